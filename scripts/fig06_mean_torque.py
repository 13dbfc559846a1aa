"""Fig. 6: whine response versus speed for several mean torques, from results/fig06_mean_torque.nc.

Writes figures/fig06_mean_torque.png. Run from the repository root after
``gearsweep run studies/fig06_mean_torque.yaml``:

    python scripts/fig06_mean_torque.py [--results results] [--figures figures]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import xarray as xr  # noqa: E402

from gearsweep.plot.whine import natural_frequency, plot_response_vs_speed  # noqa: E402

STUDY = "fig06_mean_torque"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--results", type=Path, default=Path("results"))
    parser.add_argument("--figures", type=Path, default=Path("figures"))
    args = parser.parse_args()
    args.figures.mkdir(parents=True, exist_ok=True)
    path = args.results / f"{STUDY}.nc"
    if not path.exists():
        raise SystemExit(f"{path} not found: run `gearsweep run studies/{STUDY}.yaml` first")
    with xr.open_dataset(path) as ds:
        f_n = natural_frequency(ds)
        fig, (ax, ax2) = plt.subplots(2, 1, figsize=(7.2, 7.0), sharex=True,
                                      height_ratios=[1.5, 1.0], layout="constrained")
        plot_response_vs_speed(ax, ds, by="torque", variable="p_rms", natural_frequency_hz=f_n)
        ax.get_legend().set_loc("lower right")
        ax.set_title("Fig. 6: effect of the mean driving torque on the whine response "
                     "(m_eq = 0.1527 kg, c = 5.5 N s/mm);\ndotted: mesh order n meets f_n at "
                     "60 f_n / (48 n) rpm", fontsize=9)
        ax.set_xlabel("")
        plot_response_vs_speed(ax2, ds, by="torque", variable="p_rms", natural_frequency_hz=f_n,
                               relative=True, log=False)
        ax2.get_legend().remove()
        ax2.set_title("the same, relative to the lowest torque", fontsize=9)
        fig.savefig(args.figures / "fig06_mean_torque.png", dpi=150)
        plt.close(fig)


if __name__ == "__main__":
    main()

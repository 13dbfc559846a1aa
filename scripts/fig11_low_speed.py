"""Counterpart of the experiment's Fig. 11: waterfall and mesh-order lines at driven speeds
200-800 rpm, from results/fig11_low_speed.nc.

The 48-tooth gear drives and the 32-tooth pinion (where the paper's magnetic pick-up sits) is
driven; the speed axes show the pinion's speed, mesh frequency x 60 / 32. Writes
figures/fig11_low_speed.png. Run from the repository root after
``gearsweep run studies/fig11_low_speed.yaml``:

    python scripts/fig11_low_speed.py [--results results] [--figures figures]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import xarray as xr  # noqa: E402

from gearsweep.plot.whine import plot_order_lines, plot_waterfall  # noqa: E402

STUDY = "fig11_low_speed"
DRIVEN_TEETH = 32  # the pinion, braked by the powder clutch in the rig


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
        fig = plt.figure(figsize=(13.0, 6.0), layout="constrained")
        grid = fig.add_gridspec(2, 2, width_ratios=[1.25, 1.0])
        ax3 = fig.add_subplot(grid[:, 0], projection="3d")
        plot_waterfall(ax3, ds, traces=31, driven_teeth=DRIVEN_TEETH)
        ax3.view_init(elev=28, azim=-62)
        ax3.set_title("waterfall of p (order 0, the mean of p, left out)", fontsize=9)
        ax_d = fig.add_subplot(grid[0, 1])
        plot_order_lines(ax_d, ds, driven_teeth=DRIVEN_TEETH)
        ax_d.set_title("mesh orders 1-3: displacement of p", fontsize=9)
        ax_d.set_xlabel("")
        ax_v = fig.add_subplot(grid[1, 1], sharex=ax_d)
        plot_order_lines(ax_v, ds, derivative=1, driven_teeth=DRIVEN_TEETH)
        ax_v.set_title("the same lines as velocity, 2 pi f x amplitude\n(a magnetic pick-up's"
                       " voltage follows velocity)", fontsize=9)
        fig.suptitle("Fig. 11 counterpart: driven pinion (32 teeth) at 200-800 rpm = driving gear"
                     " (48 teeth) at 133-533 rpm, mesh 107-427 Hz", fontsize=10)
        fig.savefig(args.figures / "fig11_low_speed.png", dpi=150)
        plt.close(fig)


if __name__ == "__main__":
    main()

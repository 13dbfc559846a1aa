"""Fig. 5: waterfall of the whine response and its order/speed map, from results/fig05_waterfall.nc.

Writes figures/fig05_waterfall.png (3-D waterfall: frequency x speed x amplitude) and
figures/fig05_campbell.png (order/speed colour map with mesh orders 1-3 and f_n). Run from the
repository root after ``gearsweep run studies/fig05_waterfall.yaml``:

    python scripts/fig05_waterfall.py [--results results] [--figures figures]

``--study fig05_waterfall_mesh`` draws the variant with the mesh model's k(t) and e(t) into
figures/fig05_waterfall_mesh.png and figures/fig05_campbell_mesh.png.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import xarray as xr  # noqa: E402

from gearsweep.plot.whine import (  # noqa: E402
    natural_frequency,
    plot_campbell,
    plot_order_lines,
    plot_waterfall,
)

STUDY = "fig05_waterfall"


def open_result(folder: Path, study: str) -> xr.Dataset:
    """The result of ``studies/<study>.yaml``, or a one-line hint of how to make it."""
    path = folder / f"{study}.nc"
    if not path.exists():
        raise SystemExit(f"{path} not found: run `gearsweep run studies/{study}.yaml` first")
    return xr.open_dataset(path)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--results", type=Path, default=Path("results"))
    parser.add_argument("--figures", type=Path, default=Path("figures"))
    parser.add_argument("--study", default=STUDY, help="result name (default %(default)s)")
    args = parser.parse_args()
    args.figures.mkdir(parents=True, exist_ok=True)
    suffix = args.study.removeprefix(STUDY)
    with open_result(args.results, args.study) as ds:
        f_n = natural_frequency(ds)
        fig = plt.figure(figsize=(8.0, 6.4), layout="constrained")
        ax = fig.add_subplot(projection="3d")
        plot_waterfall(ax, ds, traces=40)
        ax.view_init(elev=28, azim=-62)
        ax.set_title(f"{ds.attrs['title']}\nwaterfall of the dynamic transmission error p (Eq. 9);"
                     f" 40 of {ds.sizes['speed']} speeds drawn; order 0 (mean of p) left out",
                     fontsize=9)
        fig.savefig(args.figures / f"fig05_waterfall{suffix}.png", dpi=150)
        plt.close(fig)

        fig, (ax, ax2) = plt.subplots(2, 1, figsize=(8.0, 7.6), sharex=True,
                                      height_ratios=[1.4, 1.0], layout="constrained")
        plot_campbell(ax, ds, natural_frequency_hz=f_n)
        ax.set_title(f"{ds.attrs['title']}\ndashed: order f_n / f_mesh, f_n = sqrt(k0/m)/2pi;"
                     " circles: order n meets f_n at 60 f_n / (48 n) rpm", fontsize=9)
        ax.set_xlabel("")
        plot_order_lines(ax2, ds, orders=(1, 2, 3, 4), log=True)
        for n in (1, 2, 3, 4):
            ax2.axvline(60 * f_n / (48 * n), color="0.4", ls=":", lw=0.8)
        ax2.set_title("the mesh-order lines; dotted: 60 f_n / (48 n)", fontsize=9)
        fig.savefig(args.figures / f"fig05_campbell{suffix}.png", dpi=150)
        plt.close(fig)


if __name__ == "__main__":
    main()

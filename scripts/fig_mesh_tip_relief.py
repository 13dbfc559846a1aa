"""STE through the mesh cycle and its harmonics without and with tip relief, at one torque.

Reads ``RESULTS/mesh_tip_relief.nc`` (``gearsweep run studies/mesh_tip_relief.yaml``) and writes
``FIGURES/mesh_tip_relief.png``::

    python scripts/fig_mesh_tip_relief.py [--results results] [--figures figures]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import xarray as xr  # noqa: E402

from gearsweep.plot.mesh import plot_ste_harmonics, plot_tip_relief  # noqa: E402

STUDY = "mesh_tip_relief"


def open_result(results: Path, study: str) -> xr.Dataset:
    path = results / f"{study}.nc"
    if not path.exists():
        sys.exit(f"{path}: not found; run `gearsweep run studies/{study}.yaml -o {path}` first")
    return xr.load_dataset(path)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--results", type=Path, default=Path("results"))
    parser.add_argument("--figures", type=Path, default=Path("figures"))
    args = parser.parse_args(argv)
    args.figures.mkdir(parents=True, exist_ok=True)
    ds = open_result(args.results, STUDY)
    variants = [str(v) for v in ds["variant"].values]

    fig, (ax, bx) = plt.subplots(1, 2, figsize=(9.6, 4.0), layout="constrained",
                                 width_ratios=[3, 2])
    plot_tip_relief(ax, {v: ds.sel(variant=v) for v in variants})
    ax.legend(fontsize=8)
    ax.set_title("STE through the mesh cycle", fontsize=9)
    plot_ste_harmonics(bx, {v: ds["ste_harmonic"].sel(variant=v).values for v in variants})
    bx.legend(fontsize=8)
    bx.set_title("STE Fourier amplitudes", fontsize=9)
    fig.suptitle(f"Tip relief on both gears from the single-contact bounds to the tips, Table 1"
                 f" (consistent interpretation), T = {float(ds['torque']):g} N m", fontsize=9)
    fig.savefig(args.figures / "mesh_tip_relief.png", dpi=150)
    plt.close(fig)


if __name__ == "__main__":
    main()

"""STE peak-to-peak and first harmonic versus load, with and without tip relief.

Reads ``RESULTS/mesh_ste_vs_load.nc`` (``gearsweep run studies/mesh_ste_vs_load.yaml``) and
writes ``FIGURES/mesh_ste_vs_load.png``::

    python scripts/fig_mesh_ste_vs_load.py [--results results] [--figures figures]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import xarray as xr  # noqa: E402

from gearsweep.plot.mesh import plot_ste_vs_load  # noqa: E402

STUDY = "mesh_ste_vs_load"
DESIGN_TORQUE = 50.0  # [N m] the load the relief of the study was chosen for (Table 1's torque)


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

    fig, ax = plt.subplots(figsize=(6.4, 4.0), layout="constrained")
    for variant in ds["variant"].values:
        v = ds.sel(variant=variant)
        pp = v["ste"].max("mesh_phase") - v["ste"].min("mesh_phase")
        plot_ste_vs_load(ax, v["torque"].values, pp.values,
                         v["ste_harmonic"].sel(harmonic=1).values, label=str(variant),
                         design_torque=DESIGN_TORQUE)
    ax.legend(loc="upper left", fontsize=8)
    ax.set_title("STE versus load, Table 1 (consistent interpretation), z = 48/32, m = 2.5 mm",
                 fontsize=9)
    fig.savefig(args.figures / "mesh_ste_vs_load.png", dpi=150)
    plt.close(fig)


if __name__ == "__main__":
    main()

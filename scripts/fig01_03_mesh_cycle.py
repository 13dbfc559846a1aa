"""Figs. 1-3 from the static mesh study of Table 1 (consistent interpretation) at 50 N m.

Reads ``RESULTS/fig01_02_mesh_cycle.nc`` (``gearsweep run studies/fig01_02_mesh_cycle.yaml``) and
writes ``FIGURES/fig01_ste.png``, ``fig02_load_sharing.png`` and ``fig03_backlash_stiffness.png``::

    python scripts/fig01_03_mesh_cycle.py [--results results] [--figures figures]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import xarray as xr  # noqa: E402

from gearsweep.plot.mesh import (  # noqa: E402
    plot_backlash_stiffness,
    plot_load_sharing,
    plot_ste,
)

STUDY = "fig01_02_mesh_cycle"


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
    torque = float(ds["torque"])
    pair = f"Table 1 (consistent interpretation), z = 48/32, m = 2.5 mm, T = {torque:g} N m"

    fig, ax = plt.subplots(figsize=(6.4, 4.0), layout="constrained")
    plot_ste(ax, ds)
    ax.set_title(f"Fig. 1: static transmission error\n{pair}", fontsize=9)
    ax.legend(loc="upper left", fontsize=8)
    fig.savefig(args.figures / "fig01_ste.png", dpi=150)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(6.4, 4.0), layout="constrained")
    plot_load_sharing(ax, ds)
    ax.set_title(f"Fig. 2: load sharing, contact ratio {float(ds['contact_ratio']):.2f}\n{pair}",
                 fontsize=9)
    fig.savefig(args.figures / "fig02_load_sharing.png", dpi=150)
    plt.close(fig)

    k0 = float(ds["k_harmonic"].sel(harmonic=0))
    backlash = float(ds["gear_backlash"])
    fig, ax = plt.subplots(figsize=(6.4, 4.0), layout="constrained")
    plot_backlash_stiffness(ax, k0, backlash, mean_force=float(ds["mean_force"]))
    ax.set_title(f"Fig. 3: mesh force with backlash, k = k0 of Table 1 at {torque:g} N m\n"
                 f"backlash {backlash * 1e3:.3g} mm along the line of action", fontsize=9)
    fig.savefig(args.figures / "fig03_backlash_stiffness.png", dpi=150)
    plt.close(fig)


if __name__ == "__main__":
    main()

"""Arguments shared by the figure scripts: where results are read and figures written."""

from __future__ import annotations

import argparse
import subprocess
from pathlib import Path

import xarray as xr

from gearsweep.units import si_data_vars

ROOT = Path(__file__).resolve().parents[1]


def parse(description: str) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=description)
    p.add_argument("--results", type=Path, default=Path("results"), help="folder of .nc results")
    p.add_argument("--figures", type=Path, default=Path("figures"), help="folder for the PNGs")
    return p.parse_args()


def open_result(folder: Path, study: str) -> xr.Dataset:
    """The result of ``study`` with its data variables in SI (the file stores display units, p
    in um; the plot functions and the scripts' arithmetic work in SI and label in display
    units). Coordinates stay in their display units (backlash in mm, damping in N s/mm)."""
    path = folder / f"{study}.nc"
    if not path.exists():
        raise SystemExit(f"{path} not found: run `gearsweep run studies/{study}.yaml` first")
    return si_data_vars(xr.load_dataset(path))


def git_commit() -> str:
    """The repository's short commit (``unknown`` outside a git checkout): for the provenance
    the benchmark and calibration scripts write."""
    try:
        return subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
                              capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"

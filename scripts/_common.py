"""Arguments shared by the figure scripts: where results are read and figures written."""

from __future__ import annotations

import argparse
from pathlib import Path

import xarray as xr


def parse(description: str) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=description)
    p.add_argument("--results", type=Path, default=Path("results"), help="folder of .nc results")
    p.add_argument("--figures", type=Path, default=Path("figures"), help="folder for the PNGs")
    return p.parse_args()


def open_result(folder: Path, study: str) -> xr.Dataset:
    path = folder / f"{study}.nc"
    if not path.exists():
        raise SystemExit(f"{path} not found: run `gearsweep run studies/{study}.yaml` first")
    return xr.load_dataset(path)

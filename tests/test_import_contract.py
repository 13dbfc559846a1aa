"""Import contract: the numerics packages stay free of I/O, study and plotting libraries.

``gearsweep/kernels/`` and ``gearsweep/analysis/`` work on floats and arrays in SI units; they must
not import (at module level or inside functions) any of the heavy or user-facing libraries below,
so that they load fast, run in any worker, and keep the layering of the package (STYLE.md). The
check parses every module with ``ast`` (nothing is imported or executed), so it also covers code
paths a test run would not reach.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "gearsweep"
NUMERIC_PACKAGES = ("kernels", "analysis")
FORBIDDEN = {"xarray", "dask", "distributed", "yaml", "pydantic", "pint", "matplotlib", "netCDF4"}


def imported_modules(source: str) -> set[str]:
    """Top-level names of every module imported anywhere in ``source`` (absolute imports)."""
    names = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            names.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module.split(".")[0])
    return names


def _modules() -> list[Path]:
    return sorted(p for sub in NUMERIC_PACKAGES for p in (PACKAGE / sub).rglob("*.py"))


def test_scanner_finds_every_import_form():
    src = (
        "import xarray as xr\n"
        "import dask.array\n"
        "from matplotlib import pyplot\n"
        "from . import sibling\n"
        "def f():\n"
        "    import yaml\n"
        "    from pint.registry import UnitRegistry\n"
    )
    assert imported_modules(src) == {"xarray", "dask", "matplotlib", "yaml", "pint"}


def test_kernels_are_scanned():
    assert PACKAGE / "kernels" / "rk.py" in _modules()


@pytest.mark.parametrize("path", _modules(), ids=lambda p: str(p.relative_to(PACKAGE)))
def test_numeric_modules_import_no_io_study_or_plot_library(path):
    bad = imported_modules(path.read_text()) & FORBIDDEN
    assert not bad, f"{path.relative_to(PACKAGE.parent)} imports {sorted(bad)}"

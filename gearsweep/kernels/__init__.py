"""Numerics on floats and arrays in SI units: no files, YAML, xarray, dask or plotting here."""

from gearsweep.kernels.batch import BatchResult, simulate
from gearsweep.kernels.rk import LANES, METHODS, NODES, STAT_NAMES, STATUS_DIVERGED, STATUS_OK
from gearsweep.kernels.tables import fourier_table, phases

__all__ = [
    "LANES",
    "METHODS",
    "NODES",
    "STAT_NAMES",
    "STATUS_DIVERGED",
    "STATUS_OK",
    "BatchResult",
    "fourier_table",
    "phases",
    "simulate",
]

"""Chunks -> Dataset -> netCDF with xarray: the in-memory Dataset of a plan's results
(``assemble``, from ``resultfile.describe``), the one function that builds the other result
Datasets (``build_dataset``: mesh and analysis studies), and the atomic netCDF writer
(``write_netcdf``). The file ``gearsweep run`` streams is written without xarray
(``resultfile.ResultFile``), and is the same file."""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from gearsweep.errors import stops_held
from gearsweep.files import check_replaceable, temp_beside
from gearsweep.study.resultfile import (
    COORDS,
    VARIABLES,
    describe,
    finish,
    global_attrs,
    result_layout,
    variable_attrs,
    variable_encoding,
)

_DUCK_ARRAYS = {"dask": ("dask.array", "Array"), "pint": ("pint", "Quantity"),
                "sparse": ("sparse", "SparseArray"), "cupy": ("cupy", "ndarray"),
                "cubed": ("cubed", "Array")}
"""The duck-array libraries xarray tests every wrapped array against (``array_type(name)``):
the module and class an array of each would be an instance of."""


def _probe(module: str, cls: str) -> type:
    """A class that stands for ``module.cls`` in ``isinstance`` tests without importing
    ``module``: an object can only be an instance of it once the module has been imported."""

    class Meta(type):
        def __instancecheck__(self, obj) -> bool:
            mod = sys.modules.get(module)
            return mod is not None and isinstance(obj, getattr(mod, cls))

    return Meta(f"{cls}Probe", (), {})


def _lazy_duck_array_probes() -> None:
    """Let xarray ask whether an array is a dask array or a pint quantity (and the like) without
    importing dask or pint.

    xarray asks ``array_type(name)`` whenever it wraps an array (``Variable``, indexes), and the
    first ask imports the library when it is installed: dask and dask.array 0.3 s, pint 0.13 s of
    every ``gearsweep run``, which makes neither (an 8-case study took 1.75 s, the imports of its
    libraries 0.88 s). The answers are the same without the imports (see ``_probe``); the modules
    and their versions are still imported when xarray asks for those. Nothing is changed for a
    library already imported, or if xarray's private cache is not where it was (xarray 2025.x)."""
    try:
        from xarray.namedarray import pycompat, utils
    except ImportError:  # pragma: no cover - another xarray layout: leave it alone
        return
    cache = getattr(pycompat, "_cached_duck_array_modules", None)
    base = getattr(pycompat, "DuckArrayModule", None)
    if not isinstance(cache, dict) or base is None:  # pragma: no cover
        return

    class Lazy(base):
        def __init__(self, name: str, probe: type) -> None:  # noqa: D107 - nothing imported
            self.name = name
            self.type = (probe,)

        def __getattr__(self, attr):  # module, version, available: the real thing, on demand
            real = base(self.name)
            cache[self.name] = real
            return getattr(real, attr)

    for name, (module, cls) in _DUCK_ARRAYS.items():
        if name not in cache and name not in sys.modules:
            cache[name] = Lazy(name, _probe(module, cls))
    # "is this a dask collection?" (asked of every array it wraps): False without importing
    # dask.base for an object that lacks ``__dask_graph__``, as dask itself answers
    real = getattr(utils, "is_dask_collection", None)
    if real is not None:
        def is_dask_collection(x):
            return real(x) if hasattr(x, "__dask_graph__") else False

        utils.is_dask_collection = is_dask_collection


_lazy_duck_array_probes()


def build_dataset(
    data_vars: dict[str, tuple[tuple[str, ...], np.ndarray]],
    coords: dict[str, tuple[tuple[str, ...], np.ndarray]],
    *,
    title: str,
    study_text: str = "",
    settings: dict | None = None,
    source: str = "gearsweep",
    var_attrs: dict[str, dict] | None = None,
) -> xr.Dataset:
    """Build a result Dataset per docs/data-format.md: named dims, units and long names, global attributes
    (``resultfile.variable_attrs``, ``resultfile.global_attrs``).

    Parameters
    ----------
    data_vars, coords : dict name -> (dims, values)
        Values as stored, with units and long names from ``COORDS``/``VARIABLES`` unless
        ``var_attrs`` gives them. A variable whose ``var_attrs`` name a ``kind``
        (``gearsweep.units.KINDS``) is given in SI and stored in that kind's display unit.
    title : str
    study_text : str
        The study YAML as run (kept verbatim with its sha256).
    settings : dict
        Solver settings, written as global attributes.
    """
    var_attrs = var_attrs or {}

    def variable(name: str, dims: tuple[str, ...], values, table: dict) -> xr.Variable:
        values, attrs = variable_attrs(name, table, var_attrs.get(name), values)
        return xr.Variable(dims, values, attrs)

    ds = xr.Dataset(
        {k: variable(k, d, v, VARIABLES) for k, (d, v) in data_vars.items()},
        coords={k: variable(k, d, v, COORDS) for k, (d, v) in coords.items()},
    )
    ds.attrs.update(global_attrs(title, study_text, settings, source))
    return ds


CHUNK_CACHE_BYTES = 1 << 20
"""HDF5 chunk cache per variable while a dask-backed Dataset is written [bytes]."""


def coordinate_encoding(ds: xr.Dataset) -> dict[str, dict]:
    """netCDF encoding without ``_FillValue`` for every coordinate of ``ds`` (CF 1.10, section
    2.5.1: a coordinate has no missing values)."""
    return {name: {"_FillValue": None} for name in ds.coords}


def result_encoding(ds: xr.Dataset, codec: str | None = None,
                    shuffle: bool | None = None) -> dict[str, dict]:
    """netCDF4 encoding of a result Dataset: no ``_FillValue`` on coordinates (CF 2.5.1), the
    codec and the chunk layout on every numeric data variable (``resultfile.variable_encoding``:
    the streamed writer lays its files out alike)."""
    encoding = coordinate_encoding(ds)
    for k in ds.data_vars:
        if ds[k].dtype.kind in "fiub":
            encoding[k] = variable_encoding(ds[k].shape, ds[k].dtype, codec, shuffle)
    return encoding


def write_netcdf(ds: xr.Dataset, path: str | Path, codec: str | None = None) -> Path:
    """Write ``ds`` to ``path`` atomically: a temporary file in the same folder, then rename.

    A reader never sees a half-written file at ``path``; a crash leaves the old file (if any).
    Variables backed by dask arrays are written block by block (each block one chunk of the
    file), so the whole Dataset need not fit in memory. A stop (Ctrl-C, or a signal the caller
    handles) while xarray writes is held until the file is closed (``errors.stops_held``), then
    raised here: the temporary file is removed and nothing is renamed.
    """
    path = Path(path)
    check_replaceable(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = temp_beside(path)
    os.close(fd)
    try:
        ds = ds.copy(deep=False)  # the caller's Dataset keeps its own chunks
        encoding = result_encoding(ds, codec)
        for k in ds.data_vars:
            if ds[k].chunks and "chunksizes" in encoding.get(k, {}):
                # dask-backed: one block per file chunk (a written chunk is never read back)
                ds[k] = ds[k].chunk(dict(zip(ds[k].dims, encoding[k]["chunksizes"],
                                             strict=True)))
        if any(ds[k].chunks for k in ds.data_vars):
            import dask
            import netCDF4

            # One block at a time, in this process (never on a dask cluster a caller may have
            # made the default scheduler: the blocks read files of this machine). Each block is
            # one whole file chunk, so the HDF5 chunk cache (64 MB per variable by default,
            # which would keep most of a large study in memory) is not needed.
            cache = netCDF4.get_chunk_cache()
            netCDF4.set_chunk_cache(CHUNK_CACHE_BYTES)
            try:
                with dask.config.set(scheduler="synchronous"), stops_held():
                    ds.to_netcdf(tmp, engine="netcdf4", format="NETCDF4", encoding=encoding)
            finally:
                netCDF4.set_chunk_cache(*cache)
        else:
            with stops_held():  # a Ctrl-C lands once the file is closed, then removes it
                ds.to_netcdf(tmp, engine="netcdf4", format="NETCDF4", encoding=encoding)
        finish(Path(tmp), path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def empty_results(plan: Any) -> dict[str, np.ndarray]:
    """Full-size result arrays (NaN / status 3 'skipped') that chunks are written into."""
    out = {}
    for name, (shape, dtype) in result_layout(plan, plan.n_lanes).items():
        fill = 3 if name == "status" else False if dtype.kind == "b" else np.nan
        out[name] = np.full(shape, fill, dtype=dtype)
    return out


def store_chunk(results: dict[str, np.ndarray], plan: Any, lane0: int, lane1: int,
                chunk: dict[str, np.ndarray]) -> None:
    """Copy one chunk's arrays into the full-size result arrays."""
    for name, arr in chunk.items():
        if plan.continued:
            results[name][:, lane0:lane1] = arr
        else:
            results[name][lane0:lane1] = arr


def assemble(plan: Any, results: dict[str, np.ndarray], elapsed: float | None = None,
             kernel: float | None = None, earlier: list | tuple = (), chunks: int = 0
             ) -> xr.Dataset:
    """The Dataset of ``describe(plan)`` (docs/data-format.md), its results the lane-ordered arrays
    ``results`` put on the study's dims (``earlier``, ``chunks``: a resumed run's, as
    ``describe``)."""
    desc = describe(plan, elapsed, kernel, earlier, chunks)
    lane_shape = [len(plan.grids[d]) for d in plan.lane_dims]
    variables = {}
    for name, var in desc.variables.items():
        values = var.values
        if values is None:  # a result: (direction?, lanes, chain?, *extra) -> var.dims
            arr = results[name]
            if plan.continued:
                a = arr.reshape([arr.shape[0], *lane_shape, arr.shape[2], *arr.shape[3:]])
                now = ["direction", *plan.lane_dims, "speed"]
            else:
                a = arr.reshape([*lane_shape, *arr.shape[1:]])
                now = list(plan.lane_dims)
            now += list(var.dims[len(now):])
            values = np.transpose(a, [now.index(d) for d in var.dims])
        variables[name] = xr.Variable(var.dims, values, var.attrs)
    ds = xr.Dataset(variables).set_coords([n for n, v in desc.variables.items() if v.coord])
    ds.attrs.update(desc.attrs)
    return ds

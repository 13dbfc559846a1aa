"""Chunks -> Dataset -> netCDF: the layout of a plan's result arrays, the one function that builds
every result Dataset (with the resolved model and provenance), and the atomic netCDF writer."""

from __future__ import annotations

import hashlib
import json
import math
import os
import sys
import tempfile
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from gearsweep.files import check_replaceable
from gearsweep.model import MeshModel, mesh_frequency, model_record
from gearsweep.study.display import display_coordinates
from gearsweep.study.filelayout import file_chunks
from gearsweep.study.gearscene import gear_pair
from gearsweep.study.measured import scene_measured
from gearsweep.study.outputs import VarSpec, status_attrs
from gearsweep.study.provenance import coordinate_encoding, provenance
from gearsweep.units import KINDS, to_display

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

UM = KINDS["displacement"].cf
"""The unit of p (and of every displacement) in a result: um."""

COORDS = {
    "speed": ("rpm", "shaft speed of the driving gear (gear 1)"),
    "mesh_frequency": ("Hz", "tooth-mesh frequency"),
    "torque": ("N m", "mean driving torque T1m"),
    "mean_force": ("N", "mean mesh force F_m"),
    "damping": ("N s m-1", "mesh viscous damping c"),
    "backlash": ("m", "total backlash along the line of action"),
    "mass": ("kg", "equivalent mass m_eq"),
    "stiffness": ("N m-1", "mean mesh stiffness k0"),
    "direction": ("-", "order in which speed was swept, state carried between speeds"),
    "frequency": ("Hz", "spectrum frequency"),
    "order": ("1", "spectrum frequency / mesh frequency"),
    "alpha": ("1", "Mathieu parameter alpha = k0 / (m (N w)^2)"),
    "beta": ("1", "Mathieu parameter beta = k1 / (m (N w)^2)"),
    "gamma": ("1", "Mathieu parameter gamma = c / (m N w)"),
    "mesh_phase": ("1", "position in one mesh cycle"),
    "method": ("-", "integrator name"),
    "steps_per_period": ("1", "integration steps per mesh period"),
}
"""Units and long names of the coordinates of DATA.md (units as CF/UDUNITS strings: "1" for a
dimensionless number; the string labels, direction and method, carry none in the file)."""

VARIABLES = {
    "p_rms": (UM, "rms of p about its mean, steady state"),
    "p_pp": (UM, "peak-to-peak of p, steady state"),
    "p_max": (UM, "maximum of p, steady state"),
    "p_min": (UM, "minimum of p, steady state"),
    "p_mean": (UM, "mean of p, steady state"),
    "contact_loss_fraction": ("1", "fraction of steady-state time with |p| < backlash/2"),
    "backside_contact_fraction": ("1", "fraction of steady-state time on the back flank"),
    "impacts_per_period": ("1", "entries into contact from the gap per mesh period"),
    "settle_error": ("1", "change of the extremes of p between the halves of the window / p_pp"),
    "spectrum": (UM, "single-sided amplitude spectrum of p over whole mesh periods"),
    "floquet_multiplier": ("1", "largest |mu| of the monodromy matrix"),
    "unstable": ("1", "the equation is unstable (floquet_multiplier > 1)"),
    "integrator_unstable": ("1", "the method and step diverge where the equation does not"),
    "status": ("1", "0 ok; nonzero flags a diverged, unsettled or skipped case"),
}



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
    """Build a result Dataset per DATA.md: named dims, units and long names, global attributes.

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
        a = {}
        if name in table:
            a["units"], a["long_name"] = table[name]
        a.update(var_attrs.get(name, {}))
        kind = a.pop("kind", None)
        if kind is not None:  # given in SI, stored in the kind's display unit
            values, a["units"] = to_display(np.asarray(values), kind), KINDS[kind].cf
        a.setdefault("units", "1")
        a.setdefault("long_name", name.replace("_", " "))
        return xr.Variable(dims, values, a)

    ds = xr.Dataset(
        {k: variable(k, d, v, VARIABLES) for k, (d, v) in data_vars.items()},
        coords={k: variable(k, d, v, COORDS) for k, (d, v) in coords.items()},
    )
    if "status" in ds:
        ds["status"].attrs.update(status_attrs())
    now = datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")
    ds.attrs.update(
        Conventions="CF-1.10",
        title=title,
        history=f"{now}: {provenance()}",
        source=source,
        study=study_text,
        study_sha256=hashlib.sha256(study_text.encode()).hexdigest(),
    )
    for k, v in (settings or {}).items():
        ds.attrs[k] = v
    return ds


CODEC = "zstd"
"""Compression of the result variables: ``"zstd"`` (level ``ZSTD_LEVEL``), ``"zlib"`` (level 1),
``"blosc_lz4"`` or ``"none"``. Chosen by measurement (docs/scale.md, "Writing the result file"):
on the 1e6-case rattle result zstd writes 46 MB for 0.18 s of CPU, zlib with shuffle 42 MB for
0.93 s; the writer shares the cores with the kernel, so its CPU time is what a run pays. Readers
need HDF5's zstd filter: the netCDF4 wheels ship it (and point HDF5_PLUGIN_PATH at it on import),
as does netCDF-C >= 4.9 built with plugins."""

ZSTD_LEVEL = -1
"""zstd's level: -1, its fast mode. Against level 1, on the 1e6-case rattle result 0.116 s of CPU
to write instead of 0.147 s for 48.9 MB instead of 46.0 (+6 %; ``bench_pipeline.py --codecs``);
a 1e7-case run 13.38 s instead of 13.58 s (medians of 5 alternating runs, 26 Nov 2026: the
writer's CPU is taken from the kernel's cores). A reader decodes any level alike."""

SHUFFLE = False
"""HDF5's byte-shuffle filter before the codec: used with zlib (42 instead of 46 MB, and faster);
netCDF4-python applies it with zlib only (with zstd it is ignored)."""

CHUNK_CACHE_BYTES = 1 << 20
"""HDF5 chunk cache per variable while a dask-backed Dataset is written [bytes]."""


def variable_encoding(var: xr.Variable | xr.DataArray, codec: str | None = None,
                      shuffle: bool | None = None) -> dict:
    """netCDF4 encoding of one numeric data variable: codec, shuffle and chunk shape."""
    codec = codec or CODEC
    shuffle = SHUFFLE if shuffle is None else shuffle
    enc: dict[str, Any] = {}
    if codec == "zlib":
        enc.update(zlib=True, complevel=1, shuffle=shuffle)
    elif codec == "zstd":
        enc.update(compression="zstd", complevel=ZSTD_LEVEL, shuffle=shuffle)
    elif codec == "blosc_lz4":
        enc.update(compression="blosc_lz4", blosc_shuffle=1 if shuffle else 0)
    elif codec != "none":
        raise ValueError(f"unknown codec {codec!r}: zlib, zstd, blosc_lz4 or none")
    if var.ndim and var.size:
        dtype = np.dtype(np.int8) if var.dtype == bool else var.dtype
        enc["chunksizes"] = file_chunks(var.shape, dtype.itemsize)
    return enc


def result_encoding(ds: xr.Dataset, codec: str | None = None,
                    shuffle: bool | None = None) -> dict[str, dict]:
    """netCDF4 encoding of a result Dataset: no ``_FillValue`` on coordinates (CF 2.5.1), the
    codec and the chunk layout on every numeric data variable. The streamed writer
    (``ResultFile``) and ``write_netcdf`` use the same, so their files are laid out alike."""
    encoding = coordinate_encoding(ds)
    for k in ds.data_vars:
        if ds[k].dtype.kind in "fiub":
            encoding[k] = variable_encoding(ds[k].variable, codec, shuffle)
    return encoding


def _finish(tmp: Path, path: Path) -> None:
    """fsync ``tmp``, give it ordinary permissions and rename it to ``path``."""
    with open(tmp, "rb+") as fh:
        os.fsync(fh.fileno())
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)  # mkstemp made it private (0600); a result file is not
    os.replace(tmp, path)


def write_netcdf(ds: xr.Dataset, path: str | Path, codec: str | None = None) -> Path:
    """Write ``ds`` to ``path`` atomically: a temporary file in the same folder, then rename.

    A reader never sees a half-written file at ``path``; a crash leaves the old file (if any).
    Variables backed by dask arrays are written block by block (each block one chunk of the
    file), so the whole Dataset need not fit in memory.
    """
    path = Path(path)
    check_replaceable(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".partial", dir=path.parent)
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
                with dask.config.set(scheduler="synchronous"):
                    ds.to_netcdf(tmp, engine="netcdf4", format="NETCDF4", encoding=encoding)
            finally:
                netCDF4.set_chunk_cache(*cache)
        else:
            ds.to_netcdf(tmp, engine="netcdf4", format="NETCDF4", encoding=encoding)
        _finish(Path(tmp), path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


class _SkipResults:
    """xarray's ``ArrayWriter`` interface: writes the coordinates and the other variables of
    the skeleton at once, and leaves the result variables (``skip``) to ``ResultFile.write``."""

    def __init__(self, skip: set[str]) -> None:
        self.skip = skip

    def add(self, source, target, region=None) -> None:
        if getattr(target, "variable_name", None) in self.skip:
            return
        target[region or ...] = np.asarray(source)


class ResultFile:
    """The netCDF file of a plan's results, written chunk by chunk as the chunks finish.

    ``ResultFile(plan, path)`` creates ``tmp`` (default: a temporary file beside ``path``) with
    every dimension, coordinate, variable and attribute of the Dataset that ``assemble`` builds,
    the result variables still unwritten; ``write(lane0, lane1, arrays)`` puts one chunk's
    arrays (``run_chunk``'s layout) where they belong, in any order, as one hyperslab per run of
    whole rows; ``close(elapsed, kernel)`` writes the global attributes (in ``assemble``'s
    order, with the run's timings), fsyncs and renames ``tmp`` to ``path``; ``abort()`` removes
    ``tmp``. The data, coordinates, attributes and encoding are those ``write_netcdf`` gives the
    in-memory Dataset of ``run_plan`` (tested). Not thread-safe: one thread writes at a time.
    """

    def __init__(self, plan: Any, path: str | Path, tmp: str | Path | None = None,
                 codec: str | None = None, shuffle: bool | None = None) -> None:
        from xarray.backends.netCDF4_ import NETCDF4_PYTHON_LOCK, NetCDF4DataStore
        from xarray.conventions import encode_dataset_coordinates

        self.plan, self.path = plan, Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        if tmp is None:
            fd, tmp = tempfile.mkstemp(prefix=f".{self.path.name}.", suffix=".partial",
                                       dir=self.path.parent)
            os.close(fd)
        self.tmp = Path(tmp)
        self.layout = result_layout(plan, 1)
        template = assemble(plan, _placeholders(plan), elapsed=0.0, kernel=0.0)
        encoding = result_encoding(template, codec, shuffle)
        variables, self.attrs = encode_dataset_coordinates(template)
        for k, enc in encoding.items():
            variables[k].encoding = enc
        self.dims = {name: template[name].dims for name in self.layout}
        self._sync_fd: int | None = None
        self.flagged = 0
        """Cases written so far whose ``status`` is not 0."""
        self.beyond = 0
        """Cases written so far that are beyond the step limit (``beyond_step_limit``)."""
        # The library's lock only: xarray's default adds a per-file write lock for dask, whose
        # look-up imports dask.distributed (0.6 s); this file has one writer.
        self.store = NetCDF4DataStore.open(str(self.tmp), mode="w", format="NETCDF4",
                                           lock=NETCDF4_PYTHON_LOCK)
        try:
            self.store.store(variables, {}, set(encoding), _SkipResults(set(self.layout)))
            self.vars = {name: self.store.ds.variables[name] for name in self.layout}
            for var in self.vars.values():
                var.set_auto_maskandscale(False)
                chunking = var.chunking()
                if chunking != "contiguous":  # room for the partly filled chunks at the edges
                    size = int(np.prod(chunking)) * var.dtype.itemsize
                    var.set_var_chunk_cache(size=max(3 * size, 1 << 20))
        except BaseException:
            self.abort()
            raise

    def write(self, lane0: int, lane1: int, arrays: dict[str, np.ndarray]) -> None:
        """Write the arrays of lanes ``[lane0, lane1)`` into the file (and count its flagged
        cases and those beyond the step limit)."""
        plan = self.plan
        self.flagged += int(np.count_nonzero(arrays["status"]))
        if "beyond_step_limit" in arrays:
            self.beyond += int(np.count_nonzero(arrays["beyond_step_limit"]))
        lane_shape = [len(plan.grids[d]) for d in plan.lane_dims]
        for lo, hi, box in _boxes(lane0, lane1, lane_shape):
            for name, arr in arrays.items():
                var = self.vars[name]
                spec_extra = arr.shape[3:] if plan.continued else arr.shape[1:]
                box_shape = [b - a for a, b in box]
                if plan.continued:
                    piece = arr[:, lo - lane0:hi - lane0]
                    piece = piece.reshape([piece.shape[0], *box_shape, piece.shape[2],
                                           *spec_extra])
                    now = ["direction", *plan.lane_dims, "speed"]
                else:
                    piece = arr[lo - lane0:hi - lane0].reshape([*box_shape, *spec_extra])
                    now = list(plan.lane_dims)
                dims = self.dims[name]
                now += list(dims[len(now):])  # the extra dims, in the same order
                piece = np.transpose(piece, [now.index(d) for d in dims])
                where = dict(zip(plan.lane_dims, box, strict=True))
                index = tuple(slice(*where[d]) if d in where else slice(None) for d in dims)
                var[index] = np.ascontiguousarray(piece, dtype=var.dtype)
        self._sync()

    def _sync(self) -> None:
        """Send the bytes written so far to the disk (``fdatasync``), in the writer thread while
        the next chunk computes: the fsync of ``close`` then waits for the last chunk's only.
        Without it, that fsync waited 0.2-0.3 s for a 460 MB file (1e7 cases) after the last
        chunk, with nothing left to overlap it. Data HDF5 still holds (its chunk cache, its
        metadata) goes at ``close``."""
        if os.name != "posix":  # Windows: no fsync through a read-only descriptor
            return
        sync = getattr(os, "fdatasync", os.fsync)  # no fdatasync on macOS
        if self._sync_fd is None:
            self._sync_fd = os.open(self.tmp, os.O_RDONLY)
        sync(self._sync_fd)

    def _release(self) -> None:
        if self._sync_fd is not None:
            os.close(self._sync_fd)
            self._sync_fd = None

    def close(self, elapsed: float | None = None, kernel: float | None = None) -> Path:
        """Write the global attributes with the run's timings, close, fsync and rename."""
        attrs = dict(self.attrs)
        for key, value in (("elapsed_seconds", elapsed), ("kernel_seconds", kernel)):
            if value is None:
                attrs.pop(key, None)
            else:
                attrs[key] = round(value, 3)
        try:
            self.store.set_attributes({k: self.store.encode_attribute(v)
                                       for k, v in attrs.items()})
            self.store.close()
            self._release()
            _finish(self.tmp, self.path)
        except BaseException:
            self.abort()
            raise
        return self.path

    def abort(self) -> None:
        """Close and remove the unfinished file."""
        try:
            self.store.close()
        except Exception:  # noqa: BLE001 -- already failing; the file goes anyway
            pass
        self._release()
        self.tmp.unlink(missing_ok=True)


def _placeholders(plan: Any) -> dict[str, np.ndarray]:
    """Result arrays of the full shape that hold no memory (one element, broadcast)."""
    return {name: np.broadcast_to(np.zeros((), dtype), shape)
            for name, (shape, dtype) in result_layout(plan, plan.n_lanes).items()}


def _boxes(a: int, b: int, shape: list[int]) -> list[tuple[int, int, tuple[tuple[int, int], ...]]]:
    """Lanes ``[a, b)`` of a C-order grid of ``shape`` as consecutive boxes: (first lane, end
    lane, ((start, stop) per dim)). A run of whole rows is one box."""
    if a >= b:
        return []
    if len(shape) <= 1:
        return [(a, b, ((a, b),) * len(shape))]
    inner = math.prod(shape[1:])
    i0, r0 = divmod(a, inner)
    i1, r1 = divmod(b, inner)
    out = []

    def within(i: int, lo: int, hi: int) -> None:
        for x, y, box in _boxes(lo, hi, shape[1:]):
            out.append((i * inner + x, i * inner + y, ((i, i + 1), *box)))

    if i0 == i1:
        within(i0, r0, r1)
        return out
    if r0:
        within(i0, r0, inner)
        i0 += 1
    if i1 > i0:
        out.append((i0 * inner, i1 * inner, ((i0, i1), *((0, n) for n in shape[1:]))))
    if r1:
        within(i1, 0, r1)
    return out


# --------------------------------------------------------------------------- a plan's results


def result_layout(plan: Any, lanes: int) -> dict[str, tuple[tuple[int, ...], np.dtype]]:
    """Shape and dtype of every result array for ``lanes`` lanes, in the Dataset's order:
    (directions?, lanes, chain?, *extra)."""
    lead = ([len(plan.directions)] if plan.continued else []) + [lanes] + (
        [plan.chain] if plan.continued else [])
    out = {}
    for name, spec in plan.specs.items():
        extra = [len(spec.extra_coords[d]) for d in spec.extra_dims]
        out[name] = (tuple(lead + extra), np.dtype(spec.dtype))
    out["status"] = (tuple(lead), np.dtype(np.int8))
    return out


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
             kernel: float | None = None) -> xr.Dataset:
    """Reshape the lane-ordered arrays onto the study's dims and build the Dataset (DATA.md)."""
    lane_shape = [len(plan.grids[d]) for d in plan.lane_dims]
    data_vars = {}
    for name, arr in results.items():
        spec = plan.specs.get(name, VarSpec())
        if plan.continued:
            # (direction, lanes, speed, *extra) -> (direction, *lane_dims, speed, *extra) -> dims
            a = arr.reshape([arr.shape[0], *lane_shape, arr.shape[2], *arr.shape[3:]])
            order_now = ["direction", *plan.lane_dims, "speed", *spec.extra_dims]
            target = ["direction", *plan.dims, *spec.extra_dims]
            a = np.transpose(a, [order_now.index(d) for d in target])
            dims = tuple(target)
        else:
            a = arr.reshape([*lane_shape, *arr.shape[1:]])
            dims = (*plan.dims, *spec.extra_dims)
        data_vars[name] = (dims, a)
    coords: dict[str, tuple] = {d: ((d,), plan.grids[d]) for d in plan.dims}
    if plan.continued:
        coords["direction"] = (("direction",), np.array(plan.directions))
    if isinstance(plan.model, MeshModel):
        coords["mesh_frequency"] = (("speed",), mesh_frequency(plan.grids["speed"],
                                                               plan.model.teeth))
    for spec in plan.specs.values():
        for d, v in spec.extra_coords.items():
            coords.setdefault(d, ((d,), v))
        for name, c in spec.aux_coords.items():
            coords.setdefault(name, c)
    s = plan.study.solver
    settings = {
        "scene": plan.study.scene.kind,
        "method": s.method,
        "steps_per_period": s.steps_per_period,
        "kink_aware": int(s.kink_aware),
        "transient_periods": s.transient_periods,
        "record_periods": s.record_periods,  # the study's name for it
        "divergence_factor": s.divergence_factor,
        "settle_tolerance": s.settle_tolerance,
        "step_guard": s.step_guard,
        "cases": plan.n_cases,
    }
    if elapsed is not None:
        settings["elapsed_seconds"] = round(elapsed, 3)
    if kernel is not None:
        settings["kernel_seconds"] = round(kernel, 3)
    var_attrs = {n: sp.result_attrs() for n, sp in plan.specs.items()}
    ds = build_dataset(data_vars, coords, title=plan.study.title, study_text=plan.text,
                       settings=settings, var_attrs=var_attrs,
                       source=f"gearsweep study, scene {plan.study.scene.kind!r}")
    ds = display_coordinates(ds)  # swept coordinates in the study's units (gearsweep.units)
    ds.attrs["model"] = json.dumps(model_record(plan.model))
    if getattr(plan.study.scene, "gear", None) is not None:
        ds = ds.assign(gear_variables(plan))
    if getattr(plan.study.scene, "excitation", None) is not None:
        ds = ds.assign(excitation_variables(plan))
    if "speed" in ds.coords and isinstance(plan.model, MeshModel):
        ds["speed"].attrs["gear"] = f"driving gear (gear 1, {plan.model.teeth} teeth)"
    return ds


def display_variable(dims: tuple[str, ...], si_values, kind: str, **attrs) -> xr.Variable:
    """A result variable of ``kind`` from SI values: stored in the kind's display unit."""
    return xr.Variable(dims, to_display(np.asarray(si_values, float), kind),
                       {"units": KINDS[kind].cf, **attrs})


def gear_variables(plan: Any) -> dict[str, xr.Variable]:
    """What a gear scene's pair gave the model at each load: k0, k_n and the e(t) harmonics the
    kernel used (over ``torque`` when the load is swept), so the result shows its excitation."""
    if plan.gear_load_swept:
        torques = plan.case_torques({d: plan.grids[d] for d in plan.grids
                                     if d in ("torque", "mean_force")})
        models = [plan.model_for_load(float(t)) for t in torques]
        lead = ("torque",) if "torque" in plan.grids else ("mean_force",)
    else:
        models, lead = [plan.model], ()

    nh = max(1, *(len(hs) for m in models for hs in (m.stiffness_harmonics, m.ste_harmonics)))

    def stack(values: list) -> np.ndarray:
        a = np.asarray(values, float)
        return a if lead else a[0]

    def amplitudes(harmonics) -> list[float]:
        return [h.amplitude for h in harmonics] + [0.0] * (nh - len(harmonics))

    pair = gear_pair(plan.study.scene.gear).check()  # geometry: the same at every load
    return {
        "gear_contact_ratio": xr.Variable((), pair.contact_ratio, {
            "units": "1", "long_name": "transverse contact ratio of the gear pair",
            "gear": pair.name}),
        "gear_base_radius_1": display_variable((), pair.base_radius1, "length",
                                               long_name="base radius of the driving gear 1"),
        "gear_base_radius_2": display_variable((), pair.base_radius2, "length",
                                               long_name="base radius of the driven gear 2"),
        "harmonic": xr.Variable(("harmonic",), np.arange(1, nh + 1), {
            "units": "1", "long_name": "harmonic order in mesh orders"}),
        "gear_stiffness": display_variable(lead, stack([m.stiffness for m in models]),
                                           "stiffness", long_name="mean mesh stiffness k0 of the"
                                           " gear pair at the load"),
        "gear_stiffness_harmonic": display_variable(
            (*lead, "harmonic"), stack([amplitudes(m.stiffness_harmonics) for m in models]),
            "stiffness", long_name="amplitude of the mesh stiffness harmonic k_n the kernel used"
            " (none: constant stiffness)"),
        "gear_ste_harmonic": display_variable(
            (*lead, "harmonic"), stack([amplitudes(m.ste_harmonics) for m in models]),
            "displacement", long_name="amplitude of the transmission-error harmonic e_n the"
            " kernel used (loaded STE with constant k0; STE - F/k(t) with k(t))"),
    }


def excitation_variables(plan: Any) -> dict[str, xr.Variable]:
    """A scene's excitation file: the residuals of its fit and the harmonics the kernel used
    (``excitation_order`` in mesh orders), so the result shows how well the series holds the
    samples. Residuals are NaN for what the file does not give."""
    sc = plan.study.scene
    fit = scene_measured(sc, plan.model.mean_force)
    ex = sc.excitation
    nan = float("nan")
    k_fit, e_fit = fit.stiffness_fit, fit.excitation_fit
    out = {
        "excitation_fit_residual_ste": display_variable(
            (), fit.ste_residual_rms, "displacement", long_name="rms of measured STE - the"
            " model's quasi-static STE at the samples (F_m / k(t) + e(t) with k(t); mean + e(t)"
            " with constant stiffness)", max=to_display(fit.ste_residual_max, "displacement"),
            samples=e_fit.samples if e_fit else 0, file=ex.file, harmonics=ex.harmonics,
            span=ex.span),
        "excitation_fit_residual_stiffness": display_variable(
            (), k_fit.residual_rms if k_fit else nan, "stiffness", long_name="rms of measured"
            " mesh stiffness - its fitted series at the samples",
            max=to_display(k_fit.residual_max if k_fit else nan, "stiffness"),
            samples=k_fit.samples if k_fit else 0, file=ex.file),
    }
    for name, f, kind, what in (("ste", e_fit, "displacement", "excitation e(t) the kernel used"),
                                ("stiffness", k_fit, "stiffness", "mesh stiffness fitted")):
        if f is None:
            continue  # both fits have the same orders (gear.measured.fit_orders)
        out["excitation_order"] = xr.Variable(("excitation_order",), np.array(
            [h.order for h in f.harmonics]), {"units": "1", "long_name": "fitted mesh order"})
        out[f"excitation_{name}_amplitude"] = display_variable(
            ("excitation_order",), np.array([h.amplitude for h in f.harmonics]), kind,
            long_name=f"amplitude of the {what}, cos(2 pi order phi + phase)")
        out[f"excitation_{name}_phase"] = xr.Variable(
            ("excitation_order",), np.array([h.phase for h in f.harmonics]),
            {"units": "rad", "long_name": f"phase of the {what}"})
    return out

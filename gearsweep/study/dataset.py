"""The one function that builds every result Dataset, and the atomic netCDF writer (DATA.md)."""

from __future__ import annotations

import hashlib
import os
import tempfile
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import xarray as xr

from gearsweep.study.provenance import coordinate_encoding, provenance

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
    "order": ("-", "spectrum frequency / mesh frequency"),
    "alpha": ("-", "Mathieu parameter alpha = k0 / (m (N w)^2)"),
    "beta": ("-", "Mathieu parameter beta = k1 / (m (N w)^2)"),
    "gamma": ("-", "Mathieu parameter gamma = c / (m N w)"),
    "mesh_phase": ("-", "position in one mesh cycle"),
    "method": ("-", "integrator name"),
    "steps_per_period": ("-", "integration steps per mesh period"),
}
"""Units and long names of the coordinates of DATA.md (units as CF/UDUNITS strings)."""

VARIABLES = {
    "p_rms": ("m", "rms of p about its mean, steady state"),
    "p_pp": ("m", "peak-to-peak of p, steady state"),
    "p_max": ("m", "maximum of p, steady state"),
    "p_min": ("m", "minimum of p, steady state"),
    "p_mean": ("m", "mean of p, steady state"),
    "contact_loss_fraction": ("1", "fraction of steady-state time with |p| < backlash/2"),
    "backside_contact_fraction": ("1", "fraction of steady-state time on the back flank"),
    "impacts_per_period": ("1", "entries into contact from the gap per mesh period"),
    "settle_error": ("1", "change of the extremes of p between the halves of the window / p_pp"),
    "spectrum": ("m", "single-sided amplitude spectrum of p over whole mesh periods"),
    "floquet_multiplier": ("1", "largest |mu| of the monodromy matrix"),
    "unstable": ("1", "the equation is unstable (floquet_multiplier > 1)"),
    "integrator_unstable": ("1", "the method and step diverge where the equation does not"),
    "status": ("1", "0 ok; nonzero flags a diverged, unsettled or skipped case"),
}

STATUS_CODES = {
    0: "ok",
    1: "diverged: p became non-finite or exceeded divergence_factor x its static scale",
    2: "not settled: settle_error above solver.settle_tolerance (results kept)",
    3: "skipped: the step is beyond the method's stability limit for this case",
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
        Values in SI (speed in rpm). Units and long names come from ``COORDS``/``VARIABLES``
        unless ``var_attrs`` gives them.
    title : str
    study_text : str
        The study YAML as run (kept verbatim with its sha256).
    settings : dict
        Solver settings, written as global attributes.
    """
    var_attrs = var_attrs or {}

    def attrs(name: str, table: dict) -> dict:
        a = {}
        if name in table:
            a["units"], a["long_name"] = table[name]
        a.update(var_attrs.get(name, {}))
        a.setdefault("units", "1")
        a.setdefault("long_name", name.replace("_", " "))
        return a

    ds = xr.Dataset(
        {k: xr.Variable(d, v, attrs(k, VARIABLES)) for k, (d, v) in data_vars.items()},
        coords={k: xr.Variable(d, v, attrs(k, COORDS)) for k, (d, v) in coords.items()},
    )
    if "status" in ds:
        ds["status"].attrs["flag_values"] = np.array(sorted(STATUS_CODES), dtype=np.int8)
        ds["status"].attrs["flag_meanings"] = " ".join(
            STATUS_CODES[k].split(":")[0].replace(" ", "_") for k in sorted(STATUS_CODES))
        ds["status"].attrs["codes"] = "; ".join(f"{k} {v}" for k, v in STATUS_CODES.items())
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


CHUNK_CACHE_BYTES = 1 << 20
"""HDF5 chunk cache per variable while a streamed Dataset is written [bytes]."""


def write_netcdf(ds: xr.Dataset, path: str | Path) -> Path:
    """Write ``ds`` to ``path`` atomically: a temporary file in the same folder, then rename.

    A reader never sees a half-written file at ``path``; a crash leaves the old file (if any).
    Variables backed by dask arrays are written block by block (each block one chunk of the
    file), so the whole Dataset need not fit in memory.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".partial", dir=path.parent)
    os.close(fd)
    try:
        ds = ds.copy(deep=False)  # the caller's Dataset keeps its own chunks
        encoding = coordinate_encoding(ds)  # CF 2.5.1: no _FillValue on coordinates
        for k in ds.data_vars:
            if ds[k].chunks:  # dask-backed (streamed from disk): regular blocks, one file chunk
                size = {d: max(c) for d, c in zip(ds[k].dims, ds[k].chunks, strict=True)}
                ds[k] = ds[k].chunk(size)  # each (a written chunk is never read back)
            if ds[k].dtype.kind in "fiub":
                encoding[k] = {"zlib": True, "complevel": 1}
                if ds[k].chunks:
                    encoding[k]["chunksizes"] = tuple(max(c) for c in ds[k].chunks)
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
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp made it private (0600); a result file is not
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path

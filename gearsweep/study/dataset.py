"""Chunks -> Dataset -> netCDF: the layout of a plan's result arrays, the one function that builds
every result Dataset (with the resolved model and provenance), and the atomic netCDF writer."""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from gearsweep.model import MeshModel, mesh_frequency, model_record
from gearsweep.study.display import display_coordinates
from gearsweep.study.gearscene import gear_pair
from gearsweep.study.measured import scene_measured
from gearsweep.study.outputs import VarSpec
from gearsweep.study.provenance import coordinate_encoding, provenance
from gearsweep.units import KINDS, to_display

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

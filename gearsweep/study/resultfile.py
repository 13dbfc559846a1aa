"""A plan's result file without xarray: what it holds (``describe``) and the writer that streams
the chunks into it as they finish (``ResultFile``).

``describe(plan)`` is the one account of a result: every variable (dims, values or, for a result,
its shape and dtype, attributes) and the global attributes, in the file's order. ``dataset.assemble``
makes the in-memory Dataset of ``run_plan`` from it, and ``ResultFile`` writes the file of
``gearsweep run`` from it with netCDF4 alone, encoded as xarray encodes that Dataset (CF: NaN as
the ``_FillValue`` of floating variables, none on coordinates; booleans as int8 with
``dtype: "bool"``; a ``coordinates`` attribute naming the auxiliary coordinates; strings as
variable-length strings). ``tests/test_resultfile.py`` checks, for every study of ``studies/``,
that the two files are the same variable for variable: order, dims, dtypes, chunks, filters, fill
values, attributes in order, values.

Why not xarray here: the writer runs beside the kernel, on the same cores, and importing xarray
(with pandas) and encoding the template through it took 0.27 s of CPU of every run, 13 % of a
1e6-case run on 2 cores (docs/scale.md).
"""

from __future__ import annotations

import errno
import hashlib
import json
import math
import os
import shutil
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from gearsweep.files import ordinary_mode, temp_beside
from gearsweep.kernels.cuda import device_name
from gearsweep.model import SWEEPABLE, MeshModel, mesh_frequency, model_record
from gearsweep.study.filelayout import file_chunks
from gearsweep.study.gearscene import gear_pair, warned_once
from gearsweep.study.measured import scene_measured
from gearsweep.study.outputs import VarSpec, parted_cases, status_attrs
from gearsweep.study.provenance import provenance
from gearsweep.units import KINDS, decimal_coordinates, to_display

try:
    import resource
except ImportError:  # Windows: no file-size limit to read
    resource = None

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
"""Units and long names of the coordinates of docs/data-format.md (units as CF/UDUNITS strings: "1" for a
dimensionless number; the string labels, direction and method, carry none in the file). Swept
coordinates are stored in their display unit (``display_coordinate``), not the SI unit here."""

VARIABLES = {
    "p_rms": (UM, "rms of p about its mean, steady state"),
    "p_pp": (UM, "peak-to-peak of p, steady state"),
    "p_max": (UM, "maximum of p, steady state"),
    "p_min": (UM, "minimum of p, steady state"),
    "p_mean": (UM, "mean of p, steady state"),
    "contact_loss_fraction": ("1", "fraction of steady-state time with |p| < backlash/2"),
    "backside_contact_fraction": ("1", "fraction of steady-state time on the back flank"),
    "contact_lost": ("1", ("loaded flanks part in the steady state: p_min < 0 under F_m > 0"
                           " (drive flanks), p_max > 0 under F_m < 0 (back flanks), p of both"
                           " signs at F_m = 0 (data-format.md)")),
    "impacts_per_period": ("1", "entries into contact from the gap per mesh period"),
    "settle_error": ("1", "change of the extremes of p between the halves of the window / p_pp"),
    "transient_left": ("1", ("share of the start's free vibration left after the transient"
                             " (damping or the step's map; above settle_tolerance: status 2)")),
    "spectrum": (UM, "single-sided amplitude spectrum of p over whole mesh periods"),
    "floquet_multiplier": ("1", ("largest |mu| of the monodromy matrix of the linear equation,"
                                 " teeth in contact (no backlash, no forcing)")),
    "unstable": ("1", ("the equation is unstable (floquet_multiplier above the variable's threshold"
                      " attribute; false also where floquet_multiplier is NaN: not computed)")),
    "integrator_unstable": ("1", ("the method and step diverge where the equation does not (false"
                                  " also where floquet_multiplier is NaN: not computed)")),
    "status": ("1", "0 ok; nonzero flags a diverged, unsettled or skipped case"),
}

P_MEANING = ("p = r1 theta1 - r2 theta2 - e(t), Eq. (5) of Choi, Lee & Shin (1997): the mesh"
             " deflection where k(t) is a gear pair's (e = STE - F_m/k), the dynamic minus the"
             " static TE where e is the loaded STE; the dynamic TE is p + e (spectrum option"
             " dte); dimensionless in the Mathieu scene")
"""What ``p`` in the long names of the result variables means (their ``comment``; with the long
name and units within ``filelayout.ATTRIBUTE_TEXT_BYTES``: docs/data-format.md says the rest)."""

# ------------------------------------------------------------------------------- attributes


def variable_attrs(name: str, table: dict, extra: dict | None = None, values=None
                   ) -> tuple[Any, dict]:
    """(values, attributes) of a variable: units and long name from ``table`` unless ``extra``
    gives them; an ``extra`` that names a ``kind`` (``gearsweep.units.KINDS``) means ``values``
    are SI, returned in that kind's display unit."""
    a: dict[str, Any] = {}
    if name in table:
        a["units"], a["long_name"] = table[name]
    a.update(extra or {})
    kind = a.pop("kind", None)
    if kind is not None:  # given in SI, stored in the kind's display unit
        values, a["units"] = to_display(np.asarray(values), kind), KINDS[kind].cf
    if values is not None and np.asarray(values).dtype.kind in "OSU":
        a.pop("units", None)  # a label (method, direction, variant, scene): no unit
    else:
        a.setdefault("units", "1")
    a.setdefault("long_name", name.replace("_", " "))
    return values, a


def history_line(when: datetime | None = None) -> str:
    """This run's line of ``history``: the time stamp (UTC; ``when``, default now) and
    ``provenance()``."""
    return f"{(when or datetime.now(UTC)).strftime('%Y-%m-%dT%H:%M:%SZ')}: {provenance()}"


def global_attrs(title: str, study_text: str = "", settings: dict | None = None,
                 source: str = "gearsweep") -> dict[str, Any]:
    """A result's global attributes (docs/data-format.md): conventions, title, history (time stamp and
    ``provenance``), source, the study text as run with its sha256, then ``settings``."""
    attrs: dict[str, Any] = {
        "Conventions": "CF-1.10", "title": title, "history": history_line(),
        "source": source, "study": study_text,
        "study_sha256": hashlib.sha256(study_text.encode()).hexdigest()}
    attrs.update(settings or {})
    return attrs


@dataclass(frozen=True)
class EarlierRun:
    """An earlier run of a study whose saved chunks a resumed run used
    (``checkpoint.ChunkStore.earlier_runs``, from the records it kept per saved chunk)."""

    history: str | None
    """Its line of ``history`` (its start: time stamp and ``provenance()``); ``None``: not
    recorded."""
    chunks: int
    """Its chunks that the resumed run used."""
    elapsed: float
    """Its chunk phase until its last saved chunk [s]; NaN: not recorded."""
    kernel: float | None
    """Its time in the kernel until then [s] (``kernel_seconds``); ``None``: not measured."""


UNRECORDED = ("time unknown: an earlier run that saved chunks of this study but kept no record"
              " of its command or timings")
"""The line of ``history`` of an ``EarlierRun`` whose own line was not recorded."""


def run_attrs(history: str, elapsed: float | None, kernel: float | None,
              earlier: tuple[EarlierRun, ...] | list[EarlierRun] = (), chunks: int = 0
              ) -> dict[str, Any]:
    """The global attributes that say how a result was made: ``history``, ``elapsed_seconds``,
    ``kernel_seconds`` (``None``: left out) of this run (its ``history`` line, its chunk phase
    and kernel seconds) and, for a resumed run (``earlier``: the runs whose saved chunks it used,
    oldest first; ``chunks``: those it computed itself), the same summed over the runs.

    A resumed result's ``history`` has one line per run that contributed, oldest first (CF and
    the netCDF User Guide: a program *appends* its line), ``elapsed_seconds`` and
    ``kernel_seconds`` are the totals over those runs, and ``run_chunks``,
    ``run_elapsed_seconds`` and ``run_kernel_seconds`` give each run's share, in the order of
    the ``history`` lines (NaN where a run's was not recorded; then the total is NaN too). A
    result made in one run has neither the extra lines nor the ``run_*`` attributes."""
    if not earlier:
        return {"history": history, "elapsed_seconds": None if elapsed is None else round(elapsed, 3),
                "kernel_seconds": None if kernel is None else round(kernel, 3)}
    nan = float("nan")
    each_elapsed = [round(r.elapsed, 3) for r in earlier] + [
        nan if elapsed is None else round(elapsed, 3)]
    each_kernel = [nan if r.kernel is None else round(r.kernel, 3) for r in earlier] + [
        nan if kernel is None else round(kernel, 3)]
    return {
        "history": "\n".join([*(r.history or UNRECORDED for r in earlier), history]),
        "elapsed_seconds": None if elapsed is None else round(sum(each_elapsed), 3),
        "kernel_seconds": None if kernel is None else round(sum(each_kernel), 3),
        "run_chunks": np.array([*(r.chunks for r in earlier), chunks], dtype=np.int64),
        "run_elapsed_seconds": np.array(each_elapsed),
        "run_kernel_seconds": np.array(each_kernel)}


def with_run_attrs(attrs: dict[str, Any], made: dict[str, Any]) -> dict[str, Any]:
    """``attrs`` with those of ``run_attrs`` (``made``; ``None`` ones left out): ``history`` and
    the timings where they were, the ``run_*`` ones right after the last timing."""
    out = {k: made.get(k, v) for k, v in attrs.items() if not k.startswith("run_")}
    out.update({k: v for k, v in made.items() if not k.startswith("run_")})
    runs = {k: v for k, v in made.items() if k.startswith("run_")}
    if runs:
        keys = list(out)
        at = max((keys.index(k) + 1 for k in ("elapsed_seconds", "kernel_seconds") if k in out),
                 default=len(keys))
        out = {**dict(list(out.items())[:at]), **runs, **dict(list(out.items())[at:])}
    return {k: v for k, v in out.items() if v is not None}


def display_coordinate(name: str, values: np.ndarray, attrs: dict) -> tuple[np.ndarray, dict]:
    """A swept coordinate in its display unit (values and ``units``): backlash in mm, damping in
    N s/mm, speed in rpm, ... rounded to 14 significant digits (``units.decimal_coordinates``),
    so that a study sweeping ``backlash: [0.1 mm, 0.2 mm]`` (or ``[100 um, 200 um]``) gives
    ``ds.sel(backlash=0.1)``. Dimensionless quantities carry CF's ``units: "1"``; string
    coordinates carry no unit."""
    attrs = dict(attrs)
    if np.asarray(values).dtype.kind in "OSU":
        attrs.pop("units", None)
        return values, attrs
    if attrs.get("units") == "-":
        attrs["units"] = "1"
    kind = SWEEPABLE.get(name)
    if kind is None or kind == "dimensionless":
        return values, attrs
    attrs["units"] = KINDS[kind].cf
    return decimal_coordinates(to_display(values, kind)), attrs  # 100 um -> 0.1 (mm), exactly


def data_attrs(attrs: dict) -> dict:
    """A result variable's attributes as stored: ``units: "1"`` for "-", and what ``p`` means
    (``comment``) where its long name speaks of p."""
    attrs = dict(attrs)
    if attrs.get("units") == "-":
        attrs["units"] = "1"
    if " p " in f" {attrs.get('long_name', '')} ".replace(",", " "):
        attrs.setdefault("comment", P_MEANING)
    return attrs


# ------------------------------------------------------------------------------ description


@dataclass
class Var:
    """One variable of a result: its dims and attributes, and its values or, for a result
    variable written chunk by chunk, its shape and dtype (``values`` is ``None``)."""

    dims: tuple[str, ...]
    values: np.ndarray | None
    attrs: dict[str, Any]
    coord: bool = False
    """A coordinate (a dimension's, or an auxiliary one such as ``mesh_frequency``)."""
    shape: tuple[int, ...] = ()
    dtype: np.dtype = field(default_factory=lambda: np.dtype(float))

    def __post_init__(self) -> None:
        if self.values is not None:
            self.values = np.asarray(self.values)
            self.shape, self.dtype = self.values.shape, self.values.dtype


@dataclass
class Description:
    """A result: its variables (in the file's order) and global attributes."""

    variables: dict[str, Var]
    attrs: dict[str, Any]


def result_layout(plan: Any, lanes: int) -> dict[str, tuple[tuple[int, ...], np.dtype]]:
    """Shape and dtype of every result array for ``lanes`` lanes (the chunks' layout, before
    they are put on the study's dims), in the file's order: (directions?, lanes, chain?,
    *extra)."""
    lead = ([len(plan.directions)] if plan.continued else []) + [lanes] + (
        [plan.chain] if plan.continued else [])
    out = {}
    for name, spec in plan.specs.items():
        extra = [len(spec.extra_coords[d]) for d in spec.extra_dims]
        out[name] = (tuple(lead + extra), np.dtype(spec.dtype))
    out["status"] = (tuple(lead), np.dtype(np.int8))
    return out


def result_dims(plan: Any, name: str) -> tuple[str, ...]:
    """The dims of the result variable ``name`` in the file: (direction?, *study dims,
    *extra)."""
    spec = plan.specs.get(name, VarSpec())
    return (*(["direction"] if plan.continued else []), *plan.dims, *spec.extra_dims)


def describe(plan: Any, elapsed: float | None = None, kernel: float | None = None,
             earlier: tuple[EarlierRun, ...] | list[EarlierRun] = (), chunks: int = 0
             ) -> Description:
    """Every variable and attribute of ``plan``'s result (docs/data-format.md), the results as
    shapes; ``earlier`` and ``chunks``: a resumed run's (``run_attrs``)."""
    sizes = {d: len(plan.grids[d]) for d in plan.dims}
    if plan.continued:
        sizes["direction"] = len(plan.directions)
    variables: dict[str, Var] = {}
    for name, (_, dtype) in result_layout(plan, plan.n_lanes).items():
        spec = plan.specs.get(name)
        _, attrs = variable_attrs(name, VARIABLES, spec.result_attrs() if spec else None)
        if name == "status":
            attrs.update(status_attrs())
        dims = result_dims(plan, name)
        shape = tuple(sizes[d] if d in sizes else len(spec.extra_coords[d]) for d in dims)
        variables[name] = Var(dims, None, data_attrs(attrs), shape=shape, dtype=dtype)

    coords: dict[str, tuple[tuple[str, ...], Any]] = {d: ((d,), plan.grids[d]) for d in plan.dims}
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
    for name, (dims, values) in coords.items():
        values, attrs = variable_attrs(name, COORDS, None, values)
        values, attrs = display_coordinate(name, np.asarray(values), attrs)
        variables[name] = Var(tuple(dims), values, attrs, coord=True)
    if "speed" in variables and isinstance(plan.model, MeshModel):
        variables["speed"].attrs["gear"] = f"driving gear (gear 1, {plan.model.teeth} teeth)"

    if getattr(plan.study.scene, "gear", None) is not None:
        variables.update(gear_variables(plan))
    if getattr(plan.study.scene, "excitation", None) is not None:
        variables.update(excitation_variables(plan))

    s = plan.study.solver
    settings: dict[str, Any] = {
        "scene": plan.study.scene.kind,
        "method": s.method,
        "steps_per_period": s.steps_per_period,
        "kink_aware": int(s.kink_aware),
        "transient_periods": s.transient_periods,
        "record_periods": s.record_periods,  # the study's name for it
        "divergence_factor": s.divergence_factor,
        "settle_tolerance": s.settle_tolerance,
        "step_guard": s.step_guard,
        "device": plan.device,  # where the kernel ran (auto resolved), and in what precision:
        "precision": s.precision,  # float32 on a GPU differs from float64 by 5e-5 relative
        **({"device_name": device_name()} if plan.device == "cuda" else {}),  # which GPU
        "cases": plan.n_cases,
        **initial_state_attrs(plan),
    }
    if elapsed is not None:
        settings["elapsed_seconds"] = round(elapsed, 3)
    if kernel is not None:
        settings["kernel_seconds"] = round(kernel, 3)
    attrs = global_attrs(plan.study.title, plan.text, settings,
                         source=f"gearsweep study, scene {plan.study.scene.kind!r}")
    attrs["model"] = json.dumps(model_record(plan.model))
    if plan.model_swept:
        attrs["model_swept"] = " ".join(plan.model_swept)
    if plan.excitation_sha256 is not None:
        attrs["excitation_sha256"] = plan.excitation_sha256
    if getattr(plan.study.scene, "excitation", None) is not None and plan.study._base_folder:
        # where the study's relative paths were read from: its result runs again from there
        # (``api.result_study``; it looked in the working folder: no such file)
        attrs["study_folder"] = plan.study._base_folder
    if earlier:
        attrs = with_run_attrs(attrs, run_attrs(attrs["history"], elapsed, kernel, earlier,
                                                chunks))
    return Description(variables, attrs)


def unit_in_name(cf: str) -> str:
    """A UDUNITS unit as a suffix of an attribute name (no spaces, no hyphens: ``um`` -> ``um``,
    ``mm s-1`` -> ``mm_per_s``), as ``elapsed_seconds`` carries its unit."""
    words = []
    for w in cf.split():
        words += ["per", w.removesuffix("-1")] if w.endswith("-1") else [w]
    return "_".join(words)


def initial_state_attrs(plan: Any) -> dict[str, Any]:
    """The solver's start (``initial_displacement``, ``initial_velocity``) as global attributes:
    dimensional ones in their kind's display unit, the unit in the name (``initial_displacement_um``,
    ``initial_velocity_mm_per_s``; ``static`` as written), a Mathieu scene's bare numbers under the
    study's names. A result's verdict may hang on its start (stability_rig.yaml's 1 um: the
    paper's criterion is growth by divergence_factor from it); it was only in the study text."""
    s = plan.study.solver
    if plan.dimensionless:
        return {"initial_displacement": s.initial_displacement,
                "initial_velocity": s.initial_velocity}
    out = {}
    for name, kind, value in (("initial_displacement", "displacement", s.initial_displacement),
                              ("initial_velocity", "velocity", s.initial_velocity)):
        shown = value if isinstance(value, str) else float(to_display(np.asarray(value, float),
                                                                      kind))
        out[f"{name}_{unit_in_name(KINDS[kind].cf)}"] = shown
    return out


def display_variable(dims: tuple[str, ...], si_values, kind: str, **attrs) -> Var:
    """A variable of ``kind`` from SI values: stored in the kind's display unit."""
    return Var(dims, to_display(np.asarray(si_values, float), kind),
               {"units": KINDS[kind].cf, **attrs})


def gear_variables(plan: Any) -> dict[str, Var]:
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

    k_from, kh_from, e_from = plan.gear_sources
    with warned_once():
        pair = gear_pair(plan.study.scene.gear).check()  # geometry: the same at every load
    return {
        "gear_contact_ratio": Var((), pair.contact_ratio, {
            "units": "1", "long_name": "transverse contact ratio of the gear pair",
            "gear": pair.name}),
        "gear_base_radius_1": display_variable((), pair.base_radius1, "length",
                                               long_name="base radius of the driving gear 1"),
        "gear_base_radius_2": display_variable((), pair.base_radius2, "length",
                                               long_name="base radius of the driven gear 2"),
        "harmonic": Var(("harmonic",), np.arange(1, nh + 1), {
            "units": "1", "long_name": "harmonic order in mesh orders"}, coord=True),
        "gear_stiffness": display_variable(lead, stack([m.stiffness for m in models]),
                                           "stiffness", long_name=GEAR_LABELS["k0", k_from]),
        "gear_stiffness_harmonic": display_variable(
            (*lead, "harmonic"), stack([amplitudes(m.stiffness_harmonics) for m in models]),
            "stiffness", long_name=GEAR_LABELS["k_n", kh_from]),
        "gear_ste_harmonic": display_variable(
            (*lead, "harmonic"), stack([amplitudes(m.ste_harmonics) for m in models]),
            "displacement", long_name=GEAR_LABELS["e_n", e_from, k_from == "typed"]),
    }


GEAR_LABELS = {
    ("k0", "pair"): "mean mesh stiffness k0 of the gear pair at the load, the kernel's",
    ("k0", "typed"): ("mean mesh stiffness k0 the kernel used: typed in the scene's stiffness"
                      " beside the gear pair, not the pair's own k0"),
    ("k_n", "pair"): ("amplitude of the gear pair's mesh stiffness harmonic k_n at the load, the"
                      " kernel's"),
    ("k_n", "typed"): ("amplitude of the mesh stiffness harmonic k_n the kernel used: typed in"
                       " the scene's stiffness_harmonics beside the gear pair, not the pair's"),
    ("k_n", "none"): ("amplitude of the mesh stiffness harmonic k_n the kernel used: none"
                      " (zeros), the stiffness is constant k0"),
    ("e_n", "loaded_ste", True): ("amplitude of the harmonic e_n of the gear pair's loaded STE"
                                  " at the load: the excitation e(t) the kernel used with the"
                                  " typed stiffness"),
    ("e_n", "loaded_ste", False): ("amplitude of the harmonic e_n of the gear pair's loaded STE"
                                   " at the load: the excitation e(t) the kernel used with"
                                   " constant k0"),
    ("e_n", "no_load_te", False): ("amplitude of the harmonic e_n of STE - F_m / k(t) with the"
                                   " gear pair's k(t) at the load: the excitation e(t) the"
                                   " kernel used"),
}
"""The ``long_name`` of a gear scene's ``gear_*`` variables by where the model's k0, k_n and e_n
came from (``plan.gear_sources``): the pair's at the load or typed in beside it. Fig. 5's scene
types the paper's k0 = 1073 kN/mm beside a pair whose own k0 is 219 kN/mm, and its file named
the typed value "mean mesh stiffness k0 of the gear pair at the load" (an outside tester)."""


EXCITATION_SOURCES = {
    "samples": "a least-squares fit of the file's samples (their DFT where evenly spaced)",
    "integrated": ("the file's harmonics, integrated by its mesh study between the breaks of the"
                   " mesh (k_harmonic, and ste_harmonic or e_harmonic)")}
"""Where the harmonics of an excitation file come from, as the result's ``source`` says."""


def excitation_variables(plan: Any) -> dict[str, Var]:
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
            span=ex.span, source=EXCITATION_SOURCES[fit.source]),
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
        out["excitation_order"] = Var(("excitation_order",), np.array(
            [h.order for h in f.harmonics]), {"units": "1", "long_name": "fitted mesh order"},
            coord=True)
        out[f"excitation_{name}_amplitude"] = display_variable(
            ("excitation_order",), np.array([h.amplitude for h in f.harmonics]), kind,
            long_name=f"amplitude of the {what}, cos(2 pi order phi + phase)")
        out[f"excitation_{name}_phase"] = Var(
            ("excitation_order",), np.array([h.phase for h in f.harmonics]),
            {"units": "rad", "long_name": f"phase of the {what}"})
    return out


# --------------------------------------------------------------------------------- encoding

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


def variable_encoding(shape: tuple[int, ...], dtype, codec: str | None = None,
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
    if len(shape) and math.prod(shape):
        dtype = np.dtype(np.int8) if np.dtype(dtype) == bool else np.dtype(dtype)
        enc["chunksizes"] = file_chunks(tuple(shape), dtype.itemsize)
    return enc


def _coordinates_attrs(variables: dict[str, Var]) -> tuple[dict[str, str], str | None]:
    """xarray's ``coordinates`` attributes (``conventions.encode_dataset_coordinates``): per
    variable, the auxiliary coordinates whose dims are all among its own, sorted by name; those
    on no variable go into a global ``coordinates`` attribute."""
    aux = [n for n, v in variables.items() if v.coord and v.dims != (n,)]
    per: dict[str, list[str]] = {}
    for name, var in variables.items():
        if name in aux:
            continue
        names = sorted(c for c in aux if name not in var.dims
                       and set(variables[c].dims) <= set(var.dims))
        if names:
            per[name] = names
    written = {c for names in per.values() for c in names}
    rest = sorted(set(aux) - written)
    return {k: " ".join(v) for k, v in per.items()}, (" ".join(rest) if rest else None)


def encoded(desc: Description, codec: str | None = None, shuffle: bool | None = None
            ) -> list[tuple[str, dict, dict, np.ndarray | None]]:
    """Each variable as ``netCDF4.Dataset.createVariable`` takes it, as xarray (``to_netcdf``
    with ``dataset.result_encoding``) makes it: (name, createVariable's arguments, attributes
    in order, values to write or ``None`` for a result). Raises ``TypeError`` for a dtype this
    encoder does not know (it knows those of gearsweep's results: floats, integers, booleans,
    strings)."""
    coordinates, _ = _coordinates_attrs(desc.variables)
    out = []
    for name, var in desc.variables.items():
        dtype = np.dtype(var.dtype)
        attrs = dict(var.attrs)
        if name in coordinates:
            attrs["coordinates"] = coordinates[name]
        fill = None
        encoding: dict[str, Any] = {}
        values = var.values
        if not var.coord:  # a coordinate: no codec, no _FillValue (CF 2.5.1)
            if dtype.kind not in "fiub":
                raise TypeError(f"{name}: no netCDF encoding here for a data variable of {dtype}")
            encoding = variable_encoding(var.shape, dtype, codec, shuffle)
            if dtype.kind == "f":
                fill = dtype.type(np.nan)
        if dtype.kind == "b":
            attrs["dtype"] = "bool"
            dtype = np.dtype(np.int8)
            values = None if values is None else values.astype(np.int8)
        if dtype.kind == "U":
            datatype: Any = str
            values = None if values is None else values.astype(object)
        elif dtype.kind in "fiu":
            datatype = dtype
        else:
            raise TypeError(f"{name}: no netCDF encoding here for {dtype}")
        args = dict(varname=name, datatype=datatype, dimensions=var.dims, zlib=False,
                    complevel=4, shuffle=True, fletcher32=False, contiguous=False,
                    chunksizes=None, endian="native", least_significant_digit=None,
                    fill_value=fill)  # xarray's defaults (NetCDF4DataStore.prepare_variable)
        args.update(encoding)
        out.append((name, args, attrs, values))
    return out


def global_attributes(desc: Description) -> dict[str, Any]:
    """The file's global attributes: the description's, and xarray's global ``coordinates``
    where an auxiliary coordinate is on no variable."""
    _, rest = _coordinates_attrs(desc.variables)
    return dict(desc.attrs, coordinates=rest) if rest else dict(desc.attrs)


def _set_attribute(obj, key: str, value) -> None:
    """One attribute, as xarray sets it (a list of strings as NC_STRING)."""
    a = np.asarray(value)
    if a.dtype.kind in "US" and a.size > 1:
        obj.setncattr_string(key, value)
    else:
        obj.setncattr(key, value)


# ----------------------------------------------------------------------------------- writer


def finish(tmp: Path, path: Path) -> None:
    """fsync ``tmp``, give it ordinary permissions and rename it to ``path``."""
    with open(tmp, "rb+") as fh:
        os.fsync(fh.fileno())
    os.chmod(tmp, ordinary_mode())  # mkstemp made it private (0600); a result file is not
    os.replace(tmp, path)


def boxes(a: int, b: int, shape: list[int]) -> list[tuple[int, int, tuple[tuple[int, int], ...]]]:
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
        for x, y, box in boxes(lo, hi, shape[1:]):
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


METADATA_BYTES = 1 << 20
"""Bytes a write of a result file may add beyond its data (HDF5's metadata, the global
attributes): the margin within which a failed write is put down to the file-size limit."""


class ResultFile:
    """The netCDF file of a plan's results, written chunk by chunk as the chunks finish.

    ``ResultFile(plan, path)`` creates ``tmp`` (default: a temporary file beside ``path``) with
    every dimension, coordinate, variable and attribute of ``describe(plan)``, the result
    variables still unwritten; ``write(lane0, lane1, arrays)`` puts one chunk's arrays
    (``run_chunk``'s layout) where they belong, in any order, as one hyperslab per run of whole
    rows; ``close(elapsed, kernel)`` writes the global attributes (with the run's timings),
    fsyncs and renames ``tmp`` to ``path``; ``abort()`` removes ``tmp``. The file is the one
    ``dataset.write_netcdf`` writes of ``run_plan``'s Dataset (tested). Not thread-safe: one
    thread writes at a time.
    """

    def __init__(self, plan: Any, path: str | Path, tmp: str | Path | None = None,
                 codec: str | None = None, shuffle: bool | None = None) -> None:
        import netCDF4  # here, not at import: the estimate and validate need no netCDF4

        self.plan, self.path = plan, Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        if tmp is None:
            fd, tmp = temp_beside(self.path)
            os.close(fd)
        self.tmp = Path(tmp)
        desc = describe(plan, elapsed=0.0, kernel=0.0)
        self.attrs = global_attributes(desc)
        self.dims = {name: desc.variables[name].dims for name in result_layout(plan, 1)}
        self._sync_fd: int | None = None
        self.flagged = 0
        """Cases written so far whose ``status`` is not 0."""
        self.beyond = 0
        """Cases written so far that are beyond the step limit (``beyond_step_limit``)."""
        self.contact_lost = 0
        """Cases written so far whose teeth would separate (``contact_lost``)."""
        self.parted: int | None = 0 if "contact_loss_fraction" in self.dims and (
            "spectrum" in plan.outputs) else None
        """Cases written so far whose flanks parted (``outputs.parted_cases``), counted only for
        a spectrum's warning (``outputs.impact_aliasing``); ``None`` where the stats that say so
        are not stored, or there is no spectrum to warn of (no pass over every case then)."""
        self.written: dict[str, Any] = {}
        """The global attributes as ``close`` wrote them."""
        self.nc = netCDF4.Dataset(str(self.tmp), mode="w", format="NETCDF4")
        coordinates = 0  # bytes written so far
        try:
            dims: dict[str, int] = {}
            for var in desc.variables.values():
                dims.update(zip(var.dims, var.shape, strict=True))
            for dim, size in dims.items():
                self.nc.createDimension(dim, size)
            self.vars = {}
            for name, args, attrs, values in encoded(desc, codec, shuffle):
                var = self.nc.createVariable(**args)
                var.setncatts(attrs)
                var.set_auto_maskandscale(False)
                if values is not None:
                    coordinates += np.asarray(values).nbytes
                    var[...] = values
                elif name in self.dims:
                    self.vars[name] = var
                    chunking = var.chunking()
                    if chunking != "contiguous":
                        # Room for one file chunk: the one a chunk of lanes leaves partly
                        # filled, which the next completes. The others are compressed and
                        # written as each write fills them, beside the next chunk's kernel;
                        # with room for three, up to three per variable were kept until the
                        # close, after the last kernel (the 1e6-case result in the CLI's
                        # chunks: the last write and the close took 41 ms, now 25 ms).
                        size = int(np.prod(chunking)) * var.dtype.itemsize
                        var.set_var_chunk_cache(size=max(size, 1 << 20))
        except RuntimeError as exc:  # writing the coordinates failed (a full disk, say)
            error = self._write_error(exc, coordinates)
            self.abort()
            raise error from exc
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
        if "contact_lost" in arrays:
            self.contact_lost += int(np.count_nonzero(arrays["contact_lost"]))
        if self.parted is not None:
            self.parted += parted_cases(arrays) or 0
        lane_shape = [len(plan.grids[d]) for d in plan.lane_dims]
        for lo, hi, box in boxes(lane0, lane1, lane_shape):
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
                try:
                    var[index] = np.ascontiguousarray(piece, dtype=var.dtype)
                except RuntimeError as exc:  # netCDF4's every failure; HDF5's cause is not kept
                    raise self._write_error(exc, sum(a.nbytes for a in arrays.values())) from exc
        self._sync()

    def _write_error(self, exc: RuntimeError, pending: int = 0) -> OSError:
        """The ``OSError`` of a failed netCDF write (``NetCDF: HDF error`` alone), ``pending``
        bytes at most being written (uncompressed): where the file and they reach this
        process's file-size limit (``ulimit -f``; a write past it fails with EFBIG), that limit;
        else the room left on the file's disk, a full disk being the usual cause. (A limit
        reached was said as a failure of the netCDF library with 36 GB free on the disk, and
        told to fix that; an outside tester's finding.)"""
        limit = resource.getrlimit(resource.RLIMIT_FSIZE)[0] if resource else None
        if limit is not None and limit != resource.RLIM_INFINITY:
            try:
                size = os.stat(self.tmp).st_size
            except OSError:
                size = limit
            if size + pending + METADATA_BYTES >= limit:
                return OSError(errno.EFBIG, f"this process's file-size limit ({limit / 1e6:.1f}"
                               f" MB, ulimit -f) is reached at {size / 1e6:.1f} MB of the file"
                               f" (the netCDF library failed: {exc})", str(self.tmp))
        try:
            free = shutil.disk_usage(self.tmp.parent).free
        except OSError:
            return OSError(errno.EIO, f"the netCDF library failed ({exc})", str(self.tmp))
        code = errno.ENOSPC if free < (64 << 20) else errno.EIO
        return OSError(code, f"the netCDF library failed ({exc}; {free / 1e6:.1f} MB free on"
                       " its disk)", str(self.tmp))

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

    def close(self, elapsed: float | None = None, kernel: float | None = None,
              earlier: tuple[EarlierRun, ...] | list[EarlierRun] = (), chunks: int = 0) -> Path:
        """Write the global attributes with the run's timings (``run_attrs``: those of a
        resumed run with its ``earlier`` runs' and the ``chunks`` it computed), close, fsync and
        rename. ``written``: the global attributes as written."""
        attrs = with_run_attrs(self.attrs, run_attrs(self.attrs["history"], elapsed, kernel,
                                                     earlier, chunks))
        self.written = attrs
        try:
            try:
                for key, value in attrs.items():
                    _set_attribute(self.nc, key, value)
                self.nc.close()  # HDF5 writes what it holds: the last file chunks, metadata
            except RuntimeError as exc:  # (what HDF5 held: at most its chunk caches)
                held = sum(v.get_var_chunk_cache()[0] for v in self.vars.values())
                raise self._write_error(exc, held) from exc
            self._release()
            finish(self.tmp, self.path)
        except BaseException:
            self.abort()
            raise
        return self.path

    def abort(self) -> None:
        """Close and remove the unfinished file."""
        try:
            self.nc.close()
        except Exception:  # noqa: BLE001 -- already failing (or closed); the file goes anyway
            pass
        self._release()
        self.tmp.unlink(missing_ok=True)

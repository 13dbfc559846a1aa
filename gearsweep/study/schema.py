"""Study files: YAML validated by pydantic models, units parsed once into SI floats.

A study names its scene (the model variant, which switches on only the terms it needs), the
values it sweeps, how the speed axis is continued, the solver and the outputs::

    title: Rattle jump hysteresis (Fig. 8)
    scene:
      kind: rattle              # whine | rattle | full | mathieu
      mass: 0.1527 kg
      teeth: 48
      stiffness: 1073 kN/mm
      damping: 100 N*s/m
      backlash: 0.5 mm
      fluctuation: [{amplitude: 300 N, order: 1}]
    sweep:
      speed: {start: 5000 rpm, stop: 10000 rpm, num: 400}
    continuation: [up, down]
    solver: {method: rk4, steps_per_period: 64, transient_periods: 100, record_periods: 50}
    outputs: [stats, {spectrum: {max_order: 4}}]   # a name, or {name: {options}}

A scene of the gear drive may name a gear pair (``gear: table1_consistent`` or a mapping of
``GearPair`` fields) instead of ``teeth``, ``stiffness``, ``stiffness_harmonics`` and ``ste``: they
are then computed from its static mesh at the scene's mean load (``gearsweep.study.gearscene``).
A ``stiffness`` (and ``stiffness_harmonics``) typed in beside the gear replaces the pair's k(t);
e(t) is then the pair's loaded STE (``plan.build_model``).
A top-level ``type: mesh`` selects a static mesh study (``gearsweep.study.mesh``).

Every model forbids unknown keys. ``load_study`` turns any problem into one ``StudyError`` line:
file, field path, value, and what is allowed.
"""

from __future__ import annotations

import difflib
import math
import re
import signal
import typing
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from types import SimpleNamespace
from typing import Annotated, Any, Literal

import numpy as np
import yaml
from pydantic import (
    AfterValidator,
    BaseModel,
    BeforeValidator,
    Field,
    TypeAdapter,
    ValidationError,
    ValidationInfo,
    WrapValidator,
    field_validator,
    model_validator,
)
from pydantic_core import PydanticCustomError

from gearsweep.errors import (
    NO_VALUE,
    GearStudyError,
    GeometryError,
    StudyError,
    article,
    problem_line,
    signals_held,
)
from gearsweep.files import NotUtf8, utf8_text
from gearsweep.gear import GeometryWarning
from gearsweep.gear.excitation import static_mesh
from gearsweep.gear.mesh import load_cautions
from gearsweep.kernels.cuda import DEVICES, PRECISIONS
from gearsweep.kernels.tableaux import KERNEL_METHODS
from gearsweep.model import SWEEPABLE
from gearsweep.study.analysis_specs import AnalysisSpec, AnalysisStudy
from gearsweep.study.gearscene import (
    PRESETS,
    GearField,
    GearSpec,
    TipReliefSpec,
    gear_pair,
    preset_centre_said,
    scene_excitation,
    tip_reliefs,
    warned_once,
)
from gearsweep.study.measured import ExcitationSpec, excitation_problems
from gearsweep.study.outputs import OUTPUTS, configure
from gearsweep.study.quantities import (
    MAX_SPEED,
    MAX_STE,
    MAX_STEPS_PER_PERIOD,
    MAX_TEETH,
    MIN_SPEED,
    SEL_APART,
    SPEED_BELOW,
    SPEED_BEYOND,
    STE_BEYOND,
    Angle,
    Count,
    Damping,
    Displacement,
    EachOnce,
    FieldProblems,
    Flag,
    Force,
    Inertia,
    Length,
    Mass,
    Order,
    Real,
    Speed,
    Stiffness,
    Strict,
    Torque,
    Velocity,
    WholeStudy,
    speed_bound,
)
from gearsweep.units import (
    COORDINATE_DIGITS,
    KINDS,
    QuantityKind,
    UnitParseError,
    decimal_coordinates,
    to_display,
    to_si,
)


class Drive(Strict):
    """Physical inputs of Eq. (7): inertias and base radii give m_eq and the force scale."""

    inertia_1: Inertia = Field(gt=0, description="polar inertia of the driving gear")
    inertia_2: Inertia = Field(gt=0, description="polar inertia of the driven gear")
    base_radius_1: Length | None = Field(None, gt=0, description="base radius of the driving gear"
                                         " (required without a scene.gear, which gives it)")
    base_radius_2: Length | None = Field(None, gt=0, description="base radius of the driven gear"
                                         " (required without a scene.gear, which gives it)")


class StiffnessHarmonic(Strict):
    amplitude: Stiffness = Field(ge=0, description="k_n of Eq. (1)")
    order: Order | None = Field(None, gt=0, allow_inf_nan=False,
                               description="mesh order (default: position + 1; once per list)")
    phase: Angle | None = Field(None, description="phase a_n (default 0; beside a 'gear': the"
                                " pair's phase of that order, so that k(t) and the pair's STE"
                                " keep their relative phase)")


def _ste_bound(v: float) -> float:
    if v > MAX_STE:
        raise ValueError(STE_BEYOND)
    return v


class SteHarmonic(Strict):
    amplitude: Annotated[Displacement, AfterValidator(_ste_bound)] = Field(
        ge=0, description=f"STE harmonic e_n (at most {MAX_STE * 1e3:g} mm)")
    order: Order | None = Field(None, gt=0, allow_inf_nan=False,
                               description="mesh order (default: position + 1; once per list)")
    phase: Angle = Field(0.0, description="phase")


AMPLITUDE = "expected a force (e.g. '300 N') or a torque (e.g. '5 N*m')"


class Fluctuation(Strict):
    """A harmonic of the driving-torque fluctuation: a force [N] or a torque [N m] (Eq. 7)."""

    amplitude: Real | str = Field(description=(
        "force [N] or driving torque [N m] amplitude; a torque is the force m_eq r1 T / I1 of"
        " Eq. (7) with scene.drive, or T / r1 beside a typed mass (a driven gear much heavier"
        " than the driving one: validate notes it)"))
    order: Order = Field(gt=0, allow_inf_nan=False,
                        description="mesh order (1 = mesh frequency; 1/teeth, e.g. 1/48, = shaft;"
                        " once per list)")
    phase: Angle = Field(0.0, description="phase")

    @field_validator("amplitude", mode="before")
    @classmethod
    def _not_true_or_false(cls, v: Any) -> Any:
        if isinstance(v, bool):  # told what an amplitude is (a quantity), not Real's 'a number'
            raise ValueError(AMPLITUDE)
        return v

    @field_validator("amplitude")
    @classmethod
    def _force_or_torque(cls, v: Any) -> Any:
        for kind in ("force", "torque"):
            try:
                if not math.isfinite(to_si(v, kind)):
                    raise ValueError("expected a finite amplitude")
                return v
            except UnitParseError:
                pass
        raise ValueError(AMPLITUDE)

    @property
    def is_torque(self) -> bool:
        """The amplitude is a driving torque (it does not read as a force): Eq. (7) or F = T/r1."""
        try:
            to_si(self.amplitude, "force")
        except UnitParseError:
            return True
        return False


def swept_fields(raw: Any) -> frozenset[str]:
    """The scene fields that a study file's ``sweep:`` gives: sweeping a parameter gives the
    scene's field of that name (``SCENE_PARAMETERS``; ``mass`` is m_eq, which ``drive`` would
    give), which the scene then need not write. Written there too, it is allowed and the sweep
    replaces it (``replaced_by_sweep``). ``parse_study`` passes them to the scene's checks as the
    validation context's ``swept`` (``given_or_swept``, ``scene_presence``)."""
    sweep = raw.get("sweep") if isinstance(raw, dict) else None
    if not isinstance(sweep, dict):
        return frozenset()
    return frozenset(n for n in sweep if isinstance(n, str) and n in SWEEPABLE)


def _swept(info: ValidationInfo | None) -> frozenset[str]:
    """``swept_fields`` of the study being validated (none when validated without them)."""
    context = info.context if info is not None else None
    return frozenset(context.get("swept", ())) if isinstance(context, dict) else frozenset()


class _GivenBySweep:
    """The default of a scene field that is required unless the study sweeps it."""

    def __repr__(self) -> str:
        return "(required unless swept)"


SWEEP_GIVES = _GivenBySweep()
"""The default of a field that ``given_or_swept`` checks: not written in the scene."""


def given_or_swept(value: Any, handler: Callable[[Any], Any], info: ValidationInfo) -> Any:
    """A field a scene must give, or the study sweep (a rattle scene's ``backlash``): left out
    (its default ``SWEEP_GIVES``), it is ``None`` where the sweep gives it (``swept_fields``),
    else pydantic's own error of a required field (said as ever: "this field is required")."""
    if value is SWEEP_GIVES:
        if info.field_name in _swept(info):
            return None
        raise PydanticCustomError("missing", "Field required")
    return handler(value)


def scene_presence(has, drive_has, swept=frozenset()) -> list[tuple[tuple[str, ...], str]]:
    """The problems of which fields a whine, rattle or full scene gives, each ``(fields,
    message)`` as ``FieldProblems`` takes them (the fields the message is about: a field given
    beside another it excludes is reported on its own line; what is missing, on the scene's, in
    one line): ``has(name)`` says whether the scene gives field ``name``, ``drive_has(name)`` the
    same of its ``drive``; a field in ``swept`` (``swept_fields``) is given by the sweep, and
    need not be written. Asked by the scene's validator, and, when other errors stop that
    validator, on the file's own keys (``_problems_beside_errors``), so that a bare scene's
    problems come in one run."""
    problems = []
    if (has("mass") and has("drive")) or not (has("mass") or has("drive") or "mass" in swept):
        problems.append((("mass", "drive"), ("give exactly one of 'mass' (m_eq) and 'drive'"
                         " (inertias, radii)")))
    if has("mean_force") and has("torque"):
        problems.append((("mean_force", "torque"), ("give at most one of 'mean_force' and"
                         " 'torque'")))
    if has("drive") and has("base_radius"):
        problems.append((("base_radius",), ("with a 'drive', its 'base_radius_1' is the base"
                         " radius: leave out 'base_radius'")))
    if has("drive") and not has("gear"):
        missing = [f"'drive.{f}'" for f in ("base_radius_1", "base_radius_2") if not drive_has(f)]
        if missing:
            problems.append((("drive",), (f"{' and '.join(missing)} required (or a 'gear', which"
                             " gives the base radii)")))
    if not has("gear") and not has("excitation"):
        missing = [f"'{f}'" for f in ("teeth", "stiffness") if not (has(f) or f in swept)]
        if missing:
            problems.append(((), (f"{' and '.join(missing)} required (or a 'gear' that gives"
                             " teeth, stiffness and their harmonics)")))
    return problems


class _Driven(Strict):
    """Fields shared by the scenes of the gear drive (not the dimensionless Mathieu scene)."""

    mass: Mass | None = Field(None, gt=0, description="equivalent mass m_eq")
    drive: Drive | None = None
    teeth: Count | None = Field(None, gt=0, le=MAX_TEETH, description="teeth of the driving gear N1")
    stiffness: Stiffness | None = Field(None, gt=0, description="mean mesh stiffness k0")
    gear: GearField | None = Field(None, description="gear pair giving k(t), e(t), N1, r1;"
                                   " with 'stiffness' (and 'stiffness_harmonics') typed in beside"
                                   " it, those replace the pair's k(t) and e(t) is the pair's"
                                   " loaded STE (the paper's use of its computed STE)")
    harmonics: Count | None = Field(None, ge=1, le=100, description="Fourier harmonics of a gear")
    excitation: ExcitationSpec | None = Field(None, description="STE and/or stiffness samples"
                                              " from a file, fitted (study/measured.py)")
    damping: Damping = Field(0.0, ge=0, description="mesh viscous damping c")
    speed: Annotated[Speed, AfterValidator(speed_bound)] | None = Field(
        None, gt=0, description="driving-gear speed if not swept")
    mean_force: Force | None = Field(None, description="mean mesh force F_m")
    torque: Torque | None = Field(None, description="mean driving torque T1m")
    base_radius: Length | None = Field(None, gt=0, description="driving base radius r1")
    fluctuation: list[Fluctuation] = Field(default_factory=list)

    @model_validator(mode="after")
    def _mass_and_force(self, info: ValidationInfo) -> _Driven:
        # The independent problems of the scene at once (a user fixing one at a time met them
        # over several runs), each at the line of the field it names (they were all at the
        # scene's line, an outside tester's finding), what is missing in one line at the scene's
        problems = scene_presence(lambda f: getattr(self, f, None) is not None,
                                  lambda f: getattr(self.drive, f, None) is not None,
                                  _swept(info))
        if problems:
            raise FieldProblems(problems)
        if self.excitation is not None and self.gear is not None:  # at the later written
            raise FieldProblems([(("gear", "excitation"), ("give either 'gear' or 'excitation',"
                                  " not both"))])
        if self.excitation is not None:  # checked with the sweep (consistency_problems)
            return self
        if self.gear is None:
            if self.harmonics is not None:
                raise FieldProblems([(("harmonics",), ("'harmonics' is the number of Fourier terms"
                                      " of a 'gear'; no gear"))])
            return self
        typed = [f for f in ("teeth", "ste", "base_radius") if getattr(self, f, None)]
        if typed:
            raise FieldProblems([(("gear", *typed), (f"give either 'gear' or typed-in"
                                  f" {', '.join(typed)}, not both: the gear pair gives teeth, ste"
                                  " and base_radius (and stiffness and stiffness_harmonics, unless"
                                  " typed in to replace the pair's)"))])
        if getattr(self, "stiffness_harmonics", None) and self.stiffness is None:
            raise FieldProblems([(("gear", "stiffness_harmonics"), ("'stiffness_harmonics' beside a"
                                  " 'gear' need 'stiffness' too: a typed-in k(t) replaces the"
                                  " pair's as a whole"))])
        return self

    @property
    def r1(self) -> float | None:
        if self.drive is not None and self.drive.base_radius_1 is not None:
            return self.drive.base_radius_1
        return self.base_radius

    def drive_radii(self) -> tuple[float, float]:
        """Base radii of the drive: as given, or the gear pair's where ``drive`` omits them."""
        d = self.drive
        if d.base_radius_1 is not None and d.base_radius_2 is not None:
            return d.base_radius_1, d.base_radius_2
        pair = gear_pair(self.gear)  # the radii are geometry: any load gives the same
        return (d.base_radius_1 if d.base_radius_1 is not None else pair.base_radius1,
                d.base_radius_2 if d.base_radius_2 is not None else pair.base_radius2)


class WhineScene(_Driven):
    """Eq. (9): no backlash (f(p) = p); time-varying stiffness and STE excitation."""

    kind: Literal["whine"]
    stiffness_harmonics: list[StiffnessHarmonic] = Field(default_factory=list)
    ste: list[SteHarmonic] = Field(default_factory=list)


class RattleScene(_Driven):
    """Eq. (13): constant stiffness with backlash; torque fluctuation and STE excitation."""

    kind: Literal["rattle"]
    backlash: Annotated[Length, WrapValidator(given_or_swept)] = Field(
        SWEEP_GIVES, gt=0, validate_default=True, description="total backlash on the line of"
        " action")
    ste: list[SteHarmonic] = Field(default_factory=list)


class FullScene(_Driven):
    """Eq. (6) with every term."""

    kind: Literal["full"]
    backlash: Length = Field(0.0, ge=0, description="total backlash on the line of action")
    stiffness_harmonics: list[StiffnessHarmonic] = Field(default_factory=list)
    ste: list[SteHarmonic] = Field(default_factory=list)


class MathieuScene(Strict):
    """Eq. (11): p'' + gamma p' + (alpha + beta cos tau) p = 0 (k0 + k1 only, homogeneous)."""

    kind: Literal["mathieu"]
    alpha: Real = Field(0.25, description="k0 / (m (N w)^2)")
    beta: Real = Field(0.0, description="k1 / (m (N w)^2)")
    gamma: Real = Field(0.0, ge=0, description="c / (m N w)")


Scene = Annotated[WhineScene | RattleScene | FullScene | MathieuScene, Field(discriminator="kind")]

SCENE_PARAMETERS = {
    "whine": {"speed", "torque", "mean_force", "damping", "mass", "stiffness"},
    "rattle": {"speed", "torque", "mean_force", "damping", "mass", "stiffness", "backlash"},
    "full": {"speed", "torque", "mean_force", "damping", "mass", "stiffness", "backlash"},
    "mathieu": {"alpha", "beta", "gamma"},
}
"""Which parameters each scene lets a study sweep."""


MAX_RANGE_NUM = 10_000_000
"""The most values of a ``{start, stop, num}`` range."""


class Range(Strict):
    """``{start, stop, num}``: ``num`` values from ``start`` to ``stop`` inclusive."""

    start: Real | str
    stop: Real | str
    num: Count = Field(ge=1, le=MAX_RANGE_NUM)
    spacing: Literal["linear", "log"] = "linear"


def _one_value(v: Any) -> Any:
    """A single value given for a sweep axis (``speed: 3000 rpm``) is a one-value axis, the
    same as ``[3000 rpm]`` (a dim of length 1); YAML's true and false are no value (their own
    line says what an axis is)."""
    if isinstance(v, str | int | float) and not isinstance(v, bool):
        return [v]
    return v


SweepAxis = Annotated[list[Real | str] | Range, BeforeValidator(_one_value)]
"""One entry of ``sweep:``: a list of values, a ``{start, stop, num}`` range, or one value
(``3000 rpm``: the list ``[3000 rpm]``)."""

SWEEP_DESCRIPTION = ("each swept parameter: a list of values ([3000 rpm, 4000 rpm]), a range"
                     " {start, stop, num}, or one value (3000 rpm: the same as [3000 rpm], a"
                     " dim of length 1)")


class Solver(Strict):
    method: Literal[KERNEL_METHODS] = "rk4"
    steps_per_period: Count = Field(64, ge=4, le=MAX_STEPS_PER_PERIOD,
                                    description="steps per mesh period (at least 4 per period"
                                    " of the highest harmonic the scene lists, a gear's"
                                    " harmonics and an excitation file's fit included)")
    kink_aware: Flag = Field(
        False, description="redo steps that cross the backlash boundaries in pieces that end on "
        "them (gearsweep.kernels.kink): keeps the method's order 4/5 with backlash, where the "
        "plain step falls to order 2; no effect without backlash")
    transient_periods: Count = Field(100, ge=0, le=10**9, description="mesh periods discarded")
    record_periods: Count = Field(50, ge=1, le=10**9, description="mesh periods recorded for statistics"
                                  " (a driven scene: two cycles of its excitation at least, 2"
                                  " for mesh orders, 96 for a shaft order of 48 teeth)")
    divergence_factor: Real = Field(1e6, gt=1, description=(
        "|p| bound / static scale (of a gear scene: (|F_m| + the force amplitudes) / k0, the"
        " STE, backlash / 2 and the start, |p0| + |p'0| sqrt(m / k0); of a Mathieu scene:"
        " max(|p0|, |p'0|))"))
    settle_tolerance: Real = Field(1e-2, gt=0, description=(
        "settle_error above it: status 2 (extremes compared between the halves of the record;"
        " not a test of periodicity: an irregular motion may pass, docs/rattle.md)"))
    initial_displacement: Literal["static"] | Displacement = Field(
        0.0, description="p at t = 0 (Mathieu: a bare number; default 1); 'static': the static"
        " equilibrium of each case on the flank its load presses, b + F_m / k0 (the drive flank;"
        " -b + F_m / k0, the back flank, for F_m < 0; b = backlash / 2, k0 the mean stiffness at"
        " the case's load)")
    initial_velocity: Velocity = Field(
        0.0, description="p' at t = 0 (Mathieu: a bare number, in its own units)")
    device: Literal[DEVICES] = Field(
        "cpu", description="where the kernel runs: cpu, cuda (a CUDA GPU, docs/gpu.md) or auto"
        " (cuda where a GPU is present)")
    precision: Literal[tuple(PRECISIONS)] = Field(
        "float64", description="float32: the state in single precision (device cuda only; its"
        " error is about 6e-8 of |p|, so large against a response small beside the mean"
        " deflection: docs/gpu.md)")
    step_guard: Annotated[Literal["warn", "skip", "off"], BeforeValidator(_guard_word)] = Field(
        "warn", description="cases whose step is beyond the method's stability limit (or, a forced"
        " scene near a parametric tongue, whose fixed-step map's resonant response is more than"
        " 1 % off the exact equation's, or whose map could not be checked: docs/stability.md):"
        " flag them (warn), do not integrate them (skip, status 3; the floquet output's"
        " min_steps_per_period is still given for them), or do not check (off)")


def _guard_word(v: Any) -> Any:
    """``step_guard: off`` unquoted: YAML reads ``off`` (and ``no``, ``false``) as false, which is
    what it means here; ``on``/``yes``/``true`` (true) name no mode."""
    if v is True:
        raise ValueError("'warn', 'skip' or 'off' (YAML reads on, yes and true as true, which"
                         " names no mode)")
    return "off" if v is False else v


def _output_request(v: Any) -> Any:
    """``"stats"`` -> ``{name: stats}``; ``{spectrum: {max_order: 4}}`` -> name + options."""
    if isinstance(v, str):
        return {"name": v}
    if isinstance(v, dict) and "name" not in v:
        if len(v) != 1:
            raise ValueError("an output name, or a mapping of one output name to its options")
        ((name, options),) = v.items()
        return {"name": name, "options": {} if options is None else options}
    return v


class OutputRequest(Strict):
    """One entry of ``outputs:``: a name (``stats``) or ``{name: {option: value}}``.

    The options are checked by the output itself (``gearsweep.study.outputs.configure``).
    """

    name: str
    options: dict[str, Any] = Field(default_factory=dict)


class Study(WholeStudy):
    title: str = Field(min_length=1)
    description: str = ""
    scene: Scene
    sweep: dict[str, SweepAxis] = Field(default_factory=dict, description=SWEEP_DESCRIPTION)
    continuation: list[Literal["up", "down"]] = Field(default_factory=list)
    solver: Solver = Field(default_factory=Solver)
    outputs: list[Annotated[OutputRequest, BeforeValidator(_output_request)]] = Field(
        default_factory=lambda: [OutputRequest(name="stats")])

    @model_validator(mode="before")
    @classmethod
    def _dimensionless_start(cls, data: Any, info: ValidationInfo) -> Any:
        """The Mathieu scene is dimensionless: its ``solver.initial_displacement`` is a bare
        number (p in units of its own scale), taken as is. One written with a unit is refused
        (``1 um`` ran as p0 = 1e-6, silently: found by a new-user test)."""
        if not (isinstance(data, dict) and isinstance(data.get("scene"), dict)
                and data["scene"].get("kind") == "mathieu"
                and isinstance(data.get("solver", {}), dict)):
            return data
        if "initial_displacement" not in data.get("solver", {}):  # its default is 1, written
            # here: the field's 0 was taken as "not given", so an explicit 0 became 1
            data = dict(data, solver=dict(data.get("solver", {}), initial_displacement=1.0))
        starts = (("initial_displacement", "m", "p in units of its own scale, e.g. 1"),
                  ("initial_velocity", "m/s", "p' in its own units, e.g. 0"))
        for name, si, what in starts:
            v = data["solver"].get(name)
            if isinstance(v, bool) or isinstance(v, str) and v.strip() != "static":
                try:
                    if isinstance(v, bool):
                        raise ValueError(v)
                    float(v)
                except ValueError:
                    problem = Problem(f"solver.{name}", v, "a number (not true or false)"
                                      if isinstance(v, bool) else f"a bare number in a mathieu"
                                      f" scene ({what}): no unit there")
                    sink = (info.context or {}).get("problems") if info is not None else None
                    if sink is None:
                        raise ValueError(f"{problem.path}: {problem.message}") from None
                    sink.append(problem)
                    v = 1.0 if name == "initial_displacement" else 0.0  # reported: the rest is
                    # validated as if the default were given
            if isinstance(v, str) and v.strip() == "static" and name == "initial_displacement":
                v = "static"  # ('static ' with a space: its own problem below, on its own line)
                data = dict(data, solver=dict(data["solver"], initial_displacement=v))
            if isinstance(v, int | float | str) and not isinstance(v, bool) and v != "static":
                data = dict(data, solver=dict(data["solver"], **{name: f"{float(v)!r} {si}"}))
        return data

    @model_validator(mode="after")
    def _consistent(self, info: ValidationInfo) -> Study:
        problems = consistency_problems(self)
        sink = (info.context or {}).get("problems") if info is not None else None
        if sink is not None:  # parse_study reports every problem with its line
            sink.extend(problems)
        elif problems:
            raise ValueError(f"{problems[0].path}: {problems[0].message}")
        return self

    def grid(self, name: str) -> np.ndarray:
        """Values of swept parameter ``name`` in its canonical unit (rpm for speed, else SI)."""
        spec = self.sweep[name]
        kind = SWEEPABLE[name]
        if isinstance(spec, Range):
            a, b = to_si(spec.start, kind), to_si(spec.stop, kind)
            if spec.spacing == "log":
                return np.geomspace(a, b, spec.num)
            return np.linspace(a, b, spec.num)
        return np.array([to_si(v, kind) for v in spec], dtype=float)


@dataclass
class Problem:
    """One problem of a study: the field's path as the file writes it, the value, the message."""

    path: str
    value: Any
    message: str


SPEED_MISSING = "the speed must be swept (sweep.speed) or given (scene.speed)"


def speed_problems(kind: str, swept: bool, given: bool, continuation: list) -> list[Problem]:
    """A speed given nowhere, and a continuation without a speed sweep, of a scene of ``kind``
    (``swept``: sweep.speed is given, ``given``: scene.speed is). A continuation without a speed
    at all is one mistake, one line: that of the continuation, which says to sweep the speed."""
    out = []
    if continuation and not swept:
        allowed = ("continuation carries the state along sweep.speed: sweep the speed"
                   if kind != "mathieu" else "continuation carries the state along sweep.speed,"
                   " which a mathieu scene does not have: leave continuation out")
        out.append(Problem("continuation", list(continuation), allowed))
    elif kind != "mathieu" and not swept and not given:
        out.append(Problem("scene.speed", "(missing)", SPEED_MISSING))
    return out


def repeated_order_problems(scene) -> list[Problem]:
    """A list of harmonics (``stiffness_harmonics``, ``ste``, ``fluctuation``) that gives one
    order twice, at the second: the kernel summed them, with no word (an order left out is the
    harmonic's position + 1, so ``[{amplitude: 5 um, order: 2}, {amplitude: 1 um}]`` was two
    order-2 harmonics, 6 um; an outside tester's finding)."""
    out = []
    for name in ("stiffness_harmonics", "ste", "fluctuation"):
        seen: dict[float, int] = {}
        for i, h in enumerate(getattr(scene, name, None) or []):
            order = float(h.order if h.order is not None else i + 1)
            if order in seen:
                given = h.order is not None
                out.append(Problem(f"scene.{name}[{i}]" + (".order" if given else ""),
                                   h.order if given else f"(left out: position + 1 = {i + 1})",
                                   f"order {order:g} again (scene.{name}[{seen[order]}] has it):"
                                   " give each harmonic of a list its own order"))
            seen.setdefault(order, i)
    return out


def gear_backlash_problems(scene, swept: bool) -> list[Problem]:
    """A scene whose ``gear`` gives a backlash (``gear.backlash``, circumferential at the pitch
    circle) and whose dead zone (``scene.backlash``, on the line of action; 0 unless given in a
    full scene) says otherwise: the gear's was ignored, with no word (0.2 mm beside
    scene.backlash 0.3 mm; an outside tester's finding). Agreeing within 1 um is fine; a swept
    backlash is the dead zone beside the gear's (``swept``: nothing to refuse)."""
    gear = getattr(scene, "gear", None)
    if gear is None or gear.backlash is None or scene.kind not in ("rattle", "full") or swept:
        # Swept: the sweep's values are the dead zone, the gear's backlash thins the pair's
        # teeth (its k(t) and e(t)). Refused until 27 Nov 2026 with "leave gear.backlash out",
        # which changed the pair's stiffness with no word (k0 421.9 -> 424.8 kN/mm for an
        # outside tester's pair), and quoted the sweep as '(swept)'.
        return []
    try:
        loa = gear_pair(gear).backlash_loa
    except GeometryError:  # the pair's own line says what is wrong with it
        return []
    if not swept and abs(scene.backlash - loa) <= 1e-6:
        return []
    where = "scene.backlash"
    value = (f"{scene.backlash * 1e3:g} mm" if "backlash" in scene.model_fields_set
             else f"(not given: {scene.backlash * 1e3:g} mm)")
    # The scene does not take its dead zone from the gear (docs/mesh.md): this line said "give
    # it ... or as gear.backlash", and a full scene with gear.backlash alone was then refused
    # with the scene's default 0 mm, which the file did not write (an outside tester's finding).
    return [Problem(where, value, f"the gear's backlash is {loa * 1e3:.4g} mm on the line of"
                    f" action (gear.backlash {gear.backlash * 1e3:g} mm at the pitch circle x"
                    " cos alpha_w), but the dynamic model's dead zone is"
                    f" {where}, not taken from the gear: write scene.backlash:"
                    f" {loa * 1e3:.4g} mm (on the line of action), or leave gear.backlash out")]


def consistency_problems(study: Study) -> list[Problem]:
    """What the fields' own checks cannot see: sweep vs scene, outputs, continuation."""
    out: list[Problem] = []
    sc = study.scene
    gear = getattr(sc, "gear", None) is not None  # (its swept stiffness: gear_load_problems)
    out += sweep_name_problems(sc.kind, [n for n in study.sweep if not (gear and n == "stiffness")],
                               gear)
    out += speed_problems(sc.kind, "speed" in study.sweep, getattr(sc, "speed", None) is not None,
                          study.continuation)
    axis = study.sweep.get("speed")
    if study.continuation and axis is not None and (
            axis.num if isinstance(axis, Range) else len(axis)) < 2:
        # one speed: "up" and "down" are the same run, no state carried (an outside tester's
        # finding: accepted with no word)
        out.append(Problem("continuation", list(study.continuation), "a continuation carries"
                           " the state from speed to speed: sweep.speed needs 2 or more values"
                           " (it has one), or leave continuation out"))
    out += repeated_order_problems(sc)
    out += gear_backlash_problems(sc, "backlash" in study.sweep)
    if "mass" in study.sweep and getattr(sc, "drive", None) is not None and any(
            f.is_torque for f in getattr(sc, "fluctuation", [])):
        # a torque fluctuation's force is Eq. (7) of the drive's m_eq: a swept mass replaced the
        # one and not the other, scaling the forcing by m_drive / m_swept (an outside tester)
        out.append(Problem("sweep.mass", "(swept)", "a torque fluctuation beside scene.drive is"
                           " a force from the drive's inertias (Eq. 7), which a swept mass"
                           " would contradict: give the fluctuation as a force, or sweep a"
                           " scene with scene.mass instead of scene.drive"))
    if sc.kind != "mathieu":
        if sc.gear is not None:
            out += gear_load_problems(list(study.sweep), any(
                getattr(sc, n) is not None for n in ("torque", "mean_force")))
        elif ("torque" in study.sweep or sc.torque is not None) and sc.r1 is None:
            out.append(Problem("scene.base_radius", "(missing)", "a torque needs the driving"
                               " gear's base radius: scene.base_radius or scene.drive"))
        elif sc.r1 is None and sc.drive is None:
            for i, f in enumerate(getattr(sc, "fluctuation", [])):
                if f.is_torque:  # Eq. (7) needs r1 (and the drive's inertia)
                    out.append(Problem(f"scene.fluctuation[{i}].amplitude", f.amplitude,
                                       "a force (e.g. '300 N'), or for a torque amplitude"
                                       " give scene.base_radius (F = T / r1, a rigid driven"
                                       " gear) or scene.drive (Eq. 7: F = m_eq T r1 / I1)"))
                    break
        loads = {}
        for name in ("torque", "mean_force"):  # the swept loads in SI, for a file's own load
            try:
                with np.errstate(all="ignore"):  # a log range from -10 N m: its own line says so
                    loads[name] = study.grid(name) if name in study.sweep else None
            except Exception:  # noqa: BLE001 -- a unit problem of the sweep, reported beside
                loads[name] = None
        out += [Problem(*p) for p in excitation_problems(sc, study.sweep,
                                                         {k: v for k, v in loads.items()
                                                          if v is not None})]
        if "torque" in study.sweep and "mean_force" in study.sweep:
            out.append(Problem("sweep.mean_force", NO_VALUE, "sweep torque or mean_force, not both"))
    if study.continuation:
        if len(set(study.continuation)) != len(study.continuation):
            out.append(Problem("continuation", list(study.continuation),
                               "list each direction at most once"))
    sv = study.solver  # what the device will refuse, said when the study is read
    if sc.kind == "mathieu" and sv.initial_displacement == "static":
        out.append(Problem("solver.initial_displacement", "static", "a bare number in a mathieu"
                           " scene (default 1): 'static' is the equilibrium of a gear scene's"
                           " load, which a mathieu scene has not"))
    if sv.precision == "float32" and sv.device == "cpu":
        out.append(Problem("solver.precision", sv.precision, "float32 runs on the GPU only (the"
                           " CPU kernel is float64): set solver.device: cuda (or auto), or"
                           " precision: float64"))
    if sv.kink_aware and sv.device == "cuda" and (getattr(sc, "backlash", 0) or "backlash"
                                                  in study.sweep):
        out.append(Problem("solver.kink_aware", True, "the kink-aware step runs on the CPU only:"
                           " set solver.device: cpu, or kink_aware: false on the GPU"))
    out += output_name_problems([o.name for o in study.outputs])
    return out


def gear_load_problems(swept: list, load_given: bool) -> list[Problem]:
    """A gear scene's sweep and load: its stiffness comes from the pair at the mean load."""
    out = []
    if "stiffness" in swept:
        out.append(Problem("sweep.stiffness", NO_VALUE, "a gear scene computes its stiffness from"
                           " the gear pair; sweep torque, or type in the coefficients"))
    if not load_given and not {"torque", "mean_force"} & set(swept):
        out.append(Problem("scene.torque", "(missing)", "a 'gear' needs the mean load"
                           " (scene.torque, scene.mean_force or sweep.torque): its stiffness and"
                           " STE are computed at that load"))
    return out


def sweep_name_problems(kind: str, names: list, gear: bool = False) -> list[Problem]:
    """Entries of ``sweep:`` that the scene of ``kind`` cannot sweep (a misspelt ``sped``); a
    scene with a ``gear`` does not list the stiffness, which its pair gives
    (``gear_load_problems`` refuses sweeping it: the list offered it to a misspelling)."""
    allowed = set(SCENE_PARAMETERS[kind]) - ({"stiffness"} if gear else set())
    out = []
    for name in names:
        if name not in allowed:
            close = difflib.get_close_matches(str(name), sorted(allowed), n=1)
            hint = f"did you mean {close[0]!r}? " if close else ""
            # the name as written, as a field that is none is named (it said "not a sweepable
            # parameter" without it)
            out.append(Problem(f"sweep.{name}", NO_VALUE, f"{name!r} is not a sweepable parameter"
                               f" of the {kind!r} scene; {hint}allowed: {', '.join(sorted(allowed))}"))
    return out


def output_name_problems(names: list) -> list[Problem]:
    """Names in ``outputs:`` that are no output, listed twice, or none at all."""
    out = []
    for i, name in enumerate(names):
        if name not in OUTPUTS:
            close = difflib.get_close_matches(str(name), sorted(OUTPUTS), n=1)
            hint = f"did you mean {close[0]!r}? " if close else ""
            out.append(Problem(f"outputs[{i}]", name, f"not an output; {hint}allowed:"
                               f" {', '.join(sorted(OUTPUTS))}"))
    for i, name in enumerate(names):  # the repeat, named (it said only "list each output at
        if name in names[:i]:  # most once", not which)
            out.append(Problem(f"outputs[{i}]", name, f"listed already (outputs[{names.index(name)}]);"
                               " list each output at most once"))
    if not names:
        out.append(Problem("outputs", [], f"at least one output (leave the key out for stats);"
                           f" allowed: {', '.join(sorted(OUTPUTS))}"))
    return out


def replaced_by_sweep(study) -> list[str]:
    """Scene values that the sweep replaces (``validate`` says so): a swept parameter's value in
    the scene is not used (it need not be written there: ``swept_fields``)."""
    sc = study.scene
    load = {"torque": "mean_force", "mean_force": "torque"}  # either one gives the mean load
    out = [f"scene.{given}" for name in study.sweep
           for given in (name, load.get(name)) if given
           if given in sc.model_fields_set and getattr(sc, given, None) is not None]
    if "mass" in study.sweep and getattr(sc, "drive", None) is not None:
        out.append("scene.drive's m_eq")  # its inertias give m_eq, which the sweep replaces
    return out


def value_problems(name: str, items: list[tuple[str | int, Any]],
                   is_range: bool) -> tuple[list[Problem], list[float]]:
    """Unit and physical bounds of the values ``items`` (``(key, value)``: ``start`` and ``stop``
    of a range, or the indices of a list) of swept parameter ``name``: the problems, and the SI
    values of those that have none."""
    kind = SWEEPABLE[name]
    out: list[Problem] = []
    values = []
    for key, v in items:
        where = f"sweep.{name}.{key}" if is_range else f"sweep.{name}[{key}]"
        try:
            val = to_si(v, kind)
        except UnitParseError as exc:
            msg = str(exc)
            out.append(Problem(where, NO_VALUE, msg) if "has no unit" in msg
                       else Problem(where, v, f"{article(kind)}: {msg}"))
            continue
        if not math.isfinite(val):
            out.append(Problem(where, v, "a finite number"))
        elif name in ("speed", "mass", "stiffness", "backlash") and val <= 0:
            out.append(Problem(where, v, f"{name} must be > 0"))
        elif name == "speed" and val > MAX_SPEED:
            out.append(Problem(where, v, SPEED_BEYOND))
        elif name == "speed" and val < MIN_SPEED:
            out.append(Problem(where, v, SPEED_BELOW))
        elif name in ("damping", "gamma") and val < 0:
            out.append(Problem(where, v, f"{name} must be >= 0"))
        else:
            values.append(val)
    return out, values


def repeat_problem(where: str, written: list, values: list,
                   why: str = SEL_APART) -> Problem | None:
    """The first entry of the list ``where`` whose value equals an earlier entry's, as one
    problem at that entry naming the earlier one (``None`` when each value is there once): a
    sweep's list, an analysis' list (``analysis_problems``). ``values``: as the result holds them
    (a quantity in its display unit, rounded as its coordinate), ``written``: as the file writes
    them; ``why``: what a repeat breaks."""
    seen: dict[Any, int] = {}
    for i, val in enumerate(values):
        if val in seen:
            j = seen[val]
            return Problem(f"{where}[{i}]", written[i], f"a value not already in the list (the"
                           f" same as {where}[{j}], {written[j]!r}): each value once, or {why}")
        seen[val] = i
    return None


def analysis_problems(study: AnalysisStudy, raw: Any = None) -> list[Problem]:
    """An entry given twice in a list of the analysis whose entries become a coordinate of the
    result or name what is computed (the fields marked ``EachOnce``): it ran the same thing
    twice into a coordinate that ``ds.sel()`` could not tell apart (``methods: [rk4, rk4]``;
    an outside tester's finding). A quantity's values are compared in its display unit, as
    the result holds them: '7500 rpm' and '125 Hz' are one speed."""
    o = study.analysis
    out = []
    for name, field in type(o).model_fields.items():
        once = next((m for m in field.metadata if isinstance(m, EachOnce)), None)
        if once is None:
            continue
        values = list(getattr(o, name))
        kind = _quantity_kind(field)
        if kind is not None:
            values = [float(v) for v in decimal_coordinates(to_display(np.asarray(values), kind))]
        where = f"analysis.{name}"
        given = written_at(raw, where) if raw is not None else None
        written = list(given) if isinstance(given, list) and len(given) == len(values) else \
            list(getattr(o, name))
        problem = repeat_problem(where, written, values, once.why)
        if problem is not None:
            out.append(problem)
    return out


def grid_problems(study, with_order: bool = True) -> list[Problem]:
    """Units and physical bounds of every sweep value; ranges in increasing order."""
    out: list[Problem] = []
    for name, spec in study.sweep.items():
        if name not in SWEEPABLE:
            continue  # not a sweepable parameter: one line from consistency_problems, not more
        kind = SWEEPABLE[name]
        is_range = isinstance(spec, Range)
        raw = [("start", spec.start), ("stop", spec.stop)] if is_range else list(enumerate(spec))
        if not raw:
            out.append(Problem(f"sweep.{name}", spec, "a non-empty list or {start, stop, num}"))
            continue
        problems, values = value_problems(name, raw, is_range)
        out += problems
        shown = [float(v) for v in decimal_coordinates(to_display(np.asarray(values), kind))] \
            if kind != "dimensionless" else values  # as the file's coordinate will hold them
        if not is_range and len(values) == len(raw) and len(set(shown)) < len(shown):
            out.append(repeat_problem(f"sweep.{name}", [v for _, v in raw], shown))
        if (with_order and not is_range and len(values) == len(raw)
                and len(set(shown)) == len(shown)):  # (a value twice: said above, one line;
            # [3000 rpm, 50 Hz] was also 'out of order' on the same field)
            continued = name == "speed" and getattr(study, "continuation", None)
            down = not continued and len(values) > 1 and values[1] < values[0]
            for i in range(1, len(values)):
                if (values[i] >= values[i - 1]) if down else (values[i] <= values[i - 1]):
                    out.append(Problem(f"sweep.{name}[{i}]", raw[i][1], (
                        f"a speed below the one before ({raw[i - 1][1]!r}): a continued sweep"
                        " takes the list in increasing order (up) or in decreasing order"
                        " (down), so list the speeds in increasing order") if continued else (
                        f"a value {'above' if down else 'below'} the one before"
                        f" ({raw[i - 1][1]!r}): list the values in increasing or decreasing"
                        " order (the result's coordinate is monotonic, as CF asks)")))
                    break
        if is_range and len(values) == 2:
            a, b = values
            if a == b and spec.num > 1:
                out.append(Problem(f"sweep.{name}.stop", spec.stop, f"a stop above start"
                                   f" ({spec.start!r}): {spec.num} equal values could not be told"
                                   " apart by ds.sel(); one value is [value]"))
            elif spec.num == 1 and a < b:  # linspace(a, b, 1) is [a]: the stop was dropped
                out.append(Problem(f"sweep.{name}.num", 1, (
                    f"2 or more from {spec.start!r} to {spec.stop!r} (one value is its start"
                    f" alone, the stop unused: write [{spec.start}] for that)")))
            elif spec.spacing == "log" and (a <= 0 or b <= 0):
                end = "start" if a <= 0 else "stop"
                out.append(Problem(f"sweep.{name}.{end}", getattr(spec, end),
                                   "above zero: log spacing needs positive start and stop"))
            elif kind != "dimensionless" and spec.num > 1 and a < b and _finer_than_kept(
                    shown, spec):  # [3000 rpm, 3000.00000000001 rpm] is refused above
                out.append(Problem(f"sweep.{name}.num", spec.num, (
                    f"fewer values from {spec.start!r} to {spec.stop!r}: {spec.num} of them are"
                    f" closer than the {COORDINATE_DIGITS} significant digits the result's"
                    " coordinate keeps, so some are equal there and ds.sel() cannot tell them"
                    " apart")))
            elif with_order and a > b:  # equal only for num: 1 (above)
                out.append(Problem(f"sweep.{name}.start", spec.start, (
                    f"start must be below stop ({spec.stop!r}): give a range in increasing order"
                    " (a down sweep is 'continuation: [down]')") if spec.num > 1 else (
                    f"start must be at most stop ({spec.stop!r}); one value is [value]")))
    return out


def _finer_than_kept(shown: list[float], spec: Range) -> bool:
    """Whether neighbouring points of the range ``shown`` (start, stop in the display unit) can
    round to one value at ``COORDINATE_DIGITS`` significant digits: a linear step below the last
    kept digit of the largest end, or a log ratio within 10^(1 - digits) of 1 (arithmetic
    only: no grid is built)."""
    a, b = shown
    if spec.spacing == "log":
        return (b / a) ** (1.0 / (spec.num - 1)) - 1.0 < 10.0 ** (1 - COORDINATE_DIGITS)
    top = max(abs(a), abs(b))
    unit = 10.0 ** (math.floor(math.log10(top)) - (COORDINATE_DIGITS - 1)) if top else 0.0
    return (b - a) / (spec.num - 1) < unit


def _check_grids(study, file: str, raw=None) -> None:
    """Units and physical bounds of every sweep value (every problem at once)."""
    problems = grid_problems(study)
    if problems:
        raise _error(file, problems, raw)


# ------------------------------------------------------------------------------ locations


class _Map(dict):
    """A YAML mapping with the line of each key (``lines``) and of itself (``line``)."""

    line: int = 0
    lines: dict


class _Seq(list):
    """A YAML sequence with the line of each item (``lines``) and of itself (``line``)."""

    line: int = 0
    lines: list


class _Loader(yaml.SafeLoader):
    """PyYAML's safe loader that keeps line numbers and records duplicate keys."""

    def __init__(self, stream) -> None:
        super().__init__(stream)
        self.duplicates: list[tuple[_Map, Any, int, int]] = []
        self.odd_keys: list[tuple[_Map, str, int, Any]] = []
        """Keys YAML reads as other than a name (``on``, ``no``, ``2``, ``~``): (mapping, the key
        as written, its line, what YAML read); the mapping holds them as written."""
        self.odd_numbers: list[tuple[Any, str | int, int, str]] = []
        """Values YAML 1.1 and YAML 1.2 read differently (``030``, ``50:00``, ``0o10``):
        (mapping or sequence, key or index, line, message); the container holds YAML 1.1's
        reading (``_two_readings``)."""

    def compose_node(self, parent, index):
        """A scalar written through an alias (``record_periods: *z``) is a copy of its anchor's
        node marked where the alias is written, so that a problem with its value is reported
        at the field that uses it, not at the anchor (a sequence item's line is its node's;
        ``_two_readings`` used the node's mark). Mappings and sequences stay shared."""
        alias = self.peek_event() if self.check_event(yaml.AliasEvent) else None
        node = super().compose_node(parent, index)
        if alias is not None and isinstance(node, yaml.ScalarNode):
            node = yaml.ScalarNode(node.tag, node.value, alias.start_mark, alias.end_mark,
                                   node.style)
        return node


def _construct_map(loader: _Loader, node: yaml.MappingNode):
    data = _Map()
    data.line, data.lines = node.start_mark.line + 1, {}
    yield data
    first: dict = {}
    for knode, _ in node.value:  # duplicates among the keys written here (not merged ones)
        if knode.tag == "tag:yaml.org,2002:merge":
            continue
        key = loader.construct_object(knode, deep=True)
        if not isinstance(key, str) and isinstance(knode, yaml.ScalarNode):
            loader.odd_keys.append((data, knode.value, knode.start_mark.line + 1, key))
            key = knode.value
        try:
            hash(key)
        except TypeError:
            raise yaml.constructor.ConstructorError(
                "while constructing a mapping", node.start_mark, "found an unhashable key",
                knode.start_mark) from None
        if key in first:
            loader.duplicates.append((data, key, knode.start_mark.line + 1, first[key]))
        else:
            first[key] = knode.start_mark.line + 1
    loader.flatten_mapping(node)
    for knode, vnode in node.value:
        key = _construct(loader, knode)
        if not isinstance(key, str) and isinstance(knode, yaml.ScalarNode):
            key = knode.value  # as written (odd_keys: refused, named so)
        try:
            data[key] = _construct(loader, vnode)
        except TypeError:
            raise yaml.constructor.ConstructorError(
                "while constructing a mapping", node.start_mark, "found an unhashable key",
                knode.start_mark) from None
        data.lines[key] = knode.start_mark.line + 1
        _note_two_readings(loader, data, key, vnode, data[key])


def _construct_seq(loader: _Loader, node: yaml.SequenceNode):
    data = _Seq()
    data.line, data.lines = node.start_mark.line + 1, [n.start_mark.line + 1 for n in node.value]
    yield data
    data.extend(_construct(loader, n) for n in node.value)
    for i, (n, value) in enumerate(zip(node.value, data, strict=True)):
        _note_two_readings(loader, data, i, n, value)


_YAML12_NUMBER = re.compile(r"[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?"
                            r"|[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN)")
"""A float (or decimal integer) of YAML 1.2's core schema."""


def _yaml12_reading(text: str) -> int | float | str:
    """What YAML 1.2's core schema reads the plain scalar ``text`` as, of numbers: a decimal,
    octal (``0o``) or hexadecimal (``0x``) integer, a float, else the text."""
    if re.fullmatch(r"[-+]?[0-9]+", text):
        return int(text)
    if re.fullmatch(r"0o[0-7]+|0x[0-9a-fA-F]+", text):
        return int(text[2:], 8 if text[1] == "o" else 16)
    if not _YAML12_NUMBER.fullmatch(text):
        return text
    return float(text.replace(".", "", 1)) if text.lower().lstrip("+-") in (".inf", ".nan") \
        else float(text)


def _same_number(a: Any, b: Any) -> bool:
    return a == b or (isinstance(a, float) and isinstance(b, float) and a != a and b != b)


def _two_readings(node: yaml.Node, value: Any) -> str | None:
    """Why the plain scalar ``node``, which this (YAML 1.1) loader read as ``value``, reads
    otherwise in YAML 1.2, or ``None`` where the two agree (or it is no number in either).

    YAML 1.1 reads 030 as octal (24), 50:00 and 1:30.5 as base 60, 0b10 as binary and 1_000 with
    its digits grouped; YAML 1.2 reads 030 as 30, the others as text, and 0o10 as 8 (text in
    YAML 1.1). A study file is kept with its results and read by other tools, some of each
    version: such a number is refused, naming both readings, rather than taken in either (what
    ``speed: [03000, 04000]`` meant was 3000-4000 rpm, not the 1536-2048 rpm it ran). Text that
    YAML 1.2 alone reads as a number the fields read as that number (1e3, 089: a quantity's or a
    whole number's text), so it agrees."""
    if not isinstance(node, yaml.ScalarNode) or node.style is not None or isinstance(value, bool):
        return None
    text = node.value
    if isinstance(value, str):
        if value != text:
            return None
        v12 = _yaml12_reading(text)
        try:
            if isinstance(v12, str) or _same_number(float(text), v12):
                return None
        except ValueError:
            pass
        return (f"{text} is read as the text '{text}' by YAML 1.1 and as {v12!r} by YAML 1.2"
                f" (octal): write the number in decimal digits ({v12!r}), or in quotes"
                f" ('{text}') if text is meant")
    if not isinstance(value, int | float):
        return None
    v12 = _yaml12_reading(text)
    if isinstance(v12, int | float):
        if _same_number(value, v12):
            return None
        return (f"{text} is read as {value!r} by YAML 1.1 (a leading 0 makes it octal) and as"
                f" {v12!r} by YAML 1.2: write it without the leading 0 ({v12!r}), or"
                f" {value!r} if octal was meant")
    if ":" in text:
        why = "base 60"
    elif "0b" in text:
        why = "binary"
    elif "0x" in text:  # YAML 1.2 reads hexadecimal digits with no sign and no _
        why = ", ".join(["hexadecimal with a sign" if text[0] in "+-" else "hexadecimal",
                         *(["digits grouped by _"] if "_" in text else [])])
    else:
        why = "digits grouped by _"
    return (f"{text} is read as {value!r} by YAML 1.1 ({why}) and as the text '{text}' by YAML"
            f" 1.2: write the number in decimal digits ({value!r}), or in quotes ('{text}') if"
            " text is meant")


_TEXT_FIELDS = ("title", "description", "scene.excitation.file")
"""Fields that are text: a value of theirs YAML reads two ways is told only to be quoted."""


def _as_text_field(path: str, message: str) -> str:
    """``message`` of ``_two_readings`` for the value of ``path``; for a text field (``title:
    1:30``) its readings and the quoting advice alone (it was told "write the number in decimal
    digits (90)": a title is no number)."""
    if path not in _TEXT_FIELDS:
        return message
    written = message.split(" is read as ", 1)[0]
    readings = message.split(": write ", 1)[0]
    return f"{readings}: {path.rsplit('.', 1)[-1]} is text; write it in quotes ('{written}')"


def _note_two_readings(loader: _Loader, container: Any, key: str | int, node: yaml.Node,
                       value: Any) -> None:
    message = _two_readings(node, value)
    if message is not None:
        loader.odd_numbers.append((container, key, node.start_mark.line + 1, message))


def _construct(loader: _Loader, node: yaml.Node) -> Any:
    """``loader.construct_object``, with a value it cannot read (``!!int xyz``, the date
    2020-13-45) reported at the node's line as a YAML error."""
    try:
        return loader.construct_object(node, deep=True)
    except (ValueError, OverflowError, ArithmeticError) as exc:
        why = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise yaml.constructor.ConstructorError(
            None, None, f"cannot read {node.value!r} as {node.tag.rsplit(':', 1)[-1]} ({why})",
            node.start_mark) from None


_Loader.add_constructor("tag:yaml.org,2002:map", _construct_map)
_Loader.add_constructor("tag:yaml.org,2002:seq", _construct_seq)


def _path_parts(path: str) -> list[str | int]:
    parts: list[str | int] = []
    for name, index in re.findall(r"([^.\[\]]+)|\[(\d+)\]", path):
        parts.append(int(index) if index else name)
    return parts


def line_of(raw: Any, path: str | list) -> int | None:
    """Line of the deepest part of ``path`` (``scene.ste[0].amplitude``) that the file has."""
    parts = _path_parts(path) if isinstance(path, str) else path
    line = getattr(raw, "line", None)
    for p in parts:
        if isinstance(raw, dict) and p in raw:
            line = getattr(raw, "lines", {}).get(p, line)
            raw = raw[p]
        elif isinstance(raw, list) and isinstance(p, int) and 0 <= p < len(raw):
            lines = getattr(raw, "lines", [])
            line = lines[p] if p < len(lines) else line
            raw = raw[p]
        else:
            break
    return line


def written_at(raw: Any, path: str) -> Any:
    """The value at ``path`` (``outputs[0].spectrum.max_order``) as the file writes it (``40``,
    not the ``40.0`` a model holds), or ``None`` if the file has nothing there."""
    return _as_written(raw, _path_parts(path))


def _error(file: str, problems: list[Problem], raw: Any = None,
           kind: type[StudyError] = StudyError) -> StudyError:
    problems = [Problem(_as_file_writes(raw, p.path), p.value, p.message) for p in problems]
    return kind.many(file, [(line_of(raw, p.path), p.path, p.value, p.message)
                            for p in problems])


def _as_file_writes(raw: Any, path: str) -> str:
    """``path`` as the file writes it: the one value of a sweep axis given as a scalar
    (``speed: 3000``, validated as ``[3000]``) is ``sweep.speed``, not ``sweep.speed[0]``."""
    m = re.fullmatch(r"(sweep\.[^.\[\]]+)\[0\]", path)
    if m is None:
        return path
    written = _as_written(raw, _path_parts(m[1]))
    return m[1] if written is not None and not isinstance(written, dict | list) else path


def _path_of(root: Any, target: Any, prefix: str = "") -> str | None:
    """The path of the container ``target`` inside ``root`` (by identity)."""
    if root is target:
        return prefix
    items = root.items() if isinstance(root, dict) else enumerate(root) \
        if isinstance(root, list) else ()
    for k, v in items:
        if isinstance(v, dict | list):
            sub = f"{prefix}[{k}]" if isinstance(root, list) else \
                f"{prefix}.{k}" if prefix else str(k)
            found = _path_of(v, target, sub)
            if found is not None:
                return found
    return None


FLOW_OPENERS = {"while parsing a flow mapping": "{", "while parsing a flow sequence": "["}
"""PyYAML's context of an error inside a flow mapping or sequence, and the bracket that opened
it."""


def load_yaml(text: str, file: str, duplicates: list | None = None) -> Any:
    """The YAML text as Python objects with line marks; every way the loader can fail (syntax,
    tags, values it cannot construct, nesting, duplicate keys) raises one ``StudyError``. With a
    list ``duplicates``, duplicate keys are appended to it as problems ``(line, path, value,
    message)`` instead (the last value of the key is kept), so that the caller reports them
    together with the other problems of the file."""
    loader = None
    try:
        loader = _Loader(text)  # checks the characters at once (control characters: ReaderError)
        raw = loader.get_single_data()
    except RecursionError:
        raise StudyError(file, "(yaml)", NO_VALUE, "YAML nested less deeply") from None
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        problem = exc.problem or exc.context or "not valid YAML"
        # pyyaml's words for the layout mistakes of a hand-written file, said in the file's
        if "expected <block end>, but found '<block" in problem:  # terms
            problem += " (this line's indentation does not match the lines of its block)"
        elif re.fullmatch(r"expected <block end>, but found '[,}\]]'", problem):
            problem += " (braces { } or brackets [ ] on this line that do not pair up)"
        elif problem == "mapping values are not allowed here":
            problem += (" (a line indented deeper than the one above it, or ': ' inside a"
                        " value: quote the value)")
        elif "'\\t' that cannot start any token" in problem:
            problem += " (a tab: YAML indents with spaces only)"
        elif (exc.context in FLOW_OPENERS and exc.context_mark is not None and mark is not None
              and mark.line > exc.context_mark.line):  # still inside a '{' of an earlier line:
            # "expected ',' or '}', but got ':'" on the line after an unclosed one said nothing
            problem += (f" (an unclosed '{FLOW_OPENERS[exc.context]}' opened at line"
                        f" {exc.context_mark.line + 1}?)")  # of that (an outside tester's)
        raise StudyError(file, "(yaml)", NO_VALUE, f"not valid YAML: {problem}",
                         mark.line + 1 if mark is not None else None) from None
    except yaml.reader.ReaderError as exc:
        line = text.count("\n", 0, exc.position) + 1 if isinstance(exc.position, int) else None
        raise StudyError(file, "(yaml)", NO_VALUE, f"not valid YAML: character"
                         f" {chr(exc.character) if isinstance(exc.character, int) else exc.character!r}"
                         " is not allowed in a YAML file", line) from None
    except Exception as exc:  # noqa: BLE001 -- a value the loader cannot construct (a date...)
        line = None
        try:
            line = loader.peek_event().start_mark.line + 1 if loader.check_event() else None
        except Exception:  # noqa: BLE001 -- the line is a courtesy; the message is what counts
            line = None
        why = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise StudyError(file, "(yaml)", NO_VALUE, f"a value YAML cannot read ({why})",
                         line) from None
    finally:
        if loader is not None:
            loader.dispose()
    if loader.duplicates or loader.odd_keys or loader.odd_numbers:
        problems = []
        for container, key, line, first in loader.duplicates:
            where = _path_of(raw, container) or ""
            path = f"{where}.{key}" if where else str(key)
            msg = f"duplicate key (also on line {first}); each key at most once in a mapping"
            problems.append((line, path, NO_VALUE, msg))
        for container, key, line, read in loader.odd_keys:
            where = _path_of(raw, container) or ""
            what = (str(read).lower() if isinstance(read, bool) else "null" if read is None
                    else f"the number {read!r}" if isinstance(read, int | float)
                    else f"{article(type(read).__name__)} ({read})")
            msg = (f"{key!r} as a key is read by YAML as {what}, not as a name; write it in"
                   f" quotes ('{key}') if a name is meant")
            problems.append((line, f"{where}.{key}" if where else key, NO_VALUE, msg))
        for container, key, line, msg in loader.odd_numbers:
            where = _path_of(raw, container) or ""
            path = (f"{where}[{key}]" if isinstance(key, int) else f"{where}.{key}" if where
                    else str(key))
            problems.append((line, _as_file_writes(raw, path), NO_VALUE,
                             _as_text_field(path, msg)))
        if duplicates is None:
            raise StudyError.many(file, problems)
        duplicates.extend(problems)
    return raw


# ------------------------------------------------------------------------------ pydantic errors


_BRANCHES = ("list[union[float,str]]", "Range", "float", "str", "int", "list", "dict[str,any]",
             "literal['up','down']")


def _kinds(union: Any) -> dict[str, type]:
    """Tag -> model of a union discriminated by ``kind`` (``Annotated[A | B, Field(...)]``)."""
    members = typing.get_args(typing.get_args(union)[0])
    return {typing.get_args(m.model_fields["kind"].annotation)[0]: m for m in members}


_SCENES = _kinds(Scene)
_ANALYSES = _kinds(AnalysisSpec)
_TAGGED = {"scene": _SCENES, "analysis": _ANALYSES}
"""The fields that hold a union tagged by ``kind``, and the models of their kinds."""


def _user_path(loc: tuple) -> list[str | int]:
    """The parts of a pydantic error location that are keys and indices of the user's file
    (without the tag of a scene's or an analysis' kind and pydantic's names of union branches
    and validators)."""
    parts: list[str | int] = []
    for i, p in enumerate(loc):
        if isinstance(p, int):
            parts.append(p)
            continue
        p = str(p)
        if i and p in _TAGGED.get(str(loc[i - 1]), ()):
            # the tag pydantic puts after a tagged union's field ('analysis', 'work_precision',
            # 'steps_per_period'): not a key of the file, whose line it would miss
            continue
        if p.startswith(("function-", "literal[", "union[", "list[", "dict[")) or p in _BRANCHES:
            continue
        if p == "[key]":  # pydantic's mark of a mapping's key ('sweep.torqe.[key]')
            continue
        parts.append(p)
    return parts


def _loc(loc: tuple | list) -> str:
    parts = _user_path(tuple(loc)) if isinstance(loc, tuple) else loc
    text = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in parts)
    return text.removeprefix(".") or "(top level)"


def _as_written(raw, parts: list):
    """The value at ``parts`` as the user wrote it (``'-0.5 mm'``, not the SI number a quantity
    validator turned it into), or ``None`` if the file has nothing there."""
    for p in parts:
        if isinstance(raw, dict) and p in raw:
            raw = raw[p]
        elif isinstance(raw, list) and isinstance(p, int) and 0 <= p < len(raw):
            raw = raw[p]
        else:
            return None
    return raw


@cache
def _vocabulary() -> tuple[str, ...]:
    """Every field name of the study models (for 'did you mean' on an unknown field)."""
    names: set[str] = set()
    for m in (Study, WhineScene, RattleScene, FullScene, MathieuScene, Drive, StiffnessHarmonic,
              SteHarmonic, Fluctuation, Range, Solver, GearSpec, TipReliefSpec, ExcitationSpec):
        names.update(m.model_fields)
    names.update(SCENE_PARAMETERS["full"] | SCENE_PARAMETERS["mathieu"])
    return tuple(sorted(names))


def _num_of_steps(raw: Any, parent: list, key: str) -> str:
    """`` (start, stop and step 50 rpm give num: 111)`` where a range written with a step
    (``{start, stop, step}``) gives a whole number of values, else ``''``."""
    spec = _as_written(raw, parent)
    kind = SWEEPABLE.get(parent[1])
    if not isinstance(spec, dict) or kind is None:
        return ""
    try:
        start, stop, step = (to_si(spec.get(k), kind) for k in ("start", "stop", key))
        n = (stop - start) / step + 1
    except (UnitParseError, TypeError, ValueError, ZeroDivisionError, OverflowError):
        return ""
    if not (math.isfinite(n) and n >= 1 and abs(n - round(n)) < 1e-9 * n):
        return ""
    if n > MAX_RANGE_NUM:  # (1e-300 rpm printed a num of 300 digits, beyond what num takes)
        return (f" (start, stop and {key} {spec.get(key)} give {n:.3g} values, more than the"
                f" {MAX_RANGE_NUM:,} a range takes)")
    return f" (start, stop and {key} {spec.get(key)} give num: {round(n)})"


def _unknown_field(key: str, parent: list, raw: Any, missing=()) -> tuple[str, str | None]:
    """Why ``key`` is not allowed under ``parent``, and the field it suggests (or ``None``): a
    field of another scene (or analysis) kind is named as such, and a misspelling is matched
    first against the required fields ``missing`` beside it (``ordr`` beside a missing ``order``:
    the one line of that mistake), then against the fields of where it stands (a range's, the
    solver's, the scene's, the analysis'), not every field of every model."""
    choices: tuple[str, ...] | None = None
    where = ""
    listed = None  # where and which fields to list when nothing is close: those of the choices
    if len(parent) == 2 and parent[0] == "sweep":
        choices, where = tuple(Range.model_fields), "a {start, stop, num} range"
        spec = _as_written(raw, parent)
        if key in ("step", "increment", "delta", "interval") and isinstance(spec, dict) \
                and "num" not in spec:
            # a range by its step: the line said "did you mean 'stop'?" beside "num: missing"
            return (f"{key!r} is not a field of {where}: give num, the number of values"
                    f"{_num_of_steps(raw, parent, key)}"), "num"
    elif parent == ["solver"]:
        choices, where = tuple(Solver.model_fields), "solver"
    elif parent == []:  # any kind of study's: a misspelt 'analysis' or 'mesh' made it dynamic
        studies = {"dynamic": Study, "mesh": MeshStudy, "analysis": AnalysisStudy}
        typed = raw.get("type") if isinstance(raw, dict) else None
        own = typed if isinstance(typed, str) and typed in studies else "dynamic"
        elsewhere = [f"one of {article(k)} study" for k, m in studies.items()
                     if k != own and key in m.model_fields]
        if own == "dynamic" and any(key in m.model_fields for m in _SCENES.values()):
            elsewhere.append(f"a field of the scene: scene.{key}")
        if elsewhere:  # 'positions' in a dynamic study, 'scene' in a mesh study
            return (f"{key!r} is not a field of {article(own)} study (it is"
                    f" {', and '.join(elsewhere)})"), None
        choices = tuple(dict.fromkeys([*Study.model_fields, *MeshStudy.model_fields,
                                       *AnalysisStudy.model_fields]))
        where = "a study"
        listed = (f"{article(own)} study", tuple(studies[own].model_fields))
    elif (parent and parent[-1] == "gear") or (len(parent) == 2 and parent[0] == "gears"):
        # a mesh study's or a scene's pair, or one of a mesh study's labelled pairs
        choices, where = tuple(GearSpec.model_fields), "gear"
        pair = GEAR_WORDS.get(key)
        if pair:  # 'teeth: [20, 40]' was told "did you mean 'teeth'?" (a scene's field)
            return f"{key!r} is not a field of gear -- did you mean {pair}?", None
    elif len(parent) == 1 and parent[0] in _TAGGED:
        noun, kinds = parent[0], _TAGGED[parent[0]]
        held = raw.get(noun) if isinstance(raw, dict) else None
        kind = held.get("kind") if isinstance(held, dict) else None
        if kind in kinds:
            choices = tuple(kinds[kind].model_fields)
            where = f"{article(kind)} {noun}"
            others = [k for k, m in kinds.items() if key in m.model_fields]
            if others:
                return (f"{key!r} is not a field of {where} (it is one of"
                        f" {article(' or '.join(others))} {noun})"), None
    meant = _closest(key, missing) or _closest(key, _vocabulary() if choices is None else choices)
    hint = f" -- did you mean {meant!r}?" if meant else ""
    if choices is None:
        return f"{key!r} is an unknown field" + (hint or " (see docs/study-reference.md)"), meant
    if not hint and listed:  # matched against every kind of study, listed those of its own
        where, choices = listed
    return f"{key!r} is not a field of {where}" + (
        hint or f"; its fields: {', '.join(c for c in choices if c != 'kind')}"), meant


GEAR_WORDS = {"teeth": "z1 and z2 (the teeth of gear 1 and of gear 2)",
              "z": "z1 and z2 (the teeth of gear 1 and of gear 2)",
              "shift": "x1 and x2 (the profile shifts)",
              "profile_shift": "x1 and x2 (the profile shifts)",
              "tip_radius": "tip_radius1 and tip_radius2",
              "root_radius": "root_radius1 and root_radius2"}
"""Fields a user writes for a pair that a gear spells per gear (an outside tester wrote
``teeth: [20, 40]``)."""

SYNONYMS = {"gpu": "cuda", "nvidia": "cuda"}
"""Words a user writes for a choice by another name: ``device: gpu`` means ``cuda`` (by spelling
it was nearest to ``cpu``, and the hint said so; found by an outside test)."""

FIELD_WORDS = {"ste_harmonics": "ste", "static_transmission_error": "ste",
               "transmission_error": "ste"}
"""Fields a user writes by another name: ``ste_harmonics`` (the STE's harmonics, written like
``stiffness_harmonics``) means ``ste``; by spelling it was nearest to ``harmonics`` (a gear's
Fourier count), and the hint said so (an outside tester's finding)."""


def _closest(word: Any, choices) -> str | None:
    names = [str(c) for c in choices]
    said = str(word).strip().lower()
    meant = SYNONYMS.get(said) or FIELD_WORDS.get(said)
    if meant in names:
        return meant
    same = [n for n in names if n.lower() == str(word).strip().lower() and n != str(word)]
    if same:  # 'RK4' for 'rk4': said "Input should be 'rk4' or 'rk5'" (an outside tester)
        return same[0]
    close = difflib.get_close_matches(str(word), names, n=1, cutoff=0.6)
    return close[0] if close and close[0] != str(word) else None  # (never itself)


def _did_you_mean(word: Any, choices) -> str:
    close = _closest(word, choices)
    return f" -- did you mean {close!r}?" if close else ""


def _is_branch_mismatch(err: dict) -> bool:
    return err["type"].endswith("_type") or err["type"] in ("union_tag_invalid",
                                                             "model_attributes_type")


def _problems(exc: ValidationError, raw=None) -> list[Problem]:
    """Every error of a pydantic validation, in the study's words, one per field."""
    errs = [(tuple(_user_path(e["loc"])), e) for e in exc.errors()]
    # Of the branches of a union (a list or a {start, stop, num} range, a float or a string),
    # report the one the user evidently meant: a type mismatch of another branch is dropped when
    # a more specific error lies at or below the same place.
    by_path: dict[tuple, dict] = {}
    for path, e in errs:
        if _is_branch_mismatch(e) and any(
                (q[:len(path)] == path and q != path) or (q == path and not _is_branch_mismatch(f))
                for q, f in errs):
            continue
        kept = by_path.get(path)
        if kept is not None and kept["type"] == "literal_error" and e["type"] == "value_error":
            # a quantity or a word ('static'): the quantity's message says what was wrong
            by_path[path] = {**e, "or_literal": kept.get("ctx", {}).get("expected", "")}
            continue
        by_path.setdefault(path, e)
    missing: dict[tuple, list[str]] = {}  # the required fields not given, by where they belong
    for path, e in by_path.items():
        if e["type"] == "missing" and path and isinstance(path[-1], str):
            missing.setdefault(path[:-1], []).append(path[-1])
    explained: set[tuple] = set()  # of those, the ones a misspelt key beside them stands for
    out: list[tuple[tuple, Problem]] = []
    for path, e in by_path.items():
        parts = list(path)
        msg = e["msg"].removeprefix("Value error, ")
        value = e.get("input")
        written = _as_written(raw, parts)
        if isinstance(written, str | int | float) and not isinstance(value, dict | list):
            value = written
        if isinstance(value, dict | list):
            value = "{...}" if isinstance(value, dict) else "[...]"
        t = e["type"]
        if isinstance(e.get("ctx", {}).get("error"), FieldProblems):  # at the fields it names
            out += [(path, p) for p in _field_problems(raw, parts, e["ctx"]["error"])]
            continue
        if t == "extra_forbidden":
            key = parts[-1] if parts else value
            value = NO_VALUE
            msg, meant = _unknown_field(str(key), parts[:-1], raw, missing.get(path[:-1], ()))
            if meant in missing.get(path[:-1], ()):
                explained.add((*path[:-1], meant))
        elif t == "missing":
            value, msg = "(missing)", "this field is required"
            gear = _as_written(raw, ["scene", "gear"])
            if parts == ["scene", "backlash"] and isinstance(gear, dict) and "backlash" in gear:
                # gear.backlash (at the pitch circle) is not the scene's dead zone (docs/mesh.md)
                msg += (" (the dead zone along the line of action; gear.backlash, at the pitch"
                        " circle, is not passed on: write scene.backlash = gear.backlash x cos"
                        " alpha_w)")
        elif t == "union_tag_invalid":
            ctx = e.get("ctx", {})
            tags = re.findall(r"'([^']*)'", str(ctx.get("expected_tags", "")))
            noun = _noun(parts)
            parts.append("kind")
            value = ctx.get("tag", value)
            hint = _did_you_mean(value, tags)
            msg = (hint.removeprefix(" -- ") + f" (allowed: {', '.join(tags)})" if hint
                   else f"not {article(noun)} kind; allowed: {', '.join(tags)}")
        elif t in ("model_type", "model_attributes_type", "dict_type") or (
                t == "union_tag_not_found" and not isinstance(_as_written(raw, parts), dict)):
            msg = _mapping_wanted(parts, e, raw)
        elif t == "union_tag_not_found":
            noun = _noun(parts)
            tags = list(_TAGGED[noun])
            parts.append("kind")
            value = "(missing)"
            msg = f"{article(noun)} needs a kind: {', '.join(tags[:-1])} or {tags[-1]}"
        elif t == "literal_error":
            allowed = re.findall(r"'([^']*)'", str(e.get("ctx", {}).get("expected", "")))
            hint = _did_you_mean(value, allowed)
            if hint:
                msg = hint.removeprefix(" -- ") + f" (allowed: {', '.join(allowed)})"
        elif t.endswith("_type") and len(path) == 2 and path[0] == "sweep":
            msg = "a value, a list of values or {start, stop, num}"
        elif (t.endswith("_type") and len(path) == 3 and path[0] == "sweep"
              and path[1] in SWEEPABLE and path[2] != "num"):  # a range's start or stop, an item
            kind = SWEEPABLE[path[1]]
            msg = ("a number" if kind == "dimensionless"
                   else f"{article(kind)} such as '1 {KINDS[kind].examples[0]}'")
        elif t == "list_type":  # 'outputs: stats', 'continuation: up': one item, no brackets
            one = _as_written(raw, parts)
            item = _list_item_model(parts[-1]) if parts else None
            msg = (f"a list of mappings, e.g. [{{{_example(item)}}}]"
                   if item is not None and not isinstance(one, dict)  # ('fluctuation: 300 N')
                   else f"a list; for one item write [{one}]" if isinstance(one, str | int | float)
                   else "a list; a mapping here is one item of it: write it as [{...}]"
                   if isinstance(one, dict) else "a list, e.g. [a, b]")
        elif t == "tuple_type":  # pydantic's word: a file writes a list (analysis.graphical)
            msg = "a list, e.g. [a, b, c]"
        elif t == "finite_number":
            msg = "a finite number (not nan or inf)"
        elif t == "string_type" and isinstance(written, int | float | bool):  # 'title: 2026'
            read = "a boolean" if isinstance(written, bool) else "a number"
            msg = f"text; YAML reads this unquoted value as {read}: write it in quotes"
        elif "has no unit" in msg:
            value = NO_VALUE
        if e.get("or_literal"):
            msg += f" (or {e['or_literal']})"
        out.append((path, Problem(_loc(parts), value, msg)))
    # 'ordr: 1' where 'order' is required is one mistake: its line says 'did you mean', and the
    # missing field's own line would only repeat it
    return [p for path, p in out if not (path in explained and by_path[path]["type"] == "missing")]


def _field_problems(raw: Any, parts: list, err: FieldProblems) -> list[Problem]:
    """The problems of ``err``, raised by the validator of the model at ``parts``: each at the
    one of its fields the file writes on the latest line, with the value written there; those
    with none of their fields written, joined in one line at the model's own."""
    out, here = [], []
    for fields, message in err.problems:
        written = [parts + _path_parts(f) for f in fields]
        written = [p for p in written if _as_written(raw, p) is not None]
        if not written:
            here.append(message)
            continue
        at = max(written, key=lambda p: line_of(raw, p) or 0)  # (the first of one line)
        out.append(Problem(_loc(at), _shown_value(_as_written(raw, at)), message))
    if here:
        out.insert(0, Problem(_loc(parts), _shown_value(_as_written(raw, parts)), "; ".join(here)))
    return out


def _shown_value(value: Any) -> Any:
    """A value as a problem's line shows it: a mapping ``{...}``, a list ``[...]`` (and a part
    of the file that is not there, ``{...}``: a model's)."""
    if value is None or isinstance(value, dict):
        return "{...}"
    return "[...]" if isinstance(value, list) else value


@cache
def _models() -> dict[str, type]:
    """The models of a study's sections by class name (as pydantic's ``model_type`` names them)."""
    found, todo = {}, [Strict]
    while todo:
        m = todo.pop()
        found[m.__name__] = m
        todo += m.__subclasses__()
    return found


def _list_item_model(name: Any) -> type | None:
    """The model of the items of a study's field ``name`` that is a list of mappings
    (``fluctuation``, ``ste``, ``stiffness_harmonics``), else ``None``."""
    for model in _models().values():
        f = model.model_fields.get(name) if isinstance(name, str) else None
        args = typing.get_args(f.annotation) if f is not None else ()
        if (f is not None and typing.get_origin(f.annotation) is list and args
                and isinstance(args[0], type) and issubclass(args[0], BaseModel)):
            return args[0]
    return None


def _example(model: type, first: tuple[str, ...] = ()) -> str:
    """``kind: rattle, mass: ..., ...``: the first fields of ``model`` (after ``first``), each
    with its default where that is a plain word or number."""
    shown = list(first)
    for name, f in model.model_fields.items():
        if len(shown) == 2:
            break
        if name in ("kind", "type"):
            continue
        d = f.default
        plain = isinstance(d, str | int | float) and not isinstance(d, bool) and not f.is_required()
        if isinstance(d, float) and d.is_integer():
            d = int(d)  # max_order: 4, as a study writes it
        shown.append(f"{name}: {d if plain else '...'}")
    return ", ".join([*shown, "..."])


def _mapping_wanted(parts: list, err: dict, raw: Any) -> str:
    """What a section written as a list or a single value should be: a mapping of its fields
    (pydantic said "Input should be a valid dictionary or instance of Solver"). An output's
    options are named as the file writes them (``parts`` ``outputs[0].options`` becomes
    ``outputs[0].spectrum``)."""
    noun = next((str(p) for p in reversed(parts) if isinstance(p, str)), "")
    written = _as_written(raw, parts)
    if len(parts) == 3 and parts[0] == "outputs" and parts[2] == "options":
        item = _as_written(raw, parts[:2])
        name = next(iter(item)) if isinstance(item, dict) and len(item) == 1 else None
        if isinstance(name, str) and getattr(OUTPUTS.get(name), "options_model", None):
            parts[2] = noun = name  # as the file writes it: outputs[0].spectrum
            written = item[name]
            model = OUTPUTS[name].options_model
            return (f"a mapping of {noun} options ({_example(model)})"
                    + (", not a list" if isinstance(written, list) else ""))
        if isinstance(name, str) and name in OUTPUTS:  # ('floquet: 5': not a key 'options')
            parts[2] = name
            return f"the {name!r} output takes no options"
    model = _models().get(str(err.get("ctx", {}).get("class_name", "")))
    if parts and parts[-1] in _TAGGED:
        kinds = _TAGGED[noun]
        items = written if isinstance(written, list) else [written]
        said = [i.get("kind") if isinstance(i, dict) else i for i in items]
        kind = next((k for k in said if isinstance(k, str) and k in kinds), next(iter(kinds)))
        text = f"a mapping of {noun} fields ({_example(kinds[kind], (f'kind: {kind}',))})"
    elif model is OutputRequest:
        text = ("an output name, or a mapping of one output name to its options (stats, or"
                " {spectrum: {max_order: 4}})")
    elif model is GearSpec:
        text = (f"a preset name ({', '.join(PRESETS)}) or a mapping of gear fields"
                f" ({_example(model)})")
    elif model is not None:
        text = f"a mapping of {noun} fields ({_example(model)})"
    elif parts[-1:] == ["sweep"]:
        text = ("a mapping of the swept parameters to their values (speed: {start: ..., stop:"
                " ..., num: ...}, ...)")
    elif parts == ["gears"]:
        text = "a mapping of labels to gear pairs (no relief: table1_consistent, ...)"
    else:
        text = "a mapping (name: value, ...)"
    return text + (", not a list" if isinstance(written, list) else "")


def _noun(parts: list) -> str:
    """What a tagged union's field holds: a scene or an analysis."""
    return str(parts[-1]) if parts and parts[-1] in _TAGGED else "scene"


def _problems_beside_errors(raw: Any) -> list[Problem]:
    """What pydantic's own errors stop the study's validators from saying, checked on the file
    itself when the study does not validate: ``grid_problems`` of its ``sweep:``, a speed given
    nowhere, and which fields the scene gives (``scene_presence``)."""
    sweep = raw.get("sweep") if isinstance(raw, dict) else None
    scene = raw.get("scene") if isinstance(raw, dict) else None
    cont = raw.get("continuation") if isinstance(raw, dict) else None
    out = []
    if (isinstance(scene, dict) and scene.get("kind") in tuple(SCENE_PARAMETERS)
            and (isinstance(sweep, dict) or "sweep" not in raw)):  # else: sweep's own error
        if not (isinstance(cont, list) and all(c in ("up", "down") for c in cont)):
            cont = []  # continuation's own error, or none
        out += speed_problems(scene["kind"], isinstance(sweep, dict) and "speed" in sweep,
                              "speed" in scene, cont)
        if isinstance(sweep, dict):
            gear = scene.get("gear") is not None  # (its swept stiffness: gear_load_problems)
            out += sweep_name_problems(scene["kind"], [n for n in sweep if isinstance(n, str)
                                                       and not (gear and n == "stiffness")], gear)
        if scene["kind"] != "mathieu" and scene.get("gear") is not None:  # a gear's own error
            out += gear_load_problems(list(sweep) if isinstance(sweep, dict) else [],  # hid these
                                      any(scene.get(n) is not None for n in ("torque", "mean_force")))
    outputs = raw.get("outputs") if isinstance(raw, dict) else None
    if isinstance(outputs, list):  # the names (an entry's own structure: the study's errors)
        names = [o if isinstance(o, str) else next(iter(o)) if isinstance(o, dict) and len(o) == 1
                 and "name" not in o else o.get("name") if isinstance(o, dict) else None
                 for o in outputs]
        if all(isinstance(n, str) for n in names):
            out += output_name_problems(names)
            for i, (name, entry) in enumerate(zip(names, outputs, strict=True)):
                try:  # an output's options beside the study's other problems
                    options = _output_request(entry).get("options") if isinstance(entry, dict) \
                        else None
                except ValueError:
                    options = None  # its own structural error says so
                if name in OUTPUTS and isinstance(options, dict):
                    try:
                        configure(name, options, "<study>", f"outputs[{i}].{name}")
                    except StudyError as exc:
                        out += [Problem(f, v, a) for _, f, v, a in exc.problems]
    if isinstance(scene, dict) and scene.get("kind") in ("whine", "rattle", "full"):
        drive = scene.get("drive")
        given = scene_presence(lambda f: scene.get(f) is not None,  # a drive that is no mapping:
                               lambda f: not isinstance(drive, dict) or drive.get(f) is not None,
                               swept_fields(raw))
        # its own error says so, not that its fields are missing
        if given:  # the same lines as the scene's validator gives, where it ran
            out += _field_problems(raw, ["scene"], FieldProblems(given))
    if isinstance(sweep, dict):  # each entry on its own: a 'spacing: logg' in one range hides
        parsed = {}  # neither a missing unit of its start nor the problems of the other entries
        for name, spec in sweep.items():
            if not isinstance(name, str) or name not in SWEEPABLE:
                continue  # the study's own errors, or consistency_problems once they are mended
            try:
                parsed[name] = _sweep_entry().validate_python(spec)
            except ValidationError as exc:  # structural problems are in the study's own errors;
                out += _loose_value_problems(name, spec, exc)  # the values fine in themselves
            except RecursionError:
                continue
        out += grid_problems(SimpleNamespace(sweep=parsed))
    return out


@cache
def _sweep_entry() -> TypeAdapter:
    """The validator of one entry of ``sweep:`` (a list of values or a range)."""
    return TypeAdapter(typing.get_args(Study.model_fields["sweep"].annotation)[1])


def _loose_value_problems(name: str, spec: Any, exc: ValidationError) -> list[Problem]:
    """``value_problems`` of the values of a sweep entry that does not validate (a range with a
    misspelt spacing or a missing num, a list with a nested item) that are themselves numbers or
    strings without an error of their own."""
    bad = {p[0] for p in (_user_path(e["loc"]) for e in exc.errors()) if p}
    if isinstance(spec, dict):
        items = [(k, spec[k]) for k in ("start", "stop") if k in spec]
    elif isinstance(spec, list):
        items = list(enumerate(spec))
    else:
        return []
    items = [(k, v) for k, v in items if k not in bad and isinstance(v, str | int | float)
             and not isinstance(v, bool)]
    return value_problems(name, items, isinstance(spec, dict))[0]


def _first_error(exc: ValidationError, file: str, raw=None) -> StudyError:
    """Every error of ``exc`` as one ``StudyError`` (a line each; the name is kept for callers)."""
    return _error(file, _problems(exc, raw), raw)


def parse_study(text: str, file: str = "<study>", base: str | Path | None = None,
                device: str | None = None) -> Study | MeshStudy | AnalysisStudy:
    """Validate a study from its YAML text; every problem of the file raises one ``StudyError``
    with a line per problem (``file.yaml:LINE: field.path: value -- message``). Relative file
    paths in it are read from ``base`` (default: the folder of ``file``, else the working one).

    A top-level ``type: mesh`` selects a static mesh study (``gearsweep.study.mesh``).
    ``device`` replaces a dynamic study's ``solver.device`` before the checks (``gearsweep run
    --device``: a float32 or kink-aware study was refused for the device the flag replaces).
    """
    duplicates: list = []
    raw = load_yaml(text, file, duplicates)
    if (device is not None and isinstance(raw, dict) and "type" not in raw
            and isinstance(raw.get("solver"), dict)):
        raw["solver"]["device"] = device
    if base is None:
        base = Path(file).parent if file and not file.startswith("<") else Path.cwd()
    base = str(Path(base).resolve())
    try:  # a Ctrl-C held to the end: pydantic turned one raised while it built a model's
        with signals_held(signal.SIGINT):  # validator (the first study parsed) into a
            study = _parse_raw(raw, file, base)  # SchemaError (``errors.signals_held``)
    except StudyError as exc:
        if not duplicates:
            raise
        raise StudyError.many(file, duplicates).joined(exc) from None
    if duplicates:
        raise StudyError.many(file, duplicates)
    study._source_text = text
    study._base_folder = base
    return study


def study_text(study: Study | MeshStudy | AnalysisStudy) -> str:
    """YAML text that ``parse_study`` validates to ``study``: its fields as they are now, each
    quantity with its SI unit (``0.0004698 m``; a bare SI number is refused, as from a user).
    For a study changed in Python (``model_copy(update=...)`` does not validate): parsed again,
    the change is checked like a study file's, and a result's ``study`` attribute stays a study
    that reads back. Every study in ``studies/`` parses back to itself (a test)."""
    fields = _with_units(study)
    if isinstance(study, Study) and study.scene.kind == "mathieu":  # dimensionless (a bare
        fields["solver"]["initial_displacement"] = study.solver.initial_displacement  # number)
        fields["solver"]["initial_velocity"] = study.solver.initial_velocity
    return yaml.safe_dump(fields, sort_keys=False, allow_unicode=True)


def _with_units(value: Any, kind: str | None = None) -> Any:
    """``study_text``'s fields: models as mappings, quantity floats with their SI unit."""
    if isinstance(value, BaseModel):
        return {name: _with_units(getattr(value, name), _quantity_kind(info))
                for name, info in type(value).model_fields.items()
                if getattr(value, name) is not None}
    if isinstance(value, list | tuple):
        return [_with_units(v, kind) for v in value]
    if isinstance(value, dict):
        return {k: _with_units(v, kind) for k, v in value.items()}
    if isinstance(value, np.generic):  # a numpy scalar set in Python: its repr 'np.float64(0.2)'
        value = value.item()  # was read as a unit 'np', and PyYAML cannot represent one
    if kind is not None and isinstance(value, float):
        return f"{value!r} {KINDS[kind].si}"
    return value


def _quantity_kind(field: Any) -> str | None:
    """The kind of a quantity field (``quantities.Q``'s ``QuantityKind``), also inside an
    optional or a union (``Literal["static"] | Displacement``); else ``None``."""
    todo = [*field.metadata, field.annotation]
    while todo:
        a = todo.pop()
        if isinstance(a, QuantityKind):
            return a.kind
        todo.extend(getattr(a, "__metadata__", ()))
        todo.extend(typing.get_args(a))
    return None


def _parse_raw(raw: Any, file: str, base: str | None = None
               ) -> Study | MeshStudy | AnalysisStudy:
    """``parse_study`` of the loaded YAML (with line marks)."""
    if not isinstance(raw, dict):
        held = "nothing (an empty file)" if raw is None else (
            "a list" if isinstance(raw, list) else f"a single value {raw!r}")
        raise StudyError(file, "(top level)", NO_VALUE,
                         f"the file holds {held}; a study is a mapping with title, scene, sweep,"
                         " solver, outputs", 1)
    if "type" in raw and raw["type"] not in ("mesh", "analysis"):
        raise StudyError(file, "type", raw["type"], "'mesh' (a static mesh study), 'analysis'"
                         " (method stability, work-precision), or no 'type' for a dynamic study",
                         line_of(raw, "type"))
    if raw.get("type") == "mesh":
        return parse_mesh_study(raw, file)
    if raw.get("type") == "analysis":
        try:
            study = AnalysisStudy.model_validate(raw)
        except ValidationError as exc:
            raise _first_error(exc, file, raw) from None
        problems = analysis_problems(study, raw)
        if problems:
            raise _error(file, problems, raw)
        return study
    problems: list[Problem] = []
    try:
        study = Study.model_validate(raw, context={"problems": problems, "file": file,
                                                   "base": base, "swept": swept_fields(raw)})
    except ValidationError as exc:
        err = _first_error(exc, file, raw)
        more = problems + _problems_beside_errors(raw)  # every problem of the file at once
        raise (err.joined(_error(file, more, raw)) if more else err) from None
    except RecursionError:
        raise StudyError(file, "(top level)", "{...}", "values nested less deeply") from None
    problems += grid_problems(study)
    for i, req in enumerate(study.outputs):  # beside the other problems (were said after them)
        if req.name not in OUTPUTS:
            continue  # its name's own line (consistency_problems)
        try:
            configure(req.name, req.options, file, f"outputs[{i}].{req.name}")
        except StudyError as exc:
            problems += [Problem(f, v, a) for _, f, v, a in exc.problems]
    if problems:
        raise _error(file, problems, raw)
    _check_gear(study, file, raw)
    return study


def first_load(study: Study) -> float | None:
    """The first swept mean torque [N m] of a gear scene (``None`` when the load is not swept)."""
    if "torque" in study.sweep:
        return float(study.grid("torque")[0])
    if "mean_force" in study.sweep:
        return float(study.grid("mean_force")[0]) * gear_pair(study.scene.gear).base_radius1
    return None


def _largest_of(spec: Any, values: np.ndarray, name: str) -> tuple[float, str]:
    """The largest of ``values`` (a sweep of ``name``'s ``spec``) and where the file writes it:
    a range's start or stop, else the list's item."""
    i = int(np.argmax(values))
    if isinstance(spec, Range):
        return float(values[i]), f"sweep.{name}.{'stop' if i == len(values) - 1 else 'start'}"
    return float(values[i]), f"sweep.{name}[{i}]"


def largest_load(study: Study) -> tuple[float, str]:
    """The largest mean torque [N m] of a gear scene and where the file writes it (a
    ``mean_force`` is ``F_m r_b1``): the load whose STE ``mesh.load_faults`` tests, the STE
    growing with the load."""
    sc = study.scene
    for name in ("torque", "mean_force"):
        if name in study.sweep:
            value, where = _largest_of(study.sweep[name], study.grid(name), name)
            break
    else:
        name = "torque" if sc.torque is not None else "mean_force"
        value, where = float(getattr(sc, name)), f"scene.{name}"
    if name == "mean_force":
        value *= gear_pair(sc.gear).base_radius1
    return value, where


GEAR_LOAD = ("a positive load: a gear scene's k(t) and STE are the pair's under it, in the drive"
             " direction")


def _check_gear(study: Study, file: str, raw=None) -> None:
    """Geometry of a scene's gear pair: checked here, so ``validate`` refuses what ``run`` would."""
    sc = study.scene
    if getattr(sc, "gear", None) is None:
        return
    problems = []  # every load is one the pair's k(t) and STE are computed at: the first alone
    for name in ("torque", "mean_force"):  # was checked, so [50 N m, -50 N m] validated and
        spec = study.sweep.get(name)  # run stopped at the second load, in a line of no field
        if spec is not None:
            keys = ["start", "stop"] if isinstance(spec, Range) else list(range(len(spec)))
            values = ([to_si(spec.start, SWEEPABLE[name]), to_si(spec.stop, SWEEPABLE[name])]
                      if isinstance(spec, Range) else study.grid(name))
            bad = next((k for k, v in zip(keys, values, strict=True) if not v > 0), None)
            if bad is not None:
                where = f"sweep.{name}.{bad}" if isinstance(bad, str) else f"sweep.{name}[{bad}]"
                shown = getattr(spec, bad) if isinstance(bad, str) else spec[bad]
                problems.append(Problem(where, written_at(raw, where) or shown, GEAR_LOAD))
        elif getattr(sc, name, None) is not None and not getattr(sc, name) > 0:
            problems.append(Problem(f"scene.{name}", written_at(raw, f"scene.{name}")
                                    or getattr(sc, name), GEAR_LOAD))
    if problems:
        raise _error(file, problems, raw)
    found: list = []
    top, load_at = largest_load(study)

    def computed() -> tuple[float, float]:
        found.append(scene_excitation(sc, first_load(study)))
        return top, scene_excitation(sc, top).ste_max

    problems = gear_refusals(sc.gear, computed, file, raw, "scene.gear", load_at)
    if problems:
        raise _error(file, problems, raw, GearStudyError)
    ex = found[0]
    if sc.drive is not None:
        for g, given, gear in ((1, sc.drive.base_radius_1, ex.base_radius_1),
                               (2, sc.drive.base_radius_2, ex.base_radius_2)):
            if given is not None and abs(given / gear - 1.0) > 1e-3:
                where = f"scene.drive.base_radius_{g}"
                raise StudyError(file, where, _as_written(raw, _path_parts(where)) or given,
                                 f"the gear's base radius {gear * 1e3:.6g} mm (within 0.1 %), or"
                                 " omit the gear and type in the coefficients",
                                 line_of(raw, where))


# --------------------------------------------------------------------------- mesh studies


class MeshStudy(WholeStudy):
    """A static mesh study: gear pair(s) x torque(s) -> mesh cycle, Fourier series."""

    type: Literal["mesh"]
    title: str = Field(min_length=1)
    description: str = ""
    gear: GearField | None = None
    gears: dict[str, GearField] | None = Field(None, description="labelled variants")
    torque: Torque | None = Field(None, gt=0, description="driving torque T1 [N m]")
    sweep: dict[Literal["torque"], SweepAxis] = Field(default_factory=dict, description=(
        "torque: a list of torques ([20 N*m, 50 N*m]), a range {start, stop, num}, or one"
        " torque (50 N*m: the same as [50 N*m])"))
    positions: Count = Field(200, ge=8, le=100_000, description="positions per mesh cycle")
    harmonics: Count = Field(10, ge=1, le=100, description=(
        "Fourier harmonics kept (integrated between the mesh's jumps: any number of positions)"))

    @model_validator(mode="after")
    def _consistent(self) -> MeshStudy:
        if (self.gear is None) == (self.gears is None):  # (both: at the later one's line)
            raise FieldProblems([(("gear", "gears"), ("give exactly one of 'gear' (one pair) and"
                                  " 'gears' (labelled variants)"))])
        if self.gears is not None and not self.gears:
            raise FieldProblems([(("gears",), "'gears' needs at least one labelled gear pair")])
        if (self.torque is None) == ("torque" not in self.sweep):
            raise FieldProblems([(("torque", "sweep.torque"), ("give exactly one of 'torque' and"
                                  " 'sweep.torque'"))])
        return self

    @property
    def variants(self) -> dict[str, GearSpec]:
        """Label -> gear spec (one unnamed entry ``""`` for a single ``gear``)."""
        return dict(self.gears) if self.gears is not None else {"": self.gear}

    @property
    def swept_torque(self) -> bool:
        return "torque" in self.sweep

    def torques(self) -> np.ndarray:
        """Driving torques [N m]."""
        if not self.swept_torque:
            return np.array([self.torque])
        spec = self.sweep["torque"]
        if isinstance(spec, Range):
            a, b = to_si(spec.start, "torque"), to_si(spec.stop, "torque")
            return np.geomspace(a, b, spec.num) if spec.spacing == "log" else np.linspace(
                a, b, spec.num)
        return np.array([to_si(v, "torque") for v in spec], dtype=float)


def parse_mesh_study(raw: dict[str, Any], file: str) -> MeshStudy:
    """Validate a ``type: mesh`` study and every gear pair in it (one error line per problem)."""
    sweep = raw.get("sweep") if isinstance(raw, dict) else None
    if isinstance(sweep, dict) and "torque" in sweep and raw.get("torque") is not None:
        # On the sweep's line, with the torque's value (was line 1, '(top level)', '{...}')
        raise _error(file, [Problem("sweep.torque", sweep["torque"], "a torque swept or given,"
                                    f" not both (torque: {raw['torque']!r} too): drop one")], raw)
    try:
        study = MeshStudy.model_validate(raw)
    except ValidationError as exc:
        raise _first_error(exc, file, raw) from None
    _check_grids(study, file, raw)
    torques = study.torques()
    bad = [i for i, t in enumerate(torques) if not (math.isfinite(t) and t > 0)]
    if bad:  # on the value's own line (had none)
        where = ("sweep.torque" + (f"[{bad[0]}]" if not isinstance(study.sweep["torque"], Range)
                                   else "") if study.swept_torque else "torque")
        raise _error(file, [Problem(where, written_at(raw, where) if raw else float(torques[bad[0]]),
                                    "a positive torque (it loads the mesh)")], raw)
    problems = []  # of every variant at once, each at its field's line (were at the gear's)
    top, load_at = ((float(torques[0]), "torque") if not study.swept_torque
                    else _largest_of(study.sweep["torque"], torques, "torque"))
    for label, spec in study.variants.items():

        def computed(spec=spec) -> tuple[float, float]:  # at the largest torque: its STE is
            pair = gear_pair(spec).check()  # what mesh.load_faults tests
            mc = static_mesh(pair, top, tip_reliefs(spec, pair), n=study.positions)
            return top, float(mc.ste.max())

        problems += gear_refusals(spec, computed, file, raw,
                                  f"gears.{label}" if label else "gear", load_at)
    if problems:
        raise _error(file, problems, raw, GearStudyError)
    return study


def gear_refusals(spec: GearSpec, compute: Callable[[], tuple[float, float]], file: str,
                  raw: Any, where: str, load_at: str) -> list[Problem]:
    """The problems of the gear pair of ``spec``, written at ``where`` (``gear``, ``gears.NAME``,
    ``scene.gear``), that ``compute`` (its check and mesh) raises, each at the line of the first
    of the fields it names (``GeometryError.faults``, the most responsible first) that the file
    writes there, with the value written (a standard tip radius follows x1: at x1's line); at
    ``where``'s line when it writes none of them (a preset's); a fault of the ``torque``
    (``mesh.load_faults``: a deflection beyond the tooth) at ``load_at``, where the file writes
    the largest load, which ``compute`` returns with its peak STE. Its ``GeometryWarning``
    (nearly pointed teeth, a load beyond any rating) is warned the same way, once, when there is
    no problem."""
    try:
        pair = gear_pair(spec)
        with warned_once():
            torque, ste_peak = compute()
    except GeometryError as exc:  # (pair: set, raised after it)
        if not exc.faults:  # what the messages of no field say: at the gear's line, as it was
            return [Problem(where, NO_VALUE, str(exc))]
        note = preset_centre_said(spec, pair)
        return _at_gear_fields([(m + note if "centre_distance" in f else m, f)
                                for m, f in exc.faults], pair.name, raw, where, load_at)
    cautions = [*pair.cautions(), *load_cautions(pair, torque, ste_peak)]
    for p in _at_gear_fields(cautions, pair.name, raw, where, load_at):
        text = problem_line(file, line_of(raw, p.path), p.path, p.value, p.message)
        warnings.warn(GeometryWarning(text), stacklevel=3)
    return []


def _at_gear_fields(faults: list[tuple[str, tuple[str, ...]]], name: str, raw: Any,
                    where: str, load_at: str) -> list[Problem]:
    """``(message, fields)`` of the pair ``name`` as problems of the gear at ``where``: each at
    the first of its fields the file writes there (``torque``: at ``load_at``, where the file
    writes the load), naming the others it writes that share the blame (not teeth and module,
    which set every radius), else at ``where``, with the pair's name."""

    def path(field: str) -> str:
        return load_at if field == "torque" else f"{where}.{field}"

    out = []
    for message, fields in faults:
        written = [f for f in fields if written_at(raw, path(f)) is not None]
        if not written:
            out.append(Problem(where, NO_VALUE, f"{name}: {message}"))
            continue
        at, *others = written
        shared = ", ".join(f"{load_at if f == 'torque' else f}: {written_at(raw, path(f))}"
                           for f in others
                           if f not in ("z1", "z2", "module"))
        out.append(Problem(path(at), _shown_value(written_at(raw, path(at))),
                           message + (f"; also set by {shared}" if shared else "")))
    return out


def summary(study: MeshStudy) -> str:
    """One line describing the cases of a mesh study (for ``gearsweep validate``)."""
    nv, nt = len(study.variants), len(study.torques())
    return (f"mesh study, {nv} gear pair{'s' if nv > 1 else ''} x {nt} torque{'s' if nt > 1 else ''},"
            f" {study.positions} positions per mesh cycle, {study.harmonics} harmonics")


def read_text(path: str | Path) -> tuple[str, str]:
    """(text, name to show) of a study file; ``-`` reads stdin (shown as ``<stdin>``)."""
    if str(path) == "-":
        import sys

        buffer = getattr(sys.stdin, "buffer", None)  # (bytes: 'character \udce9 is not allowed')
        try:
            return (sys.stdin.read() if buffer is None else utf8_text(buffer.read())), "<stdin>"
        except NotUtf8 as exc:
            raise StudyError("<stdin>", "(file)", NO_VALUE, (
                f"not UTF-8 text: {exc.what} (a study file is UTF-8 text: save it as UTF-8)"),
                exc.line) from None
    path = Path(path)
    try:
        return utf8_text(path.read_bytes()), str(path)
    except NotUtf8 as exc:
        if not is_netcdf(path):
            raise StudyError(str(path), "(file)", NO_VALUE, (
                f"not UTF-8 text: {exc.what} (a study file is UTF-8 text: save it as UTF-8)"),
                exc.line) from None
        why = "this is a netCDF result; 'gearsweep inspect' describes it"
    except OSError as exc:
        why = exc.strerror
    raise StudyError(str(path), "(file)", str(path), f"a study file in YAML ({why})")


def is_netcdf(path: Path) -> bool:
    """Whether ``path`` starts as a netCDF file does (classic ``CDF`` or HDF5-based)."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(8)
    except OSError:
        return False
    return head.startswith((b"CDF\x01", b"CDF\x02", b"CDF\x05", b"\x89HDF\r\n\x1a\n"))


def load_study(path: str | Path) -> tuple[Study | MeshStudy | AnalysisStudy, str]:
    """Read and validate a study file (``-``: stdin); returns the study and its text (kept in
    the results)."""
    text, name = read_text(path)
    return parse_study(text, name), text

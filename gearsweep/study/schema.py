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
A top-level ``type: mesh`` selects a static mesh study (``gearsweep.study.mesh_runner``).

Every model forbids unknown keys. ``load_study`` turns any problem into one ``StudyError`` line:
file, field path, value, and what is allowed.
"""

from __future__ import annotations

import math
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Literal

import numpy as np
import yaml
from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    ValidationError,
    field_validator,
    model_validator,
)

from gearsweep.errors import GeometryError, StudyError
from gearsweep.model import SWEEPABLE
from gearsweep.study.gearscene import GearField
from gearsweep.study.units import CANONICAL, UnitParseError, to_si

if TYPE_CHECKING:
    from gearsweep.study.mesh_runner import MeshStudy


def _parse(kind: str, value: Any) -> Any:
    try:
        out = to_si(value, kind)
    except UnitParseError as exc:
        raise ValueError(str(exc)) from None
    if not math.isfinite(out):
        raise ValueError("expected a finite number")
    return out


def Q(kind: str) -> Any:  # noqa: N802 -- reads as a type in the models below
    """A float field given as a number or a string with units of ``kind``."""
    return Annotated[float, BeforeValidator(partial(_parse, kind))]


Length, Mass, Force, Torque = Q("length"), Q("mass"), Q("force"), Q("torque")
Damping, Stiffness, Inertia, Angle, Speed = (Q("damping"), Q("stiffness"), Q("inertia"),
                                            Q("angle"), Q("speed"))


class Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Drive(Strict):
    """Physical inputs of Eq. (7): inertias and base radii give m_eq and the force scale."""

    inertia_1: Inertia = Field(gt=0, description="polar inertia of the driving gear [kg m^2]")
    inertia_2: Inertia = Field(gt=0, description="polar inertia of the driven gear [kg m^2]")
    base_radius_1: Length = Field(gt=0, description="base radius of the driving gear [m]")
    base_radius_2: Length = Field(gt=0, description="base radius of the driven gear [m]")


class StiffnessHarmonic(Strict):
    amplitude: Stiffness = Field(ge=0, description="k_n of Eq. (1) [N/m]")
    order: float | None = Field(None, gt=0, allow_inf_nan=False,
                                description="mesh order (default: position + 1)")
    phase: Angle = Field(0.0, description="phase a_n [rad]")


class SteHarmonic(Strict):
    amplitude: Length = Field(ge=0, description="STE harmonic e_n [m]")
    order: float | None = Field(None, gt=0, allow_inf_nan=False,
                                description="mesh order (default: position + 1)")
    phase: Angle = Field(0.0, description="phase [rad]")


class Fluctuation(Strict):
    """A harmonic of the driving-torque fluctuation: a force [N] or a torque [N m] (Eq. 7)."""

    amplitude: float | str = Field(description="force [N] or driving torque [N m] amplitude")
    order: float = Field(gt=0, allow_inf_nan=False,
                         description="mesh order (1 = mesh frequency; 1/teeth = shaft)")
    phase: Angle = Field(0.0, description="phase [rad]")

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
        raise ValueError("expected a force (e.g. '300 N') or a torque (e.g. '5 N*m')")


class _Driven(Strict):
    """Fields shared by the scenes of the gear drive (not the dimensionless Mathieu scene)."""

    mass: Mass | None = Field(None, gt=0, description="equivalent mass m_eq [kg]")
    drive: Drive | None = None
    teeth: int | None = Field(None, gt=0, le=1000, description="teeth of the driving gear N1")
    stiffness: Stiffness | None = Field(None, gt=0, description="mean mesh stiffness k0 [N/m]")
    gear: GearField | None = Field(None, description="gear pair giving k(t), e(t), N1, r1")
    harmonics: int | None = Field(None, ge=1, le=100, description="Fourier harmonics of a gear")
    damping: Damping = Field(0.0, ge=0, description="mesh viscous damping c [N s/m]")
    speed: Speed | None = Field(None, gt=0, description="driving-gear speed if not swept [rpm]")
    mean_force: Force | None = Field(None, description="mean mesh force F_m [N]")
    torque: Torque | None = Field(None, description="mean driving torque T1m [N m]")
    base_radius: Length | None = Field(None, gt=0, description="driving base radius r1 [m]")
    fluctuation: list[Fluctuation] = Field(default_factory=list)

    @model_validator(mode="after")
    def _mass_and_force(self) -> _Driven:
        if (self.mass is None) == (self.drive is None):
            raise ValueError("give exactly one of 'mass' (m_eq) and 'drive' (inertias, radii)")
        if self.mean_force is not None and self.torque is not None:
            raise ValueError("give at most one of 'mean_force' and 'torque'")
        if self.drive is not None and self.base_radius is not None:
            raise ValueError("'base_radius' is already given by 'drive.base_radius_1'")
        if self.gear is None:
            missing = [f"'{f}'" for f in ("teeth", "stiffness") if getattr(self, f) is None]
            if missing:
                raise ValueError(f"{' and '.join(missing)} required (or a 'gear' that gives"
                                 " teeth, stiffness and their harmonics)")
            if self.harmonics is not None:
                raise ValueError("'harmonics' is the number of Fourier terms of a 'gear'; no gear")
            return self
        typed = [f for f in ("teeth", "stiffness", "stiffness_harmonics", "ste", "base_radius")
                 if getattr(self, f, None)]
        if typed:
            raise ValueError(f"give either 'gear' or typed-in {', '.join(typed)}, not both: the"
                             " gear pair gives teeth, stiffness, stiffness_harmonics, ste and"
                             " base_radius")
        if self.torque is None and self.mean_force is None:
            raise ValueError("a 'gear' needs the mean load (scene.torque or scene.mean_force):"
                             " its stiffness and STE are computed at that load")
        return self

    @property
    def r1(self) -> float | None:
        return self.drive.base_radius_1 if self.drive is not None else self.base_radius


class WhineScene(_Driven):
    """Eq. (9): no backlash (f(p) = p); time-varying stiffness and STE excitation."""

    kind: Literal["whine"]
    stiffness_harmonics: list[StiffnessHarmonic] = Field(default_factory=list)
    ste: list[SteHarmonic] = Field(default_factory=list)


class RattleScene(_Driven):
    """Eq. (13): constant stiffness with backlash; torque fluctuation and STE excitation."""

    kind: Literal["rattle"]
    backlash: Length = Field(gt=0, description="total backlash on the line of action [m]")
    ste: list[SteHarmonic] = Field(default_factory=list)


class FullScene(_Driven):
    """Eq. (6) with every term."""

    kind: Literal["full"]
    backlash: Length = Field(0.0, ge=0, description="total backlash on the line of action [m]")
    stiffness_harmonics: list[StiffnessHarmonic] = Field(default_factory=list)
    ste: list[SteHarmonic] = Field(default_factory=list)


class MathieuScene(Strict):
    """Eq. (11): p'' + gamma p' + (alpha + beta cos tau) p = 0 (k0 + k1 only, homogeneous)."""

    kind: Literal["mathieu"]
    alpha: float = Field(0.25, description="k0 / (m (N w)^2)")
    beta: float = Field(0.0, description="k1 / (m (N w)^2)")
    gamma: float = Field(0.0, ge=0, description="c / (m N w)")


Scene = Annotated[WhineScene | RattleScene | FullScene | MathieuScene, Field(discriminator="kind")]

SCENE_PARAMETERS = {
    "whine": {"speed", "torque", "mean_force", "damping", "mass", "stiffness"},
    "rattle": {"speed", "torque", "mean_force", "damping", "mass", "stiffness", "backlash"},
    "full": {"speed", "torque", "mean_force", "damping", "mass", "stiffness", "backlash"},
    "mathieu": {"alpha", "beta", "gamma"},
}
"""Which parameters each scene lets a study sweep."""


class Range(Strict):
    """``{start, stop, num}``: ``num`` values from ``start`` to ``stop`` inclusive."""

    start: float | str
    stop: float | str
    num: int = Field(ge=1, le=10_000_000)
    spacing: Literal["linear", "log"] = "linear"


class Solver(Strict):
    method: Literal["rk4", "rk5"] = "rk4"
    steps_per_period: int = Field(64, ge=4, le=65536, description="steps per mesh period")
    kink_aware: bool = Field(
        False, description="redo steps that cross the backlash boundaries in pieces that end on "
        "them (gearsweep.kernels.kink): keeps the method's order 4/5 with backlash, where the "
        "plain step falls to order 2; no effect without backlash")
    transient_periods: int = Field(100, ge=0, description="mesh periods discarded")
    record_periods: int = Field(50, ge=1, description="mesh periods recorded for statistics")
    divergence_factor: float = Field(1e6, gt=1, description="|p| bound / static scale")
    settle_tolerance: float = Field(1e-2, gt=0, description="settle_error above it: status 2")
    initial_displacement: Length = Field(0.0, description="p at t = 0 [m] (Mathieu: 1)")
    initial_velocity: float = Field(0.0, allow_inf_nan=False, description="p' at t = 0 [m/s]")
    device: Literal["cpu", "cuda", "auto"] = Field(
        "cpu", description="where the kernel runs: cpu, cuda (a CUDA GPU, docs/gpu.md) or auto"
        " (cuda where a GPU is present)")
    precision: Literal["float64", "float32"] = Field(
        "float64", description="float32: the state in single precision (device cuda only)")
    step_guard: Literal["warn", "skip", "off"] = Field(
        "warn", description="cases whose step is beyond the method's stability limit: flag them"
        " (warn), do not integrate them (skip, status 3), or do not check (off)")


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


class Study(Strict):
    title: str = Field(min_length=1)
    description: str = ""
    scene: Scene
    sweep: dict[str, list[float | str] | Range] = Field(default_factory=dict)
    continuation: list[Literal["up", "down"]] = Field(default_factory=list)
    solver: Solver = Field(default_factory=Solver)
    outputs: list[Annotated[OutputRequest, BeforeValidator(_output_request)]] = Field(
        default_factory=lambda: [OutputRequest(name="stats")])

    @model_validator(mode="after")
    def _consistent(self) -> Study:
        allowed = SCENE_PARAMETERS[self.scene.kind]
        for name in self.sweep:
            if name not in allowed:
                raise ValueError(f"sweep.{name}: not a parameter of the {self.scene.kind!r} scene;"
                                 f" allowed: {', '.join(sorted(allowed))}")
        if self.scene.kind != "mathieu":
            if "speed" not in self.sweep and self.scene.speed is None:
                raise ValueError("the speed must be swept (sweep.speed) or given (scene.speed)")
            if self.scene.gear is not None:
                for name in ("torque", "mean_force", "stiffness"):
                    if name in self.sweep:
                        raise ValueError(
                            f"sweep.{name}: a gear scene computes stiffness and STE at one mean"
                            " load; sweeping it is not supported (one study per load, or type"
                            " in the coefficients)")
            elif "torque" in self.sweep or self.scene.torque is not None:
                if self.scene.r1 is None:
                    raise ValueError("a torque needs the driving gear's base radius:"
                                     " scene.base_radius or scene.drive")
            if "torque" in self.sweep and "mean_force" in self.sweep:
                raise ValueError("sweep torque or mean_force, not both")
        if self.continuation:
            if "speed" not in self.sweep:
                raise ValueError("continuation carries the state along sweep.speed:"
                                 " sweep the speed")
            if len(set(self.continuation)) != len(self.continuation):
                raise ValueError("continuation lists each direction at most once")
        from gearsweep.study.outputs import OUTPUTS

        names = [o.name for o in self.outputs]
        for name in names:
            if name not in OUTPUTS:
                raise ValueError(f"outputs: {name!r} is not an output; allowed:"
                                 f" {', '.join(sorted(OUTPUTS))}")
        if len(set(names)) != len(names):
            raise ValueError("outputs: list each output at most once")
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


def _check_grids(study: Study, file: str) -> None:
    """Units and physical bounds of every sweep value (one line per problem)."""
    positive = {"speed", "mass", "stiffness", "backlash"}
    for name, spec in study.sweep.items():
        kind = SWEEPABLE[name]
        raw = [spec.start, spec.stop] if isinstance(spec, Range) else list(spec)
        where = f"sweep.{name}" if not isinstance(spec, Range) else f"sweep.{name}.start/stop"
        if not raw:
            raise StudyError(file, f"sweep.{name}", spec, "a non-empty list or {start, stop, num}")
        for v in raw:
            try:
                val = to_si(v, kind)
            except UnitParseError as exc:
                raise StudyError(file, where, v, f"{kind} in {CANONICAL[kind] or 'no unit'}: {exc}"
                                 ) from None
            if not math.isfinite(val):
                raise StudyError(file, where, v, "a finite number")
            if name in positive and val <= 0:
                raise StudyError(file, where, v, f"{name} must be > 0")
            if name in ("damping", "gamma") and val < 0:
                raise StudyError(file, where, v, f"{name} must be >= 0")
        if isinstance(spec, Range) and spec.spacing == "log":
            if to_si(spec.start, kind) <= 0 or to_si(spec.stop, kind) <= 0:
                raise StudyError(file, where, raw, "log spacing needs positive start and stop")


def _user_path(loc: tuple) -> list[str | int]:
    """The parts of a pydantic error location that are keys and indices of the user's file
    (without the scene kind's tag and pydantic's names of union branches and validators)."""
    parts: list[str | int] = []
    for p in loc:
        if isinstance(p, int):
            parts.append(p)
        elif p in ("whine", "rattle", "full", "mathieu") and parts and parts[-1] == "scene":
            continue  # the discriminator's tag is not part of the user's path
        elif p.startswith("function-") or p in ("list[union[float,str]]", "Range", "float", "str"):
            continue
        else:
            parts.append(p)
    return parts


def _loc(loc: tuple) -> str:
    text = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in _user_path(loc))
    return text.removeprefix(".") or "(top level)"


def _as_written(raw, loc: tuple):
    """The value at ``loc`` as the user wrote it (``'-0.5 mm'``, not the SI number a quantity
    validator turned it into), or ``None`` if the file has nothing there."""
    for p in _user_path(loc):
        if isinstance(raw, dict) and p in raw:
            raw = raw[p]
        elif isinstance(raw, list) and isinstance(p, int) and 0 <= p < len(raw):
            raw = raw[p]
        else:
            return None
    return raw


def _first_error(exc: ValidationError, file: str, raw=None) -> StudyError:
    # Of the branches of a union (a list or a {start, stop, num} range), report the one the
    # user evidently meant: a type mismatch of another branch is the least specific error.
    errs = exc.errors()
    err = min(errs, key=lambda e: (e["type"].endswith("_type") or e["type"] == "union_tag_invalid"
                                   and len(errs) > 1, -len(e["loc"])))
    msg = err["msg"].removeprefix("Value error, ")
    value = err.get("input")
    written = _as_written(raw, err["loc"])
    if isinstance(written, str | int | float) and not isinstance(value, dict | list):
        value = written
    if isinstance(value, dict | list):
        value = "{...}" if isinstance(value, dict) else "[...]"
    if err["type"] == "extra_forbidden":
        msg = "unknown field (check the spelling; see the study format in the README)"
    if err["type"] == "missing":
        value, msg = "(missing)", "this field is required"
    return StudyError(file, _loc(err["loc"]), value, msg)


def parse_study(text: str, file: str = "<study>") -> Study | MeshStudy:
    """Validate a study from its YAML text; any problem raises one ``StudyError``.

    A top-level ``type: mesh`` selects a static mesh study (``gearsweep.study.mesh_runner``).
    """
    try:
        raw = yaml.safe_load(text)
    except RecursionError:
        raise StudyError(file, "(yaml)", "(text)", "YAML nested less deeply") from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"line {mark.line + 1}" if mark is not None else "(yaml)"
        problem = getattr(exc, "problem", None) or "not valid YAML"
        raise StudyError(file, where, "(text)", f"valid YAML ({problem})") from None
    if not isinstance(raw, dict):
        raise StudyError(file, "(top level)", type(raw).__name__,
                         "a mapping with title, scene, sweep, solver, outputs")
    if "type" in raw and raw["type"] != "mesh":
        raise StudyError(file, "type", raw["type"],
                         "'mesh' (a static mesh study), or no 'type' for a dynamic study")
    if raw.get("type") == "mesh":
        from gearsweep.study.mesh_runner import parse_mesh_study

        return parse_mesh_study(raw, file)
    try:
        study = Study.model_validate(raw)
    except ValidationError as exc:
        raise _first_error(exc, file, raw) from None
    except RecursionError:
        raise StudyError(file, "(top level)", "{...}", "values nested less deeply") from None
    _check_grids(study, file)
    _check_gear(study, file)
    from gearsweep.study.outputs import configure

    for i, req in enumerate(study.outputs):
        configure(req.name, req.options, file, f"outputs[{i}].{req.name}")
    return study


def _check_gear(study: Study, file: str) -> None:
    """Geometry of a scene's gear pair: checked here, so ``validate`` refuses what ``run`` would."""
    sc = study.scene
    if getattr(sc, "gear", None) is None:
        return
    from gearsweep.study.gearscene import scene_excitation

    try:
        ex = scene_excitation(sc)
    except GeometryError as exc:
        raise GeometryError(f"{file}: scene.gear: {exc}") from None
    if sc.drive is not None:
        for g, given, gear in ((1, sc.drive.base_radius_1, ex.base_radius_1),
                               (2, sc.drive.base_radius_2, ex.base_radius_2)):
            if abs(given / gear - 1.0) > 1e-3:
                raise StudyError(file, f"scene.drive.base_radius_{g}", given,
                                 f"the gear's base radius {gear:.6g} m (within 0.1 %), or omit"
                                 " the gear and type in the coefficients")


def load_study(path: str | Path) -> tuple[Study | MeshStudy, str]:
    """Read and validate a study file; returns the study and its text (kept in the results)."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        why = exc.strerror if isinstance(exc, OSError) else "not UTF-8 text"
        raise StudyError(str(path), "(file)", str(path), f"a readable UTF-8 file ({why})") from None
    return parse_study(text, str(path)), text

"""From a validated study to a plan: the model, the grid, the lanes and the step guard, resolved once.

The cases of a study form a grid over its swept parameters (in the order the study lists them).
They are run in *lanes*: without continuation a lane is one case; with ``continuation`` a lane is
one sweep along ``speed`` (every other parameter fixed), run up and/or down, each speed starting
from the final state of the previous one. Lanes are independent, so a study is cut into chunks of
lanes (``Plan.chunks``); ``gearsweep.study.chunk`` computes one chunk, ``gearsweep.study.execute``
runs them (here or on dask) and ``gearsweep.study.dataset`` puts them together.
"""

from __future__ import annotations

import hashlib
import inspect
import math
import re
from dataclasses import dataclass, field, replace
from functools import lru_cache
from typing import Any

import numpy as np

from gearsweep.analysis.stability import (
    COARSE_STEPS,
    RESONANCE_TOL,
    STRONG_VARIATION,
    TONGUE_MARGIN,
    frozen_map_multiplier,
    frozen_poles,
    frozen_step_ok,
    map_step_check,
    needs_map_check,
    ray_limit,
    resonance_error,
    stability_polynomial,
    step_limit_hw,
)
from gearsweep.errors import NO_VALUE, StudyError
from gearsweep.files import atomic_write, cache_folder
from gearsweep.gear.excitation import DEFAULT_HARMONICS
from gearsweep.gear.measured import positive_minimum
from gearsweep.kernels import LANES
from gearsweep.kernels.cuda import CHUNK_STEPS as GPU_CHUNK_STEPS
from gearsweep.kernels.cuda import planned_device
from gearsweep.kernels.floquet import UNSTABLE_TOL, floquet, largest_multiplier, monodromy
from gearsweep.model import (
    Harmonic,
    MathieuModel,
    MeshModel,
    _case,
    equivalent_mass,
    hill_cycle,
    hill_parameters,
    mean_mesh_force,
)
from gearsweep.model import fluctuating_force as eq7_force
from gearsweep.study.gearscene import scene_excitation
from gearsweep.study.lanes import lane_values
from gearsweep.study.measured import scene_measured, typed_harmonics
from gearsweep.study.outputs import (
    OUTPUTS,
    VarSpec,
    configure,
    forced_scene,
    record_periods_needed,
)
from gearsweep.study.schema import Study, first_load, line_of, load_yaml, written_at
from gearsweep.units import to_si

STATUS_NOT_SETTLED = 2
CHUNK_STEPS = 1e9
"""Target integration steps per chunk: about 0.7 s of kernel time on this 2-core machine (plain
RK4 on a rattle scene, about 1,400 Msteps/s), long enough that the per-chunk work around the
kernel (lane values, kernel inputs, outputs: about 20 ms for 400,000 lanes; the checkpoint file
is written by a background thread) stays near 5 %, short enough
for progress and checkpoints every second or so."""
CHUNK_SIGNAL_BYTES = 64e6
"""At most this much recorded time history per chunk (outputs reduce it per chunk)."""


def build_model(study: Study, torque: float | None = None) -> MeshModel | MathieuModel:
    """The scene's fixed values as a ``MeshModel`` (or ``MathieuModel``) in SI units.

    ``torque`` [N m]: the mean load at which a gear scene's k(t) and e(t) are computed when the
    study sweeps the load (default: the first swept load, or the scene's own).
    """
    sc = study.scene
    if sc.kind == "mathieu":
        return MathieuModel(alpha=sc.alpha, beta=sc.beta, gamma=sc.gamma)
    if sc.drive is not None:
        d = sc.drive
        rb1, rb2 = sc.drive_radii()  # the gear pair's where the drive does not repeat them
        mass = equivalent_mass(d.inertia_1, d.inertia_2, rb1, rb2)
    else:
        mass = sc.mass
    r1 = sc.r1
    gear = None
    if getattr(sc, "gear", None) is not None:
        gear = scene_excitation(sc, torque if torque is not None else first_load(study))
    if gear is not None:
        r1 = gear.base_radius_1
    mean_force = sc.mean_force if sc.mean_force is not None else 0.0
    if sc.torque is not None:
        mean_force = mean_mesh_force(sc.torque, r1)
    fluct = []
    for f in sc.fluctuation:
        if not f.is_torque:
            amp = to_si(f.amplitude, "force")
        else:
            # A driving-torque amplitude: Eq. (7) with the drive's inertia, or F = T / r1
            # (the rigid-pinion limit I2 -> infinity) when only m_eq and r1 are known.
            torque = to_si(f.amplitude, "torque")
            if sc.drive is not None:
                amp = eq7_force(torque, mass, r1, sc.drive.inertia_1)
            elif r1 is not None:
                amp = torque / r1
            else:
                amp = math.nan
        fluct.append(Harmonic(amp, f.order, f.phase))

    if gear is not None:  # k(t), e(t) of the gear pair at the mean load (gearscene.py)
        k_from, kh_from, e_from = gear_sources(sc)
        teeth = gear.teeth
        k0 = sc.stiffness if k_from == "typed" else gear.stiffness
        # a typed k_n without a phase keeps the pair's phase of its order
        k_h = {"typed": typed_harmonics(getattr(sc, "stiffness_harmonics", []),
                                        {h.order: h.phase for h in gear.stiffness_harmonics}),
               "pair": gear.stiffness_harmonics, "none": ()}[kh_from]
        e_h = gear.ste_harmonics if e_from == "loaded_ste" else gear.no_load_te_harmonics
    else:
        teeth, k0 = sc.teeth, sc.stiffness
        k_h = typed_harmonics(getattr(sc, "stiffness_harmonics", []))
        e_h = typed_harmonics(getattr(sc, "ste", []))
    if getattr(sc, "excitation", None) is not None:  # samples from a file, fitted (measured.py)
        fit = scene_measured(sc, mean_force)
        if fit.stiffness is not None:  # k0 and, with k(t), k_n from the file
            k0, k_h = fit.stiffness, fit.stiffness_harmonics
        if fit.excitation_fit is not None:  # e(t): STE - F_m / k(t), or the STE (rattle)
            e_h = fit.ste_harmonics
    def given(value: float | None) -> float:
        # None: a field the scene leaves to the sweep (schema.swept_fields), which gives each
        # case its own; the model has no scene value of it (model_swept names it), not a case's
        return math.nan if value is None else value

    return MeshModel(
        mass=given(mass),
        teeth=teeth,
        stiffness=given(k0),
        damping=sc.damping,
        mean_force=mean_force,
        base_radius=r1,
        backlash=given(getattr(sc, "backlash", 0.0)),
        stiffness_harmonics=k_h,
        ste_harmonics=e_h,
        force_harmonics=tuple(fluct),
    )


def gear_sources(scene: Any) -> tuple[str, str, str]:
    """Where the k0, the k_n and the e_n of a gear scene's model come from (``build_model``; the
    result's ``gear_*`` variables say it, ``resultfile.gear_variables``): k0 ``"typed"`` (a
    ``stiffness`` typed in beside the gear, e.g. the paper's printed k0) or ``"pair"`` (the gear
    pair's at the load); the k_n ``"typed"`` (``stiffness_harmonics`` beside a typed k0),
    ``"pair"`` or ``"none"`` (constant stiffness: a typed k0 without k_n, or a rattle scene,
    Eq. 13); the e_n ``"loaded_ste"`` (the pair's loaded STE at the load, where k(t) is typed or
    constant, as the paper drives Eq. (9) by its computed STE, Figs. 1-2) or ``"no_load_te"``
    (e(t) = STE - F_m / k(t) with the pair's own k(t))."""
    if scene.stiffness is not None:
        typed_kn = bool(getattr(scene, "stiffness_harmonics", []))
        return "typed", "typed" if typed_kn else "none", "loaded_ste"
    if scene.kind == "rattle":
        return "pair", "none", "loaded_ste"
    return "pair", "pair", "no_load_te"


@dataclass
class Plan:
    """Everything needed to run any chunk of a study, independent of where it runs."""

    study: Study
    text: str
    model: MeshModel | MathieuModel
    dims: list[str]
    """Swept dims, in the study's order (without ``direction``)."""
    grids: dict[str, np.ndarray]
    directions: list[str]
    """``["up"]``, ``["down"]``, both, or ``[]`` (no continuation)."""
    outputs: list[str]
    specs: dict[str, VarSpec] = field(default_factory=dict)
    options: dict[str, Any] = field(default_factory=dict)
    """Validated options of the outputs that take some (``outputs.configure``), by name."""
    memo: dict[str, Any] = field(default_factory=dict, init=False, repr=False, compare=False)
    """Per-study results kept between chunks (the step guard's table); not copied by
    ``dataclasses.replace``, so a changed plan never sees another's."""

    @property
    def continued(self) -> bool:
        return bool(self.directions)

    @property
    def study_key(self) -> str:
        """sha256 of the study as validated (its fields as JSON, keys sorted): the name of its
        checkpoint folder. An edit of the file that leaves every value as it was (a comment, the
        spacing, the order of keys) keeps the chunks saved by an interrupted run; a changed value,
        the title included, makes another study. (``study_sha256`` in a result is of the text.)
        The device is the one the chunks run on (``device``): ``auto`` on a machine without a
        GPU is the study with ``cpu``, so either resumes the other's chunks. A file the scene
        reads (``excitation.file``) counts by its bytes (sha256), not its name: its samples
        changed between an interrupted run and the next, the chunks of the old samples were
        resumed beside new ones, with the new file's fit in the result (an adversarial test)."""
        if "study_key" not in self.memo:
            import json

            study = self.study.model_dump(mode="json")
            study["solver"]["device"] = self.device
            if self.excitation_sha256 is not None:
                study["scene"]["excitation"]["file_sha256"] = self.excitation_sha256
            dump = json.dumps(study, sort_keys=True)
            self.memo["study_key"] = hashlib.sha256(dump.encode()).hexdigest()
        return self.memo["study_key"]

    @property
    def excitation_sha256(self) -> str | None:
        """sha256 of the bytes of the file the scene's k(t) and e(t) are fitted from
        (``excitation.file``), read once; ``None`` without one. In the study key, and in the
        result (``excitation_sha256``): the samples are not in the file, and the same study text
        fitted to other samples gave other numbers under the same ``study_sha256``."""
        if "excitation_sha256" not in self.memo:
            ex = getattr(getattr(self.study, "scene", None), "excitation", None)
            digest = None
            if ex is not None:
                with open(ex.file, "rb") as fh:
                    digest = hashlib.file_digest(fh, "sha256").hexdigest()
            self.memo["excitation_sha256"] = digest
        return self.memo["excitation_sha256"]

    @property
    def model_swept(self) -> list[str]:
        """The fields of ``model`` that hold the scene's own value where the cases had others:
        each swept parameter (``torque`` as ``mean_force``), and with a gear scene that sweeps
        its load, its k(t) and e(t) (those of the first load, unless a stiffness is typed beside
        the gear). The result names them (``model_swept``): its ``model`` attribute alone read
        as if every case had run with ``damping: 0.0`` (an outside tester's finding)."""
        out = [("mean_force" if d == "torque" else d) for d in self.dims if d != "speed"]
        if self.gear_load_swept:
            typed_k = self.gear_sources[0] == "typed"
            out += [] if typed_k else ["stiffness", "stiffness_harmonics"]
            out += ["ste_harmonics"]
        return list(dict.fromkeys(out))

    @property
    def gear_sources(self) -> tuple[str, str, str]:
        """``gear_sources`` of the plan's scene (a gear scene)."""
        return gear_sources(self.study.scene)

    @property
    def driven(self) -> bool:
        """Does anything drive the response (a mean force, or a swept one, a force harmonic, an
        STE)? An undriven scene (a Mathieu chart; a whine scene with neither load nor STE, the
        stability studies) is the homogeneous Eq. (11)-(12): its response dies away or grows,
        it has no steady state to settle into, so the settle test (status 2) does not apply."""
        m = self.model
        if not isinstance(m, MeshModel):
            return False
        return bool(m.mean_force or m.ste_harmonics or m.force_harmonics
                    or "mean_force" in self.grids or "torque" in self.grids)

    @property
    def has_backlash(self) -> bool:
        return isinstance(self.model, MeshModel) and (self.model.backlash > 0
                                                       or "backlash" in self.grids)

    @property
    def gear_load_swept(self) -> bool:
        """A gear scene sweeping its load: k(t) and e(t) are computed per distinct load."""
        return getattr(self.study.scene, "gear", None) is not None and (
            "torque" in self.grids or "mean_force" in self.grids)

    def model_for_load(self, torque: float) -> MeshModel:
        """The gear scene's model at mean driving torque ``torque`` [N m] (built once per plan:
        ``_per_load``)."""
        cache = self._per_load().setdefault("models", {})
        if torque not in cache:
            cache[torque] = build_model(self.study, torque)
        return cache[torque]

    def stiffest_load(self) -> float:
        """The largest mean stiffness k0 [N/m] of the swept loads' k(t) (``model_for_load``),
        found once per plan (``_per_load``)."""
        per_load = self._per_load()
        if "stiffest" not in per_load:
            g = self.grids
            loads = self.case_torques({d: g[d] for d in ("torque", "mean_force") if d in g})
            per_load["stiffest"] = max(self.model_for_load(float(t)).stiffness
                                       for t in np.unique(loads))
        return per_load["stiffest"]

    def _per_load(self) -> dict[str, Any]:
        """What a gear scene that sweeps its load knows of its loads (their models, the
        stiffest k0): of the study alone, so shared by the plans of its loads (``at_load``)."""
        return self.memo.setdefault("per_load", {})

    def at_load(self, torque: float) -> Plan:
        """The plan whose model is the gear scene's at ``torque`` [N m] (``model_for_load``):
        what one load's kernel call and outputs read. It shares this plan's ``_per_load``: the
        spectrum's sampling asks each load's plan for every load's k0 (``outputs.resonant_order``),
        and with a memo of its own every load's plan built every load's model again, in every
        chunk (2,353 builds for 48 loads; an outside tester's 1,200 cases of 300 loads were still
        running after 10 min)."""
        at = replace(self, model=self.model_for_load(torque))
        at.memo["per_load"] = self._per_load()
        return at

    def with_solver(self, **changes: Any) -> Plan:
        """The plan with the solver's fields ``changes`` (the short runs of a warm-up and of a
        rate measurement). It shares this plan's ``_per_load``: a scene's models depend on the
        scene and the sweep alone, and the warm-up's one case built every load's model again."""
        solver = self.study.solver.model_copy(update=changes)
        new = replace(self, study=self.study.model_copy(update={"solver": solver}))
        new.memo["per_load"] = self._per_load()
        return new

    def case_torques(self, params: dict[str, np.ndarray]) -> np.ndarray:
        """Mean driving torque [N m] of each case of a gear scene that sweeps its load."""
        if "torque" in params:
            return np.asarray(params["torque"], float)
        return np.asarray(params["mean_force"], float) * self.model.base_radius

    def case_mean_forces(self, params: dict[str, np.ndarray], n: int) -> np.ndarray:
        """Mean mesh force F_m [N] of each of the ``n`` cases ``params`` of a gear-mesh scene:
        its swept ``mean_force``, or its swept ``torque`` by Eq. (7), else the scene's. Its sign
        says which flank the load presses: the drive flank for F_m > 0, the back flank for
        F_m < 0 (``outputs.loaded_flank_lost``, ``chunk._start``)."""
        if "torque" in params:
            return mean_mesh_force(np.asarray(params["torque"], float), self.model.base_radius)
        if "mean_force" in params:
            return np.asarray(params["mean_force"], float)
        return np.full(n, float(self.model.mean_force))

    @property
    def load_signs(self) -> set[int]:
        """The signs (-1, 0, 1) of the mean mesh forces of the cases of a gear-mesh scene: of its
        swept ``mean_force`` or ``torque`` (F_m = T / r1, r1 > 0), else of the scene's F_m."""
        g = self.grids
        vals = g.get("mean_force", g.get("torque", [self.model.mean_force]))
        return {int(v) for v in np.sign(np.asarray(vals, float))}

    @property
    def dimensionless(self) -> bool:
        return isinstance(self.model, MathieuModel)

    @property
    def lane_dims(self) -> list[str]:
        return [d for d in self.dims if not (self.continued and d == "speed")]

    @property
    def n_lanes(self) -> int:
        return math.prod(len(self.grids[d]) for d in self.lane_dims)  # Python int: no overflow

    @property
    def chain(self) -> int:
        """Cases per lane per direction (speeds of a continued sweep, else 1)."""
        return len(self.grids["speed"]) if self.continued else 1

    @property
    def cases_per_lane(self) -> int:
        """Cases per lane: the chain's speeds in each sweep direction (1 for independent cases)."""
        return self.chain * max(len(self.directions), 1)

    @property
    def n_cases(self) -> int:
        return self.n_lanes * self.cases_per_lane

    @property
    def steps_per_case(self) -> int:
        s = self.study.solver
        return (s.transient_periods + s.record_periods) * s.steps_per_period

    def samples_per_period(self) -> int:
        need = [OUTPUTS[o].signal_samples_per_period(self) for o in self.outputs]
        return max(need, default=0)

    @property
    def device(self) -> str:
        """``"cpu"`` or ``"cuda"``: where the chunks will run (``cuda.planned_device``)."""
        return planned_device(self.study.solver.device)

    def default_lanes_per_chunk(self) -> int:
        """Lanes per chunk for about ``CHUNK_STEPS`` steps on the CPU, ``cuda.CHUNK_STEPS`` on
        the GPU (and at most ``CHUNK_SIGNAL_BYTES`` of recorded signal)."""
        per_lane = self.steps_per_case * self.cases_per_lane
        steps = CHUNK_STEPS if self.device == "cpu" else GPU_CHUNK_STEPS
        lanes_per_chunk = max(4 * LANES, int(steps // max(per_lane, 1)))
        # Up and down sweeps of a lane run side by side: one signal per direction.
        signal = (self.samples_per_period() * self.study.solver.record_periods * 8
                  * max(len(self.directions), 1))
        if signal:
            lanes_per_chunk = min(lanes_per_chunk,
                                  max(4 * LANES, int(CHUNK_SIGNAL_BYTES // signal)))
        return lanes_per_chunk

    def chunks(self, lanes_per_chunk: int | None = None) -> list[tuple[int, int]]:
        """Lane ranges ``[start, stop)`` of the chunks (whole sweeps inside a chunk)."""
        if lanes_per_chunk is None:
            lanes_per_chunk = self.default_lanes_per_chunk()
        n = self.n_lanes
        return [(a, min(a + lanes_per_chunk, n)) for a in range(0, n, lanes_per_chunk)]


STEPS_PER_HARMONIC = 4
"""Fewest steps per period of the highest excitation harmonic written in the study (its
``stiffness_harmonics``, ``ste`` and ``fluctuation``) or asked of a ``gear:`` (its
``harmonics``, known before the mesh is computed; an excitation file's fit is not held to it).
The excitation tables are read at the steps' nodes, and with fewer steps the integration cannot
follow that harmonic's forcing: at half a step per period an STE of order 64 gave p_rms
8.8e-14 um against 3.56 um at 1024 steps per mesh period, with status 0. A gear whine of 10
harmonics at 32 steps was accepted while typed harmonics of order 10 were refused, and its
spectrum sampled p 32 times per period (an outside tester). The studies of this repository take
12.8 or more, their gears too."""


def make_plan(study: Study, text: str = "", file: str | None = None) -> Plan:
    """Grids, dims and output specs of a study (nothing is integrated yet).

    A problem found here (steps per period against the outputs' sampling, an output's options)
    is reported under ``file`` and the line of its field in ``text``, like the schema's own: the
    field as the file writes it (``outputs[0].spectrum.max_order``) and its value as written
    (``40``, not ``40.0``)."""
    try:
        return _make_plan(study, text)
    except StudyError as exc:
        if exc.file != "<study>" or file is None or not text:
            raise
        raw = load_yaml(text, file)
        found = []
        for _, field_, value, allowed in exc.problems:  # every problem planning found
            where = _field_in_file(study, raw, field_)
            written = written_at(raw, where)
            if isinstance(written, str | int | float) and value is not NO_VALUE:
                value = written
            found.append((line_of(raw, where), where, value, allowed))
        raise StudyError.many(file, found) from None


def _field_in_file(study: Study, raw: Any, field: str) -> str:
    """An output's field named as an output names it (``outputs.spectrum.max_order``), as the
    study file writes it: ``outputs[0].spectrum.max_order`` (or ``outputs[0].options.max_order``
    for an entry written ``{name: spectrum, options: {...}}``)."""
    m = re.fullmatch(r"outputs\.(\w+)((?:\.\w+)*)", field)
    names = [o.name for o in study.outputs]
    if m is None or m[1] not in names:
        return field
    i = names.index(m[1])
    item = written_at(raw, f"outputs[{i}]")
    return f"outputs[{i}].{'options' if isinstance(item, dict) and 'name' in item else m[1]}{m[2]}"


def _make_plan(study: Study, text: str) -> Plan:
    dims = list(study.sweep)
    grids = {d: study.grid(d) for d in dims}
    if study.scene.kind != "mathieu" and "speed" not in grids:
        grids["speed"] = np.array([study.scene.speed])
        dims.append("speed")
    problems: list[StudyError] = []  # every one of them at once (they came one run each)
    options, refused = {}, False
    for o in study.outputs:
        try:
            options[o.name] = configure(o.name, o.options)
        except StudyError as exc:
            problems.append(exc)
            options[o.name], refused = None, True  # its defaults, to check the rest
    plan = Plan(study, text, build_model(study), dims, grids, list(study.continuation),
                [o.name for o in study.outputs], options=options)
    for o in plan.outputs:
        try:
            plan.specs.update(OUTPUTS[o].variables(plan))
        except StudyError as exc:
            problems.append(exc)
    if study.solver.step_guard == "warn":
        plan.specs["beyond_step_limit"] = VarSpec(dtype="bool", attrs={
            "units": "1", "long_name": "step beyond the method's stability limit, or (a forced"
            " scene near a parametric tongue of k(t)) the fixed-step map's resonant response more"
            f" than {RESONANCE_TOL * 100:g} % off the exact equation's, or a map the step guard could"
            " not check (k(t)'s orders with no short common period): results may be spoiled by"
            " the integrator (docs/stability.md)"})
    typed = getattr(study.scene, "stiffness_harmonics", None)
    if typed:  # (a gear's own k(t) is positive: the pair's teeth in contact)
        k0 = grids["stiffness"].min() if "stiffness" in grids else plan.model.stiffness
        low, where = positive_minimum(k0, plan.model.stiffness_harmonics,
                                      getattr(plan.model, "cycle_periods", 1))
        if not low > 0:  # said at k0's field instead where the file writes it later
            k0_at = "scene.stiffness"
            if "stiffness" in grids:
                spec, i = study.sweep["stiffness"], int(np.argmin(grids["stiffness"]))
                k0_at = (f"sweep.stiffness[{i}]" if isinstance(spec, list | tuple) else
                         f"sweep.stiffness.{'start' if i == 0 else 'stop'}")
            problems.append(_at_later_written(study, text, StudyError(
                "<study>", "scene.stiffness_harmonics", NO_VALUE, (
                    f"harmonics that keep k(t) positive: with k0 = {k0 / 1e6:.6g} kN/mm"
                    f"{' (the least swept)' if 'stiffness' in grids else ''} they take it to"
                    f" {low / 1e6:.4g} kN/mm at mesh phase {where:.3g}")),
                [(k0_at, k0, (f"above {(k0 - low) / 1e6:.6g} kN/mm, where"
                              " scene.stiffness_harmonics keep k(t) positive (at this k0 they"
                              f" take it to {low / 1e6:.4g} kN/mm at mesh phase {where:.3g})"))]))
    rec, cycle = study.solver.record_periods, getattr(plan.model, "cycle_periods", 1)
    if plan.driven and rec < 2 * cycle:
        problems.append(StudyError("<study>", "solver.record_periods", rec,
                                   record_periods_needed(cycle, model=plan.model)))
    spp = study.solver.steps_per_period
    orders = [h.order for typed, model_field in (  # the harmonics written in the study (a
        ("stiffness_harmonics", "stiffness_harmonics"), ("ste", "ste_harmonics"),  # gear's or
        ("fluctuation", "force_harmonics"))  # an excitation file's: their number is a setting)
        if getattr(study.scene, typed, None) for h in getattr(plan.model, model_field, ())]
    gear = None  # a gear's highest order: its harmonics, the number asked for
    if getattr(study.scene, "gear", None) is not None:
        gear = study.scene.harmonics if study.scene.harmonics is not None else DEFAULT_HARMONICS
        orders.append(gear)
    fitted = None  # an excitation file's fit: its highest mesh order, the number asked for
    if getattr(study.scene, "excitation", None) is not None:
        fitted = study.scene.excitation.harmonics
        orders.append(fitted)
    if orders and spp < STEPS_PER_HARMONIC * max(orders):  # (order 64 at 32 steps: p_rms
        top = max(orders)  # 8.8e-14 um against 3.56 um at 1024 steps, status 0)
        whose = (f", the gear's harmonics: {gear}" if gear == top else
                 f", scene.excitation.harmonics: {fitted}" if fitted == top else "")
        fewest = (f"at most {spp // STEPS_PER_HARMONIC} ({STEPS_PER_HARMONIC} steps per period"
                  f" of the highest harmonic: solver.steps_per_period is {spp})")
        problems.append(_at_later_written(study, text, StudyError(
            "<study>", "solver.steps_per_period", spp, (
                f"at least {math.ceil(STEPS_PER_HARMONIC * top)} ({STEPS_PER_HARMONIC} steps per"
                f" period of the highest excitation harmonic, mesh order {top:g}{whose}; fewer"
                " cannot follow its forcing)")),
            [(f, n, fewest) for f, n in (("scene.harmonics", gear),
                                         ("scene.excitation.harmonics", fitted)) if n == top]))
    sps = None if refused else plan.samples_per_period()  # (options refused: their defaults
    if sps and spp % sps:  # are no guide to the samples the study asks for)
        problems.append(_at_later_written(study, text, StudyError(
            "<study>", "solver.steps_per_period", spp,
            f"a multiple of {sps} (the samples per period the outputs need)"),
            [(f"outputs.{o}.samples_per_period", sps, (f"a divisor of solver.steps_per_period"
              f" ({spp}): the samples are taken from the steps")) for o in plan.outputs
             if getattr(plan.options.get(o), "samples_per_period", None) == sps]))
    if problems:  # one line per field (record_periods was said by the spectrum and the plan)
        said = {}
        for p in (p for e in problems for p in e.problems):
            said.setdefault(p[1], p)
        raise StudyError.many("<study>", list(said.values()))
    return plan


def _at_later_written(study: Study, text: str, err: StudyError,
                      others: list[tuple[str, Any, str]]) -> StudyError:
    """``err``, a problem between its field and each of ``others`` (``(field, value, message)``
    saying it at that field), said at the one of them the study file writes last (the README's
    rule: a problem between two fields is said at the later written of the two); ``err`` itself
    where the file writes none of the others later, or there is no file. It said "solver.
    steps_per_period: 64 -- a multiple of 48" at the solver's line with the spectrum's
    ``samples_per_period: 48`` written below it (an outside tester's finding)."""
    if not text or not others:
        return err
    raw = load_yaml(text, "<study>")

    def written_line(field_: str) -> int:
        where = _field_in_file(study, raw, field_)
        return (line_of(raw, where) or 0) if written_at(raw, where) is not None else 0

    line, at = written_line(err.field), None
    for other in others:
        if written_line(other[0]) > line:
            line, at = written_line(other[0]), other
    return err if at is None else StudyError("<study>", *at)


def _lanes(plan: Plan, lane0: int, lane1: int, guard: bool = False, transient: bool = False
           ) -> tuple[dict[str, np.ndarray], np.ndarray | None, np.ndarray | None]:
    """Swept values of lanes ``[lane0, lane1)`` (C order over ``plan.lane_dims``), with
    ``guard`` the step guard's verdict per lane looked up in its table (``_guard_table``;
    ``None`` when there is none: then ``_integrate`` checks the lanes itself), and with
    ``transient`` the residual ``transient_left`` per lane looked up in its table
    (``_transient_table``; ``None`` when there is none: then it is computed per case).
    """
    dims = plan.lane_dims
    table = _guard_table(plan) if guard else None
    left = _transient_table(plan) if transient else None
    pos = table[0] if table is not None else left[0] if left is not None else None
    values, flat = lane_values([plan.grids[d] for d in dims], lane0, lane1, pos)
    return (dict(zip(dims, values, strict=True)), table[2][flat] if table is not None else None,
            left[2][flat] if left is not None else None)


def _lane_params(plan: Plan, lane0: int, lane1: int) -> dict[str, np.ndarray]:
    """Swept values of lanes ``[lane0, lane1)`` (C order over ``plan.lane_dims``)."""
    return _lanes(plan, lane0, lane1)[0]


STATUS_SKIPPED = 3


_GUARD_MARGIN = 2e-3
"""Half-width of the bracket about the tabulated limit (``_stable_steps``) within which the step
guard solves a case's limit exactly (``analysis.stability.frozen_step_ok``): the table's linear
interpolation is within 1e-4 of it. The bracket decides nothing itself: a step 0.2 % within
the polynomial's limit was flagged by the guard (and validate) and passed by advise."""


@lru_cache(maxsize=4)
def _hw_table(method: str) -> tuple[np.ndarray, np.ndarray, float]:
    """(zeta grid, largest stable h w_n on it, largest stable h|lambda| on the negative real
    axis) of ``method``, solved once from its stability polynomial and kept on disk beside the
    Numba cache (``files.cache_folder``), keyed by the source of the solver and the polynomial: about
    0.4 s of solving that every run of a guarded study would otherwise pay at start-up."""
    key = hashlib.sha256(repr((
        inspect.getsource(_solve_hw_table), inspect.getsource(step_limit_hw),
        inspect.getsource(ray_limit), stability_polynomial(method))).encode()).hexdigest()[:16]
    path = cache_folder(__file__) / f"hw_table.{method}.{key}.npz"
    try:
        with np.load(path) as f:
            return f["zeta"], f["hw"], float(f["real"])
    except (OSError, KeyError, ValueError):
        pass
    zeta, hw, real = _solve_hw_table(method)
    try:  # a concurrent reader sees the whole file or none
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write(path, lambda fh: np.savez(fh, zeta=zeta, hw=hw, real=real), durable=False)
    except OSError:  # a read-only installation: solve it in every process
        pass
    return zeta, hw, real


def _solve_hw_table(method: str) -> tuple[np.ndarray, np.ndarray, float]:
    """``_hw_table`` solved from the stability polynomial."""
    # The limit has square-root behaviour at zeta -> 0 (RK5) and zeta -> 1+ (the fast over-damped
    # pole), and the pole's angle arccos(-zeta) has it at zeta -> 1-: below 1 a cosine grid
    # (quadratic at both ends), above 1 geometric in zeta - 1 (steps of 3.8 %).
    u = np.linspace(0.0, 1.0, 1001)
    zeta = np.unique(np.concatenate([0.5 * (1.0 - np.cos(np.pi * u)),
                                     1.0 + np.geomspace(1e-12, 1e4, 1000)]))
    # In slices: the exact solver's work arrays grow with the number of zeta values at once.
    hw = np.concatenate([np.asarray(step_limit_hw(method, zeta[i:i + 500]), float)
                         for i in range(0, len(zeta), 500)])
    return zeta, hw, float(ray_limit(method, np.pi))


def _stable_steps(method: str, k_over_m: np.ndarray, c_over_m: np.ndarray,
                  margin: float = -_GUARD_MARGIN) -> np.ndarray:
    """The largest stable step h* [s] per case from the table, (1 + ``margin``) times its
    interpolation: a lower bound of ``analysis.stability.max_stable_step`` (the default, 0.2 %
    below), an upper bound with ``+_GUARD_MARGIN`` (tested against the exact limit); the step
    guard judges the steps between the two exactly (``_frozen_ok``).

    h* = (h w_n)*(zeta) / w_n with (h w_n)* tabulated once per method on a zeta grid that
    resolves its square-root ends and interpolated linearly.
    Vectorised: a Mathieu chart has as many distinct zeta as cases.
    """
    zeta_grid, hw_grid, real_lim = _hw_table(method)
    k, c = np.broadcast_arrays(np.asarray(k_over_m, float), np.asarray(c_over_m, float))
    osc = k > 0
    wn = np.sqrt(np.where(osc, k, 1.0))
    zeta = np.clip(np.where(osc, c / (2.0 * wn), 0.0), 0.0, zeta_grid[-1])
    # Linear interpolation on this grid is second-order accurate (error < 1e-4 relative):
    # 0.2 % on either side brackets the polynomial's limit.
    hw = (1.0 + margin) * np.interp(zeta, zeta_grid, hw_grid)
    # k <= 0: real poles -c/2 +- sqrt(c^2/4 - k); only the negative one can limit the step.
    neg = 0.5 * c + np.sqrt(np.maximum(0.25 * c * c - k, 0.0))
    with np.errstate(divide="ignore"):
        return np.where(osc, hw / wn, np.where(neg > 0, real_lim / neg, np.inf))


def _step_ok(plan: Plan, params: dict[str, np.ndarray], n: int) -> np.ndarray:
    """The guard rail: is the study's step within the method's stability limit, per case?

    Frozen-coefficient estimate at the largest stiffness of the cycle, from the method's
    stability polynomial (the rule of ``gearsweep.analysis.stability.check_step``: steps per
    period >= T / h*).
    """
    if plan.gear_load_swept and n:  # each case at its own load's k(t): the first load's k(t)
        torques = plan.case_torques(params)  # judged every load, so a case's verdict hung on
        ok = np.empty(n, bool)  # the order of the others (100 N m at 1080 rpm, 16 steps: beyond
        for load in np.unique(torques):  # alone, within after 12.5 N m)
            idx = np.flatnonzero(torques == load)
            sub = {k: np.asarray(v)[idx] for k, v in params.items()}
            ok[idx] = _model_step_ok(plan, plan.model_for_load(float(load)), sub, len(idx))
        return ok
    return _model_step_ok(plan, plan.model, params, n)


def _model_step_ok(plan: Plan, model, params: dict[str, np.ndarray], n: int) -> np.ndarray:
    """``_step_ok`` of cases that share the model ``model``: the frozen-coefficient rule, and
    where the step guard checks it (``analysis.stability.needs_map_check``) the map's
    monodromy (``_map_multipliers``)."""
    a, b, g, harm, kmax, cm, period = hill_parameters(model, params, n)
    ok = _frozen_ok(plan, kmax, cm, period, n)
    if isinstance(model, MeshModel) and model.stiffness_harmonics and hill_cycle(model)[0] == 0:
        return ok & ~_unanalysed(plan, model, params, n)
    if not np.any(b):  # constant stiffness: nothing more to check, at no cost
        return ok
    beyond, _ = _map_multipliers(plan, model, a, b, g, harm, ok)
    return ok & ~beyond


def _unanalysed(plan: Plan, model: MeshModel, params: dict[str, np.ndarray], n: int) -> np.ndarray:
    """The cases whose map the step guard would check (``needs_map_check``'s rule with the
    several-harmonics tongue damping r / 4) but cannot: k(t)'s orders have no common period of at
    most ``HILL_CYCLE_MAX`` mesh periods (``model.hill_cycle``). They count as beyond the step
    limit, unchecked, never as passed; the warning says why (``plan.memo["unanalysed"]``)."""
    k0, m, c = (_case(params, name, getattr(model, name), n)
                for name in ("stiffness", "mass", "damping"))
    r = sum(abs(h.amplitude) for h in model.stiffness_harmonics) / k0
    zeta = np.abs(c) / (2.0 * np.sqrt(k0 * m))
    need = (r > STRONG_VARIATION) | (plan.study.solver.steps_per_period < COARSE_STEPS) | ~(
        zeta > TONGUE_MARGIN * r / 4.0)
    if need.any():
        plan.memo["unanalysed"] = True
    return need


def _frozen_ok(plan: Plan, kmax, cm, period, n: int) -> np.ndarray:
    """The frozen-coefficient rule at the largest stiffness, T / steps per period <= h*
    (``analysis.stability.frozen_step_ok``, the rule ``gearsweep advise`` applies too), the
    table's bracket of h* (``_stable_steps``) sparing the exact solution outside it."""
    s = plan.study.solver
    bracket = (_stable_steps(s.method, kmax, cm), _stable_steps(s.method, kmax, cm, _GUARD_MARGIN))
    h = np.asarray(period, float) / s.steps_per_period
    return np.broadcast_to(frozen_step_ok(s.method, h, kmax, cm, bracket=bracket), (n,))


def _map_multipliers(plan: Plan, model, a, b, g, harm, ok) -> tuple[np.ndarray, np.ndarray]:
    """(beyond, the map's largest |mu| per mesh period) per case: ``analysis.stability.
    map_step_check`` at the study's method and steps for the cases that pass the frozen rule
    (``ok``) where ``analysis.stability.needs_map_check`` asks for it (False and NaN elsewhere),
    over one period of the Hill equation (``model.hill_cycle``: the cycle of fractional stiffness
    orders; the multiplier is taken per mesh period), with the resonance test where the scene is
    forced (``forced_scene``). Each distinct (alpha, beta, gamma) of a model is computed once per
    study (``plan.memo``): a continued sweep asks again at every speed of every chunk."""
    n = np.size(a)
    beyond, disc = np.zeros(n, bool), np.full(n, np.nan)
    a, b, g, ok = (np.broadcast_to(np.asarray(x), (n,)) for x in (a, b, g, ok))
    s = plan.study.solver
    cycle, q = hill_cycle(model)
    spp = s.steps_per_period * max(cycle, 1)
    strong = ok & np.isfinite(a) & needs_map_check(a, b, g, harm, spp)
    if not strong.any():
        return beyond, disc
    forced = forced_scene(plan)
    idx = np.flatnonzero(strong)
    # Rows (alpha, beta, gamma) as 24-byte keys: one sort, no Python loop over cases (a dict of
    # tuples took 4 s of 1e6 combinations, against 0.13 s of the frozen rule).
    rows = np.ascontiguousarray(np.stack([a[idx], b[idx], g[idx]], axis=1), dtype=float)
    keys = rows.view(np.dtype((np.void, 24))).ravel()
    uniq, inverse = np.unique(keys, return_inverse=True)
    memo = plan.memo.setdefault("map_multipliers", {})
    name = (id(model), repr(harm), s.method, spp, forced, q)
    known, kb, kd = memo.get(name, (uniq[:0], np.zeros(0, bool), np.zeros(0)))
    pos = np.minimum(np.searchsorted(known, uniq), max(known.size - 1, 0))
    have = (known.size > 0) & (known[pos] == uniq) if known.size else np.zeros(uniq.size, bool)
    if not have.all():
        t = uniq[~have].view(np.float64).reshape(-1, 3)
        with np.errstate(over="ignore", invalid="ignore"):
            f, d = map_step_check(t[:, 0], t[:, 1], t[:, 2], spp, method=s.method,
                                  harmonics=harm, forced=forced, cycles=q)
            d = d ** (1.0 / cycle) if cycle > 1 else d
        known, kb, kd = (np.concatenate(x) for x in ((known, uniq[~have]), (kb, f), (kd, d)))
        order = np.argsort(known, kind="stable")
        known, kb, kd = known[order], kb[order], kd[order]
        memo[name] = (known, kb, kd)
        pos = np.searchsorted(known, uniq)
    inverse = np.ravel(inverse)
    beyond[idx] = kb[pos][inverse]
    disc[idx] = kd[pos][inverse]
    if np.any(beyond & ~(disc > 1 + UNSTABLE_TOL)):  # flagged by the resonance test alone:
        plan.memo["resonance_flagged"] = True  # the warning says so (``step_limit_text``)
    return beyond, disc


GUARD_PARAMS = ("alpha", "beta", "gamma", "speed", "mass", "stiffness", "damping")
"""The swept parameters ``_step_ok`` depends on (those ``hill_parameters`` reads for its
kmax/m, c/m and period)."""


def _guard_dims(plan: Plan) -> tuple[str, ...]:
    """The swept dims ``_step_ok`` depends on: ``GUARD_PARAMS``, and the load of a gear scene
    that sweeps it (k(t) is the pair's at each load)."""
    return GUARD_PARAMS + (("torque", "mean_force") if plan.gear_load_swept else ())


_GUARD_TABLE_MAX = 1 << 20
"""Largest grid over the guard's dims that is solved once per study (else: per chunk)."""


def _swept_grid(plan: Plan, names: tuple[str, ...]) -> tuple[dict[str, np.ndarray], int] | None:
    """Every combination of the swept values of ``names`` (flat arrays by dim), and how many;
    ``None`` when there are more than ``_GUARD_TABLE_MAX``."""
    dims = [d for d in plan.dims if d in names]
    m = math.prod(len(plan.grids[d]) for d in dims)
    if m > _GUARD_TABLE_MAX:
        return None
    grid = np.meshgrid(*[plan.grids[d] for d in dims], indexing="ij")  # NumPy: validate compiles
    return {d: g.ravel() for d, g in zip(dims, grid, strict=True)}, m  # nothing


def cases_beyond_step_limit(plan: Plan) -> int | None:
    """How many cases of ``plan`` the step guard will find beyond the method's stability limit
    (``_step_ok``, solved on the grid of the swept dims it depends on, speed included, before
    anything runs: ``gearsweep validate`` says so); ``None`` when that grid is larger than
    ``_GUARD_TABLE_MAX``."""
    swept = _swept_grid(plan, _guard_dims(plan))
    if swept is None:
        return None
    params, m = swept
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        ok = np.asarray(_step_ok(plan, params, m))
    return int((~ok).sum()) * (plan.n_cases // m)  # each grid point: the other dims' cases


def frozen_map_check(plan: Plan) -> tuple[float, bool, bool] | None:
    """The step guard's check of the fixed-step map (``analysis.stability.map_step_check``, at
    the study's method and steps over one period of the Hill equation, without the resonance
    test) at the cases of ``plan`` that fail the frozen-coefficient rule (``_frozen_ok``, on the
    grid of the swept dims it depends on): (the largest |mu| per mesh period among them, whether
    one's map diverges (|mu| > 1 + tol over the period), whether one diverges where the
    equation does not). ``None`` where no case fails the rule, none can be checked (orders
    with no short common period) or the grid is larger than ``_GUARD_TABLE_MAX``. The frozen
    rule takes the stiffest instant of the mesh cycle as if it lasted: conservative where k(t)
    varies (docs/stability.md); ``gearsweep advise`` says "diverges" only where the map does."""
    swept = _swept_grid(plan, _guard_dims(plan))
    if swept is None:
        return None
    params, n = swept
    if plan.gear_load_swept and n:
        torques = plan.case_torques(params)
        groups = [(plan.model_for_load(float(t)), np.flatnonzero(torques == t))
                  for t in np.unique(torques)]
    else:
        groups = [(plan.model, np.arange(n))]
    s = plan.study.solver
    mu, diverges, integrator = [], False, False
    for model, idx in groups:
        sub = {k: np.asarray(v)[idx] for k, v in params.items()}
        a, b, g, harm, kmax, cm, period = hill_parameters(model, sub, idx.size)
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            bad = ~_frozen_ok(plan, kmax, cm, period, idx.size)
            a, b, g = (np.broadcast_to(np.asarray(x, float), (idx.size,))[bad] for x in (a, b, g))
            cycle = hill_cycle(model)[0]
            if not a.size or cycle == 0 or not np.all(np.isfinite(a)):
                continue
            beyond, disc = map_step_check(a, b, g, s.steps_per_period * cycle, method=s.method,
                                          harmonics=harm)
        diverges |= bool(np.any(disc > 1.0 + UNSTABLE_TOL))
        integrator |= bool(np.any(beyond))
        mu.append(float(np.max(disc)) ** (1.0 / cycle))
    return (max(mu), diverges, integrator) if mu else None


def resonance_steps(plan: Plan, start: int, target: float, multiple: int = 8,
                    most: int = 4096) -> tuple[int, float, float, float] | None:
    """The fewest steps per mesh period, from ``start`` on in ``multiple``s, from which up to twice
    as many the fixed-step map's resonant response (``analysis.stability.resonance_error``) is
    within ``target`` at every case of ``plan`` the step guard checks the map of (on the grid of the
    swept dims it depends on; ``most`` at most), with that error at ``start`` and at the steps
    found and the speed where it was largest at ``start`` [rpm] (the error returned for the steps found is the
    largest over that run); ``None`` where the scene is not
    forced, no case is checked or the grid is larger than ``_GUARD_TABLE_MAX``. The advisor's
    error model does not see this amplification (docs/precision.md)."""
    swept = _swept_grid(plan, GUARD_PARAMS)
    if swept is None or not forced_scene(plan) or "speed" not in swept[0]:
        return None
    params, m = swept
    cycle, q = hill_cycle(plan.model)
    a, b, g, harm, *_ = hill_parameters(plan.model, params, m)
    a, b, g = (np.broadcast_to(np.asarray(x, float), (m,)) for x in (a, b, g))
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        pick = np.isfinite(a) & np.asarray(b != 0) & needs_map_check(
            a, b, g, harm, start * max(cycle, 1))
        if not pick.any():
            return None
        rows = np.unique(np.stack([a[pick], b[pick], g[pick], params["speed"][pick]], 1), axis=0)
        eq = floquet(rows[:, 0], rows[:, 1], rows[:, 2], method="rk5", rtol=1e-10,
                     tol=UNSTABLE_TOL, harmonics=harm)
        rows, M_eq = rows[~eq.unstable], eq.monodromy.reshape(-1, 2, 2)[~eq.unstable]
        if not rows.size:
            return None

        def error(S: int) -> np.ndarray:
            M = monodromy(rows[:, 0], rows[:, 1], rows[:, 2], S * max(cycle, 1),
                          method=plan.study.solver.method, harmonics=harm)
            e = resonance_error(M, M_eq, q)
            return np.where(largest_multiplier(M) > 1 + UNSTABLE_TOL, np.inf, e)

        # The error changes sign with the step (the whine scene of docs/stability.md: 2e-3 at
        # 128 steps, 3e-5 at 160, 1.9e-4 at 192, then falling as about S^-4.6): the steps found
        # are the first of a run that stays within the target up to twice as many.
        first = error(start)
        S, e = start, np.max(first)
        run, worst = (start, e) if e <= target else (None, 0.0)
        while (run is None or S < 2 * run) and S < most:
            S = (S // multiple + 1) * multiple
            e = float(np.max(error(S)))
            if e > target:
                run, worst = None, 0.0
            elif run is None:
                run, worst = S, e
            else:
                worst = max(worst, e)
    steps = run if run is not None else S
    return steps, float(np.max(first)), worst if run is not None else e, float(
        rows[int(np.argmax(first)), 3])


def transient_left(plan: Plan, params: dict[str, np.ndarray], n: int) -> tuple[np.ndarray, ...]:
    """Per case of ``params``: (the share of the start's free vibration the transient leaves,
    the decay per mesh period it was judged by, whether the map's multiplier set it, that
    multiplier or NaN). The residual is 0 where it cannot be judged (undamped, a Mathieu chart).

    A case's free vibration decays per mesh period by exp(Re(lambda) T), lambda the slower pole
    of m s^2 + c s + k0 (``analysis.stability.frozen_poles``): exp(-c / (2 m) T) below critical
    damping, exp(-omega_n (zeta - sqrt(zeta^2 - 1)) T) above it (c / 2m there said nothing was
    left where zeta = 20 left 0.0065 after 12 periods); or by the largest |mu| of the fixed-step
    map at the study's method and step when that is larger: in closed form where the stiffness
    is constant (``analysis.stability.frozen_map_multiplier``, |R(h lambda)| at the poles per
    step: RK5 at 8 steps per period, zeta 0.02, decays by 0.921 a period where damping says
    0.73, and 50 transient periods left 1.6 %, not 1.6e-7: an outside check), and where the step
    guard computes the map's multiplier (``needs_map_check``) where it varies:
    a parametric mode can decay far slower than damping says (an outside check: mu = 0.979
    against exp(-c T / 2m) = 0.62; 200 transient periods left 1.4 %, status 0 with the
    statistics 1 % off). Cases whose map diverges are the step guard's; undamped cases, whose
    free vibration the equation does not damp at all (the map's decay there is the integrator's:
    RK5 at 200 steps, 1 - 1.1e-5 a period), are not judged. Where this residual is above
    ``solver.settle_tolerance`` a case cannot have settled, whatever the record's halves say:
    its status is 2 (``chunk._outputs``), and ``gearsweep validate`` says so beforehand
    (``transient_residual``)."""
    if isinstance(plan.model, MathieuModel) or not n:
        z = np.zeros(n)
        return z, z, np.zeros(n, bool), np.full(n, np.nan)
    if plan.gear_load_swept:  # each case at its own load's k(t) (as ``_step_ok``)
        torques = plan.case_torques(params)
        parts = [np.zeros(n), np.zeros(n), np.zeros(n, bool), np.full(n, np.nan)]
        for load in np.unique(torques):
            idx = np.flatnonzero(torques == load)
            sub = {k: np.asarray(v)[idx] for k, v in params.items()}
            for whole, part in zip(parts, _model_transient_left(
                    plan, plan.model_for_load(float(load)), sub, len(idx)), strict=True):
                whole[idx] = part
        return tuple(parts)
    return _model_transient_left(plan, plan.model, params, n)


def _model_transient_left(plan: Plan, model, params: dict[str, np.ndarray],
                          n: int) -> tuple[np.ndarray, ...]:
    """``transient_left`` of cases that share the model ``model``."""
    a, b, g, harm, kmax, cm, period = hill_parameters(model, params, n)
    cm, period = np.broadcast_to(cm, (n,)), np.broadcast_to(period, (n,))
    k_over_m = (_case(params, "stiffness", model.stiffness, n)
                / _case(params, "mass", model.mass, n))
    # The equation's decay per mesh period at the mean stiffness, by its slower pole: c / (2 m) T
    # below critical damping, omega_n (zeta - sqrt(zeta^2 - 1)) T above it (c / 2m overstated it
    # there: at zeta = 20 the slow pole left 0.0065 after 12 periods where it gave 0).
    decay = np.where(cm > 0, np.maximum(-frozen_poles(k_over_m, cm)[0].real * period, 0.0), 0.0)
    by_map, disc = np.zeros(n, bool), np.full(n, np.nan)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        if not model.stiffness_harmonics:
            # Constant stiffness: the fixed-step map's multiplier in closed form, |R(h lambda)| at
            # the poles, per period (RK5 at 8 steps, zeta 0.02: 0.921 against exp(-c T / 2m) 0.73)
            spp = plan.study.solver.steps_per_period
            disc = np.asarray(frozen_map_multiplier(plan.study.solver.method, k_over_m, cm,
                                                    period / spp, spp), float)
        elif np.any(b):
            ok = _frozen_ok(plan, kmax, cm, period, n)
            _, disc = _map_multipliers(plan, model, a, b, g, harm, ok)
        slow = np.isfinite(disc) & (disc > 0) & (disc < 1)
        mu_decay = -np.log(np.where(slow, disc, 1.0))
        # Undamped, the equation's multipliers have |mu1 mu2| = det M = 1: a map that decays
        # there decays by the integrator's own damping, not the equation's (that stays 0).
        by_map = slow & (mu_decay < decay)
        decay = np.where(by_map, mu_decay, decay)
    residual = np.where(decay > 0, np.exp(-decay * plan.study.solver.transient_periods), 0.0)
    return residual, decay, by_map, disc


def transient_residual(plan: Plan) -> tuple[float, float, int, float | None] | None:
    """The largest share of a free vibration the transient leaves among the cases of ``plan``
    (``transient_left``, on the grid of the swept dims it depends on), the speed where it is
    largest [rpm], the transient periods that bring it to ``solver.settle_tolerance``, and the
    map's multiplier where it decided (else ``None``: damping did); ``None`` when it is within
    that tolerance, for a Mathieu chart (a stability study), or when the grid is larger than
    ``_GUARD_TABLE_MAX``. The ``status`` check compares the halves of the record and misses a
    beat slower than the record (an outside check, 27 Nov 2026: zeta = 0.001, 300 transient and
    20 recorded periods, status 0 with p_pp 10-17 % off, where this estimate gives 15 %): the
    run flags those cases not settled (status 2) and ``gearsweep validate`` notes them first."""
    swept = None if isinstance(plan.model, MathieuModel) else _swept_grid(plan, _guard_dims(plan))
    if swept is None or "speed" not in swept[0]:
        return None
    params, m = swept
    residual, decay, by_map, disc = transient_left(plan, params, m)
    known = decay > 0
    if not known.any():
        return None
    worst = int(np.argmin(np.where(known, decay, np.inf)))
    tol = plan.study.solver.settle_tolerance
    if residual[worst] <= tol:
        return None
    mu = float(disc[worst]) if by_map[worst] else None
    return (float(residual[worst]), float(params["speed"][worst]),
            math.ceil(math.log(1 / tol) / decay[worst]), mu)


def _guard_table(plan: Plan) -> tuple[list[int], tuple[int, ...], np.ndarray] | None:
    """The step guard solved once on the grid of the swept dims it depends on.

    Returns (positions of those dims in ``lane_dims``, their grid shape, flat ``_step_ok`` over
    that grid), or ``None`` when the grid is too large to keep (a Mathieu chart sweeping alpha,
    beta and gamma finely): then each chunk is checked on its own. A study sweeping torque and
    backlash besides speed and damping checks speeds x dampings once instead of every case.
    """
    if "guard" not in plan.memo:
        grid = _guard_grid(plan)
        table = None
        if grid is not None:
            pos, shape, params, m = grid
            with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
                table = (pos, shape, np.array(_step_ok(plan, params, m)))
        plan.memo["guard"] = table
    return plan.memo["guard"]


def _guard_grid(plan: Plan) -> tuple[list[int], tuple[int, ...], dict[str, np.ndarray], int] | None:
    """(positions in ``lane_dims`` of the swept dims the step guard and ``transient_left``
    depend on, their grid shape, every combination of their values (flat, C order), how many);
    ``None`` when there are more than ``_GUARD_TABLE_MAX``."""
    pos = [i for i, d in enumerate(plan.lane_dims) if d in _guard_dims(plan)]
    shape = tuple(len(plan.grids[plan.lane_dims[i]]) for i in pos)
    m = int(np.prod(shape, dtype=np.int64))
    if m > _GUARD_TABLE_MAX:
        return None
    dims = [plan.lane_dims[i] for i in pos]
    values, _ = lane_values([plan.grids[d] for d in dims], 0, m)
    return pos, shape, dict(zip(dims, values, strict=True)), m


def _transient_table(plan: Plan) -> tuple[list[int], tuple[int, ...], np.ndarray] | None:
    """``transient_left``'s residual solved once on the grid of the swept dims it depends on
    (those of the step guard: ``_guard_grid``), as (positions, shape, flat residual), where that
    grid has at most a quarter of the study's cases (else ``None``: per case). Per case it cost
    a 1e6-case study 0.13 s of the writer thread's CPU beside the kernel (the fixed-step map's
    multiplier for constant stiffness, 27 Nov 2026), where its 100 speeds x 10 dampings need
    1,000 evaluations. Each value is the same elementwise arithmetic as per case."""
    if "transient" not in plan.memo:
        grid = _guard_grid(plan)
        table = None
        if grid is not None and 4 * grid[3] <= plan.n_cases:
            pos, shape, params, m = grid
            with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
                table = (pos, shape, np.array(transient_left(plan, params, m)[0], float))
        plan.memo["transient"] = table
    return plan.memo["transient"]



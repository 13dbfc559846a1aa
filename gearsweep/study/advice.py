"""The step advisor for a whole study: ``analysis.advise`` given a plan's numbers (its softest
mass, stiffest load, least damping, every swept case's stability limit, the multiple its outputs
need), then the checks of the fixed-step map the frozen-coefficient rule does not see (a
parametric resonance of k(t), the step guard's map check) and the reach of a study's
``solver.steps_per_period``.

``study_advice`` is what ``gearsweep advise`` prints and ``gearsweep.advise`` returns;
``plan_advice`` is what ``gearsweep validate`` reads the written steps' expected error from.
"""

from __future__ import annotations

import dataclasses
import math
import numbers

import numpy as np

from gearsweep.analysis.advise import SAFETY, Advice, advise
from gearsweep.analysis.stability import RESONANCE_TOL
from gearsweep.errors import StudyError
from gearsweep.model import MeshModel
from gearsweep.study.outputs import OUTPUTS, options_of
from gearsweep.study.plan import (
    cases_beyond_step_limit,
    frozen_map_check,
    make_plan,
    resonance_steps,
)
from gearsweep.study.schema import MAX_STEPS_PER_PERIOD, line_of, load_yaml

DEFAULT_TARGET = 1e-4
"""The trajectory error relative to the amplitude that the advice aims at unless told (``gearsweep
advise --target``, ``gearsweep.advise(target=...)``)."""


def check_target(target: object, name: str, field: str = "target") -> float:
    """``target`` as a float, if a relative error between 0 and 1 (both excluded); else one
    ``StudyError`` naming the study ``name`` and ``field`` (the CLI's ``--target``, the API's
    ``target``)."""
    if (isinstance(target, bool) or not isinstance(target, numbers.Real)
            or not (math.isfinite(target) and 0.0 < target < 1.0)):
        raise StudyError(name, field, target, "a relative error between 0 and 1 (e.g. 1e-4)")
    return float(target)


def study_advice(study, text: str, name: str, target: float = DEFAULT_TARGET, *,
                 field: str = "target") -> Advice:
    """The advice on a validated dynamic study of a gear scene (``text``: its YAML; ``name``: the
    name its problems are reported under, a path or ``<dict>``): the steps per mesh period for
    ``target``, their cost, the steps as written and every warning, ``gearsweep advise``'s
    (``str(advice)``: its text, headed by ``name``).

    Raises
    ------
    StudyError
        For a ``target`` outside (0, 1) (named ``field``), a mesh or analysis study (nothing is
        integrated) and a Mathieu scene (no accuracy model), at the field's line of ``text``.
    """
    target = check_target(target, name, field)
    if getattr(study, "type", None) in ("mesh", "analysis"):  # (at the field's line: had none)
        raise StudyError(name, "type", study.type,
                         "a dynamic study (whine, rattle, full): nothing is integrated here",
                         line_of(load_yaml(text, name), "type"))
    plan = make_plan(study, text, name)
    if not isinstance(plan.model, MeshModel):
        raise StudyError(name, "scene.kind", study.scene.kind,
                         "a gear scene (whine, rattle, full): the Mathieu scene has no accuracy"
                         " model", line_of(load_yaml(text, name), "scene.kind"))
    a = plan_advice(plan, target, map_check=True)
    a = resonance_advice(plan, a)
    for n, how in ((a.steps_per_period, ""), (a.kink_steps_per_period, " kink-aware")):
        if n is not None and n > MAX_STEPS_PER_PERIOD:  # advice a study cannot take
            a.warnings.append(f"the{how} target needs {n} steps per mesh period, beyond the"
                              f" {MAX_STEPS_PER_PERIOD} a study takes (solver.steps_per_period):"
                              " out of reach here; ask for a larger target")
    a.warnings.extend(map_check_warnings(study, text, name, a))
    scene = f"{study.scene.kind} scene" + (" with backlash" if plan.has_backlash else "")
    return dataclasses.replace(a, scene=scene, study_name=name)


def steps_multiple(plan) -> int:
    """What the advised steps per period must be a multiple of for this study to take it: 8, and
    each samples_per_period an output fixes (a spectrum's): the advice of 536 steps for a study
    with a 32-sample spectrum was refused by validate ('a multiple of 32')."""
    multiple = 8
    for name in plan.outputs:
        out = OUTPUTS[name]
        if getattr(out, "options_model", None) is not None:
            sps = getattr(options_of(plan, out), "samples_per_period", None)
            if sps:
                multiple = math.lcm(multiple, int(sps))
    return multiple


def plan_advice(plan, target: float, free_vibration: bool = True,
                map_check: bool = False) -> Advice:
    """``advise`` for a gear scene's plan: its lowest mass and damping, its stiffest load and
    stiffness, its smallest backlash, the steps it has (``Advice.chosen_error``: the expected
    error of those); ``free_vibration``: see ``advise``; ``map_check``: where the steps fail
    the frozen-coefficient rule, check the fixed-step map there as the step guard does
    (``plan.frozen_map_check``), so that the warning says "diverges" only where it does."""
    study = plan.study
    model = plan.model
    s = study.solver
    grids = plan.grids
    if plan.gear_load_swept:
        # k(t) is the pair's at each load: the stiffest sets omega_n (the first listed load's
        # did, so the advice for [12.5 N m, 100 N m] and [100 N m, 12.5 N m] differed)
        loads = plan.case_torques({n: grids[n] for n in ("torque", "mean_force") if n in grids})
        model = max((plan.model_for_load(float(t)) for t in np.unique(loads)),
                    key=lambda m: m.stiffness + sum(abs(h.amplitude) for h in m.stiffness_harmonics))
    k0 = float(np.max(grids["stiffness"])) if "stiffness" in grids else model.stiffness
    mass = float(np.min(grids["mass"])) if "mass" in grids else model.mass
    damping = float(np.min(grids["damping"])) if "damping" in grids else model.damping
    backlash = None
    if plan.has_backlash:
        backlash = float(np.min(grids["backlash"])) if "backlash" in grids else model.backlash
    return advise(mass=mass, k0=k0, damping=damping, speed_rpm=grids["speed"], teeth=model.teeth,
                  stability_cases=stability_cases(plan),
                  k_harmonics=[(h.amplitude, h.order, h.phase) for h in model.stiffness_harmonics],
                  highest_order=max(1.0, model.highest_order),
                  backlash=backlash, method=s.method, kink_aware=s.kink_aware, target=target,
                  steps_per_period=s.steps_per_period,
                  periods=s.transient_periods + s.record_periods,
                  cases_per_speed=plan.n_cases / len(grids["speed"]),  # priced as --estimate
                  free_vibration=free_vibration,
                  multiple=steps_multiple(plan),
                  map_check=frozen_map_check(plan) if map_check else None)


def stability_cases(plan) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(mass, k0 + sum |k_n|, damping) of every combination of the plan's swept mass, stiffness,
    damping and load (each load's k(t)), whose worst the advised step must be stable at, as the
    step guard judges each case: the limit is not monotonic in the damping ratio (RK4: 2.95 at
    zeta 0.1, 2.62 at 0.5), and the smallest damping's, all ``advise`` was given, passed 12 RK4
    steps the guard flagged (an outside tester)."""
    grids = plan.grids
    if plan.gear_load_swept:
        loads = plan.case_torques({n: grids[n] for n in ("torque", "mean_force") if n in grids})
        models = [plan.model_for_load(float(t)) for t in np.unique(loads)]
    else:
        models = [plan.model]
    rows = []
    for model in models:
        swing = sum(abs(h.amplitude) for h in model.stiffness_harmonics)
        m, k, c = np.meshgrid(
            np.unique(grids["mass"]) if "mass" in grids else [model.mass],
            np.unique(grids["stiffness"]) if "stiffness" in grids else [model.stiffness],
            np.unique(grids["damping"]) if "damping" in grids else [model.damping],
            indexing="ij")
        rows.append(np.stack([m.ravel(), k.ravel() + swing, c.ravel()]))
    m, k, c = np.unique(np.concatenate(rows, axis=1), axis=1)
    return m, k, c


def resonance_advice(plan, a: Advice) -> Advice:
    """The advice ``a`` with its steps raised where the fixed-step map misses a parametric
    resonance of k(t) by more than the target allows (``plan.resonance_steps`` at target /
    SAFETY, as the error model aims): near a tongue the forced response is amplified by
    1 / det(I - M), and the error model, fitted away from tongues, does not see the map's error
    there (an outside analyst: 96 steps advised for 1e-4 with 3.7e-5 expected, 2.5e-2 measured)."""
    n = a.steps_per_period
    if n is None or n > MAX_STEPS_PER_PERIOD:
        return a
    found = resonance_steps(plan, n, min(a.target / SAFETY, RESONANCE_TOL),
                            multiple=steps_multiple(plan),
                            most=MAX_STEPS_PER_PERIOD)
    if found is None or found[0] == n:
        return a
    steps, before, after, rpm = found
    hw = a.h_omega_n * n / steps
    warn = (f"near a parametric resonance of k(t) ({rpm:.0f} rpm) the fixed-step map's forced"
            f" response at {n} steps per mesh period is off by {before:.1e} (det(I - M) of the"
            f" map against the equation's converged monodromy; docs/stability.md), which the"
            f" error model does not see: {steps} steps bring it to {after:.1e} (advised above)")
    return dataclasses.replace(
        a, steps_per_period=steps, h_omega_n=hw, expected_error=max(a.expected_error, after),
        msteps=a.msteps * steps / n, warnings=[*a.warnings, warn])


def map_check_warnings(study, text: str, name: str, a: Advice) -> list[str]:
    """What the step guard's map check (the fixed-step map's monodromy where k(t) varies strongly,
    the step is coarse or a parametric tongue is open: ``analysis.stability.needs_map_check``)
    finds at the advised steps, which the advisor's frozen rule does not see: an outside
    analyst's whine scene (k1 = 1050 of k0 = 1073 kN/mm, zeta 0.007, RK5) was told 40 steps were
    stable, where the map diverges up to 55. ``name``: the study's, for the plan's problems."""
    out = []
    for n, what in ((a.steps_per_period, "the advised"),):
        if n is None or n > MAX_STEPS_PER_PERIOD:
            continue
        solver = study.solver.model_copy(update={"steps_per_period": int(n)})
        try:
            beyond = cases_beyond_step_limit(make_plan(study.model_copy(update={"solver": solver}),
                                                       text, name))
        except StudyError:  # (a step count the outputs' samples do not divide: not judged here)
            continue
        if beyond:
            out.append(f"at {what} {n} steps per mesh period the step guard finds {beyond}"
                       " case(s) beyond the method's stability limit: k(t) varies and the"
                       " fixed-step map diverges where the equation does not, which the"
                       " frozen-coefficient limit above does not see (docs/stability.md); take"
                       " more steps (`gearsweep validate` with them says how many cases remain)")
    return out

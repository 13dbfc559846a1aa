"""What a study can ask for (``outputs:`` in the YAML): the extension point of the runner.

An ``Output`` declares the variables it adds (their extra dims and coordinates) and computes them
for a batch of cases from the kernel's ``BatchResult`` (and the cases' parameters). New scenes add
an ``Output`` here (e.g. spectra, Floquet multipliers); the runner, chunking and the Dataset
builder need no change.

``signal_samples_per_period`` > 0 asks the runner to record p at that many samples per mesh period
over the recorded window (``steps_per_period`` must be a multiple of it). The signal exists only
for one chunk of cases at a time: an output reduces it to what it keeps (e.g. a few spectral bins).

An output that takes options (``outputs: [{spectrum: {max_order: 4}}]`` in the YAML) names a
pydantic model in ``options_model``; ``configure`` validates the options against it and the plan
keeps the result in ``plan.options[name]``.
"""

from __future__ import annotations

import contextlib
import contextvars
import math
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
from pydantic import BaseModel, Field, ValidationError, model_validator

from gearsweep.analysis.period import motion_period
from gearsweep.analysis.sensor import pinion_displacement, spectrum_rms
from gearsweep.analysis.spectrum import kept_bins, line_phase, line_spectrum
from gearsweep.analysis.stability import check_step, map_step_limit, needs_map_check
from gearsweep.errors import StudyError
from gearsweep.kernels import BatchResult
from gearsweep.kernels.floquet import (
    UNSTABLE_TOL,
    floquet,
    initial_steps,
    largest_multiplier,
    monodromy,
    monodromy_call,
)
from gearsweep.model import RPM, MeshModel, hill_cycle, hill_parameters, mesh_frequency
from gearsweep.study.quantities import (
    MAX_STEPS_PER_PERIOD,
    Count,
    FieldProblems,
    Flag,
    Real,
    Strict,
)
from gearsweep.units import KINDS, to_display

STATUS_CODES = {
    0: "ok",
    1: "diverged: p became non-finite or exceeded divergence_factor x its static scale, or a"
       " statistic of p overflowed",
    2: "not settled: settle_error above solver.settle_tolerance, or the transient's decay"
       " (damping, or the fixed-step map's largest Floquet multiplier: |mu|^transient_periods)"
       " leaves more than settle_tolerance of the start's free vibration (results kept; a"
       " response that"
       " has died away, p_pp below 1e-9 of its static scale, is settled; driven scenes only: an"
       " undriven one, a Mathieu chart say, decays or grows, see the floquet output)",
    3: "skipped: the step is beyond the method's stability limit for this case",
}
"""The result's ``status`` codes: the one table (the file's ``flag_values``, ``flag_meanings`` and
``codes`` attributes, the reference's table, the estimate's attribute text)."""


def record_periods_needed(cycle: int, multiple: bool = False, model: Any = None) -> str:
    """What a driven scene's ``record_periods`` must be for an excitation cycle of ``cycle`` mesh
    periods: two cycles at least (the settle test compares the extremes of the record's two
    halves, each must hold a whole cycle); with ``multiple`` (a spectrum) also whole cycles.
    With the ``model``, a long cycle names the order that sets it (0.3333 is 3333/10000, a
    cycle of 10,000 periods, where 1/3 is one of 3: an outside tester's finding)."""
    what = f"a multiple of {cycle}, at least {2 * cycle}" if multiple and cycle > 1 \
        else f"at least {2 * cycle}"
    source = model.longest_cycle_order() if cycle > 1 and model is not None and hasattr(
        model, "longest_cycle_order") else None
    why = ""
    if source is not None:
        order, exact = source
        why = f", set by order {order:g} = {exact.numerator}/{exact.denominator}"
        short = exact.limit_denominator(100)
        if short != exact and abs(float(short) - order) <= 1e-3 * order:  # 0.3333 for 1/3
            why += f", write '{short.numerator}/{short.denominator}' if that is meant"
    return (f"{what} for this excitation (its cycle is {cycle} mesh period"
            f"{'s' if cycle != 1 else ''}{why}: the settle test compares the extremes of the"
            " record's two halves, each must hold a whole cycle" + (
                "; a spectrum needs whole cycles)" if multiple else ")"))


def status_attrs() -> dict[str, Any]:
    """The ``status`` variable's CF flag attributes, from ``STATUS_CODES``."""
    return {"flag_values": np.array(sorted(STATUS_CODES), dtype=np.int8),
            "flag_meanings": " ".join(STATUS_CODES[k].split(":")[0].replace(" ", "_")
                                      for k in sorted(STATUS_CODES)),
            "codes": "; ".join(f"{k} {v}" for k, v in STATUS_CODES.items())}

Plan = Any
"""What an output is given: a ``gearsweep.study.plan.Plan`` (its ``model``, ``study``, ``grids``,
``options``). Named, not imported: the plan imports the outputs, so the outputs cannot import it."""


@dataclass(frozen=True)
class VarSpec:
    """A variable an output adds: extra trailing dims with their coordinates, and attributes."""

    extra_dims: tuple[str, ...] = ()
    extra_coords: dict[str, np.ndarray] = field(default_factory=dict)
    dtype: str = "float64"
    attrs: dict = field(default_factory=dict)
    aux_coords: dict[str, tuple[tuple[str, ...], np.ndarray]] = field(default_factory=dict)
    """Non-index coordinates ``name -> (dims, values)`` over the study's dims and the extra dims
    (e.g. ``frequency`` on ``(speed, order)``)."""
    kind: str | None = None
    """Kind of quantity (``gearsweep.units.KINDS``): ``compute`` returns SI values, the runner
    stores them in the kind's display unit (p in um), and ``units`` is that unit."""

    def result_attrs(self) -> dict:
        """The variable's attributes in a result: ``attrs`` with the display unit of ``kind``."""
        return dict(self.attrs, units=KINDS[self.kind].cf) if self.kind else dict(self.attrs)

    def to_result(self, values: np.ndarray) -> np.ndarray:
        """SI values from ``compute`` in the unit the result stores (``result_attrs``)."""
        return to_display(values, self.kind) if self.kind else values


class Output(Protocol):
    name: str
    options_model: type[BaseModel] | None
    """Pydantic model of the output's options (``None`` or absent: it takes none)."""

    def signal_samples_per_period(self, plan: Plan) -> int: ...

    # optional: ``kernel_calls(plan) -> list[dict]``, the ``simulate`` calls of ``compute`` of its
    # own (keyword arguments), so that the estimate knows their compiled specialisations

    def variables(self, plan: Plan) -> dict[str, VarSpec]: ...

    def compute(self, plan: Plan, params: dict[str, np.ndarray],
                result: BatchResult) -> dict[str, np.ndarray]: ...


def options_of(plan: Plan, output: Output) -> BaseModel:
    """The options of ``output`` in the plan's study: the model ``configure`` validated, or its
    defaults where the study gave none."""
    opts = plan.options.get(output.name)
    return opts if isinstance(opts, output.options_model) else output.options_model()


class Stats:
    """Steady-state statistics of p (docs/data-format.md): rms, peak-to-peak, extremes, mean, contact."""

    name = "stats"
    options_model = None

    def signal_samples_per_period(self, plan: Plan) -> int:
        return 0

    def variables(self, plan: Plan) -> dict[str, VarSpec]:
        names = ["p_rms", "p_pp", "p_max", "p_min", "p_mean", "settle_error"]
        if plan.has_backlash:
            names += ["contact_loss_fraction", "backside_contact_fraction", "impacts_per_period"]
        if plan.dimensionless:
            return {n: VarSpec(attrs={"units": "1"}) for n in names}
        specs = {n: VarSpec(kind="displacement" if n.startswith("p_") else None) for n in names}
        if separation_flagged(plan):
            specs["contact_lost"] = VarSpec(dtype="bool")
        if plan.driven:  # where the status rule judges the transient (chunk._outputs fills it)
            specs["transient_left"] = VarSpec()
        return specs

    def compute(self, plan: Plan, params: dict[str, np.ndarray],
                result: BatchResult) -> dict[str, np.ndarray]:
        s = result.stats
        out = {k: s[k] for k in ("p_rms", "p_max", "p_min", "p_mean", "settle_error")}
        out["p_pp"] = s["p_max"] - s["p_min"]
        if plan.has_backlash:
            for k in ("contact_loss_fraction", "backside_contact_fraction", "impacts_per_period"):
                out[k] = s[k]
        if separation_flagged(plan):
            fm = plan.case_mean_forces(params, len(s["p_min"]))
            out["contact_lost"] = loaded_flank_lost(fm, s["p_min"], s["p_max"])
        return out


def loaded_flank_lost(mean_force, p_min, p_max) -> np.ndarray:
    """Did the flank the mean force presses leave contact in the steady state (``contact_lost``)?
    Under F_m > 0 the drive flank, lost where p fell below 0 (p_min < 0); under F_m < 0 the back
    flank, lost where p rose above 0 (p_max > 0). Under F_m = 0 neither flank is pressed: the
    teeth part where p takes both signs (p_min < 0 < p_max), the force passing from one flank to
    the other; a p of one sign keeps one flank in contact. NaN extremes (a diverged case): False."""
    fm = np.asarray(mean_force, float)
    with np.errstate(invalid="ignore"):
        below, above = np.asarray(p_min) < 0.0, np.asarray(p_max) > 0.0
    return np.where(fm > 0, below, np.where(fm < 0, above, below & above))


def separation_flagged(plan: Plan) -> bool:
    """Does the ``stats`` output of ``plan`` mark the cases whose loaded flank leaves contact
    (``contact_lost``, ``loaded_flank_lost``)? A driven scene without backlash: f(p) = p, drive
    flanks in contact while p > 0, back flanks while p < 0; where p crosses 0 against the load
    the linear force k(t) p is the other flanks' at once, a pair with no backlash, where a real
    pair's teeth would separate (a scene with backlash has
    ``contact_loss_fraction``). An outside tester's whine study peaked 34 % above its ``full``
    scene with 0.075 mm of backlash, whose teeth parted 17-24 % of the time there; Fig. 5's
    scene has p < 0 from 1,700 rpm. Not for an undriven scene (the stability studies: a
    homogeneous equation, whose scale and so sign are arbitrary) nor the Mathieu scene."""
    return bool(plan.driven and not plan.has_backlash and not plan.dimensionless)


PHASE_FLOOR = {"float64": 1e-9, "float32": 1e-4}
"""Per ``solver.precision``: a line's phase is NaN where its amplitude is at most this fraction
of the largest sample or line of its case (the ``phase_floor`` attribute of ``spectrum_phase``).
Below it the line is round-off, or in float32 the single precision's own error, and its phase
says nothing. float64: round-off lines are about 1e-13 of the largest (a linear response's
empty orders, tests/test_spectrum_phase.py), 1e-9 leaves four decades. float32 (a GPU): the
empty orders' round-off was 4e-8 of the largest on the CUDA simulator, and a float32 run
differs from float64 by 5e-5 (the ``precision`` attribute's note): 1e-4. Lines above it keep
their phase, small as they are (a transient not yet decayed shows there too: the phase is that
of what was recorded)."""

MAX_SPECTRUM_CELLS = 1 << 24
"""Most lines x speeds of a spectrum output (its ``order`` coordinate and the 2-D ``frequency``
on speed x order): beyond it a study is refused before they are made (``record_periods: 1e8``
took ``gearsweep validate`` 19 s and 6.45 GB before its estimate could refuse it). The
studies here keep at most 2.4e5."""


IMPACT_ALIASING = (
    "where the flanks part (contact loss), the kinks of f(p) put lines at every order, which"
    " alias onto the kept ones: spectrum and force_spectrum may be off by that aliasing of the"
    " impacts (force_spectrum's error"
    " falls only as samples_per_period^-2: 1.8 % of F_m on its mean at 16 samples, 0.04 % at 128,"
    " tests/test_spectrum_impacts.py)")
"""Why a spectrum with backlash samples every step by default, and what validate and run say of
one sampled below them (``Spectrum.aliasing``). Measured on a full scene with backlash, k(t),
STE and a fluctuation (an outside tester's), 5000-12,000 rpm, 1024 steps per mesh period:
force_spectrum's mean off F_m by 1.8e-2 / 4.0e-3 / 2.4e-3 / 4.1e-4 / 2.1e-5 at 16 / 32 / 64 /
128 / 256 samples per period, its order 3 by 4.7e-2 ... 7.9e-5 of scipy DOP853's; spectrum's
mean off p_mean by 1.9e-4 at 16, 4.7e-8 at 128 and round-off at every step
(tests/test_spectrum_impacts.py)."""


class SpectrumOptions(Strict):
    """Options of the ``spectrum`` output (a study model like the others: its validator is
    built when a study first asks for a spectrum; built with the class, it was 4 ms of every
    run's start)."""

    max_order: Real = Field(4.0, gt=0, description="highest mesh order kept [-]")
    samples_per_period: Count | None = Field(
        None, ge=2, le=MAX_STEPS_PER_PERIOD, description="samples of p per mesh period (a divisor"
        " of steps_per_period; default: with backlash all the steps (the kinks of f(p) where the"
        " flanks part have lines at every order); else the smallest divisor >= 4 max_order, >= 4"
        " x the highest"
        " order H of the scene's excitation, a gear's included, and, where k(t) varies or there"
        " is backlash, > r_n + H + max_order, r_n = f_n / f_mesh at the lowest speed: no order up"
        " to r_n + H, where the resonance spreads, folds onto a kept one; all steps where no"
        " divisor is enough; validate warns of a samples_per_period below that)")
    force: Flag = Field(True, description="also the spectrum of the dynamic mesh force"
                        " k(t) f(p) + c p' (variable force_spectrum) [N]")
    pinion: Flag = Field(False, description="also what the sensors of gear 2, the driven gear"
                         " (the paper's pinion: its rig drives the 48-tooth gear 1), see: its"
                         " angular motion at the base circle r2 theta2 per line (pinion_spectrum)"
                         " and its rms (pinion_rms) [um], from the mesh force by Eq. (4); where"
                         " your pinion drives, it is gear 1 and this is the wheel's motion"
                         " (gearsweep.analysis.sensor); needs force and scene.drive")
    phase: Flag = Field(False, description="also the phase of each line, spectrum_phase (and"
                        " force_spectrum_phase with force) [rad] in (-pi, pi]: p ~ sum spectrum"
                        " cos(2 pi order phi + spectrum_phase), phi the mesh phase (0 at t = 0);"
                        f" NaN where the line is at most phase_floor ({PHASE_FLOOR['float64']:g};"
                        f" float32: {PHASE_FLOOR['float32']:g}) of its case's largest or spectrum"
                        " is NaN (docs/data-format.md)")
    dte: Flag = Field(False, description="also the spectrum of the dynamic transmission error"
                      " p + e = r1 theta1 - r2 theta2 (Eq. 5) per line, dte_spectrum [um] (and"
                      " dte_spectrum_phase with phase): what an angle or transmission-error"
                      " measurement sees; p is r1 theta1 - r2 theta2 less the scene's e(t) (with a"
                      " gear pair's k(t), e = STE - F_m/k and p is the mesh deflection), so p alone"
                      " hides whatever e(t) cancels (tip relief); from p's"
                      " lines and e(t)'s harmonics; NaN at order 0, a mean the model leaves out;"
                      " not for the Mathieu scene")

    @model_validator(mode="after")
    def _nyquist(self) -> SpectrumOptions:
        sps = self.samples_per_period
        if sps is not None and self.max_order > sps / 2:  # at max_order's line if written, else
            # at samples_per_period's (were the output's)
            raise FieldProblems([(("max_order", "samples_per_period"), (
                f"max_order {self.max_order:g} is above the Nyquist order samples_per_period / 2"
                f" = {sps / 2:g}"))])
        return self


def resonant_order(plan: Plan) -> tuple[float, float] | None:
    """The natural frequency's mesh order r_n = f_n / f_mesh at the sweep's lowest speed, where
    it is largest, and that speed [rpm]: f_n = sqrt(k0 / m) / 2 pi with the largest k0 and the
    least m of the sweep (a gear sweeping its load: its stiffest load's k0, ``Plan.stiffest_load``,
    found once per plan; each load's plan asks it). ``None`` where the
    steady response has only the excitation's orders (constant stiffness and no backlash: a
    linear time-invariant scene) and for a Mathieu chart."""
    m = plan.model
    if not isinstance(m, MeshModel) or not (m.stiffness_harmonics or plan.has_backlash):
        return None
    g = plan.grids
    k = float(np.max(g["stiffness"])) if "stiffness" in g else m.stiffness
    if plan.gear_load_swept and "stiffness" not in g:
        k = max(k, plan.stiffest_load())
    mass = float(np.min(g["mass"])) if "mass" in g else m.mass
    speed = float(np.min(g["speed"]))
    return math.sqrt(k / mass) / (2.0 * math.pi) / float(mesh_frequency(speed, m.teeth)), speed


class Spectrum:
    """Single-sided amplitude spectrum of p over the whole recorded mesh periods (docs/data-format.md).

    p is sampled ``samples_per_period`` times per mesh period over the ``record_periods`` whole
    periods, so mesh order r falls on bin ``r * record_periods`` exactly: no window, no leakage
    for a periodic steady state. Bins up to ``max_order`` are kept on the ``order`` coordinate
    (``k / record_periods``, exact), with ``frequency`` = order x mesh frequency [Hz] as a 2-D
    auxiliary coordinate on ``(speed, order)``. Memory: the signal of one chunk, then
    cases x kept bins.

    ``force_spectrum`` [N] is the spectrum of the dynamic mesh force ``k(t) f(p) + c p'``:
    ``k(t) f(p)`` is formed from the samples (k(t) is known at every sample), and ``c p'`` is
    added bin by bin as ``i c w_k`` times the spectrum of p (exact for a periodic, band-limited
    p; the Nyquist bin of ``c p'``, whose phase is not observable, is taken as zero).

    With ``phase: true``, ``spectrum_phase`` (and ``force_spectrum_phase``) [rad] give each
    line's phase theta_r in the model's convention (the harmonics of ``gearsweep.model`` are
    ``a cos(2 pi r phi + phase)``, phi the mesh phase, 0 at t = 0): p(phi) ~= sum_r A_r
    cos(2 pi r phi + theta_r), A_r the ``spectrum``. The samples sit after step
    ``n_transient + j * stride + 1`` (``_first_sample``), which the phase is referred back from.
    Order 0: 0 or pi (the sign of the mean). The Nyquist order (kept only where max_order is
    samples_per_period / 2) sees a line only at the samples: its pair is the one line through
    them. NaN where the amplitude is NaN (a case that diverged or was skipped; one that did not
    settle keeps its lines and their phases, as its other results) and where the line is at
    most ``PHASE_FLOOR`` (of the solver's precision) of its case's largest sample or line.
    """

    name = "spectrum"
    options_model = SpectrumOptions

    def _opts(self, plan: Plan) -> SpectrumOptions:
        return options_of(plan, self)

    def signal_samples_per_period(self, plan: Plan) -> int:
        o = self._opts(plan)
        if o.samples_per_period is not None:
            return o.samples_per_period
        return self.samples_needed(plan)[0]

    def samples_needed(self, plan: Plan) -> tuple[int, int, float, tuple[float, float] | None]:
        """The default samples_per_period (the one rule), the least number that the folding
        rule asks (it may not divide steps_per_period, or exceed it), the highest order ``band``
        the response carries with weight, and (r_n, its speed [rpm]) or ``None``.

        * At least 4 samples per period of ``max_order`` and of the excitation's highest order
          H: a gear pair's k(t) (10 harmonics, steps where one pair takes over from two) gives p
          and k(t) f(p) lines far above 3 max_order. At 16 samples (max_order 4) they folded
          back: a 25/41 pair at 500-1500 rpm had its force_spectrum lines 1-3 1.3x-105x too
          large and order 4 of p 39 % off (an engineer new to the tool; tests/test_whine.py).
        * All the steps where there is backlash (``IMPACT_ALIASING``): where the flanks part,
          f(p) has kinks, and their lines fall off only as the square of the order.
        * More than band + max_order, band = r_n + H where k(t) varies or there is backlash
          (``resonant_order``; else band = H), so that no order up to band folds onto a kept
          one (order q folds onto S - q): the steady response of such a scene has every order,
          amplified near r_n and spread from there by the harmonics. At 40 samples (4 x H) a
          23/61 pair's force_spectrum lines 1-3 at 500 rpm (r_n = 31.6) were 14-25 % off m (2 pi
          n f_mesh)^2 times those of p, which Eq. (9) with e = 0 makes them equal (an outside
          tester; tests/test_whine.py).
        """
        o = self._opts(plan)
        spp = plan.study.solver.steps_per_period
        top = plan.model.highest_order if isinstance(plan.model, MeshModel) else 0.0
        res = resonant_order(plan)
        band = top + res[0] if res is not None else top
        least = max(math.ceil(4 * max(o.max_order, top)), math.floor(band + o.max_order) + 1)
        if plan.has_backlash:  # p's kinks where the flanks part: every step (IMPACT_ALIASING)
            return spp, least, band, res
        for d in range(least, spp + 1):
            if spp % d == 0:
                return d, least, band, res
        return spp, least, band, res

    def aliasing(self, plan: Plan) -> str | None:
        """What validate and run warn of where the spectrum's samples let orders up to the band
        of ``samples_needed`` fold onto the kept ones (a samples_per_period written in the
        study, or steps_per_period too few for any): ``None`` where they do not."""
        o = self._opts(plan)
        sps = self.signal_samples_per_period(plan)
        default, least, band, res = self.samples_needed(plan)
        spp = plan.study.solver.steps_per_period
        if sps - o.max_order > band:
            return None
        top = band - res[0] if res is not None else band
        why = (f"r_n = f_n / f_mesh = {res[0]:.3g} at {res[1]:g} rpm" + (
            f", spread by the excitation's harmonics up to order {top:g}" if top else "")
            if res is not None else "the excitation's highest order")
        written = o.samples_per_period is not None
        if least > spp:  # no divisor of the steps is enough: more steps
            fix = (f"steps_per_period {spp} has no divisor of {least} or more: {least} or more"
                   " steps per period give one")
        else:
            fix = (f"at least {least} avoid it (a divisor of steps_per_period {spp}; left out,"
                   f" the default takes {default})")
        return (f"the spectrum's samples_per_period {sps}{'' if written else ' (all the steps)'}:"
                f" mesh orders up to {band:.3g} ({why}) fold onto the kept orders 0-"
                f"{o.max_order:g}, whose lines may be off; {fix}")

    def _force(self, plan: Plan) -> bool:
        return self._opts(plan).force and isinstance(plan.model, MeshModel)

    def _pinion(self, plan: Plan) -> bool:
        o = self._opts(plan)
        if not o.pinion:
            return False
        if not self._force(plan) or getattr(plan.study.scene, "drive", None) is None:
            raise StudyError("<study>", "outputs.spectrum.pinion", True,
                             "a scene with a drive (inertias and base radii) and force: true")
        if "mass" in plan.grids:  # m_eq swept away from the inertias the pinion's motion uses
            raise StudyError("<study>", "outputs.spectrum.pinion", True,
                             "a scene whose m_eq is its drive's: the pinion's motion comes from"
                             " the drive's inertias, which a swept mass contradicts")
        return True

    def _dte(self, plan: Plan) -> bool:
        if not self._opts(plan).dte:
            return False
        if not isinstance(plan.model, MeshModel):
            raise StudyError("<study>", "outputs.spectrum.dte", True,
                             "a scene of the gear drive: the Mathieu scene has no transmission"
                             " error")
        return True

    def variables(self, plan: Plan) -> dict[str, VarSpec]:
        o = self._opts(plan)
        sps = self.signal_samples_per_period(plan)
        rec = plan.study.solver.record_periods
        where = "outputs.spectrum"
        problems = []  # each said at once
        if o.max_order > sps / 2:
            problems.append((None, f"{where}.max_order", o.max_order, (f"at most samples_per_period"
                             f" / 2 = {sps / 2:g} (the Nyquist order)")))
        cycle = plan.model.cycle_periods if isinstance(plan.model, MeshModel) else 1
        if rec % cycle or (plan.driven and rec < 2 * cycle):  # both rules in one line
            problems.append((None, "solver.record_periods", rec,
                             record_periods_needed(cycle, True, plan.model) if plan.driven else
                             f"a multiple of {cycle} mesh periods (the cycle of the excitation)"
                             " for a spectrum without leakage"))
        pinion = dte = False
        try:
            pinion = self._pinion(plan)
        except StudyError as exc:
            problems += exc.problems
        try:
            dte = self._dte(plan)
        except StudyError as exc:
            problems += exc.problems
        lines = kept_bins(rec * sps, rec, o.max_order)
        speeds = len(plan.grids.get("speed", (0,)))
        if lines * speeds > MAX_SPECTRUM_CELLS:  # before the coordinates are made: 1e8 recorded
            problems.append((None, "solver.record_periods", rec, (  # periods took validate to
                f"a spectrum of at most {MAX_SPECTRUM_CELLS:.3g} lines x speeds: {lines:.3g}"  # 6 GB
                f" lines (max_order {o.max_order:g} x record_periods) at {speeds} speeds; record"
                " fewer periods or keep a lower max_order")))
        if problems:
            raise StudyError.many("<study>", problems)
        order = np.arange(lines) / rec
        aux = {}
        if isinstance(plan.model, MeshModel):
            f_mesh = mesh_frequency(plan.grids["speed"], plan.model.teeth)
            aux["frequency"] = (("speed", "order"), f_mesh[:, None] * order[None, :])
        common = dict(extra_dims=("order",), extra_coords={"order": order}, aux_coords=aux)
        specs = {"spectrum": VarSpec(
            **common, kind=None if plan.dimensionless else "displacement",
            attrs={**({"units": "1"} if plan.dimensionless else {}), "samples_per_period": sps,
                   "window": "none (whole mesh periods)"})}
        if self._force(plan):
            specs["force_spectrum"] = VarSpec(**common, attrs={
                "units": "N", "samples_per_period": sps,
                "long_name": "single-sided amplitude spectrum of the dynamic mesh force"
                             " k(t) f(p) + c p' over whole mesh periods"})
        if o.phase:
            phase_attrs = {"units": "rad",
                           "phase_floor": PHASE_FLOOR[plan.study.solver.precision]}
            specs["spectrum_phase"] = VarSpec(**common, attrs={**phase_attrs, "long_name": (
                "phase of each line of spectrum: p ~ sum spectrum cos(2 pi order phi +"
                " spectrum_phase), phi the mesh phase (0 at t = 0), in (-pi, pi]; NaN where the"
                " line is at most phase_floor of its case's largest or spectrum is NaN")})
            if self._force(plan):
                specs["force_spectrum_phase"] = VarSpec(**common, attrs={
                    **phase_attrs, "long_name": (
                        "phase of each line of force_spectrum: k(t) f(p) + c p' ~ sum"
                        " force_spectrum cos(2 pi order phi + force_spectrum_phase), phi the mesh"
                        " phase (0 at t = 0), in (-pi, pi]; NaN where the line is at most"
                        " phase_floor of its case's largest or force_spectrum is NaN")})
        if dte:
            specs["dte_spectrum"] = VarSpec(**common, kind="displacement", attrs={
                "long_name": "single-sided amplitude spectrum of the dynamic transmission error"
                " p + e = r1 theta1 - r2 theta2 (Eq. 5) over whole mesh periods, from the lines"
                " of p and the harmonics of the scene's e(t); NaN at order 0 (e(t) enters Eq. 6"
                " only as e'': its mean is not in the model)"})
            if o.phase:
                specs["dte_spectrum_phase"] = VarSpec(**common, attrs={
                    **phase_attrs, "long_name": (
                        "phase of each line of dte_spectrum: p + e ~ sum dte_spectrum cos(2 pi"
                        " order phi + dte_spectrum_phase), phi the mesh phase (0 at t = 0), in"
                        " (-pi, pi]; NaN where the line is at most phase_floor of its case's"
                        " largest or dte_spectrum is NaN")})
        if pinion:
            specs["pinion_spectrum"] = VarSpec(**common, kind="displacement", attrs={
                "long_name": "pinion (gear 2, driven) motion r2 theta2 per line: (r2^2 / I2)"
                " |W_k| / (2 pi f_k)^2 of the mesh force W (Eq. 4); 0 at order 0"})
            specs["pinion_rms"] = VarSpec(kind="displacement", attrs={
                "long_name": "rms of r2 theta2 over the kept lines: the doubly"
                " integrated tangential acceleration of the pinion (gear 2, driven) at its base circle"})
        return specs

    def compute(self, plan: Plan, params: dict[str, np.ndarray],
                result: BatchResult) -> dict[str, np.ndarray]:
        o = self._opts(plan)
        s = plan.study.solver
        rec = s.record_periods
        sig = result.signal
        order, c = line_spectrum(sig, rec, o.max_order)
        bad = result.status != 0
        amp = np.abs(c)
        amp[bad] = np.nan
        out = {"spectrum": amp}
        if o.phase:
            out["spectrum_phase"] = self._phase(plan, c, np.max(np.abs(sig), axis=1), bad)
        if self._force(plan):
            force, spring = self._force_spectrum(plan, params, sig, order, c)
            out["force_spectrum"] = np.abs(force)
            out["force_spectrum"][bad] = np.nan
            if o.phase:
                out["force_spectrum_phase"] = self._phase(
                    plan, force, np.max(np.abs(spring), axis=1), bad)
        if self._dte(plan):
            dte = c + self._ste_lines(plan, len(order))[None, :]
            dte[:, 0] = np.nan  # the mean of e(t) is not in the model
            out["dte_spectrum"] = np.abs(dte)
            out["dte_spectrum"][bad] = np.nan
            if o.phase:
                out["dte_spectrum_phase"] = self._phase(
                    plan, dte, np.max(np.abs(sig), axis=1), bad)
        if self._pinion(plan):
            scene = plan.study.scene  # r2: the drive's, or the gear pair's where it omits it
            _, r2 = scene.drive_radii()  # (drive.base_radius_2 was None: a TypeError traceback)
            freq = mesh_frequency(np.asarray(params["speed"], float), plan.model.teeth)
            fs = np.where(order[None, :] > 0, out["force_spectrum"], 0.0)
            x = pinion_displacement(fs, freq[:, None] * order[None, :],
                                    base_radius_2=r2, inertia_2=scene.drive.inertia_2)
            out["pinion_spectrum"] = x
            out["pinion_rms"] = spectrum_rms(x)
        return out

    def _first_sample(self, plan: Plan) -> tuple[int, int]:
        """Where the recorded sample j = 0 lies after t = 0: (whole mesh periods, steps after
        them). Sample j is the state after ``n_transient + j * stride + 1`` steps (the kernel
        records the end of each step from step ``n_transient`` on: ``rk._sample``)."""
        return plan.study.solver.transient_periods, 1

    def _phase(self, plan: Plan, coeff: np.ndarray, largest_sample: np.ndarray,
               bad: np.ndarray) -> np.ndarray:
        """The lines' phases [rad] (``line_phase`` referred to t = 0), NaN where the amplitude
        is (``bad``: the kernel's status, non-finite lines) and where a line is at most
        ``PHASE_FLOOR`` (of the solver's precision) of the case's largest sample or line."""
        s = plan.study.solver
        whole, step = self._first_sample(plan)
        theta = line_phase(coeff, s.record_periods, whole, step / s.steps_per_period)
        amp = np.abs(coeff)
        with np.errstate(invalid="ignore"):  # a diverged case's non-finite samples
            scale = np.fmax(largest_sample, np.max(amp, axis=1, initial=0.0))
            theta[amp <= PHASE_FLOOR[s.precision] * scale[:, None]] = np.nan
        theta[bad] = np.nan
        theta[~np.isfinite(amp)] = np.nan
        return theta

    def _ste_lines(self, plan: Plan, lines: int) -> np.ndarray:
        """The harmonics of the model's e(t) as complex lines in the frame of ``line_spectrum``
        of the recorded samples (sample 0 after ``_first_sample``), on the bins 0 .. lines - 1
        [m]: e_n cos(2 pi r phi + b_n) is ``e_n exp(i (b_n + 2 pi r phi_0))`` at bin r x
        record_periods (a whole bin: record_periods is a multiple of the excitation's cycle),
        phi_0 the mesh phase of sample 0. Orders above the kept ones are left out."""
        s = plan.study.solver
        whole, step = self._first_sample(plan)
        to_samples = np.exp(-1j * line_phase(np.ones(lines, complex), s.record_periods, whole,
                                             step / s.steps_per_period))
        e = np.zeros(lines, complex)
        for hm in plan.model.ste_harmonics:
            k = round(hm.order * s.record_periods)
            if k < lines:
                e[k] += hm.amplitude * np.exp(1j * hm.phase) * to_samples[k]
        return e

    def _force_spectrum(self, plan: Plan, params: dict[str, np.ndarray], sig: np.ndarray,
                        order: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Complex spectrum of k(t) f(p) + c p' for every case of the chunk [N], and the samples
        of k(t) f(p) [N]."""
        model: MeshModel = plan.model  # type: ignore[assignment]
        s = plan.study.solver
        n = sig.shape[0]
        spp = s.steps_per_period
        stride = spp // self.signal_samples_per_period(plan)
        whole, step = self._first_sample(plan)  # phase of sample j in mesh periods
        phi = whole + (step + stride * np.arange(sig.shape[1])) / spp

        def per_case(name: str, default: float) -> np.ndarray:
            return np.asarray(params[name], float) if name in params else np.full(n, default)

        k_t = per_case("stiffness", model.stiffness)[:, None] + sum(
            (hm.amplitude * np.cos(2.0 * math.pi * hm.order * phi + hm.phase)
             for hm in model.stiffness_harmonics), np.zeros_like(phi))[None, :]
        f_p = sig
        if plan.has_backlash:
            b = per_case("backlash", model.backlash)[:, None] / 2.0
            f_p = sig - np.clip(sig, -b, b)
        _, c_spring = line_spectrum(k_t * f_p, s.record_periods, self._opts(plan).max_order)
        omega = model.teeth * per_case("speed", math.nan) * RPM  # mesh angular frequency [rad/s]
        dp = 1j * omega[:, None] * order[None, :] * c  # spectrum of p'
        n_samples = sig.shape[1]
        if n_samples % 2 == 0 and len(order) == n_samples // 2 + 1:
            dp[:, -1] = 0.0
        return c_spring + per_case("damping", model.damping)[:, None] * dp, k_t * f_p


def impact_aliasing(plan: Plan, parted: int | None = None) -> str | None:
    """What validate and run warn of where a scene with backlash has its spectrum sampled below
    its steps (``IMPACT_ALIASING``): ``parted`` the cases whose flanks parted in the steady state
    (``contact_loss_fraction`` or ``backside_contact_fraction`` above 0; ``None`` before the run
    or where they are not stored: the line says they may). ``None`` where nothing is to say,
    no case parted included."""
    if "spectrum" not in plan.outputs or not plan.has_backlash or parted == 0:
        return None
    sps, spp = plan.samples_per_period(), plan.study.solver.steps_per_period
    if sps >= spp:
        return None
    who = "" if parted is None else f"{parted} of {plan.n_cases} case(s) part their flanks; "
    return (f"the spectrum's samples_per_period {sps} with backlash: {who}{IMPACT_ALIASING};"
            f" samples_per_period {spp} (all the steps, the default with backlash) brings them to"
            " the steps' own error")


def parted_cases(arrays) -> int | None:
    """Cases of ``arrays`` (a result or a chunk's variables) whose flanks parted in the steady
    state, for ``impact_aliasing``; ``None`` where the stats that say so are not stored."""
    if "contact_loss_fraction" not in arrays:
        return None
    parted = np.asarray(arrays["contact_loss_fraction"]) > 0
    if "backside_contact_fraction" in arrays:
        parted = parted | (np.asarray(arrays["backside_contact_fraction"]) > 0)
    return int(np.count_nonzero(parted))


def spectrum_aliasing(plan: Plan) -> str | None:
    """The warning of a study whose spectrum's samples fold the resonance's orders onto its
    kept lines (``Spectrum.aliasing``), ``None`` when it has none or no spectrum."""
    return OUTPUTS["spectrum"].aliasing(plan) if "spectrum" in plan.outputs else None


class PeriodOptions(Strict):
    """Options of the ``period`` output."""

    tolerance: Real = Field(1e-3, gt=0, lt=1, description="largest change of p between samples"
                            " one motion period apart, relative to p_pp, that counts as repeating")


class Period:
    """The period of the steady motion in mesh periods (docs/data-format.md).

    p is recorded once per mesh period, at the same phase of each (a Poincare section),
    and ``motion_period`` is the smallest P up to record_periods / 2 for which every sample
    equals the one P periods before within ``tolerance`` x p_pp
    (``gearsweep.analysis.period``): 1 for a motion with the mesh period, 2 or 4 after a period
    doubling, the excitation's cycle for a motion that follows a longer cycle, NaN for an
    irregular motion or one that repeats over more than half the record. ``period_mismatch`` is
    that largest change / p_pp (where no P fits, the smallest over P). The settle test (status 2)
    compares only the extremes of the record's halves, and an irregular motion may pass it.
    """

    name = "period"
    options_model = PeriodOptions

    def _opts(self, plan: Plan) -> PeriodOptions:
        return options_of(plan, self)

    def signal_samples_per_period(self, plan: Plan) -> int:
        return 1

    def seconds(self, plan: Plan, chunks: int, rate: float) -> float:
        """Typical time of ``compute`` over a run [s]: ``motion_period`` compares the samples P
        apart (R - P comparisons, ``PERIOD_COMPARE_SECONDS`` each) for P = 1, 2, ... until the
        case's period. A driven scene without backlash is linear: its settled motion repeats
        with the excitation's cycle (``MeshModel.cycle_periods``; one that diverged or did not
        settle is not compared), and is priced so; any other (backlash, a Mathieu chart, an
        undriven scene) as ``worst_seconds``. Every case was priced as having no period: the
        estimate of 8,000 whine cases at 4,000 recorded periods said 67.2 s (4.2 s taken), and
        of 80,000 refused them at 11.1 min (about 45 s)."""
        r = plan.study.solver.record_periods
        longest = r // 2
        cycle = plan.model.cycle_periods if isinstance(plan.model, MeshModel) else longest + 1
        if plan.has_backlash or not plan.driven or cycle > longest:
            return self.worst_seconds(plan, chunks, rate)
        return plan.n_cases * _comparisons(r, cycle) * PERIOD_COMPARE_SECONDS

    def worst_seconds(self, plan: Plan, chunks: int, rate: float) -> float:
        """Time of ``compute`` over a run [s] at most: every case compared up to P = R / 2 (no
        period), about 3 R^2 / 8 comparisons a case, quadratic in ``record_periods``."""
        r = plan.study.solver.record_periods
        return plan.n_cases * _comparisons(r, r // 2) * PERIOD_COMPARE_SECONDS

    def variables(self, plan: Plan) -> dict[str, VarSpec]:
        rec = plan.study.solver.record_periods
        if rec < 2:
            raise StudyError("<study>", "solver.record_periods", rec,
                             "at least 2 for the period output (periods up to half the record)")
        tol = self._opts(plan).tolerance
        return {
            "motion_period": VarSpec(attrs={
                "units": "1", "tolerance": tol, "longest": rec // 2,
                "long_name": "period of the steady motion in mesh periods (p once per mesh period"
                " repeats; NaN: irregular, longer than half the record, still decaying, or the"
                " case diverged or was skipped)"}),
            "period_mismatch": VarSpec(attrs={
                "units": "1", "long_name": "largest change of p between samples motion_period"
                " mesh periods apart / p_pp (no period found: the smallest over the periods"
                " tried)"}),
        }

    def compute(self, plan: Plan, params: dict[str, np.ndarray],
                result: BatchResult) -> dict[str, np.ndarray]:
        sps = plan.samples_per_period()  # the signal's, the largest any output asked for
        q = result.signal[:, ::sps]  # one step into every recorded mesh period: the same
        # phase whatever the signal's sampling (sample j follows step 1 + j * stride)
        pp = result.stats["p_max"] - result.stats["p_min"]
        ok = result.status == 0  # the others' are NaN: not compared (a diverged case's
        period = np.full(len(ok), np.nan)  # non-finite samples were, up to R / 2)
        mismatch = np.full(len(ok), np.nan)
        period[ok], mismatch[ok] = motion_period(q[ok], pp[ok], self._opts(plan).tolerance)
        return {"motion_period": period, "period_mismatch": mismatch}


def _comparisons(record: int, longest: int) -> int:
    """Comparisons of ``motion_period`` for one case over ``record`` samples that tries the
    periods 1 .. ``longest``: sum of record - P."""
    return longest * record - longest * (longest + 1) // 2


PERIOD_COMPARE_SECONDS = 1.3e-9
"""One comparison of ``motion_period`` [s]. Measured on this 2-core machine (26 Nov 2026, 23:45
UTC), the Fig. 8 scene at 2,000 speeds without continuation, [stats, period] less [stats]: 3.7 s
at 2,000 recorded periods, 16.2 s at 4,000 (1.2e10 comparisons); the estimate priced 0 s."""

TOL = UNSTABLE_TOL
"""A multiplier counts as > 1 above 1 + TOL (converged to rtol 1e-8, far below)."""

THRESHOLD = 1.0 + TOL
"""``unstable`` and ``integrator_unstable`` are a multiplier above this: the number ``compute``
compares against, stored as their ``threshold`` attribute (a number, so that
``ds.floquet_multiplier > ds.unstable.attrs["threshold"]`` works; it was the string
'1 + 1e-06', on which that comparison raised: an outside tester's finding)."""


class Floquet:
    """Floquet multipliers, integrator stability and the step guard rail (docs/data-format.md
    names), of the linear equation with the teeth in contact: backlash and forcing left out, so a
    rattle scene's multiplier is the same for every backlash and load.

    For every case the homogeneous equation with the teeth in contact (f(p) = p, no forcing),

        m p'' + c p' + (k0 + sum_n k_n cos(n N w t + a_n)) p = 0,

    is put in Mathieu time tau = N w t (``alpha = k0 / (m (N w)^2)``, ``gamma = c / (m N w)``, the
    harmonics scaled by ``1 / (m (N w)^2)``; the Mathieu scene gives alpha, beta, gamma directly), and

    * ``floquet_multiplier``, ``floquet_error``, ``unstable``: converged Floquet analysis
      (``gearsweep.kernels.floquet.floquet``, RK5 with step doubling);
    * ``discrete_multiplier``, ``integrator_unstable``: the same monodromy matrix computed with the
      study's own method and steps_per_period; ``integrator_unstable`` where that fixed-step map has
      a multiplier > 1 and the equation does not;
    * ``min_steps_per_period``: the guard rail's fewest stable steps per mesh period of the study's
      method (stability polynomial at the largest stiffness, ``gearsweep.analysis.stability``;
      where the step guard checks the fixed-step map (``needs_map_check``: k(t) varies strongly,
      the step is coarse, or a parametric tongue is open near the case), the first step count
      from there whose map does not diverge where the equation does not).

    For the rattle and full scenes these describe the contact (linear) phase only: with backlash the
    motion is piecewise linear and its stability is not a Floquet question.
    """

    name = "floquet"

    def signal_samples_per_period(self, plan: Plan) -> int:
        return 0

    def kernel_calls(self, plan: Plan) -> list[dict]:
        """The kernel calls of ``compute`` besides the study's (one case each): its monodromy
        maps, converged with RK5 and at the study's method and step (their specialisation
        depends on which terms are given, not on the values)."""
        s = plan.study.solver
        return [monodromy_call(1.0, 0.0, 0.0, s.steps_per_period, method=m)
                for m in dict.fromkeys(("rk5", s.method))]

    def seconds(self, plan: Plan, chunks: int, rate: float) -> float:
        """Predicted time of ``compute`` over a run of ``chunks`` chunks [s], from arithmetic:
        each distinct case (both directions of a continued sweep share one) pays
        ``FLOQUET_CASE_SECONDS`` and the monodromy maps' lane-steps at ``rate`` [Msteps/s]:
        ``FLOQUET_PERIODS`` times ``floquet``'s first step count (from the largest frozen pole;
        per speed with the scene's other values, or at the grid's largest alpha, beta, gamma of a
        Mathieu scene) and the study's own map, and in a forced scene the step-limit scan's
        exact monodromy and maps (``_forced_lane_steps``); each chunk pays
        ``FLOQUET_CALL_SECONDS``."""
        g = plan.grids
        if plan.dimensionless:
            params = {d: np.array([np.max(np.abs(g[d]))]) for d in ("alpha", "beta", "gamma")
                      if d in g}
        else:
            params = {"speed": np.asarray(g["speed"], float)} if "speed" in g else {}
        n = len(params["speed"]) if "speed" in params else 1
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            a, b, gm, harm, *_ = hill_parameters(plan.model, params, n)
            first = initial_steps(np.nan_to_num(a), np.nan_to_num(b), np.nan_to_num(gm), harm)
        steps = 2.0 * (FLOQUET_PERIODS * float(np.mean(first)) + plan.study.solver.steps_per_period)
        if forced_scene(plan) and not plan.dimensionless:
            steps += _forced_lane_steps(plan)
        cases = plan.n_cases / max(len(plan.directions), 1)
        return (cases * (FLOQUET_CASE_SECONDS + steps / (rate * 1e6))
                + chunks * FLOQUET_CALL_SECONDS)

    def variables(self, plan: Plan) -> dict[str, VarSpec]:
        return {
            "floquet_multiplier": VarSpec(attrs={"method": "rk5, steps doubled until converged",
                                                 "equation": "homogeneous, teeth in contact"}),
            "floquet_error": VarSpec(attrs={"units": "1", "long_name":
                                            "estimated error of floquet_multiplier (Richardson)"}),
            "unstable": VarSpec(dtype="bool", attrs={
                "threshold": THRESHOLD,
                "comment": f"floquet_multiplier > threshold (1 + {TOL:g})"}),
            "discrete_multiplier": VarSpec(attrs={
                "units": "1", "long_name": "largest |mu| of the fixed-step map over one mesh "
                "period at the study's method and steps_per_period"}),
            "integrator_unstable": VarSpec(dtype="bool", attrs={
                "threshold": THRESHOLD,
                "comment": f"discrete_multiplier > threshold (1 + {TOL:g}) where"
                           " floquet_multiplier is not"}),
            "min_steps_per_period": VarSpec(attrs={
                "units": "1", "long_name": "fewest steps per mesh period for which the study's "
                "method is stable (stability polynomial at the largest stiffness; where the step "
                "guard checks it, the fixed-step map's monodromy too); computed also for a case "
                "the step guard skips (status 3), whose other floquet variables are not"}),
        }

    @staticmethod
    @contextlib.contextmanager
    def shared():
        """Within: ``compute`` keeps each distinct case's multipliers and reuses them (a continued
        sweep computes its cases speed by speed, up and down, on the same parameters: the
        multipliers depend on the parameters only, ``chunk.run_chunk`` computes them once for
        all its speeds first). Per thread: a chunk runs in one thread."""
        token = _FLOQUET_MEMO.set({})
        try:
            yield
        finally:
            _FLOQUET_MEMO.reset(token)

    def step_limits(self, plan: Plan, params: dict[str, np.ndarray], n: int) -> np.ndarray:
        """``min_steps_per_period`` alone, of cases that share ``plan``'s model: what ``compute``
        gives them, for the cases the step guard skips (``step_guard: skip``, status 3), whose
        other variables are not computed; this one is the number their user needs (it was NaN
        there: an outside tester's finding)."""
        a, b, g, harm, kmax, cm, period = hill_parameters(plan.model, params, n)
        a, b, g = (np.broadcast_to(np.asarray(x, float), (n,)) for x in (a, b, g))
        return _step_limit(_HillSolver(plan), harm, np.isfinite(a), a, b, g, kmax, cm, period)

    def compute(self, plan: Plan, params: dict[str, np.ndarray],
                result: BatchResult) -> dict[str, np.ndarray]:
        n = result.x_final.shape[0]
        a, b, g, harm, kmax, cm, period = hill_parameters(plan.model, params, n)
        s = _HillSolver(plan)
        ok = np.isfinite(a)
        memo = _FLOQUET_MEMO.get()
        if memo is None:
            fl_mu, fl_err, disc = np.full(n, np.nan), np.full(n, np.nan), np.full(n, np.nan)
            if ok.any():
                fl_mu[ok], fl_err[ok], disc[ok] = _multipliers(a[ok], b[ok], g[ok], harm, s)
            limit = _step_limit(s, harm, ok, a, b, g, kmax, cm, period)
        else:
            fl_mu, fl_err, disc, limit = _shared(memo.setdefault(repr(harm), {}), s, harm, ok,
                                                 a, b, g, kmax, cm, period)
        unstable = fl_mu > THRESHOLD
        return {
            "floquet_multiplier": fl_mu,
            "floquet_error": fl_err,
            "unstable": unstable,
            "discrete_multiplier": disc,
            "integrator_unstable": (disc > THRESHOLD) & ~unstable & ok,
            "min_steps_per_period": limit,
        }


FLOQUET_CASE_SECONDS = 10e-6
"""The bookkeeping of ``compute`` per case, besides its monodromy maps (priced by their steps).
Measured on this 2-core machine (26 Nov 2026, 23:15 UTC), the floquet output's whole time per
case, as the wall time of a run with [stats, floquet] less that of [stats]: 13 us (Strutt chart,
26,462 cases), 17 us (a continued rattle study, 10,000 distinct cases), 5-9 us (a whine study,
100,000 cases). Until that day the step-limit scan of ``min_steps_per_period`` ran per case
(34 and 18 us in the first two; 40 us was priced); it now runs per distinct damping ratio."""
FLOQUET_CALL_SECONDS = 0.06
"""The same scan's fixed part, per ``compute`` call (one per chunk): 0.05 s for one case."""
FLOQUET_PERIODS = 15
"""Steps of ``floquet``'s doubling per lane (two per case), in units of its first step count:
1 + 2 + 4 + 8, three doublings. Measured: 800, 25,226, 414 and 391 lane-steps a case against
first step counts of 40, 1056, 32 and 27 on average (a rattle, the rig, the Strutt chart and a
gear study): 10-14 of them per lane."""

FORCED_PERIODS = 31
"""Steps per lane of the equation's monodromy that ``map_step_limit`` computes in a forced
scene (``floquet`` at rtol 1e-10, besides the output's own at 1e-8), in units of ``floquet``'s
first step count: 1 + 2 + 4 + 8 + 16, four doublings. Measured (27 Nov 2026): 30 and 25 of them
(whine scenes with k1 / k0 = 0.98 and 0.84, RK5 at 64 steps: 6,308 and 1,655 lane-steps a case
against first step counts of 208 and 65)."""

FORCED_SAMPLE = 32
"""Cases of the guard's grid (evenly spaced) whose step-limit scan ``_forced_lane_steps`` runs to
price a forced scene's scan."""


def _forced_lane_steps(plan: Plan) -> float:
    """Lane-steps a case of a forced scene's ``min_steps_per_period`` costs beyond the floquet
    output's own maps (``_step_limit``: ``map_step_limit`` with ``forced``): the equation's
    monodromy (``FORCED_PERIODS`` first step counts) and the map at every count the scan tries
    from the frozen limit to the first that passes, 2 S lanes-steps each. The scan's length is
    the study's own (RK5 at 64 steps near the principal tongue: 38 -> 108; RK4 further): it is
    run on ``FORCED_SAMPLE`` cases of the swept grid, those the guard checks averaged over all
    (the mean over the sample, unchecked cases costing nothing). Every forced case of a strong
    k(t) was priced at the output's 1e-8 monodromy alone: RK4 at 64 steps near the principal
    tongue took 7 times what was priced."""
    grids = plan.grids
    names = [d for d in ("speed", "damping", "mass", "stiffness", "torque", "mean_force")
             if d in grids and d in plan.dims]
    shape = tuple(len(grids[d]) for d in names)
    m = math.prod(shape)
    pick = np.unique(np.linspace(0, m - 1, min(m, FORCED_SAMPLE)).round().astype(np.int64))
    at = np.unravel_index(pick, shape) if names else ()
    params = {d: np.asarray(grids[d], float)[i] for d, i in zip(names, at, strict=True)}
    n = pick.size
    s = _HillSolver(plan)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        a, b, g, harm, kmax, cm, period = hill_parameters(plan.model, params, n)
        a, b, g = (np.broadcast_to(np.asarray(x, float), (n,)) for x in (a, b, g))
        ok = np.isfinite(a)
        strong = np.flatnonzero(ok & needs_map_check(a, b, g, harm, s.steps_per_period * s.cycle))
        if not strong.size:
            return 0.0
        _, start = check_step(s.method, s.steps_per_period, period, kmax, cm)
        start = np.broadcast_to(np.asarray(start, float), (n,))[strong].astype(np.int64)
        limit = map_step_limit(a[strong], b[strong], g[strong], start, method=s.method,
                               harmonics=harm, forced=True, cycles=s.cycles,
                               spp_scale=s.cycle).astype(np.int64)
        first = initial_steps(a[strong], b[strong], g[strong], harm)
    tried = (limit * (limit + 1) - start * (start - 1)) // 2 * s.cycle  # sum of S, start..limit
    return float(np.sum(2.0 * (FORCED_PERIODS * first + tried))) / n


_FLOQUET_MEMO: contextvars.ContextVar[dict | None] = contextvars.ContextVar("floquet_memo",
                                                                        default=None)
"""``Floquet.shared``'s table per shape of the stiffness variation: case -> its arrays' values."""


def forced_scene(plan: Plan) -> bool:
    """The scene's response is forced (a mean force or load, STE or force harmonics): the step
    guard's map check then also judges the map's resonant response (``map_step_check``'s
    ``forced``). A Mathieu scene and a free vibration (the rig of Fig. 7.2) are not."""
    m = plan.model
    if not isinstance(m, MeshModel):
        return False
    return bool(m.mean_force or m.ste_harmonics or m.force_harmonics
                or {"torque", "mean_force"} & set(plan.grids))


@dataclass(frozen=True)
class _HillSolver:
    """The study's method and steps with the period of its Hill equation (``hill_cycle``: a
    fractional stiffness order's cycle of ``cycle`` mesh periods, the forcing's ``cycles`` of
    them) and whether the scene is forced (``forced_scene``)."""

    method: str
    steps_per_period: int
    cycle: int
    cycles: int
    forced: bool

    def __init__(self, plan: Plan):
        cycle, q = hill_cycle(plan.model)
        for k, v in dict(method=plan.study.solver.method,
                         steps_per_period=plan.study.solver.steps_per_period,
                         cycle=max(cycle, 1), cycles=q, forced=forced_scene(plan)).items():
            object.__setattr__(self, k, v)


def _multipliers(a, b, g, harm, solver) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Converged largest |mu| and its error (RK5) and the study's fixed-step map's largest |mu|
    of the cases (a, b, g) of the Hill equation of shape ``harm``, per mesh period (the equation's
    period is ``solver.cycle`` of them)."""
    fl = floquet(a, b, g, method="rk5", rtol=1e-8, tol=TOL, harmonics=harm)
    M = monodromy(a, b, g, solver.steps_per_period * solver.cycle, method=solver.method,
                  harmonics=harm)
    mu, err, disc = fl.multiplier, fl.error, largest_multiplier(M)
    if solver.cycle > 1:  # |mu|^(1/P) per mesh period, its error by the derivative
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            per = mu ** (1.0 / solver.cycle)
            err = err * per / (solver.cycle * mu)
            mu, disc = per, disc ** (1.0 / solver.cycle)
    return mu, err, disc


def _step_limit(solver, harm, ok, a, b, g, kmax, cm, period) -> np.ndarray:
    """``min_steps_per_period`` of the cases: the frozen-coefficient limit (``check_step``), and
    where the step guard checks the map (``needs_map_check``, the step guard's rule) the first
    step count from it on whose map passes the guard's monodromy check (``map_step_limit``)."""
    n = np.size(a)
    _, limit = check_step(solver.method, solver.steps_per_period, period, kmax, cm)
    limit = np.array(np.broadcast_to(limit, (n,)), dtype=float)
    strong = np.flatnonzero(ok & needs_map_check(a, b, g, harm,
                                                 solver.steps_per_period * solver.cycle))
    if strong.size:
        with np.errstate(over="ignore", invalid="ignore"):
            limit[strong] = map_step_limit(a[strong], b[strong], g[strong],
                                           limit[strong].astype(np.int64),
                                           method=solver.method, harmonics=harm,
                                           forced=solver.forced, cycles=solver.cycles,
                                           spp_scale=solver.cycle)
    return limit


def _shared(table: dict, solver, harm, ok, a, b, g, kmax, cm, period) -> tuple:
    """``Floquet.compute``'s per-case arrays (multiplier, error, discrete multiplier, step limit)
    from ``table``, the cases not yet in it computed (each once) and added."""
    n = a.size
    kmax, cm, period = (np.broadcast_to(x, (n,)) for x in (kmax, cm, period))
    keys = list(zip(a.tolist(), b.tolist(), g.tolist(), kmax.tolist(), cm.tolist(),
                    period.tolist(), ok.tolist(), strict=True))
    todo: dict[tuple, int] = {}
    for i, key in enumerate(keys):
        if key not in table:
            todo.setdefault(key, i)
    if todo:
        idx = np.array(list(todo.values()))
        m = idx.size
        fl_mu, fl_err, disc = np.full(m, np.nan), np.full(m, np.nan), np.full(m, np.nan)
        good = ok[idx]
        if good.any():
            j = idx[good]
            fl_mu[good], fl_err[good], disc[good] = _multipliers(a[j], b[j], g[j], harm, solver)
        limit = _step_limit(solver, harm, ok[idx], a[idx], b[idx], g[idx], kmax[idx], cm[idx],
                            period[idx])
        for key, *vals in zip(todo, fl_mu, fl_err, disc, limit, strict=True):
            table[key] = vals
    out = np.array([table[key] for key in keys], dtype=float).reshape(n, 4)
    return tuple(out[:, c].copy() for c in range(4))


OUTPUTS: dict[str, Output] = {"stats": Stats(), "spectrum": Spectrum(), "floquet": Floquet(),
                             "period": Period()}
"""Registered outputs by name."""


def configure(name: str, options: dict[str, Any], file: str = "<study>",
              where: str | None = None) -> BaseModel | None:
    """Validate the options of output ``name``; a problem raises one ``StudyError`` line.

    Returns
    -------
    The output's options model instance, or ``None`` for an output that takes no options.
    """
    where = where or f"outputs.{name}"
    model = getattr(OUTPUTS[name], "options_model", None)
    if model is None:
        if options:
            raise StudyError(file, where, options, f"the {name!r} output takes no options")
        return None
    try:
        return model.model_validate(options)
    except ValidationError as exc:  # every option's problem at once (a misspelt one hid the rest)
        problems = []
        for err in exc.errors():
            loc = ".".join(str(p) for p in err["loc"])
            msg = err["msg"].removeprefix("Value error, ")
            value = err.get("input")
            if isinstance(value, dict):
                value = options
            if err["type"] == "extra_forbidden":
                msg = f"unknown option; allowed: {', '.join(model.model_fields)}"
            found = err.get("ctx", {}).get("error")
            if isinstance(found, FieldProblems):  # at the first option it names that is written
                for fields, m in found.problems:  # (its line: the caller's); none: the output
                    at = next((f for f in fields if f in options), None)
                    problems.append((None, f"{where}.{at}" if at else where,
                                     options[at] if at else value, m))
                continue
            problems.append((None, f"{where}.{loc}" if loc else where, value, msg))
        raise StudyError.many(file, problems) from None

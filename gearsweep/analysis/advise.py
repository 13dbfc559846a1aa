"""Step advice: the steps per mesh period a case needs for a target accuracy, its cost, and a
warning when a chosen step lies beyond the method's stability limit.

Error model (measured, ``scripts/calibrate_advisor.py``): the trajectory error over the
steady-state window, relative to the response amplitude, obeys

    err <= C (h omega_n max(1, r))^p min(1, (n r / knee)^2),
    h = T_mesh / steps_per_period,  omega_n = sqrt(k_max / m),  r = Omega / omega_n

(Omega: the mesh angular frequency; n >= 1: the highest order of the scene's stiffness, STE and
force harmonics, whose resonance lies at r = 1 / n), with p = 4 (RK4) or 5 (RK5) on smooth scenes and with the
kink-aware step on backlash scenes, and p = 2 for the plain step on backlash scenes (the kinks
of the dead zone). Why this shape (docs/precision.md, "Step advice"): the damped free vibration
decays in the transient, so the steady error is that of the forced response. Near the resonance
it is the shift of the discrete natural frequency, ~ (h omega_n)^p, amplified by the resonance;
far below it the same shift weighted by the response's sensitivity to omega_n, about r^2 (the
static response is exact for a Runge-Kutta step), so (h omega_n)^p r^2, with r the highest
harmonic's, n r (below its own resonance each harmonic's error goes so); far above it the
method's error on the forcing itself, ~ (h Omega)^p = (h omega_n r)^p. C and the knee are fitted
per method and scene kind (``data/error_constants.json``, with the provenance): C the upper
envelope over the calibration runs, the knee the one whose envelope overestimates them least.
At a fixed step count the model's error does not grow with speed, so the lowest speed sets the
step count:

    steps_per_period >= 2 pi max(1, 1/r) (SAFETY C s / target)^(1/p),  s = min(1, (n r/knee)^2)

at the lowest speed, rounded up to a multiple of 8 (SAFETY = 2). A varying stiffness adds
response orders beyond the excitation's: n is raised to ``effective_order``. Below half the
calibration's damping ratio a warning bounds the error by zeta_cal / zeta times the expected one,
with zeta the damping ratio of the slowest free decay among the speeds (``free_decay``: near a
parametric resonance of k(t) it decays slower than c gives); speeds where k(t) makes the
equation unstable are named. Stability: the step must also
satisfy h omega_n below the limit of the method's stability polynomial at the poles
omega_n (-zeta +- sqrt(zeta^2 - 1)), zeta = c / (2 m omega_n) (``stability.step_limit_hw``: on the
ray of the complex pair below zeta = 1, the faster real pole above), at every case of the study
(``stability_cases``: the limit is not monotonic in zeta, RK4's 2.95 at 0.1 and 2.62 at 0.5).
That rule takes the stiffest instant of the mesh cycle as if it lasted, which is conservative
where k(t) varies: a written step beyond it is said to diverge only where the fixed-step map
over the mesh cycle does (``map_check``, the step guard's check; an outside tester's RK4 run at
h omega_n = 3.42 against the limit 2.95 was stable, p_rms 1.5 % off scipy's).
"""

from __future__ import annotations

import json
import math
import textwrap
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path

import numpy as np

from gearsweep.analysis.stability import (
    frozen_step_ok,
    largest_multiplier,
    step_limit_hw,
    tableau_monodromy,
)
from gearsweep.kernels import tableaux
from gearsweep.kernels.floquet import UNSTABLE_TOL

CONSTANTS_FILE = Path(__file__).parent / "data" / "error_constants.json"
SAFETY = 2.0
"""The advised step aims at target / SAFETY: the constants are envelopes over a few speeds, and
a held-out case can sit slightly above them (one held-out RK5 whine case reached 0.9 of the
envelope's prediction)."""
LIGHT_DAMPING = 0.5
"""A damping ratio below this fraction of the calibration's (``calibration_damping_ratio`` of
the constants, about 0.2) is warned about: near a resonance the steady response's error grows
about as 1 / zeta (the resonance's amplification of the step's phase error), and the constants
were fitted on scenes damped as the paper's rig. Measured at the whine scene's resonance (18,370
rpm, tests/test_precision.py): at zeta = 0.01 the advised RK4 step gave 4.6 times the expected
error, RK5 1.9 times, both within the warning's bound zeta_cal / zeta = 19.5; at zeta = 0.001,
22 and 11 times (bound 195). (With the constants fitted at 3000-12000 rpm before 27 Nov 2026:
7.3 and 4.1 times at zeta = 0.01, 113 at 0.001.) Far below the resonance the error hardly
depends on zeta (the linear oscillator's, closed form: within a factor of about 2 from zeta = 0.01 to
0.2 at r = 0.05), but the harmonics' resonances at r = 1/n are resonances too, so the warning
does not depend on the speeds, except through the decay near a parametric resonance of k(t)
(``free_decay``: zeta is then the damping ratio of the slowest decay)."""
ACCURACY_NOTE = 0.05
"""``gearsweep validate`` notes a study whose own steps give an expected trajectory error
(this model's bound, at the lowest speed) above this fraction of the amplitude: RK4 at 8 steps
per mesh period was 20-40 % off without a word (an outside tester). Every study of studies/ is
below 1 % (0.75 % the most, studies/rattle_table1_pair.yaml; tests/test_precision.py); the
bound can overestimate far
below resonance (docs/precision.md), which the note says."""
PARAMETRIC_REACH = 4.0
"""A varying stiffness k(t) = k0 + sum k_j cos(...) multiplies the response, so the response
carries orders beyond the excitation's (order 1 forcing: 2, 3, ... at about (eps / 2)^(j - 1) of
it, eps = sum |k_j| / k0), and each resonates at r = 1 / j. The error model takes as its highest
order n_eff = max(n, 1 + PARAMETRIC_REACH eps). Fitted (27 Nov 2026) on a whine scene with one
stiffness harmonic of order 1 and one STE harmonic (n = 1): k1 / k0 = 0.1-0.8, zeta 0.195 and
0.078, 2000-27000 rpm every 1000 and 40000, 44000 rpm, RK4 and RK5 at the advised steps for
targets 1e-2 to 1e-8; 3 left a case at 1.33 times the bound, 4 all within 0.97 of it. Without it
(n = 1) the measured error reached 26 times the expected one (k1 = 0.7 k0, zeta 0.078, 4000 rpm,
RK5, target 1e-2): 10.6 times the light-damping bound (docs/precision.md)."""
KINK_COST = 1.5
"""Wall time of a kink-aware step over a plain one on a rattle batch: 1.43-1.53 on benchmark B2
(``scripts/bench_kink.py``, docs/precision.md); fewer crossings per step cost less."""


def stability_polynomial(method: str) -> np.ndarray:
    """Coefficients (ascending powers of z = h lambda) of the stability function R(z) of the
    kernel's method, as floats (derived from its tableau in ``gearsweep.kernels.tableaux``)."""
    if method not in tableaux.KERNEL_METHODS:
        raise ValueError(f"method must be one of {', '.join(tableaux.KERNEL_METHODS)}, got {method!r}")
    return np.array([float(c) for c in tableaux.stability_polynomial(method)])


@cache
def stability_limit(method: str, zeta: float) -> float:
    """Largest h omega_n [1] for which |R(h lambda)| <= 1 at the poles lambda / omega_n =
    -zeta +- sqrt(zeta^2 - 1) of the oscillator at damping ratio ``zeta`` >= 0: below 1 the first
    crossing of 1 along the ray of the complex pair, from 1 on the faster real pole's,
    3.386 / (zeta + sqrt(zeta^2 - 1)) for RK5 (``gearsweep.analysis.stability.step_limit_hw``,
    the one computation of it; the over-damped case raised here, and ``advise`` took zeta 0.999,
    3.388 for RK5 at zeta 1.56 where 1.226 holds: an outside tester's run diverged)."""
    if not zeta >= 0.0:
        raise ValueError(f"damping ratio must be >= 0, got {zeta}")
    stability_polynomial(method)  # the method check
    return float(step_limit_hw(method, zeta))


def worst_stability_limit(method: str, omega_n: float, mass, k_max, damping
                          ) -> tuple[float, float]:
    """(The largest h omega_n [1] stable at every case, the damping ratio of the case that sets
    it): each case (``mass`` [kg], largest stiffness ``k_max`` [N/m], ``damping`` [N s/m],
    broadcast together) is stable for h < ``stability_limit`` at its zeta over its own omega_n,
    taken here as h ``omega_n``: the limit ``advise`` states. Whether a step is within it,
    case by case, is ``stability.frozen_step_ok``'s, the step guard's frozen rule."""
    m, k, c = (np.ravel(x).astype(float) for x in np.broadcast_arrays(mass, k_max, damping))
    wn = np.sqrt(k / m)
    zeta = c / (2.0 * m * wn)
    hw = np.asarray(step_limit_hw(method, zeta), dtype=float) * omega_n / wn
    i = int(np.argmin(hw))
    return float(hw[i]), float(zeta[i])


def _beyond_text(spp: int, hw: float, rpm: float, method: str, limit: float, varying: bool,
                 map_check: tuple[float, bool, bool] | None) -> str:
    """``advise``'s warning for a written step beyond the frozen-coefficient limit: "diverges"
    where the frozen rule is exact (constant stiffness) or the map diverges (``map_check``)."""
    head = (f"{spp} steps per period give h omega_n = {hw:.3f} at {rpm:.0f} rpm, beyond the"
            f" {method} stability limit {limit:.3f}")
    if not varying:  # (constant stiffness: the map's multiplier is |R(h lambda)|^N)
        return head + ": the integration diverges there whatever the physics."
    head += (", the frozen-coefficient limit at the stiffest instant of the mesh cycle (k0 +"
             " sum |k_n|), a conservative check where k(t) varies")
    if map_check is None:
        return (head + "; the stepping map over the mesh cycle was not checked here (the step"
                " guard's map check: docs/stability.md).")
    mu, diverges, integrator = map_check
    if diverges and integrator:
        return (head + f"; the stepping map over the mesh cycle diverges too (multiplier"
                f" {mu:.4g} per mesh period): the integration diverges there whatever the"
                " physics.")
    if diverges:
        return (head + f"; the stepping map over the mesh cycle diverges (multiplier {mu:.4g}"
                " per mesh period) where the equation itself does (a parametric resonance of"
                " k(t)).")
    return (head + f", but the stepping map over the mesh cycle is stable (multiplier"
            f" {mu:.4g} per mesh period): results at this step are not guaranteed accurate;"
            " the accuracy advice says what step the target needs.")


def effective_order(k0: float, k_harmonics, highest_order: float) -> float:
    """n_eff = max(n, 1 + PARAMETRIC_REACH sum |k_j| / k0): the highest order the error model
    takes, ``highest_order`` n (at least 1) raised for the orders a varying stiffness adds."""
    variation = sum(abs(a) for a, _, _ in k_harmonics) / k0
    return max(1.0, float(highest_order), 1.0 + PARAMETRIC_REACH * variation)


FLOQUET_HW = 0.25
"""Step (h omega_n) of the RK5 map whose monodromy gives ``free_decay``'s multipliers; speeds
that would need more than ``FLOQUET_STEPS`` steps per cycle for it are left out."""
FLOQUET_STEPS = 4096
DECAY_MARGIN = 0.99
"""The light-damping warning takes the decay that ``free_decay`` finds where it is below this
fraction of zeta (the RK5 map's own error, relative 1e-5 or less against the converged
multipliers of ``kernels.floquet``, does not move it)."""


def free_decay(mass: float, k0: float, damping: float, k_harmonics, omega) -> np.ndarray:
    """Largest Floquet multiplier |mu| per mesh period [1] of the free equation
    m p'' + c p' + k(t) p = 0 at each mesh angular frequency ``omega`` [rad/s] (k(t) = k0 +
    sum k_j cos(j Omega t + phi_j): the equation in contact), from the monodromy of an RK5 map
    at h omega_n <= ``FLOQUET_HW`` over the cycle of the stiffness orders; NaN where that would
    take more than ``FLOQUET_STEPS`` steps. |mu| = exp(-zeta omega_n T) without a parametric
    resonance (complex multipliers, det M = exp(-c T / m)); larger near and in a tongue."""
    from fractions import Fraction

    omega = np.atleast_1d(np.asarray(omega, dtype=float))
    cycle = math.lcm(*(Fraction(float(o)).limit_denominator(1000).denominator
                       for _, o, _ in k_harmonics))
    k_ref = max(abs(a) for a, _, _ in k_harmonics)
    k_max = k0 + sum(abs(a) for a, _, _ in k_harmonics)
    w = omega / cycle  # Mathieu time: one cycle is 2 pi
    out = np.full(omega.shape, np.nan)
    ok = 2.0 * math.pi * math.sqrt(k_max / mass) / w <= FLOQUET_HW * FLOQUET_STEPS
    if not ok.any():
        return out
    steps = math.ceil(2.0 * math.pi * math.sqrt(k_max / mass) / (w[ok].min() * FLOQUET_HW))
    harmonics = ([a / k_ref for a, _, _ in k_harmonics],
                 [round(float(o) * cycle) for _, o, _ in k_harmonics],
                 [ph for _, _, ph in k_harmonics])
    wk = w[ok]
    M = tableau_monodromy(k0 / (mass * wk**2), k_ref / (mass * wk**2), damping / (mass * wk),
                          steps, "rk5", harmonics)
    out[ok] = largest_multiplier(M) ** (1.0 / cycle)
    return out


@cache
def _free_decay(mass, k0, damping, k_harmonics: tuple, omega: tuple) -> np.ndarray:
    """``free_decay`` once per scene (``advise`` calls itself for the kink-aware step)."""
    mu = free_decay(mass, k0, damping, k_harmonics, omega)
    mu.flags.writeable = False  # (shared by the callers of the cache)
    return mu


def load_constants(path: Path = CONSTANTS_FILE) -> dict:
    """The measured error constants and their provenance."""
    return json.loads(Path(path).read_text())


def model_error(constant: float, order: float, knee: float | None, h_omega_n: float,
                ratio: float, highest_order: float = 1.0) -> float:
    """The error model's bound C (h omega_n max(1, r))^p min(1, (n r / knee)^2) [1] for the step
    h omega_n, r = Omega / omega_n and the scene's highest harmonic order n (``knee`` None: no
    reduction below the resonance). A knee above n is taken as n, so that the reduction ends at
    the resonance r = 1 at the latest (else the bound would grow with speed above it)."""
    if not knee:
        return constant * (h_omega_n * max(1.0, ratio)) ** order
    sensitivity = min(1.0, (highest_order * ratio / min(knee, highest_order)) ** 2)
    return constant * (h_omega_n * max(1.0, ratio)) ** order * sensitivity


@dataclass(frozen=True)
class Advice:
    """Result of ``advise`` (see there)."""

    method: str
    kink_aware: bool
    scene_kind: str
    target: float
    steps_per_period: int
    h_omega_n: float
    expected_error: float
    stability_limit: float
    msteps: float
    order: float
    constant: float
    omega_n: float
    zeta: float
    ratio: float = math.nan
    """r = Omega / omega_n at the lowest speed (mesh angular frequency over omega_n)."""
    knee: float | None = None
    """The error model's knee in n r (None: none)."""
    highest_order: float = 1.0
    """n_eff: the highest harmonic order of the scene's excitation (at least 1), raised for
    the orders a varying stiffness adds (``effective_order``)."""
    chosen: int | None = None
    chosen_error: float | None = None
    kink_steps_per_period: int | None = None
    """For a plain step on a backlash scene: the steps per period the kink-aware step needs
    for the same target (None otherwise)."""
    kink_msteps: float | None = None
    warnings: list[str] = field(default_factory=list)
    varying_stiffness: bool = False
    """The scene's stiffness varies (k(t): a gear pair's steps between one and two tooth pairs
    in contact), which makes the response ring at omega_n (``report``: the extremes)."""
    limit_zeta: float = math.nan
    """The damping ratio of the case whose stability limit binds (``worst_stability_limit``;
    ``zeta`` unless the study sweeps the damping, mass or stiffness)."""
    decay_zeta: float = math.nan
    """The damping ratio that the slowest free decay among the speeds corresponds to (zeta
    itself unless k(t) slows it, near a parametric resonance: ``free_decay``); the light-damping
    warning compares this one with the calibration's."""
    scene: str | None = None
    """What ``report`` names the case by default (``"full scene with backlash"``: a study's
    advice, ``study.advice``); None: the calibration class (``"rattle case"``)."""
    study_name: str | None = None
    """The study advised on (its path, ``<dict>``, ...), which ``str`` heads the report with."""

    def __str__(self) -> str:
        """The report as ``gearsweep advise`` prints it: the study's name and a colon, then the
        report indented by two spaces (the report alone where no study is named)."""
        if self.study_name is None:
            return self.report()
        return f"{self.study_name}:\n" + textwrap.indent(self.report(), "  ")

    def _knee_text(self) -> str:
        return (f" min(1, ({self.highest_order:g} r / {self.knee:g})^2)" if self.knee
                else "")

    def _limit_text(self) -> str:
        if math.isnan(self.limit_zeta) or math.isclose(self.limit_zeta, self.zeta, rel_tol=1e-9):
            return ""
        return (f" (at every swept case; the one at damping ratio {self.limit_zeta:.3f}"
                " sets it)")

    def report(self, scene: str | None = None, width: int = 96) -> str:
        """A few lines of at most ``width`` characters for a person. ``scene`` names the case
        (e.g. ``"full scene with backlash"``; default: ``self.scene``, else the calibration
        class, whine or rattle)."""
        name = self.method + (" kink-aware" if self.kink_aware else "")
        what = scene or self.scene or f"{self.scene_kind} case"
        lines = [
            (f"{what}, {name} (error constants of the {self.scene_kind} calibration): at the"
             f" largest stiffness k0 + sum |k_n|, omega_n = {self.omega_n:.4g} rad/s and damping"
             f" ratio {self.zeta:.3f}; the method is stable for h omega_n <"
             f" {self.stability_limit:.3f}{self._limit_text()}."),
        ]
        if self.chosen is not None:
            lines.append(f"As written: {self.chosen} steps per mesh period, expected trajectory"
                         f" error {self.chosen_error:.1e} of the amplitude.")
        lines.append(
            f"For a target of {self.target:.1e}: {self.steps_per_period} steps per mesh period"
            f" (h omega_n = {self.h_omega_n:.3g} at the lowest speed, expected error"
            f" {self.expected_error:.1e} from err <= {self.constant:.3g} (h omega_n max(1, r))^"
            f"{self.order:g}{self._knee_text()} with r = Omega / omega_n = {self.ratio:.3g}),"
            f" {self.msteps:.3g} Msteps.")
        # An extreme taken on the step grid lies within half a step, T / (2 N), of the true one,
        # where p' = 0: there m p'' = -k(t) (p - p_qs), p_qs = e(t) + F_m / k(t) the quasi-static
        # deflection, and the sample is low by p'' (T / 2N)^2 / 2 = (pi q / N)^2 / 2 |p - p_qs|
        # with q = omega_n / Omega (omega_n at the largest stiffness). A line at the mesh order
        # has |p - p_qs| = r^2 of its amplitude: (pi / N)^2 / 2 of it. Impacts and the steps of
        # a gear pair's k(t) make p ring about p_qs with about the amplitude: (pi q / N)^2 / 2
        # of that (an outside tester's 27/41 pair at 2000 rpm, q = 7.4, N = 248: p_pp off by
        # 2.5e-3 of the amplitude, where 8.0e-5 was said; tests/test_precision.py).
        sampled = (math.pi / self.steps_per_period) ** 2 / 2
        line = (f"The target is the trajectory's (and p_rms's) error; p_max and p_min are taken"
                f" on the step grid and can each be off by up to (pi/N)^2/2 of the amplitude"
                f" (p_pp/2; p_pp by twice that) = {sampled:.1e} at N = {self.steps_per_period}"
                f" steps per mesh period")
        ring = 1.0 / self.ratio if self.ratio > 0 else math.inf
        cause = ("impacts" if self.scene_kind == "rattle" else
                 "the steps of k(t)" if self.varying_stiffness else None)
        if cause and ring > 1.0:
            ringing = (math.pi * ring / self.steps_per_period) ** 2 / 2
            line += (f" for a line at the mesh order, and up to (pi q/N)^2/2 = {ringing:.1e} of"
                     f" the ringing's own amplitude where the ringing after {cause}, at order"
                     f" q = omega_n / Omega = {ring:.3g}, sets the extremes")
        lines.append(line + ".")
        lines += [f"WARNING: {w}" for w in self.warnings]
        return "\n".join(textwrap.fill(line, width, subsequent_indent="  ") for line in lines)


def advise(
    *,
    mass: float,
    k0: float,
    damping: float,
    speed_rpm,
    teeth: int,
    k_harmonics=(),
    highest_order: float | None = None,
    backlash: float | None = None,
    method: str = "rk4",
    kink_aware: bool = False,
    target: float = 1e-6,
    steps_per_period: int | None = None,
    periods: int = 200,
    constants: dict | None = None,
    cases_per_speed: float = 1.0,
    multiple: int = 8,
    free_vibration: bool = True,
    stability_cases=None,
    map_check: tuple[float, bool, bool] | None = None,
) -> Advice:
    """Steps per mesh period for a target accuracy, the cost, and stability warnings.

    Parameters
    ----------
    mass : float
        Equivalent mass m_eq [kg].
    k0 : float
        Mean mesh stiffness [N/m].
    damping : float
        Mesh viscous damping c [N s/m].
    speed_rpm : array_like
        Speeds of the study [rpm] (of the gear with ``teeth`` teeth); the lowest sets the step.
    teeth : int
        Teeth of that gear (mesh frequency = teeth * rpm / 60).
    k_harmonics : sequence of (amplitude [N/m], order, phase [rad])
        Stiffness harmonics; omega_n uses the largest stiffness k0 + sum |k_n|.
    highest_order : float or None
        The highest order among the scene's stiffness, STE and force harmonics (default: that
        of ``k_harmonics``); at least 1 is taken. Its resonance, at r = 1 / n, ends the error
        model's reduction far below the resonance.
    backlash : float or None
        Total backlash [m]; selects the rattle error constants.
    method : {"rk4", "rk5"}
    kink_aware : bool
        Kink-aware stepping (matters only with backlash).
    target : float
        Trajectory error relative to the response amplitude [1].
    steps_per_period : int or None
        A step count already chosen: its expected error is reported, with warnings if it misses
        the target or is unstable.
    periods : int
        Mesh periods integrated per speed (transient + record), for the cost.
    constants : dict or None
        Error constants (default: ``load_constants()``).
    cases_per_speed : float
        Cases the study runs at each speed (its other swept parameters, both directions of a
        continued sweep), for the cost: a study's ``n_cases / len(speeds)``.
    multiple : int
        The advised steps per period is a multiple of this (8; a study whose outputs sample p
        at a fixed number of points per period needs a multiple of that too).
    free_vibration : bool
        Look for speeds where k(t) slows the free vibration's decay or makes it grow
        (``free_decay``: a monodromy per speed, about 1.4 s for a scene of 56 stiffness
        harmonics), for the light-damping and instability warnings. False: only the steps and
        errors (the warnings assume the damping's own decay), as ``validate``'s accuracy note.
    stability_cases : (mass [kg], largest stiffness [N/m], damping [N s/m]) or None
        The cases the step must be stable at, arrays broadcast together (a study's swept mass,
        stiffness k0 + sum |k_n| and damping: the limit is not monotonic in the damping ratio,
        and above zeta = 1 a smaller stiffness has the faster pole); the limit is the smallest
        over them (``worst_stability_limit``). Default: (mass, k0 + sum |k_n|, damping).
    map_check : (float, bool, bool) or None
        Where ``steps_per_period`` fails the frozen-coefficient rule (the stability polynomial
        at the stiffest instant, k0 + sum |k_n|: conservative where k(t) varies), the step
        guard's check of the fixed-step map over the mesh cycle at the cases it fails
        (``stability.map_step_check``; ``study.plan.frozen_map_check`` for a study): the
        largest |mu| per mesh period, whether a case's map diverges (|mu| > 1 + tol) and
        whether one diverges where the equation does not. The warning says "diverges" only
        where the map does. None: not checked (with constant stiffness the frozen rule is
        the map's; with a varying one the warning says the map was not checked).

    Returns
    -------
    Advice
    """
    stability_polynomial(method)  # the method check
    if not target > 0:
        raise ValueError(f"target must be positive, got {target}")
    speeds = np.atleast_1d(np.asarray(speed_rpm, dtype=float))
    if np.any(speeds <= 0):
        raise ValueError("speeds must be positive")
    k_max = k0 + sum(abs(a) for a, _, _ in k_harmonics)
    wn = math.sqrt(k_max / mass)
    zeta = damping / (2.0 * mass * wn)
    omega_min = 2.0 * math.pi * teeth * speeds.min() / 60.0
    kind = "rattle" if backlash is not None else "whine"
    key = f"{kind}/{method}" + ("-kink" if kink_aware and kind == "rattle" else "")
    table = (constants or load_constants())["constants"][key]
    C, p, knee = table["C"], table["order"], table.get("knee")
    r = omega_min / wn
    if highest_order is None:
        highest_order = max((float(o) for _, o, _ in k_harmonics), default=1.0)
    n = effective_order(k0, k_harmonics, highest_order)
    hw_target = (target / (SAFETY * model_error(C, p, knee, 1.0, r, n))) ** (1.0 / p)
    cases = (mass, k_max, damping) if stability_cases is None else stability_cases
    limit, limit_zeta = worst_stability_limit(method, wn, *cases)
    warnings = []
    hw = min(hw_target, 0.9 * limit)
    spp = int(multiple * math.ceil(2.0 * math.pi * wn / (omega_min * hw) / multiple - 1e-9))
    hw_adv = 2.0 * math.pi * wn / (omega_min * spp)
    msteps = len(speeds) * cases_per_speed * periods * spp / 1e6
    chosen_err = None
    if steps_per_period is not None:
        hw_c = 2.0 * math.pi * wn / (omega_min * steps_per_period)
        chosen_err = model_error(C, p, knee, hw_c, r, n)
        m_c, k_c, c_c = (np.ravel(x).astype(float) for x in np.broadcast_arrays(*cases))
        h_c = 2.0 * math.pi / (omega_min * steps_per_period)  # the step guard's rule, its
        if not np.all(frozen_step_ok(method, h_c, k_c / m_c, c_c / m_c)):  # function
            warnings.append(_beyond_text(steps_per_period, hw_c, float(speeds.min()), method,
                                         limit, bool(k_harmonics), map_check))
        elif chosen_err > target:
            warnings.append(
                f"{steps_per_period} steps per period miss the target ({chosen_err:.1e} > "
                f"{target:.1e}).")
    zeta_cal = (constants or load_constants()).get("calibration_damping_ratio", {}).get(kind)
    decay, unstable = zeta, ""
    if k_harmonics and free_vibration:
        # near a parametric tongue the free vibration decays slower than c alone gives
        rpm = np.unique(speeds)
        mu = _free_decay(mass, k0, damping, tuple(map(tuple, k_harmonics)),
                         tuple(2.0 * math.pi * teeth * rpm / 60.0))
        bad = mu > 1.0 + UNSTABLE_TOL
        if bad.any():
            unstable = (f"at {bad.sum()} of the {rpm.size} speeds ({rpm[bad].min():.0f}-"
                        f"{rpm[bad].max():.0f} rpm) k(t) makes the equation itself unstable"
                        f" (Floquet multiplier up to {np.nanmax(mu):.4g} per mesh period, a"
                        " parametric resonance): there the response in contact grows without"
                        " bound and the error model does not hold")
        stable = np.isfinite(mu) & ~bad
        if stable.any():
            w = 2.0 * math.pi * teeth * rpm[stable] / 60.0
            slowest = -np.log(np.maximum(mu[stable], 1e-300)) * w / (2.0 * math.pi * wn)
            if slowest.min() < DECAY_MARGIN * zeta:
                decay = max(0.0, float(slowest.min()))  # (|mu| within 1 + UNSTABLE_TOL)
                at = float(rpm[stable][np.argmin(slowest)])
    if zeta_cal and decay < LIGHT_DAMPING * zeta_cal:
        bound = (f"up to about {zeta_cal / decay:.0f} times the expected error" if decay > 0
                 else "without bound (undamped)")
        what = (f"damping ratio {zeta:.3g} is" if decay == zeta else
                f"the free vibration decays at {at:.0f} rpm as at damping ratio {decay:.3g}"
                f" (near a parametric resonance of k(t); damping ratio {zeta:.3g}),")
        warnings.append(
            f"{what} far below the calibration's {zeta_cal:.2f}: near a resonance the error"
            f" grows about as 1 / zeta, {bound}; check with a run at twice the steps.")
    if unstable:
        warnings.append(unstable + ".")
    kink_spp = kink_msteps = None
    if kind == "rattle" and not kink_aware:
        alt = advise(mass=mass, k0=k0, damping=damping, speed_rpm=speeds, teeth=teeth,
                     k_harmonics=k_harmonics, highest_order=n, backlash=backlash,
                     method=method, kink_aware=True,
                     target=target, periods=periods, constants=constants,
                     cases_per_speed=cases_per_speed, multiple=multiple,
                     free_vibration=free_vibration, stability_cases=stability_cases)
        kink_spp, kink_msteps = alt.steps_per_period, alt.msteps
        warnings.append(
            f"with backlash the plain step converges only as h^2; kink-aware stepping "
            f"(solver.kink_aware: true) restores order {alt.order:g} and needs {kink_spp} steps "
            f"per period ({kink_msteps:.3g} Msteps) for the same target, each step costing up to "
            f"about {KINK_COST:g} times a plain one.")
    return Advice(method, kink_aware, kind, target, spp, hw_adv,
                  model_error(C, p, knee, hw_adv, r, n), limit, msteps, p, C, wn, zeta, r, knee, n,
                  steps_per_period, chosen_err, kink_spp, kink_msteps, warnings,
                  bool(k_harmonics), limit_zeta, decay)

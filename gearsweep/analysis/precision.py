"""Error of the fixed-step kernels and of scipy's adaptive solvers against a reference solution.

Error measures, both relative to the reference amplitude A = (max - min) / 2 of p over the window
and both taken at common instants (``SAMPLES_PER_PERIOD`` per mesh period, the same for every
step size, so that they measure integration error and not sampling error):

``trajectory_error``
    max |p - p_ref| over the window / A.
``amplitude_error``
    |A - A_ref| / A_ref, with A from the same samples.

The window is the last ``record_periods`` of ``transient_periods + record_periods`` mesh periods,
integrated from the same initial state as the reference.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from gearsweep.analysis.reference import PiecewiseSolution, reference_exact, reference_ivp
from gearsweep.kernels import rk
from gearsweep.kernels.batch import simulate
from gearsweep.model import PAPER_RIG, Scene, gear_scene, mesh_frequency

SAMPLES_PER_PERIOD = 8
"""Common sampling instants per mesh period (the coarsest step studied, 8 per period)."""


@dataclass(frozen=True)
class Window:
    """Integration length and the recorded window [mesh periods]."""

    transient_periods: int = 40
    record_periods: int = 20

    @property
    def periods(self) -> int:
        return self.transient_periods + self.record_periods


def sample_times(scene: Scene, window: Window) -> np.ndarray:
    """Common sampling instants of the window [s]."""
    n0 = window.transient_periods * SAMPLES_PER_PERIOD
    n1 = window.periods * SAMPLES_PER_PERIOD
    return np.arange(n0 + 1, n1 + 1) * scene.period / SAMPLES_PER_PERIOD


def reference(scene: Scene, window: Window, exact: bool | None = None) -> PiecewiseSolution:
    """The reference solution from p = p' = 0: exact piecewise-analytic for constant stiffness
    (unless ``exact=False``), DOP853 with crossing events otherwise."""
    t_end = window.periods * scene.period
    if exact is None:
        exact = not scene.k_harmonics
    if exact:
        return reference_exact(scene, t_end)
    return reference_ivp(scene, t_end)


def errors(p: np.ndarray, p_ref: np.ndarray) -> tuple[float, float]:
    """(trajectory_error, amplitude_error) of samples ``p`` against ``p_ref`` [1]."""
    a_ref = 0.5 * (p_ref.max() - p_ref.min())
    if not np.all(np.isfinite(p)):
        return math.nan, math.nan
    a = 0.5 * (p.max() - p.min())
    return float(np.max(np.abs(p - p_ref)) / a_ref), float(abs(a - a_ref) / a_ref)


@dataclass(frozen=True)
class Run:
    """One integration: errors [1] and costs."""

    trajectory_error: float
    amplitude_error: float
    seconds: float
    """Wall time per case [s]."""
    rhs_evaluations: float
    """Right-hand-side evaluations per case."""


def fixed_call(scene: Scene, method: str, steps_per_period: int, kink_aware: bool = False,
               copies: int = 64) -> dict:
    """The ``simulate`` keyword arguments (without step counts) of ``run_fixed``'s call:
    ``copies`` cases of ``scene``, a sample recorded every ``steps_per_period /
    SAMPLES_PER_PERIOD`` steps (what ``analysis_cost`` asks Numba's cache for)."""
    kw = scene.kernel_kwargs(int(steps_per_period))
    kw["h"] = np.repeat(kw["h"], copies)
    return dict(kw, method=method, kink_aware=kink_aware,
                signal_stride=int(steps_per_period) // SAMPLES_PER_PERIOD)


def run_fixed(scene: Scene, method: str, steps_per_period: int, window: Window, p_ref: np.ndarray,
              *, kink_aware: bool = False, copies: int = 64, repeat: int = 3) -> Run:
    """Integrate ``copies`` identical cases with the batch kernel and measure error and cost.

    The wall time is the best of ``repeat`` calls divided by ``copies`` (a batch is how the kernel
    is used; a lone case would time the call overhead). ``steps_per_period`` must be a multiple of
    ``SAMPLES_PER_PERIOD``.
    """
    spp = int(steps_per_period)
    stride = spp // SAMPLES_PER_PERIOD
    kw = fixed_call(scene, method, spp, kink_aware, copies)
    n_tr = window.transient_periods * spp
    best = math.inf
    res = None
    for _ in range(repeat):
        t0 = time.perf_counter()
        # record from the step that ends at the first sampling instant of the window
        res = simulate(n_transient=n_tr + stride - 1,
                       n_record=window.record_periods * spp - stride + 1, **kw)
        best = min(best, time.perf_counter() - t0)
    p = res.signal[0]
    e_traj, e_amp = errors(p, p_ref)
    if res.status[0] != rk.STATUS_OK:
        e_traj = e_amp = math.nan
    stages = rk.STAGES[rk.METHODS[method]]
    steps = window.periods * spp
    sub = 0.0 if res.substeps is None else float(res.substeps[0])
    return Run(e_traj, e_amp, best / copies, stages * (steps + sub))


def run_scipy(scene: Scene, method: str, rtol: float, window: Window, p_ref: np.ndarray) -> Run:
    """Integrate with ``solve_ivp`` as a user would: the dead zone in the right-hand side, no
    events, ``atol = rtol * response scale``, output at the sampling instants by the solver's
    dense output."""
    from scipy.integrate import solve_ivp  # heavy: loaded only where a peer runs

    b = scene.half_gap
    w = scene.omega
    km, cm, gm = scene.k_mean, scene.damping, scene.g_mean
    kh = [(a, r * w, ph) for a, r, ph in scene.k_harmonics]
    gh = [(a, r * w, ph) for a, r, ph in scene.g_harmonics]
    cos = math.cos

    def rhs(t, y):
        x, v = y
        k = km
        for a, ww, ph in kh:
            k += a * cos(ww * t + ph)
        g = gm
        for a, ww, ph in gh:
            g += a * cos(ww * t + ph)
        f = x
        if b is not None:
            f = x - b if x > b else (x + b if x < -b else 0.0)
        return [v, g - cm * v - k * f]

    scale = scene.response_scale()
    atol = [rtol * scale, rtol * scale * scene.omega_n]
    ts = sample_times(scene, window)
    t0 = time.perf_counter()
    r = solve_ivp(rhs, (0.0, ts[-1]), [0.0, 0.0], method=method, rtol=rtol, atol=atol, t_eval=ts)
    seconds = time.perf_counter() - t0
    if not r.success:
        return Run(math.nan, math.nan, seconds, float(r.nfev))
    e_traj, e_amp = errors(r.y[0], p_ref)
    return Run(e_traj, e_amp, seconds, float(r.nfev))


def fit_order(steps_per_period, err, lo: float = 1e-10, hi: float = 1e-2) -> float:
    """Convergence order: minus the least-squares slope of log(err) against log(steps per
    period), over the points with ``lo < err < hi`` (the asymptotic range above the reference's
    floor); NaN with fewer than three such points."""
    s = np.asarray(steps_per_period, dtype=float)
    e = np.asarray(err, dtype=float)
    ok = np.isfinite(e) & (e > lo) & (e < hi)
    if ok.sum() < 3:
        return math.nan
    return float(-np.polyfit(np.log(s[ok]), np.log(e[ok]), 1)[0])


# --------------------------------------------------------------------------- the two scenes

MASS = PAPER_RIG.mass
"""Equivalent mass of the paper's Fig. 6 [kg]."""
DAMPING = PAPER_RIG.damping
"""Mesh damping of the paper's Fig. 6, 5.5 N s/mm [N s/m]."""
K0 = PAPER_RIG.stiffness
"""Mean mesh stiffness of Fig. 7.2 [N/m]."""
K_HARMONICS = ((PAPER_RIG.stiffness_harmonics[0].amplitude, 1, 0.0), (40e6, 2, 0.0), (10e6, 3, 0.0))
"""Stiffness harmonics (k1 of Fig. 7.2; k2, k3 as benchmark B1) [N/m]."""
STE_HARMONICS = ((5e-6, 1, 0.0), (1e-6, 2, 0.0), (0.3e-6, 3, 0.0))
"""STE harmonics of benchmark B1 [m]."""
FORCE = PAPER_RIG.mean_force
"""Mean mesh force, 50 N m on the 60 mm pitch radius [N]."""
TEETH = PAPER_RIG.teeth
"""Teeth of the gear whose speed is given."""


def whine_scene(rpm: float = 6000.0, *, damping: float = DAMPING, k0: float = K0) -> Scene:
    """Smooth scene: time-varying stiffness and STE, no backlash (Eq. 9)."""
    return gear_scene(mass=MASS, damping=damping, k0=k0, mesh_frequency=float(mesh_frequency(rpm, TEETH)),
                      k_harmonics=K_HARMONICS, ste_harmonics=STE_HARMONICS, force=FORCE)


def rattle_scene(rpm: float = 9000.0, *, damping: float = DAMPING, k0: float = K0,
                 backlash: float = 4e-6) -> Scene:
    """Rattle scene: constant stiffness, first STE harmonic, backlash (Eq. 13); at 9000 rpm the
    teeth leave contact and strike the back flank four times per mesh period."""
    return gear_scene(mass=MASS, damping=damping, k0=k0, mesh_frequency=float(mesh_frequency(rpm, TEETH)),
                      ste_harmonics=STE_HARMONICS[:1], force=FORCE, backlash=backlash)

"""The compiled peers on the work-precision chart: the same batches of cases run by gearsweep's
fixed-step kernels and by the solvers a numerical engineer would pick instead (issue 25).

A *batch* is one scene of ``gearsweep.analysis.precision`` (whine, rattle) or benchmark problem B1
at many speeds spread evenly over the scene's range. Every runner returns the displacement p at
the common sampling instants of ``precision.sample_times`` for every case of the batch, the wall
time of the whole batch (all cores; compilation excluded and measured separately) and the
right-hand-side evaluations per case; ``errors_of`` measures them against the reference of
``precision.reference`` with ``precision.errors`` (the error measure of the work-precision chart).

Peers (all optional: each is imported inside its runner, none is a dependency of gearsweep):

``numbalsoda``
    LSODA (and DOP853) from inside a Numba ``prange`` loop over the cases, the right-hand side a
    ``cfunc``; what a Numba user writes. With events (scenes with backlash): its ``solve_ivp``
    (DOP853, a terminal event with a Brent root find) stopped at each backlash crossing and
    restarted on the next piece (``run_numbalsoda_events``).
``diffrax``
    JAX, ``vmap`` over the cases, Tsit5 / Dopri5 / Dopri8 with ``PIDController``; on the CPU.
    With events (scenes with backlash): ``diffrax.Event`` with an ``optimistix`` root finder at
    each crossing, restarted in a ``lax.while_loop`` (``diffrax_event_solver``).
``sksundae``
    SUNDIALS CVODE (scikit-sundae), Adams, the right-hand side a Python function.
``scipy``
    ``solve_ivp`` exactly as ``precision.run_scipy`` (one case at a time, Python right-hand side).

All peers integrate the same equation in scaled variables, x = p / s, u = p' / (s omega_n) with
s = ``Scene.response_scale()``, with ``atol = rtol``: the same tolerances as
``precision.run_scipy`` (atol = rtol s for p and rtol s omega_n for p'). The dead zone sits in the
right-hand side (no events): f(p) = p - clip(p, -b, b), b = 0 without backlash; the events
variants integrate one linear piece of it at a time (f = |r| (p - r b), contact state r).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from gearsweep.analysis import precision as pr
from gearsweep.kernels import rk
from gearsweep.kernels.batch import simulate
from gearsweep.model import Scene

# columns of the per-case parameter matrix
W, C, KM, K1, K2, K3, G0, G1, G2, G3, B, S, WN, NFEV = range(14)
NPAR = 14


# --------------------------------------------------------------------------- batches


@dataclass(frozen=True)
class Batch:
    """Cases of one scene at ``n`` speeds evenly spread over [rpm_min, rpm_max]."""

    name: str
    make: Callable[[float], Scene]
    rpm_min: float
    rpm_max: float
    n: int
    window: pr.Window
    n_error: int = 24
    """Cases (evenly spread, first and last included) on which the error is measured."""

    @cached_property
    def rpm(self) -> np.ndarray:
        return np.linspace(self.rpm_min, self.rpm_max, self.n)

    @cached_property
    def scenes(self) -> list[Scene]:
        return [self.make(float(r)) for r in self.rpm]

    @cached_property
    def error_cases(self) -> np.ndarray:
        return np.unique(np.round(np.linspace(0, self.n - 1, min(self.n_error, self.n))).astype(int))

    def times(self, i: int) -> np.ndarray:
        return pr.sample_times(self.scenes[i], self.window)

    @cached_property
    def sample_times(self) -> np.ndarray:
        """(n, m) sampling instants of every case [s]."""
        return np.stack([self.times(i) for i in range(self.n)])

    @cached_property
    def params(self) -> np.ndarray:
        """(n, NPAR) parameters of the scaled right-hand side (see the module docstring)."""
        return np.stack([scene_params(s) for s in self.scenes])


def scene_params(scene: Scene) -> np.ndarray:
    """One row of ``Batch.params``: harmonics of orders 1, 2, 3 with zero phase only."""
    p = np.zeros(NPAR)
    p[W], p[C], p[KM], p[G0] = scene.omega, scene.damping, scene.k_mean, scene.g_mean
    for harmonics, first in ((scene.k_harmonics, K1), (scene.g_harmonics, G1)):
        for a, r, ph in harmonics:
            if ph != 0.0 or r not in (1, 2, 3):
                raise ValueError("the peers' right-hand side takes orders 1, 2, 3 with zero phase")
            p[first + int(r) - 1] += a
    p[B] = scene.half_gap or 0.0
    p[S] = scene.response_scale()
    p[WN] = scene.omega_n
    return p


def whine_batch(n: int = 1000, **kw) -> Batch:
    """Whine scene, 3000-12000 rpm (the advisor's calibration range)."""
    return Batch("whine", pr.whine_scene, 3000.0, 12000.0, n, pr.Window(), **kw)


def rattle_batch(n: int = 1000, **kw) -> Batch:
    """Rattle scene, 7000-13000 rpm (the advisor's calibration range; contact loss)."""
    return Batch("rattle", pr.rattle_scene, 7000.0, 13000.0, n, pr.Window(), **kw)


def b1_batch(n: int = 1000, **kw) -> Batch:
    """Benchmark B1 (docs/benchmark.md): the whine scene's model at 1000-20000 rpm, 200 mesh
    periods from rest, the last 100 recorded."""
    return Batch("B1", pr.whine_scene, 1000.0, 20000.0, n, pr.Window(100, 100), **kw)


BATCHES = {"whine": whine_batch, "rattle": rattle_batch, "B1": b1_batch}


def _reference_one(args) -> np.ndarray:
    make, rpm, window = args
    scene = make(rpm)
    return pr.reference(scene, window)(pr.sample_times(scene, window))[0]


def references(batch: Batch, processes: int = 1) -> np.ndarray:
    """(len(error_cases), m) reference p at the sampling instants of the error cases [m]."""
    jobs = [(batch.make, float(batch.rpm[i]), batch.window) for i in batch.error_cases]
    if processes > 1:
        from multiprocessing import get_context

        with get_context("fork").Pool(processes) as pool:
            return np.stack(pool.map(_reference_one, jobs))
    return np.stack([_reference_one(j) for j in jobs])


# --------------------------------------------------------------------------- results


@dataclass
class BatchRun:
    """One method at one setting over a batch."""

    p: np.ndarray
    """(n_cases, m) p at the sampling instants [m]; NaN rows for failed cases."""
    seconds: float
    """Wall time of the batch (best of the repeats) [s]."""
    cases: int
    """Cases in the timed batch."""
    rhs_evaluations: np.ndarray
    """Right-hand-side evaluations of each case."""
    case_index: np.ndarray
    """Indices (into the batch) of the rows of ``p``."""
    notes: dict = field(default_factory=dict)
    seconds_median: float = math.nan
    """Median wall time of the repeats [s]."""

    @property
    def seconds_per_case(self) -> float:
        return self.seconds / self.cases


def errors_of(run: BatchRun, batch: Batch, p_ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(trajectory_error, amplitude_error) [1] of each error case that the run covers; NaN for
    the error cases it does not."""
    te = np.full(len(batch.error_cases), np.nan)
    ae = np.full(len(batch.error_cases), np.nan)
    row = {int(c): k for k, c in enumerate(run.case_index)}
    for j, c in enumerate(batch.error_cases):
        if int(c) in row:
            te[j], ae[j] = pr.errors(run.p[row[int(c)]], p_ref[j])
    return te, ae


def _timed(fn, repeat: int):
    """(last result, best wall time [s], median wall time [s]) over ``repeat`` calls. The best
    is the cost: on a shared machine a call can wait tens of milliseconds for its threads."""
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return out, float(np.min(times)), float(np.median(times))


# --------------------------------------------------------------------------- gearsweep


def gearsweep_kwargs(scenes: list[Scene], spp: int) -> dict:
    """Arguments of ``simulate`` for the cases ``scenes`` (one scene at several speeds): the
    stiffness table is shared (it does not depend on the speed), the STE forcing e_n (n W)^2
    scales with W^2 per case."""
    s0 = scenes[0]
    kw = s0.kernel_kwargs(spp)
    kw["h"] = np.array([s.period / spp for s in scenes])
    # The scene's periodic forcing (the STE term, as the Scene carries it) scales with W^2.
    w2 = (np.array([s.omega for s in scenes]) / s0.omega) ** 2
    for table, scale in (("ste_table", "ste_scale"), ("fluct_table", "fluct_scale")):
        if kw.get(table) is not None:
            kw[scale] = np.asarray(kw[scale], dtype=float) * w2
    return kw


def _gearsweep_call(scenes, window: pr.Window, method: str, spp: int, kink_aware: bool):
    stride = spp // pr.SAMPLES_PER_PERIOD
    kw = gearsweep_kwargs(scenes, spp)
    n_tr = window.transient_periods * spp
    stages = rk.STAGES[rk.METHODS[method]]

    def go():
        # record from the step that ends at the first sampling instant of the window
        res = simulate(method=method, n_transient=n_tr + stride - 1,
                       n_record=window.record_periods * spp - stride + 1,
                       signal_stride=stride, kink_aware=kink_aware, **kw)
        p = res.signal
        p[res.status != rk.STATUS_OK] = np.nan
        sub = np.zeros(len(scenes)) if res.substeps is None else np.asarray(res.substeps, float)
        return p, stages * (window.periods * spp + sub)

    return go


def run_gearsweep(batch: Batch, method: str, spp: int, *, kink_aware: bool = False,
                  repeat: int = 3) -> BatchRun:
    """gearsweep's batch kernel (``simulate``), one call over all cases at ``spp`` steps per
    mesh period (a multiple of ``precision.SAMPLES_PER_PERIOD``)."""
    go = _gearsweep_call(batch.scenes, batch.window, method, spp, kink_aware)
    (p, rhs), sec, med = _timed(go, repeat)
    return BatchRun(p, sec, batch.n, rhs, np.arange(batch.n), seconds_median=med)


def speed_bands(batch: Batch, ratio: float = 2.0) -> list[np.ndarray]:
    """Case indices split into bands of speed whose highest / lowest speed is at most
    ``ratio`` (geometric edges)."""
    nb = max(1, math.ceil(math.log(batch.rpm_max / batch.rpm_min) / math.log(ratio) - 1e-9))
    edges = batch.rpm_min * (batch.rpm_max / batch.rpm_min) ** (np.arange(nb + 1) / nb)
    band = np.clip(np.searchsorted(edges, batch.rpm, side="right") - 1, 0, nb - 1)
    return [np.nonzero(band == k)[0] for k in range(nb) if np.any(band == k)]


def run_gearsweep_banded(batch: Batch, method: str, spp: int, *, kink_aware: bool = False,
                         ratio: float = 2.0, repeat: int = 3) -> BatchRun:
    """One kernel call per speed band (``speed_bands``): ``spp`` steps per period in the band of
    the lowest speed, fewer in faster bands so that the step times omega_n is no larger than at
    the lowest speed (steps per period scaled by rpm_min / band's lowest rpm, rounded up to a
    multiple of ``precision.SAMPLES_PER_PERIOD``). Fewer steps for the fast cases; but the error
    at a given h omega_n grows with speed (measured: docs/performance.md), so the same h omega_n
    is not the same accuracy."""
    q = pr.SAMPLES_PER_PERIOD
    calls = []
    for idx in speed_bands(batch, ratio):
        s = max(q, q * math.ceil(spp * batch.rpm_min / batch.rpm[idx[0]] / q - 1e-9))
        calls.append((idx, _gearsweep_call([batch.scenes[i] for i in idx], batch.window, method, s,
                                           kink_aware)))

    def go():
        return [(idx, fn()) for idx, fn in calls]

    parts, sec, med = _timed(go, repeat)
    p = np.full(batch.sample_times.shape, np.nan)
    rhs = np.zeros(batch.n)
    for idx, (pp, rr) in parts:
        p[idx], rhs[idx] = pp, rr
    return BatchRun(p, sec, batch.n, rhs, np.arange(batch.n), seconds_median=med,
                    notes={"bands": len(calls)})


# --------------------------------------------------------------------------- numbalsoda


_NUMBALSODA: dict = {}


def _numbalsoda():
    """Compile (once) the cfunc right-hand side and the prange drivers."""
    if _NUMBALSODA:
        return _NUMBALSODA
    import numba as nb
    from numbalsoda import dop853, lsoda, lsoda_sig

    @nb.cfunc(lsoda_sig)
    def rhs(t, y, dy, d):
        x = y[0]
        u = y[1]
        th = d[0] * t
        c1, c2, c3 = math.cos(th), math.cos(2.0 * th), math.cos(3.0 * th)
        k = d[2] + d[3] * c1 + d[4] * c2 + d[5] * c3
        g = d[6] + d[7] * c1 + d[8] * c2 + d[9] * c3
        s = d[11]
        wn = d[12]
        p = s * x
        b = d[10]
        f = p - min(max(p, -b), b)
        dy[0] = wn * u
        dy[1] = (g - d[1] * s * wn * u - k * f) / (s * wn)
        d[13] += 1.0

    def make_driver(solver):
        @nb.njit(parallel=True)
        def drive(fptr, params, ts, rtol, mxstep, out, nfev):
            n = params.shape[0]
            for i in nb.prange(n):
                data = params[i].copy()
                data[13] = 0.0
                t = np.empty(ts.shape[1] + 1)
                t[0] = 0.0
                t[1:] = ts[i]
                u0 = np.zeros(2)
                usol, ok = solver(fptr, u0, t, data, rtol, rtol, mxstep)
                if ok:
                    for j in range(ts.shape[1]):
                        out[i, j] = usol[j + 1, 0] * params[i, 11]
                else:
                    for j in range(ts.shape[1]):
                        out[i, j] = np.nan
                nfev[i] = data[13]

        return drive

    _NUMBALSODA.update(rhs=rhs, LSODA=make_driver(lsoda), DOP853=make_driver(dop853))
    return _NUMBALSODA


def numbalsoda_compile(batch: Batch, solver: str = "LSODA") -> float:
    """Compile the driver on a two-case batch; returns the wall time [s]."""
    t0 = time.perf_counter()
    nb_ = _numbalsoda()
    out = np.empty((2, batch.sample_times.shape[1]))
    nb_[solver](nb_["rhs"].address, batch.params[:2], batch.sample_times[:2], 1e-3, 100000, out,
                np.empty(2))
    return time.perf_counter() - t0


def run_numbalsoda(batch: Batch, rtol: float, solver: str = "LSODA", *, repeat: int = 3) -> BatchRun:
    """numbalsoda's LSODA (or DOP853) over all cases, ``prange`` over the cases."""
    nb_ = _numbalsoda()
    out = np.empty(batch.sample_times.shape)
    nfev = np.empty(batch.n)

    def go():
        nb_[solver](nb_["rhs"].address, batch.params, batch.sample_times, rtol, 1_000_000, out,
                    nfev)

    _, sec, med = _timed(go, repeat)
    return BatchRun(out.copy(), sec, batch.n, nfev.copy(), np.arange(batch.n), seconds_median=med)


_NUMBALSODA_EVENTS: dict = {}
NUMBALSODA_EVENT_HYSTERESIS = 1e-6
"""As ``EVENT_HYSTERESIS`` for numbalsoda: its root finder stops within 1e-8 in tau, up to about
1e-8 in x, and it stops on a sign change in either direction (a restart a little outside its
piece would stop at once); the overlap's force error is of order 1e-12."""


def _numbalsoda_events():
    """Compile (once) numbalsoda's ``solve_ivp`` (DOP853 with events) driver, piece by piece as
    ``diffrax_event_solver``, in the time tau = omega_n t (its Brent root finder has a fixed
    absolute tolerance of 1e-8 in the time variable: in seconds that would be 1e-4 of a mesh
    period)."""
    if _NUMBALSODA_EVENTS:
        return _NUMBALSODA_EVENTS
    import numba as nb
    from numbalsoda import lsoda_sig, solve_ivp

    hyst = NUMBALSODA_EVENT_HYSTERESIS

    @nb.cfunc(lsoda_sig)
    def rhs(tau, y, dy, d):
        x = y[0]
        u = y[1]
        wn = d[12]
        th = d[0] * tau / wn
        c1, c2, c3 = math.cos(th), math.cos(2.0 * th), math.cos(3.0 * th)
        k = d[2] + d[3] * c1 + d[4] * c2 + d[5] * c3
        g = d[6] + d[7] * c1 + d[8] * c2 + d[9] * c3
        s = d[11]
        r = d[14]
        f = abs(r) * (s * x - r * d[10])
        dy[0] = u
        dy[1] = (g - d[1] * s * wn * u - k * f) / (s * wn * wn)

    @nb.cfunc(lsoda_sig)
    def event(tau, y, out, d):
        bx = d[10] / d[11]
        x = y[0]
        r = d[14]
        if r > 0:
            c = x - bx
        elif r < 0:
            c = -x - bx
        else:
            c = (bx - x) * (bx + x) / bx
        out[0] = c + hyst

    @nb.njit(parallel=True)
    def drive(fptr, eptr, params, ts, rtol, max_pieces, out, nfev, pieces, ok):
        n = params.shape[0]
        m = ts.shape[1]
        for i in nb.prange(n):
            data = np.zeros(16)
            data[:14] = params[i]
            wn = params[i, 12]
            taus = ts[i] * wn
            tau_end = taus[m - 1]
            tau = 0.0
            y = np.zeros(2)
            k0 = 0
            nf = 0
            good = True
            npc = 0
            while k0 < m and npc < max_pieces:  # (empty t_eval: solve_ivp saves every step)
                npc += 1
                span = np.array([tau, tau_end])
                sol = solve_ivp(fptr, span, y, taus[k0:], n_events=1, event_fcn=eptr,
                                data=data.ctypes.data, rtol=rtol, atol=rtol)
                nf += sol.nfev
                if not sol.success:
                    good = False
                    break
                nt = min(sol.t.shape[0], m - k0)
                for j in range(nt):
                    out[i, k0 + j] = sol.y[j, 0] * params[i, 11]
                k0 += nt
                if not sol.event_found:
                    break
                tau = sol.t_event
                y = sol.y_event.copy()
                side = 1.0 if y[0] > 0 else -1.0
                data[14] = side if side * y[1] > 0 else 0.0
            nfev[i] = nf
            pieces[i] = npc
            ok[i] = good and k0 == m

    _NUMBALSODA_EVENTS.update(rhs=rhs, event=event, drive=drive)
    return _NUMBALSODA_EVENTS


def run_numbalsoda_events(batch: Batch, rtol: float, *, repeat: int = 3) -> BatchRun:
    """numbalsoda's ``solve_ivp`` (DOP853) with a terminal event at each backlash crossing,
    restarted on the next piece, ``prange`` over the cases (``_numbalsoda_events``)."""
    if batch.scenes[0].half_gap is None:
        raise ValueError("the events variant is for scenes with backlash")
    e = _numbalsoda_events()
    out = np.full(batch.sample_times.shape, np.nan)
    nfev = np.zeros(batch.n)
    pieces = np.zeros(batch.n, dtype=np.int64)
    ok = np.zeros(batch.n, dtype=np.bool_)

    def go():
        e["drive"](e["rhs"].address, e["event"].address, batch.params, batch.sample_times, rtol,
                   MAX_SEGMENTS, out, nfev, pieces, ok)

    _, sec, med = _timed(go, repeat)
    p = out.copy()
    p[~ok] = np.nan
    return BatchRun(p, sec, batch.n, nfev.copy(), np.arange(batch.n), seconds_median=med,
                    notes={"pieces_max": int(pieces.max()), "pieces_mean": float(pieces.mean())})


# --------------------------------------------------------------------------- diffrax

def _scaled_rhs(jnp, t, y, d, f):
    """The batch's equation in scaled variables for diffrax: ``d`` one case's row of the
    parameter matrix (columns ``W, C, KM, K1..K3, G0..G3, B, S, WN``), ``f`` the spring's
    deflection function of p = s x (the diffrax variants differ only there)."""
    u = y[1]
    th = d[0] * t
    c1, c2, c3 = jnp.cos(th), jnp.cos(2.0 * th), jnp.cos(3.0 * th)
    k = d[2] + d[3] * c1 + d[4] * c2 + d[5] * c3
    g = d[6] + d[7] * c1 + d[8] * c2 + d[9] * c3
    s, wn = d[11], d[12]
    return jnp.stack([wn * u, (g - d[1] * s * wn * u - k * f) / (s * wn)])




DIFFRAX_SOLVERS = ("Tsit5", "Dopri5", "Dopri8")


def diffrax_solver(name: str, max_steps: int = 1 << 20):
    """A jitted ``vmap``-ed solve for ``name``: ``f(params, ts, rtol) -> (p, steps, ok)``, and
    the RHS evaluations per step."""
    import jax

    jax.config.update("jax_enable_x64", True)
    import diffrax
    import jax.numpy as jnp

    solver = getattr(diffrax, name)()
    tab = solver.tableau
    per_step = len(tab.c) + 1 - (1 if tab.fsal else 0)

    def rhs(t, y, d):
        p, b = d[11] * y[0], d[10]
        return _scaled_rhs(jnp, t, y, d, p - jnp.clip(p, -b, b))  # the dead zone in the RHS

    term = diffrax.ODETerm(rhs)

    def one(d, ts, rtol):
        sol = diffrax.diffeqsolve(
            term, solver, t0=0.0, t1=ts[-1], dt0=None, y0=jnp.zeros(2), args=d,
            saveat=diffrax.SaveAt(ts=ts),
            stepsize_controller=diffrax.PIDController(rtol=rtol, atol=rtol),
            max_steps=max_steps, throw=False)
        ok = sol.result == diffrax.RESULTS.successful
        return sol.ys[:, 0] * d[11], sol.stats["num_steps"], ok

    return jax.jit(jax.vmap(one, in_axes=(0, 0, None))), per_step


def diffrax_compile(batch: Batch, name: str):
    """Compile for the batch's shapes; returns (compiled function, seconds, evals per step)."""
    import jax.numpy as jnp

    fn, per_step = diffrax_solver(name)
    t0 = time.perf_counter()
    compiled = fn.lower(jnp.asarray(batch.params), jnp.asarray(batch.sample_times), 1e-6).compile()
    return compiled, time.perf_counter() - t0, per_step


def run_diffrax(batch: Batch, compiled, per_step: int, rtol: float, *, repeat: int = 3) -> BatchRun:
    import jax.numpy as jnp

    d, ts = jnp.asarray(batch.params), jnp.asarray(batch.sample_times)

    def go():
        p, steps, ok = compiled(d, ts, rtol)
        p.block_until_ready()
        return np.asarray(p), np.asarray(steps), np.asarray(ok)

    (p, steps, ok), sec, med = _timed(go, repeat)
    p = p.copy()
    p[~ok] = np.nan
    # under vmap every case runs until the slowest has finished (masked steps still cost)
    return BatchRun(p, sec, batch.n, per_step * steps.astype(float), np.arange(batch.n),
                    notes={"max_steps_in_batch": int(steps.max())}, seconds_median=med)


MAX_SEGMENTS = 4096
"""Bound on the linear pieces (backlash crossings + 1) of one case in ``diffrax_event_solver``."""
EVENT_HYSTERESIS = 1e-9
"""A piece ends EVENT_HYSTERESIS (in x = p / s) past its boundary, so that the next piece starts
inside itself (its event function at 2 EVENT_HYSTERESIS > 0, clear of the root finder's
tolerance); the force error of the overlap is of the order of its square."""


def diffrax_event_solver(name: str, max_steps: int = 1 << 16, max_segments: int = MAX_SEGMENTS,
                         dtmax_periods: float | None = None, root_finder: str = "bisection"):
    """diffrax with its event handling at the backlash crossings: a jitted ``vmap``-ed solve
    ``f(params, ts, rtol) -> (p, steps, ok, segments)`` and the RHS evaluations per step.

    Each case is integrated piece by piece: on a piece the contact state r (-1: contact on the
    negative flank, 0: free flight in the gap, +1: contact on the positive flank) is fixed, the
    right-hand side is the smooth linear one of that piece, f(p) = |r| (p - r b), continued past
    the piece's ends (so the step that holds the crossing, and its interpolant in which the root
    is found, see no kink), and a ``diffrax.Event`` stops the solve where the piece ends (|p| = b:
    c = p - b on r = +1, -p - b on r = -1, (b^2 - p^2) / b in the gap, each positive inside its
    piece, plus ``EVENT_HYSTERESIS``; ``direction=False``: the solve stops on a downcrossing of
    c). ``root_finder``: "bisection" (default; ``optimistix.Bisection`` within the step that
    holds the crossing) or "newton" (``optimistix.Newton``, the documented choice; measured, it
    fails to converge on some crossings of Dopri8 at rtol 1e-3 to 1e-5 and of Dopri5 at 1e-3).
    The next piece is chosen from the side and the sign of p' at the crossing (both pieces have
    the same vector field on the boundary), and a ``lax.while_loop`` restarts ``diffeqsolve``
    from the crossing (a new initial step each time) until the end time. Under ``vmap`` the loop
    runs until the case with the most crossings has finished (the other lanes are masked), and
    every inner solve until its slowest lane has. Scenes with backlash only."""
    import jax

    jax.config.update("jax_enable_x64", True)
    import diffrax
    import jax.numpy as jnp
    import optimistix as optx
    from jax import lax

    solver = getattr(diffrax, name)()
    tab = solver.tableau
    per_step = len(tab.c) + 1 - (1 if tab.fsal else 0)

    def rhs(t, y, args):
        d, r = args  # the piece's linear force, continued past its ends
        return _scaled_rhs(jnp, t, y, d, jnp.abs(r) * (d[11] * y[0] - r * d[10]))

    def cond_fn(t, y, args, **kwargs):
        d, r = args
        bx = d[10] / d[11]
        x = y[0]
        inside = jnp.where(r > 0, x - bx, jnp.where(r < 0, -x - bx, (bx - x) * (bx + x) / bx))
        return inside + EVENT_HYSTERESIS

    term = diffrax.ODETerm(rhs)
    if root_finder == "newton":
        finder = optx.Newton(rtol=1e-12, atol=1e-12)
    else:  # c > 0 at the step's start, <= 0 at its end (a downcrossing): flip
        finder = optx.Bisection(rtol=1e-14, atol=1e-12, flip=True)
    event = diffrax.Event(cond_fn, finder, direction=False)

    def one(d, ts, rtol):
        m = ts.shape[0]
        t_end = ts[-1]

        def body(c):
            t, y, r, out, nseg, steps, ok = c
            sol = diffrax.diffeqsolve(
                term, solver, t0=t, t1=t_end, dt0=None, y0=y, args=(d, r),
                # (ts, t1=True) in one SaveAt loses t1 at an event (diffrax 0.7.2): two subs
                saveat=diffrax.SaveAt(subs=[diffrax.SubSaveAt(ts=jnp.clip(ts, t, t_end)),
                                            diffrax.SubSaveAt(t1=True)]),
                stepsize_controller=diffrax.PIDController(
                    rtol=rtol, atol=rtol,
                    dtmax=None if dtmax_periods is None else dtmax_periods * 2 * jnp.pi / d[0]),
                event=event, max_steps=max_steps, throw=False)
            t1, y1, ys = sol.ts[1][0], sol.ys[1][0], sol.ys[0][:, 0]
            hit = sol.result == diffrax.RESULTS.event_occurred
            good = (sol.result == diffrax.RESULTS.successful) | hit
            take = (ts > t) & (ts <= t1) & jnp.isfinite(ys)
            out = jnp.where(take, ys * d[11], out)
            side = jnp.sign(y1[0])
            r1 = jnp.where(hit, jnp.where(side * y1[1] > 0, side, 0.0), r)
            t1 = jnp.where(hit, t1, t_end)
            return t1, y1, r1, out, nseg + 1, steps + sol.stats["num_steps"], ok & good

        def cond(c):
            return (c[0] < t_end) & c[6] & (c[4] < max_segments)

        init = (jnp.zeros(()), jnp.zeros(2), jnp.zeros(()), jnp.full(m, jnp.nan),
                jnp.zeros((), int), jnp.zeros((), int), jnp.ones((), bool))
        t, _, _, out, nseg, steps, ok = lax.while_loop(cond, body, init)
        return out, steps, ok & (t >= t_end), nseg

    return jax.jit(jax.vmap(one, in_axes=(0, 0, None))), per_step


def diffrax_event_compile(batch: Batch, name: str, chunk: int | None = None, **kw):
    """As ``diffrax_compile`` for ``diffrax_event_solver`` (``kw``: its keywords), for ``vmap``
    over ``chunk`` cases at a time (None: the whole batch in one call)."""
    import jax.numpy as jnp

    if batch.scenes[0].half_gap is None:
        raise ValueError("the events variant is for scenes with backlash")
    fn, per_step = diffrax_event_solver(name, **kw)
    n = batch.n if chunk is None else min(chunk, batch.n)
    t0 = time.perf_counter()
    compiled = fn.lower(jnp.asarray(batch.params[:n]), jnp.asarray(batch.sample_times[:n]),
                        1e-6).compile()
    return compiled, time.perf_counter() - t0, per_step


def run_diffrax_events(batch: Batch, compiled, per_step: int, rtol: float, *,
                       repeat: int = 3) -> BatchRun:
    """``diffrax_event_solver`` over the batch, in chunks of the cases the compiled function
    takes (one call after the other; the last chunk padded with copies of the last case).
    RHS evaluations: accepted + rejected steps of all pieces times the new stages per step (the
    root finds' interpolant evaluations and the initial step selection of each piece not
    counted)."""
    import jax.numpy as jnp

    k = compiled.in_avals[0][0].shape[0] if hasattr(compiled, "in_avals") else batch.n
    n = batch.n
    idx = np.minimum(np.arange(-(-n // k) * k), n - 1)
    parts = [(jnp.asarray(batch.params[idx[j:j + k]]), jnp.asarray(batch.sample_times[idx[j:j + k]]))
             for j in range(0, len(idx), k)]

    def go():
        res = [compiled(d, ts, rtol) for d, ts in parts]
        res[-1][0].block_until_ready()
        p, steps, ok, nseg = (np.concatenate([np.asarray(r[i]) for r in res])[:n]
                              for i in range(4))
        return p, steps, ok, nseg

    (p, steps, ok, nseg), sec, med = _timed(go, repeat)
    p = p.copy()
    p[~ok] = np.nan
    return BatchRun(p, sec, batch.n, per_step * steps.astype(float), np.arange(batch.n),
                    notes={"max_steps_in_batch": int(steps.max()), "pieces_max": int(nseg.max()),
                           "pieces_mean": float(nseg.mean())}, seconds_median=med)


# --------------------------------------------------------------------------- per-case peers


def _python_rhs(d):
    w, c, km, k1, k2, k3, g0, g1, g2, g3, b, s, wn = (float(v) for v in d[:13])
    cos = math.cos

    def f(t, x, u):
        th = w * t
        c1, c2, c3 = cos(th), cos(2.0 * th), cos(3.0 * th)
        k = km + k1 * c1 + k2 * c2 + k3 * c3
        g = g0 + g1 * c1 + g2 * c2 + g3 * c3
        p = s * x
        fp = p - min(max(p, -b), b)
        return wn * u, (g - c * s * wn * u - k * fp) / (s * wn)

    return f


def _cvode_rhs(f):
    def rhs(t, y, yp):
        yp[0], yp[1] = f(t, y[0], y[1])

    return rhs


def run_cvode(batch: Batch, rtol: float, cases, method: str = "Adams") -> BatchRun:
    """scikit-sundae CVODE, one case at a time (Python right-hand side) over ``cases``; the wall
    time is the serial time (divide by the cores for an ideal process pool)."""
    from sksundae.cvode import CVODE

    cases = np.asarray(cases)
    m = batch.sample_times.shape[1]
    out = np.full((len(cases), m), np.nan)
    nfev = np.full(len(cases), np.nan)
    t0 = time.perf_counter()
    for k, i in enumerate(cases):
        d = batch.params[i]
        solver = CVODE(_cvode_rhs(_python_rhs(d)), method=method, rtol=rtol, atol=rtol,
                       max_num_steps=1_000_000)
        r = solver.solve(np.concatenate([[0.0], batch.sample_times[i]]), np.zeros(2))
        nfev[k] = r.nfev
        if r.success and r.y.shape[0] == m + 1:
            out[k] = r.y[1:, 0] * d[S]
    return BatchRun(out, time.perf_counter() - t0, len(cases), nfev, cases)


def run_scipy(batch: Batch, method: str, rtol: float, cases) -> BatchRun:
    """``scipy.integrate.solve_ivp`` as ``precision.run_scipy`` (atol = rtol times the response
    scale, Python right-hand side, dense output at the sampling instants), one case at a time."""
    from scipy.integrate import solve_ivp

    cases = np.asarray(cases)
    m = batch.sample_times.shape[1]
    out = np.full((len(cases), m), np.nan)
    nfev = np.full(len(cases), np.nan)
    t0 = time.perf_counter()
    for k, i in enumerate(cases):
        f = _python_rhs(batch.params[i])
        s = batch.params[i, S]
        ts = batch.sample_times[i]
        r = solve_ivp(lambda t, y, f=f: f(t, y[0], y[1]), (0.0, ts[-1]), [0.0, 0.0], method=method,
                      rtol=rtol, atol=rtol, t_eval=ts)
        nfev[k] = r.nfev
        if r.success:
            out[k] = r.y[0] * s
    return BatchRun(out, time.perf_counter() - t0, len(cases), nfev, cases)


# --------------------------------------------------------------------------- equal accuracy


def cost_at(error, cost, target: float) -> tuple[float, str]:
    """Cost at which a method's error first falls to ``target``, interpolated linearly in
    log(cost)-log(error) along its curve (points ordered by cost; the error made monotone by a
    running minimum). Returns (cost, flag): flag "" interpolated, "<" the cheapest point is
    already below the target (its cost, an upper bound), "none" never reached (NaN)."""
    e = np.asarray(error, float)
    c = np.asarray(cost, float)
    ok = np.isfinite(e) & np.isfinite(c) & (e > 0)
    if not ok.any():
        return math.nan, "none"
    order = np.argsort(c[ok])
    e, c = np.minimum.accumulate(e[ok][order]), c[ok][order]
    below = np.nonzero(e <= target)[0]
    if below.size == 0:
        return math.nan, "none"
    j = int(below[0])
    if j == 0:
        return float(c[0]), "<"
    le0, le1 = math.log(e[j - 1]), math.log(e[j])
    lc0, lc1 = math.log(c[j - 1]), math.log(c[j])
    if le1 == le0:
        return float(c[j]), ""
    w = (math.log(target) - le0) / (le1 - le0)
    return float(math.exp(lc0 + w * (lc1 - lc0))), ""

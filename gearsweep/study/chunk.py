"""One chunk of a plan: the lanes' values -> kernel calls (carrying the state along continued
sweeps) -> the outputs' arrays and the status of every case. Runs wherever the chunk is sent."""

from __future__ import annotations

import dataclasses
import threading
import time

import numpy as np

from gearsweep.kernels import STATUS_DIVERGED, BatchResult
from gearsweep.kernels.cuda import kernel_for
from gearsweep.model import kernel_inputs
from gearsweep.study.outputs import OUTPUTS, Floquet
from gearsweep.study.plan import (
    STATUS_NOT_SETTLED,
    STATUS_SKIPPED,
    Plan,
    _lane_params,
    _lanes,
    _step_ok,
    transient_left,
)


class _Clock:
    """Seconds spent in the kernel (``simulate``) by this process, summed over its threads."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.seconds = 0.0

    def add(self, seconds: float) -> None:
        with self._lock:
            self.seconds += seconds


KERNEL_CLOCK = _Clock()
"""Read before and after a run in this process: the difference is its time in the kernel
(``run_plan`` stores it as the Dataset's ``kernel_seconds``, beside ``elapsed_seconds``)."""


def _integrate(plan: Plan, params: dict[str, np.ndarray], n: int, x0, v0,
               ok: np.ndarray | None = None) -> tuple:
    """One kernel call for ``n`` cases; returns (BatchResult, per-output arrays, status).

    ``ok``: the step guard's verdict per case if already known (else it is computed here).
    """
    guard = plan.study.solver.step_guard
    if guard == "off":
        ok = np.ones(n, bool)
    elif ok is None:
        ok = _step_ok(plan, params, n)
    if guard == "skip" and not ok.all():
        return _integrate_subset(plan, params, n, x0, v0, ok)
    res, out, status = _integrate_all(plan, params, n, x0, v0)
    if guard == "warn":
        out["beyond_step_limit"] = ~ok
    return res, out, status


def _integrate_subset(plan: Plan, params, n: int, x0, v0, ok: np.ndarray) -> tuple:
    """Integrate only the cases whose step is stable; the others get status 3 and NaN."""
    idx = np.flatnonzero(ok)
    sub = {k: np.asarray(v)[idx] for k, v in params.items()}
    sx0 = None if x0 is None else np.asarray(x0)[idx]
    sv0 = None if v0 is None else np.asarray(v0)[idx]
    res, out, status = _integrate_all(plan, sub, len(idx), sx0, sv0)
    full = {}
    for name, arr in out.items():
        fill = False if arr.dtype == bool else np.nan
        a = np.full((n, *arr.shape[1:]), fill, dtype=arr.dtype)
        a[idx] = arr
        full[name] = a
    if "min_steps_per_period" in full and idx.size < n:  # the number a skipped case needs
        full["min_steps_per_period"][~ok] = _skipped_step_limits(plan, params, ~ok)
    st = np.full(n, STATUS_SKIPPED, np.int8)
    st[idx] = status
    xf = np.full(n, np.nan)
    vf = np.full(n, np.nan)
    xf[idx], vf[idx] = res.x_final, res.v_final
    rs = np.full(n, STATUS_DIVERGED, np.int8)  # a skipped lane restarts a continued sweep
    rs[idx] = res.status
    return BatchResult(stats={}, x_final=xf, v_final=vf, status=rs, signal=None), full, st


def _skipped_step_limits(plan: Plan, params, skipped: np.ndarray) -> np.ndarray:
    """The floquet output's ``min_steps_per_period`` of the cases the step guard skips (each at
    its own load's k(t) where a gear scene sweeps its load), as ``step_guard: off`` gives them."""
    idx = np.flatnonzero(skipped)
    sub = {k: np.asarray(v)[idx] for k, v in params.items()}
    floquet = OUTPUTS["floquet"]
    if not plan.gear_load_swept:
        return floquet.step_limits(plan, sub, idx.size)
    torques = plan.case_torques(sub)
    out = np.empty(idx.size)
    for load in np.unique(torques):
        at = np.flatnonzero(torques == load)
        out[at] = floquet.step_limits(plan.at_load(float(load)),
                                      {k: v[at] for k, v in sub.items()}, at.size)
    return out


def _integrate_all(plan: Plan, params: dict[str, np.ndarray], n: int, x0, v0) -> tuple:
    """One kernel call for the cases, or one per distinct load of a gear scene that sweeps it
    (each load has its own k(t) and e(t): ``Plan.model_for_load``). No cases (every one the
    step guard skips): one call of none, at the plan's model (there were no loads to merge: an
    IndexError traceback)."""
    if not plan.gear_load_swept or n == 0:
        return _integrate_model(plan, params, n, x0, v0)
    torques = plan.case_torques(params)
    loads, which = np.unique(torques, return_inverse=True)
    parts = []
    for g, load in enumerate(loads):
        idx = np.flatnonzero(which == g)
        sub = {k: np.asarray(v)[idx] for k, v in params.items()}
        at = plan.at_load(float(load))
        parts.append((idx, _integrate_model(at, sub, len(idx), _take(x0, idx), _take(v0, idx))))
    return _merge(parts, n)


def _take(a, idx: np.ndarray):
    """The cases ``idx`` of a per-case initial state (``None`` and scalars are shared)."""
    if a is None:
        return None
    a = np.asarray(a, float)
    return a[idx] if a.ndim else a


def _merge(parts: list[tuple[np.ndarray, tuple]], n: int) -> tuple:
    """Put the (BatchResult, outputs, status) of case subsets back in case order."""

    def full(arrays: list[np.ndarray | None]) -> np.ndarray | None:
        if arrays[0] is None:
            return None
        a = np.empty((n, *arrays[0].shape[1:]), dtype=arrays[0].dtype)
        for (idx, _), arr in zip(parts, arrays, strict=True):
            a[idx] = arr
        return a

    results = [p[1][0] for p in parts]
    res = BatchResult(
        stats={k: full([r.stats[k] for r in results]) for k in results[0].stats},
        x_final=full([r.x_final for r in results]), v_final=full([r.v_final for r in results]),
        status=full([r.status for r in results]), signal=full([r.signal for r in results]),
        substeps=full([r.substeps for r in results]))
    out = {k: full([p[1][1][k] for p in parts]) for k in parts[0][1][1]}
    return res, out, full([p[1][2] for p in parts])


def _start(plan: Plan, params: dict[str, np.ndarray], n: int) -> float | np.ndarray:
    """p at t = 0 of each case: the solver's ``initial_displacement``, or with ``static`` the
    static equilibrium of each case (at its own load) on the flank its load presses: b + F_m / k0
    on the drive flank, -b + F_m / k0 on the back flank for F_m < 0 (b + F_m / k0 was in the gap
    there, or past the back flank, and the case started with a flight across the backlash)."""
    s = plan.study.solver
    if s.initial_displacement != "static":
        return s.initial_displacement  # (a Mathieu scene's default 1 is the schema's)
    if plan.dimensionless:
        raise ValueError("initial_displacement 'static' needs a gear scene, not Mathieu")

    half_gap, fm, k0 = _static_terms(plan, params, n)
    return np.where(fm < 0, -half_gap, half_gap) + fm / k0


def _static_terms(plan: Plan, params: dict[str, np.ndarray], n: int) -> tuple:
    """(b / 2, F_m, k0) of each case of a gear scene: its half backlash, mean force and mean
    stiffness (at its own load)."""
    model = plan.model

    def case(name: str, default: float) -> np.ndarray:
        return np.asarray(params[name], float) if name in params else np.full(n, default)

    if plan.gear_load_swept:
        torques = plan.case_torques(params)
        k0 = np.array([plan.model_for_load(float(t)).stiffness for t in torques])
    else:
        k0 = case("stiffness", model.stiffness)
    fm = plan.case_mean_forces(params, n)
    return case("backlash", model.backlash) / 2.0, fm, k0


def _away_from_rest(plan: Plan, params: dict[str, np.ndarray], n: int,
                    p_mean: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """Cases of a gear scene whose mean p is not where a response that has died away rests:
    F_m / k0 past the flank it is pressed on (b / 2 + F_m / k0 for F_m > 0), or anywhere in the
    backlash without a mean force; to 1e-6 of the static scale."""
    half_gap, fm, k0 = _static_terms(plan, params, n)
    rest = fm / k0 + np.sign(fm) * half_gap
    tol = 1e-6 * scale
    return np.where(fm == 0, np.abs(p_mean) > half_gap + tol, np.abs(p_mean - rest) > tol)


def _kernel_call(plan: Plan, params: dict[str, np.ndarray], n: int, x0, v0) -> dict:
    """The keyword arguments of the kernel call (``simulate``) for the cases ``params``."""
    s = plan.study.solver
    spp = s.steps_per_period
    x_init = _start(plan, params, n)
    kin = kernel_inputs(plan.model, params, n, spp, s.divergence_factor, x_init,
                        s.initial_velocity)
    if x0 is not None:
        kin["x0"], kin["v0"] = x0, v0
    sps = plan.samples_per_period()
    return dict(method=s.method, n_transient=s.transient_periods * spp,
                n_record=s.record_periods * spp, steps_per_period=spp,
                signal_stride=spp // sps if sps else 0, kink_aware=s.kink_aware, **kin)


def first_kernel_call(plan: Plan) -> dict:
    """The keyword arguments of the kernel call of the plan's first case: which compiled
    specialisation a run calls (``kernels.batch.specialisation``; every call of a plan uses the
    same one, its terms being the study's), without building the grid of cases or compiling
    anything (not even ``lane_values``: the first case is every grid's first value, and a gear
    scene's model, ``plan.model``, is the one at the first swept load)."""
    params = {d: plan.grids[d][:1] for d in plan.dims}
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        return _kernel_call(plan, params, 1, None, None)


def kernel_calls(plan: Plan) -> list[dict]:
    """A ``simulate`` call (keyword arguments) of every compiled specialisation a run of the
    plan uses: the first case's (``first_kernel_call``) and those its outputs make of their own
    (the ``floquet`` output's monodromy maps)."""
    calls = [first_kernel_call(plan)]
    for name in plan.outputs:
        extra = getattr(OUTPUTS[name], "kernel_calls", None)
        if extra is not None:
            calls += extra(plan)
    return calls


def _integrate_model(plan: Plan, params: dict[str, np.ndarray], n: int, x0, v0) -> tuple:
    call = _kernel_call(plan, params, n, x0, v0)
    return _outputs(plan, params, call, _run_kernel(plan, call))


def _run_kernel(plan: Plan, call: dict) -> BatchResult:
    """The kernel call, its seconds added to ``KERNEL_CLOCK``."""
    s = plan.study.solver
    t0 = time.perf_counter()
    res = kernel_for(s.device, s.precision)(**call)
    KERNEL_CLOCK.add(time.perf_counter() - t0)
    return res


def _outputs(plan: Plan, params: dict[str, np.ndarray], call: dict, res: BatchResult,
             left: np.ndarray | None = None) -> tuple:
    """(BatchResult, per-output arrays, status) of a kernel call's result; ``left``: the cases'
    ``transient_left`` residual where it was looked up (``plan._transient_table``), else
    computed here."""
    s = plan.study.solver
    out: dict[str, np.ndarray] = {}
    for o in plan.outputs:
        out.update(OUTPUTS[o].compute(plan, params, res))
    out = {name: plan.specs[name].to_result(a) if name in plan.specs else a
           for name, a in out.items()}  # SI -> the unit the result stores (p in um)
    status = res.status.astype(np.int8)
    # A statistic that overflowed (p_rms of p ~ 1e291 m under a mean force of 1e300 N: p^2 is
    # inf) is no result: the case is flagged as diverged, its values NaN as a diverged case's
    # (it was status 0 with p_rms inf; found by an adversarial test). So is one whose p left
    # the divergence bound between the kernel's checks, once per mesh period (a 27/41 whine
    # scene at 48 steps per period: p_max 2.5e9 um against a bound of 1.25e7 um, status 0).
    bound = np.asarray(call["bound"], float)
    with np.errstate(invalid="ignore"):
        beyond = (np.abs(res.stats["p_max"]) > bound) | (np.abs(res.stats["p_min"]) > bound)
    over = (status == 0) & (beyond | ~np.logical_and.reduce(
        [np.isfinite(a) for a in res.stats.values()]))
    if over.any():
        status[over] = STATUS_DIVERGED
        for a in out.values():
            if a.dtype.kind == "f" and a.shape[:1] == over.shape:
                a[over] = np.nan
        if "contact_lost" in out:  # a flag of the p thrown away is no verdict (a diverged
            out["contact_lost"][over] = False  # case's is False); Floquet's flags stay
    # A response that has died away (a free vibration with nothing driving it) has nothing left
    # to settle: its settle_error is round-off over round-off (0.48 with p_pp 1e-16 m). Below
    # 1e-9 of the static scale (the divergence bound's, kernel_inputs) it counts as settled.
    scale = bound / s.divergence_factor
    quiet = res.stats["p_max"] - res.stats["p_min"] <= 1e-9 * scale
    if quiet.any() and not plan.dimensionless:  # quiet where it rests, not frozen on its way:
        # at 1e10 rpm the whole run is 5 ns, p moved 1e-13 m towards an equilibrium at 235 um,
        # and was taken as settled (status 0; found by an adversarial test)
        idx = np.flatnonzero(quiet)  # the quiet cases only: often none, rarely many
        sub = {k: np.asarray(v)[idx] for k, v in params.items()}
        quiet[idx] = ~_away_from_rest(plan, sub, len(idx), res.stats["p_mean"][idx],
                                      np.broadcast_to(scale, quiet.shape)[idx])
    unsettled = (status == 0) & ~(res.stats["settle_error"] <= s.settle_tolerance) & ~quiet
    # A transient the plan knows cannot have decayed (its damping or the map's largest Floquet
    # multiplier leaves more than settle_tolerance of the start's free vibration) is not settled
    # however alike the record's halves are: a beat slower than the record passed the test
    # (whine_gear_table1, 0.55 N s/mm at 14,429 rpm: mu = 0.9998 per period, 98 % left after
    # 100 transient periods, p_rms 3.01 um with status 0 where the steady state is 0.26 um).
    if left is None:
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            left = transient_left(plan, params, len(status))[0]
    unsettled |= (status == 0) & (left > s.settle_tolerance) & ~quiet
    if "transient_left" in plan.specs:  # the residual the rule judged, recorded beside status
        out["transient_left"] = np.array(np.broadcast_to(left, status.shape), float)
    if plan.driven:  # an undriven scene decays or grows: nothing to settle into (Plan.driven)
        status[unsettled] = STATUS_NOT_SETTLED
    return res, out, status


@dataclasses.dataclass(frozen=True)
class Prepared:
    """A chunk's swept values, step-guard verdicts, kernel call and ``transient_left`` residual
    (looked up; ``None``: computed with the outputs), made before its turn (``prepare``)."""

    params: dict[str, np.ndarray]
    ok: np.ndarray
    call: dict
    left: np.ndarray | None = None


def prepare(plan: Plan, lane0: int, lane1: int) -> Prepared | None:
    """The kernel call of lanes ``[lane0, lane1)``, made ahead of the kernel (in another thread
    while the chunk before computes: ``execute.InProcess``); ``None`` where the chunk is not one
    call of all its cases (a continued sweep, a gear scene that sweeps its load, cases the step
    guard skips), which ``run_chunk`` computes whole."""
    if plan.continued or plan.gear_load_swept:
        return None
    guard = plan.study.solver.step_guard
    n = lane1 - lane0
    params, ok, left = _lanes(plan, lane0, lane1, guard != "off", transient=True)
    if guard == "off":
        ok = np.ones(n, bool)
    elif ok is None:
        ok = _step_ok(plan, params, n)
    if guard == "skip" and not ok.all():
        return None
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):  # as run_chunk's caller
        return Prepared(params, ok, _kernel_call(plan, params, n, None, None), left)


def run_prepared(plan: Plan, prep: Prepared):
    """Run a prepared chunk's kernel; return the function that makes its arrays (those of
    ``run_chunk``) from the kernel's result, to be called later, in another thread (the
    writer's, while the next chunk computes). A result with a recorded signal (a spectrum's)
    is made into arrays here: the signal is many times their size, and is not held on."""
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):  # as run_chunk's caller
        res = _run_kernel(plan, prep.call)

    def arrays() -> dict[str, np.ndarray]:
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            _, out, status = _outputs(plan, prep.params, prep.call, res, prep.left)
        if plan.study.solver.step_guard == "warn":
            out["beyond_step_limit"] = ~prep.ok
        out["status"] = status
        return out

    if res.signal is not None:
        done = arrays()
        return lambda: done
    return arrays


def run_chunk(plan: Plan, lane0: int, lane1: int) -> dict[str, np.ndarray]:
    """Compute lanes ``[lane0, lane1)``: arrays of shape (directions?, lanes, chain?, *extra)."""
    n = lane1 - lane0
    if not plan.continued:
        guard = plan.study.solver.step_guard != "off"
        params, ok, _ = _lanes(plan, lane0, lane1, guard)
        _, out, status = _integrate(plan, params, n, None, None, ok)
        out["status"] = status
        return out
    params = _lane_params(plan, lane0, lane1)
    if "floquet" not in plan.outputs:
        return _continued(plan, params, n)
    with Floquet.shared():  # the multipliers depend on the case, not on the state or direction:
        _floquet_once(plan, params, n)  # all speeds' in one batch, then each speed reuses them
        return _continued(plan, params, n)


def _floquet_once(plan: Plan, params: dict[str, np.ndarray], n: int) -> None:
    """Compute the ``floquet`` output of lanes ``params`` at every speed of a continued sweep
    (one direction; the step guard's skipped cases left out), for ``Floquet.shared`` to keep."""
    speeds = plan.grids["speed"]
    ns = len(speeds)
    every = {name: np.repeat(vals, ns) for name, vals in params.items()}
    every["speed"] = np.tile(speeds, n)
    if plan.study.solver.step_guard == "skip":
        keep = np.flatnonzero(_step_ok(plan, every, n * ns))
        every = {k: v[keep] for k, v in every.items()}
    torques = plan.case_torques(every) if plan.gear_load_swept else None
    for load in [None] if torques is None else np.unique(torques):
        idx = slice(None) if load is None else np.flatnonzero(torques == load)
        sub = {k: v[idx] for k, v in every.items()}
        at = plan if load is None else plan.at_load(float(load))
        if len(sub["speed"]):
            OUTPUTS["floquet"].compute(at, sub, _Sized(len(sub["speed"])))


class _Sized:
    """What ``Floquet.compute`` reads of a kernel result: the number of cases."""

    def __init__(self, n: int) -> None:
        self.x_final = np.empty(n)


def _continued(plan: Plan, params: dict[str, np.ndarray], n: int) -> dict[str, np.ndarray]:
    """``run_chunk`` of a continued sweep."""
    # Continued sweeps: the up and the down sweep of every lane advance side by side as lanes of
    # one kernel call (step k is speed k going up and speed n-1-k going down).
    speeds = plan.grids["speed"]
    ns, nd = len(speeds), len(plan.directions)
    s = plan.study.solver
    both = {name: np.tile(vals, nd) for name, vals in params.items()}
    x0 = np.broadcast_to(_start(plan, both, n * nd), (n * nd,)).astype(float)
    x = x0.copy()
    v = np.full(n * nd, s.initial_velocity)
    cols: dict[str, np.ndarray] = {}
    for k in range(ns):
        idx = np.concatenate([np.full(n, k if d == "up" else ns - 1 - k) for d in plan.directions])
        res, out, status = _integrate(plan, dict(both, speed=speeds[idx]), n * nd, x, v)
        out["status"] = status
        for name, arr in out.items():
            if name not in cols:
                cols[name] = np.empty((nd, n, ns, *arr.shape[1:]), dtype=arr.dtype)
            a = arr.reshape(nd, n, *arr.shape[1:])
            for di in range(nd):
                cols[name][di, :, idx[di * n]] = a[di]
        # Carry the state; a diverged lane restarts from the initial state at the next speed
        # (the kernel's verdict, a skipped lane's too, or _outputs': a p beyond the bound).
        dead = (res.status == STATUS_DIVERGED) | (status == STATUS_DIVERGED)
        x = np.where(dead, x0, res.x_final)
        v = np.where(dead, s.initial_velocity, res.v_final)
    return cols

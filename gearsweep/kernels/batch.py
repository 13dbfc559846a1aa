"""Public entry to the batch kernel: plain NumPy arrays in SI units in, plain arrays out.

``simulate`` broadcasts scalars, makes arrays contiguous float64, switches terms off with ``None``
(each combination is its own compiled specialisation, cached on disk) and returns a
``BatchResult``. It knows nothing of studies, units, xarray or files.
"""

from __future__ import annotations

import os
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numba
import numpy as np

from gearsweep.jit import ready
from gearsweep.kernels import kink, rk


@dataclass(frozen=True)
class BatchResult:
    """Per-case results of one kernel call (arrays of length ``n``)."""

    stats: dict[str, np.ndarray]
    """Steady-state statistics, keyed by ``rk.STAT_NAMES`` [m] or [1]."""
    x_final: np.ndarray
    """Displacement p at the end [m] (NaN for diverged cases)."""
    v_final: np.ndarray
    """Velocity p' at the end [m/s]."""
    status: np.ndarray
    """``rk.STATUS_OK`` or ``rk.STATUS_DIVERGED`` (int8)."""
    signal: np.ndarray | None
    """p at every ``stride``-th recorded step, shape (n, n_samples) [m], if asked for."""
    substeps: np.ndarray | None = None
    """Kink-aware kernel only: extra work at backlash crossings per case, in step-equivalents
    (right-hand-side evaluations / the method's stages); ``None`` for the plain kernel."""


def _own(a) -> np.ndarray:
    """``a`` as a C-contiguous, writable float64 array (copied only if it is not one already).

    Numba types a read-only array apart from a writable one, and every combination of the two
    over the kernel's arguments is a specialisation of its own (tens of seconds to compile each):
    ``np.broadcast_to`` returns read-only views, so a per-case array or a batch of one case used
    to reach the kernel read-only while a broadcast scalar was copied writable.
    """
    return np.require(np.asarray(a, dtype=np.float64), requirements=("C", "W"))


def _vec(x, n: int) -> np.ndarray:
    return _own(np.broadcast_to(x, (n,)))


def _tab(t) -> np.ndarray | None:
    if t is None:
        return None
    t = _own(t)
    if t.ndim != 2 or t.shape[1] != len(rk.NODES):
        raise ValueError(f"a coefficient table must have shape (S, {len(rk.NODES)}), got {t.shape}")
    return t


def checked_inputs(h, method: str, n_transient: int, n_record: int, steps_per_period: int,
                   tables: Sequence, signal_stride: int) -> tuple[np.ndarray, int, list, int]:
    """The checks and conversions of ``simulate``'s arguments that every device shares: returns
    ``h`` as float64, the number of cases, the three tables (``_tab``) and the signal stride."""
    h = _own(np.atleast_1d(h))
    n = h.shape[0]
    if method not in rk.METHODS:
        raise ValueError(f"method must be one of {sorted(rk.METHODS)}, got {method!r}")
    if n_transient < 0 or n_record < 0 or steps_per_period < 1:
        raise ValueError("step counts must be non-negative and steps_per_period >= 1")
    tables = [_tab(t) for t in tables]
    sizes = {t.shape[0] for t in tables if t is not None}
    if len(sizes) > 1:
        raise ValueError(f"coefficient tables cover different cycles: {sorted(sizes)} steps")
    return h, n, tables, max(int(signal_stride), 1)


def simulate(
    h,
    *,
    method: str = "rk4",
    damping=0.0,
    k_mean=0.0,
    k_scale=None,
    k_table=None,
    force=0.0,
    ste_scale=0.0,
    ste_table=None,
    fluct_scale=0.0,
    fluct_table=None,
    half_gap=None,
    bound=np.inf,
    x0=0.0,
    v0=0.0,
    n_transient: int,
    n_record: int,
    steps_per_period: int,
    signal_stride: int = 0,
    kink_aware: bool = False,
) -> BatchResult:
    """Integrate ``p'' = G(t) - damping p' - K(t) f(p)`` for a batch of cases.

    Parameters
    ----------
    h : array_like (n,)
        Fixed step [s]; it must divide the excitation cycle of the tables into ``S`` steps.
    method : {"rk4", "rk5"}
    damping : array_like
        c / m [1/s].
    k_mean, k_scale, k_table :
        Stiffness / mass: ``k_mean + k_scale * k_table`` [1/s^2]. ``k_table=None``: constant
        ``k_mean``. ``k_scale=None``: ``k_table`` alone, shared by every case (fastest).
    force, ste_scale, ste_table, fluct_scale, fluct_table :
        Force / mass: ``force + ste_scale * ste_table + fluct_scale * fluct_table`` [m/s^2].
    half_gap : array_like or None
        Half the backlash [m]; ``None``: no backlash (f(p) = p).
    bound : array_like
        A case whose |p| exceeds it [m] (or turns non-finite) is stopped and flagged.
    x0, v0 : array_like
        Initial state [m], [m/s].
    n_transient, n_record, steps_per_period : int
        Steps discarded, steps recorded, steps per mesh period.
    signal_stride : int
        If > 0, also return p at every ``signal_stride``-th recorded step: sample ``j`` is p
        after step ``n_transient + j * signal_stride + 1``, at the time
        ``(n_transient + j * signal_stride + 1) * h`` after the start (the state after each
        step, not before it: one step later than ``(n_transient + j * signal_stride) * h``, a
        phase of ``2 pi / steps_per_period`` per mesh period).
    kink_aware : bool
        Use ``gearsweep.kernels.kink``: a step that crosses a backlash boundary p = +-b is
        redone in pieces that end on the boundary, so the method keeps its order through the
        kinks of the dead zone (the plain step falls to order 2 there). Steps without crossings
        are the plain kernel's, bit for bit; without backlash the two are identical.
    """
    h, n, tables, stride = checked_inputs(h, method, n_transient, n_record, steps_per_period,
                                          (k_table, ste_table, fluct_table), signal_stride)
    signal = None
    if signal_stride > 0:
        signal = np.full((n, (n_record + stride - 1) // stride), np.nan)
    # The driver (``rk.Threaded``) uses no more threads than blocks: the many small calls of a
    # continued sweep with few lanes run in the calling thread alone.
    out = _call(method, h, n, damping, k_mean, k_scale, tables, force, ste_scale, fluct_scale,
                half_gap, bound, x0, v0, n_transient, n_record, steps_per_period, signal, stride,
                kink_aware)
    stats, xf, vf, status = out[:4]
    return BatchResult(
        stats={name: stats[:, q] for q, name in enumerate(rk.STAT_NAMES)},
        x_final=xf,
        v_final=vf,
        status=status,
        signal=signal,
        substeps=out[4] if kink_aware else None,
    )


def _call(method, h, n, damping, k_mean, k_scale, tables, force, ste_scale, fluct_scale,
          half_gap, bound, x0, v0, n_transient, n_record, steps_per_period, signal, stride,
          kink_aware=False):
    driver, args = _driver_call(method, h, n, damping, k_mean, k_scale, tables, force, ste_scale,
                                fluct_scale, half_gap, bound, x0, v0, n_transient, n_record,
                                steps_per_period, signal, stride, kink_aware)
    out = driver(*args)
    if len(out) == 4:  # plain kernel: no substeps
        out = (*out, np.zeros(n))
    return out


def _driver_call(method, h, n, damping, k_mean, k_scale, tables, force, ste_scale, fluct_scale,
                 half_gap, bound, x0, v0, n_transient, n_record, steps_per_period, signal,
                 stride, kink_aware=False):
    """The batch driver (``rk.Threaded``) a call uses and its positional arguments."""
    # Without backlash there are no kinks: the kink-aware kernel would be the plain one.
    kinks = kink_aware and half_gap is not None
    drivers = kink.INTEGRATE if kinks else rk.INTEGRATE
    extra = (kink.sub_blocks(n, numba.get_num_threads()),) if kinks else ()
    return drivers[rk.METHODS[method]], (
        h,
        _vec(damping, n),
        _vec(k_mean, n),
        None if k_scale is None else _vec(k_scale, n),
        tables[0],
        _vec(force, n),
        _vec(ste_scale, n),
        tables[1],
        _vec(fluct_scale, n),
        tables[2],
        None if half_gap is None else _vec(half_gap, n),
        _vec(bound, n),
        _vec(x0, n),
        _vec(v0, n),
        int(n_transient),
        int(n_record),
        int(steps_per_period),
        signal,
        stride,
        *extra,
    )


def dispatcher(call: dict) -> tuple[numba.core.dispatcher.Dispatcher, tuple]:
    """The compiled function (Numba dispatcher: its driver and combination of terms,
    ``specialisation``) that a ``simulate`` call of these keyword arguments uses, and the
    arguments it passes it, for one case of the call; nothing is compiled."""
    kw = {k: (v if k in _NOT_PER_CASE or v is None else np.ravel(v)[:1]) for k, v in call.items()
          if k not in ("n_transient", "n_record")}
    kw.setdefault("steps_per_period", 1)
    get = kw.get
    h, n, tables, stride = checked_inputs(
        kw["h"], get("method", "rk4"), 0, 1, kw["steps_per_period"],
        (get("k_table"), get("ste_table"), get("fluct_table")), get("signal_stride", 0))
    signal = np.full((n, 1), np.nan) if int(get("signal_stride") or 0) > 0 else None
    threaded, args = _driver_call(
        get("method", "rk4"), h, n, get("damping", 0.0), get("k_mean", 0.0), get("k_scale"),
        tables, get("force", 0.0), get("ste_scale", 0.0), get("fluct_scale", 0.0),
        get("half_gap"), get("bound", np.inf), get("x0", 0.0), get("v0", 0.0), 0, 1,
        kw["steps_per_period"], signal, stride, bool(get("kink_aware")))
    return threaded.driver(args), threaded.arguments(args)


def compiled(call: dict) -> bool:
    """Whether the compiled function that a ``simulate`` call of these keyword arguments uses
    (``dispatcher``) is ready without compiling (``jit.ready``: in this process already, or in
    Numba's disk cache for this machine and this source): about 10 ms, most of it typing the
    arguments."""
    return ready(*dispatcher(call))


COLD_COMPILE_SECONDS = {("rk4", False): 4.0, ("rk5", False): 4.5, ("rk4", True): 11.0,
                        ("rk5", True): 16.0}
"""One-time compile time of one specialisation of a batch driver on a cold cache [s], rounded up
from the measured (this 2-core machine, 26 Nov 2026, with the threaded drivers, ``rk.Threaded``;
``scripts/bench_compile.py``: plain RK4 3.2 s, RK5 3.4 s, kink-aware RK4 9.1-9.3 s, RK5
13.2-13.8 s; docs/benchmark.md). The estimate adds it where the cache lacks the study's
specialisation; ``compile_cost`` orders the main job's compiles by it. The earlier
15/25/68/97 s predate the memoized inlining and the per-combination drivers, and 6/7/18/22 s
the threaded drivers."""

COLD_COMPILE_BYTES = {("rk4", False): 100e6, ("rk5", False): 100e6, ("rk4", True): 250e6,
                      ("rk5", True): 450e6}
"""Resident memory the one-time compile of one specialisation adds to a run's peak on a cold
cache [bytes] (LLVM's), rounded up from the measured (this 2-core machine, 27 Nov 2026,
``scripts/bench_compile.py``: a run's peak resident memory on a fresh cache against a second run
on the cache it filled, 168 MB; plain RK4 and RK5 +76 and +77 MB, kink-aware RK4 +206 MB,
kink-aware RK5 +422 MB). Several in one run add more than the largest, less than their sum
(``compile_peak``), where the cache lacks them (``estimate.compile_bytes``)."""


def specialisation(call: dict) -> tuple:
    """Which compiled function (``rk.Specialised``) a ``simulate`` call of these keyword arguments
    uses: (method, kink-aware, then whether k_scale, k_table, ste_table, fluct_table, half_gap
    and a signal are given). Calls with different keys can be compiled in different processes at
    once; ``compile_cost`` gives a rough relative cold compile time."""
    kinks = bool(call.get("kink_aware")) and call.get("half_gap") is not None
    return (call.get("method", "rk4"), kinks,
            *(call.get(k) is not None for k in ("k_scale", "k_table", "ste_table", "fluct_table",
                                                "half_gap")),
            int(call.get("signal_stride") or 0) > 0)


def not_compiled(calls: list[dict], ask_cache: bool = True) -> set[tuple]:
    """The ``specialisation`` keys of ``simulate`` calls (keyword arguments) that are neither
    in Numba's cache nor compiled in this process (every one: ``ask_cache=False``)."""
    keys: dict[tuple, bool] = {}
    for call in calls:
        key = specialisation(call)
        if key not in keys:
            keys[key] = not (ask_cache and compiled(call))
    return {key for key, cold in keys.items() if cold}


COMPILE_REST_SHARE = 0.5
"""What each compile but the largest adds to a process's peak, as a share of its own
``COLD_COMPILE_BYTES`` (``compile_peak``)."""


def compile_peak(each: list[float]) -> float:
    """What several one-time compiles in one process add to its peak resident memory [bytes],
    from what each adds alone: the largest, and ``COMPILE_REST_SHARE`` of each other. LLVM's
    memory freed after a compile is partly reused by the next and partly kept: two plain RK5 in
    one run add +91 MB against +77 MB for one (``studies/stability_rig.yaml``); the six of
    studies/work_precision.yaml (stated 100, 100, 100, 100, 250 and 450 MB) add +410 MB
    compiled one after another with the kink-aware RK5 first, +541 MB in the order the study
    compiles them, the largest last; its first run peaked 523 MB above its second (806 against
    283 MB, ``scripts/bench_compile.py``), and on a cheap grid 551 MB (847 against 296 MB,
    ``tests/test_analysis_cost.py``; 27 Nov 2026): more than the largest alone (450 MB, which
    the estimate said), 775 MB here. 0 for none."""
    return max(each, default=0.0) + COMPILE_REST_SHARE * (sum(each) - max(each, default=0.0))


def compile_cost(key: tuple) -> float:
    """Rough relative cold compile time of the function of ``specialisation`` key ``key``."""
    return COLD_COMPILE_SECONDS[key[:2]] / COLD_COMPILE_SECONDS[("rk4", False)]


def precompile(calls: Sequence[dict], workers: int | None = None) -> float:
    """Compile the kernel specialisations that ``calls`` will need, in up to ``workers``
    processes side by side, and leave them in Numba's disk cache; returns the wall time [s].

    Each call is a dict of ``simulate`` keyword arguments without the step counts (e.g.
    ``Scene.kernel_kwargs`` plus ``method`` and ``kink_aware``; ``signal_stride`` > 0 if the
    real calls record a signal, since that is a specialisation of its own). Numba compiles on one
    core, so on a cold cache a set of scenes that needs several specialisations compiles about
    ``workers`` times faster; the later ``simulate`` calls of this process load them from the
    cache. With the cache warm it costs the start of the processes (about 2 s).

    Calls that use the same compiled function (driver and combination of terms switched off,
    ``rk.Specialised``) go to the same process: each keeps one cache index, which Numba updates
    by read-modify-write. ``workers`` defaults to the cores this process may use; with one worker
    or one function the calls are compiled in this process.
    """
    t0 = time.perf_counter()
    groups: dict[tuple, list[dict]] = {}
    for call in calls:
        groups.setdefault(specialisation(call), []).append(dict(call))
    if workers is None:
        workers = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (
            os.cpu_count() or 1)
    # the most expensive drivers first: the pool hands the cheap ones to whichever is free
    order = sorted(groups, key=lambda k: -compile_cost(k) * len(groups[k]))
    workers = max(1, min(int(workers), len(order)))
    if workers == 1:
        for key in order:
            _compile_group(groups[key])
    else:
        # spawn, not fork: Numba's workqueue and GNU OpenMP thread pools are not fork-safe once a
        # parallel kernel has run in this process. Imported here: multiprocessing (and the socket
        # module it brings) is 4-5 ms of every run's start that only a precompile needs.
        from concurrent.futures import ProcessPoolExecutor
        from multiprocessing import get_context

        with ProcessPoolExecutor(workers, mp_context=get_context("spawn")) as pool:
            for f in [pool.submit(_compile_group, groups[key]) for key in order]:
                f.result()
    return time.perf_counter() - t0


def _compile_group(calls: list[dict]) -> None:
    """Run every call for one step of one case: compiles (or loads) its specialisation."""
    for call in calls:
        kw = {k: (v if k in _NOT_PER_CASE or v is None else np.ravel(v)[:1])
              for k, v in call.items() if k not in ("n_transient", "n_record")}
        kw.setdefault("steps_per_period", 1)
        simulate(n_transient=0, n_record=1, **kw)


_NOT_PER_CASE = frozenset({"method", "k_table", "ste_table", "fluct_table", "steps_per_period",
                           "signal_stride", "kink_aware"})

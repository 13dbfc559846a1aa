"""CUDA backend of the batch kernel: one GPU thread per case, the same model, steps and outputs.

``simulate_cuda`` takes exactly the arguments of ``gearsweep.kernels.batch.simulate`` (plus
``precision`` and ``max_chunk``) and returns the same ``BatchResult``, so a caller switches device
with one line (``kernel_for(device)``). numba-cuda (numba's CUDA target) is imported only when a
CUDA kernel is built or a device is looked for: the CPU path never imports it.

What runs on the device
-----------------------
The thread of case ``i`` keeps its state, its constants and its running statistics in registers
for the whole run and calls the CPU kernel's own per-case functions of ``gearsweep.kernels.rk``:
``_rk4_step`` / ``_rk5_step`` (the one definition of each method: no coefficient is repeated
here), ``_k`` / ``_g`` (stiffness and force at a node), ``_stage_spring`` (backlash dead zone),
``_stat_step`` / ``_final_stats`` (the statistics of ``rk.STAT_NAMES``). numba-cuda compiles a
CPU ``@njit`` function called from a kernel as a device function, so the step is the same source
on both devices. The periodic tables at the stage nodes (``rk.NODES``) are read by step index as
on the CPU (every thread of a warp reads the same row: one broadcast load). Divergence is
checked once per mesh period, recorded signals are written with the same stride, and the
statistics are reduced on the device: only ``N_STATS + 2`` numbers per case come back.

Terms that are off (``None`` on the CPU) are compile-time constants of a kernel specialisation
(``_kernel``): numba-cuda cannot pass ``None`` to a kernel, so a ``None`` or ``1`` sentinel
closed over by the kernel stands in for the CPU kernel's array-or-None argument of ``_k``, ``_g``
and ``_stage_spring``, and a dummy array is passed in its place.

Agreement: float64 results agree with the CPU kernel to round-off (both contract a * b + c into
fused multiply-adds where the compiler chooses, so the last bits may differ; tests/test_cuda.py
checks 1e-12 relative on the simulator). ``precision="float32"`` keeps the state, the per-case
constants, the tables and the recorded signal in float32 (rounded after every step); the stage
arithmetic of the shared step is promoted by its float64 constants and the statistics are
accumulated in float64. Its error (about 1e-6 relative) is that of the float32 state.

Not on the device: the kink-aware step (``gearsweep.kernels.kink``: a scalar fix-up path with
gathers across lanes, written for the CPU's vector blocks). ``simulate_cuda(kink_aware=True)``
with backlash raises ``DeviceError``; without backlash it is the plain step, as on the CPU.

Large batches are cut into chunks that fit the device's free memory; chunks alternate between two
CUDA streams with pinned host buffers, so one chunk's transfers overlap the other's kernel.
"""

from __future__ import annotations

import functools
import hashlib
import importlib.util
import math
import os
import sys
import threading
import warnings
from pathlib import Path

import numpy as np

from gearsweep.errors import DeviceError
from gearsweep.kernels import rk
from gearsweep.kernels.batch import BatchResult, checked_inputs, simulate

DEVICES = ("cpu", "cuda", "auto")
"""Values of a study's ``solver.device``: ``auto`` is ``cuda`` where a CUDA GPU is present."""

PRECISIONS = {"float64": np.float64, "float32": np.float32}

THREADS_PER_BLOCK = 128
"""Threads (cases) per CUDA block: four warps; registers, not shared memory, bound occupancy."""

LOW_OCCUPANCY = r".*Grid size \d+ will likely result in GPU under-utilization"
"""numba-cuda's performance warning for a launch of few blocks, silenced: a study of few cases.
(``warnings`` matches a message from its start, and numba-cuda's begins with a terminal colour
code, ``\x1b[1mGrid size 1 ...``, as seen on an H200 with numba-cuda 0.30.4: hence ``.*``.)"""

MEMORY_FRACTION = 0.5
"""Share of the device's free memory that the two stream buffers may take together."""

CHUNKS = 4
"""A large batch goes in at least this many chunks, so that packing and copying one chunk
overlaps the kernel of another ..."""

MIN_CHUNK = 1 << 19
"""... but no chunk below this many cases (two waves of resident threads on an H100, 132 SMs x
2048), where a launch would leave the GPU part idle."""

# Rows of the per-case parameter matrix sent to the device (one transfer per chunk).
_PH, _PCM, _PKM, _PKA, _PGM, _PES, _PFS, _PB, _PBD, _PX0, _PV0 = range(11)
_N_PARAMS = 11
_N_OUT = rk.N_STATS + 2  # the statistics, then x_final and v_final


def _has_numba_cuda() -> bool:
    return importlib.util.find_spec("numba_cuda") is not None


def simulator() -> bool:
    """True when numba's CUDA simulator is switched on (``NUMBA_ENABLE_CUDASIM=1``): as numba-cuda
    read it when it was imported, else as the environment says now."""
    config = sys.modules.get("numba.cuda.core.config")
    if config is not None:
        return bool(config.ENABLE_CUDASIM)
    return os.environ.get("NUMBA_ENABLE_CUDASIM", "0") not in ("", "0")


cuda = None
"""``numba.cuda``, set by ``_cuda()`` on first use. A module global, not a local: the kernels use
it by this name, and the CUDA simulator runs them with the globals bound to the module swapped
for its fake one."""


def _cuda():
    """``numba.cuda`` from numba-cuda, imported on first use; ``DeviceError`` if not installed."""
    global cuda
    if not _has_numba_cuda():
        raise DeviceError("device cuda: numba-cuda is not installed; install the CUDA extra: "
                          "pip install -e \".[cuda]\" (see docs/gpu.md)")
    from numba import cuda as module

    cuda = module
    return module


def device_name() -> str:
    """The GPU a CUDA run computes on, as its result records it (``device_name``): its model
    (``numba.cuda.get_current_device().name``), or ``CUDA simulator`` under numba's simulator
    (``NUMBA_ENABLE_CUDASIM=1``), whose results were labelled ``cuda`` alone, as a GPU's (an
    outside tester); ``?`` where the device cannot be asked."""
    if simulator():
        return "CUDA simulator"
    try:
        name = _cuda().get_current_device().name
    except Exception:  # noqa: BLE001 - a broken driver: the result still says 'cuda'
        return "?"
    return name.decode("utf-8", "replace") if isinstance(name, bytes) else str(name)


@functools.cache
def gpu_present() -> bool:
    """True when numba-cuda is installed and sees a real CUDA GPU (the simulator does not count).
    Does not import numba-cuda when it is not installed. Asked once per process."""
    if not _has_numba_cuda() or simulator():
        return False
    try:
        return bool(_cuda().is_available())
    except Exception:  # a broken driver or toolkit: no usable GPU
        return False


def planned_device(device: str) -> str:
    """Where a study's chunks will run, for sizing and estimating them: ``"cuda"`` when the study
    asks for ``cuda`` (whether or not a GPU is there: running it is refused with one line by
    ``resolve_device``), or for ``auto`` on a machine with a GPU; else ``"cpu"``. Never raises."""
    return "cuda" if device == "cuda" or (device == "auto" and gpu_present()) else "cpu"


STATED_STEPS_PER_SECOND = 8e10
"""A GPU's rate for estimates [steps/s, the whole device]: B2 (backlash, RK4, float64) at 1e6
cases in whole ``simulate_cuda`` calls (packing, transfers, kernel), measured on an H200 on
26 Nov 2026: 8.2e10 (B1 9.1e10; at 4e6 cases 1.1e11 and 1.4e11; docs/gpu.md). An H100 has the
same 132 SMs. Not a promise: RK5 and the other terms cost more per step."""

HOST_MEMORY_BYTES = 0.9e9
"""Host memory a GPU run holds beyond the CPU run's estimate [bytes]: the CUDA context,
numba-cuda and its libraries, and the pinned buffers kept between calls. From one measurement:
the 1e7-case study with the GPU's chunks peaked at 1.52 GB, where the CPU-side estimate was
0.65 GB (H200, 26 Nov 2026, docs/data/device-2026-11-26). Since the next chunk's inputs and the
kernel results waiting for the writer are counted (``execute.CHUNKS_HELD``, later that day) the
CPU-side estimate of that study is 1.23 GB, the whole 2.13 GB: not measured on a GPU since."""

CHUNK_STEPS = 4e9
"""Integration steps per chunk of a study on the GPU (the CPU's ``plan.CHUNK_STEPS`` is 1e9):
about 0.05 s of an H100/H200, 1.6e6 cases of 2,560 steps (``studies/heavy/scale_1e6.yaml``).
Writing a chunk's results takes longer than integrating it, so a study is cut into several
chunks (seven at 1e7 such cases): the writer saves one while the GPU integrates the next,
and memory holds a few chunks, not the whole study."""


def resolve_device(device: str) -> str:
    """``"cpu"`` or ``"cuda"`` for a study's ``solver.device``; ``DeviceError`` (one line, exit 2
    in the CLI) when ``cuda`` is asked for and neither a GPU nor the simulator is there."""
    if device not in DEVICES:
        raise DeviceError(f"device must be one of {', '.join(DEVICES)}, got {device!r}")
    if device == "cpu":
        return "cpu"
    if device == "auto":
        return "cuda" if gpu_present() else "cpu"
    _cuda()
    if simulator() or gpu_present():
        return "cuda"
    raise DeviceError("device cuda: no CUDA GPU found (numba-cuda sees none); use device: cpu or"
                      " auto, or run where a GPU and its driver are present")


def kernel_for(device: str = "cpu", precision: str = "float64"):
    """The batch function for a device: ``simulate`` or ``simulate_cuda`` (same arguments)."""
    if resolve_device(device) == "cpu":
        if precision != "float64":
            raise DeviceError(f"precision {precision} needs device cuda; the CPU kernel is float64")
        return simulate
    return functools.partial(simulate_cuda, precision=precision)


def _row_values(tab, j, on):
    """The 5 node values of step ``j`` (zeros when the term is off: ``on`` is None)."""
    if on is None:
        return 0.0, 0.0, 0.0, 0.0, 0.0
    return tab[j, 0], tab[j, 1], tab[j, 2], tab[j, 3], tab[j, 4]


_row = None
"""``_row_values`` as a CUDA device function, made by ``_kernel`` on first use (numba-cuda is
imported only then). A module global, as are the CPU kernel's functions the kernels call
(``rk._rk4_step`` ...): numba-cuda keys its disk cache on the values a kernel closes over,
and a function's pickle carries an identity made anew in every process, so a kernel closing
over functions would never be found in the cache."""


@functools.cache
def _source_token() -> int:
    """A number that changes with the source of the CUDA kernels and of the CPU functions they
    call (this module and ``rk``): closed over by every kernel, so that its disk cache entry is
    not used after either file changed (numba-cuda's cache checks only this module's file)."""
    digest = hashlib.sha256()
    for module in (sys.modules[__name__], rk):
        digest.update(Path(module.__file__).read_bytes())
    return int(digest.hexdigest()[:15], 16)


@functools.cache
def _kernel(method: int, has_k: bool, has_kamp: bool, has_e: bool, has_f: bool, has_gap: bool,
            has_signal: bool, precision: str):
    """The CUDA kernel of one specialisation (terms on/off, method, precision), compiled on its
    first launch, or loaded from Numba's disk cache (``NUMBA_CACHE_DIR`` or ``__pycache__``, as
    the CPU kernels) where an earlier process compiled it for this GPU, and kept for the
    process. The kernel closes over plain values only (see ``_row``), each specialisation under
    a name of its own (one cache index each, as the CPU kernels: ``rk.Specialised``)."""
    global _row
    cu = _cuda()
    if _row is None:
        _row = cu.jit(device=True, inline="always")(_row_values)
    dt = PRECISIONS[precision]
    rk4 = method == rk.RK4
    # sentinels: None where the CPU kernel passes None (term off), 1 where it passes an array
    KT = 1 if has_k else None
    KA = 1 if has_kamp else None
    ET = 1 if has_e else None
    FT = 1 if has_f else None
    GAP = 1 if has_gap else None
    SIG = has_signal
    SOURCE = _source_token()
    ST_DIVERGED = rk.STATUS_DIVERGED
    NS = rk.N_STATS
    inf = math.inf
    nan = math.nan

    def integrate(P, n, ktab, etab, ftab, S, n_transient, n_record, spp, stride, out, status,
                  signal):
        i = cuda.grid(1)
        if i >= n or SOURCE < 0:  # SOURCE (>= 0) is a closed-over value: see _source_token
            return
        hh = P[_PH, i]
        h2 = dt(0.5 * hh)
        h6 = dt(hh / 6)
        c = P[_PCM, i]
        km = P[_PKM, i]
        ka = P[_PKA, i]
        gm = P[_PGM, i]
        es = P[_PES, i]
        fs = P[_PFS, i]
        b = P[_PB, i]
        bd = P[_PBD, i]
        X = P[_PX0, i]
        V = P[_PV0, i]
        dead = False
        # running statistics (float64 whatever the precision), see rk._stat_step
        max1 = -inf
        min1 = inf
        max2 = -inf
        min2 = inf
        s1 = 0.0
        s2 = 0.0
        shift = 0.0
        gaps = 0.0
        backs = 0.0
        impacts = 0.0
        prev = 0.0
        half = n_transient + n_record // 2
        j = 0
        jp = 0
        for s in range(n_transient + n_record):
            if s == half and s > n_transient:
                max1, min1, max2, min2 = max2, min2, -inf, inf
            K = _row(ktab, j, KT)
            E = _row(etab, j, ET)
            F = _row(ftab, j, FT)
            if s == n_transient and GAP is not None:  # the region of the state before the
                prev = rk._region(float(X), float(b))  # first recorded one (rk._mark_prev)
            if rk4:
                Xn, Vn = rk._rk4_step(X, V, hh, h2, h6, c,
                                      rk._k(km, ka, K[0], KT, KA), rk._k(km, ka, K[2], KT, KA),
                                      rk._k(km, ka, K[4], KT, KA),
                                      rk._g(gm, es, E[0], ET, fs, F[0], FT),
                                      rk._g(gm, es, E[2], ET, fs, F[2], FT),
                                      rk._g(gm, es, E[4], ET, fs, F[4], FT),
                                      b, GAP, True, 0.0)
            else:
                Xn, Vn = rk._rk5_step(X, V, hh, c,
                                      rk._k(km, ka, K[0], KT, KA), rk._k(km, ka, K[1], KT, KA),
                                      rk._k(km, ka, K[2], KT, KA), rk._k(km, ka, K[3], KT, KA),
                                      rk._k(km, ka, K[4], KT, KA),
                                      rk._g(gm, es, E[0], ET, fs, F[0], FT),
                                      rk._g(gm, es, E[1], ET, fs, F[1], FT),
                                      rk._g(gm, es, E[2], ET, fs, F[2], FT),
                                      rk._g(gm, es, E[3], ET, fs, F[3], FT),
                                      rk._g(gm, es, E[4], ET, fs, F[4], FT),
                                      b, GAP, True, 0.0)
            X = dt(Xn)
            V = dt(Vn)
            j = j + 1 if j + 1 < S else 0
            jp = jp + 1 if jp + 1 < spp else 0
            if s >= n_transient:
                if s == n_transient:  # the first recorded step: origin of the sums
                    shift = float(X)
                    if half == n_transient:
                        max1, min1, max2, min2 = max2, min2, -inf, inf
                max2, min2, s1, s2, gaps, backs, impacts, prev = rk._stat_step(
                    float(X), max2, min2, s1, s2, shift, float(b), gaps, backs, impacts, prev, GAP)
                if SIG:
                    r = s - n_transient
                    if r % stride == 0:
                        signal[i, r // stride] = X
            if jp == 0 and not (abs(X) <= bd and abs(V) < inf):
                dead = True
                X = dt(0.0)
                V = dt(0.0)
        if dead:
            for q in range(_N_OUT):
                out[q, i] = nan
            status[i] = ST_DIVERGED
            return
        out[NS, i] = X
        out[NS + 1, i] = V
        status[i] = 0
        if n_record == 0:
            for q in range(NS):
                out[q, i] = nan
            return
        st = rk._final_stats(n_record, spp, max1, min1, max2, min2, s1, s2, shift, gaps, backs,
                         impacts)
        for q in range(NS):
            out[q, i] = st[q]

    tag = "".join(f"{t}{int(on)}" for t, on in zip("kaefgs", (has_k, has_kamp, has_e, has_f,
                                                                has_gap, has_signal), strict=True))
    integrate.__name__ = integrate.__qualname__ = f"integrate_rk{method}_cuda_{precision}_{tag}"
    try:
        return cu.jit(integrate, cache=True)
    except RuntimeError as exc:  # no folder to keep it in: compiled in every process, as the CPU
        if "no locator available" not in str(exc):  # kernels are (gearsweep.jit._cached)
            raise
        return cu.jit(integrate)


def _chunk_cases(cu, per_case: int, n: int, max_chunk: int | None) -> int:
    """Cases per chunk: ``n / CHUNKS`` but at least ``MIN_CHUNK``, both stream buffers within
    ``MEMORY_FRACTION`` of the free memory, at most ``max_chunk``."""
    try:
        free = float(cu.current_context().get_memory_info()[0])
    except Exception:
        free = math.inf
    if not math.isfinite(free):  # the simulator reports no limit
        free = float(1 << 30)
    tpb = THREADS_PER_BLOCK
    m = -(-max(MIN_CHUNK, -(-n // CHUNKS)) // tpb) * tpb  # whole blocks, rounded up
    fit = int(free * MEMORY_FRACTION) // (2 * per_case)
    m = min(m, fit // tpb * tpb if fit >= tpb else fit)  # whole blocks, rounded down
    if max_chunk is not None:
        m = min(m, int(max_chunk))
    return max(1, min(m, n))


def simulate_cuda(
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
    precision: str = "float64",
    max_chunk: int | None = None,
) -> BatchResult:
    """``gearsweep.kernels.batch.simulate`` on a CUDA GPU (or numba's CUDA simulator): same
    arguments, same ``BatchResult`` (statistics float64 whatever the precision).

    precision : {"float64", "float32"}
        Arithmetic of the state (see the module docstring).
    max_chunk : int or None
        At most this many cases per kernel launch (default: as many as fit the free memory).
    """
    if precision not in PRECISIONS:
        raise ValueError(f"precision must be one of {sorted(PRECISIONS)}, got {precision!r}")
    h, n, tables, stride = checked_inputs(h, method, n_transient, n_record, steps_per_period,
                                          (k_table, ste_table, fluct_table), signal_stride)
    if kink_aware and half_gap is not None:
        raise DeviceError("kink_aware: the kink-aware step (gearsweep.kernels.kink) runs on the CPU"
                          " only; use device: cpu, or kink_aware: false on the GPU")
    cu = _cuda()
    dt = PRECISIONS[precision]
    S = next((t.shape[0] for t in tables if t is not None), 1)
    n_sig = (n_record + stride - 1) // stride if signal_stride > 0 else 0

    # per-case inputs as length-n views (no copy): each chunk is packed from them straight into
    # its pinned buffer, while the GPU runs the chunk before
    cols = [(r, np.broadcast_to(np.asarray(v, np.float64), (n,))) for r, v in (
        (_PH, h), (_PCM, damping), (_PKM, k_mean), (_PKA, 1.0 if k_scale is None else k_scale),
        (_PGM, force), (_PES, ste_scale), (_PFS, fluct_scale),
        (_PB, 0.0 if half_gap is None else half_gap), (_PBD, bound), (_PX0, x0), (_PV0, v0))]
    dummy = np.zeros((1, len(rk.NODES)), dt)
    d_tabs = [cu.to_device(dummy if t is None else t.astype(dt)) for t in tables]
    kern = _kernel(rk.METHODS[method], tables[0] is not None, k_scale is not None,
                   tables[1] is not None, tables[2] is not None, half_gap is not None,
                   n_sig > 0, precision)

    isz = np.dtype(dt).itemsize
    per_case = _N_PARAMS * isz + _N_OUT * 8 + 1 + n_sig * isz
    m = _chunk_cases(cu, per_case, n, max_chunk)
    stats = np.empty((rk.N_STATS, n))
    xf = np.empty(n)
    vf = np.empty(n)
    status = np.empty(n, np.int8)
    signal = np.empty((n, n_sig)) if n_sig else None

    # two buffer sets, one per stream: chunk k uses set k % 2 while chunk k - 1 finishes
    with _BUFFER_LOCK:
        sets = _buffer_sets(cu, dt, m, max(n_sig, 1), min(2, -(-n // m)))
        try:
            _run_chunks(cu, kern, sets, cols, d_tabs, n, m, S, n_transient, n_record,
                        steps_per_period, stride, n_sig, stats, xf, vf, status, signal)
        finally:
            if len(sets) * m * per_case > KEEP_BUFFER_BYTES:
                _BUFFERS.clear()  # too big to hold on to between calls
    return BatchResult(
        stats={name: stats[q] for q, name in enumerate(rk.STAT_NAMES)},
        x_final=xf,
        v_final=vf,
        status=status,
        signal=signal,
        substeps=np.zeros(n) if kink_aware else None,
    )


KEEP_BUFFER_BYTES = 512e6
"""Buffers of at most this much pinned host memory (and as much on the device) are kept for
the next call. A study's GPU chunks (``CHUNK_STEPS``) need about 0.2 GB; a 1e7-case study run
as one chunk needs about 1 GB, which would stay resident while its results are written (that
run's peak RSS was 3.8 GB with the buffers kept, 1.7 GB in an earlier call without, H200,
26 Nov 2026; how much of the difference the buffers make was not measured)."""

REUSE_WIDER = 4
"""Kept buffers serve a call of ``m`` cases per chunk when they hold at most this many times
``m`` (only the used part is copied, ``_copy``); a much smaller call gets buffers of its own."""

_BUFFER_LOCK = threading.Lock()
_BUFFERS: dict = {}


def _buffer_sets(cu, dt, m: int, sig_cols: int, count: int) -> list[dict]:
    """``count`` sets of pinned host and device buffers for chunks of ``m`` cases, kept from the
    last call when they are big enough: allocating them in every call (page-locking some 200 MB
    of host memory at 1e6 cases) cost as much as the kernel: B1 at 1e6 cases took 0.141 s a call
    with, 0.076 s without (H200, 26 Nov 2026, two calls on two fresh machines). The study
    runner calls once per chunk."""
    key = (np.dtype(dt).str, sig_cols)
    have = _BUFFERS.get("sets")
    if (have is not None and _BUFFERS["key"] == key and m <= _BUFFERS["m"] <= REUSE_WIDER * m
            and len(have) >= count):
        return have[:count]
    _BUFFERS.clear()  # drop the old ones first: their device memory is needed
    sets = []
    for _ in range(count):
        st = cu.stream()
        sets.append(dict(
            stream=st,
            h_in=cu.pinned_array((_N_PARAMS, m), dt),
            d_in=cu.device_array((_N_PARAMS, m), dt, stream=st),
            h_out=cu.pinned_array((_N_OUT, m), np.float64),
            d_out=cu.device_array((_N_OUT, m), np.float64, stream=st),
            h_st=cu.pinned_array(m, np.int8),
            d_st=cu.device_array(m, np.int8, stream=st),
            h_sig=cu.pinned_array((m, sig_cols), dt),
            d_sig=cu.device_array((m, sig_cols), dt, stream=st),
            pending=None,
        ))
    _BUFFERS.update(key=key, m=m, sets=sets)
    return sets


def _copy(src, dst, k: int, stream, cases_first: bool = False) -> None:
    """Copy the first ``k`` cases of a buffer between host and device (``src`` to ``dst``, one of
    them a device array): the whole buffer where it holds exactly ``k``, else the used part only
    (each row's first ``k`` columns: a kept buffer can be wider than the chunk). Buffers are
    (rows, cases) except the signal, (cases, samples): ``cases_first``."""
    device_to_host = hasattr(src, "copy_to_host")
    width = src.shape[0] if cases_first or src.ndim == 1 else src.shape[1]

    def one(s, d):
        if device_to_host:
            s.copy_to_host(d, stream=stream)
        else:
            d.copy_to_device(s, stream=stream)

    if k == width:
        one(src, dst)
    elif cases_first or src.ndim == 1:
        one(src[:k], dst[:k])
    else:
        for r in range(src.shape[0]):
            one(src[r, :k], dst[r, :k])


def _run_chunks(cu, kern, sets, cols, d_tabs, n, m, S, n_transient, n_record, steps_per_period,
                stride, n_sig, stats, xf, vf, status, signal) -> None:
    """Chunks of ``m`` cases through the buffer ``sets`` in turn (see ``simulate_cuda``)."""

    def drain(buf):
        if buf["pending"] is None:
            return
        a, k = buf["pending"]
        buf["stream"].synchronize()
        stats[:, a:a + k] = buf["h_out"][:rk.N_STATS, :k]
        xf[a:a + k] = buf["h_out"][rk.N_STATS, :k]
        vf[a:a + k] = buf["h_out"][rk.N_STATS + 1, :k]
        status[a:a + k] = buf["h_st"][:k]
        if signal is not None:
            signal[a:a + k] = buf["h_sig"][:k, :n_sig]
        buf["pending"] = None

    try:
        for q, a in enumerate(range(0, n, m)):
            k = min(m, n - a)
            buf = sets[q % len(sets)]
            drain(buf)
            st = buf["stream"]
            for r, col in cols:
                buf["h_in"][r, :k] = col[a:a + k]
            _copy(buf["h_in"], buf["d_in"], k, st)
            tpb = min(THREADS_PER_BLOCK, 32 * -(-k // 32))
            with warnings.catch_warnings():  # a small study fills few blocks: not a fault
                warnings.filterwarnings("ignore", message=LOW_OCCUPANCY)
                kern[-(-k // tpb), tpb, st](buf["d_in"], k, d_tabs[0], d_tabs[1], d_tabs[2], S,
                                            int(n_transient), int(n_record),
                                            int(steps_per_period), stride, buf["d_out"],
                                            buf["d_st"], buf["d_sig"])
            _copy(buf["d_out"], buf["h_out"], k, st)
            _copy(buf["d_st"], buf["h_st"], k, st)
            if signal is not None:
                _copy(buf["d_sig"], buf["h_sig"], k, st, cases_first=True)
            buf["pending"] = (a, k)
        for buf in sets:
            drain(buf)
    finally:  # an error part way: the kept buffers must not say a chunk is pending
        for buf in sets:
            if buf["pending"] is not None:
                buf["stream"].synchronize()
                buf["pending"] = None

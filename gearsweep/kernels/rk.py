"""Batch fixed-step Runge-Kutta kernel for the 1-DOF gear mesh model, Eq. (6) of the paper.

Per case ``i`` the kernel integrates, in SI units,

    p'' = G_i(t) - cm_i p' - K_i(t) f(p)
    K_i(t) = kmean_i + kamp_i ktab(t)                      stiffness / mass            [1/s^2]
    G_i(t) = gmean_i + escale_i etab(t) + fscale_i ftab(t) (force / mass) - e''(t)    [m/s^2]
    f(p)   = p - clip(p, -b_i, b_i)                        backlash dead zone, b = backlash / 2

with a fixed step ``h_i`` that divides the excitation cycle into ``S`` steps exactly. The periodic
shapes are then needed only at the stage nodes of one cycle: ``gearsweep.kernels.tables`` tabulates
them once at the quarter-step nodes ``NODES`` (shared by RK4 and RK5), and the kernel looks them up
by step index: no cos/sin inside the loop.

Scenes switch terms off by passing ``None``: ``ktab`` (constant stiffness), ``etab`` (no STE
excitation), ``ftab`` (no torque fluctuation), ``half_gap`` (no backlash, f(p) = p), ``signal``
(no time history). Numba compiles one specialisation per combination of ``None`` and array and
prunes the branches of the terms that are off, so a scene does not pay for them.

Cases are advanced in blocks of ``LANES``: all lanes of a block take the same step index, so the
inner loop over lanes is branch-free and LLVM vectorises it across cases (AVX2/AVX-512); ranges of
blocks are spread over Numba's number of threads (``Threaded``). Each case's arithmetic does not
depend on which block or thread runs it, so results are identical for any thread count.

Methods
-------
``RK4``: the classic fourth-order method (Kutta 1901), nodes c = (0, 1/2, 1/2, 1).
``RK5``: Butcher's fifth-order method (Butcher 1964; Butcher, *Numerical Methods for ODEs*, 2016,
Sec. 236): six stages, the fewest any fifth-order explicit method can have, rational coefficients,
and nodes c = (0, 1/4, 1/4, 1/2, 3/4, 1) on a quarter-step grid, so that one table of five
nodes per step serves both methods. (Dormand-Prince's fifth-order solution needs seven stages, or
six with FSAL, and nodes at 1/5, 3/10, 4/5, 8/9, which would need a table per node.)
"""

import math
import os
import threading
from collections import Counter
from concurrent.futures import ThreadPoolExecutor
from types import SimpleNamespace

import numba
import numpy as np

from gearsweep.jit import jit, jit_helper, unique_name
from gearsweep.kernels import tableaux
from gearsweep.kernels.fpenv import ftz_on, ftz_restore

LANES = 32
"""Cases advanced together in one vectorised block (four AVX-512 or eight AVX2 registers). 64
lanes would save 5 % on B2 but double the wasted lanes of continued sweeps, whose blocks are
mostly empty (one lane per sweep direction)."""

NODES = (0.0, 0.25, 0.5, 0.75, 1.0)
"""Stage nodes (fractions of a step) at which the periodic shapes are tabulated."""

RK4 = 4
RK5 = 5


def _unrolled_constants():
    """The coefficients of the unrolled RK4 and RK5 steps, taken from ``tableaux`` (the one home
    of the coefficients; Numba freezes these module globals into the compiled code as literals).

    The unrolled arithmetic below skips the tableaux' zero entries and, for RK5, uses the
    symmetry of Butcher's weights (b1 = b6, b3 = b5): checked here, so a change of tableau that
    the unrolled code cannot represent fails at import instead of integrating something else."""
    t4, t5 = tableaux.get("rk4"), tableaux.get("rk5")
    A4, A5, b4, b5 = t4.A, t5.A, t4.b, t5.b

    def zeros(A, keep):
        return all(A[i][j] == 0 for i in range(len(A)) for j in range(i) if (i, j) not in keep)

    ok = (zeros(A4, {(1, 0), (2, 1), (3, 2)}) and A4[1][0] == A4[2][1] and A4[3][2] == 1
          and t4.c == tuple(float(x) for x in (0.0, 0.5, 0.5, 1.0))
          and zeros(A5, {(1, 0), (2, 0), (2, 1), (3, 1), (3, 2), (4, 0), (4, 3), (5, 0), (5, 1),
                         (5, 2), (5, 3), (5, 4)})
          and b5[1] == 0 and b5[0] == b5[5] and b5[2] == b5[4]
          and tuple(float(x) for x in t5.c) == (0.0, 0.25, 0.25, 0.5, 0.75, 1.0))
    if not ok:
        raise RuntimeError("the unrolled RK4/RK5 steps do not match gearsweep.kernels.tableaux")
    n4, d4 = tableaux.integer_rows(b4)
    n6, d6 = tableaux.integer_rows(A5[5][:5])
    nb, db = tableaux.integer_rows(b5)
    f = float
    return dict(
        RK4_A21=f(A4[1][0]), RK4_A43=f(A4[3][2]), RK4_B=n4, RK4_D=d4,
        RK5_A21=f(A5[1][0]), RK5_A31=f(A5[2][0]), RK5_A32=f(A5[2][1]), RK5_A42=f(A5[3][1]),
        RK5_A43=f(A5[3][2]), RK5_A51=f(A5[4][0]), RK5_A54=f(A5[4][3]), RK5_N6=n6, RK5_D6=d6,
        RK5_B=nb, RK5_D=db)


_K = _unrolled_constants()
# RK4: a21 = a32 (the half step), a43, weights b = (b1, b2, b3, b4) / d (integers over 6).
_RK4_A21, _RK4_A43, _RK4_D = _K["RK4_A21"], _K["RK4_A43"], _K["RK4_D"]
_RK4_B1, _RK4_B2, _RK4_B3, _RK4_B4 = _K["RK4_B"]
# RK5 (Butcher): rows 2-5 of A as they stand; row 6 and the weights as integers over 7 and 90.
_RK5_A21, _RK5_A31, _RK5_A32 = _K["RK5_A21"], _K["RK5_A31"], _K["RK5_A32"]
_RK5_A42, _RK5_A43, _RK5_A51, _RK5_A54 = _K["RK5_A42"], _K["RK5_A43"], _K["RK5_A51"], _K["RK5_A54"]
_RK5_N61, _RK5_N62, _RK5_N63, _RK5_N64, _RK5_N65 = _K["RK5_N6"]
_RK5_D6 = _K["RK5_D6"]
_RK5_B1, _, _RK5_B3, _RK5_B4, _, _ = _K["RK5_B"]
_RK5_D = _K["RK5_D"]
METHODS = dict(zip(tableaux.KERNEL_METHODS, (RK4, RK5), strict=True))
STAGES = {code: tableaux.get(name).stages for name, code in METHODS.items()}
"""Stages (right-hand side evaluations) of a step of each method, from its tableau."""

# Columns of the statistics array returned per case.
ST_MAX, ST_MIN, ST_MEAN, ST_RMS, ST_CONTACT_LOSS, ST_BACKSIDE, ST_IMPACTS, ST_SETTLE = range(8)
N_STATS = 8
STAT_NAMES = (
    "p_max",
    "p_min",
    "p_mean",
    "p_rms",
    "contact_loss_fraction",
    "backside_contact_fraction",
    "impacts_per_period",
    "settle_error",
)
"""``settle_error``: change of the extremes between the first and the second half of the recorded
window, relative to the peak-to-peak: near 0 for a settled periodic response."""

_BIT = np.array([1 << l for l in range(LANES)], np.int64)
"""Lane ``l``'s bit in a block's crossing mask (a constant table: one masked OR per vector of
lanes, where shifting by the lane index took three vector operations)."""

STATUS_OK = 0
STATUS_DIVERGED = 1
"""The state became non-finite or left ``|p| <= bound``: the case was stopped, statistics NaN."""

# Rows of the per-block scratch array ``w`` (row r of lane l at o + r * LANES + l, block offset
# o): the state, the constants and the running statistics of the LANES cases of one block live in
# ONE allocation, so every access is at a constant offset from one base pointer. LLVM can then
# prove the rows disjoint and vectorise the lane loops without run-time alias checks (with one
# array per row it had to emit, and run every step, pairwise overlap checks, and gave up on the
# statistics loop altogether).
(_X, _V, _H, _H2, _H6, _C, _KM, _KA, _GM, _ES, _FS, _B, _BD, _DEAD,  # state and constants
 _MAX1, _MIN1, _MAX2, _MIN2,  # extremes over the first / second half of the recorded window
 _SUM, _SUM2, _SHIFT,  # sums of (p - shift) and (p - shift)^2, shift = first recorded p
 _GAP, _BACK, _IMP, _PREV,  # counts of steps apart / on the back flank / impacts
 _XO, _VO, _NSUB) = range(28)  # kink-aware kernel: state at the start of the step, substeps
_N_ROWS = 28
_BLOCK = _N_ROWS * LANES


_KINK = False
"""Whether the lane code below is the kink-aware kernel's (``gearsweep.kernels.kink``, which
compiles copies of it with ``_KINK = True``) or the plain kernel's. A module global, not an
argument: Numba freezes it into the code, so each kernel's copy is compiled with the other's
branches pruned (as an argument, the kink-aware driver inlined both at Numba IR level)."""


@jit_helper
def _dead_zone(x, b):
    """Backlash force law f(p) of Eq. (8), branch-free: p - clip(p, -b, b)."""
    y = x if x < b else b
    y = y if y > -b else -b
    return x - y


@jit_helper
def _spring(x, b, half_gap):
    if half_gap is None:
        return x
    return _dead_zone(x, b)


@jit_helper
def _k(km, ka, kt, ktab, kamp):
    """Stiffness/mass at one node: the mean alone when the stiffness is constant, the table
    alone when every case shares it (``kamp is None``), else mean + scale * table."""
    if ktab is None:
        return km
    if kamp is None:
        return kt
    return km + ka * kt


@jit_helper
def _g(gm, es, et, etab, fs, ft, ftab):
    """Force/mass at one node: mean force, STE term and torque fluctuation, as switched on."""
    g = gm
    if etab is not None:
        g += es * et
    if ftab is not None:
        g += fs * ft
    return g


@jit_helper
def _row(tab, j):
    """The 5 node values of step ``j`` as a tuple (registers, not memory); zeros when off."""
    if tab is None:
        return (0.0, 0.0, 0.0, 0.0, 0.0)
    return (tab[j, 0], tab[j, 1], tab[j, 2], tab[j, 3], tab[j, 4])


@jit_helper
def _scratch(nsub):
    """Zeroed scratch of ``nsub`` blocks, one flat array starting on a 64-byte boundary (Numba
    aligns to 32 bytes only; an AVX-512 load or store that straddles two cache lines is slower).
    Block q's row r, lane l is at o + r * LANES + l with o = q * _BLOCK: the helpers below take
    the block's offset ``o`` (a slice per block would be a new array view, reference-counted with
    atomic instructions, every step)."""
    size = nsub * _BLOCK
    buf = np.zeros(size + 8)
    off = ((-buf.ctypes.data) % 64) // 8
    return buf[off:off + size]


@jit_helper
def _law(X, b, half_gap):
    """The force law f(p) = on (p - sh) that the kink-aware kernel's trial step uses in every
    stage: the law of the region of the step's start p = X (contact beyond +-b: on, sh = +-b;
    gap: off), extended smoothly beyond its boundaries, so that the trial step is one smooth
    trajectory that ``kink._fix_lanes`` can interpolate. Where every stage stays in the start
    region this is the dead zone itself, bit for bit: p - b in contact (the plain kernel's own
    operation) and 0 in the gap. The plain kernel (``_KINK`` False) keeps the dead zone in every
    stage."""
    if _KINK and half_gap is not None:
        return (X > b) | (X < -b), (b if X > b else -b)
    return True, 0.0


@jit_helper
def _stage_spring(x, b, half_gap, on, sh):
    """f(p) at a stage: the start region's law in the kink-aware kernel (see ``_law``; one
    subtraction with AVX-512 zero-masking), else ``_spring``."""
    if _KINK and half_gap is not None:
        return (x - sh) if on else 0.0
    return _spring(x, b, half_gap)


@jit_helper
def _after_step(w, o, l, X, V, Xn, half_gap, rec):
    """Bookkeeping of lane ``l`` after its step from (X, V) to end position Xn, while all three
    are in registers; returns the lane's crossing bit (0 or 1 << l).

    Plain kernel: with ``rec`` the end p enters the statistics; the bit is 0. Kink-aware kernel
    (``_KINK``): the start state is kept for the fix-up (rows _XO, _VO); the bit is set if the
    step ended in another region of the dead zone (p > b, |p| <= b, p < -b) than it started, so
    its trial step, taken with the start region's law, must be redone; with ``rec`` the START p
    enters the statistics: a fix-up may still change the end p, and the start p of step s is the
    final end p of step s - 1 (the driver shifts the window by one step and records the last end
    p after its loop, so both kernels record the same states). ``rec`` is a literal at every
    call site and ``_KINK`` a constant: each combination is one branch-free vector loop, and the bits
    OR-reduce into a vector register (no separate pass over the lanes)."""
    if _KINK:
        w[o + _XO * LANES + l] = X
        w[o + _VO * LANES + l] = V
        if rec:
            _record(w, o, l, X, half_gap)
        if half_gap is not None:
            b = w[o + _B * LANES + l]
            crossed = ((X > b) != (Xn > b)) | ((X < -b) != (Xn < -b))
            return _BIT[l] if crossed else np.int64(0)
        return np.int64(0)
    if rec:
        _record(w, o, l, Xn, half_gap)
    return np.int64(0)


@jit_helper
def _rk4_step(X, V, hh, q2, h6, c, Ka, Kb, Kc, Ga, Gb, Gc, b, half_gap, on, sh):
    """One classic RK4 step of one case from (X, V); returns the end state (p, p').

    ``hh``, ``q2``, ``h6``: h, h/2, h/6; ``c``: damping/mass; ``Ka, Kb, Kc`` and ``Ga, Gb, Gc``:
    stiffness/mass and force/mass at the nodes 0, 1/2, 1 of the step; ``b``, ``half_gap``,
    ``on``, ``sh``: the force law (``_stage_spring``). The one definition of the method:
    the CPU lane loop ``_rk4_lanes`` and the CUDA kernel (``gearsweep.kernels.cuda``) both call it.
    """
    k1x = V
    k1v = Ga - c * V - Ka * _stage_spring(X, b, half_gap, on, sh)
    x2 = X + q2 * k1x
    v2 = V + q2 * k1v
    k2x = v2
    k2v = Gb - c * v2 - Kb * _stage_spring(x2, b, half_gap, on, sh)
    x3 = X + q2 * k2x
    v3 = V + q2 * k2v
    k3x = v3
    k3v = Gb - c * v3 - Kb * _stage_spring(x3, b, half_gap, on, sh)
    x4 = X + hh * (_RK4_A43 * k3x)
    v4 = V + hh * (_RK4_A43 * k3v)
    k4x = v4
    k4v = Gc - c * v4 - Kc * _stage_spring(x4, b, half_gap, on, sh)
    return (X + h6 * (_RK4_B1 * k1x + _RK4_B2 * k2x + _RK4_B3 * k3x + _RK4_B4 * k4x),
            V + h6 * (_RK4_B1 * k1v + _RK4_B2 * k2v + _RK4_B3 * k3v + _RK4_B4 * k4v))


@jit_helper
def _rk5_step(X, V, h, c, K0, K1, K2, K3, K4, G0, G1, G2, G3, G4, b, half_gap, on, sh):
    """One step of Butcher's six-stage fifth-order method for one case from (X, V); returns the
    end state. ``K0..K4``, ``G0..G4``: stiffness/mass and force/mass at the ``NODES`` of the
    step; other arguments as ``_rk4_step``. Used by ``_rk5_lanes`` and the CUDA kernel."""
    # stage 1, c = 0
    a1 = V
    b1 = G0 - c * V - K0 * _stage_spring(X, b, half_gap, on, sh)
    # stage 2, c = 1/4
    x2 = X + h * (_RK5_A21 * a1)
    v2 = V + h * (_RK5_A21 * b1)
    a2 = v2
    b2 = G1 - c * v2 - K1 * _stage_spring(x2, b, half_gap, on, sh)
    # stage 3, c = 1/4
    x3 = X + h * (_RK5_A31 * a1 + _RK5_A32 * a2)
    v3 = V + h * (_RK5_A31 * b1 + _RK5_A32 * b2)
    a3 = v3
    b3 = G1 - c * v3 - K1 * _stage_spring(x3, b, half_gap, on, sh)
    # stage 4, c = 1/2
    x4 = X + h * (_RK5_A42 * a2 + _RK5_A43 * a3)
    v4 = V + h * (_RK5_A42 * b2 + _RK5_A43 * b3)
    a4 = v4
    b4 = G2 - c * v4 - K2 * _stage_spring(x4, b, half_gap, on, sh)
    # stage 5, c = 3/4
    x5 = X + h * (_RK5_A51 * a1 + _RK5_A54 * a4)
    v5 = V + h * (_RK5_A51 * b1 + _RK5_A54 * b4)
    a5 = v5
    b5 = G3 - c * v5 - K3 * _stage_spring(x5, b, half_gap, on, sh)
    # stage 6, c = 1
    x6 = X + h * (_RK5_N61 * a1 + _RK5_N62 * a2 + _RK5_N63 * a3 + _RK5_N64 * a4
                  + _RK5_N65 * a5) / _RK5_D6
    v6 = V + h * (_RK5_N61 * b1 + _RK5_N62 * b2 + _RK5_N63 * b3 + _RK5_N64 * b4
                  + _RK5_N65 * b5) / _RK5_D6
    a6 = v6
    b6 = G4 - c * v6 - K4 * _stage_spring(x6, b, half_gap, on, sh)
    return (X + h * (_RK5_B1 * (a1 + a6) + _RK5_B3 * (a3 + a5) + _RK5_B4 * a4) / _RK5_D,
            V + h * (_RK5_B1 * (b1 + b6) + _RK5_B3 * (b3 + b5) + _RK5_B4 * b4) / _RK5_D)


@jit_helper
def _rk4_lanes(w, o, half_gap, kamp, ktab, K, etab, E, ftab, F, rec):
    """One classic RK4 step for every lane of the block at offset ``o`` of ``w``; K, E, F: table
    rows of the step (5 nodes). ``rec``: the step's p enters the running statistics (its end
    p in the plain kernel; in the kink-aware one, its start p, see ``_after_step``). Returns the bit mask
    of the lanes whose step crossed a backlash boundary (kink-aware kernel only, else 0)."""
    mask = np.int64(0)
    for l in range(LANES):
        hh = w[o + _H * LANES + l]
        q2 = w[o + _H2 * LANES + l]
        b = w[o + _B * LANES + l]
        c = w[o + _C * LANES + l]
        kl = w[o + _KM * LANES + l]
        kal = w[o + _KA * LANES + l]
        X = w[o + _X * LANES + l]
        V = w[o + _V * LANES + l]
        on, sh = _law(X, b, half_gap)
        Ka = _k(kl, kal, K[0], ktab, kamp)
        Kb = _k(kl, kal, K[2], ktab, kamp)
        Kc = _k(kl, kal, K[4], ktab, kamp)
        gl = w[o + _GM * LANES + l]
        el = w[o + _ES * LANES + l]
        fl = w[o + _FS * LANES + l]
        Ga = _g(gl, el, E[0], etab, fl, F[0], ftab)
        Gb = _g(gl, el, E[2], etab, fl, F[2], ftab)
        Gc = _g(gl, el, E[4], etab, fl, F[4], ftab)
        Xn, Vn = _rk4_step(X, V, hh, q2, w[o + _H6 * LANES + l], c, Ka, Kb, Kc, Ga, Gb, Gc, b,
                           half_gap, on, sh)
        w[o + _X * LANES + l] = Xn
        w[o + _V * LANES + l] = Vn
        mask |= _after_step(w, o, l, X, V, Xn, half_gap, rec)
    return mask


@jit_helper
def _rk5_lanes(w, o, half_gap, kamp, ktab, K, etab, E, ftab, F, rec):
    """One step of Butcher's six-stage fifth-order method for every lane (arguments and result
    as RK4)."""
    mask = np.int64(0)
    for l in range(LANES):
        h = w[o + _H * LANES + l]
        b = w[o + _B * LANES + l]
        c = w[o + _C * LANES + l]
        kl = w[o + _KM * LANES + l]
        kal = w[o + _KA * LANES + l]
        gl = w[o + _GM * LANES + l]
        el = w[o + _ES * LANES + l]
        fl = w[o + _FS * LANES + l]
        X = w[o + _X * LANES + l]
        V = w[o + _V * LANES + l]
        on, sh = _law(X, b, half_gap)
        G0 = _g(gl, el, E[0], etab, fl, F[0], ftab)
        G1 = _g(gl, el, E[1], etab, fl, F[1], ftab)
        G2 = _g(gl, el, E[2], etab, fl, F[2], ftab)
        G3 = _g(gl, el, E[3], etab, fl, F[3], ftab)
        G4 = _g(gl, el, E[4], etab, fl, F[4], ftab)
        K0 = _k(kl, kal, K[0], ktab, kamp)
        K1 = _k(kl, kal, K[1], ktab, kamp)
        K2 = _k(kl, kal, K[2], ktab, kamp)
        K3 = _k(kl, kal, K[3], ktab, kamp)
        K4 = _k(kl, kal, K[4], ktab, kamp)
        Xn, Vn = _rk5_step(X, V, h, c, K0, K1, K2, K3, K4, G0, G1, G2, G3, G4, b, half_gap, on,
                           sh)
        w[o + _X * LANES + l] = Xn
        w[o + _V * LANES + l] = Vn
        mask |= _after_step(w, o, l, X, V, Xn, half_gap, rec)
    return mask


OPTIONAL = {"kamp": 3, "ktab": 4, "etab": 7, "ftab": 9, "half_gap": 10, "signal": 17}
"""The drivers' arguments that may be ``None`` (a term switched off), by position."""


class Specialised:
    """The compiled part of a batch driver (``Threaded``), as one function per combination of the
    terms switched off (``OPTIONAL`` arguments that are ``None``), each with a Numba cache index
    of its own.

    ``driver(args)`` picks (and on first use creates) the function of the arguments' combination: a run
    loads from the disk cache only what it calls, and two processes that compile different
    combinations at once (``batch.precompile``, the main job's workers, dask workers on a cold
    cache) never update the same index (Numba updates an index by read-modify-write, and an
    entry lost that way could point at another specialisation's data file). ``make()`` returns
    a new Python function of the driver's compiled part (the range of blocks that ``Threaded``
    calls), which ``decorator`` compiles (``jit``; the kink-aware drivers'
    ``jit_block_cached``); ``stats`` sums Numba's cache counters over the combinations used in
    this process.
    """

    def __init__(self, make, name: str, decorator=jit) -> None:
        self._make = make
        self._name = name
        self._decorator = decorator
        self._drivers: dict[tuple[bool, ...], object] = {}
        self._lock = threading.Lock()

    def driver(self, args):
        """The compiled function for ``args`` (the driver's positional arguments)."""
        key = tuple(args[i] is not None for i in OPTIONAL.values())
        d = self._drivers.get(key)
        if d is None:
            with self._lock:
                d = self._drivers.get(key)
                if d is None:
                    f = self._make()
                    tag = "".join(f"{k[0] if k != 'kamp' else 'a'}{int(on)}"
                                  for k, on in zip(OPTIONAL, key, strict=True))
                    d = self._drivers[key] = self._decorator(unique_name(f, f"{self._name}_{tag}"))
        return d

    @property
    def name(self) -> str:
        """The compiled functions' name (before the combination of terms)."""
        return self._name

    @property
    def stats(self):
        hits, misses = Counter(), Counter()
        for d in list(self._drivers.values()):
            hits.update(d.stats.cache_hits)
            misses.update(d.stats.cache_misses)
        return SimpleNamespace(cache_hits=hits, cache_misses=misses)


class Threaded:
    """A batch driver whose blocks are stepped by Numba's number of threads
    (``numba.get_num_threads()`` of the calling thread): each a Python thread that calls the
    compiled function (``nogil``, ``Specialised``) on ranges of blocks it takes in turn, the
    calling thread among them; with one thread, or one block, the calling thread alone, with no
    hand-over at all.

    The ranges shrink as the blocks run out (``ranges``: "guided" scheduling): a thread that
    took the last range while the other was held up (by a core shared with the result writer, by
    more crossings) leaves the other waiting for a short range only. With equal ranges (four
    per thread) the calling thread of a 1e7-case study waited 1.0 s in all for the last range
    of the other; the kernel alone (no writer beside it), 0.5 s (docs/benchmark.md).

    ``layout(args)`` gives, for the driver's arguments, the compiled function's arguments before
    the range of blocks (``lo``, ``hi``), the number of blocks and the new output arrays that
    follow the range (and are returned). Each case's arithmetic does not depend on its block or
    thread, so the results do not change with either (tested bit for bit).

    Not a ``prange`` loop: Numba's parallel lowering of that loop built a gufunc around its body
    and ran the body's code through LLVM there and once more in the driver: 1.0 of the 3.7 s of a
    plain RK4 specialisation's compile, 2.3 of the kink-aware RK4's 13 s (docs/benchmark.md).
    """

    SHORTEST = 64
    """The shortest range is ``1 / (SHORTEST x threads)`` of the blocks (at least one block):
    the time the other threads may wait at the end, against one call of the compiled function
    (tens of microseconds) per range."""

    _pool = None
    _pool_lock = threading.Lock()

    def __init__(self, ranges: Specialised, layout) -> None:
        self._ranges = ranges
        self._layout = layout

    def arguments(self, args: tuple) -> tuple:
        """The compiled function's arguments for the driver's ``args``: every block, and new
        output arrays."""
        head, nblocks, outputs = self._layout(args)
        return (*head, 0, nblocks, *outputs)

    def driver(self, args: tuple):
        """The compiled function (Numba dispatcher) for the driver's ``args``."""
        return self._ranges.driver(args)

    @property
    def stats(self):
        return self._ranges.stats

    @property
    def name(self) -> str:
        """The compiled functions' name (before the combination of terms)."""
        return self._ranges.name

    def __call__(self, *args):
        head, nblocks, outputs = self._layout(args)
        f = self.driver(args)
        threads = max(1, min(numba.get_num_threads(), nblocks))
        if threads == 1:
            f(*head, 0, nblocks, *outputs)
            return outputs
        todo = iter(self.ranges(nblocks, threads))
        lock = threading.Lock()

        def work():
            while True:
                with lock:
                    r = next(todo, None)
                if r is None:
                    return
                f(*head, r[0], r[1], *outputs)

        others = [self._executor().submit(work) for _ in range(threads - 1)]
        try:
            work()
        finally:  # also on an exception here (Ctrl-C): no further ranges, the started ones end
            with lock:
                for _ in todo:
                    pass
            for fut in others:
                fut.result()
        return outputs

    @classmethod
    def ranges(cls, nblocks: int, threads: int) -> list[tuple[int, int]]:
        """The ranges of blocks ``[lo, hi)``, in the order they are taken: each ``1 / (2
        threads)`` of the blocks not yet taken, down to the shortest (``SHORTEST``)."""
        shortest = max(1, nblocks // (cls.SHORTEST * threads))
        out, lo = [], 0
        while lo < nblocks:
            hi = min(nblocks, lo + max(shortest, (nblocks - lo) // (2 * threads)))
            out.append((lo, hi))
            lo = hi
        return out

    @classmethod
    def _executor(cls):
        """The worker threads of every ``Threaded`` driver (at most Numba's thread count of
        this process less one: the calling thread works too)."""
        with cls._pool_lock:
            if cls._pool is None:
                cls._pool = ThreadPoolExecutor(max(1, numba.config.NUMBA_NUM_THREADS - 1),
                                               thread_name_prefix="gearsweep-kernel")
            return cls._pool

    @classmethod
    def _forget_pool(cls) -> None:
        """In a forked child (a local dask cluster's worker): the parent's threads are not
        there, so a new pool is made on first use."""
        cls._pool = None
        cls._pool_lock = threading.Lock()


os.register_at_fork(after_in_child=Threaded._forget_pool)


def _driver(method):
    """The batch driver of one method (a separate compiled function per method, so that a scene
    compiles only the method it uses: Butcher's RK5 loop takes twice as long to compile as RK4's;
    and per combination of terms switched off, ``Specialised``), its blocks spread over threads
    (``Threaded``)."""
    return Threaded(Specialised(lambda: _integrate_function(method), f"integrate_rk{method}"),
                    _plain_layout)


def _plain_layout(args: tuple) -> tuple:
    """The plain drivers' ``Threaded`` layout: the arguments before the range (the driver's own),
    the number of blocks of ``LANES``, and new output arrays (stats, xf, vf, status)."""
    n = args[0].shape[0]
    return args, -(-n // LANES), (np.empty((n, N_STATS)), np.empty(n), np.empty(n),
                                  np.zeros(n, np.int8))


def _integrate_function(method):
    """A new Python function of the batch driver of one method (``_driver`` compiles it)."""
    rk4 = method == RK4

    def integrate(h, cm, kmean, kamp, ktab, gmean, escale, etab, fscale, ftab, half_gap, bound, x0,
                  v0, n_transient, n_record, steps_per_period, signal, stride, lo, hi, stats, xf,
                  vf, status):
        n = h.shape[0]
        S = _cycle(ktab, etab, ftab)
        for blk in range(lo, hi):
            csr = ftz_on()  # subnormals flushed to 0 in this block's work (``fpenv``)
            i0 = blk * LANES
            w = _scratch(1)
            _load(w, 0, i0, n, h, cm, kmean, kamp, gmean, escale, fscale, half_gap, bound, x0, v0)
            half = n_transient + n_record // 2
            j = 0  # step index within the excitation cycle: s % S
            jp = 0  # step index within the mesh period: s % steps_per_period
            for s in range(n_transient + n_record):
                K = _row(ktab, j)
                E = _row(etab, j)
                F = _row(ftab, j)
                # Recorded steps update the statistics inside the lane loop, while the new p is
                # in registers. ``rec`` is a constant at each call site, so each of the two
                # copies LLVM inlines is one branch-free vector loop (a run-time flag stops LLVM from
                # vectorising the dead-zone case: B2 0.16 s -> 0.25 s). The first recorded step
                # sets the origin of the sums; the region the impacts start from is that of the
                # state before it (``_mark_prev``).
                rec = s > n_transient
                if s == half and rec:
                    _split(w, 0)
                if s == n_transient:  # the state before the first recorded one: apart or not
                    _mark_prev(w, 0, half_gap)
                if rk4:
                    if rec:
                        _rk4_lanes(w, 0, half_gap, kamp, ktab, K, etab, E, ftab, F, True)
                    else:
                        _rk4_lanes(w, 0, half_gap, kamp, ktab, K, etab, E, ftab, F, False)
                elif rec:
                    _rk5_lanes(w, 0, half_gap, kamp, ktab, K, etab, E, ftab, F, True)
                else:
                    _rk5_lanes(w, 0, half_gap, kamp, ktab, K, etab, E, ftab, F, False)
                j = j + 1 if j + 1 < S else 0
                jp = jp + 1 if jp + 1 < steps_per_period else 0
                if s == n_transient:
                    _start_record(w, 0, half_gap)
                    if half == n_transient:
                        _split(w, 0)
                    _accumulate(w, 0, half_gap)
                if signal is not None and s >= n_transient:
                    _sample(w, 0, signal, s - n_transient, stride, i0, n)
                if jp == 0:
                    _check(w, 0)
            _finish(w, 0, i0, n, n_record, steps_per_period, stats, xf, vf, status)
            ftz_restore(csr)

    integrate.__doc__ = _INTEGRATE_DOC
    return integrate


_INTEGRATE_DOC = """Integrate a batch of cases; see the module docstring for the model.

    Parameters
    ----------
    h, cm, kmean, kamp, gmean, escale, fscale, bound, x0, v0 : ndarray (n,)
        Step [s]; damping/mass [1/s]; stiffness/mass mean [1/s^2] and scale of ``ktab``
        (``kamp=None``: ``ktab`` is the stiffness/mass itself, shared by every case);
        mean force/mass [m/s^2]; scales of ``etab`` and ``ftab``; divergence bound on |p| [m];
        initial displacement [m] and velocity [m/s].
    ktab, etab, ftab : ndarray (S, 5) or None
        Shapes at the ``NODES`` of each of the ``S`` steps of one excitation cycle.
    half_gap : ndarray (n,) or None
        Half the backlash b [m]; ``None``: no backlash, f(p) = p.
    n_transient, n_record : int
        Steps discarded, then steps whose end states are recorded in the statistics.
    steps_per_period : int
        Steps per mesh period: impacts are counted per mesh period and divergence is checked once
        every mesh period.
    signal : ndarray (n, n_record // stride) or None
        Filled with p at every ``stride``-th recorded step.
    lo, hi : int
        The blocks of ``LANES`` cases this call steps: ``lo`` ... ``hi - 1`` (``Threaded``).
    stats : ndarray (n, N_STATS)
    xf, vf : ndarray (n,)
        State at the end [m], [m/s] (for continuation and monodromy matrices).
    status : ndarray (n,) int8
        Filled for the cases of those blocks. The driver (``INTEGRATE``, ``Threaded``) is called
        without ``lo`` ... ``status`` and returns (stats, xf, vf, status) for the whole batch.
    """


@jit_helper
def _cycle(ktab, etab, ftab):
    """Steps per excitation cycle: the length of whichever table is present (1 if none)."""
    if ktab is not None:
        return ktab.shape[0]
    if etab is not None:
        return etab.shape[0]
    if ftab is not None:
        return ftab.shape[0]
    return 1


@jit_helper
def _load(w, o, i0, n, h, cm, kmean, kamp, gmean, escale, fscale, half_gap, bound, x0, v0):
    """Fill the scratch array of the block starting at case ``i0`` (lanes past ``n`` repeat the
    last case; their results are discarded)."""
    for l in range(LANES):
        i = min(i0 + l, n - 1)
        w[o + _X * LANES + l] = x0[i]
        w[o + _V * LANES + l] = v0[i]
        w[o + _H * LANES + l] = h[i]
        w[o + _H2 * LANES + l] = _RK4_A21 * h[i]
        w[o + _H6 * LANES + l] = h[i] / _RK4_D
        w[o + _C * LANES + l] = cm[i]
        w[o + _KM * LANES + l] = kmean[i]
        w[o + _KA * LANES + l] = kamp[i] if kamp is not None else 1.0
        w[o + _GM * LANES + l] = gmean[i]
        w[o + _ES * LANES + l] = escale[i]
        w[o + _FS * LANES + l] = fscale[i]
        w[o + _BD * LANES + l] = bound[i]
        if half_gap is not None:
            w[o + _B * LANES + l] = half_gap[i]


@jit_helper
def _sample(w, o, signal, r, stride, i0, n):
    """Store p of the block's cases as recorded step ``r`` if it falls on the stride."""
    if r % stride == 0:
        for l in range(LANES):
            if i0 + l < n:
                signal[i0 + l, r // stride] = w[o + _X * LANES + l]


@jit_helper
def _mark_prev(w, o, half_gap):
    """Each lane's region (``_PREV``, ``_region``) in the state just before the first recorded
    one, so that an entry into contact at the window's first step is counted: over whole periods
    of a periodic motion every entry is then counted once, wherever the window starts."""
    if half_gap is not None:
        for l in range(LANES):
            w[o + _PREV * LANES + l] = _region(w[o + _X * LANES + l], w[o + _B * LANES + l])


@jit_helper
def _start_record(w, o, half_gap):
    """Reset the running statistics at the first recorded step (``_PREV`` is ``_mark_prev``'s)."""
    for l in range(LANES):
        for q in range(_MAX1, _PREV):
            w[o + q * LANES + l] = 0.0
        w[o + _MAX1 * LANES + l] = -np.inf
        w[o + _MAX2 * LANES + l] = -np.inf
        w[o + _MIN1 * LANES + l] = np.inf
        w[o + _MIN2 * LANES + l] = np.inf
        # sums about the first sample: no cancellation in the rms
        w[o + _SHIFT * LANES + l] = w[o + _X * LANES + l]


@jit_helper
def _accumulate(w, o, half_gap):
    """Enter the current state of every lane into the running statistics."""
    for l in range(LANES):
        _record(w, o, l, w[o + _X * LANES + l], half_gap)


@jit_helper
def _split(w, o):
    """Halfway through the window: keep the extremes so far as the first half's, restart."""
    for l in range(LANES):
        w[o + _MAX1 * LANES + l] = w[o + _MAX2 * LANES + l]
        w[o + _MIN1 * LANES + l] = w[o + _MIN2 * LANES + l]
        w[o + _MAX2 * LANES + l] = -np.inf
        w[o + _MIN2 * LANES + l] = np.inf


@jit_helper
def _record(w, o, l, X, half_gap):
    """Enter p = X of lane ``l`` into its running statistics (``_stat_step``)."""
    r = w[o + _MAX2 * LANES + l], w[o + _MIN2 * LANES + l], w[o + _SUM * LANES + l], \
        w[o + _SUM2 * LANES + l]
    if half_gap is None:
        r = _stat_step(X, r[0], r[1], r[2], r[3], w[o + _SHIFT * LANES + l], 0.0, 0.0, 0.0, 0.0,
                       0.0, half_gap)
    else:
        r = _stat_step(X, r[0], r[1], r[2], r[3], w[o + _SHIFT * LANES + l], w[o + _B * LANES + l],
                       w[o + _GAP * LANES + l], w[o + _BACK * LANES + l], w[o + _IMP * LANES + l],
                       w[o + _PREV * LANES + l], half_gap)
        w[o + _GAP * LANES + l] = r[4]
        w[o + _BACK * LANES + l] = r[5]
        w[o + _IMP * LANES + l] = r[6]
        w[o + _PREV * LANES + l] = r[7]
    w[o + _MAX2 * LANES + l] = r[0]  # the running extremes (see _split)
    w[o + _MIN2 * LANES + l] = r[1]
    w[o + _SUM * LANES + l] = r[2]
    w[o + _SUM2 * LANES + l] = r[3]


@jit_helper
def _stat_step(X, pmax, pmin, s1, s2, shift, b, gaps, backs, impacts, prev, half_gap):
    """The running statistics of one case after entering p = X, branch-free (counts are sums of
    0.0/1.0; an impact is a step into contact on a flank from the gap or from the other flank,
    whose gap the step crossed): extremes, sums of (p - shift) and its square, and with backlash
    the counts of steps apart / on the back flank / impacts and the case's region (``prev``: 1
    drive flank, 0 apart, -1 back flank, ``_region``). The one definition, used by ``_record``
    and the CUDA kernel."""
    pmax = max(pmax, X)
    pmin = min(pmin, X)
    d = X - shift
    s1 += d
    s2 += d * d
    if half_gap is not None:
        gap = 1.0 if abs(X) < b else 0.0
        back = 1.0 if X < -b else 0.0
        gaps += gap
        backs += back
        region = 1.0 - gap - 2.0 * back
        impacts += (1.0 - gap) * (1.0 if region != prev else 0.0)  # into contact: an impact
        prev = region
    return pmax, pmin, s1, s2, gaps, backs, impacts, prev


@jit_helper
def _region(X, b):
    """The region of the dead zone p = X is in: 1 drive flank, 0 apart (|p| < b), -1 back flank
    (p < -b); ``_stat_step``'s ``prev``."""
    return 0.0 if abs(X) < b else (-1.0 if X < -b else 1.0)


@jit_helper
def _check(w, o):
    """Stop lanes whose state is non-finite or beyond the bound (checked once per mesh period)."""
    for l in range(LANES):
        if not (abs(w[o + _X * LANES + l]) <= w[o + _BD * LANES + l] and abs(w[o + _V * LANES + l]) < np.inf):
            w[o + _DEAD * LANES + l] = 1.0
            w[o + _X * LANES + l] = 0.0
            w[o + _V * LANES + l] = 0.0


@jit_helper
def _finish(w, o, i0, n, n_record, spp, stats, xf, vf, status):
    """Turn the accumulators of one block into per-case statistics and final states."""
    for l in range(LANES):
        i = i0 + l
        if i >= n:
            break
        if w[o + _DEAD * LANES + l] != 0.0:
            for q in range(N_STATS):
                stats[i, q] = np.nan
            xf[i] = np.nan
            vf[i] = np.nan
            status[i] = STATUS_DIVERGED
            continue
        xf[i] = w[o + _X * LANES + l]
        vf[i] = w[o + _V * LANES + l]
        if n_record == 0:
            for q in range(N_STATS):
                stats[i, q] = np.nan
            continue
        out = _final_stats(n_record, spp, w[o + _MAX1 * LANES + l], w[o + _MIN1 * LANES + l],
                           w[o + _MAX2 * LANES + l], w[o + _MIN2 * LANES + l],
                           w[o + _SUM * LANES + l], w[o + _SUM2 * LANES + l],
                           w[o + _SHIFT * LANES + l], w[o + _GAP * LANES + l],
                           w[o + _BACK * LANES + l], w[o + _IMP * LANES + l])
        for q in range(N_STATS):
            stats[i, q] = out[q]


@jit_helper
def _final_stats(n_record, spp, max1, min1, max2, min2, s1, s2, shift, gaps, backs, impacts):
    """The ``STAT_NAMES`` of one case from its accumulators after ``n_record`` recorded steps
    (``_stat_step``; extremes of the first and second half of the window), as a tuple in the
    order of the ``ST_*`` columns. Used by ``_finish`` and the CUDA kernel."""
    mean_d = s1 / n_record
    pmax = max(max1, max2)
    pmin = min(min1, min2)
    drift = max(abs(max2 - max1), abs(min2 - min1))
    pp = pmax - pmin
    return (pmax, pmin, shift + mean_d, math.sqrt(max(s2 / n_record - mean_d * mean_d, 0.0)),
            gaps / n_record, backs / n_record, impacts * spp / n_record,
            drift / pp if pp > 0 else 0.0)


INTEGRATE = {RK4: _driver(RK4), RK5: _driver(RK5)}
"""The batch driver of each method (``METHODS`` value -> ``Threaded``)."""

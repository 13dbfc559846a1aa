"""Kink-aware fixed-step RK4/RK5: steps that cross the backlash boundaries are finished in the
new region.

Same model, tables, arguments and statistics as ``gearsweep.kernels.batch.simulate`` (see its
docstring); the two kernels differ only in steps whose end state lies in another region of the
dead zone than their start state (regions p > b, |p| <= b, p < -b).

Why
---
The dead zone f(p) is continuous with a jump in its slope at p = +-b, so p''' jumps at a
crossing: p is only C^2 there and p' only C^1. A Runge-Kutta step that straddles a crossing makes
a local error O(h^2) in p' (and O(h^3) in p) whatever its order, and with a bounded number of
crossings per mesh period the global error of the plain step falls only as h^2. Finishing each
piece of the step inside one region restores the method's order.

How
---
1. A kink block is up to ``SUB_MAX`` plain blocks of ``LANES`` cases in one scratch array (same
   layout and lane code as the plain kernel, ``rk._rk4_lanes`` / ``rk._rk5_lanes``); each takes
   a vectorised trial step in which every stage uses the force law of the region the lane
   starts the step in, f(p) = sw (p - sh), extended smoothly past its boundaries
   (``rk._law``): the trial is one smooth trajectory, and where all stages stay in that region
   it is the plain step bit for bit. In the same lane loop (``rk._after_step``) every lane
   keeps its start state and sets its bit in a crossing mask if its region at the step's end
   (p > b, |p| <= b, p < -b) differs from the region at its start. The statistics take each
   step's start state there too, so no extra pass over the lanes is needed. The plain blocks of
   a kink block are interleaved over the batch (block blk holds blk, blk + nblocks, ...), so
   each thread's share spans the whole sweep.
2. After all blocks' trial steps, each block's flagged lanes (less the lanes past the batch's
   end and the diverged ones: one AND with a per-block bit mask) are corrected by
   ``_fix_lanes`` in one branch-free pass vectorised across lanes like the lane loops. Where
   they fill at least ``DENSE`` of the vectors of 8 lanes they span, the pass runs in place on
   the block's rows: neighbouring cases of a sweep cross in the same steps (B2: 7.7 of the 8
   lanes of a vector with a crossing cross too), so nothing is moved. Sparser crossing lanes
   (cases in random order, chaotic neighbours) are gathered from all blocks of the kink block
   into group blocks of the same layout at the end of the scratch, corrected there together
   and copied back (one inlined call site for both kinds of job, ``_fix_jobs``). RK4
   (``_correct_rk4``): the crossing time and velocity from the cubic
   Hermite interpolant of the trial (inverse-cubic estimate, Newton steps), then the trial's end
   plus the closed-form Taylor series of the difference between the two laws' trajectories
   (a linear equation in which the forcing cancels), to tau^5: no substep. RK5
   (``_correct_rk5``): the crossing from the quintic Hermite interpolant (p'' at both ends too)
   and a substep of RK5 with the new law. Cost per crossing: 0.25 step-equivalents (RK4, the
   coefficients at the crossing) or 4/3 (RK5, a substep and two evaluations of p'').
3. The few lanes the vectorised pass cannot finish (a second crossing within the step, Newton not
   converged, e.g. for a grazing crossing) go through the scalar ``_fixup``: substeps with the
   region's law to the estimate of the cubic Hermite interpolant, ``_project`` onto the boundary
   (Taylor polynomial of the method's order, Newton's method for the time left), redone to the
   projection's estimate until accepted (at most ``NEWTON_MAX`` times), and repeated for up to
   ``MAX_CROSSINGS`` crossings.
Steps of lanes that do not cross are untouched, so a case whose stages never leave their
region gives results identical bit for bit to the plain kernel.

Why the order is kept: with a bounded number of crossings per mesh period, a crossing step needs
only a local error O(h^4) (RK4) / O(h^5) (RK5) for the global error to keep the method's order.
RK4's correction is O(h^5) in p' (series truncation O(tau^5); crossing time O(h^4) and velocity
O(h^3) from the cubic enter as K p' tau dt and K tau^2 dv); RK5's interpolant gives p' at the
crossing to the trial's end error amplified by 1/h, O(h^5), and a crossing time off by delta
costs K p' delta^2 (the two laws agree on the boundary). Measured: tests/test_precision.py,
docs/precision.md.

Coefficients inside a step
--------------------------
The tables hold K(t) and G(t) only at the five quarter-step nodes of each step. The fix-ups need
them at other times; they are taken from the quartic through the five node values of the step
(its monomial coefficients in the step fraction, which also give the time derivatives needed
by the series and the Taylor polynomial; tabulated once per batch for the S steps of the cycle,
``_monomial_table``). For smooth periodic coefficients its error is O(h^5)
relative to the coefficient; it acts only at crossing steps (a bounded number per period), so
it adds O(h^6) to the global error: below the order of both methods. (A linear interpolant
would add O(h^2) per crossing and undo the gain.) This keeps ``simulate``'s table conventions;
no Fourier coefficients are needed.

Limitations
-----------
A crossing followed by a return within the same step (both ends in one region) is not detected:
that step is taken with the start region's law throughout. This happens only for grazing
contacts, where the excursion lasts less than one step. A crossing at which p' is tiny
(tangential) goes to the scalar path, which may not converge in ``NEWTON_MAX`` substeps; the
last estimate is kept.

Cost counter: ``integrate`` also returns the extra work per case in step-equivalents (right-hand
side evaluations / stages of the method): a vectorised fix-up counts 0.25 (RK4) or 4/3 (RK5), the
scalar path one per substep and one per projection.

Speed: on benchmark B2 (4.6 % of lane-steps cross) the kink-aware kernel takes about 1.43 to 1.5
times the plain kernel's wall time (``scripts/bench_kink.py``, one or two threads, 24 Nov 2026,
docs/precision.md; 1.6 with every crossing lane gathered, 1.7 before the monomial table, 2.0 to
2.1 before the changes of that day): about 1.10 for the trial lane loops with their crossing
test (1.065 of it without keeping the start state), the rest for the correction passes (a
dependency chain) and the 0.23 % of crossings (grazing ones) that take the scalar path. With the
cases in random order (every crossing lane gathered) it is about 2.0. Without backlash (``half_gap=None``) the
detection is compiled out and the cost is the plain kernel's.
"""

import types

import numpy as np
from numba.cpython.unsafe.numbers import leading_zeros, trailing_zeros

from gearsweep.jit import inlined_copies, jit_block_cached, jit_helper, jit_inline
from gearsweep.kernels import rk
from gearsweep.kernels.fpenv import ftz_on, ftz_restore
from gearsweep.kernels.rk import (
    _B,
    _BIT,
    _BLOCK,
    _C,
    _DEAD,
    _ES,
    _FS,
    _GM,
    _H,
    _KA,
    _KM,
    _NSUB,
    _RK4_A21,
    _RK4_A43,
    _RK4_B1,
    _RK4_B2,
    _RK4_B3,
    _RK4_B4,
    _RK4_D,
    _RK5_A21,
    _RK5_A31,
    _RK5_A32,
    _RK5_A42,
    _RK5_A43,
    _RK5_A51,
    _RK5_A54,
    _RK5_B1,
    _RK5_B3,
    _RK5_B4,
    _RK5_D,
    _RK5_D6,
    _RK5_N61,
    _RK5_N62,
    _RK5_N63,
    _RK5_N64,
    _RK5_N65,
    _V,
    _VO,
    _X,
    _XO,
    LANES,
    N_STATS,
    RK4,
    RK5,
    Specialised,
    Threaded,
)

# The rk helpers this driver calls, as copies inlined at Numba IR level, like this module's own
# helpers (``jit_inline``; why: ``gearsweep.jit.inlined_copies``). ``_fixup``, the scalar path for
# rare lanes, stays a function of its own (its helpers are inlined into it).
_RK = inlined_copies({name: getattr(rk, name) for name in (
    "_accumulate", "_check", "_cycle", "_finish", "_g", "_k", "_load", "_rk4_lanes", "_rk5_lanes",
    "_row", "_sample", "_scratch", "_split", "_start_record", "_mark_prev", "_law",
    "_stage_spring", "_spring",
    "_dead_zone", "_after_step", "_record", "_stat_step", "_region", "_final_stats", "_rk4_step",
    "_rk5_step")}, {"_KINK": True})
_accumulate, _check, _cycle, _finish = (_RK[n] for n in ("_accumulate", "_check", "_cycle",
                                                         "_finish"))
_g, _k, _load, _rk4_lanes, _rk5_lanes = (_RK[n] for n in ("_g", "_k", "_load", "_rk4_lanes",
                                                          "_rk5_lanes"))
_row, _sample, _scratch, _split, _start_record, _mark_prev = (_RK[n] for n in (
    "_row", "_sample", "_scratch", "_split", "_start_record", "_mark_prev"))

_RK4_METHOD = True
"""The method the fix-up helpers below serve (``_substep`` ... ``_fix_jobs``): a module global,
not an argument, so that the copies of them for each method (``_FIXUPS``) are compiled with the
other method's branch pruned before Numba inlines them (an argument would keep both: the RK4
driver inlined, typed and lowered RK5's correction too)."""

MAX_CROSSINGS = 4
"""Crossings handled within one step; further ones are stepped over as in the plain kernel."""
NEWTON_MAX = 4
"""Substeps used at most to reach one crossing."""
SUB_MAX = 4
"""A kink block is up to this many plain blocks of ``LANES`` stepped one after the other; the
crossing lanes of its blocks that are gathered (``DENSE``) share the fix-up's vectors. Four
keep the block's scratch in a 32 KB L1 data cache: with eight, B2 took 1.48 instead of 1.40 times
the plain kernel (kink/plain, medians of 7 rounds, 24 Nov 2026, fix-ups in place)."""
DENSE = 0.5
"""A block's crossing lanes are fixed up in place when they are at least this fraction of the
lanes of the vectors of 8 they span (neighbouring cases of a sweep cross in the same steps: on
B2, 7.7 of the 8 lanes of a vector with a crossing cross); sparser ones are gathered first, so
that random neighbours do not cost a vector each."""
GROUP_TOL = 1e-3
"""The vectorised fix-up's crossing time is accepted when its last Newton update is below this
fraction of the step: the error left is of order its square (quadratic convergence), and a
crossing time off by delta costs K p' delta^2 (far below the step's own error)."""
TAU_MAX = 0.125
"""A substep's end is moved onto the boundary by ``_project`` only if it is at most this fraction
of the step away from it in time; farther, the substep is redone to the new estimate."""
ROOT_TOL = 1e-6
"""Newton's method for the crossing time has converged when its last update is below this
fraction of the step (the error after that update is far smaller: the convergence is
quadratic). A crossing time off by delta switches the force law where the two laws differ by
K p' delta: an error of order K p' delta^2 in p', far below the step's own."""

_MONO = np.array([[3.0, 0.0, 0.0, 0.0, 0.0],
                  [-25.0, 48.0, -36.0, 16.0, -3.0],
                  [70.0, -208.0, 228.0, -112.0, 22.0],
                  [-80.0, 288.0, -384.0, 224.0, -48.0],
                  [32.0, -128.0, 192.0, -128.0, 32.0]]) / 3.0
"""Inverse Vandermonde matrix of the nodes 0, 1/4, 1/2, 3/4, 1: monomial coefficients in theta
of the quartic through five node values."""

@jit_inline
def _monomials(row, P, q):
    """P[q, :] = coefficients of the quartic in theta through the five node values ``row``."""
    for k in range(5):
        acc = 0.0
        for i in range(5):
            acc += _MONO[k, i] * row[i]
        P[q, k] = acc


@jit_inline
def _monomial_table(ktab, etab, ftab, S):
    """Monomial coefficients of every step's quartics (``_monomials``), once per batch: table
    [j, q] for step j of the cycle and q = 0, 1, 2 for the stiffness, STE and torque shapes
    (rows of the tables that are off stay zero)."""
    PT = np.zeros((S, 3, 5))
    for j in range(S):
        if ktab is not None:
            _monomials(ktab[j], PT[j], 0)
        if etab is not None:
            _monomials(etab[j], PT[j], 1)
        if ftab is not None:
            _monomials(ftab[j], PT[j], 2)
    return PT


@jit_inline
def _val(P, q, th):
    return (((P[q, 4] * th + P[q, 3]) * th + P[q, 2]) * th + P[q, 1]) * th + P[q, 0]


@jit_inline
def _d1(P, q, th):
    return ((4.0 * P[q, 4] * th + 3.0 * P[q, 3]) * th + 2.0 * P[q, 2]) * th + P[q, 1]


@jit_inline
def _d2(P, q, th):
    return (12.0 * P[q, 4] * th + 6.0 * P[q, 3]) * th + 2.0 * P[q, 2]


@jit_inline
def _region(x, b):
    """+1 beyond b (drive flank in contact), -1 below -b (back flank), 0 in the gap."""
    return (1.0 if x > b else 0.0) - (1.0 if x < -b else 0.0)


@jit_inline
def _kg(P, th, ktab, kamp, etab, ftab, kl, kal, gl, el, fl):
    """Stiffness/mass and force/mass at fraction ``th`` of the step, from the quartics (terms
    that are off are pruned as in the plain kernel)."""
    kk = _k(kl, kal, _val(P, 0, th), ktab, kamp)
    gg = _g(gl, el, _val(P, 1, th), etab, fl, _val(P, 2, th), ftab)
    return kk, gg


@jit_inline
def _kg_dt(P, th, ih, ktab, kamp, etab, ftab, kal, el, fl):
    """First and second time derivatives of stiffness/mass and force/mass at ``th``."""
    K1 = 0.0
    K2 = 0.0
    if ktab is not None:
        s = 1.0 if kamp is None else kal
        K1 = s * _d1(P, 0, th) * ih
        K2 = s * _d2(P, 0, th) * ih * ih
    G1 = 0.0
    G2 = 0.0
    if etab is not None:
        G1 += el * _d1(P, 1, th) * ih
        G2 += el * _d2(P, 1, th) * ih * ih
    if ftab is not None:
        G1 += fl * _d1(P, 2, th) * ih
        G2 += fl * _d2(P, 2, th) * ih * ih
    return K1, K2, G1, G2


@jit_inline
def _substep(X, V, ta, tb, h, sw, sh, c, P, ktab, kamp, etab, ftab, kl, kal, gl, el, fl):
    """One RK step of the same method from fraction ``ta`` to ``tb`` of the step ``h``, with the
    force law f(p) = sw (p - sh) of one region extended smoothly beyond its boundary: the stages
    never see the kink (a stage on the far side of the boundary evaluated with the dead zone
    itself would cost O(H^4) per crossing and cap RK5 at order 4)."""
    eta = tb - ta
    H = eta * h
    if _RK4_METHOD:
        tm = ta + _RK4_A21 * eta
        K1, G1 = _kg(P, ta, ktab, kamp, etab, ftab, kl, kal, gl, el, fl)
        K2, G2 = _kg(P, tm, ktab, kamp, etab, ftab, kl, kal, gl, el, fl)
        K3, G3 = _kg(P, tb, ktab, kamp, etab, ftab, kl, kal, gl, el, fl)
        k1v = G1 - c * V - K1 * sw * (X - sh)
        k1x = V
        x2 = X + _RK4_A21 * H * k1x
        v2 = V + _RK4_A21 * H * k1v
        k2v = G2 - c * v2 - K2 * sw * (x2 - sh)
        k2x = v2
        x3 = X + _RK4_A21 * H * k2x
        v3 = V + _RK4_A21 * H * k2v
        k3v = G2 - c * v3 - K2 * sw * (x3 - sh)
        k3x = v3
        x4 = X + H * (_RK4_A43 * k3x)
        v4 = V + H * (_RK4_A43 * k3v)
        k4v = G3 - c * v4 - K3 * sw * (x4 - sh)
        k4x = v4
        return (X + H * (1.0 / _RK4_D) * (_RK4_B1 * k1x + _RK4_B2 * k2x + _RK4_B3 * k3x
                                          + _RK4_B4 * k4x),
                V + H * (1.0 / _RK4_D) * (_RK4_B1 * k1v + _RK4_B2 * k2v + _RK4_B3 * k3v
                                          + _RK4_B4 * k4v))
    K1, G1 = _kg(P, ta, ktab, kamp, etab, ftab, kl, kal, gl, el, fl)
    K2, G2 = _kg(P, ta + 0.25 * eta, ktab, kamp, etab, ftab, kl, kal, gl, el, fl)
    K4, G4 = _kg(P, ta + 0.5 * eta, ktab, kamp, etab, ftab, kl, kal, gl, el, fl)
    K5, G5 = _kg(P, ta + 0.75 * eta, ktab, kamp, etab, ftab, kl, kal, gl, el, fl)
    K6, G6 = _kg(P, tb, ktab, kamp, etab, ftab, kl, kal, gl, el, fl)
    a1 = V
    b1 = G1 - c * V - K1 * sw * (X - sh)
    x2 = X + H * (_RK5_A21 * a1)
    v2 = V + H * (_RK5_A21 * b1)
    a2 = v2
    b2 = G2 - c * v2 - K2 * sw * (x2 - sh)
    x3 = X + H * (_RK5_A31 * a1 + _RK5_A32 * a2)
    v3 = V + H * (_RK5_A31 * b1 + _RK5_A32 * b2)
    a3 = v3
    b3 = G2 - c * v3 - K2 * sw * (x3 - sh)
    x4 = X + H * (_RK5_A42 * a2 + _RK5_A43 * a3)
    v4 = V + H * (_RK5_A42 * b2 + _RK5_A43 * b3)
    a4 = v4
    b4 = G4 - c * v4 - K4 * sw * (x4 - sh)
    x5 = X + H * (_RK5_A51 * a1 + _RK5_A54 * a4)
    v5 = V + H * (_RK5_A51 * b1 + _RK5_A54 * b4)
    a5 = v5
    b5 = G5 - c * v5 - K5 * sw * (x5 - sh)
    x6 = X + H * (_RK5_N61 * a1 + _RK5_N62 * a2 + _RK5_N63 * a3 + _RK5_N64 * a4
                  + _RK5_N65 * a5) * (1.0 / _RK5_D6)
    v6 = V + H * (_RK5_N61 * b1 + _RK5_N62 * b2 + _RK5_N63 * b3 + _RK5_N64 * b4
                  + _RK5_N65 * b5) * (1.0 / _RK5_D6)
    a6 = v6
    b6 = G6 - c * v6 - K6 * sw * (x6 - sh)
    return (X + H * (_RK5_B1 * (a1 + a6) + _RK5_B3 * (a3 + a5) + _RK5_B4 * a4) * (1.0 / _RK5_D),
            V + H * (_RK5_B1 * (b1 + b6) + _RK5_B3 * (b3 + b5) + _RK5_B4 * b4) * (1.0 / _RK5_D))


@jit_inline
def _hermite_root(X, V, TX, TV, H, bd):
    """Fraction s in [0, 1] where the cubic Hermite interpolant of (X, V) -> (TX, TV) over a
    step H meets ``bd`` (start and end on opposite sides), branch-free: the secant estimate and
    one Newton step on g(s) = c0 + c1 s + c2 s^2 + c3 s^3, kept inside [0, 1]. It needs no high
    accuracy: ``_project`` corrects it."""
    c0 = X - bd
    c1 = H * V
    c2 = 3.0 * (TX - X) - H * (2.0 * V + TV)
    c3 = 2.0 * (X - TX) + H * (V + TV)
    g1 = c0 + c1 + c2 + c3
    den = c0 - g1
    s = c0 / den if den != 0.0 else 0.5
    s = min(max(s, 0.0), 1.0)
    return _newton_cubic(s, c0, c1, c2, c3)  # one step: ``_project`` corrects the rest


@jit_inline
def _newton_cubic(s, c0, c1, c2, c3):
    """One Newton step on c0 + c1 s + c2 s^2 + c3 s^3 = 0, kept inside [0, 1]."""
    g = c0 + s * (c1 + s * (c2 + s * c3))
    dg = c1 + s * (2.0 * c2 + s * 3.0 * c3)
    return min(max(s - g / dg if dg != 0.0 else s, 0.0), 1.0)


@jit_inline
def _hermite_return(X, V, TX, TV, H, bd):
    """As ``_hermite_root`` for a start on the boundary (just after a crossing): the smallest
    root in (0, 1] of the quadratic g(s) / s (1 if none)."""
    c1 = H * V
    c2 = 3.0 * (TX - X) - H * (2.0 * V + TV)
    c3 = 2.0 * (X - TX) + H * (V + TV)
    if c3 == 0.0:
        s = -c1 / c2 if c2 != 0.0 else 1.0
    else:
        disc = c2 * c2 - 4.0 * c3 * c1
        if disc < 0.0:
            return 1.0
        sq = np.sqrt(disc)
        q = -0.5 * (c2 + (sq if c2 >= 0.0 else -sq))
        r1 = q / c3
        r2 = c1 / q if q != 0.0 else 2.0
        s = 2.0
        if 0.0 < r1 <= 1.0:
            s = r1
        if 0.0 < r2 <= 1.0 and r2 < s:
            s = r2
    return min(max(s, 0.0), 1.0)


@jit_helper
def _fixup(X0, V0, TX, TV, h, b, c, P, ktab, kamp, etab, ftab, kl, kal, gl, el, fl):
    """Redo one step of one lane that crossed a boundary, any number of crossings (up to
    ``MAX_CROSSINGS``); returns (x, v, substeps taken). The scalar path, for what the vectorised
    ``_fix_lanes`` leaves: several crossings in one step, a start on a boundary, a crossing
    estimate that needs more than one substep.

    Per crossing: a substep (force law of the region being left) to the estimate from the
    Hermite cubic; then ``_project`` gives the remaining time to the boundary and, if that time
    is short, moves the state onto the boundary; otherwise the substep is redone to the new
    estimate. Then a substep with the new region's law finishes the step. Substeps and
    projections are counted alike (a projection costs about as much as a substep)."""
    th = 0.0
    X = X0
    V = V0
    reg = _region(X0, b)
    nsub = 0
    for _ in range(MAX_CROSSINGS):
        treg = _region(TX, b)
        if treg == reg:
            break
        if reg != 0.0:
            bd = reg * b
            new = 0.0
        else:
            bd = b if treg > 0.0 else -b
            new = treg
        sw = abs(reg)
        sh = b if reg > 0.0 else -b
        rem = 1.0 - th
        if abs(X - bd) <= 1e-9 * abs(TX - bd):
            sf = _hermite_return(X, V, TX, TV, rem * h, bd)
        else:
            sf = _hermite_root(X, V, TX, TV, rem * h, bd)
        tc = th + rem * sf
        CX = X
        CV = V
        for _r in range(NEWTON_MAX):
            CX, CV = _substep(X, V, th, tc, h, sw, sh, c, P, ktab, kamp, etab, ftab, kl, kal,
                              gl, el, fl)
            tn, PX, PV, ok = _project(CX, CV, tc, bd, h, sw, sh, c, P, ktab, kamp, etab,
                                      ftab, kl, kal, gl, el, fl)
            nsub += 2
            if ok and tn >= th:
                CX = PX
                CV = PV
                tc = tn
                break
            if not (tn > th and tn <= 1.0) or _r == NEWTON_MAX - 1:
                break
            tc = tn
        X = CX
        V = CV
        th = tc
        reg = new
        if th >= 1.0:
            TX = X
            TV = V
            break
        sw = abs(reg)
        sh = b if reg > 0.0 else -b
        TX, TV = _substep(X, V, th, 1.0, h, sw, sh, c, P, ktab, kamp, etab, ftab, kl, kal,
                          gl, el, fl)
        nsub += 1
    return TX, TV, nsub


@jit_inline
def _d3(P, q, th):
    return 24.0 * P[q, 4] * th + 6.0 * P[q, 3]


@jit_inline
def _kg_dt3(P, th, ih, ktab, kamp, etab, ftab, kal, el, fl):
    """Third time derivatives of stiffness/mass and force/mass at ``th`` (as ``_kg_dt``)."""
    K3 = 0.0
    G3 = 0.0
    ih3 = ih * ih * ih
    if ktab is not None:
        K3 = (1.0 if kamp is None else kal) * _d3(P, 0, th) * ih3
    if etab is not None:
        G3 += el * _d3(P, 1, th) * ih3
    if ftab is not None:
        G3 += fl * _d3(P, 2, th) * ih3
    return K3, G3


@jit_inline
def _project(X, V, tc, bd, h, sw, sh, c, P, ktab, kamp, etab, ftab, kl, kal, gl, el, fl):
    """From the state (X, V) at fraction ``tc`` of the step, near the boundary ``bd``: the time
    tau to the boundary and the state there, from a Taylor polynomial in time of the method's
    order (degree 4 for RK4, 5 for RK5) with the force law sw (p - sh) of the region being left.
    The derivatives of p come from that law and the coefficient quartics; tau is Newton's method
    on the polynomial from the linear estimate. Returns (fraction at the boundary, x, v there,
    ok), where ok means Newton converged (last update below ``ROOT_TOL`` of the step) and the
    stretch is short, |tau| <= ``TAU_MAX`` h, so that the polynomial's error, (|tau| omega)^5 /
    120 relative for RK4, is below the step's own; otherwise the caller redoes its substep to
    the new estimate. Branch-free."""
    K0, G0 = _kg(P, tc, ktab, kamp, etab, ftab, kl, kal, gl, el, fl)
    ih = 1.0 / h
    K1, K2, G1, G2 = _kg_dt(P, tc, ih, ktab, kamp, etab, ftab, kal, el, fl)
    f = sw * (X - sh)
    fv = sw * V
    a = G0 - c * V - K0 * f
    j = G1 - c * a - K1 * f - K0 * fv
    sn = G2 - c * j - K2 * f - 2.0 * K1 * fv - K0 * sw * a
    c5 = 0.0
    if not _RK4_METHOD:  # fifth derivative of p
        K3, G3 = _kg_dt3(P, tc, ih, ktab, kamp, etab, ftab, kal, el, fl)
        c5 = (G3 - c * sn - K3 * f - 3.0 * K2 * fv - 3.0 * K1 * sw * a - K0 * sw * j) * (1.0 / 120.0)
    dx = X - bd
    c2 = 0.5 * a
    c3 = j * (1.0 / 6.0)
    c4 = sn * (1.0 / 24.0)
    t = -dx / V if V != 0.0 else 0.0
    t = _newton_poly(t, dx, V, c2, c3, c4, c5)  # two steps, written out: a loop here would
    t1 = _newton_poly(t, dx, V, c2, c3, c4, c5)  # keep LLVM from vectorising _fix_lanes' loop
    tn = tc + t1 * ih
    ok = abs(t1 - t) <= ROOT_TOL * h and abs(t1) <= TAU_MAX * h and 0.0 <= tn <= 1.0
    x = X + t1 * (V + t1 * (c2 + t1 * (c3 + t1 * (c4 + t1 * c5))))
    v = V + t1 * (a + t1 * (3.0 * c3 + t1 * (4.0 * c4 + t1 * 5.0 * c5)))
    return tn, x, v, ok


@jit_inline
def _newton_poly(t, dx, c1, c2, c3, c4, c5):
    """One Newton step for the root of dx + c1 t + c2 t^2 + c3 t^3 + c4 t^4 + c5 t^5."""
    g = dx + t * (c1 + t * (c2 + t * (c3 + t * (c4 + t * c5))))
    dg = c1 + t * (2.0 * c2 + t * (3.0 * c3 + t * (4.0 * c4 + t * 5.0 * c5)))
    return t - g / dg if dg != 0.0 else t


@jit_inline
def _quintic(s, y0, d0, q2, c3, c4, c5):
    """Value and s-derivative of y0 + d0 s + q2 s^2 + c3 s^3 + c4 s^4 + c5 s^5."""
    y = y0 + s * (d0 + s * (q2 + s * (c3 + s * (c4 + s * c5))))
    dy = d0 + s * (2.0 * q2 + s * (3.0 * c3 + s * (4.0 * c4 + s * 5.0 * c5)))
    return y, dy


@jit_inline
def _newton_quintic(s, y0, d0, q2, c3, c4, c5):
    """One Newton step on the quintic of ``_quintic`` for its root, kept inside [0, 1]."""
    y, dy = _quintic(s, y0, d0, q2, c3, c4, c5)
    return min(max(s - y / dy if dy != 0.0 else s, 0.0), 1.0)


@jit_inline
def _correct_rk4(X0, V0, TX, TV, h, ih, c, sw, bd, P, ktab, kamp, etab, ftab, kl, kal, gl, el, fl):
    """Crossing step of RK4 (see ``_fix_lanes``): returns (x, v, ok) at the step's end.

    Written for a short dependency chain: the crossing fraction starts from the inverse cubic
    Hermite s(y) of the trial (its three divisions are independent; error O(h^3) in s) and is
    refined by Newton steps on the cubic y(s); the correction's coefficients, which do not
    depend on the crossing velocity, are computed beside those steps (at the inverse-cubic
    estimate: its error moves them by O(h^4) relative and delta by O(h^7)), and the velocity
    enters last, linearly: d_k = b_k + a_k vc."""
    y0 = X0 - bd
    y1 = TX - bd
    d0 = h * V0
    d1 = h * TV
    Y = y1 - y0
    # cubic Hermite of p - bd in s = t / h: y0 + d0 s + q2 s^2 + c3 s^3
    q2 = 3.0 * Y - 2.0 * d0 - d1
    c3 = d0 + d1 - 2.0 * Y
    # its inverse s(y) as a cubic Hermite in z = (y - y0) / Y, at y = 0 (z: the secant fraction)
    z = -y0 / Y
    m0 = Y / d0
    m1 = Y / d1
    s = min(max(z * (m0 + z * (3.0 - 2.0 * m0 - m1 + z * (m0 + m1 - 2.0))), 0.0), 1.0)
    # Newton steps on the cubic (three, written out: a loop would keep LLVM from vectorising the
    # fix-up's loop); the last one's update is the convergence test, and p' at the root is the
    # derivative there corrected to first order. Grazing crossings (small p') converge slowly:
    # with one step 1.3 % of B2's crossings went to the scalar ``_fixup``, which costs a few
    # hundred plain lane-steps each; with three, 0.23 %.
    s0 = _newton_cubic(s, y0, d0, q2, c3)
    s0 = _newton_cubic(s0, y0, d0, q2, c3)
    yv = y0 + s0 * (d0 + s0 * (q2 + s0 * c3))
    dv = d0 + s0 * (2.0 * q2 + s0 * 3.0 * c3)
    ds = yv / dv
    s1 = min(max(s0 - ds, 0.0), 1.0)
    ok = abs(ds) <= GROUP_TOL
    vc = (dv - (2.0 * q2 + 6.0 * c3 * s0) * ds) * ih  # p' at the crossing
    # coefficients at the crossing and the correction's coefficients, d_k = b_k + a_k vc (taken
    # at the inverse-cubic estimate s, so that they are computed beside the Newton steps)
    Kc, Gc = _kg(P, s, ktab, kamp, etab, ftab, kl, kal, gl, el, fl)
    K1, K2, G1, _ = _kg_dt(P, s, ih, ktab, kamp, etab, ftab, kal, el, fl)
    nw = 1.0 - sw  # the new region's law: the gap after contact, the flank bd after the gap
    sig = nw - sw
    g2 = 0.5 * Gc  # u2 = g2 + e2 vc, u3 = g3 + e3 vc (p_trial - bd = vc t + u2 t^2 + u3 t^3)
    e2 = -0.5 * c
    g3 = (G1 - c * Gc) * (1.0 / 6.0)
    e3 = (c * c - Kc * sw) * (1.0 / 6.0)
    a3 = -sig * Kc * (1.0 / 6.0)
    b4 = -sig * Kc * g2 * (1.0 / 12.0)
    a4 = (-sig * (Kc * e2 + K1) - 3.0 * c * a3) * (1.0 / 12.0)
    b5 = (-sig * (Kc * g3 + K1 * g2) - 4.0 * c * b4) * (1.0 / 20.0)
    a5 = (-sig * (Kc * e3 + K1 * e2 + 0.5 * K2) - 4.0 * c * a4 - nw * Kc * a3) * (1.0 / 20.0)
    tau = (1.0 - s1) * h
    x = TX + tau * tau * tau * (vc * (a3 + tau * (a4 + tau * a5)) + tau * (b4 + tau * b5))
    v = TV + tau * tau * (vc * (3.0 * a3 + tau * (4.0 * a4 + tau * 5.0 * a5))
                          + tau * (4.0 * b4 + tau * 5.0 * b5))
    return x, v, ok


@jit_inline
def _correct_rk5(X0, V0, TX, TV, h, ih, c, sw, sh, bd, P, K, E, F, ktab, kamp, etab, ftab,
                 kl, kal, gl, el, fl):
    """Crossing step of RK5 (see ``_fix_lanes``): returns (x, v, ok) at the step's end. The
    crossing comes from the quintic Hermite of the trial (p'' at both ends from the trial's law
    and the table nodes 0 and 4), a secant estimate and two Newton steps; a substep of RK5 with
    the new region's law finishes the step."""
    A0 = (_g(gl, el, E[0], etab, fl, F[0], ftab) - c * V0
          - _k(kl, kal, K[0], ktab, kamp) * (sw * (X0 - sh)))
    A1 = (_g(gl, el, E[4], etab, fl, F[4], ftab) - c * TV
          - _k(kl, kal, K[4], ktab, kamp) * (sw * (TX - sh)))
    # quintic Hermite in s = t / h of p - bd: y0 + d0 s + q2 s^2 + c3 s^3 + c4 s^4 + c5 s^5
    hh = h * h
    y0 = X0 - bd
    y1 = TX - bd
    d0 = h * V0
    q2 = 0.5 * hh * A0
    D = y1 - y0 - d0 - q2
    E1 = h * TV - d0 - 2.0 * q2
    F1 = hh * A1 - 2.0 * q2
    c3 = 10.0 * D - 4.0 * E1 + 0.5 * F1
    c4 = -15.0 * D + 7.0 * E1 - F1
    c5 = 6.0 * D - 3.0 * E1 + 0.5 * F1
    den = y0 - y1
    s = min(max(y0 / den if den != 0.0 else 0.0, 0.0), 1.0)
    s = _newton_quintic(s, y0, d0, q2, c3, c4, c5)  # two steps, written out (see _project)
    s1 = _newton_quintic(s, y0, d0, q2, c3, c4, c5)
    ok = abs(s1 - s) <= GROUP_TOL
    y, dy = _quintic(s1, y0, d0, q2, c3, c4, c5)
    # the new region's law: the gap after contact, the flank bd after the gap
    x, v = _substep(bd + y, dy / h, s1, 1.0, h, 1.0 - sw, bd, c, P, ktab, kamp, etab,
                    ftab, kl, kal, gl, el, fl)
    return x, v, ok


@jit_inline
def _fix_lanes(w, o, l0, nv, bits, P, K, E, F, ktab, kamp, etab, ftab):
    """Correct, in place, the crossing steps among lanes l0 .. l0 + nv - 1 of the block at
    offset ``o`` of ``w`` (``bits``: their crossing bits; ``nv`` a multiple of 8) in one
    branch-free pass vectorised across the lanes like the lane loops; returns the bits of the
    lanes it leaves to the scalar ``_fixup``.

    The trial step was taken with the start region's force law extended past the boundary
    (``rk._law``): one smooth trajectory p_trial. From the crossing time t_c on, the true
    trajectory follows the new region's law; both laws are f = sw (p - bd), equal on the
    boundary bd, so the difference delta = p - p_trial obeys a LINEAR equation in which the
    forcing G(t) cancels:

        delta'' + c delta' + K(t) sw_new delta = -sigma K(t) (p_trial - bd),
        delta(t_c) = delta'(t_c) = 0,   sigma = sw_new - sw_old = +-1.

    Its Taylor series delta = d3 tau^3 + d4 tau^4 + d5 tau^5 (tau = t - t_c) has closed-form
    coefficients from K, K', K'' at t_c and the derivatives of p_trial there (the old law gives
    all but the first from the crossing velocity, because f_old(bd) = 0), so the step ends at
    the trial's end plus delta(tau) and its derivative: O(tau^5) in p'. t_c and the crossing
    velocity come from the cubic Hermite interpolant of the trial (``_correct_rk4``); their
    errors, O(h^4) and O(h^3), enter p' as K p' tau dt and K tau^2 dv: O(h^5). A bounded number
    of crossings per mesh period needs only O(h^4) locally, so RK4 keeps order 4, with the errors
    of the substep this replaced (within 10 % at 32-1024 steps per period, docs/precision.md).
    Why a correction rather than a new substep from t_c: the pass is one long dependency chain
    over only a few vectors of lanes per step, so its latency, not its arithmetic, sets its
    cost (computing 32 lanes cost about the same as computing 8).

    RK5 (``_correct_rk5``) keeps the substep: the quintic Hermite (p'' at both ends too) gives
    t_c and the state there, and an RK5 substep with the new law finishes the step. The series
    to tau^5 made its convergence erratic (the error depends on where each crossing falls in its
    step; fitted order 4.4), and to tau^6, with every coefficient table on, it was 2.3 times
    less accurate than the substep at 32 steps per period (fitted order 6.2 over 32-256).

    Every lane of the range is computed and only the crossing ones are written (the others
    keep their step). Lanes left to ``_fixup`` keep their trial step: the crossing ones whose
    Newton update stayed above ``GROUP_TOL`` (e.g. a grazing crossing) or that end in another
    region than the one entered (a second crossing within the step)."""
    hard = np.int64(0)
    for l in range(l0, l0 + nv):
        i = o + l
        X0 = w[i + _XO * LANES]
        V0 = w[i + _VO * LANES]
        TX = w[i + _X * LANES]
        TV = w[i + _V * LANES]
        h = w[i + _H * LANES]
        b = w[i + _B * LANES]
        c = w[i + _C * LANES]
        kl = w[i + _KM * LANES]
        kal = w[i + _KA * LANES]
        gl = w[i + _GM * LANES]
        el = w[i + _ES * LANES]
        fl = w[i + _FS * LANES]
        ih = 1.0 / h
        sw = 1.0 if abs(X0) > b else 0.0  # the start region's law, as in rk._law
        sh = b if X0 > 0.0 else -b
        # the boundary crossed: the flank being left, or (from the gap) the one reached
        bd = sh if sw != 0.0 else (b if TX > 0.0 else -b)
        if _RK4_METHOD:
            FX, FV, ok = _correct_rk4(X0, V0, TX, TV, h, ih, c, sw, bd, P, ktab, kamp, etab, ftab,
                                      kl, kal, gl, el, fl)
        else:
            FX, FV, ok = _correct_rk5(X0, V0, TX, TV, h, ih, c, sw, sh, bd, P, K, E, F, ktab,
                                      kamp, etab, ftab, kl, kal, gl, el, fl)
        rn = (1.0 - sw) * (1.0 if bd > 0.0 else -1.0)
        crossed = (bits & _BIT[l]) != 0
        easy = ok and _region(FX, b) == rn
        take = crossed and easy
        w[i + _X * LANES] = FX if take else TX
        w[i + _V * LANES] = FV if take else TV
        # RK4: the coefficients at the crossing; RK5: a substep and two p'' evaluations
        w[i + _NSUB * LANES] += (0.25 if _RK4_METHOD else 4.0 / 3.0) if take else 0.0
        hard |= _BIT[l] if crossed and not easy else np.int64(0)
    return hard


@jit_inline
def _popcount(x):
    """Number of set bits of a 32-bit mask (LANES <= 32), branch-free (SWAR)."""
    x = x - ((x >> 1) & 0x55555555)
    x = (x & 0x33333333) + ((x >> 2) & 0x33333333)
    x = (x + (x >> 4)) & 0x0F0F0F0F
    return ((x * 0x01010101) & 0xFFFFFFFF) >> 24


@jit_inline
def _gsl(m):
    """Offset of slot ``m`` of the group scratch: block m // LANES, lane m % LANES."""
    return (m // LANES) * _BLOCK + (m & (LANES - 1))


@jit_inline
def _gather(w, g0, m, i):
    """Copy the rows a fix-up reads of the lane at ``w[i]`` (row 0) into slot ``m`` of the group
    blocks at offset ``g0``."""
    k = g0 + _gsl(m)
    for r in _ROWS_IN:
        w[k + r * LANES] = w[i + r * LANES]


@jit_inline
def _scatter(w, g0, m, i):
    """Copy slot ``m``'s fixed-up end state and substep count back to the lane at ``w[i]``."""
    k = g0 + _gsl(m)
    w[i + _X * LANES] = w[k + _X * LANES]
    w[i + _V * LANES] = w[k + _V * LANES]
    w[i + _NSUB * LANES] = w[k + _NSUB * LANES]


_ROWS_IN = (_XO, _VO, _X, _V, _H, _B, _C, _KM, _KA, _GM, _ES, _FS, _NSUB)
"""Rows a crossing lane's fix-up reads (gathered into the group scratch)."""


@jit_inline
def _fix_jobs(a, jo, jlo, jhi, jbits, nj, P, K, E, F, ktab, kamp, etab, ftab):
    """Run the fix-up jobs: job t is the lanes jlo[t] .. jhi[t] - 1 of the block at offset jo[t]
    of the scratch ``a`` (one of the kink block's own blocks, or of the group blocks after
    them), crossing bits jbits[t]. One call site of the vectorised ``_fix_lanes`` for both (each
    inlined copy adds to the compile time); the lanes it leaves go through the scalar
    ``_fixup``, in place."""
    for t in range(nj):
        # the masks make the offsets provably non-negative: without them every index would
        # carry Numba's wraparound test, and LLVM would not vectorise _fix_lanes
        o = jo[t] & 0x7FFFFFFF
        lo = jlo[t] & (LANES - 8)
        hard = _fix_lanes(a, o, lo, (jhi[t] - lo) & (2 * LANES - 8), jbits[t], P, K, E, F,
                          ktab, kamp, etab, ftab)
        while hard != 0:
            i = o + np.int64(trailing_zeros(hard))
            hard &= hard - 1
            X, V, ns = _fixup(a[i + _XO * LANES], a[i + _VO * LANES], a[i + _X * LANES],
                              a[i + _V * LANES], a[i + _H * LANES], a[i + _B * LANES],
                              a[i + _C * LANES], P, ktab, kamp, etab, ftab, a[i + _KM * LANES],
                              a[i + _KA * LANES], a[i + _GM * LANES], a[i + _ES * LANES],
                              a[i + _FS * LANES])
            a[i + _X * LANES] = X
            a[i + _V * LANES] = V
            a[i + _NSUB * LANES] += ns


@jit_inline
def _live(w, o, nlive):
    """Crossing-mask bits of the block's lanes that hold a running case: the first ``nlive``
    lanes (those past the batch's end repeat its last case), less the diverged ones."""
    bits = np.int64(0)
    for l in range(LANES):
        if l < nlive and w[o + _DEAD * LANES + l] == 0.0:
            bits |= np.int64(1) << l
    return bits


_FIXUPS = {m: inlined_copies({name: globals()[name] for name in (
    "_substep", "_project", "_fixup", "_correct_rk4", "_correct_rk5", "_fix_lanes", "_fix_jobs")},
    {"_RK4_METHOD": m == RK4}, keep=("_fixup",), tag=f"rk{m}") for m in (RK4, RK5)}
"""The fix-up helpers of each method (``_RK4_METHOD``)."""


def _driver(method):
    """The kink-aware batch driver of one method: ``_integrate_blocks`` compiled per combination
    of terms, its kink blocks spread over threads (``rk.Threaded``).

    Called with the arguments of ``gearsweep.kernels.rk.INTEGRATE``'s drivers and ``sub``, plain
    blocks of ``LANES`` per kink block (``sub_blocks``); returns stats (n, N_STATS), the state at
    the end xf, vf [m], [m/s], status (int8) and substeps: extra work at crossings in
    step-equivalents (right-hand-side evaluations / stages).

    Kink block ``blk`` steps the plain blocks blk, blk + nblocks, blk + 2 nblocks, ...:
    interleaved, so that each range of kink blocks spans the whole batch. Crossings cluster in
    parts of a sweep (B2: none below about 3000 rpm), and contiguous kink blocks would leave one
    thread with most of the fix-ups. Each lane's arithmetic does not depend on its block or
    thread, so the results do not change with either."""
    return Threaded(Specialised(lambda: _ranges_function(method), f"integrate_kink_rk{method}",
                                jit_block_cached), _kink_layout)


_KINK_RK4 = True
"""The method of a copy of ``_integrate_blocks`` (set per copy by ``_ranges_function``)."""
_KINK_FIX_JOBS = None
"""The method's ``_fix_jobs`` (``_FIXUPS``), set per copy of ``_integrate_blocks``."""


def _integrate_blocks(h, cm, kmean, kamp, ktab, gmean, escale, etab, fscale, ftab, half_gap,
                      bound, x0, v0, n_transient, n_record, steps_per_period, signal, stride, sub,
                      nblocks, lo, hi, stats, xf, vf, status, substeps):
    """Step the kink blocks ``lo`` ... ``hi - 1`` of a batch of ``nblocks`` (see ``_driver``)."""
    n = h.shape[0]
    S = _cycle(ktab, etab, ftab)
    PT = _monomial_table(ktab, etab, ftab, S)
    for blk in range(lo, hi):
        csr = ftz_on()  # subnormals flushed to 0 in this block's work (``fpenv``)
        w = _scratch(2 * sub)  # the kink block's plain blocks, then the group's blocks
        g0 = sub * _BLOCK
        for q in range(sub):
            _load(w, q * _BLOCK, (blk + q * nblocks) * LANES, n, h, cm, kmean, kamp, gmean, escale,
                  fscale, half_gap, bound, x0, v0)
        P = np.zeros((3, 5))
        # fix-up jobs (see _fix_jobs)
        jo = np.zeros(2 * sub, np.int64)
        jlo = np.zeros(2 * sub, np.int64)
        jhi = np.zeros(2 * sub, np.int64)
        jbits = np.zeros(2 * sub, np.int64)
        slot = np.zeros(sub * LANES, np.int64)
        masks = np.zeros(sub, np.int64)
        live = np.zeros(sub, np.int64)  # bits of the lanes that hold a case still running
        for q in range(sub):
            live[q] = _live(w, q * _BLOCK, n - (blk + q * nblocks) * LANES)
        half = n_transient + n_record // 2
        j = 0
        jp = 0
        # The statistics take the START state of step s for s > n_transient (inside the lane
        # loop, see rk._after_step): the end state of step s - 1 after its fix-up. The end
        # state of the last step is entered after the loop. The plain kernel records the end
        # states of steps n_transient ... end: the same states, the same statistics.
        for s in range(n_transient + n_record + 1):
            rec = s > n_transient
            if s == n_transient:  # the state before the first recorded one: apart or not
                for q in range(sub):
                    _mark_prev(w, q * _BLOCK, half_gap)
            if rec:
                for q in range(sub):
                    if s == n_transient + 1:
                        _start_record(w, q * _BLOCK, half_gap)
                    if s == half + 1:
                        _split(w, q * _BLOCK)
            if s == n_transient + n_record:  # past the last step: record its end state
                if rec:
                    for q in range(sub):
                        _accumulate(w, q * _BLOCK, half_gap)
                break
            K = _row(ktab, j)
            E = _row(etab, j)
            F = _row(ftab, j)
            # First every sub-block's trial step, each returning its crossing mask; then the
            # fix-ups of all of them. No branch between the lane
            # loops depends on a mask, so the next sub-block's loop does not wait for one.
            for q in range(sub):
                o = q * _BLOCK
                if _KINK_RK4:
                    if rec:
                        masks[q] = _rk4_lanes(w, o, half_gap, kamp, ktab, K, etab, E, ftab, F, True)
                    else:
                        masks[q] = _rk4_lanes(w, o, half_gap, kamp, ktab, K, etab, E, ftab, F,
                                              False)
                elif rec:
                    masks[q] = _rk5_lanes(w, o, half_gap, kamp, ktab, K, etab, E, ftab, F, True)
                else:
                    masks[q] = _rk5_lanes(w, o, half_gap, kamp, ktab, K, etab, E, ftab, F, False)
            # Each block's crossing lanes: where they fill most of the vectors they span (the
            # usual case: neighbouring cases of a sweep cross in the same steps), fixed up in
            # place; otherwise gathered into the group, whose vectors they then fill.
            nj = 0
            nc = 0
            for q in range(sub):
                mask = masks[q] & live[q]
                if mask == 0:
                    continue
                o = q * _BLOCK
                lo = (np.int64(trailing_zeros(mask)) >> 3) << 3
                hi = ((63 - np.int64(leading_zeros(mask))) | 7) + 1
                if _popcount(mask) >= DENSE * (hi - lo):
                    jo[nj] = o
                    jlo[nj] = lo
                    jhi[nj] = hi
                    jbits[nj] = mask
                    nj += 1
                else:
                    while mask != 0:
                        i = o + np.int64(trailing_zeros(mask))
                        mask &= mask - 1
                        _gather(w, g0, nc, i)
                        slot[nc] = i
                        nc += 1
            for q in range((nc + LANES - 1) // LANES):
                m = min(LANES, nc - q * LANES)
                jo[nj] = g0 + q * _BLOCK
                jlo[nj] = 0
                jhi[nj] = (m + 7) & -8
                jbits[nj] = (np.int64(1) << m) - 1  # m <= LANES <= 32
                nj += 1
            if nj > 0:
                for r in range(3):
                    for k in range(5):
                        P[r, k] = PT[j, r, k]
                _KINK_FIX_JOBS(w, jo, jlo, jhi, jbits, nj, P, K, E, F, ktab, kamp, etab,
                               ftab)
                for m in range(nc):
                    _scatter(w, g0, m, slot[m])
            j = j + 1 if j + 1 < S else 0
            jp = jp + 1 if jp + 1 < steps_per_period else 0
            for q in range(sub):
                if signal is not None and s >= n_transient:
                    _sample(w, q * _BLOCK, signal, s - n_transient, stride, (blk + q * nblocks) * LANES,
                            n)
                if jp == 0:
                    _check(w, q * _BLOCK)
                    live[q] = _live(w, q * _BLOCK, n - (blk + q * nblocks) * LANES)
        for q in range(sub):
            i0 = (blk + q * nblocks) * LANES
            if i0 < n:
                _finish(w, q * _BLOCK, i0, n, n_record, steps_per_period, stats, xf, vf, status)
                for l in range(min(LANES, n - i0)):
                    substeps[i0 + l] = w[q * _BLOCK + _NSUB * LANES + l]
        ftz_restore(csr)


def _ranges_function(method):
    """A new Python function of ``_integrate_blocks`` for one method (``Specialised`` compiles
    it per combination of terms; ``rk.Threaded`` calls it from its threads). The method is a global
    of the copy (Numba freezes it: the other method's branch is pruned before its helpers are
    inlined), and so is its ``_fix_jobs``: a closure variable would be hashed into Numba's cache
    key, and a dispatcher pickles differently in every process (the driver was compiled again by
    every run)."""
    g = dict(globals())
    g["_KINK_RK4"] = method == RK4
    g["_KINK_FIX_JOBS"] = _FIXUPS[method]["_fix_jobs"]
    f = _integrate_blocks
    return types.FunctionType(f.__code__, g, f.__name__, f.__defaults__, f.__closure__)


def _kink_layout(args: tuple) -> tuple:
    """The kink-aware drivers' ``rk.Threaded`` layout: the arguments before the range (``sub``
    clamped, the number of kink blocks), that number, and new output arrays (stats, xf, vf,
    status, substeps)."""
    n = args[0].shape[0]
    sub = max(1, min(int(args[-1]), SUB_MAX))  # the scratch and the job arrays are sized by it
    nplain = -(-n // LANES)
    nblocks = -(-nplain // sub)
    outputs = (np.empty((n, N_STATS)), np.empty(n), np.empty(n), np.zeros(n, np.int8),
               np.zeros(n))
    return (*args[:-1], sub, nblocks), nblocks, outputs


def sub_blocks(n, threads):
    """Plain blocks per kink block for ``n`` cases: as many as keep every thread busy with at
    least two kink blocks, at most ``SUB_MAX``."""
    return max(1, min(SUB_MAX, -(-n // LANES) // (2 * max(threads, 1))))


INTEGRATE = {RK4: _driver(RK4), RK5: _driver(RK5)}
"""The compiled kink-aware driver of each method (``rk.METHODS`` value -> function)."""

"""Kink-aware fixed-step RK4/RK5: steps that cross the backlash boundaries are redone in pieces.

Same model, tables, arguments and statistics as ``gearsweep.kernels.rk.integrate`` (see its
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
1. A kink block is up to ``SUB_MAX`` plain blocks of ``LANES`` cases (same scratch layout and
   lane code as the plain kernel, ``rk._rk4_lanes`` / ``rk._rk5_lanes``); each takes the plain
   vectorised step.
2. A branch-free pass per plain block makes a bit mask of the lanes whose region at the step's
   end differs from the region at its start: (p0 - b)(p1 - b) < 0 or (p0 + b)(p1 + b) < 0 for
   the start and end values p0, p1 (a step that ends exactly on a boundary is not a crossing).
   The flagged lanes of the whole kink block are gathered into groups of ``GROUP``, and
   ``_fixup_group`` redoes their steps from the saved start states, branch-free and vectorised
   across the group; the few lanes it cannot finish (a second crossing within the step, a start
   on a boundary, no convergence in ``NEWTON_MAX`` substeps) go through the scalar ``_fixup``.
   Both do:
   a. estimate the crossing time inside the step from the cubic Hermite interpolant of the
      trial step's end points (p and p' at both ends; Newton's method on the cubic);
   b. take a substep of the same method to that time, with the force law of the region being
      left, extended smoothly past the boundary (so no stage sees the kink);
   c. from the substep's end, a degree-4 Taylor polynomial in time (derivatives of p up to the
      fourth from the same force law and the coefficient quartics below) gives the time left to
      the boundary by Newton's method; if that time tau is short (|tau| omega < ``TAYLOR_MAX``)
      the polynomial moves the state onto the boundary (error ~ (tau omega)^4 / 24), otherwise
      the substep is redone to the new estimate (at most ``NEWTON_MAX`` substeps);
   d. finish the step with a substep from the crossing to the step's end with the new
      region's force law; if that remainder crosses again, repeat from a (at most
      ``MAX_CROSSINGS`` crossings per step).
   A typical crossing costs two substeps.
   Steps of lanes that do not cross are untouched, so a case without crossings gives results
   identical bit for bit to the plain kernel.

Coefficients inside a step
--------------------------
The tables hold K(t) and G(t) only at the five quarter-step nodes of each step. Substeps need
them at other times; they are taken from the quartic through the five node values of the step
(its monomial coefficients in the step fraction, which also give the time derivatives needed
by the Taylor polynomial). For smooth periodic coefficients its error is O(h^5) relative to the
coefficient; it acts only over the substeps of crossing steps (a bounded number per period), so
it adds O(h^6) to the global error: below the order of both methods. (A linear interpolant
would add O(h^2) per crossing and undo the gain.) This keeps ``simulate``'s table conventions;
no Fourier coefficients are needed.

Limitations
-----------
A crossing followed by a return within the same step (both ends in one region) is not detected:
that step is taken as in the plain kernel. This happens only for grazing contacts, where the
excursion lasts less than one step. A crossing at which p' is tiny (tangential) may not
converge in ``NEWTON_MAX`` substeps; the last estimate is kept.

Cost counter: ``integrate`` also returns the number of substeps per case (each costs as many
right-hand-side evaluations as one step).

Speed: on benchmark B2 (4.6 % of lane-steps cross) the kink-aware kernel takes about 4 times the
plain kernel's wall time (``scripts/bench_kink.py``; docs/precision.md). About half of the extra
time is the bookkeeping around the plain step (saving the start state, the crossing mask, the
statistics pass that cannot be fused into the step because the fix-up changes p afterwards), the
other half the group fix-up (two substeps and the root finding per crossing). Without backlash
(``half_gap=None``) the detection is compiled out and the cost is the plain kernel's.
"""

import numpy as np
from numba import prange
from numba.cpython.unsafe.numbers import trailing_zeros

from gearsweep.jit import jit, jit_inline, jit_parallel
from gearsweep.kernels.rk import (
    _B,
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
    _V,
    _VO,
    _X,
    _XO,
    LANES,
    N_STATS,
    RK4,
    RK5,
    _accumulate,
    _check,
    _cycle,
    _finish,
    _g,
    _k,
    _load,
    _rk4_lanes,
    _rk5_lanes,
    _row,
    _sample,
    _block,
    _scratch,
    _split,
    _start_record,
)

MAX_CROSSINGS = 4
"""Crossings handled within one step; further ones are stepped over as in the plain kernel."""
NEWTON_MAX = 4
"""Substeps used at most to reach one crossing."""
TAYLOR_MAX = 2e-3
"""The last stretch to a crossing, tau, is covered by a degree-4 Taylor polynomial when
|tau| * (sqrt(K) + c/m) is below this: its error, about (that)^4 / 24 relative in p', is then
below 1e-12."""
SUB_MAX = 8
"""A kink block is up to this many plain blocks of ``LANES`` stepped one after the other, so that
its crossings fill the vectorised fix-up groups (B2: about 12 crossings per step of 256 lanes)."""
GROUP = 16
"""Crossing lanes fixed up together in one branch-free, vectorised pass."""

_MONO = np.array([[3.0, 0.0, 0.0, 0.0, 0.0],
                  [-25.0, 48.0, -36.0, 16.0, -3.0],
                  [70.0, -208.0, 228.0, -112.0, 22.0],
                  [-80.0, 288.0, -384.0, 224.0, -48.0],
                  [32.0, -128.0, 192.0, -128.0, 32.0]]) / 3.0
"""Inverse Vandermonde matrix of the nodes 0, 1/4, 1/2, 3/4, 1: monomial coefficients in theta
of the quartic through five node values."""

# Rows of the fix-up group array: GROUP lanes gathered from the crossing lanes of a kink block,
# row r of lane m at r * GROUP + m of one flat array. The constant offsets let LLVM prove the rows
# disjoint and vectorise the group's lane loops (with the row stride of a 2-D argument it would
# need more run-time overlap checks than it is willing to emit, and stays scalar).
(_GX0, _GV0, _GTX, _GTV, _GH, _GB, _GC, _GKM, _GKA, _GGM, _GES, _GFS,  # inputs
 _GTH, _GCX, _GCV, _GREDO, _GNSUB) = range(17)  # crossing time, state there, progress
_G_ROWS = 17


@jit_inline
def _monomials(row, P, q):
    """P[q, :] = coefficients of the quartic in theta through the five node values ``row``."""
    for k in range(5):
        acc = 0.0
        for i in range(5):
            acc += _MONO[k, i] * row[i]
        P[q, k] = acc


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
def _substep(rk4, X, V, ta, tb, h, sw, sh, c, P, ktab, kamp, etab, ftab, kl, kal, gl, el, fl):
    """One RK step of the same method from fraction ``ta`` to ``tb`` of the step ``h``, with the
    force law f(p) = sw (p - sh) of one region extended smoothly beyond its boundary: the stages
    never see the kink (a stage on the far side of the boundary evaluated with the dead zone
    itself would cost O(H^4) per crossing and cap RK5 at order 4)."""
    eta = tb - ta
    H = eta * h
    if rk4:
        tm = ta + 0.5 * eta
        K1, G1 = _kg(P, ta, ktab, kamp, etab, ftab, kl, kal, gl, el, fl)
        K2, G2 = _kg(P, tm, ktab, kamp, etab, ftab, kl, kal, gl, el, fl)
        K3, G3 = _kg(P, tb, ktab, kamp, etab, ftab, kl, kal, gl, el, fl)
        k1v = G1 - c * V - K1 * sw * (X - sh)
        k1x = V
        x2 = X + 0.5 * H * k1x
        v2 = V + 0.5 * H * k1v
        k2v = G2 - c * v2 - K2 * sw * (x2 - sh)
        k2x = v2
        x3 = X + 0.5 * H * k2x
        v3 = V + 0.5 * H * k2v
        k3v = G2 - c * v3 - K2 * sw * (x3 - sh)
        k3x = v3
        x4 = X + H * k3x
        v4 = V + H * k3v
        k4v = G3 - c * v4 - K3 * sw * (x4 - sh)
        k4x = v4
        return (X + H * (1.0 / 6.0) * (k1x + 2 * k2x + 2 * k3x + k4x),
                V + H * (1.0 / 6.0) * (k1v + 2 * k2v + 2 * k3v + k4v))
    K1, G1 = _kg(P, ta, ktab, kamp, etab, ftab, kl, kal, gl, el, fl)
    K2, G2 = _kg(P, ta + 0.25 * eta, ktab, kamp, etab, ftab, kl, kal, gl, el, fl)
    K4, G4 = _kg(P, ta + 0.5 * eta, ktab, kamp, etab, ftab, kl, kal, gl, el, fl)
    K5, G5 = _kg(P, ta + 0.75 * eta, ktab, kamp, etab, ftab, kl, kal, gl, el, fl)
    K6, G6 = _kg(P, tb, ktab, kamp, etab, ftab, kl, kal, gl, el, fl)
    a1 = V
    b1 = G1 - c * V - K1 * sw * (X - sh)
    x2 = X + H * (0.25 * a1)
    v2 = V + H * (0.25 * b1)
    a2 = v2
    b2 = G2 - c * v2 - K2 * sw * (x2 - sh)
    x3 = X + H * (0.125 * a1 + 0.125 * a2)
    v3 = V + H * (0.125 * b1 + 0.125 * b2)
    a3 = v3
    b3 = G2 - c * v3 - K2 * sw * (x3 - sh)
    x4 = X + H * (-0.5 * a2 + a3)
    v4 = V + H * (-0.5 * b2 + b3)
    a4 = v4
    b4 = G4 - c * v4 - K4 * sw * (x4 - sh)
    x5 = X + H * (0.1875 * a1 + 0.5625 * a4)
    v5 = V + H * (0.1875 * b1 + 0.5625 * b4)
    a5 = v5
    b5 = G5 - c * v5 - K5 * sw * (x5 - sh)
    x6 = X + H * (-3.0 * a1 + 2.0 * a2 + 12.0 * a3 - 12.0 * a4 + 8.0 * a5) * (1.0 / 7.0)
    v6 = V + H * (-3.0 * b1 + 2.0 * b2 + 12.0 * b3 - 12.0 * b4 + 8.0 * b5) * (1.0 / 7.0)
    a6 = v6
    b6 = G6 - c * v6 - K6 * sw * (x6 - sh)
    return (X + H * (7.0 * (a1 + a6) + 32.0 * (a3 + a5) + 12.0 * a4) * (1.0 / 90.0),
            V + H * (7.0 * (b1 + b6) + 32.0 * (b3 + b5) + 12.0 * b4) * (1.0 / 90.0))


@jit_inline
def _hermite_root(X, V, TX, TV, H, bd):
    """Fraction s in [0, 1] where the cubic Hermite interpolant of (X, V) -> (TX, TV) over a
    step H meets ``bd`` (start and end on opposite sides), branch-free: the secant estimate and
    two Newton steps on g(s) = c0 + c1 s + c2 s^2 + c3 s^3, kept inside [0, 1]. It needs no high
    accuracy: the Taylor projection in ``_taylor`` corrects it."""
    c0 = X - bd
    c1 = H * V
    c2 = 3.0 * (TX - X) - H * (2.0 * V + TV)
    c3 = 2.0 * (X - TX) + H * (V + TV)
    g1 = c0 + c1 + c2 + c3
    den = c0 - g1
    s = c0 / den if den != 0.0 else 0.5
    s = min(max(s, 0.0), 1.0)
    s = _newton_cubic(s, c0, c1, c2, c3)  # two steps, written out: a loop here would keep
    return _newton_cubic(s, c0, c1, c2, c3)  # LLVM from vectorising the group's lane loop


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


@jit_inline
def _taylor(CX, CV, tc, bd, ih, sw, sh, c, P, ktab, kamp, etab, ftab, kl, kal, gl, el, fl):
    """From the state (CX, CV) at fraction ``tc`` (force law sw (p - sh)): the time tau to the
    boundary ``bd`` by Newton's method on the degree-4 Taylor polynomial (derivatives of p up to
    the fourth from the force law and the coefficient quartics), and the state moved by tau."""
    K0, G0 = _kg(P, tc, ktab, kamp, etab, ftab, kl, kal, gl, el, fl)
    K1, K2, G1, G2 = _kg_dt(P, tc, ih, ktab, kamp, etab, ftab, kal, el, fl)
    f = sw * (CX - sh)
    a = G0 - c * CV - K0 * f
    j = G1 - c * a - K1 * f - K0 * sw * CV
    sn = G2 - c * j - K2 * f - 2.0 * K1 * sw * CV - K0 * sw * a
    a2 = 0.5 * a
    j2 = 0.5 * j
    j6 = j * (1.0 / 6.0)
    s6 = sn * (1.0 / 6.0)
    s24 = sn * (1.0 / 24.0)
    tau = -(CX - bd) / CV if CV != 0.0 else 0.0
    tau = _newton_taylor(tau, CX - bd, CV, a, a2, j2, j6, s6, s24)  # two steps, written out
    tau = _newton_taylor(tau, CX - bd, CV, a, a2, j2, j6, s6, s24)
    return (tau, CX + tau * (CV + tau * (a2 + tau * (j6 + tau * s24))),
            CV + tau * (a + tau * (j2 + tau * s6)))


@jit_inline
def _newton_taylor(tau, dx, CV, a, a2, j2, j6, s6, s24):
    """One Newton step for the root of dx + CV tau + a2 tau^2 + j6 tau^3 + s24 tau^4."""
    gx = dx + tau * (CV + tau * (a2 + tau * (j6 + tau * s24)))
    gv = CV + tau * (a + tau * (j2 + tau * s6))
    return tau - gx / gv if gv != 0.0 else tau


@jit_inline
def _omega(P, ktab, kamp, kl, kal, c):
    """Rate scale sqrt(|K|) + |c/m| of a lane in this step, for the Taylor range test."""
    return np.sqrt(abs(_k(kl, kal, _val(P, 0, 0.5), ktab, kamp))) + abs(c)


@jit
def _fixup(rk4, X0, V0, TX, TV, h, b, c, P, ktab, kamp, etab, ftab, kl, kal, gl, el, fl):
    """Redo one step of one lane that crossed a boundary, any number of crossings (up to
    ``MAX_CROSSINGS``); returns (x, v, substeps taken). The scalar path, for what the vectorised
    ``_fixup_group`` leaves: several crossings in one step, a start on a boundary, a crossing
    estimate that needs more than one substep.

    Per crossing: a substep (force law of the region being left) to the estimate from the
    Hermite cubic; then ``_taylor`` gives the remaining time to the boundary and, if that time is
    short (|tau| omega < ``TAYLOR_MAX``), moves the state onto the boundary; otherwise the
    substep is redone to the Newton estimate. Then a substep with the new region's law finishes
    the step."""
    th = 0.0
    X = X0
    V = V0
    reg = _region(X0, b)
    nsub = 0
    ih = 1.0 / h
    om = _omega(P, ktab, kamp, kl, kal, c)
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
            CX, CV = _substep(rk4, X, V, th, tc, h, sw, sh, c, P, ktab, kamp, etab, ftab, kl, kal,
                              gl, el, fl)
            nsub += 1
            tau, PX, PV = _taylor(CX, CV, tc, bd, ih, sw, sh, c, P, ktab, kamp, etab, ftab, kl,
                                  kal, gl, el, fl)
            tn = tc + tau * ih
            if abs(tau) * om < TAYLOR_MAX and tn <= 1.0:
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
        TX, TV = _substep(rk4, X, V, th, 1.0, h, sw, sh, c, P, ktab, kamp, etab, ftab, kl, kal,
                          gl, el, fl)
        nsub += 1
    return TX, TV, nsub


@jit_inline
def _fixup_group(rk4, g, P, ktab, kamp, etab, ftab):
    """Redo the steps of the GROUP lanes gathered in ``g`` that cross one boundary, branch-free
    and vectorised across the group: Hermite estimate, substeps to the crossing (repeated for the
    lanes whose Taylor range test fails, while any does), Taylor projection onto the boundary,
    substep to the step's end with the new region's law. Writes the new end state into rows
    ``_GTX, _GTV`` and marks in ``_GREDO`` the lanes it could not finish (more than one crossing,
    start on a boundary, no convergence): ``_fixup`` redoes those."""
    for m in range(GROUP):
        X0 = g[_GX0 * GROUP + m]
        b = g[_GB * GROUP + m]
        TX = g[_GTX * GROUP + m]
        r0 = _region(X0, b)
        bd = r0 * b if r0 != 0.0 else (b if TX > b else -b)
        g[_GTH * GROUP + m] = _hermite_root(X0, g[_GV0 * GROUP + m], TX, g[_GTV * GROUP + m], g[_GH * GROUP + m], bd)
        g[_GREDO * GROUP + m] = 1.0
        g[_GNSUB * GROUP + m] = 0.0
    for _ in range(NEWTON_MAX):
        todo = 0.0
        for m in range(GROUP):
            X0 = g[_GX0 * GROUP + m]
            V0 = g[_GV0 * GROUP + m]
            h = g[_GH * GROUP + m]
            b = g[_GB * GROUP + m]
            c = g[_GC * GROUP + m]
            kl = g[_GKM * GROUP + m]
            kal = g[_GKA * GROUP + m]
            gl = g[_GGM * GROUP + m]
            el = g[_GES * GROUP + m]
            fl = g[_GFS * GROUP + m]
            r0 = _region(X0, b)
            bd = r0 * b if r0 != 0.0 else (b if g[_GTX * GROUP + m] > b else -b)
            sw = abs(r0)
            sh = b if r0 > 0.0 else -b
            th = g[_GTH * GROUP + m]
            CX, CV = _substep(rk4, X0, V0, 0.0, th, h, sw, sh, c, P, ktab, kamp, etab, ftab, kl,
                              kal, gl, el, fl)
            ih = 1.0 / h
            tau, PX, PV = _taylor(CX, CV, th, bd, ih, sw, sh, c, P, ktab, kamp, etab, ftab, kl,
                                  kal, gl, el, fl)
            tn = th + tau * ih
            ok = abs(tau) * _omega(P, ktab, kamp, kl, kal, c) < TAYLOR_MAX and 0.0 <= tn <= 1.0
            redo = g[_GREDO * GROUP + m]
            live = redo != 0.0
            g[_GCX * GROUP + m] = PX if live else g[_GCX * GROUP + m]
            g[_GCV * GROUP + m] = PV if live else g[_GCV * GROUP + m]
            g[_GTH * GROUP + m] = (tn if ok else min(max(tn, 0.0), 1.0)) if live else th
            g[_GNSUB * GROUP + m] += redo
            left = redo * (0.0 if ok else 1.0)
            g[_GREDO * GROUP + m] = left
            todo += left
        if todo == 0.0:
            break
    for m in range(GROUP):
        X0 = g[_GX0 * GROUP + m]
        b = g[_GB * GROUP + m]
        TX = g[_GTX * GROUP + m]
        r0 = _region(X0, b)
        r1 = _region(TX, b)
        rn = 0.0 if r0 != 0.0 else r1
        sh = b if rn > 0.0 else -b
        FX, FV = _substep(rk4, g[_GCX * GROUP + m], g[_GCV * GROUP + m], g[_GTH * GROUP + m], 1.0, g[_GH * GROUP + m], abs(rn), sh,
                          g[_GC * GROUP + m], P, ktab, kamp, etab, ftab, g[_GKM * GROUP + m], g[_GKA * GROUP + m],
                          g[_GGM * GROUP + m], g[_GES * GROUP + m], g[_GFS * GROUP + m])
        bd = r0 * b if r0 != 0.0 else (b if TX > b else -b)
        hard = (g[_GREDO * GROUP + m] != 0.0 or r0 == r1 or _region(FX, b) != rn
                or abs(X0 - bd) <= 1e-9 * abs(TX - bd))
        g[_GTX * GROUP + m] = FX
        g[_GTV * GROUP + m] = FV
        g[_GNSUB * GROUP + m] += 1.0
        g[_GREDO * GROUP + m] = 1.0 if hard else 0.0


@jit_inline
def _save_start(w):
    """Keep the state at the start of the step (the fix-up restarts from it)."""
    for l in range(LANES):
        w[_XO * LANES + l] = w[_X * LANES + l]
        w[_VO * LANES + l] = w[_V * LANES + l]


@jit_inline
def _crossings(w, live):
    """Bit mask of the live lanes whose step ended in another region than it started:
    (p0 - b)(p1 - b) < 0 or (p0 + b)(p1 + b) < 0 (ending exactly on a boundary is no crossing).
    Branch-free (``&`` on booleans, an OR reduction over shifted bits), so that it vectorises."""
    mask = 0
    for l in range(LANES):
        b = w[_B * LANES + l]
        xo = w[_XO * LANES + l]
        x = w[_X * LANES + l]
        d = min((xo - b) * (x - b), (xo + b) * (x + b))
        hit = (d < 0.0) & (w[_DEAD * LANES + l] == 0.0) & (l < live)
        mask |= np.int64(hit) << l
    return mask


@jit_inline
def _gather(g, m, wq, l):
    """Copy lane ``l`` of one block into slot ``m`` of the fix-up group."""
    g[_GX0 * GROUP + m] = wq[_XO * LANES + l]
    g[_GV0 * GROUP + m] = wq[_VO * LANES + l]
    g[_GTX * GROUP + m] = wq[_X * LANES + l]
    g[_GTV * GROUP + m] = wq[_V * LANES + l]
    g[_GH * GROUP + m] = wq[_H * LANES + l]
    g[_GB * GROUP + m] = wq[_B * LANES + l]
    g[_GC * GROUP + m] = wq[_C * LANES + l]
    g[_GKM * GROUP + m] = wq[_KM * LANES + l]
    g[_GKA * GROUP + m] = wq[_KA * LANES + l]
    g[_GGM * GROUP + m] = wq[_GM * LANES + l]
    g[_GES * GROUP + m] = wq[_ES * LANES + l]
    g[_GFS * GROUP + m] = wq[_FS * LANES + l]


@jit
def _fix(rk4, w, g, slot, ng, P, ktab, kamp, etab, ftab):
    """Fix up the ``ng`` lanes gathered in ``g`` (their block and lane in ``slot``) and scatter
    the results back; lanes the group pass marks go through the scalar ``_fixup``."""
    for m in range(ng, GROUP):  # pad with copies of the first lane; their results are dropped
        for r in range(_GTH):
            g[r * GROUP + m] = g[r * GROUP]
    _fixup_group(rk4, g, P, ktab, kamp, etab, ftab)
    for m in range(ng):
        q = slot[m] // LANES
        l = slot[m] % LANES
        wq = _block(w, q)
        if g[_GREDO * GROUP + m] != 0.0:
            X, V, ns = _fixup(rk4, wq[_XO * LANES + l], wq[_VO * LANES + l], wq[_X * LANES + l], wq[_V * LANES + l], wq[_H * LANES + l],
                              wq[_B * LANES + l], wq[_C * LANES + l], P, ktab, kamp, etab, ftab, wq[_KM * LANES + l],
                              wq[_KA * LANES + l], wq[_GM * LANES + l], wq[_ES * LANES + l], wq[_FS * LANES + l])
            wq[_X * LANES + l] = X
            wq[_V * LANES + l] = V
            wq[_NSUB * LANES + l] += ns
        else:
            wq[_X * LANES + l] = g[_GTX * GROUP + m]
            wq[_V * LANES + l] = g[_GTV * GROUP + m]
            wq[_NSUB * LANES + l] += g[_GNSUB * GROUP + m]


def _driver(method):
    """The kink-aware batch driver of one method (see ``rk._driver``)."""
    rk4 = method == RK4

    def integrate(h, cm, kmean, kamp, ktab, gmean, escale, etab, fscale, ftab, half_gap, bound, x0,
                  v0, n_transient, n_record, steps_per_period, signal, stride, sub):
        n = h.shape[0]
        S = _cycle(ktab, etab, ftab)
        stats = np.empty((n, N_STATS))
        xf = np.empty(n)
        vf = np.empty(n)
        status = np.zeros(n, np.int8)
        substeps = np.zeros(n, np.int64)
        span = sub * LANES
        nblocks = (n + span - 1) // span
        for blk in prange(nblocks):
            w = _scratch(sub)
            for q in range(sub):
                _load(_block(w, q), blk * span + q * LANES, n, h, cm, kmean, kamp, gmean, escale, fscale,
                      half_gap, bound, x0, v0)
            P = np.zeros((3, 5))
            g = np.zeros(_G_ROWS * GROUP)
            slot = np.zeros(GROUP, np.int64)
            half = n_transient + n_record // 2
            j = 0
            jp = 0
            for s in range(n_transient + n_record):
                K = _row(ktab, j)
                E = _row(etab, j)
                F = _row(ftab, j)
                have_p = False
                ng = 0
                for q in range(sub):
                    wq = _block(w, q)
                    _save_start(wq)
                    if rk4:
                        _rk4_lanes(wq, half_gap, kamp, ktab, K, etab, E, ftab, F, False)
                    else:
                        _rk5_lanes(wq, half_gap, kamp, ktab, K, etab, E, ftab, F, False)
                    mask = _crossings(wq, n - blk * span - q * LANES)
                    while mask != 0:
                        l = np.int64(trailing_zeros(mask))
                        mask &= mask - 1
                        if not have_p:
                            if ktab is not None:
                                _monomials(K, P, 0)
                            if etab is not None:
                                _monomials(E, P, 1)
                            if ftab is not None:
                                _monomials(F, P, 2)
                            have_p = True
                        _gather(g, ng, wq, l)
                        slot[ng] = q * LANES + l
                        ng += 1
                        if ng == GROUP:
                            _fix(rk4, w, g, slot, GROUP, P, ktab, kamp, etab, ftab)
                            ng = 0
                if ng > 0:
                    _fix(rk4, w, g, slot, ng, P, ktab, kamp, etab, ftab)
                j = j + 1 if j + 1 < S else 0
                jp = jp + 1 if jp + 1 < steps_per_period else 0
                for q in range(sub):
                    wq = _block(w, q)
                    i0 = blk * span + q * LANES
                    if s >= n_transient:
                        if s == n_transient:
                            _start_record(wq, half_gap)
                        if s == half:
                            _split(wq)
                        _accumulate(wq, half_gap)
                        if signal is not None:
                            _sample(wq, signal, s - n_transient, stride, i0, n)
                    if jp == 0:
                        _check(wq)
            for q in range(sub):
                i0 = blk * span + q * LANES
                if i0 < n:
                    _finish(_block(w, q), i0, n, n_record, steps_per_period, stats, xf, vf, status)
                    for l in range(min(LANES, n - i0)):
                        substeps[i0 + l] = int(w[q * _BLOCK + _NSUB * LANES + l])
        return stats, xf, vf, status, substeps

    integrate.__name__ = integrate.__qualname__ = f"integrate_kink_rk{method}"
    integrate.__doc__ = """Integrate a batch of cases with kink-aware steps.

    Arguments as ``gearsweep.kernels.rk.INTEGRATE``'s drivers, and ``sub``: plain blocks of
    ``LANES`` per kink block (``sub_blocks``).

    Returns
    -------
    stats : ndarray (n, N_STATS)
    xf, vf : ndarray (n,)
        State at the end [m], [m/s].
    status : ndarray (n,) int8
    substeps : ndarray (n,) int64
        Extra substeps taken at crossings (each costs one step's right-hand-side evaluations).
    """
    return jit_parallel(integrate)


def sub_blocks(n, threads):
    """Plain blocks per kink block for ``n`` cases: as many as keep every thread busy with at
    least two kink blocks, at most ``SUB_MAX``."""
    return max(1, min(SUB_MAX, -(-n // LANES) // (2 * max(threads, 1))))


INTEGRATE = {RK4: _driver(RK4), RK5: _driver(RK5)}
"""The compiled kink-aware driver of each method (``rk.METHODS`` value -> function)."""

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
1. Every block of ``LANES`` cases takes the plain vectorised step (``rk._rk4_lanes`` /
   ``rk._rk5_lanes``, the same code as the plain kernel).
2. A branch-free pass flags the lanes whose region at the step's end differs from the region at
   its start: (p0 - b)(p1 - b) < 0 or (p0 + b)(p1 + b) < 0 for the start and end values p0, p1
   (a step that ends exactly on a boundary is not a crossing). Only if a lane is flagged, a scalar
   fix-up loop redoes the step of each flagged lane from its saved start state:
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

Speed: on benchmark B2 (4.6 % of lane-steps cross) the kink-aware kernel takes 4.2 times the
plain kernel's wall time (``scripts/bench_kink.py``; docs/precision.md): a crossing costs two
scalar substeps plus root finding, against a fraction of a vectorised step. Without backlash
(``half_gap=None``) the detection is compiled out and the cost is the plain kernel's.
"""

import numpy as np
from numba import prange

from gearsweep.jit import jit_inline, jit_parallel
from gearsweep.kernels.rk import (
    _N_ACC,
    LANES,
    N_STATS,
    RK4,
    _accumulate,
    _check,
    _finish,
    _rk4_lanes,
    _rk5_lanes,
    _row,
)

MAX_CROSSINGS = 4
"""Crossings handled within one step; further ones are stepped over as in the plain kernel."""
NEWTON_MAX = 4
"""Substeps used at most to reach one crossing."""
TAYLOR_MAX = 2e-3
"""The last stretch to a crossing, tau, is covered by a degree-4 Taylor polynomial when
|tau| * (sqrt(K) + c/m) is below this: its error, about (that)^4 / 24 relative in p', is then
below 1e-12."""


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
    if x > b:
        return 1
    if x < -b:
        return -1
    return 0


@jit_inline
def _kg(P, th, kmode, kl, kal, has_e, has_f, gl, el, fl):
    """Stiffness/mass and force/mass at fraction ``th`` of the step, from the quartics.
    kmode: 0 constant ``kl``, 1 the table alone, 2 ``kl + kal * table``."""
    if kmode == 0:
        kk = kl
    elif kmode == 1:
        kk = _val(P, 0, th)
    else:
        kk = kl + kal * _val(P, 0, th)
    gg = gl
    if has_e:
        gg += el * _val(P, 1, th)
    if has_f:
        gg += fl * _val(P, 2, th)
    return kk, gg


@jit_inline
def _substep(method, X, V, ta, tb, h, sw, sh, c, P, kmode, kl, kal, has_e, has_f, gl, el, fl):
    """One RK step of the same method from fraction ``ta`` to ``tb`` of the step ``h``, with the
    force law f(p) = sw (p - sh) of one region extended smoothly beyond its boundary: the stages
    never see the kink (a stage on the far side of the boundary evaluated with the dead zone
    itself would cost O(H^4) per crossing and cap RK5 at order 4)."""
    eta = tb - ta
    H = eta * h
    if method == RK4:
        tm = ta + 0.5 * eta
        K1, G1 = _kg(P, ta, kmode, kl, kal, has_e, has_f, gl, el, fl)
        K2, G2 = _kg(P, tm, kmode, kl, kal, has_e, has_f, gl, el, fl)
        K3, G3 = _kg(P, tb, kmode, kl, kal, has_e, has_f, gl, el, fl)
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
    K1, G1 = _kg(P, ta, kmode, kl, kal, has_e, has_f, gl, el, fl)
    K2, G2 = _kg(P, ta + 0.25 * eta, kmode, kl, kal, has_e, has_f, gl, el, fl)
    K4, G4 = _kg(P, ta + 0.5 * eta, kmode, kl, kal, has_e, has_f, gl, el, fl)
    K5, G5 = _kg(P, ta + 0.75 * eta, kmode, kl, kal, has_e, has_f, gl, el, fl)
    K6, G6 = _kg(P, tb, kmode, kl, kal, has_e, has_f, gl, el, fl)
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
    """Fraction s in (0, 1] where the cubic Hermite interpolant of (X, V) -> (TX, TV) over a
    step H meets ``bd`` (the start and the end lie on opposite sides, or the start on ``bd``).

    In monomial form g(s) = c0 + c1 s + c2 s^2 + c3 s^3. When the start lies on the boundary
    (just after a crossing, |c0| tiny) the root sought is the return, a root of the quadratic
    g(s) / s; otherwise Newton's method on g from the secant estimate, kept inside [0, 1]. The
    estimate needs no high accuracy: the Taylor projection in ``_fixup`` corrects it."""
    c0 = X - bd
    c1 = H * V
    c2 = 3.0 * (TX - X) - H * (2.0 * V + TV)
    c3 = 2.0 * (X - TX) + H * (V + TV)
    g1 = c0 + c1 + c2 + c3
    if abs(c0) <= 1e-9 * abs(g1):
        # c1 + c2 s + c3 s^2 = 0: the smallest root in (0, 1]
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
    s = c0 / (c0 - g1)
    for _ in range(2):
        g = c0 + s * (c1 + s * (c2 + s * c3))
        dg = c1 + s * (2.0 * c2 + s * 3.0 * c3)
        if dg == 0.0:
            break
        s = min(max(s - g / dg, 0.0), 1.0)
    return s


@jit_inline
def _fixup(method, X0, V0, TX, TV, h, b, c, P, kmode, kl, kal, has_e, has_f, gl, el, fl):
    """Redo one step of one lane that crossed a boundary; returns (x, v, substeps taken).

    Per crossing: a substep (force law of the region being left) to the estimate from the
    Hermite cubic; then a Taylor polynomial of degree 4 in time about its end (derivatives from
    the same force law and the quartic coefficients) gives the remaining time to the boundary,
    and, if that time is short (|tau| omega < ``TAYLOR_MAX``), moves the state onto the boundary;
    otherwise the substep is redone to the Newton estimate. Then a substep with the new region's
    law finishes the step."""
    th = 0.0
    X = X0
    V = V0
    reg = _region(X0, b)
    nsub = 0
    ih = 1.0 / h
    w = np.sqrt(abs(kl) + abs(kal) * abs(_val(P, 0, 0.5)) if kmode > 0 else abs(kl)) + abs(c)
    for _ in range(MAX_CROSSINGS):
        treg = _region(TX, b)
        if treg == reg:
            break
        if reg == 1:
            bd = b
            new = 0
        elif reg == -1:
            bd = -b
            new = 0
        elif treg == 1:
            bd = b
            new = 1
        else:
            bd = -b
            new = -1
        sw = 0.0 if reg == 0 else 1.0
        sh = b if reg == 1 else -b
        rem = 1.0 - th
        tc = th + rem * _hermite_root(X, V, TX, TV, rem * h, bd)
        CX = X
        CV = V
        for _r in range(NEWTON_MAX):
            CX, CV = _substep(method, X, V, th, tc, h, sw, sh, c, P, kmode, kl, kal, has_e, has_f,
                              gl, el, fl)
            nsub += 1
            # time derivatives at the substep's end, old force law
            K0, G0 = _kg(P, tc, kmode, kl, kal, has_e, has_f, gl, el, fl)
            K1 = 0.0
            K2 = 0.0
            if kmode == 1:
                K1 = _d1(P, 0, tc) * ih
                K2 = _d2(P, 0, tc) * ih * ih
            elif kmode == 2:
                K1 = kal * _d1(P, 0, tc) * ih
                K2 = kal * _d2(P, 0, tc) * ih * ih
            G1 = 0.0
            G2 = 0.0
            if has_e:
                G1 += el * _d1(P, 1, tc) * ih
                G2 += el * _d2(P, 1, tc) * ih * ih
            if has_f:
                G1 += fl * _d1(P, 2, tc) * ih
                G2 += fl * _d2(P, 2, tc) * ih * ih
            f = sw * (CX - sh)
            a = G0 - c * CV - K0 * f
            j = G1 - c * a - K1 * f - K0 * sw * CV
            sn = G2 - c * j - K2 * f - 2.0 * K1 * sw * CV - K0 * sw * a
            a2 = 0.5 * a
            j2 = 0.5 * j
            j6 = j * (1.0 / 6.0)
            s6 = sn * (1.0 / 6.0)
            s24 = sn * (1.0 / 24.0)
            # Newton on the Taylor polynomial for the time tau to the boundary
            tau = -(CX - bd) / CV if CV != 0.0 else 0.0
            for _q in range(2):
                gx = CX - bd + tau * (CV + tau * (a2 + tau * (j6 + tau * s24)))
                gv = CV + tau * (a + tau * (j2 + tau * s6))
                if gv == 0.0:
                    break
                tau -= gx / gv
            tn = tc + tau * ih
            if abs(tau) * w < TAYLOR_MAX and tn <= 1.0:
                CX = CX + tau * (CV + tau * (a2 + tau * (j6 + tau * s24)))
                CV = CV + tau * (a + tau * (j2 + tau * s6))
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
        sw = 0.0 if reg == 0 else 1.0
        sh = b if reg == 1 else -b
        TX, TV = _substep(method, X, V, th, 1.0, h, sw, sh, c, P, kmode, kl, kal, has_e, has_f, gl,
                          el, fl)
        nsub += 1
    return TX, TV, nsub


@jit_inline
def _fixup_lanes(method, xo, vo, x, v, cross, dead, live, hl, bl, cl, P, kmode, km, ka, has_e,
                 has_f, gm, es, fs, nsub):
    """Redo the steps of the flagged lanes of a block (one call per step with crossings)."""
    for l in range(live):
        if cross[l] < 0.0 and not dead[l]:
            X, V, m = _fixup(method, xo[l], vo[l], x[l], v[l], hl[l], bl[l], cl[l], P, kmode, km[l],
                             ka[l], has_e, has_f, gm[l], es[l], fs[l])
            x[l] = X
            v[l] = V
            nsub[l] += m


@jit_parallel
def integrate(method, h, cm, kmean, kamp, ktab, gmean, escale, etab, fscale, ftab, half_gap,
              bound, x0, v0, n_transient, n_record, steps_per_period, signal, stride):
    """Integrate a batch of cases with kink-aware steps.

    Arguments as ``gearsweep.kernels.rk.integrate``.

    Returns
    -------
    stats : ndarray (n, N_STATS)
    xf, vf : ndarray (n,)
        State at the end [m], [m/s].
    status : ndarray (n,) int8
    substeps : ndarray (n,) int64
        Extra substeps taken at crossings (each costs one step's right-hand-side evaluations).
    """
    n = h.shape[0]
    S = 1
    if ktab is not None:
        S = ktab.shape[0]
    elif etab is not None:
        S = etab.shape[0]
    elif ftab is not None:
        S = ftab.shape[0]
    stats = np.empty((n, N_STATS))
    xf = np.empty(n)
    vf = np.empty(n)
    status = np.zeros(n, np.int8)
    substeps = np.zeros(n, np.int64)
    kmode = 0
    if ktab is not None:
        kmode = 1 if kamp is None else 2
    nblocks = (n + LANES - 1) // LANES
    for blk in prange(nblocks):
        i0 = blk * LANES
        x = np.empty(LANES)
        v = np.empty(LANES)
        xo = np.empty(LANES)
        vo = np.empty(LANES)
        hl = np.empty(LANES)
        h2 = np.empty(LANES)
        h6 = np.empty(LANES)
        cl = np.empty(LANES)
        km = np.empty(LANES)
        ka = np.empty(LANES)
        gm = np.empty(LANES)
        es = np.empty(LANES)
        fs = np.empty(LANES)
        bl = np.zeros(LANES)
        bd = np.empty(LANES)
        cross = np.zeros(LANES)
        P = np.zeros((3, 5))
        nsub = np.zeros(LANES, np.int64)
        K = np.empty(5)
        E = np.empty(5)
        F = np.empty(5)
        acc = np.zeros((_N_ACC, LANES))
        prev = np.zeros(LANES)
        dead = np.zeros(LANES, np.bool_)
        live = LANES if i0 + LANES <= n else n - i0
        for l in range(LANES):
            i = min(i0 + l, n - 1)
            x[l] = x0[i]
            v[l] = v0[i]
            hl[l] = h[i]
            h2[l] = 0.5 * h[i]
            h6[l] = h[i] / 6
            cl[l] = cm[i]
            km[l] = kmean[i]
            ka[l] = kamp[i] if kamp is not None else 1.0
            gm[l] = gmean[i]
            es[l] = escale[i]
            fs[l] = fscale[i]
            bd[l] = bound[i]
            if half_gap is not None:
                bl[l] = half_gap[i]
        half = n_transient + n_record // 2
        for s in range(n_transient + n_record):
            j = s % S
            _row(ktab, j, K)
            _row(etab, j, E)
            _row(ftab, j, F)
            if half_gap is not None:
                for l in range(LANES):
                    xo[l] = x[l]
                    vo[l] = v[l]
            if method == RK4:
                _rk4_lanes(x, v, hl, h2, h6, bl, half_gap, cl, km, ka, kamp, ktab, K, gm, es, etab,
                           E, fs, ftab, F)
            else:
                _rk5_lanes(x, v, hl, bl, half_gap, cl, km, ka, kamp, ktab, K, gm, es, etab, E, fs,
                           ftab, F)
            if half_gap is not None:
                dmin = 0.0
                for l in range(LANES):
                    b = bl[l]
                    # negative iff p - b or p + b changed sign over the step
                    d = min((xo[l] - b) * (x[l] - b), (xo[l] + b) * (x[l] + b))
                    cross[l] = d
                    dmin = min(dmin, d)
                if dmin < 0.0:
                    if ktab is not None:
                        _monomials(K, P, 0)
                    if etab is not None:
                        _monomials(E, P, 1)
                    if ftab is not None:
                        _monomials(F, P, 2)
                    _fixup_lanes(method, xo, vo, x, v, cross, dead, live, hl, bl, cl, P, kmode, km,
                                 ka, etab is not None, ftab is not None, gm, es, fs, nsub)
            if s >= n_transient:
                _accumulate(acc, prev, x, bl, half_gap, s >= half, s == n_transient)
                if signal is not None:
                    r = s - n_transient
                    if r % stride == 0:
                        for l in range(LANES):
                            if i0 + l < n:
                                signal[i0 + l, r // stride] = x[l]
            if (s + 1) % steps_per_period == 0:
                _check(x, v, bd, dead)
        _finish(acc, x, v, dead, i0, n, n_record, steps_per_period, stats, xf, vf, status)
        for l in range(live):
            substeps[i0 + l] = nsub[l]
    return stats, xf, vf, status, substeps

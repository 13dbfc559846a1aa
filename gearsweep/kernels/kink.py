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
   its start (sign of p - b and of p + b at both ends). Only if a lane is flagged, a scalar
   fix-up loop redoes the step of each flagged lane from its saved start state:
   a. locate the crossing time inside the step on the cubic Hermite interpolant of the trial
      step's end points (p and p' at both ends; bisection on the cubic), then refine
      it by Newton iterations on the substep itself (substep to theta, correction
      -(p - b) / (p' h)) until the correction is below ``THETA_TOL`` of a step (at most
      ``NEWTON_MAX`` substeps);
   b. keep the state of the substep that ends on the boundary, and finish the step with a
      substep from the crossing to the step's end; if that remainder crosses again, repeat
      (at most ``MAX_CROSSINGS`` crossings per step).
   Steps of lanes that do not cross are untouched, so a case without crossings gives results
   identical bit for bit to the plain kernel.

Coefficients inside a step
--------------------------
The tables hold K(t) and G(t) only at the five quarter-step nodes of each step. Substeps need
them at other times; they are taken from the quartic through the five node values of the step
(Lagrange interpolation). For smooth periodic coefficients its error is O(h^5) relative to the
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
"""

import numpy as np
from numba import prange

from gearsweep.jit import jit, jit_inline, jit_parallel
from gearsweep.kernels.rk import (
    _N_ACC,
    LANES,
    N_STATS,
    RK4,
    _accumulate,
    _check,
    _finish,
    _g,
    _k,
    _rk4_lanes,
    _rk5_lanes,
    _row,
)

MAX_CROSSINGS = 4
"""Crossings handled within one step; further ones are stepped over as in the plain kernel."""
NEWTON_MAX = 4
"""Newton substeps used to refine one crossing time."""
THETA_TOL = 1e-12
"""Newton stops when the crossing time correction is below this fraction of a step."""
BISECTIONS = 20
"""Bisections on the Hermite cubic (first estimate of the crossing to 1e-6 of a step; the
Newton substeps then converge quadratically from it)."""


@jit_inline
def _lagrange5(y, theta, on):
    """Quartic through y[0..4] at theta = 0, 1/4, 1/2, 3/4, 1, evaluated at ``theta``."""
    if not on:
        return 0.0
    u = 4.0 * theta
    a = u - 1.0
    b = u - 2.0
    c = u - 3.0
    d = u - 4.0
    return (y[0] * (a * b * c * d) / 24.0 - y[1] * (u * b * c * d) / 6.0
            + y[2] * (u * a * c * d) / 4.0 - y[3] * (u * a * b * d) / 6.0
            + y[4] * (u * a * b * c) / 24.0)


@jit_inline
def _region(x, b):
    if x > b:
        return 1
    if x < -b:
        return -1
    return 0


@jit_inline
def _acc(X, V, th, sw, sh, c, kl, kal, kamp, ktab, K, gl, el, etab, E, fl, ftab, F):
    """Right-hand side p'' at fraction ``th`` of the step with the linear force law of one
    region, f(p) = sw * (p - sh) (sw = 0 in the gap), coefficients from the quartic."""
    kk = _k(kl, kal, _lagrange5(K, th, ktab is not None), ktab, kamp)
    et = _lagrange5(E, th, etab is not None)
    ft = _lagrange5(F, th, ftab is not None)
    gg = _g(gl, el, et, etab, fl, ft, ftab)
    return gg - c * V - kk * (sw * (X - sh))


@jit_inline
def _substep(method, X, V, ta, tb, h, reg, b, c, kl, kal, kamp, ktab, K, gl, el, etab, E, fl, ftab,
             F):
    """One RK step of the same method from fraction ``ta`` to ``tb`` of the step ``h``, with the
    force law of region ``reg`` extended smoothly beyond its boundary: the stages never see the
    kink (a stage on the far side of the boundary with the dead zone itself would cost O(H^4)
    per crossing and cap RK5 at order 4)."""
    sw = 0.0 if reg == 0 else 1.0
    sh = b if reg == 1 else -b
    eta = tb - ta
    H = eta * h
    if method == RK4:
        k1v = _acc(X, V, ta, sw, sh, c, kl, kal, kamp, ktab, K, gl, el, etab, E, fl, ftab, F)
        k1x = V
        x2 = X + 0.5 * H * k1x
        v2 = V + 0.5 * H * k1v
        tm = ta + 0.5 * eta
        k2v = _acc(x2, v2, tm, sw, sh, c, kl, kal, kamp, ktab, K, gl, el, etab, E, fl, ftab, F)
        k2x = v2
        x3 = X + 0.5 * H * k2x
        v3 = V + 0.5 * H * k2v
        k3v = _acc(x3, v3, tm, sw, sh, c, kl, kal, kamp, ktab, K, gl, el, etab, E, fl, ftab, F)
        k3x = v3
        x4 = X + H * k3x
        v4 = V + H * k3v
        k4v = _acc(x4, v4, tb, sw, sh, c, kl, kal, kamp, ktab, K, gl, el, etab, E, fl, ftab, F)
        k4x = v4
        return (X + H / 6 * (k1x + 2 * k2x + 2 * k3x + k4x),
                V + H / 6 * (k1v + 2 * k2v + 2 * k3v + k4v))
    t1 = ta + 0.25 * eta
    t2 = ta + 0.5 * eta
    t3 = ta + 0.75 * eta
    a1 = V
    b1 = _acc(X, V, ta, sw, sh, c, kl, kal, kamp, ktab, K, gl, el, etab, E, fl, ftab, F)
    x2 = X + H * (0.25 * a1)
    v2 = V + H * (0.25 * b1)
    a2 = v2
    b2 = _acc(x2, v2, t1, sw, sh, c, kl, kal, kamp, ktab, K, gl, el, etab, E, fl, ftab, F)
    x3 = X + H * (0.125 * a1 + 0.125 * a2)
    v3 = V + H * (0.125 * b1 + 0.125 * b2)
    a3 = v3
    b3 = _acc(x3, v3, t1, sw, sh, c, kl, kal, kamp, ktab, K, gl, el, etab, E, fl, ftab, F)
    x4 = X + H * (-0.5 * a2 + a3)
    v4 = V + H * (-0.5 * b2 + b3)
    a4 = v4
    b4 = _acc(x4, v4, t2, sw, sh, c, kl, kal, kamp, ktab, K, gl, el, etab, E, fl, ftab, F)
    x5 = X + H * (0.1875 * a1 + 0.5625 * a4)
    v5 = V + H * (0.1875 * b1 + 0.5625 * b4)
    a5 = v5
    b5 = _acc(x5, v5, t3, sw, sh, c, kl, kal, kamp, ktab, K, gl, el, etab, E, fl, ftab, F)
    x6 = X + H * (-3.0 * a1 + 2.0 * a2 + 12.0 * a3 - 12.0 * a4 + 8.0 * a5) / 7.0
    v6 = V + H * (-3.0 * b1 + 2.0 * b2 + 12.0 * b3 - 12.0 * b4 + 8.0 * b5) / 7.0
    a6 = v6
    b6 = _acc(x6, v6, tb, sw, sh, c, kl, kal, kamp, ktab, K, gl, el, etab, E, fl, ftab, F)
    return (X + H * (7.0 * (a1 + a6) + 32.0 * (a3 + a5) + 12.0 * a4) / 90.0,
            V + H * (7.0 * (b1 + b6) + 32.0 * (b3 + b5) + 12.0 * b4) / 90.0)


@jit_inline
def _hermite_root(X, V, TX, TV, H, bd, sigma):
    """Fraction s in (0, 1] where the cubic Hermite interpolant of (X, V) -> (TX, TV) over a
    step H meets ``bd``, by ``BISECTIONS`` bisections; sigma * (p - bd) > 0 inside the region
    being left. The start counts as inside even when it lies on the boundary (just after a
    crossing), so a return to the same boundary is found, not the start itself."""
    lo = 0.0
    hi = 1.0
    for _ in range(BISECTIONS):
        s = 0.5 * (lo + hi)
        s2 = s * s
        s3 = s2 * s
        p = ((2 * s3 - 3 * s2 + 1) * X + (s3 - 2 * s2 + s) * H * V + (-2 * s3 + 3 * s2) * TX
             + (s3 - s2) * H * TV)
        if sigma * (p - bd) > 0:
            lo = s
        else:
            hi = s
    return 0.5 * (lo + hi)


@jit
def _fixup(method, X0, V0, TX, TV, h, b, c, kl, kal, kamp, ktab, K, gl, el, etab, E, fl, ftab, F):
    """Redo one step of one lane that crossed a boundary; returns (x, v, substeps taken)."""
    th = 0.0
    X = X0
    V = V0
    reg = _region(X0, b)
    nsub = 0
    for _ in range(MAX_CROSSINGS):
        treg = _region(TX, b)
        if treg == reg:
            break
        if reg == 1:
            bd = b
            sigma = 1.0
            new = 0
        elif reg == -1:
            bd = -b
            sigma = -1.0
            new = 0
        elif treg == 1:
            bd = b
            sigma = -1.0
            new = 1
        else:
            bd = -b
            sigma = 1.0
            new = -1
        rem = 1.0 - th
        s = _hermite_root(X, V, TX, TV, rem * h, bd, sigma)
        tc = th + s * rem
        CX = X
        CV = V
        for r in range(NEWTON_MAX):
            CX, CV = _substep(method, X, V, th, tc, h, reg, b, c, kl, kal, kamp, ktab, K, gl, el,
                              etab, E, fl, ftab, F)
            nsub += 1
            if CV == 0.0 or r == NEWTON_MAX - 1:
                break
            d = -(CX - bd) / (CV * h)
            tn = tc + d
            if abs(d) < THETA_TOL or not (tn > th and tn <= 1.0):
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
        TX, TV = _substep(method, X, V, th, 1.0, h, reg, b, c, kl, kal, kamp, ktab, K, gl, el, etab,
                          E, fl, ftab, F)
        nsub += 1
    return TX, TV, nsub


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
        cross = np.zeros(LANES, np.bool_)
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
                anyc = False
                for l in range(LANES):
                    b = bl[l]
                    c = ((xo[l] > b) != (x[l] > b)) or ((xo[l] < -b) != (x[l] < -b))
                    cross[l] = c
                    anyc = anyc or c
                if anyc:
                    for l in range(live):
                        if cross[l] and not dead[l]:
                            X, V, m = _fixup(method, xo[l], vo[l], x[l], v[l], hl[l], bl[l], cl[l],
                                             km[l], ka[l], kamp, ktab, K, gm[l], es[l], etab, E,
                                             fs[l], ftab, F)
                            x[l] = X
                            v[l] = V
                            nsub[l] += m
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

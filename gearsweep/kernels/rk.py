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
inner loop over lanes is branch-free and LLVM vectorises it across cases (AVX2/AVX-512); blocks are
spread over all cores with ``prange``. Each case's arithmetic does not depend on which block or
thread runs it, so results are identical for any thread count.

Methods
-------
``RK4``: the classic fourth-order method (Kutta 1901), nodes c = (0, 1/2, 1/2, 1).
``RK5``: Butcher's fifth-order method (Butcher 1964; Butcher, *Numerical Methods for ODEs*, 2016,
Sec. 236): six stages, the fewest any fifth-order explicit method can have, rational coefficients,
and nodes c = (0, 1/4, 1/4, 1/2, 3/4, 1) on a quarter-step grid, so that one table of five
nodes per step serves both methods. (Dormand-Prince's fifth-order solution needs seven stages, or
six with FSAL, and nodes at 1/5, 3/10, 4/5, 8/9, which would need a table per node.)
"""

import numpy as np
from numba import prange

from gearsweep.jit import jit_inline, jit_parallel

LANES = 32
"""Cases advanced together in one vectorised block (four AVX-512 or eight AVX2 registers)."""

NODES = (0.0, 0.25, 0.5, 0.75, 1.0)
"""Stage nodes (fractions of a step) at which the periodic shapes are tabulated."""

RK4 = 4
RK5 = 5
METHODS = {"rk4": RK4, "rk5": RK5}
STAGES = {RK4: 4, RK5: 6}

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

STATUS_OK = 0
STATUS_DIVERGED = 1
"""The state became non-finite or left ``|p| <= bound``: the case was stopped, statistics NaN."""

# Rows of the per-block accumulator.
_A_MAX1, _A_MIN1, _A_MAX2, _A_MIN2, _A_SUM, _A_SUM2, _A_GAP, _A_BACK, _A_IMP, _A_SHIFT = range(10)
_N_ACC = 10


@jit_inline
def _dead_zone(x, b):
    """Backlash force law f(p) of Eq. (8), branch-free: p - clip(p, -b, b)."""
    y = x if x < b else b
    y = y if y > -b else -b
    return x - y


@jit_inline
def _spring(x, b, half_gap):
    if half_gap is None:
        return x
    return _dead_zone(x, b)


@jit_inline
def _k(km, ka, kt, ktab, kamp):
    """Stiffness/mass at one node: the mean alone when the stiffness is constant, the table
    alone when every case shares it (``kamp is None``), else mean + scale * table."""
    if ktab is None:
        return km
    if kamp is None:
        return kt
    return km + ka * kt


@jit_inline
def _g(gm, es, et, etab, fs, ft, ftab):
    """Force/mass at one node: mean force, STE term and torque fluctuation, as switched on."""
    g = gm
    if etab is not None:
        g += es * et
    if ftab is not None:
        g += fs * ft
    return g


@jit_inline
def _rk4_lanes(x, v, hl, h2, h6, bl, half_gap, cl, km, ka, kamp, ktab, K, gm, es, etab, E, fs, ftab, F):
    """One classic RK4 step for every lane; K, E, F: table rows of the step (5 nodes)."""
    for l in range(LANES):
        hh = hl[l]
        q2 = h2[l]
        b = bl[l]
        c = cl[l]
        kl = km[l]
        kal = ka[l]
        Ka = _k(kl, kal, K[0], ktab, kamp)
        Kb = _k(kl, kal, K[2], ktab, kamp)
        Kc = _k(kl, kal, K[4], ktab, kamp)
        gl = gm[l]
        el = es[l]
        fl = fs[l]
        Ga = _g(gl, el, E[0], etab, fl, F[0], ftab)
        Gb = _g(gl, el, E[2], etab, fl, F[2], ftab)
        Gc = _g(gl, el, E[4], etab, fl, F[4], ftab)
        X = x[l]
        V = v[l]
        k1x = V
        k1v = Ga - c * V - Ka * _spring(X, b, half_gap)
        x2 = X + q2 * k1x
        v2 = V + q2 * k1v
        k2x = v2
        k2v = Gb - c * v2 - Kb * _spring(x2, b, half_gap)
        x3 = X + q2 * k2x
        v3 = V + q2 * k2v
        k3x = v3
        k3v = Gb - c * v3 - Kb * _spring(x3, b, half_gap)
        x4 = X + hh * k3x
        v4 = V + hh * k3v
        k4x = v4
        k4v = Gc - c * v4 - Kc * _spring(x4, b, half_gap)
        x[l] = X + h6[l] * (k1x + 2 * k2x + 2 * k3x + k4x)
        v[l] = V + h6[l] * (k1v + 2 * k2v + 2 * k3v + k4v)


@jit_inline
def _rk5_lanes(x, v, hl, bl, half_gap, cl, km, ka, kamp, ktab, K, gm, es, etab, E, fs, ftab, F):
    """One step of Butcher's six-stage fifth-order method for every lane."""
    for l in range(LANES):
        h = hl[l]
        b = bl[l]
        c = cl[l]
        kl = km[l]
        kal = ka[l]
        gl = gm[l]
        el = es[l]
        fl = fs[l]
        X = x[l]
        V = v[l]
        # stage 1, c = 0
        a1 = V
        b1 = _g(gl, el, E[0], etab, fl, F[0], ftab) - c * V - _k(kl, kal, K[0], ktab, kamp) * _spring(
            X, b, half_gap)
        # stage 2, c = 1/4
        g1 = _g(gl, el, E[1], etab, fl, F[1], ftab)
        k1 = _k(kl, kal, K[1], ktab, kamp)
        x2 = X + h * (0.25 * a1)
        v2 = V + h * (0.25 * b1)
        a2 = v2
        b2 = g1 - c * v2 - k1 * _spring(x2, b, half_gap)
        # stage 3, c = 1/4
        x3 = X + h * (0.125 * a1 + 0.125 * a2)
        v3 = V + h * (0.125 * b1 + 0.125 * b2)
        a3 = v3
        b3 = g1 - c * v3 - k1 * _spring(x3, b, half_gap)
        # stage 4, c = 1/2
        x4 = X + h * (-0.5 * a2 + a3)
        v4 = V + h * (-0.5 * b2 + b3)
        a4 = v4
        b4 = _g(gl, el, E[2], etab, fl, F[2], ftab) - c * v4 - _k(kl, kal, K[2], ktab, kamp) * _spring(
            x4, b, half_gap)
        # stage 5, c = 3/4
        x5 = X + h * (0.1875 * a1 + 0.5625 * a4)
        v5 = V + h * (0.1875 * b1 + 0.5625 * b4)
        a5 = v5
        b5 = _g(gl, el, E[3], etab, fl, F[3], ftab) - c * v5 - _k(kl, kal, K[3], ktab, kamp) * _spring(
            x5, b, half_gap)
        # stage 6, c = 1
        x6 = X + h * (-3.0 * a1 + 2.0 * a2 + 12.0 * a3 - 12.0 * a4 + 8.0 * a5) / 7.0
        v6 = V + h * (-3.0 * b1 + 2.0 * b2 + 12.0 * b3 - 12.0 * b4 + 8.0 * b5) / 7.0
        a6 = v6
        b6 = _g(gl, el, E[4], etab, fl, F[4], ftab) - c * v6 - _k(kl, kal, K[4], ktab, kamp) * _spring(
            x6, b, half_gap)
        x[l] = X + h * (7.0 * (a1 + a6) + 32.0 * (a3 + a5) + 12.0 * a4) / 90.0
        v[l] = V + h * (7.0 * (b1 + b6) + 32.0 * (b3 + b5) + 12.0 * b4) / 90.0


@jit_inline
def _row(tab, j, buf):
    """Copy the 5 node values of step ``j`` (zeros when the term is off)."""
    if tab is None:
        for c in range(5):
            buf[c] = 0.0
    else:
        for c in range(5):
            buf[c] = tab[j, c]


@jit_parallel
def integrate(method, h, cm, kmean, kamp, ktab, gmean, escale, etab, fscale, ftab, half_gap,
              bound, x0, v0, n_transient, n_record, steps_per_period, signal, stride):
    """Integrate a batch of cases; see the module docstring for the model.

    Parameters
    ----------
    method : int
        ``RK4`` or ``RK5``.
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

    Returns
    -------
    stats : ndarray (n, N_STATS)
    xf, vf : ndarray (n,)
        State at the end [m], [m/s] (for continuation and monodromy matrices).
    status : ndarray (n,) int8
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
    nblocks = (n + LANES - 1) // LANES
    for blk in prange(nblocks):
        i0 = blk * LANES
        x = np.empty(LANES)
        v = np.empty(LANES)
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
        K = np.empty(5)
        E = np.empty(5)
        F = np.empty(5)
        acc = np.zeros((_N_ACC, LANES))
        prev = np.zeros(LANES)
        dead = np.zeros(LANES, np.bool_)
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
            if method == RK4:
                _rk4_lanes(x, v, hl, h2, h6, bl, half_gap, cl, km, ka, kamp, ktab, K, gm, es, etab, E,
                           fs, ftab, F)
            else:
                _rk5_lanes(x, v, hl, bl, half_gap, cl, km, ka, kamp, ktab, K, gm, es, etab, E, fs,
                           ftab, F)
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
    return stats, xf, vf, status


@jit_inline
def _accumulate(acc, prev, x, bl, half_gap, second_half, first):
    """Running steady-state statistics after one recorded step: one fused pass over the lanes."""
    if first:
        for l in range(LANES):
            for q in range(_N_ACC):
                acc[q, l] = 0.0
            acc[_A_MAX1, l] = -np.inf
            acc[_A_MAX2, l] = -np.inf
            acc[_A_MIN1, l] = np.inf
            acc[_A_MIN2, l] = np.inf
            acc[_A_SHIFT, l] = x[l]  # sums about the first sample: no cancellation in the rms
            if half_gap is not None:
                prev[l] = 1.0 if abs(x[l]) < bl[l] else 0.0
    if second_half:
        for l in range(LANES):
            acc[_A_MAX2, l] = max(acc[_A_MAX2, l], x[l])
            acc[_A_MIN2, l] = min(acc[_A_MIN2, l], x[l])
    else:
        for l in range(LANES):
            acc[_A_MAX1, l] = max(acc[_A_MAX1, l], x[l])
            acc[_A_MIN1, l] = min(acc[_A_MIN1, l], x[l])
    for l in range(LANES):
        X = x[l]
        d = X - acc[_A_SHIFT, l]
        acc[_A_SUM, l] += d
        acc[_A_SUM2, l] += d * d
        if half_gap is not None:
            b = bl[l]
            gap = abs(X) < b
            was = prev[l]
            acc[_A_GAP, l] += 1.0 if gap else 0.0
            acc[_A_BACK, l] += 1.0 if X < -b else 0.0
            acc[_A_IMP, l] += 1.0 if was > 0.5 and not gap else 0.0  # gap -> contact: an impact
            prev[l] = 1.0 if gap else 0.0


@jit_inline
def _check(x, v, bd, dead):
    """Stop lanes whose state is non-finite or beyond the bound (checked once per mesh period)."""
    for l in range(LANES):
        if not (abs(x[l]) <= bd[l] and abs(v[l]) < np.inf):
            dead[l] = True
            x[l] = 0.0
            v[l] = 0.0


@jit_inline
def _finish(acc, x, v, dead, i0, n, n_record, spp, stats, xf, vf, status):
    """Turn the accumulators of one block into per-case statistics and final states."""
    for l in range(LANES):
        i = i0 + l
        if i >= n:
            break
        if dead[l]:
            for q in range(N_STATS):
                stats[i, q] = np.nan
            xf[i] = np.nan
            vf[i] = np.nan
            status[i] = STATUS_DIVERGED
            continue
        xf[i] = x[l]
        vf[i] = v[l]
        if n_record == 0:
            for q in range(N_STATS):
                stats[i, q] = np.nan
            continue
        mean_d = acc[_A_SUM, l] / n_record
        pmax = max(acc[_A_MAX1, l], acc[_A_MAX2, l])
        pmin = min(acc[_A_MIN1, l], acc[_A_MIN2, l])
        stats[i, ST_MAX] = pmax
        stats[i, ST_MIN] = pmin
        stats[i, ST_MEAN] = acc[_A_SHIFT, l] + mean_d
        stats[i, ST_RMS] = np.sqrt(max(acc[_A_SUM2, l] / n_record - mean_d * mean_d, 0.0))
        stats[i, ST_CONTACT_LOSS] = acc[_A_GAP, l] / n_record
        stats[i, ST_BACKSIDE] = acc[_A_BACK, l] / n_record
        stats[i, ST_IMPACTS] = acc[_A_IMP, l] * spp / n_record
        drift = max(abs(acc[_A_MAX2, l] - acc[_A_MAX1, l]), abs(acc[_A_MIN2, l] - acc[_A_MIN1, l]))
        pp = pmax - pmin
        stats[i, ST_SETTLE] = drift / pp if pp > 0 else 0.0

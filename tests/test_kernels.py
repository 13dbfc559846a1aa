"""Tests of the batch RK kernel (``gearsweep.kernels``) against independent truth.

Truth comes from closed forms (frequency response of a linear oscillator, static deflection,
RK stability polynomials, Butcher's order conditions, the bouncing of a free oscillator through a
dead zone), from scipy's DOP853 at rtol = 1e-13, and from NumPy statistics of the returned signal.

Only three kernel specialisations are compiled (each once, then cached on disk):

* ``_linear``: constant stiffness, harmonic force through ``fluct_table``, no backlash, signal;
* ``_smooth``: shared time-varying stiffness table and STE, no backlash, no signal (= bench B1);
* ``_backlash``: shared stiffness table and STE, dead zone, signal.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numba
import numpy as np
import pytest
from numpy.testing import assert_allclose

from gearsweep.kernels import (
    LANES,
    STAT_NAMES,
    STATUS_DIVERGED,
    STATUS_OK,
    fourier_table,
    simulate,
)

# ----------------------------------------------------------------------------- scenes


def _linear(*, h, method="rk4", damping, k, force=0.0, f0=0.0, x0=0.0, v0=0.0, spp,
            n_transient, n_record, stride=1):
    """p'' = force + f0 cos(2 pi t / (spp h)) - damping p' - k p (all per unit mass)."""
    return simulate(h, method=method, damping=damping, k_mean=k, force=force,
                    fluct_scale=f0, fluct_table=fourier_table(1.0, 1.0, 0.0, spp),
                    x0=x0, v0=v0, n_transient=n_transient, n_record=n_record,
                    steps_per_period=spp, signal_stride=stride)


# Bench-like gear mesh per unit mass: k(t)/m with 3 harmonics, STE with 3 harmonics.
_M, _C, _K0, _F = 0.1527, 5500.0, 1.073e9, 833.0
_KN, _EN, _ORD = np.array([179e6, 40e6, 10e6]), np.array([5e-6, 1e-6, 0.3e-6]), np.arange(1.0, 4.0)


def _mesh_inputs(rpm, spp=32):
    omega = 48 * np.asarray(rpm, dtype=float) * 2 * np.pi / 60
    return dict(h=2 * np.pi / omega / spp, damping=_C / _M,
                k_table=(_K0 + fourier_table(_KN, _ORD, np.zeros(3), spp)) / _M, force=_F / _M,
                ste_scale=-omega * omega,
                ste_table=fourier_table(_EN, _ORD, np.zeros(3), spp, derivative=2),
                steps_per_period=spp)


def _backlash(rpm, *, half_gap=2e-6, n_transient=32 * 40, n_record=32 * 20, stride=3, **kw):
    inputs = _mesh_inputs(rpm)
    inputs.update(kw)
    return simulate(**inputs, half_gap=np.broadcast_to(half_gap, np.shape(rpm)),
                    n_transient=n_transient, n_record=n_record, signal_stride=stride)


def _rpm(n, seed=1):
    return np.random.default_rng(seed).uniform(1000.0, 20000.0, n)


@pytest.fixture
def restore_threads():
    n = numba.get_num_threads()
    yield
    numba.set_num_threads(n)


# ----------------------------------------------------------------------------- (a) linear


def _lti_case(method, spp):
    """A damped oscillator (zeta = 0.1) driven near resonance (W = 0.8 wn), 60 + 20 periods."""
    m = 0.5  # [kg]
    wn, zeta = 2 * np.pi * 1000.0, 0.1  # [rad/s], [-]
    k, c = m * wn**2, 2 * zeta * wn * m  # [N/m], [N s/m]
    W = 0.8 * wn  # forcing frequency [rad/s]
    F0, Fm = 3.0, 5.0  # [N]
    res = _linear(h=2 * np.pi / W / spp, method=method, damping=c / m, k=k / m, force=Fm / m,
                  f0=F0 / m, spp=spp, n_transient=60 * spp, n_record=20 * spp)
    amp = (F0 / m) / math.sqrt((wn**2 - W**2) ** 2 + (c / m * W) ** 2)
    return res, amp, Fm / k


@pytest.mark.parametrize("method", ["rk4", "rk5"])
def test_linear_steady_state_matches_frequency_response(method):
    # The amplitude is sqrt(2) * p_rms: for a sinusoid sampled at N > 2 equidistant points per
    # period over whole periods, mean(cos^2) = 1/2 exactly, so sampling adds no error (the sampled
    # extremes would be low by up to 1 - cos(pi/N)). 256 steps per forcing period: wn h = 0.031,
    # and RK4's error in the steady-state amplitude, O((wn h)^4), is 2e-8 (5e-6 at 64 steps per
    # period: too coarse for 1e-6); RK5's is 1e-12. The transient has decayed by
    # exp(-zeta wn t) = exp(-47) after 60 periods.
    res, amp, static = _lti_case(method, 256)
    assert res.status[0] == STATUS_OK
    assert_allclose(math.sqrt(2.0) * res.stats["p_rms"][0], amp, rtol=1e-6)
    # The constant force gives the static deflection, F_m / k, as the mean: the discrete steady
    # state is that fixed point plus a pure harmonic of the step map, whose mean over whole
    # periods is zero; only rounding is left.
    assert_allclose(res.stats["p_mean"][0], static, rtol=1e-12)


def test_linear_amplitude_error_is_fourth_order():
    # Why 256 steps: the amplitude error at 64 steps per period exceeds 1e-6 and falls ~16-fold
    # per halving of h, so the tolerance above is met by accuracy, not by luck.
    errors = []
    for spp in (64, 128, 256):
        res, amp, _ = _lti_case("rk4", spp)
        errors.append(abs(math.sqrt(2.0) * res.stats["p_rms"][0] / amp - 1.0))
    assert errors[0] > 1e-6 > errors[2]
    assert 3.8 < math.log2(errors[1] / errors[2]) < 4.2


def test_sinusoid_statistics():
    res, amp, static = _lti_case("rk4", 256)
    sig = res.signal[0]
    assert sig.shape == (20 * 256,)
    # statistics against NumPy on the returned signal (different summation order: 1e-12)
    assert_allclose(res.stats["p_mean"][0], sig.mean(), rtol=1e-12)
    assert_allclose(res.stats["p_rms"][0], sig.std(), rtol=1e-12)
    assert res.stats["p_max"][0] == sig.max()
    assert res.stats["p_min"][0] == sig.min()
    # ... and against the known sinusoid static + amp cos(W t - phi) sampled at N = 256 points
    # per period: the sampled peak-to-peak lies in [2 amp cos(pi/N), 2 amp]
    p_pp = res.stats["p_max"][0] - res.stats["p_min"][0]
    assert 2 * amp * math.cos(math.pi / 256) * (1 - 1e-6) <= p_pp <= 2 * amp * (1 + 1e-6)
    assert_allclose(0.5 * (res.stats["p_max"][0] + res.stats["p_min"][0]), static,
                    rtol=0, atol=amp * (1 - math.cos(math.pi / 256)) + 1e-6 * amp)
    # no backlash: never apart, never on the back flank, no impacts
    for name in ("contact_loss_fraction", "backside_contact_fraction", "impacts_per_period"):
        assert res.stats[name][0] == 0.0
    assert res.stats["settle_error"][0] < 1e-6


# ----------------------------------------------------------------------------- (b) order


def _end_state_errors(method, spps):
    """Error of the end state after 4 periods of a Mathieu-Hill oscillator with STE forcing."""
    from scipy.integrate import solve_ivp

    wn, W, zeta, eps, e1 = 2 * np.pi * 50, 2 * np.pi * 40, 0.05, 0.2, 1e-3
    periods, x0 = 4, 1e-3

    def rhs(t, y):
        c1 = math.cos(W * t)
        return [y[1], e1 * W * W * c1 - 2 * zeta * wn * y[1] - wn * wn * (1 + eps * c1) * y[0]]

    ref = solve_ivp(rhs, (0, periods * 2 * np.pi / W), [x0, 0.0], method="DOP853", rtol=1e-13,
                    atol=1e-18).y[:, -1]
    errors = []
    for spp in spps:
        r = simulate(2 * np.pi / W / spp, method=method, damping=2 * zeta * wn,
                     k_table=wn * wn * (1 + eps * fourier_table(1.0, 1.0, 0.0, spp)),
                     ste_scale=-W * W, ste_table=fourier_table(e1, 1.0, 0.0, spp, derivative=2),
                     x0=x0, n_transient=periods * spp, n_record=0, steps_per_period=spp)
        errors.append(math.hypot(r.x_final[0] - ref[0], (r.v_final[0] - ref[1]) / wn))
    return np.array(errors)


@pytest.mark.parametrize(("method", "lo", "hi"), [("rk4", 3.8, 4.2), ("rk5", 4.7, 5.3)])
def test_convergence_order(method, lo, hi):
    # Time-varying stiffness (eps = 0.2) and STE forcing: smooth, so the asymptotic order shows.
    # At 32..128 steps per period the errors (1e-6..1e-12 of the 1e-3 state) are far above the
    # DOP853 reference's (~1e-16) and in the asymptotic range: measured 4.00, 4.00 and 5.09, 5.05.
    errors = _end_state_errors(method, [32, 64, 128])
    orders = np.log2(errors[:-1] / errors[1:])
    assert np.all((lo < orders) & (orders < hi)), orders


# ----------------------------------------------------------------------------- (c) threads


def _all_outputs(res):
    return [res.stats[name] for name in STAT_NAMES] + [res.x_final, res.v_final, res.status,
                                                        res.signal]


def test_parallel_equals_single_thread_bitwise(restore_threads):
    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("needs 2 threads")
    rpm = _rpm(100)
    numba.set_num_threads(1)
    one = _backlash(rpm)
    numba.set_num_threads(2)
    two = _backlash(rpm)
    for a, b in zip(_all_outputs(one), _all_outputs(two), strict=True):
        assert np.array_equal(a, b)


def test_results_independent_of_batch_size_and_position():
    rpm = _rpm(100, seed=2)
    target = 7345.0
    reference = _backlash(np.array([target]))
    assert reference.status[0] == STATUS_OK
    for n, pos in [(1, 0), (33, 0), (33, 31), (33, 32), (100, 0), (100, LANES - 1), (100, LANES),
                   (100, 99)]:
        batch = rpm[:n].copy()
        batch[pos] = target
        res = _backlash(batch)
        for a, b in zip(_all_outputs(reference), _all_outputs(res), strict=True):
            assert np.array_equal(a[0], b[pos]), (n, pos)


# ----------------------------------------------------------------------------- (d) divergence


def test_diverging_case_is_flagged_and_isolated():
    rpm = _rpm(100, seed=3)
    inputs = _mesh_inputs(rpm)
    healthy = _backlash(rpm)
    bad, beyond = 40, 41
    damping = np.full(100, inputs["damping"])
    damping[bad] = -inputs["damping"]  # negative damping: p grows like exp(+zeta wn t)
    bound = np.full(100, 1e-3)  # 1 mm: far beyond any motion of a working mesh
    bound[beyond] = 1e-6  # a healthy motion that leaves |p| <= 1 um: stopped by the bound
    res = _backlash(rpm, damping=damping, bound=bound)
    assert np.array_equal(_backlash(rpm, bound=1e-3).stats["p_max"], healthy.stats["p_max"])
    assert res.status[bad] == STATUS_DIVERGED and res.status[beyond] == STATUS_DIVERGED
    for i in (bad, beyond):
        assert all(np.isnan(res.stats[name][i]) for name in STAT_NAMES)
        assert np.isnan(res.x_final[i]) and np.isnan(res.v_final[i])
    others = np.setdiff1d(np.arange(100), [bad, beyond])
    assert np.all(res.status[others] == STATUS_OK)
    for a, b in zip(_all_outputs(healthy), _all_outputs(res), strict=True):
        assert np.array_equal(a[others], b[others])  # neighbours (same block) bit for bit


# ----------------------------------------------------------------------------- (e) Butcher

F = Fraction
# Butcher's six-stage fifth-order method as written in gearsweep/kernels/rk.py (_rk5_lanes).
_C5 = [F(0), F(1, 4), F(1, 4), F(1, 2), F(3, 4), F(1)]
_A5 = [
    [],
    [F(1, 4)],
    [F(1, 8), F(1, 8)],
    [F(0), F(-1, 2), F(1)],
    [F(3, 16), F(0), F(0), F(9, 16)],
    [F(-3, 7), F(2, 7), F(12, 7), F(-12, 7), F(8, 7)],
]
_B5 = [F(7, 90), F(0), F(32, 90), F(12, 90), F(32, 90), F(7, 90)]


def _mat(rows):
    s = len(rows)
    return [[rows[i][j] if j < len(rows[i]) else F(0) for j in range(s)] for i in range(s)]


def _dot(u, v):
    return sum((a * b for a, b in zip(u, v, strict=True)), F(0))


def _mv(a, v):
    return [_dot(row, v) for row in a]


def _mul(u, v):
    return [a * b for a, b in zip(u, v, strict=True)]


def test_butcher_rk5_order_conditions():
    a, b, c = _mat(_A5), _B5, _C5
    assert _mv(a, [F(1)] * 6) == c  # row sums are the nodes
    ac = _mv(a, c)
    c2, c3 = _mul(c, c), _mul(c, _mul(c, c))
    conditions = {  # the 17 rooted trees up to order 5: sum b Phi(t) = 1 / t!
        "b": (sum(b), F(1)),
        "bc": (_dot(b, c), F(1, 2)),
        "bc2": (_dot(b, c2), F(1, 3)),
        "bAc": (_dot(b, ac), F(1, 6)),
        "bc3": (_dot(b, c3), F(1, 4)),
        "bcAc": (_dot(b, _mul(c, ac)), F(1, 8)),
        "bAc2": (_dot(b, _mv(a, c2)), F(1, 12)),
        "bAAc": (_dot(b, _mv(a, ac)), F(1, 24)),
        "bc4": (_dot(b, _mul(c, c3)), F(1, 5)),
        "bc2Ac": (_dot(b, _mul(c2, ac)), F(1, 10)),
        "bcAc2": (_dot(b, _mul(c, _mv(a, c2))), F(1, 15)),
        "bcAAc": (_dot(b, _mul(c, _mv(a, ac))), F(1, 30)),
        "b(Ac)^2": (_dot(b, _mul(ac, ac)), F(1, 20)),
        "bAc3": (_dot(b, _mv(a, c3)), F(1, 20)),
        "bA(cAc)": (_dot(b, _mv(a, _mul(c, ac))), F(1, 40)),
        "bAAc2": (_dot(b, _mv(a, _mv(a, c2))), F(1, 60)),
        "bAAAc": (_dot(b, _mv(a, _mv(a, ac))), F(1, 120)),
    }
    assert len(conditions) == 17
    for name, (value, want) in conditions.items():
        assert value == want, name
    # not sixth order (no explicit 6-stage method is): the tall tree b A^4 c gives 1/640, not
    # 1/720 (the bushy tree b c^5 = 1/6 does hold: the weights are Boole's quadrature rule)
    assert _dot(b, _mv(a, _mv(a, _mv(a, ac)))) == F(1, 640)


def _stability_coefficients(a, b):
    """Coefficients of R(z) = 1 + sum_k (b^T A^(k-1) 1) z^k, exact."""
    coef, v = [F(1)], [F(1)] * len(b)
    for _ in range(len(b)):
        coef.append(_dot(b, v))
        v = _mv(a, v)
    return coef


def test_butcher_rk5_stability_polynomial():
    coef = _stability_coefficients(_mat(_A5), _B5)
    # 1 + z + z^2/2 + z^3/6 + z^4/24 + z^5/120 + z^6/640: the z^6 coefficient is
    # b6 a65 a54 a43 a32 a21 = 7/90 * 8/7 * 9/16 * 1 * 1/8 * 1/4 = 1/640 (not 1/1280)
    assert coef == [F(1), F(1), F(1, 2), F(1, 6), F(1, 24), F(1, 120), F(1, 640)]


@pytest.mark.parametrize("method", ["rk4", "rk5"])
def test_one_step_is_the_stability_polynomial(method):
    # p'' = -c p' - k p is y' = A y with A = [[0, 1], [-k, -c]]; one RK step maps y to R(hA) y.
    # Start from the unit vectors and compare the two columns with R(hA) evaluated in float.
    k, c, h = 1.0e6, 300.0, 1.1e-3  # eigenvalues of hA: -0.165 +- 1.09i, |z| = 1.1
    res = _linear(h=np.full(2, h), method=method, damping=c, k=k, x0=np.array([1.0, 0.0]),
                  v0=np.array([0.0, 1.0]), spp=1, n_transient=1, n_record=0)
    step = np.array([res.x_final, res.v_final])  # columns: images of e1 and e2
    if method == "rk4":
        coef = [1, 1, F(1, 2), F(1, 6), F(1, 24)]
    else:
        coef = _stability_coefficients(_mat(_A5), _B5)
    z = h * np.array([[0.0, 1.0], [-k, -c]])
    r, zk = np.zeros((2, 2)), np.eye(2)
    for a in coef:
        r += float(a) * zk
        zk = zk @ z
    assert_allclose(step, r, rtol=0, atol=1e-14 * np.abs(r).max())
    if method == "rk5":  # the z^6 term matters here: 1/1280 would be off by 0.6e-3 * |z^6|
        wrong = r - (F(1, 640) - F(1, 1280)) * np.linalg.matrix_power(z, 6)
        assert np.abs(step - wrong).max() > 1e-4


# ----------------------------------------------------------------------------- (f) statistics


def test_backlash_statistics_against_signal():
    rpm = _rpm(40, seed=4)
    res = _backlash(rpm, half_gap=np.linspace(0.5e-6, 6e-6, 40), stride=1)
    b = np.linspace(0.5e-6, 6e-6, 40)
    sig = res.signal
    assert sig.shape == (40, 32 * 20) and np.all(res.status == STATUS_OK)
    gap = np.abs(sig) < b[:, None]
    n = sig.shape[1]
    assert_allclose(res.stats["p_mean"], sig.mean(axis=1), rtol=1e-12)
    assert_allclose(res.stats["p_rms"], sig.std(axis=1), rtol=1e-9)  # rms ~ 1e-3 of the mean
    assert np.array_equal(res.stats["p_max"], sig.max(axis=1))
    assert np.array_equal(res.stats["p_min"], sig.min(axis=1))
    assert np.array_equal(res.stats["contact_loss_fraction"], gap.mean(axis=1))
    assert np.array_equal(res.stats["backside_contact_fraction"],
                          (sig < -b[:, None]).mean(axis=1))
    # into contact on a flank from the gap or the other flank between samples, the first from
    # the state before the window (the end of the transient: the same run without a record)
    before = _backlash(rpm, half_gap=b, n_record=0, stride=0).x_final
    p = np.concatenate([before[:, None], sig], axis=1)
    region = np.where(np.abs(p) < b[:, None], 0, np.where(p < -b[:, None], -1, 1))
    impacts = np.sum((region[:, 1:] != 0) & (region[:, 1:] != region[:, :-1]), axis=1)
    assert_allclose(res.stats["impacts_per_period"], impacts * 32 / n, rtol=1e-15)
    # the set is not trivial: some cases lose contact, some hit the back flank, some impact
    assert np.any(res.stats["contact_loss_fraction"] > 0)
    assert np.any(res.stats["backside_contact_fraction"] > 0)
    assert np.any(impacts > 0)


def test_impacts_of_a_free_oscillator_in_the_dead_zone():
    # No damping, no force, constant stiffness k/m = wn^2, start at rest at p = b + A: the motion
    # is a half oscillation on each flank (pi/wn each) joined by crossings of the gap 2b at speed
    # wn A (2b/(wn A) each): period T = 2 pi/wn + 4b/(wn A), two impacts per period, apart a
    # fraction (4b/(wn A))/T of the time, on the back flank (pi/wn)/T of it.
    wn, b, amp = 2 * np.pi * 100.0, 1e-5, 3e-5
    spp, h = 50, 2 * np.pi / wn / 400  # wn h = 0.016: RK4 keeps the energy to ~1e-13 a step
    n_record = 400 * 60
    res = simulate(h, damping=0.0, k_table=np.full((spp, 5), wn * wn), half_gap=b,
                   ste_scale=0.0, ste_table=np.zeros((spp, 5)), x0=b + amp,
                   n_transient=0, n_record=n_record, steps_per_period=spp, signal_stride=1)
    period = 2 * np.pi / wn + 4 * b / (wn * amp)
    window = n_record * h
    count = res.stats["impacts_per_period"][0] * n_record / spp
    assert count == round(count) and abs(count - 2 * window / period) <= 1.0
    crossing = 2 * b / (wn * amp)  # a partial crossing or flank visit at either end of the window
    assert_allclose(res.stats["contact_loss_fraction"][0], 2 * crossing / period,
                    atol=2 * crossing / window + 2 / n_record)
    assert_allclose(res.stats["backside_contact_fraction"][0], (np.pi / wn) / period,
                    atol=2 * (np.pi / wn) / window + 2 / n_record)
    sig = res.signal[0]
    assert_allclose(sig.max(), b + amp, rtol=1e-6)  # energy kept: same amplitude on both flanks
    assert_allclose(sig.min(), -b - amp, rtol=1e-6)




@pytest.mark.parametrize("kink_aware", [False, True])
def test_impacts_when_the_gap_is_crossed_within_one_step(kink_aware):
    # The free oscillator of the test above with a gap 2b that p crosses in 1e-7 s, a 250th of
    # a step: no recorded p lies in the gap, yet every half oscillation ends in an impact on the
    # other flank, two per period (T = 2 pi/wn + 4b/(wn A)). A jump from one flank to the other
    # between two steps is an entry into contact from the gap; counting only the steps that
    # start in the gap gave 0 impacts here (and 1 instead of 2 per mesh period for a forced
    # double-sided rattle with a backlash of 0.02 um, checked against solve_ivp with events).
    wn, b, amp = 2 * np.pi * 100.0, 1e-9, 3e-5
    spp, h = 50, 2 * np.pi / wn / 400
    n_record = 400 * 60
    res = simulate(h, damping=0.0, k_table=np.full((spp, 5), wn * wn), half_gap=b,
                   ste_scale=0.0, ste_table=np.zeros((spp, 5)), x0=b + amp,
                   n_transient=0, n_record=n_record, steps_per_period=spp, signal_stride=1,
                   kink_aware=kink_aware)
    sig = res.signal[0]
    assert not np.any(np.abs(sig) < b)  # the gap is never sampled
    assert np.any(sig < -b) and np.any(sig > b)  # both flanks are
    period = 2 * np.pi / wn + 4 * b / (wn * amp)
    count = res.stats["impacts_per_period"][0] * n_record / spp
    assert count == round(count) and abs(count - 2 * n_record * h / period) <= 1.0


@pytest.mark.parametrize("kink_aware", [False, True])
def test_impacts_of_a_periodic_motion_do_not_depend_on_where_the_window_starts(kink_aware):
    # A forced oscillator with backlash in a period-1 motion with one contact loss per mesh
    # period (m 0.1527 kg, k 1073 kN/mm, zeta 0.05, F_m 833 N, 300 N at the mesh frequency of
    # 19000 rpm x 48 teeth, backlash 2 um; an outside tester's solve_ivp with events gives one
    # entry into contact per period). Over whole periods of a periodic p the entries into
    # contact are the gap -> contact steps counted around the window (the last sample followed
    # by the first): the same whatever step the window starts at. The count used to take only
    # the steps inside the window, so the window that starts just at an entry missed it (0.8
    # instead of 1 here; 0.95 in a study of 20 recorded periods).
    from gearsweep.model import gear_scene
    scene = gear_scene(mass=0.1527, damping=1280.0, k0=1.073e9, mesh_frequency=19000 * 48 / 60,
                       force_harmonics=[(300.0, 1.0, 0.0)], force=833.0, backlash=2e-6)
    kw = scene.kernel_kwargs(16)
    spp = kw.pop("steps_per_period")
    b = kw["half_gap"]
    n_record = 5 * spp
    counts = []
    for shift in range(spp):
        res = simulate(**kw, n_transient=200 * spp + shift, n_record=n_record, steps_per_period=spp,
                       signal_stride=1, kink_aware=kink_aware)
        gap = np.abs(res.signal[0]) < b
        around = np.sum(gap & ~np.roll(gap, -1))  # gap -> contact, the last sample to the first
        counts.append(res.stats["impacts_per_period"][0] * n_record / spp)
        assert np.abs(res.signal[0, :spp] - res.signal[0, -spp:]).max() < 1e-9 * np.ptp(
            res.signal[0])  # periodic: the count around the window is the count per window
        assert counts[-1] == around, shift
    assert counts == [5.0] * spp  # one entry per period, at every start of the window


# ----------------------------------------------------------------------------- (g) errors


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        (dict(method="rk3"), "method must be one of"),
        (dict(k_table=np.ones((8, 4))), "shape"),
        (dict(k_table=np.ones(8)), "shape"),
        (dict(k_table=np.ones((8, 5)), ste_table=np.ones((16, 5))), "different cycles"),
        (dict(n_transient=-1), "non-negative"),
        (dict(steps_per_period=0), "steps_per_period"),
    ],
)
def test_argument_errors(kwargs, match):
    args = dict(h=1e-6, n_transient=10, n_record=10, steps_per_period=8)
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        simulate(**args)


def test_argument_forms_reach_one_specialisation(monkeypatch):
    """Scalars, per-case arrays, read-only views and a batch of one case all reach the drivers
    as the same Numba types (read-only arrays would each be a specialisation of their own)."""
    from gearsweep.kernels import kink, rk

    seen = []

    def fake(*args):
        seen.append(tuple(numba.typeof(a) for a in args))
        n = args[0].shape[0]
        return np.zeros((n, len(STAT_NAMES))), np.zeros(n), np.zeros(n), np.zeros(n, np.int8)

    monkeypatch.setattr(rk, "INTEGRATE", {m: fake for m in rk.INTEGRATE})
    monkeypatch.setattr(kink, "INTEGRATE", {m: fake for m in kink.INTEGRATE})
    tab = fourier_table(1.0, 1.0, 0.0, 8)
    ro_tab = tab.copy()
    ro_tab.flags.writeable = False
    ro = np.full(3, 2.0)
    ro.flags.writeable = False
    base = dict(n_transient=1, n_record=1, steps_per_period=8, signal_stride=1, half_gap=1e-6,
                k_table=tab)
    simulate(1e-6, damping=1.0, k_mean=2.0, **base)                          # scalars, 1 case
    simulate(np.full(3, 1e-6), damping=1.0, k_mean=2.0, **base)              # broadcast scalars
    simulate(np.full(3, 1e-6), damping=np.ones(3), k_mean=ro, **base)        # per-case arrays
    simulate(np.broadcast_to(1e-6, (3,)), damping=ro, k_mean=ro[:1], **base)  # read-only views
    simulate(ro, damping=ro, k_mean=ro, **{**base, "k_table": ro_tab})       # read-only table
    assert len(seen) == 5
    assert all(s == seen[0] for s in seen), "argument forms gave different kernel types"
    assert all(t.mutable for t in seen[0] if isinstance(t, numba.types.Array))


_PRECOMPILE_CHILD = """
import json, sys
import numpy as np
from gearsweep.kernels import rk
from gearsweep.kernels.batch import precompile, simulate

def main():
    call = dict(h=np.full(4, 1e-4), damping=10.0, k_mean=4e6, force=1.0, bound=1.0,
                steps_per_period=8)
    calls = [dict(call, method="rk4"), dict(call, method="rk5")]
    precompile(calls, workers=2)
    for c in calls:
        simulate(**c, n_transient=3, n_record=5)
    d = [rk.INTEGRATE[rk.METHODS[c["method"]]] for c in calls]
    print(json.dumps({"hits": [sum(x.stats.cache_hits.values()) for x in d],
                      "misses": [sum(x.stats.cache_misses.values()) for x in d]}))

if __name__ == "__main__":
    main()
"""


def test_precompile_in_other_processes_fills_the_cache(tmp_path):
    """On an empty cache, the specialisations compiled by ``precompile``'s two worker processes
    are loaded here from the disk cache, not compiled again (the batch of four cases here and
    the one-case calls of the workers must reach the same kernel types)."""
    import json
    import os
    import subprocess
    import sys

    script = tmp_path / "child.py"
    script.write_text(_PRECOMPILE_CHILD)
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    out = subprocess.run([sys.executable, str(script)], env=env, capture_output=True, text=True,
                         timeout=600, check=True).stdout
    stats = json.loads(out.strip().splitlines()[-1])
    assert stats == {"hits": [1, 1], "misses": [0, 0]}


_KINK_CHILD = """
import json
import numpy as np
from gearsweep.kernels import kink
from gearsweep.kernels.batch import simulate

simulate(np.full(4, 1e-4), damping=10.0, k_mean=4e6, force=1.0, half_gap=1e-7, kink_aware=True,
         steps_per_period=8, n_transient=3, n_record=5)
d = kink.INTEGRATE[kink.RK4]
print(json.dumps([sum(d.stats.cache_hits.values()), sum(d.stats.cache_misses.values())]))
"""


def test_kink_aware_driver_is_loaded_from_the_cache_by_the_next_process(tmp_path):
    """A kink-aware driver compiled by one process is loaded from the disk cache by the next
    (its cache key hashes the driver's closure variables: a compiled function among them pickled
    differently in every process, and every run compiled the driver again)."""
    import json
    import os
    import subprocess
    import sys

    script = tmp_path / "child.py"
    script.write_text(_KINK_CHILD)
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    runs = [json.loads(subprocess.run([sys.executable, str(script)], env=env, capture_output=True,
                                      text=True, timeout=600, check=True).stdout.splitlines()[-1])
            for _ in range(2)]
    assert runs == [[0, 1], [1, 0]]


_KINK_PAIR_CHILD = """
import json, sys
import numpy as np
from gearsweep.kernels import kink
from gearsweep.kernels.batch import simulate

out = {}
for method in sys.argv[1:]:
    r = simulate(np.linspace(2e-5, 4e-5, 9), method=method, damping=10.0, k_mean=4e8,
                 force=40.0, half_gap=1e-7, x0=1e-6, kink_aware=True, steps_per_period=16,
                 n_transient=64, n_record=64)
    out[method] = [float(v) for k in sorted(r.stats) for v in r.stats[k]] + [float(r.substeps.sum())]
hits = sum(sum(d.stats.cache_hits.values()) for d in kink.INTEGRATE.values())
print(json.dumps([out, hits]))
"""


@pytest.mark.slow  # compiles the kink-aware RK4 and RK5 drivers: about 40 s
def test_kink_aware_drivers_cached_by_two_processes_run_their_own_code(tmp_path):
    """The kink-aware RK4 and RK5 drivers compiled (and cached) by two processes, then both
    loaded by a third: each runs its own method (their blocks once shared a symbol name, and the
    RK5 driver ran the RK4 block: ``gearsweep.jit.unique_name``). The third process's RK5 results
    equal those of a process that compiled RK5 alone, bit for bit, and differ from RK4's."""
    import json
    import os
    import subprocess
    import sys

    script = tmp_path / "child.py"
    script.write_text(_KINK_PAIR_CHILD)

    def run(*methods, cache="cache"):
        env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / cache))
        return json.loads(subprocess.run([sys.executable, str(script), *methods], env=env,
                                         capture_output=True, text=True, timeout=900,
                                         check=True).stdout.splitlines()[-1])

    alone, _ = run("rk5", cache="alone")
    run("rk4")
    run("rk5")
    both, hits = run("rk4", "rk5")
    assert hits == 2  # both drivers loaded from the cache, none compiled
    assert both["rk5"] == alone["rk5"]
    assert both["rk5"] != both["rk4"] and both["rk5"][-1] > 0  # crossings were fixed up


def test_one_compiled_driver_per_combination_of_terms():
    """Each combination of terms switched off is a compiled function with its own name (and so
    its own Numba cache index): processes compiling different combinations never share one."""
    from gearsweep.kernels import rk

    base = dict(n_transient=2, n_record=2, steps_per_period=8, damping=1.0, k_mean=4.0)
    tab = fourier_table(1.0, 1.0, 0.0, 8)
    simulate(np.full(2, 1e-2), **base)
    simulate(np.full(2, 1e-2), k_table=tab, half_gap=1e-3, **base)
    names = {d.py_func.__qualname__ for d in rk.INTEGRATE[rk.RK4]._ranges._drivers.values()}
    assert {"integrate_rk4_a0k0e0f0h0s0", "integrate_rk4_a0k1e0f0h1s0"} <= names


def test_subnormals_flushed_in_the_kernel_only():
    """Critically damped free oscillators decaying through the subnormal range (x ~ (1 + t)
    e^-t, t = 648..792): no final state is subnormal (flushed to 0; subnormals cost 100x), those
    still normal are nonzero, and the caller's NumPy keeps IEEE subnormals afterwards."""
    tiny = np.finfo(float).tiny
    res = simulate(np.linspace(0.45, 0.55, 64), method="rk4", damping=2.0, k_mean=1.0, x0=1.0,
                   v0=0.0, n_transient=1440, n_record=0, steps_per_period=100)
    x = np.abs(res.x_final)
    assert np.all((x == 0.0) | (x >= tiny)), "a subnormal state left the kernel"
    assert (x >= tiny).sum() >= 10 and (x == 0.0).sum() >= 10
    assert (np.array([1e-310]) * 0.5)[0] > 0.0  # gradual underflow still on in this thread


def test_signal_sample_j_is_the_state_after_step_n_transient_plus_j_stride_plus_one():
    """The signal's times, as ``simulate``'s docstring states them: an undamped oscillator from
    p = 1 matches cos(w t) at t = (n_transient + j stride + 1) h to the method's error (4e-12),
    and is a step's phase away (2.5e-2) from t = (n_transient + j stride) h. (An outside
    reviewer assumed the latter from the old wording.)"""
    w, spp = 2 * np.pi * 1000.0, 256
    h = 1e-3 / spp
    r = simulate(h=np.array([h]), method="rk5", damping=0.0, k_mean=w * w, x0=1.0, v0=0.0,
                 n_transient=10, n_record=100, steps_per_period=spp, signal_stride=3)
    t = (10 + np.arange(r.signal.shape[1]) * 3 + 1) * h
    assert np.abs(r.signal[0] - np.cos(w * t)).max() < 1e-10
    assert np.abs(r.signal[0] - np.cos(w * (t - h))).max() > 1e-2

"""Reference solutions, kink-aware stepping, convergence orders and step advice (issue 7)."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numba
import numpy as np
import pytest

from gearsweep.analysis import precision as pr
from gearsweep.analysis.advise import advise, stability_limit, stability_polynomial
from gearsweep.analysis.reference import reference_exact, reference_ivp
from gearsweep.kernels import kink, rk
from gearsweep.kernels.batch import simulate
from gearsweep.model import Scene

ROOT = Path(__file__).resolve().parents[1]

# ----------------------------------------------------------------------------- references


@pytest.mark.parametrize("rpm", [6000.0, 9000.0])
def test_references_agree_on_rattle(rpm):
    """Two independent references: DOP853 (rtol 1e-12) restarted at every crossing event, and
    the exact piecewise closed form with crossings by root finding. They share no code but the
    scene; 1e-9 of the amplitude is the issue's bar (DOP853 at rtol 1e-12 over 20 periods with
    8-16 crossings reaches about 1e-10). Both must find the same crossings."""
    sc = pr.rattle_scene(rpm)
    t_end = 20 * sc.period
    ex = reference_exact(sc, t_end)
    iv = reference_ivp(sc, t_end)
    t = np.linspace(0.0, t_end, 3001)
    xe, ve = ex(t)
    xi, vi = iv(t)
    amp = 0.5 * (xe.max() - xe.min())
    assert len(ex.crossings) == len(iv.crossings) >= 2
    np.testing.assert_allclose(ex.crossings, iv.crossings, rtol=0, atol=1e-9 * sc.period)
    np.testing.assert_allclose(xi, xe, rtol=0, atol=1e-9 * amp)
    np.testing.assert_allclose(vi, ve, rtol=0, atol=1e-9 * amp * sc.omega_n)


def test_exact_solution_of_linear_oscillator():
    """Without backlash the exact solution must be the textbook one: steady state
    G / (K - w^2 + i c w) plus the decaying free response, checked at t = 3 periods against the
    formula written out here for an underdamped oscillator."""
    wn, zeta, w, g = 5.0, 0.1, 3.0, 2.0
    sc = Scene(omega=w, damping=2 * zeta * wn, k_mean=wn**2, g_harmonics=((g, 1.0, 0.0),))
    t = np.array([0.0, 0.7, 3 * sc.period])
    Y = g / complex(wn**2 - w**2, 2 * zeta * wn * w)
    wd = wn * math.sqrt(1 - zeta**2)
    # free response from y(0) = -Re Y, y'(0) = -Re(i w Y) so that p(0) = p'(0) = 0
    y0, v0 = -Y.real, -(1j * w * Y).real
    A, B = y0, (v0 + zeta * wn * y0) / wd
    expected = (Y * np.exp(1j * w * t)).real + np.exp(-zeta * wn * t) * (
        A * np.cos(wd * t) + B * np.sin(wd * t))
    x, _ = reference_exact(sc, t[-1])(t)
    np.testing.assert_allclose(x, expected, rtol=0, atol=1e-14)


# ----------------------------------------------------------------------------- kink-aware kernel


def _errors(scene, method, spps, kink, window):
    p_ref = pr.reference(scene, window)(pr.sample_times(scene, window))[0]
    return np.array([pr.run_fixed(scene, method, s, window, p_ref, kink_aware=kink, copies=1,
                                  repeat=1).trajectory_error for s in spps])


SPPS = (32, 64, 128, 256, 512)


@pytest.mark.slow  # compiles kink-kernel specialisations: 1-3 min on a cold cache
def test_kink_aware_rk4_restores_order_4_on_rattle():
    """Rattle scene at 9000 rpm (4 crossings per mesh period). Measured on this machine:
    plain RK4 order 1.96, kink-aware RK4 order 4.0 (trajectory error over periods 40-60). The
    plain step straddles kinks (p''' jumps) and falls to about 2; the kink-aware step keeps 4."""
    sc = pr.rattle_scene(9000.0)
    w = pr.Window()
    plain = pr.fit_order(SPPS, _errors(sc, "rk4", SPPS, False, w))
    kink = pr.fit_order(SPPS, _errors(sc, "rk4", SPPS, True, w))
    assert 1.5 <= plain <= 2.5, plain
    assert 3.5 <= kink <= 4.5, kink


def test_kink_aware_rk5_keeps_order_5_on_rattle():
    """Same scene with RK5: the kink-aware step must keep order about 5 (4.5..5.5)."""
    sc = pr.rattle_scene(9000.0)
    spps = (32, 64, 128, 256)
    order = pr.fit_order(spps, _errors(sc, "rk5", spps, True, pr.Window()))
    assert 4.5 <= order <= 5.5, order


@pytest.mark.parametrize("method", ["rk4", "rk5"])
def test_kink_equals_plain_without_backlash(method, monkeypatch):
    """No backlash: the kink-aware kernel (its path with ``half_gap=None``, the detection
    compiled out) takes exactly the plain steps (bit for bit), with no substep.

    ``simulate(..., kink_aware=True)`` sends a call without backlash to the plain kernel
    (``batch._driver_call``), so comparing it with a plain call compared the plain kernel with
    itself: the test passed with ``kink.INTEGRATE`` replaced by Nones (an outside tester). Here
    the plain drivers are replaced by the kink-aware ones (with their ``sub_blocks`` argument)
    for the second call, so it fails if the kink-aware kernel differs."""
    sc = pr.whine_scene(6000.0)
    kw = sc.kernel_kwargs(64)
    kw["h"] = np.repeat(kw["h"], 40) * np.linspace(0.9, 1.1, 40)
    args = dict(method=method, n_transient=640, n_record=640, signal_stride=8, **kw)
    assert kw.get("half_gap") is None and kw.get("k_table") is not None
    a = simulate(**args)
    used = []

    def kink_driver(m):
        def call(*xs):
            used.append(m)
            n = xs[0].shape[0]
            return kink.INTEGRATE[m](*xs, kink.sub_blocks(n, numba.get_num_threads()))
        return call

    monkeypatch.setattr(rk, "INTEGRATE", {m: kink_driver(m) for m in rk.INTEGRATE})
    b = simulate(**args, kink_aware=True)
    assert used == [rk.METHODS[method]]  # the kink-aware kernel ran
    assert b.substeps is not None and not b.substeps.any()
    np.testing.assert_array_equal(a.signal, b.signal)
    for k in a.stats:
        np.testing.assert_array_equal(a.stats[k], b.stats[k])
    np.testing.assert_array_equal(a.x_final, b.x_final)
    np.testing.assert_array_equal(a.v_final, b.v_final)
    np.testing.assert_array_equal(a.status, b.status)


@pytest.mark.slow  # compiles kink-kernel specialisations: 1-3 min on a cold cache
@pytest.mark.parametrize("method", ["rk4", "rk5"])
def test_kink_equals_plain_when_nothing_crosses(method):
    """Backlash present but the teeth stay in contact (3000 rpm, started at the static
    deflection): no step crosses, so no substep is taken and results are identical bit for
    bit."""
    sc = pr.rattle_scene(3000.0)
    kw = sc.kernel_kwargs(64)
    kw["h"] = np.repeat(kw["h"], 40)
    kw["x0"] = sc.half_gap + sc.g_mean / sc.k_mean  # the static deflection, in contact
    args = dict(method=method, n_transient=640, n_record=640, signal_stride=8, **kw)
    a = simulate(**args)
    b = simulate(**args, kink_aware=True)
    assert b.substeps.sum() == 0
    assert a.stats["contact_loss_fraction"].max() == 0.0
    np.testing.assert_array_equal(a.signal, b.signal)
    np.testing.assert_array_equal(a.x_final, b.x_final)
    np.testing.assert_array_equal(a.v_final, b.v_final)


def test_kink_aware_counts_substeps_and_changes_crossing_steps():
    """On the rattle scene (four crossings per period) the kink-aware kernel redoes exactly the
    steps whose end lies in another region than their start: a vectorised fix-up counts 0.25 step-
    equivalents for RK4 (one evaluation of the coefficients at the crossing), the scalar path
    more. The crossing steps are counted independently from the recorded p of every step. Its
    result differs from the plain one."""
    sc = pr.rattle_scene(9000.0)
    kw = sc.kernel_kwargs(64)
    args = dict(method="rk4", n_transient=0, n_record=1280, signal_stride=1, **kw)
    a = simulate(**args)
    b = simulate(**args, kink_aware=True)
    p = np.concatenate([[0.0], b.signal[0]])
    region = np.where(p > sc.half_gap, 1, np.where(p < -sc.half_gap, -1, 0))
    crossing_steps = np.count_nonzero(np.diff(region))
    assert 60 <= crossing_steps <= 100, crossing_steps  # 20 periods, about 4 per period
    assert 0.25 * crossing_steps <= b.substeps[0] <= 0.25 * crossing_steps + 3 * 4, b.substeps[0]
    assert not np.array_equal(a.signal, b.signal)


def test_kink_aware_results_independent_of_case_order():
    """A case's kink-aware result does not depend on its neighbours in the batch. A fine sweep
    of step sizes in order crosses in the same steps in neighbouring lanes (fixed up in place,
    ``kink.DENSE``); the same cases in random order have sparse crossing lanes, which are
    gathered first. Both give the same results bit for bit."""
    sc = pr.rattle_scene(9000.0)
    kw = sc.kernel_kwargs(64)
    n = 160
    kw["h"] = kw["h"][0] * np.linspace(0.8, 1.25, n)
    perm = np.random.default_rng(3).permutation(n)
    args = dict(method="rk4", n_transient=0, n_record=1280, signal_stride=1, kink_aware=True)
    a = simulate(**args, **kw)
    b = simulate(**args, **{**kw, "h": kw["h"][perm]})
    assert a.substeps.min() > 0  # every case crosses
    for name in a.stats:
        np.testing.assert_array_equal(b.stats[name], a.stats[name][perm])
    for x, y in [(a.x_final, b.x_final), (a.v_final, b.v_final), (a.substeps, b.substeps),
                 (a.signal, b.signal)]:
        np.testing.assert_array_equal(y, x[perm])


@pytest.mark.parametrize("kink_aware", [False, True])
def test_threads_step_every_block_once_and_agree_bit_for_bit(monkeypatch, kink_aware):
    """The drivers (``rk.Threaded``) hand ranges of blocks to their threads: with two Numba
    threads the ranges tile the batch's blocks (kink blocks of ``sub`` plain blocks for the
    kink-aware driver) exactly once, at least two threads step them, and the results equal one
    thread's bit for bit."""
    import threading
    import time

    import numba

    from gearsweep.kernels import kink, rk

    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("Numba has one thread here")
    sc = pr.rattle_scene(9000.0)
    kw = sc.kernel_kwargs(64)
    n = 600
    kw["h"] = kw["h"][0] * np.linspace(0.8, 1.25, n)
    args = dict(method="rk4", n_transient=0, n_record=640, kink_aware=kink_aware, **kw)
    threads = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        one = simulate(**args)
    finally:
        numba.set_num_threads(threads)
    calls = []
    real = rk.Threaded.driver
    n_out = 5 if kink_aware else 4  # the outputs after (lo, hi)

    def recording(self, a):
        f = real(self, a)

        def call(*full):
            calls.append((threading.get_ident(), int(full[-n_out - 2]), int(full[-n_out - 1])))
            time.sleep(0.02)  # each range takes long enough for the other thread to take one
            return f(*full)
        return call

    monkeypatch.setattr(rk.Threaded, "driver", recording)
    numba.set_num_threads(2)
    try:
        two = simulate(**args)
    finally:
        numba.set_num_threads(threads)
    blocks = -(-n // rk.LANES)
    if kink_aware:
        sub = kink.sub_blocks(n, 2)
        blocks = -(-blocks // sub)
    ranges = sorted((lo, hi) for _, lo, hi in calls)
    assert ranges[0][0] == 0 and ranges[-1][1] == blocks and len(ranges) > 2
    assert all(a[1] == b[0] and a[0] < a[1] for a, b in zip(ranges[:-1], ranges[1:], strict=True))
    assert len({t for t, *_ in calls}) == 2
    if kink_aware:
        assert one.substeps.min() > 0  # every case crosses
        np.testing.assert_array_equal(two.substeps, one.substeps)
    for name in one.stats:
        np.testing.assert_array_equal(two.stats[name], one.stats[name])
    for x, y in [(one.x_final, two.x_final), (one.v_final, two.v_final),
                 (one.status, two.status)]:
        np.testing.assert_array_equal(y, x)


# ----------------------------------------------------------------------------- stability, advice


def test_stability_limits_known_values():
    """RK4 on the imaginary axis: |R(iy)| = 1 at y = 2 sqrt(2) (classical result). The RK5
    polynomial is the kernel's tableau: z^6 coefficient b^T A^5 1 = 1/640 for Butcher's method."""
    assert stability_limit("rk4", 0.0) == pytest.approx(2 * math.sqrt(2), rel=1e-9)
    assert stability_polynomial("rk5")[6] == pytest.approx(1 / 640, rel=1e-12)
    np.testing.assert_allclose(stability_polynomial("rk5")[:6],
                               [1 / math.factorial(k) for k in range(6)], rtol=1e-12)


def test_advice_warns_beyond_stability_limit():
    """A step count with h omega_n above the RK4 limit at the lowest speed gets a warning."""
    wn = math.sqrt(1.073e9 / 0.1527)
    rpm = 3000.0
    spp = int(2 * math.pi * wn / (2 * math.pi * 48 * rpm / 60) / 3.2)  # h omega_n ~ 3.2
    adv = advise(mass=0.1527, k0=1.073e9, damping=5500.0, speed_rpm=[rpm, 9000.0], teeth=48,
                 method="rk4", steps_per_period=spp)
    assert any("stability limit" in w for w in adv.warnings)
    assert adv.steps_per_period > spp
    assert "WARNING" in adv.report()


HELD_OUT = [
    # scene, speed [rpm], damping [N s/m], k0 [N/m], method, kink-aware, target
    ("whine", 5250.0, pr.DAMPING, pr.K0, "rk4", False, 1e-6),
    ("whine", 7750.0, pr.DAMPING, pr.K0, "rk5", False, 1e-6),
    ("whine", 5250.0, pr.DAMPING, pr.K0, "rk4", False, 1e-4),
    ("whine", 5000.0, 3000.0, 0.8e9, "rk4", False, 1e-6),
    ("whine", 8000.0, 3000.0, 0.8e9, "rk5", False, 1e-6),
    ("rattle", 7500.0, pr.DAMPING, pr.K0, "rk4", True, 1e-6),
    ("rattle", 11500.0, pr.DAMPING, pr.K0, "rk5", True, 1e-6),
    ("rattle", 11500.0, pr.DAMPING, pr.K0, "rk4", False, 1e-4),
    ("rattle", 9500.0, 4000.0, 1.2e9, "rk4", True, 1e-6),
    ("rattle", 12000.0, 4000.0, 1.2e9, "rk5", True, 1e-6),
]


@pytest.mark.parametrize(("kind", "rpm", "damping", "k0", "method", "kink", "target"), HELD_OUT)
def test_advised_step_meets_target_on_held_out_cases(kind, rpm, damping, k0, method, kink, target):
    """Speeds, dampings and stiffnesses not used in the calibration
    (``scripts/calibrate_advisor.py``: 1000-30,000 rpm, both scenes at c = 5500 N s/m,
    k0 = 1.073e9 N/m; 5000 and 8000 rpm whine lie on its 500 rpm grid, but at another damping
    and stiffness): the advised step count must reach the target
    trajectory error against the reference, and not by far (the advisor aims at target / 2).
    Measured (constants of 27 Nov 2026, fitted from 1000 to 30,000 rpm): 0.128-0.604 of the
    target where the error model is the method's order (smooth, or kink-aware; 0.604: whine at
    5000 rpm with c = 3000 N s/m and k0 = 0.8e9 N/m, zeta = 0.12, near the third harmonic's
    resonance r = 1/3, where the error grows as the damping falls: 1.2 times the model's
    expected error there, within the safety factor 2), so the floor target / 10 fails advice
    about twice the steps needed (order 4; 8x the steps: 4096 times less error); the plain step
    through the backlash kinks (order 2) 0.291 at 11,500 rpm, 0.093 at 11,000 (a calibration
    speed now): its error depends on where the crossings fall within the step, and the
    constant is the envelope over the calibration speeds, hence its floor target / 30 (8x the
    steps: 64 times less error, still caught)."""
    make = pr.whine_scene if kind == "whine" else pr.rattle_scene
    scene = make(rpm, damping=damping, k0=k0)
    adv = advise(mass=pr.MASS, k0=k0, damping=damping, speed_rpm=[rpm], teeth=pr.TEETH,
                 k_harmonics=pr.K_HARMONICS if kind == "whine" else (),
                 backlash=4e-6 if kind == "rattle" else None, method=method, kink_aware=kink,
                 target=target)
    err = _trajectory_error(scene, method, adv.steps_per_period, kink)
    floor = target / (30 if kind == "rattle" and not kink else 10)
    assert floor <= err <= target, (adv.steps_per_period, err)


ACROSS_RESONANCE = [
    # scene, speed [rpm]: r = Omega / omega_n (resonance at 18,370 rpm whine, 16,680 rattle)
    ("whine", 1250.0),   # r = 0.068, far below
    ("whine", 4250.0),   # r = 0.23, among the resonances of the harmonics (r = 1/n)
    ("whine", 16000.0),  # r = 0.87, near
    ("whine", 20000.0),  # r = 1.09, near
    ("whine", 40000.0),  # r = 2.18, above (beyond the calibration's 1.63)
    ("rattle", 2000.0),  # r = 0.12, far below (no contact loss there: linear)
    ("rattle", 17000.0),  # r = 1.02, near
    ("rattle", 36000.0),  # r = 2.16, above
]
ACROSS_FACTOR = 30.0
"""The most the error model may overestimate a held-out case by. Measured (27 Nov 2026): 1.2-4.1
for the whine scene from r = 0.12 up, 1.3-1.8 for the rattle scene near the resonance, 7.1 (RK4)
and 18 (RK5) for it far below, 12-21 far above; whine RK4 16 at 1250 rpm. The old model
C (h omega_n)^p overestimated the whine scene by about 10,000 at 1250 rpm and underestimated it
near and above resonance (C_eff 0.032-0.077 against C = 0.024 from 16,000 to 30,000 rpm). Whine
RK5 far below (r < 0.1) gets twice this factor: measured 40 at 1250 rpm, where its error over
(h omega_n)^5 (3 r)^2 is 1/25 of its peak among the harmonics' resonances, which C / knee^2 must
cover (docs/precision.md)."""


@pytest.mark.parametrize("method", ["rk4", "rk5"])
@pytest.mark.parametrize(("kind", "rpm"), ACROSS_RESONANCE)
def test_error_model_bounds_held_out_speeds_from_far_below_to_above_resonance(kind, rpm, method):
    """At speeds not in the calibration, far below, near and above the resonance, at the
    calibration's damping: the advised step's expected error (the model's, at that step) is an
    upper bound of the measured trajectory error against the reference, and not a loose one
    (within ``ACROSS_FACTOR``). Backlash scenes with the kink-aware step (order 4 / 5)."""
    rattle = kind == "rattle"
    scene = (pr.rattle_scene if rattle else pr.whine_scene)(rpm)
    adv = advise(mass=pr.MASS, k0=pr.K0, damping=pr.DAMPING, speed_rpm=[rpm], teeth=pr.TEETH,
                 k_harmonics=() if rattle else pr.K_HARMONICS, backlash=4e-6 if rattle else None,
                 method=method, kink_aware=rattle, target=1e-6 if method == "rk4" else 1e-7)
    err = _trajectory_error(scene, method, adv.steps_per_period, rattle)
    factor = ACROSS_FACTOR * (2 if (method, kind) == ("rk5", "whine") and adv.ratio < 0.1 else 1)
    assert err <= adv.expected_error <= factor * err, (
        adv.steps_per_period, err, adv.expected_error)


@pytest.mark.parametrize("key", ["whine/rk4", "whine/rk5", "rattle/rk4", "rattle/rk5",
                                 "rattle/rk4-kink", "rattle/rk5-kink"])
def test_error_model_does_not_grow_with_speed_at_a_fixed_step_count(key):
    """``advise`` sizes the step at the lowest speed; that is right only if, at a fixed number
    of steps per mesh period N (h omega_n = 2 pi / (N r)), the model's error does not grow with
    r = Omega / omega_n: below the knee it goes as r^(2 - p), then r^-p, above 1 constant (a
    knee above the scene's highest order n made it grow from r = 1 to knee / n: whine RK4's
    knee 1.24 on a one-harmonic scene)."""
    from gearsweep.analysis import advise as adv_mod

    table = adv_mod.load_constants()["constants"][key]
    r = np.geomspace(0.01, 10.0, 2001)
    for n in (1.0, 3.0, 56.0):  # one harmonic (rattle scene), three (whine), the rig's 56
        err = [adv_mod.model_error(table["C"], table["order"], table.get("knee"),
                                   2 * math.pi / (64 * x), x, n) for x in r]
        assert np.all(np.diff(err) <= 1e-12 * np.max(err)), n
        assert err[-1] == pytest.approx(table["C"] * (2 * math.pi / 64) ** table["order"],
                                        rel=1e-12)


def _discrete_forced_error(method, h_omega_n, r, zeta):
    """Closed form: relative error of the periodic solution that the Runge-Kutta step (tableau
    of ``gearsweep.kernels.tableaux``) gives for p'' + 2 zeta p' + p = e^(i r t) (omega_n = 1),
    against the exact steady response. The stage equations with y_n = Y e^(i r t_n) are linear
    in Y and the stage values; solved as one complex system."""
    from gearsweep.kernels import tableaux

    tab = tableaux.get(method)
    s, h = tab.stages, h_omega_n
    a = np.zeros((s, s))
    for i, row in enumerate(tab.rows):
        a[i, :len(row)] = [float(x) for x in row]
    b = np.array([float(x) for x in tab.b])
    m = np.array([[0.0, 1.0], [-1.0, -2.0 * zeta]], dtype=complex)
    g = np.array([0.0, 1.0], dtype=complex)
    n = 2 + 2 * s
    lhs, rhs = np.zeros((n, n), complex), np.zeros(n, complex)
    lhs[:2, :2] = (np.exp(1j * r * h) - 1.0) * np.eye(2)  # Y (e^{irh} - 1) = h sum b_i K_i
    for i in range(s):
        k = slice(2 + 2 * i, 4 + 2 * i)
        lhs[:2, k] -= h * b[i] * np.eye(2)
        lhs[k, k] += np.eye(2)  # K_i = M (Y + h sum a_ij K_j) + g e^{i r c_i h}
        lhs[k, :2] -= m
        for j in range(s):
            lhs[k, 2 + 2 * j:4 + 2 * j] -= h * a[i, j] * m
        rhs[k] = g * np.exp(1j * r * a[i].sum() * h)
    y = np.linalg.solve(lhs, rhs)[0]
    exact = np.linalg.solve(1j * r * np.eye(2) - m, g)[0]
    return abs(y - exact) / abs(exact)


@pytest.mark.parametrize(("method", "rpm", "steps"), [("rk4", 1000.0, 128), ("rk4", 2000.0, 256),
                                                       ("rk5", 1000.0, 128), ("rk5", 2000.0, 256)])
def test_far_below_resonance_the_error_is_the_closed_forms_r_squared_law(method, rpm, steps):
    """The rattle scene far below resonance never loses contact: a linear oscillator forced at
    the mesh frequency (plus a constant, which the step reproduces exactly). The kernel's
    trajectory error there equals the closed form of the step's periodic solution (measured:
    within 0.1 % for RK4, 6 % for RK5), and that closed form goes as (h omega_n)^p r^2 (at a
    fixed h omega_n = 0.1, 4.00-4.19 times per doubling of r up to 0.08; RK5 departs from it
    at larger r or h omega_n, where a second error term of opposite sign appears), far below
    the (h omega_n)^p the old advice assumed. The advisor's bound covers it, within the
    held-out factor."""
    scene = pr.rattle_scene(rpm)
    r, hw = scene.omega / scene.omega_n, scene.period / steps * scene.omega_n
    zeta = scene.damping / (2 * scene.omega_n)
    closed = _discrete_forced_error(method, hw, r, zeta)
    err = _trajectory_error(scene, method, steps, False)
    assert err == pytest.approx(closed, rel=0.1)
    ratios = [_discrete_forced_error(method, 0.1, x, zeta) / _discrete_forced_error(
        method, 0.1, x / 2, zeta) for x in (0.02, 0.04, 0.08)]
    assert all(3.9 < q < 4.3 for q in ratios), ratios  # 4.00-4.19 (RK5's second term grows)
    adv = advise(mass=pr.MASS, k0=pr.K0, damping=pr.DAMPING, speed_rpm=[rpm], teeth=pr.TEETH,
                 backlash=4e-6, method=method, kink_aware=True, steps_per_period=steps)
    assert err <= adv.chosen_error <= ACROSS_FACTOR * err, (err, adv.chosen_error)


def _trajectory_error(scene, method, steps_per_period, kink_aware):
    """Trajectory error of one fixed-step run of ``scene`` against the reference, relative to
    the amplitude."""
    w = pr.Window()
    p_ref = pr.reference(scene, w)(pr.sample_times(scene, w))[0]
    return pr.run_fixed(scene, method, steps_per_period, w, p_ref, kink_aware=kink_aware,
                        copies=1, repeat=1).trajectory_error


@pytest.mark.parametrize(("rpm", "method", "target"), [(11000.0, "rk4", 1e-4), (9500.0, "rk5", 1e-5)])
def test_plain_rattle_advice_names_a_kink_aware_step_that_meets_the_target(rpm, method, target):
    """Advice for the plain step on a backlash scene also gives the kink-aware step count for
    the same target; that count is smaller and, run with the kink-aware step, meets the target
    against the reference."""
    adv = advise(mass=pr.MASS, k0=pr.K0, damping=pr.DAMPING, speed_rpm=[rpm], teeth=pr.TEETH,
                 backlash=4e-6, method=method, target=target)
    assert adv.kink_steps_per_period is not None
    assert adv.kink_steps_per_period < adv.steps_per_period
    assert f"needs {adv.kink_steps_per_period} steps per period" in " ".join(adv.report().split())
    err = _trajectory_error(pr.rattle_scene(rpm), method, adv.kink_steps_per_period, True)
    assert err <= target, (adv.kink_steps_per_period, err)


# ----------------------------------------------------------------------------- study wiring

RATTLE_STUDY = """
title: kink-aware rattle
scene:
  kind: rattle
  mass: 0.1527 kg
  teeth: 48
  stiffness: 1073 kN/mm
  damping: 5.5 N*s/mm
  backlash: 4 um
  mean_force: 833 N
  ste: [{amplitude: 5 um}]
sweep:
  speed: [8000 rpm, 9000 rpm, 11000 rpm]
solver: {method: rk4, steps_per_period: 32, kink_aware: KINK, transient_periods: 40,
         record_periods: 20}
"""


@pytest.mark.slow  # compiles kink-kernel specialisations: 1-3 min on a cold cache
def test_study_solver_kink_aware_reaches_the_kernel():
    """``solver.kink_aware`` in a study selects the kink-aware kernel: its statistics equal a
    direct kink-aware ``simulate`` of the same scene (1e-9 relative: the study builds its tables
    its own way) and differ from the plain step's (by about 1e-3 at 32 steps per period)."""
    import textwrap

    from gearsweep.api import run_study
    from gearsweep.study.schema import parse_study

    ds = {k: run_study(parse_study(textwrap.dedent(RATTLE_STUDY.replace("KINK", k)), "s.yaml"), "")
          for k in ("true", "false")}
    assert ds["true"].attrs["kink_aware"] == 1
    for i, rpm in enumerate((8000.0, 9000.0, 11000.0)):
        sc = pr.rattle_scene(rpm)
        r = simulate(method="rk4", n_transient=40 * 32, n_record=20 * 32, kink_aware=True,
                     **sc.kernel_kwargs(32))
        for name in ("p_max", "p_min"):
            assert ds["true"][name].attrs["units"] == "um"  # the kernel's stats are in m
            got = float(ds["true"][name].isel(speed=i))
            plain = float(ds["false"][name].isel(speed=i))
            assert got == pytest.approx(r.stats[name][0] * 1e6, rel=1e-9)
            assert abs(plain - got) > 1e-6 * abs(got)


@pytest.mark.parametrize("method", ["rk4", "rk5"])
def test_stability_limit_agrees_with_the_stability_module(method):
    """``advise.stability_limit`` (float polynomial, scan + brentq) and
    ``analysis.stability.step_limit_hw`` (exact rational coefficients, polynomial roots on the
    ray), written independently, agree to 1e-9 over the damping range."""
    from gearsweep.analysis.stability import step_limit_hw

    for zeta in (0.0, 0.02, 0.1, 0.215, 0.5, 0.9):
        assert stability_limit(method, zeta) == pytest.approx(float(step_limit_hw(method, zeta)),
                                                              rel=1e-9)


# Butcher's six-stage fifth-order method and the classic RK4, written out here from the
# literature (Butcher, Numerical Methods for ODEs, 2016, Sec. 236; Kutta 1901), not read from
# gearsweep.kernels.tableaux: one explicit step of y' = lambda y multiplies y by R(h lambda).
_TABLEAUX = {
    "rk5": ([[], [1 / 4], [1 / 8, 1 / 8], [0, -1 / 2, 1], [3 / 16, 0, 0, 9 / 16],
             [-3 / 7, 2 / 7, 12 / 7, -12 / 7, 8 / 7]],
            [7 / 90, 0, 32 / 90, 12 / 90, 32 / 90, 7 / 90]),
    "rk4": ([[], [1 / 2], [0, 1 / 2], [0, 0, 1]], [1 / 6, 1 / 3, 1 / 3, 1 / 6]),
}


def _step_factor(method: str, z: complex) -> complex:
    """R(z): one step of the explicit tableau on y' = lambda y from y = 1, z = h lambda."""
    A, b = _TABLEAUX[method]
    k = []
    for row in A:
        k.append(z * (1 + sum(a * kj for a, kj in zip(row, k, strict=False))))
    return 1 + sum(bi * ki for bi, ki in zip(b, k, strict=True))


def _first_unstable(method: str, pole: complex) -> float:
    """The smallest h |pole| at which |R(h pole)| = 1 is crossed upwards (a scan of 0.001, then
    brentq), the pole of unit modulus."""
    from scipy.optimize import brentq

    def f(x):
        return abs(_step_factor(method, x * pole)) - 1.0

    xs = np.arange(0.01, 6.0, 1e-3)
    i = next(i for i, x in enumerate(xs) if f(x) > 0)
    return brentq(f, xs[i - 1], xs[i], xtol=1e-14)


def _oscillator_limit(method: str, zeta: float) -> float:
    """Largest stable h omega_n of p'' + 2 zeta omega_n p' + omega_n^2 p = 0 from its poles
    omega_n (-zeta +- sqrt(zeta^2 - 1)): under-damped on the unit circle's ray, over-damped the
    faster real pole, omega_n (zeta + sqrt(zeta^2 - 1)), binds."""
    if zeta < 1:
        return _first_unstable(method, complex(-zeta, math.sqrt(1 - zeta * zeta)))
    return _first_unstable(method, -1.0) / (zeta + math.sqrt(zeta * zeta - 1))


# An outside tester's whine scene at zeta = 1.56 (RK5): advise said "stable for h omega_n <
# 3.388" (the under-damped ray at zeta 0.999) and advised 16 steps per period, h omega_n = 2.18,
# where the fast real pole limits it to 1.226; the run at 16 steps diverged at 3000 rpm.
_OVERDAMPED = """\
title: tester overdamped constant stiffness
scene:
  kind: whine
  mass: 0.1527 kg
  teeth: 48
  stiffness: 1073 kN/mm
  ste:
    - {amplitude: 5 um}
  damping: 40 N*s/mm
  mean_force: 833 N
sweep:
  speed: [3000 rpm, 6000 rpm, 12000 rpm]
solver:
  method: rk5
  steps_per_period: 64
  transient_periods: 200
  record_periods: 50
outputs: [stats]
"""
# The same tester: RK4 at 12 steps over damping 2560 and 12800 N s/m (zeta 0.1 and 0.5) at
# 3000 rpm, h omega_n = 2.91: the limit is 2.95 at zeta 0.1 and 2.62 at 0.5; advise took it at
# the smallest damping and said nothing, the run gave status [0 1].
_DAMPING_SWEEP = """\
title: damping sweep
scene:
  kind: whine
  mass: 0.1527 kg
  teeth: 48
  stiffness: 1073 kN/mm
  ste:
    - {amplitude: 5 um}
  mean_force: 833 N
sweep:
  speed: [3000 rpm]
  damping: [2560 N*s/m, 12800 N*s/m]
solver:
  method: rk4
  steps_per_period: 12
  transient_periods: 200
  record_periods: 20
outputs: [stats]
"""

# The same tester's varying scene (k1 = 500 of k0 = 1073 kN/mm, zeta 1.29 at k0 + k1), RK5 at 6
# steps per period: near 11000 rpm the fixed-step map misses a parametric resonance of k(t),
# which raises the steps advised for 0.3 (``study.advice.resonance_advice``).
_VARYING_OVERDAMPED = _OVERDAMPED.replace(
    "  ste:\n", "  stiffness_harmonics:\n    - {amplitude: 500 kN/mm}\n  ste:\n").replace(
    "speed: [3000 rpm, 6000 rpm, 12000 rpm]",
    "speed: [11000 rpm, 11150 rpm, 16000 rpm, 17200 rpm, 18000 rpm, 25000 rpm]").replace(
    "steps_per_period: 64", "steps_per_period: 6").replace(
    "transient_periods: 200", "transient_periods: 3000")


def test_rk5_real_axis_interval_from_the_tableau():
    """The independent truth below: Butcher's RK5 is stable on the negative real axis up to
    h |lambda| = 3.386 (docs/stability.md's table), RK4 up to 2.785; RK4 undamped 2 sqrt 2."""
    assert _first_unstable("rk5", -1.0) == pytest.approx(3.3865, abs=1e-4)
    assert _first_unstable("rk4", -1.0) == pytest.approx(2.7853, abs=1e-4)
    assert _oscillator_limit("rk4", 0.0) == pytest.approx(2 * math.sqrt(2), rel=1e-9)


@pytest.mark.parametrize("method", ["rk4", "rk5"])
@pytest.mark.parametrize("zeta", [0.1, 0.5, 0.999, 1.0, 1.29, 1.562, 3.0])
def test_stability_limit_is_the_oscillators_at_any_damping(method, zeta):
    """``advise.stability_limit`` against the poles' limit from the tableau written out here;
    above zeta = 1 the faster real pole binds (it raised, and advise took zeta 0.999 instead)."""
    assert stability_limit(method, zeta) == pytest.approx(_oscillator_limit(method, zeta),
                                                          rel=1e-6)


def test_advise_takes_the_fast_real_pole_above_critical_damping():
    """zeta = 1.56 (the tester's scene): the limit advise states and keeps its step under is
    3.386 / (zeta + sqrt(zeta^2 - 1)) = 1.226, not the under-damped ray's 3.388; a written
    step beyond it is warned about."""
    m, k, c = 0.1527, 1.073e9, 40e3
    zeta = c / (2 * math.sqrt(k * m))
    want = _oscillator_limit("rk5", zeta)
    assert want == pytest.approx(1.2257, abs=1e-4)
    adv = advise(mass=m, k0=k, damping=c, speed_rpm=[3000.0, 6000.0, 12000.0], teeth=48,
                 method="rk5", target=0.3, steps_per_period=16)
    assert adv.stability_limit == pytest.approx(want, rel=1e-6)
    assert adv.h_omega_n < want
    assert any("beyond the rk5 stability limit 1.226" in w for w in adv.warnings)


def test_cli_advises_a_step_that_runs_above_critical_damping(tmp_path, capsys):
    """`gearsweep advise` on the tester's zeta = 1.56 scene states the fast real pole's limit,
    and its advised step runs with status 0 at every speed (16 steps diverged at 3000 rpm);
    the study at 16 steps is told it is beyond the limit."""
    from gearsweep.api import run
    from gearsweep.cli import main

    path = tmp_path / "c.yaml"
    path.write_text(_OVERDAMPED, encoding="utf-8")
    assert main(["advise", str(path), "--target", "0.3"]) == 0
    flat = " ".join(capsys.readouterr().out.split())
    said = float(re.search(r"stable for h omega_n < (\d+\.\d+)", flat)[1])
    zeta = 40e3 / (2 * math.sqrt(1.073e9 * 0.1527))
    assert said == pytest.approx(_oscillator_limit("rk5", zeta), abs=1.5e-3)
    spp = int(re.search(r"For a target of [\d.e+-]+: (\d+) steps per mesh period", flat)[1])
    ds = run(_OVERDAMPED.replace("steps_per_period: 64", f"steps_per_period: {spp}"))
    np.testing.assert_array_equal(ds.status.values.ravel(), 0)
    path.write_text(_OVERDAMPED.replace("steps_per_period: 64", "steps_per_period: 16"),
                    encoding="utf-8")
    assert main(["advise", str(path), "--target", "0.3"]) == 0
    flat = " ".join(capsys.readouterr().out.split())
    assert re.search(r"WARNING: 16 steps per period give h omega_n = 2.18\d at 3000 rpm, beyond"
                     r" the rk5 stability limit 1.226", flat), flat


@pytest.mark.parametrize("fraction", [0.999, 1.001])
def test_validate_and_advise_agree_on_a_step_next_to_the_limit(tmp_path, capsys, fraction):
    """A written step within 0.2 % of the stability limit (the limit from the tableau written out
    here): the step guard took its limit 0.2 % tighter than advise, so validate warned of a step
    at 0.999 of the limit that advise passed. Both now apply one rule
    (``stability.frozen_step_ok``): neither warns at 0.999, both at 1.001."""
    from gearsweep.cli import main

    m, k, c = 0.1527, 1.073e9, 40e3
    limit = _oscillator_limit("rk5", c / (2 * math.sqrt(k * m)))
    rpm = 60 * math.sqrt(k / m) / (48 * 16 * fraction * limit)  # h omega_n = fraction x limit
    path = tmp_path / "band.yaml"
    path.write_text(_OVERDAMPED.replace("[3000 rpm, 6000 rpm, 12000 rpm]", f"[{rpm:.9f} rpm]")
                    .replace("steps_per_period: 64", "steps_per_period: 16"), encoding="utf-8")
    assert main(["validate", str(path)]) == 0
    guard = "beyond the stability limit" in capsys.readouterr().err
    assert main(["advise", str(path), "--target", "0.3"]) == 0
    flat = " ".join(capsys.readouterr().out.split())
    said = re.search(r"WARNING: 16 steps per period give h omega_n = ([\d.]+)", flat)
    assert guard == (fraction > 1) and (said is not None) == (fraction > 1), (guard, flat)
    if said:
        assert float(said[1]) == pytest.approx(fraction * limit, abs=1e-3)


def test_cli_advise_takes_the_limit_at_every_swept_damping(tmp_path, capsys):
    """The limit is not monotonic in zeta (RK4: 2.95 at 0.1, 2.62 at 0.5): advise checks the
    step at every swept damping, as the step guard and validate do, and states the worst."""
    from gearsweep.api import run
    from gearsweep.cli import main

    path = tmp_path / "d.yaml"
    path.write_text(_DAMPING_SWEEP, encoding="utf-8")
    assert main(["advise", str(path), "--target", "0.3"]) == 0
    flat = " ".join(capsys.readouterr().out.split())
    want = _oscillator_limit("rk4", 12800 / (2 * math.sqrt(1.073e9 * 0.1527)))
    assert want == pytest.approx(2.6225, abs=1e-3)
    said = float(re.search(r"stable for h omega_n < (\d+\.\d+)", flat)[1])
    assert said == pytest.approx(want, abs=1.5e-3)
    assert re.search(r"WARNING: 12 steps per period give h omega_n = 2.91\d at 3000 rpm, beyond"
                     r" the rk4 stability limit 2.62\d", flat), flat
    spp = int(re.search(r"For a target of [\d.e+-]+: (\d+) steps per mesh period", flat)[1])
    ds = run(_DAMPING_SWEEP.replace("steps_per_period: 12", f"steps_per_period: {spp}"))
    np.testing.assert_array_equal(ds.status.values.ravel(), 0)


@pytest.mark.slow  # compiles kink-kernel specialisations: 1-3 min on a cold cache
@pytest.mark.parametrize(("method", "lo", "hi"), [("rk4", 3.5, 4.5), ("rk5", 4.5, 5.5)])
def test_kink_aware_order_with_time_varying_stiffness_and_all_tables(method, lo, hi):
    """Every term on: stiffness table with per-case scale, STE table, torque-fluctuation table and
    backlash (9000 rpm, 4 crossings per period), against DOP853 with crossing events. The fix-up
    evaluates K, G and their time derivatives from the quartics through the table nodes; the
    kink-aware step must keep its order (measured 4.14 and 5.14; plain steps: 2.3)."""
    from gearsweep.kernels.tables import fourier_table
    from gearsweep.model import gear_scene

    sc = gear_scene(mass=pr.MASS, damping=pr.DAMPING, k0=pr.K0, mesh_frequency=48 * 9000 / 60,
                    k_harmonics=pr.K_HARMONICS, ste_harmonics=pr.STE_HARMONICS, force=pr.FORCE,
                    backlash=4e-6)
    w = pr.Window(20, 10)
    p_ref = pr.reference(sc, w)(pr.sample_times(sc, w))[0]
    spps = (32, 64, 128, 256)
    err = []
    for spp in spps:
        kw = sc.kernel_kwargs(spp)
        # first forcing harmonic through the fluctuation table, the others through the STE table
        a, r, ph = zip(*sc.g_harmonics, strict=True)
        kw["fluct_table"], kw["fluct_scale"] = fourier_table(a[:1], r[:1], ph[:1], spp), 1.0
        kw["ste_table"], kw["ste_scale"] = fourier_table(a[1:], r[1:], ph[1:], spp), 1.0
        kw["k_scale"] = np.ones(1)  # K = k_mean + k_scale * k_table: the per-case scale path
        stride = spp // pr.SAMPLES_PER_PERIOD
        res = simulate(method=method, n_transient=w.transient_periods * spp + stride - 1,
                       n_record=w.record_periods * spp - stride + 1, signal_stride=stride,
                       kink_aware=True, **kw)
        err.append(pr.errors(res.signal[0], p_ref)[0])
    order = pr.fit_order(spps, err)
    assert lo <= order <= hi, (order, err)


@pytest.mark.parametrize(("method", "target"), [("rk4", 1e-4), ("rk5", 1e-6)])
def test_light_damping_is_warned_about_and_its_error_stays_within_the_warning(method, target):
    """At the whine scene's resonance (mesh frequency = omega_n, 18,370 rpm) with zeta = 0.01,
    a twentieth of the calibration's: the advised step's error is 4.6x (RK4, over the target)
    and 1.9x (RK5, within it by the safety factor) the expected error (measured with the
    constants fitted from 1000 to 30,000 rpm; 7.3x and 4.1x with the earlier constants, whose
    C was 0.62 and 0.46 of the present ones), which the constants, fitted at zeta = 0.2, cannot
    know; advise says so, and the error stays within the factor it names (zeta_cal / zeta =
    19.5). At the calibration's damping no such warning."""
    from gearsweep.analysis import advise as adv_mod

    k_max = pr.K0 + sum(abs(a) for a, _, _ in pr.K_HARMONICS)
    wn = math.sqrt(k_max / pr.MASS)
    rpm = wn * 60 / (2 * math.pi * pr.TEETH)
    common = dict(mass=pr.MASS, k0=pr.K0, speed_rpm=[rpm], teeth=pr.TEETH,
                  k_harmonics=pr.K_HARMONICS, method=method, target=target)
    assert not [w for w in advise(damping=pr.DAMPING, **common).warnings if "damping" in w]
    c = 0.01 * 2 * pr.MASS * wn
    adv = advise(damping=c, **common)
    (warning,) = [w for w in adv.warnings if "damping ratio" in w]
    zeta_cal = adv_mod.load_constants()["calibration_damping_ratio"]["whine"]
    assert f"up to about {zeta_cal / 0.01:.0f} times" in warning
    err = _trajectory_error(pr.whine_scene(rpm, damping=c), method, adv.steps_per_period, False)
    assert adv.expected_error < err <= adv.expected_error * zeta_cal / 0.01, (
        err, adv.expected_error)
    assert (err > target) == (method == "rk4")  # RK4 misses the target; RK5 keeps within it


@pytest.mark.parametrize(("steps", "noted"), [(16, True), (64, False)])
def test_validate_notes_a_step_the_advisor_expects_to_miss_by_percents(steps, noted, tmp_path,
                                                                       capsys):
    """RK4 at few steps per period was 20-40 % off with nothing said by `validate` or `run`
    (an outside tester): `validate` now notes an expected error (the advisor's bound, the one
    `advise` prints as "As written") above ``ACCURACY_NOTE``, and is silent below it (every
    study of studies/ is)."""
    from gearsweep.analysis.advise import ACCURACY_NOTE
    from gearsweep.cli import main

    text = (ROOT / "studies" / "whine_speed_sweep.yaml").read_text(encoding="utf-8")
    text = text.replace("steps_per_period: 64", f"steps_per_period: {steps}").replace(
        "start: 1000 rpm", "start: 6000 rpm")
    path = tmp_path / "w.yaml"
    path.write_text(text, encoding="utf-8")
    assert main(["advise", str(path)]) == 0
    said = re.search(r"As written: \d+ steps per mesh period, expected trajectory error"
                     r" ([0-9.e+-]+)", " ".join(capsys.readouterr().out.split()))
    assert (float(said.group(1)) > ACCURACY_NOTE) == noted
    assert main(["validate", str(path)]) == 0
    notes = [ln for ln in capsys.readouterr().err.splitlines() if "expected trajectory" in ln]
    if noted:
        assert notes == [(f"gearsweep: note: {path}: 16 steps per mesh period: expected"
                         f" trajectory error up to {float(said.group(1)):.0%} of the amplitude at"
                         " the lowest speed (rk4; the step advisor's bound, which can"
                         " overestimate far below resonance: docs/precision.md); `gearsweep"
                         f" advise {path}` gives the steps a target needs")]
    else:
        assert notes == []


def test_every_study_here_is_below_the_accuracy_note_as_the_docs_say():
    """ACCURACY_NOTE's docstring and docs/precision.md name the study of studies/ with the
    largest expected error of its own steps: they named whine_speed_sweep.yaml at 0.71 %, and
    rattle_table1_pair.yaml has 0.75 %."""
    from gearsweep.analysis import advise as adv
    from gearsweep.model import MeshModel
    from gearsweep.study.advice import plan_advice
    from gearsweep.study.plan import make_plan
    from gearsweep.study.schema import load_study

    errors = {}
    for path in sorted((ROOT / "studies").glob("*.yaml")):
        study, text = load_study(path)
        if getattr(study, "type", None) in ("mesh", "analysis"):
            continue
        plan = make_plan(study, text, path.name)
        if isinstance(plan.model, MeshModel):
            errors[path.name] = plan_advice(plan, adv.ACCURACY_NOTE).chosen_error
    name = max(errors, key=errors.get)
    most = f"{errors[name]:.2%}".replace("%", " %")
    assert errors[name] < 0.01 < adv.ACCURACY_NOTE
    doc = " ".join((ROOT / "docs" / "precision.md").read_text(encoding="utf-8").split())
    assert f"below 1 % ({most} the most, `{name}`" in doc, (name, most)
    source = " ".join(Path(adv.__file__).read_text(encoding="utf-8").split())
    assert f"below 1 % ({most} the most, studies/{name};" in source, (name, most)


def test_the_advice_names_the_grid_error_of_the_ringing_after_impacts():
    """p_pp is taken on the step grid; with backlash the impacts ring at omega_n, order
    q = omega_n / Omega of the mesh, and where that ringing sets the extremes the grid misses up
    to 1 - cos(pi q / N) <= (pi q / N)^2 / 2 of its amplitude, not the (pi / N)^2 / 2 of a line at
    the mesh order the report said alone (an outside tester measured 1.85e-4 at N = 256 against
    7.5e-5 said, ringing at order 19)."""
    adv = advise(mass=0.22, k0=3.0e8, damping=810.0, speed_rpm=[600.0], teeth=31,
                 backlash=1e-4, method="rk4", target=1e-4)
    q = math.sqrt(3.0e8 / 0.22) / (31 * 600.0 * 2 * math.pi / 60)
    n = adv.steps_per_period
    worst = 1 - math.cos(math.pi * q / n)  # a sampled cosine's peak, half a step off
    said = (math.pi * q / n) ** 2 / 2
    assert worst <= said < 1.01 * worst + 1e-12
    text = " ".join(adv.report().split())
    assert f"at order q = omega_n / Omega = {q:.3g}" in text
    assert f"(pi q/N)^2/2 = {said:.1e} of the ringing's own amplitude" in text
    smooth = advise(mass=0.22, k0=3.0e8, damping=810.0, speed_rpm=[600.0], teeth=31,
                    method="rk4", target=1e-4)
    assert "ringing" not in smooth.report()


PAIR_27_41 = """title: 27/41 whine
scene:
  kind: whine
  gear: {module: 2.5 mm, z1: 27, z2: 41, face_width: 18 mm, x1: 0.3, x2: -0.1, backlash: 0.1 mm}
  torque: 150 N*m
  drive: {inertia_1: 5e-4 kg m^2, inertia_2: 3e-3 kg m^2}
  damping: 2 N*s/mm
sweep:
  speed: [2000 rpm]
solver: {method: rk4, steps_per_period: STEPS, transient_periods: 100, record_periods: 50}
outputs: [stats]
"""


def test_the_advice_bounds_the_grid_error_of_extremes_set_by_the_steps_of_k_t(tmp_path, capsys):
    """A gear pair's k(t) steps between one and two tooth pairs in contact, and p rings at
    omega_n after each step: order q = omega_n / Omega = 7.4 of the mesh at 2000 rpm for an
    outside tester's 27/41 pair. The advice said p_pp, p_max and p_min were within (pi/N)^2/2 =
    8.0e-5 of the amplitude at its 248 steps; measured against 4096 steps, p_min is 1.5e-3 and
    p_pp 2.5e-3 of the amplitude off (p_rms 2e-6). At an extreme p' = 0, so p'' = -(k/m)(p -
    p_qs), and half a step off the peak the sample is low by (pi q/N)^2/2 |p - p_qs|: the bound
    the advice now states, measured here against the run (each extreme within it, p_pp within
    twice it, of the amplitude p_pp / 2)."""
    from gearsweep import run
    from gearsweep.cli import main

    path = tmp_path / "pair.yaml"
    path.write_text(PAIR_27_41.replace("STEPS", "248"))
    assert main(["advise", str(path)]) == 0
    text = " ".join(capsys.readouterr().out.split())
    sentence = text[text.index("The target is the trajectory's"):]
    sentence = sentence[:sentence.index("sets the extremes.") if "sets the extremes." in sentence
                        else sentence.index(".", sentence.index("steps per mesh period"))]
    said = max(float(x) for x in re.findall(r"= (\d\.\de[-+]\d+)", sentence))
    assert "248 steps per mesh period" in text  # the advised step, the one measured here
    ds = run(str(path)).isel(speed=0)
    ref = run(PAIR_27_41.replace("STEPS", "4096")).isel(speed=0)
    amp = float(ref.p_pp) / 2
    for name in ("p_max", "p_min"):
        assert abs(float(ds[name] - ref[name])) / amp <= said, name
    assert abs(float(ds.p_pp - ref.p_pp)) / amp <= 2 * said
    assert abs(float(ds.p_pp - ref.p_pp)) / amp > 2 * (math.pi / 248) ** 2 / 2  # (the old bound)


def _strong_variation(ratio, zeta, rpm):
    """The whine scene with one stiffness harmonic k1 = ratio k0 (order 1) and the first STE
    harmonic only (n = 1), damped for the damping ratio zeta at k0 + k1 (as ``advise`` takes
    it): an outside analyst's case."""
    from gearsweep.model import gear_scene, mesh_frequency

    k1 = ratio * pr.K0
    c = zeta * 2 * math.sqrt((pr.K0 + k1) * pr.MASS)
    scene = gear_scene(mass=pr.MASS, damping=c, k0=pr.K0, k_harmonics=((k1, 1, 0.0),),
                       mesh_frequency=float(mesh_frequency(rpm, pr.TEETH)),
                       ste_harmonics=pr.STE_HARMONICS[:1], force=pr.FORCE)
    return scene, dict(mass=pr.MASS, k0=pr.K0, damping=c, teeth=pr.TEETH,
                       k_harmonics=((k1, 1, 0.0),))


@pytest.mark.parametrize(("rpm", "method", "target"), [
    (4000.0, "rk5", 1e-2),   # r = 0.18: the analyst's case
    (3500.0, "rk4", 1e-4),   # r = 0.16
    (28250.0, "rk4", 1e-4),  # r = 1.30, at the edge of the principal tongue: |mu| = 0.9955
])
def test_strong_stiffness_variation_stays_within_the_advice_and_its_warning(rpm, method, target):
    """k1 = 0.7 k0, zeta = 0.078 (an outside analyst). The varying stiffness carries the
    response to orders 2, 3, ... (each resonating at r = 1/j) that the error model's n = 1 left
    out: at 4000 rpm the advised RK5 step for 1e-2 gave 26 times the expected error, 10.6 times
    the light-damping warning's bound zeta_cal / zeta = 2.5 (RK4 at 3500 rpm: 12.9 times, 5.2
    times the bound); n_eff = 1 + 4 x 0.7 = 3.8 now (``advise.effective_order``). Near the
    principal tongue the free vibration hardly decays (Floquet multiplier 0.9955 per period at
    28,250 rpm) although c is unchanged: 4.9 times the expected error, 2.0 times the bound; the
    warning now takes the damping ratio of that decay (factor 209). Measured against DOP853
    (rtol 1e-12): the error is within what the warning says (0.48, 0.55 and 0.024 of it now)."""
    from gearsweep.analysis import advise as adv_mod

    scene, kw = _strong_variation(0.7, 0.078, rpm)
    adv = advise(speed_rpm=[rpm], highest_order=1, method=method, target=target, **kw)
    assert adv.highest_order == pytest.approx(3.8)
    zeta_cal = adv_mod.load_constants()["calibration_damping_ratio"]["whine"]
    (warning,) = [w for w in adv.warnings if "far below the calibration" in w]
    factor = zeta_cal / adv.decay_zeta
    assert f"up to about {factor:.0f} times" in warning
    err = _trajectory_error(scene, method, adv.steps_per_period, False)
    assert err <= adv.expected_error * factor, (err, adv.expected_error, factor)


def test_free_decay_agrees_with_the_kernels_floquet_multipliers_and_names_the_tongue():
    """``advise.free_decay`` (an RK5 map in numpy at h omega_n <= 0.25) against
    ``kernels.floquet`` (the batch kernel, step refined until converged): the same largest
    multiplier within 1e-5, exp(-zeta omega_n T) away from the tongues; at speeds inside the
    principal tongue (k1 = 0.7 k0, zeta = 0.078: 28,300-37,600 rpm) advise says that the
    equation itself is unstable there."""
    from gearsweep.analysis.advise import free_decay
    from gearsweep.kernels.floquet import floquet, mathieu_parameters
    from gearsweep.model import mesh_frequency

    rpm = np.array([3000.0, 16000.0, 21744.0, 28250.0, 30000.0, 37000.0, 40000.0])
    _, kw = _strong_variation(0.7, 0.078, 10000.0)
    f = mesh_frequency(rpm, pr.TEETH)
    k1 = kw["k_harmonics"][0][0]
    exact = floquet(*mathieu_parameters(pr.K0, k1, pr.MASS, kw["damping"], f)).multiplier
    mine = free_decay(pr.MASS, pr.K0, kw["damping"], kw["k_harmonics"], 2 * math.pi * f)
    assert mine == pytest.approx(exact, rel=1e-5)  # (2.8e-6 at 3000 rpm: the map's h^5)
    wn = math.sqrt((pr.K0 + k1) / pr.MASS)
    assert exact[0] == pytest.approx(math.exp(-0.078 * wn / f[0]), rel=1e-6)  # complex pair
    adv = advise(speed_rpm=rpm, method="rk4", target=1e-4, **kw)
    assert exact[4] > 1 and exact[5] > 1 and exact[3] < 1
    assert any("at 2 of the 7 speeds (30000-37000 rpm) k(t) makes the equation itself unstable"
               in " ".join(w.split()) for w in adv.warnings), adv.warnings


def test_validate_s_accuracy_note_does_not_pay_for_the_free_vibration_scan(monkeypatch):
    """``validate`` reads only the steps' expected error from the advisor: the monodromy per
    speed of ``free_decay`` (1.4 s for the rig's 56 stiffness harmonics; validate of
    rig_low_speed.yaml went from 3.0 to 5.3 s) is for ``advise``'s warnings alone."""
    from gearsweep import cli
    from gearsweep.analysis import advise as adv
    from gearsweep.study.advice import plan_advice
    from gearsweep.study.plan import make_plan
    from gearsweep.study.schema import load_study

    calls = []
    monkeypatch.setattr(adv, "free_decay",
                        lambda *a: calls.append(a) or np.full(len(a[-1]), np.nan))
    adv._free_decay.cache_clear()
    path = ROOT / "studies" / "whine_gear_table1.yaml"
    study, text = load_study(path)
    plan = make_plan(study, text, str(path))
    a = plan_advice(plan, adv.ACCURACY_NOTE, free_vibration=False)
    assert a.chosen_error is not None and calls == []
    plan_advice(plan, adv.ACCURACY_NOTE)  # advise's own path does scan
    assert len(calls) == 1
    adv._free_decay.cache_clear()
    assert cli.main(["validate", str(path)]) == 0
    assert len(calls) == 1  # validate did not


def test_cli_advise_warns_of_a_written_step_beyond_the_over_damped_limit(tmp_path, capsys):
    """The tester's varying scene (k1 = 500 of k0 = 1073 kN/mm, zeta 1.29 at k0 + k1, RK5):
    at 6 steps per period, h omega_n = 1.92 against the fast real pole's 1.608, the run
    diverged at 11000 and 11150 rpm where advise said 3.388 and warned of nothing; the
    advised steps run with status 0."""
    from gearsweep.api import run
    from gearsweep.cli import main

    text = _VARYING_OVERDAMPED
    path = tmp_path / "over6.yaml"
    path.write_text(text, encoding="utf-8")
    assert main(["advise", str(path), "--target", "0.3"]) == 0
    flat = " ".join(capsys.readouterr().out.split())
    want = _oscillator_limit("rk5", 40e3 / (2 * math.sqrt(1.573e9 * 0.1527)))
    assert want == pytest.approx(1.608, abs=1e-3)
    said = float(re.search(r"stable for h omega_n < (\d+\.\d+)", flat)[1])
    assert said == pytest.approx(want, abs=1.5e-3)
    assert re.search(r"WARNING: 6 steps per period give h omega_n = 1.92\d at 11000 rpm, beyond"
                     r" the rk5 stability limit 1.60\d", flat), flat
    spp = int(re.search(r"For a target of [\d.e+-]+: (\d+) steps per mesh period", flat)[1])
    ds = run(text.replace("steps_per_period: 6", f"steps_per_period: {spp}"))
    np.testing.assert_array_equal(ds.status.values.ravel(), 0)


def _printed_advice(text: str) -> tuple[int, list[str]]:
    """The advised steps and the warnings, read from the text `gearsweep advise` printed."""
    flat = " ".join(text.split())
    steps = int(re.search(r"For a target of [\d.e+-]+: (\d+) steps per mesh period", flat)[1])
    paragraphs: list[str] = []
    for line in text.splitlines()[1:]:  # after "STUDY:", each paragraph at 2 spaces, then 4
        if line.startswith("  ") and not line.startswith("    "):
            paragraphs.append(line.strip())
        else:
            paragraphs[-1] += " " + line.strip()
    return steps, [p.removeprefix("WARNING: ") for p in paragraphs if p.startswith("WARNING: ")]


@pytest.mark.parametrize(("study", "target"), [
    ("fig08_rattle.yaml", "1e-4"),  # a study file of studies/: the kink-aware advice too
    ("varying.yaml", "0.3"),  # _VARYING_OVERDAMPED: steps raised by a parametric resonance
])
def test_the_api_advises_what_the_cli_prints(study, target, tmp_path, capsys):
    """``gearsweep.advise`` (a notebook had no way to the study's advice: it lived in the CLI)
    gives the advice `gearsweep advise` prints: its ``str`` is the printed text, and its steps
    and warnings are the ones read back from that text; a dict or a Study of the same study is
    advised the same."""
    import yaml

    import gearsweep
    from gearsweep.api import load
    from gearsweep.cli import main

    path = ROOT / "studies" / study
    if study == "varying.yaml":
        path = tmp_path / study
        path.write_text(_VARYING_OVERDAMPED, encoding="utf-8")
    assert main(["advise", str(path), "--target", target]) == 0
    printed = capsys.readouterr().out
    steps, warned = _printed_advice(printed)
    a = gearsweep.advise(str(path), target=float(target))
    assert str(a) + "\n" == printed
    assert a.steps_per_period == steps
    assert [" ".join(w.split()) for w in a.warnings] == warned
    if study == "varying.yaml":  # the resonance's advice, carried through
        (raised,) = [w for w in warned if w.startswith("near a parametric resonance of k(t)")]
        assert f" {steps} steps bring it to " in raised
    else:
        assert a.kink_steps_per_period is not None
    for same in (yaml.safe_load(path.read_text(encoding="utf-8")), load(path)[0]):
        b = gearsweep.advise(same, target=float(target))
        assert (b.steps_per_period, b.warnings, b.report()) == (steps, a.warnings, a.report())


def test_cli_advise_takes_the_limit_at_every_swept_stiffness(tmp_path, capsys):
    """Over-damped, a smaller stiffness has the faster real pole (c / (2m) + sqrt(c^2 / 4m^2 -
    k / m)): over k0 = 300 and 1073 kN/mm at 40 N s/mm, 30 RK5 steps at 3000 rpm are within the
    stiffest case's limit and beyond the softer one's, which diverges (status 1); advise states
    the softer case's limit (at the stiffest case's omega_n) and warns, as validate does."""
    from gearsweep.api import run
    from gearsweep.cli import main
    from gearsweep.errors import StepLimitWarning

    text = _OVERDAMPED.replace("speed: [3000 rpm, 6000 rpm, 12000 rpm]",
                               "speed: [3000 rpm]\n  stiffness: [300 kN/mm, 1073 kN/mm]").replace(
        "steps_per_period: 64", "steps_per_period: 30")
    path = tmp_path / "k.yaml"
    path.write_text(text, encoding="utf-8")
    assert main(["advise", str(path), "--target", "0.3"]) == 0
    flat = " ".join(capsys.readouterr().out.split())
    m, c = 0.1527, 40e3
    wn_lo, wn_hi = math.sqrt(3e8 / m), math.sqrt(1.073e9 / m)
    want = _oscillator_limit("rk5", c / (2 * m * wn_lo)) * wn_hi / wn_lo
    assert want == pytest.approx(1.117, abs=1e-3)
    said = float(re.search(r"stable for h omega_n < (\d+\.\d+)", flat)[1])
    assert said == pytest.approx(want, abs=1.5e-3)
    assert "the one at damping ratio 2.955 sets it" in flat
    assert re.search(r"WARNING: 30 steps per period give h omega_n = 1.16\d at 3000 rpm, beyond"
                     r" the rk5 stability limit 1.11\d", flat), flat
    assert main(["validate", str(path)]) == 0
    assert "1 case(s) will use a step beyond the stability limit" in capsys.readouterr().err
    with pytest.warns(StepLimitWarning, match="beyond the stability limit"):
        ds = run(text)
    assert ds.stiffness.values.tolist() == [300.0, 1073.0]  # kN/mm
    np.testing.assert_array_equal(ds.status.values.ravel(), [1, 0])

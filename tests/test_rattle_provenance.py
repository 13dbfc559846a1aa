"""The Fig. 8 fit, the contact-loss threshold and the pinion sensor model (analysis.rattle,
analysis.sensor): issue 28, items 1, 2 and 5."""

import math

import numpy as np
from numpy.testing import assert_allclose

from gearsweep.analysis import hb, rattle, sensor
from gearsweep.model import RPM

M, K = 0.1527, 1073e6
FM = 50.0 / (0.060 * math.cos(math.radians(20.0)))
W = 48 * RPM  # mesh rad/s per rpm of the 48-tooth gear


def test_fit_puts_the_folds_on_the_targets():
    """The fitted c and F0 put the describing function's folds at the targets, checked without
    the curve or its turning-point refinement (what the fit itself iterates on): at a fixed
    frequency the single-harmonic amplitudes are the roots of G(A) (``hb.df_solutions``: a
    grid, then Brent), one outside the hysteresis band and three inside it (stable, unstable,
    stable), the count changing within 1e-5 of each target. At the old half gap of 0.25 mm the
    fit gives the c and F0 documented before (4.918 N s/mm, 72.20 kN: a regression value)."""
    b = 0.25e-3
    c, f0 = rattle.fit_turning_points([7500 * W, 8000 * W], mass=M, stiffness=K, half_gap=b,
                                      force_mean=FM)
    for rpm, into_band in ((7500.0, 1.0), (8000.0, -1.0)):
        for rel, count in ((into_band * 1e-5, 3), (-into_band * 1e-5, 1)):
            amps, stable = hb.df_solutions(rpm * W * (1.0 + rel), mass=M, stiffness=K,
                                           damping=c, half_gap=b, force_amp=f0, force_mean=FM)
            assert amps.size == count, (rpm, rel, amps)
            assert list(stable) == ([True, False, True] if count == 3 else [True])
    assert_allclose([c, f0], [4918.0, 72.20e3], rtol=2e-4)


def test_contact_loss_threshold_is_the_minimum_of_the_linear_response():
    """The least F0 that opens the mesh equals F_m min_w |k - m w^2 + i c w| / k (brute force
    over a fine frequency grid), for light and heavy damping."""
    w = np.linspace(1.0, 3.0 * math.sqrt(K / M), 2_000_001)
    for c in (492.0, 4920.0, 30e3):
        brute = FM * np.min(np.abs(K - M * w**2 + 1j * c * w)) / K
        got = rattle.contact_loss_threshold(mass=M, stiffness=K, damping=c, force_mean=FM)
        assert_allclose(got, brute, rtol=1e-6)


def test_eq15_distance_picks_the_nearest_root():
    """At a speed with three Eq. (15) roots, the distance is to the nearest of them; at the
    speeds where the gap root appears and the in-phase root leaves, the named limits hold."""
    b, f0 = 0.25e-3, 72e3
    sp = np.array([12000.0])
    roots = np.abs(hb.eq15_roots(sp * W, f0, K, M, b))[0]
    assert np.isfinite(roots).sum() == 3
    d = rattle.eq15_distance(sp, [roots[1] * 1.1], omega_per_rpm=W, force_amp=f0,
                             stiffness=K, mass=M, half_gap=b)
    assert_allclose(d.eq15, [roots[1]])
    assert_allclose(d.relative, [0.1 / 1.1], rtol=1e-12)
    assert_allclose(d.rise_eq15 * W, math.sqrt(f0 / (M * b)))
    assert_allclose(d.drop_eq15 * W, math.sqrt(K / M))


def test_pinion_displacement_is_eq4_per_line():
    """r2 theta2 = (r2^2 / I2) W / w^2 per line, 0 for the mean; and for the rigid pair without
    torque fluctuation, W - F_m = -m (p + e)'', so r2 theta2 = m r2^2 / I2 (p + e) per line."""
    r1, r2, i1, i2 = 0.0564, 0.0376, 1.598e-3, 3.157e-4
    m = 1.0 / (r1**2 / i1 + r2**2 / i2)
    f = np.array([0.0, 106.7, 213.4])
    p = np.array([0.0, 0.2e-6, 0.1e-6])  # line amplitudes of p + e
    w_force = m * (2 * math.pi * f) ** 2 * p  # |m (p + e)''| per line
    x = sensor.pinion_displacement(w_force, f, base_radius_2=r2, inertia_2=i2)
    assert_allclose(x, m * r2**2 / i2 * p, rtol=1e-12)
    assert x[0] == 0.0
    assert_allclose(sensor.spectrum_rms(x[1:]), math.sqrt(0.5 * np.sum(x[1:] ** 2)))

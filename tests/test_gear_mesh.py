"""Tooth compliance, load sharing, STE, mesh stiffness, Fourier series, ISO 6336-1 check."""

import dataclasses
import math
import re
import time
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from scipy.optimize import brentq

from gearsweep.errors import GeometryError
from gearsweep.gear.compliance import hertz_compliance, pair_compliance, tooth_profile
from gearsweep.gear.geometry import (
    GearPair,
    GeometryWarning,
    table1_as_printed,
    table1_consistent,
)
from gearsweep.gear.mesh import (
    TipRelief,
    _share_kernel,
    fourier,
    fourier_series,
    iso6336_stiffness,
    mesh_cycle,
    mesh_cycles,
)

STANDARD_PAIRS = [
    table1_consistent(),
    GearPair(module=2e-3, z1=20, z2=40, face_width=20e-3),
    GearPair(module=3e-3, z1=30, z2=90, face_width=20e-3),
    GearPair(module=4e-3, z1=25, z2=50, face_width=30e-3),
]


def _relief_at_single_contact_bounds(pair: GearPair, amount: float, shape: str = "linear"):
    """Tip relief of both gears starting where single-tooth contact begins on each tip."""
    xi1 = (pair.s_start + pair.base_pitch) / pair.base_radius1
    xi2 = (pair.line_of_action_length - (pair.s_end - pair.base_pitch)) / pair.base_radius2
    return (
        TipRelief(amount, start_roll_angle=xi1, shape=shape),
        TipRelief(amount, start_roll_angle=xi2, shape=shape),
    )


# --------------------------------------------------------------------------- ISO 6336-1


@pytest.mark.parametrize("pair", STANDARD_PAIRS, ids=lambda p: f"{p.z1}-{p.z2}")


def test_stiffness_within_band_of_iso6336(pair):
    """Mean mesh stiffness vs c_gamma and maximum single-pair stiffness vs c' within +-25 %.

    ISO 6336-1 Method B is an empirical fit to measured stiffness (its C_M = 0.8 alone is a
    20 % correction between calculated solid-disc values and measurements), and analytical
    potential-energy models differ from it by some tens of percent depending on how the
    foundation and contact are modelled. +-25 % is wide enough for that and fails if the
    Sainsot foundation term is dropped or halved (dropping it roughly doubles the stiffness of
    these pairs) or the shear term doubled; it does not catch every term off by a factor
    (without bending: 1.14-1.22 of ISO, without Hertz 1.09-1.17; measured by an outside audit),
    which is why the bending, shear and axial integrals are checked term by term in
    ``test_castigliano_integrals_by_quadrature``.
    """
    c_prime, c_gamma = iso6336_stiffness(pair)
    # Line load 200 N/mm, inside ISO's range (>= 100 N/mm); the model is linear in load anyway.
    mc = mesh_cycle(pair, torque=200.0 * (pair.face_width * 1e3) * pair.base_radius1)
    assert 0.75 < mc.mesh_stiffness.mean() / c_gamma < 1.25
    assert 0.75 < mc.pair_stiffness.max() / c_prime < 1.25


def test_iso6336_hand_value():
    # 48/32 teeth, x = 0: q' = 0.04723 + 0.15551/32 + 0.25791/48 = 0.057463 mm um/N,
    # c'_th = 17.40, C_M = 0.8, C_B = 1 + 0.5 (1.2 - 1.25) = 0.975 -> c' = 13.574 N/(mm um);
    # b = 10 mm -> 135.74 N/um. c_gamma = c' (0.75 * 1.70757 + 0.25) = 207.77 N/um.
    c_prime, c_gamma = iso6336_stiffness(table1_consistent())
    assert c_prime == pytest.approx(135.74e6, rel=1e-4)
    assert c_gamma == pytest.approx(207.77e6, rel=1e-4)


def test_a_pair_beyond_the_compliance_model_s_range_is_refused():
    """Sainsot et al.'s foundation fit diverges for many teeth: z1 = 20, z2 = 2000 gave a mean
    mesh stiffness of 18 kN/mm against ISO's c_gamma of 445 kN/mm, silently (an adversarial
    test), and 20/1000 1.5 times c_gamma. Both gears lie below the fit's root half angle,
    0.01 rad (theta_f < pi / z, the fillet centre within the tooth space), and are refused at
    z2 for it; the check against ISO (more than a factor 2 from c_gamma either way) stays."""
    for z2 in (2000, 1000):
        with pytest.raises(GeometryError, match=rf"gear 2 root half angle theta_f = \S+ rad"
                                                rf" \({z2} teeth\), outside 0.01 to 0.12 rad") as info:
            mesh_cycle(GearPair(module=1e-3, z1=20, z2=z2, face_width=20e-3), 50.0)
        assert info.value.faults[0][1][0] == "z2"
    from gearsweep.gear.mesh import _check_against_iso

    pair = GearPair(module=1e-3, z1=20, z2=100, face_width=20e-3)
    c_gamma = iso6336_stiffness(pair)[1]
    with pytest.raises(GeometryError, match=r"0.04 times ISO 6336-1's c_gamma"):
        _check_against_iso(pair, 0.04 * c_gamma)
    _check_against_iso(pair, 1.5 * c_gamma)


@pytest.mark.parametrize("youngs_modulus", [2.5e9, 70e9, 110e9, 450e9])


def test_a_pair_of_another_material_is_checked_against_iso_for_that_material(youngs_modulus):
    """Every compliance term is 1/E, so a pair's stiffness is E times that of steel (E = 206 GPa)
    and ISO 6336-1 scales its c' and c_gamma by E / E_st for other materials. The range check
    compared with steel's c_gamma: an aluminium (70 GPa) or plastic (2.5 GPa) Table 1 pair was
    refused as beyond the compliance model's range, "its foundation term ... diverges for many
    teeth or a thin body" (found by a fuzzer). Its stiffness is the steel pair's times E / E_st."""
    steel = table1_consistent()
    other = dataclasses.replace(steel, youngs_modulus=youngs_modulus)
    # at 5 N m: 50 N m deflects the plastic pair by 0.18 module, beyond any rated load (warned:
    # mesh.load_cautions); k of unmodified teeth does not depend on the load
    k = mesh_cycle(other, 5.0).mesh_stiffness.mean()
    assert k == pytest.approx(mesh_cycle(steel, 5.0).mesh_stiffness.mean()
                              * youngs_modulus / 206e9, rel=1e-6)
    far = GearPair(module=1e-3, z1=20, z2=2000, face_width=20e-3, youngs_modulus=youngs_modulus)
    with pytest.raises(GeometryError, match=r"root half angle theta_f = \S+ rad \(2000 teeth\)"):
        mesh_cycle(far, 50.0)  # still beyond the model's range, whatever the material
    # ISO's values for the pair's material (a mesh study's iso_* outputs: they were steel's)
    iso = np.array(iso6336_stiffness(other)) / np.array(iso6336_stiffness(steel))
    assert iso == pytest.approx([youngs_modulus / 206e9] * 2, rel=1e-12)


# --------------------------------------------------------------------------- compliance


def test_hertz_compliance_formula():
    pair = table1_consistent()
    expected = 4 * (1 - 0.3**2) / (math.pi * 206e9 * 10e-3)
    assert hertz_compliance(pair) == pytest.approx(expected, rel=1e-14)


def test_single_pair_stiffness_peaks_inside_path():
    """A tooth pair is softest at the ends of the path of contact (one tooth loaded at its tip)."""
    pair = table1_consistent()
    s = np.linspace(pair.s_start, pair.s_end, 101)
    k = 1.0 / pair_compliance(pair, s)
    i_max = int(np.argmax(k))
    assert 10 < i_max < 90
    assert k[0] < 0.75 * k[i_max] and k[-1] < 0.75 * k[i_max]


def test_thinner_rim_lowers_stiffness():
    pair = table1_consistent()
    means = []
    for rim in (None, 10e-3, 6e-3, 3e-3):
        q = dataclasses.replace(
            pair, rim_thickness1=rim, rim_thickness2=rim, web_width1=3e-3, web_width2=3e-3
        )
        means.append(mesh_cycle(q, 50.0).mesh_stiffness.mean())
    assert all(a > b for a, b in zip(means, means[1:], strict=False)), means


def test_a_bore_radius_is_taken_within_sainsot_s_range_and_refused_outside_it():
    """A 27/41 pair (module 2.5 mm, face 18 mm) with bore_radius2 45 mm (root radius 48.1 mm)
    gave 401.5 kN/mm, 48 mm (a 0.125 mm rim) 402.7, the solid gear 382.0: a thinner rim
    stiffer, unsaid (an outside gear engineer's finding). Sainsot et al. (2004) fitted their
    body term for 1.4 <= r_f / r_int <= 7: within it the mean stiffness falls as the rigid
    clamp closes in on the centre (more body to deform); outside it the bore is refused at
    bore_radius2, naming the bore radii that fit (r_f / 7 up, r_f / 1.4 down, to 0.01 mm)."""
    base = GearPair(module=2.5e-3, z1=27, z2=41, face_width=18e-3)
    rf = 2.5e-3 * (41 / 2 - 1.25)  # the standard root radius, 48.125 mm
    means = [mesh_cycle(dataclasses.replace(base, bore_radius2=rf / h), 50.0).mesh_stiffness.mean()
             for h in (1.4, 2.0, 3.5, 5.0, 7.0)]
    assert all(a > b for a, b in zip(means, means[1:], strict=False)), means
    fits = (f"a bore radius of {math.ceil(rf / 7 * 1e5) / 100:g} to"
            f" {math.floor(rf / 1.4 * 1e5) / 100:g} mm fits (bore_radius2")
    for bore in (45e-3, 48e-3, rf / 1.39, rf / 7.01):
        with pytest.raises(GeometryError) as err:
            mesh_cycle(dataclasses.replace(base, bore_radius2=bore), 50.0)
        (message, fields), = err.value.faults
        assert fields[0] == "bore_radius2" and fits in message, message


def test_tooth_profile_root_section():
    pair = table1_consistent()
    prof = tooth_profile(pair, 2)
    # Root section: the chord through the fillet-root tangency points, S_f = 2 r_f sin(theta_f).
    assert prof.half_width[0] == pytest.approx(prof.root_radius * math.sin(prof.theta_f), rel=1e-6)
    assert np.all(np.diff(prof.j0) > 0)


# --------------------------------------------------------------------------- load sharing, STE


def test_load_share_sums_to_one_and_single_contact_carries_all():
    mc = mesh_cycle(table1_consistent(), 50.0)
    assert_allclose(mc.load_share.sum(axis=1), 1.0, rtol=1e-12)
    assert np.all(mc.load_share >= 0) and np.all(mc.load_share <= 1 + 1e-12)  # round-off
    single = mc.in_contact.sum(axis=1) == 1
    # epsilon = 1.7076: single contact during 1 - 0.7076 = 29 % of the cycle (+-1 sample).
    assert abs(single.mean() - (2 - mc.pair.contact_ratio)) <= 1.0 / mc.phase.size
    assert_allclose(mc.load_share[single].max(axis=1), 1.0, rtol=1e-12)


def test_unmodified_mesh_is_linear_in_load_and_tangent_equals_secant():
    low, high = mesh_cycles(table1_consistent(), [25.0, 100.0])
    assert_allclose(high.ste, 4.0 * low.ste, rtol=1e-12)
    assert_allclose(low.mesh_stiffness, low.secant_stiffness, rtol=1e-12)


def test_ste_peak_to_peak_grows_with_load():
    pair = table1_consistent()
    relief = _relief_at_single_contact_bounds(pair, 4e-6)
    for tip_relief in (None, relief):
        cycles = mesh_cycles(pair, [5.0, 20.0, 50.0, 100.0, 200.0], tip_relief=tip_relief)
        pp = [np.ptp(c.ste) for c in cycles]
        mean = [c.ste.mean() for c in cycles]
        assert all(a < b for a, b in zip(mean, mean[1:], strict=False))
        if tip_relief is None:
            assert all(a < b for a, b in zip(pp, pp[1:], strict=False)), pp


def test_tip_relief_lowers_first_harmonic_at_design_load():
    """Linear relief of 6 um from the single-contact bounds, designed for 50 N m."""
    pair = table1_consistent()
    plain = mesh_cycle(pair, 50.0)
    relieved = mesh_cycle(pair, 50.0, tip_relief=_relief_at_single_contact_bounds(pair, 6e-6))
    a_plain, _ = fourier(plain.ste, 3)
    a_relief, _ = fourier(relieved.ste, 3)
    assert a_relief[1] < 0.3 * a_plain[1]
    # Far below the design load the same relief is too much: it raises the first harmonic.
    plain_low = mesh_cycle(pair, 5.0)
    relieved_low = mesh_cycle(pair, 5.0, tip_relief=_relief_at_single_contact_bounds(pair, 6e-6))
    assert fourier(relieved_low.ste, 1)[0][1] > fourier(plain_low.ste, 1)[0][1]


def test_constant_profile_error_shifts_ste_only():
    pair = table1_consistent()
    plain = mesh_cycle(pair, 50.0)
    shifted = mesh_cycle(pair, 50.0, profile_error=lambda s: np.full_like(s, 3e-6))
    assert_allclose(shifted.ste, plain.ste + 3e-6, rtol=1e-12)
    assert_allclose(shifted.load_share, plain.load_share, atol=1e-12)


def test_profile_error_array_equals_callable():
    pair = table1_consistent()
    table = 2e-6 * np.sin(np.linspace(0.0, 3.0, 301))
    grid = np.linspace(pair.s_start, pair.s_end, table.size)
    from_array = mesh_cycle(pair, 50.0, profile_error=table)
    from_callable = mesh_cycle(pair, 50.0, profile_error=lambda s: np.interp(s, grid, table))
    assert_allclose(from_array.ste, from_callable.ste, rtol=1e-14)


@settings(deadline=None, max_examples=60)
@given(
    compliance=st.lists(st.floats(1e-9, 1e-8), min_size=3, max_size=3),
    separation=st.lists(st.floats(0.0, 2e-5), min_size=3, max_size=3),
    force=st.floats(1.0, 1e4),
)


def test_share_kernel_solves_compatibility(compliance, separation, force):
    """Water filling against a root of sum max(0, (d - e_j)/c_j) = F found by scipy's brentq."""
    c = np.array([compliance])
    e = np.array([separation])
    ste, stiffness = np.empty((1, 1)), np.empty((1, 1))
    loads = np.empty((1, 1, 3))
    _share_kernel(c, e, np.array([[force]]), ste, loads, stiffness)

    def residual(d: float) -> float:
        return float(np.sum(np.maximum(0.0, (d - e[0]) / c[0])) - force)

    d_ref = brentq(residual, 0.0, 1.0, xtol=1e-18, rtol=1e-14)
    # brentq is converged to ~1e-14 relative; the kernel is a closed form: 1e-10 is loose.
    assert ste[0, 0] == pytest.approx(d_ref, rel=1e-10, abs=1e-18)
    assert loads.sum() == pytest.approx(force, rel=1e-10)


# --------------------------------------------------------------------------- Fourier


def test_fourier_recovers_known_series():
    phi = np.arange(200) / 200
    x = 3.0 + 2.0 * np.cos(2 * np.pi * phi + 0.5) + 0.7 * np.cos(2 * np.pi * 3 * phi - 1.0)
    amp, phase = fourier(x, 4)
    assert_allclose(amp, [3.0, 2.0, 0.0, 0.7, 0.0], atol=1e-12)
    assert_allclose(phase[[1, 3]], [0.5, -1.0], atol=1e-12)


TESTER_PAIR = GearPair(module=2.5e-3, z1=27, z2=41, face_width=18e-3, x1=0.3, x2=-0.1)
"""An outside tester's pair (contact ratio 1.61): at 200 uniform positions its k_5 was 54 % off."""


def _amplitudes(c: np.ndarray) -> np.ndarray:
    """Eq. (1) amplitudes of complex coefficients ``c_n = int x e^(-2 pi i n phase)``."""
    a = 2.0 * np.abs(c)
    a[0] = c[0].real
    return a


def _unmodified_harmonics_by_simpson(pair: GearPair, torque: float, orders: np.ndarray,
                                     m: int = 4001) -> tuple[np.ndarray, np.ndarray]:
    """k and STE amplitudes of an unmodified pair by Simpson's rule on ``m`` points, written
    from pair_compliance alone. k: one pair's stiffness kp(u) over its engagement u in [0, eps]
    (base pitches), as the slots stitch into it: c_n = int_0^eps kp(u) e^(-2 pi i n u) du, a
    smooth integrand without jumps. STE = F / k(phase) on each piece between the phases 0 and
    eps - floor(eps) where a pair enters and leaves, k the sum over the pairs in contact."""
    from scipy.integrate import simpson

    eps, force = pair.contact_ratio, torque / pair.base_radius1

    def kp(u: np.ndarray) -> np.ndarray:
        return 1.0 / pair_compliance(pair, pair.s_start + u * pair.base_pitch)

    def integral(x: np.ndarray, u: np.ndarray) -> np.ndarray:
        return simpson(x[:, None] * np.exp(-2j * np.pi * np.outer(u, orders)), x=u, axis=0)

    u = np.linspace(0.0, eps, m)
    c_k = integral(kp(u), u)
    c_e = 0.0
    f = eps - math.floor(eps)
    for a, b in ((0.0, f), (f, 1.0)):
        p = np.linspace(a, b, m)
        k = sum(kp(p + j) for j in range(3) if 0.5 * (a + b) + j <= eps)
        c_e = c_e + integral(force / k, p)
    return _amplitudes(c_k), _amplitudes(c_e)


@pytest.mark.parametrize("pair, torque", [(TESTER_PAIR, 150.0), (table1_consistent(), 50.0)],
                         ids=["27-41", "table1"])


def test_harmonics_match_an_independent_integral_to_1e5(pair, torque):
    """k and STE harmonics 0..10 of mesh_cycle (and of gear_excitation, which the dynamics take)
    against Simpson's rule on 4001 points per piece (converged: 200001 points move it by 1e-8).
    Measured: 1.2e-6 relative at most (the smallest harmonic, 0.6 % of k0); the DFT of 200
    uniform samples was 0.34-0.55 off at the worst order (k5 of the 27/41 pair +54 %, k3 of
    Table 1 +6.5 %: the jumps of k where a pair enters or leaves make its error 1/N)."""
    orders = np.arange(11)
    k_true, e_true = _unmodified_harmonics_by_simpson(pair, torque, orders)
    arrays = mesh_cycle(pair, torque).as_arrays(10)
    assert_allclose(arrays["k_harmonic"], k_true, rtol=1e-5)
    assert_allclose(arrays["ste_harmonic"], e_true, rtol=1e-5)
    from gearsweep.gear.excitation import gear_excitation

    ex = gear_excitation(pair, torque)
    assert_allclose([ex.stiffness, *(h.amplitude for h in ex.stiffness_harmonics)], k_true,
                    rtol=1e-5)
    assert_allclose([h.amplitude for h in ex.ste_harmonics], e_true[1:], rtol=1e-5)


def test_quadrature_integrates_a_piecewise_linear_function_with_jumps_exactly():
    """The nodes of a mesh cycle against the closed-form Fourier coefficients of a function
    linear on each piece between its breaks, jumping at each break (as k does): to 1e-11 (the
    mean is 1.7; measured 2.3e-12; 200 uniform samples of it are 8e-3 off)."""
    quad = mesh_cycle(TESTER_PAIR, 150.0, harmonics=10).quadrature
    assert_allclose(quad.breaks, [0.0, TESTER_PAIR.contact_ratio - 1.0], rtol=1e-14)
    assert_allclose(quad.weight.sum(), 1.0, rtol=1e-14)
    stops = np.append(quad.breaks[1:], 1.0)
    alpha, beta = np.array([1.0, -0.5]), np.array([2.0, 3.0])  # x = alpha + beta phase
    x = np.zeros_like(quad.phase)
    exact = np.zeros(11, dtype=complex)
    for a, b, al, be in zip(quad.breaks, stops, alpha, beta, strict=True):
        inside = (quad.phase > a) & (quad.phase < b)
        x[inside] = al + be * quad.phase[inside]
        exact[0] += al * (b - a) + be * (b**2 - a**2) / 2
        w = 2 * np.pi * np.arange(1, 11)
        # int (al + be p) e^(-iwp) dp = e^(-iwp) (al / (-iw) + be (p / (-iw) + 1 / w^2))
        def antiderivative(p, al=al, be=be, w=w):
            return np.exp(-1j * w * p) * (al / (-1j * w) + be * (p / (-1j * w) + 1 / w**2))
        exact[1:] += antiderivative(b) - antiderivative(a)
    amp, phase = quad.fourier(x)
    assert np.abs(amp - _amplitudes(exact)).max() < 1e-11
    assert np.abs(phase[1:] - np.angle(exact[1:])).max() < 1e-11 / np.abs(exact[1:]).min()


def test_relieved_harmonics_with_pairs_that_lift_off_match_100000_uniform_positions():
    """6 um relief at 10 N m: the relieved pairs carry no load for part of their contact, so k
    jumps at phases the load sets (solved: two breaks besides the geometric ones). Against the DFT
    of 100,000 uniform positions, whose error is below (sum of the jumps of k) / N = 1.5 k0 / N
    for k and, the STE being continuous here, far smaller for the STE: measured 8e-7 k0 and
    3e-9 of the mean STE; at 200 positions they were 2.7e-3 k0 and 3e-2 of a harmonic."""
    pair = table1_consistent()
    relief = _relief_at_single_contact_bounds(pair, 6e-6)
    mc = mesh_cycle(pair, 10.0, tip_relief=relief)
    assert mc.quadrature.breaks.size == 4
    many = mesh_cycle(pair, 10.0, n=100_000, tip_relief=relief)
    k, e = fourier(many.mesh_stiffness, 10)[0], fourier(many.ste, 10)[0]
    arrays = mc.as_arrays(10)
    assert np.abs(arrays["k_harmonic"] - k).max() < 2.0 * k[0] / 100_000
    assert np.abs(arrays["ste_harmonic"] - e).max() < 1e-7 * e[0]


@pytest.mark.parametrize("n", [200, 201])


def test_fourier_reconstructs_mesh_curves(n):
    """All harmonics up to N//2 reproduce the tabulated curve to round-off (1e-9 relative).

    Truncated at 30 harmonics, the rms error stays below 6 % of the peak-to-peak: the stiffness
    (and the STE slope) jumps when a pair enters or leaves, so the harmonics fall only like 1/n;
    a square wave (two jumps J per period) truncated at N harmonics leaves an rms of about
    J / (pi sqrt(N)) = 0.058 J at N = 30; the measured curves leave ~0.048 pp.
    """
    mc = mesh_cycle(table1_consistent(), 50.0, n=n)
    for x in (mc.mesh_stiffness, mc.ste):
        amp, phase = fourier(x, n // 2)
        assert_allclose(fourier_series(amp, phase, mc.phase), x, rtol=1e-9)
        amp, phase = fourier(x, 30)
        rms = np.sqrt(np.mean((fourier_series(amp, phase, mc.phase) - x) ** 2))
        assert rms < 0.06 * np.ptp(x)


# --------------------------------------------------------------------------- errors, speed


def test_mesh_of_table1_as_printed_is_refused():
    with pytest.raises(GeometryError, match="tip-root interference"):
        mesh_cycle(table1_as_printed(), 50.0)


@pytest.mark.parametrize(
    ("kwargs", "text"),
    [
        ({"torque": -1.0}, "torques must be positive"),
        ({"n": 3}, "positions per mesh cycle"),
        ({"profile_error": np.ones((2, 2))}, "profile_error must be"),
        ({"tip_relief": TipRelief(1e-6, start_radius=1e-3)}, "tip relief start radius"),
    ],
)


def test_bad_mesh_inputs_raise(kwargs, text):
    args = {"pair": table1_consistent(), "torque": 50.0} | kwargs
    with pytest.raises(GeometryError, match=text):
        mesh_cycle(**args)


def test_speed_one_cycle_and_50_load_sweep():
    """Budget from the issue: one cycle well under 1 s, 50 loads under 10 s (compiled)."""
    pair = table1_consistent()
    mesh_cycle(pair, 50.0)  # compile (or load the numba cache)
    tooth_profile.cache_clear()
    t0 = time.perf_counter()
    mesh_cycle(pair, 50.0, n=200)
    one = time.perf_counter() - t0
    tooth_profile.cache_clear()
    t0 = time.perf_counter()
    cycles = mesh_cycles(pair, np.linspace(5.0, 250.0, 50), n=200)
    sweep = time.perf_counter() - t0
    assert len(cycles) == 50
    assert one < 0.5
    assert sweep < 10.0


# --------------------------------------------------------------------------- more mesh cases


def test_contact_ratio_above_two_uses_three_pairs():
    # Long addenda (1.3 m) on 60/90 teeth, m = 1 mm: epsilon = 2.31, two or three pairs in contact.
    pair = GearPair(
        module=1e-3, z1=60, z2=90, face_width=10e-3, tip_radius1=31.3e-3, tip_radius2=46.3e-3,
        root_radius1=28.6e-3, root_radius2=43.6e-3, fillet_radius=0.25e-3,
    )  # fmt: skip
    mc = mesh_cycle(pair, 20.0)
    n_pairs = mc.in_contact.sum(axis=1)
    assert set(np.unique(n_pairs)) == {2, 3}
    # Three pairs during (epsilon - 2) of the cycle, +- one sample.
    assert abs((n_pairs == 3).mean() - (pair.contact_ratio - 2)) <= 1.0 / mc.phase.size
    assert_allclose(mc.load_share.sum(axis=1), 1.0, rtol=1e-12)


def test_tip_relief_shapes_and_start_forms():
    pair = table1_consistent()
    rb, ra = pair.base_radius1, pair.tip_radius[0]
    r_start = 61.0e-3
    xi_s, xi_a = math.sqrt(r_start**2 - rb**2) / rb, math.sqrt(ra**2 - rb**2) / rb
    xi_mid = 0.5 * (xi_s + xi_a)
    r = np.array([60.0e-3, r_start, rb * math.sqrt(1 + xi_mid**2), ra])
    lin = TipRelief(10e-6, start_radius=r_start).separation(pair, 1, r)
    par = TipRelief(10e-6, start_diameter=2 * r_start, shape="parabolic").separation(pair, 1, r)
    by_roll = TipRelief(10e-6, start_roll_angle=xi_s).separation(pair, 1, r)
    # Linear in roll angle: 0 below the start, half at mid roll angle, all at the tip.
    assert_allclose(lin, [0.0, 0.0, 5e-6, 10e-6], atol=1e-15)
    assert_allclose(par, [0.0, 0.0, 2.5e-6, 10e-6], atol=1e-15)
    assert_allclose(by_roll, lin, atol=1e-15)


def test_as_arrays_uses_data_names():
    mc = mesh_cycle(table1_consistent(), 50.0)
    arrays = mc.as_arrays(n_harmonics=5)
    expected = {"mesh_phase", "ste", "load_share", "mesh_stiffness", "k_harmonic", "k_phase"}
    assert expected | {"ste_harmonic", "ste_phase", "e_harmonic", "e_phase"} == set(arrays)
    assert arrays["k_harmonic"].shape == (6,)
    # The mean of the uniform samples is off by less than the jumps of k over n positions.
    assert abs(arrays["k_harmonic"][0] - mc.mesh_stiffness.mean()) < np.ptp(mc.mesh_stiffness) / 200
    assert np.all((arrays["mesh_phase"] >= 0) & (arrays["mesh_phase"] < 1))
    # e = STE - F / k: zero for unmodified error-free teeth (STE = F / k at every phase)
    assert arrays["e_harmonic"].max() < 1e-12 * arrays["ste_harmonic"][0]


# --------------------------------------------------------------------------- plots (data only)


def test_plots_draw_the_computed_data():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from gearsweep.plot.mesh import plot_backlash_stiffness, plot_load_sharing, plot_ste

    mc = mesh_cycle(table1_consistent(), 50.0)
    fig, axes = plt.subplots(1, 3)
    try:
        assert plot_ste(axes[0], mc, cycles=1) is fig
        x, y = axes[0].lines[0].get_data()
        assert_allclose(y[:-1], mc.ste * 1e6, rtol=1e-12)  # um
        assert "[um]" in axes[0].get_ylabel()
        plot_load_sharing(axes[1], mc)
        (pair_line,) = [ln for ln in axes[1].lines if ln.get_label() == "one tooth pair"]
        pos_mm, share = pair_line.get_data()
        assert share.max() == pytest.approx(1.0, rel=1e-12)
        path_mm = mc.pair.path_of_contact * 1e3
        assert pos_mm.min() == 0.0 and pos_mm.max() == pytest.approx(path_mm, rel=1e-12)
        # every curve of Fig. 2 has a legend entry: the thin lines had none
        handles, labels = axes[1].get_legend_handles_labels()
        assert labels == ["the other pairs in contact", "one tooth pair"]
        assert len(axes[1].lines) == 3 + 2  # three curves (two thin), the LPSTC and HPSTC lines
        # a thin line ends before the end of the path: the next pair's step to the whole load as
        # ours leaves was drawn on the right edge, a grey tick above ours (0.6 -> 1.0 at 12.6 mm)
        for ln in axes[1].lines[:2]:
            x, y = (np.asarray(a, float) for a in ln.get_data())
            assert x[np.isfinite(y)].max() < path_mm  # no segment crosses the right edge
        # gear 1's points of single contact (the contact climbs gear 1's flank from its root)
        eps, pb_mm = mc.pair.contact_ratio, mc.pair.base_pitch * 1e3
        marks = {t.get_text().strip(): t.get_position()[0] for t in axes[1].texts}
        assert marks == pytest.approx({"LPSTC of gear 1 (driving)": (eps - 1) * pb_mm,
                                       "HPSTC of gear 1": pb_mm}, rel=1e-12)
        k, backlash = 2e8, 0.4e-3
        plot_backlash_stiffness(axes[2], k, backlash)
        p, force = axes[2].lines[0].get_data()
        # Eq. (8): zero inside +-b (b = 0.2 mm), slope k outside; p in mm, force in kN.
        assert_allclose(p, [-0.5, -0.2, 0.2, 0.5], rtol=1e-12)
        assert_allclose(force, [-k * 0.3e-3 / 1e3, 0.0, 0.0, k * 0.3e-3 / 1e3], rtol=1e-12)
    finally:
        plt.close(fig)


def test_load_sharing_of_a_contact_ratio_above_2_draws_every_pair_and_no_single_contact():
    """A 60/90 pair at 16 deg with long teeth (contact ratio 2.47: two or three pairs, never one)
    was marked "HPSTC" and "LPSTC" (reversed) where three pairs change to two and drew only the
    neighbouring pairs. Now: no single-contact marks; a dotted line where the count of pairs
    changes, and each zone's count, as the mesh's own slots in contact count them; and the drawn
    shares add to 1 (the load balance) at the middle of every zone."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from gearsweep.plot.mesh import plot_load_sharing

    pair = GearPair(module=2e-3, z1=60, z2=90, face_width=20e-3,
                    pressure_angle=math.radians(16.0), tip_radius1=62.4e-3,
                    tip_radius2=92.4e-3, root_radius1=57.1e-3, root_radius2=87.1e-3)
    mc = mesh_cycle(pair, 100.0, n=400)
    eps, pb_mm = pair.contact_ratio, pair.base_pitch * 1e3
    assert eps == pytest.approx(2.47, abs=0.005)
    fig, ax = plt.subplots()
    try:
        plot_load_sharing(ax, mc)
        texts = [t.get_text() for t in ax.texts]
        assert not any("STC" in t for t in texts)
        bounds = sorted(ln.get_xdata()[0] for ln in ax.lines if ln.get_linestyle() == ":")
        # a pair enters when ours is at 1, 2 base pitches, one leaves at eps - 1, eps - 2
        assert bounds == pytest.approx([x * pb_mm for x in sorted([eps - 2, 1.0, eps - 1, 2.0])],
                                       rel=1e-12)
        edges = [0.0, *bounds, eps * pb_mm]
        mids = [0.5 * (a + b) for a, b in zip(edges[:-1], edges[1:], strict=True)]
        in_contact = mc.in_contact.sum(axis=1)  # pairs the mesh has in contact at each phase
        expected = [f"{in_contact[int((x / pb_mm % 1.0) * 400)]} pairs" for x in mids]
        assert texts == expected == ["3 pairs", "2 pairs", "3 pairs", "2 pairs", "3 pairs"]
        curves = [ln for ln in ax.lines if ln.get_linestyle() == "-"]
        for x in mids:
            total = sum(np.interp(x, *ln.get_data(), left=0.0, right=0.0) for ln in curves)
            assert total == pytest.approx(1.0, rel=1e-9)
    finally:
        plt.close(fig)


def test_compliance_integration_converges():
    """Trapezoid integration over the outline: second order, 2000 points within 1e-5 of 32000.

    Measured: 1.1e-6 at 2000 and 2.7e-7 at 4000 points (error / 4 per doubling).
    """
    pair = table1_consistent()
    s = np.linspace(pair.s_start, pair.s_end, 21)
    ref = pair_compliance(pair, s, 32000)
    err_2000 = np.abs(pair_compliance(pair, s, 2000) / ref - 1).max()
    err_4000 = np.abs(pair_compliance(pair, s, 4000) / ref - 1).max()
    assert err_2000 < 1e-5
    assert 3.0 < err_2000 / err_4000 < 5.0


@pytest.mark.parametrize("gear", [1, 2])


@pytest.mark.parametrize("pair", STANDARD_PAIRS[:2], ids=lambda p: f"{p.z1}-{p.z2}")


def test_castigliano_integrals_by_quadrature(pair, gear):
    """Bending, shear and axial compliance of a tooth at five contact radii are the
    potential-energy integrals of Yang & Lin (1987) / Tian (2004) in their textbook form,
    evaluated here on their own (Simpson's rule on 200,001 points along the centre line from the
    root section to the load point, the half width x(y) read off the tooth's outline, the load
    angle beta = alpha_r - psi from the involute):

        1/k_b = int [(y_c - y) cos(beta) - x_c sin(beta)]^2 / (E b (2x)^3 / 12) dy
        1/k_s = int 1.2 cos^2(beta) / (G b 2x) dy,   1/k_a = int sin^2(beta) / (E b 2x) dy

    to 1e-4 (the code expands the square and integrates cumulatively on 2000 points: 1e-6). A
    term dropped, doubled or with another shear factor fails; the ISO band of
    ``test_stiffness_within_band_of_iso6336`` would not catch all of those (without the bending
    term the mesh stiffness is 1.14-1.22 of ISO's, inside its +-25 %)."""
    from scipy.integrate import simpson

    from gearsweep.gear.compliance import tooth_compliance
    from gearsweep.gear.geometry import involute

    prof = tooth_profile(pair, gear)
    rb = pair.base_radius1 if gear == 1 else pair.base_radius2
    rp = pair.pitch_radius1 if gear == 1 else pair.pitch_radius2
    ra = pair.tip_radius[gear - 1]
    e, b, nu = pair.youngs_modulus, pair.face_width, pair.poisson
    g_mod = e / (2.0 * (1.0 + nu))
    radii = np.linspace(max(rb, prof.root_radius) * 1.01, ra * 0.998, 5)  # on the involute
    got = tooth_compliance(pair, gear, radii)
    for i, r in enumerate(radii):
        alpha_r = math.acos(rb / r)
        psi = pair.thickness[gear - 1] / (2.0 * rp) + involute(pair.pressure_angle) \
            - involute(alpha_r)
        beta = alpha_r - psi
        xc, yc = r * math.sin(psi), r * math.cos(psi)
        cb, sb = math.cos(beta), math.sin(beta)
        y = np.linspace(prof.y0, yc, 200_001)
        x = np.interp(y - prof.y0, prof.eta, prof.half_width)
        bending = simpson(((yc - y) * cb - xc * sb) ** 2 / (e * b * (2.0 * x) ** 3 / 12.0), x=y)
        shear = simpson(1.2 * cb**2 / (g_mod * b * 2.0 * x), x=y)
        axial = simpson(sb**2 / (e * b * 2.0 * x), x=y)
        assert_allclose([got.bending[i], got.shear[i], got.axial[i]], [bending, shear, axial],
                        rtol=1e-4, err_msg=f"contact radius {r * 1e3:.3f} mm")
        assert_allclose(got.beta[i], beta, rtol=1e-12)


@settings(deadline=None, max_examples=25)
@given(
    z1=st.integers(12, 120),
    z2=st.integers(12, 120),
    x1=st.floats(-0.5, 0.8),
    x2=st.floats(-0.5, 0.8),
)


def test_any_pair_is_refused_or_meshes_sensibly(z1, z2, x1, x2):
    """Random shifted pairs: a GeometryError, or a mesh with shares summing to 1 and stiffness
    within [0.7, 1.4] of ISO 6336-1 (wider than for standard pairs: ISO's shift terms are a fit
    too; in one sample of 371 random consistent pairs the ratios spanned 0.90-1.28, median
    1.00: a sample's extremes, not bounds, see the next test)."""
    pair = GearPair(module=2e-3, z1=z1, z2=z2, face_width=20e-3, x1=x1, x2=x2)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", GeometryWarning)  # nearly pointed teeth are allowed
            mc = mesh_cycle(pair, 10.0, n=64)
    except GeometryError as err:
        assert str(err).startswith("gear pair: ")
        return
    assert_allclose(mc.load_share.sum(axis=1), 1.0, rtol=1e-12)
    assert np.all(mc.ste > 0)
    c_prime, c_gamma = iso6336_stiffness(pair)
    assert 0.7 < mc.mesh_stiffness.mean() / c_gamma < 1.4
    assert 0.7 < mc.pair_stiffness.max() / c_prime < 1.4


def test_a_pair_inside_the_random_domain_lies_outside_the_sample_s_ratios_to_iso():
    """docs/mesh.md said the model's stiffness "stays within" 0.90-1.21 of ISO's c_gamma, the
    extremes of a sample of 371 pairs; a 14/14 pair of module 3 mm with x = 0.5 / 0.5, inside the
    sampled domain, gives 1.23 and 1.31 (an outside tester), which the doc now says. Held to
    these numbers, and inside ISO_FACTOR, the bound the model is refused beyond."""
    from gearsweep.gear.mesh import ISO_FACTOR

    pair = GearPair(module=3e-3, z1=14, z2=14, face_width=30e-3, x1=0.5, x2=0.5)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", GeometryWarning)  # (its root half angles, above 0.19)
        mc = mesh_cycle(pair, 50.0)
    c_prime, c_gamma = iso6336_stiffness(pair)
    ratios = (mc.as_arrays(10)["k_harmonic"][0] / c_gamma, mc.pair_stiffness.max() / c_prime)
    assert ratios == pytest.approx((1.23, 1.31), abs=0.005)
    assert ratios[0] > 1.21 and ratios[1] > 1.28 and max(ratios) < ISO_FACTOR
    text = (Path(__file__).resolve().parent.parent / "docs" / "mesh.md").read_text()
    assert "stays within 0.90-1.21" not in text
    assert "gives 1.23\nand 1.31" in repr(text) or "gives 1.23 and 1.31" in " ".join(text.split())


def test_sainsot_s_root_half_angle_is_refused_below_its_range_and_warned_far_above():
    """Sainsot et al. fitted their gear-body term for 0.01 <= theta_f <= 0.12 rad; only the
    bore-radius ratio was checked. From the published coefficients: below 0.01 the term's P*
    (the body's own compliance) reaches zero by theta_f = 0.0077 and the term departs 22 % from
    its value at 0.01 by 0.008, so a pair there is refused (theta_f < pi / z: any gear of more
    than 314 teeth); above 0.12 it moves slowly, within 5 % of its value at 0.12 up to
    ``SAINSOT_ROOT_ANGLE_WARNED`` (0.19) and no more than 12 % out to pi / 4, so it is
    extrapolated, with a warning that says by how much beyond 0.19 only."""
    import warnings

    from gearsweep.gear.compliance import SAINSOT_COEFFICIENTS
    from gearsweep.gear.geometry import (
        SAINSOT_ROOT_ANGLE,
        SAINSOT_ROOT_ANGLE_WARNED,
        GeometryWarning,
    )

    assert SAINSOT_ROOT_ANGLE == (0.01, 0.12)

    def term(th, h):  # the foundation term's bracket over u_f / S_f and tan(beta)
        lstar, mstar, pstar, qstar = SAINSOT_COEFFICIENTS @ [1 / th**2, h * h, h / th, 1 / th,
                                                             h, 1.0]
        r, tb = np.meshgrid(np.linspace(0.3, 3, 28), np.linspace(0, 0.5, 11))
        return lstar * r**2 + mstar * r + pstar * (1 + qstar * tb**2)

    def departs(th, edge):
        return max(float(np.max(np.abs(term(th, h) / term(edge, h) - 1)))
                   for h in np.linspace(1.4, 7, 29))

    assert (SAINSOT_COEFFICIENTS[2] @ [1 / 0.0076**2, 1.96, 1.4 / 0.0076, 1 / 0.0076, 1.4, 1]) < 0
    assert departs(0.008, 0.01) > 0.2
    assert departs(SAINSOT_ROOT_ANGLE_WARNED, 0.12) < 0.05 < departs(0.2, 0.12)
    assert departs(math.pi / 4, 0.12) < 0.12

    with pytest.raises(GeometryError, match=r"gear 2 root half angle theta_f = (\S+) rad \(400"
                                            r" teeth\), outside 0.01 to 0.12 rad") as info:
        mesh_cycle(GearPair(module=1e-3, z1=30, z2=400, face_width=20e-3), 50.0)
    theta = float(re.search(r"theta_f = (\S+) rad", str(info.value)).group(1))
    assert theta < math.pi / 400 < 0.01

    with warnings.catch_warnings():  # z1 = 20: theta_f = 0.135, within 1.5 % of the fit: silent
        warnings.simplefilter("error")
        GearPair(module=2e-3, z1=20, z2=40, face_width=20e-3).check()
    # z1 = 12, x1 = 0.5, default fillet 0.38 m: root below the base circle, so the fillet is
    # tangent to the radial flank: theta_f = psi_b + asin(rho / (r_f + rho))
    m, z, x, alpha = 2e-3, 12, 0.5, math.radians(20.0)
    rf, rho = m * (z / 2 - 1.25 + x), 0.38 * m
    theta = ((math.pi / 2 + 2 * x * math.tan(alpha)) / z + math.tan(alpha) - alpha
             + math.asin(rho / (rf + rho)))
    with pytest.warns(GeometryWarning) as said:
        GearPair(module=m, z1=z, z2=40, face_width=20e-3, x1=x).check()
    assert len(said) == 1 and said[0].message.fields[:2] == ("z1", "x1")
    assert (f"gear 1 root half angle theta_f = {theta:.3g} rad is {theta - 0.12:.2g} rad above the"
            " 0.01 to 0.12 rad") in str(said[0].message)


def test_iso6336_values_take_iso_s_low_load_rule_per_torque():
    """ISO 6336-1 scales c' (and so c_gamma) by (F_t K_A / b / 100 N/mm)^0.25 where the line load
    is below 100 N/mm; it was left out (only a docstring said so) while the mesh study labelled
    its variables ISO's c' and c_gamma, one value over a torque sweep (an outside tester).
    Table 1 at 50 N m: F_t = 50 N m / 60 mm (the reference radius, m z1 / 2) = 833.3 N on
    10 mm, 83.3 N/mm, so c_gamma = 207.77 x 0.9554 = 198.5 kN/mm (the hand value of
    test_iso6336_hand_value times ISO's factor, K_A = 1); at 200 N m (333 N/mm) unscaled."""
    pair = table1_consistent()
    w = 50.0 / (2.5e-3 * 48 / 2) / 10.0  # [N/mm]
    factor = (w / 100.0) ** 0.25
    assert factor == pytest.approx(0.9554, abs=1e-4)
    c_prime, c_gamma = iso6336_stiffness(pair, torque=50.0)
    assert c_prime == pytest.approx(135.74e6 * factor, rel=1e-4)
    assert c_gamma == pytest.approx(207.77e6 * factor, rel=1e-4)
    assert c_gamma == pytest.approx(198.5e6, rel=2e-4)
    assert iso6336_stiffness(pair, torque=200.0)[1] == pytest.approx(207.77e6, rel=1e-4)
    swept = iso6336_stiffness(pair, torque=np.array([5.0, 50.0, 200.0]))[1]
    assert_allclose(swept, 207.77e6 * np.minimum((np.array([5.0, 50.0, 200.0]) / 0.06 / 10.0
                                                  / 100.0) ** 0.25, 1.0), rtol=1e-4)
    # the compliance model's plausibility bound is load-independent (k is, for unmodified
    # teeth): it keeps ISO's value at 100 N/mm or more, so a light load is not refused
    # (at 1 N m ISO's low-load c_gamma is 75 kN/mm, ours 219: 2.9 times)
    assert mesh_cycle(pair, 1.0).mesh_stiffness.mean() == pytest.approx(
        mesh_cycle(pair, 50.0).mesh_stiffness.mean(), rel=1e-12)


def test_a_mesh_study_s_iso_values_are_per_torque(tmp_path):
    """Over a swept torque the mesh study's iso_single_stiffness and iso_mesh_stiffness are one
    value per torque (dims variant, torque), ISO's at that torque's line load (above)."""
    import gearsweep

    text = ("type: mesh\ntitle: iso\ngears: {a: table1_consistent, b: table1_profile_shift}\n"
            "sweep: {torque: [5 N*m, 50 N*m, 200 N*m]}\npositions: 16\nharmonics: 2\n")
    ds = gearsweep.run(text)
    assert ds.iso_mesh_stiffness.dims == ("variant", "torque")
    assert ds.iso_mesh_stiffness.attrs["units"] == "kN mm-1"
    factor = np.minimum((np.array([5.0, 50.0, 200.0]) / 0.06 / 10.0 / 100.0) ** 0.25, 1.0)
    assert_allclose(ds.iso_mesh_stiffness.sel(variant="a").values, 207.77 * factor, rtol=1e-4)
    assert_allclose(ds.iso_single_stiffness.sel(variant="a").values, 135.74 * factor, rtol=1e-4)
    ratio = ds.iso_mesh_stiffness.sel(variant="b") / ds.iso_mesh_stiffness.sel(variant="b",
                                                                                  torque=200.0)
    assert_allclose(ratio.values, factor, rtol=1e-12)  # same reference radius, 60 mm

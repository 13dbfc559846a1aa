"""Floquet multipliers, the stability polynomials and the integrator guard rail against
independent truth: exponentials, Mathieu characteristic values (scipy), perturbation theory."""

from fractions import Fraction
from math import factorial

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.special import mathieu_a, mathieu_b

from gearsweep.analysis import stability as st
from gearsweep.api import run_study
from gearsweep.errors import GearsweepError, StepLimitWarning
from gearsweep.kernels import simulate
from gearsweep.kernels.floquet import floquet, mathieu_parameters, monodromy, paper_criterion
from gearsweep.study.plan import make_plan
from gearsweep.study.schema import parse_study


def _bisect(flag, lo, hi, n=40):
    """Vectorised bisection on a boolean ``flag(x)`` that differs at ``lo`` and ``hi``."""
    lo, hi = np.array(lo, float), np.array(hi, float)
    f_lo = flag(lo)
    if np.any(f_lo == flag(hi)):
        raise RuntimeError("bracket does not straddle the transition")
    for _ in range(n):
        mid = 0.5 * (lo + hi)
        same = flag(mid) == f_lo
        lo = np.where(same, mid, lo)
        hi = np.where(same, hi, mid)
    return 0.5 * (lo + hi)


# --- stability polynomials ---------------------------------------------------------------


@pytest.mark.parametrize("method,order", [("rk4", 4), ("rk5", 5)])
def test_polynomial_matches_exponential_to_order(method, order):
    """A method of order p has R(z) = e^z + O(z^(p+1)): the coefficients are 1/k! up to p."""
    c = st.stability_polynomial(method)
    assert all(isinstance(x, Fraction) for x in c)
    assert c[: order + 1] == tuple(Fraction(1, factorial(k)) for k in range(order + 1))


def test_rk5_sixth_coefficient_is_product_of_subdiagonal():
    """For six stages b^T A^5 1 = b6 a65 a54 a43 a32 a21 = (7/90)(8/7)(9/16)(1)(1/8)(1/4)."""
    assert st.stability_polynomial("rk5")[6] == Fraction(1, 640)
    assert len(st.stability_polynomial("rk4")) == 5


@pytest.mark.parametrize("method", ["rk4", "rk5"])
@pytest.mark.parametrize("zeta", [0.0, 0.3, 2.0])
def test_kernel_one_step_map_is_stability_polynomial(method, zeta):
    """The kernel's one-step matrix for p'' + 2 zeta w p' + w^2 p = 0 has eigenvalues
    R(h lambda) (to rounding, 1e-13)."""
    w, h = 3.0, 0.37
    res = simulate(np.full(2, h), method=method, damping=2 * zeta * w, k_mean=w * w,
                   x0=[1.0, 0.0], v0=[0.0, 1.0], n_transient=1, n_record=0, steps_per_period=1)
    P = np.array([res.x_final, res.v_final])
    lam = np.roots([1.0, 2 * zeta * w, w * w])
    expect = np.sort_complex(st.amplification(method, h * lam))
    assert_allclose(np.sort_complex(np.linalg.eigvals(P)), expect, rtol=0, atol=1e-13)


def test_undamped_rk4_limit_is_two_sqrt_two():
    """|R(iy)|^2 = 1 - y^6/72 + y^8/576 for RK4: unit modulus again at y^2 = 8."""
    assert_allclose(st.step_limit_hw("rk4", 0.0), 2 * np.sqrt(2), rtol=1e-12)
    assert_allclose(abs(st.amplification("rk4", 2j * np.sqrt(2))), 1.0, rtol=1e-14)


@pytest.mark.parametrize("method", ["rk4", "rk5"])
@pytest.mark.parametrize("zeta", [0.0, 0.05, 0.3, 0.8, 1.5])
def test_predicted_step_limit_matches_integration(method, zeta):
    """Integrating the oscillator stays bounded at 0.99 of the predicted h w_n limit and
    diverges at 1.01 of it (the 1 % tolerance of the issue).

    N steps from (1, 1) with a bound of 10: growth is detected once |R|^N > 10. The slowest case is
    RK5 undamped, where |R| - 1 ~ 1.3e-6 at 1.01 x 0.852 (computed from the exact polynomial):
    N = 4e6 steps grow by exp(5) > 10 there.
    """
    hw = float(st.step_limit_hw(method, zeta))
    n = 4_000_000 if (method == "rk5" and zeta == 0.0) else 200_000
    res = simulate(np.array([0.99, 1.01]) * hw, method=method, damping=2 * zeta, k_mean=1.0,
                   bound=10.0, x0=1.0, v0=1.0, n_transient=n, n_record=0, steps_per_period=1000)
    assert list(res.status) == [0, 1]


def test_max_stable_step_and_check_step_si():
    """SI form: h* = (h w_n)* / w_n; check_step's limit brackets the stable step count."""
    k_over_m, c_over_m, T = 1073e6 / 0.1527, 5500 / 0.1527, 1 / 160.0
    wn = np.sqrt(k_over_m)
    zeta = c_over_m / (2 * wn)
    h = st.max_stable_step("rk5", k_over_m, c_over_m)
    assert_allclose(h * wn, st.step_limit_hw("rk5", zeta), rtol=1e-14)
    ok, limit = st.check_step("rk5", [10, 10_000], T, k_over_m, c_over_m)
    assert list(ok) == [False, True]
    assert T / limit[0] <= h < T / (limit[0] - 1)
    with pytest.raises(st.UnstableStepError, match="too coarse"):
        st.require_stable_step("rk5", 10, T, k_over_m, c_over_m)
    with pytest.raises(GearsweepError):
        st.stability_polynomial("euler")


# --- Floquet multipliers ----------------------------------------------------------------


def test_constant_coefficient_multiplier_is_exponential():
    """beta = 0: M = exp(2 pi J), so the largest |mu| = max |exp(2 pi lambda)| (to 1e-10)."""
    alpha = np.array([0.3, 1.0, 2.2, -0.2, 0.5, 0.01])
    gamma = np.array([0.0, 0.01, 0.3, 0.1, 2.0, 0.0])
    res = floquet(alpha, 0.0, gamma, rtol=1e-12)
    disc = np.sqrt((gamma**2 / 4 - alpha).astype(complex))
    expect = np.maximum(abs(np.exp(2 * np.pi * (-gamma / 2 + disc))),
                        abs(np.exp(2 * np.pi * (-gamma / 2 - disc))))
    assert res.converged.all()
    assert_allclose(res.multiplier, expect, rtol=1e-10)
    assert np.all(res.error < 1e-10 * expect)


@pytest.mark.parametrize("rtol", [1e-4, 1e-6, 1e-8])
def test_error_estimate_is_the_size_of_the_actual_error(rtol):
    """The stored Richardson error of |mu| is the true error of the constant case, where mu is
    exp(2 pi lambda) in closed form: measured estimate / true error 0.86-1.02 at these
    tolerances (the estimate is of the finer solution's error, so it tends to 1, not above it:
    an estimate, not a bound). Bounds 0.75-1.33 fail an estimate off by a factor of 2, or by
    RK5's 2**5 - 1 = 31 (the coarse solution's error instead of the fine one's)."""
    alpha = np.array([0.3, 0.7, 1.2, 1.9, 2.5])
    res = floquet(alpha, 0.0, 0.05, rtol=rtol)
    lam = -0.025 + 1j * np.sqrt(alpha - 0.025**2)
    true = abs(res.multiplier - abs(np.exp(2 * np.pi * lam)))
    assert np.all(true > 1e-14), "errors at rounding level say nothing of the estimate"
    assert_allclose(res.error / true, 1.0, rtol=0.33)
    assert np.all(res.error / true > 0.75)


def test_undamped_tongue_boundaries_match_mathieu_characteristic_values():
    """p'' + (alpha + beta cos tau) p = 0 is y'' + (a - 2 q cos 2z) y = 0 with tau = 2z,
    a = 4 alpha, q = -2 beta (the sign of q does not matter); the transition curves are
    alpha = a_n(q)/4 and b_n(q)/4. Bisection to 1e-12 on the converged flag mu > 1 + 1e-8 (which
    moves an edge by ~ (1e-8)^2 / slope, nothing); scipy's
    characteristic values at q <= 1 agree to 1e-6 (the issue's tolerance)."""
    beta = np.array([0.1, 0.25, 0.5])
    q = 2 * beta
    curves = {"a0": mathieu_a(0, q) / 4}
    for n in (1, 2, 3):
        curves[f"b{n}"] = mathieu_b(n, q) / 4
        curves[f"a{n}"] = mathieu_a(n, q) / 4
    allc = np.array(list(curves.values()))  # (7 curves, 3 betas)
    # bracket: a quarter of the distance to the nearest other curve (at most 0.01) each side;
    # _bisect checks that the stability flag really differs at the two ends
    dist = np.abs(allc[:, None, :] - allc[None, :, :])
    dist[np.arange(7), np.arange(7)] = np.inf
    d = np.minimum(0.25 * dist.min(axis=1), 0.01)
    b = np.broadcast_to(beta, allc.shape).ravel()
    edge = _bisect(lambda al: floquet(al, b, 0.0, rtol=1e-11, tol=1e-8, spp_max=2048).unstable,
                   (allc - d).ravel(), (allc + d).ravel())
    assert_allclose(edge.reshape(allc.shape), allc, rtol=0, atol=1e-6)


def test_damping_is_exact_exponential_factor():
    """p = exp(-gamma tau / 2) y turns the damped equation into the undamped one with
    alpha - gamma^2/4: mu(alpha, beta, gamma) = exp(-pi gamma) mu(alpha - gamma^2/4, beta, 0)."""
    rng = np.random.default_rng(5)
    alpha = rng.uniform(-0.3, 3.0, 40)
    beta = rng.uniform(0.0, 2.0, 40)
    gamma = rng.uniform(0.0, 0.5, 40)
    damped = floquet(alpha, beta, gamma, rtol=1e-11)
    undamped = floquet(alpha - gamma**2 / 4, beta, 0.0, rtol=1e-11)
    expect = np.exp(-np.pi * gamma) * undamped.multiplier
    assert_allclose(damped.multiplier, expect, rtol=1e-8)


@pytest.mark.parametrize("gamma", [0.01, 0.02])
def test_damped_principal_tongue_threshold(gamma):
    """Near alpha = 1/4 the undamped y-equation grows as exp(s tau) with
    s = sqrt(beta^2 - 4 (alpha - 1/4)^2) / 2 (first-order averaging; the tongue edges are
    alpha = 1/4 +- beta/2). The damped solution is exp(-gamma tau / 2) y, so instability needs
    s > gamma / 2, i.e. beta > beta_c = sqrt(gamma^2 + 4 (alpha - 1/4)^2): beta_c = gamma at
    the tip (2 gamma sqrt(alpha) in Landau's form). At alpha = 1/4 the neglected terms
    (the gamma^2/4 shift and the -beta^2/8 bend of the tongue) change beta_c by O(gamma^2)
    relative: 1e-3 is a generous bound. At alpha = 1/4 +- gamma the bend is an O(gamma) relative
    change of opposite sign on each side: 1 gamma (1 % at gamma = 0.01) is the tolerance."""
    alpha = np.array([0.25, 0.25 - gamma, 0.25 + gamma])
    bc = _bisect(lambda b: floquet(alpha, b, gamma, rtol=1e-11, tol=1e-9).unstable,
                 np.zeros(3), np.full(3, 0.5))
    pred = np.sqrt(gamma**2 + 4 * (alpha - 0.25) ** 2)
    assert abs(bc[0] / pred[0] - 1) < 1e-3
    assert_allclose(bc[1:], pred[1:], rtol=gamma)
    assert bc[1] < pred[1] < bc[2]  # the tongue bends to lower alpha: -beta^2/8


def test_damping_shrinks_every_tongue():
    """At beta = 0.6 (q = 1.2), over alpha in [-0.3, 2.6]: every point unstable with
    gamma = 0.01 is unstable without damping, and each of the resonance tongues 1..3 loses points
    (windows between the tongues placed with the characteristic values; step 1e-4 in alpha).

    The region alpha < a0/4 is a static divergence, not a resonance: at beta = 0 its edge alpha = 0
    does not depend on damping at all, and at beta = 0.6 the gamma^2/4 shift and the e^(-pi gamma)
    factor move its edge by less than the grid step; only the subset property is checked there."""
    q = 1.2
    alpha = np.linspace(-0.3, 2.6, 29001)
    u0 = floquet(alpha, q / 2, 0.0).unstable
    u1 = floquet(alpha, q / 2, 0.01).unstable
    assert not np.any(u1 & ~u0)
    cuts = [-0.3, (mathieu_a(0, q) + mathieu_b(1, q)) / 8, (mathieu_a(1, q) + mathieu_b(2, q)) / 8,
            (mathieu_a(2, q) + min(mathieu_a(3, q), mathieu_b(3, q))) / 8, 2.6]
    for lo, hi in zip(cuts[1:-1], cuts[2:], strict=True):
        sel = (alpha >= lo) & (alpha < hi)
        assert u0[sel].sum() > u1[sel].sum(), (lo, hi)  # tongue 3 (0.013 wide) vanishes
        assert u0[sel].sum() > 0


def test_monodromy_from_si_equals_mathieu_form():
    """mathieu_parameters: Eq. (12) numbers for the paper's rig at 200 rpm of the 48-tooth gear
    (mesh frequency 160 Hz): alpha = k0 / (m (2 pi 160)^2)."""
    a, b, g = mathieu_parameters(1073e6, 179e6, 0.1527, 5500.0, 48 * 200 / 60)
    Nw = 2 * np.pi * 160.0
    assert_allclose([a, b, g], [1073e6 / 0.1527 / Nw**2, 179e6 / 0.1527 / Nw**2,
                                5500 / 0.1527 / Nw], rtol=1e-15)
    assert 6900 < a < 7000


def test_integrator_instability_is_told_apart():
    """At alpha = 7000 (the rig at 200 rpm) the equation is stable (converged Floquet); with
    S = 200 steps per period RK5 has h w_n = 2 pi sqrt(7000) / 200 = 2.63 > 0.852 (undamped limit):
    the discrete map grows and the paper's criterion reports instability; integrator_unstable
    flags it; a step within the limit (S = 800) reports stable."""
    alpha, beta, gamma = 7000.0, 7000.0 * 179 / 1073, 0.0
    fl = floquet(alpha, beta, gamma)
    assert not fl.unstable
    flag, disc = st.integrator_unstable(alpha, beta, gamma, 200, floquet=fl)
    assert flag and disc > 1
    assert paper_criterion(alpha, beta, gamma, 200, n_periods=200)
    assert not paper_criterion(alpha, beta, gamma, 800, n_periods=200)
    flag, disc = st.integrator_unstable(alpha, beta, gamma, 800, floquet=fl)
    assert not flag


def test_paper_criterion_sees_a_real_tongue():
    """Inside the principal tongue (alpha = 1/4, beta = 0.3: mu = exp(2 pi 0.15) ~ 2.6 per
    period) the fixed-step criterion agrees with Floquet at a resolving step."""
    assert paper_criterion(0.25, 0.3, 0.0, 64, n_periods=50)
    assert floquet(0.25, 0.3, 0.0).unstable
    assert not paper_criterion(0.6, 0.3, 0.05, 64, n_periods=50)


def test_monodromy_determinant_is_liouville():
    """det M = exp(-2 pi gamma) for any alpha, beta (Liouville's formula), at a resolved step."""
    M = monodromy([0.3, 1.7, -0.1], [0.5, 1.2, 0.9], [0.0, 0.1, 0.4], 1024)
    assert_allclose(np.linalg.det(M), np.exp(-2 * np.pi * np.array([0.0, 0.1, 0.4])), rtol=1e-11)


# --- the study layer's ``floquet`` output ----------------------------------------------------

MATHIEU_STUDY = """
title: tiny Strutt chart
scene: {kind: mathieu}
sweep:
  alpha: [0.25, 0.6, 1.0]
  beta: [0.0, 0.3]
  gamma: [0.0, 0.02]
solver: {method: rk5, steps_per_period: 64, transient_periods: 20, record_periods: 1,
         initial_displacement: 1.0}
outputs: [floquet]
"""

RIG_STUDY = """
title: rig at two speeds, coarse step
scene:
  kind: whine
  mass: 0.1527 kg
  teeth: 48
  stiffness: 1073 kN/mm
  stiffness_harmonics: [{amplitude: 179 kN/mm}]
sweep:
  speed: [150 rpm, 1500 rpm]
  damping: [0 N*s/m, 5.5 N*s/mm]
solver: {method: rk5, steps_per_period: 200, transient_periods: 100, record_periods: 1,
         divergence_factor: 1000, initial_displacement: 1 um}
outputs: [stats, floquet]
"""


def test_floquet_output_of_a_mathieu_study_matches_direct_analysis():
    """The runner's floquet_multiplier / unstable equal a tighter ``floquet`` on the same grid
    (the output converges to rtol 1e-8: 5e-8 allows the Richardson estimate's slack), and the
    paper's criterion (status 1) fires only where the equation is unstable."""
    from gearsweep.api import run_study
    from gearsweep.study.schema import parse_study

    ds = run_study(parse_study(MATHIEU_STUDY))
    A, B, G = np.meshgrid(ds.alpha, ds.beta, ds.gamma, indexing="ij")
    direct = floquet(A, B, G, rtol=1e-11)
    mu = ds["floquet_multiplier"].transpose("alpha", "beta", "gamma").values
    assert_allclose(mu, direct.multiplier, rtol=5e-8)
    unst = ds["unstable"].transpose("alpha", "beta", "gamma").values
    assert np.array_equal(unst, direct.unstable)
    assert unst[0, 1, 0]  # alpha = 1/4, beta = 0.3: inside the principal tongue
    diverged = (ds["status"] == 1).transpose("alpha", "beta", "gamma").values
    assert not np.any(diverged & ~unst)
    assert not ds["integrator_unstable"].any()


def test_the_unstable_threshold_is_the_number_the_flags_compare_against(tmp_path):
    """``unstable`` and ``integrator_unstable`` carry their ``threshold`` as a number, the one
    ``compute`` compares against (1 + UNSTABLE_TOL): it was the string '1 + 1e-06', so that
    ``ds.floquet_multiplier > ds.unstable.attrs['threshold']`` raised (an outside tester's
    finding). Read back from a written file."""
    import xarray as xr

    from gearsweep.api import run_study
    from gearsweep.kernels.floquet import UNSTABLE_TOL
    from gearsweep.study.dataset import write_netcdf
    from gearsweep.study.schema import parse_study

    write_netcdf(run_study(parse_study(MATHIEU_STUDY)), tmp_path / "m.nc")
    ds = xr.load_dataset(tmp_path / "m.nc")
    for name in ("unstable", "integrator_unstable"):
        assert float(ds[name].attrs["threshold"]) == 1.0 + UNSTABLE_TOL
    above = ds["floquet_multiplier"] > ds["unstable"].attrs["threshold"]
    assert above.any() and (above == ds["unstable"].astype(bool)).all()


def test_an_undriven_scene_is_never_not_settled_and_its_status_follows_floquet():
    """A Strutt chart written from the reference with the solver's defaults (the settle test's
    tolerance 0.01 over 50 recorded periods) came back 1799 of 1800 flagged: decaying (stable)
    cases as 'not settled', slowly growing ones too. An undriven scene has no steady state to
    settle into: status is 0 or 1 (grown past divergence_factor), and 1 only where Floquet says
    the equation is unstable; every stable case is 0."""
    from gearsweep.api import run_study
    from gearsweep.study.schema import parse_study

    ds = run_study(parse_study("""
title: Strutt chart, defaults
scene: {kind: mathieu, gamma: 0.02}
sweep:
  alpha: {start: 0.05, stop: 1.5, num: 12}
  beta: {start: 0.0, stop: 0.6, num: 7}
outputs: [floquet]
"""))
    status = ds["status"].values
    unstable = ds["unstable"].values
    assert set(np.unique(status)) <= {0, 1} and (status == 1).any() and (status == 0).any()
    assert not np.any((status == 1) & ~unstable)  # the paper's criterion only where unstable
    assert np.all(status[~unstable] == 0)  # a stable case decays: it is never flagged


def test_floquet_output_flags_the_integrator_on_the_rig():
    """150 rpm at 200 steps per period: h w_n = 2 pi 13342 / (120 x 200) = 3.5 is past every
    RK5 limit, so the run diverges (status 1) while the equation is stable: integrator_unstable,
    and min_steps_per_period is above 200. At 1500 rpm (h w_n = 0.35) nothing is flagged."""
    from gearsweep.api import run_study
    from gearsweep.study.schema import parse_study

    with pytest.warns(StepLimitWarning, match=r"^<study>: 2 case\(s\) use a step beyond"):
        ds = run_study(parse_study(RIG_STUDY))  # the guard sees the 150 rpm cases too
    slow, fast = ds.sel(speed=150.0), ds.sel(speed=1500.0)
    assert not ds["unstable"].any()
    assert slow["integrator_unstable"].all() and (slow["status"] == 1).all()
    assert (slow["min_steps_per_period"] > 200).all()
    assert not fast["integrator_unstable"].any() and (fast["status"] == 0).all()
    assert (fast["min_steps_per_period"] < 200).all()
    fmesh = 48 * 150 / 60
    damping = ds.damping.values * 1e3  # the file's N s/mm in SI
    assert ds.damping.attrs["units"] == "N s mm-1"
    a, b, g = mathieu_parameters(1073e6, 179e6, 0.1527, damping, fmesh)
    assert_allclose(slow["floquet_multiplier"], floquet(a, b, g, rtol=1e-11).multiplier,
                    rtol=5e-8)


def test_skipped_cases_are_not_computed_and_their_flags_say_so():
    """With ``step_guard: skip`` the 150 rpm cases are skipped (status 3), floquet_multiplier
    NaN; ``unstable`` and ``integrator_unstable`` (booleans: no missing value) are false there,
    which read as "stable" (an outside tester's finding): their long_names say so."""
    from gearsweep.api import run_study
    from gearsweep.study.schema import parse_study

    ds = run_study(parse_study(RIG_STUDY.replace("solver: {", "solver: {step_guard: skip, ", 1)))
    slow = ds.sel(speed=150.0)
    assert (slow["status"] == 3).all() and slow["floquet_multiplier"].isnull().all()
    assert not slow["unstable"].any() and not slow["integrator_unstable"].any()
    for name in ("unstable", "integrator_unstable"):
        assert "false also where floquet_multiplier is NaN" in ds[name].attrs["long_name"]


def test_a_skipped_case_keeps_its_min_steps_per_period():
    """``step_guard: skip`` left ``min_steps_per_period`` NaN for exactly the cases it skips,
    whose user needs that number most (an outside tester's finding: ``off`` gave them 216-1328
    on the rig): a skipped case has the value ``step_guard: off`` computes, above its steps."""
    from gearsweep.api import run_study
    from gearsweep.study.schema import parse_study

    skip = run_study(parse_study(RIG_STUDY.replace("solver: {", "solver: {step_guard: skip, ", 1)))
    off = run_study(parse_study(RIG_STUDY.replace("solver: {", "solver: {step_guard: off, ", 1)))
    assert (skip["status"].sel(speed=150.0) == 3).all()
    limit = skip["min_steps_per_period"]
    assert limit.notnull().all() and (limit.sel(speed=150.0) > 200).all()
    np.testing.assert_array_equal(limit.values, off["min_steps_per_period"].values)
    assert "skips" in limit.attrs["long_name"]


def test_a_stability_map_of_a_users_own_result_has_its_units_teeth_and_ticks():
    """plot_operating_map, given a 30-tooth result's arrays, said '48 teeth', had no speed tick
    labels outside the paper's 100-2000 rpm, and drew the file's N s/mm as N s/m (1000 times
    too small). plot_stability_map takes the Dataset and reads its units and teeth."""
    import matplotlib

    matplotlib.use("Agg")
    from gearsweep.api import run_study
    from gearsweep.plot.stability import plot_stability_map
    from gearsweep.study.schema import parse_study

    text = RIG_STUDY.replace("teeth: 48", "teeth: 30").replace(
        "speed: [150 rpm, 1500 rpm]", "speed: {start: 3000 rpm, stop: 30000 rpm, num: 4,"
        " spacing: log}").replace("damping: [0 N*s/m, 5.5 N*s/mm]",
                                  "damping: [0 N*s/m, 1 N*s/mm, 5 N*s/mm]")
    ds = run_study(parse_study(text.replace("steps_per_period: 200", "steps_per_period: 400")))
    fig = plot_stability_map(ds, "unstable", title="mine")
    ax = fig.axes[0]
    assert ax.get_xlabel() == "speed of the driving gear (30 teeth) [rpm]"
    # N s/mm, as the file and the label (one row per computed damping)
    assert [x.get_text() for x in ax.get_yticklabels()] == ["0", "1", "5"]
    ticks = [t for t in ax.get_xticks() if 3000 <= t <= 30000]
    assert ticks == [3000, 5000, 10000, 20000, 30000]
    with pytest.raises(ValueError, match="select the other dims first"):
        plot_stability_map(ds.expand_dims(torque=[1.0, 2.0]), "unstable")
    # a result without damping (or speed) was told to select them: ds.sel(speed=..., damping=...)
    with pytest.raises(ValueError, match=r"'unstable' has no damping dim \(dims \('speed',\)\)"
                                         r"; give a result of a study sweeping both"):
        plot_stability_map(ds.isel(damping=0), "unstable")


def test_a_stability_map_claims_no_damping_it_did_not_compute():
    """With dampings 0 and 2 N s/mm and the c = 0 cells flagged, the map drew them up to 1 N s/mm
    (cells reaching halfway to the next computed value), a damping never computed, on an axis
    ticked 0 and 1. Each computed damping is now one row, ticked with its value: every tick
    within a flagged cell is a computed damping, that cell's own."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import xarray as xr
    from matplotlib.collections import QuadMesh

    from gearsweep.plot.stability import plot_stability_map

    speed = np.array([100.0, 200.0, 400.0])
    ds = xr.Dataset({"unstable": (("damping", "speed"), np.array([[1, 1, 0], [0, 0, 0]], bool))},
                    coords={"speed": speed,
                            "damping": ("damping", [0.0, 2.0], {"units": "N s mm-1"})})
    fig = plot_stability_map(ds)
    ax = fig.axes[0]
    (mesh,) = [c for c in ax.collections if isinstance(c, QuadMesh)]
    y = mesh.get_coordinates()[:, 0, 1]  # the row edges
    ticks = dict(zip(ax.get_yticks(), (x.get_text() for x in ax.get_yticklabels()), strict=True))
    lo, hi = ax.get_ylim()
    assert set(ticks.values()) == {"0", "2"}
    inside = [label for tick, label in ticks.items() if y[0] <= tick <= y[1] and lo <= tick <= hi]
    assert inside == ["0"]  # the flagged row holds c = 0 and no other damping
    from gearsweep.plot.stability import damping_row  # the row of a damping, to draw on the map

    assert damping_row(np.array([0.0, 2000.0]), 2000.0) == 1
    with pytest.raises(ValueError, match="no row for c = 1 N s/mm: its dampings are 0, 2 N s/mm"):
        damping_row(np.array([0.0, 2000.0]), 1000.0)
    plt.close(fig)


@pytest.mark.parametrize("method,c", [("rk5", 5500.0), ("rk4", 5500.0), ("rk5", 200.0)])
def test_integrator_edge_of_a_constant_stiffness_is_the_stability_polynomials_limit(method, c):
    """With the stiffness ripple off the fixed-step map over a mesh period is R(h lambda)^S,
    so its edge is where h omega_n reaches the stability polynomial's limit at the case's
    damping ratio (``step_limit_hw``, from the polynomial's roots, not from the kernel):
    speed = 60 omega_n / (teeth S (h omega_n)*)."""
    k0, m, teeth, spp = 1073e6, 0.1527, 48, 200
    wn = np.sqrt(k0 / m)
    want = 60.0 * wn / (teeth * spp * float(st.step_limit_hw(method, c / (2 * np.sqrt(k0 * m)))))
    got = st.integrator_edge((0.5 * want, 2.0 * want), k0=k0, k1=0.0, mass=m, teeth=teeth,
                             damping=c, steps_per_period=spp, method=method, tol=1e-12)
    assert got == pytest.approx(want, rel=1e-7)


def test_integrator_edge_lies_between_the_grids_last_flagged_speed_and_the_next():
    """The rig (k1 = 179 kN/mm) at c = 5.5 N s/mm and RK5 at 200 steps: the map diverges at the
    grid's 165.6 rpm and not at 170.9 rpm; the edge is between them, where the multiplier is
    1 + tol; and two speeds on one side are refused."""
    rig = dict(k0=1073e6, k1=179e6, mass=0.1527, teeth=48, damping=5500.0, steps_per_period=200)
    edge = st.integrator_edge((165.6, 170.93), **rig)
    assert 165.6 < edge < 170.93
    for speed, unstable in ((edge * 0.999, True), (edge * 1.001, False)):
        a, b, g = mathieu_parameters(1073e6, 179e6, 0.1527, 5500.0, 48 * speed / 60)
        mu = st.largest_multiplier(monodromy(a, b, g, 200, method="rk5"))[0]
        assert (mu > 1 + 1e-6) == unstable
    with pytest.raises(ValueError, match="does not cross"):
        st.integrator_edge((100.0, 150.0), **rig)


CONTINUED_RIG = """
title: rig through its principal tongue (mesh frequency twice the natural one), both sweeps
scene:
  kind: whine
  mass: 0.1527 kg
  teeth: 48
  stiffness: 1073 kN/mm
  stiffness_harmonics: [{amplitude: 179 kN/mm}]
sweep:
  damping: [0 N*s/m, 0.1 N*s/mm]
  speed: [20000 rpm, 31000 rpm, 33354 rpm, 36000 rpm, 50000 rpm]
continuation: [up, down]
solver: {method: rk5, steps_per_period: 64, transient_periods: 4, record_periods: 2,
         initial_displacement: 1 um}
outputs: [stats, floquet]
"""


def _monodromy_ivp(k0, k1, m, c, omega):
    """Largest |mu| of m p'' + c p' + (k0 + k1 cos(omega t)) p = 0 over t in [0, 2 pi / omega],
    the variational system integrated by scipy (DOP853, rtol 1e-12), independent of the kernels."""
    from scipy.integrate import solve_ivp

    def rhs(t, y):
        return [y[1], -(c * y[1] + (k0 + k1 * np.cos(omega * t)) * y[0]) / m]

    T = 2 * np.pi / omega
    cols = [solve_ivp(rhs, (0, T), y0, method="DOP853", rtol=1e-12, atol=1e-14).y[:, -1]
            for y0 in ([1.0, 0.0], [0.0, omega])]  # second column in units of 1/omega
    M = np.array(cols).T / [1.0, omega]  # columns: (p, p') at T from (1, 0) and (0, 1)
    return np.abs(np.linalg.eigvals(M)).max()


def test_continued_sweeps_compute_floquet_once_and_both_directions_agree(monkeypatch):
    """With ``continuation: [up, down]`` the floquet output was computed speed by speed for both
    sweeps (30x the cost of the same study without continuation); the multipliers depend on the
    case only. Now each distinct case is computed once, up and down carry the same values, equal
    to the study without continuation, and to the monodromy matrix of scipy's integration of the
    variational equations (unstable in the principal tongue, 33354 rpm: N w = 2 w_n)."""
    from gearsweep.api import run_study
    from gearsweep.study import outputs
    from gearsweep.study.schema import parse_study

    sizes = []
    real = outputs.floquet

    def counting(a, *args, **kw):
        sizes.append(np.size(a))
        return real(a, *args, **kw)

    monkeypatch.setattr(outputs, "floquet", counting)
    ds = run_study(parse_study(CONTINUED_RIG))
    assert sizes[-1] == 2 * 5 and sum(sizes[:-1]) <= 1  # the warm-up's trial, then 2 x 5 cases
    monkeypatch.undo()
    plain = run_study(parse_study(CONTINUED_RIG.replace("continuation: [up, down]\n", "")))
    names = ["floquet_multiplier", "floquet_error", "unstable", "discrete_multiplier",
             "integrator_unstable", "min_steps_per_period"]
    for name in names:
        up, down = ds[name].sel(direction="up"), ds[name].sel(direction="down")
        assert np.array_equal(up.values, down.values, equal_nan=True), name
        assert np.array_equal(up.transpose(*plain[name].dims).values, plain[name].values,
                              equal_nan=True), name
    mu = ds["floquet_multiplier"].sel(direction="down")
    for c in ds.damping.values:
        for rpm in ds.speed.values:
            truth = _monodromy_ivp(1073e6, 179e6, 0.1527, c * 1e3, 48 * rpm * 2 * np.pi / 60)
            assert_allclose(mu.sel(damping=c, speed=rpm), truth, rtol=1e-7)
    unstable = ds["unstable"].sel(direction="up")
    assert unstable.sel(speed=33354.0).all()
    assert not unstable.sel(speed=[20000.0, 50000.0]).any()


def test_the_estimate_prices_the_floquet_output(monkeypatch):
    """--estimate left the floquet output out (0 s for any number of cases). It now adds its
    time per distinct case (continued sweeps: one for both directions, as it is computed), and
    the monodromy steps it assumes are an upper bound within 3x of those a run counts."""
    from gearsweep.kernels import floquet as fq
    from gearsweep.study import outputs
    from gearsweep.study.estimate import quick_estimate
    from gearsweep.study.execute import STATED_RATE, WRITE_RATE

    rig = RIG_STUDY.replace("speed: [150 rpm, 1500 rpm]",
                            "speed: {start: 100 rpm, stop: 2000 rpm, num: 24, spacing: log}")

    def est(text):
        return quick_estimate(make_plan(parse_study(text), text), ask_cache=False)[0]

    with_f, without = est(rig), est(rig.replace("[stats, floquet]", "[stats]"))
    assert without.output_seconds == 0 and with_f.output_seconds > 0
    assert with_f.seconds - with_f.compile_seconds == pytest.approx(  # its maps' compile and
        without.seconds - without.compile_seconds + with_f.output_seconds  # its variables' bytes
        + (with_f.output_bytes - without.output_bytes) / WRITE_RATE)
    both = est(rig.replace("sweep:", "continuation: [up, down]\nsweep:"))
    per_chunk = outputs.FLOQUET_CALL_SECONDS
    assert abs(both.output_seconds - with_f.output_seconds) <= per_chunk * max(both.chunks,
                                                                               with_f.chunks)
    cases = with_f.cases
    steps = ((with_f.output_seconds - cases * outputs.FLOQUET_CASE_SECONDS
              - with_f.chunks * per_chunk) * STATED_RATE["rk5"] * 1e6 / cases)
    counted = []
    real = fq.monodromy

    def counting(a, b, g, S, **kw):
        counted.append(2 * np.size(a) * S)
        return real(a, b, g, S, **kw)

    monkeypatch.setattr(fq, "monodromy", counting)
    monkeypatch.setattr(outputs, "monodromy", counting)
    with pytest.warns(StepLimitWarning):
        run_study(parse_study(rig))
    measured = (sum(counted) - 2 * 200) / cases  # less the warm-up's study map
    assert measured <= steps <= 3 * measured, (steps, measured)


def test_ray_limit_of_many_angles_is_each_angles_in_bounded_memory():
    """A floquet output's chunk asks the step limit of every case at once. Each distinct angle
    is scanned once, a block at a time: the values are those of one angle alone, and 5,000
    distinct angles stay far below the 170 MB that one scan of all of them held (a 100,000-case
    study with the floquet output peaked at 2.0 GB against 0.37 GB estimated)."""
    import tracemalloc

    rng = np.random.default_rng(3)
    theta = rng.uniform(np.pi / 2, np.pi, 5_000)
    few = rng.choice(theta[:5], 50_000)
    tracemalloc.start()
    try:
        limits = st.ray_limit("rk4", theta)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 60e6  # one scan of all of them: 170 MB
    for i in (0, 7, 4_999):
        assert limits[i] == st.ray_limit("rk4", theta[i])
    assert_allclose(st.ray_limit("rk4", np.pi / 2), 2 * np.sqrt(2), rtol=1e-12)  # RK4 on the axis
    alone = {t: float(st.ray_limit("rk5", t)) for t in theta[:5]}
    np.testing.assert_array_equal(st.ray_limit("rk5", few), [alone[t] for t in few])


def _hill_multiplier_ivp(alpha, beta, gamma, order, periods):
    """Largest |mu| per period 2 pi of p'' + gamma p' + (alpha + beta cos(order tau)) p = 0, from
    its monodromy over ``periods`` periods 2 pi (the true period of a fractional ``order``),
    integrated by scipy (DOP853, rtol 1e-10), independent of the kernels."""
    from scipy.integrate import solve_ivp

    def rhs(t, y):
        return [y[1], -gamma * y[1] - (alpha + beta * np.cos(order * t)) * y[0]]

    cols = [solve_ivp(rhs, (0, 2 * np.pi * periods), y0, method="DOP853", rtol=1e-10,
                      atol=1e-12).y[:, -1] for y0 in ([1.0, 0.0], [0.0, 1.0])]
    return np.abs(np.linalg.eigvals(np.array(cols).T)).max() ** (1.0 / periods)


# An outside tester: floquet(0.25, 0.3, 0.0, harmonics=([1.0], [1.5], [0.0])) returned 1.6016
# (unstable) where the equation's multiplier per 2 pi is 1.0000, and 2.1732 for order 0.5 where
# it is 1.4985: the kernel's table at a fractional order is not periodic over the 2 pi its
# monodromy spans. The direct API now refuses such an order, naming it (kernels.floquet.whole_orders).
@pytest.mark.parametrize("order", [1.5, 0.5])
def test_the_direct_floquet_api_refuses_a_fractional_order_naming_it(order):
    harm = ([1.0], [order], [0.0])
    for call in (lambda: floquet(0.25, 0.3, 0.0, harmonics=harm),
                 lambda: monodromy(0.25, 0.3, 0.0, 64, harmonics=harm),
                 lambda: paper_criterion(0.25, 0.3, 0.0, 64, harmonics=harm),
                 lambda: st.tableau_monodromy(0.25, 0.3, 0.0, 64, "rk5", harmonics=harm),
                 lambda: st.integrator_unstable(0.25, 0.3, 0.0, 64, harmonics=harm)):
        with pytest.raises(ValueError, match=rf"order {order:g} is not a whole number"):
            call()
    floquet(0.25, 0.3, 0.0, harmonics=([1.0], [2.0], [0.0]))  # a whole order as a float: taken


@pytest.mark.parametrize(("order", "truth"), [(1.5, 1.0000), (0.5, 1.4985)])
def test_a_fractional_order_over_its_common_period_matches_scipy(order, truth):
    """The way the refusal names (a study's: ``model.hill_parameters`` over the cycle of
    ``model.hill_cycle``, |mu|^(1/P) per mesh period) gives scipy's multiplier per 2 pi."""
    from gearsweep.model import RPM, Harmonic, MeshModel, hill_cycle, hill_parameters

    # Unit mass, mesh angular frequency 1 rad/s: alpha = k0, beta = k1, gamma = c per 2 pi.
    model = MeshModel(mass=1.0, teeth=1, stiffness=0.25, damping=0.0,
                      stiffness_harmonics=(Harmonic(0.3, order),))
    a, b, g, harm, *_ = hill_parameters(model, {"speed": np.array([1.0 / RPM])}, 1)
    cycle = hill_cycle(model)[0]
    assert cycle == 2
    mu = floquet(a, b, g, harmonics=harm, rtol=1e-10).multiplier[0] ** (1.0 / cycle)
    ivp = _hill_multiplier_ivp(0.25, 0.3, 0.0, order, cycle)
    assert ivp == pytest.approx(truth, abs=5e-5)  # the tester's numbers
    assert mu == pytest.approx(ivp, rel=1e-8)

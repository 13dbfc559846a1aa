"""The phase of the spectrum lines (``outputs.spectrum.phase``) against independent truth.

References, independent of the code under test:

* the phase a test signal was made with (``line_phase``), its offsets in exact rational
  arithmetic (``fractions.Fraction``);
* constant stiffness, one harmonic of STE or of the force: the linear oscillator's steady state
  ``P = F / (k0 - m w^2 + i c w)`` (the receptance at the forcing frequency w), so the line's
  amplitude is ``|P|`` and its phase ``arg P`` in the model's convention ``cos(2 pi r phi +
  phase)``; the mesh force ``k0 p + c p'`` has ``(k0 + i c w) P``;
* scipy's ``solve_ivp`` (DOP853, rtol 1e-11) of the same equation from rest: p at instants
  between the samples against ``sum A_r cos(2 pi r phi + theta_r)``;
* the recorded samples themselves (the DFT is invertible: every line up to Nyquist, with its
  phase, gives back every sample).
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
import xarray as xr
from conftest import Crash, CrashAfter, signal_and_spectrum
from hypothesis import given, settings
from hypothesis import strategies as st
from test_execute import strip  # the tests folder is on sys.path

from gearsweep.analysis.spectrum import line_phase, line_spectrum, wrap_phase
from gearsweep.api import run_study
from gearsweep.study import execute
from gearsweep.study.execute import run_plan
from gearsweep.study.outputs import OUTPUTS, PHASE_FLOOR
from gearsweep.study.plan import make_plan
from gearsweep.study.schema import parse_study

M, K0, C, FM = 0.1527, 1.073e9, 5500.0, 833.0  # [kg], [N/m], [N s/m], [N] (tests/test_whine.py)
TEETH = 48
E1, B1 = 5e-6, -1.0  # STE harmonic of order 1 [m] and its phase [rad]
FLUCT, ORDER_F, PSI = 300.0, 2, 0.5  # force harmonic [N], its order and phase [rad]
N_RES = 60 * math.sqrt(K0 / M) / (2 * math.pi) / TEETH  # order 1 meets f_n: 16,675 rpm
SPEEDS = [3000.0, 10000.0, 15000.0, N_RES, 18000.0, 25000.0, 40000.0]  # [rpm], past resonance


def study(speeds, *, spp: int, excitation: str, phase: bool = True, record: int = 4,
          transient: int = 60, extra: str = "", max_order: float = 4,
          sps: int | None = None, force: bool = True, guard: str = "warn", kind: str = "whine") -> str:
    opts = f"max_order: {max_order}" + (", phase: true" if phase else "") + (
        f", samples_per_period: {sps}" if sps else "") + ("" if force else ", force: false")
    return f"""
title: spectrum phase test
scene: {{kind: {kind}, mass: {M} kg, teeth: {TEETH}, stiffness: {K0} N/m,
        damping: {C} N*s/m, mean_force: {FM} N, {excitation}}}
sweep: {{speed: {list(speeds)}}}
solver: {{method: rk4, steps_per_period: {spp}, transient_periods: {transient},
          record_periods: {record}, step_guard: {guard}}}
outputs: [stats, {{spectrum: {{{opts}}}}}]
{extra}
"""


STE = f"ste: [{{amplitude: {E1} m, phase: {B1} rad}}]"
FORCE = f"fluctuation: [{{amplitude: {FLUCT} N, order: {ORDER_F}, phase: {PSI} rad}}]"


def run(text: str) -> xr.Dataset:
    return run_study(parse_study(text), text)


def mesh_omega(speeds) -> np.ndarray:
    return TEETH * np.asarray(speeds, float) * 2 * math.pi / 60  # [rad/s]


def receptance(w) -> np.ndarray:
    return 1.0 / (K0 - M * w**2 + 1j * C * w)  # [m/N]


def ste_response(speeds) -> np.ndarray:
    """Complex P of the order-1 line [m]: the STE force -m e'' = m w^2 e1 cos(w t + b1)."""
    w = mesh_omega(speeds)
    return M * w**2 * E1 * np.exp(1j * B1) * receptance(w)


def force_response(speeds) -> np.ndarray:
    """Complex P of the order-2 line [m]: the force F cos(2 W t + psi)."""
    w = ORDER_F * mesh_omega(speeds)
    return FLUCT * np.exp(1j * PSI) * receptance(w)


def line(ds: xr.Dataset, order: float, name: str = "spectrum") -> np.ndarray:
    """A line as a complex number A exp(i theta) [m for p, N for the force]."""
    scale = 1e-6 if name == "spectrum" else 1.0  # um in the file
    amp = ds[name].sel(order=order).values * scale
    return amp * np.exp(1j * ds[f"{name}_phase"].sel(order=order).values)


# ------------------------------------------------------------------------- line_phase itself


def test_wrap_phase_is_minus_pi_exclusive():
    got = wrap_phase([-math.pi, math.pi, 3 * math.pi, -3 * math.pi, 0.0, -0.5, 7.0, -7.0])
    want = [math.pi, math.pi, math.pi, math.pi, 0.0, -0.5, 7.0 - 2 * math.pi, -7.0 + 2 * math.pi]
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-15)
    assert (got > -math.pi).all() and (got <= math.pi).all()


@settings(deadline=None, max_examples=60)
@given(periods=st.integers(1, 6), per=st.integers(2, 9), start=st.integers(0, 10**12),
       step=st.integers(0, 9), seed=st.integers(0, 2**32 - 1))
def test_line_phase_returns_the_phase_the_signal_was_made_with(periods, per, start, step, seed):
    """x(t) = sum_k a_k cos(2 pi (k / periods) t + ph_k), sampled from t = start + step / 10
    (whole periods up to 1e12: the phase at sample 0 is formed in exact rationals here). Bins
    inside (0, Nyquist): ph_k itself; the mean: 0 or pi by its sign; every bin: the lines
    (|c_k|, theta_k) give back the samples."""
    rng = np.random.default_rng(seed)
    n = periods * per
    kmax = n // 2
    a = rng.uniform(0.2, 2.0, kmax + 1) * rng.choice([-1.0, 1.0], kmax + 1)
    ph = rng.uniform(-math.pi, math.pi, kmax + 1)
    t0 = Fraction(start) + Fraction(step, 10)  # [periods]
    j = np.arange(n)
    # phase of line k at sample 0: ph_k + 2 pi (k / periods) t0, reduced exactly mod 1 turn
    at0 = np.array([ph[k] + 2 * math.pi * float((Fraction(k, periods) * t0) % 1)
                    for k in range(kmax + 1)])
    x = sum(a[k] * np.cos(2 * math.pi * k * j / n + at0[k]) for k in range(kmax + 1))
    _, c = line_spectrum(x, periods)
    theta = line_phase(c, periods, start, step / 10)
    assert theta.shape == (kmax + 1,)
    assert ((theta > -math.pi) & (theta <= math.pi)).all()
    inner = [k for k in range(1, kmax + 1) if 2 * k != n]
    want = np.where(a[inner] > 0, ph[inner], ph[inner] + math.pi)  # a negative a: pi more
    err = np.abs(wrap_phase(theta[inner] - want))
    assert np.all(np.minimum(err, 2 * math.pi - err) < 1e-9)
    assert theta[0] == (0.0 if c[0].real >= 0 else math.pi)
    # t of sample j in periods, relative to the last whole period: the reconstruction
    back = sum(np.abs(c[k]) * np.cos(2 * math.pi * k * j / n + theta[k]
                                     + 2 * math.pi * float((Fraction(k, periods) * t0) % 1))
               for k in range(kmax + 1))
    np.testing.assert_allclose(back, x, rtol=0, atol=1e-11 * n)


def test_line_phase_exact_for_a_start_beyond_float_precision():
    """Order 1/3 after 10**15 + 1 periods: 2 pi (1/3) start in floating point has no digit of
    the phase left; the integer reduction keeps it (truth: (10**15 + 1) / 3 turns = 2/3 mod 1)."""
    periods, per = 3, 8
    n = periods * per
    j = np.arange(n)
    start = 10**15 + 1
    x = np.cos(2 * math.pi * j / n + 0.3 + 2 * math.pi * 2 / 3)  # order 1/3, phase 0.3
    _, c = line_spectrum(x, periods)
    assert abs(line_phase(c, periods, start)[1] - 0.3) < 1e-12


# ---------------------------------------------------------------- closed forms: the receptance


def test_default_is_off_and_leaves_the_other_variables_as_they_were():
    """Without ``phase`` the result has no phase variable, and turning it on changes no bit of
    the others (existing studies and files are unchanged)."""
    off = run(study([5000.0, 20000.0], spp=64, excitation=STE, phase=False))
    on = run(study([5000.0, 20000.0], spp=64, excitation=STE))
    assert "spectrum_phase" not in off and "force_spectrum_phase" not in off
    assert set(on.data_vars) - set(off.data_vars) == {"spectrum_phase", "force_spectrum_phase"}
    for name in off.data_vars:
        np.testing.assert_array_equal(on[name].values, off[name].values, err_msg=name)
    for name in ("spectrum_phase", "force_spectrum_phase"):
        assert on[name].dims == on.spectrum.dims
        assert on[name].attrs["units"] == "rad" and on[name].attrs["long_name"]
        assert on[name].attrs["phase_floor"] == PHASE_FLOOR["float64"] == 1e-9
    no_force = run(study([5000.0], spp=64, excitation=STE, force=False))
    assert "spectrum_phase" in no_force and "force_spectrum_phase" not in no_force


def test_ste_line_phase_equals_the_receptance_below_and_above_resonance():
    """Order 1 of p: A exp(i theta) = m w^2 e1 exp(i b1) / (k0 - m w^2 + i c w).

    The error is RK4's: 4th order in the step, so halving it divides the complex error by 16.
    The largest is at the lowest speed, where a mesh period's steps are longest against f_n
    (3000 rpm: h w_n = 0.068 at 512 steps): measured 1.26e-7 at 256 steps per period, 7.8e-9
    at 512; the phase error is below it (|d theta| <= |dP| / |P|). At 512 steps: 2e-8. The
    step being one step off (the samples' phase) would be 2 pi / 512 = 0.012 rad.
    """
    want = ste_response(SPEEDS)
    err = {}
    for spp in (256, 512):
        ds = run(study(SPEEDS, spp=spp, excitation=STE))
        assert (ds.status == 0).all()
        got = line(ds, 1.0)
        err[spp] = np.max(np.abs(got / want - 1))
        dtheta = wrap_phase(ds.spectrum_phase.sel(order=1.0).values - np.angle(want))
        assert np.max(np.abs(dtheta)) <= err[spp] * 1.0001
    assert err[512] < 2e-8
    assert 12 < err[256] / err[512] < 20
    # Below resonance the response follows the force (lag < pi/2), above it opposes it (lag
    # past pi/2), at f_n the lag is pi/2; 40,000 rpm wraps past -pi (b1 - lag < -pi).
    lag = wrap_phase(B1 - ds.spectrum_phase.sel(order=1.0).values)
    assert (lag[:3] < math.pi / 2).all() and (lag[4:] > math.pi / 2).all()
    assert abs(lag[3] - math.pi / 2) < 1e-6
    assert ds.spectrum_phase.sel(order=1.0).values[-1] > 0  # wrapped into (-pi, pi]
    # The mean: F_m / k0 > 0, phase 0; the mesh force's mean F_m, phase 0.
    assert (ds.spectrum_phase.sel(order=0.0) == 0).all()
    assert (ds.force_spectrum_phase.sel(order=0.0) == 0).all()
    # Every other line of this linear response is round-off: no phase.
    others = ds.spectrum_phase.sel(order=~np.isin(ds.order, [0.0, 1.0]))
    assert others.isnull().all()
    # The mesh force k0 p + c p': (k0 + i c w) P.
    w = mesh_omega(SPEEDS)
    np.testing.assert_allclose(line(ds, 1.0, "force_spectrum"), (K0 + 1j * C * w) * want,
                               rtol=1e-7)


def test_force_line_phase_equals_the_receptance():
    """A force harmonic of order 2 (resonance at 8,337 rpm): A exp(i theta) = F exp(i psi) /
    (k0 - m (2W)^2 + i c 2W), to the step's error (512 steps: measured 3.6e-8 at 3000 rpm,
    the largest; h w_n is that of the STE case, the error of a line at twice the frequency is
    larger). Tolerance 1e-7."""
    speeds = [3000.0, N_RES / 2, 12000.0, 20000.0]
    ds = run(study(speeds, spp=512, excitation=FORCE))
    want = force_response(speeds)
    np.testing.assert_allclose(line(ds, float(ORDER_F)), want, rtol=1e-7)
    w = ORDER_F * mesh_omega(speeds)
    np.testing.assert_allclose(line(ds, float(ORDER_F), "force_spectrum"),
                               (K0 + 1j * C * w) * want, rtol=1e-7)
    assert ds.spectrum_phase.sel(order=1.0).isnull().all()  # nothing at order 1


@pytest.mark.parametrize("speed", [10000.0, 25000.0])
def test_reconstruction_matches_solve_ivp_between_the_samples(speed):
    """p(phi) = sum_r A_r cos(2 pi r phi + theta_r) at instants that are no sample against
    scipy's DOP853 from rest (60 mesh periods; the transient decays by exp(-zeta w_n t) <
    1e-14). Measured: 1.2e-9 (10,000 rpm) and 1.7e-10 (25,000 rpm) of the dynamic amplitude,
    the step's error (DOP853 agrees with the closed form to 1e-11); one step off in the
    samples' phase gives 1.2e-2. Tolerance 5e-9."""
    from scipy.integrate import solve_ivp

    ds = run(study([speed], spp=512, excitation=STE))
    w = mesh_omega([speed])[0]
    amp = ds.spectrum.isel(speed=0).values * 1e-6
    theta = ds.spectrum_phase.isel(speed=0).values
    order = ds.order.values
    phis = 60 + np.array([0.0137, 0.5, 1.2345, 2.77, 3.999])  # in the recorded window

    def rhs(t, y):
        e2 = -(w**2) * E1 * math.cos(w * t + B1)  # e''
        return [y[1], (FM - M * e2 - C * y[1] - K0 * y[0]) / M]

    t_end = phis[-1] * 2 * math.pi / w
    sol = solve_ivp(rhs, (0.0, t_end), [0.0, 0.0], method="DOP853", rtol=1e-11,
                    atol=1e-18, t_eval=phis * 2 * math.pi / w)
    keep = ~np.isnan(theta)
    back = np.sum(amp[keep, None] * np.cos(2 * math.pi * order[keep, None] * phis[None, :]
                                           + theta[keep, None]), axis=0)
    dyn = abs(ste_response([speed])[0])
    assert np.max(np.abs(back - sol.y[0])) < 5e-9 * dyn


def test_every_line_with_its_phase_gives_back_the_samples():
    """A response with content on every bin (k(t), STE, backlash, a transient still ringing
    after 7 periods, an offset of 7 periods that is no multiple of the record of 4, so orders
    k/4 carry a phase offset of their own): with every line up to Nyquist, sum A_r cos(2 pi r
    phi_j + theta_r) at the samples' phase phi_j = 7 + (1 + 4 j) / 64 (the state after step
    n_transient + 4 j + 1) gives back each sample, to the lines whose phase is NaN (at most
    phase_floor of the case's largest, each) and round-off."""
    text = study([6000.0, 17000.0, 30000.0], spp=64, sps=16, max_order=8, transient=7,
                 kind="full",
                 excitation=STE + ", stiffness_harmonics: [{amplitude: 179 kN/mm}],"
                 " backlash: 20 um")
    plan, res, out = signal_and_spectrum(text)
    sig = res.signal * 1e6
    amp, theta = out["spectrum"] * 1e6, out["spectrum_phase"]
    assert amp.shape == (3, 33) and sig.shape == (3, 64)  # every bin, Nyquist (order 8) too
    assert (res.status == 0).all()
    # 6000 rpm has settled to the mesh period (orders 0, 1, 2, ...), the others ring on every bin
    assert np.isfinite(theta).sum(axis=1).tolist() == [9, 33, 33]
    j = np.arange(64)
    phi = 7 + (1 + 4 * j) / 64
    order = np.arange(33) / 4
    keep = np.isfinite(theta)
    back = np.einsum("ck,ckj->cj", np.where(keep, amp, 0.0),
                     np.cos(2 * math.pi * order[None, :, None] * phi[None, None, :]
                            + np.where(keep, theta, 0.0)[:, :, None]))
    scale = np.max(np.abs(sig), axis=1, keepdims=True)
    floor = PHASE_FLOOR["float64"] * scale * (~keep).sum(axis=1, keepdims=True)
    assert (np.abs(back - sig) <= floor + 1e-12 * scale).all()


def test_no_phase_where_there_is_no_line_or_no_case():
    """p = 0 (no excitation, no mean force): every amplitude 0 and every phase NaN; a case the
    integrator blows up (100 rpm: h w_n = 14.8, beyond RK4's limit, status 1) or the step
    guard skips (status 3): NaN as its amplitude."""
    quiet = run(study([5000.0], spp=64, excitation="ste: []").replace(
        f"mean_force: {FM} N,", ""))
    assert (quiet.spectrum == 0).all() and quiet.spectrum_phase.isnull().all()
    assert quiet.force_spectrum_phase.isnull().all()
    ds = run(study([100.0, 5000.0], spp=16, excitation=STE, guard="off"))
    assert ds.status.values.tolist() == [1, 0]
    assert ds.spectrum.isel(speed=0).isnull().all()
    for name in ("spectrum_phase", "force_spectrum_phase"):
        assert ds[name].isel(speed=0).isnull().all()
        assert ds[name].isel(speed=1).sel(order=[0.0, 1.0]).notnull().all()
    skipped = run(study([100.0, 5000.0], spp=16, excitation=STE, guard="skip"))
    assert skipped.status.values.tolist() == [3, 0]
    assert skipped.spectrum_phase.isel(speed=0).isnull().all()
    np.testing.assert_array_equal(skipped.spectrum_phase.isel(speed=1),
                                  ds.spectrum_phase.isel(speed=1))


def test_float32_samples_get_the_float32_floor():
    """A float32 run (a GPU's ``precision: float32``) records p in single precision: the empty
    orders of a linear response are its round-off, up to 1e-8 of the largest, above the
    float64 floor. The same kernel result, its samples rounded to float32, under a plan with
    ``precision: float32``: those orders have no phase, orders 0 and 1 keep theirs (to 1e-6,
    float32's rounding of p against its amplitude); with the float64 floor the noise would
    have phases."""
    import dataclasses

    text = study([3000.0, N_RES, 25000.0], spp=64, excitation=STE)
    plan, res, out = signal_and_spectrum(text)
    res32 = dataclasses.replace(res, signal=res.signal.astype(np.float32).astype(float))
    solver = plan.study.solver.model_copy(update={"precision": "float32", "device": "cuda"})
    plan32 = dataclasses.replace(plan, study=plan.study.model_copy(update={"solver": solver}))
    params = {"speed": plan.grids["speed"]}
    noisy = OUTPUTS["spectrum"].compute(plan, params, res32)["spectrum_phase"]
    got = OUTPUTS["spectrum"].compute(plan32, params, res32)["spectrum_phase"]
    empty = ~np.isin(np.arange(17) / 4, [0.0, 1.0])
    assert np.isfinite(noisy[:, empty]).sum() >= 5  # round-off above 1e-9 at several orders
    assert np.isnan(got[:, empty]).all()
    np.testing.assert_allclose(got[:, ~empty], out["spectrum_phase"][:, ~empty], rtol=0,
                               atol=1e-6)
    assert OUTPUTS["spectrum"].variables(plan32)["spectrum_phase"].attrs["phase_floor"] == 1e-4


# ---------------------------------------------------------- chunks, resume, continuation


RATTLE = """
title: rattle, continued, with phases
scene: {kind: rattle, mass: 0.1527 kg, teeth: 48, stiffness: 1073 kN/mm, backlash: 0.1 mm,
        mean_force: 100 N, fluctuation: [{amplitude: 300 N, order: 1, phase: 40 deg}]}
sweep:
  damping: {start: 50 N*s/m, stop: 400 N*s/m, num: 8}
  speed: {start: 3000 rpm, stop: 12000 rpm, num: 6}
continuation: [up, down]
solver: {method: rk4, steps_per_period: 32, transient_periods: 13, record_periods: 4}
outputs: [stats, {spectrum: {phase: true}}]
"""


def _strip(ds: xr.Dataset, resumed: bool = False) -> xr.Dataset:
    """Without the attributes that differ between runs, and for a ``resumed`` result those only
    a resumed result has (``test_execute.strip``)."""
    return strip(ds, resumed)


def test_chunked_and_resumed_runs_give_the_same_phases(tmp_path):
    """One chunk, chunks of 12 cases, and a run that crashed after 2 chunks and was resumed
    from its checkpoints: bitwise the same phases (each chunk's come from its own samples)."""
    plan = make_plan(parse_study(RATTLE), RATTLE)
    whole = run_plan(plan, chunk_cases=plan.n_cases)
    assert whole.spectrum_phase.dims == ("direction", "damping", "speed", "order")
    assert whole.spectrum_phase.notnull().any() and whole.force_spectrum_phase.notnull().any()
    xr.testing.assert_identical(_strip(run_plan(plan, chunk_cases=12)), _strip(whole))
    out = tmp_path / "r.nc"
    with pytest.raises(Crash):
        run_plan(plan, backend=CrashAfter(2), checkpoint=out, chunk_cases=12)
    resumed = execute.run_to_file(plan, out, chunk_cases=12)
    xr.testing.assert_identical(_strip(resumed, resumed=True), _strip(whole))
    with xr.open_dataset(out) as back:
        xr.testing.assert_identical(_strip(back.load(), resumed=True), _strip(whole))
        for name in ("spectrum_phase", "force_spectrum_phase"):
            assert back[name].attrs["units"] == "rad" and back[name].attrs["long_name"]

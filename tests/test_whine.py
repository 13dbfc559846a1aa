"""Whine spectra (issue 4): the ``spectrum`` output against closed forms and harmonic balance.

References, independent of the time stepping:

* constant stiffness: the linear oscillator's frequency response to the STE force ``-m e''``,
  ``|P_n| = m (n W)^2 e_n / |k0 - m (n W)^2 + i c n W|``, and ``P_0 = F_m / k0``;
* time-varying stiffness: ``gearsweep.analysis.linear_response.periodic_response``, harmonic
  balance of Eq. (9) truncated at 40 harmonics (converged to round-off for k_n/k0 <= 1/6);
* Parseval's identity on the recorded time history.
"""

from __future__ import annotations

import math
import re
import subprocess
import sys
import warnings

import numpy as np
import pytest
from conftest import signal_and_spectrum
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

import gearsweep
from gearsweep.analysis.linear_response import periodic_response, ste_force
from gearsweep.analysis.spectrum import line_spectrum, mean_square
from gearsweep.api import run_study
from gearsweep.errors import ContactLossWarning, StudyError
from gearsweep.study.dataset import write_netcdf
from gearsweep.study.plan import CHUNK_SIGNAL_BYTES, make_plan
from gearsweep.study.schema import parse_study
from gearsweep.units import si_values

M, K0, C, FM = 0.1527, 1.073e9, 5500.0, 833.0  # [kg], [N/m], [N s/m], [N]: Fig. 6 and bench
KH = (179e6, 40e6, 10e6)  # k1 (Fig. 7.2), k2, k3 [N/m]
E = (5e-6, 1e-6, 0.3e-6)  # STE harmonics [m]
TEETH = 48
FN = math.sqrt(K0 / M) / (2 * math.pi)  # undamped natural frequency [Hz], 13.34 kHz


def whine(speeds, *, spp: int, sps: int = 16, max_order: float = 4, varying: bool = True,
          damping: float = C, transient: int = 60, record: int = 4, method: str = "rk4",
          extra: str = "", ste: bool = True, sweep_force: str = "") -> str:
    """YAML text of a whine study over ``speeds`` [rpm] with the spectrum output."""
    kh = ", ".join(f"{{amplitude: {k} N/m}}" for k in KH)
    e_n = ", ".join(f"{{amplitude: {e} m}}" for e in E)
    return f"""
title: whine test
scene:
  kind: whine
  mass: {M} kg
  teeth: {TEETH}
  stiffness: {K0} N/m
  {"stiffness_harmonics: [" + kh + "]" if varying else ""}
  damping: {damping} N*s/m
  {"" if sweep_force else f"mean_force: {FM} N"}
  {"ste: [" + e_n + "]" if ste else ""}
sweep:
  {f"mean_force: {sweep_force}" if sweep_force else ""}
  speed: {[float(s) for s in speeds]}
solver: {{method: {method}, steps_per_period: {spp}, transient_periods: {transient},
          record_periods: {record}}}
outputs: [stats, {{spectrum: {{max_order: {max_order}, samples_per_period: {sps}}}}}]
{extra}
"""


def run(text: str):
    return run_study(parse_study(text), text)


def mesh_omega(speeds) -> np.ndarray:
    return TEETH * np.asarray(speeds, float) * 2 * math.pi / 60  # [rad/s]


def reference(speeds, damping: float = C) -> np.ndarray:
    """Harmonic-balance coefficients of Eq. (9) with the test's k_n and e_n, orders 0..40."""
    w = mesh_omega(speeds)
    return periodic_response(M, damping, K0, w, k_amplitudes=KH, k_orders=(1, 2, 3),
                             mean_force=FM, f_amplitudes=ste_force(M, w, E, (1, 2, 3)),
                             f_orders=(1, 2, 3), harmonics=40)


SPEEDS = np.linspace(1000, 20000, 39)  # [rpm]: mesh 0.8-16 kHz, resonance of order 1 inside


def test_constant_stiffness_lines_equal_frequency_response():
    """Constant k: each STE line equals the analytic frequency response to 1e-6 relative.

    RK4's error in the steady-state amplitude falls as h^4; the worst line is order 3 at
    20,000 rpm (48 kHz, 3.6 x f_n). 512 steps per mesh period (171 per period of order 3,
    h w = 0.037) bring it to 6.5e-7; 256 steps give 1.1e-5, so 512 is the step needed.
    """
    w = mesh_omega(SPEEDS)
    errors = {}
    for spp in (256, 512):
        ds = run(whine(SPEEDS, spp=spp, varying=False))
        assert (ds.status == 0).all()
        err = 0.0
        for n in (1, 2, 3):
            ana = M * (n * w) ** 2 * E[n - 1] / np.abs(K0 - M * (n * w) ** 2 + 1j * C * n * w)
            err = max(err, np.max(np.abs(si_values(ds.spectrum.sel(order=float(n))) / ana - 1)))
        # The mean is exact whatever the step: a constant is a fixed point of the RK4 map.
        assert_allclose(si_values(ds.spectrum.sel(order=0.0)), FM / K0, rtol=1e-13)
        errors[spp] = err
    assert errors[512] < 1e-6
    assert errors[256] > 1e-6  # documents that 256 steps per period are not enough
    assert 12 < errors[256] / errors[512] < 20  # fourth order: 2^4 = 16


def test_lines_fall_on_integer_orders_without_leakage():
    """Order k / record_periods exactly; a periodic response puts nothing between mesh orders."""
    for varying in (False, True):
        ds = run(whine(SPEEDS, spp=64, record=4, varying=varying))
        order = ds.order.values
        assert np.array_equal(order, np.arange(17) / 4)  # 0, 0.25, ..., 4: exact binary fractions
        on = np.isin(order, [0.0, 1.0, 2.0, 3.0, 4.0])
        spec = ds.spectrum.values
        # Between the orders: only the decayed transient (exp(-60 periods * c/2m * T) < 1e-20)
        # and round-off (1e-16 of the largest line) can show.
        assert np.max(spec[:, ~on]) < 1e-12 * np.max(spec[:, on][:, 1:])
        if not varying:
            # LTI: the response to orders 1-3 has no order 4.
            assert np.max(spec[:, order == 4.0]) < 1e-12 * np.max(spec[:, on][:, 1:])
        assert_allclose(ds.frequency.values, ds.mesh_frequency.values[:, None] * order[None, :],
                        rtol=1e-15)


def test_time_varying_lines_match_harmonic_balance():
    """With k(t), the lines at orders 0-4 match harmonic balance (rk5, 512 steps, 64 samples).

    Measured: 7e-13 on the mean, 1.8e-10, 7.8e-10, 1.6e-9, 3.3e-9 on orders 1-4 (step error;
    with 64 samples per period, orders >= 60 alias onto the kept bins and are below 1e-12).
    """
    ds = run(whine(SPEEDS, spp=512, sps=64, method="rk5"))
    ref = np.abs(reference(SPEEDS))[:, :5]
    assert_allclose(si_values(ds.spectrum.sel(order=[0.0, 1.0, 2.0, 3.0, 4.0])), ref, rtol=1e-8)


def test_force_spectrum_matches_force_balance():
    """force_spectrum = |k(t) p + c p'| per line; by Eq. (9) it equals |F_n + m (n W)^2 P_n|.

    F_n: the STE force m (n W)^2 e_n (and F_m at order 0), P_n: harmonic balance. The mean is
    F_m. Measured: 3e-12 on the mean, 1.2e-9 on orders 1-3 (the step error of rk5 at 512
    steps), 1.0e-7 on order 4, a line 1e4 times below order 1 where the aliases of the
    product k(t) p (orders >= 60 at 64 samples per period) weigh most. Tolerance 3e-7.
    """
    ds = run(whine(SPEEDS, spp=512, sps=64, method="rk5"))
    ref = reference(SPEEDS)[:, :5]
    w = mesh_omega(SPEEDS)
    n = np.arange(5)
    forcing = np.zeros((len(SPEEDS), 5))
    forcing[:, 0] = FM
    forcing[:, 1:4] = ste_force(M, w, E, (1, 2, 3))
    expect = np.abs(forcing + M * (n[None, :] * w[:, None]) ** 2 * ref)
    got = ds.force_spectrum.sel(order=[0.0, 1.0, 2.0, 3.0, 4.0]).values
    assert_allclose(got, expect, rtol=3e-7)
    assert ds.force_spectrum.attrs["units"] == "N"


def test_parseval_on_the_recorded_signal():
    """DC^2 + sum A_k^2 / 2 (+ A_Nyq^2) equals the mean square of the samples to 1e-10."""
    speeds = np.linspace(1000, 20000, 17)
    plan, res, out = signal_and_spectrum(whine(speeds, spp=64, sps=16, max_order=8, record=5))
    amp = out["spectrum"]
    sig = res.signal
    assert amp.shape == (17, 41) and sig.shape == (17, 80)  # all bins up to Nyquist = order 8
    energy = amp[:, 0] ** 2 + 0.5 * np.sum(amp[:, 1:-1] ** 2, axis=1) + amp[:, -1] ** 2
    assert_allclose(energy, np.mean(sig**2, axis=1), rtol=1e-10)
    # And the dynamic part against the kernel's rms over every step (not only the samples):
    # equal up to the content above order 8 the samples miss: measured 1.6e-7.
    assert_allclose(energy - amp[:, 0] ** 2, res.stats["p_rms"] ** 2, rtol=1e-6)


@settings(deadline=None, max_examples=40)
@given(n=st.integers(2, 200), periods=st.integers(1, 7), seed=st.integers(0, 2**32 - 1))
def test_line_spectrum_parseval_and_amplitudes(n, periods, seed):
    """Random signals: Parseval to 1e-12; a cosine on bin k shows as its amplitude there."""
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(3, n))
    _, c = line_spectrum(x, periods)
    assert_allclose(mean_square(c, n), np.mean(x**2, axis=1), rtol=1e-12)
    k = int(rng.integers(0, n // 2 + 1))
    a, ph = rng.uniform(0.1, 2.0), rng.uniform(-np.pi, np.pi)
    j = np.arange(n)
    y = a * np.cos(2 * np.pi * k * j / n + ph)
    order, cy = line_spectrum(y, periods)
    expect = np.zeros(n // 2 + 1)
    expect[k] = abs(a * np.cos(ph)) if k == 0 or 2 * k == n else a  # DC, Nyquist see cos(ph)
    assert_allclose(np.abs(cy), expect, atol=1e-12 * n)
    assert order[k] == k / periods


def test_spectrum_converged_in_step():
    """Doubling steps_per_period from 256 to 512 changes the lines of orders 1-3 by < 1e-5.

    Measured (rk4, time-varying k, 1000-20,000 rpm): relative to each line, the change is
    1.5e-4 from 128 to 256 and 9.3e-6 from 256 to 512, a ratio of 16 (fourth order), so 256
    steps per mesh period resolve the spectrum to 1e-5.
    """
    lines = [1.0, 2.0, 3.0]
    spec = {spp: run(whine(SPEEDS, spp=spp, sps=32)).spectrum.sel(order=lines).values
            for spp in (128, 256, 512)}
    d1 = np.max(np.abs(spec[256] / spec[128] - 1))
    d2 = np.max(np.abs(spec[512] / spec[256] - 1))
    assert d2 < 1e-5
    assert 12 < d1 / d2 < 20


@pytest.mark.parametrize("n", [1, 2, 3])
def test_superharmonic_resonances_where_theory_puts_them(n):
    """Mesh order n meets f_n at speed 60 f_n / (n N1): the order-n line peaks there.

    Light damping (c = 0.5 N s/mm, zeta = 0.02) so the peak is sharp. Theory moves it by
    1/sqrt(1 - 2 zeta^2) - 1 = 4e-4 (the STE force grows as W^2) and by the stiffness ripple
    (k1/k0 = 1/6) by a few 1e-3; harmonic balance puts it at +0.15 %, -0.21 %, -0.16 % for
    n = 1, 2, 3 (simulated on the grid: +0.1 %, -0.2 %, -0.2 %). Tolerance 0.5 %; the
    simulated peak must also sit within one grid step (0.1 %) of the harmonic-balance peak.
    """
    damping = 500.0
    theory = 60 * FN / (n * TEETH)
    speeds = theory * np.linspace(0.97, 1.03, 61)
    ds = run(whine(speeds, spp=128, damping=damping, transient=400, record=2))
    line = ds.spectrum.sel(order=float(n)).values
    peak = speeds[np.argmax(line)]
    hb_peak = speeds[np.argmax(np.abs(reference(speeds, damping)[:, n]))]
    assert abs(peak / theory - 1) < 5e-3
    assert abs(peak - hb_peak) <= 1.01 * (speeds[1] - speeds[0])
    # A resonance, not a plateau: 3 % off the peak a single mode with zeta = 0.02 falls to
    # 2 zeta / sqrt((2 x 0.03)^2 + (2 zeta)^2) = 0.55 of it.
    assert line.max() > 1.6 * max(line[0], line[-1])


def test_outputs_accept_names_and_options():
    text = whine([5000.0], spp=64, sps=16)
    study = parse_study(text)
    assert [o.name for o in study.outputs] == ["stats", "spectrum"]
    plan = make_plan(study, text)
    assert plan.outputs == ["stats", "spectrum"]
    assert plan.options["spectrum"].max_order == 4 and plan.samples_per_period() == 16
    plain = parse_study(text.replace("{spectrum: {max_order: 4, samples_per_period: 16}}",
                                     "spectrum"))
    plan = make_plan(plain)
    assert plan.samples_per_period() == 16  # default: smallest divisor of 64 >= 4 x 4


@pytest.mark.parametrize(("option", "field", "allowed"), [
    ("{max_order: -1}", "outputs[1].spectrum.max_order", "greater than 0"),
    ("{max_ordr: 4}", "outputs[1].spectrum.max_ordr", "unknown option"),
    ("{samples_per_period: 1}", "outputs[1].spectrum.samples_per_period", "greater than or"),
])
def test_bad_spectrum_options_name_the_field(option, field, allowed):
    text = whine([5000.0], spp=64).replace("{max_order: 4, samples_per_period: 16}", option)
    with pytest.raises(StudyError) as exc:
        parse_study(text, "s.yaml")
    assert exc.value.field == field and allowed in exc.value.allowed


def test_inconsistent_spectrum_settings_are_refused():
    with pytest.raises(StudyError, match="Nyquist") as exc:
        parse_study(whine([5000.0], spp=64, sps=4, max_order=4), "s.yaml")
    # at max_order, which the message names (was the output's, outputs[1].spectrum)
    assert exc.value.file == "s.yaml" and exc.value.field == "outputs[1].spectrum.max_order"
    with pytest.raises(StudyError, match="multiple of 16"):
        make_plan(parse_study(whine([5000.0], spp=40, sps=16)))
    # A shaft-order torque fluctuation repeats every 48 mesh periods: record whole cycles.
    fluct = whine([5000.0], spp=64).replace("  mean_force:", "  fluctuation: [{amplitude: 10 N,"
                                            " order: 0.0208333333333333}]\n  mean_force:")
    with pytest.raises(StudyError, match="multiple of 48"):
        make_plan(parse_study(fluct))
    with pytest.raises(StudyError, match="at most once"):
        parse_study(whine([5000.0], spp=64).replace("outputs: [stats,", "outputs: [stats, stats,"))
    with pytest.raises(StudyError, match="takes no options"):
        parse_study(whine([5000.0], spp=64).replace("outputs: [stats,", "outputs: [{stats: {a: 1}},"))


def test_signal_memory_is_bounded_per_chunk():
    """Chunks hold at most CHUNK_SIGNAL_BYTES of time history; results do not depend on it."""
    text = whine([1000.0, 20000.0], spp=64, sps=16, max_order=0.25, record=500).replace(
        "speed: [1000.0, 20000.0]", "speed: {start: 1000 rpm, stop: 20000 rpm, num: 20000}")
    big = make_plan(parse_study(text))
    # By steps alone a chunk would hold 4e8 / (560 x 64) = 11,160 lanes, 0.7 GB of signal.
    a, b = big.chunks()[0]
    assert (b - a) * 500 * 16 * 8 <= CHUNK_SIGNAL_BYTES
    assert len(big.chunks()) >= 20000 * 500 * 16 * 8 // CHUNK_SIGNAL_BYTES
    # Continued sweeps: a lane is a whole up-and-down sweep, and both directions are integrated
    # side by side, so a chunk holds 2 signals per lane.
    sweep = whine([1000.0, 20000.0], spp=64, sps=16, max_order=0.25, record=500,
                  extra="continuation: [up, down]").replace(
        "speed: [1000.0, 20000.0]", "speed: [1000.0, 20000.0]\n  damping: {start: 1 N*s/m,"
        " stop: 5500 N*s/m, num: 2000}")
    cont = make_plan(parse_study(sweep))
    a, b = cont.chunks()[0]
    assert (b - a) * 2 * 500 * 16 * 8 <= CHUNK_SIGNAL_BYTES < (b - a + 1) * 2 * 500 * 16 * 8
    small_text = whine(np.linspace(1000, 20000, 300), spp=64)
    plan = make_plan(parse_study(small_text), small_text)
    from gearsweep.study.chunk import run_chunk
    from gearsweep.study.dataset import assemble, empty_results, store_chunk

    def by(lanes: int):
        res = empty_results(plan)
        for a, b in plan.chunks(lanes):
            store_chunk(res, plan, a, b, run_chunk(plan, a, b))
        return assemble(plan, res)

    one, many = by(300), by(128)
    assert np.array_equal(one.spectrum.values, many.spectrum.values)
    assert np.array_equal(one.force_spectrum.values, many.force_spectrum.values)


def test_spectrum_with_continuation_and_netcdf_round_trip(tmp_path):
    import xarray as xr

    text = whine(np.linspace(4000, 6000, 9), spp=64, extra="continuation: [up, down]")
    ds = run(text)
    assert ds.spectrum.dims == ("direction", "speed", "order")
    # A linear equation has one periodic response: up and down agree.
    assert_allclose(ds.spectrum.sel(direction="up"), ds.spectrum.sel(direction="down"),
                    rtol=1e-9, atol=1e-20)
    path = write_netcdf(ds, tmp_path / "w.nc")
    with xr.open_dataset(path) as back:
        assert back.frequency.dims == ("speed", "order") and "frequency" in back.coords
        assert back.frequency.attrs["units"] == "Hz" and back.spectrum.attrs["units"] == "um"
        assert_allclose(back.spectrum, ds.spectrum)


def test_error_free_teeth_respond_in_proportion_to_the_mean_force():
    """e = 0: Eq. (9) is linear in F_m, so every line (order 0 included) scales with it (Fig. 6).

    Tolerance 1e-12: the kernel scales force / mass by the same factor at every step, so only
    round-off separates the cases.
    """
    ds = run(whine(np.linspace(2000, 20000, 7), spp=64, ste=False,
                   sweep_force="[200 N, 800 N, 3200 N]"))
    assert list(ds.spectrum.dims) == ["mean_force", "speed", "order"]
    spec = ds.spectrum.transpose("mean_force", "speed", "order").values
    assert_allclose(spec[1], 4 * spec[0], rtol=1e-12, atol=1e-30)
    assert_allclose(spec[2], 16 * spec[0], rtol=1e-12, atol=1e-30)
    assert np.all(spec[0][:, 4] > 0)  # order 1 present: the stiffness ripple alone excites it


def test_aliasing_falls_with_the_samples_per_period():
    """Same integration (rk5, 512 steps), sampled 16, 64 and 128 times per mesh period.

    Orders >= sps - 4 fold onto the kept orders 0-4. Measured against 128 samples: 1.4e-5 on
    order 4 at 16 samples (orders 12, 20, ... fold in), 7.5e-14 at 64 (orders >= 60).
    """
    lines = [0.0, 1.0, 2.0, 3.0, 4.0]
    spec = {sps: run(whine(SPEEDS, spp=512, sps=sps, method="rk5")).spectrum.sel(order=lines).values
            for sps in (16, 64, 128)}
    err16 = np.max(np.abs(spec[16] / spec[128] - 1), axis=0)
    err64 = np.max(np.abs(spec[64] / spec[128] - 1), axis=0)
    assert np.all(err64 < 1e-12)
    assert 1e-6 < err16[4] < 1e-4  # visible, and the largest on the highest kept order
    assert err16[4] == err16.max()


GEAR_WHINE = """
title: a gear pair's whine spectrum, default sampling
scene:
  kind: whine
  gear: {module: 3 mm, z1: 25, z2: 41, face_width: 20 mm}
  torque: 150 N*m
  drive: {inertia_1: 4.87e-4 kg m^2, inertia_2: 3.527e-3 kg m^2}
  damping: 2 N s/mm
sweep:
  speed: [500 rpm, 1000 rpm]
solver: {method: rk4, steps_per_period: 256, transient_periods: 100, record_periods: 4}
outputs: [stats, {spectrum: {max_order: 4}}]
"""


def test_the_default_sampling_of_a_gear_scenes_spectrum_does_not_alias():
    """A gear pair's k(t) (10 harmonics) gives p and k(t) f(p) lines far above 3 max_order; the
    default samples_per_period (16 for max_order 4) folded them back: at 500-1000 rpm its
    force_spectrum line 3 came out 78x and 105x the converged value, line 1 4.7x, and line 4 of p
    39 % off (an engineer new to the tool). Now the default takes 4 samples per period of the
    excitation's highest order too (64 here); against all 256 steps sampled: 1e-3."""
    plan = make_plan(parse_study(GEAR_WHINE), GEAR_WHINE)
    assert plan.samples_per_period() == 64
    lines = [0.0, 1.0, 2.0, 3.0, 4.0]
    default = run(GEAR_WHINE)
    every = run(GEAR_WHINE.replace("max_order: 4}", "max_order: 4, samples_per_period: 256}"))
    for name in ("spectrum", "force_spectrum"):
        got, ref = (d[name].sel(order=lines).values for d in (default, every))
        assert_allclose(got, ref, rtol=1e-3, atol=1e-6 * ref.max(), err_msg=name)
    assert default.spectrum.attrs["samples_per_period"] == 64


def _exact_p(speeds, fm: float = FM) -> np.ndarray:
    """The steady response p of the constant-stiffness scene (``whine(..., varying=False)``)
    under the mean force ``fm``, from its closed form p(t) = F_m / k0 + sum_n Re(P_n e^{i n W t}),
    P_n = m (n W)^2 e_n / (k0 - m (n W)^2 + i c n W), on 4096 points of a mesh period (speed x
    point)."""
    w = mesh_omega(speeds)[:, None]
    phase = 2 * math.pi * np.arange(4096)[None, :] / 4096
    p = np.full((len(speeds), 4096), fm / K0)
    for n, e in enumerate(E, start=1):
        amp = M * (n * w) ** 2 * e / (K0 - M * (n * w) ** 2 + 1j * C * n * w)
        p += np.real(amp * np.exp(1j * n * phase))
    return p


def _exact_p_min(speeds) -> np.ndarray:
    """The least p of ``_exact_p`` under the test's F_m."""
    return _exact_p(speeds).min(axis=1)


def test_contact_lost_marks_the_speeds_where_p_falls_below_zero():
    """A whine scene has no backlash: f(p) = p, the drive flanks in contact while p > 0. Where
    the STE's force takes p below 0 the result marks the case in ``contact_lost`` (an outside
    tester's whine study peaked 34 % above the same pair with backlash, with nothing said). The
    flag against the closed form's least p (constant stiffness): at 1000 rpm p stays near F_m /
    k0 = 0.78 um, from about 6,000 rpm the STE's lines (5, 1, 0.3 um) take it below 0."""
    speeds = np.array([1000.0, 2000.0, 3000.0, 6000.0, 9000.0, 12000.0, 15000.0])
    exact = _exact_p_min(speeds)
    assert (exact > 0.1 * FM / K0).sum() >= 2 and (exact < -0.1 * FM / K0).sum() >= 3
    with pytest.warns(ContactLossWarning, match=r"<text>: 4 of 7 case\(s\) leave drive-flank"):
        ds = gearsweep.run(whine(speeds, spp=256, varying=False))
    assert_allclose(si_values(ds.p_min), exact, rtol=1e-4, atol=1e-4 * FM / K0)
    assert ds.contact_lost.dtype == bool
    assert np.array_equal(ds.contact_lost.values, exact < 0)
    assert "p_min < 0 under F_m > 0 (drive flanks)" in ds.contact_lost.attrs["long_name"]


def test_contact_lost_under_a_negative_mean_force_is_the_back_flanks():
    """F_m < 0 presses the back flanks (p < 0): they part where p rises above 0, not where it
    falls below (an outside tester's scene at -886.8 N kept p in [-0.86, -0.77] um and was
    marked lost in 4 of 4 cases, warned as leaving drive-flank contact). The flag against the
    closed form's greatest p under -F_m, the warning naming the back flank."""
    speeds = np.array([1000.0, 2000.0, 3000.0, 6000.0, 9000.0, 12000.0, 15000.0])
    exact = _exact_p(speeds, -FM)
    lost = exact.max(axis=1) > 0
    assert 2 <= lost.sum() <= len(speeds) - 2 and (exact.max(axis=1) < -0.1 * FM / K0).sum() >= 2
    with pytest.warns(ContactLossWarning, match=rf"<text>: {lost.sum()} of 7 case\(s\) leave"
                      r" back-flank contact, the flank their negative mean force presses \(p"
                      r" above 0 in the steady state.*takes the drive flanks into contact"):
        ds = gearsweep.run(whine(speeds, spp=256, varying=False).replace(
            f"mean_force: {FM} N", f"mean_force: {-FM} N"))
    at_steps = exact[:, ::4096 // 256].max(axis=1)  # the 256 steps' p, where the kernel records
    assert_allclose(si_values(ds.p_max), at_steps, rtol=1e-4, atol=1e-4 * FM / K0)
    assert np.array_equal(ds.contact_lost.values, lost)


def test_contact_lost_per_case_of_a_mean_force_sweep_through_zero():
    """A sweep over -F_m, 0 and F_m judges each case by its own load's flank; with no mean force
    neither flank is pressed and the teeth part where p takes both signs (here, the STE's lines
    about p = 0, at every speed). Each against the closed form; the warning names no one
    flank."""
    speeds = np.array([1000.0, 6000.0, 12000.0])
    forces = (-FM, 0.0, FM)
    with pytest.warns(ContactLossWarning, match=r"leave the flank their mean force presses \(p"
                      r" below 0 under F_m > 0, above 0 under F_m < 0, of both signs under"
                      r" F_m = 0 in the steady state"):
        ds = gearsweep.run(whine(speeds, spp=256, varying=False,
                                 sweep_force=str([f"{f} N" for f in forces]).replace("'", "")))
    lost = ds.contact_lost.transpose("mean_force", "speed").values
    for i, fm in enumerate(forces):
        p = _exact_p(speeds, fm)
        want = {-FM: p.max(axis=1) > 0, 0.0: (p.min(axis=1) < 0) & (p.max(axis=1) > 0),
                FM: p.min(axis=1) < 0}[fm]
        assert np.array_equal(lost[i], want), fm
    assert lost[1].all() and not lost[0].all() and not lost[2].all()


def test_contact_lost_without_a_mean_force_is_a_change_of_flank():
    """F_m = 0 alone: the warning says the cases change flank; a p of one sign (a force
    harmonic pressing on a mean STE offset is not typed here, so p is the STE's lines about 0)
    would keep one flank."""
    with pytest.warns(ContactLossWarning, match=r"<text>: 1 of 1 case\(s\) change flank without"
                      r" a mean force \(p of both signs in the steady state.*takes the other"
                      r" flanks"):
        ds = gearsweep.run(whine([3000.0], spp=128, varying=False).replace(
            f"mean_force: {FM} N", "mean_force: 0 N"))
    assert bool(ds.contact_lost.item())


def test_contact_lost_is_not_made_where_it_means_nothing():
    """Not with backlash (``contact_loss_fraction`` says it), nor for an undriven scene (the
    stability studies: a homogeneous equation, whose sign is arbitrary). And below 0 nowhere:
    no warning."""
    quiet = whine([1000.0, 2000.0], spp=64, varying=False)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ds = gearsweep.run(quiet)
    assert not ds.contact_lost.any()
    plan = make_plan(parse_study(whine([1000.0], spp=64, varying=False, ste=False).replace(
        f"mean_force: {FM} N", "")))
    assert not plan.driven and "contact_lost" not in plan.specs
    rattle = make_plan(parse_study(whine([1000.0], spp=64, varying=False).replace(
        "kind: whine", "kind: full").replace(f"mean_force: {FM} N", f"mean_force: {FM} N\n"
                                               "  backlash: 0.1 mm")))
    assert rattle.has_backlash and "contact_lost" not in rattle.specs


def test_the_cli_says_how_many_cases_leave_contact(tmp_path):
    """The CLI prints the warning ``gearsweep.run`` gives, as one line, naming the file."""
    study = tmp_path / "w.yaml"
    study.write_text(whine([1000.0, 12000.0], spp=128, varying=False))
    out = tmp_path / "w.nc"
    proc = subprocess.run([sys.executable, "-m", "gearsweep", "run", str(study), "-o", str(out),
                           "-q"], capture_output=True, text=True, check=False)
    assert proc.returncode == 0, proc.stderr
    lines = [ln for ln in proc.stderr.splitlines() if "drive-flank" in ln]
    assert lines == [(f"gearsweep: warning: {out}: 1 of 2 case(s) leave drive-flank contact (p"
                     " below 0 in the steady state, variable 'contact_lost'): a scene without"
                     " backlash takes the back flanks into contact at once (a pair with no"
                     " backlash), where a real pair's teeth would separate; a full scene with"
                     " scene.backlash models that")]


E0_WHINE = """
title: e = 0, a 23/61 pair's k(t) typed in, low speed
scene:
  kind: whine
  mass: 0.2908 kg
  teeth: 23
  stiffness: 421.9 kN/mm
  stiffness_harmonics:
    - {amplitude: 129.3 kN/mm, order: 1, phase: -1.902 rad}
    - {amplitude: 38.47 kN/mm, order: 2, phase: -0.661 rad}
    - {amplitude: 22.05 kN/mm, order: 3, phase: -2.620 rad}
    - {amplitude: 31.55 kN/mm, order: 4, phase: -1.375 rad}
    - {amplitude: 5.152 kN/mm, order: 5, phase: -0.099 rad}
    - {amplitude: 17.96 kN/mm, order: 6, phase: -2.076 rad}
    - {amplitude: 14.70 kN/mm, order: 7, phase: -0.837 rad}
    - {amplitude: 4.302 kN/mm, order: 8, phase: -2.799 rad}
    - {amplitude: 14.17 kN/mm, order: 9, phase: -1.538 rad}
    - {amplitude: 5.631 kN/mm, order: 10, phase: -0.291 rad}
  damping: 1.1 N s/mm
  mean_force: 3701 N
sweep:
  speed: [500 rpm, 1000 rpm, 2000 rpm]
solver: {method: rk5, steps_per_period: 640, transient_periods: 200, record_periods: 50}
outputs: [stats, {spectrum: {max_order: 4, phase: true}}]
"""


def test_the_default_sampling_keeps_the_resonance_off_the_kept_lines():
    """e = 0: m p'' + c p' + k(t) p = F_m makes the dynamic mesh force k(t) p + c p' equal to
    F_m - m p'', so its order-n line is m (2 pi n f_mesh)^2 times p's, exactly, with p's phase.

    At 500 rpm the natural frequency is order r_n = sqrt(k0 / m) / (2 pi f_mesh) = 31.6, and
    the steady response of a time-varying k(t) carries every order, amplified near r_n and spread
    by the 10 harmonics. 40 samples per period (the default of 4 x the highest harmonic) folded
    orders 36-44 onto orders 1-4: force_spectrum 14-25 % above m w^2 p on orders 1-3, phase 1.34
    against 1.24 rad on order 1 (an outside tester). The default now takes more than
    r_n + H + max_order = 45.6 samples: 64 of 640's divisors.

    Tolerance 1e-4 on the amplitudes, 1e-4 rad on the phases: with every step sampled (640, no
    folding beyond the integration's own) the relation holds to 8e-7 (rk5's step error on lines
    about r_n^2 = 1000 times below k0 p's); at 64 samples orders >= 60 fold in, 2e-5."""
    k0, m, teeth = 421.9e6, 0.2908, 23
    speeds = np.array([500.0, 1000.0, 2000.0])
    f_mesh = teeth * speeds / 60
    r_n = math.sqrt(k0 / m) / (2 * math.pi * f_mesh[0])
    assert 31.6 < r_n < 31.7
    ds = run(E0_WHINE)
    assert (ds.status == 0).all()
    n = np.array([1.0, 2.0, 3.0, 4.0])
    p = si_values(ds.spectrum.sel(order=n))
    expect = m * (2 * math.pi * n[None, :] * f_mesh[:, None]) ** 2 * p
    assert_allclose(ds.force_spectrum.sel(order=n).values, expect, rtol=1e-4)
    phase = ds.force_spectrum_phase.sel(order=n).values - ds.spectrum_phase.sel(order=n).values
    assert np.max(np.abs(np.angle(np.exp(1j * phase)))) < 1e-4
    # the least divisor of 640 above r_n + 10 + 4
    assert ds.spectrum.attrs["samples_per_period"] == 64
    assert make_plan(parse_study(E0_WHINE), E0_WHINE).samples_per_period() == 64


def test_validate_warns_of_samples_that_fold_the_resonance_onto_the_kept_lines(tmp_path, capsys):
    """A samples_per_period written in the study is taken as it is, but where it folds orders up
    to r_n + H (31.6 + 10 at 500 rpm here) onto the kept ones, validate, run and gearsweep.run
    (a SpectrumAliasingWarning) say so, with the
    least number that does not (more than r_n + H + max_order = 45.6: 46) and the default's
    choice (64 of 640's divisors). The default itself, and 64 written in, are not warned of."""
    from gearsweep.cli import main

    r_n = math.sqrt(421.9e6 / 0.2908) / (2 * math.pi * 23 * 500 / 60)
    path = tmp_path / "e0.yaml"
    for written, warned in (("", False), (", samples_per_period: 40", True),
                            (", samples_per_period: 64", False)):
        path.write_text(E0_WHINE.replace("phase: true", "phase: true" + written),
                        encoding="utf-8")
        assert main(["validate", str(path)]) == 0
        err = capsys.readouterr().err
        assert ("samples_per_period 40: mesh orders up to"
                f" {r_n + 10:.3g} (r_n = f_n / f_mesh = {r_n:.3g} at 500 rpm") in err if warned \
            else "samples_per_period" not in err
        if warned:
            assert f"at least {math.ceil(r_n + 10 + 4)} avoid it" in err
            assert "the default takes 64" in err and err.count("\n") == 1
    import gearsweep
    from gearsweep.errors import SpectrumAliasingWarning

    with pytest.warns(SpectrumAliasingWarning, match=r"samples_per_period 40: mesh orders up to"
                      r" 41\.6 .*the default takes 64"):  # gearsweep.run: the same line
        gearsweep.run(E0_WHINE.replace("phase: true", "phase: true, samples_per_period: 40"))


def test_the_resonant_order_of_a_load_sweep_is_its_stiffest_loads():
    """A relieved pair's k0 grows with the load (163 kN/mm at 12.5 N m, 219 at 100 N m): the
    default sampling takes r_n of the stiffest load, whichever load the sweep lists first.
    Truth: the 100 N m load in a study of its own; r_n = sqrt(k0 / m) / (2 pi 48 x 300 / 60)."""
    from gearsweep.study.outputs import resonant_order

    base = """title: relieved pair
scene:
  kind: whine
  gear: {preset: table1_consistent,
         tip_relief: {amount: 6 um, shape: linear, start_at: single_contact}}
  mass: 0.1527 kg
  damping: 5.5 N*s/mm
sweep:
  speed: [300 rpm, 600 rpm]
  torque: TORQUES
solver: {method: rk4, steps_per_period: 640, transient_periods: 10, record_periods: 2}
outputs: [stats, spectrum]
"""
    alone = make_plan(parse_study(base.replace("TORQUES", "[100 N*m]")))
    k0 = alone.model.stiffness
    r_n = math.sqrt(k0 / 0.1527) / (2 * math.pi * 48 * 300 / 60)
    assert_allclose(resonant_order(alone), (r_n, 300.0), rtol=1e-12)
    for torques in ("[12.5 N*m, 100 N*m]", "[100 N*m, 12.5 N*m]"):
        plan = make_plan(parse_study(base.replace("TORQUES", torques)))
        assert_allclose(resonant_order(plan), (r_n, 300.0), rtol=1e-12)
        assert plan.samples_per_period() == alone.samples_per_period()
    light = make_plan(parse_study(base.replace("TORQUES", "[12.5 N*m]")))
    assert light.model.stiffness < 0.8 * k0 and resonant_order(light)[0] < 0.9 * r_n


# An outside tester: k_orders=[1.5], f_orders=[2.7] returned exactly the response of orders 1
# and 2 (the orders were cut to integers in silence), and k_orders=[0.5] was refused as "got 0".
@pytest.mark.parametrize(("k_orders", "f_orders", "named"), [
    ([1.5], [1], "k_orders: order 1.5 "), ([1], [2.7], "f_orders: order 2.7 "),
    ([0.5], [1], "k_orders: order 0.5 "), ([1, 41], [1], "k_orders: order 41 ")])
def test_periodic_response_refuses_a_fractional_order_naming_the_value_typed(k_orders, f_orders,
                                                                            named):
    w = mesh_omega([5000.0])
    with pytest.raises(ValueError, match=rf"^{named}is not allowed: orders must be whole numbers"
                                         r" 1\.\.40"):
        periodic_response(M, C, K0, w, k_amplitudes=[0.1 * K0] * len(k_orders),
                          k_orders=k_orders, f_amplitudes=[100.0], f_orders=f_orders)
    # a whole order typed as a float is that order
    assert_allclose(periodic_response(M, C, K0, w, k_amplitudes=[0.1 * K0], k_orders=[2.0],
                                      f_amplitudes=[100.0], f_orders=[1.0]),
                    periodic_response(M, C, K0, w, k_amplitudes=[0.1 * K0], k_orders=[2],
                                      f_amplitudes=[100.0], f_orders=[1]), rtol=0, atol=0)


# An outside tester: f_amplitudes=[1., 2.] with f_orders=[1] raised numpy's broadcast message,
# k_orders longer than k_amplitudes a bare "zip() argument 2 is longer than argument 1".
@pytest.mark.parametrize(("kwargs", "says"), [
    ({"f_amplitudes": [1.0, 2.0], "f_orders": [1]},
     ("f_amplitudes and f_orders must have the same length (one order per amplitude); got"
     " f_amplitudes 2, f_orders 1")),
    ({"k_amplitudes": [0.1 * K0], "k_orders": [1, 2]},
     ("k_amplitudes and k_orders must have the same length (one order per amplitude); got"
     " k_amplitudes 1, k_orders 2")),
    ({"k_amplitudes": [0.1 * K0, 0.01 * K0], "k_orders": [1, 2], "k_phases": [0.0]},
     ("k_amplitudes, k_orders and k_phases must have the same length (one order and phase per"
     " amplitude); got k_amplitudes 2, k_orders 2, k_phases 1")),
    ({"f_amplitudes": [[1.0, 2.0, 3.0]] * 2, "f_orders": [1, 2]},
     ("f_amplitudes' columns and f_orders must have the same length (one order per amplitude);"
     " got f_amplitudes' columns 3, f_orders 2")),
    ({"f_amplitudes": [1.0, 2.0], "f_orders": [1, 2], "f_phases": [0.0, 1.0, 2.0]},
     ("f_amplitudes, f_orders and f_phases must have the same length (one order and phase per"
     " amplitude); got f_amplitudes 2, f_orders 2, f_phases 3")),
    ({"f_amplitudes": [[1.0]] * 3, "f_orders": [1]},
     ("f_amplitudes has 3 rows and omega 2 values; allowed: one row per value of omega, or a"
     " 1-D array")),
])
def test_periodic_response_refuses_mismatched_lengths_naming_the_arguments(kwargs, says):
    with pytest.raises(ValueError, match=f"^periodic_response: {re.escape(says)}$"):
        periodic_response(M, C, K0, mesh_omega([3000.0, 5000.0]), **kwargs)


def test_ste_force_refuses_mismatched_lengths_naming_the_arguments():
    """One order per STE amplitude: [5 um, 1 um] with orders [1] broadcast in silence to two
    lines of order 1."""
    with pytest.raises(ValueError, match=r"^ste_force: amplitudes and orders must have the same"
                                         r" length \(one order per amplitude\); got amplitudes 2,"
                                         r" orders 1$"):
        ste_force(M, mesh_omega([3000.0]), [5e-6, 1e-6], [1])


def test_a_scalar_force_amplitude_is_every_orders_against_the_closed_form():
    """A scalar f_amplitudes is still each order's (numpy's broadcast, kept): constant stiffness,
    F cos(n W t) at n = 1, 2 gives P_n = F / (k0 - m (n W)^2 + i c n W)."""
    w = mesh_omega([3000.0])
    got = periodic_response(M, C, K0, w, f_amplitudes=100.0, f_orders=[1, 2], harmonics=4)
    n = np.array([1, 2])
    assert_allclose(got[0, 1:3], 100.0 / (K0 - M * (n * w[0]) ** 2 + 1j * C * n * w[0]),
                    rtol=1e-12)
    assert_allclose(got[0, [0, 3, 4]], 0.0, atol=1e-25)


def _multiplier_ivp(mass, damping, k0, k1, omega):
    """Largest |mu| per mesh period of m p'' + c p' + (k0 + k1 cos(W t)) p = 0, its monodromy
    integrated by scipy (DOP853, rtol 1e-10), independent of the kernels."""
    from scipy.integrate import solve_ivp

    def rhs(t, y):
        return [y[1], -(damping * y[1] + (k0 + k1 * np.cos(omega * t)) * y[0]) / mass]

    T = 2 * np.pi / omega
    cols = [solve_ivp(rhs, (0, T), y0, method="DOP853", rtol=1e-10, atol=1e-14).y[:, -1]
            for y0 in ([1.0, 0.0], [0.0, omega])]
    return np.abs(np.linalg.eigvals(np.array(cols).T / [1.0, omega])).max()


# An outside tester: periodic_response returned a finite "periodic response" with no word where
# the homogeneous equation is parametrically unstable (k1 = 1050 kN/mm at a 26 kHz mesh, Floquet
# multiplier 2.08 per mesh period), though its docstring makes the steady state exist only where
# that equation is stable.
def test_periodic_response_warns_where_the_homogeneous_equation_is_unstable():
    from gearsweep.errors import UnstableEquationWarning

    m, c, k0, k1 = 0.1527, 256.0, 1.073e9, 1050e6
    args = dict(k_amplitudes=[k1], k_orders=[1], mean_force=833.0, f_amplitudes=[300.0],
                f_orders=[1])
    unstable, stable = 2 * np.pi * 26000.0, 2 * np.pi * 1600.0
    mu = _multiplier_ivp(m, c, k0, k1, unstable)
    assert mu == pytest.approx(2.085, abs=5e-4)
    with pytest.warns(UnstableEquationWarning, match=rf"1 of 2 mesh frequencies \(largest Floquet"
                                                     rf" multiplier per mesh period {mu:.4g} at"
                                                     r" 26000 Hz\)"):
        periodic_response(m, c, k0, np.array([stable, unstable]), **args)
    assert _multiplier_ivp(m, c, k0, k1, stable) < 1.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        periodic_response(m, c, k0, np.array([stable]), **args)  # stable: no warning

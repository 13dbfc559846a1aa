"""The ``period`` output: the period of a steady motion from p once per mesh period.

Truths: sequences built with a known period; a linear scene, whose steady response to a periodic
excitation has the excitation's period; and the rattle scene of Fig. 8 past its flip, where the
harmonic balance's Floquet multiplier below -1 says the period-1 motion is unstable
(tests/test_rattle.py::test_lower_branch_with_mean_force_period_doubles), so the integration
cannot settle on period 1.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

import gearsweep
from gearsweep.analysis.period import motion_period
from gearsweep.errors import StudyError

ROOT = Path(__file__).resolve().parents[1]
RNG = np.random.default_rng(7)


@pytest.mark.parametrize("period", [1, 2, 3, 4, 6, 10])
def test_motion_period_finds_the_period_of_a_repeating_sequence(period):
    orbit = RNG.uniform(-1.0, 1.0, period)
    q = np.tile(orbit, 20 // period + 1)[:20]
    q = q + 1e-5 * RNG.standard_normal(q.size)  # below the tolerance of 1e-3 x p_pp (2)
    p, mismatch = motion_period(q[None, :], np.array([2.0]), 1e-3)
    assert p[0] == period
    assert 0 < mismatch[0] <= 1e-3


def test_motion_period_of_an_irregular_or_too_long_sequence_is_nan():
    q = np.vstack([RNG.uniform(-1, 1, 20),                       # irregular
                   np.tile(RNG.uniform(-1, 1, 11), 2)[:20]])     # period 11 > 20 / 2
    p, mismatch = motion_period(q, np.array([2.0, 2.0]), 1e-3)
    assert np.isnan(p).all()
    assert (mismatch > 1e-3).all()  # the smallest over the periods tried, still above


def test_motion_period_at_rest_and_not_finite():
    q = np.array([[0.5] * 8, [0.0, 1.0, np.nan, 1.0, 0.0, 1.0, 0.0, 1.0]])
    p, mismatch = motion_period(q, np.array([0.0, 1.0]), 1e-3)
    assert p[0] == 1 and mismatch[0] == 0.0
    assert np.isnan(p[1]) and np.isnan(mismatch[1])


def _fig08(speeds, transient=200, record=20, outputs=("stats", "period")):
    s = yaml.safe_load((ROOT / "studies/fig08_rattle.yaml").read_text(encoding="utf-8"))
    s.pop("continuation", None)
    s["sweep"] = {"speed": list(speeds)}
    s["solver"].update(transient_periods=transient, record_periods=record)
    s["outputs"] = list(outputs)
    return gearsweep.run(s)


def test_period_output_tells_period_one_from_the_motion_past_the_flip():
    """6000 rpm, below the jumps: the motion has the mesh period. 9500 rpm, past the flip
    (7542 rpm): the harmonic balance's period-1 solution has a multiplier below -1, so the
    integration settles on something else; the settle test (status) may still pass it."""
    ds = _fig08([6000.0, 9500.0])
    assert ds.motion_period.sel(speed=6000.0) == 1
    assert ds.period_mismatch.sel(speed=6000.0) < 1e-6
    p = float(ds.motion_period.sel(speed=9500.0))
    assert np.isnan(p) or p >= 2
    assert ds.period_mismatch.sel(speed=9500.0) > 1e-3
    assert ds.motion_period.attrs["units"] == "1" and "long_name" in ds.motion_period.attrs


def test_a_linear_scene_responds_with_the_period_of_its_excitation():
    """Whine (no backlash), time-varying stiffness and STE: a stable linear periodic system's
    steady response has the excitation's period, one mesh period."""
    s = yaml.safe_load((ROOT / "studies/whine_speed_sweep.yaml").read_text(encoding="utf-8"))
    s["sweep"] = {"speed": [3000.0, 7000.0, 12000.0]}
    s["outputs"] = ["stats", "period"]
    ds = gearsweep.run(s)
    assert (ds.motion_period == 1).all()


def test_period_beside_a_spectrum_uses_one_sample_per_period_of_its_signal():
    alone = _fig08([6000.0, 9500.0])
    both = _fig08([6000.0, 9500.0], outputs=("stats", "period", {"spectrum": {"max_order": 2}}))
    np.testing.assert_array_equal(alone.motion_period, both.motion_period)
    np.testing.assert_allclose(alone.period_mismatch, both.period_mismatch, rtol=1e-12)


def test_period_needs_two_recorded_periods():
    with pytest.raises(StudyError, match="record_periods"):
        _fig08([6000.0], record=1)


def test_the_estimate_prices_the_period_output_by_its_comparisons():
    """motion_period compares every pair of samples P apart up to R / 2: its time grows as
    cases x R^2, and a long record made it the bulk of a run (16.2 s of 16.7 s at 2,000 cases
    and 4,000 recorded periods) while --estimate priced it 0 s. Truth: the CPU time of
    motion_period itself on samples of the study's shape (best of 2), within 3x."""
    import time

    from gearsweep.study.estimate import quick_estimate
    from gearsweep.study.plan import make_plan
    from gearsweep.study.schema import parse_study

    s = yaml.safe_load((ROOT / "studies/fig08_rattle.yaml").read_text(encoding="utf-8"))
    s.pop("continuation")
    s["sweep"] = {"speed": {"start": 5000, "stop": 11000, "num": 100}}
    s["solver"]["record_periods"] = 2000

    def est(outputs):
        text = yaml.safe_dump(dict(s, outputs=outputs))
        return quick_estimate(make_plan(parse_study(text), text), ask_cache=False)[0]

    priced = est(["stats", "period"]).output_seconds - est(["stats"]).output_seconds
    q = RNG.standard_normal((100, 2000))  # irregular: no period, every P tried
    took = []
    for _ in range(2):  # CPU time: the work priced, not the wall time that another process's
        t0 = time.process_time()  # load stretches (two busy cores beside it: wall 1.8x the
        motion_period(q, np.full(100, 8.0), 1e-3)  # price, CPU 1.18x; idle 1.2x and 1.13x)
        took.append(time.process_time() - t0)
    assert min(took) / 3 < priced < 3 * min(took)


MED = """\
title: whine with its period
scene: {kind: whine, mass: 0.1527 kg, teeth: 48, stiffness: 1073 kN/mm,
        stiffness_harmonics: [{amplitude: 179 kN/mm}], ste: [{amplitude: 5 um}],
        damping: 5.5 N*s/mm, mean_force: 833 N}
sweep:
  speed: {start: 1000 rpm, stop: 20000 rpm, num: 400}
  damping: {start: 1 N*s/mm, stop: 10 N*s/mm, num: DAMPINGS}
solver: {method: rk4, steps_per_period: 64, transient_periods: 1000, record_periods: 4000}
outputs: OUTPUTS
"""
"""An outside tester's whine study: a linear scene, whose settled motion has the period of its
excitation (1 mesh period); 400 x 20 cases ran in 4.2 s."""


def _med(dampings: int, outputs: str):
    from gearsweep.study.estimate import quick_estimate
    from gearsweep.study.plan import make_plan
    from gearsweep.study.schema import parse_study

    text = MED.replace("DAMPINGS", str(dampings)).replace("OUTPUTS", outputs)
    return quick_estimate(make_plan(parse_study(text), text), ask_cache=False)[0]


def test_the_estimate_prices_a_linear_scene_s_period_output_at_its_excitation_s_cycle():
    """The period output was priced as if no case had a period (3 R^2 / 8 comparisons a case):
    8,000 whine cases at 4,000 recorded periods said "about 67.2 s" and took 4.2 s, and 80,000
    were refused ("time > 10.0 min ... about 11.1 min") for about 45 s. A driven scene without
    backlash settles on its excitation's period: truth, the CPU time of motion_period on
    period-1 samples of the study's shape, within 3x; the worst case is said as a bound."""
    import time

    from gearsweep.study.execute import _duration
    from gearsweep.study.outputs import PERIOD_COMPARE_SECONDS

    priced = (_med(20, "[stats, period]").output_seconds - _med(20, "[stats]").output_seconds)
    q = np.repeat(RNG.standard_normal((1000, 1)), 4000, axis=1)  # period 1, a chunk's worth
    took = []
    for _ in range(3):  # CPU time, the best of 3 (see the test above)
        t0 = time.process_time()
        period, _ = motion_period(q, np.full(1000, 8.0), 1e-3)
        took.append(8 * (time.process_time() - t0))  # 8,000 cases
    assert (period == 1).all()
    assert min(took) / 3 < priced < 3 * min(took), (priced, took)
    est = _med(20, "[stats, period]")
    assert est.worst_seconds - est.seconds == pytest.approx(
        8000 * sum(4000 - p for p in range(1, 2001)) * PERIOD_COMPARE_SECONDS - priced)
    assert (f"about {_duration(est.seconds)} (at most {_duration(est.worst_seconds)} if no case's"
            " motion repeats within half its record: the period output) on ") in est.line()


def test_a_linear_scene_with_the_period_output_is_held_to_its_typical_time_not_its_bound():
    """80,000 cases: the typical time is within the 10 min limit (the run takes about 45 s),
    the bound (every case without a period) beyond it; the study is not refused."""
    from gearsweep.study.execute import LIMITS

    est = _med(200, "[stats, period]")
    assert est.seconds < LIMITS.seconds < est.worst_seconds
    assert est.over() == []

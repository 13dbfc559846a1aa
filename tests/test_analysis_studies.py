"""Analysis studies (``type: analysis``): computed into Datasets that figure scripts only draw."""

from __future__ import annotations

import numpy as np
import pytest

import gearsweep
from gearsweep.analysis.advise import stability_limit
from gearsweep.errors import StudyError


def test_method_stability_study_measures_the_polynomials_limit():
    """The kernel's measured limit on the free oscillator lies on the stability polynomial's
    (RK4's undamped limit 2 sqrt(2) is the closed form), just above it by the step at which
    |R|^steps reaches the blow-up bound (near the imaginary axis, zeta -> 0, that margin is wide:
    RK5 at zeta = 0 measures 0.90 against 0.852 with 2e5 steps, so the check is at zeta = 0.3)."""
    ds = gearsweep.run({"type": "analysis", "title": "limits", "analysis": {
        "kind": "method_stability", "zeta": [0.3], "curve_points": 5, "zeta_max": 0.4,
        "steps": 100_000}})
    assert ds.measured_limit.dims == ("method", "zeta")
    assert float(ds.polynomial_limit.sel({"method": "rk4", "zeta_curve": 0.0})) == pytest.approx(
        2 * np.sqrt(2), rel=1e-9)
    for m in ("rk4", "rk5"):  # at zeta = 0.3 the pole's ray crosses |R| = 1 steeply
        measured = float(ds.measured_limit.sel({"method": m, "zeta": 0.3}))
        predicted = stability_limit(m, 0.3)
        assert predicted <= measured <= predicted * (1 + 1e-2), (m, measured, predicted)
    coef = ds.stability_polynomial.sel({"method": "rk4"}).values
    np.testing.assert_allclose(coef[:5], [1, 1, 1 / 2, 1 / 6, 1 / 24], rtol=1e-15)
    assert ds.attrs["study"] and ds.measured_limit.attrs["units"] == "1"


def test_work_precision_study_gives_errors_costs_and_orders():
    ds = gearsweep.run({"type": "analysis", "title": "wp", "analysis": {
        "kind": "work_precision", "scenes": ["whine"], "methods": ["rk4"],
        "steps_per_period": [16, 32, 64, 128], "peers": ["RK45"], "rtol": [1e-5],
        "transient_periods": 10, "record_periods": 5, "copies": 4, "repeat": 1}})
    err = ds.trajectory_error.sel({"scene": "whine", "method": "rk4"}).values
    assert np.all(np.diff(err) < 0)  # halving the step lowers the error
    assert float(ds.order.sel({"scene": "whine", "method": "rk4"})) == pytest.approx(4.0, abs=0.3)
    assert np.all(ds.rhs_evaluations.values == 4 * 15 * ds.steps_per_period.values)
    assert np.isfinite(ds.peer_trajectory_error.values).all()


def test_bad_analysis_options_are_one_line():
    with pytest.raises(StudyError, match=r"steps_per_period must be multiples of 8"):
        gearsweep.run({"type": "analysis", "title": "wp", "analysis": {
            "kind": "work_precision", "steps_per_period": [10, 20, 40]}})
    with pytest.raises(StudyError, match=r"analysis"):
        gearsweep.run({"type": "analysis", "title": "x", "analysis": {"kind": "nope"}})

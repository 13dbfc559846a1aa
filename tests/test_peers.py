"""The compiled peers of issue 25 against the reference solutions, and the committed data file.

Each installed peer integrates a few cases of the whine and rattle batches; its error against
the independent reference (DOP853 at rtol 1e-12 with crossing events, or the exact piecewise
solution) must fall with its tolerance. A peer that is not installed is skipped.
"""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

from gearsweep.analysis import peers as P

ROOT = Path(__file__).resolve().parents[1]


def _has(mod: str) -> bool:
    return importlib.util.find_spec(mod) is not None


@pytest.fixture(scope="module", params=["whine", "rattle"])
def batch_ref(request):
    batch = P.BATCHES[request.param](3, n_error=3)
    return batch, P.references(batch)


def _max_errors(run, batch, ref):
    te, ae = P.errors_of(run, batch, ref)
    cover = np.isin(batch.error_cases, run.case_index)
    return float(np.max(te[cover])), float(np.max(ae[cover]))


def _check_converges(runner, batch, ref, tight: float):
    """Loose tolerance: visible error; tight tolerance: error below 100 rtol and 10x smaller."""
    loose = _max_errors(runner(1e-3), batch, ref)
    fine = _max_errors(runner(tight), batch, ref)
    assert math.isfinite(fine[0]) and fine[0] < 1e4 * tight
    assert fine[0] < loose[0] / 10
    assert fine[1] <= fine[0] + 1e-15  # amplitude error never exceeds the trajectory error


def test_gearsweep_batch_matches_reference_at_every_speed(batch_ref):
    # per-case step and STE scale: each speed must match its own reference
    batch, ref = batch_ref
    spp = 256
    kink = batch.name == "rattle"
    run = P.run_gearsweep(batch, "rk5", spp, kink_aware=kink, repeat=1)
    te, _ = P.errors_of(run, batch, ref)
    assert np.all(te < 1e-6), te
    coarse = P.run_gearsweep(batch, "rk5", 16, kink_aware=kink, repeat=1)
    assert np.max(P.errors_of(coarse, batch, ref)[0]) > 10 * np.max(te)


def test_banded_gearsweep_runs_each_band_at_its_own_step():
    batch = P.whine_batch(3, n_error=3)  # 3000, 7500, 12000 rpm: two bands of ratio <= 2
    ref = P.references(batch)
    bands = P.speed_bands(batch, 2.0)
    assert [list(b) for b in bands] == [[0], [1, 2]]
    run = P.run_gearsweep_banded(batch, "rk5", 128, ratio=2.0, repeat=1)
    # band 2 starts at 7500 rpm: 8 ceil(128 * 3000 / 7500 / 8) = 56 steps per period
    assert run.rhs_evaluations[1] == pytest.approx(run.rhs_evaluations[0] * 56 / 128)
    te, _ = P.errors_of(run, batch, ref)
    # each case matches its own reference and a single call at its band's step count
    assert te.max() < 1e-5
    single56 = P.run_gearsweep(batch, "rk5", 56, repeat=1)
    np.testing.assert_allclose(run.p[1:], single56.p[1:], rtol=0, atol=1e-12 * np.abs(ref).max())


@pytest.mark.skipif(not _has("numbalsoda"), reason="numbalsoda not installed")
@pytest.mark.parametrize("solver", ["LSODA", "DOP853"])
def test_numbalsoda(batch_ref, solver):
    batch, ref = batch_ref
    P.numbalsoda_compile(batch, solver)
    _check_converges(lambda tol: P.run_numbalsoda(batch, tol, solver, repeat=1), batch, ref, 1e-9)
    run = P.run_numbalsoda(batch, 1e-6, solver, repeat=1)
    assert np.all(run.rhs_evaluations > 100)


@pytest.mark.skipif(not (_has("diffrax") and _has("jax")), reason="diffrax/jax not installed")
def test_diffrax_tsit5(batch_ref):
    batch, ref = batch_ref
    compiled, _, per_step = P.diffrax_compile(batch, "Tsit5")
    assert per_step == 6  # 7 stages, first same as last
    _check_converges(lambda tol: P.run_diffrax(batch, compiled, per_step, tol, repeat=1), batch,
                     ref, 1e-9)


@pytest.mark.skipif(not (_has("diffrax") and _has("jax") and _has("optimistix")),
                    reason="diffrax/jax/optimistix not installed")
def test_diffrax_events_at_the_backlash_crossings():
    # rattle: events at |p| = b restore the step control that the dead zone's kinks ruin; against
    # the exact piecewise reference the events variant must be accurate at a tight tolerance and
    # at least 10x more accurate than the same solver without events at the same tolerance
    batch = P.rattle_batch(3, n_error=3)
    ref = P.references(batch)
    ev, _, per_step = P.diffrax_event_compile(batch, "Dopri5")
    plain, _, _ = P.diffrax_compile(batch, "Dopri5")
    tol = 1e-8
    run = P.run_diffrax_events(batch, ev, per_step, tol, repeat=1)
    te, ae = _max_errors(run, batch, ref)
    te0, ae0 = _max_errors(P.run_diffrax(batch, plain, per_step, tol, repeat=1), batch, ref)
    assert te < 1e-6 and ae < 1e-6, (te, ae)
    assert te < te0 / 10 and ae < ae0 / 10, (te, te0, ae, ae0)
    # every case went through its crossings piece by piece (about 4 per mesh period)
    assert run.notes["pieces_max"] > 2 * batch.window.periods
    assert np.all(run.rhs_evaluations > 0)
    # and it converges with the tolerance
    loose = _max_errors(P.run_diffrax_events(batch, ev, per_step, 1e-5, repeat=1), batch, ref)
    assert te < loose[0] / 30


@pytest.mark.skipif(not _has("numbalsoda"), reason="numbalsoda not installed")
def test_numbalsoda_events_at_the_backlash_crossings():
    # numbalsoda's solve_ivp (DOP853) stopped at each crossing and restarted on the next piece:
    # more accurate than its DOP853 through the kinks at the same tolerance
    batch = P.rattle_batch(3, n_error=3)
    ref = P.references(batch)
    tol = 1e-10
    run = P.run_numbalsoda_events(batch, tol, repeat=1)
    te, ae = _max_errors(run, batch, ref)
    P.numbalsoda_compile(batch, "DOP853")
    te0, ae0 = _max_errors(P.run_numbalsoda(batch, tol, "DOP853", repeat=1), batch, ref)
    assert te < 1e-7 and ae < 1e-8, (te, ae)
    assert te < te0 / 5, (te, te0)
    assert 2 * batch.window.periods < run.notes["pieces_max"] < P.MAX_SEGMENTS
    loose = _max_errors(P.run_numbalsoda_events(batch, 1e-6, repeat=1), batch, ref)
    assert te < loose[0] / 30
    with pytest.raises(ValueError, match="backlash"):
        P.run_numbalsoda_events(P.whine_batch(2, n_error=2), tol, repeat=1)


@pytest.mark.skipif(not (_has("diffrax") and _has("jax") and _has("optimistix")),
                    reason="diffrax/jax/optimistix not installed")
def test_diffrax_events_need_backlash():
    with pytest.raises(ValueError, match="backlash"):
        P.diffrax_event_compile(P.whine_batch(2, n_error=2), "Dopri5")


@pytest.mark.skipif(not _has("sksundae"), reason="scikit-sundae not installed")
def test_cvode(batch_ref):
    batch, ref = batch_ref
    _check_converges(lambda tol: P.run_cvode(batch, tol, batch.error_cases), batch, ref, 1e-9)


def test_scipy_peer_is_precision_run_scipy(batch_ref):
    # the peers' scaled right-hand side must give the chart's scipy run (same tolerances)
    from gearsweep.analysis import precision as pr

    batch, ref = batch_ref
    run = P.run_scipy(batch, "DOP853", 1e-7, batch.error_cases[:1])
    i = int(batch.error_cases[0])
    old = pr.run_scipy(batch.scenes[i], "DOP853", 1e-7, batch.window, ref[0])
    te, _ = P.errors_of(run, batch, ref)
    assert te[0] == pytest.approx(old.trajectory_error, rel=0.5, abs=1e-9)


def test_cost_at_interpolates_a_power_law():
    n = np.array([10.0, 100.0, 1000.0, 10000.0])
    err = n ** -4.0
    assert P.cost_at(err, n, 1e-10)[0] == pytest.approx(316.227766, rel=1e-9)
    assert P.cost_at(err, n, 1e-3) == (10.0, "<")
    c, flag = P.cost_at(err, n, 1e-20)
    assert math.isnan(c) and flag == "none"
    # a non-monotone curve: the running minimum of the error counts
    assert P.cost_at([1e-2, 1e-6, 1e-4, 1e-8], n, 1e-6)[0] == pytest.approx(100.0)


def _figure_module():
    spec = importlib.util.spec_from_file_location("fig_peers",
                                                  ROOT / "scripts" / "fig_work_precision_peers.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_committed_data_has_what_the_figure_draws():
    xr = pytest.importorskip("xarray")
    fig = _figure_module()
    path = ROOT / "docs" / "data" / "work_precision_peers.nc"
    with xr.open_dataset(path) as ds:
        assert set(ds.scene.values) == {"whine", "rattle", "B1"}
        for v in fig.DRAWN:
            assert v in ds.variables, v
        for name, v in ds.variables.items():
            assert "units" in v.attrs and "long_name" in v.attrs, name
        for k in ds.attrs:
            assert "-" not in k, k
        assert int(ds.cases.min()) >= 1000
        for s in ds.scene.values:
            for m in ("rk4", "rk5"):
                e = ds.amplitude_error.sel({"scene": s, "method": m}).values
                assert np.isfinite(e).sum() >= 3
                assert np.isfinite(ds.wall_time.sel({"scene": s, "method": m}).values).sum() >= 3


def test_figure_draws_from_the_committed_file(tmp_path):
    pytest.importorskip("xarray")
    fig = _figure_module()
    import xarray as xr

    with xr.open_dataset(ROOT / "docs" / "data" / "work_precision_peers.nc") as ds:
        fig.plot(ds.load(), tmp_path / "wp.png")
    assert (tmp_path / "wp.png").stat().st_size > 10_000


def test_figure_script_refuses_an_unreadable_data_file_in_one_line(tmp_path):
    """A --data file that is missing or not netCDF: one line naming it, exit 2 (it was a
    netCDF4 traceback)."""
    import subprocess
    import sys

    for bad in (tmp_path / "none.nc", ROOT / "README.md"):
        proc = subprocess.run([sys.executable, str(ROOT / "scripts" / "fig_work_precision_peers.py"),
                               "--data", str(bad), "--out", str(tmp_path / "x.png")],
                              capture_output=True, text=True, timeout=120)
        assert proc.returncode == 2, proc.stderr
        lines = proc.stderr.strip().splitlines()
        assert len(lines) == 1 and str(bad) in lines[0], proc.stderr

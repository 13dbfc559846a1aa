"""Analysis studies (``type: analysis``): computed into Datasets that figure scripts only draw."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

import gearsweep
from gearsweep.analysis.advise import stability_limit
from gearsweep.cli import main
from gearsweep.errors import StudyError
from gearsweep.study.schema import replaced_by_sweep

ROOT = Path(__file__).resolve().parents[1]


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
    with pytest.raises(StudyError, match=r"steps_per_period\[0\]: 10 -- Input should be a multiple"
                                         r" of 8"):
        gearsweep.run({"type": "analysis", "title": "wp", "analysis": {
            "kind": "work_precision", "steps_per_period": [10, 20, 40]}})
    with pytest.raises(StudyError, match=r"analysis"):
        gearsweep.run({"type": "analysis", "title": "x", "analysis": {"kind": "nope"}})


RATTLE = {  # the Fig. 8 scene (studies/fig08_rattle.yaml) on a coarse, cheap grid
    "title": "small rattle",
    "scene": {"kind": "rattle", "mass": "0.1527 kg", "teeth": 48, "stiffness": "1073 kN/mm",
              "damping": "4.92 N*s/mm", "backlash": "0.4698 mm", "torque": "50 N*m",
              "base_radius": "56.38 mm", "fluctuation": [{"amplitude": "67.8 kN", "order": 1}]},
    "sweep": {"speed": {"start": "7000 rpm", "stop": "8600 rpm", "num": 33}},
    "continuation": ["up", "down"],
    "solver": {"method": "rk4", "steps_per_period": 32, "transient_periods": 30,
               "record_periods": 4, "initial_displacement": "static"},
    "outputs": ["stats", "period"],
}


@pytest.mark.parametrize("step", ["1e-300 rpm", "0.01 rpm"])
def test_an_eq15_step_too_fine_for_the_result_s_speeds_is_one_line(tmp_path, capsys, step,
                                                                   monkeypatch):
    """eq15_step: 1e-300 rpm ended in numpy's ValueError 'Maximum allowed size exceeded' (a
    traceback) and 1e-6 rpm in 'out of memory' (44.7 GiB for the Eq. (15) speeds); validate said
    ok (found by a fuzzer). Over the result's 7000-8600 rpm, 0.01 rpm is 160,000 speeds, more
    than the 100,000 points the other point counts of an analysis take."""
    small = {**RATTLE, "sweep": {"speed": {"start": "7000 rpm", "stop": "8600 rpm", "num": 3}},
             "solver": {**RATTLE["solver"], "transient_periods": 2}}
    monkeypatch.chdir(tmp_path)  # validate and run read results/ (run's default output folder)
    gearsweep.run(small, output=tmp_path / "results" / "small.nc")
    study = tmp_path / "b.yaml"
    study.write_text(f"type: analysis\ntitle: b\nanalysis:\n  kind: rattle_balance\n"
                     f"  result: small\n  eq15_step: {step}\n", encoding="utf-8")
    for argv in (["validate", str(study)], ["run", str(study)]):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"gearsweep: error: {study}:6: analysis.eq15_step: ") and (
            "at most 100,000 speeds" in err) and err.count("\n") == 1, err
    assert not (tmp_path / "results" / "b.nc").exists()


@pytest.mark.slow
def test_rattle_balance_reads_the_result_it_balances(tmp_path):
    """The balance of a rattle result uses the model the result carries: the describing
    function's turning points are the fit's targets (7,500 / 8,000 rpm), Eq. (15)'s limits are
    the closed forms, and the jumps and amplitudes are the integration's."""
    from gearsweep.analysis import rattle as rfit
    from gearsweep.model import RPM
    from gearsweep.study.jumps import jump_summary

    res = gearsweep.run(RATTLE, output=tmp_path / "small.nc")
    bal = gearsweep.run({"type": "analysis", "title": "balance", "analysis": {
        "kind": "rattle_balance", "result": "small", "harmonics": 5, "n_time": 64}},
        output=tmp_path / "small_balance.nc")
    m, k, b, f0 = 0.1527, 1073e6, 0.4698e-3 / 2, 67.8e3
    w = 48 * RPM
    tp = bal.turning_point.sel(curve="describing_function").values
    assert_allclose(tp[np.isfinite(tp)], [7500.0, 8000.0], atol=10.0)  # c, F0 rounded to 3 digits
    assert float(bal.eq15_rise_speed) == pytest.approx(np.sqrt(f0 / (m * b)) / w, rel=1e-3)
    assert float(bal.eq15_drop_speed) == pytest.approx(np.sqrt(k / m) / w, rel=1e-12)
    js = jump_summary(res)
    assert float(bal.jump_up_speed) == float(js.jump_up_speed)
    assert float(bal.jump_down_speed) == float(js.jump_down_speed)
    amp = (0.5 * res.p_pp).where(res.status == 0).sel(direction="up").values
    assert_allclose(bal.amplitude.sel(direction="up").values, amp)
    assert res.p_pp.attrs["units"] == "um"  # eq15_distance takes SI
    d = rfit.eq15_distance(res.speed.values, amp * 1e-6, omega_per_rpm=w, force_amp=f0,
                           stiffness=k, mass=m, half_gap=b)
    assert_allclose(bal.eq15_distance.sel(direction="up").values, d.relative)
    assert bal.aft_speed.size > 10 and bal.attrs["input_small"] == res.attrs["study_sha256"]
    # the counts of motions without a short period (the figure's note)
    assert int(bal.no_period) == int(res.motion_period.isnull().sum())
    assert int(bal.no_period_settled) == int((res.motion_period.isnull() & (res.status == 0)).sum())
    assert int(bal.longest_period) == RATTLE["solver"]["record_periods"] // 2
    jm = gearsweep.run({"type": "analysis", "title": "jumps", "analysis": {
        "kind": "jump_map", "result": "small", "loss_threshold": 0.5}},
        output=tmp_path / "small_jumps.nc")
    share = float((res.contact_loss_fraction.max("direction") > 0.5).mean())
    assert 0 < share < 1 and float(jm.rattle_share) == share
    assert float(jm.jump_up_speed) == float(js.jump_up_speed)
    # a result not there is said at the field naming it, with the path looked for (793a03c: it
    # was ResultError 'run studies/gone.yaml first')
    gone = re.escape(str(tmp_path / "gone.nc"))
    with pytest.raises(StudyError, match=rf"analysis\.result: 'gone' -- no {gone}: an analysis"
                                         r" reads its inputs from its output's folder"):
        gearsweep.run({"type": "analysis", "title": "b", "analysis": {
            "kind": "rattle_balance", "result": "gone"}}, output=tmp_path / "x.nc")


def _full(torque, start, **outputs) -> dict:
    return {
        "title": "small full scene with a drive",
        "scene": {"kind": "full", "teeth": 48, "stiffness": "219 kN/mm",
                  "stiffness_harmonics": [{"amplitude": "55 kN/mm"}], "damping": "0.55 N*s/mm",
                  "backlash": "0.4698 mm",
                  "drive": {"inertia_1": "1.5981e-3 kg*m^2", "inertia_2": "3.1567e-4 kg*m^2",
                            "base_radius_1": "56.3816 mm", "base_radius_2": "37.5877 mm"}},
        "sweep": {"torque": torque, "speed": {"start": "150 rpm", "stop": "500 rpm", "num": 3}},
        "solver": {"method": "rk4", "steps_per_period": 256, "transient_periods": 2,
                   "record_periods": 2, "initial_displacement": start},
        # 64 samples: at 150 rpm r_n = f_n / f_mesh = 49.9, and orders up to 50.9 fold onto the
        # kept 0-8 below 59 samples (32 did: SpectrumAliasingWarning)
        "outputs": ["stats", {"spectrum": {"max_order": 8, "samples_per_period": 64,
                                           **outputs}}],
    }


@pytest.mark.slow  # compiles the full-scene kernel
def test_static_start_is_the_drive_flank_equilibrium_of_each_load():
    """``initial_displacement: static`` starts each case at b + F_m / k0 of its own load: a
    torque sweep equals the runs started there one load at a time, and not a common start
    (two transient periods at zeta = 0.05 leave the start visible)."""
    swept = gearsweep.run(_full(["2 N*m", "8.9 N*m"], "static"))
    for t in (2.0, 8.9):
        x0 = 0.4698e-3 / 2 + t / 56.3816e-3 / 219e6
        alone = gearsweep.run(_full([f"{t} N*m"], f"{x0} m"))
        assert_allclose(swept.p_rms.sel(torque=t).values, alone.p_rms.isel(torque=0).values,
                        rtol=1e-12)
    common = gearsweep.run(_full(["2 N*m", "8.9 N*m"], "0.2349 mm"))
    assert np.abs(common.p_rms.values / swept.p_rms.values - 1).max() > 1e-6


def test_static_start_of_a_negative_load_is_the_back_flank_equilibrium():
    """A mean force below zero (coast side) presses the back flank: its static equilibrium is
    -b + F_m / k0, where an unexcited, damped case stays at rest (p_pp 0). Started at
    b + F_m / k0 (the drive flank's formula), the -500 N case began inside the backlash and
    crossed it (p_pp 100.7 um at 0.1 mm backlash, status 2)."""
    ds = gearsweep.run({
        "title": "coast", "scene": {
            "kind": "rattle", "mass": "0.1527 kg", "teeth": 48, "stiffness": "1073 kN/mm",
            "damping": "5.5 N*s/mm", "backlash": "0.1 mm"},
        "sweep": {"speed": ["3000 rpm"], "mean_force": ["-500 N", "500 N"]},
        "solver": {"transient_periods": 0, "record_periods": 20,
                   "initial_displacement": "static"}})
    rest = np.array([-50.0 - 500 / 1073e3 * 1e3, 50.0 + 500 / 1073e3 * 1e3])  # um
    assert_allclose(ds.p_mean.isel(speed=0).values, rest, rtol=1e-12)
    assert (ds.p_pp.values < 1e-9).all()
    assert (ds.status.values == 0).all()


@pytest.mark.slow  # compiles the full-scene kernel
def test_pinion_output_is_eq4_per_line_of_the_mesh_force():
    """``spectrum: {pinion: true}``: r2 theta2 per line is (r2^2 / I2) |W_k| / (2 pi f_k)^2 of
    the force spectrum (0 at order 0) and pinion_rms its rms; a scene without a drive is
    refused in one line."""
    from gearsweep.analysis import sensor

    ds = gearsweep.run(_full(["8.9 N*m"], "static", pinion=True))
    fs = ds.force_spectrum.where(ds.order > 0, 0.0)
    want = sensor.pinion_displacement(fs.values, ds.frequency.values[None, :, :],
                                      base_radius_2=37.5877e-3, inertia_2=3.1567e-4)
    assert ds.pinion_spectrum.attrs["units"] == ds.pinion_rms.attrs["units"] == "um"
    assert_allclose(ds.pinion_spectrum.values, want * 1e6, rtol=1e-14)  # want in m
    assert (ds.pinion_spectrum.sel(order=0.0) == 0).all()
    assert_allclose(ds.pinion_rms.values, sensor.spectrum_rms(want) * 1e6, rtol=1e-14)
    study = _full(["8.9 N*m"], "static", pinion=True)
    study["scene"].pop("drive")
    study["scene"].update({"mass": "0.1547 kg", "base_radius": "56.3816 mm"})
    with pytest.raises(StudyError, match=r"outputs\[1\]\.spectrum\.pinion: True -- a scene with a drive"):
        gearsweep.run(study)


def test_pinion_output_with_a_swept_mass_is_refused():
    """A swept mass replaces the drive's m_eq, and would contradict the inertias the pinion's
    motion is formed with (accepted without a word; an adversarial test); without the pinion,
    validate says the sweep replaces the drive's m_eq. Refused when planned: nothing runs."""
    study = _full(["8.9 N*m"], "static", pinion=True)
    study["sweep"]["mass"] = ["0.15 kg", "0.2 kg"]
    with pytest.raises(StudyError, match=r"spectrum\.pinion: True -- a scene whose m_eq is its"
                                         r" drive's"):
        gearsweep.run(study)
    study["outputs"][1]["spectrum"]["pinion"] = False
    st, _ = gearsweep.api.load(study)
    assert "scene.drive's m_eq" in replaced_by_sweep(st)


def test_validate_notes_a_result_the_analysis_reads_that_is_not_there(tmp_path, monkeypatch,
                                                                      capsys):
    """``validate`` said ok, then ``run`` stopped: 'results/fig08_rattle.nc: no such result'. The
    study is valid; validate now also says what run will need first."""
    from pathlib import Path

    from gearsweep.cli import main

    study = Path(__file__).resolve().parents[1] / "studies" / "fig08_rattle_balance.yaml"
    monkeypatch.chdir(tmp_path)
    assert main(["validate", str(study)]) == 0
    out = capsys.readouterr()
    assert out.out.startswith(f"{study}: ok -- analysis study 'rattle_balance', its inputs read"
                              " from results/; estimate: ")
    line = next(i for i, ln in enumerate(study.read_text().splitlines(), 1)
                if ln.strip() == "result: fig08_rattle")
    assert out.err == (f"gearsweep: note: {study}:{line}: analysis.result: 'fig08_rattle' -- no"
                       " results/fig08_rattle.nc: an analysis reads its inputs from its output's"
                       " folder (results): run the study that makes it there first (gearsweep run"
                       " fig08_rattle.yaml -o results/fig08_rattle.nc), or this one with -o"
                       " beside it\n")
    (tmp_path / "results").mkdir()
    import netCDF4  # a readable netCDF file (an empty one is refused as run refuses it)

    netCDF4.Dataset(tmp_path / "results" / "fig08_rattle.nc", "w").close()
    # there: no note; and an empty file is no result rattle_balance reads, refused as run
    # refuses it (validate said ok of it), at the line of analysis.result
    assert main(["validate", str(study)]) == 2
    assert capsys.readouterr().err == (
        f"gearsweep: error: {study}:18: analysis.result: 'fig08_rattle' -- rattle_balance needs"
        " a gear scene's dynamic result; the result carries no resolved model (not a dynamic"
        " study)\n")


def test_jump_analyses_of_a_run_up_only_result_are_one_line(tmp_path, capsys):
    """A rattle result swept up only made jump_map and rattle_balance crash with a traceback
    (exit 1); they now say what they need, in one line, exit 2."""
    from gearsweep.cli import main

    up = {**RATTLE, "continuation": ["up"],
          "sweep": {"speed": {"start": "7000 rpm", "stop": "8600 rpm", "num": 5}},
          "solver": {**RATTLE["solver"], "transient_periods": 5}}
    gearsweep.run(up, output=tmp_path / "up.nc")
    for kind in ("jump_map", "rattle_balance"):
        study = tmp_path / f"{kind}.yaml"
        study.write_text(f"type: analysis\ntitle: t\nanalysis: {{kind: {kind}, result: up}}\n",
                         encoding="utf-8")
        assert main(["run", str(study), "-o", str(tmp_path / f"{kind}.nc")]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "continued up and down over speed" in err, err


def test_a_jump_map_of_a_result_without_up_and_down_is_refused_at_its_line(tmp_path,
                                                                         monkeypatch, capsys):
    """validate said ok of a jump_map reading a result with no up/down sweep, and run refused it
    with 'flat: jump_map needs ...': no file, line or field. Both now give the study file's
    line of analysis.result, its value and what is allowed, exit 2."""
    from gearsweep.cli import main

    flat = {**RATTLE, "sweep": {"speed": {"start": "7000 rpm", "stop": "8600 rpm", "num": 3}},
            "solver": {**RATTLE["solver"], "transient_periods": 5}}
    del flat["continuation"]  # one sweep of independent speeds
    monkeypatch.chdir(tmp_path)
    (tmp_path / "results").mkdir()
    gearsweep.run(flat, output=tmp_path / "results" / "flat.nc")
    study = tmp_path / "jm.yaml"
    study.write_text("type: analysis\ntitle: t\nanalysis:\n  kind: jump_map\n  result: flat\n",
                     encoding="utf-8")
    line = (f"gearsweep: error: {study}:5: analysis.result: 'flat' -- jump_map needs a result"
            " continued up and down over speed (continuation: [up, down]): a jump is where the"
            " two differ; this one has no up and down sweep\n")
    assert main(["validate", str(study)]) == 2
    assert capsys.readouterr().err == line
    assert main(["run", str(study), "-o", str(tmp_path / "results" / "jm.nc")]) == 2
    assert capsys.readouterr().err == line


def test_an_analysis_names_its_input_with_or_without_nc_and_refuses_a_path():
    from gearsweep.study.schema import parse_study

    text = "type: analysis\ntitle: t\nanalysis: {kind: jump_map, result: RESULT}\n"
    assert parse_study(text.replace("RESULT", "small.nc")).analysis.result == "small"
    assert parse_study(text.replace("RESULT", "small")).analysis.result == "small"
    with pytest.raises(StudyError, match=r"analysis.result: 'results/small.nc' -- the name of a"
                                         r" result in the folder the analysis writes to"):
        parse_study(text.replace("RESULT", "results/small.nc"), "s.yaml")


def test_pinion_output_of_a_gear_scene_takes_the_pair_s_radius_where_the_drive_omits_it():
    """A gear scene's drive may omit its base radii (the pair gives them); the pinion output
    then took drive.base_radius_2 = None: a TypeError traceback at the first chunk (an
    adversarial test). It takes the pair's r2, as the drive's own inertias do."""
    from gearsweep.gear import table1_consistent

    study = {"title": "p", "scene": {
        "kind": "whine", "gear": "table1_consistent", "torque": "50 N m",
        "damping": "5.5 N s/mm",
        "drive": {"inertia_1": "1.5981e-3 kg*m^2", "inertia_2": "3.1567e-4 kg*m^2"}},
        "sweep": {"speed": ["1000 rpm"]}, "solver": {"transient_periods": 10, "record_periods": 4},
        "outputs": [{"spectrum": {"pinion": True}}]}
    ds = gearsweep.run(study)
    from gearsweep.analysis import sensor

    r2 = table1_consistent().base_radius2
    fs = ds.force_spectrum.where(ds.order > 0, 0.0)
    want = sensor.pinion_displacement(fs.values, ds.frequency.values,
                                      base_radius_2=r2, inertia_2=3.1567e-4)
    assert_allclose(ds.pinion_spectrum.values, want * 1e6, rtol=1e-12)



@pytest.mark.parametrize("content", [b"garbage\n", b""])
def test_a_corrupt_input_result_is_one_line_not_a_traceback(tmp_path, capsys, monkeypatch,
                                                              content):
    """A rig result that is no netCDF (a truncated copy, a text file): validate notes nothing
    (it cannot read it), and run ended in xarray's ValueError traceback ('did not find a match
    in any of xarray's currently installed IO backends'), exit 1. Now one line, exit 2."""
    (tmp_path / "stability_rig.nc").write_bytes(content)
    study = tmp_path / "stability_artifact_map.yaml"
    study.write_text((ROOT / "studies" / "stability_artifact_map.yaml").read_text())
    assert main(["run", str(study), "-o", str(tmp_path / "map.nc")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [(f"gearsweep: error: {tmp_path / 'stability_rig.nc'}: not a readable netCDF"
                    " result (ValueError); analysis 'artifact_map' reads it: run"
                    " studies/stability_rig.yaml again")]
    assert not (tmp_path / "map.nc").exists()
    # validate said ok of it: now it says what run would (its inputs read from results/ here)
    monkeypatch.chdir(tmp_path)
    (tmp_path / "results").mkdir()
    (tmp_path / "results" / "stability_rig.nc").write_bytes(content)
    assert main(["validate", str(study)]) == 2
    assert capsys.readouterr().err.strip().splitlines() == [(
        f"gearsweep: error: {Path('results') / 'stability_rig.nc'}: not a readable netCDF result"
        " (ValueError); analysis 'artifact_map' reads it: run studies/stability_rig.yaml again")]


def test_rattle_balance_needs_four_samples_per_harmonic(tmp_path, capsys, monkeypatch):
    """n_time 99 with 25 harmonics: validate said ok, and run ended in AFTBalance's ValueError
    traceback ('n_time must be at least 4 * harmonics'). Now both say it at the field."""
    small = {**RATTLE, "sweep": {"speed": {"start": "7000 rpm", "stop": "8600 rpm", "num": 3}},
             "solver": {**RATTLE["solver"], "transient_periods": 2}}
    monkeypatch.chdir(tmp_path)  # validate and run read results/ (run's default output folder)
    gearsweep.run(small, output=tmp_path / "results" / "small.nc")
    study = tmp_path / "b.yaml"
    text = ("type: analysis\ntitle: b\nanalysis:\n  kind: rattle_balance\n  result: small\n"
            "  harmonics: 25\n  n_time: 99\n")
    study.write_text(text, encoding="utf-8")
    # (run --estimate printed an estimate, exit 0, of what validate and run refuse: a fuzz find)
    for argv in (["validate", str(study)], ["run", str(study)], ["run", "--estimate", str(study)]):
        assert main(argv) == 2
        assert capsys.readouterr().err.splitlines() == [
            (f"gearsweep: error: {study}:7: analysis.n_time: 99 -- at least 4 samples per"
            " harmonic: 100 for the 25 harmonics (or at most 24 harmonics)")]
    assert not (tmp_path / "results" / "b.nc").exists()
    study.write_text(text.replace("n_time: 99", "n_time: 100"), encoding="utf-8")
    assert main(["validate", str(study)]) == 0  # the least AFTBalance takes
    from gearsweep.analysis.hb import AFT_SAMPLES_PER_HARMONIC, AFTBalance, MeshSystem

    assert AFT_SAMPLES_PER_HARMONIC == 4
    with pytest.raises(ValueError, match="at least 4"):
        AFTBalance(MeshSystem(mass=1.0, stiffness=1.0, damping=0.1, half_gap=None), harmonics=25,
                   n_time=99)


MATHIEU = {"title": "m", "scene": {"kind": "mathieu"},
           "sweep": {"alpha": [1.0], "beta": [0.1], "gamma": [0.0]},
           "solver": {"steps_per_period": 16, "transient_periods": 2, "record_periods": 1}}


@pytest.mark.parametrize(("analysis", "line"), [
    ("{kind: rattle_budget, fitted: m, scenes: [m], names: [a], mesh: m}",
     (":4: analysis.fitted: 'm' -- rattle_budget's fitted needs a gear scene's result with one"
     " force harmonic; this result has none\n")),
    ("{kind: rattle_budget, fitted: fit, scenes: [m], names: [a], mesh: m}",
     (":4: analysis.scenes[0]: 'm' -- rattle_budget's scenes[0] needs a rattle result (backlash)"
     " continued up and down over speed, with a damping sweep; this result has none\n")),
    ("{kind: rattle_budget, fitted: fit, scenes: [fit], names: [a], mesh: m}",
     (":4: analysis.mesh: 'm' -- rattle_budget's mesh needs a mesh study's result (ste_harmonic"
     " of order 1); this result has none\n"))])
def test_a_rattle_budget_of_results_of_the_wrong_kind_is_refused_at_its_line(
        tmp_path, monkeypatch, capsys, analysis, line):
    """validate said ok of a rattle_budget whose mesh, fitted or scenes were results of another
    kind, and run ended in a KeyError ('ste_harmonic', 'speed') or a ValueError (unpacking the
    fitted force harmonics) traceback (a fuzz find); both now give the field's line, exit 2."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "results").mkdir()
    gearsweep.run(MATHIEU, output=tmp_path / "results" / "m.nc")
    fit = {**RATTLE, "sweep": {"speed": {"start": "7000 rpm", "stop": "8600 rpm", "num": 3},
                               "damping": ["4.92 N s/mm"]},
           "solver": {**RATTLE["solver"], "transient_periods": 5}}
    gearsweep.run(fit, output=tmp_path / "results" / "fit.nc")
    study = tmp_path / "b.yaml"
    study.write_text(f"type: analysis\ntitle: t\n\nanalysis: {analysis}\n", encoding="utf-8")
    assert main(["validate", str(study)]) == 2
    assert capsys.readouterr().err == f"gearsweep: error: {study}{line}"
    assert main(["run", str(study), "-o", str(tmp_path / "results" / "b.nc")]) == 2
    assert capsys.readouterr().err == f"gearsweep: error: {study}{line}"


def test_a_rattle_balance_of_a_mathieu_result_is_one_line(tmp_path, capsys):
    """The Mathieu scene's model has no force harmonics: an AttributeError traceback (exit 1);
    then a line of no file or field: now at analysis.result's line."""
    gearsweep.run(MATHIEU, output=tmp_path / "m.nc")
    study = tmp_path / "rb.yaml"
    study.write_text("type: analysis\ntitle: t\nanalysis: {kind: rattle_balance, result: m}\n",
                     encoding="utf-8")
    assert main(["run", str(study), "-o", str(tmp_path / "rb.nc")]) == 2
    err = capsys.readouterr().err
    assert err == (f"gearsweep: error: {study}:3: analysis.result: 'm' -- rattle_balance needs a"
                   " gear scene's dynamic result; the result is of a MathieuModel, not of a gear"
                   " pair's scene\n")


@pytest.mark.parametrize(("value", "match"), [("0", "greater than 0"), ("-1", "greater than 0"),
                                              ("1e300", "less than or equal to 100")])
def test_a_fig9_line_at_no_negative_or_overflowing_speed_is_refused(value, match):
    """graphical: [0, ...] and [-1, ...] ran with status 0 (lines at no or a negative speed),
    [1e300, ...] overflowed in the balance (a RuntimeWarning, status 0): a fuzz find."""
    from gearsweep.study.schema import parse_study

    text = ("type: analysis\ntitle: t\nanalysis: {kind: rattle_balance, result: r,"
            f" graphical: [{value}, 0.5, 1.25]}}\n")
    with pytest.raises(StudyError, match=rf"analysis.graphical\[0\]: .* -- Input should be {match}"):
        parse_study(text, "s.yaml")


@pytest.mark.parametrize("model", ["not json", "{}"])
def test_an_input_whose_model_attribute_is_no_model_record_is_one_line(tmp_path, capsys, model,
                                                                      monkeypatch):
    """A netCDF file not written here (its model attribute not JSON, or without a kind): run
    ended in a JSONDecodeError or KeyError traceback (a fuzz find); rattle_budget's validate too."""
    import xarray as xr

    monkeypatch.chdir(tmp_path)
    (tmp_path / "results").mkdir()
    xr.Dataset({"p_pp": (("speed",), np.zeros(3))}, coords={"speed": [1.0, 2.0, 3.0]},
               attrs={"model": model}).to_netcdf(tmp_path / "results" / "x.nc")
    study = tmp_path / "rb.yaml"
    study.write_text("type: analysis\ntitle: t\nanalysis: {kind: rattle_balance, result: x}\n",
                     encoding="utf-8")
    assert main(["run", str(study), "-o", str(tmp_path / "results" / "rb.nc")]) == 2
    assert capsys.readouterr().err == (f"gearsweep: error: {study}:3: analysis.result: 'x' --"
                                       " rattle_balance needs a gear scene's dynamic result; its"
                                       " model attribute is not a gearsweep model record\n")
    study.write_text("type: analysis\ntitle: t\nanalysis: {kind: rattle_budget, fitted: x,"
                     " scenes: [x], names: [a], mesh: x}\n", encoding="utf-8")
    assert main(["validate", str(study)]) == 2
    assert "analysis.fitted: 'x' -- rattle_budget's fitted needs" in capsys.readouterr().err


def test_run_names_every_input_it_lacks_where_it_looks(tmp_path):
    """``run`` of an analysis lacking its inputs said the first alone, as 'run
    studies/NAME.yaml first', though it looks beside its output (an outside tester's study in
    their own folder): now every missing one, at its field, with the path looked for."""
    from gearsweep.errors import StudyError

    study = {"type": "analysis", "title": "budget",
             "analysis": {"kind": "rattle_budget", "fitted": "r4", "scenes": ["g1"],
                          "names": ["gear"], "mesh": "nomesh"}}
    with pytest.raises(StudyError) as err:
        gearsweep.run(study, output=tmp_path / "bud.nc")
    assert str(err.value).splitlines() == [
        f"<study>: analysis.{field}: '{name}' -- no {tmp_path / name}.nc: an analysis reads its"
        f" inputs from its output's folder ({tmp_path}): run the study that makes it there first"
        f" (gearsweep run {name}.yaml -o {tmp_path / name}.nc), or this one with -o beside it"
        for field, name in (("fitted", "r4"), ("scenes[0]", "g1"), ("mesh", "nomesh"))]


def test_validate_and_run_of_an_analysis_read_its_inputs_in_one_folder(tmp_path, capsys,
                                                                       monkeypatch):
    """``validate`` checked an analysis's inputs in results/ while ``run -o bal.nc`` read
    them from the output's folder, and the run's error named the folder '.' where the file
    goes, without the study's line: 'gearsweep: error: .: no fig08_rattle.nc; ...' (an outside
    tester). validate takes -o as run does and says the folder; both name the study file, the
    line of the field that names the input, and the path looked for."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "bal.yaml").write_text(
        "type: analysis\ntitle: t\nanalysis:\n  kind: rattle_balance\n  result: fig08_rattle\n",
        encoding="utf-8")
    said = ("bal.yaml:5: analysis.result: 'fig08_rattle' -- no {0}: an analysis reads its inputs"
            " from its output's folder ({1}): run the study that makes it there first (gearsweep"
            " run fig08_rattle.yaml -o {0}), or this one with -o beside it")
    here, results = said.format("./fig08_rattle.nc", "."), said.format(
        "results/fig08_rattle.nc", "results")
    for extra, folder, line in (([], "results", results), (["-o", "bal.nc"], ".", here)):
        assert main(["validate", "bal.yaml", *extra]) == 0
        out, err = capsys.readouterr()
        assert f"analysis study 'rattle_balance', its inputs read from {folder}/;" in out
        assert err == f"gearsweep: note: {line}\n"
        assert main(["run", "bal.yaml", *extra]) == 2
        assert capsys.readouterr().err == f"gearsweep: error: {line}\n"
    (tmp_path / "res").mkdir()  # -o a folder: refused by both alike (validate took it, and
    for command in ("validate", "run"):  # looked for the inputs beside it)
        for folder in ("res", "res/"):
            assert main([command, "bal.yaml", "-o", folder]) == 2
            assert capsys.readouterr().err == (f"gearsweep: error: bal.yaml: --output: {folder!r}"
                                               " -- a file path, not a folder\n")


def test_rattle_balance_keeps_the_rest_where_harmonic_balance_does_not_converge(tmp_path,
                                                                               capsys):
    """An outside engineer's idle-stage scene (31 teeth, 0.22 kg, c = 0.81 N s/mm, backlash
    0.1 mm, 2 N m, a 10 N m torque fluctuation at order 2/31, up and down from 600 rpm) made
    rattle_balance end in 'RuntimeError: harmonic balance did not converge at omega = 125.664
    rad/s', a traceback, exit 1, after validate said ok. Now the AFT branch, its turning points
    and the flip speed are NaN, the integration and Eq. (15) are kept, and one note says so."""
    import xarray as xr

    from gearsweep.cli import main

    scene = ("title: idle\nscene:\n  kind: rattle\n  mass: 0.22 kg\n  teeth: 31\n"
             "  stiffness: 300 kN/mm\n  damping: 0.81 N s/mm\n  backlash: 0.1 mm\n"
             "  torque: 2 N m\n  base_radius: 36.41 mm\n"
             "  fluctuation:\n    - {amplitude: 10 N m, order: 2/31}\n"
             "sweep:\n  speed: {start: 600 rpm, stop: 900 rpm, num: 4}\n"
             "continuation: [up, down]\n"
             "solver: {method: rk4, steps_per_period: 64, transient_periods: 62,"
             " record_periods: 62}\n")
    (tmp_path / "idle.yaml").write_text(scene, encoding="utf-8")
    assert main(["run", str(tmp_path / "idle.yaml"), "-o", str(tmp_path / "idle.nc"), "-q"]) == 0
    study = tmp_path / "rb.yaml"
    study.write_text("type: analysis\ntitle: t\nanalysis: {kind: rattle_balance, result: idle}\n",
                     encoding="utf-8")
    capsys.readouterr()
    assert main(["run", str(study), "-o", str(tmp_path / "rb.nc"), "-q"]) == 0
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "did not converge at the lowest speed, 600 rpm" in err, err
    ds = xr.load_dataset(tmp_path / "rb.nc")
    assert ds["aft_amplitude"].isnull().all() and np.isnan(float(ds["flip_speed"]))
    assert ds["turning_point"].sel(curve="aft").isnull().all()
    assert np.isfinite(ds["amplitude"].values).any() and ds["eq15_root"].notnull().any()
    assert "did not converge" in ds.attrs["aft_note"]
    # its plot: no legend entry for the branch that is not there, and axes that show the
    # response (0.6 mm, Fig. 8's top, left a 0.05 mm response on the floor)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from gearsweep.plot.rattle import plot_rattle_balance

    fig, ax = plt.subplots()
    plot_rattle_balance(ax, ds)
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert not any("AFT" in t for t in labels), labels
    assert ax.get_ylim()[1] < 2.0 * float(ds["amplitude"].max()) / 1e3  # um -> mm
    plt.close(fig)


def test_rattle_balance_keeps_a_branch_that_stops_short_with_a_note(tmp_path, monkeypatch):
    """A harmonic-balance branch that stops short of the result's top speed (here: after 5
    points) was refused as a whole (the integration, describing function and Eq. (15) lost
    with it); now its points are kept, its turning points and flip speed are NaN (they would
    be those of part of the branch), and aft_note says why."""
    from gearsweep.study import analyses
    from gearsweep.study.schema import parse_study

    real = analyses.hb.aft_continuation
    monkeypatch.setattr(analyses.hb, "aft_continuation",
                        lambda *a, **k: real(*a, **{**k, "max_points": 5}))
    small = {**RATTLE, "sweep": {"speed": {"start": "7000 rpm", "stop": "8600 rpm", "num": 5}},
             "solver": {**RATTLE["solver"], "transient_periods": 5}}
    gearsweep.run(small, output=tmp_path / "small.nc")
    text = ("type: analysis\ntitle: t\nanalysis: {kind: rattle_balance, result: small,"
            " harmonics: 5, n_time: 64}\n")
    ds = analyses.run_analysis_study(parse_study(text), text, tmp_path)
    assert "stopped at" in ds.attrs["aft_note"] and "after its most points" in ds.attrs["aft_note"]
    assert int(np.isfinite(ds["aft_amplitude"]).sum()) == 5
    assert ds["turning_point"].sel(curve="aft").isnull().all()
    assert ds["turning_point"].sel(curve="describing_function").notnull().any()
    assert np.isnan(float(ds["flip_speed"])) and ds["amplitude"].notnull().any()


def test_rattle_budget_marks_a_scene_whose_jumps_cannot_be_judged(tmp_path):
    """rattle_budget gave each scene's jump speeds, NaN both where a sweep has no jump and where
    the jump criterion cannot judge it (steps that meet it, none with settled points of both
    branches beside it: jump_unsupported of the scene's jump summary), so fig08_out_of_sample
    and its printed summary read the latter as "no jump". A scene whose sweeps at c = 4.92 N s/mm
    are the unsettled pattern of test_rattle's j1 sweep (a step onto unsettled points on the
    run-up, an isolated settled point on the run-down) and at c = 0.492 N s/mm the same run-up
    all settled (one step of 28% between 6.6 and 9.2 um, two-valued against the run-down) over
    a smooth run-down: jump_unsupported 3 at the first (both sweeps), 0 at the second, whose
    run-up jumps at the midpoint of that step's speeds; the settings say which in one note."""
    import xarray as xr

    from gearsweep.plot.rattle import budget_jump

    xr.Dataset({"ste_harmonic": ("harmonic", [4.3, 1.33], {"units": "um"})},
               coords={"harmonic": [0, 1]}).to_netcdf(tmp_path / "m.nc")
    scene = {**RATTLE, "sweep": {"speed": {"start": "7000 rpm", "stop": "7165 rpm", "num": 12},
                                 "damping": ["4.92 N s/mm", "0.492 N s/mm"]},
             "solver": {**RATTLE["solver"], "transient_periods": 2, "record_periods": 2}}
    gearsweep.run(scene, output=tmp_path / "s.nc")
    ds = xr.load_dataset(tmp_path / "s.nc")
    up = [7.0, 6.7, 6.6, 6.6, 9.2, 8.4, 9.5, 9.4, 9.5, 9.6, 9.1, 9.1]
    down = [9.0, 9.1, 9.1, 9.2, 9.2, 9.1, 9.4, 9.6, 4.0, 8.8, 9.3, 9.3]
    smooth = [9.0, 9.1, 9.1, 9.2, 9.2, 9.1, 9.4, 9.6, 9.5, 8.8, 9.3, 9.3]
    unsettled = {"up": [0, 2, 2, 2, 0, 0, 2, 2, 2, 0, 0, 2],
                 "down": [0, 0, 0, 0, 0, 2, 2, 2, 0, 0, 2, 2]}
    c_bad, c_good = ds["damping"].values
    for c, d, amp, status in ((c_bad, "up", up, unsettled["up"]),
                              (c_bad, "down", down, unsettled["down"]),
                              (c_good, "up", up, [0] * 12), (c_good, "down", smooth, [0] * 12)):
        at = {"damping": c, "direction": d}
        ds["p_pp"].loc[at] = 2 * np.array(amp)
        ds["status"].loc[at] = status
        # and their settle_error: the j1 sweep's unsettled points scatter (by more than half
        # the jump threshold: no support, analysis.jumps), its settled ones do not
        ds["settle_error"].loc[at] = np.where(np.array(status) == 2, 0.2, 0.0)
    ds.to_netcdf(tmp_path / "j.nc")
    budget = gearsweep.run({"type": "analysis", "title": "b", "analysis": {
        "kind": "rattle_budget", "fitted": "s", "scenes": ["j"], "names": ["j1"], "mesh": "m"}},
        output=tmp_path / "b.nc")
    b = xr.load_dataset(tmp_path / "b.nc").sel(scene="j")
    assert int(b.jump_unsupported.sel(damping=c_bad)) == 3
    assert int(b.jump_unsupported.sel(damping=c_good)) == 0
    speed = ds["speed"].values
    assert np.isnan(float(b.jump_up_speed.sel(damping=c_bad)))
    assert float(b.jump_up_speed.sel(damping=c_good)) == pytest.approx(0.5 * (speed[3] + speed[4]))
    assert np.isnan(float(b.jump_down_speed.sel(damping=c_good)))
    assert b.jump_unsupported.attrs["units"] == "1"
    assert "cannot be judged" in b.jump_unsupported.attrs["long_name"]
    assert "jump_unsupported" in b.jump_up_speed.attrs["long_name"]
    assert budget.attrs["jump_unsupported_cases"] == 1
    assert "j1 c = 4.92" in budget.attrs["jump_note"] and "0.492" not in budget.attrs["jump_note"]
    assert "cannot be judged" in budget.attrs["jump_note"]
    assert [budget_jump(b.sel(damping=c_bad), d) for d in ("up", "down")] == [
        "jump cannot be judged"] * 2
    assert [budget_jump(b.sel(damping=c_good), d) for d in ("up", "down")] == [
        f"jump at {0.5 * (speed[3] + speed[4]):.0f} rpm", "no jump"]


def test_rattle_budget_compares_m_w2_e1_with_the_force_that_opens_the_mesh_at_each_speed(
        tmp_path):
    """rattle_budget gave one "least force that opens the mesh" per scene and damping (its
    value at resonance), and fig08_out_of_sample drew it flat across all speeds against
    m_eq w^2 e_1: the purple curve crossed it where the mesh does not open (an outside tester's
    finding). Now opening_force is that force at each budget speed, (F_m / k) / |P_1| of the
    package's harmonic balance for a unit order-1 force (``periodic_response``), and
    first_harmonic_opens_from / _to the band where the linear response to m w^2 e_1 reaches
    the static deflection F_m / k (Brent's method on ``periodic_response``; at k = 1073 kN/mm:
    from 10,554 rpm at c = 4.92 N s/mm, 10,314 at 0.492, on to the last speed). The figure
    draws one opening-force curve per scene and damping, each in its own line style and
    labelled with its c, where the two dampings' legend entries were identical."""
    import matplotlib
    import xarray as xr
    from scipy.optimize import brentq

    from gearsweep.analysis.linear_response import periodic_response, ste_force
    from gearsweep.model import RPM
    from gearsweep.plot.rattle import plot_rattle_budget

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    e1 = 1.33524e-6
    xr.Dataset({"ste_harmonic": ("harmonic", [4.3, e1 * 1e6], {"units": "um"})},
               coords={"harmonic": [0, 1]}).to_netcdf(tmp_path / "m.nc")
    scene = {**RATTLE, "sweep": {"speed": {"start": "9000 rpm", "stop": "12000 rpm", "num": 4},
                                 "damping": ["4.92 N s/mm", "0.492 N s/mm"]},
             "solver": {**RATTLE["solver"], "transient_periods": 2, "record_periods": 2}}
    gearsweep.run(scene, output=tmp_path / "s.nc")
    gearsweep.run({"type": "analysis", "title": "b", "analysis": {
        "kind": "rattle_budget", "fitted": "s", "scenes": ["s"], "names": ["s1"], "mesh": "m",
        "points": 7}}, output=tmp_path / "b.nc")
    b = xr.load_dataset(tmp_path / "b.nc")
    m, k, fm = 0.1527, 1073e6, 50.0 / 56.38e-3
    w = b["budget_speed"].values * 48 * RPM
    for c_disp, c, first in ((4.92, 4920.0, 10554.0), (0.492, 492.0, 10314.0)):
        s = b.sel(scene="s", damping=c_disp)
        unit = periodic_response(m, c, k, w, f_amplitudes=[1.0], f_orders=[1], harmonics=2)
        assert_allclose(s.opening_force.values, (fm / k) / np.abs(unit[:, 1]), rtol=1e-9)
        assert np.all(s.opening_force.values > float(s.threshold))  # off resonance: more

        def ratio(rpm, c=c):
            wv = np.array([rpm * 48 * RPM])
            p = periodic_response(m, c, k, wv, mean_force=fm, harmonics=2,
                                  f_amplitudes=ste_force(m, wv, [e1], [1]), f_orders=[1])
            return float(np.abs(p[0, 1]) / np.abs(p[0, 0])) - 1.0

        assert_allclose(float(s.first_harmonic_opens_from), brentq(ratio, 9000.0, 12000.0,
                                                                   xtol=1e-9), rtol=1e-9)
        assert_allclose(float(s.first_harmonic_opens_from), first, atol=1.0)
        assert float(s.first_harmonic_opens_to) == 12000.0  # open on to the last speed
    assert b.first_harmonic_opens_from.attrs["units"] == "rpm"
    fig, ax = plt.subplots()
    plot_rattle_budget(ax, b)
    labels = [ln.get_label() for ln in ax.get_lines()]
    assert len(labels) == len(set(labels))  # no two identical legend entries
    drawn = {ln.get_label(): ln for ln in ax.get_lines() if "opens the mesh" in ln.get_label()}
    assert len(drawn) == 2 and len({ln.get_linestyle() for ln in drawn.values()}) == 2
    for c_disp in (4.92, 0.492):
        (ln,) = [v for lab, v in drawn.items() if f"c = {c_disp:g} N s/mm" in lab]
        assert_allclose(ln.get_ydata(), b.opening_force.sel(scene="s", damping=c_disp).values)
    plt.close(fig)


def test_rattle_balance_says_which_jumps_cannot_be_judged_and_its_box_says_so(tmp_path):
    """rattle_balance carried the jump speeds but not jump_unsupported (rattle_budget and
    jump_map do), and Fig. 8's Eq. (15) box read a NaN jump as "the integration has no such
    jump" while the axes drew the drop (an outside tester). The Fig. 8 scene with its run-up's
    points from 7,950 rpm up made to scatter (status 2, settle_error 0.2: no branch there), so
    its drop (near 8,018 rpm) has no support: jump_unsupported 1 with the jump summary's
    long_name, and the box says the integration's drop cannot be judged."""
    import xarray as xr

    from gearsweep.plot.rattle import _eq15_lines
    from gearsweep.study import analyses
    from gearsweep.study.jumps import JUMP_VARIABLES, jump_summary
    from gearsweep.study.schema import parse_study

    gearsweep.run(RATTLE, output=tmp_path / "r.nc")
    ds = xr.load_dataset(tmp_path / "r.nc")
    assert int(jump_summary(ds).jump_unsupported) == 0  # as run: the drop is judged
    far = {"direction": "up", "speed": ds["speed"].values[ds["speed"].values >= 7950.0]}
    ds["status"].loc[far] = 2
    ds["settle_error"].loc[far] = 0.2
    ds.to_netcdf(tmp_path / "s.nc")
    text = ("type: analysis\ntitle: t\nanalysis: {kind: rattle_balance, result: s,"
            " harmonics: 5, n_time: 64}\n")
    bal = analyses.run_analysis_study(parse_study(text), text, tmp_path)
    assert int(bal["jump_unsupported"]) == 1 and np.isnan(float(bal["jump_up_speed"]))
    assert bal["jump_unsupported"].attrs["long_name"] == JUMP_VARIABLES["jump_unsupported"][1]
    drop = [line for line in _eq15_lines(bal) if line.startswith("run-up drop")]
    assert drop and "cannot be judged" in drop[0] and "no such jump" not in drop[0], drop

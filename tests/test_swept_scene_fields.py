"""A scene field that the sweep gives need not be written in the scene (docs/study-reference.md:
"the sweep replaces the scene's value"): a rattle scene without ``backlash`` beside
``sweep.backlash`` was refused with "scene.backlash: '(missing)' -- this field is required" (an
outside tester's finding; studies/rattle_map.yaml typed a dummy backlash to get around it), and
so were a scene without ``mass`` beside ``sweep.mass`` and one without ``stiffness`` beside
``sweep.stiffness``."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from conftest import GOOD_RATTLE

import gearsweep
from gearsweep.cli import main
from gearsweep.errors import StudyError
from gearsweep.study.plan import make_plan
from gearsweep.study.schema import parse_study, study_text

TESTER = """\
continuation:
- up
- down
description: 'Eq. (13), constant stiffness with backlash, excited at the mesh frequency
  by a force whose amplitude and damping are fitted to the paper''s jump speeds; up
  and down speed sweeps with the state carried from speed to speed.

  '
outputs:
- stats
- period
scene:
  base_radius: 56.38 mm
  damping: 4.92 N*s/mm
  fluctuation:
  - amplitude: 67.8 kN
    order: 1
  kind: rattle
  mass: 0.1527 kg
  stiffness: 1073 kN/mm
  teeth: 48
  torque: 50 N*m
solver:
  initial_displacement: static
  method: rk4
  record_periods: 10
  steps_per_period: 64
  transient_periods: 40
sweep:
  backlash:
  - 0.2 mm
  - 0.4698 mm
  speed:
    num: 61
    start: 5000 rpm
    stop: 11000 rpm
title: 'Rattle: jump hysteresis on run-up and run-down (Fig. 8, fitted c and F0)'
"""
"""An outside tester's study (a rattle scene with no scene.backlash, sweep.backlash), as
written."""

BASE = GOOD_RATTLE.replace("  mean_force: 100 N\n", "  base_radius: 60 mm\n  mean_force: 100 N\n")

SWEPT = {  # a scene field, the line that writes it in BASE, and a sweep of it
    "backlash": ("  backlash: 0.1 mm\n", "[0.1 mm, 0.2 mm]"),
    "mass": ("  mass: 0.1527 kg\n", "[0.1527 kg, 0.3 kg]"),
    "stiffness": ("  stiffness: 1073 kN/mm\n", "[1073 kN/mm, 500 kN/mm]"),
    "mean_force": ("  mean_force: 100 N\n", "[100 N, 300 N]"),
    "torque": ("  mean_force: 100 N\n", "[6 N*m, 18 N*m]"),
    "damping": ("", "[100 N*s/m, 500 N*s/m]"),
    "speed": ("", None),  # BASE sweeps the speed, with no scene.speed
}


def _swept(name: str, scene_line: str | None = None) -> str:
    """BASE sweeping ``name`` besides the speed, its scene line left out (or ``scene_line``)."""
    line, values = SWEPT[name]
    text = BASE.replace(line, scene_line or "")
    if values is not None:
        text = text.replace("  speed: {", f"  {name}: {values}\n  speed: {{")
    return text


@pytest.mark.parametrize("name", list(SWEPT))
def test_a_swept_field_need_not_be_written_in_the_scene(name, tmp_path, capsys):
    """validate and run take it; validate's summary does not say the sweep replaces a scene
    value the scene has not got; the cases run the swept values, as beside a scene value."""
    path = tmp_path / "s.yaml"
    path.write_text(_swept(name), encoding="utf-8")
    assert main(["validate", str(path)]) == 0, capsys.readouterr().err
    assert "the sweep replaces" not in capsys.readouterr().out
    out = tmp_path / "s.nc"
    assert main(["run", str(path), "-o", str(out), "-q"]) == 0, capsys.readouterr().err
    assert main(["inspect", str(out)]) == 0
    assert "p_rms" in capsys.readouterr().out
    line, _ = SWEPT[name]
    if not line:
        return
    both = gearsweep.run(_swept(name, line))  # (a swept torque replaces the scene's mean_force)
    alone = gearsweep.run(_swept(name))
    for var in ("p_rms", "p_pp", "status"):
        np.testing.assert_array_equal(alone[var].values, both[var].values)


def test_the_outside_testers_study_validates_and_runs(tmp_path, capsys):
    path = tmp_path / "r_sw1.yaml"
    path.write_text(TESTER, encoding="utf-8")
    assert main(["validate", str(path)]) == 0, capsys.readouterr().err
    out = tmp_path / "r_sw1.nc"
    assert main(["run", str(path), "-o", str(out), "-q"]) == 0, capsys.readouterr().err
    ds = gearsweep.open_result(out)
    assert ds.attrs["study"] == TESTER  # the study as written
    assert ds.sizes["backlash"] == 2 and "backlash" in ds.attrs["model_swept"].split()
    # the model holds no scene value the scene did not give (it had none: NaN, not a case's)
    assert math.isnan(json.loads(ds.attrs["model"])["backlash"])
    assert gearsweep.result_study(ds).scene.backlash is None
    case = gearsweep.result_model(ds, backlash=0.4698)
    assert case.backlash == pytest.approx(0.4698e-3)
    assert main(["inspect", str(out)]) == 0
    assert "backlash" in capsys.readouterr().out


def test_a_study_without_the_swept_scene_field_reads_back_as_itself():
    """``study_text`` writes no scene value the scene did not give; parsed again it is the same
    study (a result's study attribute of a study changed in Python)."""
    for name in ("backlash", "mass", "stiffness"):
        study = parse_study(_swept(name))
        assert getattr(study.scene, name) is None
        assert f"  {name}:" not in study_text(study).split("sweep:")[0]
        assert parse_study(study_text(study)).model_dump() == study.model_dump()


def test_the_plan_of_a_swept_field_is_that_of_a_scene_value_beside_it():
    """The kernel's inputs are the same with or without a (dummy) scene value of a swept field:
    the sweep wins (so studies/rattle_map.yaml needs no dummy backlash)."""
    from gearsweep.model import kernel_inputs
    from gearsweep.study.plan import _lane_params

    for name, dummy in (("backlash", "  backlash: 9 mm\n"), ("mass", "  mass: 9 kg\n"),
                        ("stiffness", "  stiffness: 9 kN/mm\n")):
        alone, both = make_plan(parse_study(_swept(name))), make_plan(parse_study(
            _swept(name, dummy)))
        assert alone.dims == both.dims and alone.n_lanes == both.n_lanes
        for d in alone.dims:
            np.testing.assert_array_equal(alone.grids[d], both.grids[d])
        pa, pb = _lane_params(alone, 0, alone.n_lanes), _lane_params(both, 0, both.n_lanes)
        ka = kernel_inputs(alone.model, pa, alone.n_lanes, 32)
        kb = kernel_inputs(both.model, pb, both.n_lanes, 32)
        assert ka.keys() == kb.keys()
        for key in ka:
            np.testing.assert_array_equal(np.asarray(ka[key], dtype=float),
                                          np.asarray(kb[key], dtype=float), err_msg=key)
        assert math.isnan(getattr(alone.model, name)) and name in alone.model_swept


def _lines(text: str) -> list[str]:
    with pytest.raises(StudyError) as err:
        parse_study(text, "s.yaml")
    return str(err.value).split("\n")


def test_a_field_missing_and_not_swept_is_refused_as_before():
    """Left out and swept something else: the same lines as ever."""
    damping = "  damping: [100 N*s/m, 500 N*s/m]\n  speed: {"
    no_backlash = BASE.replace("  backlash: 0.1 mm\n", "").replace("  speed: {", damping)
    assert _lines(no_backlash) == ["s.yaml:2: scene.backlash: '(missing)' -- this field is required"]
    no_mass = BASE.replace("  mass: 0.1527 kg\n", "").replace("  speed: {", damping)
    assert _lines(no_mass) == [
        ("s.yaml:2: scene: '{...}' -- give exactly one of 'mass' (m_eq) and 'drive' (inertias,"
         " radii)")]
    no_k = BASE.replace("  stiffness: 1073 kN/mm\n", "").replace("  speed: {", damping)
    assert _lines(no_k) == [
        ("s.yaml:2: scene: '{...}' -- 'stiffness' required (or a 'gear' that gives teeth,"
         " stiffness and their harmonics)")]


def test_a_swept_field_left_out_beside_another_error_says_only_that_error():
    """With another error in the file the scene's presence is checked on the file itself
    (``_problems_beside_errors``): it too takes the sweep's fields as given."""
    for name in ("backlash", "mass", "stiffness"):
        text = _swept(name).replace("method: rk4", "method: rk3")
        assert _lines(text) == [
            "s.yaml:12: solver.method: 'rk3' -- did you mean 'rk5'? (allowed: rk4, rk5)"], name


def test_a_swept_mass_beside_a_drive_and_a_mass_is_still_refused():
    """The sweep gives a missing mass; it does not allow both 'mass' and 'drive'."""
    drive = ("  drive: {inertia_1: 1e-3 kg*m^2, inertia_2: 2e-3 kg*m^2, base_radius_1: 60 mm,"
             " base_radius_2: 90 mm}\n")
    text = _swept("mass", "  mass: 0.2 kg\n" + drive)
    assert any("give exactly one of 'mass' (m_eq) and 'drive'" in line for line in _lines(text))


def test_a_whine_scene_sweeping_mass_and_stiffness_need_write_neither():
    """The scene's presence check is the whine, rattle and full scenes' alike."""
    text = ("title: t\nscene:\n  kind: whine\n  teeth: 48\n  mean_force: 1000 N\n"
            "  damping: 5.5 N*s/mm\n  stiffness_harmonics: [{amplitude: 100 kN/mm}]\nsweep:\n"
            "  mass: [0.1527 kg, 0.2 kg]\n  stiffness: [1073 kN/mm, 900 kN/mm]\n"
            "  speed: [3000 rpm, 4000 rpm]\n"
            "solver: {method: rk4, steps_per_period: 64, transient_periods: 4, record_periods: 4}\n")
    plan = make_plan(parse_study(text, "s.yaml"), text)
    assert {"mass", "stiffness"} <= set(plan.model_swept)
    assert math.isnan(plan.model.mass) and math.isnan(plan.model.stiffness)
    typed = text.replace("  teeth: 48\n", "  teeth: 48\n  mass: 1 kg\n  stiffness: 1 kN/mm\n")
    a, b = gearsweep.run(text), gearsweep.run(typed)
    np.testing.assert_array_equal(a["p_rms"].values, b["p_rms"].values)


def test_an_excitation_file_without_stiffness_takes_a_swept_one(tmp_path):
    """A rattle scene whose excitation file has the STE only: the stiffness is typed in, or,
    now, swept ("required: excitation.file has no mesh_stiffness column" only when neither)."""
    import xarray as xr

    teeth, n = 20, 48
    angle = np.arange(n) / n * 360.0 / teeth
    ste = 2e-6 + 1.2e-6 * np.cos(2 * np.pi * angle * teeth / 360.0)
    xr.Dataset({"ste": ("angle", ste * 1e6, {"units": "um"})},
               coords={"angle": ("angle", angle, {"units": "degree"})}).to_netcdf(
        tmp_path / "te.nc")
    text = ("title: t\nscene:\n  kind: rattle\n  teeth: 20\n  mass: 0.2 kg\n"
            "  damping: 1000 N*s/m\n  backlash: 20 um\n  mean_force: 100 N\n"
            "  excitation: {file: te.nc, harmonics: 4}\n"
            "sweep:\n  stiffness: [2e8 N/m, 3e8 N/m]\n  speed: [1500 rpm, 6000 rpm]\n"
            "solver: {method: rk4, steps_per_period: 64, transient_periods: 40,"
            " record_periods: 20}\n")
    (tmp_path / "r.yaml").write_text(text, encoding="utf-8")
    (tmp_path / "t.yaml").write_text(text.replace("  mean_force: 100 N\n", (
        "  mean_force: 100 N\n  stiffness: 9e8 N/m\n")), encoding="utf-8")
    alone, typed = gearsweep.run(tmp_path / "r.yaml"), gearsweep.run(tmp_path / "t.yaml")
    np.testing.assert_array_equal(alone["p_rms"].values, typed["p_rms"].values)
    (tmp_path / "n.yaml").write_text(text.replace("  stiffness: [2e8 N/m, 3e8 N/m]\n", ""),
                                     encoding="utf-8")
    with pytest.raises(StudyError, match="scene.stiffness: '\\(missing\\)' -- required:"
                       " excitation.file has no mesh_stiffness column"):
        parse_study((tmp_path / "n.yaml").read_text(encoding="utf-8"), str(tmp_path / "n.yaml"))

"""Study input errors outside testers found writing their own YAML studies for ``gearsweep
validate`` and ``gearsweep run``: each is one line ``FILE:LINE: FIELD: VALUE -- what is allowed``
and exit code 2, and ``validate`` refuses what ``run`` would refuse of the file."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
import xarray as xr
from conftest import GOOD_RATTLE

import gearsweep
from gearsweep.cli import main
from gearsweep.errors import StudyError
from gearsweep.model import SWEEPABLE
from gearsweep.study.schema import SCENE_PARAMETERS, parse_study

GOOD = GOOD_RATTLE
RANGE = "{start: 5000 rpm, stop: 6000 rpm, num: 3}"
ROOT = Path(__file__).resolve().parents[1]


def _lines(text: str) -> list[str]:
    with pytest.raises(StudyError) as err:
        parse_study(text, "s.yaml")
    return str(err.value).split("\n")


# ------------------------------------------------------------ a scalar is a one-value sweep axis


ONE_VALUE = {"speed": "3000 rpm", "mean_force": "200 N", "damping": "10 N*s/m",
             "mass": "0.2 kg", "stiffness": "1000 kN/mm", "backlash": "0.2 mm",
             "alpha": "0.5", "beta": "0.1", "gamma": "0.01"}
"""A value of every sweepable parameter (torque: its own scene below, with a base radius)."""


@pytest.mark.parametrize("name", sorted(SWEEPABLE))
def test_a_scalar_for_a_sweep_axis_is_the_list_of_that_one_value(name):
    """``sweep: {speed: 3000 rpm}`` was refused ("a list of values or {start, stop, num}"): a
    scalar is the axis of that one value, ``[3000 rpm]``, for every sweepable field."""
    if name in SCENE_PARAMETERS["mathieu"]:
        text = f"title: t\nscene: {{kind: mathieu}}\nsweep:\n  {name}: VALUE\n"
    else:
        text = GOOD.replace("mean_force: 100 N", "mean_force: 100 N\n  base_radius: 50 mm")
        if name == "torque":
            text = text.replace("  mean_force: 100 N\n", "")
        if name != "speed":
            text = text.replace(RANGE, f"[5000 rpm, 6000 rpm]\n  {name}: VALUE")
        else:
            text = text.replace(RANGE, "VALUE")
    value = ONE_VALUE.get(name, "5 N*m")
    one = parse_study(text.replace("VALUE", value), "s.yaml")
    listed = parse_study(text.replace("VALUE", f"[{value}]"), "s.yaml")
    assert one.sweep[name] == listed.sweep[name] == [float(value) if name in ("alpha", "beta",
                                                                                "gamma") else value]
    assert list(one.grid(name)) == list(listed.grid(name)) and len(one.grid(name)) == 1


def test_a_scalar_sweep_axis_runs_to_the_result_of_its_one_value_list():
    """The result of ``speed: 3000 rpm`` is that of ``speed: [3000 rpm]``: a speed dim of
    length 1 with the same values."""
    one = gearsweep.run(GOOD.replace(RANGE, "3000 rpm"))
    listed = gearsweep.run(GOOD.replace(RANGE, "[3000 rpm]"))
    assert one.sizes["speed"] == 1 and dict(one.sizes) == dict(listed.sizes)
    xr.testing.assert_equal(one, listed)


def test_a_scalar_sweep_axis_gets_the_units_checks_of_a_list_on_its_own_line():
    """A scalar axis is checked as a list's value is (unit, sign, bound), on the axis' line and
    named as the file writes it (``sweep.speed``, not ``sweep.speed[0]``)."""
    assert _lines(GOOD.replace(RANGE, "3000 mm")) == [
        ("s.yaml:10: sweep.speed: '3000 mm' -- a speed: is a length (mm), expected speed"
        " (e.g. '1 rpm')")]
    assert _lines(GOOD.replace(RANGE, "-5 rpm")) == [
        "s.yaml:10: sweep.speed: '-5 rpm' -- speed must be > 0"]
    assert _lines(GOOD.replace(RANGE, "[5000 rpm]\n  backlash: 0.2")) == [
        ("s.yaml:11: sweep.backlash: 0.2 has no unit; write e.g. '0.2 mm', or '0.2 m' if SI was"
        " meant")]
    assert _lines(GOOD.replace(RANGE, "true")) == [
        "s.yaml:10: sweep.speed: True -- a value, a list of values or {start, stop, num}"]


def test_a_scalar_torque_axis_of_a_mesh_study_is_one_torque():
    mesh = parse_study("type: mesh\ntitle: t\ngear: table1_consistent\nsweep: {torque: 50 N*m}\n")
    assert list(mesh.torques()) == [50.0]


# ------------------------------------------------------------ an unclosed '{' or '[' of YAML


def test_an_unclosed_brace_says_where_it_was_opened(tmp_path, capsys):
    """A range missing its '}' gave PyYAML's "expected ',' or '}', but got ':'" at the next line,
    with no hint: the line says which bracket, opened on which line, is not closed."""
    study = tmp_path / "s.yaml"
    study.write_text(GOOD.replace(RANGE, RANGE.removesuffix("}")))
    assert main(["validate", str(study)]) == 2
    assert capsys.readouterr().err.splitlines() == [
        (f"gearsweep: error: {study}:11: (yaml): not valid YAML: expected ',' or '}}', but got ':'"
        " (an unclosed '{' opened at line 10?)")]
    assert _lines(GOOD.replace(RANGE, "[5000 rpm, 6000 rpm")) == [
        ("s.yaml:11: (yaml): not valid YAML: expected ',' or ']', but got ':' (an unclosed '['"
        " opened at line 10?)")]
    assert _lines("title: t\nsweep:\n  speed: [1 rpm, 2 rpm\n") == [  # at the end of the file
        ("s.yaml:4: (yaml): not valid YAML: expected ',' or ']', but got '<stream end>' (an"
        " unclosed '[' opened at line 3?)")]


def test_a_bracket_mismatch_on_its_own_line_keeps_yamls_message():
    """Within one line (a '}' for a ']') nothing was left open on an earlier line: PyYAML's
    words, as before."""
    assert _lines("title: t\nsweep: {speed: [1 rpm, 2 rpm}\n") == [
        "s.yaml:2: (yaml): not valid YAML: expected ',' or ']', but got '}'"]


# ------------------------------------------------------- a problem between fields, at its field

DRIVE = ("  drive: {inertia_1: 1e-3 kg m^2, inertia_2: 2e-3 kg m^2, base_radius_1: 50 mm,"
         " base_radius_2: 50 mm}\n")


@pytest.mark.parametrize("text, line", [
    (GOOD.replace("  teeth: 48\n", DRIVE + "  teeth: 48\n"),  # mass and drive: at the later
     ("s.yaml:5: scene.drive: '{...}' -- give exactly one of 'mass' (m_eq) and 'drive'"
     " (inertias, radii)")),
    (GOOD.replace("  mass: 0.1527 kg\n", "  mass: 0.1527 kg\n  torque: 5 N*m\n  base_radius:"
                  " 50 mm\n"),
     "s.yaml:10: scene.mean_force: '100 N' -- give at most one of 'mean_force' and 'torque'"),
    (GOOD.replace("  mass: 0.1527 kg\n", DRIVE + "  base_radius: 50 mm\n"),
     ("s.yaml:5: scene.base_radius: '50 mm' -- with a 'drive', its 'base_radius_1' is the base"
     " radius: leave out 'base_radius'")),
    (GOOD.replace("  teeth: 48\n", "  teeth: 48\n  harmonics: 5\n"),
     ("s.yaml:6: scene.harmonics: 5 -- 'harmonics' is the number of Fourier terms of a 'gear';"
     " no gear")),
    (GOOD.replace("  teeth: 48\n  stiffness: 1073 kN/mm\n", (
        "  gear:\n    preset: table1_consistent\n    tip_relief: {amount: 10 um, start_radius:"
        " 60 mm,\n      start_diameter: 120 mm}\n")),
     ("s.yaml:8: scene.gear.tip_relief.start_diameter: '120 mm' -- give exactly one of start_at,"
     " start_radius, start_diameter, start_roll_angle")),
    (GOOD + "outputs:\n  - spectrum:\n      samples_per_period: 8\n      max_order: 6\n",
     ("s.yaml:15: outputs[0].spectrum.max_order: 6 -- max_order 6 is above the Nyquist order"
     " samples_per_period / 2 = 4")),
    ("type: mesh\ntitle: t\ngear: table1_consistent\ntorque: 5 N*m\ngears: {a: table1_consistent}\n",
     ("s.yaml:5: gears: '{...}' -- give exactly one of 'gear' (one pair) and 'gears' (labelled"
     " variants)")),
    (("type: analysis\ntitle: t\nanalysis:\n  kind: rattle_budget\n  fitted: a\n  scenes: [b, c]\n"
     "  names: [x]\n  mesh: m\n"),
     "s.yaml:7: analysis.names: '[...]' -- one name per scene: 2 names for the 2 scenes, not 1"),
])
def test_a_problem_between_two_fields_is_at_the_line_of_the_field_it_names(text, line):
    """Checks that compare two fields reported every problem at the line of the scene (or the
    gear, the relief, the output, the analysis, the file's first line): each is at the line of
    the field the message names, the one written beside the other."""
    assert _lines(text) == [line]


def test_what_a_scene_lacks_stays_one_line_at_the_scene():
    """A field that is not written has no line: what the scene lacks is said at its line, in
    one line, beside a problem of a written field at that field's."""
    text = "title: x\nscene:\n  kind: whine\n  harmonics: 5\n  speed: 3000 rpm\n"
    assert _lines(text) == [
        ("s.yaml:2: scene: '{...}' -- give exactly one of 'mass' (m_eq) and 'drive' (inertias,"
         " radii); 'teeth' and 'stiffness' required (or a 'gear' that gives teeth, stiffness and"
         " their harmonics)")]
    text = GOOD.replace("  mass: 0.1527 kg\n", "").replace("  teeth: 48\n", (
        "  teeth: 48\n  dampin: 1 N*s/m\n"))
    assert _lines(text) == [
        ("s.yaml:2: scene: '{...}' -- give exactly one of 'mass' (m_eq) and 'drive' (inertias,"
         " radii)"),
        ("s.yaml:5: scene.dampin: 'dampin' is not a field of a rattle scene -- did you mean"
        " 'damping'?")]


@pytest.mark.parametrize("study, line", [
    ("stability_artifact_map.yaml", ":1: type: 'analysis' -- a dynamic study"),
    ("strutt_mathieu.yaml", ":8: scene.kind: 'mathieu' -- a gear scene"),
])
def test_advise_names_the_line_of_what_it_cannot_advise_on(study, line, capsys):
    path = ROOT / "studies" / study
    assert main(["advise", str(path)]) == 2
    assert capsys.readouterr().err.startswith(f"gearsweep: error: {path}{line}")


# ------------------------------------------- an analysis' input that run refuses, validate too


def _analysis(tmp_path, kind: str, field: str, name: str) -> Path:
    study = tmp_path / f"{kind}.yaml"
    study.write_text(f"type: analysis\ntitle: t\nanalysis:\n  kind: {kind}\n  {field}: {name}\n",
                     encoding="utf-8")
    return study


def test_an_artifact_map_of_a_result_that_is_no_rig_is_refused_by_validate_at_its_line(
        tmp_path, monkeypatch, capsys):
    """An artifact_map whose rig is a result of the wrong kind (a rattle sweep: no stiffness
    harmonic, no damping sweep) was 'ok' for validate; run refused it with 'flat: artifact_map
    needs a rig ...', no file, line or field. Both now refuse it at analysis.rig's line."""
    monkeypatch.chdir(tmp_path)  # validate and run without -o read results/
    (tmp_path / "results").mkdir()
    gearsweep.run(GOOD, output=tmp_path / "results" / "flat.nc")
    study = _analysis(tmp_path, "artifact_map", "rig", "flat")
    line = (f"gearsweep: error: {study}:5: analysis.rig: 'flat' -- artifact_map needs a rig: a"
            " gear scene's result with a stiffness harmonic k1 that sweeps speed and damping"
            " (e.g. studies/stability_rig.yaml); this one has no stiffness harmonic and no"
            " damping sweep\n")
    assert main(["validate", str(study)]) == 2
    assert capsys.readouterr().err == line
    assert main(["run", str(study)]) == 2
    assert capsys.readouterr().err == line
    rig = GOOD.replace("kind: rattle", "kind: whine").replace("  backlash: 0.1 mm\n", (
        "  stiffness_harmonics: [{amplitude: 100 kN/mm}]\n")).replace(
        RANGE, f"{RANGE}\n  damping: [1 N*s/mm, 5 N*s/mm]")
    gearsweep.run(rig, output=tmp_path / "results" / "rig.nc")
    assert main(["validate", str(_analysis(tmp_path, "artifact_map", "rig", "rig"))]) == 0


def test_a_rattle_balance_of_a_result_it_cannot_balance_is_refused_by_validate(
        tmp_path, monkeypatch, capsys):
    """rattle_balance of a result that is not a constant-stiffness rattle sweep continued up and
    down: validate said ok and run refused it in a line of no file or field."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "results").mkdir()
    gearsweep.run(GOOD, output=tmp_path / "results" / "flat.nc")
    study = _analysis(tmp_path, "rattle_balance", "result", "flat")
    assert main(["validate", str(study)]) == 2
    assert capsys.readouterr().err == (
        f"gearsweep: error: {study}:5: analysis.result: 'flat' -- rattle_balance needs a"
        " constant-stiffness scene with backlash and one force harmonic\n")


# ------------------------------------------------------ a start beyond the divergence bound


FREE = """\
title: free vibration from a velocity
scene: {kind: whine, mass: 0.1527 kg, teeth: 48, stiffness: 1073 kN/mm, damping: 100 N*s/m,
        mean_force: 0 N}
sweep:
  speed: [3000 rpm, 4000 rpm]
solver: {steps_per_period: 128, transient_periods: 4, record_periods: 4, initial_velocity: VALUE}
"""


def test_a_start_with_a_velocity_is_within_the_divergence_bound():
    """The bound on |p| is divergence_factor x the static scale, which holds the start's |p0|
    but not its velocity: with no load (scale 1e-12 m, bound 1 um) a free vibration from 1 m/s
    (a swing of |p'0| / omega_n = 12 um) was 'diverged' (status 1, every statistic NaN) in
    every case. The scale holds the swing |p'0| sqrt(m / k0) now, as it holds |p0|."""
    swing = 1.0 * (0.1527 / 1073e6) ** 0.5  # [m]
    ds = gearsweep.run(FREE.replace("VALUE", "1 m/s"))
    assert (ds.status != 1).all() and ds.p_max.attrs["units"] == "um"
    assert (ds.p_max > 0.1 * swing * 1e6).all() and (ds.p_max <= swing * 1e6).all()


@pytest.mark.parametrize("start", ["initial_displacement: 100 m", "initial_displacement: -1 m",
                                   "initial_displacement: static"])
def test_a_start_far_from_rest_is_within_the_divergence_bound(start):
    """A start's displacement is in the static scale: however far (100 m), it is no case that
    diverges at its start (a tester's report that one was; it is within the bound by design)."""
    ds = gearsweep.run(FREE.replace("initial_velocity: VALUE", start).replace(
        "mean_force: 0 N", "mean_force: 100 N"))
    assert (ds.status != 1).all()


# ------------------------------------------------ numbers YAML 1.1 and YAML 1.2 read differently


def test_a_number_yaml_1_1_and_1_2_read_differently_is_refused_naming_both_readings():
    """PyYAML's YAML 1.1 resolvers read 03000 as octal (1536), 50:00 as base 60 (3000), 0b10 as
    binary and 1_000 as 1000; YAML 1.2 reads 03000 as 3000, the others as text, and 0o10 as 8
    (which YAML 1.1 reads as text). ``speed: [03000, 04000]`` validated as 1536-2048 rpm and
    ``teeth: 030`` as 24 teeth, exit 0 (an outside tester's finding). Each is one line, at its
    own line, naming both readings, in a flow sequence, a flow mapping or a block."""
    text = (GOOD.replace("speed: {start: 5000 rpm, stop: 6000 rpm, num: 3}",
                         "speed: [03000, 50:00, 1:30.5, 0o10]")
            .replace("teeth: 48", "teeth: 030")
            .replace("steps_per_period: 32, transient_periods: 4",
                     "steps_per_period: 0100, transient_periods: 1_000")
            .replace("record_periods: 4", "record_periods: 0b100"))
    assert _lines(text) == [
        ("s.yaml:5: scene.teeth: 030 is read as 24 by YAML 1.1 (a leading 0 makes it octal) and"
         " as 30 by YAML 1.2: write it without the leading 0 (30), or 24 if octal was meant"),
        ("s.yaml:10: sweep.speed[0]: 03000 is read as 1536 by YAML 1.1 (a leading 0 makes it"
         " octal) and as 3000 by YAML 1.2: write it without the leading 0 (3000), or 1536 if"
         " octal was meant"),
        ("s.yaml:10: sweep.speed[1]: 50:00 is read as 3000 by YAML 1.1 (base 60) and as the text"
         " '50:00' by YAML 1.2: write the number in decimal digits (3000), or in quotes"
         " ('50:00') if text is meant"),
        ("s.yaml:10: sweep.speed[2]: 1:30.5 is read as 90.5 by YAML 1.1 (base 60) and as the text"
         " '1:30.5' by YAML 1.2: write the number in decimal digits (90.5), or in quotes"
         " ('1:30.5') if text is meant"),
        ("s.yaml:10: sweep.speed[3]: 0o10 is read as the text '0o10' by YAML 1.1 and as 8 by"
         " YAML 1.2 (octal): write the number in decimal digits (8), or in quotes ('0o10') if"
         " text is meant"),
        ("s.yaml:11: solver.steps_per_period: 0100 is read as 64 by YAML 1.1 (a leading 0 makes"
         " it octal) and as 100 by YAML 1.2: write it without the leading 0 (100), or 64 if"
         " octal was meant"),
        ("s.yaml:11: solver.transient_periods: 1_000 is read as 1000 by YAML 1.1 (digits grouped"
         " by _) and as the text '1_000' by YAML 1.2: write the number in decimal digits (1000),"
         " or in quotes ('1_000') if text is meant"),
        ("s.yaml:11: solver.record_periods: 0b100 is read as 4 by YAML 1.1 (binary) and as the"
         " text '0b100' by YAML 1.2: write the number in decimal digits (4), or in quotes"
         " ('0b100') if text is meant")]
    with pytest.raises(StudyError) as err:  # one value, written in a block
        parse_study(GOOD.replace("speed: {start: 5000 rpm, stop: 6000 rpm, num: 3}",
                                 "speed:\n    - 3000\n    - 04000"), "s.yaml")
    assert str(err.value).startswith("s.yaml:12: sweep.speed[1]: 04000 is read as 2048"), err.value
    with pytest.raises(StudyError) as err:  # a scalar axis is named as written
        parse_study(GOOD.replace("speed: {start: 5000 rpm, stop: 6000 rpm, num: 3}",
                                 "speed: 03000"), "s.yaml")
    assert str(err.value).startswith("s.yaml:10: sweep.speed: 03000 is read as 1536"), err.value


@pytest.mark.parametrize("written", ["0x10", "+5", ".5", "-0.5", "1.5e+3", "1e3", "007", "089",
                                     "10", "0", ".inf", ".nan", "'030'", "1_000 rpm", "8:00"])
def test_a_number_both_yaml_versions_read_alike_is_taken(written):
    """Where YAML 1.1 and 1.2 agree (0x10 is 16 in both; 007 is 7; 1e3, which YAML 1.1 leaves as
    text, is read by the fields as 1000, as YAML 1.2 reads it) nothing is refused for the
    reading; a quoted value or a quantity's text is not a YAML number at all (8:00, a time of
    day to a reader, is 480 to YAML 1.1 and text to YAML 1.2: refused)."""
    from gearsweep.study.schema import load_yaml

    text = f"a: {written}\nb: [{written}]\nc: {{d: {written}}}\n"
    if written == "8:00":
        with pytest.raises(StudyError):
            load_yaml(text, "s.yaml")
        return
    assert load_yaml(text, "s.yaml") is not None


def test_a_speed_in_hexadecimal_or_with_an_exponent_is_read_as_both_yaml_versions_read_it():
    study = parse_study(GOOD.replace("{start: 5000 rpm, stop: 6000 rpm, num: 3}",
                                     "[0xBB8, 4e3, 5.0e+3]"), "s.yaml")
    assert list(study.grid("speed")) == [3000, 4000, 5000]  # rpm


def test_a_whole_number_with_an_exponent_is_taken_as_the_number_it_is():
    """``num: 1e3`` (text to YAML 1.1, 1000.0 to YAML 1.2) said "Input should be a valid integer,
    unable to parse string as an integer" of a number the user wrote, while ``num: 1.0e+3`` was
    1000; 1e12 and 1e400 said the same (an outside tester's finding). An exponent's number is
    taken as a whole number's field takes 1000.0, and held to the field's bounds."""
    study = parse_study(GOOD.replace("num: 3}", "num: 1e1}"), "s.yaml")
    assert len(study.grid("speed")) == 10
    assert _lines(GOOD.replace("num: 3}", "num: 1e12}")) == [
        "s.yaml:10: sweep.speed.num: '1e12' -- Input should be less than or equal to 10000000"]
    assert _lines(GOOD.replace("num: 3}", "num: 2.5e0}")) == [
        ("s.yaml:10: sweep.speed.num: '2.5e0' -- Input should be a valid integer, got a number"
         " with a fractional part")]
    assert _lines(GOOD.replace("teeth: 48", "teeth: 1e400")) == [
        ("s.yaml:5: scene.teeth: '1e400' -- a whole number (1e400 is beyond the largest number,"
         " about 1.8e308)")]


def test_an_aliased_number_read_two_ways_is_reported_at_the_field_that_uses_it():
    """``teeth: &z 030`` on line 5 and ``record_periods: *z`` later: the refusal of the alias
    was reported at the anchor's line (5), where an ordinary error through the same alias
    (``&z -1``) is at the field's (an outside tester's finding). In a block mapping, a flow
    sequence and a block sequence, each use is at its own line."""
    text = (GOOD.replace("teeth: 48", "teeth: &z 030")
            .replace("record_periods: 4}", "record_periods: 4}\nextra: [*z]\nmore:\n  - *z")
            .replace("solver: {method: rk4, steps_per_period: 32, transient_periods: 4,"
                     " record_periods: 4}",
                     "solver:\n  method: rk4\n  steps_per_period: 32\n  transient_periods: 4\n"
                     "  record_periods: *z"))
    from gearsweep.study.schema import load_yaml

    with pytest.raises(StudyError) as err:
        load_yaml(text, "s.yaml")
    lines = [line.split(" is read")[0] for line in str(err.value).split("\n")]
    assert lines == ["s.yaml:5: scene.teeth: 030", "s.yaml:15: solver.record_periods: 030",
                     "s.yaml:16: extra[0]: 030", "s.yaml:18: more[0]: 030"], err.value
    ordinary = _lines(GOOD.replace("teeth: 48", "teeth: &z -1").replace(
        "solver: {method: rk4, steps_per_period: 32, transient_periods: 4, record_periods: 4}",
        "solver:\n  method: rk4\n  steps_per_period: 32\n  transient_periods: 4\n"
        "  record_periods: *z"))
    assert any(x.startswith("s.yaml:15: solver.record_periods: -1") for x in ordinary), ordinary


@pytest.mark.parametrize("field", ["title", "description"])
@pytest.mark.parametrize("written, readings", [
    ("1:30", "is read as 90 by YAML 1.1 (base 60) and as the text '1:30' by YAML 1.2"),
    ("030", "is read as 24 by YAML 1.1 (a leading 0 makes it octal) and as 30 by YAML 1.2"),
    ("0o10", "is read as the text '0o10' by YAML 1.1 and as 8 by YAML 1.2 (octal)")])
def test_a_text_field_read_two_ways_is_told_to_quote_only(field, written, readings):
    """``title: 1:30`` was told "write the number in decimal digits (90)": a title is text, so
    only the quoting advice applies (an outside tester's finding)."""
    from gearsweep.study.schema import load_yaml

    with pytest.raises(StudyError) as err:
        load_yaml(f"{field}: {written}\n", "s.yaml")
    assert str(err.value) == (f"s.yaml:1: {field}: {written} {readings}: {field} is text; write"
                              f" it in quotes ('{written}')")


@pytest.mark.parametrize("written, read", [("2026", "a number"), ("1.5", "a number"),
                                           ("true", "a boolean"), ("off", "a boolean")])
def test_an_unquoted_number_for_a_text_field_is_told_to_quote_it(written, read):
    """``title: 2026`` said only "Input should be a valid string": YAML reads an unquoted 2026,
    1.5 or true as a number or a boolean, not text; the line says so and how to write it."""
    text = re.sub(r"(?m)^title: .*$", f"title: {written}", GOOD)
    assert f"title: {written}\n" in text
    (line,) = _lines(text)
    assert line.startswith("s.yaml:1: title: ") and line.endswith(
        f"-- text; YAML reads this unquoted value as {read}: write it in quotes"), line


@pytest.mark.parametrize("written, value, why", [
    ("-0x30", -48, "hexadecimal with a sign"), ("+0x30", 48, "hexadecimal with a sign"),
    ("0x_30", 48, "hexadecimal, digits grouped by _"),
    ("-0x_30", -48, "hexadecimal with a sign, digits grouped by _"),
    ("1_000", 1000, "digits grouped by _")])
def test_a_signed_or_grouped_hexadecimal_is_named_for_what_yaml_1_2_refuses(written, value, why):
    """``-0x30`` was said to be "(digits grouped by _)": it has no _; YAML 1.2 reads a
    hexadecimal with no sign and no _, so each reading is named for what it has."""
    from gearsweep.study.schema import load_yaml

    with pytest.raises(StudyError) as err:
        load_yaml(f"a: {written}\n", "s.yaml")
    assert str(err.value).startswith(f"s.yaml:1: a: {written} is read as {value} by YAML 1.1"
                                      f" ({why}) and as the text '{written}' by YAML 1.2"), err.value

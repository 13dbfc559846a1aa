"""Errors that point at the line: every problem of a file at once, in the study's own words."""

from __future__ import annotations

import io
import math
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import GOOD_RATTLE, WHINE_SCENE

from gearsweep.cli import main
from gearsweep.errors import StudyError
from gearsweep.study.plan import make_plan
from gearsweep.study.schema import parse_study
from gearsweep.units import decimal_coordinates

ROOT = Path(__file__).resolve().parents[1]

GOOD = GOOD_RATTLE


WHINE_GOOD = "title: t\n" + WHINE_SCENE + "sweep:\n  speed: [3000 rpm, 4000 rpm]\n"


def _lines(text: str) -> list[str]:
    with pytest.raises(StudyError) as err:
        parse_study(text, "s.yaml")
    return str(err.value).split("\n")


def test_three_errors_give_three_lines_with_line_numbers():
    text = (GOOD.replace("mass: 0.1527 kg", "mass: -1 kg").replace("backlash: 0.1 mm", "backlash: 0.1")
            .replace("method: rk4", "method: rk3"))
    lines = _lines(text)
    assert lines == [
        "s.yaml:4: scene.mass: '-1 kg' -- Input should be greater than 0",
        ("s.yaml:7: scene.backlash: 0.1 has no unit; write e.g. '0.1 mm', or '0.1 m' if SI was"
        " meant"),
        "s.yaml:11: solver.method: 'rk3' -- did you mean 'rk5'? (allowed: rk4, rk5)",
    ], lines


def test_a_study_error_survives_pickling_as_a_process_pool_sends_it():
    """StudyError could be pickled but not unpickled (Exception rebuilds it from its message
    alone, which ``__init__`` does not take): ``gearsweep.run`` of a bad study in a
    ProcessPoolExecutor gave BrokenProcessPool, the message lost (an outside tester's finding)."""
    import pickle

    text = GOOD.replace("mass: 0.1527 kg", "mass: -1 kg").replace("method: rk4", "method: rk3")
    with pytest.raises(StudyError) as err:
        parse_study(text, "s.yaml")
    again = pickle.loads(pickle.dumps(err.value))
    assert type(again) is StudyError and str(again) == str(err.value)
    assert (again.lines, again.problems, again.field, again.line) == (
        err.value.lines, err.value.problems, err.value.field, err.value.line)


def test_an_empty_output_list_and_a_value_swept_twice_are_refused():
    """``outputs: []`` (a result of status flags only) and a sweep that lists one value twice,
    in any spelling (``100 um`` after ``0.1 mm``: the file's coordinate would hold 0.1 twice and
    ``sel`` could not tell them apart) were accepted; each is one line now."""
    assert _lines(GOOD + "outputs: []\n") == [
        ("s.yaml:12: outputs: [] -- at least one output (leave the key out for stats); allowed:"
        " floquet, period, spectrum, stats")]
    twice = GOOD.replace("speed: {start: 5000 rpm, stop: 6000 rpm, num: 3}",
                         "speed: [6000 rpm, 100 Hz]\n  backlash: [0.1 mm, 0.2 mm, 100 um]")
    assert _lines(twice) == [
        ("s.yaml:10: sweep.speed[1]: '100 Hz' -- a value not already in the list (the same as"
        " sweep.speed[0], '6000 rpm'): each value once, or ds.sel() cannot tell them apart"),
        ("s.yaml:11: sweep.backlash[2]: '100 um' -- a value not already in the list (the same as"
        " sweep.backlash[0], '0.1 mm'): each value once, or ds.sel() cannot tell them apart")]
    parse_study(twice.replace("100 um", "300 um").replace("100 Hz", "110 Hz"), "s.yaml")


def test_an_unknown_field_is_matched_against_the_fields_where_it_stands():
    """A field of another scene kind says so (it was "'backlash' is an unknown field -- did you
    mean 'backlash'?"); a misspelling is matched against the fields of where it stands (a range:
    'step' was matched to 'ste', a scene field); an empty file or a list says what it holds
    (was 'NoneType', '_Seq')."""
    assert _lines(GOOD.replace("kind: rattle", "kind: whine").replace(
        "mean_force: 100 N", "mean_force: 100 N\n  speed: 5000 rpm")) == [
        ("s.yaml:7: scene.backlash: 'backlash' is not a field of a whine scene (it is one of a"
        " rattle or full scene)")]
    assert _lines(GOOD.replace("num: 3}", "num: 3, step: 500 rpm}")) == [
        ("s.yaml:10: sweep.speed.step: 'step' is not a field of a {start, stop, num} range -- did"
        " you mean 'stop'?")]
    assert _lines("") == [("s.yaml:1: (top level): the file holds nothing (an empty file); a study"
                          " is a mapping with title, scene, sweep, solver, outputs")]
    assert _lines("- a\n- b\n")[0].startswith("s.yaml:1: (top level): the file holds a list;")


def test_a_bare_scene_gets_every_missing_field_at_once():
    """A scene with only its kind: mass (or drive), teeth and stiffness, and the speed, in one
    run (an outside reader met them over three)."""
    assert _lines("title: x\nscene:\n  kind: whine\n") == [
        ("s.yaml:2: scene: '{...}' -- give exactly one of 'mass' (m_eq) and 'drive' (inertias,"
        " radii); 'teeth' and 'stiffness' required (or a 'gear' that gives teeth, stiffness and"
        " their harmonics)"),
        ("s.yaml:2: scene.speed: '(missing)' -- the speed must be swept (sweep.speed) or given"
        " (scene.speed)")]


def test_a_torque_fluctuation_needs_a_base_radius():
    """Without scene.base_radius, drive or gear, a torque amplitude cannot become a force (F = T
    / r1): refused in one line; it was accepted and every case came out 'diverged' (NaN)."""
    text = GOOD.replace("mean_force: 100 N\n",
                        "mean_force: 100 N\n  fluctuation: [{amplitude: 5 N m, order: 1}]\n")
    assert _lines(text) == [
        ("s.yaml:9: scene.fluctuation[0].amplitude: '5 N m' -- a force (e.g. '300 N'), or for a"
        " torque amplitude give scene.base_radius (F = T / r1, a rigid driven gear) or"
        " scene.drive (Eq. 7: F = m_eq T r1 / I1)")]
    parse_study(text.replace("5 N m", "300 N"), "s.yaml")
    parse_study(text.replace("mean_force: 100 N", "mean_force: 100 N\n  base_radius: 30 mm"),
                "s.yaml")


def test_the_torque_fluctuation_message_gives_the_force_each_choice_makes():
    """The message names the force each way of giving a torque amplitude makes, and that force
    is the one the model holds: T / r1 with a base radius; with a drive Eq. (7), m_eq T r1 / I1,
    computed here from the inertias (equal gears: half of T / r1, which the message used to name
    for both)."""
    text = GOOD.replace("mean_force: 100 N\n",
                        "mean_force: 100 N\n  fluctuation: [{amplitude: 5 N m, order: 1}]\n")
    (line,) = _lines(text)
    assert "F = T / r1" in line and "F = m_eq T r1 / I1" in line
    radius = text.replace("mean_force: 100 N", "mean_force: 100 N\n  base_radius: 50 mm")
    force = make_plan(parse_study(radius, "s.yaml")).model.force_harmonics[0].amplitude
    assert force == pytest.approx(5 / 0.05, rel=1e-12)
    i1, i2, r1, r2 = 1e-3, 1e-3, 0.05, 0.05
    drive = re.sub(r"  mass: [^\n]*\n", "  drive: {inertia_1: 0.001 kg m^2, inertia_2: 0.001 kg"
                   " m^2, base_radius_1: 50 mm, base_radius_2: 50 mm}\n", text)
    m_eq = 1 / (r1**2 / i1 + r2**2 / i2)
    force = make_plan(parse_study(drive, "s.yaml")).model.force_harmonics[0].amplitude
    assert force == pytest.approx(m_eq * 5 * r1 / i1, rel=1e-12)


def test_a_harmonic_order_given_twice_in_a_list_is_refused():
    """An order left out is the harmonic's position + 1: ``[{amplitude: 5 um, order: 2},
    {amplitude: 1 um}]`` was two order-2 harmonics, summed by the kernel with no word (an outside
    tester measured 6 um at order 2). Refused at the second, in one line each list; the same
    orders in different lists (k_2 beside e_2) are fine."""
    text = GOOD.replace("mean_force: 100 N\n", (
        "mean_force: 100 N\n  ste: [{amplitude: 5 um, order: 2}, {amplitude: 1 um}]\n"
        "  fluctuation: [{amplitude: 300 N, order: 1}, {amplitude: 30 N, order: 1.0}]\n"))
    assert _lines(text) == [
        ("s.yaml:9: scene.ste[1]: '(left out: position + 1 = 2)' -- order 2 again"
         " (scene.ste[0] has it): give each harmonic of a list its own order"),
        ("s.yaml:10: scene.fluctuation[1].order: 1.0 -- order 1 again (scene.fluctuation[0]"
         " has it): give each harmonic of a list its own order")]
    parse_study(text.replace("{amplitude: 1 um}", "{amplitude: 1 um, order: 3}")
                .replace("order: 1.0}", "order: 2}"), "s.yaml")


def test_a_mass_swept_beside_a_drive_and_a_torque_fluctuation_is_refused():
    """A torque fluctuation's force is Eq. (7) of the drive's m_eq; a swept mass replaced the
    mass and not that force, scaling the forcing by m_drive / m_swept (an outside tester's
    finding). One line on the sweep; a force fluctuation, or no fluctuation, is as before (the
    sweep replaces the drive's m_eq, which validate notes)."""
    drive = ("  drive: {inertia_1: 1.6e-3 kg*m^2, inertia_2: 3.2e-4 kg*m^2,"
             " base_radius_1: 56 mm, base_radius_2: 38 mm}\n"
             "  fluctuation: [{amplitude: 5 N*m, order: 1}]\n")
    text = (GOOD.replace("  mass: 0.1527 kg\n", drive)
            .replace("sweep:\n", "sweep:\n  mass: [0.1 kg, 0.2 kg]\n"))
    lines = _lines(text)
    assert len(lines) == 1 and lines[0].startswith("s.yaml:") and (
        "sweep.mass: '(swept)' -- a torque fluctuation beside scene.drive is a force from the"
        " drive's inertias (Eq. 7)") in lines[0], lines
    parse_study(text.replace("  mass: [0.1 kg, 0.2 kg]\n", ""), "s.yaml")
    parse_study(text.replace("5 N*m", "300 N"), "s.yaml")


def test_a_gear_field_written_for_the_pair_says_which_fields_it_is():
    """``teeth: [20, 40]`` under a mesh study's gear was told "'teeth' is an unknown field --
    did you mean 'teeth'?" (a scene's field; an outside tester's finding)."""
    text = ("type: mesh\ntitle: t\ngear:\n  module: 2 mm\n  teeth: [20, 40]\n"
            "  pressure_angle: 20 deg\n  face_width: 20 mm\ntorque: 50 N*m\n")
    assert _lines(text) == [("s.yaml:5: gear.teeth: 'teeth' is not a field of gear -- did you"
                            " mean z1 and z2 (the teeth of gear 1 and of gear 2)?")]
    assert "did you mean 'face_width'" in _lines(text.replace("face_width", "facewidth")
                                                  .replace("  teeth: [20, 40]", "  z1: 20\n  z2: 40"))[0]
    labelled = ("type: mesh\ntitle: t\ngears:\n  a: table1_consistent\n  b:\n    module: 2 mm\n"
                "    tip_radius: 22 mm\n    z1: 20\n    z2: 40\n    face_width: 20 mm\n"
                "torque: 50 N*m\n")  # a mesh study's labelled pairs: said alike
    assert _lines(labelled) == [("s.yaml:7: gears.b.tip_radius: 'tip_radius' is not a field of"
                                 " gear -- did you mean tip_radius1 and tip_radius2?")]


def test_a_gear_backlash_beside_another_dead_zone_is_refused():
    """``gear.backlash: 0.2 mm`` (at the pitch circle) beside ``scene.backlash: 0.3 mm`` (on the
    line of action) ran with 0.3 mm, the gear's ignored with no word (an outside tester's
    finding). One line on the scene's; the same dead zone in both (0.2 mm x cos 20 deg =
    0.18794 mm for this standard pair) is fine, and so is either alone."""
    gear = ("  gear: {module: 2 mm, z1: 25, z2: 50, face_width: 20 mm, backlash: 0.2 mm}\n"
            "  torque: 5 N*m\n")
    text = (GOOD.replace("  stiffness: 1073 kN/mm\n", "").replace("  teeth: 48\n", "")
            .replace("  mean_force: 100 N\n", gear).replace("backlash: 0.1 mm", "backlash: 0.3 mm"))
    assert _lines(text) == [
        ("s.yaml:5: scene.backlash: '0.3 mm' -- the gear's backlash is 0.1879 mm on the line of"
         " action (gear.backlash 0.2 mm at the pitch circle x cos alpha_w), but the dynamic"
         " model's dead zone is scene.backlash, not taken from the gear: write scene.backlash:"
         " 0.1879 mm (on the line of action), or leave gear.backlash out")]
    parse_study(text.replace("backlash: 0.3 mm", "backlash: 0.18794 mm"), "s.yaml")
    parse_study(text.replace(", backlash: 0.2 mm", ""), "s.yaml")


def test_a_gear_backlash_beside_a_swept_dead_zone_thins_the_teeth():
    """``gear.backlash`` beside ``sweep.backlash`` was refused with "leave gear.backlash out",
    quoting the sweep as '(swept)'; leaving it out thickened the teeth and raised k0 with no word
    (421.9 -> 424.8 kN/mm for an outside tester's 23/61 pair). Now the sweep is the dead zone and
    the gear's backlash the pair's geometry: its thinner teeth are less stiff."""
    gear = ("  gear: {module: 2 mm, z1: 25, z2: 50, face_width: 20 mm, backlash: 0.2 mm}\n"
            "  torque: 5 N*m\n")
    text = (GOOD.replace("  stiffness: 1073 kN/mm\n", "").replace("  teeth: 48\n", "")
            .replace("  mean_force: 100 N\n", gear)
            .replace("sweep:\n", "sweep:\n  backlash: [0.1 mm, 0.3 mm]\n")
            .replace("steps_per_period: 32", "steps_per_period: 40"))  # (4 per gear harmonic)
    plan = make_plan(parse_study(text, "s.yaml"))
    assert np.allclose(plan.grids["backlash"], [0.1e-3, 0.3e-3])
    thick = make_plan(parse_study(text.replace(", backlash: 0.2 mm", ""), "s.yaml"))
    assert plan.model.stiffness < thick.model.stiffness


def test_a_gear_backlash_alone_says_that_the_scene_does_not_take_it():
    """``gear.backlash`` alone: the line said "give the dead zone once, as scene.backlash or as
    gear.backlash", but the gear's is never passed on (docs/mesh.md): a rattle scene was then
    refused with a bare "this field is required", a full scene with its default '0 mm', which
    the file did not write (an engineer new to the tool)."""
    gear = ("  gear: {module: 2 mm, z1: 25, z2: 50, face_width: 20 mm, backlash: 0.2 mm}\n"
            "  torque: 5 N*m\n")
    rattle = (GOOD.replace("  stiffness: 1073 kN/mm\n", "").replace("  teeth: 48\n", "")
              .replace("  mean_force: 100 N\n", gear).replace("  backlash: 0.1 mm\n", ""))
    assert _lines(rattle) == [
        ("s.yaml:2: scene.backlash: '(missing)' -- this field is required (the dead zone along"
         " the line of action; gear.backlash, at the pitch circle, is not passed on: write"
         " scene.backlash = gear.backlash x cos alpha_w)")]
    assert _lines(rattle.replace(", backlash: 0.2 mm", "")) == [
        "s.yaml:2: scene.backlash: '(missing)' -- this field is required"]
    full = rattle.replace("kind: rattle", "kind: full")
    assert _lines(full) == [
        ("s.yaml:2: scene.backlash: '(not given: 0 mm)' -- the gear's backlash is 0.1879 mm on"
         " the line of action (gear.backlash 0.2 mm at the pitch circle x cos alpha_w), but the"
         " dynamic model's dead zone is scene.backlash, not taken from the gear: write"
         " scene.backlash: 0.1879 mm (on the line of action), or leave gear.backlash out")]
    assert parse_study(full.replace("kind: full", "kind: full\n  backlash: 0.18794 mm"),
                       "s.yaml").scene.backlash == pytest.approx(0.18794e-3)


def test_a_range_of_equal_values_is_refused():
    """``{start: 1 N s/mm, stop: 1 N s/mm, num: 3}`` gave three equal coordinates that sel()
    could not tell apart (as a value listed twice, which is refused); one value with num 1 is
    fine."""
    text = GOOD.replace("speed: {start: 5000 rpm, stop: 6000 rpm, num: 3}",
                        "speed: {start: 5000 rpm, stop: 5000 rpm, num: 3}")
    assert _lines(text) == [
        ("s.yaml:10: sweep.speed.stop: '5000 rpm' -- a stop above start ('5000 rpm'): 3 equal"
        " values could not be told apart by ds.sel(); one value is [value]")]
    parse_study(text.replace("num: 3", "num: 1"), "s.yaml")


def test_a_quantity_or_a_word_field_says_what_was_wrong_with_the_quantity():
    """solver.initial_displacement is a displacement or 'static': a bare number or a mass got
    "Input should be 'static'" (the word's branch); now the quantity's message, and the word."""
    text = GOOD.replace("method: rk4,", "method: rk4, initial_displacement: 2.0,")
    assert _lines(text) == [("s.yaml:11: solver.initial_displacement: 2 has no unit; write e.g."
                            " '2 um', or '2 m' if SI was meant (or 'static')")]
    assert _lines(text.replace("2.0", "2 kg")) == [
        ("s.yaml:11: solver.initial_displacement: '2 kg' -- is a mass (kg), expected"
        " displacement (e.g. '1 um') (or 'static')")]
    # a unit of no quantity a study has keeps pint's dimensions (was the only wording: "has units
    # of [mass] * [length] / [time] ** 2" for a force; a new-user test)
    assert _lines(text.replace("2.0", "2 kg/m")) == [
        ("s.yaml:11: solver.initial_displacement: '2 kg/m' -- has units of [mass] / [length],"
        " expected displacement (e.g. '1 um') (or 'static')")]


def test_a_typo_in_kind_says_did_you_mean():
    assert _lines(GOOD.replace("kind: rattle", "kind: whin")) == [
        ("s.yaml:3: scene.kind: 'whin' -- did you mean 'whine'? (allowed: whine, rattle, full,"
        " mathieu)")]


def test_an_unknown_field_says_did_you_mean():
    assert _lines(GOOD.replace("mean_force: 100 N", "mean_forse: 100 N")) == [
        ("s.yaml:8: scene.mean_forse: 'mean_forse' is not a field of a rattle scene -- did you mean"
        " 'mean_force'?")]


def test_errors_in_sweep_and_outputs_point_at_their_lines():
    text = GOOD.replace("num: 3}", "num: 0}") + "outputs: [stats, spectrun]\n"
    assert _lines(text) == [  # both at once (the output's name was said after num was mended)
        "s.yaml:10: sweep.speed.num: 0 -- Input should be greater than or equal to 1",
        ("s.yaml:12: outputs[1]: 'spectrun' -- not an output; did you mean 'spectrum'? allowed:"
         " floquet, period, spectrum, stats")]
    text = GOOD + "outputs: [stats, spectrun]\n"
    assert _lines(text) == [
        ("s.yaml:12: outputs[1]: 'spectrun' -- not an output; did you mean 'spectrum'? allowed:"
        " floquet, period, spectrum, stats")]


def test_duplicate_keys_are_refused():
    text = GOOD.replace("  teeth: 48\n", "  teeth: 48\n  teeth: 50\n")
    assert _lines(text) == [("s.yaml:6: scene.teeth: duplicate key (also on line 5); each key at"
                            " most once in a mapping")]
    lines = _lines("title: a\ntitle: b\n")  # reported beside the file's other problems
    assert any(ln.startswith("s.yaml:2: title: duplicate key") for ln in lines), lines
    assert any("scene" in ln and "required" in ln for ln in lines), lines


def test_a_key_yaml_reads_as_a_number_or_a_boolean_is_named_as_written():
    """YAML 1.1 reads the keys on, no, yes, 2 and null as true, false, true, the number 2 and
    None: the line named a list index and pydantic's words ("scene[1]: 1 -- Keys should be
    strings" for 'on: 1', "gears[0].[key]: False -- Input should be a valid string" for a gear
    labelled no; found by a fuzzer). It names the key as written, on its line, and says to quote it."""
    assert _lines(GOOD.replace("  teeth: 48\n", "  teeth: 48\n  on: 1\n")) == [
        ("s.yaml:6: scene.on: 'on' as a key is read by YAML as true, not as a name; write it in"
         " quotes ('on') if a name is meant")]
    mesh = "type: mesh\ntitle: t\ngears:\n  no: table1_consistent\n  2: table1_consistent\ntorque: 5 N*m\n"
    assert _lines(mesh) == [
        ("s.yaml:4: gears.no: 'no' as a key is read by YAML as false, not as a name; write it in"
         " quotes ('no') if a name is meant"),
        ("s.yaml:5: gears.2: '2' as a key is read by YAML as the number 2, not as a name; write it"
         " in quotes ('2') if a name is meant")]
    parse_study(mesh.replace("no:", "'no':").replace("2:", "'2':"), "s.yaml")
    assert _lines("title: t\n~: x\n")[1:] == [
        ("s.yaml:2: ~: '~' as a key is read by YAML as null, not as a name; write it in quotes"
        " ('~') if a name is meant")]  # (after line 1's: the scene is missing)


def test_a_range_from_high_to_low_is_refused():
    """It said "sweep.speed.start: '6000 rpm' -- at most stop ('5000 rpm')", which reads oddly;
    a range of one value may start at its stop (the only equal start and stop allowed)."""
    lines = _lines(GOOD.replace("start: 5000 rpm, stop: 6000 rpm", "start: 6000 rpm, stop: 5000 rpm"))
    assert lines == [("s.yaml:10: sweep.speed.start: '6000 rpm' -- start must be below stop"
                     " ('5000 rpm'): give a range in increasing order (a down sweep is"
                     " 'continuation: [down]')")]
    one = GOOD.replace("start: 5000 rpm, stop: 6000 rpm, num: 3", "start: 6000 rpm, stop: 5000 rpm,"
                       " num: 1")
    assert _lines(one) == [("s.yaml:10: sweep.speed.start: '6000 rpm' -- start must be at most stop"
                           " ('5000 rpm'); one value is [value]")]
    parse_study(one.replace("start: 6000 rpm", "start: 5000 rpm"), "s.yaml")


def test_misspelt_names_beside_other_errors_are_all_said_at_once():
    """Every problem of the file at once: a misspelt sweep entry (``sped``: only "the speed must
    be swept" was said), a misspelt output and the scene's and solver's misspelt fields, in one
    run (the sweep and the output names came one run later each; found by a new-user test)."""
    text = (GOOD.replace("mass:", "mas:").replace("  speed: {", "  sped: {")
            .replace("steps_per_period", "step_per_period") + "outputs: [stat]\n")
    lines = _lines(text)
    for says in (("s.yaml:4: scene.mas: 'mas' is not a field of a rattle scene -- did you mean"
                 " 'mass'?"),
                 ("s.yaml:10: sweep.sped: 'sped' is not a sweepable parameter of the 'rattle' scene;"
                 " did you mean 'speed'?"),
                 ("s.yaml:11: solver.step_per_period: 'step_per_period' is not a field of solver --"
                 " did you mean 'steps_per_period'?"),
                 "s.yaml:12: outputs[0]: 'stat' -- not an output; did you mean 'stats'?"):
        assert sum(ln.startswith(says) for ln in lines) == 1, (says, lines)
    # a misspelt direction of continuation hid a misspelt sweep entry
    lines = _lines(GOOD.replace("  speed: {", "  speed: {start: 1 rpm, stop: 2 rpm, num: 2}\n"
                                "  backlsh: [0.1 mm]\n  x: {") + "continuation: [up, dwn]\n")
    assert any(ln.startswith("s.yaml:14: continuation[1]") for ln in lines), lines
    assert any(ln.startswith("s.yaml:11: sweep.backlsh: 'backlsh' is not a sweepable parameter"
                             " of the 'rattle' scene; did you mean 'backlash'?") for ln in lines), lines


def test_a_repeated_output_and_an_unsweepable_name_are_named_as_written():
    """``outputs: [stats, stats]`` was told "outputs: list each output at most once" and a
    whine scene's ``sweep.backlash`` "not a sweepable parameter ...", neither naming what was
    written (an outside tester's finding): the repeat is named at its place, and the name."""
    text = GOOD.replace("  speed: {", "  speed: {start: 1 rpm, stop: 2 rpm, num: 2}\n"
                        "  alpha: [0.1 mm]\n  x: {") + "outputs:\n  - stats\n  - stats\n"
    lines = _lines(text)
    assert ("s.yaml:16: outputs[1]: 'stats' -- listed already (outputs[0]); list each output at"
            " most once") in lines, lines
    assert any(ln.startswith("s.yaml:11: sweep.alpha: 'alpha' is not a sweepable parameter of"
                             " the 'rattle' scene; allowed: ") for ln in lines), lines


def test_the_problems_found_when_planning_are_said_at_once():
    """A spectrum study took a run per problem (a new-user test: record_periods, then the
    pinion's drive, then samples_per_period against steps_per_period); the problems found when
    the study is planned are said together, one line per field (record_periods was said twice,
    by the spectrum and by the plan, in two wordings)."""
    text = (WHINE_GOOD + "solver: {steps_per_period: 60, record_periods: 1}\n"
            "outputs: [stats, {spectrum: {max_order: 3, samples_per_period: 7, pinion: true}}]\n")
    study = parse_study(text, "s.yaml")
    with pytest.raises(StudyError) as err:
        make_plan(study, text, "s.yaml")
    lines = str(err.value).splitlines()
    assert [ln.split(" -- ")[0] for ln in lines] == [
        "s.yaml:12: solver.record_periods: 1",  # (the clash of 7 samples with 60 steps: at the
        "s.yaml:13: outputs[1].spectrum.pinion: True",  # later written, samples_per_period)
        "s.yaml:13: outputs[1].spectrum.samples_per_period: 7"], lines


def test_an_output_s_options_are_said_beside_the_study_s_other_problems():
    """An output's options were checked once everything else was right, and their first problem
    alone (a misspelt option hid a bad value; an adversarial test): now each beside the rest."""
    text = (WHINE_GOOD.replace("mean_force: 1000 N", "mean_force: -800 N x")
            + "outputs: [stats, {spectrum: {max_order: -40, samples_per_perod: 32}}]\n")
    assert [ln.split(" -- ")[0] for ln in _lines(text)] == [
        "s.yaml:9: scene.mean_force: '-800 N x'",
        "s.yaml:12: outputs[1].spectrum.max_order: -40",
        "s.yaml:12: outputs[1].spectrum.samples_per_perod: 32"]
    text = WHINE_GOOD + "outputs: [stats, {spectrum: {max_order: -40, samples_per_perod: 32}}]\n"
    assert len(_lines(text)) == 2  # the study otherwise valid: the same two
    assert len(_lines(text.replace("outputs: [stats, {", "outputs: [stats, {spectrum: 1}, {"))) >= 2


def test_a_gear_s_own_error_does_not_hide_its_load_or_a_swept_stiffness():
    """``gear: {module, z1, z2}`` without face_width hid that the load was missing and that a
    gear scene cannot sweep its stiffness (each said a run later; a new-user test)."""
    text = ("title: g\nscene:\n  kind: whine\n  gear: {module: 2 mm, z1: 20, z2: 40}\n"
            "  mass: 0.1527 kg\nsweep:\n  speed: [3000 rpm]\n  stiffness: [1 kN/mm]\n")
    assert [ln.split(" -- ")[0].split(": '")[0] for ln in _lines(text)] == [
        "s.yaml:2: scene.torque", "s.yaml:4: scene.gear",
        ("s.yaml:8: sweep.stiffness: a gear scene computes its stiffness from the gear pair; sweep"
        " torque, or type in the coefficients")]


def test_a_mathieu_start_with_a_unit_or_static_is_refused():
    """A mathieu scene is dimensionless: ``initial_displacement: 1 um`` ran as p0 = 1e-6 (the
    unit read as SI), and ``static`` gave a traceback when the run built its kernel call; both
    one line, beside the study's other problems."""
    mathieu = "title: m\nscene: {kind: mathieu, alpha: 1.0, beta: 0.1, gamma: 0.01}\n"
    assert _lines(mathieu + "solver: {initial_displacement: 1 um}\n") == [
        ("s.yaml:3: solver.initial_displacement: '1 um' -- a bare number in a mathieu scene (p in"
        " units of its own scale, e.g. 1): no unit there")]
    assert _lines(mathieu + "solver: {initial_displacement: static}\n") == [
        ("s.yaml:3: solver.initial_displacement: 'static' -- a bare number in a mathieu scene"
        " (default 1): 'static' is the equilibrium of a gear scene's load, which a mathieu scene"
        " has not")]
    lines = _lines(mathieu + "solver: {initial_displacement: 1 um, steps_per_period: 2}\n")
    assert len(lines) == 2 and "no unit there" in lines[1], lines
    # 'static ' with a space: one line on its field (was the top level, 'could not convert')
    assert _lines(mathieu + "solver: {initial_displacement: 'static '}\n")[0].startswith(
        "s.yaml:3: solver.initial_displacement: 'static' -- a bare number in a mathieu scene")
    for ok in ("2", "'2'", "0.5"):
        study = parse_study(mathieu + f"solver: {{initial_displacement: {ok}}}\n", "s.yaml")
        assert study.solver.initial_displacement == pytest.approx(float(ok.strip("'")))


def test_a_range_of_one_value_with_another_stop_a_negative_log_start_and_inf_are_one_line(
        capfd):
    """Found by an adversarial test: ``{start: 5000 rpm, stop: 6000 rpm, num: 1}`` ran at 5000
    alone (the stop silently unused); a log range from -10 N m printed NumPy's RuntimeWarning
    beside its line, which did not quote the value; ``speed: [.inf]`` gave two lines, in two
    wordings, for one problem."""
    lines = _lines(GOOD.replace("num: 3}", "num: 1}"))
    assert lines == [("s.yaml:10: sweep.speed.num: 1 -- 2 or more from '5000 rpm' to '6000 rpm'"
                     " (one value is its start alone, the stop unused: write [5000 rpm] for that)")]
    text = GOOD.replace("mean_force: 100 N", "torque: 10 N m\n  base_radius: 50 mm").replace(
        "  speed: {", "  torque: {start: -10 N m, stop: 20 N m, num: 3, spacing: log}\n  speed: {")
    assert _lines(text) == [("s.yaml:11: sweep.torque.start: '-10 N m' -- above zero: log spacing"
                            " needs positive start and stop")]
    assert capfd.readouterr().err == ""
    lines = _lines(GOOD.replace("{start: 5000 rpm, stop: 6000 rpm, num: 3}", "[.inf]"))
    assert lines == ["s.yaml:10: sweep.speed[0]: inf -- a finite number (not nan or inf)"]


def test_a_speed_beyond_1e6_rpm_is_refused_in_the_scene_and_the_sweep():
    """At 1e160 rpm the whole run lasted no time, nothing moved and every statistic was 0, with
    status 0 (an adversarial test): a speed above 1e6 rpm is refused, given or swept."""
    said = ("a speed of at most 1e+06 rpm (ten times the fastest gears'; beyond it the whole run"
            " lasts nanoseconds and p cannot move in it)")
    assert _lines(GOOD.replace("{start: 5000 rpm, stop: 6000 rpm, num: 3}", "[1000 rpm, 1e7 rpm]")
                  ) == [f"s.yaml:10: sweep.speed[1]: '1e7 rpm' -- {said}"]
    text = GOOD.replace("sweep:\n  speed: {start: 5000 rpm, stop: 6000 rpm, num: 3}\n", "")
    assert _lines(text.replace("mean_force: 100 N", "mean_force: 100 N\n  speed: 1e160 rpm")) == [
        f"s.yaml:9: scene.speed: '1e160 rpm' -- {said}"]
    parse_study(text.replace("mean_force: 100 N", "mean_force: 100 N\n  speed: 1e6 rpm"), "s.yaml")


def test_a_speed_below_1e_3_rpm_is_refused_by_the_cli_in_one_line(tmp_path, capsys):
    """speed: [1e-300 rpm] ran (an outside tester): every case diverged (status 1, all NaN) and
    the aliasing warning printed an integer of 300 digits. Below 1e-3 rpm a mesh period lasts
    over a minute even with 1000 teeth, and a 1 kHz mesh needs more steps per period than a study
    takes to be stable: refused, swept (a list or a range's start) or given, in one line naming
    the file, line, field, value and what is allowed, exit 2, nothing written; 1e-3 rpm runs."""
    said = ("a speed of at least 0.001 rpm (below it a mesh period lasts over a minute even with"
            " 1000 teeth, and a 1 kHz mesh needs more than the 65536 steps per period a study"
            " takes to be stable)")
    # the bound against the code's own numbers: at 1e-3 rpm and 1000 teeth the mesh period is
    # 60 s, and no method's largest stable h omega_n (over every damping ratio) reaches the
    # steps a 1 kHz mesh needs within 65536 steps per period
    from gearsweep.study.plan import _solve_hw_table
    from gearsweep.study.quantities import MAX_STEPS_PER_PERIOD, MAX_TEETH, MIN_SPEED
    period = 60.0 / (MAX_TEETH * MIN_SPEED)
    assert period == pytest.approx(60.0)
    for method in ("rk4", "rk5"):
        hw_max = float(np.max(_solve_hw_table(method)[1]))
        assert period * 2 * math.pi * 1000.0 / hw_max > MAX_STEPS_PER_PERIOD
    sweep = "{start: 5000 rpm, stop: 6000 rpm, num: 3}"
    no_sweep = GOOD.replace(f"sweep:\n  speed: {sweep}\n", "")
    cases = [(GOOD.replace(sweep, "[1e-300 rpm]"), 10, "sweep.speed[0]: '1e-300 rpm'"),
             (GOOD.replace(sweep, "[0.0009 rpm, 1 rpm]"), 10, "sweep.speed[0]: '0.0009 rpm'"),
             (GOOD.replace(sweep, "{start: 1e-4 rpm, stop: 10 rpm, num: 3}"), 10,
              "sweep.speed.start: '1e-4 rpm'"),
             (no_sweep.replace("mean_force: 100 N", "mean_force: 100 N\n  speed: 1e-300 rpm"), 9,
              "scene.speed: '1e-300 rpm'")]
    for i, (text, line, field) in enumerate(cases):
        path = tmp_path / f"s{i}.yaml"
        path.write_text(text, encoding="utf-8")
        for argv in (["validate", str(path)], ["run", str(path), "-o", str(tmp_path / "r.nc")]):
            assert main(argv) == 2
            err = capsys.readouterr().err
            assert err == f"gearsweep: error: {path}:{line}: {field} -- {said}\n", err
        assert not (tmp_path / "r.nc").exists()
    path = tmp_path / "ok.yaml"
    path.write_text(GOOD.replace(sweep, "[1e-3 rpm]"), encoding="utf-8")
    assert main(["validate", str(path)]) == 0


def test_a_continued_sweep_over_speeds_out_of_order_is_refused():
    """A continued sweep runs up the list of speeds and back down it: with [8000, 6000, 7000]
    "up" stepped 8000 -> 6000 -> 7000, silently (found by a new-user test). Refused at the first
    speed out of order (without continuation, as any list that is not monotonic: below)."""
    text = GOOD.replace("{start: 5000 rpm, stop: 6000 rpm, num: 3}", "[8000 rpm, 6000 rpm, 7000 rpm]")
    assert _lines(text + "continuation: [up, down]\n") == [
        ("s.yaml:10: sweep.speed[1]: '6000 rpm' -- a speed below the one before ('8000 rpm'): a"
        " continued sweep takes the list in increasing order (up) or in decreasing order (down),"
        " so list the speeds in increasing order")]
    parse_study(text.replace("8000 rpm, 6000 rpm, 7000 rpm", "6000 rpm, 7000 rpm, 8000 rpm")
                + "continuation: [down]\n", "s.yaml")


def test_a_list_sweep_that_is_not_monotonic_is_refused():
    """A list sweep's values become the result's coordinate in the order written: [0.3 mm,
    0.1 mm, 200 um] gave the coordinate [0.3, 0.1, 0.2], not monotonic as CF asks of a
    coordinate variable (found by a new-user test). Refused at the first value out of order,
    with the direction the list started in; increasing and decreasing lists both run."""
    bad = GOOD.replace("  speed: {", "  backlash: [0.3 mm, 0.1 mm, 200 um]\n  speed: {")
    assert _lines(bad) == [
        ("s.yaml:10: sweep.backlash[2]: '200 um' -- a value above the one before ('0.1 mm'): list"
        " the values in increasing or decreasing order (the result's coordinate is monotonic, as"
        " CF asks)")]
    up = bad.replace("[0.3 mm, 0.1 mm, 200 um]", "[0.1 mm, 0.3 mm, 200 um]")
    assert _lines(up) == [
        ("s.yaml:10: sweep.backlash[2]: '200 um' -- a value below the one before ('0.3 mm'): list"
        " the values in increasing or decreasing order (the result's coordinate is monotonic, as"
        " CF asks)")]
    for ok in ("[0.1 mm, 200 um, 0.3 mm]", "[0.3 mm, 200 um, 0.1 mm]"):
        parse_study(bad.replace("[0.3 mm, 0.1 mm, 200 um]", ok), "s.yaml")


@pytest.mark.parametrize("values", [[0.3, 0.1, 0.2], [0.1, 0.3, 0.2], [0.1, 0.2, 0.4, 0.3],
                                    [0.4, 0.3, 0.1, 0.2], [0.4, 0.1, 0.5]])
@pytest.mark.parametrize("continued", [False, True])
def test_the_line_of_a_value_out_of_order_says_where_it_lies(values, continued):
    """'above' or 'below the one before' as the numbers are: the line said 'below' of 0.2 mm after
    0.1 mm (and 'above' of 6000 rpm after 8000 rpm in a continued sweep; found by a fuzzer)."""
    name, unit = ("speed", "rpm") if continued else ("backlash", "mm")
    scale = 10000 if continued else 1
    listed = ", ".join(f"{v * scale:g} {unit}" for v in values)
    text = GOOD.replace("  speed: {start: 5000 rpm, stop: 6000 rpm, num: 3}",
                        f"  {name}: [{listed}]" + ("" if continued else "\n  speed: [5000 rpm]"))
    [line] = _lines(text + ("continuation: [up]\n" if continued else ""))
    i = int(re.search(rf"sweep\.{name}\[(\d+)\]", line).group(1))
    word = re.search(r"a (?:value|speed) (above|below) the one before", line).group(1)
    assert word == ("above" if values[i] > values[i - 1] else "below"), line


def test_swept_and_fixed_is_stated_in_validates_summary(tmp_path, capsys):
    path = tmp_path / "s.yaml"
    path.write_text(GOOD.replace("  speed: {", "  backlash: [0.1 mm, 0.2 mm]\n  speed: {"),
                    encoding="utf-8")
    assert main(["validate", str(path)]) == 0
    assert "the sweep replaces scene.backlash" in capsys.readouterr().out


def test_stdin_is_named_stdin(monkeypatch, capsys):
    monkeypatch.setattr(sys, "stdin", io.StringIO(GOOD.replace("teeth: 48", "teeth: -1")))
    assert main(["validate", "-"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("gearsweep: error: <stdin>:5: scene.teeth: -1 -- "), err


def test_debug_is_accepted_anywhere(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text(GOOD.replace("teeth: 48", "teeth: -1"), encoding="utf-8")
    for argv in (["--debug", "validate", str(path)], ["validate", "--debug", str(path)],
                 ["validate", str(path), "--debug"]):
        with pytest.raises(StudyError):
            main(argv)


def test_inspect_on_a_study_says_it_is_a_study(tmp_path, capsys):
    path = tmp_path / "s.yaml"
    path.write_text(GOOD, encoding="utf-8")
    assert main(["inspect", str(path)]) == 2
    err = capsys.readouterr().err
    assert "a study file, not a result" in err and f"gearsweep validate {path}" in err
    assert err.count("\n") == 1


@pytest.mark.parametrize("cases", ["1e12", "1e15"])
def test_a_huge_grid_is_refused_by_validate_at_once(tmp_path, cases):
    """From arithmetic on the sweep's sizes: no grid, no kernel, in a fresh process."""
    n = round(float(cases) ** (1 / 3))
    text = GOOD.replace("  speed: {start: 5000 rpm, stop: 6000 rpm, num: 3}",
                        f"  speed: {{start: 5000 rpm, stop: 6000 rpm, num: {n}}}\n"
                        f"  damping: {{start: 1 N s/m, stop: 10 N s/m, num: {n}}}\n"
                        f"  mean_force: {{start: 1 N, stop: 10 N, num: {n}}}")
    path = tmp_path / "huge.yaml"
    path.write_text(text, encoding="utf-8")
    for argv in (["validate", str(path)], ["run", str(path), "--estimate"],
                 ["run", str(path), "-o", str(tmp_path / "o.nc")]):
        # The libraries are imported first (numpy, xarray, numba, pint: about 2 s on a loaded
        # 2-core machine, the same for any study); what is timed is the work of the command.
        # The peak is this process's own (VmHWM): getrusage's ru_maxrss carries pytest's peak
        # across the fork and exec, so growth below that peak went unseen (about 500 MB here).
        code = ("import sys, time; from gearsweep.cli import main;"
                " import gearsweep.study.estimate, gearsweep.study.schema, gearsweep.units;"
                " hwm = lambda: int(next(ln for ln in open('/proc/self/status')"
                " if ln.startswith('VmHWM:')).split()[1]);"
                " gearsweep.units.registry(); t0 = time.perf_counter(); rss0 = hwm();"
                f" rc = main({argv!r}); dt = time.perf_counter() - t0;"
                " print(rc, dt, hwm() - rss0)")
        proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                              timeout=120, cwd=ROOT)
        rc, dt, rss_kb = proc.stdout.split()[-3:]
        if argv[-1] == "--estimate":
            assert rc == "0" and "cases" in proc.stdout
        else:
            assert rc == "2", proc.stderr
            assert re.search(r"refused \(time > 10.0 min.*\): [\d,]+ cases", proc.stderr)
            assert proc.stderr.count("\n") == 1
        assert float(dt) < 1.0, (argv, dt)
        assert int(rss_kb) * 1024 < 300e6  # peak memory the command adds to the libraries
    assert not (tmp_path / "o.nc").exists()


def test_validate_and_estimate_never_compile(tmp_path):
    """``--estimate`` answers in well under a second even on a study whose kernel is not
    compiled (a cold Numba cache adds the compile time to the estimate instead)."""
    path = tmp_path / "s.yaml"
    path.write_text(GOOD.replace("method: rk4", "method: rk5").replace(
        "steps_per_period: 32", "steps_per_period: 32, kink_aware: true"), encoding="utf-8")
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "gearsweep.cli", "run", str(path), "--estimate"],
                          capture_output=True, text=True, timeout=120, cwd=ROOT,
                          env={"NUMBA_CACHE_DIR": str(tmp_path / "cache"), "PATH": "/usr/bin:/bin"})
    assert proc.returncode == 0, proc.stderr
    assert "cases" in proc.stdout
    assert "s to compile the kernel once (cold cache)" in proc.stdout, proc.stdout
    assert time.perf_counter() - t0 < 20  # the process: interpreter and imports included
    assert not any((tmp_path / "cache").rglob("*.nbi"))


def test_a_drive_beside_a_gear_takes_the_gears_base_radii():
    """``drive:`` beside ``gear:`` does not ask again for the radii the gear pair has."""
    from gearsweep.study.gearscene import scene_excitation
    from gearsweep.study.plan import build_model

    text = """\
title: drive and gear
scene:
  kind: whine
  gear: table1_consistent
  torque: 50 N m
  drive: {inertia_1: 1e-3 kg m^2, inertia_2: 2e-3 kg m^2}
  speed: 3000 rpm
"""
    study = parse_study(text, "d.yaml")
    ex = scene_excitation(study.scene)
    m = build_model(study).mass
    assert m == pytest.approx(1 / (ex.base_radius_1**2 / 1e-3 + ex.base_radius_2**2 / 2e-3))
    no_gear = text.replace("  gear: table1_consistent\n", "  teeth: 48\n  stiffness: 1e9 N/m\n")
    assert _lines(no_gear) == [
        ("s.yaml:7: scene.drive: '{...}' -- 'drive.base_radius_1' and 'drive.base_radius_2'"
        " required (or a 'gear', which gives the base radii)")]  # (the drive's line: the scene's)


def test_validate_refuses_a_number_after_the_unit_in_one_line(tmp_path):
    """``backlash: 3 mm 2`` validated and ran with a backlash of 6 mm (pint multiplied; an
    outside tester's finding): ``gearsweep validate`` exits 2 with one line naming the file,
    line, field and value."""
    path = tmp_path / "b.yaml"
    path.write_text(GOOD.replace("backlash: 0.1 mm", "backlash: 3 mm 2"), encoding="utf-8")
    proc = subprocess.run([sys.executable, "-m", "gearsweep", "validate", str(path)],
                          capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr == (f"gearsweep: error: {path}:7: scene.backlash: '3 mm 2' -- a number"
                           " inside or after the unit ('mm 2'): write one number, then its"
                           " unit, e.g. '1 mm'\n")


def test_a_swept_list_and_range_follow_the_quantity_grammar():
    """The values of a list and the ends of a range are read as the scene's quantities are."""
    text = GOOD.replace("speed: {start: 5000 rpm, stop: 6000 rpm, num: 3}",
                        "speed: {start: rpm, stop: 6000 rpm 2, num: 3}\n"
                        "  backlash: [0.1 mm, 2**10 mm, 3mm/2]")
    assert _lines(text) == [
        "s.yaml:10: sweep.speed.start: 'rpm' -- a speed: a number is missing: write e.g. '1 rpm'",
        ("s.yaml:10: sweep.speed.stop: '6000 rpm 2' -- a speed: a number inside or after the unit"
         " ('rpm 2'): write one number, then its unit, e.g. '1 rpm'"),
        ("s.yaml:11: sweep.backlash[1]: '2**10 mm' -- a length: arithmetic on the number: write the"
         " number it comes to, then its unit, e.g. '1 mm'"),
        ("s.yaml:11: sweep.backlash[2]: '3mm/2' -- a length: a number inside or after the unit"
         " ('mm/2'): write one number, then its unit, e.g. '1 mm'")]


def test_a_problem_found_when_planning_names_the_file_and_line(tmp_path, capsys):
    """Not '<study>': the planner's checks (steps per period versus the outputs' sampling)
    are reported like the schema's."""
    path = tmp_path / "sp.yaml"
    path.write_text("title: t\nscene: {kind: whine, mass: 1 kg, teeth: 20, stiffness: 1e8 N/m,"
                    " speed: 1000 rpm}\nsolver:\n  steps_per_period: 30\n"
                    "outputs: [{spectrum: {samples_per_period: 16}}]\n", encoding="utf-8")
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    assert err == (f"gearsweep: error: {path}:5: outputs[0].spectrum.samples_per_period: 16 --"
                   " a divisor of solver.steps_per_period (30): the samples are taken from the"
                   " steps\n")  # (the later written of the two)


def test_a_duplicate_key_a_scene_error_and_a_sweep_error_are_three_lines(tmp_path, capsys):
    """Every problem of the file at once (issue 29): a duplicate key does not hide the schema's
    problems, and a problem in the scene does not hide one in the sweep."""
    path = tmp_path / "three.yaml"
    path.write_text("title: three errors\nscene:\n  kind: whine\n  mass: 0.15 kg\n  teeth: 48\n"
                    "  stiffness: 1073\n  damping: 5.5 N s/mm\n  damping: 6 N s/mm\nsweep:\n"
                    "  speed: {start: 3000 rpm, stop: 1000 rpm, num: 5}\n", encoding="utf-8")
    assert main(["validate", str(path)]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert [re.search(r"three\.yaml:(\d+): (\S+):", ln).groups() for ln in lines] == [
        ("6", "scene.stiffness"), ("8", "scene.damping"), ("10", "sweep.speed.start")], lines
    assert "has no unit" in lines[0] and "duplicate key" in lines[1] and "below stop" in lines[2]


WHOLE = "a whole number (not true or false)"
"""What an integer field of a study says to YAML's true or false."""


@pytest.mark.parametrize(("old", "new", "where"), [
    ("teeth: 48", "teeth: true", "5: scene.teeth: True"),
    ("num: 3}", "num: true}", "10: sweep.speed.num: True"),
    ("steps_per_period: 32", "steps_per_period: false", "11: solver.steps_per_period: False"),
    ("transient_periods: 4", "transient_periods: false", "11: solver.transient_periods: False"),
    ("record_periods: 4}", "record_periods: true}", "11: solver.record_periods: True"),
    ("record_periods: 4}\n", "record_periods: 4}\noutputs: [{spectrum: {samples_per_period: true}}]\n",
     "12: outputs[0].spectrum.samples_per_period: True"),
])
def test_true_or_false_is_not_a_whole_number(old, new, where):
    """An integer field took YAML's true and false as 1 and 0 (pydantic's lax mode): ``teeth:
    true`` ran a scene of one tooth. Now one line, as for any other wrong value."""
    assert _lines(GOOD.replace(old, new)) == [f"s.yaml:{where} -- {WHOLE}"]
    parse_study(GOOD.replace(old, new.replace("true", "16").replace("false", "16")), "s.yaml")


@pytest.mark.parametrize(("study", "old", "new", "where"), [
    ("fig01_02_mesh_cycle.yaml", "positions: 200", "positions: true", "positions"),
    ("table1_profile_shift.yaml", "z1: 48", "z1: true", "gear.z1"),
    ("whine_measured_ste.yaml", "harmonics: 10}", "harmonics: true}", "scene.excitation.harmonics"),
    ("work_precision.yaml", "[8, 16, 32,", "[8, true, 32,", "analysis.steps_per_period[1]"),
])
def test_true_or_false_is_not_a_whole_number_in_mesh_gear_and_analysis_studies(study, old, new,
                                                                                where):
    path = ROOT / "studies" / study  # its own path: the excitation's file is found beside it
    text = path.read_text(encoding="utf-8")
    assert old in text
    with pytest.raises(StudyError) as err:
        parse_study(text.replace(old, new), str(path))
    [line] = err.value.lines
    assert line.startswith(f"{path}:") and line.endswith(f": {where}: True -- {WHOLE}"), line
    parse_study(text, str(path))


FLAG_STUDY = """\
title: flag test
scene: {kind: rattle, mass: 0.1527 kg, teeth: 48, stiffness: 1073 kN/mm, damping: 200 N*s/m,
        backlash: 4 um, mean_force: 100 N}
sweep: {speed: [12000 rpm]}
solver:
  method: rk4
  kink_aware: VALUE
"""


@pytest.mark.parametrize("value", ["1", "0", "'true'", "2.0"])
def test_a_yes_no_field_takes_only_true_or_false(value, tmp_path):
    """kink_aware: 1 was taken as true (pydantic's lax bool); now one line names the field.
    YAML's yes and no are true and false already, and pass."""
    path = tmp_path / "f.yaml"
    with pytest.raises(StudyError) as err:
        parse_study(FLAG_STUDY.replace("VALUE", value), str(path))
    [line] = err.value.lines
    assert line.startswith(f"{path}:7: solver.kink_aware: ") and line.endswith(" -- true or false")
    for ok, expected in (("true", True), ("no", False)):
        assert parse_study(FLAG_STUDY.replace("VALUE", ok)).solver.kink_aware is expected


def test_step_guard_off_unquoted_is_off(tmp_path):
    """YAML reads an unquoted ``off`` as false: ``step_guard: off`` (as the reference writes it)
    was refused with "False -- Input should be 'warn', 'skip' or 'off'". It is off now; ``on``
    names no mode and says so."""
    text = FLAG_STUDY.replace("  kink_aware: VALUE\n", "  step_guard: VALUE\n")
    for word in ("off", "no", "false", "'off'"):
        assert parse_study(text.replace("VALUE", word)).solver.step_guard == "off"
    path = tmp_path / "g.yaml"
    with pytest.raises(StudyError) as err:
        parse_study(text.replace("VALUE", "on"), str(path))
    [line] = err.value.lines
    assert line.startswith(f"{path}:7: solver.step_guard: ") and "names no mode" in line, line


@pytest.mark.parametrize(("solver", "line", "field", "says"), [
    ("  precision: float32\n", 7, "solver.precision", "float32 runs on the GPU only"),
    ("  device: cuda\n  kink_aware: true\n", 8, "solver.kink_aware",
     "the kink-aware step runs on the CPU only"),
])
def test_what_the_device_refuses_is_said_when_the_study_is_read(solver, line, field, says,
                                                                tmp_path):
    """float32 on the CPU, and the kink-aware step on the GPU with backlash, passed validate and
    --estimate and were refused only when run (without a file or line). A study with device
    auto is not refused: whether it gets a GPU is known only where it runs."""
    text = FLAG_STUDY.replace("  kink_aware: VALUE\n", solver)
    path = tmp_path / "d.yaml"
    with pytest.raises(StudyError) as err:
        parse_study(text, str(path))
    [msg] = err.value.lines
    assert msg.startswith(f"{path}:{line}: {field}: ") and says in msg, msg
    parse_study(text.replace("  precision: float32\n", "  precision: float32\n  device: auto\n")
                .replace("device: cuda", "device: auto"))


def test_a_misspelt_top_level_key_is_matched_against_every_kind_of_study(tmp_path):
    """'analyss:' in an analysis study was matched against a dynamic study's fields only (no
    suggestion, the wrong list); every kind of study's top-level fields are the choices now."""
    text = (Path(__file__).parents[1] / "studies/fig08_rattle_budget.yaml").read_text(
        encoding="utf-8")
    assert "\nanalysis:" in text
    path = tmp_path / "a.yaml"
    with pytest.raises(StudyError) as err:
        parse_study(text.replace("\nanalysis:", "\nanalyss:"), str(path))
    assert any(": analyss: 'analyss' is not a field of a study -- did you mean 'analysis'?" in ln
               for ln in err.value.lines), err.value.lines


def test_initial_velocity_is_a_velocity_and_a_bare_number_in_a_mathieu_scene(tmp_path):
    """p' at t = 0 took a bare number in m/s (silently SI, against the rule every other field
    keeps; an outside fuzz tester): now a velocity with its unit, one line for a bare number or
    another kind; a Mathieu scene, dimensionless, takes a bare number (and refuses a unit), as
    its initial_displacement does."""
    text = FLAG_STUDY.replace("  kink_aware: VALUE\n", "  initial_velocity: VALUE\n")
    path = tmp_path / "v.yaml"
    assert parse_study(text.replace("VALUE", "2 mm/s")).solver.initial_velocity == 0.002
    assert parse_study(text.replace("VALUE", "0.5 m/s")).solver.initial_velocity == 0.5
    assert parse_study(text.replace("VALUE", "0")).solver.initial_velocity == 0.0
    for value, says in (("0.5", ("0.5 has no unit; write e.g. '0.5 mm/s', or '0.5 m/s' if SI"
                                 " was meant")),
                        ("1 mm", "'1 mm' -- is a length (mm), expected velocity (e.g. '1 mm/s')")):
        with pytest.raises(StudyError) as err:
            parse_study(text.replace("VALUE", value), str(path))
        [line] = err.value.lines
        assert line.startswith(f"{path}:7: solver.initial_velocity: ") and says in line, line
    mathieu = MATHIEU.replace("initial_velocity: 0.0", "initial_velocity: 0.25")
    assert parse_study(mathieu).solver.initial_velocity == 0.25
    with pytest.raises(StudyError) as err:
        parse_study(mathieu.replace("initial_velocity: 0.25", "initial_velocity: 1 m/s"))
    assert "a bare number in a mathieu scene" in str(err.value)


def test_a_scene_missing_fields_of_both_kinds_says_all_in_one_run(tmp_path):
    """A rattle scene with only a mass: the backlash (a field pydantic requires), the speed and
    teeth and stiffness (which the scene's own check requires, as a gear could give them) came in
    two runs, the second only after the first were fixed; now in one, each once."""
    path = tmp_path / "s.yaml"
    with pytest.raises(StudyError) as err:
        parse_study("title: t\nscene: {kind: rattle, mass: 1 kg}\n", str(path))
    speed = "the speed must be swept (sweep.speed) or given (scene.speed)"
    teeth = ("'teeth' and 'stiffness' required (or a 'gear' that gives teeth, stiffness and"
             " their harmonics)")
    assert err.value.lines == [f"{path}:2: scene.backlash: '(missing)' -- this field is required",
                               f"{path}:2: scene.speed: '(missing)' -- {speed}",
                               f"{path}:2: scene: '{{...}}' -- {teeth}"], err.value.lines
    with pytest.raises(StudyError) as err:  # only the scene's own check: said once
        parse_study("title: t\nscene: {kind: rattle, mass: 1 kg, backlash: 1 mm,"
                    " speed: 1000 rpm}\n", str(path))
    assert len(err.value.lines) == 1 and "'teeth' and 'stiffness' required" in err.value.lines[0]


def test_every_integer_and_float_field_of_a_study_refuses_true_and_false():
    """Every ``int`` of every model a study file is validated by (the scenes, the gear, the
    measured excitation, the outputs' options, mesh and analysis studies) is ``Count``, every
    ``float`` is ``Real`` or a quantity (``Q``: units, which refuse true and false themselves) and
    every ``bool`` is ``Flag`` (which refuses 1 and 0): a new field that is a plain ``int``,
    ``float`` or ``bool`` (alone, optional, in a list, a tuple or a union with ``str``) fails
    here."""
    import typing

    from pydantic import BaseModel

    from gearsweep.study.analysis_specs import AnalysisStudy
    from gearsweep.study.outputs import OUTPUTS
    from gearsweep.study.quantities import Count, Flag, Order, Real
    from gearsweep.study.schema import MeshStudy, Study
    from gearsweep.units import QuantityKind

    def checked(base: type, metadata) -> bool:
        """Whether an ``int``, ``float`` or ``bool`` with these validators and constraints is
        strict about true and false."""
        if base is int:
            return any(m in metadata for m in Count.__metadata__)
        if base is bool:
            return any(m in metadata for m in Flag.__metadata__)
        return (any(m in metadata for m in (*Real.__metadata__, *Order.__metadata__))
                or any(isinstance(m, QuantityKind) for m in metadata))

    def plain(tp, where: str, seen: set) -> list[str]:
        if tp in (int, float, bool):
            return [where]
        if typing.get_origin(tp) is typing.Annotated:
            args = typing.get_args(tp)
            if args[0] in (int, float, bool):
                return [] if checked(args[0], tp.__metadata__) else [where]
            return plain(args[0], where, seen)
        if isinstance(tp, type) and issubclass(tp, BaseModel):
            if tp in seen:
                return []
            seen.add(tp)
            out = []
            for name, f in tp.model_fields.items():
                ann = f.annotation
                if ann in (int, float, bool):  # Annotated[int, ...]: the field's constraints
                    out += [] if checked(ann, f.metadata) else [f"{tp.__name__}.{name}"]
                else:
                    out += plain(ann, f"{tp.__name__}.{name}", seen)
            return out
        return [w for a in typing.get_args(tp) for w in plain(a, where, seen)]

    seen: set = set()
    roots = [Study, MeshStudy, AnalysisStudy, *(getattr(o, "options_model", None) for o in OUTPUTS.values()
                                                if getattr(o, "options_model", None))]
    assert [w for m in roots for w in plain(m, m.__name__, seen)] == []
    counted = sum(1 for m in seen for f in m.model_fields.values()
                  if any(x in f.metadata for x in Count.__metadata__))
    assert counted >= 10  # the walk reached the models (teeth, num, steps_per_period, ...)
    real = sum(1 for m in seen for f in m.model_fields.values()
               if any(x in f.metadata for x in Real.__metadata__))
    assert real >= 10  # alpha, beta, gamma, settle_tolerance, zeta_max, max_order, ...


NUMBER = "a number (not true or false)"
"""What a plain (dimensionless) float field of a study says to YAML's true or false."""

MATHIEU = """\
title: m
scene:
  kind: mathieu
  alpha: 0.25
  beta: 0.1
  gamma: 0.01
sweep:
  beta: [0.1, 0.2]
  alpha: {start: 0.2, stop: 0.3, num: 2}
solver:
  settle_tolerance: 1.0e9
  divergence_factor: 1.0e6
  initial_velocity: 0.0
outputs: [floquet, {spectrum: {max_order: 2}}]
"""


@pytest.mark.parametrize(("old", "new", "where"), [
    ("alpha: 0.25", "alpha: true", "4: scene.alpha: True"),
    ("beta: 0.1\n", "beta: false\n", "5: scene.beta: False"),
    ("gamma: 0.01", "gamma: true", "6: scene.gamma: True"),
    ("beta: [0.1, 0.2]", "beta: [0.1, true]", "8: sweep.beta[1]: True"),
    ("start: 0.2,", "start: false,", "9: sweep.alpha.start: False"),
    ("settle_tolerance: 1.0e9", "settle_tolerance: true", "11: solver.settle_tolerance: True"),
    ("divergence_factor: 1.0e6", "divergence_factor: true", "12: solver.divergence_factor: True"),
    ("initial_velocity: 0.0", "initial_velocity: false", "13: solver.initial_velocity: False"),
    ("max_order: 2", "max_order: true", "14: outputs[1].spectrum.max_order: True"),
])
def test_true_or_false_is_not_a_number(old, new, where):
    """A plain float field took YAML's true and false as 1.0 and 0.0 (pydantic's lax mode):
    ``alpha: true`` ran the Mathieu equation at alpha = 1. Now one line, as for an integer."""
    assert old in MATHIEU
    assert _lines(MATHIEU.replace(old, new)) == [f"s.yaml:{where} -- {NUMBER}"]
    parse_study(MATHIEU, "s.yaml")


@pytest.mark.parametrize(("bad", "good", "where"), [
    ("fluctuation: [{amplitude: 300 N, order: true}]", "true:1",
     "9: scene.fluctuation[0].order: True -- " + NUMBER),
    ("ste: [{amplitude: 1 um, order: false}]", "false:2", "9: scene.ste[0].order: False -- " + NUMBER),
    # a quantity (force or torque) keeps saying what it wants: a bare number would not do either
    ("fluctuation: [{amplitude: true, order: 1}]", "true:300 N",
     ("9: scene.fluctuation[0].amplitude: True -- expected a force (e.g. '300 N') or a torque"
     " (e.g. '5 N*m')")),
])
def test_true_or_false_is_not_an_order(bad, good, where):
    text = GOOD.replace("mean_force: 100 N\n", f"mean_force: 100 N\n  {bad}\n")
    assert _lines(text) == [f"s.yaml:{where}"]
    parse_study(text.replace(*good.split(":")), "s.yaml")


@pytest.mark.parametrize(("old", "new", "message"), [
    ("alpha: 0.25", "alpha: abc",
     "4: scene.alpha: 'abc' -- Input should be a valid number, unable to parse string as a number"),
    ("gamma: 0.01", "gamma: -1", "6: scene.gamma: -1 -- Input should be greater than or equal to 0"),
    ("gamma: 0.01", "gamma: .inf", "6: scene.gamma: inf -- a finite number (not nan or inf)"),
    ("settle_tolerance: 1.0e9", "settle_tolerance: 0",
     "11: solver.settle_tolerance: 0 -- Input should be greater than 0"),
    ("max_order: 2", "max_order: null", ("14: outputs[1].spectrum.max_order: None -- Input should"
     " be a valid number")),
])
def test_a_number_field_keeps_its_bounds_and_messages(old, new, message):
    """``Real`` is pydantic's float but for true and false: bounds, strings, nan and inf say what
    they said."""
    assert _lines(MATHIEU.replace(old, new)) == [f"s.yaml:{message}"]
    study = parse_study(MATHIEU.replace("alpha: 0.25", "alpha: '0.5'").replace("gamma: 0.01",
                                                                            "gamma: 1"), "s.yaml")
    assert study.scene.alpha == 0.5 and type(study.scene.gamma) is float


@pytest.mark.parametrize(("study", "old", "new", "where"), [
    ("table1_profile_shift.yaml", "x1: 0.48", "x1: true", "21: gear.x1"),
    ("method_stability.yaml", "zeta: [0.0, 0.02,", "zeta: [0.0, true,", "11: analysis.zeta[1]"),
    ("method_stability.yaml", "steps: 200000", "steps: 200000\n  zeta_max: true",
     "13: analysis.zeta_max"),
    ("work_precision.yaml", "rtol: [1.0e-3,", "rtol: [true,", "14: analysis.rtol[0]"),
    ("fig08_rattle_balance.yaml", "curve_top: 3.0", "curve_top: true", "21: analysis.curve_top"),
    ("fig08_rattle_balance.yaml", "[0.7, 0.5, 1.25]", "[0.7, true, 1.25]",
     "23: analysis.graphical[1]"),
    ("rattle_map_jumps.yaml", "loss_threshold: 0.01", "loss_threshold: true",
     "10: analysis.loss_threshold"),
])
def test_true_is_not_a_number_in_gear_and_analysis_studies(study, old, new, where):
    path = ROOT / "studies" / study
    text = path.read_text(encoding="utf-8")
    assert old in text
    with pytest.raises(StudyError) as err:
        parse_study(text.replace(old, new), str(path))
    assert err.value.lines == [f"{path}:{where}: True -- {NUMBER}"]
    parse_study(text, str(path))


def test_a_misspelt_key_of_a_mesh_sweep_and_a_single_value_for_three_have_plain_lines():
    """pydantic's own words came through: 'sweep.torqe.[key]: ...' (its location of a mapping's
    key) and 'analysis.graphical: 0.7 -- Input should be a valid tuple' (found by a fuzzer)."""
    mesh = (ROOT / "studies" / "mesh_ste_vs_load.yaml").read_text(encoding="utf-8")
    assert "  torque: {start" in mesh
    [line] = _lines(mesh.replace("  torque: {start", "  torqe: {start"))
    assert line.startswith("s.yaml:14: sweep.torqe: 'torqe' -- did you mean 'torque'?"), line
    balance = (ROOT / "studies" / "fig08_rattle_balance.yaml").read_text(encoding="utf-8")
    assert "graphical: [0.7, 0.5, 1.25]" in balance
    assert _lines(balance.replace("graphical: [0.7, 0.5, 1.25]", "graphical: 0.7")) == [
        "s.yaml:23: analysis.graphical: 0.7 -- a list, e.g. [a, b, c]"]


@pytest.mark.parametrize("field", ["fluctuation", "ste"])
def test_a_single_value_for_a_list_of_harmonics_is_told_to_write_mappings(field):
    """'fluctuation: 300 N' said "a list; for one item write [300 N]", which is refused in turn
    (an item is a mapping of amplitude and order; found by a fuzzer)."""
    text = GOOD.replace("mean_force: 100 N", f"mean_force: 100 N\n  {field}: 300 N")
    assert _lines(text) == [(f"s.yaml:9: scene.{field}: '300 N' -- a list of mappings, e.g."
                            " [{amplitude: ..., order: ..., ...}]")]
    assert "for one item write [stats]" in _lines(GOOD + "outputs: stats\n")[0]


def test_a_value_of_the_wrong_type_inside_a_sweep_says_what_that_value_is():
    """null or a list as a range's start or stop, or as an item of a list, said "a list of values
    or {start, stop, num}", the words of the sweep's entry, not of the field named (found by a
    fuzzer)."""
    text = GOOD.replace("  speed: {start: 5000 rpm, stop: 6000 rpm, num: 3}\n", (
        "  speed: {start: null, stop: 6000 rpm, num: 3}\n"
        "  backlash: [0.1 mm, [0.2 mm]]\n"
        "  damping: {start: 1 N*s/mm, stop: {a: 1}, num: 3}\n"
        "  mass: {start: 1 kg, stop: 2 kg, num: null}\n"))
    assert _lines(text) == [
        "s.yaml:10: sweep.speed.start: None -- a speed such as '1 rpm'",
        "s.yaml:11: sweep.backlash[1]: '[...]' -- a length such as '1 mm'",
        "s.yaml:12: sweep.damping.stop: '{...}' -- a damping such as '1 N s/mm'",
        "s.yaml:13: sweep.mass.num: None -- Input should be a valid integer"]
    # (a scalar is a one-value axis now: tests/test_study_input_findings.py; true is none)
    assert _lines(GOOD.replace("{start: 5000 rpm, stop: 6000 rpm, num: 3}", "true")) == [
        "s.yaml:10: sweep.speed: True -- a value, a list of values or {start, stop, num}"]


@pytest.mark.parametrize("name", ["floquet", "stats", "period"])
def test_a_single_value_as_the_options_of_an_output_names_the_output(name):
    """'outputs: [{floquet: 5}]' said "outputs[0].options: 5 -- a mapping (name: value, ...)":
    'options' is no key of the file, and floquet takes no options at all (found by a fuzzer)."""
    [line] = _lines(GOOD + f"outputs: [{{{name}: 5}}]\n")
    assert line.startswith(f"s.yaml:12: outputs[0].{name}: 5 -- "), line
    if name != "period":
        assert line.endswith(f"the '{name}' output takes no options"), line


@pytest.mark.parametrize("command", ["validate", "run"])
def test_a_result_name_longer_than_a_file_name_is_one_line(tmp_path, capsys, command):
    """An analysis' result of 300 characters ended in OSError 'File name too long' from
    validate and run (a traceback; found by a fuzzer): no file of that name can exist."""
    path = tmp_path / "a.yaml"
    path.write_text("type: analysis\ntitle: t\nanalysis:\n  kind: jump_map\n  result: "
                    + "x" * 300 + "\n", encoding="utf-8")
    argv = [command, str(path)] + (["-o", str(tmp_path / "o.nc")] if command == "run" else [])
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"gearsweep: error: {path}:5: analysis.result: 'xxx") and (
        "at most 252 bytes" in err) and err.count("\n") == 1, err


def test_validate_says_true_is_not_a_number_in_one_line(tmp_path, capsys):
    path = tmp_path / "m.yaml"
    path.write_text("title: m\nscene: {kind: mathieu, alpha: true}\n", encoding="utf-8")
    assert main(["validate", str(path)]) == 2
    assert capsys.readouterr().err == f"gearsweep: error: {path}:2: scene.alpha: True -- {NUMBER}\n"


WORK_PRECISION = ROOT / "studies" / "work_precision.yaml"
METHOD_STABILITY = ROOT / "studies" / "method_stability.yaml"


def _analysis_lines(path: Path, old: str, new: str) -> list[str]:
    text = path.read_text(encoding="utf-8")
    assert old in text
    with pytest.raises(StudyError) as err:
        parse_study(text.replace(old, new), "a.yaml")
    return err.value.lines


def test_an_analysis_error_names_the_field_as_written_and_its_own_line():
    """The analysis' kind is a key pydantic adds to the error's location
    (``analysis.work_precision.steps_per_period[1]``), not one of the file: the path named it and
    the line was that of ``analysis:`` (8), where the file has no such key. Now the path is the
    file's and the line the field's, several lines below ``analysis:``."""
    text = WORK_PRECISION.read_text(encoding="utf-8")
    assert text.splitlines()[7] == "analysis:" and "steps_per_period" in text.splitlines()[11]
    assert _analysis_lines(WORK_PRECISION, "[8, 16, 32,", "[8, true, 32,") == [
        f"a.yaml:12: analysis.steps_per_period[1]: True -- {WHOLE}"]
    assert _analysis_lines(
        WORK_PRECISION, "peers: [RK45, DOP853, LSODA]\n",
        "peers: [RK45, DOP853, LSODA]\n  copies: 0\n  repeat: many\n") == [
        "a.yaml:14: analysis.copies: 0 -- Input should be greater than or equal to 1",
        ("a.yaml:15: analysis.repeat: 'many' -- Input should be a valid integer, unable to parse"
        " string as an integer")]
    assert _analysis_lines(METHOD_STABILITY, "steps: 200000", "steps: 20") == [
        "a.yaml:12: analysis.steps: 20 -- Input should be greater than or equal to 1000"]
    # a check of each item is on the item's line (was one line on 'analysis:', and a NaN in
    # zeta hid a negative damping ratio beside it: an adversarial test)
    assert _analysis_lines(WORK_PRECISION, "[8, 16, 32, 64,", "[10, 16, 32, 64,") == [
        "a.yaml:12: analysis.steps_per_period[0]: 10 -- Input should be a multiple of 8"]
    assert _analysis_lines(METHOD_STABILITY, "zeta: [0.0, 0.02,", "zeta: [-1, .nan,") == [
        "a.yaml:11: analysis.zeta[0]: -1 -- Input should be greater than or equal to 0",
        "a.yaml:11: analysis.zeta[1]: nan -- a finite number (not nan or inf)"]


def test_an_unknown_or_missing_analysis_field_is_told_in_the_analysis_words():
    """An unknown key in an analysis is matched against the fields of its kind (a 'peer' got
    "did you mean 'speed'?", from the fields of the scenes), a field of another kind says so,
    and a missing or unknown kind lists the analyses (it said "a scene needs a kind: whine,
    rattle, full or mathieu", and "not a scene kind")."""
    assert _analysis_lines(WORK_PRECISION, "  peers:", "  peer:") == [
        ("a.yaml:13: analysis.peer: 'peer' is not a field of a work_precision analysis -- did you"
        " mean 'peers'?")]
    assert _analysis_lines(METHOD_STABILITY, "steps: 200000", "steps: 200000\n  rtol: [0.1]") == [
        ("a.yaml:13: analysis.rtol: 'rtol' is not a field of a method_stability analysis (it is one"
        " of a work_precision analysis)")]
    kinds = "method_stability, work_precision, artifact_map, rattle_balance, rattle_budget"
    assert _analysis_lines(METHOD_STABILITY, "  kind: method_stability\n", "") == [
        f"a.yaml:8: analysis.kind: '(missing)' -- an analysis needs a kind: {kinds} or jump_map"]
    assert _analysis_lines(METHOD_STABILITY, "kind: method_stability", "kind: zzz") == [
        f"a.yaml:9: analysis.kind: 'zzz' -- not an analysis kind; allowed: {kinds}, jump_map"]
    # the scene's own words are unchanged
    assert _lines("title: m\nscene:\n  alpha: 1\n") == [
        "s.yaml:2: scene.kind: '(missing)' -- a scene needs a kind: whine, rattle, full or mathieu"]
    assert _lines("title: m\nscene:\n  kind: zzz\n") == [
        "s.yaml:3: scene.kind: 'zzz' -- not a scene kind; allowed: whine, rattle, full, mathieu"]


def test_a_scene_error_names_the_field_as_written_and_its_own_line():
    """The scene's kind is dropped from the path as the analysis' is (``scene.alpha``, not
    ``scene.mathieu.alpha``), and a key named like a kind is kept (a ``mathieu:`` key in the scene
    was "'scene' is not a field of a study -- did you mean 'scene'?")."""
    text = "title: m\nscene:\n  kind: mathieu\n  alpha: 0.25\n  gamma: 0.01\n"
    assert _lines(text.replace("gamma: 0.01", "gamma: -1")) == [
        "s.yaml:5: scene.gamma: -1 -- Input should be greater than or equal to 0"]
    assert _lines(text + "  mathieu: 1\n") == [
        ("s.yaml:6: scene.mathieu: 'mathieu' is not a field of a mathieu scene; its fields: alpha,"
        " beta, gamma")]


def test_validate_names_an_analysis_field_and_its_line_in_one_line(tmp_path, capsys):
    path = tmp_path / "wp.yaml"
    path.write_text(WORK_PRECISION.read_text(encoding="utf-8").replace("[8, 16, 32,",
                                                                       "[8, true, 32,"),
                    encoding="utf-8")
    assert main(["validate", str(path)]) == 2
    assert capsys.readouterr().err == (f"gearsweep: error: {path}:12: analysis.steps_per_period[1]:"
                                       f" True -- {WHOLE}\n")


SAME = "each value once, or ds.sel() cannot tell them apart"


@pytest.mark.parametrize(("study", "old", "new", "said"), [
    ("method_stability.yaml", "methods: [rk4, rk5]", "methods: [rk4, rk4]",
     (f"10: analysis.methods[1]: 'rk4' -- a value not already in the list (the same as"
     f" analysis.methods[0], 'rk4'): {SAME}")),
    ("method_stability.yaml", "zeta: [0.0, 0.02, 0.05,", "zeta: [0.0, 0.02, 0.020,",
     (f"11: analysis.zeta[2]: 0.02 -- a value not already in the list (the same as"
     f" analysis.zeta[1], 0.02): {SAME}")),
    ("stability_artifact_map.yaml", "methods: [rk5, fehlberg5,", "methods: [rk5, rk5,",
     (f"11: analysis.methods[1]: 'rk5' -- a value not already in the list (the same as"
     f" analysis.methods[0], 'rk5'): {SAME}")),
    ("stability_artifact_map.yaml", "[100, 120, 140,", "[100, 120, 120,",
     (f"12: analysis.steps_per_period[2]: 120 -- a value not already in the list (the same as"
     f" analysis.steps_per_period[1], 120): {SAME}")),
    ("work_precision.yaml", "scenes: [whine, rattle]", "scenes: [rattle, rattle]",
     (f"10: analysis.scenes[1]: 'rattle' -- a value not already in the list (the same as"
     f" analysis.scenes[0], 'rattle'): {SAME}")),
    ("work_precision.yaml", "[rk4, rk5, rk4-kink,", "[rk4, rk4, rk4-kink,",
     (f"11: analysis.methods[1]: 'rk4' -- a value not already in the list (the same as"
     f" analysis.methods[0], 'rk4'): {SAME}")),
    ("work_precision.yaml", "[8, 16, 32, 64,", "[8, 16, 32, 32,",
     (f"12: analysis.steps_per_period[3]: 32 -- a value not already in the list (the same as"
     f" analysis.steps_per_period[2], 32): {SAME}")),
    ("work_precision.yaml", "[RK45, DOP853, LSODA]", "[RK45, RK45, LSODA]",
     (f"13: analysis.peers[1]: 'RK45' -- a value not already in the list (the same as"
     f" analysis.peers[0], 'RK45'): {SAME}")),
    ("work_precision.yaml", "[1.0e-3, 1.0e-4,", "[1.0e-3, 0.001,",
     (f"14: analysis.rtol[1]: 0.001 -- a value not already in the list (the same as"
     f" analysis.rtol[0], 0.001): {SAME}")),
    ("fig08_rattle_budget.yaml", "[rattle_table1_pair, rattle_table1_ste_paper_k]",
     "[rattle_table1_pair, rattle_table1_pair.nc]",
     (f"14: analysis.scenes[1]: 'rattle_table1_pair.nc' -- a value not already in the list (the"
     f" same as analysis.scenes[0], 'rattle_table1_pair'): {SAME}")),
    ("fig08_rattle_budget.yaml", "names: [\"pair's k0\", \"paper's k\"]",
     "names: [k0, k0]",
     ("15: analysis.names[1]: 'k0' -- a value not already in the list (the same as"
     " analysis.names[0], 'k0'): each value once, or the legends cannot tell the scenes apart")),
    ("fig08_rattle_budget.yaml", "[7500 rpm, 8000 rpm]", "[7500 rpm, 125 Hz]",
     (f"18: analysis.at_speeds[1]: '125 Hz' -- a value not already in the list (the same as"
     f" analysis.at_speeds[0], '7500 rpm'): {SAME}")),
])
def test_an_analysis_list_takes_each_entry_once(study, old, new, said, tmp_path, capsys):
    """A list of an analysis whose entries become a coordinate of the result or name what is
    computed took an entry twice (``methods: [rk4, rk4]``, ``peers: [RK45, RK45]``, a step
    count or a tolerance twice): validate said ok, the run computed it twice, into a coordinate
    that ``ds.sel()`` could not tell apart (an outside tester's finding). Refused as a sweep's
    repeated value is, by the same check, in any spelling (``125 Hz`` is ``7500 rpm``, a
    result's name with ``.nc`` is the name)."""
    text = (ROOT / "studies" / study).read_text(encoding="utf-8")
    assert old in text
    path = tmp_path / "a.yaml"
    path.write_text(text.replace(old, new), encoding="utf-8")
    assert main(["validate", str(path)]) == 2
    assert capsys.readouterr().err == f"gearsweep: error: {path}:{said}\n"


def test_the_lines_of_fig9_may_repeat_a_multiple():
    """rattle_balance's ``graphical`` is three different lines (A at x w_t, B at x (w_t + w_n), C
    at x w_n; the result's ``line`` coordinate is A, B, C whatever the numbers): one multiple
    for two of them is two lines, and stays allowed (jump_map has no list)."""
    text = (ROOT / "studies" / "fig08_rattle_balance.yaml").read_text(encoding="utf-8")
    assert "graphical: [0.7, 0.5, 1.25]" in text
    study = parse_study(text.replace("[0.7, 0.5, 1.25]", "[0.5, 0.5, 0.5]"), "a.yaml")
    assert study.analysis.graphical == (0.5, 0.5, 0.5)


def test_validate_says_true_is_not_a_whole_number_in_one_line(tmp_path, capsys):
    path = tmp_path / "t.yaml"
    path.write_text(GOOD.replace("teeth: 48", "teeth: true"), encoding="utf-8")
    assert main(["validate", str(path)]) == 2
    assert capsys.readouterr().err == f"gearsweep: error: {path}:5: scene.teeth: True -- {WHOLE}\n"


SHAFT_ORDER = "title: shaft-order fluctuation\n" + WHINE_SCENE + """\
  fluctuation: [{amplitude: 200 N, order: 1/48}]
sweep:
  speed: {start: 3000 rpm, stop: 12000 rpm, num: 4}
solver: {method: rk4, steps_per_period: 64, transient_periods: 100RECORD}
"""


def test_a_shaft_order_excitation_needs_two_whole_cycles_recorded(tmp_path, capsys):
    """``order: 1/48`` (once per revolution of the 48-tooth gear) is read as the ratio (it was
    refused: 'unable to parse string as a number'). Its response repeats every 48 mesh periods;
    the settle test compares the extremes of the record's two halves, so with the default 50
    recorded periods every case could be flagged 'not settled' (a new user's study: 24 of 50).
    Fewer than two cycles are refused at the study's line; 96 periods settle."""
    from gearsweep.api import run_study

    study = tmp_path / "s.yaml"
    study.write_text(SHAFT_ORDER.replace("RECORD", ""), encoding="utf-8")
    assert main(["validate", str(study)]) == 2
    assert capsys.readouterr().err == (
        f"gearsweep: error: {study}:13: solver.record_periods: 50 -- at least 96 for this"
        " excitation (its cycle is 48 mesh periods, set by order 0.0208333 = 1/48: the settle"
        " test compares the extremes of the record's two halves, each must hold a whole"
        " cycle)\n")
    # a decimal that stands for a short fraction is named, with the fraction to write (0.3333
    # is 3333/10000, a cycle of 10,000 periods; an outside tester's finding)
    assert main(["validate", str(study)]) == 2
    capsys.readouterr()
    study.write_text(SHAFT_ORDER.replace("RECORD", "").replace("1/48", "0.3333"),
                     encoding="utf-8")
    assert main(["validate", str(study)]) == 2
    assert ("its cycle is 10000 mesh periods, set by order 0.3333 = 3333/10000, write '1/3' if"
            " that is meant:") in capsys.readouterr().err
    good = parse_study(SHAFT_ORDER.replace("RECORD", ", record_periods: 96"))
    assert good.scene.fluctuation[0].order == 1 / 48
    ds = run_study(good)
    assert (ds.status == 0).all() and (ds.settle_error < 1e-6).all()
    for bad, why in (("1/0", "not over 0"), ("1/48 N", "valid number"), ("true", "not true")):
        with pytest.raises(StudyError, match=why):
            parse_study(SHAFT_ORDER.replace("order: 1/48", f"order: {bad}"))


def _validate(tmp_path: Path, capsys, text: str) -> tuple[int, list[str]]:
    """``gearsweep validate`` of ``text``: its exit code and its lines, the file named s.yaml."""
    path = tmp_path / "s.yaml"
    path.write_text(text, encoding="utf-8")
    code = main(["validate", str(path)])
    out = capsys.readouterr()
    lines = (out.err or out.out).strip().splitlines()
    return code, [ln.removeprefix("gearsweep: error: ").replace(str(path), "s.yaml")
                  for ln in lines]


MESH = ("type: mesh\ntitle: t\ngear:\n  preset: table1_consistent\n"
        "  tip_relief: {amount: 6 um, start_at: single_contact}\ntorque: 50 N*m\n")


@pytest.mark.parametrize(("text", "line"), [
    (GOOD.replace("mean_force: 100 N", "mean_force: 100 N\n  fluctuation: [{amplitude: 60 N,"
                  " ordr: 1}]"),
     "s.yaml:9: scene.fluctuation[0].ordr: 'ordr' is an unknown field -- did you mean 'order'?"),
    (GOOD.replace("kind: rattle", "kind: full").replace(
        "mean_force: 100 N", "mean_force: 100 N\n  stiffness_harmonics: [{amplitude: 60 kN/mm,"
        " ordr: 1}]"),
     ("s.yaml:9: scene.stiffness_harmonics[0].ordr: 'ordr' is an unknown field -- did you mean"
      " 'order'?")),
    (GOOD.replace("num: 3}", "nun: 3}"),
     ("s.yaml:10: sweep.speed.nun: 'nun' is not a field of a {start, stop, num} range -- did you"
      " mean 'num'?")),
    (MESH.replace("amount:", "amout:"),
     "s.yaml:5: gear.tip_relief.amout: 'amout' is an unknown field -- did you mean 'amount'?"),
])
def test_a_misspelt_required_key_is_one_line(text, line, tmp_path, capsys):
    """'ordr: 1' where 'order' is required also gave "order: '(missing)' -- this field is
    required" on the same line: one mistake, two lines. The did-you-mean line explains both."""
    assert _validate(tmp_path, capsys, text) == (2, [line])


def test_a_missing_field_is_still_said_beside_an_unrelated_unknown_key(tmp_path, capsys):
    text = GOOD.replace("mean_force: 100 N", "mean_force: 100 N\n  fluctuation: [{amplitude:"
                        " 60 N, phse: 1}]")
    assert _validate(tmp_path, capsys, text) == (2, [
        "s.yaml:9: scene.fluctuation[0].order: '(missing)' -- this field is required",
        "s.yaml:9: scene.fluctuation[0].phse: 'phse' is an unknown field -- did you mean 'phase'?"])


def test_a_sweep_written_as_a_list_is_one_line(tmp_path, capsys):
    """A list under 'sweep:' also gave "scene.speed: '(missing)'", though the speed is in it."""
    text = GOOD.replace("  speed: {start", "  - speed: {start")
    assert _validate(tmp_path, capsys, text) == (2, [
        ("s.yaml:9: sweep: '[...]' -- a mapping of the swept parameters to their values (speed:"
         " {start: ..., stop: ..., num: ...}, ...), not a list")])


@pytest.mark.parametrize("other_error", [False, True])
def test_a_continuation_without_any_speed_is_one_line(other_error, tmp_path, capsys):
    """'continuation: [up]' with the speed neither swept nor given also gave "scene.speed:
    '(missing)'": the continuation's line says to sweep the speed, which mends both. The same
    line when another error stops the study's own checks."""
    text = GOOD.replace("  speed: {start: 5000 rpm, stop: 6000 rpm, num: 3}",
                        "  backlash: [0.1 mm, 0.2 mm]") + "continuation: [up]\n"
    lines = [("s.yaml:12: continuation: ['up'] -- continuation carries the state along"
              " sweep.speed: sweep the speed")]
    if other_error:
        text = text.replace("teeth: 48", "teeth: -48")
        lines.insert(0, "s.yaml:5: scene.teeth: -48 -- Input should be greater than 0")
    assert _validate(tmp_path, capsys, text) == (2, lines)
    # no continuation: the speed's own line, as before
    assert _validate(tmp_path, capsys, text.replace("continuation: [up]\n", "")) == (2, [
        ("s.yaml:2: scene.speed: '(missing)' -- the speed must be swept (sweep.speed) or given"
         " (scene.speed)"), *lines[:-1]])


def test_a_continuation_of_a_mathieu_scene_says_it_has_no_speed(tmp_path, capsys):
    """It said "sweep the speed", which a Mathieu scene cannot."""
    text = "title: t\nscene: {kind: mathieu}\nsweep:\n  alpha: [0.1, 0.2]\ncontinuation: [up]\n"
    assert _validate(tmp_path, capsys, text) == (2, [
        ("s.yaml:5: continuation: ['up'] -- continuation carries the state along sweep.speed,"
         " which a mathieu scene does not have: leave continuation out")])


SOLVER = "solver: {method: rk4, steps_per_period: 32, transient_periods: 4, record_periods: 4}"


@pytest.mark.parametrize(("old", "new", "line"), [
    (("  kind: rattle\n  mass: 0.1527 kg\n  teeth: 48\n  stiffness: 1073 kN/mm\n  backlash: 0.1"
     " mm\n  mean_force: 100 N\n"),
     ("  - kind: rattle\n    mass: 0.1527 kg\n    teeth: 48\n    stiffness: 1073 kN/mm\n"
     "    backlash: 0.1 mm\n    mean_force: 100 N\n"),
     ("s.yaml:2: scene: '[...]' -- a mapping of scene fields (kind: rattle, mass: ..., ...), not a"
     " list")),
    (SOLVER, "solver: [rk4]",
     ("s.yaml:11: solver: '[...]' -- a mapping of solver fields (method: rk4, steps_per_period: 64,"
     " ...), not a list")),
    (SOLVER, "solver: rk4",
     ("s.yaml:11: solver: 'rk4' -- a mapping of solver fields (method: rk4, steps_per_period: 64,"
     " ...)")),
    (SOLVER, SOLVER + "\noutputs: [[stats]]",
     ("s.yaml:12: outputs[0]: '[...]' -- an output name, or a mapping of one output name to its"
     " options (stats, or {spectrum: {max_order: 4}}), not a list")),
    (SOLVER, SOLVER + "\noutputs: [{spectrum: [4]}]",
     ("s.yaml:12: outputs[0].spectrum: '[...]' -- a mapping of spectrum options (max_order: 4,"
     " samples_per_period: ..., ...), not a list")),
    ("  mean_force: 100 N", "  mean_force: 100 N\n  fluctuation: [[300 N, 1]]",
     ("s.yaml:9: scene.fluctuation[0]: '[...]' -- a mapping of fluctuation fields (amplitude: ...,"
     " order: ..., ...), not a list")),
    ("  mass: 0.1527 kg", "  drive: [1 kg*m^2]",
     ("s.yaml:4: scene.drive: '[...]' -- a mapping of drive fields (inertia_1: ..., inertia_2: ...,"
     " ...), not a list")),
])
def test_a_section_that_is_no_mapping_says_what_it_should_be(old, new, line, tmp_path, capsys):
    """A scene written as a list said "scene.kind: '(missing)' -- a scene needs a kind"; a solver
    (or a drive, an item of the fluctuation or the outputs) got pydantic's "Input should be a
    valid dictionary or instance of Solver". Each says it is a mapping of which fields; a drive
    that is no mapping is not also said to lack its base radii."""
    assert old in GOOD + SOLVER
    assert _validate(tmp_path, capsys, GOOD.replace(old, new)) == (2, [line])


@pytest.mark.parametrize(("text", "line"), [
    ("type: analysis\ntitle: t\nanalysis: [method_stability]\n",
     ("s.yaml:3: analysis: '[...]' -- a mapping of analysis fields (kind: method_stability,"
     " methods: ..., ...), not a list")),
    (MESH.replace("  tip_relief: {amount: 6 um, start_at: single_contact}", "  tip_relief: [6 um]"),
     ("s.yaml:5: gear.tip_relief: '[...]' -- a mapping of tip_relief fields (amount: ..., shape:"
     " linear, ...), not a list")),
    ("type: mesh\ntitle: t\ngear: [table1_consistent]\ntorque: 50 N*m\n",
     ("s.yaml:3: gear: '[...]' -- a preset name (table1_consistent, table1_as_printed,"
     " table1_profile_shift) or a mapping of gear fields (preset: ..., module: ..., ...), not a"
     " list")),
])
def test_a_section_of_a_mesh_or_analysis_study_that_is_no_mapping(text, line, tmp_path, capsys):
    assert _validate(tmp_path, capsys, text) == (2, [line])


@pytest.mark.parametrize(("text", "line"), [
    (GOOD + "foo: 1\n",
     ("s.yaml:12: foo: 'foo' is not a field of a dynamic study; its fields: title, description,"
      " scene, sweep, continuation, solver, outputs")),
    (MESH + "foo: 1\n",
     ("s.yaml:7: foo: 'foo' is not a field of a mesh study; its fields: type, title, description,"
      " gear, gears, torque, sweep, positions, harmonics")),
    ("type: analysis\ntitle: t\nanalysis: {kind: method_stability}\nfoo: 1\n",
     ("s.yaml:4: foo: 'foo' is not a field of an analysis study; its fields: type, title,"
      " description, analysis")),
    (GOOD + "positions: 200\n",
     "s.yaml:12: positions: 'positions' is not a field of a dynamic study (it is one of a mesh study)"),
    (GOOD.replace("  mean_force: 100 N\n", "") + "mean_force: 100 N\n",
     ("s.yaml:11: mean_force: 'mean_force' is not a field of a dynamic study (it is a field of the"
      " scene: scene.mean_force)")),
    (MESH + "scene: {kind: whine}\n",
     "s.yaml:7: scene: 'scene' is not a field of a mesh study (it is one of a dynamic study)"),
])
def test_an_unknown_top_level_key_lists_the_fields_of_its_own_kind_of_study(text, line, tmp_path,
                                                                           capsys):
    """It listed 'type, gear, gears, torque, positions, harmonics, analysis' among the fields of
    a dynamic study (those of every kind); a field of another kind of study (or of the scene)
    was 'did you mean' itself. A misspelling is still matched against every kind
    (test_a_misspelt_top_level_key_is_matched_against_every_kind_of_study)."""
    assert _validate(tmp_path, capsys, text) == (2, [line])


@pytest.mark.parametrize(("entry", "lines"), [
    ("{start: 0.1, stop: 0.5 mm, num: 5, spacing: logg}",
     ["s.yaml:11: sweep.backlash.spacing: 'logg' -- did you mean 'log'? (allowed: linear, log)",
      "s.yaml:11: sweep.backlash.start: 0.1 has no unit; write e.g. '0.1 mm', or '0.1 m' if SI was meant"]),
    ("{start: 0.1, stop: 0.5 mm, nun: 5}",
     [("s.yaml:11: sweep.backlash.nun: 'nun' is not a field of a {start, stop, num} range -- did"
      " you mean 'num'?"),
      "s.yaml:11: sweep.backlash.start: 0.1 has no unit; write e.g. '0.1 mm', or '0.1 m' if SI was meant"]),
    ("[0.1, [0.2 mm]]",
     ["s.yaml:11: sweep.backlash[1]: '[...]' -- a length such as '1 mm'",
      "s.yaml:11: sweep.backlash[0]: 0.1 has no unit; write e.g. '0.1 mm', or '0.1 m' if SI was meant"]),
])
def test_a_broken_sweep_entry_still_has_its_units_checked(entry, lines, tmp_path, capsys):
    """A range with a misspelt spacing hid the missing unit of its start (and every other sweep
    problem) until the spacing was mended: the sweep's values were checked only when the whole
    sweep validated. Each entry is checked on its own now, and the values of a broken one that
    are fine in themselves too."""
    text = GOOD.replace("num: 3}", f"num: 3}}\n  backlash: {entry}")
    assert _validate(tmp_path, capsys, text) == (2, lines)


@pytest.mark.parametrize(("study", "said"), [
    ("method_stability.yaml", "analysis study 'method_stability', computed in one piece: about"),
    ("mesh_tip_relief.yaml", "a mesh study, computed in one piece: peak memory about")])
def test_the_estimate_of_a_study_computed_in_one_piece_names_its_kind(study, said, capsys):
    """It said "a analysis study" (an analysis study's time is estimated now:
    tests/test_analysis_cost.py; a mesh study's memory, as validate says it)."""
    path = ROOT / "studies" / study
    assert main(["run", "--estimate", str(path)]) == 0
    assert capsys.readouterr().out.startswith(f"{path}: {said}")


def test_a_kind_that_starts_with_a_vowel_takes_an(tmp_path, capsys):
    """'expected a inertia quantity'; 'not a field of a artifact_map analysis'."""
    text = GOOD.replace("  mass: 0.1527 kg\n", "  drive: {inertia_1: true, inertia_2: 1 kg*m^2,"
                        " base_radius_1: 30 mm, base_radius_2: 30 mm}\n")
    assert _validate(tmp_path, capsys, text) == (2, [
        ("s.yaml:4: scene.drive.inertia_1: True -- expected an inertia quantity such as"
         " '1 kg m^2'")])
    analysis = (ROOT / "studies/method_stability.yaml").read_text(encoding="utf-8")
    assert _validate(tmp_path, capsys, analysis.replace("  steps: 200000", "  steps: 200000\n"
                                                        "  rig: x")) == (2, [
        ("s.yaml:13: analysis.rig: 'rig' is not a field of a method_stability analysis (it is one"
         " of an artifact_map analysis)")])


@pytest.mark.parametrize(("written", "where"), [
    ("outputs: [{spectrum: {max_order: 40}}]", "12: outputs[0].spectrum.max_order: 40"),
    ("outputs:\n  - stats\n  - spectrum:\n      max_order: 4e1",
     "15: outputs[1].spectrum.max_order: '4e1'"),
])
def test_a_planning_error_names_the_field_and_value_as_written(written, where, tmp_path, capsys):
    """The Nyquist check of the planner said "outputs.spectrum.max_order: 40.0" where the file
    says 'max_order: 40' in its outputs[0], on the line of 'outputs:'."""
    assert _validate(tmp_path, capsys, GOOD + written + "\n") == (2, [
        f"s.yaml:{where} -- at most samples_per_period / 2 = 16 (the Nyquist order)"])


def test_inspect_prints_no_unit_for_a_dimensionless_coordinate(tmp_path, capsys):
    """'alpha  60 values from 0.05 to 1.5 1': the unit '1' (dimensionless) ran into the number."""
    import numpy as np
    import xarray as xr

    path = tmp_path / "m.nc"
    xr.Dataset({"p_rms": (("alpha", "speed"), np.zeros((60, 2)))},
               coords={"alpha": ("alpha", np.linspace(0.05, 1.5, 60), {"units": "1"}),
                       "speed": ("speed", [1000.0, 2000.0], {"units": "rpm"})},
               attrs={"study": "title: m"}).to_netcdf(path)  # a result's (inspect's check)
    assert main(["inspect", str(path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert "    alpha              60 values from 0.05 to 1.5" in lines, lines
    assert "    speed               2 values from 1000 to 2000 rpm" in lines, lines


def test_inspect_counts_the_cases_a_flag_marks(tmp_path, capsys):
    """A flag (``beyond_step_limit``) was listed with no count: a whine at 64 steps per period
    had 7 of 300 cases beyond the step limit, one of them p_rms 0.7 m with status 0, and inspect
    said only 'status: 300 x code 0' (an engineer new to the tool)."""
    import numpy as np
    import xarray as xr

    path = tmp_path / "f.nc"
    flag = np.zeros(300, bool)
    flag[:7] = True
    xr.Dataset({"beyond_step_limit": ("speed", flag, {"units": "1", "long_name": "beyond"}),
                "status": ("speed", np.zeros(300, np.int8), {"units": "1"})},
               coords={"speed": ("speed", np.linspace(500.0, 6000.0, 300), {"units": "rpm"})},
               attrs={"study": "title: f"}).to_netcdf(path)
    assert main(["inspect", str(path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert "    beyond_step_limit          1      (speed) beyond  [true for 7 of 300]" in lines, lines


def test_advise_says_it_reads_stdin_and_names_it_as_validate_does(monkeypatch, capsys):
    """'advise --help' had no help for its study and did not say that '-' reads stdin; a study
    read from stdin was labelled '-:' where validate says '<stdin>:'."""
    monkeypatch.setenv("COLUMNS", "100")  # argparse wraps its help to the terminal's width
    with pytest.raises(SystemExit) as end:
        main(["advise", "--help"])
    assert end.value.code == 0
    assert re.search(r"\n  study +study file \(- reads stdin\)\n", capsys.readouterr().out)
    monkeypatch.setattr(sys, "stdin", io.StringIO(GOOD))
    assert main(["advise", "-"]) == 0
    assert capsys.readouterr().out.startswith("<stdin>:\n  rattle scene with backlash")
    monkeypatch.setattr(sys, "stdin", io.StringIO(GOOD))
    assert main(["advise", "-", "--target", "2"]) == 2
    assert capsys.readouterr().err == ("gearsweep: error: <stdin>: --target: 2.0 -- a relative"
                                       " error between 0 and 1 (e.g. 1e-4)\n")


def test_advise_says_when_its_steps_are_more_than_a_study_takes(monkeypatch, capsys):
    """``--target 1e-20`` advised 53185478400 steps per period with 'h omega_n = 0.000', with no
    word that a study takes at most 65536 (found by new-user and adversarial tests)."""
    for target, says in (("1e-20", True), ("1e-4", False)):
        monkeypatch.setattr(sys, "stdin", io.StringIO(GOOD))
        assert main(["advise", "-", "--target", target]) == 0
        out = " ".join(capsys.readouterr().out.split())
        assert ("beyond the 65536 a study takes (solver.steps_per_period): out of reach here"
                in out) is says, out
        assert "h omega_n = 0.000" not in out, out


@pytest.mark.parametrize(("line", "said"), [
    ("outputs: stats", "outputs: 'stats' -- a list; for one item write [stats]"),
    ("continuation: up", "continuation: 'up' -- a list; for one item write [up]"),
    ("outputs: {stats: {}}", ("outputs: '{...}' -- a list; a mapping here is one item of it:"
                             " write it as [{...}]")),
])
def test_one_item_where_a_list_is_wanted_says_how_to_write_it(line, said):
    """pydantic's 'Input should be a valid list' told a new user nothing about the brackets."""
    text = GOOD.replace("solver:", f"{line}\nsolver:")
    assert _lines(text) == [f"s.yaml:11: {said}"]


def test_a_drive_beside_a_base_radius_says_which_to_leave_out():
    """It said "'base_radius' is already given by 'drive.base_radius_1'", also to a drive that
    did not give it."""
    text = GOOD.replace("  mass: 0.1527 kg\n", "  drive: {inertia_1: 1e-3 kg m^2, inertia_2:"
                        " 2e-3 kg m^2, base_radius_1: 30 mm, base_radius_2: 40 mm}\n"
                        "  base_radius: 30 mm\n")
    lines = _lines(text)
    assert len(lines) == 1 and lines[0].endswith(
        "with a 'drive', its 'base_radius_1' is the base radius: leave out 'base_radius'"), lines


def test_inspect_of_an_analysis_result_names_its_input_not_a_solver(tmp_path, capsys):
    """An analysis result printed 'scene analysis: jump_map, ? at ? steps per mesh period, ?
    transient + ? recorded periods'; a range whose minimum was -0.0 printed '[-0 .. 0.8]'."""
    import numpy as np
    import xarray as xr

    path = tmp_path / "j.nc"
    xr.Dataset({"rattle_share": ("damping", np.array([-0.0, 0.8074]), {"units": "1"})},
               coords={"damping": ("damping", [1.0, 2.0], {"units": "N s mm-1"})},
               attrs={"scene": "analysis: jump_map", "input_small": "ab12",
                      "input_cases": 4, "study": "title: j"}).to_netcdf(path)
    assert main(["inspect", str(path)]) == 0
    out = capsys.readouterr().out
    assert "  analysis study jump_map, reading small\n" in out and "steps per mesh" not in out, out
    assert "[0 .. 0.8074]" in out, out


def test_validate_says_a_swept_mean_force_replaces_the_scenes_torque(tmp_path, capsys):
    """Sweeping torque over a scene's torque was said ('the sweep replaces scene.torque');
    sweeping mean_force over a scene's torque, the same load, was not."""
    text = GOOD.replace("  mean_force: 100 N\n", "  torque: 5 N m\n  base_radius: 50 mm\n").replace(
        "sweep:\n", "sweep:\n  mean_force: [100 N, 200 N]\n")
    path = tmp_path / "s.yaml"
    path.write_text(text, encoding="utf-8")
    assert main(["validate", str(path)]) == 0
    assert "the sweep replaces scene.torque" in capsys.readouterr().out


def test_options_that_do_not_apply_to_a_study_in_one_piece_are_noted(tmp_path, capsys):
    study = ROOT / "studies" / "mesh_tip_relief.yaml"
    assert main(["run", str(study), "-o", str(tmp_path / "m.nc"), "--workers", "2",
                 "--chunk-size", "10"]) == 0
    assert capsys.readouterr().err == (
        f"gearsweep: note: {study}: a mesh study is computed in one piece, in this process:"
        " --workers, --chunk-size do not apply\n")


WHOLE_NUMBER_FLAGS = [
    ("--chunk-size", (("1e5", "100000"), ("2E0", "2"), ("3.0", "3"), ("1e18", "1" + "0" * 18)),
     "2e0", ("1.5e0", "0.5", "abc", "nan", "1e19", "0", "-1e3"),
     "a positive whole number of cases up to 1e18 (100000, or 1e5)"),
    ("--workers", (("1e0", "1"),), "1", ("abc", "1.5", "0", "-2"),
     "a positive whole number of workers"),
]


@pytest.mark.parametrize("flag, same, runs, bads, allowed", WHOLE_NUMBER_FLAGS,
                         ids=[f[0] for f in WHOLE_NUMBER_FLAGS])
def test_a_whole_number_flag_takes_1e5_and_refuses_the_rest_in_one_line(tmp_path, capsys, flag,
                                                                       same, runs, bads, allowed):
    """``--chunk-size 1e5`` was refused by argparse ('invalid int value', with the usage), though
    the flag's help writes '1e9 steps', and ``--workers abc`` printed the usage too (an outside
    tester): a whole number written so is taken as written in digits; anything else is refused
    in one line naming the flag, exit 2."""
    path = tmp_path / "s.yaml"
    path.write_text(GOOD, encoding="utf-8")

    def run(value: str) -> tuple[int, str, str]:
        code = main(["run", str(path), "--estimate", f"{flag}={value}"])
        out, err = capsys.readouterr()
        return code, out, err

    for written, digits in same:
        assert run(written) == run(digits), written
    assert run(runs)[0] == 0
    for bad in bads:
        code, out, err = run(bad)
        assert code == 2 and not out and err.count("\n") == 1, (bad, err)
        assert err.startswith(f"gearsweep: error: {path}: {flag}: ") and (
            f"-- {allowed}\n") in err, err


def test_record_periods_rules_for_one_period_a_spectrum_and_a_ratio_beyond_the_teeth(tmp_path,
                                                                                   capsys):
    """A review found: one recorded period of a driven scene flagged settled cases 'not settled'
    (the rule held for cycles > 1 only); a spectrum's 'a multiple of 48' was then refused again
    with 'at least 96' (now one line says both); and order 1/97 of an 8-tooth gear got a cycle
    of 80 (the ratio is kept when the nearest small fraction is not it)."""
    from gearsweep.model import Harmonic, MeshModel

    assert MeshModel(mass=1.0, teeth=8, stiffness=1e8,
                     force_harmonics=(Harmonic(1.0, 1 / 97),)).cycle_periods == 97
    assert MeshModel(mass=1.0, teeth=48, stiffness=1e8,
                     force_harmonics=(Harmonic(1.0, 0.0208333),)).cycle_periods == 48
    study = tmp_path / "s.yaml"
    study.write_text(SHAFT_ORDER.replace("order: 1/48", "order: 1").replace(
        "RECORD", ", record_periods: 1"), encoding="utf-8")
    assert main(["validate", str(study)]) == 2
    said = "solver.record_periods: 1 -- at least 2 for this excitation (its cycle is 1 mesh period:"
    assert said in capsys.readouterr().err
    study.write_text(SHAFT_ORDER.replace("RECORD", ", record_periods: 48").replace(
        "speed: {start: 3000 rpm, stop: 12000 rpm, num: 4}",
        "speed: {start: 3000 rpm, stop: 12000 rpm, num: 4}\noutputs: [spectrum]"), encoding="utf-8")
    assert main(["validate", str(study)]) == 2
    assert "solver.record_periods: 48 -- a multiple of 48, at least 96 for this excitation" \
        in capsys.readouterr().err


def test_device_gpu_is_pointed_to_cuda():
    """'device: gpu' means the GPU: the hint names cuda (by spelling it was nearest to 'cpu',
    and said so; found by an outside test); a misspelling still gets the nearest choice."""
    for word, meant in (("gpu", "cuda"), ("cpuu", "cpu")):
        text = GOOD.replace("solver: {method", f"solver: {{device: {word}, method")
        assert _lines(text) == [(f"s.yaml:11: solver.device: '{word}' -- did you mean"
                                f" '{meant}'? (allowed: cpu, cuda, auto)")]


@pytest.mark.parametrize(("stop", "num", "spacing"), [
    ("5000.0000000001 rpm", 5, "linear"), ("5000.000000001 rpm", 5, "linear"),
    ("5000.0000000001 rpm", 5, "log"), ("5000.00000001 rpm", 5, "log"),
    ("0.1000000000000002 mm", 3, "linear"), ("0.100000000002 mm", 3, "linear")])
def test_a_range_finer_than_the_coordinates_digits_is_refused(stop, num, spacing):
    """A list with two values that the result's 14-digit coordinate cannot tell apart is
    refused; a range of such values was not ({start: 3000 rpm, stop: 3000.0000000001 rpm,
    num: 5} wrote five speeds of 3000 rpm, and ds.sel(speed=3000) gave several). Truth: the
    coordinate the file would hold, the range's grid rounded as the result rounds it."""
    start = "0.1 mm" if stop.endswith("mm") else "5000 rpm"
    name = "backlash" if stop.endswith("mm") else "speed"
    a, b = (float(v.split()[0]) for v in (start, stop))
    grid = np.geomspace(a, b, num) if spacing == "log" else np.linspace(a, b, num)
    equal = len(set(decimal_coordinates(grid))) < num
    text = GOOD.replace("  speed: {start: 5000 rpm, stop: 6000 rpm, num: 3}",
                        f"  speed: [5000 rpm]\n  {name}: {{start: {start}, stop: {stop},"
                        f" num: {num}, spacing: {spacing}}}" if name == "backlash" else
                        f"  speed: {{start: {start}, stop: {stop}, num: {num}, spacing: {spacing}}}")
    if equal:
        lines = _lines(text)
        assert len(lines) == 1 and f"sweep.{name}.num: {num} -- fewer values" in lines[0], lines
    else:
        parse_study(text, "s.yaml")


def test_a_harmonic_faster_than_the_steps_can_follow_is_refused():
    """Fewer than 4 steps per period of the highest excitation harmonic (plan.STEPS_PER_HARMONIC)
    is refused at steps_per_period, naming the steps needed: an STE of order 64 at 32 steps per
    mesh period gave p_rms 8.8e-14 um against 3.56 um at 1024 steps, with status 0 (an outside
    fuzz tester). Order 8 at 32 steps is the least accepted."""
    at = "mean_force: 100 N\n"
    with pytest.raises(StudyError) as err:
        make_plan(parse_study(GOOD.replace(
            at, at + "  fluctuation: [{amplitude: 300 N, order: 9}]\n"), "s.yaml"))
    (line,) = str(err.value).split("\n")
    assert "solver.steps_per_period: 32" in line and "at least 36" in line
    assert "mesh order 9" in line
    plan = make_plan(parse_study(GOOD.replace(
        at, at + "  fluctuation: [{amplitude: 300 N, order: 8}]\n"), "s.yaml"))
    assert plan.model.force_harmonics[0].order == 8


GEAR_WHINE_STEPS = """title: a gear whine
scene:
  kind: whine
  gear: {{module: 3 mm, z1: 23, z2: 61, face_width: 20 mm, x1: 0.3, x2: -0.1}}
  {harmonics}
  torque: 120 N m
  drive: {{inertia_1: 3.49e-4 kg m^2, inertia_2: 0.01729 kg m^2}}
  damping: 1.1 N s/mm
sweep:
  speed: {{start: 500 rpm, stop: 9000 rpm, num: 4}}
solver: {{method: rk4, steps_per_period: {spp}, transient_periods: 20, record_periods: 4}}
outputs: [stats, {{spectrum: {{max_order: 4}}}}]
"""


@pytest.mark.parametrize(("harmonics", "top"), [("harmonics: 10", 10), ("", 10),
                                                ("harmonics: 12", 12)])
def test_a_gear_is_held_to_the_steps_of_its_highest_harmonic(tmp_path, capsys, harmonics, top):
    """A gear's k(t) and e(t) have harmonics 1..`harmonics` (10 when not given), known before
    the mesh is computed: a gear whine of 10 harmonics at 32 steps per period was accepted
    (exit 0) where typed harmonics of order 10 at 32 steps were refused, and its spectrum sampled
    32 times per period (an outside tester). The same rule, on the same field: at least
    4 x harmonics steps; exactly that many is accepted."""
    path = tmp_path / "gear.yaml"
    path.write_text(GEAR_WHINE_STEPS.format(harmonics=harmonics, spp=4 * top - 8),
                    encoding="utf-8")
    assert main(["validate", str(path)]) == 2
    (line,) = capsys.readouterr().err.strip().split("\n")
    assert f"gear.yaml:11: solver.steps_per_period: {4 * top - 8} -- at least {4 * top}" in line
    assert f"mesh order {top}, the gear's harmonics: {top}" in line
    path.write_text(GEAR_WHINE_STEPS.format(harmonics=harmonics, spp=4 * top), encoding="utf-8")
    plan = make_plan(parse_study(path.read_text(encoding="utf-8"), str(path)))
    assert plan.model.highest_order == top  # the gear's, as the check took it


def test_validate_notes_a_transient_too_short_for_light_damping(tmp_path, capsys):
    """A free vibration decays as exp(-c t / (2 m)): with c = 25.6 N s/m (zeta 0.001), m_eq
    0.1527 kg and 300 transient mesh periods, at 18,500 rpm of 48 teeth exp(-0.5 (c/m) 300 T)
    = 18 % of the start's is left, and 814 periods bring it to 1 %; validate notes it (an
    outside check found such cases with status 0 and p_pp 10-17 % off). At the paper's damping
    (5.5 N s/mm) nothing is noted."""
    text = """title: light damping
scene:
  kind: whine
  mass: 0.1527 kg
  teeth: 48
  stiffness: 1073 kN/mm
  ste: [{{amplitude: 5 um}}]
  damping: {c}
sweep:
  speed: {{start: 15000 rpm, stop: 18500 rpm, num: 8}}
solver: {{method: rk4, steps_per_period: 64, transient_periods: 300, record_periods: 20}}
"""
    c_over_m, period = 25.6 / 0.1527, 60 / (48 * 18500)
    left = math.exp(-0.5 * c_over_m * 300 * period)
    need = math.ceil(math.log(100) / (0.5 * c_over_m * period))
    assert round(100 * left) == 18 and need == 814
    path = tmp_path / "s.yaml"
    path.write_text(text.format(c="0.0256 N*s/mm"), encoding="utf-8")
    assert main(["validate", str(path)]) == 0
    err = capsys.readouterr().err
    assert "transient_periods 300 leave up to 18%" in err and "at 18500 rpm" in err
    assert "814 transient periods leave 1%" in err
    path.write_text(text.format(c="5.5 N*s/mm"), encoding="utf-8")
    assert main(["validate", str(path)]) == 0
    assert "transient" not in capsys.readouterr().err


def test_a_spectrum_too_long_to_hold_is_refused_before_its_coordinates_are_made(tmp_path):
    """record_periods: 1e8 beside a spectrum took validate 19 s and 6.45 GB (its order
    coordinate and the speed x order frequency were made before the estimate could refuse it;
    an outside fuzz tester): now one line at solver.record_periods, at once."""
    text = (ROOT / "studies" / "fig05_waterfall.yaml").read_text(encoding="utf-8")
    text = re.sub(r"record_periods: \d+", "record_periods: 100000000", text)
    t0 = time.perf_counter()
    with pytest.raises(StudyError) as err:
        make_plan(parse_study(text, "w.yaml"))
    assert time.perf_counter() - t0 < 10
    (line,) = str(err.value).split("\n")
    assert "solver.record_periods: 100000000 -- a spectrum of at most" in line


@pytest.mark.parametrize(("amplitude", "ok"), [("5 m", False), ("2 mm", False), ("1 mm", True),
                                              ("5 um", True)])
def test_a_typed_ste_beyond_a_millimetre_is_a_unit_slip(amplitude, ok):
    """'5 m' for '5 um' ran (an STE of metres, p of metres, status 0): an STE is micrometres to
    tens of micrometres, and a sampled one is bounded the same (test_measured_excitation.py)."""
    text = GOOD.replace("mean_force: 100 N\n", f"mean_force: 100 N\n  ste: [{{amplitude: {amplitude}}}]\n")
    if ok:
        parse_study(text, "s.yaml")
        return
    assert _lines(text) == [(f"s.yaml:9: scene.ste[0].amplitude: '{amplitude}' -- an STE of at"
                            " most 1 mm (STEs are micrometres to tens of micrometres: a unit"
                            " slip?)")]


@pytest.mark.parametrize(("old", "new", "line", "hint"), [
    ("  mean_force: 100 N", " mean_force: 100 N", 8,
     ("expected <block end>, but found '<block mapping start>' (this line's indentation does not"
     " match the lines of its block)")),
    ("  mean_force: 100 N", "    mean_force: 100 N", 8,
     ("mapping values are not allowed here (a line indented deeper than the one above it, or ': '"
     " inside a value: quote the value)")),
    ("  mean_force: 100 N", "\tmean_force: 100 N", 8,
     "found character '\\t' that cannot start any token (a tab: YAML indents with spaces only)"),
    ("num: 3}", "num: 3}}", 10,
     ("expected <block end>, but found '}' (braces { } or brackets [ ] on this line that do not"
     " pair up)")),
])
def test_a_layout_mistake_in_yaml_is_said_in_the_files_terms(old, new, line, hint):
    """A line indented one space too few, too many, with a tab, or a stray brace: pyyaml's own
    words ("expected <block end>, but found '<block mapping start>'") were the whole message
    (an engineer new to the tool); the line now also says what in the layout is wrong."""
    assert GOOD.count(old) == 1
    assert _lines(GOOD.replace(old, new)) == [f"s.yaml:{line}: (yaml): not valid YAML: {hint}"]


def test_a_range_given_by_its_step_says_to_give_num():
    """``{start, stop, step}`` (the way many tools write a range) got two lines: num missing, and
    "'step' is not a field ... -- did you mean 'stop'?", which misleads. Now one line naming
    num, and the num that start, stop and step give where it is whole (an engineer new to the
    tool)."""
    text = GOOD.replace("num: 3}", "step: 500 rpm}")
    assert _lines(text) == [
        ("s.yaml:10: sweep.speed.step: 'step' is not a field of a {start, stop, num} range: give"
         " num, the number of values (start, stop and step 500 rpm give num: 3)")]
    assert _lines(text.replace("step: 500 rpm", "step: 300 rpm")) == [
        ("s.yaml:10: sweep.speed.step: 'step' is not a field of a {start, stop, num} range: give"
         " num, the number of values")]
    assert _lines(text.replace("step: 500 rpm", "increment: 0")) == [
        ("s.yaml:10: sweep.speed.increment: 'increment' is not a field of a {start, stop, num}"
         " range: give num, the number of values")]
    # a step that gives more values than a range takes: their count, not a num of 300 digits
    assert _lines(text.replace("step: 500 rpm", "step: 1e-300 rpm")) == [
        ("s.yaml:10: sweep.speed.step: 'step' is not a field of a {start, stop, num} range: give"
         " num, the number of values (start, stop and step 1e-300 rpm give 1e+303 values, more"
         " than the 10,000,000 a range takes)")]
    # beside a num, a step is a field too many (test_an_unknown_field_is_matched_...)
    assert "did you mean 'stop'?" in _lines(text.replace("{start", "{num: 3, start"))[0]
    parse_study(GOOD, "s.yaml")


def test_inspect_keeps_long_variable_names_and_units_in_their_columns(tmp_path, capsys):
    """'excitation_fit_residual_stiffness' (33 characters) and 'kN mm-1' pushed their lines'
    units and dimensions out of the columns (an engineer new to the tool)."""
    import numpy as np
    import xarray as xr

    path = tmp_path / "f.nc"
    xr.Dataset({"p_rms": ("speed", np.ones(3), {"units": "um", "long_name": "rms"}),
                "excitation_fit_residual_stiffness": ((), 1.0, {"units": "kN mm-1",
                                                              "long_name": "residual"})},
               coords={"speed": ("speed", [1.0, 2.0, 3.0], {"units": "rpm"})},
               attrs={"study": "title: f"}).to_netcdf(path)
    assert main(["inspect", str(path)]) == 0
    rows = [ln for ln in capsys.readouterr().out.splitlines() if " rms " in ln or " residual " in ln]
    assert len(rows) == 2 and len({r.index("(") for r in rows}) == 1, rows
    assert len({r.index(" um ") if " um " in r else r.index(" kN") for r in rows}) == 1, rows


def test_a_pressure_angle_of_45_deg_or_more_is_said_with_the_other_fields():
    """``pressure_angle: 90 deg`` beside ``z1: 2`` was said only in a second run, once z1 was
    fixed, at the gear's line (GearPair's own check; an outside tester's finding): now at its
    field's line, with the others."""
    text = ("type: mesh\ntitle: t\ngear:\n  module: 2 mm\n  z1: 2\n  z2: 40\n"
            "  pressure_angle: 90 deg\n  face_width: 20 mm\ntorque: 50 N*m\n")
    assert _lines(text) == [
        "s.yaml:5: gear.z1: 2 -- Input should be greater than or equal to 3",
        ("s.yaml:7: gear.pressure_angle: '90 deg' -- a pressure angle below 45 deg (involute spur"
         " gears: 14.5-30 deg, 20 deg the standard)")]
    parse_study(text.replace("z1: 2\n", "z1: 20\n").replace("90 deg", "25 deg"), "s.yaml")


def test_a_misspelt_sweep_of_a_gear_scene_does_not_offer_the_stiffness():
    """The list of sweepable fields offered ``stiffness`` to a gear scene, which refuses
    sweeping it (its pair gives k(t); an outside tester's finding)."""
    gear = ("  gear: {module: 2 mm, z1: 25, z2: 50, face_width: 20 mm}\n  torque: 5 N*m\n")
    text = (GOOD.replace("  stiffness: 1073 kN/mm\n", "").replace("  teeth: 48\n", "")
            .replace("  mean_force: 100 N\n", gear).replace("  speed:", "  sped:"))
    line = _lines(text)[-1]  # (after: the speed given nowhere)
    assert line.endswith("did you mean 'speed'? allowed: backlash, damping, mass, mean_force,"
                         " speed, torque"), line
    (line,) = _lines(text.replace("  sped:", "  stiffness: [1 kN/mm, 2 kN/mm]\n  speed:"))
    assert "sweep.stiffness: a gear scene computes its stiffness from the gear pair" in line
    assert "stiffness, torque" in _lines(GOOD.replace("  speed:", "  sped:"))[-1]  # no gear


@pytest.mark.parametrize("speed", ["3000 rpm", "[3000 rpm]", "{start: 3000 rpm, stop: 3000 rpm, num: 1}"])
def test_a_continuation_over_one_speed_is_refused(speed):
    """``continuation: [up, down]`` over one speed ran "up" and "down" as the same case, with no
    word (an outside tester's finding): no state to carry from speed to speed."""
    text = GOOD.replace("  speed: {start: 5000 rpm, stop: 6000 rpm, num: 3}", f"  speed: {speed}")
    parse_study(text, "s.yaml")
    assert _lines(text + "continuation: [up, down]\n") == [
        ("s.yaml:12: continuation: ['up', 'down'] -- a continuation carries the state from speed"
         " to speed: sweep.speed needs 2 or more values (it has one), or leave continuation out")]
    parse_study(GOOD + "continuation: [up, down]\n", "s.yaml")


def test_a_speed_that_no_spur_gear_runs_at_is_noted(tmp_path, capsys):
    """A mesh frequency written as the speed in Hz (190-3450 Hz read as 11,400-207,000 rpm of
    the shaft: 703 m/s at a 32 mm base circle) validated with no word (an outside tester's
    finding). A note, not a refusal: the study is valid, its speed unlikely. At 12,000 rpm
    (38 m/s) nothing is said."""
    path = tmp_path / "s.yaml"
    hz = GOOD.replace("  speed: {start: 5000 rpm, stop: 6000 rpm, num: 3}",
                      "  speed: {start: 190 Hz, stop: 3450 Hz, num: 3}")
    path.write_text(hz.replace("  mean_force: 100 N", "  mean_force: 100 N\n  base_radius: 32 mm"))
    assert main(["validate", str(path)]) == 0
    err = capsys.readouterr().err
    assert ("207,000 rpm of the driving gear moves its base circle (r1 = 32 mm) at 694 m/s,"
            " beyond any spur gear") in err  # 207000 x 2 pi / 60 x 0.032 = 693.7
    path.write_text(GOOD.replace("stop: 6000 rpm", "stop: 12000 rpm").replace(
        "  mean_force: 100 N", "  mean_force: 100 N\n  base_radius: 30 mm"))
    assert main(["validate", str(path)]) == 0
    assert "base circle" not in capsys.readouterr().err


def test_a_torque_fluctuation_beside_a_typed_mass_is_noted(tmp_path, capsys):
    """A torque amplitude beside ``mass`` and ``base_radius`` is F = T / r1 (a driven gear much
    heavier than the driving one); beside ``scene.drive`` it is Eq. (7)'s m_eq r1 T / I1: the
    same pair written both ways differed by 44 % in force with no word (an outside tester's
    finding). Now validate says which, and a force amplitude gets no note."""
    path = tmp_path / "s.yaml"
    torque = GOOD.replace("  mean_force: 100 N", "  mean_force: 100 N\n  base_radius: 36 mm\n"
                          "  fluctuation: [{amplitude: 10 N*m, order: 1}]")
    path.write_text(torque)
    assert main(["validate", str(path)]) == 0
    err = capsys.readouterr().err
    assert "scene.fluctuation[0]: a torque amplitude beside a typed mass is the force T / r1" in err
    path.write_text(torque.replace("10 N*m", "300 N"))
    assert main(["validate", str(path)]) == 0
    assert "typed mass" not in capsys.readouterr().err


def test_a_clash_of_steps_and_samples_per_period_is_said_at_the_later_written_field():
    """With the spectrum's samples_per_period 48 written after solver.steps_per_period 64 it said
    "s1.yaml:18: solver.steps_per_period: 64 -- a multiple of 48" at the earlier field (an outside
    tester's finding); the README's rule is the later written of the two. Written the other way
    round (outputs first), it is said at steps_per_period."""

    def _planned(text: str) -> list[str]:
        with pytest.raises(StudyError) as err:
            make_plan(parse_study(text, "s.yaml"), text, "s.yaml")
        return str(err.value).split("\n")

    text = GOOD + "outputs:\n  - spectrum: {samples_per_period: 12}\n"
    assert _planned(text) == [
        ("s.yaml:13: outputs[0].spectrum.samples_per_period: 12 -- a divisor of"
         " solver.steps_per_period (32): the samples are taken from the steps")]
    solver = "solver: {method: rk4, steps_per_period: 32, transient_periods: 4, record_periods: 4}\n"
    first = ("outputs:\n  - spectrum: {samples_per_period: 12}\n" + solver)
    assert _planned(GOOD.replace(solver, first)) == [
        ("s.yaml:13: solver.steps_per_period: 32 -- a multiple of 12 (the samples per period the"
         " outputs need)")]
    main_ok = GOOD + "outputs:\n  - spectrum: {samples_per_period: 16}\n"
    make_plan(parse_study(main_ok, "s.yaml"), main_ok, "s.yaml")


def test_a_gears_harmonics_against_the_steps_per_period_is_said_at_the_later_written_field():
    """The same rule for a gear's ``harmonics`` against ``steps_per_period`` (4 steps per period
    of the highest harmonic): at the steps where the solver is written below the scene, at the
    harmonics where the scene is written below the solver."""
    solver = "solver: {method: rk4, steps_per_period: 32, transient_periods: 4, record_periods: 4}\n"
    scene = ("scene:\n  kind: rattle\n  gear: table1_consistent\n  harmonics: 10\n"
             "  torque: 50 N*m\n  mass: 0.1527 kg\n  backlash: 0.4698 mm\n  damping: 4.92 N*s/mm\n")
    sweep = "sweep:\n  speed: [3000 rpm]\n"
    lines = []
    for text in ("title: t\n" + scene + sweep + solver, "title: t\n" + solver + scene + sweep):
        with pytest.raises(StudyError) as err:
            make_plan(parse_study(text, "s.yaml"), text, "s.yaml")
        lines.append(str(err.value))
    assert lines == [
        ("s.yaml:12: solver.steps_per_period: 32 -- at least 40 (4 steps per period of the highest"
         " excitation harmonic, mesh order 10, the gear's harmonics: 10; fewer cannot follow its"
         " forcing)"),
        ("s.yaml:6: scene.harmonics: 10 -- at most 8 (4 steps per period of the highest harmonic:"
         " solver.steps_per_period is 32)")]


def test_a_study_file_not_in_utf8_names_the_line_and_column_of_its_first_bad_byte(
        tmp_path, capsys, monkeypatch):
    """``title: "caf\\xe9"`` (Latin-1) said "x.yaml: (file): 'x.yaml' -- a study file in YAML (not
    UTF-8 text)", no line (an outside tester's finding)."""
    path = tmp_path / "x.yaml"
    path.write_bytes(b"# caf\xc3\xa9 in UTF-8 first\ntitle: \"caf\xe9\"\n")
    assert main(["validate", str(path)]) == 2
    assert capsys.readouterr().err == (
        f"gearsweep: error: {path}:2: (file): not UTF-8 text: byte 0xe9 at column 12 (a study"
        " file is UTF-8 text: save it as UTF-8)\n")
    monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(io.BytesIO(path.read_bytes())))
    assert main(["validate", "-"]) == 2  # (said "character '\udce9' is not allowed")
    assert capsys.readouterr().err == (
        "gearsweep: error: <stdin>:2: (file): not UTF-8 text: byte 0xe9 at column 12 (a study"
        " file is UTF-8 text: save it as UTF-8)\n")


def test_stiffness_harmonics_against_a_stiffness_written_later_are_said_at_the_stiffness():
    """Harmonics that take k(t) below 0 at the least swept k0 were said at
    scene.stiffness_harmonics, above the sweep that sets k0; by the README's rule (the later
    written of the two) it is said at the least swept stiffness, with the k0 that would do; an
    unswept k0 written above the harmonics keeps it at the harmonics."""
    scene = WHINE_SCENE.replace("1073 kN/mm", "80 kN/mm")
    sweep = "sweep:\n  speed: [3000 rpm]\n  stiffness: [1000 kN/mm, 50 kN/mm]\n"
    after = scene.replace("  stiffness: 80 kN/mm\n", "").replace("  damping:",
                                                                  "  stiffness: 80 kN/mm\n  damping:")
    lines = []
    for text in ("title: t\n" + scene + sweep, "title: t\n" + scene + "sweep:\n  speed: [3000 rpm]\n",
                 "title: t\n" + after + "sweep:\n  speed: [3000 rpm]\n"):
        with pytest.raises(StudyError) as err:
            make_plan(parse_study(text, "s.yaml"), text, "s.yaml")
        lines.append(str(err.value))
    assert lines == [
        ("s.yaml:12: sweep.stiffness[1]: '50 kN/mm' -- above 100 kN/mm, where"
         " scene.stiffness_harmonics keep k(t) positive (at this k0 they take it to -50 kN/mm at"
         " mesh phase 0.5)"),
        ("s.yaml:7: scene.stiffness_harmonics: harmonics that keep k(t) positive: with k0 = 80"
         " kN/mm they take it to -20 kN/mm at mesh phase 0.5"),
        ("s.yaml:7: scene.stiffness: '80 kN/mm' -- above 100 kN/mm, where"
         " scene.stiffness_harmonics keep k(t) positive (at this k0 they take it to -20 kN/mm at"
         " mesh phase 0.5)")]


@pytest.mark.parametrize("written", ["ste_harmonics", "static_transmission_error"])
def test_a_scene_s_ste_written_by_another_name_is_pointed_at_ste(written):
    """``scene.ste_harmonics`` was told "did you mean 'harmonics'?" (by spelling the nearest),
    but the field meant is ``ste`` (the STE's harmonics): an outside tester's finding."""
    text = GOOD_RATTLE.replace("  mean_force: 100 N\n",
                               f"  mean_force: 100 N\n  {written}: [{{amplitude: 5 um}}]\n")
    with pytest.raises(StudyError) as err:
        parse_study(text, "s.yaml")
    assert str(err.value).startswith(f"s.yaml:9: scene.{written}: '{written}' is not a"
                                      " field of a rattle scene -- did you mean 'ste'?"), err.value


def test_inspect_of_a_result_with_damaged_data_names_the_variable_in_one_line(tmp_path):
    """A result whose header is whole but whose data was overwritten (zeroed blocks: a disk
    error, a copy cut and patched): the rest described, then one line naming the variable that
    cannot be read, exit 2. It was 40 lines of traceback ending in ``RuntimeError: NetCDF: HDF
    error`` after the HDF5 filter's own ``zstd: ...`` line, exit 1 (an outside tester)."""
    import numpy as np
    import xarray as xr

    path = tmp_path / "zero.nc"
    rng = np.random.default_rng(1)
    xr.Dataset({"p_rms": (("speed",), np.ones(4)), "p_pp": (("case",), rng.random(400_000))},
               coords={"speed": ("speed", [1.0, 2.0, 3.0, 4.0], {"units": "rpm"})},
               attrs={"study": "title: z", "title": "z"}).to_netcdf(
        path, encoding={"p_pp": {"zlib": True}})
    data = bytearray(path.read_bytes())
    middle = len(data) // 2  # inside p_pp's compressed data, far from the header
    data[middle - 100_000:middle + 100_000] = bytes(200_000)
    path.write_bytes(bytes(data))
    r = subprocess.run([sys.executable, "-m", "gearsweep", "inspect", str(path)],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2, r.stderr[-3000:]
    assert r.stderr == (f"gearsweep: error: {path}: damaged: the data of p_pp cannot be read (the"
                        " file was changed or cut after it was written); run its study"
                        " again\n"), r.stderr[-3000:]
    out = r.stdout.splitlines()
    assert any(line.startswith("    p_rms ") and line.endswith("[1 .. 1]") for line in out), out
    assert any(line.startswith("    p_pp ") and line.endswith("damaged: cannot be read")
               for line in out), out

"""docs/study-reference.md is generated from the schema and must be current."""

from __future__ import annotations

import importlib.util
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _generator():
    spec = importlib.util.spec_from_file_location("gen_study_reference",
                                                  ROOT / "scripts" / "gen_study_reference.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_study_reference_is_current():
    gen = _generator()
    current = (ROOT / "docs" / "study-reference.md").read_text(encoding="utf-8")
    assert current == gen.render(), (
        "docs/study-reference.md is stale: run python scripts/gen_study_reference.py")


def test_study_reference_names_every_field_output_and_status():
    from gearsweep.study.outputs import OUTPUTS, STATUS_CODES
    from gearsweep.study.schema import RattleScene, Solver

    text = _generator().render()
    for name in [*RattleScene.model_fields, *Solver.model_fields, *OUTPUTS]:
        assert f"`{name}`" in text or f"### {name}" in text, name
    for code in STATUS_CODES:
        assert f"| {code} |" in text
    assert "| backlash | length | `mm` |" not in text  # a sweepable row names the parameter
    assert "| `backlash` | length | `mm` | rattle, full |" in text


def test_every_harmonic_list_says_an_order_is_given_once():
    """``repeated_order_problems`` refuses an order given twice in ``stiffness_harmonics``,
    ``ste`` and ``fluctuation``; the reference said so of the first two only."""
    text = _generator().render()
    for section in ("scene.stiffness_harmonics[i]", "scene.ste[i]", "scene.fluctuation[i]"):
        part = text.split(f"## {section}", 1)[1].split("\n## ", 1)[0]
        order = next(line for line in part.splitlines() if line.startswith("| `order` |"))
        assert "once per list" in order, (section, order)


def test_study_reference_states_the_gear_defaults():
    """A gear mapping's unset fields get GearPair's defaults; the reference must say which
    (a 25 deg pair is refused for the unstated 0.38 m fillet)."""
    text = _generator().render()
    for field, default in [("fillet_radius", "0.38 module"), ("pressure_angle", "20 deg"),
                           ("youngs_modulus", "206 GPa"), ("poisson", "0.3"),
                           ("tip_radius1", "m (1 + x1)"), ("root_radius1", "m (1.25 - x1)")]:
        row = next(line for line in text.splitlines() if line.startswith(f"| `{field}` | ")
                   and "(length)" in line or line.startswith(f"| `{field}` | ") and field
                   in ("pressure_angle", "youngs_modulus", "poisson"))
        assert default in row, (field, row)


TABLE_SCENES = [
    "{kind: whine, mass: 1 kg, teeth: 20, stiffness: 1e8 N/m, speed: 1000 rpm}",
    ("{kind: whine, mass: 1 kg, teeth: 20, stiffness: 1e8 N/m, mean_force: 100 N,"
     " stiffness_harmonics: [{amplitude: 1e7 N/m}], ste: [{amplitude: 1 um}], speed: 1000 rpm}"),
    ("{kind: whine, drive: DRIVE, teeth: 20, stiffness: 1e8 N/m, mean_force: 100 N,"
     " speed: 1000 rpm}"),
    ("{kind: rattle, drive: DRIVE, teeth: 20, stiffness: 1e8 N/m, backlash: 0.1 mm,"
     " torque: 1 N m, speed: 1000 rpm}"),
    ("{kind: full, gear: table1_consistent, drive: {inertia_1: 1e-3 kg m^2, inertia_2: 1e-3 kg"
     " m^2}, backlash: 0.1 mm, torque: 10 N m, speed: 1000 rpm}"),
    "{kind: mathieu, alpha: 0.5, beta: 0.1, gamma: 0.01}",
]
"""Scenes of every kind, with and without a drive, a load, backlash, k(t) and e(t)."""
DRIVE = "{inertia_1: 1e-3 kg m^2, inertia_2: 1e-3 kg m^2, base_radius_1: 30 mm, base_radius_2: 30 mm}"


def test_the_variables_table_lists_every_variable_any_output_can_write():
    """The table "Variables each output writes" had no rows for dte_spectrum,
    dte_spectrum_phase, pinion_spectrum and pinion_rms, which an option adds (an outside
    tester's finding): it is now read from the outputs' own variables with every combination of
    their yes/no options. Here, independently, every output with every combination of its yes/no
    options and each step guard, in scenes of every kind: each variable a study can have has a
    row, with the units its result stores."""
    import itertools
    import re

    from gearsweep.errors import StudyError
    from gearsweep.study.outputs import OUTPUTS
    from gearsweep.study.plan import make_plan
    from gearsweep.study.resultfile import VARIABLES, data_attrs, variable_attrs
    from gearsweep.study.schema import parse_study

    text = _generator().render()
    table = text.split("## Variables each output writes", 1)[1].split("\n## ", 1)[0]
    rows = {m[1]: m[2] for m in re.finditer(r"^\| [^|]+ \| `(\w+)` \| ([^|]+) \|", table, re.M)}
    written: dict[str, set[str]] = {}
    for scene, (name, out), guard in itertools.product(TABLE_SCENES, OUTPUTS.items(),
                                                       ("warn", "skip", "off")):
        model = getattr(out, "options_model", None)
        flags = [n for n, f in (model.model_fields.items() if model else ()) if f.annotation is bool]
        for values in itertools.product(("false", "true"), repeat=len(flags)):
            opts = ", ".join(f"{f}: {v}" for f, v in zip(flags, values, strict=True))
            study = (f"title: t\nscene: {scene.replace('DRIVE', DRIVE)}\n"
                     f"solver: {{step_guard: {guard}}}\n"
                     f"outputs: [{f'{{{name}: {{{opts}}}}}' if flags else name}]\n")
            try:
                plan = make_plan(parse_study(study), study)
            except StudyError as exc:  # an option the scene does not take
                assert re.search(r"outputs\.spectrum\.(pinion|dte): True", str(exc)), exc
                continue
            for var, spec in plan.specs.items():
                attrs = data_attrs(variable_attrs(var, VARIABLES, spec.result_attrs())[1])
                written.setdefault(var, set()).add(attrs["units"])
    assert {"dte_spectrum", "dte_spectrum_phase", "pinion_spectrum", "pinion_rms",
            "beyond_step_limit", "contact_lost", "impacts_per_period"} <= set(written)
    missing = sorted(set(written) - set(rows))
    assert not missing, f"no row in the variables table for {missing}"
    for var, units in written.items():
        assert rows[var].strip() in units, (var, rows[var], units)

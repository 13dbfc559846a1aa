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

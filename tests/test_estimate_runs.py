"""The estimate against what really happens: ``validate`` and ``run --estimate`` saying one
estimate of the same study (an outside tester's findings, 27 Nov 2026)."""

from __future__ import annotations

from pathlib import Path

import pytest

from gearsweep.cli import main
from gearsweep.study.estimate import chunk_cases, quick_estimate
from gearsweep.study.plan import make_plan
from gearsweep.study.schema import parse_study

ROOT = Path(__file__).resolve().parents[1]
SCALE = (ROOT / "studies" / "heavy" / "scale_1e6.yaml").read_text(encoding="utf-8")


def _cut(text: str, damping: int, backlash: int) -> str:
    """``studies/heavy/scale_1e6.yaml`` with ``damping`` x ``backlash`` of its 10 x 100 values
    (1,000 cases each)."""
    text = text.replace("stop: 500 N*s/m, num: 10}", f"stop: 500 N*s/m, num: {damping}}}")
    return text.replace("stop: 0.5 mm, num: 100}", f"stop: 0.5 mm, num: {backlash}}}")


S300 = _cut(SCALE, 10, 30)
"""The outside tester's 300,000-case cut (validate said 3 chunks, run --estimate 4)."""


def _plan(text: str):
    return make_plan(parse_study(text, "s.yaml"), text, "s.yaml")


def _estimate(plan, requested):
    return quick_estimate(plan, chunk_cases(plan, requested)[0])[0]  # as `gearsweep run`


@pytest.mark.parametrize("text", [S300, SCALE], ids=["300k", "1e6"])
def test_validate_and_run_estimate_say_one_estimate(tmp_path, capsys, text):
    """validate said 3 chunks and 478 MB, run --estimate 4 chunks and 462 MB of the same
    300,000 cases (5 and 6 chunks of the 1e6-case study): validate priced the runner's default
    chunks without the cap that the run puts on them."""
    study = tmp_path / "s.yaml"
    study.write_text(text, encoding="utf-8")
    assert main(["validate", str(study)]) == 0
    said = capsys.readouterr().out.split("estimate: ", 1)[1].strip()
    assert main(["run", str(study), "--estimate", "-o", str(tmp_path / "s.nc")]) == 0
    estimated = capsys.readouterr().out.split(": ", 1)[1].strip()
    assert said == estimated
    assert said == _estimate(_plan(text), None).line()

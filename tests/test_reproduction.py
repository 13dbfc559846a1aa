"""docs/REPRODUCTION.md: every study it names validates, every figure it names is in the repository.

That the main job actually produces each listed figure is checked by the main job itself, at its
end (scripts/main_job.py, check_reproduction), which CI runs.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from gearsweep.cli import main as cli

ROOT = Path(__file__).resolve().parent.parent
DOC = (ROOT / "docs" / "REPRODUCTION.md").read_text(encoding="utf-8")
STUDIES = sorted(set(re.findall(r"studies/([A-Za-z0-9_.-]+\.yaml)", DOC)))
FIGURES = sorted(set(re.findall(r"figures/([A-Za-z0-9_.-]+\.png)", DOC)))
PAPER_FIGURES = ["fig01", "fig02", "fig03", "fig05", "fig06", "fig7_1", "fig7_2", "fig08", "fig09",
                 "fig11", "fig12"]


def test_every_paper_figure_is_covered():
    for fig in PAPER_FIGURES:
        assert any(f.startswith(fig) for f in FIGURES), fig


@pytest.mark.parametrize("study", STUDIES)
def test_listed_study_exists_in_studies_and_validates(study, capsys):
    path = ROOT / "studies" / study
    assert path.exists(), f"{study} is named in REPRODUCTION.md but not in studies/"
    assert cli(["validate", str(path)]) == 0, capsys.readouterr().err


@pytest.mark.parametrize("figure", FIGURES)
def test_listed_figure_is_in_the_repository(figure):
    assert (ROOT / "figures" / figure).exists(), figure

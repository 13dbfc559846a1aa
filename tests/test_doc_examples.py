"""The Python examples of README.md and docs/*.md are code that runs: each parses, none holds a
placeholder (``{...}``, which is a set holding Ellipsis: README's ``gearsweep.run`` example did
not run as written), the README's study written as a dict runs and writes its file, and the
mesh.md example prints what the doc says it prints. (The examples that read results/ or run
whole studies were run by hand; the main job makes those results.)"""

from __future__ import annotations

import ast
import contextlib
import io
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
BLOCK = re.compile(r"^([ \t]*)```python\n(.*?)^\1```", re.M | re.S)


def examples() -> list[tuple[str, str]]:
    """(``page:line``, code) of each ```python block (dedented)."""
    out = []
    for page in PAGES:
        text = page.read_text(encoding="utf-8")
        for m in BLOCK.finditer(text):
            indent = m.group(1)
            code = "".join(line[len(indent):] if line.startswith(indent) else line
                           for line in m.group(2).splitlines(keepends=True))
            out.append((f"{page.name}:{text.count(chr(10), 0, m.start()) + 1}", code))
    return out


EXAMPLES = examples()


def test_the_docs_have_examples():
    names = {where.split(":")[0] for where, _ in EXAMPLES}
    assert {"README.md", "mesh.md"} <= names


@pytest.mark.parametrize("where,code", EXAMPLES, ids=[w for w, _ in EXAMPLES])
def test_example_parses_and_has_no_placeholder(where, code):
    tree = ast.parse(code, filename=where)
    dots = [n.lineno for n in ast.walk(tree)
            if isinstance(n, ast.Constant) and n.value is Ellipsis]
    assert not dots, f"{where}: a placeholder `...` on line(s) {dots} of the example"


def test_readme_study_dict_runs_as_written(tmp_path):
    import gearsweep

    (code,) = [c for w, c in EXAMPLES if w.startswith("README.md") and "study = {" in c]
    tree = ast.parse(code)
    (assign,) = [n for n in tree.body if isinstance(n, ast.Assign)
                 and any(isinstance(t, ast.Name) and t.id == "study" for t in n.targets)]
    study = ast.literal_eval(assign.value)
    out = tmp_path / "out.nc"
    ds = gearsweep.run(study, output=str(out))
    assert out.exists()
    assert ds.sizes["speed"] == 50 and int(ds.status.max()) == 0
    assert not bool(ds.contact_lost.any())  # the example stays in contact: no warning


def test_mesh_example_prints_what_the_doc_says():
    text = (ROOT / "docs" / "mesh.md").read_text(encoding="utf-8")
    (code,) = [c for w, c in EXAMPLES if w.startswith("mesh.md")]
    said = re.search(r"prints `([^`]*)`", text).group(1)
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        exec(compile(code, "mesh.md", "exec"), {})  # noqa: S102
    assert buf.getvalue().strip() == said

"""The layers import one way (docs/architecture.md): import-linter's contracts in pyproject.toml,
plus two rules it cannot state: no function-level import of gearsweep's own modules (a hidden edge
of the graph), and figure scripts that only read results and draw.

Every check parses source or builds the import graph: nothing of gearsweep is executed.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "gearsweep"

LAZY_OK = {"gearsweep/__init__.py", "gearsweep/__main__.py", "gearsweep/cli.py",
           "gearsweep/study/execute.py"}
"""Modules that import gearsweep's own modules inside functions on purpose: the package's
``__getattr__`` loads the API on first use (``import gearsweep`` stays as cheap as its version);
``__main__`` imports the CLI inside its Ctrl-C guard;
``cli`` and ``study.execute`` import ``study.dataset`` (and ``api``), and with it xarray, pandas
and netCDF4 (0.35 s), where a result is built: in ``run_to_file`` that is the writer thread,
beside the first chunk's kernel (docs/scale.md). import-linter still sees these edges (it reads
imports inside functions too); only these modules may have them."""

FIGURE_FORBIDDEN = ("gearsweep.kernels", "gearsweep.analysis", "gearsweep.model", "gearsweep.gear",
                    "gearsweep.study", "gearsweep.api.run", "gearsweep.api.estimate")
"""What a figure script must not import: it opens result files and calls ``gearsweep.plot``
(``gearsweep.gear``: the tooth physics; ``gearsweep.study``: every stage of a run, the mesh and
analysis computations with them)."""
FIGURE_FORBIDDEN_CALLS = ("run", "estimate")
"""``gearsweep.run(...)`` and ``gearsweep.estimate(...)`` after ``import gearsweep`` (no import
names them: a figure script that ran a study passed)."""

STILL_COMPUTING: set[str] = set()
"""Figure scripts that still compute (issue 22: to become study outputs). The test below fails
when one of them stops computing, so the list can only shrink."""


def _imports(tree: ast.AST, *, nested_only: bool = False) -> list[tuple[int, str]]:
    """(line, module) of every absolute import; with ``nested_only`` only those in functions."""
    out = []
    funcs = [n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef | ast.AsyncFunctionDef)]
    scopes = funcs if nested_only else [tree]
    for scope in scopes:
        for node in ast.walk(scope):
            if isinstance(node, ast.Import):
                out += [(node.lineno, a.name) for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                out += [(node.lineno, f"{node.module}.{a.name}") for a in node.names]
            elif isinstance(node, ast.ImportFrom):  # relative: a module of gearsweep itself
                where = ".".join(filter(None, ["gearsweep", node.module]))
                out += [(node.lineno, f"{where}.{a.name}") for a in node.names]
    return out


def test_import_linter_contracts_are_kept():
    exe = Path(sys.executable).with_name("lint-imports")
    r = subprocess.run([str(exe)], cwd=ROOT, capture_output=True, text=True)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-2000:]


def test_the_nested_import_scanner_sees_only_function_bodies():
    tree = ast.parse("import os\nfrom gearsweep import model\n"
                     "def f():\n    from gearsweep.study import plan\n    import yaml\n")
    assert _imports(tree, nested_only=True) == [(4, "gearsweep.study.plan"), (5, "yaml")]


def test_the_nested_import_scanner_sees_relative_imports():
    """``from ..study import plan`` inside a function is a hidden edge too (the scanner read only
    absolute imports)."""
    tree = ast.parse("def f():\n    from ..study import plan\n    from . import units\n")
    assert _imports(tree, nested_only=True) == [(2, "gearsweep.study.plan"), (3, "gearsweep.units")]


@pytest.mark.parametrize("path", sorted(PACKAGE.rglob("*.py")), ids=lambda p: str(p.relative_to(ROOT)))
def test_no_function_level_import_of_gearsweep_modules(path):
    rel = str(path.relative_to(ROOT))
    if rel in LAZY_OK:
        return
    hidden = [(ln, m) for ln, m in _imports(ast.parse(path.read_text()), nested_only=True)
              if m.startswith("gearsweep")]
    assert not hidden, f"{rel} imports inside functions: {hidden}"


def _figure_offences(path: Path) -> list[tuple[int, str]]:
    tree = ast.parse(path.read_text())
    calls = [(n.lineno, f"gearsweep.{n.attr}") for n in ast.walk(tree)
             if isinstance(n, ast.Attribute) and n.attr in FIGURE_FORBIDDEN_CALLS
             and isinstance(n.value, ast.Name) and n.value.id == "gearsweep"]
    return [(ln, m) for ln, m in _imports(tree)
            if m.startswith(FIGURE_FORBIDDEN) or m in ("gearsweep.run", "gearsweep.estimate")] + calls


def test_the_figure_check_sees_a_study_run_and_gear_physics(tmp_path):
    """A figure script that ran a study through ``import gearsweep`` and computed a mesh cycle
    passed ``test_figure_scripts_only_draw`` (found by an outside tester)."""
    script = tmp_path / "fig_probe.py"
    script.write_text("import gearsweep\nfrom gearsweep.gear import mesh_cycle\n"
                      "from gearsweep.study.analyses import COMPUTE\n"
                      "ds = gearsweep.run('studies/x.yaml')\n")
    assert sorted(_figure_offences(script)) == [(2, "gearsweep.gear.mesh_cycle"),
                                                (3, "gearsweep.study.analyses.COMPUTE"),
                                                (4, "gearsweep.run")]


@pytest.mark.parametrize("path", sorted((ROOT / "scripts").glob("fig*.py")), ids=lambda p: p.name)
def test_figure_scripts_only_draw(path):
    bad = _figure_offences(path)
    if path.name in STILL_COMPUTING:
        assert bad, f"{path.name} no longer computes: remove it from STILL_COMPUTING"
    else:
        assert not bad, f"{path.name} computes ({bad}): make it a study output, draw the result"

"""Fuzzing the study loader: random and mutated YAML loads, or raises one ``GearsweepError`` line.

Three generators: arbitrary text; valid studies whose values are replaced, deleted or extended
with hostile values (huge integers, NaN, power towers in unit strings, deep nesting, wrong types);
and valid study text with characters deleted, inserted or lines shuffled. Whatever the input,
``parse_study`` (and ``make_plan`` on what loads) must return or raise ``StudyError`` whose message
is a single line, within a time bound (no hang), and the CLI must exit 2 with one line on stderr.
"""

from __future__ import annotations

import copy
import math
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from gearsweep.cli import main
from gearsweep.errors import GearsweepError, StudyError
from gearsweep.study.plan import make_plan
from gearsweep.study.schema import MeshStudy, Study, parse_study

ROOT = Path(__file__).resolve().parents[1]

VALID = [
    (ROOT / "studies" / "whine_speed_sweep.yaml").read_text(encoding="utf-8"),
    """\
title: rattle
scene:
  kind: rattle
  mass: 0.1527 kg
  teeth: 48
  stiffness: 1073 kN/mm
  damping: 100 N*s/m
  backlash: 0.2 mm
  mean_force: 200 N
  fluctuation: [{amplitude: 300 N, order: 1}, {amplitude: 2 N*m, order: 0.5}]
  base_radius: 30 mm
sweep:
  speed: {start: 3000 rpm, stop: 12000 rpm, num: 30, spacing: log}
  torque: [1 N*m, 5 N*m]
continuation: [up, down]
solver: {method: rk5, steps_per_period: 32, transient_periods: 40, record_periods: 20}
""",
    """\
title: mathieu
scene: {kind: mathieu, alpha: 0.25, beta: 0.1, gamma: 0.01}
sweep: {alpha: {start: 0, stop: 2, num: 50}, beta: [0.0, 0.5]}
solver: {steps_per_period: 64}
""",
]
VALID_DICTS = [yaml.safe_load(t) for t in VALID]

SECONDS = 15.0
"""Time bound per input [s]: validating any of these inputs takes milliseconds to a few seconds
(5000 nested brackets in pure-Python YAML, on a loaded machine); what this catches is a hang, such
as pint evaluating the integer power tower 10**10**10 (minutes, then out of memory)."""

HOSTILE_STRINGS = [
    "10**10**10 N", "1_0**1_0**1_0 kg", "9**9**9", "((10**9)**9)**9 mm", "1e999 rpm", "-1e999 N",
    "nan kg", "inf N", "-inf mm", "0 rpm", "-5 mm", "1 / 0 N", "(", ")", "**", "N*m", "rpm",
    "5 kg*m**2", "3 N*s/mm", "1 m**-1", "__import__('os')", "lambda: 0", "1 apple", "", " ",
    "1e-320 m", "2e-3 kg*m^2", "0x10 N", "1,5 N", "up", "down", "rk4", "stats", "whine",
]

hostile = st.sampled_from([*HOSTILE_STRINGS, 10**400, -(10**400), float("nan"), float("inf")])
scalars = st.one_of(
    hostile,  # first and twice: hypothesis draws the first branches of one_of more often
    hostile,
    st.none(),
    st.booleans(),
    st.integers(min_value=-(10**30), max_value=10**30),
    st.sampled_from([10**400, -(10**400), 2**63, 2**64, -1, 0, 1]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from(HOSTILE_STRINGS),
    st.text(max_size=20),
)
values = st.recursive(
    scalars,
    lambda inner: st.one_of(st.lists(inner, max_size=4),
                            st.dictionaries(st.text(max_size=8) | st.sampled_from(
                                ["start", "stop", "num", "kind", "amplitude", "order"]),
                                inner, max_size=4)),
    max_leaves=8,
)


def _paths(node, prefix=()):
    """Every path (tuple of keys / indices) into a nested dict/list, the root included."""
    yield prefix
    if isinstance(node, dict):
        for k, v in node.items():
            yield from _paths(v, (*prefix, k))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from _paths(v, (*prefix, i))


def _mutate(doc, data):
    """Apply a few random edits (replace, delete, add a key, wrap in a list) to a study dict."""
    doc = copy.deepcopy(doc)
    for _ in range(data.draw(st.integers(1, 3))):
        paths = [p for p in _paths(doc) if p]
        if not paths or not isinstance(doc, dict):
            break
        path = data.draw(st.sampled_from(paths))
        parent = doc
        for k in path[:-1]:
            parent = parent[k]
        key = path[-1]
        op = data.draw(st.sampled_from(["replace", "replace", "delete", "add", "wrap", "nest"]))
        if op == "replace":
            parent[key] = data.draw(values)
        elif op == "delete":
            del parent[key]
        elif op == "add" and isinstance(parent, dict):
            parent[data.draw(st.text(max_size=10))] = data.draw(values)
        elif op == "wrap":
            parent[key] = [parent[key]]
        elif op == "nest":
            parent[key] = {"value": parent[key]}
    return doc


def _check(text: str) -> None:
    """The contract: a Study, or a one-line StudyError, quickly; never another exception."""
    t0 = time.perf_counter()
    try:
        study = parse_study(text, "fuzz.yaml")
    except GearsweepError as exc:  # StudyError, or GeometryError for an impossible gear pair
        msg = str(exc)
        assert "\r" not in msg, msg
        for line in msg.split("\n"):  # every problem at once, a line each, with its line number
            assert re.match(r"fuzz\.yaml(:\d+)?: ", line), msg
    else:
        assert isinstance(study, Study | MeshStudy)
        if isinstance(study, Study):
            try:
                make_plan(study, text)
            except GearsweepError as exc:
                assert "\n" not in str(exc)
    assert time.perf_counter() - t0 < SECONDS, text[:200]


FUZZ = settings(max_examples=200, deadline=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


@FUZZ
@given(st.text(max_size=300))
def test_random_text(text):
    _check(text)


@FUZZ
@given(st.data())
def test_mutated_studies(data):
    doc = _mutate(data.draw(st.sampled_from(VALID_DICTS)), data)
    _check(yaml.safe_dump(doc, allow_unicode=True))


@FUZZ
@given(st.data())
def test_mutated_text(data):
    text = data.draw(st.sampled_from(VALID))
    for _ in range(data.draw(st.integers(1, 4))):
        i = data.draw(st.integers(0, len(text)))
        op = data.draw(st.sampled_from(["delete", "insert", "swap_lines", "duplicate"]))
        if op == "delete":
            text = text[:i] + text[i + data.draw(st.integers(1, 10)):]
        elif op == "insert":
            ins = data.draw(st.text(max_size=6) | st.sampled_from(
                ["[", "{", ": ", "- ", "&a ", "*a", "!!python/name:os.system ", "\t", "'", "\n"]))
            text = text[:i] + ins + text[i:]
        elif op == "swap_lines":
            lines = text.splitlines()
            if len(lines) > 1:
                j = data.draw(st.integers(0, len(lines) - 2))
                lines[j], lines[j + 1] = lines[j + 1], lines[j]
                text = "\n".join(lines)
        else:
            lines = text.splitlines()
            j = data.draw(st.integers(0, max(len(lines) - 1, 0)))
            text = "\n".join(lines[: j + 1] + lines[j:])
    _check(text)


@pytest.mark.parametrize("text", [
    "[" * 5000,
    "{a: " * 3000,
    "title: t\nscene: &a [*a]\n",
    VALID[0].replace("1000 rpm", "10**10**10 rpm"),
    VALID[0].replace("num: 600", "num: " + "9" * 400),
    VALID[0].replace("5.5 N*s/mm", ".nan"),
    VALID[1].replace("order: 1}", "order: .inf}"),
])
def test_known_hostile_inputs(text):
    """Inputs that crashed or hung the loader before the fuzzer found them."""
    _check(text)
    with pytest.raises(StudyError):
        parse_study(text)


@pytest.mark.parametrize("text", [
    "title: [\n",
    VALID[0].replace("teeth: 48", "teeth: 48.5"),
    VALID[0].replace("1000 rpm", "10**10**10 rpm"),
    "[" * 5000,
])
def test_cli_exits_2_with_one_line(text, tmp_path, capsys):
    path = tmp_path / "bad.yaml"
    path.write_text(text, encoding="utf-8")
    for argv in (["validate", str(path)], ["run", str(path), "-o", str(tmp_path / "o.nc")]):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and err.startswith("gearsweep: error: ")
    assert not (tmp_path / "o.nc").exists()


def test_cli_process_exits_2_with_one_line(tmp_path):
    """The same through a real process: exit code 2, one line on stderr, no traceback."""
    path = tmp_path / "bad.yaml"
    path.write_text(VALID[0].replace("kind: whine", "kind: whale"), encoding="utf-8")
    proc = subprocess.run([sys.executable, "-m", "gearsweep.cli", "run", str(path), "-o",
                           str(tmp_path / "o.nc")], capture_output=True, text=True, timeout=120,
                          cwd=ROOT, env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"})
    assert proc.returncode == 2
    assert proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr
    assert "scene" in proc.stderr and "whale" in proc.stderr


# ------------------------------------------------- issue 26: whole classes, not lists of cases
GEAR_STUDY = (ROOT / "studies" / "whine_gear_table1.yaml").read_text(encoding="utf-8")
NUMERIC_DOCS = VALID_DICTS + [yaml.safe_load(GEAR_STUDY.replace(
    "gear: table1_consistent", "gear: {preset: table1_consistent, x1: 0.1, tip_relief:"
    " {amount: 6 um, start_at: single_contact}}"))]


def _numeric_leaves(doc, path=()):
    """Paths of every numeric value of a study: numbers and numbers with units."""
    if isinstance(doc, dict):
        for k, v in doc.items():
            yield from _numeric_leaves(v, (*path, k))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            yield from _numeric_leaves(v, (*path, i))
    elif isinstance(doc, int | float) and not isinstance(doc, bool):
        yield path
    elif isinstance(doc, str) and re.match(r"^[-+]?\d", doc.strip()):
        yield path


LEAVES = [(i, p) for i, d in enumerate(NUMERIC_DOCS) for p in _numeric_leaves(d)]
NON_FINITE = st.sampled_from([math.nan, math.inf, -math.inf, "nan", "inf", "-inf", ".nan",
                              "nan mm", "inf N", "-inf rpm", "1e999", "1e999 mm", "NaN kg",
                              "inf*2 N*m", "0/0 N"])


def _set(doc, path, value):
    doc = copy.deepcopy(doc)
    node = doc
    for p in path[:-1]:
        node = node[p]
    node[path[-1]] = value
    return doc


@FUZZ
@given(st.sampled_from(LEAVES), NON_FINITE)
def test_non_finite_values_in_every_numeric_field_are_refused(leaf, value):
    """NaN and inf, bare or with units, in any numeric field of any scene: one line per problem,
    exit 2 (never a run that reports them as diverged cases)."""
    i, path = leaf
    text = yaml.safe_dump(_set(NUMERIC_DOCS[i], path, value), allow_unicode=True)
    if isinstance(value, str) and value.startswith("."):
        text = text.replace(f"'{value}'", value)  # YAML's own .nan, not the string
    with pytest.raises(GearsweepError) as err:
        study = parse_study(text, "fuzz.yaml")
        make_plan(study, text)
    for line in str(err.value).split("\n"):
        assert re.match(r"fuzz\.yaml(:\d+)?: ", line), str(err.value)


MALFORMED = st.sampled_from([
    "!!int xyz", "!!float abc", "!!bool maybe", "!!timestamp 2020-99-99", "2020-13-45",
    "!!binary '@@@'", "!!python/object:os.system x", "!!python/name:os.system", "*undefined",
    "&a [*a]", "!!map x", "!!seq x", "!!null x", "!!str [", "'unclosed", '"\\q"', "{a: 1, a: 2}",
    "!!set {a}", "!<tag:yaml.org,2002:int> 1.5", "@reserved", "`reserved", "%directive",
    "!!omap [a]", "? [a]\n  : b", "!!merge x", "<< : 1",
])


@FUZZ
@given(st.sampled_from(LEAVES), MALFORMED)
def test_malformed_yaml_scalars_give_one_line_and_exit_2(leaf, scalar):
    """Every way the YAML loader can fail on a value gives StudyError lines, never a traceback."""
    i, path = leaf
    marker = "REPLACE_ME_0123"
    text = yaml.safe_dump(_set(NUMERIC_DOCS[i], path, marker), allow_unicode=True)
    text = text.replace(marker, scalar)
    _check(text)


@pytest.mark.parametrize("scalar", ["!!int xyz", "2020-13-45", "!!python/object:os.system x",
                                    "*undefined"])
def test_malformed_scalar_through_the_cli(scalar, tmp_path, capsys):
    path = tmp_path / "bad.yaml"
    path.write_text(VALID[0].replace("teeth: 48", f"teeth: {scalar}"), encoding="utf-8")
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and re.match(rf"gearsweep: error: {re.escape(str(path))}:\d+: ", err)


@pytest.mark.parametrize("text", [
    VALID[2] + "outputs: [{spectrum: {max_order: 4, samples_per_period: 1" + "0" * 400 + "}}]\n",
    "type: analysis\ntitle: t\nanalysis: {kind: work_precision, steps_per_period: [8, 16, 8"
    + "0" * 20 + "]}\n",
    "type: analysis\ntitle: t\nanalysis: {kind: artifact_map, rig: r, steps_per_period: [1"
    + "0" * 400 + "]}\n",
])
def test_whole_numbers_beyond_the_steps_a_study_takes_are_one_line(text):
    """A spectrum's samples_per_period of 1e400 ended in OverflowError (a traceback, exit 1), and an
    analysis' steps_per_period of 8e20 was valid until its run ended in numpy's ValueError
    "Maximum allowed size exceeded" (a traceback after `validate` said ok; found by a fuzzer):
    both are bounded by the steps per mesh period a study takes."""
    _check(text)
    with pytest.raises(StudyError, match=r"(samples|steps)_per_period.* less than or equal to"
                                         r" 65536"):
        parse_study(text, "fuzz.yaml")

"""The doc-number checker (scripts/check_claims.py) on a tiny synthetic result, and the shape of
docs/claims.yaml. The real check against results/ runs in the main job."""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
import yaml

ROOT = Path(__file__).resolve().parent.parent
_spec = importlib.util.spec_from_file_location("check_claims", ROOT / "scripts" / "check_claims.py")
cc = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(cc)


@pytest.fixture
def tiny(tmp_path):
    ds = xr.Dataset({"p_rms": ("speed", np.array([1.0, 3.0, 2.0]))},
                    coords={"speed": [100.0, 200.0, 300.0]})
    (tmp_path / "results").mkdir()
    ds.to_netcdf(tmp_path / "results" / "tiny.nc")
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "REPRODUCTION.md").write_text(
        "The response peaks at 200 rpm with an rms of 3.0 um; 1,265 cases.\n")
    return tmp_path


def _claim(**kw):
    base = dict(id="peak", quote="peaks at 200 rpm", value=200, result="results/tiny.nc",
                expr="float(ds.speed[int(ds.p_rms.argmax('speed'))])", abs=0.5)
    base.update(kw)
    return base


def check(root, **kw):
    return cc.check_claim(_claim(**kw), root=root, results=root / "results")


def test_checker_passes_a_true_claim(tiny):
    assert check(tiny) is None
    assert check(tiny, quote="1,265 cases", value=1265, expr="1265.0", abs=0) is None


@pytest.mark.parametrize("change, reason", [
    (dict(value=300, quote="peaks at 200 rpm"), "does not contain"),   # value not in the quote
    (dict(quote="peaks at 250 rpm", value=250), "quote not in"),       # doc says otherwise
    (dict(expr="float(ds.speed.max())"), "gives 300"),                 # result disagrees
    (dict(result="results/missing.nc"), "not found"),                  # result not produced
    (dict(expr="ds.nonexistent"), "failed"),                           # broken expression
    (dict(abs=0, expr="200.4"), "gives 200.4"),                        # outside the tolerance
    (dict(unit="rpm"), "unknown keys"),                                # typo in a key
])
def test_checker_fails_a_false_claim(tiny, change, reason):
    why = check(tiny, **change)
    assert why is not None and reason in why


def test_relative_tolerance(tiny):
    assert check(tiny, expr="201.0", abs=0, rel=0.01) is None
    assert check(tiny, expr="203.0", abs=0, rel=0.01) is not None


def test_claims_file_is_well_formed():
    """Every claim of docs/claims.yaml has the keys, its quote is in its doc and contains its
    value, and its result is written by a study of studies/ or named as a script's output."""
    claims = cc.load_claims(ROOT / "docs" / "claims.yaml")
    assert claims, "docs/claims.yaml has no claims"
    studies = {p.stem for p in (ROOT / "studies").glob("*.yaml")}
    scripts = "".join(p.read_text() for p in (ROOT / "scripts").glob("fig*.py"))
    ids = [c["id"] for c in claims]
    assert len(ids) == len(set(ids)), "claim ids must be unique"
    for c in claims:
        assert not set(c) - cc.KEYS, c
        doc = (ROOT / c.get("doc", "docs/REPRODUCTION.md")).read_text(encoding="utf-8")
        assert c["quote"] in doc, c["id"]
        assert any(np.isclose(x, float(c["value"]), rtol=1e-12, atol=0)
                   for x in cc.numbers_in(c["quote"])), c["id"]
        stem = Path(c["result"]).stem
        assert stem in studies or f'"{stem}.nc"' in scripts or f"{stem}.nc" in scripts, c["id"]
        assert "abs" in c or "rel" in c, f"{c['id']}: give a tolerance"


def test_a_per_figure_claim_whose_quote_lacks_its_value_fails_unless_worded(tmp_path):
    """The per-figure files dropped the check that the quote shows the value, so a claim could
    check a number its quote does not contain (an outside review). Ranges show both ends."""
    assert cc.numbers_in("apart 91-94 % of the time") == [91.0, 94.0]
    assert cc.numbers_in("1,000–4,214 rpm at −3.2e-9") == [1000.0, 4214.0, -3.2e-9]
    (tmp_path / "docs" / "claims").mkdir(parents=True)
    (tmp_path / "docs" / "page.md").write_text("the teeth never separate at 8,030 rpm\n")
    (tmp_path / "results").mkdir()
    xr.Dataset({"x": ("speed", [1.0, 2.0])}).to_netcdf(tmp_path / "results" / "r.nc")

    def run(**claim) -> list[str]:
        base = {"doc": "docs/page.md", "result": "r", "tol": 0}
        path = tmp_path / "docs" / "claims" / "c.yaml"
        path.write_text(yaml.safe_dump([{**base, **claim}]), encoding="utf-8")
        return cc.check_folder(tmp_path / "docs" / "claims", tmp_path / "results", tmp_path)[1]

    assert run(quote="8,030 rpm", expr="8030", value=8030) == []
    assert "does not contain the value 0" in run(quote="never separate", expr="0", value=0)[0]
    assert run(quote="never separate", expr="0", value=0, worded="'never': 0") == []
    assert "gives 1" in run(quote="never separate", expr="1", value=0, worded="'never': 0")[0]


def test_per_figure_claims_are_well_formed_whatever_their_doc():
    """Every claim of docs/claims/*.yaml (mesh.md, rattle.md, precision.md, whine.md... not only
    REPRODUCTION.md's) has its quote in its doc, showing its value unless `worded`, a result a
    study or figure script writes, and a tolerance: CI checks this without results; the main job
    checks the values."""
    studies = {p.stem for p in (ROOT / "studies").glob("*.yaml")}
    scripts = "".join(p.read_text() for p in (ROOT / "scripts").glob("fig*.py"))
    docs: dict = {}
    for path in sorted((ROOT / "docs" / "claims").glob("*.yaml")):
        if path.name == cc.NOT_RESULTS:
            continue
        for i, c in enumerate(yaml.safe_load(path.read_text(encoding="utf-8")) or []):
            cid = f"{path.name}[{i}]"
            assert {"quote", "value", "result", "expr"} <= set(c), cid
            assert not set(c) - {"doc", "quote", "value", "result", "expr", "tol", "scale",
                                 "worded", "note"}, cid
            doc = c.get("doc", "docs/REPRODUCTION.md")
            if doc not in docs:
                docs[doc] = (ROOT / doc).read_text(encoding="utf-8")
            assert c["quote"] in docs[doc], f"{cid}: quote not in {doc}: {c['quote']!r}"
            assert "worded" in c or any(np.isclose(x, float(c["value"]), rtol=1e-12, atol=0)
                                        for x in cc.numbers_in(c["quote"])), cid
            stem = Path(str(c["result"])).stem
            assert stem in studies or f"{stem}.nc" in scripts, f"{cid}: no study writes {stem}"
            assert "tol" in c, f"{cid}: give a tolerance"


def test_a_per_figure_expression_may_use_a_generator(tmp_path):
    """The names reach generator expressions and lambdas of an expression (they are globals)."""
    (tmp_path / "docs" / "claims").mkdir(parents=True)
    (tmp_path / "docs" / "page.md").write_text("at most 2.0 µm\n")
    (tmp_path / "results").mkdir()
    xr.Dataset({"x": ("speed", [1.0, 2.0])}).to_netcdf(tmp_path / "results" / "r.nc")
    claim = {"doc": "docs/page.md", "result": "r", "tol": 0, "quote": "at most 2.0 µm",
             "expr": "max(float(ds.x[i]) * np.ones(1)[0] for i in (0, 1))", "value": 2.0}
    path = tmp_path / "docs" / "claims" / "c.yaml"
    path.write_text(yaml.safe_dump([claim]), encoding="utf-8")
    assert cc.check_folder(tmp_path / "docs" / "claims", tmp_path / "results", tmp_path) == (1, [])


def _main(*argv: str, capsys) -> tuple[int, str, str]:
    rc = cc.main(list(argv))
    got = capsys.readouterr()
    return rc, got.out, got.err


def test_a_per_figure_file_as_claims_is_checked_alone(tmp_path, capsys):
    """``--claims docs/claims/fig05.yaml`` (a list: the per-figure form) crashed with
    AttributeError: 'list' object has no attribute 'get'. It is checked alone, in its form; a
    file in docs/claims.yaml's form (a mapping) still is, with the folder."""
    (tmp_path / "docs" / "claims").mkdir(parents=True)
    (tmp_path / "docs" / "page.md").write_text("at most 2.0 µm, and 3.0 µm\n")
    (tmp_path / "results").mkdir()
    xr.Dataset({"x": ("speed", [1.0, 2.0])}).to_netcdf(tmp_path / "results" / "r.nc")
    fig = tmp_path / "docs" / "claims" / "c.yaml"
    fig.write_text(yaml.safe_dump([{"doc": "docs/page.md", "result": "r", "tol": 0,
                                    "quote": "at most 2.0 µm", "expr": "float(ds.x.max())",
                                    "value": 2.0}]), encoding="utf-8")
    top = tmp_path / "docs" / "claims.yaml"
    top.write_text(yaml.safe_dump({"claims": [{"id": "a", "doc": "docs/page.md", "abs": 0,
                                               "quote": "and 3.0 µm", "value": 3.0,
                                               "result": "results/r.nc",
                                               "expr": "float(ds.x.sum())"}]}), encoding="utf-8")
    where = ("--results", str(tmp_path / "results"), "--root", str(tmp_path))
    rc, out, err = _main("--claims", str(fig), *where, capsys=capsys)
    assert (rc, err) == (0, "") and "== 1 quoted numbers checked against results: all hold" in out
    rc, out, err = _main("--claims", str(top), *where, capsys=capsys)
    assert (rc, err) == (0, "") and "== 2 quoted numbers checked against results: all hold" in out
    with pytest.raises(ValueError, match=r"c\.yaml: a list of per-figure claims"):
        cc.load_claims(fig)


@pytest.mark.parametrize(("text", "says"), [
    ("3\n", (r"line 1: the file holds '3' \(int\); allowed: a mapping with a list of claims"
            r" under 'claims:' \(docs/claims\.yaml\) or a list of per-figure claims")),
    ("claims: 3\n", r"line 1: 'claims' holds '3' \(int\); allowed: a list of mappings"),
    ("# c\nclaims:\n  - {id: a}\n  - 7\n", (r"line 4: 'claims', entry 1 holds '7' \(int\);"
                                           r" allowed: a mapping \(one claim\)")),
    ("- 1\n", r"line 1: the file, entry 0 holds '1' \(int\); allowed: a mapping"),
    ("a: [\n", r"line 2: not YAML"),
])
def test_a_claims_file_of_neither_form_is_refused_in_one_line(tmp_path, capsys, text, says):
    """Exit 2 and one line naming the file, its line, what it holds and what is allowed."""
    path = tmp_path / "bad.yaml"
    path.write_text(text, encoding="utf-8")
    rc, out, err = _main("--claims", str(path), capsys=capsys)
    assert rc == 2 and out == "" and err.count("\n") == 1, err
    assert re.fullmatch(rf"check_claims\.py: error: {re.escape(str(path))}: {says}.*\n", err), err


def test_the_not_results_list_is_no_claims_file(capsys):
    rc, _, err = _main("--claims", str(ROOT / "docs" / "claims" / cc.NOT_RESULTS), capsys=capsys)
    assert rc == 2 and "the list of numbers that are not results, no claims file" in err

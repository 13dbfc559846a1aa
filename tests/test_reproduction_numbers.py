"""Every number written in docs/REPRODUCTION.md and docs/whine.md is accounted for (issue 28 item
11; whine.md since an outside review found five of its result numbers stale, unchecked).

A number is accounted for when it lies inside the quote of a claim whose value it is (a claim of
docs/claims.yaml or docs/claims/*.yaml: scripts/check_claims.py, run by the main job, checks that
value against the result), or inside a quote of docs/claims/not_results.yaml, the reviewed list
of numbers that no result produces (the paper's inputs, study settings, constants of formulas,
figure and equation numbers; an entry names its doc, REPRODUCTION.md by default, and either a
quote or a whole section by its heading, for a section of test measurements or timings). This
test needs no results: it checks coverage only.

Not counted as numbers: inline code spans (`studies/fig05.yaml`), link targets ((mesh.md#...)),
file names and paths (figures/x.png), and digits that are part of a symbol or name (k0, e_1, θ2,
RK5, DOP853), i.e. a number that directly follows a letter or an underscore.
"""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_DOC = "docs/REPRODUCTION.md"
ACCOUNTED = ["docs/REPRODUCTION.md", "docs/whine.md"]
"""The docs every number of which is a claim or a reviewed not-result (the other docs' claims are
checked by scripts/check_claims.py all the same, but a number there may go unclaimed)."""
DOC = ROOT / DEFAULT_DOC
NOT_RESULTS = ROOT / "docs" / "claims" / "not_results.yaml"
WHYS = {"the paper's input", "the paper's text", "study setting", "formula", "figure or section",
        "model setting", "derived from inputs", "tolerance or grid", "reference",
        "not in any result", "test measurement", "timing"}

_spec = importlib.util.spec_from_file_location("check_claims", ROOT / "scripts" / "check_claims.py")
cc = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(cc)

# masked before numbers are read (replaced by blanks, so positions stay those of the doc)
_MASKS = [
    re.compile(r"`[^`\n]*`"),                                # inline code
    re.compile(r"\]\([^)\s]*\)"),                             # link target
    re.compile(r"[\w./-]*[\w-]+\.(?:png|ya?ml|nc|py|md|csv)\b(?:#[\w-]+)?"),  # file names, paths
]


def _masked(text: str) -> str:
    for rx in _MASKS:
        text = rx.sub(lambda m: " " * len(m.group()), text)
    return text


def doc_numbers(text: str, names: list | None = None) -> list[tuple[int, int, float]]:
    """(start, end, value) of every number of ``text`` (NUMBER of scripts/check_claims.py);
    the digits of names (k0, RK5) are skipped, and appended to ``names`` if given."""
    masked = _masked(text)
    out = []
    for m in cc.NUMBER.finditer(masked):
        start, tok = m.start(), m.group().rstrip(",")
        if tok[0] in "+-−":
            # a sign glued to a digit ("1-3", "0.4-0.6") is a range dash: read the number alone
            if start > 0 and (masked[start - 1].isalnum()):
                start, tok = start + 1, tok[1:]
        if start > 0 and (masked[start - 1].isalpha() or masked[start - 1] == "_"):
            if names is not None:
                names.append((start, tok))
            continue                                          # part of a name: k0, e_1, RK5
        try:
            value = float(tok.replace(",", "").replace("−", "-"))
        except ValueError:
            continue
        out.append((start, start + len(tok), value))
    return out


def _spans(text: str, quote: str) -> list[tuple[int, int]]:
    out, i = [], text.find(quote)
    while i >= 0:
        out.append((i, i + len(quote)))
        i = text.find(quote, i + 1)
    return out


def reproduction_claims(doc: str = DEFAULT_DOC) -> list[dict]:
    """Every claim (quote, value) that names ``doc`` (docs/REPRODUCTION.md by default)."""
    claims = [c for c in cc.load_claims(ROOT / "docs" / "claims.yaml")
              if c.get("doc", DEFAULT_DOC) == doc]
    for path in sorted((ROOT / "docs" / "claims").glob("*.yaml")):
        if path == NOT_RESULTS:
            continue
        claims += [c for c in (yaml.safe_load(path.read_text(encoding="utf-8")) or [])
                   if c.get("doc", DEFAULT_DOC) == doc]
    return claims


def not_results(doc: str = DEFAULT_DOC) -> list[dict]:
    """The not-result entries of ``doc``, each with a ``quote``: a section entry's quote is its
    text, from its heading to the next heading of its level or above."""
    text = (ROOT / doc).read_text(encoding="utf-8")
    out = []
    for n in yaml.safe_load(NOT_RESULTS.read_text(encoding="utf-8"))["not_results"]:
        if n.get("doc", DEFAULT_DOC) != doc:
            continue
        if "section" in n:
            n = {**n, "quote": section_text(text, n["section"])}
        out.append(n)
    return out


def section_text(text: str, heading: str) -> str:
    """The text of the section whose heading line is ``heading`` ("## Speed"), up to the next
    heading of its level or above ("" if the doc has no such heading)."""
    level = len(heading) - len(heading.lstrip("#"))
    m = re.search(rf"^{re.escape(heading)}[ \t]*$", text, re.M)
    if not level or m is None:
        return ""
    end = re.compile(rf"^#{{1,{level}}} ", re.M).search(text, m.end())
    return text[m.start():end.start() if end else len(text)]


def _same(a: float, b: float) -> bool:
    return abs(abs(a) - abs(b)) <= 1e-12 * max(1.0, abs(b))


def uncovered(text: str, claims: list[dict], listed: list[dict]) -> list[tuple[int, float]]:
    """(position, value) of each number of ``text`` that no claim and no not-result covers."""
    claim_spans = [(s, e, float(c["value"])) for c in claims for s, e in _spans(text, c["quote"])]
    listed_spans = [span for n in listed for span in _spans(text, n["quote"])]
    out = []
    for start, end, value in doc_numbers(text):
        if any(s <= start and end <= e and _same(value, v) for s, e, v in claim_spans):
            continue
        if any(s <= start and end <= e for s, e in listed_spans):
            continue
        out.append((start, value))
    return out


def test_number_reader():
    text = ("k0 = 219 kN/mm at 1,000 rpm (Figs. 1-3, `studies/fig05.yaml`, figures/x2.png, "
            "[mesh](mesh.md#a-1)); 0.4–0.6, −3.2 %, 1e-135, RK5, e_1, θ2, x = 0.48 / 0.52.")
    got = [(text[s:e], v) for s, e, v in doc_numbers(text)]
    assert got == [("219", 219.0), ("1,000", 1000.0), ("1", 1.0), ("3", 3.0), ("0.4", 0.4),
                   ("0.6", 0.6), ("−3.2", -3.2), ("1e-135", 1e-135), ("0.48", 0.48),
                   ("0.52", 0.52)]


@pytest.mark.parametrize("doc", ACCOUNTED)
def test_no_number_hides_behind_a_letter(doc):
    """Digits glued to a letter are read as a name (k0, θ2, DOP853); a decimal or a long number
    there ("x4.45") would escape the check: write "× 4.45" instead."""
    text = (ROOT / doc).read_text(encoding="utf-8")
    names: list = []
    doc_numbers(text, names)
    bad = [(text.count("\n", 0, pos) + 1, tok) for pos, tok in names
           if not re.fullmatch(r"\d{1,3}", tok)]
    assert not bad, f"numbers glued to a letter (line, token): {bad}"


@pytest.mark.parametrize("doc", ACCOUNTED)
def test_not_results_list_is_well_formed(doc):
    text = (ROOT / doc).read_text(encoding="utf-8")
    entries = not_results(doc)
    quotes = [n["quote"] for n in entries]
    assert len(quotes) == len(set(quotes)), "a not-result quote is listed twice"
    for n in entries:
        assert set(n) - {"doc"} in ({"quote", "why"}, {"quote", "section", "why"}), n
        assert n["why"] in WHYS, f"{n['quote']!r}: why must be one of {sorted(WHYS)}"
        if "section" in n:  # a whole section: of test measurements or timings only
            assert n["quote"], f"no section {n['section']!r} in {doc}"
            assert n["why"] in {"test measurement", "timing"}, n
            continue
        assert n["quote"] in text, f"not-result quote not in the doc: {n['quote']!r}"
        assert doc_numbers(n["quote"]), f"not-result quote without a number: {n['quote']!r}"
        # a quote needs words around its number, so that it cannot cover a result by accident
        assert re.search(r"[^\W\d_]{2,}", _masked(n["quote"])) or len(n["quote"]) >= 12, n


@pytest.mark.parametrize("doc", ACCOUNTED)
def test_claim_quotes_are_on_the_page(doc):
    """Each claim's quote is on the page and its result is written by a study or a figure
    script. (A claim may check a number the quote writes in words, "never separate", "three of
    the four"; such a claim covers no digit, so the coverage test still needs one per digit.)"""
    text = (ROOT / doc).read_text(encoding="utf-8")
    studies = {p.stem for p in (ROOT / "studies").glob("*.yaml")}
    scripts = "".join(p.read_text() for p in (ROOT / "scripts").glob("fig*.py"))
    for c in reproduction_claims(doc):
        assert c["quote"] in text, f"claim quote not in the doc: {c['quote']!r}"
        stem = Path(str(c["result"])).stem
        assert stem in studies or f"{stem}.nc" in scripts, f"{c['quote']!r}: no study writes {stem}"


def test_uncovered_finds_a_number_nobody_checks():
    text = "k0 = 219 kN/mm at 50 N m, and 7 more"
    claims = [{"quote": "k0 = 219 kN/mm", "value": 219}]
    listed = [{"quote": "at 50 N m", "why": "the paper's input"}]
    assert [v for _, v in uncovered(text, claims, listed)] == [7.0]
    # a claim covers only the number it checks, not its neighbours in the quote
    assert [v for _, v in uncovered(text, [{"quote": "219 kN/mm at 50", "value": 219}], [])] \
        == [50.0, 7.0]


@pytest.mark.parametrize("doc", ACCOUNTED)
def test_every_number_is_a_checked_result_or_a_listed_non_result(doc):
    text = (ROOT / doc).read_text(encoding="utf-8")
    missing = uncovered(text, reproduction_claims(doc), not_results(doc))
    lines = []
    for pos, value in missing:
        line = text.count("\n", 0, pos) + 1
        ctx = text[max(0, pos - 40):pos + 40].replace("\n", " ")
        lines.append(f"  line {line}: {value:g}   …{ctx}…")
    assert not missing, (f"{len(missing)} numbers of {doc} are neither checked by "
                         "a claim nor listed in docs/claims/not_results.yaml:\n"
                         + "\n".join(lines))


@pytest.mark.parametrize("doc", ACCOUNTED)
def test_no_number_is_both_a_result_and_a_non_result(doc):
    """A not-result quote must not cover a number that a claim checks as a result there: the
    reviewed list would then hide a result."""
    text = (ROOT / doc).read_text(encoding="utf-8")
    claim_spans = [(s, e, float(c["value"])) for c in reproduction_claims(doc)
                   for s, e in _spans(text, c["quote"])]
    both = []
    for n in not_results(doc):
        for s0, e0 in _spans(text, n["quote"]):
            for start, end, value in doc_numbers(text[s0:e0]):
                a, b = s0 + start, s0 + end
                if any(s <= a and b <= e and _same(value, v) for s, e, v in claim_spans):
                    both.append(f"{value:g} in {n['quote']!r}")
    assert not both, "listed as not a result, but checked as one: " + "; ".join(both)


SYMBOL_VALUE = re.compile(r"([^\W\d]\w*)\s+(?:=|is)\s+(" + cc.NUMBER.pattern + ")", re.IGNORECASE)
"""A "symbol = number" or "symbol is number" of the page (ζ = 0.475, e = 0, α is 6,953)."""


def symbol_values(text: str) -> list[tuple[str, float]]:
    """(symbol, value) of each "symbol = number" or "symbol is number" of ``text`` (outside
    code and file names)."""
    return [(m.group(1), float(m.group(2).replace(",", "").replace("−", "-")))
            for m in SYMBOL_VALUE.finditer(_masked(text))]


def test_section_text():
    text = "# T\n1\n## A\n2\n### B\n3\n## C\n4\n"
    assert section_text(text, "## A") == "## A\n2\n### B\n3\n"
    assert section_text(text, "### B") == "### B\n3\n"
    assert section_text(text, "## C") == "## C\n4\n"
    assert section_text(text, "## D") == ""


def test_symbol_values():
    assert symbol_values("(ζ = 0.475 at k0 = 1,073 kN/mm), teeth (e = 0), α is 6,953") == [
        ("ζ", 0.475), ("k0", 1073.0), ("e", 0.0), ("α", 6953.0)]


@pytest.mark.parametrize("doc", ACCOUNTED)
def test_no_symbol_value_is_a_result_here_and_a_non_result_there(doc):
    """A "symbol = number" that a claim checks as a result somewhere on the page (e = 0 of the
    computed e(t) of unmodified teeth, a ζ from the computed k0) states the same fact wherever
    the page writes it: another occurrence needs a claim too, not a not-result entry."""
    results = {(s, v) for c in reproduction_claims(doc) for s, v in symbol_values(c["quote"])
               if _same(v, float(c["value"]))}
    both = [f"{s} = {v:g} in {n['quote']!r} ({n['why']})" for n in not_results(doc)
            for s, v in symbol_values(n["quote"])
            if any(s == s2 and _same(v, v2) for s2, v2 in results)]
    assert not both, "a claim checks these as results, not_results.yaml lists them: " + "; ".join(both)

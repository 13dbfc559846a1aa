"""Check every number that the docs quote against the result it cites (docs/claims.yaml).

    python scripts/check_claims.py [--claims docs/claims.yaml] [--results results] [--root .]

``--claims`` takes docs/claims.yaml's form (checked with every docs/claims/*.yaml) or one
per-figure file of docs/claims/ (checked alone); any other file is refused with one line, exit 2.

Each claim names a quote (text that must appear verbatim in its doc), the number as quoted, the
result file that produces it and an expression that computes the number from that result; the
check fails when the quote is missing from the doc, the quote does not contain the number, the
result file is missing, or the expression's value differs from the quoted number by more than the
tolerance. The format is written at the top of docs/claims.yaml. The main job
(scripts/main_job.py) runs this after the studies and figure scripts; tests/test_claims.py checks
the checker on a tiny synthetic Dataset.
"""

from __future__ import annotations

import argparse
import builtins
import math
import re
import sys
from pathlib import Path

import numpy as np
import xarray as xr
import yaml

ROOT = Path(__file__).resolve().parent.parent
NOT_RESULTS = "not_results.yaml"  # docs/claims/: numbers no result produces (coverage test only)
KEYS = {"id", "doc", "quote", "value", "result", "expr", "abs", "rel", "note"}
RANGE_DASH = re.compile(r"(?<=\d)[-–](?=\d)")
"""The dash of a range between two numbers ("91-94"), not a minus sign."""
NUMBER = re.compile(r"[-+−]?\d[\d,]*(?:\.\d+)?(?:e[-+−]?\d+)?", re.IGNORECASE)
SAFE_BUILTINS = {name: getattr(builtins, name)
                 for name in ("abs", "bool", "float", "int", "len", "max", "min", "round", "slice",
                              "sum")}


def numbers_in(text: str) -> list[float]:
    """The numbers written in ``text`` ("1,265" -> 1265, "−3.2e-9" -> -3.2e-9; a range "91-94" or
    "1,000–4,214" -> both ends)."""
    out = []
    for tok in NUMBER.findall(RANGE_DASH.sub(" ", text)):
        try:
            out.append(float(tok.replace(",", "").replace("−", "-")))
        except ValueError:
            continue
    return out


def evaluate(expr: str, ds: xr.Dataset) -> float:
    """Value of ``expr`` over the Dataset ``ds`` (names: ds, np, math; a few builtins)."""
    value = eval(expr, {"__builtins__": SAFE_BUILTINS, "np": np, "math": math},  # noqa: S307
                 {"ds": ds})
    return float(np.asarray(value))


def check_claim(claim: dict, *, root: Path, results: Path, cache: dict | None = None,
                docs: dict | None = None) -> str | None:
    """None if the claim holds, else a one-line reason."""
    cache = {} if cache is None else cache
    docs = {} if docs is None else docs
    cid = claim.get("id", claim.get("quote", "?"))
    unknown = set(claim) - KEYS
    if unknown:
        return f"{cid}: unknown keys {sorted(unknown)}"
    for key in ("quote", "value", "result", "expr"):
        if key not in claim:
            return f"{cid}: missing '{key}'"
    doc = root / claim.get("doc", "docs/REPRODUCTION.md")
    if doc not in docs:
        docs[doc] = doc.read_text(encoding="utf-8") if doc.exists() else None
    if docs[doc] is None:
        return f"{cid}: doc {doc} not found"
    quote, value = str(claim["quote"]), float(claim["value"])
    if quote not in docs[doc]:
        return f"{cid}: quote not in {doc.name}: {quote!r}"
    if not any(math.isclose(x, value, rel_tol=1e-12, abs_tol=0.0) for x in numbers_in(quote)):
        return f"{cid}: the quote {quote!r} does not contain the value {value:g}"
    name = str(claim["result"])
    path = results / Path(name).name if name.startswith("results/") else results / name
    if path not in cache:
        cache[path] = xr.open_dataset(path).load() if path.exists() else None
    ds = cache[path]
    if ds is None:
        return f"{cid}: result {path} not found"
    try:
        got = evaluate(str(claim["expr"]), ds)
    except Exception as exc:  # noqa: BLE001  any failure of the expression is a failed claim
        return f"{cid}: expression {claim['expr']!r} failed: {type(exc).__name__}: {exc}"
    tol = float(claim.get("abs", 0.0)) + float(claim.get("rel", 0.0)) * abs(value)
    if not (abs(got - value) <= tol):
        return (f"{cid}: {name} gives {got:.6g} for {claim['expr']!r}, the doc quotes "
                f"{value:g} (tolerance {tol:.3g})")
    return None


class ClaimsFileError(ValueError):
    """A claims file that cannot be read as either format: one line naming the file."""


ALLOWED_FORMS = ("a mapping with a list of claims under 'claims:' (docs/claims.yaml) or a list"
                 " of per-figure claims (docs/claims/*.yaml, docs/claims/README.md)")


def claims_form(path: Path) -> tuple[str, list[dict]]:
    """(``"claims"`` or ``"figure"``, the claims) of the claims file ``path``: docs/claims.yaml's
    form (a mapping, its claims under ``claims:``) or a per-figure file's (a list of claims).
    Anything else raises ``ClaimsFileError`` with one line naming the file and the forms allowed
    (a per-figure file passed as ``--claims`` crashed with AttributeError: 'list' object has no
    attribute 'get')."""
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise ClaimsFileError(f"{path}: cannot read it ({exc.strerror or exc})") from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"line {mark.line + 1}: " if mark is not None else ""
        what = getattr(exc, "problem", None) or type(exc).__name__
        raise ClaimsFileError(f"{path}: {where}not YAML ({what})") from None
    if path.name == NOT_RESULTS:
        raise ClaimsFileError(f"{path}: the list of numbers that are not results, no claims file;"
                              f" allowed: {ALLOWED_FORMS}")
    if data is None:
        return "claims", []
    if isinstance(data, dict):
        form, claims, field = "claims", data.get("claims") or [], "'claims'"
    elif isinstance(data, list):
        form, claims, field = "figure", data, "the file"
    else:
        raise ClaimsFileError(f"{path}: line {_line(text)}: the file holds {str(data)[:40]!r}"
                              f" ({type(data).__name__}); allowed: {ALLOWED_FORMS}")
    if not isinstance(claims, list):
        raise ClaimsFileError(f"{path}: line {_line(text, 'claims')}: 'claims' holds"
                              f" {str(claims)[:40]!r} ({type(claims).__name__}); allowed: a list"
                              " of mappings")
    for i, c in enumerate(claims):
        if not isinstance(c, dict):
            key = "claims" if form == "claims" else None
            raise ClaimsFileError(f"{path}: line {_line(text, key, i)}: {field}, entry {i}"
                                  f" holds {str(c)[:40]!r} ({type(c).__name__}); allowed: a"
                                  " mapping (one claim)")
    return form, claims


def _line(text: str, key: str | None = None, index: int | None = None) -> int:
    """The 1-based line of the YAML ``text``'s top node, or of its mapping's ``key``, or of item
    ``index`` of that list (of the top list without ``key``)."""
    node = yaml.compose(text)
    if key is not None:
        node = next(v for k, v in node.value if k.value == key)
    if index is not None:
        node = node.value[index]
    return node.start_mark.line + 1


def load_claims(path: Path) -> list[dict]:
    """The claims of a claims file in docs/claims.yaml's form (a YAML list under ``claims:``);
    ``ClaimsFileError`` (a ``ValueError``) for a per-figure file or anything else."""
    form, claims = claims_form(path)
    if form != "claims":
        raise ClaimsFileError(f"{path}: a list of per-figure claims, not docs/claims.yaml's form"
                              " (a mapping with 'claims:'); check_files reads it")
    return claims


def check_all(claims_file: Path, results: Path, root: Path = ROOT) -> list[str]:
    """The reasons of every failed claim (empty: all hold)."""
    cache: dict = {}
    docs: dict = {}
    out = []
    for claim in load_claims(claims_file):
        why = check_claim(claim, root=root, results=results, cache=cache, docs=docs)
        if why:
            out.append(why)
    return out


# ---------------------------------------------------------------- docs/claims/*.yaml (per figure)


def _namespace(results: Path, cache: dict):
    """``load(name)`` and the per-result names of docs/claims/README.md."""
    from gearsweep.api import result_model, result_study
    from gearsweep.study.jumps import jump_summary

    def load(name: str) -> xr.Dataset:
        path = results / f"{Path(name).stem if name.endswith('.nc') else name}.nc"
        if path not in cache:
            cache[path] = xr.open_dataset(path).load()
        return cache[path]

    def names(ds: xr.Dataset) -> dict:
        js = jump_summary(ds) if "p_pp" in ds and "direction" in ds.dims else None
        model = result_model(ds) if "model" in ds.attrs else None
        scene = None
        if model is not None:
            scene = getattr(result_study(ds), "scene", None)
        def model_at(**case):  # a swept field of the model, selected (result_model's NaN else)
            return result_model(ds, **case)

        return {"ds": ds, "js": js, "model": model, "model_at": model_at, "scene": scene,
                "load": load}

    return load, names


def check_folder(folder: Path, results: Path, root: Path = ROOT) -> tuple[int, list[str]]:
    """(claims checked, reasons of the failed ones) of every ``folder/*.yaml`` in the
    per-figure format of docs/claims/README.md (``tol``, ``scale``, names ``js``, ``model``...),
    but the list of numbers that are not results (nothing to evaluate)."""
    return check_files([p for p in sorted(folder.glob("*.yaml")) if p.name != NOT_RESULTS],
                       results, root)


def check_files(paths: list[Path], results: Path, root: Path = ROOT) -> tuple[int, list[str]]:
    """``check_folder`` for the per-figure claims files ``paths``."""
    from gearsweep.analysis import hb, linear_response, precision, rattle, sensor, spectrum, stability

    cache: dict = {}
    docs: dict = {}
    load, names = _namespace(results, cache)
    n, out = 0, []
    for path in paths:
        for i, c in enumerate(yaml.safe_load(path.read_text(encoding="utf-8")) or []):
            n += 1
            cid = f"{path.name}[{i}]"
            doc = root / c.get("doc", "docs/REPRODUCTION.md")
            if doc not in docs:
                docs[doc] = doc.read_text(encoding="utf-8") if doc.exists() else ""
            quote, value = str(c["quote"]), float(c["value"])
            if quote not in docs[doc]:
                out.append(f"{cid}: quote not in {doc.name}: {quote!r}")
                continue
            # The quote shows the value (a range "91-94" shows both ends), or says it in words
            # ("never separate": 0), which the claim's `worded` states
            if "worded" not in c and not any(math.isclose(x, value, rel_tol=1e-12, abs_tol=0.0)
                                             for x in numbers_in(quote)):
                out.append(f"{cid}: the quote {quote!r} does not contain the value {value:g}"
                           " (a number said in words: give `worded`)")
                continue
            try:
                env = {"np": np, "math": math, "hb": hb, "linear_response": linear_response,
                       "rattle": rattle, "sensor": sensor,
                       "stability": stability, "spectrum": spectrum, "precision": precision,
                       **names(load(str(c["result"])))}
                # the names as globals: a generator expression or lambda of the expression
                # sees them too ("max(f(n) for n in (1, 2, 3))"), which it does not as locals
                got = float(np.asarray(eval(str(c["expr"]),  # noqa: S307
                                            {"__builtins__": SAFE_BUILTINS, **env})))
            except Exception as exc:  # noqa: BLE001  any failure of the expression fails it
                out.append(f"{cid}: expression {c['expr']!r} failed: {type(exc).__name__}: {exc}")
                continue
            got *= float(c.get("scale", 1.0))
            if not abs(got - value) <= float(c.get("tol", 0.0)):
                out.append(f"{cid}: {c['result']} gives {got:.6g} for {c['expr']!r}, the doc"
                           f" quotes {value:g} (tolerance {c.get('tol', 0)})")
    return n, out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--claims", type=Path, default=ROOT / "docs" / "claims.yaml",
                   help="docs/claims.yaml's form (checked with docs/claims/*.yaml), or one"
                        " per-figure file of docs/claims/ (checked alone)")
    p.add_argument("--results", type=Path, default=ROOT / "results")
    p.add_argument("--root", type=Path, default=ROOT)
    args = p.parse_args(argv)
    try:
        form, claims = claims_form(args.claims)
    except ClaimsFileError as exc:
        print(f"check_claims.py: error: {exc}", file=sys.stderr)
        return 2
    if form == "figure":
        n, failed = check_files([args.claims], args.results, args.root)
    else:
        n = len(claims)
        failed = check_all(args.claims, args.results, args.root)
        folder = args.root / "docs" / "claims"
        if folder.is_dir():
            m, more = check_folder(folder, args.results, args.root)
            n += m
            failed += more
    for why in failed:
        print(f"   FAIL {why}")
    print(f"== {n} quoted numbers checked against results: "
          + (f"{len(failed)} FAILED" if failed else "all hold"), flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

"""The main job: run every study under studies/ (not its subfolders), then every figure script,
then check that the figures docs/REPRODUCTION.md lists were written and that every number
docs/claims.yaml lists is what its result gives (scripts/check_claims.py).

Analysis studies (``type: analysis``) run after the others: some read their results.

    python scripts/main_job.py [--results results] [--figures figures] [--only PATTERN]

Runs in-process on the embedded default (no cluster). A study or figure script that fails is
reported and the others still run; the exit code is 1 if anything failed.
"""

from __future__ import annotations

import argparse
import fnmatch
import os
import re
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def listed_figures() -> list[str]:
    """Figure files named in docs/REPRODUCTION.md."""
    text = (ROOT / "docs" / "REPRODUCTION.md").read_text(encoding="utf-8")
    return sorted(set(re.findall(r"figures/([A-Za-z0-9_.-]+\.png)", text)))


def is_analysis(study: Path) -> bool:
    """An analysis study (``type: analysis``): it may read the results of the others."""
    return re.search(r"^type:\s*analysis\s*$", study.read_text(encoding="utf-8"), re.M) is not None


def check_reproduction(figures: Path, since: float) -> list[str]:
    """Every figure that docs/REPRODUCTION.md lists must have been written by this run."""
    missing = [f for f in listed_figures()
               if not (figures / f).exists() or (figures / f).stat().st_mtime < since - 1]
    print(f"== docs/REPRODUCTION.md lists {len(listed_figures())} figures: "
          + (f"NOT PRODUCED: {', '.join(missing)}" if missing else "all produced by this run"),
          flush=True)
    return [f"REPRODUCTION.md: {f}" for f in missing]


def check_claims(results: Path) -> list[str]:
    """Every number docs/claims.yaml and docs/claims/*.yaml list must be what the result it
    cites gives."""
    from check_claims import check_all, check_folder, load_claims

    claims = ROOT / "docs" / "claims.yaml"
    failed = check_all(claims, results, ROOT)
    n = len(load_claims(claims))
    m, more = check_folder(ROOT / "docs" / "claims", results, ROOT)
    failed += more
    for why in failed:
        print(f"   FAIL {why}", flush=True)
    print(f"== docs/claims.yaml and docs/claims/: {n + m} quoted numbers, "
          + (f"{len(failed)} FAILED" if failed else "all hold"), flush=True)
    return [f"claims: {why}" for why in failed]


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--results", type=Path, default=ROOT / "results")
    p.add_argument("--figures", type=Path, default=ROOT / "figures")
    p.add_argument("--only", default="*", help="glob on study and script names")
    args = p.parse_args()

    from gearsweep.cli import main as gearsweep

    failed: list[str] = []
    t_all = time.perf_counter()
    t_start = time.time()
    studies = sorted((s for s in (ROOT / "studies").glob("*.yaml")
                      if fnmatch.fnmatch(s.stem, args.only)), key=lambda s: (is_analysis(s), s))
    print(f"== {len(studies)} studies", flush=True)
    for study in studies:
        t0 = time.perf_counter()
        out = args.results / f"{study.stem}.nc"
        code = gearsweep(["run", str(study), "-o", str(out), "-q"])
        dt = time.perf_counter() - t0
        print(f"   {'ok  ' if code == 0 else 'FAIL'} {study.name:<40} {dt:7.1f} s", flush=True)
        if code:
            failed.append(study.name)
    scripts = sorted(s for s in (ROOT / "scripts").glob("fig*.py") if fnmatch.fnmatch(s.stem, args.only))
    print(f"== {len(scripts)} figure scripts", flush=True)
    env = dict(os.environ, MPLBACKEND="Agg")
    for script in scripts:
        t0 = time.perf_counter()
        r = subprocess.run([sys.executable, str(script), "--results", str(args.results),
                            "--figures", str(args.figures)], cwd=ROOT, env=env,
                           capture_output=True, text=True)
        dt = time.perf_counter() - t0
        print(f"   {'ok  ' if r.returncode == 0 else 'FAIL'} {script.name:<40} {dt:7.1f} s", flush=True)
        if r.returncode:
            failed.append(script.name)
            print("     " + (r.stderr.strip().splitlines() or ["(no output)"])[-1], flush=True)
    if args.only == "*":
        failed += check_reproduction(args.figures, t_start)
        failed += check_claims(args.results)
    print(f"== done in {time.perf_counter() - t_all:.1f} s; "
          + (f"FAILED: {', '.join(failed)}" if failed else "all ok"), flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

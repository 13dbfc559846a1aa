"""The main job: run every study under studies/ (not its subfolders), then every figure script,
then check that the figures docs/REPRODUCTION.md lists or any doc embeds were written and that every number
docs/claims.yaml lists is what its result gives (scripts/check_claims.py).

Analysis studies (``type: analysis``) run after the others: some read their results.

    python scripts/main_job.py [--results results] [--figures figures] [--only PATTERN]
                               [--jobs N]

The studies run in ``--jobs`` worker processes side by side (default: one per core), each with
cores / jobs kernel threads: on a cold Numba cache most of a study's time is compiling its
kernel specialisations, which Numba does on one core, so the workers compile different
specialisations at once (each has a cache index of its own, ``gearsweep.kernels.rk.Specialised``)
and every later study loads them. Studies that time themselves (``TIMED``) run after the pool,
alone, in this process, with all cores. ``--jobs 1`` runs every study in this process. A study
or figure script that fails is reported and the others still run; the exit code is 1 if anything
failed.
"""

from __future__ import annotations

import argparse
import fnmatch
import os
import re
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from multiprocessing import get_context
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

TIMED = ("work_precision",)
"""Studies whose results hold wall times (work_precision: seconds per case of each method): run
alone, with all cores, after the others."""


def cores() -> int:
    """The cores this process may use."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (
        os.cpu_count() or 1)


def run_study(study: Path, out: Path) -> tuple[int, float]:
    """Run one study with the gearsweep CLI in this process: (exit code, seconds)."""
    from gearsweep.cli import main as gearsweep

    t0 = time.perf_counter()
    # --overwrite: results/STUDY.nc is this job's result of studies/STUDY.yaml, brought up to
    # date with the study's values (a run refuses to replace another study's result without it)
    code = gearsweep(["run", str(study), "-o", str(out), "-q", "--overwrite"])
    return code, time.perf_counter() - t0


def compile_tasks(studies: list[Path]) -> list[tuple[float, Path, list[int]]]:
    """(relative compile cost, study, indices of its ``kernel_calls``) per kernel specialisation
    the analysis studies ``studies`` will use, the costliest first: one task each, so that the
    workers compile different specialisations side by side
    (``gearsweep.kernels.batch.specialisation``, ``compile_cost``)."""
    from gearsweep.kernels.batch import compile_cost, specialisation
    from gearsweep.study.analysis_cost import kernel_calls
    from gearsweep.study.schema import load_study

    tasks = []
    for study in studies:
        groups: dict[tuple, list[int]] = {}
        for i, call in enumerate(kernel_calls(load_study(str(study))[0])):
            groups.setdefault(specialisation(call), []).append(i)
        tasks += [(compile_cost(k), study, idx) for k, idx in groups.items()]
    return sorted(tasks, key=lambda t: -t[0])


def compile_for(study: Path, indices: list[int]) -> tuple[int, float]:
    """Compile (into the disk cache) the kernel calls ``indices`` of an analysis study
    (``gearsweep.study.analysis_cost.kernel_calls``): (0, seconds)."""
    from gearsweep.kernels.batch import precompile
    from gearsweep.study.analysis_cost import kernel_calls
    from gearsweep.study.schema import load_study

    t0 = time.perf_counter()
    calls = kernel_calls(load_study(str(study))[0])
    precompile([calls[i] for i in indices], workers=1)
    return 0, time.perf_counter() - t0


def _worker_threads(threads: int) -> None:
    """Pool initializer: this worker's share of the cores for the kernels (set before Numba is
    imported; with more threads than cores, OpenMP's spinning threads would slow every kernel
    call of the continued sweeps)."""
    os.environ["NUMBA_NUM_THREADS"] = str(threads)


KINK_STUDY_COST = 15.0
"""Relative cold compile cost of a study with kink-aware steps (against ``batch.compile_cost``'s
2.75 and 4.0 for the kink-aware RK4 and RK5 drivers): such a study is started first, beside the
costliest compile tasks, so that the kink-aware compilations (9-14 s each on a cold cache) run
side by side from the start."""


def study_cost(study: Path) -> float:
    """Relative cold compile cost of a plain study: kink-aware steps cost most."""
    text = study.read_text(encoding="utf-8")
    return KINK_STUDY_COST if re.search(r"^\s*kink_aware:\s*true\b", text, re.M) else 0.0


def run_studies(studies: list[Path], results: Path, jobs: int,
                compile_first: list[tuple[float, Path, list[int]]] = ()) -> list[str]:
    """Run ``studies``, ``jobs`` at a time (in this process if 1); print each one's time as it
    ends; return the names of those that failed. ``compile_first``: kernel specialisations of
    analysis studies (``compile_tasks``) that the workers compile beside ``studies``; tasks and
    studies are started costliest compilation first (``study_cost``)."""
    failed = []

    def report(study: Path, code: int, dt: float, what: str = "") -> None:
        name = study.name + what
        print(f"   {'ok  ' if code == 0 else 'FAIL'} {name:<40} {dt:7.1f} s", flush=True)
        if code:
            failed.append(name)

    if jobs <= 1 or len(studies) <= 1:
        for study in studies:
            report(study, *run_study(study, results / f"{study.stem}.nc"))
        return failed
    threads = max(1, cores() // jobs)
    with ProcessPoolExecutor(min(jobs, len(studies)), mp_context=get_context("spawn"),
                             initializer=_worker_threads, initargs=(threads,)) as pool:
        work = [(cost, 0, i) for i, (cost, _, _) in enumerate(compile_first)]
        work += [(study_cost(study), 1, i) for i, study in enumerate(studies)]
        futures = {}
        for _, is_study, i in sorted(work, key=lambda w: (-w[0], w[1], w[2])):  # stable order
            if is_study:
                study = studies[i]
                futures[pool.submit(run_study, study, results / f"{study.stem}.nc")] = (study, "")
            else:
                _, study, idx = compile_first[i]
                futures[pool.submit(compile_for, study, idx)] = (study,
                                                                 f" (compiling {len(idx)})")
        for f in as_completed(futures):
            study, what = futures[f]
            try:
                report(study, *f.result(), what)
            except Exception as exc:  # a worker that died: the study failed, the others go on
                print(f"     {type(exc).__name__}: {exc}", flush=True)
                report(study, 1, float("nan"), what)
    return failed


EMBEDDED_FIGURE = re.compile(r"!\[[^\]]*\]\((?:\.\./)?figures/([A-Za-z0-9_.-]+\.png)\)")
"""A figure a doc embeds: ``![...](figures/x.png)`` (README.md) or ``![...](../figures/x.png)``."""


def doc_pages() -> list[Path]:
    """The docs a reader sees: README.md and docs/*.md."""
    return [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


def embedded_figures() -> dict[str, list[str]]:
    """Each figure file any doc embeds (README.md, docs/*.md), with the docs that embed it."""
    out: dict[str, list[str]] = {}
    for page in doc_pages():
        for name in EMBEDDED_FIGURE.findall(page.read_text(encoding="utf-8")):
            out.setdefault(name, [])
            if page.name not in out[name]:
                out[name].append(page.name)
    return out


def listed_figures() -> list[str]:
    """Figure files named in docs/REPRODUCTION.md and every figure a doc embeds: the main job
    must have written each of them."""
    text = (ROOT / "docs" / "REPRODUCTION.md").read_text(encoding="utf-8")
    return sorted(set(re.findall(r"figures/([A-Za-z0-9_.-]+\.png)", text)) | set(embedded_figures()))


def is_analysis(study: Path) -> bool:
    """An analysis study (``type: analysis``): it may read the results of the others."""
    return re.search(r"^type:\s*analysis\s*$", study.read_text(encoding="utf-8"), re.M) is not None


def check_reproduction(figures: Path, since: float) -> list[str]:
    """Every figure that docs/REPRODUCTION.md lists or any doc embeds must have been written by
    this run."""
    listed = listed_figures()
    missing = [f for f in listed
               if not (figures / f).exists() or (figures / f).stat().st_mtime < since - 1]
    print(f"== docs/REPRODUCTION.md and the docs' images name {len(listed)} figures: "
          + (f"NOT PRODUCED: {', '.join(missing)}" if missing else "all produced by this run"),
          flush=True)
    return [f"figure {f}" for f in missing]


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


FIGURE_PRELOAD = ("matplotlib.pyplot", "xarray", "netCDF4", "gearsweep.plot.common",
                  "gearsweep.plot.sweep", "gearsweep.units")
"""Modules every figure script imports: imported once by the fork server the scripts' processes
are forked from (each script in its own process took 1.5-3.6 s, most of it these imports)."""


def draw_figure(script: Path, results: Path, figures: Path) -> tuple[int, str, float]:
    """Run one figure script as ``python SCRIPT --results R --figures F`` would, in this (fresh,
    forked) process: (exit code, its standard error, seconds). Its standard output is discarded
    as before; the error's traceback goes to the captured standard error."""
    import contextlib
    import io
    import runpy
    import traceback

    t = time.perf_counter()
    err = io.StringIO()
    code = 0
    sys.argv = [str(script), "--results", str(results), "--figures", str(figures)]
    sys.path.insert(0, str(script.parent))
    os.chdir(ROOT)
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        try:
            runpy.run_path(str(script), run_name="__main__")
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
            if not isinstance(exc.code, int | None):  # sys.exit("why"): Python prints the why
                print(exc.code, file=sys.stderr)
        except BaseException:  # noqa: BLE001 - reported like a script that failed
            traceback.print_exc()
            code = 1
    return code, err.getvalue(), time.perf_counter() - t


def draw_figures(scripts: list[Path], results: Path, figures: Path, jobs: int):
    """Run the figure scripts ``jobs`` at a time, each in a process of its own forked from a
    server that has imported what they all import (``FIGURE_PRELOAD``, ``draw_figure``); yield
    (script, exit code, standard error, seconds) as each ends. A process that dies counts as a
    failed script; the others go on."""
    os.environ["MPLBACKEND"] = "Agg"
    ctx = get_context("forkserver")
    ctx.set_forkserver_preload(list(FIGURE_PRELOAD))
    with ProcessPoolExecutor(max(1, jobs), mp_context=ctx, max_tasks_per_child=1) as pool:
        futures = {pool.submit(draw_figure, script, results, figures): script
                   for script in scripts}
        for f in as_completed(futures):
            try:
                code, err, dt = f.result()
            except Exception as exc:  # a worker that died
                code, err, dt = 1, f"{type(exc).__name__}: {exc}", float("nan")
            yield futures[f], code, err, dt


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--results", type=Path, default=ROOT / "results")
    p.add_argument("--figures", type=Path, default=ROOT / "figures")
    p.add_argument("--only", default="*", help="glob on study and script names")
    p.add_argument("--jobs", type=int, default=cores(),
                   help="studies run side by side in worker processes (default: one per core)")
    args = p.parse_args()

    failed: list[str] = []
    t_all = time.perf_counter()
    t_start = time.time()
    studies = sorted(s for s in (ROOT / "studies").glob("*.yaml")
                     if fnmatch.fnmatch(s.stem, args.only))
    timed = [s for s in studies if s.stem in TIMED]
    analysis = [s for s in studies if is_analysis(s) and s not in timed]
    plain = [s for s in studies if s not in analysis and s not in timed]
    print(f"== {len(studies)} studies ({args.jobs} at a time; then {', '.join(s.stem for s in timed)}"
          " alone)" if timed else f"== {len(studies)} studies ({args.jobs} at a time)", flush=True)
    t0 = time.perf_counter()
    failed += run_studies(plain, args.results, args.jobs,
                          compile_tasks([s for s in timed if is_analysis(s)])
                          if args.jobs > 1 else [])
    failed += run_studies(analysis, args.results, args.jobs)  # they may read the others' results
    failed += run_studies(timed, args.results, 1)
    print(f"== studies done in {time.perf_counter() - t0:.1f} s", flush=True)
    scripts = sorted(s for s in (ROOT / "scripts").glob("fig*.py") if fnmatch.fnmatch(s.stem, args.only))
    print(f"== {len(scripts)} figure scripts ({args.jobs} at a time)", flush=True)
    t0 = time.perf_counter()
    for script, code, err, dt in draw_figures(scripts, args.results, args.figures, args.jobs):
        print(f"   {'ok  ' if code == 0 else 'FAIL'} {script.name:<40} {dt:7.1f} s", flush=True)
        if code:
            failed.append(script.name)
            print("     " + (err.strip().splitlines() or ["(no output)"])[-1], flush=True)
    print(f"== figure scripts done in {time.perf_counter() - t0:.1f} s", flush=True)
    if args.only == "*":
        failed += check_reproduction(args.figures, t_start)
        failed += check_claims(args.results)
    print(f"== done in {time.perf_counter() - t_all:.1f} s; "
          + (f"FAILED: {', '.join(failed)}" if failed else "all ok"), flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

"""Command-line interface: ``gearsweep run | validate | advise | inspect``.

Errors that are the user's input (``GearsweepError``) print one line and exit with code 2; a
traceback is shown only with ``--debug``.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

from gearsweep import __version__
from gearsweep.errors import GearsweepError, ResultError, StudyError

EXIT_USAGE = 2


def _default_output(study_path: str) -> Path:
    return Path("results") / (Path(study_path).stem + ".nc")


def _check_writable(path: Path) -> None:
    """Fail before the run, not after it, when the output cannot be written."""
    folder = path.parent if str(path.parent) else Path(".")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise StudyError(str(path), "--output", str(path), f"a writable path ({exc.strerror})"
                         ) from None
    if not os.access(folder, os.W_OK) or (path.exists() and not os.access(path, os.W_OK)):
        raise StudyError(str(path), "--output", str(path), "a writable path (permission denied)")
    if path.is_dir():
        raise StudyError(str(path), "--output", str(path), "a file path, not a folder")


def cmd_validate(args: argparse.Namespace) -> int:
    from gearsweep.study.runner import make_plan
    from gearsweep.study.schema import load_study

    study, text = load_study(args.study)
    if getattr(study, "type", None) == "mesh":
        from gearsweep.study.mesh_runner import summary

        print(f"{args.study}: ok -- {summary(study)}")
        return 0
    plan = make_plan(study, text)
    dims = ", ".join(f"{d}={len(plan.grids[d])}" for d in plan.dims)
    extra = f" x directions {plan.directions}" if plan.continued else ""
    print(f"{args.study}: ok -- scene {study.scene.kind!r}, {plan.n_cases} cases ({dims}{extra}),"
          f" {study.solver.method} at {study.solver.steps_per_period} steps/period,"
          f" outputs {', '.join(plan.outputs)}")
    return 0


def _backend(args: argparse.Namespace):
    from gearsweep.study.execute import DaskBackend, InProcess

    if args.scheduler:
        return DaskBackend(scheduler=args.scheduler)
    if args.workers:
        return DaskBackend(workers=args.workers)
    return InProcess()


def cmd_run(args: argparse.Namespace) -> int:
    import numba

    from gearsweep.kernels.cuda import kernel_for
    from gearsweep.study.execute import (
        check_limits,
        cores,
        estimate,
        lanes_per_chunk,
        measure_rate,
        run_to_file,
    )
    from gearsweep.study.runner import make_plan
    from gearsweep.study.schema import load_study

    study, text = load_study(args.study)
    out = Path(args.output) if args.output else _default_output(args.study)
    if not args.estimate:
        _check_writable(out)
    if getattr(study, "type", None) == "mesh":  # a static mesh study: no integration, no chunks
        from gearsweep.study.dataset import write_netcdf
        from gearsweep.study.runner import run_study

        if args.estimate:
            print(f"{args.study}: a static mesh study, no time integration: about a second")
            return 0
        t0 = time.perf_counter()
        write_netcdf(run_study(study, text), out)
        if not args.quiet:
            print(f"{out}: static mesh study in {time.perf_counter() - t0:.2f} s")
        return 0
    if args.device:  # --device overrides the study's solver.device
        study = study.model_copy(update={"solver": study.solver.model_copy(
            update={"device": args.device})})
    kernel_for(study.solver.device, study.solver.precision)  # no GPU: one line, exit 2, now
    plan = make_plan(study, text)
    if args.chunk_size is not None and args.chunk_size < 1:
        raise StudyError(args.study, "--chunk-size", args.chunk_size, "a positive number of cases")
    if args.workers is not None and args.workers < 1:
        raise StudyError(args.study, "--workers", args.workers, "a positive number of workers")
    chunks = plan.chunks(lanes_per_chunk(plan, args.chunk_size))
    progress = not args.quiet and sys.stderr.isatty()
    with _backend(args) as backend:
        threads = backend.threads if args.scheduler else cores()
        est = estimate(plan, chunks, threads=threads)
        if args.estimate or est.seconds > 30:
            est = estimate(plan, chunks, threads=threads,
                           rate=measure_rate(plan, numba.get_num_threads()))
        if args.estimate:
            print(f"{args.study}: {est.line()}")
            return 0
        if not args.yes:
            check_limits(est, args.study)
        if not args.quiet and est.seconds > 30:
            print(f"{args.study}: {est.line()}", file=sys.stderr)
        t0 = time.perf_counter()
        ds = run_to_file(plan, out, backend=backend, chunk_cases=args.chunk_size,
                         progress=progress)
        n_bad, flagged = _counts(ds)
        if n_bad:
            print(f"gearsweep: warning: {out}: {n_bad} case(s) use a step beyond the stability limit"
                  f" of {study.solver.method} at {study.solver.steps_per_period} steps/period; their"
                  " results may be spoiled by the integrator (variable 'beyond_step_limit'; raise"
                  " solver.steps_per_period or set solver.step_guard: skip)", file=sys.stderr)
    if not args.quiet:
        print(f"{out}: {int(ds.attrs['cases'])} cases in {time.perf_counter() - t0:.2f} s"
              + (f"; {flagged} flagged in 'status' (see its 'codes' attribute)" if flagged
                 else ""))
    ds.close()
    return 0


def _counts(ds) -> tuple[int, int]:
    """(cases beyond the step limit, cases with a nonzero status) of a written result, counted
    block by block in this process (the file's variables are dask arrays)."""
    import dask

    with dask.config.set(scheduler="synchronous"):
        beyond = int(ds["beyond_step_limit"].sum()) if "beyond_step_limit" in ds else 0
        flagged = int((ds["status"] != 0).sum()) if "status" in ds else 0
    return beyond, flagged


def describe(path: str | Path) -> str:
    """A plain-words summary of a result file."""
    import xarray as xr

    path = Path(path)
    try:
        ds = xr.open_dataset(path)
    except (OSError, ValueError) as exc:
        raise ResultError(f"{path}: cannot open as a netCDF result ({exc})") from None
    with ds:
        lines = [f"{path}: {ds.attrs.get('title', '(no title)')}"]
        if ds.attrs.get("scene") == "mesh":
            lines.append(f"  made by {ds.attrs.get('history', '?')}; static mesh study,"
                         f" {ds.attrs.get('positions', '?')} positions per mesh cycle")
        else:
            lines.append(f"  made by {ds.attrs.get('history', '?')}; scene "
                         f"{ds.attrs.get('scene', '?')}, {ds.attrs.get('method', '?')} at "
                         f"{ds.attrs.get('steps_per_period', '?')} steps per mesh period, "
                         f"{ds.attrs.get('transient_periods', '?')} transient + "
                         f"{ds.attrs.get('recorded_periods', '?')} recorded periods")
        lines.append("  swept:")
        for d in ds.dims:
            c = ds[d] if d in ds.coords else None
            if c is not None and c.size and c.dtype.kind in "fi":
                lines.append(f"    {d:<14} {c.size:>6} values from {float(c.min()):.6g} to "
                             f"{float(c.max()):.6g} {c.attrs.get('units', '')}")
            elif c is not None:
                lines.append(f"    {d:<14} {c.size:>6} values: {', '.join(map(str, c.values[:6]))}")
            else:
                lines.append(f"    {d:<14} {ds.sizes[d]:>6}")
        lines.append("  variables:")
        for name, v in ds.data_vars.items():
            rng = ""
            if v.dtype.kind == "f" and v.size:
                vals = v.values
                finite = vals[vals == vals]
                if finite.size:
                    rng = f"  [{finite.min():.4g} .. {finite.max():.4g}]"
            lines.append(f"    {name:<26} {v.attrs.get('units', ''):<6} ({', '.join(v.dims)})"
                         f" {v.attrs.get('long_name', '')}{rng}")
        if "status" in ds:
            st = ds["status"].values
            counts = {int(k): int((st == k).sum()) for k in sorted(set(st.ravel().tolist()))}
            lines.append("  status: " + ", ".join(f"{n} x code {k}" for k, n in counts.items())
                         + f"  ({ds['status'].attrs.get('codes', '')})")
    return "\n".join(lines)


def cmd_advise(args: argparse.Namespace) -> int:
    """Steps per mesh period for a target accuracy, its cost, and stability warnings."""
    from gearsweep.analysis.advise import advise
    from gearsweep.model import MeshModel
    from gearsweep.study.runner import make_plan
    from gearsweep.study.schema import load_study

    study, text = load_study(args.study)
    plan = make_plan(study, text)
    model = plan.model
    if not isinstance(model, MeshModel):
        raise StudyError(args.study, "scene.kind", study.scene.kind,
                         "a gear scene (whine, rattle, full): the Mathieu scene has no accuracy model")
    s = study.solver
    grids = plan.grids
    k0 = float(np.max(grids["stiffness"])) if "stiffness" in grids else model.stiffness
    mass = float(np.min(grids["mass"])) if "mass" in grids else model.mass
    damping = float(np.min(grids["damping"])) if "damping" in grids else model.damping
    backlash = None
    if plan.has_backlash:
        backlash = float(np.min(grids["backlash"])) if "backlash" in grids else model.backlash
    a = advise(mass=mass, k0=k0, damping=damping, speed_rpm=grids["speed"], teeth=model.teeth,
               k_harmonics=[(h.amplitude, h.order, h.phase) for h in model.stiffness_harmonics],
               backlash=backlash, method=s.method, kink_aware=s.kink_aware, target=args.target,
               steps_per_period=s.steps_per_period,
               periods=s.transient_periods + s.record_periods)
    print(f"{args.study}: {a.report()}")
    return 0


def cmd_inspect(args: argparse.Namespace) -> int:
    print(describe(args.result))
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="gearsweep", description=__doc__.splitlines()[0])
    p.add_argument("--version", action="version", version=f"gearsweep {__version__}")
    p.add_argument("--debug", action="store_true", help="show tracebacks")
    sub = p.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run", help="run a study and write its netCDF result")
    r.add_argument("study")
    r.add_argument("-o", "--output", help="result file (default results/STUDY.nc)")
    r.add_argument("-q", "--quiet", action="store_true", help="no progress, no summary")
    where = r.add_mutually_exclusive_group()
    where.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                       help="run the chunks on this existing dask.distributed cluster")
    where.add_argument("--workers", type=int, metavar="N",
                       help="run the chunks on a local dask cluster of N worker processes")
    r.add_argument("--estimate", action="store_true",
                   help="print the estimated time, memory and output size; do not run")
    r.add_argument("--yes", action="store_true",
                   help="run even if the estimate is beyond the limits (10 min, 2 GB)")
    r.add_argument("--device", choices=("cpu", "cuda", "auto"),
                   help="where the kernel runs (overrides solver.device; docs/gpu.md)")
    r.add_argument("--chunk-size", type=int, metavar="CASES",
                   help="about this many cases per chunk (checkpoint and progress unit)")
    r.set_defaults(func=cmd_run)
    v = sub.add_parser("validate", help="check a study file without running it")
    v.add_argument("study")
    v.set_defaults(func=cmd_validate)
    a = sub.add_parser("advise", help="steps per period for a target accuracy, cost, warnings")
    a.add_argument("study")
    a.add_argument("--target", type=float, default=1e-6,
                   help="trajectory error relative to the amplitude (default 1e-6)")
    a.set_defaults(func=cmd_advise)
    i = sub.add_parser("inspect", help="describe a result file in words")
    i.add_argument("result")
    i.set_defaults(func=cmd_inspect)
    return p


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except GearsweepError as exc:
        if args.debug:
            raise
        print(f"gearsweep: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print("gearsweep: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())

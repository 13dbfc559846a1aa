"""The whole run of a study against its kernel, per study size and thread/worker count (JSON lines).

For each size (1e4 ... 1e7 cases: ``studies/heavy/scale_1e6.yaml`` with 1, 10, 100 or 1000 speeds)
and each repeat, in turn, two fresh processes:

* **whole run**: ``python -m gearsweep run STUDY -o OUT.nc -q --yes``, the ``gearsweep``
  command (with ``--workers N`` for the worker counts), timed from before the process starts to
  after it exits; its peak resident memory is the child's ``ru_maxrss`` (``os.wait4``); the
  file's ``kernel_seconds`` and ``elapsed_seconds`` are read back (until 26 Nov 2026, 11:00 UTC,
  the whole run was ``python -m gearsweep.cli``, which imports the CLI as ``__main__`` outside
  ``gearsweep.__main__.entry``'s Ctrl-C guard and collector pause);
* **kernel only**: ``gearsweep.kernels.simulate`` on exactly the chunks the CLI cuts (same cases,
  same kernel inputs, ``--threads`` Numba threads), after the same one-time warm-up, timed around
  ``simulate`` only.

Printed per (size, threads or workers): the medians of the whole run, of the kernel-only time and
of the run's own ``kernel_seconds``, the median of the per-repeat ratios whole / kernel-only and
whole / own kernel time (the latter is free of the machine's drift between the two processes), the
peak memory, the output size, the throughput (cases per second of whole run) and, for workers,
the efficiency = throughput / (N x one worker's throughput) (``efficiency_run``: the same of the
run's own elapsed time, without the interpreter's start and exit; where the list does not start
at one worker, against the first count's throughput per worker, ``efficiency_vs_workers``) and
the ratio to the in-process run. Each worker is one process, and a chunk uses the cores of its
host shared among the workers there: on one machine, N workers together use all its cores,
whatever N. ``--pin`` pins each run
with N workers (and its kernel-only run) to N cores, one per worker, which measures how the
workers scale. The load average is printed with every line: this machine is shared.

    PYTHONPATH=. python scripts/bench_pipeline.py --sizes 1e4,1e5,1e6,1e7 --threads 2 --repeats 3
    PYTHONPATH=. python scripts/bench_pipeline.py --sizes 1e6 --workers 1,2 --repeats 3 [--pin]
    PYTHONPATH=. python scripts/bench_pipeline.py --codecs   # write time and size per codec, 1e6
    PYTHONPATH=. python scripts/bench_pipeline.py --sizes 1e7 --codec none   # runs with --codec
    PYTHONPATH=. python scripts/bench_pipeline.py --gpu-study 1e7   # on a GPU (docs/gpu.md)

A warm Numba cache is assumed (run any study once first); the first line of each size is a
discarded warm-up run unless ``--no-warm-up``.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BASE = ROOT / "studies/heavy/scale_1e6.yaml"
SPEEDS = {1e4: 1, 1e5: 10, 1e6: 100, 1e7: 1000}
"""Speeds of the scale study per size (x 10 torques x 10 dampings x 100 backlashes)."""


def study_file(size: float, folder: Path) -> Path:
    """The scale study with ``size`` cases, written into ``folder``."""
    text = BASE.read_text(encoding="utf-8")
    old = "speed: {start: 2000 rpm, stop: 12000 rpm, num: 100}"
    assert old in text, "the scale study changed: update bench_pipeline.study_file"
    path = folder / f"scale_{size:.0e}.yaml"
    num = SPEEDS[size]  # one speed is a list (a range of one value is refused)
    new = (f"speed: {{start: 2000 rpm, stop: 12000 rpm, num: {num}}}" if num > 1
           else "speed: [2000 rpm]")
    path.write_text(text.replace(old, new), encoding="utf-8")
    return path


def load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def _env(threads: int | None) -> dict:
    """The children's environment: this checkout first on the path (before, not instead of, a
    ``PYTHONPATH`` already set: the device machine's packages live in a folder of their own)."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        p for p in (str(ROOT), os.environ.get("PYTHONPATH", "")) if p))
    if threads:
        env["NUMBA_NUM_THREADS"] = str(threads)
    return env


def whole_run(study: Path, out: Path, threads: int | None, workers: int | None,
              codec: str | None = None, extra: tuple[str, ...] = (),
              cpus: int | None = None) -> dict:
    """One ``gearsweep run`` in a fresh process to a fresh ``out`` (a study's first run; its
    rerun over its own result also reads that file's study first, to refuse replacing another
    study's: 11 ms at 1e6 cases here): wall seconds, peak RSS, the file's timings.
    ``extra``: more arguments of ``gearsweep run``; ``cpus``: the process (and the workers it
    starts) pinned to the first ``cpus`` cores."""
    import xarray as xr

    out.unlink(missing_ok=True)

    cmd = [sys.executable, "-m", "gearsweep", "run", str(study), "-o", str(out), "-q", "--yes",
           *extra]
    if workers:
        cmd += ["--workers", str(workers)]
    if codec:
        cmd += ["--codec", codec]
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, cwd=ROOT, env=_env(threads), preexec_fn=_pin(cpus))
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode:
        raise SystemExit(f"{' '.join(cmd)}: exit {proc.returncode}")
    with xr.open_dataset(out) as ds:
        elapsed = float(ds.attrs["elapsed_seconds"])
        kernel = float(ds.attrs.get("kernel_seconds", "nan"))
    return {"wall": wall, "rss": usage.ru_maxrss * 1024, "size": out.stat().st_size,
            "elapsed": elapsed, "kernel": kernel}


def _pin(cpus: int | None):
    """A ``preexec_fn`` that pins the child to the first ``cpus`` cores of this process's."""
    if not cpus:
        return None
    mine = sorted(os.sched_getaffinity(0))[:cpus]
    return lambda: os.sched_setaffinity(0, mine)


def bare_run(study: Path, threads: int | None, cpus: int | None = None) -> float:
    """Seconds in ``simulate`` over the CLI's chunks of ``study``, in a fresh process."""
    r = subprocess.run([sys.executable, __file__, "--bare", str(study)], check=True, cwd=ROOT,
                       env=_env(threads), capture_output=True, text=True, preexec_fn=_pin(cpus))
    return float(r.stdout.split()[-1])


def bare(study: Path) -> None:
    """Child mode: print the bare kernel's seconds on the study's chunks (as the CLI cuts them
    in-process: with ``--workers`` the CLI cuts about 3 per worker, the same cases in more
    chunks; ``bench_scale.bare_kernel_seconds``, the one timing loop of both scripts)."""
    from bench_scale import bare_kernel_seconds

    from gearsweep.study.estimate import chunk_cases
    from gearsweep.study.execute import chunks_to_run, warm_up
    from gearsweep.study.plan import make_plan
    from gearsweep.study.schema import load_study

    st, text = load_study(str(study))
    plan = make_plan(st, text)
    chunks = chunks_to_run(plan, None, chunk_cases(plan, None)[0])
    warm_up(plan, chunks[0])
    print(bare_kernel_seconds(plan, chunks))


def measure(study: Path, size: float, repeats: int, threads: int | None,
            workers: int | None, tmp: Path, warm: bool, codec: str | None = None,
            cpus: int | None = None) -> dict:
    out = tmp / "out.nc"
    if warm:
        whole_run(study, out, threads, workers, codec, cpus=cpus)
    runs, kernels = [], []
    for _ in range(repeats):
        kernels.append(bare_run(study, threads, cpus))
        runs.append(whole_run(study, out, threads, workers, codec, cpus=cpus))
    med = {k: statistics.median(r[k] for r in runs) for k in runs[0]}
    return {
        "cases": int(size), "threads": threads, "workers": workers or 0, "codec": codec or "default",
        "whole_s": round(med["wall"], 3), "kernel_only_s": round(statistics.median(kernels), 3),
        "ratio": round(statistics.median(r["wall"] / k for r, k in zip(runs, kernels,
                                                                        strict=True)), 3),
        "run_kernel_s": round(med["kernel"], 3), "run_elapsed_s": round(med["elapsed"], 3),
        "ratio_own_kernel": round(statistics.median(r["wall"] / r["kernel"] for r in runs), 3),
        "peak_rss_mb": round(max(r["rss"] for r in runs) / 1e6, 1),
        "output_mb": round(runs[-1]["size"] / 1e6, 2),
        "cases_per_s": round(size / med["wall"]),
        "repeats": repeats, "whole_runs_s": [round(r["wall"], 3) for r in runs],
        "kernel_only_runs_s": [round(k, 3) for k in kernels], "load": load(),
    }


def gpu_study(size: float, tmp: Path, repeats: int, codec: str | None = None) -> None:
    """The scale study of ``size`` cases on the GPU (``--device cuda``): per repeat, after a
    warm-up run that compiles, the whole run's wall time against the run's own kernel seconds
    (``simulate_cuda`` calls: packing, transfers and kernel). One JSON line with the runner's
    GPU chunks (``cuda.CHUNK_STEPS``), one with the whole study in one chunk."""
    study = study_file(size, tmp)
    out = tmp / "gpu.nc"
    for chunking, extra in (("default", ("--device", "cuda")),
                            ("one chunk", ("--device", "cuda", "--chunk-size", str(int(size))))):
        whole_run(study, out, None, None, codec, extra=extra)
        runs = [whole_run(study, out, None, None, codec, extra=extra) for _ in range(repeats)]
        print(json.dumps({
            "cases": int(size), "device": "cuda", "chunks": chunking, "codec": codec or "default",
            "whole_s": round(statistics.median(r["wall"] for r in runs), 3),
            "run_elapsed_s": round(statistics.median(r["elapsed"] for r in runs), 3),
            "run_kernel_s": round(statistics.median(r["kernel"] for r in runs), 3),
            "ratio_own_kernel": round(statistics.median(r["wall"] / r["kernel"] for r in runs), 3),
            "peak_rss_mb": round(max(r["rss"] for r in runs) / 1e6, 1),
            "whole_runs_s": [round(r["wall"], 3) for r in runs], "load": load()}), flush=True)


# ------------------------------------------------------------------------------------ codecs


def codecs(study: Path, tmp: Path, repeats: int) -> None:
    """Write the 1e6-case result chunk by chunk (``ResultFile``, as ``run_to_file`` does) with
    each codec: median wall and CPU seconds of the writes and the close, and the file size."""
    import numpy as np
    import xarray as xr

    from gearsweep.study import filelayout, resultfile
    from gearsweep.study.estimate import chunk_cases
    from gearsweep.study.execute import chunks_to_run
    from gearsweep.study.plan import make_plan
    from gearsweep.study.schema import load_study

    st, text = load_study(str(study))
    plan = make_plan(st, text)
    ref = tmp / "ref.nc"
    subprocess.run([sys.executable, "-m", "gearsweep", "run", str(study), "-o", str(ref),
                    "-q", "--yes"], check=True, cwd=ROOT, env=_env(None))
    with xr.open_dataset(ref) as ds:
        flat = {k: np.asarray(ds[k].values).reshape(plan.n_lanes) for k in
                ("p_rms", "p_pp", "p_max", "p_min", "p_mean", "settle_error",
                 "contact_loss_fraction", "backside_contact_fraction", "impacts_per_period",
                 "beyond_step_limit", "status")}
        flat["beyond_step_limit"] = flat["beyond_step_limit"].astype(bool)
    chunks = chunks_to_run(plan, None, chunk_cases(plan, None)[0])
    level = resultfile.ZSTD_LEVEL
    trials = [(c, s, filelayout.FILE_CHUNK_BYTES, level) for c, s in (
        ("none", False), ("zlib", False), ("zlib", True), ("zstd", False), ("blosc_lz4", True))]
    trials += [("zstd", False, filelayout.FILE_CHUNK_BYTES, 1),
               ("zstd", False, 1 << 20, level), ("zstd", False, 16 << 20, level)]
    default = filelayout.FILE_CHUNK_BYTES
    for codec, shuffle, chunk_bytes, zstd_level in trials:
        walls, cpus = [], []
        filelayout.FILE_CHUNK_BYTES = chunk_bytes
        resultfile.ZSTD_LEVEL = zstd_level
        try:
            for _ in range(repeats):
                out = tmp / f"{codec}_{int(shuffle)}.nc"
                t0, c0 = time.perf_counter(), time.thread_time()
                f = resultfile.ResultFile(plan, out, codec=codec, shuffle=shuffle)
                for a, b in chunks:
                    f.write(a, b, {k: v[a:b] for k, v in flat.items()})
                f.close(1.0, 1.0)
                walls.append(time.perf_counter() - t0)
                cpus.append(time.thread_time() - c0)
        except (RuntimeError, OSError) as exc:  # a filter that refuses the data (blosc)
            print(json.dumps({"codec": codec, "shuffle": shuffle, "error": str(exc)[:80]}))
            continue
        finally:
            filelayout.FILE_CHUNK_BYTES = default
            resultfile.ZSTD_LEVEL = level
        with xr.open_dataset(out) as back, xr.open_dataset(ref) as want:
            same = all(np.array_equal(back[k].values, want[k].values, equal_nan=True)
                       for k in flat)
        print(json.dumps({"codec": codec, "shuffle": shuffle, "file_chunk_mb": chunk_bytes / 2**20,
                          "zstd_level": zstd_level if codec == "zstd" else None,
                          "cases": plan.n_cases,
                          "chunks": len(chunks), "write_s": round(statistics.median(walls), 3),
                          "write_cpu_s": round(statistics.median(cpus), 3),
                          "size_mb": round(out.stat().st_size / 1e6, 2), "data_equal": same,
                          "load": load()}), flush=True)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sizes", default="1e4,1e5,1e6,1e7", help="cases, comma-separated")
    p.add_argument("--threads", default="2", help="Numba threads in-process, comma-separated")
    p.add_argument("--workers", default="", help="--workers counts, comma-separated (in-process"
                   " at the first thread count is measured beside them)")
    p.add_argument("--pin", action="store_true",
                   help="with --workers N: pin the run (and the kernel-only run) to N cores, so"
                        " that the workers' scaling is measured, one core per worker")
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--no-warm-up", action="store_true")
    p.add_argument("--codecs", action="store_true", help="the codec table instead (1e6 cases)")
    p.add_argument("--codec", help="pass --codec CODEC to gearsweep run (default: its default)")
    p.add_argument("--bare", metavar="STUDY", help="child mode: print the bare kernel's seconds")
    p.add_argument("--gpu-study", type=float, metavar="SIZE",
                   help="the scale study of SIZE cases on the GPU instead (docs/gpu.md)")
    args = p.parse_args()
    if args.bare:
        bare(Path(args.bare))
        return
    from bench_scale import byte_compile

    byte_compile()  # byte code as an install has it (bench_scale.byte_compile)
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, text=True,
                            capture_output=True).stdout.strip()
    # GEARSWEEP_DIRECT_IO=0: chunk checkpoints through the page cache (files.DirectFile)
    print(json.dumps({"commit": commit, "date": time.strftime("%Y-%m-%d %H:%M UTC",
                                                             time.gmtime()),
                      "cores": len(os.sched_getaffinity(0)), "load": load(),
                      "direct_io": os.environ.get("GEARSWEEP_DIRECT_IO", "auto")}), flush=True)
    if args.gpu_study:
        with tempfile.TemporaryDirectory() as tmp:
            gpu_study(args.gpu_study, Path(tmp), args.repeats, args.codec)
        return
    sizes = [float(s) for s in args.sizes.split(",") if s]
    threads = [int(t) for t in args.threads.split(",") if t]
    workers = [int(w) for w in args.workers.split(",") if w]
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        if args.codecs:
            codecs(study_file(1e6, tmp), tmp, args.repeats)
            return
        for size in sizes:
            study = study_file(size, tmp)
            base = None
            for t in threads:
                row = measure(study, size, args.repeats, t, None, tmp, not args.no_warm_up,
                              args.codec)
                base = base or row
                print(json.dumps(row), flush=True)
            one = None
            for w in workers:
                cpus = w if args.pin else None
                row = measure(study, size, args.repeats, None, w, tmp, not args.no_warm_up,
                              args.codec, cpus)
                if cpus:
                    row["cpus"] = cpus
                # against the first count measured (one worker, or the fewest where a study
                # is too large for one): throughput per worker over that count's per worker
                one = one or (row, w)
                (first, w0) = one
                row["efficiency_vs_workers"] = w0
                row["efficiency"] = round(row["cases_per_s"] * w0 / (w * first["cases_per_s"]), 3)
                # the same of the run's own elapsed time (no interpreter start or exit)
                row["efficiency_run"] = round(first["run_elapsed_s"] * w0
                                              / (w * row["run_elapsed_s"]), 3)
                if base is not None:
                    row["vs_in_process"] = round(row["whole_s"] / base["whole_s"], 3)
                print(json.dumps(row), flush=True)


if __name__ == "__main__":
    main()

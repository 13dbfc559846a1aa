"""Throughput of a large study run by the CLI against the bare kernel on the same chunks.

For each repeat, in turn, two fresh processes: (1) the bare kernel, ``gearsweep.kernels.simulate``
on exactly the study's chunks (same cases, same kernel inputs, all cores), after the same one-time
warm-up as the CLI's, timed around ``simulate`` only; (2) the study through ``gearsweep run``
(checkpoints, outputs, netCDF), timed three ways: its chunk phase (the file's
``elapsed_seconds``: kernel calls, outputs, checkpoint files), the whole run (process start to
exit) and its peak resident memory. Both are fresh processes so that neither has a warmer cache
or heap than the other; alternating them halves the effect of other load on this shared
machine; medians are printed.

The steadiest figure on a noisy machine is the chunk phase over the time the same run spent in
the kernel (the file's ``kernel_seconds``): both come from one run, so a neighbour's load that
slows the kernel for a second slows both. It misses only what slows the kernel itself within the
study (the background checkpoint writer competing for the cores), which the comparison with the
bare kernel includes.

    PYTHONPATH=. python scripts/bench_scale.py [studies/heavy/scale_1e6.yaml] [--repeats 3]
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import xarray as xr

from gearsweep.kernels import simulate
from gearsweep.model import kernel_inputs
from gearsweep.study.estimate import chunk_cases
from gearsweep.study.execute import chunks_to_run, warm_up
from gearsweep.study.plan import _lane_params, make_plan
from gearsweep.study.schema import load_study

ROOT = Path(__file__).resolve().parents[1]


def byte_compile() -> None:
    """Byte-compile gearsweep's modules (``__pycache__``), as an install does, before timing
    fresh processes: where ``PYTHONDONTWRITEBYTECODE`` is set (this development machine), a
    checkout without them compiled every module's source in every process, 0.1 s of each run
    (a fresh checkout against one with its byte code: 1.94 against 1.84 s for 1e6 cases)."""
    import compileall

    compileall.compile_dir(str(ROOT / "gearsweep"), quiet=1)


def bare_kernel_seconds(plan, chunks: list[tuple[int, int]]) -> float:
    """Seconds spent in ``simulate`` over these chunks of a (non-continued) study."""
    s = plan.study.solver
    total = 0.0
    for a, b in chunks:
        kin = kernel_inputs(plan.model, _lane_params(plan, a, b), b - a, s.steps_per_period,
                            s.divergence_factor, s.initial_displacement, s.initial_velocity)
        with np.errstate(all="ignore"):
            t0 = time.perf_counter()
            simulate(method=s.method, n_transient=s.transient_periods * s.steps_per_period,
                     n_record=s.record_periods * s.steps_per_period,
                     steps_per_period=s.steps_per_period, **kin)
            total += time.perf_counter() - t0
    return total


def bare_run(study: Path) -> float:
    """Seconds in ``simulate`` over the study's chunks, in a fresh process (``--bare``)."""
    r = subprocess.run([sys.executable, __file__, str(study), "--bare"], check=True, cwd=ROOT,
                       env=dict(os.environ, PYTHONPATH=str(ROOT)), capture_output=True, text=True)
    return float(r.stdout.split()[-1])


def study_run(study: Path, out: Path) -> tuple[float, float, float, int, float]:
    """(chunk-phase seconds, wall seconds, peak RSS [bytes], output bytes, kernel seconds) of one
    CLI run."""
    rss_file = out.with_suffix(".rss")
    timer = ["/usr/bin/time", "-f", "%M", "-o", str(rss_file)] if Path("/usr/bin/time").exists() \
        else []
    t0 = time.perf_counter()
    subprocess.run([*timer, sys.executable, "-m", "gearsweep", "run", str(study), "-o",
                    str(out), "-q"], check=True, cwd=ROOT,
                   env=dict(os.environ, PYTHONPATH=str(ROOT)))
    wall = time.perf_counter() - t0
    if timer:
        rss = int(rss_file.read_text().split()[-1]) * 1024  # GNU time: peak RSS in kB
    else:  # largest peak of any child so far (an upper bound of this run's)
        rss = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024
    with xr.open_dataset(out) as ds:
        chunk = float(ds.attrs["elapsed_seconds"])
        kernel = float(ds.attrs["kernel_seconds"])
    return chunk, wall, rss, out.stat().st_size, kernel


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("study", nargs="?", default=str(ROOT / "studies/heavy/scale_1e6.yaml"))
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--bare", action="store_true", help="child mode: print the bare kernel's seconds")
    args = p.parse_args()
    if not args.bare:
        byte_compile()
    study, text = load_study(args.study)
    plan = make_plan(study, text)
    chunks = chunks_to_run(plan, None, chunk_cases(plan, None)[0])  # the CLI's chunks
    if args.bare:
        warm_up(plan, chunks[0])
        print(bare_kernel_seconds(plan, chunks))
        return
    if plan.continued:
        sys.exit("bench_scale compares non-continued studies (one kernel call per chunk)")
    steps = plan.n_cases * plan.steps_per_case
    print(f"{args.study}: {plan.n_cases:,} cases x {plan.steps_per_case} steps = {steps:.3g}"
          f" steps in {len(chunks)} chunks")
    bare, chunk, wall, rss, inrun = [], [], [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "scale.nc"
        for r in range(args.repeats):
            bare.append(bare_run(Path(args.study)))
            c, w, m, size, k = study_run(Path(args.study), out)
            inrun.append(c / k)
            chunk.append(c)
            wall.append(w)
            rss.append(m)
            print(f"  repeat {r}: bare kernel {bare[-1]:.2f} s, study chunks {c:.2f} s"
                  f" (ratio {c / bare[-1]:.3f}; {k:.2f} s of it in the kernel: {c / k:.3f}),"
                  f" study wall {w:.2f} s, peak RSS {m / 1e6:.0f} MB", flush=True)
    mb, mc, mw = (statistics.median(x) for x in (bare, chunk, wall))
    print(f"bare kernel:        {mb:.2f} s  {steps / mb / 1e6:.0f} Msteps/s")
    ratios = [c / b for c, b in zip(chunk, bare, strict=True)]
    print(f"study, chunk phase: {mc:.2f} s  {steps / mc / 1e6:.0f} Msteps/s  (ratio of times to the"
          f" bare kernel's in the same repeat: median {statistics.median(ratios):.3f},"
          f" {min(ratios):.3f} to {max(ratios):.3f})")
    print(f"study, whole run:   {mw:.2f} s  {steps / mw / 1e6:.0f} Msteps/s"
          f" (process start, plan, chunks with the netCDF written beside them, exit)")
    print(f"chunk phase / its own kernel time, same run: median {statistics.median(inrun):.3f}"
          f" ({min(inrun):.3f} to {max(inrun):.3f})")
    print(f"peak RSS {max(rss) / 1e6:.0f} MB, output {size / 1e6:.1f} MB")


if __name__ == "__main__":
    main()

"""Seconds of compiling in the first run of a study on a cold Numba cache (issue 23's target:
<= 10 s on 2 cores), per compiled function, from Numba's own compile events, and the peak
resident memory of that run against a second, warm one.

    PYTHONPATH=. python scripts/bench_compile.py studies/rattle_kink_aware.yaml
    PYTHONPATH=. python scripts/bench_compile.py studies/whine_speed_sweep.yaml --top 5

Runs ``gearsweep run STUDY`` in a child process with a fresh, empty ``NUMBA_CACHE_DIR`` (so the
development cache is untouched) and prints one JSON line: the run's wall time, the seconds spent
compiling (the outermost compilations; nested ones are inside them), the costliest functions
(each with the compilations nested in it), and the peak resident memory of that cold run and of
a second run of the study on the cache the first filled (``peak_rss_mb``, ``warm_peak_rss_mb``:
what compiling adds to a run's memory, ``batch.COLD_COMPILE_BYTES``). An analysis study reads
its inputs beside its output: the results in ``--results`` (default ``results/``) are linked into
the temporary folder the two runs write to.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CHILD = r"""
import collections, json, sys, time
from numba.core import event

stack, own, outer = [], collections.defaultdict(float), [0.0]

class Timing(event.Listener):  # compile events nest: a stack of start times
    def on_start(self, ev):
        stack.append(time.perf_counter())
    def on_end(self, ev):
        seconds = time.perf_counter() - stack.pop()
        d = ev.data.get("dispatcher") if isinstance(ev.data, dict) else None
        own[getattr(getattr(d, "py_func", None), "__qualname__", "?")] += seconds
        if not stack:
            outer[0] += seconds

event.register("numba:compile", Timing())
t0 = time.perf_counter()
from gearsweep.cli import main
code = main(sys.argv[1:])
wall = time.perf_counter() - t0
rss = int(next(ln for ln in open("/proc/self/status") if ln.startswith("VmHWM:")).split()[1]) / 1024
# (VmHWM, this process's own peak: getrusage's ru_maxrss keeps the forking parent's across exec)
print(json.dumps({"rc": code, "wall_s": round(wall, 2), "compile_s": round(outer[0], 2),
                  "peak_rss_mb": round(rss),
                  "functions": {k: round(v, 2) for k, v in sorted(own.items(),
                                                                  key=lambda kv: -kv[1])}}))
"""


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("study")
    p.add_argument("--top", type=int, default=3, help="functions to list (default 3)")
    p.add_argument("--results", default="results",
                   help="folder of the results an analysis study reads (default results/)")
    args = p.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        for f in Path(args.results).glob("*.nc"):
            (Path(tmp) / f.name).symlink_to(f.resolve())
        env = dict(os.environ, NUMBA_CACHE_DIR=str(Path(tmp) / "numba"),
                   PYTHONPATH=os.pathsep.join(x for x in (str(ROOT), os.environ.get(
                       "PYTHONPATH", "")) if x))
        runs = []
        for out in ("cold.nc", "warm.nc"):
            r = subprocess.run([sys.executable, "-c", CHILD, "run", args.study, "-q", "-o",
                                str(Path(tmp) / out)], env=env, capture_output=True, text=True)
            if r.returncode != 0 or not r.stdout.strip():
                print(r.stderr[-2000:], file=sys.stderr)
                return 1
            runs.append(json.loads(r.stdout.strip().splitlines()[-1]))
    out, warm = runs
    out["warm_peak_rss_mb"] = warm["peak_rss_mb"]
    out["functions"] = dict(list(out["functions"].items())[:args.top])
    print(json.dumps({"study": args.study, "load": " ".join(f"{x:.2f}" for x in os.getloadavg()),
                      **out}))
    return 0


if __name__ == "__main__":
    sys.exit(main())

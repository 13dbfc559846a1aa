"""The CUDA kernel's compile against its load from Numba's disk cache, on a GPU.

Runs problem B2 (docs/benchmark.md: RK4, backlash) on the GPU in fresh processes that share one
empty cache folder (``NUMBA_CACHE_DIR``): the first compiles the kernel and writes the cache, the
later ones should load it. Each prints one JSON line: the seconds of importing the backend, of
making the CUDA context, of the first ``simulate_cuda`` call (compile or load, and the run) and
of a second call (the run alone), the kernel's cache hits and misses (numba-cuda's counters), and
a digest of the results, which must be the same in every process.

Usage (on a machine with a CUDA GPU and the cuda extra)::

    PYTHONPATH=. python scripts/bench_gpu_cache.py [--cases 100000] [--processes 3]
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent


def child(cases: int) -> dict:
    t0 = time.perf_counter()
    sys.path.insert(0, str(HERE))
    import numpy as np
    from bench_kernel import case_indices, problem_inputs

    from gearsweep.kernels import cuda as gk

    cu = gk._cuda()
    t1 = time.perf_counter()
    cu.current_context()
    t2 = time.perf_counter()
    inputs = problem_inputs("B2", case_indices(cases))
    first = gk.simulate_cuda(**inputs)
    t3 = time.perf_counter()
    gk.simulate_cuda(**inputs)
    t4 = time.perf_counter()
    kern = gk._kernel(4, True, False, True, False, True, False, "float64")  # B2's terms
    stats = getattr(kern, "stats", None)  # not on the simulator
    digest = hashlib.sha256(np.ascontiguousarray(np.stack(list(first.stats.values())))
                            .tobytes()).hexdigest()[:16]
    return {"cases": cases, "import_s": round(t1 - t0, 3), "context_s": round(t2 - t1, 3),
            "first_call_s": round(t3 - t2, 3), "second_call_s": round(t4 - t3, 3),
            "cache_hits": stats and sum(stats.cache_hits.values()),
            "cache_misses": stats and sum(stats.cache_misses.values()), "digest": digest}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=100_000)
    ap.add_argument("--processes", type=int, default=3)
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        print(json.dumps(child(args.cases)), flush=True)
        return 0
    with tempfile.TemporaryDirectory(prefix="gearsweep-cuda-cache-") as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        digests = set()
        for k in range(args.processes):
            t0 = time.perf_counter()
            proc = subprocess.run([sys.executable, __file__, "--child", "--cases", str(args.cases)],
                                  env=env, capture_output=True, text=True)
            if proc.returncode:
                print(proc.stderr[-2000:], file=sys.stderr)
                return proc.returncode
            row = json.loads(proc.stdout.strip().splitlines()[-1])
            row.update(process=k + 1, whole_s=round(time.perf_counter() - t0, 3))
            digests.add(row["digest"])
            print(json.dumps(row), flush=True)
        print(json.dumps({"same_results": len(digests) == 1}), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

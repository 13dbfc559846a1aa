"""Per-call floor of a small batch on one and on two threads (docs/performance.md, caveats).

    .venv/bin/python scripts/bench_call_floor.py
"""

import argparse

import numba
import numpy as np

from gearsweep.analysis import peers as P

argparse.ArgumentParser(description=__doc__.split("\n\n")[0]).parse_args()  # (--help ran it)
batch = P.whine_batch(1000)
for threads in (1, 2):
    numba.set_num_threads(threads)
    P.run_gearsweep(batch, "rk5", 8, repeat=1)
    ts = 1e3 * np.array([P.run_gearsweep(batch, "rk5", 8, repeat=1).seconds for _ in range(20)])
    print(f"{threads} threads: min {ts.min():.2f} ms median {np.median(ts):.2f} ms "
          f"max {ts.max():.2f} ms")

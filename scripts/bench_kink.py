"""Wall time of the kink-aware kernel against the plain kernel on problem B2 of
docs/benchmark.md (problem B2: 10,000 cases, RK4, 64 steps per mesh period, 200 periods,
backlash 4 um). Prints one JSON line per kernel and the ratio; best of ``--repeat`` runs after a
warm-up (compilation), both kernels timed in the same run, alternating.

``--threads 1`` gave the steadier ratio on a shared virtual machine: with two threads the ratio
moved between 1.50 and 1.76 from one process to the next (24 Nov 2026, same code; within one
process it held to 0.01), with one thread between 1.65 and 1.69 (docs/precision.md)."""

from __future__ import annotations

import argparse
import json
import time

import numba
import numpy as np

from gearsweep.kernels.batch import simulate
from gearsweep.kernels.tables import fourier_table

M, C, K0 = 0.1527, 5500.0, 1.073e9
K_N = (179e6, 40e6, 10e6)
E_N = (5e-6, 1e-6, 0.3e-6)
F, BACKLASH, TEETH = 833.0, 4e-6, 48
SPP, PERIODS = 64, 200


def b2_kwargs(n: int = 10_000) -> dict:
    """Arguments of ``simulate`` for problem B2 with ``n`` cases."""
    rpm = 1000.0 + 19000.0 * np.arange(n) / (n - 1)
    w = TEETH * rpm * 2 * np.pi / 60
    orders = (1, 2, 3)
    ktab = (K0 + fourier_table(K_N, orders, (0, 0, 0), SPP)) / M
    etab = fourier_table(E_N, orders, (0, 0, 0), SPP, derivative=2)  # e'' / W^2
    return dict(h=2 * np.pi / w / SPP, damping=C / M, k_table=ktab, force=F / M,
                ste_scale=-(w**2), ste_table=etab, half_gap=BACKLASH / 2,
                n_transient=SPP * PERIODS // 2, n_record=SPP * PERIODS // 2, steps_per_period=SPP)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--cases", type=int, default=10_000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--threads", type=int, default=None,
                    help="Numba threads (default: all cores)")
    args = ap.parse_args()
    if args.threads is not None:
        numba.set_num_threads(args.threads)
    kw = b2_kwargs(args.cases)
    best = {False: np.inf, True: np.inf}
    res = {}
    for ka in (False, True):
        simulate(**kw, kink_aware=ka)  # warm-up (compiles)
    for _ in range(args.repeat):
        for ka in (False, True):
            t0 = time.perf_counter()
            res[ka] = simulate(**kw, kink_aware=ka)
            best[ka] = min(best[ka], time.perf_counter() - t0)
    steps = args.cases * SPP * PERIODS
    for ka in (False, True):
        r = res[ka]
        amp = np.maximum(np.abs(r.stats["p_max"]), np.abs(r.stats["p_min"]))
        line = {"problem": "B2", "kernel": "kink" if ka else "plain", "seconds": best[ka],
                "msteps_per_s": steps / best[ka] / 1e6, "threads": numba.get_num_threads(),
                "median_amplitude_m": float(np.median(amp))}
        if ka:
            line["substeps_per_step"] = float(r.substeps.sum() / steps)
        print(json.dumps(line))
    amp0 = np.maximum(np.abs(res[False].stats["p_max"]), np.abs(res[False].stats["p_min"]))
    amp1 = np.maximum(np.abs(res[True].stats["p_max"]), np.abs(res[True].stats["p_min"]))
    print(json.dumps({"ratio_kink_over_plain": best[True] / best[False],
                      "max_rel_amplitude_change": float(np.max(np.abs(amp1 - amp0) / amp0))}))


if __name__ == "__main__":
    main()

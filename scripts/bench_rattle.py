"""Timings of the rattle sweeps (issue 6): a Fig. 8 sweep and a 10,000-sweep rattle map.

* Fig. 8: 400 speeds up and 400 down, one lane, RK4, 64 steps per mesh period, 40 transient and
  10 recorded mesh periods per speed.
* Map: 10,000 sweeps (4 backlash x 50 damping x 50 torque) as lanes of one ``simulate`` call per
  speed and direction, 100 speeds each way, same solver settings.

Kernels are warmed up (compiled or loaded from the cache) first; each timing is the median of
``--repeat`` runs. Usage: ``PYTHONPATH=. python scripts/bench_rattle.py [--repeat 3]``
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from gearsweep.analysis import sweep

M, K, B = 0.1527, 1073e6, 0.25e-3
C, F0, FM = 4900.0, 72e3, 50.0 / (0.060 * np.cos(np.radians(20.0)))
SOLVER = dict(steps_per_period=64, transient_periods=40, record_periods=10)


def fig8_sweep() -> tuple[sweep.SweepResult, sweep.SweepResult]:
    speed = np.linspace(5000.0, 11000.0, 400)
    kw = dict(teeth=48, mass=M, stiffness=K, damping=C, half_gap=B, force_mean=FM,
              force_amp=F0, **SOLVER)
    return sweep.sweep(speed, "up", **kw), sweep.sweep(speed, "down", **kw)


def map_sweep() -> tuple[sweep.SweepResult, sweep.SweepResult]:
    speed = np.linspace(5000.0, 11000.0, 100)
    b, c, t = np.meshgrid(np.linspace(0.25e-3, 1e-3, 4), np.geomspace(500.0, 5e4, 50),
                          np.linspace(0.0, 1e4, 50), indexing="ij")
    kw = dict(teeth=48, mass=M, stiffness=K, damping=c.ravel(), half_gap=b.ravel() / 2,
              force_mean=t.ravel() / (0.060 * np.cos(np.radians(20.0))), force_amp=F0,
              **SOLVER)
    return sweep.sweep(speed, "up", **kw), sweep.sweep(speed, "down", **kw)


def timed(fn, repeat: int) -> tuple[float, list[float], object]:
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), times, out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--skip-map", action="store_true")
    args = ap.parse_args()
    t0 = time.perf_counter()
    fig8_sweep()
    print(f"warm-up (compile or cache load + one Fig. 8 sweep): {time.perf_counter() - t0:.2f} s")
    med, times, (up, down) = timed(fig8_sweep, args.repeat)
    settle = max(np.nanmax(up.stats["settle_error"]), np.nanmax(down.stats["settle_error"]))
    print(f"Fig. 8 sweep, 400 speeds up + down: median {med:.3f} s of "
          f"{[round(t, 3) for t in times]}; max settle_error {settle:.3g}")
    if args.skip_map:
        return
    med, times, (up, down) = timed(map_sweep, max(1, min(args.repeat, 2)))
    settle = np.maximum(up.stats["settle_error"], down.stats["settle_error"])
    print(f"rattle map, 10,000 sweeps x 100 speeds up + down: median {med:.1f} s of "
          f"{[round(t, 1) for t in times]}; settle_error > 2%: {np.mean(settle > 0.02):.2%} "
          f"of case-speeds; diverged: {int(up.diverged.sum() + down.diverged.sum())}")


if __name__ == "__main__":
    main()

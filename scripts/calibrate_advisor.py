"""Refit the step advisor's error constants (gearsweep/analysis/data/error_constants.json).

For every method and scene kind, the error model of ``gearsweep.analysis.advise``

    trajectory error <= C (h omega_n max(1, r))^order min(1, (n r / knee)^2),  r = Omega / omega_n

(n: the scene's highest harmonic order, 3 whine, 1 rattle)

is fitted to runs at the calibration speeds, which lie far below, near and above the resonance
(the tests hold out other speeds): for each knee on a grid, C is the upper envelope of the
measured error over the model's shape; the knee kept is the one whose envelope overestimates the
calibration runs least (the smallest geometric mean of predicted over measured error). A maintenance
script, not part of the main job: run it after a change to the kernels.

    python scripts/calibrate_advisor.py [--output FILE]
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import math
from pathlib import Path

import numpy as np
from _common import git_commit

from gearsweep.analysis import advise as adv
from gearsweep.analysis import precision as pr

ROOT = Path(__file__).resolve().parents[1]
FIXED = ("rk4", "rk5", "rk4-kink", "rk5-kink")
SPP = (8, 16, 32, 64, 128, 256, 512, 1024)
SCENES = {"whine": pr.whine_scene, "rattle": pr.rattle_scene}
CALIBRATION_RPM = {
    "whine": (1000.0, *(500.0 * i for i in range(3, 21)), 12000.0, 14000.0, 18370.0, 30000.0),
    "rattle": (1000.0, 3000.0, *(1000.0 * i for i in range(5, 15)), 16000.0, 18000.0, 22000.0,
               30000.0),
}
"""Speeds used to fit the advisor's error constants (the tests hold out other speeds). The
resonance (mesh frequency = omega_n at the largest stiffness) lies at 18,370 rpm whine, 16,680 rpm
rattle, so r = 0.05-1.6 whine, 0.06-1.8 rattle (contact loss from about 7000 rpm). The whine
scene's harmonics (orders up to 3 in stiffness and STE, and their products) resonate at r = 1/n:
its error over (h omega_n)^4 r^2 peaks near 5500 rpm, 19 times its value at 1000 rpm (a 250 rpm
scan, 27 Nov 2026), hence the 500 rpm grid from 1500 to 10000 rpm, which meets that peak."""
KNEES = tuple(round(0.1 + 0.02 * i, 2) for i in range(146))
"""Knees tried (0.1 .. 3.0)."""
ORDER = {"rk4": 4, "rk5": 5}
"""Orders assumed in the advisor's error model (the plain step on the rattle scene: 2)."""


def _split(name: str) -> tuple[str, bool]:
    return name.split("-")[0], name.endswith("-kink")



def fit(points: list[tuple[float, float, float, float]], p: float) -> dict:
    """Knee and C of the model from (error, h omega_n, r, n) tuples: for each knee in ``KNEES``
    the envelope C = max err / shape; the knee kept is the one whose envelope overestimates the
    points least on average (geometric mean of predicted / measured; the largest ratio is set
    by the points far below resonance whatever the knee, since C / knee^2 must cover the
    largest err / ((h omega_n)^p r^2), so it cannot choose)."""
    best = None
    for knee in KNEES:
        ratios = np.array([e / shape(hw, r, n, p, knee) for e, hw, r, n in points])
        over = ratios.max() / ratios
        mean_log = float(np.mean(np.log(over)))
        if best is None or mean_log < best[0]:
            best = (mean_log, {"order": p, "C": float(ratios.max()), "knee": knee,
                               "worst_ratio": float(over.max()),
                               "median_ratio": float(np.median(over)), "points": len(points)})
    return best[1]


def shape(hw: float, r: float, n: float, p: float, knee: float) -> float:
    """The model's error over C (``advise.model_error`` with C = 1)."""
    return adv.model_error(1.0, p, knee, hw, r, n)


def highest_order(scene) -> float:
    """n of the model: the highest order of the scene's stiffness and forcing harmonics (>= 1)."""
    return max(1.0, scene.model().highest_order)


def calibrate(window: pr.Window) -> dict:
    """Fit C and the knee of the error model per method and scene kind over the calibration
    speeds (upper envelope over the points with errors between 1e-10 and 1e-2)."""
    table = {}
    for kind, make in SCENES.items():
        for m in FIXED:
            meth, kink = _split(m)
            if kind == "whine" and kink:
                continue
            p = ORDER[meth] if (kind == "whine" or kink) else 2
            points = []
            for rpm in CALIBRATION_RPM[kind]:
                scene = make(rpm)
                ref = pr.reference(scene, window)
                p_ref = ref(pr.sample_times(scene, window))[0]
                for spp in SPP:
                    hw = scene.period / spp * scene.omega_n
                    r = pr.run_fixed(scene, meth, spp, window, p_ref, kink_aware=kink, copies=1,
                                     repeat=1)
                    e = r.trajectory_error
                    if math.isfinite(e) and 1e-10 < e < 1e-2:
                        points.append((e, hw, scene.omega / scene.omega_n, highest_order(scene)))
            table[f"{kind}/{m}"] = fit(points, p)
    return {
        "description": ("trajectory error <= C (h omega_n max(1, r))^order min(1, (n r / knee)^2),"
                        " r = mesh frequency / omega_n, n = highest harmonic order; C = upper"
                        " envelope over the calibration runs for the knee that overestimates"
                        " them least (geometric mean); worst_ratio, median_ratio: of predicted /"
                        " measured; error relative to the amplitude (see"
                        " gearsweep.analysis.precision)"),
        "source": f"scripts/calibrate_advisor.py, gearsweep {git_commit()}, "
                  f"{dt.datetime.now(dt.UTC).date().isoformat()}",
        "calibration_speeds_rpm": CALIBRATION_RPM,
        "calibration_damping_ratio": calibration_damping_ratio(),
        "window_periods": [window.transient_periods, window.record_periods],
        "constants": table,
    }


def calibration_damping_ratio() -> dict:
    """zeta = c / (2 m omega_n) of the calibration scenes, omega_n at the largest stiffness (as
    ``advise`` takes it): the advisor warns far below it (``advise.LIGHT_DAMPING``)."""
    k_max = {"whine": pr.K0 + sum(abs(a) for a, _, _ in pr.K_HARMONICS), "rattle": pr.K0}
    return {kind: pr.DAMPING / (2.0 * math.sqrt(k * pr.MASS)) for kind, k in k_max.items()}


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--output", type=Path,
                   default=ROOT / "gearsweep" / "analysis" / "data" / "error_constants.json",
                   help="where to write the constants (default: the advisor's own file)")
    args = p.parse_args(argv)  # (--help ran the calibration and rewrote the advisor's file)
    data = calibrate(pr.Window())
    args.output.write_text(json.dumps(data, indent=2) + "\n")
    print(json.dumps(data["constants"], indent=1))


if __name__ == "__main__":
    main()

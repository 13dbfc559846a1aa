"""Refit the step advisor's error constants (gearsweep/analysis/data/error_constants.json).

For every method and scene kind, C in  trajectory error <= C (h omega_n)^order  is the upper
envelope over runs at the calibration speeds (the tests hold out other speeds). A maintenance
script, not part of the main job: run it after a change to the kernels.

    python scripts/calibrate_advisor.py [--output FILE]
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import math
from pathlib import Path

from _common import git_commit

from gearsweep.analysis import precision as pr

ROOT = Path(__file__).resolve().parents[1]
FIXED = ("rk4", "rk5", "rk4-kink", "rk5-kink")
SPP = (8, 16, 32, 64, 128, 256, 512, 1024)
SCENES = {"whine": pr.whine_scene, "rattle": pr.rattle_scene}
CALIBRATION_RPM = {"whine": (3000.0, 4500.0, 9000.0, 12000.0),
                   "rattle": (7000.0, 8000.0, 10000.0, 13000.0)}
"""Speeds used to fit the advisor's error constants (the tests hold out other speeds)."""
ORDER = {"rk4": 4, "rk5": 5}
"""Orders assumed in the advisor's error model (the plain step on the rattle scene: 2)."""


def _split(name: str) -> tuple[str, bool]:
    return name.split("-")[0], name.endswith("-kink")



def calibrate(window: pr.Window) -> dict:
    """Fit C in err <= C (h omega_n)^p per method and scene kind over the calibration speeds
    (upper envelope of err / (h omega_n)^p over the asymptotic points)."""
    table = {}
    for kind, make in SCENES.items():
        for m in FIXED:
            meth, kink = _split(m)
            if kind == "whine" and kink:
                continue
            p = ORDER[meth] if (kind == "whine" or kink) else 2
            ratios = []
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
                        ratios.append(e / hw**p)
            table[f"{kind}/{m}"] = {"order": p, "C": float(max(ratios)),
                                    "points": len(ratios)}
    return {
        "description": "trajectory error <= C (h omega_n)^order, C = upper envelope over the "
                       "calibration runs; error relative to the amplitude (see "
                       "gearsweep.analysis.precision)",
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

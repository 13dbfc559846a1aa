"""Measure the step advice on scenes with strong stiffness variation (docs/precision.md, "Strong
stiffness variation").

The whine scene with one stiffness harmonic k1 = eps k0 (order 1) and one or three STE
harmonics, damped for zeta (at k0 + k1, as ``advise`` takes it). Each case: ``advise`` at its
speed, one run at the advised steps, its trajectory error against DOP853 (rtol 1e-12), and
err / expected against what the advice allows: the warning's factor zeta_cal / zeta where it
warns of light damping, else the safety factor (the target). Speeds where k(t) makes the
equation unstable (Floquet multiplier > 1: warned about, no bound) are drawn again.

    python scripts/check_parametric_advice.py --fit         # the cases PARAMETRIC_REACH came from
    python scripts/check_parametric_advice.py [--seed 11 --cases 48]   # held-out cases
"""

from __future__ import annotations

import argparse
import math
import re

import numpy as np

from gearsweep.analysis import advise as adv
from gearsweep.analysis import precision as pr
from gearsweep.kernels.floquet import floquet, mathieu_parameters
from gearsweep.model import gear_scene, mesh_frequency

TARGETS = {"rk4": (1e-2, 1e-3, 1e-4, 1e-6), "rk5": (1e-2, 1e-4, 1e-6, 1e-8)}
BANDS = ((0.1, 0.35), (0.35, 0.8), (0.8, 1.2), (1.2, 2.2))
"""Bands of r = Omega / omega_n the held-out speeds are drawn from in turn: the harmonics'
resonances (r = 1/j), between, the main resonance, the principal tongue's neighbourhood."""


def measure(eps: float, zeta: float, rpm: float, ste: int, method: str, target: float) -> dict:
    k1 = eps * pr.K0
    c = zeta * 2.0 * math.sqrt((pr.K0 + k1) * pr.MASS)
    f = float(mesh_frequency(rpm, pr.TEETH))
    scene = gear_scene(mass=pr.MASS, damping=c, k0=pr.K0, mesh_frequency=f,
                       k_harmonics=((k1, 1, 0.0),), ste_harmonics=pr.STE_HARMONICS[:ste],
                       force=pr.FORCE)
    mu = float(floquet(*mathieu_parameters(pr.K0, k1, pr.MASS, c, f)).multiplier)
    a = adv.advise(mass=pr.MASS, k0=pr.K0, damping=c, speed_rpm=[rpm], teeth=pr.TEETH,
                   k_harmonics=((k1, 1, 0.0),), highest_order=ste, method=method, target=target)
    w = pr.Window()
    p_ref = pr.reference(scene, w)(pr.sample_times(scene, w))[0]
    err = pr.run_fixed(scene, method, a.steps_per_period, w, p_ref, copies=1,
                       repeat=1).trajectory_error
    said = [m for m in (re.search(r"up to about (\d+) times", x) for x in a.warnings) if m]
    allowed = float(said[0].group(1)) if said else adv.SAFETY
    return dict(eps=eps, zeta=zeta, rpm=rpm, ste=ste, method=method, target=target, mu=mu,
                r=a.ratio, spp=a.steps_per_period, q=err / a.expected_error, allowed=allowed,
                err=err)


def show(i: int, m: dict) -> str:
    ok = "ok" if m["q"] <= m["allowed"] else "OVER"
    return (f"{i:3d} {m['eps']:.3f} {m['zeta']:.4f} {m['rpm']:7.0f} {m['ste']} {m['method']}"
            f" {m['target']:.0e} |mu| {m['mu']:.4f} r {m['r']:.3f}: {m['spp']:4d} steps,"
            f" err/expected {m['q']:6.2f} allowed {m['allowed']:4.0f} {ok},"
            f" err/target {m['err'] / m['target']:.2f}")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--fit", action="store_true", help="the fitting grid instead")
    p.add_argument("--seed", type=int, default=11)
    p.add_argument("--cases", type=int, default=48)
    args = p.parse_args()
    rows = []
    if args.fit:
        for zeta in (0.195, 0.078):
            for eps in np.round(np.arange(0.1, 0.81, 0.1), 2):
                for rpm in (*range(2000, 27001, 1000), 40000, 44000):
                    for method, targets in TARGETS.items():
                        for target in targets:
                            m = measure(float(eps), zeta, float(rpm), 1, method, target)
                            if m["mu"] <= 1.0:
                                rows.append(m)
                worst = max((m for m in rows if m["eps"] == eps and m["zeta"] == zeta),
                            key=lambda m: m["q"] / m["allowed"])
                print(show(len(rows), worst), flush=True)
    else:
        rng = np.random.default_rng(args.seed)
        while len(rows) < args.cases:
            eps = round(float(rng.uniform(0.1, 0.8)), 3)
            zeta = round(float(np.exp(rng.uniform(math.log(0.01), math.log(0.2)))), 4)
            wn = math.sqrt((1.0 + eps) * pr.K0 / pr.MASS)
            r = float(rng.uniform(*BANDS[len(rows) % len(BANDS)]))
            rpm = round(r * wn * 60.0 / (2.0 * math.pi * pr.TEETH))
            ste = int(rng.choice([1, 3]))
            method = str(rng.choice(list(TARGETS)))
            m = measure(eps, zeta, float(rpm), ste, method, float(rng.choice(TARGETS[method])))
            if m["mu"] <= 1.0:
                rows.append(m)
                print(show(len(rows), m), flush=True)
    over = [m["q"] / m["allowed"] for m in rows]
    print(f"{len(rows)} cases: err / allowed up to {max(over):.2f},"
          f" {sum(x > 1 for x in over)} over, {sum(x > adv.SAFETY for x in over)} over twice")


if __name__ == "__main__":
    main()

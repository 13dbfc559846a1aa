"""Stability figures: Fig. 7.1 (Strutt diagrams), Fig. 7.2 (the rig over speed and damping) and
the step limits of the integrators. Standalone: computes with the kernels, writes PNGs.

    PYTHONPATH=. python scripts/fig_stability.py [--figures figures] [--quick]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from gearsweep.analysis import stability as st
from gearsweep.kernels.floquet import floquet
from gearsweep.plot.common import save
from gearsweep.plot.stability import (
    plot_operating_map,
    plot_rig_strutt,
    plot_stability_regions,
    plot_step_limits,
    plot_strutt,
)

K0, K1, M, TEETH = 1073e6, 179e6, 0.1527, 48  # N/m, N/m, kg, teeth of the driving gear
COARSE, FINE, METHOD = 200, 2048, "rk5"

p = argparse.ArgumentParser(description=__doc__)
p.add_argument("--figures", type=Path, default=Path("figures"))
p.add_argument("--results", type=Path, default=Path("results"), help="(unused: computes directly)")
p.add_argument("--quick", action="store_true", help="coarser grids (for a smoke run)")
p.add_argument("--only", nargs="*", default=["7.1", "7.2", "steps"], help="figures to make")
args = p.parse_args()
q = 4 if args.quick else 1


def timed(fn, repeat=3):
    fn()  # warm-up: loads the cached kernels
    ts = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        ts.append(time.perf_counter() - t0)
    return out, float(np.median(ts)), ts


def fig71() -> None:
    # --- Fig. 7.1: classical Strutt diagram, 400 x 400 converged multipliers per panel ------------
    alpha = np.linspace(-0.5, 2.75, 400 // q)
    beta = np.linspace(0.0, 2.5, 400 // q)
    A, B = np.meshgrid(alpha, beta)
    fig, axs = plt.subplots(2, 2, figsize=(11, 9), layout="constrained")
    for ax, gamma in zip(axs[0], (0.0, 0.01), strict=True):
        res, med, ts = timed(lambda g=gamma: floquet(A, B, g))
        print(f"Strutt {A.shape[0]}x{A.shape[1]}, gamma={gamma}: median {med:.2f} s "
              f"(runs {', '.join(f'{t:.2f}' for t in ts)}), converged {res.converged.mean():.4f}, "
              f"steps/period {res.steps_per_period.min()}..{res.steps_per_period.max()}, "
              f"max error {np.nanmax(res.error):.1e}, unstable {res.unstable.mean():.3f}")
        plot_strutt(alpha, beta, res.unstable, ax=ax)
        ax.set_title(rf"(a) classical range, $\gamma$ = {gamma:g}" if gamma == 0 else
                     rf"(b) classical range, $\gamma$ = {gamma:g}", fontsize=9, loc="left")

    # --- Fig. 7.1, rig range: alpha of 100..2000 rpm, beta / alpha up to 1.2 -----------------------
    Nw = lambda rpm: 2 * np.pi * TEETH * np.asarray(rpm) / 60.0  # noqa: E731
    alpha_of_speed = lambda rpm: K0 / (M * np.maximum(Nw(rpm), 1e-9) ** 2)  # noqa: E731
    speed_of_alpha = lambda a: 60.0 / (2 * np.pi * TEETH) * np.sqrt(K0 / (M * np.maximum(a, 1e-9)))  # noqa: E731
    ra = np.geomspace(40.0, 40000.0, 240 // q)
    rr = np.linspace(0.0, 1.2, 160 // q)
    RA, RR = np.meshgrid(ra, rr)
    for ax, gamma, tag in zip(axs[1], (0.0, 0.01), ("(c)", "(d)"), strict=True):
        t0 = time.perf_counter()
        res = floquet(RA, RR * RA, gamma, rtol=1e-7)
        print(f"rig range {RA.shape}, gamma={gamma}: {time.perf_counter() - t0:.1f} s, "
              f"converged {res.converged.mean():.4f}, unstable {res.unstable.mean():.3f}; "
              f"on the rig line ({K1 / K0:.3f}) largest mu - 1 = "
              f"{np.max(floquet(ra, K1 / K0 * ra, gamma, rtol=1e-7).multiplier) - 1:.1e}")
        plot_rig_strutt(ra, rr, res.unstable, ax=ax, gamma=gamma, rig_ratio=K1 / K0,
                        speed_of_alpha=(speed_of_alpha, alpha_of_speed))
        ax.set_title(rf"{tag} the rig's range, $\gamma$ = {gamma:g}", fontsize=9, loc="left")
    fig.suptitle(r"Fig. 7.1  Unstable regions of $p'' + \gamma p' + (\alpha + \beta\cos\tau)p = 0$"
                 " (converged Floquet multipliers, RK5)", fontsize=11)
    print(save(fig, args.figures / "fig7_1_strutt.png"))



def fig72() -> None:
    # --- Fig. 7.2: the rig over speed and damping, four ways --------------------------------------
    speed = np.geomspace(100.0, 2000.0, 192 // q)
    damping = np.concatenate([[0.0], np.geomspace(10.0, 10e3, 60 // q)])  # N s/m
    t0 = time.perf_counter()
    om = st.operating_map(speed, damping, k0=K0, k1=K1, mass=M, teeth=TEETH, method=METHOD,
                          coarse_spp=COARSE, fine_spp=FINE)
    print(f"operating map {om['unstable'].shape}: {time.perf_counter() - t0:.1f} s")
    fl = om["floquet"]
    print(f"  Floquet: unstable {int(om['unstable'].sum())}, largest mu {fl.multiplier.max():.12f}, "
          f"converged {fl.converged.mean():.3f}")
    for key in ("paper_coarse", "paper_fine", "integrator_unstable"):
        print(f"  {key}: {int(om[key].sum())} of {om[key].size}")
    i55 = int(np.argmin(abs(damping - 5500.0)))
    for i in (0, i55):
        ps = speed[om["paper_coarse"][i]]
        iu = speed[om["integrator_unstable"][i]]
        print(f"  c = {damping[i]:.0f} N s/m: paper criterion (S={COARSE}) unstable up to "
              f"{ps.max() if ps.size else float('nan'):.0f} rpm, integrator_unstable up to "
              f"{iu.max() if iu.size else float('nan'):.0f} rpm, guard-rail limit "
              f"{om['limit_speed'][i]:.0f} rpm")
    fig, axs = plt.subplots(2, 2, figsize=(11, 8), layout="constrained", sharex=True, sharey=True)
    plot_operating_map(speed, damping, om["unstable"], ax=axs[0, 0],
                       title="(a) the equation: converged Floquet multiplier > 1 "
                             f"(largest: 1 - {1 - fl.multiplier.max():.1e}, at c = 0)")
    plot_operating_map(speed, damping, om["paper_coarse"], ax=axs[0, 1],
                       limit_speed=om["limit_speed"], label="grows 1000x in 100 periods",
                       title=f"(b) paper's criterion, {METHOD.upper()} at {COARSE} steps per mesh period")
    plot_operating_map(speed, damping, om["paper_fine"], ax=axs[1, 0],
                       label="grows 1000x in 100 periods",
                       title=f"(c) paper's criterion, {METHOD.upper()} at {FINE} steps per mesh period")
    plot_operating_map(speed, damping, om["integrator_unstable"], ax=axs[1, 1],
                       color="#e67e22", limit_speed=om["limit_speed"],
                       label="integrator_unstable",
                       title=f"(d) the integrator is the cause: discrete map at {COARSE} steps "
                             "diverges, equation stable")
    for ax in axs.ravel():
        ax.axhline(5.5, color="0.3", lw=0.8, ls=":")
        ax.annotate("paper's c = 5.5 N s/mm", (speed.max(), 5.5), xytext=(-4, 3),
                    textcoords="offset points", ha="right", fontsize=7, color="0.3")
    fig.suptitle("Fig. 7.2  Stability of the rig versus speed and damping: k0 = 1073 kN/mm, "
                 "k1 = 179 kN/mm, m_eq = 0.1527 kg, 48-tooth driving gear", fontsize=11)
    print(save(fig, args.figures / "fig7_2_speed_damping.png"))



def fig_steps() -> None:
    # --- step limits of the methods: polynomial versus integration --------------------------------
    zc = np.linspace(0.0, 1.6, 321)
    zp = np.array([0.0, 0.02, 0.05, 0.1, 0.2, 0.3, 0.45, 0.6, 0.8, 0.95, 1.2, 1.6])
    pred = {m.upper(): st.step_limit_hw(m, zc) for m in ("rk4", "rk5")}
    t0 = time.perf_counter()
    meas = {m.upper(): st.measured_step_limit(m, zp, n_steps=4_000_000 // q) for m in ("rk4", "rk5")}
    print(f"measured step limits: {time.perf_counter() - t0:.1f} s")
    for m in ("RK4", "RK5"):
        ref = {m.lower(): st.step_limit_hw(m.lower(), zp)}[m.lower()]
        print(f"  {m}: measured / predicted - 1 = "
              + ", ".join(f"{z:g}: {x / r - 1:+.1e}" for z, x, r in zip(zp, meas[m], ref, strict=True)))
    fig, axs = plt.subplots(1, 2, figsize=(11, 4.6), layout="constrained")
    plot_stability_regions({m.upper(): st.stability_polynomial(m) for m in ("rk4", "rk5")},
                           ax=axs[0])
    plot_step_limits(zc, pred, zp, meas, ax=axs[1])
    print(save(fig, args.figures / "stability_step_limits.png"))


for key, fn in (("7.1", fig71), ("7.2", fig72), ("steps", fig_steps)):
    if key in args.only:
        fn()

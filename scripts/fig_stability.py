"""Stability figures: Fig. 7.1 (Strutt diagrams), Fig. 7.2 (the rig over speed and damping), the
Fig. 7.2 artifact map for four fifth-order Runge-Kutta methods, and the integrators' step limits.

    python scripts/fig_stability.py [--results results] [--figures figures] [--only ...]

Every figure draws study results: studies/strutt_mathieu.yaml, stability_rig.yaml and
stability_rig_fine.yaml (Figs. 7.1, 7.2), stability_artifact_map.yaml (the four tableaux) and
method_stability.yaml (the integrators' step limits). Nothing is integrated here; the one thing
evaluated at draw time is Fig. 7.1's reference, the undamped transition curves a_n(q)/4, b_n(q)/4
(scipy's Mathieu characteristic values, closed form, milliseconds: ``plot.stability.plot_strutt``).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
import yaml

from gearsweep import result_model
from gearsweep.plot.common import save
from gearsweep.plot.stability import (
    damping_row,
    plot_artifact_edges,
    plot_operating_map,
    plot_stability_regions,
    plot_step_limits,
    plot_strutt,
)
from gearsweep.units import si_values

p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
p.add_argument("--figures", type=Path, default=Path("figures"))
p.add_argument("--results", type=Path, default=Path("results"))
p.add_argument("--only", nargs="*", default=["7.1", "7.2", "methods", "steps"],
               help="figures to make")
args = p.parse_args()


def _open(name: str) -> xr.Dataset:
    path = args.results / f"{name}.nc"
    if not path.exists():
        raise SystemExit(f"{path} not found: run `gearsweep run studies/{name}.yaml` first")
    return xr.load_dataset(path)


def _scene(ds: xr.Dataset) -> dict:
    """The study text the result keeps (for the rig's k0, k1, m, teeth in titles)."""
    return yaml.safe_load(ds.attrs["study"])


def _blank(ax, flag: np.ndarray, why: str) -> None:
    """Say in the panel why it is empty."""
    if not np.any(flag):
        ax.text(0.5, 0.55, f"nothing flagged in {flag.size} cases:\n{why}", ha="center",
                va="center", transform=ax.transAxes, fontsize=8,
                bbox=dict(fc="white", ec="0.6", alpha=0.9))


def _thin_log_ticks(ax, decades: float = 0.25) -> None:
    """Leave out the speed ticks closer than ``decades`` to the one before (on a narrow panel
    "200" and "300" ran together)."""
    kept: list[float] = []
    for t in ax.get_xticks():
        if not kept or np.log10(t / kept[-1]) >= decades:
            kept.append(float(t))
    ax.set_xticks(kept)


def fig71() -> None:
    ds = _open("strutt_mathieu")
    alpha, beta = ds.alpha.values, ds.beta.values
    fig, axs = plt.subplots(1, 2, figsize=(11, 4.8), layout="constrained")
    for ax, g, tag in zip(axs, ds.gamma.values, "ab", strict=True):
        sel = ds.sel(gamma=g)
        unstable = sel.unstable.transpose("beta", "alpha").values
        plot_strutt(alpha, beta, unstable, ax=ax)
        paper = (sel.status == 1).transpose("beta", "alpha").values
        ax.contour(alpha, beta, paper.astype(float), levels=[0.5], colors="b", linewidths=0.6)
        ax.set_title(f"({tag}) gamma = {g:g}: {int(unstable.sum())} of {unstable.size} unstable "
                     "(Floquet);\nblue: edge of the paper's criterion (status = 1)",
                     fontsize=8, loc="left")
    fig.suptitle(f"Fig. 7.1  {ds.attrs['title']}  (results/strutt_mathieu.nc)", fontsize=10)
    print(save(fig, args.figures / "fig7_1_strutt.png"))


def _limit_speed(ds: xr.Dataset) -> np.ndarray:
    """Per damping, the highest speed at which the guard rail refuses the study's step."""
    spp = int(_scene(ds)["solver"]["steps_per_period"])
    refuse = (ds.min_steps_per_period > spp).transpose("damping", "speed").values
    top = np.where(refuse, ds.speed.values, -np.inf).max(axis=1)
    return np.where(np.isfinite(top), top, np.nan)


def fig72() -> None:
    coarse, fine = _open("stability_rig"), _open("stability_rig_fine")
    spp_c = int(_scene(coarse)["solver"]["steps_per_period"])
    spp_f = int(_scene(fine)["solver"]["steps_per_period"])
    speed, damping = coarse.speed.values, si_values(coarse.damping)  # SI: the plots take N s/m

    def grid(ds, var):
        return ds[var].transpose("damping", "speed").values

    # undamped, a stable Hill equation has |mu| = 1 exactly: 1 - |mu| there is the integration's
    # error, which the result estimates (floquet_error); the title says how the two compare
    undamped = coarse.sel(damping=0.0)
    off = (1.0 - undamped.floquet_multiplier) / undamped.floquet_error
    rig = result_model(coarse)
    zeta_per_damping = 1 / (2 * np.sqrt(rig.stiffness * rig.mass))  # zeta = c / (2 sqrt(k0 m))
    panels = [
        (coarse, grid(coarse, "unstable"), "#c0392b",
         ("(a) the equation: converged Floquet multiplier > 1\n(undamped, |mu| = 1: 1 - |mu| is"
          f" {float(off.min()):.2f}-{float(off.max()):.2f} x its error estimate)"),
         "the equation is stable at every grid point", "unstable"),
        (coarse, grid(coarse, "status") == 1, "#c0392b",
         f"(b) paper's criterion, RK5 at {spp_c} steps per mesh period (status = 1)", "",
         "grows 1000x in 100 periods"),
        (fine, grid(fine, "status") == 1, "#c0392b",
         f"(c) paper's criterion, RK5 at {spp_f} steps per mesh period",
         "the fine step is stable at every speed", "grows 1000x in 100 periods"),
        (coarse, grid(coarse, "integrator_unstable"), "#e67e22",
         (f"(d) this run's cause, the integrator: map at {spp_c} steps diverges, "
          "equation stable"), "", "integrator_unstable"),
    ]
    fig, axs = plt.subplots(2, 2, figsize=(11, 8), layout="constrained", sharex=True, sharey=True)
    limit = _limit_speed(coarse)
    for ax, (ds, flag, color, title, why, label) in zip(axs.ravel(), panels, strict=True):
        plot_operating_map(speed, damping, flag, ax=ax, color=color, title=title, label=label,
                           limit_speed=limit if ds is coarse and "(a)" not in title else None,
                           zeta_per_damping=zeta_per_damping, teeth=rig.teeth)
        if why:
            _blank(ax, flag, why)
        if np.any(flag):  # the lower right held the map's edge at c = 0 and the step limit's
            # undamped end: the middle right is clear of both
            ax.get_legend().set_loc("center right")
        paper = damping_row(damping, 5500.0)
        ax.axhline(paper, color="0.3", lw=0.8, ls=":")
        ax.annotate(f"paper's c = 5.5 N s/mm (ζ = {5500 * zeta_per_damping:.3f})",
                    (speed.max(), paper), xytext=(-4, 3),
                    textcoords="offset points", ha="right", fontsize=7, color="0.3")
    for ax in axs.ravel():  # shared axes, but every labelled axis shows its values
        ax.tick_params(labelleft=True, labelbottom=True)
    sc = _scene(coarse)["scene"]
    fig.suptitle(f"Fig. 7.2  Stability of the rig versus speed and damping: k0 = "
                 f"{sc['stiffness']}, k1 = {sc['stiffness_harmonics'][0]['amplitude']}, "
                 f"m_eq = {sc['mass']}, {sc['teeth']}-tooth driving gear "
                 "(results/stability_rig*.nc)", fontsize=10)
    print(save(fig, args.figures / "fig7_2_speed_damping.png"))


def fig72_methods() -> None:
    """Fig. 7.2 with four fifth-order tableaux, from results/stability_artifact_map.nc."""
    out = _open("stability_artifact_map")
    rig = _open("stability_rig")  # the map is on that study's grid
    teeth = result_model(rig).teeth
    # what the equation does there: the rig's converged Floquet multipliers (the verdict in the
    # title was typed, "stable everywhere", true or not of the result)
    n_floquet, n_grid = int(rig.unstable.sum()), int(rig.unstable.size)
    methods = [str(m) for m in out.method.values]
    spps, damping, speed = out.steps_per_period.values, si_values(out.damping), out.speed.values
    nz = damping > 0
    zeta_per_damping = float(np.median(out.zeta.values[nz] / damping[nz]))  # zeta = c / (2 sqrt(k m))
    for m in methods:
        good = spps[out.reproduces_paper.loc[m].values.astype(bool)]
        print(f"  {m}: real interval {float(out.real_interval.loc[m]):.4f}, imaginary "
              f"{float(out.imaginary_interval.loc[m]):.4f}; reproduces the paper's shape "
              f"for S = {[int(s) for s in good]}")

    fig = plt.figure(figsize=(14, 8.4), layout="constrained")
    gs = fig.add_gridspec(2, 4)
    ax0 = fig.add_subplot(gs[0, 0:2])
    plot_stability_regions({f"{m} (real {out.real_interval.loc[m].item():.2f}, imag "
                            f"{out.imaginary_interval.loc[m].item():.2f})":
                            out.stability_polynomial.loc[m].values for m in methods}, ax=ax0,
                           extent=4.2)
    ax1 = fig.add_subplot(gs[0, 2:4])
    i55 = int(np.argmin(np.abs(damping - 5500.0)))
    plot_artifact_edges(ax1, spps, {m: out.edge_speed.loc[m].isel(damping=i55).values
                                    for m in methods},
                        label="edge of the flagged region at c = 5.5 N s/mm (solid) and at c = 0 "
                              "(dotted)")
    for i, m in enumerate(methods):
        ax1.plot(spps, out.edge_speed.loc[m].isel(damping=0).values, ":", color=f"C{i}")
    j200 = int(np.argmin(np.abs(spps - 200)))
    for k, m in enumerate(methods):
        ax = fig.add_subplot(gs[1, k])
        flag = out.flag.loc[m].isel(steps_per_period=j200).values
        plot_operating_map(speed, damping, flag, ax=ax, label="criterion flags",
                           title=f"{m}, {spps[j200]} steps per mesh period:\n"
                                 + ("the paper's shape" if bool(out.reproduces_paper.loc[m][j200])
                                    else "NOT the paper's shape"),
                           zeta_per_damping=zeta_per_damping, teeth=teeth)
        ax.axhline(damping_row(damping, 5500.0), color="0.3", lw=0.8, ls=":")
        _thin_log_ticks(ax)
    floquet = (f"the equation is stable at all {n_grid} cases of the grid (Floquet,"
               " results/stability_rig.nc): what the criterion flags is the fixed step's artifact"
               if n_floquet == 0 else f"the equation is unstable at {n_floquet} of {n_grid}"
               " cases of the grid (Floquet, results/stability_rig.nc)")
    fig.suptitle("Fig. 7.2 with four fifth-order Runge-Kutta methods: the paper's criterion at a "
                 f"fixed step;\n{floquet}", fontsize=10)
    print(save(fig, args.figures / "fig7_2_methods.png"))


def fig_steps() -> None:
    """Step limits measured by integration (bisection) against the polynomial, from
    results/method_stability.nc."""
    ds = _open("method_stability")
    methods = [str(m) for m in ds.method.values]
    zp = ds.zeta.values
    for m in methods:
        meas = ds.measured_limit.loc[m].values
        pred = np.interp(zp, ds.zeta_curve.values, ds.polynomial_limit.loc[m].values)
        print(f"  {m}: measured / predicted - 1 = "
              + ", ".join(f"{z:g}: {x:+.1e}" for z, x in zip(zp, meas / pred - 1, strict=True)))
    fig, axs = plt.subplots(1, 2, figsize=(11, 4.6), layout="constrained")
    plot_stability_regions({m.upper(): ds.stability_polynomial.loc[m].values for m in methods},
                           ax=axs[0])
    plot_step_limits(ds.zeta_curve.values, {m.upper(): ds.polynomial_limit.loc[m].values
                                            for m in methods},
                     zp, {m.upper(): ds.measured_limit.loc[m].values for m in methods}, ax=axs[1])
    print(save(fig, args.figures / "stability_step_limits.png"))


for key, fn in (("7.1", fig71), ("7.2", fig72), ("methods", fig72_methods), ("steps", fig_steps)):
    if key in args.only:
        fn()

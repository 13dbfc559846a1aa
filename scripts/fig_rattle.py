"""Rattle figures (paper section 6) from the results of the rattle studies.

Reads ``results/fig08_rattle.nc``, the out-of-sample ``results/rattle_table1_pair.nc`` and
``results/rattle_table1_ste_paper_k.nc``, ``results/fig01_02_mesh_cycle.nc`` (the pair's STE)
and ``results/rattle_map.nc`` (``gearsweep run studies/<name>.yaml``), computes the harmonic
balances of the Fig. 8 scene from the study text stored in the result, and writes
``figures/fig08_rattle.png``, ``fig08_out_of_sample.png``, ``fig09_graphical.png`` and
``rattle_map.png``; prints the jump speeds, turning points and the distance of Eq. (15) from the
integration. The Fig. 12 counterpart is ``scripts/fig12_rig.py`` (the rig's regime).
"""

import math
import time

import numpy as np
from _common import open_result, parse

from gearsweep.analysis import hb
from gearsweep.analysis import rattle as rfit
from gearsweep.api import result_model
from gearsweep.model import RPM
from gearsweep.plot import rattle as rplot
from gearsweep.plot.common import plt, save
from gearsweep.plot.sweep import settled, speed_label
from gearsweep.study.jumps import jump_summary


def scene(ds):
    """The MeshModel of a result's study (SI values) and rpm -> mesh rad/s factor."""
    model = result_model(ds)
    return model, model.teeth * RPM


def zeta(c: float, model) -> float:
    """Damping ratio c / (2 sqrt(k m)) of the mesh."""
    return c / (2.0 * math.sqrt(model.stiffness * model.mass))


def amplitude_grid(b: float, top: float) -> np.ndarray:
    """Amplitudes for the describing-function curve: dense just above b (grazing)."""
    return np.unique(np.r_[np.linspace(0.005 * b, 0.9999 * b, 400),
                           b * (1 + np.geomspace(1e-8, top / b - 1, 4000))])


def fig8(ds, figures):
    model, w_per_rpm = scene(ds)
    b = model.backlash / 2
    (fh,) = model.force_harmonics
    f0 = fh.amplitude
    w_per_rpm *= fh.order
    speed = ds["speed"].values
    amp, n_bad, n_all = settled(0.5 * ds["p_pp"], ds)
    common = dict(mass=model.mass, stiffness=model.stiffness, damping=model.damping,
                  half_gap=b, force_amp=f0)
    df = hb.df_curve(amplitude_grid(b, 3 * b), force_mean=model.mean_force, **common)
    df0 = hb.df_curve(amplitude_grid(b, 3 * b), force_mean=0.0, **common)
    system = hb.MeshSystem(mass=model.mass, stiffness=model.stiffness, damping=model.damping,
                           half_gap=b, force_mean=model.mean_force, force_harmonics=(f0,))
    t0 = time.perf_counter()
    aft = hb.aft_continuation(system, speed[0] * w_per_rpm, speed[-1] * w_per_rpm,
                              harmonics=25, n_time=1024)
    t_aft = time.perf_counter() - t0
    js = jump_summary(ds)
    up_jump, down_jump = float(js.jump_up_speed), float(js.jump_down_speed)
    # the paper's (o): Eq. (15), undamped, no mean force, every root, on a 50 rpm grid
    sp15 = np.arange(speed[0], speed[-1] + 1.0, 50.0)
    r15 = hb.eq15_roots(sp15 * w_per_rpm, f0, model.stiffness, model.mass, b)
    eq15 = {"speed": np.repeat(sp15, 3).reshape(-1, 3)[np.isfinite(r15)],
            "amplitude": np.abs(r15[np.isfinite(r15)]),
            "label": "Eq. (15), undamped (the paper's o), every root"}
    dist = {d: rfit.eq15_distance(speed, amp.sel(direction=d).values, omega_per_rpm=w_per_rpm,
                                  force_amp=f0, stiffness=model.stiffness, mass=model.mass,
                                  half_gap=b) for d in ("up", "down")}
    upper = dist["up"].relative[speed < down_jump]
    lower = dist["down"].relative[speed > dist["down"].rise_eq15]
    fig, (ax, ax2) = plt.subplots(2, 1, figsize=(8, 8), sharex=True,
                                  gridspec_kw={"height_ratios": [3, 1.2]})
    curves = [
        {"speed": df0.omega / w_per_rpm, "amplitude": df0.amplitude, "stable": df0.stable,
         "label": "describing fn. A, F_m = 0", "color": "0.6", "lw": 1.0},
        {"speed": df.omega / w_per_rpm, "amplitude": df.amplitude, "stable": df.stable,
         "label": "describing fn., first-harmonic A", "color": "k"},
        {"speed": aft.omega / w_per_rpm, "amplitude": aft.amplitude, "stable": aft.stable,
         "label": "AFT harmonic balance (25 harm.), Floquet", "color": "tab:green"},
    ]
    xlab = speed_label(ds["speed"])
    rplot.plot_fig8(ax, speed, amp.sel(direction="up"), amp.sel(direction="down"), half_gap=b,
                    curves=curves, eq15=eq15, speed_label=xlab)
    ax.set_xlim(speed[0], speed[-1])
    ax.set_ylim(0, 0.6)
    # where the lower branch loses period-1 stability (a multiplier through -1)
    turns = np.nonzero(np.diff(np.sign(np.diff(aft.omega))))[0] + 1
    flip = None
    if turns.size == 2:
        after = np.nonzero(~aft.stable[turns[1] + 2:])[0]
        if after.size:
            flip = aft.omega[turns[1] + 2 + after[0]] / w_per_rpm
            ax.annotate(f"period-1 lower branch unstable above {flip:.0f} rpm (flip):\n"
                        "the integration follows period-2, -4 or irregular motions\n"
                        f"({n_bad} of {n_all} case-speeds not settled: masked)",
                        (flip, float(np.interp(flip, speed, 0.5 * ds["p_pp"].sel(
                            direction="down")) * 1e3)),
                        xytext=(8300.0, 0.03), fontsize=7.5,
                        arrowprops={"arrowstyle": "->", "color": "0.3"})
    ax.text(0.99, 0.99, "Eq. (15) against the integration:\n"
            f"run-down rise {dist['up'].rise_eq15:.0f} rpm (integration {down_jump:.0f})\n"
            f"run-up drop {dist['up'].drop_eq15:.0f} rpm (integration {up_jump:.0f})\n"
            f"amplitude, rattling branch: median {np.nanmedian(upper):.1%},"
            f" max {np.nanmax(upper):.1%}\n"
            f"amplitude, free-flight branch: median {np.nanmedian(lower):.1%}",
            transform=ax.transAxes, ha="right", va="top", fontsize=7.5,
            bbox={"fc": "white", "ec": "0.7", "alpha": 0.9})
    ax.set_title(f"{ds.attrs['title']}\nk = {model.stiffness / 1e6:g} kN/mm, m_eq = "
                 f"{model.mass:g} kg, backlash {model.backlash * 1e3:.4g} mm (line of action);"
                 f" FITTED: F0 = {f0 / 1e3:g} kN at mesh order {fh.order:g},\nc = "
                 f"{model.damping / 1e3:g} N s/mm (ζ = {zeta(model.damping, model):.3f}); "
                 f"F_m = {model.mean_force:.0f} N", fontsize=8.5)
    loss, _, _ = settled(ds["contact_loss_fraction"], ds)
    back, _, _ = settled(ds["backside_contact_fraction"], ds)
    rplot.plot_contact(ax2, speed, loss.sel(direction="up"), loss.sel(direction="down"),
                       back.sel(direction="up"), back.sel(direction="down"), speed_label=xlab)
    above = loss.sel(direction="up").where(ds["speed"] > up_jump)
    ax2.annotate(f"above the run-up drop: apart {float(above.min()):.0%}-"
                 f"{float(above.max()):.0%} of the time\n(free flight, drive-flank impacts only)",
                 (0.72, 0.55), xycoords="axes fraction", fontsize=7.5, ha="center")
    fig.tight_layout()
    print(save(fig, figures / "fig08_rattle.png"))
    tp = np.sort(hb.turning_points(df.omega, df.amplitude)) / w_per_rpm
    tp0 = np.sort(hb.turning_points(df0.omega, df0.amplitude)) / w_per_rpm
    tpa = np.sort(hb.turning_points(aft.omega, aft.amplitude)) / w_per_rpm
    print(f"sweeps: run-up jumps at {up_jump:.0f} rpm (size {float(js.jump_up_size):+.2f}),"
          f" run-down at {down_jump:.0f} rpm (size {float(js.jump_down_size):+.2f});"
          f" grid step {speed[1] - speed[0]:.1f} rpm")
    print(f"turning points [rpm]: describing fn. {tp.round(0)}, with F_m = 0 {tp0.round(0)}, "
          f"AFT {tpa.round(0)} ({aft.omega.size} points, {t_aft:.1f} s)")
    print(f"Eq. (15): rise {dist['up'].rise_eq15:.0f}, drop {dist['up'].drop_eq15:.0f} rpm;"
          f" relative distance on the rattling branch median {np.nanmedian(upper):.3f}"
          f" max {np.nanmax(upper):.3f}; free-flight branch median {np.nanmedian(lower):.3f}")
    print(f"contact loss above the run-up drop: {float(above.min()):.3f}-{float(above.max()):.3f}"
          f" (mean {float(above.mean()):.3f})")
    print(f"AFT lower branch: period-1 unstable (flip) above {flip} rpm")
    print(f"largest settle_error {float(ds['settle_error'].max()):.3g}; status != 0 at {n_bad}"
          f" of {n_all} case-speeds")


def fig8_out_of_sample(ds8, pair, paper_k, mesh, figures):
    """Fig. 8's fitted scene beside the same equation driven by the pair's own STE."""
    m8, w8 = scene(ds8)
    (fh,) = m8.force_harmonics
    fig, (ax, ax2, ax3) = plt.subplots(3, 1, figsize=(8, 10.5), sharex=True,
                                       gridspec_kw={"height_ratios": [2.2, 1, 1.6]})
    lines, loss_lines = [], []
    amp8, _, _ = settled(0.5 * ds8["p_pp"], ds8)
    lines.append({"x": ds8["speed"].values, "y": amp8.sel(direction="up").values,
                  "color": "0.55", "lw": 2.0,
                  "label": f"Fig. 8 scene, FITTED F0 = {fh.amplitude / 1e3:g} kN (run-up)"})
    lines.append({"x": ds8["speed"].values, "y": amp8.sel(direction="down").values,
                  "color": "0.55", "lw": 2.0, "ls": "--", "label": "  (run-down)"})
    colors = {0: "tab:blue", 1: "tab:orange"}
    thresholds = []
    for j, (ds, name) in enumerate(((pair, "pair's k0"), (paper_k, "paper's k"))):
        model, _ = scene(ds)
        a, nb, na = settled(0.5 * ds["p_pp"], ds)
        loss, _, _ = settled(ds["contact_loss_fraction"], ds)
        for i, c in enumerate(ds["damping"].values):
            z = zeta(c, model)
            lab = (f"{name} {model.stiffness / 1e6:.0f} kN/mm, own STE, c = {c / 1e3:g} N s/mm"
                   f" (ζ = {z:.3f})")
            for d, ls in (("up", "-"), ("down", "--")):
                kw = {"color": colors[j], "ls": ls, "lw": 1.6 if i == 0 else 0.9}
                lines.append({"x": ds["speed"].values,
                              "y": a.sel(damping=c, direction=d).values,
                              "label": lab + (" (run-up)" if d == "up" else " (run-down)"), **kw})
                loss_lines.append({"x": ds["speed"].values,
                                   "y": loss.sel(damping=c, direction=d).values,
                                   "label": None, **kw})
            thresholds.append((name, model.stiffness, c, rfit.contact_loss_threshold(
                mass=model.mass, stiffness=model.stiffness, damping=c,
                force_mean=model.mean_force)))
        if nb:
            print(f"{ds.attrs['title']}: {nb} of {na} case-speeds not settled (masked)")
    xlab = speed_label(pair["speed"])
    rplot.plot_lines(ax, None, lines, xlabel="", ylabel="amplitude of p, (p_max - p_min)/2 [mm]",
                     scale=1e3, hline={"y": m8.backlash / 2, "label": "backlash / 2"})
    ax.legend(fontsize=6.5, loc="lower right", ncol=1)
    ax.set_title("Fig. 8 out of sample: the same Eq. (13) driven by the Table 1 pair's own STE"
                 " (no fitted force)\n(no case reaches the back flank: backside contact 0"
                 " everywhere)", fontsize=9)
    loss8, _, _ = settled(ds8["contact_loss_fraction"], ds8)
    loss_lines.insert(0, {"x": ds8["speed"].values, "y": loss8.sel(direction="up").values,
                          "color": "0.55", "lw": 2.0, "label": None})
    rplot.plot_lines(ax2, None, loss_lines, xlabel="", ylabel="contact loss\n[fraction of time]",
                     log=False)
    # the force budget: what the fit needs and what the pair supplies at mesh order 1
    e1 = float(mesh["ste_harmonic"].sel(harmonic=1))
    sp = np.linspace(float(pair["speed"][0]), float(pair["speed"][-1]), 200)
    w = sp * w8
    budget = [{"x": sp, "y": np.full(sp.shape, fh.amplitude), "color": "0.55", "lw": 2.0,
               "label": f"F0 fitted for Fig. 8: {fh.amplitude / 1e3:g} kN"},
              {"x": sp, "y": np.full(sp.shape, m8.mean_force), "color": "k", "ls": "-.",
               "label": f"mean mesh force F_m = {m8.mean_force:.0f} N"},
              {"x": sp, "y": m8.mass * w**2 * e1, "color": "tab:purple",
               "label": f"m_eq w² e_1 (e_1 = {e1 * 1e6:.2f} µm, the pair's 1st STE harmonic)"}]
    for name, k, c, thr in thresholds:
        col = colors[0] if name == "pair's k0" else colors[1]
        if c == max(t[2] for t in thresholds if t[0] == name):
            budget.append({"x": sp, "y": np.full(sp.shape, k * e1), "color": col, "ls": ":",
                           "label": f"k e_1, k = {k / 1e6:.0f} kN/mm"})
        budget.append({"x": sp, "y": np.full(sp.shape, thr), "color": col, "ls": "--",
                       "lw": 0.9, "label": f"least force that opens the mesh, k = {k / 1e6:.0f}"
                                          f" kN/mm, c = {c / 1e3:g} N s/mm"})
    rplot.plot_lines(ax3, None, budget, xlabel=xlab, ylabel="force amplitude at mesh order 1 [N]")
    ax3.legend(fontsize=6.5, loc="lower right")
    fig.tight_layout()
    print(save(fig, figures / "fig08_out_of_sample.png"))
    for ds in (pair, paper_k):
        js = jump_summary(ds)
        loss = ds["contact_loss_fraction"].max("direction")
        for c in ds["damping"].values:
            opened = ds["speed"].values[(loss.sel(damping=c) > 0).values]
            up = float(js.jump_up_speed.sel(damping=c))
            down = float(js.jump_down_speed.sel(damping=c))
            span = f"{opened.min()}-{opened.max()}" if opened.size else "none"
            print(f"{ds.attrs['title'][:60]}: c = {c:g}: jumps up {up:.0f}"
                  f" down {down:.0f} rpm; contact loss at {span}"
                  f" rpm, max p_pp {float(ds['p_pp'].sel(damping=c).max()) * 1e6:.2f} µm,"
                  f" backside {float(ds['backside_contact_fraction'].sel(damping=c).max()):.3f}")
    print(f"budget: F0 {fh.amplitude:.0f} N, F_m {m8.mean_force:.0f} N, e1 {e1:.4g} m, k e1"
          f" {m8.stiffness * e1:.0f} N (paper k), m w^2 e1 at 7500/8000 rpm"
          f" {m8.mass * (7500 * w8) ** 2 * e1:.0f}/{m8.mass * (8000 * w8) ** 2 * e1:.0f} N;"
          f" thresholds {[(n, round(t)) for n, _, _, t in thresholds]}")


def fig9(ds, figures):
    model, w_per_rpm = scene(ds)
    b = model.backlash / 2
    f0 = model.force_harmonics[0].amplitude
    w_t = np.sqrt(f0 / (model.mass * b))  # the gap root appears: |p0| = b
    w_n = np.sqrt(model.stiffness / model.mass)  # the drive-flank root leaves to infinity
    speeds = np.array([0.7 * w_t, 0.5 * (w_t + w_n), 1.25 * w_n]) / w_per_rpm
    omegas = speeds * w_per_rpm
    roots = hb.eq15_roots(omegas, f0, model.stiffness, model.mass, b)
    labels = [f"{n}: {v:.0f} rpm" for n, v in zip("ABC", speeds, strict=True)]
    shaft = ds["speed"].attrs.get("gear", "driving gear")
    fig, ax = plt.subplots(figsize=(7, 5.5))
    rplot.plot_fig9(ax, stiffness=model.stiffness, mass=model.mass, force_amp=f0, half_gap=b,
                    omegas=omegas, labels=labels, roots=roots, p_range=0.75e-3)
    counts = np.isfinite(roots).sum(axis=1)
    ax.set_title("Fig. 9: Eq. (15), k f(p0) = F0 + m ω² p0 (undamped; F0 = "
                 f"{f0 / 1e3:g} kN as fitted for Fig. 8, b = {b * 1e3:.4g} mm);\nintersections "
                 f"A: {counts[0]}, B: {counts[1]}, C: {counts[2]} (3 roots between "
                 f"{w_t / w_per_rpm:.0f} and {w_n / w_per_rpm:.0f} rpm of the {shaft}))",
                 fontsize=9)
    fig.tight_layout()
    print(save(fig, figures / "fig09_graphical.png"))


def rattle_map(ds, figures):
    loss = ds["contact_loss_fraction"].max("direction")
    frac = (loss > 0.01).mean("speed").transpose("backlash", "damping", "torque")
    width = jump_summary(ds)["hysteresis_width"].transpose("backlash", "damping", "torque")
    nb = ds.sizes["backlash"]
    fig, axes = plt.subplots(2, nb, figsize=(3.0 * nb + 1.5, 7.5), sharey=True, sharex=True)
    rplot.plot_rattle_map(list(axes[0]), list(axes[1]), ds["damping"].values,
                          ds["torque"].values, ds["backlash"].values, frac.values, width.values)
    fig.suptitle(f"Where rattle occurs over {ds.speed.values[0]:.0f}-{ds.speed.values[-1]:.0f} "
                 "rpm (F0 = 72 kN at mesh order 1):\ntop: share of speeds with contact loss "
                 "(either sweep); bottom: width of the jump hysteresis band", fontsize=9)
    fig.savefig(figures / "rattle_map.png", dpi=130, bbox_inches="tight")
    plt.close(fig)
    print(figures / "rattle_map.png")
    print(f"map: {int(ds.attrs['cases'])} case-speeds in {ds.attrs.get('elapsed_seconds')} s; "
          f"status 2 (not settled) at {float((ds.status == 2).mean()):.2%}")


args = parse(__doc__.splitlines()[0])
ds8 = open_result(args.results, "fig08_rattle")
fig8(ds8, args.figures)
fig8_out_of_sample(ds8, open_result(args.results, "rattle_table1_pair"),
                   open_result(args.results, "rattle_table1_ste_paper_k"),
                   open_result(args.results, "fig01_02_mesh_cycle"), args.figures)
fig9(ds8, args.figures)
rattle_map(open_result(args.results, "rattle_map"), args.figures)

"""Rattle figures (paper section 6) from the results of the rattle studies.

Reads ``results/fig08_rattle.nc``, ``results/fig12_rattle_loads.nc`` and
``results/rattle_map.nc`` (``gearsweep run studies/<name>.yaml``), computes the harmonic
balances of the Fig. 8 scene from the study text stored in the result, and writes
``figures/fig08_rattle.png``, ``fig09_graphical.png``, ``fig12_rms_loads.png`` and
``rattle_map.png``; prints the jump speeds and turning points.
"""

import time

import numpy as np
from _common import open_result, parse

from gearsweep.analysis import hb
from gearsweep.model import RPM
from gearsweep.plot import rattle as rplot
from gearsweep.plot.common import plt, save
from gearsweep.study.jumps import jump_summary
from gearsweep.study.runner import build_model
from gearsweep.study.schema import parse_study
from gearsweep.units import from_display


def scene(ds):
    """The MeshModel of a result's study (SI values) and rpm -> excitation rad/s factor."""
    model = build_model(parse_study(ds.attrs["study"]))
    (fh,) = model.force_harmonics
    return model, fh.order * model.teeth * RPM


def amplitude_grid(b: float, top: float) -> np.ndarray:
    """Amplitudes for the describing-function curve: dense just above b (grazing)."""
    return np.unique(np.r_[np.linspace(0.005 * b, 0.9999 * b, 400),
                           b * (1 + np.geomspace(1e-8, top / b - 1, 4000))])


def fig8(ds, figures):
    model, w_per_rpm = scene(ds)
    b = model.backlash / 2
    f0 = model.force_harmonics[0].amplitude
    speed = ds["speed"].values
    amp = 0.5 * ds["p_pp"]
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
    sp15 = np.linspace(speed[0], speed[-1], 31)
    r15 = hb.eq15_roots(sp15 * w_per_rpm, f0, model.stiffness, model.mass, b)
    eq15 = {"speed": np.repeat(sp15, 3).reshape(-1, 3)[np.isfinite(r15)],
            "amplitude": np.abs(r15[np.isfinite(r15)])}
    fig, (ax, ax2) = plt.subplots(2, 1, figsize=(8, 7.5), sharex=True,
                                  gridspec_kw={"height_ratios": [3, 1.2]})
    curves = [
        {"speed": df0.omega / w_per_rpm, "amplitude": df0.amplitude, "stable": df0.stable,
         "label": "describing fn. A, F_m = 0", "color": "0.6", "lw": 1.0},
        {"speed": df.omega / w_per_rpm, "amplitude": df.amplitude, "stable": df.stable,
         "label": "describing fn., first-harmonic A", "color": "k"},
        {"speed": aft.omega / w_per_rpm, "amplitude": aft.amplitude, "stable": aft.stable,
         "label": "AFT harmonic balance (25 harm.), Floquet", "color": "tab:green"},
    ]
    rplot.plot_fig8(ax, speed, amp.sel(direction="up"), amp.sel(direction="down"), half_gap=b,
                    curves=curves, eq15=eq15)
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
                        "the integration follows period-2, -4 or irregular motions",
                        (flip, float(np.interp(flip, speed, amp.sel(direction="down")) * 1e3)),
                        xytext=(8300.0, 0.03), fontsize=7.5,
                        arrowprops={"arrowstyle": "->", "color": "0.3"})
    ax.set_title(f"Fig. 8: rattle jump, k = {model.stiffness / 1e6:g} kN/mm, m_eq = "
                 f"{model.mass:g} kg, backlash {model.backlash * 1e3:g} mm,\nF0 = {f0 / 1e3:g} kN "
                 f"at mesh order 1, F_m = {model.mean_force:.0f} N, c = "
                 f"{model.damping / 1e3:g} N s/mm", fontsize=9)
    rplot.plot_contact(ax2, speed, ds["contact_loss_fraction"].sel(direction="up"),
                       ds["contact_loss_fraction"].sel(direction="down"),
                       ds["backside_contact_fraction"].sel(direction="up"),
                       ds["backside_contact_fraction"].sel(direction="down"))
    fig.tight_layout()
    print(save(fig, figures / "fig08_rattle.png"))
    js = jump_summary(ds)
    tp = np.sort(hb.turning_points(df.omega, df.amplitude)) / w_per_rpm
    tp0 = np.sort(hb.turning_points(df0.omega, df0.amplitude)) / w_per_rpm
    tpa = np.sort(hb.turning_points(aft.omega, aft.amplitude)) / w_per_rpm
    print(f"sweeps: run-up jumps at {float(js.jump_up_speed):.0f} rpm "
          f"(size {float(js.jump_up_size):+.2f}), run-down at {float(js.jump_down_speed):.0f} "
          f"rpm (size {float(js.jump_down_size):+.2f}); grid step {speed[1] - speed[0]:.1f} rpm")
    print(f"turning points [rpm]: describing fn. {tp.round(0)}, with F_m = 0 {tp0.round(0)}, "
          f"AFT {tpa.round(0)} ({aft.omega.size} points, {t_aft:.1f} s)")
    w_t = np.sqrt(f0 / (model.mass * b)) / w_per_rpm
    w_n = np.sqrt(model.stiffness / model.mass) / w_per_rpm
    print(f"Eq. (15): three roots between {w_t:.0f} and {w_n:.0f} rpm")
    print(f"AFT lower branch: period-1 unstable (flip) above {flip} rpm")
    settle = float(ds["settle_error"].max())
    print(f"largest settle_error {settle:.3g}; status != 0 at {int((ds.status != 0).sum())} "
          "case-speeds")


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
    fig, ax = plt.subplots(figsize=(7, 5.5))
    rplot.plot_fig9(ax, stiffness=model.stiffness, mass=model.mass, force_amp=f0, half_gap=b,
                    omegas=omegas, labels=labels, roots=roots, p_range=0.75e-3)
    counts = np.isfinite(roots).sum(axis=1)
    ax.set_title("Fig. 9: Eq. (15), k f(p0) = F0 + m w^2 p0; intersections "
                 f"A: {counts[0]}, B: {counts[1]}, C: {counts[2]}\n"
                 f"(3 roots between {w_t / w_per_rpm:.0f} and {w_n / w_per_rpm:.0f} rpm)",
                 fontsize=9)
    fig.tight_layout()
    print(save(fig, figures / "fig09_graphical.png"))


def fig12(ds, figures):
    rms = ds["p_rms"].transpose("direction", "torque", "speed")
    fig, ax = plt.subplots(figsize=(8, 5))
    rplot.plot_rms_vs_speed(ax, ds["speed"].values, rms.sel(direction="up").values,
                            rms.sel(direction="down").values, ds["torque"].values,
                            load_label="T1m [N m]")
    ax.set_title("Counterpart of Fig. 12: rms of p versus speed for four mean torques\n"
                 "(rattle scene of Fig. 8; only loads comparable with F0 = 72 kN change it)",
                 fontsize=9)
    fig.tight_layout()
    print(save(fig, figures / "fig12_rms_loads.png"))


def rattle_map(ds, figures):
    loss = ds["contact_loss_fraction"].max("direction")
    frac = (loss > 0.01).mean("speed").transpose("backlash", "damping", "torque")
    width = jump_summary(ds)["hysteresis_width"].transpose("backlash", "damping", "torque")
    nb = ds.sizes["backlash"]
    fig, axes = plt.subplots(2, nb, figsize=(3.0 * nb + 1.5, 7.5), sharey=True, sharex=True)
    rplot.plot_rattle_map(list(axes[0]), list(axes[1]),  # the plot takes SI (the file: display)
                          from_display(ds["damping"].values, "damping"), ds["torque"].values,
                          from_display(ds["backlash"].values, "length"), frac.values, width.values)
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
fig9(ds8, args.figures)
fig12(open_result(args.results, "fig12_rattle_loads"), args.figures)
rattle_map(open_result(args.results, "rattle_map"), args.figures)

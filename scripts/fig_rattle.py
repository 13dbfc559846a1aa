"""Rattle figures (paper section 6) from the results of the rattle studies.

Reads ``results/fig08_rattle.nc`` and its harmonic balance ``results/fig08_rattle_balance.nc``
(describing function, AFT branch, turning points, Eq. (15) and its distance from the
integration), the out-of-sample ``results/rattle_table1_pair.nc`` and
``results/rattle_table1_ste_paper_k.nc`` with their force budget ``results/fig08_rattle_budget.nc``,
and the design map's jumps ``results/rattle_map_jumps.nc`` (``gearsweep run
studies/<name>.yaml``); writes ``figures/fig08_rattle.png``, ``fig08_out_of_sample.png``,
``fig09_graphical.png`` and ``rattle_map.png``; prints the jump speeds, turning points and the
distance of Eq. (15) from the integration. Nothing is computed here. The Fig. 12 counterpart is
``scripts/fig11_low_speed.py``.
"""

import textwrap

import numpy as np
import xarray as xr
from _common import open_result, parse

import gearsweep
from gearsweep.plot import rattle as rplot
from gearsweep.plot.common import plt, save
from gearsweep.plot.sweep import settled, speed_label
from gearsweep.units import from_display


def fig8(bal, figures):
    fig, (ax, ax2) = plt.subplots(2, 1, figsize=(11, 8), sharex=True, layout="constrained",
                                  gridspec_kw={"height_ratios": [3, 1.2]})
    rplot.plot_rattle_balance(ax, bal, ymax=0.6)  # (legends and the Eq. (15) box beside the axes)
    rplot.plot_rattle_contact(ax2, bal)
    print(save(fig, figures / "fig08_rattle.png"))
    tp = bal["turning_point"]

    def turns(curve):
        t = tp.sel(curve=curve).values
        return t[np.isfinite(t)].round(0)

    speed = bal["speed"].values
    flip = float(bal.flip_speed)
    print(f"sweeps: run-up {rplot.budget_jump(bal, 'up')} (size {float(bal.jump_up_size):+.2f}),"
          f" run-down {rplot.budget_jump(bal, 'down')} (size {float(bal.jump_down_size):+.2f});"
          f" grid step {speed[1] - speed[0]:.1f} rpm")  # (NaN: none, or cannot be judged)
    print(f"turning points [rpm]: describing fn. {turns('describing_function')}, with F_m = 0"
          f" {turns('describing_function_no_mean_force')}, AFT {turns('aft')}"
          f" ({bal.attrs['aft_points']} points, {bal.attrs['aft_seconds']:.1f} s)")
    print(f"Eq. (15): rise {float(bal.eq15_rise_speed):.0f}, drop {float(bal.eq15_drop_speed):.0f}"
          f" rpm; relative distance on the rattling branch median"
          f" {float(bal.eq15_distance_rattling_median):.3f} max"
          f" {float(bal.eq15_distance_rattling_max):.3f}; free-flight branch median"
          f" {float(bal.eq15_distance_free_flight_median):.3f}")
    print(f"contact loss above the run-up drop: {float(bal.contact_loss_above_drop_min):.3f}-"
          f"{float(bal.contact_loss_above_drop_max):.3f}"
          f" (mean {float(bal.contact_loss_above_drop_mean):.3f})")
    print(f"AFT lower branch: period-1 unstable (flip) above"
          f" {bal.flip_speed.values if np.isfinite(flip) else None} rpm")
    print(f"largest settle_error {float(bal.settle_error_max):.3g}; status != 0 at"
          f" {int(bal.not_settled)} of {int(bal.cases)} case-speeds")


def fig8_out_of_sample(ds8, results, budget, figures):
    """Fig. 8's fitted scene beside the same equation driven by the pair's own STE."""
    f0 = float(budget.fitted_force)
    fig, (ax, ax2, ax3) = plt.subplots(3, 1, figsize=(12, 10.5), sharex=True,
                                       gridspec_kw={"height_ratios": [2.2, 1, 1.6]})
    lines, loss_lines, masked = [], [], []
    amp8, nb8, na8 = settled(0.5 * ds8["p_pp"], ds8)
    lines.append({"x": ds8["speed"].values, "y": amp8.sel(direction="up").values,
                  "color": "0.55", "lw": 2.0,
                  "label": f"Fig. 8 scene, FITTED F0 = {f0 / 1e3:g} kN (run-up)"})
    lines.append({"x": ds8["speed"].values, "y": amp8.sel(direction="down").values,
                  "color": "0.55", "lw": 2.0, "ls": "--", "label": "  (run-down)"})
    colors = {0: "tab:blue", 1: "tab:orange"}
    for j, scene in enumerate(budget["scene"].values):
        ds = results[str(scene)]
        b = budget.sel(scene=scene)
        name = str(b.scene_name.values)
        a, nb, na = settled(0.5 * ds["p_pp"], ds)
        loss, _, _ = settled(ds["contact_loss_fraction"], ds)
        for i, c in enumerate(ds["damping"].values):
            k = float(b.scene_stiffness.sel(damping=c))
            lab = (f"{name} {k / 1e6:.0f} kN/mm, c = {c:g} N s/mm"  # (own STE: the title)
                   f" (ζ = {float(b.zeta.sel(damping=c)):.3f})")
            for d, ls in (("up", "-"), ("down", "--")):
                kw = {"color": colors[j], "ls": ls, "lw": 1.6 if i == 0 else 0.9}
                jump = rplot.budget_jump(b.sel(damping=c), d)  # (or: cannot be judged)
                lines.append({"x": ds["speed"].values,
                              "y": a.sel(damping=c, direction=d).values,
                              "label": f"{lab}, run-{d}: {jump}", **kw})
                loss_lines.append({"x": ds["speed"].values,
                                   "y": loss.sel(damping=c, direction=d).values,
                                   "label": None, **kw})
        if nb:
            print(f"{ds.attrs['title']}: {nb} of {na} case-speeds not settled (masked)")
            masked.append(f"{name} {nb} of {na}")
    first = results[str(budget["scene"].values[0])]
    xlab = speed_label(first["speed"])
    rplot.plot_lines(ax, None, lines, xlabel="", ylabel="amplitude of p, (p_max - p_min)/2 [mm]",
                     scale=1e3, hline={"y": float(budget.half_gap), "label": "backlash / 2"})
    outside = {"fontsize": 6.5, "loc": "upper left", "bbox_to_anchor": (1.01, 1.0)}
    ax.legend(**outside)  # beside the panel: inside it the legends hid lines
    back = float(budget.backside_contact_max.max())  # over the own-STE scenes and dampings
    back = ("no case reaches the back flank: backside contact 0 everywhere" if back == 0 else
            f"back-flank contact up to {back:.3g} of the time")  # (was typed, not read)
    ax.set_title("Fig. 8 out of sample: the same Eq. (13) driven by the Table 1 pair's own STE"
                 " (no fitted force)\n" + textwrap.fill(
                     f"(own STE: {back}; not"
                     " settled, masked: " + ", ".join([f"Fig. 8 scene {nb8} of {na8}"] + masked)
                     + " case-speeds)", 95), fontsize=9)  # (beside a wide legend: wrapped)
    loss8, _, _ = settled(ds8["contact_loss_fraction"], ds8)
    loss_lines.insert(0, {"x": ds8["speed"].values, "y": loss8.sel(direction="up").values,
                          "color": "0.55", "lw": 2.0, "label": None})
    rplot.plot_lines(ax2, None, loss_lines, xlabel="", ylabel="contact loss\n[fraction of time]",
                     log=False)
    rplot.plot_rattle_budget(ax3, budget, colors=colors)
    ax3.legend(**outside)
    ax3.set_xlabel(xlab)
    fig.tight_layout()
    print(save(fig, figures / "fig08_out_of_sample.png"))
    for scene in budget["scene"].values:
        b = budget.sel(scene=scene)
        for c in b["damping"].values:
            s = b.sel(damping=c)
            if not np.isfinite(float(s.scene_stiffness)):
                continue
            lo, hi = float(s.contact_loss_from), float(s.contact_loss_to)
            span = f"{lo}-{hi}" if np.isfinite(lo) else "none"
            print(f"{str(b.scene_title.values)[:60]}: c = {c:g}: run-up"
                  f" {rplot.budget_jump(s, 'up')}, run-down {rplot.budget_jump(s, 'down')};"
                  f" contact loss at {span} rpm, max p_pp {float(s.p_pp_max) * 1e6:.2f} µm,"
                  f" backside {float(s.backside_contact_max):.3f}")
    if "jump_note" in budget.attrs:
        print(f"jumps: {budget.attrs['jump_note']}")
    at = budget.inertia_force_at.values
    thr = [(str(b.scene_name.values), round(float(t)))
           for sc in budget["scene"].values for b in [budget.sel(scene=sc)]
           for t in b.threshold.values if np.isfinite(t)]
    first = [(str(b.scene_name.values), f"c = {c:g}", "never" if np.isnan(lo) else
              f"{lo:.0f}-{float(b.first_harmonic_opens_to.sel(damping=c)):.0f} rpm")
             for sc in budget["scene"].values for b in [budget.sel(scene=sc)]
             for c, lo in zip(b["damping"].values, b.first_harmonic_opens_from.values,
                              strict=True) if np.isfinite(float(b.threshold.sel(damping=c)))]
    print(f"budget: F0 {f0:.0f} N, F_m {float(budget.mean_force):.0f} N, e1"
          f" {float(budget.ste_1):.4g} m, k e1 {float(budget.k_e1_fitted):.0f} N (paper k), m w^2 e1"
          f" at {'/'.join(f'{s:.0f}' for s in budget.at_speed.values)} rpm"
          f" {'/'.join(f'{x:.0f}' for x in at)} N; least opening forces (at resonance) {thr};"
          f" m w^2 e1 alone opens the mesh (linear response) {first}")


def fig9(bal, figures):
    fig, ax = plt.subplots(figsize=(9.5, 5.5), layout="constrained")  # (its legend beside
    rplot.plot_rattle_graphical(ax, bal, p_range=0.75e-3)  # the axes)
    print(save(fig, figures / "fig09_graphical.png"))


def unjudged_text(ds) -> str:
    """What the map's grey cells are, in words, and how many (``jump_unsupported`` > 0, the
    cases whose hysteresis width is NaN); empty where there are none."""
    bad = ds["jump_unsupported"] > 0
    n = int(bad.sum())
    if not n:
        return ""
    return (f"\ngrey (bottom): {n} of {bad.size} cells whose jump cannot be judged"
            " (jump_unsupported): a sweep has a step that meets the jump criterion but no settled"
            "\npoints of both branches beside it, or no jump while most of its speeds did not"
            " settle")


def rattle_map(ds, scene, figures):
    """The design map of the jump summary ``ds``; ``scene``: the map's own result (for its
    excitation, named in the title as the result holds it)."""
    force = gearsweep.result_model(scene).force_harmonics[0]
    dims = ("backlash", "damping", "torque")
    frac = ds["rattle_share"].transpose(*dims)
    width = ds["hysteresis_width"].transpose(*dims)
    nb = ds.sizes["backlash"]
    fig, axes = plt.subplots(2, nb, figsize=(3.0 * nb + 1.5, 7.5), sharey=True, sharex=True)
    if unjudged_text(ds):  # two more title lines: the panels' titles ran into them (before the
        fig.subplots_adjust(top=0.84)  # colour bars, which take the panels' places)
    rplot.plot_rattle_map(list(axes[0]), list(axes[1]),  # the plot takes SI (the file: display)
                          from_display(ds["damping"].values, "damping"), ds["torque"].values,
                          from_display(ds["backlash"].values, "length"), frac.values, width.values,
                          ds["hysteresis_open"].transpose(*dims).values)
    fig.suptitle(f"Where rattle occurs over {ds.attrs['speed_from']:.0f}-{ds.attrs['speed_to']:.0f} "
                 f"rpm, the fitted scene of Fig. 8 (F0 = {force.amplitude / 1e3:.3g} kN at mesh"
                 f" order {force.order:g}, fitted; the Table 1 pair's own STE gives no rattle):\n"
                 "top: share of speeds with contact loss (either sweep); bottom: width of the jump"
                 " hysteresis band" + unjudged_text(ds), fontsize=9)

    fig.savefig(figures / "rattle_map.png", dpi=130, bbox_inches="tight")
    plt.close(fig)
    print(figures / "rattle_map.png")
    print(f"map: {int(ds.attrs['input_cases'])} case-speeds in"
          f" {ds.attrs.get('input_elapsed_seconds')} s; status 2 (not settled) at"
          f" {float(ds.not_settled_share):.2%}")


args = parse(__doc__.splitlines()[0])
balance = open_result(args.results, "fig08_rattle_balance")
budget = open_result(args.results, "fig08_rattle_budget")
fig8(balance, args.figures)
fig8_out_of_sample(open_result(args.results, "fig08_rattle"),
                   {str(s): open_result(args.results, str(s)) for s in budget["scene"].values},
                   budget, args.figures)
fig9(balance, args.figures)
with xr.open_dataset(args.results / "rattle_map.nc") as scene:  # its attributes only (lazy)
    rattle_map(open_result(args.results, "rattle_map_jumps"), scene, args.figures)

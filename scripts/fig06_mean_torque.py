"""Fig. 6: whine response versus speed for several mean torques: the Table 1 pair's own mesh (k(t)
and e(t) recomputed at each load), the pair with a 6 µm tip relief, and the paper's printed
stiffness (studies/fig06_mean_torque.yaml, fig06_mean_torque_relief.yaml,
fig06_mean_torque_paper_k.yaml); and, as panel (d), why (a) has no resonance peak: order 1 of p
at 50 N m with the pair's k(t) cut to its first harmonic, to its first two, and whole
(fig06_mean_torque_k1_only.yaml, fig06_mean_torque_k1_k2.yaml, (a) at 50 N m), beside the closed
form of a constant-amplitude force at that damping.

Writes figures/fig06_mean_torque.png. Run from the repository root after running the studies:

    python scripts/fig06_mean_torque.py [--results results] [--figures figures]
"""

from __future__ import annotations

import textwrap

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from _common import open_result, parse

from gearsweep import result_model
from gearsweep.plot.common import save
from gearsweep.plot.whine import (
    damping_text,
    lowest_in_contact,
    natural_frequency,
    plot_order_by_variant,
    plot_response_by_load,
    result_natural_frequency,
)


def other_loads_f_n(ds: xr.Dataset) -> list[tuple[list[float], float, float]]:
    """The loads whose own f_n (from the result's stored k0 at the load, ``gear_stiffness``)
    differs from the first load's, grouped by f_n: (torques [N m], f_n [Hz], k0 [N/m]) each.
    Empty where every load has the first load's f_n (the stiffness typed or not load-dependent)."""
    groups: list[tuple[list[float], float, float]] = []
    first = result_natural_frequency(ds.isel(torque=0))
    for t in ds["torque"].values[1:]:
        f = result_natural_frequency(ds.sel(torque=t))
        if f is None or first is None or np.isclose(f, first, rtol=1e-6):
            continue
        k0 = float(ds["gear_stiffness"].sel(torque=t))  # N/m (open_result: SI)
        if groups and np.isclose(groups[-1][1], f, rtol=1e-6):
            groups[-1][0].append(float(t))
        else:
            groups.append(([float(t)], f, k0))
    return groups


def mark_other_loads(ax, ds: xr.Dataset, teeth: int, orders=(1, 2, 3)) -> None:
    """Dotted lines, each in its load's line colour, where mesh order n meets the f_n of a load
    other than the first (``other_loads_f_n``); the first load's are the grey ones."""
    colours = {ln.get_label(): ln.get_color() for ln in ax.get_lines()}
    for torques, f, _ in other_loads_f_n(ds):
        colour = colours.get(f"torque = {torques[0]:g} N m", "0.5")
        for n in orders:
            s_n = 60 * f / (teeth * n)
            if ds["speed"].values[0] <= s_n <= ds["speed"].values[-1]:
                ax.axvline(s_n, color=colour, ls=":", lw=1.0)


args = parse(__doc__.splitlines()[0])
studies = ("fig06_mean_torque", "fig06_mean_torque_relief", "fig06_mean_torque_paper_k")
fig, axes = plt.subplots(2, len(studies) + 1, figsize=(21.0, 7.8), sharex=True,
                         height_ratios=[1.5, 1.0], layout="constrained")
per_load_panels = ""  # the panels whose loads' f_n differ: each load's drawn
for col, study in enumerate(studies):
    ds = open_result(args.results, study)
    f_n = natural_frequency(ds)
    ax, ax2 = axes[0, col], axes[1, col]
    if col:  # (a)-(c) share their rows' scales; (d) draws another quantity
        ax.sharey(axes[0, 0])
        ax2.sharey(axes[1, 0])
    plot_response_by_load(ax, ds, by="torque", variable="p_rms", natural_frequency_hz=f_n)
    teeth = int(round(float(ds.mesh_frequency[-1] / ds.speed[-1] * 60)))
    mark_other_loads(ax, ds, teeth)
    # clear of the lines: (a)'s fall to the right, (c)'s peak near 16,000 rpm low down; (b)'s
    # lower right is free (below the order labels at the top either way)
    ax.get_legend().set_loc(("upper right", "lower right", "upper left")[col])
    if col != 1:
        ax.get_legend().set_bbox_to_anchor((0.0, 0.0, 1.0, 0.86), transform=ax.transAxes)
    title = ds.attrs["title"].split(": ", 1)[-1]
    others = other_loads_f_n(ds)
    per_load_panels += f"({'abc'[col]})" if others else ""
    first = f"{float(ds.torque[0]):g} N m"
    per_load = ("; dotted: order n meets f_n at each load's k0: grey"
                f" {first} ({float(ds.gear_stiffness[0]) / 1e6:.0f} kN/mm), in the line's colour "
                + ", ".join(f"{'/'.join(f'{t:g}' for t in ts)} N m ({k / 1e6:.0f} kN/mm,"
                            f" {fo / 1e3:.2f} kHz)" for ts, fo, k in others)
                if others else "")
    ax.set_title(textwrap.fill(f"({'abc'[col]}) {title}; f_n = {f_n / 1e3:.2f} kHz,"
                               f" {damping_text(ds).split(', ')[1]}"
                               + (f" at {first}" if others else " (at the first load)")
                               + per_load, 62 if not others else 74),
                 fontsize=9)
    ax.set_xlabel("")
    # the baseline: the lowest torque whose cases all keep contact (a ratio set against a case
    # that lost contact compares with the linear equation's answer for a pair with no backlash)
    base = lowest_in_contact(ds, "torque")
    lowest = float(ds["torque"].min())
    plot_response_by_load(ax2, ds, by="torque", variable="p_rms", natural_frequency_hz=f_n,
                          relative=True, log=True, baseline=lowest if base is None else base)
    mark_other_loads(ax2, ds, teeth)
    # of the legend only the grey bands' entry: the ratios whose case lost contact
    grey = [h for h in ax2.get_lines() if h.get_label().startswith("grey:")]
    ax2.legend(handles=grey, fontsize=8, loc="lower right") if grey else ax2.get_legend().remove()
    ax2.set_ylabel("p_rms / p_rms at the baseline torque (title) [-]")
    ax2.set_title("relative to the lowest torque (every load keeps contact)" if base == lowest
                  else f"relative to {lowest:g} N m (every load loses contact somewhere)"
                  if base is None else f"relative to {base:g} N m, the lowest torque that keeps contact"
                  f" at every speed\n({lowest:g} N m does not: its ratio is grey there)", fontsize=9)
    if col:
        ax.set_ylabel("")
        ax2.set_ylabel("")
# room above the ratio lines for the order labels at the top of the lower panels (they printed
# over (a)'s and (c)'s highest ratio, 100 N m over 12.5 N m)
top = max(np.nanmax(ln.get_ydata()) for a in axes[1, :-1] for ln in a.get_lines()
          if ln.get_label().startswith("torque"))
axes[1, 0].set_ylim(top=3.0 * top)
model = result_model(ds)
whole = open_result(args.results, "fig06_mean_torque").sel(torque=50.0)
variants = [("k1 only", open_result(args.results, "fig06_mean_torque_k1_only")),
            ("k1 and k2", open_result(args.results, "fig06_mean_torque_k1_k2")),
            ("all ten, (a) at 50 N m", whole)]
ax, ax2 = axes[0, -1], axes[1, -1]
plot_order_by_variant(ax, variants)
ax.set_ylim(0.0, 1.9)  # room above the lines for the legend
ax.legend(fontsize=6.5, loc="upper right", title="the pair's k(t) cut to", title_fontsize=7)
ax.set_xlabel("")
ax.set_title(textwrap.fill("(d) why (a) has no peak: order 1 of p at 50 N m, the pair's k(t) cut"
                           " to its first harmonic, its first two, and whole; dotted: where a"
                           " constant-amplitude force peaks", 62), fontsize=9)
plot_order_by_variant(ax2, variants, relative=True)
ax2.axhline(1.0, color="0.3", lw=0.8)
ax2.set_title("relative to the lowest speed: k1 alone peaks, k1 and k2 do not", fontsize=9)
fig.suptitle(f"Fig. 6: effect of the mean driving torque on the whine response (m_eq ="
             f" {model.mass:g} kg, {damping_text(ds).split(', ')[0]}); dotted in (a)-(c): mesh"
             " order n meets f_n (at the first load"
             + (f"; in {per_load_panels} per load, see its title)" if per_load_panels else ")"),
             fontsize=10)
print(save(fig, args.figures / "fig06_mean_torque.png", dpi=150))

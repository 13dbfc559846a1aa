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
from _common import open_result, parse

from gearsweep import result_model
from gearsweep.plot.common import save
from gearsweep.plot.whine import (
    damping_text,
    lowest_in_contact,
    natural_frequency,
    plot_order_by_variant,
    plot_response_by_load,
)

args = parse(__doc__.splitlines()[0])
studies = ("fig06_mean_torque", "fig06_mean_torque_relief", "fig06_mean_torque_paper_k")
fig, axes = plt.subplots(2, len(studies) + 1, figsize=(21.0, 7.8), sharex=True,
                         height_ratios=[1.5, 1.0], layout="constrained")
for col, study in enumerate(studies):
    ds = open_result(args.results, study)
    f_n = natural_frequency(ds)
    ax, ax2 = axes[0, col], axes[1, col]
    if col:  # (a)-(c) share their rows' scales; (d) draws another quantity
        ax.sharey(axes[0, 0])
        ax2.sharey(axes[1, 0])
    plot_response_by_load(ax, ds, by="torque", variable="p_rms", natural_frequency_hz=f_n)
    ax.get_legend().set_loc("lower right")
    title = ds.attrs["title"].split(": ", 1)[-1]
    ax.set_title(textwrap.fill(f"({'abc'[col]}) {title}; f_n = {f_n / 1e3:.2f} kHz,"
                               f" {damping_text(ds).split(', ')[1]} (at the first load)", 62),
                 fontsize=9)
    ax.set_xlabel("")
    # the baseline: the lowest torque whose cases all keep contact (a ratio set against a case
    # that lost contact compares with the linear equation's answer for a pair with no backlash)
    base = lowest_in_contact(ds, "torque")
    lowest = float(ds["torque"].min())
    plot_response_by_load(ax2, ds, by="torque", variable="p_rms", natural_frequency_hz=f_n,
                          relative=True, log=True, baseline=lowest if base is None else base)
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
             " order n meets f_n (at the first load)", fontsize=10)
print(save(fig, args.figures / "fig06_mean_torque.png", dpi=150))

"""Fig. 6: whine response versus speed for several mean torques: the Table 1 pair's own mesh (k(t)
and e(t) recomputed at each load), the pair with a 6 µm tip relief, and the paper's printed
stiffness (studies/fig06_mean_torque.yaml, fig06_mean_torque_relief.yaml,
fig06_mean_torque_paper_k.yaml).

Writes figures/fig06_mean_torque.png. Run from the repository root after running the studies:

    python scripts/fig06_mean_torque.py [--results results] [--figures figures]
"""

from __future__ import annotations

import textwrap

import matplotlib.pyplot as plt
from _common import open_result, parse

from gearsweep import result_model
from gearsweep.plot.common import save
from gearsweep.plot.whine import damping_text, natural_frequency, plot_response_by_load

args = parse(__doc__.splitlines()[0])
studies = ("fig06_mean_torque", "fig06_mean_torque_relief", "fig06_mean_torque_paper_k")
fig, axes = plt.subplots(2, len(studies), figsize=(16.5, 7.8), sharex=True, sharey="row",
                         height_ratios=[1.5, 1.0], layout="constrained")
for col, study in enumerate(studies):
    ds = open_result(args.results, study)
    f_n = natural_frequency(ds)
    ax, ax2 = axes[0, col], axes[1, col]
    plot_response_by_load(ax, ds, by="torque", variable="p_rms", natural_frequency_hz=f_n)
    ax.get_legend().set_loc("lower right")
    title = ds.attrs["title"].split(": ", 1)[-1]
    ax.set_title(textwrap.fill(f"({'abc'[col]}) {title}; f_n = {f_n / 1e3:.2f} kHz,"
                               f" {damping_text(ds).split(', ')[1]} (at the first load)", 62),
                 fontsize=9)
    ax.set_xlabel("")
    plot_response_by_load(ax2, ds, by="torque", variable="p_rms", natural_frequency_hz=f_n,
                           relative=True, log=True)
    ax2.get_legend().remove()
    ax2.set_title("relative to the lowest torque", fontsize=9)
    if col:
        ax.set_ylabel("")
        ax2.set_ylabel("")
model = result_model(ds)
fig.suptitle(f"Fig. 6: effect of the mean driving torque on the whine response (m_eq ="
             f" {model.mass:g} kg, {damping_text(ds).split(', ')[0]}); dotted: mesh order n meets"
             " f_n (at the first load)", fontsize=10)
print(save(fig, args.figures / "fig06_mean_torque.png", dpi=150))

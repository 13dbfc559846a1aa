"""Fig. 6: whine response versus speed for several mean torques, with the assumed STE and with
error-free teeth (studies/fig06_mean_torque.yaml, studies/fig06_mean_torque_no_error.yaml).

Writes figures/fig06_mean_torque.png. Run from the repository root after running both studies:

    python scripts/fig06_mean_torque.py [--results results] [--figures figures]
"""

from __future__ import annotations

import matplotlib.pyplot as plt
from _common import open_result, parse

from gearsweep.plot.common import save
from gearsweep.plot.whine import natural_frequency, plot_response_vs_speed

args = parse(__doc__.splitlines()[0])
cases = [("fig06_mean_torque", "STE e1, e2, e3 = 5, 1, 0.3 um in phase with k(t)"),
         ("fig06_mean_torque_no_error", "error-free teeth, e(t) = 0")]
fig, axes = plt.subplots(2, 2, figsize=(12.0, 7.4), sharex=True, sharey="row",
                         height_ratios=[1.5, 1.0], layout="constrained")
for col, (study, label) in enumerate(cases):
    ds = open_result(args.results, study)
    f_n = natural_frequency(ds)
    ax, ax2 = axes[0, col], axes[1, col]
    plot_response_vs_speed(ax, ds, by="torque", variable="p_rms", natural_frequency_hz=f_n)
    ax.get_legend().set_loc("lower right")
    ax.set_title(f"({'ab'[col]}) {label}", fontsize=9)
    ax.set_xlabel("")
    plot_response_vs_speed(ax2, ds, by="torque", variable="p_rms", natural_frequency_hz=f_n,
                           relative=True, log=True)
    ax2.get_legend().remove()
    ax2.set_title("relative to the lowest torque", fontsize=9)
    if col:
        ax.set_ylabel("")
        ax2.set_ylabel("")
fig.suptitle("Fig. 6: effect of the mean driving torque on the whine response (m_eq = 0.1527 kg,"
             " c = 5.5 N s/mm, k0 = 1073 kN/mm); dotted: mesh order n meets f_n", fontsize=10)
print(save(fig, args.figures / "fig06_mean_torque.png", dpi=150))

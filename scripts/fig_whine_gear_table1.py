"""Whine response versus speed with k(t) from the Table 1 gear pair (studies/whine_gear_table1.yaml).

Reads results/whine_gear_table1.nc; writes whine_gear_table1.png.
"""

import numpy as np
from _common import open_result, parse

from gearsweep.plot.common import save
from gearsweep.plot.sweep import plot_response_vs_speed

args = parse(__doc__)
ds = open_result(args.results, "whine_gear_table1")
fig = plot_response_vs_speed(ds, "p_rms", hue="damping")
ax = fig.axes[0]
ax.set_yscale("log")
flagged = ds["status"] != 0
if bool(flagged.any()):
    sel = ds["p_rms"].where(flagged)
    for c in ds["damping"].values:
        y = sel.sel(damping=c).values * 1e6
        if np.isfinite(y).any():
            ax.plot(ds["speed"].values, y, "x", color="C3", ms=4,
                    label="not settled (growing: parametric instability)")
    ax.legend(fontsize=8)
ax.set_title("Whine, p (Eq. 5) rms, k(t) from Table 1 (consistent) at 50 N m: k0 = 219 kN/mm,"
             " e(t) = 0\nm_eq = 0.1527 kg, 10 harmonics of k", fontsize=9)
print(save(fig, args.figures / "whine_gear_table1.png", dpi=150))

"""Counterpart of the experiment's Fig. 11: waterfall and mesh-order lines at driven speeds
200-800 rpm, from results/fig11_low_speed.nc.

The 48-tooth gear drives and the 32-tooth pinion (where the paper's magnetic pick-up sits) is
driven; the speed axes show the pinion's speed, mesh frequency x 60 / 32. Writes
figures/fig11_low_speed.png. Run from the repository root after
``gearsweep run studies/fig11_low_speed.yaml``:

    python scripts/fig11_low_speed.py [--results results] [--figures figures]
"""

from __future__ import annotations

import matplotlib.pyplot as plt
from _common import open_result, parse

from gearsweep.plot.common import save
from gearsweep.plot.whine import plot_order_lines, plot_waterfall

DRIVEN_TEETH = 32  # the pinion, braked by the powder clutch in the rig

args = parse(__doc__.splitlines()[0])
ds = open_result(args.results, "fig11_low_speed")
fig = plt.figure(figsize=(13.0, 6.0), layout="constrained")
grid = fig.add_gridspec(2, 2, width_ratios=[1.25, 1.0])
ax3 = fig.add_subplot(grid[:, 0], projection="3d")
plot_waterfall(ax3, ds, traces=31, driven_teeth=DRIVEN_TEETH)
ax3.view_init(elev=28, azim=-62)
ax3.set_title("waterfall of p (order 0, the mean of p, left out)", fontsize=9)
ax_d = fig.add_subplot(grid[0, 1])
plot_order_lines(ax_d, ds, driven_teeth=DRIVEN_TEETH)
ax_d.set_title("mesh orders 1-3: displacement of p", fontsize=9)
ax_d.set_xlabel("")
ax_v = fig.add_subplot(grid[1, 1], sharex=ax_d)
plot_order_lines(ax_v, ds, derivative=1, driven_teeth=DRIVEN_TEETH)
ax_v.set_title("the same lines as velocity, 2 pi f x amplitude\n(a magnetic pick-up's voltage"
               " follows velocity)", fontsize=9)
fig.suptitle("Fig. 11 counterpart: driven pinion (32 teeth) at 200-800 rpm = driving gear"
             " (48 teeth) at 133-533 rpm, mesh 107-427 Hz", fontsize=10)
print(save(fig, args.figures / "fig11_low_speed.png", dpi=150))

"""Work-precision chart from results/work_precision.nc (studies/work_precision.yaml): error
against cost for the fixed-step kernels and scipy's solvers, on the whine and rattle scenes.

    python scripts/fig_work_precision.py [--results results] [--figures figures]
"""

from __future__ import annotations

import matplotlib.pyplot as plt
from _common import open_result, parse

from gearsweep.plot.common import save
from gearsweep.plot.precision import plot_work_precision

args = parse(__doc__.splitlines()[0])
ds = open_result(args.results, "work_precision")
scenes = list(ds.scene.values)
fig, axs = plt.subplots(2, len(scenes), figsize=(6 * len(scenes), 9), layout="constrained",
                        squeeze=False)
for col, s in enumerate(scenes):
    for row, cost in enumerate(("wall_time", "rhs_evaluations")):
        plot_work_precision(axs[row, col], ds, scene=str(s), cost=cost, label_steps=row == 0)
fig.suptitle(f"{ds.attrs['title']}: labels on rk4 points are steps per mesh period; order = "
             "fitted slope of error against steps per period", fontsize=11)
save(fig, args.figures / "work_precision.png", dpi=120)
for s in scenes:
    for m in ds.method.values:
        order = float(ds.order.sel({"scene": s, "method": m}))
        print(f"order {s} {m}: {order:.2f}")

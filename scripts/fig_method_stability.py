"""Method stability chart from results/method_stability.nc (studies/method_stability.yaml): the
largest stable h omega_n of each kernel method, measured by integration with the batch kernel,
next to the value from the method's stability polynomial.

    python scripts/fig_method_stability.py [--results results] [--figures figures]
"""

from __future__ import annotations

from _common import open_result, parse

from gearsweep.plot.common import axes, save
from gearsweep.plot.precision import plot_method_stability

args = parse(__doc__.splitlines()[0])
ds = open_result(args.results, "method_stability")
fig, ax = axes(figsize=(7.5, 5))
plot_method_stability(ax, ds, rig_zeta=float(ds.attrs["paper_rig_zeta"]))
ax.set_title(f"{ds.attrs['title']}\n(free linear oscillator; the kink-aware forms take the same "
             "steps inside a contact region)", fontsize=10)
save(fig, args.figures / "method_stability.png")
for m in ds.method.values:
    for z, v in zip(ds.zeta.values, ds.measured_limit.sel({"method": m}).values, strict=True):
        print(f"{m} zeta={z:.3f} measured={v:.4f}")

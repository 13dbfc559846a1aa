"""Whine response versus speed with k(t) from the Table 1 gear pair (studies/whine_gear_table1.yaml).

Reads results/whine_gear_table1.nc; writes whine_gear_table1.png. Only settled cases are drawn:
a case not settled at the end of its window (status 2: at low damping the parametric instability
near twice the natural frequency, and the slowly decaying cases at its edges) has no steady value;
those are masked and counted.
"""

from _common import open_result, parse

from gearsweep.api import result_model
from gearsweep.plot.common import save
from gearsweep.plot.sweep import plot_response_vs_speed
from gearsweep.plot.whine import damping_labels

args = parse(__doc__)
ds = open_result(args.results, "whine_gear_table1")
model = result_model(ds)  # k0 of the gear pair, m_eq
k0, m = model.stiffness, model.mass
fig = plot_response_vs_speed(ds, "p_rms", hue="damping", hue_labels=damping_labels(ds))
ax = fig.axes[0]
ax.set_yscale("log")
bad = int((ds["status"] != 0).sum())
ax.set_title(f"{ds.attrs['title']}\nk0 = {k0 / 1e6:.0f} kN/mm (from the pair), m_eq = {m:g} kg;"
             f" {bad} of {ds['status'].size} cases not settled, masked\n(the parametric"
             " tongue near twice f_n and its slow edges: no steady value)", fontsize=9)
print(save(fig, args.figures / "whine_gear_table1.png", dpi=150))

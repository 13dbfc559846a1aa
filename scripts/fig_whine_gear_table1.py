"""Whine response versus speed with k(t) from the Table 1 gear pair (studies/whine_gear_table1.yaml).

Reads results/whine_gear_table1.nc; writes whine_gear_table1.png. Only settled cases are drawn:
a case not settled at the end of its window (status != 0) has no steady value; those are masked
and counted, and the title gives, per damping, the mesh frequencies at which they lie over the
natural frequency f_n (read from the result: at low damping they gather around twice f_n, the
principal parametric resonance, whose tongue docs/REPRODUCTION.md checks with Floquet
multipliers apart from this figure; where they span twice f_n the title says so and points
there: the result holds no multiplier to count the unstable ones by).
"""

from _common import open_result, parse

from gearsweep.api import result_model
from gearsweep.plot.common import save
from gearsweep.plot.sweep import plot_response_vs_speed
from gearsweep.plot.whine import damping_labels, natural_frequency

args = parse(__doc__)
ds = open_result(args.results, "whine_gear_table1")
model = result_model(ds)  # k0 of the gear pair, m_eq
k0, m = model.stiffness, model.mass
fig = plot_response_vs_speed(ds, "p_rms", hue="damping", hue_labels=damping_labels(ds))
ax = fig.axes[0]
ax.set_yscale("log")
unsettled = ds["status"] != 0
bad = int(unsettled.sum())
# where the unsettled cases lie, read from the result (the reason was typed: "the parametric
# tongue near twice f_n and its slow edges", true or not of the data drawn)
f_n = natural_frequency(ds)
where = []
near_tongue = False  # some damping's unsettled cases span twice f_n (the principal tongue's centre)
for c, label in zip(ds["damping"].values, damping_labels(ds), strict=True):
    f = ds["mesh_frequency"].values[unsettled.sel(damping=c).values] / f_n
    if f.size:
        where.append(f"{f.size} at {label.split(' (')[0]}, mesh frequency {f.min():.2f}-"
                     f"{f.max():.2f} f_n")
        near_tongue |= bool(f.min() <= 2.0 <= f.max())
# The result holds no Floquet multiplier (outputs: [stats]): which of them are unstable is
# docs/REPRODUCTION.md's finding (converged multipliers computed apart), not counted here
tongue = ("\nnot settled: most in the principal parametric tongue (docs/REPRODUCTION.md)"
          if near_tongue else "")
ax.set_title(f"{ds.attrs['title']}\nk0 = {k0 / 1e6:.0f} kN/mm (from the pair), m_eq = {m:g} kg,"
             f" f_n = {f_n / 1e3:.2f} kHz\n{bad} of {ds['status'].size} cases not settled,"
             " masked" + (f" ({'; '.join(where)})" if where else "") + tongue, fontsize=9)
print(save(fig, args.figures / "whine_gear_table1.png", dpi=150))

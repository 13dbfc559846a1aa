"""STE peak-to-peak and first harmonic versus load, with and without tip relief.

Reads results/mesh_ste_vs_load.nc (studies/mesh_ste_vs_load.yaml); writes mesh_ste_vs_load.png.
"""

from _common import open_result, parse

from gearsweep.plot.common import axes, save
from gearsweep.plot.mesh import plot_ste_vs_load

DESIGN_TORQUE = 50.0  # [N m] the load the study's relief was chosen for (Table 1's torque)

args = parse(__doc__)
ds = open_result(args.results, "mesh_ste_vs_load")
fig, ax = axes(figsize=(6.4, 4.0))
for variant in ds["variant"].values:
    v = ds.sel(variant=variant)
    pp = v["ste"].max("mesh_phase") - v["ste"].min("mesh_phase")
    plot_ste_vs_load(ax, v["torque"].values, pp.values, v["ste_harmonic"].sel(harmonic=1).values,
                     label=str(variant), design_torque=DESIGN_TORQUE)
ax.legend(loc="upper left", fontsize=8)
ax.set_title("STE versus load, Table 1 (consistent interpretation), z = 48/32, m = 2.5 mm",
             fontsize=9)
print(save(fig, args.figures / "mesh_ste_vs_load.png", dpi=150))

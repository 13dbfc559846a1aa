"""Figs. 1-3: STE, load sharing and the backlash spring of Table 1 (consistent) at 50 N m.

Reads results/fig01_02_mesh_cycle.nc (studies/fig01_02_mesh_cycle.yaml); writes fig01_ste.png,
fig02_load_sharing.png and fig03_backlash_stiffness.png; with results/table1_profile_shift.nc
(studies/table1_profile_shift.yaml) also mesh_table1_readings.png: STE and its harmonics of the
two readings of Table 1 (docs/mesh.md).
"""

import matplotlib.pyplot as plt
from _common import open_result, parse

from gearsweep.plot.common import axes, save
from gearsweep.plot.mesh import (
    plot_backlash_stiffness,
    plot_load_sharing,
    plot_ste,
    plot_ste_harmonics,
    plot_tip_relief,
)

args = parse(__doc__)
ds = open_result(args.results, "fig01_02_mesh_cycle")
torque = float(ds["torque"])
pair = f"Table 1 (consistent interpretation), z = 48/32, m = 2.5 mm, T = {torque:g} N m"

fig, ax = axes(figsize=(6.4, 4.0))
plot_ste(ax, ds)
ax.set_title(f"Fig. 1: static transmission error\n{pair}", fontsize=9)
ax.legend(loc="upper left", fontsize=8)
print(save(fig, args.figures / "fig01_ste.png", dpi=150))

fig, ax = axes(figsize=(6.4, 4.0))
plot_load_sharing(ax, ds)
ax.legend(loc="lower center", fontsize=8)
ax.set_title(f"Fig. 2: load sharing, contact ratio {float(ds['contact_ratio']):.2f}\n{pair}",
             fontsize=9)
print(save(fig, args.figures / "fig02_load_sharing.png", dpi=150))

k0 = float(ds["k_harmonic"].sel(harmonic=0))
backlash = float(ds["gear_backlash"])
fig, ax = axes(figsize=(6.4, 4.0))
plot_backlash_stiffness(ax, k0, backlash, mean_force=float(ds["mean_force"]))
ax.set_title(f"Fig. 3: mesh force with backlash; k = k0 computed for the Table 1 pair\n"
             f"at {torque:g} N m (the paper prints no k for Fig. 3), backlash"
             f" {backlash * 1e3:.3g} mm along the line of action", fontsize=9)
print(save(fig, args.figures / "fig03_backlash_stiffness.png", dpi=150))

shift = open_result(args.results, "table1_profile_shift")
readings = {f"consistent (eps = {float(ds['contact_ratio']):.3f})": ds,
            f"profile shift x = 0.48 / 0.52 (eps = {float(shift['contact_ratio']):.3f})": shift}
fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11.5, 4.0), layout="constrained",
                               width_ratios=[1.6, 1.0])
plot_tip_relief(ax1, readings)
ax1.legend(loc="upper left", fontsize=8)
ax1.set_title(f"STE of the two readings of Table 1 at {torque:g} N m", fontsize=9)
plot_ste_harmonics(ax2, {k: v["ste_harmonic"].values for k, v in readings.items()}, orders=5)
ax2.legend(fontsize=7)
ax2.set_title("STE harmonics", fontsize=9)
print(save(fig, args.figures / "mesh_table1_readings.png", dpi=150))

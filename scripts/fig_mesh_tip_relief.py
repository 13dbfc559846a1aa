"""STE through the mesh cycle and its harmonics without and with tip relief, at one torque.

Reads results/mesh_tip_relief.nc (studies/mesh_tip_relief.yaml); writes mesh_tip_relief.png.
"""

import matplotlib.pyplot as plt
from _common import open_result, parse

from gearsweep.plot.common import save
from gearsweep.plot.mesh import plot_ste_harmonics, plot_tip_relief

args = parse(__doc__)
ds = open_result(args.results, "mesh_tip_relief")
variants = [str(v) for v in ds["variant"].values]
fig, (ax, bx) = plt.subplots(1, 2, figsize=(9.6, 4.0), layout="constrained", width_ratios=[3, 2])
plot_tip_relief(ax, {v: ds.sel(variant=v) for v in variants})
ax.legend(fontsize=8)
ax.set_title("STE through the mesh cycle", fontsize=9)
plot_ste_harmonics(bx, {v: ds["ste_harmonic"].sel(variant=v).values for v in variants})
bx.legend(fontsize=8)
bx.set_title("STE Fourier amplitudes", fontsize=9)
fig.suptitle("Tip relief on both gears from the single-contact bounds to the tips, Table 1"
             f" (consistent interpretation), T = {float(ds['torque']):g} N m", fontsize=9)
print(save(fig, args.figures / "mesh_tip_relief.png", dpi=150))

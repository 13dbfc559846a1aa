"""Whine response versus speed for three mean forces (studies/whine_speed_sweep.yaml)."""

from _common import open_result, parse

from gearsweep.plot.common import save
from gearsweep.plot.sweep import plot_response_vs_speed

args = parse(__doc__)
ds = open_result(args.results, "whine_speed_sweep")
fig = plot_response_vs_speed(ds, "p_pp", hue="mean_force")
fig.axes[0].set_title("Dynamic transmission error p (Eq. 5), peak-to-peak, whine scene\n"
                      "m_eq = 0.1527 kg, c = 5.5 N s/mm, k0 = 1073 kN/mm + 3 harmonics, STE 5/1/0.3 um",
                      fontsize=9)
print(save(fig, args.figures / "whine_speed_sweep.png"))

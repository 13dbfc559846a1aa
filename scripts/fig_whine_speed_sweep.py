"""Whine response versus speed for three mean forces (studies/whine_speed_sweep.yaml).

Not a reproduction of a paper figure: its STE and stiffness harmonics past k1 are assumed (typed
in the study; the paper gives no STE numbers), as the title says.
"""

from _common import open_result, parse

from gearsweep import result_model
from gearsweep.plot.common import save
from gearsweep.plot.sweep import plot_response_vs_speed
from gearsweep.plot.whine import damping_text

args = parse(__doc__)
ds = open_result(args.results, "whine_speed_sweep")
fig = plot_response_vs_speed(ds, "p_pp", hue="mean_force")
model = result_model(ds)
n_k = len(model.stiffness_harmonics)  # the paper gives k0 and k1 only (Fig. 7.2)
past_k1 = (" is" if n_k < 2 else " and k2 are" if n_k == 2 else f" and k2-k{n_k} are")
fig.axes[0].set_title(
    f"{ds.attrs['title']}\nm_eq = {model.mass:g} kg, {damping_text(ds)}, k0 = {model.stiffness / 1e6:g}"
    f" kN/mm + {len(model.stiffness_harmonics)} harmonics, STE "
    + "/".join(f"{h.amplitude * 1e6:g}" for h in model.ste_harmonics) + " µm\n"
    f"the STE{past_k1} assumed (typed in the study; the paper gives no STE numbers):\n"
    "not a reproduction of a paper figure", fontsize=9)
print(save(fig, args.figures / "whine_speed_sweep.png"))

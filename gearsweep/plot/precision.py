"""Speed against accuracy: the work-precision chart and the methods' stability limits.

Both draw the Datasets of analysis studies (``studies/work_precision.yaml``,
``studies/method_stability.yaml``); nothing is computed here.
"""

from __future__ import annotations

import numpy as np
import xarray as xr
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from gearsweep.plot.common import axes, require

STYLES = {"rk4": ("C0", "o", "-"), "rk5": ("C1", "s", "-"), "rk4-kink": ("C2", "^", "--"),
          "rk5-kink": ("C3", "v", "--"), "RK45": ("C4", "x", ":"), "DOP853": ("C5", "+", ":"),
          "LSODA": ("C7", "d", ":")}
COSTS = {"wall_time": ("peer_wall_time", "wall time per case [s]"),
         "rhs_evaluations": ("peer_rhs_evaluations", "right-hand-side evaluations per case [1]")}


def plot_work_precision(ax: Axes, ds: xr.Dataset, *, scene: str, cost: str = "wall_time",
                        label_steps: bool = True) -> Figure:
    """Trajectory error against cost on one scene: every fixed-step method (fitted order in the
    legend) and every scipy peer. ``cost``: ``wall_time`` or ``rhs_evaluations``."""
    require(ds, ("trajectory_error", cost, "order"), "plot_work_precision",
            "studies/work_precision.yaml (analysis kind work_precision)")
    fig, ax = axes(ax)
    peer_cost, xlabel = COSTS[cost]
    sel = ds.sel(scene=scene)
    for m in sel.method.values:
        if scene == "whine" and str(m).endswith("-kink"):
            continue  # no backlash: the kink-aware step is the plain one
        c, mk, ls = STYLES[str(m)]
        order = float(sel.order.sel({"method": m}))
        lab = f"{m}  (order {order:.2f})" if np.isfinite(order) else str(m)
        x, e = sel[cost].sel({"method": m}).values, sel.trajectory_error.sel({"method": m}).values
        ax.loglog(x, e, color=c, marker=mk, ls=ls, label=lab)
        if label_steps and str(m) in ("rk4", "rk4-kink"):
            for spp, xi, yi in zip(sel.steps_per_period.values, x, e, strict=True):
                if np.isfinite(yi):
                    ax.annotate(str(spp), (xi, yi), fontsize=7, color=c, xytext=(3, 3),
                                textcoords="offset points")
    for p in sel.peer.values:
        c, mk, ls = STYLES[str(p)]
        ax.loglog(sel[peer_cost].sel(peer=p), sel.peer_trajectory_error.sel(peer=p), color=c,
                  marker=mk, ls=ls, label=f"scipy {p}")
    ax.set_xlabel(xlabel)
    ax.set_ylabel("trajectory error / amplitude [1]")
    rpm = float(sel.speed)
    ax.set_title(f"{scene} scene, {rpm:.0f} rpm (driving gear):\n{sel.scene_description.item()}",
                 fontsize=10)
    if scene == "whine":
        ax.text(0.98, 0.98, "rk4-kink, rk5-kink: identical to rk4, rk5\n(no backlash)",
                transform=ax.transAxes, ha="right", va="top", fontsize=8)
    ax.grid(True, which="major", alpha=0.3)
    ax.legend(fontsize=8, loc="lower left")
    return fig


def plot_method_stability(ax: Axes, ds: xr.Dataset, *, rig_zeta: float | None = None) -> Figure:
    """Largest stable h omega_n against the damping ratio: the stability polynomial (lines) and
    the kernel measured by integration (circles), per method."""
    require(ds, ("method", "zeta_curve", "polynomial_limit", "zeta", "measured_limit"),
            "plot_method_stability", "studies/method_stability.yaml (analysis kind"
            " method_stability)")
    fig, ax = axes(ax)
    for i, m in enumerate(ds.method.values):
        color = f"C{i}"
        ax.plot(ds.zeta_curve, ds.polynomial_limit.sel({"method": m}), color=color,
                label=f"{m}: stability polynomial, $|R(h\\lambda)| = 1$")
        ax.plot(ds.zeta, ds.measured_limit.sel({"method": m}), "o", mfc="none", color=color,
                label=f"{m}: measured by integration ({ds.attrs['steps']} steps)")
    if rig_zeta is not None:
        ax.axvline(rig_zeta, color="0.5", ls=":", lw=1)
        ax.text(rig_zeta + 0.005, 0.3, f"paper's rig\n$\\zeta$ = {rig_zeta:.3f}", fontsize=8,
                color="0.4")
    ax.set_xlabel("damping ratio $\\zeta = c\\,/\\,(2 m \\omega_n)$ [1]")
    ax.set_ylabel("largest stable $h\\,\\omega_n$ [1]")
    ax.set_ylim(0, 4)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="lower right")
    return fig

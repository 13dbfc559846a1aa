"""Fig. 5: waterfall of the whine response and its order/speed map (studies/fig05_waterfall.yaml).

Writes figures/fig05_waterfall.png (3-D waterfall: frequency x speed x amplitude) and
figures/fig05_campbell.png (order/speed colour map with the mesh orders the result keeps, 1-10,
and f_n, and the order lines), and figures/fig05_order_sources.png: the order lines of the study
and of its two variants
with the STE off (studies/fig05_waterfall_no_ste.yaml) and the stiffness ripple off
(studies/fig05_waterfall_no_ripple.yaml), which says where each order comes from, and
figures/fig05_phase.png: the phase of each mesh order the study keeps (1-10) behind the STE's
same order, one panel per order (the study and the ripple-off variant), which passes -90
degrees where the line is a resonance. Run from the
repository root after running the three studies:

    python scripts/fig05_waterfall.py [--results results] [--figures figures]
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from _common import open_result, parse

from gearsweep.plot.common import save
from gearsweep.plot.whine import (
    PHASE_FLOOR,
    damping_text,
    lost_speeds,
    natural_frequency,
    plot_campbell,
    plot_order_lines,
    plot_ste_phase_lags,
    plot_waterfall,
    shade_contact_lost,
)


def lost_text(ds: xr.Dataset) -> str:
    """``p < 0 (contact_lost) at N of M speeds, from S rpm up`` from the result (``from``: the
    lowest such speed; empty where no speed lost contact): what the grey of the figures marks."""
    lost = lost_speeds(ds)
    if lost is None or not lost.any():
        return ""
    speed = ds["speed"].values[lost]
    return (f"p < 0, teeth would part (contact_lost), at {int(lost.sum())} of {lost.size} speeds,"
            f" from {speed.min():,.0f} rpm up")


def mesh_orders(ds: xr.Dataset) -> tuple[int, ...]:
    """The whole mesh orders from 1 up that the result ``ds`` keeps (its spectrum's
    max_order): Fig. 5's STE has ten harmonics, and orders 5-10 are not small (orders 8-10 are
    what first part the teeth)."""
    return tuple(int(o) for o in ds["order"].values if o >= 1 and float(o).is_integer())


def two_columns(ax) -> None:
    """The order lines' legend (its title says how many cases were masked) in two columns at
    the lower right, where the ten lines leave room."""
    title = ax.get_legend().get_title().get_text()
    ax.legend(fontsize=6.5, ncols=2, loc="lower right", title=title or None, title_fontsize=6.5)


def draw(ds: xr.Dataset, figures: Path, suffix: str = "") -> None:
    """Write fig05_waterfall{suffix}.png and fig05_campbell{suffix}.png from one result."""
    f_n = natural_frequency(ds)
    orders = mesh_orders(ds)
    teeth = int(round(float(ds.mesh_frequency[-1] / ds.speed[-1] * 60)))
    fig = plt.figure(figsize=(8.0, 6.4), layout="constrained")
    ax = fig.add_subplot(projection="3d")
    plot_waterfall(ax, ds, traces=40, natural_frequency_hz=f_n)
    ax.view_init(elev=28, azim=-62)
    ax.set_title(f"{ds.attrs['title']}\np of Eq. (9): r1 theta1 - r2 theta2 - e(t) (docs/data-format.md)"
                 f"\n{damping_text(ds)}; 40 of {ds.sizes['speed']} speeds drawn; mesh orders"
                 f" {orders[0]}-{orders[-1]} (order 0, the mean of p, left out)"
                 + (f"\ngrey floor: {lost_text(ds)}" if lost_text(ds) else ""),
                 fontsize=9)
    print(save(fig, figures / f"fig05_waterfall{suffix}.png", dpi=150))

    fig, (ax, ax2) = plt.subplots(2, 1, figsize=(8.0, 7.6), sharex=True,
                                  height_ratios=[1.4, 1.0], layout="constrained")
    plot_campbell(ax, ds, natural_frequency_hz=f_n, orders=orders)
    ax.set_title(f"{ds.attrs['title']}; {damping_text(ds)}\ndashed: order f_n / f_mesh,"
                 f" f_n = sqrt(k0/m)/2pi; circles: order n meets f_n at 60 f_n / ({teeth} n) rpm",
                 fontsize=9)
    ax.set_xlabel("")
    plot_order_lines(ax2, ds, orders=orders, log=True)
    for n in orders:
        ax2.axvline(60 * f_n / (teeth * n), color="0.4", ls=":", lw=0.8)
    ax2.set_ylim(1e-3, None)
    two_columns(ax2)
    grey = "; grey: p < 0 somewhere in the cycle" if bool(ds.get("contact_lost", False).any()) else ""
    ax2.set_title(f"the mesh-order lines {orders[0]}-{orders[-1]}; dotted: 60 f_n / ({teeth} n){grey}",
                  fontsize=9)
    print(save(fig, figures / f"fig05_campbell{suffix}.png", dpi=150))


def draw_sources(results: Path, figures: Path) -> None:
    """fig05_order_sources.png: the mesh orders of the study and of its two variants."""
    names = ("fig05_waterfall", "fig05_waterfall_no_ste", "fig05_waterfall_no_ripple")
    sets = [open_result(results, n) for n in names]
    fig, axs = plt.subplots(1, 3, figsize=(13.5, 4.4), sharey=True, layout="constrained")
    for ax, ds, tag in zip(axs, sets, "abc", strict=True):
        f_n = natural_frequency(ds)
        teeth = int(round(float(ds.mesh_frequency[-1] / ds.speed[-1] * 60)))
        orders = mesh_orders(ds)
        plot_order_lines(ax, ds, orders=orders, log=True)
        for n in orders:
            ax.axvline(60 * f_n / (teeth * n), color="0.4", ls=":", lw=0.8)
        two_columns(ax)
        ax.set_title(f"({tag}) {ds.attrs['title']}\n{damping_text(ds)}", fontsize=8.5, loc="left")
    # down to the decade under the smallest peak drawn: below 1e-4 um orders 8-10 of (b), the STE
    # off, were in the legend but not on the axes
    peaks = [np.nanmax(ln.get_ydata()) for ax in axs for ln in ax.get_lines()
             if ln.get_label().startswith("order ")]
    axs[0].set_ylim(min(1e-4, 10 ** np.floor(np.log10(min(peaks)))), 10)
    fig.suptitle("Where the mesh orders of Fig. 5 come from: the study, the STE off, the ripple"
                 " off; dotted: 60 f_n / (48 n)", fontsize=10)
    print(save(fig, figures / "fig05_order_sources.png", dpi=150))


def draw_phase(results: Path, figures: Path) -> None:
    """fig05_phase.png: the lag of each mesh order the study keeps (1-10) behind the STE's same
    order, one panel per order, the study and its ripple-off variant: a resonance of the STE's
    forcing passes -90 degrees at 60 f_n / (48 n). A speed where the order's line is below
    ``PHASE_FLOOR`` of the largest mesh-order line there is left blank."""
    study = open_result(results, "fig05_waterfall")
    flat = open_result(results, "fig05_waterfall_no_ripple")
    f_n = natural_frequency(study)
    teeth = int(round(float(study.mesh_frequency[-1] / study.speed[-1] * 60)))
    orders = mesh_orders(study)
    cols = 5
    rows = -(-len(orders) // cols)
    fig, axs = plt.subplots(rows, cols, figsize=(15.0, 3.2 * rows + 1.0), sharex=True,
                            sharey=True, layout="constrained", squeeze=False)
    for k, (ax, n) in enumerate(zip(axs.flat, orders, strict=False)):
        plot_ste_phase_lags(ax, study, orders=(n,), color="C0", label=": the study")
        plot_ste_phase_lags(ax, flat, orders=(n,), color="C1", linestyle="--",
                            label=": ripple off")
        ax.axvline(60 * f_n / (teeth * n), color="0.4", ls=":", lw=0.8)
        shade_contact_lost(ax, study)  # (the study's: the solid lines)
        ax.set_xscale("log")
        ax.set_title(f"order {n}: 60 f_n / ({teeth} x {n}) = {60 * f_n / (teeth * n):,.0f} rpm",
                     fontsize=8.5)
        if k % cols:
            ax.set_ylabel("")
        elif k:
            ax.set_ylabel("phase [deg]")
        if k < len(orders) - cols:
            ax.set_xlabel("")
        else:
            ax.set_xlabel("driving-gear speed [rpm]")
    for ax in list(axs.flat)[len(orders):]:
        ax.set_visible(False)
    axs.flat[0].legend(fontsize=7.5, loc="lower left")
    fig.suptitle(f"Fig. 5's order lines {orders[0]}-{orders[-1]}: phase of p relative to the STE's"
                 f" same order; {damping_text(study)}; solid: the study, dashed: stiffness ripple"
                 f" off\ndotted: 60 f_n / ({teeth} n), where a resonance of a force in phase with e"
                 " passes -90 deg (-m e'' or the ripple under F_m: not told apart); a speed where"
                 f" the order's line is below {PHASE_FLOOR:.0%} of the largest mesh-order line is"
                 " left blank"
                 + (f"\ngrey: the study's {lost_text(study)}" if lost_text(study) else ""),
                 fontsize=9.5)
    print(save(fig, figures / "fig05_phase.png", dpi=150))


if __name__ == "__main__":
    args = parse(__doc__.splitlines()[0])
    draw(open_result(args.results, "fig05_waterfall"), args.figures)
    draw_sources(args.results, args.figures)
    draw_phase(args.results, args.figures)

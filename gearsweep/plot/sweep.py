"""Response versus speed: the amplitude of p over a speed sweep, one line per other value."""

from __future__ import annotations

import numpy as np
import xarray as xr
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from gearsweep.plot.common import UM, axes


def _label(ds: xr.Dataset, dim: str, value) -> str:
    units = ds[dim].attrs.get("units", "")
    if isinstance(value, float | np.floating):
        return f"{dim.replace('_', ' ')} = {value:g} {units}".strip()
    return f"{dim} = {value}"


def plot_response_vs_speed(ds: xr.Dataset, var: str = "p_pp", ax: Axes | None = None,
                           hue: str | None = None, secondary_mesh_axis: bool = True) -> Figure:
    """Plot ``var`` [um] over ``speed`` [rpm], one line per value of ``hue`` (and direction).

    Parameters
    ----------
    ds : Dataset
        A result with a ``speed`` dim and ``var`` in metres.
    var : str
        ``p_pp``, ``p_rms``, ``p_max``, ...
    hue : str, optional
        The other swept dim to draw one line per value of (default: the first one).
    """
    fig, ax = axes(ax)
    da = ds[var]
    others = [d for d in da.dims if d not in ("speed", "direction")]
    if hue is None and others:
        hue = others[0]
    for d in others:
        if d != hue:
            da = da.isel({d: 0})
    dirs = list(ds["direction"].values) if "direction" in da.dims else [None]
    hues = list(ds[hue].values) if hue else [None]
    colors = matplotlib_colors(len(hues))
    for i, hv in enumerate(hues):
        for dv in dirs:
            sel = da
            if hue:
                sel = sel.sel({hue: hv})
            if dv is not None:
                sel = sel.sel(direction=dv)
            style = {"up": dict(ls="-", marker="^", ms=3), "down": dict(ls="--", marker="v", ms=3)
                     }.get(dv, dict(ls="-"))
            label = ", ".join(x for x in (_label(ds, hue, hv) if hue else "",
                                          f"run-{dv}" if dv else "") if x)
            ax.plot(ds["speed"].values, sel.values * UM, color=colors[i], label=label or None,
                    lw=1.2, **style)
    name = ds[var].attrs.get("long_name", var)
    ax.set_xlabel("driving-gear speed [rpm]")
    ax.set_ylabel(f"{var.replace('_', ' ')} [um]")
    ax.set_title(name, fontsize=10)
    ax.grid(True, alpha=0.3)
    if hue or dirs != [None]:
        ax.legend(fontsize=8)
    if secondary_mesh_axis and "mesh_frequency" in ds.coords:
        ratio = float(ds["mesh_frequency"].values[-1] / ds["speed"].values[-1])
        sec = ax.secondary_xaxis("top", functions=(lambda s: s * ratio, lambda f: f / ratio))
        sec.set_xlabel("mesh frequency [Hz]")
    return fig


def matplotlib_colors(n: int) -> list:
    import matplotlib.pyplot as plt

    cmap = plt.get_cmap("viridis")
    return [cmap(x) for x in np.linspace(0.0, 0.85, max(n, 1))]

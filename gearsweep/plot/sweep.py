"""Response versus speed: the amplitude of p over a speed sweep, one line per other value."""

from __future__ import annotations

import numpy as np
import xarray as xr
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from gearsweep.plot.common import UM, axes
from gearsweep.units import KINDS, si_data_vars


def value_label(ds: xr.Dataset, dim: str, value) -> str:
    """``dim = value unit`` for a legend (damping in N s/mm, a CF unit as written in a study)."""
    units = ds[dim].attrs.get("units", "")
    if dim == "damping" and units in ("N s/m", "N s m-1"):
        return f"c = {value / 1e3:g} N s/mm"
    if dim == "damping" and units == "N s mm-1":
        return f"c = {value:g} N s/mm"
    units = {k.cf: k.examples[0] for k in KINDS.values()}.get(units, units)  # N s mm-1: N s/mm
    if isinstance(value, float | np.floating):
        return f"{dim.replace('_', ' ')} = {value:g} {units}".strip()
    return f"{dim} = {value}"


def speed_label(speed: xr.DataArray) -> str:
    """Axis label of a ``speed`` coordinate from its attributes: which shaft, and the unit."""
    gear = speed.attrs.get("gear")
    name = f"speed of the {gear}" if gear else speed.attrs.get("long_name", "speed")
    return f"{name} [{speed.attrs.get('units', 'rpm')}]"


def settled(da: xr.DataArray, ds: xr.Dataset) -> tuple[xr.DataArray, int, int]:
    """``da`` where the case settled (``status == 0``), NaN elsewhere; and the number of masked
    cases and of all cases of ``da``'s shape (a steady-state value of a case that has not settled
    is not a curve point)."""
    if "status" not in ds:
        return da, 0, int(da.size)
    ok = (ds["status"] == 0).broadcast_like(da)
    return da.where(ok), int((~ok).sum()), int(ok.size)


CONTACT_LOST = "p < 0: teeth would part (contact_lost)"
"""What the grey of a figure marks: the cases (a line's band) or speeds (a span) where p fell
below 0 in the steady state (``contact_lost``): the drive flanks part, and a linear scene answers
there for a pair with no backlash, not for a real pair, whose teeth would separate."""


def contact_lost(da: xr.DataArray, ds: xr.Dataset) -> xr.DataArray:
    """Bool like ``da``: did the case lose contact (``ds["contact_lost"]``)? False everywhere
    where the result has no ``contact_lost`` (a rattle scene, a result without stats)."""
    if "contact_lost" not in ds:
        return xr.zeros_like(da, dtype=bool)
    return ds["contact_lost"].astype(bool).broadcast_like(da)


def mark_contact_lost(ax: Axes, x, y, lost, *, label: str | None = None) -> int:
    """A grey band under the points of the line ``(x, y)`` whose case lost contact (``lost``;
    points not drawn, NaN, are not marked), below the line; ``label``: its legend entry. The
    same grey as the spans of ``plot_order_lines`` over the speeds where a case lost contact.
    Returns the number of points marked."""
    y = np.asarray(y, float)
    mark = np.asarray(lost, bool) & np.isfinite(y)
    if not mark.any():
        return 0
    ax.plot(x, np.where(mark, y, np.nan), color="0.78", lw=6.0, marker="o", ms=5.0, mew=0.0,
            solid_capstyle="round", zorder=1.5, label=label)  # (markers: a lone point shows)
    return int(mark.sum())


def mark_contact_lost_lines(ax: Axes, x, bands, label: str) -> int:
    """``mark_contact_lost`` for each ``(y, lost)`` of ``bands``, the first band drawn with
    ``label`` (one legend entry); the number of points marked."""
    n = 0
    for y, lost in bands:
        n += mark_contact_lost(ax, x, y, lost, label=None if n else label)
    return n


def contact_lost_label(n_lost: int, n_all: int, what: str = "cases drawn") -> str:
    """The legend entry of the grey bands: what they mean and how many points they mark."""
    return f"grey: {CONTACT_LOST},\n{n_lost} of {n_all} {what}"


DIRECTION_STYLE = {"up": dict(ls="-", marker="^", ms=3), "down": dict(ls="--", marker="v", ms=3)}
"""How a line of a continued sweep's run-up and run-down is drawn (``direction``)."""


def check_dataset(ds, call: str, var: str) -> None:
    """One line (``ValueError``) where ``ds`` is not a result's Dataset: a variable alone
    (``ds.p_rms``, a natural notebook slip) lacks the ``status`` that masks the cases not
    settled, and gave an error of another argument. ``call``: the call to advise, with ``{}``
    for the variable's name (the DataArray's own, else ``var``)."""
    if not isinstance(ds, xr.Dataset):
        name = ds.name if isinstance(ds, xr.DataArray) and ds.name else var
        given = f" ({ds.name!r})" if isinstance(ds, xr.DataArray) and ds.name else ""
        raise ValueError(f"ds: a result's Dataset, with the variable named apart"
                         f" ({call.format(repr(str(name)))}), not a {type(ds).__name__}{given}")


def hold_first(ds: xr.Dataset, dims) -> tuple[xr.Dataset, list[str]]:
    """``ds`` at the first value of each of ``dims`` (dims a plot draws no line per value of),
    and a ``value_label`` of each, for ``at_title``."""
    fixed = []
    for d in dims:
        fixed.append(value_label(ds, d, ds[d].values[0]))
        ds = ds.isel({d: 0})
    return ds, fixed


def at_title(name: str, fixed: list[str]) -> str:
    """A title that names the values ``hold_first`` drew the other swept dims at."""
    return name + (f" at {', '.join(fixed)} (select others with ds.sel)" if fixed else "")


def plot_response_vs_speed(ds: xr.Dataset, var: str = "p_pp", ax: Axes | None = None,
                           hue: str | None = None, secondary_mesh_axis: bool = True,
                           hue_labels: list[str] | None = None) -> Figure:
    """Plot ``var`` over ``speed`` [rpm], one line per value of ``hue`` (and direction): a
    displacement in µm, anything else in its own unit.

    Only settled cases (``status == 0``) are drawn; the others are masked and counted in the
    legend title. Drawn cases that lost contact (``contact_lost``: p < 0, the linear scene
    answers for a pair with no backlash) lie on a grey band, counted in its legend entry.

    Parameters
    ----------
    ds : Dataset
        A result with a ``speed`` dim and ``var`` (in the unit its ``units`` attribute says: µm
        in a result file; drawn in µm).
    var : str
        ``p_pp``, ``p_rms``, ``p_max``, ...
    hue : str, optional
        The other swept dim to draw one line per value of (default: the first one). Any further
        swept dim is drawn at its first value, named in the title (``ds.sel`` another first).
    hue_labels : list of str, optional
        Legend labels of the ``hue`` values (default: name = value unit).
    """
    check_dataset(ds, "plot_response_vs_speed(ds, {})", var)
    if "speed" not in ds.dims or var not in ds.data_vars or "speed" not in ds[var].dims:
        raise ValueError(f"plot_response_vs_speed draws a variable over a 'speed' sweep: this"
                         f" result has {'no ' + repr(var) if var not in ds.data_vars else ''}"
                         f"{' over speed' if var in ds.data_vars else ''} (dims"
                         f" {tuple(ds.dims)})")
    fig, ax = axes(ax)
    ds = si_data_vars(ds)  # a result stores display units (p in um): here SI
    others = [d for d in ds[var].dims if d not in ("speed", "direction")]
    if hue is not None and hue not in others:
        raise ValueError(f"hue={hue!r}: " + (f"one of the other swept dims of {var!r}: {others}"
                                              if others else f"{var!r} has no other swept dim"))
    if hue is None and others:
        hue = others[0]
    ds, fixed = hold_first(ds, [d for d in others if d != hue])  # said so in the title
    # masked and counted among the cases drawn (it counted those of the dims held fixed too)
    da, n_masked, n_all = settled(ds[var], ds)
    lost_all = contact_lost(da, ds)
    # A displacement (SI here) is drawn in um; anything else (a fraction, a count) as it is,
    # in its own unit (contact_loss_fraction was drawn times 1e6 and labelled um; an API test)
    metres = da.attrs.get("units") == "m"
    scale, unit = (UM, "µm") if metres else (1.0, da.attrs.get("units", ""))
    dirs = list(ds["direction"].values) if "direction" in da.dims else [None]
    hues = list(ds[hue].values) if hue else [None]
    colors = matplotlib_colors(len(hues))
    bands = []  # (y, lost) of each line: drawn after the lines (the legend entry comes last)
    for i, hv in enumerate(hues):
        for dv in dirs:
            sel, lost = da, lost_all
            if hue:
                sel, lost = sel.sel({hue: hv}), lost.sel({hue: hv})
            if dv is not None:
                sel, lost = sel.sel(direction=dv), lost.sel(direction=dv)
            bands.append((sel.values * scale, lost.values))
            style = DIRECTION_STYLE.get(dv, dict(ls="-"))
            lab = (hue_labels[i] if hue_labels else value_label(ds, hue, hv)) if hue else ""
            label = ", ".join(x for x in (lab,
                                          f"run-{dv}" if dv else "") if x)
            ax.plot(ds["speed"].values, sel.values * scale, color=colors[i],
                    label=label or None, lw=1.2, zorder=2, **style)
    n_lost = int((lost_all & da.notnull()).sum())  # of the points drawn (as the other plot)
    mark_contact_lost_lines(ax, ds["speed"].values, bands,
                            contact_lost_label(n_lost, int(da.notnull().sum())))
    name = ds[var].attrs.get("long_name", var)
    ax.set_xlabel(speed_label(ds["speed"]))
    ax.set_ylabel(f"{name} [{unit}]" if unit else name)
    ax.set_title(at_title(name, fixed), fontsize=10)
    ax.grid(True, alpha=0.3)
    note = f"{n_masked} of {n_all} cases not settled (masked)" if n_masked else None
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=8, title=note, title_fontsize=8)
    elif note:  # nothing labelled (no hue, no direction, nothing drawn): legend() warned "No
        # artists with labels found" (an outside tester's finding); the count on the axes
        ax.text(0.98, 0.97, note, transform=ax.transAxes, ha="right", va="top", fontsize=8)
    if secondary_mesh_axis and "mesh_frequency" in ds.coords:
        ratio = float(ds["mesh_frequency"].values[-1] / ds["speed"].values[-1])
        sec = ax.secondary_xaxis("top", functions=(lambda s: s * ratio, lambda f: f / ratio))
        sec.set_xlabel("mesh frequency [Hz]")
    return fig


def matplotlib_colors(n: int) -> list:
    import matplotlib.pyplot as plt

    cmap = plt.get_cmap("viridis")
    return [cmap(x) for x in np.linspace(0.0, 0.85, max(n, 1))]

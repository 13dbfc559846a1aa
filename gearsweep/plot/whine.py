"""Whine figures from study results: waterfall (Fig. 5, Fig. 11), order/speed map (Campbell-style)
and response versus speed for several mean torques (Fig. 6).

Every function takes a matplotlib ``ax`` and a result Dataset of ``gearsweep run`` (docs/data-format.md names:
``spectrum`` on ``(speed, order)`` with ``frequency`` and ``mesh_frequency`` coordinates, ``p_rms``
...), draws on ``ax`` and returns its figure. Data are in SI units; axes are labelled in
engineering units (um, mm/s, kHz, rpm). ``plot_waterfall`` needs a 3-D axes
(``fig.add_subplot(projection="3d")``).
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence

import matplotlib
import numpy as np
import xarray as xr
from matplotlib.axes import Axes
from matplotlib.colors import LogNorm
from matplotlib.figure import Figure
from matplotlib.patches import Patch
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

from gearsweep.analysis.spectrum import wrap_phase
from gearsweep.model import model_from_record
from gearsweep.plot.sweep import (
    CONTACT_LOST,
    DIRECTION_STYLE,
    at_title,
    check_dataset,
    contact_lost,
    contact_lost_label,
    hold_first,
    mark_contact_lost_lines,
    settled,
    value_label,
)
from gearsweep.units import si_data_vars, si_values

__all__ = [
    "damping_labels",
    "driven_speed",
    "lost_speeds",
    "lowest_in_contact",
    "natural_frequency",
    "plot_campbell",
    "plot_order_lines",
    "plot_response_by_load",
    "plot_order_by_variant",
    "plot_waterfall",
    "result_natural_frequency",
    "shade_contact_lost",
    "stiffness_label",
]

UM = 1e6  # m -> um


def natural_frequency(ds: xr.Dataset) -> float:
    """Undamped natural frequency f_n = sqrt(k0 / m_eq) / (2 pi) [Hz] of the study in ``ds``.

    Read from the resolved model the result file carries (``attrs["model"]``), so a figure
    marks the frequency of the run that made it (a gear scene that sweeps its load: k0 at the
    first load; ``result_natural_frequency`` reads the selected case's, or gives None).
    """
    model = model_from_record(json.loads(ds.attrs["model"]))
    return math.sqrt(model.stiffness / model.mass) / (2 * math.pi)


def result_natural_frequency(ds: xr.Dataset) -> float | None:
    """f_n = sqrt(k0 / m_eq) / (2 pi) [Hz] from what a result carries, or None where it does not
    give one: the resolved model (``attrs["model"]``: m_eq ``mass``, k0 ``stiffness``, SI); where
    the study sweeps one of them (``attrs["model_swept"]``), the value ``ds`` has selected, a
    scalar ``stiffness`` or ``mass`` coordinate, or a gear scene's ``gear_stiffness`` (k0 at the
    load) of one load. None for a Mathieu scene, a result without a model (a mesh study) or a
    swept k0 or m_eq not selected."""
    if "model" not in ds.attrs:
        return None
    record = json.loads(ds.attrs["model"])
    if record.get("kind") == "mathieu":
        return None
    swept = set(ds.attrs.get("model_swept", "").split())
    k_m = []
    for name in ("stiffness", "mass"):
        if name not in swept:
            k_m.append(float(record.get(name, math.nan)))
        elif name in ds.coords and ds[name].ndim == 0:
            k_m.append(float(si_values(ds[name])))
        elif name == "stiffness" and "gear_stiffness" in ds and ds["gear_stiffness"].ndim == 0:
            k_m.append(float(si_values(ds["gear_stiffness"])))
        else:
            return None
    k0, mass = k_m
    if not (math.isfinite(k0) and math.isfinite(mass) and k0 > 0 and mass > 0):
        return None
    return math.sqrt(k0 / mass) / (2 * math.pi)


def damping_labels(ds: xr.Dataset) -> list[str]:
    """``c = ... N s/mm (ζ = ...)`` for each ``damping`` of a result: ζ = c / (2 sqrt(k0 m_eq))
    with the resolved model's m_eq and k0 (a gear scene's ``gear_stiffness``, the largest over
    its loads when it sweeps torque)."""
    model = model_from_record(json.loads(ds.attrs["model"]))
    k0 = float(si_values(ds["gear_stiffness"]).max()) if "gear_stiffness" in ds else model.stiffness
    return [f"c = {c / 1e3:g} N s/mm (ζ = {c / (2 * math.sqrt(k0 * model.mass)):.3f})"
            for c in si_values(ds["damping"])]


def damping_text(ds: xr.Dataset) -> str:
    """``c = ... N s/mm, ζ = ...`` of a result whose damping is not swept, from its resolved
    model (ζ = c / (2 sqrt(k0 m_eq)); a gear scene that sweeps the load: k0 at the first load,
    as ``natural_frequency``)."""
    model = model_from_record(json.loads(ds.attrs["model"]))
    zeta = model.damping / (2 * math.sqrt(model.stiffness * model.mass))
    return f"c = {model.damping / 1e3:g} N s/mm, ζ = {zeta:.3f}"


def driven_speed(ds: xr.Dataset, driven_teeth: int) -> np.ndarray:
    """Speed of the driven gear [rpm]: mesh frequency x 60 / its teeth (z1 n1 = z2 n2)."""
    return ds["mesh_frequency"].values * 60.0 / driven_teeth


def _speed_axis(ds: xr.Dataset, driven_teeth: int | None) -> tuple[np.ndarray, str]:
    if driven_teeth is None:
        return ds["speed"].values, "speed of the driving gear [rpm]"
    return driven_speed(ds, driven_teeth), f"speed of the driven gear ({driven_teeth} teeth) [rpm]"


def _on_speed_and_order(ds: xr.Dataset, variable: str, what: str) -> xr.DataArray:
    """``ds[variable]``, checked to be on (speed, order) only: one line naming the fix (a
    spectrum over torque too gave xarray's transpose error)."""
    if variable not in ds.data_vars:
        raise ValueError(f"{what} draws {variable!r}, which this result lacks (a study with"
                         " outputs: [spectrum])")
    da = ds[variable]
    if "speed" not in da.dims or "order" not in da.dims or da.ndim != 2:
        others = [d for d in da.dims if d not in ("speed", "order")]
        raise ValueError(f"{what} draws {variable} on (speed, order) only, got {da.dims}"
                         + (f": select one value of {others} first (ds.isel({others[0]}=0))"
                            if others else ""))
    return da


def _known_orders(ds: xr.Dataset, orders: Sequence[float], what: str) -> None:
    missing = [n for n in orders if float(n) not in set(ds["order"].values.tolist())]
    if missing:
        raise ValueError(f"{what}: order(s) {missing} are not in this spectrum (orders"
                         f" {float(ds['order'].min()):g}-{float(ds['order'].max()):g}: the"
                         " study's spectrum max_order)")


_ABOVE_FLOOR = 10
"""zorder of a waterfall's lines: a 3-D axes draws its collections (the grey floor) above the
axis, at its zorder + 1 and up, and its lines at their own zorder (2 by default: under it)."""


def plot_waterfall(
    ax: Axes,
    ds: xr.Dataset,
    *,
    traces: int = 40,
    x: str = "frequency",
    variable: str = "spectrum",
    driven_teeth: int | None = None,
    skip_mean: bool = True,
    natural_frequency_hz: float | None = None,
    zlabel: str | None = None,
) -> Figure:
    """3-D waterfall (paper Fig. 5 and Fig. 11): amplitude over frequency, one trace per speed.

    Parameters
    ----------
    ax : Axes3D
        A 3-D axes.
    ds : Dataset
        A result with ``variable`` on ``(speed, order)``.
    traces : int
        Number of speeds drawn, evenly picked from the study's speeds [-].
    x : {"frequency", "order"}
        Horizontal axis: frequency [kHz or Hz] or mesh order [-].
    variable : str
        ``spectrum`` (µm in a result file, any length unit its ``units`` says; drawn in µm)
        or ``force_spectrum`` [N].
    driven_teeth : int, optional
        Label the speed axis with the driven gear's speed (mesh frequency x 60 / teeth).
    skip_mean : bool
        Leave out order 0 (the mean of p, about F_m / k0, would dwarf the lines).
    natural_frequency_hz : float, optional
        Draw f_n [Hz] on the floor of the plot (dashed), where the order lines resonate.
    zlabel : str, optional
        Label of the amplitude axis (default: from the variable: p in µm or a force in N).

    Only settled cases (``status == 0``) are drawn: a trace of a case that has not settled is
    left empty, and the number of such traces is written in the axes' lower left corner.

    Speeds where the result marks ``contact_lost`` (p below 0 in the steady state: the drive
    flanks part, and the linear scene stands for a pair with no backlash) are grey on the floor
    of the plot, across the frequency axis, with one legend entry that counts them (the grey
    spans of ``plot_order_lines``).
    """
    if not hasattr(ax, "set_zlabel"):  # else it drew, then failed on the z label
        raise TypeError("plot_waterfall draws on a 3-D axes: fig.add_subplot(projection='3d')")
    ds = si_data_vars(ds)  # a result stores display units (p in um): here SI
    da = _on_speed_and_order(ds, variable, "plot_waterfall")
    speed, speed_label = _speed_axis(ds, driven_teeth)
    pick = np.unique(np.linspace(0, len(speed) - 1, traces).round().astype(int))
    # a case that has not settled is no trace (as in every other plot), counted among the drawn
    da, _, _ = settled(da, ds)
    n_bad = (int((ds["status"] != 0).broadcast_like(ds["speed"]).values[pick].sum())
             if "status" in ds else 0)
    orders = ds["order"].values
    cols = orders > 0 if skip_mean else np.ones(orders.shape, bool)
    is_force = da.attrs.get("units") == "N"
    scale = 1.0 if is_force else UM
    f_max = float(ds["frequency"].max()) if x == "frequency" else 0.0
    f_scale, f_unit = (1e-3, "kHz") if f_max > 5e3 else (1.0, "Hz")
    cmap = matplotlib.colormaps["viridis"]
    for q, i in enumerate(pick):
        amp = da.values[i, cols] * scale
        xs = (ds["frequency"].values[i, cols] * f_scale if x == "frequency" else orders[cols])
        ax.plot(xs, np.full(xs.shape, speed[i]), amp, lw=0.8, zorder=_ABOVE_FLOOR,
                color=cmap(0.9 * q / max(len(pick) - 1, 1)))
    x_lo, x_hi = ((float(ds["frequency"].min()) * f_scale, f_max * f_scale) if x == "frequency"
                  else (float(orders[cols][0]), float(orders[cols][-1])))
    lost = lost_speeds(ds)
    handles = []
    if lost is not None and lost.any():  # grey floor strips, as plot_order_lines's spans
        strips = [[(x_lo, lo, 0.0), (x_hi, lo, 0.0), (x_hi, hi, 0.0), (x_lo, hi, 0.0)]
                  for lo, hi in _lost_spans(speed, lost)]
        ax.add_collection3d(Poly3DCollection(strips, facecolor="0.75", edgecolor="none",
                                             alpha=0.6))
        handles.append(Patch(facecolor="0.75", alpha=0.6, label=contact_lost_label(
            int(lost.sum()), speed.size, "speeds")))
    if natural_frequency_hz is not None:
        f_line = (np.full(speed.shape, natural_frequency_hz * f_scale) if x == "frequency"
                  else natural_frequency_hz / ds["mesh_frequency"].values)
        keep = f_line <= (float(ds["frequency"].max()) * f_scale if x == "frequency"
                          else float(orders[-1]))
        handles.insert(0, ax.plot(f_line[keep], speed[keep], np.zeros(int(keep.sum())),
                                  color="tab:red", ls="--", lw=1.0, zorder=_ABOVE_FLOOR,
                                  label=f"f_n = {natural_frequency_hz / 1e3:.2f} kHz")[0])
    if handles:
        ax.legend(handles=handles, loc="upper left", fontsize=8)
    if n_bad:
        ax.text2D(0.02, 0.02, f"{n_bad} of {len(pick)} speeds drawn not settled (masked: no"
                  " trace)", transform=ax.transAxes, fontsize=8)
    ax.set_xlabel(f"frequency [{f_unit}]" if x == "frequency" else "mesh order [-]")
    ax.set_ylabel(speed_label)
    ax.set_zlabel(zlabel or ("force amplitude [N]" if is_force else "amplitude of p [µm]"))
    return ax.figure


def plot_campbell(
    ax: Axes,
    ds: xr.Dataset,
    *,
    variable: str = "spectrum",
    orders: Sequence[int] = (1, 2, 3),
    natural_frequency_hz: float | bool | None = None,
    floor: float = 1e-3,
    driven_teeth: int | None = None,
    skip_mean: bool = True,
) -> Figure:
    """Order/speed colour map of the spectrum (Campbell-style) with mesh orders and f_n marked.

    Parameters
    ----------
    ax : Axes
    ds : Dataset
        A result with ``variable`` on ``(speed, order)``.
    variable : str
        ``spectrum`` (µm in a result file, any length unit its ``units`` says; shown in µm)
        or ``force_spectrum`` [N].
    orders : sequence of int
        Mesh orders labelled at the right edge [-] (no line over the data: the lines of the
        spectrum are one bin, 1 / record_periods, tall).
    natural_frequency_hz : float or False, optional
        f_n [Hz]: drawn as the curve order = f_n / f_mesh(speed); where it meets mesh order n
        (speed 60 f_n / (n N1)) order n resonates (a super-harmonic resonance for n > 1).
        Default: the result's own, sqrt(k0 / m_eq) / (2 pi) (``result_natural_frequency``:
        drawn where the result gives one); ``False``: no curve.
    floor : float
        Smallest amplitude coloured [um or N]; the bins between mesh orders hold only round-off.
    driven_teeth : int, optional
        Speed axis in the driven gear's speed.
    skip_mean : bool
        Leave out order 0 (drawn as ``floor``, and not in the colour scale): the mean of p,
        about F_m / k0, is no vibration; drawn, it was a bright row under the order lines and,
        where it is the largest amplitude, the top of the colour scale (as ``plot_waterfall``'s
        ``skip_mean``).

    Only settled cases (``status == 0``) are coloured: the column of a speed whose case has not
    settled is left white, and counted in the legend.
    """
    ds = si_data_vars(ds)  # a result stores display units (p in um): here SI
    da = _on_speed_and_order(ds, variable, "plot_campbell")
    da, _, _ = settled(da, ds)  # a case that has not settled is no colour (as in every plot)
    n_bad = (int((ds["status"] != 0).broadcast_like(ds["speed"]).sum()) if "status" in ds
             else 0)
    is_force = da.attrs.get("units") == "N"
    scale = 1.0 if is_force else UM
    speed, speed_label = _speed_axis(ds, driven_teeth)
    order = ds["order"].values
    amp = np.clip(da.transpose("order", "speed").values * scale, floor, None)  # (NaN stays)
    if skip_mean:
        amp[order == 0, :] = np.where(np.isnan(amp[order == 0, :]), np.nan, floor)
    if natural_frequency_hz is None:
        natural_frequency_hz = result_natural_frequency(ds)
    elif natural_frequency_hz is False:
        natural_frequency_hz = None
    vmax = float(np.nanmax(amp)) if np.isfinite(amp).any() else 10 * floor
    mesh = ax.pcolormesh(_edges(speed), _edges(order), amp, norm=LogNorm(vmin=floor, vmax=vmax),
                         cmap=matplotlib.colormaps["inferno"].with_extremes(bad="white"),
                         shading="flat", rasterized=True)
    cb = ax.figure.colorbar(mesh, ax=ax, pad=0.02)
    cb.set_label("force amplitude [N]" if is_force else "amplitude of p [µm]")
    ax.set_yticks(list(orders), minor=True)
    ax.tick_params(axis="y", which="minor", length=8, color="tab:cyan", width=1.5)
    if natural_frequency_hz is not None:
        f_mesh = ds["mesh_frequency"].values
        ax.plot(speed, natural_frequency_hz / f_mesh, color="tab:cyan", lw=1.0, ls="--",
                label=f"f_n / f_mesh, f_n = {natural_frequency_hz / 1e3:.2f} kHz")
        rising = np.argsort(f_mesh, kind="stable")  # np.interp needs increasing abscissae: a
        # study may list its speeds from high to low (the circles were dropped)
        for n in orders:
            s_n = np.interp(natural_frequency_hz / n, f_mesh[rising], speed[rising], left=np.nan,
                            right=np.nan)
            if np.isfinite(s_n):
                ax.plot(s_n, n, "o", mfc="none", mec="tab:cyan", ms=9, mew=1.2)
    handles = ax.get_legend_handles_labels()[0]
    if n_bad:  # (a proxy: the white cells are no artist of their own)
        handles.append(Patch(facecolor="white", edgecolor="0.5",
                             label=f"white: {n_bad} of {speed.size} speeds not settled (masked)"))
    if handles:
        ax.legend(handles=handles, loc="upper right", fontsize=8)
    ax.set_ylim(order[0], order[-1])
    ax.set_xlabel(speed_label)
    ax.set_ylabel("order = frequency / mesh frequency [-]")
    return ax.figure


def _edges(c: np.ndarray) -> np.ndarray:
    """Cell edges around centres ``c`` (midpoints, ends extended by half a step)."""
    c = np.asarray(c, float)
    if c.size == 1:
        return np.array([c[0] - 0.5, c[0] + 0.5])
    mid = 0.5 * (c[1:] + c[:-1])
    return np.concatenate([[2 * c[0] - mid[0]], mid, [2 * c[-1] - mid[-1]]])


def _baseline_value(ds: xr.Dataset, by: str, baseline) -> float:
    """The stored value of ``by`` that ``baseline`` names (to 1e-9 relative, in the unit the
    result stores ``by`` in); one line naming the values there are where none matches (a value
    not among them was a raw KeyError from ``sel``)."""
    values = np.asarray(ds[by].values, float)
    try:
        want = float(baseline)
    except (TypeError, ValueError):
        want = math.nan
    match = np.flatnonzero(np.isclose(values, want, rtol=1e-9, atol=0.0))
    if match.size != 1:
        unit = ds[by].attrs.get("units", "")
        raise ValueError(f"baseline={baseline!r}: one of the result's values of {by!r}"
                         f"{f' [{unit}]' if unit else ''}: "
                         + ", ".join(f"{v:g}" for v in values))
    return float(values[match[0]])


def plot_response_by_load(
    ax: Axes,
    ds: xr.Dataset,
    *,
    by: str = "torque",
    variable: str = "p_rms",
    natural_frequency_hz: float | None = None,
    orders: Sequence[int] = (1, 2, 3),
    log: bool = True,
    relative: bool = False,
    baseline: float | None = None,
) -> Figure:
    """A response statistic against speed, one line per value of ``by`` (paper Fig. 6).

    Parameters
    ----------
    ax : Axes
    ds : Dataset
        A result with ``variable`` on ``(speed, by)``; any further swept dim is drawn at its
        first value, named in the title (``ds.sel`` another first); a continued sweep's run-up
        and run-down are both drawn (``direction``).
    by : str
        The other swept dim (``torque`` [N m], ``mean_force`` [N], ``damping`` ...); one that
        ``variable`` does not sweep is a ``ValueError`` naming those it does.
    variable : str
        A statistic (docs/data-format.md) of p (µm in a result file; drawn in µm), e.g.
        ``p_rms`` or ``p_pp``.
    natural_frequency_hz : float, optional
        Mark the speeds 60 f_n / (n N1) where mesh order n meets f_n [Hz].
    orders : sequence of int
        The orders n of those marks.
    log : bool
        Logarithmic amplitude axis.
    relative : bool
        Draw each line divided by the line of the value ``baseline`` of ``by`` [-].
    baseline : float, optional
        The value of ``by`` whose line the others are divided by with ``relative``; the first
        value when not given (``lowest_in_contact`` gives the lowest that keeps contact).

    Drawn cases that lost contact (``contact_lost``: p < 0, the linear scene answers for a pair
    with no backlash) lie on a grey band, counted in its legend entry; with ``relative`` a ratio
    is marked where either of its two cases lost contact (the baseline's too).
    """
    check_dataset(ds, "plot_response_by_load(ax, ds, by=..., variable={})", variable)
    if variable not in ds.data_vars or "speed" not in ds[variable].dims:
        why = "not over speed" if variable in ds.data_vars else f"it has no {variable!r}"
        raise ValueError(f"variable={variable!r}: a statistic of this result over speed ({why})")
    swept = [d for d in ds[variable].dims if d not in ("speed", "direction")]
    if by not in swept:  # (the default 'torque' on a mean_force sweep was a KeyError)
        raise ValueError(f"by={by!r}: " + (f"one of the dims {variable!r} sweeps besides speed:"
                                            f" {', '.join(swept)}" if swept else
                                            f"{variable!r} sweeps nothing besides speed"))
    ds = si_data_vars(ds)  # a result stores display units (p in um): here SI
    # any other swept dim at its first value, said in the title (a speed x mean_force x damping
    # sweep drew each force's line once per damping, with the same label; an outside tester)
    ds, fixed = hold_first(ds, [d for d in swept if d != by])
    da, n_bad, n_all = settled(ds[variable], ds)  # a case that has not settled is no point
    lost = contact_lost(da, ds)
    speed = ds["speed"].values
    first = float(ds[by].values[0]) if baseline is None else _baseline_value(ds, by, baseline)
    dirs = list(ds["direction"].values) if "direction" in da.dims else [None]  # each drawn
    bands, n_lost, n_drawn = [], 0, 0
    for v in ds[by].values:
        color = None  # a value's run-up and run-down in one colour
        for dv in dirs:
            way = {} if dv is None else {"direction": dv}
            y = da.sel({by: v, **way}).values
            y = y / da.sel({by: first, **way}).values if relative else y * UM
            mark = lost.sel({by: v, **way}).values | (
                lost.sel({by: first, **way}).values if relative else False)
            label = value_label(ds, by, v) + (f", run-{dv}" if dv is not None else "")
            (line,) = ax.plot(speed, y, lw=1.2, zorder=2, color=color, label=label,
                              **DIRECTION_STYLE.get(dv, {}))  # (said "N s mm-1", the CF unit)
            color = line.get_color()
            bands.append((y, mark))
            n_lost += int((mark & np.isfinite(y)).sum())
            n_drawn += int(np.isfinite(y).sum())
    mark_contact_lost_lines(ax, speed, bands, contact_lost_label(
        n_lost, n_drawn, "ratios drawn (in the line's\ncase or the baseline's)" if relative
        else "cases drawn"))
    if natural_frequency_hz is not None:
        f_per_rpm = float(ds["mesh_frequency"].values[-1] / speed[-1])
        for i, n in enumerate(orders):
            s_n = natural_frequency_hz / (n * f_per_rpm)
            if speed[0] <= s_n <= speed[-1]:
                ax.axvline(s_n, color="0.5", ls=":", lw=0.8)
                ax.text(s_n, 0.97 - 0.05 * (i % 2), f" order {n}",  # staggered: the higher
                        transform=ax.get_xaxis_transform(),  # orders' lines lie close together
                        ha="left", va="top", fontsize=8, color="0.3")
    if log:
        ax.set_yscale("log")
    ax.set_xlabel(f"speed of the {ds['speed'].attrs.get('gear', 'driving gear')} [rpm]")
    name = da.attrs.get("long_name", variable)
    ax.set_ylabel(f"{variable} / {variable} at {value_label(ds, by, first)} [-]" if relative
                  else f"{name} [µm]")
    if fixed:
        ax.set_title(at_title(name, fixed), fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, title=f"{n_bad} of {n_all} cases not settled (masked)" if n_bad else None,
              title_fontsize=8)
    return ax.figure


def lowest_in_contact(ds: xr.Dataset, by: str = "torque", variable: str = "p_rms") -> float | None:
    """The lowest value of ``by`` none of whose settled cases lost contact (``contact_lost``),
    the baseline of a relative ``plot_response_by_load`` whose ratios compare only responses of
    the linear mesh in contact; None where every value has a case that lost contact.

    A case that lost contact is the linear equation's answer for a pair with no backlash, not
    the pair's: a ratio set against it compares a real pair's response with that of another
    system (Fig. 6 (b): the relieved pair's 12.5 N m line from 7,105 rpm up)."""
    da, _, _ = settled(si_data_vars(ds)[variable], ds)
    lost = contact_lost(da, ds) & da.notnull()
    other = [d for d in lost.dims if d != by]
    keeps = ~lost.any(other) if other else ~lost
    values = sorted(float(v) for v, ok in zip(ds[by].values, keeps.values, strict=True) if ok)
    return values[0] if values else None


def _stiffness(ds: xr.Dataset) -> tuple[float, list[float]]:
    """k0 and the amplitudes k_n [N/m] a result of one load ran with: a gear scene's
    ``gear_stiffness`` and ``gear_stiffness_harmonic`` (the pair's at that load), else the
    resolved model's."""
    if "gear_stiffness" in ds:
        si = si_data_vars(ds[["gear_stiffness", "gear_stiffness_harmonic"]])
        return (float(si["gear_stiffness"]),
                [float(a) for a in np.atleast_1d(si["gear_stiffness_harmonic"].values)])
    model = model_from_record(json.loads(ds.attrs["model"]))
    return model.stiffness, [h.amplitude for h in model.stiffness_harmonics]


def stiffness_label(ds: xr.Dataset) -> str:
    """The k(t) a result of one load ran with [kN/mm]: ``k0 = 219; k1 = 56 kN/mm`` (with more
    than three harmonics the first three and how many)."""
    k0, k_n = _stiffness(ds)
    shown = ", ".join(f"k{i + 1} = {a / 1e6:.0f}" for i, a in enumerate(k_n[:3]))
    more = f", ... ({len(k_n)} harmonics)" if len(k_n) > 3 else ""
    return f"k0 = {k0 / 1e6:.0f}; {shown}{more} kN/mm"


def plot_order_by_variant(ax: Axes, variants: Sequence[tuple[str, xr.Dataset]], *,
                          order: int = 1, relative: bool = False) -> Figure:
    """The order-``order`` line of p against speed for several results of one load (``label``,
    ``ds``), each named by its label and its k(t) (``stiffness_label``), with the closed form of
    a constant-amplitude force at the first result's f_n and damping (grey, dashed): its
    response 1 / sqrt((1 - r^2)^2 + (2 zeta r)^2) times the line's quasi-static value, which
    peaks at 1 / (2 zeta sqrt(1 - zeta^2)) at r = sqrt(1 - 2 zeta^2). ``relative``: each line
    divided by its value at the first speed [-] (the closed form by its own there); else the
    amplitude [µm] and the closed form scaled to the first result's line at the first speed.
    Cases that did not settle are left out."""
    speed = variants[0][1]["speed"].values
    for label, ds in variants:
        line, _, _ = settled(si_data_vars(ds)["spectrum"].sel(order=float(order)), ds)
        y = line.values / line.values[0] if relative else line.values * UM
        ax.plot(ds["speed"].values, y, lw=1.3, label=f"{label}: {stiffness_label(ds)}")
    first = variants[0][1]
    model = model_from_record(json.loads(first.attrs["model"]))
    k0 = _stiffness(first)[0]
    f_n = math.sqrt(k0 / model.mass) / (2 * math.pi)
    zeta = model.damping / (2 * math.sqrt(k0 * model.mass))
    r = order * first["mesh_frequency"].values / f_n
    gain = 1 / np.sqrt((1 - r**2) ** 2 + (2 * zeta * r) ** 2)
    base = si_data_vars(first)["spectrum"].sel(order=float(order)).values[0]
    ax.plot(speed, gain / gain[0] if relative else gain / gain[0] * base * UM, color="0.45",
            ls="--", lw=1.0, label=f"a constant-amplitude force, ζ = {zeta:.3f} (closed form)")
    peak = math.sqrt(1 - 2 * zeta**2) * f_n * speed[-1] / (order * first["mesh_frequency"].values[-1])
    ax.axvline(peak, color="0.45", ls=":", lw=0.8)
    ax.set_xlabel(f"speed of the {first['speed'].attrs.get('gear', 'driving gear')} [rpm]")
    ax.set_ylabel(f"order {order} of p / its value at {speed[0]:,.0f} rpm [-]" if relative
                  else f"order-{order} amplitude of p [µm]")
    ax.grid(True, which="both", alpha=0.3)
    return ax.figure


def lost_speeds(ds: xr.Dataset) -> np.ndarray | None:
    """Bool over ``ds``'s speeds: did some case at that speed lose contact (``contact_lost``:
    p < 0 in the steady state)? None where the result has no ``contact_lost``."""
    if "contact_lost" not in ds:
        return None
    lost = ds["contact_lost"].astype(bool)
    lost = lost.any([d for d in lost.dims if d != "speed"]) if lost.dims else lost
    return np.asarray(lost.broadcast_like(ds["speed"]).values, bool)


def _lost_spans(speed: np.ndarray, lost: np.ndarray) -> list[tuple[float, float]]:
    """The speed intervals (edges: midpoints between speeds, and the ends) of the runs of
    ``lost``, in the order of ``speed``."""
    edges = np.concatenate([[speed[0]], (speed[1:] + speed[:-1]) / 2, [speed[-1]]])
    change = np.flatnonzero(np.diff(np.concatenate([[0], lost.astype(int), [0]])))
    return [(float(edges[i]), float(edges[j]))
            for i, j in zip(change[::2], change[1::2], strict=True)]


def shade_contact_lost(ax: Axes, ds: xr.Dataset, driven_teeth: int | None = None) -> int:
    """Grey spans over the speeds where any case of ``ds`` has ``contact_lost``, one legend
    entry (none where no case has), as ``plot_order_lines``; the number of speeds shaded."""
    lost = lost_speeds(ds)
    if lost is None or not lost.any():
        return 0
    speed, _ = _speed_axis(ds, driven_teeth)
    for k, (lo, hi) in enumerate(_lost_spans(speed, lost)):
        ax.axvspan(lo, hi, color="0.88", zorder=0, lw=0, label=None if k else CONTACT_LOST)
    return int(lost.sum())


def plot_order_lines(
    ax: Axes,
    ds: xr.Dataset,
    *,
    orders: Sequence[int] = (1, 2, 3),
    derivative: int = 0,
    driven_teeth: int | None = None,
    log: bool = False,
) -> Figure:
    """Amplitude of mesh-order lines against speed (the tracked orders of a waterfall).

    Parameters
    ----------
    ax : Axes
    ds : Dataset
        A result with ``spectrum`` on ``(speed, order)``.
    orders : sequence of int
        Mesh orders drawn [-].
    derivative : {0, 1, 2}
        Displacement [um], velocity [mm/s] or acceleration [m/s^2] of the line: the amplitude
        times (2 pi f)^derivative, f the line's frequency.
    driven_teeth : int, optional
        Speed axis in the driven gear's speed.
    log : bool
        Logarithmic amplitude axis.

    Speeds where the result marks ``contact_lost`` (a whine scene's p below 0 in some case at
    that speed: the drive flanks part, and the linear scene stands for a pair with no backlash)
    are shaded grey and named in the legend.
    """
    ds = si_data_vars(ds)  # a result stores display units (p in um): here SI
    _known_orders(ds, orders, "plot_order_lines")  # (was xarray's KeyError)
    shade_contact_lost(ax, ds, driven_teeth)
    speed, speed_label = _speed_axis(ds, driven_teeth)
    scale, unit, what = {0: (UM, "µm", "displacement"), 1: (1e3, "mm/s", "velocity"),
                         2: (1.0, "m/s^2", "acceleration")}[derivative]
    spectrum, _, _ = settled(ds["spectrum"], ds)  # only settled cases are drawn
    n_bad, n_all = settled(ds["status"], ds)[1:] if "status" in ds else (0, 0)  # cases
    for n in orders:
        line = spectrum.sel(order=float(n))
        w = 2 * math.pi * ds["frequency"].sel(order=float(n)).values
        ax.plot(speed, line.values * w**derivative * scale, lw=1.2, label=f"order {n}")
    ax.set_xlabel(speed_label)
    ax.set_ylabel(f"{what} amplitude of p [{unit}]")
    if log:
        ax.set_yscale("log")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, title=f"{n_bad} of {n_all} cases not settled (masked)" if n_bad else None,
              title_fontsize=8)
    return ax.figure


def ste_phase_lag(ds: xr.Dataset, order: float) -> xr.DataArray:
    """Phase of the order-``order`` line of p behind the same order of the scene's STE [deg],
    wrapped to (-180, 180]: ``spectrum_phase`` minus the STE harmonic's phase (the resolved
    model's, ``attrs["model"]``). The STE drives the mesh through -m e'' = m w^2 e, in phase with
    e, so a line that is a resonance of that forcing lags it by 90 degrees at w = omega_n
    whatever the damping (exactly so where the stiffness does not vary)."""
    if "spectrum_phase" not in ds:
        raise ValueError("ste_phase_lag: the result has no spectrum_phase (outputs: spectrum"
                         " with phase: true)")
    _known_orders(ds, [order], "ste_phase_lag")
    model = model_from_record(json.loads(ds.attrs["model"]))
    ste = [h for h in model.ste_harmonics if math.isclose(h.order, order)]
    if len(ste) != 1:
        raise ValueError(f"ste_phase_lag: the scene has no STE harmonic of order {order:g}")
    lag = ds["spectrum_phase"].sel(order=float(order)) - ste[0].phase
    out = np.degrees(xr.apply_ufunc(wrap_phase, lag)).rename("ste_phase_lag")
    out.attrs = {"units": "deg", "long_name": f"phase of the order-{order:g} line of p behind"
                 f" the STE's order-{order:g} term, in (-180, 180]"}
    return out


PHASE_FLOOR = 0.01
"""The smallest amplitude an order line must have, as a fraction of the largest mesh-order line
(orders 1 and up) of the same case, for ``plot_ste_phase_lags`` to draw its phase: below it the
line is not what p is made of, and its phase says nothing of the response."""


def plot_ste_phase_lags(ax: Axes, ds: xr.Dataset, *, orders: Sequence[int] = (1, 2, 3, 4),
                        linestyle: str = "-", label: str = "", color: str | None = None,
                        floor: float = PHASE_FLOOR) -> Figure:
    """The lag of each order line of p behind the STE's same order against speed [deg]
    (``ste_phase_lag``), with -90 degrees marked: a resonance of the STE's forcing passes it at
    omega_n. Cases that did not settle are left out, and so are the speeds where the line's
    amplitude is below ``floor`` times the largest mesh-order line of that case (``PHASE_FLOOR``);
    the line is broken where the lag wraps past -180 degrees."""
    speed, speed_label = _speed_axis(ds, None)
    spectrum = ds["spectrum"]
    whole = [o for o in spectrum["order"].values if o >= 1 and float(o).is_integer()]
    largest = spectrum.sel(order=whole).max("order").values
    for i, n in enumerate(orders):
        lag, _, _ = settled(ste_phase_lag(ds, n), ds)
        lag = np.where(spectrum.sel(order=float(n)).values >= floor * largest, lag.values, np.nan)
        wraps = np.flatnonzero(np.abs(np.diff(lag)) > 180.0)  # (-180 to +180: not a jump)
        x, y = np.insert(speed.astype(float), wraps + 1, np.nan), np.insert(lag, wraps + 1, np.nan)
        ax.plot(x, y, ls=linestyle, lw=1.1, color=color or f"C{i}", label=f"order {n}{label}")
    ax.axhline(-90.0, color="0.3", lw=0.8)
    ax.set_xlabel(speed_label)
    ax.set_ylabel("phase of p relative to the STE, same order\n[deg] (negative: lag)")
    ax.set_ylim(-185, 10)
    ax.set_yticks(range(-180, 1, 30))
    ax.grid(True, alpha=0.3)
    return ax.figure

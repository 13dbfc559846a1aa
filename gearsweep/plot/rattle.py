"""Figures of the rattle scene (section 6): Fig. 8, Fig. 9, the Fig. 12 counterpart, a design map.

The ``plot_rattle_*`` functions draw the Datasets of the rattle analysis studies
(``studies/fig08_rattle_balance.yaml``: ``rattle_balance``; ``fig08_rattle_budget.yaml``:
``rattle_budget``) as ``plot_x(ax, ds, *, ...)``; nothing is computed here. The lower-level
functions below them take arrays (SI units, speeds in rpm; a result's variable or coordinate given
as it is, with its ``units`` attribute, is read in that unit: ``plot.common.si_array``). Lengths
are shown in mm, forces in kN.
"""

from __future__ import annotations

import textwrap
from collections.abc import Sequence

import matplotlib
import numpy as np
import xarray as xr
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from gearsweep.plot.common import require, si_array
from gearsweep.plot.sweep import speed_label as _speed_label
from gearsweep.units import si_data_vars

MM = 1e3

BALANCE = "studies/fig08_rattle_balance.yaml (analysis kind rattle_balance)"
"""What the ``plot_rattle_balance``, ``_contact`` and ``_graphical`` figures draw the result of."""


def _split_runs(mask: np.ndarray) -> list[slice]:
    """Contiguous runs of equal values of ``mask``, overlapping by one point so lines join."""
    edges = np.nonzero(np.diff(mask.astype(int)))[0] + 1
    starts = np.r_[0, edges]
    stops = np.r_[edges, mask.size]
    return [slice(a, min(b + 1, mask.size)) for a, b in zip(starts, stops, strict=True)]


def plot_branch(ax: Axes, speed, amplitude, stable, *, color: str, label: str,
                lw: float = 1.6) -> None:
    """A response curve ordered along its arc: solid where stable, dashed where unstable."""
    speed = si_array(speed, "speed", "speed")
    amplitude = si_array(amplitude, "displacement", "amplitude")
    stable = np.asarray(stable, dtype=bool)
    if not np.isfinite(amplitude).any():  # (a branch harmonic balance did not find: no legend
        return  # entry for a line that is not there)
    first = {True: True, False: True}
    for run in _split_runs(stable):
        st = bool(stable[run.start])
        lab = None
        if first[st]:
            lab = f"{label} ({'stable' if st else 'unstable'})"
            first[st] = False
        ax.plot(speed[run], amplitude[run] * MM, "-" if st else "--", color=color, lw=lw,
                label=lab)


def plot_fig8(ax: Axes, speed, amp_up, amp_down, *, half_gap: float,
              curves: Sequence[dict] = (), eq15: dict | None = None,
              speed_label: str = "speed of the driving gear [rpm]") -> Figure:
    """Fig. 8: amplitude of p versus speed on run-up and run-down, with harmonic balance.

    Parameters
    ----------
    ax : Axes
    speed : array_like
        Driving-gear speed [rpm], increasing.
    amp_up, amp_down : array_like
        Half peak-to-peak of p on the run-up and the run-down [m].
    half_gap : float
        b = backlash / 2 [m], drawn as a reference line.
    curves : sequence of dict
        Harmonic-balance curves with keys ``speed`` [rpm], ``amplitude`` [m], ``stable`` (bool),
        ``label``, ``color``; drawn solid where stable, dashed where unstable.
    eq15 : dict, optional
        The paper's analytical points: ``speed`` [rpm], ``amplitude`` [m] (open circles), and
        optionally ``label``.
    speed_label : str
        x-axis label (which shaft the speed is).
    """
    speed = si_array(speed, "speed", "speed")
    half_gap = float(si_array(half_gap, "length", "half_gap"))
    ax.plot(speed, si_array(amp_up, "displacement", "amp_up") * MM, "^", ms=4, color="tab:red",
            mew=0, alpha=0.6, label="integration, run-up")
    ax.plot(speed, si_array(amp_down, "displacement", "amp_down") * MM, "v", ms=4,
            color="tab:blue", mew=0, alpha=0.6, label="integration, run-down")
    for c in curves:
        plot_branch(ax, c["speed"], c["amplitude"], c["stable"], color=c["color"],
                    label=c["label"], lw=c.get("lw", 1.6))
    if eq15 is not None:
        ax.plot(si_array(eq15["speed"], "speed", "eq15 speed"),
                si_array(eq15["amplitude"], "displacement", "eq15 amplitude") * MM, "o",
                mfc="none", ms=5,
                color="0.35", label=eq15.get("label", "Eq. (15), paper's method (o)"))
    ax.axhline(half_gap * MM, color="0.5", lw=0.8, ls=":")
    # at the left edge of the axes, whatever x limits the caller sets afterwards (placed at
    # the data's xlim it sat at -5,870 rpm in fig08_rattle.png, outside the 5,000-11,000 axes)
    ax.annotate("backlash / 2", (0.0, half_gap * MM), xycoords=("axes fraction", "data"),
                xytext=(4, 3), textcoords="offset points", fontsize=8, color="0.4")
    ax.set_xlabel(speed_label)
    ax.set_ylabel("amplitude of p, (p_max - p_min)/2 [mm]")
    # beside the axes, not on the data or the backlash / 2 label (it covered both)
    ax.legend(fontsize=7.5, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    ax.grid(alpha=0.3)
    return ax.figure


def plot_contact(ax: Axes, speed, loss_up, loss_down, back_up, back_down, *,
                 speed_label: str = "speed of the driving gear [rpm]") -> Figure:
    """Contact-loss and back-flank fractions of the up and down sweeps versus speed.

    Parameters
    ----------
    speed : array_like
        [rpm].
    loss_up, loss_down, back_up, back_down : array_like
        Fractions of the recorded time with the teeth apart / on the back flank [1].
    """
    ax.plot(speed, loss_up, "^", ms=3, color="tab:red", mew=0, label="contact loss, run-up")
    ax.plot(speed, loss_down, "v", ms=3, color="tab:blue", mew=0,
            label="contact loss, run-down")
    ax.plot(speed, back_up, "-", color="tab:red", lw=0.8, label="back-flank contact, run-up")
    ax.plot(speed, back_down, "-", color="tab:blue", lw=0.8,
            label="back-flank contact, run-down")
    ax.set_ylabel("fraction of time [1]")
    ax.set_xlabel(speed_label)
    ax.set_ylim(-0.02, 1.02)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    ax.grid(alpha=0.3)
    return ax.figure


def plot_fig9(ax: Axes, *, stiffness: float, mass: float, force_amp: float, half_gap: float,
              omegas: Sequence[float], labels: Sequence[str], roots: np.ndarray,
              p_range: float) -> Figure:
    """Fig. 9: the graphical solution of Eq. (15).

    The spring curve ``k f(p0)`` against straight lines ``F0 + m w^2 p0`` at three speeds; the
    intersections (``roots``, shape (3, 3), NaN where a line misses a piece) are marked.

    Parameters
    ----------
    stiffness, mass, force_amp, half_gap : float
        k [N/m], m_eq [kg], F0 [N], b [m].
    omegas : sequence of float
        Excitation frequencies of the lines [rad/s].
    labels : sequence of str
        Line labels (e.g. "A: 6000 rpm").
    roots : ndarray (3, 3)
        ``eq15_roots`` at ``omegas`` [m].
    p_range : float
        Half-width of the p0 axis [m].
    """
    stiffness = float(si_array(stiffness, "stiffness", "stiffness"))
    mass = float(si_array(mass, "mass", "mass"))
    force_amp = float(si_array(force_amp, "force", "force_amp"))
    half_gap = float(si_array(half_gap, "length", "half_gap"))
    p_range = float(si_array(p_range, "length", "p_range"))
    roots = si_array(roots, "displacement", "roots")
    p = np.linspace(-p_range, p_range, 801)
    spring = stiffness * (p - np.clip(p, -half_gap, half_gap))
    ax.plot(p * MM, spring / 1e3, color="k", lw=2, label="spring k f(p0)")
    colors = ("tab:green", "tab:orange", "tab:purple")
    for w, lab, col, r in zip(omegas, labels, colors, roots, strict=True):
        line = force_amp + mass * w**2 * p
        ax.plot(p * MM, line / 1e3, color=col, lw=1.3, label=f"{lab}: F0 + m ω² p0")
        ok = np.isfinite(r)
        ax.plot(r[ok] * MM, (force_amp + mass * w**2 * r[ok]) / 1e3, "o", color=col, ms=7,
                mfc="none", mew=1.8)
    ax.axhline(0, color="0.6", lw=0.6)
    ax.axvline(0, color="0.6", lw=0.6)
    for s in (-1, 1):
        ax.axvline(s * half_gap * MM, color="0.6", lw=0.6, ls=":")
    ax.set_xlabel("response amplitude p0 [mm]")
    ax.set_ylabel("force [kN]")
    top = stiffness * (p_range - half_gap) / 1e3
    ax.set_ylim(-1.1 * top, 1.1 * top)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    ax.grid(alpha=0.3)
    return ax.figure


def plot_lines(ax: Axes, x, lines: Sequence[dict], *, xlabel: str, ylabel: str,
               scale: float = 1.0, log: bool = True, hline: dict | None = None) -> Figure:
    """Curves over a speed axis: each dict of ``lines`` has ``y`` (NaN = masked), ``label`` and
    optional ``color``, ``ls``, ``marker``, ``lw``; ``y * scale`` is drawn.

    Parameters
    ----------
    x : array_like
        Speed [rpm] (of the shaft named in ``xlabel``), shared by all lines unless a line has its
        own ``x``.
    hline : dict, optional
        A reference level: ``y`` (unscaled), ``label``.
    """
    for ln in lines:
        ax.plot(ln.get("x", x), np.asarray(ln["y"]) * scale, ls=ln.get("ls", "-"),
                marker=ln.get("marker", ""), ms=3, mew=0, lw=ln.get("lw", 1.3),
                color=ln.get("color"), label=ln["label"])
    if hline is not None:
        ax.axhline(hline["y"] * scale, color="0.3", lw=0.9, ls=":")
        ax.annotate(hline["label"], (0.01, hline["y"] * scale), xycoords=("axes fraction", "data"),
                    xytext=(0, 3), textcoords="offset points", fontsize=7.5, color="0.3")
    if log:
        ax.set_yscale("log")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.grid(True, which="both", alpha=0.3)
    return ax.figure


def plot_rattle_map(axes, axes_hyst, damping, torque, backlash, rattle_fraction,
                    hysteresis_width, hysteresis_open=None) -> Figure:
    """Design map over damping x torque, one column of panels per backlash value.

    Parameters
    ----------
    axes, axes_hyst : sequence of Axes
        One panel per backlash value for the contact-loss share and for the hysteresis width.
    damping : array_like (n_c,)
        Mesh damping [N s/m] (y axis, log).
    torque : array_like (n_t,)
        Mean driving torque [N m] (x axis).
    backlash : array_like (n_b,)
        Total backlash [m].
    rattle_fraction : array_like (n_b, n_c, n_t)
        Share of swept speeds at which either sweep loses contact [1].
    hysteresis_width : array_like (n_b, n_c, n_t)
        Width of the jump hysteresis band [rpm] (NaN: cannot be judged, grey, counted in the
        colour bar's label).
    hysteresis_open : array_like (n_b, n_c, n_t) or None
        Non-zero where the band reaches an end of the swept speeds (its width a lower bound):
        hatched.
    """
    im = imh = None
    c = si_array(damping, "damping", "damping") / 1e3
    torque = si_array(torque, "torque", "torque")
    backlash = si_array(backlash, "length", "backlash")
    hysteresis_width = si_array(hysteresis_width, "speed", "hysteresis_width")
    unjudged = np.isnan(hysteresis_width)  # (jump_unsupported: the sweeps cannot say)
    vmax = max(float(np.nanmax(hysteresis_width)) if not unjudged.all() else 0.0, 1.0)
    cmap = matplotlib.colormaps["viridis"].with_extremes(bad="0.6")
    opened = (np.zeros(np.shape(hysteresis_width), bool) if hysteresis_open is None
              else np.asarray(hysteresis_open) > 0)
    for ax, axh, bl, frac, width, op in zip(axes, axes_hyst, backlash, rattle_fraction,
                                            hysteresis_width, opened, strict=True):
        im = ax.pcolormesh(torque, c, frac, vmin=0, vmax=1, cmap="magma", shading="nearest")
        ax.contour(torque, c, frac, [0.01], colors="cyan", linewidths=1.0)
        imh = axh.pcolormesh(torque, c, width, vmin=0, vmax=vmax, cmap=cmap,
                             shading="nearest")
        if op.any():
            axh.pcolor(torque, c, np.ma.masked_where(~op, op), shading="nearest", hatch="////",
                       facecolor="none", edgecolor="w", linewidth=0.0, alpha=0.6)
        for a in (ax, axh):
            a.set_yscale("log")
        ax.set_title(f"backlash {bl * MM:g} mm", fontsize=9)
        axh.set_xlabel("mean driving torque [N m]")
    axes[0].set_ylabel("mesh damping c [N s/mm]")
    axes_hyst[0].set_ylabel("mesh damping c [N s/mm]")
    fig = axes[0].figure
    cb = fig.colorbar(im, ax=list(axes), shrink=0.9)
    cb.set_label("share of speeds with contact loss [1]\n(cyan: rattle-free boundary)")
    cbh = fig.colorbar(imh, ax=list(axes_hyst), shrink=0.9)
    cbh.set_label("hysteresis band width [rpm]" + ("\n(hatched: open at an end of the sweep,"
                                                   " at least this wide)" if opened.any() else "")
                  + (f"\n(grey: {int(unjudged.sum())} of {unjudged.size} cells, the jump cannot be"
                     " judged)" if unjudged.any() else ""))
    return fig


def plot_rattle_balance(ax: Axes, ds: xr.Dataset, *, ymax: float | None = None,
                        note_at: tuple[float, float] = (8300.0, 0.03)) -> Figure:
    """Fig. 8 from a ``rattle_balance`` Dataset: the integration's run-up and run-down, the
    describing-function curves, the AFT branch, the paper's Eq. (15) points, where the lower
    branch flips, and Eq. (15) against the integration; titled with the scene's numbers.
    ``ymax`` [mm] (default: 1.6 times the integration's largest amplitude; Fig. 8 gives 0.6);
    ``note_at`` (rpm, mm): where the flip note is written."""
    require(ds, ("amplitude", "aft_speed", "eq15_root", "jump_unsupported"),
            "plot_rattle_balance", BALANCE)
    ds = si_data_vars(ds)  # a result stores display units (p in um): here SI
    speed = ds["speed"].values
    amp = ds["amplitude"]
    curves = [
        {"speed": ds.df0_speed.values, "amplitude": ds.df0_amplitude.values,
         "stable": ds.df0_stable.values, "label": "describing fn. A, F_m = 0", "color": "0.6",
         "lw": 1.0},
        {"speed": ds.df_speed.values, "amplitude": ds.df_amplitude.values,
         "stable": ds.df_stable.values, "label": "describing fn., first-harmonic A",
         "color": "k"},
        {"speed": ds.aft_speed.values, "amplitude": ds.aft_amplitude.values,
         "stable": ds.aft_stable.values, "color": "tab:green",
         "label": f"AFT harmonic balance ({ds.attrs['aft_harmonics']} harm.), Floquet"},
    ]
    r15 = ds["eq15_root"].values
    ok = np.isfinite(r15)
    eq15 = {"speed": np.broadcast_to(ds["eq15_speed"].values[:, None], r15.shape)[ok],
            "amplitude": r15[ok], "label": "Eq. (15), undamped (the paper's o), every root"}
    plot_fig8(ax, speed, amp.sel(direction="up"), amp.sel(direction="down"),
              half_gap=float(ds.half_gap), curves=curves, eq15=eq15,
              speed_label=_speed_label(ds["speed"]))
    ax.set_xlim(speed[0], speed[-1])
    if ymax is None:  # (0.6 mm, Fig. 8's, hid a user's 0.05 mm response on its floor)
        top = np.nanmax(np.r_[amp.values.ravel(), float(ds.half_gap), 0.0]) * MM
        ymax = 1.6 * top if top > 0 else 1.0
    ax.set_ylim(0, ymax)
    flip = float(ds.flip_speed)
    if np.isfinite(flip):
        ax.annotate(f"period-1 lower branch unstable above {flip:.0f} rpm (flip):\n"
                    "the integration follows period-2, -4 or irregular motions\n"
                    f"({int(ds.not_settled)} of {int(ds.cases)} case-speeds not settled:"
                    " masked" + (f";\n{int(ds.no_period)} with no period <="
                                 f" {int(ds.longest_period)} mesh periods:"
                                 f" {int(ds.no_period_settled)} settled)"
                                 if int(ds.get("no_period", -1)) >= 0 else ")"),
                    (flip, float(ds.flip_amplitude) * MM), xytext=note_at,
                    fontsize=7.5, arrowprops={"arrowstyle": "->", "color": "0.3"})
    lines = _eq15_lines(ds)
    if lines:  # beside the axes, below the legend (on the axes it covered Eq. (15)'s points)
        ax.text(1.01, 0.0, "Eq. (15) against the integration:\n" + "\n".join(lines),
                transform=ax.transAxes, ha="left", va="bottom", fontsize=7.5,
                bbox={"fc": "white", "ec": "0.7", "alpha": 0.9})
    k, m, c = float(ds.stiffness), float(ds.mass), float(ds.damping)
    fitted = "FITTED: " if _fitted(ds) else ""
    title = (f"{ds.attrs['balanced_title']}\nk = {k / 1e6:g} kN/mm, m_eq = "
             f"{m:g} kg, backlash {float(ds.backlash) * 1e3:.4g} mm (line of action);"
             f" {fitted}F0 = {float(ds.force_amplitude) / 1e3:g} kN at mesh order"
             f" {float(ds.force_order):g}, c = {c / 1e3:g} N s/mm (ζ = {float(ds.zeta):.3f});"
             f" F_m = {float(ds.mean_force):.0f} N")
    ax.set_title("\n".join(textwrap.fill(t, 62) for t in title.split("\n")), fontsize=8.5)
    # (wrapped: beside the legend the axes are narrower, and a fixed line was clipped)
    return ax.figure


def _fitted(ds: xr.Dataset) -> bool:
    """Does the ``rattle_balance`` result say its force is a fit (its study's ``fitted``)?"""
    return bool(int(ds.attrs.get("force_fitted", 0)))


def _eq15_lines(ds: xr.Dataset) -> list[str]:
    """The lines of Eq. (15) against the integration that the result has numbers for (a NaN,
    e.g. no jump or no three-root band, leaves its part out: it printed 'integration nan'; a
    jump the jump summary cannot judge reads so: it read 'no such jump')."""
    def f(name: str) -> float:
        return float(ds[name])

    unjudged = int(ds["jump_unsupported"])  # (1: the run-up's jump, 2: the run-down's, 3)

    def pair(what: str, eq: str, jump: str, bit: int) -> str | None:
        a, b = f(eq), f(jump)
        if np.isfinite(a) and np.isfinite(b):
            return f"{what} {a:.0f} rpm (integration {b:.0f})"
        if np.isfinite(a) and unjudged & bit:  # NaN: the jump summary cannot judge that sweep
            return f"{what} {a:.0f} rpm (the integration's: cannot be judged)"
        if np.isfinite(a):
            return f"{what} {a:.0f} rpm (the integration has no such jump)"
        if np.isfinite(b):
            return f"integration's {what} at {b:.0f} rpm (Eq. (15) has none: F0 >= k b)"
        return None

    out = [pair("run-down rise", "eq15_rise_speed", "jump_down_speed", 2),
           pair("run-up drop", "eq15_drop_speed", "jump_up_speed", 1)]
    med, top = f("eq15_distance_rattling_median"), f("eq15_distance_rattling_max")
    if np.isfinite(med):
        out.append(f"amplitude, rattling branch: median {med:.1%}"
                   + (f", max {top:.1%}" if np.isfinite(top) else ""))
    free = f("eq15_distance_free_flight_median")
    if np.isfinite(free):
        out.append(f"amplitude, free-flight branch: median {free:.1%}")
    return [line for line in out if line]


def plot_rattle_contact(ax: Axes, ds: xr.Dataset) -> Figure:
    """Contact-loss and back-flank fractions of a ``rattle_balance`` Dataset's integration, with
    the contact loss above the run-up drop and the largest back-flank fraction there (drive-flank
    impacts only where it is 0)."""
    require(ds, ("contact_loss_fraction", "contact_loss_above_drop_min"), "plot_rattle_contact",
            BALANCE)
    ds = si_data_vars(ds)  # a result stores display units (p in um): here SI
    loss, back = ds["contact_loss_fraction"], ds["backside_contact_fraction"]
    plot_contact(ax, ds["speed"].values, loss.sel(direction="up"), loss.sel(direction="down"),
                 back.sel(direction="up"), back.sel(direction="down"),
                 speed_label=_speed_label(ds["speed"]))
    lo, hi = float(ds.contact_loss_above_drop_min), float(ds.contact_loss_above_drop_max)
    if np.isfinite(lo) and np.isfinite(hi):  # (no run-up drop: it printed 'apart nan%-nan%')
        # the back flanks there, read from the curve drawn (the words were typed, not read)
        above = back.sel(direction="up").where(ds["speed"] > float(ds.jump_up_speed))
        top = float(above.max())
        flanks = ("drive-flank impacts only" if top == 0 else
                  f"back flanks in contact up to {top:.0%} of the time")
        ax.annotate(f"above the run-up drop: apart {lo:.0%}-{hi:.0%} of the time\n(free"
                    f" flight, {flanks})", (0.72, 0.55),
                    xycoords="axes fraction", fontsize=7.5, ha="center")
    return ax.figure


def plot_rattle_graphical(ax: Axes, ds: xr.Dataset, *, p_range: float = 0.75e-3) -> Figure:
    """Fig. 9 from a ``rattle_balance`` Dataset: Eq. (15)'s spring curve and its three lines
    with their roots, titled with the number of cuts of each line."""
    require(ds, ("line_speed", "graphical_root"), "plot_rattle_graphical", BALANCE)
    ds = si_data_vars(ds)  # a result stores display units (p in um): here SI
    per_rpm = float(ds.omega_per_rpm)
    speeds = ds["line_speed"].values
    roots = ds["graphical_root"].values
    labels = [f"{n}: {v:.0f} rpm" for n, v in zip(ds["line"].values, speeds, strict=True)]
    f0, b = float(ds.force_amplitude), float(ds.half_gap)
    plot_fig9(ax, stiffness=float(ds.stiffness), mass=float(ds.mass), force_amp=f0, half_gap=b,
              omegas=speeds * per_rpm, labels=labels, roots=roots, p_range=p_range)
    counts = np.isfinite(roots).sum(axis=1)
    shaft = ds["speed"].attrs.get("gear", "driving gear")
    # where Eq. (15) has three roots, counted on its own grid (the title took the paper's
    # w_t < w_n for granted: "3 roots between 13135 and 11375 rpm" where it has one everywhere)
    grid, n15 = ds["eq15_speed"].values, np.isfinite(ds["eq15_root"].values).sum(axis=1)
    three = grid[n15 >= 3]
    rise, drop = float(ds.eq15_rise_speed), float(ds.eq15_drop_speed)
    if np.isfinite(rise) and np.isfinite(drop) and rise < drop:  # w_t < w < w_n: F0 < k b
        band = f"3 roots between {rise:.0f} and {drop:.0f} rpm of the {shaft}"
    elif three.size:
        band = (f"3 roots between {three.min():.0f} and {three.max():.0f} rpm of the {shaft}"
                + ("" if three.size == np.ptp(np.nonzero(n15 >= 3)[0]) + 1 else
                   f", at {three.size} of the grid's speeds there"))
    else:
        band = (f"1 root at every speed from {grid[0]:.0f} to {grid[-1]:.0f} rpm of the {shaft}"
                + (": F0 > k b" if f0 > float(ds.stiffness) * b else ""))
    fit = " as fitted for Fig. 8" if _fitted(ds) else ""
    title = (("Fig. 9: " if fit else "The graphical solution of ")  # (the paper's figure
             + "Eq. (15), k f(p0) = F0 + m ω² p0 (undamped; F0 = "  # only where it is its fit)
             f"{f0 / 1e3:g} kN{fit}, b = {b * 1e3:.4g} mm); intersections "
             f"A: {counts[0]}, B: {counts[1]}, C: {counts[2]} ({band})")
    ax.set_title(textwrap.fill(title, 80), fontsize=9)  # (two fixed lines were clipped on
    # both sides at matplotlib's default figure size; an API test)
    return ax.figure


DAMPING_STYLES = ("--", "-.", (0, (5, 1, 1, 1, 1, 1)), (0, (1, 1)))
"""Line style of the opening force at each damping of a ``rattle_budget`` Dataset (its order:
the largest first; past four they repeat, told apart by their labels); the scene is the
colour."""


def plot_rattle_budget(ax: Axes, ds: xr.Dataset, *, colors: dict[int, str] | None = None
                       ) -> Figure:
    """The force budget of a ``rattle_budget`` Dataset over its speeds: the fitted force, the
    mean force, m_eq w^2 e_1, and per scene k e_1 and, per damping, the force that opens the
    mesh at each speed (``opening_force``: where m_eq w^2 e_1 crosses it, the first harmonic
    alone opens the mesh, ``first_harmonic_opens_from``)."""
    require(ds, ("budget_speed", "inertia_force", "opening_force"), "plot_rattle_budget",
            "studies/fig08_rattle_budget.yaml (analysis kind rattle_budget)")
    ds = si_data_vars(ds)  # a result stores display units (p in um): here SI
    colors = colors or {0: "tab:blue", 1: "tab:orange"}
    sp = ds["budget_speed"].values
    f0, fm, e1 = float(ds.fitted_force), float(ds.mean_force), float(ds.ste_1)
    lines = [{"x": sp, "y": np.full(sp.shape, f0), "color": "0.55", "lw": 2.0,
              "label": f"F0 fitted for Fig. 8: {f0 / 1e3:g} kN"},
             {"x": sp, "y": np.full(sp.shape, fm), "color": "k", "ls": "-.",
              "label": f"mean mesh force F_m = {fm:.0f} N"},
             {"x": sp, "y": ds.inertia_force.values, "color": "tab:purple",
              "label": f"m_eq ω² e_1 (e_1 = {e1 * 1e6:.2f} µm, the pair's 1st STE harmonic)"}]
    for j, scene in enumerate(ds["scene"].values):
        s = ds.sel(scene=scene)
        cs = [c for c in s["damping"].values if np.isfinite(float(s.threshold.sel(damping=c)))]
        for c in cs:
            k = float(s.scene_stiffness.sel(damping=c))
            if c == max(cs):
                lines.append({"x": sp, "y": np.full(sp.shape, k * e1), "color": colors[j],
                              "ls": ":", "label": f"k e_1, k = {k / 1e6:.0f} kN/mm"})
            sc = s.sel(damping=c)
            lo, hi = float(sc.first_harmonic_opens_from), float(sc.first_harmonic_opens_to)
            opens = ("m_eq ω² e_1 below it at every speed" if np.isnan(lo) else
                     f"m_eq ω² e_1 above it {lo:.0f}-{hi:.0f} rpm")
            style = DAMPING_STYLES[list(ds["damping"].values).index(c) % len(DAMPING_STYLES)]
            lines.append({"x": sp, "y": sc.opening_force.values, "color": colors[j],
                          "ls": style, "lw": 1.1,
                          "label": f"force that opens the mesh, k = {k / 1e6:.0f} kN/mm,"
                                   f" c = {c:g} N s/mm (ζ = {float(sc.zeta):.3f})\n   (least"
                                   f" {float(sc.threshold):.0f} N, at resonance): {opens}"})
    plot_lines(ax, None, lines, xlabel=_speed_label(ds["budget_speed"]),
               ylabel="force amplitude at mesh order 1 [N]")
    ax.legend(fontsize=6.5, loc="lower right")
    ax.set_title("Mesh order 1 only (the order of the fitted force). The force that opens the mesh"
                 " at each speed, F_m |k - m ω² + i c ω| / k,\nis the one whose linear response"
                 " reaches the static deflection F_m / k: where m_eq ω² e_1 exceeds it, the"
                 " first harmonic alone opens the mesh.\nNot drawn: the STE's higher orders n,"
                 " forces m_eq (n ω)² e_n, resonant where n x the mesh frequency meets f_n,\n"
                 "which can open the mesh at speeds where m_eq ω² e_1 cannot", fontsize=8)
    return ax.figure


def budget_jump(s: xr.Dataset, direction: str) -> str:
    """The jump of one sweep (``direction`` "up" or "down") of one scene and damping ``s`` of a
    ``rattle_budget`` Dataset (or of a ``rattle_balance`` one), in words: "jump at 6500 rpm",
    "no jump", or "jump cannot be judged" where the jump criterion could not judge it
    (``jump_unsupported``; its jump speed is NaN as where there is none)."""
    if int(s.jump_unsupported) & (1 if direction == "up" else 2):
        return "jump cannot be judged"
    speed = float(s[f"jump_{direction}_speed"])
    return "no jump" if np.isnan(speed) else f"jump at {speed:.0f} rpm"

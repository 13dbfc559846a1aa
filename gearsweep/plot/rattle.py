"""Figures of the rattle scene (section 6): Fig. 8, Fig. 9, the Fig. 12 counterpart, a design map.

Every function takes arrays (SI units, speeds in rpm) and a Matplotlib ``ax`` (or axes), draws,
and returns the figure. Lengths are shown in mm, forces in kN.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

MM = 1e3


def _split_runs(mask: np.ndarray) -> list[slice]:
    """Contiguous runs of equal values of ``mask``, overlapping by one point so lines join."""
    edges = np.nonzero(np.diff(mask.astype(int)))[0] + 1
    starts = np.r_[0, edges]
    stops = np.r_[edges, mask.size]
    return [slice(a, min(b + 1, mask.size)) for a, b in zip(starts, stops, strict=True)]


def plot_branch(ax: Axes, speed, amplitude, stable, *, color: str, label: str,
                lw: float = 1.6) -> None:
    """A response curve ordered along its arc: solid where stable, dashed where unstable."""
    speed = np.asarray(speed)
    amplitude = np.asarray(amplitude)
    stable = np.asarray(stable, dtype=bool)
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
    ax.plot(speed, np.asarray(amp_up) * MM, "^", ms=4, color="tab:red", mew=0, alpha=0.6,
            label="integration, run-up")
    ax.plot(speed, np.asarray(amp_down) * MM, "v", ms=4, color="tab:blue", mew=0, alpha=0.6,
            label="integration, run-down")
    for c in curves:
        plot_branch(ax, c["speed"], c["amplitude"], c["stable"], color=c["color"],
                    label=c["label"], lw=c.get("lw", 1.6))
    if eq15 is not None:
        ax.plot(eq15["speed"], np.asarray(eq15["amplitude"]) * MM, "o", mfc="none", ms=5,
                color="0.35", label=eq15.get("label", "Eq. (15), paper's method (o)"))
    ax.axhline(half_gap * MM, color="0.5", lw=0.8, ls=":")
    ax.annotate("backlash / 2", (ax.get_xlim()[0], half_gap * MM), xytext=(4, 3),
                textcoords="offset points", fontsize=8, color="0.4")
    ax.set_xlabel(speed_label)
    ax.set_ylabel("amplitude of p, (p_max - p_min)/2 [mm]")
    ax.legend(fontsize=7.5, loc="lower left")
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
    ax.legend(fontsize=7, ncol=2, loc="lower right", bbox_to_anchor=(1.0, 0.1))
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
    ax.legend(fontsize=8, loc="upper left")
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
                    hysteresis_width) -> Figure:
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
        Width of the jump hysteresis band [rpm].
    """
    im = imh = None
    c = np.asarray(damping) / 1e3
    vmax = max(float(np.nanmax(hysteresis_width)), 1.0)
    for ax, axh, bl, frac, width in zip(axes, axes_hyst, backlash, rattle_fraction,
                                        hysteresis_width, strict=True):
        im = ax.pcolormesh(torque, c, frac, vmin=0, vmax=1, cmap="magma", shading="nearest")
        ax.contour(torque, c, frac, [0.01], colors="cyan", linewidths=1.0)
        imh = axh.pcolormesh(torque, c, width, vmin=0, vmax=vmax, cmap="viridis",
                             shading="nearest")
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
    cbh.set_label("hysteresis band width [rpm]")
    return fig

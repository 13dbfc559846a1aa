"""Stability charts: Strutt diagrams (Fig. 7.1), operating maps over speed and damping
(Fig. 7.2), and the stability of the integrators themselves.

Every function takes arrays (or a Dataset) and an ``ax`` and returns the figure. Arrays are
in SI (speeds in rpm); a result's coordinate or variable given as it is (``ds.damping``, in
N s/mm) is read in its ``units`` (``plot.common.si_array``).
"""

from __future__ import annotations

import json

import numpy as np
from matplotlib.axes import Axes
from matplotlib.colors import ListedColormap
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from gearsweep.plot.common import axes, si_array
from gearsweep.units import si_values

UNSTABLE_COLOR = "#c0392b"


def _mask_image(ax: Axes, x: np.ndarray, y: np.ndarray, mask: np.ndarray, color: str,
                alpha: float = 1.0) -> None:
    cmap = ListedColormap([(1, 1, 1, 0), color])
    ax.pcolormesh(x, y, np.asarray(mask, dtype=float), cmap=cmap, vmin=0, vmax=1,
                  shading="nearest", alpha=alpha, rasterized=True)


def mathieu_transition_curves(beta_max: float, alpha_min: float, alpha_max: float,
                              n_max: int = 8, num: int = 400) -> list[tuple[str, np.ndarray,
                                                                             np.ndarray]]:
    """Transition curves of p'' + (alpha + beta cos tau) p = 0 from Mathieu characteristic values.

    With tau = 2z the equation is y'' + (a - 2q cos 2z) y = 0 with a = 4 alpha, q = -2 beta, so the
    curves are alpha = a_n(q)/4 (even solutions) and alpha = b_n(q)/4 (odd), beta = |q|/2
    (``scipy.special.mathieu_a``, ``mathieu_b``).

    Returns
    -------
    list of (label, alpha, beta)
        Curves clipped to ``alpha_min <= alpha <= alpha_max``.
    """
    from scipy.special import mathieu_a, mathieu_b

    beta = np.linspace(0.0, beta_max, num)
    q = 2.0 * beta
    out = []
    for n in range(n_max + 1):
        for label, fn in (("a", mathieu_a), ("b", mathieu_b)):
            if label == "b" and n == 0:
                continue
            al = fn(n, q) / 4.0
            al = np.where((al >= alpha_min) & (al <= alpha_max), al, np.nan)
            out.append((f"{label}{n}", al, beta))
    return out


def plot_strutt(alpha: np.ndarray, beta: np.ndarray, unstable: np.ndarray,
                ax: Axes | None = None, gamma: float | None = None, curves: bool = True,
                color: str = UNSTABLE_COLOR) -> Figure:
    """Unstable region of the damped Mathieu equation in the (alpha, beta) plane.

    Parameters
    ----------
    alpha, beta : ndarray (na,), (nb,)
        Grid axes [-].
    unstable : ndarray of bool (nb, na)
        Converged Floquet verdict (largest |mu| > 1).
    gamma : float, optional
        Damping of the chart [-], for the title.
    curves : bool
        Overlay the undamped transition curves alpha = a_n(q)/4, b_n(q)/4 (q = 2 beta).
    """
    fig, ax = axes(ax)
    _mask_image(ax, alpha, beta, unstable, color)
    handles = [Patch(color=color, label="unstable (Floquet, |mu| > 1)")]
    if curves:
        for _, al, be in mathieu_transition_curves(float(beta.max()), float(alpha.min()),
                                                   float(alpha.max())):
            ax.plot(al, be, color="k", lw=0.7)
        handles.append(Line2D([], [], color="k", lw=0.7,
                              label="a_n(q)/4, b_n(q)/4 (scipy), gamma = 0"))
    ax.set_xlabel(r"$\alpha = k_0 / (m (N\omega)^2)$ [-]")
    ax.set_ylabel(r"$\beta = k_1 / (m (N\omega)^2)$ [-]")
    ax.set_xlim(alpha.min(), alpha.max())
    ax.set_ylim(beta.min(), beta.max())
    if gamma is not None:
        ax.set_title(rf"$\gamma$ = {gamma:g}")
    ax.legend(handles=handles, loc="upper left", fontsize=7, framealpha=0.9)
    return fig


def _log_ticks(lo: float, hi: float) -> list[float]:
    """1-2-3-5 ticks of each decade between ``lo`` and ``hi`` (at least the two ends)."""
    ticks = [m * 10.0**e for e in range(int(np.floor(np.log10(lo))), int(np.ceil(np.log10(hi))) + 1)
             for m in (1, 2, 3, 5)]
    inside = [t for t in ticks if lo * (1 - 1e-9) <= t <= hi * (1 + 1e-9)]
    return inside if len(inside) >= 2 else [lo, hi]


FLAGS = ("unstable, integrator_unstable, beyond_step_limit, or a condition such as"
         " ds.floquet_multiplier > 1 or ds.status == 1")
"""What a yes/no map draws (said where it is given something else)."""


def _flag(values, name: str, what: str, draw_it: str) -> np.ndarray:
    """``values`` as bool if they are a flag: bool, or integers that are all 0 or 1; else one
    ``ValueError`` naming ``name``, its dtype and range, what ``what`` draws and how to draw the
    values themselves (``draw_it``; a continuous
    variable, floquet_multiplier, was drawn as ``astype(bool)``: all red, "480 of 480")."""
    values = np.asarray(values)
    if values.dtype == bool:
        return values
    if values.dtype.kind in "iu" and np.isin(values, (0, 1)).all():
        return values.astype(bool)
    finite = values[np.isfinite(values)] if values.dtype.kind in "fc" else values
    span = (f"values {finite.min():g} to {finite.max():g}" if values.dtype.kind in "iuf"
            and finite.size else "no finite values" if values.dtype.kind in "fc" else
            f"values such as {values.flat[0]!r}" if values.size else "no values")
    raise ValueError(f"{what} draws a yes/no flag ({FLAGS}); {name} is {values.dtype} with"
                     f" {span}, not a flag: draw a condition on it, or the values themselves"
                     f" ({draw_it})")


def plot_stability_map(ds, var: str = "unstable", ax: Axes | None = None, title: str = "",
                       **kwargs) -> Figure:
    """``var`` of a result over its ``speed`` and ``damping`` (a study sweeping both, such as
    ``studies/stability_rig.yaml``; ``var``: ``unstable``, ``integrator_unstable`` of the
    ``floquet`` output, or a condition such as ``ds.status == 1`` given as a DataArray), drawn by
    ``plot_operating_map`` with the units and teeth the result carries. Other swept dims must be
    selected first (``ds.sel(...)``).

    The map is yes/no: ``var`` must be a flag (bool, or integers 0 and 1 only). A continuous
    variable (``floquet_multiplier``, ``p_pp``) is refused with a ``ValueError`` naming it,
    its dtype and range; draw a condition on it (``ds.floquet_multiplier > 1``) or the
    variable itself with ``ds.floquet_multiplier.plot(x="speed")``."""
    flag = ds[var] if isinstance(var, str) else var
    extra = [d for d in flag.dims if d not in ("speed", "damping")]
    missing = [d for d in ("speed", "damping") if d not in flag.dims]
    if missing:  # said "select the other dims first (ds.sel(speed=..., damping=...))"
        raise ValueError(f"a map over speed and damping: {flag.name or 'the flag'!r} has no"
                         f" {' and no '.join(missing)} dim (dims {tuple(flag.dims)}); give a"
                         " result of a study sweeping both")
    if extra:
        raise ValueError(f"a map over speed and damping: select the other dims first"
                         f" (ds.sel({', '.join(f'{d}=...' for d in extra)}))")
    name = repr(var) if isinstance(var, str) else repr(flag.name) if flag.name else "it"
    values = _flag(flag.transpose("damping", "speed").values, name, "plot_stability_map",
                   f"ds.{var}.plot(x='speed')" if isinstance(var, str) else ".plot(x='speed')")
    teeth = json.loads(ds.attrs["model"]).get("teeth") if "model" in ds.attrs else None
    kwargs.setdefault("label", var if isinstance(var, str) else "flagged")
    return plot_operating_map(flag["speed"].values, si_values(flag["damping"]), values, ax=ax,
                              title=title, teeth=teeth, **kwargs)


def plot_operating_map(speed: np.ndarray, damping: np.ndarray, flag: np.ndarray,
                       ax: Axes | None = None, title: str = "", color: str = UNSTABLE_COLOR,
                       limit_speed: np.ndarray | None = None, label: str = "unstable",
                       log: bool = True, zeta_per_damping: float | None = None,
                       teeth: int | None = None) -> Figure:
    """A yes/no map over driving-gear speed [rpm] and mesh damping c [N s/m]; with
    ``zeta_per_damping`` (damping ratio per N s/m) a right-hand axis gives the damping ratio.
    From a result Dataset: ``plot_stability_map(ds)``, which converts the file's units.

    Each computed damping is one row, ticked with its value: a row claims that damping and no
    other (on a continuous damping axis the cells reached halfway to the next computed value:
    with dampings 0 and 2 N s/mm the c = 0 row was drawn up to 1 N s/mm, never computed).
    ``damping_row`` gives the row of a damping, to draw on the map.

    Parameters
    ----------
    speed : ndarray (ns,)
        Driving-gear speed [rpm].
    damping : ndarray (nc,)
        Mesh viscous damping [N s/m], SI (a result stores N s/mm: given as ``ds.damping`` it
        is read in that unit; its values, ``ds.damping.values``, would be taken as N s/m).
    flag : ndarray of bool (nc, ns)
        Bool, or integers 0 and 1 only (anything else is refused: ``ValueError``).
    teeth : int, optional
        Teeth of the driving gear, named in the speed axis' label.
    limit_speed : ndarray (nc,), optional
        Speed below which the guard rail refuses the step, drawn as a line.
    log : bool
        Log speed axis.
    """
    speed = si_array(speed, "speed", "speed")
    damping = si_array(damping, "damping", "damping")
    if limit_speed is not None:
        limit_speed = si_array(limit_speed, "speed", "limit_speed")
    flag = _flag(flag, "flag", "plot_operating_map", "ax.pcolormesh")
    fig, ax = axes(ax)
    rows = np.arange(damping.size)
    _mask_image(ax, speed, rows, flag, color)
    handles = [Patch(color=color, label=f"{label} ({int(np.count_nonzero(flag))} of "
                                        f"{flag.size})")]
    if limit_speed is not None:
        ax.plot(limit_speed, rows, color="k", lw=1.2, ls="--")
        handles.append(Line2D([], [], color="k", ls="--",
                              label="step limit of the stability polynomial"))
    ax.set_xlabel("speed of the driving gear" + (f" ({teeth} teeth)" if teeth else "")
                  + " [rpm]")
    ax.set_ylabel("mesh damping c [N s/mm]\n(one row per computed value)")
    ax.set_yticks(rows, [f"{c / 1e3:g}" for c in damping])
    if log:
        from matplotlib.ticker import FixedLocator, NullLocator, ScalarFormatter

        ax.set_xscale("log")
        ax.xaxis.set_major_locator(FixedLocator(_log_ticks(float(speed.min()),
                                                           float(speed.max()))))
        ax.xaxis.set_minor_locator(NullLocator())
        ax.xaxis.set_major_formatter(ScalarFormatter())
    ax.set_xlim(speed.min(), speed.max())
    ax.set_ylim(-0.5, damping.size - 0.5)
    if zeta_per_damping:
        sec = ax.secondary_yaxis("right")
        sec.set_yticks(rows, [f"{zeta_per_damping * c:.3g}" for c in damping])
        sec.set_ylabel("damping ratio ζ [-]", fontsize=8)
        sec.tick_params(labelsize=7)
    ax.set_title(title, fontsize=9)
    ax.legend(handles=handles, loc="lower right", fontsize=7, framealpha=0.9)
    return fig


def damping_row(damping: np.ndarray, value: float) -> int:
    """The row of ``plot_operating_map`` (its y) that draws the damping ``value`` [N s/m] of
    the computed ``damping`` [N s/m]; ``ValueError`` where it was not computed (the map has no
    row for it)."""
    damping = si_array(damping, "damping", "damping")
    hit = np.flatnonzero(np.isclose(damping, value, rtol=1e-9, atol=0.0))
    if not hit.size:
        raise ValueError(f"the map has no row for c = {value / 1e3:g} N s/mm: its dampings are"
                         f" {', '.join(f'{c / 1e3:g}' for c in damping)} N s/mm")
    return int(hit[0])


def plot_stability_regions(methods: dict[str, np.ndarray], ax: Axes | None = None,
                           zetas: tuple[float, ...] = (0.0, 0.05, 0.2, 0.5),
                           extent: float = 4.0) -> Figure:
    """|R(z)| = 1 for each method in the complex z = h lambda plane, with the rays of damped
    poles (angle arccos(-zeta)).

    Parameters
    ----------
    methods : dict name -> coefficients
        Stability polynomial coefficients, lowest power first.
    """
    fig, ax = axes(ax)
    x = np.linspace(-extent, 1.0, 500)
    y = np.linspace(0.0, extent, 400)
    Z = x[None, :] + 1j * y[:, None]
    colors = ["C0", "C1", "C2", "C3", "C4", "C5"]
    handles = []
    for (name, coef), col in zip(methods.items(), colors, strict=False):
        R = np.zeros_like(Z)
        for c in reversed(coef):
            R = R * Z + float(c)
        ax.contour(x, y, np.abs(R), levels=[1.0], colors=[col], linewidths=1.3)
        ax.contourf(x, y, np.abs(R), levels=[0, 1.0], colors=[col], alpha=0.12)
        handles.append(Line2D([], [], color=col, label=f"{name}: |R(z)| = 1"))
    for i, z in enumerate(zetas):
        th = np.arccos(-z)
        ax.plot([0, extent * np.cos(th) * 1.2], [0, extent * np.sin(th) * 1.2], color="0.4",
                lw=0.6, ls=":")
        r = (0.95 - 0.08 * (i % 2)) * extent
        ax.annotate(rf"$\zeta$={z:g}", (r * np.cos(th), r * np.sin(th)), fontsize=7, color="0.3")
    ax.axvline(0, color="k", lw=0.5)
    ax.set_xlim(-extent, 1.0)
    ax.set_ylim(0, extent)
    ax.set_aspect("equal")
    ax.set_xlabel(r"Re $h\lambda$ [-]")
    ax.set_ylabel(r"Im $h\lambda$ [-]")
    ax.legend(handles=handles, loc="lower left", fontsize=7)
    ax.set_title("stability regions (shaded) and rays of damped poles", fontsize=9)
    return fig


def plot_step_limits(zeta_curve: np.ndarray, predicted: dict[str, np.ndarray],
                     zeta_points: np.ndarray, measured: dict[str, np.ndarray],
                     ax: Axes | None = None) -> Figure:
    """Largest stable h omega_n versus damping ratio: polynomial (lines) and integration (dots).

    Parameters
    ----------
    zeta_curve, zeta_points : ndarray
        Damping ratios [-] of the predicted curve and of the measured points.
    predicted, measured : dict name -> ndarray
        Step limits h omega_n [-].
    """
    fig, ax = axes(ax)
    for i, name in enumerate(predicted):
        ax.plot(zeta_curve, predicted[name], color=f"C{i}", lw=1.3,
                label=f"{name}: stability polynomial")
        ax.plot(zeta_points, measured[name], "o", color=f"C{i}", ms=4, mfc="none",
                label=f"{name}: integration diverges")
    ax.set_xlabel(r"damping ratio $\zeta = c / (2\sqrt{k m})$ [-]")
    ax.set_ylabel(r"largest stable $h\,\omega_n$ [-]")
    ax.set_ylim(0, None)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="lower right")
    ax.set_title("step limit of the fixed-step methods", fontsize=9)
    return fig


def plot_artifact_edges(ax: Axes, steps_per_period: np.ndarray, edge: dict[str, np.ndarray],
                        *, target_rpm: float = 200.0, rel: float = 0.25,
                        label: str = "") -> Figure:
    """Edge of the fixed-step criterion's "unstable region" against the step, one line per method.

    Parameters
    ----------
    ax : Axes
    steps_per_period : ndarray (nS,)
        Fixed steps per mesh period [-].
    edge : dict name -> ndarray (nS,)
        Highest speed [rpm] the criterion flags at that step (NaN: nothing flagged).
    target_rpm, rel : float
        The paper's claim (instability near ``target_rpm``), drawn as a band of +-``rel``.
    label : str
        What the edge is (e.g. the damping), for the title.
    """
    ax.axhspan(target_rpm * (1 - rel), target_rpm * (1 + rel), color="0.85", lw=0,
               label=f"{target_rpm:g} rpm (paper) +- {rel:.0%} (our tolerance)")
    for i, (name, e) in enumerate(edge.items()):
        ax.plot(steps_per_period, e, "osD^v"[i % 5] + "-", color=f"C{i}", ms=4 + i, mfc="none",
                lw=1.0, label=name)
    ax.set_xlabel("fixed steps per mesh period [-]")
    ax.set_ylabel("highest speed flagged unstable [rpm]")
    ax.set_yscale("log")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7)
    if label:
        ax.set_title(label, fontsize=9)
    return ax.figure

"""Figures of the static mesh: STE (Fig. 1), load sharing (Fig. 2), backlash spring (Fig. 3),
STE versus load and the effect of tip relief.

Every function takes a matplotlib ``ax`` and plain arrays, a
:class:`gearsweep.gear.mesh.MeshCycle`, or one mesh cycle of a mesh study's Dataset (``gearsweep
run`` of a ``type: mesh`` study, selected down to one gear variant and one torque), draws on
``ax`` and returns its figure. Arrays are in SI units; a result's variable or coordinate
(an xarray object with a ``units`` attribute: ``ds.ste`` in um, ``ds.torque`` in N m) is
converted from its unit (``plot.common.si_array``). Axes are labelled in engineering units
(um, mm, N m, kN).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import xarray as xr
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from gearsweep.errors import ResultError
from gearsweep.gear.mesh import MeshCycle
from gearsweep.plot.common import si_array
from gearsweep.units import si_data_vars

__all__ = [
    "plot_backlash_stiffness",
    "plot_load_sharing",
    "plot_ste",
    "plot_ste_harmonics",
    "plot_ste_vs_load",
    "plot_tip_relief",
]

UM = 1e6  # m -> um
MM = 1e3  # m -> mm
SINGLE_PAIR = "single pair"
"""Legend label of the shaded single-contact zone of ``plot_ste``."""


@dataclass(frozen=True)
class _Cycle:
    """The arrays of one mesh cycle the plots need, from a MeshCycle or a Dataset."""

    phase: np.ndarray
    ste: np.ndarray
    load_share: np.ndarray
    in_contact: np.ndarray
    contact_ratio: float
    base_pitch: float
    torque: float


def _cycle(data: MeshCycle | xr.Dataset) -> _Cycle:
    if isinstance(data, MeshCycle):
        return _Cycle(data.phase, data.ste, data.load_share, data.in_contact,
                      data.pair.contact_ratio, data.pair.base_pitch, data.torque)
    data = si_data_vars(data)  # a result stores display units (STE in um): here SI
    extra = set(data["ste"].dims) - {"mesh_phase"}
    if extra:
        raise ResultError(f"select one mesh cycle first (e.g. .sel(...)); extra dims {sorted(extra)}")
    keep = data["in_contact"].values.any(axis=0)  # drop pair slots padded for other variants
    return _Cycle(data["mesh_phase"].values, data["ste"].values,
                  data["load_share"].values[:, keep], data["in_contact"].values[:, keep],
                  float(data["contact_ratio"]), float(data["base_pitch"]), float(data["torque"]))


def _shade_single_contact(ax: Axes, phase: np.ndarray, n_pairs: np.ndarray, cycles: int) -> None:
    single = n_pairs == 1
    if not single.any():
        return
    dphi = phase[1] - phase[0]
    start = phase[single].min()
    stop = phase[single].max() + dphi
    # one legend entry per axes: a plot_ste per torque on one axes gave one each
    labelled = any(p.get_label() == SINGLE_PAIR for p in ax.patches)
    for c in range(cycles):
        ax.axvspan(c + start, c + stop, color="0.9", zorder=0,
                   label=None if c or labelled else SINGLE_PAIR)


def plot_ste(
    ax: Axes,
    phase: np.ndarray | MeshCycle,
    ste: np.ndarray | None = None,
    *,
    cycles: int = 2,
    label: str | None = None,
) -> Figure:
    """STE through the mesh cycle (paper Fig. 1), repeated over ``cycles`` mesh cycles.

    Parameters
    ----------
    ax : Axes
        Where to draw.
    phase : ndarray or MeshCycle or Dataset
        Mesh phase in [0, 1) [-], or a mesh cycle (then ``ste`` is taken from it and single
        contact is shaded).
    ste : ndarray, optional
        Static transmission error along the line of action [m] (or a result's ``ste``, read in
        its unit).
    cycles : int
        Mesh cycles to show [-].
    label : str, optional
        Legend label.

    Returns
    -------
    Figure
        The figure of ``ax``.
    """
    if isinstance(phase, MeshCycle | xr.Dataset):
        mc = _cycle(phase)
        phase, ste = mc.phase, mc.ste
        _shade_single_contact(ax, phase, mc.in_contact.sum(axis=1), cycles)
        if label is None:
            label = f"T = {mc.torque:g} N m"
    else:
        phase, ste = np.asarray(phase, dtype=float), si_array(ste, "displacement", "ste")
    x = np.concatenate([phase + c for c in range(cycles)] + [[cycles]])
    y = np.concatenate([ste] * cycles + [ste[:1]]) * UM
    ax.plot(x, y, lw=1.5, label=label)
    ax.set_xlabel("mesh phase [mesh cycles]")
    ax.set_ylabel("static transmission error [um]")
    ax.set_xlim(0, cycles)
    ax.grid(True, alpha=0.3)
    return ax.figure


def contact_zones(contact_ratio: float) -> tuple[np.ndarray, np.ndarray]:
    """Where the number of tooth pairs in contact changes along one pair's engagement, and how
    many are in contact between, in base pitches from the start of the path of contact.

    A pair at ``x`` (0 to ``eps``) shares the load with the pairs at ``x + k`` (``k`` a nonzero
    integer) that lie on the path: the count changes where one enters (``x`` an integer) or
    leaves (``eps - x`` an integer).

    Parameters
    ----------
    contact_ratio : float
        ``eps`` [-], at least 1.

    Returns
    -------
    bounds : ndarray
        ``0``, the changes in increasing order, ``eps`` [base pitches].
    pairs : ndarray of int
        Pairs in contact between consecutive bounds (one fewer entries than ``bounds``).
    """
    eps = float(contact_ratio)
    whole = np.arange(1, int(np.floor(eps)) + 1, dtype=float)
    inner = np.concatenate([whole, eps - whole])
    inner = np.unique(np.round(inner[(inner > 1e-9) & (inner < eps - 1e-9)], 12))
    bounds = np.concatenate([[0.0], inner, [eps]])
    mid = 0.5 * (bounds[:-1] + bounds[1:])
    pairs = (np.floor(eps - mid) + np.floor(mid) + 1).astype(int)
    return bounds, pairs


OTHER_PAIRS = "the other pairs in contact"
"""Legend label of the thin curves of ``plot_load_sharing``."""


def plot_load_sharing(ax: Axes, cycle: MeshCycle | xr.Dataset) -> Figure:
    """Load share of one tooth pair through its whole engagement (paper Fig. 2).

    The pair enters at the start of the path of contact (position 0) and leaves at its end
    (``epsilon_alpha`` mesh cycles later); every other pair in contact meanwhile is drawn thin,
    so that the shares add up to 1 at every position. Where one pair alone carries the load
    (a contact ratio below 2) its bounds are marked as gear 1's (the driving gear, whose flank
    the contact climbs from root to tip) lowest and highest points of single tooth contact,
    LPSTC and HPSTC (gear 2's are the reverse); with none (2 or more) the bounds where the count
    of pairs changes are marked and each zone says its count (a 2.47 pair was marked "HPSTC"
    and "LPSTC" where three pairs change to two, and drew only the neighbouring pairs: the
    shares did not add to 1 where three pairs carry it).

    Parameters
    ----------
    ax : Axes
        Where to draw.
    cycle : MeshCycle or Dataset
        A computed mesh cycle.

    Returns
    -------
    Figure
        The figure of ``ax``.
    """
    cycle = _cycle(cycle)
    pb = cycle.base_pitch
    n_slot = cycle.load_share.shape[1]
    pos = np.concatenate([cycle.phase + j for j in range(n_slot)])
    share = np.concatenate([cycle.load_share[:, j] for j in range(n_slot)])
    inside = np.concatenate([cycle.in_contact[:, j] for j in range(n_slot)])
    pos, share = pos[inside], share[inside]
    eps = cycle.contact_ratio
    # Close the curve at the end of the path of contact (last sample -> eps).
    pos = np.append(pos, eps)
    share = np.append(share, share[-1])
    to_mm = pb * MM
    others = [k for k in range(-n_slot + 1, n_slot) if k]  # every pair that meets [0, eps]
    for i, shift in enumerate(others):  # one legend entry for all (Fig. 2's were unexplained)
        # up to where ours leaves: the next pair's step to the whole load at that instant is the
        # next cycle's (drawn on the edge, it was a grey tick above the end of ours)
        ax.plot((pos + shift) * to_mm, np.where(pos + shift < eps, share, np.nan), color="0.6",
                lw=0.8, label=OTHER_PAIRS if i == 0 else None)
    ax.plot(pos * to_mm, share, color="C0", lw=2.0, label="one tooth pair")
    bounds, pairs = contact_zones(eps)
    for mark in bounds[1:-1]:
        ax.axvline(mark * to_mm, color="0.4", ls=":", lw=0.8)
    if (pairs == 1).any():  # gear 1's: contact climbs its flank from root (position 0) to tip
        for mark, text, side in ((eps - 1, "LPSTC of gear 1 (driving) ", "right"),
                                 (1.0, " HPSTC of gear 1", "left")):  # (outward: apart)
            ax.text(mark * to_mm, 1.03, text, ha=side, va="bottom", fontsize=8)
    else:
        for lo, hi, n in zip(bounds[:-1], bounds[1:], pairs, strict=True):
            if hi - lo > 0.08 * eps:  # (a sliver's count would overprint its neighbours')
                ax.text(0.5 * (lo + hi) * to_mm, 1.03, f"{n} pairs", ha="center", va="bottom",
                        fontsize=8)
    ax.set_xlim(0, eps * to_mm)
    ax.set_ylim(0, 1.12)
    ax.set_xlabel("position along the path of contact from its start [mm]")
    ax.set_ylabel("load share of the tooth pair [-]")
    ax.grid(True, alpha=0.3)
    return ax.figure


def plot_backlash_stiffness(
    ax: Axes,
    stiffness: float,
    backlash: float,
    p_max: float | None = None,
    *,
    mean_force: float | None = None,
) -> Figure:
    """Piecewise-linear mesh force ``k f(p)`` with backlash (paper Fig. 3, Eq. (8)).

    Parameters
    ----------
    ax : Axes
        Where to draw.
    stiffness : float
        Mesh stiffness ``k`` [N/m].
    backlash : float
        Total backlash along the line of action [m]; the dead zone is ``+-b``, ``b`` = half.
    p_max : float, optional
        Half range of ``p`` shown [m]; default ``2.5 b``.
    mean_force : float, optional
        Mean mesh force ``F_m`` to mark for scale [N].

    Returns
    -------
    Figure
        The figure of ``ax``.
    """
    stiffness = float(si_array(stiffness, "stiffness", "stiffness"))
    backlash = float(si_array(backlash, "length", "backlash"))
    b = 0.5 * backlash
    p_max = 2.5 * b if p_max is None else float(si_array(p_max, "length", "p_max"))
    if mean_force is not None:
        mean_force = float(si_array(mean_force, "force", "mean_force"))
    p = np.array([-p_max, -b, b, p_max])
    f = np.where(p > b, p - b, np.where(p < -b, p + b, 0.0))
    ax.plot(p * MM, stiffness * f / 1e3, color="C0", lw=2.0, label="k f(p)")
    ax.axhline(0.0, color="0.5", lw=0.6)
    ax.axvline(0.0, color="0.5", lw=0.6)
    for sign in (-1, 1):
        ax.axvline(sign * b * MM, color="C3", ls="--", lw=0.8)
    y_arrow = 0.15 * stiffness * p_max / 1e3
    ax.annotate(
        "", xy=(-b * MM, y_arrow), xytext=(b * MM, y_arrow),
        arrowprops={"arrowstyle": "<->", "color": "C3"},
    )  # fmt: skip
    ax.text(0.0, 0.2 * stiffness * p_max / 1e3, f"2b = {backlash * MM:.3g} mm", ha="center")
    ax.text(b * MM, -0.1 * stiffness * p_max / 1e3, " +b", color="C3", va="top")
    ax.text(-b * MM, -0.1 * stiffness * p_max / 1e3, "-b ", color="C3", va="top", ha="right")
    ax.text(
        0.02, 0.97, f"slope k = {stiffness / 1e6:.4g} N/um",
        transform=ax.transAxes, va="top", fontsize=8,
    )  # fmt: skip
    if mean_force is not None:
        ax.axhline(mean_force / 1e3, color="C2", lw=0.8)
        ax.text(
            -p_max * MM, mean_force / 1e3, f" mean mesh force $F_m$ = {mean_force / 1e3:.3g} kN",
            color="C2", va="bottom", fontsize=8,
        )  # fmt: skip
    ax.set_xlabel("relative displacement p along the line of action [mm]")
    ax.set_ylabel("mesh force k f(p) [kN]")
    ax.grid(True, alpha=0.3)
    return ax.figure


def plot_ste_vs_load(
    ax: Axes,
    torque: Sequence[float] | np.ndarray,
    peak_to_peak: Sequence[float] | np.ndarray,
    first_harmonic: Sequence[float] | np.ndarray,
    *,
    label: str = "",
    design_torque: float | None = None,
) -> Figure:
    """STE peak-to-peak and first mesh harmonic amplitude versus torque.

    Parameters
    ----------
    ax : Axes
        Where to draw.
    torque : array_like
        Torque on the driving gear [N m].
    peak_to_peak, first_harmonic : array_like
        STE peak-to-peak and amplitude of its first harmonic [m]. A result's variables (with
        their ``units``: um in a mesh study's file) are read in their unit.
    label : str
        Suffix for the legend entries (e.g. ``"no relief"``); the legend is drawn (again at
        each call: one entry per line).
    design_torque : float, optional
        Torque to mark with a vertical line [N m].

    Returns
    -------
    Figure
        The figure of ``ax``.
    """
    torque = si_array(torque, "torque", "torque")
    peak_to_peak = si_array(peak_to_peak, "displacement", "peak_to_peak")
    first_harmonic = si_array(first_harmonic, "displacement", "first_harmonic")
    (line,) = ax.plot(torque, peak_to_peak * UM, lw=2.0, label=f"peak-to-peak {label}".strip())
    ax.plot(
        torque, first_harmonic * UM, lw=1.5, ls="--", color=line.get_color(),
        label=f"1st harmonic {label}".strip(),
    )  # fmt: skip
    if design_torque is not None and not any(ln.get_gid() == "design" for ln in ax.lines):
        ax.axvline(design_torque, color="0.4", ls=":", lw=0.8, gid="design")
        ax.text(
            design_torque, 0.38, f" design load {design_torque:g} N m", rotation=90,
            transform=ax.get_xaxis_transform(), va="bottom", ha="left", fontsize=8, color="0.3",
        )  # fmt: skip
    ax.set_xlabel("torque on the driving gear [N m]")
    ax.set_ylabel("static transmission error [um]")
    ax.set_xlim(0, torque.max())
    ax.set_ylim(bottom=0)
    ax.grid(True, alpha=0.3)
    # which line is which (solid, dashed): a user's figure had two unexplained lines
    ax.legend(fontsize=8)
    return ax.figure


def plot_tip_relief(ax: Axes, cycles: Mapping[str, MeshCycle | xr.Dataset], *,
                    cycles_shown: int = 2) -> Figure:
    """STE through the mesh cycle of several gear variants (e.g. with and without tip relief).

    Parameters
    ----------
    ax : Axes
        Where to draw.
    cycles : mapping of label to MeshCycle or Dataset
        One mesh cycle per variant (at the same torque).
    cycles_shown : int
        Mesh cycles to show [-].

    Returns
    -------
    Figure
        The figure of ``ax``.
    """
    for label, data in cycles.items():
        c = _cycle(data)
        plot_ste(ax, c.phase, c.ste, cycles=cycles_shown, label=label)
    return ax.figure


def plot_ste_harmonics(ax: Axes, amplitudes: Mapping[str, np.ndarray], *, orders: int = 5
                       ) -> Figure:
    """Bars of the STE Fourier amplitudes of mesh orders 1..``orders`` for several variants.

    Parameters
    ----------
    ax : Axes
        Where to draw.
    amplitudes : mapping of label to ndarray
        ``ste_harmonic`` of each variant (index 0 = mean, not drawn) [m], or a result's
        ``ste_harmonic`` (read in its unit).
    orders : int
        Highest mesh order shown [-].

    Returns
    -------
    Figure
        The figure of ``ax``.
    """
    n = len(amplitudes)
    width = 0.8 / max(n, 1)
    k = np.arange(1, orders + 1)
    for i, (label, amp) in enumerate(amplitudes.items()):
        amp = si_array(amp, "displacement", f"ste_harmonic of {label!r}")
        ax.bar(k + (i - (n - 1) / 2) * width, amp[1:orders + 1] * UM, width,
               label=label)
    ax.set_xticks(k)
    ax.set_xlabel("mesh order [-]")
    ax.set_ylabel("STE harmonic amplitude [um]")
    ax.grid(True, axis="y", alpha=0.3)
    return ax.figure

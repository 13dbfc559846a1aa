"""Shared plotting helpers: a non-interactive backend, new axes, SI arrays from a result's
variables, and saving figures."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import matplotlib
import numpy as np

matplotlib.use("Agg", force=False)

import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.axes import Axes  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from gearsweep.errors import article  # noqa: E402
from gearsweep.units import UnitParseError, to_si  # noqa: E402

UM = 1e6
"""Micrometres per metre, for axes in um."""


def axes(ax: Axes | None = None, figsize=(7.0, 4.5)) -> tuple[Figure, Axes]:
    """The given axes and their figure, or a new figure with one axes."""
    if ax is None:
        fig, ax = plt.subplots(figsize=figsize, layout="constrained")
        return fig, ax
    return ax.figure, ax


def require(ds, names: tuple[str, ...], what: str, study: str) -> None:
    """One line (``ValueError``) where ``ds`` is not the result ``what`` draws: it lacks one of
    the variables ``names``, which ``study`` computes (a whine result gave an AttributeError of
    a global attribute)."""
    missing = [n for n in names if n not in getattr(ds, "variables", {})]
    if missing:
        raise ValueError(f"{what} draws the result of {study}; this one has no"
                         f" {', '.join(missing)}")


def si_array(x, kind: str, what: str) -> np.ndarray:
    """``x`` as a float array in SI, for the plot functions documented as taking SI arrays.

    A plain number, list or array is SI already (as those functions document) and is taken as
    it is. An object that says its unit, a result's variable or coordinate (``ds.ste`` in um,
    ``ds.torque`` in N m, ``ds.damping`` in N s/mm: its ``attrs["units"]``) or a pint Quantity,
    is converted from that unit to SI (they were drawn as if SI: an STE in um came out 1e6 times
    too large, an outside tester's finding). A unit that is not one of ``kind``
    (``gearsweep.units.KINDS``) is a ``ValueError`` naming ``what``.
    """
    attrs = getattr(x, "attrs", None)
    if isinstance(attrs, Mapping) and "units" in attrs:
        units, values = attrs["units"], getattr(x, "values", x)
    elif hasattr(x, "magnitude") and hasattr(x, "units"):  # a pint Quantity
        units, values = x.units, x.magnitude
    else:
        return np.asarray(x, dtype=float)
    units = str(units).strip()
    try:
        if units in ("", "1"):
            raise UnitParseError("is a plain number (no dimension)")
        factor = to_si(f"1 {units}", kind)
    except UnitParseError as exc:
        raise ValueError(f"{what} is {article(kind)}, given in {units!r}: that {exc} (a plain"
                         " array is read as SI)") from None
    return np.asarray(values, dtype=float) * factor


def save(fig: Figure, path: str | Path, dpi: int = 130) -> Path:
    """Write ``fig`` as PNG (creating the folder) and close it."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path

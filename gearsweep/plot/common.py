"""Shared plotting helpers: a non-interactive backend, new axes, and saving figures."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg", force=False)

import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.axes import Axes  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

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


def save(fig: Figure, path: str | Path, dpi: int = 130) -> Path:
    """Write ``fig`` as PNG (creating the folder) and close it."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path

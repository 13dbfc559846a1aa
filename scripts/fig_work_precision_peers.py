"""Draw the work-precision chart against the compiled peers from its data file (issue 25).

Reads ``results/work_precision_peers.nc`` (written by ``scripts/bench_peers.py``), or, where
that is absent, the committed copy ``docs/data/work_precision_peers.nc``; computes nothing.
Writes ``figures/work_precision_peers.png``.

    python scripts/fig_work_precision_peers.py [--data FILE] [--out PNG]
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
CANDIDATES = (ROOT / "results" / "work_precision_peers.nc",
              ROOT / "docs" / "data" / "work_precision_peers.nc")
DRAWN = ("amplitude_error", "wall_time", "rhs_evaluations", "fitted_order", "setting")
"""Variables the chart draws (tests/test_peers.py checks the committed file has them)."""
COLOR = {"gearsweep": "black", "numbalsoda": "C0", "diffrax": "C1", "scikit-sundae": "C2",
         "scipy": "C7"}
EVENTS_COLOR = "C3"
"""Variants with events at the backlash crossings (``*-events``: diffrax, numbalsoda)."""
MARKERS = "os^vDPX*<>hp8d"
TARGETS = (1e-4, 1e-6, 1e-8)


def data_file(explicit: Path | None = None) -> Path:
    if explicit is not None:
        return explicit
    for p in CANDIDATES:
        if p.exists():
            return p
    raise FileNotFoundError("no work_precision_peers.nc: run scripts/bench_peers.py")


def plot(ds: xr.Dataset, path: Path) -> None:
    scenes = list(ds.scene.values)
    fig, axes = plt.subplots(2, len(scenes), figsize=(6.2 * len(scenes), 13),
                             constrained_layout=True, squeeze=False)
    for col, s in enumerate(scenes):
        sub = ds.sel(scene=s)
        for row, (cost, xlabel) in enumerate((("wall_time", "wall time per case [s]"),
                                              ("rhs_evaluations",
                                               "right-hand-side evaluations per case [1]"))):
            ax = axes[row, col]
            for j, m in enumerate(ds.method.values):
                x = sub[cost].sel({"method": m}).values
                y = sub.amplitude_error.sel({"method": m}).values
                ok = np.isfinite(x) & np.isfinite(y) & (y > 0)
                if not ok.any():
                    continue
                fam = str(sub.family.sel({"method": m}).values)
                order = float(sub.fitted_order.sel({"method": m}))
                lab = f"{m} (order {order:.1f})" if math.isfinite(order) else f"{m} (order -)"
                ls = "-" if fam == "gearsweep" else ("--" if fam in ("numbalsoda", "diffrax")
                                                     else ":")
                events = str(m).endswith("-events")
                color = EVENTS_COLOR if events else COLOR.get(fam, "C9")
                ax.loglog(x[ok], y[ok], color=color, marker=MARKERS[j % len(MARKERS)],
                          ls=ls, ms=5, lw=1.6 if fam == "gearsweep" else 1.1, label=lab)
            for t in TARGETS:
                ax.axhline(t, color="0.6", lw=0.6, ls="-.")
            ax.set_xlabel(xlabel)
            ax.set_ylabel("relative amplitude error, max over cases [1]")
            ax.set_title(f"{s}: {int(sub.cases)} cases, {float(sub.speed_min):.0f}-"
                         f"{float(sub.speed_max):.0f} rpm", fontsize=10)
            ax.grid(True, which="major", alpha=0.3)
            if row == 1:
                ax.legend(fontsize=7.5, loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2)
    fig.suptitle("Work-precision against the peers: solid black gearsweep (fixed step), dashed "
                 "compiled peers (batch, all cores; red: with events at the backlash "
                 "crossings: diffrax, numbalsoda),\ndotted Python-RHS peers (serial time / "
                 "threads). Order: fitted "
                 "slope of error against steps per period (gearsweep) or RHS evaluations per "
                 "case (peers).\nDash-dot lines: the targets 1e-4, 1e-6, 1e-8. "
                 f"{ds.attrs.get('threads', '?')} threads; {ds.attrs.get('history', '')}",
                 fontsize=9)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--data", type=Path, default=None)
    ap.add_argument("--results", type=Path, default=None,
                    help="folder of results (the main job's); else results/, then docs/data/")
    ap.add_argument("--figures", type=Path, default=ROOT / "figures")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    args.out = args.out or args.figures / "work_precision_peers.png"
    explicit = args.data
    if explicit is None and args.results is not None:
        candidate = args.results / "work_precision_peers.nc"
        explicit = candidate if candidate.exists() else None
    try:
        src = data_file(explicit)
        with xr.open_dataset(src) as ds:
            ds = ds.load()
    except (OSError, ValueError) as exc:  # missing, or not a netCDF file: one line, exit 2
        print(f"fig_work_precision_peers: {explicit or 'the data file'}: cannot be read"
              f" ({type(exc).__name__}: {str(exc).splitlines()[0][:200]})", file=sys.stderr)
        return 2
    plot(ds, args.out)
    for s in ds.scene.values:
        for m in ds.method.values:
            o = float(ds.fitted_order.sel({"scene": s, "method": m}))
            if math.isfinite(o):
                print(f"order {s} {m}: {o:.2f}")
    print(f"read {src}, wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

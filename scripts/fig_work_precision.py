"""Work-precision study: error against cost for the fixed-step kernels and scipy's solvers.

Runs every method on the smooth whine scene and the rattle scene of
``gearsweep.analysis.precision``, writes ``results/work_precision.nc`` and
``figures/work_precision.png``, and (``--calibrate``) refits the error constants used by
``gearsweep.analysis.advise`` into ``gearsweep/analysis/data/error_constants.json``.

    PYTHONPATH=. python scripts/fig_work_precision.py [--calibrate] [--threads 1]
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import math
import subprocess
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numba  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

from gearsweep.analysis import precision as pr  # noqa: E402
from gearsweep.kernels.batch import precompile  # noqa: E402
from gearsweep.study.dataset import write_netcdf  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
FIXED = ("rk4", "rk5", "rk4-kink", "rk5-kink")
PEERS = ("RK45", "DOP853", "LSODA")
SPP = (8, 16, 32, 64, 128, 256, 512, 1024)
RTOL = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)
SCENES = {"whine": pr.whine_scene, "rattle": pr.rattle_scene}
STUDY_RPM = {"whine": 6000.0, "rattle": 9000.0}
CALIBRATION_RPM = {"whine": (3000.0, 4500.0, 9000.0, 12000.0),
                   "rattle": (7000.0, 8000.0, 10000.0, 13000.0)}
"""Speeds used to fit the advisor's error constants (the tests hold out other speeds)."""
ORDER = {"rk4": 4, "rk5": 5}
"""Orders assumed in the advisor's error model (the plain step on the rattle scene: 2)."""


def _split(name: str) -> tuple[str, bool]:
    return name.split("-")[0], name.endswith("-kink")


def study(window: pr.Window) -> xr.Dataset:
    """Run every method on both scenes; returns the Dataset (see DATA.md conventions)."""
    nf, ns, nr = len(FIXED), len(SPP), len(RTOL)
    shape_f = (len(SCENES), nf, ns)
    shape_p = (len(SCENES), len(PEERS), nr)
    out = {k: np.full(shape_f, np.nan) for k in ("te", "ae", "sec", "rhs")}
    peer = {k: np.full(shape_p, np.nan) for k in ("te", "ae", "sec", "rhs")}
    hw = np.full((len(SCENES), ns), np.nan)
    ref_note = {}
    for i, (name, make) in enumerate(SCENES.items()):
        scene = make(STUDY_RPM[name])
        ref = pr.reference(scene, window)
        p_ref = ref(pr.sample_times(scene, window))[0]
        if not scene.k_harmonics:  # cross-check the two references on the rattle scene
            alt = pr.reference(scene, window, exact=False)
            d = np.max(np.abs(alt(pr.sample_times(scene, window))[0] - p_ref))
            ref_note[name] = f"exact piecewise solution; DOP853-with-events differs by {d:.1e} m"
        else:
            ref_note[name] = "DOP853, rtol 1e-12, crossings as events"
        hw[i] = scene.period / np.asarray(SPP) * scene.omega_n
        for j, m in enumerate(FIXED):
            meth, kink = _split(m)
            for k, spp in enumerate(SPP):
                r = pr.run_fixed(scene, meth, spp, window, p_ref, kink_aware=kink)
                out["te"][i, j, k], out["ae"][i, j, k] = r.trajectory_error, r.amplitude_error
                out["sec"][i, j, k], out["rhs"][i, j, k] = r.seconds, r.rhs_evaluations
        for j, m in enumerate(PEERS):
            for k, tol in enumerate(RTOL):
                r = pr.run_scipy(scene, m, tol, window, p_ref)
                peer["te"][i, j, k], peer["ae"][i, j, k] = r.trajectory_error, r.amplitude_error
                peer["sec"][i, j, k], peer["rhs"][i, j, k] = r.seconds, r.rhs_evaluations
    dims_f = ("scene", "method", "steps_per_period")
    dims_p = ("scene", "peer", "rtol")

    def var(dims, data, units, long_name):
        return xr.Variable(dims, data, {"units": units, "long_name": long_name})

    ds = xr.Dataset(
        {
            "trajectory_error": var(dims_f, out["te"], "1",
                                    "max |p - p_ref| over the window / reference amplitude"),
            "amplitude_error": var(dims_f, out["ae"], "1",
                                   "|A - A_ref| / A_ref, A = half peak-to-peak of p"),
            "wall_time": var(dims_f, out["sec"], "s", "wall time per case (batch of 64)"),
            "rhs_evaluations": var(dims_f, out["rhs"], "1", "right-hand-side evaluations per case"),
            "h_omega_n": var(("scene", "steps_per_period"), hw, "1",
                             "step times natural frequency at the largest stiffness"),
            "peer_trajectory_error": var(dims_p, peer["te"], "1",
                                         "scipy solve_ivp: trajectory error"),
            "peer_amplitude_error": var(dims_p, peer["ae"], "1",
                                        "scipy solve_ivp: amplitude error"),
            "peer_wall_time": var(dims_p, peer["sec"], "s", "scipy solve_ivp: wall time per case"),
            "peer_rhs_evaluations": var(dims_p, peer["rhs"], "1",
                                        "scipy solve_ivp: right-hand-side evaluations"),
        },
        coords={
            "scene": ("scene", list(SCENES), {"long_name": "scene", "units": "-"}),
            "method": ("method", list(FIXED), {"long_name": "fixed-step method", "units": "-"}),
            "steps_per_period": ("steps_per_period", np.asarray(SPP),
                                 {"long_name": "steps per mesh period", "units": "-"}),
            "peer": ("peer", list(PEERS), {"long_name": "scipy solve_ivp method", "units": "-"}),
            "rtol": ("rtol", np.asarray(RTOL), {"long_name": "relative tolerance", "units": "1"}),
            "speed": ("scene", [STUDY_RPM[s] for s in SCENES],
                      {"long_name": "gear speed (48 teeth)", "units": "rpm"}),
        },
    )
    orders = {}
    for s in SCENES:
        for m in FIXED:
            for e in ("trajectory_error", "amplitude_error"):
                sel = ds[e].sel({"scene": s, "method": m})
                # CF: attribute names without hyphens (rk4-kink -> rk4_kink)
                orders[f"order_{s}_{m}_{e}".replace("-", "_")] = pr.fit_order(SPP, sel)
    ds.attrs.update({
        "Conventions": "CF-1.10",
        "title": "Work-precision study of the gearsweep kernels",
        "history": f"{dt.datetime.now(dt.UTC).isoformat(timespec='seconds')} "
                   f"scripts/fig_work_precision.py - gearsweep {_commit()}",
        "source": "gearsweep kernels (rk, kink) and scipy.integrate.solve_ivp",
        "window": f"{window.transient_periods} transient + {window.record_periods} recorded mesh "
                  f"periods from p = p' = 0, {pr.SAMPLES_PER_PERIOD} samples per period",
        "reference_whine": ref_note["whine"],
        "reference_rattle": ref_note["rattle"],
        "threads": numba.get_num_threads(),
        **{k: (v if math.isfinite(v) else "nan") for k, v in orders.items()},
    })
    return ds


def _commit() -> str:
    try:
        return subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
                              capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def plot(ds: xr.Dataset, path: Path) -> None:
    """Two rows (wall time, RHS evaluations) x two scenes: trajectory error against cost."""
    fig, axes = plt.subplots(2, 2, figsize=(12, 9), constrained_layout=True)
    styles = {"rk4": ("C0", "o", "-"), "rk5": ("C1", "s", "-"), "rk4-kink": ("C2", "^", "--"),
              "rk5-kink": ("C3", "v", "--"), "RK45": ("C4", "x", ":"),
              "DOP853": ("C5", "+", ":"), "LSODA": ("C7", "d", ":")}
    for col, s in enumerate(ds.scene.values):
        for row, (cost, pcost, xlabel) in enumerate(
                (("wall_time", "peer_wall_time", "wall time per case [s]"),
                 ("rhs_evaluations", "peer_rhs_evaluations",
                  "right-hand-side evaluations per case [-]"))):
            ax = axes[row, col]
            for m in ds.method.values:
                if s == "whine" and m.endswith("-kink"):
                    continue  # no backlash: identical to the plain step
                e = ds.trajectory_error.sel({"scene": s, "method": m})
                order = ds.attrs[f"order_{s}_{m}_trajectory_error".replace("-", "_")]
                c, mk, ls = styles[m]
                lab = f"{m}  (order {order:.2f})" if order != "nan" else m
                ax.loglog(ds[cost].sel({"scene": s, "method": m}), e, color=c, marker=mk, ls=ls,
                          label=lab)
                if row == 0:
                    for spp, x, y in zip(ds.steps_per_period.values,
                                         ds[cost].sel({"scene": s, "method": m}).values, e.values,
                                         strict=True):
                        if m in ("rk4", "rk4-kink") and np.isfinite(y):
                            ax.annotate(str(spp), (x, y), fontsize=7, color=c,
                                        xytext=(3, 3), textcoords="offset points")
            for p in ds.peer.values:
                c, mk, ls = styles[p]
                ax.loglog(ds[pcost].sel(scene=s, peer=p), ds.peer_trajectory_error.sel(
                    scene=s, peer=p), color=c, marker=mk, ls=ls, label=f"scipy {p}")
            ax.set_xlabel(xlabel)
            ax.set_ylabel("trajectory error / amplitude [-]")
            rpm = float(ds.speed.sel(scene=s))
            desc = ("time-varying stiffness + STE, no backlash" if s == "whine"
                    else "constant stiffness, backlash 4 um, contact loss")
            ax.set_title(f"{s} scene, {rpm:.0f} rpm: {desc}", fontsize=10)
            if s == "whine":
                ax.text(0.98, 0.98, "rk4-kink, rk5-kink: identical to rk4, rk5\n(no backlash)",
                        transform=ax.transAxes, ha="right", va="top", fontsize=8)
            ax.grid(True, which="major", alpha=0.3)
            ax.legend(fontsize=8, loc="lower left" if row == 0 else "lower left")
    fig.suptitle("Work-precision: error against cost (labels on rk4 points: steps per mesh "
                 "period; order = fitted slope of error against steps per period)", fontsize=11)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def calibrate(window: pr.Window) -> dict:
    """Fit C in err <= C (h omega_n)^p per method and scene kind over the calibration speeds
    (upper envelope of err / (h omega_n)^p over the asymptotic points)."""
    table = {}
    for kind, make in SCENES.items():
        for m in FIXED:
            meth, kink = _split(m)
            if kind == "whine" and kink:
                continue
            p = ORDER[meth] if (kind == "whine" or kink) else 2
            ratios = []
            for rpm in CALIBRATION_RPM[kind]:
                scene = make(rpm)
                ref = pr.reference(scene, window)
                p_ref = ref(pr.sample_times(scene, window))[0]
                for spp in SPP:
                    hw = scene.period / spp * scene.omega_n
                    r = pr.run_fixed(scene, meth, spp, window, p_ref, kink_aware=kink, copies=1,
                                     repeat=1)
                    e = r.trajectory_error
                    if math.isfinite(e) and 1e-10 < e < 1e-2:
                        ratios.append(e / hw**p)
            table[f"{kind}/{m}"] = {"order": p, "C": float(max(ratios)),
                                    "points": len(ratios)}
    return {
        "description": "trajectory error <= C (h omega_n)^order, C = upper envelope over the "
                       "calibration runs; error relative to the amplitude (see "
                       "gearsweep.analysis.precision)",
        "source": f"scripts/fig_work_precision.py --calibrate, gearsweep {_commit()}, "
                  f"{dt.datetime.now(dt.UTC).date().isoformat()}",
        "calibration_speeds_rpm": CALIBRATION_RPM,
        "window_periods": [window.transient_periods, window.record_periods],
        "constants": table,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--calibrate", action="store_true", help="refit the advisor's constants")
    ap.add_argument("--threads", type=int, default=1, help="numba threads for the kernels")
    ap.add_argument("--compile-jobs", type=int, default=None,
                    help="processes that compile the kernels side by side (default: all cores)")
    ap.add_argument("--results", type=Path, default=ROOT / "results", help="folder for the .nc")
    ap.add_argument("--figures", type=Path, default=ROOT / "figures", help="folder for the PNG")
    args = ap.parse_args()
    numba.set_num_threads(args.threads)
    window = pr.Window()
    t0 = time.perf_counter()
    calls = [{**SCENES[s](STUDY_RPM[s]).kernel_kwargs(SPP[0]), "method": meth,
              "kink_aware": kink, "signal_stride": 1}
             for s in SCENES for meth, kink in map(_split, FIXED)]
    sec = precompile(calls, args.compile_jobs)
    print(f"kernels compiled or loaded from the cache in {sec:.1f} s")
    ds = study(window)
    args.results.mkdir(parents=True, exist_ok=True)
    args.figures.mkdir(parents=True, exist_ok=True)
    write_netcdf(ds, args.results / "work_precision.nc")
    plot(ds, args.figures / "work_precision.png")
    for k, v in ds.attrs.items():
        if k.startswith("order_") and k.endswith("trajectory_error"):
            print(f"{k}: {v}")
    if args.calibrate:
        data = calibrate(window)
        out = ROOT / "gearsweep" / "analysis" / "data" / "error_constants.json"
        out.parent.mkdir(exist_ok=True)
        out.write_text(json.dumps(data, indent=2) + "\n")
        print(json.dumps(data["constants"], indent=1))
    print(f"work-precision study: {time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()

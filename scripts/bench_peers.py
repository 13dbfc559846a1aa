"""Work-precision against the compiled peers (issue 25): every method over batches of cases.

Runs gearsweep's RK4 / RK5 (and the kink-aware steps where the scene has backlash), numbalsoda
(LSODA, DOP853; Numba prange over the cases; and DOP853 with events at the backlash crossings
where the scene has backlash), diffrax (Tsit5, Dopri5, Dopri8; vmap, CPU; and Dopri5, Dopri8
with events at the backlash crossings),
SUNDIALS CVODE (scikit-sundae, Adams) and scipy solve_ivp (RK45, DOP853, LSODA) on the whine
scene, the rattle scene and benchmark B1 (see ``gearsweep.analysis.peers``), writes
``results/work_precision_peers.nc`` and prints, per scene, the cost per case at equal accuracy
(the tables of docs/performance.md).

    nice -n 5 .venv/bin/python scripts/bench_peers.py [--cases 1000] [--copy-to docs/data]

The compiled peers and gearsweep run the whole batch (all cores); the Python-right-hand-side
peers (scipy, CVODE) run ``--serial-cases`` of the error cases one after the other, and their cost
per case is the serial time divided by the cores (an ideal process pool: this favours them).
A peer that is not installed is recorded in the file's attributes and skipped.
"""

from __future__ import annotations

import argparse
import datetime as dt
import math
import os
import shutil
import time
from importlib import metadata
from pathlib import Path

import numba
import numpy as np
import xarray as xr
from _common import git_commit

from gearsweep.analysis import peers as P
from gearsweep.analysis import precision as pr
from gearsweep.analysis.advise import advise
from gearsweep.study.dataset import write_netcdf

ROOT = Path(__file__).resolve().parents[1]
SPP = {"whine": (8, 16, 32, 64, 128, 256, 512, 1024), "rattle": (8, 16, 32, 64, 128, 256, 512, 1024),
       "B1": (16, 32, 64, 128, 256, 512, 1024, 2048)}
_RTOL = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)
RTOL = {"numbalsoda-LSODA": (*_RTOL, 1e-11), "numbalsoda-DOP853": (*_RTOL, 1e-11),
        "numbalsoda-DOP853-events": (*_RTOL, 1e-11),
        "diffrax-Tsit5": _RTOL, "diffrax-Dopri5": _RTOL, "diffrax-Dopri8": (*_RTOL, 1e-11),
        "diffrax-Dopri5-events": _RTOL, "diffrax-Dopri8-events": (*_RTOL, 1e-11),
        "cvode-Adams": _RTOL, "scipy-RK45": _RTOL, "scipy-DOP853": _RTOL, "scipy-LSODA": _RTOL}
"""Tolerances of the peers: every decade from 1e-3 to 1e-10, one more where the 1e-8 target
may need it (numbalsoda, Dopri8: 1e-11). The stopping rules below keep the run in minutes."""
TARGETS = (1e-4, 1e-6, 1e-8)
FAMILY = {"rk4": "gearsweep", "rk5": "gearsweep", "rk4-kink": "gearsweep", "rk5-kink": "gearsweep",
          "rk4-banded": "gearsweep", "rk5-banded": "gearsweep",
          "numbalsoda-LSODA": "numbalsoda", "numbalsoda-DOP853": "numbalsoda",
          "numbalsoda-DOP853-events": "numbalsoda",
          "diffrax-Tsit5": "diffrax", "diffrax-Dopri5": "diffrax", "diffrax-Dopri8": "diffrax",
          "diffrax-Dopri5-events": "diffrax", "diffrax-Dopri8-events": "diffrax",
          "cvode-Adams": "scikit-sundae", "scipy-RK45": "scipy", "scipy-DOP853": "scipy",
          "scipy-LSODA": "scipy"}
METHODS = tuple(FAMILY)
NLEVEL = max(max(len(v) for v in SPP.values()), max(len(v) for v in RTOL.values()))
BAND_RATIO = 2.0
"""rk4-banded, rk5-banded: one kernel call per speed band of at most this ratio (see
``peers.run_gearsweep_banded``); on scenes without backlash whose speed range is wider."""
ADVISED = ("rk4", "rk5", "rk4-kink", "rk5-kink")
"""Methods for which the advisor's step count is run at each target (kink: backlash scenes)."""
ADVISED_MAX_MSTEPS = 1500.0
"""An advised step count costing more lane-steps than this over the batch is not run."""
SLOW_BATCH = 15.0
"""A peer's batch (or a serial peer's run over its cases) slower than this [s]: its tighter
tolerances are not run (``stopped``)."""
SLOW_BATCH_EVENTS = 30.0
"""The same for the variants with events at the backlash crossings (diffrax, numbalsoda DOP853;
backlash scenes only): each restart costs, and the cap of 15 s would stop diffrax's before the
1e-6 target."""
EVENT_SOLVERS = ("Dopri5", "Dopri8")
"""diffrax solvers run with events (``peers.diffrax_event_solver``); Tsit5 behaves as Dopri5."""
EVENT_CHUNK = 50
"""diffrax with events: ``vmap`` over this many cases per call, the calls one after the other
(under ``vmap`` every piece of a call lasts as long as its slowest case: the cost per case grows
with the lanes; trials before the run: 3.7 / 6.1 / 19.5 ms per case for chunks of 50 / 100 /
200 at rtol 1e-5). The run also times one call over the whole batch at EVENT_ONE_CALL_RTOL."""
EVENT_ONE_CALL_RTOL = 1e-5


def _installed(dist: str) -> str | None:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return None


def run_scene(batch: P.Batch, ref: np.ndarray, args, log) -> dict:
    name = batch.name
    serial = batch.error_cases[np.round(np.linspace(0, len(batch.error_cases) - 1,
                                                    args.serial_cases)).astype(int)]
    shape = (len(METHODS), NLEVEL)
    out = {k: np.full(shape, np.nan) for k in ("setting", "te_max", "te_med", "ae_max", "ae_med",
                                                "sec", "rhs")}
    cases = np.full(len(METHODS), np.nan)
    ecases = np.full(len(METHODS), np.nan)
    compile_s = np.full(len(METHODS), np.nan)
    stopped = np.zeros(len(METHODS))
    one_call = {}
    cores = numba.get_num_threads()

    def record(m, lev, setting, run, serial_run=False):
        i = METHODS.index(m)
        te, ae = P.errors_of(run, batch, ref)
        cover = np.isin(batch.error_cases, run.case_index)
        te, ae = te[cover], ae[cover]
        fail = not np.all(np.isfinite(te))
        out["setting"][i, lev] = setting
        out["te_max"][i, lev] = np.nan if fail else te.max()
        out["te_med"][i, lev] = np.nan if fail else np.median(te)
        out["ae_max"][i, lev] = np.nan if fail else ae.max()
        out["ae_med"][i, lev] = np.nan if fail else np.median(ae)
        out["sec"][i, lev] = run.seconds_per_case / (cores if serial_run else 1)
        out["rhs"][i, lev] = float(np.nanmean(run.rhs_evaluations))
        cases[i], ecases[i] = run.cases, cover.sum()
        log(f"[{name}] {m:18s} {setting:9.3g}  amp err {out['ae_max'][i, lev]:9.2e}  traj err "
            f"{out['te_max'][i, lev]:9.2e}  {1e6 * out['sec'][i, lev]:10.2f} us/case  "
            f"{out['rhs'][i, lev]:10.0f} rhs/case")

    def repeat_for(seconds):
        return args.repeat if seconds * args.repeat < SLOW_BATCH else 1

    def best_of(run):
        """A run over a second is timed once; a shorter one is the best of ``--repeat``."""
        r = run()
        for _ in range(args.repeat - 1 if r.seconds < 1.0 else 0):
            r2 = run()
            if r2.seconds < r.seconds:
                r = r2
        return r

    # gearsweep
    backlash = batch.scenes[0].half_gap is not None
    banded = len(P.speed_bands(batch, BAND_RATIO)) > 1
    methods = (["rk4", "rk5"] + (["rk4-kink", "rk5-kink"] if backlash else [])
               + (["rk4-banded", "rk5-banded"] if banded and not backlash else []))
    for m in methods:
        meth, kink = m.split("-")[0], m.endswith("-kink")
        t0 = time.perf_counter()
        P.run_gearsweep(P.BATCHES[name](64), meth, SPP[name][0], kink_aware=kink, repeat=1)
        compile_s[METHODS.index(m)] = time.perf_counter() - t0
        for lev, spp in enumerate(SPP[name]):
            if m.endswith("-banded"):
                r = best_of(lambda spp=spp, meth=meth: P.run_gearsweep_banded(batch, meth, spp,
                                                                   ratio=BAND_RATIO, repeat=1))
            else:
                r = best_of(lambda spp=spp, meth=meth, kink=kink: P.run_gearsweep(
                    batch, meth, spp, kink_aware=kink, repeat=1))
            record(m, lev, spp, r)
    # what the advisor recommends for a target trajectory error, run and measured
    adv = {k: np.full((len(ADVISED), len(TARGETS)), np.nan) for k in ("spp", "te", "ae", "sec")}
    for a, am in enumerate(ADVISED):
        meth = am.split("-")[0]
        kink = backlash and am.endswith("-kink")
        if am.endswith("-kink") and not backlash:
            continue
        for t, target in enumerate(TARGETS):
            sc = batch.scenes[0]
            advice = advise(mass=pr.MASS, k0=pr.K0, damping=pr.DAMPING, speed_rpm=batch.rpm,
                            teeth=pr.TEETH, k_harmonics=pr.K_HARMONICS if sc.k_harmonics else (),
                            backlash=4e-6 if backlash else None, method=meth, kink_aware=kink,
                            target=target, periods=batch.window.periods)
            spp = advice.steps_per_period
            adv["spp"][a, t] = spp
            if advice.msteps > ADVISED_MAX_MSTEPS:
                log(f"[{name}] advisor {am} @ {target:.0e}: {spp} steps/period, "
                    f"{advice.msteps:.0f} Msteps: not run")
                continue
            r = best_of(lambda spp=spp, meth=meth, kink=kink: P.run_gearsweep(
                batch, meth, spp, kink_aware=kink, repeat=1))
            te, ae = P.errors_of(r, batch, ref)
            adv["te"][a, t], adv["ae"][a, t] = te.max(), ae.max()
            adv["sec"][a, t] = r.seconds_per_case
            log(f"[{name}] advisor {am} @ {target:.0e}: {spp} steps/period, traj err "
                f"{te.max():.2e}, amp err {ae.max():.2e}, {1e6 * r.seconds_per_case:.2f} us/case")

    def tolerances(m, run, serial_run=False, cap=SLOW_BATCH):
        i = METHODS.index(m)
        for lev, tol in enumerate(RTOL[m]):
            r = run(tol) if serial_run else best_of(lambda tol=tol: run(tol))
            record(m, lev, tol, r, serial_run=serial_run)
            if r.seconds > cap and lev + 1 < len(RTOL[m]):
                stopped[i] = 1.0
                log(f"[{name}] {m}: {'serial run' if serial_run else 'batch'} took "
                    f"{r.seconds:.1f} s > {cap:g} s, tighter tolerances not run")
                break

    # numbalsoda
    fams = set(args.families)
    if "numbalsoda" in fams and _installed("numbalsoda"):
        for solver in ("LSODA", "DOP853"):
            m = f"numbalsoda-{solver}"
            compile_s[METHODS.index(m)] = P.numbalsoda_compile(batch, solver)
            tolerances(m, lambda tol, solver=solver: P.run_numbalsoda(batch, tol, solver, repeat=1))
        if backlash:
            m = "numbalsoda-DOP853-events"
            t0 = time.perf_counter()
            P.run_numbalsoda_events(P.BATCHES[name](4), 1e-3, repeat=1)
            compile_s[METHODS.index(m)] = time.perf_counter() - t0

            def run_nbev(tol, m=m):
                r = P.run_numbalsoda_events(batch, tol, repeat=1)
                log(f"[{name}] {m} {tol:.0e}: pieces per case max {r.notes['pieces_max']}, "
                    f"mean {r.notes['pieces_mean']:.1f}")
                return r

            tolerances(m, run_nbev, cap=SLOW_BATCH_EVENTS)
    # diffrax
    if "diffrax" in fams and _installed("diffrax") and _installed("jax"):
        for solver in P.DIFFRAX_SOLVERS:
            m = f"diffrax-{solver}"
            compiled, sec, per_step = P.diffrax_compile(batch, solver)
            compile_s[METHODS.index(m)] = sec
            tolerances(m, lambda tol, c=compiled, k=per_step: P.run_diffrax(batch, c, k, tol,
                                                                            repeat=1))
        if backlash:
            for solver in EVENT_SOLVERS:
                m = f"diffrax-{solver}-events"
                compiled, sec, per_step = P.diffrax_event_compile(batch, solver,
                                                                  chunk=EVENT_CHUNK)
                compile_s[METHODS.index(m)] = sec
                if solver == EVENT_SOLVERS[0]:
                    whole, sec1, _ = P.diffrax_event_compile(batch, solver)
                    r1 = P.run_diffrax_events(batch, whole, per_step, EVENT_ONE_CALL_RTOL,
                                              repeat=1)
                    one_call[m] = (f"{m} rtol {EVENT_ONE_CALL_RTOL:g}, one vmap call over all "
                                   f"{batch.n} cases: {1e6 * r1.seconds_per_case:.0f} us/case "
                                   f"(compile {sec1:.1f} s)")
                    log(f"[{name}] {one_call[m]}")
                    del whole

                def run_ev(tol, c=compiled, k=per_step, m=m):
                    r = P.run_diffrax_events(batch, c, k, tol, repeat=1)
                    log(f"[{name}] {m} {tol:.0e}: pieces per case max {r.notes['pieces_max']}, "
                        f"mean {r.notes['pieces_mean']:.1f}; steps max {r.notes['max_steps_in_batch']}")
                    return r

                tolerances(m, run_ev, cap=SLOW_BATCH_EVENTS)
    # serial peers
    if "scikit-sundae" in fams and _installed("scikit-sundae"):
        tolerances("cvode-Adams", lambda tol: P.run_cvode(batch, tol, serial), serial_run=True)
    for solver in ("RK45", "DOP853", "LSODA") if "scipy" in fams else ():
        tolerances(f"scipy-{solver}", lambda tol, solver=solver: P.run_scipy(batch, solver, tol,
                                                                             serial),
                   serial_run=True)
    return {"batch": batch, "out": out, "cases": cases, "error_cases": ecases,
            "compile": compile_s, "advised": adv, "stopped": stopped, "one_call": one_call}


def fitted_orders(setting, err, rhs, method) -> float:
    """Fixed-step methods: against steps per period (as scripts/fig_work_precision.py); adaptive
    peers: against the right-hand-side evaluations per case (an effective order)."""
    x = setting if FAMILY[method] == "gearsweep" else rhs
    return pr.fit_order(x, err)


def dataset(res: dict, args, command: str) -> xr.Dataset:
    scenes = list(res)

    def stack(key):
        return np.stack([res[s]["out"][key] for s in scenes])

    def var(dims, data, units, long_name, **extra):
        return xr.Variable(dims, data, {"units": units, "long_name": long_name, **extra})

    d3 = ("scene", "method", "level")
    d2 = ("scene", "method")
    da = ("scene", "advised_method", "target")

    def advised(key):
        return np.stack([res[s]["advised"][key] for s in scenes])

    orders = {e: np.full((len(scenes), len(METHODS)), np.nan) for e in ("ae_max", "te_max")}
    for i, s in enumerate(scenes):
        o = res[s]["out"]
        for j, m in enumerate(METHODS):
            for e in orders:
                orders[e][i, j] = fitted_orders(o["setting"][j], o[e][j], o["rhs"][j], m)
    versions = {f"{k.replace('-', '_')}_version": (_installed(k) or "not installed")
                for k in ("numba", "numbalsoda", "jax", "diffrax", "optimistix", "scikit-sundae",
                          "scipy")}
    ds = xr.Dataset(
        {
            "setting": var(d3, stack("setting"), "1",
                           "steps per mesh period (gearsweep) or relative tolerance rtol = atol "
                           "in scaled variables (peers)"),
            "amplitude_error": var(d3, stack("ae_max"), "1",
                                   "max over the error cases of |A - A_ref| / A_ref, A = half "
                                   "peak-to-peak of p over the window"),
            "amplitude_error_median": var(d3, stack("ae_med"), "1",
                                          "median over the error cases of |A - A_ref| / A_ref"),
            "trajectory_error": var(d3, stack("te_max"), "1",
                                    "max over the error cases of max |p - p_ref| / A_ref"),
            "trajectory_error_median": var(d3, stack("te_med"), "1",
                                           "median over the error cases of max |p - p_ref| / A_ref"),
            "wall_time": var(d3, stack("sec"), "s",
                             "wall time per case, batch on all cores, compile excluded"),
            "rhs_evaluations": var(d3, stack("rhs"), "1",
                                   "right-hand-side evaluations per case (mean over the batch)"),
            "cases_timed": var(d2, np.stack([res[s]["cases"] for s in scenes]), "1",
                               "cases in the timed batch"),
            "cases_error": var(d2, np.stack([res[s]["error_cases"] for s in scenes]), "1",
                               "cases compared with the reference"),
            "stopped": var(d2, np.stack([res[s]["stopped"] for s in scenes]), "1",
                           "1: tighter tolerances not run (batch slower than the cap)",
                           cap_seconds=SLOW_BATCH, cap_seconds_events=SLOW_BATCH_EVENTS),
            "compile_time": var(d2, np.stack([res[s]["compile"] for s in scenes]), "s",
                                "first call (compile, or load from Numba's disk cache)"),
            "fitted_order": var(d2, orders["ae_max"], "1",
                                "minus the slope of log amplitude error against log steps per "
                                "period (gearsweep) or log rhs evaluations per case (peers)"),
            "fitted_order_trajectory": var(d2, orders["te_max"], "1",
                                           "as fitted_order, for the trajectory error"),
            "advised_steps": var(da, advised("spp"), "1",
                                 "steps per mesh period advised by gearsweep.analysis.advise for "
                                 "the target trajectory error"),
            "advised_trajectory_error": var(da, advised("te"), "1",
                                            "measured trajectory error at the advised steps, "
                                            "max over the error cases"),
            "advised_amplitude_error": var(da, advised("ae"), "1",
                                           "measured amplitude error at the advised steps, max "
                                           "over the error cases"),
            "advised_wall_time": var(da, advised("sec"), "s",
                                     "wall time per case at the advised steps"),
        },
        coords={
            "scene": ("scene", scenes, {"long_name": "scene", "units": "1"}),
            "method": ("method", list(METHODS), {"long_name": "method or peer", "units": "1"}),
            "family": ("method", [FAMILY[m] for m in METHODS],
                       {"long_name": "package", "units": "1"}),
            "level": ("level", np.arange(NLEVEL), {"long_name": "setting index", "units": "1"}),
            "advised_method": ("advised_method", list(ADVISED),
                               {"long_name": "gearsweep method given to the advisor", "units": "1"}),
            "target": ("target", np.asarray(TARGETS),
                       {"long_name": "target error relative to the amplitude", "units": "1"}),
            "speed_min": ("scene", [res[s]["batch"].rpm_min for s in scenes],
                          {"long_name": "lowest gear speed of the batch (48 teeth)", "units": "rpm"}),
            "speed_max": ("scene", [res[s]["batch"].rpm_max for s in scenes],
                          {"long_name": "highest gear speed of the batch (48 teeth)",
                           "units": "rpm"}),
            "cases": ("scene", [res[s]["batch"].n for s in scenes],
                      {"long_name": "cases in the batch", "units": "1"}),
            "window_periods": ("scene", [res[s]["batch"].window.periods for s in scenes],
                               {"long_name": "mesh periods integrated from rest", "units": "1"}),
            "record_periods": ("scene", [res[s]["batch"].window.record_periods for s in scenes],
                               {"long_name": "mesh periods in the recorded window", "units": "1"}),
        },
    )
    ds.attrs.update({
        "Conventions": "CF-1.10",
        "title": "Work-precision of gearsweep against compiled and interpreted peers (issue 25)",
        "history": f"{dt.datetime.now(dt.UTC).isoformat(timespec='seconds')} {command}",
        "source": f"scripts/bench_peers.py, gearsweep {git_commit()}",
        "reference": "gearsweep.analysis.precision.reference: exact piecewise solution (rattle), "
                     "DOP853 rtol 1e-12 with crossings as events (whine, B1)",
        "error_cases": "evenly spread over the batch, first and last case included",
        "serial_peers": "scipy and CVODE run a subset of the error cases one at a time with a "
                        "Python right-hand side; wall_time = serial time per case / threads "
                        "(an ideal process pool)",
        "threads": cores_used(),
        "jax_devices": _jax_devices(),
        "diffrax_events_chunk": f"diffrax *-events: vmap over {EVENT_CHUNK} cases per call, the "
                                "calls one after the other",
        "diffrax_events_one_call": "; ".join(f"{s}: {v}" for s in scenes
                                             for v in res[s]["one_call"].values()) or "not run",
        "cpu_count": os.cpu_count(),
        **versions,
    })
    return ds


def _jax_devices() -> str:
    if not _installed("jax"):
        return "jax not installed"
    import jax

    return ", ".join(str(d) for d in jax.devices())


def cores_used() -> int:
    return numba.get_num_threads()



def tables(ds: xr.Dataset, error: str = "amplitude_error") -> str:
    """Markdown: cost per case at equal accuracy and gearsweep's speed-up over each method."""
    lines = []
    for s in ds.scene.values:
        sub = ds.sel(scene=s)
        cost = {}
        for m in ds.method.values:
            sel = sub.sel({"method": m})
            cost[m] = [P.cost_at(sel[error].values, sel.wall_time.values, t) for t in TARGETS]
        gs = [m for m in ds.method.values if FAMILY[m] == "gearsweep"]
        best = []
        for k in range(len(TARGETS)):
            c = [(cost[m][k][0], m) for m in gs if math.isfinite(cost[m][k][0])]
            best.append(min(c) if c else (math.nan, "-"))
        lines.append(f"\n{s} ({float(sub.speed_min):.0f}-{float(sub.speed_max):.0f} rpm, "
                     f"{int(sub.cases)} cases; {error.replace('_', ' ')} max over "
                     f"{int(np.nanmax(sub.cases_error.values))} error cases)\n")
        head = "| method | order | " + " | ".join(
            f"us/case @ {t:.0e} | gearsweep x" for t in TARGETS) + " |"
        lines.append(head)
        lines.append("|" + "---|" * (2 + 2 * len(TARGETS)))
        for m in ds.method.values:
            if not np.isfinite(sub.wall_time.sel({"method": m}).values).any():
                continue
            o = float(sub.fitted_order.sel({"method": m}))
            row = f"| {m} | {o:.2f} |" if math.isfinite(o) else f"| {m} | - |"
            for k in range(len(TARGETS)):
                c, flag = cost[m][k]
                if not math.isfinite(c) and float(sub.stopped.sel({"method": m})):
                    # tighter tolerances not run: dearer than the dearest run
                    c, flag = float(np.nanmax(sub.wall_time.sel({"method": m}).values)), ">"
                if not math.isfinite(c):
                    row += " not reached | - |"
                    continue
                sp = c / best[k][0] if math.isfinite(best[k][0]) else math.nan
                row += f" {flag}{1e6 * c:.3g} | {sp:.3g} |"
            lines.append(row)
        lines.append("\nbest gearsweep method per target: " + ", ".join(
            f"{t:.0e}: {b[1]}" for t, b in zip(TARGETS, best, strict=True)))
        for am in ds.advised_method.values:
            spp = sub.advised_steps.sel(advised_method=am).values
            if not np.isfinite(spp).any():
                continue
            lines.append(f"advisor, {am}: " + "; ".join(
                f"{t:.0e}: {int(n)} steps/period -> traj err {te:.1e}, amp err {ae:.1e}, "
                f"{1e6 * c:.3g} us/case" for t, n, te, ae, c in zip(
                    TARGETS, spp, sub.advised_trajectory_error.sel(advised_method=am).values,
                    sub.advised_amplitude_error.sel(advised_method=am).values,
                    sub.advised_wall_time.sel(advised_method=am).values, strict=True)))
        lines.append("compile / first call [s]: " + ", ".join(
            f"{m} {c:.1f}" for m, c in zip(ds.method.values, sub.compile_time.values, strict=True)
            if np.isfinite(c)))
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--cases", type=int, default=1000)
    ap.add_argument("--error-cases", type=int, default=24)
    ap.add_argument("--serial-cases", type=int, default=6)
    ap.add_argument("--repeat", type=int, default=3, help="median of this many batch runs")
    ap.add_argument("--processes", type=int, default=os.cpu_count() or 1,
                    help="processes for the reference solutions")
    ap.add_argument("--scenes", nargs="+", default=list(P.BATCHES))
    ap.add_argument("--families", nargs="+", default=sorted(set(FAMILY.values())),
                    help="packages to run (gearsweep always runs); e.g. diffrax alone on a GPU")
    ap.add_argument("--results", type=Path, default=ROOT / "results")
    ap.add_argument("--copy-to", type=Path, default=None, help="also copy the .nc into this folder")
    args = ap.parse_args()
    command = "scripts/bench_peers.py " + " ".join(
        f"--{k.replace('_', '-')} {v}" for k, v in vars(args).items()
        if k not in ("results", "copy_to", "scenes", "families")) + " --scenes " + " ".join(
        args.scenes) + " --families " + " ".join(args.families)
    t_start = time.perf_counter()

    def log(msg):
        print(f"{time.perf_counter() - t_start:7.1f} s  {msg}", flush=True)

    missing = [d for d in ("numbalsoda", "diffrax", "jax", "scikit-sundae") if not _installed(d)]
    if missing:
        log(f"not installed, skipped: {', '.join(missing)}")
    # the references first, in forked processes, before JAX starts its threads
    refs = {}
    for s in args.scenes:
        batch = P.BATCHES[s](args.cases, n_error=args.error_cases)
        t0 = time.perf_counter()
        refs[s] = (batch, P.references(batch, processes=args.processes))
        log(f"[{s}] {batch.n} cases {batch.rpm_min:.0f}-{batch.rpm_max:.0f} rpm, references of "
            f"{len(batch.error_cases)} error cases in {time.perf_counter() - t0:.1f} s")
    res = {s: run_scene(*refs[s], args, log) for s in args.scenes}
    ds = dataset(res, args, command)
    args.results.mkdir(parents=True, exist_ok=True)
    path = args.results / "work_precision_peers.nc"
    write_netcdf(ds, path)  # atomic, CF: no _FillValue on coordinates
    if args.copy_to:
        args.copy_to.mkdir(parents=True, exist_ok=True)
        shutil.copy(path, args.copy_to / path.name)
    print(f"\ncommand: {command}\nthreads: {cores_used()}, written {path}")
    print("\n## equal amplitude error" + tables(ds, "amplitude_error"))
    print("\n## equal trajectory error" + tables(ds, "trajectory_error"))
    log("done")


if __name__ == "__main__":
    main()

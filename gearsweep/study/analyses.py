"""Analysis studies computed into Datasets (``type: analysis``; options in ``analysis_specs``).

Each function takes the validated options and returns a Dataset built by ``dataset.build_dataset``
(units, long names, the study text, provenance), so the figure that draws it only reads a file.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import time
from pathlib import Path

import numba
import numpy as np
import xarray as xr

from gearsweep.analysis import hb
from gearsweep.analysis import precision as pr
from gearsweep.analysis import rattle as rfit
from gearsweep.analysis import stability as st
from gearsweep.errors import ResultError, StudyError, stops_held
from gearsweep.model import PAPER_RIG, RPM, MeshModel, model_from_record
from gearsweep.study.analysis_specs import (
    AnalysisStudy,
    ArtifactMap,
    JumpMap,
    MethodStability,
    RattleBalance,
    RattleBudget,
    WorkPrecision,
)
from gearsweep.study.dataset import build_dataset
from gearsweep.study.jumps import JUMP_VARIABLES, UNSUPPORTED_WHY, jump_summary
from gearsweep.units import KINDS, from_display, si_values

DRIVEN_TEETH = 32
"""Teeth of Table 1's driven pinion (the rig's shaft the paper's rpm axes may refer to)."""

WHINE_DESCRIPTION = "time-varying stiffness + STE, no backlash"
RATTLE_DESCRIPTION = "constant stiffness, backlash 4 µm, contact loss"


def _polynomials(methods) -> tuple[np.ndarray, np.ndarray]:
    """Stability polynomial coefficients per method (ascending powers, zero-padded)."""
    polys = [[float(c) for c in st.stability_polynomial(m)] for m in methods]
    n = max(len(p) for p in polys)
    return np.arange(n), np.array([p + [0.0] * (n - len(p)) for p in polys])


POLY_ATTRS = {"units": "1", "long_name": "coefficient of z^power in the stability function R(z)"
              " of the method (z = h lambda)"}


def method_stability(o: MethodStability, inputs: dict | None = None
                     ) -> tuple[dict, dict, dict, dict]:
    """Polynomial and measured stability limits (h omega_n) per method and damping ratio."""
    zc = np.linspace(0.0, o.zeta_max, o.curve_points)
    zm = np.asarray(o.zeta, float)
    poly = np.array([st.step_limit_hw(m, zc) for m in o.methods])
    meas = np.array([st.measured_step_limit(m, zm, n_steps=o.steps) for m in o.methods])
    power, coef = _polynomials(o.methods)
    data = {
        "polynomial_limit": (("method", "zeta_curve"), poly),
        "measured_limit": (("method", "zeta"), meas),
        "stability_polynomial": (("method", "power"), coef),
    }
    coords = {"method": (("method",), np.array(o.methods)), "zeta_curve": (("zeta_curve",), zc),
              "zeta": (("zeta",), zm), "power": (("power",), power)}
    attrs = {
        "polynomial_limit": {"units": "1", "long_name": "largest stable h omega_n from the "
                             "stability polynomial, |R(h lambda)| = 1"},
        "measured_limit": {"units": "1", "long_name": "largest h omega_n at which the batch "
                           f"kernel's integration of the free oscillator over {o.steps} steps "
                           "does not blow up (bisection)"},
        "stability_polynomial": POLY_ATTRS,
        "zeta_curve": {"units": "1", "long_name": "damping ratio c / (2 m omega_n)"},
        "zeta": {"units": "1", "long_name": "damping ratio c / (2 m omega_n)"},
        "power": {"units": "1", "long_name": "power of z"},
        "method": {"long_name": "fixed-step method"},
    }
    rig = PAPER_RIG  # where the paper's rig sits on the zeta axis (figures mark it)
    rig_zeta = rig.damping / (2.0 * math.sqrt(rig.stiffness * rig.mass))
    return data, coords, attrs, {"steps": o.steps, "paper_rig_zeta": round(rig_zeta, 6)}


def _input_model(ds: xr.Dataset, name: str, field: str, kind: str) -> MeshModel:
    """The gear scene's model the input ``name`` carries; else ``StudyError`` at ``field`` (the
    study file's line of the input, reported by the caller), saying why: a mesh or analysis
    result has none, a Mathieu scene's is no gear pair's (``_model``'s words)."""
    try:
        return _model(ds, name)
    except ResultError as exc:
        why = str(exc).removeprefix(f"{name}: ")
        raise StudyError("<study>", field, name, f"{kind} needs a gear scene's dynamic result;"
                         f" {why}") from None


ARTIFACT_RIG = ("artifact_map needs a rig: a gear scene's result with a stiffness harmonic k1"
                " that sweeps speed and damping (e.g. studies/stability_rig.yaml)")


def _artifact_map_input(o: ArtifactMap, ds: xr.Dataset, _name: str = "") -> None:
    """``StudyError`` (field ``analysis.rig``) unless ``ds`` is a rig ``artifact_map`` can read:
    a gear scene's result with a stiffness harmonic, swept over speed and damping. ``validate``
    said ok of any other result and run refused it in a line of no file, line or field (an
    outside tester's finding)."""
    model = _input_model(ds, o.rig, "analysis.rig", "artifact_map")
    lacks = [what for what, missing in (
        ("a stiffness harmonic", not model.stiffness_harmonics),
        ("a speed sweep", "speed" not in ds.dims), ("a damping sweep", "damping" not in ds.dims))
        if missing]
    if lacks:
        raise StudyError("<study>", "analysis.rig", o.rig, f"{ARTIFACT_RIG}; this one has no"
                         f" {' and no '.join(w.removeprefix('a ') for w in lacks)}")


def artifact_map(o: ArtifactMap, inputs: dict) -> tuple[dict, dict, dict, dict]:
    """The paper's criterion per tableau and step over the rig result's speed x damping grid."""
    rig = inputs[o.rig]
    _artifact_map_input(o, rig)
    model = _model(rig, o.rig)
    speed = rig["speed"].values
    damping = from_display(rig["damping"].values, "damping")  # the file: display unit; here SI
    am = st.artifact_map(speed, damping, k0=model.stiffness,
                         k1=model.stiffness_harmonics[0].amplitude, mass=model.mass,
                         teeth=model.teeth, methods=o.methods, steps_per_period=o.steps_per_period)
    power, coef = _polynomials(o.methods)
    four = ("method", "steps_per_period", "damping", "speed")
    data = {
        "flag": (four, am["flag"]),
        "discrete_multiplier": (four, am["discrete_multiplier"]),
        "edge_speed": (four[:3], am["edge_speed"]),
        "reproduces_paper": (four[:2], st.reproduces_paper(am["edge_speed"], damping)),
        # The paper's rpm axes do not say which shaft: "200 rpm" of the driven 32-tooth pinion
        # (Table 1) is 200 x 32 / 48 rpm of the driving gear, the study's speed.
        "reproduces_paper_driven": (four[:2], st.reproduces_paper(
            am["edge_speed"], damping, target_rpm=200.0 * DRIVEN_TEETH / model.teeth)),
        "real_interval": (("method",), am["real_interval"]),
        "imaginary_interval": (("method",), am["imaginary_interval"]),
        "step_limit_hw": (("method", "damping"), am["step_limit_hw"]),
        "zeta": (("damping",), am["zeta"]),
        "stability_polynomial": (("method", "power"), coef),
    }
    coords = {"method": (("method",), np.array(o.methods)),
              "steps_per_period": (("steps_per_period",), np.asarray(o.steps_per_period)),
              "damping": (("damping",), rig["damping"].values), "speed": (("speed",), speed),
              "power": (("power",), power)}
    attrs = {
        "flag": {"units": "1", "long_name": "the paper's criterion reports instability (growth"
                 " 1e3-fold within 100 mesh periods from p = p' = 1e-6)"},
        "discrete_multiplier": {"units": "1", "long_name": "largest |mu| of the fixed-step map"
                                " over one mesh period"},
        "edge_speed": {"units": "rpm", "long_name": "highest speed the criterion flags"},
        "reproduces_paper": {"units": "1", "long_name": "the map has the paper's Fig. 7.2 shape"
                             " (unstable at low speed, edge near 200 rpm at 5.5 N s/mm)"},
        "reproduces_paper_driven": {"units": "1", "long_name": "the map has the paper's Fig. 7.2"
                                    " shape with its 200 rpm read as the driven pinion's speed"},
        "real_interval": {"units": "1", "long_name": "stability interval on the negative real"
                          " axis, |h lambda|"},
        "imaginary_interval": {"units": "1", "long_name": "stability interval on the imaginary"
                               " axis, |h lambda|"},
        "step_limit_hw": {"units": "1", "long_name": "largest stable h omega_n at the damping"},
        "zeta": {"units": "1", "long_name": "damping ratio at k0"},
        "stability_polynomial": POLY_ATTRS,
        "method": {"long_name": "Runge-Kutta tableau (gearsweep.kernels.tableaux)"},
        "steps_per_period": {"units": "1", "long_name": "fixed steps per mesh period"},
        "damping": dict(rig["damping"].attrs),
        "speed": dict(rig["speed"].attrs),
        "power": {"units": "1", "long_name": "power of z"},
    }
    return data, coords, attrs, {"rig_result": o.rig}


def work_precision(o: WorkPrecision, inputs: dict | None = None) -> tuple[dict, dict, dict, dict]:
    """Errors and costs of every fixed-step method and scipy peer on each scene."""
    window = pr.Window(o.transient_periods, o.record_periods)
    make = {"whine": pr.whine_scene, "rattle": pr.rattle_scene}
    speed = {"whine": o.whine_speed, "rattle": o.rattle_speed}
    ns, nm, nk, npe, nr = len(o.scenes), len(o.methods), len(o.steps_per_period), len(o.peers), \
        len(o.rtol)
    fixed = {k: np.full((ns, nm, nk), np.nan) for k in ("te", "ae", "sec", "rhs")}
    peer = {k: np.full((ns, npe, nr), np.nan) for k in ("te", "ae", "sec", "rhs")}
    hw = np.full((ns, nk), np.nan)
    order = np.full((ns, nm), np.nan)
    notes = {}
    for i, name in enumerate(o.scenes):
        scene = make[name](speed[name])
        # only the reference's samples are kept: its dense output (a DOP853 step's interpolant
        # per ~0.2 radian, analysis_cost.DENSE_STEP_BYTES each) is let go before the next one
        p_ref = pr.reference(scene, window)(pr.sample_times(scene, window))[0]
        if not scene.k_harmonics:  # cross-check the two references on a constant-k scene
            alt = pr.reference(scene, window, exact=False)(pr.sample_times(scene, window))[0]
            d = np.max(np.abs(alt - p_ref))
            notes[name] = f"exact piecewise solution; DOP853-with-events differs by {d:.1e} m"
        else:
            notes[name] = "DOP853, rtol 1e-12, crossings as events"
        hw[i] = scene.period / np.asarray(o.steps_per_period) * scene.omega_n
        for j, m in enumerate(o.methods):
            for k, spp in enumerate(o.steps_per_period):
                r = pr.run_fixed(scene, m.split("-")[0], spp, window, p_ref,
                                 kink_aware=m.endswith("-kink"), copies=o.copies, repeat=o.repeat)
                fixed["te"][i, j, k], fixed["ae"][i, j, k] = r.trajectory_error, r.amplitude_error
                fixed["sec"][i, j, k], fixed["rhs"][i, j, k] = r.seconds, r.rhs_evaluations
            order[i, j] = pr.fit_order(o.steps_per_period, fixed["te"][i, j])
        for j, m in enumerate(o.peers):
            for k, tol in enumerate(o.rtol):
                r = pr.run_scipy(scene, m, tol, window, p_ref)
                peer["te"][i, j, k], peer["ae"][i, j, k] = r.trajectory_error, r.amplitude_error
                peer["sec"][i, j, k], peer["rhs"][i, j, k] = r.seconds, r.rhs_evaluations
    f_dims, p_dims = ("scene", "method", "steps_per_period"), ("scene", "peer", "rtol")
    data = {
        "trajectory_error": (f_dims, fixed["te"]), "amplitude_error": (f_dims, fixed["ae"]),
        "wall_time": (f_dims, fixed["sec"]), "rhs_evaluations": (f_dims, fixed["rhs"]),
        "order": (("scene", "method"), order), "h_omega_n": (("scene", "steps_per_period"), hw),
        "peer_trajectory_error": (p_dims, peer["te"]), "peer_amplitude_error": (p_dims, peer["ae"]),
        "peer_wall_time": (p_dims, peer["sec"]), "peer_rhs_evaluations": (p_dims, peer["rhs"]),
    }
    coords = {
        "scene": (("scene",), np.array(o.scenes)), "method": (("method",), np.array(o.methods)),
        "steps_per_period": (("steps_per_period",), np.asarray(o.steps_per_period)),
        "peer": (("peer",), np.array(o.peers)), "rtol": (("rtol",), np.asarray(o.rtol)),
        "speed": (("scene",), np.array([speed[s] for s in o.scenes])),
        "scene_description": (("scene",), np.array(
            [WHINE_DESCRIPTION if s == "whine" else RATTLE_DESCRIPTION for s in o.scenes])),
    }
    traj = "max |p - p_ref| over the window / reference amplitude"
    amp = "|A - A_ref| / A_ref, A = half peak-to-peak of p"
    attrs = {
        "trajectory_error": {"units": "1", "long_name": traj},
        "amplitude_error": {"units": "1", "long_name": amp},
        "wall_time": {"units": "s", "long_name": f"wall time per case (best of {o.repeat} calls"
                      f" of a batch of {o.copies})"},
        "rhs_evaluations": {"units": "1", "long_name": "right-hand-side evaluations per case"},
        "order": {"units": "1", "long_name": "fitted order: minus the slope of log trajectory "
                  "error against log steps per period over 1e-10 < error < 1e-2"},
        "h_omega_n": {"units": "1", "long_name": "step times natural frequency at the largest "
                      "stiffness"},
        "peer_trajectory_error": {"units": "1", "long_name": f"scipy solve_ivp: {traj}"},
        "peer_amplitude_error": {"units": "1", "long_name": f"scipy solve_ivp: {amp}"},
        "peer_wall_time": {"units": "s", "long_name": "scipy solve_ivp: wall time per case"},
        "peer_rhs_evaluations": {"units": "1", "long_name": "scipy solve_ivp: right-hand-side "
                                 "evaluations per case"},
        "scene": {"long_name": "scene"}, "method": {"long_name": "fixed-step method"},
        "steps_per_period": {"units": "1", "long_name": "steps per mesh period"},
        "peer": {"long_name": "scipy solve_ivp method"},
        "rtol": {"units": "1", "long_name": "relative tolerance"},
        "speed": {"units": "rpm", "long_name": "shaft speed of the driving gear (48 teeth)"},
        "scene_description": {"long_name": "what the scene switches on"},
    }
    settings = {"window": f"{window.transient_periods} transient + {window.record_periods} "
                f"recorded mesh periods from p = p' = 0, {pr.SAMPLES_PER_PERIOD} samples per "
                "period", "threads": numba.get_num_threads(),
                **{f"reference_{k}": v for k, v in notes.items()}}
    return data, coords, attrs, settings


def _si(da: xr.DataArray) -> xr.DataArray:
    """A result variable in SI (results store display units: p in um, ...)."""
    return da.copy(data=si_values(da))


def _settled(da: xr.DataArray, ds: xr.Dataset) -> xr.DataArray:
    """``da`` where the case settled (status 0), NaN elsewhere."""
    return da.where((ds["status"] == 0).broadcast_like(da))


def _model(ds: xr.Dataset, name: str) -> MeshModel:
    if "model" not in ds.attrs:
        raise ResultError(f"{name}: the result carries no resolved model (not a dynamic study)")
    try:
        model = model_from_record(json.loads(ds.attrs["model"]))
    except (ValueError, KeyError, TypeError, AttributeError):  # (a file not written here)
        raise ResultError(f"{name}: its model attribute is not a gearsweep model record") from None
    if not isinstance(model, MeshModel):  # (a Mathieu scene's: an AttributeError traceback)
        raise ResultError(f"{name}: the result is of a {type(model).__name__}, not of a gear"
                          " pair's scene")
    return model


def _stat(f, values) -> float:
    """``f`` of the finite values (NaN, without a warning, when there are none)."""
    a = np.asarray(values, float)
    a = a[np.isfinite(a)]
    return float(f(a)) if a.size else math.nan


def _both_ways(ds) -> bool:
    """Is ``ds`` a sweep continued up and down over speed (what a jump needs)?"""
    return "direction" in ds.dims and {"up", "down"} <= {str(d) for d in ds["direction"].values}


EQ15_SPEEDS = 100_000
"""The most speeds of the Eq. (15) points (the point counts of the analyses take as many)."""


def _rattle_balance_input(o: RattleBalance, ds: xr.Dataset, _name: str = "") -> None:
    """``StudyError`` (field ``analysis.n_time``) below ``hb.AFT_SAMPLES_PER_HARMONIC`` samples
    per harmonic, and (field ``analysis.eq15_step``) when the step gives more than
    ``EQ15_SPEEDS`` speeds over the result's: 1e-300 rpm ended in numpy's 'Maximum allowed size
    exceeded', 1e-6 rpm in tens of GiB."""
    k = hb.AFT_SAMPLES_PER_HARMONIC  # (AFTBalance's ValueError was a traceback after validate)
    if o.n_time < k * o.harmonics:
        raise StudyError("<study>", "analysis.n_time", o.n_time, (
            f"at least {k} samples per harmonic: {k * o.harmonics} for the {o.harmonics}"
            f" harmonics (or at most {o.n_time // k} harmonics)"))
    # What the result must be (validate said ok, run refused it in a line of no file or field)
    model = _input_model(ds, o.result, "analysis.result", "rattle_balance")
    if len(model.force_harmonics) != 1 or model.backlash is None or model.stiffness_harmonics:
        raise StudyError("<study>", "analysis.result", o.result, "rattle_balance needs a"
                         " constant-stiffness scene with backlash and one force harmonic")
    if (not _both_ways(ds) or ds.sizes.get("speed", 0) < 2 or "p_pp" not in ds
            or ds["p_pp"].ndim != 2):
        raise StudyError("<study>", "analysis.result", o.result, "rattle_balance needs one case"
                         " continued up and down over speed (continuation: [up, down])")
    speed = ds["speed"].values if "speed" in ds.coords else np.zeros(0)
    if speed.size < 2:
        return  # (the analysis says what it needs of the result)
    if not (speed[-1] + 1.0 - speed[0]) / o.eq15_step <= EQ15_SPEEDS:
        least = (speed[-1] + 1.0 - speed[0]) / EQ15_SPEEDS
        raise StudyError("<study>", "analysis.eq15_step", f"{o.eq15_step:g} rpm", (
            f"at least {least:.3g} rpm: at most {EQ15_SPEEDS:,} speeds of Eq. (15) over the"
            f" result's {speed[0]:g}-{speed[-1]:g} rpm"))


def rattle_balance(o: RattleBalance, inputs: dict) -> tuple[dict, dict, dict, dict]:
    """Describing function, AFT branch, turning points and Eq. (15) of a rattle result's scene,
    beside the result's own integration (see ``RattleBalance``)."""
    ds = inputs[o.result]
    _rattle_balance_input(o, ds)
    model = _model(ds, o.result)
    b = model.backlash / 2
    (fh,) = model.force_harmonics
    f0, m, k, c, fm = fh.amplitude, model.mass, model.stiffness, model.damping, model.mean_force
    w_per_rpm = model.teeth * RPM * fh.order
    speed = ds["speed"].values
    amp = _settled(0.5 * _si(ds["p_pp"]), ds).transpose("direction", "speed")
    grid = np.unique(np.r_[np.linspace(0.005 * b, 0.9999 * b, 400),
                           b * (1 + np.geomspace(1e-8, o.curve_top - 1, 4000))])
    common = dict(mass=m, stiffness=k, damping=c, half_gap=b, force_amp=f0)
    df = hb.df_curve(grid, force_mean=fm, **common)
    df0 = hb.df_curve(grid, force_mean=0.0, **common)
    system = hb.MeshSystem(mass=m, stiffness=k, damping=c, half_gap=b, force_mean=fm,
                           force_harmonics=(f0,))
    t0 = time.perf_counter()
    aft_note = ""
    try:
        aft = hb.aft_continuation(system, speed[0] * w_per_rpm, speed[-1] * w_per_rpm,
                                  harmonics=o.harmonics, n_time=o.n_time)
    except RuntimeError:  # Newton found no solution at the first speed (a traceback, exit 1)
        nan = np.full(1, np.nan)
        aft = hb.HBBranch(omega=nan, coefficients=np.full((1, 2 * o.harmonics + 1), np.nan),
                          p_max=nan, p_min=nan, multiplier=nan, stable=np.zeros(1, bool),
                          ended="no_start")
        aft_note = (f"harmonic balance ({o.harmonics} harmonics, n_time {o.n_time}) did not"
                    f" converge at the lowest speed, {speed[0]:g} rpm: the AFT branch, its"
                    " turning points and the flip speed are NaN; the integration, the describing"
                    " function and Eq. (15) are kept; try other harmonics or n_time")
    t_aft = time.perf_counter() - t0
    if not aft.complete and not aft_note:  # its flip and turning points would be those of part
        why = ("after its most points" if aft.ended == "max_points"  # of the branch: NaN
               else "its corrector failed at the smallest step")
        aft_note = (f"the harmonic-balance branch stopped at {aft.omega[-1] / w_per_rpm:.0f} rpm"
                    f" of {speed[0]:.0f}-{speed[-1]:.0f} rpm ({why}): its points are kept, its"
                    " turning points and the flip speed are NaN; try other harmonics or n_time")
    js = jump_summary(ds)
    up_jump, down_jump = float(js.jump_up_speed), float(js.jump_down_speed)
    # the paper's (o): Eq. (15), undamped, no mean force, every root, on a grid of speeds
    sp15 = np.arange(speed[0], speed[-1] + 1.0, o.eq15_step)
    r15 = np.abs(hb.eq15_roots(sp15 * w_per_rpm, f0, k, m, b))
    dist = {d: rfit.eq15_distance(speed, amp.sel(direction=d).values, omega_per_rpm=w_per_rpm,
                                  force_amp=f0, stiffness=k, mass=m, half_gap=b)
            for d in ("up", "down")}
    upper = dist["up"].relative[speed < down_jump]
    lower = dist["down"].relative[speed > dist["down"].rise_eq15]
    # where the lower branch loses period-1 stability (a multiplier through -1)
    turns = np.nonzero(np.diff(np.sign(np.diff(aft.omega))))[0] + 1
    flip = np.nan
    if turns.size == 2 and aft.complete:
        after = np.nonzero(~aft.stable[turns[1] + 2:])[0]
        if after.size:
            flip = aft.omega[turns[1] + 2 + after[0]] / w_per_rpm
    curves = {"df": df, "df0": df0, "aft": aft}
    tps = {n: np.sort(hb.turning_points(cv.omega, cv.amplitude)) / w_per_rpm
           if n != "aft" or aft.complete else np.zeros(0) for n, cv in curves.items()}
    width = max(1, max(t.size for t in tps.values()))
    tp = np.array([np.r_[t, np.full(width - t.size, np.nan)] for t in tps.values()])
    loss = _settled(ds["contact_loss_fraction"], ds).transpose("direction", "speed")
    back = _settled(ds["backside_contact_fraction"], ds).transpose("direction", "speed")
    above = loss.sel(direction="up").where(ds["speed"] > up_jump)
    # Fig. 9: three lines of Eq. (15), around where its gap root appears and its resonance
    w_t, w_n = math.sqrt(f0 / (m * b)), math.sqrt(k / m)
    ga, gb, gc = o.graphical
    g_speed = np.array([ga * w_t, gb * (w_t + w_n), gc * w_n]) / w_per_rpm
    g_roots = hb.eq15_roots(g_speed * w_per_rpm, f0, k, m, b)
    n_bad = int((ds["status"] != 0).sum())
    sp, dr = ("speed",), ("direction", "speed")
    data = {
        "amplitude": (dr, amp.values), "contact_loss_fraction": (dr, loss.values),
        "backside_contact_fraction": (dr, back.values),
        "eq15_nearest": (dr, np.array([dist[d].eq15 for d in ("up", "down")])),
        "eq15_distance": (dr, np.array([dist[d].relative for d in ("up", "down")])),
        "df_speed": (("df_point",), df.omega / w_per_rpm), "df_amplitude": (("df_point",),
                                                                            df.amplitude),
        "df_stable": (("df_point",), df.stable),
        "df0_speed": (("df0_point",), df0.omega / w_per_rpm),
        "df0_amplitude": (("df0_point",), df0.amplitude), "df0_stable": (("df0_point",),
                                                                         df0.stable),
        "aft_speed": (("aft_point",), aft.omega / w_per_rpm),
        "aft_amplitude": (("aft_point",), aft.amplitude), "aft_stable": (("aft_point",),
                                                                         aft.stable),
        "turning_point": (("curve", "turn"), tp),
        "eq15_root": (("eq15_speed", "root"), r15),
        "graphical_root": (("line", "root"), g_roots),
        "flip_speed": ((), flip),
        "flip_amplitude": ((), float(np.interp(flip, speed, 0.5 * _si(ds["p_pp"]).sel(
            direction="down").values)) if np.isfinite(flip) else np.nan),
        "jump_up_speed": ((), up_jump), "jump_down_speed": ((), down_jump),
        "jump_up_size": ((), float(js.jump_up_size)),
        "jump_down_size": ((), float(js.jump_down_size)),
        "jump_unsupported": ((), int(js.jump_unsupported)),
        # Eq. (15) has three roots between w_t and w_n only where F0 < k b (the paper's order);
        # otherwise one root at every speed: no rise or drop of its to compare
        "eq15_rise_speed": ((), dist["up"].rise_eq15 if f0 < k * b else np.nan),
        "eq15_drop_speed": ((), dist["up"].drop_eq15 if f0 < k * b else np.nan),
        "eq15_distance_rattling_median": ((), _stat(np.median, upper)),
        "eq15_distance_rattling_max": ((), _stat(np.max, upper)),
        "eq15_distance_free_flight_median": ((), _stat(np.median, lower)),
        "contact_loss_above_drop_min": ((), _stat(np.min, above)),
        "contact_loss_above_drop_max": ((), _stat(np.max, above)),
        "contact_loss_above_drop_mean": ((), _stat(np.mean, above)),
        "settle_error_max": ((), float(ds["settle_error"].max())),
        "not_settled": ((), n_bad), "cases": ((), int(ds["status"].size)),
        # settled is not periodic: where the result has the period output, how many case-speeds
        # repeat within no half record (irregular or longer), and how many of those are status 0
        "no_period": ((), int(ds["motion_period"].isnull().sum()) if "motion_period" in ds
                      else -1),
        "no_period_settled": ((), int((ds["motion_period"].isnull() & (ds["status"] == 0)).sum())
                              if "motion_period" in ds else -1),
        "longest_period": ((), int(ds["motion_period"].attrs.get("longest", -1))
                           if "motion_period" in ds else -1),
        "mass": ((), m), "stiffness": ((), k), "damping": ((), c), "half_gap": ((), b),
        "backlash": ((), model.backlash), "force_amplitude": ((), f0),
        "force_order": ((), fh.order), "mean_force": ((), fm),
        "zeta": ((), c / (2.0 * math.sqrt(k * m))),
        "omega_per_rpm": ((), w_per_rpm),
    }
    coords = {"speed": (sp, speed),
              "direction": (("direction",), np.array(["up", "down"])),
              "curve": (("curve",), np.array(["describing_function",
                                              "describing_function_no_mean_force", "aft"])),
              "eq15_speed": (("eq15_speed",), sp15), "line": (("line",), np.array(list("ABC"))),
              "line_speed": (("line",), g_speed)}
    rpm, amp_m = {"units": "rpm"}, {"kind": "displacement"}  # kinds: given in SI, stored in
    # their display units (gearsweep.units)
    attrs = {
        "amplitude": {**amp_m, "long_name": "integration: half peak-to-peak of p (settled cases;"
                      " NaN elsewhere)"},
        "contact_loss_fraction": {"units": "1", "long_name": "integration: fraction of time with"
                                  " the teeth apart (settled cases)"},
        "backside_contact_fraction": {"units": "1", "long_name": "integration: fraction of time"
                                      " on the back flank (settled cases)"},
        "eq15_nearest": {**amp_m, "long_name": "|p0| of the Eq. (15) root nearest the integration"
                         " (NaN: none)"},
        "eq15_distance": {"units": "1", "long_name": "|Eq. (15) - integration| / integration"},
        "df_speed": {**rpm, "long_name": "describing-function curve (with the mean force)"},
        "df_amplitude": {**amp_m, "long_name": "describing function: first-harmonic amplitude A"},
        "df_stable": {"long_name": "describing function: stable (slow flow)"},
        "df0_speed": {**rpm, "long_name": "describing-function curve, F_m = 0"},
        "df0_amplitude": {**amp_m, "long_name": "describing function, F_m = 0: amplitude A"},
        "df0_stable": {"long_name": "describing function, F_m = 0: stable (slow flow)"},
        "aft_speed": {**rpm, "long_name": f"AFT harmonic-balance branch ({o.harmonics} harmonics"
                      f", {o.n_time} time samples)"},
        "aft_amplitude": {**amp_m, "long_name": "AFT branch: half peak-to-peak of p"},
        "aft_stable": {"long_name": "AFT branch: stable (Floquet)"},
        "turning_point": {**rpm, "long_name": "turning points (folds) of each curve, sorted (NaN:"
                          " fewer)"},
        "eq15_root": {**amp_m, "long_name": "Eq. (15), undamped, no mean force: |p0| of every"
                      " root (NaN: fewer roots)"},
        "graphical_root": {**amp_m, "long_name": "Eq. (15) roots p0 on the lines of Fig. 9"},
        "flip_speed": {**rpm, "long_name": "AFT lower branch: period-1 unstable (flip) above"
                       " (NaN: none)"},
        "flip_amplitude": {**amp_m, "long_name": "run-down integration's amplitude at the flip"
                           " speed (unmasked)"},
        "jump_up_speed": {**rpm, "long_name": "integration: run-up jump"},
        "jump_down_speed": {**rpm, "long_name": "integration: run-down jump"},
        "jump_up_size": {"units": "1", "long_name": "relative size of the run-up jump"},
        "jump_down_size": {"units": "1", "long_name": "relative size of the run-down jump"},
        "jump_unsupported": {"units": JUMP_VARIABLES["jump_unsupported"][0],
                             "long_name": JUMP_VARIABLES["jump_unsupported"][1]},
        "eq15_rise_speed": {**rpm, "long_name": "Eq. (15): its gap root appears (run-down rise;"
                            " NaN: F0 >= k b, one root at every speed)"},
        "eq15_drop_speed": {**rpm, "long_name": "Eq. (15): its in-phase root leaves to infinity"
                            " (linear resonance, run-up drop; NaN: F0 >= k b)"},
        "eq15_distance_rattling_median": {"units": "1", "long_name": "eq15_distance, run-up,"
                                          " below the run-down jump: median"},
        "eq15_distance_rattling_max": {"units": "1", "long_name": "eq15_distance, run-up, below"
                                       " the run-down jump: max"},
        "eq15_distance_free_flight_median": {"units": "1", "long_name": "eq15_distance,"
                                             " run-down, above Eq. (15)'s rise: median"},
        "contact_loss_above_drop_min": {"units": "1", "long_name": "run-up contact loss above"
                                        " the run-up drop: min"},
        "contact_loss_above_drop_max": {"units": "1", "long_name": "run-up contact loss above"
                                        " the run-up drop: max"},
        "contact_loss_above_drop_mean": {"units": "1", "long_name": "run-up contact loss above"
                                         " the run-up drop: mean"},
        "settle_error_max": {"units": "1", "long_name": "largest settle_error of the integration"},
        "not_settled": {"units": "1", "long_name": "case-speeds with status != 0"},
        "cases": {"units": "1", "long_name": "case-speeds of the integration"},
        "no_period": {"units": "1", "long_name": "case-speeds whose motion repeats within no"
                      " half record (motion_period NaN; -1: the result has no period output)"},
        "no_period_settled": {"units": "1", "long_name": "of those, case-speeds with status 0"},
        "longest_period": {"units": "1", "long_name": "the longest period the period output"
                           " tried [mesh periods]"},
        "mass": {"units": "kg", "long_name": "m_eq"},
        "stiffness": {"kind": "stiffness", "long_name": "mesh stiffness k"},
        "damping": {"kind": "damping", "long_name": "mesh damping c"},
        "half_gap": {"kind": "length", "long_name": "b = backlash / 2"},
        "backlash": {"kind": "length", "long_name": "backlash along the line of action"},
        "force_amplitude": {"units": "N", "long_name": "F0"},
        "force_order": {"units": "1", "long_name": "mesh order of F0"},
        "mean_force": {"units": "N", "long_name": "F_m"},
        "zeta": {"units": "1", "long_name": "damping ratio c / (2 sqrt(k m))"},
        "omega_per_rpm": {"units": "rad/s/rpm", "long_name": "excitation frequency per rpm"},
        "eq15_speed": {**rpm, "long_name": "speeds of the Eq. (15) points"},
        "line_speed": {**rpm, "long_name": "speed of each line of Fig. 9"},
        "speed": dict(ds["speed"].attrs),
    }
    settings = {"balanced_title": ds.attrs.get("title", o.result), "aft_seconds": round(t_aft, 1),
                "aft_points": int(np.isfinite(aft.omega).sum()), "aft_harmonics": o.harmonics,
                "aft_ended": aft.ended, "force_fitted": int(o.fitted)}
    if aft_note:
        settings["aft_note"] = aft_note
    return data, coords, attrs, settings


def _rattle_budget_input(o: RattleBudget, ds: xr.Dataset, name: str) -> None:
    """``StudyError`` (the field of the role ``name`` plays) unless ``ds`` is what that role
    needs: a mesh result whose ``ste_harmonic`` has order 1 for ``mesh``, a dynamic result of
    one force harmonic for ``fitted``, a continued rattle sweep over speed and damping for each
    of ``scenes`` (each was a KeyError or ValueError traceback after validate said ok)."""
    def refuse(field: str, what: str) -> None:
        raise StudyError("<study>", field, name, f"rattle_budget's {field.split('.')[-1]} needs"
                         f" {what}; this result has none")

    if name == o.fitted:
        try:
            model = _model(ds, name)
        except ResultError:
            model = None
        if model is None or len(model.force_harmonics) != 1:
            refuse("analysis.fitted", "a gear scene's result with one force harmonic")
    for i, scene in enumerate(o.scenes):
        if scene == name and not ("contact_loss_fraction" in ds and "model" in ds.attrs
                                  and "damping" in ds.dims and "speed" in ds.dims
                                  and _both_ways(ds)):
            refuse(f"analysis.scenes[{i}]", "a rattle result (backlash) continued up and down"
                   " over speed, with a damping sweep")
    if name == o.mesh and ("ste_harmonic" not in ds or "harmonic" not in ds.coords
                           or 1 not in ds["harmonic"].values):
        refuse("analysis.mesh", "a mesh study's result (ste_harmonic of order 1)")


def rattle_budget(o: RattleBudget, inputs: dict) -> tuple[dict, dict, dict, dict]:
    """Force budget of a fitted rattle scene against scenes with the pair's own STE."""
    for name, ds in inputs.items():
        _rattle_budget_input(o, ds, name)
    fit = inputs[o.fitted]
    m8 = _model(fit, o.fitted)
    (fh,) = m8.force_harmonics
    w8 = m8.teeth * RPM
    e1 = float(_si(inputs[o.mesh]["ste_harmonic"]).sel(harmonic=1))
    first = inputs[o.scenes[0]]["speed"].values
    sp = np.linspace(float(first[0]), float(first[-1]), o.points)
    dampings = sorted({float(c) for n in o.scenes for c in inputs[n]["damping"].values},
                      reverse=True)
    ns, nc = len(o.scenes), len(dampings)
    per = {v: np.full((ns, nc), np.nan) for v in (
        "stiffness", "zeta", "threshold", "jump_up", "jump_down", "open_low", "open_high",
        "p_pp_max", "backside_max", "unsupported", "first_from", "first_to")}
    opening = np.full((ns, nc, sp.size), np.nan)
    per["not_settled"] = np.zeros(ns, int)
    for i, name in enumerate(o.scenes):
        ds = inputs[name]
        model = _model(ds, name)
        js = jump_summary(ds)
        loss = ds["contact_loss_fraction"].max("direction")
        per["not_settled"][i] = int((ds["status"] != 0).sum())
        for c in ds["damping"].values:
            j = dampings.index(float(c))
            per["stiffness"][i, j] = model.stiffness
            c_si = float(from_display(float(c), "damping"))  # the file: display unit
            per["zeta"][i, j] = c_si / (2.0 * math.sqrt(model.stiffness * model.mass))
            linear = {"mass": model.mass, "stiffness": model.stiffness, "damping": c_si,
                      "force_mean": model.mean_force}
            per["threshold"][i, j] = rfit.contact_loss_threshold(**linear)
            w_rpm = model.teeth * RPM  # mesh order 1 [rad/s per rpm]
            opening[i, j] = rfit.opening_force(sp * w_rpm, **linear)
            lo, hi = (x / w_rpm for x in rfit.first_harmonic_opening(**linear, ste_amplitude=e1))
            if lo <= sp[-1] and hi >= sp[0]:  # (NaN: never) the band within the speeds
                per["first_from"][i, j], per["first_to"][i, j] = max(lo, sp[0]), min(hi, sp[-1])
            per["jump_up"][i, j] = float(js.jump_up_speed.sel(damping=c))
            per["jump_down"][i, j] = float(js.jump_down_speed.sel(damping=c))
            per["unsupported"][i, j] = int(js.jump_unsupported.sel(damping=c))
            opened = ds["speed"].values[(loss.sel(damping=c) > 0).values]
            if opened.size:
                per["open_low"][i, j], per["open_high"][i, j] = opened.min(), opened.max()
            per["p_pp_max"][i, j] = float(_si(ds["p_pp"]).sel(damping=c).max())
            per["backside_max"][i, j] = float(ds["backside_contact_fraction"].sel(damping=c).max())
    at = np.asarray(o.at_speeds, float)
    sc = ("scene", "damping")
    data = {
        "fitted_force": ((), fh.amplitude), "fitted_order": ((), fh.order),
        "mean_force": ((), m8.mean_force), "ste_1": ((), e1),
        "half_gap": ((), m8.backlash / 2),
        "k_e1_fitted": ((), m8.stiffness * e1),
        "inertia_force": (("budget_speed",), m8.mass * (sp * w8) ** 2 * e1),
        "inertia_force_at": (("at_speed",), m8.mass * (at * w8) ** 2 * e1),
        "scene_stiffness": (sc, per["stiffness"]), "zeta": (sc, per["zeta"]),
        "k_e1": (sc, per["stiffness"] * e1),
        "threshold": (sc, per["threshold"]),
        "opening_force": (("scene", "damping", "budget_speed"), opening),
        "first_harmonic_opens_from": (sc, per["first_from"]),
        "first_harmonic_opens_to": (sc, per["first_to"]), "jump_up_speed": (sc, per["jump_up"]),
        "jump_down_speed": (sc, per["jump_down"]),
        "jump_unsupported": (sc, per["unsupported"]), "contact_loss_from": (sc, per["open_low"]),
        "contact_loss_to": (sc, per["open_high"]), "p_pp_max": (sc, per["p_pp_max"]),
        "backside_contact_max": (sc, per["backside_max"]),
        "not_settled": (("scene",), per["not_settled"]),
    }
    coords = {"scene": (("scene",), np.array(o.scenes)),
              "scene_name": (("scene",), np.array(o.names)),
              "scene_title": (("scene",), np.array([inputs[n].attrs.get("title", n)
                                                    for n in o.scenes])),
              "damping": (("damping",), np.array(dampings)),
              "budget_speed": (("budget_speed",), sp),
              "at_speed": (("at_speed",), at)}
    rpm = {"units": "rpm"}
    attrs = {
        "fitted_force": {"units": "N", "long_name": f"F0 fitted for {o.fitted}"},
        "fitted_order": {"units": "1", "long_name": "mesh order of the fitted force"},
        "mean_force": {"units": "N", "long_name": "mean mesh force F_m of the fitted scene"},
        "ste_1": {"kind": "displacement", "long_name": "e_1, the pair's first STE harmonic"},
        "half_gap": {"kind": "length", "long_name": "b = backlash / 2 of the fitted scene"},
        "k_e1_fitted": {"units": "N", "long_name": "k e_1 at the fitted scene's k"},
        "inertia_force": {"units": "N", "long_name": "m_eq w^2 e_1 (w: mesh order 1)"},
        "inertia_force_at": {"units": "N", "long_name": "m_eq w^2 e_1 at at_speed"},
        "scene_stiffness": {"kind": "stiffness", "long_name": "mean mesh stiffness k0 of the"
                            " scene"},
        "zeta": {"units": "1", "long_name": "damping ratio c / (2 sqrt(k m))"},
        "k_e1": {"units": "N", "long_name": "k e_1 at the scene's k"},
        "threshold": {"units": "N", "long_name": "least force amplitude that opens the mesh"
                      " at any speed (linear response): the least opening_force, at resonance"
                      " only"},
        "opening_force": {"units": "N", "long_name": "force amplitude at mesh order 1 that opens"
                          " the mesh at this speed (linear response reaches the static"
                          " deflection): F_m |k - m w^2 + i c w| / k"},
        "first_harmonic_opens_from": {**rpm, "long_name": "lowest speed where m_eq w^2 e_1"
                                      " alone reaches opening_force (linear response; NaN:"
                                      " at no budget speed)"},
        "first_harmonic_opens_to": {**rpm, "long_name": "highest speed where m_eq w^2 e_1"
                                    " alone reaches opening_force (the last budget speed where"
                                    " it stays open; NaN: at no budget speed)"},
        "jump_up_speed": {**rpm, "long_name": "run-up jump (NaN: none, or cannot be judged:"
                          " see jump_unsupported)"},
        "jump_down_speed": {**rpm, "long_name": "run-down jump (NaN: none, or cannot be"
                            " judged: see jump_unsupported)"},
        "jump_unsupported": {"units": JUMP_VARIABLES["jump_unsupported"][0], "long_name":
                             JUMP_VARIABLES["jump_unsupported"][1] + " (NaN: the scene has no"
                             " such damping)"},
        "contact_loss_from": {**rpm, "long_name": "lowest speed with contact loss (either"
                              " sweep; NaN: none)"},
        "contact_loss_to": {**rpm, "long_name": "highest speed with contact loss"},
        "p_pp_max": {"kind": "displacement", "long_name": "largest peak-to-peak p"},
        "backside_contact_max": {"units": "1", "long_name": "largest back-flank fraction"},
        "not_settled": {"units": "1", "long_name": "case-speeds with status != 0"},
        "damping": {"units": KINDS["damping"].cf, "long_name": "mesh damping c"},
        "at_speed": rpm,
        "budget_speed": dict(inputs[o.scenes[0]]["speed"].attrs),
    }
    unjudged = [f"{n} c = {c:g}" for n, row in zip(o.names, per["unsupported"], strict=True)
                for c, u in zip(dampings, row, strict=True) if u > 0]
    settings = {"jump_unsupported_cases": len(unjudged)}
    if unjudged:  # (their jump speeds are NaN as where there is no jump)
        settings["jump_note"] = (
            f"{len(unjudged)} of {int(np.isfinite(per['unsupported']).sum())} scene dampings"
            f" ({', '.join(unjudged)}): a sweep has {UNSUPPORTED_WHY} (jump speeds NaN,"
            " jump_unsupported > 0): whether they jump cannot be judged from these results")
    return data, coords, attrs, settings


def _jump_map_input(o: JumpMap, ds: xr.Dataset, _name: str = "") -> None:
    """``StudyError`` (its field ``analysis.result``, reported at the study file's line by the
    caller) unless ``ds`` is a result ``jump_map`` can read."""
    if "contact_loss_fraction" not in ds or "p_pp" not in ds:
        raise StudyError("<study>", "analysis.result", o.result, "jump_map needs a result with"
                         " backlash (contact_loss_fraction); this one has none")
    if not _both_ways(ds):
        raise StudyError("<study>", "analysis.result", o.result, "jump_map needs a result"
                         " continued up and down over speed (continuation: [up, down]): a jump is"
                         " where the two differ; this one has no up and down sweep")


def jump_map(o: JumpMap, inputs: dict) -> tuple[dict, dict, dict, dict]:
    """Share of speeds with contact loss and the jump summary of every case of a continued
    sweep (see ``JumpMap``)."""
    ds = inputs[o.result]
    _jump_map_input(o, ds)
    js = jump_summary(ds)
    dims = list(js["hysteresis_width"].dims)
    loss = ds["contact_loss_fraction"].max("direction")
    share = (loss > o.loss_threshold).mean("speed").transpose(*dims)
    data = {"rattle_share": (tuple(dims), share.values),
            **{n: (tuple(dims), js[n].transpose(*dims).values) for n in JUMP_VARIABLES},
            "not_settled_share": ((), float((ds["status"] == 2).mean()))}
    coords = {d: ((d,), ds[d].values) for d in dims}
    attrs = {"rattle_share": {"units": "1", "long_name": "share of speeds with contact loss above"
                              f" {o.loss_threshold:g} of the time (either sweep)"},
             **{n: {"units": u, "long_name": ln} for n, (u, ln) in JUMP_VARIABLES.items()},
             "not_settled_share": {"units": "1", "long_name": "share of the result's"
                                   " case-speeds with status 2 (not settled)"},
             **{d: dict(ds[d].attrs) for d in dims}}
    unsupported = int((js["jump_unsupported"] > 0).sum())
    settings = {"speed_from": float(ds["speed"].values[0]),
                "speed_to": float(ds["speed"].values[-1]),
                "input_cases": int(ds.attrs.get("cases", ds["status"].size)),
                "input_elapsed_seconds": ds.attrs.get("elapsed_seconds", "nan"),
                "jump_unsupported_cases": unsupported}
    if unsupported:  # (the result's sweeps scatter: a band there would be read off noise)
        settings["jump_note"] = (
            f"{unsupported} of {js['jump_unsupported'].size} cases: a sweep has"
            f" {UNSUPPORTED_WHY} (jump speeds and hysteresis band NaN, jump_unsupported > 0):"
            " whether they jump cannot be judged from this result"
            f" ({float((ds['status'] == 2).mean()):.0%} of its case-speeds did not settle)")
    return data, coords, attrs, settings


COMPUTE = {"method_stability": method_stability, "work_precision": work_precision,
           "artifact_map": artifact_map,
           "rattle_balance": rattle_balance, "rattle_budget": rattle_budget,
           "jump_map": jump_map}


def _open_inputs(study: AnalysisStudy, results: Path) -> tuple[dict, dict]:
    """The results an analysis reads, and their provenance (study sha256 per input)."""
    names = study.analysis.inputs() if hasattr(study.analysis, "inputs") else []
    missing = missing_inputs(study, results)
    if missing:  # each at its field, with the path looked for (it said '.: no NAME.nc')
        raise missing
    inputs, prov = {}, {}
    for name in names:
        path = Path(results) / f"{name}.nc"
        try:
            with stops_held():  # (a Ctrl-C inside xarray's HDF5 lock hung the run)
                ds = xr.load_dataset(path)
        except (OSError, ValueError) as exc:  # (a file that is no netCDF: xarray's traceback)
            raise _unreadable(study, path, name, exc) from None
        inputs[name] = ds
        prov[f"input_{name}"] = ds.attrs.get("study_sha256") or hashlib.sha256(
            ds.attrs.get("study", "").encode()).hexdigest()
    return inputs, prov


def missing_inputs(study: AnalysisStudy, results: str | Path) -> StudyError | None:
    """The inputs of the analysis not in the folder ``results`` (its output's), each at the
    field that names it with the path looked for, as one ``StudyError`` (``None``: none)."""
    fields = study.analysis.input_fields() if hasattr(study.analysis, "input_fields") else []
    problems = []
    for field, name in fields:
        path = os.path.join(str(results), f"{name}.nc")
        if not os.path.exists(path):
            problems.append((None, field, name, (
                f"no {path}: an analysis reads its inputs from its output's folder ({results}):"
                f" run the study that makes it there first (gearsweep run {name}.yaml -o {path}),"
                " or this one with -o beside it")))
    return StudyError.many("<study>", problems) if problems else None


INPUT_CHECKS = {"jump_map": _jump_map_input, "rattle_balance": _rattle_balance_input,
                "rattle_budget": _rattle_budget_input, "artifact_map": _artifact_map_input}
"""Per analysis kind, the check of what it reads (``check_inputs``; the analysis runs it too):
``check(analysis, dataset, name)``."""


def _unreadable(study: AnalysisStudy, path: Path, name: str, exc: Exception) -> ResultError:
    return ResultError(f"{path}: not a readable netCDF result ({type(exc).__name__}); analysis"
                       f" {study.analysis.kind!r} reads it: run studies/{name}.yaml again")


def check_inputs(study: AnalysisStudy, results: str | Path) -> None:
    """Check the analysis's inputs that are in the folder ``results`` (``validate``: those not
    there yet are only noted); ``StudyError`` as the analysis itself would raise, and
    ``ResultError`` for one that is there but not a readable netCDF file (as ``run`` refuses
    it: validate said ok of it)."""
    check = INPUT_CHECKS.get(study.analysis.kind)
    for name in study.analysis.inputs() if hasattr(study.analysis, "inputs") else []:
        path = Path(results) / f"{name}.nc"
        if not path.exists():
            continue  # (validate notes it)
        try:
            ds = xr.open_dataset(path)
        except (OSError, ValueError) as exc:
            raise _unreadable(study, path, name, exc) from None
        with ds:
            if check:
                check(study.analysis, ds, name)


def run_analysis_study(study: AnalysisStudy, text: str = "", results: str | Path = "results"):
    """Compute an analysis study and return its Dataset; the results it reads
    (``analysis.inputs()``) are opened from the folder ``results``."""
    t0 = time.perf_counter()
    inputs, prov = _open_inputs(study, Path(results))
    data, coords, attrs, settings = COMPUTE[study.analysis.kind](study.analysis, inputs)
    settings = {"scene": f"analysis: {study.analysis.kind}", **settings, **prov,
                "elapsed_seconds": round(time.perf_counter() - t0, 3)}
    settings = {k: ("nan" if isinstance(v, float) and not math.isfinite(v) else v)
                for k, v in settings.items()}
    return build_dataset(data, coords, title=study.title, study_text=text, settings=settings,
                         var_attrs=attrs, source=f"gearsweep analysis study {study.analysis.kind!r}")

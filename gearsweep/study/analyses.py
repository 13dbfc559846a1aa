"""Analysis studies computed into Datasets (``type: analysis``; options in ``analysis_specs``).

Each function takes the validated options and returns a Dataset built by ``dataset.build_dataset``
(units, long names, the study text, provenance), so the figure that draws it only reads a file.
"""

from __future__ import annotations

import math
import time

import numba
import numpy as np

from gearsweep.analysis import precision as pr
from gearsweep.analysis import stability as st
from gearsweep.errors import StudyError
from gearsweep.model import MeshModel
from gearsweep.study.analysis_specs import (
    AnalysisStudy,
    ArtifactMap,
    MethodStability,
    WorkPrecision,
)
from gearsweep.study.dataset import build_dataset
from gearsweep.study.plan import build_model
from gearsweep.study.schema import load_study

WHINE_DESCRIPTION = "time-varying stiffness + STE, no backlash"
RATTLE_DESCRIPTION = "constant stiffness, backlash 4 µm, contact loss"


def _polynomials(methods) -> tuple[np.ndarray, np.ndarray]:
    """Stability polynomial coefficients per method (ascending powers, zero-padded)."""
    polys = [[float(c) for c in st.stability_polynomial(m)] for m in methods]
    n = max(len(p) for p in polys)
    return np.arange(n), np.array([p + [0.0] * (n - len(p)) for p in polys])


POLY_ATTRS = {"units": "1", "long_name": "coefficient of z^power in the stability function R(z)"
              " of the method (z = h lambda)"}


def method_stability(o: MethodStability) -> tuple[dict, dict, dict, dict]:
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
    return data, coords, attrs, {"steps": o.steps}


def artifact_map(o: ArtifactMap) -> tuple[dict, dict, dict, dict]:
    """The paper's criterion per tableau and step over the rig study's speed x damping grid."""
    rig, _ = load_study(o.rig)
    model = build_model(rig)
    if not isinstance(model, MeshModel) or not model.stiffness_harmonics:
        raise StudyError(o.rig, "scene", rig.scene.kind, "a rig with a stiffness harmonic k1")
    speed = rig.grid("speed") if "speed" in rig.sweep else np.array([rig.scene.speed])
    damping = rig.grid("damping") if "damping" in rig.sweep else np.array([model.damping])
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
        "real_interval": (("method",), am["real_interval"]),
        "imaginary_interval": (("method",), am["imaginary_interval"]),
        "step_limit_hw": (("method", "damping"), am["step_limit_hw"]),
        "zeta": (("damping",), am["zeta"]),
        "stability_polynomial": (("method", "power"), coef),
    }
    coords = {"method": (("method",), np.array(o.methods)),
              "steps_per_period": (("steps_per_period",), np.asarray(o.steps_per_period)),
              "damping": (("damping",), damping), "speed": (("speed",), speed),
              "power": (("power",), power)}
    attrs = {
        "flag": {"units": "1", "long_name": "the paper's criterion reports instability (growth"
                 " 1e3-fold within 100 mesh periods from p = p' = 1e-6)"},
        "discrete_multiplier": {"units": "1", "long_name": "largest |mu| of the fixed-step map"
                                " over one mesh period"},
        "edge_speed": {"units": "rpm", "long_name": "highest speed the criterion flags"},
        "reproduces_paper": {"units": "1", "long_name": "the map has the paper's Fig. 7.2 shape"
                             " (unstable at low speed, edge near 200 rpm at 5.5 N s/mm)"},
        "real_interval": {"units": "1", "long_name": "stability interval on the negative real"
                          " axis, |h lambda|"},
        "imaginary_interval": {"units": "1", "long_name": "stability interval on the imaginary"
                               " axis, |h lambda|"},
        "step_limit_hw": {"units": "1", "long_name": "largest stable h omega_n at the damping"},
        "zeta": {"units": "1", "long_name": "damping ratio at k0"},
        "stability_polynomial": POLY_ATTRS,
        "method": {"long_name": "Runge-Kutta tableau (gearsweep.kernels.tableaux)"},
        "steps_per_period": {"units": "1", "long_name": "fixed steps per mesh period"},
        "damping": {"units": "N s m-1", "long_name": "mesh damping c"},
        "speed": {"units": "rpm", "long_name": "shaft speed of the driving gear"},
        "power": {"units": "1", "long_name": "power of z"},
    }
    return data, coords, attrs, {"rig_study": o.rig}


def work_precision(o: WorkPrecision) -> tuple[dict, dict, dict, dict]:
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
        ref = pr.reference(scene, window)
        p_ref = ref(pr.sample_times(scene, window))[0]
        if not scene.k_harmonics:  # cross-check the two references on a constant-k scene
            alt = pr.reference(scene, window, exact=False)
            d = np.max(np.abs(alt(pr.sample_times(scene, window))[0] - p_ref))
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


COMPUTE = {"method_stability": method_stability, "work_precision": work_precision,
           "artifact_map": artifact_map}


def run_analysis_study(study: AnalysisStudy, text: str = ""):
    """Compute an analysis study and return its Dataset."""
    t0 = time.perf_counter()
    data, coords, attrs, settings = COMPUTE[study.analysis.kind](study.analysis)
    settings = {"scene": f"analysis: {study.analysis.kind}", **settings,
                "elapsed_seconds": round(time.perf_counter() - t0, 3)}
    settings = {k: ("nan" if isinstance(v, float) and not math.isfinite(v) else v)
                for k, v in settings.items()}
    return build_dataset(data, coords, title=study.title, study_text=text, settings=settings,
                         var_attrs=attrs, source=f"gearsweep analysis study {study.analysis.kind!r}")

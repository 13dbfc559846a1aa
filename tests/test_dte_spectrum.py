"""The dynamic transmission error p + e (``outputs.spectrum.dte``) against independent truth.

p of Eq. (5) is r1 th1 - r2 th2 - e(t): with a gear pair's k(t), e = STE - F_m / k(t) and p is
the mesh deflection; with e the loaded STE, the dynamic minus the static transmission error. What
an angle or transmission-error measurement sees is r1 th1 - r2 th2 = p + e. References,
independent of the code under test:

* the static solution: far below resonance r1 th1 - r2 th2 is the pair's loaded static
  transmission error (``gearsweep.gear.mesh_cycle``, the STE of the quasi-static mesh), and
  exactly, for the model's Fourier series, ``F_m / k(t) + e(t)`` (k(t) p = F_m);
* scipy's ``solve_ivp`` (DOP853) of Eq. (6) from rest, with p + e formed from its p and e(t)
  at the samples and its lines taken by numpy's FFT.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from gearsweep.api import result_model, run_study
from gearsweep.cli import main
from gearsweep.gear.excitation import gear_excitation
from gearsweep.study.gearscene import gear_pair, reliefs
from gearsweep.study.schema import parse_study

RELIEVED = """
title: dte of a relieved pair
scene:
  kind: whine
  gear: {{module: 2.5 mm, z1: 27, z2: 41, face_width: 18 mm, x1: 0.3, x2: -0.1,
         tip_relief: {{amount: 15 um, start_at: single_contact}}}}
  harmonics: 40
  drive: {{inertia_1: 5e-4 kg m^2, inertia_2: 3e-3 kg m^2}}
  damping: 2 N*s/mm
sweep: {{speed: [{speed} rpm], torque: [50 N m, 150 N m]}}
solver: {{method: rk4, steps_per_period: {spp}, transient_periods: 4, record_periods: 2}}
outputs: [{{spectrum: {{max_order: 4, samples_per_period: 256, phase: true, dte: true}}}}]
"""


def run(text: str):
    return run_study(parse_study(text), text)


def complex_lines(ds, name: str) -> np.ndarray:
    """A spectrum's lines as A exp(i theta) [um]."""
    return ds[name].values * np.exp(1j * ds[f"{name}_phase"].values)


def series(harmonics, phi) -> np.ndarray:
    return sum((h.amplitude * np.cos(2 * math.pi * h.order * phi + h.phase) for h in harmonics),
               np.zeros_like(phi))


def test_quasi_static_dte_is_the_loaded_ste_where_p_is_not():
    """An outside tester's relieved 27/41 pair (15 um from the single-contact bounds) at 5 rpm
    (mesh 2.25 Hz, f_n 5.2 kHz): r1 th1 - r2 th2 is the loaded STE. At 150 N m the relief
    cancels most of the elastic ripple: STE order 1 is 0.19 um while p's line is 4.5 um, so p
    said the relief did nothing. Measured against the model's static solution F_m / k(t) +
    e(t): 1.5e-3 of the largest STE line (the damping's c w / k at 5 rpm; 6e-3 at 20 rpm);
    against the pair's own STE from the mesh: 2.5e-3 at 50 N m and 5.2e-2 at 150 N m, where
    the 40 harmonics of k(t) are the difference (1 / k(t) of a truncated series is not the
    series of 1 / k: 0.25 with the default 10 harmonics)."""
    text = RELIEVED.format(speed=5, spp=32768)
    ds = run(text).isel(speed=0)
    scene = parse_study(text).scene
    pair = gear_pair(scene.gear).check()
    for torque, tol_mesh in ((50.0, 5e-3), (150.0, 0.07)):
        at = ds.sel(torque=torque).sel(order=[1.0, 2.0, 3.0, 4.0])
        dte = complex_lines(at, "dte_spectrum") * 1e-6
        ste = gear_excitation(pair, torque, reliefs(scene.gear), 4).ste_harmonics
        ste = np.array([h.amplitude * np.exp(1j * h.phase) for h in ste])
        model = result_model(ds.expand_dims("speed"), torque=torque)
        phi = np.arange(4096) / 4096
        static = np.fft.rfft(model.mean_force / (model.stiffness + series(
            model.stiffness_harmonics, phi)) + series(model.ste_harmonics, phi))[1:5] * 2 / 4096
        scale = np.max(np.abs(ste))
        assert np.max(np.abs(dte - static)) < 3e-3 * scale
        assert np.max(np.abs(dte - ste)) < tol_mesh * scale
    at = ds.sel(torque=150.0, order=1.0)
    assert at.spectrum > 20 * at.dte_spectrum  # p is the mesh deflection, not the DTE
    assert ds.dte_spectrum.attrs["units"] == "um"
    for name in ("spectrum", "dte_spectrum"):  # what the file says p is: not the DTE
        comment = ds[name].attrs["comment"]
        assert "r1 theta1 - r2 theta2 - e(t)" in comment
        assert "the dynamic TE is p + e" in comment and "the mesh deflection where k(t)" in comment
    assert np.isnan(ds.dte_spectrum.sel(order=0.0)).all()  # e(t)'s mean is not in the model


M, K0, C, FM = 0.1527, 1.073e9, 5500.0, 833.0  # [kg], [N/m], [N s/m], [N] (tests/test_whine.py)
K1, A1 = 179e6, 0.4  # stiffness ripple [N/m], [rad]
STE = ((4e-6, 1.0, -1.0), (1.5e-6, 1.5, 2.0), (0.7e-6, 3.0, 0.3))  # e_n [m], order, b_n [rad]
TEETH = 48
N_RES = 60 * math.sqrt(K0 / M) / (2 * math.pi) / TEETH  # order 1 meets f_n: 16,675 rpm

def typed(speed: float) -> str:
    ste = ", ".join(f"{{amplitude: {a} m, order: {o}, phase: {b} rad}}" for a, o, b in STE)
    return f"""
title: dte against solve_ivp
scene: {{kind: whine, mass: {M} kg, teeth: {TEETH}, stiffness: {K0} N/m, damping: {C} N*s/m,
        mean_force: {FM} N, stiffness_harmonics: [{{amplitude: {K1} N/m, phase: {A1} rad}}],
        ste: [{ste}]}}
sweep: {{speed: [{speed} rpm]}}
solver: {{method: rk5, steps_per_period: 512, transient_periods: 61, record_periods: 4}}
outputs: [{{spectrum: {{max_order: 4, samples_per_period: 64, phase: true, dte: true}}}}]
"""


@pytest.mark.parametrize("speed", [0.55 * N_RES, N_RES, 1.9 * N_RES])
def test_dte_lines_match_solve_ivp(speed):
    """Eq. (6) with k(t) and an e(t) of orders 1, 1.5 and 3 (a cycle of 2 mesh periods; 61
    transient periods, so sample 0 is half a cycle off), through and past the order-1
    resonance: p from DOP853 (rtol 1e-11) from rest, p + e at the 64 x 4 sample instants
    after step 1, its lines by numpy's FFT. Measured: <= 2.1e-12 of the largest line; p's
    own lines at the orders of e(t) differ from them by 0.41-4.6 of theirs."""
    from scipy.integrate import solve_ivp

    ds = run(typed(speed)).isel(speed=0)
    w = TEETH * speed * 2 * math.pi / 60  # mesh angular frequency [rad/s]

    def e(t, d=0):  # e(t) and its second derivative [m], [m/s^2]
        return sum(a * (-(o * w) ** 2 if d else 1.0) * np.cos(o * w * t + b) for a, o, b in STE)

    def rhs(t, y):
        k = K0 + K1 * math.cos(w * t + A1)
        return [y[1], (FM - M * e(t, 2) - C * y[1] - k * y[0]) / M]

    phi = 61 + (1 + 8 * np.arange(256)) / 512  # the samples: after step 61 x 512 + 8 j + 1
    t = phi * 2 * math.pi / w
    sol = solve_ivp(rhs, (0.0, t[-1]), [0.0, 0.0], method="DOP853", rtol=1e-11, atol=1e-18,
                    t_eval=t)
    c = np.fft.rfft(sol.y[0] + e(t)) / 256 * 2  # lines in the frame of sample 0
    order = np.arange(len(c)) / 4
    want = c * np.exp(-2j * math.pi * order * phi[0])  # referred to t = 0
    assert np.allclose(ds.order.values, order[:17])  # orders 0, 0.25, .. 4
    want = want[2:17:2]  # orders 0.5, 1, .. 4: the cycle is 2 periods, the rest is empty
    got = complex_lines(ds, "dte_spectrum")[2::2] * 1e-6
    scale = np.max(np.abs(want))
    assert np.max(np.abs(got - want)) < 1e-10 * scale
    assert np.max(ds.dte_spectrum.values[1::2]) * 1e-6 < 1e-10 * scale
    p = complex_lines(ds, "spectrum")[2::2] * 1e-6
    assert np.max(np.abs(p - want)) > 0.1 * scale  # p is not it


def test_dte_refused_for_the_mathieu_scene(tmp_path, capsys):
    path = tmp_path / "m.yaml"
    path.write_text("title: m\nscene: {kind: mathieu, alpha: 1, beta: 0.1, gamma: 0.01}\n"
                    "sweep: {alpha: [0.5, 1.0]}\n"
                    "solver: {method: rk4, steps_per_period: 64, transient_periods: 10,"
                    " record_periods: 4}\n"
                    "outputs: [stats, {spectrum: {dte: true}}]\n")
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "m.yaml:5: outputs[1].spectrum.dte: True -- " in err[0]
    assert "Mathieu scene has no transmission error" in err[0]

"""Your own STE and stiffness: samples in a file (CSV, netCDF), fitted, run like any scene.

Independent truths: a synthetic signal with known harmonics (the fit must find them), and the
same scene typed in as harmonics (``stiffness``, ``stiffness_harmonics``, ``ste``: the run must
give the same numbers); the gear pair's own excitation for the example file.
"""

from __future__ import annotations

import hashlib
import json
import math
import warnings
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
import yaml
from numpy.testing import assert_allclose

import gearsweep
from gearsweep.cli import main
from gearsweep.errors import ResultError, StudyError
from gearsweep.gear import fourier, mesh_cycle, table1_consistent
from gearsweep.gear.measured import (
    FitError,
    fit_fourier,
    fit_orders,
    measured_excitation,
    positive_minimum,
)
from gearsweep.model import Harmonic
from gearsweep.study.plan import build_model, make_plan
from gearsweep.study.schema import load_study, parse_study

ROOT = Path(__file__).resolve().parent.parent


TWO_PI = 2.0 * math.pi

# A whine scene's k(t) and the separation u(t) = STE - F_m / k(t) it is excited by, as harmonics
# (amplitude SI, mesh order, phase rad): the truth the file is written from.
K0 = 2.0e8


K_H = [(4.0e7, 1, 0.7), (1.5e7, 2, -1.9)]


U_H = [(1.2e-6, 1, 0.3), (0.4e-6, 3, 2.2)]


F_M = 900.0


def series(mean, harmonics, phi):
    return mean + sum(a * np.cos(TWO_PI * o * phi + p) for a, o, p in harmonics)


def write_csv(path: Path, header: str, rows) -> Path:
    lines = ["# a test file", header] + [", ".join(f"{v:.17g}" for v in r) for r in rows]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def whine_files(tmp_path: Path, n: int = 64) -> Path:
    """STE [um] and stiffness [N/mm] over one mesh cycle, as an LTCA export would give them."""
    phi = np.arange(n) / n
    k = series(K0, K_H, phi)
    ste = series(3e-6, U_H, phi) + F_M / k  # a mean of 3 um: e_0 drops out of e''
    return write_csv(tmp_path / "ltca.csv", "mesh_phase [1], ste [um], mesh_stiffness [N/mm]",
                     zip(phi, ste * 1e6, k * 1e-3, strict=True))


def harmonics_yaml(items, unit) -> str:
    return "[" + ", ".join(f"{{amplitude: {a!r} {unit}, order: {o}, phase: {p!r} rad}}"
                           for a, o, p in items) + "]"


SOLVER = ("solver: {method: rk4, steps_per_period: 64, transient_periods: 40,"
          " record_periods: 20}\noutputs: [stats]\n")


def study(scene: str, sweep: str = "sweep:\n  speed: [1500 rpm, 6000 rpm, 9000 rpm]\n") -> str:
    return f"title: measured excitation\nscene:\n{scene}{sweep}{SOLVER}"


# --------------------------------------------------------------------------- the fit


def test_fit_finds_known_harmonics_from_uneven_samples():
    """A signal with known mean and harmonics at orders 1, 2, 5, sampled at 97 random phases:
    least squares finds them to round-off; with noise of sigma, the residual rms is about sigma."""
    rng = np.random.default_rng(1)
    phi = np.sort(rng.uniform(0.0, 1.0, 97))
    truth = [(2.0, 1, 0.5), (0.7, 2, -2.5), (0.05, 5, 3.0)]
    x = series(10.0, truth, phi)
    fit = fit_fourier(phi, x, fit_orders(6, 48, False))
    assert fit.mean == pytest.approx(10.0, rel=1e-13)
    got = {round(h.order): h for h in fit.harmonics}
    for a, o, p in truth:
        assert got[o].amplitude == pytest.approx(a, rel=1e-11)
        assert got[o].phase == pytest.approx(p, abs=1e-11)
    for o in (3, 4, 6):
        assert got[o].amplitude < 1e-12
    assert fit.residual_rms < 1e-13 and fit.residual_max < 1e-12
    noisy = fit_fourier(phi, x + rng.normal(0.0, 0.01, phi.size), fit_orders(6, 48, False))
    assert 0.006 < noisy.residual_rms < 0.012  # sigma less the 13 fitted parameters' share
    assert noisy.residual_max > noisy.residual_rms
    assert abs(noisy.harmonics[0].amplitude - 2.0) < 0.01


def test_fit_of_even_samples_is_the_dft():
    """For evenly spaced samples the fit equals ``gearsweep.gear.fourier`` (the DFT) of the
    computed Table 1 mesh cycle."""
    mc = mesh_cycle(table1_consistent(), 50.0, n=200)
    amp, ph = fourier(mc.ste, 10)
    fit = fit_fourier(mc.phase, mc.ste, fit_orders(10, 48, False))
    assert fit.mean == pytest.approx(amp[0], rel=1e-12)
    assert_allclose([h.amplitude for h in fit.harmonics], amp[1:], rtol=1e-9, atol=1e-16)
    big = amp[1:] > 1e-3 * amp[1]
    assert_allclose(np.array([h.phase for h in fit.harmonics])[big], ph[1:][big], atol=1e-8)


def test_revolution_fit_finds_shaft_orders():
    """Over a revolution of a 6-tooth gear the fit holds every shaft order k/6 up to the mesh
    orders asked: a once-per-revolution runout (order 1/6) and the mesh harmonic are found."""
    teeth = 6
    phi = np.arange(300) / 300 * teeth  # mesh cycles over one revolution
    truth = [(0.5e-6, 1 / teeth, 1.0), (2e-6, 1.0, -0.4), (0.3e-6, 2 + 1 / teeth, 0.2)]
    fit = fit_fourier(phi, series(0.0, truth, phi), fit_orders(3, teeth, True))
    assert len(fit.harmonics) == 3 * teeth
    got = {round(h.order * teeth): h for h in fit.harmonics}
    for a, o, p in truth:
        assert got[round(o * teeth)].amplitude == pytest.approx(a, rel=1e-10)
        assert got[round(o * teeth)].phase == pytest.approx(p, abs=1e-9)


def test_fit_refuses_too_few_or_bunched_samples():
    with pytest.raises(FitError, match="at least 21 distinct samples"):
        fit_fourier(np.arange(20) / 20, np.ones(20), fit_orders(10, 48, False))
    with pytest.raises(FitError, match="leave 0.9 mesh cycles empty after phase 0.1"):
        fit_fourier(np.linspace(0, 0.1, 50), np.ones(50), fit_orders(10, 48, False))
    # Three harmonics from samples over 0.3 of the cycle: the least-squares problem has full
    # rank, and the fit extrapolates over the rest: from the Table 1 samples squeezed so (found
    # by an adversarial test) the mean stiffness came out -2.4e9 N/m, every case diverged, and
    # nothing said why. A gap longer than a wave of the highest order is refused.
    phi = np.linspace(0, 0.3, 40)
    with pytest.raises(FitError, match="leave 0.7 mesh cycles empty after phase 0.3, more than"
                                       " one wave of the highest order fitted \\(0.333\\)"):
        fit_fourier(phi, np.ones(40), fit_orders(3, 48, False))
    with pytest.raises(FitError, match="leave 0.35 mesh cycles empty after phase 0.3,"):
        fit_fourier(np.append(phi, 0.65), np.ones(41), fit_orders(3, 48, False))
    fit = fit_fourier(np.append(phi, [0.5, 0.75]), 2 + np.cos(2 * np.pi * np.append(phi, [0.5, 0.75])),
                      fit_orders(3, 48, False))  # gaps 0.2, 0.25, 0.25: each under a wave
    assert fit.mean == pytest.approx(2.0) and fit.harmonics[0].amplitude == pytest.approx(1.0)


def test_a_fitted_or_typed_mesh_stiffness_that_is_not_positive_is_refused(tmp_path):
    """k(t) <= 0 somewhere on the cycle is no mesh: from samples it was fitted without a word
    (every case then diverged), and typed in (k0 100 kN/mm with a 500 kN/mm harmonic) it ran
    too. Both are refused in one line, naming the least value and where it is."""
    phi = np.arange(64) / 64
    k = series(1e8, ((5e8, 1.0, 0.0),), phi)
    with pytest.raises(FitError, match="the fitted mesh stiffness is not positive \\(-4e\\+08 N/m"
                                       " at mesh phase 0.5\\)"):
        measured_excitation(phi, None, k, fit_orders(2, 48, False), time_varying=True,
                            mean_force=F_M)
    text = """title: k
scene: {kind: whine, mass: 0.1527 kg, teeth: 48, stiffness: 100 kN/mm, damping: 5 N*s/mm,
        mean_force: 800 N, stiffness_harmonics: [{amplitude: 500 kN/mm, order: 1}]}
sweep: {speed: [5000 rpm]}
"""
    path = tmp_path / "k.yaml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(StudyError, match="k.yaml:3: scene.stiffness_harmonics: harmonics that keep"
                                         " k\\(t\\) positive: with k0 = 100 kN/mm they take it"
                                         " to -400 kN/mm at mesh phase 0.5"):
        make_plan(*load_study(path), str(path))
    path.write_text(text.replace("500 kN/mm", "50 kN/mm"), encoding="utf-8")
    make_plan(*load_study(path), str(path))
    # a dip between the points of a grid (1/128 of the cycle off them) is found (an
    # adversarial test), and a cycle of 1e5 mesh periods is checked without gigabytes
    path.write_text(text.replace("100 kN/mm", "1000 kN/mm").replace(
        "{amplitude: 500 kN/mm, order: 1}", "{amplitude: 1001 kN/mm, order: 1, phase: -2.8125 deg}"))
    with pytest.raises(StudyError, match=r"take it to -1 kN/mm at mesh phase 0.508"):
        make_plan(*load_study(path), str(path))
    low, where = positive_minimum(1000.0, [Harmonic(600.0, 1e-5), Harmonic(600.0, 100.0)], 1e5)
    assert -200.0 < low < -199.0 and 0 <= where < 1e5


def test_excitation_with_k_of_t_is_ste_less_f_over_k():
    """e = STE - F_m / k: from samples of u + F_m / k the fit gives u's harmonics exactly."""
    phi = np.arange(64) / 64
    k = series(K0, K_H, phi)
    ste = series(0.0, U_H, phi) + F_M / k
    mx = measured_excitation(phi, ste, k, fit_orders(8, 48, False), time_varying=True,
                             mean_force=F_M)
    assert mx.stiffness == pytest.approx(K0, rel=1e-13)
    got = {round(h.order): h.amplitude for h in mx.ste_harmonics}
    assert got[1] == pytest.approx(1.2e-6, rel=1e-10) and got[3] == pytest.approx(0.4e-6, rel=1e-10)
    assert got[2] < 1e-18
    assert mx.ste_residual_rms < 1e-18  # exact series: the model holds the STE
    rattle = measured_excitation(phi, ste, k, fit_orders(8, 48, False), time_varying=False,
                                 mean_force=F_M)
    assert rattle.stiffness_harmonics == ()  # constant k0 (Eq. 13)
    assert {round(h.order): h.amplitude for h in rattle.ste_harmonics}[2] > 1e-9  # F/k in it


# --------------------------------------------------------------------------- whole runs


def typed_whine(extra: str = "") -> str:
    return ("  kind: whine\n  teeth: 20\n  mass: 0.2 kg\n  damping: 2 N*s/mm\n"
            f"  mean_force: {F_M} N\n{extra}")


def test_whine_from_csv_runs_as_the_typed_in_scene(tmp_path):
    """The same whine scene from an LTCA-like CSV and typed in as harmonics: same model, same
    p statistics at every speed; the fit residual is in the result (and ~0 for exact samples)."""
    path = whine_files(tmp_path)
    measured = study(typed_whine(f"  excitation: {{file: {path.name}, harmonics: 5}}\n"))
    typed = study(typed_whine(f"  stiffness: {K0!r} N/m\n"
                              f"  stiffness_harmonics: {harmonics_yaml(K_H, 'N/m')}\n"
                              f"  ste: {harmonics_yaml(U_H, 'm')}\n"))
    (tmp_path / "measured.yaml").write_text(measured)
    ds_m = gearsweep.run(tmp_path / "measured.yaml")
    ds_t = gearsweep.run(typed)
    for v in ("p_rms", "p_pp", "p_mean", "p_max"):
        assert_allclose(ds_m[v].values, ds_t[v].values, rtol=1e-8, err_msg=v)
    assert float(ds_t.p_pp.min()) > 1e-7  # a real response, not zeros on both sides
    assert float(ds_m.excitation_fit_residual_ste) < 1e-12  # um
    assert float(ds_m.excitation_fit_residual_stiffness) < 1e-12  # kN/mm of 200
    assert ds_m.excitation_fit_residual_ste.attrs["units"] == "um"
    assert "least-squares fit" in ds_m.excitation_fit_residual_ste.attrs["source"]
    assert list(ds_m.excitation_order.values) == [1, 2, 3, 4, 5]
    assert float(ds_m.excitation_ste_amplitude.sel(excitation_order=3)) == pytest.approx(
        0.4, rel=1e-10)  # um
    assert float(ds_m.excitation_stiffness_phase.sel(excitation_order=2)) == pytest.approx(
        -1.9, abs=1e-10)
    model = json.loads(ds_m.attrs["model"])
    assert model["stiffness"] == pytest.approx(K0, rel=1e-13)
    assert len(model["ste_harmonics"]) == 5
    # the samples are not in the result: their file's bytes are named by hash (an outside
    # tester fitted the same study text to samples x 1.1: other numbers, the same study_sha256)
    assert ds_m.attrs["excitation_sha256"] == hashlib.sha256(path.read_bytes()).hexdigest()
    assert "excitation_sha256" not in ds_t.attrs


def test_rattle_from_netcdf_with_angle_runs_as_the_typed_in_scene(tmp_path):
    """A rattle scene (constant k0) uses the loaded STE as is: a netCDF file over the driving
    gear's angle [deg] with the STE in um, stiffness typed in, against the STE typed in."""
    teeth, n = 20, 48
    angle = np.arange(n) / n * 360.0 / teeth
    ste = series(2e-6, U_H, angle * teeth / 360.0)
    xr.Dataset({"ste": ("angle", ste * 1e6, {"units": "um"})},
               coords={"angle": ("angle", angle, {"units": "degree"})}).to_netcdf(
        tmp_path / "te.nc")
    # Damped enough (zeta 0.08) and loaded enough that every case settles on one periodic
    # rattle (contact lost part of each period): a chaotic case would amplify round-off.
    scene = ("  kind: rattle\n  teeth: 20\n  mass: 0.2 kg\n  damping: 1000 N*s/m\n"
             "  backlash: 20 um\n  mean_force: 100 N\n  stiffness: 2e8 N/m\n")
    measured = study(scene + "  excitation: {file: te.nc, harmonics: 4}\n")
    (tmp_path / "r.yaml").write_text(measured)
    ds_m = gearsweep.run(tmp_path / "r.yaml")
    ds_t = gearsweep.run(study(scene + f"  ste: {harmonics_yaml(U_H, 'm')}\n"))
    for v in ("p_rms", "p_pp", "contact_loss_fraction"):
        assert_allclose(ds_m[v].values, ds_t[v].values, rtol=1e-8, atol=1e-15, err_msg=v)
    assert float(ds_t.contact_loss_fraction.max()) > 0.3  # the STE makes it rattle
    assert (ds_t.status.values == 0).all()
    assert float(ds_m.excitation_fit_residual_ste) < 1e-12  # um
    assert math.isnan(float(ds_m.excitation_fit_residual_stiffness))  # no stiffness in the file


def test_example_study_matches_the_gear_scene():
    """studies/whine_measured_ste.yaml (200 samples of the Table 1 mesh cycle plus noise) gives
    the DFT of those samples without the noise: k0, k_n (to the noise) and an excitation e(t) of
    noise size (unmodified teeth: e = 0). (The gear scene's own k_n, integrated between the jumps
    of k, differ from the samples' by their O(1/N): k3 by 6 %.)"""
    st, _ = load_study(ROOT / "studies/whine_measured_ste.yaml")
    model = build_model(st)
    gear = build_model(parse_study(
        "title: g\nscene:\n  kind: whine\n  gear: table1_consistent\n  torque: 50 N*m\n"
        "  mass: 0.1527 kg\nsweep:\n  speed: [1000 rpm]\n"))
    k, phase = fourier(mesh_cycle(table1_consistent(), 50.0, n=200).mesh_stiffness, 3)
    assert model.teeth == gear.teeth == 48
    assert model.mean_force == pytest.approx(gear.mean_force, rel=1e-5)
    assert model.stiffness == pytest.approx(k[0], rel=1e-3)
    for m, a, ph in zip(model.stiffness_harmonics[:3], k[1:], phase[1:], strict=True):
        assert m.amplitude == pytest.approx(a, rel=0.01)
        assert m.phase == pytest.approx(ph, abs=0.02)
    assert max(h.amplitude for h in model.ste_harmonics) < 0.01e-6  # noise, not 1.3 um


# --------------------------------------------------------------------------- refusals


@pytest.mark.parametrize(("header", "column", "meant"), [
    ("mesh_phase [1], te [um], mesh_stiffness [N/mm]", "column 2 'te'", "ste"),
    ("mesh_phase [1], ste [um], mesh_stifness [N/mm]", "column 3 'mesh_stifness'",
     "mesh_stiffness"),
    ("phase [1], ste [um]", "column 1 'phase'", "mesh_phase"),
    ("mesh_phase [1], ste [um], force [N]", "column 3 'force'", None),
])


def test_a_csv_column_of_another_name_is_refused_at_the_header_line(tmp_path, capsys, header,
                                                                     column, meant):
    """A CSV column whose name is none of those read was skipped: ``te [um]`` beside
    ``mesh_stiffness`` validated, and the scene ran without its STE (p_rms 21x lower at 20000
    rpm); ``mesh_stifness`` was told "scene.stiffness: (missing) -- required", never naming
    the column (an outside tester). It is refused at the header's line (comments counted),
    with the names read and the closest one, exit 2."""
    write_csv(tmp_path / "x.csv", header, [[0.1, 1.0, 2e5][:header.count(",") + 1]])
    f = tmp_path / "s.yaml"
    f.write_text(study(typed_whine("  excitation: {file: x.csv}\n")))
    assert main(["validate", str(f)]) == 2
    (line,) = capsys.readouterr().err.splitlines()
    names = ("mesh_phase, angle, roll_angle, ste, transmission_error, mesh_stiffness or"
             " stiffness")
    assert line.startswith(f"gearsweep: error: {f}:")
    assert (f"scene.excitation.file: 'x.csv' -- line 2: {column} is no column gearsweep reads"
            f" ({names})") in line, line  # line 1: write_csv's comment
    assert line.endswith(f"; did you mean {meant!r}?" if meant else f"({names})"), line


@pytest.mark.parametrize(("header", "rows", "message"), [
    ("ste [um]", [[1.0]], "no position column"),
    ("mesh_phase [1]", [[0.1]], "no value column"),
    ("mesh_phase [1], ste", [[0.1, 1.0]], "column 'ste' needs its unit"),
    ("mesh_phase [1], ste [N]", [[0.1, 1.0]], "column 'ste': unit 'N'"),
    ("mesh_phase [deg], ste [um]", [[0.1, 1.0]], "unit 'deg' of a mesh phase"),
    # said "unit '1': a space inside a number" (it read '1 1'; an adversarial test)
    ("angle [1], ste [um]", [[0.1, 1.0]], ("column 'angle': unit '1' is no unit of an angle;"
     " write e.g. deg or rad")),
    ("mesh_phase [1], ste [um]", [[0.1, float("nan")]], "finite"),
])


def test_bad_files_give_one_line(tmp_path, header, rows, message):
    write_csv(tmp_path / "x.csv", header, rows)
    f = tmp_path / "s.yaml"
    f.write_text(study(typed_whine("  stiffness: 2e8 N/m\n  excitation: {file: x.csv}\n")))
    with pytest.raises(StudyError) as e:
        load_study(f)
    (line,) = str(e.value).splitlines()
    assert line.startswith(f"{f}:") and "scene.excitation.file: 'x.csv'" in line and message in line


@pytest.mark.parametrize(("text", "message"), [
    ("mesh_phase [1], ste [um]\n0.0, 1.0\n0.5, abc\n", "line 4: 'abc' is not a number"),
    ("mesh_phase [1], ste [um]\n0.0, 1.0\n0.5, nan\n",
     "line 4: 'nan' is not a finite number (every sample must be one)"),
    ("mesh_phase [1], ste [um]\n0.0, 1.0\n# a comment\ninf, 0.5\n",
     "line 5: 'inf' is not a finite number (every sample must be one)"),
    ("mesh_phase [1], ste [um]\n0.0, 1.0\n# a comment\n0.5\n", "line 5 has 1 value, the header 2"),
    ("mesh_phase [1], ste [um]\n", "no samples under the header line"),
    ("mesh_phase [1], ste [um], ste [mm]\n0.0, 1.0, 0.001\n",
     "two ste columns ('ste' and 'ste'): keep one"),
    ("mesh_phase [1], mesh_stiffness [N/mm], mesh_stiffness [N/mm], ste [um]\n0.0, 1, 1, 1\n",
     "two stiffness columns"),
    ("angle [deg], mesh_phase [1], ste [um]\n0.0, 0.0, 1.0\n", "two position columns"),
    # a sample of 1e30 um validated and ran to p_rms 6e28 um with status 0 (an outside tester)
    ("mesh_phase [1], ste [um]\n0.0, 1.0\n0.5, 1e30\n",
     ("line 4: '1e30' is beyond an STE of at most 1 mm (STEs are micrometres to tens of"
     " micrometres: a unit slip?)")),
    ("mesh_phase [1], ste [m]\n0.0, 5e-6\n0.5, -0.002\n", "line 4: '-0.002' is beyond an STE"),
])


def test_bad_csv_lines_and_twin_columns_are_named(tmp_path, text, message):
    """A CSV problem names its line in the file (comments counted; a ragged row said "setting
    an array element with a sequence"), and a column given twice is refused (the second was
    ignored, whatever its unit); found by an adversarial test."""
    (tmp_path / "x.csv").write_text("# a test file\n" + text, encoding="utf-8")
    f = tmp_path / "s.yaml"
    f.write_text(study(typed_whine("  stiffness: 2e8 N/m\n  excitation: {file: x.csv}\n")))
    with pytest.raises(StudyError) as e:
        load_study(f)
    (line,) = str(e.value).splitlines()
    assert "scene.excitation.file: 'x.csv'" in line and message in line, line


def test_an_excitation_file_that_is_a_pipe_is_refused_without_reading_it(tmp_path):
    """A named pipe (or a device: /dev/zero) as excitation.file was opened and read: validate
    hung on a pipe with no writer, and /dev/zero grew the memory without end (found by a
    fuzzer). It is refused as not a regular file, before it is opened."""
    import os
    import threading

    os.mkfifo(tmp_path / "x.csv")
    f = tmp_path / "s.yaml"
    f.write_text(study(typed_whine("  stiffness: 2e8 N/m\n  excitation: {file: x.csv}\n")))
    said: list[str] = []

    def load() -> None:
        try:
            load_study(f)
        except StudyError as exc:
            said.append(str(exc))

    reader = threading.Thread(target=load, daemon=True)  # (without the check: blocked in open)
    reader.start()
    reader.join(30)
    assert not reader.is_alive(), "load_study is still waiting on the pipe"
    (line,) = said[0].splitlines()
    assert "scene.excitation.file: 'x.csv' -- not a regular file" in line, line


def test_a_sample_beyond_a_float_in_si_is_named_by_its_line(tmp_path):
    """1e308 N/mm is 1e311 N/m: the check of finite samples ran on the numbers as written, the
    unit's factor then overflowed (numpy's RuntimeWarning on stderr, and 'the fitted mesh stiffness
    is not positive (nan N/m ...)'; found by a fuzzer). Named by its line, and no warning."""
    (tmp_path / "x.csv").write_text("mesh_phase [1], mesh_stiffness [N/mm]\n0.0, 2e5\n"
                                    "0.5, 1e308\n", encoding="utf-8")
    f = tmp_path / "s.yaml"
    f.write_text(study(typed_whine("  excitation: {file: x.csv}\n")))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(StudyError) as e:
            load_study(f)
    (line,) = str(e.value).splitlines()
    assert "scene.excitation.file: 'x.csv' -- line 3: '1e308' is beyond a float in SI (N/m)" in line


@pytest.mark.parametrize(("extra", "sweep", "message"), [
    ("  excitation: {file: ltca.csv, harmonics: 40}\n", None,
     "scene.excitation.harmonics: 40 -- needs at least 81 samples"),
    ("  excitation: {file: nothere.csv}\n", None, "no such file"),
    ("  excitation: {file: ltca.csv}\n  stiffness: 2e8 N/m\n", None,
     "scene.stiffness: excitation.file gives the mesh stiffness"),
    ("  excitation: {file: ltca.csv}\n  ste: [{amplitude: 1 um}]\n", None,
     "scene.ste: excitation.file gives the STE"),
    ("  excitation: {file: ltca.csv, span: revolution}\n", None,
     "harmonics: 10 -- needs at least 401 samples over a revolution"),
    ("  excitation: {file: ltca.csv}\n", "sweep:\n  speed: [1000 rpm]\n  mean_force: [1 N, 2 N]\n",
     "sweep.mean_force: with k(t)"),
    ("  excitation: {file: ltca.csv}\n  harmonics: 3\n", None, "scene.harmonics: 3"),
])


def test_inconsistent_scenes_give_one_line_and_exit_2(tmp_path, capsys, extra, sweep, message):
    whine_files(tmp_path)
    f = tmp_path / "s.yaml"
    f.write_text(study(typed_whine(extra), *(sweep,) if sweep else ()))
    assert main(["validate", str(f)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(f) in err and message in err, err


def test_gear_and_excitation_are_exclusive(tmp_path):
    whine_files(tmp_path)
    f = tmp_path / "s.yaml"
    f.write_text(study("  kind: whine\n  gear: table1_consistent\n  torque: 50 N*m\n"
                       "  mass: 0.1527 kg\n  excitation: {file: ltca.csv}\n"))
    with pytest.raises(StudyError, match=("scene.excitation: '{...}' -- give either 'gear' or"  # the
                                          " 'excitation'")):  # later written (README)
        load_study(f)


@pytest.mark.parametrize("first, second", [("gear", "excitation"), ("excitation", "gear")])
def test_gear_and_excitation_clash_is_said_at_the_later_written(tmp_path, first, second):
    """A problem between two fields is said at the later written (README): 'gear' then
    'excitation' was said at scene.gear, the earlier line."""
    whine_files(tmp_path)
    lines = {"gear": "  gear: table1_consistent\n", "excitation": "  excitation: {file: ltca.csv}\n"}
    f = tmp_path / "s.yaml"
    f.write_text(study(f"  kind: whine\n{lines[first]}  torque: 50 N*m\n  mass: 0.1527 kg\n"
                       f"{lines[second]}"))
    with pytest.raises(StudyError) as err:
        load_study(f)
    text = str(err.value)
    assert len(text.splitlines()) == 1 and f"scene.{second}: " in text, text
    assert "give either 'gear' or 'excitation', not both" in text, text


def test_measured_model_carries_fitted_harmonics(tmp_path):
    """build_model of an excitation scene: k0, k_n and e_n are the fit's (as SI Harmonics)."""
    path = whine_files(tmp_path)
    f = tmp_path / "s.yaml"
    f.write_text(study(typed_whine(f"  excitation: {{file: {path.name}, harmonics: 3}}\n")))
    model = build_model(load_study(f)[0])
    assert [round(h.order) for h in model.stiffness_harmonics] == [1, 2, 3]
    assert model.stiffness_harmonics[0].amplitude == pytest.approx(4e7, rel=1e-12)
    assert model.stiffness_harmonics[0].phase == pytest.approx(0.7, abs=1e-12)
    assert isinstance(model.ste_harmonics[2], Harmonic)
    assert model.ste_harmonics[2].amplitude == pytest.approx(0.4e-6, rel=1e-10)


def test_revolution_samples_over_an_angle_give_shaft_orders_and_run_as_typed_in(tmp_path):
    """Samples over one revolution of a 4-tooth driving gear, position in rad: the fit holds the
    once-per-revolution runout (mesh order 1/4) and a sideband (9/4) besides the mesh order, the
    kernel runs the 4-period cycle, and the run equals the scene typed in with those orders."""
    teeth, n = 4, 400
    angle = np.arange(n) / n * TWO_PI
    truth = [(0.8e-6, 0.25, 0.4), (1.5e-6, 1.0, -1.1), (0.3e-6, 2.25, 2.0)]
    ste = series(1e-6, truth, angle * teeth / TWO_PI)
    write_csv(tmp_path / "rev.csv", "roll_angle [rad]; transmission_error [mm]",
              zip(angle, ste * 1e3, strict=True))
    (tmp_path / "rev.csv").write_text((tmp_path / "rev.csv").read_text().replace(", ", "; "))
    scene = ("  kind: rattle\n  teeth: 4\n  mass: 0.2 kg\n  damping: 1000 N*s/m\n"
             "  backlash: 20 um\n  mean_force: 100 N\n  stiffness: 2e8 N/m\n")
    f = tmp_path / "rev.yaml"
    f.write_text(study(scene + "  excitation: {file: rev.csv, harmonics: 3, span: revolution}\n",
                       "sweep:\n  speed: [20000 rpm, 45000 rpm]\n"))
    model = build_model(load_study(f)[0])
    assert len(model.ste_harmonics) == 3 * teeth and model.cycle_periods == teeth
    got = {round(h.order * teeth): h for h in model.ste_harmonics}
    for a, o, p in truth:
        assert got[round(o * teeth)].amplitude == pytest.approx(a, rel=1e-10)
        assert got[round(o * teeth)].phase == pytest.approx(p, abs=1e-9)
    ds_m = gearsweep.run(f)
    ds_t = gearsweep.run(study(scene + f"  ste: {harmonics_yaml(truth, 'm')}\n",
                               "sweep:\n  speed: [20000 rpm, 45000 rpm]\n"))
    assert_allclose(ds_m.p_rms.values, ds_t.p_rms.values, rtol=1e-8)
    assert float(ds_t.contact_loss_fraction.max()) > 0
    # the samples span a revolution: as one mesh cycle they are refused, naming the span
    f.write_text(study(scene + "  excitation: {file: rev.csv, harmonics: 3}\n"))
    with pytest.raises(StudyError, match=r"scene.excitation.span: 'mesh_cycle' -- the samples"
                       r" of excitation.file span 359.1 deg, more than one mesh cycle"):
        load_study(f)


def test_relative_paths_are_read_from_the_study_folder(tmp_path, monkeypatch):
    """The example study validates from any working folder (its file is next to it), and a dict
    study reads a relative path from the working folder."""
    monkeypatch.chdir(tmp_path)
    st, _ = load_study(ROOT / "studies/whine_measured_ste.yaml")
    assert Path(st.scene.excitation.file) == ROOT / "studies/data/ste_table1.csv"
    whine_files(tmp_path)
    data = {"title": "t", "scene": {"kind": "whine", "teeth": 20, "mass": "0.2 kg",
                                    "mean_force": "900 N", "excitation": {"file": "ltca.csv"}},
            "sweep": {"speed": ["1000 rpm"]}}
    st, _ = gearsweep.api.load(data)
    assert Path(st.scene.excitation.file) == tmp_path / "ltca.csv"


def test_a_mesh_study_result_is_an_excitation_file(tmp_path):
    """A ``type: mesh`` result (ste [m], mesh_stiffness [N m-1], UDUNITS spelling, over
    mesh_phase [-]) fed back as the file gives the gear scene's model: its k0 and k_n, which the
    mesh study integrated between the jumps of k (the DFT of its 200 samples is off by O(1/N)
    there: k3 by 6.5 %), and e = STE - F_m / k = 0 for unmodified teeth."""
    gearsweep.run(ROOT / "studies/fig01_02_mesh_cycle.yaml", output=tmp_path / "mesh.nc")
    r1 = table1_consistent().base_radius1
    scene = ("  kind: whine\n  torque: 50 N*m\n  mass: 0.1527 kg\n")
    f = tmp_path / "s.yaml"
    f.write_text(study(scene + f"  excitation: {{file: mesh.nc}}\n  teeth: 48\n"
                       f"  base_radius: {r1!r} m\n"))
    m = build_model(load_study(f)[0])
    g = build_model(parse_study(study(scene + "  gear: table1_consistent\n")))
    k, phase = fourier(mesh_cycle(table1_consistent(), 50.0, n=200).mesh_stiffness, 10)
    assert m.stiffness == pytest.approx(g.stiffness, rel=1e-13)
    assert m.mean_force == pytest.approx(g.mean_force, rel=1e-14)
    assert_allclose([h.amplitude for h in m.stiffness_harmonics],
                    [h.amplitude for h in g.stiffness_harmonics], rtol=1e-11)
    assert_allclose([h.phase for h in m.stiffness_harmonics],
                    [h.phase for h in g.stiffness_harmonics], atol=1e-11)
    assert m.stiffness_harmonics[2].amplitude / k[3] - 1 < -0.05  # not the samples' DFT
    assert max(h.amplitude for h in m.ste_harmonics) < 1e-15  # of a 4.3 um STE
    # the file states its pair: a scene of other teeth or another base radius is refused (a
    # new-user test ran 30 teeth, and a torque through 40 mm, on the 48-tooth pair's samples)
    for old, new, said in (
            ("teeth: 48", "teeth: 30", ("s.yaml:7: scene.teeth: 30 -- the driving gear's teeth of"
             " excitation.file's pair (48, from its base_radius_1 and base_pitch)")),
            (f"base_radius: {r1!r} m", "base_radius: 40 mm", ("s.yaml:8: scene.base_radius: the"
             " driving gear's base radius of excitation.file's pair (56.3816 mm, its"
             " base_radius_1), the scene's 40 mm"))):
        f.write_text(study(scene + f"  excitation: {{file: mesh.nc}}\n  teeth: 48\n"
                           f"  base_radius: {r1!r} m\n").replace(old, new))
        with pytest.raises(StudyError) as err:
            load_study(f)
        assert str(err.value).splitlines() == [f"{f.parent}/{said}"]
    # the study's own excitation file is no place for its result (gearsweep.run wrote over it)
    f.write_text(study(scene + f"  excitation: {{file: mesh.nc}}\n  teeth: 48\n"
                       f"  base_radius: {r1!r} m\n"))
    before = (tmp_path / "mesh.nc").read_bytes()
    with pytest.raises(ResultError, match="it is mesh.nc, which the study reads"):
        gearsweep.run(f, output=tmp_path / "mesh.nc")
    assert (tmp_path / "mesh.nc").read_bytes() == before


def test_a_files_stated_load_must_be_the_scenes(tmp_path, capsys):
    """A mesh study's result names its load (a scalar 'torque'); a scene that ran its STE at
    another load was accepted silently (p_rms 0.28-1.14 um where the file's load gives 2.3-2.6).
    It is refused at the scene's load field; the file's load runs."""
    phi = np.arange(64) / 64
    xr.Dataset({"ste": ("mesh_phase", series(5e-6, U_H, phi) * 1e6, {"units": "um"})},
               coords={"mesh_phase": ("mesh_phase", phi, {"units": "1"}),
                       "torque": ((), 100.0, {"units": "N m"})}).to_netcdf(tmp_path / "m.nc")
    scene = ("  kind: whine\n  teeth: 48\n  mass: 0.1527 kg\n  damping: 5 N s/mm\n"
             "  stiffness: 2e8 N/m\n  base_radius: 50 mm\n  excitation: {file: m.nc}\n")
    (tmp_path / "s.yaml").write_text(study(scene + "  torque: 20 N m\n"), encoding="utf-8")
    assert main(["validate", str(tmp_path / "s.yaml")]) == 2
    err = capsys.readouterr().err
    said = "scene.torque: excitation.file's STE is at 100 N m (its 'torque'), the scene at 20 N m"
    assert err.count("\n") == 1 and said in err, err
    (tmp_path / "s.yaml").write_text(study(scene + "  mean_force: 2 kN\n"), encoding="utf-8")
    assert main(["validate", str(tmp_path / "s.yaml")]) == 0  # 2 kN x 50 mm = 100 N m


def test_a_files_stated_load_against_swept_loads_and_unstated_ones(tmp_path, capsys):
    """A review found the check skipped a swept load (a rattle scene may sweep it beside an STE
    file) and a mean_force without base radius, and crashed (TypeError) on a torque axis of size
    1; a torque without a unit refused the whole file. Now: swept loads are compared, a force
    without a radius is asked for one, and a load the file does not state plainly is none."""
    phi = np.arange(64) / 64
    ste = ("mesh_phase", series(5e-6, U_H, phi) * 1e6, {"units": "um"})
    pos = ("mesh_phase", phi, {"units": "1"})
    for name, torque in (("scalar.nc", ((), 100.0, {"units": "N m"})),
                         ("axis.nc", (("torque",), [100.0], {"units": "N m"})),
                         ("nounit.nc", ((), 100.0))):
        xr.Dataset({"ste": ste}, coords={"mesh_phase": pos, "torque": torque}).to_netcdf(
            tmp_path / name)
    rattle = ("  kind: rattle\n  teeth: 48\n  mass: 0.1527 kg\n  damping: 5 N s/mm\n"
              "  backlash: 0.1 mm\n  stiffness: 2e8 N/m\n  base_radius: 50 mm\n")

    def validate(scene: str, sweep: str = "sweep:\n  speed: [3000 rpm]\n") -> tuple[int, str]:
        (tmp_path / "s.yaml").write_text(study(scene, sweep), encoding="utf-8")
        rc = main(["validate", str(tmp_path / "s.yaml")])
        return rc, capsys.readouterr().err

    rc, err = validate(rattle + "  excitation: {file: scalar.nc}\n",
                       "sweep:\n  speed: [3000 rpm]\n  torque: [100 N m, 50 N m]\n")
    said = "sweep.torque: excitation.file's STE is at 100 N m (its 'torque'), the scene at 50 N m"
    assert rc == 2 and said in err, err
    rc, err = validate(rattle.replace("  base_radius: 50 mm\n", "") + "  mean_force: 2 kN\n"
                       "  excitation: {file: scalar.nc}\n")
    said = ("scene.mean_force: excitation.file's STE is at 100 N m (its 'torque'): give"
            " base_radius beside mean_force, or torque")
    assert rc == 2 and said in err, err
    assert validate(rattle + "  torque: 20 N m\n  excitation: {file: nounit.nc}\n")[0] == 0
    # a torque axis of length 1 states the load (a mesh study swept over one torque writes its
    # values over it: was refused as "not 1-D", found by a new-user test)
    rc, err = validate(rattle + "  torque: 20 N m\n  excitation: {file: axis.nc}\n")
    assert rc == 2 and "excitation.file's STE is at 100 N m (its 'torque'), the scene at 20" in err
    xr.Dataset({"ste": (("torque", "mesh_phase"), [ste[1]], {"units": "um"})},
               coords={"mesh_phase": pos, "torque": (("torque",), [20.0], {"units": "N m"})}
               ).to_netcdf(tmp_path / "over.nc")
    assert validate(rattle + "  torque: 20 N m\n  excitation: {file: over.nc}\n")[0] == 0


def test_the_checkpoint_key_holds_the_excitation_files_bytes_not_its_name(tmp_path):
    """Chunks saved from one content of the excitation file are not resumed with another: the
    study's key (its checkpoint folder) changes with the file's bytes (an interrupted run was
    resumed after the STE column was tripled: 6,000 of 40,000 cases came from the new samples,
    the rest from the old, with the new fit in the file). The same bytes written again (a new
    mtime) keep the key."""
    from gearsweep.study.plan import make_plan
    from gearsweep.study.schema import load_study

    root = Path(__file__).resolve().parents[1] / "studies"
    (tmp_path / "data").mkdir()
    csv = tmp_path / "data" / "ste_table1.csv"
    original = (root / "data" / "ste_table1.csv").read_text(encoding="utf-8")
    csv.write_text(original, encoding="utf-8")
    study = tmp_path / "m.yaml"
    study.write_text((root / "whine_measured_ste.yaml").read_text(encoding="utf-8"),
                     encoding="utf-8")

    def key() -> str:
        return make_plan(*load_study(str(study))).study_key

    first = key()
    csv.write_text(original, encoding="utf-8")  # the same bytes again
    assert key() == first
    rows = original.splitlines()
    i = next(i for i, r in enumerate(rows) if r[:1].isdigit())
    cells = rows[i].split(",")
    cells[1] = f" {3 * float(cells[1]):.6f}"  # one STE sample changed
    rows[i] = ",".join(cells)
    csv.write_text("\n".join(rows) + "\n", encoding="utf-8")
    assert key() != first


def test_a_result_whose_study_reads_a_file_runs_again_from_the_result(tmp_path, monkeypatch):
    """The result keeps the folder the study's relative paths were read from (``study_folder``):
    ``run(result_study(res))`` from any working folder reads the same file and gives the same
    numbers (it looked for ``data/ste_table1.csv`` in the working folder: no such file)."""
    root = Path(__file__).resolve().parents[1] / "studies"
    text = (root / "whine_measured_ste.yaml").read_text(encoding="utf-8")
    text = text.replace("num: 96", "num: 4")
    (tmp_path / "study").mkdir()
    study = tmp_path / "study" / "m.yaml"
    study.write_text(text, encoding="utf-8")
    (tmp_path / "study" / "data").mkdir()
    (tmp_path / "study" / "data" / "ste_table1.csv").write_bytes(
        (root / "data" / "ste_table1.csv").read_bytes())
    first = gearsweep.run(study, output=tmp_path / "r.nc")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    res = gearsweep.open_result(tmp_path / "r.nc")
    assert res.attrs["study_folder"] == str((tmp_path / "study").resolve())
    again = gearsweep.run(gearsweep.result_study(res))
    np.testing.assert_array_equal(again.p_rms.values, first.p_rms.values)


def test_a_missing_file_of_a_study_without_a_file_names_where_it_was_looked_for(tmp_path,
                                                                                 monkeypatch):
    """A study from stdin or a dict reads its relative paths from the working folder, which the
    message said was the study file's folder (``<stdin>:17: ... 'data/ste.csv' -- no such file
    (a path relative to the study file)``); it now names the path it looked for."""
    text = typed_whine("  excitation: {file: data/nothere.csv}\n")
    monkeypatch.chdir(tmp_path)
    with pytest.raises(StudyError) as e:
        gearsweep.run(yaml.safe_load(study(text)))
    (line,) = str(e.value).splitlines()
    assert str(tmp_path / "data" / "nothere.csv") in line and "working folder" in line, line


def test_a_fit_is_held_to_the_steps_of_its_highest_harmonic(tmp_path):
    """An excitation file fitted to ``harmonics: 20`` at 64 steps per period ran with 3.2
    steps per period of its top order, where typed harmonics and a gear's are refused below 4
    (``STEPS_PER_HARMONIC``): now said the same way, at steps_per_period's line."""
    path = whine_files(tmp_path)
    text = study(typed_whine(f"  excitation: {{file: {path.name}, harmonics: 20}}\n"))
    (tmp_path / "s.yaml").write_text(text)
    with pytest.raises(StudyError, match=r"solver.steps_per_period: 64 -- at least 80 \(4 steps"
                                         r" per period of the highest excitation harmonic, mesh"
                                         r" order 20, scene.excitation.harmonics: 20;"):
        gearsweep.run(tmp_path / "s.yaml")
    (tmp_path / "s.yaml").write_text(text.replace("harmonics: 20", "harmonics: 16"))
    gearsweep.run(tmp_path / "s.yaml")  # 64 = 4 x 16


RELIEVED_MESH = ("type: mesh\ntitle: relieved Table 1 pair\ngear: {preset: table1_consistent,"
                 " tip_relief: {amount: 6 um, start_at: single_contact}}\ntorque: 50 N*m\n"
                 "positions: 200\nharmonics: 10\n")


@pytest.mark.parametrize("kind", ["whine", "rattle"])


def test_a_mesh_result_fed_back_gives_the_gear_scenes_integrated_harmonics(tmp_path, kind):
    """A mesh study's result fed as ``excitation.file`` gives the scene the harmonics its mesh
    study integrated between the breaks of the mesh, not the DFT of its 200 samples (off by
    O(1/N) where k jumps: k3 by 6.5 %; the twin of whine_gear_table1 fed
    fig01_02_mesh_cycle's result was up to 2.4 % off the gear scene in p_rms). Truth: the gear
    scene's own k0, k_n and e_n (integrated; tested against Simpson's rule in
    test_gear_mesh.py), for a relieved pair (e = STE - F_m / k is not 0), and its response
    over a few speeds."""
    gearsweep.run(parse_study(RELIEVED_MESH), output=tmp_path / "mesh.nc")
    r1 = table1_consistent().base_radius1
    gear = ("{preset: table1_consistent, tip_relief: {amount: 6 um, start_at: single_contact}}")
    scene = (f"  kind: {kind}\n  torque: 50 N*m\n  mass: 0.1527 kg\n  damping: 0.55 N*s/mm\n"
             + ("  backlash: 40 um\n" if kind == "rattle" else ""))
    sweep = "sweep:\n  speed: [3000 rpm, 7200 rpm, 9000 rpm]\n"
    f = tmp_path / "s.yaml"
    f.write_text(study(scene + f"  excitation: {{file: mesh.nc, harmonics: 10}}\n  teeth: 48\n"
                       f"  base_radius: {r1!r} m\n", sweep))
    m = build_model(load_study(f)[0])
    typed = study(scene + f"  gear: {gear}\n  harmonics: 10\n", sweep)
    g = build_model(parse_study(typed))
    assert m.stiffness == pytest.approx(g.stiffness, rel=1e-13)
    assert m.mean_force == pytest.approx(g.mean_force, rel=1e-14)
    assert len(m.stiffness_harmonics) == len(g.stiffness_harmonics)
    assert len(m.ste_harmonics) == len(g.ste_harmonics) == 10
    k_scale, e_scale = g.stiffness, max(h.amplitude for h in g.ste_harmonics)
    assert e_scale > 0.1e-6  # the relief's excitation, not zero
    for mine, theirs, scale in ((m.stiffness_harmonics, g.stiffness_harmonics, k_scale),
                                (m.ste_harmonics, g.ste_harmonics, e_scale)):
        assert [h.order for h in mine] == [h.order for h in theirs]
        # as complex numbers: a phase of an amplitude at rounding is any phase
        assert_allclose([h.amplitude * np.exp(1j * h.phase) for h in mine],
                        [h.amplitude * np.exp(1j * h.phase) for h in theirs],
                        rtol=0, atol=1e-12 * scale)
    f.write_text(f.read_text())
    ds_m, ds_g = gearsweep.run(f), gearsweep.run(typed)
    for v in ("p_rms", "p_pp", "p_mean"):
        assert_allclose(ds_m[v].values, ds_g[v].values, rtol=1e-9, err_msg=v)
    assert float(ds_g.p_pp.min()) > 1e-7
    assert "integrated by its mesh study" in ds_m.excitation_fit_residual_ste.attrs["source"]


def test_a_mesh_result_with_fewer_harmonics_or_another_load_is_refused(tmp_path, capsys):
    """A scene asking for more harmonics than the mesh study integrated, or at a load the
    result does not hold, is refused with one line (the samples' DFT would have given them
    silently, off by O(1/N))."""
    gearsweep.run(parse_study(RELIEVED_MESH), output=tmp_path / "mesh.nc")
    r1 = table1_consistent().base_radius1
    base = ("  kind: whine\n  mass: 0.1527 kg\n  teeth: 48\n"
            f"  base_radius: {r1!r} m\n")

    def validate(scene: str) -> tuple[int, str]:
        (tmp_path / "s.yaml").write_text(study(base + scene), encoding="utf-8")
        rc = main(["validate", str(tmp_path / "s.yaml")])
        return rc, capsys.readouterr().err

    rc, err = validate("  torque: 50 N*m\n  excitation: {file: mesh.nc, harmonics: 12}\n")
    assert rc == 2 and err.count("\n") == 1, err
    assert ("scene.excitation.harmonics: 12 -- excitation.file holds the harmonics 0-10 its mesh"
            " study integrated") in err, err
    rc, err = validate("  torque: 60 N*m\n  excitation: {file: mesh.nc, harmonics: 10}\n")
    assert rc == 2 and err.count("\n") == 1, err
    assert "excitation.file's STE is at 50 N m (its 'torque'), the scene at 60 N m" in err, err


def test_a_mesh_result_over_several_torques_gives_the_scenes_load(tmp_path, capsys):
    """A mesh study swept over torque holds each load's integrated harmonics: a scene takes
    those at its own torque (or mean_force x base radius), and one at a torque the file does not
    hold is refused in one line (the file was refused whole: 'values must be 1-D'). A result of
    several gear pairs (variant) says it needs one pair a file."""
    mesh = RELIEVED_MESH.replace("torque: 50 N*m\n", "sweep:\n  torque: [30 N*m, 50 N*m, 70 N*m]\n")
    gearsweep.run(parse_study(mesh), output=tmp_path / "mesh.nc")
    r1 = table1_consistent().base_radius1
    gear = "{preset: table1_consistent, tip_relief: {amount: 6 um, start_at: single_contact}}"
    base = "  kind: whine\n  mass: 0.1527 kg\n  damping: 0.55 N*s/mm\n"
    for load in ("torque: 70 N*m", f"mean_force: {50.0 / r1!r} N"):
        f = tmp_path / "s.yaml"
        f.write_text(study(base + f"  {load}\n  excitation: {{file: mesh.nc}}\n  teeth: 48\n"
                           f"  base_radius: {r1!r} m\n"))
        m = build_model(load_study(f)[0])
        g = build_model(parse_study(study(base + f"  {load}\n  gear: {gear}\n")))
        assert m.stiffness == pytest.approx(g.stiffness, rel=1e-13)
        for mine, theirs in ((m.stiffness_harmonics, g.stiffness_harmonics),
                             (m.ste_harmonics, g.ste_harmonics)):
            assert_allclose([h.amplitude * np.exp(1j * h.phase) for h in mine],
                            [h.amplitude * np.exp(1j * h.phase) for h in theirs], rtol=0,
                            atol=1e-12 * max(h.amplitude for h in theirs))

    def validate(scene: str) -> tuple[int, str]:
        (tmp_path / "s.yaml").write_text(study(base + scene), encoding="utf-8")
        rc = main(["validate", str(tmp_path / "s.yaml")])
        return rc, capsys.readouterr().err

    rc, err = validate(f"  torque: 60 N*m\n  excitation: {{file: mesh.nc}}\n  teeth: 48\n"
                       f"  base_radius: {r1!r} m\n")
    assert rc == 2 and err.count("\n") == 1, err
    assert ("s.yaml:6: scene.torque: excitation.file holds the mesh at 3 torques (30-70 N m,"
            " its 'torque'), not the scene's 60 N m") in err, err
    gearsweep.run(ROOT / "studies/mesh_ste_vs_load.yaml", output=tmp_path / "pairs.nc")
    rc, err = validate("  torque: 50 N*m\n  excitation: {file: pairs.nc}\n  teeth: 48\n")
    assert rc == 2 and err.count("\n") == 1, err
    assert "several gear pairs (variant): one pair a file" in err, err


def test_a_csv_not_in_utf8_names_the_line_and_column_of_its_first_bad_byte(tmp_path):
    """A Latin-1 CSV (a micro sign 0xb5 in its header) said "cannot read the file
    (UnicodeDecodeError)", no line (an outside tester's finding): its line in the file and the
    column, as for a sample that is not a number."""
    (tmp_path / "x.csv").write_bytes(b"# a test file\nmesh_phase [1], ste [\xb5m]\n0.0, 1.0\n")
    f = tmp_path / "s.yaml"
    f.write_text(study(typed_whine("  stiffness: 2e8 N/m\n  excitation: {file: x.csv}\n")))
    with pytest.raises(StudyError) as e:
        load_study(f)
    (line,) = str(e.value).splitlines()
    assert line.startswith(f"{f}:") and line.endswith(
        "scene.excitation.file: 'x.csv' -- line 2: byte 0xb5 at column 22 is not UTF-8 text"
        " (save the file as UTF-8)"), line


# --------------------------------------------------------------------------- netCDF names, units


def _ltca_netcdf(path: Path, names: dict[str, str | None], n: int = 64) -> Path:
    """``whine_files``'s STE [um] and stiffness [N/mm] as a netCDF file over mesh_phase, each
    under the name given (``names``: 'ste'/'stiffness' -> variable name), with ``units`` unless
    the name maps to None-unit (``name!`` drops the attribute)."""
    phi = np.arange(n) / n
    k = series(K0, K_H, phi)
    ste = series(3e-6, U_H, phi) + F_M / k
    data = {}
    for which, values, unit in (("ste", ste * 1e6, "um"), ("stiffness", k * 1e-3, "N/mm")):
        name = names.get(which)
        if name is None:
            continue
        bare = name.endswith("!")
        data[name.rstrip("!")] = ("mesh_phase", values, {} if bare else {"units": unit})
    xr.Dataset(data, coords={"mesh_phase": ("mesh_phase", phi, {"units": "1"})}).to_netcdf(path)
    return path


@pytest.mark.parametrize(("names", "said"), [
    ({"ste": "te", "stiffness": "mesh_stiffness"}, "variable 'te'", ),
    ({"ste": "ste", "stiffness": "mesh_stifness"}, "variable 'mesh_stifness'"),
    ({"ste": "STE_", "stiffness": None}, "variable 'STE_'"),
])
def test_a_netcdf_value_under_a_near_miss_name_is_refused(tmp_path, capsys, names, said):
    """A netCDF file with its STE as ``te`` (um) beside ``mesh_stiffness`` validated and ran
    without any STE (no excitation_ste_* variables, another p_rms): only the names read were
    looked at (an outside tester). As the CSV rule refuses ``te [um]`` with "did you mean
    'ste'?", a netCDF variable whose name is a near miss of a value the file lacks is refused,
    in one line, exit 2 (a mesh study's other variables are left alone: the test of its result
    above)."""
    _ltca_netcdf(tmp_path / "x.nc", names)
    meant = {"te": "ste", "mesh_stifness": "mesh_stiffness", "STE_": "ste"}[said.split("'")[1]]
    f = tmp_path / "s.yaml"
    extra = "" if names.get("stiffness") else "  stiffness: 2e8 N/m\n"
    f.write_text(study(typed_whine(extra + "  excitation: {file: x.nc}\n")))
    assert main(["validate", str(f)]) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert f"scene.excitation.file: 'x.nc' -- {said} is no variable gearsweep reads" in line, line
    assert line.endswith(f"did you mean {meant!r}?"), line


def test_a_netcdf_file_s_unrelated_variables_are_left_alone(tmp_path):
    """Variables not near a value the file lacks (a temperature, a ``te`` beside ``ste``) are
    not the samples' and are not refused."""
    path = _ltca_netcdf(tmp_path / "x.nc", {"ste": "ste", "stiffness": "mesh_stiffness"})
    with xr.open_dataset(path) as ds:
        ds = ds.load()
    ds["te"] = ds["ste"] * 2
    ds["temperature"] = ((), 40.0, {"units": "degC"})
    ds.to_netcdf(tmp_path / "y.nc")
    f = tmp_path / "s.yaml"
    f.write_text(study(typed_whine("  excitation: {file: y.nc}\n")))
    load_study(f)


def test_a_netcdf_variable_without_units_is_told_to_add_a_units_attribute(tmp_path):
    """_factor spoke of a CSV header to a netCDF file: "column 'ste' needs its unit in the
    header, e.g. 'ste [um]'" for a variable without ``units`` (an outside tester)."""
    _ltca_netcdf(tmp_path / "x.nc", {"ste": "ste!", "stiffness": "mesh_stiffness"})
    f = tmp_path / "s.yaml"
    f.write_text(study(typed_whine("  excitation: {file: x.nc}\n")))
    with pytest.raises(StudyError) as e:
        load_study(f)
    (line,) = str(e.value).splitlines()
    assert line.endswith("-- variable 'ste' needs a 'units' attribute, e.g. units = 'um'"), line
    assert "header" not in line and "column" not in line


def test_a_mesh_phase_without_a_unit_is_mesh_cycles_and_one_in_degrees_is_told(tmp_path):
    """``mesh_phase`` is a fraction of the mesh cycle, dimensionless: a CSV ``mesh_phase``
    column without a unit is read as ``[1]`` (docs/mesh.md says so, as the exception to "a
    column without a unit is refused"); one written in degrees spans more than a cycle and is
    refused with where the angle goes (it said only "span: revolution")."""
    path = whine_files(tmp_path)
    text = path.read_text().replace("mesh_phase [1]", "mesh_phase")
    (tmp_path / "bare.csv").write_text(text)
    models = []
    for name in (path.name, "bare.csv"):
        f = tmp_path / "s.yaml"
        f.write_text(study(typed_whine(f"  excitation: {{file: {name}, harmonics: 5}}\n")))
        models.append(build_model(load_study(f)[0]))
    assert models[0] == models[1]
    phi = np.arange(64) / 64
    write_csv(tmp_path / "deg.csv", "mesh_phase, ste [um]",
              zip(phi * 18.0, series(3.0, [(1.0, 1, 0.0)], phi), strict=True))
    f = tmp_path / "s.yaml"
    f.write_text(study(typed_whine("  stiffness: 2e8 N/m\n  excitation: {file: deg.csv}\n")))
    with pytest.raises(StudyError) as e:
        load_study(f)
    (line,) = str(e.value).splitlines()
    assert "span 17.72 mesh cycles" in line and ("mesh_phase is in mesh cycles (0 to 1); an angle"
                                                  " of the driving gear is an 'angle [deg]'"
                                                  " column") in line, line


def _unit_slip_files(tmp_path: Path, unit: str) -> Path:
    """0.5 um of STE and 300 kN/mm of stiffness written in N/mm, under the header's ``unit``."""
    phi = np.arange(64) / 64
    return write_csv(tmp_path / "ltca.csv", f"mesh_phase [1], ste [um], mesh_stiffness [{unit}]",
                     zip(phi, 0.5 + 0.1 * np.cos(TWO_PI * phi), 3e5 + 5e4 * np.cos(TWO_PI * phi),
                         strict=True))


@pytest.mark.parametrize(("unit", "force", "message"), [
    ("N/m", F_M, ("scene.excitation.file: 'ltca.csv' -- the fitted mean of column 'mesh_stiffness'"
     " [N/m] is 3e+05 N/m: at the scene's mean mesh force 900 N it gives a static mesh deflection"
     " F_m/k0 = 3000 um, beyond 1 mm")),
    ("N/m", 240.0, ("F_m/k0 = 800 um, 1.33e+03 times the file's largest STE sample (0.6 um), which"
     " holds it (at most 1000): a unit slip, N/mm data labelled N/m?")),
    ("kN/mm", F_M, ("the fitted mean of column 'mesh_stiffness' [kN/mm] is 3e+05 kN/mm (3e+11 N/m),"
     " stiffer than any spur mesh")),
])
def test_a_stiffness_column_in_the_wrong_unit_is_refused(tmp_path, capsys, unit, force, message):
    """N/mm data labelled N/m ran with status 0 and no warning, p_mean 4208 um (an outside
    tester), as did N/mm data labelled kN/mm (3e11 N/m): the mean stiffness's static deflection
    against the largest STE and the file's STE, and a stiffness beyond any spur mesh, are
    refused in one line naming the column, the value in its unit and the likely slip."""
    _unit_slip_files(tmp_path, unit)
    f = tmp_path / "s.yaml"
    f.write_text(study(typed_whine().replace(str(F_M), f"{force:g}")
                       + "  excitation: {file: ltca.csv, harmonics: 3}\n"), encoding="utf-8")
    assert main(["validate", str(f)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(f) in err and message in err, err
    if unit == "N/m" and force == F_M:
        assert "a unit slip, N/mm data labelled N/m?" in err


def test_a_borderline_stiffness_deflection_is_warned_and_a_plausible_one_is_not(tmp_path, capsys):
    """A deflection F_m/k0 100 to 1000 times the file's largest STE runs, with a warning; the
    same samples in their own unit (N/mm) run without one."""
    _unit_slip_files(tmp_path, "N/m")
    f = tmp_path / "s.yaml"
    f.write_text(study(typed_whine().replace(str(F_M), "50")
                       + "  excitation: {file: ltca.csv, harmonics: 3}\n"), encoding="utf-8")
    with warnings.catch_warnings():
        warnings.simplefilter("always")  # shown as one line by the CLI
        assert main(["validate", str(f)]) == 0
    err = capsys.readouterr().err
    assert ("gearsweep: warning: ltca.csv: the fitted mean of column 'mesh_stiffness' [N/m] is"
            " 3e+05 N/m") in err and "278 times the file's largest STE sample" in err, err
    _unit_slip_files(tmp_path, "N/mm")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert main(["validate", str(f)]) == 0
    assert "warning" not in capsys.readouterr().err


def _refused_in_one_line(tmp_path, capsys, message: str) -> Path:
    """A whine study on ``ltca.csv`` (typed stiffness, 3 harmonics), which ``gearsweep
    validate`` refuses in one line naming the study and holding ``message``; the study's path."""
    f = tmp_path / "s.yaml"
    f.write_text(study(typed_whine("  stiffness: 200 kN/mm\n  excitation: {file: ltca.csv,"
                                   " harmonics: 3}\n")), encoding="utf-8")
    assert main(["validate", str(f)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(f) in err and message in err, err
    return f


@pytest.mark.parametrize(("header", "positions", "message"), [
    ("angle [deg]", np.arange(64) * 360.0 / 25 / 64,
     ("scene.teeth: 20 -- the 64 evenly spaced samples of excitation.file cover 14.4 deg, less than"
     " the 18 deg of one mesh cycle of 20 teeth, leaving 17 spacings between the last and the"
     " first a period later (at most 1.5): samples of a 25-tooth gear's mesh cycle, not the"
     " scene's 20 teeth, or the angle's unit?")),
    ("angle [deg]", np.radians(np.arange(64) * 18.0 / 64), "radians written as deg?"),
    ("mesh_phase [1]", np.arange(64) * 0.9 / 64,
     "cover 0.9 mesh cycles, less than the 1 of one mesh cycle of 20 teeth, leaving 8.11 spacings"),
])
def test_evenly_spaced_samples_over_less_than_the_period_are_refused(tmp_path, capsys, header,
                                                                      positions, message):
    """A cycle of a 25-tooth gear written in degrees for a scene of 23 teeth spans 0.92 of its
    cycle, and was fitted as if periodic (order 3 off by 32 %: an outside tester): evenly spaced
    samples whose closing gap is several spacings are refused, naming the span, the period and
    the likely cause; unevenly spaced ones over the whole cycle still run."""
    phi = np.arange(64) / 64
    write_csv(tmp_path / "ltca.csv", f"{header}, ste [um]",
              zip(positions, series(3.0, [(1.0, 1, 0.2)], phi), strict=True))
    f = _refused_in_one_line(tmp_path, capsys, message)
    uneven = np.sort(np.random.default_rng(3).uniform(0.0, 1.0, 64))
    write_csv(tmp_path / "ltca.csv", "mesh_phase [1], ste [um]",
              zip(uneven, series(3.0, [(1.0, 1, 0.2)], uneven), strict=True))
    assert main(["validate", str(f)]) == 0


@pytest.mark.parametrize(("last", "message"), [
    ([(0.140625, 5.5), (0.140625, 6.0)], ("lines 12 and 13: two samples at mesh_phase 0.140625 with"
     " ste 5.5 and 6 um: keep one")),
    ([(1.0, 6.0)], "line 67, a period after line 3, repeats it with ste 6 and 3 um"),
])
def test_conflicting_samples_at_one_position_or_a_period_apart_are_refused(tmp_path, capsys,
                                                                           last, message):
    """Two samples at one mesh phase with different STE were averaged by the fit, and a closing
    sample (mesh phase 1) 3 um above the first was dropped without a word (an outside tester):
    both are refused, naming the lines. A closing sample equal to the first still runs."""
    phi = np.arange(64) / 64
    rows = [(p, v) for p, v in zip(phi, series(3.0, [(1.0, 1, 0.0)], phi + 0.25), strict=True)]
    rows = sorted(rows + last) if last[0][0] < 1 else rows + last
    if last[0][0] < 1:
        rows.remove((0.140625, float(series(3.0, [(1.0, 1, 0.0)], 0.140625 + 0.25))))
    write_csv(tmp_path / "ltca.csv", "mesh_phase [1], ste [um]", rows)
    f = _refused_in_one_line(tmp_path, capsys, message)
    clean = list(zip(phi, series(3.0, [(1.0, 1, 0.0)], phi + 0.25), strict=True))
    write_csv(tmp_path / "ltca.csv", "mesh_phase [1], ste [um]", [*clean, (1.0, clean[0][1])])
    assert main(["validate", str(f)]) == 0


def test_a_negative_constant_stiffness_and_a_nan_in_netcdf_are_said_where(tmp_path, capsys):
    """A rattle scene's negative stiffness samples were refused 'at mesh phase nan', and a NaN in
    a netCDF file as 'every sample must be a finite number' (an outside tester): the mean, the
    least sample and its mesh phase; the variable and the index."""
    phi = np.arange(64) / 64
    k = -series(K0, K_H, phi)
    with pytest.raises(FitError, match=r"not positive \(a mean of -2e\+08 N/m; the least sample"
                                       r" -2.306e\+08 N/m at mesh phase 0.766\)"):
        measured_excitation(phi, None, k, fit_orders(2, 48, False), time_varying=False,
                            mean_force=F_M)
    path = _ltca_netcdf(tmp_path / "ltca.nc", {"ste": "ste", "stiffness": "mesh_stiffness"})
    with xr.open_dataset(path) as ds:
        ds = ds.load()
    ds["ste"][5] = np.nan
    ds.to_netcdf(path)
    f = tmp_path / "s.yaml"
    f.write_text(study(typed_whine("  excitation: {file: ltca.nc, harmonics: 3}\n")),
                 encoding="utf-8")
    assert main(["validate", str(f)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(f) in err and ("variable 'ste': its value at index"
                                                            " 5 is nan, not a finite number") in err, err


@pytest.mark.parametrize("sweep", ["  mean_force: [900 N, 1800 N]\n",
                                   "  torque: [40 N*m, 80 N*m]\n"])
def test_a_rattle_scene_with_a_measured_ste_sweeps_no_load(tmp_path, capsys, sweep):
    """A rattle scene swept torque or mean_force keeping one load's measured STE, where a whine
    scene refuses the sweep (an outside tester): refused the same way; its stiffness (a
    typed-in k0, which e = STE does not depend on) may still be swept."""
    whine_files(tmp_path)
    f = tmp_path / "s.yaml"
    scene = ("  kind: rattle\n  teeth: 20\n  mass: 0.2 kg\n  damping: 2 N*s/mm\n"
             "  backlash: 100 um\n  base_radius: 40 mm\n  excitation: {file: ltca.csv, harmonics: 3}\n")
    f.write_text(study(scene, "sweep:\n  speed: [1000 rpm]\n" + sweep), encoding="utf-8")
    assert main(["validate", str(f)]) == 2
    err = capsys.readouterr().err.strip()
    name = sweep.split(":")[0].strip()
    assert len(err.splitlines()) == 1 and str(f) in err and (
        f"sweep.{name}: a measured STE holds for its load: one study per load") in err, err

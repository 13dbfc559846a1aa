"""From a gear pair in YAML to the dynamics and to mesh-study netCDF files; CLI errors (exit 2)."""

import math
import re
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from numpy.testing import assert_allclose
from scipy.integrate import solve_ivp

from gearsweep.cli import main
from gearsweep.errors import GeometryError, StudyError
from gearsweep.gear import GearPair, TipRelief, table1_consistent
from gearsweep.gear.excitation import gear_excitation
from gearsweep.gear.mesh import fourier_series, mesh_cycle, mesh_cycles
from gearsweep.kernels import simulate
from gearsweep.model import RPM, kernel_inputs
from gearsweep.study.plan import build_model
from gearsweep.study.schema import parse_study
from gearsweep.units import si_values

STUDIES = Path(__file__).resolve().parent.parent / "studies"


def whine(gear: str, extra: str = "", kind: str = "whine") -> str:
    """A small dynamic study whose scene has ``gear: <gear>`` (and ``extra`` scene lines)."""
    backlash = "  backlash: 0.5 mm\n" if kind == "rattle" else ""
    return (f"title: gear scene\nscene:\n  kind: {kind}\n  gear: {gear}\n  mass: 0.1527 kg\n"
            f"  damping: 5.5 N*s/mm\n{backlash}{extra}"
            "sweep:\n  speed: [1000 rpm, 2000 rpm]\n")


def single_contact_relief(pair: GearPair, amount: float) -> tuple[TipRelief, TipRelief]:
    """Linear relief of both gears from where single-tooth contact ends on each flank."""
    xi1 = (pair.s_start + pair.base_pitch) / pair.base_radius1
    xi2 = (pair.line_of_action_length - (pair.s_end - pair.base_pitch)) / pair.base_radius2
    return TipRelief(amount, start_roll_angle=xi1), TipRelief(amount, start_roll_angle=xi2)


# --------------------------------------------------------------------------- YAML -> model


def test_gear_line_gives_the_mesh_cycle_coefficients():
    """k0, k_n, a_n, N1, r_b1 and F_m of ``gear: table1_consistent`` are mesh_cycle's (to 1e-12:
    the same numbers through a different path), and e(t) of the time-varying-stiffness scene is
    STE - F/k(phase), which vanishes for unmodified error-free teeth."""
    study = parse_study(whine("table1_consistent", "  torque: 50 N*m\n  harmonics: 6\n"))
    model = build_model(study)
    pair = table1_consistent()
    mc = mesh_cycle(pair, 50.0, n=200, harmonics=6)
    k_amp, k_ph = mc.quadrature.fourier(mc.quadrature.mesh_stiffness)
    assert model.teeth == 48
    assert model.base_radius == pytest.approx(pair.base_radius1, rel=1e-15)
    assert model.mean_force == pytest.approx(50.0 / pair.base_radius1, rel=1e-15)
    assert model.stiffness == pytest.approx(k_amp[0], rel=1e-12)
    assert [h.order for h in model.stiffness_harmonics] == [1, 2, 3, 4, 5, 6]
    assert_allclose([h.amplitude for h in model.stiffness_harmonics], k_amp[1:], rtol=1e-12)
    assert_allclose([h.phase for h in model.stiffness_harmonics], k_ph[1:], rtol=1e-12)
    # No relief, no error: STE = F / k exactly, so e(t) = 0 to round-off (1e-9 of the STE).
    assert max(h.amplitude for h in model.ste_harmonics) < 1e-9 * mc.ste.mean()


def test_mean_force_gives_the_same_load_as_torque():
    pair = table1_consistent()
    force = 50.0 / pair.base_radius1
    by_force = build_model(parse_study(whine("table1_consistent", f"  mean_force: {force!r} N\n")))
    by_torque = build_model(parse_study(whine("table1_consistent", "  torque: 50 N*m\n")))
    assert by_force.stiffness == pytest.approx(by_torque.stiffness, rel=1e-12)
    assert by_force.mean_force == pytest.approx(force, rel=1e-12)


def test_rattle_gear_scene_has_constant_k0_and_the_loaded_ste():
    """Eq. (13): constant stiffness k0, so e(t) is the loaded STE itself (harmonics 1..n)."""
    study = parse_study(whine("table1_consistent", "  torque: 50 N*m\n", kind="rattle"))
    model = build_model(study)
    arrays = mesh_cycle(table1_consistent(), 50.0, harmonics=10).as_arrays()
    e_amp, e_ph = arrays["ste_harmonic"], arrays["ste_phase"]
    assert model.stiffness_harmonics == ()
    assert model.stiffness == pytest.approx(arrays["k_harmonic"][0], rel=1e-12)
    assert_allclose([h.amplitude for h in model.ste_harmonics], e_amp[1:], rtol=1e-12)
    assert_allclose([h.phase for h in model.ste_harmonics], e_ph[1:], rtol=1e-12)


def test_gear_fields_with_units_and_tip_relief():
    """A mapping of GearPair fields in YAML units, and a preset with a relief, match direct calls."""
    study = parse_study(whine("{module: 2 mm, z1: 20, z2: 40, face_width: 20 mm, x1: 0.1}",
                              "  torque: 20 N*m\n  harmonics: 3\n"))
    mc = mesh_cycle(GearPair(module=2e-3, z1=20, z2=40, face_width=20e-3, x1=0.1), 20.0,
                    harmonics=3)
    assert build_model(study).stiffness == pytest.approx(mc.as_arrays()["k_harmonic"][0],
                                                         rel=1e-12)

    relief = "{preset: table1_consistent, tip_relief: {amount: 6 um, start_at: single_contact}}"
    study = parse_study(whine(relief, "  torque: 50 N*m\n", kind="rattle"))
    pair = table1_consistent()
    mc = mesh_cycle(pair, 50.0, tip_relief=single_contact_relief(pair, 6e-6), harmonics=10)
    e_amp = mc.as_arrays()["ste_harmonic"]
    assert_allclose([h.amplitude for h in build_model(study).ste_harmonics], e_amp[1:],
                    rtol=1e-12)
    # The relief designed for 50 N m removes most of the first STE harmonic (1.34 -> 0.21 um).
    assert e_amp[1] < 0.2 * mesh_cycle(pair, 50.0).as_arrays()["ste_harmonic"][1]

    # Relief of the driven gear only, its start given as a diameter.
    relief = ("{preset: table1_consistent, tip_relief: {amount: 4 um, shape: parabolic,"
              " start_diameter: 82 mm, gears: driven}}")
    study = parse_study(whine(relief, "  torque: 50 N*m\n", kind="rattle"))
    mc = mesh_cycle(pair, 50.0, tip_relief=(None, TipRelief(4e-6, start_diameter=82e-3,
                                                            shape="parabolic")), harmonics=10)
    assert_allclose([h.amplitude for h in build_model(study).ste_harmonics],
                    mc.as_arrays()["ste_harmonic"][1:], rtol=1e-12)


def test_whine_gear_scene_integrates_to_an_independent_ode_solution():
    """The whole chain YAML -> model -> kernel against scipy's solve_ivp of Eq. (6) written from
    the mesh cycle directly: m p'' + c p' + k(t) p = F - m e''(t), k and e the 10-harmonic
    series of k(phase) and STE - F/k(phase) with tip relief (so e is not zero), at 6000 rpm
    (mesh 4800 Hz, near the 6030 Hz natural frequency, where phases of k and e matter).
    RK4 at 256 steps per period: omega_n h = 0.03 and the 10th harmonic advances 0.25 rad
    per step; measured difference 4e-7 of p_pp, tolerance 1e-4 of p_pp (a 0.1 rad phase error
    of k alone gives 6e-2, an e(t) of the wrong sign 2)."""
    relief = "{preset: table1_consistent, tip_relief: {amount: 6 um, start_at: single_contact}}"
    study = parse_study(whine(relief, "  torque: 50 N*m\n"))
    model = build_model(study)
    spp, n_tr = 256, 10  # transient: zeta = 0.47 decays e^-3.7 per mesh period
    kin = kernel_inputs(model, {"speed": np.array([6000.0])}, 1, spp)
    res = simulate(method="rk4", n_transient=n_tr * spp, n_record=spp, steps_per_period=spp,
                   signal_stride=1, **kin)
    p_kernel = res.signal[0]

    pair = table1_consistent()
    mc = mesh_cycle(pair, 50.0, tip_relief=single_contact_relief(pair, 6e-6), harmonics=10)
    q = mc.quadrature
    k_a, k_p = q.fourier(q.mesh_stiffness)
    e_a, e_p = q.fourier(q.ste - mc.load / q.mesh_stiffness)
    n = np.arange(11)
    f_mesh = 48 * 6000.0 * RPM / (2 * math.pi)
    m, c, force = 0.1527, 5.5e3, mc.load

    def rhs(t, y):
        phi = f_mesh * t
        k = np.sum(k_a * np.cos(2 * np.pi * n * phi + k_p))
        e_dd = -np.sum(e_a[1:] * (2 * np.pi * n[1:] * f_mesh) ** 2
                       * np.cos(2 * np.pi * n[1:] * phi + e_p[1:]))
        return [y[1], (force - m * e_dd - c * y[1] - k * y[0]) / m]

    # Kernel sample r of the record is the state after step n_tr * spp + r.
    t = (n_tr * spp + np.arange(spp) + 1) / (spp * f_mesh)
    ref = solve_ivp(rhs, (0.0, t[-1]), [0.0, 0.0], method="DOP853", t_eval=t, rtol=1e-10,
                    atol=1e-16, max_step=1 / (16 * f_mesh)).y[0]
    assert np.ptp(e_a[1:]) > 1e-7  # e(t) is really there (relief): ~1.5 um first harmonic
    assert_allclose(p_kernel, ref, atol=1e-4 * np.ptp(ref))


# --------------------------------------------------------------------------- refusals


def _run_cli(tmp_path, capsys, text: str, command: str = "validate") -> tuple[int, str, str]:
    path = tmp_path / "study.yaml"
    path.write_text(textwrap.dedent(text))
    argv = [command, str(path)] + (["-o", str(tmp_path / "out.nc"), "-q"] if command == "run" else [])
    rc = main(argv)
    out, err = capsys.readouterr()
    return rc, out, err


BAD_GEARS = {  # the gear (flow style, on line 4), the field each problem is at, what it says
    "table1_as_printed": ("table1_as_printed",
                          [("scene.gear", "Table 1 as printed: tip-root interference"),
                           ("scene.gear", ("Table 1 as printed: contact ratio 2.429 is outside the"
                            " stated range [1, 2]")),
                           ("scene.gear", "thickness and backlash cannot coexist")]),
    "tip_root": ("{module: 2 mm, z1: 20, z2: 40, face_width: 20 mm, tip_radius1: 23.5 mm}",
                 [("scene.gear.tip_radius1: '23.5 mm'",
                   "tip-root interference: tip radius of gear 1 (23.5 mm)")]),
    "undercut": ("{module: 2 mm, z1: 8, z2: 40, face_width: 20 mm}",
                 [("scene.gear.z1: 8", "undercut: gear 1 (z = 8")]),
    "pointed": ("{module: 2 mm, z1: 12, z2: 40, face_width: 20 mm, x1: 1.2}",
                [("scene.gear.x1: 1.2", "pointed teeth: gear 1")]),
    "thickness": (("{module: 2 mm, z1: 20, z2: 40, face_width: 20 mm, thickness1: 4 mm,"
                  " thickness2: 3 mm, backlash: 0.1 mm}"),
                  [("scene.gear.backlash: '0.1 mm'", "cannot coexist")]),
    "contact_ratio": (("{module: 2 mm, z1: 20, z2: 40, face_width: 20 mm, tip_radius1: 20.6 mm,"
                      " tip_radius2: 40.6 mm}"),
                      [("scene.gear.tip_radius2: '40.6 mm'", "contact ratio 0.552 is below 1")]),
    "relief": ("{preset: table1_consistent, tip_relief: {amount: 5 um, start_radius: 10 mm}}",
               [("scene.gear.tip_relief.start_radius: '10 mm'",
                 "tip relief start radius 10 mm of gear 1 must lie between base")]),
}


@pytest.mark.parametrize("name", list(BAD_GEARS))


def test_bad_geometry_is_one_line_a_problem_at_its_field_and_exit_2(tmp_path, capsys, name):
    """``gearsweep validate`` (not only ``run``) refuses every inconsistent geometry, one line a
    problem, each naming the file, the field it is about (the gear where the file writes none of
    those: a preset's) and the problem."""
    gear, expected = BAD_GEARS[name]
    rc, out, err = _run_cli(tmp_path, capsys, whine(gear, "  torque: 50 N*m\n"))
    assert rc == 2 and out == ""
    lines = err.splitlines()
    where = str(tmp_path / "study.yaml")
    assert all(line.startswith(f"gearsweep: error: {where}:4: scene.gear") for line in lines), err
    for field, fragment in expected:
        assert any(line.startswith(f"gearsweep: error: {where}:4: {field}") and fragment in line
                   for line in lines), (field, fragment, err)


def test_run_refuses_table1_as_printed_before_computing(tmp_path, capsys):
    rc, _, err = _run_cli(tmp_path, capsys, whine("table1_as_printed", "  torque: 50 N*m\n"),
                          command="run")
    assert rc == 2 and "tip-root interference" in err and err.count("\n") == 4  # one a problem
    assert not (tmp_path / "out.nc").exists()


def test_mesh_study_refuses_table1_as_printed(tmp_path, capsys):
    text = "type: mesh\ntitle: t\ngears:\n  printed: table1_as_printed\ntorque: 50 N*m\n"
    rc, _, err = _run_cli(tmp_path, capsys, text)
    assert rc == 2 and err.count("\n") == 4
    assert ":4: gears.printed: Table 1 as printed: tip-root interference" in err


@pytest.mark.parametrize("extra, message", [
    ("  torque: 50 N*m\n  stiffness_harmonics: [{amplitude: 179 kN/mm}]\n",
     "need 'stiffness' too"),  # a typed-in k(t) beside a gear replaces the pair's as a whole
    ("  torque: 50 N*m\n  ste: [{amplitude: 5 um}]\n", "give either 'gear' or typed-in ste"),
    ("  torque: 50 N*m\n  teeth: 48\n", "give either 'gear' or typed-in teeth"),
    ("  torque: 50 N*m\n  base_radius: 56 mm\n", "typed-in base_radius"),
])


def test_gear_with_typed_in_coefficients_is_refused(tmp_path, capsys, extra, message):
    """At the typed-in field's line (line 8), the one to leave out (was the scene's, line 2)."""
    rc, _, err = _run_cli(tmp_path, capsys, whine("table1_consistent", extra))
    assert rc == 2 and err.count("\n") == 1
    field = extra.splitlines()[1].split(":")[0].strip()
    assert f"study.yaml:8: scene.{field}: " in err and message in err


@pytest.mark.parametrize("typed, message", [
    ("teeth: 48", "give either 'gear' or typed-in teeth"),
    ("ste: [{amplitude: 5 um}]", "give either 'gear' or typed-in ste"),
    ("base_radius: 56 mm", "typed-in base_radius"),
    ("stiffness_harmonics: [{amplitude: 179 kN/mm}]", "need 'stiffness' too"),
])
def test_gear_written_after_typed_in_coefficients_is_the_line_refused(tmp_path, capsys, typed,
                                                                      message):
    """A clash between 'gear' and a typed-in field is said at the later written of the two (the
    README's rule): with the typed-in field on line 4 and the gear on line 7 it was said at line 4
    (an outside tester's finding); it is at the gear's line."""
    text = whine("table1_consistent", "  torque: 50 N*m\n").replace(
        "  gear: table1_consistent\n", f"  {typed}\n").replace(
        "  torque: 50 N*m\n", "  torque: 50 N*m\n  gear: table1_consistent\n")
    assert text.splitlines()[3] == f"  {typed}" and text.splitlines()[7].strip().startswith("gear")
    rc, _, err = _run_cli(tmp_path, capsys, text)
    assert rc == 2 and err.count("\n") == 1, err
    assert "study.yaml:8: scene.gear: 'table1_consistent' -- " in err and message in err, err


def test_gear_without_a_load_is_refused(tmp_path, capsys):
    rc, _, err = _run_cli(tmp_path, capsys, whine("table1_consistent"))
    assert rc == 2 and err.count("\n") == 1
    assert ": scene.torque: '(missing)' -- a 'gear' needs the mean load" in err


def test_gear_scene_sweeps_torque_with_k_and_ste_recomputed_per_load():
    """A torque sweep of a gear scene gives, at each load, exactly the study run at that load
    alone (its own k(t) and e(t)), and the result shows each load's k0 and harmonics."""
    from gearsweep.api import run

    loads = (10.0, 50.0, 120.0)
    swept = run(whine("table1_consistent", "  harmonics: 4\n", kind="rattle")
                + f"  torque: [{loads[0]} N*m, {loads[1]} N*m, {loads[2]} N*m]\n")
    assert swept.p_rms.dims == ("speed", "torque")
    e1 = swept.gear_ste_harmonic.sel(harmonic=1).values
    assert e1[0] < e1[1] < e1[2]  # the loaded STE grows with the load
    pair = table1_consistent().check()  # the pair's geometry is in the result too
    assert float(swept.gear_contact_ratio) == pytest.approx(pair.contact_ratio, rel=1e-14)
    assert float(swept.gear_base_radius_1) == pytest.approx(pair.base_radius1 * 1e3, rel=1e-14)
    for i, t in enumerate(loads):
        one = f"  harmonics: 4\n  torque: {t} N*m\n"
        alone = run(whine("table1_consistent", one, kind="rattle"))
        assert_allclose(swept.p_rms.isel(torque=i).values, alone.p_rms.values, rtol=1e-13)
        model = build_model(parse_study(whine("table1_consistent", one, kind="rattle")))
        assert si_values(swept.gear_stiffness)[i] == pytest.approx(model.stiffness, rel=1e-14)
        assert e1[i] == pytest.approx(model.ste_harmonics[0].amplitude * 1e6, rel=1e-14)  # um


def test_gear_scene_refuses_a_stiffness_sweep():
    text = whine("table1_consistent", "  torque: 50 N*m\n") + "  stiffness: [1 kN/mm, 2 kN/mm]\n"
    with pytest.raises(StudyError, match=r"sweep.stiffness: .*a gear scene computes its stiffness"):
        parse_study(text)


def test_drive_radii_must_match_the_gear():
    text = whine("table1_consistent", "  torque: 50 N*m\n").replace(
        "  mass: 0.1527 kg\n", "  drive: {inertia_1: 1e-3 kg*m**2, inertia_2: 1e-3 kg*m**2,"
        " base_radius_1: 60 mm, base_radius_2: 40 mm}\n")
    with pytest.raises(StudyError, match=r"scene.drive.base_radius_1: '60 mm' -- the gear's"
                                         r" base radius 56.3816 mm"):
        parse_study(text)


def test_geometry_error_is_a_gearsweep_error_raised_by_parse_study():
    """A study's impossible gear pair is a ``StudyError`` (its problems at their lines) and still
    the ``GeometryError`` it was, for code that catches that."""
    for text in (whine("table1_as_printed", "  torque: 50 N*m\n"),
                 "type: mesh\ntitle: t\ngear: table1_as_printed\ntorque: 50 N*m\n"):
        with pytest.raises(GeometryError, match=r"^<study>:\d+: (scene.)?gear: Table 1 as"
                           r" printed: ") as err:
            parse_study(text)
        assert isinstance(err.value, StudyError) and len(err.value.lines) == 4


# --------------------------------------------------------------------------- mesh studies

MESH_UNITS = {"ste": "um", "load_share": "1", "mesh_stiffness": "kN mm-1",
              "k_harmonic": "kN mm-1", "k_phase": "rad", "ste_harmonic": "um", "ste_phase": "rad"}


def test_mesh_study_netcdf_has_data_md_names_dims_units_and_mesh_cycle_values(tmp_path, capsys):
    """``gearsweep run`` of a ``type: mesh`` study: docs/data-format.md names, dims and units; the values are
    those of mesh_cycles called directly (to round-off); the file opens with no arguments."""
    text = """\
        type: mesh
        title: two variants, three torques
        gears:
          plain: table1_consistent
          relieved: {preset: table1_consistent, tip_relief: {amount: 6 um, start_at: single_contact}}
        sweep:
          torque: [10 N*m, 50 N*m, 100 N*m]
        positions: 64
        harmonics: 5
        """
    rc, out, err = _run_cli(tmp_path, capsys, text, command="run")
    assert rc == 0 and err == ""
    with xr.open_dataset(tmp_path / "out.nc") as ds:
        for name, unit in MESH_UNITS.items():
            assert ds[name].attrs["units"] == unit, name
        assert ds["ste"].dims == ("variant", "torque", "mesh_phase")
        assert ds["mesh_stiffness"].dims == ("variant", "torque", "mesh_phase")
        assert ds["load_share"].dims == ("variant", "torque", "mesh_phase", "pair")
        for name in ("k_harmonic", "k_phase", "ste_harmonic", "ste_phase"):
            assert ds[name].dims == ("variant", "torque", "harmonic")
        assert ds["torque"].attrs["units"] == "N m"
        assert list(ds["torque"].values) == [10.0, 50.0, 100.0]
        assert list(ds["variant"].values) == ["plain", "relieved"]
        assert list(ds["harmonic"].values) == list(range(6))
        phase = ds["mesh_phase"].values
        assert phase.size == 64 and phase.min() == 0.0 and phase.max() < 1.0
        assert ds.attrs["Conventions"] == "CF-1.10" and "type: mesh" in ds.attrs["study"]
        stamp = r"\d{4}-\d\d-\d\dT[\d:]+Z: .* \(gearsweep \S+( commit [0-9a-f]{12})?, numba "
        assert ds.attrs["study_sha256"] and re.match(stamp, ds.attrs["history"])
        pair = table1_consistent()
        for variant, relief in (("plain", None), ("relieved", single_contact_relief(pair, 6e-6))):
            cycles = mesh_cycles(pair, [10.0, 50.0, 100.0], n=64, tip_relief=relief, harmonics=5)
            for q, mc in enumerate(cycles):
                v = ds.sel(variant=variant).isel(torque=q)
                assert_allclose(si_values(v["ste"]), mc.ste, rtol=1e-12)  # the file: um
                assert_allclose(v["load_share"].values, mc.load_share, rtol=1e-12)
                arrays = mc.as_arrays()
                assert_allclose(si_values(v["k_harmonic"]), arrays["k_harmonic"], rtol=1e-12)
                assert_allclose(si_values(v["ste_harmonic"]), arrays["ste_harmonic"], rtol=1e-12)
                # The stored Fourier series reproduces the stored STE to the truncation error:
                # a jump J cut at N = 5 harmonics leaves an rms of J / (pi sqrt(2 N)) = 0.10 J
                # (measured 0.12-0.14 of the STE's peak-to-peak unmodified, where the STE jumps
                # by about its peak-to-peak; a wrong phase convention leaves 0.6-0.7).
                e = fourier_series(si_values(v["ste_harmonic"]), v["ste_phase"].values, phase)
                assert np.sqrt(np.mean((e - si_values(v["ste"])) ** 2)) < 0.2 * np.ptp(mc.ste)
    assert main(["inspect", str(tmp_path / "out.nc")]) == 0
    assert "static mesh study, 64 positions per mesh cycle" in capsys.readouterr().out


def test_mesh_study_harmonics_do_not_depend_on_its_positions():
    """A mesh study's k_harmonic and ste_harmonic come from the mesh cycle's quadrature, not from
    its uniform positions: 8 and 400 positions give the same numbers (to round-off). The DFT of
    16 positions had k_0 2 % and k_1 9 % off (and 1/N convergence)."""
    from gearsweep.api import run_study

    def harmonics(positions: int) -> xr.Dataset:
        study = parse_study("type: mesh\ntitle: t\ngear: table1_consistent\ntorque: 50 N*m\n"
                            f"positions: {positions}\nharmonics: 8\n")
        return run_study(study)[["k_harmonic", "k_phase", "ste_harmonic", "ste_phase"]]

    coarse, fine = harmonics(8), harmonics(400)  # (8 positions were refused for 8 harmonics)
    for name in coarse.data_vars:
        assert_allclose(coarse[name].values, fine[name].values, rtol=1e-12, atol=1e-12)


def test_single_torque_mesh_study_has_no_torque_dim():
    from gearsweep.api import run_study

    study = parse_study("type: mesh\ntitle: t\ngear: table1_consistent\ntorque: 50 N*m\n"
                        "positions: 50\nharmonics: 3\n")
    ds = run_study(study)
    assert ds["ste"].dims == ("mesh_phase",)
    assert ds["load_share"].dims == ("mesh_phase", "pair")
    assert float(ds["torque"]) == 50.0 and ds["torque"].dims == ()
    assert si_values(ds["k_harmonic"])[0] == pytest.approx(
        mesh_cycle(table1_consistent(), 50.0, n=50, harmonics=3).as_arrays()["k_harmonic"][0],
        rel=1e-12)


@pytest.mark.parametrize("text, message", [
    ("type: mesh\ntitle: t\ngear: table1_consistent\n", "give exactly one of 'torque' and"),
    ("type: mesh\ntitle: t\ntorque: 5 N*m\n", "give exactly one of 'gear' (one pair) and 'gears'"),
    ("type: mesh\ntitle: t\ngear: table1_consistent\ntorque: 5 N*m\nsweep: {torque: [2 N*m]}\n",
     "s.yaml:5: sweep.torque: ['2 N*m'] -- a torque swept or given, not both (torque: '5 N*m'"),
    ("type: mesh\ntitle: t\ngear: table1_consistent\ntorque: 5 N*m\nharmonics: 101\n",
     "s.yaml:5: harmonics: 101 -- "),
    ("type: mesh\ntitle: t\ngear: table1_consistent\nsweep: {torque: [-5 N*m]}\n",
     "s.yaml:4: sweep.torque[0]: '-5 N*m' -- a positive torque"),
    ("type: meshes\ntitle: t\n", "'mesh' (a static mesh study)"),
])


def test_mesh_study_problems_are_one_study_error(text, message):
    with pytest.raises(StudyError, match=None) as info:
        parse_study(text, "s.yaml")
    assert message in str(info.value)


@pytest.mark.parametrize("path", sorted([*STUDIES.glob("*.yaml"), *STUDIES.glob("heavy/*.yaml")]),
                         ids=lambda p: p.stem)


def test_every_study_file_validates(path, capsys):
    assert main(["validate", str(path)]) == 0
    assert capsys.readouterr().out.startswith(f"{path}: ok -- ")


def test_scene_without_gear_still_needs_teeth_and_stiffness():
    with pytest.raises(StudyError, match=r"scene: '\{...\}' -- 'stiffness' required \(or a 'gear'"):
        parse_study("title: t\nscene: {kind: whine, mass: 1 kg, teeth: 20}\nsweep: {speed: [100]}\n")
    with pytest.raises(StudyError, match=r"'harmonics' is the number of Fourier terms of a 'gear'"):
        parse_study("title: t\nscene: {kind: whine, mass: 1 kg, teeth: 20, stiffness: 1e8 N/m,"
                    " harmonics: 3}\nsweep: {speed: [100]}\n")


def test_gear_scene_with_typed_in_stiffness_keeps_the_pairs_loaded_ste_and_phases():
    """``stiffness`` (and ``stiffness_harmonics``) beside a ``gear`` replace the pair's k(t);
    e(t) is then the pair's loaded STE, and a k_n without a phase keeps the pair's phase."""
    text = ("title: t\nscene: {kind: whine, gear: table1_consistent, harmonics: 4, torque: 50 N*m,"
            " mass: 0.1527 kg, damping: 5.5 N*s/mm, stiffness: 1073 kN/mm,"
            " stiffness_harmonics: [{amplitude: 179 kN/mm}, {amplitude: 40 kN/mm, phase: 0 rad}]}"
            "\nsweep: {speed: [3000 rpm]}\n")
    model = build_model(parse_study(text))
    pair = gear_excitation(table1_consistent(), 50.0, harmonics=4)
    assert model.stiffness == pytest.approx(1.073e9)
    assert [h.amplitude for h in model.stiffness_harmonics] == pytest.approx([1.79e8, 4.0e7])
    assert model.stiffness_harmonics[0].phase == pair.stiffness_harmonics[0].phase
    assert model.stiffness_harmonics[1].phase == 0.0  # typed
    assert model.ste_harmonics == pair.ste_harmonics  # the loaded STE, not STE - F/k(t)
    # the pair's own k(t) is another model (e(t) = STE - F / k(t), about zero for these teeth)
    own = build_model(parse_study(text.replace(", stiffness: 1073 kN/mm", "").replace(
        " stiffness_harmonics: [{amplitude: 179 kN/mm}, {amplitude: 40 kN/mm, phase: 0 rad}]",
        "").replace("damping: 5.5 N*s/mm,", "damping: 5.5 N*s/mm")))
    assert own.stiffness == pytest.approx(pair.stiffness)
    with pytest.raises(StudyError, match="need 'stiffness' too"):
        parse_study(text.replace(" stiffness: 1073 kN/mm,", ""))


def test_a_web_without_a_rim_is_refused():
    """``web_width1`` without ``rim_thickness1`` was ignored (ISO's rim factor takes both):
    refused in one line (an adversarial test)."""
    from gearsweep.errors import StudyError
    from gearsweep.study.schema import parse_study

    text = ("type: mesh\ntitle: w\ngear: {preset: table1_consistent, web_width1: 5 mm}\n"
            "torque: 50 N*m\n")
    with pytest.raises(StudyError, match=r"s.yaml:3: gear.web_width1: '5 mm' -- web_width1 needs"
                       r" rim_thickness1"):  # (the field, no longer the gear)
        parse_study(text, "s.yaml")
    parse_study(text.replace("web_width1: 5 mm", "web_width1: 5 mm, rim_thickness1: 8 mm"),
                "s.yaml")


def test_a_mesh_study_beyond_the_memory_limit_is_refused_at_once(tmp_path, capsys):
    """A mesh study of 1e7 torques validated "ok", then asked numpy for 14.9 GiB (a traceback;
    an adversarial test). Its peak memory (``study.mesh.memory_bytes``) is said by validate and
    beyond 2 GB refused by validate and run, before computing, unless --yes."""
    path = tmp_path / "m.yaml"
    path.write_text("type: mesh\ntitle: m\ngear: table1_consistent\n"
                    "sweep: {torque: {start: 1 N m, stop: 100 N m, num: 10000000}}\n")
    for command in (["validate", str(path)], ["run", str(path), "-o", str(tmp_path / "m.nc")]):
        t0 = time.perf_counter()
        assert main(command) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "refused (memory > 2 GB): peak memory about 400 GB" in err
        assert time.perf_counter() - t0 < 5
    assert main(["validate", str(STUDIES / "fig01_02_mesh_cycle.yaml")]) == 0
    assert "peak memory about 300 MB" in capsys.readouterr().out


def test_run_from_python_refuses_a_mesh_study_beyond_the_memory_limit_unless_yes(tmp_path,
                                                                                 monkeypatch):
    """``gearsweep.run`` refuses what ``gearsweep run`` refuses without --yes: a mesh study of
    1e7 torques (400 GB) went straight to computing (numpy's MemoryError, after a while)."""
    import gearsweep
    import gearsweep.api
    from gearsweep.errors import LimitError

    text = ("type: mesh\ntitle: m\ngear: table1_consistent\n"
            "sweep: {torque: {start: 1 N m, stop: 100 N m, num: 10000000}}\n")
    ran = []
    monkeypatch.setattr(gearsweep.api, "run_unchunked", lambda *a: ran.append(a))
    for output in (None, tmp_path / "m.nc"):
        with pytest.raises(LimitError, match=r"refused \(memory > 2 GB\): peak memory about 400"
                                             r" GB for mesh study.*; pass yes=True to go ahead$"):
            gearsweep.run(text, output=output)
    assert not ran
    gearsweep.run(text, yes=True)
    assert len(ran) == 1


def test_a_load_swept_gear_scene_with_a_spectrum_builds_each_loads_model_once(monkeypatch):
    """Each load's k(t) and e(t) is built once per plan. The spectrum's default sampling asks
    for the stiffest load's k0 (``outputs.resonant_order``), and the plan of each load (one
    kernel call per load) had a memo of its own: every load's model was built again for each
    load in each chunk, quadratic in the loads (an outside tester's 4 speeds x 300 torques were
    still running after 10 min; 2,353 builds for 48 torques). Truth of the numbers: a load run
    alone gives the same p_rms."""
    import gearsweep
    from gearsweep.study import plan as plan_module

    built = []
    real = plan_module.build_model

    def counted(study, torque=None):
        built.append(torque)
        return real(study, torque)

    monkeypatch.setattr(plan_module, "build_model", counted)
    loads = [10.0, 30.0, 50.0, 70.0, 90.0, 110.0]
    solver = ("solver: {steps_per_period: 64, transient_periods: 4, record_periods: 4}\n"
              "outputs: [stats, {spectrum: {max_order: 3}}]\n")
    sweep = "  torque: [" + ", ".join(f"{t} N*m" for t in loads) + "]\n"
    swept = gearsweep.run(whine("table1_consistent") + sweep + solver)
    per_load = [t for t in built if t is not None]
    assert sorted(per_load) == loads  # each load once; the plan's own model (None) besides
    assert len(built) == len(loads) + 1
    monkeypatch.setattr(plan_module, "build_model", real)
    alone = gearsweep.run(whine("table1_consistent", "  torque: 70 N*m\n") + solver)
    assert_allclose(swept.p_rms.sel(torque=70.0).values, alone.p_rms.values, rtol=1e-13)


@pytest.mark.parametrize("continued", [False, True])


def test_a_load_swept_gear_scene_whose_first_cases_the_guard_skips_runs(continued):
    """step_guard: skip with a gear scene that sweeps its load, the first speed beyond the step
    limit of 40 RK4 steps per mesh period: its cases are skipped (status 3), the others run.
    Before, the warm-up's one case (skipped: no loads left to merge) ended in an IndexError
    traceback. (Posed at 16 steps, 1000 and 10000 rpm until a gear's 10 harmonics were held to
    4 steps each, plan.STEPS_PER_HARMONIC: 40 steps at 400 and 4000 rpm are the same steps.)"""
    import gearsweep

    study = {
        "title": "skip at the first speed",
        "scene": {"kind": "full", "gear": "table1_consistent", "harmonics": 10,
                  "drive": {"inertia_1": "1.5981e-3 kg*m^2", "inertia_2": "3.1567e-4 kg*m^2",
                            "base_radius_1": "56.3816 mm", "base_radius_2": "37.5877 mm"},
                  "backlash": "0.4698 mm", "damping": "5.5 N*s/mm"},
        "sweep": {"torque": ["2 N*m", "8.9 N*m"], "speed": ["400 rpm", "4000 rpm"]},
        "solver": {"method": "rk4", "steps_per_period": 40, "step_guard": "skip",
                   "transient_periods": 4, "record_periods": 4},
        "outputs": ["stats", "floquet"],
    }
    if continued:
        study["continuation"] = ["up"]
    ds = gearsweep.run(study)
    status = ds.status.squeeze(drop=True)
    assert (status.sel(speed=400.0) == 3).all()  # 40 steps per period: beyond RK4's limit
    assert (status.sel(speed=4000.0) != 3).all()
    assert ds.p_rms.sel(speed=400.0).isnull().all()
    assert ds.p_rms.sel(speed=4000.0).notnull().all()
    # the skipped cases keep their step limit, each at its own load (NaN before)
    limit = ds.min_steps_per_period.squeeze(drop=True)
    assert limit.notnull().all() and (limit.sel(speed=400.0) > 40).all()


def test_step_guard_of_a_swept_load_judges_each_load_by_its_own_stiffness():
    """A relieved pair's k(t) changes with load (k0 163 kN/mm at 12.5 N m, 219 at 100 N m), so
    at 16 RK5 steps per period the step limit falls at 1034 rpm for one and 1119 rpm for the
    other. The guard judged every case by the first listed load's k(t): at 1080 rpm the 100 N m
    case was within the limit after 12.5 N m and the 12.5 N m case beyond it after 100 N m.
    Truth: each load in a study of its own; the counts of validate agree. (Posed at 40 steps
    and 0.4 x those speeds since a gear's 10 harmonics are held to 4 steps each,
    plan.STEPS_PER_HARMONIC: the same steps, the same verdicts.)"""
    import gearsweep
    from gearsweep.study.plan import cases_beyond_step_limit, make_plan

    def study(torques):
        return textwrap.dedent(f"""\
            title: guard per load
            scene:
              kind: whine
              gear: {{preset: table1_consistent,
                      tip_relief: {{amount: 6 um, shape: linear, start_at: single_contact}}}}
              harmonics: 10
              mass: 0.1527 kg
              damping: 5.5 N*s/mm
            sweep:
              speed: [400 rpm, 432 rpm, 480 rpm]
              torque: {torques}
            solver: {{method: rk5, steps_per_period: 40, transient_periods: 0,
                      record_periods: 2}}
            """)

    alone = {}
    for t in ("12.5 N*m", "100 N*m"):
        with pytest.warns(gearsweep.errors.StepLimitWarning):
            ds = gearsweep.run(study(f"[{t}]"))
        alone[float(ds.torque[0])] = ds.beyond_step_limit.isel(torque=0).values
    assert alone[100.0].tolist() == [True, True, False]  # the case the two loads judge apart
    assert alone[12.5].tolist() == [True, False, False]
    for order in ("[12.5 N*m, 100 N*m]", "[100 N*m, 12.5 N*m]"):
        text = study(order)
        with pytest.warns(gearsweep.errors.StepLimitWarning):
            ds = gearsweep.run(text)
        for t, want in alone.items():
            assert ds.beyond_step_limit.sel(torque=t).values.tolist() == want.tolist(), order
        assert cases_beyond_step_limit(make_plan(parse_study(text), text)) == 3


def test_advise_of_a_swept_load_takes_the_stiffest_load(tmp_path, capsys):
    """``advise`` reports omega_n 'at the largest stiffness'; for a relieved pair sweeping its
    load it took the first listed load's k(t): 4.491e4 rad/s for [12.5 N m, 100 N m], 4.813e4
    for [100 N m, 12.5 N m]. Truth: the advice for the stiffer load (100 N m) alone."""
    base = (STUDIES / "fig06_mean_torque_relief.yaml").read_text(encoding="utf-8")
    said = {}
    for order in ("[100 N*m]", "[12.5 N*m, 100 N*m]", "[100 N*m, 12.5 N*m]"):
        path = tmp_path / "s.yaml"
        path.write_text(base.replace("torque: [12.5 N*m, 25 N*m, 50 N*m, 100 N*m]",
                                     f"torque: {order}"))
        assert main(["advise", str(path), "--target", "1e-6"]) == 0
        flat = " ".join(capsys.readouterr().out.split())
        said[order] = re.search(r"omega_n = ([\d.e+-]+) rad/s and damping ratio ([\d.]+)",
                                flat).groups()
    assert said["[12.5 N*m, 100 N*m]"] == said["[100 N*m]"] == said["[100 N*m, 12.5 N*m]"]


@pytest.mark.parametrize(("lines", "said"), [
    ("  torque: 50 N*m\nsweep:\n  speed: [3000 rpm]\n", None),
    ("sweep:\n  speed: [3000 rpm]\n  torque: [50 N*m, -50 N*m]\n",
     "s.yaml:9: sweep.torque[1]: '-50 N*m'"),
    ("sweep:\n  speed: [3000 rpm]\n  torque: [50 N*m, 0 N*m]\n", "s.yaml:9: sweep.torque[1]: '0 N*m'"),
    ("sweep:\n  speed: [3000 rpm]\n  torque: {start: 0 N*m, stop: 50 N*m, num: 3}\n",
     "s.yaml:9: sweep.torque.start: '0 N*m'"),
    ("sweep:\n  speed: [3000 rpm]\n  mean_force: [800 N, -1 kN]\n",
     "s.yaml:9: sweep.mean_force[1]: '-1 kN'"),
    ("  mean_force: -800 N\nsweep:\n  speed: [3000 rpm]\n", "s.yaml:7: scene.mean_force: '-800 N'"),
])


def test_every_load_of_a_gear_scene_must_be_positive_in_one_line(lines, said):
    """A gear scene's k(t) and STE are the pair's under its load: only the first swept load was
    checked, so [50 N m, -50 N m] validated and the run stopped at the second load with 'the
    mean torque -50.0 N m must be positive to load the mesh', naming no file, line or field."""
    text = ("title: g\nscene:\n  kind: whine\n  gear: table1_consistent\n  mass: 0.1527 kg\n"
            "  damping: 5.5 N*s/mm\n" + lines)
    if said is None:
        parse_study(text, "s.yaml")
        return
    with pytest.raises(StudyError) as err:
        parse_study(text, "s.yaml")
    assert str(err.value) == (f"{said} -- a positive load: a gear scene's k(t) and STE are the"
                              " pair's under it, in the drive direction")


def test_a_tip_relief_of_more_than_a_tenth_of_a_module_is_refused(tmp_path, capsys):
    """'amount: 10 m' for '10 um' gave a largest STE of 2,482,897 um (an outside fuzz tester);
    more than 0.1 module (250 um for the Table 1 pair's 2.5 mm) is refused as a unit slip, on
    the gear's line; 250 um itself is taken."""
    text = (Path(__file__).resolve().parents[1] / "studies" / "mesh_tip_relief.yaml").read_text(
        encoding="utf-8")
    path = tmp_path / "r.yaml"
    for amount, code in (("10 m", 2), ("251 um", 2), ("250 um", 0)):
        path.write_text(re.sub(r"amount: 6 um", f"amount: {amount}", text), encoding="utf-8")
        assert main(["validate", str(path)]) == code
        err = capsys.readouterr().err
        if code:
            (line,) = err.strip().splitlines()
            assert "tip_relief.amount" in line and "at most 0.1 module (250 um here)" in line


def test_profile_shift_preset_is_the_pair_the_mesh_study_types_in():
    """The rig scene with Table 1's profile-shift reading (studies/rig_low_speed_profile_shift.yaml,
    Fig. 11: its order 2 / order 1 is 0.20-0.23, against 0.55-0.57 for the consistent reading)
    names the pair as a preset; studies/table1_profile_shift.yaml types its fields in. Both are
    one pair: the same k(t) and STE at 50 N m, to round-off."""
    from gearsweep.study.gearscene import gear_pair
    from gearsweep.study.schema import load_study

    root = Path(__file__).resolve().parent.parent / "studies"
    typed = gear_pair(load_study(root / "table1_profile_shift.yaml")[0].gear).check()
    preset = gear_pair(load_study(root / "rig_low_speed_profile_shift.yaml")[0].scene.gear).check()
    a, b = (gear_excitation(p, 50.0, (None, None), 10) for p in (typed, preset))
    assert b.stiffness == pytest.approx(a.stiffness, rel=1e-12)
    for x, y in ((a.stiffness_harmonics, b.stiffness_harmonics),
                 (a.ste_harmonics, b.ste_harmonics)):
        assert [h.amplitude for h in y] == pytest.approx([h.amplitude for h in x], rel=1e-9)
    # the readings differ most at order 2 (docs/mesh.md): e_2 0.74 against 0.31 um
    consistent = gear_excitation(table1_consistent(), 50.0, (None, None), 10)
    assert consistent.ste_harmonics[1].amplitude == pytest.approx(0.738e-6, abs=1e-9)
    assert b.ste_harmonics[1].amplitude == pytest.approx(0.312e-6, abs=1e-9)
    assert preset.backlash_loa == pytest.approx(0.4592e-3, abs=5e-8)


def test_a_load_swept_gear_scene_checks_its_pairs_geometry_once(monkeypatch):
    """The pair's geometry (``GearPair.check``: its faults and cautions) does not depend on the
    load: a study that sweeps the load of a gear scene checks it once, not at each load's build
    (26 times for 12 loads: twice a build, most of its time). The pair here (a face width of its
    own) is one no other test checks, so its count starts at zero."""
    from gearsweep.study.plan import make_plan

    computed = []
    real = GearPair._faults

    def counted(self):
        computed.append(self.name)
        return real(self)

    monkeypatch.setattr(GearPair, "_faults", counted)
    loads = [10.0 + 7.0 * i for i in range(12)]
    text = (whine("{preset: table1_consistent, face_width: 11.37 mm}", kind="rattle")
            + "  torque: [" + ", ".join(f"{t} N*m" for t in loads) + "]\n")
    plan = make_plan(parse_study(text), text)
    models = [plan.model_for_load(t) for t in loads]
    e1 = [m.ste_harmonics[0].amplitude for m in models]
    assert all(a < b for a, b in zip(e1, e1[1:], strict=False))  # each load its own STE
    assert len(computed) == 1, computed


def test_a_checked_pair_still_refuses_and_warns_at_each_check():
    """Checking a pair once per pair leaves what each ``check`` says as it was: a pair that
    cannot exist raises at every check with the same message, a nearly pointed one warns at
    every check."""
    from gearsweep.gear import GeometryWarning, table1_as_printed

    bad = table1_as_printed()
    said = []
    for _ in range(2):
        with pytest.raises(GeometryError) as exc:
            bad.check()
        said.append((str(exc.value), exc.value.faults))
    assert said[0] == said[1] and "interference" in said[0][0]
    pointed = GearPair(module=2e-3, z1=12, z2=40, face_width=20e-3, x1=0.8)
    for _ in range(2):
        with pytest.warns(GeometryWarning) as said:  # also Sainsot's root angle, far above
            pointed.check()
        assert any("nearly pointed" in str(w.message) for w in said)


def test_a_relief_from_single_contact_is_refused_where_there_is_none(tmp_path, capsys):
    """``start_at: single_contact`` is where single-tooth contact ends on the flank; at a contact
    ratio of 2 or more there is none (two pairs or more at every position), yet 50/100 teeth at
    15 deg with tips 1.25 m (eps 2.646) took s_start + p_b and relieved 62 % of the path (an
    outside tester). It is refused at start_at, naming the contact ratio (its closed form here)
    and the diameters a start_diameter may take on the relieved flank; the same pair with tips
    0.75 m (eps 1.69) is taken."""
    rb1, rb2 = 50e-3 * math.cos(math.radians(15)), 100e-3 * math.cos(math.radians(15))
    ra1, ra2 = 52.5e-3, 102.5e-3
    eps = (math.sqrt(ra1**2 - rb1**2) + math.sqrt(ra2**2 - rb2**2)
           - 150e-3 * math.sin(math.radians(15))) / (math.pi * 2e-3 * math.cos(math.radians(15)))
    assert eps > 2
    text = textwrap.dedent("""\
        type: mesh
        title: high contact ratio
        gear:
          module: 2 mm
          z1: 50
          z2: 100
          face_width: 20 mm
          pressure_angle: 15 deg
          tip_radius1: 52.5 mm
          tip_radius2: 102.5 mm
          tip_relief: {amount: 10 um, start_at: single_contact, gears: driving}
        torque: 100 N*m
        """)
    path = tmp_path / "eps.yaml"
    path.write_text(text)
    assert main(["validate", str(path)]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    s_start = 150e-3 * math.sin(math.radians(15)) - math.sqrt(ra2**2 - rb2**2)
    low = 2e3 * math.hypot(rb1, s_start)  # gear 1's lowest contact diameter [mm]
    assert f"{path}:11: gear.tip_relief.start_at: 'single_contact' -- " in line, line
    assert (f"contact ratio {eps:.3f}: no single-tooth contact (2 or more pairs carry the load"
            " everywhere)") in line, line
    assert (f"give start_diameter (or start_radius, start_roll_angle): gear 1's active flank"
            f" is {math.ceil(low * 100) / 100:g} to 105 mm") in line, line
    path.write_text(text.replace("52.5 mm", "51.5 mm").replace("102.5 mm", "101.5 mm"))
    assert main(["validate", str(path)]) == 0


GEAR_FILE_SCENES = {  # extra scene lines, kind: what the gear_* variables hold
    "typed k0 and k_n": (("  torque: 50 N*m\n  harmonics: 4\n  stiffness: 1073 kN/mm\n"
                          "  stiffness_harmonics: [{amplitude: 179 kN/mm},"
                          " {amplitude: 40 kN/mm}]\n"), "whine"),
    "typed k0": ("  torque: 50 N*m\n  harmonics: 4\n  stiffness: 1073 kN/mm\n", "whine"),
    "the pair's": ("  torque: 50 N*m\n  harmonics: 4\n", "whine"),
    "rattle": ("  torque: 50 N*m\n  harmonics: 4\n", "rattle"),
}


@pytest.mark.parametrize("name", list(GEAR_FILE_SCENES))
def test_the_gear_variables_of_the_file_say_whose_k_and_e_they_hold(tmp_path, capsys, name):
    """Fig. 5's scene types the paper's k0 = 1073 kN/mm beside a pair whose own k0 is 219 kN/mm;
    its file called the typed value "mean mesh stiffness k0 of the gear pair at the load" and its
    loaded STE "(loaded STE with constant k0; STE - F/k(t) with k(t))" (an outside tester). The
    values against the pair's static mesh (``mesh_cycle``: k0 and k_n its stiffness', e_n its
    loaded STE's or those of STE - F/k(t)) or the typed numbers, and each long_name naming which
    of them the file holds."""
    extra, kind = GEAR_FILE_SCENES[name]
    study, out = tmp_path / "g.yaml", tmp_path / "g.nc"
    study.write_text(whine("table1_consistent", extra, kind=kind)
                     + "solver: {transient_periods: 5, record_periods: 2}\n", encoding="utf-8")
    assert main(["run", str(study), "-o", str(out), "-q"]) == 0, capsys.readouterr().err
    mesh = mesh_cycle(table1_consistent(), 50.0, harmonics=4).as_arrays()
    with xr.open_dataset(out) as ds:
        k0, k_n, e_n = (np.asarray(si_values(ds[v])) for v in
                        ("gear_stiffness", "gear_stiffness_harmonic", "gear_ste_harmonic"))
        said = {v: ds[v].attrs["long_name"] for v in
                ("gear_stiffness", "gear_stiffness_harmonic", "gear_ste_harmonic")}
        units = {v: ds[v].attrs["units"] for v in said}
    assert units == {"gear_stiffness": "kN mm-1", "gear_stiffness_harmonic": "kN mm-1",
                     "gear_ste_harmonic": "um"}
    typed = name.startswith("typed")
    if typed:
        assert k0 == pytest.approx(1.073e9, rel=1e-12) and k0 > 4 * mesh["k_harmonic"][0]
        assert said["gear_stiffness"] == ("mean mesh stiffness k0 the kernel used: typed in the"
                                          " scene's stiffness beside the gear pair, not the"
                                          " pair's own k0")
    else:
        assert k0 == pytest.approx(mesh["k_harmonic"][0], rel=1e-12)
        assert said["gear_stiffness"] == ("mean mesh stiffness k0 of the gear pair at the load,"
                                          " the kernel's")
    if name == "typed k0 and k_n":
        assert_allclose(k_n, [1.79e8, 4.0e7, 0.0, 0.0], rtol=1e-12)
        assert "typed in the scene's stiffness_harmonics beside the gear pair" in said[
            "gear_stiffness_harmonic"]
    elif name == "the pair's":
        assert_allclose(k_n, mesh["k_harmonic"][1:], rtol=1e-12)
        assert said["gear_stiffness_harmonic"].startswith("amplitude of the gear pair's mesh"
                                                          " stiffness harmonic k_n at the load")
    else:
        assert not k_n.any()
        assert said["gear_stiffness_harmonic"].endswith("none (zeros), the stiffness is constant"
                                                        " k0")
    if name == "the pair's":  # e(t) = STE - F / k(t): about zero for unmodified teeth
        assert_allclose(e_n, mesh["e_harmonic"][1:], rtol=1e-9, atol=1e-9 * mesh["ste"].mean())
        assert said["gear_ste_harmonic"].startswith("amplitude of the harmonic e_n of STE - F_m /"
                                                    " k(t) with the gear pair's k(t) at the load")
    else:  # the loaded STE (1.335 um at order 1 here)
        assert_allclose(e_n, mesh["ste_harmonic"][1:], rtol=1e-12)
        assert said["gear_ste_harmonic"].startswith("amplitude of the harmonic e_n of the gear"
                                                    " pair's loaded STE at the load")
        assert said["gear_ste_harmonic"].endswith(
            "with the typed stiffness" if typed else "with constant k0")
    assert "STE - F/k(t) with k(t)" not in said["gear_ste_harmonic"]

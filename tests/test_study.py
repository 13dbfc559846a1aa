"""Study files, units, grids, the runner, result files and the CLI, end to end."""

from __future__ import annotations

import math
import re
import textwrap

import numpy as np
import pytest
import xarray as xr

from gearsweep.api import run_study
from gearsweep.cli import main as cli
from gearsweep.errors import StepLimitWarning, StudyError
from gearsweep.study.dataset import write_netcdf
from gearsweep.study.plan import build_model
from gearsweep.study.schema import parse_study
from gearsweep.units import si_values, to_si

RATTLE = """
title: tiny rattle sweep
scene:
  kind: rattle
  mass: 0.1527 kg
  teeth: 48
  stiffness: 1073 kN/mm
  backlash: 4 um
  mean_force: 100 N
  fluctuation: [{amplitude: 2000 N, order: 1}]
sweep:
  speed: {start: 12000 rpm, stop: 18000 rpm, num: 13}
  damping: [1500 N*s/m, 3000 N*s/m]
continuation: [up, down]
solver: {method: rk4, steps_per_period: 32, transient_periods: 100, record_periods: 20}
"""

LINEAR = """
title: linear check
scene:
  kind: whine
  mass: 0.2 kg
  teeth: 10
  stiffness: 2.0e8 N/m
  damping: 400 N*s/m
  mean_force: 50 N
  fluctuation: [{amplitude: 10 N, order: 1}]
sweep:
  speed: [6000 rpm, 12000 rpm, 24000 rpm]
solver: {method: rk5, steps_per_period: 128, transient_periods: 200, record_periods: 10}
"""


def _study(text: str, file: str = "s.yaml"):
    return parse_study(textwrap.dedent(text), file)


# ---------------------------------------------------------------- units and grids
@pytest.mark.parametrize(
    ("value", "kind", "expected"),
    [
        ("5.5 N*s/mm", "damping", 5500.0),
        ("50 N*m", "torque", 50.0),
        ("0.5 mm", "length", 5e-4),
        ("8000 rpm", "speed", 8000.0),
        ("1073 kN/mm", "stiffness", 1.073e9),
        ("0.1527 kg", "mass", 0.1527),
        ("90 deg", "angle", math.pi / 2),
    ],
)
def test_units_are_parsed_into_si(value, kind, expected):
    assert to_si(value, kind) == pytest.approx(expected, rel=1e-12)


def test_grids_linear_log_and_lists():
    s = _study(RATTLE.replace("{start: 12000 rpm, stop: 18000 rpm, num: 13}",
                              "{start: 100 rpm, stop: 10000 rpm, num: 3, spacing: log}"))
    np.testing.assert_allclose(s.grid("speed"), [100.0, 1000.0, 10000.0], rtol=1e-12)
    np.testing.assert_allclose(s.grid("damping"), [1500.0, 3000.0])
    s2 = _study(RATTLE)
    np.testing.assert_allclose(s2.grid("speed"), np.linspace(12000, 18000, 13))


# ---------------------------------------------------------------- bad files: one clear line
BAD = [
    ("mass: 0.1527 kg", "mass: -1 kg", "scene.mass", "greater than 0"),
    ("mass: 0.1527 kg", "mass: 5 m", "scene.mass", "expected mass"),
    ("mass: 0.1527 kg", "mass: 0.15 kg\n  colour: red", "scene.colour", "not a field of a rattle scene"),
    ("steps_per_period: 32", "steps_per_period: 0", "solver.steps_per_period", "greater than or equal to 4"),
    ("record_periods: 20", "record_periods: 0", "solver.record_periods", "greater than or equal to 1"),
    ("method: rk4", "method: euler", "solver.method", "'rk4' or 'rk5'"),
    ("kind: rattle", "kind: hum", "scene.kind", "allowed: whine, rattle, full, mathieu"),
    ("num: 13}", "num: 0}", "sweep.speed.num", "greater than or equal to 1"),
    ("damping: [1500 N*s/m, 3000 N*s/m]", "damping: [-5 N*s/m]", "sweep.damping", ">= 0"),
    ("damping: [1500 N*s/m, 3000 N*s/m]", "damping: [5 kg]", "sweep.damping", "damping"),
    ("damping: [1500 N*s/m, 3000 N*s/m]", "alpha: [1, 2]", "alpha", "not a sweepable parameter"),
    ("continuation: [up, down]", "continuation: [sideways]", "continuation[0]", "'up' or 'down'"),
    ("backlash: 4 um", "backlash: 0 um", "scene.backlash", "greater than 0"),
    ("title: tiny rattle sweep", "title: ''", "title", "at least 1"),
]


@pytest.mark.parametrize(("old", "new", "field", "allowed"), BAD)
def test_bad_study_gets_one_clear_line(old, new, field, allowed):
    text = RATTLE.replace(old, new)
    assert text != RATTLE
    with pytest.raises(StudyError) as err:
        _study(text, "bad.yaml")
    msg = str(err.value)
    assert "\n" not in msg
    assert re.match(r"bad\.yaml:\d+: ", msg), msg
    assert field in msg, msg
    assert allowed in msg, msg


@pytest.mark.parametrize(("old", "new", "shown"), [
    ("backlash: 4 um", "backlash: -0.5 mm", "scene.backlash: '-0.5 mm' --"),
    ("mass: 0.1527 kg", "mass: -1 kg", "scene.mass: '-1 kg' --"),
    ("num: 13}", "num: 0}", "sweep.speed.num: 0 --"),
])
def test_bad_value_is_shown_as_written(old, new, shown):
    """The line shows the value as the file has it, not the SI number it was parsed into."""
    with pytest.raises(StudyError) as err:
        _study(RATTLE.replace(old, new), "bad.yaml")
    assert shown in str(err.value), str(err.value)


@pytest.mark.parametrize("text", ["", "- just\n- a list\n", "title: [unclosed", "42"])
def test_malformed_yaml_is_one_line(text):
    with pytest.raises(StudyError) as err:
        parse_study(text, "x.yaml")
    assert "\n" not in str(err.value) and str(err.value).startswith("x.yaml")


def test_torque_needs_base_radius_and_continuation_needs_speed():
    with pytest.raises(StudyError, match="base radius"):
        _study(RATTLE.replace("mean_force: 100 N", "torque: 5 N*m"))
    s = _study(RATTLE.replace("mean_force: 100 N", "torque: 5 N*m\n  base_radius: 30 mm"))
    assert build_model(s).mean_force == pytest.approx(5 / 0.03)
    with pytest.raises(StudyError, match="continuation"):
        _study(RATTLE.replace("  speed: {start: 12000 rpm, stop: 18000 rpm, num: 13}\n", "")
               .replace("stiffness: 1073 kN/mm", "stiffness: 1073 kN/mm\n  speed: 9000 rpm"))


def test_drive_gives_eq7_equivalent_mass_and_forces():
    s = _study(LINEAR.replace("mass: 0.2 kg", "drive: {inertia_1: 2e-3 kg*m**2, inertia_2: 1e-3 "
                              "kg*m**2, base_radius_1: 50 mm, base_radius_2: 40 mm}")
               .replace("amplitude: 10 N", "amplitude: 1 N*m"))
    m = build_model(s)
    m_eq = 1 / (0.05**2 / 2e-3 + 0.04**2 / 1e-3)
    assert m.mass == pytest.approx(m_eq, rel=1e-12)
    # Eq. (7): F_v = m_eq T1v r1 / I1
    assert m.force_harmonics[0].amplitude == pytest.approx(m_eq * 1.0 * 0.05 / 2e-3, rel=1e-12)


# ---------------------------------------------------------------- the runner
def test_linear_study_matches_the_analytic_frequency_response():
    ds = run_study(_study(LINEAR), "")
    m, k, c, f0 = 0.2, 2.0e8, 400.0, 10.0
    w = 10 * ds["speed"].values * 2 * np.pi / 60
    amp = f0 / np.sqrt((k - m * w**2) ** 2 + (c * w) ** 2)
    # rk5 at 128 steps/period: integration error ~ (h w_n)^5 / 1000 << 1e-6 here (h w_n < 0.25).
    # The rms over whole periods of uniform samples of a sinusoid is exact (sum of cos^2 = N/2),
    # so it carries the integration error alone:
    np.testing.assert_allclose(si_values(ds["p_rms"]) * np.sqrt(2), amp, rtol=1e-6)
    np.testing.assert_allclose(si_values(ds["p_mean"]), 50.0 / k, rtol=1e-9)
    # Peaks are sampled at the steps: the extremes may miss the true peak by up to
    # 1 - cos(pi / 128) = 3.0e-4 of the amplitude, and never exceed it.
    half_pp = si_values(ds["p_pp"]) / 2
    assert np.all(half_pp <= amp * (1 + 1e-6))
    assert np.all(half_pp >= amp * (1 - (1 - np.cos(np.pi / 128)) - 1e-6))
    assert (ds["status"].values == 0).all()


def test_continuation_dataset_layout_and_hysteresis_bookkeeping():
    ds = run_study(_study(RATTLE), "text")
    assert ds["p_pp"].dims == ("direction", "speed", "damping")
    assert list(ds["direction"].values) == ["up", "down"]
    assert ds["mesh_frequency"].dims == ("speed",)
    np.testing.assert_allclose(ds["mesh_frequency"].values, ds["speed"].values * 48 / 60)
    for name in ("contact_loss_fraction", "backside_contact_fraction", "impacts_per_period"):
        assert name in ds
    # The two ends of a sweep, far from the jumps, do not depend on the direction.
    up, down = ds["p_pp"].sel(direction="up"), ds["p_pp"].sel(direction="down")
    np.testing.assert_allclose(up.isel(speed=0), down.isel(speed=0), rtol=1e-6)
    assert ds.attrs["study"] == "text" and len(ds.attrs["study_sha256"]) == 64


def test_diverging_case_is_flagged_and_neighbours_are_untouched():
    ds_ok = run_study(_study(LINEAR), "")
    # At 100 rpm the step is h w_n = 14.8, far beyond RK5's stability limit (~3.4): that case
    # blows up. It must be stopped and flagged, and the other speeds must not change (bitwise).
    bad = _study(LINEAR.replace("speed: [6000 rpm,", "speed: [100 rpm, 6000 rpm,"))
    with pytest.warns(StepLimitWarning, match=r"^<study>: 1 case\(s\) use a step beyond"):
        ds = run_study(bad, "")
    assert ds["status"].sel(speed=100.0).item() == 1
    assert np.isnan(ds["p_pp"].sel(speed=100.0).item())
    np.testing.assert_array_equal(ds["p_pp"].isel(speed=slice(1, None)).values, ds_ok["p_pp"].values)
    assert (ds["status"].isel(speed=slice(1, None)).values == 0).all()


def test_netcdf_round_trip_keeps_values_and_attributes(tmp_path):
    ds = run_study(_study(RATTLE), "the study text")
    path = write_netcdf(ds, tmp_path / "r.nc")
    back = xr.open_dataset(path)
    xr.testing.assert_identical(ds, back.load())
    back.close()
    for v in list(back.data_vars) + list(back.coords):
        assert "long_name" in back[v].attrs, v
        # numbers carry a unit ("1" when dimensionless); labels such as 'direction' carry none
        assert ("units" in back[v].attrs) == (back[v].dtype.kind in "fiub"), v
        assert back[v].attrs.get("units") != "-", v
    for key in ("Conventions", "title", "history", "source", "study", "study_sha256", "method",
                "steps_per_period", "transient_periods", "record_periods"):
        assert key in back.attrs, key
    assert back.attrs["Conventions"] == "CF-1.10"
    assert not list(tmp_path.glob("*.partial"))


# ---------------------------------------------------------------- the CLI
def test_cli_end_to_end(tmp_path, capsys):
    study = tmp_path / "lin.yaml"
    study.write_text(LINEAR)
    assert cli(["validate", str(study)]) == 0
    assert "3 cases" in capsys.readouterr().out
    out = tmp_path / "out" / "lin.nc"
    assert cli(["run", str(study), "-o", str(out)]) == 0
    assert out.exists()
    assert cli(["inspect", str(out)]) == 0
    text = capsys.readouterr().out
    assert "speed" in text and "p_rms" in text and "rpm" in text


@pytest.mark.parametrize("cmd", ["validate", "run"])
def test_cli_bad_input_exits_2_with_one_line(tmp_path, capsys, cmd):
    study = tmp_path / "bad.yaml"
    study.write_text(LINEAR.replace("mass: 0.2 kg", "mass: -0.2 kg"))
    assert cli([cmd, str(study)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "scene.mass" in err and "bad.yaml" in err
    assert cli([cmd, str(tmp_path / "missing.yaml")]) == 2
    assert "missing.yaml" in capsys.readouterr().err


def test_cli_refuses_unwritable_output_before_running(tmp_path, capsys):
    study = tmp_path / "lin.yaml"
    study.write_text(LINEAR)
    blocker = tmp_path / "file"
    blocker.write_text("x")
    assert cli(["run", str(study), "-o", str(blocker / "sub" / "out.nc")]) == 2
    assert "--output" in capsys.readouterr().err
    assert cli(["inspect", str(tmp_path / "nothing.nc")]) == 2


def test_up_sweep_is_the_same_alone_or_beside_the_down_sweep():
    both = run_study(_study(RATTLE), "")
    up = run_study(_study(RATTLE.replace("continuation: [up, down]", "continuation: [up]")), "")
    down = run_study(_study(RATTLE.replace("continuation: [up, down]", "continuation: [down]")), "")
    np.testing.assert_array_equal(both["p_pp"].sel(direction="up").values,
                                  up["p_pp"].sel(direction="up").values)
    np.testing.assert_array_equal(both["p_pp"].sel(direction="down").values,
                                  down["p_pp"].sel(direction="down").values)


def test_step_guard_warns_or_skips_cases_beyond_the_stability_limit(tmp_path, capsys):
    # 100 rpm with 10 teeth and 128 steps per mesh period: h w_n = 14.8, beyond any RK limit;
    # the other speeds are within it (h w_n <= 0.25).
    text = LINEAR.replace("speed: [6000 rpm,", "speed: [100 rpm, 6000 rpm,")
    with pytest.warns(StepLimitWarning) as said:
        warn = run_study(_study(text), "")
    assert [str(w.message) for w in said] == [
        ("<study>: 1 case(s) use a step beyond the stability limit of rk5 at 128 steps/period;"
         " their results may be spoiled by the integrator (variable 'beyond_step_limit'; raise"
         " solver.steps_per_period or set solver.step_guard: skip)")]
    np.testing.assert_array_equal(warn["beyond_step_limit"].values, [True, False, False, False])
    skip = run_study(_study(text.replace("method: rk5,", "method: rk5, step_guard: skip,")), "")
    assert "beyond_step_limit" not in skip
    np.testing.assert_array_equal(skip["status"].values, [3, 0, 0, 0])
    assert np.isnan(skip["p_rms"].values[0])
    np.testing.assert_array_equal(skip["p_rms"].values[1:], warn["p_rms"].values[1:])
    study = tmp_path / "coarse.yaml"
    study.write_text(text)
    assert cli(["run", str(study), "-o", str(tmp_path / "c.nc"), "-q"]) == 0
    err = capsys.readouterr().err  # the same line, printed once (no Python warning)
    assert err == f"gearsweep: warning: {tmp_path / 'c.nc'}{str(said[0].message).removeprefix('<study>')}\n"


@pytest.mark.parametrize("method", ["rk4", "rk5"])
def test_guard_step_is_a_tight_lower_bound_of_the_exact_stability_limit(method):
    from gearsweep.analysis.stability import frozen_step_ok, max_stable_step
    from gearsweep.study.plan import _GUARD_MARGIN, _stable_steps

    rng = np.random.default_rng(1)
    k = 10 ** rng.uniform(2, 10, 400)
    zeta = np.concatenate([[0.0, 1e-4, 0.01, 0.2, 1.0, 3.0], 10 ** rng.uniform(-4, 1, 394)])
    c = 2 * zeta * np.sqrt(k)
    exact = max_stable_step(method, k, c)
    fast = _stable_steps(method, k, c)
    assert np.all(fast <= exact * (1 + 1e-12))
    # The tabulated bound is within 0.5 % of the exact limit (grid of 1/20000 in zeta near 0).
    assert np.all(fast >= exact * (1 - 5e-3)), np.max(1 - fast / exact)
    # The upper bound of the bracket within which the guard solves the limit exactly.
    assert np.all(_stable_steps(method, k, c, _GUARD_MARGIN) >= exact * (1 - 1e-12))
    # The guard's verdict is the exact rule's (``frozen_step_ok``) at steps next to the limit.
    h = exact * rng.uniform(0.997, 1.003, exact.size)
    bracket = (fast, _stable_steps(method, k, c, _GUARD_MARGIN))
    np.testing.assert_array_equal(frozen_step_ok(method, h, k, c, bracket=bracket), h <= exact)
    # Negative stiffness: limited by the decaying real pole only.
    np.testing.assert_allclose(_stable_steps(method, np.array([-4.0]), np.array([3.0])),
                               max_stable_step(method, -4.0, 3.0), rtol=1e-12)


def test_cli_advise_reports_steps_cost_and_stability(tmp_path, capsys):
    study = tmp_path / "lin.yaml"
    study.write_text(LINEAR.replace("speed: [6000 rpm,", "speed: [100 rpm, 6000 rpm,"))
    assert cli(["advise", str(study), "--target", "1e-6"]) == 0
    out = capsys.readouterr().out
    assert max(len(line) for line in out.splitlines()) <= 100  # lines a terminal shows
    flat = " ".join(out.split())
    assert "steps per mesh period" in flat and "Msteps" in flat
    assert "beyond the rk5 stability limit" in flat  # 100 rpm at 128 steps: h w_n = 14.8
    assert "whine scene, rk5" in flat  # the study's own scene, not a calibration class
    assert "For a target of 1.0e-06" in flat and "As written: 128 steps per mesh period" in flat
    assert cli(["advise", str(study)]) == 0  # default target: 1e-4
    assert "For a target of 1.0e-04" in " ".join(capsys.readouterr().out.split())
    mathieu = tmp_path / "m.yaml"
    mathieu.write_text("title: m\nscene: {kind: mathieu, alpha: 1, beta: 0.2}\n")
    assert cli(["advise", str(mathieu)]) == 2


def test_cli_advise_prices_every_case_of_the_study(tmp_path, capsys):
    """The cost is of the whole study (3 speeds x 4 forces = 12 cases of 210 periods), not of
    one case per speed: a study with a second swept parameter was priced 4x too low."""
    study = tmp_path / "grid.yaml"
    study.write_text(LINEAR.replace("  mean_force: 50 N\n", "").replace(
        "sweep:\n", "sweep:\n  mean_force: [10 N, 20 N, 30 N, 40 N]\n"))
    assert cli(["advise", str(study), "--target", "1e-6"]) == 0
    flat = " ".join(capsys.readouterr().out.split())
    spp = int(re.search(r"For a target of 1.0e-06: (\d+) steps per mesh period", flat)[1])
    msteps = float(re.search(r"([\d.e+-]+) Msteps", flat)[1])
    assert msteps == pytest.approx(12 * 210 * spp / 1e6, rel=5e-3)


@pytest.mark.parametrize("target", ["1e-4", "1e-5", "1e-6"])
def test_cli_advise_gives_steps_the_study_takes(tmp_path, capsys, target):
    """The advised steps per period (plain and kink-aware), written into the study, pass the
    study's own checks: for a rattle scene with a 32-sample spectrum the advice at 1e-4 was 536
    steps, which validate refused ('a multiple of 32 (the samples per period the outputs
    need)')."""
    from gearsweep.study.plan import make_plan

    text = textwrap.dedent("""\
        title: rattle with a spectrum
        scene: {kind: rattle, mass: 0.1527 kg, teeth: 48, stiffness: 1073 kN/mm,
                damping: 2 N*s/mm, backlash: 0.1 mm, mean_force: 100 N,
                fluctuation: [{amplitude: 300 N, order: 1}]}
        sweep:
          speed: {start: 5000 rpm, stop: 12000 rpm, num: 3}
        solver: {method: rk4, steps_per_period: 64, transient_periods: 10, record_periods: 10}
        outputs: [stats, {spectrum: {max_order: 3, samples_per_period: 32}}]
        """)
    study = tmp_path / "s.yaml"
    study.write_text(text)
    assert cli(["advise", str(study), "--target", target]) == 0
    flat = " ".join(capsys.readouterr().out.split())
    advised = [int(re.search(r"For a target of [\d.e+-]+: (\d+) steps per mesh period", flat)[1]),
               int(re.search(r"needs (\d+) steps per period", flat)[1])]  # plain, kink-aware
    for spp in advised:
        t = text.replace("steps_per_period: 64", f"steps_per_period: {spp}")
        make_plan(parse_study(t, "s.yaml"), t)  # raises StudyError if the study refuses it


def test_step_guard_solved_once_per_study_matches_the_guard_per_case():
    """The guard's table over the dims it depends on (speed, damping, mass; not the force)
    gives, chunk by chunk, the verdict of ``_step_ok`` evaluated case by case."""
    from gearsweep.study.plan import _guard_table, _lane_params, _lanes, _step_ok, make_plan

    text = LINEAR.replace("speed: [6000 rpm, 12000 rpm, 24000 rpm]", """speed: [100 rpm, 400 rpm,
    1500 rpm, 6000 rpm]
  mean_force: [10 N, 50 N, 90 N]
  damping: [0 N*s/m, 400 N*s/m, 8000 N*s/m]
  mass: [0.02 kg, 0.2 kg]""")
    plan = make_plan(_study(text), text)
    assert plan.n_lanes == 4 * 3 * 3 * 2
    pos, shape, _ = _guard_table(plan)
    assert [plan.lane_dims[i] for i in pos] == ["speed", "damping", "mass"] and shape == (4, 3, 2)
    every = np.asarray(_step_ok(plan, _lane_params(plan, 0, plan.n_lanes), plan.n_lanes))
    assert 0 < every.sum() < plan.n_lanes  # both verdicts occur
    got = []
    for a, b in plan.chunks(lanes_per_chunk=10):
        got.append(_lanes(plan, a, b, guard=True)[1])
    np.testing.assert_array_equal(np.concatenate(got), every)


def test_lane_values_walk_the_grid_in_c_order():
    """The odometer gives ``np.unravel_index``'s values for any lane range, and the flat index
    over a subset of the dims that ``np.ravel_multi_index`` gives."""
    from gearsweep.study.lanes import lane_values

    rng = np.random.default_rng(3)
    grids = [rng.normal(size=k) for k in (3, 1, 5, 4)]
    shape = [len(g) for g in grids]
    total = int(np.prod(shape))
    for a, b in [(0, total), (0, 1), (7, 8), (13, 47), (59, total)]:
        idx = np.unravel_index(np.arange(a, b), shape)
        params, flat = lane_values(grids, a, b, [0, 3])
        for j, g in enumerate(grids):
            np.testing.assert_array_equal(params[j], g[idx[j]])
        np.testing.assert_array_equal(flat, np.ravel_multi_index([idx[0], idx[3]], (3, 4)))
    params, flat = lane_values([], 0, 1)
    assert params.shape == (0, 1) and flat.tolist() == [0]


@pytest.mark.parametrize(("start", "amplitude"), [("initial_displacement: 0.0, ", 0.5),
                                                  ("", math.sqrt(1.25))])
def test_a_mathieu_start_of_zero_is_zero(start, amplitude):
    """The Mathieu scene's default start is p = 1, but an explicit 0 was taken as "not given"
    and started at 1 too (an adversarial review). p'' + p = 0 from (p0, v0): amplitude
    sqrt(p0^2 + v0^2), here v0 = 0.5: 0.5 from p0 = 0, sqrt(1.25) from the default p0 = 1."""
    from gearsweep.api import run_study

    text = ("title: m\nscene: {kind: mathieu}\nsweep: {alpha: [1.0], beta: [0.0], gamma: [0.0]}\n"
            "solver: {steps_per_period: 64, transient_periods: 1, record_periods: 7, "
            f"{start}initial_velocity: 0.5}}\n")
    ds = run_study(parse_study(text, "m.yaml"), text)
    grid = (math.pi / 64) ** 2 / 2  # the extremes are taken on the step grid
    assert float(ds.p_max.max()) == pytest.approx(amplitude, rel=grid)
    assert float(ds.p_min.min()) == pytest.approx(-amplitude, rel=grid)

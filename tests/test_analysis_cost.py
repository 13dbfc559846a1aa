"""The time and memory of an analysis study, said before it runs and refused beyond the limits.

A ``work_precision`` study with ``copies: 1000000`` validated and then ran for days (an outside
tester, 27 Nov 2026): analysis studies had no estimate. ``gearsweep.study.analysis_cost`` prices
each kind's work; these tests check its arithmetic on the cases whose cost is known exactly
(linear in copies, repeats, steps), that the CLI and the API say and refuse it as they do for
a dynamic study, and (``-m slow``) that the estimate is not below what the studies of
``studies/`` take here.
"""

from __future__ import annotations

import json
import math
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import netCDF4
import pytest
import yaml

import gearsweep
from gearsweep.analysis import precision as pr
from gearsweep.cli import main
from gearsweep.errors import LimitError, StudyError
from gearsweep.study import analysis_cost as ac
from gearsweep.study.analyses import run_analysis_study
from gearsweep.study.execute import BASELINE_FILE_MEMORY, LIMITS
from gearsweep.study.schema import parse_study

ROOT = Path(__file__).resolve().parents[1]
ANALYSES = sorted(p.name for p in (ROOT / "studies").glob("*.yaml")
                  if "type: analysis" in p.read_text(encoding="utf-8"))


@pytest.fixture(autouse=True)
def _warm_cache(monkeypatch):
    """The arithmetic of each kind's work, whatever Numba's cache holds: nothing to compile
    (the one-time compile an estimate adds on a cold cache is tested, in processes of their
    own, by ``test_an_analysis_estimate_counts_its_cold_compile``)."""
    monkeypatch.setattr(ac, "compile_cost", lambda study: (0.0, 0.0))


def _study(name: str, **changes):
    data = yaml.safe_load((ROOT / "studies" / name).read_text(encoding="utf-8"))
    data["analysis"].update(changes)
    text = yaml.safe_dump(data, sort_keys=False)
    return parse_study(text, name), text


def test_every_analysis_study_here_is_estimated_within_the_limits():
    assert len(ANALYSES) >= 6
    for name in ANALYSES:
        est = ac.estimate(_study(name)[0], ROOT / "results")
        assert 0 < est.seconds < LIMITS.seconds and not est.over(), (name, est.line())


def test_the_fixed_step_part_is_linear_in_copies_and_repeats():
    """Whole blocks of LANES cases: 64 copies are 2 blocks, 6400 are 200 (on one thread)."""
    small, _ = _study("work_precision.yaml", peers=[], copies=64, repeat=1)
    big, _ = _study("work_precision.yaml", peers=[], copies=6400, repeat=3)
    a, b = ac.estimate(small, threads=1), ac.estimate(big, threads=1)
    ref = dict(a.parts)["2 reference solutions"]
    assert dict(b.parts)["2 reference solutions"] == ref  # copies do not touch the references
    fixed_a, fixed_b = a.seconds - ref, b.seconds - ref
    assert fixed_b / fixed_a == pytest.approx(300.0, rel=1e-12)


def test_the_fixed_step_part_is_the_kernels_steps_at_the_stated_rate():
    """One scene, one method, one block: periods x steps per period steps of LANES lanes at
    ``STATED_RATE`` (350 Msteps/s per core for RK4), per step count."""
    st, _ = _study("work_precision.yaml", scenes=["whine"], methods=["rk4"],
                   steps_per_period=[16, 32, 64], peers=[], copies=32, repeat=1,
                   transient_periods=40, record_periods=20)
    parts = dict(ac.estimate(st, threads=1).parts)
    assert parts["3 fixed-step runs of 32 cases x 1"] == pytest.approx(
        32 * 60 * (16 + 32 + 64) / 350e6, rel=1e-12)


def test_a_scipy_peer_costs_more_at_a_tighter_tolerance():
    loose, _ = _study("work_precision.yaml", peers=["RK45"], rtol=[1e-3])
    tight, _ = _study("work_precision.yaml", peers=["RK45"], rtol=[1e-8])
    ratio = dict(ac.estimate(tight).parts)["2 scipy runs"] / dict(ac.estimate(loose).parts)[
        "2 scipy runs"]
    assert ratio == pytest.approx(10 ** (5 * ac.PEER_RTOL_EXPONENT["RK45"]), rel=1e-12)


def test_method_stability_counts_its_bisection_trials_in_blocks():
    st, _ = _study("method_stability.yaml", methods=["rk4"], zeta=[0.01 * i for i in range(33)],
                   steps=1_000_000)
    # 33 ratios are two blocks of 32 lanes: on one thread two rounds, on two one round
    one = ac.estimate(st, threads=1).seconds
    two = ac.estimate(st, threads=2).seconds
    assert one == pytest.approx(ac.BISECTION_TRIALS * 2 * 32 * 1e6 / 350e6, rel=1e-12)
    assert two == pytest.approx(one / 2, rel=1e-12)


def test_the_artifact_map_is_priced_on_its_rig_results_grid(tmp_path):
    st, _ = _study("stability_artifact_map.yaml", methods=["rk5"], steps_per_period=[100])
    missing = ac.estimate(st, tmp_path)
    assert "stability_rig.nc not read" in missing.line()
    with netCDF4.Dataset(tmp_path / "stability_rig.nc", "w") as nc:  # a rig of 3000 x 10
        nc.createDimension("speed", 3000)
        nc.createDimension("damping", 10)
    big = ac.estimate(st, tmp_path)
    expected = (ac.MONODROMY_CALL_SECONDS + 100 * (ac.MONODROMY_STEP_SECONDS
                                                   + 30_000 * ac.MONODROMY_POINT_STEP_SECONDS))
    assert big.seconds == pytest.approx(expected, rel=1e-12)
    assert "not read" not in big.line()


@pytest.fixture
def huge(tmp_path):
    """The outside tester's study: a million copies, 1e5 transient periods."""
    _, text = _study("work_precision.yaml", copies=1_000_000, transient_periods=100_000)
    path = tmp_path / "huge.yaml"
    path.write_text(text, encoding="utf-8")
    return path


def test_validate_refuses_a_study_of_days_in_one_line(huge, capsys):
    assert main(["validate", str(huge)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert err[0].startswith(f"gearsweep: error: {huge}: refused (time > 10.0 min, memory > 2 GB):"
                             " analysis 'work_precision', about ")
    assert err[0].endswith("; run with --yes to go ahead")
    assert main(["validate", "--yes", str(huge)]) == 0
    assert " h at stated rates" in capsys.readouterr().out


def test_run_refuses_it_before_computing_anything(huge, tmp_path, capsys):
    t0 = time.perf_counter()
    assert main(["run", str(huge), "-o", str(tmp_path / "out.nc")]) == 2
    assert time.perf_counter() - t0 < 20  # nothing integrated (the run is priced at ~3000 h)
    assert "refused (time > 10.0 min, memory > 2 GB)" in capsys.readouterr().err
    assert not (tmp_path / "out.nc").exists()
    assert main(["run", "--estimate", str(huge), "-o", str(tmp_path / "out.nc")]) == 0
    out = capsys.readouterr().out
    assert out.startswith(f"{huge}: analysis study 'work_precision', computed in one piece: about")


def test_the_api_refuses_it_unless_confirmed_and_estimates_it(huge, tmp_path):
    with pytest.raises(LimitError, match=r"refused \(time > 10.0 min, memory > 2 GB\).*pass"
                       " yes=True"):
        gearsweep.run(huge, output=tmp_path / "out.nc")
    est = gearsweep.estimate(huge)
    assert est.seconds > 1e6 and est.over() == ["time > 10.0 min", "memory > 2 GB"]
    window = pr.Window(100_000, 20)
    assert est.memory_bytes == pytest.approx(  # the signal of a million copies, and the whine
        300e6 + 1e6 * 8 * (20 * 8 + 4 * 6 + 16)  # scene's reference of 1.9 million radians
        + ac.reference_bytes(pr.whine_scene(6000.0), window), rel=1e-12)
    assert ac.reference_bytes(pr.whine_scene(6000.0), window) > 9e9


def test_validate_says_the_estimate_of_a_study_within_the_limits(capsys):
    assert main(["validate", str(ROOT / "studies" / "method_stability.yaml")]) == 0
    out = capsys.readouterr().out
    assert "ok -- analysis study 'method_stability'; estimate: about " in out


@pytest.mark.slow
@pytest.mark.parametrize("name", ANALYSES)
def test_the_estimate_is_not_below_the_run_here(name):
    """Each analysis study of studies/ run here (its inputs from results/, as the main job
    leaves them), against its estimate: the stated rates are floors, so the run takes at most
    the estimate (a factor 1.5 allowed for a busy machine), and the estimate is within 10x.

    The run's time is the smaller of its wall time and its CPU time (all its threads): the idle
    machine's wall time the estimate prices is at most either (a load stretches the wall time,
    not the CPU time; threads make the CPU time the larger). By wall time alone, the shared
    2-core machine at load 6-7 (27 Nov 2026) failed three of them, whose CPU times were within
    their estimates: fig08_rattle_balance 4.6 s against 2.8 s estimated (1.5-1.6 s of CPU),
    stability_artifact_map 31.5 s against 10.0 s (7.0-7.4 s), rattle_map_jumps 3.7 s against
    0.5 s (0.62-0.68 s); at load 2, 1.5, 7.0 and 0.66 s of wall."""
    st, text = _study(name)
    if not all((ROOT / "results" / f"{n}.nc").exists()
               for n in getattr(st.analysis, "inputs", lambda: [])()):
        pytest.skip("run the main job first (the analysis reads its results)")
    est = ac.estimate(st, ROOT / "results")
    run_analysis_study(st, text, ROOT / "results")  # compiles what it calls
    t0, c0 = time.perf_counter(), time.process_time()
    run_analysis_study(st, text, ROOT / "results")
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    seconds = min(wall, cpu)
    print(name, f"wall {wall:.3f} s, CPU {cpu:.3f} s", est.line())
    assert seconds <= 1.5 * est.seconds, (name, seconds, est.line())
    assert est.seconds <= 10 * max(seconds, 0.1), (name, seconds, est.line())
    assert math.isfinite(est.memory_bytes)


def _jump_map(tmp_path) -> Path:
    path = tmp_path / "rattle_map_jumps.yaml"
    path.write_text((ROOT / "studies" / "rattle_map_jumps.yaml").read_text(encoding="utf-8"),
                    encoding="utf-8")
    return path


def test_the_results_an_analysis_reads_count_in_its_memory_as_loaded(tmp_path):
    """An analysis holds its inputs whole (``xr.load_dataset``): the estimate adds what xarray's
    loaded Dataset holds (its ``nbytes``, strings aside), counted from the file's header."""
    import numpy as np
    import xarray as xr

    ds = xr.Dataset({"p": (("direction", "speed", "mass"), np.zeros((2, 300, 7))),
                     "status": (("direction", "speed", "mass"), np.zeros((2, 300, 7), np.int8)),
                     "rattles": (("mass",), np.zeros(7, bool))},
                    coords={"speed": np.arange(300.0), "mass": np.arange(7, dtype=np.float32)})
    ds.to_netcdf(tmp_path / "rattle_map.nc")
    st = parse_study(_jump_map(tmp_path).read_text(encoding="utf-8"), "j.yaml")
    assert ac.input_bytes(st, tmp_path) == xr.load_dataset(tmp_path / "rattle_map.nc").nbytes
    assert ac.estimate(st, tmp_path).memory_bytes == pytest.approx(
        ac.estimate(st).memory_bytes + ds.nbytes, rel=1e-12)
    assert ac.input_bytes(st, tmp_path / "elsewhere") == 0


def test_a_jump_map_of_a_result_larger_than_memory_is_refused_before_loading_it(tmp_path, capsys):
    """The rattle map it reads holds 3.2 GB (a sweep of 200,000 cases x 2,000 speeds, unwritten
    chunks of a compressed variable here: the file is small): it was priced at 300 MB and
    xr.load_dataset would have read it all."""
    with netCDF4.Dataset(tmp_path / "rattle_map.nc", "w") as nc:
        nc.createDimension("speed", 2000)
        nc.createDimension("case", 200_000)
        nc.createVariable("p_rms", "f8", ("speed", "case"), zlib=True)
    assert (tmp_path / "rattle_map.nc").stat().st_size < 1e6
    study = _jump_map(tmp_path)
    assert main(["run", str(study), "-o", str(tmp_path / "jumps.nc")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "refused (memory > 2 GB): analysis 'jump_map'" in err[0], err
    # 300 MB baseline + 3.2 GB of p_rms + its chunk cache while it loads (64 MiB, netCDF-C's
    # default; its chunks of 16 MB would fill it)
    assert "peak memory about 3.57 GB" in err[0]
    assert not (tmp_path / "jumps.nc").exists()


def _continued_map(path: Path, dampings: int) -> None:
    """A result laid out as a continued rattle map's (studies/rattle_map.yaml: direction x
    damping x torque x speed, its float outputs, int8 status; file chunks of
    ``filelayout.file_chunks``, compressed), its amplitudes rising and falling over speed."""
    import numpy as np
    import xarray as xr

    from gearsweep.study.filelayout import file_chunks

    shape = (2, dampings, 50, 100)
    dims = ("direction", "damping", "torque", "speed")
    speed = np.linspace(5000.0, 11000.0, shape[-1])
    wave = np.sin(np.linspace(0.0, 6.0, shape[-1]))
    data = {n: (dims, np.broadcast_to(wave * (1 + i), shape).copy())
            for i, n in enumerate(("p_pp", "p_rms", "p_max", "p_min", "contact_loss_fraction",
                                   "backside_contact_fraction"))}
    data["status"] = (dims, np.zeros(shape, np.int8))
    ds = xr.Dataset(data, coords={"direction": ["up", "down"], "speed": speed,
                                  "damping": np.arange(1.0, dampings + 1), "torque": np.arange(50.0)})
    ds.to_netcdf(path, encoding={n: {"zlib": True, "complevel": 1, "chunksizes": file_chunks(
        shape, ds[n].dtype.itemsize)} for n in data})


def test_a_jump_map_peaks_below_its_estimate_counting_what_loading_its_input_holds(tmp_path):
    """studies/rattle_map_jumps.yaml peaked at 545-557 MB resident against 448 MB estimated (its
    148 MB input counted once): while a result loads, HDF5 keeps each variable's chunks it
    decompressed in the variable's chunk cache (64 MB each by netCDF-C's default) until the file
    closes, as much again as the arrays here; then the jump summary's arrays (``find_jumps``),
    95 bytes per value of p_pp. Truth: the peak resident memory of the run in a process of its
    own, less the libraries' file-backed pages (as ``_COLD_AND_WARM``). The estimate holds it,
    within a factor 1.5."""
    _continued_map(tmp_path / "rattle_map.nc", 200)  # 2e6 values a variable: 16 MB each
    study = _jump_map(tmp_path)
    st = parse_study(study.read_text(encoding="utf-8"), str(study))
    est = ac.estimate(st, tmp_path)
    proc = subprocess.run([sys.executable, "-c", _COLD_AND_WARM, str(study),
                           str(tmp_path / "jumps.nc")], capture_output=True, text=True,
                          timeout=600, env=dict(os.environ, PYTHONPATH=str(ROOT)))
    assert proc.returncode == 0, proc.stderr
    run = json.loads(proc.stdout.splitlines()[-1])
    print(f"peak {run['peak'] / 1e6:.0f} MB ({run['files'] / 1e6:.0f} MB files), estimate"
          f" {est.memory_bytes / 1e6:.0f} MB")
    assert run["peak"] - run["files"] <= est.memory_bytes - BASELINE_FILE_MEMORY, run
    assert est.memory_bytes <= 1.5 * run["peak"], run


@pytest.mark.parametrize(("field", "value"), [("whine_speed", "1e300 rpm"),
                                              ("rattle_speed", "2e6 rpm")])
def test_a_work_precision_speed_beyond_a_scenes_is_refused_in_one_line(tmp_path, capsys, field,
                                                                         value):
    """whine_speed 1e300 rpm: validate, pricing the scene, ended in an OverflowError traceback
    (exit 1); the speeds take the bound of a scene's speed, MAX_SPEED."""
    data = yaml.safe_load((ROOT / "studies" / "work_precision.yaml").read_text(encoding="utf-8"))
    data["analysis"][field] = value
    (tmp_path / "wp.yaml").write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    assert main(["validate", str(tmp_path / "wp.yaml")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].endswith(
        f"analysis.{field}: '{value}' -- a speed of at most 1e+06 rpm (ten times the fastest"
        " gears'; beyond it the whole run lasts nanoseconds and p cannot move in it)"), err


def test_a_study_of_ages_is_said_in_a_few_digits(tmp_path, capsys):
    """whine_speed 1e-300 rpm: its reference solution was priced as a number of 300 digits
    followed by ' h' in the refusal line (and its memory, counted since, as 'inf GB'). Such a
    speed is refused now (below ``MIN_SPEED``, 1e-3 rpm: one line); at that lowest speed the
    refusal is said in a few digits, and so is a duration of 1e300 hours."""
    from gearsweep.study.execute import _duration

    _, text = _study("work_precision.yaml", whine_speed="1e-3 rpm")
    (tmp_path / "wp.yaml").write_text(text, encoding="utf-8")
    assert main(["validate", str(tmp_path / "wp.yaml")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "refused (time > 10.0 min, memory > 2 GB)" in err[0]
    assert re.search(r"2 reference solutions \d+\.\d h", err[0]), err
    assert max(len(w) for w in err[0].split("refused")[1].split()) < 20, err
    assert _duration(1.92e300 * 3600) == "1.92e+300 h"
    with pytest.raises(StudyError, match=r"analysis\.whine_speed: '1e-300 rpm' -- a speed of at"
                       r" least 0\.001 rpm"):
        _study("work_precision.yaml", whine_speed="1e-300 rpm")
    assert not [p for p in tmp_path.iterdir() if p.name != "wp.yaml"]


def test_the_harmonic_balance_holds_its_matrices_in_the_memory_estimate():
    """At the schema's most (200 harmonics, 65,536 samples) AFTBalance keeps E and P, 420 MB
    (620 MB resident at its peak): the estimate said the interpreter's 300 MB alone."""
    from gearsweep.analysis.hb import AFTBalance, MeshSystem

    for harmonics, n_time in ((200, 65536), (25, 1024)):
        st, _ = _study("fig08_rattle_balance.yaml", harmonics=harmonics, n_time=n_time)
        if n_time > 4096:  # its matrices' bytes without making them
            held = 2 * (2 * harmonics + 1) * n_time * 8
        else:
            bal = AFTBalance(MeshSystem(mass=0.1, stiffness=1e8, damping=50.0, half_gap=2e-6),
                             harmonics=harmonics, n_time=n_time)
            held = bal.E.nbytes + bal.P.nbytes
            assert held == 2 * (2 * harmonics + 1) * n_time * 8
        est = ac.estimate(st).memory_bytes - ac.BASELINE_MEMORY
        assert held <= est <= 2 * held, (harmonics, n_time, est, held)


def _whine_only(**changes):
    return _study("work_precision.yaml", scenes=["whine"], methods=["rk4"],
                  steps_per_period=[8, 16, 32], peers=[], copies=1, repeat=1, **changes)


def test_the_work_precision_reference_holds_its_dense_output_in_the_memory_estimate():
    """The reference solution keeps DOP853's dense output, an interpolant per step, a step per
    about 0.2 radian of the scene's fastest motion: the estimate counted the kernel's signal
    alone (300 MB for 3,020 periods of the whine scene, 457 MB resident measured). It grows with
    the periods integrated and with a lower speed (a mesh period of more radians), and is the
    largest scene's, not the sum (one reference is held at a time)."""
    def held(**changes) -> float:
        return ac.estimate(_whine_only(**changes)[0]).memory_bytes - ac.BASELINE_MEMORY

    scene = pr.whine_scene(6000.0)
    per_period = (ac.REFERENCE_STEPS_PER_RADIAN * ac.DENSE_STEP_BYTES
                  * scene.period * max(scene.omega_n, 3 * scene.omega))
    assert held(transient_periods=3040) - held(transient_periods=40) == pytest.approx(
        3000 * per_period, rel=1e-9)
    assert held(transient_periods=3000) > 250e6  # 253,000 steps, 250 MB measured at the peak
    assert held(whine_speed="600 rpm") > 5 * held()
    both = ac.estimate(_study("work_precision.yaml", copies=1)[0]).memory_bytes
    whine = ac.estimate(_study("work_precision.yaml", copies=1, scenes=["whine"])[0]).memory_bytes
    rattle = ac.estimate(_study("work_precision.yaml", copies=1, scenes=["rattle"])[0]
                         ).memory_bytes
    assert both == max(whine, rattle) > ac.BASELINE_MEMORY + 1e6


def test_a_reference_solution_holds_no_more_than_counted():
    """What a reference solution holds at its peak (tracemalloc: the interpolants and the lists
    of ``solve_ivp``; 754 B a step) and its steps (4.36 per radian at 6,000 rpm) are within
    ``DENSE_STEP_BYTES`` and ``REFERENCE_STEPS_PER_RADIAN``, on both scenes (the rattle scene's
    cross-check restarts at each of its crossings)."""
    import gc
    import tracemalloc

    window = pr.Window(20, 10)
    for scene in (pr.whine_scene(6000.0), pr.rattle_scene(9000.0)):
        pr.reference(scene, pr.Window(1, 1), exact=False)  # scipy's imports, not counted
        gc.collect()
        tracemalloc.start()
        try:
            sol = pr.reference(scene, window, exact=False)
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        steps = sum(len(piece.__closure__[0].cell_contents.interpolants) for piece in sol.pieces)
        radians = ac._radians(scene, window)
        assert 1.5 * radians < steps <= ac.REFERENCE_STEPS_PER_RADIAN * radians, (steps, radians)
        assert 500 * steps < peak <= ac.DENSE_STEP_BYTES * steps, (peak, steps)
        assert peak <= ac.reference_bytes(scene, window)


PEAK = ("import atexit, runpy, sys\n"
        "out = sys.argv.pop()\n"
        "atexit.register(lambda: open(out, 'w').write(str(1024 * int(next(\n"
        "    ln for ln in open('/proc/self/status') if ln.startswith('VmHWM:')).split()[1]))))\n"
        "runpy.run_module('gearsweep', run_name='__main__', alter_sys=True)\n")
"""``python -m gearsweep ARGS... FILE`` that writes its peak resident memory [bytes] to FILE
(VmHWM, the process's own: getrusage's ru_maxrss carries pytest's peak across fork and exec)."""


@pytest.mark.slow
def test_a_long_reference_peaks_below_the_estimate(tmp_path):
    """3,020 mesh periods of the whine scene: 457-468 MB resident at the peak measured (its
    reference 250 MB of it), priced at 300 MB before the reference counted; now 590 MB."""
    import subprocess
    import sys

    from gearsweep.kernels.batch import precompile
    from gearsweep.study.analysis_cost import kernel_calls

    st, text = _whine_only(transient_periods=3000)
    precompile(kernel_calls(st), workers=1)  # a cold compile is not what is measured here
    path = tmp_path / "wp.yaml"
    path.write_text(text, encoding="utf-8")
    subprocess.run([sys.executable, "-c", PEAK, "run", str(path), "-o", str(tmp_path / "wp.nc"),
                    "-q", str(tmp_path / "peak")], check=True, cwd=tmp_path)
    peak = int((tmp_path / "peak").read_text())
    est = ac.estimate(st)
    held = ac.reference_bytes(pr.whine_scene(6000.0), pr.Window(3000, 20))
    print(f"peak {peak / 1e6:.0f} MB, estimate {est.memory_bytes / 1e6:.0f} MB")
    assert est.memory_bytes - held < peak <= est.memory_bytes


def test_the_api_takes_yes_as_a_bool_for_an_analysis_study_too(tmp_path):
    """``yes="no"`` is truthy: a mesh or analysis study skipped its limit check and ran (the
    check of ``yes`` came after their branch); here the analysis went on to read its input."""
    from gearsweep.errors import StudyError

    st = (ROOT / "studies" / "fig08_rattle_balance.yaml").read_text(encoding="utf-8")
    with pytest.raises(StudyError, match=r"yes: 'no' -- True or False"):
        gearsweep.run(st, output=tmp_path / "b.nc", yes="no")
    assert not list(tmp_path.iterdir())


def test_a_duration_without_bound_is_said_so():
    """A work_precision at 1e-300 rpm was refused as 'about inf h' (a fuzz find)."""
    from gearsweep.study.execute import _duration, _size

    assert _duration(math.inf) == "without bound"
    assert _size(math.inf) == "without bound"
    assert _duration(7200.0) == "2.0 h"


_COLD_AND_WARM = """
import json, sys
from numba.core import event
from gearsweep.cli import main
from gearsweep.study import analysis_cost as ac
from gearsweep.study.schema import parse_study
study, out = sys.argv[1], sys.argv[2]
st = parse_study(open(study, encoding="utf-8").read(), study)
est = ac.estimate(st, out.rsplit("/", 1)[0])
import netCDF4, xarray  # noqa: E401,F401  (what the run imports: their pages counted)
def kb(field):
    return int(next(ln for ln in open("/proc/self/status") if ln.startswith(field)).split()[1])
files = kb("RssFile:") * 1024
compiles = []
with event.install_timer("numba:compile", compiles.append):
    assert main(["run", study, "-q", "-o", out]) == 0
print(json.dumps({"memory": est.memory_bytes, "compile": est.compile_bytes,
                  "compile_s": est.compile_seconds, "compiled": len(compiles),
                  "line": est.line(), "peak": kb("VmHWM:") * 1024,
                  "files": max(files, kb("RssFile:") * 1024)}))
"""
"""An analysis study's estimate, then its run's peak resident memory and Numba's compiles, in
a process of its own (VmHWM: the process's own), and the libraries' file-backed resident pages
(``files``, the larger of before and after the run)."""

SMALL_ANALYSES = {
    "stability": {"kind": "method_stability", "methods": ["rk4", "rk5"], "zeta": [0.1, 0.5],
                  "steps": 1000, "curve_points": 3},
    "precision": {"kind": "work_precision", "scenes": ["whine"], "methods": ["rk4"],
                  "steps_per_period": [16, 32, 64], "peers": [], "rtol": [1e-3],
                  "transient_periods": 2, "record_periods": 2, "copies": 1, "repeat": 1},
    "balance": {"kind": "rattle_balance", "result": "rattle", "harmonics": 5, "n_time": 64},
}


def test_an_analysis_estimate_counts_its_cold_compile(tmp_path):
    """An analysis study compiles what it calls on a cold Numba cache: the batch kernel's
    specialisations (method_stability, work_precision) or the harmonic balance's monodromy
    (rattle_balance). Its estimate left that out: studies/work_precision.yaml compiled for 56 s
    and peaked at 806 MB on a fresh cache (283 MB on the cache it filled) against 13.7 s and
    306 MB estimated; studies/fig08_rattle_balance.yaml peaked at 308 MB against 302 MB. Truth:
    Numba's compile events and the peak resident memory of each run (its own process) on a
    fresh cache and again on the cache it filled. The estimate counts a compile exactly when
    the run compiles, and its memory holds both runs' peaks, the compile's share covering the
    difference."""
    from test_analysis_studies import RATTLE  # the tests folder is on sys.path

    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "numba"), PYTHONPATH=str(ROOT))
    rattle = dict(RATTLE, sweep={"speed": {"start": "7000 rpm", "stop": "8600 rpm", "num": 3}},
                  solver={**RATTLE["solver"], "transient_periods": 2})
    (tmp_path / "rattle.yaml").write_text(yaml.safe_dump(rattle), encoding="utf-8")
    subprocess.run([sys.executable, "-m", "gearsweep", "run", str(tmp_path / "rattle.yaml"),
                    "-q", "-o", str(tmp_path / "rattle.nc")], env=env, check=True, timeout=300)
    for name, analysis in SMALL_ANALYSES.items():
        _counts_its_cold_compile(tmp_path, env, name, analysis)


def _counts_its_cold_compile(tmp_path: Path, env: dict, name: str, analysis: dict) -> None:
    """The analysis run in a process of its own on the cache ``env`` names (empty of what it
    compiles), then again on the cache it filled: the estimates against Numba's compile events
    and the runs' peak resident memory."""
    study = tmp_path / f"{name}.yaml"
    study.write_text(yaml.safe_dump({"type": "analysis", "title": name, "analysis": analysis}),
                     encoding="utf-8")
    runs = []
    for out in ("cold", "warm"):
        proc = subprocess.run([sys.executable, "-c", _COLD_AND_WARM, str(study),
                               str(tmp_path / f"{name}_{out}.nc")], env=env,
                              capture_output=True, text=True, timeout=600)
        assert proc.returncode == 0, proc.stderr
        runs.append(json.loads(proc.stdout.splitlines()[-1]))
    cold, warm = runs
    print(name, cold["peak"] / 1e6, warm["peak"] / 1e6, cold["line"])
    assert cold["compiled"] and cold["compile_s"] > 0 and cold["compile"] > 0, (name, runs)
    assert "to compile once (cold cache)" in cold["line"], (name, cold["line"])
    assert not warm["compiled"] and warm["compile_s"] == warm["compile"] == 0, (name, runs)
    # The peaks less the libraries' file-backed pages against the estimates less the baseline's
    # share of them (execute.BASELINE_FILE_MEMORY): those pages vary with how the files sit in
    # the page cache (llvmlite's library 37 MB resident in one fresh virtual environment, 98 MB
    # in another of the same wheels installed by a newer pip, as CI's: 340 MB against 288 MB
    # for the same warm run), which no estimate of a study can know.
    for run in runs:
        assert run["peak"] - run["files"] <= run["memory"] - BASELINE_FILE_MEMORY, (name, runs)
    assert cold["peak"] - warm["peak"] <= cold["compile"], (name, runs)


@pytest.mark.slow
def test_several_compiles_in_one_run_add_more_than_the_largest(tmp_path):
    """studies/work_precision.yaml compiles six kernel specialisations, the kink-aware RK5
    (450 MB alone) last: its first run peaked 523 MB above its second, and on this cheap grid
    551 MB (847 against 296 MB), where the estimate counted the largest alone, 450 MB, and said
    750 MB of the cold run (``batch.compile_peak``). Checked as
    ``test_an_analysis_estimate_counts_its_cold_compile`` checks the others (1-2 minutes)."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "numba"), PYTHONPATH=str(ROOT))
    _counts_its_cold_compile(tmp_path, env, "precision", {
        "kind": "work_precision", "steps_per_period": [8, 16, 32], "peers": [], "rtol": [1e-3],
        "transient_periods": 2, "record_periods": 2, "copies": 1, "repeat": 1})

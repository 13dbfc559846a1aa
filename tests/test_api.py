"""The Python API: ``gearsweep.run`` takes a path, YAML text, a dict or a Study and returns the
Dataset the CLI writes; results carry their model and study, so they can be run again."""

from __future__ import annotations

import copy
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from conftest import RATTLE_SCENE, RIG

import gearsweep
from gearsweep.api import load
from gearsweep.cli import main as cli
from gearsweep.errors import GearsweepError, ResultError, StepLimitWarning, StudyError
from gearsweep.model import MeshModel, model_from_record, model_record

VOLATILE = ("history", "elapsed_seconds", "kernel_seconds")
"""Attributes that differ between two runs of the same study (time stamps and timings)."""


ROOT = Path(__file__).resolve().parents[1]

def _same(a: xr.Dataset, b: xr.Dataset) -> None:
    a = a.copy()
    b = b.copy()
    for ds in (a, b):
        for k in VOLATILE:
            ds.attrs.pop(k, None)
    xr.testing.assert_identical(a, b)


def test_run_takes_a_path_text_a_dict_or_a_study_and_writes_nothing(small_whine, write_study,
                                                                    tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    path = write_study(small_whine)
    before = set(tmp_path.rglob("*"))
    by_path = gearsweep.run(path)
    by_dict = gearsweep.run(small_whine)
    by_text = gearsweep.run(path.read_text())
    by_study = gearsweep.run(gearsweep.api.load(small_whine)[0])
    assert set(tmp_path.rglob("*")) == before  # nothing written
    for ds in (by_dict, by_text, by_study):
        np.testing.assert_array_equal(ds.p_rms.values, by_path.p_rms.values)
    assert by_path.p_rms.dims == ("speed",) and by_path.sizes["speed"] == 7
    assert np.all(by_path.p_rms.values > 0)


def test_run_in_memory_equals_the_cli_file(small_whine, write_study, tmp_path):
    path = write_study(small_whine)
    out = tmp_path / "cli.nc"
    r = subprocess.run([sys.executable, "-m", "gearsweep.cli", "run", str(path), "-o", str(out),
                        "-q"], capture_output=True, text=True, env={**os.environ})
    assert r.returncode == 0, r.stderr
    with xr.open_dataset(out) as f:
        from_file = f.load()
    _same(gearsweep.run(path), from_file)


def test_run_with_output_writes_the_same_file(small_whine, write_study, tmp_path):
    out = tmp_path / "api.nc"
    ds = gearsweep.run(write_study(small_whine), output=out)
    assert out.exists()
    _same(ds, gearsweep.open_result(out))


def test_bad_input_raises_the_clis_one_line(small_whine, write_study):
    small_whine["scene"]["mass"] = "-0.2 kg"
    path = write_study(small_whine)
    with pytest.raises(StudyError) as exc:
        gearsweep.run(path)
    msg = str(exc.value)
    assert "\n" not in msg and "scene.mass" in msg and str(path) in msg
    r = subprocess.run([sys.executable, "-m", "gearsweep.cli", "run", str(path)],
                       capture_output=True, text=True)
    assert r.returncode == 2 and msg in r.stderr
    with pytest.raises(GearsweepError):
        gearsweep.run(42)


def test_a_result_runs_again_from_its_own_attributes(small_whine):
    ds = gearsweep.run(small_whine)
    model = gearsweep.result_model(ds)
    assert isinstance(model, MeshModel)
    assert model.mass == RIG.mass and model.stiffness == RIG.stiffness
    assert model.stiffness_harmonics[0].amplitude == pytest.approx(179e6)
    assert model.ste_harmonics[0].amplitude == pytest.approx(5e-6)
    again = gearsweep.run(gearsweep.result_study(ds))
    np.testing.assert_array_equal(again.p_rms.values, ds.p_rms.values)
    # ... and again from that result: the study's text (with its units) goes along; the dump of
    # a validated study, in SI without units, did not validate (an outside reader's finding)
    third = gearsweep.run(gearsweep.result_study(again))
    np.testing.assert_array_equal(third.p_rms.values, ds.p_rms.values)
    assert third.attrs["study"] == ds.attrs["study"]


def test_a_study_read_from_another_folder_keeps_its_text(small_whine, write_study):
    """A study read from a file outside the working folder (``api.load``, ``result_study`` of a
    result with a ``study_folder``) runs its own text: the text was compared with the study as
    if read from the working folder, never equal, and the result held the SI dump without units,
    which ``result_study`` refused (an outside tester's finding)."""
    path = write_study(small_whine)
    assert path.parent != Path.cwd()
    study, text = load(path)
    ds = gearsweep.run(study)
    assert ds.attrs["study"] == text
    assert gearsweep.result_study(ds) == gearsweep.result_study(gearsweep.run(path))


@pytest.mark.parametrize("path", sorted((ROOT / "studies").glob("*.yaml")), ids=lambda p: p.stem)
def test_study_text_reads_back_to_the_study(path):
    """``schema.study_text``, the text a study changed in Python is run from: every study of the
    repository (dynamic, mesh and analysis; Mathieu's bare initial displacement) parses back
    to the same fields."""
    from gearsweep.study.schema import parse_study, study_text

    study, _ = load(path)
    again = parse_study(study_text(study), "<study>", base=study._base_folder)
    assert again.model_dump() == study.model_dump()


def test_a_study_changed_in_python_is_checked_and_its_result_reads_back(small_whine):
    """``model_copy(update=...)`` validates nothing: a negative mass ran (every case NaN,
    status 1) and zero steps per period raised a bare ValueError; the result's ``study`` was an
    SI dump without units, which ``result_study`` refused (an outside tester's finding). The
    study is now run from ``study_text`` and checked as a file is."""
    study, _ = load(small_whine)
    bad = study.model_copy(update={"scene": study.scene.model_copy(update={"mass": -1.0})})
    with pytest.raises(StudyError, match=r"scene\.mass: '-1\.0 kg' -- Input should be greater"):
        gearsweep.run(bad)
    bad = study.model_copy(update={"solver": study.solver.model_copy(
        update={"steps_per_period": 0})})
    with pytest.raises(StudyError, match=r"solver\.steps_per_period"):
        gearsweep.run(bad)
    heavier = study.model_copy(update={"scene": study.scene.model_copy(
        update={"mass": 2 * study.scene.mass})})
    ds = gearsweep.run(heavier)
    back = gearsweep.result_study(ds)
    assert back.scene.mass == 2 * study.scene.mass
    assert "kg" in ds.attrs["study"]
    _same(gearsweep.run(back), ds)


def test_a_study_changed_in_python_with_numpy_values_reads_back(small_whine):
    """A value set with ``model_copy(update=...)`` from a numpy array is a numpy scalar: its
    text was 'np.float64(0.2) kg' (refused: "unknown unit 'np'") and an np.int64 one PyYAML's
    RepresenterError; as in a dict study, it is its plain value."""
    from gearsweep.study.schema import parse_study, study_text

    study, _ = load(small_whine)
    changed = study.model_copy(update={
        "scene": study.scene.model_copy(update={"mass": np.float64(0.2)}),
        "solver": study.solver.model_copy(update={"record_periods": np.int64(20)})})
    again = parse_study(study_text(changed), "<study>")
    assert (again.scene.mass, again.solver.record_periods) == (0.2, 20)
    assert gearsweep.estimate(changed).output_bytes == gearsweep.estimate(again).output_bytes


def test_numpy_values_and_other_python_types_in_a_dict_study(small_whine):
    """numpy scalars and arrays, tuples and Paths are what a study built in Python holds: they
    run as their plain values (they crashed inside PyYAML); anything else is one StudyError."""
    plain = gearsweep.run(small_whine)
    small_whine["scene"]["teeth"] = np.int64(small_whine["scene"]["teeth"])
    small_whine["solver"] = {k: np.int64(v) if isinstance(v, int) else v
                             for k, v in small_whine.get("solver", {}).items()}
    small_whine["sweep"] = {k: tuple(v) if isinstance(v, list) else v
                            for k, v in small_whine["sweep"].items()}
    _same(gearsweep.run(small_whine), plain)
    small_whine["scene"]["mass"] = object()
    with pytest.raises(StudyError, match=r"scene\.mass: .* a number, a string with units"):
        gearsweep.run(small_whine)


def test_numpy_floats_strings_and_0d_arrays_in_a_dict_study(small_whine):
    """np.float64 and np.str_ are subclasses of float and str: they were passed on as they are and
    PyYAML raised RepresenterError (a traceback); a 0-d array (np.array(5.0), what reductions
    return) raised TypeError. A study written with them is the plain one (found by a fuzzer: a
    list(np.linspace(...)) sweep is a list of np.float64)."""
    small_whine["sweep"]["mass"] = ["0.1527 kg", "0.2 kg"]
    plain = copy.deepcopy(small_whine)
    speed = small_whine["sweep"]["speed"]
    speed["start"], speed["stop"] = np.str_(speed["start"]), np.array(speed["stop"])
    small_whine["sweep"]["mass"] = [np.str_(v) for v in small_whine["sweep"]["mass"]]
    small_whine["solver"]["record_periods"] = np.array(small_whine["solver"]["record_periods"])
    assert gearsweep.estimate(small_whine).line() == gearsweep.estimate(plain).line()
    mathieu = {"title": "m", "scene": {"kind": "mathieu", "alpha": np.float64(0.25),
                                       "beta": np.float64(0.1)},
               "sweep": {"gamma": list(np.linspace(0.0, 0.02, 3))},
               "solver": {"steps_per_period": 32}}
    assert gearsweep.estimate(mathieu).line() == gearsweep.estimate(
        {**mathieu, "scene": {"kind": "mathieu", "alpha": 0.25, "beta": 0.1},
         "sweep": {"gamma": [0.0, 0.01, 0.02]}}).line()
    assert gearsweep.estimate(mathieu).line().startswith("3 cases")


def test_a_dict_study_nested_too_deeply_or_holding_itself_is_one_study_error(small_whine):
    """A dict nested 1000 deep, or one that holds itself, ended in RecursionError (a traceback);
    the same nesting in a file is one line (found by a fuzzer)."""
    for depth in (350, 1000):  # (350: past the conversion, within PyYAML's dump)
        deep = 1.0
        for _ in range(depth):
            deep = {"a": deep}
        small_whine["scene"]["mass"] = deep
        with pytest.raises(StudyError, match="nested less deeply"):
            gearsweep.estimate(small_whine)
    small_whine["scene"]["mass"] = small_whine["scene"]
    with pytest.raises(StudyError, match="nested less deeply"):
        gearsweep.estimate(small_whine)


def test_result_study_and_model_take_a_path_and_refuse_what_is_not_a_result(small_whine,
                                                                          tmp_path):
    out = tmp_path / "r.nc"
    ds = gearsweep.run(small_whine, output=out)
    assert gearsweep.result_study(out) == gearsweep.result_study(ds)
    assert gearsweep.result_model(out) == gearsweep.result_model(ds)
    for bad in (xr.Dataset(), 5):
        with pytest.raises(ResultError, match="not a gearsweep result"):
            gearsweep.result_study(bad)
        with pytest.raises(ResultError):
            gearsweep.result_model(bad)


def test_model_record_round_trips(rig):
    assert model_from_record(model_record(rig)) == rig


def test_paths_with_a_tilde_are_in_the_home_folder(small_whine, write_study, tmp_path,
                                                    monkeypatch):
    """``output='~/r.nc'`` was written with '~' as a folder name and opened by xarray, which
    expands '~', from the home folder: FileNotFoundError once the run was done, and
    ``open_result('~/r.nc')`` said "no such result file" (an outside tester's findings). The
    API expands a leading '~' as xarray, pandas and the shell do: study, output and result."""
    monkeypatch.chdir(tmp_path)
    home = tmp_path / "home"
    home.mkdir()
    monkeypatch.setenv("HOME", str(home))
    path = write_study(small_whine)
    (home / "s.yaml").write_text(path.read_text())
    ds = gearsweep.run("~/s.yaml", output="~/r.nc")
    assert (home / "r.nc").is_file() and not (tmp_path / "~").exists()
    _same(ds, gearsweep.open_result(home / "r.nc"))
    _same(ds, gearsweep.open_result("~/r.nc"))
    assert gearsweep.result_study("~/r.nc").title == gearsweep.result_study(ds).title
    _same(gearsweep.run(Path("~/s.yaml")), gearsweep.run(path))


def test_a_path_with_the_home_of_no_such_user_is_one_line(tmp_path, monkeypatch):
    """``~nosuchuser/s.yaml`` is left as it is, as the shell, xarray and pandas leave it: a
    missing study or result is one line (``Path.expanduser`` raised "RuntimeError: Could not
    determine home directory." from load, run and open_result)."""
    monkeypatch.chdir(tmp_path)
    with pytest.raises(StudyError, match=r"~gearsweep_no_such_user/s\.yaml"):
        load("~gearsweep_no_such_user/s.yaml")
    with pytest.raises(ResultError, match=r"~gearsweep_no_such_user/r\.nc: no such result file"):
        gearsweep.open_result("~gearsweep_no_such_user/r.nc")


def test_every_path_of_every_subcommand_expands_a_tilde(small_whine, write_study, tmp_path,
                                                       monkeypatch, capsys):
    """``gearsweep run s.yaml --output=~/sub/r.nc`` (no shell expands '~' after '=') wrote the
    folder ``./~`` (whose ``rm -rf ~`` deletes the home), exit 0; a quoted '~/s.yaml' was "no
    such file"; ``inspect '~/r.nc'`` checked ``./~/r.nc`` and xarray opened the home's (an outside
    tester's findings). Every path argument expands it as the API does: run's, validate's and
    advise's study, run's and validate's -o, inspect's result."""
    monkeypatch.chdir(tmp_path)
    home = tmp_path / "home"
    home.mkdir()
    monkeypatch.setenv("HOME", str(home))
    (home / "s.yaml").write_text(write_study(small_whine).read_text())
    assert cli(["run", "~/s.yaml", "--output=~/sub/r.nc", "-q"]) == 0
    assert (home / "sub" / "r.nc").is_file() and not (tmp_path / "~").exists()
    capsys.readouterr()
    assert cli(["inspect", "~/sub/r.nc"]) == 0
    assert capsys.readouterr().out.startswith(f"{home / 'sub' / 'r.nc'}: ")
    assert cli(["validate", "~/s.yaml", "-o", "~/sub/r.nc"]) == 0
    assert cli(["validate", "~/s.yaml", "-o", "~/"]) == 2  # the home, a folder: refused
    assert "a file path, not a folder" in capsys.readouterr().err
    assert cli(["advise", "~/s.yaml"]) == 0
    assert not (tmp_path / "~").exists()


def test_a_study_files_name_is_refused_as_the_output_before_running(small_whine, write_study,
                                                                    tmp_path, monkeypatch,
                                                                    capsys):
    """``gearsweep run s.yaml -o y.yaml`` and ``run(s, output="x.yml")`` wrote the netCDF result
    under a study's name, which ``open_result``, ``inspect`` and ``result_model`` then refused as
    "a study, not a result" (an outside tester). Refused before anything runs: one line naming
    the output (exit 2 from the CLI), and no file written."""
    monkeypatch.chdir(tmp_path)
    path = write_study(small_whine)
    for out in ("y.yaml", "sub/y.YML"):
        assert cli(["run", str(path), "-o", out, "-q"]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and f"--output: '{out}' -- a result file name" in err, err
        with pytest.raises(StudyError, match=r"^<study>: output: 'x\.yml' -- a result file name"
                                             r" .*read as a study, not a result\)$"):
            gearsweep.run(small_whine, output="x.yml")
    assert cli(["validate", str(path), "-o", "y.yaml"]) == 2  # as run refuses it
    assert "a result file name" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["study.yaml"]


def test_an_excitation_file_under_the_home_of_no_such_user_is_one_line(tmp_path, capsys):
    """A study's excitation file is read as every path a user gives (``files.user_path``): a
    ``~user`` of no such user is a missing file, one line and exit 2 (``Path.expanduser``
    raised RuntimeError, a traceback)."""
    study = tmp_path / "s.yaml"
    study.write_text("title: t\nscene:\n  kind: whine\n  teeth: 20\n  mass: 0.2 kg\n"
                     "  mean_force: 900 N\n  excitation: {file: ~gearsweep_no_such_user/x.csv}\n"
                     "sweep:\n  speed: [1000 rpm]\n", encoding="utf-8")
    assert cli(["validate", str(study)]) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert ":7: scene.excitation.file:" in line and "~gearsweep_no_such_user" in line, line


def test_a_path_with_a_newline_or_spaces_around_it_is_the_file(small_whine, write_study):
    """A path as read from a file (``'s.yaml\\n'``) was said "no such study file", one with
    spaces around it was opened with them ("No such file or directory") though the check that
    took it for a path had found the file stripped (an outside tester's finding)."""
    path = write_study(small_whine)
    plain = gearsweep.run(path)
    for text in (f"{path}\n", f" {path} "):
        np.testing.assert_array_equal(gearsweep.run(text).p_rms.values, plain.p_rms.values)


def test_dir_of_the_package_lists_the_api_without_loading_it():
    """``dir(gearsweep)`` (a notebook's ``gearsweep.<TAB>``) listed no public name: the API is
    loaded on first use by the module's ``__getattr__`` (an outside tester's finding)."""
    code = ("import sys, gearsweep; names = dir(gearsweep);"
            " print(all(n in names for n in gearsweep.__all__), 'gearsweep.api' in sys.modules)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.stdout.split() == ["True", "False"], r.stderr


def test_the_modules_are_attributes_after_import_gearsweep_alone():
    """``import gearsweep; gearsweep.units.si_values(da)`` (the README's spelling) raised
    AttributeError until an API call had imported the module (an outside tester's finding)."""
    code = ("import gearsweep; print(gearsweep.units.si_values.__name__,"
            " gearsweep.errors.StudyError.__name__, 'units' in dir(gearsweep))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.stdout.split() == ["si_values", "StudyError", "True"], r.stderr
    with pytest.raises(AttributeError, match="no attribute 'nothing'"):
        gearsweep.nothing  # noqa: B018


def test_run_study_without_its_text_gives_a_result_that_reads_back(small_whine):
    """``api.run_study(study)`` wrote ``study=""`` and ``result_study`` of the result said "the
    file holds nothing" (an outside tester's finding): it carries the study's own text."""
    from gearsweep.api import run_study

    study, text = load(small_whine)
    ds = run_study(study)
    assert ds.attrs["study"] == text
    assert gearsweep.result_study(ds).model_dump() == study.model_dump()


def test_the_result_names_the_model_fields_its_cases_did_not_run_with(small_whine):
    """``model`` holds the scene's value of a swept field (``damping: 0.0`` in rattle_map.nc),
    which no case ran; read without the code, the file said every case had it (an outside
    tester's finding). ``model_swept`` names those fields; a speed sweep has none."""
    import json

    plain = gearsweep.run(small_whine)
    assert "model_swept" not in plain.attrs
    small_whine["sweep"]["damping"] = ["1 N*s/mm", "2 N*s/mm"]
    small_whine["sweep"]["mean_force"] = ["500 N", "800 N"]
    ds = gearsweep.run(small_whine)
    assert ds.attrs["model_swept"].split() == ["damping", "mean_force"]
    model = json.loads(ds.attrs["model"])
    assert all(name in model for name in ds.attrs["model_swept"].split())
    assert model["damping"] not in si_of(ds["damping"])  # the scene's, not a case's
    case = gearsweep.result_model(ds, damping=2.0, mean_force=800.0)
    assert case.damping == pytest.approx(2000.0)


def si_of(da: xr.DataArray) -> list[float]:
    from gearsweep.units import si_values

    return [float(v) for v in np.ravel(si_values(da))]


SCALE = (ROOT / "studies" / "heavy" / "scale_1e6.yaml").read_text(encoding="utf-8")


def _scale(speeds: int) -> str:
    """The 1e6-case scale study with ``speeds`` speeds (x 10,000 cases)."""
    old = "speed: {start: 2000 rpm, stop: 12000 rpm, num: 100}"
    assert old in SCALE
    return SCALE.replace(old, f"speed: {{start: 2000 rpm, stop: 12000 rpm, num: {speeds}}}")


def test_estimate_from_python_is_the_clis(small_whine, write_study, capsys):
    """``gearsweep.estimate``: the estimate ``run --estimate`` prints, from Python (it needed
    ``quick_estimate(make_plan(...))``; an outside tester's finding)."""
    import dataclasses

    from gearsweep.study.execute import FIXED_SECONDS

    path = write_study(small_whine)
    est = gearsweep.estimate(path)
    assert cli(["run", str(path), "--estimate"]) == 0
    as_cli = dataclasses.replace(est, seconds=est.seconds + FIXED_SECONDS,  # a new process's
                                 start_seconds=FIXED_SECONDS)  # start, which this one paid
    assert capsys.readouterr().out.strip() == f"{path}: {as_cli.line()}"
    assert est.cases == 7 and not est.over()
    with pytest.raises(StudyError, match="type: 'mesh' -- a dynamic or analysis study"):
        gearsweep.estimate(ROOT / "studies" / "mesh_ste_vs_load.yaml")
    analysis = ROOT / "studies" / "method_stability.yaml"  # the line run --estimate prints too
    assert cli(["run", str(analysis), "--estimate"]) == 0
    assert capsys.readouterr().out.strip().endswith(gearsweep.estimate(analysis).line())


def test_an_estimate_in_this_process_leaves_out_the_start_of_a_new_one(small_whine):
    """``gearsweep.estimate`` is of a run in this running process, which never starts Python or
    imports the libraries: it added ``FIXED_SECONDS`` (1 s) all the same, and a 3-case study
    estimated at 1.00 s took 0.005 s (an outside tester). ``gearsweep run --estimate``, of a
    process still to start, keeps it; ``run``'s limits are checked on the in-process one."""
    from gearsweep.api import _load
    from gearsweep.study.estimate import before_refusing, quick_estimate
    from gearsweep.study.execute import FIXED_SECONDS
    from gearsweep.study.plan import make_plan

    gearsweep.run(small_whine)  # warm: the kernel compiled or loaded, as in a notebook
    for in_memory in (False, True):
        est = gearsweep.estimate(small_whine, in_memory=in_memory)
        assert est.seconds < 0.5 and est.start_seconds == 0.0
    plan = make_plan(*_load(small_whine))
    new = quick_estimate(plan)[0]  # the CLI's
    assert new.start_seconds == FIXED_SECONDS
    assert new.seconds == pytest.approx(gearsweep.estimate(small_whine).seconds + FIXED_SECONDS)
    here = quick_estimate(plan, new_process=False)[0]
    assert before_refusing(plan, here)[0] is here  # within the limits: as it is


def test_estimate_refuses_the_chunk_sizes_run_refuses(small_whine):
    """``estimate(chunk_cases=...)`` is checked as ``run``'s is: 0, -5 and 2.5 were priced
    without a word (0 and -5 as chunks of one case each), where ``run`` refuses them."""
    for bad in (0, -5, 2.5, True):
        with pytest.raises(StudyError, match=r"chunk_cases: .* a positive whole number"):
            gearsweep.estimate(small_whine, chunk_cases=bad)
    assert gearsweep.estimate(small_whine, chunk_cases=np.int64(7)).line() == \
        gearsweep.estimate(small_whine, chunk_cases=7).line()


def test_run_refuses_what_the_cli_refuses_unless_yes():
    """A study the CLI refuses without --yes, ``gearsweep.run`` started: 1e9 cases raised
    MemoryError for 7.45 GiB after 0.6 s (an outside tester's finding). Now one LimitError
    with the estimate, before anything runs; a result held in memory counts its arrays (2e7
    cases: 531 MB streamed to a file, 2.02 GB held), which a file does not."""
    from gearsweep.api import _load, _within_limits
    from gearsweep.errors import LimitError
    from gearsweep.study.plan import make_plan

    with pytest.raises(LimitError, match=r"refused \(time > 10.0 min, memory > 2 GB\): "
                                         r"1,000,000,000 cases.*; pass yes=True to go ahead"):
        gearsweep.run(_scale(100_000))
    st, text, name = _load(_scale(2000))
    plan = make_plan(st, text, name)
    assert gearsweep.estimate(_scale(2000)).memory_bytes < 1e9
    assert gearsweep.estimate(_scale(2000), in_memory=True).over() == ["memory > 2 GB"]
    with pytest.raises(StudyError, match=r"yes: 'no' -- True or False"):
        gearsweep.run(_scale(2000), yes="no")
    _within_limits(plan, None, False, "r.nc")  # streamed to a file: within the limits
    with pytest.raises(LimitError, match=r"refused \(memory > 2 GB\): 20,000,000 cases"):
        _within_limits(plan, None, True, name)


def test_an_estimate_in_memory_states_no_file(small_whine, tmp_path, monkeypatch):
    """``estimate(in_memory=True)``, of ``run`` without ``output``, which writes nothing: it
    stated "output at most 66.1 kB" (this study) and the time to write it, for a run that writes no file.
    Now no output bound, no disk and no write time; the result's arrays in the memory."""
    from gearsweep.study.execute import WRITE_RATE

    monkeypatch.chdir(tmp_path)
    gearsweep.run(small_whine)
    assert list(tmp_path.rglob("*")) == []  # what the estimate is of: no file, no folder
    on_file = gearsweep.estimate(small_whine)
    held = gearsweep.estimate(small_whine, in_memory=True)
    assert on_file.output_bytes > 0 and "output at most" in on_file.line()
    assert held.output_bytes == 0 and held.disk_bytes == 0
    assert "output at most" not in held.line()
    assert ", the result held in memory (no file)" in held.line()
    assert held.memory_bytes == on_file.memory_bytes + on_file.output_bytes
    assert held.seconds == pytest.approx(on_file.seconds - on_file.output_bytes / WRITE_RATE)
    assert "at most" not in held.line()  # no period output: no worst case (it said one)


def test_a_chunk_size_below_a_round_of_kernel_blocks_is_said(small_whine, write_study, capsys):
    """The kernel computes LANES lanes a block on each core: chunks of fewer run mostly empty
    blocks (a continued 1e6-case study in chunks of 2,000 cases took 58 s against 5.5 s by
    default; an outside tester's finding; here 25x on 10,000 cases). ``run`` warns it and the
    CLI notes it; the default chunks and a study smaller than one round say nothing."""
    import warnings

    from gearsweep.errors import ChunkSizeWarning, ContactLossWarning

    with pytest.warns(ChunkSizeWarning, match=r"chunk_cases=2: chunks of 2 cases hold 2 cases each,"
                                         r" where the kernel computes \d+ at a time"):
        gearsweep.run(small_whine, chunk_cases=2)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        # (the small whine study leaves drive-flank contact at its top speeds: said, not this)
        warnings.simplefilter("ignore", ContactLossWarning)
        gearsweep.run(small_whine)
        gearsweep.run(small_whine, chunk_cases=7)  # one chunk: all of the study
    from gearsweep.study.execute import CHUNK_OVERHEAD_SECONDS

    path = write_study(small_whine)
    assert cli(["run", str(path), "-o", str(path.with_suffix(".nc")), "--chunk-size", "3"]) == 0
    err = capsys.readouterr().err
    assert "--chunk-size 3: chunks of 3 cases hold 3 cases each" in err
    assert f"each chunk costs about {CHUNK_OVERHEAD_SECONDS * 1e3:.0f} ms beyond its kernel" in err
    assert "at least 7 cases per chunk keep that under 10% of the time" in err  # all 7 speeds


def test_a_dask_chunk_is_priced_at_its_own_cost_and_a_small_one_noted(small_whine, capsys,
                                                                       write_study):
    """With --workers each chunk was priced at the in-process 4 ms and a small --chunk-size had
    no note (40,000 cases in chunks of 64: estimated 3.7 s, took 8.7 s; an outside tester):
    a dask chunk costs ``DASK_CHUNK_OVERHEAD_SECONDS``, and the note says so."""
    from gearsweep.api import _load
    from gearsweep.study.estimate import quick_estimate
    from gearsweep.study.execute import CHUNK_OVERHEAD_SECONDS, DASK_CHUNK_OVERHEAD_SECONDS
    from gearsweep.study.plan import make_plan

    plan = make_plan(*_load(small_whine))
    here = quick_estimate(plan, 1, threads=1)[0]
    there = quick_estimate(plan, 1, threads=1, workers=1)[0]
    assert there.chunks == here.chunks == 7
    assert there.seconds - here.seconds == pytest.approx(
        7 * (DASK_CHUNK_OVERHEAD_SECONDS - CHUNK_OVERHEAD_SECONDS))
    assert " on 1 worker, 1 core at " in there.line()
    path = write_study(small_whine)
    assert cli(["run", str(path), "-o", str(path.with_suffix(".nc")), "--chunk-size", "1",
                "--workers", "1", "--estimate"]) == 0
    err = capsys.readouterr().err
    assert "--chunk-size 1: chunks of 1 case hold 1 case each" in err, err
    assert (f"each chunk costs about {DASK_CHUNK_OVERHEAD_SECONDS * 1e3:.0f} ms beyond its kernel"
            " (its dask task, the call,") in err, err


def test_run_cuts_a_chunk_size_beyond_the_runners_longest_chunk_as_the_cli(small_whine,
                                                                           monkeypatch):
    """``run(chunk_cases=N)`` ran chunks of N cases however long, while its limits were checked
    on the chunks the CLI cuts them to (``estimate.chunk_cases``: at most about a tenth of the
    study's kernel time, 1-30 s); it now runs those, and warns the CLI's note."""
    from gearsweep.errors import ChunkSizeWarning
    from gearsweep.study import execute
    from gearsweep.study.estimate import chunk_cases

    small_whine["solver"]["transient_periods"] = 1_000_000  # a round of blocks: about 3 s
    ran = []

    class Stop(Exception):
        pass

    def spy(plan, output, cases):
        ran.append((cases, chunk_cases(plan, 1000)))
        raise Stop

    monkeypatch.setattr(execute, "chunks_to_run", spy)
    with pytest.warns(ChunkSizeWarning, match=r"chunk_cases=1000 gives chunks longer than the"
                      r" runner allows: .*; using \d+ cases per chunk"), pytest.raises(Stop):
        gearsweep.run(small_whine, chunk_cases=1000, yes=True)
    ((cases, (cut, capped)),) = ran
    assert capped and cases == cut < 1000


def test_the_small_chunk_note_counts_the_kernels_threads(small_whine, monkeypatch):
    """A round of kernel blocks is LANES lanes on each of the kernel's threads (Numba's), not
    on each core: with NUMBA_NUM_THREADS=1 on 4 cores, chunks of one full block were told
    "the kernel computes 128 at a time on 4 cores ... up to 4x the time"."""
    import numba

    from gearsweep.api import _load
    from gearsweep.kernels import LANES
    from gearsweep.study import estimate as est_mod
    from gearsweep.study.plan import make_plan

    small_whine["sweep"]["speed"]["num"] = 10 * LANES
    plan = make_plan(*_load(small_whine))
    monkeypatch.setattr(numba.config, "NUMBA_NUM_THREADS", 1)
    monkeypatch.setattr(est_mod, "cores", lambda: 4)
    assert "empty" not in est_mod.small_chunk_note(plan, LANES)  # (its chunks' own cost, said)
    assert f"computes {LANES} at a time on 1 core:" in est_mod.small_chunk_note(plan, LANES // 2)


def test_flags_progress_and_a_path_of_another_type_are_one_line(small_whine, tmp_path,
                                                                 monkeypatch):
    """``run(progress="yes")`` and ``progress=5`` showed a bar without a word (the docstring
    allows True, False or "log"), ``estimate(in_memory="yes")`` was True, as ``yes="no"``
    once went ahead; ``open_result(3)`` raised os.fspath's TypeError (outside testers). Each is
    one line naming the argument, before anything runs."""
    from gearsweep.api import run_study

    monkeypatch.chdir(tmp_path)
    for bad in ("yes", 5, None):
        with pytest.raises(StudyError, match=rf"^<study>: progress: {bad!r} -- True, False or"
                                             r" 'log'$"):
            gearsweep.run(small_whine, progress=bad)
        with pytest.raises(StudyError, match=r"progress: .* -- True, False or 'log'$"):
            run_study(small_whine, progress=bad)
    for bad in ("yes", 1, None):
        with pytest.raises(StudyError, match=rf"^<study>: in_memory: {bad!r} -- True or False$"):
            gearsweep.estimate(small_whine, in_memory=bad)
    for bad in (3, None, b"r.nc"):
        with pytest.raises(ResultError, match=r"^path: a result file's path \(str or Path\),"
                                              rf" not {type(bad).__name__} "):
            gearsweep.open_result(bad)
    assert list(tmp_path.iterdir()) == []


def test_open_result_of_a_file_that_is_not_netcdf_is_one_line(tmp_path):
    """A folder or a PNG gave xarray's four-line engine advice inside the ResultError (the CLI's
    ``inspect`` says "not a netCDF file"); one line, as every GearsweepError (an outside
    tester's finding)."""
    png = tmp_path / "figure.png"
    png.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(64))
    for bad in (png, tmp_path):
        with pytest.raises(ResultError, match="not a readable netCDF file") as exc:
            gearsweep.open_result(bad)
        assert "\n" not in str(exc.value)


def test_open_result_refuses_a_study_and_a_missing_file(write_study, small_whine, tmp_path):
    with pytest.raises(ResultError, match="is a study"):
        gearsweep.open_result(write_study(small_whine))
    with pytest.raises(ResultError, match="no such"):
        gearsweep.open_result(tmp_path / "nope.nc")


def test_a_dict_study_is_reported_without_line_numbers(small_whine):
    """A dict has no lines: its errors named lines of the YAML made from it (`<dict>:23:`)."""
    bad = {**small_whine, "solver": {**small_whine.get("solver", {}), "kink_aware": 1}}
    with pytest.raises(StudyError) as err:
        gearsweep.run(bad)
    assert err.value.lines == ["<dict>: solver.kink_aware: 1 -- true or false"], err.value.lines


def test_bad_output_and_chunk_cases_from_python_are_one_line(small_whine):
    """From Python as from the CLI: an output that cannot be written, or not a path, and a chunk
    size that is not a positive whole number are one line (an OS error from deep inside, or a
    silent run, before)."""
    with pytest.raises(ResultError, match=r"/proc/x\.nc: cannot write the result here"):
        gearsweep.run(small_whine, output="/proc/x.nc")
    for kw, field in ((dict(output=5), "output"), (dict(chunk_cases=0), "chunk_cases"),
                      (dict(chunk_cases=2.5), "chunk_cases"), (dict(chunk_cases=True), "chunk_cases")):
        with pytest.raises(StudyError, match=field) as err:
            gearsweep.run(small_whine, **kw)
        assert "\n" not in str(err.value)
    # a NumPy whole number is a whole number (np.int64(2) was refused; an adversarial test)
    with pytest.warns(UserWarning, match="chunk_cases=2: chunks of 2 cases"):  # (small)
        two = gearsweep.run(small_whine, chunk_cases=np.int64(2))
    assert two.equals(gearsweep.run(small_whine))


def test_a_response_that_has_died_away_is_settled():
    """A free vibration with nothing driving it decays to round-off (p_pp about 1e-16 m): its
    settle_error is round-off over round-off (0.7 here), and it was flagged 'not settled'
    (status 2); below 1e-9 of the static scale it is settled. The same scene driven by a mean
    force, lightly damped, keeps its ordinary settle test (one transient period: flagged)."""
    free = {"title": "free", "scene": {"kind": "whine", "mass": "0.1527 kg", "teeth": 48,
                                       "stiffness": "1073 kN/mm", "damping": "5.5 N s/mm",
                                       "mean_force": "0 N", "speed": "2000 rpm"},
            "solver": {"steps_per_period": 32, "transient_periods": 40, "record_periods": 10,
                       "initial_displacement": "1 um"}}
    ds = gearsweep.run(free)
    assert ds.settle_error.item() > 0.05 and ds.status.item() == 0
    assert ds.p_pp.item() < 1e-9  # um
    driven = {**free, "scene": {**free["scene"], "damping": "0.05 N s/mm", "mean_force": "1000 N",
                                "stiffness_harmonics": [{"amplitude": "179 kN/mm"}]},
              "solver": {**free["solver"], "transient_periods": 1, "record_periods": 4,
                         "initial_displacement": "50 um"}}
    assert gearsweep.run(driven).status.item() == 2  # light damping, one transient period
    # Quiet where it rests, pressed on its flank by a mean force: settled. Quiet because the
    # whole run is too short to move (1e10 rpm: 5 ns; p 1e-13 m on its way to 235 um; 1e6 rpm here,
    # the most a study takes: 50 ns) was taken
    # as settled (status 0; an adversarial test): not at rest, it is flagged.
    rattle = {"title": "r", "scene": {"kind": "rattle", "mass": "0.1527 kg", "teeth": 48,
                                      "stiffness": "1073 kN/mm", "damping": "5.5 N s/mm",
                                      "backlash": "0.1 mm", "mean_force": "1000 N"},
              "sweep": {"speed": ["2000 rpm", "1e6 rpm"]},
              "solver": {"steps_per_period": 32, "transient_periods": 200, "record_periods": 10,
                         "initial_displacement": "static"}}
    ds = gearsweep.run(rattle)  # started at rest: it stays there, at any speed
    assert list(ds.status.values) == [0, 0], ds.status.values
    at_rest = 50 + 1000 / 1.073e9 * 1e6  # b/2 + F_m / k0 [um]
    assert ds.p_mean.values == pytest.approx(at_rest, rel=1e-9)
    # (now refused: 1e6 rpm at most). The same within the bounds: a heavy, soft mesh (1e6 kg,
    # F_m / k0 = 1 m) started in the gap, a metre from its rest: in its 0.26 ms p moves 3e-11 m,
    # quiet against its 1 m scale, and not at rest
    rattle["scene"].update(stiffness="1 N/mm", mass="1e6 kg")
    rattle["sweep"]["speed"] = ["1e6 rpm"]
    rattle["solver"]["initial_displacement"] = "0 um"
    ds = gearsweep.run(rattle)
    assert list(ds.status.values) == [2] and ds.p_pp.values[0] < 1e-3, ds.p_pp.values


def test_a_problem_found_when_planning_names_the_file_and_line_from_python_too(small_whine,
                                                                             write_study):
    """Steps per period against the outputs' sampling is checked when the study is planned; from
    Python the message said '<study>' with no line, the CLI 'file:line'. Both give both now (a
    dict has no lines: it is named alone)."""
    small_whine["solver"] = {**small_whine.get("solver", {}), "steps_per_period": 24}
    small_whine["outputs"] = [{"spectrum": {"samples_per_period": 16}}]
    path = write_study(small_whine)
    for given, where in ((small_whine, "<dict>: "), (path, f"{path}:")):
        with pytest.raises(StudyError) as err:
            gearsweep.run(given)
        assert str(err.value).startswith(where), str(err.value)
        if given is path:
            assert str(err.value).split(":")[1].isdigit()
        assert "solver.steps_per_period: 24 -- a multiple of 16" in str(err.value)


def test_cases_beyond_the_step_limit_warn_from_python_with_the_clis_line(small_whine, write_study,
                                                                         tmp_path, capsys):
    """``solver.step_guard: warn`` (the default) marks the cases whose step is beyond the method's
    stability limit in ``beyond_step_limit``; only the CLI said so, a result from Python was
    silent. Now ``run`` and ``run_study`` give one ``StepLimitWarning`` with the line the CLI
    prints (the CLI: that line alone, no Python warning); ``skip`` and ``off`` give none."""
    small_whine["sweep"]["speed"] = ["300 rpm", "3000 rpm", "6000 rpm"]  # 300 rpm: h w_n = 10.9
    path = write_study(small_whine)
    with pytest.warns(StepLimitWarning) as got:
        ds = gearsweep.run(path, output=tmp_path / "api.nc")
    assert ds.beyond_step_limit.values.tolist() == [True, False, False]
    assert [str(w.message) for w in got] == [
        (f"{tmp_path / 'api.nc'}: 1 case(s) use a step beyond the stability limit of rk4 at 32"
         " steps/period; their results may be spoiled by the integrator (variable"
         " 'beyond_step_limit'; raise solver.steps_per_period or set solver.step_guard: skip)")]
    assert got[0].filename == __file__  # points at the caller's line
    assert cli(["run", str(path), "-o", str(tmp_path / "cli.nc"), "-q"]) == 0
    cli_line = str(got[0].message).replace(str(tmp_path / "api.nc"), str(tmp_path / "cli.nc"))
    assert capsys.readouterr().err == f"gearsweep: warning: {cli_line}\n"
    with pytest.warns(StepLimitWarning, match=r"^<dict>: 1 case\(s\) use a step beyond") as got:
        gearsweep.run(small_whine)
    assert len(got) == 1
    with pytest.warns(StepLimitWarning, match=r"^<study>: 1 case\(s\)") as got:
        gearsweep.api.run_study(gearsweep.api.load(small_whine)[0])
    assert len(got) == 1
    for guard in ("skip", "off"):  # no warning (an error here: filterwarnings = error)
        small_whine["solver"]["step_guard"] = guard
        assert "beyond_step_limit" not in gearsweep.run(small_whine)


def test_validate_warns_of_the_cases_beyond_the_step_limit_that_run_finds(write_study, tmp_path,
                                                                          capsys):
    """``validate`` says before running what ``run`` warns of after: the same count, from the
    same guard (here a rattle sweep continued both ways, with a dim the guard does not read);
    with ``step_guard: skip`` it says they will be left uncomputed; ``off``: nothing."""
    text = "title: coarse step\n" + RATTLE_SCENE + """sweep:
  speed: [300 rpm, 400 rpm, 3000 rpm, 6000 rpm]
  damping: [50 N*s/m, 100 N*s/m, 150 N*s/m]
  backlash: [0.1 mm, 0.2 mm]
continuation: [up, down]
solver: {method: rk4, steps_per_period: 32, transient_periods: 10, record_periods: 4}
"""
    path = write_study(text)
    assert cli(["run", str(path), "-o", str(tmp_path / "r.nc"), "-q"]) == 0
    ran = capsys.readouterr().err
    with xr.open_dataset(tmp_path / "r.nc") as ds:
        n = int(ds.beyond_step_limit.sum())
    assert n == 2 * 3 * 2 * 2  # 300 and 400 rpm, every damping, backlash and direction
    assert f": {n} case(s) use a step beyond" in ran
    assert cli(["validate", str(path)]) == 0
    err = _without_transient_note(capsys.readouterr().err)  # (4 transient periods: noted)
    assert err == ran.replace(str(tmp_path / "r.nc"), str(path)).replace(" use a", " will use a")
    write_study(text.replace("record_periods: 4}", "record_periods: 4, step_guard: skip}"))
    assert cli(["validate", str(path)]) == 0
    assert _without_transient_note(capsys.readouterr().err) == (
        f"gearsweep: warning: {path}: {n} case(s) will use a step beyond the stability limit of"
        " rk4 at 32 steps/period; step_guard: skip leaves them uncomputed (status 3, skipped;"
        " raise solver.steps_per_period to compute them)\n")
    write_study(text.replace("record_periods: 4}", "record_periods: 4, step_guard: off}"))
    assert cli(["validate", str(path)]) == 0
    assert _without_transient_note(capsys.readouterr().err) == ""


def test_result_model_gives_a_swept_field_only_where_it_is_selected(small_whine):
    """``result_model`` gave the scene's unswept values for swept fields (mean_force 0.0 for
    a sweep of 400, 833 and 1600 N): a model the kernel never ran. A swept field is now NaN unless
    selected, in the result's units as for ``sel``; a gear scene's load selects k(t) and e(t) of
    that load, the ones the result's gear variables hold."""
    import dataclasses
    import math

    small_whine["sweep"]["mean_force"] = ["400 N", "833 N"]
    small_whine["sweep"]["damping"] = ["2 N s/mm", "5.5 N s/mm"]
    ds = gearsweep.run(small_whine)
    m = gearsweep.result_model(ds)
    assert math.isnan(m.mean_force) and math.isnan(m.damping) and m.mass == 0.1527
    picked = gearsweep.result_model(ds, mean_force=833, damping=5.5)
    assert (picked.mean_force, picked.damping) == (833.0, 5500.0)
    assert dataclasses.replace(picked, mean_force=0, damping=0) == dataclasses.replace(
        m, mean_force=0, damping=0)  # the rest as the record has it
    with pytest.raises(ResultError, match=r"mean_force=834 is not one of the result's 2 values"
                                          r" \(400 to 833 N; the nearest is 833\)"):
        gearsweep.result_model(ds, mean_force=834)
    # speed is swept but no field of the model (said "not a swept field"; a new-user test)
    with pytest.raises(ResultError, match=r"speed is not a field of the model: a case's speed"
                                          r" sets only its mesh frequency; select among"
                                          r" mean_force, damping"):
        gearsweep.result_model(ds, speed=3000)
    only_speed = gearsweep.run(small_whine | {"sweep": {"speed": small_whine["sweep"]["speed"]}})
    with pytest.raises(ResultError, match=r"frequency; the model is the same at every speed:"
                                          r" result_model\(ds\) alone gives it$"):
        gearsweep.result_model(only_speed, speed=3000)  # (said "select among none")
    # a value with a unit, as the study writes it (was a bare ValueError)
    assert gearsweep.result_model(ds, mean_force="0.833 kN", damping="5500 N s/m") == picked
    with pytest.raises(ResultError, match=r"damping='5.5 kg': is a mass \(kg\), expected damping"):
        gearsweep.result_model(ds, damping="5.5 kg")
    with pytest.raises(ResultError, match=r"damping=\[5.5\]: a number in the result's unit"):
        gearsweep.result_model(ds, damping=[5.5])


def test_result_model_takes_a_float32_to_its_own_precision(small_whine):
    """``result_model(ds, damping=np.float32(2.2))`` said "not one of the result's 2 values
    (...; the nearest is 2.2)": the match (9 digits) is tighter than a float32's. A float32
    finds the one stored value within its own precision; two within it are one line saying
    float32 is the cause."""
    small_whine["sweep"]["damping"] = ["2.2 N s/mm", "5.5 N s/mm"]
    ds = gearsweep.run(small_whine)
    assert gearsweep.result_model(ds, damping=np.float32(2.2)).damping == 2200.0
    with pytest.raises(ResultError, match=r"not one of the result's 2 values"):
        gearsweep.result_model(ds, damping=np.float32(2.3))
    small_whine["sweep"]["damping"] = ["5.5 N s/mm", "5.5000001 N s/mm"]
    near = gearsweep.run(small_whine)
    assert gearsweep.result_model(near, damping=5.5).damping == 5500.0
    with pytest.raises(ResultError, match=r"^damping=np.float32\(5.5\): 2 of the result's values"
                                          r" are within float32's precision of it: give it as a"
                                          r" float \(64-bit\)$"):
        gearsweep.result_model(near, damping=np.float32(5.5))


def test_result_model_of_a_result_selected_with_sel_or_isel(small_whine):
    """``ds.sel``/``ds.isel`` make a swept dim a scalar coordinate: ``result_model`` of that
    Dataset gave the scene's unswept values (mean_force 0.0, damping of the scene), a model the
    kernel never ran; it is the selected value (an outside tester's finding)."""
    small_whine["sweep"]["mean_force"] = ["400 N", "833 N"]
    small_whine["sweep"]["damping"] = ["2 N s/mm", "5.5 N s/mm"]
    ds = gearsweep.run(small_whine)
    picked = gearsweep.result_model(ds, mean_force=400, damping=2)  # not the scene's values
    assert (picked.mean_force, picked.damping) == (400.0, 2000.0)
    assert gearsweep.result_model(ds.sel(mean_force=400, damping=2)) == picked
    assert gearsweep.result_model(ds.isel(mean_force=0), damping=2) == picked
    assert gearsweep.result_model(ds.sel(mean_force=400), mean_force=400, damping=2) == picked
    partly = gearsweep.result_model(ds.sel(damping=2))
    assert partly.damping == 2000.0 and np.isnan(partly.mean_force)
    with pytest.raises(ResultError, match=r"mean_force=833 is not one of the result's 1 values"):
        gearsweep.result_model(ds.sel(mean_force=400), mean_force=833)


def test_result_model_of_a_gear_scene_at_a_swept_load():
    import re

    text = (ROOT / "studies/fig06_mean_torque.yaml").read_text(encoding="utf-8")
    text, n = re.subn(r"speed: \{start: 1000 rpm, stop: 20000 rpm, num: 1000\}",
                      "speed: [5000 rpm]", text)
    assert n == 1
    ds = gearsweep.run(text)
    at = gearsweep.result_model(ds, torque=25)
    stiffness = float(ds.gear_stiffness.sel(torque=25)) * 1e6  # kN mm-1 in the file
    assert at.stiffness == pytest.approx(stiffness, rel=1e-12)
    assert at.stiffness_harmonics[0].amplitude == pytest.approx(
        float(ds.gear_stiffness_harmonic.sel(torque=25, harmonic=1)) * 1e6, rel=1e-12)
    assert at.mean_force == pytest.approx(25 / float(ds.gear_base_radius_1) * 1e3, rel=1e-12)
    unselected = gearsweep.result_model(ds)
    assert all(np.isnan(x) for x in (unselected.mean_force, unselected.stiffness,
                                     unselected.stiffness_harmonics[0].amplitude))


def test_result_model_keeps_a_stiffness_typed_beside_a_gear_when_the_load_is_swept():
    """k(t) typed beside the gear (studies/fig05_waterfall.yaml) is the same at every load: an
    unselected load left it NaN (a review); only the pair's load-dependent parts are."""
    import re

    text = (ROOT / "studies/fig05_waterfall.yaml").read_text(encoding="utf-8")
    text, n = re.subn(r"speed: \{start: 1000 rpm, stop: 20000 rpm, num: 2000\}",
                      "speed: [5000 rpm]\n  torque: [25 N*m, 50 N*m]", text)
    assert n == 1 and "  torque: 50 N*m\n" in text
    ds = gearsweep.run(text.replace("  torque: 50 N*m\n", ""))
    m = gearsweep.result_model(ds)
    assert m.stiffness == 1073e6 and [h.amplitude for h in m.stiffness_harmonics] == [
        179e6, 40e6, 10e6]
    assert np.isnan(m.mean_force) and np.isnan(m.ste_harmonics[0].amplitude)
    at = gearsweep.result_model(ds, torque=50)
    assert at.stiffness == 1073e6 and not np.isnan(at.ste_harmonics[0].amplitude)


def test_validate_says_when_the_step_guard_grid_is_too_large_to_count(write_study, capsys):
    """Over 2^20 points of the guard's swept values, validate cannot count in advance: it said
    nothing (as if no case were beyond the limit); now it says run will count them."""
    path = write_study("""\
title: big chart
scene: {kind: mathieu}
sweep:
  alpha: {start: 0.1, stop: 2, num: 1100}
  beta: {start: 0, stop: 1, num: 1000}
solver: {transient_periods: 1, record_periods: 1}
outputs: [floquet]
""")
    assert cli(["validate", str(path), "--yes"]) == 0
    assert capsys.readouterr().err == (
        f"gearsweep: note: {path}: the step guard's grid is too large to check here; run checks"
        " every case and says how many are beyond the step limit\n")


def test_a_result_says_where_its_kernel_ran_and_in_what_precision(small_whine, tmp_path, capsys):
    """A float32 GPU run differs from a float64 one by about 5e-5 relative, and the file did not
    say which it was (an adversarial test): ``device`` and ``precision`` are global attributes,
    and ``inspect`` prints them."""
    from gearsweep.cli import main

    out = tmp_path / "w.nc"
    ds = gearsweep.run(small_whine, output=out)
    assert (ds.attrs["device"], ds.attrs["precision"]) == ("cpu", "float64")
    assert main(["inspect", str(out)]) == 0
    assert ", on cpu in float64\n" in capsys.readouterr().out



def test_a_study_path_of_any_name_is_read_as_a_file_and_a_bare_name_is_no_yaml(tmp_path,
                                                                             small_whine):
    """A string naming an existing file is a path whatever its suffix (``s.txt`` was read as
    YAML text: "the file holds a single value 's.txt'"); one that names nothing and is no YAML
    mapping says there is no such study file."""
    import yaml

    txt = tmp_path / "s.txt"
    txt.write_text(yaml.safe_dump(small_whine), encoding="utf-8")
    assert gearsweep.run(str(txt)).equals(gearsweep.run(small_whine))
    with pytest.raises(StudyError, match="no such study file"):
        gearsweep.run(str(tmp_path / "missing"))


def test_result_model_of_a_data_array_asks_for_the_dataset(small_whine):
    """``result_model(ds.p_rms)`` said the result "carries no resolved model"."""
    ds = gearsweep.run(small_whine)
    with pytest.raises(ResultError, match="give the result's Dataset .* not a DataArray"):
        gearsweep.result_model(ds.p_rms)
    assert gearsweep.result_model(ds).mass == pytest.approx(RIG.mass)


def test_result_model_of_an_analysis_result_does_not_call_it_a_mesh_study():
    """An analysis result has no model either: the message named only "a mesh study, or written
    by an older gearsweep", wrong for an analysis result of this version (found by an outside
    reader of the main job's files)."""
    ds = gearsweep.run({"type": "analysis", "title": "limits", "analysis": {
        "kind": "method_stability", "zeta": [0.3], "curve_points": 3, "zeta_max": 0.4,
        "steps": 1000}})
    with pytest.raises(ResultError, match="no resolved model .*analysis study"):
        gearsweep.result_model(ds)


def test_the_estimate_counts_numbas_threads(monkeypatch):
    """With NUMBA_NUM_THREADS=1 a run uses one core: the estimate said "on 2 cores", half the
    time (an API test)."""
    import numba

    from gearsweep.study import estimate as est_mod
    from gearsweep.study.plan import make_plan
    from gearsweep.study.schema import load_study

    plan = make_plan(*load_study(str(Path(__file__).resolve().parents[1] / "studies"
                                     / "whine_speed_sweep.yaml")))
    monkeypatch.setattr(numba.config, "NUMBA_NUM_THREADS", 1)
    one = est_mod.quick_estimate(plan)[0]
    assert one.threads == 1 and "on 1 core at" in one.line()
    assert est_mod.quick_estimate(plan, threads=2)[0].threads == 2


def test_response_vs_speed_draws_a_fraction_as_a_fraction(tmp_path):
    """``plot_response_vs_speed`` drew every variable times 1e6 and labelled it um: the contact
    loss fraction (0.5-0.9) came out as 500000-900000 um. A displacement is in um, anything else
    in its own unit; a hue that is no other swept dim, or a result without a speed sweep, is
    one line."""
    import matplotlib

    matplotlib.use("Agg")
    from gearsweep.plot.sweep import plot_response_vs_speed

    ds = gearsweep.run("title: r\n" + RATTLE_SCENE + "sweep:\n  speed: {start: 7000 rpm, stop:"
                       " 9000 rpm, num: 5}\n  damping: [3 N*s/mm, 5.5 N*s/mm]\nsolver: {method: rk4,"
                       " steps_per_period: 32, transient_periods: 300, record_periods: 20}\n")
    ax = plot_response_vs_speed(ds, "contact_loss_fraction").axes[0]
    lo, hi = ax.get_ylim()
    assert hi <= 1.1 and ax.get_ylabel().endswith("[1]")
    ax = plot_response_vs_speed(ds, "p_pp").axes[0]
    assert ax.get_ylabel().endswith("[µm]")
    drawn = np.nanmax([np.nanmax(ln.get_ydata()) for ln in ax.get_lines()])
    assert np.isfinite(drawn) and drawn == pytest.approx(float(ds.p_pp.where(ds.status == 0).max()))
    with pytest.raises(ValueError, match="hue='speed'"):
        plot_response_vs_speed(ds, "p_pp", hue="speed")
    with pytest.raises(ValueError, match="over a 'speed' sweep"):
        plot_response_vs_speed(ds.isel(speed=0, drop=True), "p_pp")


def test_the_analysis_plots_name_the_result_they_draw(small_whine):
    """``plot_method_stability`` and ``plot_work_precision`` on another result say which study
    makes theirs (a whine result gave an AttributeError of its global 'method' attribute)."""
    import matplotlib

    matplotlib.use("Agg")
    from gearsweep.plot.precision import plot_method_stability, plot_work_precision

    ds = gearsweep.run(small_whine)
    with pytest.raises(ValueError, match="studies/method_stability.yaml.*no method"):
        plot_method_stability(None, ds)
    with pytest.raises(ValueError, match="studies/work_precision.yaml.*no trajectory_error"):
        plot_work_precision(None, ds, scene="whine")


def _without_transient_note(err: str) -> str:
    """``err`` without validate's note of a short transient (tests/test_study_errors.py)."""
    return "".join(line for line in err.splitlines(True) if "solver.transient_periods" not in line)


def test_the_small_chunk_note_counts_one_case_in_the_singular(small_whine):
    """'chunks of 1 cases are 1 cases each' (an outside tester's reading of the note)."""
    from gearsweep.study.estimate import small_chunk_note
    from gearsweep.study.plan import make_plan
    from gearsweep.study.schema import Study

    note = small_chunk_note(make_plan(Study.model_validate(small_whine)), 1, threads=2)
    assert note.startswith("chunks of 1 case hold 1 case each, where"), note


@pytest.mark.parametrize(("study", "target", "flag"), [
    ("fig01_02_mesh_cycle.yaml", None, None),  # a mesh study: nothing is integrated
    ("stability_artifact_map.yaml", None, None),  # an analysis study
    ("strutt_mathieu.yaml", None, None),  # a Mathieu scene: no accuracy model
    ("fig08_rattle.yaml", 2.0, "2"),
    ("fig08_rattle.yaml", 0.0, "0"),
    ("fig08_rattle.yaml", float("nan"), "nan"),
])
def test_advise_refuses_what_gearsweep_advise_refuses(study, target, flag, capsys):
    """``gearsweep.advise`` refuses a study or target `gearsweep advise` refuses with the same
    one line, a ``StudyError`` (the target named as the keyword, ``target``, where the command
    line names ``--target``)."""
    path = str(ROOT / "studies" / study)
    assert cli(["advise", path, *(["--target", flag] if flag else [])]) == 2
    said = capsys.readouterr().err.strip().removeprefix("gearsweep: error: ")
    with pytest.raises(StudyError) as exc:
        gearsweep.advise(path, **({} if target is None else {"target": target}))
    assert str(exc.value) == said.replace(": --target: ", ": target: ")


@pytest.mark.parametrize("target", ["1e-4", True, None, 1])
def test_advise_refuses_a_target_that_is_not_a_number_between_0_and_1(target):
    """A target given as text, True or None is no relative error (``math.isfinite`` of a string
    raises TypeError, a traceback), nor is 1: one line naming ``target``, as for 2."""
    with pytest.raises(StudyError, match=r"target: .* -- a relative error between 0 and 1"):
        gearsweep.advise(str(ROOT / "studies" / "fig08_rattle.yaml"), target=target)

"""Chunked execution in-process: checkpoints and resume, estimates and limits, bad cases, outputs.

The dask backends are tested in ``test_cluster.py`` (real scheduler and worker processes).
"""

from __future__ import annotations

import dataclasses
import errno
import os
import re
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import netCDF4
import numpy as np
import pytest
import xarray as xr
from conftest import RATTLE_SCENE, Crash, CrashAfter

from gearsweep.cli import main
from gearsweep.errors import ClusterError, LimitError, ResultError
from gearsweep.study import execute
from gearsweep.study.checkpoint import (
    ChunkStore,
    chunk_folder,
    remove_checkpoints,
    saved_layout,
)
from gearsweep.study.dataset import write_netcdf
from gearsweep.study.execute import (
    Limits,
    check_limits,
    chunks_to_run,
    estimate,
    run_plan,
    run_to_file,
)
from gearsweep.study.filelayout import output_bound
from gearsweep.study.plan import make_plan
from gearsweep.study.resultfile import boxes
from gearsweep.study.schema import parse_study
from gearsweep.study.workspace import saved_chunks

ROOT = Path(__file__).resolve().parents[1]

RATTLE = "title: rattle, continued both ways\n" + RATTLE_SCENE + """sweep:
  speed: {start: 3000 rpm, stop: 12000 rpm, num: 12}
  damping: {start: 50 N*s/m, stop: 400 N*s/m, num: 12}
continuation: [up, down]
solver: {method: rk4, steps_per_period: 32, transient_periods: 40, record_periods: 20}
"""
"""288 cases in 12 lanes (one continued sweep per damping value) of 2 x 12 speeds; with
``CHUNK = 48`` cases, 6 chunks of 2 whole sweeps (each a kernel call per speed and direction)."""

CHUNK = 48

LONG = "title: rattle, long transients\n" + RATTLE_SCENE + """sweep:
  speed: {start: 3000 rpm, stop: 12000 rpm, num: 50}
  damping: {start: 50 N*s/m, stop: 400 N*s/m, num: 40}
solver: {method: rk4, steps_per_period: 64, transient_periods: 3000, record_periods: 1000}
"""
"""2000 independent cases of 256k steps: 5e8 steps, a few seconds; 20 chunks of 100 cases."""


def plan_of(text: str):
    return make_plan(parse_study(text), text)


EVERY_RUN = ("history", "elapsed_seconds", "kernel_seconds")
"""Attributes that differ between any two runs of a study: the time stamp, the timings."""

RESUMED = ("run_chunks", "run_elapsed_seconds", "run_kernel_seconds")
"""Attributes that only a resumed result has (``resultfile.run_attrs``): each run's chunks and
timings, one per line of its ``history`` (tested: ``test_a_resumed_result_records_every_run``)."""


def strip(ds: xr.Dataset, resumed: bool = False) -> xr.Dataset:
    """The Dataset without the attributes that differ between runs (``EVERY_RUN``) and, for a
    ``resumed`` result, without those that only a resumed result has (``RESUMED``: each must
    be there)."""
    ds = ds.copy()
    for k in EVERY_RUN:
        ds.attrs.pop(k, None)
    if resumed:
        for k in RESUMED:
            assert k in ds.attrs, k
            del ds.attrs[k]
    return ds


def assert_same(a: xr.Dataset, b: xr.Dataset, resumed: bool = False) -> None:
    """Bitwise-equal data, coordinates and attributes (NaN equal to NaN); ``resumed``: ``a``
    is a resumed result, ``b`` one made in one run (``strip``)."""
    xr.testing.assert_identical(strip(a, resumed), strip(b))


@pytest.fixture(scope="module")
def rattle_reference() -> xr.Dataset:
    """The continued rattle study in one chunk, in-process (the reference for every backend)."""
    plan = plan_of(RATTLE)
    ds = run_plan(plan, chunk_cases=plan.n_cases)
    assert ds.attrs["cases"] == 288
    return ds


def read_log(path: Path) -> list[tuple[int, int]]:
    if not path.exists():
        return []
    return [tuple(map(int, line.split())) for line in path.read_text().splitlines()]


def test_chunking_does_not_change_results(rattle_reference):
    """6 chunks of 2 whole sweeps give bitwise the numbers of one chunk of 12 sweeps."""
    plan = plan_of(RATTLE)
    assert len(plan.chunks(execute.lanes_per_chunk(plan, CHUNK))) == 6
    assert_same(run_plan(plan, chunk_cases=CHUNK), rattle_reference)
    assert set(rattle_reference["direction"].values) == {"up", "down"}
    assert (rattle_reference["status"] != 3).all()


def _interrupted(tmp_path: Path, monkeypatch, crash_after: int):
    """(chunk log, output, plan, chunks) after a checkpointed run of RATTLE that crashed after
    ``crash_after`` chunks."""
    log = tmp_path / "chunks.log"
    monkeypatch.setenv("GEARSWEEP_CHUNK_LOG", str(log))
    out = tmp_path / "r.nc"
    plan = plan_of(RATTLE)
    chunks = plan.chunks(execute.lanes_per_chunk(plan, CHUNK))
    with pytest.raises(Crash):
        run_plan(plan, backend=CrashAfter(crash_after), checkpoint=out, chunk_cases=CHUNK)
    return log, out, plan, chunks


def test_resume_after_crash_computes_only_missing_chunks(rattle_reference, tmp_path, monkeypatch):
    log, out, plan, chunks = _interrupted(tmp_path, monkeypatch, 3)
    first = read_log(log)
    assert first == chunks[:3]
    folder = chunk_folder(out)
    assert len(list(folder.glob("*/chunk_*.npys"))) == 3
    log.unlink()
    ds = execute.run_to_file(plan, out, chunk_cases=CHUNK)
    assert read_log(log) == chunks[3:]  # nothing computed twice
    assert not folder.exists()  # checkpoints removed once the file is written
    assert_same(ds, rattle_reference, resumed=True)
    with xr.open_dataset(out) as back:
        assert_same(back.load(), rattle_reference, resumed=True)


def test_changed_study_does_not_reuse_chunks(tmp_path, monkeypatch):
    log = tmp_path / "chunks.log"
    monkeypatch.setenv("GEARSWEEP_CHUNK_LOG", str(log))
    out = tmp_path / "r.nc"
    plan = plan_of(RATTLE)
    with pytest.raises(Crash):
        run_plan(plan, backend=CrashAfter(4), checkpoint=out, chunk_cases=CHUNK)
    changed = RATTLE.replace("backlash: 0.2 mm", "backlash: 0.3 mm")
    plan2 = plan_of(changed)
    log.unlink()
    ds = execute.run_to_file(plan2, out, chunk_cases=CHUNK)
    assert read_log(log) == plan2.chunks(execute.lanes_per_chunk(plan2, CHUNK))  # all of them
    assert_same(ds, run_plan(plan2))
    assert "backlash: 0.3 mm" in ds.attrs["study"]
    assert not chunk_folder(out).exists()  # the stale chunks of the first study went too


def test_an_edit_that_changes_no_value_keeps_the_saved_chunks(tmp_path, monkeypatch):
    """A comment added and the spacing changed: the same study (its key is of the validated
    study, not of the text), so the chunks an interrupted run saved are used; the result file
    keeps the new text. Changed values make another study (the test above)."""
    log, out, plan, chunks = _interrupted(tmp_path, monkeypatch, 3)
    edited = "# the same study, commented\n" + RATTLE.replace("backlash: 0.2 mm",
                                                             "backlash:    0.2 mm   # total")
    plan2 = plan_of(edited)
    assert plan2.text != plan.text and plan2.study_key == plan.study_key
    assert plan_of(RATTLE.replace("backlash: 0.2 mm", "backlash: 0.3 mm")).study_key \
        != plan.study_key
    log.unlink()
    ds = execute.run_to_file(plan2, out, chunk_cases=CHUNK)
    assert read_log(log) == chunks[3:]  # the three saved chunks were used
    assert ds.attrs["study"].startswith("# the same study, commented")
    assert_same(ds, run_plan(plan2), resumed=True)  # bitwise the uninterrupted run of the
    # edited study


def test_device_auto_without_a_gpu_resumes_a_cpu_run_and_the_other_way(tmp_path, monkeypatch):
    """The key is of the device the chunks run on: ``auto`` on a machine without a GPU is the
    study with ``cpu`` (``--device cpu`` resumes a run of ``device: auto`` and the other way);
    with a GPU, ``auto`` runs there, and the ``cpu`` study is another."""
    from gearsweep.kernels import cuda

    log, out, plan, chunks = _interrupted(tmp_path, monkeypatch, 3)  # device: cpu (default)
    auto = RATTLE + "  device: auto\n"
    auto = auto.replace("record_periods: 20}\n  device: auto\n",
                        "record_periods: 20, device: auto}\n")
    monkeypatch.setattr(cuda, "gpu_present", lambda: False)
    plan2 = plan_of(auto)
    assert plan2.study.solver.device == "auto" and plan2.study_key == plan.study_key
    log.unlink()
    ds = execute.run_to_file(plan2, out, chunk_cases=CHUNK)
    assert read_log(log) == chunks[3:]  # the cpu run's three saved chunks were used
    assert_same(ds, run_plan(plan2), resumed=True)  # bitwise the uninterrupted run of the auto
    # study
    monkeypatch.setattr(cuda, "gpu_present", lambda: True)
    assert plan_of(auto).study_key != plan.study_key


def test_unreadable_or_foreign_chunks_are_recomputed(rattle_reference, tmp_path, monkeypatch):
    """Chunk files cut short (in a header, in the last array: a process killed mid-write never
    leaves one, a machine that lost power can, as chunk files are not fsync'ed), left empty, or of
    the wrong shape are computed again, not trusted; the intact one is reused."""
    log = tmp_path / "chunks.log"
    monkeypatch.setenv("GEARSWEEP_CHUNK_LOG", str(log))
    out = tmp_path / "r.nc"
    plan = plan_of(RATTLE)
    chunks = plan.chunks(execute.lanes_per_chunk(plan, CHUNK))
    assert len(chunks) >= 6
    with pytest.raises(Crash):
        run_plan(plan, backend=CrashAfter(5), checkpoint=out, chunk_cases=CHUNK)
    store = ChunkStore(out, plan.study_key, plan.n_lanes, chunks)
    p0, p3 = store.path(*chunks[0]), store.path(*chunks[3])
    p0.write_bytes(p0.read_bytes()[:100])
    store.save(*chunks[1], {"status": np.zeros(3, np.int8)})
    store.path(*chunks[2]).write_bytes(b"")
    p3.write_bytes(p3.read_bytes()[:-1])
    log.unlink()
    ds = run_plan(plan, checkpoint=out, chunk_cases=CHUNK)
    assert sorted(read_log(log)) == sorted([*chunks[:4], *chunks[5:]])  # chunks[4] reused
    assert_same(ds, rattle_reference, resumed=True)
    assert list(ds.attrs["run_chunks"]) == [1, 5]  # what each run computed of the result


def test_a_chunk_saved_by_an_older_gearsweep_without_a_newer_variable_is_recomputed(
        rattle_reference, tmp_path, monkeypatch):
    """The version in the manifest stays 0.1.0 between commits: a chunk an earlier gearsweep
    saved before ``transient_left`` was recorded (27 Nov 2026) has every other array right. It
    is computed again, not written with a hole where the new variable is; the intact ones are
    reused."""
    log, out, plan, chunks = _interrupted(tmp_path, monkeypatch, 3)
    store = ChunkStore(out, plan.study_key, plan.n_lanes, chunks)
    old = store.load(*chunks[1])
    assert "transient_left" in old
    del old["transient_left"]
    store.save(*chunks[1], old)
    log.unlink()
    ds = run_plan(plan, checkpoint=out, chunk_cases=CHUNK)
    assert read_log(log) == chunks[1:2] + chunks[3:]  # chunks 0 and 2 reused
    assert_same(ds, rattle_reference, resumed=True)
    assert np.isfinite(ds["transient_left"]).all()


def test_a_resumed_run_keeps_the_saved_chunk_layout(rattle_reference, tmp_path, monkeypatch):
    """Resumed with another chunk size (another --chunk-size or --workers count), a run
    keeps the interrupted run's layout and computes only the chunks not saved; with nothing saved,
    or once the result is complete, the chunk size asked for applies."""
    log = tmp_path / "chunks.log"
    monkeypatch.setenv("GEARSWEEP_CHUNK_LOG", str(log))
    out = tmp_path / "r.nc"
    plan = plan_of(RATTLE)
    chunks = plan.chunks(execute.lanes_per_chunk(plan, CHUNK))
    other = plan.chunks(execute.lanes_per_chunk(plan, 96))
    assert set(chunks) != set(other)
    with pytest.raises(Crash):
        run_plan(plan, backend=CrashAfter(2), checkpoint=out, chunk_cases=CHUNK)
    assert saved_chunks(plan, out, 96) == (2, len(chunks))  # what the CLI says on resuming
    log.unlink()
    ds = run_plan(plan, checkpoint=out, chunk_cases=96)
    assert read_log(log) == chunks[2:]  # the two saved chunks were used, in their layout
    assert_same(ds, rattle_reference, resumed=True)
    remove_checkpoints(out)
    log.unlink()
    run_plan(plan, checkpoint=out, chunk_cases=96)
    assert read_log(log) == other


def test_the_cli_resumes_in_the_saved_chunks_and_says_so(rattle_reference, tmp_path, monkeypatch,
                                                          capsys):
    """`gearsweep run` with another --chunk-size after an interrupted run: a note says the saved
    chunks are kept, only the others are computed, and the file is the uninterrupted result."""
    log = tmp_path / "chunks.log"
    monkeypatch.setenv("GEARSWEEP_CHUNK_LOG", str(log))
    study, out = tmp_path / "r.yaml", tmp_path / "r.nc"
    study.write_text(RATTLE, encoding="utf-8")
    plan = plan_of(RATTLE)
    chunks = plan.chunks(execute.lanes_per_chunk(plan, CHUNK))
    with pytest.raises(Crash):
        execute.run_to_file(plan, out, backend=CrashAfter(2), chunk_cases=CHUNK)
    assert main(["run", str(study), "-o", str(out), "--estimate"]) == 0
    assert f"2 of {len(chunks)} chunks already saved in" in capsys.readouterr().out
    log.unlink()
    assert main(["run", str(study), "-o", str(out), "--chunk-size", "96", "--yes"]) == 0
    cap = capsys.readouterr()
    err = cap.err
    n = len(chunks)  # the summary says what this run computed (it said all the cases' time)
    assert cap.out.startswith(f"{out}: 288 cases (resumed: 2 of {n} chunks from an earlier"
                              f" run, {n - 2} computed now) in ")
    assert f"resuming in the interrupted run's {len(chunks)} chunks" in err
    assert "the chunks of --chunk-size apply to a fresh run" in err
    assert f"resuming: 2 of {len(chunks)} chunks already saved" in err
    assert read_log(log) == chunks[2:]
    with xr.open_dataset(out) as ds:
        assert_same(ds.load(), rattle_reference, resumed=True)


class CrashAtTheEnd(execute.InProcess):
    """In-process backend that dies once every chunk is computed and saved (the result not
    written: a full disk at the end, say)."""

    def run(self, plan, todo):
        yield from super().run(plan, todo)
        raise Crash


def test_a_resume_with_every_chunk_saved_says_it_writes_the_result(rattle_reference, tmp_path,
                                                                     capsys):
    """A resume after a full disk said "resuming: 22 of 22 chunks already saved ..., computing
    the others" with nothing left to compute (an outside tester's finding), and --estimate "a
    run computes only the others": both say that the run writes the result."""
    study, out = tmp_path / "r.yaml", tmp_path / "r.nc"
    study.write_text(RATTLE, encoding="utf-8")
    plan = plan_of(RATTLE)
    n = len(plan.chunks(execute.lanes_per_chunk(plan, CHUNK)))
    with pytest.raises(Crash):
        execute.run_to_file(plan, out, backend=CrashAtTheEnd(), chunk_cases=CHUNK)
    assert saved_chunks(plan, out, CHUNK) == (n, n)
    assert main(["run", str(study), "-o", str(out), "--estimate"]) == 0
    said = capsys.readouterr().out
    assert (f"all {n} chunks already saved in {out}.chunks: a run writes the result from them"
            " (the estimate is for them all)") in said, said
    assert main(["run", str(study), "-o", str(out), "--yes"]) == 0
    err = capsys.readouterr().err
    assert f"{out}: all {n} chunks already saved in {out}.chunks, writing the result" in err, err
    assert "computing the others" not in err
    with xr.open_dataset(out) as ds:
        assert_same(ds.load(), rattle_reference, resumed=True)


@pytest.mark.parametrize("guard", ["warn", "off"])
def test_a_prepared_chunk_gives_run_chunk_s_arrays_bit_for_bit(guard):
    """``InProcess`` runs a chunk that is one kernel call as ``prepare`` (in a helper thread) and
    ``run_prepared`` (its arrays made later, in the writer thread): the arrays equal
    ``run_chunk``'s bit for bit, in the same order; a continued sweep is not prepared (``None``:
    ``run_chunk`` computes it whole)."""
    from gearsweep.study.chunk import prepare, run_chunk, run_prepared

    text = RATTLE.replace("continuation: [up, down]\n", "").replace(
        "speed: {start: 3000 rpm", "speed: {start: 200 rpm").replace(
        "record_periods: 20}", f"record_periods: 20, step_guard: '{guard}'}}")
    plan = plan_of(text)
    a, b = plan.chunks(execute.lanes_per_chunk(plan, 40))[0]  # 200 rpm and up
    want = run_chunk(plan, a, b)
    got = run_prepared(plan, prepare(plan, a, b))()
    assert list(got) == list(want)
    assert ("beyond_step_limit" in got) == (guard == "warn")
    if guard == "warn":
        assert got["beyond_step_limit"].any()  # 200 rpm: a step beyond the limit
    for name in want:
        assert got[name].dtype == want[name].dtype, name
        np.testing.assert_array_equal(got[name], want[name], err_msg=name)
    assert prepare(plan_of(RATTLE), 0, 1) is None


def _records(out: Path, plan) -> dict[str, dict]:
    """What the runs recorded in the checkpoint folder (``checkpoint.RUNS``), by run in the
    order they started: their history line, the chunks they saved, and their elapsed and
    kernel seconds at their last saved chunk."""
    import json

    runs: dict[str, dict] = {}
    path = chunk_folder(out) / plan.study_key / "runs.jsonl"
    for line in path.read_text(encoding="utf-8").splitlines():
        rec = json.loads(line)
        run = runs.setdefault(rec["run"], {"chunks": []})
        if "history" in rec:
            run["history"] = rec["history"]
        else:
            run["chunks"].append(tuple(rec["chunk"]))
            run["elapsed"], run["kernel"] = rec["elapsed"], rec["kernel"]
    return runs


def test_a_resumed_result_records_every_run(rattle_reference, tmp_path, monkeypatch, capsys):
    """Interrupted twice, then completed: the result's ``history`` has a line per run, oldest
    first (each run's command, from the record it kept in the checkpoint folder), its
    ``elapsed_seconds`` and ``kernel_seconds`` are the totals over the runs (the interrupted
    runs' as they recorded them at their last saved chunk), ``run_chunks``,
    ``run_elapsed_seconds`` and ``run_kernel_seconds`` give each run's share, and ``inspect``
    says it was resumed. The data are the uninterrupted run's, bit for bit. (A resumed file
    said only the last command, and gave its 0.8 s as the study's elapsed_seconds.)"""
    from gearsweep.cli import describe
    from gearsweep.study.provenance import command

    log = tmp_path / "chunks.log"
    monkeypatch.setenv("GEARSWEEP_CHUNK_LOG", str(log))
    out = tmp_path / "r.nc"
    plan = plan_of(RATTLE)
    chunks = plan.chunks(execute.lanes_per_chunk(plan, CHUNK))
    n = len(chunks)
    for name, k in (("first", 2), ("second", 1)):
        with command(["gearsweep", "run", f"{name}.yaml"]), pytest.raises(Crash):
            execute.run_to_file(plan, out, backend=CrashAfter(k), chunk_cases=CHUNK)
    runs = list(_records(out, plan).values())
    assert [r["chunks"] for r in runs] == [chunks[:2], chunks[2:3]]
    assert [r["history"].split(": ", 1)[1].split(" (")[0] for r in runs] == [
        "gearsweep run first.yaml", "gearsweep run second.yaml"]
    with command(["gearsweep", "run", "third.yaml"]):
        written = execute.stream_to_file(plan, out, chunk_cases=CHUNK)
    assert read_log(log) == chunks  # no chunk computed twice
    with xr.open_dataset(out) as ds:
        ds.load()
    assert_same(ds, rattle_reference, resumed=True)
    lines = ds.attrs["history"].split("\n")
    assert lines[:2] == [r["history"] for r in runs]  # oldest first, as CF appends
    assert re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ: gearsweep run third\.yaml \(.*\)",
                        lines[2]), lines
    assert list(ds.attrs["run_chunks"]) == [2, 1, n - 3]
    each = list(ds.attrs["run_elapsed_seconds"])
    assert each[:2] == [round(r["elapsed"], 3) for r in runs]  # as recorded, not guessed
    assert ds.attrs["elapsed_seconds"] == round(sum(each), 3)
    kernel = list(ds.attrs["run_kernel_seconds"])
    assert kernel[:2] == [round(r["kernel"], 3) for r in runs]
    assert ds.attrs["kernel_seconds"] == round(sum(kernel), 3)
    assert all(0 < e for e in each) and all(0 <= k for k in kernel)
    assert (written.elapsed, written.run_elapsed) == (ds.attrs["elapsed_seconds"], each[2])
    assert (written.chunks, written.earlier_chunks, written.earlier_runs) == (n, 3, 2)
    text = describe(out)
    assert f"  history: {lines[0]}\n           {lines[1]}\n           {lines[2]}\n" in text
    assert (f"  resumed: 3 of {n} chunks from 2 earlier runs; chunk phase"
            f" {ds.attrs['elapsed_seconds']:.2f} s over the 3 runs (elapsed_seconds),"
            f" {each[2]:.2f} s in the last\n") in text
    # A result made in one run says nothing of the kind.
    fresh = tmp_path / "fresh.nc"
    with command(["gearsweep", "run", "fresh.yaml"]):
        execute.stream_to_file(plan, fresh, chunk_cases=CHUNK)
    with xr.open_dataset(fresh) as ds:
        assert "\n" not in ds.attrs["history"] and not set(RESUMED) & set(ds.attrs)
    assert "\n  resumed: " not in describe(fresh)


@pytest.mark.filterwarnings("ignore::gearsweep.errors.ChunkSizeWarning")  # small chunks: many
def test_gearsweep_run_with_an_output_resumes_with_every_run_recorded(tmp_path, monkeypatch):
    """``gearsweep.run(study, output=...)`` interrupted (its in-process backend raising after two
    chunks), then called again: the returned result has both runs' history lines and timings,
    and the data of the uninterrupted run."""
    import gearsweep

    text = RATTLE.replace("continuation: [up, down]\n", "")
    real = execute.InProcess.run

    def crashing(self, plan, todo):
        for i, item in enumerate(real(self, plan, todo)):
            if i == 2:
                raise Crash
            yield item

    out = tmp_path / "r.nc"
    monkeypatch.setattr(execute.InProcess, "run", crashing)
    with pytest.raises(Crash):
        gearsweep.run(text, output=out, chunk_cases=24)
    monkeypatch.setattr(execute.InProcess, "run", real)
    plan = plan_of(text)
    saved = _records(out, plan)
    assert [len(r["chunks"]) for r in saved.values()] == [2]
    ds = gearsweep.run(text, output=out, chunk_cases=24)
    n = len(execute.chunks_to_run(plan, None, 24))
    assert list(ds.attrs["run_chunks"]) == [2, n - 2]
    assert len(ds.attrs["history"].splitlines()) == 2
    assert ds.attrs["elapsed_seconds"] == round(sum(ds.attrs["run_elapsed_seconds"]), 3)
    assert ds.attrs["run_elapsed_seconds"][0] == round(next(iter(saved.values()))["elapsed"], 3)
    assert_same(ds.load(), gearsweep.run(text), resumed=True)


def test_earlier_runs_are_read_from_what_they_recorded(tmp_path):
    """``ChunkStore.earlier_runs``: a line cut short by a kill is skipped and the next run's lines
    start on a line of their own; a chunk saved again by a later run counts as that run's; a
    chunk saved without a record counts with the last run that saved any; a run none of whose
    chunks is used is left out; with no record at all, the chunks are an unrecorded run's."""
    from gearsweep.cli import _resumed_line
    from gearsweep.study.checkpoint import RUNS, RunLog
    from gearsweep.study.resultfile import UNRECORDED, run_attrs

    store = ChunkStore(tmp_path / "r.nc", "key", 8, [(0, 2), (2, 4), (4, 6), (6, 8)])
    store.open()
    gone = RunLog(store.folder, lambda: "t0: gone")  # its only chunk is not among the saved ones
    gone.chunk(6, 8, 0.5, 0.25)
    gone.close()
    one = RunLog(store.folder, lambda: "t1: one")
    one.chunk(0, 2, 1.0, 0.5)
    one.chunk(2, 4, 2.0, 1.0)
    one.close()
    with open(store.folder / RUNS, "ab") as fh:
        fh.write(b'{"run": "killed", "chunk": [4, ')  # cut short by a kill
    two = RunLog(store.folder, lambda: "t2: two")
    two.chunk(2, 4, 0.5, None)  # computed again (its file was unreadable, say)
    two.close()
    runs = store.earlier_runs([(0, 2), (2, 4), (4, 6)])  # (4, 6): saved, not recorded
    assert [(r.history, r.chunks, r.elapsed, r.kernel) for r in runs] == [
        ("t1: one", 1, 2.0, 1.0), ("t2: two", 2, 0.5, None)]
    made = run_attrs("t3: three", 1.5, 1.0, runs, chunks=1)
    assert made["history"] == "t1: one\nt2: two\nt3: three"
    assert list(made["run_chunks"]) == [1, 2, 1]
    assert made["elapsed_seconds"] == 4.0
    assert np.isnan(made["run_kernel_seconds"][1]) and np.isnan(made["kernel_seconds"])
    (store.folder / RUNS).unlink()
    runs = store.earlier_runs([(0, 2)])
    assert [(r.history, r.chunks) for r in runs] == [(None, 1)] and np.isnan(runs[0].elapsed)
    made = run_attrs("t3: three", 1.5, 1.0, runs, 3)
    assert made["history"] == f"{UNRECORDED}\nt3: three" and np.isnan(made["elapsed_seconds"])
    assert _resumed_line(made) == (  # what inspect says of it
        "resumed: 1 of 4 chunks from an earlier run; chunk phase unknown (an earlier run kept no"
        " record) over the 2 runs (elapsed_seconds), 1.50 s in the last")
    assert store.earlier_runs([]) == []


def test_streamed_counts_equal_the_file_s_after_a_resumed_run(tmp_path):
    """``stream_to_file`` counts the flagged cases and those beyond the step limit as it writes
    (the CLI reports them without opening the file again): after a run interrupted with two
    chunks saved and resumed, the counts include the saved chunks and equal the file's."""
    text = RATTLE.replace("continuation: [up, down]\n", "").replace(
        "damping: {start: 50 N*s/m, stop: 400 N*s/m, num: 12}",
        "mean_force: [200 N, 400 N, 1e308 N]").replace(
        "speed: {start: 3000 rpm", "speed: {start: 200 rpm")
    plan = plan_of(text)
    out = tmp_path / "r.nc"
    with pytest.raises(Crash):
        execute.stream_to_file(plan, out, backend=CrashAfter(2), chunk_cases=12)
    written = execute.stream_to_file(plan, out, chunk_cases=12)
    with xr.open_dataset(out) as ds:
        flagged = int((ds["status"] != 0).sum())
        beyond = int(ds["beyond_step_limit"].sum())
        assert written.cases == ds.attrs["cases"] == ds["status"].size
        assert written.elapsed == ds.attrs["elapsed_seconds"]
    assert flagged >= 12 and beyond > 0  # 1e308 N diverges at every speed; 200 rpm is coarse
    assert (written.flagged, written.beyond) == (flagged, beyond)


@pytest.mark.parametrize("edit", [
    lambda m: {**m, "chunks": [[0, float("inf")]]},  # written as Infinity
    lambda m: m | {"chunks": [[a, b] for a, b in m["chunks"]][::-1]},  # not increasing
    lambda m: m | {"chunks": [[0, 0], *m["chunks"]]},  # an empty range
    lambda m: m | {"chunks": [[0, m["n_lanes"] // 2], [m["n_lanes"] // 3, m["n_lanes"]]]},
    lambda m: m | {"n_lanes": m["n_lanes"] + 1},
    lambda m: m | {"gearsweep_version": "0.0.1"},
    lambda m: [m],
    lambda m: "[" * 100_000,  # nested too deep for the JSON reader
], ids=["infinity", "reversed", "empty-range", "overlap", "lanes", "version", "list", "deep"])
def test_a_damaged_manifest_starts_afresh(edit, rattle_reference, tmp_path):
    """A manifest that does not describe this study's chunks (damaged, or another version's) is
    no layout to resume: the run computes every chunk afresh, and the result is right."""
    import json

    out = tmp_path / "r.nc"
    plan = plan_of(RATTLE)
    with pytest.raises(Crash):
        run_plan(plan, backend=CrashAfter(2), checkpoint=out, chunk_cases=CHUNK)
    manifest = chunk_folder(out) / plan.study_key / "manifest.json"
    edited = edit(json.loads(manifest.read_text(encoding="utf-8")))
    manifest.write_text(edited if isinstance(edited, str) else json.dumps(edited),
                        encoding="utf-8")
    assert saved_layout(out, plan.study_key, plan.n_lanes) is None
    assert_same(run_plan(plan, checkpoint=out, chunk_cases=96), rattle_reference)


def test_resume_after_sigkill(tmp_path):
    """A real CLI process killed with SIGKILL partway, then resumed: same file, no chunk twice."""
    study = tmp_path / "long.yaml"
    study.write_text(LONG, encoding="utf-8")
    out = tmp_path / "long.nc"
    env = dict(os.environ, PYTHONPATH=str(ROOT), GEARSWEEP_CHUNK_LOG=str(tmp_path / "run1.log"))
    argv = [sys.executable, "-m", "gearsweep.cli", "run", str(study), "-o", str(out), "-q",
            "--chunk-size", "100"]
    proc = subprocess.Popen(argv, env=env, cwd=ROOT)
    folder = chunk_folder(out)
    deadline = time.monotonic() + 240
    try:
        while len(list(folder.glob("*/chunk_*.npys"))) < 3:
            assert proc.poll() is None, "the run ended before it could be killed"
            assert time.monotonic() < deadline, "no chunk written in time"
            time.sleep(0.01)
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(timeout=30)
    assert proc.returncode == -signal.SIGKILL
    assert not out.exists()
    plan = plan_of(LONG)
    chunks = plan.chunks(execute.lanes_per_chunk(plan, 100))
    assert len(chunks) == 20
    names = {p.name for p in folder.glob("*/chunk_*.npys")}
    kept = [c for c in chunks if f"chunk_{c[0]}_{c[1]}.npys" in names]
    assert 3 <= len(kept) < len(chunks), kept
    # Chunks logged by the killed run were all saved (the log line follows the rename).
    assert set(read_log(tmp_path / "run1.log")) <= set(kept)
    env["GEARSWEEP_CHUNK_LOG"] = str(tmp_path / "run2.log")
    subprocess.run(argv, env=env, cwd=ROOT, check=True, timeout=600)
    assert sorted(read_log(tmp_path / "run2.log")) == [c for c in chunks if c not in kept]
    assert not folder.exists()
    with xr.open_dataset(out) as resumed:
        assert_same(resumed.load(), run_plan(plan), resumed=True)
        # the killed run's line and timings, from its record of the chunks it saved
        assert len(resumed.attrs["history"].splitlines()) == 2
        assert list(resumed.attrs["run_chunks"]) == [len(kept), len(chunks) - len(kept)]


def test_estimate_matches_the_run(tmp_path):
    """Output size at least the Dataset's arrays (an upper bound of the file: checked against
    written files in tests/test_output_bound.py); time within a factor 4 of a measured run (this
    is a shared 2-core machine: a tighter bound would fail on load, a looser one would not catch
    an estimate that is off by an order of magnitude)."""
    plan = plan_of(LONG.replace("num: 50", "num: 10"))
    chunks = plan.chunks()
    threads = execute.cores()
    rate = execute.measure_rate(plan, __import__("numba").get_num_threads())
    est = estimate(plan, chunks, threads=threads, rate=rate)
    assert est.steps == 400 * 64 * 4000
    ds = run_plan(plan)
    data_bytes = sum(v.nbytes for v in ds.data_vars.values())
    assert est.output_bytes == output_bound(plan) >= data_bytes
    kernel = (est.seconds - execute.FIXED_SECONDS - est.output_bytes / execute.WRITE_RATE
              - len(chunks) * execute.CHUNK_OVERHEAD_SECONDS)
    assert kernel / 4 < ds.attrs["elapsed_seconds"] < 4 * kernel
    assert 0 < ds.attrs["kernel_seconds"] <= ds.attrs["elapsed_seconds"]
    assert "measured" in est.line() and "\n" not in est.line()


def test_limits_refuse_with_the_estimate():
    plan = plan_of(RATTLE)
    est = estimate(plan, plan.chunks(), threads=2)
    check_limits(est, "x.yaml")  # a small study passes
    with pytest.raises(LimitError) as err:
        check_limits(est, "x.yaml", Limits(seconds=0.1))
    msg = str(err.value)
    assert "\n" not in msg and "--yes" in msg and "288 cases" in msg and "time >" in msg
    assert est.over(Limits(output_bytes=1)) == ["output > 1 B"]


BIG = RATTLE.replace("stop: 12000 rpm, num: 12}", "stop: 12000 rpm, num: 4000000}")
"""96 million cases: refused by the limits (hours, gigabytes)."""


def test_cli_refuses_a_huge_study_and_estimates_it(tmp_path, capsys):
    """Refused in one line with its estimate, leaving nothing behind: no file, no checkpoint
    folder, and no output folder made for it (the writability check made the folders first)."""
    study = tmp_path / "big.yaml"
    study.write_text(BIG, encoding="utf-8")
    assert main(["run", str(study), "-o", str(tmp_path / "new" / "sub" / "big.nc")]) == 2
    assert "refused" in capsys.readouterr().err and not (tmp_path / "new").exists()
    out = tmp_path / "big.nc"
    assert main(["run", str(study), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "refused" in err and "--yes" in err and "96,000,000 cases" in err
    assert main(["run", str(study), "-o", str(out), "--estimate"]) == 0
    outp = capsys.readouterr().out
    assert outp.count("\n") == 1 and "96,000,000 cases" in outp and "GB" in outp
    assert not out.exists() and not chunk_folder(out).exists()


def test_cli_estimate_says_a_run_would_be_refused_for_another_study_s_chunks(tmp_path, capsys):
    """``--estimate`` to an output beside another study's saved chunks says, after the estimate,
    that the run would be refused and why (it said nothing, and the run was then refused; found
    by an outside test); the run itself is refused with that line, exit 2."""
    study = tmp_path / "r.yaml"
    study.write_text(RATTLE, encoding="utf-8")
    out = tmp_path / "r.nc"
    other = chunk_folder(out) / "another_study_key"
    other.mkdir(parents=True)
    (other / "chunk_0_5.npys").write_bytes(b"")
    assert main(["run", str(study), "-o", str(out), "--estimate"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 2 and lines[1].startswith(f"{study}: note: a run to this output would be"
                                                    f" refused: {out}: {chunk_folder(out)} holds 1"
                                                    " saved chunk(s) of another study"), lines
    assert main(["run", str(study), "-o", str(out), "-q"]) == 2
    assert "holds 1 saved chunk(s) of another study" in capsys.readouterr().err
    assert not out.exists()


def test_cli_yes_overrides_the_limits(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(execute, "LIMITS", Limits(seconds=0.01))
    study = tmp_path / "r.yaml"
    study.write_text(RATTLE, encoding="utf-8")
    out = tmp_path / "r.nc"
    assert main(["run", str(study), "-o", str(out), "-q"]) == 2
    assert "refused" in capsys.readouterr().err and not out.exists()
    assert main(["run", str(study), "-o", str(out), "-q", "--yes"]) == 0
    assert out.exists() and not chunk_folder(out).exists()


def test_unwritable_output_fails_before_the_run(tmp_path, capsys):
    """The output check comes first: a huge study confirmed with --yes fails at once."""
    study = tmp_path / "big.yaml"
    study.write_text(BIG, encoding="utf-8")
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    t0 = time.perf_counter()
    for out, says in ((blocker / "out.nc", "file is a file"), (blocker / "a" / "out.nc", "is a file"),
                      (tmp_path, "not a folder")):
        assert main(["run", str(study), "-o", str(out), "--yes"]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "--output" in err and says in err, err
    assert time.perf_counter() - t0 < 10  # no integration (the study would take hours)


def test_an_output_that_is_not_a_regular_file_or_is_the_study_is_refused(tmp_path, capsys):
    """The result is renamed over its path, so the path must be a regular file or nothing: a
    FIFO (like /dev/null, which ``-o /dev/null`` replaced with a file when run as root), the
    study file itself (replaced by the netCDF) and an empty ``-o`` are refused in one line before
    any computing, and left as they were; from Python, ``run_to_file`` refuses the FIFO too."""
    study = tmp_path / "big.study"  # (a .yaml output is refused for its name: another test)
    study.write_text(BIG, encoding="utf-8")
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    for out, says in ((fifo, "regular file"), (study, "study file"), ("", "empty")):
        assert main(["run", str(study), "-o", str(out), "--yes"]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "--output" in err and says in err, err
    assert stat.S_ISFIFO(os.stat(fifo).st_mode) and study.read_text(encoding="utf-8") == BIG
    with pytest.raises(ResultError, match="a device, a pipe or a socket"):
        run_to_file(plan_of(RATTLE), fifo)
    assert not chunk_folder(fifo).exists()


def test_an_output_that_holds_something_else_than_netcdf_is_refused(tmp_path, capsys):
    """A result may replace a netCDF file (an earlier result) or an empty one, not a file that
    holds something else: ``gearsweep.run(study, output=study)`` wrote the netCDF over the study
    file, and ``-o other.yaml`` over another study, without a word. Refused in one line before
    any computing, from Python and from the CLI, and the file is left as it was."""
    import gearsweep

    study = tmp_path / "rattle.study"  # (a .yaml output is refused for its name, before this
    study.write_text(RATTLE, encoding="utf-8")  # check: test_api)
    other = tmp_path / "other.txt"
    other.write_text("title: mine\n", encoding="utf-8")
    with pytest.raises(ResultError, match="a new path or a netCDF file"):
        gearsweep.run(str(study), output=study)
    assert main(["run", str(study), "-o", str(other)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "a new path or a netCDF file" in err, err
    assert study.read_text(encoding="utf-8") == RATTLE
    assert other.read_text(encoding="utf-8") == "title: mine\n"
    assert not chunk_folder(study).exists() and not chunk_folder(other).exists()
    # what a result may replace: an earlier result, an empty file, a netCDF after a user block
    result = tmp_path / "r.nc"
    write_netcdf(xr.Dataset({"x": ("i", np.arange(3.0))}), result)
    empty = tmp_path / "empty.nc"
    empty.touch()
    blocked = tmp_path / "ub.nc"
    blocked.write_bytes(bytes(512) + result.read_bytes())
    for path in (result, empty, blocked):
        write_netcdf(xr.Dataset({"y": ("i", np.arange(2.0))}), path)
        assert list(xr.load_dataset(path).data_vars) == ["y"]


def test_outputs_that_would_replace_inputs_or_cannot_be_named_are_one_line(tmp_path, capsys,
                                                                           monkeypatch):
    """Found by an adversarial test, each wrote over a file or ended in a traceback:
    ``-o new/../s.yaml`` (``new/`` made by the run) replaced the study file, ``-o data.csv`` the
    measured excitation the study reads, a 300-character name and a scheduler address without a
    port were tracebacks (exit 1), and ``transient_periods: 2e17`` an OverflowError with --yes.
    Each is one line and exit code 2 now, and the files are left as they were."""
    root = Path(__file__).resolve().parents[1]
    monkeypatch.chdir(tmp_path)
    (tmp_path / "data").mkdir()
    csv = (root / "studies/data/ste_table1.csv").read_bytes()
    (tmp_path / "data/ste_table1.csv").write_bytes(csv)
    text = (root / "studies/whine_measured_ste.yaml").read_text(encoding="utf-8")
    Path("s.yaml").write_text(text, encoding="utf-8")
    Path("lnk").symlink_to(tmp_path / "data")  # lnk/new/../../s.yaml is data/../s.yaml
    for out, says in (("new/../s.yaml", "a .yaml or .yml name is read as a study"),
                      ("lnk/new/../../s.yaml", "a .yaml or .yml name is read as a study"),
                      ("data/ste_table1.csv", "ste_table1.csv, which the study reads"),
                      ("new/../data/ste_table1.csv", "ste_table1.csv, which the study reads"),
                      ("x" * 300 + ".nc", "names of at most 255 bytes"),
                      ("x" * 300 + "/r.nc", "names of at most 255 bytes"),
                      ("new/" + "x" * 300 + "/../r.nc", "names of at most 255 bytes"),
                      ("x" * 240 + ".nc", "a file name of at most 237 bytes"),
                      ("s.yaml/../r.nc", "a path in a folder (s.yaml is a file)"),
                      ("newdir/", "a file path, not a folder"),
                      ("-", "not written to stdout")):  # it wrote a file named '-'
        assert main(["run", "s.yaml", "-o", out]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "--output" in err and says in err, err
    assert Path("s.yaml").read_text(encoding="utf-8") == text and not Path("new").exists()
    assert (tmp_path / "data/ste_table1.csv").read_bytes() == csv
    assert not Path("newdir").exists() and not (tmp_path / "data/new").exists()
    assert not Path("-").exists()
    # an analysis study's input result, from the CLI and from Python (both wrote over it)
    (tmp_path / "res").mkdir()
    rattle = tmp_path / "res" / "fig08_rattle.nc"
    write_netcdf(xr.Dataset({"x": ("i", np.arange(3.0))}), rattle)
    before = rattle.read_bytes()
    balance = str(root / "studies/fig08_rattle_balance.yaml")
    assert main(["run", balance, "-o", str(rattle)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "fig08_rattle.nc, which the study reads" in err, err
    import gearsweep

    with pytest.raises(ResultError, match="it is fig08_rattle.nc, which the study reads"):
        gearsweep.run(balance, output=rattle)
    assert rattle.read_bytes() == before
    for address in ("notaurl", "tcp://localhost", "tcp://host:port", "tcp://localhost:99999",
                    "tcp://localhost:0", "tls://localhost:8786"):  # tls: a TypeError traceback
        assert main(["run", "s.yaml", "-o", "r.nc", "--scheduler", address]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "--scheduler" in err and "tcp://HOST:PORT" in err, err
    Path("m.yaml").write_text("title: m\nscene: {kind: mathieu, alpha: 1.0, beta: 0.1, gamma:"
                              " 0.01}\nsolver: {transient_periods: 200000000000000000}\n")
    assert main(["run", "m.yaml", "-o", "m.nc", "--yes"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "solver.transient_periods" in err, err


def test_a_result_given_as_a_study_and_a_text_given_as_a_result_are_one_line(tmp_path, capsys):
    """``advise``/``validate``/``run`` on a netCDF result say it is one (was "a readable UTF-8
    file (not UTF-8 text)"); ``inspect`` on a text file says it is not netCDF in one line (was
    three, with xarray's engine list and two URLs)."""
    result = tmp_path / "r.nc"
    write_netcdf(xr.Dataset({"x": ("i", np.arange(3.0))}), result)
    for command in ("advise", "validate", "run"):
        assert main([command, str(result)]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "this is a netCDF result" in err, err
    text = tmp_path / "notes.txt"
    text.write_text("not a result\n", encoding="utf-8")
    assert main(["inspect", str(text)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "not a netCDF file" in err, err
    for missing, why in ((tmp_path / "none.nc", "No such file or directory"),
                         (tmp_path / ("x" * 300 + ".nc"), "File name too long")):
        assert main(["inspect", str(missing)]) == 2  # a long name: three warnings of xarray's
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and f"no result file there ({why})" in err, err
    # a netCDF file of someone else's: said "(no title) scene ?" and exit 0 (adversarial test)
    assert main(["inspect", str(result)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "not a gearsweep result (no 'study' attribute)" in err, err


def test_pathological_cases_are_flagged_not_fatal():
    """An absurd force (overflows to inf) and negative damping (grows without bound) are flagged
    status 1 (diverged); the other cases of the same kernel blocks are bitwise unaffected."""
    text = RATTLE.replace("continuation: [up, down]\n", "").replace(
        "damping: {start: 50 N*s/m, stop: 400 N*s/m, num: 12}",
        "mean_force: [200 N, 400 N, 1e308 N]")
    plan = plan_of(text)
    ds = run_plan(plan)
    status = ds["status"].transpose("speed", "mean_force").values
    assert (status[:, 2] == 1).all()
    assert (status[:, [0, 1]] != 1).all()
    assert np.isnan(ds["p_rms"].sel(mean_force=1e308)).all()
    good = run_plan(plan_of(text.replace(", 1e308 N", "")))
    assert_same_values(ds.sel(mean_force=[200.0, 400.0]), good)
    # Negative damping (refused by the loader, forced here): every case diverges, none aborts.
    # The step guard's stability polynomial is defined for c >= 0 only and refuses such a plan
    # outright (one GearsweepError line), so the guard is off for this part.
    plan = plan_of(text.replace("record_periods: 20}", "record_periods: 20, step_guard: 'off'}"))
    neg = dataclasses.replace(plan, model=dataclasses.replace(plan.model, damping=-2000.0))
    ds = run_plan(neg)
    assert (ds["status"] == 1).all() and ds["p_rms"].isnull().all()


WILD_WHINE = """title: 27/41 whine at a step beyond RK4's limit
scene:
  kind: whine
  gear: {module: 2.5 mm, z1: 27, z2: 41, face_width: 18 mm, x1: 0.3, x2: -0.1, backlash: 0.1 mm}
  torque: 150 N*m
  drive: {inertia_1: 5e-4 kg m^2, inertia_2: 3e-3 kg m^2}
  damping: 2 N*s/mm
sweep:
  speed: [500 rpm, 600 rpm]
solver: {method: rk4, steps_per_period: STEPS, transient_periods: 100, record_periods: 50,
         step_guard: 'off'}
outputs: [stats]
"""


def test_a_case_whose_p_left_the_divergence_bound_between_checks_is_diverged():
    """An outside engineer's 27/41 whine scene at 48 RK4 steps per mesh period, 500 rpm (beyond
    the method's stability limit there): p_max 2.5e9 um, p_min -3.9e9 um, status 0 (ok) and
    settle_error 0, although the status's codes say 1 where p exceeded divergence_factor (1e6)
    x its static scale (12.5 um here: the bound 1.25e7 um). The kernel checks the bound once per
    mesh period, and p was back inside at each check. Now the case is diverged, its values NaN;
    600 rpm and the 64-step run are unchanged."""
    import yaml

    import gearsweep

    ds = gearsweep.run(yaml.safe_load(WILD_WHINE.replace("STEPS", "48")))
    assert int(ds.status.sel(speed=500)) == 1
    assert np.isnan(ds.p_max.sel(speed=500)) and np.isnan(ds.p_pp.sel(speed=500))
    assert not bool(ds.contact_lost.sel(speed=500))  # from the p thrown away (an outside tester)
    fine = gearsweep.run(yaml.safe_load(WILD_WHINE.replace("STEPS", "64")))
    assert (fine.status == 0).all() and (ds.status.sel(speed=600) == 0)
    assert float(np.abs(fine.p_max).max()) < 100.0  # um: the static deflection's order


def assert_same_values(a: xr.Dataset, b: xr.Dataset) -> None:
    for name in b.data_vars:
        np.testing.assert_array_equal(a[name].values, b[name].values, err_msg=name)


def test_progress_per_chunk_on_stderr_only_when_asked(capsys):
    plan = plan_of(RATTLE)
    run_plan(plan, chunk_cases=CHUNK, progress=True)
    err = capsys.readouterr().err
    assert "288/288" in err and "case" in err  # tqdm's final state: every case counted
    run_plan(plan, chunk_cases=CHUNK, progress=False)
    captured = capsys.readouterr()
    assert captured.err == "" and captured.out == ""


def test_progress_for_a_log_is_plain_lines_not_too_often(capsys, monkeypatch):
    """Without a terminal (a batch log) the CLI asks for ``progress="log"``: it printed nothing
    until the end (an engineer new to the tool). One plain line per finished chunk at most every
    ``LOG_PROGRESS_SECONDS`` (0 here: every chunk but the last), none for a run shorter than
    it (the default: this run takes well under 30 s)."""
    plan = plan_of(RATTLE)
    run_plan(plan, chunk_cases=CHUNK, progress="log")
    assert capsys.readouterr().err == ""
    monkeypatch.setattr(execute, "LOG_PROGRESS_SECONDS", 0.0)
    run_plan(plan, chunk_cases=CHUNK, progress="log")
    lines = capsys.readouterr().err.splitlines()
    chunks = -(-288 // CHUNK)
    assert len(lines) == chunks - 1, lines
    done = [int(re.match(r"gearsweep: (\d+) of 288 cases \((\d+)%\), [0-9.]+ \w+ so far"
                         r"(, about [0-9.]+ \w+ left)?$", ln).group(1)) for ln in lines]
    assert done == sorted(done) and done[-1] < 288 and done[0] > 0


def test_result_file_has_ordinary_permissions(tmp_path):
    """The atomic writer's temporary file is private (mkstemp: 0600); the result must not be."""
    umask = os.umask(0o022)
    try:
        out = tmp_path / "r.nc"
        execute.run_to_file(plan_of(RATTLE), out)
        assert out.stat().st_mode & 0o777 == 0o644
    finally:
        os.umask(umask)


def test_run_to_file_streams_results_without_full_arrays(rattle_reference, tmp_path, monkeypatch):
    """``run_to_file`` never builds the full-size result arrays (its memory depends on the chunk
    size only): the file is written chunk by chunk as they finish, and equals the in-memory
    result."""

    def no_full_arrays(plan):
        raise AssertionError("run_to_file built the full result arrays")

    from gearsweep.study import dataset

    monkeypatch.setattr(dataset, "empty_results", no_full_arrays)  # what run_plan builds them with
    out = tmp_path / "s.nc"
    ds = execute.run_to_file(plan_of(RATTLE), out, chunk_cases=CHUNK)
    assert not ds["p_pp"].variable._in_memory  # the file opened lazily
    assert_same(ds.load(), rattle_reference)
    ds.close()
    with netCDF4.Dataset(out) as nc:  # chunked (filelayout.file_chunks), compressed
        assert nc["p_pp"].chunking() != "contiguous"


def _file_layout(path: Path) -> dict:
    """Per variable of a netCDF file: dims, dtype, chunking, filters, attributes; and the
    global attributes' names in order."""
    with netCDF4.Dataset(path) as nc:
        out = {name: (v.dimensions, v.dtype, v.chunking(), v.filters(),
                      {k: str(v.getncattr(k)) for k in v.ncattrs()})
               for name, v in nc.variables.items()}
        out["(global)"] = list(nc.ncattrs())
    return out


@pytest.mark.parametrize("text, chunk", [(RATTLE, CHUNK), (LONG.replace(
    "transient_periods: 3000, record_periods: 1000", "transient_periods: 30, record_periods: 10"),
    170)])
def test_streamed_file_is_the_in_process_file(text, chunk, tmp_path):
    """The file ``run_to_file`` writes as the chunks finish (chunks of 170 cases: not whole rows
    of 40 dampings, so most chunks are written as several hyperslabs) holds the data, the
    coordinates, the attributes and the encoding (codec, file chunks) that ``write_netcdf``
    gives the in-memory result of ``run_plan``: bitwise."""
    plan = plan_of(text)
    ref = tmp_path / "in_memory.nc"
    write_netcdf(run_plan(plan), ref)
    out = tmp_path / "streamed.nc"
    execute.run_to_file(plan, out, chunk_cases=chunk).close()
    with xr.open_dataset(ref) as a, xr.open_dataset(out) as b:
        assert_same(a.load(), b.load())
    assert _file_layout(ref) == _file_layout(out)


def test_boxes_cover_a_lane_range_in_order():
    """``resultfile.boxes``: any lane range of a C-order grid as consecutive boxes, whole rows in one."""
    shape = [4, 3, 5]
    grid = np.arange(60).reshape(shape)
    for a in range(0, 61, 7):
        for b in range(a, 61, 11):
            got_boxes = boxes(a, b, shape)
            got = np.concatenate([grid[tuple(slice(*s) for s in box)].ravel()
                                  for _, _, box in got_boxes] or [np.array([], int)])
            assert got.tolist() == list(range(a, b))
            assert [x for x, _, _ in got_boxes] == sorted(x for x, _, _ in got_boxes)
    assert len(boxes(15, 45, shape)) == 1  # rows 1 and 2 whole: one box


def test_xarray_still_sees_dask_arrays_and_pint_quantities_after_the_lazy_probes():
    """``study.dataset`` lets xarray test for dask arrays and pint quantities without importing
    dask or pint (0.4 s of every run): once they are imported, xarray must still keep a pint
    quantity and a dask array as they are, and a NumPy array as NumPy."""
    import subprocess
    import sys

    code = """
import sys
import numpy as np
import gearsweep.study.dataset
import xarray as xr
v = xr.Variable("x", np.arange(3.0))
assert type(v.data) is np.ndarray
assert "dask" not in sys.modules and "pint" not in sys.modules, "probes imported them"
import dask.array as da
import pint
q = pint.UnitRegistry().Quantity(np.arange(3.0), "m")
assert type(xr.Variable("x", q).data).__name__ == "Quantity"
d = xr.DataArray(da.ones(4, chunks=2))
assert d.chunks == ((2, 2),) and type(d.data).__module__.startswith("dask")
assert xr.DataArray(da.ones(4, chunks=2)).sum().compute() == 4
print("ok")
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "ok"


SHORT_ENDS = {
    # lanes, lanes per chunk: the chunks after with_short_ends on 2 cores (rounds of 64 lanes)
    (1_000_000, 273_408): [(0, 68352), (68352, 273408), (273408, 546816), (546816, 820224),
                           (820224, 955072), (955072, 1_000_000)],  # the 1e6-case study
    (10_000, 10_000): [(0, 2496), (2496, 8144), (8144, 10_000)],  # one chunk: both its ends
    (5000, 1024): [(0, 256), (256, 1024), (1024, 2048), (2048, 3072), (3072, 4096),
                   (4096, 4808), (4808, 5000)],
    (600, 100): [(a, a + 100) for a in range(0, 600, 100)],  # a quarter is under two rounds
    (100, 100): [(0, 100)],
}


@pytest.mark.parametrize("lanes, per_chunk", list(SHORT_ENDS))
def test_short_ends_cut_only_the_first_and_last_chunk(lanes, per_chunk):
    """``with_short_ends``: the first and the last chunk cut at a quarter, rounded down to whole
    rounds of kernel blocks (``LANES x threads`` = 64 lanes on 2 cores), never into a part under
    two rounds; the chunks between untouched; a GPU study's chunks left alone."""
    plan = plan_of(LONG)
    chunks = [(a, min(a + per_chunk, lanes)) for a in range(0, lanes, per_chunk)]
    assert execute.with_short_ends(plan, chunks, threads=2) == SHORT_ENDS[lanes, per_chunk]
    gpu = dataclasses.replace(plan, study=plan.study.model_copy(update={
        "solver": plan.study.solver.model_copy(update={"device": "cuda"})}))
    assert gpu.device == "cuda"
    assert execute.with_short_ends(gpu, chunks, threads=2) == chunks


def test_chunks_finishing_out_of_order_are_written_in_lane_order(tmp_path):
    """Dask workers finish chunks out of order; the writer puts them into the file in lane order
    (``execute.InLaneOrder``; the early ones wait in their checkpoint files), so the file is byte
    for byte the one an in-order run of the same chunks writes. Written as they arrive instead,
    a file chunk that two run chunks share is stored, read back and stored again, and the file
    grows (the 1e6-case study: 54.1 MB with 16 workers against 48.9 MB in-process)."""
    # 200,000 short cases: each variable several file chunks (1 MiB: 131,072 float64 cases),
    # more than HDF5's chunk cache holds; run chunks that end inside file chunks
    plan = plan_of(LONG.replace("num: 50", "num: 500").replace("num: 40", "num: 400").replace(
        "steps_per_period: 64, transient_periods: 3000, record_periods: 1000",
        "steps_per_period: 16, transient_periods: 2, record_periods: 2"))
    chunks = plan.chunks(30011)
    assert len(chunks) == 7 and plan.n_cases == 200_000
    arrays = {c: execute.run_chunk(plan, *c) for c in chunks}
    shuffled = [chunks[i] for i in np.random.default_rng(1).permutation(len(chunks))]
    assert shuffled != chunks

    def write(arrival: list[tuple[int, int]], name: str, ordered: bool = True) -> bytes:
        out = tmp_path / name
        store = ChunkStore(out, plan.study_key, plan.n_lanes, chunks)
        store.open()
        f = execute.ResultFile(plan, out)
        f.attrs["history"] = "the same for both"  # else a time stamp
        lanes = execute.InLaneOrder(chunks, store)
        for a, b in arrival:
            store.save(a, b, arrays[(a, b)])
            if ordered:
                lanes.add(f, a, b, arrays[(a, b)])
            else:
                f.write(a, b, arrays[(a, b)])
        if ordered:
            lanes.check()
        f.close(elapsed=1.0, kernel=0.5)
        return out.read_bytes()

    in_order = write(chunks, "in_order.nc")
    assert write(shuffled, "shuffled.nc") == in_order
    assert len(write(shuffled, "as_they_came.nc", ordered=False)) > len(in_order)


def test_a_chunk_that_never_arrives_is_an_error_not_a_hole(tmp_path):
    plan = plan_of(RATTLE)
    chunks = plan.chunks(4)
    lanes = execute.InLaneOrder(chunks, None)
    f = execute.ResultFile(plan, tmp_path / "r.nc")
    try:
        for c in chunks[1:]:
            lanes.add(f, *c, execute.run_chunk(plan, *c))
        with pytest.raises(RuntimeError, match="never reached"):
            lanes.check()
    finally:
        f.abort()


def test_a_result_file_that_cannot_be_made_stops_the_run_early(tmp_path, monkeypatch):
    """The result file is made in the writer thread beside the first chunks; if that fails (a
    full disk, say), the run stops with that error after a chunk or two, not after computing
    every chunk (the chunks computed are kept as checkpoints)."""
    plan = plan_of(LONG.replace("transient_periods: 3000, record_periods: 1000",
                                "transient_periods: 30, record_periods: 10"))
    log = tmp_path / "chunks.log"
    monkeypatch.setenv("GEARSWEEP_CHUNK_LOG", str(log))

    def full_disk(*args, **kwargs):
        time.sleep(0.05)  # fails while the first chunks compute
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(execute, "_result_file", full_disk)
    with pytest.raises(ResultError, match="cannot write: No space left on device; ") as err:
        execute.stream_to_file(plan, tmp_path / "r.nc", chunk_cases=100)
    assert 0 < len(read_log(log)) < len(plan.chunks(100)) // 2
    assert f" {len(read_log(log))} of " in str(err.value)  # the chunks saved, said


def test_a_dask_worker_s_full_disk_is_said_with_the_chunks_saved(tmp_path, monkeypatch):
    """A chunk that fails on a dask worker with an OSError (its own save to a full disk) gives
    the line of a full disk in-process, with the chunks saved; another failure stays the
    cluster's error."""
    plan = plan_of(LONG.replace("transient_periods: 3000, record_periods: 1000",
                                "transient_periods: 30, record_periods: 10"))

    def failing(cause):
        def compute(*args, **kwargs):
            try:
                raise cause
            except Exception as exc:
                raise ClusterError("local cluster: chunk of lanes 0-10 failed: ...") from exc
        return compute

    monkeypatch.setattr(execute, "_compute",
                        failing(OSError(errno.ENOSPC, "No space left on device")))
    with pytest.raises(ResultError, match=r"r.nc: a dask worker failed: No space left on"
                       r" device; 0 of \d+ chunks saved in .*: make room and run the same"):
        execute.stream_to_file(plan, tmp_path / "r.nc", chunk_cases=100)
    monkeypatch.setattr(execute, "_compute", failing(ValueError("a bug")))
    with pytest.raises(ClusterError, match="chunk of lanes 0-10 failed"):
        execute.stream_to_file(plan, tmp_path / "r.nc", chunk_cases=100)


def test_a_cluster_failure_says_the_chunks_saved_and_how_to_continue(tmp_path):
    """A run that loses its dask scheduler after some chunks (their files saved) says so in one
    line with the chunks saved and how to continue, as a full disk does; it said only that a
    chunk failed (an outside tester: a plain rerun then finished, identical)."""
    from distributed.client import FutureCancelledError

    plan = plan_of(LONG.replace("transient_periods: 3000, record_periods: 1000",
                                "transient_periods: 30, record_periods: 10"))

    class LosesItsScheduler(CrashAfter):
        def run(self, plan, todo):
            try:
                yield from super().run(plan, todo)
            except Crash:
                raise ClusterError("tcp://127.0.0.1:8786: lost the connection to the dask"
                                   " scheduler") from FutureCancelledError(
                                       "k", "scheduler-connection-lost")

    out = tmp_path / "r.nc"
    with pytest.raises(ClusterError) as err:
        execute.stream_to_file(plan, out, backend=LosesItsScheduler(3), chunk_cases=100)
    saved = len(list(chunk_folder(out).glob("*/chunk_*.npys")))
    total = len(chunks_to_run(plan, None, 100))
    assert saved >= 3 and str(err.value) == (
        "tcp://127.0.0.1:8786: lost the connection to the dask scheduler;"
        f" {saved} of {total} chunks saved in {chunk_folder(out)}: run the same command to"
        " continue")


def test_an_interrupted_run_to_a_file_says_the_chunks_saved(tmp_path):
    """Ctrl-C in a run to a file from Python (``gearsweep.run(..., output=...)``, a notebook):
    the ``KeyboardInterrupt`` says the chunks saved and how to continue (its message was empty;
    an outside tester)."""
    plan = plan_of(LONG.replace("transient_periods: 3000, record_periods: 1000",
                                "transient_periods: 30, record_periods: 10"))

    class CtrlC(CrashAfter):
        def run(self, plan, todo):
            try:
                yield from super().run(plan, todo)
            except Crash:
                raise KeyboardInterrupt from None

    out = tmp_path / "r.nc"
    with pytest.raises(KeyboardInterrupt) as err:
        execute.stream_to_file(plan, out, backend=CtrlC(3), chunk_cases=100)
    saved = len(list(chunk_folder(out).glob("*/chunk_*.npys")))
    total = len(chunks_to_run(plan, None, 100))
    assert saved >= 3 and str(err.value) == (
        f"{out}: interrupted: {saved} of {total} chunks saved in {chunk_folder(out)}; the same"
        " study run to the same output continues")


@pytest.mark.parametrize("chunk_cases", [None, 1, 5, 48, 100, 1000])
def test_the_estimate_counts_the_chunks_the_run_cuts(chunk_cases):
    """``--estimate`` said 16 chunks for a run that cut 18 (the short first and last chunks,
    ``with_short_ends``, were not counted; found by a new-user test): it counts them now, for
    the continued sweep and for plain cases, whatever the chunk size."""
    from gearsweep.study.estimate import quick_estimate
    from gearsweep.study.execute import chunks_to_run

    plain = RATTLE.replace("continuation: [up, down]\n", "").replace("num: 12}", "num: 3000}")
    for text in (RATTLE, plain):
        plan = plan_of(text)
        assert quick_estimate(plan, chunk_cases)[0].chunks == len(
            chunks_to_run(plan, None, chunk_cases)), text


def test_workers_beyond_the_machine_s_cores_are_refused(tmp_path, capsys, monkeypatch):
    """``--workers`` had no upper bound: ``--workers 10000`` would fork ten thousand processes
    (an adversarial test). More than the machine's cores is one line, exit 2, before any
    process starts; zero or fewer as before."""
    monkeypatch.setattr("gearsweep.cli.cores", lambda: 4)
    study = tmp_path / "r.yaml"
    study.write_text(RATTLE, encoding="utf-8")
    for n, says in (("5", "at most this machine's 4 cores"), ("0", "a positive whole number")):
        assert main(["run", str(study), "-o", str(tmp_path / "r.nc"), "--workers", n]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and f"--workers: {n} -- {says}" in err, err
    assert not (tmp_path / "r.nc").exists()


def test_running_out_of_memory_is_one_line(tmp_path, capsys, monkeypatch):
    """A mesh study of 1e7 torques asked numpy for 14.9 GiB and ended in a traceback (an
    adversarial test): running out of memory is one line, exit 2, naming the study."""
    study = tmp_path / "r.yaml"
    study.write_text(RATTLE, encoding="utf-8")

    def no_memory(*args, **kwargs):
        raise MemoryError("Unable to allocate 14.9 GiB for an array with shape (10000000, 200)")

    monkeypatch.setattr("gearsweep.cli.load_study", no_memory)
    assert main(["validate", str(study)]) == 2
    err = capsys.readouterr().err
    assert err == (f"gearsweep: error: {study}: out of memory (Unable to allocate 14.9 GiB for an"
                   " array with shape (10000000, 200)): make the study smaller, or run it where"
                   " there is more memory (chunks already saved are kept)\n")


def test_validate_notes_a_device_this_machine_lacks(tmp_path, capsys, monkeypatch):
    """``solver.device: cuda`` passed validate ("ok") and run then refused it (an adversarial
    test): validate says so in a note, exit 0 (the study may be meant for another machine)."""
    from gearsweep.errors import DeviceError

    def no_gpu(device, precision):
        raise DeviceError(f"device {device}: no CUDA GPU found")

    monkeypatch.setattr("gearsweep.cli.kernel_for", no_gpu)
    study = tmp_path / "r.yaml"
    study.write_text(RATTLE, encoding="utf-8")
    assert main(["validate", str(study)]) == 0
    out, err = capsys.readouterr()
    assert ": ok -- " in out
    err = "".join(line for line in err.splitlines(True)  # (its short transient is noted too)
                  if "solver.transient_periods" not in line)
    assert err == (f"gearsweep: note: {study}: device cpu: no CUDA GPU found: `gearsweep run`"
                   " refuses it on this machine\n")



def test_a_statistic_that_overflows_flags_its_case_as_diverged(small_whine):
    """A mean force of 1e300 N puts p near 1e291 m: p^2 overflows, p_rms is inf. Such a case is
    flagged as diverged (status 1) with NaN values, as a diverged case is (it was status 0 with
    p_rms inf and a finite p_pp), and the other loads' cases are as without it."""
    import gearsweep

    small_whine["scene"].pop("mean_force")
    small_whine["sweep"]["mean_force"] = ["400 N", "1600 N", "1e300 N"]
    ds = gearsweep.run(small_whine)
    bad = ds.sel(mean_force=1e300)
    assert (bad.status == 1).all() and bad.p_rms.isnull().all() and bad.p_pp.isnull().all()
    small_whine["sweep"]["mean_force"] = ["400 N", "1600 N"]
    ok = gearsweep.run(small_whine)
    assert (ok.status == 0).all()
    for name in ("p_rms", "p_pp", "status"):
        np.testing.assert_array_equal(ds[name].sel(mean_force=[400.0, 1600.0]), ok[name])


def test_an_output_through_a_symbolic_link_is_written_to_its_target(tmp_path, monkeypatch):
    """The result is written beside its path and renamed over it: over a link, that replaced
    the link with a file and left the target as it was. Now the run writes the target, from
    the CLI and from Python."""
    import gearsweep

    monkeypatch.chdir(tmp_path)
    study = ("title: t\nscene: {kind: whine, mass: 0.15 kg, teeth: 48, stiffness: 1000 kN/mm,"
             " mean_force: 800 N, damping: 5 N*s/mm}\nsweep: {speed: [3000, 4000]}\n")
    Path("s.yaml").write_text(study, encoding="utf-8")
    Path("target").mkdir()
    Path("target/r.nc").write_bytes(b"")  # an empty file may be replaced
    Path("link.nc").symlink_to(tmp_path / "target/r.nc")
    assert main(["run", "s.yaml", "-o", "link.nc", "-q"]) == 0
    assert Path("link.nc").is_symlink()
    first = Path("target/r.nc").read_bytes()
    assert first[:4] == b"\x89HDF"
    ds = gearsweep.run(study, output=tmp_path / "link.nc")
    ds.close()
    assert Path("link.nc").is_symlink() and Path("target/r.nc").read_bytes()[:4] == b"\x89HDF"
    assert not [p for p in Path(".").iterdir() if p.name not in ("s.yaml", "target", "link.nc")]


def test_a_default_output_that_is_a_symbolic_link_is_written_to_its_target(tmp_path, monkeypatch):
    """Without -o the result goes to results/STUDY.nc; where that is a link (results kept on
    another disk, say) the rename over it replaced the link with a file, as -o did."""
    monkeypatch.chdir(tmp_path)
    study = ("title: t\nscene: {kind: whine, mass: 0.15 kg, teeth: 48, stiffness: 1000 kN/mm,"
             " mean_force: 800 N, damping: 5 N*s/mm}\nsweep: {speed: [3000, 4000]}\n")
    Path("s.yaml").write_text(study, encoding="utf-8")
    Path("store").mkdir()
    Path("store/s.nc").write_bytes(b"")
    Path("results").mkdir()
    Path("results/s.nc").symlink_to(tmp_path / "store/s.nc")
    assert main(["run", "s.yaml", "-q"]) == 0
    assert Path("results/s.nc").is_symlink()
    assert Path("store/s.nc").read_bytes()[:4] == b"\x89HDF"


def test_history_names_the_command_main_was_given(tmp_path, small_whine):
    """``main(["run", ...])`` from Python (scripts/main_job.py runs every study so) writes that
    command into ``history``, not the process's ``sys.argv``: the main job's results said
    ``main_job.py``, which does not say which study made them or where (found by an outside
    reader of the main job's files)."""
    import shlex

    import yaml

    study = tmp_path / "s.yaml"
    study.write_text(yaml.safe_dump(small_whine))
    out = tmp_path / "out.nc"
    assert main(["run", str(study), "-o", str(out), "-q"]) == 0
    with xr.open_dataset(out) as ds:
        history = ds.attrs["history"]
    assert f": {shlex.join(['gearsweep', 'run', str(study), '-o', str(out), '-q'])} (gearsweep " \
        in history, history


def test_history_command_of_main_in_one_thread_is_not_another_threads(monkeypatch):
    """The command ``main`` was given was a module global: ``gearsweep.run`` in another thread
    wrote it into its history, and two calls that overlapped (A in, B in, A out, B out) left
    A's command as every later result's of the process."""
    import threading

    from gearsweep.study.provenance import command, command_line

    monkeypatch.setattr(sys, "argv", ["myscript.py", "arg"])
    steps = [threading.Event() for _ in range(3)]
    seen = []

    def a():
        with command(["gearsweep", "run", "a.yaml"]):
            steps[0].set()
            steps[1].wait()
            seen.append(command_line())
        steps[2].set()

    def b():
        steps[0].wait()
        with command(["gearsweep", "run", "b.yaml"]):
            seen.append(command_line())
            steps[1].set()
            steps[2].wait()

    threads = [threading.Thread(target=f) for f in (a, b)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert seen == ["gearsweep run b.yaml", "gearsweep run a.yaml"]
    assert command_line() == "myscript.py arg"


@pytest.mark.parametrize("argv, expected", [
    (["/v/bin/gearsweep", "run", "s.yaml"], "gearsweep run s.yaml"),
    (["/v/lib/site-packages/gearsweep/__main__.py", "run", "s.yaml"], "gearsweep run s.yaml"),
    (["/v/lib/site-packages/pytest/__main__.py", "-q", "t.py"], "python -m pytest -q t.py"),
    (["/home/u/mystudy/__main__.py", "o.nc"], "python -m mystudy o.nc"),
    (["/home/u/tools/cli.py", "o.nc"], "cli.py o.nc"),
    (["-", "o.nc"], "python - o.nc"),  # python - o.nc < script.py: it said "- o.nc"
])
def test_history_command_of_another_program_is_not_called_gearsweep(monkeypatch, argv, expected):
    """A program run as ``python -m PACKAGE`` (or a script named cli.py) that calls
    ``gearsweep.run(..., output=...)`` was recorded as ``gearsweep ARGS``, a command that never
    ran (``python -m mystudy o.nc`` gave ``gearsweep o.nc``)."""
    from gearsweep.study.provenance import command_line

    monkeypatch.setattr(sys, "argv", argv)
    assert command_line() == expected


def test_identity_names_the_code_loaded_not_a_later_commit(monkeypatch):
    """``identity`` read ``.git`` at every call: a ``git commit`` during a ``--workers`` or
    ``--scheduler`` run made every later chunk a worker's of "another gearsweep", though the
    client and its workers ran the same loaded code (a reviewer's finding), and it cost file
    reads per chunk. It is read once per process, at its first call."""
    from gearsweep.study import provenance

    heads = iter(["0123456789ab", "ba9876543210", "fedcba987654"])  # a commit after each read
    calls = []

    def head(root=None):
        calls.append(root)
        return next(heads)

    monkeypatch.setattr(provenance, "source_commit", head)
    provenance.identity.cache_clear()
    try:
        first = provenance.identity()
        assert first.endswith(" commit 0123456789ab")
        assert provenance.identity() == first and provenance.identity() == first
        assert len(calls) == 1
    finally:
        provenance.identity.cache_clear()  # the real checkout's for the other tests


def test_history_names_the_commit_of_a_git_checkout(tmp_path):
    """The version was 0.1.0 for every commit: a result did not name the code that made it (an
    outside data steward's finding). From a git checkout, ``history`` names the commit, read
    from ``.git`` (a loose ref, a packed one, a detached HEAD); an installed wheel names none."""
    from gearsweep.study.provenance import provenance, source_commit

    sha = "0123456789abcdef0123456789abcdef01234567"
    git = tmp_path / ".git"
    assert source_commit(tmp_path) is None  # no checkout
    (git / "refs" / "heads").mkdir(parents=True)
    (git / "HEAD").write_text("ref: refs/heads/main\n")
    (git / "refs" / "heads" / "main").write_text(sha + "\n")
    assert source_commit(tmp_path) == sha[:12]
    (git / "refs" / "heads" / "main").unlink()
    (git / "packed-refs").write_text(f"# pack-refs with: peeled\n{sha[::-1]} refs/heads/other\n"
                                     f"{sha} refs/heads/main\n")
    assert source_commit(tmp_path) == sha[:12]
    (git / "HEAD").write_text(sha[::-1] + "\n")  # detached
    assert source_commit(tmp_path) == sha[::-1][:12]
    (git / "HEAD").write_text("not a commit\n")
    assert source_commit(tmp_path) is None
    here = source_commit()  # this test's own checkout, if it is one
    assert (f" commit {here}," in provenance()) == (here is not None)


class _StubFuture:
    def __init__(self, key: str, done: bool = False) -> None:
        self.key, self._done = key, done

    def done(self) -> bool:
        return self._done


class _StubClient:
    def __init__(self, answers) -> None:
        self.answers, self.cancelled = answers, []

    def run(self, function, on_error="raise"):
        if isinstance(self.answers, BaseException):
            raise self.answers
        if on_error == "raise":
            for got in self.answers.values():
                if isinstance(got, BaseException):
                    raise got
        return dict(self.answers)

    def cancel(self, futures) -> None:
        self.cancelled.extend(f.key for f in futures)


def _stop_drain(answers, done=(), after=(-1, -1)):
    """``DaskBackend._cancel_not_begun`` over chunks k1..k4 (lanes 0-10, ..., 30-40) with a
    stub client whose workers say ``answers``: (kept, cancelled)."""
    from gearsweep.study.execute import DaskBackend

    backend = DaskBackend(workers=1)
    backend.client = _StubClient(answers)
    where = {f"k{i}": (10 * (i - 1), 10 * i) for i in range(1, 5)}
    futures = {k: _StubFuture(k, k in done) for k in where}
    backend._cancel_not_begun(futures, where, after)
    return sorted(futures), sorted(backend.client.cancelled)


def test_a_cluster_s_stop_keeps_every_chunk_up_to_the_last_begun_or_finished():
    """A Ctrl-C on a dask cluster keeps the chunks up to the last one begun and cancels the
    later ones, so that the chunks saved have no hole. A chunk already finished after the
    last begun was kept while an earlier one not begun was cancelled (a hole), and one worker
    that did not answer made every chunk "not computing": the chunks computing on the healthy
    workers were cancelled too (a reviewer's stubs)."""
    # k1 computing, k3 finished, k2 waiting: k2 is kept (and k4 cancelled)
    assert _stop_drain({"w1": ["k1"], "w2": []}, done={"k3"}) == (["k1", "k2", "k3"], ["k4"])
    # a chunk already yielded (k2: not in futures any more) after one waiting (k1)
    assert _stop_drain({"w1": []}, after=(10, 20)) == (["k1", "k2"], ["k3", "k4"])
    # one worker gone: the chunk computing on the other is kept, with those before it
    gone = OSError("Timed out trying to connect to tcp://10.0.0.2:4242")
    assert _stop_drain({"w1": gone, "w2": ["k2"]}) == (["k1", "k2"], ["k3", "k4"])
    # nothing begun: every chunk is cancelled
    assert _stop_drain({"w1": [], "w2": []}) == ([], ["k1", "k2", "k3", "k4"])
    # the scheduler not answering: which compute is not known, every chunk is kept
    assert _stop_drain(OSError("scheduler gone")) == (["k1", "k2", "k3", "k4"], [])


def test_the_transient_residual_looked_up_per_chunk_is_the_per_case_one():
    """``transient_left`` (the residual the status rule judges, and a stored variable) is solved
    once on the grid of the swept dims it depends on and looked up per chunk
    (``plan._transient_table``): per case it cost a 1e6-case study 0.13 s of the writer's CPU
    beside the kernel. The looked-up values are the per-case ones, bit for bit, in a chunk that
    is not whole rows, and the prepared chunk's outputs are those of the per-case path."""
    from gearsweep.study import chunk
    from gearsweep.study.plan import _transient_table, transient_left

    plan = plan_of(LONG.replace("transient_periods: 3000, record_periods: 1000",
                                "transient_periods: 8, record_periods: 4"))
    assert _transient_table(plan) is None  # 50 speeds x 40 dampings: the whole grid here; a
    # table is kept only for a study of at least four times as many cases
    big = plan_of(LONG.replace("transient_periods: 3000, record_periods: 1000",
                               "transient_periods: 8, record_periods: 4").replace(
        "sweep:\n", "sweep:\n  backlash: [0.1 mm, 0.2 mm, 0.3 mm, 0.4 mm]\n"))
    table = _transient_table(big)
    assert table is not None and table[2].size * 4 == big.n_cases
    prep = chunk.prepare(big, 37, 1290)  # not whole rows of any dim
    n = 1290 - 37
    want = transient_left(big, prep.params, n)[0]
    assert prep.left is not None
    np.testing.assert_array_equal(prep.left.view(np.int64), want.view(np.int64))
    looked_up = chunk.run_prepared(big, prep)()
    prep_none = dataclasses.replace(prep, left=None)
    per_case = chunk.run_prepared(big, prep_none)()
    assert looked_up.keys() == per_case.keys()
    for name in looked_up:
        np.testing.assert_array_equal(looked_up[name], per_case[name])

"""Interruptions and concurrent runs: SIGINT saves and resumes, one run per output, unwritable
outputs and another study's chunks refused before computing."""

from __future__ import annotations

import errno
import json
import math
import os
import re
import shlex
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from conftest import WHINE_SCENE

from gearsweep.cli import main
from gearsweep.study.checkpoint import chunk_folder

ROOT = Path(__file__).resolve().parents[1]

STUDY = "title: interruptible\n" + WHINE_SCENE + """sweep:
  speed: {start: 1000 rpm, stop: 20000 rpm, num: NUM}
solver: {method: rk4, steps_per_period: 128, transient_periods: 200, record_periods: 50}
"""


def _env(log: Path | None = None) -> dict:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    if log is not None:
        env["GEARSWEEP_CHUNK_LOG"] = str(log)
    return env


def _cmd(study: Path, out: Path) -> list[str]:
    return [sys.executable, "-m", "gearsweep.cli", "run", str(study), "-o", str(out), "-q",
            "--chunk-size", "500"]


def _signalled_after_two_chunks(tmp_path, sig, ignored=()) -> tuple[Path, Path, Path, int, str]:
    """A 20-chunk run of ``gearsweep run`` sent ``sig`` (or each of a tuple) once it has saved
    two chunks: (study, output, chunk log, return code, stderr). Its chunks take about 40 ms
    each (transient 1000 periods): the signal after the second lands well before the last,
    whose kernel calls follow one another with nothing between. ``ignored``: signals the run
    inherits ignored (``nohup``, a background job of a shell without job control)."""
    study = tmp_path / "s.yaml"
    study.write_text(STUDY.replace("NUM", "10000").replace("transient_periods: 200",
                                                           "transient_periods: 1000"),
                     encoding="utf-8")
    out = tmp_path / "out.nc"
    log = tmp_path / "chunks.log"
    def ignore() -> None:
        for signum in ignored:
            signal.signal(signum, signal.SIG_IGN)

    proc = subprocess.Popen(_cmd(study, out), cwd=tmp_path, env=_env(log),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=ignore if ignored else None)
    t0 = time.time()
    while not (log.exists() and len(log.read_text().splitlines()) >= 2):
        assert proc.poll() is None, proc.communicate()
        assert time.time() - t0 < 300
        time.sleep(0.05)
    for each in sig if isinstance(sig, tuple) else (sig,):
        proc.send_signal(each)
    _, err = proc.communicate(timeout=120)
    return study, out, log, proc.returncode, err


def test_sigint_saves_the_chunks_and_the_same_command_completes_the_file(tmp_path):
    study, out, log, returncode, err = _signalled_after_two_chunks(tmp_path, signal.SIGINT)
    ref = tmp_path / "ref.nc"
    assert returncode == 130, err
    lines = err.strip().splitlines()
    assert len(lines) <= 3 and "Traceback" not in err, err
    assert lines[-1].startswith("gearsweep: interrupted: ") and "of 20 chunks saved in" in err
    assert "run the same command to continue" in err
    assert not out.exists() and chunk_folder(out).is_dir()
    done = len(log.read_text().splitlines())
    assert done < 20
    # inspect of the output says where the work is and how to finish it (was "no result file")
    rc = subprocess.run([sys.executable, "-m", "gearsweep", "inspect", str(out)], cwd=tmp_path,
                        env=_env(), capture_output=True, text=True, timeout=120)
    assert rc.returncode == 2 and rc.stderr.strip() == (
        f"gearsweep: error: {out}: no result file there yet: an interrupted run saved {done}"
        f" chunks in {chunk_folder(out)}; run the same command (gearsweep run STUDY -o {out})"
        " to compute the others and write it"), rc.stderr
    # The same command completes it, computing only the missing chunks, and says so first.
    resume = [c for c in _cmd(study, out) if c != "-q"]
    rc = subprocess.run(resume, cwd=tmp_path, env=_env(log), capture_output=True, text=True,
                        timeout=600)
    assert rc.returncode == 0, rc.stderr
    assert f"resuming: {done} of 20 chunks already saved in" in rc.stderr, rc.stderr
    assert len(log.read_text().splitlines()) == 20
    # The summary says what came from the interrupted run and the time of both runs, the
    # file's elapsed_seconds (it gave the resumed part's alone as the study's).
    found = re.fullmatch(rf"{re.escape(str(out))}: 10000 cases \(resumed: {done} of 20 chunks"
                         rf" from an earlier run, {20 - done} computed now\) in [\d.]+ s"
                         r" \(computing the chunks: ([\d.]+) s now, ([\d.]+) s over the 2 runs,"
                         r" the file's elapsed_seconds\)\n", rc.stdout)
    assert found, rc.stdout
    rc = subprocess.run(_cmd(study, ref), cwd=tmp_path, env=_env(), capture_output=True,
                        text=True, timeout=600)
    assert rc.returncode == 0, rc.stderr
    with xr.open_dataset(out) as a, xr.open_dataset(ref) as b:
        for name in b.variables:
            np.testing.assert_array_equal(a[name].values, b[name].values, err_msg=name)
        # Both commands in history, oldest first (the interrupted one had -q); each run's
        # chunks and seconds, and their totals.
        history = a.attrs["history"].splitlines()
        assert [line.split(": ", 1)[1].split(" (gearsweep ")[0] for line in history] == [
            shlex.join(["gearsweep", *_cmd(study, out)[3:]]),
            shlex.join(["gearsweep", *resume[3:]])], history
        assert list(a.attrs["run_chunks"]) == [done, 20 - done]
        each = a.attrs["run_elapsed_seconds"]
        assert a.attrs["elapsed_seconds"] == round(sum(each), 3)
        assert (f"{each[1]:.2f}", f"{a.attrs['elapsed_seconds']:.2f}") == found.groups()
        assert a.attrs["kernel_seconds"] == round(sum(a.attrs["run_kernel_seconds"]), 3)
        assert "\n" not in b.attrs["history"] and "run_chunks" not in b.attrs


@pytest.mark.parametrize("name, code", [("SIGTERM", 143), ("SIGHUP", 129)])
def test_sigterm_saves_the_chunks_computed_and_exits_143(tmp_path, name, code):
    """SIGTERM (``kill``, ``docker stop``, a batch system's time limit) stops the run at once,
    as a second Ctrl-C does, after saving every chunk already computed; one line, exit 143; the
    same command completes the file. SIGHUP (the terminal closed) alike, exit 129: it ended the
    run under its default action, no line, the lock files left, the chunks computed unsaved (an
    outside tester)."""
    study, out, log, returncode, err = _signalled_after_two_chunks(tmp_path,
                                                                   getattr(signal, name))
    assert returncode == code, err
    assert "Traceback" not in err and err.count("\n") == 1, err
    found = re.fullmatch(rf"gearsweep: terminated \({name}\): (\d+) of 20 chunks saved in"
                         r" .*out.nc.chunks; run the same command to continue\n", err)
    assert found, err
    done = int(found[1])
    assert 2 <= done < 20 and len(log.read_text().splitlines()) == done
    assert sum(1 for _ in chunk_folder(out).rglob("chunk_*.npys")) == done
    assert not out.exists() and not list(chunk_folder(out).rglob("writing.nc"))
    rc = subprocess.run(_cmd(study, out), cwd=tmp_path, env=_env(log), capture_output=True,
                        text=True, timeout=600)
    assert rc.returncode == 0, rc.stderr
    assert len(log.read_text().splitlines()) == 20  # only the missing chunks computed
    with xr.open_dataset(out) as ds:
        assert int(ds.sizes["speed"]) == 10000
    assert not list(tmp_path.glob("out.nc.lock*"))


def test_signals_ignored_when_the_run_began_stay_ignored(tmp_path):
    """A run that inherits SIGINT and SIGHUP ignored (``nohup``, ``gearsweep run ... &`` in a
    script: a background job of a shell without job control) leaves them so: a Ctrl-C or a
    hang-up of that terminal does not stop it. The run set its own handler over them, and the
    terminal's Ctrl-C stopped a background run (an outside tester)."""
    _, out, log, returncode, err = _signalled_after_two_chunks(
        tmp_path, (signal.SIGINT, signal.SIGHUP), ignored=(signal.SIGINT, signal.SIGHUP))
    assert returncode == 0, err
    assert len(log.read_text().splitlines()) == 20
    with xr.open_dataset(out) as ds:
        assert int(ds.sizes["speed"]) == 10000


MESH_STUDY = """\
type: mesh
title: a mesh study to stop
gears: {plain: table1_consistent}
sweep:
  torque: {start: 2 N*m, stop: 150 N*m, num: 20}
positions: 40
"""

_SIGNAL_AS_XARRAY_WRITES = """\
import os, signal, sys
from xarray.backends import locks

SIG = getattr(signal, sys.argv[1])
real = locks.CombinedLock.release
calls = [0]

def release(self):  # the signal as xarray lets go of its HDF5 lock, in the result's write: an
    calls[0] += 1  # interrupt raised in there left the lock held; the file's close waited for
    if calls[0] == 6:  # it for ever
        os.kill(os.getpid(), SIG)
    return real(self)

locks.CombinedLock.release = release
if len(sys.argv) > 2:
    signal.signal(SIG, signal.SIG_IGN)  # as the run inherits it ignored (nohup)
from gearsweep.__main__ import entry
sys.argv = ["gearsweep", "run", "m.yaml", "-o", "out/m.nc", "-q"]
entry()
"""


def _mesh_write_interrupted(tmp_path, script: str, name: str):
    """Run ``script`` (which writes the mesh study ``m.yaml`` and signals itself with ``name``
    as xarray writes the result) in a new process; its (process, stdout, stderr), the test
    failed where it hangs (it did, for ever, before the write held the stop signals)."""
    (tmp_path / "m.yaml").write_text(MESH_STUDY, encoding="utf-8")
    proc = subprocess.Popen([sys.executable, "-c", script, name], cwd=tmp_path, env=_env(),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        out, err = proc.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, err = proc.communicate()
        pytest.fail(f"hung after {name} in the result's write: {err[-2000:]}")
    return proc, out, err


@pytest.mark.parametrize("name, code, how", [("SIGINT", 130, "interrupted"),
                                             ("SIGTERM", 143, "terminated (SIGTERM)"),
                                             ("SIGHUP", 129, "terminated (SIGHUP)")])
def test_a_signal_while_a_mesh_result_is_written_is_one_line_and_leaves_nothing(tmp_path, name,
                                                                                code, how):
    """A mesh study (computed in one piece, its result written by xarray) stopped while its
    file is written: one line, the exit code of the signal, no temporary file, no lock files.
    Ctrl-C there hung for ever (xarray's lock taken, the close waiting for it); SIGTERM and
    SIGHUP ended it under their default action, the ``.m.nc.XXXXXXXX.partial`` and the lock
    files left (an outside tester)."""
    proc, _, err = _mesh_write_interrupted(tmp_path, _SIGNAL_AS_XARRAY_WRITES, name)
    line = (f"gearsweep: {how}: nothing written (a mesh study is computed in one piece: run"
            " the same command to compute it)\n")
    assert (proc.returncode, err) == (code, line), err[-3000:]
    assert sorted(os.listdir(tmp_path / "out")) == []
    # inherited ignored, the signal is left so: the run writes its result
    r = subprocess.run([sys.executable, "-c", _SIGNAL_AS_XARRAY_WRITES, name, "ignored"],
                       cwd=tmp_path, env=_env(), capture_output=True, text=True, timeout=120)
    assert (r.returncode, r.stderr) == (0, ""), r.stderr[-3000:]
    assert sorted(os.listdir(tmp_path / "out")) == ["m.nc"]


def test_the_next_run_removes_the_temporary_file_a_killed_write_left(tmp_path):
    """A run killed (SIGKILL, a power loss) while it wrote a mesh or analysis result leaves its
    temporary file beside the output; the next run to that output removes it (each killed run
    left one more), and never a file of another name."""
    study = tmp_path / "m.yaml"
    study.write_text(MESH_STUDY, encoding="utf-8")
    out = tmp_path / "out" / "m.nc"
    out.parent.mkdir()
    left = [out.parent / ".m.nc.k2_x9q0a.partial", out.parent / ".m.nc.0123abcd.partial"]
    mine = [out.parent / ".m.nc.backup.partial", out.parent / ".m.nc.0123abcd.partial.old",
            out.parent / ".x.nc.0123abcd.partial", out.parent / "m.nc.0123abcd.partial"]
    for path in left + mine:
        path.write_bytes(b"\x89HDF\r\n\x1a\n")
    assert main(["run", str(study), "-o", str(out), "-q"]) == 0
    assert sorted(p.name for p in out.parent.iterdir()) == sorted(["m.nc", *(p.name
                                                                             for p in mine)])


def test_a_second_run_on_the_same_output_is_refused_naming_the_first(tmp_path, capsys):
    study = tmp_path / "s.yaml"
    study.write_text(STUDY.replace("NUM", "20000"), encoding="utf-8")
    out = tmp_path / "out.nc"
    log = tmp_path / "chunks.log"
    first = subprocess.Popen(_cmd(study, out), cwd=tmp_path, env=_env(log),
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        t0 = time.time()
        while not (tmp_path / "out.nc.lock.pid").exists():
            assert first.poll() is None, first.communicate()
            assert time.time() - t0 < 120
            time.sleep(0.05)
        assert main(["run", str(study), "-o", str(out), "-q"]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and f"(PID {first.pid})" in err, err
    finally:
        first.kill()  # SIGKILL: the OS drops its lock, no stale lock is left behind
        first.communicate()
    small = tmp_path / "small.yaml"
    small.write_text(STUDY.replace("NUM", "20"), encoding="utf-8")
    other = tmp_path / "other.nc"
    assert main(["run", str(small), "-o", str(other), "-q"]) == 0  # another output: free


def test_a_lock_left_by_a_killed_run_is_stale(tmp_path):
    study = tmp_path / "s.yaml"
    study.write_text(STUDY.replace("NUM", "20"), encoding="utf-8")
    out = tmp_path / "out.nc"
    code = ("import os, sys; from gearsweep.study.workspace import OutputLock;"
            f" lock = OutputLock({str(out)!r}); lock.__enter__(); os._exit(0)")
    subprocess.run([sys.executable, "-c", code], env=_env(), check=True, timeout=120)
    assert (tmp_path / "out.nc.lock").exists()  # left behind by a process that did not clean up
    assert main(["run", str(study), "-o", str(out), "-q"]) == 0


def test_chunks_of_another_study_at_the_same_path_are_refused(tmp_path, capsys):
    out = tmp_path / "out.nc"
    folder = chunk_folder(out) / ("0" * 64)
    folder.mkdir(parents=True)
    (folder / "chunk_0_10.npys").write_bytes(b"x")
    study = tmp_path / "s.yaml"
    study.write_text(STUDY.replace("NUM", "20"), encoding="utf-8")
    assert main(["run", str(study), "-o", str(out), "-q"]) == 2
    err = capsys.readouterr().err
    assert "saved chunk(s) of another study" in err and err.count("\n") == 1
    assert (folder / "chunk_0_10.npys").exists() and not out.exists()


def test_inspect_of_an_output_a_run_is_writing_says_so(tmp_path, capsys):
    """``inspect`` during a live run said "an interrupted run saved 6 chunks ... run the same
    command" (an outside tester); it asks the run's lock as the run does and names the run."""
    out = tmp_path / "out.nc"
    folder = chunk_folder(out) / ("a" * 64)
    folder.mkdir(parents=True)
    for a in range(3):
        (folder / f"chunk_{a}_{a + 1}.npys").write_bytes(b"x")
    code = ("import sys; from gearsweep.study.workspace import OutputLock;"
            f" lock = OutputLock({str(out)!r}); lock.__enter__(); print('held', flush=True);"
            " sys.stdin.read(); lock.__exit__()")
    holder = subprocess.Popen([sys.executable, "-c", code], env=_env(), stdin=subprocess.PIPE,
                              stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline() == "held\n"
        assert main(["inspect", str(out)]) == 2
        err = capsys.readouterr().err
        assert err == (f"gearsweep: error: {out}: no result file there yet: a run (PID"
                       f" {holder.pid}) is writing it now: 3 chunks saved so far in"
                       f" {chunk_folder(out)}; inspect it once that run has finished\n"), err
    finally:
        holder.communicate("", timeout=60)
    assert main(["inspect", str(out)]) == 2  # the run gone: its saved chunks, as before
    assert "an interrupted run saved 3 chunks in" in capsys.readouterr().err
    assert not (tmp_path / "out.nc.lock").exists()


def test_a_chunk_folder_holding_the_user_s_files_is_refused_and_never_removed(tmp_path, capsys):
    """OUT.nc.chunks of the user's files (notes.txt, sub/data.csv) was deleted whole at the end
    of a run (shutil.rmtree; an outside tester). The run now refuses beside it, one line, exit
    2, and the removal of checkpoints takes only the study folders gearsweep made."""
    from gearsweep.study.checkpoint import remove_checkpoints

    out = tmp_path / "out.nc"
    root = chunk_folder(out)
    (root / "sub").mkdir(parents=True)
    (root / "notes.txt").write_text("mine\n", encoding="utf-8")
    (root / "sub" / "data.csv").write_text("1,2\n", encoding="utf-8")
    study = tmp_path / "s.yaml"
    study.write_text(STUDY.replace("NUM", "20"), encoding="utf-8")
    assert main(["run", str(study), "-o", str(out), "-q"]) == 2
    err = capsys.readouterr().err
    assert err == (f"gearsweep: error: {out}: {root} holds 'notes.txt' and 1 more, not made by"
                   " gearsweep: the run keeps its checkpoints in that folder and removes it at"
                   " its end; move what is yours elsewhere, or choose another output\n"), err
    ours = root / ("a" * 64)
    ours.mkdir()
    (ours / "manifest.json").write_text("{}", encoding="utf-8")
    (ours / "chunk_0_4.npys").write_bytes(b"x")
    remove_checkpoints(out)
    assert not ours.exists()
    assert (root / "notes.txt").is_file() and (root / "sub" / "data.csv").is_file()
    (root / "notes.txt").unlink()
    (root / "sub" / "data.csv").unlink()
    (root / "sub").rmdir()
    assert main(["run", str(study), "-o", str(out), "-q"]) == 0  # nothing of the user's: runs
    assert out.is_file() and not root.exists()


def test_a_study_folder_killed_while_writing_its_manifest_is_gearsweep_s(tmp_path, capsys):
    """A run SIGKILLed inside the manifest's atomic write left <key>/.manifest.json.XXXX.partial
    and no manifest: the folder was taken for the user's, the next run refused beside it ("holds
    '<key>', not made by gearsweep") and no removal cleared it (a reviewer). A folder named by a
    study's key of gearsweep's files only is gearsweep's; the names of those files (the result
    being written, the workers' mark, the temporary files) are the ones the runs make."""
    import os

    from gearsweep.files import temp_beside
    from gearsweep.study import execute
    from gearsweep.study.checkpoint import (
        MANIFEST,
        WRITING,
        checkpoint_problem,
        foreign_entries,
        remove_checkpoints,
        shared_mark,
    )

    assert execute.WRITING is WRITING and execute.shared_mark is shared_mark  # one place
    out = tmp_path / "out.nc"
    root = chunk_folder(out)
    killed = root / ("b" * 64)
    killed.mkdir(parents=True)
    fd, _ = temp_beside(killed / MANIFEST)  # what atomic_write leaves when killed
    os.close(fd)
    assert foreign_entries(out) == [] and checkpoint_problem(out) is None
    study = tmp_path / "s.yaml"
    study.write_text(STUDY.replace("NUM", "20"), encoding="utf-8")
    assert main(["run", str(study), "-o", str(out), "-q"]) == 0, capsys.readouterr().err
    assert out.is_file() and not root.exists()  # the killed run's folder removed with the run's
    killed.mkdir(parents=True)  # and every file a run makes there is its own
    (killed / WRITING).write_bytes(b"x")
    shared_mark(killed)
    fd, _ = temp_beside(killed / WRITING)
    os.close(fd)
    theirs = root / "notes"  # not a study's key: a folder of such files alone is the user's
    theirs.mkdir()
    fd, _ = temp_beside(theirs / MANIFEST)
    os.close(fd)
    assert foreign_entries(out) == [theirs]
    remove_checkpoints(out)
    assert not killed.exists() and theirs.is_dir()


def test_a_file_in_the_way_of_the_chunk_folder_is_named(tmp_path, capsys):
    """A plain file named OUT.nc.chunks said "cannot write the result here (Not a
    directory)"; the line names the file in the way and what to do."""
    out = tmp_path / "cf.nc"
    chunk_folder(out).write_text("x", encoding="utf-8")
    study = tmp_path / "s.yaml"
    study.write_text(STUDY.replace("NUM", "20"), encoding="utf-8")
    assert main(["run", str(study), "-o", str(out), "-q"]) == 2
    err = capsys.readouterr().err
    assert err == (f"gearsweep: error: {out}: {out}.chunks is a file, where the run keeps its"
                   " checkpoint folder: move or remove it, or choose another output\n"), err
    assert chunk_folder(out).read_text(encoding="utf-8") == "x" and not out.exists()


def test_an_unwritable_output_is_refused_before_computing(tmp_path, capsys):
    study = tmp_path / "s.yaml"
    study.write_text(STUDY.replace("NUM", "20"), encoding="utf-8")
    t0 = time.perf_counter()
    assert main(["run", str(study), "-o", "/proc/x.nc"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("gearsweep: error: /proc/x.nc: --output: ") and err.count("\n") == 1
    assert time.perf_counter() - t0 < 5


def _without_dac_override() -> list[str] | None:
    """A command prefix under which the folder permissions apply (root passes them, with
    CAP_DAC_OVERRIDE): none for another user, ``setpriv`` dropping the capabilities for root;
    ``None`` where that cannot be done."""
    if os.geteuid() != 0:
        return []
    prefix = ["setpriv", "--bounding-set=-dac_override,-dac_read_search,-fowner"]
    try:
        subprocess.run([*prefix, "true"], check=True, capture_output=True, timeout=30)
    except (OSError, subprocess.SubprocessError):
        return None
    return prefix


READ_ONLY_AT_THE_END = """
import os, sys
from gearsweep.study import resultfile
real = resultfile.finish
def finish(tmp, path):  # the output's folder made read-only before the result goes there
    os.chmod(path.parent, 0o555)
    real(tmp, path)
resultfile.finish = finish
from gearsweep.cli import main
sys.exit(main(sys.argv[1:]))
"""


def test_an_output_folder_made_read_only_during_the_run_is_one_line(tmp_path):
    """The output's folder made read-only while the run computes (``chmod 555``, an outside
    tester's finding): one line naming the rename that failed (the finished file onto the
    output) and the chunks saved, exit 2. Was a traceback, exit 1: the lock's files could not
    be removed, and that error hid the run's line, which named the wrong file (writing.nc,
    which was written)."""
    prefix = _without_dac_override()
    if prefix is None:
        pytest.skip("cannot drop CAP_DAC_OVERRIDE (setpriv) to make a folder read-only for root")
    study = tmp_path / "s.yaml"
    study.write_text(STUDY.replace("NUM", "400"), encoding="utf-8")
    folder = tmp_path / "w"
    folder.mkdir()
    out = folder / "a.nc"
    args = ["run", str(study), "-o", str(out), "-q", "--chunk-size", "100"]
    try:
        r = subprocess.run([*prefix, sys.executable, "-c", READ_ONLY_AT_THE_END, *args],
                           env=_env(), capture_output=True, text=True, timeout=300)
    finally:
        folder.chmod(0o755)
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    o = re.escape(str(out))
    assert re.fullmatch(rf"gearsweep: error: {o}: cannot rename {o}\.chunks/\w+/writing\.nc to"
                        rf" {o}: Permission denied; (\d+) of \1 chunks saved in {o}\.chunks:"
                        " fix that and run the same command to continue\n", r.stderr), r.stderr
    assert not out.exists()
    assert main(args) == 0 and out.is_file() and not chunk_folder(out).exists()


def test_a_result_of_another_study_is_not_replaced_without_overwrite(tmp_path, capsys):
    """An existing result of another study at ``-o`` was replaced silently (an outside tester's
    finding; nothing already computed is to be lost): refused in one line, exit 2, the file
    untouched, unless ``--overwrite`` (``overwrite=True``); the same study's result, its file
    edited in comments, spacing or key order, is replaced by its rerun; a netCDF file that is
    not a gearsweep result is another study's too."""
    import netCDF4

    import gearsweep
    from gearsweep.errors import ResultError

    a, b, edited = tmp_path / "a.yaml", tmp_path / "b.yaml", tmp_path / "a2.yaml"
    a.write_text(STUDY.replace("NUM", "20"), encoding="utf-8")
    b.write_text(STUDY.replace("NUM", "30"), encoding="utf-8")
    lines = STUDY.replace("NUM", "20").splitlines()
    edited.write_text("\n".join(["# the same values", lines[-1], *lines[:-1]]).replace(": ", ":  "),
                      encoding="utf-8")
    out = tmp_path / "r.nc"

    def run(study, *more) -> tuple[int, str]:
        code = main(["run", str(study), "-o", str(out), "-q", *more])
        return code, capsys.readouterr().err

    def speeds() -> int:
        with netCDF4.Dataset(out) as nc:
            return nc.dimensions["speed"].size

    assert run(a) == (0, "")
    before = out.read_bytes()
    code, err = run(b)
    assert code == 2 and err.count("\n") == 1, err
    assert err.startswith(f"gearsweep: error: {out}: holds the result of another study"
                          " ('interruptible', written 20"), err
    assert err.endswith("which this result would replace: choose another -o, or pass"
                        " --overwrite to replace it\n"), err
    assert out.read_bytes() == before
    main(["run", str(b), "-o", str(out), "--estimate"])  # says the refusal it would meet
    said = capsys.readouterr().out
    assert "note: a run to this output would be refused: " in said and "--overwrite" in said
    main(["run", str(b), "-o", str(out), "--estimate", "--overwrite"])
    assert "refused" not in capsys.readouterr().out
    assert run(edited) == (0, "") and run(a, "--device", "cpu") == (0, "") and speeds() == 20
    with pytest.raises(ResultError, match="another study .*overwrite=True to replace it"):
        gearsweep.run(str(b), output=out)
    assert speeds() == 20
    assert run(b, "--overwrite") == (0, "") and speeds() == 30
    assert gearsweep.run(str(a), output=out, overwrite=True).sizes["speed"] == speeds() == 20

    with netCDF4.Dataset(out, "w") as nc:  # someone's own netCDF file
        nc.createDimension("x", 3)
    code, err = run(a)
    assert code == 2 and "holds a netCDF file that is not a gearsweep result" in err, err
    assert run(a, "--overwrite") == (0, "") and speeds() == 20


def test_a_damaged_result_is_not_replaced_without_overwrite(tmp_path, capsys):
    """A result cut short (``head -c 8000 r1.nc > t3.nc``: the netCDF signature, then nothing
    readable) was replaced by a run of another study, exit 0 (an outside tester's finding): it
    cannot be shown to be this study's, so it is refused in one line, exit 2, left as it was,
    unless ``--overwrite``. gearsweep's own runs leave no such file at ``-o``: an interrupted
    run's is in OUT.nc.chunks, and the same command continues to a whole result."""
    import netCDF4

    a, b = tmp_path / "a.yaml", tmp_path / "b.yaml"
    a.write_text(STUDY.replace("NUM", "20"), encoding="utf-8")
    b.write_text(STUDY.replace("NUM", "30"), encoding="utf-8")
    whole, out = tmp_path / "whole.nc", tmp_path / "r.nc"
    assert main(["run", str(a), "-o", str(whole), "-q"]) == 0
    damaged = whole.read_bytes()[:8000]
    out.write_bytes(damaged)
    for study in (b, a):  # not even the same study's: nothing says it is
        assert main(["run", str(study), "-o", str(out), "-q"]) == 2
        err = capsys.readouterr().err
        assert err == (f"gearsweep: error: {out}: holds data that cannot be read as a netCDF"
                       " result (damaged or cut short), so it may be another study's result,"
                       " which this result would replace: choose another -o, or pass"
                       " --overwrite to replace it\n"), err
        assert out.read_bytes() == damaged
    assert main(["run", str(b), "-o", str(out), "-q", "--overwrite"]) == 0
    with netCDF4.Dataset(out) as nc:
        assert nc.dimensions["speed"].size == 30


RATTLE_40K = """\
title: a file past the file-size limit
scene: {kind: rattle, mass: 0.1527 kg, teeth: 48, stiffness: 1073 kN/mm, base_radius: 30 mm,
        backlash: 0.1 mm, torque: 10 N*m, damping: 100 N*s/m,
        fluctuation: [{amplitude: 300 N, order: 1}]}
sweep:
  speed: {start: 2000 rpm, stop: 12000 rpm, num: 400}
  backlash: {start: 0.02 mm, stop: 0.5 mm, num: 100}
solver: {method: rk4, steps_per_period: 32, transient_periods: 60, record_periods: 20}
outputs: [stats]
"""


@pytest.mark.skipif(sys.platform == "win32", reason="RLIMIT_FSIZE")
def test_a_result_file_past_the_file_size_limit_says_that_limit(tmp_path):
    """``ulimit -f`` below the result file's size (about 2 MB here; each chunk file 0.3 MB,
    below it): the one line says the file-size limit, not a failure of the netCDF library on
    a disk with room (an outside tester's finding); the same command without the limit
    finishes the file."""
    limit = 1_500_000
    limited = ("import resource, sys; from gearsweep.cli import main;"
               f" resource.setrlimit(resource.RLIMIT_FSIZE, ({limit},"
               " resource.getrlimit(resource.RLIMIT_FSIZE)[1])); sys.exit(main(sys.argv[1:]))")
    study = tmp_path / "s.yaml"
    study.write_text(RATTLE_40K, encoding="utf-8")
    out = tmp_path / "a.nc"
    args = ["run", str(study), "-o", str(out), "-q", "--chunk-size", "4000"]
    r = subprocess.run([sys.executable, "-c", limited, *args], env=_env(), capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    assert "writing.nc: this process's file-size limit (1.5 MB, ulimit -f) is reached at" in r.stderr
    assert r.stderr.endswith(": raise the file-size limit (ulimit -f) and run the same command"
                             " to continue\n"), r.stderr
    assert main(args) == 0 and out.stat().st_size > limit


CONTINUED_6E6 = """\
title: continuation, six million cases
scene: {kind: rattle, mass: 0.1527 kg, teeth: 48, stiffness: 1073 kN/mm, backlash: 0.1 mm,
        mean_force: 100 N, fluctuation: [{amplitude: 300 N, order: 1}]}
sweep:
  mean_force: {start: 100 N, stop: 700 N, num: 60}
  speed: {start: 2000 rpm, stop: 12000 rpm, num: 50000}
continuation: [up, down]
solver: {steps_per_period: 32, transient_periods: 40, record_periods: 10}
"""


def test_a_six_million_case_continuation_is_not_one_chunk(tmp_path, capsys):
    """Chunks of at most about 30 s, and a long study in several of them (progress per chunk,
    a kill loses at most one), whatever --chunk-size asks for."""
    from gearsweep.study.estimate import CHUNK_SECONDS, chunk_cases, quick_estimate
    from gearsweep.study.plan import make_plan
    from gearsweep.study.schema import parse_study

    plan = make_plan(parse_study(CONTINUED_6E6), CONTINUED_6E6)
    assert len(plan.chunks()) == 1  # the runner's default alone: one chunk of 60 lanes
    chunk, capped = chunk_cases(plan, None, threads=2)
    est, _ = quick_estimate(plan, chunk, threads=2)
    assert capped and est.chunks >= 2
    for requested in (None, 6_000_000, 10**9):
        chunk, _ = chunk_cases(plan, requested, threads=2)
        est, compile_s = quick_estimate(plan, chunk, threads=2)
        assert (est.seconds - compile_s) / est.chunks <= CHUNK_SECONDS
    study = tmp_path / "c.yaml"
    study.write_text(CONTINUED_6E6, encoding="utf-8")
    assert main(["run", str(study), "--estimate", "--chunk-size", "6000000"]) == 0
    out = capsys.readouterr()
    assert "using 200000 cases per chunk" in out.err or "cases per chunk" in out.err
    assert " in 1 chunk:" not in out.out


def _scale_plan(speeds: int, device: str = "cpu", transient: int = 60):
    """``studies/heavy/scale_1e6.yaml`` with ``speeds`` speeds (10,000 cases per speed), on
    ``device``, with ``transient`` transient periods."""
    from gearsweep.study.plan import make_plan
    from gearsweep.study.schema import parse_study

    text = (Path(__file__).parents[1] / "studies/heavy/scale_1e6.yaml").read_text(encoding="utf-8")
    text = text.replace("num: 100}", f"num: {speeds}}}", 1)
    text = text.replace("transient_periods: 60", f"transient_periods: {transient}\n  device: {device}")
    return make_plan(parse_study(text), text)


def test_every_worker_gets_chunks():
    """--workers N cuts the default chunks so that each worker process has about
    CHUNKS_PER_WORKER of them (a 1e6-case study was 3 chunks, and 8 or 16 workers were no faster
    than 4 on a 16-core machine), never below WORKER_CHUNK_STEPS steps; in-process, unchanged."""
    from gearsweep.study.estimate import CHUNKS_PER_WORKER, WORKER_CHUNK_STEPS, chunk_cases
    from gearsweep.study.execute import lanes_per_chunk

    plan = _scale_plan(100)  # 1e6 cases of 2,560 steps
    alone = plan.chunks(lanes_per_chunk(plan, chunk_cases(plan, None, threads=16)[0]))
    assert len(alone) < 8
    for workers in (2, 4, 8, 16):
        chunk, _ = chunk_cases(plan, None, threads=16, workers=workers)
        chunks = plan.chunks(lanes_per_chunk(plan, chunk))
        steps = [(b - a) * plan.steps_per_case for a, b in chunks[:-1]]
        assert len(chunks) >= min(CHUNKS_PER_WORKER * workers, 1e6 * 2560 / WORKER_CHUNK_STEPS)
        assert len(chunks) >= workers and min(steps) >= WORKER_CHUNK_STEPS
    assert chunk_cases(plan, None, threads=16, workers=1) == chunk_cases(plan, None, threads=16)
    assert chunk_cases(plan, 50_000, workers=16)[0] == 50_000  # what the user asked for stays


def test_a_gpu_study_is_chunked_and_estimated_for_the_gpu():
    """device: cuda plans chunks of about cuda.CHUNK_STEPS (the CPU's are 1e9 steps) and states
    the GPU's rate, so that a study hours long on the CPU is not refused for it, and not measured
    on the CPU before refusing. (Planning and estimating need no GPU.)"""
    from gearsweep.kernels import cuda
    from gearsweep.study.estimate import MAX_SPEEDUP, before_refusing, quick_estimate
    from gearsweep.study.execute import LIMITS
    from gearsweep.study.plan import CHUNK_STEPS

    cpu, gpu = _scale_plan(1000), _scale_plan(1000, "cuda")  # 1e7 cases of 2,560 steps
    assert (cpu.device, gpu.device) == ("cpu", "cuda")
    per = cpu.steps_per_case
    assert abs(cpu.default_lanes_per_chunk() * per - CHUNK_STEPS) <= per
    assert abs(gpu.default_lanes_per_chunk() * per - cuda.CHUNK_STEPS) <= per
    assert len(gpu.chunks()) >= 5  # the writer overlaps the GPU, memory holds a few chunks
    est, compile_s = quick_estimate(gpu)
    assert "on the GPU at 8e+04 Msteps/s (stated) and compiling its kernel" in est.line()
    assert est.device == "cuda" and compile_s == 0  # not the CPU kernel's cold compile
    # the peak memory measured on an H200 for this study with the GPU's chunks
    data = Path(__file__).parents[1] / "docs/data/device-2026-11-26/call2/gpu_study.jsonl"
    runs = [json.loads(ln) for ln in data.read_text(encoding="utf-8").splitlines()]
    peak = next(r["peak_rss_mb"] for r in runs if r["chunks"] == "default"
                and r["codec"] == "default") * 1e6
    assert peak <= est.memory_bytes <= 1.5 * peak
    cpu, gpu = _scale_plan(1000, transient=6000), _scale_plan(1000, "cuda", transient=6000)
    cpu_est, _ = quick_estimate(cpu, threads=2)
    est, _ = quick_estimate(gpu)
    kernel_s = gpu.n_cases * gpu.steps_per_case / cuda.STATED_STEPS_PER_SECOND
    # on the CPU beyond MAX_SPEEDUP x the limit (refused at once); on the GPU within it
    assert cpu_est.seconds > MAX_SPEEDUP * LIMITS.seconds
    assert kernel_s < est.seconds < LIMITS.seconds
    assert before_refusing(gpu, est)[0] is est


def test_codec_zlib_writes_the_same_numbers_for_readers_without_zstd(tmp_path):
    """``--codec zlib``: a file any HDF5 reads, with the numbers of the default (zstd) file."""
    study = tmp_path / "s.yaml"
    study.write_text(STUDY.replace("NUM", "8"), encoding="utf-8")
    assert main(["run", str(study), "-o", str(tmp_path / "z.nc"), "-q"]) == 0
    assert main(["run", str(study), "-o", str(tmp_path / "l.nc"), "-q", "--codec", "zlib"]) == 0
    with xr.open_dataset(tmp_path / "z.nc") as z, xr.open_dataset(tmp_path / "l.nc") as zl:
        assert zl["p_rms"].encoding.get("zlib") is True
        assert z["p_rms"].encoding.get("zstd") is True
        for name in z.data_vars:
            np.testing.assert_array_equal(z[name].values, zl[name].values)


@pytest.mark.parametrize("text", [
    "type: mesh\ntitle: m\ngear: table1_consistent\ntorque: 50 N m\npositions: 20\nharmonics: 2\n",
    ("type: analysis\ntitle: a\nanalysis: {kind: method_stability, zeta: [0.3], curve_points: 3,"
     " zeta_max: 0.4, steps: 1000}\n")])
def test_codec_zlib_applies_to_mesh_and_analysis_results_too(tmp_path, text):
    """``--codec zlib`` was dropped for a mesh or analysis study: its file was written with zstd,
    which the reader the option is for cannot read (found by an outside reader of results)."""
    study = tmp_path / "s.yaml"
    study.write_text(text, encoding="utf-8")
    out = tmp_path / "l.nc"
    assert main(["run", str(study), "-o", str(out), "-q", "--codec", "zlib"]) == 0
    with xr.open_dataset(out) as ds:
        numeric = [n for n in ds.data_vars if ds[n].dtype.kind in "fiub" and ds[n].ndim]
        assert numeric
        for name in numeric:
            assert ds[name].encoding.get("zlib") is True, name
            assert not ds[name].encoding.get("zstd"), name


def test_a_continued_sweep_too_long_for_one_chunk_is_said_before_running(tmp_path, capsys):
    """One continued sweep is never split (its state carries from speed to speed): when it alone
    lasts beyond the chunk target, the run says so before computing (issue 29: a kill loses at
    most one chunk, and here a chunk is that long)."""
    study = tmp_path / "long.yaml"
    study.write_text(CONTINUED_6E6.replace("  mean_force: {start: 100 N, stop: 700 N, num: 60}\n",
                                           "").replace("num: 50000", "num: 1000000"),
                     encoding="utf-8")
    t0 = time.perf_counter()
    assert main(["run", str(study), "--estimate", "-o", str(tmp_path / "o.nc")]) == 0
    err = capsys.readouterr().err
    assert "one continued sweep (1,000,000 speeds)" in err and "never split" in err
    assert time.perf_counter() - t0 < 5


def test_validate_says_the_compile_time_as_run_estimate_does(monkeypatch, capsys, write_study,
                                                            small_whine):
    """On a cold cache ``validate`` and ``run --estimate`` print the same estimate, both with
    the compile note; and so does a refusal. (``before_refusing`` returned 0 compile seconds for
    a study within the limits, and validate printed "about 9.0 s" without saying why.)"""
    from gearsweep.study import estimate as est_mod

    monkeypatch.setattr(est_mod, "compile_seconds", lambda *args: 6.0)
    study = write_study(small_whine)
    assert main(["validate", str(study)]) == 0
    validated = capsys.readouterr().out.split("estimate: ", 1)[1].strip()
    assert main(["run", str(study), "--estimate"]) == 0
    estimated = capsys.readouterr().out.split(": ", 1)[1].strip()
    assert validated == estimated
    assert estimated.endswith("; includes about 6 s to compile the kernel once (cold cache)")
    small_whine["sweep"]["speed"]["num"] = 10**6
    small_whine["solver"]["record_periods"] = 10**5  # 3e12 steps: refused without measuring
    assert main(["validate", str(write_study(small_whine, "huge.yaml"))]) == 2
    assert "includes about 6 s to compile" in capsys.readouterr().err


def test_run_asks_the_kernel_cache_only_where_the_answer_can_change_what_it_says(
        monkeypatch, capsys, write_study, small_whine, tmp_path):
    """A run asks Numba's cache whether its kernel is compiled (7 ms) only where the estimate
    is shown (--estimate, or a study over SHOW_ESTIMATE_SECONDS) or could reach the limits; a
    small study runs without asking, and with the compile time counted as the most it can be
    it is still under both. A long one asks, and prints the estimate with the cache's answer."""
    from gearsweep import cli
    from gearsweep.kernels import batch

    asked = []
    real = batch.compiled  # what the estimate asks (``batch.not_compiled``)
    monkeypatch.setattr(batch, "compiled", lambda call: asked.append(1) or real(call))
    study = write_study(small_whine)
    assert main(["run", str(study), "-o", str(tmp_path / "a.nc"), "-q"]) == 0
    assert asked == []
    assert main(["run", str(study), "--estimate"]) == 0
    assert asked and "cases" in capsys.readouterr().out
    asked.clear()
    monkeypatch.setattr(cli, "SHOW_ESTIMATE_SECONDS", 0.0)  # now every study is "long"
    assert main(["run", str(study), "-o", str(tmp_path / "b.nc")]) == 0
    assert asked and "cases, " in capsys.readouterr().err


def test_a_study_over_the_time_limit_at_the_stated_rate_is_measured_before_refusing(monkeypatch):
    """The stated rate (350 Msteps/s per core for RK4) is a floor: a study it puts over the
    10-minute limit is estimated again at the rate measured on the machine (here: made 3x the
    stated), and refused only if it is still over; one under the limit is not measured."""
    from gearsweep.study import estimate as est_mod
    from gearsweep.study.plan import make_plan
    from gearsweep.study.schema import parse_study

    calls = []

    def fake_measure(plan, threads):
        calls.append(threads)
        return 3 * est_mod.STATED_RATE[plan.study.solver.method]

    monkeypatch.setattr(est_mod, "measure_rate", fake_measure)
    text = STUDY.replace("NUM", "400000").replace("record_periods: 50", "record_periods: 10000")
    plan = make_plan(parse_study(text, "s.yaml"), text)
    stated, _ = est_mod.quick_estimate(plan, threads=2)
    assert stated.over() and stated.rate_source == "stated"
    measured, _ = est_mod.before_refusing(plan, stated, threads=2)
    assert calls == [2] and measured.rate_source == "measured"
    assert measured.seconds < stated.seconds / 2 and not measured.over()
    small, _ = est_mod.quick_estimate(make_plan(parse_study(STUDY.replace("NUM", "10"), "s.yaml"),
                                                STUDY), threads=2)
    assert est_mod.before_refusing(plan, small, threads=2)[0] is small and calls == [2]
    # Beyond MAX_SPEEDUP times the limit no rate could save it: refused at once, nothing measured
    # (on a cold cache measuring compiles: validate of a 1e12-case grid took 4.9 s in CI).
    text = STUDY.replace("NUM", "4000000").replace("record_periods: 50", "record_periods: 10000")
    huge = make_plan(parse_study(text, "s.yaml"), text)
    stated, _ = est_mod.quick_estimate(huge, threads=2)
    assert est_mod.before_refusing(huge, stated, threads=2)[0] is stated and calls == [2]


_INTERRUPT_AT_IMPORT = """\
import sys

class Interrupt:  # Ctrl-C while the CLI's modules are being imported
    def find_spec(self, name, path=None, target=None):
        if name == "gearsweep.cli":
            raise KeyboardInterrupt

sys.meta_path.insert(0, Interrupt())
from gearsweep.__main__ import entry
sys.argv = ["gearsweep", "run", "s.yaml"]
entry()
"""


def test_ctrl_c_while_the_cli_imports_is_one_line_and_exit_130(tmp_path):
    # Before, the interrupt met no handler yet: a traceback of the module being imported.
    r = subprocess.run([sys.executable, "-c", _INTERRUPT_AT_IMPORT], cwd=tmp_path, env=_env(),
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 130, r.stderr
    assert r.stderr == "gearsweep: interrupted\n", r.stderr


_INTERRUPT_WHILE_PYDANTIC_BUILDS = """\
import os, signal, sys
import pydantic.plugin._schema_validator as sv

real = sv.SchemaValidator

def building(*args, **kw):  # a Ctrl-C 0.1 ms into the build of a model's validator (in Rust)
    signal.setitimer(signal.ITIMER_REAL, 1e-4)
    return real(*args, **kw)

sv.SchemaValidator = building
signal.signal(signal.SIGALRM, lambda signum, frame: os.kill(os.getpid(), signal.SIGINT))
from gearsweep.__main__ import entry
sys.argv = ["gearsweep", "run", "s.yaml", "-o", "o.nc", "-q"]
entry()
"""


def test_ctrl_c_while_pydantic_builds_a_validator_is_one_line_and_exit_130(tmp_path):
    # The study models' validators are built when the first study is parsed (defer_build):
    # pydantic turned a KeyboardInterrupt raised in its Rust build into a SchemaError, a
    # traceback of 40 lines and exit 1 (an outside tester: 3 in ~85 Ctrl-C of a large study).
    (tmp_path / "s.yaml").write_text(STUDY.replace("NUM", "8"), encoding="utf-8")
    r = subprocess.run([sys.executable, "-c", _INTERRUPT_WHILE_PYDANTIC_BUILDS], cwd=tmp_path,
                       env=_env(), capture_output=True, text=True, timeout=120)
    assert (r.returncode, r.stderr) == (130, "gearsweep: interrupted\n"), r.stderr[-3000:]
    assert not (tmp_path / "o.nc").exists()


class _Terminated(Exception):
    pass


def _terminated(signum, frame):
    raise _Terminated


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="fork and spawn, POSIX masks")
@pytest.mark.parametrize("method", ["fork", "spawn"])
def test_a_signal_while_local_workers_start_reaches_this_process_not_the_workers(method):
    """A Ctrl-C or SIGTERM while a local cluster starts (``execute._starting_workers``) is this
    process's once the workers are up; a worker, started from a thread as dask does, outlives
    a Ctrl-C and dies of SIGTERM. (SIGINT was ignored here: the first Ctrl-C of ``gearsweep run
    --workers 2`` lost in 3 of 6 tries, the run went on to its end, exit 0; SIGTERM was not
    held: the process ended without a word.)"""
    import multiprocessing

    from gearsweep.study import execute

    ctx = multiprocessing.get_context(method)
    workers: list = []

    def start() -> None:
        workers.append(ctx.Process(target=time.sleep, args=(60,), daemon=True))
        workers[0].start()

    previous = signal.signal(signal.SIGTERM, _terminated)
    try:
        for sig, stop in ((signal.SIGINT, KeyboardInterrupt), (signal.SIGTERM, _Terminated)):
            workers.clear()
            reached = False
            with pytest.raises(stop):
                with execute._starting_workers(method):
                    os.kill(os.getpid(), sig)
                    thread = threading.Thread(target=start)
                    thread.start()
                    thread.join()
                    reached = True
            assert reached  # held to the end of the start, then raised here
            worker = workers[0]
            try:
                os.kill(worker.pid, signal.SIGINT)  # the terminal's Ctrl-C reaches the group
                worker.join(3)
                assert worker.is_alive()
                worker.terminate()  # the nanny's SIGTERM at the cluster's close
                worker.join(30)
                assert worker.exitcode == -signal.SIGTERM
            finally:
                worker.kill()
                worker.join(30)
    finally:
        signal.signal(signal.SIGTERM, previous)


_UP_THEN_GEARSWEEP = """\
import runpy, sys
sys.argv = ["gearsweep", *sys.argv[1:]]
print("up", flush=True)  # Python has started: a SIGINT from now on is gearsweep's to handle
runpy.run_module("gearsweep", run_name="__main__", alter_sys=True)
"""


def test_ctrl_c_at_any_moment_of_the_start_leaves_no_traceback(tmp_path):
    # A real SIGINT at several moments after Python has started (a SIGINT while the interpreter
    # itself starts is Python's: "Fatal Python error: init_import_site"): while the CLI imports,
    # while it reads the study, in the first chunk. Whatever it hits, one line, exit 130.
    study = tmp_path / "s.yaml"
    study.write_text(STUDY.replace("NUM", "40000"), encoding="utf-8")  # about 2 s: the last
    # SIGINT (0.5 s) still lands before the end on a fast machine
    for delay in (0.03, 0.1, 0.25, 0.5):
        proc = subprocess.Popen([sys.executable, "-c", _UP_THEN_GEARSWEEP, "run", str(study),
                                 "-o", str(tmp_path / "o.nc"), "-q"], cwd=tmp_path, env=_env(),
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        assert proc.stdout.readline() == "up\n"
        time.sleep(delay)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=120)
        assert proc.returncode == 130, (delay, err)
        assert "Traceback" not in err and len(err.strip().splitlines()) <= 2, (delay, err)


_COLLECTOR_AFTER_ENTRY = """\
import atexit, gc, sys
from gearsweep.study import execute

seen = []
real = execute._warm_up
def warm_up(plan, first=None):  # the collector as the warm-up finds it
    seen.append(gc.isenabled())
    return real(plan, first)
execute._warm_up = warm_up
atexit.register(lambda: print(gc.isenabled(), gc.get_freeze_count() > 10000, seen, flush=True))
from gearsweep.__main__ import entry
sys.argv = ["gearsweep", *sys.argv[1:]]
entry()
"""


def test_the_cli_pauses_the_collector_for_its_set_up_only(tmp_path):
    """``gearsweep`` imports with Python's cyclic collector paused and freezes what the imports
    made (``gc.freeze``); the warm-up of a cached kernel runs paused too; the chunks and the
    exit run with the collector on. (Together 66 ms of a 1e6-case run, docs/scale.md.) A cold
    kernel compiles with the collector on: a compile makes garbage cycles by the million."""
    study = tmp_path / "s.yaml"
    study.write_text(STUDY.replace("NUM", "200"), encoding="utf-8")
    args = ["run", str(study), "-o", str(tmp_path / "o.nc"), "-q"]
    main(args)  # the kernels in Numba's cache
    r = subprocess.run([sys.executable, "-c", _COLLECTOR_AFTER_ENTRY, *args], cwd=tmp_path,
                       env=_env(), capture_output=True, text=True, timeout=120, check=True)
    assert r.stdout.split("\n")[-2] == "True True [False]", r.stdout + r.stderr


def test_warm_up_leaves_the_collector_as_it_found_it(monkeypatch):
    """``execute.warm_up`` in a library call: the collector is as before, on or off, and on
    during the warm-up when a kernel is to be compiled."""
    import gc

    from gearsweep.study import execute
    from gearsweep.study.plan import make_plan
    from gearsweep.study.schema import parse_study

    text = STUDY.replace("NUM", "50")
    plan = make_plan(parse_study(text, "s.yaml"), text)
    seen = []
    real = execute._warm_up
    monkeypatch.setattr(execute, "_warm_up", lambda p, f=None: (seen.append(gc.isenabled()),
                                                                 real(p, f)))
    was = gc.isenabled()
    try:
        for state in (True, False):
            (gc.enable if state else gc.disable)()
            execute.warm_up(plan)
            assert gc.isenabled() is state
        monkeypatch.setattr(execute, "_cached", lambda p: False)  # as if it had to compile
        gc.enable()
        execute.warm_up(plan)
        assert gc.isenabled()
    finally:
        (gc.enable if was else gc.disable)()
    assert seen == [False, False, True]


_LIGHT_LOADS = """\
import sys
import numpy as np
import pytest
from gearsweep.cli import main
code = main(sys.argv[1:])
# the kernels came from the cache without Numba's compiler set-up: its registries not imported
light = "numba.np.random.generator_core" not in sys.modules
# and a compile afterwards still sets everything up and works (sort, median, random: registries)
import numba

@numba.njit
def f(a):
    np.random.seed(0)
    return np.sort(a)[0] + np.random.random() * 0 + np.median(a)

print(code, light, f(np.array([3.0, 1.0, 2.0])), flush=True)
"""


def test_a_run_loads_cached_kernels_without_numba_s_compiler_set_up(tmp_path):
    """With the kernels in Numba's cache, a run loads them without Numba's compiler set-up
    (``jit.cache_loads_without_set_up``: its typing and lowering registries, 60-90 ms of every
    start): none of those modules is imported by the run, whose results are those of a run in
    this process; a function compiled afterwards in the same process still gets everything."""
    import xarray as xr

    study = tmp_path / "s.yaml"
    study.write_text(STUDY.replace("NUM", "50"), encoding="utf-8")
    main(["run", str(study), "-o", str(tmp_path / "here.nc"), "-q"])  # the kernels cached
    r = subprocess.run([sys.executable, "-c", _LIGHT_LOADS, "run", str(study), "-o",
                        str(tmp_path / "there.nc"), "-q"], cwd=tmp_path, env=_env(),
                       capture_output=True, text=True, timeout=120, check=True)
    assert r.stdout.split("\n")[-2] == "0 True 3.0", r.stdout + r.stderr
    with xr.open_dataset(tmp_path / "here.nc") as a, xr.open_dataset(tmp_path / "there.nc") as b:
        for name in a.data_vars:
            assert np.array_equal(a[name].values, b[name].values, equal_nan=True), name


def _full_after(real, n: int):
    """``real`` (a method) that raises ENOSPC from its ``n + 1``-th call on."""
    calls = []

    def fake(self, *args, **kwargs):
        calls.append(args[:2])
        if len(calls) > n:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real(self, *args, **kwargs)

    return fake


def test_a_full_disk_is_one_line_keeps_the_saved_chunks_and_the_same_command_completes(
        tmp_path, capsys, monkeypatch):
    """A disk that fills up under a run (the chunk files, then the result file): one line naming
    what could not be written and how many chunks are saved, exit 2, no traceback; the saved
    chunks stay, and the same command, once there is room, computes only the others and
    writes the file an uninterrupted run writes."""
    from gearsweep.study.checkpoint import ChunkStore
    from gearsweep.study.resultfile import ResultFile

    study = tmp_path / "s.yaml"
    study.write_text(STUDY.replace("NUM", "4000"), encoding="utf-8")
    out = tmp_path / "out.nc"
    args = ["run", str(study), "-o", str(out), "-q", "--chunk-size", "500"]
    monkeypatch.setattr(ChunkStore, "save", _full_after(ChunkStore.save, 3))
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"gearsweep: error: {out}: cannot write: No space left on device;"
                          f" 3 of 8 chunks saved in {out}.chunks: make room and run the same"
                          " command to continue"), err
    assert err.count("\n") == 1 and not out.exists()

    # the result file's writes fail (netCDF4 says only "NetCDF: HDF error")
    monkeypatch.undo()
    real_set = ResultFile.write

    def failing(self, a, b, arrays):
        if a > 0:
            raise self._write_error(RuntimeError("NetCDF: HDF error"))
        return real_set(self, a, b, arrays)

    monkeypatch.setattr(ResultFile, "write", failing)
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "writing.nc: the netCDF library failed (NetCDF: HDF error;" in err
    # the run stops at the failed write (not after every chunk): those computed by then are kept
    found = re.search(r"MB free on its disk\); (\d) of 8 chunks saved in .*: (make room|fix"
                      r" that) and run the same command to continue\n$", err)
    assert found and err.count("\n") == 1, err
    saved = int(found[1])
    assert 3 < saved <= 8
    assert sum(1 for _ in chunk_folder(out).rglob("chunk_*.npys")) == saved

    monkeypatch.undo()
    log = tmp_path / "log"
    monkeypatch.setenv("GEARSWEEP_CHUNK_LOG", str(log))
    assert main(args) == 0
    computed = log.read_text().splitlines() if log.exists() else []
    assert len(computed) == 8 - saved  # only the chunks not saved are computed
    again = tmp_path / "again.nc"
    assert main(["run", str(study), "-o", str(again), "-q", "--chunk-size", "500"]) == 0
    with xr.open_dataset(out) as a, xr.open_dataset(again) as b:
        xr.testing.assert_identical(a.drop_attrs(), b.drop_attrs())


def test_a_disk_full_before_the_result_file_is_made_is_one_line(tmp_path, capsys, monkeypatch):
    """netCDF4 fails while the result file's coordinates are written (``RuntimeError``, 'HDF
    error'): one line, exit 2, no half-made file left."""
    import netCDF4

    real = netCDF4.Variable.__setitem__

    def full(self, key, value):
        if self.name == "speed":
            raise RuntimeError("NetCDF: HDF error")
        return real(self, key, value)

    monkeypatch.setattr(netCDF4.Variable, "__setitem__", full)
    study = tmp_path / "s.yaml"
    study.write_text(STUDY.replace("NUM", "400"), encoding="utf-8")
    out = tmp_path / "out.nc"
    assert main(["run", str(study), "-o", str(out), "-q", "--chunk-size", "100"]) == 2
    err = capsys.readouterr().err
    assert "writing.nc: the netCDF library failed (NetCDF: HDF error; " in err, err
    assert err.count("\n") == 1 and not out.exists()
    assert not list(chunk_folder(out).rglob("writing.nc"))


@pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="counts threads in /proc")
def test_the_command_holds_openblas_to_one_thread_unless_told(tmp_path):
    """OpenBLAS started a thread per core at NumPy's import, spinning beside the import (0.1 s
    of CPU of a 0.35 s tiny run): the command sets ``OPENBLAS_NUM_THREADS=1`` before it, and
    keeps a value the environment gives. Counted at the command's exit: the only thread left."""
    code = """
import atexit, os, sys
sys.argv = ["gearsweep", "validate", sys.argv[1]]
atexit.register(lambda: print(len(os.listdir("/proc/self/task")),
                              os.environ.get("OPENBLAS_NUM_THREADS"), file=sys.stderr))
from gearsweep.__main__ import entry
entry()
"""
    study = ROOT / "studies" / "fig08_rattle.yaml"
    for given, said in ((None, "1 1"), ("2", "2")):
        env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
        if given:
            env["OPENBLAS_NUM_THREADS"] = given
        proc = subprocess.run([sys.executable, "-c", code, str(study)], env=env, cwd=ROOT,
                              capture_output=True, text=True, timeout=120)
        assert proc.returncode == 0, proc.stderr
        threads, value = proc.stderr.strip().splitlines()[-1].split()
        assert (value if given else f"{threads} {value}") == said, proc.stderr



def test_gearsweep_run_with_an_output_holds_it_as_the_cli_does(tmp_path, small_whine):
    """``gearsweep.run(..., output=)`` takes the output's lock and refuses another study's
    saved chunks there, as ``gearsweep run`` does: beside a running CLI run it made that run's
    file unreadable (which then said it had written it), and a run of another study deleted
    that run's chunks (an adversarial test)."""
    import gearsweep
    from gearsweep.study.workspace import BusyError, OutputLock

    out = tmp_path / "o.nc"
    with OutputLock(out), pytest.raises(BusyError, match="another gearsweep run"):
        gearsweep.run(small_whine, output=out)
    assert not out.exists()
    study = tmp_path / "s.yaml"
    study.write_text(STUDY.replace("NUM", "10000"), encoding="utf-8")
    _, out2, _, code, _ = _signalled_after_two_chunks(tmp_path, signal.SIGINT)
    assert code == 130 and any(chunk_folder(out2).glob("*/*.npys"))
    with pytest.raises(BusyError, match="saved chunk"):
        gearsweep.run(small_whine, output=out2)  # another study: the chunks are kept
    assert any(chunk_folder(out2).glob("*/*.npys"))
    assert gearsweep.run(small_whine, output=tmp_path / "free.nc").sizes["speed"] > 0


def test_an_output_lock_that_cannot_be_written_is_one_line_and_leaves_nothing(tmp_path,
                                                                             monkeypatch):
    """A disk full when the lock's PID file is written, or a folder where the lock goes: one
    line (``ResultError``), no lock files and no folders the run made (were a 40-line traceback,
    exit 1, with ``o.nc.lock`` and an empty ``o.nc.lock.pid`` left)."""
    import errno
    from pathlib import Path as P

    from gearsweep.errors import ResultError
    from gearsweep.study.workspace import OutputLock

    real = P.write_text

    def full(self, *args, **kwargs):
        if self.name.endswith(".lock.pid"):
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(self, *args, **kwargs)

    monkeypatch.setattr(P, "write_text", full)
    out = tmp_path / "new" / "deeper" / "o.nc"
    with pytest.raises(ResultError, match="cannot write the result here .*No space left on device"):
        with OutputLock(out):
            pass
    assert not (tmp_path / "new").exists()
    monkeypatch.undo()
    (tmp_path / "h.nc.lock").mkdir()
    with pytest.raises(ResultError, match="cannot write the result here"):
        with OutputLock(tmp_path / "h.nc"):
            pass


def test_a_stop_keeps_the_chunk_that_was_computing_and_the_last_chunk_finishes_the_run():
    """After the first Ctrl-C the chunk that was computing is handed on (to be saved), then the
    run stops; a stop during the last chunk lets the run end normally. (The chunk that finished
    after the stop was dropped: a one-chunk continued sweep ran to its end and kept nothing.)"""
    from gearsweep import cli

    class Fake:
        def __init__(self, stop_at: int) -> None:
            self.stop_at = stop_at

        def run(self, plan, todo):
            for i, c in enumerate(todo):
                if i == self.stop_at:
                    cli._STOP.set()  # Ctrl-C while chunk i computes
                yield c

    try:
        for stop_at, want, stops in ((1, [0, 1], True), (3, [0, 1, 2, 3], False)):
            cli._STOP.clear()
            got = []
            try:
                for c in cli._stoppable(Fake(stop_at)).run(None, [0, 1, 2, 3]):
                    got.append(c)
                stopped = False
            except KeyboardInterrupt:
                stopped = True
            assert (got, stopped) == (want, stops)
    finally:
        cli._STOP.clear()


def test_a_stop_while_the_checkpoints_are_removed_leaves_a_finished_run(tmp_path, monkeypatch,
                                                                       write_study, small_whine):
    """A signal after the result is in place, while the chunk files are removed, ends the run
    as finished, the chunks all removed (it reported a failed run with the file complete, and
    left half the chunks, which the next run said it resumed: an adversarial test)."""
    from gearsweep.study import execute
    from gearsweep.study.plan import make_plan
    from gearsweep.study.schema import load_study

    real, calls = execute.remove_checkpoints, []

    def interrupted(output):
        calls.append(output)
        if len(calls) == 1:
            raise KeyboardInterrupt
        real(output)

    monkeypatch.setattr(execute, "remove_checkpoints", interrupted)
    plan = make_plan(*load_study(str(write_study(small_whine))))
    out = tmp_path / "o.nc"
    written = execute.stream_to_file(plan, out)
    assert written.cases == plan.n_cases and out.is_file() and len(calls) == 2
    assert not chunk_folder(out).exists()


def test_exceptions_ignored_in_callbacks_are_not_printed_once_a_stop_is_asked():
    """A stop raised in the main thread may land in a callback or a destructor (llvmlite's
    object cache while a kernel loads): Python printed "Exception ignored in ..." with a
    traceback beside the run's one line. Before a stop they are printed as ever."""
    from gearsweep import cli

    seen = []
    hook = cli._quiet_once_stopping(seen.append)
    try:
        hook("before")
        cli._STOP.set()
        hook("after")
    finally:
        cli._STOP.clear()
    assert seen == ["before"]


def test_an_interruption_before_any_chunk_is_saved_leaves_no_chunk_folder(tmp_path, write_study,
                                                                         small_whine):
    """Interrupted before its first chunk was saved, a run says there is nothing to continue
    from and removes the folder it made (it said "0 of 22 chunks saved ...; run the same
    command to continue" and left a folder holding the manifest only)."""
    from gearsweep import cli
    from gearsweep.study.checkpoint import ChunkStore
    from gearsweep.study.execute import chunks_to_run
    from gearsweep.study.plan import make_plan
    from gearsweep.study.schema import load_study

    plan = make_plan(*load_study(str(write_study(small_whine))))
    out = tmp_path / "o.nc"
    ChunkStore(out, plan.study_key, plan.n_lanes, chunks_to_run(plan, out, None)).open()
    assert chunk_folder(out).is_dir()
    line = cli._interrupted_line(plan, out, None)
    assert line == "interrupted before the first chunk was saved: nothing to continue from"
    assert not chunk_folder(out).exists()


@pytest.mark.parametrize("terms", [("fluctuation",), ("fluctuation", "ste", "stiffness_harmonics")])
def test_the_estimate_counts_the_excitation_tables_of_a_long_cycle(terms):
    """Orders 0.0208333 and 0.0208 make a cycle of 30,000 mesh periods: the kernel's tables (5
    nodes a step over the cycle) are 38.4 MB each at 32 steps per period. The estimate said 300
    MB whatever the cycle (a study peaking at 4.0 GB ran without --yes). Truth: the memory
    NumPy allocates to build the kernel inputs (tracemalloc's peak)."""
    import tracemalloc

    import yaml

    from gearsweep.model import kernel_inputs
    from gearsweep.study.estimate import BASELINE_MEMORY, quick_estimate, table_bytes
    from gearsweep.study.plan import make_plan
    from gearsweep.study.schema import parse_study

    scene = {"kind": "whine", "mass": "0.1527 kg", "teeth": 48, "stiffness": "1073 kN/mm",
             "damping": "5.5 N*s/mm", "mean_force": "833 N",
             "fluctuation": [{"amplitude": "300 N", "order": 0.0208},
                             {"amplitude": "1 N", "order": 0.0208333}],
             "ste": [{"amplitude": "5 um", "order": 0.0208}],
             "stiffness_harmonics": [{"amplitude": "100 kN/mm", "order": 0.0208}]}
    for name in ("ste", "stiffness_harmonics"):
        if name not in terms:
            scene.pop(name)
    text = yaml.safe_dump({"title": "long cycle", "scene": scene, "sweep": {"speed": [3000]},
                           "solver": {"steps_per_period": 32, "transient_periods": 0,
                                      "record_periods": 60000}})
    plan = make_plan(parse_study(text), text)
    assert plan.model.cycle_periods == 30000
    tracemalloc.start()
    try:
        kernel_inputs(plan.model, {"speed": np.array([3000.0])}, 1, 32)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak > 1e8  # the tables are what matters here
    assert peak <= 1.01 * table_bytes(plan, several=False) <= 1.5 * peak
    est, _ = quick_estimate(plan)
    assert est.memory_bytes >= BASELINE_MEMORY + peak / 1.01


def _ctrl_c() -> None:
    """A Ctrl-C to this process, handled (``cli._on_sigint``) before this returns."""
    os.kill(os.getpid(), signal.SIGINT)
    time.sleep(0.01)


def test_a_ctrl_c_while_a_one_chunk_run_loads_its_kernel_stops_before_the_chunk(
        tmp_path, monkeypatch, capsys, write_study, small_whine):
    """A Ctrl-C while the kernel compiled (a cold cache) of a one-chunk run was told "stopping
    after the chunk being computed ...", then the run finished and wrote its file, exit 0 (an
    outside tester). No chunk was computing: it stops before the first, as the README says
    ("Ctrl-C stops after the chunk being computed"), and says so."""
    from gearsweep.study import execute

    real = execute.warm_up

    def interrupted(plan, first=None):
        _ctrl_c()  # while the kernel loads
        real(plan, first)

    monkeypatch.setattr(execute, "warm_up", interrupted)
    out = tmp_path / "o.nc"
    assert main(["run", str(write_study(small_whine)), "-o", str(out)]) == 130
    err = capsys.readouterr().err
    assert ("gearsweep: stopping before the first chunk begins (Ctrl-C again"
            " to stop at once)") in err, err
    assert "interrupted before the first chunk was saved: nothing to continue from" in err
    assert not out.exists()


def test_a_ctrl_c_during_the_last_chunk_says_the_run_finishes(tmp_path, monkeypatch, capsys,
                                                               write_study, small_whine):
    """During the last (here the only) chunk a Ctrl-C lets the run finish and write its file
    (README): the line says that, not "stopping after the chunk being computed"."""
    from gearsweep.study import execute

    real = execute.run_prepared

    def interrupted(plan, prep):
        _ctrl_c()  # while the chunk computes
        return real(plan, prep)

    monkeypatch.setattr(execute, "run_prepared", interrupted)
    out = tmp_path / "o.nc"
    assert main(["run", str(write_study(small_whine)), "-o", str(out)]) == 0
    err = capsys.readouterr().err
    assert ("gearsweep: finishing the last chunk and writing the file (Ctrl-C again to stop at"
            " once)") in err, err
    assert "stopping after" not in err
    assert xr.open_dataset(out).sizes["speed"] == 7


def test_a_cluster_s_stop_with_no_chunk_computing_says_so(capsys, monkeypatch):
    """A cluster's stop that cancelled every chunk in flight (none begun) calls ``stopping(0)``:
    the line said "stopping after the chunk being computed, which is kept" (n clamped to 1; a
    reviewer). It says that no chunk is being computed, with nothing to Ctrl-C again for."""
    from gearsweep import cli

    monkeypatch.setattr(cli, "_left", 5)
    cli._say_stopping(0)
    assert capsys.readouterr().err == "gearsweep: stopping now: no chunk is being computed\n"
    cli._say_stopping(2)
    assert capsys.readouterr().err == ("gearsweep: stopping after the 2 chunks being computed,"
                                       " which are kept (Ctrl-C again to stop at once)\n")


def test_a_cluster_s_capped_chunk_is_for_one_worker(tmp_path, monkeypatch, capsys):
    """With --scheduler the cap of a chunk counted the whole cluster's cores for it, though a
    chunk runs on one worker: scale_1e7 asked in one chunk on 16 workers of 4 threads was cut
    into a chunk of 8,749,056 cases (87 % of the study, ~16 s on one worker, the others idle;
    a reviewer). A chunk's rounds are of one worker's cores, the cap in seconds the cluster's;
    the note names the cluster's numbers, not this machine's cores."""
    from gearsweep import cli
    from gearsweep.kernels import LANES
    from gearsweep.study.estimate import (
        _longest_chunk_seconds,
        capped_chunk_note,
        chunk_cases,
        shortest_chunk_seconds,
    )
    from gearsweep.study.plan import make_plan
    from gearsweep.study.schema import parse_study

    study = Path(__file__).parents[1] / "studies/heavy/scale_1e7.yaml"
    text = study.read_text(encoding="utf-8")
    plan = make_plan(parse_study(text), text)
    n = plan.n_lanes * plan.cases_per_lane
    chunk, capped = chunk_cases(plan, n, threads=64, workers=16)
    assert capped and chunk <= n // 16, chunk  # every worker has a chunk
    rounds = math.ceil(chunk / (LANES * 4 * plan.cases_per_lane))  # of blocks on a worker's 4
    limit = _longest_chunk_seconds(plan, 64)[0]  # cores; the cap: the cluster's (1 s here)
    assert limit - shortest_chunk_seconds(plan) < rounds * shortest_chunk_seconds(plan) <= limit
    assert chunk_cases(plan, n, threads=64, workers=1) == chunk_cases(plan, n, threads=64)

    class Cluster:  # an existing cluster of 16 workers of 4 threads, as DaskBackend counts it
        n_workers, threads = 16, 64

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            return None

    monkeypatch.setattr(cli, "_backend", lambda args: Cluster())
    assert main(["run", str(study), "-o", str(tmp_path / "o.nc"), "--estimate", "--scheduler",
                 "tcp://10.0.0.5:8786", "--chunk-size", str(n)]) == 0
    err = capsys.readouterr().err
    assert f"gives {capped_chunk_note(plan, 64)}; using {chunk} cases per chunk" in err, err


def test_overwrite_says_what_it_replaces_and_refuses_a_file_that_is_not_netcdf(tmp_path, capsys):
    """``--overwrite``'s help said it replaces "a file that cannot be read as a netCDF result",
    but a file that is not netCDF at all is refused with it too (it may be the user's: the safe
    way); the help now says so, and what it does replace (an outside tester)."""
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    help_text = " ".join(capsys.readouterr().out.split())
    assert "a damaged one (it starts as netCDF does but cannot be read" in help_text, help_text
    assert "A file that is not netCDF at all (a study, a text) is never replaced" in help_text
    study = tmp_path / "s.yaml"
    study.write_text(MESH_STUDY, encoding="utf-8")
    text = tmp_path / "txt.nc"
    text.write_text("hello\n", encoding="utf-8")
    assert main(["run", str(study), "-o", str(text), "-q", "--overwrite"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "remove it first" in err, err
    assert text.read_text(encoding="utf-8") == "hello\n"


_API_INTERRUPTED_AS_XARRAY_WRITES = _SIGNAL_AS_XARRAY_WRITES.split("if len(sys.argv)")[0] + """
import gearsweep
try:
    gearsweep.run("m.yaml", output="out/m.nc")
except KeyboardInterrupt:
    print("KeyboardInterrupt")
"""


def test_a_ctrl_c_while_the_api_writes_a_mesh_result_raises_and_leaves_nothing(tmp_path):
    """``gearsweep.run(mesh_study, output=...)``: a Ctrl-C in xarray's write raises
    ``KeyboardInterrupt`` once the file is closed, and removes it, the lock files too (it hung
    for ever, as the CLI did)."""
    proc, out, err = _mesh_write_interrupted(tmp_path, _API_INTERRUPTED_AS_XARRAY_WRITES,
                                             "SIGINT")
    assert (proc.returncode, out) == (0, "KeyboardInterrupt\n"), err[-3000:]
    assert sorted(os.listdir(tmp_path / "out")) == []

"""Real dask clusters on 127.0.0.1: a scheduler and two worker processes, started with the ``dask``
command line, no dashboards, random free ports, stopped in the fixture's finaliser.

Checks: a study run through ``gearsweep run --scheduler`` and ``--workers 2`` is identical
(bitwise) to the in-process run; a worker killed with SIGKILL mid-run has its chunks re-run and
the study still completes with identical results.
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import time
from contextlib import contextmanager
from pathlib import Path

import pytest
import xarray as xr
from test_execute import LONG, RATTLE, assert_same, plan_of  # the tests folder is on sys.path

from gearsweep.study.checkpoint import chunk_folder
from gearsweep.study.execute import chunks_to_run, run_plan

pytestmark = pytest.mark.cluster

ROOT = Path(__file__).resolve().parents[1]
DASK = shutil.which("dask", path=str(Path(sys.executable).parent)) or shutil.which("dask")


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(timeout=15)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=15)


@contextmanager
def dask_cluster(tmp: Path, n_workers: int = 2, nthreads: int = 1, other: Path | None = None):
    """Start ``dask scheduler`` and ``n_workers`` x ``dask worker`` (no nanny, so that killing a
    worker's process kills the worker); yield the address, the worker processes and the
    scheduler's. ``other``: the last worker imports gearsweep from there (its PYTHONPATH)."""
    if DASK is None:
        pytest.fail("the 'dask' command is not installed next to the Python interpreter")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    procs: list[subprocess.Popen] = []
    logs = []
    try:
        log = open(tmp / "scheduler.log", "w")  # noqa: SIM115 -- closed in the finaliser
        logs.append(log)
        procs.append(subprocess.Popen([DASK, "scheduler", "--host", "127.0.0.1", "--port",
                                       str(port), "--no-dashboard"], env=env, stdout=log,
                                      stderr=subprocess.STDOUT))
        workers = []
        for i in range(n_workers):
            log = open(tmp / f"worker{i}.log", "w")  # noqa: SIM115
            logs.append(log)
            mine = env if other is None or i < n_workers - 1 else dict(env, PYTHONPATH=str(other))
            w = subprocess.Popen([DASK, "worker", address, "--host", "127.0.0.1", "--nthreads",
                                  str(nthreads), "--no-nanny", "--no-dashboard",
                                  "--death-timeout", "60"], env=mine, stdout=log,
                                 stderr=subprocess.STDOUT)
            procs.append(w)
            workers.append(w)
        from distributed import Client

        deadline = time.monotonic() + 120
        while True:
            try:
                with Client(address, timeout="10s") as client:
                    client.wait_for_workers(n_workers, timeout=60)
                break
            except (OSError, TimeoutError):
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.5)
        yield address, workers, procs[0]
    finally:
        for p in reversed(procs):
            _stop(p)
        for log in logs:
            log.close()


def _run_cli(args: list[str], **kw) -> subprocess.Popen:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.Popen([sys.executable, "-m", "gearsweep.cli", "run", *args, "-q"], env=env,
                            cwd=ROOT, **kw)


@pytest.fixture(scope="module")
def rattle_reference():
    return run_plan(plan_of(RATTLE))


def test_scheduler_identical_to_in_process(tmp_path, rattle_reference):
    """The continued rattle study (6 chunks of whole sweeps) through --scheduler on two real
    worker processes with two dask threads each: bitwise identical to one in-process chunk."""
    study = tmp_path / "rattle.yaml"
    study.write_text(RATTLE, encoding="utf-8")
    with dask_cluster(tmp_path, n_workers=2, nthreads=2) as (address, _, _):
        out = tmp_path / "sched.nc"
        proc = _run_cli([str(study), "-o", str(out), "--scheduler", address, "--chunk-size", "48"])
        assert proc.wait(timeout=600) == 0
    with xr.open_dataset(out) as ds:
        assert_same(ds.load(), rattle_reference)


def _other_gearsweep(tmp: Path) -> Path:
    """A copy of this gearsweep outside its checkout (no commit), with version 0.2.0: the
    modified copy an outside tester put on a worker's PYTHONPATH."""
    other = tmp / "other"
    shutil.copytree(ROOT / "gearsweep", other / "gearsweep",
                    ignore=shutil.ignore_patterns("__pycache__"))
    version = other / "gearsweep" / "_version.py"
    text = version.read_text(encoding="utf-8")
    version.write_text(re.sub(r'__version__ = "[^"]*"', '__version__ = "0.2.0"', text),
                       encoding="utf-8")
    return other


def test_a_worker_with_another_gearsweep_is_refused_before_computing(tmp_path, monkeypatch):
    """A worker importing another gearsweep (another version, no commit) computed the study's
    chunks under the client's history line, exit 0. The run now refuses on connecting, one
    line naming the worker and both gearsweeps, exit 2, nothing computed; a worker that
    escapes that check (one that joins later: the check skipped here) is refused by its
    chunk's return, before it computes or saves the chunk."""
    from gearsweep.errors import ClusterError
    from gearsweep.study import execute
    from gearsweep.study.provenance import identity

    study = tmp_path / "rattle.yaml"
    study.write_text(RATTLE, encoding="utf-8")
    out = tmp_path / "other.nc"
    with dask_cluster(tmp_path, n_workers=2, other=_other_gearsweep(tmp_path)) as (
            address, _, _):
        from distributed import Client

        with Client(address) as client:
            bad = [a for a, v in client.run(identity).items() if "0.2.0" in v]
        assert len(bad) == 1
        proc = _run_cli([str(study), "-o", str(out), "--scheduler", address, "--chunk-size",
                         "48"], stderr=subprocess.PIPE, text=True)
        _, err = proc.communicate(timeout=600)
        assert proc.returncode == 2, err
        assert err.count("\n") == 1, err
        assert err.startswith(f"gearsweep: error: {bad[0]}: this dask worker runs gearsweep 0.2.0,"
                              f" this run {identity()}: "), err
        assert not out.exists() and not chunk_folder(out).exists()  # nothing computed
        monkeypatch.setattr(execute.DaskBackend, "_check_workers", lambda self: None)
        with execute.DaskBackend(scheduler=address) as backend, \
                pytest.raises(ClusterError, match=f"{re.escape(bad[0])}: this dask worker runs"
                              " gearsweep 0.2.0, this run "):
            execute.stream_to_file(plan_of(RATTLE), out, backend=backend, chunk_cases=48)
        saved = {p.name for p in chunk_folder(out).glob("*/chunk_*.npys")}
    assert not out.exists() and len(saved) < 6


def test_a_scheduler_s_chunks_and_estimate_are_for_its_workers(tmp_path):
    """--scheduler cut the default chunks and priced them for this machine, not its cluster
    (6 chunks of the 1e6-case study where --workers 2 cut 8; on 4 workers one sat idle): the
    scheduler is asked for its workers on connecting, and the chunks are cut as for that many
    local workers (``CHUNKS_PER_WORKER`` each) and the estimate stated on them."""
    from gearsweep.study.estimate import CHUNKS_PER_WORKER

    study = ROOT / "studies" / "heavy" / "scale_1e6.yaml"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    here = subprocess.run([sys.executable, "-m", "gearsweep.cli", "run", str(study), "-o",
                           str(tmp_path / "h.nc"), "--estimate"], env=env, cwd=ROOT,
                          capture_output=True, text=True, timeout=300)
    with dask_cluster(tmp_path, n_workers=3) as (address, _, _):
        there = subprocess.run([sys.executable, "-m", "gearsweep.cli", "run", str(study), "-o",
                                str(tmp_path / "s.nc"), "--estimate", "--scheduler", address],
                               env=env, cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert here.returncode == 0 and there.returncode == 0, (here.stderr, there.stderr)
    chunks = [int(re.search(r" in (\d+) chunks: ", p.stdout)[1]) for p in (here, there)]
    assert chunks[1] >= CHUNKS_PER_WORKER * 3 > chunks[0], (here.stdout, there.stdout)
    assert " on 3 workers, 3 cores at " in there.stdout, there.stdout
    assert " workers" not in here.stdout, here.stdout


def test_local_cluster_identical_to_in_process(tmp_path, rattle_reference):
    """The same study through --workers 2 (a LocalCluster started and closed by the CLI)."""
    study = tmp_path / "rattle.yaml"
    study.write_text(RATTLE, encoding="utf-8")
    out = tmp_path / "local.nc"
    proc = _run_cli([str(study), "-o", str(out), "--workers", "2", "--chunk-size", "48"])
    assert proc.wait(timeout=600) == 0
    with xr.open_dataset(out) as ds:
        assert_same(ds.load(), rattle_reference)
        # the workers' time in the kernel, summed over them (issue 29: it was missing)
        assert 0 < ds.attrs["kernel_seconds"] <= 2 * ds.attrs["elapsed_seconds"]


def test_local_workers_save_their_chunks_and_the_file_is_the_in_process_file(
        tmp_path, rattle_reference, monkeypatch):
    """With a local cluster, the workers save their chunks' arrays to the checkpoint store
    themselves (they see its folder); the arrays do not pass through the client, which reads
    the saved files in lane order into the result file (here: this process cannot save a
    chunk, yet the run completes, identical to the in-process run)."""
    from gearsweep.study import execute
    from gearsweep.study.checkpoint import ChunkStore

    plan = plan_of(RATTLE)
    with execute.DaskBackend(workers=2) as backend:  # the workers start with ChunkStore intact

        def refuse(self, *args):
            raise AssertionError("a chunk was saved by the client, not by its worker")

        monkeypatch.setattr(ChunkStore, "save", refuse)
        out = tmp_path / "local.nc"
        written = execute.stream_to_file(plan, out, backend=backend, chunk_cases=48)
    assert written.cases == 288
    with xr.open_dataset(out) as ds:
        assert_same(ds.load(), rattle_reference)
    assert not chunk_folder(out).exists()  # the checkpoints go once the file is complete


def test_workers_of_a_scheduler_save_their_chunks_where_they_see_the_folder(
        tmp_path, rattle_reference, monkeypatch):
    """Workers of an existing cluster (``--scheduler``) that see the run's checkpoint folder (a
    shared file system; here the same machine) save their chunks there themselves; workers
    that do not see it (the run's mark file absent from where they look) send their arrays,
    which the client saves. The file is the in-process result either way."""
    from gearsweep.study import execute
    from gearsweep.study.checkpoint import ChunkStore

    plan = plan_of(RATTLE)
    saved_here = []
    save = ChunkStore.save

    def count(self, a, b, arrays):
        saved_here.append((a, b))
        save(self, a, b, arrays)

    monkeypatch.setattr(ChunkStore, "save", count)  # this process only: the workers are others
    with dask_cluster(tmp_path, n_workers=2, nthreads=1) as (address, _, _):
        with execute.DaskBackend(scheduler=address) as backend:
            shared = tmp_path / "shared.nc"
            execute.stream_to_file(plan, shared, backend=backend, chunk_cases=48)
            assert saved_here == []  # every chunk saved by its worker
            monkeypatch.setattr(execute, "shared_mark", lambda folder: "shared-not-there")
            apart = tmp_path / "apart.nc"
            execute.stream_to_file(plan, apart, backend=backend, chunk_cases=48)
            assert len(saved_here) == 6  # every chunk sent here and saved here
    for out in (shared, apart):
        with xr.open_dataset(out) as ds:
            assert_same(ds.load(), rattle_reference)
        assert not chunk_folder(out).exists()


def test_a_local_cluster_needs_no_fixed_port_and_listens_on_localhost_only():
    """With port 8787 taken (another run's cluster, a dask dashboard) a local cluster starts
    without a warning: its scheduler's HTTP routes listen on a free port of 127.0.0.1. (They
    took 8787 on every interface; where it was taken, the scheduler retried elsewhere with a
    warning and left a socket open: a parallel test failed on it under filterwarnings=error.)"""
    from gearsweep.study.execute import DaskBackend

    taken = socket.socket()
    try:
        try:
            taken.bind(("0.0.0.0", 8787))
            taken.listen()
        except OSError:
            pass  # taken already: the case itself
        with DaskBackend(workers=1) as backend:
            http = backend.cluster.scheduler.http_server
            bound = [s.getsockname() for s in http._sockets.values()]
    finally:
        taken.close()
    assert bound and all(host == "127.0.0.1" and port != 8787 for host, port in bound)


def test_ctrl_c_on_a_local_cluster_stops_cleanly(tmp_path):
    """Ctrl-C in a terminal signals the whole process group, the local cluster's workers too:
    they died with a traceback each and the run could wait for their chunks for good (2 of 4
    tries). The workers now ignore SIGINT; the run stops after the chunks being computed, saves
    each, says so in one line, exit 130, and the same command completes the file."""
    study = tmp_path / "long.yaml"
    study.write_text(LONG.replace("num: 50", "num: 400"), encoding="utf-8")
    out = tmp_path / "long.nc"
    args = [str(study), "-o", str(out), "--workers", "2", "--chunk-size", "20"]
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen([sys.executable, "-m", "gearsweep.cli", "run", *args], env=env,
                            cwd=ROOT, stderr=subprocess.PIPE, text=True, start_new_session=True)
    folder = chunk_folder(out)
    deadline = time.monotonic() + 300
    while not (folder.is_dir() and any(folder.rglob("chunk_*.npys"))):
        assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGINT)  # as a terminal does: the group, workers included
    try:
        _, err = proc.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        raise AssertionError("the run did not stop within 120 s of Ctrl-C") from None
    assert proc.returncode == 130, err
    assert err.strip().splitlines()[-1].startswith("gearsweep: interrupted: "), err
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err
    saved = sum(1 for _ in folder.rglob("chunk_*.npys"))
    # Every chunk being computed at the Ctrl-C is saved, its count said (it said "the chunk
    # being computed" and dropped the other worker's: a hole before a later chunk saved; an
    # outside tester): the saved chunks are the first ones, in lane order, with no hole.
    said = re.search(r"gearsweep: stopping after the (\d+) chunks being computed, which are"
                     r" kept \(Ctrl-C again to stop at once\)", err)
    assert said is not None, err
    assert 2 <= int(said[1]) <= saved, err
    chunks = chunks_to_run(plan_of(study.read_text(encoding="utf-8")), None, 20)
    names = {p.name for p in folder.rglob("chunk_*.npys")}
    assert names == {f"chunk_{a}_{b}.npys" for a, b in chunks[:saved]}, (names, err)
    rc = _run_cli(args).wait(timeout=600)
    assert rc == 0 and out.exists()
    # The result records both runs: the chunks the interrupted one left (those its workers
    # saved after it stopped count as its own) and those the second computed.
    with xr.open_dataset(out) as ds:
        assert len(ds.attrs["history"].splitlines()) == 2
        assert ds.attrs["run_chunks"][0] == saved and ds.attrs["run_chunks"].sum() == len(
            chunks_to_run(plan_of(study.read_text(encoding="utf-8")), None, 20))
        assert ds.attrs["elapsed_seconds"] == round(sum(ds.attrs["run_elapsed_seconds"]), 3)


def _children(pid: int) -> list[int]:
    """The processes ``pid`` started, from any of its threads (dask's start its workers)."""
    found = []
    for task in Path(f"/proc/{pid}/task").iterdir():
        try:
            found += [int(c) for c in (task / "children").read_text().split()]
        except OSError:  # a thread that ended meanwhile
            pass
    return found


@pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="/proc (Linux)")
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_while_the_local_cluster_starts_stops_the_run(tmp_path, sig):
    """Ctrl-C (to the process group, as a terminal sends it) or SIGTERM (to the run alone)
    once the local cluster's first worker process exists, while the cluster starts: SIGINT was
    ignored then, the run went on to its end, exit 0 (an outside tester: 3 of 6 tries at
    1.0 s); SIGTERM ended it without a word (exit 143). Now one line, exit 130 or 143."""
    study = tmp_path / "long.yaml"
    study.write_text(LONG, encoding="utf-8")
    out = tmp_path / "long.nc"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen([sys.executable, "-m", "gearsweep.cli", "run", str(study), "-o",
                             str(out), "--workers", "2", "-q"], env=env, cwd=ROOT,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    deadline = time.monotonic() + 120
    while not _children(proc.pid):
        assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
        time.sleep(0.002)
    if sig == signal.SIGINT:
        os.killpg(proc.pid, sig)
    else:
        proc.send_signal(sig)
    try:
        _, err = proc.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        raise AssertionError("the run did not stop within 120 s of the signal") from None
    how = "interrupted" if sig == signal.SIGINT else "terminated (SIGTERM)"
    assert proc.returncode == 128 + sig, err
    assert err.strip().splitlines()[-1].startswith(f"gearsweep: {how}"), err
    assert len(err.strip().splitlines()) == 1, err
    assert not out.exists()


def test_unreachable_scheduler_is_one_line(tmp_path):
    study = tmp_path / "rattle.yaml"
    study.write_text(RATTLE, encoding="utf-8")
    port = _free_port()  # nothing listens there
    proc = _run_cli([str(study), "-o", str(tmp_path / "o.nc"), "--scheduler",
                     f"tcp://127.0.0.1:{port}"], stderr=subprocess.PIPE, text=True)
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 2
    assert err.count("\n") == 1 and "cannot use the dask cluster" in err, err


def test_a_lost_scheduler_is_one_line_with_the_chunks_saved(tmp_path):
    """SIGKILL the scheduler once a chunk is saved: one line naming the lost scheduler and the
    chunks saved, exit 2 (23-31 lines of distributed's tracebacks came first, and the line
    said only that a chunk failed; an outside tester)."""
    study = tmp_path / "long.yaml"
    study.write_text(LONG, encoding="utf-8")
    out = tmp_path / "long.nc"
    with dask_cluster(tmp_path, n_workers=1) as (address, _, scheduler):
        proc = _run_cli([str(study), "-o", str(out), "--scheduler", address, "--chunk-size",
                         "100"], stderr=subprocess.PIPE, text=True)
        folder = chunk_folder(out)
        deadline = time.monotonic() + 300
        try:
            while not list(folder.glob("*/chunk_*.npys")):
                assert proc.poll() is None, "the run ended before the scheduler could be killed"
                assert time.monotonic() < deadline
                time.sleep(0.01)
            scheduler.send_signal(signal.SIGKILL)
            _, err = proc.communicate(timeout=300)
        finally:
            _stop(proc)
    saved = len(list(folder.glob("*/chunk_*.npys")))
    assert proc.returncode == 2, err
    assert re.fullmatch(
        rf"gearsweep: error: {re.escape(address)}: lost the connection to the dask scheduler"
        rf" \(.*\); {saved} of 20 chunks saved in {re.escape(str(folder.absolute()))}: run the"
        r" same command to continue\n", err), err


@pytest.mark.slow
def test_killed_worker_chunks_are_rerun(tmp_path):
    """SIGKILL one of two workers once the first chunks are saved: the scheduler re-runs its
    chunk on the other worker and the study completes, identical to the in-process result."""
    study = tmp_path / "long.yaml"
    study.write_text(LONG, encoding="utf-8")
    out = tmp_path / "long.nc"
    with dask_cluster(tmp_path, n_workers=2) as (address, workers, _):
        proc = _run_cli([str(study), "-o", str(out), "--scheduler", address, "--chunk-size",
                         "100"])
        folder = chunk_folder(out)
        deadline = time.monotonic() + 300
        try:
            while len(list(folder.glob("*/chunk_*.npys"))) < 2:
                assert proc.poll() is None, "the run ended before a worker could be killed"
                assert time.monotonic() < deadline
                time.sleep(0.01)
            workers[0].send_signal(signal.SIGKILL)
            workers[0].wait(timeout=30)
            assert proc.wait(timeout=600) == 0
        finally:
            _stop(proc)
        saved = len(list(folder.glob("*/chunk_*.npys")))
        assert saved == 0 and out.exists()
    log = (tmp_path / "worker0.log").read_text()
    assert workers[0].returncode == -signal.SIGKILL, log[-2000:]
    # The scheduler saw the worker go (and released its processing chunks to the other one).
    assert "Remove worker" in (tmp_path / "scheduler.log").read_text()
    with xr.open_dataset(out) as ds:
        assert_same(ds.load(), run_plan(plan_of(LONG)))

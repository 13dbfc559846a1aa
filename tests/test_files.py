"""The atomic writer (``gearsweep.files``): chunk checkpoints written past the page cache
(``DirectFile``) hold exactly the bytes NumPy's own writer gives, and every way the direct path
can fail (no O_DIRECT, a refused alignment, a slow device, a full disk, an error mid-write) ends
in a whole file or none."""

from __future__ import annotations

import errno
import io
import itertools
import os

import numpy as np
import numpy.lib.format as fmt
import pytest

from gearsweep import files
from gearsweep.files import DirectFile, atomic_write
from gearsweep.study.checkpoint import ChunkStore


@pytest.fixture(autouse=True)
def fresh_verdicts(monkeypatch):
    """Each test judges devices afresh (the verdicts are per process)."""
    monkeypatch.setattr(DirectFile, "_verdict", {})
    monkeypatch.setattr(DirectFile, "_written", {})


def _arrays() -> dict[str, np.ndarray]:
    """Arrays of every kind a chunk holds, one over two staging blocks, one empty, one in
    Fortran order, one whose size is no multiple of the alignment."""
    rng = np.random.default_rng(7)
    return {
        "stats": rng.random((DirectFile.BLOCK // 8 // 3 + 12_345, 3)),
        "xf": rng.random(1001),
        "status": rng.integers(0, 4, 777).astype(np.int8),
        "beyond_step_limit": rng.random(333) < 0.5,
        "empty": np.empty((0, 4)),
        "fortran": np.asfortranarray(rng.random((5, 3))),
        "signal": rng.random((3, 2 * DirectFile.BLOCK // 8 + 5)).astype(np.float32),
    }


def _numpy_bytes(arrays: dict[str, np.ndarray]) -> bytes:
    """The chunk file as NumPy's ``write_array`` writes it (the format the reader expects)."""
    out = io.BytesIO()
    fmt.write_array(out, np.array(list(arrays), dtype=str), allow_pickle=False)
    for arr in arrays.values():
        fmt.write_array(out, np.ascontiguousarray(arr), allow_pickle=False)
    return out.getvalue()


def _store(tmp_path) -> ChunkStore:
    store = ChunkStore(tmp_path / "out.nc", "key", 10, [(0, 10)])
    store.open()
    return store


def test_a_direct_chunk_file_is_numpy_s_bytes_and_reads_back(tmp_path, monkeypatch):
    if not DirectFile.usable(tmp_path / "x"):
        pytest.skip("no O_DIRECT here (not Linux)")
    opened = []
    real = DirectFile.__init__

    def spy(self, *args, **kwargs):
        real(self, *args, **kwargs)
        opened.append(self)

    monkeypatch.setattr(DirectFile, "__init__", spy)
    arrays = _arrays()
    store = _store(tmp_path)
    try:
        store.save(0, 10, arrays)
    except OSError as exc:  # pragma: no cover - a file system without O_DIRECT (tmpfs)
        pytest.skip(f"O_DIRECT refused here: {exc}")
    if not opened:
        pytest.skip("this file system refuses O_DIRECT (written buffered)")
    path = store.path(0, 10)
    assert path.read_bytes() == _numpy_bytes(arrays)
    back = store.load(0, 10)
    assert list(back) == list(arrays)
    for k, v in arrays.items():
        assert back[k].dtype == v.dtype and np.array_equal(back[k], v), k
    assert opened[0].timed >= 2 * DirectFile.BLOCK  # whole blocks went out directly
    assert not list(tmp_path.rglob("*.partial"))


def test_no_o_direct_is_the_buffered_file(tmp_path, monkeypatch):
    monkeypatch.delattr(os, "O_DIRECT", raising=False)
    arrays = _arrays()
    store = _store(tmp_path)
    store.save(0, 10, arrays)
    assert store.path(0, 10).read_bytes() == _numpy_bytes(arrays)


def test_direct_writes_can_be_switched_off(tmp_path, monkeypatch):
    monkeypatch.setenv("GEARSWEEP_DIRECT_IO", "0")
    monkeypatch.setattr(DirectFile, "__init__", lambda *a, **k: pytest.fail("written directly"))
    arrays = _arrays()
    store = _store(tmp_path)
    store.save(0, 10, arrays)
    assert store.path(0, 10).read_bytes() == _numpy_bytes(arrays)


def _refusing_open(monkeypatch, calls):
    real = os.open

    def fake(path, flags, *args, **kwargs):
        if flags & getattr(os, "O_DIRECT", 0):
            calls.append(path)
            raise OSError(errno.EINVAL, "Invalid argument")
        return real(path, flags, *args, **kwargs)

    monkeypatch.setattr(files.os, "open", fake)


@pytest.mark.skipif(not hasattr(os, "O_DIRECT"), reason="no O_DIRECT (not Linux)")
def test_a_file_system_that_refuses_o_direct_gets_buffered_files_and_is_not_asked_again(
        tmp_path, monkeypatch):
    calls: list = []
    _refusing_open(monkeypatch, calls)
    arrays = _arrays()
    store = _store(tmp_path)
    store.save(0, 10, arrays)
    assert store.path(0, 10).read_bytes() == _numpy_bytes(arrays)
    assert len(calls) == 1
    assert not DirectFile.usable(tmp_path / "x")
    store.save(0, 10, arrays)  # again: buffered at once
    assert len(calls) == 1
    assert store.path(0, 10).read_bytes() == _numpy_bytes(arrays)


@pytest.mark.skipif(not hasattr(os, "O_DIRECT"), reason="no O_DIRECT (not Linux)")
def test_a_write_refused_mid_file_falls_back_to_a_whole_buffered_file(tmp_path, monkeypatch):
    def refuse(self, length):
        raise OSError(errno.EINVAL, "Invalid argument")  # an alignment the device will not take

    monkeypatch.setattr(DirectFile, "_flush", refuse)
    arrays = _arrays()
    store = _store(tmp_path)
    store.save(0, 10, arrays)
    assert store.path(0, 10).read_bytes() == _numpy_bytes(arrays)
    assert not DirectFile.usable(tmp_path / "x")
    assert not list(tmp_path.rglob("*.partial"))


@pytest.mark.skipif(not hasattr(os, "O_DIRECT"), reason="no O_DIRECT (not Linux)")
def test_a_slow_device_is_given_up_after_judging(tmp_path, monkeypatch):
    if not DirectFile.usable(tmp_path / "x"):
        pytest.skip("no O_DIRECT here")
    clock = itertools.count(0.0, 1.0)  # every whole block "takes" 1 s: 8 MB/s
    monkeypatch.setattr(files.time, "perf_counter", lambda: float(next(clock)))
    arrays = {"a": np.ones(DirectFile.JUDGE_BYTES // 8 + 1)}
    store = _store(tmp_path)
    store.save(0, 10, arrays)  # 4 whole blocks, judged: too slow
    assert DirectFile._verdict == {os.stat(tmp_path).st_dev: False}
    assert not DirectFile.usable(tmp_path / "x")
    assert store.path(0, 10).read_bytes() == _numpy_bytes(arrays)


@pytest.mark.skipif(not hasattr(os, "O_DIRECT"), reason="no O_DIRECT (not Linux)")
def test_a_fast_device_stays_direct(tmp_path, monkeypatch):
    if not DirectFile.usable(tmp_path / "x"):
        pytest.skip("no O_DIRECT here")
    clock = itertools.count(0.0, 1e-3)  # 1 ms per whole block: 8 GB/s
    monkeypatch.setattr(files.time, "perf_counter", lambda: float(next(clock)))
    store = _store(tmp_path)
    store.save(0, 10, {"a": np.ones(DirectFile.JUDGE_BYTES // 8 + 1)})
    assert DirectFile._verdict == {os.stat(tmp_path).st_dev: True}


def test_an_error_while_writing_leaves_no_file(tmp_path, monkeypatch):
    path = tmp_path / "f.bin"

    def write(fh):
        fh.write(np.ones(DirectFile.BLOCK // 4))  # two blocks out, then the disk is full
        raise OSError(errno.ENOSPC, "No space left on device")

    for direct in (True, False):
        with pytest.raises(OSError, match="No space"):
            atomic_write(path, write, durable=False, direct=direct)
        assert list(tmp_path.iterdir()) == []


def test_a_durable_direct_file_is_fsynced(tmp_path, monkeypatch):
    synced = []
    real = os.fsync
    monkeypatch.setattr(files.os, "fsync", lambda fd: (synced.append(fd), real(fd)))
    path = tmp_path / "f.bin"
    data = np.arange(1000, dtype=np.int64)
    atomic_write(path, lambda fh: fh.write(data), durable=True, direct=True)
    assert path.read_bytes() == data.tobytes()
    assert len(synced) == 1


def test_a_full_disk_names_the_file_it_could_not_write(tmp_path, monkeypatch):
    """``os.write``'s ENOSPC names no file: a checkpoint that filled the disk was reported as
    ``OUT.nc: cannot write: No space left on device``; it now names the checkpoint."""
    def full(self, length):
        raise OSError(errno.ENOSPC, "No space left on device")  # as os.write raises it

    monkeypatch.setattr(DirectFile, "_flush", full)
    monkeypatch.setattr(DirectFile, "usable", classmethod(lambda cls, path: True))
    store = _store(tmp_path)
    with pytest.raises(OSError) as e:
        store.save(0, 10, _arrays())
    assert e.value.errno == errno.ENOSPC and e.value.filename == str(store.path(0, 10))


def test_an_output_in_a_loop_of_symbolic_links_is_refused(tmp_path):
    """A loop leads to no file: the rename over it replaced the link with a file, silently
    (a link that leads somewhere is written to its target, workspace.output_path)."""
    from gearsweep.files import replace_problem
    from gearsweep.study.workspace import output_path

    (tmp_path / "a.nc").symlink_to(tmp_path / "b.nc")
    (tmp_path / "b.nc").symlink_to(tmp_path / "a.nc")
    (tmp_path / "self.nc").symlink_to(tmp_path / "self.nc")
    (tmp_path / "dangling.nc").symlink_to(tmp_path / "new.nc")
    for name in ("a.nc", "self.nc"):
        assert "loop of symbolic links" in replace_problem(output_path(tmp_path / name))
    assert replace_problem(output_path(tmp_path / "dangling.nc")) is None


@pytest.mark.skipif(os.name != "posix", reason="POSIX permissions")
@pytest.mark.parametrize("umask", [0o022, 0o002, 0o027])
@pytest.mark.parametrize("direct", [True, False])
def test_checkpoint_files_have_the_mode_of_ordinary_files(tmp_path, monkeypatch, umask, direct):
    """A chunk checkpoint and the folder's manifest get the mode the umask gives an ordinary
    new file, as ``runs.jsonl`` beside them (made by ``open``): they were ``0o600`` (the
    temporary file's), and a colleague sharing a group's folder could not resume the run (an
    outside tester's finding)."""
    monkeypatch.setenv("GEARSWEEP_DIRECT_IO", "1" if direct else "0")
    old = os.umask(umask)
    try:
        store = _store(tmp_path)
        store.save(0, 10, {"status": np.zeros(10, np.int8)})
        ordinary = tmp_path / "ordinary"
        ordinary.write_bytes(b"")
    finally:
        os.umask(old)
    assert ordinary.stat().st_mode & 0o777 == 0o666 & ~umask
    for f in (store.path(0, 10), store.folder / "manifest.json"):
        assert f.stat().st_mode & 0o777 == 0o666 & ~umask, f

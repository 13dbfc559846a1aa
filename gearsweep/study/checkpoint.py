"""Checkpoints of a running study: every finished chunk on disk, so a re-run resumes.

Next to the output ``OUT.nc`` a run keeps ``OUT.nc.chunks/<study_key>/`` (``Plan.study_key``: the
sha256 of the study as validated, so a comment or spacing edited in its file keeps the chunks):

* ``manifest.json``: the study's key, the gearsweep version, the number of lanes and the chunk
  layout (lane ranges). A re-run keeps the saved layout (``saved_layout``), whatever chunk size
  it would choose itself; a folder whose manifest does not match the run (another version) is
  emptied before use; a changed study has another key, hence another folder, and never reads
  stale chunks.
* ``chunk_<lane0>_<lane1>.npys``: the arrays ``run_chunk`` returned for lanes ``[lane0, lane1)``:
  one ``.npy`` record (NumPy's format, ``numpy.lib.format``) of their names, then one per array in
  that order. Written to a temporary file, then renamed (``os.replace``), so a chunk file is
  either complete or absent, whatever kills the process (Ctrl-C, SIGKILL, out of memory): the
  bytes are on the device, or in the system's page cache, the moment the write returns.
  Written past the page cache where the file system allows it and is fast (Linux ``O_DIRECT``,
  ``files.DirectFile``): copying a 1e7-case run's 740 MB of chunks into fresh page-cache pages
  took about 0.5 s of CPU from the kernel beside it on 2 cores (whole run / kernel 1.25 -> 1.18,
  docs/scale-log.md); elsewhere through the page cache. Not fsync'ed: fsync'ing every chunk cost
  a 1e7-case run 0.58 s of its 15 s (medians of 4 alternating runs, docs/scale-log.md), and the
  directory entries and sizes (and, where the page cache is used, the bytes) reach the disk on
  the system's schedule (Linux: within seconds to ``vm.dirty_expire_centisecs``, 30 s). So a
  machine that loses power can lose the chunks of the last half minute or so; a chunk file left
  empty or cut short is not read (``records`` checks every header and size) and its chunk is
  computed again. Plain records, not ``np.savez``: the zip container's CRC pass and copy cost
  2.5x the write itself, and the last chunk's write is not hidden behind a computing chunk.

The result file itself is written as the chunks finish (``resultfile.ResultFile``, in
``OUT.nc.chunks/<study_key>/writing.nc`` until it is complete), by the same background thread
that saves the chunk files. An HDF5 file cut off mid-write is not trusted: a re-run of the same
study to the same output checks the chunk files that are there (``ChunkStore.records``: shapes
and dtypes from the headers, without reading the data), computes only the missing chunks, writes
the saved ones into a new result file while those compute, and finally removes the study
folders gearsweep made in ``OUT.nc.chunks``, and the folder if nothing else is in it
(``remove_checkpoints``; a run refuses to start beside what it did not make:
``checkpoint_problem``).

Every run also appends to ``runs.jsonl`` in that folder (``RunLog``) one JSON line per chunk it
saved: the chunk and the run's chunk phase and kernel seconds so far, the first line of a run
also its line of ``history`` (its start time and command). A resumed run reads it
(``ChunkStore.earlier_runs``) for what the earlier runs did, so that its file's ``history``
has a line per run that contributed and its timings are the totals over them
(``resultfile.run_attrs``): a killed run leaves its lines up to its last saved chunk, whatever
kills it. One ``write`` of under 100 bytes per chunk (23 us), not fsync'ed (as the chunk files).

Setting the environment variable ``GEARSWEEP_CHUNK_LOG`` to a file path appends one line
``<lane0> <lane1>`` to it per chunk computed and saved (read when a chunk is saved, not at import):
tests use it to check that a resumed run computes no chunk twice.
"""

from __future__ import annotations

import contextlib
import copy
import io
import json
import math
import os
import re
import secrets
import shutil
from collections.abc import Callable
from pathlib import Path

import numpy as np
import numpy.lib.format as fmt

from gearsweep._version import __version__
from gearsweep.files import PARTIAL, atomic_write
from gearsweep.study.resultfile import EarlierRun

MANIFEST = "manifest.json"
RUNS = "runs.jsonl"
"""The record of the runs that saved chunks in a study's folder (``RunLog``)."""
SUFFIX = ".npys"
"""Chunk files: ``chunk_<lane0>_<lane1>.npys``."""
WRITING = "writing.nc"
"""The result file while a run writes it, in its study's folder (renamed to ``OUT.nc`` once
complete: ``execute.stream_to_file``)."""
SHARED_MARK = "shared-"
"""Prefix of the file a run puts into its study's folder for dask workers to look for
(``shared_mark``, ``execute.DaskBackend.run``): a worker that finds it saves its chunks there
itself."""


def shared_mark(folder: Path) -> str:
    """Put a file of a random name (``SHARED_MARK`` and hex digits) into ``folder``; return its
    name."""
    name = f"{SHARED_MARK}{secrets.token_hex(8)}"
    (folder / name).write_text("gearsweep: workers that see this file save their chunks"
                               " here\n", encoding="utf-8")
    return name
FORMAT = 3
"""Version of the folder layout (bump when chunk files change meaning; 3: folders named by the
study's key, no longer by the sha256 of its text)."""


def chunk_folder(output: str | Path) -> Path:
    """The folder that holds the checkpoints of every study written to ``output``."""
    output = Path(output)
    return output.with_name(output.name + ".chunks")


def saved_layout(output: str | Path, study_key: str, n_lanes: int
                 ) -> list[tuple[int, int]] | None:
    """The chunk layout of an interrupted run of this study (same key, gearsweep version and
    number of lanes) that left chunk files next to ``output``; else ``None``.

    A resumed run keeps this layout whatever chunk size it would choose now (another
    ``--chunk-size``, another ``--workers`` count), so that no saved chunk is computed again.
    (Until 26 Nov 2026 another layout emptied the folder; since the default chunks depend on
    ``--workers``, that would have thrown away finished work. Another device is another study:
    ``solver.device`` is part of its key.)
    """
    folder = chunk_folder(output) / study_key
    try:
        old = json.loads((folder / MANIFEST).read_text(encoding="utf-8"))
        if (old["format"], old["study_key"], old["gearsweep_version"], old["n_lanes"]) != (
                FORMAT, study_key, __version__, n_lanes):
            return None
        chunks = [(int(a), int(b)) for a, b in old["chunks"]]
    except Exception:  # noqa: BLE001 - any manifest not written by this version: no layout
        return None  # (unreadable, not JSON, not a mapping, Infinity, nested too deep, ...)
    ends = [0] + [b for _, b in chunks]
    if not chunks or ends[-1] != n_lanes or any(
            not 0 <= a == e < b for (a, b), e in zip(chunks, ends[:-1], strict=True)):
        return None  # not increasing ranges that cover the lanes: not a layout to trust
    if not any(folder.glob(f"chunk_*{SUFFIX}")):
        return None
    return chunks


def _write_names(fh, names) -> None:
    """A chunk file's first record: the names of its arrays."""
    fmt.write_array(fh, np.array(list(names), dtype=str), allow_pickle=False)


def _write_header(fh, shape: tuple[int, ...], dtype: np.dtype) -> None:
    """NumPy's header of a C-ordered array (``fmt.write_array``'s, without its copies)."""
    header = {"descr": fmt.dtype_to_descr(np.dtype(dtype)), "fortran_order": False,
              "shape": tuple(shape)}
    try:
        fmt.write_array_header_1_0(fh, header)
    except ValueError:  # a header over 64 KiB: NumPy's own choice, version 2.0
        fmt.write_array_header_2_0(fh, header)


def header_bytes(layout: dict[str, tuple[tuple[int, ...], np.dtype]]) -> int:
    """Bytes of a chunk file beyond its arrays' data, for arrays of ``layout`` (name: (shape,
    dtype), ``resultfile.result_layout``): the names' record and each array's header, as
    ``ChunkStore.save`` writes them."""
    fh = io.BytesIO()
    _write_names(fh, layout)
    for shape, dtype in layout.values():
        _write_header(fh, shape, dtype)
    return fh.tell()


class ChunkStore:
    """The chunk files of one study (by its key) written to one output.

    Parameters
    ----------
    output : path
        The result file the study writes (the checkpoints live in ``<output>.chunks``).
    study_key : str
        ``Plan.study_key`` (sha256 of the study as validated); the folder's name.
    n_lanes : int
        Lanes of the study (see ``gearsweep.study.plan``).
    chunks : list of (int, int)
        Lane ranges ``[lane0, lane1)`` of the chunks, in order.
    """

    def __init__(self, output: str | Path, study_key: str, n_lanes: int,
                 chunks: list[tuple[int, int]]) -> None:
        self.root = chunk_folder(output)
        self.folder = self.root / study_key
        self.manifest = {
            "format": FORMAT,
            "study_key": study_key,
            "gearsweep_version": __version__,
            "n_lanes": int(n_lanes),
            "chunks": [[int(a), int(b)] for a, b in chunks],
        }
        self.chunks = [(int(a), int(b)) for a, b in chunks]

    def absolute(self) -> ChunkStore:
        """The same store with absolute paths (for a worker process whose working directory is
        another)."""
        out = copy.copy(self)
        out.root, out.folder = self.root.absolute(), self.folder.absolute()
        return out

    def path(self, lane0: int, lane1: int) -> Path:
        """File of the chunk of lanes ``[lane0, lane1)``."""
        return self.folder / f"chunk_{lane0}_{lane1}{SUFFIX}"

    def open(self) -> list[tuple[int, int]]:
        """Create or check the folder; return the chunks whose files are present.

        A folder left by a run with another chunk layout (the caller did not keep it: see
        ``saved_layout``) or gearsweep version is emptied first.
        """
        self.folder.mkdir(parents=True, exist_ok=True)
        mpath = self.folder / MANIFEST
        try:
            old = json.loads(mpath.read_text(encoding="utf-8"))
        except Exception:  # noqa: BLE001 - unreadable or not this version's: emptied below
            old = None
        if old != self.manifest:
            for f in self.folder.iterdir():
                if f.is_file():
                    f.unlink()
            atomic_write(mpath, lambda fh: fh.write(
                json.dumps(self.manifest, indent=1).encode("utf-8")))
            return []
        return [c for c in self.chunks if self.path(*c).is_file()]

    def save(self, lane0: int, lane1: int, arrays: dict[str, np.ndarray], *,
             direct: bool = True) -> None:
        """Write one chunk's arrays atomically (and log it when ``GEARSWEEP_CHUNK_LOG`` is set);
        ``direct``: past the page cache where that is cheaper (``files.DirectFile``: for a file
        read again only by a resumed run; not for one read back at once)."""
        def write(fh) -> None:  # the bytes of ``fmt.write_array`` per array, without its copies
            _write_names(fh, arrays)
            for arr in arrays.values():
                arr = np.ascontiguousarray(arr)
                _write_header(fh, arr.shape, arr.dtype)
                fh.write(arr)

        atomic_write(self.path(lane0, lane1), write, durable=False, direct=direct)  # no fsync:
        # module docstring
        log = os.environ.get("GEARSWEEP_CHUNK_LOG")
        if log:
            with open(log, "a", encoding="utf-8") as fh:
                fh.write(f"{lane0} {lane1}\n")

    def load(self, lane0: int, lane1: int) -> dict[str, np.ndarray] | None:
        """The arrays of one chunk, or ``None`` if its file is missing or unreadable."""
        try:
            with open(self.path(lane0, lane1), "rb") as fh:
                names = fmt.read_array(fh, allow_pickle=False)
                if names.ndim != 1 or names.dtype.kind != "U":
                    return None
                arrays = {str(k): fmt.read_array(fh, allow_pickle=False) for k in names}
                return arrays if not fh.read(1) else None  # nothing may follow the last record
        except (OSError, ValueError, EOFError):
            return None

    def records(self, lane0: int, lane1: int) -> dict[str, Record]:
        """The arrays of one chunk as ``Record``s: shape and dtype from the file's headers, the
        data read only when indexed (for writing the final file block by block).

        Raises ``OSError``/``ValueError`` if the file is missing, malformed or truncated.
        """
        out: dict[str, Record] = {}
        path = self.path(lane0, lane1)
        with open(path, "rb") as fh:
            size = os.fstat(fh.fileno()).st_size
            names = fmt.read_array(fh, allow_pickle=False)
            for name in names:
                version = fmt.read_magic(fh)
                read_header = fmt.read_array_header_1_0 if version == (1, 0) \
                    else fmt.read_array_header_2_0
                shape, fortran, dtype = read_header(fh)
                rec = Record(path, fh.tell(), shape, dtype, fortran)
                if rec.offset + rec.nbytes > size:
                    raise ValueError(f"{path}: truncated record {name!r}")
                out[str(name)] = rec
                fh.seek(rec.offset + rec.nbytes)
        return out

    def earlier_runs(self, done: list[tuple[int, int]]) -> list[EarlierRun]:
        """The earlier runs whose saved chunks ``done`` a resumed run uses, oldest first, from
        their records (``RUNS``): each run's history line, how many of ``done`` it saved (the
        last run to record a chunk, where one was computed again) and its chunk phase and
        kernel seconds up to its last saved chunk. A chunk saved without a record (a dask
        worker that finished it after its client had stopped; a kill between a chunk's file
        and its line) counts with the last run that saved any of ``done``; where no run did,
        with an ``EarlierRun`` whose line and timings are unknown. Lines that cannot be read
        (cut short by a kill) are skipped."""
        try:
            text = (self.folder / RUNS).read_text(encoding="utf-8", errors="replace")
        except OSError:
            text = ""
        runs: dict[str, dict] = {}  # by run, in the order they started
        owner: dict[tuple[int, int], str] = {}
        for line in text.splitlines():
            try:
                rec = json.loads(line)
                run = str(rec["run"])
                history = rec.get("history")
                chunk = rec.get("chunk")
                if chunk is not None:
                    chunk = (int(chunk[0]), int(chunk[1]))
                    elapsed = float(rec["elapsed"])
                    kernel = None if rec.get("kernel") is None else float(rec["kernel"])
            except Exception:  # noqa: BLE001 - a line cut short or not ours: not a record
                continue
            entry = runs.setdefault(run, {"history": None, "elapsed": math.nan,
                                          "kernel": None})
            if isinstance(history, str):
                entry["history"] = history
            if chunk is not None:
                owner[chunk] = run
                entry["elapsed"], entry["kernel"] = elapsed, kernel
        counts = dict.fromkeys(runs, 0)
        unowned = 0
        for c in done:
            if owner.get(c) in counts:
                counts[owner[c]] += 1
            else:
                unowned += 1
        used = [r for r in runs if counts[r]]
        if unowned and used:
            counts[used[-1]] += unowned
        out = [EarlierRun(runs[r]["history"], counts[r], runs[r]["elapsed"], runs[r]["kernel"])
               for r in used]
        if unowned and not used:
            out.append(EarlierRun(None, unowned, math.nan, None))
        return out

    def discard(self, lane0: int, lane1: int) -> None:
        """Remove one chunk file (an unreadable one, so that it is computed again)."""
        self.path(lane0, lane1).unlink(missing_ok=True)


class RunLog:
    """This run's record in a study's checkpoint folder (``RUNS``): one JSON line per chunk it
    saved, appended in one ``write`` (by the thread that saves the chunks), the first also
    naming the run's ``history`` line (``history()``, called then: its versions cost 10 ms the
    first time in a process, not to be spent before the first kernel call). The file is opened
    at the first chunk: a run that saves none leaves no record."""

    def __init__(self, folder: Path, history: Callable[[], str]) -> None:
        self.path = Path(folder) / RUNS
        self.run = secrets.token_hex(8)
        self.history = history
        self._fd: int | None = None

    def chunk(self, lane0: int, lane1: int, elapsed: float, kernel: float | None) -> None:
        """Chunk ``[lane0, lane1)`` is saved, ``elapsed`` seconds into the run's chunk phase,
        ``kernel`` of them in the kernel."""
        line = json.dumps({"run": self.run, "chunk": [int(lane0), int(lane1)],
                           "elapsed": round(elapsed, 6),
                           "kernel": None if kernel is None else round(kernel, 6)}) + "\n"
        if self._fd is None:
            try:  # a last line cut short by a kill: this run's lines start on a line of their own
                with open(self.path, "rb") as fh:
                    fh.seek(-1, os.SEEK_END)
                    cut = fh.read(1) != b"\n"
            except OSError:  # no file yet, or an empty one
                cut = False
            self._fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o666)
            head = json.dumps({"run": self.run, "history": self.history()}) + "\n"
            line = ("\n" if cut else "") + head + line
        os.write(self._fd, line.encode("utf-8"))

    def close(self) -> None:
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None


class Record:
    """One array of a chunk file, read from disk when indexed (an array-like for
    ``dask.array.from_array``): reading a block and dropping it frees its memory, where a memory
    map would keep every page it touched resident until unmapped."""

    def __init__(self, path: Path, offset: int, shape: tuple[int, ...], dtype: np.dtype,
                 fortran: bool) -> None:
        self.path, self.offset, self.shape, self.dtype = path, offset, tuple(shape), dtype
        self.fortran = fortran
        self.ndim = len(self.shape)
        self.nbytes = int(np.prod(self.shape, dtype=np.int64)) * dtype.itemsize

    def __array__(self, dtype=None, copy=None) -> np.ndarray:
        count = self.nbytes // self.dtype.itemsize
        flat = np.fromfile(self.path, dtype=self.dtype, count=count, offset=self.offset)
        if flat.size != count:
            raise ValueError(f"{self.path}: truncated record")
        arr = flat.reshape(self.shape, order="F" if self.fortran else "C")
        return arr if dtype is None else arr.astype(dtype)

    def __getitem__(self, key) -> np.ndarray:
        return np.asarray(self)[key]


_OURS = re.compile(rf"{re.escape(MANIFEST)}|{re.escape(RUNS)}|{re.escape(WRITING)}|chunk_\d+_\d+"
                   rf"{re.escape(SUFFIX)}|{re.escape(SHARED_MARK)}[0-9a-f]+|{PARTIAL.pattern}")
"""The files gearsweep makes in a study's checkpoint folder: its manifest, its runs' record, the
result file being written, the chunk files, the workers' mark (``shared_mark``) and the
temporary files of ``files.atomic_write`` (``files.PARTIAL``)."""

_KEY = re.compile(r"[0-9a-f]{64}")
"""A study's key (``Plan.study_key``), the name of its folder."""


def _ours(entry: Path) -> bool:
    """Whether ``entry`` of a checkpoint root is a study's folder as gearsweep makes it: a
    folder (not a link) of gearsweep's files only (``_OURS``), with its manifest, or named by a
    study's key (a run killed before its manifest, or while writing it: the folder empty, or
    with the manifest's temporary file alone; that one was taken for the user's, the next run
    refused beside it and no removal cleared it, a reviewer)."""
    try:
        if entry.is_symlink() or not entry.is_dir():
            return False
        inside = list(entry.iterdir())
    except OSError:
        return False
    if any(f.is_symlink() or not f.is_file() or not _OURS.fullmatch(f.name) for f in inside):
        return False
    return (entry / MANIFEST).is_file() or _KEY.fullmatch(entry.name) is not None


def foreign_entries(output: str | Path) -> list[Path]:
    """What ``OUT.nc.chunks`` holds that gearsweep did not make (``_ours``), sorted: a run
    refuses to start beside it (``checkpoint_problem``) and never removes it. (A folder of the
    user's, notes.txt and sub/data.csv, was deleted whole at the end of a run; an outside
    tester.)"""
    root = chunk_folder(output)
    try:
        return sorted(e for e in root.iterdir() if not _ours(e)) if root.is_dir() else []
    except OSError:
        return []


def checkpoint_problem(output: str | Path) -> str | None:
    """Why a run cannot keep its checkpoints beside ``output`` (one line, after ``output: ``),
    or ``None``: a file in the way of ``OUT.nc.chunks`` (it said only "cannot write the result
    here (Not a directory)"), or that folder holding what gearsweep did not make."""
    root = chunk_folder(output)
    if root.exists() and not root.is_dir():
        return (f"{root} is a file, where the run keeps its checkpoint folder: move or remove"
                " it, or choose another output")
    foreign = foreign_entries(output)
    if foreign:
        more = f" and {len(foreign) - 1} more" if len(foreign) > 1 else ""
        return (f"{root} holds {foreign[0].name!r}{more}, not made by gearsweep: the run keeps"
                " its checkpoints in that folder and removes it at its end; move what is yours"
                " elsewhere, or choose another output")
    return None


def remove_checkpoints(output: str | Path) -> None:
    """Remove the checkpoints of ``output`` (its study's and stale ones of other studies: every
    folder gearsweep made there, ``_ours``), and ``OUT.nc.chunks`` itself if nothing else is in
    it; what gearsweep did not make is left."""
    root = chunk_folder(output)
    try:
        entries = list(root.iterdir()) if root.is_dir() and not root.is_symlink() else []
    except OSError:
        return
    for entry in entries:
        if _ours(entry):
            shutil.rmtree(entry, ignore_errors=True)
    with contextlib.suppress(OSError):  # (not empty: what is not ours stays)
        root.rmdir()

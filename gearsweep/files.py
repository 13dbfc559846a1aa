"""Files written whole or not at all: the one atomic writer of the package (checkpoints, and the
start-up caches kept beside the Numba cache); and a path as its user means it (``user_path``)."""

from __future__ import annotations

import errno
import mmap
import os
import re
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import IO

from gearsweep.errors import ResultError


def user_path(path: str | os.PathLike[str]) -> str:
    """``path`` with a leading ``~`` made the home folder, as xarray, pandas and the shell do: for
    every path a user gives (a study file, ``-o``, ``inspect``'s result, a study's excitation
    file; the API's ``run``, ``open_result``). ``gearsweep run s.yaml --output=~/r.nc`` (no shell
    expands ``~`` after ``=``) and ``run(output="~/r.nc")`` wrote the folder ``./~``. A ``~user``
    of no such user is left as it is, as they leave it (``Path.expanduser`` raised RuntimeError,
    a traceback where a missing file is one line). A string, so that a trailing ``/`` (a folder
    meant, which ``-o`` refuses) is kept."""
    return os.path.expanduser(path)


STUDY_SUFFIXES = (".yaml", ".yml")
"""The endings of a study file's name: a file so named is read as a study (``gearsweep.run``,
``open_result``, ``inspect``), never as a result."""

RESULT_NAME = ("a result file name such as out.nc (a .yaml or .yml name is read as a study, not a"
               " result)")
"""What a run's output may be named, said where a study's name is refused: a run wrote its
netCDF result under it, which ``open_result``, ``inspect`` and ``result_model`` then refused as
a study (an outside tester)."""


def study_named(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` has a study file's name (``STUDY_SUFFIXES``, in any case)."""
    return Path(path).suffix.lower() in STUDY_SUFFIXES


def cache_folder(module_file: str | Path) -> Path:
    """Where a module keeps its small on-disk caches (the unit factors, the step-limit tables):
    beside Numba's cache. In ``NUMBA_CACHE_DIR`` where that is set (a read-only installation
    points it at a writable folder; the caches were written beside the package whatever it
    said, and there refused), else, or where that folder cannot be made and written (Numba then
    caches in the package's ``__pycache__``, silently), the module's own ``__pycache__``."""
    where = os.environ.get("NUMBA_CACHE_DIR")
    if where:
        folder = Path(where) / "gearsweep"
        try:
            folder.mkdir(parents=True, exist_ok=True)
            if os.access(folder, os.W_OK):
                return folder
        except OSError:  # (the caches were kept nowhere: pint's registry built in every run)
            pass
    return Path(module_file).parent / "__pycache__"


def ordinary_mode() -> int:
    """The permissions of an ordinary new file: ``0o666`` less the process's umask. The files
    written through a temporary one (``tempfile.mkstemp``: ``0o600``, private) get it before
    they are renamed into place: chunk checkpoints were ``0o600`` beside a ``runs.jsonl`` of
    ``0o644``, and a colleague sharing a group's folder could not resume the run (an outside
    tester's finding). The umask is read, on Linux, not set: ``os.umask``'s set and restore
    would give a file made meanwhile by another thread (the writer's, the saver's) the mode set
    in between; elsewhere that mode is ``0o077``'s, private, never wider."""
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return 0o666 & ~int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    umask = os.umask(0o077)
    os.umask(umask)
    return 0o666 & ~umask


PARTIAL = re.compile(r"\..+\.[a-z0-9_]+\.partial")
"""The name of a temporary file of ``temp_beside`` (``.NAME.XXXXXXXX.partial``, the random part
``tempfile.mkstemp``'s): what a process killed while writing a file whole leaves next to it."""


def temp_beside(path: Path) -> tuple[int, str]:
    """A new temporary file next to ``path`` (``PARTIAL``), to be written and renamed to
    ``path``: its open descriptor and its path (``tempfile.mkstemp``)."""
    return tempfile.mkstemp(prefix=f".{path.name}.", suffix=".partial", dir=path.parent)


def remove_temps_beside(path: str | Path) -> list[Path]:
    """Remove the temporary files of ``temp_beside(path)`` that a process killed while writing
    ``path`` left next to it (``.NAME.XXXXXXXX.partial``, exactly: the 8 characters of
    ``tempfile``'s names; a user's file of any other name is never touched), and return them.
    For a caller that holds ``path``'s run lock (``workspace.OutputLock``): no other run writes
    ``path`` then. Each interrupted write of a mesh or analysis result left one more of them
    (an outside tester's SIGKILL then rerun)."""
    path = Path(path)
    name = re.compile(re.escape(f".{path.name}.") + r"[a-z0-9_]{8}" + re.escape(".partial"))
    removed = []
    try:
        entries = list(os.scandir(path.parent))
    except OSError:  # no folder yet, or not ours to read
        return removed
    for entry in entries:
        try:
            if name.fullmatch(entry.name) and entry.is_file(follow_symlinks=False):
                os.unlink(entry.path)
                removed.append(Path(entry.path))
        except OSError:  # gone meanwhile, or not ours to remove: left as it is
            continue
    return removed


def atomic_write(path: Path, write: Callable[[IO[bytes]], object], *, durable: bool = True,
                 direct: bool = False) -> None:
    """Call ``write(file_object)`` on a temporary file next to ``path``, then rename it to
    ``path``: a reader, or a run killed meanwhile, sees the old file or the new one, never a part
    of it (once the process is gone: its bytes are in the system's page cache, or on the disk).
    ``durable``: fsync before the rename, so that the new file also survives a power loss (the
    manifest of a checkpoint folder); files that can be computed again (caches, chunk
    checkpoints) skip it. ``direct``: write past the page cache where the file system allows it
    (``DirectFile``: large files written once and read rarely, the chunk checkpoints; ``write``
    may then only call ``file_object.write``). On any error the temporary file is removed and
    the error raised (an ``OSError`` that names no file, as ``os.write``'s, names ``path``).
    The file gets the permissions of an ordinary new one (``ordinary_mode``)."""
    fd, tmp = temp_beside(path)
    try:
        if direct and DirectFile.usable(tmp):
            os.close(fd)
            try:
                with DirectFile(tmp, durable=durable) as fh:
                    write(fh)
                fd = None
            except OSError as exc:  # the file system refuses O_DIRECT, or its alignment
                if exc.errno != errno.EINVAL:
                    raise
                DirectFile.refuse(tmp)
                fd = os.open(tmp, os.O_WRONLY | os.O_TRUNC)
        if fd is not None:
            with os.fdopen(fd, "wb") as fh:
                write(fh)
                if durable:
                    fh.flush()
                    os.fsync(fh.fileno())
        os.chmod(tmp, ordinary_mode())
        os.replace(tmp, path)
    except BaseException as exc:
        Path(tmp).unlink(missing_ok=True)
        if isinstance(exc, OSError) and exc.filename is None:
            exc.filename = str(path)  # a full disk: "cannot write: No space left on device"
        raise


class DirectFile:
    """A file written past the system's page cache (Linux ``O_DIRECT``): the bytes go from an
    aligned staging buffer (``BLOCK`` bytes, one per thread, reused) to the device by DMA, so
    the writing thread spends almost no CPU on them; a buffered write copies every byte into
    fresh page-cache pages, which on this project's virtual machines cost about 1 s of CPU per
    GB (``dd``: 1.0 s of system time for 755 MB buffered, 0.04 s with ``oflag=direct``), and
    a 1e7-case run's 740 MB of chunk checkpoints took that CPU from the kernel beside it
    (docs/scale-log.md). The last block is padded to ``ALIGN`` and the file cut to its length.

    Where it cannot help, files are written the ordinary way (``usable``): no ``O_DIRECT``
    (macOS, Windows), a file system that refuses it (``EINVAL``: tmpfs before Linux 6.6, some
    FUSE file systems), or one where direct writes are
    slower than ``MIN_RATE`` (a network file system, a spinning disk: a direct write waits for
    the device, where a buffered one returns once copied), judged from the first ``JUDGE_BYTES``
    written there in whole blocks; the verdict holds per device for the life of the process.
    """

    ALIGN = 4096
    """Alignment of the buffer, the file offsets and the lengths written (a multiple of every
    logical block size in use)."""
    BLOCK = 8 << 20
    """Bytes staged per write."""
    MIN_RATE = 1.0e9
    """Bytes per second below which direct writes are given up. At least this fast, a direct
    write holds its thread no longer than a buffered one's copy would (about 1 s of CPU per GB
    on these machines), and keeps well ahead of what a run produces (chunk checkpoints of a
    1e7-case run: 0.09 GB/s on 2 cores, 0.25 GB/s on 16). This machine's disk took 8 MB
    blocks at 2.3-2.5 GB/s."""
    JUDGE_BYTES = 32 << 20
    """Bytes written directly to a device before its rate is judged."""

    _verdict: dict[int, bool] = {}
    """Per device (``st_dev``): direct writes refused or too slow (``False``) or judged fast
    (``True``); absent: not yet judged."""
    _written: dict[int, tuple[int, float]] = {}
    """Per device not yet judged: bytes written directly in whole blocks and the seconds they
    took."""
    _local = threading.local()

    @classmethod
    def usable(cls, path: str | Path) -> bool:
        """Whether a file at ``path`` is written directly (see the class; never with the
        environment variable ``GEARSWEEP_DIRECT_IO=0``, read at each call: a file system that
        misbehaves, or a comparison of the two ways)."""
        if not hasattr(os, "O_DIRECT") or os.environ.get("GEARSWEEP_DIRECT_IO") == "0":
            return False
        try:
            dev = os.stat(Path(path).parent).st_dev
        except OSError:
            return False
        return cls._verdict.get(dev, True)

    @classmethod
    def refuse(cls, path: str | Path) -> None:
        """Direct writes failed on the device of ``path`` (``EINVAL``): no more tries there."""
        cls._verdict[os.stat(Path(path).parent).st_dev] = False

    def __init__(self, path: str | Path, durable: bool = False) -> None:
        self.dev = os.stat(Path(path).parent).st_dev
        self.durable = durable
        self.fd = os.open(path, os.O_WRONLY | os.O_TRUNC | os.O_DIRECT)
        buf = getattr(self._local, "buf", None)
        if buf is None:
            # page-aligned; private, so that a forked process (a dask worker) writes its own
            buf = self._local.buf = mmap.mmap(-1, self.BLOCK,
                                              flags=mmap.MAP_PRIVATE | mmap.MAP_ANONYMOUS)
        self.view = memoryview(buf)
        self.fill = 0
        self.size = 0
        self.timed = 0
        """Bytes written in whole blocks, and their ``seconds``."""
        self.seconds = 0.0

    def write(self, data) -> int:
        """Append ``data`` (any bytes-like object: bytes, a C-contiguous array)."""
        src = memoryview(data)
        n = src.nbytes
        if not n:
            return 0
        src = src.cast("B")
        done = 0
        while done < n:
            take = min(n - done, self.BLOCK - self.fill)
            self.view[self.fill:self.fill + take] = src[done:done + take]
            self.fill += take
            done += take
            if self.fill == self.BLOCK:
                self._flush(self.BLOCK)
        self.size += n
        return n

    def _flush(self, length: int) -> None:
        """Write the first ``length`` bytes of the buffer (a multiple of ``ALIGN``); the time of
        a whole block counts towards the device's rate (a short write's is mostly latency)."""
        t0 = time.perf_counter()
        out = 0
        while out < length:
            out += os.write(self.fd, self.view[out:length])
        if length == self.BLOCK:
            self.timed += length
            self.seconds += time.perf_counter() - t0
        self.fill = 0

    def close(self) -> None:
        """Write the last block (padded to ``ALIGN``), cut the file to its length, close it and
        judge the device's rate (see the class)."""
        try:
            if self.fill:
                tail = self.fill
                padded = -(-tail // self.ALIGN) * self.ALIGN
                self.view[tail:padded] = bytes(padded - tail)
                self._flush(padded)
            os.ftruncate(self.fd, self.size)
            if self.durable:
                os.fsync(self.fd)  # O_DIRECT leaves the file's size and blocks map unsynced
        finally:
            os.close(self.fd)
        if self.timed and self.dev not in self._verdict:
            size, seconds = self._written.get(self.dev, (0, 0.0))
            size, seconds = size + self.timed, seconds + self.seconds
            self._written[self.dev] = (size, seconds)
            if size >= self.JUDGE_BYTES:
                self._verdict[self.dev] = size >= self.MIN_RATE * seconds

    def __enter__(self) -> DirectFile:
        return self

    def __exit__(self, exc_type, *exc: object) -> None:
        if exc_type is None:
            self.close()
        else:
            os.close(self.fd)


def utf8_text(data: bytes) -> str:
    """``data`` decoded as UTF-8 (a leading byte-order mark dropped); bytes that are not UTF-8
    raise ``NotUtf8`` naming the line and column of the first of them."""
    body = data[3:] if data.startswith(b"\xef\xbb\xbf") else data
    try:
        return body.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise NotUtf8(body, exc) from None


class NotUtf8(ValueError):
    """Text that is not UTF-8: ``line`` and ``column`` (from 1; the column in characters) of its
    first bad byte, and ``what`` says so (``byte 0xe9 at column 12``), for a line of the file's
    ``path:LINE:`` form (a Latin-1 study or CSV said no line: an outside tester's finding)."""

    def __init__(self, data: bytes, exc: UnicodeDecodeError) -> None:
        start = exc.start
        begins = data.rfind(b"\n", 0, start) + 1
        self.line = data.count(b"\n", 0, start) + 1
        self.column = len(data[begins:start].decode("utf-8", "replace")) + 1
        bad = data[start:max(exc.end, start + 1)]
        self.what = (f"byte{'s' if len(bad) > 1 else ''} {' '.join(f'0x{b:02x}' for b in bad)}"
                     f" at column {self.column}")
        super().__init__(f"line {self.line}: {self.what} is not UTF-8 text")


def replace_problem(path: str | Path) -> str | None:
    """Why a result cannot be renamed over ``path`` (``None``: it is a regular file or nothing).
    A result is written beside its path and renamed over it, which would replace a device, a
    pipe or a socket with a file (``-o /dev/null`` did, as root) and fails on a folder."""
    path = Path(path)
    try:
        path.exists()
    except OSError as exc:  # a name too long, say
        return f"a path the file system takes ({exc.strerror or type(exc).__name__})"
    if path.is_dir():
        return "a file path, not a folder"
    if path.is_symlink() and _loops(path):  # (other links are written to their targets)
        return ("a file path, not a loop of symbolic links (it leads to no file; the result"
                " would replace the link)")
    if path.exists() and not path.is_file():
        return ("a regular file or a new path (this is a device, a pipe or a socket, which the"
                " result would replace)")
    if path.is_file() and not _netcdf_or_empty(path):
        return ("a new path or a netCDF file (this file holds something else, which the result"
                " would replace: a study, say; remove it first if that is meant)")
    return None


def _loops(path: Path) -> bool:
    """Whether the symbolic link ``path`` is in a loop of links."""
    try:
        os.stat(path)
    except OSError as exc:
        return exc.errno == errno.ELOOP
    return False


_SIGNATURES = (b"\x89HDF\r\n\x1a\n", b"CDF\x01", b"CDF\x02", b"CDF\x05")
"""The first bytes of an HDF5 file (netCDF-4) and of the classic netCDF formats."""


def _netcdf_or_empty(path: Path) -> bool:
    """Whether the file at ``path`` is empty or starts as a netCDF file does (HDF5's signature
    may also follow a user block of 512, 1024, 2048, ... bytes): a file a result may replace.
    ``gearsweep.run(study, output=study)`` wrote the result over the study file."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(8)
            if not head or head.startswith(_SIGNATURES):
                return True
            offset = 512
            while offset <= 1 << 20:
                fh.seek(offset)
                if fh.read(8) == _SIGNATURES[0]:
                    return True
                offset *= 2
    except OSError:
        return True  # unreadable: the writer's own error says why
    return False


def check_replaceable(path: str | Path) -> None:
    """Raise ``ResultError`` unless a result can be renamed over ``path`` (``replace_problem``)."""
    problem = replace_problem(path)
    if problem is not None:
        raise ResultError(f"{path}: not a place for the result: {problem}")

"""What a result file says about how it was made.

``provenance()`` is the text after the time stamp in the ``history`` attribute: the command line
and the versions of gearsweep, numba, numpy, xarray and Python, so that a result can be traced
to the software that made it.
"""

from __future__ import annotations

import contextlib
import contextvars
import functools
import platform
import shlex
import sys
from importlib import metadata
from pathlib import Path

from gearsweep._version import __version__


@functools.cache  # importlib.metadata reads the package's metadata files: 0.6 ms a call, three
def _version(dist: str) -> str:  # per history and per estimate (its output bound counts history)
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return "?"


_command: contextvars.ContextVar[list[str] | None] = contextvars.ContextVar(
    "gearsweep_command", default=None)
"""The command ``cli.main`` was given when called from Python with its arguments (``command``):
scripts/main_job.py runs every study as ``main(["run", STUDY, "-o", OUT, "-q"])``, and its results
said ``main_job.py``, the process's ``sys.argv``, not the command that made them. A context
variable, not a module global: ``main`` in one thread named another thread's results, and two
calls that overlapped left the first one's command for every later result of the process."""


@contextlib.contextmanager
def command(argv: list[str]):
    """Within it (in this thread, and what it hands a copy of its context), ``command_line()``
    is ``argv`` (``["gearsweep", "run", ...]``)."""
    token = _command.set(list(argv))
    try:
        yield
    finally:
        _command.reset(token)


def command_line() -> str:
    """The command that is running, as a user would type it (``gearsweep run s.yaml -o o.nc``)."""
    given = _command.get()
    if given is not None:
        return shlex.join(given)
    argv = list(sys.argv) or ["python"]
    path = Path(argv[0])
    name = path.name
    if name == "gearsweep" or argv[0] == "-m" or (
            name in ("cli.py", "__main__.py") and path.parent.name == "gearsweep"):
        name = "gearsweep"
    elif name == "__main__.py":  # python -m PACKAGE: another program (pytest, a user's package)
        name = f"python -m {path.parent.name}"
    elif argv[0] in ("-c", "-", ""):  # python -c '...', a script from stdin, an interactive one
        name = {"-c": "python -c", "-": "python -"}.get(argv[0], "python")
    return " ".join([name, shlex.join(argv[1:])]).strip()


def source_commit(root: Path | None = None) -> str | None:
    """The git commit of the checkout gearsweep runs from (its first 12 hex digits), read from
    ``.git`` beside the package (no ``git`` process); ``None`` for an installed wheel or where
    it cannot be read. The version alone (0.1.0 for every commit) did not name the code that
    made a result (an outside data steward's finding). Edits not committed are not seen."""
    git = (root or Path(__file__).resolve().parents[2]) / ".git"
    try:
        head = (git / "HEAD").read_text(encoding="ascii").strip()
        if head.startswith("ref: "):
            ref = head[5:]
            loose = git / ref
            if loose.is_file():
                head = loose.read_text(encoding="ascii").strip()
            else:  # packed by git gc: "<sha> <ref>" lines
                packed = (git / "packed-refs").read_text(encoding="ascii").splitlines()
                head = next(line.split()[0] for line in packed if line.endswith(" " + ref))
    except (OSError, UnicodeDecodeError, StopIteration):  # no checkout (a wheel), a worktree
        return None  # (.git is a file there), or unreadable
    return head[:12] if len(head) >= 12 and all(c in "0123456789abcdef" for c in head) else None


@functools.cache
def identity() -> str:
    """The gearsweep that runs in this process as a result's history names it: ``gearsweep
    0.1.0 commit 0123456789ab`` (the commit where it runs from a git checkout:
    ``source_commit``). A dask worker's is compared with the client's before it computes a
    chunk (``execute.DaskBackend``): a worker importing another gearsweep computed other
    numbers under the client's history line (an outside tester).

    Read once per process, at its first call: it names the code this process loaded. Read
    from ``.git`` at every call, a ``git commit`` or checkout during a ``--workers`` or
    ``--scheduler`` run made every later chunk a worker's of "another gearsweep" (the client
    and its workers had both loaded the same code), and cost file reads per chunk."""
    commit = source_commit()
    return f"gearsweep {__version__}" + (f" commit {commit}" if commit else "")


def provenance() -> str:
    """``gearsweep run s.yaml -o o.nc (gearsweep 0.1.0 commit 0123456789ab, numba 0.60.0, ...)``
    (``identity``, then the versions of the libraries it computes with)."""
    versions = ", ".join(f"{d} {_version(d)}" for d in ("numba", "numpy", "xarray"))
    return f"{command_line()} ({identity()}, {versions}, Python {platform.python_version()})"


"""Files written whole or not at all: the one atomic writer of the package (checkpoints, and the
start-up caches kept beside the Numba cache)."""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import IO

from gearsweep.errors import ResultError


def atomic_write(path: Path, write: Callable[[IO[bytes]], object], *, durable: bool = True) -> None:
    """Call ``write(file_object)`` on a temporary file next to ``path``, then rename it to
    ``path``: a reader, or a run killed meanwhile, sees the old file or the new one, never a part
    of it (once the process is gone: its bytes are in the system's page cache). ``durable``:
    fsync before the rename, so that the new file also survives a power loss (the manifest of a
    checkpoint folder); files that can be computed again (caches, chunk checkpoints) skip it.
    On any error the temporary file is removed and the error raised."""
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".partial", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            write(fh)
            if durable:
                fh.flush()
                os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def replace_problem(path: str | Path) -> str | None:
    """Why a result cannot be renamed over ``path`` (``None``: it is a regular file or nothing).
    A result is written beside its path and renamed over it, which would replace a device, a
    pipe or a socket with a file (``-o /dev/null`` did, as root) and fails on a folder."""
    path = Path(path)
    if path.is_dir():
        return "a file path, not a folder"
    if path.exists() and not path.is_file():
        return ("a regular file or a new path (this is a device, a pipe or a socket, which the"
                " result would replace)")
    return None


def check_replaceable(path: str | Path) -> None:
    """Raise ``ResultError`` unless a result can be renamed over ``path`` (``replace_problem``)."""
    problem = replace_problem(path)
    if problem is not None:
        raise ResultError(f"{path}: not a place for the result: {problem}")

"""The output of a run as a workspace: one run at a time, no mixing with another study's chunks.

* ``OutputLock(out)``: an OS file lock (``filelock``) on ``OUT.nc.lock`` held for the whole run;
  a second ``gearsweep run`` on the same output is refused in one line naming the first's PID.
  The lock is the kernel's (``flock``), so a run that was killed leaves no stale lock: the OS
  releases it with the process. Taking it removes the temporary files a killed run's write
  left beside the output (``files.remove_temps_beside``).
* ``check_partial(plan, out)``: chunks of a *different* study left in ``OUT.nc.chunks`` (an
  interrupted run of another study to the same path) are refused, never mixed or silently
  deleted.
* ``saved_chunks``: how many of a study's chunks are on disk (for the interruption message).
* ``check_replaces(study, out)``: an existing result of *another* study at ``out`` (or a netCDF
  file that is not a gearsweep result) is refused, never replaced silently, unless the caller
  says so (``--overwrite``); the same study's result is replaced by its rerun.
"""

from __future__ import annotations

import contextlib
import os
import re
import warnings
from pathlib import Path

from gearsweep.errors import GearsweepError, ResultError
from gearsweep.files import remove_temps_beside, replace_problem
from gearsweep.study.checkpoint import SUFFIX, chunk_folder
from gearsweep.study.execute import chunks_to_run
from gearsweep.study.schema import parse_study


class BusyError(GearsweepError):
    """Another process is writing the same output."""


def input_files(study, results: str | Path) -> list[Path]:
    """The files a study reads beside its own text: a scene's measured excitation, and an
    analysis study's input results (``results/<name>.nc``, read from ``results``: the output's
    folder)."""
    ex = getattr(getattr(study, "scene", None), "excitation", None)
    files = [Path(ex.file)] if ex is not None else []
    analysis = getattr(study, "analysis", None)
    if analysis is not None and hasattr(analysis, "inputs"):
        files += [Path(results) / f"{name}.nc" for name in analysis.inputs()]
    return files


def output_path(out: str | Path) -> Path:
    """The path a run writes for ``out``: a symbolic link's target (the result is written beside
    its path and renamed over it, which replaced the link with a file and left the target as it
    was), else ``out`` as given."""
    out = Path(out)
    try:
        return Path(os.path.realpath(out)) if out.is_symlink() else out
    except OSError:  # a name too long, say: the checks of the output say so, in one line
        return out


def reads_output(study, out: str | Path) -> Path | None:
    """The input of ``study`` (``input_files``) that the result ``out`` would replace, if any:
    an analysis run with ``-o`` its own input result replaced it, and ``gearsweep.run`` with
    ``output=`` a study's netCDF excitation wrote over it, with no word."""
    out = Path(os.path.realpath(out))  # through links, and folders still to be made
    for f in input_files(study, out.parent):
        try:
            if out.exists() and f.exists() and os.path.samefile(out, f):
                return f
        except OSError:
            continue
    return None


def lock_path(out: str | Path) -> Path:
    out = Path(out)
    return out.with_name(out.name + ".lock")


def _owner(lock: Path) -> str:
    """The PID a run holding ``lock`` wrote beside it (``?`` where it cannot be read)."""
    try:
        return lock.with_name(lock.name + ".pid").read_text(encoding="utf-8").strip() or "?"
    except OSError:
        return "?"


def writing_run(out: str | Path) -> str | None:
    """The PID of the run writing ``out`` now (``?`` where it is not known), or ``None``: the
    run's own check (``OutputLock``), the OS lock on ``OUT.nc.lock`` tried at once and let go,
    nothing made where there is no lock file. ``gearsweep inspect`` said "an interrupted run
    saved 6 chunks ... run the same command" of a run going on (an outside tester)."""
    from filelock import FileLock, Timeout

    path = lock_path(out)
    try:
        if not path.is_file():
            return None
    except OSError:  # a name the file system cannot hold (too long): no run writes it
        return None
    lock = FileLock(str(path), timeout=0)
    try:
        lock.acquire()
    except Timeout:
        return _owner(path)
    except OSError:  # not ours to open (another user's run, a read-only folder): not known
        return None
    lock.release()
    return None


class OutputLock:
    """Exclusive lock on an output path for one run (refuses at once, never waits)."""

    def __init__(self, out: str | Path) -> None:
        from filelock import FileLock

        self.out = Path(out)
        self.path = lock_path(out)
        self.owner = self.path.with_name(self.path.name + ".pid")
        self.lock = FileLock(str(self.path), timeout=0)

    def __enter__(self) -> OutputLock:
        from filelock import Timeout

        made = [p for p in (self.path.parent, *self.path.parent.parents) if not p.exists()]
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            try:
                self.lock.acquire()
            except Timeout:
                if not self.path.exists():  # not held by another run: it cannot be made here
                    fd = os.open(self.path, os.O_WRONLY | os.O_CREAT, 0o644)  # (/proc, a
                    os.close(fd)  # read-only folder: the OSError that says why, below)
                    self.path.unlink(missing_ok=True)
                pid = _owner(self.path)
                raise BusyError(f"{self.out}: another gearsweep run (PID {pid}) is writing this"
                                " output; wait for it, or choose another -o") from None
            try:
                self.owner.write_text(f"{os.getpid()}\n", encoding="utf-8")
                remove_temps_beside(self.out)  # what a killed run's write left beside it
            except BaseException:
                self.__exit__()
                raise
        except OSError as exc:  # a full disk, a folder where the lock goes: one line, nothing
            for folder in made:  # left behind (were a traceback, a lock file and new folders)
                with contextlib.suppress(OSError):
                    folder.rmdir()
            raise ResultError(f"{self.out}: cannot write the result here ({self.path.name}:"
                              f" {exc.strerror or type(exc).__name__})") from None
        return self

    def __exit__(self, *exc: object) -> None:
        # No *.lock left beside the results, where the folder lets them go. A folder made
        # read-only during the run keeps them (harmless: the OS's lock goes with the release);
        # their removal's error hid the run's own line behind a traceback (exit 1).
        try:
            for path in (self.owner, self.path):
                with contextlib.suppress(OSError):
                    path.unlink(missing_ok=True)
        finally:
            self.lock.release()


def _sha(plan) -> str:
    return plan.study_key


def check_partial(plan, out: str | Path) -> None:
    """Refuse when ``OUT.nc.chunks`` holds saved chunks of another study."""
    root = chunk_folder(out)
    if not root.is_dir():
        return
    mine = _sha(plan)
    for folder in root.iterdir():
        if folder.is_dir() and folder.name != mine and any(folder.glob(f"*{SUFFIX}")):
            n = sum(1 for _ in folder.glob(f"*{SUFFIX}"))
            raise BusyError(f"{out}: {root} holds {n} saved chunk(s) of another study (an"
                            " interrupted run of a study with other values, another content of"
                            " a file it reads, or on another --device); finish it with that"
                            f" study, or remove {root} to start this one")


def saved_chunks(plan, out: str | Path, chunk_cases: int | None = None) -> tuple[int, int]:
    """(chunks of ``plan`` saved next to ``out``, chunks in all)."""
    chunks = chunks_to_run(plan, out, chunk_cases)
    folder = chunk_folder(out) / _sha(plan)
    done = sum(1 for a, b in chunks if (folder / f"chunk_{a}_{b}{SUFFIX}").is_file())
    return done, len(chunks)


def replaced_result(study, out: str | Path) -> str | None:
    """What the file at ``out`` holds that a result of ``study`` would replace and lose: the
    result of another study, a netCDF file that is not a gearsweep result, or a file that
    netCDF cannot read: it cannot be shown to be this study's (a result of another study cut
    short by ``head -c`` was replaced without ``--overwrite``: an outside tester's finding;
    gearsweep's own runs write their file beside it and rename it whole, so they leave none
    such). ``None``: no file, an empty one, or a result of this same study: the same values as
    validated (its comments, spacing and key order aside, and the device it ran on), which its
    rerun computes again. A file that is not netCDF at all (a study, say) is
    ``files.replace_problem``'s."""
    out = Path(out)
    try:
        if not out.is_file() or out.stat().st_size == 0 or replace_problem(out) is not None:
            return None  # (a file that is not netCDF at all: replace_problem's one line)
    except OSError:
        return None
    import netCDF4

    try:
        with netCDF4.Dataset(out) as nc:
            attrs = {k: nc.getncattr(k) for k in nc.ncattrs()
                     if k in ("study", "study_folder", "title", "history")}
    except (OSError, RuntimeError):
        return ("data that cannot be read as a netCDF result (damaged or cut short), so it may"
                " be another study's result")
    if not isinstance(attrs.get("study"), str):
        return "a netCDF file that is not a gearsweep result (no 'study' attribute)"
    try:
        with warnings.catch_warnings():  # (its geometry's warnings are not this run's)
            warnings.simplefilter("ignore")
            held = parse_study(attrs["study"], "<result>", base=attrs.get("study_folder"))
    except GearsweepError:  # a study this version no longer takes: another study
        held = None
    if held is not None and _values(held) == _values(study):
        return None
    when = re.findall(r"^(\d{4}-\d\d-\d\dT[\d:]+Z): ", str(attrs.get("history", "")), re.M)
    return (f"the result of another study ({str(attrs.get('title', ''))!r}"
            + (f", written {when[-1]})" if when else ")"))


def _values(study) -> dict:
    """A study's values as validated, without the device it runs on."""
    values = study.model_dump(mode="json")
    if isinstance(values.get("solver"), dict):
        values["solver"].pop("device", None)
    return values


def check_replaces(study, out: str | Path, ahead: str) -> None:
    """Raise ``ResultError`` where a result of ``study`` at ``out`` would replace another
    study's result (``replaced_result``): "nothing already computed is lost" (a run of one
    study replaced a file holding another's results, silently; an outside tester's finding).
    ``ahead``: how to go ahead anyway (``--overwrite``, ``overwrite=True``)."""
    held = replaced_result(study, out)
    if held is not None:
        raise ResultError(f"{out}: holds {held}, which this result would replace: {ahead}")

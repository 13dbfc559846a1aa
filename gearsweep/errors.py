"""The package's own exceptions and warnings. The CLI maps every ``GearsweepError`` to one line and
exit code 2, and prints a ``StepLimitWarning`` as one ``gearsweep: warning:`` line."""

from __future__ import annotations

import contextlib
import math
import re
import signal
import threading

EXIT_USAGE = 2
"""Exit code of the CLI for input it refuses (a ``GearsweepError``): one line on stderr."""

EXIT_INTERRUPTED = 130
"""Exit code of the CLI stopped by Ctrl-C (128 + SIGINT, as a shell reports it)."""

EXIT_TERMINATED = 143
"""Exit code of ``gearsweep run`` stopped by SIGTERM (128 + SIGTERM: ``kill``, ``docker stop``,
a batch system's time limit), the chunks it had computed saved first."""

EXIT_HUNG_UP = 129
"""Exit code of ``gearsweep run`` stopped by SIGHUP (128 + SIGHUP: its terminal closed), as by
SIGTERM."""

STOP_SIGNALS = tuple(getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP")
                     if hasattr(signal, name))
"""The signals that stop a run (no SIGHUP on Windows)."""


@contextlib.contextmanager
def signals_held(*signums: int):
    """The signals ``signums`` held while the block runs, then given to the handlers that were
    in place before it (``signal.raise_signal``): a Ctrl-C lands after the block, not inside it.

    For work that an exception raised in the middle of it spoils: pydantic builds a model's
    validator in Rust, which turned a ``KeyboardInterrupt`` raised in it into a ``SchemaError``
    (a traceback of 40 lines, exit 1: an outside tester, 3 in about 85 Ctrl-C while a study of
    20,000 speeds was parsed); a local dask cluster starting its processes. Outside the main
    thread, where signals cannot be set, nothing is changed. The block is given the list of the
    signals held so far (it may look: a temporary file then removed before the signal's own
    action, which may end the process)."""
    held: list[int] = []
    if threading.current_thread() is not threading.main_thread():
        yield held
        return
    previous = {s: signal.signal(s, lambda signum, frame: held.append(signum)) for s in signums}
    try:
        yield held
    finally:
        for s, handler in previous.items():  # (None: a handler not set from Python; Python's)
            signal.signal(s, handler if handler is not None else signal.default_int_handler
                          if s == signal.SIGINT else signal.SIG_DFL)
        for s in dict.fromkeys(held):
            signal.raise_signal(s)


def stops_held():
    """``signals_held`` of the ``STOP_SIGNALS`` that have a handler of Python's (which raises: a
    ``KeyboardInterrupt``, the CLI's stop), for xarray's netCDF reads and writes: raised while
    xarray held its HDF5 lock, the interrupt left the lock taken and the file's close then waited
    for it forever (a Ctrl-C while a mesh study's result was written hung; an outside tester).
    A signal ignored or of the default action is left as it is: nothing of Python's runs then."""
    return signals_held(*(s for s in STOP_SIGNALS if callable(signal.getsignal(s))))


def article(word: str) -> str:
    """``word`` after its indefinite article, for messages that name a kind: 'an inertia', 'an
    analysis study', 'a mesh study', 'an artifact_map analysis'."""
    vowel = word[:1].lower() in "aeio" or (word[:1].lower() == "u"
                                          and not word.lower().startswith(("uni", "use", "usu")))
    return f"{'an' if vowel else 'a'} {word}"


class GearsweepError(Exception):
    """Base class of every error that is the user's input, not a bug: one clear line, exit 2."""


NO_VALUE = object()
"""A problem whose message already shows the value (``3 has no unit; write e.g. '3 mm', ...``)."""


DICT_STUDY = "<dict>"
"""The name a study given as a Python dict is reported under: without line numbers, which would
be those of the YAML made from it, text the user never saw."""


def problem_line(file: str, line: int | None, field: str, value: object, allowed: str) -> str:
    """``file.yaml:LINE: field.path: value -- what is allowed``, on one line."""
    where = f"{file}:{line}" if line and file != DICT_STUDY else file
    if value is NO_VALUE:
        text = f"{where}: {field}: {allowed}"
    else:
        shown = repr(value)
        shown = shown if len(shown) <= 80 else shown[:60] + "..." + shown[-10:]
        text = f"{where}: {field}: {shown} -- {allowed}"
    return " ".join(text.splitlines())


class StudyError(GearsweepError):
    """A study file that cannot be run: ``file:LINE: field.path: value -- what is allowed``.

    One error may hold several problems (``StudyError.many``): every problem of a file is
    reported at once, one line each (``lines``), sorted by line number.
    """

    def __init__(self, file: str, field: str, value: object, allowed: str,
                 line: int | None = None) -> None:
        self.file, self.field, self.value, self.allowed, self.line = file, field, value, allowed, line
        self.lines = [problem_line(file, line, field, value, allowed)]
        self.problems = [(line, field, value, allowed)]
        super().__init__(self.lines[0])

    @classmethod
    def many(cls, file: str, problems: list[tuple[int | None, str, object, str]]) -> StudyError:
        """One error for several problems ``(line, field, value, allowed)`` (at least one)."""
        problems = sorted(problems, key=lambda p: (p[0] is None, p[0] or 0))
        line, field, value, allowed = problems[0]
        err = cls(file, field, value, allowed, line)
        seen: list[str] = []
        for p in problems:
            text = problem_line(file, *p)
            if text not in seen:
                seen.append(text)
        err.lines = seen
        err.problems = problems
        err.args = ("\n".join(seen),)
        return err

    def joined(self, other: StudyError) -> StudyError:
        """This error with the problem lines of ``other`` of the same file, sorted by line."""

        def line_no(text: str) -> float:
            m = re.match(re.escape(self.file) + r":(\d+):", text)
            return int(m.group(1)) if m else math.inf

        def field(text: str) -> str | None:
            m = re.match(re.escape(self.file) + r"(?::\d+)?: (\S+?):? ", text)
            return m.group(1) if m else None

        said = {field(t) for t in self.lines} - {None}  # one line per field: 'speed: [.inf]'
        more = [t for t in other.lines if field(t) not in said]  # was said twice, in two wordings
        lines = sorted(dict.fromkeys(self.lines + more), key=line_no)
        self.lines = lines
        self.args = ("\n".join(lines),)
        return self

    def __reduce__(self):
        # pickled (a process pool's worker, a dask worker): Exception's default rebuilds it as
        # ``cls(*args)``, the message alone, which __init__ does not take: unpickling raised
        # TypeError and a ProcessPoolExecutor running gearsweep.run said BrokenProcessPool
        return _rebuilt, (type(self), self.args, self.__dict__)


def _rebuilt(cls: type, args: tuple, state: dict) -> GearsweepError:
    """An exception ``cls`` with ``args`` and attributes ``state``, without its ``__init__``."""
    err = cls.__new__(cls)
    err.args = args
    err.__dict__.update(state)
    return err


class GeometryError(GearsweepError):
    """A gear pair that cannot exist (interference, pointed teeth, contact ratio below 1, ...).

    ``faults``: each problem as ``(message, fields)``, ``fields`` the names of the pair's fields
    that set what is wrong (``tip_radius1``, ``tip_relief.amount``), the most responsible first:
    a study reports each problem at the line of the first of them it writes (``schema``).
    """

    def __init__(self, message: str, faults: list[tuple[str, tuple[str, ...]]] | None = None
                 ) -> None:
        super().__init__(message)
        self.faults = list(faults or [])


class GearStudyError(StudyError, GeometryError):
    """A study's gear pair that cannot exist: each problem at the line of the field it is about
    (a ``StudyError``, and a ``GeometryError`` as it was before it named the field)."""


class ResultError(GearsweepError):
    """A results file that is missing, unreadable, or not a gearsweep result."""


class ClusterError(GearsweepError):
    """A dask cluster that cannot be reached or used, or a chunk that failed on it."""


class LimitError(GearsweepError):
    """A study predicted beyond the time, memory or output limits, not confirmed with --yes."""


class DeviceError(GearsweepError):
    """A compute device asked for (``solver.device: cuda``) that this machine cannot provide, or a
    feature that the device does not run (the kink-aware step on CUDA)."""


class ChunkSizeWarning(UserWarning):
    """``gearsweep.run(..., chunk_cases=N)`` with chunks smaller than one round of the kernel's
    lanes on all threads: most of each chunk's work is empty; or longer than the runner allows,
    then cut (``estimate.capped_chunk_note``). The CLI notes both for ``--chunk-size``. Its own
    class so that a script can filter it without matching its text."""


class StepLimitWarning(UserWarning):
    """Cases of a study run with ``solver.step_guard: warn`` (the default) whose step lies beyond
    the method's stability limit: the result marks them in ``beyond_step_limit`` and their
    values may be spoiled by the integrator. ``gearsweep.run`` warns it; the CLI prints the same
    line. Its text: ``gearsweep.study.execute.step_limit_warning``."""


class ContactLossWarning(UserWarning):
    """Cases of a driven scene without backlash whose loaded flanks part in the steady state (p
    below 0 under a positive mean force, above 0 under a negative one, of both signs under none:
    ``gearsweep.study.outputs.loaded_flank_lost``), and the scene's linear mesh force k(t) p puts
    the other flanks into contact at once (a pair with no backlash), where a real pair's teeth
    would separate (the result marks them in ``contact_lost``; a ``full`` or ``rattle`` scene
    with ``backlash`` models it). ``gearsweep.run`` warns it; the CLI prints the same line. Its
    text:
    ``gearsweep.study.execute.contact_lost_text``."""


class SpectrumAliasingWarning(UserWarning):
    """A study's ``spectrum`` sampled so few times per mesh period that the orders where the
    response has weight (up to the natural frequency's order plus the excitation's highest)
    fold onto its kept lines: ``gearsweep.run`` warns it before running; ``gearsweep validate``
    and ``run`` print the same line. Its text: ``gearsweep.study.outputs.spectrum_aliasing``."""


class UnstableEquationWarning(UserWarning):
    """``gearsweep.analysis.linear_response.periodic_response`` at a mesh frequency where the
    homogeneous equation is parametrically unstable (its largest Floquet multiplier exceeds
    1 + ``kernels.floquet.UNSTABLE_TOL``): the periodic solution returned there exists, but it is
    not the steady state, since any perturbation of it grows. Its own class so that a script can
    filter it without matching its text."""

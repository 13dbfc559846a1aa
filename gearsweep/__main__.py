"""The ``gearsweep`` command (and ``python -m gearsweep``): the CLI, imported inside a guard.

Importing ``gearsweep.cli`` loads numpy, Numba and the study layer (about 0.3 s). A Ctrl-C in that
time, or while the command line is parsed, arrived before ``cli.main`` could catch it and printed a
traceback of whatever module was being imported; here it ends as any interrupted run does: one
line, exit code 130. During the import a Ctrl-C is held until the import is done: raised inside
pydantic while it builds a model's schema, it came out as a ``SchemaError`` (a traceback, exit 1;
seen under load with the SIGINT 0.5 s after start).

The import runs with Python's cyclic garbage collector paused, and what it made is then frozen
(``gc.freeze``: left out of every later collection). The imports make some hundred thousand
objects that live as long as the process (modules, classes, functions, Numba's types), and the
collector walked them again and again as they were made, freeing nothing: 23 collections of the
younger generations and one of all, about 35 ms of the 0.34 s import (traced with
``gc.callbacks``); the warm-up's share is ``execute.warm_up``'s.

OpenBLAS, NumPy's linear algebra, is held to one thread (``OPENBLAS_NUM_THREADS=1``, unless the
environment sets it): at NumPy's import it starts a thread per core that spins waiting for work,
0.1 s of CPU beside the 0.3 s import (``/proc/self/task``), on a 2-core VM whose two cores may be
one core's two hyperthreads; a run's linear algebra is on matrices of a few rows (fits, the
step guard's polynomial roots, harmonic balance), where more threads bring nothing, and the
kernels have threads of their own. An 8-case study from process start to exit: median 0.354 s
against 0.364 s (12 alternating runs each, 26 Nov 2026).
"""

from __future__ import annotations

import gc
import os
import signal
import sys


def _interrupted() -> None:
    from gearsweep.errors import EXIT_INTERRUPTED

    print("gearsweep: interrupted", file=sys.stderr)
    sys.exit(EXIT_INTERRUPTED)


def entry() -> None:
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before NumPy's import (module docstring)
    from gearsweep.errors import signals_held  # (gearsweep's __init__ imports nothing heavy)

    collecting = gc.isenabled()
    gc.disable()  # the imports make long-lived objects only: nothing for the collector to find
    try:
        with signals_held(signal.SIGINT):
            from gearsweep.cli import entry as cli_entry
    except KeyboardInterrupt:  # held until the import was done, or where it could not be held
        _interrupted()
    finally:
        gc.freeze()  # modules, classes, Numba's types: never traversed again
        if collecting:
            gc.enable()
    try:
        cli_entry()
    except KeyboardInterrupt:  # before cli.main's own handler, or a second Ctrl-C after it
        _interrupted()


if __name__ == "__main__":
    entry()

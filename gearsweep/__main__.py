"""The ``gearsweep`` command (and ``python -m gearsweep``): the CLI, imported inside a guard.

Importing ``gearsweep.cli`` loads numpy, Numba and the study layer (about 0.3 s). A Ctrl-C in that
time, or while the command line is parsed, arrived before ``cli.main`` could catch it and printed a
traceback of whatever module was being imported; here it ends as any interrupted run does: one
line, exit code 130. During the import a Ctrl-C is held until the import is done: raised inside
pydantic while it builds a model's schema, it came out as a ``SchemaError`` (a traceback, exit 1;
seen under load with the SIGINT 0.5 s after start).
"""

from __future__ import annotations

import signal
import sys
import threading


def _interrupted() -> None:
    from gearsweep.errors import EXIT_INTERRUPTED

    print("gearsweep: interrupted", file=sys.stderr)
    sys.exit(EXIT_INTERRUPTED)


def entry() -> None:
    held: list[int] = []
    ours = threading.current_thread() is threading.main_thread()  # else signals cannot be set
    if ours:
        previous = signal.signal(signal.SIGINT, lambda signum, frame: held.append(signum))
    try:
        from gearsweep.cli import entry as cli_entry
    except KeyboardInterrupt:  # where the handler could not be ours
        _interrupted()
    finally:
        if ours:  # (None: a handler not set from Python; Python's own then)
            signal.signal(signal.SIGINT, signal.default_int_handler if previous is None
                          else previous)
    if held:
        _interrupted()
    try:
        cli_entry()
    except KeyboardInterrupt:  # before cli.main's own handler, or a second Ctrl-C after it
        _interrupted()


if __name__ == "__main__":
    entry()

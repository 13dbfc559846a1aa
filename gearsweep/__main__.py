"""The ``gearsweep`` command (and ``python -m gearsweep``): the CLI, imported inside a guard.

Importing ``gearsweep.cli`` loads numpy, Numba and the study layer (about 0.3 s). A Ctrl-C in that
time, or while the command line is parsed, arrived before ``cli.main`` could catch it and printed a
traceback of whatever module was being imported; here it ends as any interrupted run does: one
line, exit code 130.
"""

from __future__ import annotations

import sys


def entry() -> None:
    try:
        from gearsweep.cli import entry as cli_entry

        cli_entry()
    except KeyboardInterrupt:  # before cli.main's own handler, or a second Ctrl-C after it
        from gearsweep.errors import EXIT_INTERRUPTED

        print("gearsweep: interrupted", file=sys.stderr)
        sys.exit(EXIT_INTERRUPTED)


if __name__ == "__main__":
    entry()

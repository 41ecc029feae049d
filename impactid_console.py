"""The ``impactid`` console script's first code: stop signals are recorded before the package loads.

The console script imports this top-level module first. It installs SIGINT and SIGTERM handlers
that only record a signal, and then imports :mod:`impactid._launcher` (and with it the package
``impactid``, whose initialisation takes a few tens of milliseconds); the launcher acts on what was
recorded once its own handlers are in place, with the same one-line message and exit status as a
signal at any later moment. It lives outside the package because a module inside it can only run
after the package's ``__init__``: a Ctrl-C in that window ended in a traceback, a SIGTERM in a silent
death (exit -15). What remains unhandled is the interpreter's own start-up before any of impactid's
code runs (about 20 ms), where Python's default handlers apply.
"""

from __future__ import annotations

import signal

#: The signals that arrived before the launcher took over, in order.
EARLY: list[int] = []


def _record(signum, frame) -> None:  # noqa: ARG001 - signal handler signature
    EARLY.append(signum)


signal.signal(signal.SIGINT, _record)
signal.signal(signal.SIGTERM, _record)

from impactid._launcher import main as _launch  # noqa: E402 - after the handlers: that is this module's point


def main() -> int:
    """Entry point of the ``impactid`` console script; returns the exit code."""
    return _launch(early=EARLY)

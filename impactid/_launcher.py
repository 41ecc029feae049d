"""The ``impactid`` console script: a Ctrl-C or SIGTERM at any moment ends in one line.

The command line's own handlers (:func:`impactid.cli.main`) are in place only once its modules are
imported. Those are light (the parser is built from data: ``impactid --help`` loads no NumPy, SciPy,
pandas or numba); the heavy imports happen when a command runs, inside the command's environment,
which defers a stop that arrives during an import in the same way (:func:`impactid.cli._unsafe_to_stop`).
This module imports nothing of impactid's at load time but the signal helpers: it installs SIGINT
and SIGTERM handlers, imports :mod:`impactid.cli` inside :func:`main` (the one reason for a
function-level import here: no import may be broken by a signal, and the handlers come first), and
turns a signal during the import or the parser's construction into the same one-line error and exit
status as a signal during a command. A signal during the import is recorded and acted on when it
ends, not raised inside a library's initialisation.
"""

from __future__ import annotations

import signal
import sys
import threading
from collections.abc import Sequence

from impactid._signals import forget_stops, stopping_handler

__all__ = ["main"]

EXIT_INTERRUPTED = 130
EXIT_TERMINATED = 143


class _Terminated(BaseException):
    """SIGTERM arrived before the command line's own handler was installed."""


#: The signals that arrived while the modules were imported. The first is only recorded, and acted on
#: once the imports are done (a fraction of a second): an exception raised in the middle of a
#: library's initialisation can leave its C state half-built (NumPy re-raises it as ``ImportError``;
#: an old numba/llvmlite was seen to crash). A second signal is raised at once, as an escape hatch.
_arrived: list[int] = []
_importing = [False]


def _terminate(signum, frame):  # noqa: ARG001 - signal handler signature
    _arrived.append(signum)
    if not _importing[0] or len(_arrived) > 1:
        raise _Terminated()


def _interrupt(signum, frame):  # noqa: ARG001 - signal handler signature
    _arrived.append(signum)
    if not _importing[0] or len(_arrived) > 1:
        raise KeyboardInterrupt()


def _quiet_unraisable(info) -> None:
    """A stop raised inside a finalizer during the imports: the record above already says it."""
    if not isinstance(info.exc_value, (KeyboardInterrupt, _Terminated)):
        sys.__unraisablehook__(info)


def _say(text: str) -> None:
    try:
        sys.stderr.write(f"impactid: error: {text}\n")
        sys.stderr.flush()
    except (OSError, ValueError):  # a closed stderr: the exit status still says it
        pass


def _words(signum: int) -> str:
    if signum == signal.SIGTERM:
        return "terminated (SIGTERM) while starting; nothing was written"
    return "interrupted (Ctrl-C) while starting; nothing was written"


def _raise_for(signum: int) -> None:
    if signum == signal.SIGTERM:
        raise _Terminated()
    raise KeyboardInterrupt()


def _stopped(signum: int) -> int:
    _say(_words(signum))
    return EXIT_TERMINATED if signum == signal.SIGTERM else EXIT_INTERRUPTED


def main(argv: Sequence[str] | None = None, *, early: Sequence[int] = ()) -> int:
    """Entry point of the ``impactid`` command; returns the exit code.

    ``early`` are the stop signals that arrived before this function ran (the console script records
    them while the package loads: :mod:`impactid_console`); they are acted on as a signal during the
    imports is.
    """
    in_main = threading.current_thread() is threading.main_thread()
    _importing[0] = True  # from the handlers' first moment until the imports end, a signal is recorded
    previous_term = signal.signal(signal.SIGTERM, _terminate) if in_main else None
    previous_int = signal.signal(signal.SIGINT, _interrupt) if in_main else None
    _arrived[:] = early  # read after the handlers are in place: a signal in between is recorded by them
    previous_hook = sys.unraisablehook
    sys.unraisablehook = _quiet_unraisable
    try:
        try:
            from impactid import cli  # a signal meanwhile is acted on right after the import
        except BaseException:
            if _arrived:  # whatever a library made of a second signal's exception
                return _stopped(_arrived[0])
            raise
        finally:
            _importing[0] = False  # a signal from here on raises (caught below) until `late` takes over
            sys.unraisablehook = previous_hook
        if in_main:  # until the command's own environment takes over: never inside numba (impactid._signals)
            late = stopping_handler(_raise_for, lambda signum: _words(signum))
            signal.signal(signal.SIGTERM, late)
            signal.signal(signal.SIGINT, late)
        if _arrived:
            return _stopped(_arrived[0])
        # the command's own environment installs its handlers for the command and restores these after it
        return cli.main(argv)
    except KeyboardInterrupt:
        return _stopped(signal.SIGINT)
    except _Terminated:
        return _stopped(signal.SIGTERM)
    finally:
        forget_stops()  # the command has ended, and with it what its stops meant
        if in_main:
            signal.signal(signal.SIGTERM, previous_term)
            # the console script owns this process when argv is None and the command has ended (its
            # outputs are complete or rolled back): a Ctrl-C while the interpreter shuts down (about a
            # second with dask or numba loaded) has nothing left to stop and would only print a
            # traceback, so it is ignored from here on (set at once: no moment with Python's default)
            signal.signal(signal.SIGINT, signal.SIG_IGN if argv is None else previous_int)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

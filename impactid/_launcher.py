"""The ``impactid`` console script: a Ctrl-C or SIGTERM at any moment ends in one line.

The command line's own handlers (:func:`impactid.cli.main`) are in place only once its modules are
imported, and those imports (NumPy, SciPy, pandas, numba, the rigs) take a second or more. This
module imports nothing heavy at load time: it installs a SIGTERM handler, imports :mod:`impactid.cli`
inside :func:`main` (the one reason for a function-level import here: the import is the slow part
that must be interruptible), and turns an interruption during the imports or the parser's
construction into the same one-line error and exit status as an interruption during a command.
"""

from __future__ import annotations

import signal
import sys
import threading
from collections.abc import Sequence

__all__ = ["main"]

EXIT_INTERRUPTED = 130
EXIT_TERMINATED = 143


class _Terminated(BaseException):
    """SIGTERM arrived before the command line's own handler was installed."""


#: The signal that arrived while the modules were imported (None: none). A library's import code may
#: turn the exception a signal raises into another one (NumPy re-raises any failure of its C core's
#: import as ``ImportError``), so the decision rests on this record, not on the exception's type.
_arrived: list[int] = []


def _terminate(signum, frame):  # noqa: ARG001 - signal handler signature
    _arrived.append(signum)
    raise _Terminated()


def _interrupt(signum, frame):  # noqa: ARG001 - signal handler signature
    _arrived.append(signum)
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


def _stopped(signum: int) -> int:
    if signum == signal.SIGTERM:
        _say("terminated (SIGTERM) while starting; nothing was written")
        return EXIT_TERMINATED
    _say("interrupted (Ctrl-C) while starting; nothing was written")
    return EXIT_INTERRUPTED


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``impactid`` command; returns the exit code."""
    in_main = threading.current_thread() is threading.main_thread()
    previous_term = signal.signal(signal.SIGTERM, _terminate) if in_main else None
    previous_int = signal.signal(signal.SIGINT, _interrupt) if in_main else None
    previous_hook = sys.unraisablehook
    sys.unraisablehook = _quiet_unraisable
    try:
        try:
            from impactid import cli  # the slow imports, interruptible
        except BaseException:
            if _arrived:  # whatever a library made of the signal's exception
                return _stopped(_arrived[0])
            raise
        finally:
            sys.unraisablehook = previous_hook
            if in_main:
                signal.signal(signal.SIGINT, previous_int)
        # the command's own environment installs its SIGTERM handler for the command and restores
        # this one after it
        return cli.main(argv)
    except KeyboardInterrupt:
        return _stopped(signal.SIGINT)
    except _Terminated:
        return _stopped(signal.SIGTERM)
    finally:
        if in_main:
            signal.signal(signal.SIGTERM, previous_term)
            if argv is None:
                # the console script owns this process and the command has ended (its outputs are
                # complete or rolled back): a Ctrl-C while the interpreter shuts down (about a second
                # with dask or numba loaded) has nothing left to stop and would only kill it silently
                signal.signal(signal.SIGINT, signal.SIG_IGN)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

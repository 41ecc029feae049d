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


def _terminate(signum, frame):  # noqa: ARG001 - signal handler signature
    raise _Terminated()


def _say(text: str) -> None:
    try:
        sys.stderr.write(f"impactid: error: {text}\n")
        sys.stderr.flush()
    except (OSError, ValueError):  # a closed stderr: the exit status still says it
        pass


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``impactid`` command; returns the exit code."""
    in_main = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGTERM, _terminate) if in_main else None
    try:
        from impactid import cli  # the slow imports, interruptible

        # the command's own environment installs its SIGTERM handler for the command and restores
        # this one after it
        return cli.main(argv)
    except KeyboardInterrupt:
        _say("interrupted (Ctrl-C) while starting; nothing was written")
        return EXIT_INTERRUPTED
    except _Terminated:
        _say("terminated (SIGTERM) while starting; nothing was written")
        return EXIT_TERMINATED
    finally:
        if in_main:
            signal.signal(signal.SIGTERM, previous)
            if argv is None:
                # the console script owns this process and the command has ended (its outputs are
                # complete or rolled back): a Ctrl-C while the interpreter shuts down (about a second
                # with dask or numba loaded) has nothing left to stop and would only kill it silently
                signal.signal(signal.SIGINT, signal.SIG_IGN)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

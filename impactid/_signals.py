"""Ctrl-C and SIGTERM that never land inside numba's or llvmlite's machinery.

Python runs a signal handler between two bytecodes of the main thread, wherever that is. When it is
inside numba while a kernel is compiled or loaded from the cache, llvmlite is in the middle of calls
into LLVM that call back into Python (the object cache's callbacks, among others); an exception
raised there unwinds through C++ that does not expect it, and the process was seen to die of a
segmentation fault (exit -11, no message) about one time in ten when Ctrl-C or SIGTERM came 1.5 s
into ``impactid synth``, while the rig P kernel was loaded.

:func:`stopping_handler` makes a handler that raises the command's stop exception only when the
interrupted frame is not inside numba or llvmlite. Inside, it asks again a moment later (the signal is
sent once more to this process after :data:`RETRY_S`), so the stop takes effect as soon as the
compilation or the cache load in progress returns (a cold compilation of the largest kernel takes
about a minute: the first Ctrl-C then waits for it). A second signal from outside while one is
waiting ends the process at once (``os._exit`` after the one-line message: no Python code of the
interrupted machinery runs again, and outputs are still only temporary files, which are not put in
place).
"""

from __future__ import annotations

import importlib.util
import os
import signal
import sys
import threading
from collections.abc import Callable
from pathlib import Path
from types import FrameType

__all__ = [
    "RETRY_S",
    "StoppingHandler",
    "arrived_stop",
    "forget_stops",
    "in_import",
    "in_native_machinery",
    "stopping_handler",
]

#: Seconds between two tries of a stop that arrived inside numba or llvmlite.
RETRY_S = 0.05


def _package_roots() -> tuple[str, ...]:
    roots = []
    for name in ("numba", "llvmlite"):
        try:
            spec = importlib.util.find_spec(name)
        except (ImportError, ValueError):
            spec = None
        if spec is not None and spec.submodule_search_locations:
            roots.extend(str(Path(p).resolve()) + os.sep for p in spec.submodule_search_locations)
    return tuple(roots)


_ROOTS: tuple[str, ...] | None = None

#: The stop signals that reached a handler of :func:`stopping_handler` since :func:`forget_stops`.
#: Recorded on arrival, before any deferral, so that a stop whose exception was lost (raised in a
#: finalizer, or a retry that never came back) still keeps the job's outputs from being put in place
#: (:meth:`impactid._files.StagedFiles.commit` and the command line check it).
_ARRIVED: set[int] = set()


def arrived_stop() -> int | None:
    """The stop signal (SIGTERM before SIGINT) that arrived since :func:`forget_stops`, or None
    (other signals a handler was installed for are not stops of a command)."""
    if signal.SIGTERM in _ARRIVED:
        return signal.SIGTERM
    if signal.SIGINT in _ARRIVED:
        return signal.SIGINT
    return None


def forget_stops() -> None:
    """Forget the stops recorded so far (the command that received them has ended)."""
    _ARRIVED.clear()


def in_native_machinery(frame: FrameType | None) -> bool:
    """Whether ``frame`` or one of its callers is code of numba or llvmlite."""
    global _ROOTS
    if _ROOTS is None:
        _ROOTS = _package_roots()
    if not _ROOTS:
        return False
    while frame is not None:
        filename = frame.f_code.co_filename
        if filename.startswith(_ROOTS) or "/numba/" in filename or "/llvmlite/" in filename:
            return True
        frame = frame.f_back
    return False


def in_import(frame: FrameType | None) -> bool:
    """Whether ``frame`` or one of its callers is the import machinery (a module is being initialised)."""
    while frame is not None:
        if frame.f_code.co_filename.startswith("<frozen importlib"):
            return True
        frame = frame.f_back
    return False


class StoppingHandler:
    """A signal handler that calls ``stop(signum)`` (which raises) only where that is safe.

    Parameters
    ----------
    stop : raises the command's stop exception for ``signum`` (KeyboardInterrupt, ...).
    last_words : the one-line message (without ``impactid: error:``) and nothing else, used when a
        second signal ends the process at once.
    defer_while : whether the interrupted frame is one where the exception must not be raised
        (default: inside numba or llvmlite). There the signal is sent again every :data:`RETRY_S`
        and acts once the frame has returned.

    Every signal is recorded on arrival (:func:`arrived_stop`). A second signal from outside while
    one waits ends the process at once with the one-line message. :meth:`end` stops the resending
    (the command has ended: nothing is left to stop).
    """

    def __init__(
        self,
        stop: Callable[[int], None],
        last_words: Callable[[int], str],
        defer_while: Callable[[FrameType | None], bool] = in_native_machinery,
    ) -> None:
        self._stop = stop
        self._last_words = last_words
        self._defer_while = defer_while
        self._waiting = False
        self._resent = 0
        self._active = True
        self._lock = threading.Lock()

    def _resend(self, signum: int) -> None:
        with self._lock:
            if not self._active:
                return
            self._resent += 1
        try:
            os.kill(os.getpid(), signum)
        except OSError:
            pass

    def __call__(self, signum: int, frame: FrameType | None) -> None:
        _ARRIVED.add(signum)
        with self._lock:
            own = self._resent > 0
            if own:
                self._resent -= 1
        if not own and self._waiting:  # a second signal from outside: now
            try:
                sys.stderr.write(f"impactid: error: {self._last_words(signum)}\n")
                sys.stderr.flush()
            finally:
                os._exit(128 + signum)
        if self._defer_while(frame):
            self._waiting = True
            timer = threading.Timer(RETRY_S, self._resend, (signum,))
            timer.daemon = True
            timer.start()
            return
        self._waiting = False
        self._stop(signum)

    def end(self) -> None:
        """Send no deferred signal again from now on."""
        with self._lock:
            self._active = False


def stopping_handler(
    stop: Callable[[int], None],
    last_words: Callable[[int], str],
    defer_while: Callable[[FrameType | None], bool] = in_native_machinery,
) -> StoppingHandler:
    """A :class:`StoppingHandler` (the signal handler of a command; see there)."""
    return StoppingHandler(stop, last_words, defer_while)

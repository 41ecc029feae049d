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

__all__ = ["RETRY_S", "arrived_stop", "forget_stops", "in_native_machinery", "stopping_handler"]

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


def stopping_handler(stop: Callable[[int], None], last_words: Callable[[int], str]) -> Callable:
    """A signal handler that calls ``stop(signum)`` (which raises) outside numba and llvmlite.

    Parameters
    ----------
    stop : raises the command's stop exception for ``signum`` (KeyboardInterrupt, ...).
    last_words : the one-line message (without ``impactid: error:``) and nothing else, used when a
        second signal ends the process at once.
    """
    state = {"waiting": False, "retries": 0}
    lock = threading.Lock()

    def retry(signum: int) -> None:
        with lock:
            state["retries"] += 1
        try:
            os.kill(os.getpid(), signum)
        except OSError:
            pass

    def handler(signum, frame):
        _ARRIVED.add(signum)
        with lock:
            resent = state["retries"] > 0
            if resent:
                state["retries"] -= 1
        if not resent and state["waiting"]:  # a second signal from outside: now
            try:
                sys.stderr.write(f"impactid: error: {last_words(signum)}\n")
                sys.stderr.flush()
            finally:
                os._exit(128 + signum)
        if in_native_machinery(frame):
            state["waiting"] = True
            timer = threading.Timer(RETRY_S, retry, (signum,))
            timer.daemon = True
            timer.start()
            return
        state["waiting"] = False
        stop(signum)

    return handler

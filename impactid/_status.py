"""A status line on the terminal while a command works without printing (standard library only).

A command that computes for several seconds before it prints its result leaves the terminal
silent. On a terminal, :class:`StatusLine` writes one line on stderr once nothing was printed for
:data:`QUIET_S` seconds, ``impactid: estimate: fitting the contact law (4 s)``, rewritten in place
every :data:`TICK_S` seconds and erased before anything else is printed (and when the command
ends), so that the command's output is exactly what it would be without it. What the command is
doing comes from :func:`stage` (:class:`impactid.pipeline.Pipeline` names its steps: reading,
finding and reconstructing the impacts, fitting); without one the line says "working". The line is
cut to the terminal's width and erased with spaces between carriage returns (no escape sequence,
which an old console would print).

Only on a terminal: when stderr is a file or a pipe (logs, CI, tests) nothing is written, so the
output of a command is unchanged. A line that another writer left open (the compile notice of
:mod:`impactid.compilation` draws its own progress, a progress bar) is never drawn over.
``IMPACTID_PROGRESS=0`` turns the status line off. Writes to ``sys.stdout.buffer`` bypass it (no
command writes there while it runs).
"""

from __future__ import annotations

import os
import shutil
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import TextIO

__all__ = ["QUIET_S", "TICK_S", "StatusLine", "running", "stage"]

#: Seconds without output after which the status line appears.
QUIET_S = 1.0
#: Seconds between two updates of the status line.
TICK_S = 0.5



def _erase(length: int) -> str:
    """Carriage return, spaces over ``length`` characters, carriage return: no terminal escape sequence,
    so that every console erases it (a console without ANSI support would print ``\\033[K``)."""
    return "\r" + " " * length + "\r" if length else ""


class _Watched:
    """A text stream whose writes first erase the status line and are then noted by it."""

    def __init__(self, stream: TextIO, status: StatusLine) -> None:
        self._stream = stream
        self._status = status

    def write(self, text: str) -> int:
        with self._status.lock:
            self._status.erase()
            written = self._stream.write(text)
            self._status.noted(text)
            return written

    def __getattr__(self, name: str):
        return getattr(self._stream, name)


class StatusLine:
    """The status line of one command on ``stream`` (a terminal).

    Parameters
    ----------
    command : the command's name, first word of the line.
    stream : where the line is drawn (stderr).
    quiet : seconds without output before the line appears.
    tick : seconds between updates.
    clock : time source [s].
    """

    def __init__(self, command: str, stream: TextIO, *, quiet: float = QUIET_S, tick: float = TICK_S,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.command = command
        self.lock = threading.RLock()
        self._stream = stream
        self._quiet = quiet
        self._tick = tick
        self._clock = clock
        self._start = self._last = clock()
        self._open = False  # another writer's line is not ended
        self._drawn = 0  # length of the drawn line (0: none)
        self._stage = "working"
        self._done = threading.Event()
        self._thread: threading.Thread | None = None

    def text(self) -> str:
        """The line's text now, cut to the terminal's width (a wrapped line could not be erased)."""
        text = f"impactid: {self.command}: {self._stage} ({self._clock() - self._start:.0f} s)"
        width = max(shutil.get_terminal_size(fallback=(80, 24)).columns - 1, 10)
        return text if len(text) <= width else text[: width - 3] + "..."

    def set_stage(self, what: str) -> None:
        with self.lock:
            self._stage = what

    def erase(self) -> None:
        """Erase the drawn line (the caller holds :attr:`lock`)."""
        if self._drawn:
            self._stream.write(_erase(self._drawn))
            self._drawn = 0

    def noted(self, text: str) -> None:
        """Something was written (the caller holds :attr:`lock`)."""
        if text:
            self._last = self._clock()
            self._open = not text.endswith("\n")

    def draw(self) -> None:
        """Draw or update the line if the output has been quiet long enough and no other line is open."""
        with self.lock:
            if self._open or self._clock() - self._last < self._quiet:
                return
            text = self.text()
            try:
                self._stream.write(_erase(self._drawn) + text)
                self._stream.flush()
            except (OSError, ValueError):
                return
            self._drawn = len(text)

    def _run(self) -> None:
        while not self._done.wait(self._tick):
            self.draw()

    def start(self) -> None:
        self._thread = threading.Thread(target=self._run, name="impactid-status", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._done.set()
        if self._thread is not None:
            self._thread.join()
        with self.lock:
            try:
                self.erase()
                self._stream.flush()
            except (OSError, ValueError):
                pass


_CURRENT: list[StatusLine] = []


def enabled(stream: TextIO, environ=os.environ) -> bool:
    """Whether a status line is drawn: ``stream`` is a terminal and ``IMPACTID_PROGRESS`` is not 0/false/no/off."""
    if environ.get("IMPACTID_PROGRESS", "1").strip().lower() in {"0", "false", "no", "off"}:
        return False
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


@contextmanager
def running(command: str) -> Iterator[StatusLine | None]:
    """Show the status line of ``command`` while the block runs (when stderr is a terminal)."""
    if not enabled(sys.stderr):
        yield None
        return
    status = StatusLine(command, sys.stderr)
    stdout, stderr = sys.stdout, sys.stderr
    sys.stdout, sys.stderr = _Watched(stdout, status), _Watched(stderr, status)
    _CURRENT.append(status)
    status.start()
    try:
        yield status
    finally:
        status.stop()
        _CURRENT.remove(status)
        sys.stdout, sys.stderr = stdout, stderr


def stage(what: str) -> None:
    """Name what the running command does now ("reading the recordings"); nothing without a status line."""
    if _CURRENT:
        _CURRENT[-1].set_stage(what)

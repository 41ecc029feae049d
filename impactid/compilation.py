"""What impactid says while numba compiles a kernel on first use.

A kernel is compiled the first time a command runs it and loaded from numba's cache afterwards
(:mod:`impactid._cachedir` says where). The compilation of a whole simulator takes seconds to tens
of seconds (docs/performance_cold_start.md), during which the command would otherwise print
nothing. So each compilation that is not a load from the cache prints one line on stderr, when it
starts, saying what is compiled and for about how long::

    impactid: compiling rig P's simulator (first use; about 35 s, cached afterwards) ...... done in 38 s

and shows progress while it runs, at least every :data:`TICK_S` seconds: on a terminal a bar
rewritten in place (``[######----] 12 s of about 35 s``), elsewhere (a log, a pipe, CI) a dot
appended to the line, so that the line stays one line and the output is never silent for longer
than :data:`TICK_S`. The line is ended (``done in N s``) when the compilation returns.

What counts as one compilation: the outermost numba compilation of a function of impactid (numba
compiles a kernel's callees inside it, and those are part of it); a cache hit is no compilation
(numba does not report it). The label and the expected time come from :data:`KERNELS` (by the
kernel's module); the expected time is a CPU time measured on an idle machine, and a busy machine
takes longer. ``IMPACTID_COMPILE_NOTICE=0`` turns the notice off (``impactid warmup`` prints its
own lines).

This module is imported by every kernel module (before any of their functions is compiled) and
installs the notice once per process (:func:`install`). It imports numba's event API only (no
kernel), so that the kernel modules can import it without a cycle.
"""

from __future__ import annotations

import os
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TextIO

from numba.core import event

from impactid import _kernel_cache

__all__ = ["KERNELS", "TICK_S", "KernelGroup", "Notice", "group_of", "install", "notice_enabled"]

#: Longest silence, in seconds, of the notice while a compilation runs.
TICK_S = 1.0


@dataclass(frozen=True)
class KernelGroup:
    """The kernels of one module, as the notice names them.

    Attributes
    ----------
    label : what is compiled, for the user ("rig P's simulator").
    seconds : about how long a cold compilation of the module's kernels takes [s] (CPU on an idle
        machine, from docs/performance_cold_start.md).
    """

    label: str
    seconds: float


#: The kernel modules, by module name, with what the notice calls them and their cold compile time
#: (CPU of ``impactid warmup --rig NAME`` from an empty cache, docs/simulator.md "Compile time").
KERNELS: dict[str, KernelGroup] = {
    "impactid.rigs.pivoted.kernel": KernelGroup("rig P's simulator", 35.0),
    "impactid.rigs.pivoted.freeflight": KernelGroup("rig P's free flight", 2.0),
    "impactid.rigs.pivoted.reconstruct": KernelGroup("rig P's impact reconstruction", 2.0),
    "impactid.rigs.flat.kernel": KernelGroup("rig F's simulator", 10.0),
    "impactid.rigs.drop.kernel": KernelGroup("the drop rig's simulator", 45.0),
    "impactid.rigs.finger_follower.kernel": KernelGroup("the finger-follower simulator", 17.0),
    "impactid.rigs.cycloidal.kernel": KernelGroup("the cycloidal valve-train simulator", 14.0),
    "impactid._scan": KernelGroup("the recording checks", 2.0),
    "impactid.events": KernelGroup("the event detector", 1.0),
    "impactid.signal": KernelGroup("the signal integrals", 1.0),
    "impactid.simulate.dp5": KernelGroup("the integrator core", 1.0),
}


def group_of(module: str) -> KernelGroup:
    """The group a function of ``module`` belongs to (a generic one for a module not in :data:`KERNELS`)."""
    group = KERNELS.get(module)
    if group is not None:
        return group
    parent = module.rsplit(".", 1)[0]
    return KernelGroup(f"{parent.removeprefix('impactid.').replace('rigs.', 'rig ')}'s compiled functions", 2.0)


def notice_enabled(environ=os.environ) -> bool:
    """Whether the notice prints (``IMPACTID_COMPILE_NOTICE`` not 0, false, no or off)."""
    return environ.get("IMPACTID_COMPILE_NOTICE", "1").strip().lower() not in {"0", "false", "no", "off"}


class Notice:
    """The one line of a compilation and its progress, on ``stream`` (stderr when it is None).

    Parameters
    ----------
    group : what is compiled.
    first : True for the group's first compilation in the process (the line then says how long the
        whole group takes); later ones say "more of" it.
    stream : where to write (default: ``sys.stderr`` at the time of writing).
    tty : bar rewritten in place (True) or dots (False); default: whether ``stream`` is a terminal.
    tick : seconds between two progress updates.
    clock : the time source [s] (tests pass their own).
    """

    def __init__(self, group: KernelGroup, *, first: bool = True, stream: TextIO | None = None,
                 tty: bool | None = None, tick: float = TICK_S, clock: Callable[[], float] = time.monotonic) -> None:
        self.group = group
        self.first = first
        self._stream = stream
        self._tick = tick
        self._clock = clock
        self._tty = tty
        self._start = clock()
        self._done = threading.Event()
        self._thread: threading.Thread | None = None
        self._lock = threading.Lock()

    @property
    def stream(self) -> TextIO:
        return self._stream if self._stream is not None else sys.stderr

    @property
    def tty(self) -> bool:
        if self._tty is None:
            try:
                self._tty = bool(self.stream.isatty())
            except (AttributeError, ValueError):
                self._tty = False
        return self._tty

    def header(self) -> str:
        """The line's text before any progress."""
        g = self.group
        if self.first:
            return f"impactid: compiling {g.label} (first use; about {g.seconds:.0f} s, cached afterwards)"
        return f"impactid: compiling more of {g.label} (first use, cached afterwards)"

    def bar(self, elapsed: float, width: int = 20) -> str:
        """The terminal's progress bar after ``elapsed`` seconds (full at the expected time, then waiting)."""
        fraction = min(elapsed / self.group.seconds, 1.0) if self.group.seconds > 0 else 1.0
        filled = int(round(fraction * width))
        return f"[{'#' * filled}{'-' * (width - filled)}] {elapsed:.0f} s of about {self.group.seconds:.0f} s"

    def _write(self, text: str) -> None:
        with self._lock:
            try:
                self.stream.write(text)
                self.stream.flush()
            except (OSError, ValueError):  # a closed stream: the notice is not worth an error
                pass

    def start(self) -> None:
        """Print the line and start the progress (a daemon thread)."""
        self._write(self.header() + (" " + self.bar(0.0) if self.tty else " "))
        self._thread = threading.Thread(target=self._run, name="impactid-compile-notice", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._done.wait(self._tick):
            elapsed = self._clock() - self._start
            self._write(f"\r{self.header()} {self.bar(elapsed)}" if self.tty else ".")

    def finish(self) -> float:
        """End the progress and the line (``done in N s``); returns the seconds taken."""
        self._done.set()
        if self._thread is not None:
            self._thread.join()
        elapsed = self._clock() - self._start
        if self.tty:
            self._write(f"\r{self.header()} {self.bar(elapsed)}, done\n")
        else:
            self._write(f" done in {elapsed:.0f} s\n")
        return elapsed


class _Listener(event.Listener):
    """numba's ``numba:compile`` events (a cache miss): a :class:`Notice` for each outermost one of impactid."""

    def __init__(self) -> None:
        self._local = threading.local()
        self._seen: set[str] = set()

    def on_start(self, ev: event.Event) -> None:
        depth = getattr(self._local, "depth", 0)
        self._local.depth = depth + 1
        if depth or not notice_enabled():
            return
        module = _module_of(ev)
        if not module.startswith("impactid."):
            return
        group = group_of(module)
        notice = Notice(group, first=group.label not in self._seen)
        self._seen.add(group.label)
        self._local.notice = notice
        notice.start()

    def on_end(self, ev: event.Event) -> None:
        self._local.depth = max(getattr(self._local, "depth", 1) - 1, 0)
        if self._local.depth == 0:
            notice = getattr(self._local, "notice", None)
            self._local.notice = None
            if notice is not None:
                notice.finish()


def _module_of(ev: event.Event) -> str:
    data = ev.data if isinstance(ev.data, dict) else {}
    function = getattr(data.get("dispatcher"), "py_func", None)
    return getattr(function, "__module__", None) or ""


_INSTALLED: list[_Listener] = []


def install() -> None:
    """Install the notice and the kernel cache's locators (once per process; the kernel modules call it when imported).

    The locators (:mod:`impactid._kernel_cache`: kernels compiled at installation, a cache stamped by
    the source's content) must be in place before a module defines its ``cache=True`` kernels, so
    every kernel module calls this first.
    """
    _kernel_cache.install()
    if not _INSTALLED:
        listener = _Listener()
        event.register("numba:compile", listener)
        _INSTALLED.append(listener)

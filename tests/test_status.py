"""The status line of a silent command on a terminal (impactid._status)."""

from __future__ import annotations

import io
import os
import pty
import re
import subprocess
import sys
import time

import pytest

from impactid import _status


class _Clock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def _line(clock: _Clock) -> tuple[_status.StatusLine, io.StringIO]:
    stream = io.StringIO()
    return _status.StatusLine("estimate", stream, quiet=1.0, tick=0.5, clock=clock), stream


def test_the_line_appears_after_a_quiet_second_and_says_the_stage():
    clock = _Clock()
    status, stream = _line(clock)
    clock.now = 0.5
    status.draw()
    assert stream.getvalue() == ""  # not quiet long enough
    clock.now = 1.2
    status.set_stage("fitting the contact law")
    status.draw()
    assert stream.getvalue() == "impactid: estimate: fitting the contact law (1 s)"


def test_output_erases_the_line_first_and_is_written_unchanged():
    clock = _Clock()
    status, stream = _line(clock)
    out = io.StringIO()
    watched = _status._Watched(out, status)
    clock.now = 2.0
    status.draw()
    watched.write("beta = 2.4e10\n")
    drawn = "impactid: estimate: working (2 s)"
    assert stream.getvalue() == drawn + "\r" + " " * len(drawn) + "\r"  # erased on its own stream, no escape code
    assert out.getvalue() == "beta = 2.4e10\n"
    status.draw()  # output a moment ago: quiet again
    assert stream.getvalue().count("impactid: estimate") == 1


def test_a_line_left_open_by_another_writer_is_not_drawn_over():
    clock = _Clock()
    status, stream = _line(clock)
    watched = _status._Watched(stream, status)
    watched.write("impactid: compiling rig P's simulator (first use; about 35 s) ")
    clock.now = 10.0
    status.draw()
    assert "impactid: estimate" not in stream.getvalue()
    watched.write(" done in 30 s\n")
    clock.now = 12.0
    status.draw()
    assert stream.getvalue().endswith("impactid: estimate: working (12 s)")


def test_stop_erases_the_line():
    clock = _Clock()
    status, stream = _line(clock)
    clock.now = 3.0
    status.draw()
    status.stop()
    assert stream.getvalue() == "impactid: estimate: working (3 s)\r" + " " * 33 + "\r"


def test_the_line_is_cut_to_the_terminal_width(monkeypatch):
    monkeypatch.setattr(_status.shutil, "get_terminal_size", lambda fallback: os.terminal_size((30, 24)))
    clock = _Clock()
    status, stream = _line(clock)
    status.set_stage("finding and reconstructing the impacts of recording 2 of 2")
    clock.now = 5.0
    status.draw()
    assert len(stream.getvalue()) == 29 and stream.getvalue().endswith("...")


def test_nothing_is_drawn_off_a_terminal_or_when_turned_off():
    assert not _status.enabled(io.StringIO())

    class Tty(io.StringIO):
        def isatty(self) -> bool:
            return True

    assert _status.enabled(Tty(), environ={})
    assert not _status.enabled(Tty(), environ={"IMPACTID_PROGRESS": "0"})
    with _status.running("estimate") as status:  # pytest's stderr is no terminal
        assert status is None


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs a pseudo-terminal")
def test_a_command_on_a_terminal_is_never_silent_for_long_and_its_output_is_unchanged(tmp_path):
    """`impactid synth` (seconds of work, one line at the end) with stderr on a pseudo-terminal."""
    out = tmp_path / "s.h5"
    command = [sys.executable, "-c", "import sys, impactid_console; sys.exit(impactid_console.main())",
               "synth", "--rig", "pivoted-follower", "--e-over-rc", "0.05", "--cam-speed", "15", "--duration", "0.5",
               "--out", str(out)]
    master, slave = pty.openpty()
    env = {**os.environ, "IMPACTID_COMPILE_NOTICE": "0"}
    proc = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=slave, env=env, cwd=tmp_path)
    os.close(slave)
    stamps, shown = [time.perf_counter()], bytearray()
    while True:
        try:
            data = os.read(master, 4096)
        except OSError:
            break
        if not data:
            break
        stamps.append(time.perf_counter())
        shown += data
    stdout = proc.communicate()[0].decode()
    os.close(master)
    assert proc.returncode == 0, shown.decode(errors="replace")
    text = shown.decode(errors="replace")
    if stamps[-1] - stamps[0] > 2.0:  # a run long enough to be silent: the line was drawn, then erased
        assert "impactid: synth: working" in text
        assert re.search(r"\r +\r$", text)
    assert "impactid: synth" not in stdout and out.exists()

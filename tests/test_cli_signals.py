"""Ctrl-C and SIGTERM at any moment of a command's life, including while Python is still importing
its modules: one line ``impactid: error: ...``, exit 130 or 143, no traceback."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

LAUNCH = [sys.executable, "-c", "import sys; from impactid._launcher import main; sys.exit(main())"]


def _run_and_signal(args, sig, delay):
    proc = subprocess.Popen([*LAUNCH, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env={**os.environ, "PYTHONUNBUFFERED": "1"})
    time.sleep(delay)
    assert proc.poll() is None, "the command ended before the signal: the test needs a longer one"
    proc.send_signal(sig)
    out, err = proc.communicate(timeout=120)
    return proc.returncode, out, err


@pytest.mark.parametrize("sig, code, word", [(signal.SIGINT, 130, "interrupted"), (signal.SIGTERM, 143, "terminated")])
@pytest.mark.parametrize("delay", [0.15, 0.4, 0.8, 1.5])
def test_a_signal_while_starting_ends_in_one_line(sig, code, word, delay, tmp_path):
    # a 30 s synthetic recording takes several seconds of CPU, far longer than the latest signal: the signal
    # lands while Python imports the modules, while the parser is built, or while the command runs, and
    # each ends in the one line
    returncode, out, err = _run_and_signal(["synth", "--e-over-rc", "0.2", "--cam-speed", "16", "--duration", "30",
                                            "--out", str(tmp_path / "s.h5")], sig, delay)
    assert "Traceback" not in err, err
    assert returncode == code, (returncode, err, out, sorted(p.name for p in tmp_path.iterdir()))
    lines = [line for line in err.splitlines() if line.strip()]
    assert lines and lines[-1].startswith(f"impactid: error: {word}"), err
    assert sum(line.startswith("impactid: error:") for line in lines) == 1, err
    assert not list(tmp_path.iterdir())  # no partial output


@pytest.mark.parametrize("sig, expected", [(signal.SIGINT, KeyboardInterrupt), (signal.SIGTERM, None)])
def test_a_stop_whose_exception_was_lost_still_keeps_the_outputs_out(sig, expected, tmp_path):
    """Python drops an exception raised in a finalizer: the stop's arrival, recorded before the
    handler raises, still keeps every output of the job from being put in place."""
    from impactid._files import StagedFiles, TerminationRequested
    from impactid._signals import arrived_stop, forget_stops, stopping_handler

    class Lost(Exception):
        pass

    def stop(signum):
        raise Lost()

    handler = stopping_handler(stop, lambda signum: "stopped")
    forget_stops()
    try:
        with pytest.raises(Lost):
            handler(sig, sys._getframe())  # the exception a finalizer would have swallowed
        assert arrived_stop() == sig
        out = tmp_path / "result.json"
        with pytest.raises(expected or TerminationRequested):
            with StagedFiles() as staged:
                staged.write_text(out, "{}")
        assert not list(tmp_path.iterdir())  # neither the output nor its temporary file
    finally:
        forget_stops()
    assert arrived_stop() is None


def test_a_closed_stdout_ends_quietly(monkeypatch, capsys):
    """`impactid ... | head`: the reader went away; no error line, the shell's status for SIGPIPE."""
    from impactid import cli

    def closed(args):
        raise BrokenPipeError(32, "Broken pipe")

    parser = cli.build_parser()
    args = parser.parse_args(["regime", "--e-over-rc", "0.2", "--cam-speed", "16"])
    monkeypatch.setattr(args, "func", closed)
    monkeypatch.setattr(cli.build_parser().__class__, "parse_args", lambda self, argv=None: args)
    assert cli.main(["regime"]) == cli.EXIT_BROKEN_PIPE
    assert capsys.readouterr().err == ""


def test_a_stop_inside_numba_waits_until_it_returns():
    """A signal that lands in numba's or llvmlite's Python code is not raised there (an exception
    unwinding through LLVM's callbacks crashed the process); it is raised a moment later, outside."""
    from impactid._signals import arrived_stop, forget_stops, in_native_machinery, stopping_handler

    class Stop(Exception):
        pass

    calls = []

    def stop(signum):
        calls.append(signum)
        raise Stop()

    handler = stopping_handler(stop, lambda signum: "stopped")
    namespace: dict = {}
    exec(compile("import sys\ndef inside():\n    return sys._getframe()\n", "/site-packages/numba/core/fake.py",
                 "exec"), namespace)
    frame = namespace["inside"]()
    assert in_native_machinery(frame) and not in_native_machinery(sys._getframe())
    previous = signal.signal(signal.SIGUSR1, handler)
    try:
        handler(signal.SIGUSR1, frame)  # inside: nothing raised, a retry is on its way
        assert calls == []
        with pytest.raises(Stop):
            time.sleep(5)  # the retry lands here, outside numba: the stop is raised
        assert calls == [signal.SIGUSR1]
        assert arrived_stop() is None  # a signal other than SIGINT and SIGTERM stops no command's outputs
    finally:
        signal.signal(signal.SIGUSR1, previous)
        forget_stops()


@pytest.mark.parametrize("sig, code, word", [(signal.SIGINT, 130, "interrupted"), (signal.SIGTERM, 143, "terminated")])
def test_a_signal_before_the_package_has_loaded_is_acted_on_in_one_line(sig, code, word):
    """The console script's first module (``impactid_console``) records a stop signal before the package
    ``impactid`` loads (a Ctrl-C there was a traceback, a SIGTERM a silent exit -15); the launcher acts on it
    once its own handlers are in place. Sent here right after that module's import, deterministically."""
    code_text = ("import os, signal, sys\n"
                 "import impactid_console\n"
                 f"os.kill(os.getpid(), {int(sig)})\n"
                 "sys.argv = ['impactid', 'info', '--help']\n"
                 "sys.exit(impactid_console.main())\n")
    proc = subprocess.run([sys.executable, "-c", code_text], capture_output=True, text=True, timeout=120)
    assert proc.returncode == code, (proc.returncode, proc.stderr)
    assert proc.stderr.strip().splitlines() == [f"impactid: error: {word} " + proc.stderr.split(word, 1)[1].strip()]
    assert "usage" not in proc.stdout  # the command did not run


def test_the_console_script_starts_with_the_recording_module():
    """The installed ``impactid`` script imports ``impactid_console`` (its handlers come before the package)."""
    from importlib.metadata import entry_points

    (script,) = [e for e in entry_points(group="console_scripts") if e.name == "impactid"]
    assert script.value == "impactid_console:main"

"""Ctrl-C during ``impactid campaign`` on a local cluster: one line, exit 130, no traceback.

The terminal sends SIGINT to every process of its foreground process group, the cluster's worker
processes included. They start with SIGINT blocked and ignore it, and this process closes the
cluster (impactid.distributed._cluster_start); the slow test sends SIGINT to the whole process group
of a real ``impactid campaign`` while its tasks run, as a Ctrl-C at the terminal does.
"""

from __future__ import annotations

import multiprocessing
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from impactid.distributed import _cluster_start
from tests import test_campaign as _campaign_tests

recordings = _campaign_tests.recordings  # the session fixture of the rig P recordings (a, b)


def test_processes_started_with_a_cluster_never_see_ctrl_c_and_this_process_acts_on_it_after():
    """The mechanism, without dask: a process spawned (as dask's nanny spawns a worker) from a thread
    started inside the block has SIGINT blocked from its start; a Ctrl-C here during the block is
    held until the caller can close what it started, then raised."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    exitcodes: list[int | None] = []

    def spawn_a_worker() -> None:
        # the child raises SIGINT in itself: blocked, it stays pending and the child ends normally;
        # acted on, the child dies of a KeyboardInterrupt (exit code 1)
        child = multiprocessing.get_context("spawn").Process(target=signal.raise_signal, args=(signal.SIGINT,))
        child.start()
        child.join(120)
        exitcodes.append(child.exitcode)

    try:
        with _cluster_start() as deferred:
            os.kill(os.getpid(), signal.SIGINT)  # a Ctrl-C while the cluster starts: not raised here
            spawner = threading.Thread(target=spawn_a_worker)
            spawner.start()
            spawner.join(180)
        assert exitcodes == [0]
        assert deferred.received == [signal.SIGINT]
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler  # restored
        assert signal.SIGINT not in signal.pthread_sigmask(signal.SIG_BLOCK, [])
        with pytest.raises(KeyboardInterrupt):
            deferred.deliver()  # once the cluster is in hand (and closed by the caller's finally)
    finally:
        signal.signal(signal.SIGINT, previous)


def _group_alive(pgid: int) -> list[int]:
    """The processes of a process group that are still running (zombies left out)."""
    alive = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[2]) == pgid and fields[0] != "Z":
                alive.append(int(entry.name))
    return alive


def _sigint_blocked_or_ignored(pid: int) -> bool:
    """Whether a process has SIGINT blocked (in its main thread) or ignored."""
    masks = dict(line.split(":", 1) for line in Path(f"/proc/{pid}/status").read_text().splitlines() if ":" in line)
    bit = 1 << (signal.SIGINT - 1)
    return bool((int(masks["SigBlk"], 16) | int(masks["SigIgn"], 16)) & bit)


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads the process table from /proc")
def test_ctrl_c_during_a_campaign_on_a_local_cluster_is_one_line_and_exit_130(tmp_path, recordings):
    pytest.importorskip("distributed")
    folder = tmp_path / "recordings"
    folder.mkdir()
    for name in ("a", "b"):
        shutil.copy(recordings[name], folder / f"{name}.h5")
    out, err = tmp_path / "out", tmp_path / "stderr.txt"
    command = [sys.executable, "-m", "impactid.cli", "campaign", str(folder), "--out", str(out), "--workers", "2",
               "--no-progress"]
    with err.open("w") as stderr:
        # a process group of its own, as a terminal's foreground job: os.killpg reaches it and its workers
        process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=stderr, start_new_session=True)
        try:
            deadline = time.monotonic() + 600
            while "fit tasks on a local cluster" not in err.read_text() and process.poll() is None:
                assert time.monotonic() < deadline, "the campaign did not start its tasks in 10 minutes"
                time.sleep(0.1)
            # the workers (and multiprocessing's resource tracker) neither act on SIGINT nor can
            children = [pid for pid in _group_alive(process.pid) if pid != process.pid]
            assert len(children) >= 2 and all(_sigint_blocked_or_ignored(pid) for pid in children)
            # Ctrl-C at the terminal, as the tasks start: every process of the group gets SIGINT
            os.killpg(process.pid, signal.SIGINT)
            process.communicate(timeout=300)
        finally:
            if process.poll() is None:
                os.killpg(process.pid, signal.SIGKILL)
                process.wait()
    lines = err.read_text().splitlines()
    assert process.returncode == 130, lines
    assert not any("Traceback" in line or "KeyboardInterrupt" in line for line in lines), lines
    assert [line for line in lines if line.startswith("impactid:")] == [
        "impactid: error: interrupted (Ctrl-C); outputs not completed were not written"]
    assert all(line.startswith(("impactid campaign: ", "impactid: error: ")) for line in lines), lines
    # no partial output: no summary table, no temporary file
    assert not (out / "campaign.csv").exists() and not (out / "campaign.parquet").exists()
    assert not [p for p in out.rglob("*") if ".tmp" in p.name]
    # and no worker left behind
    deadline = time.monotonic() + 60
    while _group_alive(process.pid) and time.monotonic() < deadline:
        time.sleep(0.2)
    assert not _group_alive(process.pid)

"""Repository-wide test configuration (the root, so that it sees the items of every test path).

* Executed notebooks (nbmake items collected from ``notebooks/``) are slow tests: ``pytest -m "not slow"``
  is the warm loop of under a minute; CI runs everything. The hook lives here and not in
  ``tests/conftest.py`` because a conftest below the root is not loaded for a run of ``notebooks/`` alone.
* **numba's cache is compiled once, before the workers start, and the run says so.** On a fresh
  installation every compiled kernel is compiled on first use (the rig P integrator alone takes about a
  minute per entry point), and two xdist workers that start on the same rig both compile it, at the same
  time: half the CPU of the first minutes goes into compiling twice. When the whole suite runs on
  several workers and the cache is cold, the controller first runs a few tests that touch every kernel,
  in two processes at once (one per family of kernels), so that the workers load the kernels from the
  cache. The warm-up's outcome is ignored (the real run reports any failure); ``IMPACTID_NO_WARMUP=1``
  turns it off. It prints a line when it starts, one per family compiled and a heartbeat every
  :data:`WARMUP_HEARTBEAT` seconds, so that pytest's first line comes within seconds of the start and
  the run never sits silent.
"""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

#: The warm-up, per family of kernels: a file of numba's cache that is there once the family is
#: compiled (a glob relative to the package), and tests that compile the family and do little else.
WARMUP_GROUPS = (
    ("rigs/pivoted/__pycache__/kernel.integrate-*.nbi",
     ("tests/rigs/pivoted/test_runs.py::test_batch_equals_single_events",
      "tests/rigs/pivoted/test_reconstruct.py::test_onsets_within_one_sample")),
    ("rigs/cycloidal/__pycache__/kernel.integrate_a-*.nbi",
     ("tests/rigs/cycloidal/test_simulate.py::test_level_b_static_state",
      "tests/rigs/cycloidal/test_simulate.py::test_level_a_quasistatic_limit")),
    ("rigs/finger_follower/__pycache__/kernel.evaluate-*.nbi",
     ("tests/rigs/finger_follower/test_simulate.py::test_rest_on_the_base_circle_stays_at_rest",)),
    ("rigs/flat/__pycache__/kernel.integrate-*.nbi",
     ("tests/rigs/flat/test_simulate.py::test_free_start_matches_reference",)),
    ("rigs/drop/__pycache__/kernel.replay-*.nbi",
     ("tests/rigs/drop/test_kernel.py::test_kernel_matches_reference",
      "tests/rigs/drop/test_identify.py::test_noise_free_recovery")),
)


def _cold_groups() -> list[tuple[str, tuple[str, ...]]]:
    """The warm-up groups (family name, tests) whose kernels are not in numba's cache (without
    importing impactid)."""
    spec = importlib.util.find_spec("impactid")
    if spec is None or spec.origin is None:
        return []
    package = Path(spec.origin).parent
    # where the kernels are cached: NUMBA_CACHE_DIR, else IMPACTID_CACHE_DIR/numba (impactid._cachedir; a
    # read-only installation's user folder is set as NUMBA_CACHE_DIR when impactid is imported)
    cache_dir = os.environ.get("NUMBA_CACHE_DIR") or (
        os.environ.get("IMPACTID_CACHE_DIR") and str(Path(os.environ["IMPACTID_CACHE_DIR"]) / "numba"))
    cold = []
    for marker, tests in WARMUP_GROUPS:
        if cache_dir:  # numba then reads and writes only there
            warm = Path(cache_dir).is_dir() and next(Path(cache_dir).rglob(Path(marker).name), None) is not None
        else:
            warm = next(package.glob(marker), None) is not None
        if not warm:
            cold.append((marker.split("/__pycache__")[0], tests))
    return cold


#: Seconds between two progress lines of the warm-up.
WARMUP_HEARTBEAT = 20.0


def pytest_sessionstart(session):
    config = session.config
    if hasattr(config, "workerinput") or os.environ.get("IMPACTID_NO_WARMUP") == "1":
        return  # an xdist worker, or a warm-up process itself
    workers = getattr(config.option, "numprocesses", None)
    if not isinstance(workers, int) or workers < 2 or config.option.file_or_dir:
        return  # one process, or a chosen subset of the tests
    cold = _cold_groups()
    if not cold:
        return
    reporter = config.pluginmanager.get_plugin("terminalreporter")

    def say(text: str) -> None:
        if reporter is not None:
            reporter.write_line(text, flush=True)
        else:
            print(text, file=sys.__stderr__, flush=True)

    say(f"impactid: compiling the numba kernels of {len(cold)} rig famil{'y' if len(cold) == 1 else 'ies'} once, "
        f"before the workers start (first run of a fresh installation: a few minutes; later runs load them "
        f"from numba's cache; IMPACTID_NO_WARMUP=1 skips this)")
    root = Path(__file__).resolve().parent
    env = {**os.environ, "IMPACTID_NO_WARMUP": "1", "IMPACTID_COMPILE_NOTICE": "0"}
    command = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "no:xdist", "-o", "addopts=",
               "--no-header"]
    # one process per family, as many at a time as there are workers; a line when each is done and
    # a heartbeat in between, so that the run never sits silent
    waiting, running, done = list(cold), {}, 0
    started = time.monotonic()
    last_line = started
    while waiting or running:
        while waiting and len(running) < workers:
            family, tests = waiting.pop(0)
            running[family] = (subprocess.Popen([*command, *tests], cwd=root, env=env, stdout=subprocess.DEVNULL,
                                                stderr=subprocess.DEVNULL), time.monotonic())
        time.sleep(0.5)
        for family, (proc, t0) in list(running.items()):
            if proc.poll() is not None:
                del running[family]
                done += 1
                last_line = time.monotonic()
                say(f"impactid: {family} compiled ({last_line - t0:.0f} s; {done} of {len(cold)})")
        if time.monotonic() - last_line >= WARMUP_HEARTBEAT:
            last_line = time.monotonic()
            say(f"impactid: still compiling {', '.join(running)} ({last_line - started:.0f} s so far)")


def pytest_collection_modifyitems(config, items):
    slow = pytest.mark.slow
    for item in items:
        if item.path.suffix == ".ipynb":
            item.add_marker(slow)

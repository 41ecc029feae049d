"""Repository-wide test configuration (the root, so that it sees the items of every test path).

* Executed notebooks (nbmake items collected from ``notebooks/``) are slow tests: ``pytest -m "not slow"``
  is the warm loop of under a minute; CI runs everything. The hook lives here and not in
  ``tests/conftest.py`` because a conftest below the root is not loaded for a run of ``notebooks/`` alone.
* **numba's cache is compiled once, before the workers start.** On a fresh installation every compiled
  kernel is compiled on first use (the rig P integrator alone takes about a minute per entry point), and
  two xdist workers that start on the same rig both compile it, at the same time: half the CPU of the
  first minutes goes into compiling twice. When the whole suite runs on several workers and the cache
  is cold, the controller first runs a few tests that touch every kernel, in two processes at once (one
  per family of kernels), so that the workers load the kernels from the cache. The warm-up's outcome is
  ignored (the real run reports any failure); ``IMPACTID_NO_WARMUP=1`` turns it off.
"""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import pytest

#: The warm-up, per family of kernels: a file of numba's cache that is there once the family is
#: compiled (a glob relative to the package), and tests that compile the family and do little else.
WARMUP_GROUPS = (
    ("rigs/pivoted/__pycache__/kernel.integrate-*.nbi",
     ("tests/simulate/test_simulator.py::test_batch_equals_single_events",
      "tests/test_reconstruct.py::test_onsets_within_one_sample")),
    ("rigs/cycloidal/__pycache__/kernel.integrate_a-*.nbi",
     ("tests/rigs/cycloidal/test_simulate.py::test_level_b_static_state",
      "tests/rigs/cycloidal/test_simulate.py::test_level_a_quasistatic_limit")),
    ("rigs/finger_follower/__pycache__/kernel.evaluate-*.nbi",
     ("tests/rigs/finger_follower/test_simulate.py::test_rest_on_the_base_circle_stays_at_rest",)),
    ("rigs/flat/__pycache__/kernel.integrate-*.nbi",
     ("tests/simulate/test_flat_simulator.py::test_free_start_matches_reference",)),
)


def _cold_groups() -> list[tuple[str, ...]]:
    """The tests of the warm-up groups whose kernels are not in numba's cache (without importing impactid)."""
    spec = importlib.util.find_spec("impactid")
    if spec is None or spec.origin is None:
        return []
    package = Path(spec.origin).parent
    cache_dir = os.environ.get("NUMBA_CACHE_DIR")
    cold = []
    for marker, tests in WARMUP_GROUPS:
        if next(package.glob(marker), None) is None and not (
                cache_dir and Path(cache_dir).is_dir() and next(Path(cache_dir).rglob(Path(marker).name), None)):
            cold.append(tests)
    return cold


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
    # the cold groups shared out over as many processes as there are workers
    shares = [sum(cold[k::workers], ()) for k in range(min(workers, len(cold)))]
    root = Path(__file__).resolve().parent
    env = {**os.environ, "IMPACTID_NO_WARMUP": "1"}
    command = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "no:xdist", "-o", "addopts=",
               "--no-header"]
    procs = [subprocess.Popen([*command, *tests], cwd=root, env=env, stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL) for tests in shares]
    for proc in procs:
        proc.wait()


def pytest_collection_modifyitems(config, items):
    slow = pytest.mark.slow
    for item in items:
        if item.path.suffix == ".ipynb":
            item.add_marker(slow)

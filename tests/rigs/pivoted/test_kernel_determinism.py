"""Rig P's kernels give the same bits whether they were just compiled or loaded from numba's cache.

A kernel compiled with a fast-math flag (FMA contraction) and called by symbol has two compilations that
differ at round-off (its own, and the copy linked into its caller and optimised again there), and which one
runs depended on what the process had compiled or loaded before: a fresh compilation and a cached one of the
same run parted after 1 s of simulated time (``impactid.rigs.pivoted.kernel._STEP_FLAGS``). Every kernel
compiled with a fast-math flag is therefore inlined into its callers (``forceinline``).
"""

from __future__ import annotations

import os
import subprocess
import sys

import pytest
from numba.core.registry import CPUDispatcher

from impactid.rigs.pivoted import kernel as K


def _dispatchers() -> dict[str, CPUDispatcher]:
    return {name: obj for name, obj in vars(K).items() if isinstance(obj, CPUDispatcher)}


def test_the_step_functions_are_compiled_with_contraction():
    fast = {name for name, d in _dispatchers().items() if d.targetoptions.get("fastmath")}
    assert {"_dp5_step", "_initial_step", "_sensitivity_step", "_stage", "_begin", "_sensitivity_stage"} <= fast


def test_every_kernel_compiled_with_fast_math_is_inlined_into_its_callers():
    not_inlined = sorted(name for name, d in _dispatchers().items()
                         if d.targetoptions.get("fastmath") and not d.targetoptions.get("forceinline"))
    assert not not_inlined, f"compiled with fast-math flags but called by symbol: {', '.join(not_inlined)}"


_RUNS = """
import hashlib, sys
import numpy as np
from impactid import SUNDAR2016, HuntCrossley, simulate, simulate_events

rig, law = SUNDAR2016.with_eccentricity_ratio(0.2), HuntCrossley(24.7e9, 1.36)


def run_simulate():
    result = simulate(rig, 16.0, law, 2.0, t_eval=np.linspace(0.0, 2.0, 401))
    numbers = result.contacts.select_dtypes("number").to_numpy(dtype=float)
    return hashlib.sha256(np.ascontiguousarray(numbers).tobytes()
                          + np.ascontiguousarray(result.alpha).tobytes()).hexdigest()[:16]


def run_batch():
    states = np.array([[0.07, -4.0, 0.3], [0.071, -3.9, 0.31], [0.069, -4.1, 0.29]])
    trials = np.array([[1.0e10, 1.4], [2.47e10, 1.5], [5.0e10, 1.6]])
    batch = simulate_events(rig, 16.0, states, np.full(3, 0.0625), trials, sensitivities=True)
    return hashlib.sha256(np.ascontiguousarray(batch.alpha_m).tobytes()).hexdigest()[:16]


first, second = (run_batch, run_simulate) if sys.argv[1] == "batch-first" else (run_simulate, run_batch)
done = {first.__name__: first(), second.__name__: second()}
print(done["run_simulate"], done["run_batch"])
"""


@pytest.mark.slow
def test_the_same_bits_fresh_and_from_the_cache(tmp_path):
    """A fresh compilation and two processes that load the kernels from numba's cache, calling the simulator and
    the batch of S1 events in either order, give the same bits (``_STEP_FLAGS``: the step functions' own
    compilation and a caller's copy differed at round-off). The shipped kernels are kept out."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba"), "IMPACTID_SHIPPED_KERNELS": str(tmp_path / "none"),
           "IMPACTID_COMPILE_NOTICE": "0", "NUMBA_NUM_THREADS": "1"}
    script = tmp_path / "runs.py"
    script.write_text(_RUNS)

    def run(order: str) -> str:
        done = subprocess.run([sys.executable, str(script), order], env=env, capture_output=True, text=True,
                              timeout=900, check=True)
        return done.stdout.strip()

    fresh = run("simulate-first")  # compiles everything
    assert run("batch-first") == fresh  # the batch's kernels loaded first, from the cache
    assert run("simulate-first") == fresh

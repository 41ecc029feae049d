"""Rig P's kernels give the same bits whether they were just compiled or loaded from numba's cache.

A kernel compiled with a fast-math flag (FMA contraction) and called by symbol has two compilations that
differ at round-off (its own, and the copy linked into its caller and optimised again there), and which one
runs depended on what the process had compiled or loaded before: a fresh compilation and a cached one of the
same run parted after 1 s of simulated time (``impactid.rigs.pivoted.kernel._STEP_FLAGS``). Every kernel
compiled with a fast-math flag is therefore inlined into its callers (``forceinline``).
"""

from __future__ import annotations

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

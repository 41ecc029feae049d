"""``impactid warmup``: compile (or load from numba's cache) the kernels the commands run, ahead of time.

For container images and CI: run ``impactid warmup`` once after ``pip install`` (as the user and on
the CPU type that will run the commands: numba's cache is keyed on both), and the first
``impactid estimate`` starts from the cache instead of compiling. Each rig's warm-up runs small
versions of what its commands run, through the same functions and therefore with the same
argument types (one compiled signature per kernel), so that what is compiled is exactly what the
commands load: for rig P a short run with a sample grid (``simulate``, ``synth``), a batch of S1
events with forward sensitivities and histories (the estimate's fits) and the estimate of the
built-in example recordings (reading, checking and reconstructing them; the recordings are
generated and cached on the way, as the first ``--example`` would).

Each rig declares its warm-up in the registry (:attr:`impactid.rigs.base.RigModel.warmup`, an import
path read on first use, so that ``impactid warmup --rig NAME`` loads only that rig, as a command
loads only its own rig); a rig with an estimator and an example then runs its estimate on the example
through :class:`impactid.pipeline.Pipeline`, as ``impactid estimate --example`` does. Imported when
the command runs (``impactid --help`` stays light); part of the application layer.
"""

from __future__ import annotations

import os
import time
import warnings
from collections.abc import Callable
from pathlib import Path

from impactid import _cachedir, _kernel_cache, compilation
from impactid.pipeline import Pipeline, read_recordings
from impactid.rigs.registry import PLUGINS, rig_model

__all__ = ["all_models", "warm_up"]


def _what(model) -> str:
    """What a rig's warm-up compiles, in words (its function's first docstring line)."""
    run = model.function("warmup")
    doc = (run.__doc__ or "").strip().splitlines() if run is not None else []
    parts = [doc[0].rstrip(".")] if doc else []
    if model.example is not None and model.estimation is not None:
        parts.append("and its estimate of the example recordings")
    return " ".join(parts) or "nothing to compile"


def warm_up(models: list[str], log: Callable[[str], None]) -> dict[str, float]:
    """Run the warm-up of each of ``models``; returns the CPU seconds each took.

    Parameters
    ----------
    models : model names (keys of :data:`impactid.rigs.registry.PLUGINS`).
    log : receives one line per rig (what, and how long).
    """
    choice = _cachedir.choose_kernel_cache(Path(compilation.__file__).parent)
    folder = os.environ.get("NUMBA_CACHE_DIR") or str(choice.folder or "beside the package (__pycache__)")
    if os.environ.get(_kernel_cache.BUILD_ENV):  # setup.py's build step: into the package being built
        folder = f"{os.environ[_kernel_cache.BUILD_ENV]} (shipped with the package being built)"
    log(f"numba cache: {folder}")
    times = {}
    for name in models:
        model = rig_model(name)  # an unknown or broken rig fails here, with the registry's message
        run = model.function("warmup")
        estimate = model.example is not None and model.estimation is not None
        if run is None and not estimate:
            log(f"{name}: nothing to compile")
            continue
        log(f"{name}: {_what(model)} ...")
        c0, w0 = time.process_time(), time.perf_counter()
        with warnings.catch_warnings():  # the small runs' notes (an estimate's model checks) are no news here
            warnings.simplefilter("ignore")
            if run is not None:
                run()
            if estimate:
                Pipeline(model=name).run(read_recordings(model.example()))
        cpu, wall = time.process_time() - c0, time.perf_counter() - w0
        times[name] = cpu
        log(f"{name}: ready ({cpu:.1f} s CPU, {wall:.1f} s)")
    return times


def all_models() -> list[str]:
    """Every registered model, in the registry's order."""
    return list(PLUGINS)

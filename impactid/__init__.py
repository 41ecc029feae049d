"""impactid: identify contact and impact models from measured time series of impact experiments.

The public API, following the data::

    read_recording / Recording          recordings (HDF5, CSV + TOML rig files)
    find_events, reconstruct            impacts and their kinematics
    estimate, Pipeline                  contact damping (beta, n) and restitution, with intervals
    simulate, simulate_event(s)         the compiled forward simulator of rig P
    HuntCrossley, Restitution           contact and impact laws
    MODELS, rig_model, register         the rig registry (rig P, rig F, the bouncing ball, ...)
    Parameter, FitResult, Estimate      result types

Everything else lives in the submodules: the core (``impactid.io``, ``impactid.events``,
``impactid.simulate``, ``impactid.synth``, ...) and each rig's folder (``impactid.rigs.pivoted``,
``impactid.rigs.flat``, ...).
"""

import importlib
import importlib.util
import os
import sys
import types
from pathlib import Path
from typing import Any

from impactid import _cachedir
from impactid._version import __version__


def _numba_cache_fallback() -> None:
    """Choose the folder numba caches impactid's compiled kernels in, before numba is imported.

    numba caches compiled kernels beside the package (``__pycache__``); when the installation is
    read-only they go to impactid's folder in the user's cache (``~/.cache/impactid/numba`` on
    Linux), and when that is not writable either (no home folder, a service account) to a per-user
    folder in the temporary directory (a cache that does not outlive the machine, but a working
    command: without one numba refuses every ``cache=True`` kernel, "no locator available").
    ``IMPACTID_CACHE_DIR`` moves the cache (to ``$IMPACTID_CACHE_DIR/numba``); an explicit
    ``NUMBA_CACHE_DIR`` is kept. The choice is :func:`impactid._cachedir.choose_kernel_cache`
    (standard library only: ``import impactid`` stays light).
    """
    if os.environ.get("NUMBA_CACHE_DIR") or "numba" in sys.modules:
        return
    choice = _cachedir.choose_kernel_cache(Path(__file__).parent)
    if choice.folder is not None:
        os.environ["NUMBA_CACHE_DIR"] = str(choice.folder)


_numba_cache_fallback()

#: Where each public name lives. ``import impactid`` loads none of them (no numba, SciPy or pandas):
#: a name is imported from its module on first use (PEP 562), so that ``impactid --help`` and a
#: notebook's ``import impactid`` start in a fraction of a second, and a Ctrl-C during the heavy
#: imports of a command reaches the command line's own handler (:mod:`impactid._launcher`).
_PUBLIC = {
    "HuntCrossley": "impactid.contact", "Restitution": "impactid.contact",
    "ImpactidError": "impactid.errors", "RigParameterError": "impactid.errors",
    "SimulationError": "impactid.errors", "SimulationInputError": "impactid.errors",
    "Estimate": "impactid.rigs.pivoted.estimates", "estimate": "impactid.pipeline",
    "find_events": "impactid.events",
    "Recording": "impactid.io", "read_recording": "impactid.io",
    "Pipeline": "impactid.pipeline",
    "reconstruct": "impactid.rigs.pivoted.reconstruct",
    "FitResult": "impactid.results", "Parameter": "impactid.results",
    "ALZATE2007": "impactid.rigs", "SUNDAR2016": "impactid.rigs", "FlatFollowerRig": "impactid.rigs",
    "PivotedFollowerRig": "impactid.rigs", "load_rig_toml": "impactid.rigs", "save_rig_toml": "impactid.rigs",
    "MODELS": "impactid.rigs.registry", "register": "impactid.rigs.registry", "rig_model": "impactid.rigs.registry",
    "Tolerances": "impactid.simulate", "simulate": "impactid.rigs.pivoted.runs",
    "simulate_event": "impactid.rigs.pivoted.runs", "simulate_events": "impactid.rigs.pivoted.runs",
}


#: Public functions named like a submodule (``impactid.simulate`` the function, ``impactid.simulate``
#: the package). Importing the submodule sets the package's attribute to the module; the face below
#: answers these names with the function whatever was imported before, as the eager imports did.
_SHADOWED = frozenset(name for name in _PUBLIC if importlib.util.find_spec(f"{__name__}.{name}") is not None)


class _Face(types.ModuleType):
    """The package's module type: public functions win over same-named submodules."""

    def __getattribute__(self, name: str) -> Any:
        if name in _SHADOWED:
            return getattr(importlib.import_module(_PUBLIC[name]), name)
        return super().__getattribute__(name)


sys.modules[__name__].__class__ = _Face


def __getattr__(name: str) -> Any:
    module = _PUBLIC.get(name)
    if module is not None:
        value = getattr(importlib.import_module(module), name)
        globals()[name] = value  # the next access is a plain attribute
        return value
    try:  # a submodule used as an attribute (impactid.rigs, impactid.io, ...)
        return importlib.import_module(f"{__name__}.{name}")
    except ModuleNotFoundError as exc:
        if exc.name != f"{__name__}.{name}":
            raise
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_PUBLIC))


__all__ = [
    "ALZATE2007", "MODELS", "SUNDAR2016", "Estimate", "FitResult", "FlatFollowerRig", "HuntCrossley", "ImpactidError",
    "Parameter", "Pipeline", "PivotedFollowerRig", "Recording", "Restitution", "RigParameterError", "SimulationError",
    "SimulationInputError", "Tolerances", "__version__", "estimate", "find_events", "load_rig_toml", "read_recording",
    "reconstruct", "register", "rig_model", "save_rig_toml", "simulate", "simulate_event", "simulate_events",
]

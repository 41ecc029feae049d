"""Rig descriptions: parameters (frozen dataclasses with TOML round trip) and geometry.

Every rig is a plug-in package below this one (``impactid.rigs.pivoted``, ``impactid.rigs.flat``,
...). Importing :mod:`impactid.rigs` loads none of them: the names below are imported from their
modules on first use (PEP 562), so that reading a rig file or building the command line does not
import every rig's numerics.
"""

from __future__ import annotations

import importlib
from typing import Any

_PUBLIC = {
    "ALZATE2007": "impactid.rigs.flat", "FlatFollowerRig": "impactid.rigs.flat",
    "SUNDAR2016": "impactid.rigs.pivoted", "PivotedFollowerRig": "impactid.rigs.pivoted",
    "RIG_MODELS": "impactid.rigs.registry", "load_rig_toml": "impactid.rigs.registry",
    "rig_from_mapping": "impactid.rigs.registry", "save_rig_toml": "impactid.rigs.registry",
}

__all__ = ["ALZATE2007", "SUNDAR2016", "FlatFollowerRig", "PivotedFollowerRig", "RIG_MODELS", "Rig",
           "load_rig_toml", "rig_from_mapping", "save_rig_toml"]


def __getattr__(name: str) -> Any:
    if name == "Rig":  # either rig dataclass
        value = __getattr__("PivotedFollowerRig") | __getattr__("FlatFollowerRig")
    elif name in _PUBLIC:
        value = getattr(importlib.import_module(_PUBLIC[name]), name)
    else:
        try:  # a rig package used as an attribute (impactid.rigs.flat, ...)
            return importlib.import_module(f"{__name__}.{name}")
        except ModuleNotFoundError as exc:
            if exc.name != f"{__name__}.{name}":
                raise
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))

"""Rig descriptions: parameters (frozen dataclasses with TOML round trip) and geometry."""

from impactid.rigs.flat import ALZATE2007, FlatFollowerRig
from impactid.rigs.pivoted import SUNDAR2016, PivotedFollowerRig
from impactid.rigs.registry import RIG_MODELS, load_rig_toml, rig_from_mapping, save_rig_toml

#: Either rig dataclass.
Rig = PivotedFollowerRig | FlatFollowerRig

__all__ = ["ALZATE2007", "SUNDAR2016", "FlatFollowerRig", "PivotedFollowerRig", "RIG_MODELS", "Rig",
           "load_rig_toml", "rig_from_mapping", "save_rig_toml"]

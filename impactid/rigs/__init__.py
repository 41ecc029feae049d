"""Rig descriptions: parameters (frozen dataclasses with TOML round trip) and geometry."""

from impactid.rigs.flat import SEED000_TABLE5, FlatFollowerRig
from impactid.rigs.pivoted import SEED001_TABLE1, PivotedFollowerRig
from impactid.rigs.registry import RIG_MODELS, load_rig_toml, rig_from_mapping, save_rig_toml

#: Either rig dataclass.
Rig = PivotedFollowerRig | FlatFollowerRig

__all__ = ["SEED000_TABLE5", "SEED001_TABLE1", "FlatFollowerRig", "PivotedFollowerRig", "RIG_MODELS", "Rig",
           "load_rig_toml", "rig_from_mapping", "save_rig_toml"]

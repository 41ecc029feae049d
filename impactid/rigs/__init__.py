"""Rig descriptions: parameters (frozen dataclasses with TOML round trip) and geometry."""

from impactid.rigs.pivoted import (
    SEED001_TABLE1,
    PivotedFollowerRig,
    load_rig_toml,
    save_rig_toml,
)

__all__ = ["SEED001_TABLE1", "PivotedFollowerRig", "load_rig_toml", "save_rig_toml"]

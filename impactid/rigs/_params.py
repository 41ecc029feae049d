"""Behaviour shared by the rig parameter dataclasses: construction from a mapping (naming missing and
unknown parameters), plain-dict export, validated copies, number checks and TOML text."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import fields
from typing import Any

import numpy as np

from impactid.errors import RigParameterError
from impactid.rigs._toml import format_toml

__all__ = ["RigParameters"]

class RigParameters:
    """Mixin for frozen rig dataclasses with a class attribute ``model`` (the docs/formats.md name)."""

    model: str

    def _check_numbers(self) -> None:
        """Every field a finite real number (stored as float), else :class:`RigParameterError`."""
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
                raise RigParameterError(f"rig parameter {f.name!r} must be a number, got {type(value).__name__}")
            value = float(value)
            object.__setattr__(self, f.name, value)
            if not math.isfinite(value):
                raise RigParameterError(f"rig parameter {f.name!r} is not finite ({value!r})")

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any], source: str = ""):
        """Build a rig from a mapping of parameter names to values, naming missing/unknown keys."""
        where = f"{source}: " if source else ""
        names = [f.name for f in fields(cls)]
        missing = [n for n in names if n not in values]
        if missing:
            raise RigParameterError(f"{where}rig '{cls.model}' is missing parameter(s) {', '.join(missing)}")
        unknown = sorted(set(values) - set(names) - {"model"})
        if unknown:
            raise RigParameterError(f"{where}unknown rig parameter(s) {', '.join(unknown)} for '{cls.model}'")
        try:
            return cls(**{n: values[n] for n in names})
        except RigParameterError as exc:
            raise RigParameterError(f"{where}{exc}") from None

    def to_dict(self) -> dict[str, float]:
        """Parameters as a plain dict (docs/formats.md names, SI units)."""
        return {f.name: getattr(self, f.name) for f in fields(self)}

    def replace(self, **changes: float):
        """A copy with some parameters changed (validated again)."""
        return dataclasses.replace(self, **changes)

    def to_toml(self, operating: Mapping[str, float] | None = None) -> str:
        """TOML text with ``[rig]`` (model + parameters) and optional ``[operating]`` tables."""
        tables: dict[str, Mapping[str, Any]] = {"rig": {"model": self.model, **self.to_dict()}}
        if operating:
            tables["operating"] = dict(operating)
        return format_toml(tables, header="impactid rig file (SI units; docs/formats.md parameter names)")

"""Registry of rig models, the one rig resolver, and the TOML rig-file reader/writer (docs/formats.md)."""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from impactid.errors import RigParameterError
from impactid.rigs._toml import read_toml, write_text_atomic
from impactid.rigs.base import RigModel

__all__ = ["MODELS", "RIG_MODELS", "ResolvedRig", "load_rig_toml", "register", "resolve_rig", "rig_by_name",
           "rig_from_mapping", "rig_model", "save_rig_toml"]

#: The registered rig models by docs/formats.md model name (:class:`~impactid.rigs.base.RigModel`).
MODELS: dict[str, RigModel] = {}


def register(model: RigModel) -> RigModel:
    """Add a rig model to the registry (one line per rig, below)."""
    if model.name in MODELS:
        raise ValueError(f"rig model {model.name!r} is registered twice")
    MODELS[model.name] = model
    if hasattr(model.parameters, "from_mapping"):  # rigs described by rig files (not the bouncing ball)
        RIG_MODELS[model.name] = model.parameters
    return model


#: Rig ``model`` names (of rig files and recordings) and the parameter dataclass of each (filled by
#: :func:`register`).
RIG_MODELS: dict[str, type] = {}


def rig_model(name: str) -> RigModel:
    """The registered rig model named ``name``; unknown names raise ``KeyError`` listing the known ones."""
    try:
        return MODELS[name]
    except KeyError:
        raise KeyError(f"unknown rig model {name!r} (known: {', '.join(MODELS) or 'none'})") from None


@dataclass(frozen=True)
class ResolvedRig:
    """What a rig specification names (:func:`resolve_rig`).

    model : the registered :class:`~impactid.rigs.base.RigModel`.
    rig : its parameter set (a preset, or the rig file's).
    operating : the rig file's ``[operating]`` table (empty for a name).
    file : the rig file, or None when a name was given.
    """

    model: RigModel
    rig: Any
    operating: Mapping[str, float] = field(default_factory=dict)
    file: str | None = None


def rig_by_name(name: str) -> tuple[RigModel, Any] | None:
    """The model and parameter set ``name`` stands for, or None when it names none.

    A model name stands for the model's default preset (the paper's table: ``"pivoted-follower"`` is
    ``SUNDAR2016``); a preset name for that preset of the model that has it (``"ALZATE2007"``). Exact
    names first, then ignoring case when that names one parameter set only.
    """
    if not isinstance(name, str):
        return None
    if name in MODELS:
        return MODELS[name], MODELS[name].default
    exact = [(m, m.presets[name]) for m in MODELS.values() if name in m.presets]
    if len(exact) == 1:
        return exact[0]
    folded = name.casefold()
    loose = [(m, m.default) for m in MODELS.values() if m.name.casefold() == folded]
    loose += [(m, rig) for m in MODELS.values() for key, rig in m.presets.items() if key.casefold() == folded]
    unique = {(m.name, id(rig)): (m, rig) for m, rig in exact + loose}
    if len(unique) > 1:
        raise RigParameterError(f"rig name {name!r} is ambiguous: a preset of "
                                f"{', '.join(sorted({m.name for m, _ in unique.values()}))}; give a rig file")
    return next(iter(unique.values()), None)


def resolve_rig(spec: str | os.PathLike[str] | None, default: str | None = None) -> ResolvedRig:
    """The one rig resolver of the command line (``--rig``) and of the API: what ``spec`` names.

    Rules, in order:

    1. None: the default preset of the model named ``default``;
    2. a registered model name: that model's default preset (the paper's parameter table);
    3. a preset name of a registered model (``SUNDAR2016``, ``ALZATE2007``, ``kim1990``, ...): that
       preset and its model (see :func:`rig_by_name`);
    4. anything else: a TOML rig file (:func:`load_rig_toml`); its ``[rig] model`` names the model
       and its ``[operating]`` table comes along.

    Raises
    ------
    RigParameterError
        naming the file for a missing or bad rig file, or when neither ``spec`` nor ``default``
        names a rig.
    """
    if spec is None:
        if default is None:
            raise RigParameterError("no rig given (a model name, a preset name or a TOML rig file)")
        model = rig_model(default)
        return ResolvedRig(model, model.default)
    named = rig_by_name(os.fspath(spec))
    if named is not None:
        return ResolvedRig(*named)
    rig, operating = load_rig_toml(spec)
    return ResolvedRig(rig_model(rig.model), rig, operating, os.fspath(spec))



def rig_from_mapping(values: Mapping[str, Any], source: str = ""):
    """Build the rig named by ``values['model']`` (a docs/formats.md rig model name)."""
    where = f"{source}: " if source else ""
    model = values.get("model")
    if model is None:
        raise RigParameterError(f"{where}rig has no 'model' (expected one of {', '.join(RIG_MODELS)})")
    if model not in RIG_MODELS:
        raise RigParameterError(f"{where}unknown rig model {model!r} (known: {', '.join(RIG_MODELS)})")
    return RIG_MODELS[model].from_mapping(values, source=source)


def load_rig_toml(path: str | os.PathLike[str]):
    """Read the ``[rig]`` table of a TOML rig file (docs/formats.md).

    Returns
    -------
    rig : the rig dataclass named by ``model``
    operating : dict of the ``[operating]`` table (empty if absent), e.g. ``cam_speed_hz``

    Raises
    ------
    RigParameterError
        naming the file and the parameter when the file is missing, malformed, or a parameter is
        missing, unknown, non-finite or non-physical.
    """
    data = read_toml(path)
    if "rig" not in data or not isinstance(data["rig"], dict):
        raise RigParameterError(f"{path}: no [rig] table")
    operating = data.get("operating", {})
    if not isinstance(operating, dict):
        raise RigParameterError(f"{path}: [operating] must be a table")
    for key, value in operating.items():
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise RigParameterError(f"{path}: operating parameter {key!r} must be a finite number, got {value!r}")
    return rig_from_mapping(data["rig"], source=str(path)), dict(operating)


def save_rig_toml(rig, path: str | os.PathLike[str], operating: Mapping[str, float] | None = None) -> Path:
    """Write a rig (and optional operating point) as a TOML rig file, atomically."""
    return write_text_atomic(path, rig.to_toml(operating))


# ---- the registry: one line per rig (a rig's folder defines its MODEL; see impactid/rigs/base.py) ----
from impactid.rigs.pivoted import MODEL as _PIVOTED; register(_PIVOTED)  # noqa: E402, E702, I001
from impactid.rigs.flat import MODEL as _FLAT; register(_FLAT)  # noqa: E402, E702, I001
from impactid.rigs.ball import MODEL as _BALL; register(_BALL)  # noqa: E402, E702, I001
from impactid.rigs.finger_follower import MODEL as _FINGER; register(_FINGER)  # noqa: E402, E702, I001
from impactid.rigs.cycloidal import MODEL as _CYCLOIDAL; register(_CYCLOIDAL)  # noqa: E402, E702, I001
from impactid.rigs.drop import MODEL as _DROP; register(_DROP)  # noqa: E402, E702, I001

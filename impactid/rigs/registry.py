"""Registry of rig models, the one rig resolver, and the TOML rig-file reader/writer (docs/formats.md)."""

from __future__ import annotations

import importlib
import math
import os
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from impactid.errors import RigParameterError
from impactid.rigs._toml import read_toml, write_text_atomic
from impactid.rigs.base import Argument, CommandSpec, Estimator, RigModel

__all__ = ["DEFAULT_EXAMPLE_MODEL", "MODELS", "PLUGINS", "RIG_MODELS", "ResolvedRig", "estimable_models",
           "estimate_arguments", "estimate_title", "estimator", "is_rig_parameters", "load_rig_toml", "register",
           "resolve_rig", "rig_by_name", "rig_commands", "rig_from_mapping", "rig_model", "save_rig_toml"]

#: The built-in rigs, one line per rig: the docs/formats.md model name, the package whose ``MODEL``
#: (a :class:`~impactid.rigs.base.RigModel`) it is, and whether the rig is described by TOML rig
#: files (the bouncing ball is not). A rig package is imported on first use of its name (the
#: plug-in pattern of obspy's entry points): importing the registry loads no rig, and reading a
#: recording of one rig loads that rig only.
PLUGINS: dict[str, tuple[str, bool]] = {
    "pivoted-follower": ("impactid.rigs.pivoted", True),
    "flat-follower": ("impactid.rigs.flat", True),
    "bouncing-ball": ("impactid.rigs.ball", False),
    "finger-follower-hla": ("impactid.rigs.finger_follower", True),
    "cycloidal-flat-follower-ehl": ("impactid.rigs.cycloidal", True),
    "drop-impact": ("impactid.rigs.drop", True),
    "tracked-ball": ("impactid.rigs.tracks", False),
    "planar-impact": ("impactid.rigs.planar", True),
}

#: The rig whose built-in example recordings the commands' ``--example`` reads.
DEFAULT_EXAMPLE_MODEL = "pivoted-follower"

#: Models already loaded (or registered at run time with :func:`register`).
_LOADED: dict[str, RigModel] = {}


def _load(name: str) -> RigModel:
    model = _LOADED.get(name)
    if model is None:
        package, _ = PLUGINS[name]
        model = importlib.import_module(package).MODEL
        if model.name != name:
            raise RuntimeError(f"{package}.MODEL is named {model.name!r}, registered as {name!r}")
        _LOADED[name] = model
    return model


class _Models(Mapping):
    """The registered rig models by model name, imported on first access (read-only mapping)."""

    def __getitem__(self, name: str) -> RigModel:
        if name not in PLUGINS:
            raise KeyError(name)
        return _load(name)

    def __iter__(self) -> Iterator[str]:
        return iter(list(PLUGINS))

    def __len__(self) -> int:
        return len(PLUGINS)

    def __contains__(self, name: object) -> bool:
        return name in PLUGINS

    def __repr__(self) -> str:
        return f"MODELS({', '.join(PLUGINS)})"


class _RigModels(Mapping):
    """Rig ``model`` names of rig files and recordings -> the parameter dataclass of each (imported
    on first access of that name)."""

    def __getitem__(self, name: str) -> type:
        if name not in PLUGINS or not PLUGINS[name][1]:
            raise KeyError(name)
        return _load(name).parameters

    def __iter__(self) -> Iterator[str]:
        return iter([name for name, (_, files) in PLUGINS.items() if files])

    def __len__(self) -> int:
        return sum(files for _, files in PLUGINS.values())

    def __contains__(self, name: object) -> bool:
        return name in PLUGINS and PLUGINS[name][1]


#: The registered rig models by docs/formats.md model name (:class:`~impactid.rigs.base.RigModel`).
MODELS: Mapping[str, RigModel] = _Models()

#: Rig ``model`` names (of rig files and recordings) and the parameter dataclass of each.
RIG_MODELS: Mapping[str, type] = _RigModels()


def register(model: RigModel, package: str | None = None) -> RigModel:
    """Add a rig model at run time (a rig outside impactid): ``package`` is where its ``MODEL`` lives
    (default: the module that defines its parameters)."""
    if model.name in PLUGINS:
        raise ValueError(f"rig model {model.name!r} is registered twice")
    PLUGINS[model.name] = (package or model.parameters.__module__, hasattr(model.parameters, "from_mapping"))
    _LOADED[model.name] = model
    return model


def rig_model(name: str) -> RigModel:
    """The registered rig model named ``name``; unknown names raise ``KeyError`` listing the known ones."""
    if name not in PLUGINS:
        raise KeyError(f"unknown rig model {name!r} (known: {', '.join(PLUGINS) or 'none'})")
    return _load(name)


#: The import-path fields of a rig model that its package may also declare as module constants (the
#: field's name in upper case), so that the command line is built without building ``MODEL``.
_LIGHT_FIELDS = ("commands", "estimation", "estimate_arguments")
_NOT_DECLARED = object()


def _declared(name: str, constant: str, read: Callable[[RigModel], Any]) -> Any:
    """What the rig model ``name``'s package declares as the module constant ``constant``, read without
    building its ``MODEL`` (which imports the rig's parameters, and for some rigs its kernel); else (a
    package that does not declare it, or a model registered at run time) ``read(model)``."""
    model = _LOADED.get(name)
    if model is None:
        declared = vars(importlib.import_module(PLUGINS[name][0])).get(constant, _NOT_DECLARED)
        if declared is not _NOT_DECLARED:
            return declared
        model = _load(name)
    return read(model)


def _path(name: str, field: str) -> Any:
    """The import-path field ``field`` of the rig model ``name`` (:data:`_LIGHT_FIELDS`), read without
    building its ``MODEL`` when its package declares it as a module constant (``COMMANDS``, ...): the
    parser and every ``--help`` load no rig's parameters or numerics. Unknown names raise ``KeyError``."""
    if name not in PLUGINS:
        raise KeyError(f"unknown rig model {name!r} (known: {', '.join(PLUGINS) or 'none'})")
    return _declared(name, field.upper(), lambda model: getattr(model, field))


def _preset_names(name: str) -> tuple[str, ...]:
    """The names of the rig model ``name``'s presets (its package's ``PRESET_NAMES``, read without
    building its ``MODEL``; else the model's :attr:`~impactid.rigs.base.RigModel.presets`)."""
    return tuple(_declared(name, "PRESET_NAMES", lambda model: tuple(model.presets)))


def rig_commands(name: str) -> tuple[CommandSpec, ...]:
    """The commands the rig model ``name`` contributes (:meth:`~impactid.rigs.base.RigModel.command_specs`),
    read from its commands module without building its ``MODEL`` when its package declares ``COMMANDS``."""
    path = _path(name, "commands")
    if isinstance(path, str):
        return tuple(importlib.import_module(path).COMMANDS)
    return rig_model(name).command_specs()


def estimator(name: str) -> Estimator | None:
    """The :class:`~impactid.rigs.base.Estimator` of the rig model ``name`` (the ``ESTIMATOR`` of its
    :attr:`~impactid.rigs.base.RigModel.estimation` module, imported on first use), or None when
    impactid estimates nothing from that rig's recordings. Unknown names raise ``KeyError``."""
    path = _path(name, "estimation")
    if path is None:
        return None
    found = getattr(importlib.import_module(path), "ESTIMATOR", None)
    if not isinstance(found, Estimator):
        raise RuntimeError(f"{path}.ESTIMATOR of rig {name!r} is not an Estimator")
    return found


def _estimate_declaration(name: str, attribute: str) -> Any:
    """``ARGUMENTS`` or ``TITLE`` of the rig's :attr:`~impactid.rigs.base.RigModel.estimate_arguments`
    module (light: the estimation is not imported), else the estimator's own; None without an estimation."""
    if _path(name, "estimation") is None:
        return None
    path = _path(name, "estimate_arguments")
    if path is not None:
        return getattr(importlib.import_module(path), attribute)
    found = estimator(name)
    return found.arguments if attribute == "ARGUMENTS" else found.title


def estimate_arguments(name: str) -> tuple[Argument, ...]:
    """The command-line arguments of the rig model ``name``'s estimate (its
    :attr:`~impactid.rigs.base.Estimator.arguments`), read from its light
    :attr:`~impactid.rigs.base.RigModel.estimate_arguments` module when it names one (the estimation
    module is not imported); empty when impactid estimates nothing from that rig."""
    found = _estimate_declaration(name, "ARGUMENTS")
    return tuple(found) if found is not None else ()


def estimate_title(name: str) -> str:
    """What the rig model ``name``'s estimate identifies, one line (:attr:`~impactid.rigs.base.Estimator.title`),
    read as :func:`estimate_arguments` reads the arguments; empty without an estimation."""
    return _estimate_declaration(name, "TITLE") or ""


def estimable_models() -> tuple[str, ...]:
    """The names of the registered rig models with an estimation (imports each rig's package, neither
    its estimation module nor, when the package declares ``ESTIMATION``, its parameters)."""
    return tuple(name for name in PLUGINS if _path(name, "estimation") is not None)


def is_rig_parameters(value: Any) -> bool:
    """Whether ``value`` is the parameter set of a registered rig described by rig files (loads
    that rig only)."""
    name = getattr(value, "model", None)
    return isinstance(name, str) and name in RIG_MODELS and isinstance(value, RIG_MODELS[name])


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
    folded = name.casefold()
    # the rigs ``name`` may stand for, found by their names and preset names without building the
    # others' models (a rig file's path, the usual case, names none: no rig's model is built here)
    meant = [MODELS[m] for m in PLUGINS
             if m.casefold() == folded or any(p.casefold() == folded for p in _preset_names(m))]
    exact = [(m, m.presets[name]) for m in meant if name in m.presets]
    if len(exact) == 1:
        return exact[0]
    loose = [(m, m.default) for m in meant if m.name.casefold() == folded]
    loose += [(m, rig) for m in meant for key, rig in m.presets.items() if key.casefold() == folded]
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

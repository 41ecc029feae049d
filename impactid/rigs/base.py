"""What every rig model provides: the :class:`RigModel` record, its channels and its commands.

A rig is one folder of ``impactid/rigs/`` (its parameters, geometry, compiled kernel, measurement
model, figures and commands) behind one :class:`RigModel`, registered with one line in
:mod:`impactid.rigs.registry`. The pipeline, the recordings and the command line dispatch through
the registry by the docs/formats.md model name; nothing outside a rig's folder names the rig.

A rig model is a frozen record of functions and tables rather than a class hierarchy: the physics
are pure functions in the rig's modules, and the record says which of them play which role.
Capabilities a rig does not have are ``None`` (a bouncing ball has no cam to detach from), and
callers say so to the user instead of failing.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

__all__ = ["Argument", "ChannelSpec", "CommandSpec", "ContactLaw", "RigModel"]


@dataclass(frozen=True)
class ChannelSpec:
    """A channel a rig's recordings may hold (the file-format contract of that rig).

    ``quantity`` names the physical quantity for unit parsing (:data:`impactid.units.SI_UNITS`),
    ``unit`` is its SI unit as written in files, ``required`` whether the rig's measurement model
    cannot work without it.
    """

    name: str
    quantity: str
    unit: str
    description: str
    required: bool = False


@dataclass(frozen=True)
class Argument:
    """A command-line argument: the flags and the keyword arguments of ``add_argument``.

    ``options`` may also be a function returning them, called when the parser is built: for
    options (such as ``choices``) that come from modules a rig's import must not load. Arguments
    with the same ``exclusive`` name form a mutually exclusive group (at most one may be given).
    """

    flags: tuple[str, ...]
    options: Mapping[str, Any] | Callable[[], Mapping[str, Any]] = field(default_factory=dict)
    exclusive: str = ""

    def add_to(self, parser: argparse.ArgumentParser) -> None:
        """Add to ``parser`` unless an argument with the same first flag is there already (rigs that
        share a command share its common arguments)."""
        known = {flag for action in parser._actions for flag in action.option_strings}
        if known.intersection(self.flags):
            return
        options = self.options() if callable(self.options) else self.options
        target = parser
        if self.exclusive:
            groups = parser.__dict__.setdefault("_exclusive_groups", {})
            if self.exclusive not in groups:
                groups[self.exclusive] = parser.add_mutually_exclusive_group()
            target = groups[self.exclusive]
        target.add_argument(*self.flags, **dict(options))


@dataclass(frozen=True)
class CommandSpec:
    """A command a rig contributes to the ``impactid`` command line.

    ``group`` is the command group (``"valvetrain"`` gives ``impactid valvetrain NAME``; ``""`` a
    top-level command). Several rigs may contribute the same ``(group, name)``: the command then
    takes ``--rig`` and runs the chosen rig's ``run``; its arguments are the union of theirs (the
    first registered rig's declaration of a flag wins). What ``--rig`` takes is ``rig_argument``:

    * ``"model"``: one of the contributing rigs' model names (``impactid valvetrain simulate --rig
      finger-follower-hla``);
    * ``"resolve"``: a model name, a preset name or a TOML rig file, resolved through the registry
      (:func:`~impactid.rigs.registry.resolve_rig`): the command runs the implementation of the rig
      that names, with ``args.resolved_rig`` (a :class:`~impactid.rigs.registry.ResolvedRig`) set;
      without ``--rig``, the rig whose spec has ``default_rig`` (``impactid synth``, ``impactid
      detachment``).

    A top-level command of one rig gets no ``--rig`` from the command line; it may declare its own
    (and resolve it with :func:`~impactid.rigs.registry.resolve_rig`).

    ``description`` is the longer text of ``impactid ... NAME --help``. ``run(args, model)`` returns
    the exit code; errors the user caused raise
    :class:`~impactid.errors.ImpactidError`.
    """

    group: str
    name: str
    help: str
    arguments: Sequence[Argument]
    run: Callable[[argparse.Namespace, RigModel], int]
    description: str = ""
    rig_argument: str = "model"
    default_rig: bool = False

    def __post_init__(self) -> None:
        if self.rig_argument not in ("model", "resolve"):
            raise ValueError(f"rig_argument must be 'model' or 'resolve', got {self.rig_argument!r}")


@dataclass(frozen=True)
class ContactLaw:
    """Description of a contact or impact law a rig's simulator accepts (parameters, bounds, packing).

    ``parameters`` maps each parameter name to ``(unit, (low, high))``: its SI unit and the bounds of
    a search; ``pack(law) -> numpy array`` gives the law's vector for the compiled kernel.
    """

    name: str
    law_type: type
    parameters: Mapping[str, tuple[str, tuple[float, float]]]
    pack: Callable[[Any], Any]


@dataclass(frozen=True)
class RigModel:
    """A rig: its parameters and presets, its physics for the compiled kernel, its measurement model.

    Attributes
    ----------
    name : the docs/formats.md model name (``"pivoted-follower"``, ``"finger-follower-hla"``, ...).
    title : one line for users, citing the paper (``"... (Sundar, Dreyer & Singh 2016)"``).
    citation : key of the paper in the bibliography (``docs/bibliography.md``).
    parameters : the frozen dataclass of the rig's parameters (``from_mapping``, ``to_dict``, TOML).
    presets : named parameter sets (the papers' tables), the default first.
    channels : the channels its recordings may hold (name -> :class:`ChannelSpec`).
    laws : the contact or impact laws its simulator accepts.
    gap, gap_rate : ``gap(rig, state, cam_angle)`` [m] (positive = open) and its rate [m/s]; for
        a rig with several contacts, the cam/follower contact.
    contact_coordinate : a function of the state and cam angle giving the coordinate in which
        contact is measured (indentation, deflection), or None.
    detachment : ``detachment(rig, **options)`` -> the cam speed [Hz] at which the follower
        leaves the cam, or None.
    pack : ``pack(rig) -> numpy array``: the parameter vector the compiled kernel takes.
    kernel : import path of the rig's compiled kernel module (built on :mod:`impactid.simulate.dp5`),
        a string so that reading a rig file does not load numba.
    simulate : the rig's main simulation entry point, or None.
    measure : the measurement model: ``measure(recording, **options)`` turns a recording into
        per-event (per-impact, per-revolution, per-bounce) kinematics, or None.
    example : ``example(refresh=False)`` -> the paths of the rig's built-in example recordings
        (generated on first use and cached), or None.
    commands : what the rig adds to the command line.
    """

    name: str
    title: str
    citation: str
    parameters: type
    presets: Mapping[str, Any]
    channels: Mapping[str, ChannelSpec] = field(default_factory=dict)
    laws: Sequence[ContactLaw] = ()
    gap: Callable | None = None
    gap_rate: Callable | None = None
    contact_coordinate: Callable | None = None
    detachment: Callable | None = None
    pack: Callable | None = None
    kernel: Any = None
    simulate: Callable | None = None
    measure: Callable | None = None
    example: Callable | None = None
    commands: Sequence[CommandSpec] = ()

    @property
    def default(self):
        """The default parameter set (the first preset)."""
        return next(iter(self.presets.values()))

    def preset(self, name: str):
        """A preset by name; unknown names raise ``KeyError`` listing the known ones."""
        try:
            return self.presets[name]
        except KeyError:
            raise KeyError(f"no preset {name!r} for rig {self.name!r}; presets: {', '.join(self.presets)}") from None

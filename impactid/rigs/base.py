"""What every rig model provides: the :class:`RigModel` record, its channels and its commands.

A rig is one folder of ``impactid/rigs/`` (its parameters, geometry, compiled kernel, measurement
model, figures and commands) behind one :class:`RigModel`, registered with one line in
:mod:`impactid.rigs.registry`. The pipeline, the recordings and the command line dispatch through
the registry by the docs/formats.md model name; nothing outside a rig's folder names the rig.

A rig model is a frozen record of functions and tables rather than a class hierarchy: the physics
are pure functions in the rig's modules, and the record says which of them play which role.
Capabilities a rig does not have are ``None`` (a bouncing ball has no cam to detach from), and
callers say so to the user instead of failing.

A rig that identifies a contact law from its recordings names its estimation module
(:attr:`RigModel.estimation`), whose ``ESTIMATOR`` (an :class:`Estimator`) is what the generic
``impactid estimate`` and :class:`impactid.pipeline.Pipeline` run: the rig's options, their
command-line arguments, ``prepare`` (one recording) and ``fit`` (the prepared recordings of one
rig, jointly), and how a result is written and told. :func:`estimate_options` checks a rig's
options (an unknown one is an :class:`OptionError` naming it and the rig).

The command line is built from light modules only (``impactid --help`` and every ``impactid COMMAND
--help`` load no numba, pandas, SciPy, matplotlib or rig numerics): a rig's commands module declares
its arguments as data and imports the numerics inside each command's ``run``; the arguments of its
estimate live in a light module named by :attr:`RigModel.estimate_arguments` (its ``ARGUMENTS`` and
``TITLE``; the estimation module imports them from there), so that ``impactid estimate --help``
does not import the estimation. The registry reads these import paths without building the
rig's ``MODEL`` when the rig's package also declares them as module constants named like the fields
in upper case (``COMMANDS``, ``ESTIMATION``, ``ESTIMATE_ARGUMENTS``; and ``PRESET_NAMES``, the names of
:attr:`RigModel.presets`, so that ``--rig PRESET`` builds no other rig's model) and builds ``MODEL``
(which imports the rig's parameters) on first access (:func:`lazy_attributes`,
:func:`impactid.rigs.registry.rig_commands`).
"""

from __future__ import annotations

import argparse
import importlib
import json
import sys
import threading
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from impactid._version import __version__
from impactid.errors import ImpactidError

__all__ = ["Argument", "ChannelSpec", "CommandSpec", "ContactLaw", "Estimator", "OptionError", "PreparedRecording",
           "RigModel", "argument_dests", "estimate_options", "lazy_attributes", "options_record",
           "pipeline_provenance"]


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
    replay : ``"module:name"``, the import path of the rig's replay: what turns trial parameters into
        the residual vector of the measured events (and its Jacobian, where the kernel integrates
        sensitivities), the function the identification engine (:mod:`impactid.engine`) searches
        over; None where the rig's fits have no replay of their own (closed-form laws). Read with
        :meth:`function`.
    calibrate : ``"module:name"``, the import path of the rig's calibration of its own pipeline (the
        bias the measurement adds, estimated on synthetic recordings of the same rig), or None.
    warmup : ``"module:name"``, the import path of a function of no argument that runs small versions of
        the rig's simulations with the argument types its commands use, so that its compiled kernels
        compile (or load from numba's cache) the signatures the commands run (``impactid warmup``,
        which then also runs the rig's estimate on its example recordings where it has both); None
        where the rig has no compiled kernel.
    commands : what the rig adds to the command line: the :class:`CommandSpec` records, or the import
        path of the module that holds them as ``COMMANDS`` (read by :meth:`command_specs`).
    estimation : import path of the rig's estimation module, whose ``ESTIMATOR`` (an
        :class:`Estimator`) identifies the contact law from the rig's recordings (``impactid
        estimate``, :class:`impactid.pipeline.Pipeline`); a string, as :attr:`kernel`, so that reading
        a rig file does not load it. None: impactid estimates nothing from this rig's recordings.
    estimate_arguments : import path of the light module (no numerics at module level) that holds
        the command-line arguments of the rig's estimate as ``ARGUMENTS`` (what
        :attr:`Estimator.arguments` is) and its one-line ``TITLE`` (:attr:`Estimator.title`): what
        ``impactid estimate`` and its ``--help`` read without importing :attr:`estimation`. None: they
        are read from the ``ESTIMATOR`` (which imports the estimation module).
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
    commands: Sequence[CommandSpec] | str = ()
    estimation: str | None = None
    estimate_arguments: str | None = None
    replay: str | None = None
    calibrate: str | None = None
    warmup: str | None = None

    def command_specs(self) -> tuple[CommandSpec, ...]:
        """The rig's commands: :attr:`commands`, imported from its module on first use when it is an
        import path (the module's ``COMMANDS``), so that loading a rig does not load its command line."""
        if isinstance(self.commands, str):
            return tuple(importlib.import_module(self.commands).COMMANDS)
        return tuple(self.commands)

    def function(self, name: str) -> Any:
        """The object an import-path field names (``"replay"``, ``"calibrate"``), imported on first use;
        None where the rig has none. ``"module:attribute"`` paths only."""
        path = getattr(self, name)
        if path is None:
            return None
        module, _, attribute = path.partition(":")
        return getattr(importlib.import_module(module), attribute)

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


def lazy_attributes(module: str, names: Mapping[str, str],
                    built: Mapping[str, Callable[[], Any]] | None = None) -> Callable[[str], Any]:
    """The module ``__getattr__`` (PEP 562) of a rig's package, so that importing the package (the
    registry, the command line) loads none of the rig's parameters or numerics.

    Each of ``names`` (name -> the module that defines it) is imported on first access; each of
    ``built`` (name -> a function of no argument: the rig's ``MODEL``) is built once, on first
    access. Either is then kept in the module ``module`` (a second access costs nothing).
    """
    lock = threading.RLock()
    built = dict(built or {})

    def __getattr__(name: str) -> Any:
        if name in names:
            value = getattr(importlib.import_module(names[name]), name)
        elif name in built:
            with lock:  # one record, whichever thread asks first
                namespace = vars(sys.modules[module])
                if name in namespace:
                    return namespace[name]
                value = built[name]()
        else:
            raise AttributeError(f"module {module!r} has no attribute {name!r}")
        vars(sys.modules[module])[name] = value
        return value

    return __getattr__


# ---- estimation -------------------------------------------------------------------------------------


class OptionError(ImpactidError, ValueError):
    """An estimate option a rig does not have, or a value it does not take (the message names both)."""


@dataclass(frozen=True)
class PreparedRecording:
    """One recording as a rig's estimator prepared it (:attr:`Estimator.prepare`): what its fits take.

    Attributes
    ----------
    model : the rig model of the recording (docs/formats.md model name).
    source : the recording's name in messages and results (its file, or ``"recording k"``).
    data : the rig's own product (per-impact kinematics, event sets, observations ...): picklable,
        so that a campaign can send it to the workers of its fits and cache it.
    notes : what qualifies the recording, gathered while it was read (a clipped channel, ...),
        carried into the fits' results ahead of the fits' own notes.
    """

    model: str
    source: str
    data: Any
    notes: tuple[str, ...] = ()


@dataclass(frozen=True)
class Estimator:
    """What a rig gives the generic estimate (``impactid estimate``, :class:`impactid.pipeline.Pipeline`,
    :mod:`impactid.campaign`): its options, the two stages of the job and how a result is delivered.

    The job has two stages so that a campaign can prepare its recordings in parallel, each once, and
    feed each product to several fits: ``prepare`` one recording, then ``fit`` the prepared
    recordings of one rig jointly.

    Attributes
    ----------
    options : every option of the rig's estimate and its default (name -> default; tuples for pairs,
        never lists); the options a user gives are checked against these names
        (:func:`estimate_options`) and recorded in the result.
    arguments : the command-line arguments of these options for ``impactid estimate`` (their ``dest``
        need not be the option names: :attr:`from_arguments` maps them). Arguments of several rigs
        that share a flag are declared alike (the first registered rig's declaration is used).
    prepare : ``prepare(recording, options, source) -> data``: read and measure one
        :class:`~impactid.io.Recording` (events, per-impact kinematics, observations) with the full
        ``options``; ``source`` is the recording's name in messages and results. ``data`` becomes
        the :attr:`PreparedRecording.data` of the recording.
    fit : ``fit(prepared, options, progress) -> result``: the estimate from one or several
        :class:`PreparedRecording` of this rig (several: a joint fit); ``progress`` is None or a
        callback ``(stage, fraction)``. It never warns: its notes are in the result (:attr:`notes`),
        including the prepared recordings' :attr:`PreparedRecording.notes`.
    to_dict : ``to_dict(result) -> dict``: the result as JSON-ready data (SI units), what
        ``impactid estimate --out/--json`` writes.
    summary : ``summary(result) -> list of str``: the lines ``impactid estimate`` prints.
    notes : ``notes(result) -> sequence of str``: the result's notes, issued as :attr:`warning` by
        :meth:`impactid.pipeline.Pipeline.fit` (each once).
    warning : the warning category of the notes.
    figures : ``figures(result, args) -> (names, write)`` or None: the file names of the figures of
        ``--plots`` and ``write(staged)``, which writes them into ``args.plots`` (a
        :class:`~impactid._files.StagedFiles` transaction); None: the rig draws no figure.
    from_arguments : ``from_arguments(args) -> dict``: the options the command line gives (an
        :class:`argparse.Namespace` holding :attr:`arguments`); raises
        :class:`~impactid.commandline.UsageError` naming an argument it cannot take. None: every
        option whose name is an argument's ``dest``.
    check : ``check(options) -> options``: check (raising ``ValueError`` naming the option) and
        normalise the values of the full options (e.g. a residual's alias to its name), or None.
    compact : ``compact(data) -> data``: the prepared data without what only figures need (the
        samples), small enough to pickle and cache (a campaign's products); None: ``data`` as it is.
    prepare_options : the options that change what ``prepare`` makes (the others change the fit
        only): a campaign keys its prepared products by them.
    title : what the estimate identifies, one line (``--help``).
    """

    options: Mapping[str, Any]
    arguments: Sequence[Argument]
    prepare: Callable[[Any, Mapping[str, Any], str], Any]
    fit: Callable[[Sequence[PreparedRecording], Mapping[str, Any], Callable[[str, float], None] | None], Any]
    to_dict: Callable[[Any], dict]
    summary: Callable[[Any], list[str]]
    notes: Callable[[Any], Sequence[str]]
    warning: type[Warning] = UserWarning
    figures: Callable[[Any, argparse.Namespace], tuple[Sequence[str], Callable[[Any], object]] | None] | None = None
    from_arguments: Callable[[argparse.Namespace], Mapping[str, Any]] | None = None
    check: Callable[[Mapping[str, Any]], Mapping[str, Any]] | None = None
    compact: Callable[[Any], Any] | None = None
    prepare_options: tuple[str, ...] = ()
    title: str = ""

    def argument_dests(self) -> tuple[str, ...]:
        """The ``dest`` of each of :attr:`arguments` (what they set in an :class:`argparse.Namespace`)."""
        return argument_dests(self.arguments)

    def options_from_arguments(self, args: argparse.Namespace) -> dict[str, Any]:
        """The options ``args`` gives (:attr:`from_arguments`, or the arguments named as options)."""
        if self.from_arguments is not None:
            return dict(self.from_arguments(args))
        return {dest: getattr(args, dest) for dest in self.argument_dests()
                if dest in self.options and hasattr(args, dest)}


def argument_dests(arguments: Sequence[Argument]) -> tuple[str, ...]:
    """The ``dest`` of each of ``arguments`` (what they set in an :class:`argparse.Namespace`)."""
    out = []
    for argument in arguments:
        options = argument.options() if callable(argument.options) else argument.options
        flag = argument.flags[0]
        out.append(options.get("dest") or (flag.lstrip("-").replace("-", "_") if flag.startswith("-") else flag))
    return tuple(out)


def _frozen_value(value: Any) -> Any:
    """An option's value as the options hold it: lists (from TOML or JSON) as tuples."""
    return tuple(_frozen_value(v) for v in value) if isinstance(value, list) else value


def estimate_options(estimator: Estimator, model: str, given: Mapping[str, Any]) -> dict[str, Any]:
    """The full options of a rig's estimate: its defaults (:attr:`Estimator.options`) updated by ``given``,
    checked and normalised (:attr:`Estimator.check`).

    Raises
    ------
    OptionError
        naming the option and the rig ``model``: an option the rig's estimate does not have (with
        the ones it has), or a value :attr:`Estimator.check` refuses.
    """
    unknown = sorted(set(given) - set(estimator.options))
    if unknown:
        raise OptionError(f"unknown option(s) {', '.join(unknown)} of the {model!r} rig's estimate (known: "
                          f"{', '.join(sorted(estimator.options))})")
    options = {name: _frozen_value(given.get(name, default)) for name, default in estimator.options.items()}
    if estimator.check is not None:
        try:
            options = {name: _frozen_value(value) for name, value in estimator.check(options).items()}
        except OptionError:
            raise
        except (TypeError, ValueError) as exc:
            raise OptionError(str(exc)) from None
    return options


def options_record(options: Mapping[str, Any]) -> dict[str, Any]:
    """The options as JSON-ready data (tuples as lists), as results record them."""
    return {name: (list(value) if isinstance(value, tuple) else value) for name, value in options.items()}


def pipeline_provenance(options: Mapping[str, Any]) -> str:
    """The provenance line of an estimate made with ``options``: the impactid version and the options."""
    return f"impactid {__version__} pipeline {json.dumps(options_record(options), sort_keys=True)}"

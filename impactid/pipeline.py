"""The estimate: every option of the job from recordings to estimates, in one frozen object, for any rig.

In the manner of pvlib's ``ModelChain``: a :class:`Pipeline` holds the choices that decide an estimate
and runs the steps in order::

    recordings -> (per recording) prepare -> (jointly) fit -> result

What the steps are is the rig's: the pipeline dispatches on the rig model of the recordings (their
``/rig``), through the registry (:func:`impactid.rigs.registry.estimator`), to the rig's
:class:`~impactid.rigs.base.Estimator` (rig P's :mod:`impactid.rigs.pivoted.estimation`: events,
per-impact kinematics, contact damping ``beta, n`` with calibration, restitution; the drop rig's
:mod:`impactid.rigs.drop.estimation`: ``k, beta, n``). The options are the rig's
(:attr:`Estimator.options <impactid.rigs.base.Estimator.options>`): a pipeline made without a rig
model takes the options of any rig's estimate and is checked against the recordings' rig when it
runs; ``Pipeline(model=NAME, ...)`` holds every option of that rig's estimate. The options are
recorded in the result and its provenance, so that an estimate says how it was made.

:func:`estimate` is a thin call on it.

Example
-------
>>> from impactid import Pipeline
>>> pipeline = Pipeline(fix_n=1.5, bootstrap_resamples=200)      # doctest: +SKIP
>>> result = pipeline.run(["rec_020_16.h5", "rec_025_15.h5"])      # doctest: +SKIP
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

from impactid import _status
from impactid.errors import ImpactidError
from impactid.io import Recording, RecordingError, check_memory, read_recording
from impactid.rigs.base import Estimator, OptionError, PreparedRecording, estimate_options, options_record
from impactid.rigs.registry import PLUGINS, estimable_models, estimator

__all__ = ["Pipeline", "PreparedRecording", "estimate", "read_recordings", "recordings_model", "rig_estimator"]

Progress = Callable[[str, float], None]


def _frozen(value: Any) -> Any:
    return tuple(_frozen(v) for v in value) if isinstance(value, list) else value


def _estimators() -> dict[str, Estimator]:
    """The estimators of every registered rig that has one, by model name (imports them)."""
    return {name: estimator(name) for name in estimable_models()}


def rig_estimator(model: str, where: str = "") -> Estimator:
    """The :class:`~impactid.rigs.base.Estimator` of rig model ``model``.

    Raises
    ------
    RecordingError
        when impactid estimates nothing from that rig's recordings (naming the models it does
        estimate from); ``where`` (a recording's name) starts the message.
    """
    found = estimator(model)
    if found is None:
        able = " or ".join(repr(m) for m in estimable_models()) or "no"
        raise RecordingError(f"{where or 'recording'}: needs a {able} rig (impactid estimates no contact law from "
                             f"the recordings of this model), the recording's rig is {model!r}")
    return found


def _check_unbound(options: Mapping[str, Any]) -> dict[str, Any]:
    """Options given without a rig model: each must be an option of some rig's estimate, all of them of
    one rig's, and some rig's estimate must take their values (normalised when only one rig's can)."""
    if not options:
        return {}
    ests = _estimators()
    unknown = sorted(name for name in options if not any(name in est.options for est in ests.values()))
    if unknown:
        known = "; ".join(f"{model}: {', '.join(sorted(est.options))}" for model, est in ests.items())
        raise OptionError(f"unknown option(s) {', '.join(unknown)} (the estimates' options are {known})")
    candidates = [model for model, est in ests.items() if set(options) <= set(est.options)]
    if not candidates:
        owners = ", ".join(f"{name} ({' or '.join(m for m, est in ests.items() if name in est.options)})"
                           for name in options)
        raise OptionError(f"the options belong to the estimates of different rigs: {owners}")
    first: OptionError | None = None
    for model in candidates:
        try:
            full = estimate_options(ests[model], model, options)
        except OptionError as exc:
            first = first or exc
            continue
        return {name: full[name] for name in options} if len(candidates) == 1 else {
            name: _frozen(value) for name, value in options.items()}
    raise first


@dataclass(frozen=True, init=False, repr=False)
class Pipeline:
    """Every option of an estimate (frozen; recorded in the result), for the recordings of any rig whose
    model has an estimation (:attr:`~impactid.rigs.base.RigModel.estimation`).

    ``Pipeline(**options)`` takes the options of a rig's estimate (rig P's: ``residual``, ``fix_n``,
    ``method``, ``grid``, ``integration``, ``anchor``, ``c_bounds``, ``n_bounds``, ``landscape``,
    ``calibrate``, ``residual_floor``, ``separability_width``, ``bootstrap_resamples``,
    ``bootstrap_seed``: :data:`impactid.rigs.pivoted.estimation.OPTIONS`; the drop rig's:
    :data:`impactid.rigs.drop.estimation.OPTIONS`); they are checked when given (an option no rig's
    estimate has, or options of different rigs, raise :class:`~impactid.rigs.base.OptionError`) and
    again against the rig of the recordings it runs on, whose defaults complete them.
    ``Pipeline(model=NAME, **options)`` holds every option of that rig's estimate. ``options=`` (pairs
    or a mapping), updated by the keywords, gives the options too: ``dataclasses.replace(pipeline,
    calibrate=False)`` is the pipeline with one option changed.

    An option reads as an attribute (``pipeline.fix_n``): the value given, else the default of the
    rig's estimate (of the estimates that have the option, when they agree and no model is given).

    Attributes
    ----------
    options : the options, ``(name, value)`` pairs (pairs of numbers as tuples): those given, or with
        ``model`` every option of that rig's estimate.
    model : the rig model whose estimate the options complete, or None.
    """

    options: tuple[tuple[str, Any], ...]
    model: str | None

    def __init__(self, model: str | None = None, options: Mapping[str, Any] | Sequence[tuple[str, Any]] = (),
                 **given: Any) -> None:
        # ``options`` (pairs or a mapping) updated by the keywords: what ``dataclasses.replace(pipeline,
        # fix_n=1.5)`` passes
        options = {**dict(options), **given}
        if model is not None:
            if model not in PLUGINS:
                raise OptionError(f"unknown rig model {model!r} (known: {', '.join(PLUGINS)})")
            items = estimate_options(rig_estimator(model, f"rig model {model!r}"), model, options)
        else:
            items = _check_unbound(options)
        object.__setattr__(self, "options", tuple(items.items()))
        object.__setattr__(self, "model", model)

    def __getattr__(self, name: str) -> Any:
        if name.startswith("_") or name in ("options", "model"):
            raise AttributeError(name)
        given = dict(self.__dict__.get("options", ()))
        if name in given:
            return given[name]
        if self.__dict__.get("model") is None:
            defaults = {repr(est.options[name]): est.options[name] for est in _estimators().values()
                        if name in est.options}
            if len(defaults) == 1:
                return next(iter(defaults.values()))
        raise AttributeError(f"the pipeline has no option {name!r}")

    def __repr__(self) -> str:
        text = ", ".join([f"model={self.model!r}"] * (self.model is not None) +
                         [f"{name}={value!r}" for name, value in self.options])
        return f"Pipeline({text})"

    def option_values(self) -> dict[str, Any]:
        """The options as a dict (name -> value)."""
        return dict(self.options)

    def to_dict(self) -> dict:
        """The options as JSON-ready data (pairs as lists)."""
        return options_record(self.option_values())

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], model: str | None = None) -> Pipeline:
        """The pipeline of :meth:`to_dict` (e.g. from a result's ``pipeline``)."""
        return cls(model=model, **{k: _frozen(v) for k, v in data.items()})

    def bind(self, model: str) -> Pipeline:
        """This pipeline with every option of rig ``model``'s estimate (its defaults where none is given).

        Raises
        ------
        OptionError
            when an option is not one of that rig's estimate, or its value is refused; when the
            pipeline holds the options of another rig's estimate.
        """
        if self.model is not None:
            if self.model != model:
                raise OptionError(f"the pipeline holds the options of the {self.model!r} rig's estimate; the "
                                  f"recordings are of the {model!r} rig")
            return self
        return Pipeline(model=model, **self.option_values())

    def prepare(self, recording, *, rig=None, name: str | None = None, keep_samples: bool = True) -> PreparedRecording:
        """Read and measure one recording by its rig's estimator: the first half of :meth:`run`.

        Parameters
        ----------
        recording : a :class:`~impactid.io.Recording` or the path of a recording file.
        rig : overrides the recording's rig (a rig dataclass or the path of a TOML rig file).
        name : the recording's name in messages and results when it has no file (default ``"recording 1"``).
        keep_samples : keep what only the figures need (the samples; rig P's per-event histories);
            False leaves a product that pickles small (what the tasks of :mod:`impactid.campaign`
            pass to the fits).

        Returns
        -------
        PreparedRecording
            the rig model, the recording's name and the rig's own product
            (:attr:`PreparedRecording.data <impactid.rigs.base.PreparedRecording.data>`).
        """
        rec = _read(recording, rig)
        model = rec.require_rig().model
        est = rig_estimator(model, rec.source or name or "recording")
        source = rec.source or name or "recording 1"
        data = est.prepare(rec, self.bind(model).option_values(), source)
        if not keep_samples and est.compact is not None:
            data = est.compact(data)
        return PreparedRecording(model=model, source=source, data=data)

    def run(self, recordings, *, rig=None, progress: Progress | None = None) -> Any:
        """Read and measure ``recordings`` (one rig model), then estimate the rig's contact law jointly.

        Parameters
        ----------
        recordings : one or several :class:`~impactid.io.Recording` objects or paths (several: joint fit).
        rig : overrides the recordings' rig: a rig dataclass, or the path of a TOML rig file, whose
            ``[operating]`` table also supplies or overrides the operating point.
        progress : callback ``(stage, fraction)`` for a progress display.

        Returns
        -------
        The rig's result (rig P: :class:`~impactid.rigs.pivoted.estimates.Estimate`; the drop rig:
        :class:`~impactid.rigs.drop.identify.DropFit`), with its notes, which are also issued here,
        each once, in the rig's warning category.

        Raises
        ------
        ImpactidError
            for recordings of different rig models (naming both), a rig impactid estimates nothing
            from (naming those it does), an option that rig's estimate does not have.
        """
        _status.stage("reading the recordings")  # what a terminal's status line says (impactid._status)
        recs = read_recordings(recordings, rig=rig)
        model = recordings_model(recs)
        rig_estimator(model, recs[0].source or "recording 1")
        self.bind(model)  # the options are checked before anything is measured
        prepared, left_out = [], []
        for k, rec in enumerate(recs):
            _status.stage(f"finding and reconstructing the impacts of recording {k + 1} of {len(recs)}")
            try:
                prepared.append(self.prepare(rec, name=f"recording {k + 1}"))
            except ImpactidError as exc:
                # a recording whose impacts cannot be measured does not take a joint fit with it: the
                # others are fitted and the result says which was left out and why
                if len(recs) == 1:
                    raise
                left_out.append(f"{rec.source or f'recording {k + 1}'} left out of the joint fit: {exc}")
        if not prepared:
            raise ImpactidError("no recording of the joint fit can be measured: " + "; ".join(left_out))
        if left_out:
            first = prepared[0]
            prepared[0] = replace(first, notes=tuple(left_out) + tuple(first.notes))
        return self.fit(prepared, progress=progress)

    def fit(self, prepared: Sequence[PreparedRecording], *, progress: Progress | None = None,
            warn: bool = True) -> Any:
        """Estimate the contact law from prepared recordings of one rig model: the second half of :meth:`run`
        (several: a joint fit).

        Parameters
        ----------
        prepared : the :meth:`prepare` products of one or several recordings of one rig.
        progress : callback ``(stage, fraction)`` for a progress display.
        warn : issue the result's notes as warnings of the rig's category (they are in the result
            either way).

        Returns
        -------
        The rig's result, as :meth:`run` (the same numbers for the same recordings and options).
        """
        prepared = list(prepared)
        if not prepared:
            raise ImpactidError("no recording given")
        first = prepared[0]
        other = next((p for p in prepared if p.model != first.model), None)
        if other is not None:
            raise ImpactidError(_mixed(first.source, first.model, other.source, other.model))
        est = rig_estimator(first.model, first.source)
        _status.stage("fitting the contact law")
        result = est.fit(prepared, self.bind(first.model).option_values(), progress)
        if warn:
            for message in dict.fromkeys(est.notes(result)):
                warnings.warn(message, est.warning, stacklevel=3)
        return result


def _mixed(source_a: str, model_a: str, source_b: str, model_b: str) -> str:
    return (f"a joint fit needs recordings of one rig model: {source_a} is a {model_a!r} recording, {source_b} a "
            f"{model_b!r} one (estimate each rig's recordings apart)")


def _read(recording, rig) -> Recording:
    if isinstance(recording, Recording):
        return recording.with_rig(rig) if rig is not None else recording
    return read_recording(recording, rig=rig)


def read_recordings(recordings, *, rig=None) -> list[Recording]:
    """The recordings of an estimate: :class:`~impactid.io.Recording` objects as they are (with ``rig``
    applied), paths read (their sizes checked against the memory first).

    Raises
    ------
    ImpactidError
        when none is given, or a file cannot be read (naming it).
    """
    if isinstance(recordings, (Recording, str)) or hasattr(recordings, "__fspath__"):
        recordings = [recordings]
    recordings = list(recordings)
    check_memory([r for r in recordings if isinstance(r, (str, os.PathLike))], "estimate")
    recs = [_read(r, rig) for r in recordings]
    if not recs:
        raise ImpactidError("no recording given")
    return recs


def recordings_model(recordings: Sequence[Recording]) -> str:
    """The rig model of recordings estimated jointly.

    Raises
    ------
    RecordingError
        a recording without a rig; recordings of different rig models (naming both).
    """
    models = [rec.require_rig().model for rec in recordings]
    for k, model in enumerate(models[1:], start=1):
        if model != models[0]:
            raise RecordingError(_mixed(recordings[0].source or "recording 1", models[0],
                                        recordings[k].source or f"recording {k + 1}", model))
    return models[0]


def _estimable(model) -> bool:
    """Whether impactid estimates a contact law from the recordings of rig ``model`` (a
    :class:`~impactid.rigs.base.RigModel`): whether it names an estimation module."""
    return model.estimation is not None


def estimate(recordings, *, rig=None, progress: Progress | None = None, **options: Any) -> Any:
    """Read and measure recordings, then estimate their rig's contact law (rig P: ``beta, n`` and the
    restitution law; the drop rig: ``k, beta, n``).

    A thin call on :class:`Pipeline` (which holds every option of the job and is recorded in the
    result's provenance): ``estimate(recs, rig=rig, progress=progress, **options)`` is
    ``Pipeline(**options).run(recs, rig=rig, progress=progress)``.

    Parameters
    ----------
    recordings : one or several :class:`~impactid.io.Recording` objects or paths (several: joint fit).
    rig : overrides the recordings' rig: rig parameters (e.g. :data:`~impactid.rigs.pivoted.SUNDAR2016`), or
        the path of a TOML rig file, whose ``[operating]`` table also supplies or overrides the
        operating point.
    progress : callback ``(stage, fraction)`` for a progress display.
    **options : options of the rig's estimate (rig P: ``residual``, ``fix_n``, ``method``, ``grid``,
        ``integration``, ``anchor``, ``c_bounds``, ``n_bounds``, ``landscape``, ``calibrate``, ...;
        :data:`impactid.rigs.pivoted.estimation.OPTIONS`).
    """
    return Pipeline(**options).run(recordings, rig=rig, progress=progress)

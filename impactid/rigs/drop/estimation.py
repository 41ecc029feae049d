"""The drop rig's estimate: ``k``, ``beta`` and ``n`` of the Hunt–Crossley contact from drop recordings.

What the generic estimate (``impactid estimate DROP1.h5 DROP2.h5``, :class:`impactid.pipeline.Pipeline`,
:mod:`impactid.campaign`) runs for recordings of the ``drop-impact`` rig, in two stages::

    prepare (one recording):   impacts found and measured (measure_impacts)
    fit (prepared recordings): fit_drop, jointly over the drops (several heights)

The result is the :class:`~impactid.rigs.drop.identify.DropFit` of :func:`~impactid.rigs.drop.identify.fit_drop`
(the shared :class:`~impactid.results.FitResult`), with the estimate's options in its provenance.
"""

from __future__ import annotations

import argparse
from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import Any

from impactid.rigs.base import Estimator, PreparedRecording, pipeline_provenance
from impactid.rigs.drop.arguments import ARGUMENTS, TITLE
from impactid.rigs.drop.commands import fit_figures
from impactid.rigs.drop.identify import N_STARTS, DropFit, fit_drop
from impactid.rigs.drop.measure import ImpactObservations, measure_impacts
from impactid.rigs.drop.parameters import ACCELERATION_CHANNEL, FORCE_CHANNEL, N_BOUNDS, N_MAX

__all__ = ["ESTIMATOR", "OPTIONS", "DropEstimateWarning", "check_options", "fit", "prepare"]

#: Every option of the drop rig's estimate and its default (:func:`~impactid.rigs.drop.identify.fit_drop`):
#:
#: * ``fix_n``: fix the damping index ``n`` [-] (None: fit it);
#: * ``channels``: the signals fitted (``impactor_acceleration``, ``contact_force``; None: those each
#:   recording has);
#: * ``max_impacts``: impacts used per recording, the first ones (None: all that are measured);
#: * ``speeds``: ``"fit"`` (onset speeds fitted with the contact) or ``"measured"`` (held);
#: * ``confidence``: coverage of the intervals [-];
#: * ``snr_min``: impacts whose peak is below this many noise standard deviations are left out [-];
#: * ``n_starts``: damping indices the fit starts from [-].
OPTIONS: Mapping[str, Any] = {
    "fix_n": None,
    "channels": None,
    "max_impacts": 4,
    "speeds": "fit",
    "confidence": 0.95,
    "snr_min": 20.0,
    "n_starts": tuple(N_STARTS),
}

#: The options that change what :func:`prepare` makes (the others change only the fit).
PREPARE_OPTIONS = ("max_impacts", "snr_min")

_CHANNELS = (ACCELERATION_CHANNEL, FORCE_CHANNEL)


class DropEstimateWarning(UserWarning):
    """A note of a drop estimate (issued by :meth:`impactid.pipeline.Pipeline.fit`)."""


def _number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def check_options(options: Mapping[str, Any]) -> dict[str, Any]:
    """Check the values of the full options (``ValueError`` naming the option); channel names as tuples."""
    out = dict(options)
    fix_n = out["fix_n"]
    if fix_n is not None and not (_number(fix_n) and 0.0 <= fix_n <= N_MAX):
        raise ValueError(f"fix_n must be a damping index in [0, {N_MAX:g}] or None, got {fix_n!r}")
    if out["speeds"] not in ("fit", "measured"):
        raise ValueError(f"speeds must be 'fit' or 'measured', got {out['speeds']!r}")
    if not (_number(out["confidence"]) and 0.0 < out["confidence"] < 1.0):
        raise ValueError(f"confidence must lie in (0, 1), got {out['confidence']!r}")
    max_impacts = out["max_impacts"]
    if max_impacts is not None and not (isinstance(max_impacts, int) and not isinstance(max_impacts, bool)
                                        and max_impacts >= 1):
        raise ValueError(f"max_impacts must be a positive integer or None, got {max_impacts!r}")
    if not (_number(out["snr_min"]) and out["snr_min"] > 0.0):
        raise ValueError(f"snr_min must be a positive number, got {out['snr_min']!r}")
    channels = out["channels"]
    if channels is not None:
        channels = (channels,) if isinstance(channels, str) else tuple(channels)
        unknown = [c for c in channels if c not in _CHANNELS]
        if unknown or not channels:
            raise ValueError(f"channels must name {', '.join(_CHANNELS)}; got {list(channels)!r}")
        out["channels"] = channels
    starts = out["n_starts"]
    starts = (starts,) if _number(starts) else tuple(starts)
    if not starts or not all(_number(s) and N_BOUNDS[0] <= s <= N_BOUNDS[1] for s in starts):
        raise ValueError(f"n_starts must be damping indices in [{N_BOUNDS[0]:g}, {N_BOUNDS[1]:g}], got {starts!r}")
    out["n_starts"] = starts
    return out


def prepare(recording, options: Mapping[str, Any], source: str) -> ImpactObservations:
    """Find and measure the impacts of one drop recording (:func:`~impactid.rigs.drop.measure.measure_impacts`)."""
    observed = measure_impacts(recording, max_impacts=options["max_impacts"], snr_min=options["snr_min"])
    return observed if observed.source == source else replace(observed, source=source)


def fit(prepared: Sequence[PreparedRecording], options: Mapping[str, Any], progress=None) -> DropFit:
    """``k``, ``beta`` and ``n`` from prepared drops, jointly (:func:`~impactid.rigs.drop.identify.fit_drop`);
    the prepared recordings' notes lead the result's. ``progress`` is not used (the fit is one search)."""
    observations = [replace(p.data, notes=p.notes + tuple(n for n in p.data.notes if n not in p.notes))
                    if p.notes else p.data for p in prepared]
    result = fit_drop(observations, fix_n=options["fix_n"], channels=options["channels"],
                      max_impacts=options["max_impacts"], speeds=options["speeds"], confidence=options["confidence"],
                      n_starts=options["n_starts"], snr_min=options["snr_min"])
    return replace(result, provenance=result.provenance + (pipeline_provenance(options),))


def to_dict(result: DropFit) -> dict:
    """The fit as JSON-ready data (the :class:`~impactid.results.FitResult` schema)."""
    return result.to_dict()


def summary(result: DropFit) -> list[str]:
    """The lines ``impactid estimate`` prints: one line on the data, then the fit report."""
    stats = result.statistics
    return [f"impactid estimate: {stats.get('n_recordings', 0)} drop recording(s), {stats.get('n_impacts', 0)} "
            f"impacts, channels {stats.get('channels', '')}"] + result.report().splitlines()


def _notes(result: DropFit) -> tuple[str, ...]:
    return tuple(result.notes)


def figures(result: DropFit, args: argparse.Namespace):
    """The figure of ``estimate --plots``: that of ``impactid drop fit``."""
    return fit_figures(result, args.plots)


# ARGUMENTS and TITLE are declared in the light impactid.rigs.drop.arguments (MODEL.estimate_arguments), so that
# ``impactid estimate --help`` does not import this module

#: What the generic estimate runs for the drop rig's recordings.
ESTIMATOR = Estimator(
    options=OPTIONS, arguments=ARGUMENTS, prepare=prepare, fit=fit, to_dict=to_dict, summary=summary, notes=_notes,
    warning=DropEstimateWarning, figures=figures, check=check_options, prepare_options=PREPARE_OPTIONS,
    title=TITLE)

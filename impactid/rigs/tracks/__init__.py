"""The tracked-ball rig: bounces of a ball filmed or motion-captured, from its positions against time.

A ball's track (2-D from a video, 3-D from stereo cameras or motion capture) shows its flights and
its bounces. Each bounce is fitted as two flights (gravity, quadratic drag and the Magnus force of
its spin) that meet at the contact, giving the velocities before and after, the normal restitution,
the tangential velocity ratio and the change of spin, with intervals; laws across bounces (normal:
constant or speed-dependent; tangential: a ratio, or a rigid ball with Coulomb friction and
sticking) are chosen by AIC or BIC. The modules follow the data:

* :mod:`~impactid.rigs.tracks.parameters`: the :class:`TrackedBall` and its air model, the
  table-tennis preset;
* :mod:`~impactid.rigs.tracks.readers`: Tracker exports, phyphox-like and plain CSV/TSV, the SpinDOE
  trajectories and their spin index (:func:`read_track` -> :class:`Track`);
* :mod:`~impactid.rigs.tracks.flight`: the equations of flight and a vectorised integrator;
* :mod:`~impactid.rigs.tracks.bounces`: finding bounces, fitting each (:class:`BounceFit`);
* :mod:`~impactid.rigs.tracks.laws`: the laws across bounces;
* :mod:`~impactid.rigs.tracks.rule`: the table-tennis rule as a band of restitution;
* :mod:`~impactid.rigs.tracks.analysis`: the whole job, :func:`analyse_tracks` -> :class:`TrackAnalysis`;
* :mod:`~impactid.rigs.tracks.figures`, :mod:`~impactid.rigs.tracks.commands` (``impactid tracks
  analyse``) and :mod:`~impactid.rigs.tracks.cli` (what it runs).

See ``docs/tracks.md``. Importing this package loads nothing of the rig; :data:`MODEL` and the names
below are built or imported on first use.
"""

from __future__ import annotations

from impactid.rigs.base import RigModel, lazy_attributes

__all__ = ["MODEL", "TABLE_TENNIS_BALL", "BounceFit", "Track", "TrackAnalysis", "TrackAnalysisError",
           "TrackFileError", "TrackParameterError", "TrackedBall", "air_model_share", "analyse_tracks",
           "find_bounces", "fit_bounce", "read_track", "rule_band"]

#: The rig's command by import path; impactid's generic estimate takes no tracks.
COMMANDS = "impactid.rigs.tracks.commands"
ESTIMATION = None
ESTIMATE_ARGUMENTS = None

#: The names of the rig's presets (``MODEL.presets``).
PRESET_NAMES = ("table-tennis-ball",)

_LAZY = {
    **dict.fromkeys(("TABLE_TENNIS_BALL", "TrackParameterError", "TrackedBall"), "impactid.rigs.tracks.parameters"),
    **dict.fromkeys(("Track", "TrackFileError", "read_track"), "impactid.rigs.tracks.readers"),
    **dict.fromkeys(("BounceFit", "find_bounces", "fit_bounce"), "impactid.rigs.tracks.bounces"),
    **dict.fromkeys(("TrackAnalysis", "TrackAnalysisError", "air_model_share", "analyse_tracks"),
                    "impactid.rigs.tracks.analysis"),
    "rule_band": "impactid.rigs.tracks.rule",
}


def _measure(tracks, **options):
    """:func:`~impactid.rigs.tracks.analysis.analyse_tracks` (imported on use: it loads numpy and SciPy)."""
    from impactid.rigs.tracks.analysis import analyse_tracks

    return analyse_tracks(tracks, **options)


def _model() -> RigModel:
    """The tracked ball behind the rig-model protocol: no cam, no compiled kernel; its measurement
    turns tracks into per-bounce restitution and its command is ``impactid tracks analyse``."""
    from impactid.rigs.tracks.parameters import MODEL_NAME, TRACKED_BALLS, TrackedBall

    return RigModel(
        name=MODEL_NAME,
        title="A ball's bounces from its tracked positions (Tracker, phyphox, CSV/TSV; drag, Magnus, friction)",
        citation="",
        parameters=TrackedBall,
        presets=TRACKED_BALLS,
        measure=_measure,
        commands=COMMANDS,
    )


__getattr__ = lazy_attributes(__name__, _LAZY, {"MODEL": _model})


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))

"""The bouncing-ball rig: restitution of a ball on a floor from the timing or the sound of its bounces.

A ball dropped on a floor bounces with flights that shrink by the coefficient of restitution; the
times of the impacts, heard by a phone (phyphox's "Acoustic stopwatch") or recorded as audio, are
enough to measure ``e`` as a function of the impact speed. The modules follow the data:

* :mod:`~impactid.rigs.ball.parameters`: the :class:`Ball` (mass, diameter, drag coefficient, air
  density, gravity) and presets (table tennis, golf, tennis);
* :mod:`~impactid.rigs.ball.readers`: phyphox exports (.xlsx, .xls, CSV, zip), CSV of times, WAV;
* :mod:`~impactid.rigs.ball.onsets`: impact clicks in audio;
* :mod:`~impactid.rigs.ball.sequence`: missed bounces, echoes, spurious and displaced triggers,
  release artefacts and junk, each with its reason;
* :mod:`~impactid.rigs.ball.flight`: exact inversion of a flight time into launch and landing
  speeds, with quadratic drag, buoyancy and added mass;
* :mod:`~impactid.rigs.ball.laws`: constant, linear and viscoelastic laws, cluster-robust errors,
  AIC/BIC, the chained trajectory fit;
* :mod:`~impactid.rigs.ball.analysis`: the whole job, :func:`analyse_bounces`;
* :mod:`~impactid.rigs.ball.figures`, :mod:`~impactid.rigs.ball.synth`, :mod:`~impactid.rigs.ball.commands`
  (``impactid bounces``, its arguments) and :mod:`~impactid.rigs.ball.cli` (what it runs).

See ``docs/bounces.md`` for the method, the formats and the results on real recordings. Importing
this package loads nothing of the rig: the names below are imported from their modules on first use
and :data:`MODEL` is built on first use, so that building the command line (which reads
:data:`COMMANDS`) loads neither numpy nor SciPy.
"""

from __future__ import annotations

from impactid.rigs.base import RigModel, lazy_attributes

__all__ = [
    "BALL_PRESETS", "GOLF", "MODEL", "LAWS", "TABLE_TENNIS", "TENNIS", "Audio", "Ball", "BallParameterError",
    "BounceAnalysis", "BounceAnalysisError", "BounceFileError", "BounceRecording", "ChainedFit", "CleanedSequence",
    "FlightConstants", "Law", "LawFit", "Onsets", "analyse_bounces", "ball_preset", "clean_sequence",
    "detect_onsets", "fit_chained", "fit_law", "flight_constants", "flight_time", "get_law", "invert_flights",
    "landing_speed", "launch_speed", "read_audio", "read_bounces", "read_event_csv", "read_many", "read_phyphox",
    "read_wav", "restitution_from_flights", "select_law",
]

#: The rig's command by import path (:data:`MODEL`'s field, read by the registry without building
#: :data:`MODEL`); impactid's generic estimate takes no bounce recordings.
COMMANDS = "impactid.rigs.ball.commands"
ESTIMATION = None
ESTIMATE_ARGUMENTS = None

#: The names of the rig's presets, the default first (``MODEL.presets``): ``--rig NAME`` finds its rig
#: without building the other rigs' models.
PRESET_NAMES = ("table-tennis", "pingpong", "ping-pong", "tabletennis", "golf", "tennis")

#: Where the public names live, imported on first use.
_LAZY = {
    **dict.fromkeys(("BounceAnalysis", "BounceAnalysisError", "analyse_bounces"), "impactid.rigs.ball.analysis"),
    **dict.fromkeys(("FlightConstants", "flight_constants", "flight_time", "invert_flights", "landing_speed",
                     "launch_speed", "restitution_from_flights"), "impactid.rigs.ball.flight"),
    **dict.fromkeys(("LAWS", "ChainedFit", "Law", "LawFit", "fit_chained", "fit_law", "get_law", "select_law"),
                    "impactid.rigs.ball.laws"),
    **dict.fromkeys(("Onsets", "detect_onsets"), "impactid.rigs.ball.onsets"),
    **dict.fromkeys(("BALL_PRESETS", "GOLF", "TABLE_TENNIS", "TENNIS", "Ball", "BallParameterError", "ball_preset"),
                    "impactid.rigs.ball.parameters"),
    **dict.fromkeys(("Audio", "BounceFileError", "BounceRecording", "read_audio", "read_bounces", "read_event_csv",
                     "read_many", "read_phyphox", "read_wav"), "impactid.rigs.ball.readers"),
    **dict.fromkeys(("CleanedSequence", "clean_sequence"), "impactid.rigs.ball.sequence"),
}


def _measure(sources, **options):
    """:func:`~impactid.rigs.ball.analysis.analyse_bounces` (imported on use: it loads numpy and SciPy)."""
    from impactid.rigs.ball.analysis import analyse_bounces

    return analyse_bounces(sources, **options)


def _model() -> RigModel:
    """The bouncing ball behind the rig-model protocol: no cam, no compiled kernel; its measurement model
    turns bounce recordings into per-bounce restitution and its command is ``impactid bounces``. Built on
    first use of :data:`MODEL` (registered in :mod:`impactid.rigs.registry`)."""
    from impactid.rigs.ball.parameters import BALL_PRESETS, Ball

    return RigModel(
        name="bouncing-ball",
        title="A ball bouncing on a floor, timed by the sound of its bounces (phyphox, CSV, WAV)",
        citation="",
        parameters=Ball,
        presets=BALL_PRESETS,
        measure=_measure,
        commands=COMMANDS,
    )


__getattr__ = lazy_attributes(__name__, _LAZY, {"MODEL": _model})


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))

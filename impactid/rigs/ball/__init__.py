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
* :mod:`~impactid.rigs.ball.figures`, :mod:`~impactid.rigs.ball.synth`, :mod:`~impactid.rigs.ball.cli`.

See ``docs/bounces.md`` for the method, the formats and the results on real recordings.
"""

from impactid.rigs.ball.analysis import BounceAnalysis, BounceAnalysisError, analyse_bounces
from impactid.rigs.ball.flight import (
    FlightConstants,
    flight_constants,
    flight_time,
    invert_flights,
    landing_speed,
    launch_speed,
    restitution_from_flights,
)
from impactid.rigs.ball.laws import LAWS, ChainedFit, Law, LawFit, fit_chained, fit_law, get_law, select_law
from impactid.rigs.ball.onsets import Onsets, detect_onsets
from impactid.rigs.ball.parameters import (
    BALL_PRESETS,
    GOLF,
    TABLE_TENNIS,
    TENNIS,
    Ball,
    BallParameterError,
    ball_preset,
)
from impactid.rigs.ball.readers import (
    Audio,
    BounceFileError,
    BounceRecording,
    read_audio,
    read_bounces,
    read_event_csv,
    read_many,
    read_phyphox,
    read_wav,
)
from impactid.rigs.ball.sequence import CleanedSequence, clean_sequence

__all__ = [
    "BALL_PRESETS", "GOLF", "MODEL", "LAWS", "TABLE_TENNIS", "TENNIS", "Audio", "Ball", "BallParameterError",
    "BounceAnalysis", "BounceAnalysisError", "BounceFileError", "BounceRecording", "ChainedFit", "CleanedSequence",
    "FlightConstants", "Law", "LawFit", "Onsets", "analyse_bounces", "ball_preset", "clean_sequence",
    "detect_onsets", "fit_chained", "fit_law", "flight_constants", "flight_time", "get_law", "invert_flights",
    "landing_speed", "launch_speed", "read_audio", "read_bounces", "read_event_csv", "read_many", "read_phyphox",
    "read_wav", "restitution_from_flights", "select_law",
]

# ---- the rig model (registered in impactid.rigs.registry) ----
from impactid.rigs.base import RigModel  # noqa: E402

#: The bouncing ball behind the rig-model protocol: no cam, no compiled kernel; its measurement model
#: turns bounce recordings into per-bounce restitution and its command is ``impactid bounces``.
MODEL = RigModel(
    name="bouncing-ball",
    title="A ball bouncing on a floor, timed by the sound of its bounces (phyphox, CSV, WAV)",
    citation="",
    parameters=Ball,
    presets=BALL_PRESETS,
    measure=analyse_bounces,
    commands="impactid.rigs.ball.cli",
)

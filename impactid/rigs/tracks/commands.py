"""The commands the tracked-ball rig contributes (``RigModel.commands`` names this module):
``impactid tracks analyse TRACK...`` and its implementation of the shared ``impactid synth``
(``--rig tracked-ball``, or its preset's name), which writes a synthetic track that ``tracks analyse``
reads (their arguments as data; their runs in :mod:`impactid.rigs.tracks.cli`).

Light: building the command line imports this module only; the readers and the analysis (numpy,
SciPy, pandas) are imported when the command runs.
"""

from __future__ import annotations

import argparse

from impactid.commandline import (
    FIGURE_FORMAT,
    REPORT,
    SEED,
    SYNTH_OUT,
    integer_in,
    nonnegative,
    number,
    number_up_to,
    pair,
    positive,
)
from impactid.rigs.base import Argument, CommandSpec

__all__ = ["COMMANDS", "SYNTH", "SYNTH_SUFFIXES", "command", "synth_command"]

#: The suffixes ``impactid synth --rig tracked-ball --out`` writes (the keys of
#: :data:`impactid.rigs.tracks.synth.TRACK_FORMATS`, which loads numpy).
SYNTH_SUFFIXES = (".csv", ".tsv", ".txt")


def _spin(text: str) -> tuple[float, ...]:
    parts = [p for p in text.replace(";", ",").split(",") if p.strip()]
    if len(parts) not in (1, 3):
        raise argparse.ArgumentTypeError(f"one value (2-D) or three (WX,WY,WZ) in rad/s, got {text!r}")
    return tuple(number(p) for p in parts)


def _band(text: str) -> tuple[float, float]:
    parts = text.split(",")
    if len(parts) != 2:
        raise argparse.ArgumentTypeError(f"two speeds LOW,HIGH in m/s, got {text!r}")
    lo, hi = (nonnegative(p) for p in parts)
    if not lo < hi:
        raise argparse.ArgumentTypeError(f"LOW must be below HIGH, got {text!r}")
    return lo, hi


_coefficient = number_up_to(10.0)
_window = number_up_to(2.0, zero=False, unit="s")


def _arguments() -> tuple[Argument, ...]:
    return (
        Argument(("tracks",), dict(metavar="TRACK", nargs="+",
                                   help="track files (Tracker export, phyphox-like or plain CSV/TSV of t, x, y[, z]); "
                                        "several are analysed together, in one frame")),
        Argument(("--time",), dict(default=None, metavar="COL", help="the time column (name or 1-based number)")),
        Argument(("--x",), dict(default=None, metavar="COL", help="the x column (name or number)")),
        Argument(("--y",), dict(default=None, metavar="COL", help="the y column (name or number)")),
        Argument(("--z",), dict(default=None, metavar="COL", help="the z column (name or number)")),
        Argument(("--up",), dict(choices=("x", "y", "z"), default=None,
                                 help="the vertical axis of the files (default z in 3-D, y in 2-D)")),
        Argument(("--units",), dict(default=None, metavar="UNIT",
                                    help="length unit of the positions (m, cm, mm, in, ft; default: the header's, "
                                         "else m)")),
        Argument(("--time-units",), dict(default=None, metavar="UNIT",
                                         help="time unit (s, ms, us; default: the header's, else s)")),
        Argument(("--spin",), dict(type=_spin, default=None, metavar="W",
                                   help="spin before the bounce [rad/s] in the files' axes: WX,WY,WZ (3-D) or one "
                                        "value (2-D, counter-clockwise); default: a spin index (index.csv) beside "
                                        "the files, else 0")),
        Argument(("--spin-after",), dict(action="store_true",
                                         help="the spin given or indexed was measured after the bounce")),
        Argument(("--no-magnus",), dict(action="store_true", help="flights without the Magnus force")),
        Argument(("--surface-height",), dict(type=number, default=None, metavar="M",
                                             help="height of the surface in the files' frame [m] (default: estimated "
                                                  "from where the fitted flights meet)")),
        Argument(("--surface",), dict(choices=("auto", "plane", "flat"), default="auto",
                                      help="an estimated surface: a tilted plane when BIC prefers it (auto, the "
                                           "default), always (plane) or horizontal (flat)")),
        Argument(("--mass",), dict(type=positive, default=None, metavar="KG", help="ball mass [kg] (default 0.0027)")),
        Argument(("--diameter",), dict(type=positive, default=None, metavar="M",
                                       help="ball diameter [m] (default 0.040)")),
        Argument(("--drag-coefficient",), dict(type=_coefficient, default=None, metavar="CD",
                                               help="drag coefficient (default 0.45)")),
        Argument(("--lift-scale",), dict(type=_coefficient, default=None, metavar="F",
                                         help="factor on the lift coefficient of Sawicki, Hubbard & Stronge (2003), "
                                              "C_L = 1.5 S (S <= 0.1), 0.09 + 0.6 S, S = R|omega|/|v| (default 1)")),
        Argument(("--air-density",), dict(type=nonnegative, default=None, metavar="KG/M3",
                                          help="air density [kg/m^3] (default 1.204)")),
        Argument(("--window",), dict(type=_window, default=None, metavar="S",
                                     help="flight fitted on each side of a bounce [s] (default 0.12)")),
        Argument(("--min-flight",), dict(type=integer_in(3, 1000), default=None, metavar="N",
                                         help="samples of flight each side of a bounce needs (default 5)")),
        Argument(("--speed-band",), dict(type=_band, default=None, metavar="LOW,HIGH",
                                         help="normal impact speeds of the restitution compared with the table-tennis "
                                              "rule [m/s] (default 2,3)")),
        Argument(("--criterion",), dict(choices=("bic", "aic"), default="bic",
                                        help="how the laws are chosen (default bic)")),
        Argument(("--no-rule",), dict(action="store_true", help="skip the table-tennis rule's band")),
        Argument(("--no-air-share",), dict(action="store_true",
                                           help="skip the air model's share of the uncertainty (by default the lift "
                                                "scale is estimated from the tracks and every bounce refitted with the "
                                                "drag coefficient and the lift scale at the ends of their ranges)")),
        Argument(("--out",), dict(metavar="RESULT.json", default=None, help="write the result as JSON (atomically)")),
        Argument(("--plots",), dict(metavar="DIR", default=None, help="write the figures into DIR")),
        FIGURE_FORMAT,
        REPORT,
        Argument(("--json",), dict(action="store_true", help="print the result as JSON")),
    )


def _synth_arguments() -> tuple[Argument, ...]:
    """The tracked ball's arguments of ``impactid synth`` (``--height`` and ``--bounce-law`` are shared
    with the bouncing ball's, ``--mu`` with rig P's, ``--seed`` and ``--out`` with every rig's: the first
    rig's declaration of a shared flag wins, so the tracked ball's own help for them is in docs/synthetic.md)."""
    return (
        Argument(("--height",), {"type": nonnegative, "default": None, "metavar": "M",
                                 "help": "tracked-ball: release height of the ball's bottom above the surface "
                                         "(default 0.305)"}),
        Argument(("--bounce-law",), {"type": pair, "default": None, "metavar": "E0,GAMMA",
                                     "help": "tracked-ball: normal restitution e = E0 - GAMMA v, v the normal impact "
                                             "speed [m/s] (default 0.9,0)"}),
        Argument(("--mu",), {"type": nonnegative, "default": None,
                             "help": "tracked-ball: Coulomb friction coefficient of the bounces (default 0.25)"}),
        Argument(("--horizontal-speed",), {"type": number, "default": None, "metavar": "M/S",
                                           "help": "tracked-ball: horizontal speed at the release, along x [m/s] "
                                                   "(default 0.5)"}),
        Argument(("--spin",), {"type": _spin, "default": None, "metavar": "W",
                               "help": "tracked-ball: spin at the release [rad/s]: one value, counter-clockwise in "
                                       "the x-y plane of a 2-D track (t, x, y; y up), or WX,WY,WZ for a 3-D track "
                                       "(t, x, y, z; z up) (default 0, 2-D)"}),
        Argument(("--bounces",), {"type": integer_in(1, 1000), "default": None, "metavar": "N",
                                  "help": "tracked-ball: number of bounces; the track ends at the next touchdown "
                                          "(default 3)"}),
        Argument(("--frame-rate",), {"type": positive, "default": None, "metavar": "FPS",
                                     "help": "tracked-ball: frames per second (default 240, a phone's slow motion)"}),
        Argument(("--position-noise",), {"type": nonnegative, "default": None, "metavar": "M",
                                         "help": "tracked-ball: standard deviation of each tracked coordinate [m] "
                                                 "(default 0.001)"}),
        SEED, SYNTH_OUT,
    )


def run(args, model) -> int:
    """Run ``impactid tracks analyse`` (:func:`impactid.rigs.tracks.cli.run`, imported now)."""
    from impactid.rigs.tracks.cli import run as run_tracks

    return run_tracks(args)


def run_synth(args, model) -> int:
    """Run ``impactid synth --rig tracked-ball`` (:func:`impactid.rigs.tracks.cli.run_synth`, imported now)."""
    from impactid.rigs.tracks.cli import run_synth as run_tracks_synth

    return run_tracks_synth(args)


def synth_command() -> CommandSpec:
    """The tracked ball's ``impactid synth`` (``--rig tracked-ball`` or its preset's name)."""
    return CommandSpec(
        group="", name="synth", help="write a synthetic track of a bouncing, spinning ball (CSV, TSV, Tracker .txt)",
        arguments=_synth_arguments(), run=run_synth, rig_argument="resolve")


def command() -> CommandSpec:
    """``impactid tracks analyse``."""
    return CommandSpec(
        group="tracks", name="analyse",
        help="bounces of a tracked ball: restitution, tangential ratio, spin change, laws (Tracker, CSV/TSV)",
        description="Every bounce of ball tracks (positions against time, 2-D or 3-D) fitted as two flights with "
                    "gravity, drag and the Magnus force meeting at the surface: the normal restitution, the "
                    "tangential velocity ratio and the change of spin per bounce with intervals, laws across "
                    "bounces chosen by AIC/BIC, and the table-tennis rule's band through the same air model.",
        arguments=_arguments(), run=run)


#: The tracked ball's ``impactid synth``.
SYNTH = synth_command()

#: The commands the tracked-ball rig contributes.
COMMANDS = (command(), SYNTH)

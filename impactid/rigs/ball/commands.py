"""The command the bouncing-ball rig contributes, ``impactid bounces`` (``RigModel.commands`` names
this module): its arguments as data, its run in :mod:`impactid.rigs.ball.cli`.

Light: building the command line (``impactid --help``, ``impactid bounces --help``) imports this
module and :mod:`~impactid.rigs.ball.parameters` only; the analysis (numpy, SciPy, the readers) is
imported when the command runs. The choices of ``--law`` are written out here: they are the names
of :data:`impactid.rigs.ball.laws.LAWS` (``tests/test_package.py`` checks that they agree).
"""

from __future__ import annotations

import argparse

from impactid.commandline import nonnegative, positive
from impactid.rigs.ball.parameters import ball_preset
from impactid.rigs.base import Argument, CommandSpec

__all__ = ["COMMANDS", "LAWS", "command"]

#: The laws ``--law`` names (the names of :data:`impactid.rigs.ball.laws.LAWS`, which loads numpy).
LAWS = ("constant", "linear", "viscoelastic")


def _ball_name(text: str) -> str:
    try:
        return ball_preset(text).name
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _drag_coefficient(text: str) -> float:
    value = nonnegative(text)
    if value > 10.0:
        raise argparse.ArgumentTypeError(f"must lie in [0, 10], got {text!r}")
    return value


def _arguments() -> tuple[Argument, ...]:
    """The arguments of ``impactid bounces``."""
    return (
        Argument(("files",), dict(metavar="FILE", nargs="+", help="one drop per file")),
        Argument(("--ball",), dict(type=_ball_name, default=None, metavar="NAME",
                                   help="preset ball: pingpong (table-tennis), golf, tennis")),
        Argument(("--mass",), dict(type=positive, default=None, metavar="KG", help="mass of a custom ball [kg]")),
        Argument(("--diameter",), dict(type=positive, default=None, metavar="M",
                                       help="diameter of a custom ball [m]")),
        Argument(("--drag-coefficient",), dict(type=_drag_coefficient, default=None, metavar="CD",
                                               help="drag coefficient (default: the preset's; 0.42 custom)")),
        Argument(("--air-density",), dict(type=nonnegative, default=None, metavar="KG/M3",
                                          help="air density [kg/m^3] (default 1.204)")),
        Argument(("--gravity",), dict(type=positive, default=None, metavar="M/S2",
                                      help="gravitational acceleration [m/s^2] (default 9.80665)")),
        Argument(("--no-drag",), dict(action="store_true",
                                      help="analyse the flights without air even for a known ball")),
        Argument(("--law",), dict(choices=["auto", *LAWS], default="auto",
                                  help="law to report: auto (selected by --criterion) or one by name")),
        Argument(("--criterion",), dict(choices=["bic", "aic"], default="bic",
                                        help="model selection criterion (default bic)")),
        Argument(("--no-chained",), dict(action="store_true", help="skip the chained trajectory fits (faster)")),
        Argument(("--out",), dict(metavar="RESULT.json", help="write the result as JSON (atomically)")),
        Argument(("--plots",), dict(metavar="DIR", help="write figures (restitution, intervals, audio onsets)")),
        Argument(("--json",), dict(action="store_true", help="print the result as JSON")),
    )


def run(args, model) -> int:
    """Run ``impactid bounces`` (:func:`impactid.rigs.ball.cli.run`, imported now: it loads the analysis)."""
    from impactid.rigs.ball.cli import run as run_bounces

    return run_bounces(args)


def command() -> CommandSpec:
    """``impactid bounces``: the command the bouncing-ball rig contributes to the command line."""
    return CommandSpec(
        group="", name="bounces",
        help="restitution e(v) of a ball on a floor from bounce timings (phyphox exports, CSV, WAV)",
        description="Restitution of a ball on a floor from the times of its bounces: phyphox 'Acoustic "
                    "stopwatch' exports (.xlsx, .xls, CSV, zip), a CSV of event times, or WAV audio. Several "
                    "files are several drops of one ball on one surface.",
        arguments=_arguments(), run=run)


#: The commands the bouncing-ball rig contributes (``RigModel.commands`` names this module).
COMMANDS = (command(),)

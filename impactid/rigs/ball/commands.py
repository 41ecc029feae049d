"""The commands the bouncing-ball rig contributes (``RigModel.commands`` names this module):
``impactid bounces`` (its arguments as data, its run in :mod:`impactid.rigs.ball.cli`) and its
implementation of the shared ``impactid synth`` (``--rig bouncing-ball``, or a ball's preset name:
``--rig pingpong``), which writes a synthetic drop that ``impactid bounces`` reads
(:func:`impactid.rigs.ball.synth.synth_drop` and :func:`~impactid.rigs.ball.synth.write_drop`).

Light: building the command line (``impactid --help``, ``impactid bounces --help``) imports this
module and :mod:`~impactid.rigs.ball.parameters` only; the analysis (numpy, SciPy, the readers) and
the synthesis are imported when a command runs. The choices of ``--law`` are written out here: they
are the names of :data:`impactid.rigs.ball.laws.LAWS` (``tests/test_package.py`` checks that they agree).
"""

from __future__ import annotations

import argparse
import math

from impactid.commandline import (
    FIGURE_FORMAT,
    REPORT,
    SEED,
    SYNTH_OUT,
    UsageError,
    check_out_suffix,
    check_outputs,
    nonnegative,
    pair,
    positive,
    refuse_other_rigs_options,
)
from impactid.rigs.ball.parameters import ball_preset
from impactid.rigs.base import Argument, CommandSpec, argument_dests

__all__ = ["COMMANDS", "LAWS", "command", "synth_command"]

#: The rig's model name (``MODEL.name``).
MODEL_NAME = "bouncing-ball"

#: The suffixes ``impactid synth --rig bouncing-ball --out`` writes (the keys of
#: :data:`impactid.rigs.ball.synth.DROP_FORMATS`, which loads numpy).
SYNTH_SUFFIXES = (".csv", ".xlsx", ".wav")

#: Largest trigger jitter ``--jitter`` takes [s] (a tenth of the shortest flight a drop records).
MAX_JITTER_S = 0.01

#: The laws ``--law`` names (the names of :data:`impactid.rigs.ball.laws.LAWS`, which loads numpy).
LAWS = ("constant", "linear", "viscoelastic")


def _ball_name(text: str) -> str:
    try:
        return ball_preset(text).name
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _audio_channel(text: str) -> str | int:
    if text.strip().lower() == "mix":
        return "mix"
    if not text.strip().isdigit():
        raise argparse.ArgumentTypeError(f"must be 'mix' or a channel number (0 = the first), got {text!r}")
    return int(text)


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
        Argument(("--audio-channel",), dict(type=_audio_channel, default="mix", metavar="mix|N",
                                            help="audio: mix the channels (default) or use channel N (0 = first)")),
        Argument(("--law",), dict(choices=["auto", *LAWS], default="auto",
                                  help="law to report: auto (selected by --criterion) or one by name")),
        Argument(("--criterion",), dict(choices=["bic", "aic"], default="bic",
                                        help="model selection criterion (default bic)")),
        Argument(("--no-chained",), dict(action="store_true", help="skip the chained trajectory fits (faster)")),
        Argument(("--out",), dict(metavar="RESULT.json", help="write the result as JSON (atomically)")),
        Argument(("--plots",), dict(metavar="DIR", help="write figures (restitution, intervals, audio onsets)")),
        FIGURE_FORMAT,
        REPORT,
        Argument(("--json",), dict(action="store_true", help="print the result as JSON")),
    )


def run(args, model) -> int:
    """Run ``impactid bounces`` (:func:`impactid.rigs.ball.cli.run`, imported now: it loads the analysis)."""
    from impactid.rigs.ball.cli import run as run_bounces

    return run_bounces(args)


def _jitter(text: str) -> float:
    value = nonnegative(text)
    if value > MAX_JITTER_S:
        raise argparse.ArgumentTypeError(f"must lie in [0, {MAX_JITTER_S:g}] s, got {text!r}")
    return value


def _synth_arguments() -> tuple[Argument, ...]:
    """The bouncing ball's arguments of ``impactid synth`` (``--height`` is shared with drop-impact's,
    ``--seed`` and ``--out`` with every rig's; the first rig's declaration of a shared flag wins, and the
    ball's comes before the drop rig's)."""
    return (
        Argument(("--ball",), dict(type=_ball_name, default=None, metavar="NAME",
                                   help="bouncing-ball: preset ball, pingpong (table-tennis, the default), golf or "
                                        "tennis (or name it with --rig)")),
        Argument(("--height",), {"type": nonnegative, "default": None, "metavar": "M",
                                 "help": "drop height [m]: bouncing-ball: release height of the ball's bottom above "
                                         "the floor (default 0.3); tracked-ball: the same (default 0.305); "
                                         "drop-impact: fall of the contact point to the contact surface (default: "
                                         "the rig file's [operating] drop_height_m)"}),
        Argument(("--bounce-law",), {"type": pair, "default": None, "metavar": "E0,GAMMA",
                                     "help": "bouncing-ball: restitution e = E0 - GAMMA v, v the impact speed [m/s] "
                                             "(default 0.96,0.02); tracked-ball: the same, v the normal impact "
                                             "speed (default 0.9,0)"}),
        Argument(("--jitter",), {"type": _jitter, "default": 0.0, "metavar": "S",
                                 "help": "bouncing-ball: standard deviation of the trigger times [s] (default 0; "
                                         "a phone's acoustic stopwatch: about 2e-4)"}),
        Argument(("--faults",), {"action": "store_true",
                                 "help": "bouncing-ball: add a stopwatch's faults (a release click, a missed bounce, "
                                         "an echo, a spurious trigger, two junk events)"}),
        SEED, SYNTH_OUT,
    )


def _synth_ball(args):
    """The ball of ``impactid synth``: ``--ball``, else the preset ``--rig`` named (table tennis for the
    model's name); a ``--ball`` that contradicts a preset named by ``--rig`` is refused."""
    named = args.resolved_rig.rig
    if args.ball is None:
        return named
    ball = ball_preset(args.ball)
    if args.rig is not None and args.rig.casefold() != MODEL_NAME and ball.name != named.name:
        raise UsageError(f"argument --ball: {args.ball!r} contradicts --rig {args.rig} (the {named.name} ball)")
    return ball


def run_synth(args, model) -> int:
    """``impactid synth --rig bouncing-ball``: a synthetic drop (the times of its bounces) as CSV, phyphox
    Excel export or WAV audio, for ``impactid bounces``."""
    from impactid.rigs.ball.synth import DEFAULT_BOUNCE_LAW, DEFAULT_HEIGHT, STOPWATCH_FAULTS, synth_drop, write_drop

    refuse_other_rigs_options(args, argument_dests(SYNTH.arguments), command="synth", model_name=MODEL_NAME,
                              hints={"noise": " (the trigger timing noise is --jitter)"})
    ball = _synth_ball(args)
    height = DEFAULT_HEIGHT if args.height is None else args.height
    if not 0.02 <= height <= 20.0:
        raise UsageError(f"argument --height: a ball's release height must lie in [0.02, 20] m, got {height:g}")
    law, params = DEFAULT_BOUNCE_LAW
    if args.bounce_law is not None:
        e0, gamma = args.bounce_law
        params = {"e0": e0, "gamma": gamma}
        if not (0.0 < e0 <= 1.0 and gamma >= 0.0 and e0 - gamma * math.sqrt(2.0 * 9.81 * height) > 0.3):
            raise UsageError(f"argument --bounce-law: e = {e0:g} - {gamma:g} v needs 0 < E0 <= 1, GAMMA >= 0 and e "
                             f"above 0.3 at the first impact (a drop with a few bounces at least)")
    check_out_suffix(args.out, SYNTH_SUFFIXES, "a drop")
    check_outputs(args, [])
    faults = STOPWATCH_FAULTS if args.faults else {}
    drop = synth_drop(law, params, seed=args.seed, ball=ball, height=height, jitter=args.jitter, **faults)
    write_drop(args.out, drop, seed=args.seed)
    e = drop.restitution
    print(f"{args.out}: {len(drop.times)} events of a {ball.name} ball dropped from {height:g} m, "
          f"{drop.true_times.size} impacts (e {e.max():.3f} to {e.min():.3f})")
    return 0


def synth_command() -> CommandSpec:
    """The bouncing ball's ``impactid synth`` (``--rig bouncing-ball`` or a ball preset's name)."""
    return CommandSpec(
        group="", name="synth", help="write a synthetic drop of a ball: its bounce times (CSV, phyphox .xlsx, WAV)",
        arguments=_synth_arguments(), run=run_synth, rig_argument="resolve")


def command() -> CommandSpec:
    """``impactid bounces``: the command the bouncing-ball rig contributes to the command line."""
    return CommandSpec(
        group="", name="bounces",
        help="restitution e(v) of a ball on a floor from bounce timings (phyphox exports, CSV, audio: WAV, FLAC, Ogg)",
        description="Restitution of a ball on a floor from the times of its bounces: phyphox 'Acoustic "
                    "stopwatch' exports (.xlsx, .xls, CSV, zip), a CSV of event times, or audio (WAV, FLAC, "
                    "Ogg). Several files are several drops of one ball on one surface.",
        arguments=_arguments(), run=run)


#: The bouncing ball's ``impactid synth``.
SYNTH = synth_command()

#: The commands the bouncing-ball rig contributes (``RigModel.commands`` names this module).
COMMANDS = (command(), SYNTH)

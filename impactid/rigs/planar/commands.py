"""The commands the planar-impact rig contributes (``RigModel.commands`` names this module):
``impactid planar fit``, ``impactid planar predict`` and its implementation of the shared ``impactid
synth`` (``--rig planar-impact``, a body's preset name or a rig file), which writes a synthetic table
of impacts that ``planar fit`` reads (their arguments as data, their runs in
:mod:`impactid.rigs.planar.cli`).

Light: building the command line imports this module only; the readers and the fits (NumPy, pandas,
SciPy) are imported when a command runs. The choices of ``--law`` are written out here: they are the
names of :data:`impactid.rigs.planar.laws.LAWS` (a test checks that they agree).
"""

from __future__ import annotations

import argparse

from impactid.commandline import (
    FIGURE_FORMAT,
    REPORT,
    SEED,
    SYNTH_OUT,
    fraction,
    integer_in,
    nonnegative,
    number,
    pair,
    positive,
)
from impactid.rigs.base import Argument, CommandSpec

__all__ = ["BODIES", "COMMANDS", "LAWS", "MODEL_NAME", "RULES", "SYNTH", "SYNTH_SUFFIXES"]

#: The rig's model name (``MODEL.name``).
MODEL_NAME = "planar-impact"

#: The laws ``impactid planar fit --law`` names (:data:`impactid.rigs.planar.laws.LAWS`, which loads NumPy).
LAWS = ("newton-constant-stick", "newton-constant-et", "newton-linear-stick", "newton-linear-et",
        "chatterjee-ruina-constant-stick", "chatterjee-ruina-constant-et", "chatterjee-ruina-linear-stick",
        "chatterjee-ruina-linear-et")

#: The impact rules ``impactid synth --rig planar-impact --impact-rule`` names
#: (:data:`impactid.rigs.planar.laws.RULES`).
RULES = ("newton", "chatterjee-ruina")

#: The suffixes ``impactid synth --rig planar-impact --out`` writes
#: (:data:`impactid.rigs.planar.synth.TABLE_FORMATS`).
SYNTH_SUFFIXES = (".csv", ".tsv")

#: The named bodies ``--body`` takes (the keys of :data:`impactid.rigs.planar.parameters.PRESETS`).
BODIES = ("mcube-ellipse",)


def _confidence(text: str) -> float:
    value = positive(text)
    if not value < 1.0:
        raise argparse.ArgumentTypeError(f"must lie in (0, 1), got {text!r}")
    return value


_BODY = (
    Argument(("--body",), dict(choices=BODIES, default=None,
                               help="a named body: mcube-ellipse (Fazeli et al. 2017: 36.4 g, k_g 19.2 mm)")),
    Argument(("--rig-file",), dict(default=None, metavar="RIG.toml",
                                   help="TOML rig file of the body ([rig] model = \"planar-impact\")")),
    Argument(("--mass",), dict(type=positive, default=None, metavar="KG", help="mass of the body [kg]")),
    Argument(("--radius-of-gyration",), dict(type=positive, default=None, metavar="M",
                                             help="radius of gyration about the centre of mass [m]")),
)


def run_fit(args, model) -> int:
    """Run ``impactid planar fit`` (:func:`impactid.rigs.planar.cli.run_fit`, imported now)."""
    from impactid.rigs.planar.cli import run_fit as run

    return run(args)


def run_predict(args, model) -> int:
    """Run ``impactid planar predict`` (:func:`impactid.rigs.planar.cli.run_predict`, imported now)."""
    from impactid.rigs.planar.cli import run_predict as run

    return run(args)


FIT = CommandSpec(
    group="planar", name="fit", help="fit an impact law with friction to a table of planar impacts",
    description="Fit impact laws (Newton or Chatterjee-Ruina restitution, constant or speed-dependent; Coulomb "
                "friction with sticking; tangential restitution or not) to the measured impulses (or post-impact "
                "velocities) of a table of planar impacts, and select one by BIC or AIC (docs/planar_impacts.md).",
    arguments=(
        Argument(("impacts",), dict(metavar="IMPACTS.csv", help="the table of impacts (docs/formats.md)")),
        *_BODY,
        Argument(("--law",), dict(choices=["auto", *LAWS], default="auto",
                                  help="the law: auto (every law, selected by --criterion) or one by name")),
        Argument(("--criterion",), dict(choices=["bic", "aic"], default="bic",
                                        help="law selection criterion (default bic)")),
        Argument(("--target",), dict(choices=["impulse", "velocity"], default=None,
                                     help="fit the measured impulses (default when the table has them) or the "
                                          "post-impact velocities")),
        Argument(("--confidence",), dict(type=_confidence, default=0.95, metavar="P",
                                         help="coverage of the intervals (default 0.95)")),
        Argument(("--out",), dict(metavar="RESULT.json", default=None,
                                  help="write the fit as JSON (atomically): what predict --law reads")),
        Argument(("--plots",), dict(metavar="DIR", default=None,
                                    help="write figures (a few impacts' measured and predicted outcomes; predicted "
                                         "against measured over every impact)")),
        FIGURE_FORMAT, REPORT,
        Argument(("--json",), dict(action="store_true", help="print the result as JSON")),
    ),
    run=run_fit)

PREDICT = CommandSpec(
    group="planar", name="predict",
    help="predict the impulses and post-impact velocities of planar impacts from their pre-impact states",
    description="Predict each impact's impulse and post-impact velocity from its pre-impact state and contact "
                "Jacobian alone (no post-impact, impulse or published-model column is read), with a law fitted "
                "by 'impactid planar fit'. Where the table holds the measured impulses or post-impact velocities, "
                "they are read afterwards to score the prediction (unless --no-score).",
    arguments=(
        Argument(("impacts",), dict(metavar="IMPACTS.csv", help="the table of impacts (docs/formats.md)")),
        Argument(("--law",), dict(required=True, metavar="RESULT.json", help="a fit written by impactid planar fit")),
        Argument(("--out",), dict(required=True, metavar="PREDICTIONS.csv",
                                  help="write the predictions as CSV (atomically)")),
        *_BODY,
        Argument(("--no-score",), dict(action="store_true",
                                       help="do not read the measured outcome to score the prediction")),
        Argument(("--json",), dict(action="store_true", help="print a summary as JSON")),
    ),
    run=run_predict)



def _tangential_restitution(text: str) -> float:
    value = number(text)
    if not -1.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"must lie in [-1, 1], got {text!r}")
    return value


def run_synth(args, model) -> int:
    """Run ``impactid synth --rig planar-impact`` (:func:`impactid.rigs.planar.cli.run_synth`, imported now)."""
    from impactid.rigs.planar.cli import run_synth as run

    return run(args)


SYNTH = CommandSpec(
    group="", name="synth", help="write a synthetic table of planar impacts made by a known impact law (CSV, TSV)",
    arguments=(
        # shared with rig F's (--restitution) and rig P's (--mu) synth: their declarations come first
        Argument(("--restitution",), {"type": fraction, "default": None,
                                      "help": "planar-impact: restitution e (e0 of a speed-dependent law; "
                                              "default 0.6)"}, exclusive="restitution"),
        Argument(("--mu",), {"type": nonnegative, "default": None,
                             "help": "planar-impact: Coulomb friction coefficient (default 0.3)"}),
        Argument(("--restitution-slope",), {"type": number, "default": None, "metavar": "GAMMA",
                                            "help": "planar-impact: a speed-dependent restitution e0 (1 - GAMMA u), "
                                                    "e0 the --restitution, u the approach speed [m/s], GAMMA in s/m "
                                                    "(default: constant)"}),
        Argument(("--tangential-restitution",), {"type": _tangential_restitution, "default": None, "metavar": "ET",
                                                 "help": "planar-impact: tangential restitution e_t in [-1, 1] "
                                                         "(default: none, sliding stops when friction suffices)"}),
        Argument(("--impact-rule",), {"choices": RULES, "default": None,
                                      "help": "planar-impact: Newton's restitution with Coulomb friction (newton, "
                                              "the default) or the impulse-space law of Chatterjee & Ruina 1998"}),
        Argument(("--impacts",), {"type": integer_in(1, 1_000_000), "default": None, "metavar": "N",
                                  "help": "planar-impact: number of impacts (default 200)"}),
        Argument(("--velocity-noise",), {"type": nonnegative, "default": None, "metavar": "M/S",
                                         "help": "planar-impact: standard deviation of the measured velocities "
                                                 "before and after [m/s] (over k_g on omega [rad/s]; default 0.01)"}),
        Argument(("--approach-speeds",), {"type": pair, "default": None, "metavar": "LOW,HIGH",
                                          "help": "planar-impact: range of the contact point's approach speed [m/s] "
                                                  "(default 1,3)"}),
        Argument(("--semi-axes",), {"type": pair, "default": None, "metavar": "A,B",
                                    "help": "planar-impact: semi-axes of the elliptical body [m] (default 0.035,0.025, "
                                            "the MCube ellipse)"}),
        SEED, SYNTH_OUT),
    run=run_synth, rig_argument="resolve")

#: The commands the planar-impact rig contributes.
COMMANDS = (FIT, PREDICT, SYNTH)

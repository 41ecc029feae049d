"""Rig P's command-line arguments that are declared once for several commands: those of its estimate
(``impactid estimate``, :data:`ARGUMENTS` and :data:`TITLE`, the :attr:`~impactid.rigs.base.Estimator.arguments`
and :attr:`~impactid.rigs.base.Estimator.title` of :mod:`impactid.rigs.pivoted.estimation`) and the
per-event kinematics' ``--integration`` and ``--anchor`` (also of ``impactid events``).

Light: data and argument types only (``MODEL.estimate_arguments`` names this module), so that
``impactid estimate --help`` imports neither the estimation nor numpy. The choices of
``--integration`` and ``--anchor`` are written out here; they are the names of
:data:`impactid.signal.INTEGRATORS` and :data:`impactid.rigs.pivoted.anchors.ANCHORS`
(``tests/test_package.py`` checks that they agree).
"""

from __future__ import annotations

import argparse

from impactid.commandline import exponent
from impactid.rigs.base import Argument

__all__ = ["ANCHORS", "ARGUMENTS", "INTEGRATORS", "MAX_GRID_POINTS", "TITLE", "kinematics_arguments"]

#: Largest grid of trial laws ``--grid NB,NN`` accepts (each costs one S1 run per impact).
MAX_GRID_POINTS = 100_000

#: The integration methods of the per-event kinematics (the names of :data:`impactid.signal.INTEGRATORS`).
INTEGRATORS = ("rk", "trapezoid", "simpson", "spectral")
#: The integration-constant anchors (the names of :data:`impactid.rigs.pivoted.anchors.ANCHORS`).
ANCHORS = ("return-time", "cam-geometry", "cam-phase")

#: What rig P's estimate identifies, one line (``impactid estimate --help``).
TITLE = "Hunt-Crossley beta, n and the restitution law (pivoted-follower)"


def kinematics_arguments(anchor: str) -> tuple[Argument, ...]:
    """``--integration`` and ``--anchor`` (default ``anchor``) of the per-event kinematics."""
    return (
        Argument(("--integration",), {"default": "rk", "choices": list(INTEGRATORS),
                                      "help": "integration method (default rk, as in the paper)"}),
        Argument(("--anchor",), {"default": anchor, "choices": list(ANCHORS),
                                 "help": f"integration-constant anchor (default {anchor}; return-time is the "
                                         "paper's)"}),
    )


def _grid_counts(text: str) -> tuple[int, int]:
    try:
        parts = [int(x) for x in text.replace("x", ",").split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected NB[,NN] grid counts, got {text!r}") from None
    if len(parts) == 1:
        parts.append(21)
    if len(parts) != 2 or min(parts) < 3:
        raise argparse.ArgumentTypeError(f"grid counts must be NB[,NN] with each >= 3, got {text!r}")
    if parts[0] * parts[1] > MAX_GRID_POINTS:
        raise argparse.ArgumentTypeError(
            f"{text!r} asks for {parts[0] * parts[1]:,} trial laws (each simulated for every impact); at most "
            f"{MAX_GRID_POINTS:,}: use the optimiser (no --grid) for a precise estimate")
    return parts[0], parts[1]


#: The arguments of rig P's estimate on ``impactid estimate`` (:attr:`~impactid.rigs.base.Estimator.arguments`).
ARGUMENTS = (
    Argument(("--residual",), {"default": "lambda1", "choices": ["lambda1", "lambda2", "lambda3"],
                               "help": "pivoted-follower: residual minimised (default lambda1: accelerometer only)"}),
    Argument(("--fix-n",), {"type": exponent, "default": None, "metavar": "N",
                            "help": "fix the exponent n of the damping (0: viscous)"}),
    Argument(("--method",), {"choices": ["least-squares", "optimise"], "default": "least-squares",
                             "help": "pivoted-follower: least-squares (default: trust-region Gauss-Newton, profile "
                                     "intervals) or optimise (nested Brent searches, lattice and bootstrap "
                                     "intervals; about 100x the simulations)"}),
    Argument(("--grid",), {"type": _grid_counts, "default": None, "metavar": "NB[,NN]",
                           "help": "pivoted-follower: paper-style grid search with NB values of beta (log) and NN "
                                   "of n instead of --method"}),
    Argument(("--n-range",), {"type": exponent, "nargs": 2, "default": [0.5, 2.5], "metavar": ("LO", "HI"),
                              "help": "pivoted-follower: search bounds of n (default 0.5 2.5)"}),
    *kinematics_arguments("cam-phase"),
)

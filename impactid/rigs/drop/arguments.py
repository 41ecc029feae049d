"""The drop fit's command-line arguments, declared once for ``impactid drop fit`` and for the drop
rig's part of the generic ``impactid estimate`` (:data:`ARGUMENTS` and :data:`TITLE`, the
:attr:`~impactid.rigs.base.Estimator.arguments` and :attr:`~impactid.rigs.base.Estimator.title` of
:mod:`impactid.rigs.drop.estimation`).

Light: data and argument types only (``MODEL.estimate_arguments`` names this module), so that
``impactid estimate --help`` imports neither the estimation nor numpy.
"""

from __future__ import annotations

import argparse

from impactid.commandline import exponent, fraction, integer_in
from impactid.rigs.base import Argument

__all__ = ["ARGUMENTS", "TITLE", "fit_arguments"]

#: What the drop rig's estimate identifies, one line (``impactid estimate --help``).
TITLE = "Hunt-Crossley k, beta, n (drop-impact)"


def _channel_list(text: str) -> tuple[str, ...]:
    from impactid.rigs.drop.parameters import ACCELERATION_CHANNEL, FORCE_CHANNEL  # loads numpy: when given

    names = {"acceleration": ACCELERATION_CHANNEL, ACCELERATION_CHANNEL: ACCELERATION_CHANNEL,
             "force": FORCE_CHANNEL, FORCE_CHANNEL: FORCE_CHANNEL}
    out = []
    for part in text.split(","):
        part = part.strip()
        if part not in names:
            raise argparse.ArgumentTypeError(f"unknown channel {part!r} (acceleration, force)")
        out.append(names[part])
    return tuple(dict.fromkeys(out))


def fit_arguments(prefix: str = "") -> tuple[Argument, ...]:
    """The options of the drop fit (:func:`~impactid.rigs.drop.identify.fit_drop`), declared once for
    ``impactid drop fit`` and the generic ``impactid estimate`` (which prefixes their help with the
    rig's name: its options are the union of the rigs')."""
    return (
        Argument(("--fix-n",), {"type": exponent, "default": None, "metavar": "N",
                                "help": "fix the exponent n of the damping (0: viscous)"}),
        Argument(("--channels",), {"type": _channel_list, "default": None, "metavar": "acceleration,force",
                                   "help": f"{prefix}the signals fitted (default: those the recordings have)"}),
        Argument(("--max-impacts",), {"type": integer_in(1, 1000), "default": 4,
                                      "help": f"{prefix}impacts fitted per recording, the first ones (default 4)"}),
        Argument(("--speeds",), {"choices": ["fit", "measured"], "default": "fit",
                                 "help": f"{prefix}onset speeds fitted with the contact (default) or held at the "
                                         "measured values"}),
        Argument(("--confidence",), {"type": fraction, "default": 0.95,
                                     "help": f"{prefix}coverage of the intervals (default 0.95)"}),
    )


#: The arguments of the drop rig's estimate on ``impactid estimate`` (:attr:`~impactid.rigs.base.Estimator.arguments`).
ARGUMENTS = fit_arguments("drop-impact: ")

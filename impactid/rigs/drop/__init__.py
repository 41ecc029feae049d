"""The single-impact test rig (``drop-impact``): a mass dropped or swung onto a contact.

What drop towers, instrumented pendulums and ball-drop force plates record: an impactor of known
mass falls (or swings) onto a contact, impacts and bounces; an accelerometer on the impactor and,
optionally, a load cell under the contact record the impacts. The contact is the Hunt–Crossley law
``F = max(k delta^p + beta delta^n d(delta)/dt, 0)``; the fit identifies ``k``, ``beta`` and ``n``.

* :mod:`.parameters` - :class:`DropRig`, :class:`DropLaw`, the preset :data:`STEEL_ON_PA6`, Hertz's
  closed forms;
* :mod:`.kernel` - the compiled event-driven integrator (DP5 core, forward sensitivities);
  :mod:`.simulate` - :func:`simulate_drop`, :func:`replay_impacts`;
* :mod:`.synth` - synthetic recordings; :mod:`.measure` - recording to per-impact observations;
  :mod:`.identify` - :func:`fit_drop`; :mod:`.figures`; :mod:`.commands` (``impactid synth --rig
  drop-impact``, ``impactid drop simulate``, ``impactid drop fit``);
* :mod:`.estimation` - what the generic ``impactid estimate DROP1.h5 DROP2.h5`` and
  :class:`impactid.pipeline.Pipeline` run for this rig's recordings (``MODEL.estimation``).

See ``docs/drop.md``. Importing this package loads nothing of the rig (not even numpy): the parameters
and the numerical modules are imported on first use of their names, and :data:`MODEL` and
:data:`CHANNELS` are built on first use, so that building the command line (which reads
:data:`COMMANDS`, :data:`ESTIMATION` and :data:`ESTIMATE_ARGUMENTS`) loads none of them.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from impactid.rigs.base import ChannelSpec, ContactLaw, RigModel, lazy_attributes

if TYPE_CHECKING:
    from impactid.rigs.drop.parameters import DropLaw, DropRig

#: The contact law the rig's simulator and fit take: Hunt-Crossley with the force clipped at 0.
LAW_NAME = "hunt-crossley-clipped"

#: The rig's commands, estimation and estimate arguments, by import path: the values of
#: :data:`MODEL`'s fields, read by the registry without building :data:`MODEL`.
COMMANDS = "impactid.rigs.drop.commands"
ESTIMATION = "impactid.rigs.drop.estimation"
ESTIMATE_ARGUMENTS = "impactid.rigs.drop.arguments"

#: The names of the rig's presets, the default first (``MODEL.presets``): ``--rig NAME`` finds its rig
#: without building the other rigs' models.
PRESET_NAMES = ("STEEL_ON_PA6",)

#: Where the names live, imported on first use (reading a rig file does not load numba; importing the
#: package, as the command line does, loads not even the parameters).
_LAZY = {
    **{name: "impactid.rigs.drop.parameters" for name in (
        "ACCELERATION_CHANNEL", "FORCE_CHANNEL", "MODEL_NAME", "N_BOUNDS", "PA6_PAD_LAW", "PRESETS", "STEEL_ON_PA6",
        "DropLaw", "DropRig", "nominal_law")},
    "simulate_drop": "impactid.rigs.drop.simulate", "replay_impacts": "impactid.rigs.drop.simulate",
    "DropRun": "impactid.rigs.drop.simulate", "Tolerances": "impactid.rigs.drop.simulate",
    "synth_drop_impact": "impactid.rigs.drop.synth", "synth_drop_series": "impactid.rigs.drop.synth",
    "measure_impacts": "impactid.rigs.drop.measure", "ImpactObservations": "impactid.rigs.drop.measure",
    "fit_drop": "impactid.rigs.drop.identify", "DropFit": "impactid.rigs.drop.identify",
}


def _channels() -> dict[str, ChannelSpec]:
    """The channels this rig's recordings may hold (:data:`CHANNELS`)."""
    from impactid.rigs.drop.parameters import ACCELERATION_CHANNEL, FORCE_CHANNEL

    return {
        ACCELERATION_CHANNEL: ChannelSpec(ACCELERATION_CHANNEL, "acceleration", "m/s^2",
                                          "accelerometer on the impactor: specific force along the line of impact, "
                                          "away from the contact (F/m: 0 in flight, +g at rest on the contact)"),
        FORCE_CHANNEL: ChannelSpec(FORCE_CHANNEL, "force", "N", "load cell under the contact: contact force, "
                                                                "compressive positive"),
    }


def _simulate(rig: DropRig, law: DropLaw | None = None, height: float = 0.05, **options):
    """:func:`~impactid.rigs.drop.simulate.simulate_drop` (the rig's nominal law by default)."""
    from impactid.rigs.drop.parameters import nominal_law
    from impactid.rigs.drop.simulate import simulate_drop

    return simulate_drop(rig, law if law is not None else nominal_law(rig), height, **options)


def _measure(recording, **options):
    from impactid.rigs.drop.measure import measure_impacts

    return measure_impacts(recording, **options)


def _pack_rig(rig: DropRig):
    import numpy as np

    return np.array([rig.mass, rig.gravity, rig.k, rig.p], dtype=float)


def _pack_law(law: DropLaw):
    """``(beta, n)``; ``k`` is the rig's (:func:`_pack_rig`)."""
    import numpy as np

    return np.array([law.beta, law.n], dtype=float)


def _model() -> RigModel:
    """The rig model record (registered in :mod:`impactid.rigs.registry`), built on first use of :data:`MODEL`."""
    from impactid.rigs.drop.parameters import MODEL_NAME, N_BOUNDS, PRESETS, DropLaw, DropRig

    return RigModel(
        name=MODEL_NAME,
        title="single-impact test rig: a mass dropped or swung onto a Hunt-Crossley contact (drop tower, "
              "instrumented pendulum, ball-drop force plate)",
        citation="",  # Hunt & Crossley (1975), cited in docs/drop.md (not in docs/bibliography.md)
        parameters=DropRig,
        presets=PRESETS,
        channels=__getattr__("CHANNELS"),
        # named apart from rig P's (unclipped) "hunt-crossley" law: the force is clipped at 0
        laws=(ContactLaw(name=LAW_NAME, law_type=DropLaw,
                         parameters={"k": ("N m^-p", (0.0, math.inf)), "beta": ("N s m^-(n+1)", (0.0, math.inf)),
                                     "n": ("1", N_BOUNDS)}, pack=_pack_law),),
        gap=lambda rig, state, cam_angle: -state[0],
        gap_rate=lambda rig, state, cam_angle, cam_rate: -state[1],
        contact_coordinate=lambda state, cam_angle: state[0],
        pack=_pack_rig,
        kernel="impactid.rigs.drop.kernel",
        simulate=_simulate,
        measure=_measure,
        commands=COMMANDS,
        estimation=ESTIMATION,
        estimate_arguments=ESTIMATE_ARGUMENTS,
        replay="impactid.rigs.drop.simulate:replay_impacts",
        warmup="impactid.rigs.drop.simulate:warm_up",
    )


__getattr__ = lazy_attributes(__name__, _LAZY, {"MODEL": _model, "CHANNELS": _channels})

__all__ = ["ACCELERATION_CHANNEL", "CHANNELS", "FORCE_CHANNEL", "LAW_NAME", "MODEL", "MODEL_NAME", "N_BOUNDS",
           "PA6_PAD_LAW", "PRESETS", "STEEL_ON_PA6", "DropFit", "DropLaw", "DropRig", "DropRun", "ImpactObservations",
           "Tolerances", "fit_drop", "measure_impacts", "nominal_law", "replay_impacts", "simulate_drop",
           "synth_drop_impact", "synth_drop_series"]


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))

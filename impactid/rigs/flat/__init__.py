"""Rig F: an eccentric cam and an oscillating flat-faced follower (Alzate, di Bernardo, Montanaro & Santini 2007).

* :mod:`~impactid.rigs.flat.parameters`: geometry as pure functions, :class:`FlatFollowerRig` and the
  paper's rig :data:`ALZATE2007`;
* :mod:`~impactid.rigs.flat.kernel`: the compiled event-driven simulator on the shared DP5 core;
* :mod:`~impactid.rigs.flat.simulate`: runs, the speed-dependent restitution law, bifurcation sweeps.
* :mod:`~impactid.rigs.flat.commands`: its commands (``impactid bifurcation``, ``restitution``,
  ``cam-fit``, and its ``detachment`` and ``synth``).

Its measurement model (encoders to impacts and restitution) is :mod:`impactid.rigs.flat.encoder_impacts`; its
cam profile fit is :mod:`impactid.rigs.flat.camprofile`.

Importing this package loads nothing of the rig: the names below are imported from
:mod:`~impactid.rigs.flat.parameters` on first use and :data:`MODEL` is built on first use, so that
building the command line (which reads :data:`COMMANDS`) loads no numpy.
"""

from __future__ import annotations

from impactid.rigs.base import ChannelSpec, ContactLaw, RigModel, lazy_attributes

__all__ = ["ALZATE2007", "MODEL", "MODEL_NAME", "FlatFollowerRig", "contact_angle_derivatives",
           "contact_follower_angle", "flat_gap", "flat_gap_rate", "flat_lever", "flat_spring_torque"]

#: The rig's commands by import path (:data:`MODEL`'s field, read by the registry without building
#: :data:`MODEL`); impactid estimates nothing from rig F's recordings.
COMMANDS = "impactid.rigs.flat.commands"
ESTIMATION = None
ESTIMATE_ARGUMENTS = None

#: The names of the rig's presets, the default first (``MODEL.presets``): ``--rig NAME`` finds its rig
#: without building the other rigs' models.
PRESET_NAMES = ("ALZATE2007",)

#: The names of :mod:`~impactid.rigs.flat.parameters` (numpy), imported on first use.
_LAZY = {name: "impactid.rigs.flat.parameters" for name in __all__ if name != "MODEL"}


def _simulate(*args, **kwargs):
    """:func:`impactid.rigs.flat.simulate.simulate_flat` (imported on use: reading a rig file does not load numba)."""
    from impactid.rigs.flat.simulate import simulate_flat

    return simulate_flat(*args, **kwargs)


def _measure(recording, **options):
    """Restitution at the recording's cam speed from its encoders
    (:func:`impactid.rigs.flat.encoder_impacts.restitution_at_speed`)."""
    from impactid.rigs.flat.encoder_impacts import restitution_at_speed

    return restitution_at_speed(recording, **options)


def _pack_rig(rig):
    from impactid.rigs.flat.simulate import pack_flat_rig

    return pack_flat_rig(rig)


def _pack_restitution(law):
    import numpy as np

    return np.array([law.a, law.b], dtype=float)


def _model() -> RigModel:
    """The rig model record (registered in :mod:`impactid.rigs.registry`), built on first use of :data:`MODEL`."""
    from impactid.rigs.flat.parameters import ALZATE2007, MODEL_NAME, FlatFollowerRig

    return RigModel(
        name=MODEL_NAME,
        title="Eccentric cam on an oscillating flat-faced follower (Alzate, di Bernardo, Montanaro & Santini 2007)",
        citation="alzate2007",
        parameters=FlatFollowerRig,
        presets={"ALZATE2007": ALZATE2007},
        channels={
            "cam_angle": ChannelSpec("cam_angle", "angle", "rad", "cam encoder angle", required=True),
            "follower_angle": ChannelSpec("follower_angle", "angle", "rad", "follower encoder angle", required=True),
        },
        laws=(ContactLaw(name="speed-restitution", law_type=object,
                         parameters={"a": ("1", (0.0, 1.0)), "b": ("s/rad", (-1.0, 1.0))}, pack=_pack_restitution),),
        gap=lambda rig, state, cam_angle: rig.gap(state[0], cam_angle),
        detachment=lambda rig, **options: rig.detachment_speed_hz(**options),
        pack=_pack_rig,
        kernel="impactid.rigs.flat.kernel",
        replay="impactid.rigs.flat.encoder_impacts:simulated_first_bounce",
        simulate=_simulate,
        measure=_measure,
        commands=COMMANDS,
        warmup="impactid.rigs.flat.simulate:warm_up",
    )


__getattr__ = lazy_attributes(__name__, _LAZY, {"MODEL": _model})


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))

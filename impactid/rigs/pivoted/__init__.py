"""Rig P: an eccentric cam and a pivoted follower with point contact (Sundar, Dreyer & Singh 2016).

The folder holds the rig's parts, following the data:

* :mod:`~impactid.rigs.pivoted.parameters`: geometry and forces as pure functions, the
  :class:`PivotedFollowerRig` parameters and the paper's rig :data:`SUNDAR2016`;
* :mod:`~impactid.rigs.pivoted.kernel`: the compiled event-driven simulator (on the shared DP5 core
  :mod:`impactid.simulate.dp5`), driven by :mod:`impactid.rigs.pivoted.runs`.
* :mod:`~impactid.rigs.pivoted.commands`: its commands (``events``, ``regime``, ``regime-map``,
  ``simulate``, and its ``detachment`` and ``synth``).

The measurement model (accelerometer and force channels to per-impact kinematics) is
:func:`impactid.rigs.pivoted.reconstruct.reconstruct` (``MODEL.measure``); the estimators are in
:mod:`impactid.rigs.pivoted.estimates`, and what the generic ``impactid estimate`` runs for this
rig (``MODEL.estimation``) in :mod:`impactid.rigs.pivoted.estimation` (its command-line arguments in the
light :mod:`impactid.rigs.pivoted.arguments`).

Importing this package loads nothing of the rig: the names below are imported from
:mod:`~impactid.rigs.pivoted.parameters` on first use and :data:`MODEL` is built on first use, so that
building the command line (which reads :data:`COMMANDS`, :data:`ESTIMATION` and
:data:`ESTIMATE_ARGUMENTS`) loads neither numpy nor SciPy.
"""

from __future__ import annotations

from impactid.rigs.base import ChannelSpec, ContactLaw, RigModel, lazy_attributes

__all__ = ["MODEL", "MODEL_NAME", "SUNDAR2016", "PivotedFollowerRig", "free_torque", "gap", "gap_paper", "gap_rate",
           "gap_rate_paper", "lever_arm", "sliding_velocity", "spring_force", "tangential_gap_paper",
           "tangential_gap_rate", "tangential_gap_rate_paper", "zero_state_angle"]

#: The rig's commands, estimation and estimate arguments, by import path: the values of
#: :data:`MODEL`'s fields, read by the registry without building :data:`MODEL`.
COMMANDS = "impactid.rigs.pivoted.commands"
ESTIMATION = "impactid.rigs.pivoted.estimation"
ESTIMATE_ARGUMENTS = "impactid.rigs.pivoted.arguments"

#: The names of the rig's presets, the default first (``MODEL.presets``): ``--rig NAME`` finds its rig
#: without building the other rigs' models.
PRESET_NAMES = ("SUNDAR2016",)

#: The names of :mod:`~impactid.rigs.pivoted.parameters` (numpy, SciPy), imported on first use.
_LAZY = {name: "impactid.rigs.pivoted.parameters" for name in __all__ if name != "MODEL"}


def _simulate(*args, **kwargs):
    """:func:`impactid.rigs.pivoted.runs.simulate` (imported on use: reading a rig file does not load numba)."""
    from impactid.rigs.pivoted.runs import simulate

    return simulate(*args, **kwargs)


def _detachment(rig, **options):
    from impactid.rigs.pivoted.regimes import detachment_speed

    return detachment_speed(rig, **options).cam_speed_hz


def _measure(recording, **options):
    from impactid.rigs.pivoted.reconstruct import reconstruct

    return reconstruct(recording, **options)


def _example(refresh: bool = False):
    from impactid.rigs.pivoted.example import example_recording_paths

    return example_recording_paths(refresh)


def _pack_rig(rig):
    from impactid.rigs.pivoted.runs import pack_rig

    return pack_rig(rig)


def _pack_law(law):
    from impactid.rigs.pivoted.runs import pack_law

    return pack_law(law)


def _model() -> RigModel:
    """The rig model record (registered in :mod:`impactid.rigs.registry`), built on first use of :data:`MODEL`."""
    from impactid.rigs.pivoted.parameters import MODEL_NAME, SUNDAR2016, PivotedFollowerRig

    return RigModel(
        name=MODEL_NAME,
        title="Eccentric cam on a pivoted follower with point contact (Sundar, Dreyer & Singh 2016)",
        citation="sundar2016",
        parameters=PivotedFollowerRig,
        presets={"SUNDAR2016": SUNDAR2016},
        channels={
            "accel_tangential": ChannelSpec("accel_tangential", "acceleration", "m/s^2",
                                            "tangential acceleration of the follower tip", required=True),
            "force_x": ChannelSpec("force_x", "force", "N", "pivot reaction, horizontal"),
            "force_y": ChannelSpec("force_y", "force", "N", "pivot reaction, vertical"),
            "cam_angle": ChannelSpec("cam_angle", "angle", "rad", "cam encoder angle"),
        },
        laws=(ContactLaw(name="hunt-crossley", law_type=object,
                         parameters={"beta": ("N s m^-(n+1)", (1e8, 1e13)), "n": ("1", (0.5, 2.5))}, pack=_pack_law),),
        gap=lambda rig, state, cam_angle: rig.gap(state[0], cam_angle),
        gap_rate=lambda rig, state, cam_angle, cam_rate: rig.gap_rate(state[0], state[1], cam_angle, cam_rate),
        detachment=_detachment,
        pack=_pack_rig,
        kernel="impactid.rigs.pivoted.kernel",
        simulate=_simulate,
        measure=_measure,
        example=_example,
        commands=COMMANDS,
        estimation=ESTIMATION,
        estimate_arguments=ESTIMATE_ARGUMENTS,
        replay="impactid.rigs.pivoted.damping_objective:DampingObjective",
        calibrate="impactid.rigs.pivoted.calibration:pipeline_bias",
        warmup="impactid.rigs.pivoted.runs:warm_up",
    )


__getattr__ = lazy_attributes(__name__, _LAZY, {"MODEL": _model})


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))

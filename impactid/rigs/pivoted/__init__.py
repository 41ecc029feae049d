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
rig (``MODEL.estimation``) in :mod:`impactid.rigs.pivoted.estimation`.
"""

from impactid.rigs.base import ChannelSpec, ContactLaw, RigModel
from impactid.rigs.pivoted.parameters import (
    MODEL_NAME,
    SUNDAR2016,
    PivotedFollowerRig,
    free_torque,
    gap,
    gap_paper,
    gap_rate,
    gap_rate_paper,
    lever_arm,
    sliding_velocity,
    spring_force,
    tangential_gap_paper,
    tangential_gap_rate,
    tangential_gap_rate_paper,
    zero_state_angle,
)

__all__ = ["MODEL", "MODEL_NAME", "SUNDAR2016", "PivotedFollowerRig", "free_torque", "gap", "gap_paper", "gap_rate",
           "gap_rate_paper", "lever_arm", "sliding_velocity", "spring_force", "tangential_gap_paper",
           "tangential_gap_rate", "tangential_gap_rate_paper", "zero_state_angle"]


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


MODEL = RigModel(
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
    commands="impactid.rigs.pivoted.commands",
    estimation="impactid.rigs.pivoted.estimation",
    replay="impactid.rigs.pivoted.damping_objective:DampingObjective",
    calibrate="impactid.rigs.pivoted.calibration:pipeline_bias",
)

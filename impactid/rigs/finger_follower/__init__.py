"""Finger-follower valve train with a hydraulic lash adjuster (Kim, Jeon & Park 1990).

An overhead camshaft drives a finger follower pivoted on a hydraulic tappet (HLA); the follower
opens the valve against a spring with surge (two masses). Six degrees of freedom, one-sided
contacts at the tappet, the cam and the valve, a valve seat, and a tappet whose drag depends on
the direction of the plunger's motion. The folder holds:

* :mod:`~impactid.rigs.finger_follower.parameters` - the frozen parameter dataclass and the paper's tables as presets;
* :mod:`~impactid.rigs.finger_follower.cam` - lift laws, the contact point, rocker ratio and lever arm (pure functions);
* :mod:`~impactid.rigs.finger_follower.kernel` - the compiled event-driven integrator (on
  :mod:`impactid.simulate.dp5`);
* :mod:`~impactid.rigs.finger_follower.simulate` - runs, periodic steady state, summaries, modes, jump
  and bounce speeds;
* :mod:`~impactid.rigs.finger_follower.analysis` - the rocker-ratio comparison and the leak-down against speed;
* :mod:`~impactid.rigs.finger_follower.synth` - synthetic recordings of the paper's test rig;
* :mod:`~impactid.rigs.finger_follower.identify` - synchronous averaging, the tappet-drag fit, the cam-lift fit;
* :mod:`~impactid.rigs.finger_follower.figures` and :mod:`~impactid.rigs.finger_follower.commands` - figures
  and the ``impactid valvetrain`` commands.

:data:`MODEL` is the rig's record for the registry (:mod:`impactid.rigs.registry`), built on first use:
importing this package loads nothing of the rig (the parameters and the numerics are imported on
first use of their names), so that building the command line (which reads :data:`COMMANDS`) loads
neither numpy nor numba.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

from impactid.rigs.base import ChannelSpec, ContactLaw, RigModel, lazy_attributes

__all__ = ["KIM1990", "KIM1990_TABLE2", "MODEL", "FingerFollowerRig", "TappetDrag"]

#: The rig's commands by import path (:data:`MODEL`'s field, read by the registry without building
#: :data:`MODEL`); impactid's generic estimate takes no valve-train recordings.
COMMANDS = "impactid.rigs.finger_follower.commands"
ESTIMATION = None
ESTIMATE_ARGUMENTS = None

#: The names of the rig's presets, the default first (``MODEL.presets``): ``--rig NAME`` finds its rig
#: without building the other rigs' models.
PRESET_NAMES = ("kim1990", "kim1990-table2")

#: Where the names live, imported on first use (numpy; ``pack`` and ``prepare`` load numba).
_LAZY = {
    **dict.fromkeys(("KIM1990", "KIM1990_TABLE2", "MODEL_NAME", "FingerFollowerRig"),
                    "impactid.rigs.finger_follower.parameters"),
    **dict.fromkeys(("pack", "prepare"), "impactid.rigs.finger_follower.simulate"),
}


@dataclass(frozen=True)
class TappetDrag:
    """The hydraulic tappet's drag law (K-6): ``F_d = alpha C_d(sign Y_t') Y_t' + beta K_e Y_t``.

    Attributes
    ----------
    alpha, beta : the weights on the limiting damping and stiffness [-].
    """

    alpha: float
    beta: float


def _pack_drag(law: TappetDrag):
    import numpy as np

    return np.array([float(law.alpha), float(law.beta)])


@functools.lru_cache(maxsize=8)
def _train(rig):
    from impactid.rigs.finger_follower.simulate import prepare

    return prepare(rig)


def _gap(rig, state, cam_angle):
    """Cam/follower gap [m] (positive = open): minus the elastic separation function of (K-10)."""
    import numpy as np

    kin = _train(rig).kinematics
    y = np.asarray(state, dtype=float)
    d_fc = kin("Y_c", cam_angle) - y[1] - kin("L_fc", cam_angle) * np.sin(y[2])
    return -(d_fc + rig.F_fc0 / rig.K_fc)


def _gap_rate(rig, state, cam_angle, omega=0.0):
    """Rate of the cam/follower gap [m/s] at camshaft speed ``omega`` [rad/s]."""
    import numpy as np

    kin = _train(rig).kinematics
    y = np.asarray(state, dtype=float)
    rate = (kin("Y_c", cam_angle, 1) * omega - y[7] - kin("L_fc", cam_angle) * y[8] * np.cos(y[2])
            - kin("L_fc", cam_angle, 1) * omega * np.sin(y[2]))
    return -rate


def _detachment(rig, **options) -> float:
    """Jump speed [Hz of camshaft speed] (sweep and bisection, see ``simulate.critical_speeds``)."""
    from impactid.rigs.finger_follower.simulate import critical_speeds

    speeds = critical_speeds(_train(rig), **options)
    return speeds.jump_speed_rpm / 60.0 if math.isfinite(speeds.jump_speed_rpm) else math.nan


def _measure(recording, **options):
    from impactid.rigs.finger_follower.identify import synchronous_average

    return synchronous_average(recording, **options).to_frame()


CHANNELS = {
    "valve_displacement": ChannelSpec("valve_displacement", "length", "m",
                                      "valve displacement, positive opening, from the seated rest position",
                                      required=True),
    "tappet_displacement": ChannelSpec("tappet_displacement", "length", "m",
                                       "hydraulic tappet plunger displacement, positive compressed (leak-down)"),
    "cam_angle": ChannelSpec("cam_angle", "angle", "rad",
                             "camshaft encoder angle, unwrapped; the nose is at operating nose_angle_rad",
                             required=True),
    "valve_velocity": ChannelSpec("valve_velocity", "velocity", "m/s", "valve velocity, positive opening"),
    "contact_load": ChannelSpec("contact_load", "force", "N", "cam/follower contact force (synthetic data only)"),
}


def _model() -> RigModel:
    """The rig model record (registered in :mod:`impactid.rigs.registry`), built on first use of :data:`MODEL`
    (it loads the compiled kernel: numba)."""
    from impactid.rigs.finger_follower import kernel
    from impactid.rigs.finger_follower.parameters import KIM1990, KIM1990_TABLE2, MODEL_NAME, FingerFollowerRig
    from impactid.rigs.finger_follower.simulate import pack, simulate

    return RigModel(
        name=MODEL_NAME,
        title="Finger-follower valve train with a hydraulic lash adjuster (Kim, Jeon & Park 1990)",
        citation="kim1990",
        parameters=FingerFollowerRig,
        presets={"kim1990": KIM1990, "kim1990-table2": KIM1990_TABLE2},
        channels=CHANNELS,
        laws=(ContactLaw(name="hla-drag", law_type=TappetDrag,
                         parameters={"alpha": ("", (1e-5, 1.0)), "beta": ("", (1e-3, 1.0))}, pack=_pack_drag),),
        gap=_gap,
        gap_rate=_gap_rate,
        contact_coordinate=None,
        detachment=_detachment,
        pack=pack,
        kernel=kernel,
        simulate=simulate,
        measure=_measure,
        commands=COMMANDS,
        warmup="impactid.rigs.finger_follower.simulate:warm_up",
    )


__getattr__ = lazy_attributes(__name__, _LAZY, {"MODEL": _model})


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))

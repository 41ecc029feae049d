"""Analyses of the finger-follower valve train: cycle curves, the rocker-ratio comparison, leak-down.

* :func:`cycle_table` - valve lift, velocity, acceleration, tappet motion and the contact forces
  against cam angle in the steady state (the paper's Figs. 9-12);
* :func:`rocker_ratio_effect` - the train with its fluctuating rocker ratio against the same
  train with the ratio held at its base-circle value (the paper's Fig. 12 comparison);
* :func:`leakdown_curve` (re-exported from :mod:`impactid.rigs.finger_follower.simulate`) - maximum
  tappet leak-down against camshaft speed (the paper's Fig. 8).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from impactid.rigs.finger_follower.simulate import (
    SteadyState,
    ValveTrain,
    leakdown_curve,
    prepare,
    steady_state,
    summarize,
)

__all__ = ["COMPARED", "cycle_table", "leakdown_curve", "rocker_ratio_effect"]

#: Quantities :func:`rocker_ratio_effect` compares.
COMPARED = ("peak_cam_force_opening_N", "peak_cam_force_closing_N", "peak_cam_force_nose_N", "max_F_vf_N",
            "max_valve_lift_m", "seating_speed_m_s", "max_tappet_leakdown_m")


def cycle_table(state: SteadyState) -> pd.DataFrame:
    """The last revolution of a steady state as a table against cam angle (SI, angles in deg).

    Columns ``cam_angle_deg`` (wrapped to [-180, 180), 0 at the nose), ``Y_v, Y_v_dot, Y_v_ddot``
    [m, m/s, m/s^2], ``Y_t, Y_t_dot`` [m, m/s] and the forces ``F_tf, F_fc, F_vf, F_seat, F_drag`` [N].
    """
    rev = state.revolution
    data: dict[str, Any] = {"cam_angle_deg": rev.theta_deg}
    for name in ("Y_v", "Y_v_dot", "Y_v_ddot", "Y_t", "Y_t_dot", "F_tf", "F_fc", "F_vf", "F_seat", "F_drag"):
        data[name] = rev.channel(name)
    return pd.DataFrame(data)


def rocker_ratio_effect(rig_or_train, rpm: float, *, lift=None, **options) -> pd.DataFrame:
    """The fluctuating rocker ratio against a constant one, in the steady state at ``rpm``.

    The comparison train has the same kinematic valve lift, with the rocker ratio held at ``RR0``
    and the lever arm at ``L_fc0`` (``Kinematics`` variant ``"constant_ratio"``), so the valve
    motion asked of the train is the same and only the force transmission differs.

    Returns
    -------
    DataFrame indexed by the quantities of :data:`COMPARED` with columns ``variable``,
    ``constant_ratio`` and ``change`` (``variable / constant_ratio - 1``), plus the rocker-ratio
    range of the variable train (``RR_min``, ``RR_max``).
    """
    if isinstance(rig_or_train, ValveTrain):
        rig = rig_or_train.rig
        lift = rig_or_train.lift if lift is None else lift
        opts = {"clip_tension": rig_or_train.clip_tension, "moment_cos": rig_or_train.moment_cos}
    else:
        rig, opts = rig_or_train, {}
    trains = {v: prepare(rig, lift, variant=v, **opts) for v in ("variable", "constant_ratio")}
    rows = {}
    for variant, train in trains.items():
        s = summarize(steady_state(train, rpm, **options))
        rows[variant] = [s[k] for k in COMPARED]
        rr = train.kinematics.values["RR"]
        rows[variant] += [float(np.min(rr)), float(np.max(rr))]
    index = list(COMPARED) + ["RR_min", "RR_max"]
    table = pd.DataFrame(rows, index=index)
    table["change"] = table["variable"] / table["constant_ratio"] - 1.0
    table.attrs["rpm"] = float(rpm)
    return table

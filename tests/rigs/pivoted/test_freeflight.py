"""The compiled free flight (RK4 + sensitivity) against solve_ivp, and the return-time anchor."""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from impactid import SUNDAR2016
from impactid.rigs.pivoted.freeflight import FREE_FLIGHT_STEPS, free_flight, return_time_anchors
from impactid.rigs.pivoted.runs import pack_rig

RIG = SUNDAR2016
P = pack_rig(RIG)


def reference(alpha0, rate0, duration):
    def rhs(t, y):
        return [y[1], float(RIG.free_torque(y[0])) / RIG.I_b]

    sol = solve_ivp(rhs, (0, duration), [alpha0, rate0], method="DOP853", rtol=1e-13, atol=1e-15)
    return sol.y[:, -1]


def test_free_flight_matches_solve_ivp():
    for alpha0, rate0, duration in [(0.08, 6.0, 0.06), (0.14, -2.0, 0.0625), (0.1, 0.0, 0.1)]:
        a, v, sa, _ = free_flight(alpha0, rate0, duration, P, FREE_FLIGHT_STEPS)
        ra, rv = reference(alpha0, rate0, duration)
        # RK4 with 2000 steps: error ~ (omega h)^4 ~ 1e-12 of the motion; 1e-11 rad / 1e-9 rad/s bounds it
        assert abs(a - ra) < 1e-11 and abs(v - rv) < 1e-9
        h = 1e-6
        fd = (reference(alpha0 + h, rate0, duration)[0] - reference(alpha0 - h, rate0, duration)[0]) / (2 * h)
        assert abs(sa - fd) < 1e-6


def test_return_time_anchor_recovers_the_start_angle():
    alpha_true, rate0, duration = 0.0791, 5.2, 0.0600
    end = reference(alpha_true, rate0, duration)[0]
    out = np.empty((1, 3))
    return_time_anchors(np.array([rate0]), np.array([duration]), np.array([end - alpha_true]),
                        np.array([0.12]), P, FREE_FLIGHT_STEPS, 1e-14, out)
    assert out[0, 2] > 0  # converged
    assert abs(out[0, 0] - alpha_true) < 1e-10

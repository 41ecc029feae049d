"""The flight of a spinning ball between bounces: the equations of motion and a vectorised integrator.

``dp/dt = v``, ``dv/dt = -g' e_z - k_D |v| v + k_L lambda (C_L(S) / S) (omega x v)`` with ``g'`` gravity
less buoyancy over the effective mass, ``k_D`` and ``k_L`` the drag and lift rates of
:class:`~impactid.rigs.tracks.parameters.TrackedBall`, ``lambda`` its lift scale, ``C_L(S)`` the lift
coefficient (:func:`~impactid.rigs.tracks.parameters.lift_coefficient`) at the spin parameter
``S = R |omega| / |v|``, and the spin ``omega`` constant over a flight
(a table-tennis ball loses about 1 % of its spin in 0.1 s). :func:`flight_positions` integrates a
batch of flights at once with the classical fourth-order Runge-Kutta method, each from its own start
time and state to common sample times (forwards or backwards), in equal sub-steps of at most
``max_step``; the tests compare it with :func:`scipy.integrate.solve_ivp` (DOP853, rtol 1e-12).
"""

from __future__ import annotations

import math

import numpy as np

from impactid.rigs.tracks.parameters import TrackedBall, lift_over_spin

__all__ = ["MAX_STEP", "acceleration", "flight_positions", "flight_rhs"]

#: Longest sub-step of the integrator [s]: at 4 ms the error of a 0.2 s table-tennis flight is below
#: 1e-10 m (tests/rigs/tracks/test_flight.py), far below any tracking noise.
MAX_STEP = 4e-3


def acceleration(velocity: np.ndarray, spin: np.ndarray, ball: TrackedBall,
                 lift_scale: np.ndarray | float | None = None) -> np.ndarray:
    """The acceleration [m/s^2] of balls with ``velocity`` (..., 3) [m/s] and ``spin`` (..., 3) [rad/s];
    ``lift_scale`` (...) or a number replaces ``ball.lift_scale`` (None: the ball's)."""
    vx, vy, vz = velocity[..., 0], velocity[..., 1], velocity[..., 2]
    wx, wy, wz = spin[..., 0], spin[..., 1], spin[..., 2]
    speed = np.sqrt(vx * vx + vy * vy + vz * vz)
    drag = ball.drag_rate * speed
    s = ball.radius * np.sqrt(wx * wx + wy * wy + wz * wz) / np.maximum(speed, 1e-9)
    km = ball.lift_rate * (ball.lift_scale if lift_scale is None else lift_scale) * lift_over_spin(s)
    return np.stack([-drag * vx + km * (wy * vz - wz * vy), -drag * vy + km * (wz * vx - wx * vz),
                     -drag * vz + km * (wx * vy - wy * vx) - ball.net_gravity], axis=-1)


def flight_rhs(ball: TrackedBall, spin: np.ndarray):
    """``f(t, y)`` of the state ``y = (p, v)`` (6,) for :func:`scipy.integrate.solve_ivp`."""
    spin = np.asarray(spin, dtype=float)

    def rhs(_t, y):
        return np.concatenate([y[3:], acceleration(y[None, 3:], spin[None, :], ball)[0]])

    return rhs


def flight_positions(position: np.ndarray, velocity: np.ndarray, start: np.ndarray, times: np.ndarray,
                     ball: TrackedBall, spin: np.ndarray, max_step: float = MAX_STEP,
                     lift_scale: np.ndarray | None = None) -> np.ndarray:
    """Positions of a batch of flights at the sample times.

    Parameters
    ----------
    position, velocity : (B, 3) the state of each flight at its ``start`` [m], [m/s].
    start : (B,) the time of that state [s].
    times : (n,) the sample times [s], ordered away from the starts (ascending for flights after
        them, descending for flights before them); each flight is integrated through them in turn.
    ball : the ball and its air model.
    spin : (B, 3) or (3,) the spin of each flight [rad/s].
    max_step : longest sub-step [s].
    lift_scale : (B,) the lift scale of each flight (None: ``ball.lift_scale``).

    Returns
    -------
    (B, n, 3) positions [m].
    """
    p = np.array(position, dtype=float, ndmin=2)
    v = np.array(velocity, dtype=float, ndmin=2)
    t_now = np.array(start, dtype=float, ndmin=1).copy()
    w = np.broadcast_to(np.asarray(spin, dtype=float), p.shape)
    times = np.asarray(times, dtype=float)
    lam = None if lift_scale is None else np.broadcast_to(np.asarray(lift_scale, dtype=float), p.shape[:1])
    out = np.empty((p.shape[0], times.size, 3))
    for i, t in enumerate(times):
        span = t - t_now
        steps = max(1, math.ceil(float(np.max(np.abs(span))) / max_step))
        h = (span / steps)[:, None]
        for _ in range(steps):
            k1v = acceleration(v, w, ball, lam)
            v2 = v + 0.5 * h * k1v
            k2v = acceleration(v2, w, ball, lam)
            v3 = v + 0.5 * h * k2v
            k3v = acceleration(v3, w, ball, lam)
            v4 = v + h * k3v
            k4v = acceleration(v4, w, ball, lam)
            p = p + h / 6.0 * (v + 2.0 * v2 + 2.0 * v3 + v4)
            v = v + h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v)
        t_now = np.full_like(t_now, t)
        out[:, i, :] = p
    return out

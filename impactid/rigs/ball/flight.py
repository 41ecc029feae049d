"""Vertical free flight of a ball between two impacts, with gravity and (optionally) air.

Equation of motion (upwards positive, ``v`` the velocity)::

    (m + rho V / 2) dv/dt = -(m - rho V) g - k v |v|,      k = 0.5 rho Cd A

with buoyancy ``rho V g`` and the added mass ``rho V / 2`` of a sphere. Divided by the effective
mass it reads ``dv/dt = -g_e (1 + v |v| / v_t^2)`` with the effective gravity
``g_e = g (m - rho V) / (m + rho V / 2)`` and the terminal speed ``v_t = sqrt((m - rho V) g / k)``.
Both numbers are held by :class:`FlightConstants`; a flight without air has ``g_e = g`` and
``v_t = inf``.

Closed forms (``s = u / v_t`` for a launch speed ``u``):

* up:   ``v(t) = v_t tan(atan(s) - g_e t / v_t)``, apex after ``t_up = (v_t / g_e) atan(s)`` at height
  ``H = v_t^2 / (2 g_e) ln(1 + s^2)``;
* down: ``v(t) = -v_t tanh(g_e t / v_t)``, fallen ``(v_t^2 / g_e) ln cosh(g_e t / v_t)``, so the fall
  from ``H`` lasts ``t_down = (v_t / g_e) acosh(sqrt(1 + s^2)) = (v_t / g_e) asinh(s)`` and lands at
  ``w = v_t tanh(asinh(s)) = u / sqrt(1 + s^2)``;
* the flight time ``T(u) = (v_t / g_e) (atan(s) + asinh(s))`` is increasing and concave in ``u``; it
  is inverted by Newton's method started below the root (``s0 = g_e T / (2 v_t)``, because
  ``atan(s) + asinh(s) <= 2 s``), which then converges monotonically and quadratically.

Without drag (``v_t -> inf``) these reduce to ``T = 2 u / g``, ``w = u`` and, for a sequence of
flights, ``e_k = T_k / T_(k-1)`` and ``v_k = g T_(k-1) / 2``.

Every function is a pure function on arrays; speeds are magnitudes [m/s], times [s].
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from impactid.rigs.ball.parameters import STANDARD_GRAVITY, Ball

__all__ = ["FlightConstants", "apex_height", "chain_flights", "flight_constants", "flight_time",
           "flight_time_derivative", "invert_flights", "landing_speed", "landing_speed_derivative",
           "launch_speed", "launch_from_landing", "restitution_from_flights", "trajectory"]


@dataclass(frozen=True)
class FlightConstants:
    """What a vertical flight depends on.

    Attributes
    ----------
    gravity : effective gravitational acceleration ``g_e`` [m/s^2] (buoyancy and added mass included).
    terminal_speed : ``v_t`` [m/s]; ``inf`` without drag.
    label : how they were obtained (for reports), e.g. ``"vacuum"`` or ``"air: drag, buoyancy, added mass"``.
    """

    gravity: float = STANDARD_GRAVITY
    terminal_speed: float = math.inf
    label: str = "vacuum"

    @property
    def drag(self) -> bool:
        """Whether the flight has drag (finite terminal speed)."""
        return math.isfinite(self.terminal_speed)

    def to_dict(self) -> dict:
        return {"gravity_m_s2": self.gravity, "terminal_speed_m_s": self.terminal_speed, "label": self.label}


def flight_constants(ball: Ball | None = None, drag: bool = True, gravity: float | None = None) -> FlightConstants:
    """The flight constants of ``ball``: with air (drag, buoyancy, added mass) or in vacuum.

    Parameters
    ----------
    ball : the ball; None for an unknown ball (vacuum flight, the only one possible).
    drag : include the air (drag, buoyancy and added mass); False for a vacuum flight.
    gravity : [m/s^2]; default the ball's (or standard gravity without a ball).
    """
    g = float(gravity) if gravity is not None else (ball.gravity if ball is not None else STANDARD_GRAVITY)
    if not (math.isfinite(g) and g > 0.0):
        raise ValueError(f"gravity must be positive and finite, got {gravity!r}")
    if ball is None or not drag or ball.air_density == 0.0:
        return FlightConstants(g, math.inf, "vacuum")
    m, ma = ball.mass, ball.displaced_air_mass
    g_e = g * (m - ma) / (m + 0.5 * ma)
    k = ball.drag_constant
    vt = math.inf if k == 0.0 else math.sqrt((m - ma) * g / k)
    label = "air: drag, buoyancy, added mass" if k > 0.0 else "air: buoyancy, added mass (no drag)"
    return FlightConstants(g_e, vt, label)


def _s(u, vt):
    return np.asarray(u, dtype=float) / vt


def flight_time(u, constants: FlightConstants = FlightConstants()) -> np.ndarray:
    """Duration [s] of a flight launched upwards at speed ``u`` [m/s] that lands at its launch height."""
    u = np.asarray(u, dtype=float)
    g, vt = constants.gravity, constants.terminal_speed
    if not math.isfinite(vt):
        return 2.0 * u / g
    s = u / vt
    return vt / g * (np.arctan(s) + np.arcsinh(s))


def flight_time_derivative(u, constants: FlightConstants = FlightConstants()) -> np.ndarray:
    """``dT/du`` [s^2/m] of :func:`flight_time`."""
    u = np.asarray(u, dtype=float)
    g, vt = constants.gravity, constants.terminal_speed
    if not math.isfinite(vt):
        return np.full_like(u, 2.0 / g)
    s2 = (u / vt) ** 2
    return (1.0 / (1.0 + s2) + 1.0 / np.sqrt(1.0 + s2)) / g


def landing_speed(u, constants: FlightConstants = FlightConstants()) -> np.ndarray:
    """Speed [m/s] at landing of a flight launched at ``u`` [m/s]: ``u / sqrt(1 + (u/v_t)^2)``."""
    u = np.asarray(u, dtype=float)
    vt = constants.terminal_speed
    if not math.isfinite(vt):
        return u.copy()
    return u / np.sqrt(1.0 + (u / vt) ** 2)


def landing_speed_derivative(u, constants: FlightConstants = FlightConstants()) -> np.ndarray:
    """``dw/du`` [-] of :func:`landing_speed`: ``(1 + s^2)^(-3/2)``."""
    u = np.asarray(u, dtype=float)
    vt = constants.terminal_speed
    if not math.isfinite(vt):
        return np.ones_like(u)
    return (1.0 + (u / vt) ** 2) ** -1.5


def launch_from_landing(w, constants: FlightConstants = FlightConstants()) -> np.ndarray:
    """Launch speed [m/s] of the flight that lands at ``w`` [m/s] (NaN if ``w >= v_t``)."""
    w = np.asarray(w, dtype=float)
    vt = constants.terminal_speed
    if not math.isfinite(vt):
        return w.copy()
    with np.errstate(invalid="ignore", divide="ignore"):
        out = w / np.sqrt(1.0 - (w / vt) ** 2)
    return np.where(w < vt, out, np.nan)


def apex_height(u, constants: FlightConstants = FlightConstants()) -> np.ndarray:
    """Apex height [m] above the launch point of a flight launched at ``u`` [m/s]."""
    u = np.asarray(u, dtype=float)
    g, vt = constants.gravity, constants.terminal_speed
    if not math.isfinite(vt):
        return u ** 2 / (2.0 * g)
    return vt ** 2 / (2.0 * g) * np.log1p((u / vt) ** 2)


def launch_speed(T, constants: FlightConstants = FlightConstants(), *, rtol: float = 1e-15,
                 max_iter: int = 200) -> np.ndarray:
    """Invert :func:`flight_time`: the launch speed [m/s] of a flight of duration ``T`` [s].

    Exact to round-off: Newton's method on ``atan(s) + asinh(s) = g_e T / v_t`` from below the
    root (see the module notes). Non-positive or non-finite ``T`` give NaN.
    """
    T = np.asarray(T, dtype=float)
    g, vt = constants.gravity, constants.terminal_speed
    valid = np.isfinite(T) & (T > 0.0)
    if not math.isfinite(vt):
        return np.where(valid, 0.5 * g * T, np.nan)
    tau = np.where(valid, g * T / vt, 1.0)
    s = 0.5 * tau
    for _ in range(max_iter):
        f = np.arctan(s) + np.arcsinh(s) - tau
        d = 1.0 / (1.0 + s * s) + 1.0 / np.sqrt(1.0 + s * s)
        step = -f / d
        s = s + step
        if np.all(np.abs(step) <= rtol * np.maximum(s, 1e-300)):
            break
    return np.where(valid, s * vt, np.nan)


def invert_flights(T, constants: FlightConstants = FlightConstants()) -> tuple[np.ndarray, np.ndarray]:
    """Launch and landing speeds [m/s] of flights of durations ``T`` [s]."""
    u = launch_speed(T, constants)
    return u, landing_speed(u, constants)


def restitution_from_flights(T_before, T_after, constants: FlightConstants = FlightConstants()
                             ) -> tuple[np.ndarray, np.ndarray]:
    """Coefficient of restitution and impact speed of the impacts between two flights.

    Parameters
    ----------
    T_before : duration [s] of the flight that ends at the impact.
    T_after : duration [s] of the flight that starts at it.
    constants : the flight's :class:`FlightConstants`.

    Returns
    -------
    e : ``u(T_after) / w(T_before)`` [-] (``T_after / T_before`` without drag).
    v : impact speed ``w(T_before)`` [m/s] (``g T_before / 2`` without drag).
    """
    _, w = invert_flights(T_before, constants)
    u = launch_speed(T_after, constants)
    return u / w, w


def chain_flights(u0: float, n: int, law: Callable[[np.ndarray], np.ndarray],
                  constants: FlightConstants = FlightConstants()) -> dict[str, np.ndarray]:
    """A sequence of ``n`` flights: the first launched at ``u0`` [m/s], each next one launched at
    ``e(w) w`` from the landing speed ``w`` of the one before.

    Returns a dict of arrays of length ``n``: ``T`` (durations [s]), ``u`` (launch speeds),
    ``w`` (landing speeds), and ``e`` (of length ``n - 1``: the restitution at each inner impact).
    """
    T, U, W, E = np.empty(n), np.empty(n), np.empty(n), np.empty(max(n - 1, 0))
    u = float(u0)
    for k in range(n):
        U[k] = u
        T[k] = flight_time(u, constants)
        W[k] = landing_speed(u, constants)
        if k < n - 1:
            E[k] = float(law(np.asarray(W[k])))
            u = E[k] * W[k]
    return {"T": T, "u": U, "w": W, "e": E}


def trajectory(u: float, t, constants: FlightConstants = FlightConstants()) -> tuple[np.ndarray, np.ndarray]:
    """Height [m] and velocity [m/s] (upwards positive) at times ``t`` [s] after a launch at ``u``,
    from the closed forms (valid for ``0 <= t <= flight_time(u)``)."""
    t = np.asarray(t, dtype=float)
    g, vt = constants.gravity, constants.terminal_speed
    if not math.isfinite(vt):
        return u * t - 0.5 * g * t ** 2, u - g * t
    s = u / vt
    t_up = vt / g * math.atan(s)
    H = vt ** 2 / (2 * g) * math.log1p(s * s)
    phase = np.arctan(s) - g * np.minimum(t, t_up) / vt
    up_h = vt ** 2 / g * np.log(np.cos(phase) / math.cos(math.atan(s)))
    up_v = vt * np.tan(phase)
    td = np.maximum(t - t_up, 0.0)
    down_h = H - vt ** 2 / g * np.log(np.cosh(g * td / vt))
    down_v = -vt * np.tanh(g * td / vt)
    rising = t <= t_up
    return np.where(rising, up_h, down_h), np.where(rising, up_v, down_v)

"""Rig F: eccentric cam on an oscillating flat-faced follower (Alzate et al. 2007, docs/rig_f.md).

Angles are counter-clockwise; ``theta_f`` is the follower angle, ``theta_c`` the cam angle [rad].
With ``X = e cos theta_c + x0`` and ``Y = e sin theta_c + y0`` (the cam centre), the gap (A-26,
corrected) is ``h = X sin theta_f - Y cos theta_f - d - R`` and the follower angle in contact (A-17)
is ``theta_hat = arcsin((d + R) / rho) + atan2(Y, X)`` with ``rho = |(X, Y)|``.

As for rig P, the physics lives in pure functions (numpy ufuncs only) and
:class:`FlatFollowerRig` organises the calls, validates parameters and round-trips TOML.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from impactid.errors import RigParameterError
from impactid.rigs._params import RigParameters

__all__ = ["ALZATE2007", "MODEL_NAME", "FlatFollowerRig", "contact_angle_derivatives", "contact_follower_angle",
           "flat_gap", "flat_gap_rate", "flat_lever", "flat_spring_torque"]

MODEL_NAME = "flat-follower"


# --------------------------------------------------------------------------------------------
# Pure physics
# --------------------------------------------------------------------------------------------


def flat_gap(theta_f, theta_c, R, e, x0, y0, d):
    """Gap ``h`` between cam and follower face [m] (A-26 with ``e cos`` restored); >= 0 apart."""
    X = e * np.cos(theta_c) + x0
    Y = e * np.sin(theta_c) + y0
    return X * np.sin(theta_f) - Y * np.cos(theta_f) - d - R


def contact_angle_derivatives(theta_c, R, e, x0, y0, d):
    """``(theta_hat, d theta_hat/d theta_c, d2 theta_hat/d theta_c2)`` of (A-17) [rad, -, rad^-1].

    Uses numpy ufuncs only, so it also compiles with numba for scalars (the rig F simulator).
    With ``X, Y`` the cam centre, ``q = X^2 + Y^2``, ``s = (d + R) / sqrt(q)`` and
    ``phi = atan2(Y, X)``: ``theta_hat = arcsin(s) + phi``; ``q' = 2 e (y0 cos - x0 sin)``,
    ``q'' = -2 e (x0 cos + y0 sin)``, ``phi' = N / q`` with ``N = e (x0 cos + y0 sin + e)``.
    """
    c = d + R
    ct, st = np.cos(theta_c), np.sin(theta_c)
    X = e * ct + x0
    Y = e * st + y0
    q = X * X + Y * Y
    s = c / np.sqrt(q)
    value = np.arcsin(s) + np.arctan2(Y, X)
    dq = 2.0 * e * (y0 * ct - x0 * st)
    ddq = -2.0 * e * (x0 * ct + y0 * st)
    N = e * (x0 * ct + y0 * st + e)
    dphi = N / q
    ds = -0.5 * s * dq / q
    root = np.sqrt(1.0 - s * s)
    first = ds / root + dphi
    ddphi = dq * (0.5 * q - N) / (q * q)
    dds = -0.5 * (ds * dq / q + s * (ddq * q - dq * dq) / (q * q))
    second = dds / root + s * ds * ds / root**3 + ddphi
    return value, first, second


def contact_follower_angle(theta_c, R, e, x0, y0, d, derivatives: int = 0):
    """Follower angle in contact ``theta_hat(theta_c)`` [rad] (A-17) and its analytic derivatives.

    Parameters
    ----------
    theta_c : cam angle [rad] (array or scalar).
    derivatives : 0, 1 or 2; with 1 or 2 returns a tuple ``(theta_hat, d/dtheta_c, d2/dtheta_c2)``
        up to the order asked [rad, rad/rad, rad/rad^2].
    """
    theta_c = np.asarray(theta_c, dtype=float)
    if derivatives == 0:
        X = e * np.cos(theta_c) + x0
        Y = e * np.sin(theta_c) + y0
        return np.arcsin((d + R) / np.sqrt(X * X + Y * Y)) + np.arctan2(Y, X)
    value, first, second = contact_angle_derivatives(theta_c, R, e, x0, y0, d)
    return (value, first) if derivatives == 1 else (value, first, second)


def flat_gap_rate(theta_f, rate_f, theta_c, omega, e, x0, y0):
    """Rate of the gap ``dh/dt`` [m/s] at follower rate ``rate_f`` [rad/s] and cam speed ``omega``
    [rad/s]: ``X' sin th - Y' cos th + (X cos th + Y sin th) th'`` (A-19 with the cam centre)."""
    ct, st = np.cos(theta_c), np.sin(theta_c)
    X = e * ct + x0
    Y = e * st + y0
    cf, sf = np.cos(theta_f), np.sin(theta_f)
    return -e * omega * st * sf - e * omega * ct * cf + (X * cf + Y * sf) * rate_f


def flat_lever(theta_f, theta_c, e, x0, y0):
    """``dh/dtheta_f = X cos th + Y sin th`` [m]: the follower's lever arm at the contact (A-24)."""
    X = e * np.cos(theta_c) + x0
    Y = e * np.sin(theta_c) + y0
    return X * np.cos(theta_f) + Y * np.sin(theta_f)


def flat_spring_torque(theta_f, K, x_A, d, spring_length):
    """Spring moment ``M_s(theta_f)`` of (A-10) [N m]: ``J theta_ddot + M_s = 0`` in free flight.

    ``M_s = K (x_A tan th + d / cos th - L) (x_A / cos^2 th + d sin th / cos^2 th)``, ``L`` the
    spring elongation constant ``y_A - d_0 - d_1`` [m]. Positive values push the follower
    towards the cam (decreasing ``theta_f``).
    """
    c = np.cos(theta_f)
    t = np.tan(theta_f)
    return K * (x_A * t + d / c - spring_length) * (x_A / c**2 + d * np.sin(theta_f) / c**2)


# --------------------------------------------------------------------------------------------
# Parameters
# --------------------------------------------------------------------------------------------

_UNITS = {"R": "m", "e": "m", "x0": "m", "y0": "m", "d": "m", "J": "kg m^2", "K": "N/m", "x_A": "m",
          "spring_length": "m"}


@dataclass(frozen=True)
class FlatFollowerRig(RigParameters):
    """Parameters of rig F (SI units; names as in docs/formats.md).

    Attributes
    ----------
    R : cam radius [m]
    e : cam eccentricity [m]
    x0, y0 : cam centre of rotation from the follower pivot [m]
    d : half follower height (pivot to follower face) [m]
    J : follower moment of inertia about its pivot [kg m^2]
    K : spring stiffness [N/m]
    x_A : spring hook abscissa [m]
    spring_length : spring elongation constant ``y_A - d_0 - d_1`` [m]
    """

    model: ClassVar[str] = MODEL_NAME

    R: float
    e: float
    x0: float
    y0: float
    d: float
    J: float
    K: float
    x_A: float
    spring_length: float

    def __post_init__(self) -> None:
        self._check_numbers()
        for name in ("R", "d", "J", "K", "x0", "spring_length"):
            if getattr(self, name) <= 0.0:
                raise RigParameterError(
                    f"rig parameter {name!r} must be positive, got {getattr(self, name)!r} [{_UNITS[name]}]")
        if not 0.0 <= self.e < self.R:
            raise RigParameterError(f"rig parameter 'e' = {self.e!r} m must lie in [0, R = {self.R!r} m)")
        if math.hypot(self.x0, self.y0) - self.e <= self.d + self.R:
            raise RigParameterError(
                "rig parameters place the cam within d + R of the follower pivot: "
                f"|(x0, y0)| - e = {math.hypot(self.x0, self.y0) - self.e!r} m <= d + R = {self.d + self.R!r} m")

    # ---- geometry and statics ----------------------------------------------------------------
    def gap(self, theta_f, theta_c):
        """Gap ``h`` [m] (A-26 corrected)."""
        return flat_gap(theta_f, theta_c, self.R, self.e, self.x0, self.y0, self.d)

    def contact_angle(self, theta_c, derivatives: int = 0):
        """Follower angle in contact and optionally its derivatives (A-17)."""
        return contact_follower_angle(theta_c, self.R, self.e, self.x0, self.y0, self.d, derivatives)

    def spring_torque(self, theta_f):
        """Spring moment ``M_s`` of (A-10) [N m]."""
        return flat_spring_torque(theta_f, self.K, self.x_A, self.d, self.spring_length)

    def contact_torque(self, theta_c, cam_speed_hz: float):
        """Torque the cam must exert on the follower to keep it in contact (A-11) [N m].

        ``tau = J omega^2 theta_hat'' + M_s(theta_hat)`` at constant cam speed ``omega``; the cam can
        only push (``tau >= 0``), so contact is lost where ``tau`` would turn negative.
        """
        omega = 2.0 * math.pi * cam_speed_hz
        th, _, dd = self.contact_angle(theta_c, derivatives=2)
        return self.J * omega**2 * dd + self.spring_torque(th)

    def detachment_speed_hz(self, samples: int = 20_000) -> float:
        """Lowest constant cam speed [Hz] at which the follower leaves the cam (A-11).

        ``tau(theta_c) >= 0`` for all cam angles requires ``omega^2 <= M_s / (-J theta_hat'')`` wherever
        ``theta_hat'' < 0``; the minimum of that ratio over a fine grid of cam angles, refined by a
        bounded scalar minimisation, gives the detachment speed.
        """
        from scipy import optimize

        def ratio(tc):
            th, _, dd = self.contact_angle(tc, derivatives=2)
            with np.errstate(divide="ignore", invalid="ignore"):
                return np.where(dd < 0.0, self.spring_torque(th) / (-self.J * dd), np.inf)

        grid = np.linspace(0.0, 2.0 * math.pi, samples, endpoint=False)
        values = ratio(grid)
        k = int(np.argmin(values))
        if not np.isfinite(values[k]):
            return math.inf
        step = grid[1] - grid[0]
        res = optimize.minimize_scalar(lambda tc: float(ratio(tc)), bounds=(grid[k] - step, grid[k] + step),
                                       method="bounded", options={"xatol": 1e-12})
        best = min(float(res.fun), float(values[k]))
        if best <= 0.0:
            return 0.0
        return math.sqrt(best) / (2.0 * math.pi)



#: Table 5 of Alzate et al. (2007) (docs/rig_f.md).
ALZATE2007 = FlatFollowerRig(R=0.045, e=0.015, x0=0.249, y0=0.0, d=0.021, J=0.043, K=105.0, x_A=-0.031,
                                 spring_length=0.173)

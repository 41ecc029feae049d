"""Rig P: eccentric cylindrical cam on a pivoted follower with point contact (Sundar, Dreyer & Singh 2016).

Frame (docs/rig_p.md): origin at the follower pivot P, ``e_x`` horizontal towards the cam, ``e_y`` up.
``alpha`` is the follower angle from ``e_x``, clockwise positive (tip moving down); the bar's unit
vectors are ``u = (cos a, -sin a)`` and ``n = (sin a, cos a)`` (towards the cam). The cam centre is
``G_c(Theta) = PE - e (cos Theta, sin Theta)``.

The module has two layers:

* pure physics functions (``gap``, ``lever_arm``, ``gap_rate``, ...) whose arguments are plain numbers
  or numpy arrays. They use only numpy ufuncs, so the compiled simulator compiles these very
  functions with numba: the formulas exist once.
* :class:`PivotedFollowerRig`, a frozen dataclass of the rig parameters (SI units, names of
  docs/formats.md) with validation, TOML round trip and convenience methods that call the functions above.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from scipy import optimize

from impactid.errors import RigParameterError
from impactid.rigs._params import RigParameters

__all__ = ["MODEL_NAME", "SUNDAR2016", "PivotedFollowerRig", "free_torque", "gap", "gap_paper", "gap_rate",
           "gap_rate_paper", "lever_arm", "sliding_velocity", "spring_force", "tangential_gap_paper",
           "tangential_gap_rate", "tangential_gap_rate_paper", "zero_state_angle"]

MODEL_NAME = "pivoted-follower"

# --------------------------------------------------------------------------------------------
# Pure physics (numpy- and numba-compatible). Angles [rad], lengths [m], rates [rad/s], [m/s].
# --------------------------------------------------------------------------------------------


def gap(alpha, theta, PE_x, PE_y, e, contact_radius):
    """Normal gap ``psi_i`` between cam and follower contact line [m] (positive = separated).

    ``psi_i = n(alpha) . G_c(Theta) - (h_p + r_c)``; ``contact_radius`` is ``h_p + r_c`` [m].
    Equivalent to (S-5) (see :func:`gap_paper`).
    """
    gx = PE_x - e * np.cos(theta)
    gy = PE_y - e * np.sin(theta)
    return np.sin(alpha) * gx + np.cos(alpha) * gy - contact_radius


def lever_arm(alpha, theta, PE_x, PE_y, e):
    """Lever arm ``chi = u(alpha) . G_c(Theta)`` of the contact force about P [m]."""
    gx = PE_x - e * np.cos(theta)
    gy = PE_y - e * np.sin(theta)
    return np.cos(alpha) * gx - np.sin(alpha) * gy


def gap_rate(alpha, alpha_dot, theta, theta_dot, chi, e):
    """Gap rate ``dpsi_i/dt = chi alpha_dot - e cos(alpha + Theta) Theta_dot`` [m/s] (S-7)."""
    return chi * alpha_dot - e * np.cos(alpha + theta) * theta_dot


def tangential_gap_rate(alpha, alpha_dot, theta, theta_dot, psi, contact_radius, e):
    """``dpsi_j/dt = alpha_dot (psi_i + h_p + r_c) - e Theta_dot sin(alpha + Theta)`` [m/s] (S-8)."""
    return alpha_dot * (psi + contact_radius) - e * theta_dot * np.sin(alpha + theta)


def sliding_velocity(alpha, alpha_dot, theta, theta_dot, tangential_rate, e, r_c):
    """Relative sliding velocity at the contact ``v_r`` [m/s] (S-18).

    ``tangential_rate`` is ``dpsi_j/dt`` from :func:`tangential_gap_rate`."""
    return tangential_rate - (r_c + e * np.sin(alpha + theta)) * (alpha_dot + theta_dot)


def spring_force(alpha, k_s, L_s_u, d_y, d_x, w_b):
    """Coil-spring force ``F_s`` [N] (S-10); positive in compression, pushing the bar up."""
    return k_s * (L_s_u - d_y + d_x * np.tan(alpha) + 0.5 * w_b / np.cos(alpha))


def free_torque(alpha, spring, m_b, g, l_g, d_x):
    """Torque about P of gravity and spring ``m_b g l_g cos(alpha) - F_s d_x`` [N m] (S-9).

    ``spring`` is ``F_s`` from :func:`spring_force` [N]."""
    return m_b * g * l_g * np.cos(alpha) - spring * d_x


# Paper forms (S-3)..(S-8), kept to show that the closed forms above are the same functions.


def zero_state_angle(PE_x, PE_y, contact_distance):
    """0-state follower angle ``alpha0`` (S-3, corrected as in docs/rig_p.md) [rad].

    ``contact_distance`` is ``D = h_p + r_c + e`` [m]; requires ``D < |PE|``.
    """
    num = PE_y * contact_distance + np.sqrt(
        PE_x**4 + PE_x**2 * PE_y**2 - PE_x**2 * contact_distance**2
    )
    return np.arccos(num / (PE_x**2 + PE_y**2))


def gap_paper(alpha, theta, alpha0, chi0, contact_radius, e):
    """``psi_i`` in the paper's form (S-5)."""
    theta0 = 0.5 * np.pi - alpha0
    return (
        chi0 * np.sin(alpha - alpha0)
        + contact_radius * (np.cos(alpha - alpha0) - 1.0)
        + e * (np.sin(alpha + theta0) - np.sin(alpha + theta))
    )


def tangential_gap_paper(alpha, theta, alpha0, chi0, contact_radius, e):
    """``psi_j`` in the paper's form (S-6); ``chi = chi0 - psi_j``."""
    theta0 = 0.5 * np.pi - alpha0
    return (
        chi0 * (1.0 - np.cos(alpha - alpha0))
        + contact_radius * np.sin(alpha - alpha0)
        - e * (np.cos(alpha + theta0) - np.cos(alpha + theta))
    )


def gap_rate_paper(alpha, alpha_dot, theta, theta_dot, alpha0, chi0, contact_radius, e):
    """``dpsi_i/dt`` in the paper's form (S-7)."""
    theta0 = 0.5 * np.pi - alpha0
    return (
        chi0 * np.cos(alpha - alpha0) * alpha_dot
        - contact_radius * np.sin(alpha - alpha0) * alpha_dot
        + e * (np.cos(alpha + theta0) * alpha_dot - np.cos(alpha + theta) * (alpha_dot + theta_dot))
    )


def tangential_gap_rate_paper(alpha, alpha_dot, theta, theta_dot, alpha0, chi0, contact_radius, e):
    """``dpsi_j/dt`` in the paper's form (S-8)."""
    theta0 = 0.5 * np.pi - alpha0
    return (
        chi0 * np.sin(alpha - alpha0) * alpha_dot
        + contact_radius * np.cos(alpha - alpha0) * alpha_dot
        + e * (np.sin(alpha + theta0) * alpha_dot - np.sin(alpha + theta) * (alpha_dot + theta_dot))
    )


# --------------------------------------------------------------------------------------------
# Parameters
# --------------------------------------------------------------------------------------------

_UNITS = {
    "m_b": "kg", "I_b": "kg m^2", "l_g": "m", "l_a": "m", "w_b": "m", "r_d": "m", "r_c": "m",
    "e": "m", "k_s": "N/m", "L_s_u": "m", "d_x": "m", "d_y": "m", "PE_x": "m", "PE_y": "m",
    "Y_c": "Pa", "Y_b": "Pa", "nu_c": "-", "nu_b": "-", "mu": "-", "g": "m/s^2",
}


@dataclass(frozen=True)
class PivotedFollowerRig(RigParameters):
    """Parameters of rig P (SI units; names as in docs/formats.md).

    Attributes
    ----------
    m_b : follower mass [kg]
    I_b : follower moment of inertia about the pivot P [kg m^2]
    l_g : pivot to follower centre of gravity [m]
    l_a : pivot to accelerometer [m]
    w_b : bar width [m]
    r_d : dowel-pin radius [m]
    r_c : cam radius [m]
    e : cam eccentricity [m]
    k_s : coil-spring stiffness [N/m]
    L_s_u : undeflected spring length [m]
    d_x : spring axis from P along e_x [m]
    d_y : spring ground below P [m]
    PE_x, PE_y : cam rotation axis E from P [m]
    Y_c, Y_b : Young's moduli of cam and pin [Pa]
    nu_c, nu_b : Poisson's ratios [-]
    mu : Coulomb friction coefficient at the contact [-]
    g : gravitational acceleration [m/s^2]
    """

    model: ClassVar[str] = MODEL_NAME

    m_b: float
    I_b: float
    l_g: float
    l_a: float
    w_b: float
    r_d: float
    r_c: float
    e: float
    k_s: float
    L_s_u: float
    d_x: float
    d_y: float
    PE_x: float
    PE_y: float
    Y_c: float
    Y_b: float
    nu_c: float
    nu_b: float
    mu: float
    g: float

    # ---- construction and validation -------------------------------------------------------
    def __post_init__(self) -> None:
        self._check_numbers()
        positive = ("m_b", "I_b", "l_g", "l_a", "w_b", "r_d", "r_c", "k_s", "L_s_u", "d_x",
                    "PE_x", "Y_c", "Y_b", "g")
        for name in positive:
            if getattr(self, name) <= 0.0:
                raise RigParameterError(
                    f"rig parameter {name!r} must be positive, got {getattr(self, name)!r} "
                    f"[{_UNITS[name]}]"
                )
        if self.e < 0.0:
            raise RigParameterError(f"rig parameter 'e' (cam eccentricity) must be >= 0, got {self.e!r} m")
        if self.e >= self.r_c:
            raise RigParameterError(
                f"rig parameter 'e' = {self.e!r} m must be smaller than the cam radius r_c = {self.r_c!r} m"
            )
        for name in ("nu_c", "nu_b"):
            if not 0.0 <= getattr(self, name) < 0.5:
                raise RigParameterError(f"rig parameter {name!r} must lie in [0, 0.5), got {getattr(self, name)!r}")
        if self.mu < 0.0:
            raise RigParameterError(f"rig parameter 'mu' must be >= 0, got {self.mu!r}")
        if self.I_b < self.m_b * self.l_g**2 * (1.0 - 1e-12):
            raise RigParameterError(
                f"rig parameters 'I_b' = {self.I_b!r} kg m^2 and 'm_b' l_g^2 = {self.m_b * self.l_g**2!r} kg m^2: "
                "the moment of inertia about the pivot cannot be smaller than m_b l_g^2 "
                "(are l_g and l_b swapped, as in the paper's Table 1?)"
            )
        if self.contact_distance >= math.hypot(self.PE_x, self.PE_y):
            raise RigParameterError(
                "rig parameters place the cam axis E closer to the pivot than h_p + r_c + e: "
                f"|PE| = {math.hypot(self.PE_x, self.PE_y)!r} m <= {self.contact_distance!r} m"
            )

    def with_eccentricity_ratio(self, e_over_rc: float) -> PivotedFollowerRig:
        """A copy with ``e = e_over_rc * r_c``."""
        if not (isinstance(e_over_rc, (int, float)) and math.isfinite(e_over_rc)):
            raise RigParameterError(f"e/r_c must be a finite number, got {e_over_rc!r}")
        return self.replace(e=float(e_over_rc) * self.r_c)

    # ---- derived quantities ------------------------------------------------------------------
    @property
    def e_over_rc(self) -> float:
        """Eccentricity ratio ``e / r_c`` [-]."""
        return self.e / self.r_c

    @property
    def h_p(self) -> float:
        """Offset of the follower contact line from the bar axis ``0.5 w_b + 2 r_d`` [m].

        It is also the moment arm of the friction force about P (S-16)."""
        return 0.5 * self.w_b + 2.0 * self.r_d

    @property
    def contact_radius(self) -> float:
        """``h_p + r_c`` [m]: distance from the cam centre to the bar axis at zero gap."""
        return self.h_p + self.r_c

    @property
    def contact_distance(self) -> float:
        """``D = h_p + r_c + e`` [m] of the 0-state (S-3)."""
        return self.contact_radius + self.e

    @property
    def effective_radius(self) -> float:
        """``rho_e = (1/r_c + 1/r_d)^-1`` [m] (S-13)."""
        return 1.0 / (1.0 / self.r_c + 1.0 / self.r_d)

    @property
    def effective_modulus(self) -> float:
        """``Y_e = [(1-nu_c^2)/Y_c + (1-nu_b^2)/Y_b]^-1`` [Pa] (S-12)."""
        return 1.0 / ((1.0 - self.nu_c**2) / self.Y_c + (1.0 - self.nu_b**2) / self.Y_b)

    @property
    def k_H(self) -> float:
        """Hertz point-contact stiffness ``4/3 Y_e sqrt(rho_e)`` [N m^-1.5] (S-11)."""
        return 4.0 / 3.0 * self.effective_modulus * math.sqrt(self.effective_radius)

    @property
    def alpha0(self) -> float:
        """0-state follower angle (S-3, corrected) [rad]."""
        return float(zero_state_angle(self.PE_x, self.PE_y, self.contact_distance))

    @property
    def theta0(self) -> float:
        """0-state cam angle ``pi/2 - alpha0`` (S-4) [rad]."""
        return 0.5 * math.pi - self.alpha0

    @property
    def chi0(self) -> float:
        """Lever arm at the 0-state ``u(alpha0) . PE`` [m]."""
        a0 = self.alpha0
        return self.PE_x * math.cos(a0) - self.PE_y * math.sin(a0)

    # ---- geometry and forces (vectorised) -----------------------------------------------------
    def gap(self, alpha, theta):
        """Gap ``psi_i(alpha, Theta)`` [m]; positive = separated."""
        return gap(alpha, theta, self.PE_x, self.PE_y, self.e, self.contact_radius)

    def lever_arm(self, alpha, theta):
        """Lever arm ``chi(alpha, Theta)`` [m]."""
        return lever_arm(alpha, theta, self.PE_x, self.PE_y, self.e)

    def gap_rate(self, alpha, alpha_dot, theta, theta_dot):
        """Gap rate ``dpsi_i/dt`` [m/s] for cam speed ``theta_dot`` [rad/s]."""
        chi = self.lever_arm(alpha, theta)
        return gap_rate(alpha, alpha_dot, theta, theta_dot, chi, self.e)

    def tangential_gap_rate(self, alpha, alpha_dot, theta, theta_dot):
        """``dpsi_j/dt`` [m/s] (S-8)."""
        psi = self.gap(alpha, theta)
        return tangential_gap_rate(alpha, alpha_dot, theta, theta_dot, psi, self.contact_radius, self.e)

    def sliding_velocity(self, alpha, alpha_dot, theta, theta_dot):
        """Relative sliding velocity ``v_r`` [m/s] (S-18)."""
        return sliding_velocity(alpha, alpha_dot, theta, theta_dot,
                                self.tangential_gap_rate(alpha, alpha_dot, theta, theta_dot), self.e, self.r_c)

    def spring_force(self, alpha):
        """Spring force ``F_s`` [N] (S-10)."""
        return spring_force(alpha, self.k_s, self.L_s_u, self.d_y, self.d_x, self.w_b)

    def free_torque(self, alpha):
        """Gravity plus spring torque about P [N m] (right side of S-9)."""
        return free_torque(alpha, self.spring_force(alpha), self.m_b, self.g, self.l_g, self.d_x)

    def contact_angle(self, theta):
        """Follower angle at which the gap closes for cam angle ``theta`` [rad] (``psi_i = 0``).

        Solved by Newton's method on the closed form (converges in a few iterations because
        ``dpsi/dalpha = chi`` is about 0.09 m and the curvature is small); vectorised.
        """
        theta = np.asarray(theta, dtype=float)
        alpha = np.full_like(theta, self.alpha0)
        for _ in range(50):
            psi = self.gap(alpha, theta)
            step = psi / self.lever_arm(alpha, theta)
            alpha = alpha - step
            if np.all(np.abs(step) < 1e-15):
                break
        return alpha if alpha.ndim else float(alpha)

    def static_equilibrium(self, theta: float = 0.0) -> float:
        """Static equilibrium follower angle ``alpha*`` with the cam at ``theta`` [rad].

        Gravity and spring torque balanced by the Hertz contact force ``k_H delta^1.5`` at the
        lever arm ``chi``; friction is left out of the statics (docs/estimation.md). If the spring
        does not hold the follower against the cam, the free equilibrium is returned.
        """
        alpha_c = float(self.contact_angle(theta))
        k_h = self.k_H

        def torque(alpha: float) -> float:
            delta = max(-float(self.gap(alpha, theta)), 0.0)
            return float(self.free_torque(alpha)) + k_h * delta**1.5 * float(self.lever_arm(alpha, theta))

        if torque(alpha_c) > 0.0:
            # gravity wins at the contact angle: the follower hangs free below the cam
            lo, hi = alpha_c, alpha_c + 0.5
            return optimize.brentq(lambda a: float(self.free_torque(a)), lo, hi, xtol=1e-15, rtol=1e-15)
        lo = alpha_c - 1e-6
        while torque(lo) < 0.0:
            lo = alpha_c - 4.0 * (alpha_c - lo)
            if alpha_c - lo > 0.1:
                raise RigParameterError("no static equilibrium in contact found for this rig")
        return optimize.brentq(torque, lo, alpha_c, xtol=1e-16, rtol=4 * np.finfo(float).eps)

    # ---- TOML ---------------------------------------------------------------------------------


#: Table 1 of Sundar, Dreyer & Singh (2016) with its labels repaired (docs/rig_p.md); ``e`` for e/r_c = 0.2.
SUNDAR2016 = PivotedFollowerRig(
    m_b=0.257, I_b=3.3e-3, l_g=0.086, l_a=0.063, w_b=0.0127, r_d=0.0032, r_c=0.0175,
    e=0.2 * 0.0175, k_s=3319.0, L_s_u=0.053, d_x=0.035, d_y=0.058, PE_x=0.089, PE_y=0.027,
    Y_c=210e9, Y_b=210e9, nu_c=0.3, nu_b=0.3, mu=0.2, g=9.81,
)

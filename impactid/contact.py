"""Contact-force and restitution laws, and the conversions between them (docs/rig_p.md, docs/estimation.md).

Sign conventions: ``delta = -psi_i >= 0`` is the indentation [m] and ``gap_rate = dpsi_i/dt``
[m/s] (negative while approaching). Forces are compressive-positive [N].

All functions are pure and accept numpy arrays; the law functions use only numpy ufuncs so the
compiled simulator compiles the same code with numba.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from impactid.errors import SimulationInputError

__all__ = ["HuntCrossley", "Restitution", "beta_from_gamma", "clip_tensile", "coulomb_friction", "gamma_from_beta",
           "hunt_crossley_force", "restitution_coefficient", "viscous_force"]

def hunt_crossley_force(delta, gap_rate, k_H, beta, n, p=1.5):
    """Generalised Hunt–Crossley contact force ``F = k_H delta^p - beta delta^n dpsi/dt`` [N].

    Parameters
    ----------
    delta : indentation ``-psi_i`` [m]; values <= 0 mean no contact and give 0 force.
    gap_rate : ``dpsi_i/dt`` [m/s] (negative while approaching, so damping is compressive then).
    k_H : Hertz stiffness [N m^-1.5].
    beta : damping coefficient [N s m^-(n+1)].
    n : damping index [-]; ``n = 0`` is viscous damping (force ``-beta dpsi/dt`` from first touch).
    p : stiffness exponent [-]; 1.5 for Hertz point contact (the papers), 1 for a linear spring.

    Returns
    -------
    Contact force, unclipped: it can be tensile (negative) near separation, as in the paper's
    model. Use :func:`clip_tensile` for the clipped variant. ``delta`` is clamped at 0, so call it
    for points in contact only (multiply by a contact mask otherwise); at first touch
    (``delta = 0``) the force is 0 for ``n > 0`` and ``-beta dpsi/dt`` for ``n = 0`` (viscous).
    """
    d = np.maximum(delta, 0.0)
    return k_H * np.power(d, p) - beta * np.power(d, n) * gap_rate


def viscous_force(delta, gap_rate, k_H, c):
    """Hertz stiffness with viscous damping ``c`` [N s/m] (the n = 0 case of Hunt–Crossley)."""
    return hunt_crossley_force(delta, gap_rate, k_H, c, 0.0)


def clip_tensile(force):
    """Replace tensile (negative) contact force by 0 [N]."""
    return np.maximum(force, 0.0)


def coulomb_friction(normal_force, sliding_velocity, mu):
    """Coulomb friction magnitude ``F_f = mu F_lam sgn(v_r)`` [N] (S-17)."""
    return mu * normal_force * np.sign(sliding_velocity)


def restitution_coefficient(approach_speed, gamma, xi0=1.0):
    """Speed-dependent coefficient of restitution ``xi = xi0 - gamma v_a`` [-].

    ``xi0 = 1`` gives Hunt and Crossley's law ``xi = 1 - gamma v_a`` (S-25); ``gamma = 0`` gives a
    constant coefficient ``xi0``. Values below 0 are outside the law's range and are returned as
    they are (the simulator refuses them; docs/estimation.md forbids silent clamping).
    """
    return xi0 - gamma * np.asarray(approach_speed, dtype=float)


def beta_from_gamma(gamma, k_H):
    """Hunt–Crossley damping ``beta = 1.5 gamma k_H`` [N s m^-2.5] for n = 1.5 (docs/estimation.md).

    ``gamma`` [s/m], ``k_H`` [N m^-1.5]. With the paper rig's k_H (about 8.0e9) gamma = 0.758 s/m gives
    about 9.1e9 N s m^-2.5, as in section 8.3 of Sundar, Dreyer & Singh (2016).
    """
    return 1.5 * np.asarray(gamma, dtype=float) * k_H


def gamma_from_beta(beta, k_H):
    """Inverse of :func:`beta_from_gamma`: ``gamma = beta / (1.5 k_H)`` [s/m]."""
    return np.asarray(beta, dtype=float) / (1.5 * k_H)


# --------------------------------------------------------------------------------------------
# Law descriptions used by the simulator
# --------------------------------------------------------------------------------------------


def _check_finite(name: str, value: float) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        raise SimulationInputError(f"{name} must be a number, got {value!r}")
    value = float(value)
    if not math.isfinite(value):
        raise SimulationInputError(f"{name} must be finite, got {value!r}")
    return value


@dataclass(frozen=True)
class HuntCrossley:
    """Generalised Hunt–Crossley contact law ``F = k_H delta^1.5 - beta delta^n dpsi/dt``.

    Attributes
    ----------
    beta : damping coefficient [N s m^-(n+1)] (the papers quote GN s m^-2.5 for n = 1.5).
    n : damping index [-]; 0 is viscous damping.
    clip : replace tensile force by 0 (the paper's model is unclipped; default False).
    stiffness_exponent : exponent p of the elastic term ``k_H delta^p`` (1.5, Hertz, by default;
        1 makes a linear spring–dashpot with ``n = 0``).
    """

    beta: float
    n: float = 1.5
    clip: bool = False
    stiffness_exponent: float = 1.5

    def __post_init__(self) -> None:
        object.__setattr__(self, "beta", _check_finite("beta", self.beta))
        object.__setattr__(self, "n", _check_finite("n", self.n))
        if self.beta < 0.0:
            raise SimulationInputError(f"beta must be >= 0, got {self.beta!r} N s m^-(n+1)")
        if self.n < 0.0:
            raise SimulationInputError(f"damping index n must be >= 0, got {self.n!r}")
        object.__setattr__(self, "stiffness_exponent", _check_finite("stiffness_exponent", self.stiffness_exponent))
        if self.stiffness_exponent < 1.0:
            raise SimulationInputError(f"stiffness exponent must be >= 1, got {self.stiffness_exponent!r}")


@dataclass(frozen=True)
class Restitution:
    """Instantaneous restitution law ``xi = xi0 - gamma v_a`` (docs/estimation.md; S3 simulations).

    Attributes
    ----------
    gamma : slope [s/m]; ``xi0 = 1`` gives Hunt and Crossley's ``xi = 1 - gamma v_a``.
    xi0 : restitution at zero approach speed [-]; ``gamma = 0`` gives a constant coefficient.
    v_stick : approach speed [m/s] below which an impact ends in sticking (rigid contact that
        lasts while the constraint force is compressive). The bounce sequence of this law never
        ends in finite time when ``xi -> 1`` (bounce speeds decay like 1/k), so it is replaced by
        its limit, the constrained motion; the kinetic energy so neglected is below
        ``0.5 (I_b / chi^2) v_stick^2`` (about 2e-11 J for rig P at the default 1e-5 m/s).
    """

    gamma: float
    xi0: float = 1.0
    v_stick: float = 1e-5

    def __post_init__(self) -> None:
        for name in ("gamma", "xi0", "v_stick"):
            object.__setattr__(self, name, _check_finite(name, getattr(self, name)))
        if self.gamma < 0.0:
            raise SimulationInputError(f"gamma must be >= 0, got {self.gamma!r} s/m")
        if not 0.0 < self.xi0 <= 1.0:
            raise SimulationInputError(f"xi0 must lie in (0, 1], got {self.xi0!r}")
        if self.v_stick < 0.0:
            raise SimulationInputError(f"v_stick must be >= 0, got {self.v_stick!r} m/s")

"""Parameters of the single-impact test rig (``drop-impact``): a mass dropped or swung onto a contact.

The rig has one degree of freedom, the position ``x`` [m] of the impactor's contact point along the
line of impact, **positive into the contact** (downwards for a drop tower), zero where it first
touches the contact's undeformed surface. The penetration is ``delta = x`` when ``x > 0``. The
contact force on the impactor opposes ``x`` and is the Hunt–Crossley force

    ``F = max(k delta^p + beta delta^n d(delta)/dt, 0)``  (no tension),

so that the equation of motion is ``m x'' = m g - F`` (``g``: the component of gravity along ``x``;
0 for a pendulum swung onto a vertical target). This module holds

* :class:`DropRig`: the rig (impactor mass, Hertz stiffness ``k``, stiffness exponent ``p``, gravity)
  as a frozen dataclass with validation and the TOML round trip of every rig
  (:class:`~impactid.rigs._params.RigParameters`);
* :class:`DropLaw`: the contact's damping (``beta``, ``n``), what the fit identifies with ``k``;
* pure functions: :func:`hertz_stiffness` (``k`` of a sphere on a flat), :func:`hertz_contact_time`
  and :func:`hertz_max_penetration` (the undamped impact without gravity, Hertz's closed forms, used
  for starting values and checks), :func:`hunt_crossley_damping` (``beta`` from a restitution slope);
* the preset :data:`STEEL_ON_PA6` (a 1 kg steel striker with a 16 mm hemispherical tip on a
  polyamide-6 pad) and its nominal law :data:`PA6_PAD_LAW`.

SI units throughout.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

from impactid.errors import RigParameterError, SimulationInputError
from impactid.rigs._params import RigParameters

__all__ = ["ACCELERATION_CHANNEL", "FORCE_CHANNEL", "MODEL_NAME", "PA6_PAD_LAW", "PRESETS", "STEEL_ON_PA6", "DropLaw",
           "DropRig", "hertz_contact_time", "hertz_max_penetration", "hertz_stiffness", "hunt_crossley_damping",
           "nominal_law", "stiffness_from_contact_time"]

MODEL_NAME = "drop-impact"
#: The accelerometer on the impactor: the specific force along the line of impact, away from the
#: contact, ``F/m`` [m/s^2] (what an accelerometer senses: 0 in free fall, ``+g`` at rest on the
#: contact; the impactor's acceleration towards the contact is ``g`` minus this).
ACCELERATION_CHANNEL = "impactor_acceleration"
#: A load cell under the contact: the contact force ``F`` [N], compressive positive.
FORCE_CHANNEL = "contact_force"

#: Units of the rig parameters (for messages and documentation).
UNITS = {"mass": "kg", "k": "N m^-p", "p": "-", "gravity": "m/s^2"}
#: Range of the stiffness exponent ``p``: 1 (a linear spring) to 3; Hertz point contact is 1.5.
P_RANGE = (1.0, 3.0)
#: Largest damping index ``n`` accepted by the simulator (the fit searches a narrower range).
N_MAX = 10.0
#: Range of the damping index ``n`` the fit searches (:func:`~impactid.rigs.drop.identify.fit_drop`).
N_BOUNDS = (0.5, 3.0)


# --------------------------------------------------------------------------------------------
# Pure functions
# --------------------------------------------------------------------------------------------


def hertz_stiffness(radius, youngs_1, poisson_1, youngs_2, poisson_2):
    """Hertz stiffness ``k = 4/3 E* sqrt(R)`` [N m^-1.5] of a sphere of radius ``radius`` [m] on a flat.

    ``E* = [(1 - nu_1^2)/E_1 + (1 - nu_2^2)/E_2]^-1`` [Pa] from the Young's moduli [Pa] and Poisson's
    ratios [-] of the two bodies (Johnson 1985, *Contact Mechanics*, eq. 4.22). The force is then
    ``k delta^1.5`` for the approach ``delta`` [m].
    """
    modulus = 1.0 / ((1.0 - poisson_1**2) / youngs_1 + (1.0 - poisson_2**2) / youngs_2)
    return 4.0 / 3.0 * modulus * math.sqrt(radius)


def _time_factor(p: float) -> float:
    """``T v / delta_max`` of the undamped impact with ``F = k delta^p``: ``2 int_0^1 du / sqrt(1 - u^(p+1))``
    ``= 2 sqrt(pi) Gamma(1 + 1/(p+1)) / Gamma(1/2 + 1/(p+1))`` (2.9432 for p = 1.5, pi for p = 1)."""
    q = 1.0 / (p + 1.0)
    return 2.0 * math.sqrt(math.pi) * math.gamma(1.0 + q) / math.gamma(0.5 + q)


def hertz_max_penetration(mass, k, p, speed):
    """Largest penetration [m] of an undamped impact at ``speed`` [m/s] without gravity:
    ``((p + 1) m v^2 / (2 k))^(1/(p+1))`` (the kinetic energy stored as ``k delta^(p+1)/(p+1)``)."""
    return ((p + 1.0) * mass * speed**2 / (2.0 * k)) ** (1.0 / (p + 1.0))


def hertz_contact_time(mass, k, p, speed):
    """Contact duration [s] of an undamped impact at ``speed`` [m/s] without gravity (Hertz: for
    ``p = 1.5``, ``2.9432 delta_max / v``). Inverting it for ``k`` gives the starting stiffness of
    the fit from a measured contact duration."""
    return _time_factor(p) * hertz_max_penetration(mass, k, p, speed) / speed


def stiffness_from_contact_time(mass, p, speed, duration):
    """The ``k`` [N m^-p] whose undamped impact at ``speed`` [m/s] lasts ``duration`` [s] (the inverse
    of :func:`hertz_contact_time`)."""
    delta_max = duration * speed / _time_factor(p)
    return (p + 1.0) * mass * speed**2 / (2.0 * delta_max ** (p + 1.0))


def hunt_crossley_damping(k, slope):
    """Hunt–Crossley damping ``beta = slope * k`` [N s m^-(p+1)] for ``n = p``.

    With ``n = p`` the force is ``k delta^p (1 + (beta/k) d(delta)/dt)``, and for light damping the
    coefficient of restitution is ``e ~ 1 - (2/3) (beta/k) v`` (Hunt & Crossley 1975), so a
    restitution falling by ``(2/3) slope`` per m/s of impact speed gives ``beta = slope k``.
    ``slope`` in s/m.
    """
    return slope * k


# --------------------------------------------------------------------------------------------
# The rig and the law
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class DropRig(RigParameters):
    """The single-impact test rig (a drop tower, an instrumented pendulum, a ball-drop force plate).

    Attributes
    ----------
    mass : impactor mass [kg] (with the accelerometer and whatever moves with it).
    k : contact stiffness [N m^-p]: the elastic force is ``k delta^p``. The fit identifies it; the
        rig's value is the nominal one (what simulations and synthetic recordings use).
    p : stiffness exponent [-], in [1, 3]: 1.5 for Hertz point contact (a sphere on a flat), 1 for a
        linear spring. Fixed in the fit.
    gravity : component of gravity along the line of impact [m/s^2], >= 0 (towards the contact):
        the local g for a drop, 0 for a pendulum swung horizontally onto a vertical target.
    """

    model: ClassVar[str] = MODEL_NAME

    mass: float
    k: float
    p: float = 1.5
    gravity: float = 9.81

    def __post_init__(self) -> None:
        self._check_numbers()
        for name in ("mass", "k"):
            if getattr(self, name) <= 0.0:
                raise RigParameterError(f"rig parameter {name!r} must be positive, got {getattr(self, name)!r} "
                                        f"[{UNITS[name]}]")
        if not P_RANGE[0] <= self.p <= P_RANGE[1]:
            raise RigParameterError(f"rig parameter 'p' (stiffness exponent) must lie in [{P_RANGE[0]:g}, "
                                    f"{P_RANGE[1]:g}], got {self.p!r} (1.5 for Hertz point contact)")
        if self.gravity < 0.0:
            raise RigParameterError(f"rig parameter 'gravity' must be >= 0 (its component towards the contact), "
                                    f"got {self.gravity!r} m/s^2")

    # ---- derived quantities ------------------------------------------------------------------
    def impact_speed(self, height: float, release_speed: float = 0.0) -> float:
        """Speed [m/s] at first touch after a fall of ``height`` [m] (the contact point's height above
        the contact surface at release) from ``release_speed`` [m/s] towards the contact:
        ``sqrt(v0^2 + 2 g h)``."""
        return math.sqrt(release_speed**2 + 2.0 * self.gravity * height)

    def static_penetration(self) -> float:
        """Penetration [m] at rest on the contact, ``(m g / k)^(1/p)`` (0 without gravity)."""
        return (self.mass * self.gravity / self.k) ** (1.0 / self.p)


@dataclass(frozen=True)
class DropLaw:
    """Damping of the Hunt–Crossley contact law ``F = k delta^p + beta delta^n d(delta)/dt``.

    Attributes
    ----------
    beta : damping coefficient [N s m^-(n+1)], >= 0.
    n : damping index [-], in [0, 10]; ``n = p`` is Hunt and Crossley's original law, 0 viscous
        damping (a force jump at first touch).
    """

    beta: float
    n: float = 1.5

    def __post_init__(self) -> None:
        for name in ("beta", "n"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) and not hasattr(value, "__float__"):
                raise SimulationInputError(f"law parameter {name!r} must be a number, got {type(value).__name__}")
            value = float(value)
            if not math.isfinite(value):
                raise SimulationInputError(f"law parameter {name!r} must be finite, got {value!r}")
            object.__setattr__(self, name, value)
        if self.beta < 0.0:
            raise SimulationInputError(f"law parameter 'beta' must be >= 0, got {self.beta!r} N s m^-(n+1)")
        if not 0.0 <= self.n <= N_MAX:
            raise SimulationInputError(f"law parameter 'n' (damping index) must lie in [0, {N_MAX:g}], got {self.n!r}")


# --------------------------------------------------------------------------------------------
# The preset
# --------------------------------------------------------------------------------------------

#: Steel striker on a polyamide-6 pad: a 1 kg impactor with the 16 mm diameter hemispherical tip of the
#: drop-weight test standard ASTM D7136 (radius 8 mm), steel (E = 210 GPa, nu = 0.3) on a thick pad of
#: polyamide 6 (PA6, dry: E = 2.8 GPa, nu = 0.39, typical datasheet values), so that
#: ``k = hertz_stiffness(8e-3, 210e9, 0.3, 2.8e9, 0.39)`` = 3.88e8 N m^-1.5; Hertz exponent 1.5; local
#: gravity 9.81 m/s^2. A 5 cm drop (0.99 m/s) then penetrates 0.37 mm for 1.21 ms with a peak of
#: 2.87 kN (290 g on the accelerometer): 62 samples per impact at 51.2 kHz.
STEEL_ON_PA6 = DropRig(mass=1.0, k=hertz_stiffness(8e-3, 210e9, 0.3, 2.8e9, 0.39), p=1.5, gravity=9.81)

#: Restitution slope [s/m] of the nominal law (:func:`nominal_law`).
NOMINAL_RESTITUTION_SLOPE = 0.3


def nominal_law(rig: DropRig) -> DropLaw:
    """The nominal damping of a rig's contact (for simulations and synthetic recordings when none is
    given): Hunt and Crossley's ``n = p`` with ``beta = 0.3 s/m * k`` (:func:`hunt_crossley_damping`),
    i.e. a coefficient of restitution of about 0.8 at 1 m/s, an assumed value for a stiff polymer
    (measure yours: that is what :func:`~impactid.rigs.drop.identify.fit_drop` is for)."""
    return DropLaw(beta=hunt_crossley_damping(rig.k, NOMINAL_RESTITUTION_SLOPE), n=rig.p)


#: Nominal damping of the PA6 pad of :data:`STEEL_ON_PA6` (:func:`nominal_law`): beta = 1.16e8 N s m^-2.5,
#: n = 1.5.
PA6_PAD_LAW = nominal_law(STEEL_ON_PA6)

#: The rig's presets, the default first (their names are global among the registered rigs).
PRESETS = {"STEEL_ON_PA6": STEEL_ON_PA6}

"""The tracked ball and its air model: a frozen :class:`TrackedBall` dataclass and the table-tennis preset.

The flight of a tracked ball is gravity, quadratic drag and the Magnus (lift) force of its spin, with
the buoyancy and the added mass of the air it displaces (docs/tracks.md, "The flight model"):

* drag ``F_D = -1/2 rho A C_D |v| v`` (``A = pi d^2 / 4``);
* lift ``F_L = 1/2 rho A C_L(S) |v|^2 (omega x v) / (|omega| |v|)`` with the spin parameter
  ``S = R |omega| / |v|`` and the lift coefficient of Sawicki, Hubbard & Stronge (2003), a bilinear
  fit to measured lift on spinning balls (:func:`lift_coefficient`): ``C_L = 1.5 S`` for
  ``S <= 0.1``, ``C_L = 0.09 + 0.6 S`` above; times ``lift_scale`` (1: the published fit; the
  analysis can estimate the scale from the tracks, :func:`~impactid.rigs.tracks.analysis.analyse_tracks`);
* buoyancy ``rho V g`` and added mass ``rho V / 2`` (``V = pi d^3 / 6``).

The preset :data:`TABLE_TENNIS_BALL` is the ITTF ball (2.7 g, 40 mm) with ``C_D = 0.45``, the middle
of :data:`DRAG_RANGE` 0.40-0.50: the subcritical drag of a smooth sphere (Achenbach 1972) at the
Reynolds numbers of a table-tennis ball in play (``Re = v d / nu``, 5e3-5e4 at 2-20 m/s). The
published lift fit was made for baseballs; whether it holds for a table-tennis ball is what the
estimated ``lift_scale`` tells. The analysis states what the drag coefficient's range and the lift
scale's range do to every restitution.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

import numpy as np

from impactid.errors import ImpactidError

__all__ = ["AIR_DENSITY", "DRAG_RANGE", "LIFT_MODEL", "MODEL_NAME", "SHELL_INERTIA", "STANDARD_GRAVITY",
           "TABLE_TENNIS_BALL", "TRACKED_BALLS", "TrackParameterError", "TrackedBall", "lift_coefficient",
           "lift_over_spin", "tracked_ball"]

#: The rig's model name (the registry's key).
MODEL_NAME = "tracked-ball"
#: Standard gravity [m/s^2].
STANDARD_GRAVITY = 9.80665
#: Density of air at 20 degC and 101.325 kPa [kg/m^3] (the brief's 1.2 to two digits).
AIR_DENSITY = 1.204
#: Moment of inertia of a thin spherical shell over ``m R^2`` [-] (a table-tennis ball).
SHELL_INERTIA = 2.0 / 3.0
#: The drag coefficients an uncertainty statement spans [-] (a smooth sphere below the drag crisis,
#: Achenbach 1972; Re 5e3-5e4).
DRAG_RANGE = (0.40, 0.50)
#: The lift model's name (the citation of :func:`lift_coefficient`).
LIFT_MODEL = "Sawicki, Hubbard & Stronge (2003): C_L = 1.5 S (S <= 0.1), 0.09 + 0.6 S (S > 0.1)"
#: Where the bilinear lift fit changes slope [-].
_LIFT_KNEE = 0.1


def lift_coefficient(spin_parameter):
    """The lift coefficient ``C_L(S)`` of Sawicki, Hubbard & Stronge (2003) [-]: ``1.5 S`` for
    ``S <= 0.1`` and ``0.09 + 0.6 S`` above (continuous at 0.1), ``S = R |omega| / |v|`` >= 0."""
    s = np.asarray(spin_parameter, dtype=float)
    return np.where(s <= _LIFT_KNEE, 1.5 * s, 0.09 + 0.6 * s)


def lift_over_spin(spin_parameter):
    """``C_L(S) / S`` [-], finite at ``S = 0`` (1.5): the lift force is ``1/2 rho A R (C_L / S) (omega x v)``."""
    s = np.asarray(spin_parameter, dtype=float)
    return np.where(s <= _LIFT_KNEE, 1.5, 0.6 + 0.09 / np.maximum(s, _LIFT_KNEE))


class TrackParameterError(ImpactidError, ValueError):
    """A ball or air parameter that is not finite or not physical (the message names it)."""


@dataclass(frozen=True)
class TrackedBall:
    """A ball in free flight with spin.

    Attributes
    ----------
    name : a label (``"table-tennis"``, ``"custom"``).
    mass : [kg], > 0.
    diameter : [m], > 0.
    drag_coefficient : ``C_D`` of the quadratic drag [-], >= 0 (0: no drag).
    lift_scale : the factor on the lift coefficient of :func:`lift_coefficient` [-], >= 0 (1: the
        published fit; 0: no Magnus force).
    air_density : [kg/m^3], >= 0 (0: vacuum: no drag, no Magnus force, no buoyancy).
    gravity : [m/s^2], > 0.
    inertia : moment of inertia over ``m R^2`` [-] (2/3 a thin shell, 2/5 a solid ball), in (0, 1].
    """

    name: str
    mass: float
    diameter: float
    drag_coefficient: float = 0.45
    lift_scale: float = 1.0
    air_density: float = AIR_DENSITY
    gravity: float = STANDARD_GRAVITY
    inertia: float = SHELL_INERTIA

    def __post_init__(self) -> None:
        for f in fields(self):
            if f.name == "name":
                continue
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise TrackParameterError(f"ball parameter {f.name!r} must be a number, got {type(value).__name__}")
            value = float(value)
            if not math.isfinite(value):
                raise TrackParameterError(f"ball parameter {f.name!r} is not finite ({value!r})")
            object.__setattr__(self, f.name, value)
        for name in ("mass", "diameter", "gravity", "inertia"):
            if getattr(self, name) <= 0.0:
                raise TrackParameterError(f"ball parameter {name!r} must be positive, got {getattr(self, name)!r}")
        for name in ("drag_coefficient", "lift_scale", "air_density"):
            if getattr(self, name) < 0.0:
                raise TrackParameterError(f"ball parameter {name!r} must be >= 0, got {getattr(self, name)!r}")
        if self.inertia > 1.0:
            raise TrackParameterError(f"ball parameter 'inertia' must lie in (0, 1], got {self.inertia!r}")
        if self.air_density * self.volume >= self.mass:
            raise TrackParameterError(f"ball {self.name!r} is lighter than the air it displaces: it would not fall")

    @property
    def radius(self) -> float:
        """[m]"""
        return 0.5 * self.diameter

    @property
    def area(self) -> float:
        """Frontal area ``pi d^2 / 4`` [m^2]."""
        return math.pi * self.diameter ** 2 / 4.0

    @property
    def volume(self) -> float:
        """``pi d^3 / 6`` [m^3]."""
        return math.pi * self.diameter ** 3 / 6.0

    @property
    def effective_mass(self) -> float:
        """The mass the forces accelerate: the ball's plus the added mass ``rho V / 2`` [kg]."""
        return self.mass + 0.5 * self.air_density * self.volume

    @property
    def net_gravity(self) -> float:
        """Downward acceleration of gravity less buoyancy, over the effective mass [m/s^2]."""
        return (self.mass - self.air_density * self.volume) * self.gravity / self.effective_mass

    @property
    def drag_rate(self) -> float:
        """``1/2 rho A C_D / m_eff`` [1/m]: the drag acceleration is ``-drag_rate |v| v``."""
        return 0.5 * self.air_density * self.area * self.drag_coefficient / self.effective_mass

    @property
    def lift_rate(self) -> float:
        """``1/2 rho A R / m_eff`` [-]: the lift acceleration is ``lift_rate lift_scale (C_L / S) (omega x v)``
        (:func:`lift_over_spin`)."""
        return 0.5 * self.air_density * self.area * self.radius / self.effective_mass

    def with_(self, **changes) -> TrackedBall:
        """A copy with some parameters changed (validated again)."""
        return replace(self, **changes)

    def to_dict(self) -> dict:
        """Plain dict of the parameters (SI units)."""
        return {f.name: getattr(self, f.name) for f in fields(self)}

    @classmethod
    def from_mapping(cls, data) -> TrackedBall:
        """A ball from a mapping of its fields (unknown names refused, naming them)."""
        names = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - names)
        if unknown:
            raise TrackParameterError(f"unknown ball parameter(s): {', '.join(unknown)}")
        return cls(**dict(data))


#: The ITTF ball (2.7 g, 40 mm, a thin shell) with the default air model.
TABLE_TENNIS_BALL = TrackedBall("table-tennis", mass=2.7e-3, diameter=40e-3)

#: Presets by name, the default first.
TRACKED_BALLS: dict[str, TrackedBall] = {"table-tennis-ball": TABLE_TENNIS_BALL}


def tracked_ball(name: str) -> TrackedBall:
    """The preset called ``name`` (``table-tennis``, ``pingpong`` and ``table-tennis-ball`` name the one preset).

    Raises
    ------
    ValueError
        naming the valid names.
    """
    key = str(name).strip().lower().replace("_", "-").replace(" ", "-")
    if key in ("table-tennis", "pingpong", "ping-pong", "table-tennis-ball"):
        return TABLE_TENNIS_BALL
    raise ValueError(f"unknown ball {name!r}; valid: table-tennis (pingpong)")

"""The ball of a bouncing-ball rig: a frozen :class:`Ball` dataclass and named presets.

A ball is described by what its free flight depends on: its mass [kg], its diameter [m], its drag
coefficient (quadratic air drag ``F = 0.5 rho Cd A v^2``), the air density [kg/m^3] and the
gravitational acceleration [m/s^2]. The presets are the balls of the common sports, with their
regulation mass and diameter and a typical drag coefficient *at bouncing speeds* (a few m/s, i.e.
Reynolds numbers of 10^3 to 10^4, well below the drag crisis):

* ``table-tennis`` (aliases ``pingpong``, ``ping-pong``): 2.7 g, 40 mm (ITTF regulation ball).
  ``Cd = 0.42``: the smooth-sphere drag correlation of Morrison (2013, *An Introduction to Fluid
  Mechanics*, Cambridge University Press, eq. 8.83) gives 0.46 at 0.5 m/s, 0.42 at 1 m/s and 0.40 at
  2.5 m/s for a 40 mm sphere in air (Re = 1.3e3 to 6.6e3).
* ``golf``: 45.9 g, 42.7 mm (R&A / USGA rules: at most 45.93 g, at least 42.67 mm). ``Cd = 0.42``:
  at bouncing speeds (Re < 10^4) the dimples do not yet trigger the drag crisis they are made for
  (it happens above Re ~ 5e4, Bearman & Harvey 1976, *Aeronautical Quarterly* 27, 112-122), so the
  ball behaves as a smooth sphere (same correlation as above).
* ``tennis``: 57.5 g, 67 mm (ITF rules: 56.0-59.4 g, 65.4-68.6 mm). ``Cd = 0.55``: the felt raises
  the drag above a smooth sphere's; wind-tunnel values of 0.55-0.6 for non-spinning new balls
  (Mehta & Pallis 2001, *Sports Engineering* 4, 177-189; Goodwill, Chin & Haake 2004, *J. Wind Eng.
  Ind. Aerodyn.* 92, 935-958), measured at higher Reynolds numbers than a bounce reaches.

All three drag coefficients are uncertain by about +-0.1 at bouncing speeds; the drag correction
of the restitution coefficient is proportional to ``Cd`` (see ``docs/bounces.md`` for its size).

The air around the ball also buoys it (``rho V g``) and must be accelerated with it (added mass
``rho V / 2`` for a sphere): for the table-tennis ball these are 1.5 % and 0.75 % of its mass.
:mod:`impactid.rigs.ball.flight` includes both whenever air is included (they change the speeds by
about 2 % and the interval ratios not at all).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

from impactid.errors import ImpactidError

__all__ = ["AIR_DENSITY", "BALL_PRESETS", "GOLF", "STANDARD_GRAVITY", "TABLE_TENNIS", "TENNIS", "Ball",
           "BallParameterError", "ball_preset"]

#: Standard gravity [m/s^2] (the default; give the local value for the last 0.1 %).
STANDARD_GRAVITY = 9.80665
#: Density of dry air at 20 degC and 101.325 kPa [kg/m^3].
AIR_DENSITY = 1.204


class BallParameterError(ImpactidError, ValueError):
    """A ball parameter that is missing, not finite or not physical (the message names it)."""


@dataclass(frozen=True)
class Ball:
    """A ball in free flight.

    Attributes
    ----------
    name : a label (``"table-tennis"``, ``"custom"``, ...).
    mass : [kg], > 0.
    diameter : [m], > 0.
    drag_coefficient : quadratic drag coefficient ``Cd`` [-], >= 0 (0: no drag).
    air_density : [kg/m^3], >= 0 (0: vacuum).
    gravity : gravitational acceleration [m/s^2], > 0.
    """

    name: str
    mass: float
    diameter: float
    drag_coefficient: float = 0.47
    air_density: float = AIR_DENSITY
    gravity: float = STANDARD_GRAVITY

    def __post_init__(self) -> None:
        for f in fields(self):
            if f.name == "name":
                continue
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) and not hasattr(value, "__float__"):
                raise BallParameterError(f"ball parameter {f.name!r} must be a number, got {type(value).__name__}")
            value = float(value)
            if not math.isfinite(value):
                raise BallParameterError(f"ball parameter {f.name!r} is not finite ({value!r})")
            object.__setattr__(self, f.name, value)
        for name in ("mass", "diameter", "gravity"):
            if getattr(self, name) <= 0.0:
                raise BallParameterError(f"ball parameter {name!r} must be positive, got {getattr(self, name)!r}")
        for name in ("drag_coefficient", "air_density"):
            if getattr(self, name) < 0.0:
                raise BallParameterError(f"ball parameter {name!r} must be >= 0, got {getattr(self, name)!r}")
        if self.displaced_air_mass >= self.mass:
            raise BallParameterError(f"ball {self.name!r} is lighter than the air it displaces "
                                     f"({self.mass:g} kg <= {self.displaced_air_mass:g} kg): it would not fall")

    # ---- derived quantities -------------------------------------------------------------------
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
    def displaced_air_mass(self) -> float:
        """Mass of the air the ball displaces [kg]."""
        return self.air_density * self.volume

    @property
    def drag_constant(self) -> float:
        """``k = 0.5 rho Cd A`` [kg/m]: the drag force is ``k v^2``."""
        return 0.5 * self.air_density * self.drag_coefficient * self.area

    @property
    def terminal_speed(self) -> float:
        """Terminal speed [m/s] with buoyancy: ``sqrt((m - rho V) g / k)`` (inf without drag)."""
        k = self.drag_constant
        return math.inf if k == 0.0 else math.sqrt((self.mass - self.displaced_air_mass) * self.gravity / k)

    def with_(self, **changes) -> Ball:
        """A copy with some parameters changed (validated again)."""
        return replace(self, **changes)

    def to_dict(self) -> dict:
        """Plain dict of the parameters (SI units)."""
        return {f.name: getattr(self, f.name) for f in fields(self)}


#: ITTF regulation ball; Cd from the smooth-sphere correlation at bouncing speeds (see module docs).
TABLE_TENNIS = Ball("table-tennis", mass=2.7e-3, diameter=40e-3, drag_coefficient=0.42)
#: R&A/USGA golf ball; Cd as a smooth sphere below the dimples' drag crisis.
GOLF = Ball("golf", mass=45.9e-3, diameter=42.7e-3, drag_coefficient=0.42)
#: ITF tennis ball; Cd from wind-tunnel values of non-spinning balls.
TENNIS = Ball("tennis", mass=57.5e-3, diameter=67e-3, drag_coefficient=0.55)

#: Presets by name, with the aliases a user may guess.
BALL_PRESETS: dict[str, Ball] = {"table-tennis": TABLE_TENNIS, "pingpong": TABLE_TENNIS, "ping-pong": TABLE_TENNIS,
                                 "tabletennis": TABLE_TENNIS, "golf": GOLF, "tennis": TENNIS}


def ball_preset(name: str) -> Ball:
    """The preset ball called ``name`` (case-insensitive; ``_`` and spaces read as ``-``).

    Raises
    ------
    ValueError
        listing the valid names when ``name`` is not one of them.
    """
    key = str(name).strip().lower().replace("_", "-").replace(" ", "-")
    if key not in BALL_PRESETS:
        raise ValueError(f"unknown ball {name!r}; valid: {', '.join(BALL_PRESETS)}")
    return BALL_PRESETS[key]

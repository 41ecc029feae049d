"""The body of a planar impact (``planar-impact``): its mass and radius of gyration.

A rigid body moving in the plane has the generalised velocity ``v = (v_x, v_y, omega)`` of its centre
of mass [m/s, m/s, rad/s] and the mass matrix ``M = m diag(1, 1, k_g^2)`` (mass ``m`` [kg], radius of
gyration ``k_g`` [m] about the centre of mass). That is all an algebraic impact law needs of the body:
the contact's geometry comes with each impact as the rows of its contact Jacobian
(:mod:`impactid.rigs.planar.table`). The preset :data:`MCUBE_ELLIPSE` is the ellipse of the planar
impact dataset of Fazeli, Donlon, Drumwright & Rodriguez (2017).

Light: importing this module loads the rig-parameter base (NumPy) only.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from impactid.errors import RigParameterError
from impactid.rigs._params import RigParameters

__all__ = ["MCUBE_ELLIPSE", "MODEL_NAME", "PRESETS", "UNITS", "PlanarBody"]

#: The rig's model name (docs/formats.md, ``[rig] model`` of a rig file).
MODEL_NAME = "planar-impact"

#: Units of the body's parameters.
UNITS = {"mass": "kg", "radius_of_gyration": "m"}


@dataclass(frozen=True)
class PlanarBody(RigParameters):
    """A rigid body in the plane.

    Attributes
    ----------
    mass : ``m`` [kg], > 0.
    radius_of_gyration : ``k_g`` [m], > 0: the moment of inertia about the centre of mass is ``m k_g^2``.
    """

    model: ClassVar[str] = MODEL_NAME

    mass: float
    radius_of_gyration: float

    def __post_init__(self) -> None:
        self._check_numbers()
        for name in ("mass", "radius_of_gyration"):
            if not getattr(self, name) > 0.0:
                raise RigParameterError(f"rig parameter {name!r} must be positive, got {getattr(self, name)!r} "
                                        f"[{UNITS[name]}]")

    @property
    def inertia(self) -> float:
        """Moment of inertia about the centre of mass ``m k_g^2`` [kg m^2]."""
        return self.mass * self.radius_of_gyration**2

    @property
    def inverse_mass(self) -> tuple[float, float, float]:
        """The diagonal of ``M^-1``: ``(1/m, 1/m, 1/(m k_g^2))`` [1/kg, 1/kg, 1/(kg m^2)]."""
        return (1.0 / self.mass, 1.0 / self.mass, 1.0 / self.inertia)

    @property
    def diagonal_mass(self) -> tuple[float, float, float]:
        """The diagonal of ``M``: ``(m, m, m k_g^2)`` [kg, kg, kg m^2]."""
        return (self.mass, self.mass, self.inertia)


#: The ellipse of the MIT MCube planar impact dataset (Fazeli, Donlon, Drumwright & Rodriguez 2017,
#: "Empirical evaluation of common contact models for planar impact", ICRA): 36.4 g, semi-axes 35 mm
#: and 25 mm, radius of gyration 19.2 mm (the dataset's documentation).
MCUBE_ELLIPSE = PlanarBody(mass=0.0364, radius_of_gyration=0.0192)

#: Named bodies, the default first.
PRESETS = {"mcube-ellipse": MCUBE_ELLIPSE}

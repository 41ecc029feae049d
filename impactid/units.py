"""Units at the edges: parse a unit string and give the factor to SI.

Unit strings are parsed **case-sensitively** by `pint <https://pint.readthedocs.io>`_ (``MN`` is a
meganewton, ``mN`` a millinewton), so that impactid does not keep its own table of spellings. A
unit is accepted for a quantity only when it has that quantity's dimension; angles must be angle
units (radian, degree, turn, ...), not just any dimensionless unit, so that ``counts`` is refused.

Two conventions of measurement practice that pint spells differently are added:

* on an acceleration channel, a bare ``g`` (which pint reads as gram) means the standard gravity
  ``g_n = 9.80665 m/s^2``, as accelerometer data sheets use it;
* ``rev`` is a revolution (a turn), and ``m/s2`` is ``m/s^2``.
"""

from __future__ import annotations

import functools
import math

from impactid.errors import ImpactidError

__all__ = ["UnitError", "si_factor"]

#: SI unit of each physical quantity impactid reads, in pint's spelling.
SI_UNITS = {"acceleration": "m/s^2", "force": "N", "angle": "rad", "length": "m", "velocity": "m/s",
            "time": "s", "angular velocity": "rad/s", "pressure": "Pa"}
_ANGLE_UNITS = {"radian", "milliradian", "microradian", "degree", "arcminute", "arcsecond", "turn",
                "revolution", "rev", "gradian"}
_GRAVITY_SPELLINGS = {"g", "g0", "g_0", "g_n", "gn"}


class UnitError(ImpactidError, ValueError):
    """A unit string that cannot be parsed, or that has the wrong dimension for its quantity.

    ``reason`` is the message without the unit string (for messages that name it already).
    """

    def __init__(self, unit: str, reason: str):
        super().__init__(f"unit {unit!r}: {reason}")
        self.reason = reason


@functools.lru_cache(maxsize=1)
def _registry():
    import pint

    registry = pint.UnitRegistry(autoconvert_offset_to_baseunit=True)
    registry.define("rev = turn")
    return registry


@functools.lru_cache(maxsize=256)
def si_factor(unit: str, quantity: str) -> float:
    """Factor that converts a value in ``unit`` to the SI unit of ``quantity``.

    Parameters
    ----------
    unit : the unit string as written in a file (``"m/s^2"``, ``"g"``, ``"kN"``, ``"deg"``, ...).
    quantity : a key of :data:`SI_UNITS` (``"acceleration"``, ``"force"``, ``"angle"``, ...).

    Raises
    ------
    UnitError
        when the string does not parse or has another dimension than ``quantity``.
    """
    if quantity not in SI_UNITS:
        raise ValueError(f"unknown quantity {quantity!r}; known: {', '.join(SI_UNITS)}")
    text = str(unit).strip()
    si = SI_UNITS[quantity]
    if quantity == "acceleration" and text in _GRAVITY_SPELLINGS:
        text = "standard_gravity"
    text = text.replace("s2", "s^2") if text.endswith("/s2") else text
    if text == "":
        raise UnitError(unit, f"empty (expected {si})")
    import pint

    registry = _registry()
    try:
        parsed = registry.Quantity(1.0, text)
    except (pint.errors.PintError, AttributeError, TypeError, ValueError, SyntaxError, KeyError) as exc:
        raise UnitError(unit, f"not a known unit (expected {si} or another unit of {quantity}; {exc})") from None
    if quantity == "angle":
        names = {name for name, _ in parsed.unit_items()}
        if not names or not names <= _ANGLE_UNITS:
            raise UnitError(unit, f"not an angle (expected {si}, deg, turn, ...)")
    try:
        factor = float(parsed.to(si).magnitude)
    except pint.errors.DimensionalityError:
        raise UnitError(unit, f"not a unit of {quantity} (expected {si})") from None
    if not (math.isfinite(factor) and factor > 0.0):
        raise UnitError(unit, f"gives a non-positive factor {factor!r}")
    return factor

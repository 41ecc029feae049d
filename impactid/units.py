"""Units at the edges: parse a unit string and give the factor to SI.

Unit strings are parsed **case-sensitively** by `pint <https://pint.readthedocs.io>`_ (``MN`` is a
meganewton, ``mN`` a millinewton), so that impactid does not keep its own table of spellings. A
unit is accepted for a quantity only when it has that quantity's dimension; angles must be angle
units (radian, degree, turn, ...), not just any dimensionless unit, so that ``counts`` is refused.

Two conventions of measurement practice that pint spells differently are added:

* on an acceleration channel, a bare ``g`` (which pint reads as gram) means the standard gravity
  ``g_n = 9.80665 m/s^2``, as accelerometer data sheets use it;
* ``rev`` is a revolution (a turn), and ``m/s2`` is ``m/s^2``.

pint evaluates a unit string as an arithmetic expression, and its parser raises whatever Python's
tokenizer and arithmetic raise on a malformed one (``AssertionError`` for ``m/s^``, ``TokenError``
for ``((``, ``ZeroDivisionError`` for ``m/s/0``, ...), or computes for ever (``2^2^2^2^30`` is an
integer with billions of digits). So a unit string is first held to the shape of a unit: at most
:data:`MAX_UNIT_LENGTH` characters, printable, and every exponent a plain number of magnitude at
most :data:`MAX_UNIT_EXPONENT` (not an expression, not a chain); then every exception the parser
raises becomes a :class:`UnitError`.
"""

from __future__ import annotations

import functools
import math
import re

from impactid.errors import ImpactidError

__all__ = ["MAX_UNIT_EXPONENT", "MAX_UNIT_LENGTH", "UnitError", "si_factor"]

#: SI unit of each physical quantity impactid reads, in pint's spelling.
SI_UNITS = {"acceleration": "m/s^2", "force": "N", "angle": "rad", "length": "m", "velocity": "m/s",
            "time": "s", "angular velocity": "rad/s", "pressure": "Pa"}
_ANGLE_UNITS = {"radian", "milliradian", "microradian", "degree", "arcminute", "arcsecond", "turn",
                "revolution", "rev", "gradian"}
_GRAVITY_SPELLINGS = {"g", "g0", "g_0", "g_n", "gn"}
#: Longest unit string parsed (``meter / second ** 2`` has 19 characters).
MAX_UNIT_LENGTH = 80
#: Largest magnitude of an exponent in a unit string (physical units use 1 to 4).
MAX_UNIT_EXPONENT = 12
#: An exponent as pint evaluates it (after its preprocessing turned ``^`` and superscripts into
#: ``**``): a plain number, perhaps signed and in parentheses, and not raised to a power again.
_EXPONENT = re.compile(r"\*\*\s*(\(\s*)?(?P<value>[-+]?\s*(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(?(1)\))")


class UnitError(ImpactidError, ValueError):
    """A unit string that cannot be parsed, or that has the wrong dimension for its quantity.

    ``reason`` is the message without the unit string (for messages that name it already).
    """

    def __init__(self, unit: str, reason: str):
        super().__init__(f"unit {shown(unit)}: {reason}")
        self.reason = reason


def shown(unit: object, limit: int = 2 * MAX_UNIT_LENGTH) -> str:
    """A unit string as a message shows it: its ``repr``, cut to ``limit`` characters with the length
    said (a 500,000-character attribute is not echoed whole)."""
    text = repr(unit)
    if len(text) <= limit:
        return text
    return f"{text[:limit]}... ({len(str(unit)):,} characters)"


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
    _check_shape(unit, text)
    import pint

    registry = _registry()
    # pint's parser evaluates the string with Python's tokenizer and arithmetic: a malformed string
    # raises whatever they raise (AssertionError, tokenize.TokenError, ZeroDivisionError,
    # OverflowError, RecursionError, ...), so every exception is a unit that does not parse
    try:
        parsed = registry.Quantity(1.0, text)
        names = {name for name, _ in parsed.unit_items()}
    except Exception as exc:  # noqa: BLE001 - see above
        raise UnitError(unit, f"not a known unit (expected {si} or another unit of {quantity}; "
                              f"{_reason(exc)})") from None
    if quantity == "angle" and (not names or not names <= _ANGLE_UNITS):
        raise UnitError(unit, f"not an angle (expected {si}, deg, turn, ...)")
    try:
        factor = float(parsed.to(si).magnitude)
    except pint.errors.DimensionalityError:
        raise UnitError(unit, f"not a unit of {quantity} (expected {si})") from None
    except Exception as exc:  # noqa: BLE001 - an overflow or an offset unit's arithmetic, as above
        raise UnitError(unit, f"cannot be converted to {si} ({_reason(exc)})") from None
    if not (math.isfinite(factor) and factor > 0.0):
        raise UnitError(unit, f"gives a non-positive or non-finite factor {factor!r}")
    return factor


def _reason(exc: BaseException) -> str:
    """One line about a parser exception: pint's own message, or what Python's tokenizer or
    arithmetic stumbled on."""
    import tokenize

    import pint

    if isinstance(exc, pint.errors.PintError):
        return " ".join(str(exc).split())
    if isinstance(exc, tokenize.TokenError):
        return "unbalanced parentheses or an unfinished expression"
    if isinstance(exc, ZeroDivisionError):
        return "a division by zero"
    if isinstance(exc, OverflowError):
        return "a number out of range"
    text = " ".join(str(exc).split())
    return f"a malformed expression ({type(exc).__name__}{': ' + text if text else ''})"


def _check_shape(unit: str, text: str) -> None:
    """Refuse a string that is not shaped like a unit before pint evaluates it (see the module notes)."""
    if len(text) > MAX_UNIT_LENGTH:
        raise UnitError(unit, f"{len(text)} characters, too long to be a unit (at most {MAX_UNIT_LENGTH})")
    if not text.isprintable():
        raise UnitError(unit, "holds control characters or undecodable bytes; not a unit")
    from pint.util import string_preprocessor

    try:
        evaluated = string_preprocessor(text)
    except Exception as exc:  # noqa: BLE001 - third-party text processing, as in si_factor
        raise UnitError(unit, f"not a known unit ({_reason(exc)})") from None
    position = 0
    while (start := evaluated.find("**", position)) >= 0:
        match = _EXPONENT.match(evaluated, start)
        if match is None:
            raise UnitError(unit, "an exponent (after ^ or **) must be a plain number, as in m/s^2 or s^-1")
        value = float(match.group("value").replace(" ", ""))
        if not abs(value) <= MAX_UNIT_EXPONENT:
            raise UnitError(unit, f"exponent {match.group('value')} is out of range (at most {MAX_UNIT_EXPONENT} "
                                  "in magnitude)")
        position = match.end()
        if evaluated[position:].lstrip().startswith("**"):
            raise UnitError(unit, "an exponent raised to a power again; not a unit")

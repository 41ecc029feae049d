"""Exception types of impactid.

Every error impactid raises on purpose derives from :class:`ImpactidError`, so a caller (or the
CLI) can tell a problem with the user's input or with a simulation apart from a programming
error. Input errors also derive from :class:`ValueError` so that generic code keeps working.
"""

from __future__ import annotations

__all__ = ["ImpactidError", "RigParameterError", "SimulationError", "SimulationInputError"]

class ImpactidError(Exception):
    """Base class of all errors raised deliberately by impactid."""


class RigParameterError(ImpactidError, ValueError):
    """A rig description is missing a parameter or has a non-finite or non-physical value.

    The message names the parameter (and the file, when the rig came from a file).
    """


class SimulationInputError(ImpactidError, ValueError):
    """A simulation was asked for with a non-physical input (NaN state, zero cam speed, ...)."""


class SimulationError(ImpactidError, RuntimeError):
    """The integrator failed (step-size underflow, too many steps, non-finite state, ...).

    Raised instead of returning a partial or garbage result.
    """

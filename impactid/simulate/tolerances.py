"""Integrator tolerances of the one-angle rigs' compiled kernels (rig P, rig F) on the DP5 core."""

from __future__ import annotations

import math
from dataclasses import dataclass

from impactid.errors import SimulationInputError

__all__ = ["DEFAULT_TOLERANCES", "Tolerances"]


@dataclass(frozen=True)
class Tolerances:
    """Integrator settings.

    Attributes
    ----------
    rtol : relative tolerance of the embedded error estimate [-].
    atol_alpha : absolute tolerance on the follower angle [rad].
    atol_rate : absolute tolerance on the follower rate [rad/s].
    max_step_revolutions : largest step as a fraction of a cam revolution; bounds the step in free
        flight so that a grazing contact cannot be stepped over.
    max_steps : step budget of one call (a run that needs more raises SimulationError).

    The defaults (rtol 1e-10) make alpha, contact times and peak forces agree with a
    ``solve_ivp`` DOP853 reference at rtol 1e-12 to better than 1e-8 relative, 1e-9 s and
    1e-6 relative (tests/rigs/pivoted/test_kernel_against_solve_ivp.py).
    """

    rtol: float = 1e-10
    atol_alpha: float = 1e-13
    atol_rate: float = 1e-11
    max_step_revolutions: float = 1.0 / 50.0
    max_steps: int = 50_000_000

    def __post_init__(self) -> None:
        for name in ("rtol", "atol_alpha", "atol_rate", "max_step_revolutions"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise SimulationInputError(f"tolerance {name} must be positive and finite, got {value!r}")
        if self.rtol < 1e-14:
            raise SimulationInputError(f"rtol {self.rtol!r} is below what double precision supports (1e-14)")


DEFAULT_TOLERANCES = Tolerances()

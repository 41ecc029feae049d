"""The simulation core shared by every rig: the Dormand-Prince 5(4) stepper with dense output and
event location (:mod:`impactid.simulate.dp5`, compiled with numba) and the integrator tolerances
(:class:`Tolerances`).

Each rig's kernel and runs live in its own folder (rig P's long runs and S1 events are
:mod:`impactid.rigs.pivoted.runs`).
"""

from impactid.simulate.tolerances import DEFAULT_TOLERANCES, Tolerances

__all__ = ["DEFAULT_TOLERANCES", "Tolerances"]

"""Forward simulation of rig P: the compiled hybrid integrator and the runs built on it."""

from impactid.simulate.runs import (
    DEFAULT_TOLERANCES,
    BatchResult,
    EventResult,
    SimulationResult,
    Tolerances,
    observables,
    simulate,
    simulate_event,
    simulate_events,
)

__all__ = [
    "DEFAULT_TOLERANCES", "BatchResult", "EventResult", "SimulationResult", "Tolerances",
    "observables", "simulate", "simulate_event", "simulate_events",
]

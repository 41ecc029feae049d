"""impactid: identify contact and impact models from measured time series of impact experiments."""

from impactid.contact import HuntCrossley, Restitution
from impactid.errors import ImpactidError, RigParameterError, SimulationError, SimulationInputError
from impactid.rigs import SUNDAR2016, PivotedFollowerRig, load_rig_toml, save_rig_toml
from impactid.simulate import Tolerances, simulate, simulate_event, simulate_events

__version__ = "0.1.0"

__all__ = [
    "HuntCrossley", "Restitution", "ImpactidError", "RigParameterError", "SimulationError",
    "SimulationInputError", "SUNDAR2016", "PivotedFollowerRig", "load_rig_toml", "save_rig_toml",
    "Tolerances", "simulate", "simulate_event", "simulate_events", "__version__",
]

"""impactid: identify contact and impact models from measured time series of impact experiments.

The public API, following the data::

    read_recording / Recording          recordings (HDF5, CSV + TOML rig files)
    find_events, reconstruct            impacts and their kinematics
    estimate, Pipeline                  contact damping (beta, n) and restitution, with intervals
    simulate, simulate_event(s)         the compiled forward simulator of rig P
    HuntCrossley, Restitution           contact and impact laws
    MODELS, rig_model, register         the rig registry (rig P, rig F, the bouncing ball, ...)
    Parameter, FitResult, Estimate      result types

Everything else lives in the submodules (``impactid.rigs.flat``, ``impactid.camprofile``,
``impactid.synth``, ...).
"""

__version__ = "0.1.0"

from impactid.contact import HuntCrossley, Restitution  # noqa: E402
from impactid.errors import ImpactidError, RigParameterError, SimulationError, SimulationInputError  # noqa: E402
from impactid.estimates import Estimate, estimate  # noqa: E402
from impactid.events import find_events  # noqa: E402
from impactid.io import Recording, read_recording  # noqa: E402
from impactid.pipeline import Pipeline  # noqa: E402
from impactid.reconstruct import reconstruct  # noqa: E402
from impactid.results import FitResult, Parameter  # noqa: E402
from impactid.rigs import (  # noqa: E402
    ALZATE2007,
    SUNDAR2016,
    FlatFollowerRig,
    PivotedFollowerRig,
    load_rig_toml,
    save_rig_toml,
)
from impactid.rigs.registry import MODELS, register, rig_model  # noqa: E402
from impactid.simulate import Tolerances, simulate, simulate_event, simulate_events  # noqa: E402

__all__ = [
    "ALZATE2007", "MODELS", "SUNDAR2016", "Estimate", "FitResult", "FlatFollowerRig", "HuntCrossley", "ImpactidError",
    "Parameter", "Pipeline", "PivotedFollowerRig", "Recording", "Restitution", "RigParameterError", "SimulationError",
    "SimulationInputError", "Tolerances", "__version__", "estimate", "find_events", "load_rig_toml", "read_recording",
    "reconstruct", "register", "rig_model", "save_rig_toml", "simulate", "simulate_event", "simulate_events",
]

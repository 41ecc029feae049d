"""Valve train II: cycloidal cam, flat-faced follower, spring surge and an EHL line contact
(Kushwaha, Rahnejat & Jin 2000).

* :mod:`.parameters` - :class:`CycloidalEHLRig` and the presets (:data:`KUSHWAHA2000`, ...);
* :mod:`.cam` - the cycloidal lift law and the flat follower's kinematics;
* :mod:`.contact` - Hertz line contact and the extrapolated EHL film with its validity flags;
* :mod:`.kernel` - compiled levels A and B on the DP5 core; :mod:`.simulate` - steady cycles,
  cycle analyses, jump speeds;
* :mod:`.synth` - synthetic recordings; :mod:`.identify` - surge, preload and mass fits;
* :mod:`.figures`, :mod:`.commands` - figures and the ``impactid valvetrain`` commands.

See ``docs/cycloidal_ehl.md``.
"""

from impactid.rigs.base import ChannelSpec, RigModel
from impactid.rigs.cycloidal import kernel
from impactid.rigs.cycloidal.contact import TABLE3_RANGES, ehl_film, film_scheme
from impactid.rigs.cycloidal.identify import SurgeFit, fit_surge
from impactid.rigs.cycloidal.parameters import (
    KUSHWAHA2000,
    KUSHWAHA2000_THICK_OIL,
    KUSHWAHA2000_ZEROS_EXACT,
    MODEL_NAME,
    PRESETS,
    CycloidalEHLRig,
)
from impactid.rigs.cycloidal.simulate import (
    CycleResult,
    JumpSpeedResult,
    Tolerances,
    cycle,
    jump_speed,
    level_b_steady_cycle,
    pack,
    sweep,
)
from impactid.rigs.cycloidal.synth import synth_recording

#: The channels this rig's recordings may hold (docs/formats.md "Additions").
CHANNELS = {
    "valve_displacement": ChannelSpec("valve_displacement", "length", "m",
                                      "valve (= retainer) lift, positive opening, 0 on the seat"),
    "cam_angle": ChannelSpec("cam_angle", "angle", "rad", "camshaft angle, unwrapped; the nose is at pi (mod 2 pi)",
                             required=True),
    "valve_velocity": ChannelSpec("valve_velocity", "velocity", "m/s", "valve velocity, positive opening (optional)"),
    "contact_load": ChannelSpec("contact_load", "force", "N", "cam/follower contact load, compressive positive "
                                "(synthetic recordings)"),
}


def _detachment_hz(rig: CycloidalEHLRig, level: str = "A", **options) -> float:
    """Cam speed [Hz] of the first jump (:func:`jump_speed`)."""
    return jump_speed(rig, level, **options).rpm / 60.0


def _simulate(rig: CycloidalEHLRig, rpm: float, level: str = "A", **options) -> CycleResult:
    return cycle(rig, rpm, level, **options)


#: The rig model record (registered in :mod:`impactid.rigs.registry`).
MODEL = RigModel(
    name=MODEL_NAME,
    title="cycloidal cam, flat-faced follower, two-mass spring surge, EHL line contact "
          "(Kushwaha, Rahnejat & Jin 2000)",
    citation="kushwaha2000",
    parameters=CycloidalEHLRig,
    presets=PRESETS,
    channels=CHANNELS,
    detachment=_detachment_hz,
    pack=pack,
    kernel=kernel,
    simulate=_simulate,
    measure=None,
    commands="impactid.rigs.cycloidal.commands",
)

__all__ = ["CHANNELS", "KUSHWAHA2000", "KUSHWAHA2000_THICK_OIL", "KUSHWAHA2000_ZEROS_EXACT", "MODEL", "MODEL_NAME",
           "PRESETS", "TABLE3_RANGES", "CycleResult", "CycloidalEHLRig", "JumpSpeedResult", "SurgeFit", "Tolerances",
           "cycle", "ehl_film", "film_scheme", "fit_surge", "jump_speed", "level_b_steady_cycle", "sweep",
           "synth_recording"]

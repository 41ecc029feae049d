"""Valve train II: cycloidal cam, flat-faced follower, spring surge and an EHL line contact
(Kushwaha, Rahnejat & Jin 2000).

* :mod:`.parameters` - :class:`CycloidalEHLRig` and the presets (:data:`KUSHWAHA2000`, ...);
* :mod:`.cam` - the cycloidal lift law and the flat follower's kinematics;
* :mod:`.contact` - Hertz line contact and the extrapolated EHL film with its validity flags;
* :mod:`.kernel` - compiled levels A and B on the DP5 core; :mod:`.simulate` - steady cycles,
  cycle analyses, jump speeds;
* :mod:`.synth` - synthetic recordings; :mod:`.identify` - surge, preload and mass fits;
* :mod:`.figures`, :mod:`.commands` - figures and the ``impactid valvetrain`` commands.

See ``docs/cycloidal_ehl.md``. Importing this package loads nothing of the rig: the names below are
imported from their modules on first use and :data:`MODEL` is built on first use, so that building
the command line (which reads :data:`COMMANDS`) loads neither numpy nor numba.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from impactid.rigs.base import ChannelSpec, RigModel, lazy_attributes

if TYPE_CHECKING:
    from impactid.rigs.cycloidal.parameters import CycloidalEHLRig
    from impactid.rigs.cycloidal.simulate import CycleResult

__all__ = ["CHANNELS", "KUSHWAHA2000", "KUSHWAHA2000_THICK_OIL", "KUSHWAHA2000_ZEROS_EXACT", "MODEL", "MODEL_NAME",
           "PRESETS", "TABLE3_RANGES", "CycleResult", "CycloidalEHLRig", "JumpSpeedResult", "SurgeFit", "Tolerances",
           "cycle", "ehl_film", "film_scheme", "fit_surge", "jump_speed", "level_b_steady_cycle", "sweep",
           "synth_recording"]

#: The rig's commands by import path (:data:`MODEL`'s field, read by the registry without building
#: :data:`MODEL`); impactid's generic estimate takes no valve-train recordings.
COMMANDS = "impactid.rigs.cycloidal.commands"
ESTIMATION = None
ESTIMATE_ARGUMENTS = None

#: The names of the rig's presets, the default first (``MODEL.presets``): ``--rig NAME`` finds its rig
#: without building the other rigs' models.
PRESET_NAMES = ("kushwaha2000", "kushwaha2000-zeros-exact", "kushwaha2000-thick-oil")

#: Where the public names live, imported on first use (numpy; the simulation, numba).
_LAZY = {
    **dict.fromkeys(("TABLE3_RANGES", "ehl_film", "film_scheme"), "impactid.rigs.cycloidal.contact"),
    **dict.fromkeys(("SurgeFit", "fit_surge"), "impactid.rigs.cycloidal.identify"),
    **dict.fromkeys(("KUSHWAHA2000", "KUSHWAHA2000_THICK_OIL", "KUSHWAHA2000_ZEROS_EXACT", "MODEL_NAME", "PRESETS",
                     "CycloidalEHLRig"), "impactid.rigs.cycloidal.parameters"),
    **dict.fromkeys(("CycleResult", "JumpSpeedResult", "Tolerances", "cycle", "jump_speed", "level_b_steady_cycle",
                     "pack", "sweep"), "impactid.rigs.cycloidal.simulate"),
    "synth_recording": "impactid.rigs.cycloidal.synth",
}

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
    from impactid.rigs.cycloidal.simulate import jump_speed

    return jump_speed(rig, level, **options).rpm / 60.0


def _simulate(rig: CycloidalEHLRig, rpm: float, level: str = "A", **options) -> CycleResult:
    from impactid.rigs.cycloidal.simulate import cycle

    return cycle(rig, rpm, level, **options)


def _model() -> RigModel:
    """The rig model record (registered in :mod:`impactid.rigs.registry`), built on first use of :data:`MODEL`
    (it loads the compiled kernels: numba)."""
    from impactid.rigs.cycloidal import kernel
    from impactid.rigs.cycloidal.parameters import MODEL_NAME, PRESETS, CycloidalEHLRig
    from impactid.rigs.cycloidal.simulate import pack

    return RigModel(
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
        commands=COMMANDS,
        warmup="impactid.rigs.cycloidal.simulate:warm_up",
    )


__getattr__ = lazy_attributes(__name__, _LAZY, {"MODEL": _model})


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))

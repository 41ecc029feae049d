"""Synthetic encoder recordings of rig F (Alzate et al. 2007) in permanent contact, for cam-profile fitting.

Below the detachment speed the follower rides on the cam, so its angle is the contact angle
``theta_hat(theta_c)`` of (A-17) exactly; no integration is needed. The two incremental encoders
count whole pulses: the cam encoder from an unknown zero (``cam_zero_offset``, drawn from the paper
unless given, recorded only in ``/truth``), the follower encoder from the follower's zero angle.
Impacting recordings of rig F need its impact simulator (cam-profile and bifurcation work).
"""

from __future__ import annotations

import math

import numpy as np

from impactid._version import __version__
from impactid.errors import SimulationInputError
from impactid.io import CHANNEL_UNITS, Recording
from impactid.rigs.flat import FlatFollowerRig
from impactid.synth.recording import SyntheticRecording
from impactid.synth.sensors import NO_SENSOR_ERRORS, SensorModel, apply_sensors, encoder_counts

__all__ = ["DEFAULT_CAM_PPR", "DEFAULT_FLAT_SAMPLE_RATE_HZ", "DEFAULT_FOLLOWER_PPR", "synth_flat_encoders"]

DEFAULT_FLAT_SAMPLE_RATE_HZ = 20_000.0
DEFAULT_CAM_PPR = 5000
DEFAULT_FOLLOWER_PPR = 10_000


def synth_flat_encoders(rig: FlatFollowerRig, cam_speed_hz: float, duration: float, *,
                        sample_rate_hz: float = DEFAULT_FLAT_SAMPLE_RATE_HZ, cam_ppr: int | None = DEFAULT_CAM_PPR,
                        follower_ppr: int | None = DEFAULT_FOLLOWER_PPR, cam_zero_offset: float | None = None,
                        sensors: SensorModel = NO_SENSOR_ERRORS, spin_up_s: float = 0.0) -> SyntheticRecording:
    """Permanent-contact encoder recording of rig F at constant cam speed (after an optional spin-up).

    Parameters
    ----------
    cam_speed_hz : cam speed [Hz]; must lie below the rig's detachment speed.
    duration : recorded time [s].
    cam_ppr, follower_ppr : encoder pulses per revolution (None: exact angles).
    cam_zero_offset : the cam encoder's zero relative to the model's ``theta_c = 0`` [rad]; the
        recorded ``cam_angle`` is ``theta_c - cam_zero_offset`` counted in pulses. Drawn uniformly
        in [0, 2 pi) from ``sensors.seed`` when None.
    sensors : further imperfections (Gaussian noise on the angle channels if set by name).
    spin_up_s : the cam starts at rest and its speed ramps linearly to ``cam_speed_hz`` over the first
        ``spin_up_s`` seconds of the recording [s] (0: constant speed throughout). The follower stays in
        contact (the speed never exceeds ``cam_speed_hz``; the angular acceleration does not affect the
        contact angle, only the contact torque).

    Raises
    ------
    SimulationInputError : the cam speed is at or above detachment (the follower would not stay
        in contact) or an argument is not positive.
    """
    for name, value in (("cam_speed_hz", cam_speed_hz), ("duration", duration), ("sample_rate_hz", sample_rate_hz)):
        if not (math.isfinite(value) and value > 0.0):
            raise SimulationInputError(f"{name} must be positive, got {value!r}")
    if not (math.isfinite(spin_up_s) and spin_up_s >= 0.0):
        raise SimulationInputError(f"spin_up_s must be >= 0, got {spin_up_s!r}")
    detach = rig.detachment_speed_hz()
    if cam_speed_hz >= detach:
        raise SimulationInputError(
            f"cam speed {cam_speed_hz * 60:.5g} rpm is at or above the detachment speed {detach * 60:.5g} rpm: "
            "the follower does not stay in permanent contact")
    rng = np.random.default_rng(sensors.seed)
    if cam_zero_offset is None:
        cam_zero_offset = float(rng.uniform(0.0, 2.0 * math.pi))
    n = int(round(duration * sample_rate_hz))
    t = np.arange(n) / sample_rate_hz
    theta_c = 2.0 * math.pi * cam_speed_hz * t
    if spin_up_s > 0.0:  # speed ramps 0 -> cam_speed_hz over spin_up_s, angle continuous after it
        ramp = t < spin_up_s
        theta_c = np.where(ramp, math.pi * cam_speed_hz * t * t / spin_up_s,
                           2.0 * math.pi * cam_speed_hz * (t - 0.5 * spin_up_s))
    theta_f = rig.contact_angle(theta_c)
    cam = theta_c - cam_zero_offset
    follower = theta_f.copy()
    if cam_ppr is not None:
        cam = encoder_counts(cam, int(cam_ppr))
    if follower_ppr is not None:
        follower = encoder_counts(follower, int(follower_ppr))
    measured, applied = apply_sensors({"cam_angle": cam, "follower_angle": follower}, sample_rate_hz, sensors, rng)
    recording = Recording(
        channels=measured, sample_rate_hz=sample_rate_hz, units={k: CHANNEL_UNITS[k] for k in measured},
        rig=rig, operating={"cam_speed_hz": float(cam_speed_hz), "eccentricity_m": rig.e},
        provenance=(f"impactid.rigs.flat.synth.synth_flat_encoders: permanent contact at {cam_speed_hz * 60:.6g} rpm"
                    + (f" after a {spin_up_s:g} s spin-up" if spin_up_s > 0.0 else ""),))
    truth = {
        "generator": "impactid.rigs.flat.synth.synth_flat_encoders",
        "impactid_version": __version__,
        "model": "rig F permanent contact (A-17)",
        "cam_speed_hz": float(cam_speed_hz),
        "spin_up_s": float(spin_up_s),
        "cam_zero_offset": float(cam_zero_offset),
        "cam_ppr": int(cam_ppr) if cam_ppr is not None else 0,
        "follower_ppr": int(follower_ppr) if follower_ppr is not None else 0,
        "detachment_speed_hz": float(detach),
        "sample_rate_hz": float(sample_rate_hz),
        "applied": applied,
        "theta_c": theta_c,
        "theta_f": theta_f,
    }
    return SyntheticRecording(recording=recording, truth=truth)

"""Synthetic encoder recordings of rig F above detachment: impacting motion with a restitution law.

The rig F simulator (:func:`impactid.rigs.flat.simulate.simulate_flat`) runs from permanent contact at
``theta_c = 0``; the first ``settle_revolutions`` cam revolutions are discarded and the exact dense
output is sampled at ``t_k = settle + k / sample_rate_hz`` (the recording keeps the simulation
clock, so the impact times in ``/truth`` are on the recording's time axis). The encoders count whole
pulses as in :func:`impactid.rigs.flat.synth.synth_flat_encoders`, the cam encoder from an unknown zero.
"""

from __future__ import annotations

import math

import numpy as np

from impactid._version import __version__
from impactid.errors import SimulationInputError
from impactid.io import CHANNEL_UNITS, Recording
from impactid.rigs.flat import FlatFollowerRig
from impactid.rigs.flat.simulate import DEFAULT_RESTITUTION, SpeedRestitution, simulate_flat
from impactid.rigs.flat.synth import DEFAULT_CAM_PPR, DEFAULT_FLAT_SAMPLE_RATE_HZ, DEFAULT_FOLLOWER_PPR
from impactid.synth.recording import SyntheticRecording
from impactid.synth.sensors import NO_SENSOR_ERRORS, SensorModel, apply_sensors, encoder_counts

__all__ = ["DEFAULT_SETTLE_REVOLUTIONS", "synth_flat_impacting"]

#: Revolutions simulated and discarded before recording (transients of rig F's period-1 impacting
#: motion decay within a few revolutions: each impact removes 1 - r^2 of the relative energy).
DEFAULT_SETTLE_REVOLUTIONS = 30


def synth_flat_impacting(rig: FlatFollowerRig, cam_speed_hz: float, duration: float, *,
                         restitution: float | SpeedRestitution = DEFAULT_RESTITUTION,
                         settle_revolutions: int = DEFAULT_SETTLE_REVOLUTIONS,
                         sample_rate_hz: float = DEFAULT_FLAT_SAMPLE_RATE_HZ, cam_ppr: int | None = DEFAULT_CAM_PPR,
                         follower_ppr: int | None = DEFAULT_FOLLOWER_PPR, cam_zero_offset: float | None = None,
                         sensors: SensorModel = NO_SENSOR_ERRORS) -> SyntheticRecording:
    """Encoder recording of rig F at a constant cam speed (any regime, typically impacting).

    Parameters
    ----------
    cam_speed_hz : cam speed [Hz].
    duration : recorded time [s] (after the settling revolutions).
    restitution : coefficient of restitution or a law linear in cam speed.
    cam_ppr, follower_ppr : encoder pulses per revolution (None: exact angles).
    cam_zero_offset : cam encoder zero relative to the model's ``theta_c = 0`` [rad]; drawn from
        ``sensors.seed`` when None.
    """
    for name, value in (("cam_speed_hz", cam_speed_hz), ("duration", duration), ("sample_rate_hz", sample_rate_hz)):
        if not (math.isfinite(value) and value > 0.0):
            raise SimulationInputError(f"{name} must be positive, got {value!r}")
    rng = np.random.default_rng(sensors.seed)
    if cam_zero_offset is None:
        cam_zero_offset = float(rng.uniform(0.0, 2.0 * math.pi))
    settle = settle_revolutions / cam_speed_hz
    n = int(round(duration * sample_rate_hz))
    t = settle + np.arange(n) / sample_rate_hz
    run = simulate_flat(rig, cam_speed_hz, float(t[-1]), restitution=restitution, times=t)
    theta_c = run.cam_angle
    cam = theta_c - cam_zero_offset
    follower = run.theta_f.copy()
    if cam_ppr is not None:
        cam = encoder_counts(cam, int(cam_ppr))
    if follower_ppr is not None:
        follower = encoder_counts(follower, int(follower_ppr))
    measured, applied = apply_sensors({"cam_angle": cam, "follower_angle": follower}, sample_rate_hz, sensors, rng)
    law = restitution if isinstance(restitution, SpeedRestitution) else SpeedRestitution(a=float(restitution))
    recording = Recording(
        channels=measured, sample_rate_hz=sample_rate_hz, units={k: CHANNEL_UNITS[k] for k in measured},
        rig=rig, operating={"cam_speed_hz": float(cam_speed_hz), "eccentricity_m": rig.e}, start_time_s=settle,
        provenance=(f"impactid.rigs.flat.synth_impacts.synth_flat_impacting: {cam_speed_hz * 60:.6g} rpm, "
                    f"r = {run.restitution:.6g}",))
    events = run.events[run.events["t"] >= settle]
    truth = {
        "generator": "impactid.rigs.flat.synth_impacts.synth_flat_impacting",
        "impactid_version": __version__,
        "model": "rig F impacting, restitution law (A-10..A-17)",
        "cam_speed_hz": float(cam_speed_hz),
        "restitution": float(run.restitution),
        "restitution_a": law.a,
        "restitution_b_per_rad_s": law.b,
        "cam_zero_offset": float(cam_zero_offset),
        "cam_ppr": int(cam_ppr) if cam_ppr is not None else 0,
        "follower_ppr": int(follower_ppr) if follower_ppr is not None else 0,
        "sample_rate_hz": float(sample_rate_hz),
        "applied": applied,
        "theta_c": theta_c,
        "theta_f": run.theta_f,
        "impact_times": events.loc[events["kind"] == "impact", "t"].to_numpy(),
        "impact_rate_before": events.loc[events["kind"] == "impact", "rate_before"].to_numpy(),
        "impact_rate_after": events.loc[events["kind"] == "impact", "rate_after"].to_numpy(),
    }
    return SyntheticRecording(recording=recording, truth=truth)

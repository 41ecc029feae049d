"""Synthetic recordings of the single-impact test rig: drops from known heights with a known contact.

A recording is one drop: the impactor is released at time 0 from ``height`` above the contact
surface (with ``release_speed`` towards it), and the acquisition records from ``pre_trigger`` seconds
before the first impact (as a drop tower's light gate triggers it) for ``duration`` seconds, through
the bounces, at ``sample_rate_hz``. Channels (SI; declared by the rig, see ``docs/drop.md``):

* ``impactor_acceleration`` [m/s^2]: the accelerometer on the impactor, the specific force ``F/m``
  along the line of impact away from the contact (0 in flight, ``g`` at rest on the contact);
* ``contact_force`` [N]: a load cell under the contact, the contact force ``F``.

The exact signals (the simulator's continuous extension at the sample instants, or, with
``decimation`` > 1, a finer grid filtered and decimated) go through the generic sensor chain
(:func:`impactid.synth.sensors.apply_sensors`: Gaussian noise as a fraction of each channel's
peak, ADC quantisation and saturation); an accelerometer offset and drift are added to the
acceleration channel first. The recording carries the rig in ``/rig`` and the drop in its
operating point (``drop_height_m``, ``release_speed_m_s``); what generated it (the law, the exact
histories, the impact table, the sensor settings) goes to ``/truth``, which no estimator reads.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from impactid._version import __version__
from impactid.errors import SimulationInputError
from impactid.rigs.drop.parameters import ACCELERATION_CHANNEL, FORCE_CHANNEL, DropLaw, DropRig
from impactid.rigs.drop.simulate import DEFAULT_TOLERANCES, Tolerances, simulate_drop
from impactid.synth.recording import SyntheticRecording
from impactid.synth.sensors import NO_SENSOR_ERRORS, SensorModel, antialias_decimate, apply_sensors

__all__ = ["CHANNELS", "DEFAULT_DURATION_S", "DEFAULT_PRE_TRIGGER_S", "DEFAULT_SAMPLE_RATE_HZ", "SyntheticRecording",
           "synth_drop_impact", "synth_drop_series"]

#: The channels a synthetic recording can hold, and their SI units.
CHANNELS = {ACCELERATION_CHANNEL: "m/s^2", FORCE_CHANNEL: "N"}
#: Sample rate [Hz]: 51.2 kHz, a common rate of dynamic signal analysers (about 60 samples over a
#: 1.2 ms impact of the preset).
DEFAULT_SAMPLE_RATE_HZ = 51_200.0
#: Recorded time [s] after the start.
DEFAULT_DURATION_S = 0.5
#: Recorded time before the first impact [s].
DEFAULT_PRE_TRIGGER_S = 0.01
#: Output samples simulated beyond each end when decimating (the FIR filter's edge zone).
_DECIMATION_MARGIN = 64


def _positive(name: str, value, *, allow_zero: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        raise SimulationInputError(f"{name} must be a number, got {value!r}")
    value = float(value)
    if not math.isfinite(value) or value < 0.0 or (value == 0.0 and not allow_zero):
        raise SimulationInputError(f"{name} must be {'>= 0' if allow_zero else 'positive'} and finite, got {value!r}")
    return value


def synth_drop_impact(rig: DropRig, law: DropLaw, height: float, *, release_speed: float = 0.0,
                      duration: float = DEFAULT_DURATION_S, pre_trigger: float = DEFAULT_PRE_TRIGGER_S,
                      sample_rate_hz: float = DEFAULT_SAMPLE_RATE_HZ, sensors: SensorModel = NO_SENSOR_ERRORS,
                      channels: Sequence[str] = tuple(CHANNELS),
                      tol: Tolerances = DEFAULT_TOLERANCES) -> SyntheticRecording:
    """A synthetic recording of one drop.

    Parameters
    ----------
    rig, law : the rig and the contact's damping (the truth).
    height : fall of the contact point to the contact surface [m] (> 0, or 0 with a release speed).
    release_speed : speed at release towards the contact [m/s].
    duration : recorded time [s].
    pre_trigger : recorded time before the first impact [s] (the recording starts at the release
        if the fall is shorter).
    sample_rate_hz : sample rate [Hz].
    sensors : the acquisition chain's imperfections (none by default).
    channels : which of :data:`CHANNELS` to record.
    tol : integration settings of the simulation.

    Returns
    -------
    :class:`SyntheticRecording`
    """
    from impactid.io import Recording

    unknown = sorted(set(channels) - set(CHANNELS))
    if unknown or not channels:
        raise SimulationInputError(f"channels: unknown or none {unknown or list(channels)}; the drop rig records "
                                   f"{', '.join(CHANNELS)}")
    height = _positive("height", height, allow_zero=True)
    release_speed = _positive("release_speed", release_speed, allow_zero=True)
    duration = _positive("duration", duration)
    pre_trigger = _positive("pre_trigger", pre_trigger, allow_zero=True)
    sample_rate_hz = _positive("sample_rate_hz", sample_rate_hz)
    speed = rig.impact_speed(height, release_speed)
    if speed <= 0.0:
        raise SimulationInputError("height and release_speed are both 0: nothing impacts")
    if rig.gravity > 0.0:
        fall_time = (speed - release_speed) / rig.gravity
    else:
        fall_time = height / release_speed
    q = int(sensors.decimation)
    n = int(round(duration * sample_rate_hz))
    if n < 16:
        raise SimulationInputError(f"duration {duration!r} s at {sample_rate_hz!r} Hz gives {n} samples (need 16)")
    start = max(math.floor((fall_time - pre_trigger) * sample_rate_hz), 0) / sample_rate_hz
    margin = _DECIMATION_MARGIN if q > 1 else 0
    fine_rate = q * sample_rate_hz
    j = np.arange(-margin * q, (n + margin) * q)
    t_fine = start + j / fine_rate
    t_fine = t_fine[t_fine >= 0.0]
    lead = int(np.count_nonzero(t_fine < start - 0.5 / fine_rate))  # fine samples before the first output
    run = simulate_drop(rig, law, height, release_speed=release_speed, duration=float(t_fine[-1]), t_eval=t_fine,
                        tol=tol)
    exact_fine = {ACCELERATION_CHANNEL: run.acceleration, FORCE_CHANNEL: run.force}
    sample_index = slice(lead, lead + n * q, q)
    clean: dict[str, np.ndarray] = {}
    for name in channels:
        x = exact_fine[name]
        if q == 1:
            clean[name] = x[sample_index].copy()
        else:
            y = antialias_decimate(x[lead % q:], q)
            first = lead // q
            clean[name] = y[first:first + n]
    t_samples = start + np.arange(n) / sample_rate_hz
    # the accelerometer's offset and drift (the generic chain applies them to rig P's channel only),
    # then noise and ADC through the generic chain
    offsets: dict[str, dict[str, float]] = {}
    shifted = dict(clean)
    if ACCELERATION_CHANNEL in shifted and (sensors.accel_offset or sensors.accel_drift):
        shifted[ACCELERATION_CHANNEL] = (shifted[ACCELERATION_CHANNEL] + sensors.accel_offset
                                         + sensors.accel_drift * (t_samples - t_samples[0]))
        offsets[ACCELERATION_CHANNEL] = {"offset": sensors.accel_offset, "drift_per_s": sensors.accel_drift}
    rng = np.random.default_rng(sensors.seed)
    measured, applied = apply_sensors(shifted, sample_rate_hz, replace(sensors, accel_offset=0.0, accel_drift=0.0),
                                      rng)
    for name, info in offsets.items():
        applied[name] = {**info, **applied[name]}
    measured = {name: measured[name] for name in channels}
    recording = Recording(
        channels=measured, sample_rate_hz=sample_rate_hz, units={k: CHANNELS[k] for k in measured}, rig=rig,
        operating={"drop_height_m": height, "release_speed_m_s": release_speed}, start_time_s=start,
        provenance=(f"impactid.rigs.drop.synth.synth_drop_impact: drop from {height:g} m at {release_speed:g} m/s, "
                    f"beta = {law.beta:.6g}, n = {law.n:.6g}",))
    table = run.impacts
    in_window = (table["onset_time_s"] >= t_samples[0]) & (table["onset_time_s"] < t_samples[0] + duration)
    window = table[in_window]
    truth: dict[str, Any] = {
        "generator": "impactid.rigs.drop.synth.synth_drop_impact",
        "impactid_version": __version__,
        "model": "drop-impact",
        "mass": rig.mass, "k": rig.k, "p": rig.p, "gravity": rig.gravity,
        "beta": law.beta, "n": law.n,
        "height": height, "release_speed": release_speed, "impact_speed": speed,
        "sample_rate_hz": sample_rate_hz, "tolerance_rtol": tol.rtol,
        "sensors": {k: v for k, v in sensors.to_dict().items() if v is not None and v != {}},
        "applied": applied,
        "t": t_samples,
        "x": run.x[sample_index].copy(), "v": run.v[sample_index].copy(),
        "force": run.force[sample_index].copy(), "acceleration": run.acceleration[sample_index].copy(),
        "impacts": {col: window[col].to_numpy(dtype=float) for col in window.columns if col not in ("kind", "end")},
        "impact_ends": ",".join(window["end"].tolist()),
        "t_rest": run.t_rest,
    }
    return SyntheticRecording(recording=recording, exact={k: clean[k] for k in channels}, truth=_plain(truth))


def synth_drop_series(rig: DropRig, law: DropLaw, heights: Sequence[float], *, seed: int = 0,
                      sensors: SensorModel = NO_SENSOR_ERRORS, **options) -> list[SyntheticRecording]:
    """Drops from several heights (one recording each), the sensor noise of drop ``i`` drawn with
    seed ``seed + i``; ``options`` as :func:`synth_drop_impact`."""
    if not len(heights):
        raise SimulationInputError("heights: give at least one drop height")
    return [synth_drop_impact(rig, law, h, sensors=replace(sensors, seed=int(seed) + i), **options)
            for i, h in enumerate(heights)]


def _plain(value: Any) -> Any:
    """Mappings to dicts and numpy scalars to Python scalars (HDF5-ready)."""
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, np.generic):
        return value.item()
    return value

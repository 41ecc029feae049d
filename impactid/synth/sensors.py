"""Sensor models applied to exact simulated signals: anti-alias decimation, accelerometer offset and
drift, additive Gaussian noise, ADC quantisation with saturation, encoder quantisation.

All pure functions on arrays (sample spacing explicit where it matters); :class:`SensorModel`
collects the settings and :func:`apply_sensors` applies them in the order a real acquisition
chain does: analogue signal -> (anti-alias filter + decimation) -> accelerometer offset/drift ->
noise -> ADC (quantisation, saturation). Every random draw comes from one seeded generator.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from impactid.errors import SimulationInputError

__all__ = ["ANGLE_CHANNELS", "NO_SENSOR_ERRORS", "SensorModel", "add_noise", "antialias_decimate", "apply_sensors",
           "encoder_counts", "quantise"]

#: Channels that are encoder angles: quantised in counts, no analogue noise by default.
ANGLE_CHANNELS = ("cam_angle", "follower_angle")


@dataclass(frozen=True)
class SensorModel:
    """Imperfections of the acquisition chain (all off by default).

    Attributes
    ----------
    noise : additive Gaussian noise, standard deviation as a fraction of the channel's peak
        absolute value. A float applies to every analogue channel (accelerometer and forces; the
        encoder angles are quantised instead); a mapping sets channels by name.
    adc_bits : ADC resolution in bits for the analogue channels (None: no quantisation).
    adc_range : ADC full scale (+-range) per channel in SI units; by default 1.25 times the
        channel's peak, so nothing saturates. A smaller range clips the signal, as a saturated
        accelerometer does.
    accel_offset : constant accelerometer offset [m/s^2].
    accel_drift : slow linear accelerometer drift [m/s^2 per s] from the first sample.
    decimation : simulate at ``decimation`` times the output rate, low-pass (linear-phase FIR,
        delay compensated, as in a delta-sigma ADC) and keep every ``decimation``-th sample.
        1 samples the exact signals directly.
    cam_encoder_ppr, follower_encoder_ppr : encoder counts per revolution for the angle channels
        (None: exact angles).
    seed : seed of the random generator.
    """

    noise: float | Mapping[str, float] = 0.0
    adc_bits: int | None = None
    adc_range: Mapping[str, float] = field(default_factory=dict)
    accel_offset: float = 0.0
    accel_drift: float = 0.0
    decimation: int = 1
    cam_encoder_ppr: int | None = None
    follower_encoder_ppr: int | None = None
    seed: int = 0

    def __post_init__(self) -> None:
        levels = self.noise.values() if isinstance(self.noise, Mapping) else [self.noise]
        for level in levels:
            if not (math.isfinite(level) and level >= 0.0):
                raise SimulationInputError(f"noise fractions must be finite and >= 0, got {level!r}")
        if self.adc_bits is not None and not 2 <= int(self.adc_bits) <= 32:
            raise SimulationInputError(f"adc_bits must lie in [2, 32], got {self.adc_bits!r}")
        for name, value in self.adc_range.items():
            if not (math.isfinite(value) and value > 0.0):
                raise SimulationInputError(f"adc_range of {name!r} must be positive, got {value!r}")
        if int(self.decimation) != self.decimation or self.decimation < 1:
            raise SimulationInputError(f"decimation must be a positive integer, got {self.decimation!r}")
        for name in ("cam_encoder_ppr", "follower_encoder_ppr"):
            value = getattr(self, name)
            if value is not None and (int(value) != value or value < 1):
                raise SimulationInputError(f"{name} must be a positive integer, got {value!r}")
        for name in ("accel_offset", "accel_drift"):
            if not math.isfinite(getattr(self, name)):
                raise SimulationInputError(f"{name} must be finite")

    def noise_fraction(self, channel: str) -> float:
        """Noise standard deviation of ``channel`` as a fraction of its peak."""
        if isinstance(self.noise, Mapping):
            return float(self.noise.get(channel, 0.0))
        return 0.0 if channel in ANGLE_CHANNELS else float(self.noise)

    def to_dict(self) -> dict[str, Any]:
        """Settings as plain data (for the ``/truth`` group)."""
        out = asdict(self)
        out["noise"] = dict(self.noise) if isinstance(self.noise, Mapping) else self.noise
        out["adc_range"] = dict(self.adc_range)
        return out


def antialias_decimate(x: np.ndarray, factor: int) -> np.ndarray:
    """Low-pass and keep every ``factor``-th sample; output sample k is at input sample ``k * factor``.

    A linear-phase Kaiser-window FIR (``scipy.signal.resample_poly``) with its delay compensated;
    the caller supplies margins at both ends, where the filter sees zero padding.
    """
    if factor == 1:
        return x.copy()
    # scipy.signal imports scipy.stats (0.3-0.6 s together): loaded where a recording is decimated, not by every
    # estimate that imports the sensor models (the contact-duration check, the calibration)
    from scipy import signal

    return signal.resample_poly(x, 1, factor)


def add_noise(x: np.ndarray, fraction: float, rng: np.random.Generator) -> tuple[np.ndarray, float]:
    """Add white Gaussian noise of standard deviation ``fraction * max|x|``; returns (signal, sigma)."""
    sigma = fraction * float(np.max(np.abs(x))) if x.size else 0.0
    if sigma == 0.0:
        return x, 0.0
    return x + rng.normal(0.0, sigma, size=x.shape), sigma


def quantise(x: np.ndarray, bits: int, full_scale: float) -> tuple[np.ndarray, float]:
    """Mid-tread ADC of ``bits`` bits over ``[-full_scale, full_scale)``: round to the nearest code,
    saturating at the end codes. Returns (signal, lsb)."""
    lsb = 2.0 * full_scale / 2.0**bits
    codes = np.clip(np.round(x / lsb), -(2.0 ** (bits - 1)), 2.0 ** (bits - 1) - 1.0)
    return codes * lsb, lsb


def encoder_counts(angle: np.ndarray, ppr: int, zero: float = 0.0) -> np.ndarray:
    """Incremental-encoder reading of ``angle`` [rad]: whole counts of ``2 pi / ppr`` since ``zero``
    (floor, as a counter does), returned in radians."""
    step = 2.0 * math.pi / ppr
    return np.floor((angle - zero) / step) * step


def apply_sensors(clean: Mapping[str, np.ndarray], sample_rate_hz: float, model: SensorModel,
                  rng: np.random.Generator | None = None) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Apply offset/drift, noise and ADC quantisation to decimated clean channels.

    Returns the measured channels and a dict of what was applied per channel (noise sigma, ADC
    lsb and full scale, number of saturated samples) for the ``/truth`` group. Decimation and
    encoders are applied by the caller (they need the fine grid and the angle zero).
    """
    rng = np.random.default_rng(model.seed) if rng is None else rng
    out: dict[str, np.ndarray] = {}
    applied: dict[str, Any] = {}
    for name in sorted(clean):  # sorted: the random stream does not depend on dict order
        x = np.array(clean[name], dtype=float)
        info: dict[str, Any] = {}
        if name == "accel_tangential" and (model.accel_offset or model.accel_drift):
            t = np.arange(x.size) / sample_rate_hz
            x = x + model.accel_offset + model.accel_drift * t
            info["offset"] = model.accel_offset
            info["drift_per_s"] = model.accel_drift
        peak = float(np.max(np.abs(clean[name])))
        x, sigma = add_noise(x, model.noise_fraction(name), rng)
        info["noise_sigma"] = sigma
        if model.adc_bits is not None and name not in ANGLE_CHANNELS:
            full_scale = float(model.adc_range.get(name, 1.25 * peak if peak > 0 else 1.0))
            saturated = int(np.count_nonzero((x >= full_scale) | (x < -full_scale)))
            x, lsb = quantise(x, int(model.adc_bits), full_scale)
            info.update(adc_bits=int(model.adc_bits), adc_full_scale=full_scale, adc_lsb=lsb,
                        saturated_samples=saturated)
        out[name] = x
        applied[name] = info
    return out, applied


#: The ideal acquisition: exact signals at the sample instants.
NO_SENSOR_ERRORS = SensorModel()

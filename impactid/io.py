"""Recordings: the :class:`Recording` container and its readers and writers (docs/formats.md).

Readers are ``read_<format>(path) -> Recording``; :func:`read_recording` picks one by file type.
Every problem with a file raises :class:`RecordingError` (an :class:`~impactid.errors.ImpactidError`)
naming the file, the channel and the problem; suspicious but usable recordings give a
:class:`RecordingWarning`. Reading never loads the synthetic ``/truth`` group: that is what
:func:`read_truth` is for, and nothing in the estimation path calls it.

Units are converted at this edge: a channel stored in a known non-SI unit (``g``, ``mm/s^2``,
``kN``, ``deg``, ...) is converted to SI on reading, and the conversion is recorded in the
recording's provenance. An unknown unit for a known channel is an error.
"""

from __future__ import annotations

import json
import math
import mmap
import os
import re
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np

from impactid._files import StagedFiles, atomic_write
from impactid._scan import channel_scan, count_equal, extreme_stats
from impactid.errors import ImpactidError, RigParameterError
from impactid.rigs import load_rig_toml, rig_from_mapping
from impactid.rigs.registry import is_rig_parameters
from impactid.units import UnitError, si_factor
from impactid.units import shown as shown_unit

__all__ = ["CAM_SPEED_TOLERANCE", "CHANNEL_QUANTITY", "CHANNEL_UNITS", "CLIP_RUN", "CSV_TIME_TOLERANCE", "FORMAT_NAME",
           "FORMAT_VERSION", "MAP_BYTES", "MAX_CAM_SPEED_HZ", "MAX_SAMPLE_RATE_HZ", "MEMORY_FACTORS",
           "MEMORY_LIMIT_VARIABLE", "MIN_CAM_SPEED_HZ", "MIN_SAMPLES_PER_REVOLUTION", "MIN_SAMPLE_RATE_HZ",
           "OFFSET_ATTRIBUTES", "SCALE_ATTRIBUTES", "SHORT_REVOLUTIONS", "TIME_RESOLUTION", "Footprint", "Recording",
           "RecordingError", "RecordingWarning", "available_memory", "channel_spec", "check_cam_speed", "check_memory",
           "check_time_base", "read_csv", "read_hdf5", "read_recording", "read_truth", "recording_footprint",
           "release_pages", "select_channels", "write_csv", "write_hdf5"]

FORMAT_NAME = "recording"
FORMAT_VERSION = 1

#: Channels of docs/formats.md and their SI units.
CHANNEL_UNITS: Mapping[str, str] = MappingProxyType({
    "accel_tangential": "m/s^2",
    "force_x": "N",
    "force_y": "N",
    "cam_angle": "rad",
    "follower_angle": "rad",
})

#: The physical quantity of each channel (its unit string is parsed by :mod:`impactid.units`).
CHANNEL_QUANTITY: Mapping[str, str] = MappingProxyType({
    "accel_tangential": "acceleration",
    "force_x": "force",
    "force_y": "force",
    "cam_angle": "angle",
    "follower_angle": "angle",
})

#: Plausible sample rates [Hz]. Below 1 Hz nothing of an impact (a contact lasts micro- to
#: milliseconds) or of a cam revolution is resolved; above 100 MHz a recording samples 100 times
#: faster than the bandwidth of the fastest shock accelerometers and force sensors (about 1 MHz):
#: decimate such a capture first. Values outside are damaged or mistyped attributes (a rate in kHz
#: or in samples per revolution, a period written as a rate).
MIN_SAMPLE_RATE_HZ = 1.0
MAX_SAMPLE_RATE_HZ = 100e6
#: Finest spacing of float64 time stamps accepted, as a fraction of the sample interval: near time
#: ``t`` doubles are ``|t| * 2^-52`` apart, so a start time far from zero (``1e300`` s, or a Unix
#: epoch at a high sample rate) cannot tell neighbouring samples apart, and every time difference
#: the methods take (onset to separation, impact to impact) is rounded. The times of every sample
#: must resolve 1/1024 of the sample interval: ``|t| * fs`` below about ``2^42`` (4.4e12).
TIME_RESOLUTION = 2.0 ** -10
#: Plausible cam speeds [Hz]: from one revolution in 1000 s up to 60 000 rpm (six times the
#: camshaft of a racing engine at 20 000 rpm); and a cam revolution spans at least
#: :data:`MIN_SAMPLES_PER_REVOLUTION` samples (the encoder angle moves less than 45 degrees from one
#: sample to the next, and an impact, its flight and its return fit in a revolution).
MIN_CAM_SPEED_HZ = 1e-3
MAX_CAM_SPEED_HZ = 1000.0
MIN_SAMPLES_PER_REVOLUTION = 8
#: Environment variable: the memory [bytes] a job may use, instead of the machine's available memory
#: (``MemAvailable`` of ``/proc/meminfo``).
MEMORY_LIMIT_VARIABLE = "IMPACTID_MEMORY_LIMIT"
#: Peak memory of a job beyond the interpreter's own, per byte of a recording's channels as float64
#: (samples x channels x 8 bytes). Measured with ``/usr/bin/time -v`` (maximum resident set size)
#: on synthetic rig P recordings of 0.3, 1, 3, 10 and 20 s at 204.8 kHz (4 channels, 2 to 131 MB as
#: float64), as the slope of the peak against the size: reading (``impactid info``) 1.05,
#: ``events`` 2.0, ``estimate`` (one recording, calibrated least squares, ``--fix-n``) 5.5 up to
#: 10 s and 8.0 from 10 to 20 s (the 3.4 GB peak of a 60 s recording is 8.7 times its 393 MB).
#: The factors below round these up. A joint fit holds every recording read and processes one at a
#: time (:func:`check_memory`).
MEMORY_FACTORS: Mapping[str, float] = MappingProxyType({"read": 1.5, "events": 2.5, "estimate": 9.0})
#: Dataset attributes of a linear calibration ``value = raw * scale + offset`` (an integer channel
#: of ADC codes, say), in the spellings of common conventions.
SCALE_ATTRIBUTES = ("scale", "scale_factor")
OFFSET_ATTRIBUTES = ("offset", "add_offset")

#: Consecutive accelerometer samples at the channel's extreme value that (with a histogram spike
#: there) mark a clipped, saturated recording.
CLIP_RUN = 3
#: Relative difference between the operating point's cam speed and the cam encoder's mean speed
#: above which :meth:`Recording.check` warns.
CAM_SPEED_TOLERANCE = 0.002
#: A recording shorter than this many cam revolutions gets a warning.
SHORT_REVOLUTIONS = 3.0


class RecordingError(ImpactidError, ValueError):
    """A recording file is missing, unreadable, malformed or physically inconsistent."""


class RecordingWarning(UserWarning):
    """A recording is usable but suspicious (clipped accelerometer, very short, ...)."""


def _frozen(array: np.ndarray) -> np.ndarray:
    array.flags.writeable = False
    return array


@dataclass(frozen=True)
class Recording:
    """A measured (or synthetic) recording with its rig description.

    Attributes
    ----------
    channels : read-only mapping of channel name to a read-only 1-D float array (SI units).
    units : channel name to unit string (SI, after conversion at reading).
    sample_rate_hz : sampling rate [Hz].
    start_time_s : time of the first sample [s].
    rig : the rig dataclass of its model (:data:`impactid.rigs.registry.RIG_MODELS`), or None when
        the file had none.
    operating : operating point, e.g. ``cam_speed_hz`` [Hz], ``eccentricity_m`` [m].
    source : the file the recording was read from ("" if built in memory).
    provenance : what was done to the data, oldest first (one line per step).
    """

    channels: Mapping[str, np.ndarray]
    sample_rate_hz: float
    units: Mapping[str, str]
    rig: Any = None
    operating: Mapping[str, float] = field(default_factory=dict)
    start_time_s: float = 0.0
    source: str = ""
    provenance: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        where = self.source or "recording"
        rate = self.sample_rate_hz
        if isinstance(rate, bool) or not isinstance(rate, (int, float, np.floating, np.integer)):
            raise RecordingError(f"{where}: sample rate must be a number, got {rate!r}")
        if not math.isfinite(float(rate)) or float(rate) <= 0.0:
            raise RecordingError(f"{where}: sample rate must be positive and finite, got {rate!r} Hz")
        object.__setattr__(self, "sample_rate_hz", float(rate))
        if not math.isfinite(float(self.start_time_s)):
            raise RecordingError(f"{where}: start_time_s must be finite, got {self.start_time_s!r}")
        object.__setattr__(self, "start_time_s", float(self.start_time_s))
        if not self.channels:
            raise RecordingError(f"{where}: the recording has no channels")
        channels: dict[str, np.ndarray] = {}
        ranges: dict[str, tuple[float, float]] = {}
        length = None
        for name, data in self.channels.items():
            array = np.asarray(data)
            if array.ndim != 1:
                raise RecordingError(f"{where}: channel {name!r} must be 1-D, got shape {array.shape}")
            if not (np.issubdtype(array.dtype, np.floating) or np.issubdtype(array.dtype, np.integer)):
                raise RecordingError(f"{where}: channel {name!r} is not numeric (dtype {array.dtype})")
            if array.size == 0:
                raise RecordingError(f"{where}: channel {name!r} is empty")
            if length is None:
                length = array.size
            elif array.size != length:
                raise RecordingError(
                    f"{where}: channels have unequal lengths ({name!r} has {array.size} samples, "
                    f"{next(iter(channels))!r} has {length})")
            # read-only float arrays are shared; anything else is copied, so that a caller's array
            # is never frozen or aliased (readers freeze the arrays they own to avoid the copy)
            if array.dtype != np.float64 or array.flags.writeable:
                array = _frozen(np.array(array, dtype=np.float64))
            lo, hi, finite = channel_scan(array)  # one compiled pass: range and finiteness
            if not finite:
                bad = ~np.isfinite(array)
                raise RecordingError(
                    f"{where}: channel {name!r} has {int(bad.sum())} NaN or Inf sample(s), the first at index "
                    f"{int(np.argmax(bad))}")
            channels[name] = array
            ranges[name] = (float(lo), float(hi))
        check_time_base(where, float(rate), self.start_time_s, length)
        missing_units = [n for n in channels if n not in self.units]
        if missing_units:
            raise RecordingError(f"{where}: no units given for channel(s) {', '.join(missing_units)}")
        object.__setattr__(self, "channels", MappingProxyType(channels))
        object.__setattr__(self, "_ranges", ranges)
        object.__setattr__(self, "units", MappingProxyType({n: str(self.units[n]) for n in channels}))
        operating = {}
        for key, value in dict(self.operating).items():
            if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
                raise RecordingError(f"{where}: operating parameter {key!r} must be a number, got {value!r}")
            if not math.isfinite(float(value)):
                raise RecordingError(f"{where}: operating parameter {key!r} is not finite ({value!r})")
            operating[key] = float(value)
        if "cam_speed_hz" in operating:
            check_cam_speed(where, operating["cam_speed_hz"], float(rate))
        object.__setattr__(self, "operating", MappingProxyType(operating))
        object.__setattr__(self, "provenance", tuple(self.provenance))
        if self.rig is not None and not is_rig_parameters(self.rig):
            raise RecordingError(f"{where}: rig must be a rig dataclass, got {type(self.rig).__name__}")
        ecc = operating.get("eccentricity_m")
        rig_e = getattr(self.rig, "e", None)
        if ecc is not None and rig_e is not None and not math.isclose(ecc, rig_e, rel_tol=1e-9, abs_tol=1e-12):
            raise RecordingError(
                f"{where}: operating eccentricity_m = {ecc!r} m disagrees with the rig's e = {rig_e!r} m")

    # ---- basic properties ----------------------------------------------------------------------
    @property
    def n_samples(self) -> int:
        """Number of samples per channel."""
        return next(iter(self.channels.values())).size

    @property
    def duration(self) -> float:
        """``n_samples / sample_rate_hz`` [s]."""
        return self.n_samples / self.sample_rate_hz

    @property
    def time(self) -> np.ndarray:
        """Sample times [s]: ``start_time_s + k / sample_rate_hz`` (computed exactly from k)."""
        return self.start_time_s + np.arange(self.n_samples) / self.sample_rate_hz

    @property
    def cam_speed_hz(self) -> float | None:
        """Cam speed ``Omega_c`` [Hz] from the operating point (None if unknown)."""
        return self.operating.get("cam_speed_hz")

    def channel_range(self, name: str) -> tuple[float, float]:
        """``(min, max)`` of a channel (computed once, when the recording was built)."""
        self.channel(name)
        return self._ranges[name]

    def __contains__(self, channel: str) -> bool:
        return channel in self.channels

    def __getitem__(self, channel: str) -> np.ndarray:
        return self.channel(channel)

    def channel(self, name: str) -> np.ndarray:
        """The samples of one channel (read-only), with a clear error if it does not exist."""
        if name not in self.channels:
            raise RecordingError(
                f"{self.source or 'recording'}: no channel {name!r} (has {', '.join(self.channels)})")
        return self.channels[name]

    def require(self, *names: str, method: str = "this method") -> None:
        """Raise :class:`RecordingError` unless all channels ``names`` exist (naming the method)."""
        missing = [n for n in names if n not in self.channels]
        if missing:
            raise RecordingError(
                f"{self.source or 'recording'}: {method} needs channel(s) {', '.join(missing)}, "
                f"which the recording does not have (it has {', '.join(self.channels)})")

    def require_rig(self, model: str | None = None) -> Any:
        """The rig, or a :class:`RecordingError` if there is none (or it is not of ``model``)."""
        where = self.source or "recording"
        if self.rig is None:
            raise RecordingError(f"{where}: no rig description (no /rig group; pass a TOML rig file)")
        if model is not None and self.rig.model != model:
            raise RecordingError(f"{where}: needs a {model!r} rig, the recording's rig is {self.rig.model!r}")
        return self.rig

    def require_cam_speed(self) -> float:
        """``cam_speed_hz`` or a :class:`RecordingError` if the operating point does not give it."""
        if self.cam_speed_hz is None:
            raise RecordingError(
                f"{self.source or 'recording'}: operating point has no cam_speed_hz "
                "(add it to /operating or to the [operating] table of a TOML rig file)")
        return self.cam_speed_hz

    def encoder_speed_hz(self, channel: str = "cam_angle") -> float:
        """Mean turning speed of an angle channel [Hz] (least-squares slope of the unwrapped angle
        against time, over at most 200 000 evenly spread samples)."""
        angle = self.channel(channel)
        step = max(1, angle.size // 200_000)
        y = np.unwrap(angle[::step])
        t = np.arange(y.size) * (step / self.sample_rate_hz)
        t = t - t.mean()
        denom = float(np.dot(t, t))
        return float(np.dot(t, y - y.mean()) / denom / (2.0 * math.pi)) if denom > 0 else math.nan

    # ---- new recordings from this one (never mutating) -----------------------------------------
    def with_step(self, description: str, **changes: Any) -> Recording:
        """A new recording with ``changes`` applied and ``description`` appended to the provenance."""
        return replace(self, provenance=self.provenance + (description,), **changes)

    def with_rig(self, rig: Any) -> Recording:
        """A new recording with its rig (and, from a TOML rig file, its operating point) replaced.

        ``rig`` is a rig dataclass or the path of a TOML rig file (docs/formats.md)."""
        new_rig, operating, note = _resolve_rig(rig)
        merged = dict(self.operating)
        merged.update(operating)
        if getattr(new_rig, "e", None) is not None and "eccentricity_m" in merged and "eccentricity_m" not in operating:
            merged["eccentricity_m"] = new_rig.e
        return self.with_step(note, rig=new_rig, operating=merged)

    def slice_time(self, start: float, stop: float) -> Recording:
        """The samples with ``start <= t < stop`` [s], as a new recording."""
        k0 = max(0, int(math.ceil((start - self.start_time_s) * self.sample_rate_hz - 1e-9)))
        k1 = min(self.n_samples, int(math.ceil((stop - self.start_time_s) * self.sample_rate_hz - 1e-9)))
        if k1 <= k0:
            raise RecordingError(f"{self.source or 'recording'}: no samples in [{start}, {stop}) s")
        return self.with_step(
            f"slice_time({start!r}, {stop!r}): samples {k0}:{k1}",
            channels={n: c[k0:k1] for n, c in self.channels.items()},
            start_time_s=self.start_time_s + k0 / self.sample_rate_hz)

    def check(self) -> list[str]:
        """Warn about suspicious but usable data; returns the warning texts.

        * a clipped or saturated accelerometer: runs of ``CLIP_RUN`` or more consecutive samples at
          the channel's extreme value;
        * a very short recording: fewer than ``SHORT_REVOLUTIONS`` cam revolutions (or 1000 samples
          when the cam speed is unknown).
        """
        where = self.source or "recording"
        messages = []
        if "accel_tangential" in self.channels:
            a = self.channels["accel_tangential"]
            lo, hi = self.channel_range("accel_tangential")
            for label, extreme in (("maximum", hi), ("minimum", lo)):
                # a saturated ADC piles samples on its end code: a spike in the histogram at the
                # extreme. A quantised smooth plateau also repeats its extreme value, but the next
                # code inwards is about as populated, so it is not mistaken for clipping.
                if extreme == 0.0 or count_equal(a, extreme) < CLIP_RUN:
                    continue  # the common case, decided by one parallel pass
                count, run, neighbour = extreme_stats(a, extreme, label == "maximum")
                if run >= CLIP_RUN and extreme != 0.0 and count > 3 * neighbour:
                    messages.append(
                        f"{where}: channel 'accel_tangential' looks clipped: {count} samples at its "
                        f"{label} {extreme:.6g} m/s^2 (longest run {run}); impacts there are unreliable")
        if self.cam_speed_hz is not None and "cam_angle" in self.channels and self.n_samples > 2:
            turning = self.encoder_speed_hz("cam_angle")
            if not math.isclose(turning, self.cam_speed_hz, rel_tol=CAM_SPEED_TOLERANCE):
                messages.append(f"{where}: channel 'cam_angle' turns at {turning:.6g} Hz but the operating point "
                                f"says cam_speed_hz = {self.cam_speed_hz:.6g} Hz; the methods use the operating "
                                "point's value")
        if self.cam_speed_hz is not None:
            revs = self.duration * self.cam_speed_hz
            if revs < SHORT_REVOLUTIONS:
                messages.append(f"{where}: very short recording: {self.duration:.4g} s is {revs:.3g} cam "
                                f"revolution(s) (fewer than {SHORT_REVOLUTIONS:g})")
        elif self.n_samples < 1000:
            messages.append(f"{where}: very short recording ({self.n_samples} samples)")
        for message in messages:
            warnings.warn(message, RecordingWarning, stacklevel=2)
        return messages


def check_time_base(where: str, sample_rate_hz: float, start_time_s: float, n_samples: int, *,
                    rate_name: str = "sample_rate_hz", start_name: str = "start_time_s") -> None:
    """Refuse an implausible time base (docs/formats.md): a sample rate outside
    [:data:`MIN_SAMPLE_RATE_HZ`, :data:`MAX_SAMPLE_RATE_HZ`], or sample times so far from zero that
    float64 does not resolve :data:`TIME_RESOLUTION` of a sample interval.

    Parameters
    ----------
    where : the file (for the message).
    sample_rate_hz : sample rate [Hz] (positive and finite).
    start_time_s : time of the first sample [s] (finite).
    n_samples : samples per channel.
    rate_name, start_name : how the file names the two (``/signals sample_rate_hz``, ...).

    Raises
    ------
    RecordingError
        naming the file, the attribute and the limit.
    """
    if not MIN_SAMPLE_RATE_HZ <= sample_rate_hz <= MAX_SAMPLE_RATE_HZ:
        raise RecordingError(
            f"{where}: {rate_name} = {sample_rate_hz:.6g} Hz is not a plausible sample rate (impactid reads "
            f"{MIN_SAMPLE_RATE_HZ:g} Hz to {MAX_SAMPLE_RATE_HZ / 1e6:g} MHz; a damaged or mistyped attribute?)")
    interval = 1.0 / sample_rate_hz
    last = max(abs(start_time_s), abs(start_time_s + max(n_samples - 1, 0) * interval))
    spacing = float(np.spacing(last))
    if not spacing <= TIME_RESOLUTION * interval:
        raise RecordingError(
            f"{where}: {start_name} = {start_time_s:.6g} s is too far from 0 for {sample_rate_hz:.6g} Hz: float64 "
            f"times near {last:.6g} s are {spacing:.3g} s apart, more than 1/{1 / TIME_RESOLUTION:.0f} of the sample "
            f"interval {interval:.3g} s, so samples cannot be told apart; give times from the start of the run "
            "(e.g. start_time_s = 0)")


def check_cam_speed(where: str, cam_speed_hz: float, sample_rate_hz: float, *,
                    name: str = "operating cam_speed_hz") -> None:
    """Refuse an implausible cam speed (docs/formats.md): outside [:data:`MIN_CAM_SPEED_HZ`,
    :data:`MAX_CAM_SPEED_HZ`], or fewer than :data:`MIN_SAMPLES_PER_REVOLUTION` samples per revolution.

    Parameters
    ----------
    where : the file (for the message).
    cam_speed_hz : the operating point's cam speed [Hz].
    sample_rate_hz : the recording's sample rate [Hz].
    name : where the cam speed was given (``/operating cam_speed_hz``, a rig file's ``[operating]``).

    Raises
    ------
    RecordingError
        naming the file, where the cam speed came from and the limit.
    """
    if not cam_speed_hz > 0.0:
        raise RecordingError(f"{where}: {name} must be positive, got {cam_speed_hz!r}")
    if not MIN_CAM_SPEED_HZ <= cam_speed_hz <= MAX_CAM_SPEED_HZ:
        raise RecordingError(
            f"{where}: {name} = {cam_speed_hz:.6g} Hz is not a plausible cam speed (impactid reads "
            f"{MIN_CAM_SPEED_HZ:g} Hz to {MAX_CAM_SPEED_HZ:g} Hz, i.e. up to {60 * MAX_CAM_SPEED_HZ:.0f} rpm; "
            "a speed in rpm or rad/s written as Hz?)")
    per_revolution = sample_rate_hz / cam_speed_hz
    if per_revolution < MIN_SAMPLES_PER_REVOLUTION:
        raise RecordingError(
            f"{where}: {name} = {cam_speed_hz:.6g} Hz gives {per_revolution:.3g} samples per cam revolution at "
            f"{sample_rate_hz:.6g} Hz; at least {MIN_SAMPLES_PER_REVOLUTION} are needed to resolve a revolution")


def channel_spec(channel: str) -> tuple[str, str] | None:
    """``(SI unit, quantity)`` of a channel impactid interprets: the channels above, and those the
    registered rig models declare (:attr:`impactid.rigs.base.RigModel.channels`); None otherwise."""
    if channel in CHANNEL_UNITS:
        return CHANNEL_UNITS[channel], CHANNEL_QUANTITY[channel]
    from impactid.rigs.registry import MODELS

    for model in MODELS.values():
        spec = model.channels.get(channel)
        if spec is not None:
            return spec.unit, spec.quantity
    return None


def _to_si(where: str, channel: str, unit: str, data: np.ndarray) -> tuple[np.ndarray, str, str | None]:
    """Convert a channel to SI; returns (data, SI unit, provenance note or None).

    The unit string is parsed case-sensitively (:func:`impactid.units.si_factor`); a channel
    impactid does not interpret keeps its data and unit.
    """
    spec = channel_spec(channel)
    if spec is None:
        return data, unit, None  # a channel impactid does not interpret: kept as is
    si, quantity = spec
    if unit == si:  # the SI spelling itself: factor 1 without loading the unit parser (pint: 0.4 s)
        return data, si, None
    try:
        factor = si_factor(unit, quantity)
    except UnitError as exc:
        raise RecordingError(f"{where}: channel {channel!r} has units {shown_unit(unit)}: {exc.reason}") from None
    if factor == 1.0:
        return data, si, None
    return data * factor, si, f"channel {channel!r} converted from {unit} to {si} (x {factor!r})"


def available_memory() -> tuple[float | None, str]:
    """Bytes a job may use and where that number comes from.

    :data:`MEMORY_LIMIT_VARIABLE` (``IMPACTID_MEMORY_LIMIT``, in bytes) when set; else
    ``MemAvailable`` of ``/proc/meminfo`` (memory the kernel can give without swapping, other
    users' jobs deducted); else the free physical pages (``os.sysconf``); ``None`` when the
    platform tells neither (no check).

    Raises
    ------
    RecordingError
        when the environment variable is set but is not a positive number of bytes.
    """
    text = os.environ.get(MEMORY_LIMIT_VARIABLE, "").strip()
    if text:
        try:
            limit = float(text)
        except ValueError:
            limit = math.nan
        if not (math.isfinite(limit) and limit > 0.0):
            raise RecordingError(f"environment variable {MEMORY_LIMIT_VARIABLE}={text!r}: expected a positive number "
                                 "of bytes (e.g. 8e9)")
        return limit, f"{MEMORY_LIMIT_VARIABLE}"
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024.0, "MemAvailable"
    except (OSError, ValueError, IndexError):
        pass
    try:
        return float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_AVPHYS_PAGES")), "free physical memory"
    except (ValueError, OSError, AttributeError):  # pragma: no cover - platforms without sysconf
        return None, "unknown"


@dataclass(frozen=True)
class Footprint:
    """The size of a recording's channels, from the file's metadata (nothing is read).

    n_samples : samples of the longest channel.
    n_channels : channels (for a CSV, its columns, the time column included).
    longest : the name of the longest channel.
    """

    n_samples: int
    n_channels: int
    longest: str

    @property
    def nbytes(self) -> float:
        """Bytes of the channels as float64 [B]."""
        return 8.0 * self.n_samples * max(self.n_channels, 1)


def recording_footprint(path: str | os.PathLike[str]) -> Footprint | None:
    """The size of a recording from its metadata (HDF5: dataset shapes; CSV: file size over the
    length of its first rows), or None when the file cannot be sized (the reader then reports
    what is wrong with it)."""
    path = Path(path)
    try:
        if not path.is_file():
            return None
        with path.open("rb") as fh:
            head = fh.read(8)
        if head == _HDF5_SIGNATURE or path.suffix.lower() in (".h5", ".hdf5", ".hdf"):
            import h5py

            with h5py.File(path, "r") as fh:
                signals = fh.get("signals")
                shapes = {name: item.shape for name, item in signals.items()
                          if isinstance(item, h5py.Dataset) and len(item.shape) == 1} if signals is not None else {}
            if not shapes:
                return None
            longest = max(shapes, key=lambda name: shapes[name][0])
            return Footprint(int(shapes[longest][0]), len(shapes), longest)
        if path.suffix.lower() in (".csv", ".txt"):
            with path.open("rb") as fh:
                sample = fh.read(1 << 16)
            lines = [line for line in sample.splitlines()[1:-1] if line.strip() and not line.lstrip().startswith(b"#")]
            if not lines:
                return None
            per_row = sum(len(line) + 1 for line in lines) / len(lines)
            columns = lines[0].count(b",") + 1
            return Footprint(int(path.stat().st_size / per_row) + 1, columns, "time_s")
    except Exception:  # noqa: BLE001 - sizing is advisory: a damaged file is reported by its reader
        return None
    return None


def check_memory(paths, job: str) -> None:
    """Refuse a job whose recordings would not fit in memory, before anything is allocated.

    The job needs about ``MEMORY_FACTORS["read"]`` times the float64 size of every recording (they
    are read first and kept) plus ``MEMORY_FACTORS[job] - MEMORY_FACTORS["read"]`` times the
    largest one (processed one at a time); it is refused when that exceeds
    :func:`available_memory`.

    Parameters
    ----------
    paths : the recordings (paths; anything else is skipped).
    job : a key of :data:`MEMORY_FACTORS` (``"read"``, ``"events"``, ``"estimate"``).

    Raises
    ------
    RecordingError
        naming the (largest) file, its size, the estimate and the memory available.
    """
    sized = [(str(p), f) for p in paths if isinstance(p, (str, os.PathLike))
             for f in [recording_footprint(p)] if f is not None]
    if sized:
        _refuse_if_too_large(sized, job)


def _refuse_if_too_large(sized: list[tuple[str, Footprint]], job: str) -> None:
    """The test of :func:`check_memory` on ``(file, footprint)`` pairs."""
    factor, read = MEMORY_FACTORS[job], MEMORY_FACTORS["read"]
    limit, source = available_memory()
    if limit is None:
        return
    total = sum(f.nbytes for _, f in sized)
    where, largest = max(sized, key=lambda pair: pair[1].nbytes)
    need = read * total + (factor - read) * largest.nbytes
    if need > limit:
        others = (f"; with the {len(sized) - 1} other recording(s), {_size_text(total)} as float64"
                  if len(sized) > 1 else "")
        raise RecordingError(
            f"{where}: {_JOB_TEXT.get(job, job)} needs about {_size_text(need)} of memory ({largest.n_samples:,} "
            f"samples of channel {largest.longest!r} x {largest.n_channels} channel(s) x 8 bytes = "
            f"{_size_text(largest.nbytes)}, x {factor:g}{others}), more than the {_size_text(limit)} available "
            f"({source}); split the recording, or set {MEMORY_LIMIT_VARIABLE} (bytes) if more memory can be used")


_JOB_TEXT = {"read": "reading it", "events": "finding and reconstructing its events", "estimate": "the estimate"}


def _size_text(nbytes: float) -> str:
    """A number of bytes for a message (``"3.4 GB"``, ``"17.7 MB"``)."""
    for unit, scale in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if nbytes >= scale:
            return f"{nbytes / scale:.3g} {unit}"
    return f"{nbytes:.0f} bytes"


def _calibrate(where: str, name: str, attrs, data: np.ndarray) -> tuple[np.ndarray, str | None]:
    """Apply a dataset's ``scale``/``offset`` attributes (raw -> physical value)."""
    scale = next((attrs[k] for k in SCALE_ATTRIBUTES if k in attrs), None)
    offset = next((attrs[k] for k in OFFSET_ATTRIBUTES if k in attrs), None)
    if scale is None and offset is None:
        if data.dtype.kind in "iu" and (channel_spec(name) or ("rad",))[0] != "rad":
            warnings.warn(f"{where}: channel {name!r} holds integers ({data.dtype}) without a 'scale' attribute: "
                          f"read as values in its units, not as ADC codes", RecordingWarning, stacklevel=3)
        return data, None
    scale_v = 1.0 if scale is None else _attr_float(where, f"channel {name!r} attribute scale", scale)
    offset_v = 0.0 if offset is None else _attr_float(where, f"channel {name!r} attribute offset", offset)
    if not (math.isfinite(scale_v) and scale_v != 0.0 and math.isfinite(offset_v)):
        raise RecordingError(f"{where}: channel {name!r} has an invalid calibration (scale {scale_v!r}, "
                             f"offset {offset_v!r})")
    return (data.astype(np.float64) * scale_v + offset_v,
            f"channel {name!r} calibrated: raw x {scale_v!r} + {offset_v!r}")


def select_channels(where: str, available: Sequence[str], wanted: Sequence[str] | None) -> list[int]:
    """Positions in ``available`` of the channels a reader keeps: all (``wanted`` None), else those named
    in ``wanted`` that the file has (a job's optional channels may be missing; the job's own
    :meth:`Recording.require` names a missing one it needs). A file that has none of them is an error
    naming both lists (a recording needs a channel)."""
    if wanted is None:
        return list(range(len(available)))
    wanted_set = set(wanted)
    kept = [k for k, name in enumerate(available) if name in wanted_set]
    if not kept:
        raise RecordingError(f"{where}: none of the channels {', '.join(wanted)} is in the recording (it has "
                             f"{', '.join(available)})")
    return kept


# ---------------------------------------------------------------------------------------------
# HDF5
# ---------------------------------------------------------------------------------------------

def _attr_str(value: Any) -> str:
    if isinstance(value, bytes):
        return value.decode("utf-8", errors="replace")
    if isinstance(value, np.ndarray) and value.shape == ():
        return _attr_str(value[()])
    return str(value)


def _attr_float(where: str, what: str, value: Any) -> float:
    try:
        array = np.asarray(value)
        if array.size != 1:
            raise TypeError
        number = float(array.reshape(()))
    except (TypeError, ValueError):
        raise RecordingError(f"{where}: {what} must be a number, got {value!r}") from None
    return number


def _units_text(where: str, name: str, value: Any) -> str:
    """A channel's ``units`` attribute as text; bytes that are not UTF-8 are an error naming them."""
    if isinstance(value, np.ndarray) and value.shape == ():
        value = value[()]
    if isinstance(value, (bytes, np.bytes_)):
        try:
            return bytes(value).decode("utf-8")
        except UnicodeDecodeError:
            raise RecordingError(f"{where}: channel {name!r} has units {bytes(value)[:40]!r}: not UTF-8 text, "
                                 "not a unit") from None
    return _attr_str(value)


def _check_path(path: Path) -> None:
    """A clear error for a path that does not exist (or is a dangling symbolic link), is a directory
    or a special file (opening a named pipe would wait for a writer forever)."""
    if not path.exists():
        if path.is_symlink():
            raise RecordingError(f"{path}: is a symbolic link to {os.readlink(path)}, which does not exist "
                                 "(a dangling link)")
        raise RecordingError(f"{path}: file not found")
    if path.is_dir():
        raise RecordingError(f"{path}: is a directory, not a recording")
    if not path.is_file():
        raise RecordingError(f"{path}: is a special file (named pipe, device or socket), not a recording")


def _open_hdf5(path: Path):
    import h5py

    _check_path(path)
    try:
        return h5py.File(path, "r")
    except OSError as exc:
        if not os.access(path, os.R_OK):
            raise RecordingError(f"{path}: cannot read file (permission denied)") from None
        raise RecordingError(f"{path}: not an HDF5 file or damaged ({exc})") from None


def _member(where: str, group, name: str, label: str):
    """``group[name]``, None when there is no such link, or a :class:`RecordingError` that says why a
    link cannot be followed (an external link to a missing file, a dangling soft link)."""
    import h5py

    link = group.get(name, getlink=True)
    if link is None:
        return None
    try:
        return group[name]
    except (KeyError, OSError, ValueError, RuntimeError) as exc:
        if isinstance(link, h5py.ExternalLink):
            raise RecordingError(f"{where}: {label} is an external link to {link.filename}:{link.path}, which cannot "
                                 "be opened (the file or the object it names is missing)") from None
        if isinstance(link, h5py.SoftLink):
            raise RecordingError(f"{where}: {label} is a soft link to {link.path}, which does not exist") from None
        raise RecordingError(f"{where}: {label} cannot be opened ({type(exc).__name__}: {exc})") from None


def _check_virtual_sources(where: str, path: Path, name: str, item) -> None:
    """A virtual dataset reads as fill values where a source is missing: refuse it instead."""
    import h5py

    for source in item.virtual_sources():
        if source.file_name == ".":  # a dataset of the same file
            if not isinstance(item.file.get(source.dset_name), h5py.Dataset):
                raise RecordingError(f"{where}: channel {name!r} is a virtual dataset whose source {source.dset_name} "
                                     "does not exist in the file (it would read as fill values)")
            continue
        given = Path(source.file_name)
        candidates = [given] if given.is_absolute() else [path.parent / given, given]
        found = next((c for c in candidates if c.is_file()), None)
        if found is None:
            raise RecordingError(f"{where}: channel {name!r} is a virtual dataset whose source file "
                                 f"{source.file_name} does not exist (it would read as fill values)")
        try:
            with h5py.File(found, "r") as other:
                present = isinstance(other.get(source.dset_name), h5py.Dataset)
        except OSError:
            present = False
        if not present:
            raise RecordingError(f"{where}: channel {name!r} is a virtual dataset whose source "
                                 f"{source.file_name}:{source.dset_name} cannot be read (it would read as fill "
                                 "values)")


def _check_storage(where: str, path: Path, name: str, item) -> None:
    """Refuse a dataset whose samples are not all there (virtual sources, contiguous storage)."""
    if item.is_virtual:
        _check_virtual_sources(where, path, name, item)
        return
    if item.external:
        return  # raw data in external files: a missing one is reported when it is read
    stored = item.id.get_storage_size()
    if item.compression is None and item.chunks is None and item.shape[0] and stored < item.nbytes:
        raise RecordingError(f"{where}: channel {name!r} declares {item.shape[0]:,} samples but stores "
                             f"only {stored:,} of its {item.nbytes:,} bytes (damaged or never written)")


#: Channels of at least this many bytes, stored contiguous, uncompressed and as little-endian float64 in a
#: local file, are mapped from the file instead of copied into memory (:func:`_mapped`): 4 M samples, 20 s
#: at 204.8 kHz.
MAP_BYTES = 32 * 2 ** 20


def _mapped(path: Path, item) -> np.ndarray | None:
    """The samples of a dataset as a read-only array mapped from the file, or None when they cannot be.

    A mapped channel occupies memory only where it is read (a rig's pivot forces are read around the
    impacts only), and the pages read are the operating system's file cache, shared and given back
    (:func:`_release`). The file must not be rewritten in place while the recording is in use (impactid
    writes files whole and renames them, which leaves a mapping of the old file valid).
    """
    if (os.name != "posix" or item.nbytes < MAP_BYTES or item.dtype != np.dtype("<f8") or item.chunks is not None
            or item.compression is not None or item.is_virtual or item.external):
        return None  # (elsewhere a mapped file cannot be replaced while it is mapped)
    offset = item.id.get_offset()
    if offset is None:
        return None
    start = offset - offset % mmap.ALLOCATIONGRANULARITY
    try:
        with open(path, "rb") as fh:
            if os.fstat(fh.fileno()).st_size < offset + item.nbytes:
                return None  # a truncated file: read (and refused) as before, never a mapping past its end
            mapping = mmap.mmap(fh.fileno(), offset - start + item.nbytes, access=mmap.ACCESS_READ, offset=start)
    except (OSError, ValueError, OverflowError):
        return None
    return np.frombuffer(mapping, dtype=np.float64, count=item.shape[0], offset=offset - start)


def release_pages(recording: Recording) -> None:
    """Give back the memory pages of a recording's channels mapped from its file (:data:`MAP_BYTES`) that
    have been read so far; their samples stay readable (a read maps them again from the file cache).

    A job that reads a mapped channel in many short windows (rig P's pivot forces around each impact)
    calls this now and then: each window's read maps the 64 kB about it, which over a thousand impacts
    is most of the channel. Channels held in memory are not touched.
    """
    _release(recording.channels)


def _release(channels: Mapping[str, np.ndarray]) -> None:
    """Give back the pages of the mapped channels read so far (the recording's checks read them all): the
    next read of a sample maps it again from the file cache."""
    for array in channels.values():
        base = array.base
        mapping = base.obj if isinstance(base, memoryview) else None
        if isinstance(mapping, mmap.mmap) and hasattr(mmap, "MADV_DONTNEED"):
            mapping.madvise(mmap.MADV_DONTNEED)


def _read_dataset(where: str, name: str, item, path: Path | None = None) -> np.ndarray:
    try:
        if path is not None and not item.attrs.keys() & {*SCALE_ATTRIBUTES, *OFFSET_ATTRIBUTES}:
            mapped = _mapped(path, item)
            if mapped is not None:
                return mapped
        return item[()]
    except (OSError, RuntimeError, ValueError) as exc:
        if item.external:
            files = ", ".join(str(entry[0]) for entry in item.external)
            raise RecordingError(f"{where}: channel {name!r} keeps its samples in external raw file(s) {files}, "
                                 f"which cannot be read ({exc})") from None
        raise RecordingError(f"{where}: channel {name!r} cannot be read (damaged; {type(exc).__name__}: "
                             f"{exc})") from None


def read_hdf5(path: str | os.PathLike[str], rig: Any = None, *, channels: Sequence[str] | None = None) -> Recording:
    """Read an HDF5 recording (docs/formats.md, format version 1).

    Parameters
    ----------
    path : the ``.h5`` file.
    rig : optional rig that supplies or overrides the file's ``/rig``: a rig dataclass or the path
        of a TOML rig file (whose ``[operating]`` values also override ``/operating``).
    channels : the channels to read (:func:`select_channels`; None: all). Every channel's metadata is
        checked; only these channels' samples are read (a job that needs the accelerometer alone reads
        a quarter of a rig P recording).

    The ``/truth`` group is never read (see :func:`read_truth`). The time base and the size are
    checked from the metadata, before any sample is read (:func:`check_time_base`,
    :func:`check_memory`).
    """
    path = Path(path)
    where = str(path)
    wanted = None if channels is None else tuple(channels)
    import h5py

    try:
        fh = _open_hdf5(path)
        with fh:
            root_kind = fh.attrs.get("impactid_format")
            if root_kind is not None and _attr_str(root_kind) != FORMAT_NAME:
                raise RecordingError(
                    f"{where}: impactid_format is {_attr_str(root_kind)!r}, not a {FORMAT_NAME!r} file")
            version = fh.attrs.get("format_version")
            if version is not None and _attr_float(where, "format_version", version) > FORMAT_VERSION:
                raise RecordingError(f"{where}: format_version {_attr_str(version)} is newer than this "
                                     f"impactid understands ({FORMAT_VERSION})")
            signals = _member(where, fh, "signals", "/signals")
            if signals is None or not isinstance(signals, h5py.Group):
                raise RecordingError(f"{where}: no /signals group")
            if "sample_rate_hz" not in signals.attrs:
                raise RecordingError(f"{where}: /signals has no sample_rate_hz attribute")
            rate = _attr_float(where, "sample_rate_hz", signals.attrs["sample_rate_hz"])
            if not math.isfinite(rate) or rate <= 0.0:
                raise RecordingError(f"{where}: sample_rate_hz must be positive and finite, got {rate!r}")
            start = _attr_float(where, "start_time_s", signals.attrs.get("start_time_s", 0.0))
            if not math.isfinite(start):
                raise RecordingError(f"{where}: /signals start_time_s must be finite, got {start!r}")
            channels: dict[str, np.ndarray] = {}
            units: dict[str, str] = {}
            notes: list[str] = []
            items = [(name, _member(where, signals, name, f"/signals/{name}")) for name in signals.keys()]
            for name, item in items:
                if not isinstance(item, h5py.Dataset):
                    raise RecordingError(f"{where}: /signals/{name} is not a dataset")
                if "units" not in item.attrs:
                    raise RecordingError(f"{where}: channel {name!r} has no units attribute")
                if item.ndim != 1:
                    raise RecordingError(f"{where}: channel {name!r} must be 1-D, got shape {item.shape}")
                if item.dtype.kind not in "fiu":
                    raise RecordingError(f"{where}: channel {name!r} is not numeric (dtype {item.dtype})")
            if not items:
                raise RecordingError(f"{where}: /signals has no channels")
            items = [items[k] for k in select_channels(where, [name for name, _ in items], wanted)]
            longest = max(items, key=lambda entry: entry[1].shape[0])
            _refuse_if_too_large([(where, Footprint(int(longest[1].shape[0]), len(items), longest[0]))], "read")
            check_time_base(where, rate, start, int(longest[1].shape[0]), rate_name="/signals sample_rate_hz",
                            start_name="/signals start_time_s")
            for name, item in items:
                _check_storage(where, path, name, item)
            for name, item in items:
                data = _read_dataset(where, name, item, path)
                data, cal_note = _calibrate(where, name, item.attrs, data)
                if cal_note:
                    notes.append(cal_note)
                data, unit, note = _to_si(where, name, _units_text(where, name, item.attrs["units"]), data)
                channels[name] = _frozen(data) if data.dtype == np.float64 else data
                units[name] = unit
                if note:
                    notes.append(note)
            file_rig = None
            if rig is None:  # an overriding rig makes the file's /rig irrelevant (even a broken link to it)
                rig_group = _member(where, fh, "rig", "/rig")
                if rig_group is not None:
                    file_rig = _rig_from_attrs(where, rig_group)
            operating = {}
            op_group = _member(where, fh, "operating", "/operating")
            if op_group is not None:
                for key, value in op_group.attrs.items():
                    operating[key] = _attr_float(where, f"operating {key}", value)
            provenance_attr = fh.attrs.get("provenance")
            earlier = tuple(json.loads(_attr_str(provenance_attr))) if provenance_attr is not None else ()
    except RecordingError:
        raise
    except RigParameterError as exc:
        raise RecordingError(str(exc)) from None
    except (OSError, KeyError, ValueError, TypeError, RuntimeError) as exc:
        raise RecordingError(f"{where}: damaged or malformed HDF5 recording ({type(exc).__name__}: {exc})") from None
    provenance = earlier + (f"read_hdf5({where})",) + tuple(notes)
    recording_rig = file_rig
    speed_from = "/operating cam_speed_hz"
    if rig is not None:
        recording_rig, toml_operating, rig_note = _resolve_rig(rig)
        operating.update(toml_operating)
        if getattr(recording_rig, "e", None) is not None and "eccentricity_m" in operating \
                and "eccentricity_m" not in toml_operating:
            operating["eccentricity_m"] = recording_rig.e
        if "cam_speed_hz" in toml_operating:
            speed_from = f"rig file {rig} [operating] cam_speed_hz"
        provenance += (rig_note,)
    if recording_rig is None:
        raise RecordingError(f"{where}: no /rig group and no rig file given (use --rig RIG.toml)")
    if math.isfinite(operating.get("cam_speed_hz", math.nan)):
        check_cam_speed(where, operating["cam_speed_hz"], rate, name=speed_from)
    recording = Recording(channels=channels, sample_rate_hz=rate, units=units, rig=recording_rig,
                          operating=operating, start_time_s=start, source=where, provenance=provenance)
    _release(recording.channels)
    return recording


def _rig_from_attrs(where: str, group) -> Any:
    values: dict[str, Any] = {}
    for key, value in group.attrs.items():
        if key == "model":
            values[key] = _attr_str(value)
        else:
            values[key] = _attr_float(where, f"rig parameter {key!r}", value)
    try:
        return rig_from_mapping(values, source=f"{where} /rig")
    except RigParameterError as exc:
        raise RecordingError(str(exc)) from None


def _resolve_rig(rig: Any) -> tuple[Any, dict[str, float], str]:
    if isinstance(rig, (str, os.PathLike)):
        try:
            loaded, operating = load_rig_toml(rig)
        except RigParameterError as exc:
            raise RecordingError(str(exc)) from None
        return loaded, operating, f"rig from {rig}"
    if is_rig_parameters(rig):
        return rig, {}, f"rig supplied by the caller ({rig.model})"
    raise RecordingError(f"rig must be a rig dataclass or a TOML rig file path, got {type(rig).__name__}")


def read_truth(path: str | os.PathLike[str]) -> dict[str, Any]:
    """The ``/truth`` group of a synthetic recording, for validation only.

    Returns a nested dict: attributes as Python scalars/strings, datasets as numpy arrays,
    subgroups as dicts. Raises :class:`RecordingError` if the file has no ``/truth``.
    """
    import h5py

    path = Path(path)
    fh = _open_hdf5(path)
    with fh:
        group = fh.get("truth")
        if group is None:
            raise RecordingError(f"{path}: no /truth group (not a synthetic recording)")

        def load(g) -> dict[str, Any]:
            out: dict[str, Any] = {}
            for k, v in g.attrs.items():
                if isinstance(v, (bytes, str)):
                    out[k] = _attr_str(v)
                else:
                    out[k] = v.item() if np.ndim(v) == 0 else np.asarray(v)
            for k, item in g.items():
                out[k] = load(item) if isinstance(item, h5py.Group) else item[()]
            return out

        return load(group)


def _write_group_tree(group, values: Mapping[str, Any]) -> None:
    for key, value in values.items():
        if isinstance(value, Mapping):
            _write_group_tree(group.create_group(key), value)
        elif isinstance(value, np.ndarray) and value.ndim > 0:
            group.create_dataset(key, data=value)
        elif isinstance(value, (list, tuple)) and value and not isinstance(value[0], str):
            group.create_dataset(key, data=np.asarray(value))
        elif value is None:
            group.attrs[key] = "none"
        elif isinstance(value, (list, tuple)):
            group.attrs[key] = json.dumps(list(value))
        else:
            group.attrs[key] = value


def write_hdf5(recording: Recording, path: str | os.PathLike[str], *, truth: Mapping[str, Any] | None = None,
               compression: str | None = None) -> Path:
    """Write a recording as HDF5 (docs/formats.md), atomically (temporary file in the same folder, then
    rename). Refuses to overwrite the file the recording was read from.

    Parameters
    ----------
    truth : optional nested mapping written to ``/truth`` (synthetic data): scalars and strings as
        attributes, arrays as datasets, mappings as subgroups.
    compression : h5py compression filter for the channels (e.g. ``"gzip"``); none by default so
        that reading is as fast as possible.
    """
    import h5py

    path = Path(path)

    def write(tmp: Path) -> None:
        # libver v110: object headers and the superblock carry checksums, so a damaged file is
        # reported by the HDF5 library instead of being parsed (old-format metadata can crash it)
        with h5py.File(tmp, "w", libver=("v110", "latest")) as fh:
            fh.attrs["impactid_format"] = FORMAT_NAME
            fh.attrs["format_version"] = FORMAT_VERSION
            fh.attrs["provenance"] = json.dumps(list(recording.provenance) + [f"write_hdf5({path})"])
            signals = fh.create_group("signals")
            signals.attrs["sample_rate_hz"] = recording.sample_rate_hz
            signals.attrs["start_time_s"] = recording.start_time_s
            for name, data in recording.channels.items():
                ds = signals.create_dataset(name, data=data, compression=compression)
                ds.attrs["units"] = recording.units[name]
            if recording.rig is not None:
                rig_group = fh.create_group("rig")
                rig_group.attrs["model"] = recording.rig.model
                for key, value in recording.rig.to_dict().items():
                    rig_group.attrs[key] = float(value)
            op = fh.create_group("operating")
            for key, value in recording.operating.items():
                op.attrs[key] = float(value)
            if truth is not None:
                _write_group_tree(fh.create_group("truth"), truth)

    return atomic_write(path, write, protect=[recording.source])


# ---------------------------------------------------------------------------------------------
# CSV + TOML
# ---------------------------------------------------------------------------------------------

#: Largest deviation of a CSV time stamp from the uniform grid, as a fraction of the sample
#: interval, accepted as rounding of the printed times (a 204.8 kHz recording printed with 9
#: significant digits deviates by up to about 0.2 %).
CSV_TIME_TOLERANCE = 0.05


#: pandas before 3.1 parses decimal floats with a fast routine that can be off by up to about 2000
#: units in the last place (0.8216181435011584 read as ...582); ``float_precision="round_trip"``
#: makes it exact, and 3.1, where that parser is the default, deprecates the option. A CSV written
#: with ``repr`` precision then reads back bit for bit on every supported pandas.
def _exact_floats(pandas_version: str) -> dict[str, str]:
    """The ``pd.read_csv`` option that parses floats exactly with this pandas (none from 3.1)."""
    major_minor = tuple(int(part) for part in pandas_version.split(".")[:2] if part.isdigit())
    return {} if major_minor >= (3, 1) else {"float_precision": "round_trip"}


def read_csv(path: str | os.PathLike[str], rig: Any = None, *, channels: Sequence[str] | None = None) -> Recording:
    """Read a CSV recording (a ``time_s`` column and channel columns, SI units) plus its rig.

    Parameters
    ----------
    rig : a rig dataclass or a TOML rig file (``[rig]``, ``[operating]``). If omitted, a TOML file
        next to the CSV with the same stem (``run1.csv`` -> ``run1.toml``) is used.
    channels : the channel columns to keep (:func:`select_channels`; None: all). The text is parsed
        whole; the other columns are dropped before their conversion and checks.

    The file is UTF-8 text; a byte-order mark is skipped, and a trailing comma on every line (an
    empty last column without a name) is ignored (docs/formats.md).
    """
    import pandas as pd

    path = Path(path)
    where = str(path)
    wanted = None if channels is None else tuple(channels)
    _check_path(path)
    footprint = recording_footprint(path)
    if footprint is not None:
        _refuse_if_too_large([(where, footprint)], "read")
    header = _check_csv_header(path)
    try:
        with warnings.catch_warnings():
            # pandas only warns when a row has more fields than the header: make it an error
            warnings.simplefilter("error", pd.errors.ParserWarning)
            # (a UTF-8 byte-order mark is skipped; a trailing comma on every data row is dropped by
            # index_col=False, and pandas warns when the extra field holds a value)
            frame = pd.read_csv(path, comment="#", skipinitialspace=True, index_col=False, on_bad_lines="error",
                                **_exact_floats(pd.__version__))
    except pd.errors.ParserWarning:
        raise RecordingError(f"{where}: malformed CSV: rows have a value after the last of the header's "
                             f"{len(header)} columns") from None
    except UnicodeDecodeError:
        raise RecordingError(_not_utf8(path)) from None
    except PermissionError:
        raise RecordingError(f"{where}: cannot read file (permission denied)") from None
    except pd.errors.ParserError as exc:
        fields = re.search(r"Expected (\d+) fields in line (\d+), saw (\d+)", str(exc))
        if fields:
            expected, line, saw = fields.groups()
            raise RecordingError(f"{where}: malformed CSV: line {line} has {saw} fields, the lines before it "
                                 f"{expected} (a trailing comma or a value after the last column on some rows "
                                 "only?)") from None
        raise RecordingError(f"{where}: malformed CSV ({type(exc).__name__}: {' '.join(str(exc).split())})") from None
    except (pd.errors.EmptyDataError, ValueError, OSError) as exc:
        raise RecordingError(f"{where}: malformed CSV ({type(exc).__name__}: {exc})") from None
    frame = _drop_unnamed_trailing_column(where, frame, header)
    frame.columns = [str(c).strip() for c in frame.columns]
    if "time_s" not in frame.columns:
        raise RecordingError(f"{where}: malformed CSV: no 'time_s' column (columns: {', '.join(frame.columns)})")
    if len(frame.columns) != len(set(frame.columns)):
        raise RecordingError(f"{where}: malformed CSV: duplicate column names")
    if len(frame) < 2:
        raise RecordingError(f"{where}: malformed CSV: fewer than two samples")
    if wanted is not None:
        names = [c for c in frame.columns if c != "time_s"]
        if names:
            frame = frame[["time_s"] + [names[k] for k in select_channels(where, names, wanted)]]
    columns: dict[str, np.ndarray] = {}
    for name in frame.columns:
        column = frame[name]
        if column.dtype.kind not in "fiu":
            values = pd.to_numeric(column, errors="coerce").to_numpy(dtype=float)
            text = column.astype(str).str.strip().str.lower()
            bad = np.isnan(values) & column.notna().to_numpy() & ~text.isin(["nan", "inf", "-inf", "+inf"]).to_numpy()
            if bad.any():
                row = int(np.argmax(bad))
                raise RecordingError(
                    f"{where}: malformed CSV: column {name!r} row {row + 2} is not a number ({column.iloc[row]!r})")
        columns[name] = column.to_numpy(dtype=float) if column.dtype.kind in "fiu" else values
    time = columns.pop("time_s")
    if not np.all(np.isfinite(time)):
        raise RecordingError(f"{where}: column 'time_s' has NaN or Inf values")
    if not columns:
        raise RecordingError(f"{where}: malformed CSV: no channel columns besides 'time_s'")
    n = time.size
    if not np.all(np.diff(time) > 0.0):
        raise RecordingError(f"{where}: time column 'time_s' is not increasing")
    # sample interval by least squares over all samples: printed times are rounded, and the fit
    # averages the rounding instead of trusting the first and last stamps
    k = np.arange(n) - 0.5 * (n - 1)
    dt = float(np.dot(k, time - time.mean()) / np.dot(k, k))
    if not dt > 0.0:
        raise RecordingError(f"{where}: time column 'time_s' is not increasing")
    deviation = np.abs(time - time.mean() - k * dt)
    worst = int(np.argmax(deviation))
    if deviation[worst] > CSV_TIME_TOLERANCE * dt:
        raise RecordingError(
            f"{where}: time column 'time_s' is not uniform: sample {worst} at {time[worst]!r} s is "
            f"{deviation[worst] / dt:.3g} sample intervals off the grid of {dt!r} s")
    rate = 1.0 / dt
    check_time_base(where, rate, float(time[0]), n, rate_name="the sample rate of column 'time_s' (1 / interval)",
                    start_name="column 'time_s' (first time)")
    if rig is None:
        sibling = path.with_suffix(".toml")
        if not sibling.exists() and not sibling.is_symlink():  # a dangling link is reported by the reader
            raise RecordingError(f"{where}: a CSV recording needs a rig file (--rig RIG.toml, or {sibling.name} "
                                 "next to it)")
        rig = sibling
    recording_rig, operating, rig_note = _resolve_rig(rig)
    channels, units, notes = {}, {}, []
    for name, data in columns.items():
        data, unit, note = _to_si(where, name, (channel_spec(name) or ("",))[0], data)
        channels[name], units[name] = _frozen(data), unit
        if note:
            notes.append(note)
    if recording_rig is not None and getattr(recording_rig, "e", None) is not None:
        operating.setdefault("eccentricity_m", recording_rig.e)
    if "cam_speed_hz" in operating and isinstance(rig, (str, os.PathLike)):
        check_cam_speed(where, operating["cam_speed_hz"], rate, name=f"rig file {rig} [operating] cam_speed_hz")
    return Recording(channels=channels, sample_rate_hz=rate, units=units, rig=recording_rig, operating=operating,
                     start_time_s=float(time[0]), source=where,
                     provenance=(f"read_csv({where})", rig_note, *notes))


def _check_csv_header(path: Path) -> list[str]:
    """The header's column names, stripped (empty when the file has no header line).

    Refuses duplicated column names (pandas would rename the second ``a`` to ``a.1`` silently) and
    text that is not UTF-8 (naming the line and the byte). A UTF-8 byte-order mark is skipped.
    """
    import csv

    try:
        with path.open("r", encoding="utf-8-sig", newline="") as fh:
            for line in fh:
                if line.strip() and not line.lstrip().startswith("#"):
                    header = [c.strip() for c in next(csv.reader([line]))]
                    break
            else:
                return []
    except UnicodeDecodeError:
        raise RecordingError(_not_utf8(path)) from None
    except (OSError, csv.Error):
        return []  # reported by the reader itself
    seen: set[str] = set()
    twice = sorted({c for c in header if c and (c in seen or seen.add(c))})
    if twice:
        raise RecordingError(f"{path}: malformed CSV: duplicate column name(s) {', '.join(map(repr, twice))}")
    return header


def _not_utf8(path: Path) -> str:
    """The message for a CSV file that is not UTF-8 text: the first line and byte that are not."""
    try:
        with path.open("rb") as fh:
            for number, line in enumerate(fh, 1):
                try:
                    line.decode("utf-8")
                except UnicodeDecodeError as exc:
                    header = number == 1 and not line.lstrip().startswith(b"#")
                    return (f"{path}: not UTF-8 text: byte 0x{line[exc.start]:02x} at line {number}, column "
                            f"{exc.start + 1}{' (the header)' if header else ''}; a CSV recording must be "
                            "saved as UTF-8 (plain ASCII is UTF-8)")
    except OSError:
        pass
    return f"{path}: not UTF-8 text; a CSV recording must be saved as UTF-8"


def _drop_unnamed_trailing_column(where: str, frame, header: list[str]):
    """Drop the empty column a trailing comma on the header line makes (no name, no value); refuse
    any other column without a name."""
    if len(header) != len(frame.columns):
        return frame
    for position, name in enumerate(header):
        if name:
            continue
        empty = bool(frame.iloc[:, position].isna().all())
        if position == len(header) - 1 and empty:
            return frame.iloc[:, :position]
        raise RecordingError(f"{where}: malformed CSV: column {position + 1} has no name in the header"
                             f"{'' if empty else ' but holds values'}")
    return frame


def write_csv(recording: Recording, path: str | os.PathLike[str], rig_path: str | os.PathLike[str] | None = None,
              ) -> tuple[Path, Path]:
    """Write a recording as CSV (``time_s`` + channels, 17 significant digits) and its TOML rig file.

    The rig file defaults to the CSV path with suffix ``.toml``. Both are written atomically.
    """
    path = Path(path)
    rig_path = Path(rig_path) if rig_path is not None else path.with_suffix(".toml")
    if recording.rig is None:
        raise RecordingError(f"{path}: cannot write a CSV recording without a rig")
    names = list(recording.channels)
    table = np.column_stack([recording.time] + [recording.channels[n] for n in names])

    def write(tmp: Path) -> None:
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(",".join(["time_s"] + names) + "\n")
            np.savetxt(fh, table, delimiter=",", fmt="%.17g")

    with StagedFiles(protect=[recording.source]) as staged:  # the CSV and its rig file together
        staged.write_with(path, write)
        staged.write_text(rig_path, recording.rig.to_toml(dict(recording.operating)))
    return path, rig_path


# ---------------------------------------------------------------------------------------------
# dispatch
# ---------------------------------------------------------------------------------------------

_HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"


def read_recording(path: str | os.PathLike[str], rig: Any = None, *, check: bool = True,
                   channels: Sequence[str] | None = None) -> Recording:
    """Read a recording, choosing the reader by file type (HDF5 signature or ``.csv`` suffix).

    Parameters
    ----------
    rig : optional rig dataclass or TOML rig file that supplies or overrides the file's rig.
    check : run :meth:`Recording.check` (warnings for clipped or very short recordings).
    channels : the channels a job needs (:func:`select_channels`; None: all): only those are read.
    """
    path = Path(path)
    _check_path(path)
    try:
        with path.open("rb") as fh:
            head = fh.read(8)
    except PermissionError:
        raise RecordingError(f"{path}: cannot read file (permission denied)") from None
    except OSError as exc:
        raise RecordingError(f"{path}: cannot read file ({exc.strerror})") from None
    if head == _HDF5_SIGNATURE or path.suffix.lower() in (".h5", ".hdf5", ".hdf"):
        recording = read_hdf5(path, rig=rig, channels=channels)
    elif path.suffix.lower() in (".csv", ".txt"):
        recording = read_csv(path, rig=rig, channels=channels)
    else:
        raise RecordingError(f"{path}: unknown recording type (expected HDF5 .h5 or .csv)")
    if check:
        recording.check()
    return recording

"""The measurement model of the single-impact test rig: a recording to per-impact observations.

:func:`measure_impacts` reads the accelerometer (``impactor_acceleration``, the specific force
``F/m``) and/or the load cell (``contact_force``, ``F``) of one drop and returns, for each impact
(contact phase that ends in a separation), its onset and end, contact duration, peak force, impulse,
approach and separation speeds, and the window of samples the fit uses. All array work is
vectorised (run detection with ``numpy.diff``, sums and fits over slices); the Python loop runs over
impacts, not samples.

Steps
-----
1. **Candidates**: runs of the detection signal (the acceleration, or the force divided by the
   mass) above 5 % of its peak.
2. **Baseline and noise**, from the free flight (samples before the first candidate and between
   candidates, each at least a guard of the longest candidate away): per channel a straight line
   (an offset and a drift) fitted by least squares and removed, and the noise standard deviation
   ``1.4826 MAD(diff) / sqrt(2)`` of the consecutive free samples (insensitive to what is left of an
   offset or a drift).
3. **Impacts**: runs above ``max(5 sigma, 1e-3 peak)`` that contain a candidate's peak. An impact is
   kept if it ends in a flight (the signal stays below the threshold for a while before the next
   impact or the recording's end), its peak is ``snr_min`` noise standard deviations or more, and the
   flight before it is consistent with its neighbours' speeds (below); the sequence is cut at the
   first impact that fails, so that the impactor's final rest on the contact (whose ringing can
   cross the threshold) is never taken for an impact.
4. **Onset and end**: a line fitted to ``signal^(1/p)`` on the rising (falling) edge between 5 % and
   40 % of the impact's peak and extrapolated to zero: exact for the elastic start of a Hertz
   contact (``F ~ t^p``), a starting value the fit refines otherwise.
5. **Speeds** (positive magnitudes; ``x`` points into the contact): the impulse ``I = int a dt``
   (acceleration units) changes the velocity by ``g T - I`` over the contact of duration ``T``, so
   the separation speed is ``I - g T - v_in``. The approach speed of the first impact comes from the
   drop (``/operating`` ``drop_height_m`` and ``release_speed_m_s``: ``sqrt(v0^2 + 2 g h)``), of later
   impacts from the flight time before them (``g T_flight / 2``, independent of the accelerometer's
   calibration); without the drop, from the impulse and the flight after it. The flight before an
   impact must agree with the separation speed of the impact before it within 15 %.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from impactid.errors import ImpactidError
from impactid.rigs.drop.parameters import ACCELERATION_CHANNEL, FORCE_CHANNEL, DropRig
from impactid.signal import true_runs

__all__ = ["CANDIDATE_LEVEL", "FLIGHT_TOLERANCE", "ImpactObservations", "MeasurementError", "NOISE_FLOOR",
           "measure_impacts"]

#: Candidate impacts: runs above this fraction of the detection signal's peak.
CANDIDATE_LEVEL = 0.05
#: Threshold of an impact's extent: this many noise standard deviations ...
THRESHOLD_SIGMAS = 5.0
#: ... and at least this fraction of the peak.
THRESHOLD_FRACTION = 1e-3
#: Relative disagreement of a flight time with the speeds around it beyond which the sequence is cut.
FLIGHT_TOLERANCE = 0.15
#: Noise floor of a channel as a fraction of its peak: the accuracy of the simulated signal at the fit's
#: tolerances (a noise-free channel is weighted and checked against this).
NOISE_FLOOR = 1e-6
#: Edges of the onset and end fits, as fractions of an impact's peak.
EDGE_RANGE = (0.05, 0.4)
#: Samples (at least; a quarter of the impact's length if more) an edge fit may reach beyond the samples
#: above the threshold.
EDGE_REACH = 8
#: Restitution assumed for a first starting speed when neither the drop nor a following flight gives it.
ASSUMED_RESTITUTION = 0.8
_MIN_FREE_SAMPLES = 32


class MeasurementError(ImpactidError, ValueError):
    """A recording from which no drop impact can be measured (the message names the file and the channel)."""


@dataclass(frozen=True)
class ImpactObservations:
    """What :func:`measure_impacts` measured in one recording.

    Attributes
    ----------
    source : the recording's file ("recording" if built in memory).
    rig : the drop rig (mass, ``p``, gravity are used; ``k`` never is).
    sample_rate_hz, start_time_s : the time base (sample ``i`` at ``start_time_s + i / sample_rate_hz``).
    signals : the channels with their baseline (offset and drift) removed, SI units.
    noise : noise standard deviation of each channel [SI] between impacts (0 for a noise-free channel).
    baseline : per channel ``(offset, drift)`` removed [unit, unit/s] (at the first sample).
    impacts : one row per impact kept, in time order (columns in :func:`measure_impacts`).
    notes : what qualifies the measurement (impacts dropped and why, ...).
    operating : the recording's operating point.
    """

    source: str
    rig: DropRig
    sample_rate_hz: float
    start_time_s: float
    signals: Mapping[str, np.ndarray]
    noise: Mapping[str, float]
    baseline: Mapping[str, tuple[float, float]]
    impacts: pd.DataFrame
    notes: tuple[str, ...] = ()
    operating: Mapping[str, float] = field(default_factory=dict)

    @property
    def channels(self) -> tuple[str, ...]:
        return tuple(self.signals)

    def time(self, first: int, stop: int) -> np.ndarray:
        """Times [s] of samples ``first .. stop-1``."""
        return self.start_time_s + np.arange(first, stop) / self.sample_rate_hz

    def noise_weight(self, channel: str) -> float:
        """The noise standard deviation the fit weights ``channel`` with: the measured one, at least
        :data:`NOISE_FLOOR` times the channel's peak."""
        peak = float(np.max(np.abs(self.signals[channel])))
        return max(self.noise[channel], NOISE_FLOOR * peak)


def _segments_mask(n: int, starts: np.ndarray, stops: np.ndarray) -> np.ndarray:
    """Boolean mask of the union of ``[starts, stops)`` (clipped to ``[0, n)``; empty ones ignored)."""
    starts = np.clip(starts, 0, n)
    stops = np.clip(stops, 0, n)
    keep = stops > starts
    marks = np.zeros(n + 1, dtype=np.int64)
    np.add.at(marks, starts[keep], 1)
    np.add.at(marks, stops[keep], -1)
    return np.cumsum(marks[:-1]) > 0


def _edge_zero(t: np.ndarray, y: np.ndarray, p: float) -> float:
    """Where a line fitted to ``y^(1/p)`` against ``t`` reaches 0 (NaN with fewer than two points)."""
    if t.size < 2:
        return math.nan
    slope, intercept = np.polyfit(t, np.power(y, 1.0 / p), 1)
    return -intercept / slope if slope != 0.0 else math.nan


def measure_impacts(recording, *, rig: DropRig | None = None, detect: str | None = None, snr_min: float = 20.0,
                    max_impacts: int | None = None, window_pad: int = 3) -> ImpactObservations:
    """Find the impacts of one drop recording and measure them.

    Parameters
    ----------
    recording : a :class:`~impactid.io.Recording` with ``impactor_acceleration`` and/or ``contact_force``.
    rig : the drop rig (default: the recording's); its mass, ``p`` and gravity are used.
    detect : the channel the impacts are found in (default: the acceleration if present).
    snr_min : smallest peak, in noise standard deviations, of an impact kept.
    max_impacts : keep at most this many (the first ones).
    window_pad : samples before the onset and after the end in each impact's fit window.

    Returns
    -------
    :class:`ImpactObservations`; its ``impacts`` table has the columns ``impact``, ``first_sample``,
    ``stop_sample`` (the extent above the threshold), ``window_start``, ``window_stop`` (the fit
    window, stop exclusive), ``onset_time_s``, ``end_time_s``, ``contact_duration_s``,
    ``peak_acceleration_m_s2``, ``peak_force_n``, ``impulse_m_s``, ``approach_speed_m_s``,
    ``approach_speed_from``, ``separation_speed_m_s``, ``flight_time_after_s``, ``restitution``,
    ``snr``.

    Raises
    ------
    MeasurementError
        naming the file and the channel: no drop rig, no usable channel, no impact, too little
        free flight to measure the noise, no impact that ends in a separation.
    """
    where = recording.source or "recording"
    rig = rig if rig is not None else recording.rig
    if not isinstance(rig, DropRig):
        got = getattr(rig, "model", None)
        raise MeasurementError(f"{where}: needs a 'drop-impact' rig (the recording's rig is {got!r}; pass a rig "
                               "file)")
    present = [c for c in (ACCELERATION_CHANNEL, FORCE_CHANNEL) if c in recording.channels]
    if not present:
        raise MeasurementError(f"{where}: has neither an {ACCELERATION_CHANNEL!r} nor a {FORCE_CHANNEL!r} channel "
                               f"(it has {', '.join(recording.channels)})")
    detect = present[0] if detect is None else detect
    if detect not in present:
        raise MeasurementError(f"{where}: no channel {detect!r} to find the impacts in (it has "
                               f"{', '.join(recording.channels)})")
    if not (math.isfinite(snr_min) and snr_min > 0.0):
        raise MeasurementError(f"snr_min must be positive, got {snr_min!r}")
    fs = recording.sample_rate_hz
    dt = 1.0 / fs
    n = recording.n_samples
    m, p, g = rig.mass, rig.p, rig.gravity
    scale = {ACCELERATION_CHANNEL: 1.0, FORCE_CHANNEL: 1.0 / m}  # to acceleration units (F/m)
    raw = {c: np.asarray(recording.channel(c), dtype=float) for c in present}
    notes: list[str] = []
    # ---- 1. candidates -------------------------------------------------------------------------
    det = raw[detect] * scale[detect]
    peak = float(det.max())
    if not peak > 0.0:
        raise MeasurementError(f"{where}: channel {detect!r} is never positive (largest {peak:.6g}): no impact "
                               "(is the sign convention compressive-positive, away from the contact?)")
    hi_starts, hi_stops = true_runs(det > CANDIDATE_LEVEL * peak)
    # ---- 2. baseline and noise from the free flight ------------------------------------------------
    guard = max(8, int((hi_stops - hi_starts).max()))
    seg_starts = np.concatenate([[0], hi_stops[:-1] + guard])  # before the first candidate, and between them
    seg_stops = hi_starts - guard
    free = _segments_mask(n, seg_starts, seg_stops)
    if free.sum() < _MIN_FREE_SAMPLES:
        raise MeasurementError(f"{where}: channel {detect!r}: only {int(free.sum())} samples of free flight before "
                               f"and between the impacts (need {_MIN_FREE_SAMPLES}) to measure the noise and the "
                               "baseline: record a pre-trigger before the first impact")
    t_rel = np.arange(n) * dt
    pairs = free[:-1] & free[1:]
    signals: dict[str, np.ndarray] = {}
    noise: dict[str, float] = {}
    baseline: dict[str, tuple[float, float]] = {}
    design = np.column_stack([np.ones(int(free.sum())), t_rel[free]])
    for c in present:
        coef, *_ = np.linalg.lstsq(design, raw[c][free], rcond=None)
        signals[c] = raw[c] - (coef[0] + coef[1] * t_rel)
        diffs = np.diff(raw[c])[pairs]
        noise[c] = float(1.4826 * np.median(np.abs(diffs - np.median(diffs))) / math.sqrt(2.0))
        baseline[c] = (float(coef[0]), float(coef[1]))
    # ---- 3. impacts ------------------------------------------------------------------------------
    det = signals[detect] * scale[detect]
    sigma = noise[detect] * scale[detect]
    threshold = max(THRESHOLD_SIGMAS * sigma, THRESHOLD_FRACTION * peak)
    starts, stops = true_runs(det > threshold)
    hi_peaks = np.array([a + int(np.argmax(det[a:b])) for a, b in zip(hi_starts, hi_stops)])
    which = np.searchsorted(starts, hi_peaks, side="right") - 1
    which = np.unique(which[(which >= 0) & (hi_peaks < stops[np.clip(which, 0, None)])])
    starts, stops = starts[which], stops[which]
    next_starts = np.concatenate([starts[1:], [n]])
    rows = []
    cut = False  # the sequence was cut short (a note says why, or max_impacts)
    for i, (a, b) in enumerate(zip(starts, stops)):
        pulse = det[a:b]
        k_peak = a + int(np.argmax(pulse))
        peak_i = float(det[k_peak])
        gap = int(next_starts[i] - b)
        if a == 0:
            notes.append(f"{where}: an impact at the recording's start (sample 0) is left out: its onset is not "
                         "recorded")
            continue
        if gap < max(5, (b - a) // 2):
            reason = ("it does not end before the recording does" if next_starts[i] == n else
                      "the signal does not return to the free-flight level before the next rise")
            notes.append(f"{where}: the contact from t = {recording.start_time_s + a * dt:.6g} s is not a separated "
                         f"impact ({reason}): it and what follows are left out (the impactor's rest on the contact?)")
            cut = True
            break
        snr = peak_i / sigma if sigma > 0.0 else math.inf
        if snr < snr_min:
            notes.append(f"{where}: the impact at t = {recording.start_time_s + a * dt:.6g} s peaks at {snr:.3g} noise "
                         f"standard deviations (< snr_min = {snr_min:g}): it and the later ones are left out")
            cut = True
            break
        t_abs = recording.start_time_s + np.arange(a - 1, b + 1) * dt
        seg = det[a - 1:b + 1]
        lo, hi = EDGE_RANGE
        rising = np.arange(a - 1, k_peak + 1) - (a - 1)
        falling = np.arange(k_peak, b + 1) - (a - 1)
        reach = max(EDGE_REACH, (b - a) // 4) * dt  # how far beyond the run an edge may be extrapolated
        sel = rising[(seg[rising] >= lo * peak_i) & (seg[rising] <= hi * peak_i)]
        onset = _edge_zero(t_abs[sel], seg[sel], p)
        if not (math.isfinite(onset) and t_abs[0] - reach <= onset <= t_abs[k_peak - a + 1]):
            onset = recording.start_time_s + (a - 0.5) * dt
        sel = falling[(seg[falling] >= lo * peak_i) & (seg[falling] <= hi * peak_i)]
        end = _edge_zero(t_abs[sel], seg[sel], p)
        if not (math.isfinite(end) and t_abs[k_peak - a + 1] <= end <= t_abs[-1] + reach):
            end = recording.start_time_s + (b - 0.5) * dt
        # the fit window: from window_pad samples before the onset to window_pad after the end, within
        # the flights around the impact
        first = int(math.floor((onset - recording.start_time_s) * fs))
        last = int(math.ceil((end - recording.start_time_s) * fs))
        w0 = max(min(first, a - 1) - window_pad, int(stops[i - 1]) if i > 0 else 0, 0)
        w1 = min(max(last, b) + window_pad + 1, int(next_starts[i]), n)
        impulse = float(np.sum(det[w0:w1]) * dt)
        peak_force = float(np.max(signals[FORCE_CHANNEL][a:b])) if FORCE_CHANNEL in signals else m * peak_i
        rows.append({"impact": len(rows), "first_sample": int(a), "stop_sample": int(b), "window_start": int(w0),
                     "window_stop": int(w1), "onset_time_s": onset, "end_time_s": end,
                     "contact_duration_s": end - onset, "peak_acceleration_m_s2": peak_i, "peak_force_n": peak_force,
                     "impulse_m_s": impulse, "snr": snr, "gap_after": gap})
        if max_impacts is not None and len(rows) >= max_impacts:
            cut = True
            break
    if rows and not cut:
        # the candidates were all measured: what rises above the noise after them is too small to be one
        last_stop = rows[-1]["stop_sample"]
        small, _ = true_runs(det[last_stop:] > max(threshold, snr_min * sigma))
        if small.size:
            notes.append(f"{where}: {small.size} contact(s) after t = {recording.start_time_s + last_stop * dt:.6g} s "
                         f"below {100 * CANDIDATE_LEVEL:g} % of the largest peak are not measured (small bounces, the "
                         "final rest on the contact)")
    if not rows:
        raise MeasurementError(f"{where}: channel {detect!r}: no impact that ends in a separation was found "
                               + ("(" + "; ".join(notes) + ")" if notes else ""))
    table = pd.DataFrame(rows)
    # ---- 5. speeds -------------------------------------------------------------------------------
    onset = table["onset_time_s"].to_numpy()
    end = table["end_time_s"].to_numpy()
    duration = end - onset
    impulse = table["impulse_m_s"].to_numpy()
    flight_after = np.append(onset[1:] - end[:-1], np.nan)
    count = len(table)
    approach = np.full(count, np.nan)
    source = [""] * count
    height = recording.operating.get("drop_height_m")
    release = recording.operating.get("release_speed_m_s", 0.0)
    if height is not None and rig.impact_speed(height, release) > 0.0:
        approach[0] = rig.impact_speed(height, release)
        source[0] = "drop height"
    elif count > 1 and g > 0.0:
        approach[0] = impulse[0] - g * duration[0] - 0.5 * g * flight_after[0]
        source[0] = "impulse and the next flight"
    else:
        approach[0] = (impulse[0] - g * duration[0]) / (1.0 + ASSUMED_RESTITUTION)
        source[0] = f"impulse, restitution {ASSUMED_RESTITUTION:g} assumed"
        notes.append(f"{where}: no drop height (/operating drop_height_m) and no second impact: the first impact's "
                     f"starting speed assumes a restitution of {ASSUMED_RESTITUTION:g}")
    separation = np.full(count, np.nan)
    kept = count
    for i in range(count):
        separation[i] = impulse[i] - g * duration[i] - approach[i]
        if i + 1 < count:
            if g > 0.0:
                approach[i + 1] = 0.5 * g * flight_after[i]
                source[i + 1] = "flight time"
                if abs(approach[i + 1] - separation[i]) > FLIGHT_TOLERANCE * approach[i + 1]:
                    notes.append(f"{where}: the flight after impact {i} ({flight_after[i]:.6g} s, "
                                 f"{approach[i + 1]:.4g} m/s) disagrees with its separation speed from the "
                                 f"accelerometer ({separation[i]:.4g} m/s) by more than {100 * FLIGHT_TOLERANCE:g} %: "
                                 "the later impacts are left out")
                    kept = i + 1
                    break
            else:
                approach[i + 1] = separation[i]
                source[i + 1] = "separation speed"
    table = table.iloc[:kept].copy()
    table["approach_speed_m_s"] = approach[:kept]
    table["approach_speed_from"] = source[:kept]
    table["separation_speed_m_s"] = separation[:kept]
    table["flight_time_after_s"] = flight_after[:kept]
    with np.errstate(invalid="ignore", divide="ignore"):
        table["restitution"] = separation[:kept] / approach[:kept]
    bad = ~(table["approach_speed_m_s"].to_numpy() > 0.0)
    if bad.any():
        raise MeasurementError(f"{where}: channel {detect!r}: impact {int(np.flatnonzero(bad)[0])} has no positive "
                               "approach speed (check the drop height and the channel's scale and sign)")
    table = table.drop(columns=["gap_after"]).reset_index(drop=True)
    for c in present:
        off, drift = baseline[c]
        if off != 0.0 or drift != 0.0:
            unit = "m/s^2" if c == ACCELERATION_CHANNEL else "N"
            if abs(off) > 0.0 and (noise[c] == 0.0 or abs(off) > noise[c] or abs(drift) * n * dt > noise[c]):
                notes.append(f"{where}: channel {c!r}: baseline {off:.4g} {unit} + {drift:.4g} {unit}/s removed "
                             "(fitted to the free flight)")
    return ImpactObservations(source=where, rig=rig, sample_rate_hz=fs, start_time_s=recording.start_time_s,
                              signals=signals, noise=noise, baseline=baseline, impacts=table, notes=tuple(notes),
                              operating=dict(recording.operating))

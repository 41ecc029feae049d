"""Impact clicks in audio: band-pass, energy envelope, a threshold from the noise floor, a
refractory period from the physics of the bouncing, sub-sample onset times and a confidence.

Steps (:func:`detect_onsets`):

1. **Band-pass** every channel (4th-order Butterworth, zero phase) to ``band``, default 0.8 kHz to
   min(12 kHz, 0.45 fs): the click of a ball on a floor rings at a few kHz (the ball's shell and the
   floor's local modes), speech, footsteps and hum lie below.
2. **Energy envelope**: the band-passed power summed over the channels (so that a stereo recording
   whose channels differ in gain or sign still adds up), averaged over ``window`` (0.25 ms), square
   root: an RMS envelope in full-scale units.
3. **Threshold from the noise floor**: the envelope's median and its median absolute deviation (the
   clicks occupy a few per cent of the recording, so both describe the background); the threshold
   is ``median + k * 1.4826 MAD`` with ``k = threshold_sigma`` (8), and never below
   ``k`` times the quantisation step of the file. No amplitude is fixed.
4. **Candidates**: the stretches where the envelope exceeds the threshold (stretches closer than
   one window are one); each has a peak.
5. **Onset time**: constant-fraction timing, as in nuclear-pulse electronics: the last upward
   crossing of ``fraction`` (20 %) of the peak before the peak, interpolated linearly between
   samples. For clicks of one shape this time is independent of the click's loudness; its offset
   from the true contact (a fraction of a millisecond) is the same for every click of a ball and
   cancels in the intervals.
6. **Refractory period from the physics**: the click's sound pressure grows with the impact speed
   (``A ~ v``, linear acoustics) and so does the flight that ends in it (``T = 2 v / g`` without
   drag, the same ratio ``T / A`` along a drop), so the shortest flight the ball can have before its
   click is lost in the noise is ``T_min = c * threshold`` with ``c`` the median of ``T_k / A_k``
   over consecutive candidates (flight before the click over the click's peak). Candidates closer
   than ``max(T_min / 2, ring-down)`` to a louder earlier one are the same impact's ring-down or
   echo: the half allows for the click-to-click scatter of amplitude (spin, where the ball lands).
   The ring-down is the median time a click stays above the threshold: no onset can be told apart
   inside it. Echoes later than this survive and are left to the sequence cleaning
   (:mod:`impactid.rigs.ball.sequence`), which knows the flights.
7. **Confidence**: ``1 - threshold / peak``, the fraction of the click's peak above the threshold
   (0 at the threshold, towards 1 for clear clicks).

Timing accuracy measured on synthetic clicks (``tests/rigs/ball/test_onsets.py``,
``docs/bounces.md``): a constant offset, and interval errors of a few microseconds at 44.1 and
48 kHz with background noise 40 dB below the loudest click.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Onsets", "detect_onsets", "envelope"]


@dataclass(frozen=True)
class Onsets:
    """The impact clicks found in one recording.

    Attributes
    ----------
    times : onset times [s], increasing.
    confidence : per onset, in [0, 1]: the fraction of its peak above the threshold.
    peak : per onset, the envelope peak [full scale].
    threshold : detection threshold of the envelope [full scale].
    noise_floor : median of the envelope [full scale].
    refractory : shortest separation of two onsets [s] (see the module notes).
    shortest_flight : ``T_min`` [s], the shortest flight whose click would still be heard (NaN if not
        estimable).
    ring_down : median time a click stays above the threshold [s].
    band : band-pass edges [Hz].
    sample_rate : [Hz].
    envelope : the envelope, decimated to ``envelope_rate`` (for figures).
    envelope_rate : [Hz].
    suppressed : onsets [s] dropped as ring-down or echo of a louder click within the refractory period.
    notes : what qualifies the result.
    """

    times: np.ndarray
    confidence: np.ndarray
    peak: np.ndarray
    threshold: float
    noise_floor: float
    refractory: float
    shortest_flight: float
    ring_down: float
    band: tuple[float, float]
    sample_rate: float
    envelope: np.ndarray = field(repr=False)
    envelope_rate: float = 0.0
    suppressed: np.ndarray = field(default_factory=lambda: np.empty(0))
    notes: tuple[str, ...] = ()

    @property
    def snr_db(self) -> np.ndarray:
        """Peak over noise floor [dB]."""
        return 20.0 * np.log10(self.peak / max(self.noise_floor, 1e-300))

    def describe(self) -> str:
        """One provenance line."""
        return (f"found {self.times.size} impact click(s): band {self.band[0]:.0f}-{self.band[1]:.0f} Hz, "
                f"RMS envelope, threshold {self.threshold:.3g} (noise floor {self.noise_floor:.3g}), "
                f"refractory {1e3 * self.refractory:.3g} ms, constant-fraction onsets"
                + (f"; {self.suppressed.size} ring-down/echo trigger(s) suppressed" if self.suppressed.size else ""))


def envelope(samples: np.ndarray, sample_rate: float, band: tuple[float, float], window: float) -> np.ndarray:
    """RMS envelope [full scale] of the band-passed ``samples`` ((n,) or (n, channels)), summed
    over channels, averaged over ``window`` [s]."""
    from scipy.ndimage import uniform_filter1d
    from scipy.signal import butter, sosfiltfilt

    x = np.asarray(samples, dtype=float)
    if x.ndim == 1:
        x = x[:, None]
    x = x - np.median(x, axis=0)
    sos = butter(4, band, btype="bandpass", fs=sample_rate, output="sos")
    pad = min(x.shape[0] - 1, 3 * int(sample_rate / band[0]) + 12)
    y = sosfiltfilt(sos, x, axis=0, padlen=max(pad, 0))
    power = np.sum(y * y, axis=1)
    width = max(3, int(round(window * sample_rate)))
    return np.sqrt(np.maximum(uniform_filter1d(power, width, mode="nearest"), 0.0))


def detect_onsets(samples: np.ndarray, sample_rate: float, *, band: tuple[float, float] | None = None,
                  window: float = 0.25e-3, threshold_sigma: float = 8.0, fraction: float = 0.2,
                  refractory: float | None = None, quantum: float = 2.0 ** -24,
                  envelope_rate: float = 2000.0) -> Onsets:
    """Find the impact clicks in an audio recording.

    Parameters
    ----------
    samples : (n,) or (n, channels) audio, full scale 1.
    sample_rate : [Hz].
    band : band-pass edges [Hz]; default (800, min(12000, 0.45 fs)).
    window : envelope averaging window [s].
    threshold_sigma : threshold in robust standard deviations of the envelope above its median.
    fraction : constant-fraction level of the onset time (of the click's peak envelope).
    refractory : shortest separation of two onsets [s]; default from the physics (module notes).
    quantum : quantisation step of the samples (full scale 1): the threshold is at least
        ``threshold_sigma`` of them.
    envelope_rate : rate [Hz] of the decimated envelope kept for figures.

    Returns
    -------
    Onsets
    """
    fs = float(sample_rate)
    if not (math.isfinite(fs) and fs > 0):
        raise ValueError(f"sample_rate must be positive, got {sample_rate!r}")
    if band is None:
        band = (800.0, min(12000.0, 0.45 * fs))
    lo, hi = float(band[0]), float(band[1])
    if not (0.0 < lo < hi < 0.5 * fs):
        raise ValueError(f"band must satisfy 0 < low < high < fs/2 = {0.5 * fs:g} Hz, got {band!r}")
    if not 0.0 < fraction < 1.0:
        raise ValueError(f"fraction must lie in (0, 1), got {fraction!r}")
    env = envelope(samples, fs, (lo, hi), window)
    n = env.size
    median = float(np.median(env))
    mad = float(np.median(np.abs(env - median)))
    threshold = max(median + threshold_sigma * 1.4826 * mad, threshold_sigma * quantum)
    notes: list[str] = []

    above = env > threshold
    gap = max(3, int(round(window * fs)))
    starts, ends = _runs(above, gap)
    peaks = np.array([s + int(np.argmax(env[s:e])) for s, e in zip(starts, ends)], dtype=int)
    peak_values = env[peaks] if peaks.size else np.empty(0)
    onset = np.array([_constant_fraction(env, s, p, fraction) for s, p in zip(starts, peaks)]) / fs
    durations = (ends - starts) / fs
    ring_down = float(np.median(durations)) if durations.size else 0.0

    shortest = math.nan
    if refractory is None:
        if onset.size >= 3:
            flights = np.diff(onset)
            ratio = flights / peak_values[1:]  # flight before each click over that click's peak
            shortest = float(np.median(ratio) * threshold)
        refractory = max(0.5 * shortest if math.isfinite(shortest) else 0.0, ring_down)
    keep, suppressed = _apply_refractory(onset, peak_values, float(refractory))
    times, peak_values = onset[keep], peak_values[keep]
    confidence = np.clip(1.0 - threshold / np.maximum(peak_values, 1e-300), 0.0, 1.0)
    if times.size and np.max(peak_values) < 4.0 * threshold:
        notes.append("the loudest click is less than 4 times the detection threshold: onsets are uncertain")
    step = max(1, int(round(fs / envelope_rate)))
    decimated = env[: (n // step) * step].reshape(-1, step).max(axis=1) if n >= step else env.copy()
    return Onsets(times=times, confidence=confidence, peak=peak_values, threshold=float(threshold),
                  noise_floor=median, refractory=float(refractory), shortest_flight=shortest, ring_down=ring_down,
                  band=(lo, hi), sample_rate=fs, envelope=decimated, envelope_rate=fs / step,
                  suppressed=onset[suppressed], notes=tuple(notes))


def _runs(mask: np.ndarray, gap: int) -> tuple[np.ndarray, np.ndarray]:
    """Start and end (exclusive) indices of the True stretches of ``mask``, merging stretches
    separated by fewer than ``gap`` samples."""
    if not mask.any():
        return np.empty(0, dtype=int), np.empty(0, dtype=int)
    d = np.diff(mask.astype(np.int8), prepend=0, append=0)
    starts = np.flatnonzero(d == 1)
    ends = np.flatnonzero(d == -1)
    keep_s, keep_e = [starts[0]], [ends[0]]
    for s, e in zip(starts[1:], ends[1:]):
        if s - keep_e[-1] < gap:
            keep_e[-1] = e
        else:
            keep_s.append(s)
            keep_e.append(e)
    return np.array(keep_s), np.array(keep_e)


def _constant_fraction(env: np.ndarray, start: int, peak: int, fraction: float) -> float:
    """Sub-sample index of the last upward crossing of ``fraction * env[peak]`` before ``peak``."""
    level = fraction * env[peak]
    lo = max(0, start - int(2 * (peak - start)) - 8)
    seg = env[lo:peak + 1]
    below = np.flatnonzero(seg < level)
    if below.size == 0:
        return float(lo)
    i = lo + int(below[-1])
    a, b = env[i], env[i + 1]
    return i + (level - a) / (b - a) if b != a else float(i)


def _apply_refractory(times: np.ndarray, peaks: np.ndarray, refractory: float) -> tuple[np.ndarray, np.ndarray]:
    """Indices kept and suppressed: within ``refractory`` of the first member of a group, keep the
    earliest candidate whose peak is at least half the group's loudest (a louder direct click wins
    over its echoes; a faint precursor does not win over the click)."""
    keep, suppressed = [], []
    i, n = 0, times.size
    while i < n:
        j = i
        while j + 1 < n and times[j + 1] - times[i] < refractory:
            j += 1
        group = np.arange(i, j + 1)
        loud = peaks[group].max()
        chosen = int(group[np.flatnonzero(peaks[group] >= 0.5 * loud)[0]])
        keep.append(chosen)
        suppressed += [int(g) for g in group if g != chosen]
        i = j + 1
    return np.array(keep, dtype=int), np.array(suppressed, dtype=int)

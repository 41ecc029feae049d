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
4. **Candidates**, with hysteresis (a Schmitt trigger): a click starts when the envelope exceeds
   the threshold and lasts until it falls below a release level (``median + 3 x 1.4826 MAD``), so
   that its ring-down, beating between resonances around the threshold, does not trigger again;
   each candidate has a peak.
5. **Onset time**: constant-fraction timing, as in nuclear-pulse electronics: the last upward
   crossing of ``fraction`` (20 %) of the peak before the peak, interpolated linearly between
   samples. For clicks of one shape this time is independent of the click's loudness; its offset
   from the true contact (a fraction of a millisecond) is the same for every click of a ball and
   cancels in the intervals.
6. **Refractory period from the physics**: the click's sound pressure grows with the impact speed
   (``A ~ v``, linear acoustics) and so does the flight that ends in it (``T = 2 v / g`` without
   drag), so along a drop ``T / A`` is one number ``c``, measured as the median of ``T_k / A_k``
   over the main sequence of clicks (each at least half as loud as the previous main click: a
   bounce loses a few per cent of its speed, an echo is much weaker than its click). Hence:

   * the shortest flight the ball can have before its click is lost in the noise is
     ``T_min = c * threshold``; the refractory period is ``max(T_min / 2, ring-down)``, the half
     allowing for the click-to-click scatter of loudness (spin, where the ball lands), the
     ring-down being the median time a click stays above the threshold (no onset can be told apart
     inside it);
   * a click of peak ``A`` ends a flight of about ``c A``: a candidate that follows a louder click
     sooner than ``c A / 2`` is too loud for so short a flight - an echo (a delayed, attenuated
     copy) or the click's ring-down - and is suppressed.

   Whatever survives (spurious sounds, echoes weaker than the noise would let us judge) is left
   to the sequence cleaning (:mod:`impactid.rigs.ball.sequence`), which knows the flights.
7. **Confidence**: ``1 - threshold / peak``, the fraction of the click's peak above the threshold
   (0 at the threshold, towards 1 for clear clicks).

Memory: the audio is read block by block (a memory-mapped WAV is never copied whole); each block
is band-passed with a margin on either side long enough for the filter's transients to decay below
1e-13 of the signal, so the envelope is the one a single pass over the whole recording would give;
the envelope itself is kept in single precision. A recording of ``n`` frames needs about
:func:`memory_needed` bytes (8 per frame, plus the blocks).

Timing accuracy measured on synthetic clicks (``tests/rigs/ball/test_onsets.py``,
``docs/bounces.md``): a constant offset, and interval errors of a few microseconds at 44.1 and
48 kHz with background noise 40 dB below the loudest click.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.ndimage import uniform_filter1d
from scipy.signal import butter, sosfiltfilt

from impactid.signal import true_runs

__all__ = ["BLOCK_FRAMES", "DEFAULT_BAND", "Onsets", "detect_onsets", "envelope", "memory_needed", "min_sample_rate"]

#: Frames band-passed at a time (5.5 s at 48 kHz): the working memory of the envelope does not grow
#: with the recording.
BLOCK_FRAMES = 1 << 18
#: Default band-pass [Hz]: from 800 Hz to min(12 kHz, 0.45 fs) (module notes).
DEFAULT_BAND = (800.0, 12000.0)
#: Highest band-pass edge as a fraction of the sample rate (the filter needs room below Nyquist).
_NYQUIST_MARGIN = 0.45


def min_sample_rate(band: tuple[float, float] | None = None) -> float:
    """Lowest sample rate [Hz] the detector can work at: above ``DEFAULT_BAND[0] / 0.45`` (1778 Hz)
    with the default band, whose upper edge ``min(12 kHz, 0.45 fs)`` must lie above its lower edge
    of 800 Hz; above twice the upper edge of a given ``band``."""
    if band is None:
        return DEFAULT_BAND[0] / _NYQUIST_MARGIN
    return 2.0 * float(band[1])


def memory_needed(frames: int, channels: int, itemsize: int = 8) -> int:
    """Bytes :func:`detect_onsets` needs for ``frames`` x ``channels`` samples of ``itemsize`` bytes
    (not counting the samples themselves): the single-precision envelope and, at the same time,
    its copy for the median or its deviations for the MAD, or the threshold mask and its edges
    (8 bytes per frame); a copy of one channel for its median; and the block being filtered (a
    dozen double-precision copies of a block and its margins, each at most a block)."""
    frames, channels = int(frames), int(channels)
    per_frame = max(8 * frames, itemsize * frames)
    blocks = 12 * 8 * channels * min(frames, 3 * BLOCK_FRAMES)
    return per_frame + blocks


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


def _transient_frames(band: tuple[float, float], sample_rate: float, width: int) -> int:
    """Samples after which a transient of the band-pass has decayed below 1e-13 (from its slowest
    pole), plus the averaging window: the margin each block is filtered with (at most a block: a
    band so narrow that its transients outlast a block still decays by e^-30 within one)."""
    _, poles, _ = butter(4, band, btype="bandpass", fs=sample_rate, output="zpk")
    slowest = float(np.max(np.abs(poles))) if poles.size else 0.0
    decay = math.ceil(math.log(1e-13) / math.log(slowest)) if 0.0 < slowest < 1.0 else BLOCK_FRAMES
    return min(max(256, decay + width), BLOCK_FRAMES)


def envelope(samples: np.ndarray, sample_rate: float, band: tuple[float, float], window: float, *,
             scale: float = 1.0, offset: float = 0.0, block_frames: int = BLOCK_FRAMES) -> np.ndarray:
    """RMS envelope [full scale] of the band-passed ``samples`` ((n,) or (n, channels)), summed
    over channels, averaged over ``window`` [s]; single precision.

    ``samples`` may be integers as stored in a file (a memory map): a sample at full scale is
    ``(stored - offset) * scale``. They are band-passed ``block_frames`` at a time, each block with
    a margin in which the filter's transients decay (module notes), so memory does not grow with
    the recording beyond the envelope itself.
    """
    x = samples if getattr(samples, "ndim", 0) else np.asarray(samples)
    if x.ndim == 1:
        x = x[:, None]
    n, channels = x.shape
    scale, offset = float(scale), float(offset)
    centre = np.array([(float(np.median(x[:, j])) - offset) * scale for j in range(channels)])
    sos = butter(4, band, btype="bandpass", fs=sample_rate, output="sos")
    pad = 3 * int(sample_rate / band[0]) + 12
    width = max(3, int(round(window * sample_rate)))
    margin = _transient_frames(band, sample_rate, width)
    block_frames = max(int(block_frames), 1)
    out = np.empty(n, dtype=np.float32)
    for start in range(0, n, block_frames):
        stop = min(n, start + block_frames)
        lo, hi = max(0, start - margin), min(n, stop + margin)
        seg = (np.asarray(x[lo:hi], dtype=float) - offset) * scale - centre
        y = sosfiltfilt(sos, seg, axis=0, padlen=max(min(seg.shape[0] - 1, pad), 0))
        power = np.sum(y * y, axis=1)
        smooth = uniform_filter1d(power, width, mode="nearest")
        out[start:stop] = np.sqrt(np.maximum(smooth[start - lo:stop - lo], 0.0))
    return out


def detect_onsets(samples: np.ndarray, sample_rate: float, *, band: tuple[float, float] | None = None,
                  window: float = 0.25e-3, threshold_sigma: float = 8.0, release_sigma: float = 3.0,
                  fraction: float = 0.2,
                  refractory: float | None = None, quantum: float = 2.0 ** -24,
                  envelope_rate: float = 2000.0, scale: float = 1.0, offset: float = 0.0) -> Onsets:
    """Find the impact clicks in an audio recording.

    Parameters
    ----------
    samples : (n,) or (n, channels) audio, full scale 1.
    sample_rate : [Hz].
    band : band-pass edges [Hz]; default (800, min(12000, 0.45 fs)).
    window : envelope averaging window [s].
    threshold_sigma : threshold in robust standard deviations of the envelope above its median.
    release_sigma : release level of the hysteresis, in the same units: a click lasts until the
        envelope falls below it.
    fraction : constant-fraction level of the onset time (of the click's peak envelope).
    refractory : shortest separation of two onsets [s]; default from the physics (module notes).
    quantum : quantisation step of the samples (full scale 1): the threshold is at least
        ``threshold_sigma`` of them.
    envelope_rate : rate [Hz] of the decimated envelope kept for figures.
    scale, offset : ``samples`` as stored (e.g. the integers of a memory-mapped WAV): a sample at
        full scale is ``(stored - offset) * scale``.

    Returns
    -------
    Onsets
    """
    fs = float(sample_rate)
    if not (math.isfinite(fs) and fs > 0):
        raise ValueError(f"sample_rate must be positive, got {sample_rate!r}")
    if band is None:
        if not fs > min_sample_rate():
            raise ValueError(f"sample rate {fs:g} Hz too low for the default band ({DEFAULT_BAND[0]:g} Hz to "
                             f"{_NYQUIST_MARGIN:g} fs): the detector needs more than {min_sample_rate():.0f} Hz")
        band = (DEFAULT_BAND[0], min(DEFAULT_BAND[1], _NYQUIST_MARGIN * fs))
    lo, hi = float(band[0]), float(band[1])
    if not (0.0 < lo < hi < 0.5 * fs):
        raise ValueError(f"band must satisfy 0 < low < high < fs/2 = {0.5 * fs:g} Hz, got {band!r}")
    if not 0.0 < fraction < 1.0:
        raise ValueError(f"fraction must lie in (0, 1), got {fraction!r}")
    env = envelope(samples, fs, (lo, hi), window, scale=scale, offset=offset)
    n = env.size
    median = float(np.median(env))
    deviation = env - np.float32(median)  # in place from here: one more envelope's worth of memory
    np.abs(deviation, out=deviation)
    mad = float(np.median(deviation, overwrite_input=True))
    del deviation
    threshold = max(median + threshold_sigma * 1.4826 * mad, threshold_sigma * quantum)
    notes: list[str] = []

    # hysteresis (a Schmitt trigger): a click starts above the threshold and lasts until the envelope
    # falls below the release level, so that its ring-down, beating between resonances, does not
    # re-trigger
    release = max(median + release_sigma * 1.4826 * mad, release_sigma * quantum)
    gap = max(3, int(round(window * fs)))
    # stretches fewer than ``gap`` samples apart are one onset
    starts, ends = true_runs(env > min(release, threshold), max_gap=gap - 1)
    # the loudest sample of a run: between runs the envelope is below the level that starts one
    # (itself at most the threshold), so the maximum from one start to the next is the run's own
    loud = np.maximum.reduceat(env, starts) > threshold if starts.size else np.zeros(0, dtype=bool)
    starts, ends = starts[loud], ends[loud]
    peaks = np.array([s + int(np.argmax(env[s:e])) for s, e in zip(starts, ends)], dtype=int)
    peak_values = env[peaks].astype(float) if peaks.size else np.empty(0)
    onset = np.array([_constant_fraction(env, s, p, fraction) for s, p in zip(starts, peaks)]) / fs
    durations = (ends - starts) / fs
    ring_down = float(np.median(durations)) if durations.size else 0.0

    shortest = math.nan
    c = math.nan
    if onset.size >= 3:
        c = _flight_per_amplitude(onset, peak_values)
    if refractory is None:
        if math.isfinite(c):
            shortest = c * threshold
        refractory = max(0.5 * shortest if math.isfinite(shortest) else 0.0, ring_down)
    keep, suppressed = _suppress(onset, peak_values, float(refractory), c)
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


def _constant_fraction(env: np.ndarray, start: int, peak: int, fraction: float) -> float:
    """Sub-sample index of the last upward crossing of ``fraction * env[peak]`` before ``peak``."""
    level = fraction * float(env[peak])
    lo = max(0, start - int(2 * (peak - start)) - 8)
    seg = env[lo:peak + 1]
    below = np.flatnonzero(seg < level)
    if below.size == 0:
        return float(lo)
    i = lo + int(below[-1])
    a, b = float(env[i]), float(env[i + 1])
    return i + (level - a) / (b - a) if b != a else float(i)


def _flight_per_amplitude(times: np.ndarray, peaks: np.ndarray) -> float:
    """``c``: the median ratio of a flight to the peak of the click that ends it, along the main
    sequence of clicks (each at least half as loud as the main click before it: a bounce loses a
    few per cent of its speed, an echo or a spurious sound is much weaker than the click before it)."""
    main = [0]
    for j in range(1, times.size):
        if peaks[j] >= 0.5 * peaks[main[-1]]:
            main.append(j)
    main = np.array(main)
    if main.size < 3:
        return math.nan
    flights = np.diff(times[main])
    return float(np.median(flights / peaks[main[1:]]))


def _suppress(times: np.ndarray, peaks: np.ndarray, refractory: float, c: float) -> tuple[np.ndarray, np.ndarray]:
    """Indices kept and suppressed. A candidate is suppressed when it follows a louder kept click
    sooner than ``refractory``, or sooner than half the flight that would end in a click as loud as
    itself (``0.5 c A``: too loud for so short a flight, so an echo or the click's ring-down), or
    follows a louder suppressed sound (an echo) sooner than ``refractory`` (its ring-down); a
    candidate more than twice as loud as every kept click within the refractory period before it
    replaces them (they were a faint precursor)."""
    keep: list[int] = []
    suppressed: list[int] = []
    for j in range(times.size):
        shadow = refractory
        if math.isfinite(c):
            shadow = max(shadow, 0.5 * c * peaks[j])
        recent = [i for i in keep[-8:] if times[j] - times[i] < shadow]
        louder = [i for i in recent if peaks[i] >= peaks[j] or times[j] - times[i] < refractory and
                  peaks[j] <= 2.0 * peaks[i]]
        # the ring-down of a louder sound just before, even one suppressed as an echo, is no new click
        ringing = [i for i in suppressed[-8:] if times[j] - times[i] < refractory and peaks[i] >= peaks[j]]
        if louder or ringing:
            suppressed.append(j)
            continue
        faint = [i for i in recent if times[j] - times[i] < refractory]
        for i in faint:
            keep.remove(i)
            suppressed.append(i)
        keep.append(j)
    return np.array(keep, dtype=int), np.array(sorted(suppressed), dtype=int)

"""Impact contacts in audio: band-pass, energy envelope, an adaptive threshold, every click
found, the clicks of one contact merged with a refractory time learned from the drop, echoes and
ringing rejected, sub-sample onset times and a confidence.

Real recordings hold several clicks per contact (the ball's shell and the floor), echoes at fixed
delays, the ringing of the surface, room noise and clipped peaks. Steps (:func:`detect_onsets`):

1. **Band-pass** every channel (4th-order Butterworth, zero phase) to ``band``, default 0.8 kHz to
   min(12 kHz, 0.45 fs): the click of a ball on a floor rings at a few kHz, speech, footsteps and
   hum lie below. The detector therefore needs a sample rate above 800 / 0.45 = 1778 Hz
   (:func:`min_sample_rate`).
2. **Energy envelope**: the band-passed power summed over the channels (``channel="mix"``: a stereo
   recording whose channels differ in gain or sign still adds up) or of one channel, averaged over
   ``window`` (0.25 ms), square root: an RMS envelope in full-scale units.
3. **Adaptive threshold**: the envelope's median and median absolute deviation over a sliding
   window of ``background`` (0.5 s) describe the background there (noise, hum, ringing); the
   threshold is ``median + k * 1.4826 MAD`` with ``k = threshold_sigma`` (8), the release level
   the same with ``release_sigma`` (3), and neither below ``k`` quantisation steps of the file.
4. **Clicks**: a sound starts above the threshold and lasts until the envelope falls below the
   release level (a Schmitt trigger); inside it, every peak that stands ``rise`` (3) times above
   the valley before it is a click of its own. The onset time is the constant-fraction time, as in
   nuclear-pulse electronics: the last upward crossing of ``fraction`` (20 %) of the click's rise
   (from the background, or from the valley before it, to its peak), interpolated linearly between
   samples: independent of the click's loudness for clicks of one shape.
5. **Contacts, with a refractory time learned from the drop** (:func:`_learn_refractory`): the
   gaps between consecutive clicks are of two kinds, within a contact (milliseconds, the same at
   every contact) and between contacts (the flights, shrinking geometrically); sorted, they are
   split at their largest step (at least :data:`SPLIT_RATIO`, three gaps on either side), first
   among the gaps of the first half of the clicks, whose flights are the longest. Clicks closer
   than the geometric mean of the gaps on either side of the step are one contact, timed at its
   first click at least a quarter as loud as its loudest.
6. **Echoes and ringing**: a weaker sound at a delay that recurs after at least three contacts and
   a quarter of them is an echo (a ball's flights never recur at one length); a click within the
   ringing time of the contact before it (the median time a contact's sound stays above the
   release level) and weaker than ``ringing_ratio`` (0.35) of it is ringing. Every rejected click
   keeps its time and reason (:data:`REJECTION_WORDS`).

   Whatever survives (spurious sounds, echoes weaker than the noise lets us judge) is left to the
   sequence cleaning (:mod:`impactid.rigs.ball.sequence`), which knows the flights.
7. **Confidence**: ``1 - threshold / peak``, the fraction of the click's peak above the threshold.

Memory: the audio is read block by block (a memory-mapped WAV is never copied whole); each block
is band-passed with a margin on either side long enough for the filter's transients to decay below
1e-13 of the signal, so the envelope is the one a single pass over the whole recording would give;
the envelope itself is kept in single precision, its sliding statistics at ``envelope_rate``. A
recording of ``n`` frames needs about :func:`memory_needed` bytes (8 per frame, plus the blocks).

Timing accuracy measured on synthetic clicks (``tests/rigs/ball/test_onsets.py``,
``tests/rigs/ball/test_audio_room.py``, ``docs/bounces.md``): a constant offset, and interval errors
of a few tens of microseconds at 44.1 and 48 kHz with background noise 40 dB below the loudest
click; with two to four clicks per contact, echoes, ringing, noise 20 dB below the loudest click and
clipping, the restitution of the heard contacts equals that of the true impact times within 1e-4.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.ndimage import median_filter, uniform_filter1d
from scipy.signal import butter, find_peaks, sosfiltfilt

from impactid.signal import true_runs

__all__ = ["BLOCK_FRAMES", "DEFAULT_BAND", "Onsets", "detect_onsets", "envelope", "memory_needed", "min_sample_rate"]

#: Frames band-passed at a time (5.5 s at 48 kHz): the working memory of the envelope does not grow
#: with the recording.
BLOCK_FRAMES = 1 << 18
#: Default band-pass [Hz]: from 800 Hz to min(12 kHz, 0.45 fs) (module notes).
DEFAULT_BAND = (800.0, 12000.0)
#: Highest band-pass edge as a fraction of the sample rate (the filter needs room below Nyquist).
_NYQUIST_MARGIN = 0.45
#: Length of the sliding window of the adaptive threshold [s]: long against a contact (milliseconds),
#: short against the changes of the background (a door, a voice, the ringing of the floor).
BACKGROUND_WINDOW = 0.5
#: A click on top of the sound of another counts when the envelope rises by this factor above the
#: valley before it (10 dB in power: more than the beating of a click's resonances makes).
RISE_FACTOR = 3.0
#: A click weaker than this fraction of the contact before it, within that contact's ringing time, is
#: ringing; echoes are weaker than this fraction of their contact.
RINGING_RATIO = 0.35


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
    """The impact contacts found in one recording.

    Attributes
    ----------
    times : onset times [s] of the contacts, increasing.
    confidence : per onset, in [0, 1]: the fraction of its peak above the threshold.
    peak : per onset, the envelope peak [full scale].
    threshold : detection threshold of the envelope [full scale] (the median of the sliding one).
    noise_floor : median of the envelope's sliding median [full scale].
    refractory : clicks closer than this are one contact [s] (learned from the gaps, module notes).
    shortest_flight : shortest time between two accepted contacts [s] (NaN with fewer than two).
    ring_down : ringing time: the median time the sound of an accepted contact stays above the
        release level [s].
    band : band-pass edges [Hz].
    sample_rate : [Hz].
    envelope : the envelope, decimated (maximum) to ``envelope_rate`` (for figures).
    envelope_rate : [Hz].
    rejected : times [s] of the clicks that are not contacts.
    rejected_peaks : their envelope peaks [full scale].
    rejected_reasons : per rejected click, a key of :data:`REJECTION_WORDS` (``contact``, ``echo``,
        ``ringing``).
    echo_delays : the recurring echo delays found [s].
    threshold_curve : the sliding threshold at ``envelope_rate`` [full scale].
    waveform : (frames, 2) lowest and highest sample at ``envelope_rate`` [full scale], channels averaged.
    channel : ``"mix"`` or the index of the channel used.
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
    rejected: np.ndarray = field(default_factory=lambda: np.empty(0))
    rejected_peaks: np.ndarray = field(default_factory=lambda: np.empty(0))
    rejected_reasons: tuple[str, ...] = ()
    echo_delays: tuple[float, ...] = ()
    threshold_curve: np.ndarray = field(default_factory=lambda: np.empty(0), repr=False)
    waveform: np.ndarray = field(default_factory=lambda: np.empty((0, 2)), repr=False)
    channel: str = "mix"
    notes: tuple[str, ...] = ()

    @property
    def suppressed(self) -> np.ndarray:
        """Times [s] of every rejected click (:attr:`rejected`)."""
        return self.rejected

    @property
    def snr_db(self) -> np.ndarray:
        """Peak over noise floor [dB]."""
        return 20.0 * np.log10(self.peak / max(self.noise_floor, 1e-300))

    def describe(self) -> str:
        """One provenance line."""
        counts = {r: self.rejected_reasons.count(r) for r in REJECTION_WORDS}
        rejected = ", ".join(f"{k} {r}" for r, k in counts.items() if k)
        return (f"found {self.times.size} impact contact(s): band {self.band[0]:.0f}-{self.band[1]:.0f} Hz, "
                f"channel {self.channel}, RMS envelope, sliding threshold (median {self.threshold:.3g}; noise floor "
                f"{self.noise_floor:.3g}), refractory {1e3 * self.refractory:.3g} ms, constant-fraction onsets"
                + (f"; clicks rejected: {rejected}" if rejected else ""))


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
                  fraction: float = 0.2, refractory: float | None = None, quantum: float = 2.0 ** -24,
                  envelope_rate: float = 2000.0, scale: float = 1.0, offset: float = 0.0,
                  channel: str | int = "mix", background: float = BACKGROUND_WINDOW, rise: float = RISE_FACTOR,
                  ringing_ratio: float = RINGING_RATIO) -> Onsets:
    """Find the impact contacts in an audio recording (module notes).

    Parameters
    ----------
    samples : (n,) or (n, channels) audio, full scale 1.
    sample_rate : [Hz]; above :func:`min_sample_rate`.
    band : band-pass edges [Hz]; default (800, min(12000, 0.45 fs)).
    window : envelope averaging window [s].
    threshold_sigma : threshold in robust standard deviations of the envelope above its median, both
        taken over a sliding window of ``background`` seconds.
    release_sigma : release level of the hysteresis, in the same units: a click lasts until the
        envelope falls below it.
    fraction : constant-fraction level of the onset time (of the click's rise from the valley
        before it to its peak).
    refractory : clicks closer than this [s] are one contact; default learned from the gaps
        between the clicks (module notes).
    quantum : quantisation step of the samples (full scale 1): the threshold is at least
        ``threshold_sigma`` of them.
    envelope_rate : rate [Hz] of the decimated envelope, threshold and waveform kept for figures.
    scale, offset : ``samples`` as stored (e.g. the integers of a memory-mapped WAV): a sample at
        full scale is ``(stored - offset) * scale``.
    channel : ``"mix"`` (the band-passed power of every channel summed) or the index of the one
        channel to use (0 = the first).
    background : length of the sliding window of the threshold [s].
    rise : a click inside another click's sound counts when the envelope rises by this factor
        above the valley before it.
    ringing_ratio : a click within the ringing time of a louder contact and weaker than this fraction
        of it is the ringing.

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
    if not (rise > 1.0 and 0.0 < ringing_ratio < 1.0 and background > 0.0):
        raise ValueError(f"need rise > 1, 0 < ringing_ratio < 1 and background > 0, got {rise!r}, "
                         f"{ringing_ratio!r}, {background!r}")
    x = samples if getattr(samples, "ndim", 0) else np.asarray(samples)
    if x.ndim == 1:
        x = x[:, None]
    if channel != "mix":
        if isinstance(channel, bool) or not isinstance(channel, (int, np.integer)) or not 0 <= channel < x.shape[1]:
            raise ValueError(f"channel must be 'mix' or an index in [0, {x.shape[1] - 1}], got {channel!r}")
        x = x[:, int(channel):int(channel) + 1]
    env = envelope(x, fs, (lo, hi), window, scale=scale, offset=offset)
    n = env.size
    step = max(1, int(round(fs / envelope_rate)))
    level, spread = _background(env, step, max(3, int(round(background * fs / step))))
    start_level = np.maximum(level + threshold_sigma * 1.4826 * spread, threshold_sigma * quantum)
    release_level = np.maximum(level + release_sigma * 1.4826 * spread, release_sigma * quantum)
    threshold = float(np.median(start_level))
    median = float(np.median(level))
    notes: list[str] = []

    # hysteresis (a Schmitt trigger): a sound starts above the threshold and lasts until the envelope
    # falls below the release level; inside it, every rise by ``rise`` above the valley before it is
    # a click of its own (a second click of the contact, an echo, or the next impact over ringing)
    gap = max(3, int(round(window * fs)))
    mask = np.empty(n, dtype=bool)
    for first in range(0, n, BLOCK_FRAMES - BLOCK_FRAMES % step):
        last = min(n, first + BLOCK_FRAMES - BLOCK_FRAMES % step)
        mask[first:last] = env[first:last] > np.repeat(release_level[first // step:(last - 1) // step + 1],
                                                       step)[:last - first]
    starts, ends = true_runs(mask, max_gap=gap - 1)
    del mask
    found = [_clicks_in_run(env, s, e, start_level[s // step], float(level[s // step]), rise, gap, fraction)
             for s, e in zip(starts, ends)]
    clicks = [c for run in found for c in run]
    onset = np.array([c[0] for c in clicks], dtype=float) / fs
    peak_values = np.array([c[1] for c in clicks], dtype=float)
    run_end = np.array([c[2] for c in clicks], dtype=float) / fs
    candidates = Candidates(onset, peak_values, run_end - onset)

    split = ""
    if refractory is None:
        refractory, split = _learn_refractory(candidates.times)
    decision = _decide(candidates, float(refractory), ringing_ratio)
    keep = decision.keep
    times, peak_values = onset[keep], peak_values[keep]
    gaps = np.diff(times)
    confidence = np.clip(1.0 - threshold / np.maximum(peak_values, 1e-300), 0.0, 1.0)
    if times.size and np.max(peak_values) < 4.0 * threshold:
        notes.append("the loudest click is less than 4 times the detection threshold: onsets are uncertain")
    if split:
        notes.append(split)
    for reason, count in decision.counts().items():
        if count:
            notes.append(f"{count} click(s) rejected: {REJECTION_WORDS[reason]}")
    decimated = env[: (n // step) * step].reshape(-1, step).max(axis=1) if n >= step else env.copy()
    return Onsets(times=times, confidence=confidence, peak=peak_values, threshold=threshold,
                  noise_floor=median, refractory=float(refractory),
                  shortest_flight=float(np.min(gaps)) if gaps.size else math.nan, ring_down=decision.ringing_time,
                  band=(lo, hi), sample_rate=fs, envelope=decimated, envelope_rate=fs / step,
                  rejected=onset[decision.rejected], rejected_peaks=candidates.peaks[decision.rejected],
                  rejected_reasons=tuple(decision.reasons), echo_delays=decision.echo_delays,
                  threshold_curve=start_level.astype(np.float32), waveform=_waveform(x, step, scale, offset),
                  channel=str(channel), notes=tuple(notes))


#: Why a click is not an impact (the legend of the onset figure).
REJECTION_WORDS = {"contact": "a further click of the same contact (within the refractory time)",
                   "echo": "an echo (a weaker copy at a delay that recurs after the contacts)",
                   "ringing": "ringing (much weaker than the contact before it, within its ringing time)"}


@dataclass(frozen=True)
class Candidates:
    """The clicks found before any is rejected: onset times [s], envelope peaks [full scale], and the
    time each one's sound lasts above the release level [s]."""

    times: np.ndarray
    peaks: np.ndarray
    durations: np.ndarray


@dataclass(frozen=True)
class Decision:
    """Which candidates are impacts: ``keep`` and ``rejected`` (indices), the reason of each
    rejected one (a key of :data:`REJECTION_WORDS`), the echo delays found [s] and the ringing time [s]."""

    keep: np.ndarray
    rejected: np.ndarray
    reasons: tuple[str, ...]
    echo_delays: tuple[float, ...]
    ringing_time: float

    def counts(self) -> dict[str, int]:
        return {reason: self.reasons.count(reason) for reason in REJECTION_WORDS}


def _background(env: np.ndarray, step: int, width: int) -> tuple[np.ndarray, np.ndarray]:
    """Sliding median and median absolute deviation of the envelope [full scale], one per ``step``
    samples, over ``width`` such points (the envelope subsampled, not averaged, so that its spread
    is the spread of its samples). Clicks occupy a few per cent of any stretch of a drop, so both
    describe the background: noise, hum, and the ringing of the surface."""
    sub = np.asarray(env[::step], dtype=float)
    width = max(3, int(width) | 1)
    if sub.size <= width:  # shorter than the window: the whole recording is the window
        level = np.full(sub.size, float(np.median(sub)))
        return level, np.full(sub.size, float(np.median(np.abs(sub - level))))
    half = width // 2
    level = median_filter(sub, size=width, mode="nearest")
    level[:half], level[-half:] = level[half], level[-half - 1]  # full windows only: no edge replicated
    spread = median_filter(np.abs(sub - level), size=width, mode="nearest")
    spread[:half], spread[-half:] = spread[half], spread[-half - 1]
    return level, spread


def _clicks_in_run(env: np.ndarray, start: int, stop: int, threshold: float, background: float, rise: float,
                   gap: int, fraction: float) -> list[tuple[float, float, int]]:
    """The clicks of one sound (a run of the envelope above the release level): (onset [samples],
    peak [full scale], end of the run [samples]). The first is the run's rise; every later peak that
    stands ``rise`` times above the valley before it is one more. Runs whose peak stays below the
    threshold are background. Onsets are at ``fraction`` of the rise from the level below the click
    (the ``background`` [full scale] for the first, the valley for the others) to its peak."""
    seg = env[start:stop]
    if seg.size == 0 or float(seg.max()) <= threshold:
        return []
    peaks, _ = find_peaks(seg, distance=gap)
    if peaks.size == 0 or int(np.argmax(seg)) not in peaks:
        peaks = np.union1d(peaks, [int(np.argmax(seg))])
    clicks: list[tuple[float, float, int]] = []
    base = start  # where the valley before the next click is searched from
    best = -1  # the highest peak of the current click (index into seg)
    for p in peaks:
        if best < 0:
            if seg[p] > threshold:
                best = int(p)
                clicks.append((_constant_fraction(env, start, start + best, fraction, floor=background),
                               float(seg[best]), stop))
            continue
        valley = int(np.argmin(seg[best:p + 1])) + best
        if seg[p] > threshold and seg[p] >= rise * seg[valley]:
            best = int(p)
            base = start + valley
            onset = _constant_fraction(env, base, start + best, fraction, floor=float(seg[valley]), before=False)
            clicks.append((onset, float(seg[best]), stop))
        elif seg[p] > seg[best]:  # the same click still rising
            best = int(p)
            clicks[-1] = (_constant_fraction(env, base, start + best, fraction,
                                             floor=background if base == start else float(env[base]),
                                             before=base == start),
                          float(seg[best]), stop)
    return clicks


def _constant_fraction(env: np.ndarray, start: int, peak: int, fraction: float, floor: float = 0.0,
                       before: bool = True) -> float:
    """Sub-sample index of the last upward crossing of ``floor + fraction * (env[peak] - floor)``
    before ``peak``, searched back to ``start`` and, when ``before``, further by twice the rise (a
    click that rises from the background)."""
    level = floor + fraction * (float(env[peak]) - floor)
    lo = max(0, start - int(2 * (peak - start)) - 8) if before else start
    seg = env[lo:peak + 1]
    below = np.flatnonzero(seg < level)
    if below.size == 0:
        return float(lo)
    i = lo + int(below[-1])
    a, b = float(env[i]), float(env[i + 1])
    return i + (level - a) / (b - a) if b != a else float(i)


#: Smallest ratio of the shortest gap between contacts to the longest gap between the clicks of one
#: contact for the two to be told apart (module notes).
SPLIT_RATIO = 3.0


def _learn_refractory(times: np.ndarray) -> tuple[float, str]:
    """The refractory time [s] from the gaps between consecutive clicks, and a line saying how.

    The gaps of a drop form two populations: between the clicks of one contact (its clicks, echoes
    and ringing: milliseconds, the same at every contact) and between contacts (the flights, which
    shrink geometrically, so consecutive ones differ by a few per cent). Sorted by length, the two
    are separated by the largest step between neighbours with at least three gaps on either side
    (not one odd gap, nor the junk gaps before and after a drop), if it exceeds
    :data:`SPLIT_RATIO`; the refractory time is the geometric mean of the gaps on either side. The
    gaps of the first half of the clicks are tried first: their flights are the drop's longest, far
    from the clicks of a contact, while the last flights of a long drop can be as short as a
    contact's echoes. Without such a step, the refractory time is 0 (every click is a contact)."""
    for part, what in ((times[: times.size // 2 + 1], "the first half of the clicks"), (times, "all clicks")):
        if part.size < 9 and part is not times:
            continue
        gaps = np.sort(np.diff(part))
        gaps = gaps[gaps > 0.0]
        if gaps.size < 6:
            continue
        ratios = gaps[1:] / gaps[:-1]
        ratios[:2] = ratios[gaps.size - 4:] = 0.0  # three gaps at least on either side
        k = int(np.argmax(ratios))
        if ratios[k] < SPLIT_RATIO:
            continue
        value = math.sqrt(gaps[k] * gaps[k + 1])
        return value, (f"refractory time {1e3 * value:.3g} ms learned from the gaps between {what}: {k + 1} gap(s) "
                       f"up to {1e3 * gaps[k]:.3g} ms within contacts, {gaps.size - k - 1} from "
                       f"{1e3 * gaps[k + 1]:.3g} ms between them")
    return 0.0, ""


#: Tolerance of a recurring echo delay [s].
ECHO_TOLERANCE = 0.5e-3
#: Longest echo delay looked for [s] (a wall 35 m away).
MAX_ECHO_DELAY = 0.2


def _decide(c: Candidates, refractory: float, ringing_ratio: float) -> Decision:
    """Which candidates are impacts (module notes): the clicks of one contact merged (the first
    click at least a quarter as loud as the contact's loudest is its onset), then echoes at a
    recurring delay and ringing rejected."""
    t, a = c.times, c.peaks
    reason: dict[int, str] = {}
    # 1. contacts: chains of clicks closer than the refractory time
    contacts: list[int] = []
    j = 0
    while j < t.size:
        group = [j]
        while group[-1] + 1 < t.size and t[group[-1] + 1] - t[group[-1]] < refractory:
            group.append(group[-1] + 1)
        loudest = max(a[g] for g in group)
        head = next(g for g in group if a[g] >= 0.25 * loudest)
        contacts.append(head)
        for g in group:
            if g != head:
                reason[g] = "contact"
        j = group[-1] + 1
    contacts_arr = np.array(contacts, dtype=int)
    # 2. echoes: a weaker copy at a delay that recurs after many contacts
    echo_delays = _echo_delays(t[contacts_arr], a[contacts_arr])
    kept: list[int] = []
    for i in contacts:
        echo = any(abs(t[i] - t[p] - d) <= ECHO_TOLERANCE and a[i] < a[p]
                   for p in kept[-8:] for d in echo_delays)
        if echo:
            reason[i] = "echo"
        else:
            kept.append(i)
    # 3. ringing: much weaker than the contact before it, within its ringing time
    ringing_time = float(np.median(c.durations[kept])) if kept else 0.0
    final: list[int] = []
    for i in kept:
        if final and t[i] - t[final[-1]] < ringing_time and a[i] < ringing_ratio * a[final[-1]]:
            reason[i] = "ringing"
        else:
            final.append(i)
    rejected = np.array(sorted(reason), dtype=int)
    return Decision(keep=np.array(final, dtype=int), rejected=rejected, reasons=tuple(reason[i] for i in rejected),
                    echo_delays=echo_delays, ringing_time=ringing_time)


def _echo_delays(t: np.ndarray, a: np.ndarray) -> tuple[float, ...]:
    """Delays [s] at which a weaker sound follows at least three contacts and a quarter of them:
    room echoes. A bouncing ball's flights shrink from one to the next and never recur at one
    length."""
    delays = []
    for i in range(t.size):
        for j in range(i + 1, t.size):
            d = t[j] - t[i]
            if d > MAX_ECHO_DELAY:
                break
            if a[j] < a[i]:
                delays.append(d)
    if len(delays) < 3:
        return ()
    delays = np.sort(np.array(delays))
    found: list[float] = []
    need = max(3, int(math.ceil(0.25 * t.size)))
    for d in delays:
        near = delays[np.abs(delays - d) <= ECHO_TOLERANCE]
        centre = float(np.median(near))
        if near.size >= need and all(abs(centre - f) > ECHO_TOLERANCE for f in found):
            found.append(centre)
    return tuple(found)


def _waveform(x: np.ndarray, step: int, scale: float, offset: float) -> np.ndarray:
    """The audio (channels averaged) as its lowest and highest sample in every ``step`` samples:
    an (n // step, 2) single-precision array [full scale] for figures, read block by block."""
    n = x.shape[0] // step
    out = np.empty((n, 2), dtype=np.float32)
    block = max(step, (BLOCK_FRAMES // step) * step)
    for first in range(0, n * step, block):
        last = min(n * step, first + block)
        seg = ((np.asarray(x[first:last], dtype=float) - offset) * scale).mean(axis=1).reshape(-1, step)
        out[first // step:last // step, 0] = seg.min(axis=1)
        out[first // step:last // step, 1] = seg.max(axis=1)
    return out

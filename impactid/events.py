"""Impact detection and segmentation (section 5.1 of Sundar, Dreyer & Singh (2016)).

A contact of rig P shows on the accelerometer as a pulse three orders of magnitude above the
smooth free-flight acceleration. :func:`find_events` finds the pulses, then refines each one
against a local free-flight baseline:

1. **noise floor**: ``sigma`` from the median absolute second difference of the channel
   (:func:`impactid.signal.noise_floor`: ``var(d2) = 6 sigma^2`` for white noise; the smooth
   free-flight signal contributes almost nothing to a second difference at 204.8 kHz, and contacts
   are under 1 % of the samples);
2. **pulse cores**: runs of samples more than ``threshold`` above the channel median (default
   ``max(10 sigma, 2 % of the largest excursion)``), merged across gaps of up to :data:`CORE_GAP` samples;
3. **onset** of each pulse: a quadratic free-flight baseline is fitted to the 64 samples that end
   16 samples before the core; the first contact sample is the first of the samples from which
   the deviation stays above ``onset_threshold`` (default ``max(5 sigma, 1e-6 x peak)``, raised above the
   ringing that a linear-phase anti-alias filter puts ahead of the rise, :func:`_ringing_level`). The
   onset time ``t_onset`` is refined within the preceding sample interval by fitting the rise
   ``c (t - t0)^p`` (Hertz: ``p = 1.5`` at first touch) to the first three contact samples;
4. **separation** ``t_a``: the same from the other side (baseline after the pulse); then, because a
   nearly plastic contact (restitution below about 0.01) ends in a low tail of 2-5 ms that a local
   quadratic follows, and a follower may ride the cam after an impact, the contact's true end is
   found against a cubic free-flight baseline of :data:`CONTACT_END_BASELINE_S`, moved on past
   every sample (or block of samples, under noise) that deviates from it (:func:`_contact_end`);
5. **next onset** ``t_e``: the onset of the following event;
6. **the motion's pattern** (:func:`_motion_pattern`): the cam turns at a constant speed, so in
   periodic motion the onsets recur at the same cam phase after a whole number ``k`` of
   revolutions and ``m`` impacts; each event's integration window runs from its onset to the
   onset that closes one period of the motion (``period_end``: the next one in period-1 motion).

Quality flags per event: ``truncated`` (no room for a baseline before the pulse, or no next
onset: not usable), ``too_short`` (fewer than 3 samples of contact: an impulse, i.e. an
instantaneous impact; its time is the centroid of the pulse and the reconstruction treats it as
a velocity jump), ``ringing`` (the rise is preceded by an anti-alias filter's ringing: a band-limited
recording, docs/estimation.md), ``overlapping`` (the next
pulse starts within the post-contact baseline window), ``clipped`` (the pulse reaches the
channel's extreme value for 3 or more samples), ``chattering`` (more than one contact within one
cam revolution), ``periodic`` (the onset recurs one period of the motion later or earlier),
``not_period1`` (the motion there is not one impact per revolution: period-k, multi-impact or
irregular) and ``riding`` (the contact lasts longer than :data:`RIDING_FRACTION` of a revolution:
the follower rides the cam). Chattering, period-k motion, non-recurring and riding events are named
in the result's notes (:attr:`EventTable.warnings`), which :func:`find_events` issues as
:class:`EventWarning`, each once, unless a caller that carries the notes on in its own result
(:func:`impactid.rigs.pivoted.reconstruct.reconstruct`) asks it not to.
"""

from __future__ import annotations

import functools
import math
import warnings
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from numba import njit
from scipy import optimize

from impactid import compilation
from impactid._scan import extreme_stats
from impactid.io import CLIP_RUN, Recording, RecordingError
from impactid.signal import noise_floor, true_runs

__all__ = ["BASELINE_GAP", "BASELINE_LENGTH", "CONTACT_END_BASELINE_S", "CONTACT_END_DEGREE", "CORE_GAP",
           "INVERTED_RATIO", "MAX_BASELINE_MOVES", "MAX_PATTERN_EVENTS", "MAX_TAIL_MOVES", "MIN_SAMPLES",
           "NOISY_ONSET", "ONSET_FIT", "ONSET_FITS", "PATTERN_SHARE", "PERIOD_TOLERANCE", "RIDING_FRACTION",
           "TAIL_BLOCK", "TAIL_SNR",
           "EventTable", "EventWarning", "NoImpactsError", "find_events", "separation_before"]

compilation.install()  # before the kernels (impactid.compilation)

#: Samples skipped between a baseline window and the pulse, and the baseline window length.
BASELINE_GAP = 16
BASELINE_LENGTH = 64
#: Tolerance of the motion's pattern check (:func:`_motion_pattern`): how far, in cam revolutions, the
#: spacing of two onsets one period apart may lie from a whole number of revolutions.
PERIOD_TOLERANCE = 0.01
#: Onset threshold, relative to the peak, above which the onset is fitted over the noisy rise
#: (:func:`_fit_onsets`) rather than solved from three samples.
NOISY_ONSET = 1e-4


#: Pulse cores separated by at most this many samples below the threshold are one pulse.
CORE_GAP = 3
#: Fewest samples in which a pulse and its two baseline windows can be found.
MIN_SAMPLES = 2 * (BASELINE_GAP + BASELINE_LENGTH) + 8
#: A channel whose largest negative excursion from the median exceeds this many times its largest
#: positive one is taken as inverted (impact pulses on rig P's accelerometer are positive).
INVERTED_RATIO = 3.0


class EventWarning(UserWarning):
    """The events break an assumption of the pipeline (period-1 impacting, clean pulses)."""


class NoImpactsError(RecordingError):
    """A recording in which no impact can be found (names the file and the channel)."""


@dataclass(frozen=True)
class EventTable:
    """Impact events of one recording.

    Attributes
    ----------
    table : one row per event: ``onset_index`` (first contact sample), ``t_onset`` [s] (refined,
        between the previous sample and ``onset_index``), ``separation_index`` (first free sample
        after the pulse), ``t_separation`` [s], ``t_next`` [s] (next onset; NaN for the last
        event), ``peak`` [m/s^2] (largest deviation from the free-flight baseline),
        ``contact_samples``, ``spacing`` [s] (``t_next - t_onset``), quality flags (bool columns),
        ``period_end`` (position of the event whose onset closes this event's integration window:
        one period of the motion later; -1 if none) and ``usable`` (complete, clean, and its window
        closed by a found onset).
    noise_sigma : noise floor of the channel [m/s^2].
    threshold, onset_threshold : detection thresholds used [m/s^2].
    warnings : notes on events that break an assumption of the pipeline (issued as
        :class:`EventWarning` by :func:`find_events` unless ``warn=False``).
    provenance : the recording's provenance plus this step.
    """

    table: pd.DataFrame
    noise_sigma: float
    threshold: float
    onset_threshold: float
    sample_rate_hz: float
    start_time_s: float
    cam_speed_hz: float | None
    warnings: tuple[str, ...] = ()
    provenance: tuple[str, ...] = field(default=())

    def __len__(self) -> int:
        return len(self.table)

    @property
    def usable(self) -> pd.DataFrame:
        """Rows of the events the per-event kinematics can process."""
        return self.table[self.table["usable"]]


@dataclass(frozen=True)
class _Quadratic:
    """A quadratic free-flight baseline ``polyval(coeffs, k - centre)`` of sample indices ``k`` [m/s^2]."""

    coeffs: np.ndarray
    centre: float

    def __call__(self, at) -> np.ndarray:
        return _horner(self.coeffs, np.asarray(at) - self.centre)


def _horner(coeffs: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``numpy.polyval(coeffs, x)`` for finite ``x`` (the same operations in the same order, without its
    array of zeros to start from): a baseline is evaluated on every event's few samples."""
    y = coeffs[0] * x + coeffs[1]
    for c in coeffs[2:]:
        y = y * x + c
    return y


@functools.lru_cache(maxsize=64)
def _fit_design(samples: int, degree: int, scale: float | None) -> tuple[np.ndarray, np.ndarray, float]:
    """:func:`numpy.polyfit`'s scaled design for ``samples`` consecutive samples about their centre (divided by
    ``scale`` unless None): ``(design, column norms, rcond)``, made once per window length (every event's
    baselines have the same few lengths) by polyfit's own steps, so that :func:`_polyfit` gives its numbers
    to the last bit."""
    position = np.arange(samples) - 0.5 * samples  # = np.arange(lo, hi) - 0.5 * (lo + hi), exactly
    if scale is not None:
        position = position / scale
    design = np.vander(position, degree + 1)
    norm = np.sqrt((design * design).sum(axis=0))
    design /= norm
    design.flags.writeable = False
    return design, norm, samples * np.finfo(float).eps


def _polyfit(y: np.ndarray, degree: int, scale: float | None = None) -> np.ndarray:
    """``numpy.polyfit(position, y, degree)`` for samples ``y`` at positions about their centre
    (:func:`_fit_design`), without rebuilding the design for every window."""
    design, norm, rcond = _fit_design(y.size, degree, scale)
    coeffs, _, rank, _ = np.linalg.lstsq(design, y + 0.0, rcond)
    if rank != degree + 1:
        warnings.warn("Polyfit may be poorly conditioned", np.exceptions.RankWarning, stacklevel=3)
    return (coeffs.T / norm).T


def _baseline(x: np.ndarray, lo: int, hi: int) -> _Quadratic | None:
    """Quadratic least-squares fit to ``x[lo:hi]``: a function of sample indices, or None if the
    window does not fit in the recording."""
    if lo < 0 or hi > x.size or hi - lo < 8:
        return None
    centre = 0.5 * (lo + hi)
    return _Quadratic(_polyfit(x[lo:hi], 2), centre)


#: Most times the post-pulse baseline window is moved on past a tensile tail.
MAX_BASELINE_MOVES = 16
#: Length [s] of the long free-flight baseline that finds where a contact really ends
#: (:func:`_contact_end`): a cubic over it fits rig P's free-flight acceleration to the 24-bit
#: quantisation (measured: largest residual 1.5e-3 m/s^2 over 4 ms, against 2 to 9 m/s^2 of the
#: tail of a nearly plastic contact), so a low tail shows against it where a 64-sample quadratic
#: follows it.
CONTACT_END_BASELINE_S = 4e-3
#: Degree of that baseline.
CONTACT_END_DEGREE = 3
#: Samples per block of the block-mean test of a tail (noise averages down by its square root).
TAIL_BLOCK = 16
#: A block whose mean deviation from the long baseline exceeds this many standard errors of the noise
#: is contact (false alarm about 2e-9 per block).
TAIL_SNR = 6.0
#: Most times the long baseline is moved on past a tail (a follower riding the cam for 40 ms needs
#: about ten).
MAX_TAIL_MOVES = 64
#: A contact that lasts longer than this fraction of a cam revolution is not an impact: the follower
#: rides the cam after it (the envelope's riding cases: 16 % and 32 %; nearly plastic impacts of the
#: documented laws, restitution down to 0.0017: at most 6 %, a 4.9 ms contact at 12 Hz).
RIDING_FRACTION = 0.1
#: A rise whose clear part starts at this fraction of the pulse's peak (:func:`_ringing_level`) ...
RINGING_CLEAR = 0.01
#: ... and the onset threshold this many times the largest deviation before it, where the deviation
#: before it goes negative beyond the threshold (the ringing of a linear-phase anti-alias filter) ...
RINGING_FACTOR = 2.0
#: ... and beyond this many noise standard deviations (a Gaussian sample falls that far below once in 1e15:
#: at 5, one event in 300 noisy recordings of the coverage validation was flagged by its noise).
RINGING_NOISE = 8.0


def _ringing_level(dev: np.ndarray, threshold: float, peak: float, sigma: float) -> float:
    """The onset threshold that a band-limited (anti-alias filtered) rise needs: ``RINGING_FACTOR`` times the
    largest deviation before the rise's clear part where that deviation swings below ``-threshold`` and below
    :data:`RINGING_NOISE` times the noise ``sigma``, else 0.

    A contact only pushes (the pulse is positive): a deviation below the free-flight baseline by more than the
    noise just before the rise is the ringing that a linear-phase anti-alias filter puts ahead of a sharp
    rise (it alternates in sign, at 1e-4 to 1e-3 of the peak for 51.2 kHz recordings of a 0.5 ms contact);
    its positive lobes are not contact, and the first contact sample is the first above them. Such a rise's
    onset is then fitted over the rise (:func:`_fit_onsets`), as a noisy one's is.
    """
    clear = np.flatnonzero(dev > RINGING_CLEAR * abs(peak))
    if clear.size == 0 or clear[0] == 0:
        return 0.0
    ahead = dev[:clear[0]]
    if not np.any(ahead < -max(threshold, RINGING_NOISE * sigma)):
        return 0.0
    return RINGING_FACTOR * float(np.max(np.abs(ahead)))


#: Most events in one period of the motion the pattern check looks for (:func:`_motion_pattern`).
MAX_PATTERN_EVENTS = 12
#: Share of the onsets that must recur for a pattern to be the motion's (the rest: a transient).
PATTERN_SHARE = 0.8


def _next_core_start(starts: np.ndarray, current: int, size: int) -> int:
    """Start of the pulse core after the one starting at ``current`` (``size`` if none); ``starts``
    ascending."""
    k = int(np.searchsorted(starts, current, side="right"))
    return int(starts[k]) if k < starts.size else size


def _clean_baseline_after(x: np.ndarray, core_end: int, threshold: float, limit: int):
    """Free-flight baseline after a pulse whose core ends at ``core_end``: ``(baseline, window start)``.

    The window of :data:`BASELINE_LENGTH` samples starts :data:`BASELINE_GAP` samples after the
    core. If samples of its first half deviate from the fitted quadratic by more than
    ``threshold`` (the pulse's tail is still in the window: a tensile tail below the baseline,
    or a slow return), the window is moved to start ``BASELINE_GAP`` samples after the last such
    sample and fitted again, at most :data:`MAX_BASELINE_MOVES` times and never into the next
    pulse (``limit``). Returns ``(None, start)`` when no window fits.
    """
    a_lo = core_end + BASELINE_GAP
    after = _baseline(x, a_lo, a_lo + BASELINE_LENGTH)
    for _ in range(MAX_BASELINE_MOVES):
        if after is None:
            break
        head = np.arange(a_lo, a_lo + BASELINE_LENGTH // 2)
        bad = np.flatnonzero(np.abs(x[head] - after(head)) > threshold)
        if bad.size == 0:
            break
        moved = int(head[bad[-1]]) + BASELINE_GAP
        if moved + BASELINE_LENGTH > limit:
            break
        a_lo = moved
        after = _baseline(x, a_lo, a_lo + BASELINE_LENGTH)
    return after, a_lo


def _polynomial_baseline(x: np.ndarray, lo: int, hi: int, degree: int):
    """Least-squares polynomial of ``degree`` fitted to ``x[lo:hi]``: a function of sample indices."""
    centre = 0.5 * (lo + hi)
    scale = max(0.5 * (hi - lo), 1.0)
    coeffs = _polyfit(x[lo:hi], degree, scale)
    return lambda at: _horner(coeffs, (np.asarray(at) - centre) / scale)


def _tail_samples(deviation: np.ndarray, threshold: float, block_threshold: float) -> np.ndarray:
    """Positions in ``deviation`` that belong to a contact: samples beyond ``threshold``, and every
    sample of a block of :data:`TAIL_BLOCK` whose mean lies beyond ``block_threshold``."""
    bad = np.abs(deviation) > threshold
    blocks = deviation.size // TAIL_BLOCK
    if blocks:
        means = deviation[: blocks * TAIL_BLOCK].reshape(blocks, TAIL_BLOCK).mean(axis=1)
        bad[: blocks * TAIL_BLOCK] |= np.repeat(np.abs(means) > block_threshold, TAIL_BLOCK)
    return np.flatnonzero(bad)


def _last_contact_sample(deviation: np.ndarray, threshold: float, block_threshold: float) -> int:
    """The last position in ``deviation`` that belongs to a contact (-1 if none): the last sample beyond
    ``threshold`` when it lies in or after the last block that is (:func:`_tail_samples`), else that
    block's last sample (a tail that only the block means show, under noise)."""
    single = np.flatnonzero(np.abs(deviation) > threshold)
    either = _tail_samples(deviation, threshold, block_threshold)
    if either.size == 0:
        return -1
    if single.size and single[-1] >= either[-1] - TAIL_BLOCK:
        return int(single[-1])
    return int(either[-1])


def separation_before(x: np.ndarray, ka: int, free_start: int, threshold: float, block_threshold: float,
                      limit: int, rate: float) -> tuple[int, float] | None:
    """The separation of a contact known to last at least until ``free_start`` (a sample index of free
    flight, e.g. where the reconstruction's force balance ends the contact): ``(first free sample,
    sub-sample separation [samples])``, or None when no baseline fits before ``limit`` (the next pulse).

    A cubic free-flight baseline of :data:`CONTACT_END_BASELINE_S` is fitted from ``free_start`` on (moved
    on past any sample of its first half that still deviates, as in :func:`_contact_end`), and the contact
    ends after the last sample from ``ka - 1`` on that deviates from it by more than ``threshold`` (or a
    block of :data:`TAIL_BLOCK` by more than ``block_threshold``); the separation is refined between
    samples from the last three contact samples (:func:`_subsample_start`).
    """
    found, baseline = _contact_end(x, ka, threshold, block_threshold, limit, rate, max(threshold, block_threshold),
                                   first=free_start)
    if baseline is None or found < 3:
        return None
    fall = x[found - 3:found][::-1] - baseline(np.arange(found - 1, found - 4, -1))
    return found, _subsample_start(fall, found - 1, -1)


def _contact_end(x: np.ndarray, ka: int, threshold: float, block_threshold: float, limit: int, rate: float,
                 detection_threshold: float, first: int | None = None):
    """Where a contact really ends, past a long low tail: ``(separation index, baseline)``, or
    ``(ka, None)`` when there is no tail beyond the separation ``ka`` found by the local baseline.

    The local post-pulse baseline (:func:`_clean_baseline_after`, a quadratic over 64 samples) follows
    any tail that is smooth over 64 samples: the tensile tail of a nearly plastic Hunt–Crossley contact
    (``n < 1.5``, restitution below about 0.01), which lasts 2-5 ms at a few m/s^2, or a follower that
    rides the cam after the impact (tens of ms at a few N). Here a cubic is fitted over
    :data:`CONTACT_END_BASELINE_S` of the samples after ``ka`` (free flight is a cubic there to the
    quantisation; a tail and the free flight after it are not); while samples of its first half
    deviate from it by more than ``detection_threshold`` (the onset threshold, at least
    :data:`TAIL_SNR` noise standard deviations: its false alarms over hundreds of samples are then
    negligible), or blocks of :data:`TAIL_BLOCK` samples by more than ``block_threshold`` on
    average, the window is moved to start :data:`BASELINE_GAP` samples after the last of them (at
    most :data:`MAX_TAIL_MOVES` times, never into the next pulse at ``limit``). If it moved, the
    contact ends after the last sample from ``ka`` on that deviates from the final baseline by more
    than ``threshold`` (:func:`_last_contact_sample`; the window's start when the tail reaches the
    next pulse: the contact then lasts until it). ``rate`` [Hz] converts the window's length. ``first``
    starts the window there instead, known to be after the contact (:func:`separation_before`).
    """
    length = max(BASELINE_LENGTH, int(round(CONTACT_END_BASELINE_S * rate)))
    start = ka + BASELINE_GAP if first is None else int(first)
    baseline = None
    moved = first is not None
    for _ in range(MAX_TAIL_MOVES):
        hi = min(start + length, limit - BASELINE_GAP)
        if hi - start < BASELINE_LENGTH:
            if first is not None and baseline is None:
                return ka, None
            return (start if moved else ka), (baseline if moved else None)
        baseline = _polynomial_baseline(x, start, hi, CONTACT_END_DEGREE)
        head = np.arange(start, start + (hi - start) // 2)
        bad = _tail_samples(x[head] - baseline(head), detection_threshold, block_threshold)
        if bad.size == 0:
            break
        start = int(head[bad[-1]]) + BASELINE_GAP
        moved = True
    if not moved:
        return ka, None
    span = np.arange(ka - 1, start)
    last = _last_contact_sample(x[span] - baseline(span), threshold, block_threshold)
    return (int(span[last]) + 1 if last >= 0 else ka), baseline


#: :func:`_power_law_start`'s answers that are not a start: no power law (the caller's fallback), and no
#: convergence (what SciPy's ``brentq`` raises).
_NO_POWER_LAW = -2.0
_NOT_CONVERGED = -1.0


@njit(nogil=True, cache=True)
def _start_mismatch(s, r1, r2, r3):  # pragma: no cover - compiled
    """The exponents of the two sample pairs differ by this when the start lies ``s`` samples before the
    first (:func:`_power_law_start`)."""
    p12 = math.log(r2 / r1) / math.log((1.0 + s) / s)
    p23 = math.log(r3 / r2) / math.log((2.0 + s) / (1.0 + s))
    return p12 - p23


@njit(nogil=True, cache=True)
def _power_law_start(r1, r2, r3):  # pragma: no cover - compiled
    """Where ``c s^p`` through the deviations ``0 < r1 < r2 < r3`` of three consecutive samples starts: ``s`` in
    (0, 1) samples before the first (both pairs of samples giving one exponent ``p``, in [0.5, 4]), by
    Brent's method on ``[1e-6, 1 - 1e-9]`` (``xtol`` 1e-12; the steps of SciPy's ``brentq``, the same
    numbers: tests/test_events_compiled.py); :data:`_NO_POWER_LAW` when the bracket holds no root, a mismatch is
    not a number or the exponent is out of range; :data:`_NOT_CONVERGED` after 100 iterations."""
    lo, hi = 1e-6, 1.0 - 1e-9
    if not _start_mismatch(lo, r1, r2, r3) * _start_mismatch(hi, r1, r2, r3) < 0.0:
        return _NO_POWER_LAW
    xtol, rtol = 1e-12, 4.0 * np.finfo(np.float64).eps
    xpre, xcur = lo, hi
    fpre, fcur = _start_mismatch(xpre, r1, r2, r3), _start_mismatch(xcur, r1, r2, r3)
    if math.isnan(fpre) or math.isnan(fcur):
        return _NO_POWER_LAW
    xblk = fblk = spre = scur = 0.0
    root = math.nan
    if fpre == 0.0:
        root = xpre
    elif fcur == 0.0:
        root = xcur
    else:
        for _ in range(100):
            if fpre != 0.0 and fcur != 0.0 and (fpre < 0.0) != (fcur < 0.0):
                xblk, fblk = xpre, fpre
                spre = scur = xcur - xpre
            if abs(fblk) < abs(fcur):
                xpre, xcur, xblk = xcur, xblk, xcur
                fpre, fcur, fblk = fcur, fblk, fcur
            delta = (xtol + rtol * abs(xcur)) / 2.0
            sbis = (xblk - xcur) / 2.0
            if fcur == 0.0 or abs(sbis) < delta:
                root = xcur
                break
            if abs(spre) > delta and abs(fcur) < abs(fpre):
                if xpre == xblk:  # interpolate
                    stry = -fcur * (xcur - xpre) / (fcur - fpre)
                else:  # extrapolate
                    dpre = (fpre - fcur) / (xpre - xcur)
                    dblk = (fblk - fcur) / (xblk - xcur)
                    stry = -fcur * (fblk * dblk - fpre * dpre) / (dblk * dpre * (fblk - fpre))
                if 2.0 * abs(stry) < min(abs(spre), 3.0 * abs(sbis) - delta):
                    spre, scur = scur, stry  # a good short step
                else:
                    spre = scur = sbis
            else:
                spre = scur = sbis
            xpre, fpre = xcur, fcur
            if abs(scur) > delta:
                xcur += scur
            else:
                xcur += delta if sbis > 0.0 else -delta
            fcur = _start_mismatch(xcur, r1, r2, r3)
            if math.isnan(fcur):
                return _NO_POWER_LAW
        else:
            return _NOT_CONVERGED
    p = math.log(r2 / r1) / math.log((1.0 + root) / root)
    return root if 0.5 <= p <= 4.0 else _NO_POWER_LAW


def _subsample_start(r: np.ndarray, k_first: int, direction: int) -> float:
    """Sub-sample start of a power-law rise ``c |t - t0|^p`` from three deviations ``r``.

    ``r[0..2]`` are the deviations at samples ``k_first, k_first + direction, ...``. Returns the
    start in sample units (between ``k_first - direction`` and ``k_first``); falls back to the
    ``p = 1.5`` two-sample solution, then to the mid-point.
    """
    r1, r2, r3 = (abs(v) for v in r[:3])
    if not (0.0 < r1 < r2 < r3):
        return k_first - 0.5 * direction
    s = _power_law_start(float(r1), float(r2), float(r3))
    if s == _NOT_CONVERGED:
        raise RuntimeError("the sub-sample start did not converge in 100 iterations")
    if s >= 0.0:
        return k_first - s * direction
    rho = (r2 / r1) ** (1.0 / 1.5)  # (1 + s) / s = rho
    if rho > 1.0:
        s = 1.0 / (rho - 1.0)
        if 0.0 < s <= 1.0:
            return k_first - s * direction
    return k_first - 0.5 * direction


#: Samples before the first contact sample ``k0`` that the onset fit takes, and the longest span it
#: looks through for the end of the rise (:func:`_fit_onsets`).
ONSET_FIT_BEFORE = 6
ONSET_FIT_SPAN = 46
#: How noisy onsets are fitted (:func:`find_events`' ``onset_fit``): ``"scipy"``, one SciPy
#: ``least_squares`` per event (:func:`_fit_onset`; 5 ms each, 5 s for a 60 s recording), or
#: ``"batched"``, one Levenberg–Marquardt iteration over all events (:func:`_fit_onsets`; 50 to 100 times
#: faster, and at the minimum, where SciPy stops within its ``xtol`` of 1e-8 of ``k0``: the onsets differ
#: by 1e-5 to 2e-3 samples, more where SciPy stopped on a bound at a worse minimum). "batched" is the
#: default: it moved the old golden example's beta by 1e-5 relative, and the golden example
#: (tests/golden/estimate_example_fix_n.json) is made with it.
ONSET_FIT = "batched"
ONSET_FITS = ("scipy", "batched")
#: The onset fit's Levenberg–Marquardt iterations at most, and its stop: the scaled step below this
#: [-] (the parameters in units of their scales: ``c`` of its guess, ``t0`` of 1 sample, ``p`` of 0.5).
ONSET_FIT_ITERATIONS = 200
ONSET_FIT_STEP = 1e-12


def _fit_onsets(x: np.ndarray, baselines: list[_Quadratic], k0: np.ndarray, peak: np.ndarray, sigma: float,
                guess: np.ndarray) -> np.ndarray:
    """Onsets in sample units by least squares of ``c (k - t0)^p`` to the noisy rises, all events at once.

    Used when noise lifts the onset threshold: the three-sample solution then starts from a late
    first contact sample and cannot reach back more than one sample. Each event's fit takes the
    samples from :data:`ONSET_FIT_BEFORE` before ``k0`` to the first one above 30 % of the peak
    (within :data:`ONSET_FIT_SPAN`), with ``c >= 0``, ``t0`` in ``[k0 - 6, k0 + 1]`` and ``p`` in
    [1, 3], started from ``t0 = guess`` (kept 0.1 sample inside its bounds), ``p = 1.5``. The fits
    are one batched, bounded Levenberg–Marquardt iteration over all events (analytic Jacobian,
    variables scaled by ``c``'s guess, 1 sample and 0.5, bounds by projection with the active ones
    held), iterated until every step is below :data:`ONSET_FIT_STEP` of the scales: the minimum
    SciPy's ``least_squares`` (trf) finds, which stops earlier (``xtol`` 1e-8 of the parameters'
    norm, i.e. of ``k0``); tests/test_events_motion.py compares the two on noisy recordings.

    Parameters
    ----------
    x : the channel [m/s^2].
    baselines : each event's free-flight baseline before the pulse.
    k0 : each event's first contact sample.
    peak : each event's peak above its baseline [m/s^2].
    sigma : the channel's noise floor [m/s^2].
    guess : each event's onset from three samples [samples].

    Returns
    -------
    numpy.ndarray
        the onsets [samples]: ``guess`` where the rise has too few samples or the fit fails.
    """
    k0 = np.asarray(k0, dtype=np.int64)
    guess = np.asarray(guess, dtype=float)
    out = guess.copy()
    if k0.size == 0:
        return out
    lo = np.maximum(k0 - ONSET_FIT_BEFORE, 0)
    idx = lo[:, None] + np.arange(ONSET_FIT_SPAN)[None, :]
    inside = idx < np.minimum(k0 + 40, x.size)[:, None]
    idx = np.where(inside, idx, 0)
    coeffs = np.array([b.coeffs for b in baselines], dtype=float).reshape(-1, 3)
    centre = np.array([b.centre for b in baselines], dtype=float)
    u = idx - centre[:, None]
    dev = x[idx] - ((coeffs[:, :1] * u + coeffs[:, 1:2]) * u + coeffs[:, 2:3])  # polyval's Horner order
    high = inside & (dev > 0.3 * np.asarray(peak, dtype=float)[:, None])
    first = np.where(high.any(axis=1), np.argmax(high, axis=1), -1)
    ok = first >= 4
    if not ok.any():
        return out
    rows = np.flatnonzero(ok)
    span = (idx[rows] - k0[rows, None]).astype(float)  # sample index relative to k0
    dev = dev[rows]
    mask = np.arange(ONSET_FIT_SPAN)[None, :] <= first[rows, None]
    last = first[rows]
    span_last = span[np.arange(rows.size), last]
    t_guess = np.clip(guess[rows] - k0[rows], -ONSET_FIT_BEFORE + 0.1, 0.9)
    c_guess = np.maximum(dev[np.arange(rows.size), last], sigma) / np.maximum(span_last - t_guess, 1.0) ** 1.5
    scale = np.stack([c_guess, np.ones_like(c_guess), np.full_like(c_guess, 0.5)], axis=1)
    lower = np.stack([np.zeros_like(c_guess), np.full_like(c_guess, -float(ONSET_FIT_BEFORE)),
                      np.ones_like(c_guess)], axis=1)
    upper = np.stack([np.full_like(c_guess, np.inf), np.ones_like(c_guess), np.full_like(c_guess, 3.0)], axis=1)
    q = np.stack([c_guess, t_guess, np.full_like(c_guess, 1.5)], axis=1)

    def residual_and_jacobian(q: np.ndarray, with_jacobian: bool):
        c, t0, power = q[:, :1], q[:, 1:2], q[:, 2:3]
        gap = np.maximum(span - t0, 0.0)
        touching = gap > 0.0
        safe = np.where(touching, gap, 1.0)
        rise = np.where(touching, safe ** power, 0.0)
        r = np.where(mask, c * rise - dev, 0.0)
        if not with_jacobian:
            return r, None
        jac = np.empty(r.shape + (3,))
        jac[..., 0] = rise
        jac[..., 1] = np.where(touching, -c * power * rise / safe, 0.0)
        jac[..., 2] = c * rise * np.log(safe)
        jac *= (mask[..., None] * scale[:, None, :])  # in scaled variables
        return r, jac

    r, jac = residual_and_jacobian(q, True)
    cost = np.einsum("ij,ij->i", r, r)
    damping = np.full(rows.size, 1e-3)
    active = np.ones(rows.size, dtype=bool)
    eye = np.eye(3)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        for _ in range(ONSET_FIT_ITERATIONS):
            a = np.einsum("eji,ejk->eik", jac, jac)
            g = np.einsum("eji,ej->ei", jac, r)
            # bounds: a variable on its bound that the gradient pushes outwards is held
            held = ((q <= lower) & (g > 0.0)) | ((q >= upper) & (g < 0.0))
            keep = ~held
            a_free = a * keep[:, :, None] * keep[:, None, :] + eye * held[:, :, None]
            diag = np.einsum("eii->ei", a_free)
            system = a_free + damping[:, None, None] * eye * np.maximum(diag, 1e-300)[:, :, None]
            try:
                step = -np.linalg.solve(system, (g * keep)[..., None])[..., 0]
            except np.linalg.LinAlgError:
                break
            step = np.where(active[:, None] & np.isfinite(step), step, 0.0)
            trial = np.clip(q + step * scale, lower, upper)
            r_trial, _ = residual_and_jacobian(trial, False)
            cost_trial = np.einsum("ij,ij->i", r_trial, r_trial)
            better = active & np.isfinite(cost_trial) & (cost_trial <= cost)
            moved = np.max(np.abs(trial - q) / scale, axis=1)
            q = np.where(better[:, None], trial, q)
            cost = np.where(better, cost_trial, cost)
            damping = np.where(better, np.maximum(damping / 3.0, 1e-12), np.minimum(damping * 4.0, 1e12))
            active &= ~((moved < ONSET_FIT_STEP) | (damping >= 1e12))
            if not active.any():
                break
            r, jac = residual_and_jacobian(q, True)
    fitted = q[:, 1] + k0[rows]
    good = np.isfinite(fitted) & np.isfinite(cost)
    out[rows[good]] = fitted[good]
    return out


def _fit_onset(x: np.ndarray, baseline, k0: int, peak: float, sigma: float, guess: float) -> float:
    """Onset in sample units by least squares of ``c (k - t0)^p`` to the noisy rise (one SciPy
    ``least_squares`` call; :data:`ONSET_FIT` ``"scipy"``).

    Used when noise lifts the onset threshold: the three-sample solution then starts from a late
    first contact sample and cannot reach back more than one sample. The fit takes the samples
    from 6 before ``k0`` to the first one above 30 % of the peak, with ``t0`` in ``[k0 - 6, k0 + 1]``
    and ``p`` in [1, 3]. Returns ``guess`` when there are too few samples or the fit fails.
    """
    lo = max(k0 - 6, 0)
    span = np.arange(lo, min(k0 + 40, x.size))
    dev = x[span] - baseline(span)
    high = np.flatnonzero(dev > 0.3 * peak)
    if high.size == 0 or high[0] < 4:
        return guess
    span, dev = span[: high[0] + 1], dev[: high[0] + 1]

    def model(q):
        c, t0, p = q
        return c * np.power(np.maximum(span - t0, 0.0), p) - dev

    t_guess = min(max(guess, k0 - 5.9), k0 + 0.9)
    c_guess = max(dev[-1], sigma) / max(span[-1] - t_guess, 1.0) ** 1.5
    try:
        fit = optimize.least_squares(model, [c_guess, t_guess, 1.5], x_scale=[c_guess, 1.0, 0.5],
                                     bounds=([0.0, k0 - 6.0, 1.0], [np.inf, k0 + 1.0, 3.0]))
    except ValueError:
        return guess
    return float(fit.x[1]) if fit.success else guess


def find_events(recording: Recording, *, threshold: float | None = None, onset_threshold: float | None = None,
                channel: str = "accel_tangential", warn: bool = True, onset_fit: str | None = None) -> EventTable:
    """Find the impact events of a recording (see the module docstring for the method).

    Parameters
    ----------
    recording : the recording; needs ``channel`` (default the accelerometer) and, for the
        period-1 check, ``cam_speed_hz`` in its operating point.
    threshold : pulse-core detection level above the channel median [m/s^2] (overrides the
        noise-derived default).
    onset_threshold : deviation from the free-flight baseline that counts as contact [m/s^2].
    warn : issue an :class:`EventWarning` for each note (:attr:`EventTable.warnings`); callers that
        carry the notes on in their own result pass False.
    onset_fit : how noisy onsets are fitted, ``"scipy"`` or ``"batched"`` (None: :data:`ONSET_FIT`).
    """
    onset_fit = ONSET_FIT if onset_fit is None else onset_fit
    if onset_fit not in ONSET_FITS:
        raise ValueError(f"onset_fit must be one of {', '.join(ONSET_FITS)}; got {onset_fit!r}")
    recording.require(channel, method="event detection")
    x = recording[channel]
    rate = recording.sample_rate_hz
    where = recording.source or "recording"
    if x.size < MIN_SAMPLES:
        raise NoImpactsError(f"{where}: no impacts found in channel {channel!r}: the recording has only "
                             f"{x.size} samples (at least {MIN_SAMPLES} are needed for a pulse and its baselines)")
    sigma = noise_floor(x)
    level = float(np.median(x))
    lo_x, hi_x = recording.channel_range(channel)
    excursion = hi_x - level
    if hi_x == lo_x:
        raise NoImpactsError(f"{where}: no impacts found in channel {channel!r}: the channel is constant "
                             f"({hi_x:.6g} {recording.units.get(channel, '')}); is the sensor connected?")
    if level - lo_x > INVERTED_RATIO * max(excursion, 0.0):
        raise NoImpactsError(
            f"{where}: channel {channel!r} looks inverted: its largest excursion from the median is negative "
            f"({lo_x - level:.4g} against {excursion:+.4g}), but a contact pushes the follower towards "
            "increasing alpha, so impact pulses are positive (FORMAT: positive for increasing alpha); "
            "flip the sign of the channel")
    thr = float(threshold) if threshold is not None else max(10.0 * sigma, 0.02 * excursion)
    if not (math.isfinite(thr) and thr > 0.0):
        raise ValueError(f"threshold must be positive and finite, got {threshold!r}")
    # cores split by a few noisy samples are one pulse; never merged across a real free flight
    starts, ends = true_runs(x - level > thr, max_gap=CORE_GAP)
    saturated = _saturated_extremes(x, lo_x, hi_x)
    rows = []
    to_fit: list[tuple[int, _Quadratic, int, float, float]] = []  # (row, baseline, k0, peak, guess) of noisy rises
    for cs, ce in zip(starts, ends):
        peak_index = cs + int(np.argmax(x[cs:ce]))
        flags = {"truncated": False, "too_short": False, "overlapping": False, "clipped": False, "ringing": False}
        # onset: baseline before the core
        b_lo, b_hi = cs - BASELINE_GAP - BASELINE_LENGTH, cs - BASELINE_GAP
        search = np.arange(b_hi, cs + 1)
        before = _baseline(x, b_lo, b_hi)
        if before is None:
            flags["truncated"] = True
            rows.append(dict(onset_index=cs, t_onset=np.nan, separation_index=ce, t_separation=np.nan,
                             peak=float(x[peak_index] - level), contact_samples=ce - cs, **flags))
            continue
        base = before(search)
        dev = x[search] - base
        peak = float(x[peak_index] - base[-1])
        othr = float(onset_threshold) if onset_threshold is not None else max(5.0 * sigma, 1e-6 * abs(peak))
        # a band-limited rise: the first contact sample is the first above the filter's ringing ahead of it (the
        # separation keeps the threshold: the contact's own low end is not ringing)
        ringing = _ringing_level(dev, othr, peak, sigma) if onset_threshold is None else 0.0
        flags["ringing"] = ringing > othr
        rise_threshold = max(othr, ringing)
        below = np.flatnonzero(dev <= rise_threshold)
        k0 = int(search[below[-1]] + 1) if below.size else int(search[0])
        rise = x[k0:k0 + 3] - before(np.arange(k0, k0 + 3))
        t_on = _subsample_start(rise, k0, +1)
        # a noisy (or ringing) rise: its onset is fitted after the loop, all such events at once (_fit_onsets)
        fit_onset = rise_threshold > NOISY_ONSET * abs(peak)
        # separation: baseline after the pulse. The pulse may end with a tensile tail below the
        # baseline (a damping law with n < 1.5 pulls before the gap reopens) that lasts longer
        # than BASELINE_GAP beyond the positive core: the baseline window is moved on until its
        # first half is free of it (:func:`_clean_baseline_after`).
        limit = _next_core_start(starts, cs, x.size)
        after, a_lo = _clean_baseline_after(x, ce, othr, limit=limit)
        a_hi = a_lo + BASELINE_LENGTH
        search_a = np.arange(ce - 1, a_lo)
        if after is None:
            flags["truncated"] = True
            ka, t_sep = ce, float(ce)
        else:
            dev_a = np.abs(x[search_a] - after(search_a))
            above = np.flatnonzero(dev_a > othr)
            ka = int(search_a[above[-1]] + 1) if above.size else ce
            # a long low tail (a nearly plastic contact, a follower riding the cam) that the local
            # quadratic followed: the contact ends where the long free-flight baseline is reached
            block_thr = max(TAIL_SNR * sigma / math.sqrt(TAIL_BLOCK), 1e-6 * abs(peak))
            ka_end, long_baseline = _contact_end(x, ka, othr, block_thr, limit, rate, max(othr, TAIL_SNR * sigma))
            if long_baseline is not None:
                ka, after = ka_end, long_baseline
                a_hi = max(a_hi, ka + BASELINE_GAP + BASELINE_LENGTH)
            fall = x[ka - 3:ka][::-1] - after(np.arange(ka - 1, ka - 4, -1))
            t_sep = _subsample_start(fall, ka - 1, -1)
            if np.any(x[ka:a_hi] - level > thr):
                flags["overlapping"] = True
        flags["too_short"] = ka - k0 < 3
        if flags["too_short"] and ka > k0:
            # an impulse (instantaneous impact, e.g. the restitution model S3, docs/estimation.md): its
            # area sits in the samples around the impact time with linear-interpolation weights,
            # so the impact time is the centroid of the deviation
            dev_i = x[k0:ka] - before(np.arange(k0, ka))
            if np.all(dev_i > 0):
                t_on = t_sep = float(np.sum(np.arange(k0, ka) * dev_i) / np.sum(dev_i))
                fit_onset = False
        flags["clipped"] = bool(saturated.size and np.isin(x[k0:ka], saturated).sum() >= CLIP_RUN)
        if fit_onset:
            to_fit.append((len(rows), before, k0, peak, t_on))
        rows.append(dict(onset_index=k0, t_onset=recording.start_time_s + t_on / rate, separation_index=ka,
                         t_separation=recording.start_time_s + t_sep / rate, peak=peak, contact_samples=ka - k0,
                         **flags))
    if to_fit:
        where_rows, fit_baselines, fit_k0, fit_peak, fit_guess = zip(*to_fit)
        if onset_fit == "batched":
            fitted = _fit_onsets(x, list(fit_baselines), np.array(fit_k0), np.array(fit_peak), sigma,
                                 np.array(fit_guess))
        else:
            fitted = [_fit_onset(x, *args, sigma, guess) for args, guess in zip(zip(fit_baselines, fit_k0, fit_peak),
                                                                                  fit_guess)]
        for row, t_on in zip(where_rows, fitted):
            rows[row]["t_onset"] = recording.start_time_s + float(t_on) / rate
    if not rows:
        raise NoImpactsError(f"{where}: no impacts found in channel {channel!r} (no pulse rises {thr:.4g} "
                             f"{recording.units.get(channel, '')} above the median {level:.4g}; noise floor "
                             f"{sigma:.3g})")
    table = pd.DataFrame(rows, columns=["onset_index", "t_onset", "separation_index", "t_separation", "peak",
                                        "contact_samples", "truncated", "too_short", "overlapping", "clipped",
                                        "ringing"])
    table["onset_index"] = table["onset_index"].astype(np.int64)
    table["separation_index"] = table["separation_index"].astype(np.int64)
    table.insert(4, "t_next", np.append(table["t_onset"].to_numpy()[1:], np.nan))
    table.insert(5, "next_index", np.append(table["onset_index"].to_numpy()[1:], -1).astype(np.int64))
    table["spacing"] = table["t_next"] - table["t_onset"]
    table.loc[table.index[-1:], "truncated"] = True  # the last event has no next onset
    messages = _period_check(table, recording.cam_speed_hz, rate)
    table["usable"] = _usable(table)
    table.index.name = "event"
    for flag, text in (("clipped", "clipped pulses"), ("overlapping", "overlapping contacts")):
        bad = table.index[table[flag]].tolist()
        if bad:
            messages.append(f"{where}: {text} at events {_list(bad)}; they are not used")
    messages = [m if m.startswith(where) else f"{where}: {m}" for m in messages]
    if warn:
        for message in messages:
            warnings.warn(message, EventWarning, stacklevel=2)
    return EventTable(
        table=table, noise_sigma=sigma, threshold=thr,
        onset_threshold=float(onset_threshold) if onset_threshold is not None else max(5.0 * sigma, 0.0),
        sample_rate_hz=rate, start_time_s=recording.start_time_s, cam_speed_hz=recording.cam_speed_hz,
        warnings=tuple(messages),
        provenance=recording.provenance + (
            f"find_events(channel={channel!r}, threshold={thr:.6g}, noise_sigma={sigma:.6g}): {len(table)} events",))


def _usable(table: pd.DataFrame) -> np.ndarray:
    """Events whose kinematics can be integrated: complete and clean (not truncated, overlapping or
    clipped), with the onset that closes their window (``period_end``) found and every pulse in the
    window clean."""
    clean = ~(table["truncated"] | table["overlapping"] | table["clipped"]).to_numpy()
    inner_clean = ~(table["overlapping"] | table["clipped"]).to_numpy()
    onset_known = np.isfinite(table["t_onset"].to_numpy())
    ends = table["period_end"].to_numpy()
    out = np.zeros(len(table), dtype=bool)
    for i, j in enumerate(ends):
        out[i] = bool(clean[i] and j > i and onset_known[j] and inner_clean[i:j].all())
    return out


def _saturated_extremes(x: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """The channel's extreme values at which it is saturated: a saturated ADC piles samples on its
    end code (a run of :data:`CLIP_RUN` or more, and a spike in the histogram there), whereas a
    quantised smooth peak also repeats its extreme code but the next code inwards is about as
    populated (the criterion of :meth:`impactid.io.Recording.check`)."""
    out = []
    for extreme, upper in ((hi, True), (lo, False)):
        if extreme == 0.0:
            continue
        count, run, neighbour = extreme_stats(x, extreme, upper)
        if run >= CLIP_RUN and count > 3 * neighbour:
            out.append(extreme)
    return np.array(out)


def _plural(count: int, noun: str) -> str:
    """``"1 impact"``, ``"2 impacts"``."""
    return f"{count} {noun}{'' if count == 1 else 's'}"


def _list(indices, limit: int = 12) -> str:
    shown = ", ".join(str(i) for i in indices[:limit])
    return shown + (f", ... ({len(indices)} in all)" if len(indices) > limit else "")


def _motion_pattern(t_onset: np.ndarray, cam_speed_hz: float) -> tuple[int, int, np.ndarray]:
    """The cam-synchronous pattern of the onsets: ``(m, k, recurs)``.

    The cam turns at a constant speed, so in periodic motion of ``k`` revolutions with ``m`` impacts
    the onsets recur at the same cam phase every ``m`` events, ``k`` revolutions later: the spacing
    ``t[i + m] - t[i]`` is a whole number ``k`` of revolutions. The smallest ``m`` (up to
    :data:`MAX_PATTERN_EVENTS`, with at least ``m + 1`` comparisons in the recording) for which at
    least :data:`PATTERN_SHARE` of the spacings are ``k`` revolutions to :data:`PERIOD_TOLERANCE` of
    a revolution is the pattern; ``recurs[i]`` says whether onset ``i`` recurs ``m`` events later.
    ``(0, 0, all False)`` when no pattern fits (irregular motion). The test reads the motion (when the
    impacts happen against the cam), not the pulses' shape: a pulse that peaks within a few samples
    changes its sampled peak by several per cent from one impact to the next while the motion repeats.
    """
    n = t_onset.size
    revolutions = np.asarray(t_onset, dtype=float) * cam_speed_hz
    for m in range(1, MAX_PATTERN_EVENTS + 1):
        if n - m < m + 1:
            break
        spacing = revolutions[m:] - revolutions[:-m]
        whole = np.round(spacing)
        ok = np.isfinite(spacing) & (np.abs(spacing - whole) <= PERIOD_TOLERANCE) & (whole >= 1)
        if not ok.any():
            continue
        k = int(np.median(whole[ok]))
        ok &= whole == k
        if ok.mean() >= PATTERN_SHARE:
            recurs = np.zeros(n, dtype=bool)
            recurs[: n - m] = ok
            return m, k, recurs
    return 0, 0, np.zeros(n, dtype=bool)


def _period_check(table: pd.DataFrame, cam_speed_hz: float | None, rate: float) -> list[str]:
    """Flag chattering, non-recurring and riding events and set each event's period; return the notes.

    Columns set: ``chattering`` (the next or previous onset within half a revolution), ``periodic``
    (the onset recurs at the same cam phase one period of the motion later or earlier,
    :func:`_motion_pattern`), ``not_period1`` (the motion there is not one impact per revolution),
    ``riding`` (the contact lasts longer than :data:`RIDING_FRACTION` of a revolution) and
    ``period_end`` (the position of the event whose onset closes the event's integration window: one
    period of the motion later for a recurring onset, the next onset otherwise; -1 if none).
    """
    n = len(table)
    table["chattering"] = False
    table["not_period1"] = False
    table["periodic"] = False
    table["riding"] = False
    positions = np.arange(n)
    table["period_end"] = np.where(positions + 1 < n, positions + 1, -1).astype(np.int64)
    if cam_speed_hz is None:
        return ["no cam_speed_hz: the one-impact-per-revolution check is skipped"]
    period = 1.0 / cam_speed_hz
    duration = (table["t_separation"] - table["t_onset"]).to_numpy()
    table["riding"] = np.isfinite(duration) & (duration > RIDING_FRACTION * period)
    messages = []
    if table["riding"].any():
        riding = table.index[table["riding"]].tolist()
        longest = float(np.nanmax(duration[table["riding"].to_numpy()]))
        messages.append(
            f"the follower rides the cam after the impact at events {_list(riding)}: the contact lasts up to "
            f"{longest * 1e3:.3g} ms, {longest / period:.0%} of a cam revolution (an impact lasts at most "
            f"{RIDING_FRACTION:.0%}); the apex after it is set by the cam, not by the contact law")
    if n < 2:
        return messages
    spacing = table["spacing"].to_numpy()
    short = spacing < 0.5 * period
    chatter = short | np.concatenate(([False], short[:-1]))
    m, k, recurs = _motion_pattern(table["t_onset"].to_numpy(), cam_speed_hz)
    periodic = recurs.copy()
    if m:
        periodic[m:] |= recurs[:-m]
        # a recurring onset's window ends one period later; an onset of the pattern whose period is
        # not complete in the recording has none; the others (not recurring) end at the next onset
        ends = np.where(recurs, positions + m, np.where(periodic, n, positions + 1))
        table["period_end"] = np.where(ends < n, ends, -1).astype(np.int64)
    table["chattering"] = chatter
    table["periodic"] = periodic
    table["not_period1"] = ~periodic | (m != 1) | (k != 1)
    if chatter.any():
        messages.append(f"several contacts within one cam revolution (chattering) at events "
                        f"{_list(table.index[chatter].tolist())}")
    if m and (m, k) != (1, 1):
        impacts, revolutions = _plural(m, "impact"), _plural(k, "cam revolution")
        messages.append(
            f"the motion is period-{k}: {impacts} every {revolutions} of {period * 1e3:.4g} ms (the onsets recur at "
            f"the same cam phase {_plural(m, 'event')} later); each event is reconstructed over one period of the "
            f"motion, from its onset to the onset {_plural(m, 'event')} later, and replayed from its own onset state")
    lone = table.index[~periodic].tolist()
    if lone:
        what = ("the impacts do not recur with the cam: no pattern of up to "
                f"{MAX_PATTERN_EVENTS} impacts in a whole number of revolutions fits their onsets (irregular "
                "motion)" if not m else f"impacts do not recur with the cam at events {_list(lone)} (a transient, "
                "or irregular motion there)")
        messages.append(f"{what}: the per-event reconstruction takes an event's integration constants from the "
                        "follower's state recurring one period later, so these events' onset states cannot be "
                        "reconstructed and they are not used to estimate the contact law")
    return messages

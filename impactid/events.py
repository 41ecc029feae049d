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
   the deviation stays above ``onset_threshold`` (default ``max(5 sigma, 1e-6 x peak)``). The
   onset time ``t_onset`` is refined within the preceding sample interval by fitting the rise
   ``c (t - t0)^p`` (Hertz: ``p = 1.5`` at first touch) to the first three contact samples;
4. **separation** ``t_a``: the same from the other side (baseline after the pulse);
5. **next onset** ``t_e``: the onset of the following event.

Quality flags per event: ``truncated`` (no room for a baseline before the pulse, or no next
onset: not usable), ``too_short`` (fewer than 3 samples of contact: an impulse, i.e. an
instantaneous impact; its time is the centroid of the pulse and the reconstruction treats it as
a velocity jump), ``overlapping`` (the next
pulse starts within the post-contact baseline window), ``clipped`` (the pulse reaches the
channel's extreme value for 3 or more samples), ``chattering`` (more than one contact within one
cam revolution) and ``not_period1`` (spacing or pulse size differs from the neighbours: the
one-impact-per-revolution assumption of the anchoring step fails there). Events with the last
three flags are named in the result's notes (:attr:`EventTable.warnings`), which
:func:`find_events` issues as :class:`EventWarning`, each once, unless a caller that carries the
notes on in its own result (:func:`impactid.rigs.pivoted.reconstruct.reconstruct`) asks it not to.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy import optimize

from impactid._scan import extreme_stats
from impactid.io import CLIP_RUN, Recording, RecordingError
from impactid.signal import noise_floor, true_runs

__all__ = ["BASELINE_GAP", "BASELINE_LENGTH", "CORE_GAP", "INVERTED_RATIO", "MAX_BASELINE_MOVES", "MIN_SAMPLES",
           "NOISY_ONSET", "PEAK_TOLERANCE", "PERIOD_TOLERANCE", "EventTable", "EventWarning", "NoImpactsError",
           "find_events"]

#: Samples skipped between a baseline window and the pulse, and the baseline window length.
BASELINE_GAP = 16
BASELINE_LENGTH = 64
#: Relative tolerances of the period-1 check: spacing of onsets against one cam revolution, and
#: peak acceleration against the neighbouring events.
PERIOD_TOLERANCE = 0.01
PEAK_TOLERANCE = 0.03
#: Onset threshold, relative to the peak, above which the onset is fitted over the noisy rise
#: (:func:`_fit_onset`) rather than solved from three samples.
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
        ``contact_samples``, ``spacing`` [s] (``t_next - t_onset``), quality flags (bool columns)
        and ``usable`` (no flag that prevents the per-event kinematics).
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


def _baseline(x: np.ndarray, lo: int, hi: int):
    """Quadratic least-squares fit to ``x[lo:hi]``: a function of sample indices, or None if the
    window does not fit in the recording."""
    if lo < 0 or hi > x.size or hi - lo < 8:
        return None
    centre = 0.5 * (lo + hi)
    coeffs = np.polyfit(np.arange(lo, hi) - centre, x[lo:hi], 2)
    return lambda at: np.polyval(coeffs, np.asarray(at) - centre)


#: Most times the post-pulse baseline window is moved on past a tensile tail.
MAX_BASELINE_MOVES = 16


def _next_core_start(starts: np.ndarray, current: int, size: int) -> int:
    """Start of the pulse core after the one starting at ``current`` (``size`` if none)."""
    later = starts[starts > current]
    return int(later[0]) if later.size else size


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


def _subsample_start(r: np.ndarray, k_first: int, direction: int) -> float:
    """Sub-sample start of a power-law rise ``c |t - t0|^p`` from three deviations ``r``.

    ``r[0..2]`` are the deviations at samples ``k_first, k_first + direction, ...``. Returns the
    start in sample units (between ``k_first - direction`` and ``k_first``); falls back to the
    ``p = 1.5`` two-sample solution, then to the mid-point.
    """
    r1, r2, r3 = (abs(v) for v in r[:3])
    if not (0.0 < r1 < r2 < r3):
        return k_first - 0.5 * direction

    def mismatch(s):  # s = distance of the start before k_first, in samples, in (0, 1)
        p12 = math.log(r2 / r1) / math.log((1.0 + s) / s)
        p23 = math.log(r3 / r2) / math.log((2.0 + s) / (1.0 + s))
        return p12 - p23

    try:
        lo, hi = 1e-6, 1.0 - 1e-9
        if mismatch(lo) * mismatch(hi) < 0.0:
            s = optimize.brentq(mismatch, lo, hi, xtol=1e-12)
            p = math.log(r2 / r1) / math.log((1.0 + s) / s)
            if 0.5 <= p <= 4.0:
                return k_first - s * direction
    except (ValueError, ZeroDivisionError):
        pass
    rho = (r2 / r1) ** (1.0 / 1.5)  # (1 + s) / s = rho
    if rho > 1.0:
        s = 1.0 / (rho - 1.0)
        if 0.0 < s <= 1.0:
            return k_first - s * direction
    return k_first - 0.5 * direction


def _fit_onset(x: np.ndarray, baseline, k0: int, peak: float, sigma: float, guess: float) -> float:
    """Onset in sample units by least squares of ``c (k - t0)^p`` to the noisy rise.

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
                channel: str = "accel_tangential", warn: bool = True) -> EventTable:
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
    """
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
    for cs, ce in zip(starts, ends):
        peak_index = cs + int(np.argmax(x[cs:ce]))
        flags = {"truncated": False, "too_short": False, "overlapping": False, "clipped": False}
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
        below = np.flatnonzero(dev <= othr)
        k0 = int(search[below[-1]] + 1) if below.size else int(search[0])
        rise = x[k0:k0 + 3] - before(np.arange(k0, k0 + 3))
        t_on = _subsample_start(rise, k0, +1)
        if othr > NOISY_ONSET * abs(peak):
            t_on = _fit_onset(x, before, k0, peak, sigma, t_on)
        # separation: baseline after the pulse. The pulse may end with a tensile tail below the
        # baseline (a damping law with n < 1.5 pulls before the gap reopens) that lasts longer
        # than BASELINE_GAP beyond the positive core: the baseline window is moved on until its
        # first half is free of it (:func:`_clean_baseline_after`).
        after, a_lo = _clean_baseline_after(x, ce, othr, limit=_next_core_start(starts, cs, x.size))
        a_hi = a_lo + BASELINE_LENGTH
        search_a = np.arange(ce - 1, a_lo)
        if after is None:
            flags["truncated"] = True
            ka, t_sep = ce, float(ce)
        else:
            dev_a = np.abs(x[search_a] - after(search_a))
            above = np.flatnonzero(dev_a > othr)
            ka = int(search_a[above[-1]] + 1) if above.size else ce
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
        at_extreme = np.isin(x[k0:ka], saturated)
        flags["clipped"] = bool(at_extreme.sum() >= CLIP_RUN)
        rows.append(dict(onset_index=k0, t_onset=recording.start_time_s + t_on / rate, separation_index=ka,
                         t_separation=recording.start_time_s + t_sep / rate, peak=peak, contact_samples=ka - k0,
                         **flags))
    if not rows:
        raise NoImpactsError(f"{where}: no impacts found in channel {channel!r} (no pulse rises {thr:.4g} "
                             f"{recording.units.get(channel, '')} above the median {level:.4g}; noise floor "
                             f"{sigma:.3g})")
    table = pd.DataFrame(rows, columns=["onset_index", "t_onset", "separation_index", "t_separation", "peak",
                                        "contact_samples", "truncated", "too_short", "overlapping", "clipped"])
    table["onset_index"] = table["onset_index"].astype(np.int64)
    table["separation_index"] = table["separation_index"].astype(np.int64)
    table.insert(4, "t_next", np.append(table["t_onset"].to_numpy()[1:], np.nan))
    table.insert(5, "next_index", np.append(table["onset_index"].to_numpy()[1:], -1).astype(np.int64))
    table["spacing"] = table["t_next"] - table["t_onset"]
    table.loc[table.index[-1:], "truncated"] = True  # the last event has no next onset
    messages = _period_check(table, recording.cam_speed_hz)
    table["usable"] = ~(table["truncated"] | table["overlapping"] | table["clipped"])
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


def _list(indices, limit: int = 12) -> str:
    shown = ", ".join(str(i) for i in indices[:limit])
    return shown + (f", ... ({len(indices)} in all)" if len(indices) > limit else "")


def _period_check(table: pd.DataFrame, cam_speed_hz: float | None) -> list[str]:
    """Flag chattering and non-period-1 events; return warning texts naming them."""
    n = len(table)
    table["chattering"] = False
    table["not_period1"] = False
    if n < 2 or cam_speed_hz is None:
        return [] if cam_speed_hz is not None else ["no cam_speed_hz: the one-impact-per-revolution check is skipped"]
    period = 1.0 / cam_speed_hz
    spacing = table["spacing"].to_numpy()
    short = spacing < 0.5 * period
    chatter = short | np.concatenate(([False], short[:-1]))
    off_period = np.abs(spacing / period - 1.0) > PERIOD_TOLERANCE
    peaks = table["peak"].to_numpy()
    ref = np.median(peaks)
    jump = np.zeros(n, dtype=bool)
    jump[1:] |= np.abs(np.diff(peaks)) > PEAK_TOLERANCE * ref
    jump[:-1] |= np.abs(np.diff(peaks)) > PEAK_TOLERANCE * ref
    off_period &= np.isfinite(spacing)
    table["chattering"] = chatter
    table["not_period1"] = off_period | jump
    messages = []
    if chatter.any():
        messages.append(f"several contacts within one cam revolution (chattering) at events "
                        f"{_list(table.index[chatter].tolist())}")
    bad = table.index[table["not_period1"] & ~table["chattering"]].tolist()
    if bad:
        messages.append(
            f"impacts are not period-1 (one alike impact per cam revolution of {period * 1e3:.4g} ms) at events "
            f"{_list(bad)}: onset spacing or pulse size differs by more than {PERIOD_TOLERANCE:.0%} / "
            f"{PEAK_TOLERANCE:.0%}; the return-time anchor assumes period-1 motion there")
    return messages

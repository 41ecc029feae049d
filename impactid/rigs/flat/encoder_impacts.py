"""Impacts of rig F seen by its encoders, and the coefficient of restitution against cam speed.

Alzate et al. (2007) (section 5.1) takes ``r`` as a linear function of the cam speed, each value estimated
from impacting runs between 130 and 155 rpm. This module measures it from encoder recordings
(``cam_angle``, ``follower_angle``) in two ways and fits ``r = a + b omega``.

Relative motion
    ``d(t) = theta_f(t) - theta_hat(theta_c(t) + offset)`` with ``theta_hat`` a cam profile: a
    fitted :class:`~impactid.rigs.flat.camprofile.GaussianSumProfile` (``impactid cam-fit``) or the rig's
    analytic contact angle (A-17). The follower can never be inside the cam, so ``d >= 0`` and
    ``d = 0`` while it rides the cam; ``offset`` (the cam-encoder zero relative to the profile's
    convention) is the value that puts the riding samples on ``d = 0`` (:func:`align_profile`).
    At contact ``h_dot = (dh/dtheta_f) d_dot`` exactly (because ``h(theta_hat(theta_c), theta_c) = 0``),
    so the restitution law ``h_dot+ = -r h_dot-`` reads ``d_dot+ = -r d_dot-``: the geometry of the
    rig is not needed, only the profile.

Impact-law method (:func:`first_impacts`)
    Each cam revolution of impacting motion has one long flight (the follower leaves the cam,
    flies, lands); the landing is the *first impact*, followed by a first bounce and a chattering
    sequence. The follower's angle before and after the first impact is fitted jointly with
    ``theta_f = theta_1 + w- tau + A tau^2 / 2 + kappa w- tau^3 / 6`` (``tau < 0``) and the same with
    ``w+`` (``0 < tau`` < the bounce's end), ``tau = t - t_1``, by nonlinear least squares over
    ``(t_1, w-, w+, A, kappa)``: the impact is on the profile (``theta_1 = theta_hat(theta_c(t_1))``),
    the acceleration ``A`` is continuous through it and the jerk of each side is ``kappa w-+`` (the free
    flight is autonomous, ``theta_ddot = f(theta)``, so the jerk is ``f'(theta) theta_dot``); the relative
    rates are ``v = w - omega theta_hat'``. Fitting 25 ms either side (the count crossings below)
    instead of differencing quantised counts gives ``r = -v+ / v-`` to about 1e-3. The
    first bounce's height is the maximum of the fitted bounce.

First-bounce method (:func:`restitution_at_speed` with ``method="first-bounce"``)
    The seed's own method: ``r`` is the value for which the model's steady motion at that cam
    speed has the observed first-bounce height. It needs the rig's model (A-10, A-17) and is as
    good as that model; the impact-law method needs only the profile.

Encoder quantisation: counts are floors of the angle, so half a count is added before use (the
quantisation error then has zero mean; :func:`impactid.rigs.flat.encoders.read_counter`).

Count crossings (:class:`_ImpactFit`): near an impact the follower often moves far less than one count
per sample (about 1/85 count per sample after a 150 rpm impact with r = 0.5), so its samples are a
staircase of two or three levels whose error is one slowly changing function of time, the same at
every revolution of a period-1 motion, and a smooth fit through the samples errs alike at every impact
(-2.45e-2 in r there). Where the follower moves less than a count per sample the fit uses the count
changes instead: each is a crossing of a known level (the count boundary) within a known sample
interval, fitted at the interval's middle with the error ``|theta_dot| dt / sqrt(12)``; samples are
used where it moves faster. The jerk either side is ``kappa w-+`` (the free flight is autonomous, A-10).

The pipeline's own error of a point (:data:`RESTITUTION_SYSTEMATIC`, :data:`RESTITUTION_SINGLE_IMPACT`):
part of the error is common to a recording's first impacts, which the scatter over its revolutions does
not show. The rest depends on where each impact falls between samples; it averages over revolutions
when the impacts' sub-sample phases spread (:func:`phase_spread`), and not when a revolution is a whole
number of samples (150 rpm at 20 kHz: 8000 samples, every impact at one phase, a standard error of
1e-8). Each point carries the floor that applies (:attr:`RestitutionAtSpeed.systematic`: the averaged
floor, or one impact's error when the phases do not spread; :func:`systematic_error`), and the speed law
is weighted by, and checked against, ``sqrt(stderr^2 + systematic^2)`` (:func:`fit_speed_law`).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd
from scipy import optimize, stats

from impactid.engine import (
    Free,
    Uncertainty,
    check_model,
    combine_checks,
    compare_models,
    identifiability,
    residual_against_noise,
    search,
    uncertainty,
)
from impactid.errors import ImpactidError
from impactid.io import Recording
from impactid.results import FitResult
from impactid.rigs.flat import MODEL_NAME, FlatFollowerRig
from impactid.rigs.flat.encoders import CounterReading, read_counter

__all__ = ["BOUNCE_SEARCH", "FIT_WINDOW_S", "FLIGHT_THRESHOLD_COUNTS", "IMPACT_GUARD_SAMPLES", "LAWS", "METHODS",
           "PHASE_SPREAD_MIN", "RESTITUTION_SINGLE_IMPACT", "RESTITUTION_SYSTEMATIC", "SMOOTHING_S",
           "SYSTEMATIC_FOLLOWER_STEP", "SYSTEMATIC_SAMPLE_RATE_HZ", "EncoderImpactError", "EncoderImpactWarning",
           "RelativeMotion", "RestitutionAtSpeed", "SpeedLawResult", "align_profile", "first_impacts",
           "fit_speed_law", "phase_spread", "refine_offset", "relative_motion", "restitution_at_speed",
           "simulated_first_bounce", "systematic_error"]

#: Joint-fit window on each side of a first impact [s]: long enough for hundreds of samples, short
#: enough that a cubic describes the smooth free flight (and the cam's motion) to far below a count.
FIT_WINDOW_S = 0.025
#: The first bounce's end is searched for up to this many fit windows after the impact.
BOUNCE_SEARCH = 4
#: Samples next to the impact left out of the fit (the sample straddling it mixes both sides).
IMPACT_GUARD_SAMPLES = 1.5
#: A flight rises more than this many follower counts above the cam.
FLIGHT_THRESHOLD_COUNTS = 3.0
#: Moving-average length that smooths the quantisation sawtooth before flights are located [s]
#: (detection only: the fits use the raw samples).
SMOOTHING_S = 0.002
#: The pipeline's own error of one point's ``r`` [-], a standard deviation, where the point's first impacts fall at
#: sub-sample phases that spread (:func:`phase_spread` at least :data:`PHASE_SPREAD_MIN`): the error common to its
#: impacts (module doc), which their scatter (the point's ``stderr``) does not show. Measured with the
#: count-crossing fit (:func:`first_impacts`) on noise-free ``synth_flat_impacting`` recordings (4 s, 20 kHz,
#: encoders 5000/10 000 ppr, cam zero 0.5 + rpm/77 rad), r = 0.40, 0.45, ..., 0.70 at 128, 130, ..., 152, 145 and
#: 150 rpm and r = 0.42, 0.47, ..., 0.67 at 129, 131, 133.33, 135, 137, 139, 141.18, 143, 147, 149 and 150 rpm: over
#: the 145 period-1 points (8 first impacts or more) (20 of them phase-locked) error RMS 1.0e-3, 95th percentile
#: 1.7e-3, largest 7.1e-3 (150 rpm, r 0.65, stderr 2.9e-3), 5.2e-3 (149 rpm, r 0.62, stderr 1.2e-3) and 4.5e-3 (146
#: rpm, r 0.65, stderr 1.1e-4): each within 1.9 of its point's error with this floor. The previous per-impact fit
#: (samples, shared jerk) on the first grid: RMS 4.3e-3, largest 2.45e-2 (150 rpm, r 0.50). Measured by a loop of
#: ``synth_flat_impacting`` and ``restitution_at_speed`` over those grids; ``python benchmarks/validate_rig_f.py``
#: (section "The pipeline's own error of r") repeats it on its own grids at 10, 20 and 40 kHz and 2000/4000 ppr.
RESTITUTION_SYSTEMATIC = 2.5e-3
#: One first impact's error of ``r`` [-], the floor of a point whose impacts' sub-sample phases do not spread (a
#: revolution of a whole number of samples: every impact errs alike, the scatter over revolutions is ~1e-8 and the
#: error does not average). Measured on the impacts of the second grid above (571 first impacts at phases spread by
#: the sampling, 20 kHz): ``|r_i - r|`` median 6.2e-4, 95th percentile 2.4e-3, 99th percentile 5.6e-3, largest
#: 1.1e-2; this is the 99th percentile, so that one impact's error is covered without averaging (the 95th percentile
#: alone is the averaged floor). The phase-locked points of those grids (150, 141.18 and 133.33 rpm: 8000, 8500 and
#: 9000 samples a revolution) erred by at most 2.1e-3. On the validation page's own 20 kHz grid (91 points, 32 of
#: them with phases that do not spread) the 95th percentile is 3.2e-3, and no point errs by more than 2 point
#: errors. At 40 kHz (75 points) the 95th / 99th percentiles are 2.2e-3 / 4.7e-3, at 10 kHz 5.3e-3 / 9.8e-3: both
#: floors grow as ``1 / sample rate`` below :data:`SYSTEMATIC_SAMPLE_RATE_HZ` and are kept above it
#: (:func:`systematic_error`).
RESTITUTION_SINGLE_IMPACT = 5.5e-3
#: The impacts' sub-sample phases spread over at least this fraction of the sample interval
#: (:func:`phase_spread`) for their errors to average (``n`` phases at random spread over ``1 - ln(n)/n``,
#: 0.74 for 9 impacts; a recording locked to the samples over less than 1e-3).
PHASE_SPREAD_MIN = 0.5
#: The sample rate [Hz] at which the floors were measured.
SYSTEMATIC_SAMPLE_RATE_HZ = 20_000.0
#: The follower count [rad] at which :data:`RESTITUTION_SYSTEMATIC` was measured (10 000 ppr). With
#: 4000 ppr (2.5 times coarser) the previous fit's points of the same grid erred up to 6 times more: a
#: coarser encoder's floor grows with the square of its count (:func:`systematic_error`; the validation
#: page measures it for this fit).
SYSTEMATIC_FOLLOWER_STEP = 2.0 * math.pi / 10_000


class EncoderImpactError(ImpactidError, ValueError):
    """An encoder recording cannot give impacts (missing channel, no flight, no riding, ...)."""


class EncoderImpactWarning(UserWarning):
    """An impact measurement is doubtful (few impacts, scattered estimates, method outside its range)."""


def _channel(recording: Recording, name: str) -> CounterReading:
    """An encoder channel read as a floor counter (:func:`impactid.rigs.flat.encoders.read_counter`:
    half a count added when it is quantised)."""
    if name not in recording.channels:
        raise EncoderImpactError(f"{recording.source or 'recording'}: channel {name!r} is missing "
                                 "(rig F impacts need 'cam_angle' and 'follower_angle')")
    return read_counter(recording.channels[name], "floor")


def _analytic_profile(recording: Recording):
    if getattr(recording.rig, "model", None) != MODEL_NAME:
        raise EncoderImpactError(f"{recording.source or 'recording'}: no cam profile given and the rig is not a "
                                 "flat-follower rig with an analytic profile; pass a fitted profile (impactid cam-fit)")
    return recording.rig.contact_angle


def align_profile(theta_c: np.ndarray, theta_f: np.ndarray, profile, tolerance: float,
                  coarse: int = 720, subsample: int = 4000) -> float:
    """Cam-angle offset [rad] that puts the riding samples on the profile.

    A coarse scan over ``coarse`` offsets maximises the number of samples within ``tolerance`` of
    the profile (riding samples; flight samples lie above it); the best offset is refined by least
    squares on the riding samples. Raises :class:`EncoderImpactError` when fewer than 5 % of the
    samples ride the cam at the best offset.
    """
    stride = max(1, theta_c.size // subsample)
    tc, tf = theta_c[::stride], theta_f[::stride]
    offsets = np.linspace(0.0, 2.0 * math.pi, coarse, endpoint=False)
    scores = [np.count_nonzero(np.abs(tf - profile(tc + off)) < tolerance) for off in offsets]
    best = float(offsets[int(np.argmax(scores))])
    if max(scores) < 0.05 * tc.size:
        raise EncoderImpactError("the follower never rides the cam profile (fewer than 5 % of samples within "
                                 f"{tolerance:.3g} rad of it at any cam offset): wrong profile or no contact phases")
    # refine by least squares on the riding samples, re-selected with a tighter band each time:
    # flight samples lie above the profile only, so a loose band would bias the offset
    for band in (2.0, 1.0, 0.5, 0.5):
        riding = np.abs(theta_f - profile(theta_c + best)) < band * tolerance
        tc_r, tf_r = theta_c[riding], theta_f[riding]
        res = optimize.least_squares(lambda x, tc_r=tc_r, tf_r=tf_r: tf_r - profile(tc_r + x[0]), [best])
        best = float(res.x[0])
    return float(np.mod(best, 2.0 * math.pi))


@dataclass(frozen=True)
class RelativeMotion:
    """Follower angle relative to the cam profile.

    Attributes
    ----------
    t : sample times [s]; theta_c, theta_f : cam and follower angles [rad] (half a count added)
    relative : ``theta_f - theta_hat(theta_c + offset)`` [rad] (>= 0 up to quantisation)
    offset : cam-angle offset between the recording and the profile [rad]
    follower_step, cam_step : encoder counts [rad] (0 when not quantised)
    cam_speed_hz : mean cam speed [Hz] (slope of the cam angle)
    source : the recording's source
    """

    t: np.ndarray
    theta_c: np.ndarray
    theta_f: np.ndarray
    relative: np.ndarray
    offset: float
    follower_step: float
    cam_step: float
    cam_speed_hz: float
    source: str
    profile: object = field(repr=False)


def relative_motion(recording: Recording, profile=None, offset: float | None = None) -> RelativeMotion:
    """Relative motion ``theta_f - theta_hat(theta_c + offset)`` of a rig F encoder recording.

    ``profile`` is any callable ``theta_hat(theta_c, derivatives=0|1|2)`` (a fitted
    :class:`~impactid.rigs.flat.camprofile.GaussianSumProfile`); default the rig's analytic A-17.
    ``offset`` [rad] defaults to the fitted alignment (:func:`align_profile`).
    """
    cam, follower = _channel(recording, "cam_angle"), _channel(recording, "follower_angle")
    theta_c, theta_f = cam.angle, follower.angle
    profile = _analytic_profile(recording) if profile is None else profile
    t = recording.start_time_s + np.arange(theta_c.size) / recording.sample_rate_hz
    slope = float(np.polyfit(t - t[0], theta_c, 1)[0])
    if not slope > 0.0:
        raise EncoderImpactError(f"{recording.source or 'recording'}: channel 'cam_angle' does not increase "
                                 f"(mean cam speed {slope / (2 * math.pi):.4g} Hz)")
    f_step = follower.step or 0.0
    tolerance = max(1.5 * f_step, 2e-4)
    if offset is None:
        offset = align_profile(theta_c, theta_f, profile, tolerance)
    return RelativeMotion(t=t, theta_c=theta_c, theta_f=theta_f, relative=theta_f - profile(theta_c + offset),
                          offset=float(offset), follower_step=f_step, cam_step=cam.step or 0.0,
                          cam_speed_hz=slope / (2.0 * math.pi), source=recording.source or "", profile=profile)


def _follower_model(x, tau_pre, tau_post):
    """Free flight of the follower either side of the impact, to third order in ``tau``: shared angle at
    the impact (on the profile) and acceleration; rates ``w-`` before and ``w+`` after; the jerk of each
    side ``kappa w-+`` with one shared ``kappa``."""
    theta1, wm, wp, acc, kappa = x
    a, b = tau_pre, tau_post
    return (theta1 + wm * a + 0.5 * acc * a * a + kappa * wm * a**3 / 6.0,
            theta1 + wp * b + 0.5 * acc * b * b + kappa * wp * b**3 / 6.0)


def _follower_rate(x, tau, after):
    """The rate of :func:`_follower_model` [rad/s] at ``tau`` on one side of the impact."""
    _, wm, wp, acc, kappa = x
    w = wp if after else wm
    return w + acc * tau + 0.5 * kappa * w * tau * tau


class _ImpactFit:
    """Joint least-squares fit of the follower's free flight before and after one first impact.

    Unknowns: the impact time ``t_1``, the follower rates ``w-`` and ``w+`` [rad/s], its
    acceleration ``A`` and ``kappa`` [1/s^2]. The flight is autonomous (A-10: ``theta_ddot = f(theta)``,
    no damping), so the follower's angle and acceleration are continuous through the impact and its
    jerk on either side is ``f'(theta_1) w-+``: one unknown, ``kappa = f'(theta_1)``, gives the jerk
    of both sides (the module doc's ``c-, c+`` without a free parameter each). The angle at ``t_1`` is
    not free: the impact is on the profile, ``theta_f(t_1) = theta_hat(theta_c(t_1))``. The relative
    rates follow with the profile's analytic derivative, ``d_dot = w - omega theta_hat'``.

    Observations of a quantised follower (:meth:`observations`): where the follower moves less than
    one count per sample, the samples' quantisation error is one slowly changing staircase, the same at
    every revolution of a period-1 motion; the information is in the count changes instead, each a
    crossing of a known level (the count boundary) within a known sample interval. Such a crossing is
    fitted at the interval's middle (error ``|theta_dot| dt / sqrt(12)``), a sample (half a count
    added) where the follower moves faster (error ``count / sqrt(12)``), each weighted by its error.
    """

    def __init__(self, t, theta_f, cam_line, profile, step):
        self.t, self.theta_f, self.cam_line, self.profile, self.step = t, theta_f, cam_line, profile, step
        self.dt = float(np.median(np.diff(t)))
        if step > 0.0:
            jump = np.rint(np.diff(theta_f) / step)
            self.crossing = np.flatnonzero(np.abs(jump) == 1.0)
            self.t_cross = 0.5 * (t[self.crossing] + t[self.crossing + 1])
            self.level = 0.5 * (theta_f[self.crossing] + theta_f[self.crossing + 1])
        else:
            self.crossing, self.t_cross, self.level = (np.empty(0, dtype=int), np.empty(0), np.empty(0))

    def cam(self, time):
        return self.cam_line[0] + self.cam_line[1] * time

    def observations(self, x, t_lo, t_hi):
        """``(times, values, weights, after)`` of the observations between ``t_lo`` and ``t_hi`` (samples,
        or count crossings where the fitted follower ``x`` moves less than a count per sample)."""
        t1 = x[0]
        in_span = (self.t > t_lo) & (self.t < t_hi)
        if self.step <= 0.0:
            times = self.t[in_span]
            return times, self.theta_f[in_span], np.ones(times.size), times > t1
        after = self.t > t1
        rate = np.where(after, _follower_rate(x, self.t - t1, True), _follower_rate(x, self.t - t1, False))
        fast = in_span & (np.abs(rate) * self.dt >= self.step)
        tc = self.t_cross
        crate = np.where(tc > t1, _follower_rate(x, tc - t1, True), _follower_rate(x, tc - t1, False))
        slow = (tc - 0.5 * self.dt > t_lo) & (tc + 0.5 * self.dt < t_hi) & (np.abs(crate) * self.dt < self.step)
        sd_cross = np.sqrt((crate[slow] * self.dt) ** 2 / 12.0 + (1e-3 * self.step) ** 2)
        times = np.concatenate((self.t[fast], tc[slow]))
        values = np.concatenate((self.theta_f[fast], self.level[slow]))
        weights = np.concatenate((np.full(np.count_nonzero(fast), math.sqrt(12.0) / self.step), 1.0 / sd_cross))
        return times, values, weights, times > t1

    def model(self, x, times, after):
        t1 = x[0]
        theta1 = float(self.profile(self.cam(t1)))
        pre, post = _follower_model((theta1, *x[1:]), times[~after] - t1, times[after] - t1)
        out = np.empty(times.size)
        out[~after], out[after] = pre, post
        return out

    def residual(self, x, times, values, weights, after):
        # the side of each observation is fixed for the pass (``after``), not moved with t_1
        return (values - self.model(x, times, after)) * weights

    def bounce(self, x, span):
        """``(end, height)`` of the first bounce: where the fitted flight after the impact meets the
        profile again (first crossing on a 2000-point grid, refined by brentq) and its highest point
        above the profile [s, rad]."""
        t1 = x[0]
        theta1 = float(self.profile(self.cam(t1)))

        def gap(tau):
            _, post = _follower_model((theta1, *x[1:]), np.empty(0), np.atleast_1d(tau))
            return post - self.profile(self.cam(t1 + np.atleast_1d(tau)))

        grid = np.linspace(0.0, span, 2001)[1:]
        g = gap(grid)
        neg = np.flatnonzero(g < 0.0)
        if neg.size == 0 or neg[0] == 0:
            return math.inf, float(g.max()) if g.size else math.nan
        k = int(neg[0])
        end = optimize.brentq(lambda s: float(gap(s)[0]), grid[k - 1], grid[k], xtol=1e-12)
        return end, float(g[:k].max())


def first_impacts(motion: RelativeMotion, window_s: float = FIT_WINDOW_S,
                  threshold_counts: float = FLIGHT_THRESHOLD_COUNTS):
    """The first impact of every flight: impact time, relative rates, ``r``, first-bounce height.

    Returns a pandas DataFrame with one row per flight that ends in a measurable impact:
    ``t_impact`` [s], ``cam_angle`` [rad], ``flight_height`` [rad] (highest point of the flight),
    ``rate_before``, ``rate_after`` [rad/s] (relative, ``d_dot``), ``restitution`` [-],
    ``bounce_height`` [rad], ``bounce_duration`` [s], ``rms_residual`` [rad], ``n_before``,
    ``n_after`` (samples fitted).
    """
    import pandas as pd
    from scipy import ndimage, signal

    t, d = motion.t, motion.relative
    fs = 1.0 / float(np.median(np.diff(t)))
    count = motion.follower_step if motion.follower_step > 0.0 else 1e-4
    guard = IMPACT_GUARD_SAMPLES / fs
    # The flights: one highest peak of the (quantisation-smoothed) relative angle per half
    # revolution at least; the landing guess is where the smoothed descent reaches one count.
    smooth = ndimage.uniform_filter1d(d, max(1, int(round(SMOOTHING_S * fs))), mode="nearest")
    peaks, _ = signal.find_peaks(smooth, height=threshold_counts * count,
                                 distance=max(1, int(0.5 * fs / motion.cam_speed_hz)))
    rows = []
    for peak in peaks:
        below = np.flatnonzero(smooth[peak:] < count)
        if below.size == 0 or peak < 10:
            continue  # flight cut by the recording's ends
        i0, i1 = int(peak), int(peak + below[0])
        if i1 >= t.size - 2:
            continue
        pre = slice(max(i0, int(i1 - window_s * fs)), i1)
        if pre.stop - pre.start < 10:
            continue
        # first guesses: a parabola through the flight's last samples, extrapolated to the profile
        local = slice(max(0, i1 - int(window_s * fs)), min(t.size, i1 + int(window_s * fs)))
        # cam angle in the profile's convention, a local straight line (constant cam speed)
        cam_line = np.polyfit(t[local] - t[i1], motion.theta_c[local] + motion.offset, 1)[::-1]
        fit = _ImpactFit(t - t[i1], motion.theta_f, cam_line, motion.profile, motion.follower_step)
        c2, c1, c0 = np.polyfit(fit.t[pre], motion.theta_f[pre], 2)
        probe = np.linspace(-0.002, 0.01, 1201)
        above = np.polyval([c2, c1, c0], probe) - motion.profile(fit.cam(probe))
        cross = np.flatnonzero((above[:-1] > 0.0) & (above[1:] <= 0.0))
        if cross.size == 0:
            continue
        t1 = float(probe[cross[0]])
        omega = cam_line[1]
        wm = 2.0 * c2 * t1 + c1
        cam_rate = omega * float(motion.profile(fit.cam(t1), derivatives=1)[1])
        x = np.array([t1, wm, cam_rate - 0.6 * (wm - cam_rate), 2.0 * c2, 0.0])
        # the bounce is looked for up to BOUNCE_SEARCH windows on; at most one window is fitted
        span_post = fit.bounce(x, BOUNCE_SEARCH * window_s)[0]
        ok = False
        for attempt in range(8):
            # the observations (samples or count crossings) and their sides follow the fit: re-chosen
            # each pass, at least twice
            pre_obs = fit.observations(x, max(x[0] - window_s, fit.t[i0] - 0.5 * fit.dt), x[0] - guard)
            post_obs = fit.observations(x, x[0] + guard, x[0] + min(span_post - guard, window_s))
            n_pre, n_post = pre_obs[0].size, post_obs[0].size
            if n_pre < 10 or n_post < 2:
                ok = False
                break
            obs = tuple(np.concatenate(pair) for pair in zip(pre_obs, post_obs, strict=True))
            res = optimize.least_squares(fit.residual, x, args=obs, method="lm", x_scale="jac")
            x = res.x
            end, height = fit.bounce(x, BOUNCE_SEARCH * window_s)
            ok = math.isfinite(end) and res.success
            if not ok:
                break
            converged = abs(end - span_post) < guard and attempt > 0
            span_post = end
            if converged:
                break
        if not ok:
            continue
        t1 = float(x[0])
        if span_post > window_s:
            # a bounce longer than the fit window: its height from a cubic fitted to the whole bounce
            whole = (fit.t > t1 + guard) & (fit.t < t1 + span_post - guard)
            coef = np.polyfit(fit.t[whole] - t1, motion.theta_f[whole], 3)
            apex = np.linspace(0.0, span_post, 2001)
            height = float(np.max(np.polyval(coef, apex) - motion.profile(fit.cam(t1 + apex))))
        cam_rate = omega * float(motion.profile(fit.cam(t1), derivatives=1)[1])
        rate_before, rate_after = float(x[1]) - cam_rate, float(x[2]) - cam_rate
        if not rate_before < 0.0 < rate_after:
            continue
        rows.append({
            "t_impact": t1 + t[i1],
            "cam_angle": float(fit.cam(t1) - motion.offset),
            "flight_height": float(d[i0:i1].max()),
            "rate_before": rate_before,
            "rate_after": rate_after,
            "restitution": -rate_after / rate_before,
            "bounce_height": height,
            "bounce_duration": span_post,
            "rms_residual": float(np.sqrt(np.mean((res.fun / obs[2]) ** 2))),
            "n_before": n_pre,
            "n_after": n_post,
        })
    return pd.DataFrame(rows, columns=["t_impact", "cam_angle", "flight_height", "rate_before", "rate_after",
                                       "restitution", "bounce_height", "bounce_duration", "rms_residual",
                                       "n_before", "n_after"])


def refine_offset(motion: RelativeMotion, impacts) -> float:
    """Cam offset [rad] refitted on samples that certainly ride the cam.

    :func:`align_profile` cannot tell riding samples from the tail of a chattering sequence whose
    bounces are lower than a count; those lie above the profile only and bias the offset (by about
    0.6 mrad of cam angle at 130 rpm). With the first impacts measured, each flight, its first
    bounce and the chattering that follows are excluded: the sequence of bounces after a bounce of
    duration ``T_b`` with restitution ``r`` lasts about ``T_b / (1 - r)`` (constant relative
    acceleration), and 1.5 times that is cut. The offset is then least squares on the rest.
    """
    t = motion.t
    keep = np.ones(t.size, dtype=bool)
    period = 1.0 / motion.cam_speed_hz
    for row in impacts.itertuples():
        r = min(max(float(row.restitution), 0.0), 0.95)
        end = row.t_impact + 1.5 * row.bounce_duration / (1.0 - r)
        start = row.t_impact - 0.5 * period  # the flight (at most half a revolution before landing)
        keep &= ~((t > start) & (t < end))
    tolerance = max(0.75 * motion.follower_step, 1e-4)
    riding = keep & (np.abs(motion.relative) < tolerance)
    if np.count_nonzero(riding) < 100:
        return motion.offset
    profile = motion.profile
    res = optimize.least_squares(lambda x: motion.theta_f[riding] - profile(motion.theta_c[riding] + x[0]),
                                 [motion.offset])
    return float(np.mod(res.x[0], 2.0 * math.pi))


# ---------------------------------------------------------------------------------------------
# r at one cam speed, and the law over speeds
# ---------------------------------------------------------------------------------------------

METHODS = ("impact-law", "first-bounce")


@dataclass(frozen=True)
class RestitutionAtSpeed:
    """Coefficient of restitution measured at one cam speed.

    Attributes
    ----------
    cam_speed_hz : mean cam speed [Hz]
    restitution, stderr : estimate and its standard error [-]
    method : "impact-law" or "first-bounce"
    n_impacts : first impacts used
    bounce_height : median first-bounce height [rad]
    impacts : per-impact table (:func:`first_impacts`)
    source : recording
    warnings : doubts about this value
    systematic : the pipeline's own error of ``restitution`` [-] (:func:`systematic_error`), common to
        its impacts and so not in ``stderr``; NaN: :data:`RESTITUTION_SYSTEMATIC`
    phase_spread : spread of the impacts' sub-sample phases [-] (:func:`phase_spread`; NaN: unknown)
    """

    cam_speed_hz: float
    restitution: float
    stderr: float
    method: str
    n_impacts: int
    bounce_height: float
    impacts: object = field(repr=False)
    source: str = ""
    warnings: tuple[str, ...] = ()
    systematic: float = math.nan
    phase_spread: float = math.nan

    @property
    def cam_speed_rpm(self) -> float:
        return self.cam_speed_hz * 60.0

    @property
    def measurement_error(self) -> float:
        """The point's whole standard error [-]: ``sqrt(stderr^2 + systematic^2)`` (NaN when ``stderr`` is)."""
        floor = self.systematic if math.isfinite(self.systematic) else RESTITUTION_SYSTEMATIC
        return math.hypot(self.stderr, floor) if math.isfinite(self.stderr) else math.nan

    def to_dict(self) -> dict:
        return {"source": self.source, "cam_speed_hz": self.cam_speed_hz, "cam_speed_rpm": self.cam_speed_rpm,
                "method": self.method, "restitution": self.restitution, "stderr": self.stderr,
                "systematic": self.systematic if math.isfinite(self.systematic) else RESTITUTION_SYSTEMATIC,
                "phase_spread": self.phase_spread, "n_impacts": self.n_impacts,
                "bounce_height_rad": self.bounce_height, "warnings": list(self.warnings)}


def phase_spread(t_impact, sample_rate_hz: float) -> float:
    """How far the impacts' sub-sample phases spread over the sample interval [-]: one minus the largest
    gap between the phases ``frac(t_impact * sample_rate_hz)`` taken round the unit circle (0: every
    impact at one phase, as when a revolution is a whole number of samples; about ``1 - ln(n) / n`` for
    ``n`` phases spread at random). NaN with fewer than two impacts."""
    phases = np.sort(np.mod(np.asarray(t_impact, dtype=float) * sample_rate_hz, 1.0))
    if phases.size < 2:
        return math.nan
    gaps = np.diff(np.concatenate((phases, phases[:1] + 1.0)))
    return float(1.0 - gaps.max())


def systematic_error(follower_step: float, spread: float = 1.0,
                     sample_rate_hz: float = SYSTEMATIC_SAMPLE_RATE_HZ) -> float:
    """The pipeline's own error of a point's ``r`` [-] with a follower encoder of count ``follower_step``
    [rad], impacts whose sub-sample phases spread by ``spread`` (:func:`phase_spread`) and a sample rate
    ``sample_rate_hz`` [Hz].

    :data:`RESTITUTION_SYSTEMATIC` (impacts at phases that spread, their errors partly averaged) or, when
    the phases spread over less than :data:`PHASE_SPREAD_MIN` of the sample interval (or are unknown,
    NaN), :data:`RESTITUTION_SINGLE_IMPACT` (every impact errs alike: the point's error is one impact's);
    times ``(follower_step / SYSTEMATIC_FOLLOWER_STEP)^2`` for a coarser encoder (0 or NaN: an
    unquantised channel) and ``SYSTEMATIC_SAMPLE_RATE_HZ / sample_rate_hz`` for a slower sampling (each
    factor never below 1: the measured floors are kept for finer encoders and faster sampling)."""
    ratio = follower_step / SYSTEMATIC_FOLLOWER_STEP if math.isfinite(follower_step) and follower_step > 0 else 0.0
    rate_known = math.isfinite(sample_rate_hz) and sample_rate_hz > 0.0
    slower = SYSTEMATIC_SAMPLE_RATE_HZ / sample_rate_hz if rate_known else 1.0
    locked = not (math.isfinite(spread) and spread >= PHASE_SPREAD_MIN)
    base = RESTITUTION_SINGLE_IMPACT if locked else RESTITUTION_SYSTEMATIC
    return base * max(1.0, ratio) ** 2 * max(1.0, slower)


def simulated_first_bounce(rig: FlatFollowerRig, cam_speed_hz: float, restitution: float,
                           settle_revolutions: int = 30, points_per_revolution: int = 20000) -> float:
    """First-bounce height [rad] of the model's motion at a cam speed (after settling).

    As in the data: the highest flight of the last revolution ends in the first impact; the height
    of ``theta_f - theta_hat(theta_c)`` between that impact and the next one is the first bounce,
    found on a grid of ``points_per_revolution`` (apex error below 1e-9 rad). NaN when the flight
    does not end in two impacts within the simulated time.
    """
    from impactid.rigs.flat.simulate import simulate_flat

    period = 1.0 / cam_speed_hz
    t_end = (settle_revolutions + 2) * period
    times = np.linspace(settle_revolutions * period, t_end, 2 * points_per_revolution + 1)
    run = simulate_flat(rig, cam_speed_hz, t_end, restitution=restitution, times=times)
    rel = run.theta_f - rig.contact_angle(run.cam_angle)
    first_rev = run.t < (settle_revolutions + 1) * period
    t_peak = run.t[first_rev][int(np.argmax(rel[first_rev]))]
    impacts = run.events.loc[(run.events["kind"] == "impact") & (run.events["t"] > t_peak), "t"].to_numpy()
    if impacts.size < 2:
        return math.nan
    inside = (run.t > impacts[0]) & (run.t < impacts[1])
    return float(rel[inside].max()) if np.any(inside) else math.nan


def restitution_at_speed(recording: Recording, profile=None, method: str = "impact-law",
                         rig: FlatFollowerRig | None = None, offset: float | None = None, *,
                         warn: bool = True) -> RestitutionAtSpeed:
    """Coefficient of restitution of one impacting encoder recording (constant cam speed).

    Parameters
    ----------
    profile : cam profile callable (default the rig's analytic A-17).
    method : "impact-law" (mean of ``-v+/v-`` over the first impacts) or "first-bounce" (the
        model's ``r`` that reproduces the median first-bounce height; needs the rig).
    rig : rig F parameters for "first-bounce" (default the recording's rig).
    warn : issue an :class:`EncoderImpactWarning` for each note (the result's ``warnings``, prefixed
        with the recording); callers that carry the notes on pass False.

    Raises
    ------
    ValueError : unknown method. EncoderImpactError : no measurable impact.
    """
    if method not in METHODS:
        raise ValueError(f"unknown restitution method {method!r}; valid: {', '.join(METHODS)}")
    motion = relative_motion(recording, profile, offset)
    table = first_impacts(motion)
    if offset is None and not table.empty:
        motion = relative_motion(recording, profile, refine_offset(motion, table))
        table = first_impacts(motion)
    where = recording.source or "recording"
    if table.empty:
        raise EncoderImpactError(f"{where}: no measurable first impact in 'follower_angle' (the follower never "
                                 f"rises {FLIGHT_THRESHOLD_COUNTS:g} counts above the cam, or every flight is cut)")
    notes = []
    if len(table) < 5:
        notes.append(f"only {len(table)} first impacts")
    bounce = float(np.median(table["bounce_height"]))
    spread = phase_spread(table["t_impact"].to_numpy(), recording.sample_rate_hz)
    if method == "impact-law":
        values = table["restitution"].to_numpy()
        r = float(np.mean(values))
        se = float(np.std(values, ddof=1) / math.sqrt(values.size)) if values.size > 1 else math.nan
    else:
        rig = recording.rig if rig is None else rig
        if getattr(rig, "model", None) != MODEL_NAME:
            raise EncoderImpactError(f"{where}: the first-bounce method needs a flat-follower rig description")
        speed = motion.cam_speed_hz

        def mismatch(r):
            return simulated_first_bounce(rig, speed, r) - bounce

        # scan r for the first bracket (the model may stop being period-1 at high r: NaN there)
        grid = np.linspace(0.05, 0.95, 19)
        values = np.array([mismatch(r) for r in grid])
        sign_change = np.flatnonzero(np.isfinite(values[:-1]) & np.isfinite(values[1:])
                                     & (values[:-1] * values[1:] < 0.0))
        if sign_change.size == 0:
            notes.append("the model's first-bounce height does not bracket the measured one for r in [0.05, 0.95]")
            r, se = math.nan, math.nan
        else:
            k = int(sign_change[0])
            lo, hi = float(grid[k]), float(grid[k + 1])
            r = float(optimize.brentq(mismatch, lo, hi, xtol=1e-6))
            # standard error from the scatter of the bounce heights through the local slope
            r_up, r_down = min(r + 0.01, hi), max(r - 0.01, lo)
            slope = (mismatch(r_up) - mismatch(r_down)) / (r_up - r_down)
            heights = table["bounce_height"].to_numpy()
            se_h = 1.2533 * np.std(heights, ddof=1) / math.sqrt(heights.size) if heights.size > 1 else math.nan
            se = float(abs(se_h / slope)) if slope != 0.0 else math.nan
    for note in notes if warn else ():
        warnings.warn(f"{where}: {note}", EncoderImpactWarning, stacklevel=2)
    return RestitutionAtSpeed(cam_speed_hz=motion.cam_speed_hz, restitution=r, stderr=se, method=method,
                              n_impacts=len(table), bounce_height=bounce, impacts=table,
                              source=recording.source or "", warnings=tuple(notes),
                              systematic=systematic_error(motion.follower_step, spread, recording.sample_rate_hz),
                              phase_spread=spread)


@dataclass(frozen=True)
class SpeedLawResult(FitResult):
    """The speed-dependent restitution law ``r = a + b omega`` fitted over cam speeds (:func:`fit_speed_law`).

    ``params``: ``a`` [-] and ``b`` [s/rad] (per rad/s of cam speed; ``b`` is fixed at 0 when every
    point is at one cam speed or the constant law is fitted). ``tables["points"]``: one row per cam speed
    (the columns of :meth:`RestitutionAtSpeed.to_dict`, ``measurement_error``, ``notes`` joined).
    ``details``: ``method`` (of the points), ``fitted_law`` (``linear`` or ``constant``), ``law`` (the
    law with its slope per rad/s and per rpm), ``stderr_b_per_rpm``, ``covariance`` (how the standard
    errors were made), ``point_errors`` (each point's ``sqrt(stderr^2 + systematic^2)``), ``correlation``
    (of ``a`` and ``b``). ``statistics``: those of the engine (:func:`impactid.engine.uncertainty`),
    ``speeds``, ``residual_rms`` [-] and the check against the points' errors (``noise_sd``,
    ``residual_over_noise``).

    Attributes
    ----------
    points : the per-speed measurements fitted (:class:`RestitutionAtSpeed`, with their per-impact
        tables); not part of the JSON form (empty after :meth:`~impactid.results.FitResult.from_json`).
    """

    kind = "speed-restitution"
    title = "restitution r = a + b omega"

    points: tuple[RestitutionAtSpeed, ...] = field(default=(), repr=False, compare=False)

    @property
    def law(self):
        """The fitted :class:`~impactid.rigs.flat.simulate.SpeedRestitution` (``b`` per rad/s)."""
        from impactid.rigs.flat.simulate import SpeedRestitution

        return SpeedRestitution(a=self.value("a"), b=self.value("b"))

    @property
    def stderr_a(self) -> float:
        """Standard error of ``a`` [-] (NaN: undetermined)."""
        return self.params["a"].stderr

    @property
    def stderr_b(self) -> float:
        """Standard error of ``b`` [s/rad] (NaN: undetermined or fixed at one speed)."""
        return self.params["b"].stderr if not self.params["b"].fixed else math.nan

    @property
    def residual_rms(self) -> float:
        """RMS of ``r_i - (a + b omega_i)`` over the speeds [-]."""
        return float(self.statistics["residual_rms"])


LAWS = ("linear", "constant")


def fit_speed_law(points, *, confidence: float = 0.95, law: str = "linear") -> SpeedLawResult:
    """Weighted least squares of ``r = a + b omega`` (omega the cam speed [rad/s]) through the identification engine.

    Each point is weighted by its whole error, ``sigma_i = sqrt(stderr_i^2 + systematic_i^2)``
    (:attr:`RestitutionAtSpeed.measurement_error`): the scatter over its revolutions and the
    pipeline's own error :data:`RESTITUTION_SYSTEMATIC`, common to its impacts (module doc). That
    error is known, so the covariance is not rescaled by the residual (a known scale): the standard
    errors are those of the points propagated, and the model check (:func:`impactid.engine.check_model`,
    the cam speed as the per-point covariate) tests the residual against ``sigma_i``: a law that misses
    the points by more than their error is a lack of fit, and the engine's rule widens (or withholds)
    the intervals. Without a standard error for every point (a point of one impact): ordinary least
    squares scaled by the residual scatter (lmfit's ``scale_covar``) with three speeds or more, the law
    undetermined with two, and the model not checked against a noise. One cam speed: ``r`` is a
    constant (``b`` fixed at 0; noted in the result).

    Parameters
    ----------
    points : :class:`RestitutionAtSpeed` measurements (non-finite ``restitution`` left out).
    confidence : coverage of the intervals.
    law : ``"linear"`` (``r = a + b omega``) or ``"constant"`` (``b`` fixed at 0: the law of a rig whose
        restitution does not depend on the cam speed; the check then tests that).

    The identifiability block (:func:`impactid.engine.identifiability`: the law is linear, so the
    quadratic profiles are exact) compares, with three speeds or more, the constant ``r`` with the
    line (AIC, BIC, likelihood-ratio test, with the points' known errors).

    Raises
    ------
    EncoderImpactError : no finite restitution estimate. ValueError : unknown ``law``.
    """
    if law not in LAWS:
        raise ValueError(f"unknown restitution law {law!r}; valid: {', '.join(LAWS)}")
    pts = tuple(p for p in points if math.isfinite(p.restitution))
    if not pts:
        raise EncoderImpactError("no finite restitution estimate to fit")
    omega = np.array([2.0 * math.pi * p.cam_speed_hz for p in pts])
    r = np.array([p.restitution for p in pts])
    sigma = np.array([p.measurement_error for p in pts])
    notes = [f"{p.source or 'recording'}: {note}" for p in pts for note in p.warnings]
    one_speed = len(pts) == 1 or float(np.ptp(omega)) < 1e-9
    if one_speed and law == "linear":
        notes.append("one cam speed only: r is fitted as a constant (b fixed at 0)")
    constant_law = one_speed or law == "constant"
    free = (Free("a", float(np.mean(r)), unit=""),
            Free("b", 0.0, vary=not constant_law, unit="s/rad"))
    n_params = 1 if constant_law else 2
    known = bool(np.all(np.isfinite(sigma)) and np.all(sigma > 0.0))
    weight = 1.0 / sigma if known else np.ones_like(r)

    def residual(u):
        return (r - (u[0] + u[1] * omega)) * weight

    def jacobian(u):
        return -np.column_stack((np.ones_like(omega), omega)) * weight[:, None]

    found = search(residual, free, jacobian=jacobian)
    floors = sorted({float(f"{math.sqrt(max(p.measurement_error ** 2 - p.stderr ** 2, 0.0)):.2g}") for p in pts}
                    if known else set())
    floor_text = "/".join(f"{f:.2g}" for f in floors)
    if known:
        fit = _normal_intervals(uncertainty(found, confidence=confidence, scale=1.0))
        how = ("weighted by each point's standard error and the pipeline's own error of r "
               f"({floor_text}), known scale")
    elif len(pts) > n_params:
        fit = uncertainty(found, confidence=confidence)
        how = "ordinary least squares, scaled by the residual scatter (reduced chi-square)"
    else:
        fit = _undetermined(uncertainty(found, confidence=confidence, scale=1.0),
                            "the standard errors of the points are not known: those of the law are not")
        how = "as many speeds as parameters, the points' standard errors unknown"
    values = found.values()
    resid = r - (values["a"] + values["b"] * omega)
    check_stats, check_notes = ({}, ())
    if known:
        check_stats, check_notes = residual_against_noise(resid, sigma, what="restitution")
    else:
        notes.append("the points' standard errors are not all known: the law is not checked against them")
    order = np.argsort(omega, kind="stable")
    checked = check_model(resid[order], sigma[order] if known else None,
                          noise_reference=("each cam speed's standard error (the scatter over its revolutions) and "
                                           f"the pipeline's own error of r ({floor_text})"),
                          what="restitution", n_params=n_params, covariate=omega[order],
                          covariate_name="cam speed [rad/s]", assumed_over_noise=1.0 if known else None,
                          assumed_sd=None if known or not math.isfinite(fit.scale) else math.sqrt(fit.scale))
    parameters = checked.widen(fit.parameters)
    comparison = None
    if not one_speed and len(pts) > 2:
        w2 = weight * weight
        constant = (r - float(np.sum(w2 * r) / np.sum(w2))) * weight
        line_coef = np.linalg.lstsq(np.column_stack((np.ones_like(omega), omega)) * weight[:, None], r * weight,
                                    rcond=None)[0]
        line = (r - (line_coef[0] + line_coef[1] * omega)) * weight
        comparison = compare_models([{"name": "constant r", "n_params": 1, "n_data": len(pts),
                                      "rss": float(constant @ constant)},
                                     {"name": "a + b omega", "n_params": 2, "n_data": len(pts),
                                      "rss": float(line @ line)}],
                                    nested=[("constant r", "a + b omega")], choice="constant r or r = a + b omega",
                                    known_scale=known)
    described = identifiability(found, fit, comparison=comparison, describes_data=checked.describes_data,
                                quadratic_reason="the law is linear: the quadratic profile is exact")
    statistics = {**fit.statistics, "speeds": len(pts), "residual_rms": float(np.sqrt(np.mean(resid**2))),
                  **{k: v for k, v in check_stats.items() if k != "residual_rms"}}
    b = values["b"]
    rpm = 2.0 * math.pi / 60.0
    stderr_b = parameters[1].stderr if not constant_law else math.nan
    details = {"method": ", ".join(sorted({p.method for p in pts})), "fitted_law": "constant" if constant_law
               else "linear", "law": {"a": values["a"], "b_per_rad_s": b, "b_per_rpm": b * rpm},
               "stderr_b_per_rpm": stderr_b * rpm, "covariance": how,
               "point_errors": [float(v) for v in sigma],
               "correlation": {"names": list(fit.names), "matrix": fit.correlation}}
    table = pd.DataFrame([{**{k: v for k, v in p.to_dict().items() if k != "warnings"},
                           "measurement_error": p.measurement_error, "notes": "; ".join(p.warnings)} for p in pts])
    return SpeedLawResult(params=parameters, statistics=statistics,
                          notes=(*notes, *fit.notes, *check_notes, *checked.further_notes),
                          tables={"points": table}, details=details, points=pts,
                          provenance=(f"impactid.rigs.flat.encoder_impacts.fit_speed_law: {len(pts)} cam speed(s), "
                                      f"{'constant' if constant_law else 'linear'} law, {how}",),
                          model_check=combine_checks([checked]), identifiability=described)


def _normal_intervals(fit: Uncertainty) -> Uncertainty:
    """``fit`` with the normal quantile in its intervals: the scale is known (the points' errors), so the
    Student-t of the engine's default (a scale estimated from ``dof`` residuals) does not apply."""
    q = float(stats.norm.ppf(0.5 + 0.5 * fit.confidence))
    parameters = tuple(p if p.fixed or not math.isfinite(p.stderr) else replace(
        p, interval=(p.value - q * p.stderr, p.value + q * p.stderr)) for p in fit.parameters)
    return replace(fit, parameters=parameters)


def _undetermined(fit: Uncertainty, reason: str) -> Uncertainty:
    """``fit`` with every varying parameter's standard error and interval undetermined (``reason``)."""
    parameters = tuple(p if p.fixed else replace(p, stderr=math.nan, interval=(math.nan, math.nan),
                                                 note="undetermined by the data") for p in fit.parameters)
    return replace(fit, parameters=parameters, notes=(*fit.notes, reason))

"""Anchors of the per-impact reconstruction: the constant of the second integration, as typed objects.

The double integration of the angular acceleration (:func:`impactid.rigs.pivoted.reconstruct.reconstruct`)
leaves each event's angle known up to a constant ``C`` (``alpha = angle + C``). An *anchor* fixes it,
from an :class:`EventWindows` (the integrated windows of a recording's usable events, before anchoring),
and returns :class:`AnchoredOnsets` (the constants and what the anchor found on the way: the cam
angle at each onset, the recording's cam phase, the return-time onset angles). One frozen dataclass
per anchor, by name in :data:`ANCHORS`:

``return-time`` (:class:`ReturnTimeAnchor`)
    the paper's function Xi (S-19): the free-flight angle from which the follower, starting with
    the measured rate, covers the measured displacement in the measured flight time (Newton on
    the compiled free flight, :func:`impactid.rigs.pivoted.freeflight.return_time_anchors`).
``cam-geometry`` (:class:`CamGeometryAnchor`)
    the gap is zero at the contact onset at the cam angle of the ``cam_angle`` channel.
``cam-phase`` (:class:`CamPhaseAnchor`)
    return-time first; then one cam phase for the whole recording, and the gap zero at each onset
    at that cam angle.

Also here: the cam angle where the gap closes at a given follower angle (:func:`theta_from_gap`),
with the Hertz check that tells its two roots apart (:func:`hertz_ratio`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import ClassVar, Protocol

import numpy as np
from scipy import optimize

from impactid.engine.distributions import student_t_quantile
from impactid.io import Recording
from impactid.rigs._params import RigParameters
from impactid.rigs.pivoted import spring_force
from impactid.rigs.pivoted.freeflight import FREE_FLIGHT_STEPS, return_time_anchors
from impactid.rigs.pivoted.runs import pack_rig
from impactid.signal import quantisation_step

__all__ = ["ANCHORS", "GUESS_EVENTS", "HERTZ_PHASE_DISAGREEMENT", "HERTZ_PHASE_GAIN", "HERTZ_RATIO_SYSTEMATIC",
           "PHASE_NOTE_SPREAD", "PHASE_PROFILE_FACTOR", "PHASE_PROFILE_MIN", "Anchor", "AnchoredOnsets",
           "CamGeometryAnchor", "CamPhaseAnchor", "ContactWindow", "EventWindows", "ReturnTimeAnchor", "hertz_ratio",
           "bracketed_root", "phase_from_hertz", "phase_profile_stderr", "theta_from_gap"]

#: How far [rad] beyond its bracket a closed-form root of the gap may lie by rounding (:func:`theta_from_gap`).
ROOT_SLACK = 1e-12

#: Events whose return-time anchor starts from the static equilibrium; the others start from the median of
#: their start angles (:class:`ReturnTimeAnchor`: half the Newton iterations, the same roots to 1e-16 rad).
GUESS_EVENTS = 8

#: Per event, its contact's times [s from the sub-sample onset], angles [rad] and angular
#: accelerations [rad/s^2], or None where the window is too short or the constant undetermined.
ContactWindow = tuple[np.ndarray, np.ndarray, np.ndarray] | None


@dataclass(frozen=True)
class EventWindows:
    """The integrated windows of a recording's usable events, before anchoring.

    Each window runs from an event's first contact sample to the last free sample before the next
    onset. Sample indices within a window count from its first sample.

    Attributes
    ----------
    recording : the recording (rig P).
    rig : rig P's parameters.
    sample_rate_hz : sampling rate [Hz].
    omega : cam speed [rad/s].
    first_sample, next_sample, separation_sample : per event, the recording's sample index of the first
        contact sample, of the next event's first contact sample, and of the detected separation.
    onset_offset : per event, how far [samples] the sub-sample onset lies before the first contact sample.
    next_offset : per event, how far [samples] the next onset lies before ``next_sample``.
    t_onset : per event, the onset's time from the recording's start [s].
    impulsive : per event, whether the contact is an impulse (fewer than 3 contact samples).
    head_rate_change, tail_rate_change : per event, the rate change [rad/s] over the sub-sample piece
        from the onset to the first sample and from the last sample to the next onset (NaN where undetermined).
    angles, rates, accelerations : per event, the integrated angle [rad] (before anchoring), rate
        [rad/s] and detrended angular acceleration [rad/s^2] on the window's samples.
    angle_onset, rate_onset : per event, the angle [rad] (before anchoring) and rate [rad/s] at the onset.
    rate_after : per event, the rate [rad/s] just after an impulse (NaN for other contacts).
    contact_end : per event, the window's sample where the contact and its margin end.
    free_start, free_end : per event, the window's samples where the return-time anchor's free flight
        starts and ends.
    t_next : per event, the next onset's time from the recording's start [s] (None: not given).
    """

    recording: Recording
    rig: RigParameters
    sample_rate_hz: float
    omega: float
    first_sample: np.ndarray
    next_sample: np.ndarray
    separation_sample: np.ndarray
    onset_offset: np.ndarray
    next_offset: np.ndarray
    t_onset: np.ndarray
    impulsive: np.ndarray
    head_rate_change: np.ndarray
    tail_rate_change: np.ndarray
    angles: list[np.ndarray]
    rates: list[np.ndarray]
    accelerations: list[np.ndarray]
    angle_onset: np.ndarray
    rate_onset: np.ndarray
    rate_after: np.ndarray
    contact_end: np.ndarray
    free_start: np.ndarray
    free_end: np.ndarray
    t_next: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.angles)

    @property
    def dt(self) -> float:
        """Sampling interval [s]."""
        return 1.0 / self.sample_rate_hz

    def contact_windows(self, constants: np.ndarray) -> list[ContactWindow]:
        """Per event, ``(t, alpha, alpha_ddot)`` over its contact and its margin after it, times from
        the sub-sample onset [s], with the anchor's ``constants`` [rad] applied."""
        out = []
        dt = self.dt
        for i, angle in enumerate(self.angles):
            hi = min(int(self.contact_end[i]) + 1, angle.size)
            if hi < 3 or not math.isfinite(constants[i]):
                out.append(None)
                continue
            k = np.arange(hi)
            out.append(((k + self.onset_offset[i]) * dt, angle[:hi] + constants[i], self.accelerations[i][:hi]))
        return out


@dataclass(frozen=True)
class AnchoredOnsets:
    """What an anchor determines.

    Attributes
    ----------
    constants : per event, the constant ``C`` [rad] of the second integration (``alpha = angle + C``).
    iterations : per event, the return-time anchor's Newton iterations (-1: not converged; 0 without it).
    theta_onset : per event, the cam angle [rad] at the onset when the anchor fixes it (the encoder's,
        or the recording's cam phase); None: it follows from the gap (:func:`theta_from_gap`).
    return_time_onset : per event, the return-time anchor's onset angle [rad] (for the plausibility
        checks), None when the anchor did not run it.
    cam_phase, cam_phase_stderr : the recording's cam phase ``Theta_ref`` [rad] and its standard error
        (cam-phase anchor; NaN otherwise).
    notes : what qualifies the anchoring (the cam phase poorly fixed by the onset angles).
    """

    constants: np.ndarray
    iterations: np.ndarray
    theta_onset: np.ndarray | None = None
    return_time_onset: np.ndarray | None = None
    cam_phase: float = math.nan
    cam_phase_stderr: float = math.nan
    notes: tuple[str, ...] = ()


class Anchor(Protocol):
    """An anchoring method: its name, the channels it needs beyond the accelerometer, and the anchoring."""

    name: ClassVar[str]
    channels: ClassVar[tuple[str, ...]]

    def anchor(self, windows: EventWindows) -> AnchoredOnsets:
        """The constants of the second integration of every event of ``windows``."""
        ...


@dataclass(frozen=True)
class ReturnTimeAnchor:
    """The paper's function Xi (S-19): the free-flight start angle from which the follower, with the
    measured rate, covers the measured displacement over the window's free flight in its duration.

    Attributes
    ----------
    tolerance : Newton's step tolerance [rad].
    steps : RK4 steps of each free flight.
    """

    name: ClassVar[str] = "return-time"
    channels: ClassVar[tuple[str, ...]] = ()
    tolerance: float = 1e-14
    steps: int = FREE_FLIGHT_STEPS

    def anchor(self, windows: EventWindows) -> AnchoredOnsets:
        """Constants ``C`` of all events by the return-time condition (Newton from the static equilibrium)."""
        starts, ends, angles, rates = windows.free_start, windows.free_end, windows.angles, windows.rates
        n = len(angles)
        start_rate = np.array([rates[i][starts[i]] for i in range(n)])
        displacement = np.array([angles[i][ends[i]] - angles[i][starts[i]] for i in range(n)])
        duration = (ends - starts) / windows.sample_rate_hz
        packed = pack_rig(windows.rig)
        static = windows.rig.static_equilibrium(0.0)
        # Newton from the static equilibrium for a few events (4 iterations each on rig P), then from the
        # median of their start angles for all (the flights of a recording are alike: 2 iterations); an
        # event that does not converge from there is solved again from the static equilibrium
        first = min(n, GUESS_EVENTS)
        out = np.empty((n, 3))  # start angle, Newton slope, iterations
        return_time_anchors(start_rate[:first], duration[:first], displacement[:first], np.full(first, static),
                            packed, self.steps, self.tolerance, out[:first])
        solved = out[:first, 0][(out[:first, 2] >= 0) & np.isfinite(out[:first, 0])]
        if n > first and solved.size:
            return_time_anchors(start_rate[first:], duration[first:], displacement[first:],
                                np.full(n - first, float(np.median(solved))), packed, self.steps, self.tolerance,
                                out[first:])
            again = first + np.flatnonzero(out[first:, 2] < 0)
            if again.size:
                redo = np.empty((again.size, 3))
                return_time_anchors(start_rate[again], duration[again], displacement[again],
                                    np.full(again.size, static), packed, self.steps, self.tolerance, redo)
                out[again] = redo
        elif n > first:
            return_time_anchors(start_rate[first:], duration[first:], displacement[first:], np.full(n - first, static),
                                packed, self.steps, self.tolerance, out[first:])
        constants = np.array([out[i, 0] - angles[i][starts[i]] for i in range(n)])
        return AnchoredOnsets(constants=constants, iterations=out[:, 2],
                              return_time_onset=windows.angle_onset + constants)


@dataclass(frozen=True)
class CamGeometryAnchor:
    """The gap is zero at each onset: ``alpha(t0) = contact_angle(Theta(t0))`` with ``Theta`` from the
    ``cam_angle`` channel (a least-squares line through the event's encoder samples at the nominal cam
    speed, with half a count added back when the channel is quantised, since an encoder counter truncates)."""

    name: ClassVar[str] = "cam-geometry"
    channels: ClassVar[tuple[str, ...]] = ("cam_angle",)

    def anchor(self, windows: EventWindows) -> AnchoredOnsets:
        """Constants ``C`` of all events from the encoder's cam angle at each onset."""
        rec = windows.recording
        rec.require("cam_angle", method="the 'cam-geometry' anchor")
        theta0 = _encoder_theta(rec, windows.first_sample, windows.next_sample, -windows.onset_offset * windows.dt,
                                windows.omega)
        alpha_onset = np.asarray(windows.rig.contact_angle(theta0))
        return AnchoredOnsets(constants=alpha_onset - windows.angle_onset, iterations=np.zeros(len(theta0)),
                              theta_onset=theta0)


@dataclass(frozen=True)
class CamPhaseAnchor:
    """Return-time first; then one cam phase for the whole recording, and the gap zero at each onset.

    The cam turns at the constant ``Omega_c``, so ``Theta(t_onset) = Theta_ref + 2 pi Omega_c t_onset``
    with one ``Theta_ref`` for all events. Each event's return-time anchor gives an estimate of it
    (from ``psi_i = 0`` at its onset angle); their circular median (robust to a few non-period-1
    events) starts a soft-L1 least-squares fit of the phase to the onset angles
    (``contact_angle(Theta_ref + Omega t_i) = alpha_i``), which is the recording's phase. The
    onset angle is then the contact angle at the event's cam angle, with no double-integration
    error in it; the onset rate stays the integrated one. Without any phase estimate the return-time
    constants stand.

    Attributes
    ----------
    first : the return-time anchor that starts it.
    """

    name: ClassVar[str] = "cam-phase"
    channels: ClassVar[tuple[str, ...]] = ()
    first: ReturnTimeAnchor = ReturnTimeAnchor()

    def anchor(self, windows: EventWindows) -> AnchoredOnsets:
        """Constants ``C`` of all events from the recording's cam phase (after the return-time anchor)."""
        start = self.first.anchor(windows)
        alpha_on = windows.angle_onset + start.constants
        phase = self.phase_guess(windows, alpha_on, start.constants)
        if phase is None:
            return start
        linear = self.linear_stderr(windows, alpha_on, phase)
        phase, stderr = self.fit_phase(windows, alpha_on, phase)
        # near an extremum of the contact angle the onset angles hardly fix the phase; the contacts'
        # Hertz ratios do, and are taken in where the two disagree (phase_from_hertz)
        profiled = stderr > PHASE_PROFILE_FACTOR * linear
        phase, stderr, hertz = phase_from_hertz(windows, phase, stderr)
        theta_common = phase + windows.omega * windows.t_onset
        constants = np.asarray(windows.rig.contact_angle(theta_common)) - windows.angle_onset
        notes = ()
        if profiled or hertz:
            how = hertz or "its profile is wider than its linearisation"
            notes = tuple(filter(None, (_phase_note(windows, phase, stderr, linear, how),)))
        return AnchoredOnsets(constants=constants, iterations=start.iterations, theta_onset=theta_common,
                              return_time_onset=start.return_time_onset, cam_phase=phase, cam_phase_stderr=stderr,
                              notes=notes)

    @staticmethod
    def phase_guess(windows: EventWindows, alpha_on: np.ndarray, constants: np.ndarray) -> float | None:
        """The circular median [rad] of the per-event phases ``Theta(t_onset) - Omega t_onset`` of the
        return-time onsets ``alpha_on`` [rad] (None when no event gives one)."""
        omega, t_rel = windows.omega, windows.t_onset
        theta = theta_from_gap(windows.rig, alpha_on, windows.rate_onset, omega, windows.contact_windows(constants))
        phases = np.angle(np.exp(1j * (theta - omega * t_rel)))
        ok = np.isfinite(phases)
        if not np.any(ok):
            return None
        first = phases[ok][0]
        return first + float(np.median(np.angle(np.exp(1j * (phases[ok] - first)))))

    @staticmethod
    def linear_stderr(windows: EventWindows, alpha_on: np.ndarray, phase: float) -> float:
        """Gauss–Newton's standard error [rad] of the phase ``phase`` [rad] fitted to the onset angles ``alpha_on``
        [rad] (from their scatter about the fit)."""
        rig, omega, t_rel = windows.rig, windows.omega, windows.t_onset
        resid = np.asarray(rig.contact_angle(phase + omega * t_rel)) - alpha_on
        slope = (np.asarray(rig.contact_angle(phase + 1e-6 + omega * t_rel))
                 - np.asarray(rig.contact_angle(phase - 1e-6 + omega * t_rel))) / 2e-6
        m = int(np.isfinite(resid).sum())
        return float(np.sqrt(np.nansum(resid ** 2) / (m - 1) / np.nansum(slope ** 2))) if m > 1 else math.inf

    @staticmethod
    def fit_phase(windows: EventWindows, alpha_on: np.ndarray, phase: float) -> tuple[float, float]:
        """The phase [rad] refined from ``phase`` by a soft-L1 fit to the onset angles ``alpha_on`` [rad],
        and its standard error [rad].

        The fit is in angle space, where the return-time errors are zero-mean (the inverse map from a
        noisy angle to the gap-zero cam angle is nonlinear, so the median of per-event phases is
        biased); the soft-L1 loss guards against the odd non-period-1 event. The standard error is
        Gauss–Newton's, from the scatter of the onset angles about the fit.
        """
        rig, omega, t_rel = windows.rig, windows.omega, windows.t_onset
        spread = float(np.median(np.abs(np.asarray(rig.contact_angle(phase + omega * t_rel)) - alpha_on)))
        fit = optimize.least_squares(lambda q: np.asarray(rig.contact_angle(q[0] + omega * t_rel)) - alpha_on,
                                     [phase], loss="soft_l1", f_scale=max(3.0 * spread, 1e-9), xtol=1e-14, ftol=1e-14,
                                     gtol=1e-14)
        if fit.success and abs(fit.x[0] - phase) < 0.5:
            phase = float(fit.x[0])
        stderr = CamPhaseAnchor.linear_stderr(windows, alpha_on, phase)
        if math.isfinite(stderr):
            stderr = max(stderr, phase_profile_stderr(rig, omega, t_rel, alpha_on, phase, stderr))
        return phase, stderr


#: Relative uncertainty of the approach speeds from the cam phase above which the reconstruction says so.
PHASE_NOTE_SPREAD = 0.005


def _phase_note(windows: EventWindows, phase: float, stderr: float, linear: float, how: str) -> str:
    """The note of a cam phase that the onset angles fix poorly: its standard error [rad] against the
    linearised one, ``how`` it was found, and what it does to the approach speeds (their spread over the
    phase's 95 % range); empty where that spread is below :data:`PHASE_NOTE_SPREAD`."""
    rig, omega = windows.rig, windows.omega
    speeds = []
    for shift in (-1.96 * stderr, 0.0, 1.96 * stderr):
        theta0 = phase + shift + omega * windows.t_onset
        alpha0 = np.asarray(rig.contact_angle(theta0))
        speeds.append(-np.asarray(rig.gap_rate(alpha0, windows.rate_onset, theta0, omega)))
    spread = float(np.nanmedian(np.abs(speeds[2] - speeds[0]) / (2.0 * np.abs(speeds[1]))))
    if not spread >= PHASE_NOTE_SPREAD:
        return ""
    where = windows.recording.source or "recording"
    return (f"{where}: the impacts happen near the top of the cam's lift, where the contact angle barely changes with "
            f"the cam phase, so the onset angles fix it poorly: the cam phase is known to +-{1.96 * stderr:.2g} rad "
            f"(95 %; +-{1.96 * linear:.2g} rad by the onset angles' linearisation; {how}), and with it the "
            f"approach speeds to +-{spread:.1%}; the intervals carry this, and with a restitution near 1 (beta "
            "barely moves alpha_m) they are wide")


#: Systematic uncertainty [-] of the log of a contact's Hertz ratio at the true phase
#: (:func:`phase_from_hertz`): the accelerometer's force at the deepest indentation differs from the
#: Hertz force by the friction's direction, the free-flight torque and the sampling of the deepest
#: point; measured noise-free at period-1 points, 0.1 to 1.5 %.
HERTZ_RATIO_SYSTEMATIC = 0.015
#: The Hertz ratios are taken into the phase (:func:`phase_from_hertz`) where they fix it this many
#: times more precisely than the onset angles ...
HERTZ_PHASE_GAIN = 3.0
#: ... and widen the phase's standard error where their phase and the angles' differ by more than this
#: many standard deviations of the difference.
HERTZ_PHASE_DISAGREEMENT = 2.0


def bracketed_root(f: Callable[[float], float], lo: float, hi: float, *, xtol: float) -> float:
    """The root of ``f`` in ``[lo, hi]`` (its ends of opposite signs) by Brent's method, or NaN where ``f``
    is undefined (NaN) somewhere on the way: a quantity that does not exist there has no root to give."""
    try:
        return float(optimize.brentq(f, lo, hi, xtol=xtol))
    except ValueError:  # brentq's "function value is NaN" (or ends of one sign)
        return math.nan


def phase_from_hertz(windows: EventWindows, phase: float, stderr: float) -> tuple[float, float, str]:
    """The cam phase [rad] and its standard error [rad] checked against the contacts' Hertz ratios, and what
    the ratios did ("" where nothing).

    Near an extremum of the contact angle ``alpha_c(Theta)`` (the top of the cam's lift, where slow
    impacts at small eccentricities land) an onset angle barely depends on the cam phase, and the
    onset angles fix the phase poorly (and its linearised standard error is too small); the
    indentation does depend on it: with the onset on the gap zero, ``delta(t) ~ chi [alpha_c(Theta0 +
    Omega t) - alpha_c(Theta0) - (alpha(t) - alpha(t0))]`` grows with the slope ``alpha_c'(Theta0)``,
    which changes linearly with the phase there. At the deepest indentation the gap rate is zero, so
    the contact force is ``k_H delta^1.5`` whatever the damping law: the accelerometer's force there
    (with the friction of the sliding direction, ``mu h_p``) over it, the Hertz ratio, is 1 at the
    true phase. Near the top of the lift its log changes by about 1 per radian of phase, with 3 %
    scatter per contact at 0.3 % noise (measured): the phase to about 0.01 rad from 15 impacts, where
    the angles' error was 0.04 to 0.08 rad (2 to 4.5 of their standard errors).

    The phase where the mean log ratio is zero (within 0.5 rad of ``phase``) and its standard error
    (the ratios' scatter and :data:`HERTZ_RATIO_SYSTEMATIC`, over the slope) are compared with
    ``(phase, stderr)``, the angles'. Where the ratios' standard error is :data:`HERTZ_PHASE_GAIN`
    times smaller (onsets at the very top of the lift: the angles' profile error is 0.1 to 5 rad there),
    the result is the inverse-variance mean, its standard error scaled by the disagreement where
    that exceeds 1 (the Birge ratio). Where the two differ by more than
    :data:`HERTZ_PHASE_DISAGREEMENT` standard deviations of the difference, the angles' phase stays
    and the difference is added to its standard error in quadrature (the ratios' phase then lies within
    one standard error): the ratios are not trusted more than the angles (with friction and at low approach speeds their
    phase can be off by as much: 2.6 of its standard errors on the built-in example's calibration
    recording), so the disagreement is carried into the intervals rather than resolved. Otherwise
    ``(phase, stderr)`` is returned unchanged (as it is when the ratios do not determine a phase). The
    third element says which, for the reconstruction's note.
    At the validation's period-1 points and the built-in example the two agree and the angles are the
    more precise: nothing changes there.
    """
    rig, omega = windows.rig, windows.omega
    mu_h = float(getattr(rig, "mu", 0.0)) * float(rig.h_p)
    dt = windows.dt
    # every event's contact samples side by side (padded; ``inside`` marks the samples), so that the ratios
    # of all events are one array expression per phase tried (the search tries about twenty)
    spans = np.array([min(int(windows.contact_end[i]) + 1, angle.size) for i, angle in enumerate(windows.angles)],
                     dtype=np.int64).reshape(-1)
    spans = np.where((spans < 3) | np.asarray(windows.impulsive, dtype=bool), 0, spans)
    width = int(spans.max()) if spans.size else 0
    inside = np.arange(width)[None, :] < spans[:, None]
    angles, rates, accelerations = (np.zeros((spans.size, width)) for _ in range(3))
    for i, hi in enumerate(spans):
        angles[i, :hi] = windows.angles[i][:hi]
        rates[i, :hi] = windows.rates[i][:hi]
        accelerations[i, :hi] = windows.accelerations[i][:hi]
    times = (np.arange(width)[None, :] + np.asarray(windows.onset_offset, dtype=float)[:, None]) * dt
    rows = np.arange(spans.size)

    def log_ratios(q: float) -> np.ndarray:
        """Per event, the log of the force the accelerometer implies at the deepest indentation over the Hertz
        force there, with the cam phase ``q`` [rad] (NaN without indentation, force or contact samples)."""
        if width == 0:
            return np.full(spans.size, np.nan)
        theta0 = q + omega * windows.t_onset
        constants = np.asarray(rig.contact_angle(theta0)) - windows.angle_onset
        alpha = angles + constants[:, None]
        theta = theta0[:, None] + omega * times
        gap = np.where(inside, rig.gap(alpha, theta), np.inf)
        j = np.argmin(gap, axis=1)
        delta = -gap[rows, j]
        a_j, th_j = alpha[rows, j], theta[rows, j]
        torque = rig.m_b * rig.g * rig.l_g * np.cos(a_j) - spring_force(
            a_j, rig.k_s, rig.L_s_u, rig.d_y, rig.d_x, rig.w_b) * rig.d_x
        sliding = rig.sliding_velocity(a_j, rates[rows, j], th_j, omega)
        arm = rig.lever_arm(a_j, th_j) - mu_h * np.copysign(1.0, sliding)
        force = (rig.I_b * accelerations[rows, j] - torque) / arm
        ok = (spans > 0) & (delta > 0.0) & (force > 0.0)
        out = np.full(spans.size, np.nan)
        out[ok] = np.log(force[ok] / (rig.k_H * delta[ok] ** 1.5))
        return out

    def mean_log(q: float) -> float:
        values = log_ratios(q)
        return float(np.nanmean(values)) if np.any(np.isfinite(values)) else math.nan

    lo, hi = phase - 0.5, phase + 0.5
    f_lo, f_hi = mean_log(lo), mean_log(hi)
    if not (math.isfinite(f_lo) and math.isfinite(f_hi) and f_lo * f_hi < 0.0):
        return phase, stderr, ""
    hertz = bracketed_root(mean_log, lo, hi, xtol=1e-5)
    if not math.isfinite(hertz):  # the ratios vanish inside the bracket (no indentation or force there)
        return phase, stderr, ""
    values = log_ratios(hertz)
    m = int(np.isfinite(values).sum())
    step = 1e-3
    slope = (mean_log(hertz + step) - mean_log(hertz - step)) / (2.0 * step)
    if m < 3 or not (math.isfinite(slope) and slope != 0.0):
        return phase, stderr, ""
    widen = student_t_quantile(0.975, m - 1) / 1.96  # small-sample widening of the scatter term
    scatter = widen * float(np.nanstd(values, ddof=1)) / math.sqrt(m)
    hertz_stderr = math.hypot(scatter, HERTZ_RATIO_SYSTEMATIC) / abs(slope)
    difference = abs(hertz - phase) / math.hypot(stderr, hertz_stderr)
    if abs(hertz - phase) <= PHASE_PROFILE_MIN:
        return phase, stderr, ""
    if HERTZ_PHASE_GAIN * hertz_stderr < stderr:
        weight_angles, weight_hertz = stderr ** -2, hertz_stderr ** -2
        combined = (weight_angles * phase + weight_hertz * hertz) / (weight_angles + weight_hertz)
        return (float(combined), float((weight_angles + weight_hertz) ** -0.5 * max(difference, 1.0)),
                f"the contacts' Hertz ratios fix it {stderr / hertz_stderr:.2g} times better and set it")
    if difference > HERTZ_PHASE_DISAGREEMENT:
        return (phase, math.hypot(stderr, hertz - phase),
                f"the contacts' Hertz ratios put it {hertz - phase:+.2g} rad away ({difference:.2g} standard "
                "deviations), and the difference is added to its error")
    return phase, stderr, ""


#: The cam phase's standard error is taken from its profile (:func:`phase_profile_stderr`) where the
#: profile's interval is wider than this many times the linearised one: near an extremum of the contact
#: angle the linearisation is no longer valid (slow impacts land near the top of the cam's lift) ...
PHASE_PROFILE_FACTOR = 1.5
#: ... and wider than this [rad]: below it the phase moves the approach speeds by less than 0.1 % (the
#: noise-free period-1 points, whose profiles differ from their linearisations at the 1e-5 rad level,
#: keep their numbers).
PHASE_PROFILE_MIN = 1e-3


def phase_profile_stderr(rig: RigParameters, omega: float, t_rel: np.ndarray, alpha_on: np.ndarray, phase: float,
                         linear_stderr: float) -> float:
    """The cam phase's standard error [rad] from the profile of its angle-space fit, where that is wider.

    The cam-phase fit matches ``contact_angle(phase + omega t_i)`` to the onset angles ``alpha_on``
    [rad] of the events at ``t_rel`` [s]. Gauss–Newton's standard error assumes that the contact angle
    changes linearly with the phase over the phase's uncertainty. Where the onsets lie near an extremum
    of the contact angle (the top of the cam's lift: slow impacts at a small eccentricity), it changes
    quadratically, the onset angles hardly determine the phase, and the linearised standard error is
    far too small: with 0.35 % noise, a phase 3.5 of its standard errors off (0.079 rad), the approach
    speed 5 % off and beta several times off, its interval excluding the truth. Here the 95 % region of
    the phase is found on the profile, ``RSS(phase) <= RSS_min (1 + t^2 / (m - 1))`` (Student's ``t``,
    ``m`` onsets), by stepping out from ``phase`` on both sides (at most pi), and its half-width over
    ``t`` is returned when it exceeds :data:`PHASE_PROFILE_FACTOR` times ``linear_stderr``; else
    ``linear_stderr`` (the two agree where the linearisation holds).
    """
    ok = np.isfinite(alpha_on)
    t_ok, a_ok = t_rel[ok], alpha_on[ok]
    m = int(ok.sum())
    if m < 2 or not (math.isfinite(linear_stderr) and linear_stderr > 0.0):
        return linear_stderr

    def rss(q: float) -> float:
        return float(np.sum((np.asarray(rig.contact_angle(q + omega * t_ok)) - a_ok) ** 2))

    t_value = student_t_quantile(0.975, m - 1)
    level = rss(phase) * (1.0 + t_value ** 2 / (m - 1))
    step = max(0.25 * linear_stderr, 1e-6)
    edges = []
    for side in (-1.0, 1.0):
        inner, outer = 0.0, step
        while outer < math.pi and rss(phase + side * outer) <= level:
            inner, outer = outer, min(2.0 * outer, math.pi)
        if outer >= math.pi and rss(phase + side * outer) <= level:
            edges.append(math.pi)
            continue
        edges.append(optimize.brentq(lambda d, side=side: rss(phase + side * d) - level, inner, outer,
                                     xtol=1e-3 * step))
    half_width = max(edges)
    profile = half_width / t_value
    return profile if profile > max(PHASE_PROFILE_FACTOR * linear_stderr, PHASE_PROFILE_MIN) else linear_stderr


#: Anchoring methods by name.
ANCHORS: dict[str, Anchor] = {a.name: a for a in (ReturnTimeAnchor(), CamGeometryAnchor(), CamPhaseAnchor())}


def _encoder_theta(rec: Recording, k0: np.ndarray, k1: np.ndarray, t_onset_rel: np.ndarray, omega: float) -> np.ndarray:
    """Cam angle at each onset from the encoder channel (least-squares offset at nominal speed)."""
    cam = rec["cam_angle"]
    # an encoder channel holds its count between edges and moves in whole counts: the angle read is
    # the start of a count, half a count behind the mean angle over it
    half_count = 0.5 * quantisation_step(cam, max_samples=20_000, min_steps=1, reject_uniform_motion=True)
    dt = 1.0 / rec.sample_rate_hz
    out = np.empty(k0.size)
    for i, (a, b) in enumerate(zip(k0, k1)):
        tau = (np.arange(a, b) - a) * dt  # time from the first contact sample
        offset = np.mean(cam[a:b] - omega * tau) + half_count
        out[i] = offset + omega * t_onset_rel[i]
    return out


def theta_from_gap(rig: RigParameters, alpha0: np.ndarray, rate0: np.ndarray, omega: float,
                   contacts: list[ContactWindow] | None = None) -> np.ndarray:
    """Cam angle [rad] where ``psi_i(alpha0, Theta) = 0`` with the gap closing (S-5 solved for Theta).

    A follower angle meets the cam twice per revolution (on its rising and on its falling side),
    and both roots can have a closing gap, with free flights that both stay outside the cam (a
    low cam speed, or a heavily damped contact). ``contacts`` (per event: the times [s from the
    onset], angles and angular accelerations over the contact) then decides by the physics of the
    contact: at the deepest indentation the gap rate is zero, so the force the accelerometer
    implies must be the Hertz force ``k_H delta^1.5`` of the indentation the cam angle gives
    (:func:`hertz_ratio`); the root whose ratio is nearest 1 is taken. (The reopening time of
    the gap is no guide: with noise and a nearly plastic impact the right root's gap may not
    reopen at all.)

    Parameters
    ----------
    rig : rig P's parameters.
    alpha0 : follower angles [rad]; rate0 : their rates [rad/s].
    omega : cam speed [rad/s].
    contacts : per event, its contact window (:meth:`EventWindows.contact_windows`) or None.
    """
    grid = np.linspace(0.0, 2.0 * math.pi, 721)
    alpha0, rate0 = np.asarray(alpha0, dtype=float), np.asarray(rate0, dtype=float)
    out = np.full(alpha0.size, np.nan)
    # the brackets of every event at once (a sign change of the gap between grid points), and the roots in
    # closed form: psi = sin(a) PE_x + cos(a) PE_y - (h_p + r_c) - e sin(a + Theta) (S-5), so
    # sin(a + Theta) = s with s = (sin(a) PE_x + cos(a) PE_y - h_p - r_c) / e: a + Theta = asin(s) or pi - asin(s)
    g = rig.gap(alpha0[:, None], grid[None, :])
    changes = np.sign(g[:, :-1]) != np.sign(g[:, 1:])
    level = (np.sin(alpha0) * rig.PE_x + np.cos(alpha0) * rig.PE_y - rig.contact_radius) / rig.e
    with np.errstate(invalid="ignore"):
        phi = np.arctan2(level, np.sqrt((1.0 - level) * (1.0 + level)))
    candidates = np.mod(np.stack([phi - alpha0, math.pi - phi - alpha0], axis=1), 2.0 * math.pi)
    for i, (a, ad) in enumerate(zip(alpha0, rate0)):
        roots = []
        for j in np.flatnonzero(changes[i]):
            lo, hi = grid[j], grid[j + 1]
            inside = candidates[i][(candidates[i] >= lo - ROOT_SLACK) & (candidates[i] <= hi + ROOT_SLACK)]
            if inside.size == 1:
                roots.append(float(min(max(inside[0], lo), hi)))
            else:  # none or both in one bracket (a grazing double root, or rounding at a bracket's end)
                roots.append(optimize.brentq(lambda th, a=a: float(rig.gap(a, th)), lo, hi, xtol=1e-15))
        closing = [th for th in roots if rig.gap_rate(a, ad, th, omega) < 0.0]
        if len(closing) > 1 and contacts is not None and contacts[i] is not None:
            t, alpha, acceleration = contacts[i]
            ratios = np.array([hertz_ratio(rig, t, alpha, acceleration, th, omega) for th in closing])
            scores = np.where(ratios > 0.0, np.abs(np.log(np.where(ratios > 0.0, ratios, 1.0))), np.inf)
            out[i] = closing[int(np.argmin(scores))]
        elif closing:
            out[i] = closing[0]
        elif roots:  # grazing: take the root nearest the closing side
            out[i] = min(roots, key=lambda th: rig.gap_rate(a, ad, th, omega))
    return out


def hertz_ratio(rig: RigParameters, t: np.ndarray, alpha: np.ndarray, acceleration: np.ndarray,
                theta0: float, omega: float) -> float:
    """Force implied by the accelerometer at the deepest indentation over ``k_H delta^1.5`` there,
    for the contact histories ``t`` [s from the onset], ``alpha`` [rad], ``acceleration``
    [rad/s^2] with the cam at ``theta0 + omega t`` (NaN without indentation)."""
    gap = rig.gap(alpha, theta0 + omega * t)
    j = int(np.argmin(gap))
    delta = -float(gap[j])
    if not delta > 0.0:
        return math.nan
    alpha, theta = float(alpha[j]), float(theta0 + omega * t[j])
    torque = rig.m_b * rig.g * rig.l_g * math.cos(alpha) - float(
        spring_force(alpha, rig.k_s, rig.L_s_u, rig.d_y, rig.d_x, rig.w_b)) * rig.d_x
    chi = float(rig.lever_arm(alpha, theta))
    force = (rig.I_b * float(acceleration[j]) - torque) / chi
    return force / (rig.k_H * delta ** 1.5)

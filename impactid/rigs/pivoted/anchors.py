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
from dataclasses import dataclass
from typing import ClassVar, Protocol

import numpy as np
from scipy import optimize

from impactid.io import Recording
from impactid.rigs._params import RigParameters
from impactid.rigs.pivoted import spring_force
from impactid.rigs.pivoted.freeflight import FREE_FLIGHT_STEPS, return_time_anchors
from impactid.rigs.pivoted.runs import pack_rig
from impactid.signal import quantisation_step

__all__ = ["ANCHORS", "Anchor", "AnchoredOnsets", "CamGeometryAnchor", "CamPhaseAnchor", "ContactWindow",
           "EventWindows", "ReturnTimeAnchor", "hertz_ratio", "theta_from_gap"]

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
    """

    constants: np.ndarray
    iterations: np.ndarray
    theta_onset: np.ndarray | None = None
    return_time_onset: np.ndarray | None = None
    cam_phase: float = math.nan
    cam_phase_stderr: float = math.nan


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
        guess = np.full(n, windows.rig.static_equilibrium(0.0))
        out = np.empty((n, 3))  # start angle, Newton slope, iterations
        return_time_anchors(start_rate, duration, displacement, guess, pack_rig(windows.rig), self.steps,
                            self.tolerance, out)
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
        phase, stderr = self.fit_phase(windows, alpha_on, phase)
        theta_common = phase + windows.omega * windows.t_onset
        constants = np.asarray(windows.rig.contact_angle(theta_common)) - windows.angle_onset
        return AnchoredOnsets(constants=constants, iterations=start.iterations, theta_onset=theta_common,
                              return_time_onset=start.return_time_onset, cam_phase=phase, cam_phase_stderr=stderr)

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
        resid = np.asarray(rig.contact_angle(phase + omega * t_rel)) - alpha_on
        slope = (np.asarray(rig.contact_angle(phase + 1e-6 + omega * t_rel))
                 - np.asarray(rig.contact_angle(phase - 1e-6 + omega * t_rel))) / 2e-6
        m = int(np.isfinite(resid).sum())
        stderr = float(np.sqrt(np.nansum(resid ** 2) / (m - 1) / np.nansum(slope ** 2))) if m > 1 else math.inf
        return phase, stderr


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
    out = np.full(alpha0.size, np.nan)
    for i, (a, ad) in enumerate(zip(alpha0, rate0)):
        g = rig.gap(a, grid)
        roots = []
        for j in np.flatnonzero(np.sign(g[:-1]) != np.sign(g[1:])):
            roots.append(optimize.brentq(lambda th, a=a: float(rig.gap(a, th)), grid[j], grid[j + 1], xtol=1e-15))
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

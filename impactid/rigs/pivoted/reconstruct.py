"""Per-impact kinematics and contact quantities (sections 5.1 and 8.2 of Sundar, Dreyer & Singh (2016)).

For every usable event of an :class:`~impactid.events.EventTable` (one cam revolution from a
contact onset to the next):

1. the angular acceleration ``a_t / l_a`` is detrended and integrated twice
   (:func:`impactid.signal.detrend_integrate`, method by name). Two refinements of the paper's
   steps make this exact to the sampling's accuracy (alpha_m to ~5e-6 instead of ~2e-5):

   * the event means (of the acceleration, then of the rate) are taken over the event's true
     span, from its sub-sample onset to the next one, with the chosen quadrature plus the two
     sub-sample pieces, instead of over the samples: over one revolution of period-1 motion the
     true acceleration and rate then integrate to zero exactly, so what is removed is the
     accelerometer's offset and the rate's constant and nothing of the motion;
   * each pulse edge (onset and separation) is fitted with ``c |t - t_edge|^p`` from its two
     nearest contact samples and the integration rule's error on that singular part is
     subtracted (:func:`impactid.signal.edge_correction`).

   Both need the edge samples :data:`EDGE_SNR` times above the noise floor; with noisy data the
   paper's plain sample means are used (noise then dominates the error anyway). Beyond period-1
   points (docs/estimation.md, "Long contacts and period-k motion"):

   * the window is integrated over one period of the motion (to the onset that closes it,
     ``period_end`` of the events: ``m`` onsets later in period-``k`` motion with ``m`` impacts),
     where the state recurs and the event means are exact, and cut at the next onset
     (:func:`_window_integral`);
   * a pulse whose head peaks within :data:`HEAD_MODEL_PEAK_SAMPLES` samples (a nearly plastic
     contact) is modelled as a Hunt–Crossley impact (:class:`PulseHead`), which gives its onset,
     its rise's integral and the rules' quadrature error on it;
   * a contact that the accelerometer's force balance shows to last beyond the detected separation
     (a tail smooth over the detector's baseline) gets its separation found again and the events
     are integrated and anchored again (:func:`_contacts_that_end_later`); one that lasts beyond
     :data:`~impactid.events.RIDING_FRACTION` of a revolution is a follower riding the cam;
2. the constant of the second integration is anchored, by name (:data:`ANCHORS`: typed anchor
   objects of :mod:`impactid.rigs.pivoted.anchors`, each given the integrated
   :class:`~impactid.rigs.pivoted.anchors.EventWindows` and returning
   :class:`~impactid.rigs.pivoted.anchors.AnchoredOnsets`):

   ``return-time``
       the paper's function Xi (S-19): the free-flight angle from which the follower, starting
       with the measured rate, covers the measured displacement in the measured flight time.
       The flight runs from 8 samples after separation to 8 samples before the next onset
       (both in free flight), so neither end needs a sub-sample contact time; the paper's form
       (return to the same angle after ``t_e``, taking ``t_a ~ 0``) is the special case of zero
       displacement. Newton on the compiled free flight with its exact sensitivity. Assumes
       period-1 motion only through the event window being one revolution.
   ``cam-geometry``
       the gap is zero at the contact onset: ``alpha(t0) = contact_angle(Theta(t0))`` with
       ``Theta`` from the ``cam_angle`` channel (a least-squares line through the event's
       encoder samples at the nominal cam speed, with half a count added back when the channel
       is quantised, since an encoder counter truncates).
   ``cam-phase``
       the cam turns at constant speed, so all onsets share one cam phase ``Theta_ref``
       (``Theta(t_onset) = Theta_ref + 2 pi Omega_c t_onset``): the return-time anchor gives one
       estimate of it per event, their circular median the recording's phase, and the gap is
       zero at each onset at that cam angle. No encoder needed; the onset angle carries no
       double-integration error (with 0.5 % noise the onset angle error drops from 1 % to the
       phase's, and the approach-speed scatter with it). Used by the estimators.

3. ``Theta(0)``: from the encoder with ``cam-geometry``, from the recording's phase with ``cam-phase``;
   otherwise from ``psi_i(alpha(0), Theta) = 0`` on the closing branch (the root where the gap rate is negative), and
   ``Theta(t) = Theta(0) + 2 pi Omega_c t`` (S-20);
4. indentation ``-psi_i``, contact force from the pivot forces (S-21) when they exist,
   ``alpha_m`` (S-22, the sampled maximum refined by a parabola), the approach speed ``v_a``
   (the gap rate at the sub-sample onset, i.e. (S-28) with the step ``tau`` equal to the onset's
   distance from the first contact sample; the rate is continuous there in compliant contact),
   the separation speed (the gap rate where the reconstructed gap reopens, interpolated
   linearly between samples; the paper's variant, the gap rate at the maximum of ``alpha_dot``,
   is reported too) and ``xi = v_s / v_a``. ``alpha_m`` is NaN where the follower has no apex
   between the impact and the next one (multi-impact motion).

In :func:`reconstruct` each step is a function: the inputs checked (:func:`_checked_inputs`), the
events chosen (:func:`_events_to_reconstruct`), the windows integrated with their onset states
(:func:`_integrate_events`, :func:`_integrate_windows`, :func:`_onset_states`), the anchor, the onset cam angles
(:func:`_onset_cam_angles`), the per-event table (:func:`_event_table`, :func:`_event_row`) and the
notes (:func:`_plausibility`, :func:`_reconstruction_notes`).

The result holds the per-event table, the contact-phase histories (with 8 samples of margin on
each side) and, on request, the full histories of any event (recomputed, so that 850 events of a
60 s recording do not hold gigabytes). The input recording is never modified.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd
from numba import njit
from scipy import optimize

from impactid import compilation
from impactid.errors import ImpactidError
from impactid.events import (
    BASELINE_GAP,
    RIDING_FRACTION,
    TAIL_BLOCK,
    TAIL_SNR,
    EventTable,
    EventWarning,
    find_events,
    separation_before,
)
from impactid.io import Recording, RecordingError, release_pages
from impactid.rigs._params import RigParameters
from impactid.rigs.pivoted import MODEL_NAME, spring_force
from impactid.rigs.pivoted.anchors import (
    ANCHORS,
    Anchor,
    AnchoredOnsets,
    EventWindows,
    hertz_ratio,
    theta_from_gap,
)
from impactid.rigs.pivoted.freeflight import free_flight_fit
from impactid.rigs.pivoted.runs import pack_rig
from impactid.signal import EventSpan, PowerLawEdge, detrend_integrate, get_integrator, sampled_model_correction

compilation.install()  # before the kernels: the kernel cache's locators and the first-use notice

__all__ = ["ANCHORS", "ANCHOR_MARGIN", "ANCHOR_SEPARATION_DELAY", "CONTACT_ANGLE_MARGIN", "CONTACT_HERTZ_TOLERANCE",
           "EDGE_SNR", "FORCE_BALANCE_TOLERANCE", "HISTORY_MARGIN", "PLAUSIBILITY_EVENTS", "RELEASE_EVENTS",
           "EventKinematics", "Reconstruction", "band_limited_decimation", "reconstruct"]

#: Samples between a free-flight end point of the return-time anchor and a contact.
ANCHOR_MARGIN = 8
#: Time [s] from the detected separation to the start of the return-time anchor's free flight. With
#: ``n < 1.5`` and a large ``beta`` the Hunt-Crossley force turns tensile late in the restitution;
#: once the sensor noise exceeds about 1e-6 of the peak, the event detector's post-pulse baseline
#: absorbs that smooth tail and the detected separation comes up to 0.6 ms early. A free flight
#: started 8 samples after it integrates the tail as flight and biases the onset angle by 1-2 % of
#: ``alpha_m`` (a beta error of -8 to -40 % in the envelope validation). Starting 1.2 ms later
#: removes the bias and moves tail-free cases by less than 0.05 % (docs/validation_envelope.md).
#: The delay is capped at a quarter of the free interval, for events that follow each other closely.
ANCHOR_SEPARATION_DELAY = 1.2e-3
#: Deviation above the noise floor that a pulse edge's first sample needs for its power law to be
#: fitted (the edge corrections and the sub-sample span of the event means; see detrend_integrate).
EDGE_SNR = 20.0
#: Samples of margin kept around the contact phase in the stored histories.
HISTORY_MARGIN = 8
#: Events whose contact histories are made between two releases of the recording's mapped pages
#: (:func:`impactid.io.release_pages`): a history's pivot forces map 64 kB of each force channel.
RELEASE_EVENTS = 64


def _reopening(gap: np.ndarray) -> tuple[int, float] | None:
    """Where a sampled gap turns positive after its deepest point: ``(j, w)`` with the crossing at
    ``j + w`` samples (linear interpolation), or None when it never reopens."""
    deepest = int(np.argmin(gap))
    after = np.flatnonzero((gap[deepest:-1] <= 0.0) & (gap[deepest + 1:] > 0.0))
    if after.size == 0 or gap[deepest] >= 0.0:
        return None
    j = deepest + int(after[0])
    return j, float(-gap[j] / (gap[j + 1] - gap[j]))


@dataclass(frozen=True)
class EventKinematics:
    """Histories of one event on its samples (``t`` from the sub-sample onset [s]).

    ``alpha`` [rad], ``alpha_dot`` [rad/s], ``alpha_ddot`` [rad/s^2] (detrended), ``theta`` [rad],
    ``gap`` [m] (``psi_i``; negative = indentation), ``gap_rate`` [m/s], ``contact_force`` [N]
    (S-21; None without force channels).
    """

    event: int
    t: np.ndarray
    alpha: np.ndarray
    alpha_dot: np.ndarray
    alpha_ddot: np.ndarray
    theta: np.ndarray
    gap: np.ndarray
    gap_rate: np.ndarray
    contact_force: np.ndarray | None

    @property
    def indentation(self) -> np.ndarray:
        """``max(-psi_i, 0)`` [m]."""
        return np.maximum(-self.gap, 0.0)


@dataclass(frozen=True)
class Reconstruction:
    """Result of :func:`reconstruct`: per-event table, contact histories, provenance.

    ``table`` columns (one row per processed event): ``t_onset`` [s], ``t_separation`` [s],
    ``t_next`` [s], ``contact_duration`` [s], ``alpha_onset`` [rad], ``alpha_dot_onset`` [rad/s],
    ``theta_onset`` [rad], ``alpha_m`` [rad], ``t_alpha_m`` [s from onset], ``approach_speed``
    ``v_a`` [m/s], ``separation_speed`` [m/s], ``separation_speed_at_max_rate`` [m/s], ``xi``,
    ``peak_indentation`` [m], ``peak_force`` [N] (NaN without force channels), ``anchor_constant``
    [rad], ``anchor_iterations``, ``contact_duration_force_balance`` [s] (the contact's length by the
    accelerometer's force balance), and the event flags (``chattering``, ``not_period1``, ``periodic``,
    ``riding``, ``contact_consistent``). ``t_onset`` and ``t_next`` are a modelled head's onsets where
    the pulse is under-resolved (:class:`PulseHead`).
    """

    table: pd.DataFrame
    contact: dict[int, EventKinematics]
    integration: str
    anchor: str
    rig: RigParameters  # rig P's parameters
    cam_speed_hz: float
    events: EventTable
    warnings: tuple[str, ...] = ()
    provenance: tuple[str, ...] = field(default=())
    #: cam-phase anchor only: the recording's cam phase ``Theta_ref`` [rad] and its standard error
    cam_phase: float = math.nan
    cam_phase_stderr: float = math.nan
    #: the rig file's free-flight model against the recording's free flights
    #: (:meth:`~impactid.rigs.pivoted.freeflight.FreeFlightFit.to_dict`; empty when not made)
    free_flight: dict = field(default_factory=dict, repr=False)
    #: why the recorded motion is not the rig file's, for a refusal where the reconstruction fails at most
    #: events: the free flight disagrees with the rig's inertia and spring (``rig_mismatch``), or it agrees
    #: but the onsets do not lie on the rig file's cam (``geometry_mismatch``); "" otherwise
    #: (:func:`_rig_file_check`)
    rig_mismatch: str = ""
    geometry_mismatch: str = ""
    _recording: Recording | None = field(default=None, repr=False)

    def __len__(self) -> int:
        return len(self.table)

    @property
    def band_limited(self) -> bool:
        """Whether the recording is band-limited: most of its used pulses' rises are preceded by the ringing of
        a linear-phase anti-alias filter (the event detector's ``ringing`` flag)."""
        table = self.events.table
        if "ringing" not in table or len(self.table) == 0:
            return False
        return bool(table.loc[self.table.index, "ringing"].to_numpy(dtype=bool).mean() > 0.5)

    @property
    def operating_point(self) -> dict:
        """The recording's operating point: cam speed [Hz] and eccentricity ratio ``e/r_c``."""
        return {"cam_speed_hz": self.cam_speed_hz, "e_over_rc": self.rig.e_over_rc}

    @property
    def fixed_parameters(self) -> dict:
        """The rig's parameters other than the operating point's eccentricity ``e``: recordings of one
        joint fit must share them (the contact pair and the follower)."""
        return {k: v for k, v in self.rig.to_dict().items() if k != "e"}

    def event_kinematics(self, event: int) -> EventKinematics:
        """Full histories of one event (recomputed from the recording)."""
        if event not in self.table.index:
            raise KeyError(f"event {event} was not reconstructed (events: {list(self.table.index)[:10]} ...)")
        return _event_histories(self._recording, self.events, self.table.loc[event], self.rig,
                                self.integration, self.cam_speed_hz)


class _Scaled:
    """A channel divided by a constant where it is read (``x[key] / scale``, the same numbers as
    ``(x / scale)[key]``): the accelerometer over its radius, the angular acceleration, without a copy
    of the whole recording (98 MB at 60 s and 204.8 kHz) beside the event windows."""

    __slots__ = ("samples", "scale")

    def __init__(self, samples: np.ndarray, scale: float) -> None:
        self.samples, self.scale = samples, scale

    @property
    def size(self) -> int:
        return self.samples.size

    def __getitem__(self, key):
        return self.samples[key] / self.scale


def _event_histories(rec, events, row, rig, integration, cam_speed_hz) -> EventKinematics:
    """Histories of a whole event window, recomputed from the recording (as ``reconstruct`` did)."""
    position = events.table.index.get_loc(row.name)
    angular = _Scaled(rec["accel_tangential"], rig.l_a)
    noise = events.noise_sigma / rig.l_a
    end = int(events.table["period_end"].iloc[position])
    pulses = _pulses(rec, events, angular, rig, noise, positions=range(position, end + 1))
    dt = 1.0 / rec.sample_rate_hz
    window = _window_integral(angular, pulses, position, dt, integration, noise)
    a = int(pulses.first[position])
    return _contact_history(window.angle, window.rate, window.acceleration, rec, a, 0, window.angle.size,
                            window.onset_offset, float(row["anchor_constant"]), float(row["theta_onset"]), rig,
                            2.0 * math.pi * cam_speed_hz, dt, int(row.name))


def reconstruct(recording: Recording, events: EventTable | None = None, *, integration="rk",
                anchor: str = "return-time", rig: RigParameters | None = None, warn: bool = True) -> Reconstruction:
    """Per-impact kinematics, contact force, approach and separation speeds of every usable event.

    Parameters
    ----------
    recording : a rig P recording with ``accel_tangential`` (forces and ``cam_angle`` optional)
        and ``cam_speed_hz``.
    events : from :func:`~impactid.events.find_events` (found here with defaults if None).
    integration : integration method name (:data:`impactid.signal.INTEGRATORS`) or callable.
    anchor : ``"return-time"`` (the paper's), ``"cam-geometry"`` (needs ``cam_angle``) or ``"cam-phase"``
        (:data:`ANCHORS`, :mod:`impactid.rigs.pivoted.anchors`).
    rig : overrides the recording's rig.
    warn : issue an :class:`~impactid.events.EventWarning` for each note of the result
        (:attr:`Reconstruction.warnings`; those of ``events`` given here were issued by
        :func:`~impactid.events.find_events`). Callers that carry the notes on pass False.

    Raises
    ------
    RecordingError : a needed channel, the rig or the cam speed is missing.
    ValueError : unknown integration or anchor name (listing the valid ones).
    ImpactidError : no usable event.
    """
    rig, cam_speed_hz, method = _checked_inputs(recording, integration, anchor, rig)
    given = events is not None
    events = _events_to_reconstruct(recording, events, warn=warn)
    windows = _integrate_events(recording, rig, events, integration, cam_speed_hz)
    anchored = method.anchor(windows)
    noise = events.noise_sigma / rig.l_a
    durations = _contact_by_force_balance(windows, anchored.constants, noise)
    longer = _contacts_that_end_later(recording, events, windows, durations, cam_speed_hz)
    if longer is not None:  # a tail the event detector's baselines followed: integrate and anchor again
        events = longer
        windows = _integrate_events(recording, rig, events, integration, cam_speed_hz)
        anchored = method.anchor(windows)
        durations = _contact_by_force_balance(windows, anchored.constants, noise)
    theta_on = _onset_cam_angles(windows, anchored)
    table, contact, hertz = _event_table(windows, _refined_onsets(events.usable, windows), anchored, theta_on)
    messages = list(events.warnings) + list(anchored.notes)
    messages += _riding_by_force_balance(recording, table, durations, cam_speed_hz)
    messages += _plausibility(windows, anchored, hertz)
    messages += _reconstruction_notes(recording, table, anchor)
    free_flight, rig_mismatch, geometry_mismatch = _rig_file_check(windows, anchored, noise)
    if rig_mismatch:
        messages.append(f"{recording.source or 'recording'}: {rig_mismatch}")
    int_name = integration if isinstance(integration, str) else getattr(integration, "__name__", "custom")
    if warn:
        for message in messages[len(events.warnings) if given else 0:]:
            warnings.warn(message, EventWarning, stacklevel=2)
    return Reconstruction(
        table=table, contact=contact, integration=int_name, anchor=anchor, rig=rig, cam_speed_hz=cam_speed_hz,
        events=events, warnings=tuple(messages), cam_phase=float(anchored.cam_phase),
        cam_phase_stderr=float(anchored.cam_phase_stderr), free_flight=free_flight, rig_mismatch=rig_mismatch,
        geometry_mismatch=geometry_mismatch,
        provenance=events.provenance + (f"reconstruct(integration={int_name!r}, anchor={anchor!r}): "
                                        f"{len(table)} events",),
        _recording=recording)


def _checked_inputs(recording: Recording, integration, anchor: str,
                    rig: RigParameters | None) -> tuple[RigParameters, float, Anchor]:
    """The rig, the cam speed [Hz] and the anchor of a reconstruction, once its inputs are checked.

    Raises
    ------
    ValueError : unknown integration or anchor name.
    RecordingError : not a rig P recording, or a channel the reconstruction or the anchor needs is missing.
    """
    get_integrator(integration)  # validate the name before any work
    if anchor not in ANCHORS:
        raise ValueError(f"unknown anchor {anchor!r}; valid: {', '.join(ANCHORS)}")
    method = ANCHORS[anchor]
    rig = rig if rig is not None else recording.require_rig(MODEL_NAME)
    if getattr(rig, "model", None) != MODEL_NAME:
        raise RecordingError(f"{recording.source}: per-impact reconstruction needs a pivoted-follower rig")
    recording.require("accel_tangential", method="per-impact reconstruction")
    for channel in method.channels:
        recording.require(channel, method=f"the {anchor!r} anchor")
    return rig, recording.require_cam_speed(), method


def _events_to_reconstruct(recording: Recording, events: EventTable | None, *, warn: bool) -> EventTable:
    """The events (found with defaults when None, their notes left to the result) with usable ones.

    Raises
    ------
    ImpactidError : no usable event (the notes of events found here, which say why, are issued first).
    """
    given = events is not None
    if events is None:
        events = find_events(recording, warn=False)  # its notes are this result's first ones
    if events.usable.empty:
        for message in events.warnings if warn and not given else ():  # they say why (clipped, overlapping)
            warnings.warn(message, EventWarning, stacklevel=3)
        where = recording.source or "recording"
        why = "; ".join(m.removeprefix(f"{where}: ") for m in events.warnings)
        raise ImpactidError(f"{where}: no usable impact events ({len(events)} found, none complete and clean"
                            + (f": {why})" if why else ")"))
    return events


def _integrate_events(recording: Recording, rig: RigParameters, events: EventTable, integration,
                      cam_speed_hz: float) -> EventWindows:
    """Each usable event's window integrated twice (before anchoring, :func:`_window_integral`), with its
    onset state and the free flight of the return-time anchor (:data:`ANCHOR_MARGIN`,
    :data:`ANCHOR_SEPARATION_DELAY`)."""
    usable = events.usable
    rate_hz = recording.sample_rate_hz
    dt = 1.0 / rate_hz
    angular = _Scaled(recording["accel_tangential"], rig.l_a)
    noise = events.noise_sigma / rig.l_a
    pulses = _pulses(recording, events, angular, rig, noise)
    positions = [events.table.index.get_loc(e) for e in usable.index]
    windows = [_window_integral(angular, pulses, p, dt, integration, noise) for p in positions]
    k0 = usable["onset_index"].to_numpy()
    k1 = usable["next_index"].to_numpy()
    ka = usable["separation_index"].to_numpy()
    onset_offset = np.array([w.onset_offset for w in windows])
    next_offset = np.array([w.next_offset for w in windows])
    head_change = np.array([w.head_rate_change for w in windows])
    tail_change = np.array([w.tail_rate_change for w in windows])
    impulsive = usable["too_short"].to_numpy(dtype=bool)
    angles = [w.angle for w in windows]
    rates = [w.rate for w in windows]
    accs = [w.acceleration for w in windows]
    angle_onset, rate_onset, rate_after = _onset_states(angular, k0, ka, onset_offset, head_change, impulsive,
                                                        angles, rates, accs, dt)
    band = np.array([math.isfinite(w.onset_rate) for w in windows], dtype=bool)
    if band.any():
        rate_onset = np.where(band, [w.onset_rate for w in windows], rate_onset)
        angle_onset = np.where(band, [w.onset_angle for w in windows], angle_onset)
    free_samples = k1 - ka
    delay = np.maximum(ANCHOR_MARGIN, np.minimum(round(ANCHOR_SEPARATION_DELAY * rate_hz), free_samples // 4))
    return EventWindows(
        recording=recording, rig=rig, sample_rate_hz=rate_hz, omega=2.0 * math.pi * cam_speed_hz, first_sample=k0,
        next_sample=k1, separation_sample=ka, onset_offset=onset_offset, next_offset=next_offset,
        t_onset=pulses.t_onset[positions] - recording.start_time_s, impulsive=impulsive,
        head_rate_change=head_change, tail_rate_change=tail_change, angles=angles, rates=rates, accelerations=accs,
        angle_onset=angle_onset, rate_onset=rate_onset, rate_after=rate_after,
        contact_end=(ka - k0) + ANCHOR_MARGIN, free_start=(ka - k0) + delay, free_end=(k1 - k0) - 1 - ANCHOR_MARGIN,
        t_next=pulses.t_onset[[p + 1 for p in positions]] - recording.start_time_s)


def _refined_onsets(usable: pd.DataFrame, windows: EventWindows) -> pd.DataFrame:
    """The usable events with the onset times of the reconstruction (a modelled head's, :class:`PulseHead`)
    in ``t_onset`` and ``t_next`` where they differ from the event detector's."""
    start = windows.recording.start_time_s
    onset = windows.t_onset + start
    nxt = windows.t_next + start
    moved = np.abs(onset - usable["t_onset"].to_numpy()) > 1e-12
    moved_next = np.abs(nxt - usable["t_next"].to_numpy()) > 1e-12
    if not (moved.any() or moved_next.any()):
        return usable
    out = usable.copy()
    out.loc[moved, "t_onset"] = onset[moved]
    out.loc[moved_next, "t_next"] = nxt[moved_next]
    return out


@dataclass(frozen=True)
class _Pulses:
    """The contact pulses of an :class:`~impactid.events.EventTable`, by position in its table.

    ``first``: first contact sample; ``onset``: the onset [samples of the recording, fractional;
    the head model's where it exists, the event detector's otherwise]; ``t_onset``: the same [s];
    ``separation`` [samples, fractional]; ``impulsive``: fewer than 3 contact samples; ``period_end``:
    the position of the event that closes the integration window; ``heads``: the :class:`PulseHead`
    of each under-resolved pulse (None for the others).
    """

    first: np.ndarray
    onset: np.ndarray
    t_onset: np.ndarray
    separation: np.ndarray
    impulsive: np.ndarray
    period_end: np.ndarray
    heads: tuple
    ringing: np.ndarray | None = None


def _pulses(recording: Recording, events: EventTable, angular: np.ndarray, rig: RigParameters, noise: float,
            positions=None) -> _Pulses:
    """The pulses of ``events`` with the head model fitted to the under-resolved ones among ``positions``
    (all by default; :func:`_fit_pulse_head`). ``angular`` is the recording's angular acceleration
    [rad/s^2] and ``noise`` its noise floor [rad/s^2]."""
    table = events.table
    rate_hz = recording.sample_rate_hz
    first = table["onset_index"].to_numpy()
    onset = (table["t_onset"].to_numpy() - recording.start_time_s) * rate_hz
    t_onset = table["t_onset"].to_numpy().copy()
    impulsive = table["too_short"].to_numpy(dtype=bool)
    clean = ~(table["overlapping"] | table["clipped"]).to_numpy(dtype=bool)
    ringing = table["ringing"].to_numpy(dtype=bool) if "ringing" in table else None
    heads: list[PulseHead | None] = [None] * len(table)
    rises: list[int] = []
    for p in range(len(table)) if positions is None else positions:
        if p < 0 or p >= len(table) or impulsive[p] or not clean[p] or not math.isfinite(onset[p]):
            continue
        if ringing is not None and ringing[p]:  # a band-limited rise: no head model of a sharp one
            continue
        head = _fit_pulse_head(angular, int(first[p]), float(onset[p]), 1.0 / rate_hz, rig, noise)
        if head is not None:
            heads[p] = head
            onset[p] = head.onset
            t_onset[p] = recording.start_time_s + head.onset / rate_hz
            continue
        rises.append(p)
    # the onsets of resolved pulses whose rise is not one power law (the recording's median exponent of its first
    # two contact samples away from Hertz's 1.5): refined by the head model, each fit started from the last one's law
    if rises and _rises_not_one_power_law(angular, first, onset, impulsive, clean, noise):
        law = None
        for p in rises:
            separation = (float(table["t_separation"].iloc[p]) - recording.start_time_s) * rate_hz
            rise, fitted = _fit_rise_onset(angular, int(first[p]), float(onset[p]), separation, 1.0 / rate_hz, rig,
                                           noise, law)
            if rise is not None:
                law = fitted
                onset[p] = rise
                t_onset[p] = recording.start_time_s + rise / rate_hz
    return _Pulses(first=first, onset=onset, t_onset=t_onset,
                   separation=(table["t_separation"].to_numpy() - recording.start_time_s) * rate_hz,
                   impulsive=impulsive, period_end=table["period_end"].to_numpy(), heads=tuple(heads),
                   ringing=ringing)


@dataclass(frozen=True)
class _WindowIntegral:
    """One event's window integrated (:func:`_window_integral`): on the samples from its first contact
    sample to the last before the next onset, the detrended angular acceleration [rad/s^2], the rate
    [rad/s] and the angle [rad] up to its constant; the onset's and the next onset's sub-sample offsets
    before their first contact samples [samples], and the rate changes [rad/s] over the sub-sample
    pieces from the onset to the first sample and from the last sample to the next onset."""

    acceleration: np.ndarray
    rate: np.ndarray
    angle: np.ndarray
    onset_offset: float
    next_offset: float
    head_rate_change: float
    tail_rate_change: float
    onset_rate: float = math.nan
    onset_angle: float = math.nan


def _window_integral(angular: np.ndarray, pulses: _Pulses, position: int, dt: float, integration,
                     noise: float) -> _WindowIntegral:
    """The event at ``position`` integrated over one period of the motion, cut to its own window.

    The event means of :func:`~impactid.signal.detrend_integrate` (the accelerometer's offset and the
    rate's constant) are exact where the true acceleration and rate integrate to zero: over a span in
    which the follower's state recurs, i.e. one period of the motion, from the event's onset to the
    onset one period later (``period_end``; the next onset in period-1 motion, the ``m``-th next in
    period-``k`` motion with ``m`` impacts, whose impacts differ from each other). The span is
    integrated with every pulse's edges (:func:`_pulse_edges`) and the quadrature corrections of the
    modelled heads (:class:`PulseHead`), and cut at the next onset.
    """
    p, q = position, int(pulses.period_end[position])
    k0, k1, kend = int(pulses.first[p]), int(pulses.first[p + 1]), int(pulses.first[q])
    onset_offset = float(k0 - pulses.onset[p])
    next_offset = float(k1 - pulses.onset[p + 1])
    end_offset = float(kend - pulses.onset[q])
    if pulses.ringing is not None and pulses.ringing[p] and k0 - RINGING_LEAD - RINGING_FIT >= 0:
        return _band_limited_window(angular, k0, k1, kend, onset_offset, next_offset, end_offset, dt, integration)
    n = kend - k0
    edges: list[PowerLawEdge] = []
    correction = None
    for r in range(p, q):
        if pulses.impulsive[r]:
            continue
        kr = int(pulses.first[r])
        shift = (kr - k0) * dt
        head = pulses.heads[r]
        for edge in _pulse_edges(angular, kr, float(kr - pulses.onset[r]), float(pulses.separation[r]), dt, noise,
                                 onset=head is None):
            edges.append(edge if r == p else replace(edge, time=edge.time + shift))
        if head is not None:
            term = sampled_model_correction(n, dt, integration, kr - k0, head.values, head.exact)
            correction = term if correction is None else correction + term
    head = pulses.heads[p]
    if head is not None:
        head_change = head.rise_integral
    else:
        head_change = float(_onset_rate_change(angular, np.array([k0]), np.array([onset_offset]), dt, noise)[0])
    span_tail = float(_free_tail_rate_change(angular, np.array([kend]), np.array([end_offset]), dt)[0])
    span = _event_span(onset_offset, end_offset, head_change, span_tail)
    add, rate, angle = detrend_integrate(angular[k0:kend], dt, integration, span=span, edges=tuple(edges),
                                         rate_correction=correction)
    own = k1 - k0
    tail_change = span_tail if q == p + 1 else float(
        _free_tail_rate_change(angular, np.array([k1]), np.array([next_offset]), dt)[0])
    return _WindowIntegral(acceleration=add[:own], rate=rate[:own], angle=angle[:own], onset_offset=onset_offset,
                           next_offset=next_offset, head_rate_change=head_change, tail_rate_change=tail_change)


#: The rate [Hz] at which the calibration and the model check replay a band-limited recording before its anti-alias
#: filter and decimation (:func:`band_limited_decimation`).
FILTER_SOURCE_RATE_HZ = 204_800.0


def band_limited_decimation(sample_rate_hz: float) -> int:
    """The decimation factor with which the calibration and the model check reproduce a band-limited recording at
    ``sample_rate_hz`` [Hz]: simulated at :data:`FILTER_SOURCE_RATE_HZ` or more, then low-passed by a
    linear-phase filter at the recording's Nyquist frequency and decimated (at least 2)."""
    return max(2, int(math.ceil(FILTER_SOURCE_RATE_HZ / float(sample_rate_hz) - 1e-9)))


#: Samples before the first contact sample where a band-limited (anti-alias filtered) event's window starts,
#: clear of the filter's ringing ahead of the rise (:func:`_band_limited_window`) ...
RINGING_LEAD = 24
#: ... and the samples of free flight before that, to which the free-flight acceleration is fitted.
RINGING_FIT = 48


def _band_limited_window(angular, k0, k1, kend, onset_offset, next_offset, end_offset, dt, integration):
    """The window of a band-limited event: one period from :data:`RINGING_LEAD` samples before the first
    contact sample (free flight, clear of the filter's ringing), integrated without edge corrections
    (the quadrature of a band-limited pulse needs none), and the onset state carried from the window's
    start to the onset along the free-flight acceleration (a quadratic fitted to the
    :data:`RINGING_FIT` samples before it)."""
    lead = RINGING_LEAD
    lo = k0 - lead
    n = kend - k0
    a = np.asarray(angular[lo:kend], dtype=float)
    tail = 1.0 - end_offset + onset_offset
    span = EventSpan(head=0.0, tail=tail, head_rate_change=0.0, tail_rate_change=float(a[n - 1]) * tail * dt)
    add_p, rate_p, _ = detrend_integrate(a[:n], dt, integration, span=span)
    bias = float(a[0] - add_p[0])
    integral = get_integrator(integration)
    add = a - bias
    rate = integral(add, dt) + float(rate_p[0])
    angle = integral(rate, dt)
    # free flight before the window: acceleration c0 + c1 u + c2 u^2, u in samples from the window's start
    u_fit = np.arange(-RINGING_FIT, 0, dtype=float)
    c2, c1, c0 = np.polyfit(u_fit, np.asarray(angular[lo - RINGING_FIT:lo], dtype=float) - bias, 2)
    s_on = lead - onset_offset
    onset_rate = float(rate[0]) + dt * (c0 * s_on + c1 * s_on ** 2 / 2.0 + c2 * s_on ** 3 / 3.0)
    onset_angle = float(angle[0]) + dt * (float(rate[0]) * s_on
                                          + dt * (c0 * s_on ** 2 / 2.0 + c1 * s_on ** 3 / 6.0 + c2 * s_on ** 4 / 12.0))
    own = k1 - k0
    head_change = float(rate[lead]) - onset_rate
    tail_change = float(add[lead + own - 1] + bias) * (1.0 - next_offset) * dt
    return _WindowIntegral(acceleration=add[lead:lead + own], rate=rate[lead:lead + own], angle=angle[lead:lead + own],
                           onset_offset=onset_offset, next_offset=next_offset, head_rate_change=head_change,
                           tail_rate_change=tail_change, onset_rate=onset_rate, onset_angle=onset_angle)


def _onset_states(angular: np.ndarray, k0: np.ndarray, ka: np.ndarray, onset_offset: np.ndarray,
                  head_change: np.ndarray, impulsive: np.ndarray, angles: list[np.ndarray], rates: list[np.ndarray],
                  accs: list[np.ndarray], dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Angle [rad] (before anchoring) and rate [rad/s] at each sub-sample onset, and the rate just after
    an impulse (NaN for other contacts): ``(angle_onset, rate_onset, rate_after)``.

    Back from the first contact sample, the rate changes over the sub-sample piece by the rise integral
    of the pulse edge, less the removed offset; the angle by the piece's mean rate times its length.
    For impulses (fewer than 3 contact samples) the first samples carry the impulse itself, so the
    pre-impact rate is the integrated rate before it (sample 0 of the window), not extrapolated
    back through the impulse (the onset may then lie after the first contact sample).
    """
    rate_first = np.array([r[0] for r in rates])
    acc_first = np.array([x[0] for x in accs])
    offsets_removed = angular[k0] - acc_first
    edge_rise = np.where(np.isfinite(head_change) & (onset_offset > 0.0),
                         head_change - offsets_removed * onset_offset * dt,
                         onset_offset * dt * acc_first)  # no edge law: linear extrapolation
    rate_onset = rate_first - edge_rise
    angle_onset = np.array([ang[0] for ang in angles]) - onset_offset * dt * 0.5 * (rate_first + rate_onset)
    rate_after = np.full(len(angles), np.nan)
    for i in np.flatnonzero(impulsive):
        # the window starts at the impulse's first sample, so part of it is lost to the quadrature
        # there; the rate after it is right (the window's mean rate is removed), and the exact jump
        # is the impulse area. Both are taken at the impact time (centroid, -onset_offset samples).
        j = min(int(ka[i] - k0[i]) + 1, len(rates[i]) - 1)
        back = (j + onset_offset[i]) * dt
        rate_after[i] = rates[i][j] - accs[i][j] * back
        jump = dt * float(np.sum(accs[i][: j - 1]))
        rate_onset[i] = rate_after[i] - jump
        angle_onset[i] = angles[i][j] - rate_after[i] * back
    return angle_onset, rate_onset, rate_after


def _onset_cam_angles(windows: EventWindows, anchored: AnchoredOnsets) -> np.ndarray:
    """Cam angle [rad] at each onset: the anchor's, or where the gap closes at the anchored onset angle."""
    if anchored.theta_onset is not None:
        return anchored.theta_onset
    alpha_on = windows.angle_onset + anchored.constants
    return theta_from_gap(windows.rig, alpha_on, windows.rate_onset, windows.omega,
                          windows.contact_windows(anchored.constants))


def _event_table(windows: EventWindows, usable: pd.DataFrame, anchored: AnchoredOnsets,
                 theta_on: np.ndarray) -> tuple[pd.DataFrame, dict[int, EventKinematics], np.ndarray]:
    """The per-event table (:class:`Reconstruction`), the contact histories, and each contact's Hertz
    ratio (:func:`~impactid.rigs.pivoted.anchors.hertz_ratio`; NaN for impulses)."""
    rig, omega, dt = windows.rig, windows.omega, windows.dt
    constants = anchored.constants
    alpha_on = windows.angle_onset + constants
    k0, k1, ka = windows.first_sample, windows.next_sample, windows.separation_sample
    rows = []
    contact: dict[int, EventKinematics] = {}
    hertz = np.full(len(windows), np.nan)
    for i, event in enumerate(usable.index):
        if i % RELEASE_EVENTS == RELEASE_EVENTS - 1:
            release_pages(windows.recording)  # the pivot forces' windows read so far
        n_contact = int(ka[i] - k0[i])
        hi = min(n_contact + HISTORY_MARGIN, int(k1[i] - k0[i]))
        hist = _contact_history(windows.angles[i], windows.rates[i], windows.accelerations[i], windows.recording,
                                k0[i], 0, hi, windows.onset_offset[i], constants[i], theta_on[i], rig, omega, dt,
                                event)
        contact[event] = hist
        hertz[i] = (math.nan if windows.impulsive[i] else
                    hertz_ratio(rig, hist.t, hist.alpha, hist.alpha_ddot, float(theta_on[i]), omega))
        rows.append(_event_row(windows, i, usable.loc[event], hist, alpha_on[i], theta_on[i], anchored, hertz[i]))
    return pd.DataFrame(rows, index=pd.Index(list(usable.index), name="event")), contact, hertz


def _event_row(windows: EventWindows, i: int, ev_row: pd.Series, hist: EventKinematics, alpha_on: float,
               theta_on: float, anchored: AnchoredOnsets, hertz: float) -> dict:
    """One row of the per-event table: event ``i``'s onset state, ``alpha_m``, approach and separation
    speeds [m/s], ``xi``, peak indentation [m] and force [N], the anchor's outcome and the event flags."""
    rig, omega, dt = windows.rig, windows.omega, windows.dt
    constant, rate_on, onset_offset = anchored.constants[i], windows.rate_onset[i], windows.onset_offset[i]
    n_contact = int(windows.separation_sample[i] - windows.first_sample[i])
    alpha_full = windows.angles[i] + constant
    j = int(np.argmax(alpha_full))
    alpha_m, t_m = _parabolic_max(alpha_full, j)
    if j <= n_contact or j >= alpha_full.size - 2:
        # no apex between this impact and the next (multi-impact motion: the cam catches the follower
        # while it still rises, or the follower never rises above its onset angle): the window's
        # largest angle is that at one of its ends, which any law reproduces; there is no alpha_m (NaN)
        alpha_m = t_m = math.nan
    v_a = -float(rig.gap_rate(alpha_on, rate_on, theta_on, omega))
    if windows.impulsive[i]:
        v_s = float(rig.gap_rate(alpha_on, windows.rate_after[i], theta_on, omega))
    else:
        v_s = _reopening_rate(hist)
    jmax = int(np.argmax(hist.alpha_dot[:n_contact + 1])) if n_contact >= 1 else 0
    v_s_paper = float(hist.gap_rate[jmax])
    return {
        "t_onset": ev_row["t_onset"], "t_separation": ev_row["t_separation"], "t_next": ev_row["t_next"],
        "contact_duration": ev_row["t_separation"] - ev_row["t_onset"],
        "alpha_onset": alpha_on, "alpha_dot_onset": rate_on, "theta_onset": theta_on,
        "alpha_m": alpha_m, "t_alpha_m": (t_m + onset_offset) * dt,
        "approach_speed": v_a, "separation_speed": v_s, "separation_speed_at_max_rate": v_s_paper,
        "xi": v_s / v_a if v_a > 0 else math.nan,
        "peak_indentation": float(np.max(-hist.gap)),
        "peak_force": float(np.max(hist.contact_force)) if hist.contact_force is not None else math.nan,
        "anchor_constant": constant, "anchor_iterations": anchored.iterations[i],
        "onset_offset": onset_offset, "next_offset": windows.next_offset[i],
        "head_rate_change": windows.head_rate_change[i], "tail_rate_change": windows.tail_rate_change[i],
        "chattering": bool(ev_row["chattering"]), "not_period1": bool(ev_row["not_period1"]),
        "periodic": bool(ev_row["periodic"]), "riding": bool(ev_row["riding"]),
        "hertz_ratio": hertz,
        "contact_consistent": bool(not math.isfinite(hertz)
                                   or 1.0 / CONTACT_HERTZ_TOLERANCE <= hertz <= CONTACT_HERTZ_TOLERANCE),
    }


def _reconstruction_notes(recording: Recording, table: pd.DataFrame, anchor: str) -> list[str]:
    """Notes on events whose gap does not reopen (``xi`` undetermined) and where the anchor did not converge."""
    messages = []
    undetermined = table.index[~np.isfinite(table["xi"])].tolist()
    if undetermined:
        messages.append(
            f"{recording.source or 'recording'}: the reconstructed gap does not reopen after the contact at events "
            f"{undetermined[:12]}{' ...' if len(undetermined) > 12 else ''}: separation speed and xi are undetermined "
            "there (the angle error exceeds the indentation; noisy or non-period-1 data)")
    failed = table.index[table["anchor_iterations"] < 0].tolist()
    if failed:
        messages.append(f"{recording.source or 'recording'}: the {anchor} anchor did not converge at events {failed}")
    return messages


#: Smallest contact force [N] the accelerometer's force balance tells from free flight (a follower riding
#: the cam presses on it with about 3 N: the envelope validation's hc16 and hc44).
CONTACT_FORCE_FLOOR = 0.3
#: Samples per block of the force-balance test of a contact's end (:func:`_contact_by_force_balance`).
FORCE_BALANCE_BLOCK = 32


def _contact_by_force_balance(windows: EventWindows, constants: np.ndarray, noise: float) -> np.ndarray:
    """Per event, how long [s] its contact lasts from the onset by the accelerometer's force balance.

    In free flight the follower's angular acceleration is the free-flight torque over ``I_b``, a known
    function of the angle (S-9); in contact it differs by the contact's torque. A follower that rides
    the cam after an impact follows the cam smoothly, so no baseline of the signal alone tells the ride
    from the flight (the event detector ends such a contact 6.7 ms into a 16 ms ride); the force
    balance does (where the reconstruction holds, in periodic motion): ``alpha_ddot - Q(alpha) / I_b`` stays
    at the contact's few newtons there and drops to
    the free-flight level (the mean over the window's second half) when the follower lifts off.
    The contact lasts through the blocks of :data:`FORCE_BALANCE_BLOCK` samples after the detected
    separation whose mean stays beyond :data:`CONTACT_FORCE_FLOOR` (as an angular acceleration at the
    0-state lever arm) and :data:`~impactid.events.TAIL_SNR` standard errors of the ``noise`` floor
    [rad/s^2]. NaN where the window is too short or the constant unknown.
    """
    rig = windows.rig
    out = np.full(len(windows), np.nan)
    block = FORCE_BALANCE_BLOCK
    threshold = max(TAIL_SNR * noise / math.sqrt(block), CONTACT_FORCE_FLOOR * rig.chi0 / rig.I_b)
    for i, angle in enumerate(windows.angles):
        if not math.isfinite(constants[i]):
            continue
        residual = windows.accelerations[i] - np.asarray(rig.free_torque(angle + constants[i])) / rig.I_b
        start = int(windows.separation_sample[i] - windows.first_sample[i])
        blocks = (residual.size - start) // block
        if blocks < 2:
            continue
        level = float(np.mean(residual[residual.size // 2:]))
        means = (residual[start:start + blocks * block] - level).reshape(blocks, block).mean(axis=1)
        above = np.abs(means) > threshold
        k = int(np.argmin(above)) if not above.all() else blocks
        out[i] = (start + k * block + windows.onset_offset[i]) * windows.dt
    return out


def _contacts_that_end_later(recording: Recording, events: EventTable, windows: EventWindows, durations: np.ndarray,
                             cam_speed_hz: float) -> EventTable | None:
    """The events with the separations of the contacts that the accelerometer's force balance shows to last
    longer than detected, or None when none does.

    A contact's tail that is smooth over the event detector's 4 ms cubic baseline (a nearly plastic law
    whose tail turns from compressive to tensile along a ramp of 5 ms; a follower riding the cam) passes for
    free flight there. The force balance (``durations`` [s] from each onset, :func:`_contact_by_force_balance`;
    periodic events only: their reconstruction holds) does not: where its contact lasts beyond the detected
    separation by more than one of its blocks, the separation is found again from a free-flight baseline
    started where the force balance ends the contact (:func:`~impactid.events.separation_before`), and the
    ``riding`` flag follows the new duration. Contacts the detector ended right are untouched (their force
    balance ends in the first block after them).
    """
    table = events.table
    usable = events.usable
    rate_hz = recording.sample_rate_hz
    x = recording["accel_tangential"]
    updated = table.copy()
    changed = []
    for i, event in enumerate(usable.index):
        if not bool(usable.loc[event, "periodic"]) or not math.isfinite(durations[i]):
            continue
        k0, ka = int(windows.first_sample[i]), int(windows.separation_sample[i])
        end = k0 + int(math.ceil(durations[i] * rate_hz - windows.onset_offset[i]))
        if end <= ka + FORCE_BALANCE_BLOCK:
            continue
        peak = float(usable.loc[event, "peak"])
        threshold = max(5.0 * events.noise_sigma, 1e-6 * abs(peak))
        block = max(TAIL_SNR * events.noise_sigma / math.sqrt(TAIL_BLOCK), 1e-6 * abs(peak))
        found = separation_before(x, ka, end + BASELINE_GAP, threshold, block, int(windows.next_sample[i]), rate_hz)
        if found is None or found[0] <= ka:
            continue
        updated.loc[event, "separation_index"] = found[0]
        updated.loc[event, "t_separation"] = recording.start_time_s + found[1] / rate_hz
        updated.loc[event, "contact_samples"] = found[0] - int(updated.loc[event, "onset_index"])
        changed.append(event)
    if not changed:
        return None
    duration = (updated["t_separation"] - updated["t_onset"]).to_numpy()
    updated["riding"] = updated["riding"].to_numpy(dtype=bool) | (np.isfinite(duration)
                                                                  & (duration > RIDING_FRACTION / cam_speed_hz))
    return replace(events, table=updated, provenance=events.provenance + (
        f"separations moved to the force balance's contact end at events {changed[:12]}"
        f"{' ...' if len(changed) > 12 else ''}",))


def _riding_by_force_balance(recording: Recording, table: pd.DataFrame, duration: np.ndarray,
                             cam_speed_hz: float) -> list[str]:
    """Mark in ``table`` (column ``riding``) the events whose contact lasts, by the accelerometer's force balance
    (``duration`` [s] from each onset, :func:`_contact_by_force_balance`), more than
    :data:`~impactid.events.RIDING_FRACTION` of a cam revolution; return a note naming those the event detector
    did not mark."""
    table["contact_duration_force_balance"] = duration
    period = 1.0 / cam_speed_hz
    # (only where the reconstruction holds: an event whose onset does not recur is integrated wrongly, and
    # its force balance would show any error as a contact)
    riding = np.isfinite(duration) & (duration > RIDING_FRACTION * period) & table["periodic"].to_numpy(dtype=bool)
    new = riding & ~table["riding"].to_numpy(dtype=bool)
    table["riding"] = table["riding"].to_numpy(dtype=bool) | riding
    if not new.any():
        return []
    longest = float(np.nanmax(duration[new]))
    return [f"{recording.source or 'recording'}: the follower rides the cam after the impact at events "
            f"{table.index[new].tolist()[:12]}{' ...' if new.sum() > 12 else ''}: by the accelerometer's force "
            f"balance the contact lasts up to {longest * 1e3:.3g} ms, {longest / period:.0%} of a cam revolution "
            f"(an impact lasts at most {RIDING_FRACTION:.0%}); the apex after it is set by the cam, not by the "
            "contact law"]


#: Events whose free flights enter the force-balance check (enough to average the noise).
PLAUSIBILITY_EVENTS = 8
#: Mean free-flight contact force, as a fraction of the typical free-flight pivot force, above
#: which the force channels and the accelerometer are reported as inconsistent.
FORCE_BALANCE_TOLERANCE = 0.1
#: Margin [rad] around the range of contact angles within which return-time onset angles must lie.
CONTACT_ANGLE_MARGIN = 0.01
#: Largest factor between the accelerometer's force at the deepest indentation and the Hertz force
#: there for a contact the per-impact method can use. Noise-free they agree to 1-4 % (friction,
#: mu h_p / chi, is 3 % on rig P); with 1 % noise the indentation's error moves the ratio to
#: 0.88-2.0 (measured over period-1 points with beta 8e9-9e10, n 1.2-1.8, and the 45 Hunt-Crossley
#: cases of the envelope validation with 0-1 % noise and 51.2-204.8 kHz: 0.69-1.23). A unit
#: mistake moves it by orders of magnitude (g read as m/s^2: 3e-4), and so does a follower that
#: rides the cam after a nearly plastic impact (0.012 and 779 in the envelope); a nearly plastic
#: impact whose tail the event detector ends too early gives 2.7.
CONTACT_HERTZ_TOLERANCE = 2.5


def _plausibility(windows: EventWindows, anchored: AnchoredOnsets, hertz: np.ndarray) -> list[str]:
    """Cross-checks of the channels against the rig model; returns warning texts naming channels.

    * onset angles (:func:`_onset_angle_check`): the return-time anchor's onset angles
      (accelerometer only) must lie where the follower can touch the cam, within the range of
      ``contact_angle(Theta)`` over a revolution;
    * Hertz at the deepest indentation (:func:`_hertz_check`, accelerometer only): there the gap rate
      is zero, so the Hunt–Crossley damping term vanishes and the contact force is ``k_H delta^1.5``
      with the rig's own Hertz stiffness. The force the accelerometer implies (the equation of motion
      solved for it, friction left out: a few per cent) must match it; an accelerometer in other units
      than declared (g read as m/s^2, say) scales the force but not the indentation in the same way;
    * force balance (S-21) in free flight (:func:`_force_balance_check`), where the contact force is
      zero: with the pivot forces and the accelerometer it must give about 0 N. Swapped or mislabelled
      force channels, or an accelerometer off by a factor, leave a mean force comparable with the
      pivot force itself.
    """
    return (_onset_angle_check(windows, anchored.return_time_onset) + _hertz_check(windows, hertz)
            + _force_balance_check(windows, anchored.constants))


#: Most free flights the rig-file check compares (:func:`_rig_file_check`; 128 flights of a 60 s recording at
#: 204.8 kHz are 1.5 million samples: a misfit of the rig file's model that matters shows in far fewer, and the
#: check of all 959 took 0.43 s of the 60 s estimate's 5).
RIG_CHECK_FLIGHTS = 128


def _rig_file_check(windows: EventWindows, anchored: AnchoredOnsets, noise: float) -> tuple[dict, str, str]:
    """The rig file against the recording's free flights (:func:`~impactid.rigs.pivoted.freeflight.free_flight_fit`).

    Each flight (the return-time anchor's free samples) is compared at the return-time anchor's angles
    (they exist wherever the onset state may not: the anchor's constant needs no cam angle). Returns the
    fit (as a dict; empty when not made), the reason when the free flight disagrees with the rig file's
    inertia and spring, and, when a clean free flight agrees with them but the onset angles lie outside
    the angles where the rig file's follower touches its cam, the reason naming the contact geometry.
    Neither reason is given for a free flight that is not clean (a follower riding the cam, contacts in
    the flight): what it shows is not a rig constant.
    """
    onset = anchored.return_time_onset
    constants = onset - windows.angle_onset if onset is not None else anchored.constants
    flights = [(i, int(windows.free_start[i]), int(windows.free_end[i])) for i in range(len(windows))]
    flights = [(i, lo, hi) for i, lo, hi in flights if hi - lo >= 16 and math.isfinite(constants[i])]
    if len(flights) > RIG_CHECK_FLIGHTS:  # a long recording: flights spread over it (a 60 s one: 128 of 959)
        flights = [flights[k] for k in np.linspace(0, len(flights) - 1, RIG_CHECK_FLIGHTS).round().astype(int)]
    # each flight's angles made as the fit takes it (all of them at once are the length of the recording)
    alphas = (windows.angles[i][lo:hi] + constants[i] for i, lo, hi in flights)
    accelerations = (windows.accelerations[i][lo:hi] for i, lo, hi in flights)
    fit = free_flight_fit(alphas, accelerations, pack_rig(windows.rig), noise)
    if fit is None:
        return {}, "", ""
    if fit.disagrees:
        return fit.to_dict(), fit.reason(), ""
    geometry = ""
    if fit.clean and _onset_angle_check(windows, onset):
        geometry = ("the recorded free flight between impacts agrees with the rig file's free-flight model (its "
                    f"inertia I_b and spring k_s: {100 * fit.misfit:.2g} % of the swing), but the reconstructed "
                    "onsets do not lie where the rig file's follower touches its cam: the recorded motion is not "
                    "the motion of the rig described by the rig file; check the rig file's contact geometry (the "
                    "pin radius r_d, the cam radius r_c and eccentricity e, the pivot position) or the "
                    "accelerometer's scale")
    return fit.to_dict(), "", geometry


def _onset_angle_check(windows: EventWindows, onset: np.ndarray | None) -> list[str]:
    """A note when the median return-time onset angle [rad] lies outside the angles of contact."""
    if onset is None or not np.any(np.isfinite(onset)):
        return []
    reach = np.asarray(windows.rig.contact_angle(np.linspace(0.0, 2.0 * math.pi, 361)))
    lo, hi = float(np.min(reach)) - CONTACT_ANGLE_MARGIN, float(np.max(reach)) + CONTACT_ANGLE_MARGIN
    median = float(np.nanmedian(onset))
    if lo <= median <= hi:
        return []
    where = windows.recording.source or "recording"
    return [f"{where}: channel 'accel_tangential': the reconstructed onset angles (median {median:.4g} rad) "
            f"lie outside the angles where the follower touches the cam ({lo:.4g} to {hi:.4g} rad): the "
            "accelerometer's scale or units look wrong"]


def _hertz_check(windows: EventWindows, ratio: np.ndarray) -> list[str]:
    """A note when the median Hertz ratio of the contacts is beyond :data:`CONTACT_HERTZ_TOLERANCE`."""
    if not np.any(np.isfinite(ratio)):
        return []
    median = float(np.nanmedian(ratio))
    if 1.0 / CONTACT_HERTZ_TOLERANCE <= median <= CONTACT_HERTZ_TOLERANCE:
        return []
    recording = windows.recording
    where = recording.source or "recording"
    unit = recording.units.get("accel_tangential")
    return [f"{where}: channel 'accel_tangential' implies {median:.3g} times the Hertz force k_H delta^1.5 "
            "at the deepest indentation, where the two must agree: either the accelerometer's scale or "
            f"units are wrong (declared {unit!r}; in g, perhaps?), or the contact here is not a short "
            "pulse followed by a free flight (a nearly plastic impact whose tail cannot be told from the "
            "flight, or a follower that rides the cam after the impact); such events are left out of the "
            "estimates"]


def _force_balance_check(windows: EventWindows, constants: np.ndarray) -> list[str]:
    """A note when the force balance (S-21) over the first :data:`PLAUSIBILITY_EVENTS` free flights gives
    a contact force [N] beyond :data:`FORCE_BALANCE_TOLERANCE` of the pivot force (with force channels)."""
    recording, rig = windows.recording, windows.rig
    if not ("force_x" in recording and "force_y" in recording):
        return []
    k0, angles, accs = windows.first_sample, windows.angles, windows.accelerations
    residual, pivot = [], []
    for i in range(min(len(angles), PLAUSIBILITY_EVENTS)):
        lo_i, hi_i = int(windows.free_start[i]), int(windows.free_end[i])
        if hi_i - lo_i < 16:
            continue
        alpha = angles[i][lo_i:hi_i] + constants[i]
        nx = recording["force_x"][k0[i] + lo_i:k0[i] + hi_i]
        ny = recording["force_y"][k0[i] + lo_i:k0[i] + hi_i]
        fs = spring_force(alpha, rig.k_s, rig.L_s_u, rig.d_y, rig.d_x, rig.w_b)
        force = (rig.m_b * rig.l_g * accs[i][lo_i:hi_i] + nx * np.sin(alpha)
                 + (ny + fs - rig.m_b * rig.g) * np.cos(alpha))
        residual.append(float(np.median(force)))
        pivot.append(float(np.median(np.hypot(nx, ny))))
    if not residual:
        return []
    mean_force, typical = float(np.median(residual)), float(np.median(pivot))
    if abs(mean_force) <= FORCE_BALANCE_TOLERANCE * typical:
        return []
    where = recording.source or "recording"
    return [f"{where}: channels 'force_x', 'force_y' and 'accel_tangential' disagree: the force "
            f"balance (S-21) gives {mean_force:.3g} N of contact force in free flight, where it is 0, "
            f"against pivot forces of {typical:.3g} N; are the force channels swapped or mislabelled, "
            "or the accelerometer in other units than declared?"]


def _edge_law(angular: np.ndarray, k: int, s: float, direction: int, noise: float) -> tuple[float, float]:
    """Power law ``c d^p`` of a pulse edge above the free-flight baseline: ``(c, p)``, ``c`` per
    sample^p of the distance ``d`` into the pulse (NaN when the samples do not determine it).

    ``k`` is the contact sample nearest the edge, at distance ``s`` (samples, in (0, 1]) from it;
    ``direction`` +1 for an onset (free samples at ``k - 1, k - 2``; the next contact sample at
    ``k + 1``), -1 for a separation (free samples at ``k + 1, k + 2``; the next at ``k - 1``).
    The baseline is extrapolated linearly from the two free samples; ``p`` follows from the two
    contact samples (Hertz: 1.5). Undetermined (NaN) when the nearer deviation is below
    :data:`EDGE_SNR` times the channel's noise floor ``noise`` [rad/s^2]: a law fitted to noise
    would correct the integral by noise.
    """
    d = direction
    if not (0.0 < s <= 1.0 and 0 <= k - 2 * d < angular.size and 0 <= k + d < angular.size):
        return math.nan, math.nan
    free1, free2 = angular[k - d], angular[k - 2 * d]
    dev0 = angular[k] - (2.0 * free1 - free2)
    dev1 = angular[k + d] - (3.0 * free1 - 2.0 * free2)
    # a compressive edge rises above the baseline; a tensile one (the tail of a law with n < p that
    # pulls before the gap reopens) falls below it: the law is fitted to the magnitudes
    sign = 1.0 if dev0 > 0.0 else -1.0
    dev0, dev1 = sign * dev0, sign * dev1
    if not (EDGE_SNR * noise < dev0 < dev1):
        return math.nan, math.nan
    p = math.log(dev1 / dev0) / math.log((1.0 + s) / s)
    if not 0.0 <= p <= 4.0:
        return math.nan, math.nan
    return sign * dev0 / s ** p, p


def _onset_rate_change(angular: np.ndarray, k: np.ndarray, offset: np.ndarray, dt: float,
                       noise: float) -> np.ndarray:
    """Rate change from each contact onset to its first contact sample ``k`` [rad/s].

    The onset lies ``offset`` samples before ``k``. Over that sub-sample interval the acceleration
    is the free-flight baseline (extrapolated linearly from the two samples before ``k``) plus the
    contact rise ``c (t - t0)^p`` (:func:`_edge_law`), whose integral is ``c offset^(p+1) dt / (p + 1)``.
    NaN where the samples do not determine the edge law.
    """
    out = np.full(k.size, np.nan)
    for i, (kk, s) in enumerate(zip(k, offset)):
        c, p = _edge_law(angular, int(kk), float(s), +1, noise)
        if math.isnan(c):
            continue
        base_mid = angular[kk - 1] + (angular[kk - 1] - angular[kk - 2]) * (1.0 - 0.5 * s)
        out[i] = s * dt * (base_mid + c * s ** p / (p + 1.0))
    return out


def _pulse_edges(angular: np.ndarray, k0: int, onset_offset: float, t_separation: float,
                 dt: float, noise: float, *, onset: bool = True) -> tuple[PowerLawEdge, ...]:
    """The onset and separation edges of the pulse that starts the window at sample ``k0``
    (``t_separation`` in samples of the recording), for :func:`~impactid.signal.edge_correction`
    (the separation's only when ``onset`` is False: a modelled head, :class:`PulseHead`, corrects its own)."""
    edges = []
    c, p = _edge_law(angular, k0, onset_offset, +1, noise) if onset else (math.nan, math.nan)
    if not math.isnan(c):
        edges.append(PowerLawEdge(time=-onset_offset * dt, coefficient=c / dt ** p, exponent=p, side=+1))
    last = int(math.ceil(t_separation)) - 1  # last contact sample
    c, p = _edge_law(angular, last, t_separation - last, -1, noise)
    if not math.isnan(c):
        edges.append(PowerLawEdge(time=(t_separation - k0) * dt, coefficient=c / dt ** p, exponent=p, side=-1))
    return tuple(edges)


def _event_span(onset_offset: float, next_offset: float, head_change: float, tail_change: float) -> EventSpan | None:
    """The true span of an event (onset to next onset) about its samples; None when the sub-sample
    onsets are not both within a sample of the window's ends (then the plain means are used)."""
    head, tail = float(onset_offset), 1.0 - float(next_offset)
    if not (0.0 <= head <= 1.0 and 0.0 <= tail <= 1.0 and math.isfinite(head_change) and math.isfinite(tail_change)):
        return None
    return EventSpan(head=head, tail=tail, head_rate_change=float(head_change), tail_rate_change=float(tail_change))


def _free_tail_rate_change(angular: np.ndarray, k: np.ndarray, offset: np.ndarray, dt: float) -> np.ndarray:
    """Rate change from the last free sample ``k - 1`` to the onset ``offset`` samples before
    ``k`` [rad/s]: the free-flight acceleration (extrapolated linearly) over ``1 - offset`` samples
    (NaN where the onset is not within the sample before ``k``)."""
    out = np.full(k.size, np.nan)
    for i, (kk, s) in enumerate(zip(k, offset)):
        if 2 <= kk <= angular.size and 0.0 <= s < 1.0:
            slope = angular[kk - 1] - angular[kk - 2]
            out[i] = (1.0 - s) * dt * (angular[kk - 1] + 0.5 * slope * (1.0 - s))
    return out


def _contact_history(angle, rate, add, rec, a, lo, hi, offset, constant, theta0, rig, omega, dt, event):
    """Histories on samples ``lo:hi`` of the event window starting at recording sample ``a``."""
    t = (np.arange(lo, hi) + offset) * dt
    alpha = angle[lo:hi] + constant
    theta = theta0 + omega * t
    gap = rig.gap(alpha, theta)
    gap_rate = rig.gap_rate(alpha, rate[lo:hi], theta, omega)
    force = None
    if "force_x" in rec and "force_y" in rec:
        nx = rec["force_x"][a + lo:a + hi]
        ny = rec["force_y"][a + lo:a + hi]
        fs = spring_force(alpha, rig.k_s, rig.L_s_u, rig.d_y, rig.d_x, rig.w_b)
        force = rig.m_b * rig.l_g * add[lo:hi] + nx * np.sin(alpha) + (ny + fs - rig.m_b * rig.g) * np.cos(alpha)
    # copies, not views: a view of the window would keep its whole revolution of samples alive with the
    # result (two float64 arrays the length of the recording over all events: 190 MB for 60 s)
    return EventKinematics(event=int(event), t=t, alpha=alpha, alpha_dot=rate[lo:hi].copy(),
                           alpha_ddot=add[lo:hi].copy(), theta=theta, gap=gap, gap_rate=gap_rate, contact_force=force)


def _parabolic_max(x: np.ndarray, j: int) -> tuple[float, float]:
    """Maximum of a sampled peak refined by the parabola through three samples: (value, index)."""
    if 0 < j < x.size - 1:
        y0, y1, y2 = x[j - 1], x[j], x[j + 1]
        denom = y0 - 2.0 * y1 + y2
        if denom < 0.0:
            s = 0.5 * (y0 - y2) / denom
            return float(y1 - 0.25 * (y0 - y2) * s), j + s
    return float(x[j]), float(j)


def _reopening_rate(hist: EventKinematics) -> float:
    """Gap rate where the gap turns positive again after the deepest indentation (interpolated)."""
    crossing = _reopening(hist.gap)
    if crossing is None:
        return math.nan
    j, w = crossing
    return float((1.0 - w) * hist.gap_rate[j] + w * hist.gap_rate[j + 1])


# ---- under-resolved pulse heads ---------------------------------------------------------------------

#: A pulse whose largest deviation comes within this many samples of its first contact sample is
#: under-resolved: the head of a nearly plastic Hunt–Crossley contact (restitution below about 0.03)
#: stops the approach within 10-20 us (its peak at the 2nd to 4th sample at 204.8 kHz, against the 8th
#: to 25th of the contacts of the validation's period-1 points), and neither a power law of two samples
#: nor any polynomial rule follows it there (onsets off by up to 0.4 samples, the rate after it by
#: 0.5 % of its jump, beta by -3 to -14 %; at 819.2 kHz the same contacts give +0.2 %).
HEAD_MODEL_PEAK_SAMPLES = 5
#: The head model spans the samples until the pulse has decayed below this fraction of its peak...
HEAD_MODEL_END = 5e-3
#: ... and at most this many samples after the first contact sample.
HEAD_MODEL_SAMPLES = 48
#: Samples before the head whose least-squares line is the free-flight baseline under it.
HEAD_BASELINE_SAMPLES = 16
#: RK4 steps per sample interval of the head model's differential equation.
HEAD_MODEL_SUBSTEPS = 32
#: Largest rms misfit of the head model, relative to the pulse's peak, with which it is used (else the
#: power-law edges are: a pulse the model does not describe is left to them).
HEAD_MODEL_MISFIT = 0.02
#: Lever arm [m] of the head model's scale: its value is immaterial (a change of it is a change of the
#: model's scale of indentation, which the fitted coefficients and approach speed absorb exactly).
HEAD_MODEL_LEVER = 0.09


@dataclass(frozen=True)
class PulseHead:
    """The head of an under-resolved contact pulse, modelled as a Hunt–Crossley impact.

    Near its onset a contact of rig P is an impact of the follower (effective mass ``I_b / chi^2``) on
    a cam that moves on by less than its own curvature in the 10-50 us the head lasts: the indentation
    ``delta`` obeys ``delta'' = -chi a(t)`` with the contact's angular acceleration
    ``a = A delta^1.5 + B delta^q delta'`` (the Hertz term and the damping term of the generalised
    Hunt–Crossley force, each times ``chi / I_b``; friction scales both), from ``delta = 0`` and
    ``delta' = v0`` at the onset ``t0``. The five numbers ``t0, v0, A, B, q`` are fitted to the samples
    of the head (:func:`_fit_pulse_head`); the model then gives the onset between samples, the rise's
    integral up to the first contact sample and the rules' quadrature error on the head
    (:func:`~impactid.signal.sampled_model_correction`). Nothing of it enters the estimate of the
    contact law other than through these integrals.

    Attributes
    ----------
    first_sample : the recording's first contact sample of the pulse.
    onset : the onset [samples of the recording, fractional]: between ``first_sample - 1`` and ``first_sample``.
    values : the model's angular acceleration [rad/s^2] at samples ``first_sample ... first_sample + len - 1``.
    exact : its exact integral from ``first_sample`` to each of them [rad/s].
    rise_integral : the angular acceleration's integral from the onset to ``first_sample`` [rad/s]: the
        model's (exact) and the free-flight baseline's.
    misfit : rms misfit relative to the peak.
    """

    first_sample: int
    onset: float
    values: np.ndarray
    exact: np.ndarray
    rise_integral: float
    misfit: float


#: The onset of a resolved pulse is refined by the head model (:func:`_fit_rise_onset`) fitted to this many of
#: its first contact samples ...
RISE_MODEL_SAMPLES = 16
#: ... where it fits them to within this rms fraction of their largest deviation (else the event detector's
#: onset stays).
RISE_MODEL_MISFIT = 1e-4
#: ... in a recording whose rises are not one power law: the median over its pulses of the exponent through their
#: first two contact samples (:func:`_rise_exponent`) more than this away from Hertz's 1.5. A Hunt–Crossley force
#: with ``n`` at or above 1.5 starts as Hertz's power (its damping term rises as fast or faster), the three-sample
#: law is then unbiased (noise-free envelope cases with n 1.58-1.73: exponents 1.500-1.515, the head model's onsets
#: within 0.007 samples of the detector's), and the fit, 5-6 ms a pulse, is not run.
RISE_MODEL_EXPONENT_TOLERANCE = 0.05


@njit(cache=True)
def _head_rhs(d, v, a_coef, b_coef, q):  # pragma: no cover - compiled
    if d <= 0.0:
        return 0.0
    return a_coef * d ** 1.5 + b_coef * d ** q * v


@njit(cache=True)
def _head_model(t0, v0, a_coef, b_coef, q, lever, times, substeps, out_acc, out_rate):  # pragma: no cover
    """Angular acceleration [rad/s^2] and indentation rate [m/s] of the head model at ``times`` [s]
    (ascending; zero acceleration and ``v0`` before the onset ``t0``), RK4 with ``substeps`` steps per
    unit of ``times``' spacing."""
    d = 0.0
    v = v0
    t = t0
    spacing = times[1] - times[0] if times.size > 1 else 1.0
    for k in range(times.size):
        tk = times[k]
        if tk <= t0:
            out_acc[k] = 0.0
            out_rate[k] = v0
            continue
        m = max(1, int(math.ceil((tk - t) / spacing * substeps)))
        h = (tk - t) / m
        for _ in range(m):
            a1 = _head_rhs(d, v, a_coef, b_coef, q)
            k1d, k1v = v, -lever * a1
            a2 = _head_rhs(d + 0.5 * h * k1d, v + 0.5 * h * k1v, a_coef, b_coef, q)
            k2d, k2v = v + 0.5 * h * k1v, -lever * a2
            a3 = _head_rhs(d + 0.5 * h * k2d, v + 0.5 * h * k2v, a_coef, b_coef, q)
            k3d, k3v = v + 0.5 * h * k2v, -lever * a3
            a4 = _head_rhs(d + h * k3d, v + h * k3v, a_coef, b_coef, q)
            k4d, k4v = v + h * k3v, -lever * a4
            d += h / 6.0 * (k1d + 2.0 * k2d + 2.0 * k3d + k4d)
            v += h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v)
        t = tk
        out_acc[k] = _head_rhs(d, v, a_coef, b_coef, q)
        out_rate[k] = v


def _head_residual(times: np.ndarray, deviation: np.ndarray, peak: float, dt: float):
    """The residuals of the head model (:func:`_head_model`) against ``deviation`` [rad/s^2] at ``times`` [s], in
    fractions of ``peak``, as a function of its parameters ``x``: the onset [samples of ``dt``], the logs of the
    approach speed and of the two coefficients, the exponent (a non-finite value counts as 1e6)."""
    acc = np.empty(times.size)
    rate = np.empty(times.size)

    def residual(x):
        _head_model(x[0] * dt, math.exp(x[1]), math.exp(x[2]), math.exp(x[3]), x[4], HEAD_MODEL_LEVER, times,
                    HEAD_MODEL_SUBSTEPS, acc, rate)
        out = (acc - deviation) / peak
        return np.where(np.isfinite(out), out, 1e6)

    return residual


def _two_sample_exponent(first: float, second: float, s: float) -> float:
    """The exponent ``p`` of the power law ``c (t - t0)^p`` through a pulse's first two contact samples ``first``
    and ``second`` (above its baseline) when its onset lies ``s`` samples before the first."""
    return math.log(second / first) / math.log((1.0 + s) / s)


def _head_baseline(angular: np.ndarray, k0: int):
    """The free-flight baseline under a pulse whose first contact sample is ``k0``: the least-squares
    line through the :data:`HEAD_BASELINE_SAMPLES` samples before it (a function of sample indices),
    or None without room."""
    lo = k0 - HEAD_BASELINE_SAMPLES
    if lo < 0:
        return None
    idx = np.arange(lo, k0)
    slope, intercept = np.polyfit(idx - k0, angular[lo:k0], 1)
    return lambda at: intercept + slope * (np.asarray(at, dtype=float) - k0)


def _fit_pulse_head(angular: np.ndarray, k0: int, onset_guess: float, dt: float, rig: RigParameters,
                    noise: float) -> PulseHead | None:
    """The head model (:class:`PulseHead`) of the pulse whose first contact sample is ``k0``, or None
    when the pulse is resolved (its peak later than :data:`HEAD_MODEL_PEAK_SAMPLES` samples after
    ``k0``), below :data:`EDGE_SNR` times the ``noise`` floor [rad/s^2], or not described by the model
    (misfit above :data:`HEAD_MODEL_MISFIT`). ``onset_guess`` [samples] is the event detector's onset."""
    baseline = _head_baseline(angular, k0)
    hi = min(k0 + HEAD_MODEL_SAMPLES, angular.size)
    if baseline is None or hi - k0 < 8:
        return None
    idx = np.arange(k0 - 2, hi)
    dev = angular[idx] - baseline(idx)
    contact = dev[2:]
    j_peak = int(np.argmax(contact))
    peak = float(contact[j_peak])
    if j_peak >= HEAD_MODEL_PEAK_SAMPLES or not peak > EDGE_SNR * noise:
        return None
    below = np.flatnonzero(contact[j_peak:] < HEAD_MODEL_END * peak)
    end = j_peak + int(below[0]) + 1 if below.size else contact.size
    idx, dev = idx[: end + 2], dev[: end + 2]
    times = (idx - k0) * dt
    lever = HEAD_MODEL_LEVER
    s0 = min(max(k0 - onset_guess, 0.05), 0.95)
    q0 = 1.3
    if contact[0] > 0.0 and contact[1] > contact[0]:
        q0 = min(max(_two_sample_exponent(contact[0], contact[1], s0), 0.8), 2.5)
    v0 = lever * float(np.sum(dev)) * dt
    if not v0 > 0.0:
        return None
    a0 = lever * rig.k_H / rig.I_b
    t_peak = (j_peak + s0) * dt
    d_peak, v_peak = 0.5 * v0 * t_peak, 0.5 * v0
    residual = _head_residual(times, dev, peak, dt)

    fit = None
    for q in (q0, 1.5) if abs(q0 - 1.5) > 0.05 else (q0,):  # the damping-dominated and the Hertzian start
        b = max(peak - a0 * d_peak ** 1.5, 0.1 * peak) / (d_peak ** q * v_peak)
        start = np.array([-s0, math.log(v0), math.log(a0), math.log(b), q])
        # the logarithms within e^+-12 (a factor of 1.6e5) of their starts: far beyond any head's, and
        # short of the floating-point range
        reach = np.array([0.0, 12.0, 12.0, 12.0, 0.0])
        try:
            trial = optimize.least_squares(residual, start, bounds=(np.array([-2.0, 0, 0, 0, 0.5]) + start * (reach > 0)
                                                                    - reach,
                                                                    np.array([0.2, 0, 0, 0, 3.0]) + start * (reach > 0)
                                                                    + reach),
                                           x_scale=[0.1, 0.1, 0.5, 0.5, 0.1], xtol=1e-10, ftol=1e-10, gtol=1e-10)
        except (ValueError, ArithmeticError):
            continue
        if fit is None or trial.cost < fit.cost:
            fit = trial
    if fit is None:
        return None
    misfit = float(np.sqrt(np.mean(fit.fun ** 2)))
    if not (fit.success and misfit <= HEAD_MODEL_MISFIT and -1.0 <= fit.x[0] < 0.0):
        return None
    t0, v0 = fit.x[0] * dt, math.exp(fit.x[1])
    # the model on the first contact sample and after it (3 more samples for the rules' stencils)
    model_times = np.concatenate(([0.0], (np.arange(1, end + 3)) * dt))
    values = np.empty(model_times.size)
    rates = np.empty(model_times.size)
    _head_model(t0, v0, math.exp(fit.x[2]), math.exp(fit.x[3]), fit.x[4], lever, model_times,
                HEAD_MODEL_SUBSTEPS, values, rates)
    exact = (rates[0] - rates) / lever
    s = -float(fit.x[0])  # the onset's distance before the first contact sample [samples]
    rise = (v0 - rates[0]) / lever + float(baseline(k0 - 0.5 * s)) * s * dt
    return PulseHead(first_sample=int(k0), onset=float(k0 - s), values=values, exact=exact,
                     rise_integral=float(rise), misfit=misfit)


def _rises_not_one_power_law(angular: np.ndarray, first: np.ndarray, onset: np.ndarray, impulsive: np.ndarray,
                             clean: np.ndarray, noise: float) -> bool:
    """Whether a recording's contact rises are not one power law: the median over all its clean, resolved pulses
    of :func:`_rise_exponent` more than :data:`RISE_MODEL_EXPONENT_TOLERANCE` from Hertz's 1.5. Decided over the
    whole recording, so that a call for a few pulses (:func:`event_kinematics`) decides as the reconstruction did.
    ``first`` and ``onset`` [samples] are the pulses' first contact samples and the event detector's onsets."""
    exponents = []
    for p in range(first.size):
        if impulsive[p] or not clean[p] or not math.isfinite(onset[p]):
            continue
        exponent = _rise_exponent(angular, int(first[p]), float(onset[p]), noise)
        if exponent is not None:
            exponents.append(exponent)
    return bool(exponents) and abs(float(np.median(exponents)) - 1.5) > RISE_MODEL_EXPONENT_TOLERANCE


def _rise_exponent(angular: np.ndarray, k0: int, onset_guess: float, noise: float) -> float | None:
    """The exponent ``p`` of the power law ``c (t - t0)^p`` through the first two contact samples of a pulse whose
    first contact sample is ``k0`` and whose onset the event detector put at ``onset_guess`` [samples]; None where
    there is no baseline, the first contact sample is below :data:`EDGE_SNR` times the ``noise`` floor [rad/s^2]
    (noisy rises keep the detector's least-squares onset) or the rise does not grow."""
    baseline = _head_baseline(angular, k0)
    if baseline is None or k0 + RISE_MODEL_SAMPLES > angular.size or not math.isfinite(onset_guess):
        return None
    contact = angular[k0:k0 + 2] - baseline(np.arange(k0, k0 + 2))
    if not (contact[0] > EDGE_SNR * noise and contact[1] > contact[0]):
        return None
    s0 = min(max(k0 - onset_guess, 0.02), 0.98)
    return _two_sample_exponent(contact[0], contact[1], s0)


def _fit_rise_onset(angular: np.ndarray, k0: int, onset_guess: float, separation: float, dt: float,
                    rig: RigParameters, noise: float, law: np.ndarray | None = None
                    ) -> tuple[float | None, np.ndarray | None]:
    """The onset [samples of the recording] of a resolved pulse whose first contact sample is ``k0``, from the
    Hunt–Crossley head model (:class:`PulseHead`'s, :func:`_head_model`) fitted to its first
    :data:`RISE_MODEL_SAMPLES` contact samples; None where the first contact sample is below :data:`EDGE_SNR`
    times the ``noise`` floor [rad/s^2] (the event detector's least-squares onset is the one for noisy rises),
    the noise floor exceeds :data:`RISE_MODEL_MISFIT` of the peak (no fit could be that close), the model does not
    fit (rms misfit above :data:`RISE_MODEL_MISFIT`) or puts the onset outside the sample interval before ``k0``.

    The event detector takes the onset from a single power law ``c (t - t0)^p`` through the first three contact
    samples (Hertz: ``p = 1.5`` at first touch). The Hunt–Crossley force ``k_H delta^1.5 + beta delta^n delta'``
    is not one power law: with ``n < 1.5`` its damping term dominates the first microseconds (by 10 to 70 times
    at a large ``beta``: ``beta / k_H v^(n - 1/2) t^(n - 3/2)``) and hands over to the Hertz term during the rise,
    and the three-sample law then puts the onset up to 0.25 samples late. The gap at the reconstructed onset is
    then already closed by ``v_a`` times that, and the cam-phase anchor, which puts every onset on the gap's zero,
    shifts the recording's cam phase to match: by 2e-4 to 6e-4 rad (5 of its standard errors) at e/r_c 0.06,
    where the contact angle changes slowly with the phase, and beta by 20 % in a joint fit whose two recordings
    barely separate beta from n (docs/validation_envelope.md). The head model has the force's two terms (its
    exponent ``q`` comes out within 0.02 of ``n``) and gives the onset within 0.002 samples noise-free.

    ``onset_guess`` [samples] is the event detector's onset; ``separation`` [samples] its separation (the
    pulse's area sets the start of the approach speed). ``law``: a previous pulse's fitted parameters (the
    second return value), tried first (the pulses of a recording share the law and nearly the approach speed).
    Returns the onset (or None, as above) and the fitted parameters (log approach speed and coefficients, the
    exponent).
    """
    baseline = _head_baseline(angular, k0)
    hi = k0 + RISE_MODEL_SAMPLES
    end = int(math.ceil(separation)) if math.isfinite(separation) else hi
    if baseline is None or hi > angular.size or end < hi:
        return None, None
    idx = np.arange(k0 - 2, hi)
    dev = angular[idx] - baseline(idx)
    contact = dev[2:]
    if not (contact[0] > EDGE_SNR * noise and contact[1] > contact[0]):
        return None, None
    peak = float(np.max(np.abs(contact)))
    if not noise <= RISE_MODEL_MISFIT * peak:  # the model could not fit within the misfit asked: no time spent
        return None, None
    times = (idx - k0) * dt
    lever = HEAD_MODEL_LEVER
    s0 = min(max(k0 - onset_guess, 0.02), 0.98)
    q0 = min(max(_two_sample_exponent(contact[0], contact[1], s0), 0.8), 2.5)
    # the approach speed from the pulse's rate change: between once (plastic) and twice (elastic) the speed
    area = np.arange(k0, end)
    change = lever * float(np.sum(angular[area] - baseline(area))) * dt
    if not change > 0.0:
        return None, None
    a0 = lever * rig.k_H / rig.I_b
    t_last = (RISE_MODEL_SAMPLES - 1 + s0) * dt
    residual = _head_residual(times, dev, peak, dt)

    # the fit has local minima: started from the last pulse's law, then from the plastic and the elastic approach
    # speed and from half of the plastic one, each with the damping-dominated and the Hertzian exponent, until one
    # fits
    starts = [] if law is None else [np.concatenate([[-s0], law])]
    exponents = (q0, 1.5) if abs(q0 - 1.5) > 0.05 else (q0,)
    for v0 in (change, 0.5 * change, 0.25 * change, 2.0 * change):
        for q in exponents:
            d_last = v0 * t_last
            damping = max(contact[-1] - a0 * d_last ** 1.5, 0.1 * contact[-1]) / (d_last ** q * v0)
            if damping > 0.0 and math.isfinite(damping):  # not where the window's last sample is past the pulse
                starts.append(np.array([-s0, math.log(v0), math.log(a0), math.log(damping), q]))
    fit = None
    reach = np.array([0.0, 12.0, 12.0, 12.0, 0.0])
    for start in starts:
        try:
            trial = optimize.least_squares(residual, start,
                                           bounds=(np.array([-2.0, 0, 0, 0, 0.5]) + start * (reach > 0) - reach,
                                                   np.array([0.2, 0, 0, 0, 3.0]) + start * (reach > 0) + reach),
                                           x_scale=[0.1, 0.1, 0.5, 0.5, 0.1], xtol=1e-12, ftol=1e-12, gtol=1e-12)
        except (ValueError, ArithmeticError):
            continue
        if fit is None or trial.cost < fit.cost:
            fit = trial
        if math.sqrt(2.0 * fit.cost / fit.fun.size) <= RISE_MODEL_MISFIT:
            break
    if fit is None:
        return None, None
    misfit = float(np.sqrt(np.mean(fit.fun ** 2)))
    if not (fit.success and misfit <= RISE_MODEL_MISFIT and -1.0 <= fit.x[0] < 0.0):
        return None, None
    return float(k0 + fit.x[0]), fit.x[1:].copy()

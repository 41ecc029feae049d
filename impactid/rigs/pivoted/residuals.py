"""Residuals between measured impact events and their S1 simulations (docs/rig_p.md).

Every reconstructed event (:mod:`impactid.rigs.pivoted.reconstruct`) is replayed by the compiled simulator
from its measured onset state ``alpha(0), alpha_dot(0), Theta(0)`` through the contact and the
free flight to the measured next onset ``t_e``, for each trial law ``(beta, n)`` (S1). The
residuals per event are

``lambda1``
    ``(alpha_m(S1) - alpha_m) / alpha_m``: the relative error of the maximum follower angle
    after the impact. Needs only the accelerometer. Returned **signed**; the paper's L1 is its
    absolute value.
``lambda2``
    ``sqrt(int (F - F_S1)^2 dt) / sqrt(int F^2 dt)``: the relative L2 misfit of the contact
    force history. Non-negative by construction.
``lambda3``
    ``(A - A_S1) / A`` with ``A`` the hysteresis loop area ``oint F d(delta)`` of the contact
    force against the indentation. Returned signed; the paper's L3 is its absolute value.

Integration rules (stated because they set the residual floor): ``lambda2`` and ``lambda3`` are
evaluated on the recording's own sample instants of the contact history (from the first contact
sample to 8 samples after the measured separation, so a simulated contact that outlasts the
measured one is still compared), with the simulated force and indentation taken at exactly those
instants (dense output of the simulator). ``lambda2`` uses the trapezoid rule in time; the loop
area of ``lambda3`` is the trapezoid rule of ``F`` in ``delta`` along the sampled path,
``sum 0.5 (F_k + F_k+1)(delta_k+1 - delta_k)``, the same rule for measurement and simulation.
``lambda2`` and ``lambda3`` need the pivot force channels (the measured contact force is S-21).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from impactid.errors import ImpactidError
from impactid.events import MAX_PATTERN_EVENTS
from impactid.io import RecordingError
from impactid.rigs.pivoted import PivotedFollowerRig
from impactid.rigs.pivoted.reconstruct import Reconstruction, band_limited_decimation
from impactid.rigs.pivoted.runs import DEFAULT_TOLERANCES, BatchResult, Tolerances, simulate_events

__all__ = ["FAILED_SIMULATION_RESIDUAL", "RESIDUALS", "EventSet", "force_misfit", "loop_area", "residual_name"]

#: Residual of an event whose S1 run with a trial law cannot be simulated (step budget exceeded,
#: step-size underflow, non-finite state): a 100 % relative error, far above the residual of any
#: plausible law (near the estimate residuals are 1e-5 .. 1e-2), so the search moves away from it.
FAILED_SIMULATION_RESIDUAL = 1.0

#: Residual names, and the short aliases accepted on input.
RESIDUALS = ("lambda1", "lambda2", "lambda3")
_ALIASES = {"l1": "lambda1", "l2": "lambda2", "l3": "lambda3", "lambda1": "lambda1", "lambda2": "lambda2",
            "lambda3": "lambda3"}


def residual_name(name: str) -> str:
    """Canonical residual name (``lambda1``/``lambda2``/``lambda3``; ``L1``.. accepted)."""
    key = str(name).strip().lower()
    if key not in _ALIASES:
        raise ValueError(f"unknown residual {name!r}; valid: {', '.join(RESIDUALS)} (or L1, L2, L3)")
    return _ALIASES[key]


def loop_area(force: np.ndarray, indentation: np.ndarray) -> float:
    """Hysteresis loop area ``oint F d(delta)`` [J] of a sampled contact (trapezoid rule in ``delta``).

    Positive when the force on approach exceeds the force on restitution (energy dissipated).
    """
    force = np.asarray(force, dtype=float)
    delta = np.asarray(indentation, dtype=float)
    return float(np.sum(0.5 * (force[1:] + force[:-1]) * np.diff(delta)))


def force_misfit(t: np.ndarray, measured: np.ndarray, simulated: np.ndarray) -> float:
    """``sqrt(int (F - F_S1)^2 dt) / sqrt(int F^2 dt)`` by the trapezoid rule on the samples ``t``."""
    num = np.trapezoid((np.asarray(measured) - np.asarray(simulated)) ** 2, t)
    den = np.trapezoid(np.asarray(measured) ** 2, t)
    return math.sqrt(num / den) if den > 0.0 else math.nan


def _names(index) -> str:
    """The first twelve event numbers of ``index``, as the messages list them."""
    events = list(index)
    return f"{events[:12]}{' ...' if len(events) > 12 else ''}"


def _riding_reason(rows) -> str:
    """Why events whose follower rides the cam are left out (``rows``: their reconstruction table rows)."""
    durations = np.concatenate([rows[c].to_numpy(dtype=float) for c in ("contact_duration",
                                                                     "contact_duration_force_balance") if c in rows]
                               + [np.array([np.nan])])
    longest = float(np.nanmax(durations)) if np.any(np.isfinite(durations)) else math.nan
    return (f"the follower rides the cam after the impact there (the contact lasts up to {longest * 1e3:.3g} ms): the "
            "apex after it is set by the cam's motion, not by the contact law (d lambda1 / d ln beta is 1e-6 to "
            "4e-5 there, against 4e-3 to 0.35 after impacts), so lambda1 cannot identify the law from them")


#: Events left out before the others, by a flag of the reconstruction table, with the reason.
_LEFT_OUT = (("riding", _riding_reason),)


def _hertz_rig_clause(recon: Reconstruction, disagreeing: int) -> str:
    """What a Hertz disagreement at most of the ``disagreeing`` events says about the rig file, when the
    recording's free flight agrees with the rig file's inertia and spring (``recon.free_flight``)."""
    fit = recon.free_flight
    if not (fit and fit.get("clean") and not fit.get("disagrees") and disagreeing * 2 > len(recon.table)):
        return ""
    return ("; the free flight between impacts agrees with the rig file's inertia I_b and spring k_s, so if the "
            "impacts are short pulses the recorded motion is not the motion of the rig described by the rig file: "
            "check its contact constants (the Young's moduli Y_c and Y_b, the pin radius r_d)")


def _rig_file_reason(recon: Reconstruction, source: str, tab, valid: np.ndarray) -> tuple[str, ...]:
    """The reconstruction's finding that the recorded motion is not the rig file's
    (:attr:`~impactid.rigs.pivoted.reconstruct.Reconstruction.rig_mismatch`, ``geometry_mismatch``), as the
    first reason, where it explains the events lost: the onset state not reconstructed or a follower
    riding the cam at most of the events."""
    riding = tab["riding"].to_numpy(dtype=bool) if "riding" in tab else np.zeros(len(tab), dtype=bool)
    if recon.rig_mismatch and np.count_nonzero(~valid | riding) * 2 > len(tab):
        return (f"{source}: {recon.rig_mismatch}",)
    if recon.geometry_mismatch and np.count_nonzero(~valid) * 2 > len(tab):
        return (f"{source}: {recon.geometry_mismatch}",)
    return ()


@dataclass(frozen=True)
class EventSet:
    """The measured events of one recording, ready to be replayed by S1.

    Attributes
    ----------
    source : name of the recording (for messages).
    rig, cam_speed_hz : the rig and its cam speed [Hz].
    events : event numbers (rows of the reconstruction table).
    states : (n, 3) onset states ``alpha [rad], alpha_dot [rad/s], Theta [rad]``.
    t_end : (n,) time from onset to the next onset ``t_e`` [s].
    alpha_m : (n,) measured maximum follower angle [rad].
    approach_speed : (n,) measured ``v_a`` [m/s].
    peak_indentation : (n,) measured peak indentation [m].
    contact_duration : (n,) measured duration of the first contact [s] (NaN where the gap does not
        reopen); used to tell apart laws that match ``alpha_m`` equally well.
    pulse_peak : (n,) the event detector's pulse peak above the free-flight baseline [m/s^2], and
        noise_sigma, sample_rate_hz : the accelerometer's noise floor [m/s^2] and the sample rate [Hz]:
        what the contact-duration check needs to replay the detector on a simulated pulse.
    decimation : 1, or for a band-limited recording the decimation through which the contact-duration check's
        replay is low-passed like the recording (``reconstruct.band_limited_decimation``).
    t : per-event sample instants of the contact history [s from onset].
    force : per-event measured contact force on ``t`` [N] (None without force channels).
    indentation : per-event measured indentation on ``t`` [m].
    dropped : events of the reconstruction left out (non-finite onset state), with the reason.
    """

    source: str
    rig: PivotedFollowerRig
    cam_speed_hz: float
    events: np.ndarray
    states: np.ndarray
    t_end: np.ndarray
    alpha_m: np.ndarray
    approach_speed: np.ndarray
    peak_indentation: np.ndarray
    t: tuple[np.ndarray, ...]
    force: tuple[np.ndarray, ...] | None
    indentation: tuple[np.ndarray, ...]
    dropped: tuple[str, ...] = ()
    alpha: tuple[np.ndarray, ...] = ()
    theta: tuple[np.ndarray, ...] = ()
    phase_stderr: float = math.nan
    contact_duration: np.ndarray | None = None
    pulse_peak: np.ndarray | None = None
    noise_sigma: float = math.nan
    sample_rate_hz: float = math.nan
    decimation: int = 1

    def __len__(self) -> int:
        return int(self.events.size)

    @classmethod
    def from_reconstruction(cls, recon: Reconstruction, source: str | None = None) -> EventSet:
        """Collect the events of a :class:`~impactid.rigs.pivoted.reconstruct.Reconstruction` that can be
        replayed, each left out one named in :attr:`dropped` with its reason, in this order: onsets that
        do not recur with the cam (``periodic`` False: unknown integration constants), a follower that rides
        the cam (``riding``), no apex between the impact and the next one (``alpha_m`` NaN), an onset state
        that could not be reconstructed, and a contact that disagrees with the rig's Hertz contact."""
        tab = recon.table
        source = source or (recon._recording.source if recon._recording is not None else None) or "recording"
        states = tab[["alpha_onset", "alpha_dot_onset", "theta_onset"]].to_numpy(dtype=float)
        t_end = (tab["t_next"] - tab["t_onset"]).to_numpy(dtype=float)
        alpha_m = tab["alpha_m"].to_numpy(dtype=float)
        valid = np.all(np.isfinite(states), axis=1) & np.isfinite(t_end) & (t_end > 0)
        ok = valid.copy()
        dropped: tuple[str, ...] = ()
        if "periodic" in tab:
            bad = ok & ~tab["periodic"].to_numpy(dtype=bool)
            if np.any(bad):
                dropped += (f"{source}: events {_names(tab.index[bad])} left out: their onsets do not recur with the "
                            f"cam within {MAX_PATTERN_EVENTS} impacts (irregular motion, a transient, or a longer "
                            "period), so their integration constants, which the reconstruction takes from the "
                            "follower's state recurring one period later, are unknown",)
            ok &= ~bad
        for flag, reason in _LEFT_OUT:
            if flag in tab:
                bad = ok & tab[flag].to_numpy(dtype=bool)
                if np.any(bad):
                    dropped += (f"{source}: events {_names(tab.index[bad])} left out: {reason(tab[bad])}",)
                ok &= ~bad
        no_apex = ok & ~np.isfinite(alpha_m)
        if np.any(no_apex):
            dropped += (f"{source}: events {_names(tab.index[no_apex])} left out: the follower has no apex between the "
                        "impact and the next one (the cam strikes it again while it still rises, or it never rises "
                        "above its onset angle), so there is no alpha_m to compare",)
        ok &= ~no_apex
        unknown = ~valid
        if np.any(unknown):
            dropped += (f"{source}: events {_names(tab.index[unknown])} left out: their onset state (angle, rate or "
                        "cam angle at the gap zero) could not be reconstructed",)
        consistent = (tab["contact_consistent"].to_numpy(dtype=bool) if "contact_consistent" in tab
                      else np.ones(len(tab), dtype=bool))
        if np.any(ok & ~consistent):
            bad = tab.index[ok & ~consistent].tolist()
            ratio = float(np.nanmedian(tab["hertz_ratio"].to_numpy(dtype=float)[ok & ~consistent]))
            dropped += (f"{source}: events {bad[:12]}{' ...' if len(bad) > 12 else ''} left out: their reconstructed "
                        f"contact disagrees with the rig's Hertz contact (the accelerometer's force at the deepest "
                        f"indentation is {ratio:.3g} times k_H delta^1.5): the contact is not a short pulse followed "
                        "by a free flight there (or the accelerometer's units are wrong)"
                        + _hertz_rig_clause(recon, np.count_nonzero(ok & ~consistent)),)
        ok &= consistent
        dropped = _rig_file_reason(recon, source, tab, valid) + dropped
        index = tab.index[ok]
        hist = [recon.contact[int(e)] for e in index]
        force = None
        if hist and all(h.contact_force is not None for h in hist):
            force = tuple(np.asarray(h.contact_force, dtype=float) for h in hist)
        return cls(source=source, rig=recon.rig, cam_speed_hz=float(recon.cam_speed_hz),
                   events=np.asarray(index, dtype=int), states=np.ascontiguousarray(states[ok]),
                   t_end=np.ascontiguousarray(t_end[ok]), alpha_m=alpha_m[ok],
                   approach_speed=tab["approach_speed"].to_numpy(dtype=float)[ok],
                   peak_indentation=tab["peak_indentation"].to_numpy(dtype=float)[ok],
                   t=tuple(np.asarray(h.t, dtype=float) for h in hist), force=force,
                   indentation=tuple(h.indentation for h in hist), dropped=dropped,
                   alpha=tuple(np.asarray(h.alpha, dtype=float) for h in hist),
                   theta=tuple(np.asarray(h.theta, dtype=float) for h in hist),
                   phase_stderr=float(getattr(recon, "cam_phase_stderr", math.nan)),
                   contact_duration=(tab["contact_duration"].to_numpy(dtype=float)[ok] if "contact_duration" in tab
                                     else None),
                   pulse_peak=(recon.events.table["peak"].reindex(index).to_numpy(dtype=float)
                               if "peak" in recon.events.table else None),
                   noise_sigma=float(recon.events.noise_sigma), sample_rate_hz=float(recon.events.sample_rate_hz),
                   decimation=band_limited_decimation(float(recon.events.sample_rate_hz)) if recon.band_limited else 1)

    def subset(self, index) -> EventSet:
        """The events at positions ``index`` (an int, slice or index array) of this set."""
        from dataclasses import replace

        idx = np.atleast_1d(np.arange(len(self))[index])
        pick = lambda seq: tuple(seq[i] for i in idx) if seq else seq  # noqa: E731
        return replace(self, events=self.events[idx], states=np.ascontiguousarray(self.states[idx]),
                       t_end=np.ascontiguousarray(self.t_end[idx]), alpha_m=self.alpha_m[idx],
                       approach_speed=self.approach_speed[idx], peak_indentation=self.peak_indentation[idx],
                       t=pick(self.t), force=pick(self.force) if self.force is not None else None,
                       indentation=pick(self.indentation), alpha=pick(self.alpha), theta=pick(self.theta),
                       contact_duration=None if self.contact_duration is None else self.contact_duration[idx],
                       pulse_peak=None if self.pulse_peak is None else self.pulse_peak[idx])

    def scale_alpha_m(self, factor: float) -> EventSet:
        """The same events with the measured ``alpha_m`` multiplied by ``factor`` (a bias correction,
        :mod:`impactid.rigs.pivoted.calibration`)."""
        from dataclasses import replace

        return replace(self, alpha_m=self.alpha_m * float(factor))

    def shift_phase(self, dphi: float) -> EventSet:
        """The same events with the recording's cam phase moved by ``dphi`` [rad] (cam-phase anchor).

        Every onset stays on the gap zero: ``Theta`` moves by ``dphi``, the onset angle to the contact
        angle there, and each event's angle history (so ``alpha_m``) by the same amount; the
        indentation is recomputed. Used to carry the phase's uncertainty into the estimates.
        """
        from dataclasses import replace

        theta0 = self.states[:, 2] + dphi
        alpha0 = np.asarray(self.rig.contact_angle(theta0), dtype=float)
        shift = alpha0 - self.states[:, 0]
        states = np.ascontiguousarray(np.column_stack([alpha0, self.states[:, 1], theta0]))
        alpha = tuple(a + d for a, d in zip(self.alpha, shift))
        theta = tuple(th + dphi for th in self.theta)
        indentation = tuple(np.maximum(-np.asarray(self.rig.gap(a, th)), 0.0) for a, th in zip(alpha, theta))
        return replace(self, states=states, alpha_m=self.alpha_m + shift, alpha=alpha, theta=theta,
                       indentation=indentation)

    def require(self, residual: str) -> None:
        """Raise a :class:`RecordingError` if ``residual`` needs data this set does not have."""
        residual = residual_name(residual)
        if residual != "lambda1" and self.force is None:
            raise RecordingError(f"{self.source}: residual {residual} needs the contact force, i.e. the pivot force "
                                 "channels 'force_x' and 'force_y', which this recording does not have; "
                                 "use lambda1 (accelerometer only)")
        if len(self) == 0:
            if self.dropped:
                raise ImpactidError("no event can be used to estimate the contact law: " + "; ".join(self.dropped))
            raise ImpactidError(f"{self.source}: no event with a reconstructed onset state to simulate")

    def simulate(self, trials: np.ndarray, *, histories: bool = False,
                 tolerances: Tolerances = DEFAULT_TOLERANCES, sensitivities: bool = False) -> BatchResult:
        """Batch S1 of every event for every trial ``(beta, n)`` (histories on the contact samples;
        with ``sensitivities``, the forward sensitivities as well)."""
        return simulate_events(self.rig, self.cam_speed_hz, self.states, self.t_end, np.atleast_2d(trials),
                               grids=list(self.t) if histories else None, tolerances=tolerances,
                               on_failure="flag", sensitivities=sensitivities)

    def residuals_and_jacobian(self, trials: np.ndarray, residual: str = "lambda1", *,
                               tolerances: Tolerances = DEFAULT_TOLERANCES
                               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per-event residuals, their derivatives by ``(ln beta, n)`` and the failed runs.

        The derivatives come from the forward sensitivities the simulator integrates with each run
        (``simulate_events(..., sensitivities=True)``), not from differences: ``lambda1`` from
        ``d alpha_m``, ``lambda2`` and ``lambda3`` from the derivatives of the simulated force and
        gap histories at the contact samples, through the same integration rules as the residuals
        (the trapezoid rules of the module docstring, differentiated). Returns ``(r, J, failed)`` with
        shapes ``(k, m)``, ``(k, m, 2)`` and ``(k, m)`` for ``k`` trials and ``m`` events; a failed run
        has the penalty residual and a zero derivative, an event without a residual NaN in both, and
        a run whose sliding velocity reversed during a contact NaN derivatives (see
        :func:`~impactid.rigs.pivoted.runs.simulate_events`).
        """
        return self._evaluate(trials, residual, tolerances, sensitivities=True)

    def _jacobian_of(self, batch: BatchResult, trials: np.ndarray, residual: str, r: np.ndarray) -> np.ndarray:
        if residual == "lambda1":
            return batch.alpha_m_sensitivity / self.alpha_m[None, :, None]
        out = np.empty((trials.shape[0], len(self), 2))
        off = batch.grid_offsets
        for i in range(len(self)):
            t, f = self.t[i], self.force[i]
            cols = slice(off[i], off[i + 1])
            sim_f = batch.contact_force[:, None, cols]  # (k, 1, samples)
            d_f = batch.contact_force_sensitivity[:, :, cols]  # (k, 2, samples)
            if residual == "lambda2":
                den = self._force_norms[i]
                d_num = np.trapezoid(-2.0 * (f[None, None, :] - sim_f) * d_f, t, axis=2)
                with np.errstate(divide="ignore", invalid="ignore"):
                    value = np.where(r[:, i, None] > 0, d_num / (2.0 * den * r[:, i, None]), 0.0)
                out[:, i, :] = value if den > 0 else math.nan
            else:
                area = self._loop_areas[i]
                gap = batch.gap[:, None, cols]
                sim_delta = np.maximum(-gap, 0.0)
                d_delta = np.where(gap < 0.0, -batch.gap_sensitivity[:, :, cols], 0.0)
                d_area = np.sum(0.5 * (d_f[:, :, 1:] + d_f[:, :, :-1]) * np.diff(sim_delta, axis=2)
                                + 0.5 * (sim_f[:, :, 1:] + sim_f[:, :, :-1]) * np.diff(d_delta, axis=2), axis=2)
                out[:, i, :] = -d_area / area if area > 0 else math.nan
        return out

    def residuals(self, trials: np.ndarray, residual: str = "lambda1", *,
                  tolerances: Tolerances = DEFAULT_TOLERANCES) -> np.ndarray:
        """Per-event residuals, shape (n_trials, n_events); signed for lambda1 and lambda3 (see module doc).

        Events whose measured loop area or force norm is not positive get NaN. A run that cannot
        be simulated gets :data:`FAILED_SIMULATION_RESIDUAL` (see :meth:`residuals_and_failures`).
        """
        return self.residuals_and_failures(trials, residual, tolerances=tolerances)[0]

    def residuals_and_failures(self, trials: np.ndarray, residual: str = "lambda1", *,
                               tolerances: Tolerances = DEFAULT_TOLERANCES) -> tuple[np.ndarray, np.ndarray]:
        """Per-event residuals and a bool array of the runs that could not be simulated.

        A trial law is a question, not an input: its S1 run may chatter, stick or fail. Chattering
        and sticking runs are simulated to the end (``alpha_m`` exists whatever the number of
        contacts); a run that truly fails (step budget, step-size underflow, non-finite state)
        gets the documented penalty :data:`FAILED_SIMULATION_RESIDUAL` for that event, so that
        the search goes on and stays away from it.
        """
        out, _, failed = self._evaluate(trials, residual, tolerances, sensitivities=False)
        return out, failed

    def _evaluate(self, trials, residual: str, tolerances: Tolerances, sensitivities: bool):
        """``(residuals, Jacobian or None, failed)``: one batch of S1 runs, the penalty for failed runs."""
        residual = residual_name(residual)
        self.require(residual)
        trials = np.atleast_2d(np.asarray(trials, dtype=float))
        batch = self.simulate(trials, histories=residual != "lambda1", tolerances=tolerances,
                              sensitivities=sensitivities)
        failed = batch.failed
        out = self._residuals_of(batch, trials, residual)
        jac = self._jacobian_of(batch, trials, residual, out) if sensitivities else None
        if failed.any():
            out = np.where(failed, FAILED_SIMULATION_RESIDUAL, out)
            if jac is not None:
                jac = np.where(failed[:, :, None], 0.0, jac)
        return out, jac, failed

    @functools.cached_property
    def _force_norms(self) -> np.ndarray:
        """Per event: ``int F^2 dt`` of the measured contact force (the denominator of lambda2) [N^2 s]."""
        return np.array([np.trapezoid(f ** 2, t) for t, f in zip(self.t, self.force)])

    @functools.cached_property
    def _loop_areas(self) -> np.ndarray:
        """Per event: the measured hysteresis loop area (the denominator of lambda3) [J]."""
        return np.array([loop_area(f, d) for f, d in zip(self.force, self.indentation)])

    def _residuals_of(self, batch: BatchResult, trials: np.ndarray, residual: str) -> np.ndarray:
        if residual == "lambda1":
            return (batch.alpha_m - self.alpha_m) / self.alpha_m
        out = np.empty((trials.shape[0], len(self)))
        off = batch.grid_offsets
        for i in range(len(self)):
            t, f = self.t[i], self.force[i]
            sim_f = batch.contact_force[:, off[i]:off[i + 1]]
            if residual == "lambda2":
                den = self._force_norms[i]
                num = np.trapezoid((f[None, :] - sim_f) ** 2, t, axis=1)
                out[:, i] = np.sqrt(num / den) if den > 0 else math.nan
            else:
                area = self._loop_areas[i]
                sim_delta = np.maximum(-batch.gap[:, off[i]:off[i + 1]], 0.0)
                sim_area = np.sum(0.5 * (sim_f[:, 1:] + sim_f[:, :-1]) * np.diff(sim_delta, axis=1), axis=1)
                out[:, i] = (area - sim_area) / area if area > 0 else math.nan
        return out

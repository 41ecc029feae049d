"""What both search methods of the contact-damping fit report alike: identifiability, notes, tables.

* :func:`approach_speed_spread`: how much the impacts' approach speeds differ;
* :func:`separability`: whether the data separate ``beta`` from ``n`` (the ``n`` interval no wider than
  the separability width and off the search bounds), with the note that says why not;
* :func:`bound_notes`: an estimate on a search bound;
* :func:`failure_note`: S1 runs with trial laws that could not be simulated;
* :func:`per_event_table`: the per-event residuals at the estimate;
* :func:`widen_interval`: an interval widened by an independent error, in quadrature;
* :func:`damping_model_check`: the engine's model check of the per-event residuals, with rig P's own
  checks of the measured contact durations (:func:`contact_duration_check`) and contact pulses
  (:func:`~impactid.rigs.pivoted.pulse_check.pulse_check`), and :func:`apply_model_check`, which
  widens or withholds the intervals and never lets a model the check rejects be called separable;
* :func:`damping_identifiability`: the engine's identifiability block of the least-squares fit, with
  the profile along the valley as ``n``'s refit profile and ``n`` fitted against ``n`` held at 1.5.

The model check (docs/identifiability.md). The per-event residuals (``lambda1`` relative errors of
``alpha_m``) have no independent noise reference: the noise of a measured ``alpha_m`` is not measured
per event, so the residual variance itself is the scale (as the intervals' ``s^2`` is) and the scatter
is not tested. Their structure is: a trend with the approach speed within each recording, and the
alternation of consecutive impacts (the lag-1 autocorrelation within each recording). It counts only
when the residual RMS exceeds the pipeline's own level (the indifference: the residual floor, or the
calibrated systematic error), below which the noise-free pipeline makes residuals of every shape on
data of the right law. The recordings' mean residuals are not tested against each other: they are
what a joint fit's ``n`` and each recording's systematic error absorb, and the law comparison (``n``
fitted against ``n`` held) states what the data say about them. Rig P's own check compares the
measured first-contact durations with the fitted law's (one S1 run per event at the estimate,
counted in the check, not in the fit's simulations), measured like the recording's: the replayed
contacts go through the same event detector with the recording's noise (:func:`detected_durations`),
since the noise cuts a measured contact short. A law whose contacts, so measured, last more than
:data:`CONTACT_DURATION_MISMATCH` longer or shorter (median over the events) than measured, or a
recording without any contact pulse (instantaneous impacts: a restitution law), is rejected. The
contact-pulse check (:mod:`impactid.rigs.pivoted.pulse_check`, one more S1 run per event, with the
contact force on the measured samples) compares the replayed peak force, impulse and width with the
measured ones: a wrong rig constant (contact stiffness, effective inertia, spring) that ``beta``
absorbs while ``alpha_m`` is matched leaves them off beyond their precision. That is a ``systematic
misfit`` whose intervals are withheld, not widened: the error is a bias of ``beta`` that no
inflation of the residual scatter covers (a Young's modulus 20 % off moves ``beta`` by 26 % with an
interval of +-0.2 %).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd

from impactid.engine import (
    Free,
    ModelCheck,
    Search,
    check_model,
    combine_checks,
    compare_models,
    identifiability,
    profile_shape,
    uncertainty,
)
from impactid.engine.checks import widen_interval as widen_by_factor
from impactid.engine.distributions import chi2_sf
from impactid.engine.identifiability import LRT_SIGNIFICANCE, profile_note
from impactid.events import BASELINE_GAP, BASELINE_LENGTH, CONTACT_END_BASELINE_S, NoImpactsError, find_events
from impactid.io import Recording, RecordingError
from impactid.rigs.pivoted.calibration import noise_free
from impactid.rigs.pivoted.damping_objective import DampingObjective, DampingProblem
from impactid.rigs.pivoted.pulse_check import pulse_check, withhold_for_rig
from impactid.rigs.pivoted.residuals import FAILED_SIMULATION_RESIDUAL, EventSet
from impactid.rigs.pivoted.runs import simulate_events
from impactid.synth.sensors import antialias_decimate

__all__ = ["ALIKE_SPREAD", "CONTACT_DURATION_MISMATCH", "DETERMINED_REACH", "DURATION_CHECK_BLOCKS",
           "DURATION_CHECK_EVENTS", "DURATION_REPLAYS", "FAILED_SHARE_NOTED", "N_COMPARED", "REPLAY_MARGIN_S",
           "REPLAY_SEED", "REPLAY_SPAN", "SEPARABILITY_WIDTH", "apply_model_check", "approach_speed_spread",
           "bound_notes", "contact_duration_check", "damping_identifiability", "damping_model_check",
           "detected_durations", "failure_note", "interval_reach", "mark_reach", "per_event_table",
           "search_identifiability", "separability", "widen_interval"]

#: Widest ``n`` interval for which ``beta`` and ``n`` count as separable.
SEPARABILITY_WIDTH = 0.25
#: Relative spread (std/mean) of approach speeds below which impacts count as "all alike".
ALIKE_SPREAD = 0.02
#: Median relative difference between the fitted law's first-contact durations, as the event detector
#: measures them with the recording's noise (:func:`detected_durations`), and the measured ones beyond
#: which the law is rejected; a recording of instantaneous impacts (measured 0 s) differs by 100 %.
#: Measured on the envelope's recordings of the right law: at most 4.4 % on the noisy ones whose estimate
#: is within 5 % (the simulated durations, not replayed, differed by up to 260 %), 1e-6 noise-free at
#: 204.8 kHz, and 3-42 % at 51.2-102.4 kHz, where the recordings' anti-alias filter (which the replay
#: does not know) stretches the measured pulse.
CONTACT_DURATION_MISMATCH = 0.5
#: Noise realisations of each event's replayed contact (the median of their detected durations).
DURATION_REPLAYS = 3
#: Seed of the replay's noise (the check gives the same answer on every run).
REPLAY_SEED = 2026
#: A replayed contact is sampled over this many times the measured contact, and at least
#: :data:`REPLAY_MARGIN_S` beyond it [s] (a longer replayed contact is cut there: it is rejected anyway).
REPLAY_SPAN = 3.0
REPLAY_MARGIN_S = 2e-3
#: Most events of a recording the contact-duration check replays, in blocks spread over it (a 60 s recording: 128
#: of 959; :func:`_check_events`). The check compares medians over events against a 50 % threshold; 128 events
#: fix a median duration to a few percent (its order statistics) where a thousand cost a second of replays and
#: detection.
DURATION_CHECK_EVENTS = 128
#: The damping index a fitted ``n`` is compared with (Hunt and Crossley's).
N_COMPARED = 1.5


def _relative_spread(speeds: np.ndarray) -> float:
    """Relative spread (std/mean) of the finite ``speeds`` (0 with fewer than two, or a mean not above 0)."""
    va = np.asarray(speeds, dtype=float)
    va = va[np.isfinite(va)]
    return float(np.std(va) / np.mean(va)) if va.size > 1 and np.mean(va) > 0 else 0.0


def _speeds_differ(event_set: EventSet) -> bool:
    """Whether a recording's finite approach speeds spread (std/mean) by :data:`ALIKE_SPREAD` or more."""
    return _relative_spread(event_set.approach_speed) >= ALIKE_SPREAD


def approach_speed_spread(problem: DampingProblem) -> float:
    """Relative spread (std/mean) of the finite approach speeds over all events (0 with fewer than two)."""
    return _relative_spread(np.concatenate([s.approach_speed for s in problem.sets]))


def separability(problem: DampingProblem, n_interval: tuple[float, float], beta_interval: tuple[float, float],
                 region: str, notes: list[str]) -> bool | None:
    """Whether ``beta, n`` are separable (None with ``n`` fixed); a note says why not.

    Parameters
    ----------
    problem : the fit.
    n_interval : the interval of ``n``; beta_interval : that of ``beta`` [N s m^-(n+1)].
    region : what the ``n`` interval is, for the note (the indifference region, the profile interval).
    notes : the fit's notes, appended to.
    """
    if problem.fix_n is not None:
        return None
    n_lo, n_hi = problem.n_bounds
    touches = n_interval[0] <= n_lo + 1e-9 or n_interval[1] >= n_hi - 1e-9
    # impacts all alike (one operating point of period-1 motion) carry one observable, whatever the width
    # of the n interval their sum of squares gives: two parameters are not determined by it (a joint fit
    # left with one usable recording put n in [1.51, 1.76] against the truth 1.25)
    spread = approach_speed_spread(problem)
    separable = bool((n_interval[1] - n_interval[0]) <= problem.separability_width and not touches
                     and spread >= ALIKE_SPREAD)
    if not separable:
        why = (f"all impacts have nearly the same approach speed (spread {100 * spread:.2g} %)"
               if spread < ALIKE_SPREAD else f"the approach speeds spread only {100 * spread:.2g} %")
        notes.append(
            f"beta and n are not separable from these data ({why}): along the valley beta(n) {region} "
            f"for n from {n_interval[0]:.3g} to {n_interval[1]:.3g} "
            f"(beta {beta_interval[0]:.4g} to {beta_interval[1]:.4g}); the joint point estimate is not precise. Fix n "
            + ("(--fix-n) or fit recordings at several operating points together." if len(problem.sets) == 1 else
               "(--fix-n), add operating points whose approach speeds differ more (lower e/r_c or cam speed), "
               "or record with less noise."))
    return separable


def bound_notes(problem: DampingProblem, logc_hat: float, n_hat: float, notes: list[str]) -> None:
    """Notes on an estimate ``(log10 c, n)`` that lies on a search bound."""
    (lc_lo, lc_hi), (n_lo, n_hi) = problem.log10_c_bounds, problem.n_bounds
    if logc_hat <= lc_lo + 1e-6 or logc_hat >= lc_hi - 1e-6:
        notes.append(f"the estimate lies on the search bound of c = beta delta_ref^n ({10 ** logc_hat:.3g} N s/m): "
                     "widen the bounds or check the data")
    if problem.fix_n is None and (n_hat <= n_lo + 1e-6 or n_hat >= n_hi - 1e-6):
        notes.append(f"the estimate of n lies on its search bound ({n_hat:.3g})")


#: Share of the S1 runs with trial laws that may fail without a note (their count is always in the
#: result's ``failed_simulations``). A few trial laws far from the estimate (the search's first steps,
#: extreme corners of the box) exhaust the step budget and are penalised, which steers the search away
#: from them and changes nothing else; a failure at the estimate itself is a residual of
#: :data:`FAILED_SIMULATION_RESIDUAL` there, which the model check flags as an outlier. The built-in
#: example has 1 failure in 6241 runs.
FAILED_SHARE_NOTED = 0.01


def failure_note(obj: DampingObjective, notes: list[str]) -> None:
    """Say how many S1 runs with trial laws could not be simulated (penalised, not fatal), when they
    are more than :data:`FAILED_SHARE_NOTED` of the runs."""
    if obj.n_failed > FAILED_SHARE_NOTED * obj.n_simulations:
        notes.append(f"{obj.n_failed} of {obj.n_simulations} S1 runs with trial laws could not be simulated "
                     f"(step budget or step-size underflow); each counted as a residual of "
                     f"{FAILED_SIMULATION_RESIDUAL:g} for its event, so the search avoided those laws")


def per_event_table(problem: DampingProblem, residuals: np.ndarray) -> pd.DataFrame:
    """The table ``source, event, approach_speed`` [m/s] ``, residual`` of the pooled events."""
    sets = problem.sets
    return pd.DataFrame({"source": np.concatenate([[s.source] * len(s) for s in sets]),
                         "event": np.concatenate([s.events for s in sets]),
                         "approach_speed": np.concatenate([s.approach_speed for s in sets]),
                         "residual": residuals})


def widen_interval(interval: tuple[float, float], centre: float, extra: float) -> tuple[float, float]:
    """Widen ``(lo, hi)`` about ``centre`` by ``extra`` in quadrature on each side."""
    lo, hi = interval
    return (centre - math.hypot(centre - lo, extra), centre + math.hypot(hi - centre, extra))


# ---- the model check ------------------------------------------------------------------------------


def _replay_grids(s: EventSet) -> list[np.ndarray] | None:
    """Per event, the recording's sample instants from the first contact sample on [s from onset],
    over :data:`REPLAY_SPAN` times the measured contact (at least :data:`REPLAY_MARGIN_S` beyond it,
    at most the time to the next onset); None without what the detector replay needs. For a band-limited
    recording (``s.decimation`` q > 1) the instants are q times denser, the recording's among them at every
    q-th from the q - 1 that precede the first (those before the onset are left out: the force is zero there,
    and :func:`detected_durations` puts them back as zeros)."""
    rate, sigma = s.sample_rate_hz, s.noise_sigma
    if s.pulse_peak is None or s.contact_duration is None or not (math.isfinite(rate) and rate > 0.0
                                                                   and math.isfinite(sigma) and sigma >= 0.0):
        return None
    dt = 1.0 / rate
    q = max(int(s.decimation), 1)
    grids = []
    for ti, measured, t_end in zip(s.t, s.contact_duration, s.t_end):
        first = float(ti[0]) if ti.size else 0.5 * dt
        phase = first - dt * math.floor(first / dt)  # the first sample at or after the onset
        phase = phase if phase > 0.0 else dt
        measured = float(measured) if math.isfinite(measured) and measured > 0.0 else 0.0
        span = min(max(REPLAY_SPAN * measured, measured + REPLAY_MARGIN_S), float(t_end) * (1.0 - 1e-9))
        count = max(int(math.floor((span - phase) / dt)) + 1, 1)
        grid = phase + (dt / q) * np.arange(-(q - 1), q * count)
        grids.append(grid[grid > 0.0] if q > 1 else grid)
    return grids


def detected_durations(force: Sequence[np.ndarray], grids: Sequence[np.ndarray], peak: np.ndarray, sigma: float,
                       rate_hz: float, *, replays: int | None = None, seed: int | None = None,
                       decimation: int = 1) -> np.ndarray:
    """The contact durations the event detector (:func:`impactid.events.find_events`) measures on
    simulated contact pulses with the recording's noise [s].

    Each event's contact force on its sample instants (``grids``, from the onset [s]) is scaled to the
    measured pulse peak (the accelerometer's deviation from the free flight is the contact force
    times a lever and an inertia that change little over a contact), laid on a quiet free flight
    long enough for the detector's baselines, and white noise of the recording's noise floor
    ``sigma`` [m/s^2] is added; ``replays`` noise realisations of every event are detected in one
    synthetic recording at ``rate_hz``, and each event's duration is the median of its detections
    (0 where no pulse is detected: the replay has no contact the detector sees; NaN where the
    replay failed). Returns (events,) [s].

    ``decimation`` q > 1 (a band-limited recording): the forces are on :func:`_replay_grids`' q times denser
    instants, and the synthetic recording is low-passed and decimated by q
    (:func:`impactid.synth.sensors.antialias_decimate`, the filter the calibration assumes) before its noise
    is added, so that the replayed pulses are stretched by a filter as the measured ones are.
    """
    replays = DURATION_REPLAYS if replays is None else int(replays)
    seed = REPLAY_SEED if seed is None else int(seed)
    q = max(int(decimation), 1)
    lead = BASELINE_GAP + BASELINE_LENGTH + 64
    tail = int(math.ceil(CONTACT_END_BASELINE_S * rate_hz)) + BASELINE_GAP + BASELINE_LENGTH + 64
    pieces, starts = [], []
    position = 0
    scaled = []
    for f, p in zip(force, peak):
        f = np.asarray(f, dtype=float)
        top = float(np.max(f)) if f.size else 0.0
        ok = np.all(np.isfinite(f)) and math.isfinite(p)
        scaled.append(None if not ok else (f * (p / top) if top > 0.0 else np.zeros_like(f)))
    # a dense pulse (q > 1) from its grid's k = -(q - 1) on: the grid holds q count + q - 1 instants less those
    # dropped before the onset, put back as zeros; it is laid so that its k = 0, the recording's first sample after
    # the onset, falls on an output sample (q = 1: the pulse as it is, at ``lead``)
    scaled = [None if pulse is None else np.concatenate([np.zeros((q - 1 - np.asarray(grid).size) % q), pulse])
              for pulse, grid in zip(scaled, grids)]
    at = q * lead - (q - 1)
    for _ in range(replays):
        for pulse in scaled:
            samples = 0 if pulse is None else -(-pulse.size // q) + (q > 1)  # output samples the pulse spans
            length = q * (lead + samples + tail)
            piece = np.zeros(length)
            if pulse is not None:
                piece[at:at + pulse.size] = pulse
            starts.append(position // q)
            pieces.append(piece)
            position += length
    x = np.concatenate(pieces) if pieces else np.zeros(0)
    if q > 1:
        x = antialias_decimate(x, q)
    x = x + np.random.default_rng(seed).normal(0.0, sigma, x.size) if sigma > 0.0 else x
    found = np.full(len(starts), 0.0)
    try:
        table = find_events(Recording(channels={"accel_tangential": x}, sample_rate_hz=rate_hz,
                                      units={"accel_tangential": "m/s^2"}, source="replayed contacts"),
                            warn=False).table
    except (NoImpactsError, RecordingError):
        table = None
    if table is not None and len(table):
        segment = np.searchsorted(np.asarray(starts), table["onset_index"].to_numpy(), side="right") - 1
        duration = (table["t_separation"] - table["t_onset"]).to_numpy(dtype=float)
        seen = np.zeros(len(starts), dtype=bool)
        for k, d in zip(segment, duration):
            if k >= 0 and not seen[k]:  # the first pulse of a segment: the first contact
                found[k], seen[k] = d, True
    n_events = len(scaled)
    per_replay = found.reshape(replays, n_events) if n_events else np.zeros((replays, 0))
    out = np.median(per_replay, axis=0) if n_events else np.zeros(0)
    out[[pulse is None for pulse in scaled]] = math.nan
    return out


#: Blocks of consecutive events the duration check takes from a long recording (:func:`_check_events`).
DURATION_CHECK_BLOCKS = 8


def _check_events(count: int) -> np.ndarray:
    """The events the duration check replays from a recording of ``count`` events: :data:`DURATION_CHECK_EVENTS` in
    :data:`DURATION_CHECK_BLOCKS` blocks of consecutive events spread over it (every event of a period-k motion up
    to the block's length is among them; evenly spaced single events can all fall on one branch of a period-2
    motion: 255 events give 128 even ones)."""
    blocks = max(min(DURATION_CHECK_BLOCKS, DURATION_CHECK_EVENTS), 1)
    per = DURATION_CHECK_EVENTS // blocks
    starts = np.linspace(0, count - per, blocks).round().astype(int)
    return np.unique((starts[:, None] + np.arange(per)[None, :]).ravel())


def _noise_free(event_set: EventSet) -> bool:
    """Whether the recording's accelerometer noise floor is below
    :data:`~impactid.rigs.pivoted.calibration.NOISE_FREE_FRACTION` of its largest contact pulse."""
    peaks = np.asarray(event_set.pulse_peak if event_set.pulse_peak is not None else [], dtype=float)
    peak = float(np.nanmax(np.abs(peaks))) if peaks.size and np.isfinite(peaks).any() else math.nan
    return bool(peak > 0.0) and noise_free(float(event_set.noise_sigma) / peak)


def contact_duration_check(problem: DampingProblem, beta: float, n: float) -> dict[str, Any]:
    """Rig P's own model check: the fitted law's first-contact durations against the measured ones.

    The measured duration is cut by the noise at the contact's ends (by 2-42 % at 0.2-0.9 % noise on
    recordings of the right law): the fitted law's contacts are therefore replayed through the same
    event detector with the recording's noise (:func:`detected_durations`) and compared like with
    like. Without what the replay needs (an event set made by hand) the simulated durations are
    compared as they are. A recording with more than :data:`DURATION_CHECK_EVENTS` events is checked on
    that many, in blocks of consecutive events spread over it (:func:`_check_events`). In a noise-free
    recording (:func:`_noise_free`) an event agrees when its replayed or its simulated contact lasts as
    measured (no noise cuts the ends there, and the replay, the contact force alone on a quiet flight,
    loses the low tail of a long, nearly plastic contact).

    Parameters
    ----------
    problem : the fit (its event sets hold the measured durations [s]).
    beta : [N s m^-(n+1)]; n : the fitted law.

    Returns
    -------
    dict
        ``verdict`` (``consistent``, ``rejected`` or ``not checked`` when no duration is measured),
        ``events`` compared, ``measured_median_s``, ``model_median_s`` (the simulated contacts),
        ``replayed_median_s`` (the same as the detector measures them with the recording's noise),
        ``median_relative_difference`` (replayed against measured), ``simulated_relative_difference``
        (the simulated durations against the measured ones, as they are: reported), ``threshold``
        (:data:`CONTACT_DURATION_MISMATCH`), ``compared`` (``detector replay`` or ``simulated``),
        ``simulations`` (one S1 run per event at the estimate) and ``reason`` (in words).
    """
    measured, model, replayed, runs = [], [], [], 0
    as_simulated = []  # per event: the simulated duration where the recording is noise-free (NaN elsewhere)
    how = set()
    trial = np.array([[beta, n]])
    for s in problem.sets:
        if s.contact_duration is None or len(s) == 0:
            continue
        if len(s) > DURATION_CHECK_EVENTS:
            s = s.subset(_check_events(len(s)))
        m_s = np.asarray(s.contact_duration, dtype=float)
        grids = _replay_grids(s)
        if grids is None:
            f_s = np.asarray(s.simulate(trial).contact_duration, dtype=float)[0]
            r_s = f_s
            how.add("simulated")
        else:
            batch = simulate_events(s.rig, s.cam_speed_hz, s.states, s.t_end, trial, grids=grids, on_failure="flag")
            f_s = np.where(batch.failed[0], np.nan, np.asarray(batch.contact_duration, dtype=float)[0])
            force = [batch.contact_force[0, batch.grid_offsets[i]:batch.grid_offsets[i + 1]] for i in range(len(s))]
            force = [np.full(1, np.nan) if batch.failed[0, i] else f for i, f in enumerate(force)]
            r_s = detected_durations(force, grids, np.asarray(s.pulse_peak, dtype=float), s.noise_sigma,
                                     s.sample_rate_hz, decimation=s.decimation)
            how.add("detector replay")
        measured.append(m_s)
        model.append(f_s)
        replayed.append(r_s)
        as_simulated.append(f_s if _noise_free(s) else np.full(len(s), np.nan))
        runs += len(s)
    block: dict[str, Any] = {"verdict": "not checked", "events": 0, "measured_median_s": math.nan,
                             "model_median_s": math.nan, "replayed_median_s": math.nan,
                             "median_relative_difference": math.nan, "threshold": CONTACT_DURATION_MISMATCH,
                             "compared": " and ".join(sorted(how)), "simulations": runs, "reason": ""}
    if not measured:
        block["reason"] = "no measured contact duration"
        return block
    m, f, r = np.concatenate(measured), np.concatenate(model), np.concatenate(replayed)
    quiet = np.concatenate(as_simulated)
    ok = np.isfinite(m) & np.isfinite(r)
    if not ok.any():
        block["reason"] = "no event with both a measured and a simulated contact duration"
        return block
    m, f, r, quiet = m[ok], f[ok], r[ok], quiet[ok]
    with np.errstate(divide="ignore", invalid="ignore"):
        pulse = m > 0.0
        per = np.where(pulse, m, 1.0)
        rel = np.where(pulse, np.abs(r / per - 1.0), np.where(r > 0.0, np.inf, 0.0))
        raw = np.abs(f / np.where(pulse, m, np.nan) - 1.0)
        # noise-free: no noise cuts the contact's ends, and a simulated contact that lasts as measured agrees (the
        # replay lays the contact force alone on a quiet flight, and loses the low tail of a long, nearly plastic
        # contact that the reconstruction's force balance follows: np12, 4.38 ms simulated, 4.34 ms measured,
        # 0.12 ms replayed)
        rel = np.where(np.isfinite(quiet) & pulse, np.fmin(rel, np.abs(quiet / per - 1.0)), rel)
    median = float(np.median(rel))
    block.update(events=int(m.size), measured_median_s=float(np.median(m)),
                 model_median_s=float(np.nanmedian(f)) if np.any(np.isfinite(f)) else math.nan,
                 replayed_median_s=float(np.median(r)), median_relative_difference=median,
                 simulated_relative_difference=float(np.nanmedian(raw)) if np.any(np.isfinite(raw)) else math.nan)
    if not median <= CONTACT_DURATION_MISMATCH:
        block["verdict"] = "rejected"
        if float(np.max(m)) <= 0.0:
            block["reason"] = (f"the recordings show no contact pulse (every measured first contact lasts 0 s: "
                               f"instantaneous impacts) while the fitted law's contacts last "
                               f"{1e3 * block['model_median_s']:.3g} ms: a contact law does not describe these "
                               "impacts (a restitution law may)")
        else:
            block["reason"] = (f"the fitted law's first contacts last {1e3 * block['model_median_s']:.3g} ms "
                               f"({1e3 * block['replayed_median_s']:.3g} ms as the event detector measures them "
                               f"with the recording's noise) against {1e3 * block['measured_median_s']:.3g} ms "
                               f"measured (median relative difference {100 * median:.3g} %, more than "
                               f"{100 * CONTACT_DURATION_MISMATCH:g} %)")
    else:
        block["verdict"] = "consistent"
    return block


def damping_model_check(problem: DampingProblem, per_event: np.ndarray, *, n_params: int, beta: float,
                        n: float, assumed_sd: float | None = None) -> tuple[ModelCheck, dict[str, dict[str, Any]]]:
    """The model check of a contact-damping fit (module doc).

    Parameters
    ----------
    problem : the fit.
    per_event : the pooled per-event residuals at the estimate (NaN where an event is not used).
    n_params : parameters fitted (1 with ``n`` fixed, else 2).
    beta, n : the estimate [N s m^-(n+1)], [-].
    assumed_sd : the residual standard deviation the intervals assumed (default ``sqrt(RSS / dof)``).

    Returns
    -------
    (ModelCheck, rig P's own checks: a dict of the ``contact_duration`` block of
    :func:`contact_duration_check` and the ``contact_pulse`` block of
    :func:`~impactid.rigs.pivoted.pulse_check.pulse_check`); the check is :meth:`~impactid.engine.ModelCheck.rejected`
    when the contact durations reject the law, and a ``systematic misfit`` with its intervals withheld
    (:func:`~impactid.rigs.pivoted.pulse_check.withhold_for_rig`) when the contact pulses find one.
    """
    owner = np.concatenate([[k] * len(es) for k, es in enumerate(problem.sets)]).astype(int)
    # the trend with the approach speed is tested within each recording (the engine's), and only where its speeds
    # differ (by ALIKE_SPREAD or more): period-1 impacts share one speed, and what their measured speeds spread is
    # measurement error, which the residuals share (the envelope's low-rate hc31: a "trend" of correlation -0.98
    # over a spread of 0.05 %, with beta +0.09 %)
    speed = np.concatenate([es.approach_speed if _speeds_differ(es) else np.full(len(es), np.nan)
                            for es in problem.sets])
    used = np.isfinite(per_event)
    covariate = speed[used]
    covariate = covariate if np.isfinite(covariate).any() else None
    check = check_model(per_event[used], None, noise_reference="", what=problem.residual, n_params=n_params,
                        groups=owner[used], covariate=covariate, covariate_name="approach speed [m/s]",
                        structure_floor=problem.indifference, assumed_sd=assumed_sd,
                        between=False)
    durations = contact_duration_check(problem, beta, n)
    if durations["verdict"] == "rejected":
        check = check.rejected(durations["reason"])
    pulse = pulse_check(problem, beta, n)
    check = withhold_for_rig(check, pulse)
    return check, {"contact_duration": durations, "contact_pulse": pulse}


def apply_model_check(check: ModelCheck, rig_checks: dict[str, dict[str, Any]], beta: float, n: float,
                      beta_interval: tuple[float, float], n_interval: tuple[float, float], separable: bool | None,
                      notes: list[str]) -> tuple[tuple[float, float], tuple[float, float], bool | None, dict]:
    """The intervals and the separability verdict after the model check, and the ``model_check`` block.

    A check that widens moves each side of ``beta``'s interval away from the estimate by its
    inflation in the logarithm (``beta`` spans decades), and ``n``'s linearly; one that withholds
    (a law the contact durations reject, or contact pulses that point to a wrong rig constant) makes
    both intervals NaN. ``rig_checks`` (rig P's own check blocks, :func:`damping_model_check`) enter
    the ``model_check`` block under their names. A model the check does not find
    consistent is never separable (``separable`` False; None stays None with ``n`` fixed).
    """
    notes.extend(check.notes)
    if check.action == "withheld":
        beta_interval, n_interval = (math.nan, math.nan), ((n, n) if separable is None else (math.nan, math.nan))
    elif check.action == "widened":
        lo, hi = beta_interval
        if lo > 0.0 and beta > 0.0:  # in the logarithm, on each side: beta's interval stays positive
            beta_interval = (beta * (lo / beta) ** check.inflation, beta * (hi / beta) ** check.inflation)
        if separable is not None:
            n_interval = widen_by_factor(n_interval, n, check.inflation)
    if check.describes_data is False and separable:
        separable = False
        notes.append("beta and n are not reported as separable: the model check finds that the law does not "
                     "describe the data")
    return beta_interval, n_interval, separable, combine_checks([check], extra=rig_checks)


# ---- identifiability --------------------------------------------------------------------------------------


def damping_identifiability(problem: DampingProblem, fit, describes_data: bool | None,
                            n_interval: tuple[float, float] = (math.nan, math.nan)) -> dict[str, Any]:
    """The identifiability block of the least-squares fit (:func:`impactid.engine.identifiability`) in
    its search coordinates ``(log10 c, n)`` (``c = beta delta_ref^n`` [N s/m]).

    ``log10 c``'s profile is quadratic (from the Gauss-Newton ``J^T J``); ``n``'s is the profile
    along the valley the fit traced (``log10 c`` re-optimised at each ``n``: a refit profile), its
    shape read from where it rises by the 95 % threshold. With ``n`` fitted, the law with ``n`` held
    at :data:`N_COMPARED` is compared with it: AIC, BIC and the likelihood-ratio statistic from the sums
    of squares (read off the valley profile, where it reaches ``N_COMPARED``), and the decision by the
    Wald test on the reported ``n_interval`` (95 %), which holds the recordings' systematic errors
    besides the statistics: the sums of squares alone ignore them and would reject a right ``n``
    that the interval holds.
    """
    lc_lo, lc_hi = problem.log10_c_bounds
    fixed = problem.fix_n is not None
    x = np.asarray(fit.x, dtype=float)
    free = [Free("log10_c", float(min(max(x[0], lc_lo), lc_hi)), lc_lo, lc_hi, unit="log10(N s/m)")]
    if not fixed:
        free.append(Free("n", float(min(max(x[1], problem.n_bounds[0]), problem.n_bounds[1])), *problem.n_bounds))
    r = np.asarray(fit.residuals, dtype=float)
    found = Search(free=tuple(free), x=x[:len(free)], residual=r, jacobian=np.asarray(fit.jacobian, dtype=float),
                   cost=0.5 * float(r @ r), nfev=int(fit.evaluations), success=True, message="")
    stated = uncertainty(found)
    comparison = None
    block = identifiability(found, stated, describes_data=describes_data,
                            quadratic_reason="the profile along the valley stands for n's refit profile")
    if not fixed:
        prof = fit.profile
        rise = (prof["rss"].to_numpy(float) - fit.rss) / fit.s2 if fit.s2 > 0 else np.full(len(prof), np.nan)
        n_values = prof["n"].to_numpy(float)
        low = float(np.nanmax(np.where(n_values < x[1], rise, -np.inf), initial=-np.inf))
        high = float(np.nanmax(np.where(n_values > x[1], rise, -np.inf), initial=-np.inf))
        quadratic_shape = block["profiles"]["n"]["shape"]
        block["profiles"]["n"] = {"shape": profile_shape(low, high), "method": "refit (the valley: log10 c "
                                  "re-optimised at each n)", "points": np.column_stack([n_values, rise]).tolist()}
        # the notes speak of the refit profile, not of the quadratic one it replaces
        notes = [v for v in block["notes"] if v != profile_note("n", quadratic_shape)]
        if block["profiles"]["n"]["shape"] != "bounded":
            notes.append(profile_note("n", block["profiles"]["n"]["shape"]))
        block["notes"] = list(dict.fromkeys(notes))
        block["profile_method"] = ("mixed: n's profile is the valley (refit), log10 c's quadratic (Gauss-Newton "
                                   "J^T J)")
        if block["profiles"]["n"]["shape"] != "bounded":
            block["determined"] = False
        held = f"n = {N_COMPARED:g}"
        if n_values.size and n_values.min() <= N_COMPARED <= n_values.max():
            rss_held = float(np.interp(N_COMPARED, n_values, prof["rss"].to_numpy(float)))
            comparison = compare_models([{"name": held, "n_params": 1, "n_data": r.size, "rss": rss_held},
                                         {"name": "n fitted", "n_params": 2, "n_data": r.size, "rss": fit.rss}],
                                        nested=[(held, "n fitted")], choice=f"n fitted or held at {N_COMPARED:g}")
        else:
            comparison = {"choice": f"n fitted or held at {N_COMPARED:g}", "models": [], "likelihood_ratio": [],
                          "note": f"{held} lies beyond the profile along the valley (which stops where the sum of "
                                  "squares rises by 1.5 times its 95 % threshold): no sums of squares to compare"}
        half = 0.5 * (n_interval[1] - n_interval[0])
        sd = half / 1.959963984540054 if math.isfinite(half) and half > 0 else math.nan
        z2 = ((x[1] - N_COMPARED) / sd) ** 2 if math.isfinite(sd) else math.nan
        p = chi2_sf(z2, 1) if math.isfinite(z2) else math.nan
        comparison["wald"] = {"statistic": z2, "dof": 1, "p_value": p, "rejects_simple": bool(p < LRT_SIGNIFICANCE),
                              "n_interval": list(n_interval)}
        if block["profiles"]["n"]["shape"] != "bounded":  # n not determined: its interval is cut by a bound
            comparison["wald"].update(rejects_simple=False, note="not applicable: the profile of n is not bounded "
                                      "(its interval is cut by the search's bound), so the data do not reject the "
                                      "held law")
            comparison["preferred"] = held
        else:
            comparison["preferred"] = ("n fitted" if p < LRT_SIGNIFICANCE
                                       else held if math.isfinite(p) else "undecided")
        comparison["rule"] = (f"{held} unless the Wald test on the reported 95 % interval of n (statistics and the "
                              f"recordings' systematic errors) rejects it at p < {LRT_SIGNIFICANCE:g}; the "
                              "likelihood-ratio statistic of the sums of squares is reported beside it")
        block["model_comparison"] = comparison
    block["coordinates"] = "log10_c = log10(beta delta_ref^n) [c in N s/m], n"
    block["delta_ref"] = problem.delta_ref
    return block


#: A fit whose 95 % interval of ``beta`` reaches more than this many times away from the estimate (a decade, on
#: either side) does not report ``beta`` as determined: its interval is the answer, not the value (the envelope's
#: low-rate hc07: +101 %, its interval 0.0045 to 54 times the truth).
DETERMINED_REACH = 10.0


def interval_reach(beta: float, beta_interval: tuple[float, float]) -> float:
    """How many times away from ``beta`` its interval reaches, on the farther side (NaN for a withheld one)."""
    lo, hi = beta_interval
    if not (beta > 0.0 and lo > 0.0 and math.isfinite(hi)):
        return math.nan
    return max(beta / lo, hi / beta)


def mark_reach(block: dict[str, Any], beta: float, beta_interval: tuple[float, float], notes: list[str]) -> None:
    """Mark ``block`` (an identifiability block) not determined, with the note first and among ``notes``, where
    ``beta``'s interval reaches more than :data:`DETERMINED_REACH` times away from it."""
    reach = interval_reach(beta, beta_interval)
    if not (math.isfinite(reach) and reach > DETERMINED_REACH):
        return
    note = (f"beta's 95 % interval [{beta_interval[0]:.4g}, {beta_interval[1]:.4g}] reaches {reach:.3g} times away "
            f"from the estimate {beta:.4g}: beta is not determined by these data (more than {DETERMINED_REACH:g} "
            "times; the interval is the answer, not the value)")
    block["determined"] = False
    block["notes"] = [note] + [v for v in block.get("notes", []) if v != note]
    notes.append(note)


def search_identifiability(problem: DampingProblem, separable: bool | None, n_interval: tuple[float, float],
                           describes_data: bool | None) -> dict[str, Any]:
    """The identifiability block of the ``"optimise"`` and ``"grid"`` methods, which have no Jacobian: the
    shape of ``n``'s profile read from its interval (the lattice's indifference region and bootstrap)
    against the search bounds, and the separability verdict."""
    if problem.fix_n is not None:
        profiles = {}
    else:
        lo, hi = problem.n_bounds
        low_open = n_interval[0] <= lo + 1e-9
        high_open = n_interval[1] >= hi - 1e-9
        shape = "flat" if low_open and high_open else ("one-sided" if low_open or high_open else "bounded")
        profiles = {"n": {"shape": shape, "method": "the lattice's indifference region and bootstrap", "points": []}}
    determined = bool(separable in (None, True) and describes_data is not False
                      and all(p["shape"] == "bounded" for p in profiles.values()))
    from impactid.engine import CONDITION_LIMIT, PROFILE_THRESHOLD

    return {"condition_number": math.nan, "condition_limit": CONDITION_LIMIT,
            "names": ["log10_c"] + ([] if problem.fix_n is not None else ["n"]),
            "correlation": [], "largest_correlation": {"pair": [], "value": math.nan}, "near_bounds": [],
            "profiles": profiles, "profile_threshold": PROFILE_THRESHOLD,
            "profile_method": "lattice (no Jacobian: the optimise and grid methods)", "profile_evaluations": 0,
            "model_comparison": None, "determined": determined,
            "notes": ["the optimise and grid methods have no Jacobian: the condition number and the correlations are "
                      "those of the least-squares method"]}

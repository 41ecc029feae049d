"""The ``"least-squares"`` method of the contact-damping fit (:mod:`impactid.engine.valley`).

Steps, one function each:

1. the **search**: the trust-region Gauss–Newton fit of the per-event residuals over several starts,
   equally good minima told apart by the measured contact durations (:func:`gauss_newton_search`,
   :func:`by_contact_duration`);
2. the **statistical interval** of ``beta``: the 95 % profile region projected on ``beta``, holding any
   minima nothing told apart (:func:`profile_interval`), and where the residuals barely depend on the law,
   every other minimum along ``beta`` that fits within the pipeline's error (:func:`competing_minima`: a
   replay's contacts that come and go with the law make the objective a sawtooth);
3. the **systematic shifts**: a common-mode residual error of each recording (:func:`systematic_shifts`)
   and each recording's cam-phase error (:func:`cam_phase_shifts`), by linear propagation through the
   Gauss–Newton normal matrix, combined over recordings in quadrature (:func:`quadrature`); the phase's
   at Student's t of its own degrees of freedom (:func:`phase_quantiles`) and checked by refits
   (:func:`cam_phase_refits`);
4. the **intervals**: ``beta``'s statistical interval and the phase's range added on each side (the two share
   the accelerometer's integration: their errors are correlated), the systematic shift in quadrature
   (:func:`combine_phase`), kept inside the search box (:func:`clip_to_search_box`); ``n`` widened in
   quadrature (:func:`n_interval`);
5. the **standard errors** and a **linearised bootstrap** over impacts (:func:`standard_errors`,
   :func:`linearised_bootstrap`);
6. the **model check** of the per-event residuals and the contact durations, which widens or withholds
   the intervals and never lets a rejected law be separable, and the **identifiability** block
   (:func:`~impactid.rigs.pivoted.damping_diagnostics.damping_model_check`,
   :func:`~impactid.rigs.pivoted.damping_diagnostics.apply_model_check`,
   :func:`~impactid.rigs.pivoted.damping_diagnostics.damping_identifiability`).

Identifiability and the shared notes are :mod:`impactid.rigs.pivoted.damping_diagnostics`'.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy import optimize

from impactid.engine import linearised_bootstrap as engine_bootstrap
from impactid.engine.distributions import student_t_quantile
from impactid.engine.valley import LeastSquaresFit, fit_least_squares
from impactid.rigs.pivoted.damping_diagnostics import (
    apply_model_check,
    bound_notes,
    damping_identifiability,
    damping_model_check,
    failure_note,
    mark_reach,
    per_event_table,
    separability,
    widen_interval,
)
from impactid.rigs.pivoted.damping_objective import DampingObjective, DampingProblem
from impactid.rigs.pivoted.estimate_results import DampingEstimate, Progress

__all__ = ["FINE_STRUCTURE_FLOORS", "MINIMA_SCAN_EXTENSIONS", "MINIMA_SCAN_HALF_WIDTH", "MINIMA_SCAN_STEP",
           "PHASE_REFIT_Z", "REFIT_PROBE", "CompetingMinima", "by_contact_duration", "cam_phase_refits",
           "cam_phase_shifts", "clip_to_search_box", "combine_phase", "competing_minima", "competing_minima_note",
           "contact_counts", "gauss_newton_search", "least_squares_estimate", "linearised_bootstrap", "n_interval",
           "phase_quantiles", "point_estimate", "profile_interval", "quadrature", "standard_errors",
           "systematic_shifts", "valley_box"]

#: A 10 % change of ``beta`` that moves the per-event residuals by less than this many residual floors (rms)
#: makes :func:`competing_minima` scan along ``beta``: the law then barely moves the residuals, and a replay's
#: contact that comes or goes with the law (a graze after a long, nearly plastic contact) changes them by as
#: much, so other minima can fit within the pipeline's error.
FINE_STRUCTURE_FLOORS = 10.0
#: Spacing [decades of c] of :func:`competing_minima`'s scan.
MINIMA_SCAN_STEP = 0.01
#: Half-width [decades of c] of :func:`competing_minima`'s scan about the estimate.
MINIMA_SCAN_HALF_WIDTH = 0.2
#: Times :func:`competing_minima`'s scan is extended by another half-width on a side its region reaches.
MINIMA_SCAN_EXTENSIONS = 2


def point_estimate(problem: DampingProblem, obj: DampingObjective, fit: LeastSquaresFit) -> tuple[float, float]:
    """``(beta, n)`` at the end of a :func:`gauss_newton_search` (``n`` the fixed one where fixed)."""
    n_hat = float(problem.fix_n) if problem.fix_n is not None else float(fit.x[1])
    return float(obj.beta(fit.x[0], n_hat)), n_hat


def least_squares_estimate(problem: DampingProblem, obj: DampingObjective, fit: LeastSquaresFit,
                           notes: list[str]) -> DampingEstimate:
    """The :class:`DampingEstimate` of a finished :func:`gauss_newton_search`: its intervals (profile, competing
    minima, cam phase, systematic error), bootstrap, model check and identifiability (the work after the search,
    which a calibrated estimate skips for a first fit that it refits:
    :func:`~impactid.rigs.pivoted.damping.start_contact_damping`)."""
    fix_n = problem.fix_n
    systematic = problem.indifference
    logc_hat = fit.x[0]
    beta_hat, n_hat = point_estimate(problem, obj, fit)
    J, r = fit.jacobian, fit.residuals
    # d log(beta) / d(log10 c, n)
    grad = np.array([math.log(10.0), -math.log(obj.delta_ref)])[: J.shape[1]]
    normal = np.linalg.pinv(J.T @ J)

    log_iv = profile_interval(fit, obj, n_hat, fix_n, notes)
    minima = competing_minima(problem, obj, fit, n_hat, systematic)
    if minima is not None:
        log_iv = (min(log_iv[0], math.log(float(obj.beta(minima.interval[0], n_hat)))),
                  max(log_iv[1], math.log(float(obj.beta(minima.interval[1], n_hat)))))
        counts = contact_counts(problem, obj, np.concatenate([[logc_hat], minima.log10_c]), n_hat)[:, fit.used]
        notes.append(competing_minima_note(obj, minima, n_hat, beta_hat, counts))
    per_event_hat = np.full(fit.used.size, math.nan)
    per_event_hat[fit.used] = r
    sys_shifts = systematic_shifts(problem, fit, normal, systematic)
    phase_shifts = cam_phase_shifts(problem, obj, fit, normal, logc_hat, n_hat, per_event_hat)
    phase_logbeta, sys_logbeta = quadrature(phase_shifts, grad), quadrature(sys_shifts, grad)
    # each recording's phase error at its 95 % range: Student's t, its standard error being a scatter estimate
    z_phase = phase_quantiles(problem)
    phase95 = quadrature([z * dx for z, dx in zip(z_phase, phase_shifts)], grad)
    # the phase's effect on beta is far from linear where alpha_m barely depends on beta (restitution
    # near 1, slow impacts near the top of the cam's lift): refits at the phase's 95 % range bound it
    # as well (the larger of both, per side)
    refit_lo, refit_hi = cam_phase_refits(problem, obj, logc_hat, n_hat, phase_shifts, z=z_phase)
    log_iv = combine_phase(log_iv, math.log(beta_hat), (max(phase95, math.log(beta_hat) - refit_lo),
                                                        max(phase95, refit_hi - math.log(beta_hat))), sys_logbeta)
    beta_iv = clip_to_search_box(problem, obj, log_iv, n_hat, notes)
    phase_n_sd = quadrature(phase_shifts, grad, 1) if fix_n is None else 0.0
    n_iv = n_interval(problem, fit, n_hat, math.hypot(1.96 * phase_n_sd, quadrature(sys_shifts, grad, 1))
                      if fix_n is None else 0.0)

    beta_se, n_se = standard_errors(fit, grad, beta_hat, fixed_n=fix_n is not None)
    boot = linearised_bootstrap(obj, J, r, logc_hat, n_hat, problem.bootstrap_resamples, problem.bootstrap_seed)
    b_boot = np.percentile(boot[:, 0], [2.5, 97.5])
    n_boot = np.percentile(boot[:, 1], [2.5, 97.5])

    region = (f"the 95 % profile interval of the {problem.residual} sum of squares (with the pipeline's systematic "
              f"residual error {systematic:.3g} per recording) stays open")
    separable = separability(problem, n_iv, beta_iv, region, notes)
    if separable is False:
        beta_iv, n_iv = valley_box(problem, obj, notes)
    bound_notes(problem, logc_hat, n_hat, notes)
    check, durations = damping_model_check(problem, per_event_hat, n_params=J.shape[1], beta=beta_hat, n=n_hat,
                                           assumed_sd=math.sqrt(fit.s2))
    beta_iv, n_iv, separable, model_block = apply_model_check(check, durations, beta_hat, n_hat, beta_iv, n_iv,
                                                              separable, notes)
    if math.sqrt(fit.s2) > 0.05:
        notes.append(f"the residual scatter between impacts is large (rms {math.sqrt(fit.s2):.3g}); "
                     f"the estimate rests on {r.size} impacts")
    prof = fit.profile
    valley = pd.DataFrame({"n": prof["n"], "beta": obj.beta(prof["log10_c"].to_numpy(), prof["n"].to_numpy()),
                           "log10_c": prof["log10_c"], "objective": prof["objective"]})
    land = problem.landscape_if_asked()
    failure_note(obj, notes)
    block = damping_identifiability(problem, fit, check.describes_data, n_iv)
    mark_reach(block, beta_hat, beta_iv, notes)
    return DampingEstimate(
        beta=beta_hat, n=n_hat, fixed_n=fix_n is not None, residual=problem.residual,
        objective=float(np.mean(np.abs(r))), method="least-squares", beta_interval=beta_iv, n_interval=n_iv,
        beta_bootstrap_interval=(float(b_boot[0]), float(b_boot[1])),
        n_bootstrap_interval=(float(n_boot[0]), float(n_boot[1])), indifference=float(systematic),
        separable=separable, phase_beta_sd=beta_hat * math.expm1(min(phase_logbeta, 700.0)), phase_n_sd=phase_n_sd,
        valley=valley, per_event=per_event_table(problem, per_event_hat), delta_ref=obj.delta_ref, bootstrap=boot,
        landscape=land, n_simulations=obj.n_simulations, seconds=math.nan, warnings=tuple(notes),
        n_failed_simulations=obj.n_failed, beta_stderr=check.widen_stderr(beta_se), n_stderr=check.widen_stderr(n_se),
        model_check=model_block, identifiability=block)


def gauss_newton_search(problem: DampingProblem, obj: DampingObjective, systematic: float, notes: list[str],
                        progress: Progress, *, sensitivities: bool = True) -> LeastSquaresFit:
    """The Gauss–Newton fit of the per-event residuals (:func:`impactid.engine.valley.fit_least_squares`).

    ``systematic`` (the residual's systematic error per event) sets the sum of squares within which
    minima count as equally good; those are told apart by :func:`by_contact_duration`. The start scan
    simulates a part of the events (:meth:`~impactid.rigs.pivoted.damping_objective.DampingObjective.scan_part`)
    where there are more than :data:`~impactid.rigs.pivoted.damping_objective.SCAN_EVENTS`.
    """
    fix_n = problem.fix_n
    part = obj.scan_part()

    def scan(logc, n):  # the start scan on a part of the events; its simulations count in the fit's
        before = part.n_simulations
        cost = part.scan_cost(logc, n)
        obj.n_simulations += part.n_simulations - before
        obj.n_failed += part.n_failed
        part.n_failed = 0
        return cost

    return fit_least_squares(obj.per_event, fix_n=fix_n, lc_bounds=problem.log10_c_bounds, n_bounds=problem.n_bounds,
                             progress=progress,
                             choose=lambda points: by_contact_duration(obj, problem.sets, points, fix_n, notes),
                             rss_tolerance=obj.n_events * systematic ** 2,
                             per_event_jacobian=obj.per_event_and_jacobian if sensitivities else None,
                             scan=scan if part is not None else None)


def by_contact_duration(obj: DampingObjective, sets: Sequence, points, fix_n: float | None,
                        notes: list[str]) -> int | None:
    """Which of several equally good minima ``(log10 c[, n])`` reproduces the measured contact durations.

    A heavily damped law can make the follower chatter and still reach the measured ``alpha_m``
    (with friction especially); the duration of the first contact tells it apart. Returns the index
    of the point whose simulated first contacts differ least from the measured ones (median relative
    difference over the events with a measured duration), if it is clearly the best (less than half
    the next and below 20 %); None otherwise. The simulations count in ``obj``; the choice is noted.
    """
    measured = np.concatenate([s.contact_duration if s.contact_duration is not None else np.full(len(s), np.nan)
                               for s in sets])
    if not np.isfinite(measured).any():
        return None
    trials = np.array([[float(obj.beta(p[0], p[1] if len(p) > 1 else fix_n)), p[1] if len(p) > 1 else fix_n]
                       for p in points])
    simulated = np.concatenate([s.simulate(trials).contact_duration for s in sets], axis=1)
    obj.n_simulations += trials.shape[0] * measured.size
    with np.errstate(all="ignore"):
        score = np.nanmedian(np.abs(simulated / measured[None, :] - 1.0), axis=1)
    order = np.argsort(score)
    best = int(order[0])
    if not (np.isfinite(score[best]) and score[best] < 0.2 and score[best] < 0.5 * score[order[1]]):
        return None
    others = ", ".join(f"beta {trials[i, 0]:.4g} ({100 * score[i]:.0f} %)" for i in order[1:])
    notes.append(f"other laws match the {obj.residual} residuals as well ({others} median difference of the first "
                 f"contact's duration); the estimate is the one whose contacts last as measured "
                 f"({100 * score[best]:.1f} %)")
    return best


def profile_interval(fit: LeastSquaresFit, obj: DampingObjective, n_hat: float, fix_n: float | None,
                     notes: list[str]) -> tuple[float, float]:
    """The statistical interval of ``ln beta``: the profile-likelihood region projected on ``beta``.

    The profile points within the 95 % threshold of the sum of squares, each with its half-width in
    ``log10 c``, plus the ends of the ``n`` interval (joint fits) and any equally good minima that
    nothing told apart (then noted: the interval holds them all).
    """
    prof = fit.profile
    inside = prof["rss"] - fit.rss <= fit.threshold
    lc_in, n_in, half = (prof.loc[inside, k].to_numpy(dtype=float) for k in ("log10_c", "n", "half_width"))
    if fix_n is None:  # the interval's ends on the profile (half-width 0 there)
        ends = np.asarray(fit.n_interval)
        lc_in = np.concatenate([lc_in, np.interp(ends, prof["n"], prof["log10_c"])])
        n_in = np.concatenate([n_in, ends])
        half = np.concatenate([half, [0.0, 0.0]])
    if not fit.resolved:  # equally good minima that nothing told apart: the interval holds them all
        lc_in = np.concatenate([lc_in, [a[0] for a in fit.alternatives]])
        n_in = np.concatenate([n_in, [a[1] if len(a) > 1 else n_hat for a in fit.alternatives]])
        half = np.concatenate([half, np.zeros(len(fit.alternatives))])
        notes.append(f"the {obj.residual} residuals are matched equally well by other laws ("
                     + ", ".join(f"beta {obj.beta(a[0], a[1] if len(a) > 1 else n_hat):.4g}" for a in fit.alternatives)
                     + ") that the measured contact durations do not tell apart: the interval of beta holds them all")
    log_beta = np.log(obj.beta(np.concatenate([lc_in - half, lc_in + half]), np.concatenate([n_in, n_in])))
    return (float(log_beta.min()), float(log_beta.max()))


@dataclass(frozen=True)
class CompetingMinima:
    """Other minima of the sum of squares along ``log10 c`` (``n`` held) that fit within the pipeline's error.

    Attributes
    ----------
    log10_c : the competing minima [log10 (N s/m)], other than the search's.
    rss : their sums of squares.
    best_rss : the least sum of squares of the scan and the search.
    tolerance : the excess over ``best_rss`` within which a law counts as fitting (``t^2 s^2 + m floor^2``).
    interval : ``(lo, hi)`` [log10 (N s/m)], the hull of the scanned laws within the tolerance, rounded
        outward to the next scan point (the sum of squares between scan points is not known: it may jump).
    """

    log10_c: np.ndarray
    rss: np.ndarray
    best_rss: float
    tolerance: float
    interval: tuple[float, float]


def competing_minima(problem: DampingProblem, obj: DampingObjective, fit: LeastSquaresFit, n_hat: float,
                     floor: float) -> CompetingMinima | None:
    """Other minima along ``log10 c`` (``n`` held at ``n_hat``) that fit as well as the search's, within the
    pipeline's error: the local profile interval does not see them.

    Where a 10 % change of ``beta`` moves the residuals by less than :data:`FINE_STRUCTURE_FLOORS` floors
    (rms over the events, from the Jacobian at the estimate; no simulation), a replay's contact that comes
    and goes with the law (after a long, nearly plastic contact the follower grazes the cam again or not)
    changes them by as much, and the sum of squares along ``beta`` is a sawtooth with several minima.
    There ``log10 c`` is scanned every :data:`MINIMA_SCAN_STEP` decades over +-:data:`MINIMA_SCAN_HALF_WIDTH`
    about the estimate (extended by another half-width, :data:`MINIMA_SCAN_EXTENSIONS` times at most, on a
    side where laws within the tolerance reach the scan's end; within the search box). Every scanned law
    whose sum of squares lies within ``t^2 s^2 + m floor^2`` of the best (the fit's 95 % threshold plus the
    floor's share over the ``m`` events: what the intervals' systematic widening allows for) fits within the
    error; a local minimum among them more than 0.02 decades from the estimate is a competing minimum.

    Parameters
    ----------
    problem : the fit (its search box).
    obj : its objective (the scan's simulations count in it).
    fit : the Gauss–Newton fit (estimate, Jacobian, threshold, events used).
    n_hat : the exponent held.
    floor : the residual's systematic floor per event (its units: those of the residual).

    Returns
    -------
    CompetingMinima or None
        None where the residuals depend on the law strongly enough (nothing simulated) or the scan finds
        no other minimum within the tolerance.
    """
    jac = np.asarray(fit.jacobian, dtype=float)[:, 0]  # d r / d log10 c
    m = jac.size
    moved = math.sqrt(float(np.mean(jac ** 2))) * math.log10(1.1) if m else math.inf
    if not (floor > 0 and moved < FINE_STRUCTURE_FLOORS * floor):
        return None
    logc_hat = float(fit.x[0])
    lo_box, hi_box = (float(v) for v in problem.log10_c_bounds)
    tolerance = fit.threshold + m * floor ** 2
    steps = int(round(MINIMA_SCAN_HALF_WIDTH / MINIMA_SCAN_STEP))

    def rss_at(grid: np.ndarray) -> np.ndarray:
        r = np.atleast_2d(obj.per_event(grid, np.full(grid.size, n_hat)))[:, fit.used]
        return np.where(np.all(np.isfinite(r), axis=1), np.sum(np.nan_to_num(r) ** 2, axis=1), np.inf)

    offsets = np.arange(-steps, steps + 1)
    grid = logc_hat + MINIMA_SCAN_STEP * offsets
    grid = grid[(grid >= lo_box) & (grid <= hi_box)]
    rss = rss_at(grid)
    for _ in range(MINIMA_SCAN_EXTENSIONS):
        best = min(fit.rss, float(np.min(rss)))
        within = rss - best <= tolerance
        more = []
        if within[0] and grid[0] - MINIMA_SCAN_STEP >= lo_box:
            more.append(grid[0] - MINIMA_SCAN_STEP * np.arange(steps, 0, -1))
        if within[-1] and grid[-1] + MINIMA_SCAN_STEP <= hi_box:
            more.append(grid[-1] + MINIMA_SCAN_STEP * np.arange(1, steps + 1))
        if not more:
            break
        extra = np.concatenate(more)
        extra = extra[(extra >= lo_box) & (extra <= hi_box)]
        grid = np.concatenate([grid, extra])
        rss = np.concatenate([rss, rss_at(extra)])
        order = np.argsort(grid)
        grid, rss = grid[order], rss[order]
    best = min(fit.rss, float(np.min(rss)))
    within = rss - best <= tolerance
    left = np.concatenate([[np.inf], rss[:-1]])
    right = np.concatenate([rss[1:], [np.inf]])
    local = within & (rss <= left) & (rss <= right) & (np.abs(grid - logc_hat) > 0.02)
    if not local.any():
        return None
    inside = np.flatnonzero(within)
    lo_i, hi_i = max(int(inside[0]) - 1, 0), min(int(inside[-1]) + 1, grid.size - 1)
    interval = (min(float(grid[lo_i]), logc_hat), max(float(grid[hi_i]), logc_hat))
    return CompetingMinima(log10_c=grid[local], rss=rss[local], best_rss=best, tolerance=float(tolerance),
                           interval=interval)


def contact_counts(problem: DampingProblem, obj: DampingObjective, log10_c: np.ndarray, n: float) -> np.ndarray:
    """The replays' numbers of contacts ``(k, n_events)`` at ``k`` laws ``(log10 c, n)`` (the first contact
    and any later one before the event's end); the simulations count in ``obj``."""
    log10_c = np.atleast_1d(np.asarray(log10_c, dtype=float))
    trials = np.column_stack([obj.beta(log10_c, n), np.full(log10_c.size, float(n))])
    obj.n_simulations += trials.shape[0] * obj.n_events
    return np.concatenate([s.simulate(trials).n_contacts for s in problem.sets], axis=1)


def competing_minima_note(obj: DampingObjective, minima: CompetingMinima, n_hat: float, beta_hat: float,
                          counts: np.ndarray) -> str:
    """The note of :func:`competing_minima`: the other minima, the tolerance and whether the replays' number of
    contacts differs between them and the estimate (``counts``, ``(1 + minima, events)``, the estimate first)."""
    others = ", ".join(f"beta {float(obj.beta(c, n_hat)):.4g} (sum of squares {v:.3g})"
                       for c, v in zip(minima.log10_c, minima.rss))
    differ = np.any(counts[1:] != counts[0][None, :], axis=0)
    why = (f"the replays' number of contacts differs between them in {int(differ.sum())} of {differ.size} events "
           f"(a contact that comes and goes with the law)" if differ.any()
           else "the replays' number of contacts is the same at all of them")
    lo, hi = (float(obj.beta(c, n_hat)) for c in minima.interval)
    return (f"beta is not identified to better than the spread of several minima: the {obj.residual} residuals "
            f"barely depend on the law here, and other laws fit within the pipeline's error (the best sum of "
            f"squares {minima.best_rss:.3g} plus {minima.tolerance:.3g}) as well as the estimate {beta_hat:.4g}: "
            f"{others}; {why}. The interval of beta holds them all ({lo:.4g} to {hi:.4g} before the systematic "
            f"widening)")


def _event_owners(problem: DampingProblem) -> np.ndarray:
    """Per pooled event, the index of its recording's event set."""
    return np.concatenate([[k] * len(es) for k, es in enumerate(problem.sets)])


def systematic_shifts(problem: DampingProblem, fit: LeastSquaresFit, normal: np.ndarray,
                      systematic: float) -> list[np.ndarray]:
    """Per recording, the shift of ``(log10 c[, n])`` that a common-mode residual error ``systematic``
    of its events causes (linear propagation through the normal matrix ``normal = (J^T J)^+``)."""
    owner = _event_owners(problem)[fit.used]
    J = fit.jacobian
    return [normal @ (J.T @ (systematic * (owner == k))) for k in range(len(problem.sets))]


def cam_phase_shifts(problem: DampingProblem, obj: DampingObjective, fit: LeastSquaresFit, normal: np.ndarray,
                     logc_hat: float, n_hat: float, per_event_hat: np.ndarray) -> list[np.ndarray]:
    """Per recording with a cam-phase error, the shift of ``(log10 c[, n])`` that a phase shifted by its
    standard error causes (its residuals' change at the estimate, propagated linearly). The extra
    simulations count in ``obj``."""
    owner_all = _event_owners(problem)
    J = fit.jacobian
    shifts = []
    for k, es in enumerate(problem.sets):
        if not (math.isfinite(es.phase_stderr) and es.phase_stderr > 0):
            continue
        sub = problem.objective([es.shift_phase(es.phase_stderr)])
        delta = np.zeros(fit.used.size)
        delta[owner_all == k] = sub.per_event(logc_hat, n_hat)[0] - per_event_hat[owner_all == k]
        obj.n_simulations += sub.n_simulations
        shifts.append(normal @ (J.T @ np.nan_to_num(delta[fit.used])))
    return shifts


#: Standard errors of the cam phase at which :func:`cam_phase_refits` refits by default (the normal 95 % range;
#: :func:`least_squares_estimate` passes Student's t of each recording, :func:`phase_quantiles`).
PHASE_REFIT_Z = 1.96
#: Spacing [decades of c] of the three points that test the linear prediction of a refit (2 % of beta).
REFIT_PROBE = 0.01


def cam_phase_refits(problem: DampingProblem, obj: DampingObjective, logc_hat: float, n_hat: float,
                     linear_shifts: Sequence[np.ndarray] = (), z: Sequence[float] | None = None) -> tuple[float, float]:
    """The range of ``ln beta`` over refits with each recording's cam phase moved by +-``z`` standard errors
    (``n`` held at ``n_hat``).

    ``z`` holds one quantile per recording with a phase error, in :func:`cam_phase_shifts`' order
    (:func:`phase_quantiles`; default :data:`PHASE_REFIT_Z` for each).

    Where the phase's effect is linear this lies within the linear propagation (:func:`cam_phase_shifts`);
    where it is not (slow impacts near the top of the cam's lift with a restitution near 1: beta moved by
    factors while alpha_m barely moves, docs/estimation.md) it is what covers the truth. Each refit first
    tries the linear prediction (``linear_shifts``, the shift of ``(log10 c[, n])`` for +1 standard error of
    each recording's phase, in :func:`cam_phase_shifts`' order): three points :data:`REFIT_PROBE` decades
    apart around it; if the middle one is the lowest, the parabola's vertex through them is the refit
    (the linear prediction held, to within the probe). Otherwise ``log10 c`` is scanned over the search
    box (41 points) and refined by bounded Brent around its best point. The simulations count in ``obj``.
    Returns ``(ln beta_hat, ln beta_hat)`` without a phase error.
    """
    lo_box, hi_box = problem.log10_c_bounds
    centre = math.log(float(obj.beta(logc_hat, n_hat)))
    low = high = centre
    grid = np.linspace(lo_box, hi_box, 41)
    shifts = iter(linear_shifts)
    quantiles = iter(z if z is not None else ())
    for k, es in enumerate(problem.sets):
        if not (math.isfinite(es.phase_stderr) and es.phase_stderr > 0):
            continue
        shift = next(shifts, None)  # cam_phase_shifts has one entry per recording with a phase error
        zk = float(next(quantiles, PHASE_REFIT_Z))
        for sign in (-1.0, 1.0):
            sets = list(problem.sets)
            sets[k] = es.shift_phase(sign * zk * es.phase_stderr)
            sub = problem.objective(sets)

            def rss(g, sub=sub):
                return np.nansum(np.atleast_2d(sub.per_event(np.atleast_1d(g), np.full(np.size(g), n_hat))) ** 2,
                                 axis=1)

            best = None
            if shift is not None and np.all(np.isfinite(shift)):
                # cam_phase_shifts holds (J^T J)^+ J^T dr: the optimum moves by minus that
                guess = float(np.clip(logc_hat - sign * zk * shift[0], lo_box + REFIT_PROBE,
                                      hi_box - REFIT_PROBE))
                probe = guess + REFIT_PROBE * np.array([-1.0, 0.0, 1.0])
                values = rss(probe)
                if np.all(np.isfinite(values)) and values[1] < values[0] and values[1] < values[2]:
                    curvature = values[0] - 2.0 * values[1] + values[2]
                    best = guess + 0.5 * REFIT_PROBE * (values[0] - values[2]) / curvature
            if best is None:
                scan = rss(grid)
                j = int(np.nanargmin(scan)) if np.any(np.isfinite(scan)) else grid.size // 2
                best = optimize.minimize_scalar(lambda g: float(rss(g)[0]),
                                                bounds=(grid[max(j - 1, 0)], grid[min(j + 1, grid.size - 1)]),
                                                method="bounded", options={"xatol": 1e-4}).x
            obj.n_simulations += sub.n_simulations
            obj.n_failed += sub.n_failed
            value = math.log(float(obj.beta(best, n_hat)))
            low, high = min(low, value), max(high, value)
    return low, high


def phase_quantiles(problem: DampingProblem, level: float = 0.95) -> list[float]:
    """Per recording with a cam-phase error (in :func:`cam_phase_shifts`' order), the two-sided ``level``
    quantile of Student's t with ``m - 1`` degrees of freedom, ``m`` the recording's events.

    The phase's standard error ``s_phi`` is Gauss–Newton's from the scatter of the ``m`` onset angles about
    the one fitted phase (:mod:`impactid.rigs.pivoted.anchors`): an estimate with ``m - 1`` degrees of
    freedom, so ``(phi_hat - phi) / s_phi`` follows Student's t there, not the normal law. With 14 impacts
    (a 1 s recording at 15 Hz) the 95 % quantile is 2.16, not 1.96; measured over 60 noise seeds at the
    coverage study's P2 (e/r_c 0.25, 15 Hz), the true phase error over ``s_phi`` had a standard deviation
    of 1.08 (t with 13 degrees of freedom: 1.09; P3 1.14 over 30). The statistical interval of the fit already uses t
    (the profile threshold ``t^2 s^2``); this puts the phase on the same footing. The set's events are
    those replayed, at most the phase fit's, so the quantile errs on the wide side.
    """
    out = []
    for es in problem.sets:
        if not (math.isfinite(es.phase_stderr) and es.phase_stderr > 0):
            continue
        dof = max(len(es) - 1, 1)
        out.append(student_t_quantile(0.5 + 0.5 * level, dof))
    return out


def combine_phase(statistical: tuple[float, float], centre: float, phase: tuple[float, float],
                  systematic: float) -> tuple[float, float]:
    """The interval of ``ln beta``: the statistical interval and the cam phase's range added on each side,
    the systematic shift in quadrature with their sum.

    Derivation. To first order the error of ``ln beta_hat`` is ``e = e_s + e_phi + e_sys``: ``e_s`` from
    the per-event residual errors (the statistical interval, half-widths ``h_s`` at 95 %: ``t s`` times
    the slope), ``e_phi`` from the recording's cam-phase error (half-width ``h_phi``: ``t`` standard errors of
    the phase, propagated linearly or by refits) and ``e_sys`` the common-mode residual floor (``h_sys``,
    independent of both). ``e_s`` and ``e_phi`` are not independent: the phase is fitted to the
    return-time onset angles, which come from the same double integration of the accelerometer as each
    event's excursion to ``alpha_m``, so a noise that moves an event's integration constant moves both.
    Then ``var(e_s + e_phi) = s_s^2 + s_phi^2 + 2 rho s_s s_phi`` with a correlation ``rho`` the estimator
    cannot measure (the events' onset angles are not in the event sets). Measured over noise seeds at the
    coverage study's points (true phase and per-event ``alpha_m`` errors from the synthetic truth), ``rho``
    was +0.36 (P2, 60 seeds), +0.51 (P1, 30 seeds) and +0.12 (P3, 30 seeds): adding the two in
    quadrature (``rho = 0``) understated the spread of ``e`` at P2 (1.66 % against 1.81 %), where the
    phase dominates (1.60 %, the statistical part 0.44 %), and its coverage was 89 %. Whatever ``rho``,
    Cauchy–Schwarz gives ``sd(e_s + e_phi) <= s_s + s_phi``: the half-widths add, ``h_s + h_phi``. The
    systematic floor is a different error (the pipeline's), added in quadrature as before:
    ``lo = c - hypot(h_s,lo + h_phi,lo, h_sys)``, likewise ``hi``.

    Parameters
    ----------
    statistical : ``(lo, hi)`` of ``ln beta`` [ln(N s m^-(n+1))], the statistical interval.
    centre : ``ln beta_hat``.
    phase : ``(below, above)``, the phase's 95 % range of ``ln beta`` on each side of ``centre`` (>= 0).
    systematic : the systematic shift of ``ln beta`` (>= 0).
    """
    lo, hi = statistical
    below = max(centre - lo, 0.0) + max(phase[0], 0.0)
    above = max(hi - centre, 0.0) + max(phase[1], 0.0)
    return (centre - math.hypot(below, systematic), centre + math.hypot(above, systematic))


def quadrature(shifts: Sequence[np.ndarray], grad: np.ndarray, component: int | None = None) -> float:
    """The shifts combined in quadrature: as ``ln beta`` shifts (``grad @ dx``), or of one component of ``dx``."""
    values = [float(grad @ dx) if component is None else float(dx[component]) for dx in shifts]
    return float(np.sqrt(np.sum(np.square(values)))) if values else 0.0


def clip_to_search_box(problem: DampingProblem, obj: DampingObjective, log_interval: tuple[float, float],
                       n_hat: float, notes: list[str]) -> tuple[float, float]:
    """The interval of ``beta`` [N s m^-(n+1)] from that of ``ln beta``, stopped at the search box.

    A linear propagation through a nearly singular valley can reach beyond the box: the interval stops
    at the box's extreme ``beta`` (``beta = c / delta_ref^n``, least at ``(c_lo, n_lo)``, largest at
    ``(c_hi, n_hi)``), with a note.
    """
    lc_bounds = problem.log10_c_bounds
    n_box = (n_hat, n_hat) if problem.fix_n is not None else problem.n_bounds
    box = (math.log(obj.beta(lc_bounds[0], n_box[0])), math.log(obj.beta(lc_bounds[1], n_box[1])))
    if log_interval[0] < box[0] or log_interval[1] > box[1]:
        notes.append("the interval of beta reaches the search box of c = beta delta_ref^n: the data bound beta "
                     "only weakly")
    log_iv = (max(log_interval[0], box[0]), min(log_interval[1], box[1]))
    return (math.exp(log_iv[0]), math.exp(log_iv[1]))


def n_interval(problem: DampingProblem, fit: LeastSquaresFit, n_hat: float, extra: float) -> tuple[float, float]:
    """The interval of ``n``: the profile interval widened by ``extra`` in quadrature, within the bounds
    and opened to a bound the profile reaches (``(n, n)`` with ``n`` fixed)."""
    if problem.fix_n is not None:
        return (n_hat, n_hat)
    n_bounds = problem.n_bounds
    n_iv = widen_interval(fit.n_interval, n_hat, extra)
    n_iv = (max(n_iv[0], n_bounds[0]), min(n_iv[1], n_bounds[1]))
    if fit.reaches_bound[0]:
        n_iv = (n_bounds[0], n_iv[1])
    if fit.reaches_bound[1]:
        n_iv = (n_iv[0], n_bounds[1])
    return n_iv


def valley_box(problem: DampingProblem, obj: DampingObjective, notes: list[str]) -> tuple[tuple[float, float],
                                                                                        tuple[float, float]]:
    """The intervals of ``beta`` [N s m^-(n+1)] and ``n`` of a fit that cannot separate them: the search box.

    Where ``beta`` and ``n`` are not separable the data fix only the valley ``beta(n)``; a 95 % region
    along an explored stretch of it rests on the pipeline's systematic errors along the valley, which
    no statistic measures (a joint fit left with one usable recording of identical impacts put ``n`` in
    [1.50, 1.83] with the truth at 1.25, and ``beta`` 70 times too large). The intervals are therefore
    the search box: every law the box holds, with a note; the statistical stretch stays in the
    separability note. Fix ``n`` or add operating points to determine them.
    """
    (lc_lo, lc_hi), (n_lo, n_hi) = problem.log10_c_bounds, problem.n_bounds
    corners = obj.beta(np.array([lc_lo, lc_lo, lc_hi, lc_hi]), np.array([n_lo, n_hi, n_lo, n_hi]))
    notes.append("the intervals of beta and n are the search box: along the valley the data do not tell the laws "
                 "apart beyond the pipeline's systematic errors, which no interval along it would hold")
    return (float(np.min(corners)), float(np.max(corners))), (float(n_lo), float(n_hi))


def standard_errors(fit: LeastSquaresFit, grad: np.ndarray, beta_hat: float, *, fixed_n: bool) -> tuple[float, float]:
    """Gauss–Newton standard errors of ``beta`` [N s m^-(n+1)] and ``n`` (0 with ``n`` fixed)."""
    beta_se = beta_hat * math.sqrt(max(float(grad @ fit.covariance @ grad), 0.0))
    n_se = 0.0 if fixed_n else math.sqrt(max(float(fit.covariance[1, 1]), 0.0))
    return beta_se, n_se


def linearised_bootstrap(obj: DampingObjective, J: np.ndarray, r: np.ndarray, logc_hat: float, n_hat: float,
                         resamples: int, seed: int) -> np.ndarray:
    """Bootstrap over impacts, linearised (:func:`impactid.engine.linearised_bootstrap`): one weighted
    Gauss–Newton step from the estimate per resample of the events. Returns ``(resamples, 2)``
    estimates ``(beta, n)``."""
    steps = engine_bootstrap(J, r, resamples, seed)
    x_b = np.tile([logc_hat, n_hat], (steps.shape[0], 1))
    x_b[:, : steps.shape[1]] += steps
    return np.column_stack([obj.beta(x_b[:, 0], x_b[:, 1]), x_b[:, 1]]).astype(float)

"""Contact damping: the Hunt–Crossley ``beta, n`` from measured events (Sundar, Dreyer & Singh 2016, sections 5.2, 6-7).

The estimate minimises the paper's objective, the **mean residual over events** ``J(beta, n)``
(``|lambda1|`` by default; :mod:`impactid.rigs.pivoted.residuals`), pooling the events of every recording
given (a joint fit over operating points).

Search coordinates. ``beta`` and ``n`` trade off along a long curved valley: a change of ``n``
by 0.5 moves the matching ``beta`` by a factor ``delta^-0.5`` (~150 at the rig's 40 um
indentations). The search therefore runs in ``(log10 c, n)`` with ``c = beta delta_ref^n``
[N s/m], the damping coefficient at a reference indentation ``delta_ref`` (the median measured
peak indentation). In these coordinates the valley is nearly straight and a box of bounds
contains it (default ``c`` in [1, 1e6] N s/m, ``n`` in [0.5, 2.5]); results are reported in
``beta`` [N s m^-(n+1)] (:mod:`impactid.rigs.pivoted.damping_objective`).

Methods. ``"least-squares"`` (default): the per-event residual vector minimised by a
trust-region Gauss–Newton method, with the Gauss–Newton covariance and the profile along the
valley for the intervals (:mod:`impactid.rigs.pivoted.damping_least_squares` on
:mod:`impactid.engine.valley`, where its interval rules are stated). ``"optimise"``: for each ``n``
a bounded Brent search of ``log10 c``, bracketed by a 41-point scan; for the joint fit the same
inner search inside an outer bounded Brent over ``n`` (a profile: it follows the valley by
construction, so its curvature cannot stall it). ``"grid"``: the paper's grid search, the grid
point of least objective. Both are :mod:`impactid.rigs.pivoted.damping_search`. On the validation
cases the least-squares method agrees with the optimiser within both methods' intervals at about a
hundredth of the simulations (``benchmarks/bench_estimate.py``, docs/performance.md).

Uncertainty and identifiability (``"optimise"`` and ``"grid"``). Around the estimate the per-event
residuals are tabulated on a lattice (81 values of ``log10 c`` over +-0.1 decade about the valley,
for 41 values of ``n`` in the joint fit) and interpolated by cubic splines. From it:

* a **bootstrap over impacts** (400 resamples of the events, the fit repeated on each), giving
  95 % percentile intervals;
* the **indifference region** where the mean residual stays within ``Delta`` of its minimum,
  ``Delta = max(2 SE, floor)``: ``SE`` is the standard error of the mean residual over events at
  the estimate, ``floor`` the residual level the noise-free pipeline itself reaches
  (:data:`RESIDUAL_FLOOR`, measured on S2 recordings at the true parameters), below which
  differences mean nothing.

The reported interval of each parameter is the hull of both. The valley ``beta(n)`` (minimum over
``beta`` at each ``n``) is reported with its objective. If the ``n`` interval is wider than
:data:`~impactid.rigs.pivoted.damping_diagnostics.SEPARABILITY_WIDTH` or reaches a search bound,
``beta`` and ``n`` are declared not separable: a warning says so, with the valley, and the joint
point estimate must not be read as precise (fix ``n`` or fit several operating points jointly).

:func:`fit_contact_damping` itself validates its arguments (:func:`damping_problem`), runs the
method and issues the notes as warnings.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

from impactid.engine.valley import LeastSquaresFit
from impactid.errors import ImpactidError, SimulationError
from impactid.rigs.pivoted.damping_diagnostics import SEPARABILITY_WIDTH
from impactid.rigs.pivoted.damping_least_squares import gauss_newton_search, least_squares_estimate, point_estimate
from impactid.rigs.pivoted.damping_objective import (
    C_BOUNDS,
    N_BOUNDS,
    DampingObjective,
    DampingProblem,
    reference_indentation,
)
from impactid.rigs.pivoted.damping_search import fit_by_search
from impactid.rigs.pivoted.estimate_results import DampingEstimate, EstimationWarning, Progress
from impactid.rigs.pivoted.residuals import EventSet, residual_name

__all__ = ["BOOTSTRAP_RESAMPLES", "BOOTSTRAP_SEED", "CALIBRATION_THRESHOLD", "JACOBIANS", "METHODS", "RESIDUAL_FLOOR",
           "DampingSearch", "damping_problem", "finish_contact_damping", "fit_contact_damping",
           "start_contact_damping"]

#: Residual floor of the noise-free pipeline per residual, about twice the largest mean residual
#: measured at the true parameters on noise-free S2 recordings at 204.8 kHz (return-time and
#: cam-phase anchors, e/r_c 0.2 at 16 Hz and 0.25 at 15 Hz: lambda1 1.2e-5 .. 3.4e-5, lambda2
#: 1.0e-3 .. 1.24e-3, lambda3 1.8e-5 .. 2.4e-5).
RESIDUAL_FLOOR = {"lambda1": 7.0e-5, "lambda2": 2.5e-3, "lambda3": 5.0e-5}
#: Calibrated pipeline biases of alpha_m below this are left uncorrected (the noise-free pipeline's
#: own level at 204.8 kHz, a few 1e-6; half the lambda1 residual floor).
CALIBRATION_THRESHOLD = 0.5 * RESIDUAL_FLOOR["lambda1"]
#: Bootstrap resamples and the random seed (fixed: the same data give the same intervals).
BOOTSTRAP_RESAMPLES = 400
BOOTSTRAP_SEED = 20161122
#: Estimation methods: ``"least-squares"`` (trust-region Gauss-Newton, :mod:`impactid.engine.valley`),
#: ``"optimise"`` (nested bounded Brent along the valley), ``"grid"`` (the paper's grid search).
METHODS = ("least-squares", "optimise", "grid")
#: How the least-squares method differentiates the residuals (``fit_contact_damping(jacobian=...)``).
JACOBIANS = ("sensitivities", "differences")


def _no_progress(stage: str, fraction: float) -> None:
    return None


def fit_contact_damping(sets: EventSet | Sequence[EventSet], residual: str = "lambda1", *,
                        fix_n: float | None = None, method: str = "least-squares", grid: tuple[int, int] = (41, 21),
                        c_bounds: tuple[float, float] = C_BOUNDS, n_bounds: tuple[float, float] = N_BOUNDS,
                        landscape: bool = False, progress: Progress | None = None,
                        systematic: float = 0.0, residual_floor: float | None = None,
                        separability_width: float = SEPARABILITY_WIDTH, bootstrap_resamples: int = BOOTSTRAP_RESAMPLES,
                        bootstrap_seed: int = BOOTSTRAP_SEED, warn: bool = True,
                        jacobian: str = "sensitivities") -> DampingEstimate:
    """Estimate the Hunt–Crossley damping ``beta`` (and ``n`` unless ``fix_n``) from measured events.

    Parameters
    ----------
    sets : event sets of one or several recordings of the same rig (pooled: joint fit).
    residual : ``lambda1`` (default, accelerometer only), ``lambda2`` or ``lambda3``.
    fix_n : fix the exponent (1.5: Hunt–Crossley; 0: viscous).
    method : ``"least-squares"`` (default: trust-region Gauss–Newton with the profile along the valley,
        :mod:`impactid.engine.valley`), ``"optimise"`` (bounded Brent, profile over n, lattice and
        bootstrap intervals) or ``"grid"`` (the paper's grid search).
    grid : grid points ``(n_c, n_n)`` of the grid method (n_n ignored when n is fixed).
    c_bounds : bounds of ``c = beta delta_ref^n`` [N s/m]; n_bounds : bounds of ``n``.
    landscape : also compute the 41 x 41 objective landscape over the bounds (for plots).
    progress : callback ``(stage, fraction)`` for a progress display.
    systematic : a known systematic uncertainty of the residual (e.g. half a calibrated pipeline
        bias, :mod:`impactid.rigs.pivoted.calibration`): the indifference level of the intervals is at least this.
    residual_floor : the residual's noise floor (default :data:`RESIDUAL_FLOOR` of the residual); the
        indifference level of the intervals is at least this.
    separability_width : widest interval of ``n`` with which ``beta, n`` count as separable.
    bootstrap_resamples, bootstrap_seed : resamples of the events and the seed of the bootstrap.
    warn : issue an :class:`EstimationWarning` for each note (the result's ``warnings``); callers that
        carry the notes on pass False.
    jacobian : how the least-squares method differentiates the residuals: ``"sensitivities"``
        (default: the forward sensitivities the simulator integrates with each run; a point where a
        run has none, a sliding reversal in a contact with friction, is differenced instead) or
        ``"differences"`` (central differences of batched runs, the method before sensitivities).

    Returns
    -------
    DampingEstimate
        ``beta`` [N s m^-(n+1)], ``n``, their intervals, the valley, the per-event residuals, the notes.

    Raises
    ------
    ImpactidError : no events, or no finite objective anywhere in the bounds.
    ValueError : unknown residual or method, bad bounds.
    """
    return _finish(start_contact_damping(
        sets, residual, fix_n=fix_n, method=method, grid=grid, c_bounds=c_bounds, n_bounds=n_bounds,
        landscape=landscape, progress=progress, systematic=systematic, residual_floor=residual_floor,
        separability_width=separability_width, bootstrap_resamples=bootstrap_resamples,
        bootstrap_seed=bootstrap_seed, warn=warn, jacobian=jacobian), stacklevel=3)


@dataclass(frozen=True)
class DampingSearch:
    """A contact-damping fit whose search has ended (:func:`start_contact_damping`): its point estimate, and
    what :func:`finish_contact_damping` needs to make the :class:`DampingEstimate` (once).

    Attributes
    ----------
    beta : the estimate of ``beta`` [N s m^-(n+1)]; n : of ``n`` (the fixed one where fixed).
    residual : the residual fitted; n_simulations : S1 runs so far; seconds : time so far [s].
    """

    beta: float
    n: float
    residual: str
    n_simulations: int
    seconds: float
    problem: DampingProblem = field(repr=False)
    objective: DampingObjective = field(repr=False)
    found: LeastSquaresFit | DampingEstimate = field(repr=False)
    notes: list[str] = field(repr=False)
    progress: Progress = field(repr=False)
    warn: bool = True
    finished: list[bool] = field(default_factory=list, repr=False)  # [True] once finish_contact_damping ran


def start_contact_damping(sets: EventSet | Sequence[EventSet], residual: str = "lambda1", *,
                          fix_n: float | None = None, method: str = "least-squares",
                          grid: tuple[int, int] = (41, 21), c_bounds: tuple[float, float] = C_BOUNDS,
                          n_bounds: tuple[float, float] = N_BOUNDS, landscape: bool = False,
                          progress: Progress | None = None, systematic: float = 0.0,
                          residual_floor: float | None = None, separability_width: float = SEPARABILITY_WIDTH,
                          bootstrap_resamples: int = BOOTSTRAP_RESAMPLES, bootstrap_seed: int = BOOTSTRAP_SEED,
                          warn: bool = True, jacobian: str = "sensitivities") -> DampingSearch:
    """The first part of :func:`fit_contact_damping` (the same arguments): the search for the estimate, without
    its intervals, checks and diagnostics, which :func:`finish_contact_damping` adds.

    A calibrated estimate (:mod:`impactid.rigs.pivoted.estimation`) measures the pipeline's bias at the first
    estimate and, where it corrects the data, fits again: the first fit's intervals and checks would be
    discarded, and are not computed (on the 60 s benchmark recording, 0.4 s of the command's 5 s). The
    ``"optimise"`` and ``"grid"`` methods make their whole estimate here."""
    t_start = time.perf_counter()
    progress = progress or _no_progress
    residual = residual_name(residual)
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; valid: {', '.join(METHODS)}")
    if jacobian not in JACOBIANS:
        raise ValueError(f"unknown jacobian {jacobian!r}; valid: {', '.join(JACOBIANS)}")
    problem = damping_problem(sets, residual, fix_n=fix_n, c_bounds=c_bounds, n_bounds=n_bounds, landscape=landscape,
                              systematic=systematic, residual_floor=residual_floor,
                              separability_width=separability_width, bootstrap_resamples=bootstrap_resamples,
                              bootstrap_seed=bootstrap_seed)
    obj = problem.objective()
    notes: list[str] = [m for s in problem.sets for m in s.dropped]
    progress("search", 0.0)
    if method == "least-squares":
        try:
            found = gauss_newton_search(problem, obj, problem.indifference, notes, progress,
                                        sensitivities=jacobian == "sensitivities")
        except SimulationError as exc:
            raise ImpactidError(f"simulation failed inside the search bounds: {exc}") from exc
        beta_hat, n_hat = point_estimate(problem, obj, found)
    else:
        found = fit_by_search(problem, obj, method, grid, notes, progress)
        beta_hat, n_hat = found.beta, found.n
    return DampingSearch(beta=beta_hat, n=n_hat, residual=problem.residual, n_simulations=obj.n_simulations,
                         seconds=time.perf_counter() - t_start, problem=problem, objective=obj, found=found,
                         notes=notes, progress=progress, warn=warn)


def finish_contact_damping(search: DampingSearch) -> DampingEstimate:
    """The :class:`DampingEstimate` of a :func:`start_contact_damping`: the intervals, checks and diagnostics
    of its estimate (the same as :func:`fit_contact_damping`'s; its notes are warned where the search was
    started with ``warn``).

    Raises
    ------
    ValueError : the search was finished already (its notes and simulation count would be added twice).
    """
    return _finish(search, stacklevel=3)


def _finish(search: DampingSearch, stacklevel: int) -> DampingEstimate:
    """:func:`finish_contact_damping`, its warnings attributed ``stacklevel`` frames up (to the caller of the
    public function that was called)."""
    if search.finished:
        raise ValueError("this contact-damping search was finished already")
    search.finished.append(True)
    t_start = time.perf_counter()
    if isinstance(search.found, DampingEstimate):
        estimate = search.found
    else:
        try:
            estimate = least_squares_estimate(search.problem, search.objective, search.found, search.notes)
        except SimulationError as exc:
            raise ImpactidError(f"simulation failed inside the search bounds: {exc}") from exc
    search.progress("done", 1.0)
    for message in estimate.warnings if search.warn else ():
        warnings.warn(message, EstimationWarning, stacklevel=stacklevel)
    return replace(estimate, seconds=search.seconds + time.perf_counter() - t_start)


def damping_problem(sets: EventSet | Sequence[EventSet], residual: str = "lambda1", *, fix_n: float | None = None,
                    c_bounds: tuple[float, float] = C_BOUNDS, n_bounds: tuple[float, float] = N_BOUNDS,
                    landscape: bool = False, systematic: float = 0.0, residual_floor: float | None = None,
                    separability_width: float = SEPARABILITY_WIDTH, bootstrap_resamples: int = BOOTSTRAP_RESAMPLES,
                    bootstrap_seed: int = BOOTSTRAP_SEED) -> DampingProblem:
    """The validated :class:`~impactid.rigs.pivoted.damping_objective.DampingProblem` of a fit
    (the arguments as in :func:`fit_contact_damping`).

    Raises
    ------
    ImpactidError : no event sets.
    ValueError : unknown residual, bad bounds or fixed ``n``.
    RecordingError : an event set lacks what the residual needs.
    """
    sets = [sets] if isinstance(sets, EventSet) else list(sets)
    residual = residual_name(residual)
    if not sets:
        raise ImpactidError("no recordings to estimate from")
    for s in sets:
        s.require(residual)
    c_lo, c_hi = (float(x) for x in c_bounds)
    n_lo, n_hi = (float(x) for x in n_bounds)
    if not (0 < c_lo < c_hi and math.isfinite(c_hi)):
        raise ValueError(f"c bounds must satisfy 0 < low < high, got {c_bounds}")
    if fix_n is None and not (0 <= n_lo < n_hi and math.isfinite(n_hi)):
        raise ValueError(f"n bounds must satisfy 0 <= low < high, got {n_bounds}")
    if fix_n is not None and not (math.isfinite(fix_n) and fix_n >= 0):
        raise ValueError(f"fixed n must be finite and >= 0, got {fix_n}")
    return DampingProblem(
        sets=tuple(sets), residual=residual, fix_n=fix_n, log10_c_bounds=(math.log10(c_lo), math.log10(c_hi)),
        n_bounds=(n_lo, n_hi), delta_ref=reference_indentation(sets),
        residual_floor=RESIDUAL_FLOOR[residual] if residual_floor is None else float(residual_floor),
        systematic=float(systematic), separability_width=separability_width,
        bootstrap_resamples=bootstrap_resamples, bootstrap_seed=bootstrap_seed, landscape=landscape)

"""The ``"optimise"`` and ``"grid"`` methods of the contact-damping fit, with lattice intervals.

Steps, one function each:

1. the **scan** of the objective over ``(n, log10 c)`` (:func:`scan_objective`), 41 values of
   ``log10 c`` per ``n`` row (one row with ``n`` fixed; rows 0.05 apart in the joint fit);
2. the **valley**: the minimum over ``log10 c`` in each row, a bounded Brent search bracketed by the
   scan (:func:`trace_valley`);
3. the **point estimate**: the grid point of least objective (:func:`grid_estimate`), or a profile
   along the valley, a bounded Brent over ``n`` of the inner search (:func:`profile_estimate`);
4. the **lattice** about the valley (81 values of ``log10 c`` over +-0.1 decade, widened while the
   region reaches its edge) and from it the **bootstrap** over impacts and the **indifference region**
   (:func:`lattice_uncertainty`), combined into intervals (:func:`combined_intervals`);
5. the **cam-phase propagation**: each recording's cam phase shifted by its standard error and the
   fit repeated near the estimate (:func:`cam_phase_spread`), widening the intervals
   (:func:`widen_by_cam_phase`);
6. the **model check** and the **identifiability** block, as the least-squares method's
   (:mod:`~impactid.rigs.pivoted.damping_diagnostics`; without a Jacobian, the block reads ``n``'s
   profile from its interval).

Identifiability and the shared notes are :mod:`impactid.rigs.pivoted.damping_diagnostics`'.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy import interpolate, optimize

from impactid.errors import ImpactidError, SimulationError
from impactid.rigs.pivoted.damping_diagnostics import (
    apply_model_check,
    bound_notes,
    damping_model_check,
    failure_note,
    mark_reach,
    per_event_table,
    search_identifiability,
    separability,
    widen_interval,
)
from impactid.rigs.pivoted.damping_objective import DampingObjective, DampingProblem
from impactid.rigs.pivoted.estimate_results import DampingEstimate, Progress

__all__ = ["LATTICE_HALF_WIDTH", "LATTICE_POINTS", "LOGC_XTOL", "N_LATTICE_STEP", "N_XTOL", "SCAN_POINTS",
           "Indifference", "LatticeUncertainty", "Valley", "bootstrap_and_region", "cam_phase_spread",
           "combined_intervals", "fit_by_search", "grid_estimate", "indifference_at", "lattice_residuals",
           "lattice_rows", "lattice_uncertainty", "minimise_logc", "profile_estimate", "profile_fit", "scan_objective",
           "trace_valley", "widen_by_cam_phase"]

#: Values of ``log10 c`` of the scan that brackets each row's Brent search.
SCAN_POINTS = 41
#: Half-width [decades of c] of the lattice about the valley (first attempt; widened 5-fold while
#: the region or the bootstrap reaches its edge, twice at most).
LATTICE_HALF_WIDTH = 0.1
#: Values of ``log10 c`` per lattice row.
LATTICE_POINTS = 81
#: Spacing of the ``n`` rows of the scan and the lattice in a joint fit.
N_LATTICE_STEP = 0.05
#: Tolerances of the Brent searches: ``log10 c`` [decades] and ``n``.
LOGC_XTOL = 1e-7
N_XTOL = 1e-4


@dataclass(frozen=True)
class Valley:
    """The minimum of the objective over ``log10 c`` in each row of ``n``.

    Attributes
    ----------
    n : the rows' exponents.
    log10_c : ``log10 c`` [c in N s/m] of each row's minimum.
    objective : the mean residual there.
    """

    n: np.ndarray
    log10_c: np.ndarray
    objective: np.ndarray

    def centre(self) -> Callable[[float], float]:
        """``log10 c`` of the valley as a smooth function of ``n`` (cubic spline through the rows)."""
        return interpolate.CubicSpline(self.n, self.log10_c)

    def table(self, obj: DampingObjective) -> pd.DataFrame:
        """The valley as the table ``n, beta`` [N s m^-(n+1)] ``, log10_c, objective``."""
        return pd.DataFrame({"n": self.n, "beta": obj.beta(self.log10_c, self.n), "log10_c": self.log10_c,
                             "objective": self.objective})


@dataclass(frozen=True)
class Indifference:
    """The per-event residuals at the estimate and the indifference level of the mean residual.

    Attributes
    ----------
    per_event : residuals of the pooled events at the estimate (NaN where undefined).
    finite : where ``per_event`` is finite.
    standard_error : standard error of the mean absolute residual over the finite events.
    level : ``max(2 standard_error, floor, systematic)`` (inf with fewer than two events).
    """

    per_event: np.ndarray
    finite: np.ndarray
    standard_error: float
    level: float

    @property
    def events_used(self) -> int:
        """Events with a finite residual at the estimate."""
        return int(self.finite.sum())


@dataclass(frozen=True)
class LatticeUncertainty:
    """Bootstrap and indifference region from the lattice about the valley.

    Attributes
    ----------
    bootstrap : ``(resamples, 2)`` bootstrap estimates ``(beta, n)``.
    region : ``(beta_lo, beta_hi, n_lo, n_hi)`` of the indifference region (NaN when empty).
    reaches_edge : whether the region or a bootstrap estimate reaches the lattice's edge in ``log10 c``.
    half_width : the lattice's final half-width [decades of c].
    """

    bootstrap: np.ndarray
    region: tuple[float, float, float, float]
    reaches_edge: bool
    half_width: float


def fit_by_search(problem: DampingProblem, obj: DampingObjective, method: str, grid: tuple[int, int],
                  notes: list[str], progress: Progress) -> DampingEstimate:
    """The ``"optimise"`` or ``"grid"`` estimate of ``beta`` (and ``n``) with lattice intervals.

    Parameters
    ----------
    problem : the validated fit.
    obj : its objective (counts the simulations of the whole fit).
    method : ``"optimise"`` or ``"grid"``.
    grid : grid points ``(n_c, n_n)`` of the grid method.
    notes : the fit's notes, appended to.
    progress : callback ``(stage, fraction)``.

    Raises
    ------
    ImpactidError : a simulation failed in the scan, or the objective is undefined everywhere.
    """
    fix_n = problem.fix_n
    n_rows = lattice_rows(problem)
    scan = scan_objective(obj, n_rows, problem.log10_c_bounds)
    valley = trace_valley(obj, n_rows, scan, problem.log10_c_bounds, progress)
    if method == "grid":
        n_hat, logc_hat, j_hat = grid_estimate(obj, problem, n_rows, grid)
    elif fix_n is not None:
        n_hat, logc_hat, j_hat = float(fix_n), float(valley.log10_c[0]), float(valley.objective[0])
    else:
        n_hat, logc_hat, j_hat = profile_estimate(obj, problem, valley)
    progress("uncertainty", 0.65)

    indifference = indifference_at(obj, problem, logc_hat, n_hat)
    centre = valley.centre()(n_rows) if fix_n is None else np.array([logc_hat])
    lattice = lattice_uncertainty(obj, problem, n_rows, centre, indifference, j_hat)
    progress("uncertainty", 0.95)
    beta_hat = float(obj.beta(logc_hat, n_hat))
    b_boot, n_boot, beta_iv, n_iv = combined_intervals(lattice, beta_hat, n_hat, fixed_n=fix_n is not None)
    centre_of = valley.centre() if fix_n is None else (lambda n: logc_hat)
    phase_beta_sd, phase_n_sd = cam_phase_spread(obj, problem, centre_of, logc_hat, n_hat)
    progress("uncertainty", 0.99)
    beta_iv, n_iv = widen_by_cam_phase(problem, beta_iv, n_iv, beta_hat, n_hat, phase_beta_sd, phase_n_sd)
    if lattice.reaches_edge:
        notes.append(f"the {problem.residual} objective stays within {indifference.level:.3g} of its minimum beyond "
                     f"+-{lattice.half_width:.2g} decades of beta about the valley: beta is poorly determined by "
                     "these data")

    region = f"the mean {problem.residual} stays within {indifference.level:.3g} of its minimum"
    separable = separability(problem, n_iv, beta_iv, region, notes)
    bound_notes(problem, logc_hat, n_hat, notes)
    check, durations = damping_model_check(problem, indifference.per_event, n_params=1 if fix_n is not None else 2,
                                           beta=beta_hat, n=n_hat)
    beta_iv, n_iv, separable, model_block = apply_model_check(check, durations, beta_hat, n_hat, beta_iv, n_iv,
                                                              separable, notes)
    if indifference.level > 0.05:
        notes.append(f"the residual scatter between impacts is large (standard error of the mean "
                     f"{indifference.standard_error:.3g}); the estimate rests on {indifference.events_used} impacts")
    land = problem.landscape_if_asked()
    failure_note(obj, notes)
    block = search_identifiability(problem, separable, n_iv, check.describes_data)
    mark_reach(block, beta_hat, beta_iv, notes)
    return DampingEstimate(
        beta=beta_hat, n=n_hat, fixed_n=fix_n is not None, residual=problem.residual, objective=j_hat, method=method,
        beta_interval=beta_iv, n_interval=n_iv, beta_bootstrap_interval=(float(b_boot[0]), float(b_boot[1])),
        n_bootstrap_interval=(float(n_boot[0]), float(n_boot[1])), indifference=indifference.level,
        separable=separable, phase_beta_sd=phase_beta_sd, phase_n_sd=phase_n_sd, valley=valley.table(obj),
        per_event=per_event_table(problem, indifference.per_event), delta_ref=problem.delta_ref,
        bootstrap=lattice.bootstrap, landscape=land, n_simulations=obj.n_simulations, seconds=math.nan,
        warnings=tuple(notes), n_failed_simulations=obj.n_failed, model_check=model_block,
        identifiability=block)


# ---------------------------------------------------------------------------------------------
# scan, valley, point estimate
# ---------------------------------------------------------------------------------------------


def lattice_rows(problem: DampingProblem) -> np.ndarray:
    """The ``n`` rows of the scan and the lattice: the fixed ``n``, or at least 5 rows about
    :data:`N_LATTICE_STEP` apart over the bounds."""
    if problem.fix_n is not None:
        return np.array([float(problem.fix_n)])
    n_lo, n_hi = problem.n_bounds
    count = int(round((n_hi - n_lo) / N_LATTICE_STEP)) + 1
    return np.linspace(n_lo, n_hi, max(count, 5))


def scan_objective(obj: DampingObjective, n_rows: np.ndarray, lc_bounds: tuple[float, float]) -> np.ndarray:
    """The objective on :data:`SCAN_POINTS` values of ``log10 c`` over the bounds per row: ``(rows, 41)``.

    Raises
    ------
    ImpactidError : a simulation failed, or the residual is undefined for every event.
    """
    c_scan = np.linspace(lc_bounds[0], lc_bounds[1], SCAN_POINTS)
    nn, cc = np.meshgrid(n_rows, c_scan, indexing="ij")
    try:
        scan = obj.mean(obj.per_event(cc.ravel(), nn.ravel())).reshape(nn.shape)
    except SimulationError as exc:
        raise ImpactidError(f"simulation failed inside the search bounds: {exc}") from exc
    if not np.any(np.isfinite(scan)):
        raise ImpactidError(f"the {obj.residual} residual is undefined for every event (no usable contact data)")
    return scan


def minimise_logc(obj: DampingObjective, n: float, lo: float, hi: float,
                  scan: np.ndarray | None = None) -> tuple[float, float]:
    """Bounded Brent search of ``log10 c`` in ``[lo, hi]`` at fixed ``n``, bracketed by a scan
    (computed here when not given). Returns ``(log10 c, J)``."""
    grid = np.linspace(lo, hi, SCAN_POINTS)
    if scan is None:
        scan = obj.mean(obj.per_event(grid, n))
    k = int(np.argmin(scan))
    a, b = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
    res = optimize.minimize_scalar(lambda x: obj(x, n), bounds=(a, b), method="bounded",
                                   options={"xatol": LOGC_XTOL})
    if res.fun <= scan[k]:
        return float(res.x), float(res.fun)
    return float(grid[k]), float(scan[k])


def trace_valley(obj: DampingObjective, n_rows: np.ndarray, scan: np.ndarray, lc_bounds: tuple[float, float],
                 progress: Progress) -> Valley:
    """The valley: each row's minimum over ``log10 c`` (:func:`minimise_logc` on the row's scan)."""
    valley_c = np.empty(n_rows.size)
    valley_j = np.empty(n_rows.size)
    for k, n in enumerate(n_rows):
        valley_c[k], valley_j[k] = minimise_logc(obj, float(n), lc_bounds[0], lc_bounds[1], scan[k])
        progress("valley", 0.6 * (k + 1) / n_rows.size)
    return Valley(n=n_rows, log10_c=valley_c, objective=valley_j)


def grid_estimate(obj: DampingObjective, problem: DampingProblem, n_rows: np.ndarray,
                  grid: tuple[int, int]) -> tuple[float, float, float]:
    """The paper's grid search: the grid point of least objective, ``(n, log10 c, J)``.

    ``grid`` is ``(n_c, n_n)`` points over the bounds; with ``n`` fixed the rows are ``n_rows``.
    """
    lc_lo, lc_hi = problem.log10_c_bounds
    gc = np.linspace(lc_lo, lc_hi, int(grid[0]))
    gn = n_rows if problem.fix_n is not None else np.linspace(*problem.n_bounds, int(grid[1]))
    gnn, gcc = np.meshgrid(gn, gc, indexing="ij")
    values = obj.mean(obj.per_event(gcc.ravel(), gnn.ravel())).reshape(gnn.shape)
    i, j = np.unravel_index(int(np.argmin(values)), values.shape)
    return float(gn[i]), float(gc[j]), float(values[i, j])


def profile_estimate(obj: DampingObjective, problem: DampingProblem, valley: Valley) -> tuple[float, float, float]:
    """The joint estimate ``(n, log10 c, J)``: a profile along the valley between the rows either side
    of its least row, within 0.05 decade of it in ``log10 c`` (the row itself if that is better)."""
    k = int(np.argmin(valley.objective))
    n_rows = valley.n
    a, b = n_rows[max(k - 1, 0)], n_rows[min(k + 1, n_rows.size - 1)]
    logc_hat, n_hat, j_hat = profile_fit(obj, valley.centre(), problem.log10_c_bounds, 0.05, n_range=(a, b))
    if valley.objective[k] < j_hat:
        return float(n_rows[k]), float(valley.log10_c[k]), float(valley.objective[k])
    return n_hat, logc_hat, j_hat


def profile_fit(obj: DampingObjective, centre_of: Callable[[float], float], lc_bounds: tuple[float, float],
                c_half: float, *, n_range: tuple[float, float] | None = None,
                fix_n: float | None = None) -> tuple[float, float, float]:
    """Nested bounded Brent: ``log10 c`` within ``c_half`` decades of ``centre_of(n)`` (the valley),
    inside a search of ``n`` over ``n_range`` (a profile along the valley; ``fix_n`` instead of
    ``n_range`` for the inner search alone). Returns ``(log10 c, n, J)``."""
    found: dict[float, tuple[float, float]] = {}

    def inner(n: float) -> float:
        c0 = float(centre_of(n))
        res = optimize.minimize_scalar(lambda x: obj(x, n), method="bounded", options={"xatol": LOGC_XTOL},
                                       bounds=(max(c0 - c_half, lc_bounds[0]), min(c0 + c_half, lc_bounds[1])))
        found[n] = (float(res.x), float(res.fun))
        return float(res.fun)

    if n_range is None:
        n = float(fix_n)
    else:
        n = float(optimize.minimize_scalar(inner, bounds=n_range, method="bounded", options={"xatol": N_XTOL}).x)
    if n not in found:
        inner(n)
    return found[n][0], n, found[n][1]


# ---------------------------------------------------------------------------------------------
# uncertainty: lattice, bootstrap, indifference region, cam phase
# ---------------------------------------------------------------------------------------------


def indifference_at(obj: DampingObjective, problem: DampingProblem, logc_hat: float, n_hat: float) -> Indifference:
    """The per-event residuals at the estimate and the level ``Delta = max(2 SE, floor, systematic)``
    within which the mean residual counts as indifferent (``SE``: standard error of the mean)."""
    per_event_hat = obj.per_event(logc_hat, n_hat)[0]
    finite = np.isfinite(per_event_hat)
    n_used = int(finite.sum())
    se = float(np.std(np.abs(per_event_hat[finite]), ddof=1) / math.sqrt(n_used)) if n_used > 1 else math.inf
    level = max(2.0 * se, problem.indifference) if math.isfinite(se) else math.inf
    return Indifference(per_event=per_event_hat, finite=finite, standard_error=se, level=level)


def lattice_uncertainty(obj: DampingObjective, problem: DampingProblem, n_rows: np.ndarray, centre: np.ndarray,
                        indifference: Indifference, j_hat: float) -> LatticeUncertainty:
    """Bootstrap and indifference region on a lattice about the valley ``centre`` (``log10 c`` per row),
    widened 5-fold (twice at most) while they reach its edge."""
    half = LATTICE_HALF_WIDTH
    for attempt in range(3):
        u = np.linspace(-half, half, LATTICE_POINTS)
        lat = lattice_residuals(obj, n_rows, centre, u)
        boot, region, edge = bootstrap_and_region(lat, n_rows, centre, u, obj, indifference.finite, j_hat,
                                                  indifference.level, problem.bootstrap_resamples,
                                                  problem.bootstrap_seed)
        if not edge or attempt == 2:
            break
        half *= 5.0
    return LatticeUncertainty(bootstrap=boot, region=region, reaches_edge=edge, half_width=half)


def lattice_residuals(obj: DampingObjective, n_rows: np.ndarray, centre: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Per-event residuals on the lattice ``(n_rows, u)``, ``log10 c = centre(n) + u``: shape ``(K, U, N)``."""
    nn = np.repeat(n_rows, u.size)
    cc = (centre[:, None] + u[None, :]).ravel()
    return obj.per_event(cc, nn).reshape(n_rows.size, u.size, -1)


def bootstrap_and_region(lat: np.ndarray, n_rows: np.ndarray, centre: np.ndarray, u: np.ndarray,
                         obj: DampingObjective, finite: np.ndarray, j_hat: float, indifference: float,
                         resamples: int, seed: int) -> tuple[np.ndarray, tuple[float, ...], bool]:
    """Bootstrap estimates ``(beta, n)``, the indifference region ``(beta_lo, beta_hi, n_lo, n_hi)``, and
    whether either reaches the edge of the lattice in ``u``.

    The per-event residuals are interpolated (cubic splines, signed: smooth in both coordinates)
    onto a fine grid; a second pass zooms the fine grid onto the box that holds the region and the
    bootstrap estimates, so that narrow intervals are resolved (201 x 161 points over the box).
    """
    lat = lat[:, :, finite]
    n_ev = lat.shape[2]
    spline_u = interpolate.CubicSpline(u, lat, axis=1)
    spline_c = interpolate.CubicSpline(n_rows, centre) if n_rows.size > 1 else None
    rng = np.random.default_rng(seed)
    weights = rng.multinomial(n_ev, np.full(n_ev, 1.0 / n_ev), size=resamples) / n_ev
    u_box, n_box = (u[0], u[-1]), (n_rows[0], n_rows[-1])
    for _ in range(2):
        u_fine = np.linspace(*u_box, 201)
        fine = spline_u(u_fine)  # (K, U', N)
        if spline_c is not None:
            n_fine = np.linspace(*n_box, 161)
            fine = interpolate.CubicSpline(n_rows, fine, axis=0)(n_fine)
            c_fine = spline_c(n_fine)
        else:
            n_fine, c_fine = n_rows, centre
        absval = np.abs(fine).reshape(-1, n_ev)
        full = absval.mean(axis=1)
        ui = np.tile(np.arange(u_fine.size), n_fine.size)
        ni = np.repeat(np.arange(n_fine.size), u_fine.size)
        level = min(j_hat, float(full.min())) + indifference
        inside = np.flatnonzero(full <= level)
        best = np.argmin(weights @ absval.T, axis=1)
        pts = np.concatenate([inside, best])
        u_lo, u_hi = u_fine[max(ui[pts].min() - 2, 0)], u_fine[min(ui[pts].max() + 2, u_fine.size - 1)]
        n_lo, n_hi = n_fine[max(ni[pts].min() - 2, 0)], n_fine[min(ni[pts].max() + 2, n_fine.size - 1)]
        u_box, n_box = (u_lo, u_hi), (n_lo, n_hi)
    logc = c_fine[ni] + u_fine[ui]
    ngrid = n_fine[ni]
    beta = obj.beta(logc, ngrid)
    region = ((float(beta[inside].min()), float(beta[inside].max()), float(ngrid[inside].min()),
               float(ngrid[inside].max())) if inside.size else (math.nan,) * 4)
    boot = np.column_stack([beta[best], ngrid[best]])
    u_all = u_fine[ui[np.concatenate([inside, best])]]
    edge = bool(np.any((u_all <= u[0]) | (u_all >= u[-1])))
    return boot, region, edge


def combined_intervals(lattice: LatticeUncertainty, beta_hat: float, n_hat: float, *, fixed_n: bool):
    """The 95 % bootstrap percentiles and the hulls of them, the indifference region and the estimate.

    Returns
    -------
    beta_bootstrap, n_bootstrap : 2.5 and 97.5 percentiles (NaN without bootstrap estimates).
    beta_interval : ``(lo, hi)`` [N s m^-(n+1)]; n_interval : ``(lo, hi)`` (``(n, n)`` with ``n`` fixed).
    """
    boot, region = lattice.bootstrap, lattice.region
    b_boot = np.percentile(boot[:, 0], [2.5, 97.5]) if boot.size else np.array([math.nan, math.nan])
    n_boot = np.percentile(boot[:, 1], [2.5, 97.5]) if boot.size else np.array([math.nan, math.nan])
    beta_iv = (float(min(b_boot[0], region[0], beta_hat)), float(max(b_boot[1], region[1], beta_hat)))
    if fixed_n:
        n_iv = (n_hat, n_hat)
    else:
        n_iv = (float(min(n_boot[0], region[2], n_hat)), float(max(n_boot[1], region[3], n_hat)))
    return b_boot, n_boot, beta_iv, n_iv


def cam_phase_spread(obj: DampingObjective, problem: DampingProblem, centre_of: Callable[[float], float],
                     logc_hat: float, n_hat: float) -> tuple[float, float]:
    """Standard deviations of ``beta`` [N s m^-(n+1)] and ``n`` caused by the cam phases' errors.

    The common-mode error of each recording's cam phase (cam-phase anchor; recordings without a
    phase error contribute nothing), by linear propagation: the phase is shifted by its standard
    error and the fit repeated within 0.1 decade of the valley (``n`` within 0.15 of the estimate);
    the shifts are combined in quadrature. The repeated fits' simulations count in ``obj``.
    """
    sets, fix_n = problem.sets, problem.fix_n
    n_lo, n_hi = problem.n_bounds
    phase_beta_sd = phase_n_sd = 0.0
    for k, es in enumerate(sets):
        if not (math.isfinite(es.phase_stderr) and es.phase_stderr > 0):
            continue
        shifted = list(sets)
        shifted[k] = es.shift_phase(es.phase_stderr)
        sub = problem.objective(shifted)
        n_range = None if fix_n is not None else (max(n_hat - 0.15, n_lo), min(n_hat + 0.15, n_hi))
        lc2, n2, _ = profile_fit(sub, centre_of, problem.log10_c_bounds, 0.1, n_range=n_range, fix_n=fix_n)
        obj.n_simulations += sub.n_simulations
        obj.n_failed += sub.n_failed
        phase_beta_sd = math.hypot(phase_beta_sd, float(obj.beta(lc2, n2)) - float(obj.beta(logc_hat, n_hat)))
        phase_n_sd = math.hypot(phase_n_sd, n2 - n_hat)
    return phase_beta_sd, phase_n_sd


def widen_by_cam_phase(problem: DampingProblem, beta_interval: tuple[float, float], n_interval: tuple[float, float],
                       beta_hat: float, n_hat: float, phase_beta_sd: float, phase_n_sd: float):
    """The intervals widened by 1.96 cam-phase standard deviations in quadrature: ``beta`` in log space
    (it is positive and was searched on a log scale, and shifts multiplicatively along the valley),
    ``n`` clipped to its bounds. Returns ``(beta_interval, n_interval)``."""
    log_iv = widen_interval((math.log(beta_interval[0]), math.log(beta_interval[1])), math.log(beta_hat),
                            1.96 * math.log1p(phase_beta_sd / beta_hat))
    beta_iv = (math.exp(log_iv[0]), math.exp(log_iv[1]))
    if problem.fix_n is not None:
        return beta_iv, n_interval
    n_iv = widen_interval(n_interval, n_hat, 1.96 * phase_n_sd)
    return beta_iv, (max(n_iv[0], problem.n_bounds[0]), min(n_iv[1], problem.n_bounds[1]))

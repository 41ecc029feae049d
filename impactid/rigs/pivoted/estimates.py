"""Estimates: Hunt–Crossley damping ``beta, n`` and restitution laws (Sundar, Dreyer & Singh 2016, sections 5.2, 6-8).

Contact damping
---------------
The estimate minimises the paper's objective, the **mean residual over events** ``J(beta, n)``
(``|lambda1|`` by default; :mod:`impactid.rigs.pivoted.residuals`), pooling the events of every recording
given (a joint fit over operating points).

Search coordinates. ``beta`` and ``n`` trade off along a long curved valley: a change of ``n``
by 0.5 moves the matching ``beta`` by a factor ``delta^-0.5`` (~150 at the rig's 40 um
indentations). The search therefore runs in ``(log10 c, n)`` with ``c = beta delta_ref^n``
[N s/m], the damping coefficient at a reference indentation ``delta_ref`` (the median measured
peak indentation). In these coordinates the valley is nearly straight and a box of bounds
contains it (default ``c`` in [1, 1e6] N s/m, ``n`` in [0.5, 2.5]); results are reported in
``beta`` [N s m^-(n+1)].

Methods. ``"least-squares"`` (default): the per-event residual vector minimised by a
trust-region Gauss–Newton method, with the Gauss–Newton covariance and the profile along the
valley for the intervals (:mod:`impactid.gauss_newton`, where its interval rules are stated).
``"optimise"``: for each ``n`` a bounded Brent search of ``log10 c``, bracketed by a 41-point
scan; for the joint fit the same inner search inside an outer bounded Brent over ``n`` (a
profile: it follows the valley by construction, so its curvature cannot stall it).
``"grid"``: the paper's grid search, the grid point of least objective. On the validation cases
the least-squares method agrees with the optimiser within both methods' intervals at about a
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
:data:`SEPARABILITY_WIDTH` or reaches a search bound, ``beta`` and ``n`` are declared not
separable: a warning says so, with the valley, and the joint point estimate must not be read as
precise (fix ``n`` or fit several operating points jointly).

Restitution
-----------
``xi`` and ``v_a`` per impact come from the reconstruction (docs/estimation.md); ``gamma`` of
``xi = 1 - gamma v_a`` by least squares through the law's fixed intercept, the constant-``r``
fit, a free-intercept line (to test the law), ``xi_mean``, ``va_mean`` and the Hunt–Crossley
equivalent ``beta = 1.5 gamma k_H``.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy import interpolate, optimize

from impactid.errors import ImpactidError, SimulationError
from impactid.results import FitResult, Parameter
from impactid.rigs.pivoted.residuals import EventSet, residual_name

__all__ = ["ALIKE_SPREAD", "BOOTSTRAP_RESAMPLES", "BOOTSTRAP_SEED", "CALIBRATION_THRESHOLD", "C_BOUNDS", "METHODS",
           "N_BOUNDS", "RESIDUAL_FLOOR", "SEPARABILITY_WIDTH", "ContactDampingResult", "DampingEstimate", "Estimate",
           "EstimationWarning", "Landscape", "Progress", "RestitutionEstimate", "RestitutionResult",
           "fit_contact_damping", "fit_restitution", "objective_landscape", "reference_indentation"]

#: Default search bounds: damping at the reference indentation ``c`` [N s/m] and exponent ``n``.
C_BOUNDS = (1.0, 1.0e6)
N_BOUNDS = (0.5, 2.5)
#: Residual floor of the noise-free pipeline per residual, about twice the largest mean residual
#: measured at the true parameters on noise-free S2 recordings at 204.8 kHz (return-time and
#: cam-phase anchors, e/r_c 0.2 at 16 Hz and 0.25 at 15 Hz: lambda1 1.2e-5 .. 3.4e-5, lambda2
#: 1.0e-3 .. 1.24e-3, lambda3 1.8e-5 .. 2.4e-5).
RESIDUAL_FLOOR = {"lambda1": 7.0e-5, "lambda2": 2.5e-3, "lambda3": 5.0e-5}
#: Widest ``n`` interval for which ``beta`` and ``n`` count as separable.
SEPARABILITY_WIDTH = 0.25
#: Relative spread (std/mean) of approach speeds below which impacts count as "all alike".
ALIKE_SPREAD = 0.02
#: Bootstrap resamples and the random seed (fixed: the same data give the same intervals).
BOOTSTRAP_RESAMPLES = 400
BOOTSTRAP_SEED = 20161122
#: Estimation methods: ``"least-squares"`` (trust-region Gauss-Newton, :mod:`impactid.gauss_newton`),
#: ``"optimise"`` (nested bounded Brent along the valley), ``"grid"`` (the paper's grid search).
METHODS = ("least-squares", "optimise", "grid")
#: How the least-squares method differentiates the residuals (``fit_contact_damping(jacobian=...)``).
JACOBIANS = ("sensitivities", "differences")

_SCAN_POINTS = 41
_LATTICE_HALF_WIDTH = 0.1  # decades of c around the valley
_LATTICE_POINTS = 81
_N_LATTICE_STEP = 0.05
_LOGC_XTOL = 1e-7
_N_XTOL = 1e-4


class EstimationWarning(UserWarning):
    """The data do not support (part of) an estimate as precisely as its number suggests."""


Progress = Callable[[str, float], None]


def _no_progress(stage: str, fraction: float) -> None:
    return None


# ---------------------------------------------------------------------------------------------
# objective
# ---------------------------------------------------------------------------------------------


class _Objective:
    """Mean residual over the pooled events of several event sets, in (log10 c, n)."""

    def __init__(self, sets: Sequence[EventSet], residual: str, delta_ref: float):
        self.sets = list(sets)
        self.residual = residual
        self.delta_ref = delta_ref
        self.n_simulations = 0
        self.n_failed = 0  # S1 runs that could not be simulated (penalised, see residuals)
        self.n_events = sum(len(s) for s in self.sets)

    def beta(self, logc, n):
        return np.power(10.0, logc) / np.power(self.delta_ref, n)

    def per_event(self, logc, n) -> np.ndarray:
        """Per-event residuals, shape (m, n_events), for m points (arrays broadcast)."""
        logc, n = np.broadcast_arrays(np.atleast_1d(np.asarray(logc, dtype=float)),
                                      np.atleast_1d(np.asarray(n, dtype=float)))
        trials = np.column_stack([self.beta(logc, n), n])
        self.n_simulations += trials.shape[0] * self.n_events
        parts = [s.residuals_and_failures(trials, self.residual) for s in self.sets]
        self.n_failed += int(sum(int(f.sum()) for _, f in parts))
        return np.concatenate([r for r, _ in parts], axis=1)

    def per_event_and_jacobian(self, logc, n) -> tuple[np.ndarray, np.ndarray]:
        """Per-event residuals ``(k, n_events)`` and their derivatives ``(k, n_events, 2)`` by
        ``(log10 c, n)``, from the simulator's forward sensitivities (one run per trial and event).

        The kernel differentiates by ``(ln beta, n)`` with ``beta`` held; with
        ``ln beta = ln(10) log10 c - n ln(delta_ref)``::

            dr/dlog10 c = ln(10) dr/dln beta,    dr/dn (c held) = dr/dn (beta held) - ln(delta_ref) dr/dln beta
        """
        logc, n = np.broadcast_arrays(np.atleast_1d(np.asarray(logc, dtype=float)),
                                      np.atleast_1d(np.asarray(n, dtype=float)))
        trials = np.column_stack([self.beta(logc, n), n])
        self.n_simulations += trials.shape[0] * self.n_events
        parts = [s.residuals_and_jacobian(trials, self.residual) for s in self.sets]
        self.n_failed += int(sum(int(f.sum()) for _, _, f in parts))
        r = np.concatenate([p[0] for p in parts], axis=1)
        by_law = np.concatenate([p[1] for p in parts], axis=1)
        jac = np.empty_like(by_law)
        jac[..., 0] = math.log(10.0) * by_law[..., 0]
        jac[..., 1] = by_law[..., 1] - math.log(self.delta_ref) * by_law[..., 0]
        return r, jac

    @staticmethod
    def mean(per_event: np.ndarray) -> np.ndarray:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            out = np.nanmean(np.abs(per_event), axis=-1)
        return np.where(np.isfinite(out), out, np.inf)

    def __call__(self, logc: float, n: float) -> float:
        return float(self.mean(self.per_event(logc, n))[0])


def _minimise_logc(obj: _Objective, n: float, lo: float, hi: float,
                   scan: np.ndarray | None = None) -> tuple[float, float]:
    """Bounded Brent search of log10 c at fixed n, bracketed by a scan. Returns (log10 c, J)."""
    grid = np.linspace(lo, hi, _SCAN_POINTS)
    if scan is None:
        scan = obj.mean(obj.per_event(grid, n))
    k = int(np.argmin(scan))
    a, b = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
    res = optimize.minimize_scalar(lambda x: obj(x, n), bounds=(a, b), method="bounded",
                                   options={"xatol": _LOGC_XTOL})
    if res.fun <= scan[k]:
        return float(res.x), float(res.fun)
    return float(grid[k]), float(scan[k])


# ---------------------------------------------------------------------------------------------
# results
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Landscape:
    """Mean residual on a grid: ``objective[i, j]`` at ``n[i]``, ``beta[i, j]`` (log-spaced in c)."""

    n: np.ndarray
    log10_c: np.ndarray
    beta: np.ndarray
    objective: np.ndarray
    residual: str


class ContactDampingResult(FitResult):
    """Hunt–Crossley damping ``beta, n`` of :func:`fit_contact_damping` as a shared fit result."""

    kind = "contact-damping"
    title = "Hunt-Crossley contact damping"


class RestitutionResult(FitResult):
    """Restitution laws of :func:`fit_restitution` as a shared fit result."""

    kind = "restitution"
    title = "restitution xi = 1 - gamma v_a"


@dataclass(frozen=True)
class DampingEstimate:
    """Hunt–Crossley damping estimate.

    Attributes
    ----------
    beta : [N s m^-(n+1)]; n : exponent (fixed or estimated).
    residual : name of the residual minimised; objective : its mean over events at the estimate.
    beta_interval, n_interval : (low, high) intervals (see module doc; ``n_interval`` is
        ``(n, n)`` when ``n`` was fixed).
    separable : whether the data separate beta from n (None when n was fixed).
    valley : DataFrame ``n, beta, objective`` of the minimum over beta at each n (joint fits).
    per_event : DataFrame ``source, event, approach_speed, residual`` at the estimate.
    delta_ref : reference indentation [m]; c = beta delta_ref^n is the damping there [N s/m].
    bootstrap : (n_resamples, 2) bootstrap estimates (beta, n).
    phase_beta_sd, phase_n_sd : standard deviations of beta and n caused by the error of each
        recording's cam phase (cam-phase anchor; 0 otherwise), already included in the intervals.
    """

    beta: float
    n: float
    fixed_n: bool
    residual: str
    objective: float
    method: str
    beta_interval: tuple[float, float]
    n_interval: tuple[float, float]
    beta_bootstrap_interval: tuple[float, float]
    n_bootstrap_interval: tuple[float, float]
    indifference: float
    separable: bool | None
    phase_beta_sd: float
    phase_n_sd: float
    valley: pd.DataFrame
    per_event: pd.DataFrame
    delta_ref: float
    bootstrap: np.ndarray
    landscape: Landscape | None
    n_simulations: int
    seconds: float
    warnings: tuple[str, ...] = ()
    #: S1 runs (trial law x event) that could not be simulated and got the documented penalty
    n_failed_simulations: int = 0
    #: Gauss-Newton standard errors of beta and n (least-squares method; NaN otherwise)
    beta_stderr: float = math.nan
    n_stderr: float = math.nan

    @property
    def damping_at_reference(self) -> float:
        """``c = beta delta_ref^n`` [N s/m]."""
        return self.beta * self.delta_ref ** self.n

    def to_result(self) -> ContactDampingResult:
        """The estimate as a shared :class:`~impactid.results.FitResult` (report, JSON round trip, tables)."""
        unit = f"N s m^-({self.n:.4g}+1)"
        why = "" if self.separable in (None, True) else "beta and n are not separable from these data"
        params = [Parameter("beta", self.beta, interval=self.beta_interval, unit=unit, note=why),
                  Parameter("n", self.n, stderr=0.0 if self.fixed_n else math.nan,
                            interval=(self.n, self.n) if self.fixed_n else self.n_interval, fixed=self.fixed_n,
                            note=why)]
        statistics = {"residual": self.residual, "objective": self.objective, "indifference": self.indifference,
                      "events": int(np.isfinite(self.per_event["residual"]).sum()), "simulations": self.n_simulations,
                      "failed_simulations": self.n_failed_simulations, "seconds": self.seconds}
        details = {"method": self.method, "separable": self.separable, "delta_ref": self.delta_ref,
                   "c_ref": self.damping_at_reference, "beta_bootstrap_95": list(self.beta_bootstrap_interval),
                   "n_bootstrap_95": list(self.n_bootstrap_interval)}
        return ContactDampingResult(params=params, statistics=statistics, notes=self.warnings,
                                    tables={"per_event": self.per_event, "valley": self.valley}, details=details)

    def report(self) -> str:
        """An lmfit-style fit report (of :meth:`to_result`)."""
        return self.to_result().report()


@dataclass(frozen=True)
class RestitutionEstimate:
    """Restitution law fits over impacts (docs/estimation.md).

    ``gamma`` [s/m] of ``xi = 1 - gamma v_a`` (least squares, intercept fixed at 1) with its
    standard error; ``r_constant`` the constant-r fit (mean xi) with its standard error;
    ``intercept``/``slope`` of the free line ``xi = a - b v_a`` (NaN when the speeds do not
    spread); ``beta_equivalent = 1.5 gamma k_H`` [N s m^-2.5]; ``va_spread`` = std/mean of v_a.
    """

    gamma: float
    gamma_stderr: float
    r_constant: float
    r_constant_stderr: float
    intercept: float
    intercept_stderr: float
    slope: float
    slope_stderr: float
    xi_mean: float
    va_mean: float
    va_spread: float
    beta_equivalent: float
    impacts_used: int
    per_impact: pd.DataFrame
    warnings: tuple[str, ...] = ()

    def to_result(self) -> RestitutionResult:
        """The fit as a shared :class:`~impactid.results.FitResult` (report, JSON round trip, tables)."""
        def ci(value, stderr):
            return (value - 1.96 * stderr, value + 1.96 * stderr)

        params = [Parameter("gamma", self.gamma, self.gamma_stderr, ci(self.gamma, self.gamma_stderr), unit="s/m"),
                  Parameter("r_constant", self.r_constant, self.r_constant_stderr,
                            ci(self.r_constant, self.r_constant_stderr)),
                  Parameter("intercept", self.intercept, self.intercept_stderr,
                            ci(self.intercept, self.intercept_stderr)),
                  Parameter("slope", self.slope, self.slope_stderr, ci(self.slope, self.slope_stderr), unit="s/m")]
        statistics = {"impacts": self.impacts_used, "xi_mean": self.xi_mean, "va_mean": self.va_mean,
                      "va_spread": self.va_spread}
        return RestitutionResult(params=params, statistics=statistics, notes=self.warnings,
                                 tables={"per_impact": self.per_impact},
                                 details={"beta_equivalent_n1.5": self.beta_equivalent})

    def report(self) -> str:
        """An lmfit-style fit report (of :meth:`to_result`)."""
        return self.to_result().report()



# ---------------------------------------------------------------------------------------------
# contact damping
# ---------------------------------------------------------------------------------------------


def reference_indentation(sets: Sequence[EventSet]) -> float:
    """Median measured peak indentation over all events [m] (1e-5 m if none is positive)."""
    values = np.concatenate([s.peak_indentation for s in sets]) if sets else np.empty(0)
    values = values[np.isfinite(values) & (values > 0)]
    return float(np.median(values)) if values.size else 1e-5


def objective_landscape(sets: Sequence[EventSet], residual: str = "lambda1", *, n_values=None, c_values=None,
                        delta_ref: float | None = None) -> Landscape:
    """Mean residual over a (n, c) grid (one batch simulation). Defaults: 41 x 41 over the default bounds."""
    residual = residual_name(residual)
    delta_ref = reference_indentation(sets) if delta_ref is None else float(delta_ref)
    obj = _Objective(sets, residual, delta_ref)
    n_values = np.linspace(*N_BOUNDS, 41) if n_values is None else np.atleast_1d(np.asarray(n_values, float))
    logc = np.log10(np.geomspace(*C_BOUNDS, 41) if c_values is None else np.asarray(c_values, float))
    nn, cc = np.meshgrid(n_values, logc, indexing="ij")
    values = obj.mean(obj.per_event(cc.ravel(), nn.ravel())).reshape(nn.shape)
    return Landscape(n=n_values, log10_c=logc, beta=obj.beta(cc, nn), objective=values, residual=residual)


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
        :mod:`impactid.gauss_newton`), ``"optimise"`` (bounded Brent, profile over n, lattice and
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
    bootstrap_resamples, bootstrap_seed : resamples of the events and the paper of the bootstrap.
    warn : issue an :class:`EstimationWarning` for each note (the result's ``warnings``); callers that
        carry the notes on pass False.
    jacobian : how the least-squares method differentiates the residuals: ``"sensitivities"``
        (default: the forward sensitivities the simulator integrates with each run; a point where a
        run has none, a sliding reversal in a contact with friction, is differenced instead) or
        ``"differences"`` (central differences of batched runs, the method before sensitivities).

    Raises
    ------
    ImpactidError : no events, or no finite objective anywhere in the bounds.
    ValueError : unknown residual or method, bad bounds.
    """
    t_start = time.perf_counter()
    progress = progress or _no_progress
    sets = [sets] if isinstance(sets, EventSet) else list(sets)
    residual = residual_name(residual)
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; valid: {', '.join(METHODS)}")
    if jacobian not in JACOBIANS:
        raise ValueError(f"unknown jacobian {jacobian!r}; valid: {', '.join(JACOBIANS)}")
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
    delta_ref = reference_indentation(sets)
    obj = _Objective(sets, residual, delta_ref)
    lc_lo, lc_hi = math.log10(c_lo), math.log10(c_hi)
    notes: list[str] = [m for s in sets for m in s.dropped]
    progress("search", 0.0)
    floor = RESIDUAL_FLOOR[residual] if residual_floor is None else float(residual_floor)
    if method == "least-squares":
        try:
            return _fit_least_squares(obj, sets, fix_n=fix_n, lc_bounds=(lc_lo, lc_hi), n_bounds=(n_lo, n_hi),
                                      systematic=max(floor, float(systematic)), notes=notes, progress=progress,
                                      landscape=landscape, separability_width=separability_width,
                                      bootstrap_resamples=bootstrap_resamples, bootstrap_seed=bootstrap_seed,
                                      t_start=t_start, warn=warn,
                                      sensitivities=jacobian == "sensitivities")
        except SimulationError as exc:
            raise ImpactidError(f"simulation failed inside the search bounds: {exc}") from exc

    # -- point estimate and the valley --------------------------------------------------------
    if fix_n is not None:
        n_rows = np.array([float(fix_n)])
    else:
        count = int(round((n_hi - n_lo) / _N_LATTICE_STEP)) + 1
        n_rows = np.linspace(n_lo, n_hi, max(count, 5))
    c_scan = np.linspace(lc_lo, lc_hi, _SCAN_POINTS)
    nn, cc = np.meshgrid(n_rows, c_scan, indexing="ij")
    try:
        scan = obj.mean(obj.per_event(cc.ravel(), nn.ravel())).reshape(nn.shape)
    except SimulationError as exc:
        raise ImpactidError(f"simulation failed inside the search bounds: {exc}") from exc
    if not np.any(np.isfinite(scan)):
        raise ImpactidError(f"the {residual} residual is undefined for every event (no usable contact data)")
    valley_c = np.empty(n_rows.size)
    valley_j = np.empty(n_rows.size)
    for k, n in enumerate(n_rows):
        valley_c[k], valley_j[k] = _minimise_logc(obj, float(n), lc_lo, lc_hi, scan[k])
        progress("valley", 0.6 * (k + 1) / n_rows.size)
    if method == "grid":
        gc = np.linspace(lc_lo, lc_hi, int(grid[0]))
        gn = n_rows if fix_n is not None else np.linspace(n_lo, n_hi, int(grid[1]))
        gnn, gcc = np.meshgrid(gn, gc, indexing="ij")
        values = obj.mean(obj.per_event(gcc.ravel(), gnn.ravel())).reshape(gnn.shape)
        i, j = np.unravel_index(int(np.argmin(values)), values.shape)
        n_hat, logc_hat, j_hat = float(gn[i]), float(gc[j]), float(values[i, j])
    elif fix_n is not None:
        n_hat, logc_hat, j_hat = float(fix_n), float(valley_c[0]), float(valley_j[0])
    else:
        k = int(np.argmin(valley_j))
        valley_spline = interpolate.CubicSpline(n_rows, valley_c)
        a, b = n_rows[max(k - 1, 0)], n_rows[min(k + 1, n_rows.size - 1)]

        logc_hat, n_hat, j_hat = _profile_fit(obj, valley_spline, (lc_lo, lc_hi), 0.05, n_range=(a, b))
        if valley_j[k] < j_hat:
            n_hat, logc_hat, j_hat = float(n_rows[k]), float(valley_c[k]), float(valley_j[k])
    progress("uncertainty", 0.65)

    # -- lattice about the valley: bootstrap and indifference region ----------------------------
    per_event_hat = obj.per_event(logc_hat, n_hat)[0]
    finite = np.isfinite(per_event_hat)
    n_used = int(finite.sum())
    se = float(np.std(np.abs(per_event_hat[finite]), ddof=1) / math.sqrt(n_used)) if n_used > 1 else math.inf
    indifference = max(2.0 * se, floor, float(systematic)) if math.isfinite(se) else math.inf
    if fix_n is None:
        centre = interpolate.CubicSpline(n_rows, valley_c)(n_rows)
    else:
        centre = np.array([logc_hat])
    half = _LATTICE_HALF_WIDTH
    for attempt in range(3):
        u = np.linspace(-half, half, _LATTICE_POINTS)
        lat = _lattice(obj, n_rows, centre, u)
        boot, region, edge = _uncertainty(lat, n_rows, centre, u, obj, finite, j_hat, indifference,
                                          bootstrap_resamples, bootstrap_seed)
        if not edge or attempt == 2:
            break
        half *= 5.0
    progress("uncertainty", 0.95)
    beta_hat = float(obj.beta(logc_hat, n_hat))
    b_boot = np.percentile(boot[:, 0], [2.5, 97.5]) if boot.size else np.array([math.nan, math.nan])
    n_boot = np.percentile(boot[:, 1], [2.5, 97.5]) if boot.size else np.array([math.nan, math.nan])
    beta_iv = (float(min(b_boot[0], region[0], beta_hat)), float(max(b_boot[1], region[1], beta_hat)))
    if fix_n is None:
        n_iv = (float(min(n_boot[0], region[2], n_hat)), float(max(n_boot[1], region[3], n_hat)))
    else:
        n_iv = (n_hat, n_hat)
    # -- common-mode error of each recording's cam phase (cam-phase anchor), by linear propagation
    phase_beta_sd = phase_n_sd = 0.0
    centre_of = (interpolate.CubicSpline(n_rows, valley_c) if fix_n is None else (lambda n: logc_hat))
    for k, es in enumerate(sets):
        if not (math.isfinite(es.phase_stderr) and es.phase_stderr > 0):
            continue
        shifted = list(sets)
        shifted[k] = es.shift_phase(es.phase_stderr)
        sub = _Objective(shifted, residual, delta_ref)
        n_range = None if fix_n is not None else (max(n_hat - 0.15, n_lo), min(n_hat + 0.15, n_hi))
        lc2, n2, _ = _profile_fit(sub, centre_of, (lc_lo, lc_hi), 0.1, n_range=n_range, fix_n=fix_n)
        obj.n_simulations += sub.n_simulations
        obj.n_failed += sub.n_failed
        phase_beta_sd = math.hypot(phase_beta_sd, float(obj.beta(lc2, n2)) - float(obj.beta(logc_hat, n_hat)))
        # (a relative sd of beta is used below: beta shifts multiplicatively along the valley)
        phase_n_sd = math.hypot(phase_n_sd, n2 - n_hat)
    progress("uncertainty", 0.99)
    # beta widened in log space (it is positive and was searched on a log scale); n clipped to its bounds
    log_iv = _widen((math.log(beta_iv[0]), math.log(beta_iv[1])), math.log(beta_hat),
                    1.96 * math.log1p(phase_beta_sd / beta_hat))
    beta_iv = (math.exp(log_iv[0]), math.exp(log_iv[1]))
    if fix_n is None:
        n_iv = _widen(n_iv, n_hat, 1.96 * phase_n_sd)
        n_iv = (max(n_iv[0], n_lo), min(n_iv[1], n_hi))
    if edge:
        notes.append(f"the {residual} objective stays within {indifference:.3g} of its minimum beyond "
                     f"+-{half:.2g} decades of beta about the valley: beta is poorly determined by these data")

    # -- identifiability -----------------------------------------------------------------------
    separable = _identifiability(sets, residual, fix_n, n_hat, logc_hat, n_iv, beta_iv, (lc_lo, lc_hi), (n_lo, n_hi),
                                 indifference, separability_width, notes)
    if indifference > 0.05:
        notes.append(f"the residual scatter between impacts is large (standard error of the mean "
                     f"{se:.3g}); the estimate rests on {n_used} impacts")

    valley = pd.DataFrame({"n": n_rows, "beta": obj.beta(valley_c, n_rows), "log10_c": valley_c,
                           "objective": valley_j})
    sources = np.concatenate([[s.source] * len(s) for s in sets])
    events = np.concatenate([s.events for s in sets])
    per_event = pd.DataFrame({"source": sources, "event": events, "approach_speed": np.concatenate(
        [s.approach_speed for s in sets]), "residual": per_event_hat})
    land = objective_landscape(sets, residual, delta_ref=delta_ref) if landscape else None
    _failure_note(obj, notes)
    progress("done", 1.0)
    for message in notes if warn else ():
        warnings.warn(message, EstimationWarning, stacklevel=2)
    return DampingEstimate(
        beta=beta_hat, n=n_hat, fixed_n=fix_n is not None, residual=residual, objective=j_hat, method=method,
        beta_interval=beta_iv, n_interval=n_iv, beta_bootstrap_interval=(float(b_boot[0]), float(b_boot[1])),
        n_bootstrap_interval=(float(n_boot[0]), float(n_boot[1])), indifference=indifference, separable=separable,
        phase_beta_sd=phase_beta_sd, phase_n_sd=phase_n_sd, valley=valley, per_event=per_event,
        delta_ref=delta_ref, bootstrap=boot, landscape=land,
        n_simulations=obj.n_simulations, seconds=time.perf_counter() - t_start, warnings=tuple(notes),
        n_failed_simulations=obj.n_failed)


def _failure_note(obj: _Objective, notes: list[str]) -> None:
    """Say how many S1 runs with trial laws could not be simulated (penalised, not fatal)."""
    if obj.n_failed:
        from impactid.rigs.pivoted.residuals import FAILED_SIMULATION_RESIDUAL

        notes.append(f"{obj.n_failed} of {obj.n_simulations} S1 runs with trial laws could not be simulated "
                     f"(step budget or step-size underflow); each counted as a residual of "
                     f"{FAILED_SIMULATION_RESIDUAL:g} for its event, so the search avoided those laws")


def _identifiability(sets, residual, fix_n, n_hat, logc_hat, n_iv, beta_iv, lc_bounds, n_bounds, indifference,
                     separability_width, notes: list[str], region: str | None = None) -> bool | None:
    """Whether ``beta, n`` are separable (None with ``n`` fixed); notes on bounds and identifiability.

    ``region`` says what the ``n`` interval is (default: the indifference region of the mean residual).
    """
    (lc_lo, lc_hi), (n_lo, n_hi) = lc_bounds, n_bounds
    separable = None
    va = np.concatenate([s.approach_speed for s in sets])
    va = va[np.isfinite(va)]
    spread = float(np.std(va) / np.mean(va)) if va.size > 1 and np.mean(va) > 0 else 0.0
    region = region or f"the mean {residual} stays within {indifference:.3g} of its minimum"
    if fix_n is None:
        touches = n_iv[0] <= n_lo + 1e-9 or n_iv[1] >= n_hi - 1e-9
        separable = bool((n_iv[1] - n_iv[0]) <= separability_width and not touches)
        if not separable:
            why = (f"all impacts have nearly the same approach speed (spread {100 * spread:.2g} %)"
                   if spread < ALIKE_SPREAD else f"the approach speeds spread only {100 * spread:.2g} %")
            notes.append(
                f"beta and n are not separable from these data ({why}): along the valley beta(n) {region} "
                f"for n from {n_iv[0]:.3g} to {n_iv[1]:.3g} "
                f"(beta {beta_iv[0]:.4g} to {beta_iv[1]:.4g}); the joint point estimate is not precise. Fix n "
                + ("(--fix-n) or fit recordings at several operating points together." if len(sets) == 1 else
                   "(--fix-n), add operating points whose approach speeds differ more (lower e/r_c or cam speed), "
                   "or record with less noise."))
    if logc_hat <= lc_lo + 1e-6 or logc_hat >= lc_hi - 1e-6:
        notes.append(f"the estimate lies on the search bound of c = beta delta_ref^n ({10 ** logc_hat:.3g} N s/m): "
                     "widen the bounds or check the data")
    if fix_n is None and (n_hat <= n_lo + 1e-6 or n_hat >= n_hi - 1e-6):
        notes.append(f"the estimate of n lies on its search bound ({n_hat:.3g})")
    return separable


def _fit_least_squares(obj: _Objective, sets: list[EventSet], *, fix_n, lc_bounds, n_bounds, systematic: float,
                       notes: list[str], progress, landscape: bool, separability_width: float,
                       bootstrap_resamples: int, bootstrap_seed: int, t_start: float,
                       warn: bool = True, sensitivities: bool = True) -> DampingEstimate:
    """The ``"least-squares"`` method (:mod:`impactid.gauss_newton`) as a :class:`DampingEstimate`."""
    from impactid.gauss_newton import fit_least_squares

    residual = obj.residual
    fit = fit_least_squares(obj.per_event, fix_n=fix_n, lc_bounds=lc_bounds, n_bounds=n_bounds, progress=progress,
                            choose=lambda points: _by_contact_duration(obj, sets, points, fix_n, notes),
                            rss_tolerance=obj.n_events * systematic ** 2,
                            per_event_jacobian=obj.per_event_and_jacobian if sensitivities else None)
    logc_hat = fit.x[0]
    n_hat = float(fix_n) if fix_n is not None else fit.x[1]
    beta_hat = float(obj.beta(logc_hat, n_hat))
    J, r = fit.jacobian, fit.residuals
    # d log(beta) / d(log10 c, n)
    grad = np.array([math.log(10.0), -math.log(obj.delta_ref)])[: J.shape[1]]
    normal = np.linalg.pinv(J.T @ J)

    # -- statistical: the profile-likelihood region projected on beta ---------------------------
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
        notes.append(f"the {residual} residuals are matched equally well by other laws ("
                     + ", ".join(f"beta {obj.beta(a[0], a[1] if len(a) > 1 else n_hat):.4g}" for a in fit.alternatives)
                     + ") that the measured contact durations do not tell apart: the interval of beta holds them all")
    log_beta = np.log(obj.beta(np.concatenate([lc_in - half, lc_in + half]), np.concatenate([n_in, n_in])))
    log_iv = (float(log_beta.min()), float(log_beta.max()))
    n_iv = fit.n_interval

    # -- systematic: a common-mode residual error of each recording, and each cam phase ---------
    per_event_hat = np.full(fit.used.size, math.nan)
    per_event_hat[fit.used] = r
    owner_all = np.concatenate([[k] * len(es) for k, es in enumerate(sets)])
    owner = owner_all[fit.used]
    # each recording's shift of (log10 c, n), combined in quadrature as log(beta) and n shifts
    sys_shifts = [normal @ (J.T @ (systematic * (owner == k))) for k in range(len(sets))]
    phase_shifts = []
    for k, es in enumerate(sets):
        if not (math.isfinite(es.phase_stderr) and es.phase_stderr > 0):
            continue
        sub = _Objective([es.shift_phase(es.phase_stderr)], residual, obj.delta_ref)
        delta = np.zeros(fit.used.size)
        delta[owner_all == k] = sub.per_event(logc_hat, n_hat)[0] - per_event_hat[owner_all == k]
        obj.n_simulations += sub.n_simulations
        phase_shifts.append(normal @ (J.T @ np.nan_to_num(delta[fit.used])))

    def quadrature(shifts, component=None):
        values = [float(grad @ dx) if component is None else float(dx[component]) for dx in shifts]
        return float(np.sqrt(np.sum(np.square(values)))) if values else 0.0

    phase_logbeta, sys_logbeta = quadrature(phase_shifts), quadrature(sys_shifts)
    log_iv = _widen(log_iv, math.log(beta_hat), math.hypot(1.96 * phase_logbeta, sys_logbeta))
    # a linear propagation through a nearly singular valley can reach beyond the search box: the interval
    # stops at the box's extreme beta (beta = c / delta_ref^n, least at (c_lo, n_lo), largest at (c_hi, n_hi))
    n_box = (n_hat, n_hat) if fix_n is not None else n_bounds
    box = (math.log(obj.beta(lc_bounds[0], n_box[0])), math.log(obj.beta(lc_bounds[1], n_box[1])))
    if log_iv[0] < box[0] or log_iv[1] > box[1]:
        notes.append("the interval of beta reaches the search box of c = beta delta_ref^n: the data bound beta "
                     "only weakly")
    log_iv = (max(log_iv[0], box[0]), min(log_iv[1], box[1]))
    beta_iv = (math.exp(log_iv[0]), math.exp(log_iv[1]))
    phase_n_sd = quadrature(phase_shifts, 1) if fix_n is None else 0.0
    if fix_n is None:
        n_iv = _widen(n_iv, n_hat, math.hypot(1.96 * phase_n_sd, quadrature(sys_shifts, 1)))
        n_iv = (max(n_iv[0], n_bounds[0]), min(n_iv[1], n_bounds[1]))
        if fit.reaches_bound[0]:
            n_iv = (n_bounds[0], n_iv[1])
        if fit.reaches_bound[1]:
            n_iv = (n_iv[0], n_bounds[1])
    else:
        n_iv = (n_hat, n_hat)

    # -- Gauss-Newton standard errors and the linearised bootstrap -----------------------------
    beta_se = beta_hat * math.sqrt(max(float(grad @ fit.covariance @ grad), 0.0))
    n_se = math.sqrt(max(float(fit.covariance[1, 1]), 0.0)) if fix_n is None else 0.0
    rng = np.random.default_rng(bootstrap_seed)
    m = r.size
    weights = rng.multinomial(m, np.full(m, 1.0 / m), size=bootstrap_resamples).astype(float)
    boot = []
    for w in weights:
        A = J.T @ (w[:, None] * J)
        dx = -np.linalg.lstsq(A, J.T @ (w * r), rcond=None)[0]
        x_b = np.array([logc_hat, n_hat])
        x_b[: dx.size] += dx
        boot.append((float(obj.beta(x_b[0], x_b[1])), float(x_b[1])))
    boot = np.asarray(boot)
    b_boot = np.percentile(boot[:, 0], [2.5, 97.5])
    n_boot = np.percentile(boot[:, 1], [2.5, 97.5])

    region = (f"the 95 % profile interval of the {residual} sum of squares (with the pipeline's systematic "
              f"residual error {systematic:.3g} per recording) stays open")
    separable = _identifiability(sets, residual, fix_n, n_hat, logc_hat, n_iv, beta_iv, lc_bounds, n_bounds,
                                 systematic, separability_width, notes, region=region)
    if math.sqrt(fit.s2) > 0.05:
        notes.append(f"the residual scatter between impacts is large (rms {math.sqrt(fit.s2):.3g}); "
                     f"the estimate rests on {m} impacts")
    valley = pd.DataFrame({"n": prof["n"], "beta": obj.beta(prof["log10_c"].to_numpy(), prof["n"].to_numpy()),
                           "log10_c": prof["log10_c"], "objective": prof["objective"]})
    per_event = pd.DataFrame({"source": np.concatenate([[s.source] * len(s) for s in sets]),
                              "event": np.concatenate([s.events for s in sets]),
                              "approach_speed": np.concatenate([s.approach_speed for s in sets]),
                              "residual": per_event_hat})
    land = objective_landscape(sets, residual, delta_ref=obj.delta_ref) if landscape else None
    _failure_note(obj, notes)
    progress("done", 1.0)
    for message in notes if warn else ():
        warnings.warn(message, EstimationWarning, stacklevel=3)
    return DampingEstimate(
        beta=beta_hat, n=n_hat, fixed_n=fix_n is not None, residual=residual, objective=float(np.mean(np.abs(r))),
        method="least-squares", beta_interval=beta_iv, n_interval=n_iv,
        beta_bootstrap_interval=(float(b_boot[0]), float(b_boot[1])),
        n_bootstrap_interval=(float(n_boot[0]), float(n_boot[1])), indifference=float(systematic),
        separable=separable, phase_beta_sd=beta_hat * math.expm1(min(phase_logbeta, 700.0)), phase_n_sd=phase_n_sd,
        valley=valley, per_event=per_event, delta_ref=obj.delta_ref, bootstrap=boot, landscape=land,
        n_simulations=obj.n_simulations, seconds=time.perf_counter() - t_start, warnings=tuple(notes),
        n_failed_simulations=obj.n_failed, beta_stderr=beta_se, n_stderr=n_se)


def _by_contact_duration(obj: _Objective, sets: list[EventSet], points, fix_n, notes: list[str]) -> int | None:
    """Which of several equally good minima ``(log10 c[, n])`` reproduces the measured contact durations.

    A heavily damped law can make the follower chatter and still reach the measured ``alpha_m``
    (with friction especially); the duration of the first contact tells it apart. Returns the index
    of the point whose simulated first contacts differ least from the measured ones (median relative
    difference over the events with a measured duration), if it is clearly the best (less than half
    the next and below 20 %); None otherwise.
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


def _widen(interval, centre, extra):
    """Widen (lo, hi) about ``centre`` by ``extra`` in quadrature on each side."""
    lo, hi = interval
    return (centre - math.hypot(centre - lo, extra), centre + math.hypot(hi - centre, extra))


def _profile_fit(obj: _Objective, centre_of, lc_bounds, c_half: float, *, n_range=None,
                 fix_n: float | None = None) -> tuple[float, float, float]:
    """Nested bounded Brent: ``log10 c`` within ``c_half`` decades of ``centre_of(n)`` (the valley),
    inside a search of ``n`` over ``n_range`` (a profile along the valley; ``fix_n`` instead of
    ``n_range`` for the inner search alone). Returns ``(log10 c, n, J)``."""
    found: dict[float, tuple[float, float]] = {}

    def inner(n: float) -> float:
        c0 = float(centre_of(n))
        res = optimize.minimize_scalar(lambda x: obj(x, n), method="bounded", options={"xatol": _LOGC_XTOL},
                                       bounds=(max(c0 - c_half, lc_bounds[0]), min(c0 + c_half, lc_bounds[1])))
        found[n] = (float(res.x), float(res.fun))
        return float(res.fun)

    if n_range is None:
        n = float(fix_n)
    else:
        n = float(optimize.minimize_scalar(inner, bounds=n_range, method="bounded", options={"xatol": _N_XTOL}).x)
    if n not in found:
        inner(n)
    return found[n][0], n, found[n][1]


def _lattice(obj: _Objective, n_rows, centre, u) -> np.ndarray:
    """Per-event residuals on the lattice (n_rows, u), log10 c = centre(n) + u: shape (K, U, N)."""
    nn = np.repeat(n_rows, u.size)
    cc = (centre[:, None] + u[None, :]).ravel()
    return obj.per_event(cc, nn).reshape(n_rows.size, u.size, -1)


def _uncertainty(lat, n_rows, centre, u, obj, finite, j_hat, indifference, resamples=BOOTSTRAP_RESAMPLES,
                 seed=BOOTSTRAP_SEED):
    """Bootstrap estimates (beta, n), the indifference region (beta_lo, beta_hi, n_lo, n_hi), and
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


# ---------------------------------------------------------------------------------------------
# restitution
# ---------------------------------------------------------------------------------------------


def fit_restitution(per_impact: pd.DataFrame, k_H: float, *, min_spread: float = 0.05,
                    warn: bool = True) -> RestitutionEstimate:
    """Fit restitution laws to per-impact ``approach_speed`` (v_a [m/s]) and ``xi``.

    ``per_impact`` needs columns ``approach_speed`` and ``xi`` (others are kept). Impacts with a
    non-finite xi or v_a <= 0 are left out (and counted in a warning). ``k_H`` [N m^-1.5] gives
    the Hunt–Crossley equivalent ``beta = 1.5 gamma k_H``.

    Warns (:class:`EstimationWarning`) when the approach speeds spread too little for the data to
    test the linear law (relative spread below ``min_spread`` or a free-intercept slope no larger
    than twice its standard error: ``gamma`` then rests on the assumed intercept 1), when some
    ``xi`` lie outside [0, 1], and when the fitted law predicts ``xi < 0`` at a measured speed; the
    result carries these notes (``warnings``), and callers that carry them on pass ``warn=False``.
    """
    frame = per_impact.copy()
    ok = np.isfinite(frame["xi"]) & np.isfinite(frame["approach_speed"]) & (frame["approach_speed"] > 0)
    notes = []
    if (~ok).any():
        notes.append(f"{int((~ok).sum())} impacts without a determined xi or approach speed were left out")
    used = frame[ok]
    n = len(used)
    if n == 0:
        raise ImpactidError("no impact with a determined xi and approach speed: the restitution law cannot be fitted")
    v = used["approach_speed"].to_numpy(float)
    xi = used["xi"].to_numpy(float)
    gamma = float(np.sum(v * (1.0 - xi)) / np.sum(v * v))
    resid = xi - (1.0 - gamma * v)
    gamma_se = float(math.sqrt(np.sum(resid ** 2) / (n - 1) / np.sum(v * v))) if n > 1 else math.inf
    r_const = float(np.mean(xi))
    r_se = float(np.std(xi, ddof=1) / math.sqrt(n)) if n > 1 else math.inf
    spread = float(np.std(v) / np.mean(v))
    intercept = slope = a_se = b_se = math.nan
    if n > 2 and spread > 1e-6:
        design = np.column_stack([np.ones(n), -v])
        coef, *_ = np.linalg.lstsq(design, xi, rcond=None)
        dof_res = xi - design @ coef
        cov = np.linalg.inv(design.T @ design) * np.sum(dof_res ** 2) / (n - 2)
        intercept, slope = float(coef[0]), float(coef[1])
        a_se, b_se = (float(math.sqrt(max(cov[0, 0], 0.0))), float(math.sqrt(max(cov[1, 1], 0.0))))
    if spread < min_spread or not (abs(slope) > 2.0 * b_se):
        notes.append(
            f"the approach speeds spread only {100 * spread:.2g} % (v_a {v.min():.4g} to {v.max():.4g} m/s): the data "
            "cannot determine the slope of xi(v_a); gamma = (1 - xi_mean)/va_mean follows from the law's assumed "
            "intercept xi(0) = 1, and a constant r fits as well")
    outside = int(np.sum((xi < 0) | (xi > 1)))
    if outside:
        notes.append(f"{outside} impacts have xi outside [0, 1]")
    if gamma > 0 and np.any(v > 1.0 / gamma):
        notes.append(f"the fitted law gives xi < 0 for v_a > 1/gamma = {1 / gamma:.4g} m/s, reached by "
                     f"{int(np.sum(v > 1 / gamma))} impacts: outside the law's range (docs/estimation.md)")
    for message in notes if warn else ():
        warnings.warn(message, EstimationWarning, stacklevel=2)
    frame["used"] = ok
    return RestitutionEstimate(
        gamma=gamma, gamma_stderr=gamma_se, r_constant=r_const, r_constant_stderr=r_se, intercept=intercept,
        intercept_stderr=a_se, slope=slope, slope_stderr=b_se, xi_mean=float(np.mean(xi)), va_mean=float(np.mean(v)),
        va_spread=spread, beta_equivalent=float(1.5 * gamma * k_H), impacts_used=n, per_impact=frame,
        warnings=tuple(notes))


# ---------------------------------------------------------------------------------------------
# the whole job: recordings -> events -> kinematics -> estimates
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Estimate:
    """Result of :func:`estimate`: contact damping, restitution, and what they rest on."""

    damping: DampingEstimate
    restitution: RestitutionEstimate | None
    sources: tuple[str, ...]
    operating_points: tuple[dict, ...]
    reconstructions: tuple = field(default=(), repr=False)
    event_sets: tuple = field(default=(), repr=False)
    warnings: tuple[str, ...] = ()
    provenance: tuple[str, ...] = ()
    #: per recording, the pipeline's alpha_m bias measured on the model's own recording
    #: (:mod:`impactid.rigs.pivoted.calibration`), when the estimate was calibrated
    calibration: tuple[dict, ...] = ()
    #: the options of the :class:`~impactid.pipeline.Pipeline` that made the estimate
    pipeline: dict = field(default_factory=dict)

    def report(self) -> str:
        """lmfit-style reports of the damping and the restitution fits, with the recordings and notes."""
        parts = [self.damping.to_result().report()]
        parts.append(self.restitution.to_result().report() if self.restitution is not None
                     else "[[restitution]]\n    not estimated (see the notes)")
        parts.append("[[Recordings]]\n" + "\n".join(
            f"    {s}: {op['events']} events at e/r_c {op['e_over_rc']:.4g}, {op['cam_speed_hz']:.4g} Hz"
            for s, op in zip(self.sources, self.operating_points)))
        if self.warnings:
            parts.append("[[Notes]]\n" + "\n".join(f"    - {w}" for w in self.warnings))
        return "\n".join(parts)

    def to_dict(self, per_impact: bool = True) -> dict:
        """The result as JSON-ready data: the keys of docs/formats.md (SI units) plus uncertainty and detail."""
        d, r = self.damping, self.restitution
        out = {
            "beta": d.beta, "n": d.n, "gamma": r.gamma if r else None, "xi_mean": r.xi_mean if r else None,
            "va_mean": r.va_mean if r else None,
            "impacts_used": int(len(d.per_event[np.isfinite(d.per_event["residual"])])),
            "residual": d.residual, "objective": d.objective,
            "units": {"beta": "N s m^-(n+1)", "gamma": "s/m", "va_mean": "m/s", "c_ref": "N s/m",
                      "delta_ref": "m"},
            "uncertainty": {
                "beta_interval": list(d.beta_interval), "n_interval": list(d.n_interval),
                "beta_bootstrap_95": list(d.beta_bootstrap_interval), "n_bootstrap_95": list(d.n_bootstrap_interval),
                "objective_indifference": d.indifference, "separable": d.separable, "n_fixed": d.fixed_n,
                "gamma_stderr": r.gamma_stderr if r else None, "beta_sd_from_cam_phase": d.phase_beta_sd,
                "n_sd_from_cam_phase": d.phase_n_sd,
            },
            "contact_damping": {"method": d.method, "delta_ref": d.delta_ref, "c_ref": d.damping_at_reference,
                                "simulations": d.n_simulations, "failed_simulations": d.n_failed_simulations,
                                "seconds": d.seconds,
                                "valley": d.valley[["n", "beta", "objective"]].to_dict(orient="list")},
            "restitution": None if r is None else {
                "gamma": r.gamma, "gamma_stderr": r.gamma_stderr, "r_constant": r.r_constant,
                "r_constant_stderr": r.r_constant_stderr, "intercept": r.intercept,
                "intercept_stderr": r.intercept_stderr, "slope": r.slope, "slope_stderr": r.slope_stderr,
                "va_spread": r.va_spread, "beta_equivalent_n1.5": r.beta_equivalent,
                "impacts_used": r.impacts_used},
            "recordings": [dict(source=s, **op) for s, op in zip(self.sources, self.operating_points)],
            "calibration": [dict(c) for c in self.calibration],
            "warnings": list(self.warnings),
            "provenance": list(self.provenance),
        }
        if per_impact:
            merged = d.per_event if r is None else d.per_event.merge(
                r.per_impact[["source", "event", "xi", "separation_speed"]], on=["source", "event"], how="outer")
            out["per_impact"] = merged.to_dict(orient="records")
        return out


#: Calibrated pipeline biases of alpha_m below this are left uncorrected (the noise-free pipeline's
#: own level at 204.8 kHz, a few 1e-6; half the lambda1 residual floor).
CALIBRATION_THRESHOLD = 0.5 * RESIDUAL_FLOOR["lambda1"]

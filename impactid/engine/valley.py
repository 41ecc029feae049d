"""Least-squares estimation of the contact law: trust-region Gauss–Newton along the valley.

The ``"least-squares"`` method of :func:`impactid.rigs.pivoted.estimates.fit_contact_damping` (docs/estimation.md).
It minimises the sum of squares of the **per-event residual vector** ``r(x)`` (``lambda1`` signed;
:mod:`impactid.rigs.pivoted.residuals`) over ``x = (log10 c, n)``, ``c = beta delta_ref^n`` the damping at the
reference indentation: coordinates in which the ``beta``-``n`` valley is nearly straight.

Search. A 41-point scan of ``log10 c`` over its bounds at the starting ``n`` (1.5, or the fixed
``n``) brackets the valley (on a representative part of the events when the caller gives ``scan``: the
scan only chooses the starts); from each of its lowest local minima (at most three: with friction a
plateau or a second minimum of chattering laws can compete with the narrow true minimum) scipy's
trust-region reflective ``least_squares`` (bounded) converges in a few Gauss–Newton steps. The
lowest end point is kept, unless another fits as well at another ``c`` (within the 95 % threshold
or the caller's tolerance): then the caller's other evidence decides (the estimator compares the
simulated and measured contact durations), or the fit reports the minima as unresolved.
Jacobians. The Jacobian ``dr/dx`` comes from the **forward sensitivities** the simulator integrates
with each run (``per_event_jacobian``: the variational equations of the S1 model in the compiled
kernel, on the same steps as the state; ``impactid.rigs.pivoted.kernel``): every residual evaluation
of the search then also yields its Jacobian, at about 1.3 times the cost of a run without them, where
differences would take two (``n`` fixed) or four more runs. Checked against central differences of
the simulator at tight tolerance in tests/rigs/pivoted/test_sensitivity.py. Where the simulator cannot
integrate them (friction: the friction force jumps at sliding reversals, which are not located as
events) the Jacobian is computed by **central differences in one batched S1 call** per iteration
(four trial laws for ``(log10 c, n)``, two for ``log10 c`` alone): with the simulator at ``rtol``
1e-10, steps of 1e-3 (decades of ``c``, and in ``n``) give derivatives accurate to about 1e-6
relative (truncation ``h^2`` against round-off ``rtol / h``), checked in tests/test_engine_valley.py
against steps four times smaller.

Uncertainty. With ``s^2 = RSS / (m - p)`` (``m`` events, ``p`` parameters), ``t = t_{0.975, m-p}``:

* **Gauss–Newton covariance** ``s^2 (J^T J)^-1``, reported as the standard errors;
* the **profile along the valley**, by continuation from the optimum: ``n`` is stepped outwards
  (adaptive steps, the next ``log10 c`` predicted by extrapolation and corrected by 1-D
  Gauss–Newton) and the profile ``RSS(n)`` recorded until it rises by more than
  ``1.5 t^2 s^2``. The 95 % interval of ``n`` is where ``RSS(n) - RSS_min <= t^2 s^2``; the interval of
  ``beta`` is the projection of that confidence region (at each profile point the cross-valley
  half-width ``sqrt(t^2 s^2 - dRSS) / |dr/dlog10 c|``), i.e. the profile-likelihood interval of
  ``beta``. With ``n`` fixed both reduce to ``log10 c +- t s / |dr/dlog10 c|``.
* **systematic errors** propagated linearly and added in quadrature to each side: the
  pipeline's own residual floor (a common-mode error of every event of one recording, at most
  :data:`~impactid.rigs.pivoted.estimates.RESIDUAL_FLOOR` or the calibrated ``systematic``; each recording
  independently), and the error of each recording's cam phase (cam-phase anchor).
* a **linearised bootstrap** over events (resampled weights in the Gauss–Newton normal
  equations; no simulations), reported beside the interval.

A point on the profile below the optimum restarts the search from there (the valley has no
second minimum in any case measured, but a search must not rely on that).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
import pandas as pd
from scipy import optimize

from impactid.engine.distributions import student_t_quantile

__all__ = ["JACOBIAN_STEP", "LeastSquaresFit", "fit_least_squares", "jacobian"]

#: Central-difference steps of the Jacobian: decades of ``c``, and ``n``.
JACOBIAN_STEP = (1.0e-3, 1.0e-3)
#: Points of the starting scan of ``log10 c`` (0.15 decades apart over the default 6 decades: the
#: minimum of a noise-free recording is about 0.1 decade wide at the level of the plateau of
#: chattering laws, so a coarser scan can start the search on the plateau; envelope case hc06).
START_SCAN_POINTS = 41
#: Most starting points: the lowest local minima of the scan, each searched from.
MAX_STARTS = 3
#: The profile continues until ``RSS`` rises by this many times the 95 % threshold.
PROFILE_REACH = 1.5
#: Most points on each side of the profile.
PROFILE_MAX_POINTS = 40


@dataclass(frozen=True)
class LeastSquaresFit:
    """A least-squares fit of ``(log10 c, n)`` with its profile along the valley.

    Attributes
    ----------
    x : ``(log10 c, n)`` at the minimum.
    residuals : per-event residuals at ``x`` (the events used, i.e. finite at the start).
    used : bool mask of the events used, over all events of the objective.
    jacobian : ``(m, p)`` Jacobian at ``x`` (``p`` = 1 with ``n`` fixed).
    rss : residual sum of squares; dof : ``m - p``; s2 : ``rss / dof``; threshold : ``t^2 s2``.
    covariance : ``(p, p)`` Gauss–Newton covariance of ``x``.
    profile : DataFrame ``n, log10_c, rss, objective, half_width`` (half-width in decades of ``c``
        across the valley where ``rss - rss_min <= threshold``, else 0), sorted by ``n``.
    n_interval : 95 % profile interval of ``n`` (``(n, n)`` when fixed); reaches_bound : whether
        the profile reached a bound of ``n`` before the threshold, on the low or high side.
    evaluations : trial laws simulated (each for every event), search and profile together.
    alternatives : other minima that fit as well at another ``c`` (friction cases: a heavily damped,
        chattering law can reproduce ``alpha_m`` too); resolved : whether ``choose`` told them apart.
    """

    x: tuple[float, ...]
    residuals: np.ndarray
    used: np.ndarray
    jacobian: np.ndarray
    rss: float
    dof: int
    s2: float
    threshold: float
    covariance: np.ndarray
    profile: pd.DataFrame
    n_interval: tuple[float, float]
    reaches_bound: tuple[bool, bool]
    evaluations: int
    alternatives: tuple[tuple[float, ...], ...] = ()
    resolved: bool = True


def jacobian(residual_of: Callable[[np.ndarray, np.ndarray], np.ndarray], x: np.ndarray,
             step: tuple[float, ...] = JACOBIAN_STEP) -> np.ndarray:
    """Central-difference Jacobian of ``residual_of`` at ``x`` in one batched call.

    ``residual_of(logc, n)`` takes arrays of ``k`` trial points and returns ``(k, m)`` residuals;
    ``x`` is ``(log10 c,)`` (with ``n`` fixed by the caller) or ``(log10 c, n)``. Returns ``(m, p)``.
    """
    x = np.asarray(x, dtype=float)
    p = x.size
    h = np.asarray(step[:p], dtype=float)
    points = np.repeat(x[None, :], 2 * p, axis=0)
    for j in range(p):
        points[2 * j, j] += h[j]
        points[2 * j + 1, j] -= h[j]
    values = residual_of(points[:, 0], points[:, 1] if p > 1 else None)
    return np.column_stack([(values[2 * j] - values[2 * j + 1]) / (2.0 * h[j]) for j in range(p)])


def fit_least_squares(per_event: Callable[[np.ndarray, np.ndarray], np.ndarray], *, fix_n: float | None,
                      lc_bounds: tuple[float, float], n_bounds: tuple[float, float], n_start: float = 1.5,
                      progress: Callable[[str, float], None] | None = None,
                      choose: Callable[[list[np.ndarray]], int | None] | None = None,
                      rss_tolerance: float = 0.0,
                      per_event_jacobian: Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]
                      | None = None,
                      scan: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None) -> LeastSquaresFit:
    """Minimise the sum of squares of the per-event residuals over ``(log10 c, n)``.

    Parameters
    ----------
    per_event : ``per_event(log10_c, n) -> (k, m_all)`` residuals of all events for ``k`` trial
        points (arrays broadcast; NaN for events without a residual).
    fix_n : the fixed exponent, or None to fit ``n`` as well.
    lc_bounds : bounds of ``log10 c`` [log10 (N s/m)]; n_bounds : bounds of ``n``.
    n_start : starting ``n`` of a joint fit (clipped into the bounds).
    progress : callback ``(stage, fraction)``.
    choose : when end points of several starts fit equally well (within the 95 % threshold) at
        different ``c``, ``choose(points)`` returns the index of the right one by other evidence, or
        None when it cannot tell (the fit then reports them as unresolved ``alternatives``).
    rss_tolerance : differences of the sum of squares below this (or the 95 % threshold) do not tell
        minima apart (e.g. the number of events times the square of the residual's systematic floor).
    per_event_jacobian : ``per_event_jacobian(log10_c, n) -> (r, J)``, the residuals ``(k, m_all)`` of
        ``per_event`` with their derivatives ``(k, m_all, 2)`` by ``(log10 c, n)`` (forward
        sensitivities); None to difference ``per_event`` instead.
    scan : ``scan(log10_c, n) -> (k,)``, the start scan's cost at ``k`` points from a representative part
        of the events (its local minima only choose the starts; a part costs a fraction of the runs); the
        events used are then those with a residual at the scan's best point. None: the sum of squares of
        ``per_event`` over the events with a residual at every scan point.

    Returns
    -------
    LeastSquaresFit
    """
    progress = progress or (lambda stage, fraction: None)
    lc_lo, lc_hi = (float(v) for v in lc_bounds)
    n_lo, n_hi = (float(v) for v in n_bounds)
    n0 = float(fix_n) if fix_n is not None else min(max(float(n_start), n_lo), n_hi)
    grid = np.linspace(lc_lo, lc_hi, START_SCAN_POINTS)
    if scan is None:
        values = per_event(grid, np.full(grid.size, n0))
        used = np.all(np.isfinite(values), axis=0)  # NaN: an event without this residual (no force data)
        if not used.any():
            raise ValueError("no event has a residual at the starting point")
        cost = np.sum(values[:, used] ** 2, axis=1)
        evaluations = grid.size
    else:
        cost = np.asarray(scan(grid, np.full(grid.size, n0)), dtype=float)
        best = int(np.argmin(np.where(np.isfinite(cost), cost, np.inf)))
        used = np.all(np.isfinite(per_event(grid[best:best + 1], np.full(1, n0))), axis=0)
        if not used.any():
            raise ValueError("no event has a residual at the starting point")
        evaluations = grid.size + 1
    starts = [[float(grid[k])] if fix_n is not None else [float(grid[k]), n0] for k in _local_minima(cost)]
    for attempt in range(3):
        ends = []
        for x0 in starts:
            x, r, jac, nfev = _solve(per_event, used, x0, fix_n, (lc_lo, lc_hi), (n_lo, n_hi), per_event_jacobian)
            evaluations += nfev
            ends.append((x, r, jac))
        rss = np.array([np.sum(r ** 2) for _, r, _ in ends])
        k = int(np.argmin(rss))
        fit = _statistics(*ends[k], used)
        # other end points that fit as well (within the 95 % threshold) at another c: ambiguous minima
        rivals = [i for i in range(len(ends)) if i != k and rss[i] - rss[k] <= max(fit.threshold, rss_tolerance)
                  and abs(ends[i][0][0] - ends[k][0][0]) > 0.02]
        alternatives: tuple = ()
        if rivals:
            group = [k] + rivals
            pick = choose([ends[i][0] for i in group]) if choose is not None else None
            if pick is not None:
                k = group[pick]
                fit = _statistics(*ends[k], used)
            alternatives = tuple(tuple(float(v) for v in ends[i][0]) for i in group if i != k)
            fit = replace(fit, alternatives=alternatives, resolved=pick is not None)
        x, r, jac = ends[k]
        progress("search", 0.5)
        if fix_n is not None:
            profile = _cross_valley(fit, x, fix_n, r, jac)
            return _finish(fit, profile, (fix_n, fix_n), (False, False), evaluations)
        walk = _Profile(per_event, used, fit, (n_lo, n_hi), per_event_jacobian)
        lower = walk.run(-1)
        upper = walk.run(+1)
        evaluations += walk.evaluations
        progress("uncertainty", 0.8)
        better = walk.better_point
        if better is None or attempt == 2:
            return _finish(fit, pd.concat([lower, upper], ignore_index=True).drop_duplicates("n").sort_values("n"),
                           walk.interval, walk.reaches_bound, evaluations)
        starts = [list(better)]  # the profile found a lower point: the search restarts there
    raise AssertionError("unreachable")


# ---------------------------------------------------------------------------------------------
# internals
# ---------------------------------------------------------------------------------------------


def _local_minima(cost: np.ndarray) -> list[int]:
    """Indices of the lowest local minima of a scan (a flat run counts once), at most
    :data:`MAX_STARTS`, best first (no threshold on their values: a scan point samples a narrow
    minimum's depth arbitrarily)."""
    finite = np.where(np.isfinite(cost), cost, np.inf)
    k = np.arange(finite.size)
    left = np.concatenate([[np.inf], finite[:-1]])
    right = np.concatenate([finite[1:], [np.inf]])
    minima = k[(finite < left) & (finite <= right)]
    if minima.size == 0:
        minima = np.array([int(np.argmin(finite))])
    minima = minima[np.argsort(finite[minima], kind="stable")]
    return [int(i) for i in minima[:MAX_STARTS]]


def _solve(per_event, used, x0, fix_n, lc_bounds, n_bounds, per_event_jacobian=None):
    """Trust-region reflective least squares from ``x0``; returns ``(x, r, J, function evaluations)``.

    With ``per_event_jacobian`` every evaluation integrates the sensitivities as well (scipy asks for
    the Jacobian at nearly every point whose residuals it evaluates: each accepted step), and the
    Jacobian is read from the same run."""
    cache: dict[tuple, np.ndarray] = {}
    count = [0]
    p = 1 if fix_n is not None else 2

    def residual_of(lc, n):
        lc = np.atleast_1d(lc)
        n = np.full(lc.size, fix_n) if n is None else np.atleast_1d(n)
        count[0] += lc.size
        return per_event(lc, n)[:, used]

    if per_event_jacobian is not None:
        jacobians: dict[tuple, np.ndarray] = {}

        def evaluate(x):
            key = tuple(np.round(x, 15))
            if key not in cache:
                n = np.array([fix_n if fix_n is not None else x[1]])
                r, J = per_event_jacobian(np.array([x[0]]), n)
                count[0] += 1
                cache[key], jacobians[key] = r[0, used], J[0, used, :p]
                if not np.isfinite(jacobians[key]).all():  # a run without sensitivities (friction reversal)
                    jacobians[key] = jacobian(residual_of, x)
            return key

        def fun(x):
            return cache[evaluate(x)]

        def jac(x):
            return jacobians[evaluate(x)]

        return _trust_region(fun, jac, x0, fix_n, lc_bounds, n_bounds, count)

    def fun(x):
        key = tuple(np.round(x, 15))
        if key not in cache:
            cache[key] = residual_of(np.array([x[0]]), None if fix_n is not None else np.array([x[1]]))[0]
        return cache[key]

    def jac(x):
        return jacobian(residual_of, x)

    return _trust_region(fun, jac, x0, fix_n, lc_bounds, n_bounds, count)


def _trust_region(fun, jac, x0, fix_n, lc_bounds, n_bounds, count):
    lower = [lc_bounds[0]] if fix_n is not None else [lc_bounds[0], n_bounds[0]]
    upper = [lc_bounds[1]] if fix_n is not None else [lc_bounds[1], n_bounds[1]]
    # a start may lie outside the box (the profile walk can find a lower point beyond a bound of
    # log10 c): the search starts from the nearest point of the box and ends on the bound if the
    # minimum lies beyond it
    x0 = np.clip(np.asarray(x0, dtype=float), lower, upper)
    res = optimize.least_squares(fun, x0, jac=jac, bounds=(lower, upper), method="trf",
                                 x_scale="jac", xtol=1e-10, ftol=1e-12, gtol=1e-12, max_nfev=100)
    x = np.asarray(res.x, dtype=float)
    r = fun(x)
    J = jac(x)
    return x, r, J, count[0]


def _statistics(x, r, J, used) -> LeastSquaresFit:
    """The fit at ``x`` with its statistics; the profile and the interval of ``n`` still empty."""
    m, p = J.shape
    rss = float(np.sum(r ** 2))
    dof = max(m - p, 1)
    s2 = rss / dof
    threshold = student_t_quantile(0.975, dof) ** 2 * s2
    with np.errstate(all="ignore"):
        cov = s2 * np.linalg.pinv(J.T @ J)
    return LeastSquaresFit(x=tuple(float(v) for v in x), residuals=r, used=used, jacobian=J, rss=rss, dof=dof, s2=s2,
                           threshold=threshold, covariance=cov, profile=pd.DataFrame(), n_interval=(math.nan, math.nan),
                           reaches_bound=(False, False), evaluations=0)


def _cross_valley(fit: LeastSquaresFit, x, n, r, J) -> pd.DataFrame:
    jc = float(np.sqrt(np.sum(J[:, 0] ** 2)))
    half = math.sqrt(fit.threshold) / jc if jc > 0 else math.inf
    return pd.DataFrame({"n": [float(n)], "log10_c": [float(x[0])], "rss": [fit.rss],
                         "objective": [float(np.mean(np.abs(r)))], "half_width": [half]})


def _finish(fit: LeastSquaresFit, profile, n_interval, reaches, evaluations) -> LeastSquaresFit:
    return replace(fit, profile=profile.reset_index(drop=True), n_interval=(float(n_interval[0]), float(n_interval[1])),
                   reaches_bound=(bool(reaches[0]), bool(reaches[1])), evaluations=int(evaluations))


class _Profile:
    """Continuation along the valley from the optimum: ``log10 c`` minimised at each ``n``."""

    def __init__(self, per_event, used, fit: LeastSquaresFit, n_bounds, per_event_jacobian=None):
        self.per_event = per_event
        self.per_event_jacobian = per_event_jacobian
        self.used = used
        self.fit = fit
        self.n_bounds = n_bounds
        self.evaluations = 0
        self.better_point: tuple[float, float] | None = None
        self.ends: dict[int, float] = {}
        self.touch: dict[int, bool] = {}
        H = fit.jacobian.T @ fit.jacobian
        # the valley's slope d log10 c / dn at the optimum, and the scale of n to step by
        self.slope = -H[0, 1] / H[0, 0] if H[0, 0] > 0 else 0.0
        curvature = H[1, 1] - H[0, 1] ** 2 / H[0, 0] if H[0, 0] > 0 else 0.0
        sd = math.sqrt(fit.threshold / curvature) if curvature > 0 else 0.1
        self.first_step = min(max(0.25 * sd, 1e-4), 0.05)

    @property
    def interval(self) -> tuple[float, float]:
        return self.ends[-1], self.ends[+1]

    @property
    def reaches_bound(self) -> tuple[bool, bool]:
        return self.touch[-1], self.touch[+1]

    def _row(self, n, lc, r, jc) -> dict:
        drss = float(np.sum(r ** 2)) - self.fit.rss
        room = self.fit.threshold - drss
        half = math.sqrt(room) / jc if room > 0 and jc > 0 else 0.0
        return {"n": n, "log10_c": lc, "rss": self.fit.rss + drss, "objective": float(np.mean(np.abs(r))),
                "half_width": half}

    def _minimise_c(self, n, lc):
        """1-D Gauss–Newton in ``log10 c`` at fixed ``n`` from a predicted ``lc``: the slope at the
        prediction (the forward sensitivities of one trial, or a forward difference of two), then
        chord steps of one trial each until the step is below 1e-7 decades. Returns
        ``(log10 c, residuals, |dr/dlog10 c|)``."""
        if self.per_event_jacobian is not None:
            r, J = self.per_event_jacobian(np.array([lc]), np.array([n]))
            r, d = r[0, self.used], J[0, self.used, 0]
            self.evaluations += 1
        if self.per_event_jacobian is None or not np.isfinite(d).all():
            h = JACOBIAN_STEP[0]
            values = self.per_event(np.array([lc, lc + h]), np.full(2, n))[:, self.used]
            self.evaluations += 2
            r, d = values[0], (values[1] - values[0]) / h
        dd = float(d @ d)
        for _ in range(8):
            step = -float(d @ r) / dd if dd > 0 else 0.0
            step = max(min(step, 0.2), -0.2)
            if abs(step) < 1e-7:
                break
            lc += step
            r = self.per_event(np.array([lc]), np.array([n]))[0, self.used]
            self.evaluations += 1
        return lc, r, math.sqrt(dd)

    def run(self, direction: int) -> pd.DataFrame:
        x_hat = self.fit.x
        jc = float(np.sqrt(np.sum(self.fit.jacobian[:, 0] ** 2)))
        rows = [self._row(float(x_hat[1]), float(x_hat[0]), self.fit.residuals, jc)]
        n_lo, n_hi = self.n_bounds
        step = self.first_step
        prev_n, prev_lc = float(x_hat[1]), float(x_hat[0])
        slope = self.slope
        limit = PROFILE_REACH * self.fit.threshold
        # until the threshold is crossed the interval reaches the bound (or the profile's last point)
        self.touch[direction] = True
        self.ends[direction] = n_hi if direction > 0 else n_lo
        for _ in range(PROFILE_MAX_POINTS):
            n = prev_n + direction * step
            at_bound = n <= n_lo or n >= n_hi
            n = min(max(n, n_lo), n_hi)
            lc, r, jc = self._minimise_c(n, prev_lc + slope * (n - prev_n))
            row = self._row(n, lc, r, jc)
            rows.append(row)
            drss = row["rss"] - self.fit.rss
            if drss < -1e-9 * max(self.fit.rss, 1e-300) and drss < -0.01 * self.fit.threshold:
                self.better_point = (lc, n)
                break
            previous = rows[-2]["rss"] - self.fit.rss
            if drss >= self.fit.threshold > previous:
                # crossing between the last two points: interpolate in sqrt(dRSS) (linear near a minimum)
                a, b = math.sqrt(max(previous, 0.0)), math.sqrt(drss)
                w = (math.sqrt(self.fit.threshold) - a) / (b - a) if b > a else 1.0
                self.ends[direction] = prev_n + w * (n - prev_n)
                self.touch[direction] = False
            if drss >= limit:
                break
            if at_bound:
                break
            slope = (lc - prev_lc) / (n - prev_n) if n != prev_n else slope
            rise = drss - previous
            if rise < 0.05 * self.fit.threshold:
                step = min(2.0 * step, 0.25)
            elif rise > 0.5 * self.fit.threshold:
                step = max(0.5 * step, 1e-4)
            prev_n, prev_lc = n, lc
        return pd.DataFrame(rows)

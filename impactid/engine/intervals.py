"""The engine's uncertainty: covariance, standard errors, intervals, bound hits and correlations at
the optimum of a search (:func:`uncertainty`), and the linearised bootstrap over groups of residuals
(:func:`linearised_bootstrap`)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from impactid.engine.covariance import Covariance, covariance_from_jacobian
from impactid.engine.distributions import two_sided_quantile
from impactid.engine.least_squares import Search
from impactid.results import Parameter

__all__ = ["BOUND_TOLERANCE", "Uncertainty", "linearised_bootstrap", "safe_exp", "uncertainty"]

#: A value within this fraction of a bound's magnitude (at least 1) counts as on the bound [-].
BOUND_TOLERANCE = 1e-6
#: The largest argument of ``exp`` whose value is a finite float (``ln`` of the largest float).
_LOG_MAX_FLOAT = math.log(np.finfo(float).max)


def safe_exp(u: float) -> float:
    """``exp(u)`` without the overflow: ``inf`` beyond the largest float (a log-coordinate interval whose
    standard error is huge reaches there), 0 below the smallest, NaN for NaN."""
    u = float(u)
    if math.isnan(u):
        return math.nan
    if u > _LOG_MAX_FLOAT:
        return math.inf
    return math.exp(u)

@dataclass(frozen=True)
class Uncertainty:
    """How well a search determined its parameters.

    Attributes
    ----------
    covariance : of the varying parameters in search coordinates (:class:`~impactid.engine.covariance.Covariance`).
    scale : the variance scale applied (the reduced chi-square, or the given one).
    dof : degrees of freedom (data minus varying parameters).
    confidence : nominal coverage of the intervals.
    parameters : the reported parameters as :class:`~impactid.results.Parameter` (value, stderr,
        interval, bounds, unit, a note where undetermined or on a bound).
    notes : what qualifies the fit (undetermined directions, bound hits).
    statistics : ``ndata``, ``nvarys``, ``dof``, ``reduced_chi_square``, ``condition_number``,
        ``cost``, ``nfev``, ``success``.
    correlation : the correlation matrix of the varying parameters (NaN where undetermined).
    names : the varying parameters' names (rows and columns of ``correlation``).
    """

    covariance: Covariance
    scale: float
    dof: int
    confidence: float
    parameters: tuple[Parameter, ...]
    notes: tuple[str, ...]
    statistics: Mapping[str, float]
    correlation: np.ndarray
    names: tuple[str, ...] = field(default=())

    def stderr(self, name: str) -> float:
        """Standard error of a varying parameter in its search coordinate."""
        return float(self.covariance.stderr[self.names.index(name)])


def uncertainty(found: Search, *, confidence: float = 0.95, scale: float | None = None,
                dof: int | None = None) -> Uncertainty:
    """Covariance, intervals, bound hits and correlations at the optimum of a search.

    Parameters
    ----------
    found : the :class:`Search`.
    confidence : nominal coverage of the intervals (Student-t with the fit's degrees of freedom;
        normal with zero degrees of freedom and a known scale).
    scale : variance of the residual; None: the reduced chi-square ``2 cost / dof`` (lmfit's
        ``scale_covar``: the residuals' own scatter, right when the weights are relative), else a
        known value (1 for residuals weighted by a noise that is known). With a known scale, as
        many data as parameters (zero degrees of freedom) still determine an uncertainty.
    dof : the degrees of freedom, when the fit eliminated parameters in closed form that the
        search does not see (default: data minus varying parameters).
    """
    varying = found.varying
    names = tuple(p.name for p in varying)
    n_data = found.residual.size
    dof = n_data - len(varying) if dof is None else int(dof)
    if dof < 0 or (dof == 0 and scale is None):
        raise ValueError(f"{n_data} data cannot determine {len(varying)} parameters"
                         + (" and the residual's scale" if dof == 0 else ""))
    s2 = float(2.0 * found.cost / dof) if scale is None else float(scale)
    covariance = covariance_from_jacobian(found.jacobian, s2, names=names)
    notes = [covariance.reason] if covariance.reason else []
    q = two_sided_quantile(confidence, dof)
    values = found.values()
    parameters, k, on_bound = [], 0, []
    for p in found.free:
        if not p.vary:
            if p.report:
                parameters.append(Parameter(p.name, p.value, 0.0, (p.value, p.value), confidence, True, p.unit,
                                            "fixed", min=p.min, max=p.max))
            continue
        x, se = float(found.x[k]), float(covariance.stderr[k])
        k += 1
        lo_b, hi_b = p.bounds()
        near = BOUND_TOLERANCE * max(1.0, abs(lo_b) if math.isfinite(lo_b) else 1.0,
                                     abs(hi_b) if math.isfinite(hi_b) else 1.0)
        hit = (math.isfinite(lo_b) and abs(x - lo_b) <= near) or (math.isfinite(hi_b) and abs(x - hi_b) <= near)
        if hit:
            on_bound.append(p.name)
        if not p.report:
            continue
        value = values[p.name]
        if math.isfinite(se):
            interval = (x - q * se, x + q * se)
            stderr = value * se if p.log else se
            if p.log:
                interval = (safe_exp(interval[0]), safe_exp(interval[1]))
            note = "on a bound of the search: the data do not bound it inside" if hit else ""
        else:
            interval, stderr, note = (math.nan, math.nan), math.nan, "undetermined by the data"
        parameters.append(Parameter(p.name, value, stderr, interval, confidence, False, p.unit, note,
                                    min=p.min, max=p.max))
    if on_bound:
        notes.append(f"{', '.join(on_bound)} on a bound of the search: the data do not bound "
                     f"{'it' if len(on_bound) == 1 else 'them'} inside (intervals not reliable)")
    statistics = {"ndata": n_data, "nvarys": len(varying), "dof": dof,
                  "reduced_chi_square": float(2.0 * found.cost / dof) if dof else math.nan, "variance_scale": s2,
                  "condition_number": covariance.condition, "cost": found.cost, "nfev": found.nfev,
                  "success": found.success}
    return Uncertainty(covariance=covariance, scale=s2, dof=dof, confidence=confidence, parameters=tuple(parameters),
                       notes=tuple(notes), statistics=statistics, correlation=covariance.correlation, names=names)


def linearised_bootstrap(jacobian: np.ndarray, residual: np.ndarray, resamples: int, seed: int) -> np.ndarray:
    """Bootstrap over the rows of a least-squares problem, linearised at its optimum.

    Each resample draws the rows (events, impacts) with replacement (multinomial weights, numpy's
    ``default_rng(seed)``) and takes one weighted Gauss–Newton step from the optimum,
    ``dx = -(J^T W J)^+ J^T W r`` (least squares, so that a resample that leaves a direction
    undetermined gives its minimum-norm step). No model is evaluated: the cost is ``resamples``
    small least-squares solves.

    Parameters
    ----------
    jacobian : ``(m, p)`` Jacobian of the residual at the optimum, in the search coordinates.
    residual : ``(m,)`` residual at the optimum.
    resamples : number of bootstrap resamples.
    seed : seed of the resampling.

    Returns
    -------
    ``(resamples, p)`` steps ``dx`` from the optimum, one row per resample (add them to the optimum's
    coordinates and map to the reported parameters).
    """
    J = np.asarray(jacobian, dtype=float)
    r = np.asarray(residual, dtype=float)
    rng = np.random.default_rng(seed)
    m = r.size
    weights = rng.multinomial(m, np.full(m, 1.0 / m), size=resamples).astype(float)
    steps = np.empty((resamples, J.shape[1]))
    for k, w in enumerate(weights):
        normal = J.T @ (w[:, None] * J)
        steps[k] = -np.linalg.lstsq(normal, J.T @ (w * r), rcond=None)[0]
    return steps

"""The identification engine every rig's fit uses: the search, the uncertainty and the model check.

A rig gives the engine its residual (and, where its kernel integrates sensitivities, the Jacobian)
as functions of the searched parameters, described like lmfit's parameters (:class:`Free`: name,
value, min, max, vary). The engine then

1. **searches** (:func:`search`): scipy's trust-region reflective least squares within the bounds,
   with the analytic Jacobian or finite differences, from one or several starts (the best cost
   wins; every start is recorded);
2. **states the uncertainty** (:func:`uncertainty`): the covariance from the Jacobian at the optimum
   by the shared rule of :func:`impactid.covariance.covariance_from_jacobian` (undetermined
   directions are reported, never inverted), scaled by the reduced chi-square (lmfit's
   ``scale_covar``) or by a known noise, Student-t intervals mapped back through a logarithmic
   coordinate where a parameter is searched in one, bound hits, and the correlation matrix;
3. **checks the model** (:func:`residual_against_noise`): the residual against the recording's own
   noise, with a note when the model does not describe the data.

The rig keeps what is its own: its residual, the noise it measures, its tables and its result
type (a :class:`~impactid.results.FitResult` built from :attr:`Uncertainty.parameters`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy import optimize, stats

from impactid.covariance import Covariance, covariance_from_jacobian
from impactid.results import Parameter

__all__ = ["BOUND_TOLERANCE", "LACK_OF_FIT_FACTOR", "Free", "Search", "Uncertainty", "residual_against_noise",
           "search", "uncertainty"]

#: A value within this fraction of a bound's magnitude (at least 1) counts as on the bound [-].
BOUND_TOLERANCE = 1e-6
#: A residual RMS more than this many times the noise's is a lack of fit [-].
LACK_OF_FIT_FACTOR = 1.5
#: Sigmas of the chi-square spread by which the residual's mean square may exceed the noise's before
#: the excess is reported as systematic.
SIGNIFICANT_EXCESS_SIGMAS = 3.0
#: Smallest reported excess of the residual's mean square over the noise's [-].
SIGNIFICANT_EXCESS_FLOOR = 0.02


@dataclass(frozen=True)
class Free:
    """A parameter of the search, described as lmfit describes one.

    Attributes
    ----------
    name : the parameter's name.
    value : the start value [unit] (the true value, not its logarithm, when ``log``).
    min, max : the bounds of the search [unit].
    vary : False holds the parameter at ``value`` (it is reported as fixed).
    unit : SI unit of the value.
    log : search ``ln(value)`` (a positive parameter spanning decades); the standard error and the
        interval are mapped back (``stderr = value * stderr_ln``, interval ``exp`` of the bounds).
    report : whether the parameter appears in the result's parameters (False for nuisance
        parameters such as per-impact onset times, which the rig reports in its tables).
    """

    name: str
    value: float
    min: float = -math.inf
    max: float = math.inf
    vary: bool = True
    unit: str = ""
    log: bool = False
    report: bool = True

    def __post_init__(self) -> None:
        if not (self.min <= self.value <= self.max):
            raise ValueError(f"parameter {self.name!r}: start {self.value!r} outside [{self.min!r}, {self.max!r}]")
        if self.log and not self.value > 0.0:
            raise ValueError(f"parameter {self.name!r}: a logarithmic coordinate needs a positive value")

    def coordinate(self, value: float) -> float:
        """The search coordinate of ``value`` (its logarithm when ``log``)."""
        return math.log(value) if self.log else float(value)

    def bounds(self) -> tuple[float, float]:
        """The bounds in the search coordinate."""
        if not self.log:
            return float(self.min), float(self.max)
        return (math.log(self.min) if self.min > 0.0 else -math.inf), (math.log(self.max) if self.max < math.inf
                                                                        else math.inf)


@dataclass(frozen=True)
class Search:
    """Where the search ended.

    Attributes
    ----------
    free : the parameters searched (all of them, varying or not).
    x : the varying parameters at the optimum, in search coordinates.
    residual : the residual vector there (weighted as the rig's residual function returns it).
    jacobian : its Jacobian with respect to ``x``.
    cost : half the sum of squared residuals.
    nfev : residual evaluations over all starts.
    success : whether the best start's search converged.
    message : the optimiser's message for the best start.
    starts : one record per start: its values, cost, evaluations, success.
    """

    free: tuple[Free, ...]
    x: np.ndarray
    residual: np.ndarray
    jacobian: np.ndarray
    cost: float
    nfev: int
    success: bool
    message: str
    starts: tuple[dict, ...] = ()

    @property
    def varying(self) -> tuple[Free, ...]:
        return tuple(p for p in self.free if p.vary)

    def values(self) -> dict[str, float]:
        """Every parameter's value at the optimum [unit] (fixed ones at their given value)."""
        out, k = {}, 0
        for p in self.free:
            if p.vary:
                out[p.name] = math.exp(self.x[k]) if p.log else float(self.x[k])
                k += 1
            else:
                out[p.name] = float(p.value)
        return out


def _full_vector(free: Sequence[Free], x: np.ndarray) -> np.ndarray:
    """Search coordinates of every parameter (fixed ones at their value) from the varying ones."""
    out = np.empty(len(free))
    k = 0
    for i, p in enumerate(free):
        if p.vary:
            out[i] = x[k]
            k += 1
        else:
            out[i] = p.coordinate(p.value)
    return out


def search(residual: Callable[[np.ndarray], np.ndarray], free: Sequence[Free], *,
           jacobian: Callable[[np.ndarray], np.ndarray] | None = None,
           starts: Sequence[Mapping[str, float]] = (), xtol: float = 1e-12, ftol: float = 1e-12,
           gtol: float = 1e-12, max_nfev: int | None = None, x_scale: str | float = "jac",
           differences: str = "3-point", diff_step: float | None = None, tr_solver: str | None = None,
           normalise: bool = True) -> Search:
    """Least squares within bounds from one or several starts; the lowest cost wins.

    Parameters
    ----------
    residual : ``residual(u) -> r``: the (noise-weighted) residual vector for the search
        coordinates ``u`` of *every* parameter in ``free`` order (fixed ones at their value, logs
        where ``log``), so that a rig writes one function whatever is held fixed.
    free : the parameters (:class:`Free`).
    jacobian : ``jacobian(u) -> J`` with one column per parameter in ``free`` (the columns of fixed
        parameters are dropped here); None: finite differences, ``differences`` (``"3-point"``,
        central, by default: the covariance is read from this Jacobian, and one-sided differences
        bias the standard errors by about 1e-5 relative on NIST's Misra1a; ``"2-point"`` halves
        the cost) with ``diff_step``.
    tr_solver : the trust-region subproblem solver of :func:`scipy.optimize.least_squares` (None:
        its default, ``"exact"`` for dense Jacobians; ``"lsmr"`` for large or nearly singular
        problems such as rig F's Gaussian-sum cam profile, where the exact solver wanders along
        flat valleys).
    normalise : divide each coordinate by the magnitude of its start value (1 for a start at 0)
        during the search, so that a parameter of 5e-4 and one of 2e2 take comparable
        finite-difference steps and tolerances; False searches the coordinates as given (for a
        residual whose coordinates are already of comparable size, or to reproduce a fit
        written without it). A parameter that starts near 0 but moves far (a phase) is better
        searched unnormalised or started at its typical size.
    starts : each a mapping of parameter name -> start value [unit] overriding ``Free.value``;
        empty: the ``Free`` values alone.
    xtol, ftol, gtol, max_nfev, x_scale, diff_step : of :func:`scipy.optimize.least_squares`
        (trust-region reflective). The defaults stop on the parameters' relative change of 1e-12,
        tighter than any interval the fits report, so that the stopping rule does not move a
        result by more than round-off on the scale of its uncertainty.

    Returns
    -------
    Search
    """
    free = tuple(free)
    varying = [i for i, p in enumerate(free) if p.vary]
    if not varying:
        raise ValueError("no parameter varies")
    # the search runs in coordinates divided by their start magnitudes, so that a parameter of
    # 5e-4 and one of 2e2 take comparable finite-difference steps and tolerances
    typical = np.array([(abs(free[i].coordinate(free[i].value)) or 1.0) if normalise else 1.0 for i in varying])
    lower = np.array([free[i].bounds()[0] for i in varying]) / typical
    upper = np.array([free[i].bounds()[1] for i in varying]) / typical

    def fun(z):
        return residual(_full_vector(free, z * typical))

    jac = None
    if jacobian is not None:
        def jac(z):
            return np.asarray(jacobian(_full_vector(free, z * typical)))[:, varying] * typical

    tried, best = [], None
    for start in (starts or ({},)):
        unknown = set(start) - {p.name for p in free}
        if unknown:
            raise ValueError(f"start names unknown parameters: {', '.join(sorted(unknown))}")
        z0 = np.array([free[i].coordinate(start.get(free[i].name, free[i].value)) for i in varying]) / typical
        span = np.maximum(np.abs(lower), np.abs(upper))
        inside = 1e-12 * np.where(np.isfinite(span), span, 0.0)
        z0 = np.clip(z0, lower + inside, upper - inside)
        options = dict(bounds=(lower, upper), method="trf", x_scale=x_scale, xtol=xtol, ftol=ftol, gtol=gtol,
                       max_nfev=max_nfev)
        if tr_solver is not None:
            options["tr_solver"] = tr_solver
        if jac is not None:
            options["jac"] = jac
        else:
            options["jac"] = differences
            if diff_step is not None:
                options["diff_step"] = diff_step
        sol = optimize.least_squares(fun, z0, **options)
        tried.append({**{free[i].name: start.get(free[i].name, free[i].value) for i in varying},
                      "cost": float(sol.cost), "nfev": int(sol.nfev), "success": bool(sol.success)})
        if best is None or sol.cost < best.cost:
            best = sol
    return Search(free=free, x=np.asarray(best.x, dtype=float) * typical, residual=np.asarray(best.fun, dtype=float),
                  jacobian=np.asarray(best.jac, dtype=float) / typical, cost=float(best.cost),
                  nfev=int(sum(t["nfev"] for t in tried)), success=bool(best.success), message=str(best.message),
                  starts=tuple(tried))


@dataclass(frozen=True)
class Uncertainty:
    """How well a search determined its parameters.

    Attributes
    ----------
    covariance : of the varying parameters in search coordinates (:class:`~impactid.covariance.Covariance`).
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
    q = float(stats.t.ppf(0.5 + 0.5 * confidence, dof) if dof > 0 else stats.norm.ppf(0.5 + 0.5 * confidence))
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
                interval = (math.exp(interval[0]), math.exp(interval[1]))
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


def residual_against_noise(residual: np.ndarray, noise_sd: float | np.ndarray, *, what: str,
                           unit: str = "") -> tuple[dict[str, float], tuple[str, ...]]:
    """Whether a model describes the data: its residual against the recording's own noise.

    Parameters
    ----------
    residual : measured minus model [unit].
    noise_sd : the noise standard deviation the recording shows where the model has nothing to
        explain (between impacts, before a trigger, ...) [unit]; one value or one per sample.
    what : what the residual is of (a channel's name), for the notes.
    unit : its unit, for the notes.

    Returns
    -------
    statistics : ``residual_rms`` [unit], ``noise_sd`` [unit] (the median), and
        ``residual_over_noise`` (RMS of the residual in units of the noise).
    notes : a lack of fit (the ratio above :data:`LACK_OF_FIT_FACTOR`), or a significant systematic
        excess (the mean square above ``1 + max(3 sqrt(2 / N), 0.02)`` times the noise's, the
        chi-square spread of N samples).
    """
    residual = np.asarray(residual, dtype=float)
    noise = np.broadcast_to(np.asarray(noise_sd, dtype=float), residual.shape)
    rms = float(np.sqrt(np.mean(residual**2)))
    ratio = float(np.sqrt(np.mean((residual / noise) ** 2)))
    statistics = {"residual_rms": rms, "noise_sd": float(np.median(noise)), "residual_over_noise": ratio}
    excess = max(SIGNIFICANT_EXCESS_SIGMAS * math.sqrt(2.0 / max(residual.size, 1)), SIGNIFICANT_EXCESS_FLOOR)
    unit_text = f" {unit}" if unit else ""
    if ratio > LACK_OF_FIT_FACTOR:
        return statistics, (f"lack of fit: the residual RMS of {what!r} ({rms:.4g}{unit_text}) is {ratio:.3g} times "
                            f"its noise (more than {LACK_OF_FIT_FACTOR:g}): the model does not describe everything "
                            "in the data; the intervals assume the model",)
    if ratio**2 > 1.0 + excess:
        return statistics, (f"the residual of {what!r} exceeds its noise significantly (mean square {ratio**2:.3g} "
                            f"times the noise's, more than 1 + {excess:.2g} for {residual.size} samples): a "
                            "systematic misfit below the noise level",)
    return statistics, ()

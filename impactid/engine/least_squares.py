"""The engine's search: lmfit-like parameters (:class:`Free`) and trust-region least squares from
one or several starts (:func:`search`)."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from scipy import optimize

__all__ = ["Free", "Search", "search"]


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
           starts: Sequence[Mapping[str, float]] = (), xtol: float = 1e-12, ftol: float | None = 1e-15,
           gtol: float | None = None, max_nfev: int | None = None, x_scale: str | float = "jac",
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
        (trust-region reflective; None disables a test). The defaults stop on the parameters'
        relative change of 1e-12, or on a relative decrease of the cost below 1e-15 (about 5 eps:
        the cost no longer decreases beyond its own round-off), so that the stopping rule does not
        move a result by more than round-off on the scale of its uncertainty. A looser ``ftol``
        stops about ``sqrt(ftol * dof)`` standard deviations short of the optimum (1e-12 left
        NIST's ENSO at 5 significant digits). scipy's ``gtol`` is absolute, in the residual's
        units, so it is off by default: 1e-12 stopped NIST's Lanczos1 (residuals of 1e-13) 0.4
        standard deviations short, its standard errors wrong in the third digit
        (tests/test_engine_nist.py).

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

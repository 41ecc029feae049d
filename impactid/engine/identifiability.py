"""The engine's identifiability block: what the data determine, and how well (docs/identifiability.md).

:func:`identifiability` describes the optimum of a search, from its Jacobian and (where a refit is
affordable) from profiles:

* the **condition number** of the column-scaled ``J^T J`` (:mod:`impactid.engine.covariance`: above
  :data:`~impactid.engine.covariance.CONDITION_LIMIT` the standard errors are undetermined);
* the **correlation matrix** of the reported parameters and its largest entry;
* the parameters **on or near a bound** of the search (within :data:`NEAR_BOUND_STDERR` standard
  errors): their intervals are cut by the bound, not by the data;
* the **profile shape** of each parameter: ``bounded`` (the fit worsens by the 95 % threshold of
  ``chi^2_1``, :data:`PROFILE_THRESHOLD`, on both sides within the bounds), ``one-sided`` (on one
  side only: the other runs into a bound or stays flat), ``flat`` (on neither: the data do not
  determine it). The profile is the **refit** one where the fit can afford it (every other
  parameter re-optimised at fixed values of this one: the likelihood profile, which sees the
  curvature and the bounds of the real problem), else the **quadratic** model ``chi^2 = k^2`` at
  ``k`` standard errors from ``J^T J`` at the optimum (which sees only the bounds); the block says
  which;
* where a fit offers a choice between laws (``n`` free or fixed; a constant or a speed-dependent
  restitution), :func:`compare_models`: AIC, BIC and the likelihood-ratio test of the nested pair.

The block is a plain JSON-ready mapping (the :attr:`impactid.results.FitResult.identifiability`
of every fit).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from impactid.engine.covariance import CONDITION_LIMIT
from impactid.engine.distributions import chi2_quantile, chi2_sf, two_sided_quantile
from impactid.engine.intervals import BOUND_TOLERANCE, Uncertainty, safe_exp
from impactid.engine.least_squares import Search, search

__all__ = ["LRT_SIGNIFICANCE", "NEAR_BOUND_STDERR", "PROFILE_STEPS", "PROFILE_THRESHOLD", "compare_models",
           "identifiability", "profile_interval", "profile_note", "profile_shape"]

#: A parameter within this many standard errors of a bound of its search is "near" it.
NEAR_BOUND_STDERR = 2.0
#: The rise of ``chi^2`` (in units of the residual variance) that bounds a 95 % profile interval:
#: the 0.95 quantile of ``chi^2_1``.
PROFILE_THRESHOLD = chi2_quantile(0.95, 1)
#: Standard errors from the optimum at which a profile is evaluated on each side: the first beyond the
#: 95 % threshold of a quadratic profile, then three times farther for a profile flatter than that.
PROFILE_STEPS = (2.0, 6.0)
#: The simpler of two nested laws is kept unless the likelihood-ratio test rejects it at this level.
LRT_SIGNIFICANCE = 0.05


def profile_shape(rise_low: float, rise_high: float, threshold: float = PROFILE_THRESHOLD) -> str:
    """``bounded``, ``one-sided`` or ``flat`` from the largest rises of ``chi^2`` found on each side."""
    low, high = rise_low >= threshold, rise_high >= threshold
    return "bounded" if low and high else ("one-sided" if low or high else "flat")


def profile_note(name: str, shape: str) -> str:
    """The note of a profile that is not bounded (``shape`` one-sided or flat: :func:`profile_shape`)."""
    where = ("on one side only (a bound of the search or a flat side on the other)" if shape == "one-sided"
             else "on neither side")
    return f"the profile of {name} is {shape}: the data bound it {where}"


def _side_points(x: float, se: float, lo: float, hi: float, side: int) -> list[float]:
    """The profile's coordinates on one side: :data:`PROFILE_STEPS` standard errors out, stopped at the bound."""
    points = []
    for k in PROFILE_STEPS:
        target = x + side * k * se
        bound = lo if side < 0 else hi
        if math.isfinite(bound) and (target - bound) * side >= 0.0:
            if abs(bound - x) > BOUND_TOLERANCE * max(1.0, abs(bound)):
                points.append(bound)
            break
        points.append(target)
    return points


def _refit_rise(residual: Callable, found: Search, index: int, coordinate: float, scale: float,
                options: Mapping[str, Any]) -> tuple[float, int]:
    """``(chi^2(fixed) - chi^2(optimum)) / scale`` with the ``index``-th parameter of ``found.free`` held at
    ``coordinate`` (search coordinates) and the others re-optimised from the optimum; and the evaluations."""
    values = found.values()
    fixed = found.free[index]
    value = safe_exp(coordinate) if fixed.log else coordinate
    free = tuple(replace(p, vary=False, value=value, min=min(p.min, value), max=max(p.max, value)) if i == index
                 else replace(p, value=min(max(values[p.name], p.min), p.max)) for i, p in enumerate(found.free))
    if not any(p.vary for p in free):
        r = np.asarray(residual(np.array([p.coordinate(p.value) for p in free])), dtype=float)
        return float(r @ r - 2.0 * found.cost) / scale, 1
    again = search(residual, free, **dict(options))
    return float(2.0 * again.cost - 2.0 * found.cost) / scale, again.nfev


def identifiability(found: Search, fit: Uncertainty, *, residual: Callable[[np.ndarray], np.ndarray] | None = None,
                    profile: Sequence[str] | None = None, search_options: Mapping[str, Any] | None = None,
                    quadratic_reason: str = "", comparison: Mapping[str, Any] | None = None,
                    names: Sequence[str] | None = None, describes_data: bool | None = None) -> dict[str, Any]:
    """The identifiability block of a fit at the optimum of its search.

    Parameters
    ----------
    found : the :class:`~impactid.engine.Search` (its Jacobian, bounds and optimum).
    fit : its :class:`~impactid.engine.Uncertainty` (covariance, standard errors, variance scale).
    residual : the search's residual function (``u -> r``, every parameter's coordinate); with it the
        profiles of the parameters named in ``profile`` are refits (the others re-optimised at each
        fixed value), else every profile is quadratic.
    profile : the parameters profiled by refit (default: every reported varying one when ``residual``
        is given); the others get the quadratic profile.
    search_options : keyword arguments of the refits' :func:`~impactid.engine.search` (tolerances,
        ``max_nfev``, ``diff_step``, ...), as the fit's own search had them.
    quadratic_reason : why the profiles are quadratic (e.g. "a refit costs 200 simulations"), for the block.
    comparison : a :func:`compare_models` block, where the fit offers a choice between laws.
    names : the parameters described (default: the reported varying ones; nuisance parameters such as
        onset times are left out of the block but not of the covariance).
    describes_data : the model check's verdict (:attr:`~impactid.engine.ModelCheck.describes_data`):
        False never lets the block say ``determined`` (a model that does not describe its data
        determines nothing about the system, however well conditioned).

    Returns
    -------
    dict
        ``condition_number``, ``condition_limit``, ``names``, ``correlation`` (of ``names``),
        ``largest_correlation`` (``pair``, ``value``), ``near_bounds`` (``name``, ``bound``, ``value``,
        ``distance_stderr``, ``on_bound``), ``profiles`` (per name: ``shape``, ``method``, ``points``
        ``[[value, rise], ...]`` in the parameter's unit and units of the residual variance),
        ``profile_threshold``, ``profile_method``, ``model_comparison``, ``determined`` and ``notes``.
    """
    varying = [p for p in found.free if p.vary]
    index_of = {p.name: k for k, p in enumerate(varying)}
    full_index = {p.name: i for i, p in enumerate(found.free)}
    described = [p.name for p in varying if p.report] if names is None else [n for n in names if n in index_of]
    sel = [index_of[n] for n in described]
    corr = np.asarray(fit.correlation, dtype=float)[np.ix_(sel, sel)] if sel else np.zeros((0, 0))
    largest: dict[str, Any] = {"pair": [], "value": math.nan}
    for a in range(len(sel)):
        for b in range(a + 1, len(sel)):
            v = float(corr[a, b])
            if math.isfinite(v) and not abs(v) <= abs(largest["value"]):
                largest = {"pair": [described[a], described[b]], "value": v}
    scale = float(fit.scale) if fit.scale > 0 else 1.0
    refit = set(profile if profile is not None else described) if residual is not None else set()
    options = dict(search_options or {})
    near, profiles, notes = [], {}, []
    evaluations = 0
    for name in described:
        k = index_of[name]
        p = varying[k]
        x = float(found.x[k])
        se = float(fit.covariance.stderr[k])
        lo, hi = p.bounds()

        def value_of(u: float, p=p) -> float:
            return safe_exp(u) if p.log else u

        for bound, where in ((lo, "min"), (hi, "max")):
            if not math.isfinite(bound):
                continue
            on = abs(x - bound) <= BOUND_TOLERANCE * max(1.0, abs(bound))
            distance = abs(x - bound) / se if se > 0 and math.isfinite(se) else (0.0 if on else math.inf)
            if on or distance < NEAR_BOUND_STDERR:
                near.append({"name": name, "bound": where, "value": value_of(bound), "distance_stderr": distance,
                             "on_bound": bool(on)})
        if not (math.isfinite(se) and se > 0):
            profiles[name] = {"shape": "flat", "method": "none: the standard error is undetermined", "points": []}
            continue
        rises = {-1: 0.0, 1: 0.0}
        points = []
        use_refit = name in refit
        for side in (-1, 1):
            for u in _side_points(x, se, lo, hi, side):
                if use_refit:
                    try:
                        rise, nfev = _refit_rise(residual, found, full_index[name], u, scale, options)
                    except (ValueError, ArithmeticError) as exc:
                        notes.append(f"the profile of {name} could not be refitted at {value_of(u):.6g}: {exc}")
                        rise, nfev = math.nan, 0
                    evaluations += nfev
                else:
                    rise = ((u - x) / se) ** 2
                points.append([value_of(u), rise])
                if math.isfinite(rise):
                    rises[side] = max(rises[side], rise)
                if rise >= PROFILE_THRESHOLD:
                    break
        points.sort(key=lambda q: q[0])
        shape = profile_shape(rises[-1], rises[1])
        profiles[name] = {"shape": shape, "method": "refit" if use_refit else "quadratic", "points": points}
        if shape != "bounded":
            notes.append(profile_note(name, shape))
    condition = float(fit.covariance.condition)
    determined = bool(fit.covariance.determined and condition <= CONDITION_LIMIT
                      and all(v["shape"] == "bounded" for v in profiles.values())
                      and not any(b["on_bound"] for b in near))
    if describes_data is False:
        determined = False
        notes.append("the model check finds that the model does not describe the data: the parameters are not "
                     "reported as determined, however well conditioned")
    if not fit.covariance.determined and fit.covariance.reason:
        notes.insert(0, fit.covariance.reason)
    for b in near:
        how = "is on" if b["on_bound"] else f"lies within {b['distance_stderr']:.2g} standard errors of"
        notes.append(f"{b['name']} {how} its {b['bound']} bound ({b['value']:.6g}): its interval is cut by the "
                     "bound, not by the data")
    methods = {v["method"] for v in profiles.values() if v["method"] in ("refit", "quadratic")}
    method = ("refit: every other parameter re-optimised at each fixed value" if methods == {"refit"} else
              "quadratic: chi^2 = k^2 at k standard errors from J^T J at the optimum (the bounds are seen, the "
              "curvature is not)" + (f"; {quadratic_reason}" if quadratic_reason else "") if methods == {"quadratic"}
              else "mixed: refit for " + ", ".join(n for n, v in profiles.items() if v["method"] == "refit")
              + ", quadratic for the others" if methods else "none")
    return {"condition_number": condition, "condition_limit": CONDITION_LIMIT, "names": list(described),
            "correlation": corr.tolist(), "largest_correlation": largest, "near_bounds": near,
            "profiles": profiles, "profile_threshold": PROFILE_THRESHOLD, "profile_method": method,
            "profile_evaluations": int(evaluations), "model_comparison": dict(comparison) if comparison else None,
            "determined": determined, "notes": list(dict.fromkeys(notes))}


def compare_models(models: Sequence[Mapping[str, Any]], nested: Sequence[tuple[str, str]] = (), *,
                   choice: str = "", known_scale: bool = False) -> dict[str, Any]:
    """AIC, BIC and likelihood-ratio tests between laws fitted to the same data.

    Parameters
    ----------
    models : each ``name``, ``n_params`` (fitted), ``n_data`` and the fit's ``rss`` (sum of squared
        weighted residuals) or ``loglik`` (a log-likelihood of its own).
    nested : ``(simple, general)`` pairs: ``simple`` is ``general`` with parameters held (``n`` fixed,
        a slope of 0).
    choice : what the comparison decides, in words ("n free or fixed at 1.5").
    known_scale : the weights are the noise's (the residual variance is 1, not fitted): the
        log-likelihood is ``-rss / 2`` and no scale is counted; else the Gaussian likelihood with the
        scale fitted, ``-n/2 (ln(2 pi rss / n) + 1)``, the scale counted as a parameter.

    Returns
    -------
    dict
        ``choice``, ``models`` (each with ``loglik``, ``aic``, ``bic``, ``delta_aic``, ``delta_bic``),
        ``likelihood_ratio`` (per pair: ``simple``, ``general``, ``statistic``, ``dof``, ``p_value``,
        ``rejects_simple``), ``preferred`` (the simplest model no test rejects in favour of a more
        general one, at :data:`LRT_SIGNIFICANCE`; by BIC among models no test relates) and ``rule``.
    """
    rows = []
    for m in models:
        n = int(m["n_data"])
        k = int(m["n_params"]) + (0 if known_scale else 1)
        if m.get("loglik") is not None:
            ll = float(m["loglik"])
        else:
            rss = float(m["rss"])
            ll = -0.5 * rss if known_scale else (-0.5 * n * (math.log(2.0 * math.pi * rss / n) + 1.0)
                                                 if rss > 0 else math.inf)
        rows.append({"name": str(m["name"]), "n_params": int(m["n_params"]), "n_data": n, "loglik": ll,
                     "aic": 2 * k - 2 * ll, "bic": k * math.log(max(n, 1)) - 2 * ll})
    best_aic = min((r["aic"] for r in rows if math.isfinite(r["aic"])), default=math.nan)
    best_bic = min((r["bic"] for r in rows if math.isfinite(r["bic"])), default=math.nan)
    for r in rows:
        r["delta_aic"] = r["aic"] - best_aic
        r["delta_bic"] = r["bic"] - best_bic
    by_name = {r["name"]: r for r in rows}
    tests = []
    rejected: set[str] = set()
    related: set[str] = set()
    for simple, general in nested:
        s, g = by_name[simple], by_name[general]
        dof = g["n_params"] - s["n_params"]
        statistic = max(2.0 * (g["loglik"] - s["loglik"]), 0.0) if math.isfinite(g["loglik"] - s["loglik"]) \
            else math.nan
        p = chi2_sf(statistic, dof) if dof > 0 and math.isfinite(statistic) else math.nan
        rejects = bool(p < LRT_SIGNIFICANCE)
        if rejects:
            rejected.add(simple)
        related |= {simple, general}
        tests.append({"simple": simple, "general": general, "statistic": statistic, "dof": dof, "p_value": p,
                      "rejects_simple": rejects})
    candidates = [r for r in rows if r["name"] not in rejected]
    if not candidates:
        candidates = rows
    # among the models the tests do not reject, the simplest of those the tests relate; BIC otherwise
    tested = [r for r in candidates if r["name"] in related]
    pool = tested or candidates
    preferred = min(pool, key=lambda r: (r["n_params"], r["bic"]) if tested else (r["bic"], r["n_params"]))["name"]
    return {"choice": choice, "models": rows, "likelihood_ratio": tests, "preferred": preferred,
            "known_scale": bool(known_scale),
            "rule": (f"the simpler of nested laws unless the likelihood-ratio test rejects it at p < "
                     f"{LRT_SIGNIFICANCE:g}; AIC and BIC (lmfit's definitions, the fitted scale counted) for laws "
                     "the tests do not relate")}


def profile_interval(residual: Callable[[np.ndarray], np.ndarray], found: Search, fit: Uncertainty, name: str, *,
                     confidence: float | None = None, search_options: Mapping[str, Any] | None = None,
                     max_standard_errors: float = 50.0) -> tuple[float, float]:
    """The profile-likelihood interval of one parameter: where ``chi^2`` with it held and the others
    re-optimised rises above its minimum by the threshold of ``confidence``.

    The threshold is ``t^2`` times the fit's variance scale (:attr:`Uncertainty.scale`), ``t`` the
    Student quantile of the fit's degrees of freedom (normal with none): the interval the covariance
    gives when the problem is linear, and the likelihood-ratio (F-test) interval of one parameter
    otherwise, as lmfit's ``conf_interval`` computes it. Each side is found by stepping out in standard
    errors until the rise exceeds the threshold and bisecting (relative tolerance 1e-4 of the standard
    error); a side that does not reach it within ``max_standard_errors`` or the search's bound is open
    (that bound, or infinite), as a profile that stays flat is.

    Parameters
    ----------
    residual : the search's residual function (every parameter's coordinate, as :func:`search` takes it).
    found, fit : the search and its :func:`uncertainty`.
    name : the parameter (a varying one).
    confidence : coverage (default: the fit's).
    search_options : keyword arguments of the refits' :func:`search`.
    max_standard_errors : farthest step [standard errors].

    Returns
    -------
    ``(low, high)`` in the parameter's unit (mapped back from its logarithm where it is searched in one).
    """
    names = [p.name for p in found.free]
    index = names.index(name)
    free = found.free[index]
    if not free.vary:
        return (free.value, free.value)
    k = [p.name for p in found.varying].index(name)
    x, se = float(found.x[k]), float(fit.covariance.stderr[k])
    level = fit.confidence if confidence is None else confidence
    q = two_sided_quantile(level, fit.dof)
    threshold = q * q
    options = dict(search_options or {})
    lo_bound, hi_bound = free.bounds()
    if not (math.isfinite(se) and se > 0.0):
        se = max(abs(x), 1.0) * 1e-3

    def rise(coordinate: float) -> float:
        return _refit_rise(residual, found, index, coordinate, fit.scale, options)[0]

    ends = []
    for side, bound in ((-1, lo_bound), (1, hi_bound)):
        inner, outer, step = x, None, 1.0
        while step <= max_standard_errors:
            trial = x + side * step * se
            if math.isfinite(bound) and (trial - bound) * side >= 0.0:
                trial = bound
            if rise(trial) >= threshold:
                outer = trial
                break
            inner = trial
            if trial == bound:
                break
            step *= 2.0
        if outer is None:
            ends.append(bound if math.isfinite(bound) else side * math.inf)
            continue
        while abs(outer - inner) > 1e-4 * se:
            middle = 0.5 * (inner + outer)
            if rise(middle) >= threshold:
                outer = middle
            else:
                inner = middle
        ends.append(0.5 * (inner + outer))
    low, high = ends
    if free.log:
        return (safe_exp(low), safe_exp(high))
    return (low, high)

"""Restitution laws over impacts (Sundar, Dreyer & Singh 2016, section 8).

``xi`` and ``v_a`` per impact come from the reconstruction (docs/estimation.md); ``gamma`` [s/m] of
``xi = 1 - gamma v_a`` by least squares through the law's fixed intercept, the constant-``r`` fit, a
free-intercept line (to test the law), ``xi_mean``, ``va_mean`` and the Hunt–Crossley equivalent
``beta = 1.5 gamma k_H`` [N s m^-2.5].

The model check and the honest floor of the standard errors (:func:`_checked_errors`). The residuals
of ``xi = 1 - gamma v_a`` carry no independent noise reference (the residual variance is the scale), so
the engine's check (:func:`impactid.engine.check_model`) looks at their structure: a trend with ``v_a``
within each recording, the recordings' means, and the alternation of consecutive impacts; a check that
finds structure widens the standard errors by the engine's rule. The scatter's standard errors also
miss the pipeline's own error of ``xi``, which repeats from impact to impact (a period-1 motion is
sampled at a phase that repeats with it) and so does not average down, and which the scatter need
not show at all (a settled orbit sampled alike at every impact gives identical ``xi``: a residual of
rounding and a standard error of 1e-14 s/m). The standard errors are therefore never below that of an
error :data:`XI_SYSTEMATIC` common to every impact: ``gamma``'s at least ``XI_SYSTEMATIC / mean(v_a)``,
``r_constant``'s at least ``XI_SYSTEMATIC`` (the free line's are not floored: they test the law). The
free line's intercept and slope are undetermined (NaN standard errors) when the approach speeds spread
less than ``min_spread``: a line through points at one speed is not a measurement of either. The laws
are compared (constant ``r``, ``1 - gamma v_a`` and, where the speeds spread, the free line: AIC, BIC,
likelihood-ratio tests) in the identifiability block.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pandas as pd

from impactid.engine import Free, Search, check_model, combine_checks, compare_models, identifiability, uncertainty
from impactid.errors import ImpactidError
from impactid.rigs.pivoted.estimate_results import EstimationWarning, RestitutionEstimate

__all__ = ["XI_SYSTEMATIC", "fit_restitution"]

#: The pipeline's own error of a measured ``xi`` on noise-free recordings of the restitution law (S3)
#: at 204.8 kHz, about twice the largest measured: 1.9e-3 (return-time anchor, e/r_c 0.2 at 16 Hz,
#: alternating with the impacts' sampling phase), 1.5e-3 (cam-phase anchor, the same point, common to
#: every impact), 1.5e-4 (cam-geometry) and below 3.5e-4 at e/r_c 0.25, 15 Hz. A slower recording's
#: is larger (the error comes from where the impact falls within a sample).
XI_SYSTEMATIC = 4.0e-3


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

    Raises
    ------
    ImpactidError : no impact with a determined ``xi`` and approach speed.
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
    gamma, gamma_se = _through_fixed_intercept(v, xi)
    r_const = float(np.mean(xi))
    r_se = float(np.std(xi, ddof=1) / math.sqrt(n)) if n > 1 else math.inf
    spread = float(np.std(v) / np.mean(v))
    intercept, slope, a_se, b_se = _free_line(v, xi, spread)
    notes += _law_notes(v, xi, gamma, spread, slope, b_se, min_spread)
    groups = pd.factorize(used["source"])[0] if "source" in used else None
    errors, more, blocks = _checked_errors(v, xi, gamma, {"gamma": gamma_se, "r_constant": r_se, "intercept": a_se,
                                                          "slope": b_se}, spread, min_spread, groups)
    gamma_se, r_se, a_se, b_se = (errors[k] for k in ("gamma", "r_constant", "intercept", "slope"))
    notes += more
    for message in notes if warn else ():
        warnings.warn(message, EstimationWarning, stacklevel=2)
    frame["used"] = ok
    return RestitutionEstimate(
        gamma=gamma, gamma_stderr=gamma_se, r_constant=r_const, r_constant_stderr=r_se, intercept=intercept,
        intercept_stderr=a_se, slope=slope, slope_stderr=b_se, xi_mean=float(np.mean(xi)), va_mean=float(np.mean(v)),
        va_spread=spread, beta_equivalent=float(1.5 * gamma * k_H), impacts_used=n, per_impact=frame,
        warnings=tuple(notes), model_check=blocks[0], identifiability=blocks[1])


def _through_fixed_intercept(v: np.ndarray, xi: np.ndarray) -> tuple[float, float]:
    """``gamma`` [s/m] of ``xi = 1 - gamma v_a`` by least squares, and its standard error (inf for one impact)."""
    n = v.size
    gamma = float(np.sum(v * (1.0 - xi)) / np.sum(v * v))
    resid = xi - (1.0 - gamma * v)
    gamma_se = float(math.sqrt(np.sum(resid ** 2) / (n - 1) / np.sum(v * v))) if n > 1 else math.inf
    return gamma, gamma_se


def _free_line(v: np.ndarray, xi: np.ndarray, spread: float) -> tuple[float, float, float, float]:
    """The free line ``xi = a - b v_a``: ``(a, b [s/m], se(a), se(b))``, NaN with fewer than three impacts
    or speeds that do not spread (relative ``spread`` not above 1e-6)."""
    n = v.size
    if not (n > 2 and spread > 1e-6):
        return math.nan, math.nan, math.nan, math.nan
    design = np.column_stack([np.ones(n), -v])
    coef, *_ = np.linalg.lstsq(design, xi, rcond=None)
    dof_res = xi - design @ coef
    cov = np.linalg.inv(design.T @ design) * np.sum(dof_res ** 2) / (n - 2)
    return (float(coef[0]), float(coef[1]), float(math.sqrt(max(cov[0, 0], 0.0))),
            float(math.sqrt(max(cov[1, 1], 0.0))))


def _law_notes(v: np.ndarray, xi: np.ndarray, gamma: float, spread: float, slope: float, slope_se: float,
               min_spread: float) -> list[str]:
    """What qualifies the fit: speeds too alike to test the law, ``xi`` outside [0, 1], and speeds where
    the fitted law gives ``xi < 0``."""
    notes = []
    if spread < min_spread or not (abs(slope) > 2.0 * slope_se):
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
    return notes


def _checked_errors(v: np.ndarray, xi: np.ndarray, gamma: float, stderr: dict[str, float], spread: float,
                    min_spread: float, groups: np.ndarray | None) -> tuple[dict[str, float], list[str], tuple]:
    """The model check of ``xi = 1 - gamma v_a`` and the standard errors after it (module doc: widened by a
    check that finds structure, never below the pipeline's floor :data:`XI_SYSTEMATIC`).

    Returns the standard errors [s/m for ``gamma`` and ``slope``], the notes, and the ``model_check`` and
    ``identifiability`` blocks."""
    resid = xi - (1.0 - gamma * v)
    n = v.size
    check = check_model(resid, None, noise_reference="", what="xi about 1 - gamma v_a", n_params=1, groups=groups,
                        covariate=v, covariate_name="approach speed [m/s]")
    constant = check_model(xi - xi.mean(), None, noise_reference="", what="xi about the constant r", n_params=1,
                           groups=groups, covariate=v, covariate_name="approach speed [m/s]")
    errors, notes = dict(stderr), list(check.notes) + list(constant.notes)
    floor = {"gamma": XI_SYSTEMATIC / float(np.mean(v)), "r_constant": XI_SYSTEMATIC}
    for name, value in floor.items():
        widened = (check if name == "gamma" else constant).widen_stderr(errors[name])
        errors[name] = max(widened, value) if math.isfinite(widened) else widened
    raised = [name for name, value in floor.items() if errors[name] == value]
    if raised:
        notes.append(f"the standard error of {' and '.join(raised)} is the pipeline's own floor (an error of xi of "
                     f"{XI_SYSTEMATIC:g} common to every impact: gamma {floor['gamma']:.3g} s/m, r "
                     f"{floor['r_constant']:.3g}), not the impacts' scatter, which that error need not show")
    if n > 2 and spread < min_spread:
        errors["intercept"] = errors["slope"] = math.nan
        notes.append(f"the free line's intercept and slope are undetermined: the approach speeds spread only "
                     f"{100 * spread:.2g} % (less than {100 * min_spread:g} %)")
    # the laws compared, and the identifiability of the free line xi = a - b v_a
    models = [{"name": "constant r", "n_params": 1, "n_data": n, "rss": float(np.sum((xi - xi.mean()) ** 2))},
              {"name": "1 - gamma v_a", "n_params": 1, "n_data": n, "rss": float(resid @ resid)}]
    nested = []
    design = np.column_stack([np.ones(n), -v])
    if n > 2 and spread > 1e-6:
        coef, *_ = np.linalg.lstsq(design, xi, rcond=None)
        line = xi - design @ coef
        if spread >= min_spread:  # a line through speeds that do not spread is not a law to compare
            models.append({"name": "a - b v_a", "n_params": 2, "n_data": n, "rss": float(line @ line)})
            nested = [("constant r", "a - b v_a"), ("1 - gamma v_a", "a - b v_a")]
        found = Search(free=(Free("intercept", float(coef[0])), Free("slope", float(coef[1]), unit="s/m")),
                       x=np.asarray(coef, dtype=float), residual=line, jacobian=-design, cost=0.5 * float(line @ line),
                       nfev=1, success=True, message="closed-form least squares")
    else:
        found = Search(free=(Free("gamma", float(gamma), unit="s/m"),), x=np.array([gamma]), residual=resid,
                       jacobian=v[:, None], cost=0.5 * float(resid @ resid), nfev=1, success=True,
                       message="closed-form least squares")
    comparison = compare_models(models, nested, choice="constant r, xi = 1 - gamma v_a or a free line xi = a - b v_a") \
        if all(m["rss"] > 0 for m in models) else None
    block = {}
    if found.residual.size > found.x.size:
        block = identifiability(found, uncertainty(found), comparison=comparison, describes_data=check.describes_data,
                                quadratic_reason="the laws are linear: the quadratic profile is exact")
    return errors, notes, (combine_checks([check, constant]), block)

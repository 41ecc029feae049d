"""Restitution laws over impacts (Sundar, Dreyer & Singh 2016, section 8).

``xi`` and ``v_a`` per impact come from the reconstruction (docs/estimation.md); ``gamma`` [s/m] of
``xi = 1 - gamma v_a`` by least squares through the law's fixed intercept, the constant-``r`` fit, a
free-intercept line (to test the law), ``xi_mean``, ``va_mean`` and the Hunt–Crossley equivalent
``beta = 1.5 gamma k_H`` [N s m^-2.5].
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pandas as pd

from impactid.errors import ImpactidError
from impactid.rigs.pivoted.estimate_results import EstimationWarning, RestitutionEstimate

__all__ = ["fit_restitution"]


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
    for message in notes if warn else ():
        warnings.warn(message, EstimationWarning, stacklevel=2)
    frame["used"] = ok
    return RestitutionEstimate(
        gamma=gamma, gamma_stderr=gamma_se, r_constant=r_const, r_constant_stderr=r_se, intercept=intercept,
        intercept_stderr=a_se, slope=slope, slope_stderr=b_se, xi_mean=float(np.mean(xi)), va_mean=float(np.mean(v)),
        va_spread=spread, beta_equivalent=float(1.5 * gamma * k_H), impacts_used=n, per_impact=frame,
        warnings=tuple(notes))


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

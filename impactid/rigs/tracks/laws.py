"""Impact laws fitted across the bounces of tracked balls, and the choice between them by AIC or BIC.

**Normal** (the restitution ``e_n`` of each bounce against its normal impact speed ``v_n``):
``constant`` (``e_n = e``) and ``linear`` (``e_n = e0 - gamma v_n``). Each bounce is weighted by
``1 / (s_i^2 + tau^2)``, ``s_i`` its standard error and ``tau`` the scatter of the bounces about the
constant law beyond their errors (the DerSimonian-Laird moment estimate): real bounces scatter more
than their flights' fits say (the spin, the spot of the table, the ball's seam). The covariance is
scaled by the reduced chi-square where it exceeds 1, never shrunk below what the weights say.

**Tangential** (the tangential velocity after the bounce from the one before, the spin before and
the normal impulse ``P_n = m (v_out,z - v_in,z)`` of the bounce), a rigid ball with moment of inertia
``k m R^2`` on a rigid surface with Coulomb friction (the rebound model of Nakashima et al. 2010):
the contact point slips with ``u_t = v_t - R (omega x n)``; stopping it takes the tangential impulse
``m u_t k / (1 + k)``; when friction can give it (``mu P_n`` at least that) the ball leaves rolling
(``v_t,out = v_t - u_t k / (1 + k)``), else it slides throughout (``v_t,out = v_t - mu (P_n / m)
u_t / |u_t|``). The laws: ``ratio`` (``v_t,out = beta v_t``, no friction model), ``coulomb`` (``mu``
fitted, sliding or sticking per bounce) and ``rolling`` (every bounce sticks: ``mu`` infinite, no
parameter). The residual is the outgoing tangential velocity [m/s], its scale fitted.

The fits go through the identification engine (:func:`impactid.engine.search`,
:func:`~impactid.engine.uncertainty`, :func:`~impactid.engine.check_model`,
:func:`~impactid.engine.identifiability`); :func:`select` compares the laws of one kind
(:func:`~impactid.engine.compare_models`) and picks the lowest AIC or BIC.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from scipy import stats

from impactid.engine import (
    NO_NOISE_REFERENCE,
    Free,
    ModelCheck,
    check_model,
    compare_models,
    identifiability,
    search,
    uncertainty,
)
from impactid.results import Parameter

__all__ = ["NORMAL_LAWS", "TANGENTIAL_LAWS", "LawFit", "fit_normal_law", "fit_tangential_law", "select",
           "tangential_prediction"]

#: The normal laws by name -> their parameters.
NORMAL_LAWS = {"constant": ("e",), "linear": ("e0", "gamma")}
#: The tangential laws by name -> their parameters.
TANGENTIAL_LAWS = {"ratio": ("beta",), "coulomb": ("mu",), "rolling": ()}


@dataclass(frozen=True)
class LawFit:
    """One law fitted across bounces.

    Attributes
    ----------
    kind : ``"normal"`` or ``"tangential"``.
    name : the law's name.
    params : its parameters (:class:`~impactid.results.Parameter`).
    rss : the sum of squared (weighted) residuals.
    n_data : residuals.
    check : the model check.
    identifiability : the engine's identifiability block (empty for a law without parameters).
    extra : law-specific results (the bounces that stick, the scatter ``tau``).
    """

    kind: str
    name: str
    params: tuple[Parameter, ...]
    rss: float
    n_data: int
    check: ModelCheck
    identifiability: dict[str, Any] = field(default_factory=dict)
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def n_params(self) -> int:
        return sum(1 for p in self.params if not p.fixed)

    def __getitem__(self, name: str) -> Parameter:
        return {p.name: p for p in self.params}[name]


def _scatter(e: np.ndarray, se: np.ndarray) -> float:
    """DerSimonian-Laird estimate of the scatter beyond the standard errors about a constant."""
    w = 1.0 / se ** 2
    mean = float(np.sum(w * e) / np.sum(w))
    q = float(np.sum(w * (e - mean) ** 2))
    denom = float(np.sum(w) - np.sum(w ** 2) / np.sum(w))
    return math.sqrt(max(0.0, (q - (e.size - 1)) / denom)) if denom > 0 else 0.0


def fit_normal_law(name: str, speed: np.ndarray, e: np.ndarray, se: np.ndarray, *, confidence: float = 0.95,
                   tau: float | None = None) -> LawFit:
    """Fit a normal law (:data:`NORMAL_LAWS`) to per-bounce restitutions ``e`` (standard errors ``se``)
    at normal impact speeds ``speed`` [m/s]; ``tau`` the scatter beyond ``se`` (None: estimated)."""
    if name not in NORMAL_LAWS:
        raise ValueError(f"unknown normal law {name!r}; valid: {', '.join(NORMAL_LAWS)}")
    speed, e, se = (np.asarray(a, dtype=float) for a in (speed, e, se))
    tau = _scatter(e, se) if tau is None else float(tau)
    sd = np.sqrt(se ** 2 + tau ** 2)
    need = len(NORMAL_LAWS[name]) + 1
    if e.size < need:
        raise ValueError(f"the {name} law needs at least {need} bounces, got {e.size}")
    mean = float(np.sum(e / sd ** 2) / np.sum(1 / sd ** 2))
    if name == "constant":
        free = [Free("e", mean, 0.0, 2.0)]

        def law(u):
            return np.full_like(speed, u[0])
    else:
        slope = float(np.polyfit(speed, e, 1, w=1 / sd)[0]) if np.ptp(speed) > 0 else 0.0
        free = [Free("e0", min(max(mean - slope * float(np.mean(speed)), 0.01), 1.99), 0.0, 2.0),
                Free("gamma", -slope, -5.0, 5.0, unit="s/m")]

        def law(u):
            return u[0] - u[1] * speed

    def residual(u):
        return (e - law(u)) / sd

    found = search(residual, free)
    dof = max(e.size - len(free), 1)
    fit = uncertainty(found, confidence=confidence, scale=max(1.0, 2.0 * found.cost / dof))
    check = check_model(found.residual, 1.0, noise_reference="the bounces' standard errors and their scatter tau",
                        what=f"e_n about the {name} law", n_params=len(free), covariate=speed,
                        covariate_name="normal impact speed", order=False)
    block = identifiability(found, fit, describes_data=check.describes_data)
    return LawFit("normal", name, check.widen(fit.parameters), float(np.sum(found.residual ** 2)), e.size, check,
                  block, {"tau": tau})


def tangential_prediction(mu: float, v_in: np.ndarray, v_out_z: np.ndarray, spin: np.ndarray, radius: float,
                          inertia: float) -> tuple[np.ndarray, np.ndarray]:
    """The outgoing tangential velocity [m/s] (B, 2) of the Coulomb law with sticking (module doc), and
    whether each bounce sticks (B,).

    Parameters
    ----------
    mu : the friction coefficient [-] (inf: always sticks).
    v_in : (B, 3) incoming velocities [m/s]; v_out_z : (B,) outgoing normal velocities [m/s].
    spin : (B, 3) incoming spins [rad/s]; radius [m]; inertia : ``I / (m R^2)`` [-].
    """
    v_t = v_in[:, :2]
    u_t = v_t - radius * np.column_stack([spin[:, 1], -spin[:, 0]])
    slip = np.sqrt(np.sum(u_t * u_t, axis=1))
    stop = inertia / (1.0 + inertia) * slip
    dv_n = v_out_z - v_in[:, 2]
    sticks = mu * dv_n >= stop if math.isfinite(mu) else np.ones(slip.size, dtype=bool)
    unit = u_t / np.where(slip > 0, slip, 1.0)[:, None]
    friction = np.where(sticks, stop, mu * dv_n if math.isfinite(mu) else 0.0)
    return v_t - friction[:, None] * unit, sticks


def fit_tangential_law(name: str, v_in: np.ndarray, v_out: np.ndarray, spin: np.ndarray, radius: float,
                       inertia: float, *, dimensions: np.ndarray | None = None, confidence: float = 0.95) -> LawFit:
    """Fit a tangential law (:data:`TANGENTIAL_LAWS`) to the bounces' incoming and outgoing velocities
    ``v_in``, ``v_out`` (B, 3) [m/s] and incoming spins (B, 3) [rad/s]; ``dimensions`` (B,) 2 or 3
    per bounce (a 2-D bounce contributes its ``x`` only)."""
    if name not in TANGENTIAL_LAWS:
        raise ValueError(f"unknown tangential law {name!r}; valid: {', '.join(TANGENTIAL_LAWS)}")
    v_in, v_out, spin = (np.asarray(a, dtype=float) for a in (v_in, v_out, spin))
    dims = np.full(v_in.shape[0], 3) if dimensions is None else np.asarray(dimensions)
    mask = np.column_stack([np.ones(dims.size, dtype=bool), dims == 3]).ravel()
    observed = v_out[:, :2].ravel()[mask]
    speed_n = -v_in[:, 2]

    def predict(params: np.ndarray) -> np.ndarray:
        if name == "ratio":
            return (params[0] * v_in[:, :2]).ravel()[mask]
        mu = math.inf if name == "rolling" else params[0]
        return tangential_prediction(mu, v_in, v_out[:, 2], spin, radius, inertia)[0].ravel()[mask]

    covariate = np.repeat(speed_n, 2)[mask]
    extra: dict[str, Any] = {}
    if name == "rolling":
        r = observed - predict(np.empty(0))
        check = check_model(r, None, noise_reference=NO_NOISE_REFERENCE, what="v_t,out about the rolling law",
                            unit="m/s", n_params=0, covariate=covariate, covariate_name="normal impact speed",
                            order=False)
        extra["sticking"] = int(v_in.shape[0])
        return LawFit("tangential", name, (), float(r @ r), r.size, check, {}, extra)
    if name == "ratio":
        start = float(np.sum(observed * v_in[:, :2].ravel()[mask]) / np.sum(v_in[:, :2].ravel()[mask] ** 2))
        free = [Free("beta", min(max(start, -1.9), 1.9), -2.0, 2.0)]
    else:
        free = [Free("mu", 0.2, 1e-4, 10.0, log=True)]
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        # a friction that no bounce feels (all of them stick) leaves the search flat: its scipy step
        # divides by zero; the engine then reports the parameter undetermined
        warnings.simplefilter("ignore", RuntimeWarning)
        found = search(lambda u: observed - predict(np.array([math.exp(u[0]) if free[0].log else u[0]])), free,
                       starts=({}, {free[0].name: 0.05 if name == "coulomb" else 0.5},
                               {free[0].name: 1.0 if name == "coulomb" else 0.9}))
        fit = uncertainty(found, confidence=confidence)
    check = check_model(found.residual, None, noise_reference=NO_NOISE_REFERENCE,
                        what=f"v_t,out about the {name} law", unit="m/s", n_params=1, covariate=covariate,
                        covariate_name="normal impact speed", order=False)
    block = identifiability(found, fit, describes_data=check.describes_data)
    params = check.widen(fit.parameters)
    if name == "coulomb":
        mu = found.values()["mu"]
        extra["sticking"] = int(np.sum(tangential_prediction(mu, v_in, v_out[:, 2], spin, radius, inertia)[1]))
        params = (_profile_mu(params[0], lambda m: observed - predict(np.array([m])), confidence, extra),)
    return LawFit("tangential", name, params, float(np.sum(found.residual ** 2)),
                  found.residual.size, check, block, extra)


#: The friction coefficients of the profile of ``mu`` [-] (then infinity: every bounce sticks).
_MU_GRID = np.geomspace(1e-3, 10.0, 241)


def _profile_mu(param: Parameter, residual, confidence: float, extra: dict) -> Parameter:
    """``mu``'s interval joined with its profile-likelihood interval. The Coulomb law has a kink where a
    bounce passes from sliding to sticking, and no dependence on ``mu`` at all once every bounce sticks:
    the delta method at the fitted value then gives an interval far too narrow (or none). The profile
    keeps every ``mu`` of the grid (and infinity) whose sum of squares stays below
    ``RSS_min (1 + F_{1, n-1} / (n - 1))`` (the scale unknown); reaching infinity leaves the interval open
    above (every bounce may stick: ``mu`` is only bounded below)."""
    rss = np.array([float(np.sum(residual(m) ** 2)) for m in _MU_GRID] + [float(np.sum(residual(math.inf) ** 2))])
    n = residual(param.value).size
    dof = max(n - 1, 1)
    best = min(float(np.min(rss)), float(np.sum(residual(param.value) ** 2)))
    limit = best * (1.0 + float(stats.f.ppf(confidence, 1, dof)) / dof)
    keep = np.flatnonzero(rss <= limit)
    if keep.size == 0:
        return param
    grid = np.r_[_MU_GRID, math.inf]
    low = float(grid[max(keep[0] - 1, 0)]) if keep[0] > 0 else 0.0  # the next grid value below is outside
    high = float(grid[min(keep[-1] + 1, grid.size - 1)])
    lo, hi = param.interval
    lo = low if not math.isfinite(lo) else min(lo, low)
    hi = high if not math.isfinite(hi) else max(hi, high)
    extra["mu_profile"] = [low, high]
    note = param.note
    if math.isinf(hi):
        note = ("every bounce may stick within the data's scatter: mu is bounded below only"
                + (f"; {note}" if note else ""))
    return replace(param, interval=(lo, hi), note=note)


def select(fits: Sequence[LawFit], criterion: str = "bic", nested: Sequence[tuple[str, str]] = ()) -> tuple[str, dict]:
    """The law of lowest ``criterion`` (``"aic"`` or ``"bic"``) among ``fits`` (of one kind, on the same
    data) and the comparison block (:func:`~impactid.engine.compare_models`, with ``selected`` and
    ``criterion`` added)."""
    if criterion not in ("aic", "bic"):
        raise ValueError(f"unknown criterion {criterion!r}; valid: aic, bic")
    fits = list(fits)
    block = compare_models([{"name": f.name, "n_params": f.n_params, "n_data": f.n_data, "rss": f.rss}
                            for f in fits], nested=nested, choice=f"{fits[0].kind} law")
    rows = [r for r in block["models"] if math.isfinite(r[criterion])]
    chosen = min(rows, key=lambda r: (r[criterion], r["n_params"]))["name"] if rows else fits[0].name
    block["criterion"] = criterion
    block["selected"] = chosen
    return chosen, block

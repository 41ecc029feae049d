"""Identification of a planar impact law from measured impacts, and its prediction of new impacts.

:func:`fit_planar_law` fits one law (:mod:`impactid.rigs.planar.laws`) to the measured impulses (or
post-impact velocities) of a set of impacts through the identification engine every rig uses
(:mod:`impactid.engine`): the search (trust-region reflective within the parameters' bounds, several
starts from values read off the data), the uncertainty (covariance from the Jacobian scaled by the
residual variance, Student-t intervals), the model check and the identifiability block.
:func:`fit_planar` fits every candidate law, compares them by AIC and BIC
(:func:`impactid.engine.compare_models`) and returns the selected law's fit with the comparison.

The residual of an impulse fit is the relative impulse error of each component,
``(p_pred - p_meas) / |p_meas|`` (tangential, then normal, for every impact): the least-squares
fit minimises what a prediction is scored by. The residual of a velocity fit is
``M^(1/2) (v_pred^+ - v_meas^+) / |M^(1/2) v^-|`` (three components per impact).

:func:`predict_planar` uses the pre-impact state and the contact Jacobian only (a
:class:`~impactid.rigs.planar.table.PlanarImpacts` from :func:`~impactid.rigs.planar.table.read_pre_impact`
holds nothing else); :func:`score_predictions` compares a prediction with the measured outcome,
read separately.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import replace

import numpy as np
import pandas as pd

from impactid.engine import (
    NO_NOISE_REFERENCE,
    Free,
    check_model,
    combine_checks,
    compare_models,
    identifiability,
    search,
    uncertainty,
)
from impactid.results import FitResult
from impactid.rigs.planar.laws import LAWS, PlanarLaw, get_law, outcome
from impactid.rigs.planar.parameters import PlanarBody
from impactid.rigs.planar.table import PlanarImpacts

__all__ = ["MU_MAX", "PlanarFitError", "PlanarLawFit", "fit_planar", "fit_planar_law", "predict_planar",
           "score_predictions"]

#: Largest friction coefficient the search considers [-].
MU_MAX = 2.0
#: Fewest impacts a fit takes.
MIN_IMPACTS = 5


class PlanarFitError(ValueError):
    """Impacts a fit cannot use (too few, no measured outcome of the kind asked for)."""


class PlanarLawFit(FitResult):
    """The fit of a planar impact law (:func:`fit_planar_law`, :func:`fit_planar`).

    ``params`` are the law's (``e`` or ``e0``, ``gamma``; ``mu``; ``e_t``); ``details`` hold the
    ``law`` (``name``, ``rule``, ``restitution``, ``tangential``, ``formula``), the ``body`` (mass,
    radius of gyration), the ``target`` and the covariance; ``tables["impacts"]`` the fitted impacts
    and, for :func:`fit_planar`, ``tables["laws"]`` the candidates' comparison.
    """

    kind = "planar-impact-law-fit"
    title = "planar impact law fit"

    @property
    def law(self) -> PlanarLaw:
        """The fitted law."""
        d = self.details["law"]
        return PlanarLaw(d["rule"], d["restitution"], bool(d["tangential"]))

    @property
    def body(self) -> PlanarBody:
        """The body the law was fitted for."""
        return PlanarBody.from_mapping(self.details["body"])


def _require(impacts: PlanarImpacts, target: str) -> np.ndarray:
    if target == "impulse":
        if impacts.impulse is None:
            raise PlanarFitError(f"{impacts.source}: no measured impulses (columns impulse_t, impulse_n) to fit")
        return impacts.impulse
    if target == "velocity":
        if impacts.v_post is None:
            raise PlanarFitError(f"{impacts.source}: no post-impact velocities (vx_post, vy_post, omega_post) to fit")
        return impacts.v_post
    raise ValueError(f"target must be 'impulse' or 'velocity', got {target!r}")


def _target(impacts: PlanarImpacts, target: str | None) -> str:
    if target is None:
        return "impulse" if impacts.impulse is not None else "velocity"
    return target


def _free(law: PlanarLaw, impacts: PlanarImpacts, body: PlanarBody, target: str) -> list[Free]:
    """The law's parameters with bounds, and starting values read off the data."""
    minv = np.asarray(body.inverse_mass)
    vn = np.sum(impacts.jn * impacts.v_pre, axis=1)
    speed = np.clip(-vn, 1e-9, None)
    if target == "impulse":
        w_nn = np.sum(impacts.jn * impacts.jn * minv, axis=1)
        e_data = impacts.impulse[:, 1] * w_nn / speed - 1.0
        ratio = np.abs(impacts.impulse[:, 0]) / np.clip(np.abs(impacts.impulse[:, 1]), 1e-300, None)
    else:
        e_data = np.sum(impacts.jn * impacts.v_post, axis=1) / speed
        dv = (impacts.v_post - impacts.v_pre) / minv  # M dv: the generalised impulse
        ratio = np.abs(dv[:, 0]) / np.clip(np.abs(dv[:, 1]), 1e-300, None)
    e_start = float(np.clip(np.median(e_data), 0.05, 0.95))
    mu_start = float(np.clip(1.5 * np.median(ratio), 0.02, 0.9 * MU_MAX))
    free = []
    if law.restitution == "constant":
        free.append(Free("e", e_start, 0.0, 1.0))
    else:
        g_max = 1.0 / float(np.max(speed))  # e(u) >= 0 over the fitted speeds
        free += [Free("e0", e_start, 0.0, 2.0), Free("gamma", 0.0, -g_max, g_max, unit="s/m")]
    free.append(Free("mu", mu_start, 0.0, MU_MAX))
    if law.tangential:
        free.append(Free("e_t", 0.0, -1.0, 1.0))
    return free


def _starts(law: PlanarLaw, free: Sequence[Free]) -> list[dict[str, float]]:
    mu = next(p.value for p in free if p.name == "mu")
    starts = [{}, {"mu": min(4.0 * mu, 0.9 * MU_MAX)}]
    if law.tangential:
        starts += [{"e_t": -0.5}, {"e_t": 0.5}, {"e_t": -0.9, "mu": min(2.0 * mu, 0.9 * MU_MAX)}]
    return starts


def _residual_function(law: PlanarLaw, impacts: PlanarImpacts, body: PlanarBody, target: str, free):
    minv = np.asarray(body.inverse_mass)
    names = [p.name for p in free]
    if target == "impulse":
        measured = impacts.impulse
        scale = np.hypot(measured[:, 0], measured[:, 1])
    else:
        root_mass = np.sqrt(np.asarray(body.diagonal_mass))
        measured = impacts.v_post * root_mass
        scale = np.linalg.norm(impacts.v_pre * root_mass, axis=1)

    def residual(u: np.ndarray) -> np.ndarray:
        values = dict(zip(names, (float(x) for x in u)))
        out = outcome(law, values, impacts.v_pre, impacts.jt, impacts.jn, minv)
        if target == "impulse":
            r = (np.stack([out.p_t, out.p_n], axis=1) - measured) / scale[:, None]
        else:
            r = (out.v_post * root_mass - measured) / scale[:, None]
        r = r.T.ravel()  # all first components, then all second, ...
        return np.where(np.isfinite(r), r, 1e3)  # a Painleve impact: a large residual, not a crash

    return residual


def _search(law, impacts, body, target):
    free = _free(law, impacts, body, target)
    residual = _residual_function(law, impacts, body, target, free)
    found = search(residual, free, starts=_starts(law, free), differences="3-point", xtol=1e-10, ftol=1e-12)
    return found, residual


def _impact_table(law: PlanarLaw, values, impacts: PlanarImpacts, body: PlanarBody) -> pd.DataFrame:
    out = outcome(law, values, impacts.v_pre, impacts.jt, impacts.jn, np.asarray(body.inverse_mass))
    table = pd.DataFrame({"impact": impacts.impact, "vt_pre": out.vt, "vn_pre": out.vn, "restitution": out.restitution,
                          "impulse_t_fit": out.p_t, "impulse_n_fit": out.p_n, "sticking": out.sticking})
    if impacts.impulse is not None:
        table["impulse_t"] = impacts.impulse[:, 0]
        table["impulse_n"] = impacts.impulse[:, 1]
        table["relative_impulse_error"] = (np.hypot(out.p_t - impacts.impulse[:, 0], out.p_n - impacts.impulse[:, 1])
                                           / np.hypot(impacts.impulse[:, 0], impacts.impulse[:, 1]))
    return table


def fit_planar_law(impacts: PlanarImpacts, body: PlanarBody, law: str | PlanarLaw, *, target: str | None = None,
                   confidence: float = 0.95, profiles: bool = True,
                   comparison: Mapping | None = None) -> PlanarLawFit:
    """Fit one impact law to measured impacts.

    Parameters
    ----------
    impacts : the impacts with their measured outcome (:func:`~impactid.rigs.planar.table.read_impacts`).
    body : the body (mass, radius of gyration).
    law : a name of :data:`~impactid.rigs.planar.laws.LAWS` or a :class:`~impactid.rigs.planar.laws.PlanarLaw`.
    target : ``"impulse"`` (the measured impulses; the default when the table has them) or
        ``"velocity"`` (the post-impact velocities).
    confidence : coverage of the intervals.
    profiles : refit profiles in the identifiability block (else quadratic ones).
    comparison : a :func:`~impactid.engine.compare_models` block to carry (:func:`fit_planar`).

    Returns
    -------
    PlanarLawFit
        parameters with standard errors and Student-t intervals (widened or withheld by the model
        check), statistics (RSS, AIC, BIC, the median relative impulse error of the fitted impacts,
        the fraction that stick), the model check, the identifiability block.

    Raises
    ------
    PlanarFitError
        fewer than :data:`MIN_IMPACTS` impacts, or no measured outcome of the ``target`` kind.
    """
    law = get_law(law)
    target = _target(impacts, target)
    _require(impacts, target)
    if len(impacts) < MIN_IMPACTS:
        raise PlanarFitError(f"{impacts.source}: {len(impacts)} impact(s); a law needs at least {MIN_IMPACTS}")
    found, residual = _search(law, impacts, body, target)
    stated = uncertainty(found, confidence=confidence)
    n = len(impacts)
    components = found.residual.size // n
    speed = -np.sum(impacts.jn * impacts.v_pre, axis=1)
    labels = ("tangential", "normal") if target == "impulse" else ("v_x", "v_y", "omega")
    checked = check_model(found.residual, None, noise_reference=NO_NOISE_REFERENCE,
                          what=f"relative {target} error", n_params=len(found.varying),
                          groups=np.repeat(np.arange(components), n), order=False,
                          covariate=np.tile(speed, components), covariate_name="approach speed [m/s]")
    params = checked.widen(stated.parameters)
    described = identifiability(found, stated, residual=residual if profiles else None,
                                search_options={"xtol": 1e-10, "ftol": 1e-12},
                                quadratic_reason="" if profiles else "profiles not asked for",
                                comparison=comparison, describes_data=checked.describes_data)
    values = found.values()
    table = _impact_table(law, values, impacts, body)
    rss = float(found.residual @ found.residual)
    k = len(found.varying)
    m = found.residual.size
    loglik = -0.5 * m * (math.log(2.0 * math.pi * rss / m) + 1.0) if rss > 0 else math.inf
    statistics = {"n_impacts": n, "n_residuals": m, "n_params": k, "target": target, "rss": rss, "loglik": loglik,
                  "aic": 2 * (k + 1) - 2 * loglik, "bic": (k + 1) * math.log(m) - 2 * loglik,
                  "sticking_fraction": float(np.mean(table["sticking"])), **stated.statistics}
    if "relative_impulse_error" in table:
        statistics["median_relative_impulse_error"] = float(np.median(table["relative_impulse_error"]))
    notes = list(stated.notes) + list(checked.further_notes)
    if not found.success:
        notes.insert(0, f"the search stopped without converging: {found.message}")
    details = {"law": {"name": law.name, "rule": law.rule, "restitution": law.restitution,
                       "tangential": law.tangential, "formula": law.formula},
               "body": body.to_dict(), "target": target, "residual_components": list(labels),
               "covariance": stated.covariance.matrix.tolist(), "names": list(stated.names),
               "starts": [dict(s) for s in found.starts]}
    return PlanarLawFit(params=params, statistics=statistics, notes=tuple(dict.fromkeys(notes)),
                        tables={"impacts": table}, details=details,
                        model_check=combine_checks([checked]), identifiability=described,
                        provenance=(f"{law.name} law fitted to the {target}s of {n} impacts of {impacts.source}: "
                                    "impactid.engine's search, uncertainty, model check and identifiability",))


def fit_planar(impacts: PlanarImpacts, body: PlanarBody, *, laws: Sequence[str] | str = "auto",
               criterion: str = "bic", target: str | None = None, confidence: float = 0.95,
               profiles: bool = True) -> PlanarLawFit:
    """Fit candidate laws and return the one ``criterion`` selects, with the comparison.

    Parameters
    ----------
    impacts, body, target, confidence, profiles : as :func:`fit_planar_law`.
    laws : ``"auto"`` (every law of :data:`~impactid.rigs.planar.laws.LAWS`), one name, or several.
    criterion : ``"bic"`` or ``"aic"`` (lowest wins).

    Returns
    -------
    PlanarLawFit
        the selected law's fit; its identifiability block's ``model_comparison`` holds every
        candidate's AIC and BIC and the likelihood-ratio tests of the nested pairs (constant within
        linear restitution, ``e_t = 0`` within ``e_t`` fitted), ``tables["laws"]`` one row per
        candidate, ``details["selection"]`` the rule.
    """
    if criterion not in ("bic", "aic"):
        raise ValueError(f"criterion must be 'bic' or 'aic', got {criterion!r}")
    names = list(LAWS) if laws == "auto" else ([laws] if isinstance(laws, str) else list(laws))
    candidates = [get_law(n) for n in names]
    if len(candidates) == 1:
        return fit_planar_law(impacts, body, candidates[0], target=target, confidence=confidence, profiles=profiles)
    fits = {law.name: fit_planar_law(impacts, body, law, target=target, confidence=confidence, profiles=False)
            for law in candidates}
    nested = []
    for law in candidates:
        for other in candidates:
            if law.rule == other.rule and law != other and (
                    (law.tangential == other.tangential and law.restitution == "constant"
                     and other.restitution == "linear")
                    or (law.restitution == other.restitution and not law.tangential and other.tangential)):
                nested.append((law.name, other.name))
    comparison = compare_models([{"name": name, "n_params": f.statistics["n_params"],
                                  "n_data": f.statistics["n_residuals"], "rss": f.statistics["rss"]}
                                 for name, f in fits.items()], nested,
                                choice="the impact law: rule, constant or speed-dependent restitution, with or "
                                       "without tangential restitution")
    chosen = min(fits, key=lambda name: fits[name].statistics[criterion])
    comparison["selected"] = chosen
    comparison["selection"] = f"lowest {criterion.upper()}"
    best = fit_planar_law(impacts, body, chosen, target=target, confidence=confidence, profiles=profiles,
                          comparison=comparison)
    rows = []
    for name, fit in fits.items():
        rows.append({"law": name, "n_params": fit.statistics["n_params"], "rss": fit.statistics["rss"],
                     "aic": fit.statistics["aic"], "bic": fit.statistics["bic"],
                     "median_relative_impulse_error": fit.statistics.get("median_relative_impulse_error", math.nan),
                     "parameters": "; ".join(f"{p.name} = {p.value:.4g} +/- {p.stderr:.2g}"
                                             for p in fit.params.values())})
    table = pd.DataFrame(rows)
    table["delta_aic"] = table["aic"] - table["aic"].min()
    table["delta_bic"] = table["bic"] - table["bic"].min()
    details = {**best.details, "selection": f"lowest {criterion.upper()} of {len(fits)} laws: {chosen}"}
    return replace(best, tables={**best.tables, "laws": table}, details=details,
                   provenance=best.provenance + (f"{len(fits)} laws compared by {criterion.upper()}",))


def predict_planar(law: PlanarLaw | str, values: Mapping[str, float], body: PlanarBody,
                   impacts: PlanarImpacts) -> pd.DataFrame:
    """Predict the impulse and the post-impact velocity of each impact from its pre-impact state.

    Uses ``impacts.v_pre``, ``impacts.jt`` and ``impacts.jn`` only (never an outcome the table may
    hold).

    Returns
    -------
    DataFrame
        per impact: ``impact``, ``vt_pre``, ``vn_pre`` [m/s], ``restitution``, ``predicted_impulse_t``,
        ``predicted_impulse_n`` [N s], ``predicted_vx_post``, ``predicted_vy_post`` [m/s],
        ``predicted_omega_post`` [rad/s], ``sticking``.
    """
    law = get_law(law)
    out = outcome(law, values, impacts.v_pre, impacts.jt, impacts.jn, np.asarray(body.inverse_mass))
    return pd.DataFrame({"impact": impacts.impact, "vt_pre": out.vt, "vn_pre": out.vn,
                         "restitution": out.restitution, "predicted_impulse_t": out.p_t,
                         "predicted_impulse_n": out.p_n, "predicted_vx_post": out.v_post[:, 0],
                         "predicted_vy_post": out.v_post[:, 1], "predicted_omega_post": out.v_post[:, 2],
                         "sticking": out.sticking})


def score_predictions(predictions: pd.DataFrame, truth: PlanarImpacts, body: PlanarBody) -> pd.DataFrame:
    """The prediction errors per impact, against the measured outcome read separately.

    Adds ``relative_impulse_error`` ``|p_pred - p_meas| / |p_meas|`` (with the measured
    ``impulse_t``, ``impulse_n``) where ``truth`` has impulses, and ``relative_velocity_error``
    ``|M^(1/2) (v_pred - v_meas)| / |M^(1/2) v_meas|`` where it has post-impact velocities.
    The rows must be the same impacts in the same order.
    """
    if len(predictions) != len(truth) or not np.array_equal(predictions["impact"].to_numpy(), truth.impact):
        raise PlanarFitError(f"{truth.source}: the measured impacts are not the predicted ones")
    scored = predictions.copy()
    if truth.impulse is not None:
        p = np.stack([scored["predicted_impulse_t"], scored["predicted_impulse_n"]], axis=1)
        scored["impulse_t"] = truth.impulse[:, 0]
        scored["impulse_n"] = truth.impulse[:, 1]
        scored["relative_impulse_error"] = (np.linalg.norm(p - truth.impulse, axis=1)
                                            / np.linalg.norm(truth.impulse, axis=1))
    if truth.v_post is not None:
        root_mass = np.sqrt(np.asarray(body.diagonal_mass))
        v = np.stack([scored["predicted_vx_post"], scored["predicted_vy_post"], scored["predicted_omega_post"]], axis=1)
        scored["relative_velocity_error"] = (np.linalg.norm((v - truth.v_post) * root_mass, axis=1)
                                             / np.linalg.norm(truth.v_post * root_mass, axis=1))
    return scored

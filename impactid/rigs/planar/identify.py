"""Identification of a planar impact law from measured impacts, and its prediction of new impacts.

:func:`fit_planar_law` fits one law (:mod:`impactid.rigs.planar.laws`) to the measured impulses (or
post-impact velocities) of a set of impacts through the identification engine every rig uses
(:mod:`impactid.engine`): the search (trust-region reflective within the parameters' bounds, several
starts from values read off the data), the uncertainty (the covariance clustered by impact,
:func:`impact_sandwich`, since the noise of each pre-impact state enters its prediction; Student-t
intervals), the model check and the identifiability block; where every impact sticks, ``mu`` is
reported undetermined with the lower bound the data give.
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
from scipy import stats

from impactid.engine import (
    NO_NOISE_REFERENCE,
    Covariance,
    Free,
    Search,
    Uncertainty,
    check_model,
    combine_checks,
    compare_models,
    covariance_from_jacobian,
    identifiability,
    search,
    uncertainty,
)
from impactid.results import FitResult, Parameter
from impactid.rigs.planar.laws import LAWS, PlanarLaw, get_law, outcome
from impactid.rigs.planar.parameters import PlanarBody
from impactid.rigs.planar.table import PlanarImpacts

__all__ = ["MU_MAX", "PlanarFitError", "PlanarLawFit", "fit_planar", "fit_planar_law", "impact_sandwich",
           "predict_planar", "score_predictions"]

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
    # where every impact sticks the residual does not depend on mu: a zero column of the Jacobian, which
    # the trust-region steps divide by (0/0); the search stays where it is along mu (fit_planar_law says why)
    with np.errstate(divide="ignore", invalid="ignore"):
        found = search(residual, free, starts=_starts(law, free), differences="3-point", xtol=1e-10, ftol=1e-12)
    return found, residual


def _friction_bound(params: Sequence[Parameter], table: pd.DataFrame) -> tuple[tuple[Parameter, ...], str]:
    """Where every fitted impact sticks, ``mu`` is not determined: the data give only the lower bound
    ``max |p_t| / p_n`` of the fitted impulses. Returns the parameters (``mu`` undetermined, its interval
    ``[bound, undetermined]``) and the note saying so, or the parameters unchanged and ""."""
    if not (len(table) and bool(table["sticking"].all())):
        return tuple(params), ""
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.abs(table["impulse_t_fit"].to_numpy()) / table["impulse_n_fit"].to_numpy()
    bound = float(np.max(ratio[np.isfinite(ratio)])) if np.any(np.isfinite(ratio)) else 0.0
    note = (f"mu is not determined: every impact sticks (its impulse lies inside the friction cone), so the data "
            f"give only a lower bound, mu >= {bound:.4g} (the largest |p_t| / p_n of the fitted impulses)")
    out = [replace(p, value=math.nan, stderr=math.nan, interval=(bound, math.nan),
                   note=f"every impact sticks: only the lower bound mu >= {bound:.4g} is determined")
           if p.name == "mu" and not p.fixed else p for p in params]
    return tuple(out), note


def impact_sandwich(found: Search, stated: Uncertainty, n_impacts: int) -> Uncertainty:
    r"""The uncertainty of a planar fit with the covariance clustered by impact (a sandwich estimator).

    The residual of an impact depends on its measured pre-impact state twice: through the measured
    outcome and through the prediction (the approach speed, the sticking impulse), so its components
    are correlated and their variance differs from impact to impact, by an amount no weighting known
    in advance describes (the noise of a motion-capture system is not known, the real impulses are
    not the velocity changes'). The covariance ``scale (J^T J)^-1`` of :func:`impactid.engine.uncertainty`
    assumes independent residuals of one variance; here it is replaced by the covariance that holds for
    any noise of the impacts' states and outcomes as long as the impacts are independent of each other,

    .. math:: C = \frac{N - 1}{N} (J^T J)^{-1} \Big(\sum_i \tilde s_i \tilde s_i^T\Big) (J^T J)^{-1}, \qquad
              \tilde s_i = J_i^T (I - H_{ii})^{-1} r_i,

    (``N`` impacts, ``k`` parameters, ``J_i`` and ``r_i`` the rows of impact ``i``, ``H_ii = J_i (J^T J)^-1
    J_i^T`` its block of the hat matrix): the linearised jackknife over impacts, which does not shrink
    where a few impacts carry a parameter (the sliding ones for ``mu``). The intervals are Student-t
    with ``N - k`` degrees of freedom. Parameters the model does not depend on stay undetermined as in
    :func:`~impactid.engine.covariance_from_jacobian`.

    Parameters
    ----------
    found : the search; its residual and Jacobian are ordered component by component, each
        component over every impact (:func:`_residual_function`).
    stated : the engine's uncertainty of the same search (the notes, bounds and statistics kept).
    n_impacts : number of impacts ``N``.

    Returns
    -------
    Uncertainty
        with the clustered covariance, standard errors, correlations and intervals, and
        ``statistics["covariance"]`` naming the estimator.
    """
    jacobian, residual = np.asarray(found.jacobian, float), np.asarray(found.residual, float)
    k = jacobian.shape[1]
    dof = n_impacts - k
    bread = covariance_from_jacobian(jacobian, 1.0, names=stated.names)
    if dof <= 0 or not np.any(np.isfinite(bread.stderr)):
        return stated
    components = residual.size // n_impacts
    live = np.isfinite(bread.stderr)
    b = bread.matrix[np.ix_(live, live)]
    per_impact = jacobian[:, live].reshape(components, n_impacts, -1).transpose(1, 0, 2)  # (N, c, k)
    r = residual.reshape(components, n_impacts).T  # (N, c)
    leverage = np.einsum("icp,pq,idq->icd", per_impact, b, per_impact)  # the hat matrix's blocks
    keep = np.eye(components) - leverage
    adjusted = np.einsum("icd,id->ic", np.linalg.pinv(keep), r)  # an impact of leverage 1: no crash
    scores = np.einsum("icp,ic->ip", per_impact, adjusted)
    meat = scores.T @ scores * ((n_impacts - 1) / n_impacts)
    matrix = np.full((k, k), math.nan)
    matrix[np.ix_(live, live)] = b @ meat @ b
    stderr = np.where(live, np.sqrt(np.clip(np.diag(matrix), 0.0, None)), math.nan)
    covariance = Covariance(matrix, stderr, bread.condition, bread.reason)
    q = float(stats.t.ppf(0.5 + 0.5 * stated.confidence, dof))
    by_name = dict(zip(stated.names, range(k)))
    free = {p.name: p for p in found.varying}
    parameters = []
    for p in stated.parameters:
        j = by_name.get(p.name)
        if p.fixed or j is None or not (math.isfinite(p.stderr) and math.isfinite(stderr[j])):
            parameters.append(p)
            continue
        x = float(found.x[j])
        if free[p.name].log:
            interval = (math.exp(x - q * stderr[j]), math.exp(x + q * stderr[j]))
            se = p.value * stderr[j]
        else:
            interval, se = (x - q * stderr[j], x + q * stderr[j]), float(stderr[j])
        parameters.append(replace(p, stderr=float(se), interval=interval))
    statistics = {**stated.statistics, "dof": dof, "model_based_stderr": dict(zip(stated.names,
                                                                                 map(float, stated.covariance.stderr))),
                  "covariance": "clustered by impact (sandwich with leverage correction: the linearised jackknife)"}
    return replace(stated, covariance=covariance, dof=dof, parameters=tuple(parameters), statistics=statistics,
                   correlation=covariance.correlation)


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
    n = len(impacts)
    stated = impact_sandwich(found, uncertainty(found, confidence=confidence), n)
    components = found.residual.size // n
    speed = -np.sum(impacts.jn * impacts.v_pre, axis=1)
    labels = ("tangential", "normal") if target == "impulse" else ("v_x", "v_y", "omega")
    checked = check_model(found.residual, None, noise_reference=NO_NOISE_REFERENCE,
                          what=f"relative {target} error", n_params=len(found.varying),
                          groups=np.repeat(np.arange(components), n), order=False,
                          covariate=np.tile(speed, components), covariate_name="approach speed [m/s]")
    params = checked.widen(stated.parameters)
    with np.errstate(divide="ignore", invalid="ignore"):  # the profiles' refits: as in _search
        described = identifiability(found, stated, residual=residual if profiles else None,
                                    search_options={"xtol": 1e-10, "ftol": 1e-12},
                                    quadratic_reason="" if profiles else "profiles not asked for",
                                    comparison=comparison, describes_data=checked.describes_data)
    values = found.values()
    table = _impact_table(law, values, impacts, body)
    params, sticking_note = _friction_bound(params, table)
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
    if sticking_note:  # said once, in words, instead of the engine's "residuals do not depend on mu"
        notes = [sticking_note] + [n for n in notes if not ("do not depend on" in n and "mu" in n)]
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

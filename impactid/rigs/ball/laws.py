"""Restitution laws ``e(v)``, their fits to per-impact coefficients, model selection, and the
chained trajectory fit.

The laws (:data:`LAWS`; each linear in its parameters, so every fit is a linear least-squares
problem with an exact solution):

* ``constant``: ``e = e`` - the textbook coefficient;
* ``linear``: ``e = e0 - gamma v`` [gamma in s/m] - the first-order speed dependence that most
  measurements report, and impactid's ``Restitution`` law of the valve-train rigs;
* ``viscoelastic``: ``e = 1 - a v^(1/5)`` [a in (s/m)^(1/5)] - the first term of the restitution of
  viscoelastic spheres in Hertzian contact (Kuwabara & Kono 1987, *Jpn. J. Appl. Phys.* 26, 1230;
  Brilliantov, Spahn, Hertzsch & Poeschel 1996, *Phys. Rev. E* 53, 5382): the damping force of
  the Hunt-Crossley/Kuwabara-Kono type, proportional to the indentation rate times the square root
  of the indentation, gives ``1 - e`` growing as ``v^(1/5)``. Chosen because it is the law a contact
  model predicts, with a single parameter fixed by the material, and because it differs from the
  linear law in shape: it bends (steep at low speed, flat at high speed) and tends to 1 at rest.

Uncertainty and the shared intervals
------------------------------------
Each coefficient has the variance ``tau^2 + sigma_t^2 |de/dt|^2`` (:func:`variance_model`): a
bounce-to-bounce scatter of the restitution and the timing noise of the events, which reaches
``e_k`` through the exact derivative of the flight inversion. Its inverse weights the least-squares
fits (the analysis estimates it once, under the linear law, and uses it for every law).

Consecutive coefficients of one drop share a flight (``e_k = T_k / T_(k-1)`` and
``e_(k+1) = T_(k+1) / T_k`` both contain ``T_k``), and every flight shares its end events with its
neighbours, so the coefficients of a drop are correlated (negatively, for neighbours). The errors
are **cluster-robust by drop** (the sandwich of Liang & Zeger 1986 with the CR1 small-sample
factor ``G / (G - 1) (n - 1) / (n - p)`` and Student-t intervals with ``G - 1`` degrees of freedom;
Cameron & Miller 2015): each drop is a cluster, so any correlation within a drop (the shared
flights, a drop-to-drop change of spin or floor spot) is allowed for, and only the independence of
different drops is assumed. With few drops the cluster-robust variance is itself noisy and tends
to be too small, so each standard error is raised, if needed, to the model-based one, computed
with the full noise covariance ``tau^2 I + sigma_t^2 J J^T`` (``J = de/dt``, which holds the shared
intervals exactly). With fewer than :data:`MIN_CLUSTERS` drops the errors come from a Newey-West
sandwich within each drop (lag 2), again never below the model-based ones, and a note says so.

The identification engine and the ball's own layer
---------------------------------------------------
Both fits run on the identification engine every rig's fit uses (:mod:`impactid.engine`). Each law
is linear in its parameters, so the per-impact fit is solved exactly in closed form (no search to
converge, no start to choose) and handed to the engine as a :class:`~impactid.engine.Search` at the
solution, as rig F's cam profile hands its variable projection; the chained fit, nonlinear, is the
engine's search (:func:`impactid.engine.search`: trust-region reflective, tolerances 1e-12, its
Jacobian by central differences grouped by drop). :func:`impactid.engine.uncertainty` then states,
for both, the bread ``(X^T W X)^-1`` (the chained fit's ``(J^T J)^-1``, the drops' starts included)
by the shared covariance rule (:func:`impactid.engine.covariance.covariance_from_jacobian`): its condition
number is reported, and beyond :data:`~impactid.engine.covariance.CONDITION_LIMIT` (speeds too close
together to tell ``e0`` from ``gamma``, say) the standard errors are undetermined and a note says
why; and the parameters (units, bounds, bound hits) and notes of the result.

The engine's own covariance, ``s^2 (J^T J)^-1``, assumes independent residuals. The bounces of one
drop are not independent (the shared flights above, and whatever varies from drop to drop), so
the standard errors, intervals and correlations reported are the ball's own layer on top of the
engine's bread: the sandwiches (cluster-robust by drop, Newey-West within a drop), never below the
model-based covariance of the noise model, with their Student-t degrees of freedom.

Model check: a law that describes ``e(v)`` leaves residuals whose signs, in the order of the impact
speed, change as often as in a random order; the Wald-Wolfowitz runs test (:func:`runs_check`) flags
too few runs (:data:`RUNS_Z_LIMIT`) as a lack of fit in the fit's notes. (The per-impact residuals
are not checked against a noise level: the only one, ``tau`` and ``sigma_t``, is estimated from the
same residuals.) The chained fit's residuals are checked against the timing noise of the events,
measured independently by the per-impact fits, by the engine's rule
(:func:`impactid.engine.residual_against_noise`).

Model selection by the Gaussian likelihood with the fitted variances: AIC and BIC (the scale
counted as a parameter); the law with the smallest criterion is selected, except that a simpler
law within 2 of the best is preferred ("not worth more parameters").

The engine's whole check (:func:`impactid.engine.check_model`) runs beside these: for the per-impact
fits, the trend of the weighted residual with the impact speed within each drop (consecutive
coefficients are not compared: neighbours share a flight and alternate by construction; the drops'
means are not compared: the cluster-robust errors allow for drop-to-drop variation), the runs test's
verdict joining it; for the chained fit, the event-time residuals against the timing noise with
their persistence along each drop, which widens or withholds the law's intervals by the engine's
rule. Each fit's identifiability block (:func:`impactid.engine.identifiability`: condition number, the
correlation of the reported covariance, quadratic profiles, exact for the linear laws) compares, for
the linear law, the constant law nested in it (``gamma = 0``: AIC, BIC, likelihood-ratio test).

The chained trajectory fit (:func:`fit_chained`) predicts every accepted event time of a drop from
the drop's first impact time and first launch speed, flight by flight with the law (missed
bounces included as sums of flights), and fits all drops at once by nonlinear least squares (the
engine's search): a cross-check that uses every interval, including the ones a missed bounce merged.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np
import pandas as pd
from scipy.optimize import nnls
from scipy.stats import t as student

from impactid import engine
from impactid.engine import (
    Free,
    ModelCheck,
    Search,
    Uncertainty,
    check_model,
    combine_checks,
    compare_models,
    identifiability,
    residual_against_noise,
    search,
    uncertainty,
)
from impactid.engine.covariance import Covariance
from impactid.results import FitResult, Parameter
from impactid.rigs.ball.flight import FlightConstants, flight_time, landing_speed, launch_speed

__all__ = ["LACK_OF_FIT_FACTOR", "LAWS", "MIN_CLUSTERS", "RUNS_Z_LIMIT", "ChainedFit", "Law", "LawFit", "RunsCheck",
           "TimingNoise", "fit_chained", "fit_law", "get_law", "law_table", "runs_check", "select_law",
           "variance_model"]

#: Fewest drops for cluster-robust standard errors.
MIN_CLUSTERS = 4


@dataclass(frozen=True)
class Law:
    """A restitution law ``e(v) = offset + X(v) beta``, linear in its parameters ``beta``.

    Attributes
    ----------
    name : its name.
    names : parameter names.
    units : parameter units (SI).
    formula : as text.
    columns : ``X(v)``: (n,) speeds [m/s] -> (n, p) design matrix.
    offset : constant part of ``e``.
    """

    name: str
    names: tuple[str, ...]
    units: tuple[str, ...]
    formula: str
    columns: Callable[[np.ndarray], np.ndarray]
    offset: float = 0.0

    def design(self, v) -> np.ndarray:
        """The design matrix at speeds ``v`` [m/s]."""
        return self.columns(np.atleast_1d(np.asarray(v, dtype=float)))

    def evaluate(self, beta, v) -> np.ndarray:
        """``e`` at speeds ``v`` [m/s] for parameters ``beta``."""
        v = np.asarray(v, dtype=float)
        out = self.offset + self.design(v) @ np.asarray(beta, dtype=float)
        return out.reshape(v.shape) if v.ndim else out[0]

    @property
    def n_params(self) -> int:
        return len(self.names)


LAWS: dict[str, Law] = {
    "constant": Law("constant", ("e",), ("",), "e = e", lambda v: np.ones((v.size, 1))),
    "linear": Law("linear", ("e0", "gamma"), ("", "s/m"), "e = e0 - gamma v",
                  lambda v: np.column_stack([np.ones(v.size), -v])),
    "viscoelastic": Law("viscoelastic", ("a",), ("(s/m)^0.2",), "e = 1 - a v^(1/5)",
                        lambda v: -np.abs(v)[:, None] ** 0.2, offset=1.0),
}


def get_law(law: str | Law) -> Law:
    """The law called ``law`` (or ``law`` itself when it is a :class:`Law`).

    Raises
    ------
    ValueError
        listing the valid names.
    """
    if isinstance(law, Law):
        return law
    if law not in LAWS:
        raise ValueError(f"unknown law {law!r}; valid: {', '.join(LAWS)}")
    return LAWS[law]


@dataclass(frozen=True)
class LawFit(FitResult):
    """A restitution law fitted to per-impact coefficients (weighted least squares in closed form,
    stated through :mod:`impactid.engine`; errors cluster-robust by drop).

    ``details`` holds ``law`` (name), ``formula``, ``covariance`` (of the parameters, as used for
    the errors), ``correlation`` (its correlation matrix), ``covariance_model`` (the model-based
    one), ``covariance_method``, ``dof`` (of the t intervals) and ``speed_range`` [m/s].
    ``statistics`` holds the counts, ``scale``, ``loglik``, ``aic``, ``bic``, ``condition_number``
    (of the column-scaled ``X^T W X``), the runs test (``runs``, ``runs_expected``, ``runs_z``, where
    it applies) and the speed range.
    """

    kind = "restitution-law"
    title = "Restitution law fit"

    @property
    def law(self) -> Law:
        return get_law(self.details["law"])

    @property
    def beta(self) -> np.ndarray:
        return np.array([self.params[n].value for n in self.law.names])

    @property
    def covariance(self) -> np.ndarray:
        return np.array(self.details["covariance"], dtype=float)

    def predict(self, v, confidence: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``e(v)`` and the lower and upper limits of its confidence band (of the mean law)."""
        law = self.law
        v = np.asarray(v, dtype=float)
        X = law.design(v)
        mean = law.offset + X @ self.beta
        var = np.einsum("ij,jk,ik->i", X, self.covariance, X)
        level = confidence if confidence is not None else next(iter(self.params.values())).confidence
        q = student.ppf(0.5 + level / 2.0, max(float(self.details.get("dof", 1)), 1.0))
        half = q * np.sqrt(np.maximum(var, 0.0))
        return mean, mean - half, mean + half

    def plot(self, ax=None, **kwargs):
        """The law and its band over the fitted speed range."""
        from matplotlib.figure import Figure

        fig = None
        if ax is None:
            fig = Figure(figsize=(6.0, 4.0), constrained_layout=True)
            ax = fig.add_subplot()
        lo, hi = self.details.get("speed_range", (0.1, 3.0))
        v = np.linspace(lo, hi, 200)
        mean, low, high = self.predict(v)
        line = ax.plot(v, mean, label=f"{self.details['law']}: {self.details['formula']}", **kwargs)[0]
        ax.fill_between(v, low, high, color=line.get_color(), alpha=0.2, lw=0)
        ax.set_xlabel("impact speed v [m/s]")
        ax.set_ylabel("coefficient of restitution e [-]")
        return fig if fig is not None else ax.figure


@dataclass(frozen=True)
class TimingNoise:
    """The noise covariance ``tau^2 I + sigma_t^2 J J^T`` of per-impact coefficients (see
    :func:`variance_model`), held as its factors: the (n, events) Jacobian ``J`` [1/s] is sparse
    (three entries a row) and the n x n matrix is never formed, so n coefficients take memory in
    proportion to n, not to its square.

    Attributes
    ----------
    tau : intrinsic scatter of the restitution [-].
    sigma_t : timing noise of one event [s].
    jacobian : (n, events) sparse matrix (or array) ``de/dt`` [1/s].
    """

    tau: float
    sigma_t: float
    jacobian: object

    def sandwich(self, A: np.ndarray) -> np.ndarray:
        """``A C A^T`` for a (p, n) matrix ``A`` and this covariance ``C``, without forming ``C``."""
        A = np.atleast_2d(np.asarray(A, dtype=float))
        AJ = np.asarray(self.jacobian.T @ A.T).T  # (p, events)
        return self.tau ** 2 * (A @ A.T) + self.sigma_t ** 2 * (AJ @ AJ.T)

    def toarray(self) -> np.ndarray:
        """The dense (n, n) covariance (for small n only)."""
        J = self.jacobian.toarray() if hasattr(self.jacobian, "toarray") else np.asarray(self.jacobian)
        return self.tau ** 2 * np.eye(J.shape[0]) + self.sigma_t ** 2 * (J @ J.T)


def variance_model(residuals, gains, *, floor: float = 1e-300) -> tuple[float, float]:
    """Variance of each coefficient as ``tau^2 + sigma_t^2 g_k``: an intrinsic scatter of the
    restitution (``tau``, the same for every impact) plus the timing noise (``sigma_t`` [s], one per
    event, reaching ``e_k`` through its gain ``g_k = |de_k/dt|^2`` [s^-2]). Fitted to the squared
    residuals by non-negative least squares. Returns ``(tau, sigma_t)``."""
    r2 = np.asarray(residuals, dtype=float) ** 2
    g = np.asarray(gains, dtype=float)
    if not (np.all(np.isfinite(r2)) and np.all(np.isfinite(g))):  # never hand NaN or inf to the solver
        raise ValueError("residuals and gains must be finite")
    scale = float(np.mean(g)) or 1.0
    A = np.column_stack([np.ones_like(g), g / scale])
    coef, _ = nnls(A, r2)
    tau2, s2 = float(coef[0]), float(coef[1]) / scale
    if tau2 + s2 * float(np.mean(g)) <= floor:
        tau2 = max(float(np.mean(r2)), floor)
    return math.sqrt(tau2), math.sqrt(s2)


# ---- per-impact fit: one job each ----------------------------------------------------------------

#: A law whose residuals, ordered by impact speed, change sign so rarely that the number of runs lies
#: this many standard deviations below the number expected for residuals in random order (the
#: Wald-Wolfowitz runs test) does not follow ``e(v)``: a one-sided 3-sigma level (0.13 % of fits of a
#: law that describes the data are flagged by chance).
RUNS_Z_LIMIT = 3.0
#: Fewest coefficients for the runs test (below, its normal approximation does not hold).
RUNS_MIN_DATA = 10
#: The chained fit's residual scale above this many times the timing noise of the events is
#: reported as a lack of fit: the engine's rule (:data:`impactid.engine.LACK_OF_FIT_FACTOR`), the
#: other rigs' fits'.
LACK_OF_FIT_FACTOR = engine.LACK_OF_FIT_FACTOR


@dataclass(frozen=True)
class LawData:
    """Checked inputs of a per-impact fit.

    Attributes
    ----------
    v : (n,) impact speeds [m/s].
    e : (n,) coefficients of restitution [-].
    weights : (n,) inverse relative variances of the coefficients [-].
    groups : (n,) the drop of each coefficient (the clusters).
    """

    v: np.ndarray
    e: np.ndarray
    weights: np.ndarray
    groups: np.ndarray

    @property
    def n(self) -> int:
        return int(self.v.size)


@dataclass(frozen=True)
class LeastSquares:
    """The weighted least-squares solution of a linear law, on the identification engine.

    Attributes
    ----------
    beta : (p,) the law's parameters [their units].
    design : (n, p) the weighted design matrix ``sqrt(w) X`` [-, per parameter unit].
    residuals : (n,) weighted residuals ``sqrt(w) (e - e_fit)`` [-].
    found : the closed-form solution as the engine's :class:`~impactid.engine.Search` (at ``beta``,
        with the residuals and their Jacobian ``-sqrt(w) X``).
    engine : :func:`impactid.engine.uncertainty` of ``found`` at unit variance scale: its covariance
        is the bread ``(X^T W X)^-1`` with its condition (the shared covariance rule), its
        parameters carry the units, bounds and bound hits, its notes the undetermined directions.
    """

    beta: np.ndarray
    design: np.ndarray
    residuals: np.ndarray
    found: Search
    engine: Uncertainty

    @property
    def bread(self) -> Covariance:
        """``(X^T W X)^-1`` and its condition (the engine's covariance at unit scale)."""
        return self.engine.covariance

    @property
    def rss(self) -> float:
        """The weighted residual sum of squares [-]."""
        return float(self.residuals @ self.residuals)


@dataclass(frozen=True)
class Sandwich:
    """A sandwich covariance of the law's parameters and how it was formed.

    Attributes
    ----------
    matrix : (p, p) covariance [parameter units squared].
    dof : degrees of freedom of the Student-t intervals.
    method : how the errors were formed, for the details and the provenance.
    notes : what qualifies it.
    """

    matrix: np.ndarray
    dof: int
    method: str
    notes: tuple[str, ...] = ()


@dataclass(frozen=True)
class RunsCheck:
    """The Wald-Wolfowitz runs test of residuals ordered by impact speed.

    Attributes
    ----------
    runs : number of runs of equal sign.
    expected : their expected number for residuals in random order.
    sd : its standard deviation.
    """

    runs: int
    expected: float
    sd: float

    @property
    def z(self) -> float:
        """``(runs - expected) / sd`` (NaN when the test does not apply)."""
        return (self.runs - self.expected) / self.sd if self.sd > 0 else math.nan

    @property
    def fails(self) -> bool:
        """Whether there are too few runs: the law misses a systematic trend of ``e(v)``."""
        return bool(self.z < -RUNS_Z_LIMIT)


def _law_data(spec: Law, v, e, weights, groups) -> LawData:
    """The inputs of :func:`fit_law`, checked (enough, finite, weights not negative)."""
    v = np.asarray(v, dtype=float)
    e = np.asarray(e, dtype=float)
    n, p = v.size, spec.n_params
    if n <= p:
        raise ValueError(f"law {spec.name!r} has {p} parameter(s) and needs more than {p} coefficients, got {n}")
    groups = np.zeros(n, dtype=int) if groups is None else np.asarray(groups)
    w = np.ones(n) if weights is None else np.asarray(weights, dtype=float)
    if not (np.all(np.isfinite(v)) and np.all(np.isfinite(e)) and np.all(np.isfinite(w)) and np.all(w >= 0)):
        # checked here because LAPACK's least squares can loop forever on NaN or inf, beyond Ctrl-C
        raise ValueError("speeds, coefficients and weights must be finite (weights not negative)")
    return LawData(v, e, w, groups)


def _weighted_least_squares(spec: Law, data: LawData, confidence: float) -> LeastSquares:
    """The law fitted by weighted least squares, stated through the identification engine.

    Every law is linear in its parameters, so the least-squares solution is exact in closed form
    (no search to converge, no start to choose): it is solved here and handed to the engine as a
    :class:`~impactid.engine.Search` at the solution (as rig F's cam profile hands its variable
    projection), and :func:`impactid.engine.uncertainty` states the bread ``(X^T W X)^-1`` by the
    shared covariance rule (undetermined, NaN, when the design's condition is beyond
    :data:`~impactid.engine.covariance.CONDITION_LIMIT`), the parameters with their units and bound hits,
    and the notes."""
    sw = np.sqrt(data.weights)
    Xw = spec.design(data.v) * sw[:, None]
    yw = (data.e - spec.offset) * sw
    beta, *_ = np.linalg.lstsq(Xw, yw, rcond=None)
    beta = np.asarray(beta, dtype=float)
    residuals = yw - Xw @ beta
    found = Search(free=tuple(Free(name, float(b), unit=unit) for name, unit, b in zip(spec.names, spec.units, beta)),
                   x=beta, residual=residuals, jacobian=-Xw, cost=0.5 * float(residuals @ residuals), nfev=1,
                   success=True, message="closed-form weighted least squares (the law is linear in its parameters)")
    # unit scale: the bread; the ball's own layer (fit_law) scales it by the noise model or the residuals
    return LeastSquares(beta, Xw, residuals, found, uncertainty(found, confidence=confidence, scale=1.0))


def _model_covariance(spec: Law, data: LawData, fit: LeastSquares, noise_cov) -> np.ndarray:
    """The covariance of the parameters under the noise model (``A C A^T`` with ``beta = A e``), or,
    without one, ``s^2 (X^T W X)^-1`` with the residual scale ``s^2 = rss / (n - p)``."""
    if noise_cov is None:
        return fit.rss / (data.n - spec.n_params) * fit.bread.matrix
    A = fit.bread.matrix @ (spec.design(data.v) * data.weights[:, None]).T  # beta = A y
    if isinstance(noise_cov, TimingNoise):
        return noise_cov.sandwich(A)
    return A @ np.asarray(noise_cov, dtype=float) @ A.T


def _cluster_robust(fit: LeastSquares, index: np.ndarray, G: int) -> Sandwich:
    """The cluster-robust sandwich by drop (CR1; Liang & Zeger 1986), ``G - 1`` dof."""
    n, p = fit.design.shape
    scores = fit.design * fit.residuals[:, None]
    meat = np.zeros((p, p))
    for g in range(G):
        sg = scores[index == g].sum(axis=0)
        meat += np.outer(sg, sg)
    bread = fit.bread.matrix
    dof = G - 1
    return Sandwich(bread @ meat @ bread * (G / (G - 1)) * ((n - 1) / (n - p)), dof,
                    f"cluster-robust by drop (CR1, {G} drops, t with {dof} dof)")


def _newey_west(fit: LeastSquares, index: np.ndarray, G: int, hac_lag: int) -> Sandwich:
    """The Newey-West sandwich within each drop (Bartlett weights up to ``hac_lag``), ``n - p`` dof."""
    n, p = fit.design.shape
    scores = fit.design * fit.residuals[:, None]
    meat = scores.T @ scores
    for lag in range(1, hac_lag + 1):
        weight = 1.0 - lag / (hac_lag + 1.0)
        for g in range(G):
            sg = scores[index == g]
            if sg.shape[0] > lag:
                cross = sg[lag:].T @ sg[:-lag]
                meat += weight * (cross + cross.T)
    bread = fit.bread.matrix
    dof = n - p
    note = (f"{G} drop(s): fewer than {MIN_CLUSTERS} for errors clustered by drop; the errors allow for "
            f"correlation between neighbouring impacts only, not for drop-to-drop variation")
    return Sandwich(bread @ meat @ bread * (n / (n - p)), dof,
                    f"Newey-West within each drop (lag {hac_lag}, {G} drop(s), t with {dof} dof)", (note,))


def _robust_covariance(fit: LeastSquares, groups: np.ndarray, hac_lag: int) -> Sandwich:
    """Cluster-robust by drop with at least :data:`MIN_CLUSTERS` drops, else Newey-West within each."""
    labels, index = np.unique(groups, return_inverse=True)
    G = labels.size
    return _cluster_robust(fit, index, G) if G >= MIN_CLUSTERS else _newey_west(fit, index, G, hac_lag)


def _never_below_model(robust: Sandwich, cov_model: np.ndarray, names: Sequence[str]) -> Sandwich:
    """``robust`` with each standard error raised, where smaller, to the model-based one (a robust
    variance from few clusters is itself noisy and tends to be too small)."""
    raise_to = np.sqrt(np.maximum(np.diag(cov_model), 1e-300) / np.maximum(np.diag(robust.matrix), 1e-300))
    D = np.diag(np.maximum(raise_to, 1.0))
    raised = [names[i] for i in range(len(names)) if raise_to[i] > 1.0]
    method = robust.method + (f"; raised to the model-based error for {', '.join(raised)}" if raised else "")
    return Sandwich(D @ robust.matrix @ D, robust.dof, method, robust.notes)


def _law_parameters(stated: Uncertainty, cov: np.ndarray, dof: float, confidence: float) -> list[Parameter]:
    """The engine's parameters (``stated``: value, unit, bounds, bound hits) with the standard
    errors of the ball's covariance ``cov`` (of the law's parameters, the first rows of ``stated``'s
    varying ones) and Student-t intervals with ``dof`` degrees of freedom; a standard error that is
    not a number is undetermined (its note says why)."""
    q = float(student.ppf(0.5 + confidence / 2.0, dof))
    reason = next(iter(stated.notes), "") if not stated.covariance.determined else ""
    params = []
    for par in stated.parameters:
        if par.fixed:
            params.append(par)
            continue
        i = stated.names.index(par.name)
        var = float(cov[i, i])
        se = math.sqrt(var) if math.isfinite(var) and var >= 0 else math.nan
        if math.isfinite(se):
            interval, note = (par.value - q * se, par.value + q * se), par.note
        else:
            interval = (math.nan, math.nan)
            note = f"undetermined: {reason or 'the covariance is not finite'}"
        params.append(replace(par, stderr=se, interval=interval, confidence=confidence, note=note))
    return params


def _correlation(cov: np.ndarray) -> np.ndarray:
    """The correlation matrix of a covariance (NaN where a variance is not a positive number)."""
    sd = np.sqrt(np.where(np.diag(cov) > 0, np.diag(cov), np.nan))
    with np.errstate(invalid="ignore", divide="ignore"):
        return cov / np.outer(sd, sd)


def runs_check(v, residuals) -> RunsCheck:
    """The Wald-Wolfowitz runs test of ``residuals`` ordered by the speeds ``v`` [m/s].

    A law that describes ``e(v)`` leaves residuals whose signs, in the order of the impact speed,
    change as often as in a random order; a law that misses a trend or a bend leaves long runs of
    one sign. Exact zeros count as positive.

    Parameters
    ----------
    v : (n,) impact speeds [m/s], the order of the test.
    residuals : (n,) residuals of the law's fit [-] (weighted or not: only their signs count).

    Returns
    -------
    RunsCheck
        the runs, their expected number and its standard deviation; with fewer than
        :data:`RUNS_MIN_DATA` residuals, or residuals of one sign only, ``sd`` is 0 and the test
        does not apply (``z`` is NaN, ``fails`` False).
    """
    r = np.asarray(residuals, dtype=float)[np.argsort(np.asarray(v, dtype=float), kind="stable")]
    signs = r >= 0
    n = r.size
    n_pos = int(signs.sum())
    n_neg = n - n_pos
    runs = 1 + int(np.count_nonzero(signs[1:] != signs[:-1])) if n else 0
    if n < RUNS_MIN_DATA or n_pos == 0 or n_neg == 0:
        return RunsCheck(runs, math.nan, 0.0)
    expected = 1.0 + 2.0 * n_pos * n_neg / n
    var = 2.0 * n_pos * n_neg * (2.0 * n_pos * n_neg - n) / (n * n * (n - 1.0))
    return RunsCheck(runs, expected, math.sqrt(max(var, 0.0)))


def _lack_of_fit_note(spec: Law, check: RunsCheck, v: np.ndarray) -> str:
    """The note of a failed runs test ("" when it passes or does not apply)."""
    if not check.fails:
        return ""
    return (f"lack of fit: ordered by impact speed, the residuals form {check.runs} runs of one sign where "
            f"{check.expected:.1f} +/- {check.sd:.1f} are expected (z = {check.z:.1f}, below -{RUNS_Z_LIMIT:g}): "
            f"the {spec.name} law ({spec.formula}) does not follow e(v) over {float(v.min()):.3g}-"
            f"{float(v.max()):.3g} m/s, and its intervals assume that it does")


def _law_statistics(spec: Law, data: LawData, fit: LeastSquares, sandwich: Sandwich, check: RunsCheck,
                    n_drops: int) -> dict:
    """Fit statistics: counts, the residual scale, the Gaussian likelihood with the relative
    variances ``1/w`` and a free scale (ML), AIC and BIC (the scale counted), the condition of the
    design, the runs test (where it applies) and the speed range."""
    n, p = data.n, spec.n_params
    rss = fit.rss
    loglik = (-0.5 * n * (math.log(2.0 * math.pi * rss / n) + 1.0) + 0.5 * float(np.sum(np.log(data.weights)))
              if rss > 0 else math.inf)
    k = p + 1
    return {"n_impacts": n, "n_drops": n_drops, "n_params": p, "dof": sandwich.dof,
            "scale": math.sqrt(rss / (n - p)), "loglik": loglik, "aic": 2 * k - 2 * loglik,
            "bic": k * math.log(n) - 2 * loglik, "condition_number": fit.bread.condition,
            **({"runs": check.runs, "runs_expected": check.expected, "runs_z": check.z} if check.sd > 0 else {}),
            "speed_min_m_s": float(data.v.min()), "speed_max_m_s": float(data.v.max())}


def _law_model_check(spec: Law, data: LawData, fit: LeastSquares, runs: RunsCheck) -> ModelCheck:
    """The engine's check of a per-impact fit (module doc): the weighted residuals, no independent
    noise reference (the noise model comes from the same residuals), the impact speed as the
    covariate within each drop, no lag or between-drop tests; a failed runs test makes it structured."""
    order = np.argsort(data.groups, kind="stable")
    checked = check_model(fit.residuals[order], None, noise_reference="", what="e (weighted)",
                          n_params=spec.n_params, groups=np.asarray(data.groups)[order], order=False,
                          covariate=data.v[order], covariate_name="impact speed [m/s]", between=False)
    if runs.fails and checked.verdict in ("consistent", "not checked"):
        finding = f"too few runs of one sign along the impact speed (z = {runs.z:.3g})"
        checked = replace(checked, verdict="structured", findings=checked.findings + (finding,))
    return checked


def _law_identifiability(spec: Law, data: LawData, fit: LeastSquares, sandwich: Sandwich,
                         checked: ModelCheck) -> dict:
    """The identifiability block of a per-impact fit: the engine's, with the reported (sandwich)
    covariance's standard errors and correlations, and for the linear law the constant law nested in
    it compared (AIC, BIC, likelihood-ratio test with the same weights)."""
    se = np.sqrt(np.clip(np.diag(sandwich.matrix), 0.0, None))
    stated = replace(fit.engine, covariance=replace(fit.bread, matrix=np.asarray(sandwich.matrix, dtype=float),
                                                    stderr=np.where(np.isfinite(fit.bread.stderr), se, np.nan)),
                     correlation=_correlation(sandwich.matrix))
    comparison = None
    if spec.name == "linear":
        w = data.weights
        mean = float(np.sum(w * data.e) / np.sum(w))
        rss_constant = float(np.sum(w * (data.e - mean) ** 2))
        comparison = compare_models([{"name": "constant", "n_params": 1, "n_data": data.n, "rss": rss_constant},
                                     {"name": "linear", "n_params": 2, "n_data": data.n, "rss": fit.rss}],
                                    nested=[("constant", "linear")], choice="constant e or e = e0 - gamma v")
    return identifiability(fit.found, stated, comparison=comparison, describes_data=checked.describes_data,
                           quadratic_reason="the law is linear: the quadratic profile is exact")


def fit_law(law: str | Law, v, e, *, weights=None, noise_cov: np.ndarray | TimingNoise | None = None,
            groups: Sequence | None = None, confidence: float = 0.95, hac_lag: int = 2, label: str = "") -> LawFit:
    """Fit a restitution law to per-impact coefficients by weighted least squares.

    Parameters
    ----------
    law : a name of :data:`LAWS` or a :class:`Law`.
    v : impact speeds [m/s].
    e : coefficients of restitution [-].
    weights : inverse relative variances of the coefficients (see :func:`variance_model`); equal if None.
    noise_cov : covariance of the coefficients under the noise model (``tau^2 I + sigma_t^2 J J^T``,
        block-diagonal by drop), for the model-based errors: a :class:`TimingNoise` (its factors) or
        an (n, n) array; None: independent, variances from the residual scale and ``weights``.
    groups : the drop of each impact (the clusters); None: one drop.
    confidence : coverage of the intervals.
    hac_lag : with fewer than :data:`MIN_CLUSTERS` drops, the neighbours (within a drop) whose
        correlation the Newey-West sandwich allows for (2: the timing noise of one event reaches
        three consecutive coefficients).
    label : what was fitted, for the provenance.

    Returns
    -------
    LawFit
        the one :class:`~impactid.results.FitResult` of the fit: the parameters (value, stderr,
        Student-t interval, unit; undetermined, with the reason, when the design's condition is
        beyond :data:`~impactid.engine.covariance.CONDITION_LIMIT`), statistics (AIC, BIC, the condition
        number, the runs test), notes (a lack of fit, few drops) and in ``details`` the covariance,
        the correlation matrix and how the errors were formed.

    Raises
    ------
    ValueError
        too few coefficients for the law's parameters, or a non-finite input.
    """
    spec = get_law(law)
    data = _law_data(spec, v, e, weights, groups)
    fit = _weighted_least_squares(spec, data, confidence)
    cov_model = _model_covariance(spec, data, fit, noise_cov)
    sandwich = _never_below_model(_robust_covariance(fit, data.groups, hac_lag), cov_model, spec.names)
    check = runs_check(data.v, fit.residuals)
    notes = [*fit.engine.notes, *filter(None, (_lack_of_fit_note(spec, check, data.v),))]
    notes += sandwich.notes
    checked = _law_model_check(spec, data, fit, check)
    notes += checked.notes
    n_drops = int(np.unique(data.groups).size)
    details = {"law": spec.name, "formula": spec.formula, "covariance": sandwich.matrix.tolist(),
               "correlation": _correlation(sandwich.matrix).tolist(), "covariance_model": cov_model.tolist(),
               "covariance_method": sandwich.method, "dof": sandwich.dof,
               "speed_range": [float(data.v.min()), float(data.v.max())]}
    return LawFit(params=_law_parameters(fit.engine, sandwich.matrix, sandwich.dof, confidence),
                  statistics=_law_statistics(spec, data, fit, sandwich, check, n_drops), notes=tuple(notes),
                  details=details, model_check=combine_checks([checked]),
                  identifiability=_law_identifiability(spec, data, fit, sandwich, checked),
                  provenance=(f"fit {spec.name} law ({spec.formula}) to {data.n} coefficients from {n_drops} drop(s)"
                              + (f" [{label}]" if label else "")
                              + f": weighted least squares in closed form, stated through impactid.engine; errors "
                                f"{sandwich.method}",))


def select_law(fits: Mapping[str, LawFit], criterion: str = "bic", margin: float = 2.0) -> tuple[str, str]:
    """The law to report: smallest ``criterion`` (``aic`` or ``bic``), a simpler one preferred
    when within ``margin`` of the best. Returns (name, reason)."""
    if criterion not in ("aic", "bic"):
        raise ValueError(f"unknown criterion {criterion!r}; valid: aic, bic")
    values = {name: float(fit.statistics[criterion]) for name, fit in fits.items()}
    best = min(values, key=values.get)
    close = [name for name in values if values[name] - values[best] < margin]
    chosen = min(close, key=lambda n: (fits[n].law.n_params, values[n]))
    ranking = ", ".join(f"{n} {values[n] - values[best]:+.1f}" for n in sorted(values, key=values.get))
    if chosen == best:
        reason = f"smallest {criterion.upper()} (differences: {ranking})"
    else:
        reason = (f"{best} has the smallest {criterion.upper()}, but {chosen} is within {margin:g} with fewer "
                  f"parameters (differences: {ranking})")
    return chosen, reason


# ---- chained trajectory fit ---------------------------------------------------------------------


@dataclass(frozen=True)
class ChainedFit(FitResult):
    """A law fitted to every accepted event time of every drop by chaining flights.

    ``details`` holds ``law``, ``formula``, ``covariance`` (of the law parameters), ``correlation``,
    ``covariance_method``, ``drops`` (per drop: name, fitted first impact time [s] and launch speed
    [m/s]) and ``residuals_s``; ``statistics`` the counts, ``timing_sigma_s`` (the residual scale
    [s]), with a measured timing noise ``timing_noise_s`` [s] and ``residual_over_timing_noise``
    (the model check), ``loglik``, ``aic``, ``bic``, ``condition_number`` (of the column-scaled ``J^T J``, the
    drops' starts included), ``success`` and ``nfev``.
    """

    kind = "restitution-chained"
    title = "Chained trajectory fit"

    @property
    def law(self) -> Law:
        return get_law(self.details["law"])

    @property
    def beta(self) -> np.ndarray:
        return np.array([self.params[n].value for n in self.law.names])


def _chain_times(law: Law, beta, t0: np.ndarray, u0: np.ndarray, numbers: np.ndarray, mask: np.ndarray,
                 constants: FlightConstants) -> np.ndarray:
    """Predicted impact times of several drops at once.

    ``t0``, ``u0``: (D,) first impact times [s] and launch speeds [m/s]; ``numbers``: (D, K) impact
    numbers (0 = the first), ``mask`` (D, K) which of them exist. Returns (D, K) times."""
    steps = int(numbers[mask].max()) if mask.any() else 0
    times = np.empty((t0.size, steps + 1))
    times[:, 0] = t0
    u = u0.copy()
    X_offset = law.offset
    beta = np.asarray(beta, dtype=float)
    for m in range(steps):
        times[:, m + 1] = times[:, m] + flight_time(u, constants)
        w = landing_speed(u, constants)
        e = X_offset + law.design(w) @ beta
        u = np.clip(e, 0.0, 2.0) * w
    return np.take_along_axis(times, np.where(mask, numbers, 0), axis=1)


@dataclass(frozen=True)
class ChainData:
    """The accepted event times of several drops, stacked for the chained fit.

    Attributes
    ----------
    observed : (D, K) event times [s] (zero where ``mask`` is False).
    numbers : (D, K) impact numbers, 0 for a drop's first (a gap of 2 is a missed bounce).
    mask : (D, K) which entries exist.
    sizes : events of each drop.
    clusters : the cluster (drop of origin) of each row: segments of one drop split at odd
        bounces share one.
    names : each row's name.
    """

    observed: np.ndarray
    numbers: np.ndarray
    mask: np.ndarray
    sizes: tuple[int, ...]
    clusters: tuple[str, ...]
    names: tuple[str, ...]

    @property
    def n_events(self) -> int:
        return int(sum(self.sizes))


def _chain_data(drops: Sequence[Mapping]) -> ChainData:
    """The drops' accepted times and impact numbers as (D, K) arrays."""
    sizes = tuple(int(np.asarray(d["times"]).size) for d in drops)
    D, K = len(drops), max(sizes)
    numbers = np.zeros((D, K), dtype=int)
    observed = np.zeros((D, K))
    mask = np.zeros((D, K), dtype=bool)
    for j, d in enumerate(drops):
        size = sizes[j]
        numbers[j, :size] = np.asarray(d["numbers"], int)
        observed[j, :size] = np.asarray(d["times"], float)
        mask[j, :size] = True
    return ChainData(observed, numbers, mask, sizes,
                     tuple(str(d.get("cluster", d.get("name", j))) for j, d in enumerate(drops)),
                     tuple(str(d.get("name", str(j))) for j, d in enumerate(drops)))


def _chain_start(spec: Law, drops: Sequence[Mapping], constants: FlightConstants, start) -> np.ndarray:
    """Starting values: the law's parameters (``start``, or a constant 0.9 and its analogues),
    then per drop its first impact time [s] and its launch speed [m/s] from its first single
    flight, stepped back to the first impact with the starting law."""
    beta0 = np.asarray(start, dtype=float) if start is not None else {
        "constant": np.array([0.9]), "linear": np.array([0.9, 0.0]), "viscoelastic": np.array([0.1])}.get(
        spec.name, np.full(spec.n_params, 0.1))
    x0 = list(beta0)
    for d in drops:
        t, num = np.asarray(d["times"], float), np.asarray(d["numbers"], int)
        k = int(np.argmax(np.diff(num) == 1)) if np.any(np.diff(num) == 1) else 0
        T0 = (t[k + 1] - t[k]) / max(num[k + 1] - num[k], 1)
        u = float(launch_speed(T0, constants))
        for _ in range(k if num[k] > 0 else 0):  # step back to the first impact with the starting law
            u = u / max(float(spec.evaluate(beta0, u)), 0.3)
        x0 += [t[0], u]
    return np.array(x0)


#: Relative step of the chained fit's central differences: the cube root of the machine epsilon
#: (the truncation and rounding errors of a central difference balance there), as SciPy's "3-point".
DIFFERENCE_STEP = float(np.finfo(float).eps) ** (1.0 / 3.0)


#: Most parameters (law and drops' starts) for which the chained search solves its trust-region
#: subproblems exactly (a dense SVD each iteration, cubic in the number of drops); above, by LSMR
#: (as SciPy does for a sparse Jacobian).
EXACT_SOLVER_MAX_PARAMS = 200


def _chain_free(spec: Law, data: ChainData, x0: np.ndarray) -> tuple[Free, ...]:
    """The chained fit's parameters for the engine: the law's (reported), then per row its first
    impact time [s] and launch speed [m/s] (nuisance parameters, reported in ``details["drops"]``)."""
    p = spec.n_params
    law = [Free(name, float(x0[i]), unit=unit) for i, (name, unit) in enumerate(zip(spec.names, spec.units))]
    starts = [Free(f"{q}[{name}]", float(x0[p + 2 * j + k]), unit=unit, report=False)
              for j, name in enumerate(data.names) for k, (q, unit) in enumerate((("t0", "s"), ("u0", "m/s")))]
    return tuple(law + starts)


def _chain_jacobian(residuals: Callable[[np.ndarray], np.ndarray], p: int, data: ChainData):
    """The Jacobian of the chained residuals by central differences, grouped by its pattern: every
    event depends on the law's ``p`` parameters and on its own drop's two starts only, so all the
    drops' ``t0`` (and then all their ``u0``) are stepped at once, ``2 p + 4`` residual evaluations
    a Jacobian whatever the number of drops (SciPy's ``jac_sparsity`` grouping, which the engine's
    dense differences do not do)."""
    D = len(data.sizes)
    drop_of_row = np.repeat(np.arange(D), data.sizes)
    rows = np.arange(drop_of_row.size)

    def jacobian(u: np.ndarray) -> np.ndarray:
        u = np.asarray(u, dtype=float)
        J = np.zeros((rows.size, u.size))
        for cols in [[i] for i in range(p)] + [p + 2 * np.arange(D), p + 1 + 2 * np.arange(D)]:
            cols = np.asarray(cols)
            h = DIFFERENCE_STEP * np.maximum(1.0, np.abs(u[cols]))
            up, down = u.copy(), u.copy()
            up[cols] += h
            down[cols] -= h
            step = (up - down)[cols]  # the steps as represented
            diff = residuals(up) - residuals(down)
            if cols.size == 1:
                J[:, cols[0]] = diff / step[0]
            else:
                J[rows, cols[drop_of_row]] = diff / step[drop_of_row]
        return J

    return jacobian


def _chained_covariance(J: np.ndarray, r: np.ndarray, data: ChainData, spec: Law, bread: Covariance) -> Sandwich:
    """The covariance of the law's parameters in the chained fit: cluster-robust by drop (CR1)
    never below the model-based one with at least :data:`MIN_CLUSTERS` drops, else model-based
    (independent event-time errors, scale from the residuals). ``bread``: the engine's
    ``(J^T J)^-1`` of every parameter (the drops' starts included) at unit scale."""
    N, P = J.shape
    p = spec.n_params
    rss = float(r @ r)
    sigma2 = rss / max(N - P, 1)
    B = bread.matrix
    cov_model = (sigma2 * B)[:p, :p]
    labels = sorted(set(data.clusters))
    G = len(labels)
    if G < MIN_CLUSTERS:
        dof = max(N - P, 1)
        note = (f"{G} drop(s): model-based errors, which assume independent event-time errors; a bounce-to-"
                "bounce scatter of e accumulates along a drop and makes them too small")
        return Sandwich(cov_model, dof, f"model-based (independent event-time errors), t with {dof} dof",
                        (note,))
    rows_of: dict[str, list[int]] = {c: [] for c in labels}
    pos = 0
    for j, size in enumerate(data.sizes):
        rows_of[data.clusters[j]].extend(range(pos, pos + size))
        pos += size
    meat = np.zeros((P, P))
    for c in labels:
        rows = np.array(rows_of[c])
        sg = np.asarray(J[rows].T @ r[rows]).ravel()
        meat += np.outer(sg, sg)
    cov_robust = (B @ meat @ B)[:p, :p] * (G / (G - 1)) * ((N - 1) / max(N - P, 1))
    raise_to = np.sqrt(np.maximum(np.diag(cov_model), 1e-300) / np.maximum(np.diag(cov_robust), 1e-300))
    D = np.diag(np.maximum(raise_to, 1.0))
    dof = G - 1
    return Sandwich(D @ cov_robust @ D, dof,
                    f"cluster-robust by drop (CR1, {G} drops, t with {dof} dof), never below model-based")


def _chained_lack_of_fit(spec: Law, r: np.ndarray, dof: int,
                         timing_noise: float | None) -> tuple[dict, tuple[str, ...]]:
    """The chained fit's model check (:func:`impactid.engine.residual_against_noise`): its residuals
    ``r`` [s] against the timing noise of the events ``timing_noise`` [s] (measured independently,
    e.g. from the per-impact coefficients). The residuals are taken at the fit's residual scale
    (``r sqrt(N / dof)``: the drops' starts and the law absorb ``N - dof`` degrees of freedom), so
    that the ratio is the residual scale ``timing_sigma_s`` over the noise. Statistics and, above
    :data:`LACK_OF_FIT_FACTOR` (or for a significant excess), a note."""
    if timing_noise is None or not (math.isfinite(timing_noise) and timing_noise > 0):
        return {}, ()
    stats, notes = residual_against_noise(r * math.sqrt(r.size / max(dof, 1)), timing_noise, what="event times",
                                          unit="s")
    statistics = {"timing_noise_s": float(timing_noise), "residual_over_timing_noise": stats["residual_over_noise"]}
    why = (f"here the {spec.name} law, one e per impact speed, does not describe whole drops (a bounce-to-bounce "
           "scatter of e accumulates along a drop, or the flight model misses something); the intervals are widened "
           "by the residual scale")
    return statistics, tuple(f"{note}; {why}" for note in notes)


def fit_chained(drops: Sequence[Mapping], law: str | Law, constants: FlightConstants, *,
                start: Sequence[float] | None = None, confidence: float = 0.95,
                timing_noise: float | None = None) -> ChainedFit:
    """Fit ``law`` to the accepted event times of several drops, flight by flight.

    The search is the identification engine's (:func:`impactid.engine.search`: trust-region
    reflective, tolerances 1e-12, at most 500 evaluations) over the law's parameters and each
    drop's first impact time and launch speed, with the Jacobian by central differences grouped by
    drop (:func:`_chain_jacobian`); the bread ``(J^T J)^-1`` of every parameter, its condition and
    the notes come from :func:`impactid.engine.uncertainty`, the robust errors from the ball's own
    sandwich on top of it (the event times of one drop are not independent: see the module's
    documentation), and the model check from :func:`impactid.engine.residual_against_noise`.

    Parameters
    ----------
    drops : per drop a mapping with ``name``, ``times`` (accepted impact times [s]) and ``numbers``
        (their impact numbers, 0 for the first; a gap of 2 is a missed bounce); optionally
        ``cluster`` (segments of one drop share one).
    law : the law.
    constants : the flight (:func:`~impactid.rigs.ball.flight.flight_constants`).
    start : starting law parameters (default: a constant 0.9 or its analogue).
    confidence : coverage of the intervals.
    timing_noise : the timing noise of one event [s], measured independently (the analysis gives
        the per-impact fits' ``sigma_t``), for the model check; None: no check.

    Returns
    -------
    ChainedFit
        the one :class:`~impactid.results.FitResult` of the fit: the law's parameters with
        cluster-robust errors by drop (never below the model-based ones; model-based with fewer
        than :data:`MIN_CLUSTERS` drops), undetermined with the reason when the Jacobian's
        condition is beyond :data:`~impactid.engine.covariance.CONDITION_LIMIT`; statistics (the timing
        scatter of the residuals, AIC, BIC, the condition number and, with ``timing_noise``, the
        residual scale over it: above :data:`LACK_OF_FIT_FACTOR`, or significantly above 1 by the
        engine's chi-square rule, a note reports it); in ``details`` the covariance, the
        correlation matrix, each drop's fitted start and the residuals.

    Raises
    ------
    ValueError
        too few event times for the parameters.
    """
    spec = get_law(law)
    p = spec.n_params
    x0 = _chain_start(spec, drops, constants, start)
    data = _chain_data(drops)
    if data.n_events <= p + 2 * len(drops):
        raise ValueError("too few event times for the chained fit")

    def residuals(x):
        pred = _chain_times(spec, x[:p], x[p::2], x[p + 1::2], data.numbers, data.mask, constants)
        return (data.observed - pred)[data.mask]

    # the engine's search (trust-region reflective, tolerances 1e-12) in the parameters' own
    # coordinates, with the Jacobian's central differences grouped by its pattern
    found = search(residuals, _chain_free(spec, data, x0), jacobian=_chain_jacobian(residuals, p, data),
                   max_nfev=500, normalise=False,
                   tr_solver="lsmr" if x0.size > EXACT_SOLVER_MAX_PARAMS else None)
    r = found.residual
    N, P = data.n_events, x0.size
    rss = float(r @ r)
    stated = uncertainty(found, confidence=confidence, scale=1.0)  # the bread (J^T J)^-1, its condition
    sandwich = _chained_covariance(found.jacobian, r, data, spec, stated.covariance)
    notes = [] if found.success else [f"the optimiser stopped without converging: {found.message}"]
    notes += stated.notes
    timing_sigma = math.sqrt(rss / max(N - P, 1))
    check, lack = _chained_lack_of_fit(spec, r, N - P, timing_noise)
    notes += lack
    notes += sandwich.notes
    drop_of = np.repeat(np.arange(len(data.sizes)), data.sizes)
    checked = check_model(r, timing_noise if timing_noise is not None and math.isfinite(timing_noise) else None,
                          noise_reference="the timing noise of one event, measured by the per-impact fits",
                          what="event times", unit="s", n_params=P, groups=drop_of,
                          assumed_sd=math.sqrt(rss / max(N - P, 1)))
    notes += checked.further_notes
    loglik = -0.5 * N * (math.log(2.0 * math.pi * rss / N) + 1.0) if rss > 0 else math.inf
    statistics = {"n_events": N, "n_drops": len(drops), "n_params": P, "dof": sandwich.dof,
                  "timing_sigma_s": timing_sigma, **check, "loglik": loglik,
                  "aic": 2 * (P + 1) - 2 * loglik, "bic": (P + 1) * math.log(N) - 2 * loglik,
                  "condition_number": stated.covariance.condition, "success": bool(found.success),
                  "nfev": int(found.nfev)}
    x = found.x
    details = {"law": spec.name, "formula": spec.formula, "covariance": sandwich.matrix.tolist(),
               "correlation": _correlation(sandwich.matrix).tolist(), "covariance_method": sandwich.method,
               "drops": [{"name": name, "t0_s": float(x[p + 2 * j]), "u0_m_s": float(x[p + 2 * j + 1])}
                         for j, name in enumerate(data.names)],
               "residuals_s": r.tolist()}
    params = checked.widen(_law_parameters(stated, sandwich.matrix, sandwich.dof, confidence))
    se = np.sqrt(np.clip(np.diag(sandwich.matrix), 0.0, None))
    law_se = np.where(np.isfinite(stated.covariance.stderr[:p]), se, np.nan)
    reported = replace(stated, covariance=replace(stated.covariance,
                                                  stderr=np.concatenate([law_se, stated.covariance.stderr[p:]])),
                       correlation=np.pad(_correlation(sandwich.matrix), ((0, P - p), (0, P - p)),
                                          constant_values=np.nan))
    described = identifiability(found, reported, describes_data=checked.describes_data,
                                quadratic_reason="a refit of every drop's start per point costs a whole fit")
    return ChainedFit(params=params, statistics=statistics, notes=tuple(notes), details=details,
                      model_check=combine_checks([checked]), identifiability=described,
                      provenance=(f"chained trajectory fit of the {spec.name} law to {N} event times of "
                                  f"{len(drops)} drop(s) ({constants.label}): impactid.engine's search and "
                                  f"uncertainty; errors {sandwich.method}",))


def law_table(fits: Mapping[str, FitResult]) -> pd.DataFrame:
    """One row per law: parameters (value +/- stderr), AIC, BIC and their differences to the best."""
    rows = []
    for name, fit in fits.items():
        row = {"law": name, "n_params": len(fit.params), "aic": fit.statistics.get("aic"),
               "bic": fit.statistics.get("bic")}
        row["parameters"] = "; ".join(f"{p.name} = {p.value:.5g} +/- {p.stderr:.2g}" for p in fit.params.values())
        rows.append(row)
    frame = pd.DataFrame(rows)
    if len(frame):
        frame["delta_aic"] = frame["aic"] - frame["aic"].min()
        frame["delta_bic"] = frame["bic"] - frame["bic"].min()
    return frame

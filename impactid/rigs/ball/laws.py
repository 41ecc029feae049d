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

Model selection by the Gaussian likelihood with the fitted variances: AIC and BIC (the scale
counted as a parameter); the law with the smallest criterion is selected, except that a simpler
law within 2 of the best is preferred ("not worth more parameters").

The chained trajectory fit (:func:`fit_chained`) predicts every accepted event time of a drop from
the drop's first impact time and first launch speed, flight by flight with the law (missed
bounces included as sums of flights), and fits all drops at once by nonlinear least squares: a
cross-check that uses every interval, including the ones a missed bounce merged.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from impactid.results import FitResult, Parameter
from impactid.rigs.ball.flight import FlightConstants, flight_time, landing_speed

__all__ = ["LAWS", "MIN_CLUSTERS", "ChainedFit", "Law", "LawFit", "TimingNoise", "fit_chained", "fit_law", "get_law",
           "law_table", "select_law", "variance_model"]

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
    """A restitution law fitted to per-impact coefficients (weighted least squares, errors
    cluster-robust by drop).

    ``details`` holds ``law`` (name), ``formula``, ``covariance`` (of the parameters, as used for
    the errors), ``covariance_method``, ``dof`` (of the t intervals) and ``speed_range`` [m/s].
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
        from scipy.stats import t as student

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
    from scipy.optimize import nnls

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


def fit_law(law: str | Law, v, e, *, weights=None, noise_cov: np.ndarray | None = None,
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
    """
    from scipy.stats import t as student

    spec = get_law(law)
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
    X = spec.design(v)
    y = e - spec.offset
    sw = np.sqrt(w)
    Xw, yw = X * sw[:, None], y * sw
    beta, *_ = np.linalg.lstsq(Xw, yw, rcond=None)
    r = yw - Xw @ beta  # weighted residuals
    rss = float(r @ r)
    sigma2 = rss / (n - p)
    bread = np.linalg.inv(Xw.T @ Xw)
    if noise_cov is None:
        cov_model = sigma2 * bread
    else:
        A = bread @ (X * w[:, None]).T  # beta = A y
        if isinstance(noise_cov, TimingNoise):
            cov_model = noise_cov.sandwich(A)
        else:
            cov_model = A @ np.asarray(noise_cov, dtype=float) @ A.T
    labels, index = np.unique(groups, return_inverse=True)
    G = labels.size
    notes = []
    scores = Xw * r[:, None]
    if G >= MIN_CLUSTERS:
        meat = np.zeros((p, p))
        for g in range(G):
            sg = scores[index == g].sum(axis=0)
            meat += np.outer(sg, sg)
        cov_robust = bread @ meat @ bread * (G / (G - 1)) * ((n - 1) / (n - p))
        dof = G - 1
        method = f"cluster-robust by drop (CR1, {G} drops, t with {dof} dof)"
    else:
        meat = scores.T @ scores
        for lag in range(1, hac_lag + 1):
            weight = 1.0 - lag / (hac_lag + 1.0)
            for g in range(G):
                sg = scores[index == g]
                if sg.shape[0] > lag:
                    cross = sg[lag:].T @ sg[:-lag]
                    meat += weight * (cross + cross.T)
        cov_robust = bread @ meat @ bread * (n / (n - p))
        dof = n - p
        method = f"Newey-West within each drop (lag {hac_lag}, {G} drop(s), t with {dof} dof)"
        notes.append(f"{G} drop(s): fewer than {MIN_CLUSTERS} for errors clustered by drop; the errors allow for "
                     f"correlation between neighbouring impacts only, not for drop-to-drop variation")
    raise_to = np.sqrt(np.maximum(np.diag(cov_model), 1e-300) / np.maximum(np.diag(cov_robust), 1e-300))
    D = np.diag(np.maximum(raise_to, 1.0))
    cov = D @ cov_robust @ D
    raised = [spec.names[i] for i in range(p) if raise_to[i] > 1.0]
    if raised:
        method += f"; raised to the model-based error for {', '.join(raised)}"
    q = student.ppf(0.5 + confidence / 2.0, dof)
    params = []
    for i, (name, unit) in enumerate(zip(spec.names, spec.units)):
        se = math.sqrt(max(cov[i, i], 0.0))
        params.append(Parameter(name, float(beta[i]), se, (beta[i] - q * se, beta[i] + q * se), confidence,
                                unit=unit))
    # Gaussian likelihood with the given relative variances 1/w and a free scale (ML)
    loglik = (-0.5 * n * (math.log(2.0 * math.pi * rss / n) + 1.0) + 0.5 * float(np.sum(np.log(w)))
              if rss > 0 else math.inf)
    k = p + 1
    statistics = {"n_impacts": n, "n_drops": G, "n_params": p, "dof": dof,
                  "scale": math.sqrt(sigma2), "loglik": loglik, "aic": 2 * k - 2 * loglik,
                  "bic": k * math.log(n) - 2 * loglik,
                  "speed_min_m_s": float(v.min()), "speed_max_m_s": float(v.max())}
    details = {"law": spec.name, "formula": spec.formula, "covariance": cov.tolist(),
               "covariance_model": cov_model.tolist(), "covariance_method": method, "dof": dof,
               "speed_range": [float(v.min()), float(v.max())]}
    return LawFit(params=params, statistics=statistics, notes=tuple(notes), details=details,
                  provenance=(f"fit {spec.name} law ({spec.formula}) to {n} coefficients from {G} drop(s)"
                              + (f" [{label}]" if label else "") + f": weighted least squares; errors {method}",))


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

    ``details`` holds ``law``, ``formula``, ``covariance`` (of the law parameters), ``drops`` (per
    drop: name, fitted first impact time [s] and launch speed [m/s]) and ``residuals_s``.
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


def fit_chained(drops: Sequence[Mapping], law: str | Law, constants: FlightConstants, *,
                start: Sequence[float] | None = None, confidence: float = 0.95) -> ChainedFit:
    """Fit ``law`` to the accepted event times of several drops, flight by flight.

    Parameters
    ----------
    drops : per drop a mapping with ``name``, ``times`` (accepted impact times [s]) and ``numbers``
        (their impact numbers, 0 for the first; a gap of 2 is a missed bounce).
    law : the law.
    constants : the flight (:func:`~impactid.rigs.ball.flight.flight_constants`).
    start : starting law parameters (default: a constant 0.9 or its analogue).
    confidence : coverage of the intervals.

    Returns
    -------
    ChainedFit, with model-based errors (independent event-time errors; the scale from the residuals).
    """
    from scipy.optimize import least_squares
    from scipy.sparse import lil_matrix
    from scipy.stats import t as student

    from impactid.rigs.ball.flight import launch_speed

    spec = get_law(law)
    p = spec.n_params
    beta0 = np.asarray(start, dtype=float) if start is not None else {
        "constant": np.array([0.9]), "linear": np.array([0.9, 0.0]), "viscoelastic": np.array([0.1])}.get(
        spec.name, np.full(p, 0.1))
    x0 = list(beta0)
    sizes = []
    for d in drops:
        t, num = np.asarray(d["times"], float), np.asarray(d["numbers"], int)
        k = int(np.argmax(np.diff(num) == 1)) if np.any(np.diff(num) == 1) else 0
        T0 = (t[k + 1] - t[k]) / max(num[k + 1] - num[k], 1)
        u = float(launch_speed(T0, constants))
        for _ in range(k if num[k] > 0 else 0):  # step back to the first impact with the starting law
            u = u / max(float(spec.evaluate(beta0, u)), 0.3)
        x0 += [t[0], u]
        sizes.append(t.size)
    x0 = np.array(x0)
    total = sum(sizes)
    if total <= p + 2 * len(drops):
        raise ValueError("too few event times for the chained fit")
    D, K = len(drops), max(sizes)
    numbers = np.zeros((D, K), dtype=int)
    observed = np.zeros((D, K))
    mask = np.zeros((D, K), dtype=bool)
    for j, d in enumerate(drops):
        size = sizes[j]
        numbers[j, :size] = np.asarray(d["numbers"], int)
        observed[j, :size] = np.asarray(d["times"], float)
        mask[j, :size] = True

    def residuals(x):
        pred = _chain_times(spec, x[:p], x[p::2], x[p + 1::2], numbers, mask, constants)
        return (observed - pred)[mask]

    sparsity = lil_matrix((total, x0.size), dtype=int)
    pos = 0
    for j, size in enumerate(sizes):
        sparsity[pos:pos + size, :p] = 1
        sparsity[pos:pos + size, p + 2 * j:p + 2 * j + 2] = 1
        pos += size
    sol = least_squares(residuals, x0, jac_sparsity=sparsity, x_scale="jac", xtol=1e-12, ftol=1e-12, gtol=1e-12,
                        max_nfev=500)
    r = sol.fun
    N, P = total, x0.size
    rss = float(r @ r)
    sigma2 = rss / max(N - P, 1)
    J = sol.jac  # sparse (events x parameters, two drop columns a row): never made dense
    notes = [] if sol.success else [f"the optimiser stopped without converging: {sol.message}"]
    JTJ = J.T @ J
    JTJ = JTJ.toarray() if hasattr(JTJ, "toarray") else np.asarray(JTJ)
    try:
        bread = np.linalg.inv(JTJ) if np.all(np.isfinite(JTJ)) else np.full((P, P), np.nan)
    except np.linalg.LinAlgError:
        bread = np.full((P, P), np.nan)
    cov_model = (sigma2 * bread)[:p, :p]
    clusters = [str(d.get("cluster", d.get("name", j))) for j, d in enumerate(drops)]
    labels = sorted(set(clusters))
    G = len(labels)
    if G >= MIN_CLUSTERS:
        meat = np.zeros((P, P))
        pos = 0
        rows_of = {c: [] for c in labels}
        for j, size in enumerate(sizes):
            rows_of[clusters[j]].extend(range(pos, pos + size))
            pos += size
        for c in labels:
            rows = np.array(rows_of[c])
            sg = np.asarray(J[rows].T @ r[rows]).ravel()
            meat += np.outer(sg, sg)
        cov_robust = (bread @ meat @ bread)[:p, :p] * (G / (G - 1)) * ((N - 1) / max(N - P, 1))
        raise_to = np.sqrt(np.maximum(np.diag(cov_model), 1e-300) / np.maximum(np.diag(cov_robust), 1e-300))
        D_ = np.diag(np.maximum(raise_to, 1.0))
        cov = D_ @ cov_robust @ D_
        dof = G - 1
        method = f"cluster-robust by drop (CR1, {G} drops, t with {dof} dof), never below model-based"
    else:
        cov = cov_model
        dof = max(N - P, 1)
        method = f"model-based (independent event-time errors), t with {dof} dof"
        notes.append(f"{G} drop(s): model-based errors, which assume independent event-time errors; a bounce-to-"
                     "bounce scatter of e accumulates along a drop and makes them too small")
    q = student.ppf(0.5 + confidence / 2.0, dof)
    params = []
    for i, (name, unit) in enumerate(zip(spec.names, spec.units)):
        se = math.sqrt(cov[i, i]) if math.isfinite(cov[i, i]) and cov[i, i] >= 0 else math.nan
        params.append(Parameter(name, float(sol.x[i]), se, (sol.x[i] - q * se, sol.x[i] + q * se), confidence,
                                unit=unit))
    loglik = -0.5 * N * (math.log(2.0 * math.pi * rss / N) + 1.0) if rss > 0 else math.inf
    statistics = {"n_events": N, "n_drops": len(drops), "n_params": P, "dof": dof,
                  "timing_sigma_s": math.sqrt(sigma2), "loglik": loglik, "aic": 2 * (P + 1) - 2 * loglik,
                  "bic": (P + 1) * math.log(N) - 2 * loglik, "success": bool(sol.success), "nfev": int(sol.nfev)}
    details = {"law": spec.name, "formula": spec.formula, "covariance": cov.tolist(), "covariance_method": method,
               "drops": [{"name": d.get("name", str(j)), "t0_s": float(sol.x[p + 2 * j]),
                          "u0_m_s": float(sol.x[p + 2 * j + 1])} for j, d in enumerate(drops)],
               "residuals_s": r.tolist()}
    return ChainedFit(params=params, statistics=statistics, notes=tuple(notes), details=details,
                      provenance=(f"chained trajectory fit of the {spec.name} law to {N} event times of "
                                  f"{len(drops)} drop(s) ({constants.label})",))


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

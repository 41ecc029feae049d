"""The engine's model check: whether a model describes the data.

Two levels:

* :func:`residual_against_noise`: the residual's size against the recording's own noise, with a
  note when the model does not describe the data (the statistics every fit has reported since the
  engine was introduced);
* :func:`check_model`: the whole check every fit runs (docs/identifiability.md), a
  :class:`ModelCheck`:

  1. **scatter against the noise reference** of the data kind: a recording's channels between
     impacts, an encoder's quantisation step over ``sqrt(12)``, a timing's trigger jitter, the
     scatter of a synchronous average over revolutions; where the data carry no noise reference
     (NIST problems, per-impact residuals of a pipeline) the residual variance itself, and then the
     scatter is not tested (it cannot be: the covariance was scaled by it);
  2. **lack-of-fit statistic**: ``chi^2 = sum (r / sigma)^2`` with ``dof = n - p`` and its upper-tail
     p-value (with a noise reference);
  3. **structure across events**: the correlation of the per-event residual with the rig's
     per-event covariate (an approach speed, a cam speed), within groups (recordings, drops) when
     given, with its two-sided p-value; the spread of the groups' mean residuals against their
     standard errors and a systematic floor; the lag-1 autocorrelation of consecutive residuals
     (negative: alternation between consecutive impacts; positive: a persistent, smooth misfit) and
     the runs test on their signs; the effective number of independent residuals ``n_eff`` from the
     integrated autocorrelation.

  Structure is evidence against the model only where the residual is larger than what the model
  may leave: a residual at or below its noise reference bounds what the model misses whatever its
  shape, and without a noise reference, a residual below the rig's ``structure_floor`` (the
  residual level its own pipeline reaches on noise-free data of the right model) means nothing.

The verdict, and what the fit does about it (:meth:`ModelCheck.widen`):

====================== ===================================================================================
verdict                meaning
====================== ===================================================================================
``consistent``         no evidence against the model: intervals as computed
``systematic misfit``  the residual's mean square exceeds the noise's significantly, below
                       :data:`LACK_OF_FIT_FACTOR` times it
``structured``         the residual trends with the covariate, alternates, or persists along its order
``lack of fit``        the residual RMS is more than :data:`LACK_OF_FIT_FACTOR` times the noise
``rejected``           a rig's own check (a measured quantity the fit did not use, the model contradicts)
``not checked``        too few data for any test and no noise reference
====================== ===================================================================================

**Widening rule.** Unless the verdict is ``consistent`` or ``not checked``, every standard error is
multiplied by ``inflation = sqrt(max(1, s_obs^2 / s_assumed^2)) * sqrt(max(1, n / n_eff))``: the
first factor is the residual's observed variance over the variance the covariance assumed (a
covariance scaled by a known noise is scaled up to the residual; one already scaled by the
residual variance gets 1), the second the residuals' lost independence (a smooth misfit makes
neighbouring residuals agree, so ``n`` residuals carry only ``n_eff`` independent pieces of
information). Each side of an interval moves away from the value by the same factor (in the
logarithm for an interval symmetric in it: a parameter searched in its logarithm).

**Withholding rule.** A residual more than :data:`GROSS_LACK_OF_FIT` times its noise that is also
structured (``n_eff < n / 2``, or a significant trend) is a model error, not scatter: the estimate's
error is then of the size of what the model misses, which no interval computed under the model
bounds. The standard errors and intervals are then withheld (``null``), with the reason in each
parameter's note; so are they after a rig's own check rejects the model.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from impactid.engine.distributions import chi2_sf, normal_sf, student_t_sf
from impactid.engine.intervals import safe_exp

__all__ = ["GROSS_LACK_OF_FIT", "LACK_OF_FIT_FACTOR", "MIN_STRUCTURE_DATA", "NO_NOISE_REFERENCE",
           "SIGNIFICANT_EXCESS_FLOOR", "SIGNIFICANT_EXCESS_SIGMAS", "STRUCTURE_SIGNIFICANCE", "ModelCheck",
           "check_model", "combine_checks", "governing_check", "residual_against_noise", "widen_interval"]

#: A residual RMS more than this many times the noise's is a lack of fit [-].
LACK_OF_FIT_FACTOR = 1.5
#: Sigmas of the chi-square spread by which the residual's mean square may exceed the noise's before
#: the excess is reported as systematic.
SIGNIFICANT_EXCESS_SIGMAS = 3.0
#: Smallest reported excess of the residual's mean square over the noise's [-].
SIGNIFICANT_EXCESS_FLOOR = 0.02
#: A structured residual more than this many times its noise is a model error no interval bounds:
#: the standard errors and intervals are withheld [-].
GROSS_LACK_OF_FIT = 3.0
#: Two-sided p-value below which a trend, an alternation, a persistence or a spread of the groups'
#: means counts as structure: the normal distribution's 3 sigma (0.27 % of fits of a model that
#: describes the data are flagged by chance, per test).
STRUCTURE_SIGNIFICANCE = 0.0027
#: Fewest residuals (events, samples) for a structure test: below, the tests' distributions do not hold.
MIN_STRUCTURE_DATA = 8
#: The noise reference of data that carry none.
NO_NOISE_REFERENCE = "none: the residual variance itself (the scatter is not tested)"

VERDICTS = ("consistent", "not checked", "systematic misfit", "structured", "lack of fit", "rejected")


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


# ---- the structure tests ----------------------------------------------------------------------------


def _group_slices(n: int, groups: np.ndarray | None) -> list[np.ndarray]:
    """Index arrays of the consecutive runs of equal group labels (the whole range without groups)."""
    if groups is None:
        return [np.arange(n)]
    groups = np.asarray(groups)
    cuts = np.flatnonzero(groups[1:] != groups[:-1]) + 1
    return [np.asarray(s) for s in np.split(np.arange(n), cuts)]


def _lag1(z: np.ndarray, slices: list[np.ndarray]) -> tuple[float, int]:
    """Lag-1 autocorrelation of ``z`` over consecutive pairs within each slice (each slice centred),
    and the number of pairs."""
    num = den = 0.0
    pairs = 0
    for s in slices:
        x = z[s] - np.mean(z[s]) if s.size else z[s]
        if x.size < 2:
            continue
        num += float(np.sum(x[1:] * x[:-1]))
        den += float(np.sum(x * x))
        pairs += x.size - 1
    return (num / den if den > 0 else math.nan), pairs


def _effective_samples(z: np.ndarray, slices: list[np.ndarray]) -> float:
    """Effective number of independent residuals: ``n / tau`` with ``tau = 1 + 2 sum rho_k`` summed
    over the lags before the autocorrelation first drops to zero or below (within each slice; the
    slices' autocorrelations pooled by their sums of squares). Negative correlation (alternation)
    does not count (``tau >= 1``)."""
    n = z.size
    longest = max((s.size for s in slices), default=0)
    if n < MIN_STRUCTURE_DATA or longest < 3:
        return float(n)
    den = sum(float(np.sum((z[s] - z[s].mean()) ** 2)) for s in slices if s.size)
    if not den > 0:
        return float(n)
    tau = 1.0
    for lag in range(1, longest - 1):
        num = 0.0
        for s in slices:
            x = z[s] - z[s].mean()
            if x.size > lag:
                num += float(np.sum(x[lag:] * x[:-lag]))
        rho = num / den
        if not rho > 0.0:
            break
        tau += 2.0 * rho
    return float(n / max(tau, 1.0))


def _runs(z: np.ndarray, slices: list[np.ndarray]) -> tuple[int, float, float]:
    """Wald-Wolfowitz runs of the signs of ``z`` in order within each slice: runs, their expected
    number and its standard deviation (summed over the slices; 0 where the test does not apply)."""
    runs, expected, var = 0, 0.0, 0.0
    for s in slices:
        signs = z[s] >= 0.0
        m = signs.size
        if m == 0:
            continue
        runs += 1 + int(np.count_nonzero(signs[1:] != signs[:-1]))
        pos = int(signs.sum())
        neg = m - pos
        if pos == 0 or neg == 0 or m < 2:
            expected += 1.0
            continue
        expected += 1.0 + 2.0 * pos * neg / m
        var += 2.0 * pos * neg * (2.0 * pos * neg - m) / (m * m * (m - 1.0))
    return runs, expected, math.sqrt(max(var, 0.0))


def _trend(residual: np.ndarray, covariate: np.ndarray, slices: list[np.ndarray]) -> dict[str, float]:
    """Correlation of ``residual`` with ``covariate`` within each slice (both centred per slice), its
    t statistic with ``n - groups - 1`` degrees of freedom and two-sided p-value."""
    r_c = np.concatenate([residual[s] - residual[s].mean() for s in slices])
    x_c = np.concatenate([covariate[s] - covariate[s].mean() for s in slices])
    dof = residual.size - len(slices) - 1
    sxx, syy = float(np.sum(x_c * x_c)), float(np.sum(r_c * r_c))
    if dof < 1 or not (sxx > 0.0 and syy > 0.0):
        return {"correlation": math.nan, "t": math.nan, "dof": max(dof, 0), "p_value": math.nan}
    rho = float(np.clip(np.sum(x_c * r_c) / math.sqrt(sxx * syy), -1.0, 1.0))
    t = rho * math.sqrt(dof / max(1.0 - rho * rho, 1e-300))
    return {"correlation": rho, "t": float(t), "dof": int(dof), "p_value": 2.0 * student_t_sf(abs(t), dof)}


def _between(residual: np.ndarray, slices: list[np.ndarray], floor: float) -> dict[str, float]:
    """Whether the groups' mean residuals differ more than their standard errors (and a systematic
    ``floor`` per group) allow: ``chi^2 = sum (m_g - m)^2 / (se_g^2 + floor^2)`` with ``groups - 1``
    degrees of freedom (``m`` their weighted mean)."""
    means, var = [], []
    for s in slices:
        x = residual[s]
        if x.size < 2:
            continue
        means.append(float(x.mean()))
        var.append(float(np.var(x, ddof=1)) / x.size + floor * floor)
    if len(means) < 2 or not all(v > 0 for v in var):
        return {}
    m, v = np.array(means), np.array(var)
    w = 1.0 / v
    centre = float(np.sum(w * m) / np.sum(w))
    chi2 = float(np.sum(w * (m - centre) ** 2))
    dof = len(means) - 1
    return {"groups": len(means), "chi_square": chi2, "dof": dof, "p_value": chi2_sf(chi2, dof)}


# ---- the check ------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ModelCheck:
    """The model check of one residual (one channel, one kind of data) of a fit.

    Attributes
    ----------
    what, unit : what the residual is of, and its unit.
    noise_reference : where its noise comes from (:data:`NO_NOISE_REFERENCE` where the data carry none).
    n, n_params : residuals and fitted parameters; ``dof = n - n_params``.
    residual_rms : RMS of the residual [unit].
    noise_sd : the noise reference's standard deviation (median over samples) [unit]; NaN without one.
    residual_over_noise : RMS of the residual in units of the noise; NaN without a noise reference.
    chi_square, chi_square_p_value : ``sum (r / sigma)^2`` and its upper-tail probability under
        ``chi^2(dof)``; NaN without a noise reference.
    covariate : the per-event covariate's name ("" without one); trend : its correlation with the
        residual within groups (``correlation``, ``t``, ``dof``, ``p_value``).
    between_groups : the spread of the groups' mean residuals (``groups``, ``chi_square``, ``dof``,
        ``p_value``), empty with fewer than two groups.
    lag1_autocorrelation, lag1_z : of consecutive residuals within groups, and ``rho sqrt(pairs)``.
    runs, runs_expected, runs_z : the runs test on the residuals' signs in order.
    effective_samples : ``n_eff`` (:func:`_effective_samples`).
    structure_floor : the residual level below which structure is not evidence (no noise reference) [unit].
    assumed_sd : the residual standard deviation the fit's covariance assumed [unit] (NaN: unknown).
    assumed_over_noise : the same in units of the noise reference (NaN: unknown).
    findings : what counts against the model ("trend with ...", "alternation", ...).
    verdict : one of ``consistent``, ``not checked``, ``systematic misfit``, ``structured``,
        ``lack of fit``, ``rejected``.
    inflation : the factor the standard errors are multiplied by (1: none).
    action : ``none``, ``widened`` or ``withheld``.
    notes : the check's notes, in words.
    """

    what: str
    unit: str
    noise_reference: str
    n: int
    n_params: int
    residual_rms: float
    noise_sd: float = math.nan
    residual_over_noise: float = math.nan
    chi_square: float = math.nan
    chi_square_p_value: float = math.nan
    covariate: str = ""
    trend: Mapping[str, float] = field(default_factory=dict)
    between_groups: Mapping[str, float] = field(default_factory=dict)
    lag1_autocorrelation: float = math.nan
    lag1_z: float = math.nan
    runs: int = 0
    runs_expected: float = math.nan
    runs_z: float = math.nan
    effective_samples: float = math.nan
    structure_floor: float = 0.0
    assumed_sd: float = math.nan
    assumed_over_noise: float = math.nan
    scatter_notes: tuple[str, ...] = ()
    findings: tuple[str, ...] = ()
    verdict: str = "consistent"
    inflation: float = 1.0
    action: str = "none"
    notes: tuple[str, ...] = ()

    @property
    def dof(self) -> int:
        return self.n - self.n_params

    @property
    def describes_data(self) -> bool | None:
        """Whether nothing counts against the model (None: not checked)."""
        return None if self.verdict == "not checked" else self.verdict == "consistent"

    @property
    def further_notes(self) -> tuple[str, ...]:
        """The notes beyond those of :func:`residual_against_noise` (for fits that report those already)."""
        return tuple(n for n in self.notes if n not in self.scatter_notes)

    def rejected(self, reason: str) -> ModelCheck:
        """This check with the model rejected by a rig's own check (``reason``, in words): the
        standard errors and intervals are withheld."""
        return replace(self, verdict="rejected", action="withheld", inflation=math.inf,
                       findings=self.findings + (reason,),
                       notes=self.notes + (f"model rejected: {reason}; its standard errors and intervals are "
                                           "withheld",))

    def widen_stderr(self, stderr: float) -> float:
        """A standard error after this check: times :attr:`inflation` when widened, NaN when withheld."""
        if self.action == "withheld":
            return math.nan
        return stderr * self.inflation if self.action == "widened" else stderr

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (non-finite numbers stay floats; :func:`impactid.results.json_ready` writes null)."""
        return {"what": self.what, "unit": self.unit, "noise_reference": self.noise_reference, "n": self.n,
                "n_params": self.n_params, "dof": self.dof, "residual_rms": self.residual_rms,
                "noise_sd": self.noise_sd, "residual_over_noise": self.residual_over_noise,
                "chi_square": self.chi_square, "chi_square_p_value": self.chi_square_p_value,
                "covariate": self.covariate, "trend": dict(self.trend), "between_groups": dict(self.between_groups),
                "lag1_autocorrelation": self.lag1_autocorrelation, "lag1_z": self.lag1_z, "runs": self.runs,
                "runs_expected": self.runs_expected, "runs_z": self.runs_z,
                "effective_samples": self.effective_samples, "structure_floor": self.structure_floor,
                "assumed_sd": self.assumed_sd, "assumed_over_noise": self.assumed_over_noise,
                "findings": list(self.findings), "verdict": self.verdict,
                "describes_data": self.describes_data, "inflation": self.inflation, "action": self.action,
                "notes": list(self.notes)}

    def widen(self, parameters: Sequence, *, names: Sequence[str] | None = None) -> tuple:
        """The parameters with their standard errors and intervals widened (or withheld) by this check.

        Parameters
        ----------
        parameters : :class:`~impactid.results.Parameter` objects.
        names : the parameters concerned (default: every parameter that is not fixed).

        Returns
        -------
        The parameters, those concerned widened by :attr:`inflation` (module doc: each side of the
        interval moved away from the value by the factor, in the logarithm for an interval symmetric
        in it) or withheld (standard error and interval NaN, the reason in the note); the others as
        they were.
        """
        if self.action == "none":
            return tuple(parameters)
        out = []
        for p in parameters:
            if p.fixed or (names is not None and p.name not in names) or not math.isfinite(p.value):
                out.append(p)
                continue
            if self.action == "withheld":
                why = f"withheld: {self.findings[-1] if self.findings else self.verdict}"
                out.append(replace(p, stderr=math.nan, interval=(math.nan, math.nan),
                                   note=f"{p.note}; {why}" if p.note else why))
                continue
            out.append(replace(p, stderr=p.stderr * self.inflation, interval=widen_interval(
                p.interval, p.value, self.inflation), note=(f"{p.note}; " if p.note else "")
                + f"interval widened x {self.inflation:.3g} by the model check ({self.verdict})"))
        return tuple(out)


def widen_interval(interval: tuple[float, float], value: float, factor: float) -> tuple[float, float]:
    """``interval`` with each side moved away from ``value`` by ``factor``; in the logarithm when the
    interval is positive and symmetric in it (a parameter searched in its logarithm)."""
    lo, hi = (float(v) for v in interval)
    if not (math.isfinite(lo) and math.isfinite(hi) and math.isfinite(value)):
        return lo, hi
    if lo > 0.0 and value > 0.0 and hi > 0.0:
        down, up = math.log(value / lo), math.log(hi / value)
        if down > 0.0 and up > 0.0 and abs(down - up) <= 1e-6 * max(down, up):
            return value * safe_exp(-factor * down), value * safe_exp(factor * up)
    return value - factor * (value - lo), value + factor * (hi - value)


def check_model(residual: np.ndarray, noise_sd: float | np.ndarray | None = None, *, noise_reference: str,
                what: str, unit: str = "", n_params: int = 0, groups: np.ndarray | None = None,
                order: bool = True, covariate: np.ndarray | None = None, covariate_name: str = "",
                event_residual: np.ndarray | None = None, event_groups: np.ndarray | None = None,
                structure_floor: float = 0.0, assumed_sd: float | None = None,
                assumed_over_noise: float | None = None, between: bool = True) -> ModelCheck:
    """The model check of a fit's residual (module doc): scatter, lack of fit, structure, verdict.

    Parameters
    ----------
    residual : measured minus model [unit], in the data's own order (time, cam angle, event number),
        concatenated over the groups.
    noise_sd : the noise reference's standard deviation [unit] (one value or one per residual);
        None: the data carry none (the residual variance itself).
    noise_reference : where the noise comes from, in words (``"channels between impacts"``, ...).
    what, unit : what the residual is of, and its unit (for the notes).
    n_params : parameters fitted (the chi-square's ``dof = n - n_params``).
    groups : (n,) labels of the groups (recordings, impacts, drops) the residuals fall in, in runs;
        consecutive residuals are compared within a group only.
    order : whether the residuals' order means something (time, angle, event number): False skips the
        lag-1, runs and ``n_eff`` tests (e.g. coefficients whose neighbours share data by construction).
    covariate : per-event covariate (an approach speed [m/s], a cam speed [rad/s]) of each residual,
        or of each ``event_residual`` when given; None: no trend test.
    covariate_name : its name, for the notes.
    event_residual : one residual per event (e.g. a pulse's relative amplitude misfit) for the trend
        and between-group tests, when ``residual`` holds samples; default ``residual``.
    event_groups : the groups of ``event_residual`` (default ``groups``).
    structure_floor : without a noise reference, the residual RMS below which structure is not
        evidence (the level the rig's pipeline reaches on data of the right model) [unit]; also the
        systematic error per group in the between-group test.
    assumed_sd : the residual standard deviation the fit's covariance assumed [unit] (the noise for
        a covariance scaled by a known noise; ``sqrt(RSS / dof)`` for one scaled by the residual);
        default: the noise reference, or the residual's own ``sqrt(RSS / dof)`` without one.
    assumed_over_noise : the same in units of the noise reference, for noise that varies between
        samples (``sqrt(reduced chi-square)`` of residuals weighted by it and a covariance scaled by
        the residual variance; 1 for a covariance scaled by the noise); overrides ``assumed_sd``.
    between : test whether the groups' mean residuals differ beyond their scatter (False where the
        fit absorbs a mean per group: each recording's own systematic error, a joint fit's index).

    Returns
    -------
    ModelCheck
    """
    r = np.asarray(residual, dtype=float).ravel()
    n = r.size
    if n == 0:
        raise ValueError(f"no residual of {what!r} to check")
    finite = np.isfinite(r)
    if not finite.all():
        r = r[finite]
        groups = None if groups is None else np.asarray(groups)[finite]
        if covariate is not None and event_residual is None:
            covariate = np.asarray(covariate, dtype=float)[finite]
        if noise_sd is not None and np.ndim(noise_sd) > 0:
            noise_sd = np.asarray(noise_sd, dtype=float)[finite]
        n = r.size
    rms = float(np.sqrt(np.mean(r * r))) if n else math.nan
    dof = n - int(n_params)
    slices = _group_slices(n, groups)
    notes: list[str] = []
    findings: list[str] = []
    fields: dict[str, Any] = {}
    has_noise = noise_sd is not None and bool(np.all(np.isfinite(np.asarray(noise_sd, dtype=float)))) and bool(
        np.all(np.asarray(noise_sd, dtype=float) > 0.0))
    verdict = "consistent"
    if has_noise:
        noise = np.broadcast_to(np.asarray(noise_sd, dtype=float), r.shape)
        scatter, scatter_notes = residual_against_noise(r, noise, what=what, unit=unit)
        z = r / noise
        chi2 = float(np.sum(z * z))
        fields.update(noise_sd=scatter["noise_sd"], residual_over_noise=scatter["residual_over_noise"],
                      chi_square=chi2, chi_square_p_value=chi2_sf(chi2, dof) if dof > 0 else math.nan)
        notes += scatter_notes
        ratio = scatter["residual_over_noise"]
        if ratio > LACK_OF_FIT_FACTOR:
            verdict = "lack of fit"
            findings.append(f"the residual RMS is {ratio:.3g} times its noise ({noise_reference})")
        elif scatter_notes:
            verdict = "systematic misfit"
            findings.append(f"the residual's mean square is {ratio ** 2:.3g} times its noise's ({noise_reference})")
        # a residual at its noise bounds what the model misses, whatever its shape
        gate = verdict != "consistent"
        assumed = float(np.sqrt(np.mean(noise * noise))) if assumed_sd is None else float(assumed_sd)
        if assumed_over_noise is None:
            assumed_over_noise = assumed / float(np.sqrt(np.mean(noise * noise)))
        fields.update(scatter_notes=tuple(scatter_notes), assumed_over_noise=float(assumed_over_noise))
    else:
        z = r / rms if rms > 0 else r
        gate = rms > structure_floor and n >= MIN_STRUCTURE_DATA
        assumed = (math.sqrt(float(r @ r) / dof) if dof > 0 else math.nan) if assumed_sd is None else float(assumed_sd)
        if n < MIN_STRUCTURE_DATA:
            verdict = "not checked"
            notes.append(f"{what}: {n} residual(s) and no noise reference: the model is not checked")
    # ---- structure ----
    structured: list[str] = []
    if order and n >= MIN_STRUCTURE_DATA:
        rho, pairs = _lag1(z, slices)
        runs, expected, sd = _runs(z, slices)
        fields.update(lag1_autocorrelation=rho, lag1_z=rho * math.sqrt(pairs) if pairs else math.nan, runs=runs,
                      runs_expected=expected if sd > 0 else math.nan,
                      runs_z=(runs - expected) / sd if sd > 0 else math.nan,
                      effective_samples=_effective_samples(z, slices))
        p_lag = 2.0 * normal_sf(abs(fields["lag1_z"])) if math.isfinite(fields["lag1_z"]) else math.nan
        if gate and p_lag < STRUCTURE_SIGNIFICANCE:
            kind = "alternation between consecutive" if rho < 0 else "persistence along the order of the"
            structured.append(f"{kind} residuals (lag-1 autocorrelation {rho:+.3g}, z = {fields['lag1_z']:.3g})")
    else:
        fields.update(effective_samples=float(n))
    if event_residual is None:
        trend_residual, trend_groups = r, groups
    else:
        trend_residual = np.asarray(event_residual, dtype=float).ravel()
        trend_groups = None if event_groups is None else np.asarray(event_groups)
    x = None if covariate is None else np.asarray(covariate, dtype=float).ravel()
    keep = np.isfinite(trend_residual) & (np.isfinite(x) if x is not None else True)
    if not keep.all():
        trend_residual = trend_residual[keep]
        trend_groups = None if trend_groups is None else np.asarray(trend_groups)[keep]
        x = None if x is None else x[keep]
    trend_slices = _group_slices(trend_residual.size, trend_groups)
    if x is not None:
        if trend_residual.size >= MIN_STRUCTURE_DATA:
            trend = _trend(trend_residual, x, trend_slices)
            fields.update(covariate=covariate_name, trend=trend)
            if gate and trend["p_value"] < STRUCTURE_SIGNIFICANCE:
                structured.append(f"a trend of the residual with {covariate_name} (correlation "
                                  f"{trend['correlation']:+.3g}, p = {trend['p_value']:.2g})")
        else:
            fields.update(covariate=covariate_name, trend={"correlation": math.nan, "t": math.nan, "dof": 0,
                                                           "p_value": math.nan})
    if between and len(trend_slices) > 1 and trend_residual.size >= MIN_STRUCTURE_DATA:
        between = _between(trend_residual, trend_slices, structure_floor)
        fields.update(between_groups=between)
        if gate and between and between["p_value"] < STRUCTURE_SIGNIFICANCE:
            structured.append(f"mean residuals that differ between the {between['groups']} groups beyond their "
                              f"scatter (chi-square {between['chi_square']:.3g} for {between['dof']} dof, "
                              f"p = {between['p_value']:.2g})")
    if structured:
        findings += structured
        if verdict == "consistent":
            verdict = "structured"
        notes.append(f"the residual of {what!r} is structured: " + "; ".join(structured)
                     + (f" ({covariate_name} is the rig's per-event covariate)" if covariate_name and any(
                         "trend" in s for s in structured) else ""))
    # ---- what the fit does about it ----
    n_eff = float(fields.get("effective_samples", n))
    inflation, action = 1.0, "none"
    if verdict not in ("consistent", "not checked"):
        if has_noise:
            ratio, over = fields["residual_over_noise"], fields["assumed_over_noise"]
            variance_factor = max(1.0, ratio / over) if over > 0 and math.isfinite(over) else 1.0
        else:
            variance_factor = max(1.0, rms / assumed) if assumed > 0 and math.isfinite(assumed) else 1.0
        correlation_factor = math.sqrt(max(1.0, n / max(n_eff, 1.0)))
        inflation = variance_factor * correlation_factor
        gross = has_noise and fields["residual_over_noise"] > GROSS_LACK_OF_FIT
        persistent = n_eff < 0.5 * n or any("trend" in s or "groups" in s for s in structured)
        if gross and persistent:
            action = "withheld"
            findings.append(f"a structured residual {fields['residual_over_noise']:.3g} times its noise (more than "
                            f"{GROSS_LACK_OF_FIT:g}) is a model error that no interval computed under the model bounds")
            notes.append(f"the model does not describe {what!r}: its residual is {fields['residual_over_noise']:.3g} "
                         f"times the noise and structured ({n_eff:.3g} independent residuals of {n}); the standard "
                         "errors and intervals are withheld: the estimate's error is of the size of what the model "
                         "misses (check the rig's constants and the model)")
        elif inflation > 1.0 + 1e-12:
            action = "widened"
            notes.append(f"the intervals are widened x {inflation:.3g} by the model check of {what!r} ("
                         f"{variance_factor:.3g} for the residual's variance over the one the covariance assumed, "
                         f"{correlation_factor:.3g} for {n_eff:.3g} independent residuals of {n})")
    return ModelCheck(what=what, unit=unit, noise_reference=noise_reference if has_noise else NO_NOISE_REFERENCE,
                      n=n, n_params=int(n_params), residual_rms=rms, structure_floor=float(structure_floor),
                      assumed_sd=assumed, findings=tuple(findings), verdict=verdict, inflation=inflation,
                      action=action, notes=tuple(notes), **fields)


def governing_check(checks: Sequence[ModelCheck]) -> ModelCheck:
    """The check whose action the parameters of a fit with several residuals (channels) follow: one
    that withholds, else the one with the largest inflation (the parameters are widened once, by it)."""
    checks = list(checks)
    if not checks:
        raise ValueError("no model check")
    withheld = [c for c in checks if c.action == "withheld"]
    return withheld[0] if withheld else max(checks, key=lambda c: c.inflation if c.action == "widened" else 1.0)


def combine_checks(checks: Sequence[ModelCheck], *, extra: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The ``model_check`` block of a :class:`~impactid.results.FitResult` from its checks.

    Returns
    -------
    ``verdict`` (the worst of the checks', in the order of :data:`VERDICTS`), ``describes_data``,
    ``action`` (``withheld`` if any check withholds, else ``widened`` if any widens, else ``none``),
    ``inflation`` (the largest), ``rule`` (the widening and withholding rules, in words), ``checks``
    (each :meth:`ModelCheck.to_dict`) and the ``extra`` entries (a rig's own checks).
    """
    checks = list(checks)
    if not checks:
        block = {"verdict": "not checked", "describes_data": None, "action": "none", "inflation": 1.0, "checks": []}
    else:
        worst = max(checks, key=lambda c: VERDICTS.index(c.verdict))
        actions = {c.action for c in checks}
        action = "withheld" if "withheld" in actions else ("widened" if "widened" in actions else "none")
        block = {"verdict": worst.verdict, "describes_data": worst.describes_data, "action": action,
                 "inflation": max(c.inflation for c in checks), "checks": [c.to_dict() for c in checks]}
    block["rule"] = (f"structure counts at p < {STRUCTURE_SIGNIFICANCE:g} (3 sigma) above the noise; lack of fit: "
                     f"RMS > {LACK_OF_FIT_FACTOR:g} x noise; widened: stderr x sqrt(max(1, s_obs^2/s_assumed^2)) "
                     f"x sqrt(max(1, n/n_eff)); withheld: structured and RMS > {GROSS_LACK_OF_FIT:g} x noise, or "
                     "rejected by a rig's own check (docs/identifiability.md)")
    if extra:
        block.update(extra)
    return block

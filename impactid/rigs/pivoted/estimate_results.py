"""Result types of rig P's estimates: the contact damping, the restitution law, and the whole job.

:class:`DampingEstimate` is what :func:`~impactid.rigs.pivoted.damping.fit_contact_damping` returns,
:class:`RestitutionEstimate` what :func:`~impactid.rigs.pivoted.restitution.fit_restitution` returns, and
:class:`Estimate` what the estimate pipeline (:func:`impactid.pipeline.estimate`) returns: both fits and
what they rest on. Each converts to the shared :class:`~impactid.results.FitResult` (``to_result``:
lmfit-style report, JSON round trip, tables). Units are SI: ``beta`` [N s m^-(n+1)], ``gamma`` [s/m],
speeds [m/s], indentations [m].
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import pandas as pd

from impactid.results import FitResult, Parameter

__all__ = ["ContactDampingResult", "DampingEstimate", "Estimate", "EstimationWarning", "Landscape",
           "PivotedEstimateResult", "Progress", "RestitutionEstimate", "RestitutionResult"]


class EstimationWarning(UserWarning):
    """The data do not support (part of) an estimate as precisely as its number suggests."""


#: A progress display: called with the stage's name and the fraction done (0 to 1).
Progress = Callable[[str, float], None]


@dataclass(frozen=True)
class Landscape:
    """Mean residual on a grid: ``objective[i, j]`` at ``n[i]``, ``beta[i, j]`` (log-spaced in c).

    Attributes
    ----------
    n : exponents of the grid's rows.
    log10_c : ``log10 c`` of its columns, ``c = beta delta_ref^n`` [N s/m].
    beta : ``beta`` [N s m^-(n+1)] at each grid point.
    objective : the mean residual over events at each grid point.
    residual : the residual's name (``"lambda1"``, ...).
    """

    n: np.ndarray
    log10_c: np.ndarray
    beta: np.ndarray
    objective: np.ndarray
    residual: str


class ContactDampingResult(FitResult):
    """Hunt–Crossley damping ``beta, n`` of :func:`~impactid.rigs.pivoted.damping.fit_contact_damping` as a shared
    fit result."""

    kind = "contact-damping"
    title = "Hunt-Crossley contact damping"


class PivotedEstimateResult(FitResult):
    """Rig P's whole estimate (:meth:`Estimate.to_result`): the contact damping ``beta, n`` and the
    restitution laws, with everything they rest on, as one shared fit result."""

    kind = "pivoted-estimate"
    title = "rig P estimate: Hunt-Crossley beta, n and the restitution law"


class RestitutionResult(FitResult):
    """Restitution laws of :func:`~impactid.rigs.pivoted.restitution.fit_restitution` as a shared fit result."""

    kind = "restitution"
    title = "restitution xi = 1 - gamma v_a"


@dataclass(frozen=True)
class DampingEstimate:
    """Hunt–Crossley damping estimate.

    Attributes
    ----------
    beta : [N s m^-(n+1)]; n : exponent (fixed or estimated).
    residual : name of the residual minimised; objective : its mean over events at the estimate.
    beta_interval, n_interval : (low, high) intervals (:mod:`impactid.rigs.pivoted.damping`; ``n_interval`` is
        ``(n, n)`` when ``n`` was fixed).
    separable : whether the data separate beta from n (None when n was fixed).
    valley : DataFrame ``n, beta, objective`` of the minimum over beta at each n (joint fits).
    per_event : DataFrame ``source, event, approach_speed, residual`` at the estimate.
    delta_ref : reference indentation [m]; c = beta delta_ref^n is the damping there [N s/m].
    bootstrap : (n_resamples, 2) bootstrap estimates (beta, n).
    phase_beta_sd, phase_n_sd : standard deviations of beta and n caused by the error of each
        recording's cam phase (cam-phase anchor; 0 otherwise), already included in the intervals.
    """

    beta: float
    n: float
    fixed_n: bool
    residual: str
    objective: float
    method: str
    beta_interval: tuple[float, float]
    n_interval: tuple[float, float]
    beta_bootstrap_interval: tuple[float, float]
    n_bootstrap_interval: tuple[float, float]
    indifference: float
    separable: bool | None
    phase_beta_sd: float
    phase_n_sd: float
    valley: pd.DataFrame
    per_event: pd.DataFrame
    delta_ref: float
    bootstrap: np.ndarray
    landscape: Landscape | None
    n_simulations: int
    seconds: float
    warnings: tuple[str, ...] = ()
    #: S1 runs (trial law x event) that could not be simulated and got the documented penalty
    n_failed_simulations: int = 0
    #: Gauss-Newton standard errors of beta and n (least-squares method; NaN otherwise)
    beta_stderr: float = math.nan
    n_stderr: float = math.nan
    #: the model check (:func:`~impactid.rigs.pivoted.damping_diagnostics.damping_model_check`: the engine's
    #: block, with rig P's contact-duration check) and the identifiability block (empty: not made)
    model_check: Mapping[str, Any] = field(default_factory=dict)
    identifiability: Mapping[str, Any] = field(default_factory=dict)
    #: 95 % interval of ``c = beta delta_ref^n`` [N s/m] (:func:`~impactid.rigs.pivoted.estimation.fit`: with
    #: ``n`` fixed, beta's interval times ``delta_ref^n``; with ``n`` estimated, beta's interval of the fit
    #: repeated with ``n`` held at its estimate times ``delta_ref^n``, widened by the change of ``c`` along the
    #: valley over ``n``'s interval); NaN where not made (``beta, n`` not separable, interval withheld)
    c_interval: tuple[float, float] = (math.nan, math.nan)

    @property
    def damping_at_reference(self) -> float:
        """``c = beta delta_ref^n`` [N s/m]: the damping coefficient at the reference indentation (the
        median measured peak indentation), the search's coordinate; its unit does not change with ``n``."""
        return self.beta * self.delta_ref ** self.n

    def to_result(self) -> ContactDampingResult:
        """The estimate as a shared :class:`~impactid.results.FitResult` (report, JSON round trip, tables)."""
        unit = f"N s m^-({self.n:.4g}+1)"
        why = "" if self.separable in (None, True) else "beta and n are not separable from these data"
        no_stderr = f"no standard error from the {self.method} method: the interval is the uncertainty"
        params = [Parameter("beta", self.beta, stderr=self.beta_stderr, interval=self.beta_interval, unit=unit,
                            note=why or ("" if math.isfinite(self.beta_stderr) else no_stderr)),
                  Parameter("n", self.n, stderr=0.0 if self.fixed_n else self.n_stderr,
                            interval=(self.n, self.n) if self.fixed_n else self.n_interval, fixed=self.fixed_n,
                            note=why or ("" if self.fixed_n or math.isfinite(self.n_stderr) else no_stderr))]
        statistics = {"residual": self.residual, "objective": self.objective, "indifference": self.indifference,
                      "events": int(np.isfinite(self.per_event["residual"]).sum()), "simulations": self.n_simulations,
                      "failed_simulations": self.n_failed_simulations, "seconds": self.seconds}
        details = {"method": self.method, "separable": self.separable, "delta_ref": self.delta_ref,
                   "c_ref": self.damping_at_reference, "c_ref_interval": list(self.c_interval),
                   "beta_bootstrap_95": list(self.beta_bootstrap_interval),
                   "n_bootstrap_95": list(self.n_bootstrap_interval)}
        return ContactDampingResult(params=params, statistics=statistics, notes=self.warnings,
                                    tables={"per_event": self.per_event, "valley": self.valley}, details=details,
                                    model_check=self.model_check, identifiability=self.identifiability)

    def report(self) -> str:
        """An lmfit-style fit report (of :meth:`to_result`)."""
        return self.to_result().report()


@dataclass(frozen=True)
class RestitutionEstimate:
    """Restitution law fits over impacts (docs/estimation.md).

    ``gamma`` [s/m] of ``xi = 1 - gamma v_a`` (least squares, intercept fixed at 1) with its
    standard error; ``r_constant`` the constant-r fit (mean xi) with its standard error;
    ``intercept``/``slope`` of the free line ``xi = a - b v_a`` (NaN when the speeds do not
    spread); ``beta_equivalent = 1.5 gamma k_H`` [N s m^-2.5]; ``va_spread`` = std/mean of v_a.
    """

    gamma: float
    gamma_stderr: float
    r_constant: float
    r_constant_stderr: float
    intercept: float
    intercept_stderr: float
    slope: float
    slope_stderr: float
    xi_mean: float
    va_mean: float
    va_spread: float
    beta_equivalent: float
    impacts_used: int
    per_impact: pd.DataFrame
    warnings: tuple[str, ...] = ()
    #: the model check of ``xi = 1 - gamma v_a`` and the identifiability block with the laws compared
    #: (:func:`~impactid.rigs.pivoted.restitution.fit_restitution`; empty: not made)
    model_check: Mapping[str, Any] = field(default_factory=dict)
    identifiability: Mapping[str, Any] = field(default_factory=dict)

    def to_result(self) -> RestitutionResult:
        """The fit as a shared :class:`~impactid.results.FitResult` (report, JSON round trip, tables)."""
        def ci(value, stderr):
            return (value - 1.96 * stderr, value + 1.96 * stderr)

        params = [Parameter("gamma", self.gamma, self.gamma_stderr, ci(self.gamma, self.gamma_stderr), unit="s/m"),
                  Parameter("r_constant", self.r_constant, self.r_constant_stderr,
                            ci(self.r_constant, self.r_constant_stderr)),
                  Parameter("intercept", self.intercept, self.intercept_stderr,
                            ci(self.intercept, self.intercept_stderr)),
                  Parameter("slope", self.slope, self.slope_stderr, ci(self.slope, self.slope_stderr), unit="s/m")]
        statistics = {"impacts": self.impacts_used, "xi_mean": self.xi_mean, "va_mean": self.va_mean,
                      "va_spread": self.va_spread}
        return RestitutionResult(params=params, statistics=statistics, notes=self.warnings,
                                 tables={"per_impact": self.per_impact},
                                 details={"beta_equivalent_n1.5": self.beta_equivalent},
                                 model_check=self.model_check, identifiability=self.identifiability)

    def report(self) -> str:
        """An lmfit-style fit report (of :meth:`to_result`)."""
        return self.to_result().report()


@dataclass(frozen=True)
class Estimate:
    """Result of :func:`impactid.pipeline.estimate`: contact damping, restitution, and what they rest on."""

    damping: DampingEstimate
    restitution: RestitutionEstimate | None
    sources: tuple[str, ...]
    operating_points: tuple[dict, ...]
    reconstructions: tuple = field(default=(), repr=False)
    event_sets: tuple = field(default=(), repr=False)
    warnings: tuple[str, ...] = ()
    provenance: tuple[str, ...] = ()
    #: per recording, the pipeline's alpha_m bias measured on the model's own recording
    #: (:mod:`impactid.rigs.pivoted.calibration`), when the estimate was calibrated
    calibration: tuple[dict, ...] = ()
    #: the options of the :class:`~impactid.pipeline.Pipeline` that made the estimate
    pipeline: dict = field(default_factory=dict)

    def report(self) -> str:
        """An lmfit-style fit report of the whole estimate (:meth:`to_result`'s, :meth:`FitResult.report
        <impactid.results.FitResult.report>`): one table of the parameters (the contact damping ``beta, n``
        and, as a second model of the same impacts, the restitution laws), then the damping at the reference
        indentation (a unit that does not change with ``n``), what the restitution rows are, the recordings,
        the model check, the identifiability block and the notes, each note once."""
        lines = self.to_result(per_impact=False).report().splitlines()
        d, r = self.damping, self.restitution
        c_lo, c_hi = d.c_interval
        c_interval = (f"[{c_lo:.5g}, {c_hi:.5g}]" if math.isfinite(c_lo) and math.isfinite(c_hi)
                      else "n/a (no interval of beta; see the notes)")
        extra = ["[[Damping at the reference indentation]]",
                 f"    c_ref = beta delta_ref^n = {d.damping_at_reference:.5g} N s/m, 95 % interval {c_interval}",
                 f"    (delta_ref = {d.delta_ref * 1e6:.4g} µm, the median measured peak indentation; the unit "
                 "of c_ref does not change with n)"]
        if r is not None:
            extra += ["[[Restitution]]",
                      "    gamma, r_constant, intercept, slope: the restitution laws xi = 1 - gamma v_a, xi = r and "
                      "xi = a - b v_a",
                      f"    (xi = v_s / v_a over {r.impacts_used} impacts), a second model of the same impacts (rigid "
                      "impacts), not an estimate of beta",
                      f"    (1.5 gamma k_H = {r.beta_equivalent:.4g} N s m^-2.5 equals beta at n = 1.5 only for xi "
                      f"near 1; mean xi here {r.xi_mean:.3g})"]
        extra.append("[[Recordings]]")
        extra += [f"    {s}: {op['events']} events at e/r_c {op['e_over_rc']:.4g}, {op['cam_speed_hz']:.4g} Hz"
                  for s, op in zip(self.sources, self.operating_points)]
        blocks = ("[[Model Check]]", "[[Identifiability]]", "[[Notes]]")
        at = next((i for i, line in enumerate(lines) if line in blocks), len(lines))
        return "\n".join(lines[:at] + extra + lines[at:])

    def to_result(self, per_impact: bool = True) -> PivotedEstimateResult:
        """The whole estimate as one shared :class:`~impactid.results.FitResult` (``pivoted-estimate``).

        Parameters: ``beta`` [N s m^-(n+1)] and ``n`` of the contact damping (``min``/``max``: the search
        bounds; ``beta``'s are the bounds of ``c`` divided by ``delta_ref^n`` at the estimated ``n``), and
        the restitution laws' ``gamma`` [s/m] (``xi = 1 - gamma v_a``), ``r_constant``, ``intercept`` and
        ``slope`` [s/m] (``xi = a - b v_a``; intervals +-1.96 standard errors; NaN, with the reason, when the
        restitution law was not estimated). Statistics, notes (the warnings), tables (``per_impact``,
        ``valley``, ``recordings``, ``calibration``), details (units, the uncertainty's detail, the contact
        damping's method and reference, the restitution's, the pipeline's options) and provenance carry
        everything else the estimate reports. ``per_impact=False`` leaves the per-impact table out.
        """
        d, r = self.damping, self.restitution
        options = dict(self.pipeline)
        c_lo, c_hi = options.get("c_bounds") or (math.nan, math.nan)
        n_lo, n_hi = options.get("n_bounds") or (-math.inf, math.inf)
        scale = d.delta_ref ** d.n
        why = "" if d.separable in (None, True) else "beta and n are not separable from these data"
        if (d.model_check or {}).get("action") == "withheld":
            findings = [f for c in d.model_check.get("checks", ()) for f in c.get("findings", ())]
            why = "; ".join(filter(None, (why, "interval withheld: the model check rejects the law"
                                          + (f" ({findings[-1]})" if findings else ""))))
        params = [
            Parameter("beta", d.beta, stderr=d.beta_stderr, interval=d.beta_interval, unit=f"N s m^-({d.n:.4g}+1)",
                      note=why, min=c_lo / scale if math.isfinite(c_lo) else -math.inf,
                      max=c_hi / scale if math.isfinite(c_hi) else math.inf),
            Parameter("n", d.n, stderr=0.0 if d.fixed_n else d.n_stderr, interval=tuple(d.n_interval),
                      fixed=d.fixed_n, note=why, min=-math.inf if d.fixed_n else n_lo,
                      max=math.inf if d.fixed_n else n_hi),
        ]
        if not math.isfinite(params[0].stderr) and not params[0].note:
            params[0] = replace(params[0], note=f"no standard error from the {d.method} method: the interval is "
                                                "the uncertainty")
        if r is not None:
            restitution_notes = [w for w in r.warnings] or ["the restitution data do not determine it"]

            def law(name, value, stderr, unit=""):
                note = "" if math.isfinite(stderr) else f"standard error undetermined: {restitution_notes[0]}"
                return Parameter(name, value, stderr, (value - 1.96 * stderr, value + 1.96 * stderr), unit=unit,
                                 note=note)

            params += [law("gamma", r.gamma, r.gamma_stderr, "s/m"),
                       law("r_constant", r.r_constant, r.r_constant_stderr),
                       law("intercept", r.intercept, r.intercept_stderr), law("slope", r.slope, r.slope_stderr, "s/m")]
        else:
            missing = next((w for w in self.warnings if w.startswith("restitution law not estimated")),
                           "restitution law not estimated")
            params += [Parameter(name, math.nan, unit=unit, note=missing)
                       for name, unit in (("gamma", "s/m"), ("r_constant", ""), ("intercept", ""), ("slope", "s/m"))]
        statistics = {
            "impacts_used": int(np.isfinite(d.per_event["residual"]).sum()), "residual": d.residual,
            "objective": d.objective, "objective_indifference": d.indifference, "separable": d.separable,
            "xi_mean": r.xi_mean if r else math.nan, "va_mean": r.va_mean if r else math.nan,
            "va_spread": r.va_spread if r else math.nan, "restitution_impacts_used": r.impacts_used if r else 0,
            "simulations": d.n_simulations, "failed_simulations": d.n_failed_simulations, "seconds": d.seconds,
            "n_recordings": len(self.sources)}
        tables = {}
        if per_impact:
            tables["per_impact"] = d.per_event if r is None else d.per_event.merge(
                r.per_impact[["source", "event", "xi", "separation_speed"]], on=["source", "event"], how="outer")
        tables["valley"] = d.valley[["n", "beta", "objective"]]
        tables["recordings"] = pd.DataFrame([dict(source=s, **op) for s, op in zip(self.sources,
                                                                                   self.operating_points)])
        tables["calibration"] = pd.DataFrame([dict(c) for c in self.calibration])
        details = {
            "units": {"beta": "N s m^-(n+1)", "gamma": "s/m", "slope": "s/m", "va_mean": "m/s", "c_ref": "N s/m",
                      "delta_ref": "m", "beta_equivalent": "N s m^-2.5"},
            "uncertainty": {"beta_bootstrap_95": list(d.beta_bootstrap_interval),
                            "n_bootstrap_95": list(d.n_bootstrap_interval), "beta_sd_from_cam_phase": d.phase_beta_sd,
                            "n_sd_from_cam_phase": d.phase_n_sd},
            "contact_damping": {"method": d.method, "delta_ref": d.delta_ref, "c_ref": d.damping_at_reference,
                                "c_ref_interval": list(d.c_interval)},
            "restitution": None if r is None else {"beta_equivalent": r.beta_equivalent},
            "pipeline": options,
        }
        return PivotedEstimateResult(params=params, statistics=statistics, notes=self.warnings, tables=tables,
                                     details=details, provenance=self.provenance,
                                     model_check=merged_model_check(d.model_check, r.model_check if r else {}),
                                     identifiability=_with_parts(d.identifiability,
                                                                 {"restitution": r.identifiability} if r else {}))

    def to_dict(self, per_impact: bool = True) -> dict:
        """The result as JSON-ready data: :meth:`to_result`'s document (the ``FitResult`` schema of
        docs/formats.md, SI units)."""
        return self.to_result(per_impact=per_impact).to_dict()


def _with_parts(block: Mapping[str, Any], parts: Mapping[str, Mapping[str, Any]]) -> dict[str, Any]:
    """An identifiability block with the other fits' blocks under ``parts`` (empty ones left out)."""
    out = dict(block)
    parts = {name: dict(part) for name, part in parts.items() if part}
    if parts:
        out["parts"] = parts
    return out


def merged_model_check(damping: Mapping[str, Any], restitution: Mapping[str, Any]) -> dict[str, Any]:
    """The ``model_check`` block of rig P's whole estimate: the contact damping's and the restitution
    law's checks together (the worst verdict, the strongest action, every check), each part's own
    verdict under ``parts`` and the contact-duration and contact-pulse checks of the damping."""
    from impactid.engine.checks import VERDICTS

    blocks = {name: dict(b) for name, b in (("contact_damping", damping), ("restitution", restitution)) if b}
    if not blocks:
        return {}
    worst = max(blocks.values(), key=lambda b: VERDICTS.index(b.get("verdict", "not checked")))
    actions = [b.get("action", "none") for b in blocks.values()]
    out = {"verdict": worst.get("verdict"), "describes_data": worst.get("describes_data"),
           "action": "withheld" if "withheld" in actions else ("widened" if "widened" in actions else "none"),
           "inflation": max(float(b.get("inflation") or 1.0) for b in blocks.values()),
           "checks": [c for b in blocks.values() for c in b.get("checks", ())],
           "rule": next(iter(blocks.values())).get("rule", ""),
           "parts": {name: {"verdict": b.get("verdict"), "action": b.get("action"), "inflation": b.get("inflation")}
                     for name, b in blocks.items()}}
    for name in ("contact_duration", "contact_pulse"):
        if name in blocks.get("contact_damping", {}):
            out[name] = blocks["contact_damping"][name]
    return out

"""Rig P's estimate: Hunt–Crossley ``beta, n`` and the restitution law from its recordings (``ESTIMATOR``).

What the generic estimate (``impactid estimate``, :class:`impactid.pipeline.Pipeline`,
:mod:`impactid.campaign`) runs for recordings of the ``pivoted-follower`` rig, in two stages::

    prepare (one recording):  events -> per-impact kinematics -> event set (+ the calibration's sampling)
    fit (prepared recordings): contact damping (+ calibration) -> restitution -> Estimate

The options (:data:`OPTIONS`) are the choices that decide an estimate: the per-event kinematics
method and anchor, the residual, the search and its bounds, the uncertainty options and the
calibration. They are recorded in the result (:attr:`~impactid.rigs.pivoted.estimates.Estimate.pipeline`
and its provenance), so that an estimate says how it was made.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import pandas as pd

from impactid.commandline import UsageError, num
from impactid.contact import HuntCrossley
from impactid.errors import ImpactidError
from impactid.rigs.base import Estimator, PreparedRecording, options_record, pipeline_provenance
from impactid.rigs.pivoted import figures
from impactid.rigs.pivoted.arguments import ARGUMENTS, MAX_GRID_POINTS, TITLE
from impactid.rigs.pivoted.calibration import RecordingSampling, pipeline_bias
from impactid.rigs.pivoted.damping import DampingSearch, finish_contact_damping, start_contact_damping
from impactid.rigs.pivoted.estimates import (
    BOOTSTRAP_RESAMPLES,
    BOOTSTRAP_SEED,
    C_BOUNDS,
    CALIBRATION_THRESHOLD,
    METHODS,
    N_BOUNDS,
    SEPARABILITY_WIDTH,
    DampingEstimate,
    Estimate,
    EstimationWarning,
    Progress,
    fit_contact_damping,
    fit_restitution,
)
from impactid.rigs.pivoted.example import example_truth
from impactid.rigs.pivoted.reconstruct import Reconstruction, reconstruct
from impactid.rigs.pivoted.residuals import EventSet, residual_name

__all__ = ["ESTIMATOR", "MAX_GRID_POINTS", "OPTIONS", "PreparedImpacts", "check_options", "fit", "prepare"]

#: Every option of rig P's estimate and its default:
#:
#: * ``residual``: ``"lambda1"`` (accelerometer only, default), ``"lambda2"`` or ``"lambda3"``;
#: * ``fix_n``: fix the Hunt–Crossley exponent (1.5: Hertzian; None: estimate it jointly with beta);
#: * ``method``: ``"least-squares"`` (trust-region Gauss–Newton on the per-event residuals, with the
#:   profile along the valley; :mod:`impactid.engine.valley`), ``"optimise"`` (nested bounded Brent
#:   searches along the valley, lattice and bootstrap intervals) or ``"grid"`` (the paper's grid);
#: * ``grid``: grid points ``(n_c, n_n)`` of the grid method;
#: * ``integration``, ``anchor``: per-event kinematics (:func:`impactid.rigs.pivoted.reconstruct.reconstruct`);
#: * ``c_bounds``: bounds of ``c = beta delta_ref^n`` [N s/m]; ``n_bounds``: bounds of ``n`` [-];
#: * ``landscape``: also compute the objective landscape (for plots);
#: * ``calibrate``: measure and correct the pipeline's alpha_m bias on the model's own recording
#:   (:mod:`impactid.rigs.pivoted.calibration`; lambda1 only);
#: * ``residual_floor``: the residual's noise floor (None: the calibrated default of the residual);
#: * ``separability_width``: widest interval of ``n`` with which ``beta, n`` count as separable [-];
#: * ``bootstrap_resamples``, ``bootstrap_seed``: the bootstrap over events.
OPTIONS: Mapping[str, Any] = {
    "residual": "lambda1",
    "fix_n": None,
    "method": "least-squares",
    "grid": (41, 21),
    "integration": "rk",
    "anchor": "cam-phase",
    "c_bounds": C_BOUNDS,
    "n_bounds": N_BOUNDS,
    "landscape": False,
    "calibrate": True,
    "residual_floor": None,
    "separability_width": SEPARABILITY_WIDTH,
    "bootstrap_resamples": BOOTSTRAP_RESAMPLES,
    "bootstrap_seed": BOOTSTRAP_SEED,
}

#: The options that change what :func:`prepare` makes (the others change only the fits).
PREPARE_OPTIONS = ("integration", "anchor")


def check_options(options: Mapping[str, Any]) -> dict[str, Any]:
    """Check the values of the full options and normalise the residual's name (``ValueError`` naming
    the option)."""
    out = dict(options)
    out["residual"] = residual_name(out["residual"])
    if out["method"] not in METHODS:
        raise ValueError(f"method must be one of {', '.join(METHODS)}; got {out['method']!r}")
    fix_n = out["fix_n"]
    if fix_n is not None and not (isinstance(fix_n, (int, float)) and math.isfinite(fix_n) and fix_n >= 0.0):
        raise ValueError(f"fix_n must be a finite number >= 0, got {fix_n!r}")
    if out["bootstrap_resamples"] < 10:
        raise ValueError(f"bootstrap_resamples must be at least 10, got {out['bootstrap_resamples']!r}")
    return out


def _fit_options(options: Mapping[str, Any]) -> dict:
    """The keyword arguments of :func:`~impactid.rigs.pivoted.estimates.fit_contact_damping` the options give."""
    return {name: options[name] for name in ("fix_n", "method", "grid", "c_bounds", "n_bounds", "landscape",
                                             "residual_floor", "separability_width", "bootstrap_resamples",
                                             "bootstrap_seed")}


def _calibrated(options: Mapping[str, Any]) -> bool:
    """Whether the estimate is calibrated (:mod:`impactid.rigs.pivoted.calibration`; lambda1 only)."""
    return bool(options["calibrate"] and residual_name(options["residual"]) == "lambda1")


@dataclass(frozen=True)
class PreparedImpacts:
    """One rig P recording read, segmented and reconstructed (:func:`prepare`): what its fits use.

    Attributes
    ----------
    source : the recording's name in messages and results.
    reconstruction : the per-impact kinematics (without the samples after :func:`compact`).
    event_set : the :class:`~impactid.rigs.pivoted.residuals.EventSet` the fits replay.
    impacts : per impact ``source, event, approach_speed`` [m/s], ``xi`` [-], ``separation_speed``
        [m/s] (the restitution fit's data).
    sampling : the :class:`~impactid.rigs.pivoted.calibration.RecordingSampling` of the calibration
        (None when the estimate is not calibrated).
    warnings : the notes of the per-impact kinematics.
    """

    source: str
    reconstruction: Reconstruction
    event_set: EventSet
    impacts: pd.DataFrame
    sampling: RecordingSampling | None
    warnings: tuple[str, ...] = ()


def prepare(recording, options: Mapping[str, Any], source: str) -> PreparedImpacts:
    """Find the impacts of one recording and reconstruct each (the notes in the result, not warned)."""
    recon = reconstruct(recording, integration=options["integration"], anchor=options["anchor"], warn=False)
    es = EventSet.from_reconstruction(recon, source=source)
    tab = recon.table.reset_index()
    impacts = pd.DataFrame({"source": es.source, "event": tab["event"], "approach_speed": tab["approach_speed"],
                            "xi": tab["xi"], "separation_speed": tab["separation_speed"]})
    sampling = (RecordingSampling.of(recording, recon.events.noise_sigma, band_limited=recon.band_limited,
                                     onset_time_s=float(recon.table["t_onset"].iloc[0]) if len(recon) else math.nan)
                if _calibrated(options) else None)
    return PreparedImpacts(source=es.source, reconstruction=recon, event_set=es, impacts=impacts, sampling=sampling,
                           warnings=tuple(recon.warnings))


def compact(data: PreparedImpacts) -> PreparedImpacts:
    """The prepared recording without its samples (a few kB per impact; the figures' histories need them)."""
    if getattr(data.reconstruction, "_recording", None) is None:
        return data
    return replace(data, reconstruction=replace(data.reconstruction, _recording=None))


def fit(prepared: Sequence[PreparedRecording], options: Mapping[str, Any],
        progress: Progress | None = None) -> Estimate:
    """Estimate ``beta, n`` and the restitution law from prepared recordings of one rig (several: jointly).

    The recordings may differ in cam speed and eccentricity only. Returns the
    :class:`~impactid.rigs.pivoted.estimates.Estimate` with the damping estimate, the restitution law
    (None, with the reason among the warnings, when it cannot be fitted), per-event tables, notes
    (the prepared recordings' first) and provenance; nothing is warned.
    """
    prepared = list(prepared)
    if not prepared:
        raise ImpactidError("no recording given")
    collected: list[str] = [m for p in prepared for m in p.notes + tuple(w for w in p.data.warnings
                                                                          if w not in p.notes)]
    prepared, left_out = _usable(prepared)
    collected += left_out
    data = [p.data for p in prepared]
    recons = [d.reconstruction for d in data]
    sets = [d.event_set for d in data]
    frames = [d.impacts for d in data]
    # operating points may differ in cam speed and eccentricity; the contact pair must be the same
    models = {repr(r.fixed_parameters) for r in recons}
    if len(models) > 1:
        raise ImpactidError("a joint fit needs recordings of the same rig (parameters other than the eccentricity "
                            "e equal); they differ between " + ", ".join(s.source for s in sets))
    fit_options = _fit_options(options)
    calibration: list[dict] = []
    systematic = 0.0
    if _calibrated(options):
        # the first fit's intervals and checks only where no correction refits it (start_contact_damping)
        search = start_contact_damping(sets, options["residual"], **fit_options, progress=progress, warn=False)
        damping, sets, calibration, systematic = _calibrate(search, [d.sampling for d in data], sets, fit_options,
                                                            integration=options["integration"],
                                                            anchor=options["anchor"])
    else:
        damping = fit_contact_damping(sets, options["residual"], **fit_options, progress=progress, warn=False)
    collected += damping.warnings  # the final fit's notes: a calibrated refit's replace the first fit's
    # (which may say what the refit no longer finds: a "not determined" of the uncorrected data)
    damping = _with_reference_interval(damping, sets, fit_options, systematic)
    # a part of the job that cannot be done does not take the others with it: without a
    # determined xi the restitution law is missing from the result, with the reason
    try:
        restitution = fit_restitution(pd.concat(frames, ignore_index=True), recons[0].rig.k_H, warn=False)
        collected += restitution.warnings
    except ImpactidError as exc:
        restitution = None
        collected.append(f"restitution law not estimated: {exc}")
    ops = tuple({**r.operating_point, "events": len(s)} for r, s in zip(recons, sets))
    prov = tuple(p for r in recons for p in r.provenance) + (
        f"fit_contact_damping(residual={damping.residual!r}, method={options['method']!r}, "
        f"fix_n={options['fix_n']}): {damping.n_simulations} S1 simulations in {damping.seconds:.2f} s",
        pipeline_provenance(options))
    return Estimate(damping=damping, restitution=restitution, sources=tuple(s.source for s in sets),
                    operating_points=ops, reconstructions=tuple(recons), event_sets=tuple(sets),
                    warnings=tuple(collected), provenance=prov, calibration=tuple(calibration),
                    pipeline=options_record(options))


def _usable(prepared: Sequence[PreparedRecording]) -> tuple[list[PreparedRecording], list[str]]:
    """The prepared recordings with at least one event the fit can replay, and a note per recording left
    out (a part of a joint fit that cannot be done does not take the others with it). With no usable
    recording at all, nothing is left out here: the fit then refuses with every recording's reason."""
    usable = [p for p in prepared if len(p.data.event_set) > 0]
    if not usable or len(usable) == len(prepared):
        return list(prepared), []
    notes = []
    kept = ", ".join(p.source for p in usable)
    for p in prepared:
        if len(p.data.event_set) == 0:
            reasons = [d.removeprefix(f"{p.source}: ") for d in p.data.event_set.dropped]
            reason = "; ".join(reasons) or "no impact with a reconstructed onset state"
            notes.append(f"{p.source} left out of the joint fit ({reason}); the estimate rests on {kept} alone")
    points = {(round(p.data.event_set.cam_speed_hz, 9), p.data.reconstruction.operating_point.get("e_over_rc"))
              for p in usable}
    if len(points) == 1:
        notes.append("the recordings left make one operating point: one operating point separates beta and n only "
                     "as far as its impacts differ in approach speed (the interval of n says how far)")
    return usable, notes


def _calibrate(search: DampingSearch, samplings, sets, fit_options: dict, *, integration: str, anchor: str):
    """Measure the pipeline's biases at the first estimate (:mod:`impactid.rigs.pivoted.calibration`), the point
    estimate of ``search``: where the alpha_m bias is significant and exceeds
    :data:`~impactid.rigs.pivoted.estimates.CALIBRATION_THRESHOLD` (or a phase correction refits anyway:
    :func:`_corrections`), correct the measured alpha_m, and where a cam-phase bias was measured (band-limited or
    noise-free recordings), correct the cam phase; then fit again, with the intervals' indifference at least half
    the largest alpha_m correction and the phase's standard error widened. Without a correction the first fit is
    finished (its intervals and checks); with one it is not (the refit's replace them)."""
    law = HuntCrossley(beta=search.beta, n=search.n)
    biases = [pipeline_bias(s, law, integration=integration, anchor=anchor) for s in samplings]
    applied, phased = _corrections(biases)
    if not any(applied) and not any(phased):
        return finish_contact_damping(search), sets, _calibration_record(sets, biases), 0.0
    search.progress("done", 1.0)
    measured_at = law
    simulations, seconds = search.n_simulations, search.seconds
    # a band-limited recording's phase bias depends on the law's pulse shape: measured again at the corrected
    # estimate until it agrees with the one applied (_settled), at most PHASE_CALIBRATION_ROUNDS fits
    for attempt in range(PHASE_CALIBRATION_ROUNDS):
        corrected = [_corrected_set(s, b, use, phase) for s, b, use, phase in zip(sets, biases, applied, phased)]
        systematic = max((0.5 * abs(b.alpha_m) + 2.0 * b.stderr for b, use in zip(biases, applied) if use),
                         default=0.0)
        again = fit_contact_damping(corrected, search.residual, **fit_options, systematic=systematic, warn=False)
        simulations, seconds = simulations + again.n_simulations, seconds + again.seconds
        # an unfiltered onset's phase bias barely moves with the law (the 60 s benchmark recording: -4.42e-5 to
        # -4.63e-5 rad over beta -0.05 % to +0.4 %): measured once; a band-limited one's with the filtered pulse
        if attempt == PHASE_CALIBRATION_ROUNDS - 1 or not any(_filtered(sets, phased)):
            break
        law = HuntCrossley(beta=again.beta, n=again.n)
        update = [pipeline_bias(s, law, integration=integration, anchor=anchor) for s in samplings]
        if all(not use or not u.phase_measured or _settled(u.phase, b.phase, math.hypot(u.phase_stderr, b.phase_stderr))
               for u, b, use in zip(update, biases, phased)):
            break
        biases, measured_at = update, law
        applied, phased = _corrections(biases)
    notes = _calibration_notes(sets, biases, applied, phased, measured_at)
    again = replace(again, warnings=again.warnings + tuple(notes), n_simulations=simulations, seconds=seconds)
    record = _calibration_record(sets, biases)
    return again, corrected, record, systematic


def _calibration_notes(sets, biases, applied: list[bool], phased: list[bool], measured_at: HuntCrossley) -> list[str]:
    """The notes of :func:`_calibrate`'s corrections: the alpha_m biases corrected, and the cam-phase biases of the
    noise-free and of the band-limited recordings, each with the law they were measured at."""
    notes = []
    if any(applied):
        notes.append(f"the pipeline's bias of alpha_m at these recordings' sampling, measured on the model's own "
                     f"recording at beta {measured_at.beta:.4g}, n {measured_at.n:.4g}, is "
                     + ", ".join(f"{b.alpha_m:+.2e} +- {b.stderr:.1e} ({s.source})" for s, b in zip(sets, biases)
                                 if math.isfinite(b.alpha_m))
                     + "; alpha_m was corrected where the bias is significant and the fit repeated, with the "
                       "intervals widened by half the correction plus two standard errors")
    filtered = _filtered(sets, phased)
    quiet = [use and not band for use, band in zip(phased, filtered)]

    def phases(which: list[bool]) -> str:
        return ", ".join(f"{b.phase:+.2e} +- {b.phase_stderr:.1e} rad ({s.source})"
                         for s, b, use in zip(sets, biases, which) if use)

    if any(quiet):
        notes.append("the cam-phase bias of the onsets of " + ", ".join(s.source for s, q in zip(sets, quiet) if q)
                     + " (noise-free: the pipeline's own, measured on the model's recording with the same sampling) is "
                     + phases(quiet) + f" at beta {measured_at.beta:.4g}, n {measured_at.n:.4g}; the cam phase was "
                       "corrected by it and its standard error widened by half the correction plus two standard errors")
    if any(filtered):
        limited = [s.source for s, band in zip(sets, filtered) if band]
        notes.append(("the recording " if len(limited) == 1 else "the recordings ") + ", ".join(limited)
                     + (" is" if len(limited) == 1 else " are")
                     + " band-limited (a linear-phase anti-alias filter rings ahead of each rise and smooths the "
                       "contact onset): the cam-phase bias of the onsets, measured on the model's own recording "
                       f"through such a filter at beta {measured_at.beta:.4g}, n {measured_at.n:.4g}, is "
                     + phases(filtered) + "; the cam phase was corrected by it and its standard error widened by half "
                       "the correction plus two standard errors (the recording's own filter is not known: "
                       "docs/estimation.md)")
    return notes


def _filtered(sets, phased: list[bool]) -> list[bool]:
    """Per recording, whether its cam phase is corrected as a band-limited recording's (through the filter)."""
    return [use and s.decimation > 1 for s, use in zip(sets, phased)]


def _corrections(biases) -> tuple[list[bool], list[bool]]:
    """Per recording, whether the calibration corrects its ``alpha_m`` and its cam phase (a measured phase bias).

    ``alpha_m`` is corrected where its bias is significant (two standard errors) and above
    :data:`~impactid.rigs.pivoted.estimates.CALIBRATION_THRESHOLD`, the level that spares a refit for a bias at the
    pipeline's own level; where a phase correction refits anyway, every significant bias is corrected (the
    near-plastic envelope case np12: 2.0e-5 +- 3.0e-6, below the threshold, where alpha_m moves by only 1.2e-3 per
    unit of ln beta; measured: beta +1.02 % uncorrected, -0.55 % corrected)."""
    phased = [b.phase_measured for b in biases]
    refit = any(phased)
    return [b.significant and (refit or abs(b.alpha_m) > CALIBRATION_THRESHOLD) for b in biases], phased


def _calibration_record(sets, biases) -> list[dict]:
    """The calibration table's rows: each recording's source and its measured biases."""
    return [dict(source=s.source, **b.to_dict()) for s, b in zip(sets, biases)]


#: Most times a band-limited recording's cam-phase bias is measured (:func:`_calibrate`: at the first estimate,
#: then at each corrected one until the bias settles).
PHASE_CALIBRATION_ROUNDS = 3


def _settled(new: float, old: float, stderr: float) -> bool:
    """Whether a re-measured phase bias ``new`` [rad] agrees with the one applied, ``old``: within two standard
    errors ``stderr`` [rad] of the two, or within a quarter of itself (noise-free recordings measure it with
    standard errors far below how much it moves with the law)."""
    return abs(new - old) <= max(2.0 * stderr, 0.25 * abs(old))


def _corrected_set(event_set, bias, alpha_m: bool, phase: bool):
    """``event_set`` with the calibration's corrections: ``alpha_m`` scaled by the bias where ``alpha_m``, the cam
    phase moved back by the phase bias where ``phase``, its standard error widened by half the correction plus two
    standard errors of the calibration."""
    out = event_set.scale_alpha_m(1.0 / (1.0 + bias.alpha_m)) if alpha_m else event_set
    if phase:
        widened = math.hypot(out.phase_stderr if math.isfinite(out.phase_stderr) else 0.0,
                             0.5 * abs(bias.phase) + 2.0 * bias.phase_stderr)
        out = replace(out.shift_phase(-bias.phase), phase_stderr=widened)
    return out


def _with_reference_interval(damping, sets, fit_options: dict, systematic: float):
    """The damping estimate with the 95 % interval of ``c = beta delta_ref^n`` [N s/m] (``c_interval``).

    With ``n`` fixed, ``c`` is beta times a constant: beta's interval times ``delta_ref^n``. With ``n``
    estimated, beta's interval spans mostly the valley (a change ``dn`` moves beta by ``delta_ref^-dn``)
    along which ``c`` barely changes: the fit is repeated with ``n`` held at its estimate (the same
    event sets, options and systematic error, so the same statistical, cam-phase and systematic terms)
    and its beta interval, times ``delta_ref^n``, widened on each side by the largest relative change of
    ``c`` along the valley within ``n``'s interval, is ``c``'s. Not made (NaN) where beta and n are not
    separable or the model check withholds the intervals: then no interval of ``c`` is stated either.
    """
    scale = damping.delta_ref ** damping.n
    withheld = (damping.model_check or {}).get("action") == "withheld"
    if withheld or not all(math.isfinite(v) for v in damping.beta_interval):
        return damping
    if damping.fixed_n:
        return replace(damping, c_interval=(damping.beta_interval[0] * scale, damping.beta_interval[1] * scale))
    if not damping.separable:
        return damping
    held = fit_contact_damping(sets, damping.residual, **dict(fit_options, fix_n=damping.n, landscape=False),
                               systematic=systematic, warn=False)
    if (held.model_check or {}).get("action") == "withheld" or not all(map(math.isfinite, held.beta_interval)):
        return damping
    c_hat = damping.damping_at_reference
    lo, hi = held.beta_interval[0] * scale, held.beta_interval[1] * scale
    valley = damping.valley
    inside = valley[(valley["n"] >= damping.n_interval[0]) & (valley["n"] <= damping.n_interval[1])]
    if len(inside):
        c_valley = inside["beta"].to_numpy(float) * damping.delta_ref ** inside["n"].to_numpy(float)
        c_valley = c_valley[np.isfinite(c_valley)]
        if c_valley.size:
            lo *= min(1.0, float(c_valley.min()) / c_hat)
            hi *= max(1.0, float(c_valley.max()) / c_hat)
    return replace(damping, c_interval=(min(lo, c_hat), max(hi, c_hat)),
                   n_simulations=damping.n_simulations + held.n_simulations, seconds=damping.seconds + held.seconds)


# ---- delivery: JSON, the printed summary, the figures -----------------------------------------------


def to_dict(result: Estimate) -> dict:
    """The estimate as JSON-ready data: the :class:`~impactid.results.FitResult` document of
    :meth:`~impactid.rigs.pivoted.estimate_results.Estimate.to_result` (``pivoted-estimate``,
    docs/formats.md); ``impactid estimate`` adds ``recordings_read``. On the built-in example's
    recordings, ``details.truth`` holds the law the example was made with (:func:`example_truth`, from
    its recipe) and its ``c_ref`` at the estimate's reference indentation."""
    data = result.to_result().to_dict()
    truth = example_truth(result.sources)
    if truth is not None:
        data["details"]["truth"] = {**truth, "c_ref": _true_reference_damping(result, truth),
                                    "source": "the built-in example's recipe (impactid.rigs.pivoted.example."
                                              "EXAMPLE_RECIPE), not the recordings' /truth"}
    return data


def _true_reference_damping(result: Estimate, truth: Mapping[str, Any]) -> float:
    """``c`` [N s/m] of the true law at the estimate's reference indentation."""
    return float(truth["beta"]) * result.damping.delta_ref ** float(truth["n"])


#: What the printed intervals are (one sentence, under the contact law's lines).
INTERVALS = ("95 % confidence intervals of the contact law's parameters from these recordings: they hold the impacts' "
             "scatter, each recording's cam-phase error and the pipeline's systematic error (docs/estimation.md)")

#: What each residual compares (docs/estimation.md, "Residuals"), for the summary's first line.
RESIDUAL_MEANING = {"lambda1": "the relative error of the maximum follower angle after each impact",
                    "lambda2": "the relative misfit of each contact-force history",
                    "lambda3": "the relative error of each hysteresis loop's area"}


#: Below this mean ``xi`` the restitution law's Hunt-Crossley equivalent is said not to be comparable with beta.
XI_NEAR_ONE = 0.9


def _interval(low: float, high: float, fmt: str, why: str) -> str:
    """``95 % interval [low, high]``, or ``95 % interval n/a (why)`` when either end is undetermined: never
    "undetermined" beside a value that exists."""
    if low is not None and high is not None and math.isfinite(low) and math.isfinite(high):
        return f"95 % interval [{low:{fmt}}, {high:{fmt}}]"
    return f"95 % interval n/a ({why})"


def _why_no_interval(damping: DampingEstimate) -> str:
    """Why the contact law's intervals are missing (for :func:`summary`)."""
    if (damping.model_check or {}).get("action") == "withheld":
        return "WITHHELD: the model check rejects the law; see the warnings"
    if damping.separable is False:
        return "beta and n are not separable from these data; see the warnings"
    return "not determined by these data; see the warnings"


def summary(result: Estimate) -> list[str]:
    """The lines ``impactid estimate`` prints for an estimate: the Hunt-Crossley law with 95 % intervals
    (and, on the built-in example's recordings, the values it was made with beside them), the damping
    ``c`` at the reference indentation (a unit that does not change with ``n``), then the restitution
    law as a second model of the same impacts, then the warnings, each once. An interval the data do not
    give is ``n/a`` with its reason, never "undetermined" beside a value that exists."""
    d, r = result.damping, result.restitution
    truth = example_truth(result.sources)
    used = int(np.isfinite(d.per_event["residual"]).sum())
    why = _why_no_interval(d)

    def made_with(value: float, fmt: str) -> str:
        return "" if truth is None else f"   example made with {value:{fmt}}"

    meaning = RESIDUAL_MEANING.get(d.residual, "")
    lines = [f"impactid estimate: {len(result.sources)} recording(s), {used} impacts; contact law fitted (method "
             f"{d.method}) on the residual {d.residual}" + (f" ({meaning})" if meaning else "")
             + f"; {d.n_simulations} simulated impacts (S1), {d.seconds:.2f} s",
             f"  beta  = {num(d.beta, '.4g')} N s m^-(n+1)   {_interval(*d.beta_interval, '.4g', why)}"
             + made_with(truth["beta"] if truth else 0.0, ".4g")]
    block = dict(d.identifiability or {})
    if block.get("determined", True) is False and all(math.isfinite(v) for v in d.beta_interval):
        # an interval is stated, but the fit does not stand by its parameters: said beside them, not only below,
        # with the block's note that says why (not one of its other notes)
        reason = next((v for v in block.get("notes") or () if "determined" in v),
                      "see the identifiability block in the result")
        lines.append(f"  (NOT DETERMINED: {reason})")
    if d.fixed_n:
        lines.append(f"  n     = {d.n:.5g} (fixed)" + made_with(truth["n"] if truth else 0.0, ".5g"))
    else:
        stated = all(math.isfinite(v) for v in d.n_interval)
        withheld = (d.model_check or {}).get("action") == "withheld"
        tag = "" if d.separable or withheld or not stated else "   NOT SEPARABLE from beta (see the warnings)"
        lines.append(f"  n     = {num(d.n, '.5g')}   {_interval(*d.n_interval, '.5g', why)}{tag}"
                     + made_with(truth["n"] if truth else 0.0, ".5g"))
    lines.append(f"  c_ref = {num(d.damping_at_reference, '.5g')} N s/m   {_interval(*d.c_interval, '.5g', why)}"
                 + made_with(_true_reference_damping(result, truth) if truth else 0.0, ".5g"))
    lines.append("  (Hunt-Crossley law F = k_H delta^1.5 - beta delta^n d(delta)/dt; c_ref = beta delta_ref^n is the "
                 f"damping at delta_ref = {d.delta_ref * 1e6:.4g} µm, the median measured peak indentation: its unit, "
                 "N s/m, does not change with n;")
    lines.append(f"   {INTERVALS})")
    boot_beta, boot_n = d.beta_bootstrap_interval, d.n_bootstrap_interval
    if all(math.isfinite(v) for v in boot_beta):
        boot = f"beta [{boot_beta[0]:.4g}, {boot_beta[1]:.4g}]"
        if not d.fixed_n and all(math.isfinite(v) for v in boot_n):
            boot += f", n [{boot_n[0]:.5g}, {boot_n[1]:.5g}]"
        lines.append(f"  bootstrap over the impacts (95 %): {boot} (the impacts' scatter alone, a part of the "
                     "intervals above)")
    lines.append(f"  objective (mean |{d.residual}| at the estimate) = {num(d.objective, '.4g')}")
    if r is None:
        reason = next((w for w in result.warnings if w.startswith("restitution law not estimated")),
                      "see the warnings")
        lines.append("  second model of the same impacts, the restitution law xi = 1 - gamma v_a: not estimated "
                     f"({reason})")
    else:
        lines.append("  second model of the same impacts: the restitution law xi = 1 - gamma v_a (xi = v_s / v_a, "
                     "separation over approach speed; rigid impacts, docs/estimation.md). It is not an estimate of "
                     "beta:")
        half = 1.96 * r.gamma_stderr
        gamma_why = (r.warnings[0] if r.warnings else "the restitution data do not determine its standard error")
        lines.append(f"    gamma = {num(r.gamma)} s/m   "
                     f"{_interval(r.gamma - half, r.gamma + half, '.5g', gamma_why)}")
        lines.append(f"    constant r = {num(r.r_constant)} (the mean xi over the impacts; mean approach speed "
                     f"{num(r.va_mean)} m/s)")
        far = math.isfinite(r.xi_mean) and r.xi_mean < XI_NEAR_ONE
        lines.append(f"    (1.5 gamma k_H = {num(r.beta_equivalent, '.4g')} N s m^-2.5 equals Hunt-Crossley's beta at "
                     f"n = 1.5 only for impacts with xi near 1; the mean xi here is {num(r.xi_mean, '.3g')}"
                     + (", so it is not comparable with beta above)" if far else ")"))
        if truth is not None and any(w.startswith("the residual of 'xi about") for w in result.warnings):
            lines.append("    (its model check is expected to find structure here (the warnings below): the example "
                         "was made with the Hunt-Crossley law, whose xi is not linear in the approach speed at these "
                         "dampings)")
    lines += [f"  warning: {message}" for message in dict.fromkeys(result.warnings)]
    return lines


def estimate_figures(result: Estimate, args: argparse.Namespace):
    """The figures of ``estimate --plots``: their names and their writer."""
    names = ["hysteresis.png"] + (["restitution.png"] if result.restitution is not None else []) + [
        "landscape.png", "residuals.png"]
    return names, lambda staged: figures.estimate_figures(result, args.plots, staged)


# ---- the command line -------------------------------------------------------------------------------


# the arguments (ARGUMENTS) are declared in the light impactid.rigs.pivoted.arguments (MODEL.estimate_arguments),
# so that ``impactid estimate --help`` does not import this module


def from_arguments(args: argparse.Namespace) -> dict[str, Any]:
    """The options of ``impactid estimate``'s arguments (``--grid`` chooses the grid method)."""
    lo, hi = args.n_range
    if not lo < hi:
        raise UsageError(f"argument --n-range: need LO < HI, got {lo:g} {hi:g}")
    return dict(residual=args.residual, fix_n=args.fix_n, method="grid" if args.grid else args.method,
                grid=tuple(args.grid or (41, 21)), integration=args.integration, anchor=args.anchor,
                c_bounds=C_BOUNDS, n_bounds=(lo, hi))


def _notes(result: Estimate) -> tuple[str, ...]:
    return result.warnings


#: What the generic estimate runs for rig P's recordings.
ESTIMATOR = Estimator(
    options=OPTIONS, arguments=ARGUMENTS, prepare=prepare, fit=fit, to_dict=to_dict, summary=summary, notes=_notes,
    warning=EstimationWarning, figures=estimate_figures, from_arguments=from_arguments, check=check_options,
    compact=compact, prepare_options=PREPARE_OPTIONS, title=TITLE)

"""The estimation pipeline: every option of the job from recordings to estimates, in one frozen object.

In the manner of pvlib's ``ModelChain``: a :class:`Pipeline` holds the choices that decide an estimate
(the per-event kinematics method and anchor, the residual, the search and its bounds, the
uncertainty options, the calibration) and runs the steps in order::

    recordings -> events -> kinematics -> event sets -> contact damping (+ calibration) -> restitution

:func:`impactid.estimate` is a thin call on it. The pipeline's options are recorded in the result
(:attr:`~impactid.rigs.pivoted.estimates.Estimate.pipeline` and its provenance), so that an estimate says how it
was made.

Example
-------
>>> from impactid import Pipeline
>>> pipeline = Pipeline(fix_n=1.5, bootstrap_resamples=200)      # doctest: +SKIP
>>> result = pipeline.run(["rec_020_16.h5", "rec_025_15.h5"])      # doctest: +SKIP
"""

from __future__ import annotations

import json
import math
import warnings
from collections.abc import Sequence
from dataclasses import asdict, dataclass, replace
from typing import TYPE_CHECKING

import pandas as pd

from impactid._version import __version__
from impactid.errors import ImpactidError
from impactid.rigs.pivoted.estimates import (
    BOOTSTRAP_RESAMPLES,
    BOOTSTRAP_SEED,
    C_BOUNDS,
    CALIBRATION_THRESHOLD,
    METHODS,
    N_BOUNDS,
    SEPARABILITY_WIDTH,
    Estimate,
    EstimationWarning,
    Progress,
    fit_contact_damping,
    fit_restitution,
)
from impactid.rigs.pivoted.residuals import EventSet, residual_name

if TYPE_CHECKING:
    from impactid.rigs.pivoted.calibration import RecordingSampling
    from impactid.rigs.pivoted.reconstruct import Reconstruction

__all__ = ["Pipeline", "PreparedRecording", "estimate"]


@dataclass(frozen=True)
class Pipeline:
    """Every option of an estimate (frozen; recorded in the result).

    Attributes
    ----------
    residual : ``"lambda1"`` (accelerometer only, default), ``"lambda2"`` or ``"lambda3"``.
    fix_n : fix the Hunt–Crossley exponent (1.5: Hertzian; None: estimate it jointly with beta).
    method : ``"least-squares"`` (trust-region Gauss–Newton on the per-event residuals, with the
        profile along the valley; :mod:`impactid.gauss_newton`), ``"optimise"`` (nested bounded Brent
        searches along the valley, lattice and bootstrap intervals) or ``"grid"`` (the paper's grid).
    grid : grid points ``(n_c, n_n)`` of the grid method.
    integration, anchor : per-event kinematics (:func:`impactid.rigs.pivoted.reconstruct.reconstruct`).
    c_bounds : bounds of ``c = beta delta_ref^n`` [N s/m]; n_bounds : bounds of ``n``.
    landscape : also compute the objective landscape (for plots).
    calibrate : measure and correct the pipeline's alpha_m bias on the model's own recording
        (:mod:`impactid.rigs.pivoted.calibration`; lambda1 only).
    residual_floor : the residual's noise floor (None: the calibrated default of the residual).
    separability_width : widest interval of ``n`` with which ``beta, n`` count as separable.
    bootstrap_resamples, bootstrap_seed : the bootstrap over events.
    """

    residual: str = "lambda1"
    fix_n: float | None = None
    method: str = "least-squares"
    grid: tuple[int, int] = (41, 21)
    integration: str = "rk"
    anchor: str = "cam-phase"
    c_bounds: tuple[float, float] = C_BOUNDS
    n_bounds: tuple[float, float] = N_BOUNDS
    landscape: bool = False
    calibrate: bool = True
    residual_floor: float | None = None
    separability_width: float = SEPARABILITY_WIDTH
    bootstrap_resamples: int = BOOTSTRAP_RESAMPLES
    bootstrap_seed: int = BOOTSTRAP_SEED

    def __post_init__(self) -> None:
        object.__setattr__(self, "residual", residual_name(self.residual))
        if self.method not in METHODS:
            raise ValueError(f"method must be one of {', '.join(METHODS)}; got {self.method!r}")
        if self.fix_n is not None and not (math.isfinite(self.fix_n) and self.fix_n >= 0.0):
            raise ValueError(f"fix_n must be a finite number >= 0, got {self.fix_n!r}")
        if self.bootstrap_resamples < 10:
            raise ValueError(f"bootstrap_resamples must be at least 10, got {self.bootstrap_resamples!r}")

    def fit_options(self) -> dict:
        """The keyword arguments of :func:`~impactid.rigs.pivoted.estimates.fit_contact_damping` this pipeline uses."""
        return dict(fix_n=self.fix_n, method=self.method, grid=self.grid, c_bounds=self.c_bounds,
                    n_bounds=self.n_bounds, landscape=self.landscape, residual_floor=self.residual_floor,
                    separability_width=self.separability_width, bootstrap_resamples=self.bootstrap_resamples,
                    bootstrap_seed=self.bootstrap_seed)

    def to_dict(self) -> dict:
        """The options as JSON-ready data."""
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(self).items()}

    @classmethod
    def from_dict(cls, data: dict) -> Pipeline:
        """The pipeline of :meth:`to_dict` (e.g. from a result's ``pipeline``)."""
        return cls(**{k: (tuple(v) if isinstance(v, list) else v) for k, v in data.items()})

    def prepare(self, recording, *, rig=None, name: str | None = None,
                keep_samples: bool = True) -> PreparedRecording:
        """Read, segment and reconstruct one recording: the first half of :meth:`run`, for one recording.

        Parameters
        ----------
        recording : a :class:`~impactid.io.Recording` or the path of a recording file.
        rig : overrides the recording's rig (a rig dataclass or the path of a TOML rig file).
        name : the recording's name in messages and results when it has no file (default ``"recording 1"``).
        keep_samples : keep the recording in the reconstruction (needed for the per-event histories of
            the figures); False leaves a product of a few kB per impact that pickles (what the tasks of
            :mod:`impactid.campaign` pass to the fits).

        Returns
        -------
        PreparedRecording
            the reconstruction, the event set the fits replay, the per-impact speeds of the restitution
            fit, the sampling the calibration needs and the notes of the per-impact kinematics.
        """
        from impactid.io import Recording, read_recording
        from impactid.rigs.pivoted.calibration import RecordingSampling

        if isinstance(recording, Recording):
            rec = recording.with_rig(rig) if rig is not None else recording
        else:
            rec = read_recording(recording, rig=rig)
        recon = _per_impact_kinematics(rec, integration=self.integration, anchor=self.anchor)
        es = EventSet.from_reconstruction(recon, source=rec.source or name or "recording 1")
        tab = recon.table.reset_index()
        impacts = pd.DataFrame({"source": es.source, "event": tab["event"], "approach_speed": tab["approach_speed"],
                                "xi": tab["xi"], "separation_speed": tab["separation_speed"]})
        sampling = RecordingSampling.of(rec) if self._calibrated() else None
        if not keep_samples and getattr(recon, "_recording", None) is not None:
            recon = replace(recon, _recording=None)
        return PreparedRecording(source=es.source, reconstruction=recon, event_set=es, impacts=impacts,
                                 sampling=sampling, warnings=tuple(recon.warnings))

    def run(self, recordings, *, rig=None, progress: Progress | None = None) -> Estimate:
        """Read, segment and reconstruct ``recordings``, then estimate ``beta, n`` and the restitution law.

        Parameters
        ----------
        recordings : one or several :class:`~impactid.io.Recording` objects or paths (several: joint fit).
        rig : overrides the recordings' rig: a rig dataclass, or the path of a TOML rig file, whose
            ``[operating]`` table also supplies or overrides the operating point.
        progress : callback ``(stage, fraction)`` for a progress display.

        Returns
        -------
        Estimate
            with the damping estimate, the restitution law (None, with the reason among the
            warnings, when it cannot be fitted), per-event tables, notes and provenance. The notes
            of every step are collected in the result's ``warnings`` and issued here, each once, as
            :class:`~impactid.rigs.pivoted.estimates.EstimationWarning` (the steps themselves do not warn).
        """
        from impactid.io import Recording, check_memory, read_recording

        if isinstance(recordings, (Recording, str)) or hasattr(recordings, "__fspath__"):
            recordings = [recordings]
        check_memory(recordings, "estimate")  # the paths among them: refused before anything is read
        recs = [(r.with_rig(rig) if rig is not None else r) if isinstance(r, Recording) else read_recording(r, rig=rig)
                for r in recordings]
        if not recs:
            raise ImpactidError("no recording given")
        prepared = [self.prepare(rec, name=f"recording {k + 1}") for k, rec in enumerate(recs)]
        return self.fit(prepared, progress=progress)

    def fit(self, prepared: Sequence[PreparedRecording], *, progress: Progress | None = None,
            warn: bool = True) -> Estimate:
        """Estimate ``beta, n`` and the restitution law from prepared recordings: the second half of
        :meth:`run` (several: a joint fit).

        Parameters
        ----------
        prepared : the :meth:`prepare` products of one or several recordings of one rig (they may
            differ in cam speed and eccentricity only).
        progress : callback ``(stage, fraction)`` for a progress display.
        warn : issue the notes as :class:`~impactid.rigs.pivoted.estimates.EstimationWarning` (they are in the
            result's ``warnings`` either way).

        Returns
        -------
        Estimate
            as :meth:`run` (the same numbers for the same recordings and options).
        """
        prepared = list(prepared)
        if not prepared:
            raise ImpactidError("no recording given")
        recons = [p.reconstruction for p in prepared]
        sets = [p.event_set for p in prepared]
        frames = [p.impacts for p in prepared]
        collected: list[str] = [m for p in prepared for m in p.warnings]
        # operating points may differ in cam speed and eccentricity; the contact pair must be the same
        models = {repr(r.fixed_parameters) for r in recons}
        if len(models) > 1:
            raise ImpactidError("a joint fit needs recordings of the same rig (parameters other than the eccentricity "
                                "e equal); they differ between " + ", ".join(s.source for s in sets))
        damping = fit_contact_damping(sets, self.residual, **self.fit_options(), progress=progress, warn=False)
        collected += damping.warnings
        calibration: list[dict] = []
        if self._calibrated():
            first = damping
            damping, sets, calibration = _calibrated(damping, [p.sampling for p in prepared], sets,
                                                     self.fit_options(), integration=self.integration,
                                                     anchor=self.anchor)
            collected += damping.warnings if damping is not first else ()
        # a part of the job that cannot be done does not take the others with it: without a
        # determined xi the restitution law is missing from the result, with the reason
        try:
            restitution = fit_restitution(pd.concat(frames, ignore_index=True), recons[0].rig.k_H, warn=False)
            collected += restitution.warnings
        except ImpactidError as exc:
            restitution = None
            collected.append(f"restitution law not estimated: {exc}")
        if warn:
            for message in dict.fromkeys(collected):
                warnings.warn(message, EstimationWarning, stacklevel=3)
        ops = tuple({**r.operating_point, "events": len(s)} for r, s in zip(recons, sets))
        prov = tuple(p for r in recons for p in r.provenance) + (
            f"fit_contact_damping(residual={damping.residual!r}, method={self.method!r}, fix_n={self.fix_n}): "
            f"{damping.n_simulations} S1 simulations in {damping.seconds:.2f} s",
            f"impactid {__version__} pipeline {json.dumps(self.to_dict(), sort_keys=True)}")
        return Estimate(damping=damping, restitution=restitution, sources=tuple(s.source for s in sets),
                        operating_points=ops, reconstructions=tuple(recons), event_sets=tuple(sets),
                        warnings=tuple(collected), provenance=prov, calibration=tuple(calibration),
                        pipeline=self.to_dict())

    def _calibrated(self) -> bool:
        """Whether the estimate is calibrated (:mod:`impactid.rigs.pivoted.calibration`; lambda1 only)."""
        return bool(self.calibrate and residual_name(self.residual) == "lambda1")


@dataclass(frozen=True)
class PreparedRecording:
    """One recording read, segmented and reconstructed (:meth:`Pipeline.prepare`): what its fits use.

    Attributes
    ----------
    source : the recording's name in messages and results.
    reconstruction : the per-impact kinematics (rig P: a :class:`~impactid.rigs.pivoted.reconstruct.Reconstruction`;
        without the samples when prepared with ``keep_samples=False``).
    event_set : the :class:`~impactid.rigs.pivoted.residuals.EventSet` the fits replay.
    impacts : per impact ``source, event, approach_speed`` [m/s], ``xi`` [-], ``separation_speed``
        [m/s] (the restitution fit's data).
    sampling : the :class:`~impactid.rigs.pivoted.calibration.RecordingSampling` of the calibration (None when the
        pipeline is not calibrated).
    warnings : the notes of the per-impact kinematics.
    """

    source: str
    reconstruction: Reconstruction
    event_set: EventSet
    impacts: pd.DataFrame
    sampling: RecordingSampling | None
    warnings: tuple[str, ...] = ()


#: The contact law the pipeline estimates: a recording's rig model must offer it
#: (:attr:`~impactid.rigs.base.RigModel.laws`) and a measurement model of per-impact kinematics.
ESTIMATED_LAW = "hunt-crossley"


def _estimable(model) -> bool:
    return model.measure is not None and any(law.name == ESTIMATED_LAW for law in model.laws)


def _per_impact_kinematics(recording, *, integration: str, anchor: str):
    """The per-impact kinematics of one recording by its rig's measurement model (the registry's
    :attr:`~impactid.rigs.base.RigModel.measure`: rig P's is :func:`impactid.rigs.pivoted.reconstruct.reconstruct`),
    with their notes in the result rather than warned."""
    from impactid.io import RecordingError
    from impactid.rigs.registry import MODELS, rig_model

    model = rig_model(recording.require_rig().model)
    if not _estimable(model):
        able = " or ".join(repr(m.name) for m in MODELS.values() if _estimable(m))
        raise RecordingError(f"{recording.source or 'recording'}: needs a {able} rig (per-impact kinematics for a "
                             f"{ESTIMATED_LAW} law), the recording's rig is {model.name!r}")
    return model.measure(recording, integration=integration, anchor=anchor, warn=False)


def _calibrated(damping, samplings, sets, fit_options: dict, *, integration: str, anchor: str):
    """Measure the pipeline's alpha_m bias at the first estimate (:mod:`impactid.rigs.pivoted.calibration`); where it
    exceeds :data:`CALIBRATION_THRESHOLD`, correct the measured alpha_m and fit again, with the
    intervals' indifference at least half the largest correction."""
    from impactid.contact import HuntCrossley
    from impactid.rigs.pivoted.calibration import pipeline_bias

    law = HuntCrossley(beta=damping.beta, n=damping.n)
    biases = [pipeline_bias(s, law, integration=integration, anchor=anchor) for s in samplings]
    record = [dict(source=s.source, **b.to_dict()) for s, b in zip(sets, biases)]
    applied = [b.significant and abs(b.alpha_m) > CALIBRATION_THRESHOLD for b in biases]
    if not any(applied):
        return damping, sets, record
    corrected = [s.scale_alpha_m(1.0 / (1.0 + b.alpha_m)) if use else s for s, b, use in zip(sets, biases, applied)]
    systematic = max(0.5 * abs(b.alpha_m) + 2.0 * b.stderr for b, use in zip(biases, applied) if use)
    again = fit_contact_damping(corrected, damping.residual, **fit_options, systematic=systematic, warn=False)
    note = (f"the pipeline's bias of alpha_m at these recordings' sampling, measured on the model's own recording "
            f"at the first estimate (beta {damping.beta:.4g}, n {damping.n:.4g}), is "
            + ", ".join(f"{b.alpha_m:+.2e} +- {b.stderr:.1e} ({s.source})" for s, b in zip(sets, biases)
                        if math.isfinite(b.alpha_m))
            + "; alpha_m was corrected where the bias is significant and the fit repeated, with the intervals "
              "widened by half the correction plus two standard errors")
    again = replace(again, warnings=again.warnings + (note,), n_simulations=again.n_simulations + damping.n_simulations,
                    seconds=again.seconds + damping.seconds)
    return again, corrected, record


def estimate(recordings, *, residual: str = "lambda1", fix_n: float | None = None, method: str = "least-squares",
             grid: tuple[int, int] = (41, 21), rig=None, integration: str = "rk", anchor: str = "cam-phase",
             c_bounds=C_BOUNDS, n_bounds=N_BOUNDS, landscape: bool = False,
             progress: Progress | None = None, calibrate: bool = True) -> Estimate:
    """Read, segment and reconstruct recordings, then estimate ``beta, n`` and the restitution laws.

    A thin call on :class:`impactid.pipeline.Pipeline` (which holds every option of the job and is
    recorded in the result's provenance): ``estimate(recs, **options)`` is
    ``Pipeline(**options).run(recs, rig=rig, progress=progress)``.

    Parameters
    ----------
    recordings : one or several :class:`~impactid.io.Recording` objects or paths (several: joint fit).
    residual, fix_n, method, grid, c_bounds, n_bounds, landscape : see :func:`fit_contact_damping`.
    rig : overrides the recordings' rig: rig parameters (e.g. :data:`~impactid.rigs.SUNDAR2016`), or the path of
        a TOML rig file, whose ``[operating]`` table also supplies or overrides the operating point.
    integration, anchor : per-event kinematics methods (:func:`impactid.rigs.pivoted.reconstruct.reconstruct`).
    progress : callback ``(stage, fraction)`` for a progress display.
    calibrate : measure the pipeline's bias of alpha_m on the model's own recording at the first
        estimate and, where it matters, correct it and fit again (:mod:`impactid.rigs.pivoted.calibration`;
        lambda1 only).
    """
    pipeline = Pipeline(residual=residual, fix_n=fix_n, method=method, grid=tuple(grid), integration=integration,
                        anchor=anchor, c_bounds=tuple(c_bounds), n_bounds=tuple(n_bounds), landscape=landscape,
                        calibrate=calibrate)
    return pipeline.run(recordings, rig=rig, progress=progress)

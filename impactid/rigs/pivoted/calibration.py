"""Self-calibration of the measurement pipeline: its bias at this recording's sampling, measured on
the model's own recording.

The per-impact pipeline (event detection, double integration, anchoring) measures ``alpha_m``
with a small bias that depends on how the contact is sampled: a few samples per contact (a low
sample rate), a coarse ADC, or a contact whose force rises like ``t^n`` with ``n`` well below the
Hertz 1.5 (a damping-dominated, nearly plastic impact) all leave a bias of 1e-4 to 3e-3 in
``alpha_m``, and the L1 estimate of ``beta`` absorbs it: with all impacts alike, nothing in the
residuals shows it. The estimate can only be as accurate as the pipeline.

:func:`pipeline_bias` measures that bias where it matters, at the estimate: the rig is simulated at
the recording's operating point with the fitted law, sampled at the recording's rate with its
noise level, and put through the same pipeline; the relative error of the reconstructed
``alpha_m`` against the simulation's own maximum angle is the bias (the calibration recording has
at least :data:`MIN_EVENTS` impacts, so that the bias is measured to a small fraction of the
per-event scatter). Where the bias is significant, :func:`impactid.pipeline.estimate` corrects the
measured ``alpha_m`` by it, fits again, and widens the intervals by half the correction plus two
standard errors of the calibration (the calibration reproduced 50 to 100 % of the actual bias in
the envelope validation; an anti-alias filter the calibration cannot know of accounts for the rest).

A band-limited recording (:attr:`~impactid.rigs.pivoted.reconstruct.Reconstruction.band_limited`: its rises are
preceded by the ringing of a linear-phase anti-alias filter) is reproduced with such a filter
(:func:`band_limited_decimation`) and with its onsets where the measurement's fall between two samples, and the
cam phase reconstructed from it, against the simulation's, is also measured (:attr:`PipelineBias.phase`): the
filter smooths each rise and leaves the onset times an error of a fraction of a sample that the cam-phase anchor
turns into a phase error (docs/estimation.md, "Band-limited recordings"). The phase bias of a noise-free recording
(noise floor below :data:`NOISE_FREE_FRACTION` of its peak) is measured too, without a filter: a sharp onset's error is
a few hundredths of a sample, but in periodic motion it is the same at every impact, and nothing else hides it
(docs/estimation.md, "The cam phase of noise-free recordings").
"""

from __future__ import annotations

import functools
import math
import warnings
from dataclasses import dataclass

import numpy as np

from impactid.contact import HuntCrossley
from impactid.events import find_events
from impactid.rigs.pivoted.reconstruct import band_limited_decimation, reconstruct
from impactid.rigs.pivoted.runs import simulate
from impactid.signal import noise_floor

__all__ = ["CACHE_SIZE", "MIN_EVENTS", "NOISE_FREE_FRACTION", "PipelineBias", "RecordingSampling",
           "band_limited_decimation", "calibration_duration", "noise_free", "pipeline_bias"]

#: Seconds of simulated settling before the calibration recording (the slowest period-1 transients
#: of rig P need about 35 s; docs/estimation.md).
SETTLE_S = 40.0


#: Impacts the calibration recording holds (:func:`calibration_duration`): enough that the bias is
#: measured to an eighth of the per-event scatter, whatever the measurement's length (a 60 s recording
#: is not copied: its 960 impacts would measure the same bias, four times more finely, in 15 times the
#: time and memory; the calibration's standard error widens the intervals, so nothing is claimed that
#: 64 impacts do not show).
MIN_EVENTS = 64
#: Calibrations kept per process (:func:`pipeline_bias` is cached on its rig, operating point, law,
#: sampling and methods: a campaign's fits of one operating point measure it once).
CACHE_SIZE = 64


@dataclass(frozen=True)
class PipelineBias:
    """The pipeline's relative error of ``alpha_m`` on the model's own recording.

    ``alpha_m`` is the mean over the calibration's events of ``alpha_m(measured) / alpha_m(true) - 1``,
    ``stderr`` its standard error (the per-event scatter over the square root of the number of
    events), ``events`` how many were compared. For a band-limited or noise-free recording also ``phase``, the
    reconstructed cam phase less the simulation's [rad], and ``phase_stderr``, the reconstruction's standard
    error of it [rad] (NaN otherwise).
    """

    alpha_m: float
    stderr: float
    events: int
    phase: float = math.nan
    phase_stderr: float = math.nan

    @property
    def significant(self) -> bool:
        """Whether the bias stands out of its own uncertainty (more than two standard errors)."""
        return bool(math.isfinite(self.alpha_m) and abs(self.alpha_m) > 2.0 * self.stderr)

    @property
    def phase_measured(self) -> bool:
        """Whether a cam-phase bias was measured (band-limited and noise-free recordings, with its standard error)."""
        return bool(math.isfinite(self.phase) and math.isfinite(self.phase_stderr))

    def to_dict(self) -> dict:
        out = {"alpha_m": self.alpha_m, "stderr": self.stderr, "events": self.events}
        if math.isfinite(self.phase):
            out.update(phase=self.phase, phase_stderr=self.phase_stderr)
        return out


@dataclass(frozen=True)
class RecordingSampling:
    """What the calibration copies of a recording: its rig and operating point, its sampling and
    the accelerometer's noise level (a few numbers, where the recording holds millions of samples:
    what a task of a campaign passes on instead of the recording).

    Attributes
    ----------
    rig : the rig dataclass (rig P).
    cam_speed_hz : cam speed [Hz].
    sample_rate_hz : sampling rate [Hz].
    start_time_s : time of the first sample [s].
    duration : recorded time [s].
    noise_fraction : the accelerometer's noise floor as a fraction of its largest magnitude [-].
    decimation : the anti-alias decimation the calibration applies (1: none; a band-limited recording's
        :func:`band_limited_decimation`).
    onset_fraction : where a band-limited or noise-free recording's first used onset falls between two samples
        [samples, in [0, 1)]; NaN otherwise.
    """

    rig: object
    cam_speed_hz: float
    sample_rate_hz: float
    start_time_s: float
    duration: float
    noise_fraction: float
    decimation: int = 1
    onset_fraction: float = math.nan

    @classmethod
    def of(cls, recording, noise_sigma: float | None = None, band_limited: bool = False,
           onset_time_s: float = math.nan) -> RecordingSampling:
        """The sampling of a :class:`~impactid.io.Recording` (with a rig, a cam speed and ``accel_tangential``).

        ``noise_sigma`` is the accelerometer's noise floor [m/s^2] where it is known already (the
        :attr:`~impactid.events.EventTable.noise_sigma` of the recording's events: the same
        :func:`~impactid.signal.noise_floor`, which takes a second over a 60 s recording); None computes it.
        ``band_limited``: the recording's rises ring (``Reconstruction.band_limited``), with its first used
        onset at ``onset_time_s`` [s].
        """
        accel = recording["accel_tangential"]
        sigma = noise_floor(accel) if noise_sigma is None else float(noise_sigma)
        lo, hi = recording.channel_range("accel_tangential")  # the largest magnitude, without a pass over it
        fraction = sigma / max(abs(lo), abs(hi), 1e-300)
        rate = float(recording.sample_rate_hz)
        return cls(rig=recording.rig, cam_speed_hz=float(recording.require_cam_speed()),
                   sample_rate_hz=rate, start_time_s=float(recording.start_time_s),
                   duration=float(recording.duration), noise_fraction=float(fraction),
                   decimation=band_limited_decimation(rate) if band_limited else 1,
                   onset_fraction=((float(onset_time_s) - float(recording.start_time_s)) * rate) % 1.0
                   if (band_limited or noise_free(fraction)) and math.isfinite(onset_time_s) else math.nan)


#: A recording whose accelerometer noise floor is below this fraction of its largest magnitude is noise-free: its
#: cam-phase bias is measured too (its replay's phase error is then the pipeline's, not a noise realisation's), and
#: the contact-duration check takes its simulated contacts as they are where they match
#: (:func:`~impactid.rigs.pivoted.damping_diagnostics.contact_duration_check`, which compares the noise floor with
#: the largest contact pulse, the event set's nearest measure of the same magnitude).
NOISE_FREE_FRACTION = 1e-4


def noise_free(noise_fraction: float) -> bool:
    """Whether a noise floor of ``noise_fraction`` of the signal's magnitude [-] is noise-free
    (:data:`NOISE_FREE_FRACTION`)."""
    return bool(math.isfinite(noise_fraction) and noise_fraction < NOISE_FREE_FRACTION)


def _phase_calibrated(sampling: RecordingSampling) -> bool:
    """Whether the calibration measures the cam-phase bias: band-limited or noise-free recordings."""
    return sampling.decimation > 1 or noise_free(sampling.noise_fraction)


def calibration_duration(sampling: RecordingSampling) -> float:
    """Length of the calibration recording [s]: ``MIN_EVENTS + 1`` cam revolutions (:data:`MIN_EVENTS`;
    rig P impacts once per revolution in period-1 motion), whatever the measurement's duration.

    A recording shorter than that (the built-in example's 1 s) is calibrated on the same length as before
    (which was ``max(duration, (MIN_EVENTS + 1) / cam_speed_hz)``); a longer one on those revolutions
    only, not on a copy of the recording (a 60 s recording: 4.1 s at 16 Hz instead of 60 s).
    """
    return (MIN_EVENTS + 1) / sampling.cam_speed_hz


def pipeline_bias(recording, law, *, integration="rk", anchor: str = "cam-phase", seed: int = 0) -> PipelineBias:
    """Bias of the reconstructed ``alpha_m`` at the recording's sampling, on the model at ``law``.

    The model's recording is :func:`calibration_duration` long (``MIN_EVENTS + 1`` cam revolutions),
    whatever the measurement's length; the result is cached per process on what decides it (the rig,
    cam speed, sampling, noise level, law, methods and seed; :data:`CACHE_SIZE` entries).

    Parameters
    ----------
    recording : the measured :class:`~impactid.io.Recording` (its rig, cam speed, sample rate,
        start time and the accelerometer's noise floor are copied), or its :class:`RecordingSampling`.
    law : the fitted :class:`~impactid.contact.HuntCrossley` law.
    integration, anchor : the reconstruction's methods (the same as the estimate's).
    seed : seed of the simulated noise.

    Returns
    -------
    PipelineBias
        the mean relative error of ``alpha_m`` [-], its standard error [-] and the events compared
        (NaN, NaN, 0 when the calibration cannot run).
    """
    sampling = recording if isinstance(recording, RecordingSampling) else RecordingSampling.of(recording)
    # the measurement's duration does not decide the calibration: one cache entry per operating point
    key = RecordingSampling(rig=sampling.rig, cam_speed_hz=sampling.cam_speed_hz,
                            sample_rate_hz=sampling.sample_rate_hz, start_time_s=max(sampling.start_time_s, SETTLE_S),
                            duration=calibration_duration(sampling), noise_fraction=sampling.noise_fraction,
                            decimation=sampling.decimation, onset_fraction=sampling.onset_fraction)
    try:
        hash((key, law))
    except TypeError:  # an unhashable rig or law (not the package's own): measured without the cache
        return _measure_bias(key, law, integration, anchor, seed)
    return _cached_bias(key, law, integration, anchor, seed)


@functools.lru_cache(maxsize=CACHE_SIZE)
def _cached_bias(key: RecordingSampling, law: HuntCrossley, integration: str, anchor: str, seed: int) -> PipelineBias:
    """:func:`_measure_bias`, cached per process on its (hashable, frozen) arguments."""
    return _measure_bias(key, law, integration, anchor, seed)


def _first_contact(sampling: RecordingSampling, law, start_time_s: float) -> float:
    """Time [s] of the model's first contact after ``start_time_s`` (NaN if none within the calibration recording)."""
    try:
        run = simulate(sampling.rig, sampling.cam_speed_hz, law, duration=start_time_s + sampling.duration,
                       mu=sampling.rig.mu)
    except Exception:  # noqa: BLE001 - the recording is then sampled as it falls
        return math.nan
    starts = run.contacts["t_start"].to_numpy(dtype=float)
    later = starts[starts > start_time_s]
    return float(later[0]) if later.size else math.nan


def _measure_bias(sampling: RecordingSampling, law, integration: str, anchor: str, seed: int) -> PipelineBias:
    """Simulate ``sampling.duration`` seconds of the model from ``sampling.start_time_s`` on, put them through
    the pipeline and compare each reconstructed ``alpha_m`` with the simulation's apex (see
    :func:`pipeline_bias`)."""
    # the simulator's sampling imports scipy.signal (1-2 s): only when a calibration runs, not with this module
    from impactid.rigs.pivoted.synth import synth_pivoted
    from impactid.synth import SensorModel

    def model_recording(start_time_s: float):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            synthetic = synth_pivoted(sampling.rig, sampling.cam_speed_hz, law, sampling.duration,
                                      settle_s=start_time_s, sample_rate_hz=sampling.sample_rate_hz,
                                      mu=sampling.rig.mu,
                                      sensors=SensorModel(noise={"accel_tangential": sampling.noise_fraction},
                                                          seed=seed, decimation=sampling.decimation),
                                      channels=("accel_tangential",))
            try:
                return synthetic, reconstruct(synthetic.recording, find_events(synthetic.recording, warn=False),
                                              integration=integration, anchor=anchor, warn=False)
            except Exception:  # noqa: BLE001 - a calibration that cannot run leaves the estimate as it is
                return synthetic, None

    def aligned_start(first_onset: float) -> float:
        # an onset's error depends on where the onset falls between two samples, and in periodic motion the onsets
        # fall at a few recurring places (at 16 Hz and 204.8 kHz: one): the model's recording is sampled with its
        # first onset where the measurement's falls (the sampling grid moved by the difference)
        first = (first_onset - start) * sampling.sample_rate_hz
        shift = (sampling.onset_fraction - first) % 1.0
        shift = shift - 1.0 if shift > 0.5 else shift
        return start - shift / sampling.sample_rate_hz

    start = sampling.start_time_s
    aligned = _phase_calibrated(sampling) and math.isfinite(sampling.onset_fraction)
    phase_known = sampling.decimation > 1  # a noise-free recording's phase bias: only from an aligned grid
    if aligned and sampling.decimation == 1:
        # a sharp onset is detected within a few hundredths of a sample: the model's first contact, from a run
        # without the recording's samples (a fifteenth of the cost of one), places the grid (the bias changes by
        # a factor of eight as the onset moves between two samples at 16 Hz: unaligned, it is not measured)
        contact = _first_contact(sampling, law, start)
        phase_known = math.isfinite(contact)
        start = aligned_start(contact) if phase_known else start
        synthetic, recon = model_recording(start)
    else:
        synthetic, recon = model_recording(start)
        if recon is not None and aligned and len(recon.table):  # band-limited: its onsets as the pipeline finds them
            start = aligned_start(float(recon.table["t_onset"].iloc[0]))
            synthetic, recon = model_recording(start)
    if recon is None:
        return PipelineBias(math.nan, math.nan, 0)
    apex_t = np.asarray(synthetic.truth["apexes"]["t"], dtype=float)
    apex_a = np.asarray(synthetic.truth["apexes"]["alpha"], dtype=float)
    order = np.argsort(apex_t, kind="stable")
    apex_t, apex_a = apex_t[order], apex_a[order]
    t_onset = recon.table["t_onset"].to_numpy(dtype=float)
    t_next = recon.table["t_next"].to_numpy(dtype=float)
    alpha_m = recon.table["alpha_m"].to_numpy(dtype=float)
    # the largest apex strictly between each onset and the next (apexes sorted in time)
    known = np.isfinite(t_onset) & np.isfinite(t_next)
    lo = np.searchsorted(apex_t, np.where(known, t_onset, np.inf), side="right")
    hi = np.where(known, np.searchsorted(apex_t, np.where(known, t_next, -np.inf), side="left"), 0)
    errors = np.array([alpha_m[i] / float(np.max(apex_a[lo[i]:hi[i]])) - 1.0
                       for i in range(alpha_m.size) if hi[i] > lo[i]])
    errors = errors[np.isfinite(errors)]
    phase, phase_stderr = math.nan, math.nan
    if _phase_calibrated(sampling) and phase_known and math.isfinite(recon.cam_phase):
        # the recording's cam phase is Theta at its first sample; the simulation's is theta_ref (0) at t = 0
        true_phase = 2.0 * math.pi * sampling.cam_speed_hz * start
        phase = float(np.angle(np.exp(1j * (recon.cam_phase - true_phase))))
        phase_stderr = float(recon.cam_phase_stderr)
    if errors.size < 2:
        return PipelineBias(math.nan, math.nan, int(errors.size), phase, phase_stderr)
    return PipelineBias(float(np.mean(errors)), float(np.std(errors, ddof=1) / math.sqrt(errors.size)),
                        int(errors.size), phase, phase_stderr)

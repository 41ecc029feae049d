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
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from impactid.signal import noise_floor

__all__ = ["PipelineBias", "RecordingSampling", "pipeline_bias"]

#: Seconds of simulated settling before the calibration recording (the slowest period-1 transients
#: of rig P need about 35 s; docs/estimation.md).
SETTLE_S = 40.0


#: Fewest impacts the calibration recording holds (it is made longer than the measurement when
#: needed, so that the bias is measured to a small fraction of the per-event scatter).
MIN_EVENTS = 64


@dataclass(frozen=True)
class PipelineBias:
    """The pipeline's relative error of ``alpha_m`` on the model's own recording.

    ``alpha_m`` is the mean over the calibration's events of ``alpha_m(measured) / alpha_m(true) - 1``,
    ``stderr`` its standard error (the per-event scatter over the square root of the number of
    events), ``events`` how many were compared.
    """

    alpha_m: float
    stderr: float
    events: int

    @property
    def significant(self) -> bool:
        """Whether the bias stands out of its own uncertainty (more than two standard errors)."""
        return bool(math.isfinite(self.alpha_m) and abs(self.alpha_m) > 2.0 * self.stderr)

    def to_dict(self) -> dict:
        return {"alpha_m": self.alpha_m, "stderr": self.stderr, "events": self.events}


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
    """

    rig: object
    cam_speed_hz: float
    sample_rate_hz: float
    start_time_s: float
    duration: float
    noise_fraction: float

    @classmethod
    def of(cls, recording) -> RecordingSampling:
        """The sampling of a :class:`~impactid.io.Recording` (with a rig, a cam speed and ``accel_tangential``)."""
        accel = recording["accel_tangential"]
        fraction = noise_floor(accel) / max(float(np.max(np.abs(accel))), 1e-300)
        return cls(rig=recording.rig, cam_speed_hz=float(recording.require_cam_speed()),
                   sample_rate_hz=float(recording.sample_rate_hz), start_time_s=float(recording.start_time_s),
                   duration=float(recording.duration), noise_fraction=float(fraction))


def pipeline_bias(recording, law, *, integration="rk", anchor: str = "cam-phase", seed: int = 0) -> PipelineBias:
    """Bias of the reconstructed ``alpha_m`` at the recording's sampling, on the model at ``law``.

    Parameters
    ----------
    recording : the measured :class:`~impactid.io.Recording` (its rig, cam speed, sample rate,
        start time, duration and the accelerometer's noise floor are copied), or its
        :class:`RecordingSampling`.
    law : the fitted :class:`~impactid.contact.HuntCrossley` law.
    integration, anchor : the reconstruction's methods (the same as the estimate's).
    seed : seed of the simulated noise.
    """
    from impactid.events import find_events
    from impactid.rigs.pivoted.reconstruct import reconstruct
    from impactid.rigs.pivoted.synth import synth_pivoted
    from impactid.synth import SensorModel

    sampling = recording if isinstance(recording, RecordingSampling) else RecordingSampling.of(recording)
    fraction = sampling.noise_fraction
    duration = max(sampling.duration, (MIN_EVENTS + 1) / sampling.cam_speed_hz)
    start = max(sampling.start_time_s, SETTLE_S)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        synthetic = synth_pivoted(sampling.rig, sampling.cam_speed_hz, law, duration, settle_s=start,
                                  sample_rate_hz=sampling.sample_rate_hz, mu=sampling.rig.mu,
                                  sensors=SensorModel(noise={"accel_tangential": fraction}, seed=seed),
                                  channels=("accel_tangential",))
        try:
            recon = reconstruct(synthetic.recording, find_events(synthetic.recording, warn=False),
                                integration=integration, anchor=anchor, warn=False)
        except Exception:  # noqa: BLE001 - a calibration that cannot run leaves the estimate as it is
            return PipelineBias(math.nan, math.nan, 0)
    apex_t = np.asarray(synthetic.truth["apexes"]["t"], dtype=float)
    apex_a = np.asarray(synthetic.truth["apexes"]["alpha"], dtype=float)
    errors = []
    for _, row in recon.table.iterrows():
        later = np.flatnonzero((apex_t > row["t_onset"]) & (apex_t < row["t_next"]))
        if later.size:
            true = float(np.max(apex_a[later]))
            errors.append(row["alpha_m"] / true - 1.0)
    errors = np.asarray(errors)
    errors = errors[np.isfinite(errors)]
    if errors.size < 2:
        return PipelineBias(math.nan, math.nan, int(errors.size))
    return PipelineBias(float(np.mean(errors)), float(np.std(errors, ddof=1) / math.sqrt(errors.size)),
                        int(errors.size))

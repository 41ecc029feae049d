"""The calibration's onset-state part (issue 26): the pipeline's bias of the cam phase, measured on the model's
own replay, is the bias a recording of the rig shows, and it is corrected only where the contacts are well
sampled."""

from __future__ import annotations

import math

import numpy as np
import pytest

from impactid import SUNDAR2016, HuntCrossley
from impactid.events import find_events
from impactid.rigs.pivoted.calibration import MIN_PHASE_SAMPLES, PipelineBias, RecordingSampling, pipeline_bias
from impactid.rigs.pivoted.reconstruct import reconstruct
from impactid.rigs.pivoted.residuals import EventSet
from impactid.rigs.pivoted.synth import synth_pivoted
from impactid.synth import SensorModel

# an envelope point whose tensile Hunt-Crossley tail leaves a cam-phase bias of about -2e-4 rad noise-free
RIG = SUNDAR2016.with_eccentricity_ratio(0.0571)
CAM_SPEED_HZ = 18.5
LAW = HuntCrossley(8.067e10, 1.3629)


def _phase_error(recon, truth, cam_speed_hz: float) -> float:
    """The reconstruction's cam phase against the recording's truth [rad] (the test's check, not the estimator's)."""
    tab = recon.table
    theta = tab["theta_onset"].to_numpy(float) - truth["theta_ref"] - 2 * math.pi * cam_speed_hz * tab["t_onset"]
    return float(np.nanmedian(np.angle(np.exp(1j * theta.to_numpy(float)))))


@pytest.mark.slow
def test_the_replay_measures_the_recordings_cam_phase_bias():
    """A noise-free recording (settled 60 s: other sample alignments than the replay's, which starts at 40 s)
    and the calibration at its law: the replay's phase bias is the recording's to within 10 % (measured 7 %),
    significant, and correcting the recording by it leaves less than a fifth of its phase error. (At a law
    20 % off in beta the replay gives -2.7e-4 rad against the recording's -2.1e-4.)"""
    made = synth_pivoted(RIG, CAM_SPEED_HZ, LAW, 1.0, settle_s=60.0, sensors=SensorModel(adc_bits=24, seed=3),
                         channels=("accel_tangential",))
    recon = reconstruct(made.recording, find_events(made.recording, warn=False), integration="rk", anchor="cam-phase",
                        warn=False)
    actual = _phase_error(recon, made.truth, CAM_SPEED_HZ)
    assert abs(actual) > 5e-5  # the case has a bias to calibrate
    bias = pipeline_bias(RecordingSampling.of(made.recording), LAW)
    assert bias.phase_significant
    assert bias.cam_phase == pytest.approx(actual, rel=0.1)
    es = EventSet.from_reconstruction(recon)
    corrected = es.shift_phase(-bias.cam_phase)
    moved = float(np.median(corrected.states[:, 2] - es.states[:, 2]))
    assert abs(actual + moved) < 0.2 * abs(actual)
    # the contacts are well sampled here, so the estimator would correct it
    assert np.nanmedian(es.contact_duration) * es.sample_rate_hz >= MIN_PHASE_SAMPLES
    # after the correction, the replay's alpha_m bias left is what the onset phase did not explain
    assert math.isfinite(bias.alpha_m_at_phase) and abs(bias.alpha_m_at_phase) < abs(bias.alpha_m)


def test_a_phase_bias_within_two_standard_errors_is_not_significant():
    assert not PipelineBias(1e-4, 1e-5, 64, cam_phase=1e-3, cam_phase_stderr=6e-4).phase_significant
    assert PipelineBias(1e-4, 1e-5, 64, cam_phase=-1e-3, cam_phase_stderr=4e-4).phase_significant
    assert not PipelineBias(1e-4, 1e-5, 64).phase_significant  # no phase measured (another anchor)
    record = PipelineBias(1e-4, 1e-5, 64, cam_phase=1e-3, cam_phase_stderr=1e-4).to_dict()
    assert {"alpha_m", "stderr", "events", "cam_phase", "cam_phase_stderr", "alpha_m_at_phase"} <= set(record)

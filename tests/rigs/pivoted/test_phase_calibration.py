"""The calibration's cam-phase bias of noise-free, unfiltered recordings (docs/estimation.md, "The cam phase of
noise-free recordings").

At 16 Hz and 204.8 kHz a revolution is 12 800 samples, so every onset of period-1 motion falls at the same place
between two samples, and the onset detector's error there (a few hundredths of a sample) is the same at every impact:
the cam-phase anchor turns it into a phase error of tens of its standard errors. The recording is impactid's generator
(noise-free, without an ADC: the 60 s benchmark recording's sampling); the truth is read only to score.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import fields, replace

import numpy as np
import pandas as pd
import pytest

from impactid import SUNDAR2016, HuntCrossley
from impactid.pipeline import Pipeline, estimate
from impactid.rigs.pivoted import damping, estimation
from impactid.rigs.pivoted.calibration import NOISE_FREE_FRACTION, RecordingSampling, pipeline_bias
from impactid.rigs.pivoted.reconstruct import reconstruct
from impactid.rigs.pivoted.synth import synth_pivoted
from impactid.synth import SensorModel

LAW = HuntCrossley(2.47e10, 1.5)
CAM_HZ = 16.0


@pytest.fixture(scope="module")
def recording():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return synth_pivoted(SUNDAR2016, CAM_HZ, LAW, 1.0, settle_s=40.0, sensors=SensorModel(),
                             channels=("accel_tangential",)).recording


def _phase_error(recon, recording) -> float:
    true_phase = 2.0 * math.pi * CAM_HZ * recording.start_time_s
    return float(math.remainder(recon.cam_phase - true_phase, 2.0 * math.pi))


def _sampling(recon, recording) -> RecordingSampling:
    return RecordingSampling.of(recording, recon.events.noise_sigma, band_limited=recon.band_limited,
                                onset_time_s=float(recon.table["t_onset"].iloc[0]))


def test_the_calibration_reproduces_a_noise_free_phase_bias(recording):
    """The model's recording, sampled with its first onset where the measurement's falls, has the measurement's
    phase error to a fraction of itself (here -4.32e-5 rad against -4.68e-5, 22 of its standard errors; the 60 s
    benchmark recording: -4.32e-5 against -4.50e-5)."""
    recon = reconstruct(recording, anchor="cam-phase", warn=False)
    actual = _phase_error(recon, recording)
    assert not recon.band_limited
    assert abs(actual) > 4.0 * recon.cam_phase_stderr  # a bias the interval would not hold
    sampling = _sampling(recon, recording)
    assert sampling.noise_fraction < NOISE_FREE_FRACTION and math.isfinite(sampling.onset_fraction)
    bias = pipeline_bias(sampling, LAW)
    assert bias.phase_measured
    assert abs(bias.phase - actual) < 0.15 * abs(actual), (bias.phase, actual)
    # the same bias at a law 0.5 % away: measured once, not iterated with the law
    moved = pipeline_bias(sampling, HuntCrossley(1.005 * LAW.beta, LAW.n))
    assert abs(moved.phase - bias.phase) < 0.1 * abs(bias.phase), (moved.phase, bias.phase)


def test_no_phase_bias_without_the_measurement_s_onset(recording):
    """Unaligned, the bias is anything between -0.55e-5 and -4.3e-5 rad as the onset moves between two samples
    (at 16 Hz every onset falls at the same place): it is not measured then, nor corrected."""
    recon = reconstruct(recording, anchor="cam-phase", warn=False)
    unaligned = replace(_sampling(recon, recording), onset_fraction=math.nan)
    assert not pipeline_bias(unaligned, LAW).phase_measured


def test_a_noisy_recording_gets_no_phase_calibration(recording):
    recon = reconstruct(recording, anchor="cam-phase", warn=False)
    noisy = replace(_sampling(recon, recording), noise_fraction=10.0 * NOISE_FREE_FRACTION)
    assert not pipeline_bias(noisy, LAW).phase_measured


def test_the_estimate_corrects_the_noise_free_phase(recording):
    """The fit with the phase corrected keeps the truth in its interval and says what it corrected: beta -1.8e-5
    relative (without the calibration: +1.3e-4)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = estimate([recording], fix_n=LAW.n)
    record = result.calibration[0]
    assert "phase" in record
    assert any("cam-phase bias of the onsets" in w and "noise-free" in w for w in result.warnings)
    low, high = result.damping.beta_interval
    assert low <= LAW.beta <= high
    assert abs(result.damping.beta / LAW.beta - 1.0) < 5e-5


def test_a_refitted_first_fit_is_not_finished(recording, monkeypatch):
    """The phase correction refits: the first fit's intervals and checks, which the refit's replace, are not
    computed (one least_squares_estimate, the refit's); the search alone gives the law the bias is measured at."""
    finished = []
    original = damping.least_squares_estimate

    def counting(problem, obj, fit, notes):
        finished.append(problem.systematic)
        return original(problem, obj, fit, notes)

    monkeypatch.setattr(damping, "least_squares_estimate", counting)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = estimate([recording], fix_n=LAW.n)
    assert "phase" in result.calibration[0]
    assert len(finished) == 1
    assert finished[0] > 0.0  # the refit's: its systematic error carries the correction


def test_without_a_correction_the_calibrated_estimate_is_the_first_fit(recording):
    """A calibration that corrects nothing (here, told not to by a threshold no bias reaches) finishes the first
    fit: the same estimate, intervals and checks as the fit without a calibration."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        plain = estimate([recording], fix_n=LAW.n, calibrate=False)
        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(estimation, "_corrections", lambda biases: ([False] * len(biases), [False] * len(biases)))
            calibrated = estimate([recording], fix_n=LAW.n)
    differing = []
    for item in fields(plain.damping):
        a, b = getattr(calibrated.damping, item.name), getattr(plain.damping, item.name)
        if item.name == "seconds":
            continue
        if isinstance(a, pd.DataFrame):
            same = a.equals(b)
        elif isinstance(a, np.ndarray):
            same = np.array_equal(a, b, equal_nan=True)
        else:
            same = a == b or (isinstance(a, float) and math.isnan(a) and math.isnan(b))
        if not same:
            differing.append(item.name)
    assert not differing


def test_a_search_is_finished_once(recording):
    """Finishing a search twice would add its notes and simulations twice: refused."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sets = Pipeline(model="pivoted-follower", fix_n=LAW.n).prepare(recording).data.event_set
        search = damping.start_contact_damping(sets, fix_n=LAW.n, warn=False)
        damping.finish_contact_damping(search)
    with pytest.raises(ValueError, match="finished already"):
        damping.finish_contact_damping(search)

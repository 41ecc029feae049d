"""Sensor models: noise and quantisation statistics, offset and drift, decimation, encoders."""

from __future__ import annotations

import math

import numpy as np
import pytest

from impactid import SUNDAR2016, HuntCrossley
from impactid.io import RecordingWarning
from impactid.rigs.pivoted.synth import synth_pivoted
from impactid.synth import SensorModel
from impactid.synth.sensors import antialias_decimate, apply_sensors, encoder_counts, quantise

RIG = SUNDAR2016.with_eccentricity_ratio(0.25)
LAW = HuntCrossley(24.7e9, 1.5)


@pytest.fixture(scope="module")
def clean():
    return synth_pivoted(RIG, 15.0, LAW, 1.0, settle_s=5.0)


def test_noise_has_the_requested_standard_deviation(clean):
    noisy = synth_pivoted(RIG, 15.0, LAW, 1.0, settle_s=5.0, sensors=SensorModel(noise=0.005, seed=11))
    for name in ("accel_tangential", "force_x", "force_y"):
        residual = noisy.recording[name] - clean.recording[name]
        sigma = 0.005 * np.max(np.abs(clean.recording[name]))
        n = residual.size
        # sample std of n Gaussian draws has relative standard error 1/sqrt(2n) ~ 0.16 %: 1 % is > 6 sigma
        assert np.std(residual) == pytest.approx(sigma, rel=0.01)
        assert abs(np.mean(residual)) < 5 * sigma / math.sqrt(n)
        assert noisy.truth["applied"][name]["noise_sigma"] == pytest.approx(sigma)
    assert np.array_equal(noisy.recording["cam_angle"], clean.recording["cam_angle"])  # encoders are not noisy


def test_quantisation_statistics_and_saturation():
    rng = np.random.default_rng(5)
    x = rng.uniform(-0.9, 0.9, 200_000)
    q, lsb = quantise(x, 12, 1.0)
    assert lsb == 2.0 / 4096
    codes = q / lsb
    assert np.array_equal(codes, np.round(codes))
    err = q - x
    assert np.max(np.abs(err)) <= lsb / 2 * (1 + 1e-12)
    assert np.std(err) == pytest.approx(lsb / math.sqrt(12), rel=0.01)  # uniform rounding error
    sat, _ = quantise(np.array([-5.0, 5.0]), 12, 1.0)
    assert sat[0] == -1.0 and sat[1] == 1.0 - lsb


def test_adc_range_below_peak_clips_the_accelerometer(clean):
    peak = np.max(np.abs(clean.recording["accel_tangential"]))
    syn = synth_pivoted(RIG, 15.0, LAW, 1.0, settle_s=5.0,
                        sensors=SensorModel(adc_bits=16, adc_range={"accel_tangential": 0.5 * peak}))
    assert syn.truth["applied"]["accel_tangential"]["saturated_samples"] > 0
    with pytest.warns(RecordingWarning, match="looks clipped: 295 samples at its maximum") as record:
        syn.recording.check()  # the recording itself says it is clipped
    assert len(record) == 1  # the quantised free-flight plateau at the minimum is not called clipped


def test_offset_and_drift_are_exact(clean):
    syn = synth_pivoted(RIG, 15.0, LAW, 1.0, settle_s=5.0, sensors=SensorModel(accel_offset=2.5, accel_drift=-0.4))
    t = np.arange(syn.recording.n_samples) / syn.recording.sample_rate_hz
    diff = syn.recording["accel_tangential"] - clean.recording["accel_tangential"]
    assert np.allclose(diff, 2.5 - 0.4 * t, rtol=0, atol=1e-9)
    assert np.array_equal(syn.recording["force_x"], clean.recording["force_x"])


def test_decimation_keeps_sample_instants_and_the_in_band_signal(clean):
    syn = synth_pivoted(RIG, 15.0, LAW, 1.0, settle_s=5.0, sensors=SensorModel(decimation=4))
    assert syn.recording.n_samples == clean.recording.n_samples
    assert np.array_equal(syn.recording.time, clean.recording.time)
    assert np.array_equal(syn.recording["cam_angle"], clean.recording["cam_angle"])
    # a longer run (the filter margin) ends with different final steps: equal to the integrator tolerance
    assert np.allclose(syn.truth["alpha"], clean.truth["alpha"], rtol=0, atol=1e-10)
    # the contact pulses (a few hundred us) lie mostly below the 102 kHz Nyquist limit: what the
    # filter removes is small, and low-pass filtering both to 20 kHz makes them agree closely
    from scipy import signal

    sos = signal.butter(8, 20_000, fs=204_800, output="sos")
    a = signal.sosfiltfilt(sos, syn.recording["accel_tangential"])
    b = signal.sosfiltfilt(sos, clean.recording["accel_tangential"])
    peak = np.max(np.abs(b))
    assert np.max(np.abs(a - b)[200:-200]) < 1e-3 * peak


def test_antialias_filter_rejects_out_of_band_tone():
    fs = 8.0 * 1000
    t = np.arange(8000) / fs
    tone = np.sin(2 * np.pi * 3000 * t)  # above the 500 Hz output Nyquist frequency at factor 8
    out = antialias_decimate(tone, 8)
    assert np.max(np.abs(out[20:-20])) < 0.01


def test_encoder_counts():
    angle = np.linspace(0, 4 * np.pi, 100_001)
    counts = encoder_counts(angle, 5000, zero=0.3)
    step = 2 * np.pi / 5000
    assert np.allclose(np.round(counts / step), counts / step, atol=1e-9)
    err = (angle - 0.3) - counts
    assert np.all(err >= -1e-12) and np.all(err < step + 1e-12)


def test_random_stream_independent_of_channel_order():
    a = {"force_x": np.ones(100), "force_y": np.ones(100)}
    b = {"force_y": np.ones(100), "force_x": np.ones(100)}
    m = SensorModel(noise=0.1, seed=1)
    out_a, _ = apply_sensors(a, 1000.0, m)
    out_b, _ = apply_sensors(b, 1000.0, m)
    assert np.array_equal(out_a["force_x"], out_b["force_x"])

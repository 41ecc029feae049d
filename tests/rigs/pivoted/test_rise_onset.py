"""The onset of a resolved contact pulse from the Hunt–Crossley head model (reconstruct._fit_rise_onset)."""

from __future__ import annotations

import numpy as np
import pytest

from impactid import SUNDAR2016
from impactid.events import _subsample_start
from impactid.rigs.pivoted.reconstruct import (
    HEAD_MODEL_LEVER,
    HEAD_MODEL_SUBSTEPS,
    RISE_MODEL_EXPONENT_TOLERANCE,
    _fit_rise_onset,
    _head_model,
    _rise_exponent,
)


def _pulse(offset: float, exponent: float, damping_share: float, noise: float = 0.0):
    """Samples of a Hunt–Crossley impact on a sloped free-flight baseline whose onset lies ``offset`` samples
    before sample 100 (unit sampling interval of 1/204800 s), with the damping term ``damping_share`` times the
    Hertz term one sample into the contact; and its true onset [samples]."""
    dt = 1.0 / 204800.0
    k0, samples = 100, 300
    v0 = 0.4
    a_coef = HEAD_MODEL_LEVER * SUNDAR2016.k_H / SUNDAR2016.I_b
    b_coef = damping_share * a_coef * (v0 * dt) ** (1.5 - exponent) / v0
    times = (np.arange(samples) - k0) * dt
    acc, rate = np.empty(samples), np.empty(samples)
    _head_model(-offset * dt, v0, a_coef, b_coef, exponent, HEAD_MODEL_LEVER, times, 4 * HEAD_MODEL_SUBSTEPS,
                acc, rate)
    baseline = 30.0 + 2.0e3 * times
    rng = np.random.default_rng(1)
    return acc + baseline + noise * rng.standard_normal(samples), k0 - offset


@pytest.mark.parametrize("offset", [0.15, 0.5, 0.85])
def test_damping_dominated_rise_gives_the_onset(offset):
    """n < 1.5 with a large beta: the damping term dominates the first samples 20 times. A single power law
    through the first three contact samples (the event detector's) puts the onset late; the head model finds it."""
    angular, true_onset = _pulse(offset, 1.36, 20.0)
    dev = angular - (30.0 + 2.0e3 * (np.arange(angular.size) - 100) / 204800.0)
    three = _subsample_start(dev[100:103], 100, +1)
    assert three - true_onset > 0.01  # the bias the refinement removes
    onset, law = _fit_rise_onset(angular, 100, three, 250.0, 1.0 / 204800.0, SUNDAR2016, 1e-6)
    assert onset is not None
    assert abs(onset - true_onset) < 2e-3
    assert abs(_rise_exponent(angular, 100, three, 1e-6) - 1.5) > RISE_MODEL_EXPONENT_TOLERANCE  # refined
    # started from another pulse's fitted law (a recording's pulses share it): the same onset
    other, _ = _pulse(1.0 - offset, 1.36, 20.0)
    again, _ = _fit_rise_onset(other, 100, _subsample_start(other[100:103] - (30.0 + 2.0e3 * np.arange(3) / 204800.0),
                                                            100, +1), 250.0, 1.0 / 204800.0, SUNDAR2016, 1e-6, law)
    assert again is not None and abs(again - (100 - (1.0 - offset))) < 2e-3


def test_hertzian_rise_is_kept_and_noise_is_left_to_the_detector():
    """n above 1.5 (a Hertz-dominated rise): the onset agrees with the power law's; a rise within EDGE_SNR
    noise floors of the noise: no refinement (None)."""
    angular, true_onset = _pulse(0.4, 1.7, 0.05)
    onset, _ = _fit_rise_onset(angular, 100, 99.6, 250.0, 1.0 / 204800.0, SUNDAR2016, 1e-6)
    assert onset is not None and abs(onset - true_onset) < 2e-3
    # such a rise is one power law at first: its exponent is Hertz's, and a recording of them is not refined
    assert abs(_rise_exponent(angular, 100, 99.6, 1e-6) - 1.5) <= RISE_MODEL_EXPONENT_TOLERANCE
    noisy, _ = _pulse(0.4, 1.36, 20.0, noise=1.0)
    assert _fit_rise_onset(noisy, 100, 99.6, 250.0, 1.0 / 204800.0, SUNDAR2016, 1e3) == (None, None)
    assert _rise_exponent(noisy, 100, 99.6, 1e3) is None
    # noise above the misfit the model must reach (1e-4 of the peak) but below the edge's 20 floors: not fitted
    assert _fit_rise_onset(noisy, 100, 99.6, 250.0, 1.0 / 204800.0, SUNDAR2016, 20.0) == (None, None)
    assert _rise_exponent(angular, 100, float("nan"), 1e-6) is None


def test_a_window_past_the_pulse_is_no_error():
    """At a low sampling rate the head model's 16 samples can reach past a short pulse (its last samples below
    the baseline): the starts that would need a negative damping coefficient are skipped, not a math error."""
    angular, true_onset = _pulse(0.4, 1.36, 20.0)
    angular[115] = 30.0 - 1.0e4  # the window's last sample below the baseline (the pulse's area stays positive)
    onset, law = _fit_rise_onset(angular, 100, 99.6, 250.0, 1.0 / 204800.0, SUNDAR2016, 1e-6)
    assert (onset is None) == (law is None)

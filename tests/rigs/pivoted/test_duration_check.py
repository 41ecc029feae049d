"""The contact-duration check measures the replayed contacts as the recording's were measured
(impactid/rigs/pivoted/damping_diagnostics.py: detected_durations).

The event detector cuts a noisy contact short (it sees a contact only where it rises above the noise), so a
law's simulated contacts are longer than the measured ones by an amount that grows with the noise. Replayed
through the same detector with the same noise, the right law's contacts measure as the recording's do.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

import impactid.rigs.pivoted.damping_diagnostics as check
from impactid import SUNDAR2016, HuntCrossley
from impactid.events import find_events
from impactid.io import Recording
from impactid.rigs.pivoted.damping_diagnostics import CONTACT_DURATION_MISMATCH, detected_durations
from impactid.rigs.pivoted.reconstruct import reconstruct
from impactid.rigs.pivoted.residuals import EventSet
from impactid.rigs.pivoted.synth import synth_pivoted
from impactid.synth import SensorModel

RATE = 204800.0
DURATION = 3e-4  # a Hertz-like contact of 0.3 ms: 61 samples
PEAK = 2000.0  # [m/s^2]


def _pulses(count: int, phase: float = 0.4):
    """Per event, sample instants from the onset [s] and a half-sine^1.5 contact force on them [N]."""
    dt = 1.0 / RATE
    grids, forces = [], []
    for k in range(count):
        t = (phase + 0.05 * k) * dt + dt * np.arange(int(2 * DURATION * RATE))
        grids.append(t)
        forces.append(np.where(t < DURATION, np.sin(np.pi * np.minimum(t, DURATION) / DURATION) ** 1.5, 0.0) * 7.0)
    return grids, forces


def _recorded_durations(forces, sigma: float, seed: int) -> np.ndarray:
    """The durations the detector measures on a 'recording' of the same pulses (its own noise realisation)."""
    gap = 2000
    x = np.zeros(gap + len(forces) * (gap + forces[0].size))
    for k, f in enumerate(forces):
        start = gap + k * (gap + f.size)
        x[start:start + f.size] = f * PEAK / f.max()
    x += np.random.default_rng(seed).normal(0.0, sigma, x.size)
    table = find_events(Recording({"accel_tangential": x}, RATE, {"accel_tangential": "m/s^2"}), warn=False).table
    return (table["t_separation"] - table["t_onset"]).to_numpy()


def test_noise_free_replay_measures_the_contact_itself():
    grids, forces = _pulses(8)
    got = detected_durations(forces, grids, np.full(8, PEAK), 0.0, RATE)
    assert np.all(np.abs(got - DURATION) < 1.5 / RATE)


@pytest.mark.parametrize("noise", [0.03, 0.06])
def test_noisy_replay_is_cut_short_like_the_recording(noise):
    grids, forces = _pulses(12)
    sigma = noise * PEAK
    replayed = detected_durations(forces, grids, np.full(12, PEAK), sigma, RATE)
    recorded = _recorded_durations(forces, sigma, seed=7)
    assert recorded.size == 12
    # the simulated contact is longer than the measured one, the replay is not: like with like
    shortfall = float(np.median(1.0 - recorded / DURATION))
    assert shortfall > 0.05
    assert abs(float(np.median(replayed)) / float(np.median(recorded)) - 1.0) < 0.05
    assert float(np.median(np.abs(replayed / recorded - 1.0))) < CONTACT_DURATION_MISMATCH / 5


def test_a_replay_that_fails_is_nan_and_one_without_contact_is_zero():
    grids, forces = _pulses(3)
    forces[1] = np.full(1, math.nan)
    grids[1] = grids[1][:1]
    forces[2] = np.zeros_like(forces[2])
    got = detected_durations(forces, grids, np.full(3, PEAK), 1.0, RATE)
    assert math.isfinite(got[0]) and got[0] > 0.0
    assert math.isnan(got[1]) and got[2] == 0.0


@pytest.fixture(scope="module")
def long_contacts():
    """A nearly plastic law's period-1 recording (restitution about 0.002, contacts of 4.3 ms; impactid's generator,
    noise-free) and its event set."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        synthetic = synth_pivoted(SUNDAR2016.with_eccentricity_ratio(0.15), 13.0, NEAR_PLASTIC, 1.0, settle_s=40.0,
                                  sensors=SensorModel(adc_bits=24), channels=("accel_tangential",))
        return EventSet.from_reconstruction(reconstruct(synthetic.recording, anchor="cam-phase", warn=False))


NEAR_PLASTIC = HuntCrossley(1e11, 1.2)


def test_a_noise_free_recording_takes_a_simulated_contact_that_lasts_as_measured(long_contacts, monkeypatch):
    """The replay lays the contact force alone on a quiet flight; the envelope case np12 (the independent reference's
    recording) lost its low tail there (0.12 ms replayed, 4.34 ms measured, 4.38 ms simulated) and the check
    rejected the true law. In a noise-free recording no noise cuts the contact's ends: a simulated contact that
    lasts as measured agrees. In a noisy one the replay alone decides."""
    real = check.detected_durations
    monkeypatch.setattr(check, "detected_durations", lambda *a, **k: 0.03 * real(*a, **k))  # the tail lost
    block = check.contact_duration_check(SimpleNamespace(sets=[long_contacts]), NEAR_PLASTIC.beta, NEAR_PLASTIC.n)
    assert block["measured_median_s"] > 4e-3
    assert block["verdict"] == "consistent", block
    noisy = replace(long_contacts, noise_sigma=1e-3 * float(np.nanmax(long_contacts.pulse_peak)))
    block = check.contact_duration_check(SimpleNamespace(sets=[noisy]), NEAR_PLASTIC.beta, NEAR_PLASTIC.n)
    assert block["verdict"] == "rejected", block


def test_a_long_recording_is_checked_on_a_subsample(long_contacts, monkeypatch):
    monkeypatch.setattr(check, "DURATION_CHECK_EVENTS", 5)
    block = check.contact_duration_check(SimpleNamespace(sets=[long_contacts]), NEAR_PLASTIC.beta, NEAR_PLASTIC.n)
    assert len(long_contacts) > 5 and block["events"] == 5 and block["simulations"] == 5


def test_the_subsample_holds_both_branches_of_a_period_two_motion():
    """Evenly spaced single events of 255 are all even (one branch of a period-2 motion); the blocks are not."""
    for count in (129, 255, 509, 959):
        picked = check._check_events(count)
        assert picked.size == check.DURATION_CHECK_EVENTS and picked.min() == 0 and picked.max() == count - 1
        assert 0 < int(np.sum(picked % 2 == 0)) < picked.size

"""The event detector on long, low contact tails and on the motion's pattern (impactid.events).

Synthetic signals whose truth is exact: a cubic free flight with a pulse and a low tail (the tensile
tail of a nearly plastic Hunt–Crossley contact, or a follower riding the cam), and onset times of
period-1, period-k and irregular motion.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from scipy import optimize

import impactid.events as events_module
from impactid import SUNDAR2016, HuntCrossley
from impactid.events import (
    BASELINE_GAP,
    MAX_PATTERN_EVENTS,
    PERIOD_TOLERANCE,
    _contact_end,
    _fit_onset,
    _motion_pattern,
    find_events,
)
from impactid.rigs.pivoted.synth import synth_pivoted
from impactid.synth import SensorModel

RATE = 204_800.0


def _free_flight(n: int) -> np.ndarray:
    """A smooth free-flight acceleration [m/s^2]: rig P's is a few m/s^2 varying over tens of ms."""
    t = np.arange(n) / RATE
    return -3.2 - 40.0 * t + 300.0 * t ** 2 - 900.0 * t ** 3


@pytest.mark.parametrize("tail_ms, sign", [(2.5, -1.0), (4.0, -1.0), (3.0, +1.0)])
def test_the_contact_ends_where_the_low_tail_joins_the_free_flight(tail_ms, sign):
    """A tail of a few m/s^2 that a 64-sample quadratic follows (the local baseline's separation lies 2.5 to
    4 ms early) ends at its last sample above the threshold: a tensile tail (sign -1, ``n < 1.5``) or a
    compressive one (+1). (A ride on the cam of tens of ms is smooth over the long baseline too: the
    reconstruction's force balance finds its end, tests/rigs/pivoted/test_general_motion.py.)"""
    x = _free_flight(40_000)
    ka_local = 30  # where the local baseline put the separation: just after the pulse's core
    end = ka_local + int(round(tail_ms * 1e-3 * RATE))
    k = np.arange(ka_local - 1, end)
    # the tail falls to zero like (t_end - t)^1.2 (the damping term of the law at the reopening gap)
    tail = 6.0 * ((end - k) / (end - ka_local)) ** 1.2
    x[k] += sign * tail
    threshold = 1e-2
    found, baseline = _contact_end(x, ka_local, threshold, threshold, x.size, RATE, threshold)
    assert baseline is not None
    assert found == k[np.flatnonzero(tail > threshold)[-1]] + 1  # the first sample within the threshold
    assert end - found <= 3
    free = np.arange(end + BASELINE_GAP, end + 2000)
    assert np.max(np.abs(x[free] - baseline(free))) < 1e-6


def test_no_tail_keeps_the_local_separation():
    """Free flight right after the separation: nothing moves (the clean period-1 contacts keep their numbers)."""
    x = _free_flight(20_000)
    found, baseline = _contact_end(x, 30, 1e-2, 1e-2, x.size, RATE, 1e-2)
    assert found == 30 and baseline is None


def test_noise_alone_is_not_a_tail():
    """White noise at the detection threshold's sixth: no false tail over a hundred contacts."""
    rng = np.random.default_rng(3)
    sigma = 0.05
    moved = 0
    for _ in range(100):
        x = _free_flight(3000) + rng.normal(0.0, sigma, 3000)
        found, baseline = _contact_end(x, 30, 5 * sigma, 6 * sigma / 4, x.size, RATE, 6 * sigma)
        moved += baseline is not None
    assert moved == 0


def _onsets(phases_in_revolution, revolutions_per_period, periods, frequency=16.0, jitter=0.0, seed=0):
    """Onset times [s] of periodic motion: ``phases`` are the impacts' cam phases (in revolutions from the
    period's start) within one period of ``revolutions_per_period`` revolutions."""
    rng = np.random.default_rng(seed)
    t = [(p + revolutions_per_period * k) / frequency for k in range(periods) for p in phases_in_revolution]
    return np.array(t) + rng.normal(0.0, jitter, len(t))


@pytest.mark.parametrize("phases, k", [([0.03], 1), ([0.85], 2), ([0.01, 0.31], 2), ([0.12, 1.71], 3),
                                       ([0.65, 0.79, 0.90], 2), ([0.77, 1.74, 2.91], 4)])
def test_the_pattern_is_read_from_the_onsets(phases, k):
    """Period-1, one impact every other revolution, two alternating impacts, and longer patterns; onsets
    jittered by a tenth of a sample (the detector's accuracy)."""
    t = _onsets(phases, k, periods=8, jitter=0.1 / RATE)
    m, revolutions, recurs = _motion_pattern(t, 16.0)
    assert (m, revolutions) == (len(phases), k)
    assert recurs[: t.size - m].all() and not recurs[t.size - m:].any()


def test_irregular_onsets_have_no_pattern():
    rng = np.random.default_rng(11)
    t = np.cumsum(rng.uniform(0.3, 1.7, 24)) / 16.0
    m, k, recurs = _motion_pattern(t, 16.0)
    assert (m, k) == (0, 0) and not recurs.any()


def test_a_transient_event_does_not_break_the_pattern():
    """One onset displaced by 5 % of a revolution (a transient): the pattern stands, that onset does not recur."""
    t = _onsets([0.2], 1, periods=16)
    t[5] += 0.05 / 16.0
    m, k, recurs = _motion_pattern(t, 16.0)
    assert (m, k) == (1, 1)
    assert not recurs[4] and not recurs[5] and recurs[[0, 1, 2, 3, 6, 7]].all()


def test_the_tolerance_is_a_hundredth_of_a_revolution():
    """Two impacts whose spacings differ from a whole revolution by 2 % do not make period-1 motion."""
    assert PERIOD_TOLERANCE == 0.01
    t = _onsets([0.0, 0.49], 1, periods=10)  # two impacts a revolution: period-1 with m = 2
    assert _motion_pattern(t, 16.0)[:2] == (2, 1)
    drift = np.arange(12) * 1.02 / 16.0  # each revolution 2 % long: not periodic with the cam
    assert _motion_pattern(drift, 16.0)[0] == 0
    assert MAX_PATTERN_EVENTS >= 4 and math.isfinite(PERIOD_TOLERANCE)


# ---- the batched onset fit against SciPy's, event by event ------------------------------------------


def _profile_cost(x: np.ndarray, baseline, k0: int, peak: float, t0: float) -> float:
    """Least-squares cost of ``c (k - t0)^p`` to the rise with ``t0`` [samples] held and ``c, p`` at their
    best (SciPy, tolerances 1e-15): the cost of the onset ``t0`` whatever the fit's other parameters."""
    span = np.arange(max(k0 - 6, 0), min(k0 + 40, x.size))
    dev = x[span] - baseline(span)
    high = np.flatnonzero(dev > 0.3 * peak)
    span, dev = span[: high[0] + 1], dev[: high[0] + 1]
    fit = optimize.least_squares(lambda q: q[0] * np.power(np.maximum(span - t0, 0.0), q[1]) - dev,
                                 [max(dev[-1], 1e-9) / max(span[-1] - t0, 1.0) ** 1.5, 1.5],
                                 bounds=([0.0, 1.0], [np.inf, 3.0]), xtol=1e-15, ftol=1e-15, gtol=1e-15)
    return float(fit.cost)


@pytest.mark.parametrize("noise, adc_bits", [(0.002, 24), (0.005, 24), (0.02, None)])
def test_the_batched_onset_fits_reach_scipys_minimum(monkeypatch, noise, adc_bits):
    """On a noisy synthetic recording of rig P (1 s at 204.8 kHz, 16 impacts, e/r_c 0.2, 16 Hz), every
    noisy onset of the batched fit (:func:`impactid.events._fit_onsets`) is SciPy's per-event
    ``least_squares`` (:func:`impactid.events._fit_onset`) to within SciPy's own stopping rule, and no
    worse a fit.

    Tolerance: SciPy's trf stops when its step falls below ``xtol (xtol + |x|)`` with ``xtol`` 1e-8
    and ``|x|`` at least ``t0`` (the sample index ``k0``, up to 2e5 here), so its onset is known to
    ``1e-8 |x|`` samples (the last step; measured at 0.2 and 0.5 % noise: at most 2 % of it), where the
    batched fit iterates to 1e-12 of a sample. At 2 % noise the minimum is flat in ``t0`` (SciPy's last
    step then understates its distance to it: 2e-4 samples further down, the cost lower by 1e-8) and
    SciPy once stops on the bound ``p = 1`` at a worse minimum (0.85 samples away, cost 14 % higher):
    beyond the tolerance the batched fit's cost must be no higher (at most a quarter of the events).
    Everywhere its cost is at most SciPy's plus 1e-9 relative (the profile over ``c, p`` at each onset,
    :func:`_profile_cost`).
    """
    syn = synth_pivoted(SUNDAR2016.with_eccentricity_ratio(0.2), 16.0, HuntCrossley(24.7e9, 1.5), 1.0,
                        sensors=SensorModel(noise=noise, adc_bits=adc_bits, seed=3), channels=("accel_tangential",))
    captured = []
    batched = events_module._fit_onsets

    def spy(x, baselines, k0, peak, sigma, guess):
        out = batched(x, baselines, k0, peak, sigma, guess)
        captured.append((x, baselines, k0, peak, sigma, guess, out))
        return out

    monkeypatch.setattr(events_module, "_fit_onsets", spy)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        table_b = find_events(syn.recording, warn=False, onset_fit="batched").table
        table_s = find_events(syn.recording, warn=False, onset_fit="scipy").table
    assert len(captured) == 1
    x, baselines, k0, peak, sigma, guess, out = captured[0]
    assert k0.size >= 10  # the noise lifts the onset threshold: most onsets are fitted
    elsewhere = 0
    for b, k, p, g, t_batched in zip(baselines, k0, peak, guess, out):
        t_scipy = _fit_onset(x, b, int(k), float(p), sigma, float(g))
        cost_b = _profile_cost(x, b, int(k), float(p), t_batched)
        cost_s = _profile_cost(x, b, int(k), float(p), t_scipy)
        assert cost_b <= cost_s * (1.0 + 1e-9)  # never a worse fit
        if abs(t_batched - t_scipy) > 1e-8 * k:  # beyond SciPy's stop: further down a flat valley, or another
            assert cost_b <= cost_s                # minimum, never uphill
            elsewhere += 1
        print(f"k0 {k}: batched - scipy {t_batched - t_scipy:+.2e} samples, cost {cost_b / cost_s - 1.0:+.1e}")
    assert elsewhere <= k0.size // 4
    # the rest of the table is the same: the onsets differ by the fits alone
    assert table_b.drop(columns=["t_onset", "t_next", "spacing"]).equals(
        table_s.drop(columns=["t_onset", "t_next", "spacing"]))

"""The event detector on long, low contact tails and on the motion's pattern (impactid.events).

Synthetic signals whose truth is exact: a cubic free flight with a pulse and a low tail (the tensile
tail of a nearly plastic Hunt–Crossley contact, or a follower riding the cam), and onset times of
period-1, period-k and irregular motion.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from impactid.events import (
    BASELINE_GAP,
    MAX_PATTERN_EVENTS,
    PERIOD_TOLERANCE,
    _contact_end,
    _motion_pattern,
)

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

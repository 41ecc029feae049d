"""Rig F's encoder signals (impactid.rigs.flat.encoders): count step, counter conventions, edges, revolutions."""

from __future__ import annotations

import math

import numpy as np
import pytest

from impactid.rigs.flat.encoders import (
    COUNTERS,
    EncoderError,
    complete_revolutions,
    encoder_edges,
    encoder_step,
    local_linear,
    pulses_per_revolution,
    read_counter,
)

Q = 2 * math.pi / 1000  # count step of a 1000 ppr encoder [rad]
T = np.arange(400) / 1000.0  # 1 kHz sampling [s]
ANGLE = 0.003 + 1.7 * T + 0.4 * T * T  # smooth, forward [rad]
FLOOR = np.floor(ANGLE / Q) * Q


def test_encoder_step_and_edges_are_exact():
    assert encoder_step(FLOOR) == pytest.approx(Q, rel=1e-12)
    assert encoder_step(FLOOR + np.random.default_rng(1).normal(0, 1e-4, T.size)) is None
    assert encoder_step(0.3 + 1e-3 * np.arange(100)) is None  # exact uniform motion is on a grid, not counts
    times, values, index = encoder_edges(FLOOR, T, Q, "floor")
    # each edge is a count boundary crossed between the samples before and after it
    np.testing.assert_allclose(values / Q, np.round(values / Q), atol=1e-9)
    crossing = np.interp(values, ANGLE, T)  # the exact crossing times
    assert np.all((crossing > T[index - 1]) & (crossing <= T[index]))
    assert np.max(np.abs(times - crossing)) <= 0.5 / 1000.0 + 1e-12
    rounded = np.round(ANGLE / Q) * Q
    _, values_r, _ = encoder_edges(rounded, T, Q, "round")
    np.testing.assert_allclose(np.mod(values_r / Q, 1.0), 0.5, atol=1e-9)


def test_encoder_step_is_exactly_two_pi_over_ppr_and_none_for_too_few_changes():
    assert encoder_step(FLOOR) == 2 * math.pi / 1000  # snapped, not the smallest difference
    assert pulses_per_revolution(encoder_step(FLOOR)) == 1000
    assert pulses_per_revolution(None) is None
    assert pulses_per_revolution(2 * math.pi / 1000.4) is None
    assert encoder_step(np.array([0.1])) is None
    assert encoder_step(np.array([0.0, 0.0, Q])) is None  # one change: no step to compare with


def test_read_counter_adds_the_mean_offset_of_the_convention():
    floor = read_counter(FLOOR, "floor")
    assert floor.step == pytest.approx(Q) and floor.shift == pytest.approx(0.5 * Q)
    np.testing.assert_array_equal(floor.angle, FLOOR + 0.5 * Q)
    # the floor counter's reading plus half a count is unbiased: the mean error is below 1 % of a count
    assert abs(np.mean(floor.angle - ANGLE)) < 0.05 * Q
    assert "1000 counts/rev" in floor.describe("cam_angle") and "floor counter" in floor.describe("cam_angle")
    rounded = read_counter(FLOOR, "round")
    assert rounded.shift == 0.0 and rounded.step == pytest.approx(Q)
    none = read_counter(FLOOR, "none")
    assert none.step is None and none.shift == 0.0
    assert "counter 'none'" in none.describe("cam_angle")
    exact = read_counter(ANGLE, "floor")
    assert exact.step is None and "not quantised" in exact.describe("follower_angle")
    np.testing.assert_array_equal(exact.angle, ANGLE)
    with pytest.raises(EncoderError, match="unknown encoder counter 'ceil'"):
        read_counter(FLOOR, "ceil")
    with pytest.raises(EncoderError, match="need a 'floor' or 'round' counter"):
        encoder_edges(FLOOR, T, Q, "none")
    assert set(COUNTERS) == {"floor", "round", "none"}


def test_local_linear_recovers_a_line_through_noisy_edges():
    times = np.linspace(0.0, 1.0, 200)
    values = 2.0 + 3.0 * times + np.random.default_rng(2).uniform(-1e-3, 1e-3, times.size)
    query = np.array([0.1, 0.5, 0.9])
    np.testing.assert_allclose(local_linear(query, times, values, 16), 2.0 + 3.0 * query, atol=5e-4)
    exact = 2.0 + 3.0 * times
    np.testing.assert_allclose(local_linear(query, times, exact, 4), 2.0 + 3.0 * query, rtol=1e-13)


@pytest.mark.parametrize("direction", [1.0, -1.0])
def test_complete_revolutions_count_from_the_first_sample_either_way(direction):
    cam = 0.4 + direction * np.linspace(0.0, 3.5 * 2 * math.pi, 3501)
    revolutions = complete_revolutions(cam)
    assert len(revolutions) == 3 and revolutions.turns == pytest.approx(3.5)
    assert revolutions.travel[0] == 0.0 and revolutions.travel[-1] > 0.0
    for k, members in enumerate(revolutions.members):
        travel = revolutions.travel[members]
        assert np.all((travel >= 2 * math.pi * k) & (travel < 2 * math.pi * (k + 1)))
        assert np.all(np.diff(members) == 1)
    covered = np.concatenate(revolutions.members)
    assert covered.size == np.count_nonzero(revolutions.travel < 3 * 2 * math.pi)
    assert len(complete_revolutions(np.linspace(0.0, 6.0, 50))) == 0  # less than one revolution

"""The table-tennis rule's band: closed form in vacuum, higher with drag."""

import math

import pytest

from impactid.rigs.tracks import TABLE_TENNIS_BALL, rule_band
from impactid.rigs.tracks.rule import apex_height, impact_speed


def test_vacuum_band_is_the_square_root():
    ball = TABLE_TENNIS_BALL.with_(air_density=0.0)
    band = rule_band(ball)
    assert band.low == pytest.approx(math.sqrt(0.22 / 0.305), abs=1e-9)
    assert band.high == pytest.approx(math.sqrt(0.25 / 0.305), abs=1e-9)
    assert impact_speed(ball) == pytest.approx(math.sqrt(2 * ball.gravity * 0.305), rel=1e-10)


def test_drag_raises_the_band():
    band = rule_band(TABLE_TENNIS_BALL)
    assert 0.87 < band.low < 0.885 and 0.93 < band.high < 0.945  # measured 0.8776, 0.9373 at C_D 0.45
    assert band.drag_range[0] <= band.low and band.drag_range[1] >= band.high
    assert apex_height(TABLE_TENNIS_BALL, band.high * band.impact_speed) == pytest.approx(0.25, abs=1e-9)

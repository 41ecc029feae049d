import math

import pytest

from impactid.rigs.ball import BALL_PRESETS, GOLF, TABLE_TENNIS, TENNIS, Ball, BallParameterError, ball_preset


def test_presets_and_aliases():
    assert TABLE_TENNIS.mass == pytest.approx(2.7e-3) and TABLE_TENNIS.diameter == pytest.approx(0.040)
    assert GOLF.mass == pytest.approx(45.9e-3) and GOLF.diameter == pytest.approx(42.7e-3)
    assert TENNIS.mass == pytest.approx(57.5e-3) and TENNIS.diameter == pytest.approx(0.067)
    for name in ("pingpong", "ping-pong", "Table Tennis", "table_tennis"):
        assert ball_preset(name) is TABLE_TENNIS
    assert set(BALL_PRESETS) >= {"pingpong", "table-tennis", "golf", "tennis"}


def test_unknown_preset_lists_valid_names():
    with pytest.raises(ValueError, match="valid: .*golf"):
        ball_preset("football")


def test_derived_quantities():
    b = TABLE_TENNIS
    assert b.area == pytest.approx(math.pi * 0.02 ** 2)
    assert b.drag_constant == pytest.approx(0.5 * 1.204 * 0.42 * b.area)
    vt = math.sqrt((b.mass - b.displaced_air_mass) * b.gravity / b.drag_constant)
    assert b.terminal_speed == pytest.approx(vt)
    assert 8.0 < b.terminal_speed < 10.0  # a table-tennis ball falls at about 9 m/s
    assert b.displaced_air_mass / b.mass == pytest.approx(0.0149, rel=0.02)  # buoyancy 1.5 %
    assert Ball("x", 1.0, 0.1, drag_coefficient=0.0).terminal_speed == math.inf


@pytest.mark.parametrize("field,value", [("mass", 0.0), ("mass", -1.0), ("diameter", math.nan),
                                         ("drag_coefficient", -0.1), ("air_density", math.inf), ("gravity", 0.0)])
def test_bad_parameters_name_the_field(field, value):
    kwargs = {"name": "b", "mass": 0.01, "diameter": 0.03} | {field: value}
    with pytest.raises(BallParameterError, match=field):
        Ball(**kwargs)


def test_ball_lighter_than_air_refused():
    with pytest.raises(BallParameterError, match="lighter than the air"):
        Ball("balloon", mass=1e-4, diameter=0.1)


def test_with_revalidates():
    assert TABLE_TENNIS.with_(drag_coefficient=0.5).drag_coefficient == 0.5
    with pytest.raises(BallParameterError):
        TABLE_TENNIS.with_(mass=-1.0)

"""The closed-form flight against a numerical integration, its exact inversion, and the vacuum limit."""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from impactid.rigs.ball import TABLE_TENNIS, TENNIS, flight_constants
from impactid.rigs.ball.flight import (
    FlightConstants,
    apex_height,
    chain_flights,
    flight_time,
    flight_time_derivative,
    landing_speed,
    landing_speed_derivative,
    launch_from_landing,
    launch_speed,
    restitution_from_flights,
    trajectory,
)


def _integrate(ball, u):
    """Flight of ``ball`` launched at ``u`` from the equation of motion (buoyancy, added mass, drag)."""
    m, ma, k, g = ball.mass, ball.displaced_air_mass, ball.drag_constant, ball.gravity

    def rhs(t, y):
        return [y[1], (-(m - ma) * g - k * y[1] * abs(y[1])) / (m + 0.5 * ma)]

    def land(t, y):
        return y[0]

    def apex(t, y):
        return y[1]

    land.terminal, land.direction = True, -1
    sol = solve_ivp(rhs, (0.0, 10.0), [0.0, u], events=[land, apex], rtol=1e-12, atol=1e-14, method="DOP853",
                    first_step=1e-6, dense_output=True)
    t_land = sol.t_events[0][0]
    return t_land, -sol.y_events[0][0][1], float(sol.y_events[1][0][0]), sol


@pytest.mark.parametrize("ball", [TABLE_TENNIS, TENNIS, TABLE_TENNIS.with_(drag_coefficient=2.0)],
                         ids=["table-tennis", "tennis", "heavy drag"])
@pytest.mark.parametrize("u", [0.3, 1.5, 4.0])
def test_closed_forms_match_solve_ivp(ball, u):
    c = flight_constants(ball)
    T_num, w_num, h_num, sol = _integrate(ball, u)
    assert float(flight_time(u, c)) == pytest.approx(T_num, rel=1e-9)
    assert float(landing_speed(u, c)) == pytest.approx(w_num, rel=1e-9)
    assert float(apex_height(u, c)) == pytest.approx(h_num, rel=1e-9)
    ts = np.linspace(0.0, T_num, 7)
    y, v = trajectory(u, ts, c)
    ref = sol.sol(ts)
    assert y == pytest.approx(ref[0], abs=1e-9)
    assert v == pytest.approx(ref[1], abs=1e-8)


def test_drag_shortens_and_slows_compared_with_vacuum():
    c = flight_constants(TABLE_TENNIS)
    vac = flight_constants(TABLE_TENNIS, drag=False)
    assert vac.terminal_speed == math.inf and vac.gravity == TABLE_TENNIS.gravity
    assert c.gravity < vac.gravity  # buoyancy and added mass
    assert float(landing_speed(2.0, c)) < 2.0
    # up and down are different with drag: the ball lands slower than it left
    assert float(landing_speed(2.0, c)) / 2.0 == pytest.approx(1 / math.sqrt(1 + (2.0 / c.terminal_speed) ** 2))


@pytest.mark.parametrize("constants", [flight_constants(TABLE_TENNIS), FlightConstants(9.81, 0.5),
                                       FlightConstants(9.81, math.inf)], ids=["table-tennis", "vt=0.5", "vacuum"])
def test_inversion_is_exact(constants):
    u = np.geomspace(1e-3, 20.0, 200)
    T = flight_time(u, constants)
    assert launch_speed(T, constants) == pytest.approx(u, rel=1e-13)
    w = landing_speed(u, constants)
    assert launch_from_landing(w, constants) == pytest.approx(u, rel=1e-10)


def test_inversion_of_bad_times_is_nan():
    c = flight_constants(TABLE_TENNIS)
    out = launch_speed([0.0, -1.0, math.nan, math.inf], c)
    assert np.all(np.isnan(out))


def test_derivatives_match_finite_differences():
    c = flight_constants(TABLE_TENNIS)
    u = np.array([0.2, 1.0, 3.0])
    h = 1e-6
    assert flight_time_derivative(u, c) == pytest.approx((flight_time(u + h, c) - flight_time(u - h, c)) / (2 * h),
                                                          rel=1e-7)
    assert landing_speed_derivative(u, c) == pytest.approx(
        (landing_speed(u + h, c) - landing_speed(u - h, c)) / (2 * h), rel=1e-7)


def test_vacuum_limit_is_the_textbook_formula():
    vac = FlightConstants(9.81, math.inf)
    T = np.array([0.46, 0.43, 0.40, 0.372])
    e, v = restitution_from_flights(T[:-1], T[1:], vac)
    assert e == pytest.approx(T[1:] / T[:-1], rel=1e-15)
    assert v == pytest.approx(9.81 * T[:-1] / 2, rel=1e-15)
    # a huge terminal speed converges to the same numbers
    far = FlightConstants(9.81, 1e7)
    e2, v2 = restitution_from_flights(T[:-1], T[1:], far)
    assert e2 == pytest.approx(e, rel=1e-9) and v2 == pytest.approx(v, rel=1e-9)


def test_restitution_from_simulated_flights_recovers_the_law_exactly():
    c = flight_constants(TABLE_TENNIS)
    law = lambda w: 0.97 - 0.02 * w  # noqa: E731
    seq = chain_flights(2.3, 15, law, c)
    e, v = restitution_from_flights(seq["T"][:-1], seq["T"][1:], c)
    assert e == pytest.approx(law(v), abs=1e-12)
    assert v == pytest.approx(seq["w"][:-1], rel=1e-12)
    # ignoring the air gives a different, speed-dependent answer (the point of the drag correction)
    e_vac, v_vac = restitution_from_flights(seq["T"][:-1], seq["T"][1:], flight_constants(None))
    assert np.max(np.abs(e_vac - law(v))) > 5e-3

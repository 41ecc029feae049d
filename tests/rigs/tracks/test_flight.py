"""The vectorised flight integrator against scipy's solve_ivp on the independent reference's equations."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from impactid.rigs.tracks import TABLE_TENNIS_BALL
from impactid.rigs.tracks.flight import flight_positions
from impactid.rigs.tracks.parameters import lift_coefficient, lift_over_spin
from tests.rigs.tracks import reference_tracks as ref


def _reference(p0, v0, spin, times, cd=0.45, scale=1.0):
    sol = solve_ivp(ref._rhs(np.asarray(spin, float), cd, scale), (0.0, times[-1]), np.r_[p0, v0], method="DOP853",
                    rtol=1e-12, atol=1e-14, t_eval=times)
    return sol.y[:3].T


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_integrator_matches_solve_ivp(sign):
    p0, v0, spin = np.array([0.0, 0.5, 0.02]), np.array([0.3, -8.0, 2.5]), np.array([-200.0, 30.0, 80.0])
    times = sign * np.linspace(0.007, 0.2, 28)
    got = flight_positions(np.tile(p0, (4, 1)), np.tile(v0, (4, 1)), np.zeros(4), times, TABLE_TENNIS_BALL, spin)
    want = _reference(p0, v0, spin, times)
    assert np.max(np.abs(got[0] - want)) < 1e-9  # measured: 3e-12 m
    assert np.max(np.abs(got - got[0])) == 0.0


def test_comparison_can_fail():
    p0, v0, spin = np.array([0.0, 0.5, 0.02]), np.array([0.3, -8.0, 2.5]), np.array([-200.0, 30.0, 80.0])
    times = np.linspace(0.007, 0.2, 28)
    got = flight_positions(p0[None], v0[None], np.zeros(1), times, TABLE_TENNIS_BALL.with_(drag_coefficient=0.4545),
                           spin)
    assert np.max(np.abs(got[0] - _reference(p0, v0, spin, times))) > 1e-5  # 1 % more drag is seen


def test_vacuum_is_a_parabola():
    ball = TABLE_TENNIS_BALL.with_(air_density=0.0)
    times = np.linspace(0.01, 0.3, 10)
    got = flight_positions(np.zeros((1, 3)), np.array([[1.0, 2.0, 3.0]]), np.zeros(1), times, ball, np.ones(3) * 100)
    want = np.column_stack([times, 2 * times, 3 * times - 0.5 * ball.gravity * times ** 2])
    assert np.max(np.abs(got[0] - want)) < 1e-12


@pytest.mark.parametrize("s, want", [(0.0, 0.0), (0.05, 0.075), (0.1, 0.15), (0.3, 0.27), (0.5, 0.39), (1.0, 0.69)])
def test_lift_coefficient_is_the_published_bilinear_fit(s, want):
    """Sawicki, Hubbard & Stronge (2003): C_L = 1.5 S up to S = 0.1, 0.09 + 0.6 S above."""
    assert float(lift_coefficient(s)) == pytest.approx(want, abs=1e-12)
    assert float(lift_coefficient(s)) == pytest.approx(ref.lift(s), abs=1e-12)
    if s > 0:
        assert float(lift_over_spin(s)) == pytest.approx(want / s, rel=1e-12)
    else:
        assert float(lift_over_spin(s)) == 1.5


def test_lift_scale_is_seen():
    """Half the published lift moves a spinning flight by more than the integrator's error."""
    p0, v0, spin = np.array([0.0, 0.5, 0.02]), np.array([0.3, -8.0, 2.5]), np.array([-200.0, 30.0, 80.0])
    times = np.linspace(0.007, 0.2, 28)
    half = flight_positions(p0[None], v0[None], np.zeros(1), times, TABLE_TENNIS_BALL, spin, lift_scale=np.array([0.5]))
    assert np.max(np.abs(half[0] - _reference(p0, v0, spin, times, scale=0.5))) < 1e-9
    assert np.max(np.abs(half[0] - _reference(p0, v0, spin, times))) > 1e-3

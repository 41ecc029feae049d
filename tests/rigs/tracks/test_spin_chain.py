"""The spin of a track's later bounces: carried from the bounce before (given -> propagated), estimated
from the flights' Magnus curvature when nothing gives it, or declared unknown; and the friction
coefficient's interval open above when every bounce may stick. Tracks of the independent reference
(``reference_tracks.py``)."""

import math

import numpy as np
import pytest

from impactid.rigs.tracks import TABLE_TENNIS_BALL, Track, analyse_tracks
from impactid.rigs.tracks.laws import fit_tangential_law, tangential_prediction
from tests.rigs.tracks.reference_tracks import RADIUS, bouncing_track

INERTIA = TABLE_TENNIS_BALL.inertia


def _three_bounces(spin, v0, mu, seed, dims=3):
    times, pos, truth = bouncing_track(np.array([0.0, 0.0, 0.35]), np.array(v0), np.array(spin), e_n=0.9, mu=mu,
                                       duration=1.2, rate=240.0, noise=1e-3, seed=seed, bounces=3)
    if dims == 2:
        pos = pos * np.array([1.0, 0.0, 1.0])
    return times, pos, truth


def _spins(result, side="in"):
    table = result.bounces[result.bounces["analysed"]]
    values = table[[f"spin_{side}_{a}_rad_s" for a in "xyz"]].to_numpy(float)
    return table, values


@pytest.fixture(scope="module")
def sliding_then_sticking():
    """3-D, spin (60, -150, 30) rad/s, 4 m/s along x, mu 0.25, three bounces."""
    times, pos, truth = _three_bounces((60.0, -150.0, 30.0), (4.0, 0.0, 0.0), 0.25, seed=5)
    given = analyse_tracks([Track("given", times, pos, 3, (60.0, -150.0, 30.0))], rule=False)
    return truth, given


def test_given_spin_is_propagated_to_the_later_bounces(sliding_then_sticking):
    truth, res = sliding_then_sticking
    table, spin_in = _spins(res)
    assert list(table["spin_source"]) == ["given", "propagated", "propagated"]
    for k, row in enumerate(table.itertuples()):
        w_true = truth[k][3]
        for j, axis in enumerate("xy"):  # the spin about the normal never changes at the contact
            se = getattr(row, f"spin_in_{axis}_rad_s_stderr")
            assert abs(spin_in[k, j] - w_true[j]) <= 3 * se + 1e-9, (k, axis, spin_in[k, j], w_true[j], se)
    # the test can fail: the given spin applied again to the second bounce is far outside its interval
    assert abs(spin_in[1, 1] - (-150.0)) > 5 * table.iloc[1]["spin_in_y_rad_s_stderr"]
    # the spin after a bounce is the spin before the next
    _, spin_out = _spins(res, "out")
    assert np.allclose(spin_out[:-1], spin_in[1:])
    assert res["tangential.coulomb.mu"].contains(0.25)
    assert res.statistics["bounces_in_tangential_laws"] == 3


def test_unknown_spin_is_estimated_from_the_flights():
    """2-D, no spin given, backspin 120 rad/s at the release: the first bounce's spin is estimated from the
    Magnus curvature (covering the truth, and not 0), the later ones propagated; mu covered."""
    times, pos, truth = _three_bounces((0.0, -120.0, 0.0), (3.0, 0.0, 0.0), 0.2, seed=2, dims=2)
    res = analyse_tracks([Track("free", times, pos, 2, None)], rule=False)
    table, spin_in = _spins(res)
    assert list(table["spin_source"]) == ["estimated", "propagated", "propagated"]
    se = table["spin_in_y_rad_s_stderr"].to_numpy(float)
    true_y = np.array([t[3][1] for t in truth])
    assert np.all(np.abs(spin_in[:, 1] - true_y) <= 3 * se)
    assert abs(spin_in[0, 1]) > 3 * se[0]  # the estimate sees the backspin
    assert res["tangential.coulomb.mu"].contains(0.2)
    fit = res.details["bounce_fits"][0]
    assert any("estimated from the flights" in n for n in fit["notes"])


def test_unknown_spin_without_magnus_is_declared():
    """No spin given and no Magnus force: the first bounce's spin is unknown (slip and spins undetermined,
    said so), the bounce is left out of the friction laws; its restitution is still reported."""
    times, pos, _ = _three_bounces((0.0, 0.0, 0.0), (2.0, 0.0, 0.0), 0.25, seed=1)
    res = analyse_tracks([Track("plain", times, pos, 3, None)], rule=False, spin=False)
    table = res.bounces[res.bounces["analysed"]]
    assert set(table["spin_source"]) == {"unknown"}
    assert table["ut_in_m_s"].isna().all() and table["spin_in_y_rad_s"].isna().all()
    assert table["e_n"].between(0.85, 0.95).all()
    assert "tangential.coulomb.mu" not in res.params and "tangential.ratio.beta" in res.params
    assert any("no bounce has a known incoming spin" in n for n in res.notes)
    fit = res.details["bounce_fits"][0]
    assert fit["params"]["ut_in"]["note"] == "the incoming spin is unknown"


def test_mu_is_bounded_below_only_when_every_bounce_sticks():
    """The Coulomb law on bounces that all stick: mu's interval is open above and holds the true mu; on
    bounces that slide it is closed and holds it (the profile likelihood, not the kinked delta method)."""
    rng = np.random.default_rng(0)
    n = 12
    v_in = np.column_stack([rng.uniform(1, 3, n), rng.uniform(-1, 1, n), -rng.uniform(2, 3, n)])
    v_out_z = -0.9 * v_in[:, 2]
    for mu, spin_y in ((0.6, 60.0), (0.1, -150.0)):
        spin = np.column_stack([np.zeros(n), np.full(n, spin_y), np.zeros(n)])
        v_t, sticks = tangential_prediction(mu, v_in, v_out_z, spin, RADIUS, INERTIA)
        v_out = np.column_stack([v_t + 0.01 * rng.standard_normal((n, 2)), v_out_z])
        law = fit_tangential_law("coulomb", v_in, v_out, spin, RADIUS, INERTIA)
        lo, hi = law["mu"].interval
        assert lo <= mu <= hi
        if sticks.all():
            assert math.isinf(hi) and "bounded below only" in law["mu"].note
        else:
            assert not sticks.any() and hi < 2 * mu

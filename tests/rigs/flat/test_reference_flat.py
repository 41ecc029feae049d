"""Sanity of the rig F solve_ivp reference (tests/rigs/flat/reference_flat.py) on its own."""

from __future__ import annotations

import math

import numpy as np
import pytest

from impactid.rigs.flat import ALZATE2007 as RIG
from tests.rigs.flat import reference_flat as ref

RPM130 = 130.0 * 2.0 * math.pi / 60.0  # [rad/s]


def _gap_rate(theta_f, rate, theta_c, omega):
    """h_dot written afresh: d/dt of (e cos tc + x0) sin th - (e sin tc + y0) cos th."""
    X, Y = RIG.e * math.cos(theta_c) + RIG.x0, RIG.e * math.sin(theta_c) + RIG.y0
    Xd, Yd = -RIG.e * omega * math.sin(theta_c), RIG.e * omega * math.cos(theta_c)
    return Xd * math.sin(theta_f) - Yd * math.cos(theta_f) + (X * math.cos(theta_f) + Y * math.sin(theta_f)) * rate


@pytest.fixture(scope="module")
def free_start():
    """From a free state well above the cam (0.45 rad, rising), at 130 rpm, until a little after the first impacts."""
    return ref.run_flat_reference(RIG, RPM130, 0.8, 0.6, theta_c0=1.0, theta_f0=0.45, theta_f_dot0=0.5)


@pytest.fixture(scope="module")
def periodic():
    """Started in contact at theta_c0 = 0, 130 rpm, r = 0.8, five revolutions."""
    return ref.run_flat_reference(RIG, RPM130, 0.8, 5 * 2.0 * math.pi / RPM130)


def test_free_flight_conserves_energy(free_start):
    first = free_start.events[0]
    assert first.kind == "impact" and first.time > 0.05
    t = np.linspace(0.0, first.time, 400)[:-1]  # state(first.time) is the post-impact state
    th, thd = free_start.state(t)
    energy = ref.free_flight_energy(RIG, th, thd)
    e_impact = ref.free_flight_energy(RIG, first.theta_f, first.rate_before)
    assert np.ptp(np.append(energy, e_impact)) < 1e-9 * energy[0]
    # the potential is the spring moment's: dV/dtheta_f = M_s
    x = np.linspace(0.1, 0.6, 11)
    dv = (ref.spring_potential(RIG, x + 1e-6) - ref.spring_potential(RIG, x - 1e-6)) / 2e-6
    np.testing.assert_allclose(dv, RIG.spring_torque(x), rtol=1e-8)


def test_impact_obeys_the_restitution_law(free_start):
    first = free_start.events[0]
    assert abs(float(ref.gap(RIG, first.theta_f, first.theta_c))) < 1e-15
    assert first.theta_c == pytest.approx(1.0 + RPM130 * first.time, rel=1e-15)
    before = _gap_rate(first.theta_f, first.rate_before, first.theta_c, RPM130)
    after = _gap_rate(first.theta_f, first.rate_after, first.theta_c, RPM130)
    assert before < -1e-3
    assert after == pytest.approx(-0.8 * before, rel=1e-12)
    assert first.gap_rate_before == pytest.approx(before, rel=1e-13)
    # the dense output continues from the post-impact state
    th, thd = free_start.state(first.time)
    assert th[0] == pytest.approx(first.theta_f, abs=1e-15)
    assert thd[0] == pytest.approx(first.rate_after, rel=1e-12)
    # a restitution law given as a function of the cam speed
    half = ref.run_flat_reference(RIG, RPM130, lambda w: 0.5 if w == RPM130 else 0.0, first.time + 1e-3,
                                  theta_c0=1.0, theta_f0=0.45, theta_f_dot0=0.5)
    e = half.events[0]
    assert half.r == 0.5 and e.time == pytest.approx(first.time, abs=1e-12)
    assert _gap_rate(e.theta_f, e.rate_after, e.theta_c, RPM130) == pytest.approx(-0.5 * before, rel=1e-12)


def test_no_penetration_and_every_impact_sequence_ends_in_sticking(periodic):
    t = np.linspace(0.0, periodic.t_end, 200_001)
    th, _ = periodic.state(t)
    assert ref.gap(RIG, th, periodic.cam_angle(t)).min() > -1e-13
    times = [e.time for e in periodic.events]
    assert all(b >= a for a, b in zip(times, times[1:]))
    kinds = [e.kind for e in periodic.events]
    assert kinds.count("release") == kinds.count("stick") == 5
    for i, e in enumerate(periodic.events):
        if e.kind == "stick":
            prev = periodic.events[i - 1]
            assert prev.kind == "impact" and prev.time == e.time
            assert 0.0 <= prev.gap_rate_after < periodic.v_stick
            assert ref.contact_torque(RIG, e.theta_c, RPM130) >= 0.0
        if e.kind == "impact":
            assert e.gap_rate_after == pytest.approx(-0.8 * e.gap_rate_before, rel=1e-9, abs=1e-15)


def test_release_where_the_contact_torque_vanishes(periodic):
    # the module's tau is the rig's
    tc = np.linspace(0.0, 2.0 * math.pi, 50)
    np.testing.assert_allclose(ref.contact_torque(RIG, tc, RPM130), RIG.contact_torque(tc, RPM130 / (2 * math.pi)),
                               rtol=1e-14, atol=1e-15)
    assert ref.contact_torque(RIG, 0.0, RPM130) > 0.0
    release = periodic.events[0]
    assert release.kind == "release"
    assert abs(float(ref.contact_torque(RIG, release.theta_c, RPM130))) < 1e-12
    assert ref.contact_torque(RIG, release.theta_c - 1e-6, RPM130) > 0.0 > ref.contact_torque(
        RIG, release.theta_c + 1e-6, RPM130)
    th, th1 = RIG.contact_angle(release.theta_c, derivatives=1)
    assert release.theta_f == pytest.approx(th, abs=1e-15)
    assert release.rate_after == pytest.approx(RPM130 * th1, rel=1e-14)
    # before the release the follower rides on the cam exactly
    t = np.linspace(0.0, release.time, 50)
    np.testing.assert_array_equal(periodic.state(t)[0], RIG.contact_angle(periodic.cam_angle(t)))
    # every revolution re-sticks before the next one: period-1, the same sample each revolution
    _, _, strobe = periodic.stroboscopic()
    assert strobe.size == 6
    np.testing.assert_allclose(strobe, RIG.contact_angle(0.0), rtol=0, atol=1e-15)
    period = 2.0 * math.pi / RPM130
    first_rev = [e for e in periodic.events if e.time < period]
    last_rev = [e for e in periodic.events if e.time >= 4 * period]
    assert len(first_rev) == len(last_rev)
    for a, b in zip(first_rev[:12], last_rev[:12]):
        assert b.time - 4 * period == pytest.approx(a.time, abs=1e-10)


def test_below_detachment_the_follower_never_leaves_the_cam():
    omega = 100.0 * 2.0 * math.pi / 60.0  # detachment is near 122.5 rpm
    run = ref.run_flat_reference(RIG, omega, 0.8, 3 * 2.0 * math.pi / omega, theta_c0=0.4)
    assert run.events == ()
    t = np.linspace(0.0, run.t_end, 101)
    th, thd = run.state(t)
    a, a1 = RIG.contact_angle(run.cam_angle(t), derivatives=1)
    np.testing.assert_array_equal(th, a)
    np.testing.assert_array_equal(thd, omega * a1)


@pytest.mark.parametrize(("theta_c0", "sticks"), [(4.5, True), (2.0, False)])
def test_plastic_impact_sticks_only_where_the_cam_can_push(theta_c0, sticks):
    """r = 0 leaves no separation speed; the follower then sticks iff tau >= 0 (tau < 0 near 2 rad at 130 rpm)."""
    assert (ref.contact_torque(RIG, theta_c0, RPM130) >= 0.0) == sticks
    th, th1 = RIG.contact_angle(theta_c0, derivatives=1)
    run = ref.run_flat_reference(RIG, RPM130, 0.0, 0.01, theta_c0=theta_c0, theta_f0=th + 1e-4,
                                 theta_f_dot0=RPM130 * th1 - 0.5)
    kinds = [e.kind for e in run.events]
    assert kinds[0] == "impact" and abs(run.events[0].gap_rate_after) < 1e-15
    if sticks:
        assert kinds[:2] == ["impact", "stick"]
    else:
        assert "stick" not in kinds
        # it leaves the cam at once: the gap grows after the impact
        t = run.events[0].time + np.array([1e-4, 1e-3])
        assert np.all(np.diff(ref.gap(RIG, run.state(t)[0], run.cam_angle(t))) > 0.0)


def test_input_checks():
    with pytest.raises(ValueError, match="restitution"):
        ref.run_flat_reference(RIG, RPM130, 1.2, 0.1)
    with pytest.raises(ValueError, match="omega"):
        ref.run_flat_reference(RIG, 0.0, 0.8, 0.1)
    with pytest.raises(ValueError, match="penetrates"):
        ref.run_flat_reference(RIG, RPM130, 0.8, 0.1, theta_f0=0.1, theta_f_dot0=0.0)

"""Rig P parameters, TOML round trip, validation, and geometry (closed forms vs the paper's S-5..S-8)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from impactid import SUNDAR2016, PivotedFollowerRig, RigParameterError, load_rig_toml, save_rig_toml
from impactid.rigs import pivoted as geo

#: agreement "to round-off" for lengths built from terms of about 0.1 m: ~10 ulp of 0.1 m [m]
ROUNDOFF = 1e-15


def test_table1_defaults_and_derived_values(rig):
    assert rig.m_b == 0.257 and rig.I_b == 3.3e-3 and rig.l_g == 0.086 and rig.l_a == 0.063
    assert rig.PE_x == 0.089 and rig.PE_y == 0.027
    assert rig.e == pytest.approx(0.2 * 0.0175, rel=1e-15)
    assert rig.h_p == pytest.approx(0.5 * 0.0127 + 2 * 0.0032)
    # docs/rig_p.md: k_H about 8.0e9 N m^-1.5
    assert rig.k_H == pytest.approx(8.0e9, rel=0.01)
    assert rig.with_eccentricity_ratio(0.1).e == pytest.approx(0.1 * 0.0175, rel=1e-15)
    assert rig.with_eccentricity_ratio(0.1).e_over_rc == pytest.approx(0.1)


def test_toml_round_trip(tmp_path, rig):
    path = save_rig_toml(rig, tmp_path / "rig.toml", operating={"cam_speed_hz": 16.0, "eccentricity_m": rig.e})
    loaded, operating = load_rig_toml(path)
    assert loaded == rig
    assert operating == {"cam_speed_hz": 16.0, "eccentricity_m": rig.e}
    assert "[rig]" in path.read_text() and 'model = "pivoted-follower"' in path.read_text()


def _write_rig(tmp_path, **changes):
    values = SUNDAR2016.to_dict() | changes
    lines = ["[rig]", 'model = "pivoted-follower"']
    for key, value in values.items():
        if value is not None:
            lines.append(f"{key} = {value}")
    path = tmp_path / "bad.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"k_s": -3319.0}, "'k_s' must be positive"),
        ({"k_s": None}, "missing parameter(s) k_s"),
        ({"I_b": "nan"}, "'I_b' is not finite"),
        ({"e": 0.02}, "smaller than the cam radius"),
        ({"nu_c": 0.6}, "'nu_c' must lie in [0, 0.5)"),
        ({"l_g": 0.173}, "moment of inertia about the pivot cannot be smaller"),
        ({"mu": -0.1}, "'mu' must be >= 0"),
        ({"Y_b": 0.0}, "'Y_b' must be positive"),
    ],
)
def test_invalid_rig_files_name_file_and_parameter(tmp_path, changes, message):
    path = _write_rig(tmp_path, **changes)
    with pytest.raises(RigParameterError) as info:
        load_rig_toml(path)
    assert message in str(info.value)
    assert str(path) in str(info.value)


def test_rig_file_errors(tmp_path):
    with pytest.raises(RigParameterError, match="not found"):
        load_rig_toml(tmp_path / "missing.toml")
    bad = tmp_path / "broken.toml"
    bad.write_text("[rig\nmodel = 3")
    with pytest.raises(RigParameterError, match="not a valid TOML"):
        load_rig_toml(bad)
    unknown = tmp_path / "unknown.toml"
    unknown.write_text('[rig]\nmodel = "rotary-tappet"\n')
    with pytest.raises(RigParameterError, match="unknown rig model 'rotary-tappet'"):
        load_rig_toml(unknown)
    extra = _write_rig(tmp_path, k_spring=1.0)
    with pytest.raises(RigParameterError, match="unknown rig parameter"):
        load_rig_toml(extra)


def test_zero_state_closes_the_gap(rig):
    # (S-3) corrected: at (alpha0, Theta0) the gap is zero and the 0-state lever arm is u(alpha0).PE
    for ratio in (0.05, 0.15, 0.25):
        r = rig.with_eccentricity_ratio(ratio)
        # round-off: the terms are lengths of about 0.09 m, a few ulp is about 3e-16 m
        assert abs(r.gap(r.alpha0, r.theta0)) < ROUNDOFF
        # at alpha0 the cam's farthest reach just touches: over all cam angles the gap is
        # psi = e (1 - cos(Theta - Theta0)) >= 0, zero at Theta0 only
        theta = np.linspace(0, 2 * np.pi, 2001)
        np.testing.assert_allclose(r.gap(r.alpha0, theta), r.e * (1 - np.cos(theta - r.theta0)), atol=ROUNDOFF)


@pytest.mark.parametrize("ratio", [0.05, 0.2, 0.25])
def test_closed_forms_equal_paper_expressions(rig, ratio):
    """(S-5)..(S-8) expand to the closed forms of docs/rig_p.md (to round-off)."""
    r = rig.with_eccentricity_ratio(ratio)
    rng = np.random.default_rng(1)
    alpha = rng.uniform(-0.2, 0.3, 500)
    theta = rng.uniform(0.0, 4 * np.pi, 500)
    alpha_dot = rng.uniform(-8, 8, 500)
    theta_dot = 2 * np.pi * rng.uniform(1, 30, 500)
    a0, chi0, R = r.alpha0, r.chi0, r.contact_radius
    psi = r.gap(alpha, theta)
    np.testing.assert_allclose(geo.gap_paper(alpha, theta, a0, chi0, R, r.e), psi, rtol=0, atol=ROUNDOFF)
    psi_j = geo.tangential_gap_paper(alpha, theta, a0, chi0, R, r.e)
    np.testing.assert_allclose(chi0 - psi_j, r.lever_arm(alpha, theta), rtol=0, atol=ROUNDOFF)
    np.testing.assert_allclose(geo.gap_rate_paper(alpha, alpha_dot, theta, theta_dot, a0, chi0, R, r.e),
                               r.gap_rate(alpha, alpha_dot, theta, theta_dot), rtol=0, atol=1e-14)
    np.testing.assert_allclose(
        geo.tangential_gap_rate_paper(alpha, alpha_dot, theta, theta_dot, a0, chi0, R, r.e),
        r.tangential_gap_rate(alpha, alpha_dot, theta, theta_dot), rtol=0, atol=1e-14)


def test_rates_are_time_derivatives(rig):
    """Gap rate and tangential rate match central differences along a trajectory."""
    t = np.linspace(0, 0.05, 11)
    h = 1e-6
    w = 2 * np.pi * 16

    def traj(tt):
        return 0.05 + 0.02 * np.sin(40 * tt), 0.3 + w * tt

    a, th = traj(t)
    ad = 0.02 * 40 * np.cos(40 * t)
    (ap, thp), (am, thm) = traj(t + h), traj(t - h)
    # central-difference truncation (h^2/6) e w^3 is about 6e-10 m/s; round-off 1e-15 m / h = 1e-9 m/s
    fd_gap = (rig.gap(ap, thp) - rig.gap(am, thm)) / (2 * h)
    np.testing.assert_allclose(rig.gap_rate(a, ad, th, w), fd_gap, rtol=0, atol=3e-9)
    fd_chi = (rig.lever_arm(ap, thp) - rig.lever_arm(am, thm)) / (2 * h)
    np.testing.assert_allclose(-rig.tangential_gap_rate(a, ad, th, w), fd_chi, rtol=0, atol=3e-9)


def test_static_equilibrium_balances_torques(rig):
    in_contact = []
    for theta in np.linspace(0.0, 2 * np.pi, 13):
        a = rig.static_equilibrium(theta)
        delta = -rig.gap(a, theta)
        if delta > 0:
            assert delta < 1e-5  # a slight Hertzian indentation
            torque = rig.free_torque(a) + rig.k_H * delta**1.5 * rig.lever_arm(a, theta)
            # brentq resolves alpha to ~1e-16 rad; the torque stiffness is ~1.6e5 N m/rad
            assert abs(torque) < 1e-10
        else:
            # the cam is high enough that the follower hangs free on its spring
            assert abs(rig.free_torque(a)) < 1e-12
        in_contact.append(delta > 0)
    assert in_contact[0]  # the paper's start: cam at Theta = 0 holds the follower down
    assert not all(in_contact)
    alpha_c = rig.contact_angle(np.array([0.0, 2.0]))
    np.testing.assert_allclose(rig.gap(alpha_c, np.array([0.0, 2.0])), 0.0, atol=1e-17)


def test_spring_force_formula(rig):
    a = 0.04
    expected = 3319 * (0.053 - 0.058 + 0.035 * math.tan(a) + 0.5 * 0.0127 / math.cos(a))
    assert rig.spring_force(a) == pytest.approx(expected, rel=1e-15)


def test_direct_construction_validation():
    with pytest.raises(RigParameterError, match="'m_b' must be a number"):
        PivotedFollowerRig(**(SUNDAR2016.to_dict() | {"m_b": "heavy"}))
    with pytest.raises(RigParameterError, match="e/r_c must be a finite number"):
        SUNDAR2016.with_eccentricity_ratio(float("nan"))

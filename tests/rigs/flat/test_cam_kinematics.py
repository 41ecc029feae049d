"""Contact-point kinematics study (Lee 2005): analytic derivatives, spline convergence, sharper profile."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from impactid.rigs.flat import ALZATE2007 as RIG
from impactid.rigs.flat.cam_kinematics import (
    DEFAULT_NODES,
    ProfileSum,
    analytic_follower_kinematics,
    convergence_order,
    displacement_spline,
    flat_follower_cam_curvature_radius,
    revised_nose_profile,
    spline_error_study,
    spline_follower_kinematics,
)
from impactid.rigs.flat.camprofile import GaussianSumProfile

OMEGA = 130.0 * 2.0 * math.pi / 60.0  # [rad/s]
ANGLES = np.linspace(0.0, 2.0 * math.pi, 97)
SHARP = revised_nose_profile()

# ---- independent complex-analytic implementations (for the complex-step derivative) -------------


def _eccentric_complex(tc):
    """A-17 written afresh with complex-safe functions (x0 > e, so atan2(Y, X) = arctan(Y / X))."""
    X = RIG.e * np.cos(tc) + RIG.x0
    Y = RIG.e * np.sin(tc) + RIG.y0
    return np.arcsin((RIG.d + RIG.R) / np.sqrt(X * X + Y * Y)) + np.arctan(Y / X)


def _sharp_complex(tc):
    (a,), (b,), (c,) = SHARP.terms[1].a, SHARP.terms[1].b, SHARP.terms[1].c
    lobe = sum(a * np.exp(-(((tc - b - 2.0 * math.pi * k) / c) ** 2)) for k in range(-2, 3))
    return _eccentric_complex(tc) + lobe


def _complex_step(f, x, h=1e-30):
    return np.imag(f(x + 1j * h)) / h


def _central8(g, x, h):
    """Eighth-order central difference of g at x with step h."""
    w = (4.0 / 5.0, -1.0 / 5.0, 4.0 / 105.0, -1.0 / 280.0)
    return sum(wk * (g(x + (k + 1) * h) - g(x - (k + 1) * h)) for k, wk in enumerate(w)) / h


@pytest.mark.parametrize(("profile", "reference", "step"), [
    (RIG.contact_angle, _eccentric_complex, 1e-2),
    (SHARP, _sharp_complex, 1e-3),  # the lobe is 0.05 rad wide: smaller FD step
], ids=["eccentric", "revised-nose"])
def test_analytic_derivatives_match_complex_step(profile, reference, step):
    th, t1, t2 = profile(ANGLES, derivatives=2)
    np.testing.assert_allclose(th, np.real(reference(ANGLES + 0j)), rtol=0, atol=1e-15)
    cs1 = _complex_step(reference, ANGLES)
    np.testing.assert_allclose(t1, cs1, rtol=0, atol=1e-13 * np.abs(cs1).max())
    cs2 = _central8(lambda x: _complex_step(reference, x), ANGLES, step)
    np.testing.assert_allclose(t2, cs2, rtol=0, atol=1e-10 * np.abs(cs2).max())
    # the kinematics at constant cam speed are the chain rule of these
    f, fd, fdd = analytic_follower_kinematics(profile, ANGLES, OMEGA)
    np.testing.assert_array_equal(f, th)
    np.testing.assert_allclose(fd, OMEGA * cs1, rtol=0, atol=1e-13 * OMEGA * np.abs(cs1).max())
    np.testing.assert_allclose(fdd, OMEGA**2 * cs2, rtol=0, atol=1e-10 * OMEGA**2 * np.abs(cs2).max())


def test_profile_sum_adds_values_and_derivatives():
    g = GaussianSumProfile(a=(0.1,), b=(1.0,), c=(0.4,))
    total = ProfileSum((RIG.contact_angle, g))
    np.testing.assert_allclose(total(ANGLES), RIG.contact_angle(ANGLES) + g(ANGLES), rtol=1e-15)
    for k in (1, 2):
        got, a, b = total(ANGLES, derivatives=k), RIG.contact_angle(ANGLES, k), g(ANGLES, k)
        assert len(got) == k + 1
        for j in range(k + 1):
            np.testing.assert_allclose(got[j], a[j] + b[j], rtol=1e-15, atol=0)
    with pytest.raises(ValueError):
        ProfileSum(())


# ---- the sharper profile is a real cam ---------------------------------------------------------


def test_eccentric_cam_radius_of_curvature_is_its_radius():
    rho = flat_follower_cam_curvature_radius(RIG.contact_angle, ANGLES, RIG.x0, RIG.y0, RIG.d)
    np.testing.assert_allclose(rho, RIG.R, rtol=1e-12)


def test_revised_nose_is_convex_sharper_and_at_the_nose():
    tc = np.linspace(0.0, 2.0 * math.pi, 20001)
    rho = flat_follower_cam_curvature_radius(SHARP, tc, RIG.x0, RIG.y0, RIG.d)
    assert 0.005 < rho.min() < 0.5 * RIG.R  # convex (a flat face can follow it), locally much sharper
    k = int(np.argmin(rho))
    assert abs(tc[k] - SHARP.terms[1].b[0]) < 0.1  # the sharp part sits at the nose
    assert abs(SHARP.terms[1].b[0] - tc[np.argmax(RIG.contact_angle(tc))]) < 1e-3
    peak_sharp = np.abs(SHARP(tc, derivatives=2)[2]).max()
    peak_cam = np.abs(RIG.contact_angle(tc, derivatives=2)[2]).max()
    assert 3.0 < peak_sharp / peak_cam < 5.0
    # outside a few lobe widths the profile is the eccentric cam
    far = np.abs(np.angle(np.exp(1j * (tc - SHARP.terms[1].b[0])))) > 0.5
    np.testing.assert_allclose(SHARP(tc[far]), RIG.contact_angle(tc[far]), rtol=0, atol=1e-12)
    with pytest.raises(ValueError):
        revised_nose_profile(width=0.0)


# ---- the spline ------------------------------------------------------------------------------


def test_spline_interpolates_the_nodes_and_is_periodic():
    n = 64
    spline = displacement_spline(RIG.contact_angle, n, theta_start=0.3)
    knots = 0.3 + 2.0 * math.pi * np.arange(n) / n
    np.testing.assert_allclose(spline(knots), RIG.contact_angle(knots), rtol=1e-14)
    a = spline_follower_kinematics(RIG.contact_angle, ANGLES, OMEGA, n, theta_start=0.3)
    b = spline_follower_kinematics(RIG.contact_angle, ANGLES + 4.0 * math.pi, OMEGA, n, theta_start=0.3)
    for u, v, scale in zip(a, b, (1.0, OMEGA, OMEGA**2)):
        np.testing.assert_allclose(u, v, rtol=0, atol=1e-12 * scale)
    with pytest.raises(ValueError, match="at least 4"):
        displacement_spline(RIG.contact_angle, 3)


def test_study_matches_the_definition_and_is_independent_of_cam_speed():
    n, m = 40, 5
    frame = spline_error_study(RIG.contact_angle, nodes=[n], points_per_interval=m)
    grid = 2.0 * math.pi * np.arange(n * m) / (n * m)
    fine = np.linspace(0.0, 2.0 * math.pi, 400_001)
    _, v_ref, a_ref = analytic_follower_kinematics(RIG.contact_angle, fine, OMEGA)
    _, v_s, a_s = spline_follower_kinematics(RIG.contact_angle, grid, OMEGA, n)
    _, v_a, a_a = analytic_follower_kinematics(RIG.contact_angle, grid, OMEGA)
    row = frame.iloc[0]
    err_a = np.abs(a_s - a_a) / np.abs(a_ref).max()
    err_v = np.abs(v_s - v_a) / np.abs(v_ref).max()
    assert row["max_rel_error_acceleration"] == pytest.approx(err_a.max(), rel=1e-6)
    assert row["rms_rel_error_acceleration"] == pytest.approx(np.sqrt(np.mean(err_a**2)), rel=1e-6)
    assert row["max_rel_error_velocity"] == pytest.approx(err_v.max(), rel=1e-6)
    assert row["rms_rel_error_velocity"] == pytest.approx(np.sqrt(np.mean(err_v**2)), rel=1e-6)
    assert row["theta_c_max_error_acceleration"] == pytest.approx(grid[np.argmax(err_a)])
    assert frame.attrs["acceleration_scale"] == pytest.approx(np.abs(a_ref).max() / OMEGA**2, rel=1e-9)


def test_spline_error_of_the_eccentric_cam_falls_at_the_expected_orders():
    nodes = [100, 200, 400, 800, 1600]
    frame = spline_error_study(RIG.contact_angle, nodes=nodes)
    for column in ("max_rel_error_acceleration", "rms_rel_error_acceleration",
                   "max_rel_error_velocity", "rms_rel_error_velocity"):
        assert np.all(np.diff(frame[column]) < 0.0), column
    assert convergence_order(frame, "max_rel_error_acceleration") == pytest.approx(2.0, abs=0.1)
    assert convergence_order(frame, "rms_rel_error_acceleration") == pytest.approx(2.0, abs=0.1)
    assert convergence_order(frame, "max_rel_error_velocity") == pytest.approx(3.0, abs=0.15)
    # Lee (2005): with 1000 nodes the spline acceleration "almost agrees" with the analytic one
    assert spline_error_study(RIG.contact_angle, nodes=[1000])["max_rel_error_acceleration"].iloc[0] < 1e-5


def test_sharper_profile_needs_many_more_nodes():
    smooth = spline_error_study(RIG.contact_angle, nodes=DEFAULT_NODES)
    sharp = spline_error_study(SHARP, nodes=DEFAULT_NODES)
    target = 1e-3

    def nodes_needed(frame):
        ok = frame[frame["max_rel_error_acceleration"] <= target]
        return int(ok["nodes"].min()) if len(ok) else math.inf

    assert nodes_needed(sharp) >= 10 * nodes_needed(smooth)
    at_1000 = (sharp.set_index("nodes").loc[1000, "max_rel_error_acceleration"]
               / smooth.set_index("nodes").loc[1000, "max_rel_error_acceleration"])
    assert at_1000 > 100.0
    # the error of the sharper profile sits at the revised nose (as Lee's (2005) Fig. 7 window)
    assert np.all(np.abs(sharp["theta_c_max_error_acceleration"].iloc[3:] - SHARP.terms[1].b[0]) < 0.05)
    # once the nodes resolve the lobe, the same second order appears
    assert convergence_order(sharp, "max_rel_error_acceleration", nodes_min=1000) == pytest.approx(2.0, abs=0.15)


def test_convergence_order_and_input_checks():
    n = np.array([10, 20, 40, 80])
    frame = pd.DataFrame({"nodes": n, "e": 3.0 * n**-2.5})
    assert convergence_order(frame, "e") == pytest.approx(2.5, rel=1e-12)
    with pytest.raises(ValueError):
        convergence_order(frame, "e", nodes_min=80)
    with pytest.raises(ValueError, match="constant"):
        spline_error_study(lambda tc, derivatives=0: (np.zeros_like(tc),) * 3 if derivatives else np.zeros_like(tc),
                           nodes=[10])
    with pytest.raises(ValueError):
        spline_error_study(RIG.contact_angle, nodes=[10], points_per_interval=0)

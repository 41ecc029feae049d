"""Cam lift, contact point, rocker ratio and lever arm: closed forms and the specification's values."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from impactid.errors import RigParameterError
from impactid.rigs.finger_follower.cam import (
    CycloidalLift,
    LiftTable,
    base_geometry,
    build_kinematics,
    check_convex,
    contact_kinematics,
    read_lift,
    write_lift,
)

DEG = math.pi / 180


def _extremum(f, a, b, sign):
    r = minimize_scalar(lambda t: sign * f(t), bounds=(a, b), method="bounded", options={"xatol": 1e-10})
    return sign * r.fun, r.x


def test_cycloidal_lift_closed_forms():
    lift = CycloidalLift(6e-3, 0.5 * math.pi, 0.5 * math.pi)
    assert lift(0.0) == (pytest.approx(6e-3, rel=1e-15), 0.0, pytest.approx(0.0, abs=1e-15))
    assert lift(1.0 * math.pi) == (0.0, 0.0, 0.0)
    # S = S_K (x/b - sin(2 pi x/b)/(2 pi)), x = b - |gamma|: half the lift half-way, slope 2 S_K/b there
    S, S1, S2 = lift(-0.25 * math.pi)
    assert S == pytest.approx(3e-3, rel=1e-14) and S1 == pytest.approx(2 * 6e-3 / (0.5 * math.pi), rel=1e-14)
    assert S2 == pytest.approx(0.0, abs=1e-15)
    g = np.linspace(-1.5, 1.5, 301)
    h = 1e-6
    S, S1, S2 = lift(g)
    assert np.allclose(S1, (lift(g + h)[0] - lift(g - h)[0]) / (2 * h), atol=1e-9)
    assert np.allclose(S2, (lift(g + h)[1] - lift(g - h)[1]) / (2 * h), atol=1e-7)
    asym = CycloidalLift(6e-3, 1.2, 1.8)
    assert asym.event == (-1.2, 1.8) and asym(-1.2)[0] == 0.0 and asym(1.79)[0] > 0.0


def test_convexity_of_the_reference_cam(rig):
    lift = CycloidalLift(rig.S_K, rig.beta_K, rig.beta_K)
    assert check_convex(lift, rig.R_c) == pytest.approx(3.14e-3, abs=5e-6)   # quoted 3.14 mm
    with pytest.raises(RigParameterError, match="not convex"):
        check_convex(CycloidalLift(6e-3, 1.0, 1.0), rig.R_c)


def test_base_geometry_matches_the_specification(rig):
    geo = base_geometry(rig)
    A, C0, P0 = map(np.array, (geo.A, geo.C0, geo.P0))
    assert A * 1e3 == pytest.approx([25.488, 25.987], abs=1e-3)
    assert C0 * 1e3 == pytest.approx([23.724, -20.980], abs=1e-3)
    assert P0 * 1e3 == pytest.approx([25.000, 12.996], abs=1e-3)
    assert np.hypot(*A) == pytest.approx(rig.R_ab, rel=1e-14) and np.hypot(*C0) == pytest.approx(rig.R_1, rel=1e-14)
    assert np.hypot(*(A - C0)) == pytest.approx(rig.R_c + rig.R_f, rel=1e-14)
    assert math.degrees(geo.normal) == pytest.approx(87.85, abs=0.01)
    assert math.degrees(geo.angle_B) == pytest.approx(87.04, abs=0.01)


def test_contact_lies_on_the_common_normal_and_base_circle_is_exact(rig):
    th = np.radians([-150.0, -60.0, -20.0, 0.0, 25.0, 70.0, 170.0])
    k = contact_kinematics(rig, th)
    C, P = k["C"], k["P"]
    assert np.allclose(np.hypot(C[:, 0], C[:, 1]), rig.R_1, rtol=1e-13)
    assert np.allclose(np.hypot(*(C - P).T), rig.R_f, rtol=1e-12)
    geo = base_geometry(rig)
    # the pad centre lies on the cam's normal at P, at R_f beyond the flat-follower envelope (K-7):
    # C - A = (R_c + S + R_f) n + S' t, so |C - A|^2 = (R_c + S + R_f)^2 + S'^2 and the same for P with R_f = 0
    S, S1, _ = CycloidalLift(rig.S_K, rig.beta_K, rig.beta_K)(k["gamma"])
    AC, AP = C - np.array(geo.A), P - np.array(geo.A)
    assert np.allclose(np.hypot(*AC.T) ** 2, (rig.R_c + S + rig.R_f) ** 2 + S1**2, rtol=1e-12)
    assert np.allclose(np.hypot(*AP.T) ** 2, (rig.R_c + S) ** 2 + S1**2, rtol=1e-12)
    base = np.abs(np.degrees(th)) > 100
    assert np.allclose(k["RR"][base], 1.47, atol=1e-12) and np.allclose(k["phi"][base], 0.0, atol=1e-13)
    assert np.allclose(k["gamma"][base], th[base], atol=1e-12)


def test_rocker_ratio_and_lift_of_the_reference_cam(rig):
    ck = lambda t, key: float(contact_kinematics(rig, t)[key])  # noqa: E731
    rr_min, th_min = _extremum(lambda t: ck(t, "RR"), -80 * DEG, -5 * DEG, 1)
    rr_max, th_max = _extremum(lambda t: ck(t, "RR"), 5 * DEG, 80 * DEG, -1)
    assert rr_min == pytest.approx(1.265, abs=5e-4) and abs(th_min / DEG + 39) < 1.0
    assert rr_max == pytest.approx(1.980, abs=5e-4) and abs(th_max / DEG - 37) < 1.0
    assert ck(0.0, "RR") == pytest.approx(1.604, abs=5e-4)
    yv, _ = _extremum(lambda t: ck(t, "Y_v_kin"), -30 * DEG, 30 * DEG, -1)
    yc, _ = _extremum(lambda t: ck(t, "Y_c"), -30 * DEG, 30 * DEG, -1)
    assert yv == pytest.approx(9.512e-3, abs=5e-7) and yc == pytest.approx(6.081e-3, abs=5e-7)
    ph, _ = _extremum(lambda t: ck(t, "phi"), -30 * DEG, 30 * DEG, -1)
    assert math.degrees(ph) == pytest.approx(15.0, abs=0.05)


def test_closed_forms_of_the_outputs_and_their_derivatives(rig):
    th = np.radians(np.linspace(-85, 85, 35))
    k = contact_kinematics(rig, th)
    # (K-7b..f): RR = L_sum/d_c, L_fc = d_c - L_tf, Y_c = d_c sin(phi), Y_v,kin = L_sum sin(phi) = RR Y_c
    assert np.allclose(k["RR"], rig.L_sum / k["d_c"], rtol=1e-15)
    assert np.allclose(k["L_fc"], k["d_c"] - rig.L_tf, atol=1e-17)
    assert np.allclose(k["Y_c"], k["d_c"] * np.sin(k["phi"]), atol=1e-17)
    assert np.allclose(k["Y_v_kin"], k["RR"] * k["Y_c"], atol=1e-16)
    h = 1e-6
    kp, km = contact_kinematics(rig, th + h), contact_kinematics(rig, th - h)
    for name, deriv in (("Y_c", "dY_c"), ("L_fc", "dL_fc"), ("phi", "dphi"), ("gamma", "dgamma")):
        assert np.allclose(k[deriv], (kp[name] - km[name]) / (2 * h), atol=1e-8), name


def test_rigid_train_has_zero_deflections(rig):
    """With Y_t = 0, theta_f = phi and Y_f = L_tf sin(phi) the three contact deflections vanish (K-D13)."""
    th = np.radians(np.linspace(-90, 90, 19))
    k = contact_kinematics(rig, th)
    phi = k["phi"]
    Yf = rig.L_tf * np.sin(phi)
    Yv = k["Y_v_kin"]
    assert np.allclose(Yf - rig.L_tf * np.sin(phi), 0.0, atol=1e-18)
    assert np.allclose(k["Y_c"] - Yf - k["L_fc"] * np.sin(phi), 0.0, atol=1e-17)
    assert np.allclose(Yf - Yv + rig.L_vf * np.sin(phi), 0.0, atol=1e-17)


def test_splines_of_the_table_match_the_exact_kinematics(rig, train):
    """The 0.1 deg periodic cubic splines: within 2e-11 m where the lift is smooth; within 5e-9 m
    next to the contact's passage over the nose (about 6.5 deg) and the event ends (+-90 deg),
    where the cycloidal lift's third derivative jumps. 5e-9 m of cam input is 0.4 N through K_fc,
    for a fraction of a degree; the reference model uses the same table and spline."""
    kin = train.kinematics
    th = np.radians(np.linspace(-120, 120, 2401) + 0.0371)
    k = contact_kinematics(rig, th)
    err_y, err_l = np.abs(kin("Y_c", th) - k["Y_c"]), np.abs(kin("L_fc", th) - k["L_fc"])
    deg = np.degrees(th)
    smooth = (np.abs(np.abs(deg) - 90) > 1.0) & (np.abs(deg - 6.5) > 1.5)
    assert err_y[smooth].max() < 2e-11 and err_l[smooth].max() < 2e-11
    assert err_y.max() < 5e-9 and err_l.max() < 5e-9
    assert np.abs(kin("Y_c", th, 1) - k["dY_c"])[smooth].max() < 5e-8
    opens, closes = kin.open_interval()
    assert closes - opens == pytest.approx(math.radians(157.16), abs=math.radians(0.01))


def test_constant_ratio_variant(rig, train):
    const = build_kinematics(rig, variant="constant_ratio")
    th = np.radians(np.linspace(-90, 90, 37))
    assert np.allclose(const.rocker_ratio(th), rig.RR0) and np.allclose(const.lever_arm(th), rig.L_fc0)
    # the same kinematic valve lift is asked of both trains
    assert np.allclose(const.valve_lift(th), train.kinematics.valve_lift(th), atol=1e-12)
    assert np.allclose(const.cam_input(th) * rig.RR0, const.valve_lift(th), atol=1e-15)


def test_lift_table_and_files(tmp_path, rig):
    law = CycloidalLift(rig.S_K, rig.beta_K, rig.beta_K)
    for name in ("lift.csv", "lift.toml"):
        write_lift(law, tmp_path / name)
    table = read_lift(tmp_path / "lift.csv")
    assert isinstance(table, LiftTable) and read_lift(tmp_path / "lift.toml") == law
    g = np.radians(np.linspace(-89, 89, 179))
    # a clamped spline through 0.25 deg samples of the law reproduces it closely
    assert np.abs(table(g)[0] - law(g)[0]).max() < 1e-9
    write_lift(table, tmp_path / "table.toml")
    again = read_lift(tmp_path / "table.toml")
    assert np.array_equal(again.gamma, table.gamma) and np.array_equal(again.lift, table.lift)
    bad = tmp_path / "bad.csv"
    bad.write_text("gamma_rad,lift_m\n-1,0\n-0.5,1e-3\n0,2e-3\n0.5,1e-3\n1,1e-4\n")
    with pytest.raises(RigParameterError, match="must be 0 at the first and last point"):
        read_lift(bad)
    with pytest.raises(RigParameterError, match="lift file not found"):
        read_lift(tmp_path / "missing.csv")

"""Checks of the independent finger-follower/HLA reference model
(tests/rigs/finger_follower/reference_finger_follower.py).

The model is the OHC finger-follower valve train with a hydraulic lash adjuster of Kim, Jeon & Park
(1990), as repaired by the project's valve-train specification. The tests check closed forms,
statics, kinematics and the specification's quoted reference-run numbers, and the internal
consistency of the hybrid integrator. Numbers quoted by the specification are compared at the
precision it quotes them (half a unit of the last digit), unless a test says otherwise and why.

Runtime: the tests outside ``slow`` (closed forms, statics, kinematics, short energy runs) take about
2 s of CPU; the ``slow`` ones, whose steady-state runs at 900 and 2450 rpm are most of it, about 110 s.
"""

import math

import numpy as np
import pytest
from scipy.optimize import brentq, minimize_scalar

from tests.rigs.finger_follower import reference_finger_follower as R

DEG = math.pi / 180.0


def half_unit(x_quoted_str):
    """Half a unit of the last quoted digit of a number given as a string, e.g. '84.50' -> 0.005."""
    s = x_quoted_str.split("e")[0]
    dec = len(s.split(".")[1]) if "." in s else 0
    return 0.5 * 10.0 ** (-dec)


def close_to_quoted(value, quoted: str, scale=1.0):
    """|value/scale - quoted| <= half a unit of the quoted last digit (plus round-off)."""
    return abs(value / scale - float(quoted)) <= half_unit(quoted) * (1.0 + 1e-9)


@pytest.fixture(scope="module")
def p():
    return R.reference_params()


@pytest.fixture(scope="module")
def kin(p):
    return R.build_kinematics(p)


@pytest.fixture(scope="module")
def kin_const(p, kin):
    return R.build_kinematics(p, variant="constant_ratio", table=kin.table)


@pytest.fixture(scope="module")
def run900(p, kin):
    # at least five revolutions so that the 2nd, 3rd and 5th can be compared
    return R.run_steady_state(900.0, p, kin, min_rev=5)


@pytest.fixture(scope="module")
def run2450(p, kin):
    return R.run_steady_state(2450.0, p, kin)


# =============================================================================================
# Closed forms
# =============================================================================================
def test_surge_model_closed_forms(p):
    sm = R.surge_model(35000.0, 504.46, 0.04)
    assert close_to_quoted(sm["m"], "9.290", 1e-3)
    assert close_to_quoted(sm["K_s1"], "93.33", 1e3)
    assert close_to_quoted(sm["K_s2"], "140.0", 1e3)
    assert close_to_quoted(sm["a"], "2.524", 1e-5)
    # series stiffness = K0
    k = 1.0 / (1.0 / sm["K_s1"] + 1.0 / sm["K_s2"] + 1.0 / sm["K_s1"])
    assert k == pytest.approx(35000.0, rel=1e-12)
    # clamped-clamped two-mass chain: modes f0 (in phase) and 2 f0 (anti-phase)
    K1, K2, m = sm["K_s1"], sm["K_s2"], sm["m"]
    Kmat = np.array([[K1 + K2, -K2], [-K2, K2 + K1]])
    lam, vec = np.linalg.eigh(Kmat / m)
    f = np.sqrt(lam) / (2 * math.pi)
    assert f == pytest.approx([504.46, 2 * 504.46], rel=1e-12)
    assert vec[0, 0] * vec[1, 0] > 0 and vec[0, 1] * vec[1, 1] < 0
    # stiffness-proportional damping: table values (printed 2.355 and 3.534, i.e. 2.3557 and 3.5336
    # truncated) and modal damping ratios 0.04 / 0.08
    assert sm["C_s1"] == pytest.approx(2.3557, abs=5e-5) and abs(sm["C_s1"] - 2.355) < 1e-3
    assert close_to_quoted(sm["C_s2"], "3.534")
    zeta = sm["a"] * np.sqrt(lam) / 2.0
    assert zeta == pytest.approx([0.04, 0.08], rel=1e-12)
    # the parameter dict carries the same values
    assert p["m1"] == p["m2"] == sm["m"]
    assert p["K_s3"] == p["K_s1"] and p["C_s3"] == p["C_s1"]


def test_contact_damping_reproduces_table2(p):
    Me = lambda l: R.equivalent_follower_mass(l, p["M_f"], p["I_f"])  # noqa: E731
    C_tf = R.contact_damping(p["K_tf"], p["M_t"], Me(p["L_tf"]))
    assert close_to_quoted(C_tf, "118.97")
    C_vf = R.contact_damping(p["K_vf"], p["M_v"] + p["m1"] + p["m2"], Me(p["L_vf"]))
    assert close_to_quoted(C_vf, "94.13")
    assert close_to_quoted(R.contact_damping(p["K_vf"], p["M_v"], Me(p["L_vf"])), "92.76")
    # C_fc = 197.97 corresponds to l = 12.72 mm (rigid cam), 212.06 with L_fc0 = 10.78 mm
    l = brentq(lambda x: R.contact_damping(p["K_fc"], Me(x)) - 197.97, 1e-3, 3e-2)
    assert close_to_quoted(l, "12.72", 1e-3)
    assert close_to_quoted(R.contact_damping(p["K_fc"], Me(p["L_fc0"])), "212.06")
    # radius of gyration 13.88 mm
    assert close_to_quoted(math.sqrt(p["I_f"] / p["M_f"]), "13.88", 1e-3)


def test_tappet_limits_and_time_constants(p):
    assert close_to_quoted(p["K_e"], "1.6432", 1e7)
    assert close_to_quoted(p["C_d_plus"], "2.6350", 1e6)
    assert close_to_quoted(p["C_d_minus"], "1.1281")
    tl = R.tappet_limits(p["A_e"], p["E_oil"], p["H_e"], p["mu_oil"], p["L_p"], p["R_p"], p["h_clear"])
    assert close_to_quoted(tl["C_d_plus_terms"][0], "2.6320", 1e6)
    assert close_to_quoted(tl["C_d_plus_terms"][1], "2987")
    assert close_to_quoted(p["K_tp"] / p["K_e_formula"], "4.046")
    for rpm, c_q, k_q, tau_q in ((900, "1.871", "4.601", "4.07"), (1600, "2.477", "4.930", "5.02")):
        a, b = R.alpha_beta(rpm)
        assert close_to_quoted(a * p["C_d_plus"], c_q, 1e4)
        assert close_to_quoted(b * p["K_e"], k_q, 1e6)
        assert close_to_quoted(a * p["C_d_plus"] / (b * p["K_e"]), tau_q, 1e-3)
    # the table2 preset swaps the stiffness only
    p2 = R.reference_params("table2")
    assert p2["K_e"] == 6.648e7 and p2["C_d_plus"] == p["C_d_plus"]
    # K_s is about 0.1 % of beta K_e
    assert p["K_s"] / (0.28 * p["K_e"]) == pytest.approx(1.3e-3, abs=3e-4)


def test_preloads_and_thresholds(p):
    assert close_to_quoted(p["F_vf0"], "42.55")
    assert close_to_quoted(p["F_fc0"], "62.55")
    # moment and force balance of the follower on the base circle (paper's moments)
    assert p["F_fc0"] - p["F_tf0"] - p["F_vf0"] == pytest.approx(0.0, abs=1e-12)
    assert (p["F_tf0"] * p["L_tf"] + p["F_fc0"] * p["L_fc0"] - p["F_vf0"] * p["L_vf"]) == pytest.approx(
        0.0, abs=1e-13)
    assert close_to_quoted(p["F_tf0"] / p["K_tf"], "0.36", 1e-6)
    assert close_to_quoted(p["F_fc0"] / p["K_fc"], "0.75", 1e-6)
    assert close_to_quoted(p["F_vf0"] / p["K_vf"], "0.98", 1e-6)
    assert close_to_quoted(p["F_o"] / p["K_se"], "20.99", 1e-6)
    assert close_to_quoted(p["F_vf0"] / p["K_se"], "3.2", 1e-6)
    assert p["Y_v_star"] == pytest.approx((p["F_o"] - p["F_vf0"]) / p["K_se"], rel=1e-15)
    assert p["d_c0"] == pytest.approx(25.00e-3, rel=1e-12)
    assert close_to_quoted(p["L_fc0"], "10.78", 1e-3)


def test_alpha_beta_speed_law():
    assert R.alpha_beta(900) == (0.0071, 0.28)
    assert R.alpha_beta(1600) == (0.0094, 0.30)
    assert R.alpha_beta(600) == (0.0071, 0.28) and R.alpha_beta(2450) == (0.0094, 0.30)
    a, b = R.alpha_beta(1250)
    assert a == pytest.approx(0.5 * (0.0071 + 0.0094)) and b == pytest.approx(0.29)
    assert R.alpha_beta(1250, law="step") == (0.0071, 0.28)
    assert R.alpha_beta(1600, law="step") == (0.0094, 0.30)
    p = R.reference_params(ab_law="step")
    assert R.alpha_beta(1599, p) == (0.0071, 0.28)


# =============================================================================================
# Statics
# =============================================================================================
@pytest.mark.parametrize("opts", [{}, {"moment_cos": True}, {"clip_tension": True}, {"F_tf0": 60.0}])
def test_rest_state_is_static_equilibrium(opts, kin):
    p = R.reference_params(**opts)
    y0 = np.zeros(12)
    for theta in (-math.pi, -2.5, -1.7, 1.8, 3.0):
        for rpm in (0.0, 900.0, 2450.0):
            omega = 2 * math.pi * rpm / 60
            f = R.rhs(0.0, y0, omega, theta, p, kin, rpm=rpm)
            # accelerations: only round-off of the preload balance (F L / I_f ~ 1e5 m/s^2 scale)
            assert np.max(np.abs(f)) < 1e-9
            F = R.contact_forces(theta, y0, omega, p, kin, rpm=rpm)
            assert F["F_tf"] == pytest.approx(p["F_tf0"], abs=1e-12)
            assert F["F_fc"] == pytest.approx(p["F_fc0"], abs=1e-9)
            assert F["F_vf"] == pytest.approx(p["F_vf0"], abs=1e-12)
            assert F["F_seat"] == pytest.approx(p["F_o"] - p["F_vf0"], abs=1e-12)
            assert F["mode"] == (True, True, True, True, True)


def test_valve_branches_agree_at_lift_off(p, kin):
    """Eq. 8f and 8g give the same force at Y_v* (with zero valve velocity)."""
    y = np.zeros(12)
    y[5] = p["Y_v_star"]
    omega = 0.0
    a_seat = R.rhs(0.0, y, omega, -math.pi, p, kin, rpm=900, mode=(True, True, True, True, True))
    a_open = R.rhs(0.0, y, omega, -math.pi, p, kin, rpm=900, mode=(True, True, True, False, True))
    assert a_seat[11] == pytest.approx(a_open[11], abs=1e-9)


# =============================================================================================
# Kinematics
# =============================================================================================
def test_base_geometry(p):
    geo = R.base_geometry(p)
    assert close_to_quoted(geo["A"][0], "25.488", 1e-3) and close_to_quoted(geo["A"][1], "25.987", 1e-3)
    assert close_to_quoted(geo["C0"][0], "23.724", 1e-3) and close_to_quoted(geo["C0"][1], "-20.980", 1e-3)
    assert close_to_quoted(geo["P0"][0], "25.000", 1e-3) and close_to_quoted(geo["P0"][1], "12.996", 1e-3)
    assert close_to_quoted(geo["angle_B"] / DEG, "87.04")
    assert close_to_quoted(geo["BP0"], "28.18", 1e-3)
    assert close_to_quoted(geo["normal_deg"], "87.85")
    assert close_to_quoted(geo["g0"] / DEG, "-92.15")
    # triangle sides
    A, C0, P0 = geo["A"], geo["C0"], geo["P0"]
    assert np.hypot(*A) == pytest.approx(p["R_ab"], rel=1e-14)
    assert np.hypot(*C0) == pytest.approx(p["R_1"], rel=1e-14)
    assert np.hypot(*(A - C0)) == pytest.approx(p["R_c"] + p["R_f"], rel=1e-14)
    assert np.hypot(*(P0 - A)) == pytest.approx(p["R_c"], rel=1e-14)


def test_rocker_ratio_on_base_circle(p, kin):
    geo = R.base_geometry(p)
    for th in (-math.pi, -2.0, -1.6, 1.6, 2.9):
        k = R.contact_kinematics(th, p, geo=geo)
        assert k["gamma"] == pytest.approx(th, abs=1e-12)
        assert k["RR"] == pytest.approx(1.47, abs=1e-12)
        assert k["phi"] == pytest.approx(0.0, abs=1e-13)
        assert float(kin("RR", th)) == pytest.approx(1.47, abs=1e-12)


def test_rigid_limit_has_zero_deflections(p, kin):
    """theta_f = phi, Y_f = L_tf sin(phi), Y_t = 0, Y_v = Y_v,kin give d_tf = d_fc = d_vf = 0."""
    geo = R.base_geometry(p)
    for th in np.linspace(-1.5, 1.5, 13):
        k = R.contact_kinematics(th, p, geo=geo)
        y = np.zeros(12)
        y[2] = k["phi"]
        y[1] = p["L_tf"] * math.sin(k["phi"])
        y[5] = k["Y_v_kin"]
        d_tf = y[1] - p["L_tf"] * math.sin(y[2]) - y[0]
        d_fc = k["Y_c"] - y[1] - k["L_fc"] * math.sin(y[2])
        d_vf = y[1] - y[5] + p["L_vf"] * math.sin(y[2])
        assert max(abs(d_tf), abs(d_fc), abs(d_vf)) < 1e-17
        # the same through the splines used by the dynamics (table spline error only)
        y[2] = float(kin("phi", th))
        y[1] = p["L_tf"] * math.sin(y[2])
        y[5] = float(kin("Y_v_kin", th))
        F = R.contact_forces(th, y, 0.0, p, kin)
        assert abs(F["d_tf"]) < 1e-17 and abs(F["d_vf"]) < 1e-15 and abs(F["d_fc"]) < 1e-12


def test_contact_lies_on_common_normal(p):
    """|BC| = R_1, |CP| = R_f, P on the cam profile, and the cam normal at P passes through C."""
    geo = R.base_geometry(p)
    for th in (-1.2, -0.68, -0.2, 0.0, 0.3, 0.65, 1.3):
        k = R.contact_kinematics(th, p, geo=geo)
        C, P = k["C"], k["P"]
        assert np.hypot(*C) == pytest.approx(p["R_1"], rel=1e-13)
        assert np.hypot(*(C - P)) == pytest.approx(p["R_f"], rel=1e-12)
        # tangent of the rotated cam profile at P: dP/dgamma is parallel to t, perpendicular to C - P
        S, S1, S2 = R.cam_lift(k["gamma"], p)
        sig = p["cam_sense"]
        psi = geo["g0"] + sig * (th - k["gamma"])
        t = np.array([sig * math.sin(psi), -sig * math.cos(psi)])
        assert abs(np.dot(t, C - P)) < 1e-15


def test_spline_matches_exact_kinematics(p, kin):
    geo = R.base_geometry(p)
    rng = np.random.default_rng(4)
    for th in rng.uniform(-1.6, 1.6, 25):
        k = R.contact_kinematics(th, p, gamma_guess=th, geo=geo)
        Yc, dYc, Lfc, dLfc = kin.eval(th)
        assert Yc == pytest.approx(k["Y_c"], abs=2e-11)
        assert Lfc == pytest.approx(k["L_fc"], abs=2e-11)
        assert dYc == pytest.approx(k["dY_c"], abs=5e-8)
        assert dLfc == pytest.approx(k["dL_fc"], abs=5e-8)
        # exact derivatives against central differences of the exact kinematics
        h = 1e-6
        kp = R.contact_kinematics(th + h, p, gamma_guess=k["gamma"], geo=geo)
        km = R.contact_kinematics(th - h, p, gamma_guess=k["gamma"], geo=geo)
        assert k["dY_c"] == pytest.approx((kp["Y_c"] - km["Y_c"]) / (2 * h), abs=1e-9)
        assert k["dL_fc"] == pytest.approx((kp["L_fc"] - km["L_fc"]) / (2 * h), abs=1e-9)
        assert k["dphi"] == pytest.approx((kp["phi"] - km["phi"]) / (2 * h), abs=1e-8)
    # fast scalar evaluation = CubicSpline evaluation, including outside [-pi, pi)
    for th in (-7.0, -3.0, 0.123, 2.0, 9.5):
        Yc, dYc, Lfc, dLfc = kin.eval(th)
        assert Yc == pytest.approx(float(kin("Y_c", th)), abs=1e-15)
        assert dYc == pytest.approx(float(kin("Y_c", th, 1)), abs=1e-13)
        assert Lfc == pytest.approx(float(kin("L_fc", th)), abs=1e-15)
        assert dLfc == pytest.approx(float(kin("L_fc", th, 1)), abs=1e-13)


def _extremum(fun, a, b, sign):
    r = minimize_scalar(lambda t: sign * fun(t), bounds=(a, b), method="bounded",
                        options={"xatol": 1e-10})
    return sign * r.fun, r.x / DEG


def test_reference_cam_kinematics_against_quoted_values(p):
    geo = R.base_geometry(p)
    ck = lambda th, key: R.contact_kinematics(th, p, geo=geo)[key]  # noqa: E731
    rr_min, th_min = _extremum(lambda t: ck(t, "RR"), -80 * DEG, -5 * DEG, 1)
    rr_max, th_max = _extremum(lambda t: ck(t, "RR"), 5 * DEG, 80 * DEG, -1)
    assert close_to_quoted(rr_min, "1.265") and abs(th_min + 39) < 1.0      # "39 deg before the nose"
    assert close_to_quoted(rr_max, "1.980") and abs(th_max - 37) < 1.0
    assert close_to_quoted(ck(0.0, "RR"), "1.604")
    # the paper's range 1.15 to 1.97 cannot be reached with a symmetric lift on this geometry: max only
    assert rr_max > 1.97
    yv, _ = _extremum(lambda t: ck(t, "Y_v_kin"), -30 * DEG, 30 * DEG, -1)
    assert close_to_quoted(yv, "9.512", 1e-3)
    yc, _ = _extremum(lambda t: ck(t, "Y_c"), -30 * DEG, 30 * DEG, -1)
    assert close_to_quoted(yc, "6.081", 1e-3)
    ph, _ = _extremum(lambda t: ck(t, "phi"), -30 * DEG, 30 * DEG, -1)
    assert close_to_quoted(ph / DEG, "15.0")
    lmin, _ = _extremum(lambda t: ck(t, "L_fc"), 5 * DEG, 80 * DEG, 1)
    lmax, _ = _extremum(lambda t: ck(t, "L_fc"), -80 * DEG, -5 * DEG, -1)
    assert close_to_quoted(lmin, "4.34", 1e-3) and close_to_quoted(lmax, "14.84", 1e-3)
    # smallest cam radius of curvature (convex cam)
    rho, _ = _extremum(lambda g: float(R.cam_radius_of_curvature(g, p)), -80 * DEG, -1 * DEG, 1)
    assert close_to_quoted(rho, "3.14", 1e-3)
    g = np.linspace(-math.pi, math.pi, 20001)
    assert R.cam_radius_of_curvature(g, p).min() > 0


def test_valve_open_duration(p):
    """Kinematic valve lift over 0.1 mm: quoted 156.9 deg (and '157 deg' elsewhere in the specification).

    Root-finding on the exact kinematics gives 157.16 deg, 0.26 deg more than the 156.9 quoted. We
    could not find the definition behind 156.9: the flat-follower lift S > 0.1 mm gives 155.15, the
    cam input Y_c 153.79, the valve lift above 0.1 mm plus Y_v* 155.80, the dynamic valve lift at
    600 rpm 155.5 deg; a 0.25 deg table gives 157.0 or 157.25. The test therefore checks the value
    against the quoted one within 0.3 deg (the size of the unexplained difference, documented, and
    about 1/25 of the slope-equivalent of a 0.01 mm change of the threshold: 0.4 deg), and its own
    value to 0.01 deg, so that any change of the kinematics is still caught.
    """
    geo = R.base_geometry(p)
    f = lambda t: R.contact_kinematics(t, p, geo=geo)["Y_v_kin"] - 1e-4  # noqa: E731
    a = brentq(f, -89 * DEG, -45 * DEG, xtol=1e-13)
    b = brentq(f, 45 * DEG, 89 * DEG, xtol=1e-13)
    width = (b - a) / DEG
    assert abs(width - 156.9) < 0.3
    assert width == pytest.approx(157.165, abs=0.01)
    assert round(width) == 157


def test_cam_sense_mirrors_the_flanks(p):
    """Counter-clockwise rotation swaps the flanks: RR_+(theta) = RR_-(-theta) (symmetric lift)."""
    p1 = R.reference_params(cam_sense=1)
    g0, g1 = R.base_geometry(p), R.base_geometry(p1)
    for th in (-1.0, -0.68, -0.3, 0.2, 0.65, 1.1):
        k0 = R.contact_kinematics(-th, p, geo=g0)
        k1 = R.contact_kinematics(th, p1, geo=g1)
        assert k1["RR"] == pytest.approx(k0["RR"], abs=1e-12)
        assert k1["Y_c"] == pytest.approx(k0["Y_c"], abs=1e-15)


def test_constant_ratio_variant(p, kin, kin_const):
    th = np.linspace(-math.pi, math.pi, 721)
    assert np.allclose(kin_const("RR", th), p["RR0"], rtol=0, atol=1e-14)
    assert np.allclose(kin_const("L_fc", th), p["L_fc0"], rtol=0, atol=1e-16)
    assert np.allclose(kin_const("Y_v_kin", th), kin("Y_v_kin", th), rtol=0, atol=1e-16)
    assert np.allclose(kin_const("Y_c", th) * p["RR0"], kin("Y_v_kin", th), rtol=0, atol=1e-15)


# =============================================================================================
# Energy, linearised modes
# =============================================================================================
def _undamped(p):
    q = dict(p)
    for k in ("C_tf", "C_fc", "C_vf", "C_se", "C_s1", "C_s2", "C_s3"):
        q[k] = 0.0
    return q


def _energy_run(p, kin, theta, v, alpha, t_end=3e-3, n=61):
    """Cam held at theta; start from the static equilibrium with follower/valve velocities v."""
    q = R.static_equilibrium(theta, p, kin, 0.28)
    y0 = np.r_[q, np.zeros(6)]
    y0[7], y0[11], y0[8] = v
    t = np.linspace(0.0, t_end, n)
    res = R.simulate(p, kin, y0, theta, 0.0, t_end, alpha=alpha, beta=0.28, t_eval=t)
    E = np.array([R.mechanical_energy(theta, y, p, kin, 0.28) for y in res["y"].T])
    E0 = R.mechanical_energy(theta, y0, p, kin, 0.28)
    Ek = 0.5 * (p["M_f"] * v[0] ** 2 + p["M_v"] * v[1] ** 2 + p["I_f"] * v[2] ** 2)
    return res, E, E0, Ek


@pytest.mark.parametrize("theta, v, switches", [
    (-math.pi, (-0.6, 0.4, 20.0), {"g_tf", "g_vf", "g_fc", "g_seat"}),   # base circle: seat opens
    pytest.param(-0.4, (-0.6, -0.4, 20.0), {"g_tf", "g_vf", "g_fc"},     # opening flank, valve open
                 marks=pytest.mark.slow),
])
def test_energy_is_conserved_without_damping_through_separations(kin, theta, v, switches):
    """moment_cos=True is virtual-work consistent: with all damping zero the energy is conserved,
    also through contact separations and the seat switch (the elastic forces are continuous there).

    Bound: 1e-6 of the kinetic energy put in (measured drift 1.6e-7 with the default tolerances:
    about 2e-12 m of deflection error); the paper's moments without cos(theta_f), which are not
    conservative, drift by 2e-3 at the 11 deg follower rotation of the second case.
    """
    p = _undamped(R.reference_params(moment_cos=True))
    res, E, E0, Ek = _energy_run(p, kin, theta, v, alpha=0.0)
    assert switches <= {e["name"] for e in res["events"]}
    assert np.max(np.abs(E - E0)) < 1e-6 * Ek
    if theta > -1.0:
        p_paper = _undamped(R.reference_params(moment_cos=False))
        _, E, E0, Ek = _energy_run(p_paper, kin, theta, v, alpha=0.0)
        assert np.max(np.abs(E - E0)) > 1e-4 * Ek


def test_energy_decreases_with_damping(kin):
    p = R.reference_params(moment_cos=True)
    res, E, E0, Ek = _energy_run(p, kin, -math.pi, (-0.6, 0.4, 20.0), alpha=0.0071, n=301)
    assert E[0] == E0
    assert np.all(np.diff(E) <= 1e-6 * Ek)
    assert E[-1] - E0 < -0.5 * Ek


def test_linearised_modes(p, kin):
    seated = R.linearised_modes(p, kin, "seated", rpm=900)
    f = seated["freq_hz"]
    # the highest mode is about 11.3 kHz (quoted "about 11 kHz (11.3 kHz)")
    assert close_to_quoted(f[-1] / 1e3, "11.3")
    # with the valve nearly held by the seat, the spring masses show the surge pair f0, 2 f0
    assert f[0] == pytest.approx(504.46, rel=0.01) and f[1] == pytest.approx(2 * 504.46, rel=0.01)
    # symmetric stiffness about the rest state (theta_f = 0)
    K = seated["K"]
    assert np.allclose(K, K.T, rtol=1e-6, atol=1e-6 * np.abs(K).max())
    nose = R.linearised_modes(p, kin, "nose", rpm=900)
    q = nose["q_eq"]
    assert q[5] > p["Y_v_star"]                      # valve open
    F = R.contact_forces(0.0, np.r_[q, np.zeros(6)], 0.0, p, kin)
    assert min(F["F_tf"], F["F_fc"], F["F_vf"]) > 0  # all contacts carry load
    assert F["F_seat"] == 0.0
    assert 10e3 < nose["freq_hz"][-1] < 11.3e3
    # static tappet compression at the nose = (F_tf - F_tf0)/(K_s + beta K_e)
    assert q[0] == pytest.approx((F["F_tf"] - p["F_tf0"]) / (p["K_s"] + 0.28 * p["K_e"]), rel=1e-8)


# =============================================================================================
# Dynamics: reference runs quoted by the specification
# =============================================================================================
@pytest.mark.slow
def test_run_in_converges_900(run900):
    r = run900
    assert r["converged"] and r["n_rev"] >= 5
    diffs = [h["diff"] for h in r["history"]]
    assert diffs[-1] < 1e-4
    # the Poincare-section change decays (steady state reached, not a slow drift)
    assert diffs[-1] < diffs[0] * 1e-3


@pytest.mark.slow
def test_max_leakdown_900(run900, p):
    """Quoted: max Y_t 84.50 um at 900 rpm; the 2nd, 3rd and 5th revolutions give the same value."""
    s = run900["summary"]
    assert close_to_quoted(s["max_tappet_leakdown"], "84.50", 1e-6)
    assert close_to_quoted(s["max_tappet_leakdown"], "85", 1e-6)      # tappet-stiffness decision: "85 um at 900 rpm"
    h = run900["history"]
    for k in (1, 2, 4):
        assert close_to_quoted(h[k]["max_Y_t"], "84.50", 1e-6)
        assert h[k]["max_Y_t"] == pytest.approx(s["max_tappet_leakdown"], abs=1e-12)
    # the paper measured "at most about 0.1 mm" of tappet motion
    assert s["max_tappet_leakdown"] < 1e-4


@pytest.mark.slow
def test_run900_sanity(run900, p):
    s = run900["summary"]
    st = run900["steady"]
    assert s["openings"] == 1 and not s["bounce"]
    assert s["separations"] == []
    assert s["min_F_tf"] > 0 and s["min_F_fc"] > 0 and s["min_F_vf"] > 0
    assert s["seating_velocity"] < 0
    # dynamic lift close to the kinematic one minus the tappet's share (RR - 1 = 0.5 .. 0.6)
    assert 9.3e-3 < s["max_valve_lift"] < 9.512e-3
    # the run ends at rest on the base circle with the preloads
    i = np.argmin(np.abs(st["theta_deg"] - 150.0))
    assert st["F_fc"][i] == pytest.approx(p["F_fc0"], abs=0.5)
    assert abs(st["y"][0][i]) < 1e-7


@pytest.mark.slow
def test_flank_peaks_2450_variable(run2450):
    """Quoted (cam-sense decision): opening-flank peak 680 N, closing-flank peak 1085 N at 2450 rpm."""
    s = run2450["summary"]
    assert close_to_quoted(s["peak_cam_force_opening"], "680")
    assert close_to_quoted(s["peak_cam_force_closing"], "1085")
    assert s["theta_peak_opening_deg"] < -60 and 40 < s["theta_peak_closing_deg"] < 55


@pytest.mark.slow
def test_tappet_contact_grazes_at_2450(run2450):
    """Quoted (HLA-preload decision): at 2450 rpm the tappet/follower contact already grazes zero with F_tf0 = 20 N."""
    s = run2450["summary"]
    seps = [x for x in s["separations"] if x[0] == "tappet/follower"]
    assert len(seps) >= 1
    assert abs(s["min_F_tf"]) < 2.0                   # grazing: the (damping-)tensile dip is small
    assert all(x[0] == "tappet/follower" for x in s["separations"])
    assert s["openings"] == 1
    assert run2450["converged"]


@pytest.mark.slow
def test_constant_ratio_flank_peaks_2450(run2450, p, kin_const):
    """Quoted (cam-sense decision): constant rocker ratio gives 761 N (opening) and 859 N (closing): the variable
    ratio lowers the first peak and raises the second, as the paper's Fig. 12 says."""
    rc = R.run_steady_state(2450.0, p, kin_const)
    s, sv = rc["summary"], run2450["summary"]
    assert close_to_quoted(s["peak_cam_force_opening"], "761")
    assert close_to_quoted(s["peak_cam_force_closing"], "859")
    assert sv["peak_cam_force_opening"] < s["peak_cam_force_opening"]
    assert sv["peak_cam_force_closing"] > s["peak_cam_force_closing"]
    # the same kinematic valve lift: the dynamic lifts agree closely
    assert s["max_valve_lift"] == pytest.approx(sv["max_valve_lift"], abs=5e-5)


@pytest.mark.slow
def test_max_leakdown_600(p, kin):
    """Quoted (tappet-stiffness decision): 92 um at 600 rpm with K_e."""
    r = R.run_steady_state(600.0, p, kin)
    assert close_to_quoted(r["summary"]["max_tappet_leakdown"], "92", 1e-6)


@pytest.mark.slow
def test_max_leakdown_table2_preset(kin):
    """Quoted (tappet-stiffness decision): 24 um at 900 rpm with Table 2's K_tp (4 times stiffer)."""
    p2 = R.reference_params("table2")
    r = R.run_steady_state(900.0, p2, kin)
    assert close_to_quoted(r["summary"]["max_tappet_leakdown"], "24", 1e-6)


@pytest.mark.slow
def test_clip_tension_forces_non_negative(kin):
    p = R.reference_params(clip_tension=True)
    r = R.run_steady_state(2450.0, p, kin)
    st = r["steady"]
    for k in ("F_tf", "F_fc", "F_vf", "F_seat"):
        assert st[k].min() >= -1e-9
    # the clipped interval of the tappet/follower force is reported
    assert any(x[0] == "tappet/follower" for x in r["summary"]["tension_intervals"] + r["summary"]["separations"])
    # clipping a sub-newton tensile dip hardly changes the peaks
    assert r["summary"]["peak_cam_force_closing"] == pytest.approx(1085.0, abs=5.0)


@pytest.mark.slow
def test_default_accuracy_against_tight_dop853(p, kin):
    """The module's default integrator settings (RK45, rtol 1e-10, DEFAULT_ATOL, max_step T/1000)
    against DOP853 at rtol 1e-12, atol/100, max_step T/20000: one revolution from rest at 2450 rpm.
    The module docstring claims 1e-4 N in the forces and under 1e-12 m in the displacements."""
    rpm = 2450.0
    omega = 2 * math.pi * rpm / 60
    T = 2 * math.pi / omega
    t = T * np.arange(3600) / 3600
    a = R.simulate(p, kin, np.zeros(12), -math.pi, omega, T, t_eval=t)
    b = R.simulate(p, kin, np.zeros(12), -math.pi, omega, T, t_eval=t, method="DOP853", rtol=1e-12,
                   atol=R.DEFAULT_ATOL / 100, max_step=T / 20000)
    d = np.abs(a["y"] - b["y"]).max(axis=1)
    assert np.all(d[[0, 1, 3, 4, 5]] < 1e-12)
    assert d[2] * p["L_vf"] < 1e-12
    for k in ("F_tf", "F_fc", "F_vf", "F_seat", "F_drag"):
        assert np.max(np.abs(a[k] - b[k])) < 1e-3
    assert [e["name"] for e in a["events"] if e["name"] != "vt"] == [
        e["name"] for e in b["events"] if e["name"] != "vt"]


@pytest.mark.slow
def test_hybrid_integration_matches_plain_switching_rhs(p, kin):
    """The event-driven integrator against a plain RK45 run whose right-hand side switches modes by
    itself (the specification's reference-run set-up, max_step = T/20000), one revolution from rest at 900 rpm.

    The plain run steps over its switches without locating them; at rtol 1e-10 it differs from the
    hybrid run by 8e-12 m at most (measured). The bound 2e-11 m (0.002 N of contact force) is that
    error with a margin of 2.5; a mis-handled switch in the hybrid integrator (a wrong mode for one
    step of a few us) shows up as 1e-9 m or more.
    """
    from scipy.integrate import solve_ivp

    rpm = 900.0
    omega = 2 * math.pi * rpm / 60
    T = 2 * math.pi / omega
    t = T * np.arange(3600) / 3600
    hy = R.simulate(p, kin, np.zeros(12), -math.pi, omega, T, t_eval=t)
    pl = solve_ivp(lambda tt, y: R.rhs(tt, y, omega, -math.pi, p, kin, rpm=rpm), (0, T), np.zeros(12),
                   method="RK45", t_eval=t, rtol=1e-10, atol=R.DEFAULT_ATOL, max_step=T / 20000)
    assert pl.success
    d = np.abs(hy["y"] - pl.y).max(axis=1)
    assert np.all(d[[0, 1, 3, 4, 5]] < 2e-11)
    assert d[2] * p["L_vf"] < 2e-11

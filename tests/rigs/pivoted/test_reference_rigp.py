"""Quick self-checks of the independent Rig P reference (tests/rigs/pivoted/reference_rigp.py).

Total runtime is well under 20 s.
"""

import math

import numpy as np
import pytest

from tests.rigs.pivoted import reference_rigp as R

BETA = 24.7e9  # N s m^-2.5 (Table 2 operating points)
N_EXP = 1.5
MU = 0.2


@pytest.fixture(scope="module")
def p():
    return R.reference_params(0.2)


@pytest.fixture(scope="module")
def sanity_run(p):
    a_s = R.static_equilibrium(0.0, p)
    return R.run_hybrid(a_s, 0.0, 0.0, 16.0, 0.3, p, BETA, N_EXP, MU)


def test_hertz_constant(p):
    assert p["k_H"] == pytest.approx(8.0e9, rel=0.01)
    assert p["h_p"] == pytest.approx(0.5 * 0.0127 + 2 * 0.0032, rel=1e-15)
    assert p["e"] == pytest.approx(0.2 * 0.0175, rel=1e-15)


def test_closed_forms_match_paper_expressions(p):
    rng = np.random.default_rng(1)
    a = rng.uniform(-0.2, 0.3, 50)
    ad = rng.uniform(-10, 10, 50)
    th = rng.uniform(0, 2 * np.pi, 50)
    W = 2 * np.pi * 16.0
    # (S-5) and (S-7) against the closed forms of docs/rig_p.md
    np.testing.assert_allclose(R.gap(a, th, p), R.gap_paper_S5(a, th, p), rtol=0, atol=1e-15)
    np.testing.assert_allclose(R.gap_rate(a, ad, th, W, p), R.gap_rate_paper_S7(a, ad, th, W, p),
                               rtol=0, atol=1e-13)
    # 0-state: psi_i = 0 there, and it is the largest distance from E (d psi/d alpha at fixed
    # E-to-line distance): psi_j = 0 at the 0-state too
    a0, th0 = R.zero_state(p)
    assert abs(R.gap(a0, th0, p)) < 1e-15
    assert abs(R.psi_j(a0, th0, p)) < 1e-15
    # time derivatives by central differences along a smooth path
    h = 1e-6
    for k in range(5):
        t = 0.01 * k
        al = lambda s: 0.05 + 0.1 * np.sin(3 * s)  # noqa: E731
        ald = 0.3 * np.cos(3 * t)
        thf = lambda s: 0.4 + W * s  # noqa: E731
        d_psi = (R.gap(al(t + h), thf(t + h), p) - R.gap(al(t - h), thf(t - h), p)) / (2 * h)
        d_psij = (R.psi_j(al(t + h), thf(t + h), p) - R.psi_j(al(t - h), thf(t - h), p)) / (2 * h)
        assert d_psi == pytest.approx(R.gap_rate(al(t), ald, thf(t), W, p), rel=1e-7, abs=1e-10)
        assert d_psij == pytest.approx(R.psi_j_rate(al(t), ald, thf(t), W, p), rel=1e-7, abs=1e-10)


def test_contact_force_law(p):
    a_c = R.contact_angle(0.3, p)
    assert abs(R.gap(a_c, 0.3, p)) < 1e-15
    assert R.contact_force(a_c + 1e-4, 0.0, 0.3, 0.0, p, BETA, N_EXP) == 0.0  # separated
    a = a_c - 1e-4
    delta = -R.gap(a, 0.3, p)
    dpsi = R.gap_rate(a, 2.0, 0.3, 100.0, p)
    F = R.contact_force(a, 2.0, 0.3, 100.0, p, BETA, N_EXP)
    assert F == pytest.approx(p["k_H"] * delta ** 1.5 - BETA * delta ** 1.5 * dpsi, rel=1e-14)
    # viscous case: delta**0 = 1, force is unclipped (tensile when separating fast)
    Fv = R.contact_force(a, 50.0, 0.3, 0.0, p, 1470.0, 0.0)
    dpsi_v = R.gap_rate(a, 50.0, 0.3, 0.0, p)
    assert Fv == pytest.approx(p["k_H"] * delta ** 1.5 - 1470.0 * dpsi_v, rel=1e-14)
    assert Fv < 0.0
    assert R.contact_force(a, 50.0, 0.3, 0.0, p, 1470.0, 0.0, clip=True) == 0.0


def test_free_flight_energy_conserved():
    # Cam raised by 20 mm so that the follower never reaches it.
    q = R.reference_params(0.2)
    q["PE_y"] += 0.02
    r = R.run_hybrid(-0.05, 0.0, 0.0, 16.0, 0.05, q, BETA, N_EXP, MU)
    assert r["contacts"] == []
    t = np.linspace(0.0, 0.05, 41)
    A, AD, C = r["evaluate"](t)
    assert not C.any()
    assert np.all(R.gap(A, 2 * np.pi * 16.0 * t, q) > 0)
    E = R.free_flight_energy(A, AD, q)
    scale = np.max(0.5 * q["I_b"] * AD ** 2)  # the energy exchanged, not an arbitrary offset
    assert scale > 1e-4
    assert np.max(np.abs(E - E[0])) / scale < 1e-10


def test_static_equilibrium(p):
    a_s = R.static_equilibrium(0.0, p)
    psi = R.gap(a_s, 0.0, p)
    assert psi < 0
    acc = R.angular_acceleration(a_s, 0.0, 0.0, 0.0, p, BETA, N_EXP, MU, True)
    torque_scale = p["m_b"] * p["g"] * p["l_g"] / p["I_b"]
    assert abs(acc) < 1e-9 * torque_scale
    # free-flight torque at alpha* is towards the cam, balanced by about 1 N of contact force
    F = R.contact_force(a_s, 0.0, 0.0, 0.0, p, BETA, N_EXP)
    assert 0.1 < F < 10.0
    # with the cam standing still the follower stays there (one open contact from t = 0).
    # mu = 0 here: with Theta_dot = 0, v_r is proportional to alpha_dot, and Coulomb friction
    # sgn(v_r) at rest makes the ODE chatter (a sticking problem), as the model says it would.
    r = R.run_hybrid(a_s, 0.0, 0.0, 0.0, 0.01, p, BETA, N_EXP, 0.0)
    assert len(r["contacts"]) == 1
    c = r["contacts"][0]
    assert c["t_start"] == 0.0 and math.isnan(c["t_end"])
    assert abs(r["final"][0] - a_s) < 1e-12 and abs(r["final"][1]) < 1e-8
    assert c["peak_force"] == pytest.approx(F, rel=1e-6)


def test_sanity_run(sanity_run, p):
    r = sanity_run
    cs = r["contacts"]
    assert len(cs) >= 1
    closed = [c for c in cs if not math.isnan(c["t_end"])]
    assert closed
    for c in closed:
        dur = c["t_end"] - c["t_start"]
        assert 20e-6 < dur < 2000e-6, dur
        assert c["peak_force"] > 100.0
        assert 0 < c["peak_indentation"] < 100e-6
        assert c["dpsi_start"] < 0 < c["dpsi_end"]  # approach, then separation
        assert c["dpsi_end"] < -c["dpsi_start"]  # energy is lost
    # impacts after the first one, roughly once per cam revolution (62.5 ms)
    starts = np.array([c["t_start"] for c in cs])
    assert np.all(np.diff(starts[1:]) > 0.04)
    assert r["alpha_m"] >= max(R.static_equilibrium(0.0, p), r["final"][0])
    A, AD, C = r["evaluate"](np.array([r["t_alpha_m"]]))
    assert A[0] == pytest.approx(r["alpha_m"], rel=1e-12)
    assert abs(AD[0]) < 1e-6


def test_peaks_are_continuous_maxima(sanity_run, p):
    r = sanity_run
    W = 2 * np.pi * 16.0
    c = r["contacts"][1]
    t = np.linspace(c["t_start"], c["t_end"], 20001)
    A, AD, _ = r["evaluate"](t)
    F = R.contact_force(A, AD, W * t, W, p, BETA, N_EXP)
    d = -R.gap(A, W * t, p)
    assert c["peak_force"] >= F.max() * (1 - 1e-12)
    assert c["peak_force"] == pytest.approx(F.max(), rel=1e-7)
    assert c["peak_indentation"] >= d.max() * (1 - 1e-12)
    # at the peak indentation the gap rate vanishes
    At, ADt, _ = r["evaluate"](np.array([c["t_peak_indentation"]]))
    assert abs(R.gap_rate(At[0], ADt[0], W * c["t_peak_indentation"], W, p)) < 1e-6


def test_event_states_on_the_boundary(sanity_run, p):
    r = sanity_run
    W = 2 * np.pi * 16.0
    for c in r["contacts"][1:]:
        for tt in (c["t_start"], c["t_end"]):
            if math.isnan(tt):
                continue
            A, AD, _ = r["evaluate"](np.array([tt]))
            assert abs(R.gap(A[0], W * tt, p)) < 1e-13


def test_restitution(p):
    a_c = R.contact_angle(0.0, p)
    W = 2 * np.pi * 16.0
    r = R.run_restitution(a_c, 0.0, 0.0, 16.0, 0.2, p, 1.0, 0.8)
    assert len(r["impacts"]) >= 2
    for im in r["impacts"]:
        th = W * im["t"]
        before = R.gap_rate(im["alpha"], im["alpha_dot_before"], th, W, p)
        after = R.gap_rate(im["alpha"], im["alpha_dot_after"], th, W, p)
        assert before < 0
        assert im["xi"] == pytest.approx(1.0 - 0.8 * im["v_a"], rel=1e-14)
        assert after == pytest.approx(-im["xi"] * before, rel=1e-10)
        assert abs(R.gap(im["alpha"], th, p)) < 1e-13
    with pytest.raises(ValueError):
        R.run_restitution(a_c, 0.0, 0.0, 16.0, 0.2, p, 1.0, 5.0)  # xi = 1 - 5*0.35 < 0

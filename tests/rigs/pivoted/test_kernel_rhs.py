"""The kernel's fused right-hand side and snapshot against the public (composable) formulas."""

from __future__ import annotations

import math

import numpy as np
import pytest

from impactid import SUNDAR2016, HuntCrossley, contact
from impactid.rigs.pivoted import kernel as K
from impactid.rigs.pivoted.runs import pack_law, pack_rig


def _reference_acceleration(rig, law, mode, t, a, ad, theta_ref, omega):
    th = theta_ref + omega * t
    torque = rig.free_torque(a)
    if mode == K.FREE:
        return torque / rig.I_b
    psi = rig.gap(a, th)
    chi = rig.lever_arm(a, th)
    dpsi = rig.gap_rate(a, ad, th, omega)
    force = contact.hunt_crossley_force(-psi, dpsi, rig.k_H, law.beta, law.n, law.stiffness_exponent)
    if law.clip:
        force = contact.clip_tensile(force)
    friction = contact.coulomb_friction(force, rig.sliding_velocity(a, ad, th, omega), rig.mu)
    return (torque + force * chi - friction * rig.h_p) / rig.I_b


@pytest.mark.parametrize("law", [HuntCrossley(24.7e9, 1.5), HuntCrossley(1470.0, 0.0), HuntCrossley(3e11, 2.0),
                                 HuntCrossley(5e10, 1.2, clip=True), HuntCrossley(2e5, 0.0, stiffness_exponent=1.0)])
def test_fused_acceleration_equals_public_formulas(law):
    rig = SUNDAR2016.with_eccentricity_ratio(0.15)
    p, lv = pack_rig(rig), pack_law(law)
    rng = np.random.default_rng(7)
    omega = 2 * math.pi * 17
    for _ in range(300):
        t = rng.uniform(0, 0.1)
        th_ref = rng.uniform(0, 2 * math.pi)
        a = rig.contact_angle(th_ref + omega * t) - rng.uniform(-1e-6, 4e-5) / 0.09
        ad = rng.uniform(-6, 6)
        for mode in (K.FREE, K.CONTACT):
            got = K.acceleration(mode, t, a, ad, p, lv, th_ref, omega)
            ref = _reference_acceleration(rig, law, mode, t, a, ad, th_ref, omega)
            # terms up to ~1e6 rad/s^2 cancel to the result; 1e-9 relative of the largest term
            assert got == pytest.approx(ref, rel=1e-9, abs=1e-9 * max(1.0, abs(ref))), (mode, a, ad)
        snap = K._snapshot(K.CONTACT, t, a, ad, K.acceleration(K.CONTACT, t, a, ad, p, lv, th_ref, omega),
                           p, lv, th_ref, omega)
        assert snap[0] == pytest.approx(rig.gap(a, th_ref + omega * t), abs=1e-16)
        assert snap[1] == pytest.approx(rig.gap_rate(a, ad, th_ref + omega * t, omega), abs=1e-14)
        assert snap[4] == pytest.approx(rig.sliding_velocity(a, ad, th_ref + omega * t, omega), abs=1e-14)


def test_force_rate_is_the_time_derivative_of_the_force():
    """dF/dt of the snapshot against a central difference along a simulated contact."""
    from impactid import simulate_event

    rig = SUNDAR2016.with_eccentricity_ratio(0.2)
    law = HuntCrossley(24.7e9, 1.5)
    a_c = rig.contact_angle(1.0)
    ev = simulate_event(rig, 16.0, law, a_c + 1e-9, -4.0, 1.0, 2e-4)
    p, lv, omega = pack_rig(rig), pack_law(law), 2 * math.pi * 16
    t = np.linspace(2e-5, 1.5e-4, 7)
    h = 1e-9
    grid = np.sort(np.concatenate([t - h, t, t + h]))
    ev = simulate_event(rig, 16.0, law, a_c + 1e-9, -4.0, 1.0, 2e-4, t_eval=grid,
                        tolerances=__import__("impactid").Tolerances(rtol=1e-13, atol_alpha=1e-16, atol_rate=1e-14))
    f = ev.contact_force.reshape(-1, 3)
    fd = (f[:, 2] - f[:, 0]) / (2 * h)
    for i, ti in enumerate(t):
        a, ad = ev.alpha[3 * i + 1], ev.alpha_dot[3 * i + 1]
        add = K.acceleration(K.CONTACT, ti, a, ad, p, lv, 1.0, omega)
        rate = K._snapshot(K.CONTACT, ti, a, ad, add, p, lv, 1.0, omega)[3]
        assert rate == pytest.approx(fd[i], rel=1e-5)


def test_shifted_sine_and_cosine_match_the_library():
    """The angle-addition shortcut used for the stages of a step agrees with math.sin/cos to a few
    ulp, on both sides of its series/direct switch (|d| = 0.03), for small and large angles."""
    shifted = K._sincos_shifted.py_func  # the same arithmetic, in Python doubles
    rng = np.random.default_rng(1)
    x0 = np.concatenate([rng.uniform(-0.3, 0.3, 200), rng.uniform(-5000.0, 5000.0, 200)])
    d = np.concatenate([rng.uniform(-0.03, 0.03, 300), [0.0, 1e-12, -2.9999e-2, 3e-2, 0.05, -0.2] * 5,
                        rng.uniform(-1e-5, 1e-5, 70)])
    worst = 0.0
    for x, dx in zip(x0, d):
        s, c = shifted(x, math.sin(x), math.cos(x), dx)
        worst = max(worst, abs(s - math.sin(x + dx)), abs(c - math.cos(x + dx)))
    # math.sin(x + dx) itself carries the rounding of x + dx (ulp(5000) ~ 9e-13): compare with that
    assert worst < 2e-12
    small = [abs(shifted(x, math.sin(x), math.cos(x), dx)[0] - math.sin(x + dx))
             for x, dx in zip(x0[:200], d[:200])]
    assert max(small) < 4e-16
    # a free-flight stage evaluated through the shortcut equals the direct right-hand side
    x, dx = 0.1234, 0.0123
    compiled = K.acceleration(K.FREE, 0.0, x + dx, 0.0, pack_rig(SUNDAR2016), pack_law(HuntCrossley(1e9)), 0.0, 1.0)
    sa, ca = shifted(x, math.sin(x), math.cos(x), dx)
    via_shift = K._free_torque_of.py_func(sa, ca, pack_rig(SUNDAR2016)) / SUNDAR2016.I_b
    assert via_shift == pytest.approx(compiled, rel=1e-14)

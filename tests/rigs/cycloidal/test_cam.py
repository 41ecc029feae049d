"""Cycloidal lift law and flat-follower kinematics: closed forms, finite differences, the reference."""

from __future__ import annotations

import math

import numpy as np
import pytest

from impactid.rigs.cycloidal import cam
from tests.rigs.cycloidal import reference_cycloidal_ehl as R

DEG = math.pi / 180.0


def test_lift_agrees_with_the_reference_everywhere(rig, ref_p):
    psi = np.linspace(-7.0, 14.0, 20001)
    for ours, theirs in zip(cam.lift(psi, rig.S, rig.beta), R.lift(psi, ref_p)):
        np.testing.assert_allclose(ours, theirs, rtol=0, atol=1e-15 * np.max(np.abs(theirs)))
    assert cam.lift(0.3, rig.S, rig.beta) == (0.0, 0.0, 0.0, 0.0)
    s, s1, s2, _ = cam.lift(math.pi, rig.S, rig.beta)
    assert s == pytest.approx(rig.S, rel=1e-15) and abs(s1) < 1e-18 and abs(s2) < 1e-15


def test_derivatives_against_central_differences(rig):
    # away from the break points; truncation error h^2 (2 pi/beta)^2/6 of each amplitude
    psi = np.concatenate([np.linspace(92, 178, 50), np.linspace(182, 268, 50)]) * DEG
    h = 1e-5
    for k in range(3):
        num = (cam.lift(psi + h, rig.S, rig.beta)[k] - cam.lift(psi - h, rig.S, rig.beta)[k]) / (2 * h)
        exact = cam.lift(psi, rig.S, rig.beta)[k + 1]
        np.testing.assert_allclose(num, exact, rtol=0, atol=2e-9 * np.max(np.abs(exact)))


def test_peaks_jerk_jump_and_symmetry(rig):
    S, beta = rig.S, rig.beta
    psi = np.linspace(90, 180, 90001) * DEG
    _, s1, s2, _ = cam.lift(psi, S, beta)
    assert s1.max() == pytest.approx(2 * S / beta, rel=1e-9)
    assert s2.max() == pytest.approx(2 * math.pi * S / beta**2, rel=1e-9)
    assert s2.min() == pytest.approx(-2 * math.pi * S / beta**2, rel=1e-9)
    jump = cam.lift(math.pi - 1e-9, S, beta)[3] - cam.lift(math.pi + 1e-9, S, beta)[3]
    assert jump == pytest.approx(8 * math.pi**2 * S / beta**3, rel=1e-6)  # the cusp of Fig. 2
    x = np.linspace(0, beta, 41)[1:]
    for k, sign in ((0, 1), (1, -1), (2, 1), (3, -1)):
        np.testing.assert_allclose(cam.lift(math.pi + x, S, beta)[k], sign * cam.lift(math.pi - x, S, beta)[k],
                                   atol=1e-15)


def test_velocities_and_radius(rig, ref_p):
    psi = np.linspace(0, 2 * math.pi, 3601)
    w = 2 * math.pi * 3000 / 60
    np.testing.assert_allclose(cam.entraining_velocity(psi, w, rig.S, rig.beta, rig.R0),
                               R.entraining_velocity(psi, 3000.0, ref_p), rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(cam.sliding_velocity(psi, w, rig.S, rig.beta, rig.R0),
                               R.sliding_velocity(psi, 3000.0, ref_p), rtol=1e-14)
    np.testing.assert_allclose(cam.radius_of_curvature(psi, rig.S, rig.beta, rig.R0),
                               R.radius_of_curvature(psi, ref_p), rtol=1e-14)
    # nose entraining velocity at 3000 rpm (the paper's "in excess of 4 m/s", R-D3): omega (R0 + S)/2
    assert cam.entraining_velocity(math.pi, w, rig.S, rig.beta, rig.R0) == pytest.approx(0.5 * w * 0.028, rel=1e-14)
    # extrema of R where s' + s''' = 0 (cos 4x = -1/15 for beta = 90 deg); spec: 6.86 and 41.14 mm
    r_min, p_min = cam.min_radius_of_curvature(rig.S, rig.beta, rig.R0)
    r_max, p_max = cam.max_radius_of_curvature(rig.S, rig.beta, rig.R0)
    assert r_min == pytest.approx(6.859e-3, abs=1e-6) and r_max == pytest.approx(41.141e-3, abs=1e-6)
    # their positions in closed form: s' + s''' = (S/beta)[1 - cos th] + (4 pi^2 S/beta^3) cos th = 0, so
    # cos th = 1/(1 - 4 pi^2/beta^2) (th = 2 pi x/beta); the minimum in the deceleration part, the maximum
    # at the mirror angle in the acceleration part
    th = 2 * math.pi - math.acos(1.0 / (1.0 - 4 * math.pi**2 / rig.beta**2))
    assert p_min == pytest.approx(math.pi - rig.beta + th * rig.beta / (2 * math.pi), abs=1e-7)
    assert p_max == pytest.approx(math.pi - rig.beta + (2 * math.pi - th) * rig.beta / (2 * math.pi), abs=1e-7)


def test_zero_entrainment_angles(rig, ref_p):
    z = cam.zero_entrainment_angles(rig.S, rig.beta, rig.R0)
    np.testing.assert_allclose(z, R.zero_entrainment_angles(ref_p), atol=1e-13)
    np.testing.assert_allclose(np.degrees(z) - 180, [-35.237, -10.810, 10.810, 35.237], atol=1e-3)
    w = 100.0
    np.testing.assert_allclose(cam.entraining_velocity(z, w, rig.S, rig.beta, rig.R0), 0.0, atol=1e-13)
    # no reversal of the entrainment on a large base circle
    assert cam.zero_entrainment_angles(rig.S, rig.beta, 0.1).size == 0


def test_rigid_jump_speed(rig, ref_p):
    w, psi = cam.rigid_jump_speed(rig.m3, rig.k0, rig.f_p, rig.S, rig.beta)
    assert w * 60 / (2 * math.pi) == pytest.approx(R.rigid_jump_speed(ref_p), rel=1e-9)
    assert w * 60 / (2 * math.pi) == pytest.approx(3240.0, abs=1.0)  # the specification's number
    # the rigid load touches zero there and only there
    s, _, s2, _ = cam.lift(np.linspace(0, 2 * math.pi, 200001), rig.S, rig.beta)
    W = rig.m3 * w**2 * s2 + rig.f_p + rig.k0 * s
    assert W.min() == pytest.approx(0.0, abs=1e-6) and W.min() > -1e-6
    assert math.degrees(psi) == pytest.approx(156.18, abs=0.05)

"""The step's shortcuts (docs/performance_simulator.md): the shortened series of the in-step sines and
cosines, the library sines and cosines a step hands to the next, and the step-size controller on
the squared error norm. Each must give the numbers of the long way, to round-off."""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from numba import njit

from impactid import SUNDAR2016, HuntCrossley
from impactid.rigs.pivoted import kernel as K
from impactid.rigs.pivoted.runs import pack_law, pack_rig
from impactid.simulate import dp5

#: The series' branches of ``kernel._sincos_shifted``: upper bound of ``|d|`` and the number of terms
#: of ``sin d`` and of ``cos d - 1`` that each evaluates.
TIERS = [(2.6e-4, 2, 2), (4.3e-3, 3, 3), (0.03, 5, 4)]


def _sin_terms(d: Fraction, n: int) -> Fraction:
    return sum((-1) ** k * d ** (2 * k + 1) / math.factorial(2 * k + 1) for k in range(n))


def _cos_m1_terms(d: Fraction, n: int) -> Fraction:
    return sum((-1) ** k * d ** (2 * k) / math.factorial(2 * k) for k in range(1, n + 1))


@pytest.mark.parametrize(("bound", "n_sin", "n_cos"), TIERS)
def test_each_series_branch_truncates_below_1e_20(bound, n_sin, n_cos):
    """Exact (rational) arithmetic: the terms a branch leaves out add up to less than 1e-20 at the
    largest increment it takes, a thousandth of an ulp of a sine or cosine above 0.1."""
    d = Fraction(float(np.nextafter(bound, 0.0)))
    assert abs(_sin_terms(d, 12) - _sin_terms(d, n_sin)) < Fraction(1, 10**20)
    assert abs(_cos_m1_terms(d, 12) - _cos_m1_terms(d, n_cos)) < Fraction(1, 10**20)


def test_shifted_sine_and_cosine_at_the_branch_limits():
    """On both sides of every branch limit of the series the shortcut agrees with the library."""
    shifted = K._sincos_shifted.py_func
    rng = np.random.default_rng(3)
    worst = 0.0
    for bound, _, _ in TIERS:
        for d in (np.nextafter(bound, 0.0), bound, 0.999 * bound, 1.001 * bound):
            for sign in (1.0, -1.0):
                for x in rng.uniform(-0.3, 0.3, 20):
                    s, c = shifted(x, math.sin(x), math.cos(x), sign * d)
                    worst = max(worst, abs(s - math.sin(x + sign * d)), abs(c - math.cos(x + sign * d)))
    assert worst < 4e-16


@pytest.mark.parametrize("mode", [K.FREE, K.CONTACT])
@pytest.mark.parametrize("theta_ref", [0.7, 4021.3])
def test_a_step_hands_the_library_sines_and_cosines_to_the_next(mode, theta_ref):
    """``S[5:10]`` after a step are what a step starting there needs (``_trig_at``): the library sine
    and cosine of ``alpha_1``, exactly, and Theta at ``t + h`` (from the absolute time, to an ulp of
    Theta) with its library sine and cosine, exactly. Also for a cam angle of 4000 rad (a long run)."""
    rig = SUNDAR2016.with_eccentricity_ratio(0.2)
    p, lv = pack_rig(rig), pack_law(HuntCrossley(24.7e9, 1.5)).copy()
    omega, t = 2 * math.pi * 16, 1.3e-3
    th = theta_ref + omega * t
    a_c = float(rig.contact_angle(th))
    a, ad, h = (a_c - 2e-6 / rig.lever_arm(a_c, th), -1.0, 4e-6) if mode == K.CONTACT else (a_c + 0.02, 2.0, 8e-4)
    Km, S = np.empty((7, 2)), np.empty(K.N_MONITOR)
    trig = K._trig_at(mode, t, a, theta_ref, omega)
    f0 = K.acceleration(mode, t, a, ad, p, lv, theta_ref, omega)
    a1, _, _, _ = K._dp5_step(mode, t, a, ad, h, f0, p, lv, theta_ref, omega, Km, S, trig)
    assert S[5] == math.sin(a1) and S[6] == math.cos(a1)
    th1 = theta_ref + omega * (t + h)
    assert abs(S[9] - th1) <= math.ulp(th1)
    if mode != K.FREE:
        assert S[7] == math.sin(S[9]) and S[8] == math.cos(S[9])


def test_the_squared_controller_is_the_controller():
    """Acceptance on the squared norm is exactly ``sqrt(err2) <= 1``; its step factors are the
    square-root controller's to about an ulp."""
    ones = [1.0]
    for _ in range(4):
        ones = [np.nextafter(ones[0], 0.0), *ones, np.nextafter(ones[-1], 2.0)]
    rng = np.random.default_rng(5)
    samples = [*ones, 0.0, 5e-324, *np.exp(rng.uniform(math.log(1e-30), math.log(1e6), 2000))]
    for x in samples:
        err = math.sqrt(x)
        assert dp5.accepted_squared(x) == (err <= 1.0)
        for rejected in (False, True):
            assert dp5.step_factor_squared(x, rejected) == pytest.approx(dp5.step_factor(err, rejected), rel=5e-16)
        if err > 1.0:
            for exponent, floor in ((0.2, 0.2), (1.0 / 2.5, 0.01)):
                assert dp5.shrink_factor_squared(x, exponent, floor) == pytest.approx(
                    dp5.shrink_factor(err, exponent, floor), rel=5e-16)
    for layout in (_norms_pair, _norms_vector):
        norm, norm2 = layout(0.1, -3.0, 0.1001, -2.9, 3e-12, -4e-10)
        assert norm2 == pytest.approx(norm**2, rel=1e-15)


@njit
def _norms_pair(a0, d0, a1, d1, ea, ed):
    return (dp5.error_norm((a0, d0), (a1, d1), (ea, ed), 1e-10, (1e-13, 1e-11)),
            dp5.error_norm_squared((a0, d0), (a1, d1), (ea, ed), 1e-10, (1e-13, 1e-11)))


@njit
def _norms_vector(a0, d0, a1, d1, ea, ed):
    y0, y1, e, atol = np.array([a0, d0]), np.array([a1, d1]), np.array([ea, ed]), np.array([1e-13, 1e-11])
    return dp5.error_norm(y0, y1, e, 1e-10, atol), dp5.error_norm_squared(y0, y1, e, 1e-10, atol)

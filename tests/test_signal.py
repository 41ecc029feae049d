"""Integration methods of the per-impact pipeline against closed-form integrals."""

from __future__ import annotations

import numpy as np
import pytest

from impactid.signal import INTEGRATORS, detrend_integrate, get_integrator


def periodic_case(n):
    """One period of a smooth periodic acceleration with its exact first and second integrals."""
    period = 0.0625
    dt = period / n
    t = np.arange(n) * dt
    w = 2 * np.pi / period
    a = np.cos(w * t) + 0.3 * np.sin(3 * w * t)
    v = np.sin(w * t) / w - 0.3 * np.cos(3 * w * t) / (3 * w)
    x = -np.cos(w * t) / w**2 - 0.3 * np.sin(3 * w * t) / (3 * w) ** 2
    return a, v - v.mean(), x, dt


@pytest.mark.parametrize("method, order", [("trapezoid", 2), ("simpson", 4), ("rk", 4)])
def test_convergence_order(method, order):
    errors = []
    for n in (200, 400, 800):
        a, v, _, dt = periodic_case(n)
        got = get_integrator(method)(a, dt)
        exact = v - v[0]
        errors.append(np.max(np.abs(got - exact)))
    rates = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(rates > order - 0.3), (method, errors, rates)


def test_spectral_is_exact_for_band_limited_periodic_signals():
    a, v, _, dt = periodic_case(256)
    got = INTEGRATORS["spectral"](a, dt)
    assert np.max(np.abs(got - (v - v[0]))) < 1e-15 * 256


@pytest.mark.parametrize("method", list(INTEGRATORS))
def test_detrend_integrate_recovers_angle_up_to_a_constant(method):
    a, v, x, dt = periodic_case(4096)
    offset = 0.37  # a constant accelerometer offset is removed by the detrending
    add, rate, angle = detrend_integrate(a + offset, dt, method)
    assert np.max(np.abs(rate - v)) < 1e-7
    assert np.max(np.abs((angle - angle.mean()) - (x - x.mean()))) < 1e-9


def test_unknown_method_lists_the_valid_ones():
    with pytest.raises(ValueError, match="unknown integration method 'euler'; valid: rk, trapezoid, simpson, spectral"):
        get_integrator("euler")
    assert get_integrator(np.cumsum) is np.cumsum  # a callable is accepted

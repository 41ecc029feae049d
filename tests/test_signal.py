"""Signal processing of the core: channel statistics (quantisation, noise, runs) and the integration methods of
the per-impact pipeline against closed-form integrals."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import integrate

import impactid.signal as signal_module
from impactid.signal import (
    INTEGRATORS,
    MAD_TO_SIGMA,
    EventSpan,
    PowerLawEdge,
    detrend_integrate,
    edge_correction,
    get_integrator,
    noise_floor,
    quantisation_step,
    true_runs,
)

# ---- channel statistics -------------------------------------------------------------------------

LSB = 0.01  # code size of a test ADC


def test_quantisation_step_finds_the_code_of_an_adc_and_zero_for_continuous_data():
    rng = np.random.default_rng(3)
    continuous = np.sin(np.linspace(0.0, 20.0, 5000)) + rng.normal(0.0, 0.05, 5000)
    codes = np.round(continuous / LSB) * LSB
    assert quantisation_step(codes) == pytest.approx(LSB)
    assert quantisation_step(continuous) == 0.0
    assert quantisation_step(codes[:10]) == 0.0  # fewer than min_steps changes: no evidence
    assert quantisation_step(codes[:10], min_steps=2) == pytest.approx(LSB)
    assert quantisation_step(np.array([1.0])) == 0.0
    # only the first max_samples are looked at: a continuous tail does not matter
    assert quantisation_step(np.concatenate((codes, continuous)), max_samples=codes.size) == pytest.approx(LSB)
    assert quantisation_step(np.concatenate((codes, continuous)), max_samples=None) == 0.0


def test_quantisation_step_options_of_an_encoder():
    q = 2 * np.pi / 1000
    t = np.arange(400) / 1000.0
    counts = np.floor((0.003 + 1.7 * t) / q) * q
    step = quantisation_step(counts, min_steps=2, on_grid=True, reject_uniform_motion=True, period=2 * np.pi)
    assert step == 2 * np.pi / 1000  # exactly 2 pi / ppr
    uniform = 0.3 + 1e-3 * np.arange(100)  # exact uniform motion lies on a grid but is not counted
    assert quantisation_step(uniform, min_steps=2) == pytest.approx(1e-3)
    assert quantisation_step(uniform, min_steps=2, reject_uniform_motion=True) == 0.0
    # steps that are whole codes but samples that drift off the grid
    changes = np.diff(np.rint(counts / q)) * q * (1.0 + 5e-7)  # each change 5e-7 code long...
    changes[np.flatnonzero(changes)[0]] = q  # ...but the smallest one, which sets the code
    drifting = counts[0] + np.concatenate(([0.0], np.cumsum(changes)))
    assert quantisation_step(drifting, min_steps=2) == pytest.approx(q)
    assert quantisation_step(drifting, min_steps=2, on_grid=True) == 0.0


def test_noise_floor_of_white_noise_quantised_and_curved_channels():
    rng = np.random.default_rng(4)
    sigma = 0.02
    noise = rng.normal(0.0, sigma, 200_000)
    assert noise_floor(noise) == pytest.approx(sigma, rel=0.02)
    # a clean quantised ramp: no white noise, but the code's quantisation noise lsb / sqrt(12)
    ramp = np.round(np.linspace(0.0, 5.0, 20_000) / LSB) * LSB
    assert noise_floor(ramp) == pytest.approx(LSB / np.sqrt(12.0))
    assert noise_floor(ramp, include_quantisation=False) == 0.0
    # a steady curvature: every second difference is the same, so only the median absolute deviation
    # (subtract_curvature) sees no noise
    parabola = 0.5 * 1e-3 * np.arange(1000.0) ** 2
    assert noise_floor(parabola, include_quantisation=False) > 1e-4
    assert noise_floor(parabola, subtract_curvature=True, include_quantisation=False) == pytest.approx(0.0, abs=1e-12)
    assert noise_floor(np.array([1.0, 2.0, 0.0, 5.0])) == 0.0  # too few samples


def test_true_runs_and_merging_across_short_gaps():
    mask = np.array([1, 1, 0, 0, 1, 0, 0, 0, 0, 1, 1, 1], dtype=bool)
    starts, stops = true_runs(mask)
    np.testing.assert_array_equal(starts, [0, 4, 9])
    np.testing.assert_array_equal(stops, [2, 5, 12])
    starts, stops = true_runs(mask, max_gap=2)
    np.testing.assert_array_equal(starts, [0, 9])
    np.testing.assert_array_equal(stops, [5, 12])
    starts, stops = true_runs(mask, max_gap=4)
    np.testing.assert_array_equal(starts, [0])
    np.testing.assert_array_equal(stops, [12])
    empty = true_runs(np.zeros(5, dtype=bool))
    assert empty[0].size == 0 and empty[1].size == 0
    assert [a.tolist() for a in true_runs(np.ones(3, dtype=bool))] == [[0], [3]]


# ---- integration ---------------------------------------------------------------------------------


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


# ---- pulse edges and the event's true span ------------------------------------------------

DT = 1.0 / 204_800.0
PULSE_AMPLITUDE = 2.0e4  # rad/s^2, about rig P's
PULSE_SAMPLES = 64.0


def pulse(t, t0):
    """A contact-like pulse ``A (4 u (1 - u))^1.5`` on ``u = (t - t0) / T_c`` in [0, 1] (Hertz-like
    ``|t - edge|^1.5`` at both edges, smooth inside), plus a smooth free-flight baseline."""
    u = (np.asarray(t, dtype=float) - t0) / (PULSE_SAMPLES * DT)
    inside = (u > 0.0) & (u < 1.0)
    core = np.where(inside, PULSE_AMPLITUDE * np.abs(4.0 * u * (1.0 - u)) ** 1.5, 0.0)
    return core - 74.0 + 3.0e3 * np.asarray(t)


def pulse_edges(t0, first_time):
    """The exact edge laws of ``pulse``: ``c |t - edge|^1.5`` with ``c = A (4 / T_c)^1.5``."""
    c = PULSE_AMPLITUDE * (4.0 / (PULSE_SAMPLES * DT)) ** 1.5
    return (PowerLawEdge(time=t0 - first_time, coefficient=c, exponent=1.5, side=+1),
            PowerLawEdge(time=t0 + PULSE_SAMPLES * DT - first_time, coefficient=c, exponent=1.5, side=-1))


@pytest.mark.parametrize("method", ["rk", "simpson", "trapezoid"])
@pytest.mark.parametrize("offset", [0.07, 0.4, 0.72, 0.97])
def test_edge_correction_removes_the_pulse_edge_error(method, offset):
    """The rate after a pulse whose onset lies ``offset`` samples before the first sample, against
    scipy's adaptive quadrature of the same function (with its breakpoints at the edges)."""
    t0 = -offset * DT
    t = np.arange(160) * DT
    a = pulse(t, t0)
    end = t0 + PULSE_SAMPLES * DT
    exact = integrate.quad(lambda s: float(pulse(s, t0)), 0.0, end, points=[end], epsabs=1e-13, epsrel=1e-14,
                           limit=200)[0] + integrate.quad(lambda s: float(pulse(s, t0)), end, t[-1])[0]
    rule = get_integrator(method)
    plain = rule(a, DT)[-1] - exact
    corrected = rule(a, DT)[-1] - edge_correction(t.size, DT, method, pulse_edges(t0, 0.0))[-1] - exact
    # uncorrected: up to 1.5e-4 rad/s (the pulse's velocity jump is ~0.6 rad/s); corrected: the
    # remainder's singularity is |t - edge|^2.5 (here with a large coefficient: (1 - u)^1.5)
    assert abs(corrected) < 1e-5, (plain, corrected)
    assert abs(corrected) < 0.1 * abs(plain) or abs(plain) < 1e-5, (plain, corrected)


def test_edge_correction_leaves_other_methods_alone():
    edges = pulse_edges(-0.3 * DT, 0.0)
    assert not np.any(edge_correction(100, DT, "spectral", edges))
    assert not np.any(edge_correction(100, DT, np.cumsum, edges))


@pytest.mark.parametrize("method", ["rk", "simpson", "trapezoid"])
@pytest.mark.parametrize("head, tail", [(0.72, 0.1), (0.9, 0.8), (0.1, 0.05)])
def test_span_means_recover_the_offset_and_the_zero_mean_rate(method, head, tail):
    """One period of a periodic acceleration sampled from ``head`` samples after its start to
    ``tail`` samples before its end: with the span, the accelerometer offset and the rate's
    constant come out right; the plain sample means are off by O(dt)."""
    n = 4000
    period = (n - 1 + head + tail) * DT
    w = 2 * np.pi / period
    offset = 0.37
    t = (np.arange(n) + head) * DT  # time from the true start of the period

    def acc(s):
        return np.cos(w * s) + 0.3 * np.sin(3 * w * s) + offset

    def rate_true(s):  # zero mean over the period
        return np.sin(w * s) / w - 0.3 * np.cos(3 * w * s) / (3 * w)

    head_change = integrate.quad(acc, 0.0, head * DT)[0]
    tail_change = integrate.quad(acc, t[-1], period)[0]
    span = EventSpan(head=head, tail=tail, head_rate_change=head_change, tail_rate_change=tail_change)
    add, rate, _ = detrend_integrate(acc(t), DT, method, span=span)
    assert np.max(np.abs(add - (acc(t) - offset))) < 1e-9
    tolerance = 1e-11 if method != "trapezoid" else 3e-9  # measured 1e-13 / 1.1e-9 (its dt^2 error)
    assert np.max(np.abs(rate - rate_true(t))) < tolerance
    _, plain_rate, _ = detrend_integrate(acc(t), DT, method)
    assert np.max(np.abs(plain_rate - rate_true(t))) > 100 * tolerance  # measured 4.5e-7 .. 2.1e-6


@pytest.mark.parametrize("size", [5, 6, 1000, signal_module._CHUNK + 3, 2 * signal_module._CHUNK + 1])
@pytest.mark.parametrize("subtract_curvature", [False, True])
def test_noise_floor_in_chunks_is_the_whole_array_formula_to_the_last_bit(size, subtract_curvature):
    """The chunked second difference and the in-place median give the numbers of the whole-array formula."""
    rng = np.random.default_rng(size)
    x = np.sin(np.linspace(0.0, 40.0, size)) + 1e-3 * rng.normal(size=size)
    second = x[2:] - 2.0 * x[1:-1] + x[:-2]
    assert np.array_equal(signal_module._second_difference(x), second)
    centre = np.median(second) if subtract_curvature else 0.0
    expected = MAD_TO_SIGMA * np.median(np.abs(second - centre)) / np.sqrt(6.0)
    assert noise_floor(x, subtract_curvature=subtract_curvature, include_quantisation=False) == expected

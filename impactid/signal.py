"""Detrending and double integration of sampled acceleration (section 5.1 of Sundar, Dreyer & Singh (2016)).

Pure functions on arrays with the sample spacing ``dt`` [s] passed explicitly. The integration
method is chosen by name from :data:`INTEGRATORS` (or given as a callable ``f(y, dt) -> cumulative
integral`` with the same length as ``y`` and a zero first value); an unknown name raises a
ValueError listing the valid ones.

Methods (cumulative integral of uniformly sampled ``y``):

``trapezoid``
    the trapezoidal rule, second order.
``simpson``
    scipy's cumulative Simpson rule (quadratic through each three samples), fourth order on
    smooth data.
``rk``
    the classical Runge-Kutta (RK4) step of ``dx/dt = y(t)`` with ``y`` at the half-sample taken
    from the four-point cubic interpolant (as the paper integrates the measured acceleration
    "using the Runge-Kutta method"): ``x_{k+1} = x_k + dt/6 (y_k + 4 y_{k+1/2} + y_{k+1})``.
    Fourth order on smooth data.
``spectral``
    division by ``i omega`` in the frequency domain: exact for a band-limited periodic signal,
    which an event of period-1 motion (one cam revolution) is. The mean is removed first (the
    zero frequency has no integral) and the first sample is set to zero.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy import integrate

__all__ = ["EDGE_SPAN_SAMPLES", "INTEGRATORS", "EventSpan", "PowerLawEdge", "cumulative_rk4", "cumulative_simpson",
           "cumulative_spectral", "cumulative_trapezoid", "detrend_integrate", "edge_correction",
           "get_integrator"]

def cumulative_trapezoid(y: np.ndarray, dt: float) -> np.ndarray:
    """Cumulative trapezoidal integral of ``y`` sampled every ``dt`` [s]; first value 0."""
    return integrate.cumulative_trapezoid(y, dx=dt, initial=0.0)


def cumulative_simpson(y: np.ndarray, dt: float) -> np.ndarray:
    """Cumulative Simpson integral (scipy); first value 0."""
    return integrate.cumulative_simpson(y, dx=dt, initial=0.0)


def cumulative_rk4(y: np.ndarray, dt: float) -> np.ndarray:
    """RK4 integral of ``dx/dt = y(t)`` with cubic half-sample values; first value 0.

    At the two ends the half-sample value comes from the one-sided cubic through the four
    nearest samples.
    """
    y = np.asarray(y, dtype=float)
    n = y.size
    if n < 4:
        return cumulative_trapezoid(y, dt)
    half = np.empty(n - 1)
    half[1:-1] = (-y[:-3] + 9.0 * y[1:-2] + 9.0 * y[2:-1] - y[3:]) / 16.0
    half[0] = (5.0 * y[0] + 15.0 * y[1] - 5.0 * y[2] + y[3]) / 16.0
    half[-1] = (5.0 * y[-1] + 15.0 * y[-2] - 5.0 * y[-3] + y[-4]) / 16.0
    steps = dt / 6.0 * (y[:-1] + 4.0 * half + y[1:])
    out = np.empty(n)
    out[0] = 0.0
    np.cumsum(steps, out=out[1:])
    return out


def cumulative_spectral(y: np.ndarray, dt: float) -> np.ndarray:
    """Periodic spectral integral of ``y`` (its mean removed); first value 0."""
    y = np.asarray(y, dtype=float)
    n = y.size
    spectrum = np.fft.rfft(y - y.mean())
    omega = 2.0 * np.pi * np.fft.rfftfreq(n, dt)
    spectrum[0] = 0.0
    spectrum[1:] /= 1j * omega[1:]
    if n % 2 == 0:
        spectrum[-1] = 0.0  # the Nyquist bin of an even length has no well-defined integral
    x = np.fft.irfft(spectrum, n)
    return x - x[0]


#: Integration methods by name.
INTEGRATORS: dict[str, Callable[[np.ndarray, float], np.ndarray]] = {
    "rk": cumulative_rk4,
    "trapezoid": cumulative_trapezoid,
    "simpson": cumulative_simpson,
    "spectral": cumulative_spectral,
}


def get_integrator(method: str | Callable[[np.ndarray, float], np.ndarray]):
    """The integration function for ``method`` (a name of :data:`INTEGRATORS` or a callable)."""
    if callable(method):
        return method
    try:
        return INTEGRATORS[method]
    except (KeyError, TypeError):
        raise ValueError(f"unknown integration method {method!r}; valid: {', '.join(INTEGRATORS)}") from None


@dataclass(frozen=True)
class PowerLawEdge:
    """A contact pulse's edge where the acceleration behaves like ``c |t - t_edge|^p``.

    ``time`` [s] from the window's first sample; ``coefficient`` ``c`` [rad/s^2 per s^p] and
    ``exponent`` ``p`` of the pulse (above the free-flight baseline); ``side`` +1 for an onset
    (the pulse is after ``time``), -1 for a separation (the pulse is before ``time``).
    """

    time: float
    coefficient: float
    exponent: float
    side: int


#: Half-width of the span around an edge over which its quadrature error is corrected [samples].
EDGE_SPAN_SAMPLES = 16


def edge_correction(n: int, dt: float, method, edges: Sequence[PowerLawEdge]) -> np.ndarray:
    """Quadrature error of ``method`` on the singular part of pulse edges, per sample.

    At a contact onset the acceleration rises like ``c (t - t0)^p`` (Hertz: ``p = 1.5``) and at
    the separation it ends like ``c (t_a - t)^p``: at ``t0``/``t_a`` the derivatives of order
    above ``p`` are infinite, so no polynomial rule integrates it to its order, and the error
    depends on where the edge falls between samples (the generalised Euler-Maclaurin expansion:
    ``c dt^(p+1)`` times a Hurwitz-zeta factor of the sub-sample position). On rig P at 204.8 kHz
    that is 1e-5 .. 6e-4 rad/s of rate after a pulse. This function applies the integration
    method itself to the samples of the bare power law within :data:`EDGE_SPAN_SAMPLES` samples
    of the edge and returns its cumulative result minus the exact integral (``c x^(p+1)/(p+1)``),
    held constant after the span. Subtracting it from the cumulative integral of the acceleration
    leaves the method's error on the remainder, whose singularity is weaker by one power of ``t``.
    (Beyond the span the power law is smooth and the method's error on it decays like
    ``x^(p-4) dt^5`` for the fourth-order rules; there the data's own shape governs the error.
    The trapezoid's own end terms at the span's ends (``dt^2/12 f1 - dt^4/720 f3``) are removed;
    those of the fourth-order rules are O(dt^4 times the third derivative) there, below 1e-10 rad/s.)
    Returns zeros for the other methods (``spectral``, callables), which are not corrected.
    """
    integral = get_integrator(method)
    total = np.zeros(n)
    if integral not in (cumulative_rk4, cumulative_simpson, cumulative_trapezoid):
        return total
    for edge in edges:
        c, p = float(edge.coefficient), float(edge.exponent)
        if not (math.isfinite(c) and math.isfinite(p) and math.isfinite(edge.time) and c != 0.0):
            continue
        centre = int(round(edge.time / dt))
        lo, hi = max(centre - EDGE_SPAN_SAMPLES, 0), min(centre + EDGE_SPAN_SAMPLES + 1, n)
        lo -= lo % 2  # scipy's cumulative Simpson pairs the intervals from the window's start
        if hi - lo < 4:
            continue
        # (evaluated 3 samples beyond the span so that its last value comes from the rule's interior
        # stencils, as in the whole window, not from its one-sided end stencil)
        x = edge.side * (np.arange(lo, hi + 3) * dt - edge.time)  # distance into the pulse [s]
        inside = np.maximum(x, 0.0)
        numeric = integral(c * inside ** p, dt)[: hi - lo]
        inside, x = inside[: hi - lo], x[: hi - lo]
        primitive = c * inside ** (p + 1.0) / (p + 1.0)  # exact: +-(F(x_k) - F(x_lo))
        error = numeric - edge.side * (primitive - primitive[0])
        frozen = error[-1]
        if integral is cumulative_trapezoid:
            # the trapezoid's regular Euler-Maclaurin end terms at the span's ends belong to the
            # span, not to the data (whose integral runs on through them): remove them
            if lo > 0:
                error = error + _trapezoid_end_term(float(x[0]), c, p, edge.side, dt)
            frozen = error[-1] - _trapezoid_end_term(float(x[-1]), c, p, edge.side, dt)
        total[lo:hi] += error
        total[hi:] += frozen
    return total


def _trapezoid_end_term(distance: float, c: float, p: float, side: int, dt: float) -> float:
    """Euler-Maclaurin end term ``dt^2/12 f1 - dt^4/720 f3`` (``f1, f3``: first and third
    derivatives) of ``f = c |x|^p`` at ``distance`` [s] into the pulse (0 outside it)."""
    if distance <= 0.0:
        return 0.0
    d1 = side * c * p * distance ** (p - 1.0)
    d3 = side * c * p * (p - 1.0) * (p - 2.0) * distance ** (p - 3.0)
    return dt ** 2 / 12.0 * d1 - dt ** 4 / 720.0 * d3


@dataclass(frozen=True)
class EventSpan:
    """Where an event's true time span lies relative to its samples.

    The span runs from the contact onset ``head`` samples before the window's first sample to
    the next onset ``tail`` samples after its last sample (both in [0, 1]); ``head_rate_change``
    and ``tail_rate_change`` [rad/s] are the integrals of the measured acceleration over those
    two sub-sample pieces (from the edge models of the pulse, see
    :func:`impactid.rigs.pivoted.reconstruct.reconstruct`).
    """

    head: float
    tail: float
    head_rate_change: float
    tail_rate_change: float


def detrend_integrate(acceleration: np.ndarray, dt: float, method="rk", *, span: EventSpan | None = None,
                      edges: Sequence[PowerLawEdge] = ()) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Section 5.1 of Sundar, Dreyer & Singh (2016) on one event: remove the mean of the acceleration, integrate,
    remove the mean of the velocity, integrate again.

    Parameters
    ----------
    acceleration : angular acceleration samples of one event [rad/s^2] (one cam revolution, from
        one contact onset to the next).
    dt : sample interval [s].
    method : integration method (name or callable).
    span : the event's true time span (:class:`EventSpan`). With it, both means are taken over
        that span, from onset to next onset, with the chosen quadrature plus the two sub-sample
        pieces: over one revolution of period-1 motion the true acceleration and rate integrate
        to zero, so the removed constants are then the accelerometer's offset and the rate's
        integration constant. Without it (the paper's form) they are the sample means, i.e. the
        rectangle rule over the samples, whose ends lie at different phases of the motion; over
        a window that starts just after a contact onset that biases the rate by ~1e-4 rad/s over
        a revolution and alpha_m by ~2e-5 relative on rig P. Ignored by the ``spectral`` method,
        whose periodic integral removes the plain mean by construction.
    edges : the pulse edges of the window (:class:`PowerLawEdge`); the quadrature error of their
        singular part (:func:`edge_correction`) is removed from the integrated rate. Ignored by
        the ``spectral`` method.

    Returns
    -------
    acceleration, rate, angle : the detrended acceleration [rad/s^2], the rate [rad/s] and the
        angle [rad] up to the constant of the second integration (first value 0).
    """
    integral = get_integrator(method)
    a = np.asarray(acceleration, dtype=float)
    n = a.size
    spectral = integral is cumulative_spectral  # periodic: removes the plain mean itself
    rate = integral(a, dt)
    if edges and not spectral:
        rate = rate - edge_correction(n, dt, integral, edges)
    if span is None or spectral or n < 2:
        bias = a.mean()
    else:
        period = (n - 1 + span.head + span.tail) * dt
        bias = (rate[-1] + span.head_rate_change + span.tail_rate_change) / period
    if not spectral:  # every method integrates a constant exactly
        rate = rate - bias * dt * np.arange(n)
    a = a - bias
    if span is None or spectral or n < 2:
        rate = rate - rate.mean()
    else:
        # the rate is linear over the short pieces (their acceleration, less the offset, integrated)
        head_change = span.head_rate_change - bias * span.head * dt
        tail_change = span.tail_rate_change - bias * span.tail * dt
        total = (integral(rate, dt)[-1] + (rate[0] - 0.5 * head_change) * span.head * dt
                 + (rate[-1] + 0.5 * tail_change) * span.tail * dt)
        rate = rate - total / period
    angle = integral(rate, dt)
    return a, rate, angle

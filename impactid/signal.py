"""Detrending and double integration of sampled acceleration (section 5.1 of seed 001).

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

from collections.abc import Callable

import numpy as np
from scipy import integrate


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


def detrend_integrate(acceleration: np.ndarray, dt: float, method="rk") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Section 5.1 of seed 001 on one event: remove the mean of the acceleration, integrate,
    remove the mean of the velocity, integrate again.

    Parameters
    ----------
    acceleration : angular acceleration samples of one event [rad/s^2] (one cam revolution, from
        one contact onset to the next).
    dt : sample interval [s].
    method : integration method (name or callable).

    Returns
    -------
    acceleration, rate, angle : the detrended acceleration [rad/s^2], the zero-mean rate [rad/s]
        and the angle [rad] up to the constant of the second integration (first value 0).
    """
    integral = get_integrator(method)
    a = np.asarray(acceleration, dtype=float)
    a = a - a.mean()
    rate = integral(a, dt)
    rate = rate - rate.mean()
    angle = integral(rate, dt)
    return a, rate, angle

"""Signal processing of sampled channels: their noise, quantisation and runs, and the detrending and double
integration of acceleration (section 5.1 of Sundar, Dreyer & Singh (2016)).

Pure functions on arrays. Every rig's measurement uses the same three channel statistics:

* :func:`noise_floor`: white-noise standard deviation from the median absolute second difference
  (and at least the quantisation noise of the channel's code size);
* :func:`quantisation_step`: the code size of a quantised channel (an ADC's least significant bit,
  an encoder's count), 0 for a continuous one;
* :func:`true_runs`: the stretches of a boolean mask (samples above a threshold).

The integrals take the sample spacing ``dt`` [s] explicitly. The integration
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
from numba import njit
from scipy import integrate

from impactid import compilation

__all__ = ["EDGE_SPAN_SAMPLES", "INTEGRATORS", "MAD_TO_SIGMA", "MIN_NOISE_SAMPLES", "QUANTISATION_SAMPLES",
           "QUANTISATION_TOLERANCE", "ZERO_STEP", "EventSpan", "PowerLawEdge", "cumulative_rk4", "cumulative_simpson",
           "cumulative_spectral", "cumulative_trapezoid", "detrend_integrate", "edge_correction",
           "get_integrator", "noise_floor", "quantisation_step", "sampled_model_correction", "true_runs"]

compilation.install()  # before the kernels (impactid.compilation)

# --------------------------------------------------------------------------------------------
# Channel statistics: quantisation, noise, runs
# --------------------------------------------------------------------------------------------

#: Samples a channel's code size is looked for in by default (the first ones; enough steps).
QUANTISATION_SAMPLES = 200_000
#: Relative tolerance of the quantisation tests: how far (in codes) a step, or a sample, may lie from
#: the grid, and how far ``period / step`` may lie from a whole number of codes.
QUANTISATION_TOLERANCE = 1e-6
#: A step smaller than this fraction of the channel's magnitude (at least 1) is rounding, not a code.
ZERO_STEP = 1e-12
#: Median absolute deviation to the standard deviation of a Gaussian.
MAD_TO_SIGMA = 1.4826
#: Fewest samples a noise floor is estimated from (below: 0).
MIN_NOISE_SAMPLES = 5


def quantisation_step(x: np.ndarray, *, max_samples: int | None = QUANTISATION_SAMPLES, min_steps: int = 16,
                      on_grid: bool = False, reject_uniform_motion: bool = False,
                      period: float | None = None) -> float:
    """Code size of a quantised channel [the channel's unit]: 0 when the channel is not quantised.

    The candidate code is the smallest non-zero step between consecutive samples (steps below
    :data:`ZERO_STEP` times the channel's largest magnitude, at least 1, are rounding and count
    as zero). The channel is quantised when

    * it has at least ``min_steps`` non-zero steps, and
    * every non-zero step is a whole number of codes, to :data:`QUANTISATION_TOLERANCE` times the
      largest number of codes (at least 1); or, with ``on_grid``, every *sample* lies within
      :data:`QUANTISATION_TOLERANCE` codes of the grid ``x[0] + k code`` (stricter: no drift over
      a long record), and
    * with ``reject_uniform_motion``, the steps (zero ones included) take at least two different
      numbers of codes: an encoder sampled faster than it counts stands still between its edges,
      whereas exact motion at a uniform speed also lies on a grid but moves by the same amount
      every sample.

    Parameters
    ----------
    x : samples of the channel [any unit].
    max_samples : look only at the first ``max_samples`` samples (None: all of them).
    min_steps : fewest non-zero steps that can show a code size.
    on_grid : test every sample's position on the grid instead of every step's size.
    reject_uniform_motion : return 0 when every step is the same number of codes.
    period : the channel's period (``2 pi`` [rad] for an angle encoder): when ``period / code`` is
        within :data:`QUANTISATION_TOLERANCE` (relative) of a whole number ``ppr`` of counts per
        period, the code is taken as exactly ``period / ppr`` (before the grid test).

    Returns
    -------
    float : the code size [the channel's unit], or 0.0 for an unquantised channel.
    """
    x = np.asarray(x, dtype=float)
    if max_samples is not None:
        x = x[:max_samples]
    if x.size < 2:
        return 0.0
    steps = np.abs(np.diff(x))
    zero = ZERO_STEP * max(float(np.max(np.abs(x))), 1.0)
    nonzero = steps[steps > zero]
    if nonzero.size < max(int(min_steps), 1):
        return 0.0
    code = float(np.min(nonzero))
    if period is not None:
        per_period = period / code
        if abs(per_period - round(per_period)) <= QUANTISATION_TOLERANCE * per_period:
            code = period / round(per_period)
    if on_grid:
        position = (x - x[0]) / code
        if float(np.max(np.abs(position - np.round(position)))) > QUANTISATION_TOLERANCE:
            return 0.0
    else:
        codes = nonzero / code
        if np.max(np.abs(codes - np.round(codes))) > QUANTISATION_TOLERANCE * max(1.0, float(np.max(codes))):
            return 0.0
    if reject_uniform_motion and np.unique(np.rint(steps / code)).size < 2:
        return 0.0
    return code


def noise_floor(x: np.ndarray, *, subtract_curvature: bool = False, include_quantisation: bool = True) -> float:
    """White-noise standard deviation of a channel [the channel's unit], from its second differences.

    For white noise of standard deviation ``sigma`` the second difference ``x[k+1] - 2 x[k] + x[k-1]``
    has variance ``6 sigma^2``, while a signal that is smooth over three samples contributes almost
    nothing to it; the median absolute second difference (times :data:`MAD_TO_SIGMA`, divided by
    ``sqrt(6)``) is then ``sigma``, robust to the few samples of a pulse or an edge.

    Parameters
    ----------
    x : samples of the channel [any unit].
    subtract_curvature : take the absolute deviations from the median second difference (the median
        absolute deviation) instead of from zero: a signal whose curvature over three samples is not
        negligible against the noise (a slowly sampled swing) does not then count as noise.
    include_quantisation : return at least the quantisation noise ``code / sqrt(12)`` of the
        channel's code size (:func:`quantisation_step` with its defaults). A quantised channel
        whose noise is below one code (a 16-24 bit ADC on a clean signal) has most second
        differences exactly zero, so their median says 0; the code size then sets the floor, and a
        smooth signal is not mistaken for a pulse edge where it merely changes code.

    Returns
    -------
    float : the noise standard deviation [the channel's unit]; 0.0 with fewer than
    :data:`MIN_NOISE_SAMPLES` samples.
    """
    x = np.asarray(x, dtype=float)
    if x.size < MIN_NOISE_SAMPLES:
        return 0.0
    second = _second_difference(x)
    centre = np.median(second) if subtract_curvature else 0.0
    if centre != 0.0:
        np.subtract(second, centre, out=second)
    np.abs(second, out=second)
    # the one buffer is sorted in place: a 60 s channel at 204.8 kHz is 98 MB a copy
    white = float(MAD_TO_SIGMA * np.median(second, overwrite_input=True) / math.sqrt(6.0))
    if not include_quantisation:
        return white
    return max(white, quantisation_step(x) / math.sqrt(12.0))


#: Samples of a channel whose second difference is formed at a time (:func:`_second_difference`).
_CHUNK = 1 << 20


def _second_difference(x: np.ndarray) -> np.ndarray:
    """``x[2:] - 2 x[1:-1] + x[:-2]`` in one new array, formed a chunk at a time (the same numbers as the
    whole-array expression, without its two temporaries of the channel's length)."""
    out = np.empty(x.size - 2)
    scratch = np.empty(min(_CHUNK, out.size))
    for k in range(0, out.size, _CHUNK):
        stop = min(k + _CHUNK, out.size)
        part, tmp = out[k:stop], scratch[:stop - k]
        np.multiply(x[k + 1:stop + 1], 2.0, out=tmp)
        np.subtract(x[k + 2:stop + 2], tmp, out=part)
        np.add(part, x[k:stop], out=part)
    return out


def true_runs(mask: np.ndarray, *, max_gap: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """The stretches of True in a boolean mask, as start (inclusive) and stop (exclusive) indices.

    Parameters
    ----------
    mask : 1-D boolean array (e.g. the samples above a threshold).
    max_gap : stretches separated by at most ``max_gap`` False samples are merged into one (0: none
        are merged), e.g. a pulse split by a few noisy samples.

    Returns
    -------
    starts, stops : int64 arrays of equal length, ascending: ``mask[starts[i]:stops[i]]`` is all
    True (up to the merged gaps) and the samples just outside it are False.
    """
    # one int8 difference array (a view of the mask, no padded copy): masks of long audio recordings
    # hold tens of millions of samples
    edges = np.diff(np.ascontiguousarray(mask, dtype=bool).view(np.int8), prepend=np.int8(0), append=np.int8(0))
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    del edges
    if max_gap > 0 and starts.size > 1:
        separate = starts[1:] - stops[:-1] > max_gap  # a stretch that starts a run of its own
        starts, stops = starts[np.concatenate(([True], separate))], stops[np.concatenate((separate, [True]))]
    return starts, stops


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
    if y.size < 4:
        return cumulative_trapezoid(y, dt)
    return _rk4_integral(np.ascontiguousarray(y.ravel()), float(dt))


@njit(nogil=True, cache=True)
def _rk4_integral(y, dt):  # pragma: no cover - compiled
    """:func:`cumulative_rk4` of at least 4 samples in one pass: each step's half-sample value, the step
    and the running sum, in the order of the array expressions it replaces (the same numbers to the last
    bit: tests/test_events_compiled.py), without their four temporaries of the window's length."""
    n = y.shape[0]
    out = np.empty(n)
    out[0] = 0.0
    weight = dt / 6.0
    half = (5.0 * y[0] + 15.0 * y[1] - 5.0 * y[2] + y[3]) / 16.0  # one-sided at the ends
    total = weight * (y[0] + 4.0 * half + y[1])
    out[1] = total
    for k in range(1, n - 2):
        half = (-y[k - 1] + 9.0 * y[k] + 9.0 * y[k + 1] - y[k + 2]) / 16.0
        total += weight * (y[k] + 4.0 * half + y[k + 1])
        out[k + 1] = total
    half = (5.0 * y[n - 1] + 15.0 * y[n - 2] - 5.0 * y[n - 3] + y[n - 4]) / 16.0
    out[n - 1] = total + weight * (y[n - 2] + 4.0 * half + y[n - 1])
    return out


def _cumulative_rk4_arrays(y: np.ndarray, dt: float) -> np.ndarray:
    """:func:`cumulative_rk4` as array expressions (the reference the compiled one is tested against)."""
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


def sampled_model_correction(n: int, dt: float, method, first: int, values: np.ndarray,
                             exact_cumulative: np.ndarray) -> np.ndarray:
    """Quadrature error of ``method`` on a modelled stretch of a window, per sample (cumulative).

    The counterpart of :func:`edge_correction` for a part of the signal that no power law describes
    but a model does: a contact pulse that rises and peaks within a few samples (the head of a nearly
    plastic Hunt–Crossley contact, :mod:`impactid.rigs.pivoted.reconstruct`), where every rule's
    error is a sizeable fraction of the pulse's integral and depends on where the pulse falls between
    samples. ``values`` are the model's samples at window positions ``first, first + 1, ...`` (zero
    where the model is zero; the last three serve only the rules' stencils), and
    ``exact_cumulative`` its exact integral from position ``first`` to each of them (same length).
    The method is applied to the model's samples (from an even position, as scipy's cumulative
    Simpson pairs the intervals from the window's start, with zeros before ``first``) and the exact
    integral subtracted; the error is held constant after the last position that is not a stencil
    sample. Subtracting the result from the cumulative integral of the window leaves the method's
    error on the difference between the data and the model. Returns zeros for the methods that
    :func:`edge_correction` does not correct (``spectral``, callables).

    Parameters
    ----------
    n : length of the window [samples].
    dt : sample interval [s].
    method : integration method (name or callable).
    first : window position of ``values[0]`` (may be negative: positions before the window are dropped).
    values : the model's samples [the integrand's unit], at least four.
    exact_cumulative : the exact integral of the model from position ``first`` [integrand unit x s].

    Returns
    -------
    np.ndarray : the cumulative error of ``method`` on the model at each window position [integrand unit x s].
    """
    integral = get_integrator(method)
    total = np.zeros(n)
    values = np.asarray(values, dtype=float)
    exact = np.asarray(exact_cumulative, dtype=float)
    if integral not in (cumulative_rk4, cumulative_simpson, cumulative_trapezoid) or values.size < 4:
        return total
    lo = max(int(first), 0)
    lo -= lo % 2
    hi = min(int(first) + values.size - 3, n)  # the last three samples serve the stencils only
    if hi - lo < 4:
        return total
    span = np.zeros(hi + 3 - lo)
    take = np.arange(lo, hi + 3) - int(first)
    inside = (take >= 0) & (take < values.size)
    span[inside] = values[take[inside]]
    exact_span = np.zeros(span.size)
    exact_span[inside] = exact[take[inside]]
    numeric = integral(span, dt)[: hi - lo]
    error = numeric - (exact_span[: hi - lo] - exact_span[0])
    total[lo:hi] += error
    total[hi:] += error[-1]
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
                      edges: Sequence[PowerLawEdge] = (), rate_correction: np.ndarray | None = None
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
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
    rate_correction : a further cumulative quadrature error [rad/s] per sample (e.g.
        :func:`sampled_model_correction` of a modelled pulse), removed from the integrated rate with
        the edges' (None: none). Ignored by the ``spectral`` method.

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
    if rate_correction is not None and not spectral:
        rate = rate - np.asarray(rate_correction, dtype=float)
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

"""Rig F's encoder signals: counts, counter conventions, edges, local lines and revolutions.

Rig F records two angle channels from incremental encoders, ``cam_angle`` and ``follower_angle``
[rad]. This module reads them; what is fitted to them lives elsewhere (the cam profile in
:mod:`impactid.rigs.flat.camprofile`, the impacts in :mod:`impactid.rigs.flat.encoder_impacts`).

* *Count step* (:func:`encoder_step`): the step of a channel is detected from the data with the
  core's :func:`impactid.signal.quantisation_step`: its values lie on a grid of its smallest
  non-zero change, the changes take at least two different numbers of counts (an encoder sampled
  faster than it counts stands still between its edges), and a step within 1e-6 of ``2 pi / ppr``
  is taken as exactly that (:func:`pulses_per_revolution`).
* *Counter convention* (:data:`COUNTERS`, :func:`read_counter`): an incremental counter
  (``"floor"``) reports ``floor(angle / step) * step``, on average half a count *below* the
  angle; ``"round"`` reports the nearest count; ``"none"`` treats the channel as continuous.
  Whether a counter floors or rounds cannot be told from the data.
* *Edges* (:func:`encoder_edges`): when the reading changes, the angle has just crossed a count
  boundary whose value is known exactly; only its time is uncertain, by half a sample interval.
* *Local lines* (:func:`local_linear`): the angle of one encoder at the edge times of another,
  from a least-squares line through its own nearest edges (their timing errors average out).
* *Revolutions* (:func:`complete_revolutions`): the samples of each complete cam revolution,
  counted from the first sample, whichever way the cam turns.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from impactid.errors import ImpactidError
from impactid.signal import quantisation_step

__all__ = ["COUNTERS", "TWO_PI", "CamRevolutions", "CounterReading", "EncoderError", "complete_revolutions",
           "encoder_edges", "encoder_step", "local_linear", "pulses_per_revolution", "read_counter"]

TWO_PI = 2.0 * math.pi

#: Encoder counters by name: where the angle lies relative to a reading, in counts. ``"floor"``:
#: an incremental counter, the angle is in ``[reading, reading + step)`` (half a count above the
#: reading on average); ``"round"``: the nearest count (no bias); ``"none"``: treat the angle
#: channels as continuous (no edges, no correction; for comparison).
COUNTERS = {"floor": 0.5, "round": 0.0, "none": None}


class EncoderError(ImpactidError, ValueError):
    """An encoder channel cannot be read as asked (an unknown or unsuitable counter convention)."""


def encoder_step(angle: np.ndarray) -> float | None:
    """The count step [rad] of a quantised angle channel, or None when it is not quantised.

    :func:`impactid.signal.quantisation_step` over all samples with an encoder's options: every
    sample lies (to 1e-6 count) on the grid ``angle[0] + k step`` with ``step`` its smallest
    non-zero change, and its changes between samples take at least two different numbers of counts
    (typically 0 and 1: an encoder sampled faster than it counts); exact motion at a uniform speed
    also lies on a grid, but changes by the same amount every sample. When ``2 pi / step`` is
    within 1e-6 of a whole number of pulses per revolution, the step is taken as exactly
    ``2 pi / ppr``.

    Parameters
    ----------
    angle : samples of the angle channel [rad].

    Returns
    -------
    float or None : the count step [rad], None for a channel that is not quantised.
    """
    step = quantisation_step(angle, max_samples=None, min_steps=2, on_grid=True, reject_uniform_motion=True,
                             period=TWO_PI)
    return step if step > 0.0 else None


def pulses_per_revolution(step: float | None) -> int | None:
    """Pulses per revolution of an encoder of count ``step`` [rad]: ``2 pi / step`` when it is within
    1e-6 (relative) of a whole number, else None (also for ``step`` None)."""
    if step is None:
        return None
    ppr = TWO_PI / step
    return int(round(ppr)) if abs(ppr - round(ppr)) <= 1e-6 * ppr else None


@dataclass(frozen=True)
class CounterReading:
    """An angle channel read through a counter convention (:data:`COUNTERS`).

    Attributes
    ----------
    angle : the readings plus the counter's mean offset ``shift`` [rad] (the continuous angle, on
        average).
    step : detected count step [rad]; None when the channel is not quantised or the counter is
        ``"none"``.
    shift : the offset added to each reading [rad]: ``COUNTERS[counter] * step`` (0 without a step).
    counter : the counter convention (a key of :data:`COUNTERS`).
    """

    angle: np.ndarray = field(repr=False)
    step: float | None
    shift: float
    counter: str

    def describe(self, name: str) -> str:
        """One line on how channel ``name`` was read (for a result's notes)."""
        if self.step is None:
            return f"{name}: treated as continuous (not quantised" + (
                ": counter 'none')" if COUNTERS[self.counter] is None else ")")
        ppr = pulses_per_revolution(self.step)
        return (f"{name}: quantised, step {self.step:.6g} rad" + (f" ({ppr} counts/rev)" if ppr else "")
                + f", {self.counter} counter" + (f": {self.shift:.4g} rad added to the samples" if self.shift else ""))


def read_counter(readings: np.ndarray, counter: str = "floor") -> CounterReading:
    """Read an angle channel through a counter convention: detect its count step
    (:func:`encoder_step`) and add the counter's mean offset (half a count for ``"floor"``).

    Parameters
    ----------
    readings : samples of the angle channel [rad].
    counter : a key of :data:`COUNTERS`; ``"none"`` skips the detection (no step, no offset).

    Raises
    ------
    EncoderError : unknown counter.
    """
    if counter not in COUNTERS:
        raise EncoderError(f"unknown encoder counter {counter!r}; choose one of {', '.join(COUNTERS)}")
    readings = np.asarray(readings, dtype=float)
    offset = COUNTERS[counter]
    step = encoder_step(readings) if offset is not None else None
    shift = offset * step if step else 0.0
    return CounterReading(angle=readings + shift, step=step, shift=shift, counter=counter)


def encoder_edges(x, time, step: float, counter: str = "floor") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Count transitions of a quantised angle channel: when and at which angle the reading changed.

    Where the reading changes by ``n`` counts between samples ``k - 1`` and ``k``, the angle crossed
    ``n`` count boundaries inside that sample interval; they are placed at equally spaced times
    ``t[k-1] + (m - 1/2) / n * dt`` (for one count the middle of the interval, the unbiased guess of
    a crossing time uniformly distributed in it). With a ``"floor"`` counter the boundary between the
    readings ``r`` and ``r + step`` is the angle ``r + step`` exactly; with ``"round"``,
    ``r + step / 2``. The angle at a boundary is therefore known exactly; only its time is uncertain,
    by at most half a sample interval.

    Parameters
    ----------
    x : readings [rad].
    time : sample times [s].
    step : count step [rad].
    counter : ``"floor"`` or ``"round"`` (see :data:`COUNTERS`).

    Returns
    -------
    times [s], angles [rad] and the index ``k`` of the sample after each crossing (time ascending).

    Raises
    ------
    EncoderError : a counter without edges (``"none"``) or an unknown one.
    """
    offset = COUNTERS.get(counter)
    if offset is None:
        raise EncoderError(f"encoder edges need a 'floor' or 'round' counter, got {counter!r}")
    x = np.asarray(x, dtype=float)
    time = np.asarray(time, dtype=float)
    k = np.flatnonzero(np.diff(x) != 0.0) + 1
    n = np.rint(np.abs(x[k] - x[k - 1]) / step).astype(np.int64)
    keep = n > 0
    k, n = k[keep], n[keep]
    rep = np.repeat(np.arange(k.size), n)
    m = np.arange(rep.size) - np.repeat(np.cumsum(n) - n, n) + 1  # 1..n within each change
    forward = (x[k] > x[k - 1])[rep]
    j = np.where(forward, m, n[rep] + 1 - m)  # boundaries in the order they were crossed
    lo = np.minimum(x[k], x[k - 1])[rep]
    angles = lo + (j - 0.5 + offset) * step
    dt = (time[k] - time[k - 1])[rep]
    times = time[k - 1][rep] + dt * (m - 0.5) / n[rep]
    return times, angles, k[rep]


def local_linear(times, edge_times: np.ndarray, edge_values: np.ndarray, half_width: int) -> np.ndarray:
    """Values at ``times`` of the least-squares line through the ``2 half_width + 1`` edges nearest
    to each time (a local linear regression of ``edge_values`` on ``edge_times``).

    Used for the cam angle at the follower's edges: each cam edge has an exact angle but a time
    known to half a sample only, so linear interpolation between two edges errs by up to half a
    sample of cam motion (0.29 mrad at 110 rpm and 20 kHz, 0.14 mrad RMS); the line through 33
    edges (16 on each side: about 3.6 ms of cam motion at 110 rpm) brings this down to about
    1 urad RMS (measured 0.7 urad, at most 9 urad) while following speed changes slower than
    that window.

    Parameters
    ----------
    times : query times [s].
    edge_times : edge times [s], ascending, at least ``2 half_width + 1`` of them.
    edge_values : the angle at each edge [rad].
    half_width : edges on each side of a query time in its line.

    Returns
    -------
    ndarray : the line's value at each query time [rad], shaped like ``times``.
    """
    times = np.asarray(times, dtype=float)
    n, width = edge_times.size, 2 * half_width + 1
    start = np.clip(np.searchsorted(edge_times, times) - half_width, 0, n - width)
    idx = start[:, None] + np.arange(width)[None, :]
    dt = edge_times[idx] - times[:, None]  # centred on each query time: no cancellation
    value = edge_values[idx]
    dt_mean, value_mean = dt.mean(axis=1), value.mean(axis=1)
    ddt = dt - dt_mean[:, None]
    slope = np.sum(ddt * (value - value_mean[:, None]), axis=1) / np.sum(ddt * ddt, axis=1)
    return value_mean - slope * dt_mean


@dataclass(frozen=True)
class CamRevolutions:
    """The complete cam revolutions of a recording, counted from its first sample.

    Attributes
    ----------
    travel : cam angle turned since the first sample, positive in the direction the cam turns
        [rad], one per sample.
    turns : largest travel in revolutions [-].
    members : sample indices of each complete revolution ``k`` (``k 2 pi <= travel < (k + 1) 2 pi``),
        ascending; ``len(members) == floor(turns)``.
    """

    travel: np.ndarray = field(repr=False)
    turns: float
    members: tuple[np.ndarray, ...] = field(repr=False)

    def __len__(self) -> int:
        return len(self.members)


def complete_revolutions(cam_angle: np.ndarray) -> CamRevolutions:
    """Cut a cam-angle channel [rad] into its complete revolutions from the first sample
    (:class:`CamRevolutions`); a cam turning backwards counts its travel positive too."""
    cam = np.asarray(cam_angle, dtype=float)
    travel = cam - cam[0]
    travel = travel if travel[-1] >= 0.0 else -travel
    turns = float(np.max(travel)) / TWO_PI
    n_rev = max(int(math.floor(turns)), 0)
    rev = np.floor(travel / TWO_PI).astype(np.int64)
    inside = (rev >= 0) & (rev < n_rev)
    order = np.flatnonzero(inside)[np.argsort(rev[inside], kind="stable")]
    bounds = np.concatenate(([0], np.cumsum(np.bincount(rev[inside], minlength=n_rev))))
    members = tuple(np.sort(order[bounds[k]:bounds[k + 1]]) for k in range(n_rev))
    return CamRevolutions(travel=travel, turns=turns, members=members)

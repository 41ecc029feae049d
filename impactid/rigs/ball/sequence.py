"""Cleaning a sequence of acoustic triggers into the impacts of one bouncing drop.

The physics used
----------------
Each flight of a bouncing ball is shorter than the one before by the ratio ``T_(n+1) / T_n``,
which is the coefficient of restitution without drag and stays a smooth function of the flight
(the impact speed is ``v ~ g T / 2``, and ``e(v)`` and the drag vary smoothly with it). The cleaning
therefore predicts **every flight from the one before**, ``T_(n+1) = r(T_n) T_n``, with a smooth
ratio ``r(T) = a + b T + c T^2`` measured on the sequence itself (a line with fewer than twelve
flight pairs, a constant with fewer than five; a fit that leaves (0, 1) over the flights seen
drops a degree, because every flight is shorter than the one before). Two flights of a missed bounce are predicted as
``r(T) T + r(r(T) T) r(T) T``, and so on.
Because the prediction is local, a single genuinely odd bounce (the ball landing on a joint of
the floor, a spin) upsets one ratio only, while a trigger at the wrong time upsets two: the two
can be told apart.

The decisions
-------------
Every event is either an impact of the drop or not; every pair of consecutive accepted impacts is
one flight or spans ``k = 2, 3`` flights (missed bounces). The most probable labelling is found
exactly by dynamic programming over the pairs of last accepted events, with costs in units of the
measured scatter ``sigma`` of a predicted flight:

* a flight, or a span of ``k`` flights, costs ``z^2`` with ``z = (measured - predicted) / (sigma sqrt(k))``;
* each missed bounce costs ``C_miss = 4`` more (a missed trigger is a priori less likely than a
  heard one: e^-2 relative odds);
* an event that is not an impact costs ``C_out = z_reject^2 = 16``: an event is rejected only when
  keeping it costs more than a 4-sigma residual would (a genuine flight is rejected by chance
  about once in 16 000 under Gaussian timing noise);
* an *anomalous bounce*, a flight whose ratio to the previous one is off but whose successor
  continues the sequence, costs ``C_out + C_miss + 2 ln(1 + z^2 / C_out)``, about 20: more than
  dropping one event, so that a lone odd first interval is rather called a release artefact, less
  than dropping two. The logarithm makes the deviations of odd bounces heavy-tailed (a Cauchy
  law beyond ``z_reject``) rather than free, so that no sequence of echoes can pass for a
  sequence of odd bounces.

No ratio or interval threshold is fixed: ``r(T)`` and ``sigma`` are measured from the sequence,
robustly at first, then by least squares on the accepted flights, alternating with the labelling
until it no longer changes. Several robust starts are tried, all from the ratios of consecutive
intervals that lie in (0, 1) (the only range a pair of flights can have): a repeated-median line
through them, their median, and the centres of their densest clusters (up to four: one of them is
the bounces' even when echoes make most of the pairs); the scatter from the best quarter of the
pairs (their lower quartile of absolute residuals over 0.3186, its Gaussian value). When the starts
end in different labellings, the most probable one wins: each is scored by the -2 log-likelihood
of a mixture in which a heard impact has a Gaussian residual of the run's own scatter and a
rejected event a density common to all runs. ``sigma`` is never taken below the time resolution of
the recording (``0.7 x`` a 1/48000 s grid), nor below 1 us, nor below the precision of the smooth
model (:data:`MODEL_PRECISION` of the median interval).

What the labels mean (each event and each interval carries its reason):

* ``release``: events before the first impact of the sequence (the release click, handling, a
  first bounce disturbed by how the ball left the hand);
* ``end``: events after the last impact that continues the sequence (rolling, the ball caught,
  room noise): junk last events;
* ``echo``: a rejected trigger shortly after an accepted impact (within 25 % of the flight):
  a room echo or the click's ring-down re-triggering;
* ``spurious``: a rejected trigger elsewhere inside a flight;
* ``displaced``: a rejected trigger near the predicted time of an impact that is otherwise
  missing: the impact was heard, but its time is off by more than the noise allows;
* ``missed``: an interval spanning ``k >= 2`` flights (never the second flight of the sequence: the
  first flight has no predecessor, so a span after it could as well be a release click followed
  by the first flight, whose ratio ``2 e`` to the fall is that of a missed bounce, ``1 + e``). It is
  **not split**: splitting needs the
  restitution at the missed impact, which is the unknown, so the two made-up flights would carry
  no information of their own. The span is kept, whole, in the chained trajectory fit, which
  predicts sums of flights;
* ``anomalous``: a genuine flight whose start impact had an odd restitution; its e is reported
  but left out of the law fits, and the flight still serves as the predecessor of the next one;
* ``ok``: a flight between two heard impacts that continues the sequence (``first`` for the first
  flight of the sequence, which has no predecessor).

The sequence is refused (``refused`` holds the reason) when fewer than two consecutive flights
are found, when the flights do not shrink by more than the timing noise, or when they scatter by
more than :data:`MAX_RELATIVE_SCATTER` of a flight around the smooth sequence (random triggers).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd
from scipy.stats import siegelslopes

__all__ = ["CleanedSequence", "INTERVAL_FLAGS", "MAX_EVENTS", "clean_sequence"]

#: Interval flags, in the per-bounce table.
INTERVAL_FLAGS = ("ok", "first", "anomalous", "missed", "echo", "spurious", "displaced", "release", "end",
                  "refused")
#: Cost of a missed bounce (in units of z^2).
MISS_COST = 4.0
#: Most flights one interval may span by default (2 = one missed bounce; two in a row cannot be
#: told from the end of the sequence by one further trigger).
MAX_SPAN = 2
#: Most consecutive events skipped between two accepted impacts.
MAX_SKIP = 8
#: Relative precision of the smooth ratio model: a quadratic r(T) follows the flights of the laws of
#: :mod:`~impactid.rigs.ball.laws`, with drag, to 2e-4 of the median flight (rms; 1.7e-3 at worst,
#: for a 1 m drop; ``tests/rigs/ball/test_sequence.py``), so sigma is never taken below 5e-4 of it.
MODEL_PRECISION = 5e-4
#: Largest scatter of the flights around the smooth sequence, relative to the median flight, for
#: which the triggers are taken as the impacts of a bouncing ball (measured: 0.5 % for the
#: table-tennis recordings, 5 % for the worst rubber-ball drop; random triggers give 30 % and more).
MAX_RELATIVE_SCATTER = 0.1
#: Most events one drop may hold. A bouncing ball's flights shrink geometrically: with ``e <= 0.99``
#: and flights from 10 s (a 120 m bounce) down to 1 ms (no two clicks are told apart closer) a drop
#: has at most ln(1e-4) / ln(0.99) ~ 900 impacts; with as many echoes and spurious triggers again,
#: 2000. The bound keeps the cleaning's cost (a dynamic programme whose states grow with the events,
#: run a few dozen times) and memory (the robust starting line is a repeated median over all pairs
#: of ratios, quadratic in their number) bounded: more events are not one drop of a ball.
MAX_EVENTS = 2000
#: Columns of :attr:`CleanedSequence.intervals`.
_INTERVAL_COLUMNS = ["index", "start_s", "end_s", "interval_s", "flights", "predicted_s", "z", "flag", "reason"]
#: Ratios of consecutive intervals are summed into a density on this many grid points per block of
#: ratios (bounds the memory of the cluster search: grid points x block x 8 bytes, ~3 MB).
_DENSITY_BLOCK = 1024


@dataclass(frozen=True)
class CleanedSequence:
    """The impacts found in one drop's events.

    Attributes
    ----------
    times : all event times [s].
    status : per event: ``impact``, ``release``, ``end``, ``echo``, ``spurious`` or ``displaced``.
    impact_number : per event, the impact's number in the drop (0 = first accepted impact, missed
        impacts counted), -1 when the event is not an impact.
    event_reasons : per event, why.
    intervals : per interval between consecutive events: ``index``, ``start_s``, ``end_s``,
        ``interval_s``, ``flights`` (0 if not between two accepted impacts), ``predicted_s`` (the
        prediction from the previous flight), ``z``, ``flag`` (one of :data:`INTERVAL_FLAGS`), ``reason``.
    flights : per span between consecutive accepted impacts (a flight, or ``flights`` > 1 of them):
        ``start_event``, ``end_event`` (event indices), ``start_s``, ``duration_s``, ``flights``,
        ``predicted_s``, ``z``, ``anomalous`` (the impact at its start had an odd restitution).
    sigma : scatter of a predicted flight [s].
    ratio_model : coefficients of ``r(T)`` (highest power first).
    iterations : labelling/fit rounds until the labelling stopped changing.
    refused : empty, or why no sequence could be found.
    notes : what qualifies the result.
    """

    times: np.ndarray
    status: tuple[str, ...]
    impact_number: np.ndarray
    event_reasons: tuple[str, ...]
    intervals: pd.DataFrame = field(repr=False)
    flights: pd.DataFrame = field(default_factory=pd.DataFrame, repr=False)
    sigma: float = math.nan
    ratio_model: tuple[float, ...] = ()
    iterations: int = 0
    refused: str = ""
    notes: tuple[str, ...] = ()

    @property
    def accepted(self) -> np.ndarray:
        """Indices of the events accepted as impacts."""
        return np.flatnonzero(self.impact_number >= 0)

    def ratio(self, T) -> np.ndarray:
        """``r(T)``: predicted ratio of the next flight to a flight of ``T`` [s]."""
        return np.polyval(np.asarray(self.ratio_model), np.asarray(T, dtype=float))

    def counts(self) -> dict[str, int]:
        """Number of intervals per flag."""
        flags = self.intervals["flag"].tolist()
        return {flag: flags.count(flag) for flag in INTERVAL_FLAGS}


def _horner(model, x: float) -> float:
    value = 0.0
    for c in model:
        value = value * x + c
    return value


def _predict(model, prev: float, k: int) -> tuple[float, float]:
    """Sum of the ``k`` flights after a flight ``prev`` and the last of them (NaN if not physical)."""
    total, f = 0.0, prev
    for _ in range(k):
        r = _horner(model, f)
        if not 0.0 < r < 1.0:  # every flight is shorter than the one before: e < 1, drag only slows
            return math.nan, math.nan
        f = r * f
        total += f
    return total, f


def _last_of_span(model, span: float, k: int) -> float:
    """The last flight of a span of ``k`` flights of total ``span``, shaped by ``r(T)``."""
    if k == 1:
        return span
    if k == 2 and len(model) <= 2:  # T (1 + a + b T) = span: a quadratic in the first flight T
        b, a = (0.0, model[0]) if len(model) == 1 else (model[0], model[1])
        if b == 0.0:
            first = span / (1.0 + a)
        else:
            disc = (1.0 + a) ** 2 + 4.0 * b * span
            if disc < 0.0:
                return math.nan
            first = 2.0 * span / ((1.0 + a) + math.sqrt(disc))
        return span - first
    first = span / k
    last = math.nan
    for _ in range(60):
        total, f, chain_last = first, first, first
        for _ in range(k - 1):
            f = _horner(model, f) * f
            total += f
            chain_last = f
        if not total > 0.0:
            return math.nan
        if abs(total - span) <= 1e-13 * span:
            return chain_last
        first *= span / total
        last = chain_last
    return last


def _label(times: np.ndarray, model, sigma: float, z_reject: float, max_span: int = MAX_SPAN,
           max_skip: int = MAX_SKIP):
    """Exact minimum-cost labelling by dynamic programming over the last two accepted events.

    Returns the accepted chain as a list of (event index, flights from the previous accepted
    event, anomalous) and its cost."""
    m = times.size
    c_out = z_reject ** 2
    c_anom = c_out + MISS_COST
    # state (i, j, k) -> [cost, back state, (span, flights) whose last flight is the state's, anomalous]
    states: dict[tuple[int, int, int], list] = {}
    model = [float(c) for c in model]
    for i in range(m):
        for j in range(i + 1, min(m, i + max_skip + 2)):
            states[(i, j, 1)] = [c_out * i + c_out * (j - i - 1), None, (times[j] - times[i], 1), False]
    by_end: dict[int, list[tuple[int, int, int]]] = {}
    for key in states:
        by_end.setdefault(key[1], []).append(key)
    for j in range(m):
        for key in sorted(by_end.get(j, [])):
            cost, back, (span, k_prev), _ = states[key]
            last = _last_of_span(model, span, k_prev)  # once per state, not at every improvement
            # after the first flight (no predecessor, so unverified) only a single flight may follow:
            # a span there would be indistinguishable from a release artefact (fall time ~ flight / 2e)
            spans = 1 if back is None else max_span
            # the predicted spans after this state's last flight do not depend on the next event
            predictions = []
            for k in range(1, spans + 1):
                total = _predict(model, last, k)[0]
                if not math.isfinite(total):
                    break
                predictions.append((k, total, sigma * math.sqrt(k + (1 if k_prev > 1 else 0))))
            for n in range(j + 1, min(m, j + max_skip + 2)):
                gap = times[n] - times[j]
                base = cost + c_out * (n - j - 1)
                for k, total, spread in predictions:
                    z = (gap - total) / spread
                    new = base + z * z + MISS_COST * (k - 1)
                    anomalous = False
                    odd = base + c_anom + 2.0 * math.log1p(z * z / c_out)
                    if k == 1 and odd < new:
                        new, anomalous = odd, True
                    target = (j, n, k)
                    if target not in states or new < states[target][0]:
                        if target not in states:
                            by_end.setdefault(n, []).append(target)
                        states[target] = [new, key, (gap, k), anomalous]
                    if total > gap + 6 * spread:
                        break
    if not states:
        return [], math.inf
    end_key = min(states, key=lambda s: states[s][0] + c_out * (m - 1 - s[1]))
    total_cost = states[end_key][0] + c_out * (m - 1 - end_key[1])
    chain = []
    key = end_key
    while key is not None:
        _, back, _, anomalous = states[key]
        chain.append((key[1], key[2], anomalous))
        if back is None:
            chain.append((key[0], 0, False))
        key = back
    chain.reverse()
    return chain, float(total_cost)


def _pairs(times: np.ndarray, chain):
    """(previous flight, flight) pairs of consecutive single flights that are not anomalous."""
    prev, nxt = [], []
    for a in range(2, len(chain)):
        (i, _, _), (j, k1, _), (n, k2, anomalous) = chain[a - 2], chain[a - 1], chain[a]
        if k1 == 1 and k2 == 1 and not anomalous:
            prev.append(times[j] - times[i])
            nxt.append(times[n] - times[j])
    return np.array(prev), np.array(nxt)


def _fit_ratio(prev: np.ndarray, nxt: np.ndarray):
    """Least squares ``T_next = r(T_prev) T_prev`` with ``r(T) = a + b T + c T^2`` (a line with
    fewer than twelve pairs, a constant with fewer than five; one degree less when ``r`` leaves
    (0, 1) over the flights seen), and the residual scale."""
    coef = X = None
    for degree in ((2, 1, 0) if prev.size >= 12 else (1, 0) if prev.size >= 5 else (0,)):
        with np.errstate(over="ignore", invalid="ignore"):
            X = np.column_stack([prev ** (p + 1) for p in range(degree, -1, -1)])
        if not (np.all(np.isfinite(X)) and np.all(np.isfinite(nxt))):
            # never hand non-finite numbers to LAPACK: its SVD can loop forever on them, out of reach
            # of Ctrl-C and SIGTERM (the readers refuse such times; this guards direct callers)
            coef = None
            continue
        coef, *_ = np.linalg.lstsq(X, nxt, rcond=None)
        ends = np.polyval(coef, [prev.min(), prev.max()])
        if np.all((ends > 0.0) & (ends < 1.0)):  # physical over the flights seen, else one degree less
            break
    if coef is None:
        return np.array([math.nan]), math.nan
    resid = nxt - X @ coef
    dof = max(prev.size - degree - 1, 1)
    return coef, math.sqrt(float(resid @ resid) / dof)


def clean_sequence(times, *, resolution: float = math.nan, z_reject: float = 4.0, max_span: int = MAX_SPAN,
                   max_skip: int = MAX_SKIP, max_iter: int = 20, name: str = "") -> CleanedSequence:
    """Label the events of one drop as impacts, missed bounces, echoes, spurious or displaced
    triggers, anomalous bounces, release artefacts and junk at the end (see the module notes).

    Parameters
    ----------
    times : event times [s], strictly increasing.
    resolution : time step of the events [s] (NaN if unknown): ``sigma`` is never below
        ``0.7 x resolution``.
    z_reject : residual [sigma] beyond which keeping an event costs more than rejecting it.
    max_span : most flights one interval may span (2: one missed bounce at a time).
    max_skip : most rejected triggers between two accepted impacts.
    max_iter : most labelling/fit rounds.
    name : the drop's name, for the messages.

    Returns
    -------
    CleanedSequence (with ``refused`` set when no bouncing sequence is found).
    """
    t = np.asarray(times, dtype=float)
    if t.ndim != 1 or t.size < 3 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise ValueError("times must be a 1-D strictly increasing finite array of at least 3 events")
    if t.size > MAX_EVENTS:
        raise ValueError(f"{t.size} events: more than one drop of a ball can hold (at most {MAX_EVENTS})")
    d = np.diff(t)
    if not float(np.max(d)) < 1e100:  # the ratio model is fitted on powers of the flights up to T^3
        raise ValueError(f"an interval of {float(np.max(d)):.3g} s is beyond any flight of a ball")
    floor = max(0.7 * resolution if math.isfinite(resolution) else 0.0, 1e-6, MODEL_PRECISION * float(np.median(d)))
    ratios = d[1:] / d[:-1]
    # a pair of intervals shrinks only when the second is shorter than the first by more than the
    # timing noise can make it: the ratios of a metronome's intervals lie within a few ulps of 1, on
    # either side depending on how the times were rounded, and are no evidence of a bounce
    plausible = (ratios > 0.0) & (d[1:] < d[:-1] - floor)
    where = f"{name}: " if name else ""
    if plausible.sum() == 0:
        return _refusal(t, f"{where}no two consecutive intervals shrink beyond the timing noise ({1e3 * floor:.2g} "
                           "ms): not a ball bouncing on a floor")
    r_ok = ratios[plausible]
    starts = [np.array([float(np.median(r_ok))])]
    if r_ok.size >= 3:  # the clusters of ratios: one of them is the bounces' even when echoes dominate
        grid = np.linspace(0.0, 1.0, 401)
        density = np.zeros(grid.size)
        for first in range(0, r_ok.size, _DENSITY_BLOCK):  # blockwise: memory independent of the events
            block = r_ok[first:first + _DENSITY_BLOCK]
            density += np.exp(-0.5 * ((grid[:, None] - block[None, :]) / 0.01) ** 2).sum(axis=1)
        peaks = [i for i in range(1, grid.size - 1) if density[i] >= density[i - 1] and density[i] > density[i + 1]
                 and density[i] >= 0.2 * density.max()]
        for i in sorted(peaks, key=lambda i: -density[i])[:4]:
            starts.append(np.array([float(grid[i])]))
    if plausible.sum() >= 5:
        slope, intercept = siegelslopes(ratios[plausible], d[:-1][plausible])
        starts.insert(0, np.array([slope, intercept]))
    runs = []
    for model in starts:
        resid = d[1:][plausible] - np.polyval(model, d[:-1][plausible]) * d[:-1][plausible]
        # scale from the best quarter of the pairs (for Gaussian residuals, |r| has its lower quartile at
        # 0.3186 sigma): with echoes or other faults in most pairs, the median would be theirs
        sigma = max(float(np.quantile(np.abs(resid), 0.25)) / 0.3186, floor)
        runs.append(_iterate(t, model, sigma, floor, z_reject, max_span, max_skip, max_iter))
    chain, model, sigma, iterations = runs[0]
    scores = [0.0] * len(runs)
    if any(run[0] != chain for run in runs[1:]):
        # different labellings from the starts: keep the most probable one. Each is scored with its
        # own model and scatter, as -2 log-likelihood of a mixture in which a heard impact has a
        # Gaussian residual and a rejected event a density that is the same for every run (that of
        # the widest scatter): z^2 + ln(sigma^2 / sigma_ref^2) per flight, C_out per rejected event
        reference = max(run[2] for run in runs)
        scores = []
        for run_chain, run_model, run_sigma, _ in runs:
            cost = _label(t, run_model, run_sigma, z_reject, max_span, max_skip)[1]
            flights = max(len(run_chain) - 2, 0)
            scores.append(cost + flights * 2.0 * math.log(run_sigma / reference))
        chain, model, sigma, iterations = runs[int(np.argmin(scores))]
    result = _result(t, chain or [], model, sigma, iterations, name)
    if result.refused:
        # cleaning, not discarding: a labelling from another start that is a bouncing sequence beats
        # the most probable one when that one is not (a few faults can pull a start astray)
        usable = []
        for k in np.argsort(scores, kind="stable"):
            run_chain, run_model, run_sigma, run_iterations = runs[int(k)]
            if run_chain == chain:
                continue
            other = _result(t, run_chain or [], run_model, run_sigma, run_iterations, name)
            if not other.refused:
                usable.append(other)
                break
        if usable:
            return replace(usable[0], notes=usable[0].notes + (
                "the most probable labelling was not a bouncing sequence; the most probable one that is was kept",))
    return result


def _iterate(t, model, sigma, floor, z_reject, max_span, max_skip, max_iter):
    """Alternate labelling and fitting ``r(T)`` until the labelling stops changing."""
    chain = None
    iterations = 0
    for _round in range(1, max_iter + 1):
        iterations = _round
        new_chain, _ = _label(t, model, sigma, z_reject, max_span, max_skip)
        prev, nxt = _pairs(t, new_chain)
        if prev.size < 1:
            chain = new_chain
            break
        model, scatter = _fit_ratio(prev, nxt)
        sigma = max(scatter, floor)
        if new_chain == chain:
            break
        chain = new_chain
    return chain, model, sigma, iterations


def _refusal(t: np.ndarray, reason: str) -> CleanedSequence:
    d = np.diff(t)
    table = pd.DataFrame({"index": np.arange(d.size), "start_s": t[:-1], "end_s": t[1:], "interval_s": d,
                          "flights": 0, "predicted_s": math.nan, "z": math.nan, "flag": "refused",
                          "reason": f"not used: {reason}"})
    return CleanedSequence(times=t, status=("refused",) * t.size, impact_number=np.full(t.size, -1),
                           event_reasons=(reason,) * t.size, intervals=table, flights=_empty_flights(),
                           refused=reason)


def _empty_flights() -> pd.DataFrame:
    return pd.DataFrame(columns=["start_event", "end_event", "start_s", "duration_s", "flights", "predicted_s", "z",
                                 "anomalous"])


@dataclass(frozen=True)
class Link:
    """One accepted impact of the chain the labelling found.

    Attributes
    ----------
    event : its event index.
    flights : flights from the previous accepted impact (0 for the first; 2 spans a missed bounce).
    anomalous : whether the impact before it had an odd restitution (its flight is anomalous).
    """

    event: int
    flights: int
    anomalous: bool


@dataclass(frozen=True)
class IntervalRow:
    """One row of :attr:`CleanedSequence.intervals` (see there)."""

    index: int
    start_s: float
    end_s: float
    interval_s: float
    flights: int = 0
    predicted_s: float = math.nan
    z: float = math.nan
    flag: str = ""
    reason: str = ""


@dataclass(frozen=True)
class FlightSpan:
    """One row of :attr:`CleanedSequence.flights` (see there)."""

    start_event: int
    end_event: int
    start_s: float
    duration_s: float
    flights: int
    predicted_s: float
    z: float
    anomalous: bool


@dataclass(frozen=True)
class EventLabels:
    """Per event: its status, the reason, and its impact number (-1 when it is not an impact)."""

    status: tuple[str, ...]
    reasons: tuple[str, ...]
    number: np.ndarray


def _too_short(t: np.ndarray, model, where: str) -> CleanedSequence:
    """The refusal when fewer than three triggers form a chain: either the fitted ratio predicts
    no shorter flight (the triggers do not shrink), or too few triggers were found."""
    ratio = float(np.polyval(np.asarray(model, dtype=float), np.median(np.diff(t)))) if len(model) else math.nan
    if math.isfinite(ratio) and not ratio < 1.0:
        # the ratio fitted to the triggers predicts no shorter flight, so no chain of flights can
        # form: the reason is that they do not shrink, not that too few triggers were found
        return _refusal(t, f"{where}the flights do not shrink: the ratio of consecutive intervals fitted to the "
                           f"triggers is {ratio:.6g}, not below 1: not a ball bouncing on a floor")
    return _refusal(t, f"{where}no bouncing sequence: fewer than three triggers form one")


def _last_flights(t: np.ndarray, links: Sequence[Link], model) -> dict[int, float]:
    """The last flight [s] of the span that ends at each accepted impact (its predecessor flight)."""
    return {b.event: _last_of_span(model, t[b.event] - t[a.event], b.flights) for a, b in zip(links, links[1:])}


def _span_prediction(model, prev: float, k: int, k_prev: int, gap: float, sigma: float) -> tuple[float, float]:
    """The predicted span [s] of ``k`` flights after a flight ``prev`` [s], and the measured ``gap``'s
    residual [sigma]; its spread grows with the flights spanned, and by one more when the span
    before it held several (NaN without a predecessor)."""
    total = _predict(model, prev, k)[0] if math.isfinite(prev) else math.nan
    z = (gap - total) / (sigma * math.sqrt(k + (1 if k_prev > 1 else 0))) if math.isfinite(total) else math.nan
    return total, z


def _rejected_trigger(t: np.ndarray, x: int, i: int, j: int, k: int, prev: float, model,
                      sigma: float) -> tuple[str, str]:
    """Status and reason of a trigger ``x`` between the accepted impacts ``i`` and ``j`` (a span of
    ``k`` flights after a flight ``prev`` [s]): ``displaced`` near a predicted impact, ``echo`` soon
    after ``i``, else ``spurious``."""
    f0 = _predict(model, prev, 1)[0] if math.isfinite(prev) else (t[j] - t[i]) / k
    predicted = [t[i] + _predict(model, prev, q)[0] for q in range(1, k)] if math.isfinite(prev) else [
        t[i] + q * (t[j] - t[i]) / k for q in range(1, k)]
    dt = t[x] - t[i]
    near = min(predicted, key=lambda p: abs(t[x] - p)) if predicted else math.nan
    if predicted and abs(t[x] - near) < 0.15 * f0:
        kept = ""
        if math.isfinite(prev):
            before = dt
            z1 = (before - _predict(model, prev, 1)[0]) / sigma
            z2 = (t[j] - t[x] - _predict(model, before, 1)[0]) / sigma
            kept = f"; kept, it would put its two flights at {z1:+.1f} and {z2:+.1f} sigma"
        return "displaced", (f"trigger {1e3 * (t[x] - near):+.2f} ms from the predicted impact at {near:.5f} s"
                             f"{kept}: the impact was heard but its time is unreliable")
    if dt < 0.25 * f0:
        return "echo", (f"trigger {1e3 * dt:.2f} ms after the impact at {t[i]:.5f} s, far shorter than "
                        f"the predicted flight ({1e3 * f0:.1f} ms): echo or ring-down")
    return "spurious", (f"trigger inside the flight from {t[i]:.5f} s ({1e3 * dt:.1f} ms into a predicted "
                        f"{1e3 * f0:.1f} ms flight): spurious")


def _event_labels(t: np.ndarray, links: Sequence[Link], model, sigma: float,
                  last_flight: Mapping[int, float]) -> EventLabels:
    """Every event labelled: the accepted impacts (numbered, missed ones counted), the release
    before the first, the junk after the last, and each rejected trigger between two impacts."""
    m = t.size
    status = ["?"] * m
    reasons = [""] * m
    number = np.full(m, -1, dtype=int)
    n = 0
    for link in links:
        n += link.flights
        number[link.event] = n
        status[link.event] = "impact"
        reasons[link.event] = f"impact {n} of the drop"
    first, last = links[0].event, links[-1].event
    for i in range(first):
        status[i] = "release"
        reasons[i] = (f"before the first impact of the bouncing sequence (t = {t[first]:.5f} s): release, "
                      "handling or a first bounce that does not continue the sequence")
    for i in range(last + 1, m):
        status[i] = "end"
        reasons[i] = f"after the last impact that continues the sequence (t = {t[last]:.5f} s): junk at the end"
    for a, b in zip(links, links[1:]):
        prev = last_flight.get(a.event, math.nan)
        for x in range(a.event + 1, b.event):
            status[x], reasons[x] = _rejected_trigger(t, x, a.event, b.event, b.flights, prev, model, sigma)
    return EventLabels(tuple(status), tuple(reasons), number)


def _flight_row(t: np.ndarray, i: int, link: Link, k_prev: int, first: int, model, sigma: float,
                prev: float) -> IntervalRow:
    """The row of an interval between two consecutive accepted impacts: ``ok``, ``first``,
    ``anomalous`` or ``missed`` (a span of several flights), with its prediction."""
    gap = t[i + 1] - t[i]
    k = link.flights
    total, z = _span_prediction(model, prev, k, k_prev, gap, sigma)
    row = IntervalRow(i, t[i], t[i + 1], gap, k, total, z)
    if k > 1:
        single = _predict(model, prev, 1)[0] if math.isfinite(prev) else math.nan
        reason = (f"spans {k} flights: {gap / single:.3f} x the predicted single flight ({1e3 * single:.1f} ms; "
                  f"{k} flights predicted {1e3 * total:.1f} ms, {z:+.1f} sigma): {k - 1} bounce(s) not triggered; "
                  "not split, kept whole for the chained fit") if math.isfinite(single) else (
            f"spans {k} flights: {k - 1} bounce(s) not triggered; not split, kept whole for the chained fit")
        return replace(row, flag="missed", reason=reason)
    if not math.isfinite(total):
        return replace(row, flag="first", reason=("first flight of the sequence" if i == first else
                                                  "first flight after a missed bounce") + ": no measured predecessor")
    if link.anomalous:
        return replace(row, flag="anomalous", reason=(
            f"flight {1e3 * gap:.1f} ms where {1e3 * total:.1f} ms was predicted from the previous one "
            f"({z:+.1f} sigma) while the next flight continues the sequence: an odd bounce (a floor joint, "
            "spin or an off-centre hit would do this); its e is kept out of the law fits"))
    return replace(row, flag="ok", reason=f"one flight, {z:+.1f} sigma from the prediction")


def _other_row(t: np.ndarray, i: int, links: Sequence[Link], labels: EventLabels) -> IntervalRow:
    """The row of an interval that is not a flight between consecutive impacts: release, end, or
    one that touches a rejected trigger (named, with the span it lies in)."""
    first, last = links[0].event, links[-1].event
    row = IntervalRow(i, t[i], t[i + 1], t[i + 1] - t[i])
    if i < first:
        return replace(row, flag="release", reason=labels.reasons[i])
    if i >= last:
        return replace(row, flag="end", reason=labels.reasons[i + 1])
    culprit = i if labels.status[i] != "impact" else i + 1
    reason = f"touches a rejected trigger: {labels.reasons[culprit]}"
    left = max(link for link in range(len(links)) if links[link].event <= i)
    span = links[left + 1] if left + 1 < len(links) else None
    if span is not None and span.flights > 1:
        reason += (f"; the span from {t[links[left].event]:.5f} s to {t[span.event]:.5f} s holds {span.flights} "
                   f"flights ({span.flights - 1} bounce(s) not triggered)")
    return replace(row, flag=labels.status[culprit], reason=reason)


def _interval_table(t: np.ndarray, links: Sequence[Link], labels: EventLabels, model, sigma: float,
                    last_flight: Mapping[int, float]) -> pd.DataFrame:
    """One row per interval between consecutive events (:attr:`CleanedSequence.intervals`)."""
    after = {a.event: (b, a.flights) for a, b in zip(links, links[1:])}  # impact -> (next link, flights into it)
    rows = []
    for i in range(t.size - 1):
        nxt = after.get(i) if labels.status[i] == "impact" else None
        if nxt is not None and nxt[0].event == i + 1:
            rows.append(_flight_row(t, i, nxt[0], nxt[1], links[0].event, model, sigma,
                                    last_flight.get(i, math.nan)))
        else:
            rows.append(_other_row(t, i, links, labels))
    return pd.DataFrame([vars(r) for r in rows], columns=_INTERVAL_COLUMNS)


def _flight_table(t: np.ndarray, links: Sequence[Link], model, sigma: float,
                  last_flight: Mapping[int, float]) -> pd.DataFrame:
    """One row per span between consecutive accepted impacts (:attr:`CleanedSequence.flights`)."""
    spans = []
    for a, b in zip(links, links[1:]):
        gap = t[b.event] - t[a.event]
        total, z = _span_prediction(model, last_flight.get(a.event, math.nan), b.flights, a.flights, gap, sigma)
        spans.append(FlightSpan(a.event, b.event, t[a.event], gap, b.flights, total, z, bool(b.anomalous)))
    return pd.DataFrame([vars(s) for s in spans]) if spans else _empty_flights()


def _refusal_reason(table: pd.DataFrame, model, sigma: float, accepted: int, where: str) -> str:
    """Why the labelled sequence is not a bouncing ball ("" when it is): no two consecutive
    flights, flights that do not shrink beyond the timing noise, or a scatter beyond
    :data:`MAX_RELATIVE_SCATTER`."""
    flags = table["flag"].tolist()
    singles = [f in ("ok", "first", "anomalous") for f in flags]
    pairs = sum(a and b for a, b in zip(singles, singles[1:]))
    if pairs < 1:
        return (f"{where}no bouncing sequence: no two consecutive flights between heard impacts "
                f"({accepted} impacts accepted); at least two are needed for one coefficient of restitution")
    durations = table.loc[np.array(singles), "interval_s"].to_numpy()
    r_mean = float(np.polyval(model, np.median(durations)))
    shrink = float(durations[0] - durations[-1])
    if not r_mean < 1.0 or shrink < 3.0 * math.sqrt(2.0) * sigma:
        return (f"{where}the flights do not shrink beyond the timing noise (first {1e3 * durations[0]:.1f} "
                f"ms, last {1e3 * durations[-1]:.1f} ms, scatter {1e3 * sigma:.2g} ms): not a ball bouncing on "
                "a floor")
    if sigma > MAX_RELATIVE_SCATTER * float(np.median(durations)):
        return (f"{where}the flights scatter by {100 * sigma / np.median(durations):.0f} % around a smooth "
                f"sequence (more than {100 * MAX_RELATIVE_SCATTER:.0f} %): the triggers are not the impacts "
                "of a bouncing ball")
    return ""


def _result(t, chain, model, sigma, iterations, name) -> CleanedSequence:
    """The :class:`CleanedSequence` of a labelling ``chain`` (from :func:`_label`) of the events
    ``t`` [s], with the ratio model and scatter [s] it was found with; refused when it is not a
    bouncing sequence."""
    where = f"{name}: " if name else ""
    if len(chain) < 3:
        return _too_short(t, model, where)
    links = tuple(Link(int(i), int(k), bool(anomalous)) for i, k, anomalous in chain)
    last_flight = _last_flights(t, links, model)
    labels = _event_labels(t, links, model, sigma, last_flight)
    table = _interval_table(t, links, labels, model, sigma, last_flight)
    flights = _flight_table(t, links, model, sigma, last_flight)
    refused = _refusal_reason(table, model, sigma, len(links), where)
    if refused:
        table["reason"] = [f"not used: {refused} (cleaning said: {flag}, {reason})"
                           for flag, reason in zip(table["flag"], table["reason"])]
        table["flag"] = "refused"
    return CleanedSequence(times=t, status=labels.status, impact_number=labels.number, event_reasons=labels.reasons,
                           intervals=table, flights=flights, sigma=float(sigma),
                           ratio_model=tuple(float(c) for c in model), iterations=iterations, refused=refused)

"""The whole job: files -> restitution laws, with every decision recorded.

:func:`analyse_bounces` reads each file (one drop each), cleans its triggers
(:func:`~impactid.rigs.ball.sequence.clean_sequence`), inverts every flight exactly into launch
and landing speeds (:mod:`~impactid.rigs.ball.flight`, with air when the ball is known), forms the
coefficient of restitution of every impact between two single flights, fits the laws of
:mod:`~impactid.rigs.ball.laws` (GLS with the timing-noise covariance, errors cluster-robust by
drop), selects one, cross-checks it with the chained trajectory fit, and compares the speed
dependence with and without drag. The result is a :class:`BounceAnalysis` with a per-bounce table
(one row per interval of every file, with its flag and reason), the fits, and notes for what
cannot be determined.

Each step is a function of its own, and what passes between them is typed: the recordings are
read and checked (:func:`_read_drops`), cleaned into :class:`Drop` objects (:func:`_clean_drops`),
turned into :class:`Impacts` under a flight model (:func:`_impacts`, through
:func:`impacts_from_sequence`), fitted (:func:`_fit_all` -> :class:`LawFits`, each law's fit a
:class:`~impactid.rigs.ball.laws.LawFit`, the one :class:`~impactid.results.FitResult` of the rig),
selected (:func:`_select` -> :class:`Selection`); each further check (the speed range, the fits
without air, the drag coefficient's sensitivity, the terminal speed that would explain the slope,
the chained fits) returns a :class:`Finding`: its notes and its entries of ``details``.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd
from scipy.sparse import block_diag, csr_matrix

from impactid._files import DuplicateInputError
from impactid.errors import ImpactidError
from impactid.results import FitResult, Parameter
from impactid.rigs.ball import figures
from impactid.rigs.ball.flight import (
    FlightConstants,
    flight_constants,
    flight_time,
    flight_time_derivative,
    invert_flights,
    landing_speed,
    landing_speed_derivative,
    launch_from_landing,
    restitution_from_flights,
)
from impactid.rigs.ball.laws import (
    LAWS,
    ChainedFit,
    LawFit,
    TimingNoise,
    fit_chained,
    fit_law,
    get_law,
    law_table,
    select_law,
    variance_model,
)
from impactid.rigs.ball.parameters import Ball
from impactid.rigs.ball.readers import BounceFileError, BounceRecording, read_drops
from impactid.rigs.ball.sequence import CleanedSequence, clean_sequence

__all__ = ["BounceAnalysis", "BounceAnalysisError", "analyse_bounces", "impacts_from_sequence"]

#: Uncertainty of a typical drag coefficient at bouncing speeds (see :mod:`~impactid.rigs.ball.parameters`);
#: the analysis reports how the speed dependence moves across it.
DRAG_COEFFICIENT_UNCERTAINTY = 0.1

#: Columns of the per-bounce table.
BOUNCE_COLUMNS = ["file", "drop", "index", "start_s", "end_s", "interval_s", "flag", "reason", "flights", "z",
                  "flight_s", "impact_speed_m_s", "launch_speed_m_s", "e", "used", "e_note"]


class BounceAnalysisError(ImpactidError, ValueError):
    """No file could be analysed (each one's reason is in the message)."""


@dataclass(frozen=True)
class BounceAnalysis(FitResult):
    """Restitution of a ball on a floor from bounce timings.

    Parameters: ``constant.e``, ``linear.e0``, ``linear.gamma``, ``viscoelastic.a`` (per-impact
    fits). Tables: ``bounces`` (one row per interval, see :data:`BOUNCE_COLUMNS`), ``laws``.
    Details: ``laws``, ``chained``, ``no_drag`` (each law's :class:`~impactid.rigs.ball.laws.LawFit`
    or :class:`~impactid.rigs.ball.laws.ChainedFit` as its JSON dict; :attr:`law_fits`,
    :attr:`chained_fits`, :attr:`no_drag_fits` rebuild them), ``drag_sensitivity``, ``selected``,
    ``selection``, ``criterion``, ``ball``, ``flight``, ``files``, ``refused``, ``sequences``.
    """

    kind = "bounce-analysis"
    title = "Restitution from bounce timing"

    @property
    def selected(self) -> str:
        """Name of the selected law."""
        return str(self.details.get("selected", ""))

    def _fits(self, key: str) -> dict[str, FitResult]:
        return {name: FitResult.from_dict(data) for name, data in (self.details.get(key) or {}).items()}

    @property
    def law_fits(self) -> dict[str, LawFit]:
        """The per-impact fits by law."""
        return self._fits("laws")

    @property
    def chained_fits(self) -> dict[str, ChainedFit]:
        """The chained trajectory fits by law."""
        return self._fits("chained")

    @property
    def no_drag_fits(self) -> dict[str, LawFit]:
        """The per-impact fits without air (only when the main analysis includes drag)."""
        return self._fits("no_drag")

    @property
    def bounces(self) -> pd.DataFrame:
        """The per-bounce table."""
        return self.to_pandas("bounces")

    def summary(self) -> dict:
        """The headline numbers as a JSON-ready dict (``constant.e``, ``linear.gamma``, ...)."""
        out: dict = {}
        for name, fit in self.law_fits.items():
            entry = {}
            for p in fit.params.values():
                entry[p.name] = p.value
                entry[f"{p.name}_stderr"] = p.stderr
                entry[f"{p.name}_interval"] = list(p.interval)
            entry.update(aic=fit.statistics["aic"], bic=fit.statistics["bic"])
            out[name] = entry
        out["selected"] = self.selected
        out["selection"] = self.details.get("selection", "")
        chained = {}
        for name, fit in self.chained_fits.items():
            chained[name] = {p.name: p.value for p in fit.params.values()} | {
                f"{p.name}_stderr": p.stderr for p in fit.params.values()} | {
                "aic": fit.statistics["aic"], "bic": fit.statistics["bic"],
                "timing_sigma_s": fit.statistics["timing_sigma_s"]}
        out["chained"] = chained
        no_drag = {}
        for name, fit in self.no_drag_fits.items():
            no_drag[name] = {p.name: p.value for p in fit.params.values()} | {
                f"{p.name}_stderr": p.stderr for p in fit.params.values()}
        if no_drag:
            out["no_drag"] = no_drag
        table = self.bounces
        out["bounces"] = [
            {"file": r.file, "index": int(r.index), "interval_s": r.interval_s,
             "impact_speed_m_s": r.impact_speed_m_s, "e": r.e, "flag": r.flag, "reason": r.reason,
             "used": bool(r.used), "e_note": r.e_note}
            for r in table.itertuples(index=False)]
        return out

    def plot(self, ax=None, **kwargs):
        """e against impact speed with the fitted laws and their bands."""
        return figures.plot_restitution(self, ax=ax, **kwargs)

    def plot_intervals(self, **kwargs):
        """Intervals against bounce number per drop, rejected ones marked."""
        return figures.plot_intervals(self, **kwargs)


@dataclass(frozen=True)
class Coefficient:
    """The coefficient of restitution at one accepted impact, or why there is none.

    Attributes
    ----------
    flight_s : the flight after the impact [s] (NaN when it spans a missed bounce).
    launch_speed_m_s : the launch speed of that flight [m/s].
    impact_speed_m_s : the landing speed of the flight before [m/s] (NaN without one).
    e : ``launch / impact`` speed [-] (NaN when it cannot be formed).
    note : why it is not formed or not used ("" when used).
    jacobian : when used, its derivative ``de/dt`` [1/s] with respect to the three event times
        it depends on, as ``((m, j, i), (de/dt_m, de/dt_j, de/dt_i))``; None otherwise.
    """

    flight_s: float = math.nan
    launch_speed_m_s: float = math.nan
    impact_speed_m_s: float = math.nan
    e: float = math.nan
    note: str = ""
    jacobian: tuple[tuple[int, int, int], tuple[float, float, float]] | None = None

    @property
    def used(self) -> bool:
        """Whether the coefficient enters the law fits."""
        return self.jacobian is not None


def _coefficient(event: int, after, before, constants: FlightConstants) -> Coefficient:
    """The coefficient at the impact ``event`` from the flight spans ``after`` and ``before`` it
    (rows of :attr:`CleanedSequence.flights`; ``before`` None for the first impact).

    ``e = u(T_a) / w(T_b)`` with ``T_a = t_m - t_j`` and ``T_b = t_j - t_i``; its derivatives with
    respect to ``t_m``, ``t_j``, ``t_i`` come from the exact derivatives of the flight inversion."""
    if int(after.flights) != 1:
        return Coefficient(note="no e: the flight after this impact is not measured alone (missed bounce)")
    T_after = float(after.duration_s)
    u_after = float(invert_flights(T_after, constants)[0])
    if before is None:
        return Coefficient(T_after, u_after, note="no e: first impact of the sequence (no measured flight before it)")
    if int(before.flights) != 1:
        return Coefficient(T_after, u_after, note="no e: the flight before this impact spans a missed bounce")
    u_b, w_b = (float(x) for x in invert_flights(float(before.duration_s), constants))
    e = u_after / w_b
    if bool(after.anomalous):
        return Coefficient(T_after, u_after, w_b, e,
                           "odd bounce (the flight after it is anomalous): not used in the law fits")
    if not (math.isfinite(e) and e > 0):
        return Coefficient(T_after, u_after, w_b, e, "no e: flight inversion failed")
    du_dT = 1.0 / float(flight_time_derivative(u_after, constants))
    dw_dT = float(landing_speed_derivative(u_b, constants)) / float(flight_time_derivative(u_b, constants))
    A = du_dT / w_b
    B = e * dw_dT / w_b
    return Coefficient(T_after, u_after, w_b, e, "",
                       ((int(after.end_event), event, int(before.start_event)), (A, -A - B, B)))


def impacts_from_sequence(seq: CleanedSequence, constants: FlightConstants, *, file: str = "",
                          drop: int = 0) -> tuple[pd.DataFrame, object]:
    """Per-interval rows of one cleaned drop with the speeds and coefficients of its impacts, and
    the Jacobian ``de/dt`` [1/s] of the used coefficients with respect to the event times.

    The coefficient at an accepted impact needs a single flight before and a single flight after
    it: ``e = u(T_after) / w(T_before)``, the impact speed is ``w(T_before)`` (:func:`_coefficient`).
    It is used in the fits unless the flight after it is anomalous.

    Parameters
    ----------
    seq : the drop's cleaned sequence.
    constants : the flight model.
    file : the drop's name, for the table.
    drop : the drop's number, for the table (the cluster of its impacts).

    Returns
    -------
    table : one row per interval (:data:`BOUNCE_COLUMNS`); speeds [m/s], flights [s].
    jacobian : (used coefficients, events) sparse CSR matrix ``de/dt`` [1/s], three entries a row
        (its memory grows with the impacts, not with their square).
    """
    table = seq.intervals.copy()
    table.insert(0, "file", file)
    table.insert(1, "drop", drop)
    coefficients: dict[int, Coefficient] = {}  # by table row
    if seq.refused or seq.flights.empty:
        table["flag"] = "refused"
        if seq.refused:
            table["reason"] = f"not used: {seq.refused}"
        note = ["drop refused"] * len(table)
    else:
        ending = {int(r.end_event): r for r in seq.flights.itertuples(index=False)}
        row_of_event = {int(i): k for k, i in enumerate(table["index"])}
        for after in seq.flights.itertuples(index=False):
            event = int(after.start_event)
            if event in row_of_event:
                coefficients[row_of_event[event]] = _coefficient(event, after, ending.get(event), constants)
        note = [coefficients[k].note if k in coefficients else "" for k in range(len(table))]
    for column in ("flight_s", "impact_speed_m_s", "launch_speed_m_s", "e"):
        table[column] = [getattr(coefficients[k], column) if k in coefficients else math.nan
                         for k in range(len(table))]
    table["used"] = np.array([k in coefficients and coefficients[k].used for k in range(len(table))], dtype=bool)
    table["e_note"] = note
    rows = [coefficients[k].jacobian for k in sorted(coefficients) if coefficients[k].used]
    return table[BOUNCE_COLUMNS], _sparse_rows(rows, seq.times.size)


def _sparse_rows(rows, width: int):
    """A CSR matrix of ``len(rows)`` rows of ``width`` columns from (columns, values) per row
    (repeated columns add up)."""
    cols = np.array([c for columns, _ in rows for c in columns], dtype=np.int64)
    vals = np.array([v for _, values in rows for v in values], dtype=float)
    indptr = np.arange(len(rows) + 1, dtype=np.int64) * 3
    matrix = csr_matrix((vals, cols, indptr), shape=(len(rows), width))
    matrix.sum_duplicates()
    return matrix


#: Two drops whose event times all agree within this [s] are one drop given twice (read from two
#: files, or from two formats that round differently: phyphox's CSV keeps 10 digits, its workbook
#: 17). Triggers of two real drops differ by milliseconds; 1 us is below any trigger's timing.
SAME_DROP_TOLERANCE = 1e-6


def _check_distinct_drops(recordings: Sequence[BounceRecording]) -> None:
    """Refuse one drop given twice (the same event times, to :data:`SAME_DROP_TOLERANCE`, whatever
    the files or formats they came from): its impacts would count twice and every interval would
    narrow by about 1.4 for nothing.

    Raises
    ------
    DuplicateInputError
        naming both.
    """
    by_size: dict[int, list[BounceRecording]] = {}
    for rec in recordings:
        for earlier in by_size.get(rec.times.size, []):
            if float(np.max(np.abs(rec.times - earlier.times))) <= SAME_DROP_TOLERANCE:
                first = earlier.source or "an earlier drop given as an array"
                raise DuplicateInputError(f"{rec.source or '(array)'}: the same {rec.times.size} event times as "
                                          f"{first} (to {SAME_DROP_TOLERANCE * 1e6:g} us); each drop may be given "
                                          "once, or its impacts would count twice")
        by_size.setdefault(rec.times.size, []).append(rec)


def _as_recordings(source) -> list[BounceRecording]:
    """The drops of one source: a recording, a file (several for a table of trials:
    :func:`~impactid.rigs.ball.readers.read_drops`) or an array of event times [s]."""
    if isinstance(source, BounceRecording):
        return [source]
    if isinstance(source, (str, os.PathLike)):
        return read_drops(source)
    return [BounceRecording.from_times(source)]


def _segments(seq: CleanedSequence, name: str) -> list[dict]:
    """Accepted impacts of a drop as chained-fit segments, split at odd bounces."""
    idx = seq.accepted
    numbers = seq.impact_number[idx]
    cut = set(int(r.start_event) for r in seq.flights.itertuples(index=False) if r.anomalous)
    segments, current = [], []
    for i, n in zip(idx, numbers):
        current.append((int(i), int(n)))
        if int(i) in cut:
            segments.append(current)
            current = [(int(i), int(n))]
    segments.append(current)
    out = []
    for s, seg in enumerate(segments):
        if len(seg) >= 3:
            ev = np.array([i for i, _ in seg])
            num = np.array([n for _, n in seg])
            out.append({"name": f"{name}#{s}" if len(segments) > 1 else name, "cluster": name,
                        "times": seq.times[ev],
                        "numbers": num - num[0]})
    return out


def _drag_equivalent_terminal_speed(e_mean: float, gamma: float, v_lo: float, v_hi: float, g: float) -> float:
    """Terminal speed [m/s] at which drag alone, on a ball of constant ``e_mean``, makes a vacuum
    analysis report the slope ``gamma`` [s/m] over impact speeds ``v_lo``-``v_hi`` (NaN if none in
    1-10^4 m/s). The apparent slope of drag falls monotonically with the terminal speed."""
    if not (gamma > 0 and v_hi > v_lo > 0 and 0 < e_mean < 1):
        return math.nan
    vac = FlightConstants(g, math.inf)
    grid = np.geomspace(1.0, 1e4, 81)
    slopes = []
    for vt in grid:
        c = FlightConstants(g, float(vt))
        if vt <= 1.05 * v_hi:
            slopes.append(math.inf)
            continue
        u = e_mean * float(launch_from_landing(v_hi, c))
        Ts = []
        for _ in range(200):
            Ts.append(float(flight_time(u, c)))
            w = float(landing_speed(u, c))
            if w < v_lo or len(Ts) > 3 and Ts[-1] < 1e-4:
                break
            u = e_mean * w
        if len(Ts) < 3:
            slopes.append(math.inf)
            continue
        Ts = np.array(Ts)
        e_app, v_app = restitution_from_flights(Ts[:-1], Ts[1:], vac)
        if not (np.all(np.isfinite(e_app)) and np.all(np.isfinite(v_app))):  # LAPACK never sees NaN
            slopes.append(math.inf)
            continue
        slopes.append(-np.polyfit(v_app, e_app, 1)[0])
    slopes = np.array(slopes)
    above = np.flatnonzero(slopes >= gamma)
    if above.size == 0 or above[-1] == grid.size - 1:
        return math.nan
    i = above[-1]
    a, b = slopes[i], slopes[i + 1]
    if not math.isfinite(a):
        return float(grid[i + 1])
    x = (math.log(a) - math.log(gamma)) / (math.log(a) - math.log(b)) if a > 0 and b > 0 else 0.5
    return float(math.exp(math.log(grid[i]) + x * (math.log(grid[i + 1]) - math.log(grid[i]))))


# ---- the steps of analyse_bounces, one job each ----------------------------------------------------


@dataclass(frozen=True)
class Drop:
    """One recording cleaned into the impacts of a drop.

    Attributes
    ----------
    index : the drop's number (the cluster of its impacts in the fits).
    name : its name in the tables (the recording's, or its path when two names clash).
    recording : what was read.
    sequence : its cleaned triggers (``sequence.refused`` says why when no bouncing sequence is found).
    """

    index: int
    name: str
    recording: BounceRecording
    sequence: CleanedSequence

    @property
    def refused(self) -> str:
        return self.sequence.refused


@dataclass(frozen=True)
class Impacts:
    """The per-interval rows of every drop under one flight model, and the Jacobians ``de/dt`` [1/s]
    of their used coefficients (one sparse matrix per drop, see :func:`impacts_from_sequence`).

    Attributes
    ----------
    table : one row per interval of every drop (:data:`BOUNCE_COLUMNS`).
    jacobians : per drop, (used coefficients, events) sparse matrix.
    constants : the flight model the speeds and coefficients come from.
    """

    table: pd.DataFrame
    jacobians: tuple
    constants: FlightConstants

    @property
    def used(self) -> pd.DataFrame:
        """The rows whose coefficient enters the law fits."""
        return self.table[self.table["used"]]


@dataclass(frozen=True)
class LawFits:
    """Every law fitted to the used coefficients with one variance model.

    Attributes
    ----------
    fits : the fits by law name (the laws with more coefficients than parameters).
    tau : intrinsic scatter of the restitution [-].
    sigma_t : timing noise of one event [s].
    """

    fits: Mapping[str, LawFit]
    tau: float
    sigma_t: float


@dataclass(frozen=True)
class Selection:
    """The law reported and why.

    Attributes
    ----------
    law : its name.
    reason : the criterion's verdict, or ``"requested"``.
    criterion : ``"aic"`` or ``"bic"``.
    """

    law: str
    reason: str
    criterion: str


@dataclass(frozen=True)
class Finding:
    """What one step adds to the result: its notes, and its entries of ``details``."""

    notes: tuple[str, ...] = ()
    details: Mapping = field(default_factory=dict)


def _check_options(law: str, criterion: str) -> None:
    """Refuse an unknown law or criterion before anything is read."""
    if law != "auto":
        get_law(law)
    if criterion not in ("aic", "bic"):
        raise ValueError(f"unknown criterion {criterion!r}; valid: aic, bic")


def _read_drops(sources: Sequence) -> list[BounceRecording]:
    """Every source read (one drop each, or one per trial of a table of several drops), none given twice."""
    recordings = [r for s in sources for r in _as_recordings(s)]
    if not recordings:
        raise BounceAnalysisError("no drops given")
    _check_distinct_drops(recordings)
    return recordings


def _drop_names(recordings: Sequence[BounceRecording]) -> list[str]:
    """The recordings' names, or their sources (``drop <i>`` for arrays) when two names clash."""
    names = [r.name for r in recordings]
    if len(set(names)) < len(names):
        names = [r.source or f"drop {i}" for i, r in enumerate(recordings)]
    return names


def _clean_drops(recordings: Sequence[BounceRecording], z_reject: float) -> tuple[Drop, ...]:
    """Each recording's triggers cleaned into the impacts of its drop."""
    drops = []
    for d, (rec, name) in enumerate(zip(recordings, _drop_names(recordings))):
        try:
            seq = clean_sequence(rec.times, resolution=rec.resolution, z_reject=z_reject, name=name)
        except ValueError as exc:  # times no drop can have (the readers refuse them first, naming the row)
            raise BounceFileError(f"{rec.source or name}: {exc}") from None
        drops.append(Drop(d, name, rec, seq))
    return tuple(drops)


def _flight_provenance(constants: FlightConstants, ball: Ball | None) -> str:
    """The flight model (and the ball) as a line of provenance."""
    text = (f"flight model: {constants.label} (g_e = {constants.gravity:.5g} m/s^2, "
            f"v_t = {constants.terminal_speed:.4g} m/s)")
    if ball:
        text += f"; ball {ball.name}: m = {ball.mass:g} kg, d = {ball.diameter:g} m, Cd = {ball.drag_coefficient:g}"
    return text


def _cleaning_provenance(drop: Drop) -> str:
    """What the cleaning of one drop found, as a line of provenance."""
    seq = drop.sequence
    counts = {k: v for k, v in seq.counts().items() if v}
    return (f"{drop.name}: cleaned {drop.recording.times.size} events: {counts}, sigma {1e3 * seq.sigma:.3g} ms, "
            f"{seq.iterations} rounds" + (f"; REFUSED: {seq.refused}" if seq.refused else ""))


def _impacts(drops: Sequence[Drop], constants: FlightConstants) -> Impacts:
    """The per-interval rows and Jacobians of every drop under the flight model ``constants``."""
    parts = [impacts_from_sequence(d.sequence, constants, file=d.name, drop=d.index) for d in drops]
    return Impacts(pd.concat([p[0] for p in parts], ignore_index=True), tuple(p[1] for p in parts), constants)


def _fit_all(impacts: Impacts, confidence: float, label: str) -> LawFits:
    """Every law fitted to the used coefficients with one variance model ``tau^2 + sigma_t^2 g``
    (estimated under the linear law, three rounds)."""
    used = impacts.used
    v, e, groups = used["impact_speed_m_s"].to_numpy(float), used["e"].to_numpy(float), used["drop"].to_numpy()
    jacobians = [J for J in impacts.jacobians if J.shape[0]]
    gains = (np.concatenate([np.asarray(J.multiply(J).sum(axis=1)).ravel() for J in jacobians]) if v.size
             else np.empty(0))
    weights = None
    tau = sigma_t = math.nan
    reference = "linear" if v.size > 2 else "constant"
    for _ in range(3):
        fit = fit_law(reference, v, e, weights=weights, groups=groups, confidence=confidence)
        resid = e - fit.law.evaluate(fit.beta, v)
        tau, sigma_t = variance_model(resid, gains)
        weights = 1.0 / (tau ** 2 + sigma_t ** 2 * gains)
        weights = weights / np.mean(weights)
    # the noise covariance tau^2 I + sigma_t^2 J J^T is held as its factors, never as an n x n matrix
    noise_cov = TimingNoise(tau, sigma_t, block_diag(jacobians, format="csr")) if jacobians else None
    fits = {name: fit_law(name, v, e, weights=weights, noise_cov=noise_cov, groups=groups, confidence=confidence,
                          label=label)
            for name in LAWS if v.size > get_law(name).n_params}
    return LawFits(fits, tau, sigma_t)


def _select(fits: Mapping[str, LawFit], law: str, criterion: str) -> Selection:
    """The law to report: the one asked for, or the one ``criterion`` selects."""
    if law == "auto":
        return Selection(*select_law(fits, criterion), criterion)
    return Selection(law, "requested", criterion)


def _speed_range_note(fits: Mapping[str, LawFit], v_lo: float, v_hi: float, criterion: str) -> Finding:
    """Whether the range of impact speeds [m/s] can tell the laws apart."""
    values = {n: f.statistics[criterion] for n, f in fits.items()}
    best = min(values.values())
    if all(abs(values[n] - best) < 2.0 for n in values):
        lin = fits.get("linear")
        detect = 2.0 * lin["gamma"].stderr if lin is not None else math.nan
        return Finding((f"impact speeds {v_lo:.2f}-{v_hi:.2f} m/s: too narrow a range to tell the laws apart "
                        f"({criterion.upper()} differences < 2); the smallest slope these data could show is about "
                        f"{detect:.2g} s/m (2 standard errors of gamma)",))
    if v_hi < 1.5 * v_lo:
        return Finding((f"impact speeds span only {v_lo:.2f}-{v_hi:.2f} m/s: the laws are extrapolated outside it",))
    return Finding()


def _no_drag_comparison(drops: Sequence[Drop], vacuum: FlightConstants, fits: Mapping[str, LawFit],
                        constants: FlightConstants, confidence: float) -> Finding:
    """The laws fitted without air (``details["no_drag"]``), and how much of the slope is drag."""
    fits0 = _fit_all(_impacts(drops, vacuum), confidence, "vacuum").fits
    finding = {"no_drag": {n: f.to_dict() for n, f in fits0.items()}}
    lin, lin0 = fits.get("linear"), fits0.get("linear")
    if lin is None or lin0 is None:
        return Finding((), finding)
    g0, s0 = lin0["gamma"].value, lin0["gamma"].stderr
    g1, s1 = lin["gamma"].value, lin["gamma"].stderr
    text = (f"speed dependence: gamma = {g0:.4g} +/- {s0:.2g} s/m without drag, {g1:.4g} +/- {s1:.2g} s/m "
            f"with drag ({constants.label})")
    if abs(g0) > 2 * s0 and (abs(g1) < 2 * s1 or abs(g1) < 0.5 * abs(g0)):
        text += ": drag, not the contact, explains most of the apparent speed dependence"
    elif abs(g0) > 2 * s0:
        text += f": drag accounts for {100 * (g0 - g1) / g0:.0f} % of the apparent slope"
    return Finding((text,), finding)


def _drag_sensitivity(drops: Sequence[Drop], ball: Ball, gravity: float | None, lin: LawFit,
                      confidence: float) -> Finding:
    """The laws refitted with the drag coefficient at +/- :data:`DRAG_COEFFICIENT_UNCERTAINTY`
    (``details["drag_sensitivity"]``), and a note when ``gamma`` depends on it more than on the data."""
    sensitivity = {}
    for cd in (max(ball.drag_coefficient - DRAG_COEFFICIENT_UNCERTAINTY, 0.0),
               ball.drag_coefficient + DRAG_COEFFICIENT_UNCERTAINTY):
        other = flight_constants(ball.with_(drag_coefficient=cd), True, gravity)
        fits_cd = _fit_all(_impacts(drops, other), confidence, f"Cd = {cd:g}").fits
        g = fits_cd["linear"]["gamma"]
        sensitivity[f"{cd:g}"] = {"gamma": g.value, "gamma_stderr": g.stderr,
                                  "e0": fits_cd["linear"]["e0"].value, "e": fits_cd["constant"]["e"].value}
    (lo_cd, lo), (hi_cd, hi) = sorted(sensitivity.items(), key=lambda kv: float(kv[0]))
    g1 = lin["gamma"]
    notes = ()
    if (lo["gamma"] > 0) != (hi["gamma"] > 0) or abs(lo["gamma"] - hi["gamma"]) > 2 * g1.stderr:
        notes = (f"gamma depends on the drag coefficient more than on the data: {lo['gamma']:.3g} s/m at "
                 f"Cd = {lo_cd}, {g1.value:.3g} at Cd = {ball.drag_coefficient:g}, {hi['gamma']:.3g} at Cd = "
                 f"{hi_cd} (+/-{DRAG_COEFFICIENT_UNCERTAINTY:g}, the uncertainty of a typical Cd at bouncing "
                 "speeds): the contact's own speed dependence is not determined beyond that; measure Cd to "
                 "tell it",)
    return Finding(notes, {"drag_sensitivity": sensitivity})


def _no_air_note(ball: Ball | None, constants: FlightConstants, fits: Mapping[str, LawFit], v_lo: float,
                 v_hi: float) -> Finding:
    """The flights analysed without air: say so, and which terminal speed would explain the slope."""
    why = "no ball given" if ball is None else "air switched off"
    text = f"{why}: the flights are analysed without air (drag not corrected)"
    lin = fits.get("linear")
    if lin is not None and lin["gamma"].value > 2 * lin["gamma"].stderr:
        e_mean = fits["constant"]["e"].value
        vt = _drag_equivalent_terminal_speed(e_mean, lin["gamma"].value, v_lo, v_hi, constants.gravity)
        if math.isfinite(vt):
            text += (f"; drag alone would produce the fitted slope gamma = {lin['gamma'].value:.3g} s/m if the "
                     f"ball's terminal speed were about {vt:.3g} m/s (a table-tennis ball's is 9 m/s, a golf "
                     "ball's about 30 m/s)")
    return Finding((text,))


def _chained_fits(drops: Sequence[Drop], law_fits: LawFits, selected: str, constants: FlightConstants,
                  confidence: float) -> Finding:
    """The chained trajectory fit of every law (``details["chained"]``), checked against the timing
    noise the per-impact fits measured; notes for the selected law's lack of fit and when it
    disagrees with the per-impact fit by more than twice their joint error."""
    fits = law_fits.fits
    segments = [seg for d in drops if not d.refused for seg in _segments(d.sequence, d.name)]
    notes = []
    chain_fits = {}
    for name, fit in fits.items():
        try:
            chain_fits[name] = fit_chained(segments, name, constants, start=fit.beta, confidence=confidence,
                                           timing_noise=law_fits.sigma_t)
        except (ValueError, np.linalg.LinAlgError) as exc:
            notes.append(f"chained fit of the {name} law not possible: {exc}")
    cf, pf = chain_fits.get(selected), fits.get(selected)
    if cf is not None:
        notes += [f"chained fit of the {selected} law: {n}" for n in cf.notes if n.startswith("lack of fit")]
    if cf is not None and pf is not None:
        for pname in pf.law.names:
            a, b = pf[pname], cf[pname]
            spread = math.hypot(a.stderr, b.stderr)
            if math.isfinite(spread) and abs(a.value - b.value) > 2 * spread:
                notes.append(f"the chained fit gives {pname} = {b.value:.5g} +/- {b.stderr:.2g} against "
                             f"{a.value:.5g} +/- {a.stderr:.2g} per impact: the law does not describe whole "
                             "drops as well as single impacts")
    return Finding(tuple(notes), {"chained": {n: f.to_dict() for n, f in chain_fits.items()}})


def _parameters(fits: Mapping[str, LawFit]) -> list[Parameter]:
    """Every law's parameters, named ``<law>.<parameter>``."""
    return [replace(p, name=f"{name}.{p.name}") for name, fit in fits.items() for p in fit.params.values()]


def _statistics(drops: Sequence[Drop], impacts: Impacts, law_fits: LawFits, selection: Selection) -> dict:
    """The analysis's statistics: files, drops, intervals and their flags, impacts used, the speed
    range [m/s], the variance model and the flight model."""
    table, used = impacts.table, impacts.used
    refused = sum(1 for d in drops if d.refused)
    files = len({d.recording.source or f"(array {d.index})" for d in drops})  # a table of trials is one file
    statistics = {"files": files, "drops_analysed": len(drops) - refused, "drops_refused": refused,
                  "intervals": len(table),
                  "intervals_rejected": int((~table["flag"].isin(["ok", "first", "anomalous"])).sum()),
                  "impacts_used": len(used), "selected": selection.law, "criterion": selection.criterion,
                  "speed_min_m_s": float(used["impact_speed_m_s"].min()),
                  "speed_max_m_s": float(used["impact_speed_m_s"].max()),
                  "intrinsic_scatter": law_fits.tau, "timing_sigma_s": law_fits.sigma_t,
                  "flight_model": impacts.constants.label}
    statistics.update({f"flag_{k}": int(v) for k, v in sorted(table["flag"].value_counts().to_dict().items())})
    return statistics


def _base_details(drops: Sequence[Drop], law_fits: LawFits, selection: Selection, ball: Ball | None,
                  constants: FlightConstants) -> dict:
    """The details every analysis has: the fits, the selection, the ball, the flight, the files,
    the refusals and each drop's cleaning."""
    return {"laws": {n: f.to_dict() for n, f in law_fits.fits.items()}, "selected": selection.law,
            "selection": selection.reason, "criterion": selection.criterion,
            "ball": ball.to_dict() if ball else None, "flight": constants.to_dict(),
            "files": [d.recording.source for d in drops], "refused": [d.refused for d in drops if d.refused],
            "sequences": [{"file": d.name, "sigma_s": d.sequence.sigma, "ratio_model": list(d.sequence.ratio_model),
                           "iterations": d.sequence.iterations, "counts": d.sequence.counts()} for d in drops]}


def analyse_bounces(sources: Sequence, *, ball: Ball | None = None, drag: bool = True,
                    gravity: float | None = None, law: str = "auto",
                    criterion: str = "bic", z_reject: float = 4.0, confidence: float = 0.95, chained: bool = True,
                    compare_no_drag: bool = True) -> BounceAnalysis:
    """Restitution laws from the bounce timings of one or more drops of one ball on one surface.

    Parameters
    ----------
    sources : files (phyphox exports, CSV of times, WAV), :class:`BounceRecording` objects or arrays
        of event times [s]; one drop each.
    ball : the ball (:data:`~impactid.rigs.ball.parameters.BALL_PRESETS` or a custom one); None when
        unknown: the flights are then analysed without air.
    drag : include the air (drag, buoyancy, added mass) when the ball is known.
    gravity : [m/s^2]; default the ball's (standard gravity without a ball).
    law : ``"auto"`` (select by ``criterion``) or a law name to report.
    criterion : ``"bic"`` or ``"aic"``.
    z_reject : the cleaning's rejection level [sigma] (:func:`~impactid.rigs.ball.sequence.clean_sequence`).
    confidence : coverage of the intervals.
    chained : also run the chained trajectory fits (one per law).
    compare_no_drag : with drag, also fit without air and note how much of the speed dependence is drag.

    Returns
    -------
    BounceAnalysis

    Raises
    ------
    BounceFileError
        a file cannot be read (see :func:`~impactid.rigs.ball.readers.read_bounces`).
    BounceAnalysisError
        no file holds a usable bouncing sequence (every refusal's reason is given).
    DuplicateInputError
        one drop given twice (the same event times).
    """
    _check_options(law, criterion)
    recordings = _read_drops(sources)
    constants = flight_constants(ball, drag, gravity)
    drops = _clean_drops(recordings, z_reject)
    provenance = [line for r in recordings for line in r.provenance]
    provenance.append(_flight_provenance(constants, ball))
    provenance += [_cleaning_provenance(d) for d in drops]
    refused = [d.refused for d in drops if d.refused]
    notes = [note for r in recordings for note in r.notes] + [f"refused: {r}" for r in refused]
    impacts = _impacts(drops, constants)
    if len(impacts.used) < 3:
        reasons = "; ".join(refused) or f"only {len(impacts.used)} usable coefficient(s) of restitution"
        raise BounceAnalysisError(f"no usable bouncing sequence in {len(recordings)} file(s): {reasons}")
    law_fits = _fit_all(impacts, confidence, constants.label)
    fits = law_fits.fits
    provenance.append(f"variance of each e: intrinsic scatter tau = {law_fits.tau:.3g} plus timing noise sigma_t = "
                      f"{1e3 * law_fits.sigma_t:.3g} ms per event through the flight model (weights of the fits)")
    selection = _select(fits, law, criterion)
    v_lo, v_hi = float(impacts.used["impact_speed_m_s"].min()), float(impacts.used["impact_speed_m_s"].max())
    findings = [_speed_range_note(fits, v_lo, v_hi, criterion)]
    lin = fits.get("linear")
    if compare_no_drag and constants.drag:
        vacuum = flight_constants(None, gravity=gravity if gravity is not None else (ball.gravity if ball else None))
        findings.append(_no_drag_comparison(drops, vacuum, fits, constants, confidence))
    if compare_no_drag and constants.drag and ball is not None and lin is not None:
        findings.append(_drag_sensitivity(drops, ball, gravity, lin, confidence))
    elif not constants.drag:
        findings.append(_no_air_note(ball, constants, fits, v_lo, v_hi))
    if chained:
        findings.append(_chained_fits(drops, law_fits, selection.law, constants, confidence))
    details = _base_details(drops, law_fits, selection, ball, constants)
    for finding in findings:
        notes += finding.notes
        details.update(finding.details)
    notes += [f"{name} law: {n}" for name, fit in fits.items() for n in fit.notes]
    # the analysis states its selected law's model check and identifiability (each law's own are in details)
    chosen = fits[selection.law]
    return BounceAnalysis(params=_parameters(fits), statistics=_statistics(drops, impacts, law_fits, selection),
                          notes=tuple(dict.fromkeys(notes)),
                          tables={"bounces": impacts.table, "laws": law_table(fits)},
                          details=details, provenance=tuple(provenance),
                          model_check={**chosen.model_check, "law": selection.law},
                          identifiability={**chosen.identifiability, "law": selection.law,
                                           "parts": {name: dict(f.identifiability) for name, f in fits.items()}})

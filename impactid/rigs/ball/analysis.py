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
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from impactid.errors import ImpactidError
from impactid.results import FitResult, Parameter
from impactid.rigs.ball.flight import (
    FlightConstants,
    flight_constants,
    flight_time_derivative,
    invert_flights,
    landing_speed_derivative,
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
from impactid.rigs.ball.readers import BounceFileError, BounceRecording, read_bounces
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
    Details: ``laws``, ``chained``, ``no_drag`` (fits as dicts), ``selected``, ``selection``,
    ``ball``, ``flight``, ``files``, ``refused``, ``sequences``.
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
        from impactid.rigs.ball.figures import plot_restitution

        return plot_restitution(self, ax=ax, **kwargs)

    def plot_intervals(self, **kwargs):
        """Intervals against bounce number per drop, rejected ones marked."""
        from impactid.rigs.ball.figures import plot_intervals

        return plot_intervals(self, **kwargs)


def impacts_from_sequence(seq: CleanedSequence, constants: FlightConstants, *, file: str = "",
                          drop: int = 0) -> tuple[pd.DataFrame, np.ndarray]:
    """Per-interval rows of one cleaned drop with the speeds and coefficients of its impacts, and
    the Jacobian ``de/dt`` [1/s] of the used coefficients with respect to the event times (a sparse
    matrix, one row per used coefficient and three entries a row: its memory grows with the
    impacts, not with their square).

    The coefficient at an accepted impact needs a single flight before and a single flight after
    it: ``e = u(T_after) / w(T_before)``, the impact speed is ``w(T_before)``. It is used in the fits
    unless the flight after it is anomalous.
    """
    t = seq.times
    table = seq.intervals.copy()
    table.insert(0, "file", file)
    table.insert(1, "drop", drop)
    n = len(table)
    cols = {c: np.full(n, math.nan) for c in ("flight_s", "impact_speed_m_s", "launch_speed_m_s", "e")}
    used = np.zeros(n, dtype=bool)
    note = [""] * n
    flights = seq.flights
    if seq.refused or flights.empty:
        table["flag"] = "refused"
        if seq.refused:
            table["reason"] = f"not used: {seq.refused}"
        for c, values in cols.items():
            table[c] = values
        table["used"] = used
        table["e_note"] = "drop refused"
        return table[BOUNCE_COLUMNS], _sparse_rows([], t.size)
    starting = {int(r.start_event): r for r in flights.itertuples(index=False)}
    ending = {int(r.end_event): r for r in flights.itertuples(index=False)}
    jac_rows: list[tuple[tuple[int, int, int], tuple[float, float, float]]] = []
    row_of_event = {int(i): k for k, i in enumerate(table["index"])}
    for event, after in starting.items():
        k = row_of_event.get(event)
        if k is None:
            continue
        if int(after.flights) != 1:
            note[k] = "no e: the flight after this impact is not measured alone (missed bounce)"
            continue
        T_after = float(after.duration_s)
        u_after = float(invert_flights(T_after, constants)[0])
        cols["flight_s"][k], cols["launch_speed_m_s"][k] = T_after, u_after
        before = ending.get(event)
        if before is None:
            note[k] = "no e: first impact of the sequence (no measured flight before it)"
            continue
        if int(before.flights) != 1:
            note[k] = "no e: the flight before this impact spans a missed bounce"
            continue
        u_b, w_b = (float(x) for x in invert_flights(float(before.duration_s), constants))
        e = u_after / w_b
        cols["impact_speed_m_s"][k], cols["e"][k] = w_b, e
        if bool(after.anomalous):
            note[k] = "odd bounce (the flight after it is anomalous): not used in the law fits"
            continue
        if not (math.isfinite(e) and e > 0):
            note[k] = "no e: flight inversion failed"
            continue
        used[k] = True
        # de/dt: e = u(T_a) / w(T_b), T_a = t_m - t_j, T_b = t_j - t_i
        i, j, m = int(before.start_event), event, int(after.end_event)
        du_dT = 1.0 / float(flight_time_derivative(u_after, constants))
        dw_dT = float(landing_speed_derivative(u_b, constants)) / float(flight_time_derivative(u_b, constants))
        A = du_dT / w_b
        B = e * dw_dT / w_b
        jac_rows.append(((m, j, i), (A, -A - B, B)))
    for c, values in cols.items():
        table[c] = values
    table["used"] = used
    table["e_note"] = note
    return table[BOUNCE_COLUMNS], _sparse_rows(jac_rows, t.size)


def _sparse_rows(rows, width: int):
    """A CSR matrix of ``len(rows)`` rows of ``width`` columns from (columns, values) per row
    (repeated columns add up)."""
    from scipy.sparse import csr_matrix

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
    from impactid._files import DuplicateInputError

    by_size: dict[int, list[BounceRecording]] = {}
    for rec in recordings:
        for earlier in by_size.get(rec.times.size, []):
            if float(np.max(np.abs(rec.times - earlier.times))) <= SAME_DROP_TOLERANCE:
                first = earlier.source or "an earlier drop given as an array"
                raise DuplicateInputError(f"{rec.source or '(array)'}: the same {rec.times.size} event times as "
                                          f"{first} (to {SAME_DROP_TOLERANCE * 1e6:g} us); each drop may be given "
                                          "once, or its impacts would count twice")
        by_size.setdefault(rec.times.size, []).append(rec)


def _as_recording(source) -> BounceRecording:
    if isinstance(source, BounceRecording):
        return source
    if isinstance(source, (str, os.PathLike)):
        return read_bounces(source)
    return BounceRecording.from_times(source)


def _fit_all(rows: pd.DataFrame, jacobians: list[np.ndarray], confidence: float, label: str
             ) -> tuple[dict[str, LawFit], float, float]:
    """Every law fitted to the used coefficients with one variance model ``tau^2 + sigma_t^2 g``
    (estimated under the linear law, two rounds); returns the fits, ``tau`` and ``sigma_t``."""
    from scipy.sparse import block_diag

    used = rows[rows["used"]]
    v, e, groups = used["impact_speed_m_s"].to_numpy(float), used["e"].to_numpy(float), used["drop"].to_numpy()
    jacobians = [J for J in jacobians if J.shape[0]]
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
    fits = {}
    for name in LAWS:
        if v.size > get_law(name).n_params:
            fits[name] = fit_law(name, v, e, weights=weights, noise_cov=noise_cov, groups=groups,
                                 confidence=confidence, label=label)
    return fits, tau, sigma_t


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
    from impactid.rigs.ball.flight import flight_time, landing_speed, launch_from_landing, restitution_from_flights

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
    if law != "auto":
        get_law(law)
    if criterion not in ("aic", "bic"):
        raise ValueError(f"unknown criterion {criterion!r}; valid: aic, bic")
    recordings = [_as_recording(s) for s in sources]
    if not recordings:
        raise BounceAnalysisError("no drops given")
    _check_distinct_drops(recordings)
    constants = flight_constants(ball, drag, gravity)
    provenance: list[str] = []
    notes: list[str] = []
    for r in recordings:
        provenance += list(r.provenance)
        notes += list(r.notes)
    provenance.append(f"flight model: {constants.label} (g_e = {constants.gravity:.5g} m/s^2, "
                      f"v_t = {constants.terminal_speed:.4g} m/s)" + (f"; ball {ball.name}: m = {ball.mass:g} kg, "
                                                                       f"d = {ball.diameter:g} m, Cd = "
                                                                       f"{ball.drag_coefficient:g}" if ball else ""))
    names = [r.name for r in recordings]
    if len(set(names)) < len(names):
        names = [r.source or f"drop {i}" for i, r in enumerate(recordings)]
    sequences, refused = [], []
    frames, jacobians, vacuum_frames, vacuum_jacobians = [], [], [], []
    vacuum = flight_constants(None, gravity=gravity if gravity is not None else (ball.gravity if ball else None))
    for d, (rec, name) in enumerate(zip(recordings, names)):
        try:
            seq = clean_sequence(rec.times, resolution=rec.resolution, z_reject=z_reject, name=name)
        except ValueError as exc:  # times no drop can have (the readers refuse them first, naming the row)
            raise BounceFileError(f"{rec.source or name}: {exc}") from None
        sequences.append(seq)
        counts = {k: v for k, v in seq.counts().items() if v}
        provenance.append(f"{name}: cleaned {rec.times.size} events: {counts}, sigma {1e3 * seq.sigma:.3g} ms, "
                          f"{seq.iterations} rounds" + (f"; REFUSED: {seq.refused}" if seq.refused else ""))
        if seq.refused:
            refused.append(seq.refused)
        rows, J = impacts_from_sequence(seq, constants, file=name, drop=d)
        frames.append(rows)
        jacobians.append(J)
        if compare_no_drag and constants.drag:
            rows0, J0 = impacts_from_sequence(seq, vacuum, file=name, drop=d)
            vacuum_frames.append(rows0)
            vacuum_jacobians.append(J0)
    table = pd.concat(frames, ignore_index=True)
    if refused:
        notes += [f"refused: {r}" for r in refused]
    n_used = int(table["used"].sum())
    if n_used < 3:
        reasons = "; ".join(refused) or f"only {n_used} usable coefficient(s) of restitution"
        raise BounceAnalysisError(f"no usable bouncing sequence in {len(recordings)} file(s): {reasons}")
    fits, tau, sigma_t = _fit_all(table, jacobians, confidence, constants.label)
    provenance.append(f"variance of each e: intrinsic scatter tau = {tau:.3g} plus timing noise sigma_t = "
                      f"{1e3 * sigma_t:.3g} ms per event through the flight model (weights of the fits)")
    if law == "auto":
        selected, selection = select_law(fits, criterion)
    else:
        selected, selection = law, "requested"
    # ---- notes -------------------------------------------------------------------------------
    used = table[table["used"]]
    v_lo, v_hi = float(used["impact_speed_m_s"].min()), float(used["impact_speed_m_s"].max())
    values = {n: f.statistics[criterion] for n, f in fits.items()}
    best = min(values.values())
    if all(abs(values[n] - best) < 2.0 for n in values):
        lin = fits.get("linear")
        detect = 2.0 * lin["gamma"].stderr if lin is not None else math.nan
        notes.append(f"impact speeds {v_lo:.2f}-{v_hi:.2f} m/s: too narrow a range to tell the laws apart "
                     f"({criterion.upper()} differences < 2); the smallest slope these data could show is about "
                     f"{detect:.2g} s/m (2 standard errors of gamma)")
    elif v_hi < 1.5 * v_lo:
        notes.append(f"impact speeds span only {v_lo:.2f}-{v_hi:.2f} m/s: the laws are extrapolated outside it")
    details: dict = {"laws": {n: f.to_dict() for n, f in fits.items()}, "selected": selected,
                     "selection": selection, "criterion": criterion, "ball": ball.to_dict() if ball else None,
                     "flight": constants.to_dict(), "files": [r.source for r in recordings], "refused": refused,
                     "sequences": [{"file": n, "sigma_s": s.sigma, "ratio_model": list(s.ratio_model),
                                    "iterations": s.iterations, "counts": s.counts()}
                                   for n, s in zip(names, sequences)]}
    lin = fits.get("linear")
    if compare_no_drag and constants.drag:
        table0 = pd.concat(vacuum_frames, ignore_index=True)
        fits0, _, _ = _fit_all(table0, vacuum_jacobians, confidence, "vacuum")
        details["no_drag"] = {n: f.to_dict() for n, f in fits0.items()}
        lin0 = fits0.get("linear")
        if lin is not None and lin0 is not None:
            g0, s0 = lin0["gamma"].value, lin0["gamma"].stderr
            g1, s1 = lin["gamma"].value, lin["gamma"].stderr
            text = (f"speed dependence: gamma = {g0:.4g} +/- {s0:.2g} s/m without drag, {g1:.4g} +/- {s1:.2g} s/m "
                    f"with drag ({constants.label})")
            if abs(g0) > 2 * s0 and (abs(g1) < 2 * s1 or abs(g1) < 0.5 * abs(g0)):
                text += ": drag, not the contact, explains most of the apparent speed dependence"
            elif abs(g0) > 2 * s0:
                text += f": drag accounts for {100 * (g0 - g1) / g0:.0f} % of the apparent slope"
            notes.append(text)
    if compare_no_drag and constants.drag and ball is not None and lin is not None:
        sensitivity = {}
        for cd in (max(ball.drag_coefficient - DRAG_COEFFICIENT_UNCERTAINTY, 0.0),
                   ball.drag_coefficient + DRAG_COEFFICIENT_UNCERTAINTY):
            other = flight_constants(ball.with_(drag_coefficient=cd), True, gravity)
            parts = [impacts_from_sequence(sq, other, file=n, drop=d)
                     for d, (sq, n) in enumerate(zip(sequences, names))]
            rows_cd = pd.concat([p[0] for p in parts], ignore_index=True)
            fits_cd, _, _ = _fit_all(rows_cd, [p[1] for p in parts], confidence, f"Cd = {cd:g}")
            g = fits_cd["linear"]["gamma"]
            sensitivity[f"{cd:g}"] = {"gamma": g.value, "gamma_stderr": g.stderr,
                                      "e0": fits_cd["linear"]["e0"].value, "e": fits_cd["constant"]["e"].value}
        details["drag_sensitivity"] = sensitivity
        (lo_cd, lo), (hi_cd, hi) = sorted(sensitivity.items(), key=lambda kv: float(kv[0]))
        g1 = lin["gamma"]
        if (lo["gamma"] > 0) != (hi["gamma"] > 0) or abs(lo["gamma"] - hi["gamma"]) > 2 * g1.stderr:
            notes.append(f"gamma depends on the drag coefficient more than on the data: {lo['gamma']:.3g} s/m at "
                         f"Cd = {lo_cd}, {g1.value:.3g} at Cd = {ball.drag_coefficient:g}, {hi['gamma']:.3g} at Cd = "
                         f"{hi_cd} (+/-{DRAG_COEFFICIENT_UNCERTAINTY:g}, the uncertainty of a typical Cd at bouncing "
                         "speeds): the contact's own speed dependence is not determined beyond that; measure Cd to "
                         "tell it")
    elif not constants.drag:
        why = "no ball given" if ball is None else "air switched off"
        text = f"{why}: the flights are analysed without air (drag not corrected)"
        if lin is not None and lin["gamma"].value > 2 * lin["gamma"].stderr:
            e_mean = fits["constant"]["e"].value
            vt = _drag_equivalent_terminal_speed(e_mean, lin["gamma"].value, v_lo, v_hi, constants.gravity)
            if math.isfinite(vt):
                text += (f"; drag alone would produce the fitted slope gamma = {lin['gamma'].value:.3g} s/m if the "
                         f"ball's terminal speed were about {vt:.3g} m/s (a table-tennis ball's is 9 m/s, a golf "
                         "ball's about 30 m/s)")
        notes.append(text)
    # ---- chained fits ------------------------------------------------------------------------
    if chained:
        drops = [seg for s, n in zip(sequences, names) if not s.refused for seg in _segments(s, n)]
        chain_fits = {}
        for name, fit in fits.items():
            try:
                chain_fits[name] = fit_chained(drops, name, constants, start=fit.beta, confidence=confidence)
            except (ValueError, np.linalg.LinAlgError) as exc:
                notes.append(f"chained fit of the {name} law not possible: {exc}")
        details["chained"] = {n: f.to_dict() for n, f in chain_fits.items()}
        cf, pf = chain_fits.get(selected), fits.get(selected)
        if cf is not None and pf is not None:
            for pname in pf.law.names:
                a, b = pf[pname], cf[pname]
                spread = math.hypot(a.stderr, b.stderr)
                if math.isfinite(spread) and abs(a.value - b.value) > 2 * spread:
                    notes.append(f"the chained fit gives {pname} = {b.value:.5g} +/- {b.stderr:.2g} against "
                                 f"{a.value:.5g} +/- {a.stderr:.2g} per impact: the law does not describe whole "
                                 "drops as well as single impacts")
    # ---- result ------------------------------------------------------------------------------
    params = []
    for name, fit in fits.items():
        for p in fit.params.values():
            params.append(Parameter(f"{name}.{p.name}", p.value, p.stderr, p.interval, p.confidence, unit=p.unit,
                                    note=p.note))
    flags = table["flag"].value_counts().to_dict()
    statistics = {"files": len(recordings), "drops_analysed": len(recordings) - len(refused),
                  "drops_refused": len(refused), "intervals": len(table),
                  "intervals_rejected": int((~table["flag"].isin(["ok", "first", "anomalous"])).sum()),
                  "impacts_used": n_used, "selected": selected, "criterion": criterion,
                  "speed_min_m_s": v_lo, "speed_max_m_s": v_hi,
                  "intrinsic_scatter": tau, "timing_sigma_s": sigma_t,
                  "flight_model": constants.label}
    statistics.update({f"flag_{k}": int(v) for k, v in sorted(flags.items())})
    for name, fit in fits.items():
        notes += [f"{name} law: {n}" for n in fit.notes]
    tables = {"bounces": table, "laws": law_table(fits)}
    return BounceAnalysis(params=params, statistics=statistics, notes=tuple(dict.fromkeys(notes)), tables=tables,
                          details=details, provenance=tuple(provenance))

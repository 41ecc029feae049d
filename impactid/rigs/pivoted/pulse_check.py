"""Rig P's contact-pulse check: do the replayed contacts have the measured pulse?

The contact-damping fit matches each impact's maximum follower angle ``alpha_m`` (the restitution).
A wrong rig constant is then absorbed by ``beta``: with the contact stiffness ``k_H`` (the Young's
moduli) 20 % too high, the fit's ``beta`` is 26 % off and its residuals look like those of the
right rig. What the recording measures beyond ``alpha_m`` tells them apart: the contact pulse. At
a given approach speed and effective mass a Hertz contact's peak force scales as ``k_H^(2/5)``
and its duration as ``k_H^(-2/5)`` (7.6 % for a 20 % error of ``k_H``), its impulse as the effective
mass (the inertia ``I_b``; the spring ``k_s`` moves the onset state and the pivot force's offset).

:func:`pulse_check` replays every event once at the fitted law, with the contact force on the
measured samples, and compares per event (log ratios ``ln(replayed / measured)``):

* the **peak force**: the largest sample of the pivot-force channels' contact force against the
  replay's largest on the same samples (both sampled alike: no sampling bias);
* the **impulse**: the trapezoid integral of the contact force over the contact samples;
* the **width**: impulse over peak force [s], the pulse's length without its ends (the measured
  contact duration is cut by the noise at the contact's ends and stretched by an anti-alias filter:
  on recordings of the right rig the replay's is 0.5-27 % shorter at 102.4 kHz noise-free and 2-42 %
  longer with 0.2-0.9 % noise; it is reported, not tested).

Each quantity's median log ratio ``m`` over the events is tested against

    threshold = floor + Z * 1.2533 * 1.4826 * MAD / sqrt(N)

the standard error of the median (normal approximation, ``MAD`` the median absolute deviation of
the per-event log ratios, ``N`` events) times :data:`PULSE_Z` (3 sigma, as the engine's structure
tests), plus the floor :data:`PULSE_FLOOR` the replay misses by on recordings of the right rig
(bias of the pipeline, generator differences, a noisy ``beta``). A quantity beyond its threshold
is a systematic misfit: the rig's contact stiffness, effective inertia or spring may be off. Where a
threshold of the peak force and that of the width both exceed :data:`K_H_RESOLUTION` (their change
for a 20 % ``k_H`` error) the pulse cannot resolve such an error: the check then says the rig
constants are untested at that precision (``not checked``). Without force channels the check is not
made (the accelerometer's force would itself be scaled by ``I_b``). With ``n`` fitted the pulse is
compared and reported but not tested (``not checked``): the pulse depends on ``n`` too, and a point
of the valley of equal ``alpha_m`` fits (``beta`` and ``n`` not separable) misses it by as much as a
wrong rig constant (peak force +3.8 %, width -3.7 % at ``n`` 1.72 for a true 1.5, noise-free).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from impactid.engine import ModelCheck
from impactid.rigs.pivoted.damping_objective import DampingProblem

__all__ = ["K_H_RESOLUTION", "MIN_EVENTS", "PULSE_FLOOR", "PULSE_QUANTITIES", "PULSE_Z", "PulseQuantity",
           "pulse_check", "pulse_quantities", "quantity_test", "withhold_for_rig"]

#: The quantities tested (the measured contact duration is reported only: module doc).
PULSE_QUANTITIES = ("peak_force", "impulse", "width")
#: Floor of each quantity's threshold [log ratio]: above the largest miss beyond three standard errors
#: (``|median| - 3 SE``) on recordings of the right rig whose fitted beta is within 5 % of the truth
#: (peak force 1.5 %, impulse 0.6 %, width 1.15 %; 59 recordings, noise-free to 0.9 % noise, 204.8 to
#: 51.2 kHz). Noise-free period-1 recordings repeat one impact (no scatter): there the floor is the
#: whole threshold, and what it covers is the sampling (the anti-alias filter widens a measured pulse
#: of few samples; the replay is not filtered).
PULSE_FLOOR = {"peak_force": 0.025, "impulse": 0.02, "width": 0.015}
#: Standard errors of the median beyond the floor at which a quantity counts as off (3 sigma).
PULSE_Z = 3.0
#: ``ln(1.2^(2/5))``: the peak force's change for a 20 % error of the Hertz stiffness ``k_H`` at a
#: given approach speed and effective mass; a threshold above it cannot resolve such an error.
K_H_RESOLUTION = 0.4 * math.log(1.2)
#: Fewest events with a measured and a replayed pulse for the check (the MAD needs a few).
MIN_EVENTS = 5
#: Normal-approximation factors: standard deviation per MAD, and the median's standard error per
#: the mean's (``sqrt(pi / 2)``).
_SD_PER_MAD = 1.4826
_MEDIAN_SE = math.sqrt(math.pi / 2.0)


@dataclass(frozen=True)
class PulseQuantity:
    """One pulse quantity compared over the events.

    Attributes
    ----------
    name : ``peak_force`` [N], ``impulse`` [N s], ``width`` [s] or ``contact_duration`` [s].
    events : events compared.
    measured_median, replayed_median : medians over the events [unit of the quantity].
    median_log_ratio : median of ``ln(replayed / measured)`` over the events.
    scatter : robust standard deviation of the per-event log ratios (1.4826 MAD).
    standard_error : of the median (``1.2533 scatter / sqrt(events)``).
    floor : the threshold's floor (:data:`PULSE_FLOOR`; NaN for a quantity reported only).
    threshold : ``floor + PULSE_Z standard_error`` (NaN for a quantity reported only).
    off : the median log ratio beyond the threshold.
    """

    name: str
    events: int
    measured_median: float
    replayed_median: float
    median_log_ratio: float
    scatter: float
    standard_error: float
    floor: float
    threshold: float
    off: bool

    @property
    def relative_difference(self) -> float:
        """``exp(median_log_ratio) - 1``: how much the replay's quantity differs (median) [-]."""
        return math.expm1(self.median_log_ratio)

    def to_dict(self) -> dict[str, Any]:
        return {"events": self.events, "measured_median": self.measured_median,
                "replayed_median": self.replayed_median, "median_log_ratio": self.median_log_ratio,
                "relative_difference": self.relative_difference, "scatter": self.scatter,
                "standard_error": self.standard_error, "floor": self.floor, "threshold": self.threshold,
                "off": self.off}


def pulse_quantities(t: np.ndarray, force: np.ndarray, offsets: np.ndarray) -> dict[str, np.ndarray]:
    """Per-event peak force [N], impulse [N s] and width [s] of contact-force histories stored end to end.

    Parameters
    ----------
    t : (samples,) sample instants of every event, event after event [s].
    force : (samples,) contact force on them [N].
    offsets : (events + 1,) start of each event in ``t`` (the last: ``t.size``); every event has at
        least two samples.
    """
    starts = offsets[:-1]
    peak = np.maximum.reduceat(force, starts)
    segment = 0.5 * (force[1:] + force[:-1]) * np.diff(t)  # trapezoids, across events too
    segment = np.append(segment, 0.0)
    segment[offsets[1:-1] - 1] = 0.0  # the trapezoid joining one event to the next
    impulse = np.add.reduceat(segment, starts)
    with np.errstate(divide="ignore", invalid="ignore"):
        width = np.where(peak > 0.0, impulse / peak, np.nan)
    return {"peak_force": peak, "impulse": impulse, "width": width}


def quantity_test(name: str, measured: np.ndarray, replayed: np.ndarray, floor: float) -> PulseQuantity:
    """The median log ratio of ``replayed`` over ``measured`` and its test (module doc); events where
    either is not positive and finite are left out; ``floor`` NaN: reported, not tested."""
    ok = np.isfinite(measured) & np.isfinite(replayed) & (measured > 0.0) & (replayed > 0.0)
    m, r = measured[ok], replayed[ok]
    if m.size == 0:
        return PulseQuantity(name, 0, math.nan, math.nan, math.nan, math.nan, math.nan, floor, math.nan, False)
    d = np.log(r / m)
    median = float(np.median(d))
    scatter = _SD_PER_MAD * float(np.median(np.abs(d - median)))
    se = _MEDIAN_SE * scatter / math.sqrt(d.size)
    threshold = floor + PULSE_Z * se
    return PulseQuantity(name, int(d.size), float(np.median(m)), float(np.median(r)), median, scatter, se, floor,
                         threshold, bool(abs(median) > threshold))


def _not_checked(block: dict[str, Any], reason: str) -> dict[str, Any]:
    block.update(verdict="not checked", reason=reason)
    return block


def pulse_check(problem: DampingProblem, beta: float, n: float) -> dict[str, Any]:
    """Rig P's contact-pulse check of a fitted law: the replayed contacts' peak force, impulse and width
    against the measured ones (module doc).

    Parameters
    ----------
    problem : the fit (its event sets hold the measured contact force histories [N] on their samples [s]).
    beta : [N s m^-(n+1)]; n : the fitted law.

    Returns
    -------
    dict
        ``verdict`` (``consistent``, ``systematic misfit``, or ``not checked``: no force channels, ``n``
        fitted, too few events, or a precision that cannot resolve a 20 % error of ``k_H``), ``events``,
        ``quantities`` (per quantity :meth:`PulseQuantity.to_dict`, and ``contact_duration`` reported
        only), ``off`` (the quantities beyond their thresholds), ``resolution`` (:data:`K_H_RESOLUTION`),
        ``threshold_rule`` (the derivation, in words), ``simulations`` (one S1 run per event at the
        estimate) and ``reason`` (in words).
    """
    block: dict[str, Any] = {
        "verdict": "not checked", "events": 0, "quantities": {}, "off": [], "resolution": K_H_RESOLUTION,
        "threshold_rule": (f"|median ln(replayed / measured)| > floor + {PULSE_Z:g} x 1.2533 x 1.4826 MAD / sqrt(N) "
                           "(the standard error of the median over the N events, and the floor the replay misses "
                           f"by on recordings of the right rig: {PULSE_FLOOR})"),
        "simulations": 0, "reason": ""}
    sets = [s for s in problem.sets if len(s) > 0]
    if not sets or any(s.force is None for s in sets):
        return _not_checked(block, "the contact force is not recorded (no pivot force channels): the rig's contact "
                                   "stiffness, effective inertia and spring are untested")
    measured: dict[str, list[np.ndarray]] = {q: [] for q in PULSE_QUANTITIES + ("contact_duration",)}
    replayed: dict[str, list[np.ndarray]] = {q: [] for q in measured}
    for s in sets:
        # events with a resolved pulse: at least two contact samples, all within the replay's span (an
        # impulse's samples may start before its onset)
        first = np.array([ti[0] if ti.size else -1.0 for ti in s.t])
        last = np.array([ti[-1] if ti.size else np.inf for ti in s.t])
        keep = np.flatnonzero((np.array([ti.size for ti in s.t]) >= 2) & (first >= 0.0) & (last <= s.t_end))
        if keep.size == 0:
            continue
        kept = s.subset(keep)
        batch = kept.simulate(np.array([[beta, n]]), histories=True)
        block["simulations"] += len(kept)
        lengths = np.diff(batch.grid_offsets)
        t, failed = np.concatenate(kept.t), batch.failed[0]
        got_m = pulse_quantities(t, np.concatenate(kept.force), batch.grid_offsets)
        got_r = pulse_quantities(t, np.where(np.repeat(failed, lengths), np.nan, batch.contact_force[0]),
                                 batch.grid_offsets)
        for q in PULSE_QUANTITIES:
            measured[q].append(got_m[q])
            replayed[q].append(got_r[q])
        if kept.contact_duration is not None:
            measured["contact_duration"].append(np.asarray(kept.contact_duration, dtype=float))
            replayed["contact_duration"].append(np.where(failed, np.nan, batch.contact_duration[0]))
    tests = {q: quantity_test(q, np.concatenate(measured[q]) if measured[q] else np.empty(0),
                              np.concatenate(replayed[q]) if replayed[q] else np.empty(0),
                              PULSE_FLOOR.get(q, math.nan)) for q in measured}
    block["quantities"] = {q: v.to_dict() for q, v in tests.items()}
    block["events"] = events = min(tests[q].events for q in PULSE_QUANTITIES)
    if problem.fix_n is None:
        return _not_checked(block, "n is fitted: the contact pulse depends on n as well, and a point along the "
                                   "valley of equal alpha_m fits misses it as a wrong rig constant does (compared, "
                                   "not tested): the rig's contact stiffness, effective inertia and spring are "
                                   "untested; fix n to test them")
    if events < MIN_EVENTS:
        return _not_checked(block, f"{events} events with a measured and a replayed contact pulse (fewer than "
                                   f"{MIN_EVENTS}): the rig's contact stiffness, effective inertia and spring are "
                                   "untested")
    off = [q for q in PULSE_QUANTITIES if tests[q].off]
    block["off"] = off
    described = "; ".join(f"{q.replace('_', ' ')} {100 * tests[q].relative_difference:+.3g} % (threshold "
                          f"{100 * math.expm1(tests[q].threshold):.2g} %)" for q in PULSE_QUANTITIES)
    if off:
        block["verdict"] = "systematic misfit"
        block["reason"] = (f"the replayed contact pulses differ from the measured ones beyond their precision over "
                           f"{events} events (median replayed/measured: {described}): the fitted law reproduces "
                           "alpha_m but not the contact pulse: the rig's contact stiffness (Young's moduli), "
                           "effective inertia or spring may be off, and beta absorbs the error (or the fitted law "
                           "does not describe the contacts)")
        return block
    if all(tests[q].threshold > K_H_RESOLUTION for q in ("peak_force", "width")):
        change = 100 * math.expm1(K_H_RESOLUTION)
        return _not_checked(block, f"the contact pulse's precision over {events} events ({described}) does not "
                                   f"resolve a 20 % error of the contact stiffness (a {change:.2g} % change of the "
                                   "peak force and width): the rig's constants are untested at this precision")
    block["verdict"] = "consistent"
    block["reason"] = f"the replayed contact pulses agree with the measured ones over {events} events ({described})"
    return block


def withhold_for_rig(check: ModelCheck, pulse: dict[str, Any]) -> ModelCheck:
    """``check`` after a pulse check that finds a systematic misfit: the verdict at least ``systematic
    misfit`` and the intervals withheld (a wrong rig constant biases ``beta``; widening by the residual
    scatter cannot cover that bias), the reason among the findings and notes; else ``check`` as it was."""
    if pulse.get("verdict") != "systematic misfit":
        return check
    reason = pulse["reason"]
    verdict = check.verdict if check.verdict in ("structured", "lack of fit", "rejected") else "systematic misfit"
    return replace(check, verdict=verdict, action="withheld", inflation=math.inf, findings=check.findings + (reason,),
                   notes=check.notes + (f"contact-pulse check: {reason}; the standard errors and intervals are "
                                        "withheld",))

"""Re-run one case of the envelope validation by id, with diagnostics of its errors.

The case is read from ``docs/validation_envelope_cases.json`` (the cases of
``benchmarks/validate_envelope.py``), and its recording is regenerated exactly as the validation
made it (:func:`tests.envelope.make_recording`). The clean channels (with the anti-alias
decimation) are generated once, and the sensor chain (:func:`impactid.synth.sensors.apply_sensors`,
which both generators share) is applied to them. Other noise seeds and single sensor imperfections
therefore cost no new simulation; ``--check`` verifies that the regenerated recording equals the
validation's bit for bit. The truth is read only to score. The analysis written with this script is
``benchmarks/envelope_notes.md``.

Usage::

    NUMBA_NUM_THREADS=1 python benchmarks/envelope_case.py CASE [options]

Run it single-threaded; one case takes seconds to minutes per option (a joint fit several minutes).

Notes
-----
The command-line options, each a diagnostic or an experiment:

--check
    Compare the regenerated recording with the validation's.
--motion
    The true motion: contacts per revolution, contact duration, share of the time in contact,
    the contact runs and the force 1 ms after their peak (a follower riding the cam), the tensile
    share of the contact impulse, the gaps, and the reconstruction's Hertz ratios.
--events
    Per event: ``alpha_m`` against the true apex, split into the anchor error (onset angle) and
    the excursion error (``alpha_m - alpha(0)``), the onset rate, time and cam-phase errors, the
    approach speed, the detected contact duration and the Hertz ratio; plus the return-time
    anchor's error.
--decompose
    lambda1 at the true law per event, split into the part from the measured ``alpha_m`` and the
    part from the measured onset state. Also the sensitivities ``d lambda1 / d ln beta`` and
    ``d lambda1 / d n``, the implied shift of ``beta`` and, for two recordings, the linearised
    joint shift of ``(ln beta, n)`` with the condition number of the pair. Then n-fixed fits
    (uncalibrated) on oracle event sets: true cam phase, true ``alpha_m``, true onset state, both.
--fit, --joint
    The n-fixed (joint) fit through :func:`impactid.pipeline.estimate` as the validation ran it,
    with its calibration record, and again without calibration.
--joint-oracle SET [SET ...]
    Joint fits (uncalibrated) on oracle event sets of both recordings.
--calibration
    The ``alpha_m`` bias :func:`impactid.rigs.pivoted.calibration.pipeline_bias` measures at the true law,
    against the actual mean ``alpha_m`` error, per recording.
--seeds K
    The n-fixed fit on K further noise realisations (seeds ``case.seed + 7919 k``): error,
    interval, coverage, the truth's distance in half-widths, and the anchor and excursion errors.
--anchor-study K, --scales S [S ...]
    Anchor and excursion errors over K noise seeds at the given multiples of the case's noise,
    with the detected contact duration.
--other-filter CUTOFF [CUTOFF ...]
    Decimated cases: the n-fixed fit on the case's motion through another anti-alias filter than the
    envelope's (:func:`other_filter_recording`), cut off at these fractions of the Nyquist frequency.
--variants
    The n-fixed fit with one sensor imperfection at a time (noise, ADC, offset and drift, none);
    for decimated cases also the same rate without the anti-alias filter, and 204.8 kHz.
--phase-scan
    n-fixed refits with the cam phase moved by -2 to +2 of its standard errors.
--profile, --factors F [F ...]
    Mean ``|lambda1|``, the S1 contact count and apex time along ``beta`` (n fixed) for the
    oracle event sets, and where the estimator's 41-point scan puts its best point.
--keep-all
    n-fixed fits with lambda1, lambda2 and lambda3 with the events the Hertz check drops kept.
--anchor-margin N, --anchor NAME, --residual NAME
    Experiments: start the return-time anchor's free flight N samples after the detected
    separation (8 in impactid); use another anchor or residual in the reconstructions and fits.
--json PATH
    Also write the results as JSON.
--class CLASS
    Run the n-fixed fit of every general-motion case of a class (:data:`GENERAL_CLASSES`: near-plastic,
    period-k, slow, slow-noise-free, riding, irregular) and summarise it: per case the motion, the estimate
    with its interval or the refusal with its reason, and the count of confident wrong answers (beta more
    than 5 % off with an interval that excludes the truth).

The general-motion cases (:data:`GENERAL_CASES`: ``np..``, ``pk..``, ``sl..``, ``sc..``, ``rd..``,
``ir..``) are the issue "No confident wrong answers": nearly plastic contacts, period-k and multi-impact
motion, slow noisy impacts, a follower riding the cam and irregular motion. They are recorded after
:data:`SETTLE_GENERAL_S` of settling, by impactid's generator or by the independent reference model started
on the motion impactid's simulator settles to (:func:`general_recording`); every option above works on them.

``benchmarks/validate_envelope.py`` runs these cases too (its part ``general``, :func:`run_general_case`), and the
misspecified cases (:data:`MISSPECIFIED_CASES`, part ``misspecified``, :func:`run_misspecified_case`):
restitution-law recordings fitted with Hunt–Crossley, and recordings estimated with a rig whose one constant is
off by 20-50 %. Its dask workers run :func:`run_task` (pickled by reference: they import this module as
``benchmarks.envelope_case``).

Examples
--------
``python benchmarks/envelope_case.py hc21 --events --decompose --seeds 5`` shows a noisy case's
errors against the truth; ``python benchmarks/envelope_case.py hc56 --decompose`` gives a pair's
linearised joint bias; ``python benchmarks/envelope_case.py --class period-k`` measures a class of the
general-motion cases, ``python benchmarks/envelope_case.py pk14 --events`` one of them.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
import warnings
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import signal

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from impactid import SUNDAR2016, HuntCrossley  # noqa: E402
from impactid.io import Recording  # noqa: E402
from impactid.pipeline import estimate  # noqa: E402
from impactid.rigs.pivoted.estimates import C_BOUNDS, _Objective, fit_contact_damping, reference_indentation  # noqa: E402
from impactid.rigs.pivoted.reconstruct import reconstruct  # noqa: E402
from impactid.rigs.pivoted.residuals import EventSet  # noqa: E402
from impactid.rigs.pivoted.runs import simulate  # noqa: E402
from impactid.synth.sensors import SensorModel, apply_sensors  # noqa: E402
from tests import envelope as E  # noqa: E402

CASES = ROOT / "docs" / "validation_envelope_cases.json"
SEED_STEP = 7919
#: Pipeline options of the reconstructions and fits here (``--anchor``, ``--residual``; default: the validation's).
OPTIONS = {"anchor": "cam-phase", "residual": "lambda1"}


def load_case(case_id: str, path: Path = CASES) -> E.Case:
    """The case ``case_id`` of the cached envelope cases, or of :data:`GENERAL_CASES`."""
    if case_id in GENERAL_CASES:
        return general_case(case_id)
    for c in json.loads(path.read_text())["cases"]:
        if c["id"] == case_id:
            return E.Case(**{**c, "pair": tuple(c["pair"]) if c["pair"] else None})
    raise SystemExit(f"no case {case_id!r} in {path} or among the general-motion cases")


def clean_recording(case: E.Case, point=None):
    """The recording of ``case`` (at ``point``) with the anti-alias decimation only, and its truth."""
    bare = replace(case, noise=0.0, adc_bits=None, accel_offset=0.0, accel_drift=0.0)
    if case.id in GENERAL_CASES:
        return general_recording(bare)
    return E.make_recording(bare, point)


# ---- cases beyond the period-1 envelope (docs/estimation.md, "Long contacts and period-k motion") -------

#: Settling time [s] of the general-motion cases: slow, lightly damped laws need up to 80 s to settle (the
#: envelope's 40 s left some in a transient), and period-k motion may take as long.
SETTLE_GENERAL_S = 150.0

#: The classes of the issue "No confident wrong answers" (items 1-3), and what sets each apart (mu = 0, a
#: 24-bit ADC and 1 s at 204.8 kHz unless stated; n fixed at the truth in the fits):
GENERAL_CLASSES = {
    "near-plastic": "restitution 0.002-0.03 (n 1.2-1.35, beta 2e10-1e11), contacts of 1-4.4 ms, period-1, noise-free",
    "period-k": "cam speeds 16.5-24 Hz: one impact every k revolutions, alternating impacts, bounce sequences; "
                "noise-free",
    "slow": "approach speeds 0.16-0.30 m/s, restitution 0.90-0.994 (n 1.56-1.78), 0.2-0.47 % noise on the "
            "accelerometer",
    "slow-noise-free": "the slow class's cases without noise",
    "riding": "the follower rides the cam after the impact for 11-40 ms (16-32 % of a revolution): refusals",
    "irregular": "no period: refusals",
}

#: The general-motion cases: ``(class, e/r_c, cam speed [Hz], beta [N s m^-(n+1)], n, noise, generator, seed[,
#: mu])``. Drawn with fixed seeds (near-plastic 7, period-k 11, slow 13: e/r_c, cam speed and the law uniform in
#: the class's ranges, kept where impactid's regime classification finds the class's motion and restitution),
#: plus hand-picked points (the most plastic laws, and period-k patterns the draw missed); every third
#: recording of a class by the independent reference model.
_GENERAL = {
    # near-plastic, drawn
    "np00": ("near-plastic", 0.141, 15.0, 40937845545.56903, 1.238, 0.0, "reference", 2000),
    "np01": ("near-plastic", 0.191, 13.5, 71627022936.62764, 1.349, 0.0, "impactid", 2001),
    "np02": ("near-plastic", 0.115, 15.5, 21182120791.05855, 1.207, 0.0, "impactid", 2002),
    "np03": ("near-plastic", 0.193, 13.5, 87519082893.19768, 1.27, 0.0, "reference", 2003),
    "np04": ("near-plastic", 0.218, 12.5, 29787599208.419506, 1.275, 0.0, "impactid", 2004),
    "np05": ("near-plastic", 0.124, 14.5, 76069132047.5881, 1.201, 0.0, "impactid", 2005),
    "np06": ("near-plastic", 0.192, 16.0, 65994180149.1683, 1.296, 0.0, "reference", 2006),
    "np07": ("near-plastic", 0.279, 16.0, 27261905345.599125, 1.222, 0.0, "impactid", 2007),
    "np08": ("near-plastic", 0.284, 13.5, 26744271737.124016, 1.283, 0.0, "impactid", 2008),
    "np09": ("near-plastic", 0.274, 16.0, 36647462246.762665, 1.285, 0.0, "reference", 2009),
    "np10": ("near-plastic", 0.17, 14.0, 21263311304.81824, 1.236, 0.0, "impactid", 2010),
    "np11": ("near-plastic", 0.273, 13.5, 33590191956.828926, 1.282, 0.0, "impactid", 2011),
    # near-plastic, the most plastic laws of the documented range (restitution 0.0017-0.0075)
    "np12": ("near-plastic", 0.15, 13.0, 1e11, 1.2, 0.0, "reference", 2012),
    "np13": ("near-plastic", 0.25, 12.0, 1e11, 1.2, 0.0, "impactid", 2013),
    "np14": ("near-plastic", 0.25, 12.0, 5e10, 1.2, 0.0, "impactid", 2014),
    "np15": ("near-plastic", 0.1, 15.0, 1e11, 1.2, 0.0, "reference", 2015),
    "np16": ("near-plastic", 0.2, 14.0, 1e11, 1.2, 0.0, "impactid", 2016),
    "np17": ("near-plastic", 0.2, 14.0, 5e10, 1.2, 0.0, "impactid", 2017),
    # period-k, drawn (pk04, pk07, pk08 and pk10 ride the cam: see the riding class)
    "pk00": ("period-k", 0.087, 20.0, 6174322161.93084, 1.757, 0.0, "reference", 2000),
    "pk01": ("period-k", 0.178, 24.0, 11406568994.167404, 1.598, 0.0, "impactid", 2001),
    "pk02": ("period-k", 0.084, 19.0, 23205704807.831364, 1.602, 0.0, "impactid", 2002),
    "pk03": ("period-k", 0.254, 22.5, 94442629910.03864, 1.529, 0.0, "reference", 2003),
    "pk05": ("period-k", 0.267, 24.0, 11469482488.792791, 1.48, 0.0, "impactid", 2005),
    "pk06": ("period-k", 0.071, 17.5, 18127843753.419647, 1.738, 0.0, "reference", 2006),
    "pk09": ("period-k", 0.136, 22.0, 40388497629.27207, 1.744, 0.0, "reference", 2009),
    "pk11": ("period-k", 0.059, 20.0, 29095246639.96359, 1.708, 0.0, "impactid", 2011),
    # period-k, hand-picked patterns (impactid's regime map, mu = 0)
    "pk12": ("period-k", 0.2, 17.0, 24.7e9, 1.5, 0.0, "reference", 2012),
    "pk13": ("period-k", 0.15, 21.0, 24.7e9, 1.5, 0.0, "impactid", 2013),
    "pk14": ("period-k", 0.25, 20.0, 1e10, 1.4, 0.0, "impactid", 2014),
    "pk15": ("period-k", 0.1, 20.0, 5e10, 1.6, 0.0, "reference", 2015),
    "pk16": ("period-k", 0.25, 19.0, 5e10, 1.6, 0.0, "impactid", 2016),
    "pk17": ("period-k", 0.15, 17.0, 5e10, 1.6, 0.0, "impactid", 2017),
    "pk18": ("period-k", 0.1, 21.0, 24.7e9, 1.5, 0.0, "reference", 2018),
    "pk19": ("period-k", 0.2, 22.0, 24.7e9, 1.5, 0.0, "impactid", 2019),
    "pk20": ("period-k", 0.25, 18.0, 24.7e9, 1.5, 0.0, "impactid", 2020),
    "pk21": ("period-k", 0.1, 22.0, 24.7e9, 1.5, 0.0, "reference", 2021),
    # slow impacts with noise, drawn
    "sl00": ("slow", 0.055, 17.5, 11708720108.696943, 1.781, 0.002, "reference", 2000),
    "sl01": ("slow", 0.052, 16.0, 19113481075.906765, 1.66, 0.0024, "impactid", 2001),
    "sl02": ("slow", 0.061, 16.5, 12594956803.891827, 1.562, 0.0033, "impactid", 2002),
    "sl03": ("slow", 0.102, 15.5, 12929506677.92775, 1.609, 0.0045, "reference", 2003),
    "sl04": ("slow", 0.103, 15.5, 7420557781.637514, 1.721, 0.0035, "impactid", 2004),
    "sl05": ("slow", 0.08, 16.0, 19920326744.226173, 1.776, 0.0039, "impactid", 2005),
    "sl06": ("slow", 0.093, 16.5, 18537400053.968445, 1.734, 0.0047, "reference", 2006),
    "sl07": ("slow", 0.068, 16.5, 9780656436.391045, 1.585, 0.0025, "impactid", 2007),
    "sl08": ("slow", 0.064, 15.0, 6620159442.239119, 1.603, 0.0027, "impactid", 2008),
    "sl09": ("slow", 0.067, 16.0, 14026885285.160906, 1.709, 0.0046, "reference", 2009),
    "sl10": ("slow", 0.059, 16.0, 9360033600.633497, 1.587, 0.0043, "impactid", 2010),
    "sl11": ("slow", 0.058, 16.0, 6695565609.704271, 1.628, 0.0031, "impactid", 2011),
    # riding the cam (hc16 and hc44 of the envelope; pk04, pk07, pk08, pk10 of the period-k draw)
    "rd00": ("riding", 0.2549, 10.0, 58612441771.05722, 1.2500235892323228, 0.0, "impactid", 1016),
    "rd01": ("riding", 0.261, 8.0, 58359148930.29534, 1.2346437271276738, 0.0, "impactid", 1044),
    "rd02": ("riding", 0.198, 20.5, 55291676518.35249, 1.341, 0.0, "impactid", 2004),
    "rd03": ("riding", 0.087, 23.0, 74431860838.2416, 1.321, 0.0, "reference", 2007),
    "rd04": ("riding", 0.104, 21.5, 9123814269.370575, 1.22, 0.0, "impactid", 2008),
    "rd05": ("riding", 0.135, 20.0, 8070592591.051846, 1.21, 0.0, "impactid", 2010),
    # irregular (mu 0.2 as the paper's rig)
    "ir00": ("irregular", 0.2, 18.0, 24.7e9, 1.5, 0.0, "impactid", 3000, 0.2),
    "ir01": ("irregular", 0.1, 19.0, 24.7e9, 1.5, 0.0, "reference", 3001, 0.2),
}
_GENERAL.update({f"sc{k[2:]}": ("slow-noise-free",) + v[1:5] + (0.0,) + v[6:] for k, v in _GENERAL.items()
                 if v[0] == "slow"})
GENERAL_CASES = tuple(_GENERAL)


def general_case(case_id: str) -> E.Case:
    """The :class:`tests.envelope.Case` of a general-motion case (:data:`GENERAL_CASES`)."""
    klass, e, f, beta, n, noise, generator, seed, *mu = _GENERAL[case_id]
    return E.Case(id=case_id, klass=klass, e_over_rc=e, cam_speed_hz=f, beta=beta, n=n, mu=mu[0] if mu else 0.0,
                  noise=noise, adc_bits=24, generator=generator, seed=seed)


def general_recording(case: E.Case, settle: float = SETTLE_GENERAL_S):
    """The recording of a general-motion case and its truth: impactid's generator after ``settle`` s, or the
    independent reference model started on the motion impactid's simulator settles to (in the middle of the
    longest free flight of the last revolution before ``settle``: the reference's own shooting finds period-1
    orbits only), so that it records period-k, riding and irregular motion too.

    On one machine the recording is a function of the case alone: the same bits in any process, worker or
    order, whether rig P's kernels were just compiled or loaded from the cache (they were not before the
    kernel's step functions were inlined: ``impactid.rigs.pivoted.kernel._STEP_FLAGS``). Which motion a case
    settles to may still depend on round-off, where two motions coexist and the transient between them is
    chaotic (pk00: 1 or 0.7 impacts per revolution); another machine, compiler or kernel build may then
    record the other one. :func:`settling_check` says which cases are so, and the validation's page shows
    it beside each case (benchmarks/envelope_notes.md, "Reproducible recordings")."""
    from impactid.rigs.pivoted.synth import synth_pivoted
    from tests.rigs.pivoted import reference_recordings as RR

    rig = SUNDAR2016.with_eccentricity_ratio(case.e_over_rc)
    law = HuntCrossley(case.beta, case.n)
    if case.generator != "reference":
        synthetic = synth_pivoted(rig, case.cam_speed_hz, law, case.duration, settle_s=settle,
                                  sample_rate_hz=case.sample_rate_hz, sensors=case.sensors(), mu=case.mu)
        return synthetic.recording, synthetic.truth
    period = 1.0 / case.cam_speed_hz
    run = simulate(rig, case.cam_speed_hz, law, settle, mu=case.mu)
    c = run.contacts[run.contacts["t_end"] > settle - 6 * period]
    # the free flights between the contacts of the last revolutions, and from the last one to ``settle``
    starts = np.append(c["t_start"].to_numpy()[1:], settle)
    ends = c["t_end"].to_numpy()
    k = int(np.argmax(starts - ends))
    t_section = 0.5 * (ends[k] + starts[k])
    state = simulate(rig, case.cam_speed_hz, law, t_section, t_eval=[t_section], mu=case.mu)
    hc = RR._law({"kind": "hunt-crossley", "beta": case.beta, "n": case.n})
    orbit = RR.PeriodicOrbit(state=np.array([state.alpha[0], state.alpha_dot[0]]),
                             section_phase=(2 * math.pi * case.cam_speed_hz * t_section) % (2 * math.pi),
                             cam_speed_hz=float(case.cam_speed_hz), period=period, law=hc, mu=case.mu,
                             multipliers=np.zeros(2, complex), jacobian=np.eye(2), residual=np.zeros(2),
                             contacts_per_revolution=0, contacts=[])
    return RR.reference_recording(case.e_over_rc, case.cam_speed_hz, hc, mu=case.mu, duration=case.duration,
                                  sample_rate_hz=case.sample_rate_hz, sensors=case.sensors(), start_time_s=settle,
                                  orbit=orbit)


#: Offsets [rad] of the start angle from the static equilibrium with which :func:`settling_check` settles a
#: general-motion case again: far below anything physical (a nanoradian at most), above round-off (an ulp of
#: the angle is about 1e-17 rad; two builds of the kernel differ by 1e-12 relative after a second). Eleven
#: starts (a settling of 151 s takes about 0.1 s): pk00 settles to 0.7 impacts per revolution from most starts,
#: to 1 from a few (1 from the static equilibrium itself with the kernel build of the page at a78ad08), and is
#: still in its transient at 150 s from others.
SETTLING_OFFSETS = (0.0, *(sign * 10.0 ** -k for k in range(13, 8, -1) for sign in (1.0, -1.0)))
#: Largest relative difference of the median approach speed between two settled motions that are the same.
SETTLING_SPEED_TOLERANCE = 0.01


def settled_motion(case: E.Case, settle: float = SETTLE_GENERAL_S, offset: float = 0.0) -> dict:
    """The motion impactid's simulator records in ``[settle, settle + case.duration)`` from the static
    equilibrium (cam at 0) with the start angle moved by ``offset`` [rad]: impacts per revolution (contacts
    starting in the window, over its revolutions) and the median approach speed [m/s] (NaN without one)."""
    rig = SUNDAR2016.with_eccentricity_ratio(case.e_over_rc)
    alpha0 = rig.static_equilibrium(0.0) + offset
    run = simulate(rig, case.cam_speed_hz, HuntCrossley(case.beta, case.n), settle + case.duration,
                   initial_state=(alpha0, 0.0), mu=case.mu)
    t_start = run.contacts["t_start"].to_numpy()
    inside = (t_start >= settle) & (t_start < settle + case.duration)
    speeds = -run.contacts["gap_rate_start"].to_numpy()[inside]
    return {"impacts_per_revolution": round(int(inside.sum()) / (case.duration * case.cam_speed_hz), 3),
            "v_a": float(np.median(speeds)) if speeds.size else math.nan}


def settling_check(case: E.Case, settle: float = SETTLE_GENERAL_S) -> dict:
    """Whether the motion a general-motion case settles to is robust to round-off.

    The case is settled by impactid's simulator from the static equilibrium and from starts
    :data:`SETTLING_OFFSETS` away (1e-13 to 1e-9 rad: a difference of rounding, not of the experiment); the settled
    motion is *robust* where every start gives the same impacts per revolution in the recorded window and
    median approach speeds within :data:`SETTLING_SPEED_TOLERANCE`, else *sensitive*: coexisting motions with
    a chaotic transient between them, or irregular motion, where the recorded motion depends on round-off
    (another machine, compiler or kernel build may record another one). The recording itself is the same on
    one machine either way (:func:`general_recording`).

    Returns ``settling`` (``robust`` or ``sensitive``) and ``settled_motions`` (text: each distinct motion,
    impacts per revolution at the median approach speed, with how many of the starts settled to it; the
    static equilibrium's first).
    """
    motions = [settled_motion(case, settle, offset) for offset in SETTLING_OFFSETS]
    first = motions[0]

    def same(m: dict) -> bool:
        if m["impacts_per_revolution"] != first["impacts_per_revolution"]:
            return False
        if math.isnan(m["v_a"]) or math.isnan(first["v_a"]):
            return math.isnan(m["v_a"]) and math.isnan(first["v_a"])
        return abs(m["v_a"] - first["v_a"]) <= SETTLING_SPEED_TOLERANCE * abs(first["v_a"])

    texts = [f"{m['impacts_per_revolution']:g} at {m['v_a']:.3g} m/s" for m in motions]
    counts = dict.fromkeys(texts, 0)  # the distinct motions in the order found, with how many starts gave each
    for text in texts:
        counts[text] += 1
    return {"settling": "robust" if all(same(m) for m in motions) else "sensitive",
            "settled_motions": ", ".join(f"{text} ({k}/{len(texts)})" for text, k in counts.items())}


def run_class(klass: str, **options) -> list[dict]:
    """The n-fixed fit of every general-motion case of ``klass`` (as the validation runs it: calibrated): per
    case the truth's motion, the outcome (estimate, or refusal with its reason) and the score; printed as a
    table row each and summarised against the targets (beta within 1 %; no estimate more than 5 % off with an
    interval that excludes the truth)."""
    rows = []
    for case_id in (c for c in GENERAL_CASES if _GENERAL[c][0] == klass):
        case = general_case(case_id)
        started = time.perf_counter()
        try:
            rec, truth = general_recording(case)
        except Exception as exc:  # noqa: BLE001 - a generator that cannot record the case is not impactid's error
            rows.append({"case": case_id, "outcome": f"not recorded: {type(exc).__name__}: {exc}"})
            continue
        imp = truth["impacts"]
        row = {"case": case_id, "generator": case.generator, "e_over_rc": case.e_over_rc, "hz": case.cam_speed_hz,
               "beta": case.beta, "n": case.n, "noise": case.noise,
               "impacts_per_revolution": round(len(imp["t_start"]) / (case.duration * case.cam_speed_hz), 3),
               "xi": float(np.nanmedian(imp["xi"])), "v_a": float(np.nanmedian(-np.asarray(imp["gap_rate_start"]))),
               "contact_ms": float(1e3 * np.nanmedian(np.asarray(imp["t_end"]) - np.asarray(imp["t_start"]))),
               **settling_check(case)}
        out = run_fit([rec], case, fix_n=case.n, **options)
        row.update({k: v for k, v in out.items() if k in ("outcome", "beta_error", "beta_lo_rel", "beta_hi_rel",
                                                          "covered", "events")})
        row.setdefault("outcome", "estimate")
        row["seconds"] = round(time.perf_counter() - started, 1)
        if row["outcome"] == "estimate":
            row["confident_wrong"] = bool(abs(row["beta_error"]) > 0.05 and not row["covered"])
            print(f"{case_id} {case.generator[:3]} e/r_c {case.e_over_rc:g} {case.cam_speed_hz:g} Hz beta "
                  f"{case.beta:.4g} n {case.n:g} noise {case.noise:g}: xi {row['xi']:.4g} v_a {row['v_a']:.3g} "
                  f"impacts/rev {row['impacts_per_revolution']:g} contact {row['contact_ms']:.3g} ms, settling "
                  f"{row['settling']} ({row['settled_motions']}) | beta "
                  f"{100 * row['beta_error']:+.3f} % [{100 * row['beta_lo_rel']:+.2f}, "
                  f"{100 * row['beta_hi_rel']:+.2f}] covered {row['covered']} ({row['events']} events, "
                  f"{row['seconds']} s)", flush=True)
        else:
            print(f"{case_id} {case.generator[:3]} e/r_c {case.e_over_rc:g} {case.cam_speed_hz:g} Hz: "
                  f"{row['outcome'][:400]}", flush=True)
        rows.append(row)
    est = [r for r in rows if r.get("outcome") == "estimate"]
    within = sum(abs(r["beta_error"]) <= 0.01 for r in est)
    print(f"{klass}: {len(rows)} cases, {len(est)} estimates ({within} within 1 %, "
          f"{sum(r['covered'] for r in est)} covered), {len(rows) - len(est)} refusals, "
          f"{sum(r.get('confident_wrong', False) for r in est)} confident wrong answers", flush=True)
    return rows


# ---- the validation's tasks beyond the period-1 envelope (benchmarks/validate_envelope.py) -------------------
#
# The validation ships these functions to its dask workers by reference (``benchmarks.envelope_case.run_task``):
# the workers import this repository's ``benchmarks`` (a namespace package) and ``tests`` packages.

#: The parts of the validation: the drawn period-1 cases, the general-motion cases, the misspecified models.
PARTS = ("period-1", "general", "misspecified")

#: The kinds of the misspecified class, and what sets each apart (noise-free, 24-bit ADC, 1 s at 204.8 kHz).
MISSPECIFIED_KINDS = {
    "restitution-law": "recorded with the restitution law xi = 1 - gamma v_a (S3, rigid impacts) and fitted with "
                       "Hunt-Crossley: n fixed at 1.5 on the first point, and jointly over two period-1 points of "
                       "the same law whose approach speeds differ by at least 30 %",
    "rig-constant": "recorded with the true rig, estimated (n fixed at the truth) with a rig whose one constant is "
                    "off by 20-50 %: the follower's moment of inertia I_b, the return spring's stiffness k_s, both "
                    "Young's moduli (the Hertz stiffness k_H scales with them) or the pin radius r_d (the Hertz "
                    "radius, and the contact geometry with it)",
}

#: Rig constants a ``rig-constant`` case may scale: the field(s) of
#: :class:`~impactid.rigs.pivoted.parameters.PivotedFollowerRig` each name scales.
RIG_CONSTANTS = {"I_b": ("I_b",), "k_s": ("k_s",), "Y": ("Y_c", "Y_b"), "r_d": ("r_d",)}


@dataclass(frozen=True)
class MisspecifiedCase:
    """A recording made with one model and estimated with another (all SI; ``beta`` in N s m^-(n+1)).

    ``kind`` ``"restitution-law"``: recorded with the restitution law ``gamma`` [s/m] at ``(e_over_rc,
    cam_speed_hz)`` and at ``pair``; ``"rig-constant"``: recorded with Hunt-Crossley ``beta, n`` and the true
    rig, estimated with the rig whose ``constant`` (:data:`RIG_CONSTANTS`) is multiplied by ``scale``.
    """

    id: str
    kind: str
    e_over_rc: float
    cam_speed_hz: float
    beta: float = math.nan
    n: float = math.nan
    gamma: float = math.nan
    pair: tuple[float, float] | None = None
    constant: str = ""
    scale: float = 1.0
    generator: str = "impactid"
    seed: int = 0
    klass: str = "misspecified"

    def envelope_case(self) -> E.Case:
        """The :class:`tests.envelope.Case` that records it (noise-free, 24-bit ADC)."""
        if self.kind == "restitution-law":
            return E.Case(id=self.id, klass="S3", e_over_rc=self.e_over_rc, cam_speed_hz=self.cam_speed_hz,
                          gamma=self.gamma, pair=self.pair, generator=self.generator, seed=self.seed, adc_bits=24)
        return E.Case(id=self.id, klass="noise-free", e_over_rc=self.e_over_rc, cam_speed_hz=self.cam_speed_hz,
                      beta=self.beta, n=self.n, generator=self.generator, seed=self.seed, adc_bits=24)


#: The misspecified cases. The restitution-law points are the envelope's S3 points (``s360``-``s374`` of
#: ``docs/validation_envelope_cases.json``) paired at one law, both period-1 under impactid's regime
#: classification (approach speeds 1.06/0.48, 0.85/0.42, 0.79/0.29 and 0.34/0.59 m/s); the rig-constant points
#: are the envelope's noise-free points (hc20, hc28, hc00, hc36, hc04, hc40, hc48, hc12), whose fits with the
#: right rig are within 1 %. Four of the twelve recordings are made by the independent reference model.
MISSPECIFIED_CASES = (
    MisspecifiedCase("ms00", "restitution-law", 0.2725, 13.5, gamma=0.4711, pair=(0.1746, 15.0),
                     generator="reference", seed=4000),
    MisspecifiedCase("ms01", "restitution-law", 0.2249, 13.5, gamma=0.7477, pair=(0.1575, 15.5), seed=4001),
    MisspecifiedCase("ms02", "restitution-law", 0.227, 13.5, gamma=0.9557, pair=(0.1119, 16.5), seed=4002),
    MisspecifiedCase("ms03", "restitution-law", 0.1276, 15.5, gamma=0.3287, pair=(0.1979, 14.5), seed=4003),
    MisspecifiedCase("mr00", "rig-constant", 0.1365, 15.5, beta=43060686898.4858, n=1.7539169938498236,
                     constant="I_b", scale=1.3, seed=4100),
    MisspecifiedCase("mr01", "rig-constant", 0.1662, 15.0, beta=18349100875.630653, n=1.6839391935862023,
                     constant="I_b", scale=0.75, generator="reference", seed=4101),
    MisspecifiedCase("mr02", "rig-constant", 0.1668, 10.5, beta=8546131365.012307, n=1.5839478994290928,
                     constant="Y", scale=1.5, seed=4102),
    MisspecifiedCase("mr03", "rig-constant", 0.2425, 14.0, beta=33393950704.600323, n=1.3058806129201166,
                     constant="Y", scale=0.6, generator="reference", seed=4103),
    MisspecifiedCase("mr04", "rig-constant", 0.2798, 9.5, beta=11629164769.20861, n=1.3624085408675461,
                     constant="k_s", scale=1.25, seed=4104),
    MisspecifiedCase("mr05", "rig-constant", 0.1591, 13.0, beta=28113143388.379524, n=1.7890245371717102,
                     constant="k_s", scale=0.7, seed=4105),
    MisspecifiedCase("mr06", "rig-constant", 0.1171, 11.5, beta=7342516465.511615, n=1.7297204042811312,
                     constant="r_d", scale=1.2, generator="reference", seed=4106),
    MisspecifiedCase("mr07", "rig-constant", 0.2802, 16.0, beta=75936005283.239, n=1.3366915635632672,
                     constant="Y", scale=1.2, seed=4107),
)

#: Verdicts of the model check that are a warning (:data:`impactid.engine.checks.VERDICTS` but ``consistent``
#: and ``not checked``).
WARNING_VERDICTS = ("systematic misfit", "structured", "lack of fit", "rejected")
#: An estimate this far off (relative) with an interval that excludes the truth is a confident wrong answer.
CONFIDENT_WRONG = 0.05


def confident_wrong(value: float, interval: tuple[float, float], truth: float) -> bool:
    """Whether an estimate is more than :data:`CONFIDENT_WRONG` (relative) off ``truth`` while its interval
    excludes it (a withheld, NaN, interval excludes nothing)."""
    lo, hi = interval
    off = abs(value / truth - 1.0) > CONFIDENT_WRONG if truth else False
    return bool(off and (lo > truth or hi < truth))


def damping_values(result, beta: float, n: float | None = None) -> dict:
    """The scores of a Hunt-Crossley fit against the law ``beta, n`` (``n`` None: n was fixed).

    Returns the estimate, its interval, the error, coverage, the model check's verdict and action, whether it
    warns (a verdict of :data:`WARNING_VERDICTS`), whether a note names the model check, whether the fit reports
    its parameters as determined (its identifiability block: not where the model check finds that the law does
    not describe the data, the problem is ill-conditioned, or beta's interval reaches more than ten times away
    from the estimate), the separability
    (joint fits) and whether the answer is confident and wrong (:func:`confident_wrong`, on ``beta`` and, for a
    joint fit, ``n``).
    """
    d = result.damping
    check = dict(d.model_check or {})
    verdict = str(check.get("verdict", "not checked"))
    notes = tuple(result.warnings) + tuple(d.warnings)
    values = {"beta": d.beta, "beta_lo": d.beta_interval[0], "beta_hi": d.beta_interval[1],
              "beta_error": d.beta / beta - 1.0,
              "beta_covered": bool(d.beta_interval[0] <= beta <= d.beta_interval[1]),
              "verdict": verdict, "action": str(check.get("action", "none")),
              "warned": verdict in WARNING_VERDICTS, "model_check_note": any("model check" in w for w in notes),
              "determined": bool(dict(d.identifiability or {}).get("determined", True)),
              "failed_simulations": d.n_failed_simulations}
    wrong = confident_wrong(d.beta, d.beta_interval, beta)
    if n is not None:
        values.update(n=d.n, n_lo=d.n_interval[0], n_hi=d.n_interval[1], n_error=d.n - n,
                      n_covered=bool(d.n_interval[0] <= n <= d.n_interval[1]), separable=d.separable,
                      left_out=E.left_out_of_joint_fit(notes))
        wrong = wrong or confident_wrong(d.n, d.n_interval, n)
    values["confident_wrong"] = bool(wrong)
    return values


def _truth_motion(truth: dict, case: E.Case) -> dict:
    """The true motion of a general-motion recording: impacts per revolution, median xi, v_a, contact time."""
    imp = truth["impacts"]
    if not len(imp["t_start"]):
        return {"impacts_per_revolution": 0.0}
    return {"impacts_per_revolution": round(len(imp["t_start"]) / (case.duration * case.cam_speed_hz), 3),
            "xi": float(np.nanmedian(imp["xi"])), "v_a": float(np.nanmedian(-np.asarray(imp["gap_rate_start"]))),
            "contact_ms": float(1e3 * np.nanmedian(np.asarray(imp["t_end"]) - np.asarray(imp["t_start"])))}


def run_general_case(case_id: str) -> dict:
    """The n-fixed fit (at the true ``n``) of the general-motion case ``case_id`` (:data:`GENERAL_CASES`), as
    :func:`run_class` runs it, as a row of the validation (the schema of :func:`tests.envelope.run_case`: the
    case, ``generation``, the true motion and ``outcomes``, one ``n-fixed`` outcome scored by
    :func:`damping_values`), with whether its settled motion is robust to round-off (:func:`settling_check`)."""
    case = general_case(case_id)
    row = {k: v for k, v in asdict(case).items() if k != "pair"}
    try:
        rec, truth = general_recording(case)
    except Exception as exc:  # noqa: BLE001 - a generator that cannot record the case is not impactid's error
        row.update(generation=f"{type(exc).__name__}: {exc}", outcomes=[])
        return row
    row["generation"] = "ok"
    row.update(_truth_motion(truth, case))
    row.update(settling_check(case))
    out, result = E._fit("n-fixed", [rec], fix_n=case.n)
    if result is not None:
        out.values = damping_values(result, case.beta)
    row["outcomes"] = [asdict(out)]
    return row


def misspecified_rig(rig, constant: str, scale: float):
    """``rig`` with the constant ``constant`` (:data:`RIG_CONSTANTS`) multiplied by ``scale``."""
    return replace(rig, **{name: getattr(rig, name) * scale for name in RIG_CONSTANTS[constant]})


def run_misspecified_case(case: MisspecifiedCase, joint: bool = True) -> dict:
    """The fits of a misspecified case, as a row of the validation (see :func:`run_general_case`).

    Restitution-law cases: the Hunt-Crossley fit with ``n`` fixed at 1.5 (scored against the law's
    Hunt-Crossley equivalent ``beta = 1.5 gamma k_H``, the reference the restitution fit reports), the
    restitution fit of the same call (against ``gamma``) and, with ``joint``, the joint fit over both points
    (scored against ``(1.5 gamma k_H, 1.5)``). Rig-constant cases: the fit with ``n`` fixed at the truth, on the
    recording whose rig is replaced by :func:`misspecified_rig`. Every damping outcome carries the model check's
    verdict, whether it warns and (joint) whether it is reported separable.
    """
    from impactid import SUNDAR2016

    env = case.envelope_case()
    row = {k: v for k, v in asdict(case).items() if k != "pair"}
    row["pair_e_over_rc"], row["pair_cam_speed_hz"] = case.pair if case.pair else (math.nan, math.nan)
    try:
        rec, _ = E.make_recording(env)
        partner = E.make_recording(env, case.pair)[0] if (joint and case.pair) else None
    except Exception as exc:  # noqa: BLE001 - the generator refusing a case is not impactid's error
        row.update(generation=f"{type(exc).__name__}: {exc}", outcomes=[])
        return row
    row["generation"] = "ok"
    outcomes = []
    if case.kind == "restitution-law":
        beta_eq = 1.5 * case.gamma * SUNDAR2016.k_H
        row["beta"], row["n"] = beta_eq, 1.5  # the Hunt-Crossley equivalent of the law: the reference scored
        out, result = E._fit("n-fixed", [rec], fix_n=1.5)
        if result is not None:
            out.values = damping_values(result, beta_eq)
            r = result.restitution
            outcomes.append(E.Outcome("restitution", "estimate" if r is not None else "refusal",
                                      reason="" if r is not None else "no impact with a determined xi",
                                      values={} if r is None else {
                                          "gamma": r.gamma, "gamma_stderr": r.gamma_stderr,
                                          "gamma_error": r.gamma / case.gamma - 1.0,
                                          "gamma_covered": bool(abs(r.gamma - case.gamma) <= 1.96 * r.gamma_stderr)}))
        outcomes.insert(0, out)
        if partner is not None:
            out, result = E._fit("joint", [rec, partner])
            if result is not None:
                out.values = damping_values(result, beta_eq, 1.5)
            outcomes.append(out)
    else:
        wrong = rec.with_rig(misspecified_rig(rec.require_rig(), case.constant, case.scale))
        out, result = E._fit("n-fixed", [wrong], fix_n=case.n)
        if result is not None:
            out.values = damping_values(result, case.beta)
        outcomes.append(out)
    row["outcomes"] = [asdict(o) for o in outcomes]
    return row


def task_cases(part: str) -> list:
    """The cases of a part of the validation besides ``period-1`` (whose cases are drawn and cached by
    ``benchmarks/validate_envelope.py``): the general-motion :class:`tests.envelope.Case` objects or the
    :class:`MisspecifiedCase` objects."""
    if part == "general":
        return [general_case(c) for c in GENERAL_CASES]
    if part == "misspecified":
        return list(MISSPECIFIED_CASES)
    raise ValueError(f"no cases of part {part!r} here")


def run_task(task: tuple[str, object, bool]) -> dict:
    """One case of the validation: ``(part, case, joint)`` with ``part`` of :data:`PARTS`; the row of
    :func:`tests.envelope.run_case`, :func:`run_general_case` or :func:`run_misspecified_case`."""
    part, case, joint = task
    if part == "period-1":
        return E.run_case(case, joint=joint)
    if part == "general":
        return run_general_case(case.id)
    if part == "misspecified":
        return run_misspecified_case(case, joint=joint)
    raise ValueError(f"unknown part {part!r} (one of {', '.join(PARTS)})")


def with_sensors(clean, sensors: SensorModel):
    """``clean`` through the sensor chain ``sensors`` (as both generators apply it)."""
    rng = np.random.default_rng(sensors.seed)
    channels = {k: np.asarray(v) for k, v in clean.channels.items() if k != "cam_angle"}
    measured, _ = apply_sensors(channels, clean.sample_rate_hz, sensors, rng)
    if "cam_angle" in clean.channels:
        measured["cam_angle"] = np.asarray(clean.channels["cam_angle"])
    return replace(clean, channels={k: measured[k] for k in clean.channels})


def _quiet(fn, *args, **kwargs):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = fn(*args, **kwargs)
    return out, [str(w.message) for w in caught]


def reconstruction(rec):
    """The reconstruction and event set the pipeline makes (rk integration, the anchor of :data:`OPTIONS`)."""
    recon, _ = _quiet(reconstruct, rec, integration="rk", anchor=OPTIONS["anchor"])
    return recon, EventSet.from_reconstruction(recon, source="recording")


def true_events(recon, truth, case: E.Case, point=None) -> pd.DataFrame:
    """Per reconstructed event: the true apex, onset state and next onset (nearest true contact)."""
    imp = truth["impacts"]
    ts = np.asarray(imp["t_start"], float)
    apex_t, apex_a = (np.asarray(truth["apexes"][k], float) for k in ("t", "alpha"))
    f = point[1] if point is not None else case.cam_speed_hz
    rows = []
    for event, row in recon.table.iterrows():
        k = int(np.argmin(np.abs(ts - row["t_onset"])))
        later = np.flatnonzero((apex_t > row["t_onset"]) & (apex_t < row["t_next"]))
        rows.append(dict(event=event, t_start=ts[k], dt_onset=row["t_onset"] - ts[k],
                         alpha_start=imp["alpha_start"][k], alpha_dot_start=imp["alpha_dot_start"][k],
                         theta_start=truth["theta_ref"] + 2 * math.pi * f * ts[k],
                         theta_at_onset=truth["theta_ref"] + 2 * math.pi * f * row["t_onset"],
                         alpha_at_onset=float(np.interp(row["t_onset"], truth["t"], truth["alpha"])),
                         t_end=(ts[k + 1] - ts[k]) if k + 1 < ts.size else math.nan,
                         v_a=-imp["gap_rate_start"][k],
                         apex=float(np.max(apex_a[later])) if later.size else math.nan))
    return pd.DataFrame(rows).set_index("event")


def _wrap(angle):
    """Angle difference wrapped to (-pi, pi]."""
    return np.angle(np.exp(1j * np.asarray(angle, dtype=float)))


def event_table(recon, tr: pd.DataFrame) -> pd.DataFrame:
    """Measured against true, per event."""
    tab = recon.table
    return pd.DataFrame({
        "alpha_m": tab["alpha_m"], "alpha_m_err": tab["alpha_m"] / tr["apex"] - 1.0,
        "anchor_err": (tab["alpha_onset"] - tr["alpha_at_onset"]) / tr["apex"],
        "excursion_err": ((tab["alpha_m"] - tab["alpha_onset"]) - (tr["apex"] - tr["alpha_at_onset"])) / tr["apex"],
        "rate0_err": tab["alpha_dot_onset"] - tr["alpha_dot_start"],
        "dt_onset_us": 1e6 * tr["dt_onset"], "phase_err": _wrap(tab["theta_onset"] - tr["theta_at_onset"]),
        "v_a": tab["approach_speed"],
        "v_a_err": tab["approach_speed"] / tr["v_a"] - 1.0, "contact_ms": 1e3 * tab["contact_duration"],
        "hertz_ratio": tab["hertz_ratio"], "consistent": tab["contact_consistent"]})


def motion(truth, case: E.Case, point=None) -> dict:
    """The true motion over the recording: contacts, their durations, the gap between them."""
    f = point[1] if point is not None else case.cam_speed_hz
    imp = truth["impacts"]
    ts, te = np.asarray(imp["t_start"], float), np.asarray(imp["t_end"], float)
    t = np.asarray(truth["t"], float)
    mode = np.asarray(truth["mode"]) != 0
    gap = np.asarray(truth["gap"], float)
    revs = (t[-1] - t[0]) * f
    period = 1.0 / f
    force = np.asarray(truth["contact_force"], float)
    # tensile (negative) Hunt-Crossley force late in the restitution: its impulse against the compressive one
    tension = float(-np.sum(np.minimum(force, 0.0)) / max(np.sum(np.maximum(force, 0.0)), 1e-300))
    # contact runs of the sampled truth: their length and the force more than 1 ms after their peak (riding)
    edges = np.flatnonzero(np.diff(np.concatenate(([0], mode.astype(np.int8), [0]))))
    runs = [(a, b) for a, b in zip(edges[::2], edges[1::2]) if a > 0 and b < mode.size]
    lengths = [1e3 * (t[b - 1] - t[a]) for a, b in runs]
    late = [np.median(force[a:b][t[a:b] > t[a + int(np.argmax(force[a:b]))] + 1e-3]) for a, b in runs
            if np.any(t[a:b] > t[a + int(np.argmax(force[a:b]))] + 1e-3)]
    return {"contacts": int(ts.size), "revolutions": round(float(revs), 2),
            "contacts_per_revolution": round(float(ts.size / revs), 3),
            "kinds": pd.Series(str(truth.get("impact_kinds", "")).split(",")).value_counts().to_dict(),
            "contact_ms_median": float(1e3 * np.median(te - ts)),
            "contact_share_of_revolution": float(np.median(te - ts) / period),
            "samples_in_contact_share": float(mode.mean()),
            "largest_gap_um": float(1e6 * gap.max()), "median_gap_um": float(1e6 * np.median(gap)),
            "peak_indentation_um": float(1e6 * np.nanmedian(imp["peak_indentation"])),
            "tensile_force_min_rel": float(force.min() / force.max()), "tensile_impulse_share": tension,
            "contact_run_ms_median": float(np.median(lengths)) if lengths else math.nan,
            "force_1ms_after_peak_N": float(np.median(late)) if late else math.nan,
            "v_a": float(np.median(-np.asarray(imp["gap_rate_start"], float)))}


def sensitivities(es: EventSet, beta: float, n: float, h: float = 0.01) -> dict:
    """lambda1 at the truth and its derivatives in ln beta (n fixed) and in n (beta fixed), per event."""
    trials = np.array([[beta, n], [beta * math.exp(h), n], [beta * math.exp(-h), n], [beta, n + h], [beta, n - h]])
    r = es.residuals(trials)
    return {"lambda1": r[0], "d_lnbeta": (r[1] - r[2]) / (2 * h), "d_n": (r[3] - r[4]) / (2 * h)}


def oracle_sets(es: EventSet, tr: pd.DataFrame) -> dict[str, EventSet]:
    """The event set with the true alpha_m, the true onset state (and next onset), or both."""
    t = tr.loc[es.events]
    states = np.ascontiguousarray(t[["alpha_start", "alpha_dot_start", "theta_start"]].to_numpy(float))
    t_end = np.ascontiguousarray(t["t_end"].to_numpy(float))
    apex = t["apex"].to_numpy(float)
    ok = np.isfinite(apex) & np.isfinite(t_end)
    es = es.subset(np.flatnonzero(ok))
    states, t_end, apex = states[ok], t_end[ok], apex[ok]
    phase_err = float(np.median(_wrap(es.states[:, 2] - t["theta_at_onset"].to_numpy(float)[ok])))
    return {"measured": es, "true cam phase": es.shift_phase(-phase_err), "true alpha_m": replace(es, alpha_m=apex),
            "true onset state": replace(es, states=states, t_end=t_end),
            "both true": replace(es, alpha_m=apex, states=states, t_end=t_end)}


def phase_scan(es: EventSet, case: E.Case, steps=(-2.0, -1.0, 0.0, 1.0, 2.0)) -> list[dict]:
    """The n-fixed estimate with the recording's cam phase moved by ``steps`` standard errors: the
    response of ``beta`` to the phase, against the linear one-sided propagation of the intervals."""
    out = []
    for k in steps:
        d, _ = _quiet(fit_contact_damping, [es.shift_phase(k * es.phase_stderr)], "lambda1", fix_n=case.n)
        out.append({"phase_shift_se": k, "phase_shift_rad": k * es.phase_stderr, "beta_error": d.beta / case.beta - 1.0,
                    "phase_beta_rel_sd": d.phase_beta_sd / d.beta})
        print(f"phase scan: {_fmt(out[-1])}", flush=True)
    return out


def profile(sets: dict[str, EventSet], case: E.Case, factors=None) -> dict:
    """Mean |lambda1|, the median S1 contact count and apex time along ``beta`` (n fixed) for each event set,
    and where the estimator's 41-point scan of ``log10 c`` puts its best point (measured set)."""
    factors = np.geomspace(1e-3, 30.0, 37) if factors is None else np.asarray(factors, float)
    trials = np.column_stack([case.beta * factors, np.full(factors.size, case.n)])
    out = {"beta_factor": factors.tolist()}
    lines = [["beta/true"] + [f"{x:.3g}" for x in factors]]
    for label, es in sets.items():
        batch = es.simulate(trials)
        j = np.nanmean(np.abs((batch.alpha_m - es.alpha_m) / es.alpha_m), axis=1)
        contacts = np.median(batch.n_contacts, axis=1)
        apex = 1e3 * np.median(batch.t_alpha_m, axis=1)
        out[label] = {"objective": j.tolist(), "median_contacts": contacts.tolist(), "apex_ms": apex.tolist()}
        lines.append([f"J {label}"] + [f"{x:.2g}" for x in j])
        lines.append([f"contacts {label}"] + [f"{x:.0f}" for x in contacts])
        lines.append([f"apex ms {label}"] + [f"{x:.4g}" for x in apex])
    width = max(len(r[0]) for r in lines)
    for row in lines:
        print(row[0].ljust(width), " ".join(x.rjust(7) for x in row[1:]))
    es = sets["measured"]
    obj = _Objective([es], "lambda1", reference_indentation([es]))
    grid = np.linspace(math.log10(C_BOUNDS[0]), math.log10(C_BOUNDS[1]), 41)  # the estimator's scan
    scan = obj.mean(obj.per_event(grid, case.n))
    true_logc = math.log10(case.beta * obj.delta_ref ** case.n)
    k = int(np.argmin(scan))
    near = sorted(np.argsort(np.abs(grid - true_logc))[:2])
    out["scan"] = {"best_beta_factor": 10 ** (grid[k] - true_logc), "best_objective": float(scan[k]),
                   "bracketing_truth": [(10 ** (grid[i] - true_logc), float(scan[i])) for i in near],
                   "objective_at_truth": obj(true_logc, case.n)}
    print(f"estimator's scan (measured set): {_fmt(out['scan'])}")
    return out


def anchor_study(clean, truth, case: E.Case, seeds: int, scales=(1.0, 0.5, 0.25)) -> list[dict]:
    """Errors of the return-time and cam-phase onset angles and of the excursion ``alpha_m - alpha(0)``
    (each relative to the true apex, mean over events) over noise seeds, at fractions of the case's noise."""
    out = []
    for scale in scales:
        rows = []
        for k in range(seeds):
            sensors = replace(case.sensors(), noise=case.noise * scale, seed=case.seed + SEED_STEP * k)
            r = with_sensors(clean, sensors)
            recon, _ = reconstruction(r)
            tr = true_events(recon, truth, case)
            tab = event_table(recon, tr)
            rt, _ = _quiet(reconstruct, r, integration="rk", anchor="return-time")
            rt_err = (rt.table["alpha_onset"] - tr["alpha_at_onset"].reindex(rt.table.index)) / tr["apex"]
            rows.append({"return_time": float(rt_err.mean()), "return_time_sd": float(rt_err.std()),
                         "cam_phase": float(tab["anchor_err"].median()),
                         "phase_z": float(tab["phase_err"].median() / recon.cam_phase_stderr),
                         "excursion": float(tab["excursion_err"].mean()),
                         "excursion_sd": float(tab["excursion_err"].std()), "events": len(tab),
                         "contact_ms": float(tab["contact_ms"].median())})
        f = pd.DataFrame(rows)
        m = len(f)
        line = {"noise": case.noise * scale, "seeds": m,
                "return_time_mean": float(f["return_time"].mean()),
                "return_time_se": float(f["return_time"].std() / math.sqrt(m)),
                "return_time_event_sd": float(f["return_time_sd"].mean()),
                "cam_phase_mean": float(f["cam_phase"].mean()),
                "cam_phase_se": float(f["cam_phase"].std() / math.sqrt(m)),
                "phase_z_rms": float(np.sqrt(np.mean(f["phase_z"] ** 2))),
                "excursion_mean": float(f["excursion"].mean()),
                "excursion_se": float(f["excursion"].std() / math.sqrt(m)),
                "excursion_event_sd": float(f["excursion_sd"].mean()),
                "measured_contact_ms": float(f["contact_ms"].median())}
        print(f"anchor study: {_fmt(line)}", flush=True)
        out.append(line)
    return out


def _fit_summary(result, case: E.Case) -> dict:
    d = result.damping
    out = {"beta_error": d.beta / case.beta - 1.0, "beta_lo_rel": d.beta_interval[0] / case.beta - 1.0,
           "beta_hi_rel": d.beta_interval[1] / case.beta - 1.0,
           "boot_lo_rel": d.beta_bootstrap_interval[0] / case.beta - 1.0,
           "boot_hi_rel": d.beta_bootstrap_interval[1] / case.beta - 1.0,
           "indifference": d.indifference, "objective": d.objective, "events": int(len(d.per_event)),
           "covered": bool(d.beta_interval[0] <= case.beta <= d.beta_interval[1]),
           "half_widths": _half_widths(d.beta, d.beta_interval, case.beta),
           "phase_beta_rel_sd": d.phase_beta_sd / d.beta}
    if not d.fixed_n:
        out.update(n=d.n, n_error=d.n - case.n, n_interval=list(d.n_interval), separable=d.separable,
                   n_half_widths=_half_widths(d.n, d.n_interval, case.n), phase_n_sd=d.phase_n_sd)
    out["calibration"] = [dict(c) for c in result.calibration]
    check = dict(d.model_check or {})
    durations = dict(check.get("contact_duration") or {})
    pulse = dict(check.get("contact_pulse") or {})
    out["model_check"] = {"verdict": check.get("verdict"), "action": check.get("action"),
                          "duration": durations.get("verdict"),
                          "duration_measured_ms": 1e3 * durations.get("measured_median_s", math.nan),
                          "duration_replayed_ms": 1e3 * durations.get("replayed_median_s", math.nan),
                          "duration_model_ms": 1e3 * durations.get("model_median_s", math.nan),
                          "duration_difference": durations.get("median_relative_difference", math.nan),
                          "duration_difference_unreplayed": durations.get("simulated_relative_difference", math.nan),
                          "duration_threshold": durations.get("threshold", math.nan),
                          "pulse": pulse.get("verdict")}
    return out


def _half_widths(value, interval, truth) -> float:
    """Signed distance of the truth from the estimate in units of the interval's half-width on that side."""
    side = interval[1] - value if truth >= value else value - interval[0]
    return (truth - value) / side if side > 0 else math.inf


def run_fit(recs, case: E.Case, **options) -> dict:
    started = time.perf_counter()
    try:
        result, notes = _quiet(estimate, recs, **{**OPTIONS, **options})
    except Exception as exc:  # noqa: BLE001 - a refusal is an answer here
        return {"outcome": f"{type(exc).__name__}: {str(exc)[:300]}"}
    out = _fit_summary(result, case)
    out["seconds"] = round(time.perf_counter() - started, 1)
    out["notes"] = [m[:240] for m in notes if "bias of alpha_m" in m or "not separable" in m or "left out" in m]
    return out


def _fmt(d: dict) -> str:
    def one(v):
        if isinstance(v, float):
            return f"{v:.4g}"
        if isinstance(v, (list, tuple)):
            return "[" + ", ".join(one(x) for x in v) + "]"
        if isinstance(v, dict):
            return "{" + _fmt(v) + "}"
        return str(v)
    return ", ".join(f"{k} {one(v)}" for k, v in d.items())


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("case", nargs="?", help="case id, e.g. hc21 or np03 (general-motion cases: GENERAL_CASES)")
    parser.add_argument("--class", dest="klass", choices=sorted(GENERAL_CLASSES),
                        help="run the n-fixed fit of every general-motion case of a class and summarise")
    parser.add_argument("--check", action="store_true", help="verify the recording against the validation's")
    parser.add_argument("--motion", action="store_true")
    parser.add_argument("--events", action="store_true")
    parser.add_argument("--decompose", action="store_true")
    parser.add_argument("--fit", action="store_true")
    parser.add_argument("--joint", action="store_true")
    parser.add_argument("--seeds", type=int, default=0)
    parser.add_argument("--variants", action="store_true")
    parser.add_argument("--other-filter", type=float, nargs="+", default=[], metavar="CUTOFF",
                        help="decimated cases: the n-fixed fit through another anti-alias filter, cut off at these "
                             "fractions of the Nyquist frequency (other_filter_recording)")
    parser.add_argument("--anchor-study", type=int, default=0, metavar="K",
                        help="anchor and excursion errors over K noise seeds at --scales times the case's noise")
    parser.add_argument("--scales", type=float, nargs="+", default=[1.0, 0.5, 0.25])
    parser.add_argument("--keep-all", action="store_true")
    parser.add_argument("--calibration", action="store_true",
                        help="the pipeline bias impactid.rigs.pivoted.calibration measures at the true law, per "
                             "recording, "
                             "against the actual mean alpha_m error")
    parser.add_argument("--joint-oracle", nargs="+", default=[], metavar="SET",
                        help="joint fits (uncalibrated) on oracle event sets of both recordings: measured, "
                             "'true cam phase', 'true alpha_m', 'true onset state', 'both true'")
    parser.add_argument("--phase-scan", action="store_true",
                        help="n-fixed refits with the cam phase moved by -2..2 of its standard errors")
    parser.add_argument("--profile", action="store_true",
                        help="mean |lambda1| along beta (n fixed) for the measured and the oracle event sets")
    parser.add_argument("--factors", type=float, nargs="+", help="beta/true values of --profile (default 1e-3..30)")
    parser.add_argument("--anchor-margin", type=int, default=None, metavar="SAMPLES",
                        help="experiment: start the return-time anchor's free flight this many samples after the "
                             "detected separation and end it this many samples before the next onset "
                             "(impactid.rigs.pivoted.reconstruct.ANCHOR_MARGIN, default 8; the start is the later of "
                             "this and "
                             "--anchor-delay)")
    parser.add_argument("--anchor-delay", type=float, default=None, metavar="SECONDS",
                        help="experiment: the return-time anchor's free flight starts this long after the detected "
                             "separation (impactid.rigs.pivoted.reconstruct.ANCHOR_SEPARATION_DELAY, default 1.2e-3; "
                             "0 gives "
                             "the anchoring of the validation runs before the fix, 8 samples)")
    parser.add_argument("--anchor", default="cam-phase", help="anchor of the reconstructions and fits (experiment)")
    parser.add_argument("--residual", default="lambda1", help="residual of the --fit/--joint/--seeds fits (experiment)")
    parser.add_argument("--json", type=Path, help="also write the results here")
    args = parser.parse_args(argv)
    if args.klass:
        rows = run_class(args.klass)
        if args.json:
            args.json.write_text(json.dumps(rows, indent=1, default=lambda v: v.item() if hasattr(v, "item")
                                            else str(v)) + "\n")
        return 0
    if not args.case:
        parser.error("give a case id or --class")
    case = load_case(args.case)
    OPTIONS.update(anchor=args.anchor, residual=args.residual)
    if args.anchor_margin is not None:
        sys.modules["impactid.rigs.pivoted.reconstruct"].ANCHOR_MARGIN = int(args.anchor_margin)  # (the package exports
        # a function of the same name, so the module is taken from sys.modules)
    if args.anchor_delay is not None:
        sys.modules["impactid.rigs.pivoted.reconstruct"].ANCHOR_SEPARATION_DELAY = float(args.anchor_delay)
    pd.set_option("display.width", 200)
    pd.set_option("display.max_columns", 30)
    report: dict = {"case": case.id}
    print(f"{case.id}: {case.klass}, {case.generator}, e/r_c {case.e_over_rc}, {case.cam_speed_hz} Hz, "
          f"beta {case.beta:.4g}, n {case.n:.4f}, noise {case.noise:.4g}, ADC {case.adc_bits}, offset "
          f"{case.accel_offset:.3g}, drift {case.accel_drift:.3g}, {case.sample_rate_hz:g} Hz (q {case.decimation}), "
          f"v_a {case.approach_speed:.4g} / pair {case.pair_approach_speed:.4g} m/s", flush=True)
    clean, truth = clean_recording(case)
    rec = with_sensors(clean, case.sensors())
    if args.check and case.id in GENERAL_CASES:
        print("check: general-motion cases are not in the validation's cached cases")
    elif args.check:
        original, _ = E.make_recording(case)
        same = all(np.array_equal(original.channels[k], rec.channels[k]) for k in original.channels)
        print(f"check: the regenerated recording equals the validation's: {same}")
        report["check"] = same
    partner = partner_truth = None
    if case.pair and (args.joint or args.joint_oracle or args.decompose or args.calibration):
        pclean, partner_truth = clean_recording(case, case.pair)
        partner = with_sensors(pclean, case.sensors())
    points = [("recording 1", rec, truth, None)]
    if partner is not None:
        points.append(("recording 2", partner, partner_truth, case.pair))

    oracles: list[dict] = []
    if any((args.motion, args.events, args.decompose, args.keep_all, args.profile, args.phase_scan, args.joint_oracle,
            args.calibration)):
        for name, r, tr_, point in points:
            recon, es = reconstruction(r)
            tr = true_events(recon, tr_, case, point)
            if args.motion:
                m = motion(tr_, case, point)
                ratio = recon.table["hertz_ratio"].to_numpy(float)
                m.update(events=len(recon.table), events_used=len(es), hertz_ratio_median=float(np.nanmedian(ratio)),
                         hertz_ratio_range=[float(np.nanmin(ratio)), float(np.nanmax(ratio))],
                         measured_contact_ms=float(1e3 * recon.table["contact_duration"].median()))
                print(f"motion ({name}): {_fmt(m)}")
                report.setdefault("motion", {})[name] = m
            if args.events:
                tab = event_table(recon, tr)
                print(f"events ({name}):\n{tab.to_string(float_format=lambda x: f'{x:.4g}')}")
                rt, _ = _quiet(reconstruct, r, integration="rk", anchor="return-time")
                rt_err = (rt.table["alpha_onset"] - tr["alpha_at_onset"].reindex(rt.table.index)) / tr["apex"]
                summary = {"alpha_m_err_mean": float(tab["alpha_m_err"].mean()),
                           "alpha_m_err_median": float(tab["alpha_m_err"].median()),
                           "alpha_m_err_sd": float(tab["alpha_m_err"].std()),
                           "anchor_err_median": float(tab["anchor_err"].median()),
                           "excursion_err_mean": float(tab["excursion_err"].mean()),
                           "excursion_err_sd": float(tab["excursion_err"].std()),
                           "v_a_err_median": float(tab["v_a_err"].median()),
                           "dt_onset_us_median": float(tab["dt_onset_us"].median()),
                           "t_alpha_m_ms": [float(1e3 * recon.table["t_alpha_m"].min()),
                                            float(1e3 * recon.table["t_alpha_m"].max())],
                           "phase_err": float(tab["phase_err"].median()), "phase_stderr": recon.cam_phase_stderr,
                           "return_time_anchor_err_mean": float(rt_err.mean()),
                           "return_time_anchor_err_sd": float(rt_err.std())}
                print(f"  summary: {_fmt(summary)}")
                report.setdefault("events", {})[name] = summary
            if args.decompose and len(es):
                sets = oracle_sets(es, tr)
                s_meas = sensitivities(sets["measured"], case.beta, case.n)
                s_state = sensitivities(sets["true alpha_m"], case.beta, case.n)
                dec = {"lambda1_median": float(np.median(s_meas["lambda1"])),
                       "lambda1_from_onset_state": float(np.median(s_state["lambda1"])),
                       "lambda1_from_alpha_m": float(np.median(s_meas["lambda1"] - s_state["lambda1"])),
                       "d_lambda1_d_lnbeta": float(np.median(s_meas["d_lnbeta"])),
                       "d_lambda1_d_n": float(np.median(s_meas["d_n"]))}
                dec["implied_beta_shift"] = math.expm1(-dec["lambda1_median"] / dec["d_lambda1_d_lnbeta"])
                fits = {}
                for label, s in sets.items():
                    d, _ = _quiet(fit_contact_damping, [s], "lambda1", fix_n=case.n)
                    fits[label] = {"beta_error": d.beta / case.beta - 1.0,
                                   "interval_rel": [d.beta_interval[0] / case.beta - 1,
                                                    d.beta_interval[1] / case.beta - 1]}
                dec["oracle_fits_n_fixed_uncalibrated"] = fits
                print(f"decompose ({name}): {_fmt({k: v for k, v in dec.items() if not isinstance(v, dict)})}")
                for label, v in fits.items():
                    print(f"  oracle n-fixed fit, {label}: {_fmt(v)}")
                report.setdefault("decompose", {})[name] = dec
            if args.joint_oracle:
                oracles.append(oracle_sets(es, tr))
            if args.calibration:
                from impactid.contact import HuntCrossley
                from impactid.rigs.pivoted.calibration import pipeline_bias

                bias, _ = _quiet(pipeline_bias, r, HuntCrossley(case.beta, case.n))
                actual = event_table(recon, tr)["alpha_m_err"]
                cal = {"calibrated_bias": bias.alpha_m, "calibrated_stderr": bias.stderr, "events": bias.events,
                       "actual_alpha_m_err_mean": float(actual.mean()),
                       "actual_stderr": float(actual.std() / math.sqrt(actual.size))}
                print(f"calibration at the true law ({name}): {_fmt(cal)}", flush=True)
                report.setdefault("calibration", {})[name] = cal
            if args.phase_scan and name == "recording 1":
                report["phase_scan"] = phase_scan(es, case)
            if args.profile and name == "recording 1":
                report["profile"] = profile(oracle_sets(es, tr), case, args.factors)
            if args.keep_all and name == "recording 1":
                tab = recon.table.copy()
                tab["contact_consistent"] = True
                es_all = EventSet.from_reconstruction(replace(recon, table=tab), source="recording")
                k = {"events": len(es_all)}
                for residual in ("lambda1", "lambda2", "lambda3"):
                    try:
                        d, _ = _quiet(fit_contact_damping, [es_all], residual, fix_n=case.n)
                        k[residual] = {"beta_error": d.beta / case.beta - 1.0, "objective": d.objective,
                                       "interval_rel": [d.beta_interval[0] / case.beta - 1,
                                                        d.beta_interval[1] / case.beta - 1]}
                    except Exception as exc:  # noqa: BLE001 - a refusal is an answer here
                        k[residual] = {"outcome": f"{type(exc).__name__}: {str(exc)[:200]}"}
                s_all = sensitivities(es_all, case.beta, case.n)
                k.update(lambda1_at_truth_median=float(np.median(s_all["lambda1"])),
                         d_lambda1_d_lnbeta=float(np.median(s_all["d_lnbeta"])))
                print(f"keep-all n-fixed fits (uncalibrated): {_fmt(k)}")
                report["keep_all"] = k
        if args.decompose and len(report.get("decompose", {})) == 2:
            d1, d2 = report["decompose"]["recording 1"], report["decompose"]["recording 2"]
            a = np.array([[d["d_lambda1_d_lnbeta"], d["d_lambda1_d_n"]] for d in (d1, d2)])
            b = -np.array([d1["lambda1_median"], d2["lambda1_median"]])
            x = np.linalg.solve(a, b)
            joint = {"lnbeta_shift": float(x[0]), "beta_shift": math.expm1(float(x[0])), "n_shift": float(x[1]),
                     "condition_number": float(np.linalg.cond(a))}
            print(f"linearised joint shift from the per-recording lambda1 at the truth: {_fmt(joint)}")
            report["joint_linearised"] = joint

    for label in args.joint_oracle:
        d, _ = _quiet(fit_contact_damping, [o[label] for o in oracles], "lambda1")
        out = {"beta_error": d.beta / case.beta - 1.0, "n_error": d.n - case.n,
               "beta_interval_rel": [d.beta_interval[0] / case.beta - 1, d.beta_interval[1] / case.beta - 1],
               "n_interval": list(d.n_interval), "objective": d.objective, "separable": d.separable}
        print(f"joint oracle fit (uncalibrated), {label}: {_fmt(out)}", flush=True)
        report.setdefault("joint_oracle", {})[label] = out
    if args.fit:
        for label, calibrate in (("as validated", True), ("uncalibrated", False)):
            out = run_fit([rec], case, fix_n=case.n, calibrate=calibrate)
            print(f"n-fixed fit {label}: {_fmt({k: v for k, v in out.items() if k != 'notes'})}")
            for note in out.get("notes", []):
                print(f"    note: {note}")
            report.setdefault("fit", {})[label] = out
    if args.joint and partner is not None:
        for label, calibrate in (("as validated", True), ("uncalibrated", False)):
            out = run_fit([rec, partner], case, calibrate=calibrate)
            print(f"joint fit {label}: {_fmt({k: v for k, v in out.items() if k != 'notes'})}", flush=True)
            report.setdefault("joint", {})[label] = out
    if args.seeds:
        rows = []
        for k in range(args.seeds + 1):
            sensors = replace(case.sensors(), seed=case.seed + SEED_STEP * k)
            r = with_sensors(clean, sensors)
            out = run_fit([r], case, fix_n=case.n)
            recon, _ = reconstruction(r)
            tr = true_events(recon, truth, case)
            err = recon.table["alpha_m"] / tr["apex"] - 1.0
            cal = out.get("calibration") or [{}]
            tab = event_table(recon, tr)
            rows.append({"seed": sensors.seed, "beta_error": out.get("beta_error", math.nan),
                         "lo": out.get("beta_lo_rel", math.nan), "hi": out.get("beta_hi_rel", math.nan),
                         "covered": out.get("covered"), "half_widths": out.get("half_widths", math.nan),
                         "alpha_m_err_mean": float(err.mean()), "alpha_m_err_median": float(err.median()),
                         "anchor_err": float(tab["anchor_err"].median()),
                         "excursion_err_mean": float(tab["excursion_err"].mean()),
                         "phase_z": float(tab["phase_err"].median() / recon.cam_phase_stderr),
                         "calibrated_bias": cal[0].get("alpha_m", math.nan), "outcome": out.get("outcome", "estimate")})
            print(f"seed {sensors.seed}: {_fmt(rows[-1])}", flush=True)
        frame = pd.DataFrame(rows)
        ok = frame[frame["outcome"] == "estimate"]
        summary = {"realisations": len(frame), "estimates": len(ok), "coverage": float(ok["covered"].mean()),
                   "anchor_err_mean": float(ok["anchor_err"].mean()),
                   "excursion_err_mean": float(ok["excursion_err_mean"].mean()),
                   "excursion_err_sd_of_means": float(ok["excursion_err_mean"].std()),
                   "phase_z_rms": float(np.sqrt(np.mean(ok["phase_z"] ** 2))),
                   "beta_error_mean": float(ok["beta_error"].mean()), "beta_error_sd": float(ok["beta_error"].std()),
                   "half_widths_median": float(ok["half_widths"].median()),
                   "alpha_m_err_mean": float(ok["alpha_m_err_mean"].mean()),
                   "calibrated_bias_mean": float(ok["calibrated_bias"].mean())}
        print(f"seeds summary: {_fmt(summary)}")
        report["seeds"] = {"rows": rows, "summary": summary}
    if args.anchor_study:
        report["anchor_study"] = anchor_study(clean, truth, case, args.anchor_study, args.scales)
    if args.variants:
        base = case.sensors()
        variants = {"as drawn": base,
                    "noise only": replace(base, adc_bits=None, accel_offset=0.0, accel_drift=0.0),
                    "ADC only": replace(base, noise=0.0, accel_offset=0.0, accel_drift=0.0),
                    "offset and drift only": replace(base, noise=0.0, adc_bits=None),
                    "noise, ADC, no offset or drift": replace(base, accel_offset=0.0, accel_drift=0.0),
                    "none": replace(base, noise=0.0, adc_bits=None, accel_offset=0.0, accel_drift=0.0)}
        for label, sensors in variants.items():
            if label != "as drawn" and sensors == base:
                continue
            r = with_sensors(clean, sensors)
            out = run_fit([r], case, fix_n=case.n)
            out.pop("notes", None)
            print(f"variant {label}: {_fmt(out)}", flush=True)
            report.setdefault("variants", {})[label] = out
        if case.decimation > 1:
            plain = replace(case, decimation=1, noise=0.0, adc_bits=None, accel_offset=0.0, accel_drift=0.0)
            r, _ = E.make_recording(plain)
            out = run_fit([r], case, fix_n=case.n)
            out.pop("notes", None)
            print(f"variant same rate, no anti-alias filter: {_fmt(out)}", flush=True)
            report.setdefault("variants", {})["no anti-alias filter"] = out
            full = replace(plain, sample_rate_hz=204_800.0)
            r, _ = E.make_recording(full)
            out = run_fit([r], case, fix_n=case.n)
            out.pop("notes", None)
            print(f"variant 204.8 kHz: {_fmt(out)}", flush=True)
            report.setdefault("variants", {})["204.8 kHz"] = out
    for cutoff in args.other_filter:
        r = other_filter_recording(case, cutoff)
        out = run_fit([r], case, fix_n=case.n)
        out.pop("notes", None)
        print(f"another anti-alias filter (Kaiser beta {OTHER_FILTER_BETA:g}, {OTHER_FILTER_LENGTH} output samples, "
              f"cut off at {cutoff:g} of the Nyquist frequency): {_fmt(out)}", flush=True)
        report.setdefault("other_filter", {})[str(cutoff)] = out
    if args.json:
        args.json.write_text(json.dumps(report, indent=1, default=lambda v: v.item() if hasattr(v, "item") else str(v))
                             + "\n")
    return 0


#: The other anti-alias filter of ``--other-filter``: a Kaiser-windowed FIR of this beta and this many output
#: samples (the envelope's, ``scipy.signal.resample_poly``'s default, has beta 5 and 20).
OTHER_FILTER_BETA = 8.0
OTHER_FILTER_LENGTH = 40


def other_filter_recording(case: E.Case, cutoff: float):
    """The accelerometer of ``case``'s motion (noise-free) at the case's rate through another linear-phase
    anti-alias filter than the envelope's: the case's generator at ``decimation`` times the rate, low-passed by a
    Kaiser FIR (:data:`OTHER_FILTER_BETA`, :data:`OTHER_FILTER_LENGTH` output samples) cut off at ``cutoff`` of
    the output's Nyquist frequency, and decimated (the calibration and the model check assume the envelope's)."""
    q = int(case.decimation)
    if q < 2:
        raise SystemExit(f"--other-filter needs a decimated case; {case.id} is recorded at its rate directly")
    fine, _ = E.make_recording(replace(case, decimation=1, sample_rate_hz=case.sample_rate_hz * q, noise=0.0,
                                       adc_bits=None, accel_offset=0.0, accel_drift=0.0))
    taps = signal.firwin(OTHER_FILTER_LENGTH * q + 1, cutoff / q, window=("kaiser", OTHER_FILTER_BETA))
    accel = signal.resample_poly(np.asarray(fine["accel_tangential"], dtype=float), 1, q, window=taps)
    return Recording(channels={"accel_tangential": accel}, sample_rate_hz=case.sample_rate_hz,
                     units={"accel_tangential": fine.units["accel_tangential"]}, rig=fine.rig,
                     operating=dict(fine.operating), start_time_s=fine.start_time_s,
                     source=f"{case.id} through another filter")


if __name__ == "__main__":
    sys.exit(main())

"""The period-1 envelope of rig P: validation cases drawn across it, run through impactid as a user would.

Used by ``benchmarks/validate_envelope.py`` (the full envelope, written to
``docs/validation_envelope.md``) and by ``tests/test_envelope.py`` (a fast subset in the test suite).

A case is one operating point of the rig P of Sundar, Dreyer & Singh (2016) with a contact law
(Hunt–Crossley ``beta, n``, or a restitution law ``xi = 1 - gamma v_a``) and an acquisition chain.
Its operating point lies where impactid's own regime classification finds period-1 motion (one
impact per cam revolution) for that law; the recording is made either by impactid's generator
(``impactid.synth``) or by the independent SciPy reference model (``tests/rigs/pivoted/reference_recordings.py``),
whose steady state is found by shooting, so that a bias shared by the estimator and the generator
cannot cancel. Each Hunt–Crossley case is paired with a second period-1 point of the same rig and
law whose approach speed differs by at least 30 %, for a joint fit of ``beta`` and ``n``.

Every fit is run through :func:`impactid.pipeline.estimate` (what ``impactid estimate`` calls) and
ends in one of three outcomes: an *estimate* (numbers with intervals), a *refusal* (an
:class:`~impactid.errors.ImpactidError` naming the reason: the tool says it cannot answer), or an
*error* (any other exception: a bug; the target is none). Nothing here passes the truth to the
estimator: the truth is kept beside the recording and read only to score the result.
"""

from __future__ import annotations

import math
import time
import traceback
import warnings
from dataclasses import asdict, dataclass, field

import numpy as np

from impactid import SUNDAR2016, HuntCrossley, Restitution
from impactid.errors import ImpactidError
from impactid.rigs.pivoted.synth import synth_pivoted
from impactid.synth import SensorModel
from tests.rigs.pivoted import reference_recordings as RR  # the benchmarks put the repository root on sys.path
from tests.rigs.pivoted import reference_rigp as RP

#: Classes of the envelope, and what sets each apart (the other factors at their clean values).
CLASSES = ("noise-free", "noisy", "friction", "low-rate", "S3")
#: Cam speeds [Hz] tried for period-1 motion (impactid's regime classification per law).
SPEED_GRID = np.arange(6.0, 24.01, 0.5)
E_OVER_RC = (0.05, 0.30)
BETA = (5e9, 1e11)
N_EXPONENT = (1.2, 1.8)
GAMMA = (0.3, 1.2)
NOISE = (0.001, 0.01)
#: Smallest relative difference of approach speed between the two points of a joint fit.
PAIR_SPREAD = 0.30
SETTLE_S = 40.0


@dataclass(frozen=True)
class Case:
    """One validation case (all SI; ``beta`` in N s m^-(n+1), ``gamma`` in s/m)."""

    id: str
    klass: str
    e_over_rc: float
    cam_speed_hz: float
    beta: float = math.nan
    n: float = math.nan
    gamma: float = math.nan
    mu: float = 0.0
    noise: float = 0.0
    sample_rate_hz: float = 204_800.0
    decimation: int = 1
    adc_bits: int = 24
    accel_offset: float = 0.0
    accel_drift: float = 0.0
    generator: str = "impactid"
    seed: int = 0
    duration: float = 1.0
    pair: tuple[float, float] | None = None
    approach_speed: float = math.nan
    pair_approach_speed: float = math.nan

    @property
    def law(self):
        return Restitution(gamma=self.gamma) if self.klass == "S3" else HuntCrossley(self.beta, self.n)

    def sensors(self) -> SensorModel:
        return SensorModel(noise=self.noise, adc_bits=self.adc_bits, accel_offset=self.accel_offset,
                           accel_drift=self.accel_drift, decimation=self.decimation, seed=self.seed)


def left_out_of_joint_fit(notes) -> bool:
    """Whether a joint fit's notes say that a recording was left out of it (``impactid.rigs.pivoted.estimation``'s
    note of a partial fit: the other recordings' fit, the unusable one named)."""
    return any("left out of the joint fit" in note for note in notes)


def _period1(e_over_rc: float, cam_speed_hz: float, law, mu: float) -> bool:
    from impactid.rigs.pivoted.regimes import classify_regime

    try:
        r = classify_regime(SUNDAR2016.with_eccentricity_ratio(e_over_rc), cam_speed_hz, law, mu=mu,
                            max_revolutions=1500)
    except ImpactidError:
        return False
    return r.regime == "period-1" and r.impacts_per_revolution == 1.0 and not r.settling


def _approach_speed(e_over_rc: float, cam_speed_hz: float, law, mu: float) -> float:
    """Approach speed [m/s] of the settled period-1 motion (impactid's simulator; case selection only)."""
    from impactid.rigs.pivoted.runs import simulate

    run = simulate(SUNDAR2016.with_eccentricity_ratio(e_over_rc), cam_speed_hz, law, SETTLE_S + 0.3, mu=mu)
    rows = run.contacts[run.contacts["kind"] != "stick"]
    return float(-rows["gap_rate_start"].to_numpy()[-1])


def _period1_point(rng, law, mu, e_range=E_OVER_RC, avoid_speed=None):
    """A random (e/r_c, cam speed) with period-1 motion for ``law``; ``avoid_speed`` asks for an
    approach speed at least :data:`PAIR_SPREAD` away from it. Returns (e, f, v_a) or None."""
    for _ in range(8):
        e = float(rng.uniform(*e_range))
        for f in rng.permutation(SPEED_GRID)[:12]:
            if not _period1(e, float(f), law, mu):
                continue
            va = _approach_speed(e, float(f), law, mu)
            if avoid_speed is not None and abs(va - avoid_speed) < PAIR_SPREAD * min(va, avoid_speed):
                continue
            return round(e, 4), float(f), va
    return None


def draw_cases(n_hc: int = 60, n_s3: int = 15, seed: int = 2026, progress=None) -> list[Case]:
    """Cases across the period-1 envelope (fixed seed: the same cases every run).

    Hunt–Crossley cases cycle through the classes noise-free, noisy, friction and low-rate; every
    third case (and at least a third in all) is recorded by the independent reference model. Only
    the noisy class has a 16-24 bit ADC (its quantisation is noise too, about 1e-5 of the peak at
    16 bits); the others a 24-bit one, so that each class isolates its factor.
    """
    rng = np.random.default_rng(seed)
    cases: list[Case] = []
    hc_classes = CLASSES[:4]
    k = 0
    while len([c for c in cases if c.klass != "S3"]) < n_hc:
        klass = hc_classes[k % 4]
        beta = float(math.exp(rng.uniform(math.log(BETA[0]), math.log(BETA[1]))))
        n = float(rng.uniform(*N_EXPONENT))
        mu = 0.2 if klass == "friction" else 0.0
        law = HuntCrossley(beta, n)
        first = _period1_point(rng, law, mu)
        k += 1
        if first is None:
            continue
        second = _period1_point(rng, law, mu, avoid_speed=first[2])
        if second is None:
            continue
        extra = {}
        if klass == "noisy":
            extra = dict(noise=float(rng.uniform(*NOISE)), adc_bits=int(rng.integers(16, 25)),
                         accel_offset=float(rng.uniform(-2, 2)), accel_drift=float(rng.uniform(-0.5, 0.5)))
        elif klass == "low-rate":
            q = int(rng.choice([2, 4]))
            rng.integers(16, 25)  # (drawn and unused: keeps the paper's cases)
            extra = dict(decimation=q, sample_rate_hz=204_800.0 / q, adc_bits=24)
        else:
            rng.integers(16, 25)
            extra = dict(adc_bits=24)
        index = len(cases)
        cases.append(Case(id=f"hc{index:02d}", klass=klass, e_over_rc=first[0], cam_speed_hz=first[1], beta=beta, n=n,
                          mu=mu, generator="reference" if index % 3 == 0 else "impactid", seed=1000 + index,
                          pair=(second[0], second[1]), approach_speed=first[2], pair_approach_speed=second[2],
                          **extra))
        if progress:
            progress(len(cases), n_hc + n_s3)
    while len([c for c in cases if c.klass == "S3"]) < n_s3:
        gamma = float(rng.uniform(*GAMMA))
        law = Restitution(gamma=gamma)
        point = _period1_point(rng, law, 0.0)
        if point is None:
            continue
        index = len(cases)
        rng.integers(16, 25)
        cases.append(Case(id=f"s3{index:02d}", klass="S3", e_over_rc=point[0], cam_speed_hz=point[1], gamma=gamma,
                          generator="reference" if index % 3 == 0 else "impactid", seed=1000 + index,
                          approach_speed=point[2], adc_bits=24))
        if progress:
            progress(len(cases), n_hc + n_s3)
    return cases


def make_recording(case: Case, point: tuple[float, float] | None = None):
    """The recording of ``case`` at its operating point (or at ``point``) and its truth dict."""
    e_over_rc, cam_speed = point if point is not None else (case.e_over_rc, case.cam_speed_hz)
    sensors = case.sensors()
    if case.generator == "reference":
        law = ({"kind": "restitution", "gamma": case.gamma, "xi0": 1.0} if case.klass == "S3"
               else {"kind": "hunt-crossley", "beta": case.beta, "n": case.n})
        p = RP.reference_params(e_over_rc)
        orbit = RR.periodic_orbit(p, cam_speed, law, mu=case.mu)
        rec, truth = RR.reference_recording(e_over_rc, cam_speed, law, mu=case.mu, duration=case.duration,
                                            sample_rate_hz=case.sample_rate_hz, sensors=sensors,
                                            start_time_s=SETTLE_S, orbit=orbit)
        return rec, truth
    synthetic = synth_pivoted(SUNDAR2016.with_eccentricity_ratio(e_over_rc), cam_speed, case.law, case.duration,
                              settle_s=SETTLE_S, sample_rate_hz=case.sample_rate_hz, sensors=sensors, mu=case.mu)
    return synthetic.recording, synthetic.truth


@dataclass
class Outcome:
    """What one fit ended in: ``status`` "estimate", "refusal" or "error", with the values scored."""

    fit: str
    status: str
    reason: str = ""
    values: dict = field(default_factory=dict)
    seconds: float = 0.0


def _fit(name: str, recordings, **options) -> tuple[Outcome, object]:
    from impactid.pipeline import estimate

    started = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            result = estimate(recordings, **options)
    except ImpactidError as exc:
        return Outcome(name, "refusal", reason=str(exc), seconds=time.perf_counter() - started), None
    except Exception:  # noqa: BLE001 - an unexplained error is what this validation counts
        return Outcome(name, "error", reason=traceback.format_exc(limit=3),
                       seconds=time.perf_counter() - started), None
    return Outcome(name, "estimate", seconds=time.perf_counter() - started), result


def run_case(case: Case, joint: bool = True) -> dict:
    """Run the fits of a case; returns a flat dict of the case, its outcomes and their scores."""
    row = {k: v for k, v in asdict(case).items() if k != "pair"}
    row["pair_e_over_rc"], row["pair_cam_speed_hz"] = case.pair if case.pair else (math.nan, math.nan)
    outcomes = []
    try:
        rec, truth = make_recording(case)
        partner = make_recording(case, case.pair)[0] if (joint and case.pair) else None
    except Exception as exc:  # noqa: BLE001 - the generator refusing a case is not impactid's error
        row["generation"] = f"{type(exc).__name__}: {exc}"
        row["outcomes"] = []
        return row
    row["generation"] = "ok"
    if case.klass == "S3":
        out, result = _fit("restitution", [rec], fix_n=1.5)
        if result is not None:
            r = result.restitution
            if r is None:
                out.status, out.reason = "refusal", "; ".join(w for w in result.warnings if "restitution" in w)
            else:
                out.values = {"gamma": r.gamma, "gamma_stderr": r.gamma_stderr,
                              "gamma_error": r.gamma / case.gamma - 1.0,
                              "gamma_covered": bool(abs(r.gamma - case.gamma) <= 1.96 * r.gamma_stderr)}
        outcomes.append(out)
    else:
        out, result = _fit("n-fixed", [rec], fix_n=case.n)
        if result is not None:
            d = result.damping
            out.values = {"beta": d.beta, "beta_lo": d.beta_interval[0], "beta_hi": d.beta_interval[1],
                          "beta_error": d.beta / case.beta - 1.0,
                          "beta_covered": bool(d.beta_interval[0] <= case.beta <= d.beta_interval[1]),
                          "failed_simulations": d.n_failed_simulations,
                          "verdict": str((d.model_check or {}).get("verdict", "not checked")),
                          "determined": bool(dict(d.identifiability or {}).get("determined", True))}
            r = result.restitution
            outcomes.append(Outcome("restitution", "estimate" if r is not None else "refusal",
                                    reason="" if r is not None else "no impact with a determined xi",
                                    values={} if r is None else {"gamma": r.gamma, "xi_mean": r.xi_mean}))
        outcomes.insert(0, out)
        if joint and partner is not None:
            out, result = _fit("joint", [rec, partner])
            if result is not None:
                d = result.damping
                out.values = {"beta": d.beta, "n": d.n, "beta_lo": d.beta_interval[0], "beta_hi": d.beta_interval[1],
                              "n_lo": d.n_interval[0], "n_hi": d.n_interval[1], "separable": d.separable,
                              "beta_error": d.beta / case.beta - 1.0, "n_error": d.n - case.n,
                              "beta_covered": bool(d.beta_interval[0] <= case.beta <= d.beta_interval[1]),
                              "n_covered": bool(d.n_interval[0] <= case.n <= d.n_interval[1]),
                              "failed_simulations": d.n_failed_simulations,
                              "verdict": str((d.model_check or {}).get("verdict", "not checked")),
                              "determined": bool(dict(d.identifiability or {}).get("determined", True)),
                              "left_out": left_out_of_joint_fit(tuple(result.warnings) + tuple(d.warnings))}
                if not d.separable:
                    out.reason = "not separable: " + next((w for w in d.warnings if "not separable" in w), "")
            outcomes.append(out)
    row["outcomes"] = [asdict(o) for o in outcomes]
    return row

"""A fast subset of the period-1 envelope validation (the full one: benchmarks/validate_envelope.py).

Each case names the failure class it guards against (the robustness issue's list): a trial law
that chatters or cannot be simulated must not stop a fit; a tensile contact tail must not hide the
separation; a restitution failure must not take the damping estimate with it; an operating point
where a follower angle meets the cam on both of its sides (two closing roots) must pick the right
one; an independent generator, a lower sample rate, friction, noise and the restitution model
must all end in an estimate within the envelope's targets (or an interval that holds the truth).
"""

from __future__ import annotations

import math

import pytest

from tests.envelope import Case, run_case


def _fit(row, name):
    outcome = next(o for o in row["outcomes"] if o["fit"] == name)
    assert outcome["status"] != "error", outcome["reason"]
    return outcome


CASES = [
    # the paper's measured operating point: a law with n < 1.5 pulls before the gap reopens
    Case(id="paper-point", klass="noise-free", e_over_rc=0.13, cam_speed_hz=14.05, beta=29.3e9, n=1.45),
    # independent generator (SciPy reference model, steady state by shooting)
    Case(id="reference", klass="noise-free", e_over_rc=0.086, cam_speed_hz=14.0, beta=2.3167e10, n=1.7703,
         generator="reference", adc_bits=23),
    # 102.4 kHz after the anti-alias filter
    Case(id="low-rate", klass="low-rate", e_over_rc=0.2, cam_speed_hz=16.0, beta=24.7e9, n=1.5, decimation=2,
         sample_rate_hz=102_400.0),
    # friction, at a cam speed where the onset angle meets the cam with a closing gap on both sides
    Case(id="two-roots-friction", klass="friction", e_over_rc=0.2408, cam_speed_hz=9.5, beta=6.2258e9, n=1.3547,
         mu=0.2),
    # a heavily damped law: trial laws around it chatter
    Case(id="heavy-damping", klass="noise-free", e_over_rc=0.1, cam_speed_hz=13.0, beta=9e10, n=1.8),
]


#: the case the fast loop (``pytest -m "not slow"``) keeps: the paper's measured operating point
FAST_CASES = ("paper-point",)


@pytest.mark.parametrize("case", [pytest.param(c, id=c.id, marks=() if c.id in FAST_CASES else pytest.mark.slow)
                                  for c in CASES])
def test_n_fixed_fit_within_one_percent(case):
    row = run_case(case, joint=False)
    assert row["generation"] == "ok", row["generation"]
    out = _fit(row, "n-fixed")
    assert out["status"] == "estimate", out["reason"]
    assert abs(out["values"]["beta_error"]) <= 0.01, out["values"]
    restitution = _fit(row, "restitution")  # xi is determined wherever the gap reopens (noise-free)
    assert restitution["status"] == "estimate", restitution["reason"]


@pytest.mark.slow
def test_noisy_interval_holds_the_truth():
    case = Case(id="noisy", klass="noisy", e_over_rc=0.2, cam_speed_hz=16.0, beta=24.7e9, n=1.5, noise=0.005,
                adc_bits=16, accel_offset=1.2, accel_drift=-0.3, seed=7)
    out = _fit(run_case(case, joint=False), "n-fixed")
    assert out["status"] == "estimate"
    assert out["values"]["beta_covered"], out["values"]


@pytest.mark.slow
def test_restitution_case_within_two_percent():
    case = Case(id="s3", klass="S3", e_over_rc=0.1823, cam_speed_hz=15.0, gamma=0.9965, adc_bits=17)
    out = _fit(run_case(case), "restitution")
    assert out["status"] == "estimate" and abs(out["values"]["gamma_error"]) <= 0.02, out["values"]


@pytest.mark.slow
def test_joint_fit_whose_trial_laws_chatter():
    """e/r_c 0.25 at 15 Hz with 0.05 at 16 Hz: heavily damped trial laws chatter with more than 64
    contacts in one event; the fit goes on and recovers beta and n."""
    case = Case(id="joint", klass="noise-free", e_over_rc=0.25, cam_speed_hz=15.0, beta=24.7e9, n=1.5,
                pair=(0.05, 16.0))
    out = _fit(run_case(case), "joint")
    assert out["status"] == "estimate", out["reason"]
    values = out["values"]
    assert values["separable"] and abs(values["beta_error"]) <= 0.05 and abs(values["n_error"]) <= 0.02, values
    assert math.isfinite(values["beta"])

"""The interval of rig P's beta: the cam phase's quantile, its combination with the statistical interval, and
the coverage study's expected count of confident wrong answers (benchmarks/validate_coverage.py)."""

from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from scipy import stats

from impactid.rigs.pivoted.damping_least_squares import combine_phase, phase_quantiles

ROOT = Path(__file__).resolve().parents[3]


class _Set:
    def __init__(self, m: int, phase_stderr: float):
        self.m, self.phase_stderr = m, phase_stderr

    def __len__(self) -> int:
        return self.m


def test_phase_quantile_is_student_t_with_the_events_less_one_degrees_of_freedom():
    problem = SimpleNamespace(sets=[_Set(14, 3e-3), _Set(40, math.nan), _Set(2, 1e-3)])
    z = phase_quantiles(problem)
    assert len(z) == 2  # one per recording with a phase error, in order
    assert z[0] == pytest.approx(stats.t.ppf(0.975, 13)) and z[0] == pytest.approx(2.160, abs=1e-3)
    assert z[1] == pytest.approx(stats.t.ppf(0.975, 1))
    many = phase_quantiles(SimpleNamespace(sets=[_Set(10_000, 1e-3)]))
    assert many[0] == pytest.approx(1.96, abs=1e-3)  # the normal quantile in the limit


def test_combine_phase_adds_the_phase_to_the_statistical_half_widths_and_the_systematic_in_quadrature():
    lo, hi = combine_phase((-0.01, 0.02), 0.0, (0.03, 0.04), 0.0)
    assert (lo, hi) == pytest.approx((-0.04, 0.06))
    lo, hi = combine_phase((-0.01, 0.02), 0.0, (0.02, 0.02), 0.04)
    assert (lo, hi) == pytest.approx((-0.05, 0.04 * math.sqrt(2.0)))
    assert combine_phase((1.0, 2.0), 1.5, (0.0, 0.0), 0.0) == pytest.approx((1.0, 2.0))  # nothing to add


def test_adding_the_half_widths_covers_correlated_errors_that_quadrature_does_not():
    # e = e_s + e_phi with correlation 0.5 (measured 0.45 at the coverage study's P2): quadrature under-covers
    rng = np.random.default_rng(5)
    s_s, s_phi, rho = 0.0045, 0.015, 0.5
    cov = [[s_s ** 2, rho * s_s * s_phi], [rho * s_s * s_phi, s_phi ** 2]]
    e = rng.multivariate_normal([0.0, 0.0], cov, size=200_000).sum(axis=1)
    quad = 1.96 * math.hypot(s_s, s_phi)
    _, linear = combine_phase((-1.96 * s_s, 1.96 * s_s), 0.0, (1.96 * s_phi, 1.96 * s_phi), 0.0)
    assert np.mean(np.abs(e) <= quad) < 0.93
    assert np.mean(np.abs(e) <= linear) >= 0.95


def _validate_coverage():
    spec = importlib.util.spec_from_file_location("validate_coverage", ROOT / "benchmarks" / "validate_coverage.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("validate_coverage", module)  # its dataclass looks itself up there
    spec.loader.exec_module(module)
    return module


def test_expected_confident_wrong_is_the_normal_tail_beyond_both_the_margin_and_the_interval():
    vc = _validate_coverage()
    truth = vc.BETA
    z = stats.norm.ppf(0.975)
    # a narrow interval (standard error 1 %): a 5 % error is 5 standard errors away
    p = vc.expected_confident_wrong([truth], [truth * math.exp(-z * 0.01)], [truth * math.exp(z * 0.01)])
    tails = stats.norm.sf(math.log(1.05) / 0.01) + stats.norm.cdf(math.log(0.95) / 0.01)
    assert p[0] == pytest.approx(tails, rel=1e-9)
    assert p[0] < 1e-5
    # a wide one (standard error 4 %): every miss of the interval is beyond 5 %, so the probability is 5 %
    p = vc.expected_confident_wrong([truth], [truth * math.exp(-z * 0.04)], [truth * math.exp(z * 0.04)])
    assert p[0] == pytest.approx(0.05, rel=1e-6)
    # the counts of a calibrated simulation agree with the sum of the probabilities
    rng = np.random.default_rng(1)
    se = rng.uniform(0.01, 0.04, 20_000)
    x = rng.normal(0.0, se)
    beta = truth * np.exp(x)
    lo, hi = beta * np.exp(-z * se), beta * np.exp(z * se)
    wrong = (np.abs(beta / truth - 1.0) > 0.05) & ((truth < lo) | (truth > hi))
    expected = np.sum(vc.expected_confident_wrong(beta, lo, hi))
    assert wrong.sum() == pytest.approx(expected, rel=0.1)

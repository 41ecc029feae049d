"""The engine's model check (impactid.engine.checks): scatter against a noise reference, the chi-square
lack-of-fit statistic, the structure tests (trend, alternation, persistence, groups), the verdicts and
what a fit does about them (widen, withhold)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from impactid.engine import (
    GROSS_LACK_OF_FIT,
    NO_NOISE_REFERENCE,
    Free,
    check_model,
    combine_checks,
    governing_check,
    search,
    uncertainty,
)
from impactid.engine.checks import widen_interval
from impactid.results import Parameter
from tests.test_engine import MISRA1A_X, _misra


def test_white_noise_at_its_reference_is_consistent():
    rng = np.random.default_rng(3)
    r = rng.normal(0.0, 0.2, 2000)
    check = check_model(r, 0.2, noise_reference="between impacts", what="force", unit="N", n_params=3)
    assert check.verdict == "consistent" and check.describes_data and check.action == "none"
    assert check.residual_over_noise == pytest.approx(1.0, abs=0.03)
    assert check.chi_square == pytest.approx(float(np.sum((r / 0.2) ** 2)), rel=1e-12)
    assert check.chi_square_p_value == pytest.approx(float(stats.chi2.sf(check.chi_square, 1997)), rel=1e-12)
    assert 0.01 < check.chi_square_p_value < 0.99 and check.dof == 1997
    # independent residuals: about as many independent pieces as residuals, no alternation
    assert check.effective_samples > 1800 and abs(check.lag1_z) < 3.0 and not check.notes


def test_a_smooth_misfit_far_above_the_noise_is_withheld():
    rng = np.random.default_rng(4)
    t = np.linspace(0.0, 1.0, 1440)
    r = 0.5 * np.sin(2 * np.pi * 3 * t) + rng.normal(0.0, 0.1, t.size)  # 3.6 times the noise, smooth
    check = check_model(r, 0.1, noise_reference="revolutions' scatter", what="lift", unit="m", n_params=2,
                        assumed_sd=float(np.sqrt(np.mean(r**2))))
    assert check.verdict == "lack of fit" and check.residual_over_noise > GROSS_LACK_OF_FIT
    assert check.lag1_autocorrelation > 0.9 and check.effective_samples < 0.05 * r.size
    assert check.action == "withheld" and any("withheld" in n for n in check.notes)
    p = Parameter("k", 2.0, 0.01, (1.98, 2.02), unit="N/m")
    (out,) = check.widen([p])
    assert math.isnan(out.stderr) and math.isnan(out.interval[0]) and "withheld" in out.note and out.value == 2.0
    assert math.isnan(check.widen_stderr(0.01))


def test_a_systematic_misfit_below_the_lack_of_fit_level_widens_by_the_rule():
    rng = np.random.default_rng(5)
    t = np.linspace(0.0, 1.0, 4000)
    r = 0.08 * np.sin(2 * np.pi * 2 * t) + rng.normal(0.0, 0.1, t.size)
    # a covariance scaled by the noise (known scale): the variance factor is the residual's over the noise's
    check = check_model(r, 0.1, noise_reference="between impacts", what="acceleration", n_params=2,
                        assumed_over_noise=1.0)
    assert check.verdict == "systematic misfit" and check.action == "widened"
    ratio = check.residual_over_noise
    expected = ratio * math.sqrt(r.size / check.effective_samples)
    assert check.inflation == pytest.approx(expected, rel=1e-12) and check.inflation > ratio
    # a covariance scaled by the residual variance already holds the variance factor
    again = check_model(r, 0.1, noise_reference="between impacts", what="acceleration", n_params=2,
                        assumed_over_noise=ratio)
    assert again.inflation == pytest.approx(math.sqrt(r.size / again.effective_samples), rel=1e-12)
    p = Parameter("beta", 5.0, 0.1, (4.8, 5.2))
    (out,) = again.widen([p])
    f = again.inflation
    assert out.stderr == pytest.approx(0.1 * f) and out.interval == pytest.approx((5.0 - 0.2 * f, 5.0 + 0.2 * f))
    assert "widened" in out.note


def test_widen_interval_in_the_logarithm_for_a_log_symmetric_interval():
    lo, hi = widen_interval((2.0, 8.0), 4.0, 2.0)  # symmetric in log: x / 2 .. x * 2
    assert (lo, hi) == pytest.approx((1.0, 16.0))
    assert widen_interval((3.0, 6.0), 4.0, 2.0) == pytest.approx((2.0, 8.0))  # not: linear on each side


def test_a_trend_with_the_covariate_within_groups_is_found():
    rng = np.random.default_rng(6)
    speed = np.tile(np.linspace(0.4, 0.6, 20), 2)
    groups = np.repeat([0, 1], 20)
    r = 0.02 * (speed - 0.5) / 0.1 + rng.normal(0.0, 0.005, 40) + 0.01 * groups
    check = check_model(r, None, noise_reference="", what="lambda1", n_params=1, groups=groups, covariate=speed,
                        covariate_name="approach speed [m/s]", between=False)
    assert check.noise_reference == NO_NOISE_REFERENCE and math.isnan(check.chi_square)
    assert check.trend["correlation"] > 0.9 and check.trend["p_value"] < 1e-6 and check.verdict == "structured"
    assert any("trend" in f for f in check.findings) and not check.between_groups
    # no trend: the same scatter in random order is consistent
    quiet = check_model(rng.normal(0.0, 0.005, 40), None, noise_reference="", what="lambda1", groups=groups,
                        covariate=speed, covariate_name="approach speed [m/s]")
    assert quiet.verdict == "consistent" and quiet.trend["p_value"] > 0.0027


def test_alternation_counts_only_above_the_structure_floor():
    r = 1e-5 * np.array([1.0, -1.0] * 8) + 1e-7 * np.arange(16)
    below = check_model(r, None, noise_reference="", what="lambda1", structure_floor=7e-5)
    assert below.verdict == "consistent" and below.lag1_autocorrelation < -0.9
    above = check_model(r, None, noise_reference="", what="lambda1", structure_floor=1e-6)
    assert above.verdict == "structured" and any(f.startswith("alternation") for f in above.findings)
    # alternation does not shrink the effective number of residuals (no widening from it)
    assert above.effective_samples == r.size and above.inflation == pytest.approx(1.0)


def test_group_means_that_differ_beyond_their_scatter():
    rng = np.random.default_rng(7)
    groups = np.repeat([0, 1, 2], 12)
    r = rng.normal(0.0, 0.01, 36) + np.array([0.0, 0.03, -0.03])[groups]
    check = check_model(r, None, noise_reference="", what="xi", groups=groups, order=False)
    assert check.between_groups["groups"] == 3 and check.between_groups["p_value"] < 1e-6
    assert check.verdict == "structured"
    # a systematic floor per group as large as the differences explains them
    floored = check_model(r, None, noise_reference="", what="xi", groups=groups, order=False, structure_floor=0.05)
    assert floored.verdict == "consistent"


def test_too_few_residuals_without_a_noise_reference_are_not_checked():
    check = check_model(np.array([0.1, -0.2, 0.05]), None, noise_reference="", what="r")
    assert check.verdict == "not checked" and check.describes_data is None and check.action == "none"


def test_a_rejected_model_withholds_and_the_blocks_combine():
    rng = np.random.default_rng(8)
    fine = check_model(rng.normal(0.0, 1.0, 50), 1.0, noise_reference="jitter", what="times", unit="s")
    rejected = fine.rejected("the contacts last 0 s")
    assert rejected.verdict == "rejected" and rejected.action == "withheld" and rejected.describes_data is False
    block = combine_checks([fine, rejected], extra={"contact_duration": {"verdict": "rejected"}})
    assert block["verdict"] == "rejected" and block["action"] == "withheld" and len(block["checks"]) == 2
    assert block["contact_duration"]["verdict"] == "rejected" and "withheld" in block["rule"]
    assert governing_check([fine, rejected]) is rejected
    assert combine_checks([])["verdict"] == "not checked"


def test_nist_misra1a_without_a_noise_reference_uses_the_residual_variance():
    """NIST data carry no noise reference: the scatter is not tested, and the variance the covariance
    assumed is the certified residual standard deviation."""
    found = search(_misra, (Free("b1", 500.0, 0.0, 1e4), Free("b2", 1e-4, 0.0, 1.0)))
    fit = uncertainty(found)
    check = check_model(found.residual, None, noise_reference="", what="y", n_params=2, covariate=MISRA1A_X,
                        covariate_name="x")
    assert check.noise_reference == NO_NOISE_REFERENCE and math.isnan(check.residual_over_noise)
    assert check.assumed_sd == pytest.approx(0.10187876330e0, rel=1e-8)  # NIST's certified residual SD
    assert check.assumed_sd == pytest.approx(math.sqrt(fit.scale), rel=1e-12)
    assert check.n == 14 and check.dof == 12 and check.trend["dof"] == 12

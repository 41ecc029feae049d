"""The shared covariance rule (impactid.engine.covariance): numbers below the condition limit, the reason above it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from impactid.engine.covariance import CONDITION_LIMIT, covariance_from_jacobian


def test_straight_line_matches_the_textbook_formula():
    # y = a + b x: var(b) = s2 / sum((x - mean)^2), var(a) = s2 (1/n + mean^2 / sum((x - mean)^2))
    x = np.linspace(0.0, 10.0, 21)
    J = np.column_stack((np.ones_like(x), x))
    s2 = 0.37
    cov = covariance_from_jacobian(J, s2, names=("a", "b"))
    sxx = float(np.sum((x - x.mean()) ** 2))
    assert cov.determined and cov.reason == ""
    np.testing.assert_allclose(cov.stderr, [math.sqrt(s2 * (1 / x.size + x.mean() ** 2 / sxx)), math.sqrt(s2 / sxx)],
                               rtol=1e-12)
    np.testing.assert_allclose(cov.matrix, s2 * np.linalg.inv(J.T @ J), rtol=1e-10)
    np.testing.assert_allclose(np.diag(cov.correlation), 1.0, rtol=1e-12)


def test_condition_does_not_depend_on_units():
    rng = np.random.default_rng(1)
    J = rng.normal(size=(50, 3))
    a = covariance_from_jacobian(J)
    b = covariance_from_jacobian(J * np.array([1e-9, 1.0, 1e7]))  # the same fit, parameters in other units
    assert a.condition == pytest.approx(b.condition, rel=1e-9)
    np.testing.assert_allclose(b.stderr, a.stderr / np.array([1e-9, 1.0, 1e7]), rtol=1e-9)


def test_nearly_dependent_columns_are_undetermined_with_the_reason():
    x = np.linspace(0.0, 1.0, 200)
    base = np.exp(-x)
    J = np.column_stack((base, base * (1.0 + 1e-9 * x)))  # cond(J^T J) ~ 1e19
    cov = covariance_from_jacobian(J, names=("k1", "k2"))
    assert cov.condition > CONDITION_LIMIT
    assert not cov.determined and np.all(np.isnan(cov.stderr))
    assert "do not determine the parameters separately" in cov.reason and "condition number" in cov.reason
    # just below the limit: numbers
    J2 = np.column_stack((base, base * (1.0 + 1e-4 * x)))
    cov2 = covariance_from_jacobian(J2)
    assert cov2.condition < CONDITION_LIMIT and cov2.determined


def test_a_parameter_the_residuals_ignore_is_the_only_one_undetermined():
    J = np.column_stack((np.linspace(1.0, 2.0, 10), np.zeros(10), np.linspace(0.0, 1.0, 10) ** 2))
    cov = covariance_from_jacobian(J, names=("a", "dead", "c"))
    assert math.isnan(cov.stderr[1]) and np.all(np.isfinite(cov.stderr[[0, 2]]))
    assert "dead" in cov.reason


def test_non_finite_jacobian():
    cov = covariance_from_jacobian(np.array([[1.0, np.nan], [0.0, 1.0]]))
    assert not cov.determined and "not finite" in cov.reason

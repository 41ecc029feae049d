"""The engine's distribution functions (:mod:`impactid.engine.distributions`) against ``scipy.stats``, whose import
they avoid; and the estimate's modules load neither ``scipy.stats`` nor ``scipy.signal``."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from scipy import stats

from impactid.engine import distributions as D

PROBABILITIES = [1e-6, 0.025, 0.05, 0.5, 0.8, 0.95, 0.975, 0.999]
DOFS = [1, 2, 3, 7.5, 13, 30, 200]
POINTS = [0.0, 0.3, 1.0, 1.96, 4.0, 25.0]


@pytest.mark.parametrize("dof", DOFS)
def test_student_t(dof):
    for p in PROBABILITIES:
        assert D.student_t_quantile(p, dof) == pytest.approx(stats.t.ppf(p, dof), rel=1e-13, abs=1e-300)
    for x in POINTS:
        assert D.student_t_sf(x, dof) == pytest.approx(stats.t.sf(x, dof), rel=1e-13, abs=1e-300)
        assert D.student_t_sf(-x, dof) == pytest.approx(stats.t.sf(-x, dof), rel=1e-13)


@pytest.mark.parametrize("dof", DOFS)
def test_chi_square(dof):
    for p in PROBABILITIES:
        assert D.chi2_quantile(p, dof) == pytest.approx(stats.chi2.ppf(p, dof), rel=1e-13)
    for x in POINTS:
        assert D.chi2_sf(x, dof) == pytest.approx(stats.chi2.sf(x, dof), rel=1e-13, abs=1e-300)


def test_normal():
    for p in PROBABILITIES:
        assert D.normal_quantile(p) == pytest.approx(stats.norm.ppf(p), rel=1e-14)
    for x in POINTS + [-2.0]:
        assert D.normal_sf(x) == pytest.approx(stats.norm.sf(x), rel=1e-14, abs=1e-300)
    assert np.isnan(D.chi2_sf(np.nan, 2))


def test_the_estimate_loads_neither_scipy_stats_nor_scipy_signal():
    """``scipy.stats`` with ``scipy.signal`` cost 0.3-0.6 s of every estimate's start-up
    (docs/performance_pipeline.md)."""
    code = ("import sys, impactid.rigs.pivoted.estimation, impactid.rigs.pivoted.calibration; "
            "print(sorted(m for m in ('scipy.stats', 'scipy.signal') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"

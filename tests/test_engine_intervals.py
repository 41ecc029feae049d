"""The engine's intervals at extreme inputs: a log-coordinate interval beyond the largest float."""

from __future__ import annotations

import math

import numpy as np
import pytest

from impactid.engine import Free, search, uncertainty
from impactid.engine.checks import widen_interval
from impactid.engine.intervals import safe_exp


@pytest.mark.parametrize(("u", "expected"), [(0.0, 1.0), (1.0, math.e), (709.0, math.exp(709.0)), (710.0, math.inf),
                                             (1e300, math.inf), (math.inf, math.inf), (-1e300, 0.0),
                                             (-math.inf, 0.0)])
def test_safe_exp_saturates_instead_of_overflowing(u, expected):
    assert safe_exp(u) == expected


def test_safe_exp_of_nan_is_nan():
    assert math.isnan(safe_exp(math.nan))


def test_a_log_parameter_the_data_hardly_see_gets_an_open_interval_not_an_overflow():
    # y = a x + c x^2 with c searched in its logarithm and far too small to be seen: the standard error
    # of ln c is thousands, so exp(ln c + t se) lies beyond the largest float (it raised OverflowError)
    x = np.linspace(0.0, 1.0, 40)
    noise = np.random.default_rng(1).normal(0.0, 1e-3, x.size)
    y = 2.0 * x + noise

    def residual(u):
        return u[0] * x + 1e-9 * math.exp(u[1]) * x ** 2 - y

    found = search(residual, (Free("a", 1.0, -10.0, 10.0), Free("c", 1.0, 1e-3, 10.0, log=True)), xtol=1e-14)
    fit = uncertainty(found)
    c = next(p for p in fit.parameters if p.name == "c")
    assert fit.stderr("c") > 709.0  # the case that overflowed
    lo, hi = c.interval
    assert hi == math.inf and 0.0 <= lo < c.value
    a = next(p for p in fit.parameters if p.name == "a")
    assert a.contains(2.0)


def test_widening_a_log_symmetric_interval_by_a_huge_factor_saturates():
    lo, hi = widen_interval((0.5, 2.0), 1.0, 1e6)
    assert lo == 0.0 and hi == math.inf

"""The identification engine (impactid.engine) against certified values and against lmfit."""

from __future__ import annotations

import math

import lmfit
import numpy as np
import pytest

from impactid.engine import Free, residual_against_noise, search, uncertainty
from impactid.results import FitResult

# NIST StRD nonlinear regression, Misra1a (lower difficulty): y = b1 (1 - exp(-b2 x)), with the
# certified values and standard deviations (certified to 11 digits).
MISRA1A_X = np.array([77.6, 114.9, 141.1, 190.8, 239.9, 289.0, 332.8, 378.4, 434.8, 477.3, 536.8, 593.1, 689.1,
                      760.0])
MISRA1A_Y = np.array([10.07, 14.73, 17.94, 23.93, 29.61, 35.18, 40.02, 44.82, 50.76, 55.05, 61.01, 66.40, 75.47,
                      81.78])
MISRA1A_B = (2.3894212918e02, 5.5015643181e-04)
MISRA1A_SD = (2.7070075241e00, 7.2668688436e-06)
MISRA1A_RSS = 1.2455138894e-01


def _misra(u):
    b1, b2 = u
    return MISRA1A_Y - b1 * (1.0 - np.exp(-b2 * MISRA1A_X))


def _misra_jacobian(u):
    b1, b2 = u
    e = np.exp(-b2 * MISRA1A_X)
    return -np.column_stack([1.0 - e, b1 * MISRA1A_X * e])


@pytest.mark.parametrize("start", [(500.0, 1e-4), (250.0, 5e-4)])  # NIST's two starts
@pytest.mark.parametrize("analytic", [True, False])
def test_misra1a_certified_values(start, analytic):
    free = (Free("b1", start[0], 0.0, 1e4), Free("b2", start[1], 0.0, 1.0))
    found = search(_misra, free, jacobian=_misra_jacobian if analytic else None)
    fit = uncertainty(found)
    values = found.values()
    assert values["b1"] == pytest.approx(MISRA1A_B[0], rel=1e-7)
    assert values["b2"] == pytest.approx(MISRA1A_B[1], rel=1e-7)
    assert 2.0 * found.cost == pytest.approx(MISRA1A_RSS, rel=1e-8)
    b1, b2 = fit.parameters
    assert b1.stderr == pytest.approx(MISRA1A_SD[0], rel=1e-5) and b2.stderr == pytest.approx(MISRA1A_SD[1], rel=1e-5)
    assert b1.contains(MISRA1A_B[0]) and b1.min == 0.0 and b1.vary and not fit.notes


def test_log_coordinate_matches_lmfit_and_maps_the_interval_back():
    free = (Free("b1", 500.0, 1.0, 1e4, log=True), Free("b2", 1e-4, 1e-8, 1.0, log=True))

    def residual(u):
        return _misra(np.exp(u))

    found = search(residual, free)
    fit = uncertainty(found)
    params = lmfit.Parameters()
    params.add("b1", 500.0, min=1.0, max=1e4)
    params.add("b2", 1e-4, min=1e-8, max=1.0)
    reference = lmfit.minimize(lambda p: _misra((p["b1"].value, p["b2"].value)), params, method="least_squares")
    b1 = fit.parameters[0]
    assert b1.value == pytest.approx(reference.params["b1"].value, rel=1e-7)
    # the log coordinate's error mapped back is the linear one to first order
    assert b1.stderr == pytest.approx(reference.params["b1"].stderr, rel=1e-3)
    lo, hi = b1.interval
    assert lo < b1.value < hi and math.log(hi / b1.value) == pytest.approx(math.log(b1.value / lo), rel=1e-12)


def test_fixed_parameters_bounds_and_undetermined_directions_are_reported():
    x = np.linspace(0.0, 1.0, 50)
    y = 2.0 + 3.0 * x

    # a fixed parameter, and one pushed onto its bound
    free = (Free("a", 2.0, vary=False), Free("b", 1.0, 0.0, 2.5))
    found = search(lambda u: y - (u[0] + u[1] * x), free)
    fit = uncertainty(found)
    a, b = fit.parameters
    assert a.fixed and a.stderr == 0.0 and b.value == pytest.approx(2.5)
    assert "on a bound" in b.note and any("on a bound" in n for n in fit.notes)

    # two parameters the data cannot tell apart: undetermined, never inverted
    free = (Free("c1", 1.0), Free("c2", 1.0), Free("slope", 1.0))
    found = search(lambda u: y - (u[0] + u[1] + u[2] * x), free)
    fit = uncertainty(found)
    assert all(math.isnan(p.stderr) for p in fit.parameters[:2]) and fit.notes
    result = FitResult(params=fit.parameters, statistics=fit.statistics, notes=fit.notes)
    again = FitResult.from_json(result.to_json())
    assert again["slope"].min == -math.inf and again["c1"].note == "undetermined by the data"


def test_residual_against_noise_flags_a_model_that_does_not_describe_the_data():
    rng = np.random.default_rng(1)
    noise = rng.normal(0.0, 0.1, 4000)
    stats, notes = residual_against_noise(noise, 0.1, what="force", unit="N")
    assert notes == () and stats["residual_over_noise"] == pytest.approx(1.0, abs=0.05)
    _, notes = residual_against_noise(noise + 0.3 * np.sin(np.linspace(0, 20, 4000)), 0.1, what="force", unit="N")
    assert notes and "lack of fit" in notes[0]
    _, notes = residual_against_noise(1.05 * noise, 0.1, what="force")
    assert notes and "systematic" in notes[0]

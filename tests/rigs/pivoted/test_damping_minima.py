"""Competing minima of the damping fit's sum of squares along beta (issue "No confident wrong answers", np13).

Where the law barely moves the residuals, a replay's contact that comes and goes with the law makes the sum
of squares along ``log10 c`` a sawtooth: several minima fit within the pipeline's error, and the local
profile interval of the search's minimum holds only one of them. These tests use a small synthetic
objective (no simulation): two minima 0.11 decades apart within the error.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from impactid.engine.valley import LeastSquaresFit
from impactid.rigs.pivoted.damping_least_squares import (
    FINE_STRUCTURE_FLOORS,
    competing_minima,
    competing_minima_note,
)

#: Per-event offsets of the residuals (the pipeline's errors) on the two branches of the sawtooth.
OFFSETS = np.array([[6e-5, -5e-5, 4e-5, -6e-5, 5e-5, -4e-5],
                    [-7e-5, 6e-5, -5e-5, 6e-5, -4e-5, 5e-5]])
#: Where the replays gain a contact [log10 c], and the second branch's minimum [log10 c].
JUMP, SECOND = 0.05, 0.11
FLOOR = 1e-4


class SawtoothObjective:
    """Per-event residuals ``slope (x - x_0) + offset``, with ``x_0`` and the offsets switching at :data:`JUMP`."""

    def __init__(self, slope: float, second: bool = True):
        self.slope = slope
        self.second = second
        self.n_simulations = 0
        self.n_events = OFFSETS.shape[1]
        self.residual = "lambda1"

    def beta(self, logc, n):
        return np.power(10.0, logc) / np.power(1e-5, n)

    def per_event(self, logc, n) -> np.ndarray:
        x = np.atleast_1d(np.asarray(logc, dtype=float))[:, None]
        self.n_simulations += x.shape[0] * self.n_events
        far = (x >= JUMP) & self.second
        return np.where(far, self.slope * (x - SECOND) + OFFSETS[1], self.slope * x + OFFSETS[0])


def fit_at_first_minimum(obj: SawtoothObjective) -> LeastSquaresFit:
    """The Gauss–Newton fit's statistics at the first minimum (``log10 c`` = 0, the least sum of squares)."""
    r = obj.per_event(0.0, 1.5)[0]
    obj.n_simulations = 0
    jac = np.full((r.size, 1), obj.slope)
    rss = float(np.sum(r ** 2))
    dof = r.size - 1
    s2 = rss / dof
    threshold = float(stats.t.ppf(0.975, dof) ** 2 * s2)
    half = math.sqrt(threshold) / float(np.sqrt(np.sum(jac ** 2)))
    profile = pd.DataFrame({"n": [1.5], "log10_c": [0.0], "rss": [rss], "objective": [float(np.mean(np.abs(r)))],
                            "half_width": [half]})
    return LeastSquaresFit(x=(0.0,), residuals=r, used=np.ones(r.size, bool), jacobian=jac, rss=rss, dof=dof, s2=s2,
                           threshold=threshold, covariance=s2 / np.sum(jac ** 2) * np.ones((1, 1)), profile=profile,
                           n_interval=(1.5, 1.5), reaches_bound=(False, False), evaluations=0)


PROBLEM = SimpleNamespace(log10_c_bounds=(-3.0, 3.0))


def test_a_second_minimum_within_the_error_widens_the_interval_to_hold_both():
    obj = SawtoothObjective(slope=0.01)
    fit = fit_at_first_minimum(obj)
    # the local profile interval holds the first minimum only
    assert fit.profile["half_width"].iloc[0] < SECOND / 4
    assert np.sum(obj.per_event(SECOND, 1.5) ** 2) - fit.rss < fit.threshold + OFFSETS.shape[1] * FLOOR ** 2
    obj.n_simulations = 0
    minima = competing_minima(PROBLEM, obj, fit, 1.5, FLOOR)
    assert minima is not None
    assert minima.log10_c.size == 1 and minima.log10_c[0] == pytest.approx(SECOND, abs=0.006)
    assert minima.interval[0] <= 0.0 and minima.interval[1] >= SECOND
    assert obj.n_simulations > 0  # the scan's simulations count
    note = competing_minima_note(obj, minima, 1.5, float(obj.beta(0.0, 1.5)),
                                 np.array([[1] * 6, [1, 2, 2, 2, 2, 2]]))
    assert "differs between them in 5 of 6 events" in note and "holds them all" in note


def test_no_scan_where_the_residuals_depend_on_the_law_strongly():
    # 10 % of beta moves the residuals by 0.0414 slope: far above FINE_STRUCTURE_FLOORS floors
    obj = SawtoothObjective(slope=1.0)
    assert obj.slope * math.log10(1.1) > FINE_STRUCTURE_FLOORS * FLOOR
    fit = fit_at_first_minimum(obj)
    assert competing_minima(PROBLEM, obj, fit, 1.5, FLOOR) is None
    assert obj.n_simulations == 0  # nothing simulated: a well-determined fit's simulation count is unchanged


def test_a_single_shallow_minimum_is_left_alone():
    obj = SawtoothObjective(slope=0.01, second=False)
    fit = fit_at_first_minimum(obj)
    assert competing_minima(PROBLEM, obj, fit, 1.5, FLOOR) is None
    assert obj.n_simulations > 0  # scanned, and found nothing else

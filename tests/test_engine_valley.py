"""The least-squares estimator (impactid.engine.valley): Jacobians, profile, intervals, agreement.

The profile and the intervals are checked first on a linear model, where the Gauss–Newton
covariance and the profile interval have closed forms; then on the simulator's residuals against
finite differences of other steps and against the optimiser's estimate.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from scipy import stats

from impactid.engine.valley import JACOBIAN_STEP, fit_least_squares, jacobian
from impactid.rigs.pivoted.estimates import EstimationWarning, fit_contact_damping
from impactid.rigs.pivoted.reconstruct import reconstruct
from impactid.rigs.pivoted.residuals import EventSet

BETA, N = 24.7e9, 1.5


def _linear_model(m=40, seed=1, slope=(0.8, -0.3)):
    """Residuals linear in (log10 c, n) with known optimum and noise: r = A (x - x0) + e."""
    rng = np.random.default_rng(seed)
    A = np.column_stack([rng.normal(slope[0], 0.2, m), rng.normal(slope[1], 0.5, m)])
    e = rng.normal(0.0, 1e-3, m)
    x0 = np.array([3.7, 1.45])

    def per_event(lc, n):
        lc, n = np.broadcast_arrays(np.atleast_1d(lc), np.atleast_1d(n))
        return (np.column_stack([lc - x0[0], n - x0[1]]) @ A.T) + e

    x_ls = x0 - np.linalg.lstsq(A, e, rcond=None)[0]
    return per_event, A, e, x_ls


def test_linear_model_recovers_the_least_squares_solution_and_its_profile_interval():
    per_event, A, e, x_ls = _linear_model()
    fit = fit_least_squares(per_event, fix_n=None, lc_bounds=(0.0, 6.0), n_bounds=(0.5, 2.5))
    assert fit.x == pytest.approx(tuple(x_ls), abs=1e-8)
    m = e.size
    rss = float(np.sum((A @ (x_ls - np.array([3.7, 1.45])) + e) ** 2))
    s2 = rss / (m - 2)
    cov = s2 * np.linalg.inv(A.T @ A)
    assert fit.covariance == pytest.approx(cov, rel=1e-6)
    # for a linear model the profile interval of n is exactly n_hat +- t se(n)
    half = stats.t.ppf(0.975, m - 2) * math.sqrt(cov[1, 1])
    assert fit.n_interval[0] == pytest.approx(x_ls[1] - half, abs=0.02 * half)
    assert fit.n_interval[1] == pytest.approx(x_ls[1] + half, abs=0.02 * half)
    assert fit.reaches_bound == (False, False)
    # along the profile log10 c is the conditional minimum: x_c(n) = x_c - (H01 / H00) (n - n_hat)
    H = A.T @ A
    prof = fit.profile
    expected = x_ls[0] - H[0, 1] / H[0, 0] * (prof["n"] - x_ls[1])
    assert np.allclose(prof["log10_c"], expected, atol=1e-7)


def test_linear_model_with_n_fixed():
    per_event, A, e, _ = _linear_model()
    fit = fit_least_squares(per_event, fix_n=1.6, lc_bounds=(0.0, 6.0), n_bounds=(0.5, 2.5))
    a = A[:, 0]
    b = A[:, 1] * (1.6 - 1.45) + e
    assert fit.x[0] == pytest.approx(3.7 - float(a @ b) / float(a @ a), abs=1e-9)
    assert fit.n_interval == (1.6, 1.6)


def test_profile_that_never_rises_reaches_the_bound():
    """A residual that does not depend on n: the n interval must reach both bounds."""
    rng = np.random.default_rng(4)
    e = rng.normal(0.0, 1e-3, 30)

    def per_event(lc, n):
        lc = np.atleast_1d(lc)
        return (lc[:, None] - 3.0) * 0.5 + e[None, :] + 0.0 * np.atleast_1d(n)[:, None]

    fit = fit_least_squares(per_event, fix_n=None, lc_bounds=(0.0, 6.0), n_bounds=(0.5, 2.5))
    assert fit.reaches_bound == (True, True)
    assert fit.n_interval == (0.5, 2.5)


@pytest.fixture(scope="module")
def s2_events(s2_synthetic):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return EventSet.from_reconstruction(reconstruct(s2_synthetic.recording, anchor="cam-phase"))


def test_central_difference_jacobian_of_the_simulator_is_step_independent(s2_events):
    """The batched central differences at the default steps against steps 4x smaller (truncation
    h^2: 16x smaller) and 4x larger: the default is accurate to better than 1e-3 relative."""
    from impactid.rigs.pivoted.estimates import _Objective, reference_indentation

    obj = _Objective([s2_events], "lambda1", reference_indentation([s2_events]))
    x = np.array([math.log10(BETA * obj.delta_ref ** N), N])
    default = jacobian(obj.per_event, x)
    small = jacobian(obj.per_event, x, step=tuple(h / 4 for h in JACOBIAN_STEP))
    large = jacobian(obj.per_event, x, step=tuple(h * 4 for h in JACOBIAN_STEP))
    scale = np.max(np.abs(small), axis=0)
    assert np.max(np.abs(default - small), axis=0) / scale == pytest.approx(0.0, abs=1e-3)
    # truncation of the large step is ~16x that of the default: the default sits in the flat part
    assert np.all(np.max(np.abs(large - small), axis=0) >= np.max(np.abs(default - small), axis=0))
    assert np.all(scale > 0)


@pytest.mark.slow
def test_fixed_n_agrees_with_the_optimiser_within_each_others_intervals(s2_events):
    ls = fit_contact_damping(s2_events, fix_n=N, method="least-squares")
    opt = fit_contact_damping(s2_events, fix_n=N, method="optimise")
    assert abs(ls.beta / BETA - 1) < 0.01
    assert ls.beta_interval[0] <= BETA <= ls.beta_interval[1]
    assert opt.beta_interval[0] <= ls.beta <= opt.beta_interval[1]
    assert ls.beta_interval[0] <= opt.beta <= ls.beta_interval[1]
    assert ls.method == "least-squares" and math.isfinite(ls.beta_stderr) and ls.beta_stderr > 0
    # measured: 56 trial laws per event (41-point start scan, up to three starts) against 164
    assert ls.n_simulations < 0.5 * opt.n_simulations


@pytest.mark.slow
def test_single_recording_joint_least_squares_says_not_separable(s2_events):
    with pytest.warns(EstimationWarning, match="not separable"):
        est = fit_contact_damping(s2_events, method="least-squares")
    assert est.separable is False
    assert est.n_interval[0] <= N <= est.n_interval[1]


def test_joint_least_squares_over_two_operating_points(s2_synthetic, s2_second_point):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sets = [EventSet.from_reconstruction(reconstruct(s.recording, anchor="cam-phase"))
                for s in (s2_synthetic, s2_second_point)]
        est = fit_contact_damping(sets, method="least-squares")
    assert est.beta_interval[0] <= BETA <= est.beta_interval[1]
    assert est.n_interval[0] <= N <= est.n_interval[1]
    assert abs(est.n - N) < 0.02
    events = sum(len(s) for s in sets)
    assert est.n_simulations <= 150 * events  # the target of a joint fit: a few hundred trials, not thousands


def _two_minima(lc, n):
    """Residuals that vanish at log10 c = 3.0 and at 4.3 (as a chattering law can match alpha_m)."""
    lc = np.atleast_1d(lc)
    w = np.linspace(0.5, 1.5, 12)
    return (lc[:, None] - 3.0) * (lc[:, None] - 4.3) * w[None, :] + 0.0 * np.atleast_1d(n)[:, None]


def test_equally_good_minima_are_told_apart_by_other_evidence_or_reported():
    pick_low = lambda points: int(np.argmin([p[0] for p in points]))  # noqa: E731
    fit = fit_least_squares(_two_minima, fix_n=1.5, lc_bounds=(0.0, 6.0), n_bounds=(0.5, 2.5), choose=pick_low,
                            rss_tolerance=1e-6)
    assert fit.x[0] == pytest.approx(3.0, abs=1e-6)
    assert fit.resolved and fit.alternatives[0][0] == pytest.approx(4.3, abs=1e-6)
    fit = fit_least_squares(_two_minima, fix_n=1.5, lc_bounds=(0.0, 6.0), n_bounds=(0.5, 2.5),
                            choose=lambda points: None, rss_tolerance=1e-6)
    assert not fit.resolved and len(fit.alternatives) == 1


def test_jacobian_callable_is_used_and_a_missing_one_is_differenced():
    """With exact derivatives the linear model's solution is found as before; a Jacobian of NaN (a
    run without sensitivities) falls back to differences with the same result."""
    per_event, A, e, x_ls = _linear_model()
    calls = {"exact": 0}

    def exact(lc, n):
        calls["exact"] += 1
        r = per_event(lc, n)
        return r, np.broadcast_to(A, r.shape + (2,)).copy()

    def missing(lc, n):
        r = per_event(lc, n)
        return r, np.full(r.shape + (2,), np.nan)

    bounds = dict(fix_n=None, lc_bounds=(0.0, 6.0), n_bounds=(0.5, 2.5))
    with_exact = fit_least_squares(per_event, per_event_jacobian=exact, **bounds)
    with_missing = fit_least_squares(per_event, per_event_jacobian=missing, **bounds)
    assert calls["exact"] > 0
    for fit in (with_exact, with_missing):
        assert fit.x == pytest.approx(tuple(x_ls), abs=1e-8)
        assert fit.jacobian == pytest.approx(A, rel=1e-6)


def test_sensitivity_jacobian_gives_the_fit_of_differences_with_fewer_simulations(s2_events):
    sens = fit_contact_damping(s2_events, fix_n=N, method="least-squares", jacobian="sensitivities")
    diff = fit_contact_damping(s2_events, fix_n=N, method="least-squares", jacobian="differences")
    # the same minimum to the search's stopping rule, the same interval to its resolution
    assert sens.beta == pytest.approx(diff.beta, rel=1e-5)
    assert sens.beta_interval == pytest.approx(diff.beta_interval, rel=1e-3)
    assert sens.n_simulations < diff.n_simulations
    with pytest.raises(ValueError, match="jacobian"):
        fit_contact_damping(s2_events, fix_n=N, jacobian="adjoint")


def test_a_start_outside_the_box_begins_on_its_edge():
    """The profile walk may find a lower point beyond a bound of log10 c; the restart from it must not
    fail ('Initial guess is outside of provided bounds') but end on the bound."""
    from impactid.engine.valley import _trust_region

    target = np.array([8.0, 1.6])  # the minimum lies beyond the upper bound of log10 c (6)

    def fun(x):
        return np.asarray(x, dtype=float) - target

    def jac(x):
        return np.eye(2)

    x, r, J, _ = _trust_region(fun, jac, [8.36, 1.56], None, (0.0, 6.0), (0.5, 2.5), [0])
    assert x[0] == pytest.approx(6.0) and x[1] == pytest.approx(1.6, abs=1e-8)

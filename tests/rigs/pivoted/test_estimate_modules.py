"""Rig P's estimates split by subject (issue 25): the re-exporting face and the pieces of the fits.

``impactid.rigs.pivoted.estimates`` only re-exports; the subjects are ``damping*`` (the contact damping),
``restitution`` and ``estimate_results``. The fits' numbers are checked in tests/rigs/pivoted/test_estimates.py and
tests/test_gauss_newton.py; here: the face, the validation, and the small pieces on their own.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from impactid.errors import ImpactidError
from impactid.results import result_kinds
from impactid.rigs.pivoted import (
    damping,
    damping_diagnostics,
    damping_least_squares,
    damping_objective,
    damping_search,
    estimate_results,
    estimates,
    restitution,
)
from impactid.rigs.pivoted.reconstruct import reconstruct
from impactid.rigs.pivoted.residuals import EventSet

HOMES = (damping, damping_diagnostics, damping_objective, estimate_results, restitution)


@pytest.fixture(scope="module")
def s2_events(s2_synthetic):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return EventSet.from_reconstruction(reconstruct(s2_synthetic.recording, anchor="cam-phase"))


@pytest.mark.parametrize("name", estimates.__all__)
def test_the_face_reexports_every_name_from_its_subject_module(name):
    homes = [m for m in HOMES if name in m.__all__]
    assert len(homes) == 1, f"{name} lives in {homes}"
    assert getattr(estimates, name) is getattr(homes[0], name)


def test_the_old_private_objective_name_still_works(s2_events):
    assert estimates._Objective is damping_objective.DampingObjective
    obj = estimates._Objective([s2_events], "lambda1", estimates.reference_indentation([s2_events]))
    assert obj.n_events == len(s2_events) and obj(math.log10(24.7e9 * obj.delta_ref ** 1.5), 1.5) < 1e-4


def test_result_types_keep_their_json_kinds():
    kinds = result_kinds()
    assert kinds["contact-damping"] is estimates.ContactDampingResult
    assert kinds["restitution"] is estimates.RestitutionResult


def test_the_problem_is_validated_before_any_simulation(s2_events):
    problem = damping.damping_problem(s2_events, "L1", fix_n=1.5, c_bounds=(10, 1e5))
    assert problem.sets == (s2_events,) and problem.residual == "lambda1" and problem.fix_n == 1.5
    assert problem.log10_c_bounds == (1.0, 5.0) and problem.residual_floor == damping.RESIDUAL_FLOOR["lambda1"]
    assert problem.delta_ref == damping_objective.reference_indentation([s2_events])
    assert problem.objective().n_simulations == 0 and problem.landscape_if_asked() is None
    with pytest.raises(ImpactidError, match="no recordings"):
        damping.damping_problem([])
    with pytest.raises(ValueError, match="c bounds"):
        damping.damping_problem(s2_events, c_bounds=(0.0, 1.0))
    with pytest.raises(ValueError, match="n bounds"):
        damping.damping_problem(s2_events, n_bounds=(2.0, 1.0))
    with pytest.raises(ValueError, match="fixed n"):
        damping.damping_problem(s2_events, fix_n=-1.0)
    with pytest.raises(ValueError, match="unknown method"):
        damping.fit_contact_damping(s2_events, method="simplex")
    with pytest.raises(ValueError, match="unknown jacobian"):
        damping.fit_contact_damping(s2_events, jacobian="secant")


def test_widen_interval_adds_in_quadrature():
    lo, hi = damping_diagnostics.widen_interval((1.0, 5.0), 2.0, 4.0)
    assert lo == pytest.approx(2.0 - math.hypot(1.0, 4.0)) and hi == pytest.approx(2.0 + math.hypot(3.0, 4.0))
    assert damping_diagnostics.widen_interval((1.0, 5.0), 2.0, 0.0) == (1.0, 5.0)


def test_quadrature_of_shifts():
    grad = np.array([2.0, 0.0])
    shifts = [np.array([1.0, 3.0]), np.array([2.0, 4.0])]
    assert damping_least_squares.quadrature(shifts, grad) == pytest.approx(math.hypot(2.0, 4.0))
    assert damping_least_squares.quadrature(shifts, grad, 1) == pytest.approx(5.0)
    assert damping_least_squares.quadrature([], grad) == 0.0


def test_separability_and_bound_notes(s2_events, monkeypatch):
    problem = damping.damping_problem(s2_events)
    notes: list[str] = []
    # one operating point of period-1 motion: impacts all alike carry one observable, whatever the n interval
    assert damping_diagnostics.separability(problem, (1.4, 1.6), (1e10, 3e10), "the region", notes) is False
    assert len(notes) == 1 and "nearly the same approach speed" in notes[0]
    notes.clear()
    with monkeypatch.context() as m:  # approach speeds that spread (two operating points): the interval decides
        m.setattr(damping_diagnostics, "approach_speed_spread", lambda problem: 0.5)
        assert damping_diagnostics.separability(problem, (1.4, 1.6), (1e10, 3e10), "the region", notes) is True
        assert notes == []
        assert damping_diagnostics.separability(problem, (1.0, 2.0), (1e9, 1e11), "the region", notes) is False
    notes.clear()
    assert damping_diagnostics.separability(problem, (1.0, 2.0), (1e9, 1e11), "the region", notes) is False
    assert len(notes) == 1 and "not separable" in notes[0] and "the region" in notes[0]
    fixed = damping.damping_problem(s2_events, fix_n=1.5)
    assert damping_diagnostics.separability(fixed, (1.5, 1.5), (1e10, 3e10), "", notes) is None
    notes.clear()
    damping_diagnostics.bound_notes(problem, problem.log10_c_bounds[1], problem.n_bounds[0], notes)
    assert len(notes) == 2 and "search bound of c" in notes[0] and "n lies on its search bound" in notes[1]


def test_lattice_rows_and_the_grid_estimate(s2_events):
    joint = damping.damping_problem(s2_events, n_bounds=(1.0, 2.0))
    rows = damping_search.lattice_rows(joint)
    assert rows[0] == 1.0 and rows[-1] == 2.0 and np.allclose(np.diff(rows), damping_search.N_LATTICE_STEP)
    fixed = damping.damping_problem(s2_events, fix_n=1.5)
    rows = damping_search.lattice_rows(fixed)
    np.testing.assert_array_equal(rows, [1.5])
    obj = fixed.objective()
    n_hat, logc_hat, j_hat = damping_search.grid_estimate(obj, fixed, rows, (61, 3))
    assert n_hat == 1.5 and obj.n_simulations == 61 * len(s2_events)
    assert abs(math.log10(obj.beta(logc_hat, n_hat) / 24.7e9)) <= 0.1 + 1e-12  # grid step 0.1 decade
    assert j_hat == pytest.approx(obj(logc_hat, n_hat))


def test_linearised_bootstrap_of_an_exact_linear_model():
    # residuals r = J (x - x0): every resample's Gauss-Newton step lands on x0 exactly
    obj = damping_objective.DampingObjective([], "lambda1", 1e-5)
    rng = np.random.default_rng(0)
    J = rng.normal(size=(30, 2))
    x0, x = np.array([3.0, 1.5]), np.array([3.1, 1.4])
    boot = damping_least_squares.linearised_bootstrap(obj, J, J @ (x - x0), x[0], x[1], 50, 1)
    assert boot.shape == (50, 2)
    np.testing.assert_allclose(boot[:, 1], x0[1], atol=1e-12)
    np.testing.assert_allclose(boot[:, 0], obj.beta(x0[0], x0[1]), rtol=1e-10)


def test_restitution_pieces():
    v = np.array([0.2, 0.4, 0.6, 0.8])
    xi = 1.0 - 0.5 * v
    gamma, se = restitution._through_fixed_intercept(v, xi)
    assert gamma == pytest.approx(0.5) and se == pytest.approx(0.0, abs=1e-12)
    a, b, a_se, b_se = restitution._free_line(v, xi, float(np.std(v) / np.mean(v)))
    assert (a, b) == pytest.approx((1.0, 0.5)) and a_se == pytest.approx(0.0, abs=1e-7)
    assert all(math.isnan(x) for x in restitution._free_line(v[:2], xi[:2], 0.5))
    notes = restitution._law_notes(v, xi, gamma, 0.4, b, b_se, 0.05)
    assert notes == []
    notes = restitution._law_notes(v, np.append(xi[:-1], 1.2), 2.0, 0.001, math.nan, math.nan, 0.05)
    assert len(notes) == 3

"""The engine's identifiability block (impactid.engine.identifiability): condition number, correlations,
bounds, profile shapes (refit and quadratic) and the comparison of nested laws; and the blocks in a
FitResult (JSON round trip, report)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from impactid.engine import (
    PROFILE_THRESHOLD,
    Free,
    check_model,
    combine_checks,
    compare_models,
    covariance_from_jacobian,
    identifiability,
    search,
    uncertainty,
)
from impactid.results import FitResult
from tests.test_engine import _misra, _misra_jacobian


def _misra_fit():
    free = (Free("b1", 500.0, 0.0, 1e4), Free("b2", 1e-4, 0.0, 1.0))
    found = search(_misra, free, jacobian=_misra_jacobian)
    return found, uncertainty(found)


def test_misra1a_block_by_refit_and_by_the_quadratic_model():
    found, fit = _misra_fit()
    refit = identifiability(found, fit, residual=_misra)
    quadratic = identifiability(found, fit)
    J = found.jacobian
    assert refit["condition_number"] == pytest.approx(covariance_from_jacobian(J).condition, rel=1e-12)
    assert refit["names"] == ["b1", "b2"] and refit["correlation"][0][1] == pytest.approx(fit.correlation[0, 1])
    assert refit["largest_correlation"]["pair"] == ["b1", "b2"] and abs(refit["largest_correlation"]["value"]) > 0.99
    assert refit["determined"] and quadratic["determined"] and not refit["near_bounds"]
    for name in ("b1", "b2"):
        assert refit["profiles"][name]["shape"] == "bounded" and refit["profiles"][name]["method"] == "refit"
        assert quadratic["profiles"][name]["method"] == "quadratic"
        # two standard errors out: the quadratic model's rise is 4 exactly, the refit's near it (Misra1a is
        # nearly linear about its optimum); where it stays below the 95 % threshold (3.84), the profile
        # is followed to six standard errors, where it must rise above it
        value = found.values()[name]
        se = fit.covariance.stderr[fit.names.index(name)]
        points = refit["profiles"][name]["points"]
        near = [rise for at, rise in points if abs(abs(at - value) / se - 2.0) < 1e-6]
        far = [rise for at, rise in points if abs(abs(at - value) / se - 6.0) < 1e-6]
        assert len(near) == 2 and all(3.0 < rise < 5.0 for rise in near)
        assert all(rise > PROFILE_THRESHOLD for rise in far) and len(points) == 2 + len(far)
        assert [rise for _, rise in quadratic["profiles"][name]["points"]] == pytest.approx([4.0, 4.0])
    assert refit["profile_evaluations"] > 0 and refit["profile_method"].startswith("refit")
    assert quadratic["profile_method"].startswith("quadratic") and quadratic["profile_threshold"] == PROFILE_THRESHOLD


def test_a_parameter_on_a_bound_is_one_sided_and_not_determined():
    x = np.linspace(0.0, 1.0, 50)
    y = 2.0 + 3.0 * x
    found = search(lambda u: y - (u[0] + u[1] * x), (Free("a", 1.0), Free("b", 1.0, 0.0, 2.5)))
    block = identifiability(found, uncertainty(found), residual=lambda u: y - (u[0] + u[1] * x))
    (near,) = block["near_bounds"]
    assert near["name"] == "b" and near["bound"] == "max" and near["on_bound"] and near["value"] == 2.5
    assert block["profiles"]["b"]["shape"] == "one-sided" and block["profiles"]["a"]["shape"] == "bounded"
    assert not block["determined"] and any("max bound" in n for n in block["notes"])


def test_parameters_the_data_cannot_tell_apart_are_flat():
    x = np.linspace(0.0, 1.0, 50)
    y = 2.0 + 3.0 * x
    found = search(lambda u: y - (u[0] + u[1] + u[2] * x), (Free("c1", 1.0), Free("c2", 1.0), Free("slope", 1.0)))
    block = identifiability(found, uncertainty(found))
    assert block["profiles"]["c1"]["shape"] == "flat" and block["profiles"]["c2"]["shape"] == "flat"
    assert not block["determined"] and "condition number" in block["notes"][0]


def test_a_model_the_check_rejects_is_never_determined():
    found, fit = _misra_fit()
    assert identifiability(found, fit)["determined"]
    block = identifiability(found, fit, describes_data=False)
    assert not block["determined"] and any("does not describe" in n for n in block["notes"])


def test_compare_models_nested_laws():
    rng = np.random.default_rng(2)
    v = np.linspace(0.5, 3.0, 60)
    for slope, rejects in ((0.05, True), (0.0, False)):
        e = 0.9 - slope * v + rng.normal(0.0, 0.01, v.size)
        rss_c = float(np.sum((e - e.mean()) ** 2))
        X = np.column_stack([np.ones_like(v), -v])
        coef, *_ = np.linalg.lstsq(X, e, rcond=None)
        rss_l = float(np.sum((e - X @ coef) ** 2))
        block = compare_models([{"name": "constant", "n_params": 1, "n_data": v.size, "rss": rss_c},
                                {"name": "linear", "n_params": 2, "n_data": v.size, "rss": rss_l}],
                               nested=[("constant", "linear")], choice="constant or linear")
        (test,) = block["likelihood_ratio"]
        assert test["statistic"] == pytest.approx(v.size * math.log(rss_c / rss_l), rel=1e-12) and test["dof"] == 1
        assert test["rejects_simple"] is rejects and block["preferred"] == ("linear" if rejects else "constant")
        linear = next(m for m in block["models"] if m["name"] == "linear")
        loglik = -0.5 * v.size * (math.log(2 * math.pi * rss_l / v.size) + 1)
        assert linear["aic"] == pytest.approx(2 * 3 - 2 * loglik) and linear["bic"] == pytest.approx(
            3 * math.log(v.size) - 2 * loglik)  # lmfit's definitions, the scale counted
    known = compare_models([{"name": "a", "n_params": 1, "n_data": 10, "rss": 14.0},
                            {"name": "b", "n_params": 2, "n_data": 10, "rss": 9.0}], nested=[("a", "b")],
                           known_scale=True)
    assert known["likelihood_ratio"][0]["statistic"] == pytest.approx(5.0)  # the chi-square difference


def test_blocks_round_trip_through_json_and_the_report_shows_them():
    found, fit = _misra_fit()
    check = check_model(found.residual, None, noise_reference="", what="y", n_params=2)
    result = FitResult(params=fit.parameters, statistics=fit.statistics, model_check=combine_checks([check]),
                       identifiability=identifiability(found, fit, residual=_misra))
    data = json.loads(result.to_json())
    assert {"model_check", "identifiability"} <= set(data) and data["model_check"]["checks"][0]["noise_sd"] is None
    again = FitResult.from_json(result.to_json())
    assert json.loads(again.to_json()) == data
    report = result.report()
    assert "[[Model Check]]" in report and "[[Identifiability]]" in report and "profiles (refit): b1 bounded" in report
    # a result made without them still writes (empty) blocks, and the report has no section for them
    bare = FitResult(params=fit.parameters)
    assert bare.to_dict()["model_check"] == {} and "[[Model Check]]" not in bare.report()
    assert again.to_pandas().shape[0] == 2  # the parameters' table, unaffected


def test_profile_interval_matches_lmfit_conf_interval_on_misra1a():
    """The engine's profile interval of one parameter against lmfit's ``conf_interval`` (the F-test
    interval of one parameter), on NIST's Misra1a; and against the covariance's for a linear model."""
    import lmfit

    from impactid.engine import Free, profile_interval, search, uncertainty
    from tests.test_engine import MISRA1A_X, MISRA1A_Y, _misra

    found = search(_misra, (Free("b1", 500.0, 0.0, 1e4), Free("b2", 1e-4, 0.0, 1.0)))
    fit = uncertainty(found)
    params = lmfit.Parameters()
    params.add("b1", 500.0, min=0.0, max=1e4)
    params.add("b2", 1e-4, min=0.0, max=1.0)
    model = lmfit.Minimizer(lambda p: MISRA1A_Y - p["b1"] * (1.0 - np.exp(-p["b2"] * MISRA1A_X)), params)
    reference = model.minimize(method="leastsq")
    limits = lmfit.conf_interval(model, reference, p_names=["b1", "b2"], sigmas=[0.95])
    for name in ("b1", "b2"):
        low, high = profile_interval(_misra, found, fit, name)
        (_, ref_low), _, (_, ref_high) = limits[name]  # [(0.95, low), (0, best), (0.95, high)]
        assert low == pytest.approx(ref_low, rel=2e-4) and high == pytest.approx(ref_high, rel=2e-4)
    # a linear model: the profile interval is the covariance's
    x = np.linspace(0.0, 1.0, 30)
    y = 1.0 + 2.0 * x + np.random.default_rng(0).normal(0.0, 0.1, x.size)

    def line(u):
        return y - (u[0] + u[1] * x)

    found = search(line, (Free("a", 0.5), Free("b", 1.0)))
    fit = uncertainty(found)
    slope = fit.parameters[1]
    assert profile_interval(line, found, fit, "b") == pytest.approx(slope.interval, rel=1e-5)

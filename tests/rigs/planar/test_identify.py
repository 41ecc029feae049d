"""Recovery of a known law from impacts made by the independent reference, prediction and scoring."""

import numpy as np
import pytest

from impactid.results import FitResult
from impactid.rigs.planar import (
    MCUBE_ELLIPSE,
    PlanarFitError,
    PlanarImpacts,
    PlanarLawFit,
    fit_planar,
    fit_planar_law,
    predict_planar,
    score_predictions,
)
from tests.rigs.planar.conftest import TRUTH


def _impacts(synthetic, noise=0.0, seed=0, impulse=True, velocity=True):
    v, jt, jn, p, v_post = synthetic
    rng = np.random.default_rng(seed)
    scale = np.linalg.norm(p, axis=1, keepdims=True)
    p_meas = p + noise * scale * rng.standard_normal(p.shape)
    n = len(v)
    return PlanarImpacts("synthetic", np.arange(1, n + 1), np.zeros((n, 3)), v, jn, jt,
                         v_post if velocity else None, p_meas if impulse else None)


def test_noise_free_recovery(synthetic):
    fit = fit_planar_law(_impacts(synthetic), MCUBE_ELLIPSE, "newton-linear-et", profiles=False)
    for name, value in TRUTH.items():
        assert fit.value(name) == pytest.approx(value, rel=1e-5, abs=1e-6), name
    assert fit.statistics["median_relative_impulse_error"] < 1e-6


def test_noisy_intervals_cover_the_truth(synthetic):
    fit = fit_planar_law(_impacts(synthetic, noise=0.02, seed=11), MCUBE_ELLIPSE, "newton-linear-et")
    for name, value in TRUTH.items():
        p = fit[name]
        assert p.contains(value), (name, p)
        assert p.stderr < 0.5 * max(abs(value), 0.05), (name, p)  # informative
    assert fit.model_check["verdict"] == "consistent"
    assert fit.identifiability["profiles"]["mu"]["shape"] == "bounded"


def test_velocity_target_recovers_the_law(synthetic):
    fit = fit_planar_law(_impacts(synthetic, impulse=False), MCUBE_ELLIPSE, "newton-linear-et", profiles=False)
    assert fit.statistics["target"] == "velocity"
    for name, value in TRUTH.items():
        assert fit.value(name) == pytest.approx(value, rel=1e-4, abs=1e-5), name


def test_the_comparison_selects_the_generating_law(synthetic):
    fit = fit_planar(_impacts(synthetic, noise=0.01, seed=5), MCUBE_ELLIPSE, profiles=False)
    assert fit.law.name == "newton-linear-et"
    block = fit.identifiability["model_comparison"]
    assert block["selected"] == "newton-linear-et" and len(block["models"]) == 8
    assert set(fit.tables["laws"]["law"]) == set(m["name"] for m in block["models"])


def test_prediction_of_held_out_impacts(synthetic):
    impacts = _impacts(synthetic, noise=0.01, seed=2)
    train, test = impacts.subset(np.arange(0, 120, 2)), impacts.subset(np.arange(1, 120, 2))
    fit = fit_planar_law(train, MCUBE_ELLIPSE, "newton-linear-et", profiles=False)
    predicted = predict_planar(fit.law, fit.values, MCUBE_ELLIPSE, test.pre_impact())
    exact = _impacts(synthetic).subset(np.arange(1, 120, 2))
    scored = score_predictions(predicted, exact, MCUBE_ELLIPSE)
    right = np.median(scored["relative_impulse_error"])
    assert right < 0.01
    assert np.median(scored["relative_velocity_error"]) < 0.01
    # a wrong law predicts measurably worse (the scoring can fail)
    wrong = predict_planar("newton-constant-stick", {"e": 0.6, "mu": 0.1}, MCUBE_ELLIPSE, test.pre_impact())
    assert np.median(score_predictions(wrong, exact, MCUBE_ELLIPSE)["relative_impulse_error"]) > 3 * right


def test_result_round_trips_through_json(synthetic):
    fit = fit_planar_law(_impacts(synthetic, noise=0.02), MCUBE_ELLIPSE, "newton-constant-stick", profiles=False)
    again = FitResult.from_json(fit.to_json())
    assert isinstance(again, PlanarLawFit) and again.law == fit.law and again.body == MCUBE_ELLIPSE
    assert again.values == pytest.approx(fit.values)


def test_fit_refuses_what_it_cannot_use(synthetic):
    with pytest.raises(PlanarFitError, match="no measured impulses"):
        fit_planar_law(_impacts(synthetic, impulse=False), MCUBE_ELLIPSE, "newton-constant-stick", target="impulse")
    with pytest.raises(PlanarFitError, match="at least"):
        fit_planar_law(_impacts(synthetic).subset(np.arange(3)), MCUBE_ELLIPSE, "newton-constant-stick")

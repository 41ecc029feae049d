"""Recovery of known laws: exact without noise, inside the intervals with jitter."""

import numpy as np
import pytest

from impactid.results import FitResult
from impactid.rigs.ball import LAWS, TABLE_TENNIS, analyse_bounces, fit_law, flight_constants, get_law, select_law
from impactid.rigs.ball.laws import fit_chained, variance_model
from impactid.rigs.ball.synth import simulate_drop


def test_law_registry():
    assert set(LAWS) == {"constant", "linear", "viscoelastic"}
    assert get_law("linear").evaluate([0.97, 0.02], 2.0) == pytest.approx(0.93)
    assert get_law("viscoelastic").evaluate([0.05], 1.0) == pytest.approx(0.95)
    with pytest.raises(ValueError, match="valid: constant, linear, viscoelastic"):
        get_law("quadratic")


@pytest.mark.parametrize("law,params", [("constant", {"e": 0.94}), ("linear", {"e0": 0.97, "gamma": 0.02}),
                                        ("viscoelastic", {"a": 0.05})])
def test_noise_free_recovery_is_exact(law, params):
    drops = []
    for h in (0.1, 0.2, 0.4):
        sim = simulate_drop(law, params, ball=TABLE_TENNIS, height=h, min_flight=0.15)
        drops.append(sim["times"])
    result = analyse_bounces(drops, ball=TABLE_TENNIS, law=law, compare_no_drag=False)
    fit = result.law_fits[law]
    for name, value in params.items():
        assert fit[name].value == pytest.approx(value, abs=1e-9)
    chained = result.chained_fits[law]
    for name, value in params.items():
        assert chained[name].value == pytest.approx(value, abs=1e-7)


def test_selection_prefers_the_simpler_law_within_two():
    v = np.linspace(0.5, 2.5, 40)
    rng = np.random.default_rng(0)
    e = 0.95 + 0.002 * rng.standard_normal(v.size)
    fits = {name: fit_law(name, v, e) for name in LAWS}
    chosen, reason = select_law(fits)
    assert chosen == "constant" and "BIC" in reason
    e2 = 0.97 - 0.03 * v + 0.002 * rng.standard_normal(v.size)
    fits2 = {name: fit_law(name, v, e2) for name in LAWS}
    assert select_law(fits2)[0] == "linear"
    with pytest.raises(ValueError):
        select_law(fits, criterion="r2")


@pytest.mark.slow
def test_intervals_cover_with_jitter_and_scatter():
    """20 experiments of six drops with 0.3 ms jitter and a 0.003 bounce-to-bounce scatter of e."""
    from impactid.rigs.ball.synth import synth_drop

    hits = {"e0": 0, "gamma": 0}
    runs = 12
    for seed in range(runs):
        drops = [synth_drop("linear", {"e0": 0.97, "gamma": 0.02}, seed=1000 * seed + j, ball=TABLE_TENNIS,
                            height=h, jitter=3e-4, scatter=0.003, min_flight=0.1).times
                 for j, h in enumerate((0.08, 0.12, 0.18, 0.24, 0.3, 0.36))]
        fit = analyse_bounces(drops, ball=TABLE_TENNIS, chained=False, compare_no_drag=False).law_fits["linear"]
        hits["e0"] += fit["e0"].contains(0.97)
        hits["gamma"] += fit["gamma"].contains(0.02)
        assert fit["gamma"].stderr < 0.005
    assert hits["e0"] >= runs - 2 and hits["gamma"] >= runs - 2


def test_single_drop_uses_neighbour_robust_errors():
    sim = simulate_drop("linear", {"e0": 0.97, "gamma": 0.02}, ball=None, height=0.3, min_flight=0.08)
    t = sim["times"] + np.random.default_rng(1).normal(0, 2e-4, sim["times"].size)
    result = analyse_bounces([t], chained=False)
    fit = result.law_fits["linear"]
    assert "Newey-West" in fit.details["covariance_method"]
    assert any("fewer than 4" in n for n in result.notes)


def test_variance_model_separates_scatter_and_timing():
    rng = np.random.default_rng(2)
    g = np.geomspace(10.0, 1000.0, 4000)
    tau, sig = 0.003, 5e-5
    r = rng.standard_normal(g.size) * np.sqrt(tau ** 2 + sig ** 2 * g)
    t_hat, s_hat = variance_model(r, g)
    assert t_hat == pytest.approx(tau, rel=0.15) and s_hat == pytest.approx(sig, rel=0.15)


def test_fit_results_round_trip_through_json():
    v = np.linspace(0.5, 2.5, 30)
    fit = fit_law("linear", v, 0.97 - 0.02 * v + 1e-3 * np.sin(7 * v))
    back = FitResult.from_json(fit.to_json())
    assert type(back) is type(fit) and back["gamma"].value == pytest.approx(fit["gamma"].value)
    assert back.predict([1.0])[0] == pytest.approx(fit.predict([1.0])[0])


def test_chained_fit_needs_enough_events():
    with pytest.raises(ValueError, match="too few"):
        fit_chained([{"name": "a", "times": [0.0, 0.5, 0.9], "numbers": [0, 1, 2]}], "linear",
                    flight_constants(None))


def test_errors_come_from_the_shared_covariance_rule():
    from impactid.engine.covariance import covariance_from_jacobian

    v = np.linspace(0.5, 2.5, 30)
    e = 0.97 - 0.02 * v + 1e-3 * np.sin(7 * v)
    fit = fit_law("linear", v, e)
    X = np.column_stack([np.ones(v.size), -v])
    bread = covariance_from_jacobian(X, 1.0)
    assert fit.statistics["condition_number"] == pytest.approx(bread.condition, rel=1e-12)
    scale2 = fit.statistics["scale"] ** 2
    model = np.array(fit.details["covariance_model"])
    assert np.allclose(model, scale2 * bread.matrix, rtol=1e-12, atol=0)
    corr = np.array(fit.details["correlation"])
    assert np.allclose(np.diag(corr), 1.0) and np.allclose(corr, corr.T) and -1 < corr[0, 1] < 1


def test_speeds_that_cannot_separate_the_parameters_leave_them_undetermined():
    v = np.full(20, 1.3)  # one speed: e0 and gamma are not separable
    e = 0.94 + 1e-3 * np.sin(np.arange(20.0))
    fit = fit_law("linear", v, e)
    assert not np.isfinite(fit["gamma"].stderr) and not np.isfinite(fit["e0"].stderr)
    assert "undetermined" in fit["gamma"].note and any("condition number" in n for n in fit.notes)
    assert fit.statistics["condition_number"] > 1e13
    assert np.isfinite(fit_law("constant", v, e)["e"].stderr)  # the constant law is still determined


def test_a_law_that_misses_the_trend_is_reported_as_a_lack_of_fit():
    rng = np.random.default_rng(3)
    v = np.linspace(0.5, 2.5, 60)
    e = 0.97 - 0.03 * v + 0.002 * rng.standard_normal(v.size)
    constant, linear = fit_law("constant", v, e), fit_law("linear", v, e)
    assert constant.statistics["runs_z"] < -3 and any("lack of fit" in n for n in constant.notes)
    assert abs(linear.statistics["runs_z"]) < 3 and not any("lack of fit" in n for n in linear.notes)


def test_runs_check_counts_sign_changes():
    from impactid.rigs.ball.laws import runs_check

    v = np.arange(12.0)
    alternating = runs_check(v, (-1.0) ** np.arange(12))
    assert alternating.runs == 12 and alternating.z > 3 and not alternating.fails
    blocks = runs_check(v[::-1], np.r_[np.ones(6), -np.ones(6)])  # ordered by v, not by position
    assert blocks.runs == 2 and blocks.fails
    assert not np.isfinite(runs_check(v[:5], np.ones(5)).z)  # too few to test


def test_grouped_differences_give_the_dense_jacobian():
    """The chained fit's Jacobian, its central differences grouped by drop, equals column-by-column differences."""
    from scipy.optimize._numdiff import approx_derivative

    from impactid.rigs.ball.laws import _chain_data, _chain_jacobian, _chain_start, _chain_times

    constants = flight_constants(TABLE_TENNIS)
    drops = []
    for j, h in enumerate((0.1, 0.2, 0.3)):
        t = simulate_drop("linear", {"e0": 0.96, "gamma": 0.02}, ball=TABLE_TENNIS, height=h, min_flight=0.1)["times"]
        keep = np.r_[0:3, 4:t.size]  # a missed bounce
        drops.append({"name": f"d{j}", "times": t[keep] + 1e-4 * j, "numbers": keep})
    spec, data = get_law("linear"), _chain_data(drops)
    x = _chain_start(spec, drops, constants, [0.95, 0.01])

    def residuals(u):
        return (data.observed - _chain_times(spec, u[:2], u[2::2], u[3::2], data.numbers, data.mask, constants))[
            data.mask]

    grouped = _chain_jacobian(residuals, 2, data)(x)
    dense = approx_derivative(residuals, x, method="3-point")
    assert grouped.shape == dense.shape
    assert np.allclose(grouped, dense, rtol=1e-7, atol=1e-9 * np.abs(dense).max())


def test_chained_fit_reports_its_condition_and_correlation(clean_drops):
    result = analyse_bounces([d.times for d in clean_drops], ball=TABLE_TENNIS, law="linear", compare_no_drag=False)
    chained = result.chained_fits["linear"]
    assert 1.0 <= chained.statistics["condition_number"] < 1e13
    corr = np.array(chained.details["correlation"])
    assert corr.shape == (2, 2) and np.allclose(np.diag(corr), 1.0)

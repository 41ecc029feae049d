"""``fit_drop`` on drops made by the independent ``solve_ivp`` reference: recovery without noise, interval
coverage with 0.5 % noise, the model check, and the errors a user can cause. The coverage over 100
noise seeds is measured by ``benchmarks/validate_drop.py`` (a validation script, not a test)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from impactid.results import FitResult
from impactid.rigs.drop import fit_drop
from impactid.rigs.drop.identify import IdentificationError
from impactid.rigs.drop.measure import MeasurementError
from tests.rigs.drop import reference_drop as R
from tests.rigs.drop.conftest import HEIGHTS

NAMES = ("k", "beta", "n")


def _truth(rig, law):
    return {"k": rig.k, "beta": law.beta, "n": law.n}


def _errors(fit, truth):
    return {name: fit.value(name) / truth[name] - 1.0 for name in NAMES}


def test_noise_free_recovery(reference_drops, rig, law):
    fit = fit_drop([rec for rec, _ in reference_drops])
    errors = _errors(fit, _truth(rig, law))
    assert all(abs(e) < 0.01 for e in errors.values()), errors  # the requirement
    assert all(abs(e) < 1e-6 for e in errors.values()), errors  # what the fit achieves (about 1e-9)
    assert fit.statistics["n_impacts"] >= 5 and fit.statistics["success"]
    assert fit["p"].fixed and fit["p"].value == 1.5
    assert fit["k"].unit == "N/m^1.5" and fit["beta"].unit == "N s/m^(n+1)"


def test_noisy_intervals_cover_the_truth(noisy_reference_drops, rig, law):
    fit = fit_drop([rec for rec, _ in noisy_reference_drops])
    truth = _truth(rig, law)
    for name in NAMES:
        assert fit[name].contains(truth[name]), (name, fit[name])
    # and they are informative: k to a fraction of a percent, n to a few percent
    assert fit["k"].stderr / fit.value("k") < 0.005
    assert fit["n"].stderr < 0.05
    assert 0.8 < fit.statistics["reduced_chi_square"] < 1.25
    assert not any("lack of fit" in note or "significantly" in note for note in fit.notes)


def test_fit_never_reads_the_rigs_stiffness(reference_drops, rig, law):
    recs = [rec for rec, _ in reference_drops]
    wrong = [rec.with_rig(rig.replace(k=3.0 * rig.k)) for rec in recs]
    a, b = fit_drop(recs), fit_drop(wrong)
    for name in NAMES:
        assert b.value(name) == pytest.approx(a.value(name), rel=1e-9)


def test_fixed_index_and_measured_speeds(reference_drops, rig, law):
    recs = [rec for rec, _ in reference_drops]
    fixed = fit_drop(recs, fix_n=1.5)
    assert fixed["n"].fixed and fixed.value("n") == 1.5
    assert abs(fixed.value("k") / rig.k - 1) < 1e-6 and abs(fixed.value("beta") / law.beta - 1) < 1e-6
    held = fit_drop(recs, speeds="measured")
    errors = _errors(held, _truth(rig, law))
    assert all(abs(e) < 0.01 for e in errors.values()), errors
    # the flight-time speeds are good to about 1e-5: far above the noise-free floor, and the check says so
    assert any("lack of fit" in note for note in held.notes)


def test_parameters_carry_the_bounds_of_the_search(reference_drops):
    """The engine reports every parameter as lmfit does: value, bounds, and whether it varied."""
    recs = [rec for rec, _ in reference_drops]
    fit = fit_drop(recs, max_impacts=2)
    k_start = fit.details["k_start"]
    assert fit["k"].vary and fit["k"].min == pytest.approx(k_start / 100)
    assert fit["k"].max == pytest.approx(100 * k_start)
    assert fit["n"].vary and (fit["n"].min, fit["n"].max) == (0.5, 3.0) and fit["beta"].min < fit.value("beta")
    assert len(fit.to_pandas("starts")) == 3 and fit.statistics["n_start"] in (1.0, 1.5, 2.0)
    fixed = fit_drop(recs, fix_n=1.5, max_impacts=2)
    assert not fixed["n"].vary and fixed["n"].stderr == 0.0
    assert fixed.statistics["nvarys"] == fit.statistics["nvarys"] - 1


@pytest.mark.parametrize("channel", ["impactor_acceleration", "contact_force"])
def test_one_channel_is_enough(reference_drops, rig, law, channel):
    fit = fit_drop([rec for rec, _ in reference_drops], channels=[channel])
    assert fit.statistics["channels"] == channel
    assert all(abs(e) < 1e-6 for e in _errors(fit, _truth(rig, law)).values())


def test_wrong_model_is_reported(rig, law):
    # the reference with a stiffer exponent (p = 1.6) fitted as p = 1.5: the model check notices the
    # misfit, and the intervals (the model's) miss the truth
    other = rig.replace(p=1.6, k=rig.k * 3e-4 ** -0.1)
    recs = [R.reference_recording(other, law.beta, law.n, h, noise=0.005, seed=1 + i)[0].with_rig(rig)
            for i, h in enumerate(HEIGHTS)]
    fit = fit_drop(recs)
    assert fit.statistics["reduced_chi_square"] > 1.5
    assert any("exceeds its noise" in note or "lack of fit" in note for note in fit.notes)


def test_result_round_trip_and_figure(reference_drops):
    fit = fit_drop([rec for rec, _ in reference_drops], max_impacts=2)
    back = FitResult.from_json(fit.to_json())
    assert type(back).__name__ == "DropFit" and back.value("k") == pytest.approx(fit.value("k"))
    table = fit.to_pandas("impacts")
    assert len(table) == fit.statistics["n_impacts"] <= 4
    assert {"onset_time_fitted_s", "approach_speed_fitted_m_s", "peak_force_model_n"} <= set(table.columns)
    figure = fit.plot(impacts=3)
    assert len(figure.axes) == 3 * 3  # two channels and the residuals, three impacts
    assert "[m/s$^2$]" in figure.axes[0].get_ylabel()


# ---- bad inputs ---------------------------------------------------------------------------------


def test_bad_options(reference_drops):
    recs = [rec for rec, _ in reference_drops]
    with pytest.raises(IdentificationError, match="speeds must be"):
        fit_drop(recs, speeds="guess")
    with pytest.raises(IdentificationError, match="confidence must lie in"):
        fit_drop(recs, confidence=95)
    with pytest.raises(IdentificationError, match="fix_n must be"):
        fit_drop(recs, fix_n=-1.0)
    with pytest.raises(IdentificationError, match="max_impacts"):
        fit_drop(recs, max_impacts=0)
    with pytest.raises(IdentificationError, match="no recording"):
        fit_drop([])
    with pytest.raises(IdentificationError, match="n_starts must lie"):
        fit_drop(recs, n_starts=(5.0,))


def test_channel_the_recording_lacks(rig, law):
    rec, _ = R.reference_recording(rig, law.beta, law.n, 0.05, channels=("impactor_acceleration",))
    with pytest.raises(IdentificationError, match="reference drop from 0.05 m: no channel contact_force"):
        fit_drop(rec, channels=["contact_force"])


def test_recordings_of_different_exponents(reference_drops, rig):
    recs = [reference_drops[0][0], reference_drops[1][0].with_rig(rig.replace(p=1.0))]
    with pytest.raises(IdentificationError, match="different stiffness exponents"):
        fit_drop(recs)


def test_not_a_drop_rig(reference_drops):
    from impactid.rigs.pivoted import SUNDAR2016

    rec = reference_drops[0][0]
    with pytest.raises(MeasurementError, match="needs a 'drop-impact' rig.*'pivoted-follower'"):
        fit_drop(rec.with_rig(SUNDAR2016))


def test_no_impact(rig):
    from impactid.io import Recording

    rec = Recording(channels={"impactor_acceleration": np.zeros(4096)}, sample_rate_hz=51_200.0,
                    units={"impactor_acceleration": "m/s^2"}, rig=rig, source="flat.h5")
    with pytest.raises(MeasurementError, match="flat.h5.*never positive"):
        fit_drop(rec)
    assert math.isfinite(rig.k)

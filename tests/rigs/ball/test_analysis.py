"""The whole job on synthetic drops: drag, notes, refusals, the result object."""

import numpy as np
import pytest

from impactid.results import FitResult
from impactid.rigs.ball import TABLE_TENNIS, BounceAnalysis, BounceAnalysisError, analyse_bounces
from impactid.rigs.ball.analysis import BOUNCE_COLUMNS


@pytest.fixture(scope="module")
def result(faulty_drops):
    return analyse_bounces([d.times for d in faulty_drops], ball=TABLE_TENNIS)


def test_table_has_every_interval_with_a_reason(result, faulty_drops):
    table = result.bounces
    assert list(table.columns) == BOUNCE_COLUMNS
    assert len(table) == sum(d.times.size - 1 for d in faulty_drops)
    assert table["reason"].str.len().min() > 5
    used = table[table["used"]]
    assert np.all(np.isfinite(used["e"])) and np.all(used["impact_speed_m_s"] > 0)
    assert set(table["flag"]) >= {"ok", "missed", "release", "end"}
    assert (table.loc[~table["used"] & np.isfinite(table["e"].astype(float)), "e_note"] != "").all()


def test_recovers_the_law_with_drag(result):
    fit = result.law_fits["linear"]
    assert fit["e0"].contains(0.96) and fit["gamma"].contains(0.02)
    assert result.selected in ("linear", "viscoelastic")


def test_drag_note_and_no_drag_slope(result):
    no_drag = result.no_drag_fits["linear"]
    assert no_drag["gamma"].value > result.law_fits["linear"]["gamma"].value + 0.01
    assert any("without drag" in n for n in result.notes)


@pytest.mark.slow
def test_light_ball_constant_law_drag_explains_the_slope():
    from impactid.rigs.ball.synth import simulate_drop

    drops = [simulate_drop("constant", {"e": 0.95}, ball=TABLE_TENNIS, height=h, min_flight=0.08)["times"]
             for h in (0.1, 0.2, 0.3, 0.45)]
    res = analyse_bounces(drops, ball=TABLE_TENNIS, chained=False)
    assert res.selected == "constant"
    assert any("drag, not the contact" in n for n in res.notes)
    vac = analyse_bounces(drops, chained=False)
    assert any("no ball given" in n and "terminal speed were about" in n for n in vac.notes)


def test_json_round_trip_and_report(result):
    back = FitResult.from_json(result.to_json())
    assert isinstance(back, BounceAnalysis)
    assert back.selected == result.selected
    assert back["linear.gamma"].value == pytest.approx(result["linear.gamma"].value)
    assert "linear.gamma" in result.report()
    summary = back.summary()
    assert {"constant", "linear", "selected", "bounces"} <= set(summary)


@pytest.mark.slow
def test_figures_are_figures(result):
    from matplotlib.figure import Figure

    assert isinstance(result.plot(), Figure)
    assert isinstance(result.plot_intervals(), Figure)


def test_refused_drop_is_reported_and_the_rest_analysed(faulty_drops):
    metronome = np.cumsum(np.full(12, 0.2))
    res = analyse_bounces([faulty_drops[3].times, faulty_drops[4].times, metronome], chained=False)
    assert res.statistics["drops_refused"] == 1
    assert any("refused" in n for n in res.notes)
    assert set(res.bounces[res.bounces["drop"] == 2]["flag"]) == {"refused"}


def test_nothing_usable_is_an_error():
    with pytest.raises(BounceAnalysisError, match="no usable bouncing sequence"):
        analyse_bounces([np.cumsum(np.full(12, 0.2))])
    with pytest.raises(ValueError, match="valid"):
        analyse_bounces([np.arange(5.0)], law="cubic")


def test_chained_fits_are_checked_against_the_timing_noise(result):
    noise = result.statistics["timing_sigma_s"]
    chained = result.chained_fits
    assert chained["linear"].statistics["timing_noise_s"] == pytest.approx(noise)
    # the law the drops were made with describes whole drops to the timing noise; a constant e does not
    assert chained["linear"].statistics["residual_over_timing_noise"] < 1.5
    assert not any("lack of fit" in n for n in chained["linear"].notes)
    assert chained["constant"].statistics["residual_over_timing_noise"] > 5
    assert any("lack of fit" in n for n in chained["constant"].notes)
    assert not any("chained fit of the linear law: lack of fit" in n for n in result.notes)


def test_per_impact_laws_are_checked_for_a_trend_they_miss(result):
    # the drops follow e = 0.96 - 0.02 v: a constant e leaves long runs of one sign along v
    assert any(n.startswith("constant law: lack of fit") for n in result.notes)
    assert not any(n.startswith("linear law: lack of fit") for n in result.notes)
    assert abs(result.law_fits["linear"].statistics["runs_z"]) < 3

"""The figures of ``impactid planar fit``: a few impacts' measured and predicted outcomes, and predicted
against measured over every impact (``--plots``, ``--figure-format``, embedded in ``--report``)."""

from __future__ import annotations

import json
import math
import re
from dataclasses import replace

import numpy as np
import pytest

from impactid.cli import main
from impactid.rigs.planar import MCUBE_ELLIPSE
from impactid.rigs.planar.figures import (
    IMPACTS_SHOWN,
    planar_prediction,
    plot_planar_agreement,
    plot_planar_impacts,
)
from impactid.rigs.planar.identify import fit_planar_law
from impactid.rigs.planar.table import read_impacts
from tests.rigs.planar.reference_planar import random_impacts, reference_impulses, write_table

PREDICTED = "after: predicted by the fitted law"
MEASURED = "after: measured"


def _panel(fig, symbol: str):
    """The axes whose x label names ``symbol`` (mathtext)."""
    return next(ax for ax in fig.axes if symbol in ax.get_xlabel())


def _line(ax, label: str):
    """The (x, y) data of the line labelled ``label`` (its legend is the figure's)."""
    for line in ax.get_lines():
        if line.get_label() == label:
            return np.asarray(line.get_xdata(), float), np.asarray(line.get_ydata(), float)
    raise AssertionError(f"no line {label!r} in {ax.get_xlabel()!r}")


def _shown_impacts(fig) -> list[int]:
    ticks = [t.get_text() for t in fig.axes[0].get_yticklabels()]
    return [int(re.match(r"impact (\d+):", t).group(1)) for t in ticks]


def test_fit_plots_report_and_formats(tmp_path, table, capsys):
    plots, report = tmp_path / "figures", tmp_path / "report.html"
    assert main(["planar", "fit", str(table), "--body", "mcube-ellipse", "--law", "newton-linear-et",
                 "--plots", str(plots), "--report", str(report), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert sorted(data["plots"]) == [str(plots / "planar_agreement.png"), str(plots / "planar_impacts.png")]
    assert all((plots / name).stat().st_size > 10_000 for name in ("planar_agreement.png", "planar_impacts.png"))
    page = report.read_text()
    assert page.count("data:image/png;base64,") == 2 and "planar_impacts.png" in page
    assert main(["planar", "fit", str(table), "--body", "mcube-ellipse", "--law", "newton-linear-et",
                 "--plots", str(tmp_path / "svg"), "--figure-format", "svg", "--json"]) == 0
    assert sorted(p.name for p in (tmp_path / "svg").iterdir()) == ["planar_agreement.svg", "planar_impacts.svg"]
    # an output folder that is an input is refused before any work
    assert main(["planar", "fit", str(table), "--body", "mcube-ellipse", "--plots", str(table)]) == 2
    assert "--plots" in capsys.readouterr().err


def test_the_impacts_figure_shows_the_laws_prediction(tmp_path, table):
    """The crosses are the fitted law's outcome of the impacts shown (the fit's own table), the dots the
    measured one; a wrong law moves the crosses off the dots."""
    impacts = read_impacts(table)
    result = fit_planar_law(impacts, MCUBE_ELLIPSE, "newton-linear-et")
    fig = plot_planar_impacts(planar_prediction(result, impacts))
    shown = _shown_impacts(fig)
    speeds = -np.sum(impacts.jn * impacts.v_pre, axis=1)
    assert len(shown) == IMPACTS_SHOWN and np.all(np.diff(speeds[np.asarray(shown) - 1]) >= 0)
    assert speeds[shown[0] - 1] == speeds.min() and speeds[shown[-1] - 1] == speeds.max()
    fitted = result.tables["impacts"].set_index("impact").loc[shown]
    ax = _panel(fig, "p_t")
    np.testing.assert_allclose(_line(ax, PREDICTED)[0], fitted["impulse_t_fit"], rtol=1e-12)
    np.testing.assert_allclose(_line(ax, MEASURED)[0], fitted["impulse_t"], rtol=1e-12)
    omega = _panel(fig, r"\omega")
    np.testing.assert_allclose(_line(omega, MEASURED)[0], impacts.v_post[np.asarray(shown) - 1, 2])
    close = np.abs(_line(omega, PREDICTED)[0] - _line(omega, MEASURED)[0])
    assert np.all(close < 0.1 * np.abs(_line(omega, MEASURED)[0]).max())
    wrong = replace(result, params={**result.params, "e0": replace(result.params["e0"], value=0.3)})
    off = plot_planar_impacts(planar_prediction(wrong, impacts))
    pn = _panel(off, "p_n")
    assert np.all(_line(pn, PREDICTED)[0] < 0.85 * _line(pn, MEASURED)[0])


def test_agreement_over_every_impact(tmp_path, table):
    impacts = read_impacts(table)
    result = fit_planar_law(impacts, MCUBE_ELLIPSE, "newton-linear-et")
    fig = plot_planar_agreement(planar_prediction(result, impacts))
    panels = [ax for ax in fig.axes if ax.axison]
    assert len(panels) == 5  # three velocity components and two impulse components
    for ax in panels:
        points = [line for line in ax.get_lines() if line.get_label().endswith("(predicted)")]
        assert sum(len(line.get_xdata()) for line in points) == len(impacts)
        assert re.search(r"RMS difference \d", ax.get_title())


def test_a_table_without_impulses(tmp_path, synthetic):
    v, jt, jn, _, v_post = synthetic
    path = write_table(tmp_path / "velocities.csv", v, jt, jn, v_post=v_post)
    assert main(["planar", "fit", str(path), "--body", "mcube-ellipse", "--law", "newton-linear-et",
                 "--plots", str(tmp_path / "p"), "--json"]) == 0
    impacts = read_impacts(path)
    result = fit_planar_law(impacts, MCUBE_ELLIPSE, "newton-linear-et")
    prediction = planar_prediction(result, impacts)
    agreement = plot_planar_agreement(prediction)
    assert len([ax for ax in agreement.axes if ax.axison]) == 3
    fig = plot_planar_impacts(prediction)
    ax = _panel(fig, "p_n")  # the impulse is predicted, not measured: said on the panel
    assert [t.get_text() for t in ax.texts] == ["not measured"]
    assert PREDICTED in [line.get_label() for line in ax.get_lines()]


def test_undetermined_friction_and_no_prediction(tmp_path):
    """Every impact sticks: mu stands at its lower bound (said in the title); a law whose parameter is
    undetermined without a bound predicts nothing, and the figures say so instead of dropping it."""
    v, jt, jn = random_impacts(30, seed=3)
    minv = np.asarray(MCUBE_ELLIPSE.inverse_mass)
    p = reference_impulses(v, jt, jn, minv, 0.6, 1.5, 0.0)
    path = write_table(tmp_path / "sticking.csv", v, jt, jn, impulse=p, v_post=v + minv * (jt * p[:, :1]
                                                                                           + jn * p[:, 1:]))
    impacts = read_impacts(path)
    result = fit_planar_law(impacts, MCUBE_ELLIPSE, "newton-constant-stick")
    assert not math.isfinite(result.value("mu"))
    prediction = planar_prediction(result, impacts)
    assert prediction.predicted is not None and "mu at its lower bound" in prediction.note
    assert "mu at its lower bound" in plot_planar_impacts(prediction)._suptitle.get_text()
    np.testing.assert_allclose(prediction.predicted.p_n, p[:, 1], rtol=1e-6)
    undetermined = replace(result, params={**result.params, "e": replace(result.params["e"], value=math.nan,
                                                                         interval=(math.nan, math.nan))})
    none = planar_prediction(undetermined, impacts)
    assert none.predicted is None and "e undetermined" in none.note
    fig = plot_planar_agreement(none)
    assert any("e undetermined" in t.get_text() for ax in fig.axes for t in ax.texts)
    assert PREDICTED not in [line.get_label() for ax in plot_planar_impacts(none).axes for line in ax.get_lines()]


@pytest.mark.parametrize("count", [1, 3])
def test_few_impacts_shown(table, count):
    impacts = read_impacts(table)
    result = fit_planar_law(impacts, MCUBE_ELLIPSE, "newton-constant-stick", profiles=False)
    assert len(_shown_impacts(plot_planar_impacts(planar_prediction(result, impacts), count=count))) == count

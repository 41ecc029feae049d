"""The figures of ``impactid restitution``: measured first impacts against their simulation with the fitted
law from the same pre-impact state, and the law over cam speed (``--plots``, ``--report``)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from impactid.cli import main
from impactid.io import read_recording
from impactid.rigs import ALZATE2007
from impactid.rigs.flat.encoder_impacts import fit_speed_law, restitution_at_speed
from impactid.rigs.flat.figures import IMPACTS_SHOWN, impact_overlays, plot_restitution_impacts, plot_restitution_law
from impactid.rigs.flat.simulate import SpeedRestitution
from impactid.rigs.flat.synth_impacts import synth_flat_impacting

SPEEDS_RPM = (134.0, 148.0)


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    folder = tmp_path_factory.mktemp("rigF_figures")
    return [str(synth_flat_impacting(ALZATE2007, rpm / 60.0, 1.6, cam_zero_offset=0.7 + rpm / 90.0)
                .write(folder / f"impacting_{rpm:.0f}.h5")) for rpm in SPEEDS_RPM]


@pytest.fixture(scope="module")
def fitted(recordings):
    recs = [read_recording(path, check=False) for path in recordings]
    points = [restitution_at_speed(rec, warn=False) for rec in recs]
    return recs, points, fit_speed_law(points)


def _largest_residual(overlay, after: bool) -> float:
    """The largest measured minus simulated follower angle after (or before) the impact [rad]."""
    side = overlay.time > 0.0 if after else overlay.time < 0.0
    return float(np.nanmax(np.abs(overlay.residual[side])))


def test_command_writes_the_figures_and_embeds_them(recordings, tmp_path, capsys):
    plots, report = tmp_path / "figures", tmp_path / "report.html"
    assert main(["restitution", *recordings, "--plots", str(plots), "--report", str(report), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["plots"] == [str(plots / "restitution_impacts.png"), str(plots / "restitution_law.png")]
    assert all(p.stat().st_size > 10_000 for p in plots.iterdir())
    page = report.read_text()
    assert page.count("data:image/png;base64,") == 2 and "restitution_impacts.png" in page
    assert main(["restitution", *recordings, "--plots", recordings[0]]) == 2  # an input: refused, nothing written
    assert "--plots" in capsys.readouterr().err


def test_the_fitted_law_reproduces_the_measured_impacts(fitted):
    """The simulation from the measured pre-impact state with the fitted law follows the encoder to within a
    count through the impact, its bounce and what follows; a wrong law does not."""
    recs, points, result = fitted
    overlays = impact_overlays(points, recs, result.law)
    assert len(overlays) == IMPACTS_SHOWN
    assert [round(o.cam_speed_rpm) for o in overlays] == [134, 134, 148, 148]
    assert all(o.number != p.number for o, p in zip(overlays[::2], overlays[1::2]))  # spread over the recording
    step = overlays[0].follower_step
    for overlay in overlays:
        assert not overlay.note and overlay.restitution_law == pytest.approx(result.law(overlay.cam_speed_rpm / 60))
        assert overlay.time.min() < -0.02 and overlay.time.max() > 0.02
        assert _largest_residual(overlay, after=False) < step and _largest_residual(overlay, after=True) < step
    wrong = impact_overlays(points, recs, SpeedRestitution(a=0.35))
    assert all(_largest_residual(overlay, after=False) < step for overlay in wrong)  # the same pre-impact state
    assert all(_largest_residual(overlay, after=True) > 3.0 * step for overlay in wrong)
    fig = plot_restitution_impacts(overlays)
    assert len(fig.axes) == 2 * IMPACTS_SHOWN
    simulated = [line for line in fig.axes[0].get_lines() if line.get_label().startswith("simulated")]
    assert len(simulated) == 1 and f"{overlays[0].restitution_law:.3f}" in simulated[0].get_label()


def test_an_impact_that_cannot_be_simulated_is_shown_and_said(fitted):
    recs, points, result = fitted
    for law, needle in ((None, "law is undetermined"), (SpeedRestitution(a=1.4), "outside [0, 1]")):
        overlays = impact_overlays(points, recs, law, count=2)
        assert len(overlays) == 2
        for overlay in overlays:
            assert overlay.simulated is None and needle in overlay.note and overlay.measured.size > 100
        fig = plot_restitution_impacts(overlays)
        assert any(needle in " ".join(text.get_text().split()) for ax in fig.axes for text in ax.texts)
        assert [line.get_label() for line in fig.axes[0].get_lines()][0] == "measured (follower encoder)"


def test_the_law_figure(fitted):
    _, points, result = fitted
    ax = plot_restitution_law(result).axes[0]
    rpm, r = (np.asarray(v, float) for v in ax.get_lines()[0].get_data())
    np.testing.assert_allclose(rpm, [p.cam_speed_rpm for p in points])
    np.testing.assert_allclose(r, [p.restitution for p in points])
    grid, law = (np.asarray(v, float) for v in ax.get_lines()[-1].get_data())
    np.testing.assert_allclose(law, [result.law(x / 60.0) for x in grid], rtol=1e-12)

"""The real table-tennis trajectories (not in the repository): every bounce analysed or explained,
the table-tennis rule's band beside the restitution at 2-3 m/s.

Set ``IMPACTID_REALDATA_TRACKS`` to the folder that holds ``spindoe/`` (the SpinDOE trajectories of
Gossard et al. 2023, with their ``index.csv``; ``.ci/run`` sets it when the folder is there); without
it these tests are skipped.
"""

import os
from pathlib import Path

import pytest

from impactid.rigs.tracks import analyse_tracks, read_track
from impactid.rigs.tracks.readers import is_spin_index

ROOT = Path(os.environ.get("IMPACTID_REALDATA_TRACKS") or "/nonexistent")
pytestmark = pytest.mark.skipif(not (ROOT / "spindoe").is_dir(),
                                reason="set IMPACTID_REALDATA_TRACKS to the real ball tracks")


@pytest.fixture(scope="module")
def analysis():
    files = [p for p in sorted((ROOT / "spindoe").glob("*.csv")) if not is_spin_index(p)]
    return analyse_tracks([read_track(p) for p in files])


def test_every_bounce_is_analysed_or_explained(analysis):
    table = analysis.bounces
    assert analysis.statistics["tracks"] >= 90
    assert analysis.statistics["bounces_analysed"] >= 55  # measured: 63 of 67
    assert (table["analysed"] | (table["reason"].str.len() > 0)).all()
    used = table[table["analysed"]]
    assert (used["e_n_high"] > used["e_n_low"]).all() and (used["beta_t_high"] > used["beta_t_low"]).all()


def test_rule_band_and_tracks_are_compared(analysis):
    rule = analysis.details["rule"]
    assert 0.87 < rule["e_low"] < rule["e_high"] < 0.95
    assert analysis.statistics["bounces_in_speed_band"] >= 30
    e = analysis["e_n_speed_band"]
    assert 0.85 < e.value < 1.0 and e.interval[1] - e.interval[0] < 0.05
    assert "overlaps" in rule


@pytest.mark.slow
def test_lift_tilt_and_air_model_share():
    """The lift scale estimated, the table's tilt found, and the air model's share stated for the
    per-bounce and the pooled restitution and for the rule's band (measured: lift scale 0.27
    [0.11, 0.43], slope along y 7.8 +- 0.6 mm/m), with the slopes' share in the restitution's intervals."""
    files = [p for p in sorted((ROOT / "spindoe").glob("*.csv")) if not is_spin_index(p)]
    res = analyse_tracks([read_track(p) for p in files], estimate_lift=True, air_share=True)
    lift = res["lift_scale"]
    assert 0.0 < lift.interval[0] < lift.value < lift.interval[1] < 1.0  # the published scale 1 is outside
    assert res.details["surface_plane"]["tilted"] and res["surface.slope_y"].interval[0] > 0.0
    # the slopes' errors are carried into e_n (measured: 0.0026 on the pooled e_n at 2-3 m/s)
    share = res.details["surface_share"]
    assert share["carried"] and 0.0 < share["e_n_speed_band"] < res["e_n_speed_band"].stderr
    used = res.bounces[res.bounces["analysed"]]
    assert (used["e_n_surface_stderr"] > 0).all() and (used["e_n_stderr"] > used["e_n_fit_stderr"]).all()
    stat, air = res["e_n_speed_band"], res["e_n_speed_band_air"]
    assert air.interval[0] < stat.interval[0] and air.interval[1] > stat.interval[1]
    rule = res.details["rule"]
    assert "overlaps_with_air_model" in rule and rule["band_over_drag_range"][0] < rule["e_low"]
    used = res.bounces[res.bounces["analysed"]]
    assert (used["e_n_air_low"] <= used["e_n_low"]).all() and (used["e_n_air_high"] >= used["e_n_high"]).all()


def test_measured_spin_is_used_for_the_first_bounce_only(analysis):
    """The measured spin of a trajectory is its first bounce's; a second bounce of the same trajectory
    takes the first's outgoing spin (measured: two trajectories with two bounces)."""
    fitted = analysis.bounces[analysis.bounces["spin_source"] != ""].sort_values("t_min_s")
    assert len(fitted) > 0
    later = 0
    for _, rows in fitted.groupby("track"):
        sources = list(rows["spin_source"])
        assert sources[0] == "given"
        assert all(s in ("propagated", "estimated") for s in sources[1:])
        later += len(sources) - 1
        if len(sources) > 1 and sources[1] == "propagated":
            first, second = rows.iloc[0], rows.iloc[1]
            assert second["spin_in_x_rad_s"] == pytest.approx(first["spin_out_x_rad_s"])
            assert second["spin_in_rad_s"] != pytest.approx(first["spin_in_rad_s"], rel=1e-6)
    assert later >= 1

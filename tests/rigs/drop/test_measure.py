"""``measure_impacts``: the impacts of drops made by the reference, measured against the reference's own
impact table; baseline, noise, the final rest, and the errors a user can cause."""

from __future__ import annotations

import numpy as np
import pytest

from impactid.io import Recording
from impactid.rigs.drop import DropLaw, measure_impacts
from impactid.rigs.drop.measure import MeasurementError

FS = 51_200.0


def test_impacts_match_the_reference(reference_drops, rig):
    rec, impacts = reference_drops[0]
    obs = measure_impacts(rec)
    table = obs.impacts
    assert len(table) >= 3 and obs.noise["impactor_acceleration"] == 0.0
    for i, row in table.iterrows():
        ref = impacts[i]
        assert abs(row.onset_time_s - ref["t_onset"]) < 0.5 / FS  # measured: 0.15 sample
        assert abs(row.end_time_s - ref["t_end"]) < 0.5 / FS
        assert row.peak_force_n == pytest.approx(ref["peak_force"], rel=5e-3)
        assert row.approach_speed_m_s == pytest.approx(ref["v_onset"], rel=1e-4)
        assert row.separation_speed_m_s == pytest.approx(-ref["v_end"], rel=1e-3)
    assert table.approach_speed_from[0] == "drop height"
    assert table.approach_speed_m_s[0] == pytest.approx(rig.impact_speed(0.05), rel=1e-15)
    assert set(table.approach_speed_from[1:]) == {"flight time"}
    # each window holds the impact and a few samples of flight on either side
    assert np.all(table.window_start < table.first_sample) and np.all(table.window_stop > table.stop_sample)


def test_noise_and_onsets_with_noise(noisy_reference_drops):
    rec, impacts = noisy_reference_drops[0]
    obs = measure_impacts(rec)
    # the chain's noise is 0.5 % of each channel's peak (the mass is 1 kg: the same for both channels)
    peak = max(imp["peak_force"] for imp in impacts)
    assert obs.noise["contact_force"] == pytest.approx(0.005 * peak, rel=0.05)
    assert obs.noise["impactor_acceleration"] == pytest.approx(0.005 * peak / rec.rig.mass, rel=0.05)
    for i, row in obs.impacts.iterrows():
        assert abs(row.onset_time_s - impacts[i]["t_onset"]) < 1.0 / FS
        assert row.snr > 20


def test_baseline_offset_and_drift_are_removed(reference_drops):
    rec, _ = reference_drops[0]
    a = rec.channel("impactor_acceleration")
    t = np.arange(a.size) / FS
    shifted = Recording(channels={"impactor_acceleration": a + 3.0 + 4.0 * t}, sample_rate_hz=FS,
                        units={"impactor_acceleration": "m/s^2"}, rig=rec.rig, operating=dict(rec.operating),
                        start_time_s=rec.start_time_s)
    plain = measure_impacts(rec).impacts
    moved = measure_impacts(shifted)
    np.testing.assert_allclose(moved.impacts.onset_time_s, plain.onset_time_s, atol=1e-9)
    assert moved.baseline["impactor_acceleration"] == pytest.approx((3.0, 4.0), rel=1e-9)
    assert any("baseline" in note for note in moved.notes)


def test_the_final_rest_is_not_an_impact(rig):
    from impactid.rigs.drop import synth_drop_impact

    # a lossy pad (restitution 0.6 to 0.9): at rest after 1.3 s, recorded for 2 s
    rec = synth_drop_impact(rig, DropLaw(rig.k, 1.5), 0.05, duration=2.0).recording
    obs = measure_impacts(rec, max_impacts=None)
    assert any("below 5 % of the largest peak are not measured" in note for note in obs.notes)
    assert len(obs.impacts) > 10
    assert np.all(obs.impacts.restitution < 1.0) and np.all(np.diff(obs.impacts.restitution[:10]) > 0)
    # a recording that ends inside an impact: that impact is not measured, and the note says why
    third = obs.impacts.iloc[2]
    cut = rec.slice_time(rec.start_time_s, third.onset_time_s + 0.5 * third.contact_duration_s)
    short = measure_impacts(cut)
    assert len(short.impacts) == 2
    assert any("not a separated impact (it does not end before the recording does)" in note for note in short.notes)


def test_max_impacts_and_snr(noisy_reference_drops):
    rec, _ = noisy_reference_drops[0]
    assert len(measure_impacts(rec, max_impacts=2).impacts) == 2
    few = measure_impacts(rec, snr_min=150.0)
    assert len(few.impacts) < len(measure_impacts(rec).impacts)
    assert any("snr_min" in note for note in few.notes)


def test_without_the_drop_height_speeds_come_from_the_flights(reference_drops):
    rec, impacts = reference_drops[0]
    bare = Recording(channels=dict(rec.channels), sample_rate_hz=FS, units=dict(rec.units), rig=rec.rig,
                     start_time_s=rec.start_time_s)
    table = measure_impacts(bare).impacts
    assert table.approach_speed_from[0] == "impulse and the next flight"
    assert table.approach_speed_m_s[0] == pytest.approx(impacts[0]["v_onset"], rel=1e-3)


def test_errors_name_the_file_and_channel(reference_drops, rig):
    rec, _ = reference_drops[0]
    with pytest.raises(MeasurementError, match="has neither an 'impactor_acceleration' nor a 'contact_force'"):
        measure_impacts(Recording(channels={"other": np.ones(100)}, sample_rate_hz=FS, units={"other": "V"},
                                  rig=rig, source="x.h5"))
    with pytest.raises(MeasurementError, match="no channel 'contact_force' to find the impacts in"):
        measure_impacts(Recording(channels={"impactor_acceleration": rec.channel("impactor_acceleration")},
                                  sample_rate_hz=FS, units={"impactor_acceleration": "m/s^2"}, rig=rig),
                        detect="contact_force")
    # no pre-trigger: the recording starts inside the first impact's flight-free stretch
    first = int(measure_impacts(rec).impacts.first_sample[0])
    late = rec.slice_time(rec.start_time_s + (first - 2) / FS, rec.start_time_s + (first + 90) / FS)
    with pytest.raises(MeasurementError, match="free flight before and between the impacts.*pre-trigger"):
        measure_impacts(late)
    with pytest.raises(MeasurementError, match="snr_min must be positive"):
        measure_impacts(rec, snr_min=0.0)

"""Per-impact pipeline on synthetic recordings with known truth (issue 4).

Noise-free S2 recording at e/r_c = 0.2, 16 Hz (period-1 after 40 s settling). Measured errors of
every integration method and anchor are printed by ``benchmarks/bench_pipeline.py``.
"""

from __future__ import annotations

import itertools
import warnings

import numpy as np
import pytest

from impactid import SUNDAR2016, HuntCrossley
from impactid.events import EventWarning, find_events
from impactid.io import RecordingError
from impactid.rigs.pivoted.reconstruct import ANCHORS, reconstruct
from impactid.rigs.pivoted.synth import synth_pivoted
from impactid.signal import INTEGRATORS
from impactid.synth import SensorModel

COMBOS = list(itertools.product(INTEGRATORS, ANCHORS))


@pytest.fixture(scope="module")
def events(s2_synthetic):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a clean period-1 recording gives no warning
        return find_events(s2_synthetic.recording)


@pytest.fixture(scope="module")
def results(s2_synthetic, events):
    return {combo: reconstruct(s2_synthetic.recording, events, integration=combo[0], anchor=combo[1])
            for combo in COMBOS}


def truth_rows(truth, table):
    """Index of the true contact of each reconstructed event."""
    starts = truth["impacts"]["t_start"]
    return np.array([np.argmin(np.abs(starts - t)) for t in table["t_onset"]])


def true_alpha_m(truth, t_onset, period):
    ap = truth["apexes"]
    sel = (ap["t"] > t_onset) & (ap["t"] < t_onset + period)
    return ap["alpha"][sel].max()


def test_onsets_within_one_sample(s2_synthetic, events):
    truth = s2_synthetic.truth
    dt = 1 / s2_synthetic.recording.sample_rate_hz
    assert len(events) == 16 and events.usable.shape[0] == 15  # the last one has no next onset
    onset_error = np.abs(events.table["t_onset"].to_numpy() - truth["impacts"]["t_start"])
    separation_error = np.abs(events.table["t_separation"].to_numpy()[:-1] - truth["impacts"]["t_end"][:-1])
    assert np.all(onset_error < dt) and np.all(separation_error < dt)
    # the first contact sample is the first sample at or after the true onset
    first = events.table["onset_index"].to_numpy() * dt + s2_synthetic.recording.start_time_s
    assert np.all((first >= truth["impacts"]["t_start"]) & (first < truth["impacts"]["t_start"] + dt))


@pytest.mark.parametrize("combo", COMBOS, ids=["-".join(c) for c in COMBOS])
def test_alpha_within_1e4_of_peak_to_peak_at_every_sample(s2_synthetic, events, results, combo):
    truth = s2_synthetic.truth
    result = results[combo]
    pp = truth["alpha"].max() - truth["alpha"].min()
    for event in result.table.index:
        kin = result.event_kinematics(event)
        k0 = events.table.loc[event, "onset_index"]
        assert np.max(np.abs(kin.alpha - truth["alpha"][k0:k0 + kin.alpha.size])) < 1e-4 * pp


@pytest.mark.parametrize("combo", COMBOS, ids=["-".join(c) for c in COMBOS])
def test_xi_approach_speed_and_force(s2_synthetic, results, combo):
    truth = s2_synthetic.truth
    table = results[combo].table
    rows = truth_rows(truth, table)
    assert np.all(np.abs(table["xi"].to_numpy() - truth["impacts"]["xi"][rows]) < 1e-3)
    v_a = -truth["impacts"]["gap_rate_start"][rows]
    assert np.allclose(table["approach_speed"], v_a, rtol=1e-3)
    assert np.allclose(table["peak_force"], truth["impacts"]["peak_force"][rows], rtol=1e-3)


#: The time-domain rules: their event means are taken over the true onset-to-onset span and
#: their pulse edges corrected (impactid.signal.detrend_integrate). The spectral rule treats the
#: sampled window as periodic and is limited to ~2e-5 .. 6e-5 (see the README's table).
TIME_DOMAIN = [c for c in COMBOS if c[0] != "spectral"]


def _alpha_m_errors(synthetic, result, period):
    truth = synthetic.truth
    table = result.table
    exact = np.array([true_alpha_m(truth, t, period) for t in table["t_onset"]])
    return np.abs(table["alpha_m"].to_numpy() / exact - 1)


@pytest.mark.parametrize("combo", TIME_DOMAIN, ids=["-".join(c) for c in TIME_DOMAIN])
def test_alpha_m_within_1e5(s2_synthetic, results, combo):
    """Issue 4: alpha_m within 1e-5 relative (measured 0.4e-6 .. 6e-6)."""
    assert np.max(_alpha_m_errors(s2_synthetic, results[combo], 1 / 16)) < 1e-5


@pytest.mark.parametrize("combo", TIME_DOMAIN, ids=["-".join(c) for c in TIME_DOMAIN])
def test_alpha_m_within_1e5_incommensurate_sampling(s2_second_point, combo):
    """At 15 Hz a revolution is 13653.3 samples, so the onsets fall at a different sub-sample
    position in each event (at 16 Hz: 12800 samples, nearly the same): the sub-sample span of the
    event means and the edge corrections are what keep alpha_m within 1e-5 here."""
    result = reconstruct(s2_second_point.recording, integration=combo[0], anchor=combo[1])
    assert np.max(_alpha_m_errors(s2_second_point, result, 1 / 15)) < 1e-5


def test_alpha_m_spectral_within_3e5(s2_synthetic, results):
    """Regression guard for the spectral rule at its measured accuracy (1.5e-5 .. 2.1e-5)."""
    for anchor in ANCHORS:
        assert np.max(_alpha_m_errors(s2_synthetic, results[("spectral", anchor)], 1 / 16)) < 3e-5


def test_contact_force_from_pivot_forces(s2_synthetic, events, results):
    truth = s2_synthetic.truth
    result = results[("rk", "return-time")]
    for event, hist in result.contact.items():
        k0 = events.table.loc[event, "onset_index"]
        true_force = truth["contact_force"][k0:k0 + hist.t.size]
        assert np.max(np.abs(hist.contact_force - true_force)) < 1e-5 * true_force.max()


def test_input_recording_untouched_and_provenance(s2_synthetic, results):
    rec = s2_synthetic.recording
    before = {k: v.copy() for k, v in rec.channels.items()}
    result = reconstruct(rec, integration="trapezoid", anchor="cam-geometry")
    for k, v in rec.channels.items():
        assert np.array_equal(v, before[k])
    assert result.provenance[-2].startswith("find_events(") and result.provenance[-1].startswith("reconstruct(")


def test_unknown_names_and_missing_channels(s2_synthetic):
    rec = s2_synthetic.recording
    with pytest.raises(ValueError, match="valid: rk, trapezoid, simpson, spectral"):
        reconstruct(rec, integration="euler")
    with pytest.raises(ValueError, match="valid: return-time, cam-geometry"):
        reconstruct(rec, anchor="guess")
    no_cam = rec.with_step("drop cam_angle", channels={k: v for k, v in rec.channels.items() if k != "cam_angle"},
                           units={k: v for k, v in rec.units.items() if k != "cam_angle"})
    with pytest.raises(RecordingError, match="'cam-geometry' anchor needs channel\\(s\\) cam_angle"):
        reconstruct(no_cam, anchor="cam-geometry")
    only_cam = rec.with_step("cam only", channels={"cam_angle": rec["cam_angle"]}, units={"cam_angle": "rad"})
    with pytest.raises(RecordingError, match="event detection needs channel\\(s\\) accel_tangential"):
        find_events(only_cam)


def test_period2_and_irregular_recordings_are_told_by_the_motion():
    """Period-2 motion (two alternating impacts in two revolutions) is named as such and each event's window
    closes one period later; irregular motion warns that its onsets do not recur (and chatters)."""
    period2 = synth_pivoted(SUNDAR2016.with_eccentricity_ratio(0.15), 17.0, HuntCrossley(24.7e9, 1.5), 0.5)
    with pytest.warns(EventWarning, match=r"the motion is period-2: 2 impacts every 2 cam revolutions"):
        events = find_events(period2.recording)
    table = events.table
    assert table["not_period1"].all() and table["periodic"].all() and not table["riding"].any()
    ends = table["period_end"].to_numpy()
    np.testing.assert_array_equal(ends[:-2], np.arange(2, len(table)))
    assert np.all(ends[-2:] == -1) and not table["usable"].iloc[-2:].any()
    irregular = synth_pivoted(SUNDAR2016.with_eccentricity_ratio(0.2), 18.0, HuntCrossley(24.7e9, 1.5), 0.5)
    with pytest.warns(EventWarning) as caught:
        events = find_events(irregular.recording)
    messages = " | ".join(str(w.message) for w in caught)
    assert "chattering" in messages and "do not recur with the cam" in messages
    assert not events.table["periodic"].any()


def test_noisy_recording_degrades_gracefully():
    """0.5 % noise on every analogue channel: onsets stay within 2 samples; the angle degrades to
    about 3 % of its peak-to-peak (double integration of white noise over a revolution) and the
    reconstruction says where xi cannot be determined."""
    noisy = synth_pivoted(SUNDAR2016, 16.0, HuntCrossley(24.7e9, 1.5), 1.0,
                          sensors=SensorModel(noise=0.005, seed=1))
    events = find_events(noisy.recording)
    dt = 1 / noisy.recording.sample_rate_hz
    assert np.all(np.abs(events.table["t_onset"].to_numpy() - noisy.truth["impacts"]["t_start"]) < 2 * dt)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = reconstruct(noisy.recording, events)
    # the promised bound: the angle within 3 % of its peak-to-peak at every sample of every event
    pp = noisy.truth["alpha"].max() - noisy.truth["alpha"].min()
    worst = 0.0
    for event in result.table.index:
        kin = result.event_kinematics(event)
        k0 = events.table.loc[event, "onset_index"]
        worst = max(worst, float(np.max(np.abs(kin.alpha - noisy.truth["alpha"][k0:k0 + kin.alpha.size]))))
    assert worst < 0.03 * pp, f"angle error {worst / pp:.3%} of the peak-to-peak"
    xi = result.table["xi"].to_numpy()
    if not np.all(np.isfinite(xi)):
        assert any("xi are undetermined" in str(w.message) for w in caught)

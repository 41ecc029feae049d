"""Rig P beyond clean period-1 points: long nearly plastic contacts, period-k and multi-impact motion,
a follower riding the cam, irregular motion, and slow impacts near the top of the cam's lift.

The issue "No confident wrong answers" (items 1-3): each recording below gave a confident wrong estimate
(or a refusal with a wrong reason) before. Recordings come from impactid's generator and from the
independent solve_ivp reference (``tests/rigs/pivoted/reference_recordings.py``, started on the motion
that impactid's simulator settles to, so that it records period-k motion too). The truth is read only
to score.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from scipy import optimize

from impactid import SUNDAR2016, HuntCrossley
from impactid.errors import ImpactidError
from impactid.events import EventWarning, find_events
from impactid.pipeline import estimate
from impactid.rigs.pivoted.anchors import phase_profile_stderr
from impactid.rigs.pivoted.reconstruct import reconstruct
from impactid.rigs.pivoted.residuals import EventSet
from impactid.rigs.pivoted.runs import simulate
from impactid.rigs.pivoted.synth import synth_pivoted
from impactid.synth import SensorModel
from tests.rigs.pivoted import reference_recordings as RR

SETTLE_S = 40.0


def _synth(e_over_rc, cam_speed_hz, beta, n, duration=0.5, noise=0.0, seed=1, mu=0.0):
    return synth_pivoted(SUNDAR2016.with_eccentricity_ratio(e_over_rc), cam_speed_hz, HuntCrossley(beta, n), duration,
                         settle_s=SETTLE_S, mu=mu, sensors=SensorModel(noise=noise, seed=seed))


def _reference(e_over_rc, cam_speed_hz, beta, n, duration=0.5):
    """The reference model's recording of the motion impactid's simulator settles to (any period): started
    in the middle of the longest free flight of the last revolution after :data:`SETTLE_S`."""
    rig = SUNDAR2016.with_eccentricity_ratio(e_over_rc)
    law = HuntCrossley(beta, n)
    period = 1.0 / cam_speed_hz
    run = simulate(rig, cam_speed_hz, law, SETTLE_S, mu=0.0)
    c = run.contacts[run.contacts["t_end"] > SETTLE_S - 3 * period]
    starts, ends = c["t_start"].to_numpy(), c["t_end"].to_numpy()
    k = int(np.argmax(starts[1:] - ends[:-1]))
    t_section = 0.5 * (ends[k] + starts[k + 1])
    state = simulate(rig, cam_speed_hz, law, t_section, t_eval=[t_section], mu=0.0)
    hc = {"kind": "hunt-crossley", "beta": beta, "n": n}
    orbit = RR.PeriodicOrbit(state=np.array([state.alpha[0], state.alpha_dot[0]]),
                             section_phase=(2 * math.pi * cam_speed_hz * t_section) % (2 * math.pi),
                             cam_speed_hz=float(cam_speed_hz), period=period, law=RR._law(hc), mu=0.0,
                             multipliers=np.zeros(2, complex), jacobian=np.eye(2), residual=np.zeros(2),
                             contacts_per_revolution=0, contacts=[])
    return RR.reference_recording(e_over_rc, cam_speed_hz, hc, mu=0.0, duration=duration, start_time_s=SETTLE_S,
                                  orbit=orbit)


def _quiet(fn, *args, **kwargs):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = fn(*args, **kwargs)
    return out, [str(w.message) for w in caught]


def _beta_error(recording, beta, n, **options):
    result, _ = _quiet(estimate, [recording], fix_n=n, **options)
    d = result.damping
    return d.beta / beta - 1.0, (d.beta_interval[0] <= beta <= d.beta_interval[1]), result


def _true_apex(truth, t_onset, t_next):
    apex_t, apex_a = np.asarray(truth["apexes"]["t"]), np.asarray(truth["apexes"]["alpha"])
    later = (apex_t > t_onset) & (apex_t < t_next)
    return float(np.max(apex_a[later])) if later.any() else math.nan


# ---- item 1: nearly plastic contacts ---------------------------------------------------------------

@pytest.fixture(scope="module")
def near_plastic():
    """Restitution 0.0075, a 2.57 ms contact whose head peaks at the third sample (e/r_c 0.2, 14 Hz)."""
    return _synth(0.2, 14.0, 5e10, 1.2)


def test_a_nearly_plastic_contact_ends_with_its_tail_and_is_period1(near_plastic):
    """The detector ends the contact where its 2.57 ms tensile tail joins the free flight (it took the first
    0.14 ms before), and the sampled peaks, which differ by 4 % between impacts, raise no period-1 warning."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", EventWarning)
        events = find_events(near_plastic.recording)
    truth = near_plastic.truth["impacts"]
    duration = (events.table["t_separation"] - events.table["t_onset"]).to_numpy()
    assert np.all(np.abs(duration - (truth["t_end"] - truth["t_start"])) < 2.0 / 204_800)
    peaks = events.table["peak"].to_numpy()
    assert np.ptp(peaks) / np.median(peaks) > 0.03  # the sampled peaks do differ
    assert events.table["periodic"].all() and not events.table["not_period1"].any()


def test_the_head_model_places_the_onset_and_the_kinematics(near_plastic):
    """The under-resolved head (peak at the third sample) is modelled as a Hunt–Crossley impact: onsets
    within 0.01 samples (the power law of three samples was off by up to 0.4), alpha_m within 2e-5."""
    rec, truth = near_plastic.recording, near_plastic.truth
    result, _ = _quiet(reconstruct, rec, anchor="cam-phase")
    table = result.table
    rows = [int(np.argmin(np.abs(truth["impacts"]["t_start"] - t))) for t in table["t_onset"]]
    onset_error = (table["t_onset"].to_numpy() - truth["impacts"]["t_start"][rows]) * rec.sample_rate_hz
    assert np.max(np.abs(onset_error)) < 0.01
    apex = np.array([_true_apex(truth, a, b) for a, b in zip(table["t_onset"], table["t_next"])])
    assert np.max(np.abs(table["alpha_m"].to_numpy() / apex - 1.0)) < 2e-5
    rate_error = table["alpha_dot_onset"].to_numpy() - truth["impacts"]["alpha_dot_start"][rows]
    assert np.max(np.abs(rate_error)) < 2e-4  # rad/s, of about 6.5 (0.018 without the head model)


def test_nearly_plastic_beta_within_a_percent(near_plastic):
    """n fixed, noise-free: beta -26 % (interval excluding the truth) before; now within 0.1 %."""
    error, covered, _ = _beta_error(near_plastic.recording, 5e10, 1.2)
    assert abs(error) < 1e-3 and covered


# ---- item 2: period-k and multi-impact motion --------------------------------------------------------

@pytest.fixture(scope="module")
def period2():
    """Two alternating impacts in two revolutions (e/r_c 0.2, 17 Hz, the paper's law): v_a 0.53 and 0.46 m/s."""
    return _synth(0.2, 17.0, 24.7e9, 1.5)


def test_period2_events_are_integrated_over_the_period(period2):
    """Each event's window closes two onsets later, where the state recurs: onset states and alpha_m as
    exact as at period-1 points (with one-onset windows alpha_m was off by percents, Hertz ratios 30-60)."""
    rec, truth = period2.recording, period2.truth
    result, notes = _quiet(reconstruct, rec, anchor="cam-phase")
    assert any("the motion is period-2: 2 impacts every 2 cam revolutions" in m for m in notes)
    table = result.table
    rows = [int(np.argmin(np.abs(truth["impacts"]["t_start"] - t))) for t in table["t_onset"]]
    apex = np.array([_true_apex(truth, a, b) for a, b in zip(table["t_onset"], table["t_next"])])
    assert np.max(np.abs(table["alpha_m"].to_numpy() / apex - 1.0)) < 1e-5
    assert np.max(np.abs(table["alpha_onset"].to_numpy() - truth["impacts"]["alpha_start"][rows])) < 1e-6
    assert np.max(np.abs(table["alpha_dot_onset"].to_numpy() - truth["impacts"]["alpha_dot_start"][rows])) < 1e-4
    v_a = -truth["impacts"]["gap_rate_start"][rows]
    assert np.ptp(v_a) / np.mean(v_a) > 0.1  # the impacts alternate
    np.testing.assert_allclose(table["approach_speed"], v_a, rtol=1e-5)


def test_period2_estimates(period2):
    """n fixed: beta -16 to -36 % before (every other impact dropped); now within 0.01 %. The reference
    model's recording of the same motion: within 0.1 %."""
    error, covered, result = _beta_error(period2.recording, 24.7e9, 1.5)
    assert abs(error) < 1e-4 and covered and len(result.event_sets[0]) >= 6
    reference, _ = _reference(0.2, 17.0, 24.7e9, 1.5)
    error, covered, _ = _beta_error(reference, 24.7e9, 1.5, calibrate=False)
    assert abs(error) < 1e-3 and covered


def test_an_event_without_an_apex_is_left_out_with_the_reason():
    """A cam that strikes the follower again while it still rises (e/r_c 0.25, 20 Hz): that event's largest
    angle is at the next onset, which any law reproduces; its lambda1 drove beta to +6.5 % with an interval
    excluding the truth. It is left out, saying so, and the alternate impacts estimate beta."""
    synthetic = _synth(0.25, 20.0, 1e10, 1.4)
    result, _ = _quiet(reconstruct, synthetic.recording, anchor="cam-phase")
    no_apex = ~np.isfinite(result.table["alpha_m"].to_numpy())
    assert 0 < no_apex.sum() < len(result.table)
    event_set = EventSet.from_reconstruction(result)
    assert any("no apex between the impact and the next one" in d for d in event_set.dropped)
    error, covered, _ = _beta_error(synthetic.recording, 1e10, 1.4, calibrate=False)
    assert abs(error) < 1e-3 and covered


# ---- refusals with the true reason -------------------------------------------------------------------

def test_a_follower_riding_the_cam_is_refused_saying_so():
    """The envelope validation's hc16: an impact, then 16 ms on the cam. The detector's tail ends it 6.7 ms
    in (the ride is smooth); the accelerometer's force balance shows the ride to its end."""
    rec = _synth(0.2549, 10.0, 58_612_441_771.05722, 1.2500235892323228, duration=0.6).recording
    with pytest.raises(ImpactidError, match=r"rides the cam after the impact there \(the contact lasts up to 1[4-6]"):
        _quiet(estimate, [rec], fix_n=1.25, calibrate=False)


def test_irregular_motion_is_refused_saying_its_onsets_do_not_recur():
    """e/r_c 0.2 at 18 Hz with friction: no period within 1500 revolutions (impactid regime)."""
    rec = _synth(0.2, 18.0, 24.7e9, 1.5, mu=0.2).recording
    with pytest.raises(ImpactidError, match="onsets do not recur with the cam"):
        _quiet(estimate, [rec], fix_n=1.5, calibrate=False)


# ---- item 3: slow impacts near the top of the cam's lift ---------------------------------------------

def test_the_phase_profile_widens_the_error_at_the_top_of_the_lift():
    """Onset angles near the contact angle's maximum barely fix the cam phase: its error is 0.1 rad or more
    there, and the profile widens the linearised standard error where that does not cover it; on a flank
    the two agree at a few mrad. Five noise draws of 15 onsets, 2e-4 rad of angle noise."""
    rig = SUNDAR2016.with_eccentricity_ratio(0.06)
    omega = 2 * math.pi * 16.0
    grid = np.linspace(0.0, 2 * math.pi, 4001)
    top = float(grid[np.argmax(rig.contact_angle(grid))])
    t = np.arange(15) / 16.0
    widened = 0
    for seed in range(5):
        rng = np.random.default_rng(seed)
        for offset in (-0.05, -1.0):
            true_phase = top + offset
            angles = np.asarray(rig.contact_angle(true_phase + omega * t)) + rng.normal(0.0, 2e-4, t.size)
            fit = optimize.least_squares(lambda q, a=angles: np.asarray(rig.contact_angle(q[0] + omega * t)) - a,
                                         [true_phase])
            phase = float(fit.x[0])
            slope = (np.asarray(rig.contact_angle(phase + 1e-6 + omega * t))
                     - np.asarray(rig.contact_angle(phase - 1e-6 + omega * t))) / 2e-6
            resid = np.asarray(rig.contact_angle(phase + omega * t)) - angles
            linear = float(np.sqrt(np.sum(resid ** 2) / (t.size - 1) / np.sum(slope ** 2)))
            profile = phase_profile_stderr(rig, omega, t, angles, phase, linear)
            assert profile >= linear
            assert abs(phase - true_phase) < 2.0 * profile
            if offset == -1.0:
                assert profile == linear < 0.01
            else:
                assert profile > 0.05
                widened += profile > 1.5 * linear
    assert widened >= 2


def test_a_slow_noisy_recording_gets_the_phase_of_its_contacts():
    """Approach 0.29 m/s, restitution 0.985, 0.35 % noise: the onset angles put the cam phase 0.079 rad
    (3.5 of their standard errors) off, the approach speed 5 % and beta +636 %, interval excluding the
    truth. The contacts' Hertz ratios disagree with them; the phase's error now covers the truth and so
    does beta's interval (the estimate is not precise: beta barely moves alpha_m here)."""
    synthetic = synth_pivoted(SUNDAR2016.with_eccentricity_ratio(0.103), 15.5, HuntCrossley(7.42e9, 1.721), 1.0,
                              settle_s=150.0, mu=0.0, sensors=SensorModel(noise=0.0035, seed=2004))
    result, _ = _quiet(reconstruct, synthetic.recording, anchor="cam-phase")
    error = math.remainder(result.cam_phase - synthetic.truth["theta_ref"], 2 * math.pi)
    assert abs(error) < 1.96 * result.cam_phase_stderr

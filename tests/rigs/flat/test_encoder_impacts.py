"""Restitution against cam speed from rig F encoder recordings (issue 6, item 5).

Synthetic recordings (cam 5000, follower 10 000 pulses per revolution, 20 kHz, unknown cam zero)
are made with a known linear law; the target is r(omega) within 2 %.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from impactid.results import FitResult
from impactid.rigs.flat import ALZATE2007 as RIG
from impactid.rigs.flat.encoder_impacts import (
    EncoderImpactError,
    RestitutionAtSpeed,
    SpeedLawResult,
    fit_speed_law,
    relative_motion,
    restitution_at_speed,
)
from impactid.rigs.flat.simulate import SpeedRestitution
from impactid.rigs.flat.synth import synth_flat_encoders
from impactid.rigs.flat.synth_impacts import synth_flat_impacting

LAW = SpeedRestitution.from_rpm(0.65 + 130 * 0.004, -0.004)  # r = 0.65 at 130 rpm, 0.57 at 150 rpm
SPEEDS_RPM = (130.0, 140.0, 150.0)


@pytest.fixture(scope="session")
def impacting_recordings():
    return {rpm: synth_flat_impacting(RIG, rpm / 60.0, 4.0, restitution=LAW,
                                      cam_zero_offset=0.7 + rpm / 100.0) for rpm in SPEEDS_RPM}


class _Points(dict):
    """The impact-law point of each speed, computed when first asked for (about 1.5 s each): a test of
    one speed does not pay for the others."""

    def __init__(self, recordings):
        super().__init__()
        self.recordings = recordings

    def __missing__(self, rpm):
        self[rpm] = restitution_at_speed(self.recordings[rpm].recording)
        return self[rpm]

    def values(self):
        return [self[rpm] for rpm in self.recordings]


@pytest.fixture(scope="session")
def impact_law_points(impacting_recordings):
    return _Points(impacting_recordings)


def test_cam_offset_recovered(impacting_recordings):
    s = impacting_recordings[130.0]
    motion = relative_motion(s.recording)
    # the coarse alignment only; the refined one (after the impacts) is better still
    err = (motion.offset - s.truth["cam_zero_offset"] + math.pi) % (2 * math.pi) - math.pi
    assert abs(err) < 2.0 * 2.0 * math.pi / 5000  # within two cam counts


@pytest.mark.parametrize("rpm", [pytest.param(rpm, marks=() if rpm == 140.0 else pytest.mark.slow)
                                 for rpm in SPEEDS_RPM])
def test_impact_law_within_2_percent(impact_law_points, impacting_recordings, rpm):
    point = impact_law_points[rpm]
    truth = impacting_recordings[rpm].truth["restitution"]
    assert point.n_impacts >= 8  # one first impact per revolution (about 8.7 revolutions in 4 s at 130 rpm)
    assert point.restitution == pytest.approx(truth, rel=0.02)
    assert point.cam_speed_hz == pytest.approx(rpm / 60.0, rel=1e-6)


def test_impact_times_match_truth(impact_law_points, impacting_recordings):
    point = impact_law_points[140.0]
    true_times = impacting_recordings[140.0].truth["impact_times"]
    nearest = np.array([np.min(np.abs(true_times - t)) for t in point.impacts["t_impact"]])
    assert np.all(nearest < 1e-4)  # two samples at 20 kHz


@pytest.mark.slow
@pytest.mark.parametrize("rpm", (130.0, 150.0))
def test_first_bounce_within_2_percent(impacting_recordings, rpm):
    s = impacting_recordings[rpm]
    point = restitution_at_speed(s.recording, method="first-bounce")
    assert point.restitution == pytest.approx(s.truth["restitution"], rel=0.02)


@pytest.mark.slow
def test_linear_law_recovered(impact_law_points):
    fit = fit_speed_law(impact_law_points.values())
    for rpm in np.linspace(130.0, 150.0, 5):
        assert fit.law(rpm / 60.0) == pytest.approx(LAW(rpm / 60.0), rel=0.02)
    assert fit.law.b < 0.0 and math.isfinite(fit.stderr_b) and fit["b"].unit == "s/rad"
    assert fit.details["law"]["b_per_rpm"] == pytest.approx(fit.law.b * 2 * math.pi / 60, rel=1e-12)
    assert len(fit.points) == len(SPEEDS_RPM) and fit.statistics["dof"] == 1
    again = FitResult.from_json(fit.to_json())
    assert type(again) is SpeedLawResult and again["b"].value == fit.law.b and again.law == fit.law
    assert len(again.to_pandas("points")) == len(SPEEDS_RPM) and "[[Variables]]" in fit.report()


def _point(rpm, r, se, source="x.h5"):
    return RestitutionAtSpeed(cam_speed_hz=rpm / 60.0, restitution=r, stderr=se, method="impact-law", n_impacts=8,
                              bounce_height=1e-3, impacts=None, source=source)


def test_speed_law_on_the_engine_ordinary_and_exact():
    """Three speeds: ordinary least squares with the covariance from the residual scatter (the
    textbook formulas); two speeds: the exact line with the points' own errors propagated; one
    speed: a constant, b fixed. No recording needed."""
    rpm = np.array([130.0, 140.0, 150.0])
    r = np.array([0.65, 0.62, 0.57])
    fit = fit_speed_law([_point(v, ri, 1e-3) for v, ri in zip(rpm, r, strict=True)])
    omega = 2 * math.pi * rpm / 60
    X = np.column_stack((np.ones(3), omega))
    coef, *_ = np.linalg.lstsq(X, r, rcond=None)
    resid = r - X @ coef
    cov = np.linalg.inv(X.T @ X) * (resid @ resid) / 1
    assert fit.value("a") == pytest.approx(coef[0], rel=1e-10) and fit.value("b") == pytest.approx(coef[1], rel=1e-9)
    assert fit.stderr_a == pytest.approx(math.sqrt(cov[0, 0]), rel=1e-6)
    assert fit.stderr_b == pytest.approx(math.sqrt(cov[1, 1]), rel=1e-6)
    assert fit.details["correlation"]["matrix"][0][1] == pytest.approx(cov[0, 1] / math.sqrt(cov[0, 0] * cov[1, 1]),
                                                                       rel=1e-6)
    # the line misses the middle point by 6.7 times its standard error (0.01 * 2 / 3): the check says so
    assert fit.statistics["residual_over_noise"] > 1.5 and any("lack of fit" in n for n in fit.notes)

    two = fit_speed_law([_point(130.0, 0.65, 2e-3), _point(150.0, 0.57, 1e-3)])
    w1, w2 = 2 * math.pi * 130 / 60, 2 * math.pi * 150 / 60
    assert two.value("b") == pytest.approx((0.57 - 0.65) / (w2 - w1), rel=1e-10)
    assert two.stderr_b == pytest.approx(math.hypot(2e-3, 1e-3) / (w2 - w1), rel=1e-9)
    assert two.stderr_a == pytest.approx(math.hypot(2e-3 * w2, 1e-3 * w1) / (w2 - w1), rel=1e-9)
    assert two.residual_rms < 1e-12 and not two.notes

    one = fit_speed_law([_point(140.0, 0.61, 1e-3, "only.h5")])
    assert one["b"].fixed and one.value("a") == pytest.approx(0.61) and one.stderr_a == pytest.approx(1e-3)
    assert math.isnan(one.stderr_b) and any("one cam speed" in n for n in one.notes)


def test_permanent_contact_has_no_impacts():
    s = synth_flat_encoders(RIG, 110.0 / 60.0, 2.0, cam_zero_offset=1.0)
    with pytest.raises(EncoderImpactError, match="no measurable first impact"):
        restitution_at_speed(s.recording)


def test_unknown_method_and_missing_channel(impacting_recordings):
    rec = impacting_recordings[140.0].recording
    with pytest.raises(ValueError, match="impact-law, first-bounce"):
        restitution_at_speed(rec, method="bouncing-ball")
    bare = type(rec)(channels={"cam_angle": rec.channels["cam_angle"]}, sample_rate_hz=rec.sample_rate_hz,
                     units={"cam_angle": "rad"}, rig=rec.rig, operating=dict(rec.operating))
    with pytest.raises(EncoderImpactError, match="follower_angle"):
        restitution_at_speed(bare)

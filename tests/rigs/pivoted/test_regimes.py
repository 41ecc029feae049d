"""Regime classification, detachment speed and regime maps."""

from __future__ import annotations

import numpy as np
import pytest

from impactid import SUNDAR2016, HuntCrossley, simulate
from impactid.rigs.pivoted.regimes import (
    classify_regime,
    detachment_speed,
    follower_kinematics,
    regime_map,
    required_contact_force,
)


def test_follower_kinematics_derivatives():
    rig = SUNDAR2016.with_eccentricity_ratio(0.2)
    theta = np.linspace(0, 2 * np.pi, 37)
    h = 1e-5
    a, d1, d2 = follower_kinematics(rig, theta)
    ap, _, _ = follower_kinematics(rig, theta + h)
    am, _, _ = follower_kinematics(rig, theta - h)
    # central differences: truncation h^2/6 |a'''| ~ 1e-12, round-off 1e-17 / h^2 ~ 1e-7 for d2
    np.testing.assert_allclose(d1, (ap - am) / (2 * h), atol=1e-9)
    np.testing.assert_allclose(d2, (ap - 2 * a + am) / h**2, atol=2e-6)


def test_detachment_speed_is_where_required_force_vanishes():
    rig = SUNDAR2016.with_eccentricity_ratio(0.2)
    det = detachment_speed(rig, mu=0.0)
    theta = np.linspace(0, 2 * np.pi, 20000)
    assert np.min(required_contact_force(rig, det.cam_speed_hz * 0.999, theta, mu=0.0)) > 0
    assert np.min(required_contact_force(rig, det.cam_speed_hz * 1.001, theta, mu=0.0)) < 0
    assert det.cam_speed_rpm == pytest.approx(60 * det.cam_speed_hz)
    # friction shifts it only slightly (small moment arm h_p against chi)
    assert detachment_speed(rig).cam_speed_hz == pytest.approx(det.cam_speed_hz, rel=0.02)


@pytest.mark.slow
def test_detachment_agrees_with_the_dynamic_simulation():
    """Just below detachment the settled motion keeps contact; just above it loses it."""
    rig = SUNDAR2016.with_eccentricity_ratio(0.2)
    det = detachment_speed(rig).cam_speed_hz
    law = HuntCrossley(24.7e9, 1.5)
    below = classify_regime(rig, 0.97 * det, law, settle_revolutions=100, window=24)
    above = classify_regime(rig, 1.03 * det, law, settle_revolutions=100, window=24)
    assert below.regime == "contact"
    assert above.regime != "contact" and above.impacts_per_revolution >= 1


@pytest.mark.parametrize(("e_over_rc", "hz", "expected", "period"),
                         [(0.25, 15.0, "period-1", 1), (0.15, 17.0, "period-k", 2),
                          pytest.param(0.2, 4.0, "contact", 1, marks=pytest.mark.slow)])
def test_classification_of_known_points(e_over_rc, hz, expected, period):
    res = classify_regime(SUNDAR2016.with_eccentricity_ratio(e_over_rc), hz)
    assert res.regime == expected
    assert res.period_revolutions == period


def test_slow_transient_is_not_mistaken_for_period_two():
    """At e/r_c = 0.2, 16 Hz the run alternates for tens of seconds before settling to period-1."""
    rig = SUNDAR2016.with_eccentricity_ratio(0.2)
    run = simulate(rig, 16.0, HuntCrossley(24.7e9, 1.5), 3.0)
    gaps = np.diff(run.contacts["t_start"].to_numpy())
    assert np.ptp(gaps[-6:]) > 1e-4  # still alternating after 3 s
    res = classify_regime(rig, 16.0)
    assert res.regime == "period-1"
    assert res.settled_after_s > 10.0


def test_regime_map_small_grid():
    frame = regime_map(SUNDAR2016, [0.2, 0.25], [5.0, 15.0])
    assert list(frame["regime"]) == ["contact", "period-1", "contact", "period-1"]
    assert {"detachment_hz", "simulated", "period_revolutions"} <= set(frame.columns)

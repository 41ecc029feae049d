"""The calibration's length and cache (issue 27): a few revolutions per operating point, measured once."""

from __future__ import annotations

import math

import pytest

from impactid import SUNDAR2016, HuntCrossley
from impactid.rigs.pivoted import calibration
from impactid.rigs.pivoted.calibration import (
    MIN_EVENTS,
    SETTLE_S,
    PipelineBias,
    RecordingSampling,
    calibration_duration,
    pipeline_bias,
)

RIG = SUNDAR2016.with_eccentricity_ratio(0.2)
LAW = HuntCrossley(24.7e9, 1.5)


def _sampling(duration: float, cam_speed_hz: float = 16.0, noise: float = 1e-4) -> RecordingSampling:
    return RecordingSampling(rig=RIG, cam_speed_hz=cam_speed_hz, sample_rate_hz=204_800.0, start_time_s=SETTLE_S,
                             duration=duration, noise_fraction=noise)


def test_the_calibration_replays_a_few_revolutions_not_the_recording():
    """MIN_EVENTS + 1 revolutions whatever the measurement's length: 4.06 s at 16 Hz for 1 s (as before: the
    built-in example's calibration is unchanged) and for 60 s (a copy of the recording before)."""
    for duration in (1.0, 60.0, 600.0):
        assert calibration_duration(_sampling(duration)) == pytest.approx((MIN_EVENTS + 1) / 16.0)
    assert max(1.0, (MIN_EVENTS + 1) / 16.0) == calibration_duration(_sampling(1.0))


@pytest.fixture
def measured(monkeypatch):
    """Count the calibrations measured (the simulation replaced by a stub); the cache emptied around."""
    calls = []

    def stub(sampling, law, integration, anchor, seed):
        calls.append((sampling, law, integration, anchor, seed))
        return PipelineBias(1e-4, 1e-5, MIN_EVENTS)

    calibration._cached_bias.cache_clear()
    monkeypatch.setattr(calibration, "_measure_bias", stub)
    yield calls
    calibration._cached_bias.cache_clear()


def test_one_operating_point_is_measured_once(measured):
    """Recordings of one operating point, sampling and noise level share one calibration whatever their
    lengths; another law, cam speed, noise level or method is measured anew."""
    first = pipeline_bias(_sampling(60.0), LAW)
    assert pipeline_bias(_sampling(20.0), LAW) is first
    assert len(measured) == 1
    sampling = measured[0][0]
    assert math.isclose(sampling.duration, (MIN_EVENTS + 1) / 16.0) and sampling.start_time_s == SETTLE_S
    pipeline_bias(_sampling(60.0), HuntCrossley(20e9, 1.5))
    pipeline_bias(_sampling(60.0, cam_speed_hz=15.0), LAW)
    pipeline_bias(_sampling(60.0, noise=2e-4), LAW)
    pipeline_bias(_sampling(60.0), LAW, anchor="return-time")
    assert len(measured) == 5

"""A joint fit with a recording that cannot be used fits the others and says which was left out and why
(rig P's estimate through :class:`impactid.pipeline.Pipeline`)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from impactid import SUNDAR2016
from impactid.errors import ImpactidError
from impactid.pipeline import Pipeline
from impactid.rigs.pivoted.synth import synth_pivoted
from tests.conftest import seed_law_s2


@pytest.fixture(scope="module")
def riding():
    """At e/r_c 0.05 and 4 Hz the follower rides the cam: no impact the contact law can be replayed from."""
    return synth_pivoted(SUNDAR2016.with_eccentricity_ratio(0.05), 4.0, seed_law_s2(), 1.0).recording


def _fit(recordings):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return Pipeline(fix_n=1.5).run(recordings)


def test_a_recording_without_usable_impacts_is_left_out_with_its_reason(s2_synthetic, riding):
    alone = _fit([s2_synthetic.recording])
    joint = _fit([s2_synthetic.recording, riding])
    # the estimate is the usable recording's, to the last digit, and the result says what was left out
    assert joint.damping.beta == alone.damping.beta
    assert joint.damping.beta_interval == alone.damping.beta_interval
    left = [w for w in joint.warnings if "left out of the joint fit" in w]
    assert len(left) == 1 and left[0].startswith("recording 2 left out") and "recording 1 alone" in left[0]
    assert any("one operating point" in w for w in joint.warnings)
    assert joint.sources == ("recording 1",)


def test_a_recording_that_cannot_be_measured_is_left_out_and_named(s2_synthetic):
    rec = s2_synthetic.recording
    quiet = rec.slice_time(rec.start_time_s, rec.start_time_s + 0.004)  # a few ms: no impact to find
    with pytest.raises(ImpactidError):
        _fit([quiet])
    joint = _fit([s2_synthetic.recording, quiet])
    assert any(w.startswith("recording 2 left out of the joint fit") for w in joint.warnings)
    assert np.isfinite(joint.damping.beta)


def test_a_joint_fit_with_no_usable_recording_is_refused_naming_each(riding):
    with pytest.raises(ImpactidError, match="no event can be used"):
        _fit([riding, riding])

"""Rig F encoder recordings (permanent contact) and the rig F geometry they rest on."""

from __future__ import annotations

import math

import numpy as np
import pytest

from impactid.errors import SimulationInputError
from impactid.rigs import ALZATE2007
from impactid.rigs.flat.synth import synth_flat_encoders


def test_contact_angle_derivatives_match_finite_differences():
    tc = np.linspace(0, 2 * np.pi, 37)
    th, d1, d2 = ALZATE2007.contact_angle(tc, derivatives=2)
    h = 1e-5
    fd1 = (ALZATE2007.contact_angle(tc + h) - ALZATE2007.contact_angle(tc - h)) / (2 * h)
    fd2 = (ALZATE2007.contact_angle(tc + h) - 2 * th + ALZATE2007.contact_angle(tc - h)) / h**2
    assert np.allclose(d1, fd1, atol=1e-9)
    assert np.allclose(d2, fd2, atol=1e-5)
    assert np.allclose(ALZATE2007.gap(th, tc), 0.0, atol=1e-15)  # solves (A-26) = 0


def test_encoder_recording_at_110_rpm():
    syn = synth_flat_encoders(ALZATE2007, 110 / 60, 2.0)
    rec, truth = syn.recording, syn.truth
    step_c, step_f = 2 * math.pi / 5000, 2 * math.pi / 10_000
    cam_err = (truth["theta_c"] - truth["cam_zero_offset"]) - rec["cam_angle"]
    fol_err = truth["theta_f"] - rec["follower_angle"]
    assert np.all((cam_err >= -1e-12) & (cam_err < step_c + 1e-12))
    assert np.all((fol_err >= -1e-12) & (fol_err < step_f + 1e-12))
    assert np.allclose(rec["follower_angle"] / step_f, np.round(rec["follower_angle"] / step_f), atol=1e-6)
    assert 0 <= truth["cam_zero_offset"] < 2 * math.pi


def test_no_permanent_contact_above_detachment():
    assert ALZATE2007.detachment_speed_hz() * 60 == pytest.approx(122.45, abs=0.05)
    with pytest.raises(SimulationInputError, match="detachment speed"):
        synth_flat_encoders(ALZATE2007, 130 / 60, 1.0)

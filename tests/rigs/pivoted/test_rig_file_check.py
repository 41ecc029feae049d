"""A wrong rig constant is refused with the true reason (impactid/rigs/pivoted/freeflight.py, reconstruct.py).

A noise-free 1 s recording of the envelope validation's case mr00 (rig P, e/r_c 0.1365, 15.5 Hz, Hunt-Crossley),
reconstructed with the right rig and with a rig file whose inertia I_b, spring stiffness k_s or pin radius
r_d is off: the reconstruction fails at every event, and the refusal must say that the recorded motion is
not the rig file's and name the constants, not merely that the onset state could not be reconstructed.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from impactid import SUNDAR2016, HuntCrossley
from impactid.errors import ImpactidError
from impactid.rigs.pivoted.freeflight import FREE_FLIGHT_MISFIT, free_accelerations, free_flight_fit
from impactid.rigs.pivoted.reconstruct import reconstruct
from impactid.rigs.pivoted.residuals import EventSet
from impactid.rigs.pivoted.runs import pack_rig
from impactid.rigs.pivoted.synth import synth_pivoted


@pytest.fixture(scope="module")
def recording():
    rig = SUNDAR2016.with_eccentricity_ratio(0.1365)
    return synth_pivoted(rig, 15.5, HuntCrossley(43060686898.4858, 1.7539169938498236), 1.0,
                         settle_s=40.0).recording


def _refusal(rec) -> str:
    recon = reconstruct(rec, integration="rk", anchor="cam-phase", warn=False)
    with pytest.raises(ImpactidError) as raised:
        EventSet.from_reconstruction(recon).require("lambda1")
    return str(raised.value)


def test_the_right_rig_file_agrees_with_the_free_flight(recording):
    recon = reconstruct(recording, integration="rk", anchor="cam-phase", warn=False)
    fit = recon.free_flight
    assert fit["clean"] and not fit["disagrees"] and fit["misfit"] < 1e-3
    assert recon.rig_mismatch == "" and recon.geometry_mismatch == ""
    assert len(EventSet.from_reconstruction(recon)) == len(recon.table)


@pytest.mark.parametrize(("constant", "scale"), [("I_b", 1.3), ("k_s", 0.7)])
def test_a_wrong_inertia_or_spring_is_refused_naming_the_rig_file(recording, constant, scale):
    rig = recording.require_rig()
    wrong = recording.with_rig(replace(rig, **{constant: getattr(rig, constant) * scale}))
    message = _refusal(wrong)
    assert "not the motion of the rig described by the rig file" in message
    assert "I_b" in message and "k_s" in message and "check the rig file" in message
    assert message.index("rig file") < message.index("left out")  # the reason comes first


def test_a_wrong_pin_radius_is_refused_naming_the_contact_constants(recording):
    rig = recording.require_rig()
    message = _refusal(recording.with_rig(replace(rig, r_d=rig.r_d * 1.2)))
    assert "not the motion of the rig described by the rig file" in message and "r_d" in message


def test_free_flight_fit_finds_a_scaled_model_and_leaves_noise():
    rig = SUNDAR2016.with_eccentricity_ratio(0.15)
    p = pack_rig(rig)
    rng = np.random.default_rng(0)
    alpha = [np.linspace(0.0, 0.06, 400) + 0.01 * k for k in range(4)]
    true = pack_rig(replace(rig, I_b=rig.I_b / 1.25))  # the recording's inertia: the rig file's is 1.25 x
    measured = [free_accelerations(a, true) + 3.0 + rng.normal(0.0, 0.01, a.size) for a in alpha]
    fit = free_flight_fit(alpha, measured, p, 0.01)
    assert fit.clean and fit.disagrees and fit.misfit > FREE_FLIGHT_MISFIT
    assert fit.scale == pytest.approx(1.25, rel=0.01) and abs(fit.linear) < 0.05
    right = free_flight_fit(alpha, [free_accelerations(a, p) + rng.normal(0.0, 0.01, a.size) for a in alpha], p, 0.01)
    assert right.clean and not right.disagrees and math.isclose(right.scale, 1.0, rel_tol=0.01)
    # a contact in the flights (a follower riding the cam) is not clean: no claim about the rig
    riding = [m + np.where(a < a[0] + 0.02, 40.0, 0.0) for a, m in zip(alpha, measured)]
    dirty = free_flight_fit(alpha, riding, p, 0.01)
    assert not dirty.clean and not dirty.disagrees and dirty.reason() == ""

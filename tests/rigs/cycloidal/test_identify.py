"""Surge, preload and mass identification: recovery of known values from synthetic recordings
(noise-free within 1 %, noisy inside the reported intervals), refusals with reasons, synthetic files."""

from __future__ import annotations

import math

import numpy as np
import pytest

from impactid.io import read_recording, read_truth
from impactid.rigs.cycloidal import SurgeFit, fit_surge, synth_recording
from impactid.rigs.cycloidal.identify import IdentificationError
from impactid.rigs.valvespring import damper_damping_ratio

#: the "true" rig of the synthetic recordings: every identified value moved away from the preset, so that
#: a fit that stays at its starting values fails
TRUE = {"f0": 480.0, "c_spring": 3.0, "f_p": 260.0, "m3": 0.235}
NAMES = ("f0", "c_spring", "f_p", "m3")


@pytest.fixture(scope="module")
def truth_rig(rig):
    return rig.replace(**TRUE)


@pytest.mark.slow
def test_contact_load_noise_free_recovery(rig, truth_rig):
    rec = synth_recording(truth_rig, 3000.0, revolutions=3, sample_rate_hz=20_000.0,
                          channels=("cam_angle", "contact_load")).recording.with_rig(rig)
    fit = fit_surge(rec)
    assert isinstance(fit, SurgeFit) and fit.statistics["model"] == "level A"
    for k in NAMES:
        assert fit.value(k) == pytest.approx(TRUE[k], rel=1e-6), k
    # zeta1 is valvespring's damping ratio of the two-mass model with the fitted damper: 3 pi c f0 / (8 k0)
    assert fit["k0"].fixed and fit.value("zeta1") == pytest.approx(3.0 * math.pi * 3.0 * 480 / (8 * 35e3), rel=1e-6)
    assert fit.value("zeta1") == pytest.approx(damper_damping_ratio(35e3, fit.value("f0"), fit.value("c_spring")),
                                               rel=1e-12)
    # JSON round trip of the result
    back = SurgeFit.from_json(fit.to_json())
    assert back.value("f0") == fit.value("f0") and back.kind == "valvetrain-surge-fit"
    assert fit.plot() is not None


@pytest.mark.slow
def test_contact_load_with_noise_inside_the_intervals(rig, truth_rig):
    # 3 N of white noise on a 250-770 N load (a good piezo load washer), two speeds jointly
    recs = [synth_recording(truth_rig, rpm, revolutions=3, sample_rate_hz=20_000.0, channels=("cam_angle",
                            "contact_load"), noise={"contact_load": 3.0}, seed=seed).recording.with_rig(rig)
            for rpm, seed in ((2500.0, 11), (3000.0, 12))]
    fit = fit_surge(recs)
    for k in NAMES:
        p = fit[k]
        assert p.contains(TRUE[k]), (k, p)
        assert p.stderr < 0.05 * abs(p.value), k
    assert fit.statistics["residual_sd"] == pytest.approx(3.0, rel=0.1)
    assert len(fit.to_pandas()) == 2
    # the model check: the residual against the noise measured from its first differences
    assert fit.statistics["residual_over_noise"] == pytest.approx(1.0, abs=0.1)
    assert not any("lack of fit" in n or "significantly" in n for n in fit.notes)
    assert fit["f0"].min == 20.0 and fit["c_spring"].min == 0.0 and fit["m3"].vary


@pytest.mark.slow
def test_free_k0(rig, truth_rig):
    rec = synth_recording(truth_rig.replace(k0=38_000.0), 3000.0, revolutions=3, sample_rate_hz=20_000.0,
                          channels=("cam_angle", "contact_load")).recording.with_rig(rig)
    fixed = fit_surge(rec)  # the wrong k0 held fixed: the fit cannot reach the data
    free = fit_surge(rec, free_k0=True)
    assert free.value("k0") == pytest.approx(38_000.0, rel=1e-4)
    assert free.statistics["residual_rms"] < 1e-3 * fixed.statistics["residual_rms"]
    # the wrong spring rate is a model that does not describe the data, and the check says so
    assert any("lack of fit" in n for n in fixed.notes) and not any("lack of fit" in n for n in free.notes)


@pytest.mark.slow
def test_valve_displacement_level_b(rig, truth_rig):
    # below the jump speed the displacement carries the load through the Hertz approach (um): with a
    # sensor resolving 5 nm the level-B fit recovers everything
    clean = synth_recording(truth_rig, 3000.0, level="B", revolutions=2, sample_rate_hz=20_000.0,
                            channels=("cam_angle", "valve_displacement"))
    fit = fit_surge(clean.recording.with_rig(rig))
    assert fit.statistics["model"] == "level B"
    for k in NAMES:
        assert fit.value(k) == pytest.approx(TRUE[k], rel=0.01), k
    noisy = synth_recording(truth_rig, 3000.0, level="B", revolutions=2, sample_rate_hz=20_000.0,
                            channels=("cam_angle", "valve_displacement"), noise={"valve_displacement": 5e-9},
                            seed=2)
    fit = fit_surge(noisy.recording.with_rig(rig))
    for k in NAMES:
        assert fit[k].contains(TRUE[k]), (k, fit[k])


def test_refusals(rig, truth_rig):
    # the adherent valve's displacement is the lift: no information, and the fit says why
    rec = synth_recording(truth_rig, 3000.0, level="A", revolutions=2, sample_rate_hz=20_000.0,
                          channels=("cam_angle", "valve_displacement"), noise={"valve_displacement": 1e-6})
    with pytest.raises(IdentificationError, match="cannot be identified"):
        fit_surge(rec.recording)
    no_phase = synth_recording(truth_rig, 3000.0, revolutions=1, sample_rate_hz=5_000.0, channels=("contact_load",))
    with pytest.raises(IdentificationError, match="cam_angle"):
        fit_surge(no_phase.recording)
    with pytest.raises(IdentificationError, match="no channel"):
        fit_surge(rec.recording, channel="contact_load")
    with pytest.raises(IdentificationError, match="no recording"):
        fit_surge([])


@pytest.mark.slow
def test_samples_without_contact_are_excluded(rig):
    # above the level-A jump speed the adherent load goes negative; a measured load cannot, and the fit
    # leaves those samples out and says so
    synthetic = synth_recording(rig, 3300.0, revolutions=2, sample_rate_hz=20_000.0,
                                channels=("cam_angle", "contact_load"))
    data = dict(synthetic.recording.channels)
    data["contact_load"] = np.maximum(data["contact_load"], 0.0)
    rec = synthetic.recording.with_step("clipped at 0 N", channels=data)
    fit = fit_surge(rec)
    assert any("excluded" in n for n in fit.notes)


def test_synthetic_file_round_trip(rig, tmp_path):
    synthetic = synth_recording(rig, 1000.0, revolutions=3.0, sample_rate_hz=10_000.0, noise={"contact_load": 1.0},
                                seed=3)
    path = synthetic.write(tmp_path / "rec.h5")
    rec = read_recording(path)
    assert rec.rig == rig and rec.cam_speed_hz == pytest.approx(1000 / 60)
    assert set(rec.channels) == {"cam_angle", "valve_displacement", "valve_velocity", "contact_load"}
    assert rec.units["contact_load"] == "N" and rec.n_samples == 1800
    truth = read_truth(path)
    assert truth["level"] == "A" and truth["parameters"]["f0"] == rig.f0
    # exact channels: lift and its rate on the adherent valve
    from impactid.rigs.cycloidal import cam

    psi = rec.channel("cam_angle")
    np.testing.assert_allclose(rec.channel("valve_displacement"), cam.lift(psi, rig.S, rig.beta)[0], atol=1e-15)
    assert np.std(rec.channel("contact_load") - synthetic.exact["contact_load"]) == pytest.approx(1.0, rel=0.1)

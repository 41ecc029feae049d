"""Synthetic drop recordings (``synth_drop_impact``) and the commands ``impactid synth --rig drop-impact``,
``impactid drop simulate`` and ``impactid drop fit`` end to end."""

from __future__ import annotations

import json

import numpy as np
import pytest

from impactid.cli import main
from impactid.errors import SimulationInputError
from impactid.io import read_recording, read_truth
from impactid.rigs.drop import PA6_PAD_LAW, STEEL_ON_PA6, synth_drop_impact, synth_drop_series
from impactid.rigs.registry import save_rig_toml
from impactid.synth.sensors import SensorModel
from tests.rigs.drop import reference_drop as R


def test_synthetic_recording_file(tmp_path):
    syn = synth_drop_impact(STEEL_ON_PA6, PA6_PAD_LAW, 0.05, sensors=SensorModel(noise=0.005, seed=7))
    path = syn.write(tmp_path / "drop.h5")
    rec = read_recording(path)
    assert rec.rig == STEEL_ON_PA6
    assert dict(rec.operating) == {"drop_height_m": 0.05, "release_speed_m_s": 0.0}
    assert rec.units == {"impactor_acceleration": "m/s^2", "contact_force": "N"}
    assert rec.sample_rate_hz == 51_200.0 and rec.n_samples == 25_600
    truth = read_truth(path)
    assert truth["beta"] == PA6_PAD_LAW.beta and truth["n"] == 1.5 and truth["k"] == STEEL_ON_PA6.k
    # the noise is the generic chain's: 0.5 % of each channel's peak, drawn from the seed
    sigma = truth["applied"]["contact_force"]["noise_sigma"]
    assert sigma == pytest.approx(0.005 * np.max(syn.exact["contact_force"]))
    assert np.std(rec.channel("contact_force") - syn.exact["contact_force"]) == pytest.approx(sigma, rel=0.03)
    # the recording starts 10 ms (pre-trigger) before the first impact, on the release's clock
    onset = truth["impacts"]["onset_time_s"][0]
    assert 0.0099 < onset - rec.start_time_s <= 0.01 + 1 / 51_200.0


def test_synthetic_signals_match_the_reference():
    # the kernel's exact channels against the reference's, sample by sample
    syn = synth_drop_impact(STEEL_ON_PA6, PA6_PAD_LAW, 0.05, duration=0.3)
    t0, accel, force, _ = R.drop_signals(1.0, 9.81, STEEL_ON_PA6.k, 1.5, PA6_PAD_LAW.beta, 1.5, 0.05, 51_200.0, 0.3,
                                         0.01)
    assert syn.recording.start_time_s == t0
    assert np.max(np.abs(syn.exact["contact_force"] - force)) < 1e-6 * np.max(force)
    assert np.max(np.abs(syn.exact["impactor_acceleration"] - accel)) < 1e-6 * np.max(accel)


def test_series_offsets_and_decimation():
    series = synth_drop_series(STEEL_ON_PA6, PA6_PAD_LAW, [0.05, 0.1], seed=3, sensors=SensorModel(noise=0.01),
                               duration=0.2)
    assert [s.truth["sensors"]["seed"] for s in series] == [3, 4]
    off = synth_drop_impact(STEEL_ON_PA6, PA6_PAD_LAW, 0.05, duration=0.2,
                            sensors=SensorModel(accel_offset=2.0, accel_drift=1.0))
    a = off.recording.channel("impactor_acceleration")
    t = np.arange(a.size) / 51_200.0
    np.testing.assert_allclose(a, off.exact["impactor_acceleration"] + 2.0 + t, atol=1e-9)
    filtered = synth_drop_impact(STEEL_ON_PA6, PA6_PAD_LAW, 0.05, duration=0.2, sensors=SensorModel(decimation=4))
    plain = synth_drop_impact(STEEL_ON_PA6, PA6_PAD_LAW, 0.05, duration=0.2)
    assert filtered.recording.start_time_s == plain.recording.start_time_s
    diff = filtered.exact["contact_force"] - plain.exact["contact_force"]
    assert 0.0 < np.max(np.abs(diff)) < 0.05 * np.max(plain.exact["contact_force"])  # the anti-alias filter


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"height": -0.1}, "height must be >= 0"),
    ({"height": 0.0}, "nothing impacts"),
    ({"height": 0.05, "channels": ("accel_tangential",)}, "unknown or none"),
    ({"height": 0.05, "duration": 1e-5}, "need 16"),
    ({"height": 0.05, "sample_rate_hz": float("nan")}, "sample_rate_hz must be positive"),
])
def test_synth_errors(kwargs, match):
    height = kwargs.pop("height")
    with pytest.raises(SimulationInputError, match=match):
        synth_drop_impact(STEEL_ON_PA6, PA6_PAD_LAW, height, **kwargs)


def test_simulate_errors():
    from impactid.rigs.drop import DropLaw, simulate_drop
    from impactid.rigs.drop.simulate import replay_impacts

    with pytest.raises(SimulationInputError, match="height must be >= 0"):
        simulate_drop(STEEL_ON_PA6, PA6_PAD_LAW, -1.0)
    with pytest.raises(SimulationInputError, match="t_eval must be sorted"):
        simulate_drop(STEEL_ON_PA6, PA6_PAD_LAW, 0.05, duration=0.2, t_eval=[0.1, 0.05])
    with pytest.raises(SimulationInputError, match=r"t_eval must lie in \[0, 0.2\]"):
        simulate_drop(STEEL_ON_PA6, PA6_PAD_LAW, 0.05, duration=0.2, t_eval=[0.1, 0.3])
    with pytest.raises(SimulationInputError, match="pendulum.*release_speed"):
        simulate_drop(STEEL_ON_PA6.replace(gravity=0.0), PA6_PAD_LAW, 0.05)
    with pytest.raises(SimulationInputError, match="law must be a DropLaw"):
        simulate_drop(STEEL_ON_PA6, 1e8, 0.05)
    with pytest.raises(SimulationInputError, match="onset speeds must be positive"):
        replay_impacts(STEEL_ON_PA6, DropLaw(1e8), [-1.0], [np.zeros(3)])


# ---- the commands ----------------------------------------------------------------------------------


def test_synth_then_fit_on_the_command_line(tmp_path, capsys):
    paths = [tmp_path / "low.h5", tmp_path / "high.h5"]
    for path, height in zip(paths, ("0.05", "0.2")):
        assert main(["synth", "--rig", "drop-impact", "--height", height, "--duration", "0.5", "--out",
                     str(path)]) == 0
    assert "drop-impact, 25600 samples" in capsys.readouterr().out
    assert main(["drop", "fit", *map(str, paths), "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["kind"] == "drop-impact-fit"
    values = {name: p["value"] for name, p in result["params"].items()}
    assert values["k"] == pytest.approx(STEEL_ON_PA6.k, rel=1e-6)
    assert values["beta"] == pytest.approx(PA6_PAD_LAW.beta, rel=1e-6)
    assert values["n"] == pytest.approx(1.5, rel=1e-6)


def test_synth_with_a_rig_file_and_the_law(tmp_path, capsys):
    rig_file = save_rig_toml(STEEL_ON_PA6.replace(mass=2.0), tmp_path / "rig.toml",
                             {"drop_height_m": 0.1, "release_speed_m_s": 0.5})
    out = tmp_path / "x.h5"
    assert main(["synth", "--rig", str(rig_file), "--damping-beta", "2e8", "--damping-n", "1.2", "--duration", "0.3",
                 "--accelerometer-only", "--out", str(out)]) == 0
    truth = read_truth(out)
    assert (truth["beta"], truth["n"], truth["mass"], truth["height"], truth["release_speed"]) == (2e8, 1.2, 2.0, 0.1,
                                                                                                   0.5)
    assert list(read_recording(out).channels) == ["impactor_acceleration"]


@pytest.mark.parametrize(("extra", "message"), [
    (["--beta", "1e8"], "argument --beta: not an option of 'synth' for the 'drop-impact' rig"),
    (["--e-over-rc", "0.2"], "argument --e-over-rc: not an option"),
    (["--cam-speed", "10"], "argument --cam-speed: not an option"),
])
def test_synth_refuses_other_rigs_options(tmp_path, capsys, extra, message):
    out = tmp_path / "x.h5"
    assert main(["synth", "--rig", "drop-impact", "--height", "0.05", *extra, "--out", str(out)]) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()


def test_synth_without_a_height(tmp_path, capsys):
    assert main(["synth", "--rig", "drop-impact", "--out", str(tmp_path / "x.h5")]) == 2
    assert "argument --height: no drop height" in capsys.readouterr().err


def test_simulate_command(capsys, tmp_path):
    assert main(["drop", "simulate", "--height", "0.05", "--duration", "0.3", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["impact_speed_m_s"] == pytest.approx(STEEL_ON_PA6.impact_speed(0.05))
    assert data["impacts"]["approach_speed_m_s"][0] == pytest.approx(data["impact_speed_m_s"], rel=1e-14)
    assert main(["drop", "simulate", "--height", "0.05", "--show", "2"]) == 0
    text = capsys.readouterr().out
    assert "at rest after" in text and "more (--show N, or --out)" in text


def test_fit_command_errors(tmp_path, capsys):
    missing = tmp_path / "none.h5"
    assert main(["drop", "fit", str(missing)]) == 2
    assert "none.h5" in capsys.readouterr().err
    assert main(["drop", "fit", str(missing), "--channels", "speed"]) == 2
    assert "unknown channel 'speed'" in capsys.readouterr().err


def test_estimate_refuses_rig_ps_options_for_drop_recordings(tmp_path, capsys):
    # ``impactid estimate`` is generic: a drop recording runs this rig's estimate (MODEL.estimation); an
    # option of rig P's estimate given for it is refused, naming the option and the rigs
    from impactid.pipeline import _estimable
    from impactid.rigs.drop import MODEL

    assert _estimable(MODEL)
    path = synth_drop_impact(STEEL_ON_PA6, PA6_PAD_LAW, 0.05, duration=0.2).write(tmp_path / "drop.h5")
    assert main(["estimate", str(path), "--residual", "lambda2"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("impactid: error: argument --residual: not an option of 'estimate' for the 'drop-impact' "
                          "rig") and "'pivoted-follower'" in err and err.count("\n") == 1

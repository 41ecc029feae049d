"""Hostile inputs to ``impactid valvetrain ... --rig finger-follower-hla``: each ends in one
``impactid: error:`` line naming the argument, file or channel, exit 2, no traceback, no output file.

One test per class of failure: camshaft speeds outside the model's range (arguments and a
recording's operating point), fits on channels that carry no information, recordings given twice,
absurd operating points in a recording, and arguments that used to be ignored or misread.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from impactid.cli import main
from impactid.io import Recording, write_hdf5
from impactid.rigs.finger_follower.parameters import KIM1990
from impactid.rigs.finger_follower.simulate import prepare, rigid_jump_rpm, speed_range
from impactid.rigs.finger_follower.synth import Sensors, synth_recording
from tests.cli_contract import fails_with_one_line

FF = ("--rig", "finger-follower-hla")


_fails = fails_with_one_line


@pytest.fixture(scope="module")
def recording():
    """Three revolutions at 900 rpm, angle-domain sampling, the default (noisy) sensors."""
    return synth_recording(KIM1990, 900.0, revolutions=3, seed=2).recording


def _variant(rec, path, *, operating=None, **channels):
    data = dict(rec.channels)
    data.update(channels)
    out = Recording(channels=data, sample_rate_hz=rec.sample_rate_hz, units=rec.units, rig=rec.rig,
                    operating=dict(rec.operating, **(operating or {})))
    return str(write_hdf5(out, path))


# ---- 1. camshaft speeds outside the model's range ------------------------------------------------


def test_the_speed_range_comes_from_the_rigid_jump_speed(train):
    # the closed form is within 6 % of the simulated jump speed (3130 rpm, test_simulate)
    assert rigid_jump_rpm(train) == pytest.approx(3303.2, abs=0.5)
    assert 3130.0 < rigid_jump_rpm(train) < 1.07 * 3130.0
    speeds = speed_range(train)
    assert speeds.lowest_rpm == pytest.approx(3303.2 / 300, rel=1e-3)
    assert speeds.highest_rpm == pytest.approx(3 * 3303.2, rel=1e-3)
    # a heavier valve leaves the cam earlier, and the range moves with it
    assert speed_range(prepare(KIM1990.replace(M_v=2 * KIM1990.M_v))).highest_rpm < 0.8 * speeds.highest_rpm


@pytest.mark.parametrize("argv, needles", [
    (["valvetrain", "simulate", *FF, "--rpm", "1e9"], ("argument --rpm", "1e+09 rpm is above", "9910 rpm")),
    (["valvetrain", "simulate", *FF, "--rpm", "1"], ("argument --rpm", "below", "11.01")),
    (["valvetrain", "simulate", *FF, "--rpm", "nan"], ("argument --rpm", "positive")),
    (["valvetrain", "modes", *FF, "--rpm", "1e12"], ("argument --rpm", "above")),
    (["valvetrain", "leakdown", *FF, "--rpms", "900,1e9"], ("argument --rpms", "above")),
    (["valvetrain", "jump-speed", *FF, "--rpm-to", "1e6"], ("argument --rpm-to", "above")),
    (["valvetrain", "jump-speed", *FF, "--rpm-from", "2", "--rpm-to", "3000"], ("argument --rpm-from", "below")),
    (["valvetrain", "synth", *FF, "--rpm", "1e5", "--out", "never.h5"], ("argument --rpm", "above")),
])
def test_speeds_outside_the_range_are_refused(argv, needles, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    _fails(capsys, argv, *needles)
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("command", ["fit-tappet", "fit-lift"])
@pytest.mark.parametrize("hz, side", [(500.0, "above"), (0.1, "below")])
def test_a_recordings_operating_speed_is_checked_and_named(command, hz, side, capsys, tmp_path, recording):
    # 30000 and 6 rpm: speeds a recording may hold, outside what this rig's model describes
    path = _variant(recording, tmp_path / "odd.h5", operating={"cam_speed_hz": hz})
    out = tmp_path / "fit.json"
    _fails(capsys, ["valvetrain", command, *FF, path, "--out", str(out)],
           "odd.h5", f"operating cam_speed_hz = {hz:g} Hz", side)
    assert not out.exists()


# ---- 2. fits on data that carry no information --------------------------------------------------------


@pytest.mark.parametrize("command, channel", [("fit-tappet", "tappet_displacement"),
                                              ("fit-lift", "valve_displacement")])
@pytest.mark.parametrize("kind, needle", [("zero", "zero in every sample"), ("constant", "constant (2e-05 m"),
                                          ("short", "too short")])
def test_fits_refuse_channels_without_information(command, channel, kind, needle, capsys, tmp_path, recording):
    n = recording.n_samples
    if kind == "short":
        rec = Recording(channels={k: v[: n // 5] for k, v in recording.channels.items()},
                        sample_rate_hz=recording.sample_rate_hz, units=recording.units, rig=recording.rig,
                        operating=recording.operating)
        path = str(write_hdf5(rec, tmp_path / f"{kind}.h5"))
        needles = ("short.h5", "too short")
    else:
        values = {"zero": np.zeros(n), "constant": np.full(n, 2e-5)}[kind]
        path = _variant(recording, tmp_path / f"{kind}.h5", **{channel: values})
        needles = (f"{kind}.h5", f"channel {channel!r}", needle)
    out = tmp_path / "fit.json"
    _fails(capsys, ["valvetrain", command, *FF, path, "--out", str(out)], *needles)
    assert not out.exists()


def _noise_only(recording, channel, path):
    return _variant(recording, path, **{channel: np.random.default_rng(3).normal(0.0, 1e-6, recording.n_samples)})


@pytest.mark.slow
def test_fit_lift_refuses_a_channel_of_noise_alone(capsys, tmp_path, recording):
    path = _noise_only(recording, "valve_displacement", tmp_path / "noise.h5")
    _fails(capsys, ["valvetrain", "fit-lift", *FF, path], "noise.h5", "channel 'valve_displacement'",
           "carries no information for this fit")


@pytest.mark.slow
def test_fit_tappet_refuses_a_channel_of_noise_alone(capsys, tmp_path, recording):
    # (one to two minutes: the optimiser tries the whole parameter range before it gives up)
    path = _noise_only(recording, "tappet_displacement", tmp_path / "noise.h5")
    _fails(capsys, ["valvetrain", "fit-tappet", *FF, path], "noise.h5", "channel 'tappet_displacement'",
           "carries no information for this fit")


def test_one_recording_without_information_does_not_take_the_others_with_it(capsys, tmp_path, recording):
    good = _variant(recording, tmp_path / "good.h5")
    dead = _variant(recording, tmp_path / "dead.h5", tappet_displacement=np.zeros(recording.n_samples))
    out = tmp_path / "fit.json"
    assert main(["valvetrain", "fit-tappet", *FF, good, dead, "--json", "--out", str(out)]) == 1
    captured = capsys.readouterr()
    data = json.loads(captured.out)
    # one fit per recording: a TappetFitSet, the failures in its details
    assert data["kind"] == "finger_follower_tappet_set" and data["recordings_read"] == [good, dead]
    assert data["statistics"] == {"fits": 1, "failed": 1}
    assert data["tables"]["fits"]["data"][0][data["tables"]["fits"]["columns"].index("recordings")] == good
    assert data["params"]["fit0.alpha"]["value"] == pytest.approx(0.0071, rel=0.05)
    failed = data["details"]["failed"]
    assert failed[0]["recording"] == dead and "zero in every sample" in failed[0]["reason"]
    assert "impactid: warning: not fitted" in captured.err and "impactid: error" not in captured.err
    assert json.loads(out.read_text())["details"]["failed"] == failed
    # jointly, the dead channel spoils the one fit: refused as a whole
    _fails(capsys, ["valvetrain", "fit-tappet", *FF, good, dead, "--joint"], "dead.h5", "zero in every sample")


# ---- 4. the same recording twice ---------------------------------------------------------------------


def test_fit_tappet_refuses_a_recording_given_twice(capsys, tmp_path, recording):
    path = _variant(recording, tmp_path / "a.h5")
    copy = tmp_path / "b.h5"
    copy.write_bytes((tmp_path / "a.h5").read_bytes())
    _fails(capsys, ["valvetrain", "fit-tappet", *FF, path, str(tmp_path / "." / "a.h5")], "a.h5", "given twice")
    _fails(capsys, ["valvetrain", "fit-tappet", *FF, path, str(copy), "--joint"], "b.h5", "identical contents")


# ---- absurd operating points and channels in a recording ------------------------------------------------


@pytest.mark.parametrize("operating, needles", [
    ({"samples_per_revolution": 1e12}, ("samples_per_revolution",)),
    ({"samples_per_revolution": 36.5}, ("samples_per_revolution", "whole number")),
    ({"samples_per_revolution": 720.0}, ("samples_per_revolution", "disagrees with channel 'cam_angle'")),
    ({"nose_angle_rad": 1e30}, ("nose_angle_rad",)),
])
def test_absurd_operating_points_are_refused(operating, needles, capsys, tmp_path, recording):
    path = _variant(recording, tmp_path / "odd.h5", operating=operating)
    _fails(capsys, ["valvetrain", "fit-tappet", *FF, path], "odd.h5", *needles)


def test_a_cam_angle_standing_still_is_refused(capsys, tmp_path, recording):
    path = _variant(recording, tmp_path / "stuck.h5", cam_angle=np.zeros(recording.n_samples))
    _fails(capsys, ["valvetrain", "fit-lift", *FF, path], "stuck.h5", "cam_angle", "does not increase")


def test_a_large_nose_angle_costs_no_precision(recording):
    from impactid.rigs.finger_follower.identify import synchronous_average

    shifted = recording.with_step("nose a thousand revolutions on", operating=dict(
        recording.operating, nose_angle_rad=recording.operating["nose_angle_rad"] + 2e3 * np.pi))
    a, b = synchronous_average(recording), synchronous_average(shifted)
    np.testing.assert_allclose(b.theta, a.theta, atol=1e-12)
    np.testing.assert_array_equal(b.mean["tappet_displacement"], a.mean["tappet_displacement"])


def test_non_finite_samples_are_refused_naming_file_and_channel(capsys, tmp_path):
    from impactid.rigs.registry import save_rig_toml

    rig = save_rig_toml(KIM1990, tmp_path / "rig.toml", {"cam_speed_hz": 15.0})
    path = tmp_path / "rec.csv"
    path.write_text("time_s,cam_angle,tappet_displacement,valve_displacement\n0,0,0,0\n0.001,0.1,inf,0\n"
                    "0.002,0.2,0,0\n")
    _fails(capsys, ["valvetrain", "fit-tappet", *FF, str(path), "--rig-file", str(rig)],
           "rec.csv", "tappet_displacement")


# ---- arguments that were ignored or misread ------------------------------------------------------------


@pytest.mark.parametrize("argv, needles", [
    (["valvetrain", "simulate", *FF, "--rpm", "900", "--level", "B"], ("argument --level", "another rig")),
    (["valvetrain", "simulate", *FF, "--rpm", "900", "--speeds", "1000"], ("argument --speeds",)),
    (["valvetrain", "synth", *FF, "--rpm", "900", "--sample-rate", "1000", "--out", "x.h5"],
     ("argument --sample-rate",)),
    (["valvetrain", "jump-speed", *FF, "--xtol", "1"], ("argument --xtol",)),
    (["valvetrain", "simulate", *FF, "--rpm", "900", "--preset", "kushwaha2000"], ("argument --preset", "unknown")),
    (["valvetrain", "simulate", *FF, "--rpm", "900", "--preset", "kim1990", "--rig-file", "r.toml"],
     ("--rig-file or --preset",)),
    (["valvetrain", "synth", *FF, "--rpm", "900", "--revolutions", "2.5", "--out", "x.h5"],
     ("argument --revolutions", "whole number")),
    (["valvetrain", "synth", *FF, "--rpm", "900", "--revolutions", "-2", "--out", "x.h5"],
     ("argument --revolutions", "positive")),
    (["valvetrain", "synth", *FF, "--rpm", "900", "--seed", "-1", "--out", "x.h5"], ("argument --seed",)),
    (["valvetrain", "jump-speed", *FF, "--resolution-rpm", "1e-300"], ("argument --resolution-rpm", "at least")),
    (["valvetrain", "jump-speed", *FF, "--rpm-from", "3000", "--rpm-to", "3500", "--rpm-step", "1000"],
     ("argument --rpm-step",)),
])
def test_bad_or_foreign_arguments_are_refused(argv, needles, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    _fails(capsys, argv, *needles)
    assert not list(tmp_path.iterdir())


def test_synth_to_csv_never_overwrites_its_rig_file(capsys, tmp_path):
    from impactid.rigs.registry import save_rig_toml

    rig = save_rig_toml(KIM1990.replace(F_tf0=30.0), tmp_path / "rec.toml")
    before = rig.read_bytes()
    _fails(capsys, ["valvetrain", "synth", *FF, "--rpm", "900", "--rig-file", str(rig), "--out",
                    str(tmp_path / "rec.csv")], "rec.toml", "is an input")
    assert rig.read_bytes() == before and sorted(p.name for p in tmp_path.iterdir()) == ["rec.toml"]


def test_a_low_speed_lift_recording_inside_the_range_is_still_fitted(capsys, tmp_path):
    # the lower end of the range (11 rpm) leaves room for the quasi-static lift fit at low speed
    rec = synth_recording(KIM1990, 300.0, revolutions=1, sensors=Sensors.ideal()).recording
    path = str(write_hdf5(rec, tmp_path / "slow.h5"))
    assert main(["valvetrain", "fit-lift", *FF, path, "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["params"]["S_K"]["value"] == pytest.approx(6e-3, rel=1e-3)


# ---- a part that cannot be done does not take the others with it ------------------------------------


def _failing_at(monkeypatch, bad_rpm):
    import importlib

    from impactid.errors import SimulationError

    # (the package re-exports the function ``simulate``, which shadows the module of the same name)
    S = importlib.import_module("impactid.rigs.finger_follower.simulate")

    real = S.steady_state

    def flaky(model, rpm, **options):
        if rpm == bad_rpm:
            raise SimulationError(f"finger-follower simulation at {rpm:g} rpm: the contacts chatter (test)")
        return real(model, rpm, **options)

    monkeypatch.setattr(S, "steady_state", flaky)


def test_leakdown_keeps_the_speeds_that_ran(monkeypatch, capsys, tmp_path):
    _failing_at(monkeypatch, 800.0)
    out = tmp_path / "leak.json"
    assert main(["valvetrain", "leakdown", *FF, "--rpms", "600,800,900", "--json", "--out", str(out)]) == 1
    captured = capsys.readouterr()
    rows = json.loads(captured.out)["leakdown"]
    assert [r["rpm"] for r in rows] == [600.0, 800.0, 900.0]
    assert rows[1]["max_tappet_leakdown_m"] is None and "chatter (test)" in rows[1]["failure"]
    assert rows[0]["max_tappet_leakdown_m"] > rows[2]["max_tappet_leakdown_m"] > 50e-6
    assert "impactid: warning: 800 rpm left out" in captured.err and "impactid: error" not in captured.err
    assert json.loads(out.read_text())["leakdown"] == rows
    _failing_at(monkeypatch, 600.0)
    _fails(capsys, ["valvetrain", "leakdown", *FF, "--rpms", "600"], "no speed could be simulated", "600 rpm")


def test_jump_speed_leaves_out_a_speed_that_cannot_be_simulated(monkeypatch, train):
    from impactid.rigs.finger_follower.simulate import critical_speeds

    _failing_at(monkeypatch, 3250.0)
    speeds = critical_speeds(train, rpm_from=3000.0, rpm_to=3500.0, step_rpm=250.0, resolution_rpm=1.0)
    # the jump (3130 rpm) is bracketed by the speeds that ran; the bisection stops at the failing one
    assert speeds.jump_speed_rpm == 3500.0
    assert any("could not be simulated and are left out (3250 rpm" in n for n in speeds.notes)
    assert any("the jump speed lies in (3000, 3500] rpm" in n for n in speeds.notes)
    assert speeds.sweep["failure"].astype(bool).sum() == 2

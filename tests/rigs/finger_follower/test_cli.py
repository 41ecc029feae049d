"""The ``impactid valvetrain ... --rig finger-follower-hla`` commands, called through main() as a user would."""

from __future__ import annotations

import json

import pytest

from impactid.cli import main

#: both valve trains contribute simulate, jump-speed and synth: --rig chooses
FF = ("--rig", "finger-follower-hla")


def _json(capsys):
    return json.loads(capsys.readouterr().out)


def test_simulate_json_keys_and_outputs(tmp_path, capsys):
    out, plots = tmp_path / "sim.json", tmp_path / "figs"
    assert main(["valvetrain", "simulate", *FF, "--rpm", "2450", "--json",
                 "--out", str(out), "--plots", str(plots)]) == 0
    data = _json(capsys)
    for key in ("max_valve_lift_m", "max_tappet_leakdown_m", "seating_speed_m_s", "peak_cam_force_opening_N",
                "peak_cam_force_closing_N", "separations"):
        assert key in data
    assert data["peak_cam_force_opening_N"] == pytest.approx(680.0, abs=1.0)
    assert data["separations"][0]["contact"] == "tappet/follower"
    assert "start_cam_angle_deg" in data["separations"][0]
    assert json.loads(out.read_text())["max_valve_lift_m"] == data["max_valve_lift_m"]
    assert (plots / "cycle.png").stat().st_size > 1000 and (plots / "rocker_ratio.png").exists()
    assert not list(tmp_path.rglob("*.tmp"))


def test_simulate_with_a_rig_file_and_lift_table(tmp_path, capsys):
    from impactid.rigs.finger_follower.cam import CycloidalLift, write_lift
    from impactid.rigs.finger_follower.parameters import KIM1990
    from impactid.rigs.registry import save_rig_toml

    rig_file = save_rig_toml(KIM1990.replace(F_tf0=40.0), tmp_path / "rig.toml")
    lift = write_lift(CycloidalLift(5e-3, 1.6, 1.6), tmp_path / "lift.csv")
    assert main(["valvetrain", "simulate", *FF, "--rpm", "900", "--rig-file", str(rig_file), "--lift", str(lift),
                 "--json"]) == 0
    data = _json(capsys)
    assert data["max_valve_lift_m"] == pytest.approx(5e-3 * 9.445 / 6.0, rel=0.05)


def test_modes_json(capsys):
    assert main(["valvetrain", "modes", "--json"]) == 0
    data = _json(capsys)
    seated, opened = data["frequencies_hz"]["seated"], data["frequencies_hz"]["open"]
    assert len(seated) == len(opened) == 6
    assert seated[0] == pytest.approx(504, rel=0.01) and seated[-1] == pytest.approx(11.3e3, rel=0.005)


@pytest.mark.slow
def test_jump_speed_json(capsys):
    assert main(["valvetrain", "jump-speed", *FF, "--rpm-from", "3000", "--rpm-to", "3750", "--rpm-step", "250",
                 "--json"]) == 0
    data = _json(capsys)
    assert data["jump_speed_rpm"] == pytest.approx(3130.0, abs=2.0)
    assert data["bounce_speed_rpm"] == pytest.approx(3641.0, abs=2.0)


@pytest.mark.slow
def test_synth_then_fit_tappet_and_fit_lift(tmp_path, capsys):
    rec = tmp_path / "ff900.h5"
    assert main(["valvetrain", "synth", *FF, "--rpm", "900", "--revolutions", "4", "--out", str(rec)]) == 0
    capsys.readouterr()
    out, plots = tmp_path / "fit.json", tmp_path / "plots"
    assert main(["valvetrain", "fit-tappet", str(rec), "--json", "--out", str(out), "--plots", str(plots)]) == 0
    data = _json(capsys)
    assert data["kind"] == "finger_follower_tappet" and data["recordings_read"] == [str(rec)]
    params = data["params"]
    assert params["alpha"]["value"] == pytest.approx(0.0071, rel=0.01)
    assert params["beta"]["value"] == pytest.approx(0.28, rel=0.01)
    assert params["c_t"]["interval"][0] < params["c_t"]["value"] < params["c_t"]["interval"][1]
    assert (plots / "tappet_fit_0.png").exists() and out.exists()
    low = tmp_path / "ff600.csv"
    assert main(["valvetrain", "synth", *FF, "--rpm", "600", "--revolutions", "2", "--noise-free",
                 "--out", str(low)]) == 0
    assert low.with_suffix(".toml").exists()
    capsys.readouterr()
    assert main(["valvetrain", "fit-lift", str(low), "--json"]) == 0
    lift = _json(capsys)["params"]
    assert lift["S_K"]["value"] == pytest.approx(6e-3, rel=1e-3)


@pytest.mark.parametrize(("argv", "message"), [
    (["valvetrain", "simulate", *FF, "--rpm", "0"], "argument --rpm: must be positive"),
    (["valvetrain", "simulate", *FF], "argument --rpm: required"),
    (["valvetrain", "simulate", *FF, "--rpm", "900", "--rig-file", "/nonexistent/rig.toml"], "rig file not found"),
    (["valvetrain", "fit-tappet", "/nonexistent/rec.h5"], "/nonexistent/rec.h5"),
    (["valvetrain", "jump-speed", *FF, "--rpm-from", "3000", "--rpm-to", "2000"], "must exceed --rpm-from"),
    (["valvetrain", "simulate", *FF, "--rpm", "900", "--lift", "/nonexistent/lift.csv"], "lift file not found"),
])
def test_bad_input_exits_2_with_one_line(argv, message, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("impactid: error:") and message in err and err.count("\n") == 1


def test_outputs_are_checked_before_computing_and_inputs_protected(tmp_path, capsys):
    rec = tmp_path / "r.h5"
    assert main(["valvetrain", "synth", *FF, "--rpm", "900", "--revolutions", "1", "--noise-free",
                 "--out", str(rec)]) == 0
    before = rec.read_bytes()
    assert main(["valvetrain", "fit-tappet", str(rec), "--out", str(rec)]) == 2
    assert "is an input of this command" in capsys.readouterr().err
    assert rec.read_bytes() == before
    (tmp_path / "file").write_text("x")
    assert main(["valvetrain", "simulate", *FF, "--rpm", "900", "--plots", str(tmp_path / "file")]) == 2
    assert "--plots" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file", "r.h5"]

"""``impactid valvetrain simulate | jump-speed | fit-surge | synth`` end to end: JSON keys, files, errors."""

from __future__ import annotations

import json

import pytest

from impactid.cli import main
from impactid.rigs.cycloidal import KUSHWAHA2000
from impactid.rigs.registry import save_rig_toml

#: --rig is given everywhere: once another valve train registers the same commands it is required
RIG = "cycloidal-flat-follower-ehl"
KEYS = ("nose_film_thickness_m", "nose_entraining_velocity_m_s", "max_film_thickness_m", "min_film_thickness_m",
        "zero_entrainment_angles_deg", "min_contact_load_N", "max_contact_load_N", "max_hertz_pressure_Pa",
        "fraction_outside_range")


def _json(capsys, argv):
    assert main(argv) == 0
    return json.loads(capsys.readouterr().out)


def test_simulate_json(capsys):
    d = _json(capsys, ["valvetrain", "simulate", "--rig", RIG, "--rpm", "3000", "--json"])
    for key in KEYS:
        assert key in d, key
    assert d["nose_film_thickness_m"] == pytest.approx(0.978e-6, abs=1e-9)
    assert d["nose_entraining_velocity_m_s"] == pytest.approx(4.398, abs=1e-3)
    assert len(d["zero_entrainment_angles_deg"]) == 4
    assert set(d["fraction_outside_range"]) == {"W_star", "U_star", "G_star", "ws_star", "any"}
    assert d["level"] == "A" and not d["jump_predicted"]


@pytest.mark.slow
def test_simulate_text_files_and_level_b(tmp_path, capsys):
    out, plots = tmp_path / "r.json", tmp_path / "figs"
    assert main(["valvetrain", "simulate", "--rig", RIG, "--rpm", "3000", "--level", "B", "--out", str(out), "--plots",
                 str(plots), "--speeds", "1000"]) == 0
    text = capsys.readouterr().out
    assert "nose: film 0.97" in text and "level B" in text
    d = json.loads(out.read_text())
    assert d["converged"] and not d["jump"] and len(d["per_step"]["h_m"]) == 500
    assert sorted(p.name for p in plots.iterdir()) == ["entraining.png", "film.png", "hertz.png", "kinematics.png",
                                                      "load.png", "squeeze.png"]
    assert sorted(d["plots"]) == sorted(str(p) for p in plots.iterdir())  # the figures written, not []


def test_rig_file_and_operating_speed(tmp_path, capsys):
    path = save_rig_toml(KUSHWAHA2000.replace(eta0=0.045), tmp_path / "rig.toml", {"cam_speed_hz": 1000 / 60})
    d = _json(capsys, ["valvetrain", "simulate", "--rig", RIG, "--rig-file", str(path), "--json"])
    assert d["rpm"] == pytest.approx(1000.0) and d["nose_film_thickness_m"] == pytest.approx(0.98e-6, abs=0.01e-6)


def test_jump_speed_json(capsys):
    d = _json(capsys, ["valvetrain", "jump-speed", "--rig", RIG, "--level", "A", "--rpm-range", "3000,3400", "--json"])
    assert d["jump_speed_rpm"] == pytest.approx(3175.86, abs=0.05)
    assert d["rigid_jump_speed_rpm"] == pytest.approx(3239.5, abs=0.1)
    d = _json(capsys, ["valvetrain", "jump-speed", "--rig", RIG, "--level", "rigid", "--json"])
    assert d["jump_speed_rpm"] == pytest.approx(3239.5, abs=0.1)


def test_jump_speed_out_lists_its_figures_and_only_with_plots(tmp_path, capsys):
    """``--out`` JSON: ``plots`` names the figures written with ``--plots`` (not an empty list written
    before them) and is absent without it, as in the other commands."""
    argv = ["valvetrain", "jump-speed", "--rig", RIG, "--level", "rigid"]
    bare, out, plots = tmp_path / "bare.json", tmp_path / "jump.json", tmp_path / "figs"
    assert main([*argv, "--out", str(bare)]) == 0
    assert "plots" not in json.loads(bare.read_text())
    assert main([*argv, "--out", str(out), "--plots", str(plots)]) == 0
    capsys.readouterr()
    assert json.loads(out.read_text())["plots"] == [str(plots / "jump_speed.png")]
    assert (plots / "jump_speed.png").is_file()


@pytest.mark.slow
def test_synth_then_fit_surge(tmp_path, capsys):
    rec = tmp_path / "rec.h5"
    assert main(["valvetrain", "synth", "--rig", RIG, "--rpm", "3000", "--revolutions", "3", "--sample-rate", "20000",
                 "--noise-load", "2", "--seed", "5", "--out", str(rec)]) == 0
    capsys.readouterr()
    out = tmp_path / "fit.json"
    d = _json(capsys, ["valvetrain", "fit-surge", "--rig", RIG, str(rec), "--json", "--out", str(out), "--plots",
                       str(tmp_path / "p")])
    assert d["kind"] == "valvetrain-surge-fit" and (tmp_path / "p" / "surge_fit.png").exists()
    for name, true in (("f0", 504.5), ("c_spring", 2.355), ("f_p", 275.0), ("m3", 0.225)):
        lo, hi = d["params"][name]["interval"]
        assert abs(d["params"][name]["value"] - true) < 0.05 * true and hi > lo
    written = json.loads(out.read_text())
    assert written["params"] == d["params"] and written["recordings_read"] == [str(rec)]


@pytest.mark.parametrize("argv, message", [
    (["valvetrain", "simulate", "--rig", RIG, "--rpm", "-3"], "argument --rpm"),
    (["valvetrain", "simulate", "--rig", RIG, "--rpm", "nan"], "argument --rpm"),
    (["valvetrain", "simulate", "--rig", RIG], "no camshaft speed"),
    (["valvetrain", "simulate", "--rig", RIG, "--rpm", "1000", "--level", "C"], "argument --level"),
    (["valvetrain", "simulate", "--rig", RIG, "--rpm", "1000", "--preset", "nope"], "argument --preset"),
    (["valvetrain", "simulate", "--rig", RIG, "--rpm", "1000", "--ws-mode", "clamp"], "argument --ws-mode"),
    (["valvetrain", "simulate", "--rig", RIG, "--rpm", "1000", "--rig-file", "missing.toml"], "missing.toml"),
    (["valvetrain", "jump-speed", "--rig", RIG, "--level", "kinematic"], "argument --level"),
    (["valvetrain", "jump-speed", "--rig", RIG, "--rpm-range", "3000,2000"], "argument --rpm-range"),
    (["valvetrain", "fit-surge", "--rig", RIG], "give one or more recordings"),
    (["valvetrain", "fit-surge", "--rig", RIG, "missing.h5"], "missing.h5"),
    (["valvetrain", "fit-surge", "--rig", RIG, "x.h5", "--confidence", "1.5"], "argument --confidence"),
    (["valvetrain", "synth", "--rig", RIG, "--rpm", "1000"], "argument --out"),
])
def test_errors_are_one_line(argv, message, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("impactid: error:") and message in err and err.count("\n") == 1


def test_wrong_rig_file_and_output_checks(tmp_path, capsys):
    from impactid.rigs import ALZATE2007

    other = save_rig_toml(ALZATE2007, tmp_path / "flat.toml")
    assert main(["valvetrain", "simulate", "--rig", RIG, "--rpm", "1000", "--rig-file", str(other)]) == 2
    assert "'flat-follower' rig" in capsys.readouterr().err
    folder = tmp_path / "a_folder"
    folder.mkdir()
    assert main(["valvetrain", "simulate", "--rig", RIG, "--rpm", "1000", "--out", str(folder)]) == 2
    assert "--out" in capsys.readouterr().err

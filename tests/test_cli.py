"""The impactid command line, called through main(argv) as a user would."""

from __future__ import annotations

import json

import pytest

from impactid import SEED001_TABLE1, save_rig_toml
from impactid.cli import main


def test_regime_json(capsys):
    assert main(["regime", "--e-over-rc", "0.25", "--cam-speed", "15", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["regime"] == "period-1"
    assert data["period_revolutions"] == 1
    assert data["detachment_hz"] > 0


def test_detachment_json_with_rig_file(tmp_path, capsys):
    rig_file = save_rig_toml(SEED001_TABLE1.with_eccentricity_ratio(0.1), tmp_path / "rig.toml")
    assert main(["detachment", "--rig", str(rig_file), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["cam_speed_rpm"] == pytest.approx(60 * data["cam_speed_hz"])
    assert data["e_over_rc"] == pytest.approx(0.1)
    assert rig_file.read_text().count("[rig]") == 1  # the input file is untouched


def test_regime_map_writes_csv_and_png(tmp_path, capsys):
    out = tmp_path / "map"
    assert main(["regime-map", "--e-over-rc-values", "0.25", "--cam-speeds", "5,15", "--out", str(out), "--quiet"]) == 0
    assert (out / "regime_map.csv").read_text().count("\n") == 3
    assert (out / "regime_map.png").stat().st_size > 1000
    assert not list(out.glob("*.tmp"))


def test_simulate_command(tmp_path, capsys):
    assert main(["simulate", "--e-over-rc", "0.25", "--cam-speed", "15", "--duration", "0.5",
                 "--out", str(tmp_path / "c.csv")]) == 0
    assert "contacts in 0.5 s" in capsys.readouterr().out
    assert (tmp_path / "c.csv").exists()


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["regime", "--e-over-rc", "0.2", "--cam-speed", "0"], "cam speed must be positive"),
        (["regime", "--e-over-rc", "1.5", "--cam-speed", "16"], "smaller than the cam radius"),
        (["detachment", "--rig", "/nonexistent/rig.toml"], "/nonexistent/rig.toml: rig file not found"),
        (["simulate", "--cam-speed", "16", "--beta", "-1"], "beta must be >= 0"),
    ],
)
def test_bad_input_exits_2_with_message(argv, message, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("impactid: error:") and message in err


def test_bad_rig_parameter_names_file_and_parameter(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    text = SEED001_TABLE1.to_toml().replace("k_s = 3319.0", "k_s = -5.0")
    bad.write_text(text)
    assert main(["detachment", "--rig", str(bad)]) == 2
    err = capsys.readouterr().err
    assert str(bad) in err and "'k_s' must be positive" in err


def test_version(capsys):
    with pytest.raises(SystemExit) as info:
        main(["--version"])
    assert info.value.code == 0
    assert "impactid" in capsys.readouterr().out

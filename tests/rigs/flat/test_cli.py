"""The rig F commands of the CLI: detachment, bifurcation, restitution."""

from __future__ import annotations

import json

import numpy as np
import pytest

from impactid import save_rig_toml
from impactid.cli import main
from impactid.results import FitResult
from impactid.rigs import ALZATE2007
from impactid.rigs.flat.encoder_impacts import SpeedLawResult
from impactid.rigs.flat.simulate import DEFAULT_RESTITUTION
from impactid.rigs.flat.synth_impacts import synth_flat_impacting
from tests.golden import assert_matches_golden
from tests.rigs.flat import golden_view


def result_keys():
    return FitResult(params=()).to_dict().keys()


def test_detachment_flat_rig_file(tmp_path, capsys):
    rig_file = save_rig_toml(ALZATE2007, tmp_path / "rigF.toml")
    assert main(["detachment", "--rig", str(rig_file), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["rig"] == "flat-follower"
    assert data["cam_speed_rpm"] == pytest.approx(122.454, abs=1e-3)  # paper: 125 rpm
    assert main(["detachment", "--rig", "flat-follower", "--mu", "0.1"]) == 2  # rig P options refused


def test_bifurcation_writes_csv_png_and_transitions(tmp_path, capsys):
    out = tmp_path / "bif"
    rig_file = save_rig_toml(ALZATE2007, tmp_path / "rigF.toml")
    assert main(["bifurcation", "--rig", str(rig_file), "--from", "110", "--to", "165", "--unit", "rpm",
                 "--speeds", "23", "--revolutions", "60", "--out", str(out), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    tr = data["transitions"]
    assert 120.0 < tr["detachment_rpm"] < 126.0
    assert 145.0 < tr["period1_end_rpm"] <= 160.0
    assert tr["irregular_rpm"] >= tr["period1_end_rpm"]
    regimes = (out / "regimes.csv").read_text()
    assert regimes.count("\n") == 24 and "contact" in regimes and "period-1" in regimes
    assert (out / "bifurcation.csv").read_text().count("\n") == 23 * 30 + 1
    assert (out / "bifurcation.png").stat().st_size > 5000
    assert not list(out.glob("*.tmp"))


def test_bifurcation_bad_range_and_rig(tmp_path, capsys):
    assert main(["bifurcation", "--from", "160", "--to", "110", "--out", str(tmp_path)]) == 2
    assert "from" in capsys.readouterr().err
    assert main(["bifurcation", "--rig", "pivoted-follower", "--out", str(tmp_path)]) == 2
    assert "flat-follower" in capsys.readouterr().err


@pytest.fixture(scope="module")
def impacting_files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("rigF")
    paths = []
    for rpm in (132.0, 146.0):
        s = synth_flat_impacting(ALZATE2007, rpm / 60.0, 3.0, cam_zero_offset=1.0 + rpm / 100)
        paths.append(str(s.write(folder / f"impacting_{rpm:.0f}.h5")))
    return paths


@pytest.mark.slow
def test_restitution_command_recovers_law(impacting_files, tmp_path, capsys):
    out = tmp_path / "law.json"
    assert main(["restitution", *impacting_files, "--out", str(out), "--json"]) == 0
    data = json.loads(out.read_text())
    assert json.loads(capsys.readouterr().out) == data
    # the fit-result schema (docs/formats.md, "Fit results"), plus the command's own keys
    assert data["kind"] == "speed-restitution" and list(data["params"]) == ["a", "b"]
    assert data["recordings_read"] == impacting_files and data["details"]["method"] == "impact-law"
    assert set(data) - set(result_keys()) == {"recordings_read"}
    result = FitResult.from_dict(data)
    assert type(result) is SpeedLawResult and result["b"].unit == "s/rad"
    view = golden_view(data)
    for point in view["tables"]["points"]:
        hz = point["cam_speed_hz"]
        assert point["restitution"] == pytest.approx(DEFAULT_RESTITUTION(hz), rel=0.02)
    law = data["details"]["law"]
    assert law["a"] == data["params"]["a"]["value"] and law["b_per_rad_s"] == data["params"]["b"]["value"]
    rpm = np.array([132.0, 146.0])
    fitted = law["a"] + law["b_per_rpm"] * rpm
    np.testing.assert_allclose(fitted, [DEFAULT_RESTITUTION(r / 60.0) for r in rpm], rtol=0.02)
    assert_matches_golden(view, "restitution.json")


def test_restitution_command_errors(impacting_files, tmp_path, capsys):
    assert main(["restitution"]) == 2
    assert main(["restitution", impacting_files[0], "--out", impacting_files[0]]) == 2
    assert "refusing to overwrite" in capsys.readouterr().err
    assert main(["restitution", str(tmp_path / "missing.h5")]) == 2

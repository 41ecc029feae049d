"""``impactid bounces`` end to end: JSON keys, figures, one-line errors with exit status 2."""

import json

import numpy as np
import pytest

from impactid.cli import main
from impactid.results import FitResult
from impactid.rigs.ball import BounceAnalysis
from impactid.rigs.ball.synth import write_phyphox_csv, write_phyphox_xlsx


@pytest.fixture(scope="module")
def files(tmp_path_factory, faulty_drops):
    folder = tmp_path_factory.mktemp("drops")
    paths = [write_phyphox_xlsx(folder / f"drop{i}.xlsx", d.times) for i, d in enumerate(faulty_drops[2:])]
    paths.append(write_phyphox_csv(folder / "drop.csv", faulty_drops[1].times, separator=";", decimal=","))
    return [str(p) for p in paths]


def _run(argv, capsys):
    code = main([str(a) for a in argv])
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.mark.slow
def test_json_and_figures(files, tmp_path, capsys):
    out, plots = tmp_path / "r.json", tmp_path / "plots"
    code, stdout, err = _run(["bounces", *files, "--ball", "pingpong", "--out", out, "--plots", plots,
                              "--no-chained"], capsys)
    assert code == 0, err
    data = json.loads(out.read_text())
    # the analysis in the FitResult schema at the top level, plus the files read and the figures written
    schema = {"kind", "impactid_version", "params", "statistics", "notes", "tables", "details", "provenance",
              "model_check", "identifiability"}
    assert set(data) == schema | {"recordings_read", "plots"} and data["kind"] == "bounce-analysis"
    # every law's fit states its model check and identifiability (docs/identifiability.md)
    for law in data["details"]["laws"].values():
        assert law["model_check"]["verdict"] in ("consistent", "structured") and law["identifiability"]["names"]
    assert data["recordings_read"] == files and len(data["plots"]) == 2
    back = FitResult.from_dict(data)
    assert isinstance(back, BounceAnalysis) and back["linear.gamma"].value == data["params"]["linear.gamma"]["value"]
    assert back.law_fits["linear"].statistics["condition_number"] >= 1.0
    assert {"constant.e", "linear.e0", "linear.gamma"} <= set(data["params"])
    assert data["details"]["selected"] in ("constant", "linear", "viscoelastic") and data["details"]["drag"] is True
    columns = data["tables"]["bounces"]["columns"]
    assert {"file", "index", "interval_s", "impact_speed_m_s", "e", "flag", "reason"} <= set(columns)
    assert sorted(p.name for p in plots.iterdir()) == ["intervals.png", "restitution.png"]
    assert "selected" in stdout
    code, stdout, _ = _run(["bounces", *files, "--json", "--no-drag", "--no-chained"], capsys)
    assert code == 0 and json.loads(stdout)["details"]["drag"] is False


def test_custom_ball(files, capsys):
    code, stdout, err = _run(["bounces", *files[:2], "--mass", "0.0027", "--diameter", "0.04",
                              "--drag-coefficient", "0.5", "--law", "constant", "--no-chained", "--json"], capsys)
    assert code == 0, err
    data = json.loads(stdout)
    assert data["details"]["ball"]["drag_coefficient"] == 0.5 and data["details"]["selected"] == "constant"


@pytest.mark.parametrize("args,token", [
    (["--ball", "football"], "argument --ball: unknown ball 'football'"),
    (["--mass", "0.01"], "argument --mass: a custom ball needs --diameter"),
    (["--diameter", "0.04"], "argument --diameter: a custom ball needs --mass"),
    (["--ball", "golf", "--mass", "0.01", "--diameter", "0.04"], "either --ball or --mass"),
    (["--mass", "nan", "--diameter", "0.04"], "argument --mass: expected a finite number"),
    (["--mass", "-1", "--diameter", "0.04"], "argument --mass: must be positive"),
    (["--drag-coefficient", "0.4"], "argument --drag-coefficient: needs a ball"),
    (["--law", "cubic"], "argument --law: invalid choice"),
])
def test_usage_errors(files, args, token, capsys):
    code, _, err = _run(["bounces", files[0], *args], capsys)
    assert code == 2
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("impactid: error:") and token in lines[0], err


def test_bad_file_is_one_line_naming_it(tmp_path, files, capsys):
    bad = tmp_path / "bad.xlsx"
    bad.write_text("not a workbook")
    out = tmp_path / "r.json"
    code, _, err = _run(["bounces", files[0], str(bad), "--out", out], capsys)
    assert code == 2 and str(bad) in err and len(err.strip().splitlines()) == 1
    assert not out.exists()


def test_output_checked_before_computing(files, capsys):
    code, _, err = _run(["bounces", files[0], "--out", files[0]], capsys)
    assert code == 2 and "is an input of this command" in err


@pytest.mark.slow
def test_wav_end_to_end(tmp_path, capsys):
    from impactid.rigs.ball import TABLE_TENNIS
    from impactid.rigs.ball.synth import simulate_drop, synth_audio, write_wav

    sim = simulate_drop("constant", {"e": 0.93}, ball=TABLE_TENNIS, height=0.2, first_impact=0.2, min_flight=0.09)
    speeds = np.r_[2.0, sim["v"][: sim["times"].size - 1]]
    wav = write_wav(tmp_path / "drop.wav", synth_audio(sim["times"], speeds, rng=np.random.default_rng(0)), 48000)
    code, stdout, err = _run(["bounces", wav, "--ball", "pingpong", "--plots", tmp_path / "p", "--json",
                              "--no-chained"], capsys)
    assert code == 0, err
    data = json.loads(stdout)
    e = data["params"]["constant.e"]
    assert abs(e["value"] - 0.93) < 3 * e["stderr"] + 1e-3
    assert (tmp_path / "p" / "onsets_drop.png").exists()

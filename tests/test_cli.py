"""The impactid command line, called through main(argv) as a user would."""

from __future__ import annotations

import json
import re

import pytest

from impactid import SUNDAR2016, save_rig_toml
from impactid.cli import main
from tests.golden import assert_matches_golden


def test_regime_json(capsys):
    assert main(["regime", "--e-over-rc", "0.25", "--cam-speed", "15", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["regime"] == "period-1"
    assert data["period_revolutions"] == 1
    assert data["detachment_hz"] > 0


def test_detachment_json_with_rig_file(tmp_path, capsys):
    rig_file = save_rig_toml(SUNDAR2016.with_eccentricity_ratio(0.1), tmp_path / "rig.toml")
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
        (["regime", "--e-over-rc", "0.2", "--cam-speed", "0"], "argument --cam-speed: must be positive"),
        (["regime", "--e-over-rc", "1.5", "--cam-speed", "16"], "smaller than the cam radius"),
        (["detachment", "--rig", "/nonexistent/rig.toml"], "/nonexistent/rig.toml: rig file not found"),
        (["simulate", "--cam-speed", "16", "--beta", "-1"], "argument --beta: must be >= 0"),
    ],
)
def test_bad_input_exits_2_with_message(argv, message, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("impactid: error:") and message in err


def test_bad_rig_parameter_names_file_and_parameter(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    text = SUNDAR2016.to_toml().replace("k_s = 3319.0", "k_s = -5.0")
    bad.write_text(text)
    assert main(["detachment", "--rig", str(bad)]) == 2
    err = capsys.readouterr().err
    assert str(bad) in err and "'k_s' must be positive" in err


def test_version(capsys):
    with pytest.raises(SystemExit) as info:
        main(["--version"])
    assert info.value.code == 0
    assert "impactid" in capsys.readouterr().out


def test_synth_s2_then_info(tmp_path, capsys):
    out = tmp_path / "s2.h5"
    assert main(["synth", "--rig", "pivoted-follower", "--e-over-rc", "0.2", "--cam-speed", "16", "--beta", "24.7e9",
                 "--n", "1.5", "--duration", "0.1", "--settle", "2", "--noise", "0.005", "--adc-bits", "16",
                 "--out", str(out)]) == 0
    assert main(["info", str(out), "--json"]) == 0
    data = json.loads(capsys.readouterr().out.split("\n", 1)[1])
    assert data["n_samples"] == 20480 and data["operating"]["cam_speed_hz"] == 16.0
    assert set(data["channels"]) == {"accel_tangential", "force_x", "force_y", "cam_angle"}
    from impactid.io import read_truth

    truth = read_truth(out)
    assert truth["law"] == "hunt-crossley" and truth["applied"]["force_x"]["adc_bits"] == 16


def test_synth_s3_and_rig_f(tmp_path, capsys):
    from impactid.io import read_truth

    assert main(["synth", "--law", "restitution", "--gamma", "0.8", "--cam-speed", "16", "--duration", "0.1",
                 "--settle", "2", "--out", str(tmp_path / "s3.h5")]) == 0
    assert read_truth(tmp_path / "s3.h5")["gamma"] == 0.8
    assert main(["synth", "--rig", "flat-follower", "--rpm", "110", "--duration", "0.5",
                 "--out", str(tmp_path / "f.h5")]) == 0
    truth = read_truth(tmp_path / "f.h5")
    assert truth["cam_ppr"] == 5000 and truth["follower_ppr"] == 10_000
    assert main(["synth", "--rig", "flat-follower", "--rpm", "140", "--duration", "1", "--restitution", "0.6",
                 "--out", str(tmp_path / "g.h5")]) == 0            # above detachment: impacting
    truth = read_truth(tmp_path / "g.h5")
    assert truth["restitution"] == pytest.approx(0.6) and len(truth["impact_times"]) > 0
    assert main(["synth", "--rig", "flat-follower", "--rpm", "110", "--restitution", "0.6",
                 "--out", str(tmp_path / "h.h5")]) == 2            # below detachment: no impacts to give a law
    assert "detachment" in capsys.readouterr().err
    assert not (tmp_path / "h.h5").exists()


def test_example_recording_is_cached_and_readable(tmp_path, monkeypatch):
    monkeypatch.setenv("IMPACTID_CACHE_DIR", str(tmp_path))
    from impactid.rigs.pivoted.example import EXAMPLE_POINTS, EXAMPLE_RECIPE, example_recording, example_recording_path

    path = example_recording_path()
    assert path.parent == tmp_path
    mtime = path.stat().st_mtime_ns
    rec = example_recording()
    (ratio, speed), recipe = EXAMPLE_POINTS[0], EXAMPLE_RECIPE
    assert rec.n_samples == round(recipe["duration"] * recipe["sample_rate_hz"])
    assert rec.cam_speed_hz == speed and rec.rig.e_over_rc == pytest.approx(ratio)
    assert example_recording_path().stat().st_mtime_ns == mtime  # cached, not regenerated


def test_example_truth_comes_from_the_recipe_for_the_example_files_only(tmp_path):
    """The truth printed beside the example's estimates is the recipe's, named by the example's file names
    (no file is read); other recordings, or only some of the example's, get none."""
    from impactid.rigs.pivoted.example import EXAMPLE_POINTS, EXAMPLE_RECIPE, _example_name, example_truth

    names = [tmp_path / _example_name(k) for k in range(len(EXAMPLE_POINTS))]
    truth = example_truth(names)
    assert truth["beta"] == EXAMPLE_RECIPE["beta"] and truth["n"] == EXAMPLE_RECIPE["n"]
    assert example_truth(names[:1]) is None and example_truth([tmp_path / "op1.h5", tmp_path / "op2.h5"]) is None


def _interval_line(out: str, name: str) -> tuple[float, float, float, float]:
    """(estimate, low, high, truth) of ``name``'s line of ``impactid estimate --example``'s summary."""
    line = next(line for line in out.splitlines() if line.strip().startswith(f"{name} "))
    match = re.search(r"= (\S+) .*95 % interval \[(\S+), (\S+)\]\s+example made with (\S+)", line)
    assert match, line
    return tuple(float(v) for v in match.groups())


@pytest.mark.slow
def test_estimate_example_prints_the_truth_inside_its_intervals(capsys):
    """``impactid estimate --example`` (README line 1): the recipe's law beside each estimate, inside the 95 %
    intervals, beta's interval within a factor 1.2 (n determined to about +-0.005), no warning but the
    restitution law's, which the summary says to expect."""
    from impactid.rigs.pivoted.example import EXAMPLE_RECIPE
    assert main(["estimate", "--example"]) == 0
    out = capsys.readouterr().out
    for name in ("beta", "n", "c_ref"):
        value, low, high, truth = _interval_line(out, name)
        assert low <= value <= high and low <= truth <= high, (name, out)
    _, beta_low, beta_high, _ = _interval_line(out, "beta")
    assert beta_high <= 1.2 * beta_low, out
    assert _interval_line(out, "beta")[3] == EXAMPLE_RECIPE["beta"]
    assert _interval_line(out, "n")[3] == EXAMPLE_RECIPE["n"]
    assert "95 % confidence intervals" in out and "second model of the same impacts" in out
    warned = [line for line in out.splitlines() if line.strip().startswith("warning:")]
    assert all("'xi about" in line for line in warned), warned
    assert not warned or "expected to find structure" in out


def _tables_as_records(data: dict) -> dict:
    """The document with each table of ``tables`` as a list of records, so that the golden file's
    tolerance rules name a table's columns (``tables.per_impact[*].residual``)."""
    tables = {name: [dict(zip(t["columns"], row, strict=True)) for row in t["data"]]
              for name, t in data["tables"].items()}
    return {**data, "tables": tables}


@pytest.mark.slow
def test_estimate_example_fixed_n_writes_the_format_keys(tmp_path, capsys):
    from impactid.results import FitResult
    from impactid.rigs.pivoted.estimate_results import PivotedEstimateResult
    from impactid.rigs.pivoted.example import EXAMPLE_RECIPE

    out = tmp_path / "result.json"
    assert main(["estimate", "--example", "--fix-n", "1.5", "--out", str(out), "--plots", str(tmp_path / "fig")]) == 0
    data = json.loads(out.read_text())
    # one FitResult document (docs/formats.md, "Fit results"), plus the command's recordings_read and plots
    assert data["kind"] == "pivoted-estimate" and len(data["recordings_read"]) == 2 and len(data["plots"]) == 4
    params, stats = data["params"], data["statistics"]
    assert set(params) == {"beta", "n", "gamma", "r_constant", "intercept", "slope"}
    assert params["n"]["value"] == 1.5 and params["n"]["fixed"] and stats["residual"] == "lambda1"
    assert stats["impacts_used"] >= 10
    # the example was made with beta = 24.7e9: the interval must hold it (the estimate lies inside by construction)
    assert params["beta"]["interval"][0] <= 24.7e9 <= params["beta"]["interval"][1]
    assert params["beta"]["min"] < params["beta"]["value"] < params["beta"]["max"]
    # the law the example was made with, from its recipe, beside the estimate (not read from the files)
    truth = data["details"]["truth"]
    assert truth["beta"] == EXAMPLE_RECIPE["beta"] and truth["n"] == 1.5 and "recipe" in truth["source"]
    c_lo, c_hi = data["details"]["contact_damping"]["c_ref_interval"]
    assert c_lo <= data["details"]["contact_damping"]["c_ref"] <= c_hi and c_lo <= truth["c_ref"] <= c_hi
    again = FitResult.from_json(out)
    assert type(again) is PivotedEstimateResult and again.to_dict() == {k: v for k, v in data.items()
                                                                         if k not in ("recordings_read", "plots")}
    assert_matches_golden(_tables_as_records(data), "estimate_example_fix_n.json")
    assert {p.name for p in (tmp_path / "fig").iterdir()} == {"hysteresis.png", "restitution.png", "landscape.png",
                                                             "residuals.png"}
    assert "beta" in capsys.readouterr().out


def test_estimate_bad_input_exits_2(tmp_path, capsys):
    assert main(["estimate"]) == 2
    assert "give one or more recordings" in capsys.readouterr().err
    assert main(["estimate", str(tmp_path / "missing.h5")]) == 2
    assert "missing.h5" in capsys.readouterr().err


def test_estimate_is_the_applications_and_refuses_another_rigs_options(s2_file, tmp_path, capsys):
    """``impactid estimate`` takes the union of the rigs' estimate options; the recordings' rig model
    picks the estimate, and an option of another rig's estimate is refused before any fit."""
    from impactid.rigs.registry import MODELS

    assert all(c.name != "estimate" for model in MODELS.values() for c in model.command_specs())
    out = tmp_path / "r.json"
    assert main(["estimate", str(s2_file), "--speeds", "measured", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("impactid: error: argument --speeds: not an option of 'estimate' for the "
                          "'pivoted-follower' rig") and "'drop-impact'" in err and err.count("\n") == 1
    assert not out.exists()


def test_estimate_refuses_to_overwrite_its_input(s2_file, capsys):
    before = s2_file.read_bytes()
    assert main(["estimate", str(s2_file), "--fix-n", "1.5", "--out", str(s2_file)]) == 2
    assert "refusing to overwrite" in capsys.readouterr().err
    assert s2_file.read_bytes() == before


def test_info_reads_a_rig_file_with_a_byte_order_mark_and_a_csv_with_trailing_commas(tmp_path, capsys):
    """Harmless variants editors and spreadsheets write are read (docs/formats.md), not refused."""
    import numpy as np

    from impactid.io import Recording, write_csv

    rig = SUNDAR2016.with_eccentricity_ratio(0.2)
    n, rate = 3000, 204_800.0
    rec = Recording(channels={"force_x": np.linspace(0.0, 1.0, n), "cam_angle": np.arange(n) * 2 * np.pi * 16 / rate},
                    sample_rate_hz=rate, units={"force_x": "N", "cam_angle": "rad"}, rig=rig,
                    operating={"cam_speed_hz": 16.0, "eccentricity_m": rig.e})
    csv, toml = write_csv(rec, tmp_path / "r.csv")
    toml.write_bytes(b"\xef\xbb\xbf" + toml.read_bytes())
    csv.write_bytes(b"".join(line + b",\n" for line in csv.read_bytes().splitlines()))
    assert main(["info", str(csv), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert set(data["channels"]) == {"force_x", "cam_angle"} and data["n_samples"] == n
    assert data["operating"]["cam_speed_hz"] == 16.0


def test_estimate_refuses_one_recording_given_twice_before_reading_it(tmp_path, capsys):
    twin = tmp_path / "twin.h5"
    twin.write_bytes(b"not even a recording")
    (tmp_path / "copy").mkdir()
    copy = tmp_path / "copy" / "twin.h5"
    copy.write_bytes(twin.read_bytes())
    assert main(["estimate", str(twin), str(copy), "--fix-n", "1.5"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("impactid: error:") and "identical contents" in err and "would count twice" in err

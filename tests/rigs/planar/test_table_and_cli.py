"""The table readers (the predict path reads no outcome), the commands and their one-line errors."""

import json

import numpy as np
import pandas as pd
import pytest

from impactid.cli import main
from impactid.rigs import registry
from impactid.rigs.planar import MCUBE_ELLIPSE, PlanarBody, PlanarTableError, read_impacts, read_pre_impact
from tests.cli_contract import fails_with_one_line
from tests.rigs.planar.reference_planar import write_table


def test_registry_entry_and_rig_file(tmp_path):
    model = registry.rig_model("planar-impact")
    assert model.parameters is PlanarBody and model.default == MCUBE_ELLIPSE
    path = tmp_path / "body.toml"
    path.write_text(MCUBE_ELLIPSE.to_toml())
    rig, _ = registry.load_rig_toml(path)
    assert rig == MCUBE_ELLIPSE


def test_the_prediction_path_reads_no_outcome(tmp_path, synthetic):
    v, jt, jn, p, v_post = synthetic
    clean = write_table(tmp_path / "clean.csv", v, jt, jn)
    n = len(v)
    junk = {name: ["not a number"] * n for name in ("x_post", "vx_post", "vy_post", "omega_post", "impulse_t",
                                                      "impulse_n", "ap_newton_impulse_t", "ap_newton_impulse_n")}
    poisoned = write_table(tmp_path / "poisoned.csv", v, jt, jn, extra=junk)
    a, b = read_pre_impact(clean), read_pre_impact(poisoned)
    assert b.v_post is None and b.impulse is None
    np.testing.assert_array_equal(a.v_pre, b.v_pre)
    np.testing.assert_array_equal(a.jn, b.jn)
    with pytest.raises(PlanarTableError, match="'impulse_t' has 120 value"):  # the reader that may read them does
        read_impacts(poisoned)


def test_predict_command_ignores_the_outcome_columns(tmp_path, table, capsys):
    fit = tmp_path / "fit.json"
    assert main(["planar", "fit", str(table), "--body", "mcube-ellipse", "--law", "newton-linear-et",
                 "--out", str(fit)]) == 0
    frame = pd.read_csv(table)
    for column in ("vx_post", "vy_post", "omega_post", "impulse_t", "impulse_n"):
        frame[column] = -frame[column] * 3.0  # a wrong outcome: the prediction must not change
    frame["ap_newton_impulse_t"] = 1.0
    altered = tmp_path / "altered.csv"
    frame.to_csv(altered, index=False)
    out_a, out_b = tmp_path / "a.csv", tmp_path / "b.csv"
    assert main(["planar", "predict", str(table), "--law", str(fit), "--out", str(out_a)]) == 0
    assert main(["planar", "predict", str(altered), "--law", str(fit), "--out", str(out_b)]) == 0
    a, b = pd.read_csv(out_a), pd.read_csv(out_b)
    predicted = [c for c in a.columns if c.startswith("predicted_")]
    pd.testing.assert_frame_equal(a[predicted], b[predicted])
    assert a["relative_impulse_error"].median() < 1e-5  # scored against the table's own (true) outcome
    assert b["relative_impulse_error"].median() > 1.0  # scored against the altered one, read separately
    capsys.readouterr()
    assert main(["planar", "predict", str(table), "--law", str(fit), "--out", str(out_a), "--no-score",
                 "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert "median_relative_impulse_error" not in summary and "relative_impulse_error" not in pd.read_csv(out_a)


def test_fit_command_writes_a_result(tmp_path, table, capsys):
    out = tmp_path / "fit.json"
    assert main(["planar", "fit", str(table), "--mass", "0.0364", "--radius-of-gyration", "0.0192",
                 "--law", "newton-constant-stick", "--out", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["kind"] == "planar-impact-law-fit" and set(data["params"]) == {"e", "mu"}
    assert data["model_check"]["verdict"] and data["identifiability"]["profiles"]


@pytest.mark.parametrize("drop,needle", [("jn_theta", "'jn_theta'"), ("vy_pre", "'vy_pre'")])
def test_missing_columns_are_named(tmp_path, table, capsys, drop, needle):
    bad = tmp_path / "bad.csv"
    pd.read_csv(table).drop(columns=[drop]).to_csv(bad, index=False)
    fails_with_one_line(capsys, ["planar", "fit", str(bad), "--body", "mcube-ellipse"], str(bad), needle)
    fails_with_one_line(capsys, ["planar", "predict", str(bad), "--law", str(bad), "--out", str(tmp_path / "p.csv")],
                        "--law")
    assert not (tmp_path / "p.csv").exists()


def test_hostile_inputs(tmp_path, table, capsys):
    fit = tmp_path / "fit.json"
    out = tmp_path / "pred.csv"
    fails_with_one_line(capsys, ["planar", "fit", str(table)], "--body")
    fails_with_one_line(capsys, ["planar", "fit", str(tmp_path / "none.csv"), "--body", "mcube-ellipse"], "none.csv")
    fails_with_one_line(capsys, ["planar", "fit", str(table), "--mass", "0.03"], "--radius-of-gyration")
    fails_with_one_line(capsys, ["planar", "fit", str(table), "--body", "mcube-ellipse", "--mass", "1"], "--body")
    fails_with_one_line(capsys, ["planar", "fit", str(table), "--body", "mcube-ellipse", "--out", str(table)],
                        "--out")
    nan = tmp_path / "nan.csv"
    frame = pd.read_csv(table)
    frame.loc[3, "omega_pre"] = np.nan
    frame.to_csv(nan, index=False)
    fails_with_one_line(capsys, ["planar", "fit", str(nan), "--body", "mcube-ellipse"], "'omega_pre'", "row 4")
    no_outcome = tmp_path / "pre.csv"
    frame = pd.read_csv(table).drop(columns=["impulse_t", "impulse_n", "vx_post", "vy_post", "omega_post"])
    frame.to_csv(no_outcome, index=False)
    fails_with_one_line(capsys, ["planar", "fit", str(no_outcome), "--body", "mcube-ellipse"], "'impulse_t'")
    other = tmp_path / "other.json"
    other.write_text(json.dumps({"kind": "fit", "params": {}}))
    fails_with_one_line(capsys, ["planar", "predict", str(table), "--law", str(other), "--out", str(out)],
                        "not a planar impact law fit")
    fails_with_one_line(capsys, ["planar", "fit", str(table), "--confidence", "1.5", "--body", "mcube-ellipse"],
                        "--confidence")
    assert main(["planar", "fit", str(table), "--body", "mcube-ellipse", "--law", "newton-constant-stick",
                 "--out", str(fit)]) == 0
    fails_with_one_line(capsys, ["planar", "predict", str(table), "--law", str(fit), "--out", str(table)], "--out")
    assert not out.exists()
    assert main(["planar", "predict", str(no_outcome), "--law", str(fit), "--out", str(out)]) == 0  # nothing to score
    assert "relative_impulse_error" not in pd.read_csv(out).columns

"""Every fit command writes one JSON schema: the :class:`impactid.results.FitResult` document
(docs/formats.md, "Fit results") at the top level, plus the command's own keys (``recordings_read``,
``plots``), and the document rebuilds its result through ``FitResult.from_dict``. Every document holds
the model check and the identifiability blocks (docs/identifiability.md) with their keys.

The commands run on small synthetic inputs (those of the rigs' command tests); the expensive ones
(rig P's example estimate, the cycloidal train's surge fit) are marked ``slow``.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from impactid.cli import main
from impactid.results import FitResult, result_kinds

#: The keys of a FitResult document, and of each of its parameters.
RESULT_KEYS = {"kind", "impactid_version", "params", "statistics", "notes", "tables", "details", "provenance",
               "model_check", "identifiability"}
#: The keys of the ``model_check`` block, of each of its checks, and of an ``identifiability`` block.
MODEL_CHECK_KEYS = {"verdict", "describes_data", "action", "inflation", "checks", "rule"}
CHECK_KEYS = {"what", "unit", "noise_reference", "n", "n_params", "dof", "residual_rms", "noise_sd",
              "residual_over_noise", "chi_square", "chi_square_p_value", "covariate", "trend", "between_groups",
              "lag1_autocorrelation", "lag1_z", "runs", "runs_expected", "runs_z", "effective_samples",
              "structure_floor", "assumed_sd", "assumed_over_noise", "findings", "verdict", "describes_data",
              "inflation", "action", "notes"}
IDENTIFIABILITY_KEYS = {"condition_number", "condition_limit", "names", "correlation", "largest_correlation",
                        "near_bounds", "profiles", "profile_threshold", "profile_method", "profile_evaluations",
                        "model_comparison", "determined", "notes"}
VERDICTS = {"consistent", "not checked", "systematic misfit", "structured", "lack of fit", "rejected"}
PARAMETER_KEYS = {"name", "value", "stderr", "interval", "confidence", "fixed", "vary", "unit", "note", "min", "max"}
#: What a command may add beside the result: the files it read, the figures it wrote, and the
#: ``warnings`` line of numbers written as null.
COMMAND_KEYS = {"recordings_read", "plots", "warnings"}


def _number_or_null(value) -> bool:
    return value is None or (isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value))


def check_model_check(block: dict) -> None:
    """Assert that ``block`` is a ``model_check`` block with its checks."""
    assert MODEL_CHECK_KEYS <= set(block), f"model_check misses {MODEL_CHECK_KEYS - set(block)}"
    assert block["verdict"] in VERDICTS and block["action"] in ("none", "widened", "withheld")
    assert block["checks"] and isinstance(block["rule"], str) and block["rule"]
    for check in block["checks"]:
        assert CHECK_KEYS <= set(check), f"a check misses {CHECK_KEYS - set(check)}"
        assert check["verdict"] in VERDICTS and isinstance(check["noise_reference"], str) and check["noise_reference"]
    if block["action"] != "none":
        assert block["verdict"] not in ("consistent", "not checked")


def check_identifiability(block: dict) -> None:
    """Assert that ``block`` is an ``identifiability`` block (or one of parts, each one)."""
    if "parts" in block and "condition_number" not in block:
        assert block["parts"] and isinstance(block["determined"], bool)
        for part in block["parts"].values():
            check_identifiability(part)
        return
    assert IDENTIFIABILITY_KEYS <= set(block), f"identifiability misses {IDENTIFIABILITY_KEYS - set(block)}"
    assert isinstance(block["determined"], bool) and len(block["correlation"]) in (0, len(block["names"]))
    for name, profile in block["profiles"].items():
        assert profile["shape"] in ("bounded", "one-sided", "flat") and profile["method"], name
    for part in block.get("parts", {}).values():
        check_identifiability(part)


def check_fit_document(data: dict, kind: str, recordings_read: list[str]) -> FitResult:
    """Assert that ``data`` is a FitResult document of ``kind`` with the command's keys; return the
    result it rebuilds."""
    assert RESULT_KEYS <= set(data), f"missing: {RESULT_KEYS - set(data)}"
    assert set(data) - RESULT_KEYS <= COMMAND_KEYS, f"unknown top-level keys: {set(data) - RESULT_KEYS - COMMAND_KEYS}"
    assert data["kind"] == kind and kind in result_kinds()
    assert data["recordings_read"] == [str(p) for p in recordings_read]
    assert isinstance(data["impactid_version"], str) and data["impactid_version"]
    assert isinstance(data["params"], dict) and data["params"]
    for name, p in data["params"].items():
        assert set(p) == PARAMETER_KEYS and p["name"] == name, name
        assert all(_number_or_null(p[k]) for k in ("value", "stderr", "min", "max")), p
        assert len(p["interval"]) == 2 and all(_number_or_null(v) for v in p["interval"]), p
        assert isinstance(p["fixed"], bool) and p["vary"] is (not p["fixed"])
        assert isinstance(p["unit"], str) and isinstance(p["note"], str) and 0 < p["confidence"] < 1
        if p["min"] is not None and p["max"] is not None:
            assert p["min"] <= p["max"]
    assert isinstance(data["statistics"], dict)
    assert isinstance(data["notes"], list) and all(isinstance(n, str) for n in data["notes"])
    assert isinstance(data["provenance"], list) and all(isinstance(n, str) for n in data["provenance"])
    assert isinstance(data["details"], dict)
    check_model_check(data["model_check"])
    check_identifiability(data["identifiability"])
    if kind == "bounce-analysis":
        # the analysis of several laws: the selected law's blocks at the top, and each law's fit its own
        assert data["model_check"]["law"] == data["identifiability"]["law"] == data["details"]["selected"]
        for group in ("laws", "chained"):
            for fit in (data["details"].get(group) or {}).values():
                check_model_check(fit["model_check"])
                check_identifiability(fit["identifiability"])
    # a model the check finds wanting is never "determined" nor "separable" (rig P: its contact damping's part)
    parts = data["model_check"].get("parts", {})
    wanting = (parts["contact_damping"]["verdict"] if "contact_damping" in parts
               else data["model_check"].get("verdict")) not in (None, "consistent", "not checked")
    if wanting:
        assert data["identifiability"]["determined"] is False
        assert data["statistics"].get("separable") is not True
    for name, table in data["tables"].items():
        assert set(table) == {"columns", "data"}, name
        assert all(len(row) == len(table["columns"]) for row in table["data"]), name
    # the document is plain JSON (no NaN) and rebuilds its result, which writes the same document
    text = json.dumps(data, allow_nan=False)
    back = FitResult.from_json(text)
    assert back.kind == kind and type(back) is result_kinds()[kind]
    assert json.loads(back.to_json()) == {k: v for k, v in data.items() if k in RESULT_KEYS}
    return back


def _run(argv, capsys, code: int = 0) -> dict:
    got = main([str(a) for a in argv])
    out = capsys.readouterr()
    assert got == code, out.err
    return json.loads(out.out)


# ---- the drop rig ---------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def drop_files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("drops")
    paths = [folder / "low.h5", folder / "high.h5"]
    for path, height in zip(paths, ("0.05", "0.2")):
        assert main(["synth", "--rig", "drop-impact", "--height", height, "--duration", "0.5", "--out",
                     str(path)]) == 0
    return paths


def test_drop_fit(drop_files, tmp_path, capsys):
    out, plots = tmp_path / "fit.json", tmp_path / "plots"
    data = _run(["drop", "fit", *drop_files, "--json", "--out", out, "--plots", plots], capsys)
    back = check_fit_document(data, "drop-impact-fit", drop_files)
    assert json.loads(out.read_text()) == data and data["plots"] == [str(plots / "drop_fit.png")]
    assert set(back.params) >= {"k", "beta", "n"}


def test_estimate_of_the_drop_rig(drop_files, capsys):
    data = _run(["estimate", *drop_files, "--json"], capsys)
    check_fit_document(data, "drop-impact-fit", drop_files)


# ---- the bouncing ball ------------------------------------------------------------------------------


def test_bounces(tmp_path, capsys):
    from impactid.rigs.ball import TABLE_TENNIS
    from impactid.rigs.ball.synth import synth_drop, write_phyphox_csv

    files = [write_phyphox_csv(tmp_path / f"drop{j}.csv",
                               synth_drop("linear", {"e0": 0.96, "gamma": 0.02}, seed=10 + j, ball=TABLE_TENNIS,
                                          height=h, min_flight=0.1).times)
             for j, h in enumerate((0.12, 0.24, 0.3))]
    out = tmp_path / "r.json"
    data = _run(["bounces", *files, "--ball", "pingpong", "--no-chained", "--json", "--out", out], capsys)
    back = check_fit_document(data, "bounce-analysis", files)
    assert json.loads(out.read_text()) == data
    assert "linear.gamma" in back.params and back.details["drag"] is True


# ---- the finger-follower valve train ----------------------------------------------------------------

FF = ("--rig", "finger-follower-hla")


@pytest.fixture(scope="module")
def ff900(tmp_path_factory):
    from impactid.io import write_hdf5
    from impactid.rigs.finger_follower.parameters import KIM1990
    from impactid.rigs.finger_follower.synth import synth_recording

    path = tmp_path_factory.mktemp("ff") / "ff900.h5"
    write_hdf5(synth_recording(KIM1990, 900.0, revolutions=3, seed=2).recording, path)
    return path


def test_fit_tappet_one_recording(ff900, tmp_path, capsys):
    out, plots = tmp_path / "fit.json", tmp_path / "plots"
    data = _run(["valvetrain", "fit-tappet", *FF, ff900, "--json", "--out", out, "--plots", plots], capsys)
    back = check_fit_document(data, "finger_follower_tappet", [ff900])
    assert json.loads(out.read_text()) == data and data["plots"] == [str(plots / "tappet_fit_0.png")]
    assert {"alpha", "beta", "c_t", "k_t"} <= set(back.params)


def test_fit_tappet_one_fit_per_recording(ff900, tmp_path, capsys):
    """Several recordings without --joint: one TappetFitSet; a recording that cannot be fitted is in
    its details (exit status 1), the others' fits are its parameters (``fit0.alpha``, ...)."""
    from impactid.io import Recording, read_recording, write_hdf5

    rec = read_recording(ff900)
    dead = tmp_path / "dead.h5"
    channels = dict(rec.channels, tappet_displacement=np.zeros(rec.n_samples))
    write_hdf5(Recording(channels=channels, sample_rate_hz=rec.sample_rate_hz, units=rec.units, rig=rec.rig,
                         operating=dict(rec.operating)), dead)
    data = _run(["valvetrain", "fit-tappet", *FF, ff900, dead, "--json"], capsys, code=1)
    back = check_fit_document(data, "finger_follower_tappet_set", [ff900, dead])
    assert "fit0.alpha" in back.params and back.details["failed"][0]["recording"] == str(dead)
    (single,) = back.fits
    assert single.kind == "finger_follower_tappet" and single["alpha"].value == back["fit0.alpha"].value


def test_fit_lift(tmp_path, capsys):
    low = tmp_path / "ff600.csv"
    assert main(["valvetrain", "synth", *FF, "--rpm", "600", "--revolutions", "2", "--noise-free",
                 "--out", str(low)]) == 0
    capsys.readouterr()
    data = _run(["valvetrain", "fit-lift", *FF, low, "--json"], capsys)
    back = check_fit_document(data, "finger_follower_lift", [low])
    assert back["S_K"].value == pytest.approx(6e-3, rel=1e-3)


def test_fit_damping(tmp_path, capsys):
    from impactid.io import write_hdf5
    from impactid.rigs.finger_follower.parameters import KIM1990
    from impactid.rigs.finger_follower.synth import Sensors, synth_recording

    path = tmp_path / "ff2450.h5"
    write_hdf5(synth_recording(KIM1990, 2450.0, revolutions=1, sensors=Sensors.ideal()).recording, path)
    data = _run(["valvetrain", "fit-damping", *FF, path, "--json"], capsys)
    back = check_fit_document(data, "finger_follower_damping", [path])
    assert back["zeta_contact"].value == pytest.approx(0.06, rel=1e-3)


# ---- the cycloidal-cam valve train --------------------------------------------------------------------


@pytest.mark.slow
def test_fit_surge(tmp_path, capsys):
    rec = tmp_path / "rec.h5"
    rig = ("--rig", "cycloidal-flat-follower-ehl")
    assert main(["valvetrain", "synth", *rig, "--rpm", "3000", "--revolutions", "3", "--sample-rate", "20000",
                 "--noise-load", "2", "--seed", "5", "--out", str(rec)]) == 0
    capsys.readouterr()
    out, plots = tmp_path / "fit.json", tmp_path / "plots"
    data = _run(["valvetrain", "fit-surge", *rig, rec, "--json", "--out", out, "--plots", plots], capsys)
    check_fit_document(data, "valvetrain-surge-fit", [rec])
    assert json.loads(out.read_text()) == data and data["plots"] == [str(plots / "surge_fit.png")]


# ---- rig P --------------------------------------------------------------------------------------------


@pytest.mark.slow
def test_estimate_of_rig_p(tmp_path, capsys):
    from impactid.rigs.pivoted.example import example_recording_paths

    data = _run(["estimate", "--example", "--fix-n", "1.5", "--json"], capsys)
    back = check_fit_document(data, "pivoted-estimate", example_recording_paths())
    assert set(back.params) == {"beta", "n", "gamma", "r_constant", "intercept", "slope"}
    assert back["n"].fixed and back["beta"].min < back["beta"].value < back["beta"].max
    assert set(back.tables) == {"per_impact", "valley", "recordings", "calibration"}


@pytest.mark.slow
def test_rig_p_estimate_without_a_restitution_law():
    """When the restitution law cannot be fitted its parameters are undetermined (null), with the reason."""
    import warnings
    from dataclasses import replace

    from impactid.pipeline import Pipeline
    from impactid.rigs.pivoted.example import example_recording_paths

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        est = Pipeline(fix_n=1.5, calibrate=False).run([example_recording_paths()[0]])
    est = replace(est, restitution=None, warnings=est.warnings + ("restitution law not estimated: test",))
    data = est.to_result().to_dict()
    assert data["params"]["gamma"]["value"] is None and "test" in data["params"]["gamma"]["note"]
    assert data["statistics"]["xi_mean"] is None and data["details"]["restitution"] is None
    assert FitResult.from_dict(data).to_dict() == data
    assert est.to_dict(per_impact=False)["tables"].keys() == {"valley", "recordings", "calibration"}

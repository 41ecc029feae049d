"""The generic estimate on the drop rig: ``Pipeline().run``, ``impactid estimate DROP1.h5 DROP2.h5`` and a
campaign dispatch on the recordings' ``/rig`` model to the drop rig's estimator
(``impactid.rigs.drop.estimation``) and identify ``k``, ``beta``, ``n``. The drops are made by the
independent ``solve_ivp`` reference (``tests/rigs/drop/reference_drop.py``), from two heights."""

from __future__ import annotations

import json
import shutil
import warnings

import numpy as np
import pytest

from impactid.campaign import CampaignError, load_campaign, run_campaign
from impactid.cli import main
from impactid.io import Recording, RecordingError, read_recording, write_hdf5
from impactid.pipeline import Pipeline, estimate
from impactid.results import FitResult
from impactid.rigs.base import OptionError
from impactid.rigs.drop.estimation import DropEstimateWarning
from impactid.rigs.drop.identify import DropFit

NAMES = ("k", "beta", "n")


def _truth(rig, law) -> dict[str, float]:
    return {"k": rig.k, "beta": law.beta, "n": law.n}


def _write(drops, folder) -> list[str]:
    return [str(write_hdf5(rec, folder / f"drop{k + 1}.h5")) for k, (rec, _) in enumerate(drops)]


@pytest.fixture(scope="module")
def drop_files(reference_drops, tmp_path_factory) -> list[str]:
    """The two noise-free reference drops as HDF5 files."""
    return _write(reference_drops, tmp_path_factory.mktemp("drops"))


@pytest.fixture(scope="module")
def rig_p_file(tmp_path_factory) -> str:
    """A short recording of rig P (a file of another rig model; never measured here)."""
    from impactid.rigs.pivoted import SUNDAR2016

    n, rate = 102_400, 204_800.0
    t = np.arange(n) / rate
    rec = Recording(channels={"accel_tangential": np.sin(2 * np.pi * 50.0 * t), "cam_angle": 2 * np.pi * 16.0 * t},
                    sample_rate_hz=rate, units={"accel_tangential": "m/s^2", "cam_angle": "rad"},
                    rig=SUNDAR2016.with_eccentricity_ratio(0.2),
                    operating={"cam_speed_hz": 16.0, "eccentricity_m": SUNDAR2016.with_eccentricity_ratio(0.2).e})
    return str(write_hdf5(rec, tmp_path_factory.mktemp("rig_p") / "rigp.h5"))


def test_noise_free_drops_are_identified_within_one_percent(reference_drops, rig, law):
    recordings = [rec for rec, _ in reference_drops]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fit = Pipeline().run(recordings)
    assert isinstance(fit, DropFit)
    truth = _truth(rig, law)
    errors = {name: fit.value(name) / truth[name] - 1.0 for name in NAMES}
    assert all(abs(e) < 0.01 for e in errors.values()), errors  # the requirement
    assert all(abs(e) < 1e-6 for e in errors.values()), errors  # what the fit achieves (fit_drop's own tests)
    assert fit.statistics["n_recordings"] == 2 and fit.statistics["n_impacts"] >= 5
    # the options are recorded; the notes are issued once each, in the rig's category
    assert fit.provenance[-1].startswith("impactid ") and '"speeds": "fit"' in fit.provenance[-1]
    issued = [str(w.message) for w in caught if issubclass(w.category, DropEstimateWarning)]
    assert issued == list(dict.fromkeys(fit.notes))
    # the thin call gives the same numbers, and a fixed index is an option of the drop rig's estimate too
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DropEstimateWarning)
        again = estimate(recordings, fix_n=1.5)
    assert again["n"].fixed and abs(again.value("k") / rig.k - 1.0) < 0.01


def test_noisy_drops_intervals_cover_the_truth(noisy_reference_drops, rig, law):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DropEstimateWarning)
        fit = Pipeline().run([rec for rec, _ in noisy_reference_drops])
    truth = _truth(rig, law)
    for name in NAMES:
        assert fit[name].contains(truth[name]), (name, fit[name])
    assert fit["k"].stderr / fit.value("k") < 0.005 and fit["n"].stderr < 0.05


def test_prepare_then_fit_is_run(reference_drops):
    pipeline = Pipeline(model="drop-impact", max_impacts=3)
    assert pipeline.speeds == "fit" and pipeline.max_impacts == 3 and pipeline.to_dict()["n_starts"] == [1.0, 1.5, 2.0]
    prepared = [pipeline.prepare(rec, keep_samples=False) for rec, _ in reference_drops]
    assert {p.model for p in prepared} == {"drop-impact"}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DropEstimateWarning)
        split = pipeline.fit(prepared)
        whole = pipeline.run([rec for rec, _ in reference_drops])
    assert split.values == whole.values


def test_the_command_writes_the_fit_result(drop_files, rig, law, tmp_path, capsys):
    out = tmp_path / "result.json"
    assert main(["estimate", *drop_files, "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert printed.startswith("impactid estimate: 2 drop recording(s)") and "[[Variables]]" in printed
    data = json.loads(out.read_text())
    assert data["kind"] == "drop-impact-fit" and set(NAMES) <= set(data["params"])
    assert {"params", "statistics", "notes", "tables", "details", "provenance"} <= set(data)
    assert data["recordings_read"] == drop_files
    back = FitResult.from_dict(data)
    truth = _truth(rig, law)
    assert all(abs(back.value(name) / truth[name] - 1.0) < 0.01 for name in NAMES)
    # --json prints the same document; --fix-n is the drop rig's option too
    assert main(["estimate", *drop_files, "--fix-n", "1.5", "--json", "--channels", "force"]) == 0
    fixed = json.loads(capsys.readouterr().out)
    assert fixed["params"]["n"]["fixed"] and fixed["statistics"]["channels"] == "contact_force"


def test_mixing_a_drop_and_a_rig_p_recording_is_refused(drop_files, rig_p_file, capsys):
    assert main(["estimate", drop_files[0], rig_p_file]) == 2
    lines = capsys.readouterr().err.splitlines()
    errors = [line for line in lines if line.startswith("impactid: error:")]
    assert all(line.startswith("impactid: ") for line in lines) and errors == lines[-1:]  # one line, the last
    assert "'drop-impact'" in errors[0] and "'pivoted-follower'" in errors[0]
    with pytest.raises(RecordingError, match="'pivoted-follower'.*'drop-impact'"):
        Pipeline().run([read_recording(rig_p_file), read_recording(drop_files[0])])


def test_options_of_another_rigs_estimate_are_refused(drop_files, capsys):
    with pytest.raises(OptionError, match="residual.*'drop-impact'"):
        Pipeline(residual="lambda2").run(drop_files)
    with pytest.raises(OptionError, match="different rigs"):
        Pipeline(residual="lambda2", speeds="measured")
    with pytest.raises(OptionError, match="speeds must be"):
        Pipeline(speeds="guessed")
    assert main(["estimate", drop_files[0], "--grid", "5"]) == 2
    err = capsys.readouterr().err
    assert "argument --grid: not an option of 'estimate' for the 'drop-impact' rig" in err and err.count("\n") == 1


def test_a_folder_of_drops_is_a_campaign_of_the_drop_rigs_estimate(drop_files, rig, law, tmp_path):
    folder = tmp_path / "drops"
    folder.mkdir()
    for path in drop_files:
        shutil.copy(path, folder)
    spec = load_campaign(folder)
    assert spec.model == "drop-impact" and {g: len(m) for g, m in spec.groups().items()} == {"all": 2}
    assert spec.single.fix_n == 1.5 and spec.joint.fix_n is None and spec.joint.speeds == "fit"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = run_campaign(spec, tmp_path / "out")
    table = result.table
    assert list(table["status"]) == ["ok", "ok", "ok"] and (result.ran, result.prepared) == (3, 2)
    joint = table[table["kind"] == "joint"].iloc[0]
    assert abs(joint["beta"] / law.beta - 1.0) < 0.01 and abs(joint["n"] - law.n) < 0.01
    assert joint["beta_lo"] <= joint["beta"] <= joint["beta_hi"] and not joint["n_fixed"]
    # a campaign file names the rig whose estimate it runs; its options are that rig's
    campaign = tmp_path / "c.toml"
    campaign.write_text('[campaign]\nmodel = "drop-impact"\n[options]\nspeeds = "measured"\n'
                        '[[recording]]\npath = "drops/drop1.h5"\n')
    assert load_campaign(campaign).joint.speeds == "measured"
    campaign.write_text('[campaign]\nmodel = "drop-impact"\n[options]\nresidual = "lambda2"\n'
                        '[[recording]]\npath = "drops/drop1.h5"\n')
    with pytest.raises(CampaignError, match=r"\[single\]: unknown option\(s\) residual of the 'drop-impact'"):
        load_campaign(campaign)

"""Campaigns (impactid.campaign, impactid campaign): the task graph, keys and reruns, failure rows,
atomic outputs, and the scheduler option of the sweeps.

Most tests run the campaign serially (no cluster); one test (slow) runs it on a real local cluster
of two worker processes and kills a worker in the middle of it.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import stat
import threading
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from impactid import SUNDAR2016, HuntCrossley, Pipeline
from impactid.campaign import CampaignError, load_campaign, read_fits, run_campaign, summary_table
from impactid.cli import main

LAW = HuntCrossley(beta=24.7e9, n=1.5)
#: period-1 operating points (e/r_c, cam speed [Hz]) whose impacts differ in approach speed
POINTS = {"a": (0.05, 16.0), "b": (0.25, 15.0)}
#: fast options of the test campaigns (the calibration is tested with the pipeline)
OPTIONS = '[options]\ncalibrate = false\n'


@pytest.fixture(scope="session")
def recordings(tmp_path_factory) -> dict[str, Path]:
    """Two 0.3 s recordings of rig P at two operating points (0.2 % noise) and a corrupt file."""
    from impactid.rigs.pivoted.synth import synth_pivoted
    from impactid.synth import SensorModel

    folder = tmp_path_factory.mktemp("campaign_recordings")
    paths = {}
    for k, (name, (ratio, hz)) in enumerate(POINTS.items()):
        synthetic = synth_pivoted(SUNDAR2016.with_eccentricity_ratio(ratio), hz, LAW, 0.3,
                                  sensors=SensorModel(noise=0.002, seed=k))
        paths[name] = synthetic.write(folder / f"{name}.h5")
    paths["bad"] = folder / "bad.h5"
    paths["bad"].write_bytes(b"\x89HDF\r\n\x1a\n" + b"not really an HDF5 file" * 10)
    return paths


def _campaign(folder: Path, recordings: dict[str, Path], *, names=("a", "b", "bad"), extra: str = "",
              group: tuple[str, ...] = ("a", "b")) -> Path:
    """A campaign file in ``folder`` over copies of ``recordings``."""
    folder.mkdir(parents=True, exist_ok=True)
    lines = ['[campaign]\nname = "test"\nout = "out"\n', OPTIONS, extra]
    for name in names:
        shutil.copy(recordings[name], folder / f"{name}.h5")
        lines.append(f'[[recording]]\npath = "{name}.h5"\n' + ('group = "g"\n' if name in group else ""))
    path = folder / "campaign.toml"
    path.write_text("\n".join(lines))
    return path


@pytest.fixture(scope="module")
def first_run(tmp_path_factory, recordings):
    """The test campaign (a, b alone and jointly; a corrupt file) run once, serially."""
    folder = tmp_path_factory.mktemp("campaign")
    spec = load_campaign(_campaign(folder, recordings))
    result = run_campaign(spec, spec.out)
    return spec, result


# ---- the campaign file -------------------------------------------------------------------------------


def test_campaign_file_is_read_with_paths_relative_to_it(tmp_path):
    (tmp_path / "data").mkdir()
    path = tmp_path / "data" / "c.toml"
    path.write_text('[campaign]\nname = "lab"\nout = "../res"\n[options]\nresidual = "lambda1"\nn_bounds = [0.8, 2.2]\n'
                    '[single]\nmethod = "optimise"\n[joint]\nfix_n = "free"\n'
                    '[[recording]]\npath = "r1.h5"\ngroup = "g"\ncam_speed_hz = 15.5\n'
                    '[[recording]]\npath = "sub/r2.csv"\nrig = "rig.toml"\ne_over_rc = 0.2\ngroup = "g"\n'
                    'name = "two"\n')
    spec = load_campaign(path)
    assert spec.name == "lab" and spec.out == tmp_path / "data" / "../res"
    a, b = spec.recordings
    assert (a.name, a.path, a.cam_speed_hz, a.group) == ("r1", tmp_path / "data" / "r1.h5", 15.5, "g")
    assert (b.name, b.rig, b.e_over_rc) == ("two", tmp_path / "data" / "rig.toml", 0.2)
    assert spec.single.fix_n == 1.5 and spec.single.method == "optimise" and spec.single.n_bounds == (0.8, 2.2)
    assert spec.joint.fix_n is None and spec.joint.method == "least-squares"
    assert list(spec.groups()) == ["g"]
    assert b.inputs() == [b.path, b.rig]  # a CSV with a rig file reads no sibling TOML


@pytest.mark.parametrize(("text", "message"), [
    ('[[recording]]\npath = "a.h5"\npaht = "x"\n', "recording 1: unknown key(s) paht"),
    ('[optoins]\n', "unknown table(s) optoins"),
    ('[options]\nfix_n = "hertz"\n[[recording]]\npath = "a.h5"\n', 'fix_n must be a number or "free"'),
    ('[options]\nmethod = "magic"\n[[recording]]\npath = "a.h5"\n', "[single]: method must be one of"),
    ('[options]\nbogus = 1\n[[recording]]\npath = "a.h5"\n', "unknown option(s) bogus"),
    ('[[recording]]\npath = "a.h5"\n[[recording]]\npath = "x/a.h5"\n', "a appear more than once"),
    ('[[recording]]\npath = "a.h5"\ngroup = "g"\n', "group 'g' has one recording (a)"),
    ('[[recording]]\npath = "a.h5"\ncam_speed_hz = -3\n', "cam_speed_hz must be a positive number"),
    ('[campaign]\nname = "x"\n', "no recording in the campaign"),
    ('[[recording]]\npath = \n', "not a valid TOML file"),
])
def test_bad_campaign_files_are_refused_naming_the_problem(tmp_path, text, message):
    path = tmp_path / "c.toml"
    path.write_text(text)
    with pytest.raises(CampaignError) as info:
        load_campaign(path)
    assert message in str(info.value) and str(path) in str(info.value)


def test_a_folder_is_a_campaign_of_its_recordings(tmp_path, recordings):
    for name in ("b", "a"):
        shutil.copy(recordings[name], tmp_path / f"{name}.h5")
    (tmp_path / "notes.txt").write_text("not a recording")
    (tmp_path / "sub").mkdir()
    spec = load_campaign(tmp_path)
    assert [r.name for r in spec.recordings] == ["a", "b"]
    assert {g: [r.name for r in m] for g, m in spec.groups().items()} == {"all": ["a", "b"]}
    assert spec.single.fix_n == 1.5 and spec.joint.fix_n is None
    with pytest.raises(CampaignError, match="no recording"):
        load_campaign(tmp_path / "sub")


# ---- running, rerunning, failures ---------------------------------------------------------------------


def test_every_fit_is_a_row_and_the_corrupt_file_a_failure(first_run):
    spec, result = first_run
    table = result.table
    assert list(zip(table["kind"], table["name"])) == [("single", "a"), ("single", "b"), ("single", "bad"),
                                                       ("joint", "g")]
    assert list(table["status"]) == ["ok", "ok", "failed", "ok"]
    assert (result.ran, result.skipped, result.failed, result.prepared, result.cached) == (3, 0, 1, 2, 0)
    assert result.ran + result.skipped + result.failed == result.fits == 4  # each fit counted once
    assert not result.ok and result.where == "serial"
    reason = table.loc[2, "reason"]
    assert "recording bad could not be prepared" in reason and "bad.h5" in reason and "\n" not in reason
    single = table[table["kind"] == "single"].iloc[:2]
    assert np.allclose(single["beta"], LAW.beta, rtol=0.05) and (single["n"] == 1.5).all()
    assert list(single["e_over_rc"]) == [0.05, 0.25] and list(single["cam_speed_hz"]) == [16.0, 15.0]
    joint = table.iloc[3]
    assert joint["recordings"] == "a;b" and joint["operating_points"] == "0.05/16;0.25/15" and not joint["n_fixed"]
    assert joint["n_lo"] < joint["n"] < joint["n_hi"]


def test_outputs_table_and_json_agree(first_run):
    spec, result = first_run
    out = spec.out
    parquet = pd.read_parquet(out / "campaign.parquet")
    csv = pd.read_csv(out / "campaign.csv", keep_default_na=False, na_values=[""])
    assert list(parquet.columns) == list(csv.columns) == list(result.table.columns)
    assert np.allclose(parquet["beta"], csv["beta"], equal_nan=True, rtol=1e-12)
    for _, row in parquet.iterrows():
        record = json.loads((out / row["json"]).read_text())
        assert record["key"] == row["key"] and record["status"] == row["status"]
        assert record["campaign"] == "test" and record["options"]["calibrate"] is False
        if row["status"] == "ok":
            assert record["result"]["params"]["beta"]["value"] == pytest.approx(row["beta"], rel=1e-15)
            assert record["result"]["kind"] == "pivoted-estimate"
            assert len(record["recordings"][0]["sha256"][0]) == 64
    # the table is rebuilt from the JSON files
    rebuilt = summary_table(read_fits(out, list(parquet["key"])))
    pd.testing.assert_frame_equal(rebuilt, result.table)


def test_a_fit_is_the_estimate_of_its_recording(first_run, recordings):
    spec, result = first_run
    record = json.loads((spec.out / result.table.loc[0, "json"]).read_text())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the estimate's notes (also in the campaign's result)
        direct = Pipeline(fix_n=1.5, calibrate=False).run([spec.recordings[0].path])
    assert record["result"]["params"]["beta"]["value"] == direct.damping.beta
    assert record["result"]["statistics"]["impacts_used"] == direct.to_dict()["statistics"]["impacts_used"]
    # the fit file's result is the estimate's FitResult document; the summary row reads it
    from impactid.results import FitResult

    again = FitResult.from_dict(record["result"])
    assert again["beta"].value == direct.damping.beta and again["n"].fixed
    row = result.table.loc[0]
    assert (row["beta_lo"], row["beta_hi"]) == tuple(record["result"]["params"]["beta"]["interval"])
    assert row["n_fixed"] and row["gamma"] == record["result"]["params"]["gamma"]["value"]
    assert row["gamma_stderr"] == record["result"]["params"]["gamma"]["stderr"]
    assert row["xi_mean"] == record["result"]["statistics"]["xi_mean"]
    assert row["impacts_used"] == record["result"]["statistics"]["impacts_used"] > 0
    assert row["method"] == "least-squares" and row["simulations"] == record["result"]["statistics"]["simulations"]
    assert row["warnings"] == len(record["result"]["notes"])
    table = record["result"]["tables"]["recordings"]
    assert row["e_over_rc"] == table["data"][0][table["columns"].index("e_over_rc")]


def test_rerun_skips_finished_fits_and_reruns_failed_ones(first_run):
    spec, first = first_run
    before = {p.name: p.stat().st_mtime_ns for p in (spec.out / "fits").glob("*.json")}
    lines: list[str] = []
    again = run_campaign(spec, spec.out, log=lines.append)
    assert (again.ran, again.skipped, again.failed, again.prepared, again.cached) == (0, 3, 1, 0, 0)
    assert lines[0].startswith("running 1 prepare and 1 fit tasks")  # the corrupt file's, again
    ok = first.table[first.table["status"] == "ok"]
    for key in ok["key"]:
        assert (spec.out / "fits" / f"{key}.json").stat().st_mtime_ns == before[f"{key}.json"]
    pd.testing.assert_frame_equal(again.table.drop(columns="seconds"), first.table.drop(columns="seconds"))


def test_a_missing_fit_is_made_from_the_cached_products(tmp_path, recordings):
    spec = load_campaign(_campaign(tmp_path, recordings, names=("a", "b")))
    first = run_campaign(spec, spec.out)
    joint_key = first.table.loc[first.table["kind"] == "joint", "key"].item()
    (spec.out / "fits" / f"{joint_key}.json").unlink()
    again = run_campaign(spec, spec.out)
    assert (again.ran, again.skipped, again.prepared, again.cached) == (1, 2, 0, 2)
    assert again.table.loc[2, "beta"] == first.table.loc[2, "beta"]
    # changed options run the fits they change; the per-recording fits are kept
    spec2 = load_campaign(_campaign(tmp_path, recordings, names=("a", "b"), extra="[joint]\nn_bounds = [0.6, 2.4]\n"))
    third = run_campaign(spec2, spec2.out)
    assert (third.ran, third.skipped, third.cached) == (1, 2, 2)
    # a file with the same content (new modification time) is the same input; another content is not
    os.utime(tmp_path / "a.h5", ns=(time.time_ns(), time.time_ns()))
    assert run_campaign(spec2, spec2.out).skipped == 3
    shutil.copy(recordings["b"], tmp_path / "a.h5")  # now a holds b's content: b's product serves it
    changed = run_campaign(spec2, spec2.out)
    assert (changed.ran, changed.skipped, changed.failed, changed.prepared, changed.cached) == (1, 1, 1, 0, 1)
    assert changed.table.loc[0, "beta"] == changed.table.loc[1, "beta"] != third.table.loc[0, "beta"]
    # ... and group g now holds one recording twice: refused, without a task
    assert "group 'g' names one recording twice" in changed.table.loc[2, "reason"]


def test_outputs_are_atomic_and_follow_the_umask(tmp_path, recordings, monkeypatch):
    spec = load_campaign(_campaign(tmp_path, recordings, names=("a", "bad"), group=()))
    old = os.umask(0o027)
    try:
        run_campaign(spec, spec.out)
    finally:
        os.umask(old)
    files = [p for p in spec.out.rglob("*") if p.is_file()]
    assert {p.suffix for p in files} == {".json", ".pkl", ".parquet", ".csv"}
    assert all(stat.S_IMODE(p.stat().st_mode) == 0o640 for p in files)
    table = (spec.out / "campaign.csv").read_bytes()

    def broken(self, path, **kwargs):
        Path(path).write_bytes(b"partial")
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(pd.DataFrame, "to_parquet", broken)
    with pytest.raises(Exception, match="No space left"):
        run_campaign(spec, spec.out)
    assert (spec.out / "campaign.csv").read_bytes() == table
    assert not [p for p in spec.out.rglob("*") if p.name.endswith(".tmp")]


# ---- the command ----------------------------------------------------------------------------------------


def test_command_runs_serially_without_the_campaign_extra(tmp_path, recordings, capsys, monkeypatch):
    """After `pip install impactid` (no dask, no pyarrow) a campaign runs serially, says so in one warning,
    and writes its summary as CSV (no Parquet copy); the same command with the extra runs on a cluster."""
    import impactid.campaign
    import impactid.distributed

    monkeypatch.setattr(impactid.distributed, "missing", lambda *modules: list(modules))
    monkeypatch.setattr(impactid.campaign, "parquet_available", lambda: False)
    path = _campaign(tmp_path, recordings, names=("a",), group=())
    assert main(["campaign", str(path), "--no-progress", "--out", str(tmp_path / "out")]) == 0
    captured = capsys.readouterr()
    assert "impactid: warning: dask is not installed: the campaign runs serially" in captured.err
    assert "serial" in captured.out and "campaign.csv" in captured.out and "parquet" not in captured.out
    assert (tmp_path / "out" / "campaign.csv").exists() and not (tmp_path / "out" / "campaign.parquet").exists()


def test_command_serial_reports_and_exits_1_with_a_failed_fit(tmp_path, recordings, capsys):
    path = _campaign(tmp_path, recordings, names=("a", "bad"), group=())
    assert main(["campaign", str(path), "--serial", "--no-progress"]) == 1
    out = capsys.readouterr().out
    assert "2 fits: 1 done, 0 skipped (finished earlier), 1 failed" in out
    assert "failed: single fit bad: recording bad could not be prepared" in out
    assert main(["campaign", str(path), "--workers", "0", "--json"]) == 1
    data = json.loads(capsys.readouterr().out)
    assert (data["ran"], data["skipped"], data["failed"]) == (0, 1, 1)
    # the corrupt file removed from the campaign: every fit succeeds, nothing runs again
    path.write_text(path.read_text().split("[[recording]]\npath = \"bad.h5\"")[0])
    assert main(["campaign", str(path), "--serial", "--out", str(tmp_path / "out")]) == 0
    assert "1 fits: 0 done, 1 skipped" in capsys.readouterr().out


@pytest.mark.parametrize(("argv", "message"), [
    (["campaign", "/nonexistent/c.toml", "--serial"], "/nonexistent/c.toml: campaign file or folder not found"),
    (["campaign", "{c}", "--serial", "--out", "{a}"], "is an input of this command"),
    (["campaign", "{c}", "--scheduler", "tcp://x:1", "--workers", "2"], "not allowed with argument"),
    (["campaign", "{c}", "--workers", "-1"], "argument --workers: must lie in [0, 4096]"),
    (["campaign", "{c}", "--serial", "--workers", "3"], "argument --serial: not allowed with"),
])
def test_command_errors_are_one_line_and_exit_2(tmp_path, recordings, argv, message, capsys):
    path = _campaign(tmp_path, recordings, names=("a",), group=())
    argv = [a.format(c=path, a=tmp_path / "a.h5") for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("impactid: error:") and message in err and err.count("\n") == 1


def test_command_without_an_output_folder_or_dask(tmp_path, recordings, capsys, monkeypatch):
    path = _campaign(tmp_path, recordings, names=("a",), group=())
    path.write_text(path.read_text().replace('out = "out"\n', ""))
    assert main(["campaign", str(path), "--serial"]) == 2
    assert "argument --out: no output folder" in capsys.readouterr().err
    import impactid.distributed as D

    monkeypatch.setattr(D, "missing", lambda *modules: ["distributed"])
    # a cluster asked for without dask: refused (the default runs serially instead, with a warning:
    # test_command_runs_serially_without_the_campaign_extra)
    assert main(["campaign", str(path), "--workers", "2", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "impactid campaign needs distributed" in err and "pip install 'impactid[campaign]'" in err
    assert not (tmp_path / "o").exists()


# ---- the sweeps' scheduler option --------------------------------------------------------------------------


def test_regime_map_and_bifurcation_give_the_same_results_on_a_client():
    distributed = pytest.importorskip("distributed")
    from impactid import ALZATE2007
    from impactid.rigs.flat.simulate import bifurcation
    from impactid.rigs.pivoted.regimes import regime_map

    serial = regime_map(SUNDAR2016, [0.2, 0.25], [5.0, 15.0, 16.0], max_revolutions=400)
    speeds = np.array([110.0, 130.0, 140.0, 150.0, 160.0]) / 60.0
    bif = bifurcation(ALZATE2007, speeds, 0.6, revolutions=40)
    # an in-process cluster (threads): the plumbing; the real processes are in the slow test below
    with distributed.Client(processes=False, n_workers=2, threads_per_worker=1, dashboard_address=None) as client:
        done = []
        on_client = regime_map(SUNDAR2016, [0.2, 0.25], [5.0, 15.0, 16.0], max_revolutions=400, client=client,
                               progress=lambda k, n: done.append((k, n)))
        bif_client = bifurcation(ALZATE2007, speeds, 0.6, revolutions=40, client=client)
    pd.testing.assert_frame_equal(serial, on_client)
    assert done[-1] == (6, 6) and [k for k, _ in done] == sorted(k for k, _ in done)
    pd.testing.assert_frame_equal(bif.table, bif_client.table)
    assert np.array_equal(bif.strobe_angle, bif_client.strobe_angle)


def test_regime_map_command_takes_the_scheduler_options(tmp_path, capsys, monkeypatch):
    import impactid.distributed as D

    monkeypatch.setattr(D, "CONNECT_TIMEOUT", "1s")
    out = tmp_path / "map"
    assert main(["regime-map", "--e-over-rc-values", "0.25", "--cam-speeds", "5", "--out", str(out), "--quiet",
                 "--workers", "0"]) == 0
    assert (out / "regime_map.csv").exists()
    assert main(["regime-map", "--out", str(out), "--scheduler", "tcp://127.0.0.1:1", "--quiet",
                 "--e-over-rc-values", "0.25", "--cam-speeds", "5"]) == 2
    assert "argument --scheduler: cannot connect to tcp://127.0.0.1:1" in capsys.readouterr().err


# ---- a real local cluster --------------------------------------------------------------------------------


@pytest.mark.slow
def test_campaign_on_a_local_cluster_survives_a_worker_death(tmp_path, recordings, first_run):
    """Two worker processes; the worker running the joint fit is killed (SIGKILL) once a fit has
    finished: the finished result stays on disk untouched, dask runs the lost tasks again, and the
    results equal the serial run's."""
    from impactid.distributed import connect

    spec = load_campaign(_campaign(tmp_path, recordings))
    killed: list[int] = []
    released = tmp_path / "joint-fit-may-finish"
    environ = {key: os.environ.get(key) for key in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS")}

    def hold_the_joint_fit(marker: str) -> None:
        """In each worker: the joint fit waits for ``marker`` (at most 120 s) before it runs, so
        that a worker is certainly busy with it when a single fit has finished. A worker started
        after the kill does not wait (it has not run this), nor does any once the marker exists."""
        import os as _os
        import time as _time

        import impactid.campaign as campaign_module

        original = campaign_module.fit_task

        def held(job, *prepared):
            if job.kind == "joint":
                deadline = _time.monotonic() + 120
                while not _os.path.exists(marker) and _time.monotonic() < deadline:
                    _time.sleep(0.05)
            return original(job, *prepared)

        campaign_module.fit_task = held  # the task is pickled by reference: workers resolve it here

    with connect(workers=2) as client:
        pids = client.run(os.getpid)
        client.run(hold_the_joint_fit, str(released))

        def kill_when_a_fit_is_done() -> None:
            try:
                deadline = time.monotonic() + 300
                while time.monotonic() < deadline and not killed:
                    fits = spec.out / "fits"
                    finished = [p for p in fits.glob("*.json")
                                if json.loads(p.read_text())["status"] == "ok"] if fits.exists() else []
                    busy = {w: keys for w, keys in client.processing().items()
                            if any("fit-joint" in k for k in keys)}
                    if finished and busy:
                        witness.append((finished[0], finished[0].read_bytes()))
                        worker = next(iter(busy))
                        killed.append(pids[worker])
                        os.kill(pids[worker], signal.SIGKILL)
                        return
                    time.sleep(0.1)
            finally:
                released.touch()

        witness: list[tuple[Path, bytes]] = []
        killer = threading.Thread(target=kill_when_a_fit_is_done, daemon=True)
        killer.start()
        result = run_campaign(spec, spec.out, client=client)
        killer.join(timeout=5)
        # the sweeps on the same (real, multi-process) cluster
        from impactid.rigs.pivoted.regimes import regime_map

        grid = dict(e_over_rc=[0.25], cam_speeds_hz=[5.0, 15.0], max_revolutions=300)
        pd.testing.assert_frame_equal(regime_map(SUNDAR2016, **grid, client=client), regime_map(SUNDAR2016, **grid))
    # the nannies set the workers' environment in this process (restarting the killed worker, too);
    # it is restored: numba refuses to compile here once NUMBA_NUM_THREADS has changed
    assert {key: os.environ.get(key) for key in environ} == environ
    assert killed, "no worker was busy with a fit when one had finished"
    path, content = witness[0]
    assert path.read_bytes() == content  # a finished result is never rewritten
    serial = first_run[1].table
    assert "local cluster" in result.where
    assert list(result.table["status"]) == list(serial["status"])
    assert list(result.table["key"]) == list(serial["key"])
    assert np.array_equal(result.table["beta"].to_numpy(), serial["beta"].to_numpy(), equal_nan=True), (
        result.table[["key", "beta"]], serial[["key", "beta"]])


def test_a_joint_fit_with_a_recording_that_cannot_be_prepared_fits_the_others(tmp_path, recordings):
    """A part that cannot be done does not take the others with it: the joint fit of ``a`` and the
    corrupt ``bad`` is ``a``'s fit, its record names what was left out and why."""
    spec = load_campaign(_campaign(tmp_path / "c", recordings, names=("a", "bad"), group=("a", "bad")))
    result = run_campaign(spec, spec.out)
    table = result.table.set_index("name")
    assert table.loc["g", "status"] == "ok" and table.loc["bad", "status"] == "failed"
    assert "recording bad could not be prepared" in table.loc["g", "reason"]
    assert np.isfinite(table.loc["g", "beta"]) and table.loc["g", "recordings"] == "a;bad"
    record = json.loads((spec.out / "fits" / f"{table.loc['g', 'key']}.json").read_text())
    notes = record["result"]["notes"]
    assert any(note.startswith("bad left out of the joint fit") for note in notes), notes

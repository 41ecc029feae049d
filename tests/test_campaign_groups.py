"""Campaign groups (impactid.campaign): a folder is grouped by rig from the files' headers, a group
that names one recording twice or recordings of different rigs is a failed fit known without a task,
and the summary counts each fit once.

The recordings are those of tests/test_campaign.py (rig P, 0.3 s) and one short recording of rig F,
which impactid cannot fit (its rig offers no Hunt-Crossley law); the campaigns run serially.
"""

from __future__ import annotations

import os
import shutil
from dataclasses import replace
from pathlib import Path

import h5py
import pytest

from impactid.campaign import RecordingSpec, load_campaign, read_rig_header, rig_groups, run_campaign
from impactid.cli import main
from tests import test_campaign as _campaign_tests

OPTIONS = _campaign_tests.OPTIONS
recordings = _campaign_tests.recordings  # the session fixture of the rig P recordings (a, b, a damaged "bad")


@pytest.fixture(scope="module")
def flat_recording(tmp_path_factory) -> Path:
    """A 1 s recording of rig F (flat-faced follower, 110 rpm), as ``impactid synth`` writes it."""
    path = tmp_path_factory.mktemp("rig_f") / "f.h5"
    assert main(["synth", "--rig", "flat-follower", "--rpm", "110", "--duration", "1", "--out", str(path)]) == 0
    return path


def _with_rig_attribute(source: Path, target: Path, **attributes: float) -> Path:
    """A copy of a recording whose ``/rig`` attributes are changed (another rig P, for the headers)."""
    shutil.copy(source, target)
    with h5py.File(target, "r+") as fh:
        for key, value in attributes.items():
            fh["rig"].attrs[key] = value
    return target


def _no_cluster():
    raise AssertionError("a cluster was started for a campaign with nothing to run")


# ---- folders are grouped by rig ---------------------------------------------------------------------------


def test_the_header_gives_the_rig_without_reading_samples(recordings, flat_recording, tmp_path):
    a = read_rig_header(RecordingSpec("a", recordings["a"]))
    b = read_rig_header(RecordingSpec("b", recordings["b"]))
    f = read_rig_header(RecordingSpec("f", flat_recording))
    assert (a.model, a.estimable, f.model, f.estimable) == ("pivoted-follower", True, "flat-follower", False)
    assert a == b and "e" not in dict(a.fixed)  # the eccentricity is the operating point's
    stiffer = _with_rig_attribute(recordings["a"], tmp_path / "stiff.h5", k_s=1.5 * dict(a.fixed)["k_s"])
    assert a.differences(read_rig_header(RecordingSpec("s", stiffer))) == "rig parameter(s) k_s"
    assert a.differences(f) == "model pivoted-follower against flat-follower"
    assert read_rig_header(RecordingSpec("bad", recordings["bad"])) is None  # no header: no judgement
    assert read_rig_header(RecordingSpec("gone", tmp_path / "missing.h5")) is None


def test_a_folder_of_several_rigs_is_grouped_by_rig(recordings, flat_recording, tmp_path):
    for name in ("a", "b", "bad"):
        shutil.copy(recordings[name], tmp_path / f"{name}.h5")
    shutil.copy(flat_recording, tmp_path / "f.h5")
    k_s = dict(read_rig_header(RecordingSpec("a", recordings["a"])).fixed)["k_s"]
    # two recordings of another rig P (a stiffer spring), at two eccentricities
    c = _with_rig_attribute(recordings["a"], tmp_path / "c.h5", k_s=1.5 * k_s)
    with h5py.File(c, "r") as fh:
        e = float(fh["rig"].attrs["e"])
    _with_rig_attribute(c, tmp_path / "d.h5", e=0.9 * e)
    spec = load_campaign(tmp_path)
    assert [r.name for r in spec.recordings] == ["a", "b", "bad", "c", "d", "f"]
    assert {g: [r.name for r in m] for g, m in spec.groups().items()} == {
        "pivoted-follower-1": ["a", "b"], "pivoted-follower-2": ["c", "d"]}
    # a rig F recording (not fittable), a damaged file, the only recording of its rig: in no group
    assert rig_groups([RecordingSpec(p.stem, p) for p in (tmp_path / "a.h5", c, tmp_path / "f.h5")]) == {}
    # one rig throughout: every recording in the group "all" (as before: the finished joint fits keep their key)
    assert rig_groups([RecordingSpec(n, recordings[n]) for n in ("a", "b")]) == {"all": ("a", "b")}


def test_a_mixed_folder_runs_each_fit_once_and_a_rerun_prepares_nothing(recordings, flat_recording, tmp_path):
    folder = tmp_path / "mixed"
    folder.mkdir()
    shutil.copy(recordings["a"], folder / "a.h5")
    shutil.copy(flat_recording, folder / "f.h5")
    spec = load_campaign(folder)
    spec = replace(spec, single=replace(spec.single, calibrate=False))  # fast (the calibration is tested elsewhere)
    assert spec.groups() == {}  # one recording of each rig: no joint fit
    lines: list[str] = []
    first = run_campaign(spec, tmp_path / "out", log=lines.append)
    assert list(zip(first.table["name"], first.table["status"])) == [("a", "ok"), ("f", "failed")]
    assert (first.ran, first.skipped, first.failed, first.prepared) == (1, 0, 1, 1)  # f is never prepared
    assert first.ran + first.skipped + first.failed == first.fits == 2
    reason = first.table.loc[1, "reason"]
    assert "recording f could not be prepared" in reason and "f.h5" in reason and "'flat-follower'" in reason
    assert any(line.startswith("running 1 prepare and 1 fit tasks") for line in lines)
    lines.clear()
    again = run_campaign(spec, tmp_path / "out", cluster=_no_cluster, log=lines.append)
    assert (again.ran, again.skipped, again.failed, again.prepared, again.cached) == (0, 1, 1, 0, 0)
    assert again.where == "nothing to run" and not any(line.startswith("running") for line in lines)
    assert again.table.loc[1, "reason"] == reason


# ---- groups that cannot be fitted are failed parts, known before any task --------------------------------


def test_a_group_of_one_recording_twice_is_refused_and_the_others_stand(recordings, tmp_path, capsys):
    for name in ("a", "b"):
        shutil.copy(recordings[name], tmp_path / f"{name}.h5")
    shutil.copy(recordings["b"], tmp_path / "b_copy.h5")  # identical content under another name
    os.symlink(tmp_path / "a.h5", tmp_path / "a_link.h5")  # one file under two names
    (tmp_path / "campaign.toml").write_text(
        '[campaign]\nname = "twice"\nout = "out"\nsingle_fits = false\n' + OPTIONS
        + "".join(f'[[recording]]\npath = "{path}"\nname = "{name}"\ngroup = "{group}"\n'
                  for path, name, group in [("a.h5", "a", "one_file"), ("a_link.h5", "a2", "one_file"),
                                            ("b.h5", "b", "same_bytes"), ("b_copy.h5", "b2", "same_bytes")])
        + '[[recording]]\npath = "a.h5"\nname = "a3"\ngroup = "fine"\n'
        + '[[recording]]\npath = "b.h5"\nname = "b3"\ngroup = "fine"\n')
    spec = load_campaign(tmp_path / "campaign.toml")
    result = run_campaign(spec, spec.out)
    table = result.table.set_index("name")
    assert list(table.index) == ["one_file", "same_bytes", "fine"]
    assert list(table["status"]) == ["failed", "failed", "ok"]
    one_file, same_bytes = table.loc["one_file", "reason"], table.loc["same_bytes", "reason"]
    assert "group 'one_file' names one recording twice" in one_file
    assert "a (" in one_file and "a2 (" in one_file and "one file" in one_file
    assert "group 'same_bytes'" in same_bytes and "b (" in same_bytes and "b2 (" in same_bytes
    assert "identical contents" in same_bytes
    assert (result.ran, result.skipped, result.failed, result.prepared) == (1, 0, 2, 2)  # only a and b prepared
    # the command: the counts add up, each refused group one failed line; a rerun runs nothing
    assert main(["campaign", str(tmp_path / "campaign.toml"), "--serial", "--no-progress"]) == 1
    out = capsys.readouterr().out
    assert "3 fits: 0 done, 1 skipped (finished earlier), 2 failed" in out
    assert "failed: joint fit one_file: group 'one_file' names one recording twice" in out


def test_a_group_of_different_rigs_is_refused_without_preparing_it(recordings, flat_recording, tmp_path):
    shutil.copy(recordings["a"], tmp_path / "a.h5")
    shutil.copy(flat_recording, tmp_path / "f.h5")
    stiff = _with_rig_attribute(recordings["b"], tmp_path / "stiff.h5",
                                k_s=1.5 * dict(read_rig_header(RecordingSpec("b", recordings["b"])).fixed)["k_s"])
    (tmp_path / "campaign.toml").write_text(
        '[campaign]\nname = "rigs"\nout = "out"\nsingle_fits = false\n' + OPTIONS
        + '[[recording]]\npath = "a.h5"\ngroup = "p_and_f"\n[[recording]]\npath = "f.h5"\ngroup = "p_and_f"\n'
        + f'[[recording]]\npath = "a.h5"\nname = "a2"\ngroup = "two_springs"\n'
          f'[[recording]]\npath = "{stiff.name}"\ngroup = "two_springs"\n')
    spec = load_campaign(tmp_path / "campaign.toml")
    result = run_campaign(spec, spec.out, cluster=_no_cluster)
    assert list(result.table["status"]) == ["failed", "failed"]
    assert (result.ran, result.skipped, result.failed, result.prepared, result.where) == (0, 0, 2, 0, "nothing to run")
    p_and_f, two_springs = result.table["reason"]
    assert "group 'p_and_f': a joint fit needs recordings of one rig" in p_and_f
    assert "a and f differ (model pivoted-follower against flat-follower)" in p_and_f
    assert "a2 and stiff differ (rig parameter(s) k_s)" in two_springs

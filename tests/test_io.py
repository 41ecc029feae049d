"""Recording I/O: round trips, every bad-input case, warnings, rig override, /truth isolation."""

from __future__ import annotations

import hashlib
import warnings

import h5py
import numpy as np
import pytest

from impactid import SUNDAR2016, save_rig_toml
from impactid.cli import main
from impactid.errors import ImpactidError
from impactid.io import (
    Recording,
    RecordingError,
    RecordingWarning,
    read_csv,
    read_hdf5,
    read_recording,
    read_truth,
    write_csv,
    write_hdf5,
)

RIG = SUNDAR2016


def small_recording(n=2000, rate=204_800.0, **changes) -> Recording:
    rng = np.random.default_rng(1)
    values = dict(
        channels={"accel_tangential": rng.normal(size=n), "force_x": rng.normal(size=n),
                  "force_y": rng.normal(size=n), "cam_angle": np.arange(n) * 16 * 2 * np.pi / rate},
        sample_rate_hz=rate, units={"accel_tangential": "m/s^2", "force_x": "N", "force_y": "N", "cam_angle": "rad"},
        rig=RIG, operating={"cam_speed_hz": 16.0, "eccentricity_m": RIG.e}, start_time_s=1.25)
    values.update(changes)
    return Recording(**values)


def sha(path) -> str:
    return hashlib.sha256(open(path, "rb").read()).hexdigest()


# ---- round trips --------------------------------------------------------------------------------


def test_hdf5_round_trip_is_identical(tmp_path):
    rec = small_recording()
    path = write_hdf5(rec, tmp_path / "r.h5")
    back = read_hdf5(path)
    assert back.sample_rate_hz == rec.sample_rate_hz and back.start_time_s == rec.start_time_s
    assert dict(back.units) == dict(rec.units)
    assert back.rig == rec.rig and dict(back.operating) == dict(rec.operating)
    for name in rec.channels:
        assert np.array_equal(back[name], rec[name])
    assert back.provenance[-1].startswith("read_hdf5(")
    assert not list(tmp_path.glob(".*.tmp"))


def test_csv_round_trip(tmp_path):
    rec = small_recording()
    csv, toml = write_csv(rec, tmp_path / "r.csv")
    back = read_csv(csv)  # the sibling r.toml supplies the rig
    for name in rec.channels:
        assert np.array_equal(back[name], rec[name])  # 17 significant digits round-trip doubles
    assert back.sample_rate_hz == pytest.approx(rec.sample_rate_hz, rel=1e-9)
    assert back.start_time_s == rec.start_time_s
    assert back.rig == rec.rig and back.cam_speed_hz == 16.0


def test_synthetic_round_trip_and_truth_isolated(s2_synthetic, s2_file):
    rec = read_recording(s2_file)
    for name in s2_synthetic.recording.channels:
        assert np.array_equal(rec[name], s2_synthetic.recording[name])
    assert not hasattr(rec, "truth")
    assert all("truth" not in step for step in rec.provenance)
    truth = read_truth(s2_file)
    assert truth["beta"] == 24.7e9 and truth["n"] == 1.5
    assert np.array_equal(truth["alpha"], s2_synthetic.truth["alpha"])
    assert truth["impacts"]["t_start"].size == 16


def test_channels_are_read_only_and_callers_arrays_untouched():
    data = np.zeros(100)
    rec = small_recording(n=100, channels={"accel_tangential": data}, units={"accel_tangential": "m/s^2"})
    assert data.flags.writeable
    with pytest.raises(ValueError):
        rec["accel_tangential"][0] = 1.0
    step = rec.slice_time(1.25, 1.25 + 50 / rec.sample_rate_hz)
    assert step.n_samples == 50 and rec.n_samples == 100
    assert step.provenance[-1].startswith("slice_time")


def test_rig_toml_overrides_hdf5_rig(tmp_path):
    path = write_hdf5(small_recording(), tmp_path / "r.h5")
    other = RIG.with_eccentricity_ratio(0.1)
    toml = save_rig_toml(other, tmp_path / "rig.toml", operating={"cam_speed_hz": 15.0})
    rec = read_recording(path, rig=toml, check=False)
    assert rec.rig == other and rec.cam_speed_hz == 15.0
    assert rec.operating["eccentricity_m"] == pytest.approx(other.e)
    assert f"rig from {toml}" in rec.provenance


def test_units_converted_at_the_edge(tmp_path):
    path = tmp_path / "g.h5"
    write_hdf5(small_recording(), path)
    with h5py.File(path, "r+") as fh:
        fh["signals/accel_tangential"].attrs["units"] = "g"
    rec = read_hdf5(path)
    assert rec.units["accel_tangential"] == "m/s^2"
    assert np.allclose(rec["accel_tangential"], small_recording()["accel_tangential"] * 9.80665)
    assert any("converted from g" in s for s in rec.provenance)


def test_writer_never_overwrites_its_input(tmp_path):
    path = write_hdf5(small_recording(), tmp_path / "r.h5")
    before = sha(path)
    rec = read_recording(path, check=False)
    with pytest.raises(ImpactidError, match="is an input of this command; refusing to overwrite it"):
        write_hdf5(rec, path)
    assert sha(path) == before


# ---- bad input: message and exit code ------------------------------------------------------------


def _h5(path, mutate):
    write_hdf5(small_recording(), path)
    with h5py.File(path, "r+") as fh:
        mutate(fh)
    return path


BAD_HDF5 = {
    "no /signals group": lambda fh: fh.move("signals", "sig"),
    "no sample_rate_hz": lambda fh: fh["signals"].attrs.__delitem__("sample_rate_hz"),
    "no units attribute": lambda fh: fh["signals/force_x"].attrs.__delitem__("units"),
    "no /rig group": lambda fh: fh.__delitem__("rig"),
    "unknown rig model 'rocker'": lambda fh: fh["rig"].attrs.__setitem__("model", "rocker"),
    "missing parameter\\(s\\) k_s": lambda fh: fh["rig"].attrs.__delitem__("k_s"),
    "'k_s' must be positive": lambda fh: fh["rig"].attrs.__setitem__("k_s", -1.0),
    "'mu' is not finite": lambda fh: fh["rig"].attrs.__setitem__("mu", np.nan),
    "unequal lengths": lambda fh: (fh["signals"].__delitem__("force_y"),
                                   fh["signals"].create_dataset("force_y", data=np.zeros(5)).attrs.__setitem__("units",
                                                                                                                "N")),
    "'force_x' has 1 NaN or Inf sample\\(s\\), the first at index 7": lambda fh: fh["signals/force_x"].__setitem__(
        7, np.nan),
    "'accel_tangential' has 2 NaN or Inf": lambda fh: fh["signals/accel_tangential"].__setitem__(
        slice(3, 5), np.inf),
    "sample_rate_hz must be positive": lambda fh: fh["signals"].attrs.__setitem__("sample_rate_hz", 0.0),
    "sample_rate_hz must be positive and finite, got inf": lambda fh: fh["signals"].attrs.__setitem__(
        "sample_rate_hz", np.inf),
    "has units 'furlongs'": lambda fh: fh["signals/force_x"].attrs.__setitem__("units", "furlongs"),
    "not numeric": lambda fh: (fh["signals"].__delitem__("force_y"),
                               fh["signals"].create_dataset("force_y", data=np.array([b"x"] * 2000)).attrs.__setitem__(
                                   "units", "N")),
    "impactid_format is 'result'": lambda fh: fh.attrs.__setitem__("impactid_format", "result"),
}


@pytest.mark.parametrize("message", list(BAD_HDF5))
def test_bad_hdf5_gives_clear_error_and_exit_code(tmp_path, capsys, message):
    path = _h5(tmp_path / "bad.h5", BAD_HDF5[message])
    before = sha(path)
    with pytest.raises(RecordingError, match=message) as info:
        read_recording(path)
    assert str(path) in str(info.value)
    assert main(["info", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("impactid: error: ") and str(path) in err
    assert sha(path) == before


def _write(path, text: str | bytes):
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text)
    return path


def test_missing_file_directory_and_not_hdf5(tmp_path, capsys):
    cases = {
        tmp_path / "missing.h5": "file not found",
        tmp_path: "is a directory",
        _write(tmp_path / "text.h5", "time_s,force_x\n0,1\n"): "not an HDF5 file",
        _write(tmp_path / "x.dat", b"\x00\x01"): "unknown recording type",
    }
    for path, message in cases.items():
        with pytest.raises(RecordingError, match=message):
            read_recording(path)
        assert main(["info", str(path)]) == 2
        assert message in capsys.readouterr().err


@pytest.mark.skipif(hasattr(__import__("os"), "geteuid") and __import__("os").geteuid() == 0,
                    reason="root can read any file")
def test_unreadable_file(tmp_path):
    path = write_hdf5(small_recording(), tmp_path / "r.h5")
    path.chmod(0)
    with pytest.raises(RecordingError, match="permission denied"):
        read_recording(path)


def _csv_with_rig(tmp_path, text):
    save_rig_toml(RIG, tmp_path / "r.toml", operating={"cam_speed_hz": 16.0})
    return _write(tmp_path / "r.csv", text)


@pytest.mark.parametrize("text, message", [
    ("force_x,force_y\n1,2\n3,4\n", "no 'time_s' column"),
    ("time_s,force_x\n0,1\n1e-5,abc\n2e-5,3\n", "column 'force_x' row 3 is not a number"),
    ("time_s,force_x\n0,1\n", "fewer than two samples"),
    ("time_s,force_x\n0,1\n1e-5,2\n3e-5,3\n4e-5,4\n", "not uniform: sample 1"),
    ("time_s,force_x\n0,1\n0,2\n0,3\n", "not increasing"),
    ("time_s,force_x\n0,1\n1e-5,nan\n2e-5,3\n", "'force_x' has 1 NaN or Inf"),
    ("time_s\n0\n1e-5\n", "no channel columns"),
    ("time_s,force_x\n0,1,5\n1e-5,2\n", "malformed CSV"),
    ("", "malformed CSV"),
])
def test_bad_csv(tmp_path, capsys, text, message):
    path = _csv_with_rig(tmp_path, text)
    with pytest.raises(RecordingError, match=message):
        read_recording(path)
    assert main(["info", str(path)]) == 2
    assert str(path) in capsys.readouterr().err


def test_csv_needs_a_rig(tmp_path):
    path = _write(tmp_path / "norig.csv", "time_s,force_x\n0,1\n1e-5,2\n")
    with pytest.raises(RecordingError, match="needs a rig file"):
        read_recording(path)
    bad_rig = _write(tmp_path / "bad.toml", "[rig]\nmodel = 'pivoted-follower'\n")
    with pytest.raises(RecordingError, match="missing parameter"):
        read_recording(path, rig=bad_rig)


def test_csv_time_rounding_is_accepted(tmp_path):
    rate = 204_800.0
    n = 1000
    t = 30.0 + np.arange(n) / rate
    lines = ["time_s,force_x"] + [f"{x:.9g},{i}" for i, x in enumerate(t)]
    rec = read_recording(_csv_with_rig(tmp_path, "\n".join(lines) + "\n"), check=False)
    assert rec.sample_rate_hz == pytest.approx(rate, rel=1e-6)


def test_missing_channel_for_a_method():
    rec = small_recording(channels={"force_x": np.zeros(10)}, units={"force_x": "N"})
    with pytest.raises(RecordingError, match="event detection needs channel\\(s\\) accel_tangential"):
        rec.require("accel_tangential", method="event detection")


def test_operating_eccentricity_must_match_rig():
    with pytest.raises(RecordingError, match="disagrees with the rig"):
        small_recording(operating={"cam_speed_hz": 16.0, "eccentricity_m": 0.001})


def test_warnings_for_clipped_and_short_recordings(tmp_path):
    a = np.sin(np.linspace(0, 20, 5000)) * 100
    clipped = np.clip(a, -50, 50)
    rec = small_recording(n=5000, rate=1000.0, channels={"accel_tangential": clipped},
                          units={"accel_tangential": "m/s^2"})
    with pytest.warns(RecordingWarning, match="looks clipped") as record:
        rec.check()
    assert len(record) == 2  # at the maximum and at the minimum
    short = small_recording(n=100, rate=1000.0, channels={"accel_tangential": a[:100]},
                            units={"accel_tangential": "m/s^2"})
    with pytest.warns(RecordingWarning, match="very short recording: 0.1 s is 1.6 cam revolution"):
        short.check()
    long = small_recording(n=5000, rate=1000.0, channels={"accel_tangential": a}, units={"accel_tangential": "m/s^2"})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert long.check() == []


def test_compiled_scans_agree_with_numpy():
    from impactid._scan import channel_scan, count_equal, extreme_stats

    def _longest_run(mask):  # numpy reference
        edges = np.flatnonzero(np.diff(np.concatenate(([0], mask.astype(np.int8), [0]))))
        return int((edges[1::2] - edges[0::2]).max()) if edges.size else 0

    rng = np.random.default_rng(2)
    x = np.round(rng.normal(size=100_003), 2)
    lo, hi, finite = channel_scan(x)
    assert (lo, hi, finite) == (x.min(), x.max(), True)
    for bad in (np.nan, np.inf, -np.inf):
        y = x.copy()
        y[77_777] = bad
        assert not channel_scan(y)[2]
    assert count_equal(x, x.max()) == np.count_nonzero(x == x.max())
    count, run, neighbour = extreme_stats(x, x.max(), True)
    assert count == np.count_nonzero(x == x.max()) and run == _longest_run(x == x.max())
    assert neighbour == np.count_nonzero(x == x[x < x.max()].max())
    count, run, neighbour = extreme_stats(x, x.min(), False)
    assert neighbour == np.count_nonzero(x == x[x > x.min()].min())

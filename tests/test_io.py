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


# ---- plausibility of the time base and the cam speed ----------------------------------------------


@pytest.mark.parametrize("attribute, value, message", [
    ("sample_rate_hz", 1e300, "/signals sample_rate_hz = 1e+300 Hz is not a plausible sample rate"),
    ("sample_rate_hz", 1e-300, "/signals sample_rate_hz = 1e-300 Hz is not a plausible sample rate"),
    ("sample_rate_hz", 0.5, "not a plausible sample rate"),
    ("sample_rate_hz", 2e8, "not a plausible sample rate"),
    ("start_time_s", 1e300, "/signals start_time_s = 1e+300 s is too far from 0"),
    ("start_time_s", -1.7e9, "/signals start_time_s = -1.7e+09 s is too far from 0"),  # Unix time at 204.8 kHz
    ("start_time_s", np.inf, "/signals start_time_s must be finite"),
])
def test_implausible_time_base_is_refused_naming_the_attribute(tmp_path, capsys, attribute, value, message):
    path = _h5(tmp_path / "t.h5", lambda fh: fh["signals"].attrs.__setitem__(attribute, value))
    with pytest.raises(RecordingError, match=message.replace("+", "\\+")) as info:
        read_recording(path)
    assert str(path) in str(info.value)
    assert main(["info", str(path)]) == 2  # info refuses too
    assert message in capsys.readouterr().err


def test_time_base_limits_are_the_documented_ones():
    """1 Hz and 100 MHz are accepted; start times are accepted while float64 resolves 1/1024 sample."""
    for rate in (1.0, 100e6):
        small_recording(n=20, rate=rate, operating={}, start_time_s=0.0)
    rate = 204_800.0
    ok = 2.0 ** 25 * 0.999  # float64 spacing 2^-28 s = 1/1311 of 1/rate
    small_recording(n=20, rate=rate, start_time_s=ok)
    with pytest.raises(RecordingError, match="start_time_s = .* is too far from 0 for 204800 Hz"):
        small_recording(n=20, rate=rate, start_time_s=2.0 ** 25 * 1.001)
    # the last sample counts, not only the first
    with pytest.raises(RecordingError, match="too far from 0"):
        small_recording(n=20, rate=rate, start_time_s=-(2.0 ** 25) * 1.001 + 1e-3)


@pytest.mark.parametrize("speed, message", [
    (1e12, "cam_speed_hz = 1e\\+12 Hz is not a plausible cam speed"),
    (2000.0, "cam_speed_hz = 2000 Hz is not a plausible cam speed"),
    (1e-4, "cam_speed_hz = 0.0001 Hz is not a plausible cam speed"),
])
def test_implausible_cam_speed_is_refused(tmp_path, speed, message):
    path = _h5(tmp_path / "c.h5", lambda fh: fh["operating"].attrs.__setitem__("cam_speed_hz", speed))
    with pytest.raises(RecordingError, match="/operating " + message):
        read_recording(path)
    # from a rig file, the rig file is named
    toml = save_rig_toml(RIG, tmp_path / "fast.toml", operating={"cam_speed_hz": speed})
    good = write_hdf5(small_recording(), tmp_path / "good.h5")
    with pytest.raises(RecordingError, match=f"rig file {toml} \\[operating\\] " + message):
        read_recording(good, rig=toml)


def test_cam_speed_needs_samples_per_revolution():
    small_recording(n=200, rate=1000.0, operating={"cam_speed_hz": 125.0}, channels={"force_x": np.zeros(200)},
                    units={"force_x": "N"})  # 8 samples per revolution
    with pytest.raises(RecordingError, match="cam_speed_hz = 128 Hz gives 7.81 samples per cam revolution at 1000 Hz; "
                                             "at least 8"):
        small_recording(n=200, rate=1000.0, operating={"cam_speed_hz": 128.0}, channels={"force_x": np.zeros(200)},
                        units={"force_x": "N"})


# ---- unit strings -------------------------------------------------------------------------------------


@pytest.mark.parametrize("unit, reason", [
    ("m/s^", "exponent"),
    ("((", "unbalanced parentheses"),
    ("m/s/0", "division by zero"),
    ("m s-2 )", "unbalanced parentheses"),
    ("2^2^2^2^30 m/s^2", "raised to a power again"),  # would compute for ever
    ("2^99999999 m/s^2", "exponent 99999999 is out of range"),
    ("m/s^(1+1)", "exponent"),
    ("m/s^2" * 20, "too long"),
    ("m/s\x002", "control characters"),
    ("__import__('os')", "not a known unit"),
])
def test_malformed_unit_strings_name_file_channel_and_unit(tmp_path, unit, reason):
    path = _h5(tmp_path / "u.h5", lambda fh: fh["signals/accel_tangential"].attrs.__setitem__(
        "units", np.bytes_(unit.encode())))
    with pytest.raises(RecordingError) as info:
        read_recording(path)
    text = str(info.value)
    assert text.startswith(f"{path}: channel 'accel_tangential' has units {unit!r}") and reason in text, text


def test_units_that_are_not_utf8_are_named_as_bytes(tmp_path):
    opaque = np.bytes_(b"\xff\xfe\x80")
    path = _h5(tmp_path / "u.h5", lambda fh: fh["signals/force_x"].attrs.__setitem__("units", opaque))
    with pytest.raises(RecordingError, match=r"channel 'force_x' has units b'\\xff\\xfe\\x80': not UTF-8 text"):
        read_recording(path)


def test_well_formed_units_still_convert():
    from impactid.units import si_factor

    assert si_factor("m/s^(2)", "acceleration") == 1.0
    assert si_factor("m*s^-2", "acceleration") == 1.0
    assert si_factor("m/s²", "acceleration") == 1.0
    assert si_factor("km/h/s", "acceleration") == pytest.approx(1 / 3.6)
    assert si_factor("kN", "force") == 1000.0


# ---- links, virtual datasets, external storage ---------------------------------------------------------


def test_dangling_symbolic_links_are_named(tmp_path):
    link = tmp_path / "r.h5"
    link.symlink_to(tmp_path / "gone.h5")
    with pytest.raises(RecordingError, match="is a symbolic link to .*gone.h5, which does not exist"):
        read_recording(link)
    good = write_hdf5(small_recording(), tmp_path / "good.h5")
    rig_link = tmp_path / "rig.toml"
    rig_link.symlink_to(tmp_path / "gone.toml")
    with pytest.raises(RecordingError, match="rig.toml: is a symbolic link to .*gone.toml, which does not exist"):
        read_recording(good, rig=rig_link)


@pytest.mark.parametrize("kind, message", [
    ("external channel", "/signals/force_x is an external link to missing.h5:/force_x, which cannot be opened"),
    ("external group", "/signals is an external link to missing.h5:/signals, which cannot be opened"),
    ("soft channel", "/signals/force_x is a soft link to /nowhere, which does not exist"),
])
def test_broken_hdf5_links_are_named(tmp_path, kind, message):
    def mutate(fh):
        if kind == "external group":
            del fh["signals"]
            fh["signals"] = h5py.ExternalLink("missing.h5", "/signals")
            return
        del fh["signals/force_x"]
        fh["signals/force_x"] = (h5py.ExternalLink("missing.h5", "/force_x") if kind == "external channel"
                                 else h5py.SoftLink("/nowhere"))

    path = _h5(tmp_path / "l.h5", mutate)
    with pytest.raises(RecordingError, match=message):
        read_recording(path)


def test_working_links_and_virtual_datasets_are_read(tmp_path):
    rec = small_recording()
    with h5py.File(tmp_path / "data.h5", "w") as source:
        source.create_dataset("force_x", data=rec["force_x"])

    def mutate(fh):
        del fh["signals/force_x"]
        layout = h5py.VirtualLayout(shape=(rec.n_samples,), dtype="f8")
        layout[:] = h5py.VirtualSource("data.h5", "/force_x", shape=(rec.n_samples,))
        fh["signals"].create_virtual_dataset("force_x", layout, fillvalue=np.nan).attrs["units"] = "N"
        fh["signals/force_y_link"] = h5py.SoftLink("/signals/force_y")

    path = _h5(tmp_path / "v.h5", mutate)
    back = read_recording(path, check=False)
    assert np.array_equal(back["force_x"], rec["force_x"])
    assert np.array_equal(back["force_y_link"], rec["force_y"])


def test_virtual_dataset_with_a_missing_source_is_refused(tmp_path):
    n = small_recording().n_samples

    def mutate(fh):
        del fh["signals/force_x"]
        layout = h5py.VirtualLayout(shape=(n,), dtype="f8")
        layout[:] = h5py.VirtualSource("missing_source.h5", "/force_x", shape=(n,))
        fh["signals"].create_virtual_dataset("force_x", layout, fillvalue=0.0).attrs["units"] = "N"

    path = _h5(tmp_path / "v.h5", mutate)
    with pytest.raises(RecordingError, match="channel 'force_x' is a virtual dataset whose source file "
                                             "missing_source.h5 does not exist"):
        read_recording(path)


def test_external_raw_storage_that_is_missing_is_named(tmp_path):
    n = small_recording().n_samples

    def mutate(fh):
        del fh["signals/force_x"]
        ds = fh["signals"].create_dataset("force_x", shape=(n,), dtype="f8",
                                          external=[(str(tmp_path / "raw.bin"), 0, 8 * n)])
        ds.attrs["units"] = "N"

    path = _h5(tmp_path / "x.h5", mutate)
    with pytest.raises(RecordingError, match="channel 'force_x' keeps its samples in external raw file"):
        read_recording(path)


# ---- rig files ------------------------------------------------------------------------------------


def test_rig_file_with_a_byte_order_mark_is_read(tmp_path):
    toml = save_rig_toml(RIG, tmp_path / "rig.toml", operating={"cam_speed_hz": 16.0})
    toml.write_bytes(b"\xef\xbb\xbf" + toml.read_bytes())
    rec = read_recording(write_hdf5(small_recording(), tmp_path / "r.h5"), rig=toml, check=False)
    assert rec.rig == RIG


@pytest.mark.parametrize("content, message", [
    (bytes(range(256)), "not a TOML rig file: not UTF-8 text \\(byte 0x80 at line 2\\)"),
    (b"\x89HDF\r\n\x1a\n" + bytes(100), "is an HDF5 file, not a TOML rig file"),
])
def test_binary_rig_files_are_named(tmp_path, content, message):
    toml = tmp_path / "rig.toml"
    toml.write_bytes(content)
    with pytest.raises(RecordingError, match=f"{toml}: {message}"):
        read_recording(write_hdf5(small_recording(), tmp_path / "r.h5"), rig=toml)


# ---- CSV text -----------------------------------------------------------------------------------------


def test_csv_byte_order_mark_and_trailing_commas_everywhere_are_accepted(tmp_path):
    rec = small_recording(n=300)
    csv, _ = write_csv(rec, tmp_path / "r.csv")
    text = csv.read_bytes()
    variants = {
        "bom": b"\xef\xbb\xbf" + text,
        "rows": b"\n".join(line + b"," if i else line for i, line in enumerate(text.splitlines())) + b"\n",
        "all": b"\n".join(line + b"," for line in text.splitlines()) + b"\n",
    }
    for name, content in variants.items():
        csv.write_bytes(content)
        back = read_recording(csv, check=False)
        assert list(back.channels) == list(rec.channels), name
        assert np.array_equal(back["force_x"], rec["force_x"]), name


@pytest.mark.parametrize("edit, message", [
    (lambda lines: [lines[0]] + [line + (b"," if i == 10 else b"") for i, line in enumerate(lines[1:])],
     "line 12 has 6 fields, the lines before it 5"),
    (lambda lines: [lines[0] + b","] + [line + (b",7" if i == 3 else b",") for i, line in enumerate(lines[1:])],
     "column 6 has no name in the header but holds values"),
    (lambda lines: [lines[0]] + [line + (b",7" if i == 3 else b",") for i, line in enumerate(lines[1:])],
     "rows have a value after the last of the header's 5 columns"),
    (lambda lines: [lines[0].replace(b"force_x", b"force_\xe9x")] + lines[1:],
     "not UTF-8 text: byte 0xe9 at line 1, column 31 \\(the header\\)"),
    (lambda lines: lines[:5] + [lines[5] + b"\xff"] + lines[6:], "not UTF-8 text: byte 0xff at line 6"),
])
def test_ambiguous_csv_text_is_refused_saying_what_is_wrong(tmp_path, edit, message):
    csv, _ = write_csv(small_recording(n=300), tmp_path / "r.csv")
    csv.write_bytes(b"\n".join(edit(csv.read_bytes().splitlines())) + b"\n")
    with pytest.raises(RecordingError, match=message):
        read_recording(csv)


# ---- memory -----------------------------------------------------------------------------------------------


def test_memory_limit_from_the_environment(tmp_path, monkeypatch, capsys):
    from impactid.io import available_memory, check_memory, recording_footprint

    path = write_hdf5(small_recording(n=2000), tmp_path / "r.h5")
    footprint = recording_footprint(path)
    assert (footprint.n_samples, footprint.n_channels, footprint.nbytes) == (2000, 4, 64_000)
    csv, _ = write_csv(small_recording(n=2000), tmp_path / "r.csv")
    sized = recording_footprint(csv)
    assert sized.n_channels == 5 and 1900 <= sized.n_samples <= 2100  # from the length of the first rows
    monkeypatch.setenv("IMPACTID_MEMORY_LIMIT", "5e5")
    assert available_memory() == (5e5, "IMPACTID_MEMORY_LIMIT")
    check_memory([path], "events")  # 2.5 x 64 kB
    with pytest.raises(RecordingError, match=f"{path}: the estimate needs about 576 kB of memory \\(2,000 samples of "
                                             "channel 'accel_tangential' x 4 channel\\(s\\) x 8 bytes = 64 kB, x 9\\), "
                                             "more than the 500 kB available \\(IMPACTID_MEMORY_LIMIT\\)"):
        check_memory([path], "estimate")
    monkeypatch.setenv("IMPACTID_MEMORY_LIMIT", "6e4")
    with pytest.raises(RecordingError, match="reading it needs about 96 kB"):
        read_recording(path)
    with pytest.raises(RecordingError, match="r.csv: reading it needs about"):
        read_recording(csv)
    assert main(["info", str(path)]) == 2
    assert "more than the 60 kB available" in capsys.readouterr().err
    monkeypatch.setenv("IMPACTID_MEMORY_LIMIT", "lots")
    with pytest.raises(RecordingError, match="IMPACTID_MEMORY_LIMIT='lots': expected a positive number of bytes"):
        available_memory()
    monkeypatch.delenv("IMPACTID_MEMORY_LIMIT")
    limit, source = available_memory()
    assert source in ("MemAvailable", "free physical memory", "unknown") and (limit is None or limit > 0)


def test_joint_memory_counts_every_recording_read(tmp_path, monkeypatch):
    from impactid.io import MEMORY_FACTORS, check_memory

    a = write_hdf5(small_recording(n=2000), tmp_path / "a.h5")
    b = write_hdf5(small_recording(n=4000), tmp_path / "b.h5")
    need = MEMORY_FACTORS["read"] * (64_000 + 128_000) + (MEMORY_FACTORS["estimate"] - MEMORY_FACTORS["read"]) * 128_000
    monkeypatch.setenv("IMPACTID_MEMORY_LIMIT", str(need * 1.01))
    check_memory([a, b], "estimate")
    monkeypatch.setenv("IMPACTID_MEMORY_LIMIT", str(need * 0.99))
    with pytest.raises(RecordingError, match=f"{b}: the estimate needs .* with the 1 other recording"):
        check_memory([a, b], "estimate")

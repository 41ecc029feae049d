"""Every command fed broken or degenerate inputs, arguments and output paths, as a hostile new user would.

The promise (README, ``impactid.cli``): a failure ends in exactly one line ``impactid: error: ...``
naming the file, channel or argument, with exit status 2; no traceback; the inputs untouched; no
partial output (no new file, no temporary file) left behind. Degenerate but usable inputs may
succeed (exit 0) with ``impactid: warning:`` lines. Ctrl-C ends with 130, SIGTERM with 143.
"""

from __future__ import annotations

import hashlib
import json
import os
import resource
import shutil
import signal
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import h5py
import numpy as np
import pytest

from impactid import SUNDAR2016, HuntCrossley, save_rig_toml
from impactid.cli import main
from impactid.io import write_csv, write_hdf5

RIG = SUNDAR2016.with_eccentricity_ratio(0.25)
LAW = HuntCrossley(24.7e9, 1.5)


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest() if path.is_file() else "-"


def _tree(root: Path) -> dict[str, str]:
    return {str(p.relative_to(root)): _sha(p) for p in sorted(root.rglob("*")) if not p.is_dir() or p.is_symlink()}


@pytest.fixture(scope="module")
def good(tmp_path_factory):
    """A small valid recording (0.4 s at e/r_c 0.25, 15 Hz, 6 impacts) as the base of the mutations."""
    from impactid.rigs.pivoted.synth import synth_pivoted

    return synth_pivoted(RIG, 15.0, LAW, 0.4, settle_s=5.0).recording


@pytest.fixture(scope="module")
def good_files(good, tmp_path_factory):
    """``good`` written once as HDF5 and as a 40 000-row CSV with its TOML rig file; the tests that only
    need the files copy them (writing the CSV costs ten times more than the command under test)."""
    root = tmp_path_factory.mktemp("good")
    h5 = _write(good, root / "r.h5")
    csv, rig = write_csv(replace(good, source="", channels={k: v[:40_000] for k, v in good.channels.items()}),
                         root / "c.csv")
    return {"h5": h5, "csv": csv, "csv_rig": rig}


def _copy(src: Path, folder: Path) -> Path:
    return Path(shutil.copyfile(src, folder / src.name))


def _write(rec, path, mutate=None):
    write_hdf5(replace(rec, source=""), path)
    if mutate is not None:
        with h5py.File(path, "r+") as fh:
            mutate(fh)
    return path


def _set_channel(name, values):
    def mutate(fh):
        units = fh["signals"][name].attrs["units"]
        del fh["signals"][name]
        fh["signals"].create_dataset(name, data=values)
        fh["signals"][name].attrs["units"] = units
    return mutate


# Each case: (id, builder(tmp, good) -> argv, token the error line must contain). ``None`` as the
# token marks a degenerate input that may also succeed (exit 0), with its warnings.
def _file_cases():
    n = 0.4 * 204_800

    def rec(mutate=None, name="r.h5"):
        return lambda tmp, g: str(_write(g, tmp / name, mutate))

    def text(content, name):
        def build(tmp, g):
            path = tmp / name
            path.write_bytes(content if isinstance(content, bytes) else content.encode())
            return str(path)
        return build

    def csv_case(edit=None, toml=True):
        def build(tmp, g):
            path, rig = write_csv(replace(g, source="", channels={k: v[:4000] for k, v in g.channels.items()}),
                                  tmp / "c.csv")
            if edit:
                path.write_text(edit(path.read_text()))
            if not toml:
                rig.unlink()
            return str(path)
        return build

    nan = np.full(int(n), np.nan)
    return [
        ("missing file", lambda tmp, g: str(tmp / "nope.h5"), "nope.h5: file not found"),
        ("a folder", lambda tmp, g: str(tmp), "is a directory"),
        ("empty file", text(b"", "e.h5"), "e.h5"),
        ("random bytes", text(bytes(np.random.default_rng(0).integers(0, 255, 4000, dtype=np.uint8)), "b.h5"), "b.h5"),
        ("text as h5", text("hello", "t.h5"), "t.h5"),
        ("unknown suffix", text("x", "r.dat"), "unknown recording type"),
        ("truncated hdf5", lambda tmp, g: _truncate(_write(g, tmp / "tr.h5")), "tr.h5"),
        ("no signals", rec(lambda fh: fh.move("signals", "s")), "no /signals group"),
        ("no sample rate", rec(lambda fh: fh["signals"].attrs.__delitem__("sample_rate_hz")), "sample_rate_hz"),
        ("zero sample rate", rec(lambda fh: fh["signals"].attrs.__setitem__("sample_rate_hz", 0.0)), "sample_rate_hz"),
        ("nan sample rate", rec(lambda fh: fh["signals"].attrs.__setitem__("sample_rate_hz", np.nan)),
         "sample_rate_hz"),
        ("no units", rec(lambda fh: fh["signals/force_x"].attrs.__delitem__("units")), "'force_x' has no units"),
        ("unknown units", rec(lambda fh: fh["signals/force_x"].attrs.__setitem__("units", "furlongs")), "furlongs"),
        ("accel in newtons", rec(lambda fh: fh["signals/accel_tangential"].attrs.__setitem__("units", "N")),
         "not a unit of acceleration"),
        ("angle in counts", rec(lambda fh: fh["signals/cam_angle"].attrs.__setitem__("units", "counts")),
         "not an angle"),
        ("nan samples", rec(_set_channel("force_y", np.where(np.arange(int(n)) == 7, np.nan, 1.0))),
         "'force_y' has 1 NaN"),
        ("all-nan channel", rec(_set_channel("accel_tangential", nan)), "'accel_tangential' has"),
        ("unequal lengths", rec(_set_channel("force_x", np.zeros(100))), "unequal lengths"),
        ("2-d channel", rec(_set_channel("force_x", np.zeros((2, 3)))), "must be 1-D"),
        ("text channel", rec(_set_channel("force_x", np.array([b"a", b"b"]))), "not numeric"),
        ("no rig", rec(lambda fh: fh.__delitem__("rig")), "no /rig group"),
        ("unknown rig model", rec(lambda fh: fh["rig"].attrs.__setitem__("model", "rocker")), "unknown rig model"),
        ("rig parameter missing", rec(lambda fh: fh["rig"].attrs.__delitem__("k_s")), "k_s"),
        ("rig parameter negative", rec(lambda fh: fh["rig"].attrs.__setitem__("k_s", -1.0)), "k_s"),
        ("no cam speed", rec(lambda fh: fh["operating"].attrs.__delitem__("cam_speed_hz")), "cam_speed_hz"),
        ("zero cam speed", rec(lambda fh: fh["operating"].attrs.__setitem__("cam_speed_hz", 0.0)), "cam_speed_hz"),
        ("huge declared shape", rec(_sparse_huge), "accel_tangential"),
        ("all-zero accelerometer", rec(_set_channel("accel_tangential", np.zeros(int(n)))),
         "no impacts found in channel 'accel_tangential'"),
        ("constant accelerometer", rec(_set_channel("accel_tangential", np.full(int(n), 2.5))),
         "no impacts found in channel 'accel_tangential'"),
        ("flipped accelerometer", lambda tmp, g: str(_write(_scaled(g, "accel_tangential", -1.0), tmp / "f.h5")),
         "looks inverted"),
        ("ten samples", lambda tmp, g: str(_write(_head(g, 10), tmp / "ten.h5")), "only 10 samples"),
        ("one impact", lambda tmp, g: str(_write(_head(g, 10_240), tmp / "one.h5")), "no usable impact events"),
        ("two impacts", lambda tmp, g: str(_write(_head(g, 17_000), tmp / "two.h5")), None),
        ("0.2 s recording", lambda tmp, g: str(_write(_head(g, 40_960), tmp / "short.h5")), None),
        ("swapped forces", lambda tmp, g: str(_write(_swap(g), tmp / "sw.h5")), None),
        ("accelerometer in g", lambda tmp, g: str(_write(_scaled(g, "accel_tangential", 1 / 9.80665), tmp / "g.h5")),
         None),
        ("csv without time", csv_case(lambda t: t.replace("time_s", "tiempo", 1)), "no 'time_s' column"),
        ("csv duplicate columns", csv_case(lambda t: t.replace("force_x", "force_y", 1)), "duplicate column"),
        ("csv non-numeric", csv_case(lambda t: t.replace("\n", "\nabc,", 1).replace(",", ",", 1)), "c.csv"),
        ("csv non-uniform time", csv_case(lambda t: "\n".join(
            line if i != 50 else "9" + line for i, line in enumerate(t.split("\n")))), "c.csv"),
        ("csv without rig file", csv_case(toml=False), "needs a rig file"),
        ("csv header only", text("time_s,accel_tangential\n", "h.csv"), "h.csv"),
        *READ_CASES,
    ]


def _reading_cases():
    """Files refused where the recording is read, naming the file and what is wrong (so ``info``
    refuses them too), and harmless variants that are read (token None). Each was a traceback, an
    out-of-memory line or a message that did not say what was wrong."""
    def rec(mutate, name="r.h5"):
        return lambda tmp, g: str(_write(g, tmp / name, mutate))

    def csv_bytes(edit):
        def build(tmp, g):
            path, _ = write_csv(replace(g, source="", channels={k: v[:4000] for k, v in g.channels.items()}),
                                tmp / "c.csv")
            path.write_bytes(b"\n".join(edit(path.read_bytes().splitlines())) + b"\n")
            return str(path)
        return build

    def dangling(tmp, g):
        link = tmp / "r.h5"
        link.symlink_to(tmp / "gone.h5")
        return str(link)

    return [
        # absurd time bases and operating points: limits where the file is read, naming the attribute
        ("sample rate 1e300", rec(_signals_attr("sample_rate_hz", 1e300)), "sample_rate_hz = 1e+300 Hz"),
        ("sample rate 1e-300", rec(_signals_attr("sample_rate_hz", 1e-300)), "sample_rate_hz = 1e-300 Hz"),
        ("start time 1e300", rec(_signals_attr("start_time_s", 1e300)), "start_time_s = 1e+300 s is too far from 0"),
        ("cam speed 1e12", rec(lambda fh: fh["operating"].attrs.__setitem__("cam_speed_hz", 1e12)),
         "/operating cam_speed_hz = 1e+12 Hz"),
        # malformed unit strings: the units parser raised AssertionError, TokenError, ZeroDivisionError
        ("units m/s^", rec(_units("accel_tangential", "m/s^")), "channel 'accel_tangential' has units 'm/s^'"),
        ("units ((", rec(_units("accel_tangential", "((")), "channel 'accel_tangential' has units '(('"),
        ("units m/s/0", rec(_units("accel_tangential", "m/s/0")), "channel 'accel_tangential' has units 'm/s/0'"),
        ("units m s-2 )", rec(_units("accel_tangential", "m s-2 )")), "has units 'm s-2 )'"),
        ("units opaque bytes", rec(_units("force_x", np.bytes_(b"\xff\xfe\x80"))), "'force_x' has units b'\\xff"),
        ("units power tower", rec(_units("force_x", "2^2^2^2^30 N")), "raised to a power again"),
        # links that lead nowhere
        ("dangling symlink", dangling, "r.h5: is a symbolic link to"),
        ("external link missing", rec(_external_channel), "/signals/force_x is an external link to missing.h5"),
        ("external signals missing", rec(_external_signals), "/signals is an external link to missing.h5"),
        ("soft link dangling", rec(_soft_channel), "/signals/force_x is a soft link to /nowhere"),
        ("virtual source missing", rec(_virtual_channel), "'force_x' is a virtual dataset whose source file"),
        ("external raw file missing", rec(_external_raw_channel), "'force_x' keeps its samples in external raw"),
        # CSV text
        ("csv latin-1 header", csv_bytes(lambda lines: [lines[0].replace(b"force_x", b"force_\xe9x")] + lines[1:]),
         "c.csv: not UTF-8 text: byte 0xe9 at line 1"),
        ("csv trailing comma on one row", csv_bytes(lambda lines: lines[:40] + [lines[40] + b","] + lines[41:]),
         "c.csv: malformed CSV: line 41 has 6 fields"),
        ("csv value after the last column", csv_bytes(lambda lines: [lines[0]] + [line + b",1" for line in lines[1:]]),
         "c.csv: malformed CSV: rows have a value after the last"),
        ("csv byte-order mark", csv_bytes(lambda lines: [b"\xef\xbb\xbf" + lines[0]] + lines[1:]), None),
        ("csv trailing comma everywhere", csv_bytes(lambda lines: [line + b"," for line in lines]), None),
    ]


def _signals_attr(key, value):
    return lambda fh: fh["signals"].attrs.__setitem__(key, value)


def _units(name, value):
    return lambda fh: fh["signals"][name].attrs.__setitem__("units", value)


def _replace_force_x(fh, link):
    del fh["signals/force_x"]
    fh["signals/force_x"] = link


def _external_channel(fh):
    _replace_force_x(fh, h5py.ExternalLink("missing.h5", "/force_x"))


def _external_signals(fh):
    del fh["signals"]
    fh["signals"] = h5py.ExternalLink("missing.h5", "/signals")


def _soft_channel(fh):
    _replace_force_x(fh, h5py.SoftLink("/nowhere"))


def _virtual_channel(fh):
    n = fh["signals/force_x"].shape[0]
    del fh["signals/force_x"]
    layout = h5py.VirtualLayout(shape=(n,), dtype="f8")
    layout[:] = h5py.VirtualSource("missing_source.h5", "/force_x", shape=(n,))
    fh["signals"].create_virtual_dataset("force_x", layout, fillvalue=0.0).attrs["units"] = "N"


def _external_raw_channel(fh):
    n = fh["signals/force_x"].shape[0]
    del fh["signals/force_x"]
    raw = str(Path(fh.filename).parent / "missing_raw.bin")
    fh["signals"].create_dataset("force_x", shape=(n,), dtype="f8", external=[(raw, 0, 8 * n)]).attrs["units"] = "N"


READ_CASES = _reading_cases()


def _truncate(path):
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    return str(path)


def _sparse_huge(fh):
    units = fh["signals/accel_tangential"].attrs["units"]
    del fh["signals/accel_tangential"]
    fh["signals"].create_dataset("accel_tangential", shape=(3_000_000_000,), dtype="f8")
    fh["signals/accel_tangential"].attrs["units"] = units


def _scaled(rec, name, factor):
    return replace(rec, channels={**rec.channels, name: rec.channels[name] * factor})


def _head(rec, n):
    return replace(rec, channels={k: v[:n] for k, v in rec.channels.items()})


def _swap(rec):
    return replace(rec, channels={**rec.channels, "force_x": rec.channels["force_y"],
                                  "force_y": rec.channels["force_x"]})


FILE_CASES = _file_cases()


def _run(argv, capsys):
    code = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return code, captured.err


def _assert_contract(code, err, token, allow_success):
    assert "Traceback" not in err
    lines = [line for line in err.splitlines() if line.strip()]
    assert all(line.startswith("impactid: ") for line in lines), err
    errors = [line for line in lines if line.startswith("impactid: error:")]
    if code == 0:
        assert allow_success, f"expected a failure, got success; stderr: {err}"
        assert not errors
        return
    assert code == 2, (code, err)
    assert len(errors) == 1 and lines[-1] == errors[0], err
    if token is not None:
        assert token in errors[0], errors[0]


@pytest.mark.parametrize("case", FILE_CASES, ids=[c[0] for c in FILE_CASES])
@pytest.mark.parametrize("command", ["events", pytest.param("estimate", marks=pytest.mark.slow)])
def test_broken_recordings(case, command, good, tmp_path, capsys):
    name, build, token = case
    inputs = tmp_path / "in"
    inputs.mkdir()
    path = build(inputs, good)
    before = _tree(inputs)
    outputs = tmp_path / "out"
    argv = [command, path, "--out", outputs / ("r.json" if command == "estimate" else "e.csv")]
    if command == "estimate":
        argv += ["--fix-n", "1.5"]
    code, err = _run(argv, capsys)
    _assert_contract(code, err, token, allow_success=token is None)
    assert _tree(inputs) == before  # inputs untouched
    if code != 0:
        assert not outputs.exists() or not any(outputs.iterdir())  # nothing half-written
    assert not list(tmp_path.rglob("*.tmp"))


def test_warnings_name_the_channels(good, tmp_path, capsys):
    """Swapped forces and an accelerometer in g are usable files that hide wrong answers: warned about."""
    swapped = _write(_swap(good), tmp_path / "sw.h5")
    code, err = _run(["events", swapped], capsys)
    assert code == 0 and "'force_x', 'force_y'" in err and "force balance" in err
    in_g = _write(_scaled(good, "accel_tangential", 1 / 9.80665), tmp_path / "g.h5")
    code, err = _run(["events", in_g, "--anchor", "cam-phase"], capsys)
    assert code == 0 and "channel 'accel_tangential'" in err and "units" in err
    slow_cam = _write(good, tmp_path / "cam.h5", lambda fh: fh["operating"].attrs.__setitem__("cam_speed_hz", 15.3))
    code, err = _run(["info", slow_cam], capsys)
    assert code == 0 and "'cam_angle' turns at 15 Hz" in err


def test_units_are_case_sensitive_and_scaled_integers_are_calibrated(good, tmp_path):
    from impactid.io import read_recording

    path = _write(good, tmp_path / "mn.h5", lambda fh: fh["signals/force_x"].attrs.__setitem__("units", "MN"))
    assert np.allclose(read_recording(path)["force_x"], good["force_x"] * 1e6)  # meganewton, not millinewton
    path = _write(good, tmp_path / "mn2.h5", lambda fh: fh["signals/force_x"].attrs.__setitem__("units", "mN"))
    assert np.allclose(read_recording(path)["force_x"], good["force_x"] * 1e-3)
    lsb = 0.01

    def as_codes(fh):
        units = fh["signals/force_y"].attrs["units"]
        del fh["signals/force_y"]
        fh["signals"].create_dataset("force_y", data=np.round(good["force_y"] / lsb).astype(np.int32))
        fh["signals/force_y"].attrs["units"] = units
        fh["signals/force_y"].attrs["scale"] = lsb

    back = read_recording(_write(good, tmp_path / "codes.h5", as_codes))
    assert np.max(np.abs(back["force_y"] - good["force_y"])) <= lsb / 2 + 1e-12
    assert any("calibrated" in step for step in back.provenance)


def _argument_cases():
    """(id, argv after the command's recording, token)."""
    return [
        ("rig file binary", ["events", "{rec}", "--rig", "{binary_toml}"], "binary.toml: not a TOML rig file"),
        ("rig file is a recording", ["events", "{rec}", "--rig", "{rec}"], "is an HDF5 file, not a TOML rig file"),
        ("rig file dangling link", ["events", "{rec}", "--rig", "{dangling_toml}"], "link.toml: is a symbolic link"),
        ("rig file cam speed 1e12", ["events", "{rec}", "--rig", "{fast_toml}"],
         "fast.toml [operating] cam_speed_hz = 1e+12 Hz"),
        ("info rig file binary", ["info", "{rec}", "--rig", "{binary_toml}"], "binary.toml: not a TOML rig file"),
        ("estimate one file twice", ["estimate", "{rec}", "{rec}", "--fix-n", "1.5"], "given twice"),
        ("estimate a link to it", ["estimate", "{rec}", "{rec_link}", "--fix-n", "1.5"], "given twice"),
        ("estimate a copy of it", ["estimate", "{rec}", "{rec_copy}", "--fix-n", "1.5"], "identical contents"),
        ("fix-n negative", ["estimate", "{rec}", "--fix-n", "-1"], "argument --fix-n"),
        ("fix-n nan", ["estimate", "{rec}", "--fix-n", "nan"], "argument --fix-n"),
        ("fix-n inf", ["estimate", "{rec}", "--fix-n", "inf"], "argument --fix-n"),
        ("fix-n text", ["estimate", "{rec}", "--fix-n", "one"], "argument --fix-n"),
        ("n-range reversed", ["estimate", "{rec}", "--n-range", "2.5", "0.5"], "argument --n-range"),
        ("n-range empty", ["estimate", "{rec}", "--n-range", "1", "1"], "argument --n-range"),
        ("grid huge", ["estimate", "{rec}", "--grid", "100000,100000"], "argument --grid"),
        ("grid tiny", ["estimate", "{rec}", "--grid", "2"], "argument --grid"),
        ("grid text", ["estimate", "{rec}", "--grid", "many"], "argument --grid"),
        ("unknown residual", ["estimate", "{rec}", "--residual", "lambda9"], "argument --residual"),
        ("unknown integration", ["events", "{rec}", "--integration", "euler"], "argument --integration"),
        ("unknown anchor", ["events", "{rec}", "--anchor", "moon"], "argument --anchor"),
        ("negative threshold", ["events", "{rec}", "--threshold", "-3"], "argument --threshold"),
        ("estimate nothing", ["estimate"], "give one or more recordings"),
        ("events nothing", ["events"], "no recording given"),
        ("example and file", ["events", "{rec}", "--example"], "not both"),
        ("unknown command", ["frobnicate"], "argument command"),
        ("no command", [], "required: command"),
        ("unknown option", ["events", "{rec}", "--frob"], "unrecognized arguments"),
        ("rig file missing", ["events", "{rec}", "--rig", "{tmp}/none.toml"], "none.toml: rig file not found"),
        ("rig file malformed", ["events", "{rec}", "--rig", "{bad_toml}"], "bad.toml"),
        ("regime speed nan", ["regime", "--cam-speed", "nan"], "argument --cam-speed"),
        ("regime speed zero", ["regime", "--cam-speed", "0"], "argument --cam-speed"),
        ("regime no speed", ["regime"], "no cam speed"),
        ("regime ratio too big", ["regime", "--cam-speed", "16", "--e-over-rc", "1.5"], "smaller than the cam radius"),
        ("regime flat rig", ["regime", "--cam-speed", "2", "--rig", "flat-follower"], "argument --rig"),
        ("regime-map empty speeds", ["regime-map", "--cam-speeds", "4:4:0", "--out", "{tmp}/map"], "--cam-speeds"),
        ("regime-map blank speeds", ["regime-map", "--cam-speeds", ",", "--out", "{tmp}/map"], "--cam-speeds"),
        ("regime-map negative speed", ["regime-map", "--cam-speeds", "-4,5", "--out", "{tmp}/map"], "--cam-speeds"),
        ("regime-map too many", ["regime-map", "--cam-speeds", "1:30:9000", "--e-over-rc-values", "0.1:0.2:9",
                                 "--out", "{tmp}/map"], "operating points"),
        ("bifurcation one number law", ["bifurcation", "--restitution-law", "0.6", "--out", "{tmp}/b"],
         "argument --restitution-law"),
        ("bifurcation reversed", ["bifurcation", "--from", "160", "--to", "110", "--out", "{tmp}/b"], "--from/--to"),
        ("bifurcation one speed", ["bifurcation", "--speeds", "1", "--out", "{tmp}/b"], "argument --speeds"),
        ("bifurcation restitution 2", ["bifurcation", "--restitution", "2", "--out", "{tmp}/b"],
         "argument --restitution"),
        ("bifurcation pivoted rig", ["bifurcation", "--rig", "pivoted-follower", "--out", "{tmp}/b"], "argument --rig"),
        ("synth negative duration", ["synth", "--cam-speed", "16", "--duration", "-1", "--out", "{tmp}/s.h5"],
         "argument --duration"),
        ("synth noise 2", ["synth", "--cam-speed", "16", "--noise", "2", "--out", "{tmp}/s.h5"], "argument --noise"),
        ("synth adc 1 bit", ["synth", "--cam-speed", "16", "--adc-bits", "1", "--out", "{tmp}/s.h5"],
         "argument --adc-bits"),
        ("synth decimate 0", ["synth", "--cam-speed", "16", "--decimate", "0", "--out", "{tmp}/s.h5"],
         "argument --decimate"),
        ("synth too long", ["synth", "--cam-speed", "16", "--duration", "1e6", "--out", "{tmp}/s.h5"],
         "samples to generate"),
        ("synth bad noise channel", ["synth", "--cam-speed", "16", "--noise-channel", "force_x", "--out",
                                     "{tmp}/s.h5"], "argument --noise-channel"),
        ("synth no speed", ["synth", "--out", "{tmp}/s.h5"], "no cam speed"),
        ("simulate zero duration", ["simulate", "--cam-speed", "16", "--duration", "0"], "argument --duration"),
        ("simulate n huge", ["simulate", "--cam-speed", "16", "--n", "50"], "argument --n"),
        ("detachment missing rig", ["detachment", "--rig", "{tmp}/none.toml"], "none.toml"),
        ("detachment rig folder", ["detachment", "--rig", "{tmp}"], "rig file"),
        ("cam-fit terms 0", ["cam-fit", "{rec}", "--terms", "0"], "argument --terms"),
        ("cam-fit window reversed", ["cam-fit", "{rec}", "--window", "5,1"], "argument --window"),
        ("cam-fit on rig P", ["cam-fit", "{rec}"], "{rec}"),
        ("restitution missing profile", ["restitution", "{rec}", "--profile", "{tmp}/none.json"], "none.json"),
        ("restitution nothing", ["restitution"], "give one impacting encoder recording"),
    ]


ARG_CASES = _argument_cases()

#: Inputs some argument cases name, made when a case names them: (tmp, rec) -> path.
EXTRA_INPUTS = {
    "binary_toml": lambda tmp, rec: _bytes_file(tmp / "binary.toml", bytes(range(256))),
    "dangling_toml": lambda tmp, rec: _symlink(tmp / "link.toml", tmp / "gone.toml"),
    "fast_toml": lambda tmp, rec: save_rig_toml(RIG, tmp / "fast.toml", {"cam_speed_hz": 1e12}),
    "rec_link": lambda tmp, rec: _symlink(tmp / "r_link.h5", rec),
    "rec_copy": lambda tmp, rec: _copy(rec, tmp / "copy"),
}


def _bytes_file(path, content):
    path.write_bytes(content)
    return path


def _symlink(path, target):
    path.symlink_to(target)
    return path


@pytest.mark.parametrize("case", ARG_CASES, ids=[c[0] for c in ARG_CASES])
def test_bad_arguments(case, good_files, tmp_path, capsys):
    name, argv, token = case
    rec = _copy(good_files["h5"], tmp_path)
    bad_toml = tmp_path / "bad.toml"
    bad_toml.write_text("[rig\nmodel = ")
    fill = {"rec": str(rec), "tmp": str(tmp_path), "bad_toml": str(bad_toml)}
    for key, make in EXTRA_INPUTS.items():
        if any(f"{{{key}}}" in a for a in argv):
            (tmp_path / "copy").mkdir(exist_ok=True)
            fill[key] = str(make(tmp_path, rec))
    argv = [a.format(**fill) for a in argv]
    before = _tree(tmp_path)
    code, err = _run(argv, capsys)
    _assert_contract(code, err, token.format(**fill), allow_success=False)
    assert _tree(tmp_path) == before


def _output_cases():
    """(id, argv builder (tmp, rec, rig_toml, csv) -> argv, token)."""
    def fifo(tmp):
        path = tmp / "pipe"
        os.mkfifo(path)
        return path

    def link(tmp):
        target = tmp / "target.json"
        target.write_text("{}")
        path = tmp / "link.json"
        path.symlink_to(target)
        return path

    def plain(tmp):
        path = tmp / "plain.txt"
        path.write_text("keep me")
        return path

    return [
        ("out is a folder", lambda t, r, g, c: ["estimate", r, "--fix-n", "1.5", "--out", t], "is a folder"),
        ("out under a file", lambda t, r, g, c: ["estimate", r, "--fix-n", "1.5", "--out", plain(t) / "x.json"],
         "not a folder"),
        ("out is the input", lambda t, r, g, c: ["estimate", r, "--fix-n", "1.5", "--out", r], "is an input"),
        ("events out is the input", lambda t, r, g, c: ["events", r, "--out", r], "is an input"),
        ("out is the rig file", lambda t, r, g, c: ["estimate", r, "--rig", g, "--fix-n", "1.5", "--out", g],
         "is an input"),
        ("out is the csv rig file", lambda t, r, g, c: ["events", c, "--out", Path(c).with_suffix(".toml")],
         "is an input"),
        ("out is a symlink", lambda t, r, g, c: ["events", r, "--out", link(t)], "symbolic link"),
        ("out is a fifo", lambda t, r, g, c: ["events", r, "--out", fifo(t)], "special file"),
        ("plots is a file", lambda t, r, g, c: ["estimate", r, "--fix-n", "1.5", "--plots", plain(t)],
         "not a folder"),
        ("synth out is the rig", lambda t, r, g, c: ["synth", "--rig", g, "--cam-speed", "15", "--out", g],
         "is an input"),
        ("simulate out is the rig", lambda t, r, g, c: ["simulate", "--rig", g, "--cam-speed", "15", "--out", g],
         "is an input"),
        ("regime-map out is a file", lambda t, r, g, c: ["regime-map", "--out", plain(t)], "not a folder"),
        ("bifurcation out is a file", lambda t, r, g, c: ["bifurcation", "--out", plain(t)], "not a folder"),
        ("cam-fit out is the input", lambda t, r, g, c: ["cam-fit", r, "--out", r], "is an input"),
        ("info on a fifo", lambda t, r, g, c: ["info", fifo(t)], "pipe"),
    ]


OUTPUT_CASES = _output_cases()


@pytest.mark.parametrize("case", OUTPUT_CASES, ids=[c[0] for c in OUTPUT_CASES])
def test_bad_outputs(case, good_files, tmp_path, capsys):
    name, build, token = case
    rec = _copy(good_files["h5"], tmp_path)
    rig_toml = save_rig_toml(RIG, tmp_path / "rig.toml", {"cam_speed_hz": 15.0})
    csv = _copy(good_files["csv"], tmp_path)
    _copy(good_files["csv_rig"], tmp_path)
    argv = [str(a) for a in build(tmp_path, str(rec), str(rig_toml), str(csv))]
    before = _tree(tmp_path)
    started = time.process_time()  # CPU seconds of this process: the same on an idle or a loaded machine
    code, err = _run(argv, capsys)
    _assert_contract(code, err, token, allow_success=False)
    assert _tree(tmp_path) == before
    assert time.process_time() - started < 30  # refused before the computation, not after it


@pytest.mark.skipif(os.geteuid() == 0, reason="root may write into a read-only folder")
def test_out_under_read_only_folder(good, tmp_path, capsys):
    rec = _write(good, tmp_path / "r.h5")
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        code, err = _run(["events", rec, "--out", locked / "e.csv"], capsys)
        _assert_contract(code, err, "not writable", allow_success=False)
    finally:
        locked.chmod(0o700)


@pytest.mark.parametrize("case", READ_CASES, ids=[c[0] for c in READ_CASES])
def test_info_refuses_what_the_reader_refuses(case, good, tmp_path, capsys):
    """``impactid info`` validates a recording: the cases refused where a file is read are refused
    there too (naming the file and the attribute, channel or line), the harmless ones are read."""
    name, build, token = case
    inputs = tmp_path / "in"
    inputs.mkdir()
    path = build(inputs, good)
    before = _tree(inputs)
    code, err = _run(["info", path], capsys)
    if token is None:
        assert code == 0 and "Traceback" not in err, err
    else:
        _assert_contract(code, err, token, allow_success=False)
        assert Path(path).name in err
    assert _tree(inputs) == before


def _environment_cases():
    """(id, environment, argv builder (rec, out) -> argv, token): a job larger than the memory it may use
    is refused before anything is allocated, naming the file, the estimate and the limit."""
    small = {"IMPACTID_MEMORY_LIMIT": "1e6"}
    return [
        ("info over the memory limit", small, lambda r, o: ["info", r], "reading it needs about"),
        ("events over the memory limit", small, lambda r, o: ["events", r, "--out", o],
         "finding and reconstructing its events needs"),
        ("estimate over the memory limit", small, lambda r, o: ["estimate", r, "--fix-n", "1.5", "--out", o],
         "the estimate needs"),
        ("estimate just over the limit", {"IMPACTID_MEMORY_LIMIT": "2e7"},  # 9 x 2.6 MB as float64
         lambda r, o: ["estimate", r, "--fix-n", "1.5", "--out", o],
         "more than the 20 MB available (IMPACTID_MEMORY_LIMIT)"),
        ("memory limit not a number", {"IMPACTID_MEMORY_LIMIT": "lots"}, lambda r, o: ["info", r],
         "IMPACTID_MEMORY_LIMIT='lots'"),
        ("memory limit negative", {"IMPACTID_MEMORY_LIMIT": "-5"}, lambda r, o: ["events", r, "--out", o],
         "IMPACTID_MEMORY_LIMIT='-5'"),
    ]


ENVIRONMENT_CASES = _environment_cases()


@pytest.mark.parametrize("case", ENVIRONMENT_CASES, ids=[c[0] for c in ENVIRONMENT_CASES])
def test_memory_limit(case, good_files, tmp_path, capsys, monkeypatch):
    name, environment, build, token = case
    rec = _copy(good_files["h5"], tmp_path)
    for key, value in environment.items():
        monkeypatch.setenv(key, value)
    before = _tree(tmp_path)
    code, err = _run(build(str(rec), str(tmp_path / "out" / "result")), capsys)
    _assert_contract(code, err, token, allow_success=False)
    assert f"{rec}: " in err or "IMPACTID_MEMORY_LIMIT=" in err
    assert _tree(tmp_path) == before and not (tmp_path / "out").exists()


def test_case_count():
    """The corpus: every broken or degenerate input, argument, output path and environment, counted
    (a floor at the present size, so that a case is never dropped unnoticed)."""
    assert len(FILE_CASES) + len(ARG_CASES) + len(OUTPUT_CASES) + len(ENVIRONMENT_CASES) >= 143


@pytest.mark.slow
def test_rig_file_operating_point_reaches_every_command(good, tmp_path, capsys):
    """One rig resolver: a CSV's --rig TOML with [operating] cam_speed_hz works for events and estimate alike."""
    csv, sibling = write_csv(replace(good, source=""), tmp_path / "c.csv")
    sibling.unlink()
    rig_toml = save_rig_toml(RIG, tmp_path / "rig.toml", {"cam_speed_hz": 15.0})
    assert main(["events", str(csv), "--rig", str(rig_toml)]) == 0
    assert main(["estimate", str(csv), "--rig", str(rig_toml), "--fix-n", "1.5"]) == 0
    capsys.readouterr()
    assert main(["regime", "--rig", str(rig_toml), "--json", "--max-revolutions", "300"]) == 0  # speed from the file
    assert json.loads(capsys.readouterr().out)["regime"] == "period-1"


@pytest.mark.slow
def test_outputs_get_the_umask_permissions(good, tmp_path):
    rec = _write(good, tmp_path / "r.h5")
    old = os.umask(0o022)
    try:
        assert main(["estimate", str(rec), "--fix-n", "1.5", "--out", str(tmp_path / "r.json"),
                     "--plots", str(tmp_path / "fig")]) == 0
        assert main(["events", str(rec), "--out", str(tmp_path / "e.csv")]) == 0
        assert main(["synth", "--cam-speed", "15", "--duration", "0.05", "--settle", "0.5",
                     "--out", str(tmp_path / "s.h5")]) == 0
    finally:
        os.umask(old)
    for path in [tmp_path / "r.json", tmp_path / "e.csv", tmp_path / "s.h5", *sorted((tmp_path / "fig").iterdir())]:
        assert path.stat().st_mode & 0o777 == 0o644, path


@pytest.mark.slow
def test_non_finite_results_are_null_in_json_and_undetermined_in_text(good, tmp_path, capsys, monkeypatch):
    """A non-finite standard error (one impact with a determined xi) is written as null with the reason."""
    import impactid.rigs.pivoted.estimation as P  # rig P's estimate (the restitution fit)

    real = P.fit_restitution

    def one_impact(frame, k_H, **kw):
        frame = frame.copy()
        frame.loc[frame.index[1:], "xi"] = np.nan
        return real(frame, k_H, **kw)

    monkeypatch.setattr(P, "fit_restitution", one_impact)
    rec = _write(good, tmp_path / "r.h5")
    out = tmp_path / "r.json"
    assert main(["estimate", str(rec), "--fix-n", "1.5", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    data = json.loads(out.read_text())
    assert data["params"]["gamma"]["stderr"] is None
    assert data["params"]["gamma"]["note"], data["params"]["gamma"]  # the reason it is null
    assert "undetermined" not in text, text  # issue 28: a missing error reads n/a with its reason
    assert "n/a (" in text, text


def test_restitution_failure_keeps_the_damping_estimate(good, tmp_path, capsys, monkeypatch):
    import impactid.rigs.pivoted.estimation as P  # rig P's estimate (the restitution fit)

    real = P.fit_restitution

    def no_xi(frame, k_H, **kw):
        frame = frame.copy()
        frame["xi"] = np.nan
        return real(frame, k_H, **kw)

    monkeypatch.setattr(P, "fit_restitution", no_xi)
    rec = _write(good, tmp_path / "r.h5")
    out = tmp_path / "r.json"
    assert main(["estimate", str(rec), "--fix-n", "1.5", "--out", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["params"]["beta"]["value"] == pytest.approx(24.7e9, rel=0.01)
    assert data["params"]["gamma"]["value"] is None and data["params"]["gamma"]["stderr"] is None
    assert any("restitution law not estimated" in w for w in data["notes"])
    text = capsys.readouterr().out
    assert "restitution law xi = 1 - gamma v_a: not estimated (" in text, text  # said, with the reason


@pytest.mark.slow
def test_interrupt_while_plotting_keeps_the_result_and_leaves_no_figure(good, tmp_path, capsys, monkeypatch):
    import impactid.reports as R
    import impactid.rigs.pivoted.figures as F

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    def save(fig, path, staged=None, fmt=None, **kw):
        return (staged.stage(path), interrupted())[0] if staged else interrupted()

    for module in (R, F):  # the writer, and the name rig P's figures call it by
        monkeypatch.setattr(module, "save_figure_atomic", save)
    rec = _write(good, tmp_path / "r.h5")
    code = main(["estimate", str(rec), "--fix-n", "1.5", "--out", str(tmp_path / "r.json"),
                 "--plots", str(tmp_path / "fig")])
    err = capsys.readouterr().err
    assert code == 130 and err.strip().splitlines()[-1].startswith("impactid: error: interrupted")
    assert json.loads((tmp_path / "r.json").read_text())["params"]["beta"]["value"] > 0  # the result was written first
    assert not (tmp_path / "fig").exists() or not any((tmp_path / "fig").iterdir())
    assert not list(tmp_path.rglob("*.tmp"))


def _impactid(*argv, **kwargs):
    return subprocess.Popen([sys.executable, "-m", "impactid.cli", *map(str, argv)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, **kwargs)


def _cpu_seconds(pid: int) -> float:
    """User + system CPU time [s] of a running process, all its threads (``/proc/PID/stat``)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


@pytest.mark.slow
def test_ctrl_c_during_a_grid_search(good, tmp_path):
    rec = _write(good, tmp_path / "r.h5")
    proc = _impactid("estimate", rec, "--grid", "300,300", "--progress", "--out", tmp_path / "r.json")
    # interrupt once the search has started (its progress line says so), however long the imports
    # and the reading take on a loaded machine
    seen, deadline = b"", time.time() + 180
    while b"search" not in seen and time.time() < deadline and proc.poll() is None:
        seen += os.read(proc.stderr.fileno(), 256)
    assert b"search" in seen and proc.poll() is None, seen
    time.sleep(0.5)
    # the response is measured in CPU seconds the process spends after the signal, not wall time:
    # on a loaded machine a chunk of compiled batches takes longer to finish on the clock, not in CPU
    children_before = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu_at_signal = _cpu_seconds(proc.pid)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)  # a hang guard, not the measure
    children_after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu_total = ((children_after.ru_utime - children_before.ru_utime)
                 + (children_after.ru_stime - children_before.ru_stime))
    err = seen.decode() + err
    # the compiled batches run in chunks of about 0.2 s of CPU that see Ctrl-C between them
    assert cpu_total - cpu_at_signal < 5.0, (cpu_total, cpu_at_signal)
    assert proc.returncode == 130 and "Traceback" not in err
    assert err.strip().splitlines()[-1].startswith("impactid: error: interrupted")
    assert not (tmp_path / "r.json").exists() and not list(tmp_path.rglob("*.tmp"))


@pytest.mark.slow
def test_sigterm_while_writing_leaves_no_temporary_file(tmp_path):
    proc = _impactid("synth", "--cam-speed", "15", "--e-over-rc", "0.25", "--duration", "40", "--settle", "0",
                     "--out", tmp_path / "big.h5")
    deadline = time.time() + 120
    while time.time() < deadline and not list(tmp_path.glob(".big.h5.*.tmp")) and proc.poll() is None:
        time.sleep(0.05)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143 and "Traceback" not in err, err
    assert err.strip().splitlines()[-1].startswith("impactid: error: terminated")
    assert not list(tmp_path.iterdir())


@pytest.mark.slow
def test_two_estimates_writing_the_same_output(good, tmp_path):
    rec = _write(good, tmp_path / "r.h5")
    out = tmp_path / "same.json"
    procs = [_impactid("estimate", rec, "--fix-n", "1.5", "--out", out) for _ in range(2)]
    for proc in procs:
        _, err = proc.communicate(timeout=300)
        assert proc.returncode == 0, err
    assert json.loads(out.read_text())["params"]["n"]["value"] == 1.5
    assert not list(tmp_path.rglob("*.tmp"))

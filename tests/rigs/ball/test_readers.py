"""Every accepted layout is read to the same times; every bad file is one ImpactidError naming it."""

import zipfile

import numpy as np
import pytest

from impactid.rigs.ball import BounceFileError, read_bounces, read_many
from impactid.rigs.ball.readers import BounceRecording, time_resolution
from impactid.rigs.ball.synth import (
    java_scientific,
    write_event_csv,
    write_phyphox_csv,
    write_phyphox_xlsx,
    write_wav,
)

TIMES = np.round(np.cumsum([0.69435, 0.2769, 0.26213, 0.24748, 0.23475, 0.22304]) * 48000) / 48000


def test_java_scientific_is_phyphox_number_format():
    assert java_scientific(0.6943541667) == "6.943541667E-1"
    assert java_scientific(12.5, ",") == "1,250000000E1"
    assert java_scientific(0.0) == "0.000000000E0"
    assert java_scientific(float("nan")) == "NaN"


def test_xlsx_round_trip(tmp_path):
    path = write_phyphox_xlsx(tmp_path / "drop.xlsx", TIMES)
    rec = read_bounces(path)
    assert rec.format == "phyphox-xlsx"
    assert rec.times == pytest.approx(TIMES, abs=1e-12)
    assert rec.resolution == pytest.approx(1 / 48000)
    assert any("sheet 'All'" in step for step in rec.provenance)
    assert not rec.notes


@pytest.mark.parametrize("separator,decimal", [(",", "."), ("\t", "."), (";", "."), ("\t", ","), (";", ",")])
@pytest.mark.parametrize("zipped", [False, True])
def test_every_phyphox_csv_flavour(tmp_path, separator, decimal, zipped):
    path = write_phyphox_csv(tmp_path / ("d.zip" if zipped else "d.csv"), TIMES, separator=separator,
                             decimal=decimal, zipped=zipped)
    rec = read_bounces(path)
    assert rec.format == "phyphox-csv"
    assert rec.times == pytest.approx(TIMES, abs=1e-9)  # phyphox writes 10 significant digits


@pytest.mark.parametrize("text,factor", [
    ("{t}", 1.0),                                   # one column, no header
    ("time (s)\n{t}", 1.0),                          # header with unit
    ("t [ms]\n{ms}", 1.0),                           # milliseconds
    ("time_ms\n{ms}", 1.0),
    ("# comment\nonset\n{t}", 1.0),
    ("index;time (s)\n{semi}", 1.0),                 # several columns, semicolon, decimal comma
])
def test_plain_csv_layouts(tmp_path, text, factor):
    t_lines = "\n".join(repr(float(t)) for t in TIMES)
    ms_lines = "\n".join(repr(float(t) * 1000) for t in TIMES)
    semi = "\n".join(f"{i};{str(float(t)).replace('.', ',')}" for i, t in enumerate(TIMES))
    path = tmp_path / "times.csv"
    path.write_text(text.format(t=t_lines, ms=ms_lines, semi=semi))
    rec = read_bounces(path)
    assert rec.times == pytest.approx(TIMES * factor, abs=1e-9)


def test_event_csv_writer_round_trip(tmp_path):
    assert read_bounces(write_event_csv(tmp_path / "a.csv", TIMES)).times == pytest.approx(TIMES)
    assert read_bounces(write_event_csv(tmp_path / "b.txt", TIMES, header=None)).times == pytest.approx(TIMES)


def test_interval_column_disagreement_is_a_note(tmp_path):
    path = tmp_path / "d.csv"
    rows = ['"Event time (s)","Interval (s)"'] + [f"{t},{0.5}" for t in TIMES]
    path.write_text("\n".join(rows))
    rec = read_bounces(path)
    assert any("interval column disagrees" in n for n in rec.notes)


def test_time_resolution():
    assert time_resolution(TIMES) == pytest.approx(1 / 48000)
    assert np.isnan(time_resolution(TIMES + 1e-7))


def test_read_many_and_from_times(tmp_path):
    recs = read_many([write_event_csv(tmp_path / f"{i}.csv", TIMES + i) for i in range(3)])
    assert [r.times[0] for r in recs] == pytest.approx(TIMES[0] + np.arange(3))
    assert BounceRecording.from_times(TIMES).format == "array"
    with pytest.raises(BounceFileError, match="no files"):
        read_many([])


def _xlsx_without_all(tmp_path):
    import pandas as pd

    path = tmp_path / "noall.xlsx"
    with pd.ExcelWriter(path, engine="openpyxl") as writer:
        pd.DataFrame({"Note": ["no", "times", "here"]}).to_excel(writer, sheet_name="Simple", index=False)
    return path


def _xlsx_no_time(tmp_path):
    import pandas as pd

    path = tmp_path / "notime.xlsx"
    with pd.ExcelWriter(path, engine="openpyxl") as writer:
        pd.DataFrame({"Loudness": TIMES}).to_excel(writer, sheet_name="All", index=False)
    return path


def _xlsx_values(tmp_path, values, name="v.xlsx"):
    import pandas as pd

    path = tmp_path / name
    with pd.ExcelWriter(path, engine="openpyxl") as writer:
        pd.DataFrame({"Event time (s)": values, "Interval (s)": np.zeros(len(values))}).to_excel(
            writer, sheet_name="All", index=False)
    return path


def _wav(tmp_path, samples, name, rate=48000, encoding="int16"):
    return write_wav(tmp_path / name, samples, rate, encoding)


BAD_FILES = [
    ("missing", lambda p: p / "nope.xlsx", "file not found"),
    ("folder", lambda p: p, "is a directory"),
    ("empty", lambda p: _text(p / "e.csv", ""), "empty file"),
    ("binary junk", lambda p: _bytes(p / "j.bin", bytes(range(256)) * 4), "not a spreadsheet, CSV or audio file"),
    ("xlsx that is text", lambda p: _text(p / "t.xlsx", "hello"), "not a XLSX file"),
    ("damaged xlsx", lambda p: _bytes(p / "d.xlsx", b"PK\x03\x04" + b"\x00" * 100), "zip"),
    ("damaged xls", lambda p: _bytes(p / "d.xls", b"\xd0\xcf\x11\xe0" + b"\x01" * 600), ".xls"),
    ("zip without All.csv", lambda p: _zip(p / "z.zip", {"Simple.csv": "a\n1\n", "Other.csv": "b\n2\n"}),
     "without 'All.csv'"),
    ("no All sheet", _xlsx_without_all, "no sheet 'All'"),
    ("no time column", _xlsx_no_time, "no time column"),
    ("csv without time column", lambda p: _text(p / "c.csv", "speed,height\n1,2\n3,4\n5,6\n"), "no time column"),
    ("non-monotonic", lambda p: _xlsx_values(p, [0.1, 0.5, 0.4, 0.9]), "not strictly increasing at sheet 'All', row 4"),
    ("repeated time", lambda p: _text(p / "r.csv", "0.1\n0.5\n0.5\n0.9\n"), "not strictly increasing"),
    ("NaN inside", lambda p: _xlsx_values(p, [0.1, np.nan, 0.5, 0.9]), "row 3: time is NaN"),
    ("text time", lambda p: _text(p / "x.csv", "time\n0.1\nabc\n0.9\n"), "'abc' is not a number"),
    ("two events", lambda p: _text(p / "two.csv", "0.1\n0.5\n"), "only 2 event(s)"),
    ("header only", lambda p: _text(p / "h.csv", '"Event time (s)","Interval (s)"\n'), "no"),
    ("silent wav", lambda p: _wav(p, np.zeros(48000), "silent.wav"), "silent"),
    ("clipped wav", lambda p: _wav(p, np.sign(np.sin(np.arange(48000) * 0.01)) * 1.5, "clip.wav"), "clipped"),
    ("short wav", lambda p: _wav(p, np.random.default_rng(0).normal(0, 0.1, 500), "short.wav"), "too short"),
    ("noise-only wav", lambda p: _wav(p, np.random.default_rng(0).normal(0, 0.01, 48000), "noise.wav"),
     "impact click"),
    ("damaged wav", lambda p: _bytes(p / "bad.wav", b"RIFF\x10\x00\x00\x00WAVEfmt " + b"\x00" * 8), "WAV"),
]


def _text(path, text):
    path.write_text(text)
    return path


def _bytes(path, data):
    path.write_bytes(data)
    return path


def _zip(path, members):
    with zipfile.ZipFile(path, "w") as z:
        for name, text in members.items():
            z.writestr(name, text)
    return path


@pytest.mark.parametrize("case", BAD_FILES, ids=[c[0] for c in BAD_FILES])
def test_bad_files_raise_one_line_naming_the_file(tmp_path, case):
    _, build, token = case
    path = build(tmp_path)
    with pytest.raises(BounceFileError) as info:
        read_bounces(path)
    message = str(info.value)
    assert "\n" not in message
    assert str(path) in message
    assert token in message


@pytest.mark.parametrize("case", BAD_FILES, ids=[c[0] for c in BAD_FILES])
def test_bad_files_on_the_command_line(tmp_path, case, capsys):
    """The CLI contract for each bad file: exit status 2 and one line naming the file."""
    from impactid.cli import main

    _, build, token = case
    path = build(tmp_path)
    code = main(["bounces", str(path)])
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert code == 2
    assert len(lines) == 1 and lines[0].startswith("impactid: error: ") and str(path) in lines[0]
    assert "Traceback" not in err

"""Readers: Tracker exports, phyphox-like headers with units, plain tables, the SpinDOE layout with its
spin index; errors that name the file and the column."""

import numpy as np
import pytest

from impactid.rigs.tracks import TrackFileError, read_track
from impactid.rigs.tracks.readers import is_spin_index
from tests.rigs.tracks.conftest import write_track


def _rows(n=20):
    t = np.arange(n) / 100.0
    return t, np.column_stack([0.1 * t, -2.0 * t, 0.3 - 4.9 * t ** 2])


def test_tracker_export_with_mass_line_and_decimal_commas(tmp_path):
    t, p = _rows()
    lines = ["mass A", "t\tx\ty"] + [f"{a:.3f}\t{b:.5f}\t{c:.5f}".replace(".", ",") for a, b, c in
                                     zip(t, p[:, 1], p[:, 2])]
    lines.insert(5, "0,040\t\t")  # a frame without a mark
    path = tmp_path / "tracker.txt"
    path.write_text("\n".join(lines) + "\n")
    track = read_track(path)
    assert track.dimensions == 2 and track.name == "mass A"
    assert np.allclose(track.position[:, 0], p[:, 1], atol=1e-5) and np.allclose(track.height, p[:, 2], atol=1e-5)
    assert np.all(track.position[:, 1] == 0.0)
    assert any("skipped" in n for n in track.notes)


def test_header_units_and_vertical_axis(tmp_path):
    t, p = _rows()
    path = write_track(tmp_path / "mocap.csv", t * 1e3, p, sep=",", header="Time (ms),Position x [mm],y/mm,Z (mm)",
                       scale=1e3)
    track = read_track(path)
    assert np.allclose(track.time, t) and np.allclose(track.position, p, atol=1e-8)
    turned = read_track(path, up="y")  # y up: the file's (x, y, z) become (z, x, y) inside
    assert np.allclose(turned.height, p[:, 1], atol=1e-8) and np.allclose(turned.position[:, 0], p[:, 2], atol=1e-8)


def test_columns_chosen_and_units_given(tmp_path):
    t, p = _rows()
    path = tmp_path / "lab.tsv"
    path.write_text("frame\tT\tposx\tposz\n" + "\n".join(f"{k}\t{a}\t{b * 100}\t{c * 100}" for k, (a, b, c) in
                                                           enumerate(zip(t, p[:, 0], p[:, 2]))))
    track = read_track(path, time="T", x="posx", z=4, length_unit="cm")
    assert track.dimensions == 2 and np.allclose(track.height, p[:, 2])
    assert track.columns == ("T", "posx", "posz")


def test_spindoe_layout_reads_its_spin(tmp_path):
    t, p = _rows()
    write_track(tmp_path / "007.csv", t, p)
    (tmp_path / "index.csv").write_text("traj_file,x_spin,y_spin,z_spin\n7,1.5,-200,30\n8,0,0,0\n")
    track = read_track(tmp_path / "007.csv")
    assert track.dimensions == 3 and track.spin == (1.5, -200.0, 30.0)
    assert is_spin_index(tmp_path / "index.csv") and not is_spin_index(tmp_path / "007.csv")
    assert read_track(tmp_path / "007.csv", spin=(1, 2, 3)).spin == (1.0, 2.0, 3.0)


@pytest.mark.parametrize("text, options, needles", [
    ("t,x,y\n" + "\n".join(f"{k},{k},{k}" for k in range(20)), {"z": "height"}, ("--z", "'height'", "columns")),
    ("a,b,c\n" + "\n".join(f"{k},{k},{k}" for k in range(20)), {}, ("no time column",)),
    ("t,x,y\n" + "\n".join(f"{k},{k},{k}" for k in range(5)), {}, ("5 samples",)),
    ("t,x [px],y [px]\n" + "\n".join(f"{k},{k},{k}" for k in range(20)), {}, ("column 'x [px]'", "pixels")),
    ("t,x,y\n" + "\n".join(f"{20 - k},{k},{k}" for k in range(20)), {}, ("time goes back",)),
    ("hello\nworld\n", {}, ("no rows of numbers",)),
    ("1;2;3;4;5\n" * 20, {}, ("5 columns without a header",)),
])
def test_errors_name_the_file_and_column(tmp_path, text, options, needles):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(TrackFileError) as info:
        read_track(path, **options)
    message = str(info.value)
    assert message.startswith(str(path)) and "\n" not in message
    for needle in needles:
        assert needle in message, message


def test_missing_and_binary_files(tmp_path):
    with pytest.raises(TrackFileError, match="no such file"):
        read_track(tmp_path / "absent.csv")
    (tmp_path / "b.csv").write_bytes(b"\xff\xfe\x00\x81" * 50)
    with pytest.raises(TrackFileError, match="not a text table"):
        read_track(tmp_path / "b.csv")

"""``impactid synth --rig tracked-ball``: its tracks against the independent reference, read back and
analysed by ``impactid tracks analyse`` (the law recovered within its interval), and its refusals."""

import json

import numpy as np
import pytest

from impactid.cli import main
from impactid.results import FitResult
from impactid.rigs.tracks import TABLE_TENNIS_BALL, read_track
from impactid.rigs.tracks.synth import synth_track, track_text
from tests.cli_contract import fails_with_one_line
from tests.rigs.tracks.reference_tracks import RADIUS, bouncing_track


@pytest.mark.parametrize("spin, dimensions", [((0.0, -120.0, 0.0), 2), ((-80.0, 30.0, 40.0), 3)])
def test_synthetic_track_follows_the_reference(spin, dimensions):
    """Without noise, the package's flights and bounces give the reference's positions and impacts
    (the reference: SciPy's DOP853 at rtol 1e-12 and a rigid ball with friction written from the
    specification alone)."""
    height, speed, e_n, mu = 0.3, 1.2, 0.88, 0.2
    track = synth_track(height=height, horizontal_speed=speed, spin=spin, dimensions=dimensions, e0=e_n, gamma=0.0,
                        mu=mu, bounces=2, noise=0.0)
    times, pos, truth = bouncing_track(np.array([0.0, 0.0, height + RADIUS]), np.array([speed, 0.0, 0.0]),
                                       np.array(spin), e_n=e_n, mu=mu, duration=5.0, rate=240.0, bounces=2)
    n = min(times.size, track.time.size)
    assert abs(times.size - track.time.size) <= 1 and n > 200
    np.testing.assert_allclose(track.time[:n], times[:n], atol=1e-12)
    assert np.max(np.abs(track.exact[:n] - pos[:n])) < 1e-9  # 3e-12 m measured
    assert len(truth) == track.impact_times.size == 2
    for k, (t, v_in, v_out, w_in, w_out) in enumerate(truth):
        assert abs(track.impact_times[k] - t) < 1e-8
        np.testing.assert_allclose(track.velocity_in[k], v_in, atol=1e-8)
        np.testing.assert_allclose(track.velocity_out[k], v_out, atol=1e-8)
        np.testing.assert_allclose(track.spin_in[k], w_in, atol=1e-6)
        np.testing.assert_allclose(track.spin_out[k], w_out, atol=1e-6)


def test_written_track_reads_back(tmp_path):
    """Each format reads back as the positions written (to the file's 0.1 um), with its units."""
    track = synth_track(height=0.2, horizontal_speed=0.7, spin=(1.0, 2.0, 3.0), dimensions=3, noise=1e-3, seed=4,
                        bounces=1)
    for suffix in (".csv", ".tsv", ".txt"):
        path = tmp_path / f"t{suffix}"
        path.write_text(track_text(track, suffix, name="ball A"))
        read = read_track(path)
        assert read.dimensions == 3 and read.time.size == track.time.size
        assert np.max(np.abs(read.position - track.position)) < 1e-7
        assert any("assumed" in note for note in read.notes) == (suffix == ".txt")  # a Tracker export has no units
    flat = synth_track(height=0.2, spin=(0.0, -50.0, 0.0), dimensions=2, noise=0.0, bounces=1)
    path = tmp_path / "flat.csv"
    path.write_text(track_text(flat, ".csv"))
    read = read_track(path, spin=(50.0,))  # counter-clockwise in the file's x-y plane: -y inside
    assert read.dimensions == 2 and read.spin == (0.0, -50.0, 0.0)
    np.testing.assert_allclose(read.position[:, [0, 2]], flat.exact[:, [0, 2]], atol=1e-7)


def test_synth_then_analyse_recovers_the_law(tmp_path, capsys):
    """Three single-bounce tracks with backspin (the bounces slide) from ``synth``, then ``tracks analyse``
    with the same spin: the normal restitution's and the friction's intervals hold the values made with."""
    files = []
    for seed, (height, speed) in enumerate(((0.2, 1.0), (0.3, 1.5), (0.45, 0.5)), start=1):
        out = tmp_path / f"track{seed}.csv"
        assert main(["synth", "--rig", "tracked-ball", "--height", str(height), "--horizontal-speed", str(speed),
                     "--spin", "150", "--bounce-law", "0.9,0", "--mu", "0.25", "--bounces", "1", "--seed", str(seed),
                     "--out", str(out)]) == 0
        files.append(str(out))
    assert "0 of 1 stick" in capsys.readouterr().out
    result_path, report = tmp_path / "tracks.json", tmp_path / "tracks.html"
    assert main(["tracks", "analyse", *files, "--spin", "150", "--no-air-share", "--out", str(result_path),
                 "--report", str(report)]) == 0
    text = capsys.readouterr().out
    assert "3 bounce(s) found, 3 analysed" in text and f"report written to {report}" in text
    result = FitResult.from_json(result_path)
    assert result["normal.constant.e"].contains(0.9)
    assert result["tangential.coulomb.mu"].contains(0.25)
    assert json.loads(result_path.read_text())["recordings_read"] == files
    page = report.read_text(encoding="utf-8")
    assert page.startswith("<!DOCTYPE html>") and "normal.constant.e" in page


def test_synth_defaults_make_an_analysable_track(tmp_path, capsys):
    """The defaults (a table-tennis ball from 30.5 cm, three bounces at 240 fps, 1 mm noise) as a Tracker export."""
    out = tmp_path / "ball.txt"
    assert main(["synth", "--rig", "table-tennis-ball", "--out", str(out)]) == 0
    assert "3 bounce(s)" in capsys.readouterr().out
    track = read_track(out)
    assert track.name and track.dimensions == 2 and 1.0 / np.median(np.diff(track.time)) == pytest.approx(240.0)
    assert np.min(track.height) == pytest.approx(TABLE_TENNIS_BALL.radius, abs=5e-3)


@pytest.mark.parametrize("extra, needles", [
    (["--out", "{tmp}/x.h5"], ("argument --out", ".csv, .tsv, .txt")),
    (["--bounce-law", "1.2,0"], ("argument --bounce-law",)),
    (["--bounce-law", "0.9,-0.1"], ("argument --bounce-law",)),
    (["--height", "0"], ("argument --height",)),
    (["--spin", "1,2"], ("argument --spin",)),
    (["--frame-rate", "1e7"], ("argument --frame-rate",)),
    (["--position-noise", "1"], ("argument --position-noise",)),
    (["--bounces", "0"], ("argument --bounces",)),
    (["--bounce-law", "0.3,0", "--bounces", "50"], ("--bounces", "comes to rest", "at most 7 bounces")),
    (["--noise", "0.01"], ("argument --noise: not an option", "--position-noise")),
    (["--sample-rate", "100"], ("argument --sample-rate: not an option", "--frame-rate")),
    (["--restitution", "0.8"], ("argument --restitution: not an option", "--bounce-law")),
    (["--ball", "golf"], ("argument --ball: not an option",)),
])
def test_bad_options_are_one_line_errors(tmp_path, capsys, extra, needles):
    out = tmp_path / "t.csv"
    argv = ["synth", "--rig", "tracked-ball", "--out", str(out), *(e.format(tmp=tmp_path) for e in extra)]
    fails_with_one_line(capsys, argv, *needles)
    assert not out.exists() and not (tmp_path / "x.h5").exists()

"""``impactid tracks analyse``: a synthetic 3-D track through the command, and hostile inputs."""

import json

import numpy as np
import pytest

from impactid.cli import main
from impactid.results import FitResult
from tests.cli_contract import fails_with_one_line
from tests.rigs.tracks.conftest import write_track
from tests.rigs.tracks.reference_tracks import bouncing_track
from tests.test_fit_json_schema import check_fit_document, check_identifiability, check_model_check


@pytest.fixture(scope="module")
def track_files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("tracks")
    rng = np.random.default_rng(5)
    lines = ["traj_file,x_spin,y_spin,z_spin"]
    for k in range(3):
        spin = rng.uniform(-150, 150, 3)
        v0 = np.array([rng.uniform(-0.3, 0.3), rng.uniform(-7, -5), rng.uniform(-1.5, -0.8)])
        t, p, _ = bouncing_track(np.array([0.0, 0.8, 0.3]), v0, spin, e_n=0.9, mu=0.25, duration=0.35, rate=200.0,
                                 noise=1e-3, seed=k, bounces=1)
        write_track(folder / f"{k:03d}.csv", t, p)
        lines.append(f"{k},{spin[0]},{spin[1]},{spin[2]}")
    (folder / "index.csv").write_text("\n".join(lines) + "\n")
    return folder


def test_analyse_writes_json_and_figures(track_files, tmp_path, capsys):
    out, plots = tmp_path / "r.json", tmp_path / "plots"
    files = sorted(str(p) for p in track_files.glob("*.csv"))  # index.csv included: skipped
    assert main(["tracks", "analyse", *files, "--out", str(out), "--plots", str(plots)]) == 0
    text = capsys.readouterr().out
    assert "3 bounce(s) found, 3 analysed" in text and "table-tennis rule" in text
    assert "air model C_D 0.4," in text and "lift_scale" in text  # the air model's share, the estimated lift
    data = json.loads(out.read_text())
    assert data["details"]["air_model"]["drag_range"] == [0.4, 0.5]
    for bounce in data["details"]["bounce_fits"]:
        air, stat = bounce["params"]["e_n_air"], bounce["params"]["e_n"]
        assert air["interval"][0] <= stat["interval"][0] and air["interval"][1] >= stat["interval"][1]
    assert data["details"]["spin_indexes_skipped"]
    check_fit_document(data, "tracked-ball-bounces", [f for f in files if not f.endswith("index.csv")])
    check_model_check(data["model_check"])
    check_identifiability(data["identifiability"])
    for bounce in data["details"]["bounce_fits"]:
        check_model_check(bounce["model_check"])
        check_identifiability(bounce["identifiability"])
    result = FitResult.from_json(out)
    assert type(result).__name__ == "TrackAnalysis"
    assert result["normal.constant.e"].contains(0.9)
    assert (plots / "tracks_restitution.png").is_file()


@pytest.mark.parametrize("extra, needles", [
    (["--units", "furlong"], ("--units", "furlong")),
    (["--z", "height"], ("--z", "height")),
    (["--drag-coefficient", "-1"], ("--drag-coefficient",)),
    (["--spin", "1,2"], ("--spin",)),
    (["--speed-band", "3,2"], ("--speed-band",)),
    (["--mass", "1e-9"], ("--mass", "lighter than the air")),
])
def test_hostile_options(track_files, tmp_path, capsys, extra, needles):
    out = tmp_path / "r.json"
    fails_with_one_line(capsys, ["tracks", "analyse", str(track_files / "000.csv"), "--out", str(out), *extra],
                        *needles)
    assert not out.exists()


def test_hostile_files(track_files, tmp_path, capsys):
    fails_with_one_line(capsys, ["tracks", "analyse", str(tmp_path / "absent.csv")], "absent.csv", "no such file")
    flat = write_track(tmp_path / "flat.csv", np.arange(30) / 100, np.zeros((30, 3)))
    out = tmp_path / "r.json"
    fails_with_one_line(capsys, ["tracks", "analyse", str(flat), "--out", str(out)], "no bounce")
    assert not out.exists()
    fails_with_one_line(capsys, ["tracks", "analyse", str(track_files / "index.csv")], "spin index")
    fails_with_one_line(capsys, ["tracks", "analyse", str(track_files / "000.csv"), "--out",
                                 str(track_files / "000.csv")], "--out")


def test_tracker_export_in_millimetres(tmp_path, capsys):
    """A 2-D Tracker export (first line naming the track, decimal commas, positions in mm) with two bounces."""
    t, p, truth = bouncing_track(np.array([0.0, 0.0, 0.5]), np.array([1.0, 0.0, 0.0]), np.zeros(3), e_n=0.9, mu=0.3,
                                 duration=1.2, rate=240.0, noise=5e-4, bounces=3)
    lines = ["mass A", "t\tx\ty"] + [f"{a:.4f}\t{b * 1000:.2f}\t{c * 1000:.2f}".replace(".", ",")
                                     for a, b, c in zip(t, p[:, 0], p[:, 2])]
    path = tmp_path / "tracker.txt"
    path.write_text("\n".join(lines) + "\n")
    out = tmp_path / "r.json"
    assert main(["tracks", "analyse", str(path), "--units", "mm", "--no-rule", "--out", str(out)]) == 0
    captured = capsys.readouterr()
    assert "2 bounce(s) found, 2 analysed" in captured.out and "warning" not in captured.err
    assert FitResult.from_json(out)["normal.constant.e"].contains(0.9)

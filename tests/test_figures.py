"""Every figure the package writes, read back through matplotlib's artists: both axes carry a label
with a unit in brackets (``[-]`` for a dimensionless quantity), and no label, title or legend shows an
internal name (``S1``, ``lambda1``, ``period1_end``, ``um``, an identifier joined by ``_``, ...); PNG
at 200 dpi, SVG and PDF written (docs/figures.md).

The figures are captured where they are saved (``Figure.savefig``), from the commands' ``--plots``
on small runs and from the figure functions on small results.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from impactid.cli import main

#: Internal names that must not reach a figure (whole words, outside mathtext).
BANNED_WORDS = ("S1", "S2", "S3", "lambda1", "lambda2", "lambda3", "period1_end", "um", "alpha_m", "hc", "xi",
                "beta", "gamma", "Omega", "theta_c", "theta_f")
#: Banned substrings.
BANNED_PARTS = ("(S-", "(R-", "^-(", "m^", "+/-")
#: An identifier joined by underscores (``fit_points``), outside mathtext and file names.
_IDENTIFIER = re.compile(r"\b[A-Za-z]+(?:_[A-Za-z0-9]+)+\b")
_UNIT = re.compile(r"\[[^\[\]]+\]\s*$")
_MATH = re.compile(r"\$[^$]*\$")
_FILE = re.compile(r"\S+\.(?:h5|hdf5|csv|txt|wav|toml|json)\b")


def _plain(text: str) -> str:
    """``text`` without its mathtext and file names (where symbols and file names are allowed)."""
    return _FILE.sub(" ", _MATH.sub(" ", text))


def _problems_of_text(text: str, where: str) -> list[str]:
    plain = _plain(text)
    out = [f"{where}: internal name {word!r} in {text!r}" for word in BANNED_WORDS
           if re.search(rf"(?<![\w-]){re.escape(word)}(?![\w-])", plain)]
    out += [f"{where}: {part!r} in {text!r}" for part in BANNED_PARTS if part in plain]
    out += [f"{where}: identifier {m.group(0)!r} in {text!r}" for m in _IDENTIFIER.finditer(plain)]
    return out


def _is_colorbar(ax) -> bool:
    return getattr(ax, "_colorbar", None) is not None


def figure_problems(fig, name: str) -> list[str]:
    """What a reviewer would send back: an axis without a unit, an internal name in a text."""
    problems = []
    texts = [(t.get_text(), "suptitle") for t in (fig._suptitle,) if t is not None]
    for k, ax in enumerate(fig.axes):
        where = f"{name} axes {k}"
        if not ax.axison and not _is_colorbar(ax):
            continue
        texts += [(ax.get_title(loc), f"{where} title") for loc in ("left", "center", "right")]
        texts += [(t.get_text(), f"{where} text") for t in ax.texts]
        if _is_colorbar(ax):
            label = ax.get_ylabel() or ax.get_xlabel()
            if not _UNIT.search(label):
                problems.append(f"{where}: colour bar label without a unit: {label!r}")
            texts.append((label, f"{where} colour bar"))
            continue
        ylabel, xlabel = ax.get_ylabel(), ax.get_xlabel()
        if not _UNIT.search(ylabel):
            problems.append(f"{where}: y label without a unit in brackets: {ylabel!r}")
        if not xlabel:  # shared x: the label is on a sibling (the bottom panel)
            siblings = ax.get_shared_x_axes().get_siblings(ax)
            xlabel = next((s.get_xlabel() for s in siblings if s.get_xlabel()), "")
        if not _UNIT.search(xlabel):
            problems.append(f"{where}: x label without a unit in brackets: {xlabel!r}")
        texts += [(ylabel, f"{where} y label"), (xlabel, f"{where} x label")]
        legends = [ax.get_legend()] + [a for a in ax.artists if type(a).__name__ == "Legend"]
        for legend in filter(None, legends):
            texts += [(t.get_text(), f"{where} legend") for t in legend.get_texts()]
            texts.append((legend.get_title().get_text(), f"{where} legend title"))
    for text, where in texts:
        problems += _problems_of_text(text, where)
    return problems


@pytest.fixture
def captured(monkeypatch):
    """The figures saved while the test runs, by file name."""
    from matplotlib.figure import Figure

    figures: dict[str, object] = {}
    save = Figure.savefig

    def savefig(self, fname, *args, **kwargs):
        name = Path(str(fname)).name.lstrip(".")  # a temporary name: the final one and a suffix
        match = re.match(r"(.+?\.(?:png|svg|pdf))", name)
        figures[match.group(1) if match else name] = self
        return save(self, fname, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", savefig)
    return figures


def _check_all(figures: dict) -> None:
    assert figures
    problems = [p for name, fig in figures.items() for p in figure_problems(fig, name)]
    assert not problems, "\n".join(problems)


# ---- the checker itself ----------------------------------------------------------------------------


def test_the_checker_catches_what_the_issue_lists():
    from matplotlib.figure import Figure

    fig = Figure()
    ax = fig.subplots()
    ax.plot([0, 1], [0, 1], label="measured (S-21)")
    ax.plot([0, 1], [1, 0], label="S1 at the estimate")
    ax.set(xlabel="indentation [um]", ylabel="xi", title="period1_end = irregular")
    ax.legend()
    found = "\n".join(figure_problems(fig, "bad"))
    for needle in ("'(S-'", "'S1'", "'um'", "y label without a unit", "'period1_end'"):
        assert needle in found
    assert not _problems_of_text(r"indentation $\delta$ [µm]", "ok")
    assert not _problems_of_text("example_s2.h5: impact 3", "ok")


# ---- the style and the formats ---------------------------------------------------------------------


def test_style_helpers_and_formats(tmp_path):
    from PIL import Image

    from impactid.plotting import PNG_DPI, axis_label, figure_format, figure_name, new_figure, number, save_figure
    from impactid.plotting import style as figure_style

    assert axis_label("indentation", "µm", r"\delta") == r"indentation $\delta$ [µm]"
    assert axis_label("rocker ratio", None) == "rocker ratio [-]"
    assert number(2.443e10) == r"$2.443 \times 10^{10}$"
    with figure_style():
        fig, axes = new_figure()
        axes[0, 0].plot([0, 1], [0, 1])
    png = save_figure(fig, tmp_path / "a.png")
    assert png.name == "a.png" and Image.open(png).info["dpi"][0] == pytest.approx(PNG_DPI, abs=0.5)
    assert save_figure(fig, tmp_path / "a.png", fmt="svg").read_text().lstrip().startswith("<?xml")
    with figure_format("pdf"):
        assert figure_name("x/a.png") == "x/a.pdf"
        assert save_figure(fig, tmp_path / "b.png").read_bytes().startswith(b"%PDF")
    assert figure_name("x/a.png") == "x/a.png"
    with pytest.raises(ValueError, match="unknown figure format"):
        save_figure(fig, tmp_path / "c.png", fmt="jpg")


def test_deliver_passes_figure_format_on(tmp_path):
    import argparse

    from impactid.commandline import deliver
    from impactid.plotting import new_figure
    from impactid.reports import save_figure_atomic

    args = argparse.Namespace(plots=str(tmp_path), out=None, json=False, figure_format="svg")
    fig, _ = new_figure()
    data: dict = {}
    deliver(args, data, [], (["one.png"], lambda staged: save_figure_atomic(fig, tmp_path / "one.png", staged)))
    assert data["plots"] == [str(tmp_path / "one.svg")] and (tmp_path / "one.svg").exists()
    assert not (tmp_path / "one.png").exists()


# ---- every rig's figures ---------------------------------------------------------------------------


def test_rig_p_regime_map_and_spline_study(captured, tmp_path):
    from impactid.rigs.pivoted.figures import plot_kinematics_spline_study, write_regime_map

    frame = pd.DataFrame({"e_over_rc": np.repeat([0.1, 0.2], 4), "cam_speed_hz": np.tile([5.0, 10, 15, 20], 2),
                          "regime": ["contact", "period-1", "period-k", "irregular"] * 2,
                          "detachment_hz": np.repeat([6.0, 7.0], 4)})
    write_regime_map(frame, tmp_path)
    study = pd.DataFrame({"nodes": [16, 32, 64], "max_rel_error_acceleration": [1e-2, 3e-3, 8e-4],
                          "rms_rel_error_acceleration": [5e-3, 1e-3, 3e-4],
                          "max_rel_error_velocity": [1e-3, 1e-4, 1e-5], "rms_rel_error_velocity": [5e-4, 5e-5, 5e-6]})
    captured["spline_study"] = plot_kinematics_spline_study({"cam A": study})
    _check_all(captured)


@pytest.mark.slow
def test_rig_p_estimate_figures(captured, tmp_path):
    """The estimate's four figures, the first the measured and simulated contacts of three impacts."""
    assert main(["estimate", "--example", "--fix-n", "1.5", "--plots", str(tmp_path / "p")]) == 0
    assert {"hysteresis.png", "restitution.png", "landscape.png", "residuals.png"} <= set(captured)
    contacts = captured["hysteresis.png"]
    assert len(contacts.axes) == 6 and "measured (accelerometer)" in [
        t.get_text() for t in contacts.axes[0].get_legend().get_texts()]
    _check_all(captured)


def test_rig_f_bifurcation(captured, tmp_path):
    from impactid.rigs.flat import ALZATE2007
    from impactid.rigs.registry import save_rig_toml

    rig_file = save_rig_toml(ALZATE2007, tmp_path / "rigF.toml")
    assert main(["bifurcation", "--rig", str(rig_file), "--from", "110", "--to", "165", "--unit", "rpm",
                 "--speeds", "8", "--revolutions", "30", "--out", str(tmp_path / "bif")]) == 0
    assert "bifurcation.png" in captured
    _check_all(captured)


def test_bounce_figures_tell_drops_apart(captured):
    from impactid.rigs.ball import TABLE_TENNIS, analyse_bounces
    from impactid.rigs.ball.synth import synth_drop

    drops = [synth_drop("linear", {"e0": 0.96, "gamma": 0.02}, seed=10 + j, ball=TABLE_TENNIS, height=h,
                        min_flight=0.1, missed=1) for j, h in enumerate((0.12, 0.24))]
    result = analyse_bounces([d.times for d in drops], ball=TABLE_TENNIS)
    captured["restitution"], captured["intervals"] = result.plot(), result.plot_intervals()
    for fig in (captured["restitution"], captured["intervals"]):
        legend_texts = [t.get_text() for ax in fig.axes for lg in [ax.get_legend(), *ax.artists]
                        if lg is not None and hasattr(lg, "get_texts") for t in lg.get_texts()]
        assert sum(text.startswith("drop ") for text in legend_texts) == 2
    _check_all(captured)


def test_drop_figures(captured, tmp_path):
    folder = tmp_path / "drops"
    paths = [folder / "low.h5", folder / "high.h5"]
    for path, height in zip(paths, ("0.05", "0.2")):
        assert main(["synth", "--rig", "drop-impact", "--height", height, "--duration", "0.5", "--out",
                     str(path)]) == 0
    assert main(["drop", "fit", *map(str, paths), "--plots", str(tmp_path / "p"), "--json"]) == 0
    assert main(["drop", "simulate", "--height", "0.05", "--plots", str(tmp_path / "q"), "--json"]) == 0
    assert {"drop_fit.png", "drop_force.png"} <= set(captured)
    _check_all(captured)


def test_finger_follower_figures(captured, tmp_path):
    from impactid.rigs.finger_follower.figures import plot_damping_fit

    ff = ("--rig", "finger-follower-hla")
    assert main(["valvetrain", "simulate", *ff, "--rpm", "2450", "--plots", str(tmp_path / "s"), "--json"]) == 0
    rec = tmp_path / "r.h5"
    assert main(["valvetrain", "synth", *ff, "--rpm", "900", "--revolutions", "4", "--out", str(rec)]) == 0
    assert main(["valvetrain", "fit-tappet", str(rec), "--json", "--plots", str(tmp_path / "t")]) == 0
    leak = ["valvetrain", "leakdown", *ff, "--rpms", "600,900", "--json", "--plots", str(tmp_path / "l")]
    assert main(leak) in (0, 1)
    assert {"cycle.png", "rocker_ratio.png", "tappet_fit_0.png"} <= set(captured)

    class Damping:  # the table of a DampingFit
        tables = {"cycle": pd.DataFrame({"cam_angle_deg": np.arange(5.0), "valve_displacement_measured": np.ones(5),
                                         "valve_displacement_fitted": np.ones(5)})}

        @staticmethod
        def value(name):
            return 0.05

    captured["damping_fit"] = plot_damping_fit(Damping())
    _check_all(captured)


def test_cycloidal_figures(captured, tmp_path):
    from impactid.rigs.cycloidal.figures import jump_figure, surge_fit_figure

    rig = ("--rig", "cycloidal-flat-follower-ehl")
    assert main(["valvetrain", "simulate", *rig, "--rpm", "3000", "--level", "B", "--plots", str(tmp_path / "s"),
                 "--speeds", "1000", "--json"]) == 0
    assert {"film.png", "hertz.png", "kinematics.png", "squeeze.png", "load.png", "entraining.png"} <= set(captured)
    captured["jump"] = jump_figure(np.array([2000.0, 3000, 4000]), np.array([5.0, 1.0, -2.0]), 3300.0, "B")

    class Surge:  # the curves of a surge fit
        details = {"unit": "m", "curves": [{"angle_deg": [0.0, 1, 2], "measured": [1e-6, 2e-6, 3e-6],
                                            "model": [1e-6, 2e-6, 3e-6], "rpm": 3000.0}]}
        statistics = {"channel": "valve_displacement"}

    captured["surge"] = surge_fit_figure(Surge())
    _check_all(captured)


@pytest.mark.slow
def test_rig_f_cam_fit_and_svg(captured, tmp_path):
    """``cam-fit --plots`` in SVG (the option once the command declares it; through deliver)."""
    import argparse

    from impactid.commandline import deliver
    from impactid.rigs.flat.camprofile import fit_cam_profile, select_cam_profile_data
    from impactid.rigs.flat.figures import cam_fit_figures
    from tests.rigs.flat.test_camprofile import SPEED_HZ, _encoder_recording

    t = np.arange(int(2.4 * 20_000)) / 20_000
    fit = fit_cam_profile(select_cam_profile_data(_encoder_recording(2 * np.pi * SPEED_HZ * t)), 7)
    args = argparse.Namespace(plots=str(tmp_path), out=None, json=False, figure_format="svg")
    data: dict = {}
    deliver(args, data, [], (["cam_fit.png"], lambda staged: cam_fit_figures(fit, tmp_path, staged)))
    assert (tmp_path / "cam_fit.svg").exists() and data["plots"][0].endswith("cam_fit.svg")
    _check_all(captured)


def test_rig_f_restitution_figures(captured, tmp_path):
    """``restitution --plots``: measured first impacts against their simulation with the fitted law, and the law."""
    recordings = [str(tmp_path / f"f{rpm}.h5") for rpm in ("136", "148")]
    for rpm, path in zip(("136", "148"), recordings):
        assert main(["synth", "--rig", "flat-follower", "--rpm", rpm, "--duration", "1.2", "--out", path]) == 0
    assert main(["restitution", *recordings, "--plots", str(tmp_path / "p"), "--json"]) == 0
    assert {"restitution_impacts.png", "restitution_law.png"} <= set(captured)
    legend = [t.get_text() for t in captured["restitution_impacts.png"].axes[0].get_legend().get_texts()]
    assert legend[0] == "measured (follower encoder)" and legend[1].startswith("simulated with the fitted law")
    _check_all(captured)


def test_planar_fit_figures(captured, tmp_path):
    """``planar fit --plots``: a few impacts' measured and predicted outcomes, and predicted against measured."""
    table = tmp_path / "impacts.csv"
    assert main(["synth", "--rig", "planar-impact", "--impacts", "40", "--seed", "4", "--out", str(table)]) == 0
    assert main(["planar", "fit", str(table), "--body", "mcube-ellipse", "--law", "newton-constant-stick",
                 "--plots", str(tmp_path / "p"), "--json"]) == 0
    assert {"planar_impacts.png", "planar_agreement.png"} <= set(captured)
    _check_all(captured)


# ---- --figure-format on every command that writes figures -------------------------------------------

_FF = ("--rig", "finger-follower-hla")
_CYC = ("--rig", "cycloidal-flat-follower-ehl")
#: Per command: the recording it reads (the ``impactid`` arguments that write it as ``{rec}``, or
#: None), its arguments (``{rec}`` the recording, ``{dir}`` the figures' folder), the figures it
#: writes and how the command lists them: ``plots`` (the JSON's ``plots``), ``files`` (the JSON's
#: ``files``) or None (it prints the paths).
_FIGURE_COMMANDS = {
    "bounces": (["synth", "--rig", "bouncing-ball", "--out", "{rec}.csv"],
                ["bounces", "{rec}.csv", "--no-chained", "--plots", "{dir}", "--json"],
                {"restitution", "intervals"}, "plots"),
    "drop simulate": (None, ["drop", "simulate", "--height", "0.05", "--plots", "{dir}", "--json"],
                      {"drop_force"}, "plots"),
    "drop fit": (["synth", "--rig", "drop-impact", "--height", "0.05", "--duration", "0.3", "--out", "{rec}.h5"],
                 ["drop", "fit", "{rec}.h5", "--plots", "{dir}", "--json"], {"drop_fit"}, "plots"),
    "cam-fit": (["synth", "--rig", "flat-follower", "--rpm", "60", "--duration", "3.1", "--out", "{rec}.h5"],
                ["cam-fit", "{rec}.h5", "--terms", "3", "--plots", "{dir}", "--json"], {"cam_fit"}, "plots"),
    "restitution": (["synth", "--rig", "flat-follower", "--rpm", "140", "--duration", "1", "--out", "{rec}.h5"],
                    ["restitution", "{rec}.h5", "--plots", "{dir}", "--json"],
                    {"restitution_impacts", "restitution_law"}, "plots"),
    "planar fit": (["synth", "--rig", "planar-impact", "--impacts", "30", "--out", "{rec}.csv"],
                   ["planar", "fit", "{rec}.csv", "--body", "mcube-ellipse", "--law", "newton-constant-stick",
                    "--plots", "{dir}", "--json"], {"planar_impacts", "planar_agreement"}, "plots"),
    "bifurcation": (None, ["bifurcation", "--speeds", "2", "--revolutions", "4", "--out", "{dir}", "--json"],
                    {"bifurcation"}, "files"),
    "regime-map": (None, ["regime-map", "--e-over-rc-values", "0.1", "--cam-speeds", "5", "--max-revolutions", "20",
                          "--quiet", "--out", "{dir}"], {"regime_map"}, None),
    "valvetrain simulate (finger follower)": (
        None, ["valvetrain", "simulate", *_FF, "--rpm", "1600", "--plots", "{dir}", "--json"],
        {"cycle", "rocker_ratio"}, "plots"),
    "valvetrain leakdown": (None, ["valvetrain", "leakdown", *_FF, "--rpms", "600", "--plots", "{dir}", "--json"],
                            {"leakdown"}, "plots"),
    "valvetrain fit-tappet": (
        ["valvetrain", "synth", *_FF, "--rpm", "900", "--revolutions", "4", "--out", "{rec}.h5"],
        ["valvetrain", "fit-tappet", *_FF, "{rec}.h5", "--plots", "{dir}", "--json"], {"tappet_fit_0"}, "plots"),
    "valvetrain fit-lift": (
        ["valvetrain", "synth", *_FF, "--rpm", "900", "--revolutions", "4", "--out", "{rec}.h5"],
        ["valvetrain", "fit-lift", *_FF, "{rec}.h5", "--plots", "{dir}", "--json"], {"lift_fit"}, "plots"),
    "valvetrain fit-damping": (
        ["valvetrain", "synth", *_FF, "--rpm", "2450", "--revolutions", "1", "--noise-free", "--out", "{rec}.h5"],
        ["valvetrain", "fit-damping", *_FF, "{rec}.h5", "--plots", "{dir}", "--json"], {"damping_fit"}, "plots"),
    "valvetrain simulate (cycloidal)": (
        None, ["valvetrain", "simulate", *_CYC, "--rpm", "3000", "--plots", "{dir}", "--json"],
        {"film", "hertz", "kinematics", "squeeze", "load", "entraining"}, "plots"),
    "valvetrain jump-speed": (
        None, ["valvetrain", "jump-speed", *_CYC, "--level", "rigid", "--rpm-range", "3000,3500", "--scan-step", "250",
               "--plots", "{dir}", "--json"], {"jump_speed"}, "plots"),
    "valvetrain fit-surge": (
        ["valvetrain", "synth", *_CYC, "--rpm", "3000", "--revolutions", "2", "--out", "{rec}.h5"],
        ["valvetrain", "fit-surge", *_CYC, "{rec}.h5", "--plots", "{dir}", "--json"], {"surge_fit"}, "plots"),
}


#: The cases that take several seconds (a fit, or numba compiling a kernel): marked slow.
_SLOW_FIGURE_COMMANDS = {"cam-fit", "valvetrain fit-tappet", "valvetrain fit-lift", "valvetrain fit-damping"}


@pytest.mark.parametrize("command", [pytest.param(c, marks=pytest.mark.slow) if c in _SLOW_FIGURE_COMMANDS else c
                                     for c in sorted(_FIGURE_COMMANDS)])
def test_figure_format_svg(command, tmp_path, capsys):
    """``--figure-format svg`` writes every figure as SVG (and no PNG), and the JSON names those files."""
    import json

    write, argv, figures, listed = _FIGURE_COMMANDS[command]
    fill = {"rec": str(tmp_path / "rec"), "dir": str(tmp_path / "figures")}
    if write is not None:
        assert main([a.format(**fill) for a in write]) == 0
    capsys.readouterr()
    assert main([a.format(**fill) for a in argv] + ["--figure-format", "svg"]) == 0
    stdout = capsys.readouterr().out
    folder = tmp_path / "figures"
    drawn = {p for p in folder.iterdir() if p.suffix in (".png", ".svg", ".pdf")}
    assert drawn == {folder / f"{name}.svg" for name in figures}
    assert all(p.read_text().lstrip().startswith("<?xml") for p in drawn)
    if listed is None:
        assert {Path(line) for line in stdout.split()} >= drawn
        return
    data = json.loads(stdout)
    assert {Path(p) for p in data[listed] if Path(p).suffix != ".csv"} == drawn


def test_tracks_figures(captured, tmp_path):
    """Ball tracks (issue 29): the track with its fitted flights and the per-bounce restitution."""
    track = tmp_path / "track.csv"
    assert main(["synth", "--rig", "tracked-ball", "--height", "0.3", "--spin", "150", "--bounces", "1",
                 "--seed", "3", "--out", str(track)]) == 0
    assert main(["tracks", "analyse", str(track), "--spin", "150", "--no-air-share", "--plots",
                 str(tmp_path / "p"), "--json"]) == 0
    assert captured, "no figure written"
    _check_all(captured)


def test_bounce_audio_onset_figure(captured, tmp_path):
    """Raw sound (issue 29): the waveform with the accepted onsets and the rejected clicks by reason."""
    wav = tmp_path / "drop.wav"
    assert main(["synth", "--rig", "bouncing-ball", "--ball", "pingpong", "--height", "0.3", "--seed", "1",
                 "--out", str(wav)]) == 0
    assert main(["bounces", str(wav), "--ball", "pingpong", "--plots", str(tmp_path / "p"), "--json"]) == 0
    assert any("onset" in name for name in captured), sorted(captured)
    _check_all(captured)

"""The fit report: ``FitResult.report()``'s text (lmfit's ``fit_report`` layout) and the HTML page of
``--report`` (:mod:`impactid.html_report`): built without a browser (sections, embedded figures, no
external resource, escaped text), written by a fit command (also without ``--plots``, refused up
front when it cannot be written), and loaded in a real headless browser (Chromium: no console error,
every section shown). The browser tests skip when no Chromium is installed (CI installs Debian's)."""

from __future__ import annotations

import base64
import math
import re
import shutil
import subprocess
from pathlib import Path

import pandas as pd
import pytest

from impactid._files import StagedFiles
from impactid.cli import main
from impactid.html_report import CAMPAIGN_SECTIONS, FIT_SECTIONS, FigureCapture, ReportFigure, campaign_page, fit_page
from impactid.results import FitResult, Parameter

#: A text a page must show escaped, never as markup.
HOSTILE = '<script>alert("x")</script> & <b>'
#: The first bytes of every PNG file.
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _result(**changes) -> FitResult:
    """A result with every kind of parameter row: fitted, fixed, an undetermined standard error
    (with its reason), a search-box interval, and notes that repeat a parameter's."""
    separable = "beta and n are not separable from these data"
    fields = dict(
        params=[Parameter("beta", 2.47e10, 1.1e9, (2.2e10, 2.7e10), unit="N s m^-2.5", note=separable),
                Parameter("n", 1.5, 0.02, (1.46, 1.54), note=separable),
                Parameter("k", 3.9e8, fixed=True, unit="N/m^1.5"),
                Parameter("gamma", 0.93, math.nan, (math.nan, math.nan), unit="s/m",
                          note=f"standard error undetermined: one impact {HOSTILE}")],
        statistics={"n_impacts": 12, "objective": 0.0123, "xi_mean": math.nan},
        notes=[separable, "3 impacts left out (no contact found)"],
        tables={"per_impact": pd.DataFrame({"event": [0, 1, 2], "residual": [0.01, math.nan, 0.03],
                                            "source": ["a.h5", "a.h5", HOSTILE]})},
        model_check={"verdict": "consistent", "describes_data": True, "action": "none",
                     "checks": [{"what": "contact force", "unit": "N", "residual_rms": 0.5,
                                 "residual_over_noise": 1.02, "noise_reference": "between impacts",
                                 "chi_square": 12.2, "dof": 10, "chi_square_p_value": 0.27, "verdict": "consistent"}]},
        identifiability={"condition_number": 40.0, "condition_limit": 1e8, "names": ["beta", "n", "gamma"],
                         "correlation": [[1.0, 0.97, 0.05], [0.97, 1.0, -0.3], [0.05, -0.3, 1.0]],
                         "determined": True, "profiles": {"beta": {"shape": "bounded"}}, "profile_method": "refit",
                         "near_bounds": [{"name": "n", "bound": "max", "on_bound": False}],
                         "model_comparison": {"choice": "n free or 1.5", "preferred": "n free",
                                              "models": [{"name": "n = 1.5", "aic": -10.0, "bic": -8.0},
                                                         {"name": "n free", "aic": -20.0, "bic": -17.5}],
                                              "likelihood_ratio": [{"simple": "n = 1.5", "general": "n free",
                                                                    "statistic": 12.0, "p_value": 5e-4}]}},
        provenance=["read a.h5", "fitted"])
    fields.update(changes)
    return FitResult(**fields)


# ---- the text report ----------------------------------------------------------------------------------


def test_report_is_one_parameter_table_with_the_blocks_and_each_note_once():
    text = _result().report()
    lines = text.splitlines()
    header = next(line for line in lines if line.split()[:2] == ["name", "value"])
    assert "std. error" in header and "95 % interval" in header and "unit" in header and "note" in header
    rows = {line.split()[0]: line for line in lines[lines.index(header) + 1:lines.index(header) + 5]}
    assert set(rows) == {"beta", "n", "k", "gamma"}
    assert "(4.5 %)" in rows["beta"] and "search box" in rows["beta"] and "[1]" in rows["beta"]
    assert "fixed" in rows["k"] and "3.9e+08" in rows["k"]
    assert "0.93" in rows["gamma"] and "n/a" in rows["gamma"] and "[2]" in rows["gamma"]
    assert "undetermined" not in rows["gamma"]  # the value exists: never "undetermined" beside it
    notes = lines[lines.index("[[Notes]]") + 1:]
    assert notes[0].strip() == "[1] beta and n are not separable from these data"
    assert notes[1].strip().startswith("[2] standard error undetermined: one impact")
    assert text.count("not separable from these data") == 1 and len(notes) == 3  # printed once
    assert "correlations: C(beta, n) = +0.9700, C(n, gamma) = -0.3000" in text  # |r| < 0.1 left out
    assert "preferred n free; n = 1.5 vs n free: LRT 12 (p = 0.0005)" in text
    assert "n free AIC -20, BIC -17.5" in text and "near bounds: n near max" in text
    assert "[[Model Check]]" in text and "verdict: consistent" in text


def test_report_states_differing_confidence_levels_beside_each_interval():
    result = FitResult(params=[Parameter("a", 1.0, 0.1, (0.8, 1.2), confidence=0.95),
                               Parameter("b", 2.0, 0.1, (1.8, 2.2), confidence=0.9)])
    text = result.report()
    assert "95 % interval" not in text and "[0.8, 1.2] (95 %)" in text and "[1.8, 2.2] (90 %)" in text
    assert "note" not in text.splitlines()[2]  # no note column when no parameter has a note


# ---- the page, without a browser ----------------------------------------------------------------------


def _png() -> bytes:
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    fig = Figure(figsize=(2, 1.5))
    fig.add_subplot().plot([0, 1], [1, 0])
    from io import BytesIO

    buffer = BytesIO()
    fig.savefig(buffer, format="png", dpi=50)
    return buffer.getvalue()


def _ids(html: str) -> list[str]:
    return re.findall(r'<section id="([a-z-]+)"', html)


def test_fit_page_has_every_section_embedded_figures_no_external_resource_and_escaped_text():
    png = _png()
    page = fit_page(_result(), command="impactid drop fit a.h5 --report r.html", inputs=["a.h5", HOSTILE],
                    figures=[ReportFigure("fit.png", png), ReportFigure("fit2.svg", b"<svg xmlns='x'/>")])
    assert _ids(page) == list(FIT_SECTIONS)
    sources = re.findall(r'src="([^"]*)"', page)
    assert len(sources) == 2 and sources[0].startswith("data:image/png;base64,")
    assert base64.b64decode(sources[0].split(",", 1)[1]) == png and sources[1].startswith("data:image/svg+xml;base64,")
    assert not re.search(r"(https?:|//)[^\s\"'<>]*\.", page.split("<style>")[0] + page.split("</style>")[1])
    assert "<link" not in page and "<script" not in page and "@import" not in page
    assert HOSTILE not in page and "&lt;script&gt;alert(&quot;x&quot;)&lt;/script&gt; &amp; &lt;b&gt;" in page
    assert "95 % interval" in page and "search box" in page and "impactid drop fit a.h5 --report r.html" in page
    assert "undetermined</td>" not in page and page.count("not separable from these data") == 1
    assert "<h3>per_impact</h3>" in page and "0.03" in page  # the per-impact table


def test_fit_page_from_a_json_document_and_with_nothing_to_show():
    data = _result().to_dict()
    data["recordings_read"] = ["rec.h5"]
    page = fit_page(data)
    assert _ids(page) == list(FIT_SECTIONS) and "rec.h5" in page and "beta" in page
    bare = fit_page(FitResult(params=[]))
    assert _ids(bare) == list(FIT_SECTIONS) and "this command draws no figure" in bare
    assert "this fit made no model check" in bare and "no notes" in bare


def test_long_tables_are_cut_on_the_page():
    frame = pd.DataFrame({"event": range(1000), "residual": [0.1] * 1000})
    page = fit_page(_result(tables={"per_impact": frame}))
    assert page.count("<tr>") < 450 and "the first 400 of 1000 rows" in page


def test_campaign_page_has_the_per_recording_table_pooled_estimates_and_spread():
    table = pd.DataFrame([
        {"kind": "single", "name": "a", "status": "ok", "reason": "", "beta": 2.0e10, "beta_lo": 1.9e10,
         "beta_hi": 2.1e10, "n": 1.5, "n_fixed": True},
        {"kind": "single", "name": "b", "status": "ok", "reason": "", "beta": 3.0e10, "beta_lo": 2.8e10,
         "beta_hi": 3.2e10, "n": 1.5, "n_fixed": True},
        {"kind": "single", "name": "bad", "status": "failed", "reason": f"cannot read {HOSTILE}", "beta": math.nan},
        {"kind": "joint", "name": "g", "status": "ok", "reason": "", "beta": 2.4e10, "beta_lo": 2.3e10,
         "beta_hi": 2.5e10, "n": 1.49, "n_fixed": False}])
    page = campaign_page("test", table, command="impactid campaign c.toml --report r.html", inputs=["c.toml"],
                         files=["out/campaign.csv"], counts={"fits": 4, "failed": 1})
    assert _ids(page) == list(CAMPAIGN_SECTIONS) and HOSTILE not in page
    pooled = page.split('id="pooled"')[1].split("</section>")[0]
    assert "2.4e+10" in pooled and ">g<" in pooled
    summary = page.split('id="summary"')[1].split("</section>")[0]
    # the single fits that ended in an estimate: mean 2.5e10, sample SD 7.0711e9, CV 28.3 %
    assert "2.5e+10" in summary and "7.0711e+09" in summary and "28.3 %" in summary
    assert "cannot read &lt;script&gt;" in page.split('id="failures"')[1]


def test_figure_capture_keeps_the_figures_and_passes_files_on(tmp_path):
    png = _png()
    with FigureCapture() as capture:
        capture.write_with(Path(capture.folder) / "a.png", lambda tmp: tmp.write_bytes(png))
        capture.write_with("/nonexistent/folder/b.pdf", lambda tmp: tmp.write_bytes(b"%PDF"))  # not shown
        folder = Path(capture.folder)
    assert [f.name for f in capture.figures] == ["a.png"] and capture.figures[0].data == png
    assert not folder.exists() and not Path("/nonexistent/folder").exists()
    with StagedFiles() as staged, FigureCapture(staged) as teed:
        teed.write_with(tmp_path / "plots" / "c.png", lambda tmp: tmp.write_bytes(png))
    assert (tmp_path / "plots" / "c.png").read_bytes() == png and teed.figures[0].data == png


# ---- a fit command's --report ---------------------------------------------------------------------------


@pytest.fixture(scope="module")
def drop_recording(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("report") / "drop.h5"
    assert main(["synth", "--rig", "drop-impact", "--height", "0.05", "--duration", "0.3", "--out", str(path)]) == 0
    return path


@pytest.fixture(scope="module")
def drop_page(drop_recording) -> Path:
    """``impactid drop fit --report`` without ``--plots``: the page draws its figure itself."""
    page = drop_recording.parent / "drop.html"
    assert main(["drop", "fit", str(drop_recording), "--report", str(page)]) == 0
    return page


def test_fit_command_writes_the_page_without_plots(drop_page, drop_recording):
    page = drop_page.read_text(encoding="utf-8")
    assert _ids(page) == list(FIT_SECTIONS)
    (source,) = re.findall(r'src="([^"]*)"', page)
    assert base64.b64decode(source.split(",", 1)[1]).startswith(PNG_MAGIC)
    assert f"impactid drop fit {drop_recording} --report {drop_page}" in page and "drop_fit.png" in page
    assert sorted(p.name for p in drop_page.parent.iterdir()) == ["drop.h5", "drop.html"]  # nothing else written


def test_report_with_plots_embeds_the_plotted_figure(drop_recording, tmp_path, capsys):
    page, plots = tmp_path / "r.html", tmp_path / "plots"
    assert main(["drop", "fit", str(drop_recording), "--plots", str(plots), "--figure-format", "svg",
                 "--report", str(page)]) == 0
    assert f"report written to {page}" in capsys.readouterr().out
    (source,) = re.findall(r'src="([^"]*)"', page.read_text(encoding="utf-8"))
    assert base64.b64decode(source.split(",", 1)[1]) == (plots / "drop_fit.svg").read_bytes()


@pytest.mark.parametrize("where", ["file", "same"])
def test_unwritable_report_is_refused_before_the_fit(drop_recording, tmp_path, capsys, where):
    blocker = tmp_path / "blocker"
    blocker.write_text("a file, not a folder")
    out = tmp_path / "r.json"
    report = blocker / "r.html" if where == "file" else out
    assert main(["drop", "fit", str(drop_recording), "--out", str(out), "--report", str(report)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("impactid: error:") and "--report" in err and len(err.splitlines()) == 1
    assert not out.exists() and sorted(p.name for p in tmp_path.iterdir()) == ["blocker"]


# ---- in a headless browser -------------------------------------------------------------------------------

#: The Chromium binary (Debian's ``chromium``), or None.
CHROMIUM = next(filter(None, map(shutil.which, ("chromium", "chromium-browser", "google-chrome"))), None)
needs_chromium = pytest.mark.skipif(CHROMIUM is None, reason="no Chromium binary (CI installs Debian's chromium)")
#: A console message in Chromium's log (``--enable-logging=stderr``): ``...:INFO:CONSOLE:12] "text", source: ...``.
CONSOLE = re.compile(r":CONSOLE[:(]\d*\)?\]\s*(.*)")


def _load(page: Path, tmp_path: Path) -> tuple[str, list[str]]:
    """The DOM Chromium renders of ``page`` and the console messages it logged."""
    run = subprocess.run([CHROMIUM, "--headless", "--disable-gpu", "--no-sandbox", "--no-first-run",
                          f"--user-data-dir={tmp_path / 'chromium-profile'}", "--enable-logging=stderr", "--v=0",
                          "--dump-dom", page.resolve().as_uri()], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr[-2000:]
    return run.stdout, [m.group(1) for m in map(CONSOLE.search, run.stderr.splitlines()) if m]


@needs_chromium
def test_the_console_check_sees_an_error(tmp_path):
    """The check below can fail: a page whose script logs an error is caught."""
    bad = tmp_path / "bad.html"
    bad.write_text('<!DOCTYPE html><html><body><section id="x">x</section>'
                   '<script>console.error("report-check");</script></body></html>')
    dom, console = _load(bad, tmp_path)
    assert 'id="x"' in dom and any("report-check" in message for message in console)


@needs_chromium
def test_fit_page_loads_in_chromium_without_console_errors(drop_page, tmp_path):
    dom, console = _load(drop_page, tmp_path)
    assert console == []
    for section in FIT_SECTIONS:
        assert f'id="{section}"' in dom, section
    assert re.search(r'<img src="data:image/png;base64,', dom) and "</html>" in dom


@needs_chromium
def test_campaign_page_loads_in_chromium_without_console_errors(tmp_path):
    table = pd.DataFrame([{"kind": "single", "name": "a", "status": "ok", "reason": "", "beta": 2e10},
                          {"kind": "joint", "name": "g", "status": "ok", "reason": "", "beta": 2.1e10}])
    page = tmp_path / "campaign.html"
    page.write_text(campaign_page("test", table), encoding="utf-8")
    dom, console = _load(page, tmp_path)
    assert console == [] and all(f'id="{section}"' in dom for section in CAMPAIGN_SECTIONS)


#: Every fit command and ``campaign``: each takes ``--report``.
REPORT_COMMANDS = (("estimate",), ("campaign",), ("restitution",), ("cam-fit",), ("bounces",), ("drop", "fit"),
                   ("valvetrain", "fit-tappet"), ("valvetrain", "fit-lift"), ("valvetrain", "fit-damping"),
                   ("valvetrain", "fit-surge"), ("planar", "fit"), ("tracks", "analyse"))


def _subparser(parser, path):
    for name in path:
        action = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
        parser = action.choices[name]
    return parser


@pytest.mark.parametrize("path", REPORT_COMMANDS, ids=" ".join)
def test_every_fit_command_takes_report(path):
    from impactid.cli import build_parser

    options = {s for a in _subparser(build_parser(), path)._actions for s in a.option_strings}
    assert "--report" in options

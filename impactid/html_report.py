"""The HTML report of a fit (``--report REPORT.html``): one self-contained page.

A fit command's ``--report`` writes one page that holds everything a reader needs to judge the fit,
without the JSON or the figure files beside it: the title and the provenance (the command, the
inputs, the impactid version), the parameter table (value, standard error, interval at its
confidence level, unit, a note where a number is missing or to be read with care), the fit
statistics, the model check and the identifiability blocks, the figures the command draws for
``--plots`` (embedded as base64 ``data:`` URIs: PNG, or SVG), the per-impact tables of the result
and the notes, each once. A campaign's page (:func:`campaign_page`) holds the per-recording table,
the pooled (joint) estimates and the spread of the single fits.

The page loads nothing (no external style sheet, font, image or script) and runs no JavaScript;
every text is HTML-escaped. The sections have fixed ``id`` attributes (:data:`FIT_SECTIONS`,
:data:`CAMPAIGN_SECTIONS`): every page has every section, saying "none" where the fit has nothing
for it.

Built from a :class:`~impactid.results.FitResult` (or its JSON document, as a command writes it) and
the figures' bytes; :class:`FigureCapture` collects those bytes from a figure writer made for
``--plots`` (any writer that stages its files in a :class:`~impactid._files.StagedFiles`). This
module imports no rig.
"""

from __future__ import annotations

import base64
import math
import tempfile
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from html import escape
from pathlib import Path
from typing import Any

import pandas as pd

from impactid._version import __version__
from impactid.results import (
    FitResult,
    identifiability_lines,
    model_check_lines,
    numbered_notes,
    parameter_rows,
)

__all__ = ["CAMPAIGN_SECTIONS", "FIT_SECTIONS", "MAX_TABLE_ROWS", "FigureCapture", "ReportFigure", "campaign_page",
           "campaign_spread", "fit_page"]

#: The ``id`` of every section of a fit's page, in order.
FIT_SECTIONS = ("provenance", "parameters", "statistics", "model-check", "identifiability", "figures", "residuals",
                "notes")
#: The ``id`` of every section of a campaign's page, in order.
CAMPAIGN_SECTIONS = ("provenance", "summary", "figures", "pooled", "recordings", "failures")
#: Rows of a table shown on a page (the JSON holds all of them).
MAX_TABLE_ROWS = 400

#: The MIME type of a figure file by its suffix (the formats a page can show).
_MIME = {".png": "image/png", ".svg": "image/svg+xml"}

_STYLE = """
body { font-family: system-ui, -apple-system, "Segoe UI", Roboto, sans-serif; margin: 2em auto; max-width: 1100px;
       padding: 0 1em; color: #222; line-height: 1.4; }
h1 { font-size: 1.6em; margin-bottom: 0.2em; }
h2 { font-size: 1.25em; border-bottom: 1px solid #ccc; padding-bottom: 0.2em; margin-top: 1.8em; }
h3 { font-size: 1.05em; }
table { border-collapse: collapse; margin: 0.5em 0; font-size: 0.92em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: left; vertical-align: top; }
th { background: #f0f0f0; }
td.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
pre { background: #f7f7f7; padding: 0.6em; font-size: 0.88em; white-space: pre-wrap; overflow-wrap: anywhere; }
figure { margin: 1em 0; }
figure img { max-width: 100%; height: auto; border: 1px solid #ddd; }
figcaption { font-size: 0.9em; color: #555; }
.muted { color: #666; }
.scroll { overflow-x: auto; }
"""


@dataclass(frozen=True)
class ReportFigure:
    """A figure of a page: its file ``name`` (``hysteresis.png``) and its bytes (PNG or SVG)."""

    name: str
    data: bytes

    @property
    def mime(self) -> str:
        """The MIME type of the figure (from its suffix)."""
        return _MIME[Path(self.name).suffix.lower()]

    def data_uri(self) -> str:
        """The figure as a ``data:`` URI."""
        return f"data:{self.mime};base64,{base64.b64encode(self.data).decode('ascii')}"


class FigureCapture:
    """Collects the figures a ``--plots`` writer writes, as bytes.

    It stands in for the :class:`~impactid._files.StagedFiles` transaction a figure writer stages
    its files in (``stage``, ``write_with``, ``write_text``). With ``staged`` it passes every file on
    to that transaction (the ``--plots`` files are written as before) and keeps a copy of the
    figures a page can show (PNG, SVG); without it, the files go to a private temporary folder that
    is removed on exit, whatever the folder of the path the writer names. Use as a context manager.
    """

    def __init__(self, staged=None):
        self._staged = staged
        self._folder: tempfile.TemporaryDirectory | None = None
        self._pending: list[tuple[str, Path]] = []
        self.figures: list[ReportFigure] = []

    def __enter__(self) -> FigureCapture:
        if self._staged is None:
            self._folder = tempfile.TemporaryDirectory(prefix="impactid-report-")
        return self

    def __exit__(self, *exc) -> None:
        self._collect()  # a file a writer staged and wrote itself
        if self._folder is not None:
            self._folder.cleanup()
            self._folder = None

    @property
    def folder(self) -> str:
        """The private temporary folder (without ``staged``): where a writer may think it writes."""
        if self._folder is None:
            raise RuntimeError("FigureCapture has no folder of its own (it passes files on, or is closed)")
        return self._folder.name

    def stage(self, final) -> Path:
        """A temporary path for ``final`` (in ``staged``'s transaction, or in the private folder)."""
        if self._staged is not None:
            tmp = Path(self._staged.stage(final))
        else:
            if self._folder is None:
                raise RuntimeError("FigureCapture used outside its 'with' block")
            tmp = Path(self._folder.name) / f"{len(self._pending)}_{Path(final).name}"
        self._pending.append((Path(final).name, tmp))
        return tmp

    def write_with(self, final, writer: Callable[[Path], object]) -> Path:
        """Write ``final`` by ``writer(temporary_path)`` and keep a copy of the figure."""
        tmp = self.stage(final)
        writer(tmp)
        self._collect()
        return Path(final)

    def write_text(self, final, text: str) -> Path:
        return self.write_with(final, lambda tmp: tmp.write_text(text, encoding="utf-8"))

    def _collect(self) -> None:
        for name, tmp in self._pending:
            if Path(name).suffix.lower() in _MIME and tmp.exists():
                self.figures.append(ReportFigure(name, tmp.read_bytes()))
        self._pending = []


# ---- pieces of a page ---------------------------------------------------------------------------


def _text(value: Any) -> str:
    """A cell's text: numbers in 5 significant digits, NaN and None as ``n/a``, escaped."""
    if value is None or value is pd.NA or value is pd.NaT:
        return "n/a"
    if isinstance(value, bool):
        return str(value)
    if isinstance(value, float):
        return format(value, ".5g") if math.isfinite(value) else "n/a"
    if isinstance(value, (list, tuple)):
        return escape(", ".join(map(str, value)))
    return escape(str(value))


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _table(header: Sequence[str] | None, rows: Sequence[Sequence[Any]], numeric: Sequence[bool] | None = None) -> str:
    """An HTML table (``header`` None: none; ``numeric``: the columns aligned right as numbers)."""
    numeric = list(numeric) if numeric is not None else []
    body = []
    for row in rows:
        cells = []
        for k, value in enumerate(row):
            right = numeric[k] if k < len(numeric) else False
            cells.append(f'<td class="num">{_text(value)}</td>' if right or _is_number(value)
                         else f"<td>{_text(value)}</td>")
        body.append("<tr>" + "".join(cells) + "</tr>")
    head = ("<thead><tr>" + "".join(f"<th>{escape(str(h))}</th>" for h in header) + "</tr></thead>"
            if header is not None else "")
    return f'<div class="scroll"><table>{head}<tbody>{"".join(body)}</tbody></table></div>'


def _frame_table(frame: pd.DataFrame, max_rows: int = MAX_TABLE_ROWS) -> str:
    shown = frame.head(max_rows)
    rows = [[v.item() if hasattr(v, "item") else v for v in row] for row in shown.itertuples(index=False)]
    html = _table([str(c) for c in frame.columns], rows)
    if len(frame) > max_rows:
        html += f'<p class="muted">the first {max_rows} of {len(frame)} rows (the JSON result holds all)</p>'
    return html


def _section(section_id: str, title: str, body: str) -> str:
    return f'<section id="{section_id}">\n<h2>{escape(title)}</h2>\n{body}\n</section>'


def _lines_block(lines: Sequence[str]) -> str:
    """A report block's lines (its ``[[...]]`` header left out) as preformatted text."""
    body = [line for line in lines if not line.startswith("[[")]
    return "<pre>" + escape("\n".join(line[4:] if line.startswith("    ") else line for line in body)) + "</pre>"


def _none(what: str) -> str:
    return f'<p class="muted">{escape(what)}</p>'


def _page(title: str, sections: Sequence[str]) -> str:
    return ("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
            "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
            f"<title>{escape(title)}</title>\n<style>{_STYLE}</style>\n</head>\n<body>\n"
            f"<h1>{escape(title)}</h1>\n" + "\n".join(sections) + "\n</body>\n</html>\n")


def _provenance(command: str, inputs: Sequence[str], version: str, steps: Sequence[str]) -> str:
    rows = [["command", command or "n/a"], ["inputs", "; ".join(map(str, inputs)) or "none"],
            ["impactid version", version or __version__]]
    if version and version != __version__:
        rows.append(["page written by impactid", __version__])
    body = _table(None, rows)
    if steps:
        body += "<h3>What was read and done</h3><ol>" + "".join(f"<li>{escape(str(s))}</li>" for s in steps) + "</ol>"
    return _section("provenance", "Provenance", body)


def _parameters(result: FitResult, notes: Sequence[str]) -> str:
    params = list(result.params.values())
    if not params:
        return _section("parameters", "Parameters", _none("this fit has no parameters"))
    header, rows = parameter_rows(params, notes)
    titles = ["name", "value", "standard error", header, "unit", "note"]
    if not any(row[-1] for row in rows):  # no note column when no parameter has a note
        titles, rows = titles[:-1], [row[:-1] for row in rows]
    body = _table(titles, rows, numeric=[False, True, True, True, False, False])
    body += ('<p class="muted">n/a: not determined by the fit (the note says why); "search box": the data do not '
             'separate the parameter, and the interval is the range searched, not a confidence interval.</p>')
    return _section("parameters", "Parameters", body)


def _statistics(result: FitResult) -> str:
    rows = [[key, value if _is_number(value) or value is None else str(value)]
            for key, value in result.statistics.items()]
    body = _table(["statistic", "value"], rows) if rows else _none("no fit statistics")
    return _section("statistics", "Fit statistics", body)


def _figures(figures: Sequence[ReportFigure]) -> str:
    if not figures:
        return _section("figures", "Figures", _none("this command draws no figure"))
    body = "".join(f'<figure><img src="{f.data_uri()}" alt="{escape(f.name)}"><figcaption>{escape(f.name)}'
                   "</figcaption></figure>" for f in figures)
    return _section("figures", "Figures: measured and simulated", body)


def _tables(result: FitResult) -> str:
    if not result.tables:
        return _section("residuals", "Per-impact tables", _none("this fit has no per-event table"))
    body = "".join(f"<h3>{escape(name)}</h3>" + _frame_table(frame) for name, frame in result.tables.items())
    return _section("residuals", "Per-impact tables and residuals", body)


def _notes(notes: Sequence[str]) -> str:
    if not notes:
        return _section("notes", "Notes", _none("no notes"))
    return _section("notes", "Notes", "<ol>" + "".join(f"<li>{escape(n)}</li>" for n in notes) + "</ol>")


# ---- pages --------------------------------------------------------------------------------------------


def fit_page(result: FitResult | Mapping[str, Any], *, command: str = "", inputs: Sequence[str] = (),
             figures: Sequence[ReportFigure] = (), title: str | None = None) -> str:
    """The HTML page of a fit.

    Parameters
    ----------
    result : the fit, or its JSON document (:meth:`~impactid.results.FitResult.to_dict`, as a command
        writes it; ``recordings_read`` are added to ``inputs``).
    command : the command line that made it.
    inputs : the files read.
    figures : the figures to embed (PNG or SVG bytes).
    title : the page's title (default: the result's).

    Returns
    -------
    str
        The page (UTF-8 text), with every section of :data:`FIT_SECTIONS`.
    """
    if not isinstance(result, FitResult):
        document = dict(result)
        inputs = list(dict.fromkeys([*map(str, inputs), *map(str, document.get("recordings_read") or ())]))
        result = FitResult.from_dict(document)
    notes = numbered_notes(result)
    title = title or f"impactid report: {result.title}"
    check = model_check_lines(result.model_check)
    ident = identifiability_lines(result.identifiability)
    sections = [
        _provenance(command, inputs, result.version, result.provenance),
        _parameters(result, notes),
        _statistics(result),
        _section("model-check", "Model check", _lines_block(check) if check else _none("this fit made no model check")),
        _section("identifiability", "Identifiability",
                 _lines_block(ident) if ident else _none("this fit made no identifiability analysis")),
        _figures(figures),
        _tables(result),
        _notes(notes),
    ]
    return _page(title, sections)


def campaign_spread(values: Sequence[float]) -> dict[str, float]:
    """The spread of a campaign's single-fit estimates: ``count``, ``mean``, ``sd`` (sample standard
    deviation), ``cv`` (``sd`` over the magnitude of ``mean``), ``min``, ``max`` of the finite ``values``
    (NaN where undefined)."""
    finite = [float(v) for v in values if v is not None and math.isfinite(float(v))]
    count = len(finite)
    mean = sum(finite) / count if count else math.nan
    sd = math.sqrt(sum((v - mean) ** 2 for v in finite) / (count - 1)) if count > 1 else math.nan
    return {"count": count, "mean": mean, "sd": sd, "cv": sd / abs(mean) if count > 1 and mean != 0 else math.nan,
            "min": min(finite) if finite else math.nan, "max": max(finite) if finite else math.nan}


#: Columns of a campaign's tables shown on its page (those the table has, in this order).
_RECORDING_COLUMNS = ("name", "recordings", "status", "e_over_rc", "cam_speed_hz", "beta", "beta_lo", "beta_hi", "n",
                      "n_lo", "n_hi", "n_fixed", "gamma", "impacts_used", "warnings", "reason")
_POOLED_COLUMNS = ("name", "recordings", "n_recordings", "status", "operating_points", "beta", "beta_lo", "beta_hi",
                   "n", "n_lo", "n_hi", "n_fixed", "separable", "impacts_used", "warnings", "reason")


def _campaign_figure(singles: pd.DataFrame, joints: pd.DataFrame) -> ReportFigure | None:
    """``beta`` of each single fit with its interval, and each group's pooled (joint) estimate as a
    band (PNG), or None when no fit has a ``beta``."""
    if "beta" not in singles or not len(singles.dropna(subset=["beta"])) and not len(joints):
        return None
    from io import BytesIO

    from impactid.plotting import CYCLE, MEASURED, PNG_DPI, axis_label, new_figure, style

    singles = singles.dropna(subset=["beta"])
    with style():
        fig, axes = new_figure(size=(7.0, 3.6))
        ax = axes[0, 0]
        x = list(range(len(singles)))
        beta = singles["beta"].to_numpy(dtype=float)
        lo = singles.get("beta_lo", singles["beta"]).to_numpy(dtype=float)
        hi = singles.get("beta_hi", singles["beta"]).to_numpy(dtype=float)
        below = [b - low if math.isfinite(low) else 0.0 for b, low in zip(beta, lo)]
        above = [high - b if math.isfinite(high) else 0.0 for b, high in zip(beta, hi)]
        ax.errorbar(x, beta, yerr=[below, above], fmt="o", color=MEASURED, capsize=3,
                    label="one recording (single fit, interval)")
        for k, row in enumerate(joints.dropna(subset=["beta"]).to_dict(orient="records")):
            colour = CYCLE[(k + 1) % len(CYCLE)]
            ax.axhline(row["beta"], color=colour, label=f"pooled: group {row.get('name', k)} (joint fit)")
            if math.isfinite(row.get("beta_lo", math.nan)) and math.isfinite(row.get("beta_hi", math.nan)):
                ax.axhspan(row["beta_lo"], row["beta_hi"], color=colour, alpha=0.15)
        ax.set_xticks(x, [str(n) for n in singles.get("name", pd.Series(x))], rotation=30, ha="right")
        ax.ticklabel_format(axis="y", useOffset=False)
        ax.set_xlabel("recording")
        ax.set_ylabel(axis_label("damping", r"N s m$^{-(n+1)}$", r"\beta"))
        ax.legend(loc="best")
        buffer = BytesIO()
        fig.savefig(buffer, format="png", dpi=PNG_DPI)
    return ReportFigure("campaign_beta.png", buffer.getvalue())


def campaign_page(name: str, table: pd.DataFrame, *, command: str = "", inputs: Sequence[str] = (),
                  files: Sequence[str] = (), counts: Mapping[str, Any] | None = None) -> str:
    """The HTML page of a campaign (:func:`impactid.campaign.run_campaign`'s summary ``table``).

    Sections (:data:`CAMPAIGN_SECTIONS`): provenance (the command, the campaign's inputs, the table
    files), the summary (``counts``: fits run, skipped, failed; the spread of the single fits'
    ``beta`` and ``n``: mean, standard deviation, coefficient of variation, range), the pooled
    estimates (the joint fits of the groups), the per-recording table (the single fits) and the
    failures with their reasons.
    """
    kinds = table["kind"] if "kind" in table else pd.Series([""] * len(table))
    ok = table["status"] == "ok" if "status" in table else pd.Series([True] * len(table))
    singles, joints = table[kinds == "single"], table[kinds == "joint"]
    single_ok = table[(kinds == "single") & ok]
    summary = _table(None, [[key, value] for key, value in (counts or {}).items()]) if counts else ""
    spread_rows = []
    for column, unit in (("beta", "N s m^-(n+1)"), ("n", ""), ("gamma", "s/m")):
        if column in single_ok:
            s = campaign_spread(single_ok[column].tolist())
            if s["count"]:
                spread_rows.append([column, s["count"], s["mean"], s["sd"],
                                    f"{100 * s['cv']:.3g} %" if math.isfinite(s["cv"]) else "n/a",
                                    s["min"], s["max"], unit])
    if spread_rows:
        summary += ("<h3>Spread of the single fits (one per recording)</h3>"
                    + _table(["parameter", "fits", "mean", "standard deviation", "coefficient of variation", "min",
                              "max", "unit"], spread_rows, numeric=[False, True, True, True, True, True, True, False]))
    else:
        summary += _none("no single fit ended in an estimate: no spread")
    pooled = (_frame_table(joints[[c for c in _POOLED_COLUMNS if c in joints]]) if len(joints)
              else _none("no joint fit (the campaign has no group)"))
    if len(joints):
        pooled = ('<p>The pooled estimate of each group: one fit of its recordings together (beta in N s m^-(n+1), '
                  "intervals beta_lo..beta_hi and n_lo..n_hi).</p>" + pooled)
    recordings = (_frame_table(singles[[c for c in _RECORDING_COLUMNS if c in singles]]) if len(singles)
                  else _none("no single fit"))
    failed = table[~ok]
    failures = (_table(["kind", "name", "reason"], [[r.get("kind", ""), r.get("name", ""), r.get("reason", "")]
                                                    for r in failed.to_dict(orient="records")])
                if len(failed) else _none("no fit failed"))
    figure = _campaign_figure(single_ok, table[(kinds == "joint") & ok])
    figures = _figures([figure] if figure is not None else [])
    inputs_text = list(map(str, inputs)) + [f"written: {f}" for f in files]
    sections = [
        _provenance(command, inputs_text, __version__, ()),
        _section("summary", "Summary", summary),
        figures.replace("Figures: measured and simulated", "Figure: estimate per recording"),
        _section("pooled", "Pooled estimates (joint fits)", pooled),
        _section("recordings", "Per-recording estimates (single fits)", recordings),
        _section("failures", "Failures", failures),
    ]
    return _page(f"impactid campaign report: {name}", sections)

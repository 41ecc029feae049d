"""Result types shared by every fit: :class:`Parameter` and :class:`FitResult`.

Modelled on lmfit's ``Parameter`` and ``MinimizerResult``: a fit returns its parameters (each with a
value, a standard error, an interval, whether it was fixed, and a unit), fit statistics, the notes
that qualify it (what would otherwise be warnings: the result carries them, and only the top-level
call warns, once), per-event tables, and its provenance (what was read and done, with the
impactid version). Every result prints an lmfit-style ``report()``, round-trips through
``to_json()`` / ``from_json()``, gives its tables with ``to_pandas()`` and, where a figure is the
natural answer, draws one with ``plot()`` (a :class:`matplotlib.figure.Figure`, never ``pyplot``).

Non-finite numbers (an undetermined standard error, say) are legal values of a result; in JSON
they are written as ``null``; the report shows ``n/a`` for them, with the parameter's note saying why.

Every fit states, beside its parameters, its **model check** (``model_check``: whether the model
describes the data, :func:`impactid.engine.check_model`) and its **identifiability**
(``identifiability``: condition number, correlations, bounds, profile shapes, law comparisons,
:func:`impactid.engine.identifiability`); docs/identifiability.md says what each number means.

A fit type subclasses :class:`FitResult`, sets ``kind`` (its name in JSON) and adds properties
and a ``plot()``; :func:`FitResult.from_json` rebuilds the right subclass from ``kind``.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any, ClassVar

import numpy as np
import pandas as pd

from impactid._version import __version__

__all__ = ["FitResult", "Parameter", "confidence_label", "identifiability_lines", "interval_header", "is_search_box",
           "json_ready", "model_check_lines", "note_reference", "numbered_notes", "parameter_cells",
           "parameter_rows", "parameter_table_lines", "result_kinds", "strongest_correlations"]

_KINDS: dict[str, type[FitResult]] = {}


def _finite_or_none(value):
    if value is None:
        return None
    value = float(value)
    return value if math.isfinite(value) else None


def _number(value) -> float:
    return math.nan if value is None else float(value)


def _fmt(value: float, spec: str = ".6g") -> str:
    return format(value, spec) if value is not None and math.isfinite(value) else "n/a"


@dataclass(frozen=True)
class Parameter:
    """One fitted (or fixed) parameter.

    Attributes
    ----------
    name : the parameter's name (``"beta"``, ``"gamma"``, ...).
    value : best estimate, SI units (NaN when the data do not determine it).
    stderr : standard error [same unit] (NaN when undetermined, 0 for a fixed parameter).
    interval : ``(low, high)`` confidence interval (NaN bounds when undetermined).
    confidence : the interval's nominal coverage, e.g. 0.95.
    fixed : True when the value was given, not fitted.
    unit : SI unit string, e.g. ``"N s m^-2.5"``, ``"s/m"``, ``""`` for dimensionless.
    note : why the value, error or interval is undetermined or to be read with care ("" if none).
    min, max : the bounds the search respected [same unit] (infinite: unbounded), as lmfit's.

    ``vary`` (lmfit's name) is ``not fixed``.
    """

    name: str
    value: float
    stderr: float = math.nan
    interval: tuple[float, float] = (math.nan, math.nan)
    confidence: float = 0.95
    fixed: bool = False
    unit: str = ""
    note: str = ""
    min: float = -math.inf
    max: float = math.inf

    def __post_init__(self) -> None:
        object.__setattr__(self, "value", float(self.value))
        object.__setattr__(self, "min", float(self.min))
        object.__setattr__(self, "max", float(self.max))
        object.__setattr__(self, "stderr", 0.0 if self.fixed and not math.isfinite(self.stderr) else
                           float(self.stderr))
        lo, hi = self.interval
        object.__setattr__(self, "interval", (float(lo), float(hi)))

    @property
    def vary(self) -> bool:
        """Whether the parameter was fitted (lmfit's name for ``not fixed``)."""
        return not self.fixed

    @property
    def determined(self) -> bool:
        """Whether the value is a finite number."""
        return math.isfinite(self.value)

    def contains(self, value: float) -> bool:
        """Whether ``value`` lies inside the interval (False when the interval is undetermined)."""
        lo, hi = self.interval
        return bool(lo <= value <= hi)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (non-finite numbers as None)."""
        return {"name": self.name, "value": _finite_or_none(self.value), "stderr": _finite_or_none(self.stderr),
                "interval": [_finite_or_none(self.interval[0]), _finite_or_none(self.interval[1])],
                "confidence": self.confidence, "fixed": self.fixed, "vary": not self.fixed, "unit": self.unit,
                "note": self.note, "min": _finite_or_none(self.min), "max": _finite_or_none(self.max)}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Parameter:
        interval = data.get("interval") or [None, None]
        return cls(name=str(data["name"]), value=_number(data.get("value")), stderr=_number(data.get("stderr")),
                   interval=(_number(interval[0]), _number(interval[1])),
                   confidence=float(data.get("confidence", 0.95)), fixed=bool(data.get("fixed", False)),
                   unit=str(data.get("unit", "")), note=str(data.get("note", "")),
                   min=-math.inf if data.get("min") is None else float(data["min"]),
                   max=math.inf if data.get("max") is None else float(data["max"]))

    def report_line(self, width: int = 10) -> str:
        """One line of a fit report: ``name value +/- stderr (rel %) [low, high] unit (note)``; an error
        or interval the fit did not determine is ``n/a`` (the note says why), a fixed value says so."""
        cells = parameter_cells(self)
        if self.fixed:
            text = f"    {self.name:<{width}} {cells['value']} {self.unit}".rstrip() + " (fixed)"
        else:
            text = (f"    {self.name:<{width}} {cells['value']} +/- {cells['stderr']} {cells['interval']} "
                    f"{self.unit}").rstrip()
        return text + (f"   ({self.note})" if self.note else "")


def json_ready(value, undetermined: list[str] | None = None, path: str = ""):
    """``value`` made JSON-ready: numpy types to Python, non-finite floats to None, tuples to lists,
    paths to strings, DataFrames to ``{"columns": [...], "data": [[...], ...]}`` (the inverse of
    :func:`_frame_from`). With ``undetermined`` (a list), the JSON path of every non-finite number
    written as None is appended to it (``path`` is where ``value`` sits)."""
    def inner(item, where):
        return json_ready(item, undetermined, where)

    if isinstance(value, Parameter):
        return value.to_dict()
    if isinstance(value, pd.DataFrame):
        return {"columns": [str(c) for c in value.columns], "data": inner(value.to_numpy(dtype=object).tolist(),
                                                                           f"{path}.data")}
    if isinstance(value, Mapping):
        return {str(k): inner(v, f"{path}.{k}" if path else str(k)) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [inner(v, f"{path}[{i}]") for i, v in enumerate(value)]
    if isinstance(value, np.ndarray):
        return inner(value.tolist(), path)
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        if undetermined is not None:
            undetermined.append(path)
        return None
    if isinstance(value, Path):
        return str(value)
    return value


def _frame_from(data: Mapping[str, Any]) -> pd.DataFrame:
    rows = [[math.nan if v is None else v for v in row] for row in data.get("data", [])]
    frame = pd.DataFrame(rows, columns=list(data.get("columns", [])))
    return frame.infer_objects()


def result_kinds() -> dict[str, type[FitResult]]:
    """The registered fit-result types by their ``kind`` name."""
    return dict(_KINDS)


@dataclass(frozen=True)
class FitResult:
    """Base of every fit result.

    Attributes
    ----------
    params : the parameters by name (read-only mapping of :class:`Parameter`).
    statistics : fit statistics by name (objective, chi-square, AIC, BIC, number of data, ...).
    notes : what qualifies the result (not separable, on a bound, data left out, ...).
    tables : per-event (per-impact, per-bounce, ...) tables by name.
    details : further JSON-ready information (method settings, a valley, a profile, ...).
    provenance : what was read and done, oldest first.
    version : the impactid version that made the result.
    model_check : whether the model describes the data (:func:`impactid.engine.combine_checks`:
        ``verdict``, ``describes_data``, ``action``, ``inflation``, ``checks``, ``rule``); empty when
        the fit made none.
    identifiability : what the data determine (:func:`impactid.engine.identifiability`:
        ``condition_number``, ``correlation``, ``near_bounds``, ``profiles``, ``model_comparison``,
        ``determined``, ...; ``parts`` for a result of several fits); empty when the fit made none.
    """

    kind: ClassVar[str] = "fit"
    title: ClassVar[str] = "fit"

    params: Mapping[str, Parameter]
    statistics: Mapping[str, Any] = field(default_factory=dict)
    notes: tuple[str, ...] = ()
    tables: Mapping[str, pd.DataFrame] = field(default_factory=dict, repr=False)
    details: Mapping[str, Any] = field(default_factory=dict, repr=False)
    provenance: tuple[str, ...] = ()
    version: str = ""
    model_check: Mapping[str, Any] = field(default_factory=dict, repr=False)
    identifiability: Mapping[str, Any] = field(default_factory=dict, repr=False)

    def __init_subclass__(cls, **kwargs) -> None:
        super().__init_subclass__(**kwargs)
        if "kind" in cls.__dict__:
            _KINDS[cls.kind] = cls

    def __post_init__(self) -> None:
        params = self.params.values() if isinstance(self.params, Mapping) else self.params
        object.__setattr__(self, "params", MappingProxyType({p.name: p for p in params}))
        object.__setattr__(self, "statistics", MappingProxyType(dict(self.statistics)))
        object.__setattr__(self, "tables", MappingProxyType(dict(self.tables)))
        object.__setattr__(self, "details", MappingProxyType(dict(self.details)))
        object.__setattr__(self, "model_check", MappingProxyType(dict(self.model_check or {})))
        object.__setattr__(self, "identifiability", MappingProxyType(dict(self.identifiability or {})))
        object.__setattr__(self, "notes", tuple(self.notes))
        object.__setattr__(self, "provenance", tuple(self.provenance))
        if not self.version:
            object.__setattr__(self, "version", __version__)

    # ---- access -----------------------------------------------------------------------------
    def __getitem__(self, name: str) -> Parameter:
        return self.params[name]

    def value(self, name: str) -> float:
        """The value of parameter ``name``."""
        return self.params[name].value

    @property
    def values(self) -> dict[str, float]:
        """Parameter values by name."""
        return {name: p.value for name, p in self.params.items()}

    # ---- text -------------------------------------------------------------------------------
    def report(self) -> str:
        """An lmfit-style fit report (``lmfit.fit_report``'s layout): the statistics, one table of the
        parameters (value, standard error and its relative size, the interval with its confidence
        level, unit, a note reference), the model check, the identifiability block and the notes,
        each note once (numbered; the parameters' notes are referred to by their number)."""
        notes = numbered_notes(self)
        lines = [f"[[{self.title}]]"]
        if self.statistics:
            lines.append("[[Fit Statistics]]")
            for key, value in self.statistics.items():
                text = _fmt(value) if isinstance(value, float) else str(value)
                lines.append(f"    {key:<22} = {text}")
        lines += parameter_table_lines(self.params.values(), notes)
        lines += model_check_lines(self.model_check) + identifiability_lines(self.identifiability)
        if notes:
            lines.append("[[Notes]]")
            lines += [f"    [{k}] {note}" for k, note in enumerate(notes, 1)]
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.report()

    # ---- data -------------------------------------------------------------------------------
    def to_pandas(self, table: str | None = None) -> pd.DataFrame:
        """A per-event table (the first one when ``table`` is None); the parameters as a table
        when the result has no other."""
        if table is None:
            if not self.tables:
                return pd.DataFrame([p.to_dict() for p in self.params.values()])
            table = next(iter(self.tables))
        if table not in self.tables:
            raise KeyError(f"no table {table!r}; tables: {', '.join(self.tables) or 'none'}")
        return self.tables[table].copy()

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (round-trips through :meth:`from_dict`)."""
        return {"kind": self.kind, "impactid_version": self.version,
                "params": {name: p.to_dict() for name, p in self.params.items()},
                "statistics": json_ready(dict(self.statistics)), "notes": list(self.notes),
                "tables": {name: json_ready(frame) for name, frame in self.tables.items()},
                "details": json_ready(dict(self.details)), "model_check": json_ready(dict(self.model_check)),
                "identifiability": json_ready(dict(self.identifiability)), "provenance": list(self.provenance)}

    def to_json(self, path: str | os.PathLike[str] | None = None, indent: int = 2) -> str:
        """JSON text of the result; written atomically to ``path`` when given."""
        text = json.dumps(self.to_dict(), indent=indent, allow_nan=False) + "\n"
        if path is not None:
            from impactid._files import atomic_write

            atomic_write(path, text)
        return text

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> FitResult:
        """Rebuild a result (of the subclass named by ``data["kind"]``) from :meth:`to_dict` output."""
        kind = data.get("kind", "fit")
        target = _KINDS.get(kind, FitResult) if cls is FitResult else cls
        params = [Parameter.from_dict(p) for p in data.get("params", {}).values()]
        tables = {name: _frame_from(t) for name, t in data.get("tables", {}).items()}
        return target._rebuild(params=params, statistics=data.get("statistics", {}), notes=data.get("notes", ()),
                               tables=tables, details=data.get("details", {}),
                               provenance=data.get("provenance", ()), version=data.get("impactid_version", ""),
                               model_check=data.get("model_check") or {},
                               identifiability=data.get("identifiability") or {})

    @classmethod
    def _rebuild(cls, **fields) -> FitResult:
        """Construct from the base fields (subclasses with fields of their own override this)."""
        return cls(**fields)

    @classmethod
    def from_json(cls, source: str | os.PathLike[str]) -> FitResult:
        """Rebuild a result from JSON text or from the path of a JSON file."""
        text = str(source)
        if not text.lstrip().startswith("{"):
            text = Path(source).read_text(encoding="utf-8")
        return cls.from_dict(json.loads(text))

    # ---- figures ----------------------------------------------------------------------------
    def plot(self, **kwargs):
        """The natural figure of this result (a :class:`matplotlib.figure.Figure`)."""
        raise NotImplementedError(f"{type(self).__name__} has no figure")

    def with_notes(self, notes: Iterable[str]) -> FitResult:
        """A copy with ``notes`` appended."""
        from dataclasses import replace

        return replace(self, notes=self.notes + tuple(notes))


_KINDS[FitResult.kind] = FitResult


def _g(value, spec: str = ".3g") -> str:
    """A number of a block (None or non-finite: "n/a")."""
    if isinstance(value, bool) or value is None:
        return "n/a" if value is None else str(value)
    try:
        number = float(value)
    except (TypeError, ValueError):
        return str(value)
    return format(number, spec) if math.isfinite(number) else "n/a"


# ---- the parameter table ----------------------------------------------------------------------------

#: Words of a parameter's note that say its interval is the search box (the data do not separate it).
SEARCH_BOX_WORDS = ("search box", "not separable")


def is_search_box(parameter: Parameter) -> bool:
    """Whether ``parameter``'s interval is the search box, not a confidence interval (its note says
    so: the data do not separate it from another parameter)."""
    note = parameter.note.lower()
    return any(word in note for word in SEARCH_BOX_WORDS)


def confidence_label(confidence: float) -> str:
    """``0.95`` as ``"95 %"``."""
    return f"{100 * confidence:.4g} %"


def parameter_cells(parameter: Parameter) -> dict[str, str]:
    """The text of one parameter's row of a report: ``value``, ``stderr`` (with its size relative to
    the value), ``interval`` (``[low, high]``, marked ``search box`` where it is one) and ``status``
    (``fixed``, ``fitted``). What the fit did not determine is ``n/a`` (the note says why), never
    "undetermined" beside a number that exists."""
    value = _g(parameter.value, ".6g")
    if parameter.fixed:
        return {"value": value, "stderr": "fixed", "interval": "", "status": "fixed"}
    stderr = "n/a"
    if math.isfinite(parameter.stderr):
        stderr = format(parameter.stderr, ".3g")
        if math.isfinite(parameter.value) and parameter.value != 0.0:
            stderr += f" ({100 * abs(parameter.stderr / parameter.value):.2g} %)"
    lo, hi = parameter.interval
    interval = f"[{_g(lo, '.5g')}, {_g(hi, '.5g')}]" if math.isfinite(lo) or math.isfinite(hi) else "n/a"
    if interval != "n/a" and is_search_box(parameter):
        interval += " search box"
    return {"value": value, "stderr": stderr, "interval": interval, "status": "fitted"}


def numbered_notes(result: FitResult) -> list[str]:
    """The notes of a report, each once, in order: the parameters' notes, then the result's (a
    parameter's note that is also one of the result's is listed once)."""
    notes: list[str] = []
    for note in [p.note for p in result.params.values()] + list(result.notes):
        text = " ".join(str(note).split())
        if text and text not in notes:
            notes.append(text)
    return notes


def note_reference(parameter: Parameter, notes: Sequence[str]) -> str:
    """``[k]``: the number of ``parameter``'s note among ``notes`` (:func:`numbered_notes`), "" if none."""
    text = " ".join(parameter.note.split())
    return f"[{list(notes).index(text) + 1}]" if text and text in notes else ""


def interval_header(params: Iterable[Parameter]) -> str:
    """The header of the interval column: ``95 % interval`` when every interval has that level."""
    levels = {p.confidence for p in params if not p.fixed}
    return f"{confidence_label(levels.pop())} interval" if len(levels) == 1 else "interval"


def parameter_rows(params: Iterable[Parameter], notes: Sequence[str]) -> tuple[str, list[list[str]]]:
    """The parameter table's interval column title and one row of text cells per parameter (name,
    value, standard error, interval, unit, note reference), for the text report and the HTML page;
    the confidence level is in the title (or beside each interval when they differ)."""
    params = list(params)
    header = interval_header(params)
    rows = []
    for p in params:
        cells = parameter_cells(p)
        interval = cells["interval"]
        if header == "interval" and interval not in ("", "n/a"):
            interval += f" ({confidence_label(p.confidence)})"
        rows.append([p.name, cells["value"], cells["stderr"], interval, p.unit, note_reference(p, notes)])
    return header, rows


def parameter_table_lines(params: Iterable[Parameter], notes: Sequence[str]) -> list[str]:
    """The ``[[Variables]]`` block: a header and one aligned row per parameter (name, value, standard
    error, interval, unit, note reference); the confidence level is in the header (or beside each
    interval when they differ)."""
    header, rows = parameter_rows(params, notes)
    titles = ["name", "value", "std. error", header, "unit", "note"]
    widths = [max(len(row[k]) for row in rows + [titles]) for k in range(len(titles))]
    if not any(row[5] for row in rows):  # no note column when no parameter has a note
        titles, rows, widths = titles[:5], [row[:5] for row in rows], widths[:5]

    def line(cells) -> str:
        return ("    " + "  ".join(f"{c:<{w}}" for c, w in zip(cells, widths))).rstrip()

    return ["[[Variables]]", line(titles)] + [line(row) for row in rows]


# ---- the model check and identifiability blocks ----------------------------------------------------


def model_check_lines(block: Mapping[str, Any]) -> list[str]:
    """The report's lines of a ``model_check`` block: the verdict and one line per check."""
    if not block:
        return []
    action = block.get("action", "none")
    head = f"    verdict: {block.get('verdict')}"
    if action == "widened":
        head += f" (intervals widened x {_g(block.get('inflation'))})"
    elif action == "withheld":
        head += " (standard errors and intervals withheld)"
    lines = ["[[Model Check]]", head]
    for check in block.get("checks", ()):
        unit = check.get("unit") or ""
        text = f"    {check.get('what')}: residual RMS {_g(check.get('residual_rms'))} {unit}".rstrip()
        if _finite_or_none(check.get("residual_over_noise")) is not None:
            text += (f" = {_g(check.get('residual_over_noise'))} x noise ({check.get('noise_reference')}); "
                     f"chi2 {_g(check.get('chi_square'), '.4g')} for {check.get('dof')} dof, "
                     f"p = {_g(check.get('chi_square_p_value'), '.2g')}")
        else:
            text += " (no noise reference)"
        trend = check.get("trend") or {}
        if check.get("covariate"):
            text += f"; trend with {check['covariate']} r = {_g(trend.get('correlation'), '+.2f')} " \
                    f"(p = {_g(trend.get('p_value'), '.2g')})"
        if check.get("lag1_autocorrelation") is not None:
            text += (f"; lag-1 {_g(check.get('lag1_autocorrelation'), '+.2f')}, "
                     f"n_eff {_g(check.get('effective_samples'))}")
        lines.append(text + f": {check.get('verdict')}")
    for key, value in block.items():
        if key in ("verdict", "describes_data", "action", "inflation", "checks", "rule"):
            continue
        if isinstance(value, Mapping) and "verdict" in value:
            reason = f" ({value['reason']})" if value.get("reason") else ""
            lines.append(f"    {key}: {value.get('verdict')}{reason}")
    return lines


#: Correlations a report lists (lmfit's ``min_correl``): those at least this large in magnitude.
MIN_CORRELATION = 0.1
#: At most this many correlations are listed (the strongest).
MAX_CORRELATIONS = 5


def strongest_correlations(block: Mapping[str, Any]) -> list[tuple[str, str, float]]:
    """``(a, b, r)`` of the strongest correlations of an identifiability block (``names`` and
    ``correlation``), at least :data:`MIN_CORRELATION` in magnitude, at most :data:`MAX_CORRELATIONS`,
    strongest first."""
    names = list(block.get("names") or ())
    matrix = block.get("correlation") or []
    pairs = []
    for i in range(len(names)):
        for j in range(i + 1, len(names)):
            try:
                value = float(matrix[i][j])
            except (IndexError, TypeError, ValueError):
                continue
            if math.isfinite(value) and abs(value) >= MIN_CORRELATION:
                pairs.append((names[i], names[j], value))
    return sorted(pairs, key=lambda pair: -abs(pair[2]))[:MAX_CORRELATIONS]


def identifiability_lines(block: Mapping[str, Any], indent: str = "    ") -> list[str]:
    """The report's lines of an ``identifiability`` block: conditioning, the strongest correlations,
    bounds, profiles, the law comparison with AIC, BIC and the likelihood-ratio tests (and its parts')."""
    if not block:
        return []
    lines = ["[[Identifiability]]"] if indent == "    " else []
    if "condition_number" in block:
        lines.append(f"{indent}condition number {_g(block.get('condition_number'))} (limit "
                     f"{_g(block.get('condition_limit'))}); determined: {block.get('determined')}")
        correlations = strongest_correlations(block)
        if correlations:
            lines.append(f"{indent}correlations: " + ", ".join(f"C({a}, {b}) = {r:+.4f}" for a, b, r in correlations))
        elif len(block.get("names") or ()) > 1:
            lines.append(f"{indent}correlations: all below {MIN_CORRELATION:g} in magnitude")
        profiles = block.get("profiles") or {}
        if profiles:
            lines.append(f"{indent}profiles ({str(block.get('profile_method', '')).split(':')[0]}): "
                         + ", ".join(f"{name} {p.get('shape')}" for name, p in profiles.items()))
        near = block.get("near_bounds") or []
        if near:
            lines.append(f"{indent}near bounds: " + ", ".join(
                f"{b['name']} {'on' if b.get('on_bound') else 'near'} {b['bound']}" for b in near))
    comparison = block.get("model_comparison")
    if comparison:
        models = "; ".join(f"{m.get('name')} AIC {_g(m.get('aic'), '.5g')}, BIC {_g(m.get('bic'), '.5g')}"
                           for m in comparison.get("models", ()))
        tests = "; ".join(f"{t['simple']} vs {t['general']}: LRT {_g(t.get('statistic'))} "
                          f"(p = {_g(t.get('p_value'), '.2g')})" for t in comparison.get("likelihood_ratio", ()))
        wald = comparison.get("wald")
        if wald:
            tests = "; ".join(filter(None, (f"Wald {_g(wald.get('statistic'))} (p = {_g(wald.get('p_value'), '.2g')})",
                                            tests)))
        lines.append(f"{indent}{comparison.get('choice') or 'laws'}: preferred {comparison.get('preferred')}"
                     + (f"; {tests}" if tests else ""))
        if models:
            lines.append(f"{indent}  {models}")
    for name, part in (block.get("parts") or {}).items():
        lines.append(f"{indent}{name}:")
        lines += identifiability_lines(part, indent + "  ")
    return lines

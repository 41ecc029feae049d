"""Result types shared by every fit: :class:`Parameter` and :class:`FitResult`.

Modelled on lmfit's ``Parameter`` and ``MinimizerResult``: a fit returns its parameters (each with a
value, a standard error, an interval, whether it was fixed, and a unit), fit statistics, the notes
that qualify it (what would otherwise be warnings: the result carries them, and only the top-level
call warns, once), per-event tables, and its provenance (what was read and done, with the
impactid version). Every result prints an lmfit-style ``report()``, round-trips through
``to_json()`` / ``from_json()``, gives its tables with ``to_pandas()`` and, where a figure is the
natural answer, draws one with ``plot()`` (a :class:`matplotlib.figure.Figure`, never ``pyplot``).

Non-finite numbers (an undetermined standard error, say) are legal values of a result; in JSON
they are written as ``null``, and the report says "undetermined".

A fit type subclasses :class:`FitResult`, sets ``kind`` (its name in JSON) and adds properties
and a ``plot()``; :func:`FitResult.from_json` rebuilds the right subclass from ``kind``.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any, ClassVar

import numpy as np
import pandas as pd

from impactid._version import __version__

__all__ = ["FitResult", "Parameter", "json_ready", "result_kinds"]

_KINDS: dict[str, type[FitResult]] = {}


def _finite_or_none(value):
    if value is None:
        return None
    value = float(value)
    return value if math.isfinite(value) else None


def _number(value) -> float:
    return math.nan if value is None else float(value)


def _fmt(value: float, spec: str = ".6g") -> str:
    return format(value, spec) if value is not None and math.isfinite(value) else "undetermined"


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
        """One line of a fit report: ``name: value +/- stderr (rel %) [low, high] unit``."""
        if self.fixed:
            return f"    {self.name:<{width}} {_fmt(self.value)} {self.unit}".rstrip() + " (fixed)"
        rel = ""
        if math.isfinite(self.stderr) and math.isfinite(self.value) and self.value != 0.0:
            rel = f" ({100 * abs(self.stderr / self.value):.2g} %)"
        lo, hi = self.interval
        text = (f"    {self.name:<{width}} {_fmt(self.value)} +/- {_fmt(self.stderr, '.3g')}{rel} "
                f"[{_fmt(lo)}, {_fmt(hi)}] {self.unit}").rstrip()
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
        """An lmfit-style fit report: statistics, variables, notes."""
        width = max([len(n) for n in self.params] + [8]) + 1
        lines = [f"[[{self.title}]]"]
        if self.statistics:
            lines.append("[[Fit Statistics]]")
            for key, value in self.statistics.items():
                text = _fmt(value) if isinstance(value, float) else str(value)
                lines.append(f"    {key:<22} = {text}")
        lines.append("[[Variables]]")
        lines += [p.report_line(width) for p in self.params.values()]
        if self.notes:
            lines.append("[[Notes]]")
            lines += [f"    - {note}" for note in self.notes]
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
                "details": json_ready(dict(self.details)), "provenance": list(self.provenance)}

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
                               provenance=data.get("provenance", ()), version=data.get("impactid_version", ""))

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

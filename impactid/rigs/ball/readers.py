"""Readers of bounce timings: phyphox "Acoustic stopwatch" exports, plain CSV event times, WAV audio.

One entry point, :func:`read_bounces`, recognises a file by its content (the first bytes), not only
its name, and returns a :class:`BounceRecording`: the event times [s], strictly increasing, with
what was read and done (provenance) and what qualifies it (notes). Several files are several drops
of one ball on one surface (:func:`read_many`).

Formats read
------------
* **phyphox Excel** (``.xlsx``, written by phyphox on Android; read with openpyxl through pandas;
  ``.xls``, written on iOS; read with xlrd): sheet ``All`` with the columns ``Event time (s)`` and
  ``Interval (s)``. The other sheets (``Simple``, ``Multiple``, ``Metadata Device``,
  ``Metadata Time``) are not needed.
* **phyphox CSV**: phyphox exports every sheet as one CSV file in a ZIP archive (``All.csv``, ...,
  ``meta/device.csv``, ``meta/time.csv``), or a single CSV when one set is exported. Headers are
  quoted (``"Event time (s)","Interval (s)"``), numbers are written as ``6.943541667E-1``, and the
  user picks one of five flavours: comma-separated with decimal point, tab- or semicolon-separated
  with decimal point, tab- or semicolon-separated with **decimal comma**. All are read, zipped or
  not.
* **plain CSV of event times**: one event time per line, in seconds, with or without a header;
  separated by comma, semicolon, tab or spaces when there are several columns, in which case the
  time column is the one whose header names a time (``time``, ``t``, ``event time``, ``onset``,
  ``time_s``, ...) or, without a header, the first. A unit in the header (``time (ms)``,
  ``t [s]``, ``time_ms``) is honoured (parsed by pint). A decimal comma is accepted when the
  separator is not a comma. Lines starting with ``#`` are comments.
* **WAV audio** (mono or multichannel; 8-bit unsigned, 16-, 24- and 32-bit integer, 32- and 64-bit
  float; any sample rate; read with :func:`scipy.io.wavfile.read`): the impact clicks are found by
  :func:`impactid.rigs.ball.onsets.detect_onsets`.

Every problem raises :class:`BounceFileError` with a one-line message that names the file and
the problem: missing, a folder, empty, not a spreadsheet/CSV/WAV, no ``All`` sheet, no time
column, non-numeric or NaN times, times not strictly increasing, fewer than three events, a WAV
that is silent, clipped, too short, or holds fewer than three clicks.
"""

from __future__ import annotations

import csv
import io
import math
import os
import re
import struct
import warnings
import zipfile
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from impactid.errors import ImpactidError

__all__ = ["Audio", "BounceFileError", "BounceRecording", "MIN_EVENTS", "read_audio", "read_bounces",
           "read_event_csv", "read_many", "read_phyphox", "read_wav", "time_resolution"]

#: Fewest events a file must hold: three impacts give two flights, i.e. one coefficient of restitution.
MIN_EVENTS = 3
#: Audio sample rates whose sample period event times are recognised as multiples of [Hz].
AUDIO_RATES = (8000, 11025, 16000, 22050, 24000, 32000, 44100, 48000, 88200, 96000, 176400, 192000)
#: A WAV shorter than this cannot hold three impacts of any ball we can hear bounce [s]
#: (three flights of 10 ms, i.e. bounces 0.1 mm high, are already far below audibility).
MIN_WAV_SECONDS = 0.03
#: A WAV with a larger fraction of samples at full scale is refused as clipped (overdriven input).
MAX_CLIPPED_FRACTION = 0.01

_PHYPHOX_TIME = "event time (s)"
_TIME_WORDS = ("event time", "time", "t", "times", "onset", "onsets", "onset time", "timestamp", "event")


class BounceFileError(ImpactidError, ValueError):
    """A file of bounce timings that cannot be read or used (the message names it and the problem)."""


@dataclass(frozen=True)
class Audio:
    """Audio samples as read from a WAV file.

    Attributes
    ----------
    samples : (n_samples, n_channels) float array, full scale = 1.
    sample_rate : [Hz].
    encoding : ``"int16"``, ``"int24"``, ``"int32"``, ``"uint8"``, ``"float32"``, ``"float64"``.
    source : the file read ("" if made in memory).
    """

    samples: np.ndarray
    sample_rate: float
    encoding: str = "float64"
    source: str = ""

    @property
    def n_channels(self) -> int:
        return int(self.samples.shape[1])

    @property
    def duration(self) -> float:
        """[s]"""
        return self.samples.shape[0] / self.sample_rate

    @property
    def quantum(self) -> float:
        """Smallest step of the encoding, full scale = 1."""
        return {"uint8": 2.0 ** -7, "int16": 2.0 ** -15, "int24": 2.0 ** -23, "int32": 2.0 ** -31,
                "float32": 2.0 ** -24}.get(self.encoding, 2.0 ** -53)


@dataclass(frozen=True)
class BounceRecording:
    """The impact times of one drop.

    Attributes
    ----------
    source : the file read.
    format : ``"phyphox-xlsx"``, ``"phyphox-xls"``, ``"phyphox-csv"``, ``"times-csv"``, ``"wav"``, ``"array"``.
    times : event times [s], strictly increasing.
    resolution : time step of the times [s] (e.g. 1/48000 s for phyphox), NaN when unknown.
    provenance : what was read and done, oldest first.
    notes : what qualifies the data (a disagreeing interval column, clipped clicks, ...).
    onsets : for audio, the :class:`~impactid.rigs.ball.onsets.Onsets` found (with the envelope).
    """

    source: str
    format: str
    times: np.ndarray
    resolution: float = math.nan
    provenance: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()
    onsets: object | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        times = np.array(self.times, dtype=float)
        times.setflags(write=False)
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "provenance", tuple(self.provenance))
        object.__setattr__(self, "notes", tuple(self.notes))

    @property
    def name(self) -> str:
        """The file name (without folders)."""
        return Path(self.source).name if self.source else "(array)"

    @property
    def intervals(self) -> np.ndarray:
        """Times between consecutive events [s]."""
        return np.diff(self.times)

    def with_step(self, step: str) -> BounceRecording:
        """A copy with ``step`` appended to the provenance."""
        return replace(self, provenance=self.provenance + (step,))

    @classmethod
    def from_times(cls, times: Sequence[float], source: str = "", resolution: float = math.nan) -> BounceRecording:
        """A recording from an array of event times [s] (checked as a file's would be)."""
        label = source or "(array)"
        t = _check_times(np.asarray(times, dtype=float), label, lambda i: f"event {i + 1}")
        return cls(source=source, format="array", times=t, resolution=float(resolution),
                   provenance=(f"{len(t)} event times given as an array",))


# ---- entry points -------------------------------------------------------------------------------


def read_bounces(path: str | os.PathLike[str], *, onset_options: dict | None = None) -> BounceRecording:
    """Read the impact times of one drop from a phyphox export, a CSV of times or a WAV file.

    Parameters
    ----------
    path : the file; its kind is recognised from its content (zip, OLE2, RIFF/WAVE or text).
    onset_options : keyword arguments for :func:`~impactid.rigs.ball.onsets.detect_onsets` (WAV only).

    Raises
    ------
    BounceFileError
        naming the file and the problem.
    """
    path = Path(path)
    head = _head(path)
    suffix = path.suffix.lower()
    if head.startswith(b"PK\x03\x04"):
        return _read_zip(path)
    if head.startswith(b"\xd0\xcf\x11\xe0"):
        return read_phyphox(path)
    if head[:4] == b"RIFF" and head[8:12] == b"WAVE":
        return read_wav(path, **(onset_options or {}))
    if head[:4] in (b"RIFF", b"RIFX", b"RF64"):
        raise BounceFileError(f"{path}: a RIFF file that is not a WAV audio file (or an unsupported RIFX/RF64 one)")
    if suffix in (".xlsx", ".xls", ".zip", ".wav"):
        raise BounceFileError(f"{path}: not a {suffix[1:].upper()} file (its content is not one)")
    if _looks_binary(head):
        raise BounceFileError(f"{path}: not a spreadsheet, CSV or WAV file (binary content of unknown kind)")
    return read_event_csv(path)


def read_many(paths: Iterable[str | os.PathLike[str]], **kwargs) -> list[BounceRecording]:
    """:func:`read_bounces` for each path (several drops of one ball on one surface)."""
    paths = list(paths)
    if not paths:
        raise BounceFileError("no files given")
    return [read_bounces(p, **kwargs) for p in paths]


def _head(path: Path, n: int = 4096) -> bytes:
    if not path.exists():
        raise BounceFileError(f"{path}: file not found")
    if path.is_dir():
        raise BounceFileError(f"{path}: is a directory, expected a file")
    try:
        with open(path, "rb") as fh:
            head = fh.read(n)
    except OSError as exc:
        raise BounceFileError(f"{path}: cannot read ({exc.strerror or exc})") from None
    if not head:
        raise BounceFileError(f"{path}: empty file")
    return head


def _looks_binary(head: bytes) -> bool:
    if b"\x00" in head:
        return True
    try:
        head.decode("utf-8")
        return False
    except UnicodeDecodeError as exc:
        if exc.start >= len(head) - 4:  # a multi-byte character cut at the end of the sample
            return False
    control = sum(b < 9 or 13 < b < 32 for b in head)
    return control > 0.05 * len(head)


# ---- phyphox spreadsheets -----------------------------------------------------------------------


def read_phyphox(path: str | os.PathLike[str]) -> BounceRecording:
    """Read a phyphox "Acoustic stopwatch" Excel export (``.xlsx`` or ``.xls``): sheet ``All``,
    column ``Event time (s)``."""
    path = Path(path)
    head = _head(path)
    if head.startswith(b"PK\x03\x04"):
        header, columns, sheets = _xlsx_sheet(path, "All")
        fmt = "phyphox-xlsx"
    elif head.startswith(b"\xd0\xcf\x11\xe0"):
        header, columns, sheets = _xls_sheet(path, "All")
        fmt = "phyphox-xls"
    else:
        raise BounceFileError(f"{path}: not an Excel workbook (.xlsx or .xls)")
    if header is None:
        raise BounceFileError(f"{path}: no sheet 'All' (sheets: {', '.join(sheets) or 'none'}); "
                              "expected a phyphox Acoustic stopwatch export")
    return _from_columns(path, fmt, header, columns, "sheet 'All'", row_offset=2)


def _xlsx_sheet(path: Path, name: str):
    import pandas as pd

    try:
        with pd.ExcelFile(path, engine="openpyxl") as book:
            sheets = [str(s) for s in book.sheet_names]
            if name not in sheets:
                return None, None, sheets
            frame = pd.read_excel(book, sheet_name=name, header=None, dtype=object)
    except ImportError as exc:
        raise BounceFileError(f"{path}: reading .xlsx needs openpyxl ({exc})") from None
    except zipfile.BadZipFile:
        raise BounceFileError(f"{path}: not a readable .xlsx workbook (damaged zip)") from None
    except (ValueError, KeyError, OSError, TypeError, AttributeError, IndexError) as exc:
        raise BounceFileError(f"{path}: not a readable .xlsx workbook ({_short(exc)})") from None
    except Exception as exc:  # openpyxl raises its own exception types on malformed XML
        raise BounceFileError(f"{path}: not a readable .xlsx workbook ({type(exc).__name__}: {_short(exc)})") from None
    if frame.shape[0] == 0:
        return [], [], sheets
    header = [_cell_text(v) for v in frame.iloc[0].tolist()]
    columns = [frame.iloc[1:, j].tolist() for j in range(frame.shape[1])]
    return header, columns, sheets


def _xls_sheet(path: Path, name: str):
    try:
        import xlrd
    except ImportError as exc:  # pragma: no cover - xlrd is a dependency
        raise BounceFileError(f"{path}: reading .xls needs xlrd ({exc})") from None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            book = xlrd.open_workbook(str(path), on_demand=True, logfile=io.StringIO())
    except Exception as exc:  # xlrd raises XLRDError, CompDocError, struct.error, ... on damaged files
        raise BounceFileError(f"{path}: not a readable .xls workbook ({_short(exc)})") from None
    try:
        sheets = [str(s) for s in book.sheet_names()]
        if name not in sheets:
            return None, None, sheets
        sheet = book.sheet_by_name(name)
        if sheet.nrows == 0:
            return [], [], sheets
        header = [_cell_text(v) for v in sheet.row_values(0)]
        columns = [sheet.col_values(j, start_rowx=1) for j in range(sheet.ncols)]
    except Exception as exc:
        raise BounceFileError(f"{path}: not a readable .xls workbook ({_short(exc)})") from None
    finally:
        book.release_resources()
    return header, columns, sheets


def _cell_text(value) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return ""
    return str(value).strip()


def _short(exc: BaseException) -> str:
    return " ".join(str(exc).split())[:160] or type(exc).__name__


# ---- CSV ----------------------------------------------------------------------------------------


def _read_zip(path: Path) -> BounceRecording:
    try:
        with zipfile.ZipFile(path) as archive:
            names = archive.namelist()
            if any(n.startswith("xl/") for n in names) or "[Content_Types].xml" in names:
                return read_phyphox(path)
            csvs = [n for n in names if n.lower().endswith(".csv") and not n.startswith("meta/")]
            chosen = [n for n in csvs if Path(n).name.lower() == "all.csv"] or (csvs if len(csvs) == 1 else [])
            if not chosen:
                held = ", ".join(names[:8]) or "nothing"
                raise BounceFileError(f"{path}: a zip archive without 'All.csv' (holds: {held}"
                                      f"{' ...' if len(names) > 8 else ''}); expected a phyphox CSV export")
            text = _decode(archive.read(chosen[0]), path)
    except zipfile.BadZipFile:
        raise BounceFileError(f"{path}: not a readable zip archive (damaged)") from None
    rec = _csv_text(path, text, f"{chosen[0]} in the zip")
    return rec


def read_event_csv(path: str | os.PathLike[str]) -> BounceRecording:
    """Read a phyphox CSV export (any of its five flavours) or a plain CSV of event times."""
    path = Path(path)
    _head(path)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise BounceFileError(f"{path}: cannot read ({exc.strerror or exc})") from None
    return _csv_text(path, _decode(raw, path), "")


def _decode(raw: bytes, path: Path) -> str:
    for encoding in ("utf-8-sig", "utf-16") if raw[:2] in (b"\xff\xfe", b"\xfe\xff") else ("utf-8-sig", "latin-1"):
        try:
            return raw.decode(encoding)
        except UnicodeDecodeError:
            continue
    raise BounceFileError(f"{path}: not a text file")  # pragma: no cover - latin-1 decodes anything


_NUMBER = re.compile(r"^[+-]?(\d+([.,]\d*)?|[.,]\d+)([eE][+-]?\d+)?$")


def _csv_text(path: Path, text: str, where: str) -> BounceRecording:
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    label = f"{path}" + (f" ({where})" if where else "")
    if not lines:
        raise BounceFileError(f"{label}: no data (only blank or comment lines)")
    separator = _sniff_separator(lines[:20])
    rows = _split(lines, separator)
    first_numeric = all(_NUMBER.match(c.strip().strip('"')) or c.strip().lower() in ("nan", "") for c in rows[0])
    header = None if first_numeric else [c.strip().strip('"').strip() for c in rows[0]]
    body = rows if header is None else rows[1:]
    decimal_comma = separator != "," and any("," in c for r in body[:50] for c in r)
    width = max(len(r) for r in rows)
    columns = [[r[j].strip().strip('"') if j < len(r) else "" for r in body] for j in range(width)]
    values = [[_parse_number(c, decimal_comma) for c in col] for col in columns]
    fmt = "phyphox-csv" if header and any(h.lower() == _PHYPHOX_TIME for h in header) else "times-csv"
    sep_name = {",": "comma", ";": "semicolon", "\t": "tab", None: "whitespace or none"}[separator]
    flavour = f"{sep_name}-separated, decimal {'comma' if decimal_comma else 'point'}"
    rec = _from_columns(path, fmt, header or [], values, where or "the CSV", row_offset=2 if header else 1,
                        flavour=flavour)
    return rec


def _sniff_separator(lines: list[str]) -> str | None:
    for sep in ("\t", ";", ","):
        counts = [ln.count(sep) for ln in lines]
        if counts and min(counts) > 0 and len(set(counts)) == 1:
            return sep
    for sep in ("\t", ";", ","):
        if sum(sep in ln for ln in lines) >= max(1, len(lines) // 2):
            return sep
    return None


def _split(lines: list[str], separator: str | None) -> list[list[str]]:
    if separator is None:
        rows = [ln.split() for ln in lines]
        if all(len(r) == 1 for r in rows[1:]):  # one column: the header may hold spaces ("t [ms]")
            return [[ln.strip()] for ln in lines]
        return rows
    return [row for row in csv.reader(lines, delimiter=separator)]


def _parse_number(text: str, decimal_comma: bool) -> float | str:
    t = text.strip()
    if t == "" or t.lower() in ("nan", "na", "null", "none"):
        return math.nan
    if decimal_comma:
        t = t.replace(",", ".")
    try:
        return float(t)
    except ValueError:
        return text


# ---- columns -> times ---------------------------------------------------------------------------


def _time_column(header: list[str]) -> tuple[int, float] | None:
    """Index of the time column and the factor to seconds, from the header."""
    from impactid.units import UnitError, si_factor

    candidates = []
    for j, name in enumerate(header):
        text = name.strip().lower()
        if text == _PHYPHOX_TIME:
            return j, 1.0
        match = re.match(r"^(.*?)\s*[\(\[]\s*([^\)\]]*)\s*[\)\]]\s*$", text)
        base, unit = (match.group(1).strip(), match.group(2).strip()) if match else (text, "")
        if not unit:
            m2 = re.match(r"^(.*?)[_ ](s|ms|us|µs|min)$", text)
            if m2:
                base, unit = m2.group(1), m2.group(2)
        base = base.replace("_", " ").strip()
        if base in _TIME_WORDS:
            try:
                factor = si_factor(unit or "s", "time")
            except UnitError:
                continue
            candidates.append((j, factor))
    return candidates[0] if candidates else None


def _from_columns(path: Path, fmt: str, header: list[str], columns: list[list], where: str, *,
                  row_offset: int, flavour: str = "") -> BounceRecording:
    steps = []
    if not columns or not any(len(c) for c in columns):
        raise BounceFileError(f"{path}: {where} holds no data rows")
    if header:
        found = _time_column(header)
        if found is None:
            raise BounceFileError(f"{path}: {where} has no time column (columns: "
                                  f"{', '.join(repr(h) for h in header if h) or 'unnamed'}); expected "
                                  f"'Event time (s)' or a header such as 'time' or 'time (s)'")
        j, factor = found
        name = header[j]
    else:
        j, factor, name = 0, 1.0, "column 1 (no header: seconds)"
    raw = list(columns[j])
    # trailing blank rows (and phyphox's NaN padding when all columns end) are not data
    while raw and _blank(raw[-1]) and all(len(c) < len(raw) or _blank(c[len(raw) - 1]) for c in columns):
        raw.pop()
    values = np.empty(len(raw))
    for i, v in enumerate(raw):
        if isinstance(v, str):
            parsed = _parse_number(v, decimal_comma=True)
            if isinstance(parsed, str):
                raise BounceFileError(f"{path}: {where}, row {i + row_offset}: time {v.strip()[:40]!r} is not a number")
            v = parsed
        try:
            values[i] = float(v) if v is not None and v != "" else math.nan
        except (TypeError, ValueError):
            raise BounceFileError(f"{path}: {where}, row {i + row_offset}: time {str(v)[:40]!r} is not a number"
                                  ) from None
    times = _check_times(values * factor, str(path), lambda i: f"{where}, row {i + row_offset}")
    resolution = time_resolution(times)
    unit = "" if factor == 1.0 else f" (x {factor:g} to s)"
    steps.append(f"read {len(times)} event times from {path.name}: {where}, column {name!r}{unit}"
                  + (f"; {flavour}" if flavour else "") + f" [{fmt}]")
    if math.isfinite(resolution):
        steps.append(f"event times are multiples of 1/{round(1 / resolution)} s (the recording's sample period)")
    notes = []
    if header:
        interval_note = _check_interval_column(header, columns, times, factor)
        if interval_note:
            notes.append(f"{path.name}: {interval_note}")
    return BounceRecording(source=str(path), format=fmt, times=times, resolution=resolution,
                           provenance=tuple(steps), notes=tuple(notes))


def _blank(v) -> bool:
    return v is None or (isinstance(v, str) and v.strip().lower() in ("", "nan")) or (
        isinstance(v, float) and math.isnan(v))


def _check_times(values: np.ndarray, label: str, row) -> np.ndarray:
    if values.size == 0:
        raise BounceFileError(f"{label}: no event times")
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        raise BounceFileError(f"{label}: {row(int(bad[0]))}: time is NaN or empty"
                              + (f" ({bad.size} such rows)" if bad.size > 1 else ""))
    if values.size < MIN_EVENTS:
        raise BounceFileError(f"{label}: only {values.size} event(s); at least {MIN_EVENTS} impacts are needed "
                              "for one coefficient of restitution")
    steps = np.diff(values)
    back = np.flatnonzero(steps <= 0.0)
    if back.size:
        i = int(back[0]) + 1
        raise BounceFileError(f"{label}: event times are not strictly increasing at {row(i)} "
                              f"({values[i]:.6g} s after {values[i - 1]:.6g} s)")
    return values


def _check_interval_column(header, columns, times, factor) -> str:
    idx = [j for j, h in enumerate(header) if h.strip().lower().startswith("interval")]
    if not idx:
        return ""
    col = np.array([_as_float(v) for v in columns[idx[0]][: len(times)]]) * factor
    if col.size != len(times) or not np.all(np.isfinite(col)):
        return ""
    d = np.diff(times)
    forward = np.max(np.abs(col[:-1] - d)) if d.size else 0.0
    backward = np.max(np.abs(col[1:] - d)) if d.size else 0.0
    if min(forward, backward) > 1e-6:
        return (f"its interval column disagrees with the differences of the event times (by up to "
                f"{min(forward, backward):.3g} s); the event times are used")
    return ""


def _as_float(v) -> float:
    try:
        return float(str(v).replace(",", ".")) if isinstance(v, str) else float(v)
    except (TypeError, ValueError):
        return math.nan


def time_resolution(times: np.ndarray) -> float:
    """The sample period [s] of which all ``times`` are integer multiples, among the common audio
    rates (coarsest first), or NaN."""
    times = np.asarray(times, dtype=float)
    if times.size == 0:
        return math.nan
    for rate in AUDIO_RATES:
        k = times * rate
        if np.max(np.abs(k - np.round(k))) < 1e-3 and np.max(np.abs(k)) < 2 ** 40:
            return 1.0 / rate
    return math.nan


# ---- WAV ----------------------------------------------------------------------------------------


def _wav_format(path: Path) -> tuple[int, int]:
    """(format tag, bits per sample) from the ``fmt `` chunk (0, 0 if not found)."""
    try:
        with open(path, "rb") as fh:
            data = fh.read(1 << 16)
    except OSError:
        return 0, 0
    pos = 12
    while pos + 8 <= len(data):
        cid, size = data[pos:pos + 4], struct.unpack("<I", data[pos + 4:pos + 8])[0]
        if cid == b"fmt " and pos + 24 <= len(data):
            tag, _, _, _, _, bits = struct.unpack("<HHIIHH", data[pos + 8:pos + 24])
            if tag == 0xFFFE and pos + 34 <= len(data):
                tag = struct.unpack("<H", data[pos + 32:pos + 34])[0]
            return tag, bits
        pos += 8 + size + (size & 1)
    return 0, 0


def read_audio(path: str | os.PathLike[str]) -> Audio:
    """Read a WAV file into an :class:`Audio` (float samples, full scale 1), checking that it is
    usable: not too short, not silent, not clipped, finite.

    Raises
    ------
    BounceFileError
        naming the file and the problem.
    """
    from scipy.io import wavfile

    path = Path(path)
    head = _head(path, 12)
    if not (head[:4] == b"RIFF" and head[8:12] == b"WAVE"):
        raise BounceFileError(f"{path}: not a WAV file (no RIFF/WAVE header)")
    tag, bits = _wav_format(path)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # unknown chunks: read what can be read
            rate, data = wavfile.read(path, mmap=False)
    except (ValueError, EOFError, struct.error, OSError, MemoryError, IndexError, TypeError) as exc:
        raise BounceFileError(f"{path}: not a readable WAV file ({_short(exc)})") from None
    if data.ndim == 1:
        data = data[:, None]
    if data.ndim != 2 or data.shape[1] == 0:
        raise BounceFileError(f"{path}: WAV data of unexpected shape {data.shape}")
    if rate <= 0:
        raise BounceFileError(f"{path}: WAV sample rate {rate} Hz is not positive")
    kind = data.dtype
    if kind == np.uint8:
        x, encoding, full = (data.astype(float) - 128.0) / 128.0, "uint8", 127.0 / 128.0
    elif kind == np.int16:
        x, encoding, full = data.astype(float) / 32768.0, "int16", 32767.0 / 32768.0
    elif kind == np.int32:
        x = data.astype(float) / 2.0 ** 31
        encoding = "int24" if bits == 24 else "int32"
        full = (2.0 ** 23 - 1) / 2.0 ** 23 if bits == 24 else (2.0 ** 31 - 1) / 2.0 ** 31
    elif kind in (np.float32, np.float64):
        x, encoding, full = data.astype(float), str(kind), 1.0
    elif kind == np.int64:
        x, encoding, full = data.astype(float) / 2.0 ** 63, "int64", 1.0
    else:
        raise BounceFileError(f"{path}: unsupported WAV sample type {kind}")
    n = x.shape[0]
    if n < 64 or n / rate < MIN_WAV_SECONDS:
        raise BounceFileError(f"{path}: too short ({n} samples, {n / rate:.3g} s); a drop needs at least "
                              f"{MIN_WAV_SECONDS:g} s of audio")
    if not np.all(np.isfinite(x)):
        raise BounceFileError(f"{path}: WAV holds NaN or infinite samples")
    if np.all(x == x[0:1, :]):
        raise BounceFileError(f"{path}: silent (every sample equal)")
    at_full = np.abs(x) >= full * (1.0 - 1e-9)
    fraction = float(np.mean(np.any(at_full, axis=1)))
    if fraction > MAX_CLIPPED_FRACTION:
        raise BounceFileError(f"{path}: clipped: {100 * fraction:.2g} % of the samples are at full scale "
                              f"(more than {100 * MAX_CLIPPED_FRACTION:g} %); record again with a lower input gain")
    return Audio(samples=x, sample_rate=float(rate), encoding=encoding, source=str(path))


def read_wav(path: str | os.PathLike[str], **onset_options) -> BounceRecording:
    """Read a WAV recording of a drop and find its impact clicks.

    Parameters
    ----------
    path : the WAV file.
    **onset_options : passed to :func:`~impactid.rigs.ball.onsets.detect_onsets`.
    """
    from impactid.rigs.ball.onsets import detect_onsets

    path = Path(path)
    audio = read_audio(path)
    steps = [f"read {path.name}: WAV, {audio.samples.shape[0]} samples x {audio.n_channels} channel(s), "
             f"{audio.sample_rate:g} Hz, {audio.encoding}"]
    onsets = detect_onsets(audio.samples, audio.sample_rate, quantum=audio.quantum, **onset_options)
    if onsets.times.size < MIN_EVENTS:
        raise BounceFileError(f"{path}: found {onsets.times.size} impact click(s) above the noise floor "
                              f"(threshold {onsets.threshold:.3g} full scale); at least {MIN_EVENTS} are needed")
    steps.append(onsets.describe())
    notes = [f"{path.name}: {n}" for n in onsets.notes]
    clipped = int(np.sum(np.any(np.abs(audio.samples) >= 1.0 - 2 * audio.quantum, axis=1)))
    if clipped:
        notes.append(f"{path.name}: {clipped} samples at full scale (clipped click peaks); onset times come from "
                     "the rising edge of each click and are not affected")
    return BounceRecording(source=str(path), format="wav", times=onsets.times, resolution=math.nan,
                           provenance=tuple(steps), notes=tuple(notes), onsets=onsets)

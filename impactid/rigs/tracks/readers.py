"""Readers of ball tracks: positions against time from video (Tracker), phones (phyphox-like
exports), motion capture and stereo cameras (plain CSV/TSV), into one :class:`Track`.

What is read (docs/tracks.md, "Formats"):

* **Tracker** (physlets Tracker, "Export Data"): tab- or comma-separated text, an optional first
  line naming the track (``mass A``), a header of column names (``t``, ``x``, ``y``, ...) and the
  rows; empty cells (frames without a mark) are skipped; decimal commas are read when the cells are
  not comma-separated.
* **phyphox-like and spreadsheet CSV/TSV**: a header whose names carry their units, ``Time (s)``,
  ``x (mm)``, ``Position z [m]``, ``t/ms``.
* **plain numeric tables without a header**: three columns ``t, x, y`` (a 2-D track, ``y`` up) or
  four ``t, x, y, z`` (3-D, ``z`` up), separated by commas, semicolons, tabs or spaces; the
  table-tennis trajectories of Gossard et al. (2023, SpinDOE) are of this kind, with the spin of each
  trajectory in an ``index.csv`` beside them (``traj_file,x_spin,y_spin,z_spin`` [rad/s], the
  trajectory's number in ``traj_file``), which is read when present.

Columns are found by name (``t``/``time``; ``x``, ``y``, ``z``, alone or with ``position``/``pos``)
or chosen by name or 1-based number (``time=``, ``x=``, ``y=``, ``z=``). Units come from the header,
else from ``length_unit`` and ``time_unit`` (default metres and seconds, said in the track's notes).
Inside, a track is always 3-D with ``z`` up (right-handed): a 2-D track is the plane ``y = 0``; a 3-D
track whose vertical axis is ``x`` or ``y`` (``up=``) is turned cyclically so that it becomes ``z``.
Every error is a :class:`TrackFileError` naming the file and, where one is at fault, the column.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from impactid.errors import ImpactidError

__all__ = ["LENGTH_UNITS", "MIN_SAMPLES", "TIME_UNITS", "Track", "TrackFileError", "is_spin_index", "read_spin_index",
           "read_track"]

#: Length units a header or ``length_unit`` may name -> metres.
LENGTH_UNITS = {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "um": 1e-6, "in": 0.0254, "inch": 0.0254, "ft": 0.3048,
                "px": math.nan}
#: Time units -> seconds.
TIME_UNITS = {"s": 1.0, "sec": 1.0, "ms": 1e-3, "us": 1e-6, "min": 60.0}
#: Fewest samples a track may have.
MIN_SAMPLES = 10
#: The largest file read [bytes].
MAX_BYTES = 200_000_000

_AXES = ("x", "y", "z")
_TIME_NAMES = {"t", "time", "zeit", "timestamp", "time stamp"}
_POSITION_WORDS = {"position", "pos", "coordinate", "ball", "centre", "center", "p"}
_UNIT = re.compile(r"^(?P<name>.*?)\s*(?:\((?P<u1>[^()]*)\)|\[(?P<u2>[^\[\]]*)\]|/\s*(?P<u3>[A-Za-z]+))\s*$")


class TrackFileError(ImpactidError, ValueError):
    """A track file that cannot be read (the message names the file and, where one is at fault, the column)."""


@dataclass(frozen=True)
class Track:
    """One ball track, in SI units, ``z`` up.

    Attributes
    ----------
    source : where it was read from.
    time : (n,) sample times, strictly increasing [s].
    position : (n, 3) ball centre [m]; for a 2-D track the ``y`` column is 0.
    dimensions : 2 or 3.
    spin : the ball's spin ``(wx, wy, wz)`` [rad/s] in the same frame, or None when not known.
    columns : the file's columns read as ``t``, ``x``, ``y``, ``z`` (in the internal axes' order).
    name : the track's name (Tracker's first line, or the file's stem).
    notes : what was done while reading (rows dropped, units assumed).
    """

    source: str
    time: np.ndarray
    position: np.ndarray
    dimensions: int
    spin: tuple[float, float, float] | None = None
    columns: tuple[str, ...] = ()
    name: str = ""
    notes: tuple[str, ...] = field(default=())

    @property
    def height(self) -> np.ndarray:
        """(n,) the vertical coordinate [m]."""
        return self.position[:, 2]

    def with_spin(self, spin) -> Track:
        """A copy with the spin given (``(wx, wy, wz)`` [rad/s], or None)."""
        return replace(self, spin=None if spin is None else tuple(float(s) for s in spin))


def _split_unit(text: str) -> tuple[str, str]:
    text = text.strip().strip('"').strip("'").strip()
    m = _UNIT.match(text)
    if m and m.group("name"):
        unit = m.group("u1") if m.group("u1") is not None else (m.group("u2") if m.group("u2") is not None
                                                                 else m.group("u3"))
        return m.group("name").strip(), unit.strip()
    return text, ""


def _role(name: str) -> str | None:
    """``t``, ``x``, ``y``, ``z`` or None for a column name without its unit."""
    key = name.lower().replace("_", " ").replace("-", " ").strip()
    if key in _TIME_NAMES:
        return "t"
    if key in _AXES:
        return key
    words = key.split()
    if len(words) == 2:
        for axis in _AXES:
            if axis in words and (set(words) - {axis}) <= _POSITION_WORDS:
                return axis
    return None


def _number(cell: str, decimal_comma: bool) -> float:
    cell = cell.strip().strip('"')
    if cell == "" or cell.lower() in ("nan", "na", "null", "-"):
        return math.nan
    if decimal_comma:
        cell = cell.replace(",", ".")
    return float(cell)


def _delimiter(line: str) -> str | None:
    for sep in ("\t", ";", ","):
        if sep in line:
            return sep
    return None


def _cells(line: str, sep: str | None) -> list[str]:
    return line.split(sep) if sep is not None else line.split()


def _is_numeric(cells: list[str], decimal_comma: bool) -> bool:
    try:
        [_number(c, decimal_comma) for c in cells]
    except ValueError:
        return False
    return True


def _pick(spec: str | int | None, names: list[str], path: str, option: str) -> int | None:
    """The index of the column ``spec`` names (a name, with or without its unit, or a 1-based number)."""
    if spec is None:
        return None
    text = str(spec).strip()
    if text.isdigit():
        index = int(text) - 1
        if not 0 <= index < len(names):
            raise TrackFileError(f"{path}: {option} {text}: the file has {len(names)} columns")
        return index
    wanted = text.lower()
    for i, name in enumerate(names):
        bare, _ = _split_unit(name)
        if wanted in (name.strip().strip('"').lower(), bare.lower()):
            return i
    shown = ", ".join(repr(n.strip().strip('"')) for n in names) or "none (no header)"
    raise TrackFileError(f"{path}: {option} {text!r}: no such column; columns: {shown}")


def _unit_factor(unit: str, table: dict, path: str, column: str, what: str) -> float:
    key = unit.strip().lower().replace("µ", "u")
    if key not in table or not math.isfinite(table[key]):
        why = "pixels: calibrate the track (Tracker's calibration stick) or give --units" if key == "px" else \
            f"valid: {', '.join(k for k, v in table.items() if math.isfinite(v))}"
        raise TrackFileError(f"{path}: column {column!r}: unknown {what} unit {unit!r} ({why})")
    return table[key]


def read_spin_index(path: str | Path) -> dict[str, tuple[float, float, float]]:
    """The spins of a SpinDOE-like ``index.csv``: ``traj_file,x_spin,y_spin,z_spin`` [rad/s] -> by the
    trajectory's number as text (``"7"`` for ``007.csv``)."""
    path = Path(path)
    try:
        lines = [ln for ln in path.read_text(encoding="utf-8-sig").splitlines() if ln.strip()]
    except (OSError, UnicodeDecodeError) as exc:
        raise TrackFileError(f"{path}: cannot read the spin index ({exc.__class__.__name__})") from None
    header = [c.strip().lower() for c in lines[0].split(",")] if lines else []
    needed = ("traj_file", "x_spin", "y_spin", "z_spin")
    if not all(n in header for n in needed):
        raise TrackFileError(f"{path}: a spin index needs the columns {', '.join(needed)}")
    cols = [header.index(n) for n in needed]
    out = {}
    for k, line in enumerate(lines[1:], start=2):
        cells = line.split(",")
        try:
            key = str(int(float(cells[cols[0]])))
            out[key] = tuple(float(cells[c]) for c in cols[1:])
        except (ValueError, IndexError):
            raise TrackFileError(f"{path}: line {k}: not a trajectory number and three spins") from None
    return out


def is_spin_index(path: str | Path) -> bool:
    """Whether ``path`` is a spin index (its first line names ``traj_file`` and ``x_spin``)."""
    try:
        with open(path, encoding="utf-8-sig", errors="replace") as handle:
            first = handle.readline(4096).lower()
    except OSError:
        return False
    return "traj_file" in first and "x_spin" in first


def _sidecar_spin(path: Path) -> tuple[float, float, float] | None:
    index = path.with_name("index.csv")
    if path.name == "index.csv" or not index.is_file():
        return None
    try:
        key = str(int(path.stem))
    except ValueError:
        return None
    return read_spin_index(index).get(key)


def read_track(path: str | Path, *, time: str | int | None = None, x: str | int | None = None,
               y: str | int | None = None, z: str | int | None = None, up: str | None = None,
               length_unit: str | None = None, time_unit: str | None = None,
               spin: tuple[float, ...] | None = None) -> Track:
    """Read one track (module doc for the formats).

    Parameters
    ----------
    path : the file.
    time, x, y, z : the columns to read (a name, with or without its unit, or a 1-based number);
        None: found by name, or by position in a table without a header.
    up : the file's vertical axis (``"x"``, ``"y"`` or ``"z"``); default ``z`` for a 3-D track and
        ``y`` for a 2-D one.
    length_unit, time_unit : the units of columns whose header names none (``"mm"``, ``"ms"``); a
        unit in the header wins unless these are given.
    spin : the spin [rad/s] in the file's axes: three components, or one for a 2-D track (about the
        axis out of the plane, counter-clockwise positive seen with ``x`` right and the vertical up);
        None: the ``index.csv`` beside the file where it names the track, else unknown.

    Raises
    ------
    TrackFileError
        naming the file and the column at fault.
    """
    path = Path(path)
    where = str(path)
    if not path.is_file():
        raise TrackFileError(f"{where}: no such file" if not path.exists() else f"{where}: not a regular file")
    if path.stat().st_size > MAX_BYTES:
        raise TrackFileError(f"{where}: larger than {MAX_BYTES // 1_000_000} MB; not a track")
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError:
        raise TrackFileError(f"{where}: not a text table (Tracker, CSV or TSV of t, x, y[, z])") from None
    except OSError as exc:
        raise TrackFileError(f"{where}: cannot read ({exc.strerror or exc.__class__.__name__})") from None
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise TrackFileError(f"{where}: empty")
    notes = []
    # the delimiter of the data: the first line whose cells are all numbers with it
    first_data = None
    for k, line in enumerate(lines[:50]):
        sep = _delimiter(line)
        cells = _cells(line, sep)
        if len(cells) >= 3 and (_is_numeric(cells, False) or (sep != "," and _is_numeric(cells, True))):
            first_data = k
            break
    if first_data is None:
        raise TrackFileError(f"{where}: no rows of numbers (a table of t, x, y[, z] with at least three columns)")
    sep = _delimiter(lines[first_data])
    decimal_comma = sep != "," and not _is_numeric(_cells(lines[first_data], sep), False)
    width = len(_cells(lines[first_data], sep))
    header: list[str] = []
    name = path.stem
    if first_data >= 1:
        header = [c.strip() for c in _cells(lines[first_data - 1], sep)]
        if len(header) != width:
            raise TrackFileError(f"{where}: the header has {len(header)} columns, the rows {width}")
        if first_data >= 2:
            name = lines[first_data - 2].strip().strip('"') or name
    names = header or [f"column {i + 1}" for i in range(width)]
    rows = []
    for k, line in enumerate(lines[first_data:], start=first_data + 1):
        cells = _cells(line, sep)
        if len(cells) < width:
            cells = cells + [""] * (width - len(cells))
        try:
            rows.append([_number(c, decimal_comma) for c in cells[:width]])
        except ValueError:
            raise TrackFileError(f"{where}: row {k}: not numbers ({line.strip()[:60]!r})") from None
    table = np.asarray(rows, dtype=float)
    # which columns
    chosen = {"t": _pick(time, names, where, "--time"), "x": _pick(x, names, where, "--x"),
              "y": _pick(y, names, where, "--y"), "z": _pick(z, names, where, "--z")}
    if header:
        roles = {i: _role(_split_unit(h)[0]) for i, h in enumerate(header)}
        for key in chosen:
            if chosen[key] is None:
                found = [i for i, r in roles.items() if r == key and i not in chosen.values()]
                chosen[key] = found[0] if found else None
    elif all(v is None for v in chosen.values()):
        if width == 3:
            chosen.update(t=0, x=1, y=2)
        elif width == 4:
            chosen.update(t=0, x=1, y=2, z=3)
        else:
            raise TrackFileError(f"{where}: {width} columns without a header: name them with --time, --x, --y "
                                 f"[--z] (three columns read as t, x, y; four as t, x, y, z)")
    if chosen["t"] is None:
        raise TrackFileError(f"{where}: no time column (named t or time; or choose it with --time); columns: "
                             + ", ".join(names))
    axes = [a for a in _AXES if chosen[a] is not None]
    if len(axes) < 2:
        raise TrackFileError(f"{where}: needs two or three position columns (x, y[, z]; or --x, --y, --z); found "
                             + (", ".join(axes) or "none"))
    dims = len(axes)
    vertical = (up or ("z" if dims == 3 else axes[-1])).lower()
    if vertical not in axes:
        raise TrackFileError(f"{where}: --up {vertical}: the track has no {vertical} column (it has "
                             f"{', '.join(axes)})")
    # units
    def factor(key: str) -> float:
        col = chosen[key]
        unit = _split_unit(header[col])[1] if header else ""
        table_, given = (TIME_UNITS, time_unit) if key == "t" else (LENGTH_UNITS, length_unit)
        what = "time" if key == "t" else "length"
        if given is not None:
            return _unit_factor(given, table_, where, names[col].strip(), what)
        if unit:
            return _unit_factor(unit, table_, where, names[col].strip(), what)
        return 1.0

    if header and length_unit is None and not any(_split_unit(header[chosen[a]])[1] for a in axes):
        notes.append("no length unit in the header nor given: metres assumed")
    t = table[:, chosen["t"]] * factor("t")
    cols = {a: table[:, chosen[a]] * factor(a) for a in axes}
    if dims == 3:
        order = {"z": ("x", "y", "z"), "y": ("z", "x", "y"), "x": ("y", "z", "x")}[vertical]
        pos = np.column_stack([cols[a] for a in order])
        used = tuple(names[chosen[k]].strip() for k in ("t", *order))
    else:
        horizontal = [a for a in axes if a != vertical][0]
        pos = np.column_stack([cols[horizontal], np.zeros_like(t), cols[vertical]])
        used = (names[chosen["t"]].strip(), names[chosen[horizontal]].strip(), names[chosen[vertical]].strip())
    good = np.isfinite(t) & np.all(np.isfinite(pos), axis=1)
    if not np.all(good):
        notes.append(f"{int(np.sum(~good))} rows without a time or a position skipped")
        t, pos = t[good], pos[good]
    if t.size and np.any(np.diff(t) < 0):
        k = int(np.argmax(np.diff(t) < 0))
        raise TrackFileError(f"{where}: column {used[0]!r}: time goes back at row {k + 2} ({t[k]:g} s then "
                             f"{t[k + 1]:g} s)")
    repeat = np.concatenate([[False], np.diff(t) == 0])
    if np.any(repeat):
        notes.append(f"{int(np.sum(repeat))} samples at the time of the previous one skipped")
        t, pos = t[~repeat], pos[~repeat]
    if t.size < MIN_SAMPLES:
        raise TrackFileError(f"{where}: {t.size} samples; a track needs at least {MIN_SAMPLES}")
    # spin
    spin_vec = None
    if spin is not None:
        values = [float(s) for s in spin]
        if dims == 2:
            if len(values) != 1:
                raise TrackFileError(f"{where}: a 2-D track takes one spin (about the axis out of its plane)")
            spin_vec = (0.0, -values[0], 0.0)  # x right, z up: out of the plane is -y
        else:
            if len(values) != 3:
                raise TrackFileError(f"{where}: a 3-D track takes three spin components")
            spin_vec = _turned(values, vertical)
    elif dims == 3:
        found = _sidecar_spin(path)
        if found is not None:
            spin_vec = _turned(list(found), vertical)
            notes.append(f"spin read from {path.with_name('index.csv').name}")
    return Track(source=where, time=t, position=pos, dimensions=dims, spin=spin_vec, columns=used, name=name,
                 notes=tuple(notes))


def _turned(values: list[float], vertical: str) -> tuple[float, float, float]:
    wx, wy, wz = values
    turned = {"z": (wx, wy, wz), "y": (wz, wx, wy), "x": (wy, wz, wx)}[vertical]
    return tuple(float(v) for v in turned)

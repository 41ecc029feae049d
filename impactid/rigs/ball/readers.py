"""Readers of bounce timings: phyphox "Acoustic stopwatch" exports, plain CSV event times, audio.

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
* **audio**: WAV (RIFF/WAVE, or RF64 beyond 4 GiB), FLAC, OGG (Vorbis, Opus); mono or
  multichannel; 8-bit, 16-, 24- and 32-bit integer, 32- and 64-bit float; any sample rate above
  :func:`~impactid.rigs.ball.onsets.min_sample_rate`, 1778 Hz. Read with :mod:`soundfile`
  (libsndfile, bundled in its wheels): the header gives the frames, channels, rate and sample type
  before a sample is read (the memory check), then the samples are read in their own width and
  scanned in blocks. Where soundfile cannot be imported (a platform without its wheel and without a
  system libsndfile), WAV is read by :func:`scipy.io.wavfile.read`, memory-mapped, and FLAC and OGG
  are refused naming the package. The impact clicks are found by
  :func:`impactid.rigs.ball.onsets.detect_onsets`.

Every problem raises :class:`BounceFileError` with a one-line message that names the file and
the problem: missing, a folder or a special file (a named pipe, device or socket is never opened:
it could block forever), empty, not a spreadsheet/CSV/audio file, no ``All`` sheet, no time column,
non-numeric or NaN times, times not strictly increasing, fewer than three events, more than
:data:`~impactid.rigs.ball.sequence.MAX_EVENTS`, times that no drop can have (beyond
:data:`MAX_TIME_MAGNITUDE` in magnitude or spanning more than :data:`MAX_EVENT_SPAN`), times in
another unit than the one read (a median interval longer than :data:`MAX_TYPICAL_FLIGHT` or shorter
than :data:`MIN_TYPICAL_FLIGHT`: the message names the column and the header that would say the
unit), a table larger than :data:`MAX_TABLE_BYTES`, audio that is truncated (shorter than its header
says), needs more memory than :func:`memory_budget` allows, is sampled too slowly for the detector,
is silent, clipped, too short, or holds fewer than three clicks. These checks come before any numerics.
"""

from __future__ import annotations

import csv
import io
import math
import os
import re
import stat
import struct
import warnings
import zipfile
import zlib
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.io import wavfile

from impactid._files import check_distinct_inputs
from impactid.errors import ImpactidError
from impactid.rigs.ball.onsets import DEFAULT_BAND, detect_onsets, memory_needed, min_sample_rate
from impactid.rigs.ball.sequence import MAX_EVENTS
from impactid.units import UnitError, si_factor

try:  # libsndfile through soundfile (a dependency; its wheels bundle the library): WAV, FLAC, OGG
    import soundfile
except (ImportError, OSError) as _exc:  # OSError: its pure-Python wheel on a platform without a libsndfile
    soundfile = None
    _SOUNDFILE_PROBLEM = f"{type(_exc).__name__}: {_exc}"
else:
    _SOUNDFILE_PROBLEM = ""

__all__ = ["Audio", "BounceFileError", "BounceRecording", "MAX_EVENTS", "MAX_EVENT_SPAN", "MAX_MEMORY",
           "MAX_TABLE_BYTES", "MAX_TIME_MAGNITUDE", "MAX_TYPICAL_FLIGHT", "MIN_EVENTS", "MIN_TYPICAL_FLIGHT",
           "check_file", "check_files", "memory_budget", "read_audio", "read_bounces", "read_event_csv", "read_many",
           "read_drops", "read_phyphox", "read_wav", "time_resolution", "audio_kind", "AUDIO_KINDS"]

#: Fewest events a file must hold: three impacts give two flights, i.e. one coefficient of restitution.
MIN_EVENTS = 3
#: Audio sample rates whose sample period event times are recognised as multiples of [Hz].
AUDIO_RATES = (8000, 11025, 16000, 22050, 24000, 32000, 44100, 48000, 88200, 96000, 176400, 192000)
#: A WAV shorter than this cannot hold three impacts of any ball we can hear bounce [s]
#: (three flights of 10 ms, i.e. bounces 0.1 mm high, are already far below audibility).
MIN_WAV_SECONDS = 0.03
#: A WAV with a larger fraction of samples at full scale is refused as clipped (overdriven input).
MAX_CLIPPED_FRACTION = 0.01
#: Largest magnitude of an event time [s]. 1e10 s (317 years) admits clock times such as Unix
#: timestamps (1.7e9 s), which a double still resolves to 2 us, finer than any trigger; larger
#: numbers are not the times of a drop, and their squares and cubes (which the cleaning fits)
#: overflow: times of 1e300 s once sent LAPACK into an endless loop that not even SIGTERM stopped.
MAX_TIME_MAGNITUDE = 1e10
#: Longest time from the first to the last event of one drop [s]. A drop bounces for under a minute
#: (a ball dropped from 10 m with e = 0.95 bounces for about 55 s); an hour leaves room for a
#: recording started long before the drop or stopped long after it.
MAX_EVENT_SPAN = 3600.0
#: Longest typical flight [s]: the median interval between the events of a drop must be shorter. A
#: flight of 10 s is a bounce 120 m high, ending at g T / 2 = 49 m/s: beyond any ball dropped by
#: hand and above the terminal speed of common balls (table tennis 9 m/s, tennis 20, golf 30).
#: Longer intervals mean that the times are not in the unit they were read in (milliseconds read
#: as seconds make every flight 1000 times longer and every impact 1000 times faster).
MAX_TYPICAL_FLIGHT = 10.0
#: Shortest typical flight [s]: a median interval of 1 ms is a bounce 1.2 um high at 5 mm/s, far
#: below any audible bounce (seconds read as milliseconds make flights 1000 times shorter).
MIN_TYPICAL_FLIGHT = 1e-3
#: Largest table of event times (CSV text, an uncompressed spreadsheet, an .xls file) [bytes].
#: :data:`~impactid.rigs.ball.sequence.MAX_EVENTS` rows of a phyphox export take under 100 kB;
#: 32 MiB is hundreds of times that, and its parse stays within a few hundred MiB of memory.
MAX_TABLE_BYTES = 32 * 2 ** 20
#: Most columns a table of bounce times may have: a time, an interval, a few quantities, or one
#: column per trial of a lab's table of several drops; not a row of millions of fields.
MAX_COLUMNS = 256
#: Most memory one input may need while it is analysed [bytes], when the system has twice as much
#: available (:func:`memory_budget`). The audio of a drop lasts seconds to a minute and needs a few
#: tens of MiB; 2 GiB admits about an hour and a half of 48 kHz audio (8 bytes a frame) and keeps a
#: job on a shared machine from taking all of its memory.
MAX_MEMORY = 2 * 2 ** 30
#: Frames of audio checked at a time.
_SCAN_FRAMES = 1 << 18

_PHYPHOX_TIME = "event time (s)"
_TIME_WORDS = ("event time", "time", "t", "times", "onset", "onsets", "onset time", "timestamp", "event")


class BounceFileError(ImpactidError, ValueError):
    """A file of bounce timings that cannot be read or used (the message names it and the problem)."""


@dataclass(frozen=True)
class Audio:
    """Audio samples as read from an audio file, in their own width (never converted whole).

    Attributes
    ----------
    samples : (n_samples, n_channels) array: floats at full scale 1, or integers (16-bit samples
        as int16, 24- and 32-bit ones as int32; a memory map of a WAV file when read by
        :mod:`scipy.io.wavfile`); a sample at full scale is ``(stored - offset) * scale``
        (:meth:`block` does the conversion a block at a time).
    sample_rate : [Hz].
    encoding : the file's samples: ``"uint8"``, ``"int8"``, ``"int16"``, ``"int24"``, ``"int32"``,
        ``"float32"``, ``"float64"``, or the lossy codec's name (``"vorbis"``, ``"opus"``), decoded to
        float32.
    source : the file read ("" if made in memory).
    scale : full-scale value of one stored unit (``2**-15`` for int16, ``2**-31`` for int32, 1 for floats).
    offset : stored value of silence (128 for 8-bit WAV read by scipy, else 0).
    format : the container, ``"WAV"``, ``"FLAC"`` or ``"OGG"`` ("" if made in memory).
    reader : the library that read the samples, with its version.
    """

    samples: np.ndarray
    sample_rate: float
    encoding: str = "float64"
    source: str = ""
    scale: float = 1.0
    offset: float = 0.0
    format: str = ""
    reader: str = ""

    def __post_init__(self) -> None:
        samples = self.samples if getattr(self.samples, "ndim", 0) else np.asarray(self.samples)
        if samples.ndim == 1:
            object.__setattr__(self, "samples", samples.reshape(-1, 1))

    @property
    def n_channels(self) -> int:
        return int(self.samples.shape[1])

    @property
    def n_frames(self) -> int:
        return int(self.samples.shape[0])

    @property
    def duration(self) -> float:
        """[s]"""
        return self.samples.shape[0] / self.sample_rate

    @property
    def quantum(self) -> float:
        """Smallest step of the encoding, full scale = 1."""
        return {"uint8": 2.0 ** -7, "int8": 2.0 ** -7, "int16": 2.0 ** -15, "int24": 2.0 ** -23,
                "int32": 2.0 ** -31, "float64": 2.0 ** -53}.get(self.encoding, 2.0 ** -24)

    def block(self, start: int = 0, stop: int | None = None) -> np.ndarray:
        """Frames ``start:stop`` as a (frames, channels) float array at full scale 1."""
        return (np.asarray(self.samples[start:stop], dtype=float) - self.offset) * self.scale

    def blocks(self, frames: int = _SCAN_FRAMES) -> Iterator[np.ndarray]:
        """The recording as consecutive :meth:`block` of ``frames`` frames."""
        for start in range(0, self.n_frames, frames):
            yield self.block(start, start + frames)

    def frames_at_or_above(self, level: float) -> int:
        """Number of frames with a channel whose magnitude reaches ``level`` [full scale]."""
        return sum(int(np.count_nonzero(np.any(np.abs(x) >= level, axis=1))) for x in self.blocks())


@dataclass(frozen=True)
class BounceRecording:
    """The impact times of one drop.

    Attributes
    ----------
    source : the file read.
    format : ``"phyphox-xlsx"``, ``"phyphox-xls"``, ``"phyphox-csv"``, ``"times-csv"``, ``"table-csv"``,
        ``"table-xlsx"``, ``"table-xls"``, ``"wav"``, ``"flac"``, ``"ogg"``, ``"array"``.
    times : event times [s], strictly increasing.
    resolution : time step of the times [s] (e.g. 1/48000 s for phyphox), NaN when unknown.
    provenance : what was read and done, oldest first.
    notes : what qualifies the data (a disagreeing interval column, clipped clicks, ...).
    onsets : for audio, the :class:`~impactid.rigs.ball.onsets.Onsets` found (with the envelope).
    trial : for one trial of a table of several drops (:func:`read_drops`), its name (the column's
        header, the sheet's name, or ``column <j>``); "" for a file of one drop.
    """

    source: str
    format: str
    times: np.ndarray
    resolution: float = math.nan
    provenance: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()
    onsets: object | None = field(default=None, repr=False)
    trial: str = ""

    def __post_init__(self) -> None:
        times = np.array(self.times, dtype=float)
        times.setflags(write=False)
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "provenance", tuple(self.provenance))
        object.__setattr__(self, "notes", tuple(self.notes))

    @property
    def name(self) -> str:
        """The file name (without folders), and the trial in brackets for a table of several drops."""
        name = Path(self.source).name if self.source else "(array)"
        return f"{name} [{self.trial}]" if self.trial else name

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
        _check_scale(t, label, "the event times", factor=1.0, base=None)
        return cls(source=source, format="array", times=t, resolution=float(resolution),
                   provenance=(f"{len(t)} event times given as an array",))


# ---- entry points -------------------------------------------------------------------------------


def read_bounces(path: str | os.PathLike[str], *, onset_options: dict | None = None) -> BounceRecording:
    """Read the impact times of one drop from a phyphox export, a CSV of times or audio (WAV, FLAC, OGG).

    Parameters
    ----------
    path : the file; its kind is recognised from its content (zip, OLE2, RIFF/WAVE, FLAC, Ogg or text).
    onset_options : keyword arguments for :func:`~impactid.rigs.ball.onsets.detect_onsets` (audio only).

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
    if audio_kind(head) is not None:
        return read_wav(path, **(onset_options or {}))
    if head[:4] in (b"RIFF", b"RIFX", b"RF64"):
        raise BounceFileError(f"{path}: a RIFF file that is not a WAV audio file (or an unsupported big-endian RIFX "
                              "one)")
    if suffix in (".xlsx", ".xls", ".zip") or suffix in _AUDIO_SUFFIXES:
        what = _AUDIO_SUFFIXES.get(suffix, suffix[1:].upper())
        raise BounceFileError(f"{path}: not a {what} file (its content is not one)")
    if _looks_binary(head):
        raise BounceFileError(f"{path}: not a spreadsheet, CSV or audio file (binary content of unknown kind)")
    return read_event_csv(path)


def read_many(paths: Iterable[str | os.PathLike[str]], **kwargs) -> list[BounceRecording]:
    """:func:`read_bounces` for each path (several drops of one ball on one surface).

    Raises
    ------
    BounceFileError
        a file cannot be read.
    DuplicateInputError
        one recording given twice (by two names, or two files with the same bytes): its impacts
        would count twice.
    """
    paths = list(paths)
    if not paths:
        raise BounceFileError("no files given")
    check_files(paths)
    return [read_bounces(p, **kwargs) for p in paths]


def check_files(paths: Sequence[str | os.PathLike[str]]) -> None:
    """Check the input files of one job before any is opened: each must be a regular file
    (:func:`check_file`) and none may be given twice (by two names, or as two files with the same
    bytes: :func:`impactid._files.check_distinct_inputs`). Only files whose size another input
    shares can be the same, so only they are compared (and hashed): a large recording of a size of
    its own is never read twice.

    Raises
    ------
    BounceFileError
        a file is missing, a directory or a special file.
    DuplicateInputError
        one recording given twice.
    """
    sizes = [check_file(p).st_size for p in paths]
    shared = [p for p, size in zip(paths, sizes) if sizes.count(size) > 1]
    check_distinct_inputs(shared, what="recording")


_SPECIAL_KINDS = ((stat.S_ISFIFO, "a named pipe (FIFO)"), (stat.S_ISCHR, "a character device"),
                  (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))


def _kind_error(path: Path, mode: int) -> BounceFileError | None:
    if stat.S_ISDIR(mode):
        return BounceFileError(f"{path}: is a directory, expected a file")
    if not stat.S_ISREG(mode):
        kind = next((name for test, name in _SPECIAL_KINDS if test(mode)), "a special file")
        return BounceFileError(f"{path}: is {kind}, not a file of bounce times; refusing to read it (reading it "
                               "could wait forever)")
    return None


def check_file(path: str | os.PathLike[str]) -> os.stat_result:
    """Check, without opening it, that ``path`` is an existing regular file (a symbolic link to one
    is fine); returns its status.

    Raises
    ------
    BounceFileError
        naming the file: not found, a directory, or a special file (a named pipe, a device or a
        socket, which could block a reader forever).
    """
    path = Path(path)
    try:
        status = os.stat(path)
    except (FileNotFoundError, NotADirectoryError):
        raise BounceFileError(f"{path}: file not found") from None
    except ValueError:  # a NUL byte in the name
        raise BounceFileError(f"{str(path)!r}: not a valid file name") from None
    except OSError as exc:
        raise BounceFileError(f"{path}: cannot read ({exc.strerror or exc})") from None
    problem = _kind_error(path, status.st_mode)
    if problem is not None:
        raise problem
    return status


def _head(path: Path, n: int = 4096) -> bytes:
    check_file(path)
    try:
        # O_NONBLOCK: should the file have been replaced by a named pipe since the check, opening it
        # returns at once instead of waiting for a writer; it is then refused by its status
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
        with os.fdopen(fd, "rb") as fh:
            problem = _kind_error(path, os.fstat(fh.fileno()).st_mode)
            if problem is not None:
                raise problem
            head = fh.read(n)
    except OSError as exc:
        raise BounceFileError(f"{path}: cannot read ({exc.strerror or exc})") from None
    if not head:
        raise BounceFileError(f"{path}: empty file")
    return head


def _too_large(path: Path, size: int, what: str) -> BounceFileError:
    return BounceFileError(f"{path}: {what} of {size / 2 ** 20:.1f} MiB, more than the {MAX_TABLE_BYTES / 2 ** 20:g} "
                           f"MiB a table of bounce times may take (the {MAX_EVENTS} events one drop can hold take "
                           "under 100 kB); refusing to parse it")


def _available_memory() -> int | None:
    """Memory the system reports available [bytes] (MemAvailable, within a cgroup's limit), or None."""
    available = None
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    available = int(line.split()[1]) * 1024
                    break
    except (OSError, ValueError, IndexError):
        pass
    if available is None:
        try:
            available = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        except (AttributeError, ValueError, OSError):
            available = None
    try:  # a container's own limit (cgroup v2)
        limit = Path("/sys/fs/cgroup/memory.max").read_text().strip()
        if limit.isdigit():
            used = int(Path("/sys/fs/cgroup/memory.current").read_text().strip())
            free = max(int(limit) - used, 0)
            available = free if available is None else min(available, free)
    except (OSError, ValueError):
        pass
    return available


def memory_budget() -> tuple[int, str]:
    """Most memory [bytes] one input may need: :data:`MAX_MEMORY`, or half the memory the system
    reports available when that is less; and a description of the limit for messages."""
    available = _available_memory()
    if available is None or available // 2 >= MAX_MEMORY:
        return MAX_MEMORY, f"the limit of {MAX_MEMORY / 2 ** 30:g} GiB per input"
    return available // 2, f"half the {available / 2 ** 20:,.0f} MiB of memory available"


def _check_memory(path: Path, need: int, what: str) -> None:
    budget, limit = memory_budget()
    if need > budget:
        raise BounceFileError(f"{path}: {what} needs about {need / 2 ** 20:,.0f} MiB of memory, more than "
                              f"{budget / 2 ** 20:,.0f} MiB ({limit}); cut the recording to the drop (seconds to a "
                              "minute of audio)")


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


def _check_xlsx_unpacked(path: Path) -> None:
    """Refuse a damaged ``.xlsx`` zip, or one that unpacks beyond :data:`MAX_TABLE_BYTES`, before
    anything is unpacked."""
    try:
        with zipfile.ZipFile(path) as archive:
            unpacked = sum(info.file_size for info in archive.infolist())
    except (zipfile.BadZipFile, OSError, EOFError):
        raise BounceFileError(f"{path}: not a readable .xlsx workbook (damaged zip)") from None
    if unpacked > MAX_TABLE_BYTES:
        raise _too_large(path, unpacked, "a workbook that unpacks to a table")


def _xlsx_sheet(path: Path, name: str):
    _check_xlsx_unpacked(path)
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
    size = check_file(path).st_size
    if size > MAX_TABLE_BYTES:
        raise _too_large(path, size, "a workbook")
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
            size = archive.getinfo(chosen[0]).file_size
            if size > MAX_TABLE_BYTES:
                raise _too_large(path, size, f"{chosen[0]} in the zip, a table")
            text = _decode(archive.read(chosen[0]), path)
    except (zipfile.BadZipFile, zlib.error, EOFError):
        raise BounceFileError(f"{path}: not a readable zip archive (damaged)") from None
    except (RuntimeError, NotImplementedError) as exc:  # encrypted, or an unsupported compression
        raise BounceFileError(f"{path}: not a readable zip archive ({_short(exc)})") from None
    rec = _csv_text(path, text, f"{chosen[0]} in the zip")
    return rec


def read_event_csv(path: str | os.PathLike[str]) -> BounceRecording:
    """Read a phyphox CSV export (any of its five flavours) or a plain CSV of event times."""
    path = Path(path)
    _head(path)
    try:
        with open(path, "rb") as fh:
            raw = fh.read(MAX_TABLE_BYTES + 1)  # never more, whatever the file has become since its check
    except OSError as exc:
        raise BounceFileError(f"{path}: cannot read ({exc.strerror or exc})") from None
    if len(raw) > MAX_TABLE_BYTES:
        raise _too_large(path, max(len(raw), check_file(path).st_size), "a text file")
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
    if len(lines) > MAX_EVENTS + 1:  # a header line and MAX_EVENTS events
        raise BounceFileError(f"{label}: {len(lines)} lines of data, more events than one drop of a ball can hold "
                              f"(at most {MAX_EVENTS}); one file is one drop")
    separator = _sniff_separator(lines[:20])
    fields = max((ln.count(separator) + 1 if separator else len(ln.split())) for ln in lines)
    if fields > MAX_COLUMNS:  # counted before splitting: a 30 MB line of fields would take gigabytes
        raise BounceFileError(f"{label}: a line of {fields:,} fields; a table of bounce times has one event per row "
                              f"and at most {MAX_COLUMNS} columns")
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
    if len(raw) > MAX_EVENTS + 1:  # before the trailing blank rows go (phyphox pads one column)
        raise BounceFileError(f"{path}: {where}: {len(raw)} rows, more events than one drop of a ball can hold "
                              f"(at most {MAX_EVENTS}); one file is one drop")
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
    _check_scale(times, str(path), f"{where}, column {name!r}", factor=factor,
                 base=_header_base(header[j]) if header else "")
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
    if values.ndim != 1:
        raise BounceFileError(f"{label}: event times must be one sequence, got an array of shape {values.shape}")
    if values.size == 0:
        raise BounceFileError(f"{label}: no event times")
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        raise BounceFileError(f"{label}: {row(int(bad[0]))}: time is NaN or empty"
                              + (f" ({bad.size} such rows)" if bad.size > 1 else ""))
    huge = np.flatnonzero(np.abs(values) > MAX_TIME_MAGNITUDE)
    if huge.size:
        i = int(huge[0])
        raise BounceFileError(f"{label}: {row(i)}: time {values[i]:.4g} s is beyond +/-{MAX_TIME_MAGNITUDE:g} s: not "
                              "the time of an event of a drop" + (f" ({huge.size} such rows)" if huge.size > 1 else ""))
    if values.size < MIN_EVENTS:
        raise BounceFileError(f"{label}: only {values.size} event(s); at least {MIN_EVENTS} impacts are needed "
                              "for one coefficient of restitution")
    if values.size > MAX_EVENTS:
        raise BounceFileError(f"{label}: {values.size} events, more than one drop of a ball can hold (at most "
                              f"{MAX_EVENTS}); one file is one drop")
    steps = np.diff(values)
    back = np.flatnonzero(steps <= 0.0)
    if back.size:
        i = int(back[0]) + 1
        raise BounceFileError(f"{label}: event times are not strictly increasing at {row(i)} "
                              f"({values[i]:.6g} s after {values[i - 1]:.6g} s)")
    return values


_UNITS = (("milliseconds", "ms", 1e-3), ("microseconds", "us", 1e-6), ("seconds", "s", 1.0), ("minutes", "min", 60.0))


def _header_base(header: str) -> str:
    """A column header without its unit (``"Time (ms)"`` -> ``"Time"``)."""
    text = re.sub(r"\s*[\(\[][^\)\]]*[\)\]]\s*$", "", header.strip())
    text = re.sub(r"[_ ](s|ms|us|µs|min)$", "", text)
    return text.strip() or "time"


def _check_scale(times: np.ndarray, label: str, column: str, *, factor: float, base: str | None) -> None:
    """Refuse times whose typical interval no flight of a dropped ball can have (the unit is not the
    one they were read in), or that span more than one drop can: naming the column, and the header
    that would give the unit (``base``: the column's header without its unit, "" without a header,
    None for times given as numbers). Never guesses a unit."""
    d = np.diff(times)
    typical = float(np.median(d))
    unit = next((long for long, _, f in _UNITS if math.isclose(f, factor)), f"units of {factor:g} s")
    raw = typical / factor  # the typical interval in the numbers of the file
    fits = [(long, short) for long, short, f in _UNITS
            if not math.isclose(f, factor) and MIN_TYPICAL_FLIGHT <= raw * f <= MAX_TYPICAL_FLIGHT]
    if fits and base is None:
        hint = f" If they are in {fits[0][0]}, convert them to seconds."
    elif fits:
        long, short = fits[0]
        header = f"'{base or 'time'} ({short})'"
        where = "the header of the time column" if base else "a header line"
        hint = (f" If they are in {long}, say so in {where}, e.g. {header}: a unit in the header is honoured "
                "('time (ms)', 't [us]', 'time_ms').")
    else:
        hint = ""
    g = 9.80665
    if typical > MAX_TYPICAL_FLIGHT:
        raise BounceFileError(
            f"{label}: {column}: events {typical:.4g} s apart (median interval), flights of a bounce "
            f"{g * typical ** 2 / 8:.3g} m high ending at {g * typical / 2:.3g} m/s; no dropped ball flies longer than "
            f"{MAX_TYPICAL_FLIGHT:g} s (a 120 m bounce at 49 m/s), so the times are not in {unit}.{hint}")
    if typical < MIN_TYPICAL_FLIGHT:
        raise BounceFileError(
            f"{label}: {column}: events {1e3 * typical:.4g} ms apart (median interval), flights of a bounce "
            f"{1e6 * g * typical ** 2 / 8:.3g} um high; no audible bounce is shorter than "
            f"{1e3 * MIN_TYPICAL_FLIGHT:g} ms, so the times are not in {unit}.{hint}")
    span = float(times[-1] - times[0])
    if span > MAX_EVENT_SPAN:
        raise BounceFileError(
            f"{label}: {column}: the events span {span:.4g} s, more than the {MAX_EVENT_SPAN:g} s any recording of "
            "one drop needs (a drop bounces for under a minute); one file is one drop")


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


# ---- tables of several drops --------------------------------------------------------------------

#: Headers of a column that numbers the bounces rather than timing them (skipped in a table of trials).
_INDEX_WORDS = ("n", "#", "no", "no.", "nr", "index", "bounce", "bounces", "impact", "impacts", "number", "k", "i")


def read_drops(path: str | os.PathLike[str], *, onset_options: dict | None = None) -> list[BounceRecording]:
    """The drops of one file: several for a table of trials, else the one :func:`read_bounces` reads.

    A table of trials is a workbook without phyphox's ``All`` sheet, or a CSV, whose columns are the
    bounce times of one trial each (one column per trial, or one sheet per trial; with or without a
    header row naming the trials, a unit in it honoured as in :func:`read_event_csv`; shorter
    columns end in blank cells). A first column that numbers the bounces (1, 2, 3, ... or a header
    such as ``n`` or ``bounce``) is skipped. A CSV is a table of trials when every other column is
    such a column of times, at least two of them (times that increase, with intervals that mostly
    shrink, as a bouncing ball's do); a phyphox export or a CSV with one time column is one drop, as
    before.

    Raises
    ------
    BounceFileError
        naming the file (and the sheet, column and row) and the problem.
    """
    path = Path(path)
    head = _head(path)
    if head.startswith(b"\xd0\xcf\x11\xe0") or (head.startswith(b"PK\x03\x04") and _is_workbook(path)):
        fmt, sheets = _workbook(path)
        if "All" in sheets:
            return [read_phyphox(path)]
        trials = []
        for name, rows in sheets.items():
            trials += _trials(path, rows, f"sheet {name!r}", name if len(sheets) > 1 else "", single_ok=True)
        if not trials:
            raise BounceFileError(f"{path}: no sheet 'All' (a phyphox export) and no sheet with columns of bounce "
                                  f"times (sheets: {', '.join(sheets) or 'none'})")
        return [replace(t, format=fmt) for t in trials]
    if head.startswith(b"PK\x03\x04") or head[:4] in (b"RIFF", b"RF64") or audio_kind(head) or _looks_binary(head):
        return [read_bounces(path, onset_options=onset_options)]
    try:
        with open(path, "rb") as fh:
            raw = fh.read(MAX_TABLE_BYTES + 1)
    except OSError as exc:
        raise BounceFileError(f"{path}: cannot read ({exc.strerror or exc})") from None
    if len(raw) <= MAX_TABLE_BYTES:
        rows = _csv_rows(_decode(raw, path))
        if rows is not None:
            trials = _trials(path, rows, "the CSV", "", single_ok=False)
            if trials:
                return trials
    return [read_bounces(path, onset_options=onset_options)]


def _is_workbook(path: Path) -> bool:
    try:
        with zipfile.ZipFile(path) as archive:
            names = archive.namelist()
    except (zipfile.BadZipFile, OSError, EOFError):
        return False
    return any(n.startswith("xl/") for n in names) or "[Content_Types].xml" in names


def _workbook(path: Path) -> tuple[str, dict[str, list[list]]]:
    """Every sheet of a workbook as rows of cells (``.xlsx`` through openpyxl, ``.xls`` through xlrd)."""
    size = check_file(path).st_size
    if _head(path).startswith(b"PK\x03\x04"):
        _check_xlsx_unpacked(path)
        try:
            frames = pd.read_excel(path, sheet_name=None, header=None, dtype=object, engine="openpyxl")
        except Exception as exc:  # openpyxl raises its own exception types on malformed XML
            raise BounceFileError(f"{path}: not a readable .xlsx workbook ({_short(exc)})") from None
        return "table-xlsx", {str(k): f.values.tolist() for k, f in frames.items()}
    if size > MAX_TABLE_BYTES:
        raise _too_large(path, size, "a workbook")
    import xlrd

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            book = xlrd.open_workbook(str(path), on_demand=True, logfile=io.StringIO())
        try:
            sheets = {}
            for name in book.sheet_names():
                sheet = book.sheet_by_name(name)
                sheets[str(name)] = [sheet.row_values(i) for i in range(sheet.nrows)]
        finally:
            book.release_resources()
    except Exception as exc:  # xlrd raises XLRDError, CompDocError, struct.error, ... on damaged files
        raise BounceFileError(f"{path}: not a readable .xls workbook ({_short(exc)})") from None
    return "table-xls", sheets


def _csv_rows(text: str) -> list[list] | None:
    """The cells of a CSV (numbers parsed, a decimal comma accepted when the separator is not a
    comma), or None when it is not a table of several columns."""
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines or len(lines) > MAX_EVENTS + 1:
        return None
    separator = _sniff_separator(lines[:20])
    if separator is None or max(ln.count(separator) for ln in lines) + 1 > MAX_COLUMNS:
        return None
    rows = _split(lines, separator)
    decimal_comma = separator != "," and any("," in c for r in rows[1:50] for c in r)
    return [[_parse_number(c.strip().strip('"'), decimal_comma) for c in r] for r in rows]


def _trials(path: Path, rows: list[list], where: str, sheet: str, *, single_ok: bool) -> list[BounceRecording]:
    """The trials of one table (rows of cells): every column of strictly increasing times that ends
    in blank cells, named by its header, or ``column <j>``; [] when the table is not a table of
    trials (any other column than a bounce number, or fewer than two trials unless ``single_ok``)."""
    rows = [list(r) for r in rows if any(not _blank(c) for c in r)]
    if not rows:
        return []
    width = max(len(r) for r in rows)
    rows = [r + [math.nan] * (width - len(r)) for r in rows]
    header = None
    if any(isinstance(c, str) and not _blank(c) and isinstance(_parse_number(c, True), str) for c in rows[0]):
        header = [_cell_text(c) for c in rows[0]]
        rows = rows[1:]
    first_row = 2 if header else 1
    found = []
    for j in range(width):
        name = header[j] if header else ""
        cells = [r[j] for r in rows]
        while cells and _blank(cells[-1]):
            cells.pop()
        if not cells:
            continue
        values = [_as_float(c) for c in cells]
        if not all(math.isfinite(v) for v in values):
            return []  # text or a blank inside a column: not a table of trials
        v = np.array(values)
        if j == 0 and (name.strip().lower() in _INDEX_WORDS or (
                v.size >= 2 and np.all(v == np.round(v)) and np.all(np.diff(v) == 1))):
            continue  # the bounce numbers
        factor = 1.0
        match = re.match(r"^.*?[\(\[]\s*([^\)\]]*)\s*[\)\]]\s*$", name)
        if match:
            try:
                factor = si_factor(match.group(1).strip() or "s", "time")
            except UnitError:
                return []
        d = np.diff(v)
        if v.size < MIN_EVENTS or np.any(d <= 0) or np.mean(d[1:] < d[:-1]) < 0.5:
            return []  # not the times of a drop: they do not increase, or their intervals do not mostly shrink
        found.append((j, name, v * factor, factor))
    if len(found) < (1 if single_ok else 2):
        return []
    out = []
    for j, name, times, factor in found:
        label = name or f"column {j + 1}"
        trial = "/".join(p for p in (sheet, label) if p) if (len(found) > 1 or not sheet) else sheet
        times = _check_times(times, f"{path} [{trial}]",
                             lambda i, label=label: f"{where}, column {label!r}, row {i + first_row}")
        _check_scale(times, f"{path} [{trial}]", f"{where}, column {label!r}", factor=factor,
                     base=_header_base(name) if name else "")
        resolution = time_resolution(times)
        unit = "" if factor == 1.0 else f" (x {factor:g} to s)"
        step = (f"read {len(times)} event times of trial {trial!r} from {path.name}: {where}, column {label!r}{unit} "
                f"[table of {len(found)} trial(s)]")
        out.append(BounceRecording(source=str(path), format="table-csv", times=times, resolution=resolution,
                                   provenance=(step,), trial=trial))
    return out


# ---- audio --------------------------------------------------------------------------------------

#: The audio containers read, by the first bytes of the file: name and the format's word in messages.
AUDIO_KINDS = ("WAV", "FLAC", "OGG")
_AUDIO_SUFFIXES = {".wav": "WAV", ".wave": "WAV", ".flac": "FLAC", ".ogg": "OGG", ".oga": "OGG", ".opus": "OGG"}
#: libsndfile subtype -> (dtype the samples are read as, encoding of :class:`Audio`); other subtypes
#: (Vorbis, Opus, A-law, ADPCM, ...) are decoded to 32-bit floats.
_SUBTYPES = {"PCM_U8": ("int16", "uint8"), "PCM_S8": ("int16", "int8"), "PCM_16": ("int16", "int16"),
             "PCM_24": ("int32", "int24"), "PCM_32": ("int32", "int32"), "FLOAT": ("float32", "float32"),
             "DOUBLE": ("float64", "float64")}
#: Full-scale value of one stored unit of each dtype samples are held as.
_DTYPE_SCALE = {"int16": 2.0 ** -15, "int32": 2.0 ** -31, "int64": 2.0 ** -63, "float32": 1.0, "float64": 1.0}
#: Most positive sample of each encoding [full scale]: samples at or above it are clipped.
_FULL_SCALE = {"uint8": 127 / 128, "int8": 127 / 128, "int16": 32767 / 32768, "int24": (2 ** 23 - 1) / 2 ** 23,
               "int32": (2 ** 31 - 1) / 2 ** 31}
#: libsndfile's frame count of a file whose length it cannot tell (SF_COUNT_MAX, 2^63 - 1), and above.
_UNKNOWN_FRAMES = 2 ** 62
#: RIFF sizes that streaming writers leave when they do not know the length.
_UNKNOWN_RIFF_SIZES = (0, 0xFFFFFFFF)


def audio_kind(head: bytes) -> str | None:
    """The audio container that the first bytes of a file announce: ``"WAV"`` (RIFF/WAVE, or RF64
    for WAV files over 4 GiB), ``"FLAC"`` or ``"OGG"`` (Vorbis, Opus or FLAC in an Ogg stream); None
    for anything else."""
    if head[8:12] == b"WAVE" and head[:4] in (b"RIFF", b"RF64"):
        return "WAV"
    if head.startswith(b"fLaC"):
        return "FLAC"
    if head.startswith(b"OggS"):
        return "OGG"
    return None


def _check_complete_riff(path: Path, head: bytes, size: int) -> None:
    """Refuse a RIFF/WAVE file shorter than the size its RIFF header announces (bytes 4-7 of the
    file): a copy or a recording cut short, which the readers would otherwise analyse in part without
    a word (libsndfile reads the frames that are there)."""
    if head[:4] != b"RIFF":
        return
    announced = int.from_bytes(head[4:8], "little") + 8
    if announced - 8 in _UNKNOWN_RIFF_SIZES or announced <= size + 1:  # + 1: a missing pad byte
        return
    raise BounceFileError(f"{path}: truncated WAV file: its header announces {announced:,} bytes, the file holds "
                          f"{size:,} ({100 * size / announced:.0f} %; a copy or a recording cut short; re-save what "
                          "is there with an audio editor to analyse it)")


#: An Ogg page: the capture pattern, the header (27 bytes with the capture pattern) and at most 255 segments of at
#: most 255 bytes each (RFC 3533, section 6).
_OGG_CAPTURE, _OGG_HEADER, _OGG_MAX_PAGE = b"OggS", 27, 27 + 255 + 255 * 255
#: The header-type flag of a stream's last page (RFC 3533: "end of stream").
_OGG_END_OF_STREAM = 0x04


def _check_complete_ogg(path: Path, size: int) -> None:
    """Refuse an Ogg file whose last page is cut or is not a stream's last page (RFC 3533).

    An Ogg stream ends with a page flagged *end of stream*; a copy or a recording cut short ends
    inside a page or after a page without the flag, and libsndfile then decodes the pages that are
    there without a word (it has no announced length to compare with, unlike WAV and FLAC). The last
    page is the last capture pattern within one page's length of the end whose header and segment
    table account for the bytes that follow it: up to the end of the file, or up to bytes that hold no
    capture pattern (a tag or padding some writers append after the stream, which is ignored).
    """
    with open(path, "rb") as handle:
        handle.seek(max(0, size - _OGG_MAX_PAGE))
        tail = handle.read()
    base = size - len(tail)
    start = tail.rfind(_OGG_CAPTURE)
    while start >= 0:
        header = tail[start:start + _OGG_HEADER]
        if len(header) == _OGG_HEADER and header[4] == 0:  # stream structure version 0
            n_segments = header[26]
            table = tail[start + _OGG_HEADER:start + _OGG_HEADER + n_segments]
            page_end = start + _OGG_HEADER + n_segments + sum(table)
            if len(table) == n_segments and page_end <= len(tail):
                if not header[5] & _OGG_END_OF_STREAM:
                    raise BounceFileError(f"{path}: truncated OGG file: its last page (at byte {base + start:,}) is "
                                          "not the stream's last (no end-of-stream flag): a copy or a recording cut "
                                          "short; re-save what is there with an audio editor to analyse it")
                return
            if _OGG_CAPTURE not in tail[start + 1:]:  # the last page begun: it runs past the end of the file
                raise BounceFileError(f"{path}: truncated OGG file: it ends inside a page (the page at byte "
                                      f"{base + start:,} runs past its {size:,} bytes): a copy or a recording cut "
                                      "short; re-save what is there with an audio editor to analyse it")
        start = tail.rfind(_OGG_CAPTURE, 0, start)
    raise BounceFileError(f"{path}: truncated OGG file: no complete page within its last {len(tail):,} bytes: a "
                          "copy or a recording cut short; re-save what is there with an audio editor to analyse it")


def _audio_steps(frames: int, channels: int, rate: float) -> str:
    return (f"analysing its {frames / max(rate, 1):,.0f} s of audio ({frames:,} frames x {channels} channel(s) at "
            f"{rate:g} Hz)")


def _read_soundfile(path: Path, kind: str) -> Audio:
    """Samples and format through libsndfile (:mod:`soundfile`): the header first (frames, channels,
    rate, sample type) for the memory check, then the samples in their own width (16-bit samples
    as int16, 24- and 32-bit ones as int32, floats as they are; lossy formats decoded to float32)."""
    try:
        info = soundfile.info(str(path))
    except (RuntimeError, OSError, ValueError, TypeError) as exc:  # soundfile.LibsndfileError is a RuntimeError
        raise BounceFileError(f"{path}: not a readable {kind} file ({_short(exc)})") from None
    frames, channels, rate = int(info.frames), int(info.channels), float(info.samplerate)
    if channels <= 0 or rate <= 0:
        raise BounceFileError(f"{path}: {kind} header gives {channels} channel(s) at {rate:g} Hz")
    if frames >= _UNKNOWN_FRAMES:
        raise BounceFileError(f"{path}: the decoder cannot tell the length of this {kind} file (libsndfile "
                              f"{soundfile.__libsndfile_version__}; bytes after its stream, or a damaged end); "
                              "re-save it with an audio editor, or update soundfile")
    dtype, encoding = _SUBTYPES.get(info.subtype, ("float32", str(info.subtype).lower()))
    itemsize = np.dtype(dtype).itemsize
    _check_memory(path, frames * channels * itemsize + memory_needed(frames, channels, itemsize),
                  _audio_steps(frames, channels, rate))
    try:
        data, _ = soundfile.read(str(path), dtype=dtype, always_2d=True)
    except (RuntimeError, OSError, ValueError, TypeError, MemoryError) as exc:
        raise BounceFileError(f"{path}: not a readable {kind} file, damaged or cut short ({_short(exc)})") from None
    if data.shape[0] < frames:
        raise BounceFileError(f"{path}: truncated {kind} file: its header announces {frames:,} frames, "
                              f"{data.shape[0]:,} could be read (a copy or a recording cut short)")
    reader = f"soundfile {soundfile.__version__} (libsndfile {soundfile.__libsndfile_version__})"
    return Audio(samples=data, sample_rate=rate, encoding=encoding, source=str(path), scale=_DTYPE_SCALE[dtype],
                 format=kind, reader=reader)


def _wavfile_read(path: Path, mmap: bool) -> tuple[int, np.ndarray]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # unknown chunks, a streamed length: read what can be read
        return wavfile.read(path, mmap=mmap)


def _read_scipy_wav(path: Path, size: int) -> Audio:
    """Samples of a WAV file through :func:`scipy.io.wavfile.read`, for when :mod:`soundfile` cannot
    be imported: memory-mapped (nothing read before the memory check, which takes the shape from the
    map), or, for 3-byte samples (which cannot be mapped), read whole after a check of the most
    memory a file of its size can need."""
    errors = (ValueError, EOFError, struct.error, OSError, MemoryError, IndexError, TypeError)
    three_bytes = False
    try:
        rate, data = _wavfile_read(path, mmap=True)
        mapped = True
    except errors as exc:
        three_bytes = "3-byte" in str(exc)
        mapped = False
    if mapped:
        frames, channels = data.shape[0], (data.shape[1] if data.ndim == 2 else 1)
        _check_memory(path, memory_needed(frames, channels, data.dtype.itemsize),
                      _audio_steps(frames, channels, rate))
    else:
        # the samples are read whole (3-byte ones twice: bytes, then 4-byte integers): at most this many
        samples = size // (3 if three_bytes else 1)
        _check_memory(path, size + 4 * samples + memory_needed(samples, 1, 4),
                      f"reading its {size / 2 ** 20:,.1f} MiB of audio whole (without soundfile, at most)")
        try:
            rate, data = _wavfile_read(path, mmap=False)
        except errors as exc:
            raise BounceFileError(f"{path}: not a readable WAV file ({_short(exc)})") from None
    if data.ndim == 1:
        data = data.reshape(-1, 1)
    if data.ndim != 2 or data.shape[1] == 0:
        raise BounceFileError(f"{path}: WAV data of unexpected shape {data.shape}")
    if rate <= 0:
        raise BounceFileError(f"{path}: WAV sample rate {rate} Hz is not positive")
    kind = data.dtype
    if kind == np.uint8:
        scale, offset, encoding = 1.0 / 128.0, 128.0, "uint8"
    elif kind.kind in "if" and kind.name in _DTYPE_SCALE:
        scale, offset, encoding = _DTYPE_SCALE[kind.name], 0.0, kind.name
        encoding = "int24" if three_bytes else encoding
    else:
        raise BounceFileError(f"{path}: unsupported WAV sample type {kind}")
    reader = f"scipy.io.wavfile{' (memory-mapped)' if mapped else ''}"
    return Audio(samples=data, sample_rate=float(rate), encoding=encoding, source=str(path), scale=scale,
                 offset=offset, format="WAV", reader=reader)


def read_audio(path: str | os.PathLike[str]) -> Audio:
    """Read an audio file (WAV, FLAC or OGG) into an :class:`Audio`, checking that it is usable:
    complete, analysable within :func:`memory_budget` (from its header, before a sample is read),
    not too short, finite, not silent, not clipped (scanned block by block).

    The samples are read by :mod:`soundfile` (libsndfile). Where soundfile cannot be imported (a
    platform without its wheel and without a system libsndfile), WAV files are read by
    :func:`scipy.io.wavfile.read` (memory-mapped) and FLAC and OGG are refused naming the package.

    Raises
    ------
    BounceFileError
        naming the file and the problem.
    """
    path = Path(path)
    head = _head(path, 12)
    kind = audio_kind(head)
    if kind is None:
        raise BounceFileError(f"{path}: not an audio file of a kind read here ({', '.join(AUDIO_KINDS)})")
    size = check_file(path).st_size
    if kind == "WAV":
        _check_complete_riff(path, head, size)
    if soundfile is not None:
        if kind == "OGG":  # before the decoder, which cannot tell the length of a cut stream (libsndfile 1.2.0)
            _check_complete_ogg(path, size)
        audio = _read_soundfile(path, kind)
    elif kind == "WAV" and head[:4] == b"RIFF":
        audio = _read_scipy_wav(path, size)
    else:
        what = "RF64 WAV" if kind == "WAV" else kind
        raise BounceFileError(f"{path}: reading {what} audio needs the soundfile package, which could not be "
                              f"imported ({_SOUNDFILE_PROBLEM}); `pip install soundfile` brings it with libsndfile "
                              "(a plain WAV file is read without it)")
    _check_samples(path, audio)
    return audio


def _check_samples(path: Path, audio: Audio) -> None:
    """Refuse audio too short for a drop, with NaN or infinite samples, silent, or clipped."""
    n, rate = audio.n_frames, audio.sample_rate
    if n < 64 or n / rate < MIN_WAV_SECONDS:
        raise BounceFileError(f"{path}: too short ({n} samples, {n / rate:.3g} s); a drop needs at least "
                              f"{MIN_WAV_SECONDS:g} s of audio")
    floats = audio.samples.dtype.kind == "f"
    full = _FULL_SCALE.get(audio.encoding, 1.0)
    first = audio.block(0, 1)
    silent = True
    at_full = 0
    for x in audio.blocks():
        if floats and not np.all(np.isfinite(x)):
            raise BounceFileError(f"{path}: {audio.format or 'audio'} holds NaN or infinite samples")
        silent = silent and bool(np.all(x == first))
        at_full += int(np.count_nonzero(np.any(np.abs(x) >= full * (1.0 - 1e-9), axis=1)))
    if silent:
        raise BounceFileError(f"{path}: silent (every sample equal)")
    fraction = at_full / n
    if fraction > MAX_CLIPPED_FRACTION:
        raise BounceFileError(f"{path}: clipped: {100 * fraction:.2g} % of the samples are at full scale "
                              f"(more than {100 * MAX_CLIPPED_FRACTION:g} %); record again with a lower input gain")


def read_wav(path: str | os.PathLike[str], **onset_options) -> BounceRecording:
    """Read an audio recording of a drop (WAV, FLAC or OGG: :func:`read_audio`) and find its impact clicks.

    Parameters
    ----------
    path : the audio file.
    **onset_options : passed to :func:`~impactid.rigs.ball.onsets.detect_onsets`.

    Raises
    ------
    BounceFileError
        the file cannot be read (:func:`read_audio`), is sampled too slowly for the detector, or
        holds fewer than three clicks or more than one drop can.
    """
    path = Path(path)
    audio = read_audio(path)
    band = onset_options.get("band")
    lowest = min_sample_rate(band)
    if not audio.sample_rate > lowest:
        why = (f"its band-pass starts at {DEFAULT_BAND[0]:g} Hz and must end below 0.45 x the sample rate"
               if band is None else f"the band-pass {band[0]:g}-{band[1]:g} Hz must end below half the sample rate")
        raise BounceFileError(f"{path}: sampled at {audio.sample_rate:g} Hz; the click detector needs at least "
                              f"{math.floor(lowest) + 1} Hz ({why}); record at 8 kHz or more (phones record at 44.1 "
                              "or 48 kHz)")
    channel = onset_options.get("channel", "mix")
    if channel != "mix" and not (isinstance(channel, int) and 0 <= channel < audio.n_channels):
        raise BounceFileError(f"{path}: has {audio.n_channels} channel(s) (0 to {audio.n_channels - 1}); channel "
                              f"{channel!r} was asked for")
    steps = [f"read {path.name}: {audio.format}, {audio.n_frames} samples x {audio.n_channels} channel(s), "
             f"{audio.sample_rate:g} Hz, {audio.encoding}, by {audio.reader}"]
    onsets = detect_onsets(audio.samples, audio.sample_rate, quantum=audio.quantum, scale=audio.scale,
                           offset=audio.offset, **onset_options)
    if onsets.times.size < MIN_EVENTS:
        raise BounceFileError(f"{path}: found {onsets.times.size} impact click(s) above the noise floor "
                              f"(threshold {onsets.threshold:.3g} full scale); at least {MIN_EVENTS} are needed")
    if onsets.times.size > MAX_EVENTS:
        raise BounceFileError(f"{path}: found {onsets.times.size} clicks, more than one drop of a ball can make (at "
                              f"most {MAX_EVENTS}); one file is one drop")
    steps.append(onsets.describe())
    notes = [f"{path.name}: {n}" for n in onsets.notes]
    clipped = audio.frames_at_or_above(1.0 - 2 * audio.quantum)
    if clipped:
        notes.append(f"{path.name}: {clipped} samples at full scale (clipped click peaks); onset times come from "
                     "the rising edge of each click and are not affected")
    return BounceRecording(source=str(path), format=audio.format.lower(), times=onsets.times, resolution=math.nan,
                           provenance=tuple(steps), notes=tuple(notes), onsets=onsets)

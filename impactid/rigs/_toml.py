"""TOML reading and writing of rig files (``[rig]`` and ``[operating]`` tables, docs/formats.md).

Reading uses the standard library's :mod:`tomllib`; writing is a small emitter because a rig file
is a flat table of floats and strings (no extra dependency). Files are written atomically.
"""

from __future__ import annotations

import math
import os
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from impactid.errors import RigParameterError

__all__ = ["MAX_RIG_FILE_BYTES", "format_toml", "read_toml", "write_text_atomic"]

#: Largest rig file read [bytes] (a rig file is a page of numbers; a lift table of a few thousand
#: points is far below this): a larger file is a recording or a binary given by mistake.
MAX_RIG_FILE_BYTES = 16 * 2**20
_UTF8_BOM = b"\xef\xbb\xbf"
_HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"


def read_toml(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Read a TOML file, raising :class:`RigParameterError` naming the file on any problem.

    The file must be UTF-8 text of at most :data:`MAX_RIG_FILE_BYTES`; a UTF-8 byte-order mark
    (which some editors write) is skipped.
    """
    path = Path(path)
    if path.is_dir():
        raise RigParameterError(f"{path}: is a folder, not a rig file")
    if path.is_symlink() and not path.exists():
        raise RigParameterError(f"{path}: is a symbolic link to {os.readlink(path)}, which does not exist "
                                "(a dangling link)")
    if path.exists() and not path.is_file():
        raise RigParameterError(f"{path}: is a special file (named pipe, device or socket), not a rig file")
    try:
        size = path.stat().st_size
        if size > MAX_RIG_FILE_BYTES:
            raise RigParameterError(f"{path}: {size:,} bytes, too large to be a TOML rig file (at most "
                                    f"{MAX_RIG_FILE_BYTES:,}); a recording given as the rig?")
        with path.open("rb") as fh:
            raw = fh.read()
    except FileNotFoundError:
        raise RigParameterError(f"{path}: rig file not found") from None
    except OSError as exc:
        raise RigParameterError(f"{path}: cannot read rig file ({exc.strerror})") from None
    if raw.startswith(_HDF5_SIGNATURE):
        raise RigParameterError(f"{path}: is an HDF5 file, not a TOML rig file (a recording given as the rig?)")
    if raw.startswith(_UTF8_BOM):
        raw = raw[len(_UTF8_BOM):]
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        raise RigParameterError(f"{path}: not a TOML rig file: not UTF-8 text (byte 0x{raw[exc.start]:02x} at line "
                                f"{line}); a binary file?") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise RigParameterError(f"{path}: not a valid TOML file ({exc})") from None


def _format_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        value = float(value)
        if not math.isfinite(value):
            raise ValueError(f"cannot write non-finite value {value!r} to TOML")
        return repr(value)
    if isinstance(value, str):
        escaped = value.replace("\\", "\\\\").replace('"', '\\"')
        return f'"{escaped}"'
    raise TypeError(f"cannot write {type(value).__name__} to a rig TOML file")


def format_toml(tables: Mapping[str, Mapping[str, Any]], header: str = "") -> str:
    """Format flat tables of scalars as TOML text."""
    lines = [f"# {line}" for line in header.splitlines()] if header else []
    for name, table in tables.items():
        if lines:
            lines.append("")
        lines.append(f"[{name}]")
        for key, value in table.items():
            lines.append(f"{key} = {_format_value(value)}")
    return "\n".join(lines) + "\n"


def write_text_atomic(path: str | os.PathLike[str], text: str) -> Path:
    """Write ``text`` to ``path`` atomically (see :mod:`impactid._files`)."""
    from impactid._files import atomic_write

    return atomic_write(path, text)

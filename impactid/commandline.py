"""Shared pieces of the ``impactid`` commands: usage errors, argument types and JSON output.

Every command (the core ones in :mod:`impactid.cli` and those the rigs contribute through
:class:`~impactid.rigs.base.CommandSpec`) parses numbers with these types, so a bad argument ends in
the same one-line ``impactid: error: argument --x: ...`` whichever rig defines it, and writes JSON
with :func:`json_text` (non-finite numbers become ``null`` and are listed under ``warnings``).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

from impactid.errors import ImpactidError

__all__ = ["UsageError", "exponent", "fraction", "integer_in", "json_text", "nonnegative", "num", "number", "pair",
           "positive", "print_json"]


class UsageError(ImpactidError, ValueError):
    """A command-line argument that cannot be used (parsed by argparse or checked by a command)."""


def number(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return value


def positive(text: str) -> float:
    value = number(text)
    if value <= 0.0:
        raise argparse.ArgumentTypeError(f"must be positive, got {text!r}")
    return value


def nonnegative(text: str) -> float:
    value = number(text)
    if value < 0.0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {text!r}")
    return value


def fraction(text: str) -> float:
    value = nonnegative(text)
    if value > 1.0:
        raise argparse.ArgumentTypeError(f"must lie in [0, 1], got {text!r}")
    return value


def exponent(text: str) -> float:
    value = nonnegative(text)
    if value > 10.0:
        raise argparse.ArgumentTypeError(f"must lie in [0, 10], got {text!r}")
    return value


def integer_in(lo: int, hi: int):
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
        if not lo <= value <= hi:
            raise argparse.ArgumentTypeError(f"must lie in [{lo}, {hi}], got {text!r}")
        return value

    return parse


def pair(text: str) -> tuple[float, float]:
    parts = text.split(",")
    if len(parts) != 2:
        raise argparse.ArgumentTypeError(f"expected A,B (two numbers separated by a comma), got {text!r}")
    return number(parts[0]), number(parts[1])


def json_ready(value, path: str, undetermined: list[str]):
    """``value`` with non-finite floats as None (their JSON paths collected), numpy types as Python."""
    if isinstance(value, dict):
        return {str(k): json_ready(v, f"{path}.{k}" if path else str(k), undetermined) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_ready(v, f"{path}[{i}]", undetermined) for i, v in enumerate(value)]
    if isinstance(value, np.ndarray):
        return json_ready(value.tolist(), path, undetermined)
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        undetermined.append(path)
        return None
    if isinstance(value, Path):
        return str(value)
    return value


def json_text(data: dict) -> str:
    """JSON text of a result: non-finite numbers are written as null and listed in ``warnings``."""
    undetermined: list[str] = []
    clean = json_ready(data, "", undetermined)
    shown = [p for p in undetermined if not p.startswith("per_impact")]
    if shown and isinstance(clean, dict):
        note = (f"undetermined (not a finite number, written as null): {', '.join(shown[:20])}"
                f"{' ...' if len(shown) > 20 else ''}")
        clean.setdefault("warnings", []).append(note)
    return json.dumps(clean, indent=2, allow_nan=False) + "\n"


def print_json(data) -> None:
    sys.stdout.write(json_text(data))


def num(value, fmt: str = ".5g") -> str:
    """A number for the text report; ``undetermined`` when it is None or not finite."""
    if value is None or not math.isfinite(float(value)):
        return "undetermined"
    return format(float(value), fmt)


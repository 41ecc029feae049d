"""Golden outputs: the JSON results of the CLI pinned before a refactor, compared number by number.

A refactor that should not change results (moving rigs behind the rig-model protocol, one integrator
core, shared result types) must reproduce these files. When a change of results is intended, rerun
the tests with ``IMPACTID_UPDATE_GOLDEN=1`` and explain the change in the commit message.

Numbers are compared with a relative tolerance of 1e-7: the computations are deterministic (seeded
resampling, fixed search grids), so the only differences allowed are floating-point reassociation
by the compiler (about 1e-12 per operation, amplified by the optimisers' stopping rules to well below
1e-7 in practice). Keys that name files, times or versions, and absolute paths, are not compared.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

__all__ = ["assert_matches_golden"]

GOLDEN = Path(__file__).parent
RELATIVE_TOLERANCE = 1e-7
#: keys whose values depend on the machine, the paths or the version, not on the computation
IGNORED_KEYS = frozenset({"provenance", "version", "impactid_version", "files", "file", "files_read", "plots",
                          "path", "paths", "source", "sources", "seconds", "elapsed_s", "created", "written",
                          "outputs", "recordings"})


def _differences(got, want, path: str, out: list[str]) -> None:
    if isinstance(want, dict):
        if not isinstance(got, dict):
            out.append(f"{path}: expected an object, got {type(got).__name__}")
            return
        for key in sorted(set(want) | set(got)):
            if key in IGNORED_KEYS:
                continue
            if key not in got:
                out.append(f"{path}.{key}: missing")
            elif key not in want:
                out.append(f"{path}.{key}: not in the golden file")
            else:
                _differences(got[key], want[key], f"{path}.{key}", out)
    elif isinstance(want, list):
        if not isinstance(got, list) or len(got) != len(want):
            out.append(f"{path}: expected a list of {len(want)}, got {got!r:.80}")
            return
        for k, (g, w) in enumerate(zip(got, want, strict=True)):
            _differences(g, w, f"{path}[{k}]", out)
    elif isinstance(want, float) or (isinstance(want, int) and not isinstance(want, bool) and isinstance(got, float)):
        if not isinstance(got, (int, float)) or isinstance(got, bool):
            out.append(f"{path}: expected {want!r}, got {got!r}")
        elif not math.isclose(got, want, rel_tol=RELATIVE_TOLERANCE, abs_tol=1e-300):
            out.append(f"{path}: {got!r} != golden {want!r} (relative difference {abs(got - want) / abs(want):.2e})")
    elif isinstance(want, str) and isinstance(got, str) and os.path.isabs(want) and os.path.isabs(got):
        return  # a file path of the run (a temporary folder), not a result
    elif got != want:
        out.append(f"{path}: {got!r:.80} != golden {want!r:.80}")


def assert_matches_golden(data: dict, name: str) -> None:
    """Assert that ``data`` (a JSON result) matches ``tests/golden/NAME`` (or write it when updating)."""
    path = GOLDEN / name
    plain = json.loads(json.dumps(data))
    if os.environ.get("IMPACTID_UPDATE_GOLDEN") == "1":
        path.write_text(json.dumps(plain, indent=1, sort_keys=True) + "\n")
        return
    assert path.exists(), f"golden file {path} is missing (write it with IMPACTID_UPDATE_GOLDEN=1)"
    differences: list[str] = []
    _differences(plain, json.loads(path.read_text()), name, differences)
    assert not differences, f"{len(differences)} differences from {name}:\n" + "\n".join(differences[:30])

"""Golden outputs: the JSON results of the CLI pinned before a refactor, compared number by number.

A refactor that should not change results (moving rigs behind the rig-model protocol, one integrator
core, shared result types) must reproduce these files. When a change of results is intended, rerun
the tests with ``IMPACTID_UPDATE_GOLDEN=1`` and explain the change in the commit message.

**Tolerances come from each quantity's own precision, stated beside each golden file** in
``NAME.tolerances.toml``. The computations are deterministic on one installation (the compiled batch
kernel gives bit-identical results with one or two numba threads and on an idle or a loaded
machine), but a new release of NumPy, SciPy, numba/LLVM or LAPACK changes the last bits of
individual operations; an optimiser's stopping rule, a root finder's ``xtol`` or an adaptive
integrator's step control then turns those bits into differences as large as its own tolerance.
A golden comparison checks that the result is the same *to the precision the method claims*, not
that the environment is the same. Each rule of a tolerance file names key paths (``fnmatch``
patterns on the dotted path with list indices written ``[*]``, e.g. ``per_impact[*].residual``),
an absolute and/or relative tolerance, and ``why``: where that precision comes from. A number no
rule names is compared with :data:`RELATIVE_TOLERANCE` (arithmetic that no tolerance-controlled
step touches). ``null`` (undetermined) and numbers never compare equal: a standard error that
flips between a number and "undetermined" is a failure, whatever the tolerance. Keys that name
files, times or versions, and absolute paths, are not compared.
"""

from __future__ import annotations

import fnmatch
import json
import math
import os
import re
import tomllib
from dataclasses import dataclass
from pathlib import Path

__all__ = ["assert_matches_golden"]

GOLDEN = Path(__file__).parent
#: Relative tolerance of numbers no rule of the golden file's tolerance file names: results of plain
#: arithmetic on the same inputs (reassociation by a compiler changes them by about 1e-15 per step).
RELATIVE_TOLERANCE = 1e-9


@dataclass(frozen=True)
class Rule:
    """One rule of a tolerance file: the keys it covers, its tolerances and where they come from."""

    keys: tuple[str, ...]
    rel: float
    abs: float
    why: str
    skip: bool = False

    def covers(self, path: str) -> bool:
        relative = re.sub(r"^[^.\[]*\.json", "", path).lstrip(".")  # the path below the file's name
        generic = re.sub(r"\[\d+\]", "[*]", relative)
        return any(fnmatch.fnmatchcase(generic, _literal_brackets(pattern)) for pattern in self.keys)


def _literal_brackets(pattern: str) -> str:
    """An fnmatch pattern in which ``[`` and ``]`` are literal (list indices), ``*`` still a wildcard."""
    return pattern.replace("[", "\0").replace("]", "[]]").replace("\0", "[[]")


def load_rules(name: str) -> tuple[Rule, ...]:
    """The rules of ``tests/golden/NAME.tolerances.toml`` (none when the file does not exist)."""
    path = GOLDEN / f"{Path(name).stem}.tolerances.toml"
    if not path.exists():
        return ()
    rules = []
    for k, entry in enumerate(tomllib.loads(path.read_text()).get("rule", [])):
        if not entry.get("why"):
            raise ValueError(f"{path}: rule {k + 1} states no reason (why = ...)")
        rules.append(Rule(tuple(entry["keys"]), float(entry.get("rel", 0.0)), float(entry.get("abs", 0.0)),
                          str(entry["why"]), bool(entry.get("skip", False))))
    return tuple(rules)


def _rule(path: str, rules: tuple[Rule, ...]) -> Rule | None:
    return next((rule for rule in rules if rule.covers(path)), None)
#: keys whose values depend on the machine, the paths or the version, not on the computation
IGNORED_KEYS = frozenset({"provenance", "version", "impactid_version", "files", "file", "files_read", "plots",
                          "path", "paths", "source", "sources", "seconds", "elapsed_s", "created", "written",
                          "outputs", "recordings"})


def _differences(got, want, path: str, out: list[str], rules: tuple[Rule, ...] = ()) -> None:
    rule = _rule(path, rules)
    if rule is not None and rule.skip:
        return
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
                _differences(got[key], want[key], f"{path}.{key}", out, rules)
    elif isinstance(want, list):
        if not isinstance(got, list) or len(got) != len(want):
            out.append(f"{path}: expected a list of {len(want)}, got {got!r:.80}")
            return
        for k, (g, w) in enumerate(zip(got, want, strict=True)):
            _differences(g, w, f"{path}[{k}]", out, rules)
    elif isinstance(want, (int, float)) and not isinstance(want, bool):
        if not isinstance(got, (int, float)) or isinstance(got, bool):
            out.append(f"{path}: expected {want!r}, got {got!r}")
        else:
            rel, absolute = (rule.rel, rule.abs) if rule is not None else (RELATIVE_TOLERANCE, 0.0)
            if not math.isclose(got, want, rel_tol=rel, abs_tol=max(absolute, 1e-300)):
                relative = abs(got - want) / abs(want) if want else math.inf
                out.append(f"{path}: {got!r} != golden {want!r} (difference {abs(got - want):.3g}, relative "
                           f"{relative:.2e}; tolerance rel {rel:g}, abs {absolute:g})")
    elif isinstance(want, str) and isinstance(got, str) and os.path.isabs(want) and os.path.isabs(got):
        return  # a file path of the run (a temporary folder), not a result
    elif got != want:
        out.append(f"{path}: {got!r:.80} != golden {want!r:.80}")


def assert_matches_golden(data: dict, name: str) -> None:
    """Assert that ``data`` (a JSON result) matches ``tests/golden/NAME`` (or write it when updating).

    ``IMPACTID_UPDATE_GOLDEN=1`` rewrites the golden file; ``IMPACTID_GOLDEN_DUMP=DIR`` also writes
    the result as computed into ``DIR/NAME`` (to compare environments with ``compare_files``)."""
    path = GOLDEN / name
    plain = json.loads(json.dumps(data))
    if os.environ.get("IMPACTID_GOLDEN_DUMP"):  # the result as computed here, to study the differences
        Path(os.environ["IMPACTID_GOLDEN_DUMP"], name).write_text(json.dumps(plain, indent=1, sort_keys=True))
    if os.environ.get("IMPACTID_UPDATE_GOLDEN") == "1":
        path.write_text(json.dumps(plain, indent=1, sort_keys=True) + "\n")
        return
    assert path.exists(), f"golden file {path} is missing (write it with IMPACTID_UPDATE_GOLDEN=1)"
    differences: list[str] = []
    _differences(plain, json.loads(path.read_text()), name, differences, load_rules(name))
    assert not differences, f"{len(differences)} differences from {name}:\n" + "\n".join(differences[:30])


def compare_files(got_path: str | os.PathLike[str], name: str, zero: bool = False) -> list[str]:
    """The differences of a dumped result from the golden file ``NAME`` (``zero``: with no tolerance
    at all, to see how far each quantity moved between two environments)."""
    got = json.loads(Path(got_path).read_text())
    want = json.loads((GOLDEN / name).read_text())
    out: list[str] = []
    rules = (Rule(("*",), 0.0, 0.0, "exact"),) if zero else load_rules(name)
    _differences(got, want, name, out, rules)
    return out

"""The golden comparisons themselves: every tolerance rule states its reason and covers keys of its
file, and a difference beyond a rule's tolerance (or a number turned null) is reported."""

from __future__ import annotations

import copy
import json

import pytest

from tests.golden import GOLDEN, _differences, load_rules


def _paths(data, path=""):
    if isinstance(data, dict):
        for key, value in data.items():
            yield from _paths(value, f"{path}.{key}")
    elif isinstance(data, list):
        for k, value in enumerate(data):
            yield from _paths(value, f"{path}[{k}]")
    else:
        yield path


GOLDEN_FILES = sorted(p.name for p in GOLDEN.glob("*.json"))


@pytest.mark.parametrize("name", GOLDEN_FILES)
def test_every_rule_has_a_reason_and_covers_keys(name):
    data = json.loads((GOLDEN / name).read_text())
    paths = [f"{name}{p}" for p in _paths(data)]
    for rule in load_rules(name):
        assert rule.why.strip()
        assert any(rule.covers(p) for p in paths), f"{name}: rule {rule.keys} covers no key of the file"


@pytest.mark.parametrize("name", GOLDEN_FILES)
def test_a_change_beyond_the_tolerance_is_reported(name):
    want = json.loads((GOLDEN / name).read_text())
    rules = load_rules(name)
    for rule in rules:
        if rule.skip:
            continue
        got = copy.deepcopy(want)
        # change the first number the rule covers by ten times its tolerance
        for path in _paths(want):
            if rule.covers(f"{name}{path}"):
                break
        else:
            continue
        target, parts = got, path.replace("[", ".[").strip(".").split(".")
        for part in parts[:-1]:
            target = target[int(part[1:-1])] if part.startswith("[") else target[part]
        last = parts[-1]
        key = int(last[1:-1]) if last.startswith("[") else last
        value = target[key]
        if not isinstance(value, (int, float)) or isinstance(value, bool):
            continue
        target[key] = value + 10.0 * max(rule.abs, rule.rel * abs(value)) + (1.0 if value == 0 and not rule.abs else 0)
        out: list[str] = []
        _differences(got, want, name, out, rules)
        assert out, f"{name}{path}: a change of ten tolerances went unnoticed"
        # and a number that becomes null (undetermined) is always a difference
        target[key] = None
        out = []
        _differences(got, want, name, out, rules)
        assert out

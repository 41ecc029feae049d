"""The package's layering, checked from the source (docs/contributing.md, "Layers").

Three layers, visible in the folder tree:

* the **core** (recordings and units, signals and events, the DP5 core, the identification engine,
  result types, files, the rig protocol and registry, the argument kit, the task runner) imports no
  rig and never the application;
* the **rigs** (``impactid/rigs/<rig>/``) are plug-ins: each imports the core and its own folder,
  never another rig and never the application;
* the **application** (``pipeline``, ``campaign``, ``cli``, the launcher, the package face) sits on
  top; it reaches rigs through the registry only (the face re-exports public names of rigs lazily,
  through strings, so that ``import impactid`` loads no rig).

A *room* is a rig folder, a subpackage or a top-level module. The import graph between rooms counts
every import statement, at module level and inside functions, and has no cycle.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from collections import defaultdict
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "impactid"

#: The application's rooms (everything else outside ``rigs/<rig>/`` is the core).
APPLICATION = frozenset({"impactid", "impactid.pipeline", "impactid.campaign", "impactid.cli",
                         "impactid._launcher", "impactid.warmup"})


def module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def room(module: str) -> str:
    """The room of a module: ``impactid.rigs.<rig>`` for a rig's folder, the subpackage for a
    module of one (``impactid.simulate``), else the module itself."""
    parts = module.split(".")
    if len(parts) >= 3 and parts[1] == "rigs" and (PACKAGE / "rigs" / parts[2]).is_dir():
        return ".".join(parts[:3])
    if len(parts) >= 2 and (PACKAGE / parts[1]).is_dir() and parts[1] != "rigs":
        return ".".join(parts[:2])
    return module


def rig_of(room_name: str) -> str | None:
    parts = room_name.split(".")
    if len(parts) == 3 and parts[1] == "rigs" and (PACKAGE / "rigs" / parts[2]).is_dir():
        return parts[2]
    return None


def layer(room_name: str) -> str:
    if rig_of(room_name):
        return "rig"
    return "application" if room_name in APPLICATION else "core"


def _is_package(module: str) -> bool:
    return (PACKAGE.parent / Path(*module.split(".")) / "__init__.py").exists()


def imports() -> list[tuple[str, str, int, bool]]:
    """Every internal import: (importing module, imported module, line, inside a function)."""
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        module = module_name(path)
        package = module if path.name == "__init__.py" else module.rpartition(".")[0]
        tree = ast.parse(path.read_text(), filename=str(path))
        functions = {id(n) for f in ast.walk(tree) if isinstance(f, (ast.FunctionDef, ast.AsyncFunctionDef))
                     for n in ast.walk(f)}
        for node in ast.walk(tree):
            targets = []
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = package.split(".")[: len(package.split(".")) - node.level + 1]
                    source = ".".join(base + ([node.module] if node.module else []))
                else:
                    source = node.module or ""
                for alias in node.names:  # "from impactid.rigs import flat" imports a module
                    candidate = f"{source}.{alias.name}"
                    targets.append(candidate if _is_package(candidate) or
                                   (PACKAGE.parent / Path(*candidate.split("."))).with_suffix(".py").exists()
                                   else source)
            for target in targets:
                if target == "impactid" or target.startswith("impactid."):
                    found.append((module, target, node.lineno, id(node) in functions))
    return found


def edges() -> dict[tuple[str, str], list[str]]:
    """Room -> room imports, with where each happens (``module:line``)."""
    graph: dict[tuple[str, str], list[str]] = defaultdict(list)
    for source, target, line, _ in imports():
        a, b = room(source), room(target)
        if a != b and f"{source}:{line}" not in graph[(a, b)]:
            graph[(a, b)].append(f"{source}:{line}")
    return graph


def cycles(graph: dict[tuple[str, str], list[str]]) -> list[list[str]]:
    """The strongly connected components with more than one room (Tarjan)."""
    successors: dict[str, set[str]] = defaultdict(set)
    for a, b in graph:
        successors[a].add(b)
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for succ in sorted(successors[node]):
            if succ not in index:
                visit(succ)
                low[node] = min(low[node], low[succ])
            elif succ in on_stack:
                low[node] = min(low[node], index[succ])
        if low[node] == index[node]:
            component = []
            while True:
                top = stack.pop()
                on_stack.discard(top)
                component.append(top)
                if top == node:
                    break
            if len(component) > 1:
                components.append(sorted(component))

    for node in sorted(set(successors) | {b for _, b in graph}):
        if node not in index:
            visit(node)
    return components


def violations() -> list[str]:
    """Every import that breaks a layering rule, one line each."""
    found = []
    for (a, b), where in sorted(edges().items()):
        la, lb = layer(a), layer(b)
        if la == "rig" and lb == "rig":
            found.append(f"rig {a} imports rig {b}: {', '.join(where)}")
        elif lb == "rig" and a != "impactid":
            found.append(f"{la} {a} imports rig {b}: {', '.join(where)}")
        elif lb == "rig":  # the face: lazily, through strings only
            found.append(f"the package face imports rig {b} with an import statement: {', '.join(where)}")
        elif la != "application" and lb == "application":
            found.append(f"{la} {a} imports the application {b}: {', '.join(where)}")
    return found


def test_no_import_cycle_between_rooms():
    graph = edges()
    found = cycles(graph)
    detail = []
    for component in found:
        inside = set(component)
        detail.append(" -> ".join(component) + "\n" + "\n".join(
            f"    {a} -> {b}: {', '.join(w)}" for (a, b), w in sorted(graph.items()) if a in inside and b in inside))
    assert not found, "import cycles between rooms:\n" + "\n".join(detail)


def test_layers_import_downwards_only():
    found = violations()
    assert not found, f"{len(found)} imports break the layering:\n" + "\n".join(found)


def test_the_rooms_are_what_the_tree_shows():
    """The analysis itself: a rig's module is in its rig's room, a subpackage's in the subpackage's."""
    assert room("impactid.rigs.pivoted.kernel") == "impactid.rigs.pivoted"
    assert room("impactid.rigs.registry") == "impactid.rigs.registry"
    assert room("impactid.simulate.dp5") == "impactid.simulate"
    assert layer("impactid.rigs.drop") == "rig" and layer("impactid.cli") == "application"
    assert layer("impactid.io") == "core"
    assert cycles({("a", "b"): ["x"], ("b", "c"): ["y"], ("c", "a"): ["z"], ("c", "d"): ["w"]}) == [["a", "b", "c"]]
    # a violation is found: the registry importing a rig would be one
    assert any(target.startswith("impactid.") for _, target, _, _ in imports())


@pytest.mark.parametrize("module", ["impactid", "impactid.rigs.registry", "impactid.io", "impactid.rigs"])
def test_importing_the_core_loads_no_rig(module):
    code = (f"import sys, {module}\n"
            "rigs = sorted(m for m in sys.modules if m.startswith('impactid.rigs.') and m.count('.') >= 2\n"
            "              and m.split('.')[2] not in ('base', 'registry', '_toml', '_params', 'valvespring'))\n"
            "print(','.join(rigs))")
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert loaded == "", f"import {module} loads rig modules: {loaded}"


def test_no_rig_contributes_the_estimate_command():
    from impactid.rigs.registry import MODELS, rig_model

    for name in list(MODELS):
        model = rig_model(name)
        assert all(c.name != "estimate" for c in model.command_specs()), f"{name} contributes 'estimate'"


def test_a_rig_model_names_its_own_modules():
    """The protocol's import paths (kernel, commands, estimation, replay, calibrate) point into the
    rig's own folder, and each resolves."""
    from impactid.rigs.registry import MODELS, PLUGINS, rig_model

    for name in list(MODELS):
        model = rig_model(name)
        package = PLUGINS[name][0]
        paths = {field: getattr(model, field) for field in ("kernel", "commands", "estimation", "replay", "calibrate")}
        for field, path in paths.items():
            if not isinstance(path, str):
                continue
            assert path.partition(":")[0].startswith(package + "."), f"{name}.{field} = {path!r} is outside {package}"
        for field in ("replay", "calibrate"):
            if paths[field] is not None:
                assert callable(model.function(field)), f"{name}.{field} = {paths[field]!r} does not resolve"
    assert rig_model("pivoted-follower").replay and rig_model("drop-impact").replay

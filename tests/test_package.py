"""The package face: ``import impactid`` is light, every public name resolves to the same object, and
the command line starts light (``impactid --help`` loads no numerics)."""

from __future__ import annotations

import subprocess
import sys

import pytest

import impactid


def test_import_loads_no_numerics():
    code = ("import sys, impactid; heavy = [m for m in ('numba', 'scipy', 'pandas', 'matplotlib', 'h5py') "
            "if m in sys.modules]; print(','.join(heavy))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == ""


def test_public_names_resolve_to_their_modules_objects():
    import importlib

    for name, module in impactid._PUBLIC.items():
        assert getattr(impactid, name) is getattr(importlib.import_module(module), name), name
    assert set(impactid.__all__) - {"__version__"} == set(impactid._PUBLIC)


def test_functions_named_like_submodules_stay_functions():
    import impactid.rigs.pivoted.reconstruct  # noqa: F401 - the submodules, imported before the names are read
    import impactid.rigs.pivoted.runs  # noqa: F401
    import impactid.simulate.dp5  # noqa: F401 - the core package named like the function
    from impactid import reconstruct, simulate

    assert callable(impactid.simulate) and impactid.simulate is simulate and simulate.__module__.endswith("runs")
    assert callable(impactid.reconstruct) and reconstruct.__module__ == "impactid.rigs.pivoted.reconstruct"


def test_the_command_line_imports_in_a_fresh_process():
    # module import order is no longer fixed by the package face: the command line must import alone
    subprocess.run([sys.executable, "-c", "import impactid.cli"], check=True)
    subprocess.run([sys.executable, "-c", "import impactid.io"], check=True)


def test_numba_gets_a_writable_cache_when_its_own_are_not(monkeypatch, tmp_path):
    """A read-only installation and no writable home (a service account): numba would refuse every
    cached kernel ('no locator available'); impactid points it at a per-user temporary folder."""
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.delitem(sys.modules, "numba")  # as before numba's first import (restored afterwards)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    monkeypatch.setattr(impactid.os, "access", lambda path, mode: False)
    impactid._numba_cache_fallback()
    assert "impactid-numba-cache" in impactid.os.environ["NUMBA_CACHE_DIR"]
    # a read-only installation and a writable user cache: impactid's own folder there
    (tmp_path / "cache").mkdir()
    monkeypatch.delenv("NUMBA_CACHE_DIR")
    monkeypatch.setattr(impactid.os, "access", lambda path, mode: "cache" in str(path))
    impactid._numba_cache_fallback()
    assert impactid.os.environ["NUMBA_CACHE_DIR"] == str(tmp_path / "cache" / "impactid" / "numba")


# ---- start-up: the command line is built from light modules ----------------------------------------

#: Runs ``impactid ARGS`` as the console script does (the launcher), then prints the modules loaded.
_HELP_PROBE = """
import contextlib, io, sys
from impactid._launcher import main
with contextlib.redirect_stdout(io.StringIO()) as out, contextlib.suppress(SystemExit):
    main(sys.argv[1:])
assert "usage: impactid" in out.getvalue(), out.getvalue()
print(" ".join(sorted(sys.modules)))
"""

#: What no ``--help`` may load (numpy is not needed either, and is checked too).
_HEAVY = ("numba", "llvmlite", "pandas", "scipy", "matplotlib", "numpy", "pyarrow", "h5py", "dask", "pint")

#: The modules of a rig's folder that building the parser may import: its package, its commands and
#: its arguments (and the ball's parameters, which load nothing: its ``--ball`` type reads the presets).
_LIGHT_RIG_MODULES = ("commands", "arguments")


def _loaded_by(*argv: str) -> set[str]:
    out = subprocess.run([sys.executable, "-c", _HELP_PROBE, *argv], capture_output=True, text=True, check=True)
    return set(out.stdout.split())


@pytest.mark.parametrize("argv", [["--help"], ["estimate", "--help"], ["synth", "--help"], ["valvetrain", "--help"],
                                  ["valvetrain", "simulate", "--help"], ["events", "--help"], ["bounces", "--help"],
                                  ["drop", "fit", "--help"], ["info", "--help"], ["campaign", "--help"]],
                         ids=" ".join)
def test_help_loads_no_numerics(argv):
    """``impactid --help`` and ``impactid COMMAND --help`` (a test of the modules loaded, not of seconds:
    benchmarks/bench_startup.py times them) load no numba, pandas, SciPy, matplotlib or NumPy, no
    estimation, pipeline or reader, and of each rig its package, commands and arguments only."""
    loaded = _loaded_by(*argv)
    heavy = sorted(m for m in loaded if m.split(".")[0] in _HEAVY)
    assert not heavy, f"impactid {' '.join(argv)} loads {', '.join(heavy)}"
    assert not {"impactid.pipeline", "impactid.io", "impactid.results", "impactid.campaign"} & loaded
    rig_modules = sorted(m for m in loaded if m.startswith("impactid.rigs.") and m.count(".") >= 3
                         and m.split(".")[3] not in _LIGHT_RIG_MODULES and m != "impactid.rigs.ball.parameters")
    assert not rig_modules, f"impactid {' '.join(argv)} loads rig modules {', '.join(rig_modules)}"


@pytest.mark.parametrize("argv,rig,module", [
    (["detachment", "--json"], "pivoted", "impactid.rigs.pivoted.regimes"),  # rig P by default
    (["detachment", "--rig", "alzate2007", "--json"], "flat", "impactid.rigs.flat.parameters"),  # a preset name
], ids=["default", "preset"])
def test_a_command_loads_its_own_rig_only(argv, rig, module):
    """A command builds its rig's model and loads its rig's numerics; of the other rigs, only what the
    parser reads (a preset name is found without building the other rigs' models)."""
    code = ("import contextlib, io, sys\n"
            "from impactid.cli import main\n"
            "with contextlib.redirect_stdout(io.StringIO()):\n"
            f"    assert main({argv!r}) == 0\n"
            "print(' '.join(sorted(sys.modules)))\n")
    loaded = set(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                                check=True).stdout.split())
    assert module in loaded
    others = sorted(m for m in loaded if m.startswith("impactid.rigs.") and m.count(".") >= 3
                    and m.split(".")[2] != rig and m.split(".")[3] not in _LIGHT_RIG_MODULES
                    and m != "impactid.rigs.ball.parameters")
    assert not others, f"impactid {' '.join(argv)} loads other rigs' modules: {', '.join(others)}"


def test_the_light_declarations_agree_with_the_rigs():
    """What the parser reads without building a rig's model or importing its numerics is what the
    model and the numerical modules say: the package constants (COMMANDS, ESTIMATION,
    ESTIMATE_ARGUMENTS, PRESET_NAMES) are the model's fields, the estimate's arguments and title are the
    estimator's, and the choices written out in the light modules are the numerical modules' names."""
    import importlib

    from impactid.rigs import registry

    for name, (package, _) in registry.PLUGINS.items():
        module = importlib.import_module(package)
        model = registry.rig_model(name)
        for field in ("commands", "estimation", "estimate_arguments"):
            assert vars(module)[field.upper()] == getattr(model, field), (name, field)
        assert module.PRESET_NAMES == tuple(model.presets), name
        assert registry.rig_commands(name) == model.command_specs()
        est = registry.estimator(name)
        if est is None:
            assert model.estimation is None and registry.estimate_arguments(name) == ()
        else:
            assert registry.estimate_arguments(name) == tuple(est.arguments), name
            assert registry.estimate_title(name) == est.title != "", name
    from impactid.rigs.ball import commands as ball_commands
    from impactid.rigs.ball.laws import LAWS
    from impactid.rigs.flat import commands as flat_commands
    from impactid.rigs.flat.parameters import MODEL_NAME as FLAT
    from impactid.rigs.pivoted import arguments, commands
    from impactid.rigs.pivoted.parameters import MODEL_NAME as PIVOTED
    from impactid.rigs.pivoted.reconstruct import ANCHORS
    from impactid.signal import INTEGRATORS

    assert arguments.INTEGRATORS == tuple(INTEGRATORS) and arguments.ANCHORS == tuple(ANCHORS)
    assert ball_commands.LAWS == tuple(LAWS)
    assert commands.MODEL_NAME == PIVOTED and flat_commands.MODEL_NAME == FLAT


def test_a_stop_during_a_commands_import_waits_for_the_import(tmp_path, monkeypatch):
    """A command imports its heavy modules when it runs, inside the command's environment: a Ctrl-C
    that arrives while a module is being initialised acts once the import has ended (an exception
    in the middle of a library's initialisation, pyarrow's under pandas, killed or hung the process),
    and still stops the command."""
    import threading
    import time

    from impactid import cli

    if threading.current_thread() is not threading.main_thread():
        pytest.skip("signals reach the main thread only")
    (tmp_path / "impactid_slow_module.py").write_text(
        "import os, signal, time\n"
        "os.kill(os.getpid(), signal.SIGINT)\n"
        "deadline = time.monotonic() + 0.5\n"
        "while time.monotonic() < deadline:\n"
        "    pass\n"
        "DONE = True\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, "impactid_slow_module", raising=False)
    with pytest.raises(KeyboardInterrupt):
        with cli._command_environment():
            import impactid_slow_module  # noqa: F401 - interrupted while it is initialised

            time.sleep(5.0)  # the stop lands here, right after the import
            raise AssertionError("not stopped")
    assert sys.modules["impactid_slow_module"].DONE

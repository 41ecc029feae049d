"""The package face: ``import impactid`` is light, and every public name resolves to the same object."""

from __future__ import annotations

import subprocess
import sys

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
    # a writable user cache: nothing changes
    (tmp_path / "cache").mkdir()
    monkeypatch.delenv("NUMBA_CACHE_DIR")
    monkeypatch.setattr(impactid.os, "access", lambda path, mode: "cache" in str(path))
    impactid._numba_cache_fallback()
    assert "NUMBA_CACHE_DIR" not in impactid.os.environ

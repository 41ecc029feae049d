"""The kernels compiled at installation (impactid._kernel_cache): content stamps, seeding, the build's locator."""

from __future__ import annotations

import importlib
import json
import os
import pickle
import pkgutil
import shutil
import subprocess
import sys
from pathlib import Path

import numba
import pytest
from numba.core.registry import CPUDispatcher

import impactid
from impactid import _kernel_cache, _scan

# one small cached kernel, run in a fresh process; prints numba's cache statistics of the kernel
_RUN_SCAN = """
import json, numpy as np
from impactid import _scan
x = np.linspace(0.0, 1.0, 1000)
_scan.channel_scan(x)
stats = _scan.channel_scan.stats
print(json.dumps({"hits": sum(stats.cache_hits.values()), "misses": sum(stats.cache_misses.values())}))
"""


def _run_scan(tmp_path: Path, **env: str) -> dict:
    environ = {k: v for k, v in os.environ.items()
               if k not in {"NUMBA_CACHE_DIR", _kernel_cache.BUILD_ENV, _kernel_cache.SHIPPED_ENV}}
    environ.update(env, IMPACTID_COMPILE_NOTICE="0", IMPACTID_CACHE_DIR=str(tmp_path / "user"))
    done = subprocess.run([sys.executable, "-c", _RUN_SCAN], env=environ, capture_output=True, text=True,
                          timeout=300, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_every_cached_kernel_of_impactid_gets_the_content_stamped_locator():
    found = 0
    for info in pkgutil.walk_packages(impactid.__path__, "impactid."):
        if info.name.endswith(("__main__", "_launcher")):
            continue
        module = importlib.import_module(info.name)
        for name, obj in vars(module).items():
            if not isinstance(obj, CPUDispatcher) or obj.py_func.__module__ != info.name:
                continue
            cache = getattr(obj, "_cache", None)
            if cache is None or not hasattr(cache, "_impl"):
                continue
            found += 1
            assert type(cache._impl.locator) in _kernel_cache.LOCATORS, f"{info.name}.{name}"
    assert found > 50  # every rig's kernels were seen


def test_the_stamp_follows_the_content_not_the_modification_time(tmp_path):
    source = tmp_path / "kernel.py"
    source.write_text("x = 1\n")
    first = _kernel_cache.content_stamp(str(source))
    os.utime(source, (1_000_000_000, 1_000_000_000))
    assert _kernel_cache.content_stamp(str(source)) == first
    source.write_text("x = 2\n")
    assert _kernel_cache.content_stamp(str(source)) != first
    assert numba.__version__ in first


@pytest.mark.slow
def test_kernels_compiled_into_the_shipped_folder_load_elsewhere_without_compiling(tmp_path):
    shipped = tmp_path / "shipped"
    built = _run_scan(tmp_path, **{_kernel_cache.BUILD_ENV: str(shipped)})
    assert built["misses"] == 1  # compiled, into the shipped folder laid out like the package
    assert list((shipped / Path(_scan.__file__).resolve().relative_to(_kernel_cache.PACKAGE_DIR).parent)
                .glob("_scan.channel_scan-*.nbi"))

    # a fresh cache folder with the shipped kernels: loaded, not compiled, and the files copied there
    loaded = _run_scan(tmp_path, NUMBA_CACHE_DIR=str(tmp_path / "cache"), **{_kernel_cache.SHIPPED_ENV: str(shipped)})
    assert loaded == {"hits": 1, "misses": 0}
    assert list((tmp_path / "cache").rglob("_scan.channel_scan-*.nbi"))

    # without them: compiled (the test can fail)
    cold = _run_scan(tmp_path, NUMBA_CACHE_DIR=str(tmp_path / "cold"),
                     **{_kernel_cache.SHIPPED_ENV: str(tmp_path / "nothing")})
    assert cold["misses"] == 1


def _fake_shipped(tmp_path: Path, stamp) -> Path:
    """A shipped folder with one index of ``_scan`` carrying ``stamp`` and one data file."""
    relative = Path(_scan.__file__).resolve().relative_to(_kernel_cache.PACKAGE_DIR)
    folder = tmp_path / "shipped" / relative.parent
    folder.mkdir(parents=True)
    with open(folder / "_scan.fake-1.py311.nbi", "wb") as f:
        pickle.dump(numba.__version__, f, protocol=-1)
        f.write(pickle.dumps((stamp, {"key": "_scan.fake-1.py311.1.nbc"})))
    (folder / "_scan.fake-1.py311.1.nbc").write_bytes(b"data")
    return tmp_path / "shipped"


def test_a_shipped_index_of_another_source_is_not_copied(tmp_path, monkeypatch):
    shipped = _fake_shipped(tmp_path, ("impactid-kernel-cache-1", "another source", numba.__version__))
    monkeypatch.setenv(_kernel_cache.SHIPPED_ENV, str(shipped))
    (tmp_path / "cache").mkdir()
    assert _kernel_cache.seed(tmp_path / "cache", _scan.__file__) == 0
    assert not list((tmp_path / "cache").iterdir())


@pytest.fixture
def seeded(tmp_path, monkeypatch) -> tuple[Path, Path]:
    """A shipped folder with a current index of ``_scan``, and a cache folder it was seeded into (once)."""
    shipped = _fake_shipped(tmp_path, _kernel_cache.content_stamp(_scan.__file__))
    monkeypatch.setenv(_kernel_cache.SHIPPED_ENV, str(shipped))
    cache = tmp_path / "cache"
    cache.mkdir()
    assert _kernel_cache.seed(cache, _scan.__file__) == 1
    return shipped, cache


def test_a_current_shipped_index_is_copied_once_with_its_data(tmp_path, seeded):
    cache = seeded[1]
    assert sorted(p.name for p in cache.iterdir()) == ["_scan.fake-1.py311.1.nbc", "_scan.fake-1.py311.nbi"]
    # a second process finds the copy current and copies nothing
    shutil.copytree(cache, tmp_path / "again")
    assert _kernel_cache.seed(tmp_path / "again", _scan.__file__) == 0


def test_files_outside_the_package_are_left_to_numba(tmp_path):
    assert _kernel_cache.seed(tmp_path, str(tmp_path / "elsewhere.py")) == 0
    assert _kernel_cache._UserProvided.from_function(None, str(tmp_path / "elsewhere.py")) is None


def test_the_stamp_follows_the_modules_a_kernel_inlines():
    """An upgrade that changes only a callee's module (the integrator core, the rig's geometry) must not
    load the old machine code: those files are part of the stamp."""
    from impactid.rigs.pivoted import kernel

    files = {p.relative_to(_kernel_cache.PACKAGE_DIR).as_posix() for p in _kernel_cache.source_files(kernel.__file__)}
    assert {"rigs/pivoted/kernel.py", "rigs/pivoted/parameters.py", "simulate/dp5.py"} <= files
    assert "rigs/pivoted/__init__.py" not in files  # a package's __init__ only where a name comes from it


def test_seeding_links_instead_of_copying_where_it_can(seeded):
    shipped, cache = seeded
    source = next(shipped.rglob("_scan.fake-1.py311.1.nbc"))
    assert (cache / source.name).stat().st_ino == source.stat().st_ino  # one file, two names


def test_the_build_reads_which_rigs_to_compile():
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))
    try:
        from _impactid_build import DEFAULT_RIGS, precompile_rigs
    finally:
        sys.path.pop(0)
    assert precompile_rigs({}) == list(DEFAULT_RIGS)
    for value in ("1", "yes", "true", "on"):
        assert precompile_rigs({"IMPACTID_PRECOMPILE": value}) == list(DEFAULT_RIGS)
    for value in ("0", "none", "off", ""):
        assert precompile_rigs({"IMPACTID_PRECOMPILE": value}) == []
    assert precompile_rigs({"IMPACTID_PRECOMPILE": "all"}) == ["all"]
    assert precompile_rigs({"IMPACTID_PRECOMPILE": "drop-impact, flat-follower"}) == ["drop-impact", "flat-follower"]


_CHECK_MODULE = """
import importlib, sys
from numba.core.registry import CPUDispatcher
from impactid import _kernel_cache
module = importlib.import_module(sys.argv[1])
for name, obj in vars(module).items():
    cache = getattr(obj, "_cache", None) if isinstance(obj, CPUDispatcher) else None
    if cache is not None and hasattr(cache, "_impl") and obj.py_func.__module__ == module.__name__:
        assert type(cache._impl.locator) in _kernel_cache.LOCATORS, f"{module.__name__}.{name}"
"""


@pytest.mark.slow
def test_each_kernel_module_installs_the_locators_itself():
    """Imported first, in a fresh interpreter: a kernel module must install impactid's locators before it
    defines its kernels, whatever else was imported before (the in-process test above sees the modules in
    one order only; numba 0.60's CI pass imported ``rigs.cycloidal.cam`` first and found its kernels on
    numba's locator)."""
    modules = sorted({f"impactid.{p.relative_to(_kernel_cache.PACKAGE_DIR).with_suffix('').as_posix()}"
                      .replace("/", ".") for p in _kernel_cache.PACKAGE_DIR.rglob("*.py")
                      if "njit" in p.read_text(encoding="utf-8") and p.name != "__init__.py"})
    assert "impactid.rigs.cycloidal.cam" in modules
    env = {k: v for k, v in os.environ.items() if k not in {_kernel_cache.BUILD_ENV, "NUMBA_DISABLE_JIT"}}
    for module in modules:
        done = subprocess.run([sys.executable, "-c", _CHECK_MODULE, module], env=env, capture_output=True,
                              text=True, timeout=300)
        assert done.returncode == 0, f"{module}: {done.stderr[-800:]}"

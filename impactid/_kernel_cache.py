"""Kernels compiled when impactid is installed: numba's cache, stamped by content and seeded from the package.

numba compiles a ``cache=True`` kernel on first use and keeps the machine code in a cache folder
(:mod:`impactid._cachedir` says which). A cold compilation of rig P's simulator costs about 40 s of
CPU (docs/simulator.md, "Compile time"), too much for a first command. So ``pip install .`` compiles
the kernels once, while it builds the package (``setup.py``: it runs :mod:`impactid.warmup` on the
built package), and ships numba's cache files inside the package, in :data:`SHIPPED` (``impactid/
_precompiled/<the source file's folder>``). On first use each kernel's shipped files are copied into
the cache folder numba would use anyway, where numba loads them as its own: nothing compiles.

Three things make a cache built on one path valid on another:

* **The stamp is the source's content.** numba stamps its cache with the source file's modification
  time (up to numba 0.6x) or its content (later): a copied file gets a new modification time. The
  locators below stamp impactid's kernels with the SHA-256 of the source file and the versions of
  numba, llvmlite and NumPy, so that a cache is used exactly when it was compiled from the same
  source by the same compiler for the same NumPy, wherever the file lies. (numba itself checks its
  own version, the CPU type and the Python version.)
* **The cache folder stays numba's choice** (``NUMBA_CACHE_DIR``, ``__pycache__`` beside the
  package, the user's cache folder): the shipped files are only copied there (:func:`seed`), so a
  read-only installation works, and a signature that was not shipped is compiled and saved there as
  before.
* **A copy is atomic** (a temporary name, then a rename): two processes starting together (pytest's
  workers) never read half a file.

A cache that does not fit (another CPU type, another numba or NumPy, an edited source) is not copied,
and the kernel compiles on first use as it did without it, with the notice of
:mod:`impactid.compilation`. The locators apply to impactid's own source files only; every other
package's kernels keep numba's locators. Installed by :func:`install` (from
:func:`impactid.compilation.install`, which every kernel module calls before defining its kernels).

Environment variables: ``IMPACTID_PRECOMPILE_DIR`` (set by the build only) makes the kernels compile
*into* that folder, laid out as :data:`SHIPPED`; ``IMPACTID_SHIPPED_KERNELS`` reads the shipped
files from another folder (tests).
"""

from __future__ import annotations

import functools
import hashlib
import os
import pickle
import shutil
import threading
import uuid
from pathlib import Path

import llvmlite
import numba
import numpy
from numba.core import caching

__all__ = ["BUILD_ENV", "SHIPPED", "SHIPPED_ENV", "content_stamp", "install", "seed", "shipped_dir"]

#: The package folder; only source files below it get impactid's locators.
PACKAGE_DIR = Path(__file__).resolve().parent
#: Where the kernels compiled at installation lie inside the package.
SHIPPED = PACKAGE_DIR / "_precompiled"
#: Compile into this folder (the build sets it; laid out as :data:`SHIPPED`).
BUILD_ENV = "IMPACTID_PRECOMPILE_DIR"
#: Read the shipped kernels from this folder instead of :data:`SHIPPED`.
SHIPPED_ENV = "IMPACTID_SHIPPED_KERNELS"

# numba 0.60 names its locators with a leading underscore; later releases without
_LOCATORS = {name: getattr(caching, name, None) or getattr(caching, "_" + name)
             for name in ("UserProvidedCacheLocator", "InTreeCacheLocator", "UserWideCacheLocator")}
_CACHE_IMPL = getattr(caching, "CacheImpl", None) or caching._CacheImpl


def shipped_dir() -> Path:
    """The folder the shipped kernels are read from (:data:`SHIPPED` unless ``IMPACTID_SHIPPED_KERNELS``)."""
    folder = os.environ.get(SHIPPED_ENV)
    return Path(folder) if folder else SHIPPED


def _relative(py_file: str) -> Path | None:
    """``py_file`` relative to the package folder, or None for a file outside impactid."""
    try:
        return Path(py_file).resolve().relative_to(PACKAGE_DIR)
    except (ValueError, OSError):
        return None


@functools.cache
def _file_digest(path: str, mtime_ns: int, size: int) -> str:
    # the modification time and size are part of the key so that an edit during a session is re-read
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def content_stamp(py_file: str) -> tuple[str, ...]:
    """The stamp of a kernel's cache: the source's SHA-256 and the compiler's and NumPy's versions.

    Parameters
    ----------
    py_file : the kernel's source file.
    """
    st = os.stat(py_file)
    return ("impactid-kernel-cache-1", _file_digest(py_file, st.st_mtime_ns, st.st_size),
            numba.__version__, llvmlite.__version__, numpy.__version__)


def _read_index(path: Path) -> tuple[object, list[str]] | None:
    """The stamp and the data file names of a numba cache index, or None (missing, another numba, unreadable)."""
    try:
        with open(path, "rb") as f:
            version = pickle.load(f)
            if version != numba.__version__:
                return None
            stamp, overloads = pickle.loads(f.read())
    except (OSError, EOFError, pickle.UnpicklingError, AttributeError, ImportError, TypeError, ValueError):
        return None
    return stamp, list(overloads.values())


def _same_bytes(a: Path, b: Path) -> bool:
    try:
        return a.stat().st_size == b.stat().st_size and a.read_bytes() == b.read_bytes()
    except OSError:
        return False


def _copy_atomic(source: Path, target: Path) -> None:
    temporary = target.with_name(f"{target.name}.tmp.{uuid.uuid4().hex[:12]}")
    try:
        shutil.copyfile(source, temporary)
        os.replace(temporary, target)
    finally:
        if temporary.exists():
            temporary.unlink()


_SEEDED: set[tuple[str, str]] = set()
_SEED_LOCK = threading.Lock()


def seed(cache_path: str | os.PathLike[str], py_file: str) -> int:
    """Copy the shipped cache files of ``py_file``'s kernels into ``cache_path``; returns how many indexes.

    An index is copied (its data files first) when its stamp is the source's current
    :func:`content_stamp` and the cache folder does not already hold a current one. Once per
    (folder, source file) and process; an unwritable folder is left alone (numba then compiles, as
    without shipped kernels).

    Parameters
    ----------
    cache_path : the folder numba caches the kernels of ``py_file`` in.
    py_file : the kernels' source file (inside the impactid package).
    """
    relative = _relative(py_file)
    key = (str(cache_path), str(py_file))
    with _SEED_LOCK:
        if relative is None or key in _SEEDED:
            return 0
        _SEEDED.add(key)
        source_dir = shipped_dir() / relative.parent
        if not source_dir.is_dir():
            return 0
        stamp = content_stamp(py_file)
        target_dir = Path(cache_path)
        copied = 0
        for index in sorted(source_dir.glob(f"{relative.stem}.*.nbi")):
            shipped = _read_index(index)
            if shipped is None or shipped[0] != stamp:
                continue
            target = target_dir / index.name
            if target.exists() and _same_bytes(index, target):
                continue  # copied before (the common case: no unpickling)
            present = _read_index(target)
            if present is not None and present[0] == stamp:
                continue
            try:
                for name in shipped[1]:
                    _copy_atomic(source_dir / name, target_dir / name)
                _copy_atomic(index, target_dir / index.name)
            except OSError:
                return copied
            copied += 1
        return copied


class _ContentStamped:
    """Locator mixin: impactid's files only, stamped by :func:`content_stamp`, seeded from the shipped kernels."""

    _py_file: str

    def get_source_stamp(self):
        return content_stamp(self._py_file)

    @classmethod
    def from_function(cls, py_func, py_file):
        if _relative(py_file) is None or os.environ.get(BUILD_ENV):
            return None
        locator = super().from_function(py_func, py_file)
        if locator is not None:
            seed(locator.get_cache_path(), py_file)
        return locator


class _UserProvided(_ContentStamped, _LOCATORS["UserProvidedCacheLocator"]):
    """``NUMBA_CACHE_DIR`` (numba's first choice), for impactid's kernels."""


class _InTree(_ContentStamped, _LOCATORS["InTreeCacheLocator"]):
    """``__pycache__`` beside the source (numba's second choice), for impactid's kernels."""


class _UserWide(_ContentStamped, _LOCATORS["UserWideCacheLocator"]):
    """numba's folder in the user's cache (numba's third choice), for impactid's kernels."""


class _Build(_LOCATORS["InTreeCacheLocator"]):
    """The build's locator: compile into ``$IMPACTID_PRECOMPILE_DIR`` laid out as :data:`SHIPPED`."""

    def __init__(self, py_func, py_file):
        super().__init__(py_func, py_file)
        self._cache_path = str(Path(os.environ[BUILD_ENV]) / _relative(py_file).parent)

    def get_source_stamp(self):
        return content_stamp(self._py_file)

    @classmethod
    def from_function(cls, py_func, py_file):
        if _relative(py_file) is None or not os.environ.get(BUILD_ENV):
            return None
        locator = cls(py_func, py_file)
        locator.ensure_cache_path()  # the build's folder must be writable: an error here is the build's
        return locator


#: impactid's locators, in numba's order of preference, before numba's own.
LOCATORS = (_Build, _UserProvided, _InTree, _UserWide)


def install() -> None:
    """Put impactid's locators before numba's (once per process; before any impactid kernel is defined)."""
    classes = list(_CACHE_IMPL._locator_classes)
    if classes[: len(LOCATORS)] != list(LOCATORS):
        _CACHE_IMPL._locator_classes = list(LOCATORS) + [c for c in classes if c not in LOCATORS]

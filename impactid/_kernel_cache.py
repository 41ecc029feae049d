"""Kernels compiled when impactid is installed: numba's cache, stamped by content and seeded from the package.

numba compiles a ``cache=True`` kernel on first use and keeps the machine code in a cache folder
(:mod:`impactid._cachedir` says which). A cold compilation of rig P's simulator costs about 40 s of
CPU (docs/simulator.md, "Compile time"), too much for a first command. So ``pip install .`` compiles
the kernels once, while it builds the package (``setup.py``: it runs :mod:`impactid.warmup` on the
built package), and ships numba's cache files inside the package, in :data:`SHIPPED` (``impactid/
_precompiled/<the source file's folder>``). On first use each kernel's shipped files are copied into
the cache folder numba would use anyway, where numba loads them as its own: nothing compiles.

Three things make a cache built on one path valid on another:

* **The stamp is the sources' content.** numba stamps its cache with the source file's modification
  time (up to numba 0.6x) or its content (later): a copied file gets a new modification time, and
  neither sees an edit of a module whose code the kernel inlined (numba #8926). The locators below
  stamp impactid's kernels with the SHA-256 of the kernel's source file and of every impactid source
  whose code it uses, directly or not (:func:`source_files`: its imports, followed), and with the
  versions of numba, llvmlite and NumPy. So a cache is used exactly when it was compiled from the
  same sources by the same compiler for the same NumPy, wherever the files lie, and an upgrade that
  changes a kernel's callee invalidates it. (numba itself checks its own version, the CPU type and
  the Python version.)
* **The cache folder stays numba's choice** (``NUMBA_CACHE_DIR``, ``__pycache__`` beside the
  package, the user's cache folder): the shipped files are only placed there (:func:`seed`: a hard
  link where the file system allows, else a copy), so a read-only installation works, and a
  signature that was not shipped is compiled and saved there as before.
* **Placing is atomic** (a temporary name, then a rename): two processes starting together
  (pytest's workers) never read half a file.

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
import re
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


def _digest(path: Path) -> str:
    st = path.stat()
    return _file_digest(str(path), st.st_mtime_ns, st.st_size)


def _module_file(dotted: str) -> Path | None:
    """The source file of impactid module ``dotted`` (a package's ``__init__.py``), or None if it is not one."""
    parts = dotted.split(".")
    if parts[0] != "impactid":
        return None
    base = PACKAGE_DIR.joinpath(*parts[1:])
    for candidate in (base.with_suffix(".py"), base / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


_IMPORT = re.compile(r"^[ \t]*import[ \t]+(impactid(?:\.\w+)*)", re.M)
_FROM_IMPORT = re.compile(r"^[ \t]*from[ \t]+(impactid(?:\.\w+)*)[ \t]+import[ \t]+(\([^)]*\)|[^\n]*)", re.M)


@functools.cache
def _imports(path: str, mtime_ns: int, size: int) -> tuple[str, ...]:
    """The impactid modules whose code a source file uses: ``import X.Y`` gives ``X.Y``; ``from X import a``
    gives ``X.a`` when that is a module, else ``X`` (where ``a`` is defined). Import statements at any
    depth of the file count (a function's own imports too); read by two regular expressions, not by
    parsing the file (a tenth of the time; a docstring line that reads like an import only adds a file
    to the stamp, which errs on the safe side)."""
    text = Path(path).read_text(encoding="utf-8")
    found = list(_IMPORT.findall(text))
    for module, names in _FROM_IMPORT.findall(text):
        for name in names.strip("()").split(","):
            name = name.split("#")[0].split(" as ")[0].strip().strip("()\\ \t\n")
            if not name:
                continue
            submodule = f"{module}.{name}"
            found.append(submodule if _module_file(submodule) is not None else module)
    return tuple(dict.fromkeys(found))


def source_files(py_file: str) -> list[Path]:
    """``py_file`` and every impactid source file whose code it uses, directly or through another (:func:`_imports`).

    A kernel's machine code holds what it inlined from the modules it imports (the integrator core,
    the rig's geometry), so its cache must follow those files too, not only its own: numba stamps only
    the kernel's own file, and an edit of a callee's module is not seen (numba #8926). A package's
    ``__init__`` counts only where a name is imported from it.
    """
    start = Path(py_file).resolve()
    seen: dict[Path, None] = {}
    queue = [start]
    while queue:
        path = queue.pop()
        if path in seen:
            continue
        seen[path] = None
        st = path.stat()
        for name in _imports(str(path), st.st_mtime_ns, st.st_size):
            module = _module_file(name)
            if module is not None and module not in seen:
                queue.append(module)
    return sorted(seen)


def content_stamp(py_file: str) -> tuple[str, ...]:
    """The stamp of a kernel's cache: the SHA-256 of its source and of every impactid source it uses
    (:func:`source_files`), and the compiler's and NumPy's versions.

    Computed once per source file and process (numba asks for it once per kernel: dozens of kernels
    share a module); an edit of the kernel's own file during the process is seen, one of another
    module it uses is seen by the next process.

    Parameters
    ----------
    py_file : the kernel's source file.
    """
    st = os.stat(py_file)
    return _stamp(str(Path(py_file).resolve()), st.st_mtime_ns, st.st_size)


@functools.cache
def _stamp(py_file: str, mtime_ns: int, size: int) -> tuple[str, ...]:
    digest = hashlib.sha256()
    for path in source_files(py_file):
        rel = path.relative_to(PACKAGE_DIR) if path.is_relative_to(PACKAGE_DIR) else path
        digest.update(f"{rel.as_posix()}\0{_digest(path)}\0".encode())
    return ("impactid-kernel-cache-2", digest.hexdigest(), numba.__version__, llvmlite.__version__,
            numpy.__version__)


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


def _same_size(a: Path, b: Path) -> bool:
    try:
        return a.stat().st_size == b.stat().st_size
    except OSError:
        return False


def _place(source: Path, target: Path) -> None:
    """Put ``source`` at ``target`` atomically: a hard link where the file system allows (no second copy of
    the machine code in the installation), else a copy; by a temporary name, then a rename."""
    temporary = target.with_name(f"{target.name}.tmp.{uuid.uuid4().hex[:12]}")
    try:
        try:
            os.link(source, temporary)
        except OSError:
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
            if _same_bytes(index, target) and all(_same_size(source_dir / name, target_dir / name)
                                                  for name in shipped[1]):
                continue  # placed before (the common case: no unpickling)
            present = _read_index(target)
            if present is not None and present[0] == stamp and all((target_dir / name).is_file()
                                                                   for name in present[1]):
                continue  # compiled here for the same sources (perhaps with more signatures): numba's own
            try:
                for name in shipped[1]:
                    _place(source_dir / name, target_dir / name)
                _place(index, target)
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

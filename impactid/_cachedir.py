"""Where impactid's compiled kernels are cached, decided before numba is imported (standard library only).

numba compiles every ``cache=True`` kernel on first use and keeps the machine code in a cache
folder; a cold start of rig P's simulator costs tens of seconds of compilation, a cached one a
fraction of a second. The folder, in order:

1. ``NUMBA_CACHE_DIR``, when set: numba's own variable wins (for every numba package in the process).
2. ``$IMPACTID_CACHE_DIR/numba``, when ``IMPACTID_CACHE_DIR`` is set: the variable that also holds
   the example recordings (:func:`impactid.rigs.pivoted.example.cache_dir`) moves the kernels too.
3. Beside the package (numba's ``__pycache__`` folders), when the installation is writable: numba's
   default, nothing is set.
4. The user's cache folder, when the installation is read-only (a system or Nix installation, a
   container image with a read-only site-packages): :func:`user_cache_root` ``/numba``, i.e.
   ``$XDG_CACHE_HOME/impactid/numba`` or ``~/.cache/impactid/numba`` on Linux,
   ``~/Library/Caches/impactid/numba`` on macOS, ``%LOCALAPPDATA%\\impactid\\Cache\\numba`` on Windows.
5. A per-user folder in the temporary directory, when the user's cache folder is not writable
   either (no home folder, a service account): a cache that does not outlive the machine, but a
   working command (without a writable folder numba refuses every cached kernel, "no locator
   available").

Cases 2, 4 and 5 set ``NUMBA_CACHE_DIR`` for the process (:func:`impactid._numba_cache_fallback`,
at ``import impactid``, before numba is imported); so the choice applies only when impactid is
imported before numba, and to every numba package in the process. docs/performance_cold_start.md
says why and what the cold start costs.
"""

from __future__ import annotations

import os
import sys
import tempfile
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

__all__ = ["CacheChoice", "choose_kernel_cache", "user_cache_root", "writable"]

#: The environment variable that moves impactid's caches (example recordings and compiled kernels).
ENV = "IMPACTID_CACHE_DIR"


@dataclass(frozen=True)
class CacheChoice:
    """Where the compiled kernels go.

    Attributes
    ----------
    folder : the folder to set as ``NUMBA_CACHE_DIR``, or None to leave numba's choice alone (an
        explicit ``NUMBA_CACHE_DIR``, or ``__pycache__`` beside the writable package).
    reason : why, in a few words (``impactid warmup`` prints it).
    """

    folder: Path | None
    reason: str


def user_cache_root(environ: Mapping[str, str] = os.environ, platform: str = sys.platform) -> Path | None:
    """impactid's folder in the user's cache (``$IMPACTID_CACHE_DIR`` when set), or None without a home folder.

    Parameters
    ----------
    environ : the environment (``os.environ``).
    platform : ``sys.platform``.
    """
    if environ.get(ENV):
        return Path(environ[ENV])
    if environ.get("XDG_CACHE_HOME"):
        return Path(environ["XDG_CACHE_HOME"]) / "impactid"
    if platform.startswith("win") and environ.get("LOCALAPPDATA"):
        return Path(environ["LOCALAPPDATA"]) / "impactid" / "Cache"
    try:
        home = Path.home()
    except RuntimeError:  # no home folder at all
        return None
    if platform == "darwin":
        return home / "Library" / "Caches" / "impactid"
    return home / ".cache" / "impactid"


def writable(folder: Path) -> bool:
    """Whether ``folder`` can be written, or created under its nearest existing parent."""
    existing = next((p for p in (folder, *folder.parents) if p.exists()), None)
    return existing is not None and existing.is_dir() and os.access(existing, os.W_OK)


def choose_kernel_cache(package_dir: Path, environ: Mapping[str, str] = os.environ,
                        platform: str = sys.platform) -> CacheChoice:
    """The cache folder of the compiled kernels (the order of the module's docstring).

    Parameters
    ----------
    package_dir : the folder of the installed ``impactid`` package.
    environ : the environment (``os.environ``).
    platform : ``sys.platform``.
    """
    if environ.get("NUMBA_CACHE_DIR"):
        return CacheChoice(None, f"NUMBA_CACHE_DIR ({environ['NUMBA_CACHE_DIR']})")
    if environ.get(ENV):
        return CacheChoice(Path(environ[ENV]) / "numba", f"{ENV}")
    if os.access(package_dir, os.W_OK):
        return CacheChoice(None, "beside the package (__pycache__)")
    user = user_cache_root(environ, platform)
    if user is not None and writable(user / "numba"):
        return CacheChoice(user / "numba", "the user's cache folder (the installation is read-only)")
    uid = os.getuid() if hasattr(os, "getuid") else "user"
    return CacheChoice(Path(tempfile.gettempdir()) / f"impactid-numba-cache-{uid}",
                       "a temporary folder (neither the installation nor the user's cache folder is writable)")

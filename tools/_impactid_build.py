"""impactid's build backend: setuptools' own, with the build requirements of the kernels' compilation.

``pip install .`` compiles rig P's numba kernels into the package while it builds it (``setup.py``,
docs/simulator.md "Kernels compiled at installation"). That compilation imports the package, so it
needs the package's runtime dependencies in pip's isolated build environment; this backend asks for
them (read from ``pyproject.toml``'s ``[project] dependencies``, not written twice) only for a wheel
that compiles kernels. An sdist, an editable install and ``IMPACTID_PRECOMPILE=0`` need setuptools
alone.
"""

from __future__ import annotations

import os
import tomllib
from pathlib import Path

from setuptools import build_meta as _setuptools
from setuptools.build_meta import *  # noqa: F401,F403 - the rest of the backend is setuptools' own

#: The rigs compiled when ``IMPACTID_PRECOMPILE`` is unset (or 1, yes, true, on): rig P, the rig of
#: ``impactid estimate --example``.
DEFAULT_RIGS = ("pivoted-follower",)


def precompile_rigs(environ=os.environ) -> list[str]:
    """The rigs whose kernels the build compiles, from ``IMPACTID_PRECOMPILE``: unset or 1/yes/true/on,
    :data:`DEFAULT_RIGS`; 0/no/false/off/none (or empty), none; ``all``, ``["all"]``; else the
    comma-separated rig names."""
    value = environ.get("IMPACTID_PRECOMPILE")
    if value is None or value.strip().lower() in {"1", "yes", "true", "on"}:
        return list(DEFAULT_RIGS)
    if value.strip().lower() in {"", "0", "no", "false", "off", "none"}:
        return []
    return [name.strip() for name in value.split(",") if name.strip()]


def get_requires_for_build_wheel(config_settings=None):
    requires = list(_setuptools.get_requires_for_build_wheel(config_settings))
    if precompile_rigs():
        project = tomllib.loads(Path("pyproject.toml").read_text(encoding="utf-8"))["project"]
        requires += list(project["dependencies"])
    return requires

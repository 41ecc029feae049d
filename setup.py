"""Build step of impactid: the package metadata is in pyproject.toml; this file adds one step to the build.

After the sources are copied into the build folder, the numba kernels of the rigs named by
``IMPACTID_PRECOMPILE`` are compiled there (``impactid.warmup`` run on the built package, in a
subprocess of the build's Python) into ``impactid/_precompiled``, which the wheel then carries: the
first command after ``pip install .`` loads them instead of compiling for about 40 s
(:mod:`impactid._kernel_cache`, docs/simulator.md "Compile time").

``IMPACTID_PRECOMPILE``: unset, rig P (``pivoted-follower``: the rig of ``impactid estimate --example``);
``all``, every rig (about 3 min more of building); a comma-separated list of rig names; ``0`` or
``none``, nothing. The step is best effort: when it fails, the build says so and goes on, and the
kernels compile on first use as before. An editable install (``pip install -e .``) compiles nothing
here (its kernels are cached beside the sources on first use).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

_WARMUP = """
import sys
from impactid import warmup
names = sys.argv[1].split(",")
warmup.warm_up(warmup.all_models() if names == ["all"] else names, lambda line: print("impactid build:", line))
"""


class BuildWithKernels(build_py):
    """``build_py``, then the kernels compiled into the built package (best effort)."""

    def run(self) -> None:
        super().run()
        if getattr(self, "editable_mode", False):
            return
        target = Path(self.build_lib).resolve() / "impactid" / "_precompiled"
        shutil.rmtree(target, ignore_errors=True)  # never ship a previous build's files
        rigs = os.environ.get("IMPACTID_PRECOMPILE", "pivoted-follower").strip()
        if rigs.lower() in {"", "0", "none", "no", "false", "off"}:
            return
        with tempfile.TemporaryDirectory(prefix="impactid-build-") as scratch:
            env = {key: value for key, value in os.environ.items() if key != "NUMBA_CACHE_DIR"}
            env.update(IMPACTID_PRECOMPILE_DIR=str(target), IMPACTID_CACHE_DIR=scratch,  # recordings: scratch
                       IMPACTID_COMPILE_NOTICE="0",
                       # the built package first; pip's isolated build environment reaches its build requirements
                       # through PYTHONPATH (its sitecustomize), which is kept
                       PYTHONPATH=os.pathsep.join(filter(None, [str(target.parents[1]), os.environ.get("PYTHONPATH")])))
            print(f"impactid build: compiling the kernels of {rigs} (IMPACTID_PRECOMPILE=0 skips this)", flush=True)
            result = subprocess.run([sys.executable, "-c", _WARMUP, rigs], env=env, cwd=scratch)
        if result.returncode != 0:
            shutil.rmtree(target, ignore_errors=True)
            print("impactid build: WARNING: the kernels could not be compiled now; they compile on first use",
                  flush=True)


setup(cmdclass={"build_py": BuildWithKernels})

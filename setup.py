"""Build step of impactid: the package metadata is in pyproject.toml; this file adds one step to the build.

After the sources are copied into the build folder, the numba kernels of the rigs named by
``IMPACTID_PRECOMPILE`` are compiled there (``impactid.warmup`` run on the built package, one
subprocess of the build's Python per rig) into ``impactid/_precompiled``, which the wheel then
carries: the first command after ``pip install .`` loads them instead of compiling for about 40 s
(:mod:`impactid._kernel_cache`, docs/simulator.md "Kernels compiled at installation").

``IMPACTID_PRECOMPILE`` (read by ``tools/_impactid_build.py``, the build backend, which also asks for
the build requirements this needs): unset, rig P (``pivoted-follower``: the rig of ``impactid
estimate --example``); ``all``, every rig (two rigs at a time: about 40 s more of the install on
two cores, 124.8 s against 83.4 s in one measurement); a comma-separated list of rig names; ``0``
or ``none``, nothing. The step is best effort: a rig whose compilation fails is reported and left
to compile on first use, the others are kept. A wheel with compiled kernels holds
machine code for this CPU type and Python, so it is tagged for this platform and Python, not as a
pure-Python wheel. An editable install (``pip install -e .``) compiles nothing here (its kernels
are cached beside the sources on first use). The warm-up runs without the builder's ``NUMBA_*``
settings (an optimisation level, bounds checks or debug information would otherwise reach every
user's kernels: numba's cache key does not hold them).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from setuptools import Distribution, setup
from setuptools.command.build_py import build_py

sys.path.insert(0, str(Path(__file__).resolve().parent / "tools"))
from _impactid_build import precompile_rigs  # noqa: E402 - the backend's folder, put on the path above

_WARMUP = """
import sys
from impactid import warmup
warmup.warm_up([sys.argv[1]], lambda line: print("impactid build:", line, flush=True))
"""

#: The rigs whose kernels take longest to compile (docs/simulator.md, "Compile time": about 55 and 40 s).
_LONGEST = ("drop-impact", "pivoted-follower")
#: Longest a rig's compilation may take in the build [s].
TIMEOUT_S = 1800


class BuildWithKernels(build_py):
    """``build_py``, then the kernels compiled into the built package (best effort)."""

    def run(self) -> None:
        super().run()
        if getattr(self, "editable_mode", False):
            return
        target = Path(self.build_lib).resolve() / "impactid" / "_precompiled"
        shutil.rmtree(target, ignore_errors=True)  # never ship a previous build's files
        rigs = precompile_rigs()
        if not rigs:
            return
        print(f"impactid build: compiling the kernels of {', '.join(rigs)} (IMPACTID_PRECOMPILE=0 skips this)",
              flush=True)
        if rigs == ["all"]:
            rigs = self._all_rigs(target.parents[1])
            rigs.sort(key=lambda name: name not in _LONGEST)  # the longest compilations first: they set the end
        # the rigs side by side, as many at a time as there are cores (each compilation is one thread)
        pending, running = list(rigs), {}
        with tempfile.TemporaryDirectory(prefix="impactid-build-") as scratch:
            env = {key: value for key, value in os.environ.items() if not key.startswith("NUMBA_")}
            env.update(IMPACTID_PRECOMPILE_DIR=str(target), IMPACTID_COMPILE_NOTICE="0",
                       # the built package first; pip's isolated build environment reaches its build
                       # requirements through PYTHONPATH (its sitecustomize), which is kept
                       PYTHONPATH=os.pathsep.join(filter(None, [str(target.parents[1]), os.environ.get("PYTHONPATH")])))
            while pending or running:
                while pending and len(running) < max(os.cpu_count() or 1, 1):
                    rig = pending.pop(0)
                    folder = Path(scratch) / rig  # the example recordings of each rig's warm-up: apart
                    folder.mkdir()
                    running[rig] = (subprocess.Popen([sys.executable, "-c", _WARMUP, rig], cwd=folder,
                                                     env={**env, "IMPACTID_CACHE_DIR": str(folder)}), time.monotonic())
                time.sleep(0.2)
                for rig, (proc, started) in list(running.items()):
                    code = proc.poll()
                    if code is None and time.monotonic() - started > TIMEOUT_S:
                        proc.kill()
                        code = f"no end after {TIMEOUT_S} s"
                    if code is None:
                        continue
                    del running[rig]
                    if code != 0:  # what was compiled is kept: each cache entry is complete
                        print(f"impactid build: WARNING: the kernels of {rig} could not all be compiled now "
                              f"({code}); what is missing compiles on first use", flush=True)

    @staticmethod
    def _all_rigs(built: Path) -> list[str]:
        """Every registered rig of the built package (its registry, read by the build's Python)."""
        env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(built), os.environ.get("PYTHONPATH")]))}
        names = subprocess.run([sys.executable, "-c", "from impactid import warmup; print(*warmup.all_models())"],
                               env=env, capture_output=True, text=True, timeout=300).stdout.split()
        return names


class KernelDistribution(Distribution):
    """A distribution whose wheel holds compiled kernels when the build compiles them: tagged for this
    platform and Python (machine code for this CPU type and Python), not as pure Python."""

    def has_ext_modules(self) -> bool:
        return bool(precompile_rigs()) or super().has_ext_modules()


setup(cmdclass={"build_py": BuildWithKernels}, distclass=KernelDistribution)

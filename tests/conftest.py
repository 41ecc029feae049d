"""Shared fixtures. Simulation results used by several tests are computed once per session.

impactid is imported inside the fixtures, not at the top: the xdist controller loads this file but runs
no test, and importing impactid (numba, SciPy) would cost it 3 s before the workers start.
"""

from __future__ import annotations

import functools
import os
import sysconfig
from pathlib import Path

import pytest

#: numba's cache files that ``pip install`` compiled into the installed package (``impactid/_kernel_cache.py``)
SHIPPED_ENV = "IMPACTID_SHIPPED_KERNELS"


def installed_kernels() -> Path | None:
    """The installed impactid's folder of kernels compiled at installation, if it has one.

    ``python -m pytest`` in a checkout imports the checkout's ``impactid``, not the installed copy, so
    that the kernels ``pip install ".[test]"`` compiled (rig P's by default) would be compiled again by
    every test worker. They are the checkout's kernels when the sources are the same: the kernel cache
    stamps each file with its sources' SHA-256 and ignores a shipped file whose stamp differs, so
    pointing the tests at them is safe after any edit (the edited kernels compile, the others load).
    """
    for key in ("platlib", "purelib"):  # the wheel is platform-tagged when it holds compiled kernels
        folder = Path(sysconfig.get_paths()[key]) / "impactid" / "_precompiled"
        if folder.is_dir():
            return folder
    return None


def pytest_configure(config):
    """Point the session (and, by inheritance, the xdist workers) at the installed package's kernels.

    Runs before the workers start; an explicit ``IMPACTID_SHIPPED_KERNELS`` is kept.
    """
    if not os.environ.get(SHIPPED_ENV):
        folder = installed_kernels()
        if folder is not None:
            os.environ[SHIPPED_ENV] = str(folder)


#: Table 2 operating points of Sundar, Dreyer & Singh (2016): (e/r_c, cam speed [Hz])
TABLE2_POINTS = [(0.05, 23.0), (0.10, 18.0), (0.15, 17.0), (0.20, 16.0), (0.25, 15.0)]


@functools.cache
def seed_law_s2():
    """The paper's S2 contact law (Table 2): beta = 24.7 GN s m^-2.5, n = 1.5."""
    from impactid import HuntCrossley

    return HuntCrossley(beta=24.7e9, n=1.5)


@pytest.fixture(scope="session")
def rig():
    from impactid import SUNDAR2016

    return SUNDAR2016


@pytest.fixture(scope="session")
def seed_law():
    return seed_law_s2()


@pytest.fixture(scope="session")
def s2_synthetic():
    """Noise-free S2 recording at the paper's Table 3 point (e/r_c 0.2, 16 Hz), 1 s after 40 s settling."""
    from impactid import SUNDAR2016
    from impactid.rigs.pivoted.synth import synth_pivoted

    return synth_pivoted(SUNDAR2016.with_eccentricity_ratio(0.2), 16.0, seed_law_s2(), 1.0)


@pytest.fixture(scope="session")
def s2_file(s2_synthetic, tmp_path_factory):
    """``s2_synthetic`` written to HDF5 (with ``/truth``)."""
    return s2_synthetic.write(tmp_path_factory.mktemp("s2") / "s2.h5")


@pytest.fixture(scope="session")
def s3_synthetic():
    """Noise-free S3 recording (restitution law, gamma = 0.8 s/m) at e/r_c 0.2, 16 Hz, 1 s."""
    from impactid import SUNDAR2016, Restitution
    from impactid.rigs.pivoted.synth import synth_pivoted

    return synth_pivoted(SUNDAR2016.with_eccentricity_ratio(0.2), 16.0, Restitution(gamma=0.8), 1.0)


@pytest.fixture(scope="session")
def s2_second_point():
    """Noise-free S2 recording at the other fast-settling period-1 point (e/r_c 0.25, 15 Hz), 1 s."""
    from impactid import SUNDAR2016
    from impactid.rigs.pivoted.synth import synth_pivoted

    return synth_pivoted(SUNDAR2016.with_eccentricity_ratio(0.25), 15.0, seed_law_s2(), 1.0)


@pytest.fixture(scope="session")
def s2_noisy():
    """S2 at e/r_c 0.2, 16 Hz, 4 s, with 0.5 % noise on every channel (seed 3)."""
    from impactid import SUNDAR2016
    from impactid.rigs.pivoted.synth import synth_pivoted
    from impactid.synth import SensorModel

    return synth_pivoted(SUNDAR2016.with_eccentricity_ratio(0.2), 16.0, seed_law_s2(), 4.0,
                         sensors=SensorModel(noise=0.005, seed=3))


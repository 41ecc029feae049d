"""Shared fixtures of the cycloidal-cam valve-train tests (Kushwaha, Rahnejat & Jin 2000).

``R`` is the independent plain NumPy/SciPy reference of the same specification
(``tests/rigs/cycloidal/reference_cycloidal_ehl.py``, written by someone else); nothing of impactid is imported there.
"""

from __future__ import annotations

import pytest

from impactid.rigs.cycloidal import KUSHWAHA2000
from tests.rigs.cycloidal import reference_cycloidal_ehl as R


@pytest.fixture(scope="session")
def rig():
    return KUSHWAHA2000


@pytest.fixture(scope="session")
def ref_p():
    return R.reference_params()


@pytest.fixture(scope="session")
def cycle_a3000(rig):
    from impactid.rigs.cycloidal import cycle

    return cycle(rig, 3000.0, "A")


@pytest.fixture(scope="session")
def ref_a3000(ref_p):
    return R.cycle_outputs(3000.0, ref_p, level="A")

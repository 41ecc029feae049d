"""Shared fixtures of the single-impact test rig (``drop-impact``).

``R`` (``tests/rigs/drop/reference_drop.py``) is the independent plain SciPy ``solve_ivp`` model of the
same specification; it imports nothing of impactid's physics. Recordings it makes are computed once
per session.
"""

from __future__ import annotations

import pytest

from tests.rigs.drop import reference_drop as R

#: The truth of the recovery tests: the preset's rig and nominal law, drops from these heights [m].
HEIGHTS = (0.05, 0.2)


@pytest.fixture(scope="session")
def rig():
    from impactid.rigs.drop import STEEL_ON_PA6

    return STEEL_ON_PA6


@pytest.fixture(scope="session")
def law():
    from impactid.rigs.drop import PA6_PAD_LAW

    return PA6_PAD_LAW


@pytest.fixture(scope="session")
def reference_drops(rig, law):
    """Two noise-free drops made by the reference (recording, reference impacts)."""
    return [R.reference_recording(rig, law.beta, law.n, h) for h in HEIGHTS]


@pytest.fixture(scope="session")
def noisy_reference_drops(rig, law):
    """The same drops with 0.5 % Gaussian noise on both channels (seeds 1 and 2)."""
    return [R.reference_recording(rig, law.beta, law.n, h, noise=0.005, seed=1 + i) for i, h in enumerate(HEIGHTS)]

"""Shared fixtures. Simulation results used by several tests are computed once per session."""

from __future__ import annotations

import pytest

from impactid import SEED001_TABLE1, HuntCrossley

#: the seed's S2 contact law (Table 2): beta = 24.7 GN s m^-2.5, n = 1.5
SEED_LAW = HuntCrossley(beta=24.7e9, n=1.5)

#: Table 2 operating points of seed 001: (e/r_c, cam speed [Hz])
TABLE2_POINTS = [(0.05, 23.0), (0.10, 18.0), (0.15, 17.0), (0.20, 16.0), (0.25, 15.0)]


@pytest.fixture(scope="session")
def rig():
    return SEED001_TABLE1


@pytest.fixture(scope="session")
def seed_law():
    return SEED_LAW

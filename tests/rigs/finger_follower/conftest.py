"""Shared fixtures of the finger-follower tests (computed once per session)."""

from __future__ import annotations

import pytest

from impactid.rigs.finger_follower.parameters import KIM1990


@pytest.fixture(scope="session")
def rig():
    return KIM1990


@pytest.fixture(scope="session")
def train(rig):
    from impactid.rigs.finger_follower.simulate import prepare

    return prepare(rig)


@pytest.fixture(scope="session")
def ref():
    from tests.rigs.finger_follower import reference_finger_follower as R

    return R


@pytest.fixture(scope="session")
def ref_params(ref):
    return ref.reference_params()


@pytest.fixture(scope="session")
def ref_kin(ref, ref_params):
    return ref.build_kinematics(ref_params)

"""Shared synthetic drops for the bouncing-ball tests (computed once per session)."""

from __future__ import annotations

import numpy as np
import pytest

from impactid.rigs.ball import TABLE_TENNIS
from impactid.rigs.ball.synth import synth_drop

HEIGHTS = (0.08, 0.12, 0.18, 0.24, 0.30)
LINEAR = {"e0": 0.96, "gamma": 0.02}


@pytest.fixture(scope="session")
def clean_drops():
    """Five fault-free table-tennis drops (linear law, drag), times on the 1/48000 s grid, no jitter."""
    return [synth_drop("linear", LINEAR, seed=10 + j, ball=TABLE_TENNIS, height=h, min_flight=0.1)
            for j, h in enumerate(HEIGHTS)]


@pytest.fixture(scope="session")
def faulty_drops():
    """Five drops with jitter (0.3 ms) and every kind of trigger fault."""
    return [synth_drop("linear", LINEAR, seed=20 + j, ball=TABLE_TENNIS, height=h, min_flight=0.1, jitter=3e-4,
                       missed=1, echoes=1, spurious=1, displaced=1, release=True, junk_end=1)
            for j, h in enumerate(HEIGHTS)]


def expected_status(labels) -> np.ndarray:
    """The cleaning status each injected label should get."""
    mapping = {"impact": "impact", "junk": "end", "release": "release", "displaced": "displaced",
               "echo": "extra", "spurious": "extra"}
    return np.array([mapping[label] for label in labels])

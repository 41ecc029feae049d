"""Synthetic planar impacts made by the independent reference (tests/rigs/planar/reference_planar.py)."""

import numpy as np
import pytest

from impactid.rigs.planar import MCUBE_ELLIPSE
from tests.rigs.planar.reference_planar import random_impacts, reference_impulses, write_table

#: The law the synthetic impacts follow: Newton restitution e0 (1 - gamma u), Coulomb mu, tangential e_t.
TRUTH = {"e0": 0.8, "gamma": 0.08, "mu": 0.25, "e_t": 0.3}
N_IMPACTS = 120


def reference_outcome(v, jt, jn, truth=TRUTH, body=MCUBE_ELLIPSE):
    minv = np.asarray(body.inverse_mass)
    e = truth["e0"] * (1.0 - truth["gamma"] * -(jn * v).sum(1))
    p = reference_impulses(v, jt, jn, minv, e, truth["mu"], truth["e_t"])
    v_post = v + minv * (jt * p[:, :1] + jn * p[:, 1:])
    return p, v_post


@pytest.fixture(scope="session")
def synthetic():
    v, jt, jn = random_impacts(N_IMPACTS, seed=7)
    p, v_post = reference_outcome(v, jt, jn)
    return v, jt, jn, p, v_post


@pytest.fixture()
def table(tmp_path, synthetic):
    v, jt, jn, p, v_post = synthetic
    return write_table(tmp_path / "impacts.csv", v, jt, jn, impulse=p, v_post=v_post)

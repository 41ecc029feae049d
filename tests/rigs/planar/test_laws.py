"""The closed-form laws against the independent reference (SLSQP on the complementarity conditions)."""

import numpy as np
import pytest

from impactid.rigs.planar import LAWS, MCUBE_ELLIPSE, get_law
from impactid.rigs.planar import commands as planar_commands
from impactid.rigs.planar.laws import chatterjee_ruina_impulse, delassus, newton_coulomb_impulse, outcome
from tests.rigs.planar.reference_planar import random_impacts, reference_impulses

MINV = np.asarray(MCUBE_ELLIPSE.inverse_mass)


@pytest.mark.parametrize("mu,e_t", [(0.05, 0.0), (0.3, 0.0), (0.3, 0.5), (1.0, -0.5)])
def test_newton_coulomb_matches_the_reference(mu, e_t):
    v, jt, jn = random_impacts(40, seed=3)
    e = np.linspace(0.3, 0.9, 40)
    expected = reference_impulses(v, jt, jn, MINV, e, mu, e_t)
    w = delassus(jt, jn, MINV)
    pt, pn, sticking = newton_coulomb_impulse((jt * v).sum(1), (jn * v).sum(1), *w, e, mu, e_t)
    scale = np.abs(expected).max()
    assert np.max(np.abs(np.c_[pt, pn] - expected)) < 1e-6 * scale
    if mu == 0.05:  # a thin cone: both regimes, sliding and sticking, are compared
        assert 0 < sticking.sum() < 40


def test_comparison_can_fail():
    v, jt, jn = random_impacts(40, seed=3)
    expected = reference_impulses(v, jt, jn, MINV, 0.6, 0.05, 0.0)
    pt, pn, _ = newton_coulomb_impulse((jt * v).sum(1), (jn * v).sum(1), *delassus(jt, jn, MINV), 0.6, 0.0505, 0.0)
    assert np.max(np.abs(np.c_[pt, pn] - expected)) > 1e-4 * np.abs(expected).max()


def test_frictionless_and_central_impacts_are_textbook():
    """A central impact (no lever) without friction: p_n = (1 + e) m |v_n|, p_t = 0."""
    n = 5
    jn = np.tile([0.0, 1.0, 0.0], (n, 1))
    jt = np.tile([1.0, 0.0, 0.0], (n, 1))
    v = np.stack([np.linspace(-1, 1, n), -np.linspace(1, 3, n), np.zeros(n)], axis=1)
    for rule in (newton_coulomb_impulse, chatterjee_ruina_impulse):
        pt, pn, _ = rule(v[:, 0], v[:, 1], *delassus(jt, jn, MINV), 0.7, 0.0, 0.0)
        np.testing.assert_allclose(pn, 1.7 * MCUBE_ELLIPSE.mass * -v[:, 1], rtol=1e-12)
        np.testing.assert_allclose(pt, 0.0, atol=1e-15)
    # with ample friction the contact point stops sliding: p_t = -m v_t
    pt, _, sticking = newton_coulomb_impulse(v[:, 0], v[:, 1], *delassus(jt, jn, MINV), 0.7, 10.0, 0.0)
    np.testing.assert_allclose(pt, -MCUBE_ELLIPSE.mass * v[:, 0], atol=1e-15)
    assert sticking.all()


def test_receding_contacts_get_no_impulse():
    v, jt, jn = random_impacts(6, seed=1)
    v[:, 1] *= -1.0
    out = outcome(get_law("newton-constant-et"), {"e": 0.5, "mu": 0.3, "e_t": 0.2}, v, jt, jn, MINV)
    assert np.all(out.p_n == 0) and np.all(out.p_t == 0)
    np.testing.assert_array_equal(out.v_post, v)


def test_laws_are_named_and_the_command_line_knows_them():
    assert planar_commands.LAWS == tuple(LAWS)
    assert get_law("newton-linear-et").names == ("e0", "gamma", "mu", "e_t")
    with pytest.raises(ValueError, match="laws: newton-constant-stick"):
        get_law("hertz")

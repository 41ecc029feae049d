"""Contact and restitution laws and their conversions."""

from __future__ import annotations

import numpy as np
import pytest

from impactid import SUNDAR2016, HuntCrossley, Restitution, SimulationInputError, contact


def test_hunt_crossley_conversion_matches_paper():
    # section 8.3 of Sundar, Dreyer & Singh (2016): gamma = 0.758 s/m gives 9.1 GN s m^-2.5
    beta = contact.beta_from_gamma(0.758, SUNDAR2016.k_H)
    assert beta == pytest.approx(9.1e9, rel=0.005)
    assert contact.gamma_from_beta(beta, SUNDAR2016.k_H) == pytest.approx(0.758, rel=1e-14)


def test_force_law_values():
    k, beta = 8e9, 24.7e9
    delta = np.array([0.0, 1e-6, 2e-5, 2e-5])
    rate = np.array([-0.5, -0.5, -0.1, 0.4])
    f = contact.hunt_crossley_force(delta, rate, k, beta, 1.5)
    expected = k * delta**1.5 - beta * delta**1.5 * rate
    np.testing.assert_allclose(f, expected, rtol=1e-15)
    assert f[0] == 0.0
    assert f[3] < 0.0  # unclipped: tensile near separation when rate > k/beta
    assert contact.clip_tensile(f)[3] == 0.0
    # viscous (n = 0): the damping force acts from first touch
    assert contact.viscous_force(0.0, -0.5, k, 1470.0) == pytest.approx(735.0)


def test_friction_and_restitution():
    assert contact.coulomb_friction(100.0, -2.0, 0.2) == pytest.approx(-20.0)
    np.testing.assert_allclose(contact.restitution_coefficient([0.1, 0.5], 0.8), [0.92, 0.6])
    assert contact.restitution_coefficient(0.3, 0.0, xi0=0.7) == pytest.approx(0.7)
    # outside the law's range the value is returned, not clamped
    assert contact.restitution_coefficient(2.0, 0.8) < 0


@pytest.mark.parametrize(
    "make",
    [lambda: HuntCrossley(beta=-1.0), lambda: HuntCrossley(beta=float("nan")), lambda: HuntCrossley(1e9, n=-0.5),
     lambda: Restitution(gamma=-0.1), lambda: Restitution(gamma=0.8, xi0=1.5), lambda: Restitution(gamma="x")],
)
def test_law_validation(make):
    with pytest.raises(SimulationInputError):
        make()

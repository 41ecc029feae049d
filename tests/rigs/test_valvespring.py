"""The two-mass valve-spring surge model: its closed forms and the papers' table values."""

from __future__ import annotations

import math

import numpy as np
import pytest

from impactid.rigs.valvespring import surge_accelerations, surge_model


def test_closed_forms_reproduce_the_papers_values():
    # Kim, Jeon & Park (1990): K0 = 35 kN/m, f0 = 504.46 Hz, 4 % stiffness-proportional damping
    model = surge_model(35_000.0, 504.46, damping_ratio=0.04)
    assert model.mass == pytest.approx(9.290e-3, abs=5e-7)
    assert model.k_end == pytest.approx(93_333.3, abs=0.1) and model.k_middle == pytest.approx(140_000.0)
    assert model.c_end == pytest.approx(2.3557, abs=1e-4) and model.c_middle == pytest.approx(3.5336, abs=1e-4)
    assert model.static_rate == pytest.approx(35_000.0, rel=1e-12)
    np.testing.assert_allclose(model.natural_frequencies(), [504.46, 2 * 504.46], rtol=1e-12)
    np.testing.assert_allclose(model.damping_ratios(), [0.04, 0.08], rtol=1e-12)
    # Kushwaha, Rahnejat & Jin (2000): the same spring, one damper of 2.355 N s/m
    single = surge_model(35_000.0, 504.5, damper=2.355)
    assert single.mass == pytest.approx(9.289e-3, abs=5e-7)
    ratios = single.damping_ratios()
    assert ratios[0] == pytest.approx(0.04, abs=5e-4) and ratios[1] == pytest.approx(0.06, abs=5e-3)


def test_accelerations_match_the_matrices_and_vanish_at_rest():
    model = surge_model(35_000.0, 504.46, damping_ratio=0.04)
    assert surge_accelerations(0, 0, 0, 0, 0, 0, model.mass, model.k_end, model.k_middle, model.c_end,
                               model.c_middle) == (0.0, 0.0, -0.0)
    rng = np.random.default_rng(1)
    y1, v1, y2, v2 = rng.normal(size=4) * 1e-4
    a1, a2, _ = surge_accelerations(0.0, 0.0, y1, v1, y2, v2, model.mass, model.k_end, model.k_middle,
                                    model.c_end, model.c_middle)
    mass, damping, stiffness = model.matrices()
    expected = -np.linalg.solve(mass, damping @ [v1, v2] + stiffness @ [y1, y2])
    np.testing.assert_allclose([a1, a2], expected, rtol=1e-12)


@pytest.mark.parametrize("kwargs", [{}, {"damping_ratio": 0.04, "damper": 1.0}, {"damping_ratio": -0.1},
                                    {"damper": math.nan}])
def test_bad_arguments_are_refused(kwargs):
    with pytest.raises(ValueError):
        surge_model(35_000.0, 504.46, **kwargs)

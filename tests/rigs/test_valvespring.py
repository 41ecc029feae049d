"""The two-mass valve-spring surge model: its closed forms and the papers' table values."""

from __future__ import annotations

import math

import numpy as np
import pytest

from impactid.rigs.valvespring import (
    CamSpeedRange,
    check_fit_channel,
    check_model_explains,
    damper_damping_ratio,
    surge_accelerations,
    surge_model,
)


class Refused(Exception):
    """The error a caller passes (a rig's IdentificationError)."""


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


def test_one_damper_damping_ratio_is_the_models():
    """``damper_damping_ratio`` is the surge model's first modal ratio: ``c / (2 sqrt(K_s1 m))``."""
    for K0, f0, c in ((35_000.0, 504.5, 2.355), (20_000.0, 300.0, 0.7), (80_000.0, 900.0, 10.0)):
        model = surge_model(K0, f0, damper=c)
        zeta = damper_damping_ratio(K0, f0, c)
        assert zeta == model.damping_ratios()[0]
        assert zeta == pytest.approx(c / (2.0 * math.sqrt(model.k_end * model.mass)), rel=1e-12)
        assert zeta == pytest.approx(3.0 * math.pi * c * f0 / (8.0 * K0), rel=1e-12)
    assert damper_damping_ratio(35_000.0, 504.5, 2.355) == pytest.approx(0.0400, abs=1e-4)
    assert damper_damping_ratio(35_000.0, 504.5, 0.0) == 0.0


def test_bad_spring_parameters_are_impactid_errors():
    from impactid.errors import ImpactidError

    for K0, f0 in ((0.0, 500.0), (35_000.0, math.inf)):
        with pytest.raises(ImpactidError):
            surge_model(K0, f0, damper=1.0)


def test_cam_speed_range_refuses_with_the_argument_named():
    from impactid.errors import SimulationInputError

    speeds = CamSpeedRange(3000.0)
    assert (speeds.lowest_rpm, speeds.highest_rpm) == (pytest.approx(10.0), pytest.approx(9000.0))
    assert speeds.check(10.0, "argument --rpm") == 10.0 and speeds.check("9000", "argument --rpm") == 9000.0
    for value, words in ((9000.1, "above"), (9.99, "below"), (math.nan, "finite"), (-5.0, "positive"),
                         ("fast", "expected a camshaft speed")):
        with pytest.raises(SimulationInputError, match="argument --rpm") as info:
            speeds.check(value, "argument --rpm")
        assert words in str(info.value)
        assert ("3000" in str(info.value)) == (words in ("above", "below"))  # the limit and where it comes from
    with pytest.raises(Refused):
        speeds.check(1e9, "rec.h5: operating cam_speed_hz", Refused)
    # a lift without deceleration never leaves the cam: no upper limit
    assert CamSpeedRange(math.inf).highest_rpm == math.inf
    with pytest.raises(SimulationInputError):
        CamSpeedRange(0.0)


def test_a_channel_that_cannot_inform_a_fit_is_refused_naming_file_and_channel():
    angle = np.linspace(0.0, 8.0 * math.pi, 4000)
    load = 300.0 + 200.0 * np.maximum(np.sin(angle), 0.0)
    check_fit_channel(load, angle, where="rec.h5", channel="contact_load")  # a cam-synchronous signal passes
    cases = {
        "zero in every sample": (np.zeros_like(load), angle),
        "constant (300 N in every sample)": (np.full_like(load, 300.0), angle),
        "too short: it covers 0.249 camshaft revolutions": (load[:250], angle[:250]),
        "100 samples": (load[::40], angle[::40]),
        "1 NaN or Inf sample(s), the first at index 7": (np.where(np.arange(load.size) == 7, math.nan, load), angle),
    }
    for words, (values, angles) in cases.items():
        with pytest.raises(Refused) as info:
            check_fit_channel(values, angles, where="rec.h5", channel="contact_load", unit="N", error=Refused)
        assert "rec.h5: channel 'contact_load'" in str(info.value) and words in str(info.value), words


def test_a_fit_that_explains_nothing_but_noise_is_refused():
    rng = np.random.default_rng(2)
    angle = np.linspace(0.0, 4.0 * math.pi, 2000)
    shape = np.maximum(np.sin(angle), 0.0)

    def fit(y):  # a one-parameter "model": the amplitude of the known shape, and an offset
        design = np.column_stack([np.ones_like(angle), shape])
        coef, *_ = np.linalg.lstsq(design, y, rcond=None)
        return float(np.sum((y - y.mean()) ** 2)), float(np.sum((y - design @ coef) ** 2))

    noise = rng.normal(0.0, 1.0, angle.size)
    with pytest.raises(Refused, match=r"rec.h5: channel 'x' carries no information .*\(F = "):
        check_model_explains(*fit(noise), angle.size, 1, where="rec.h5", channel="x", error=Refused)
    # a signal of half the noise's amplitude passes
    check_model_explains(*fit(noise + 0.5 * shape), angle.size, 1, where="rec.h5", channel="x", error=Refused)
    # a model that leaves more scatter than a constant explains none of it
    with pytest.raises(Refused, match="explains none of it"):
        check_model_explains(10.0, 20.0, 100, 2, where="rec.h5", channel="x", error=Refused)
    with pytest.raises(Refused, match="too short"):
        check_model_explains(10.0, 1.0, 3, 2, where="rec.h5", channel="x", error=Refused)
    check_model_explains(10.0, 0.0, 100, 2, where="rec.h5", channel="x", error=Refused)  # an exact fit

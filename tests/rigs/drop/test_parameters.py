"""Rig parameters of ``drop-impact``: the preset, Hertz's closed forms, validation, the rig-file round trip
and the registry entry."""

from __future__ import annotations

import math

import pytest

from impactid.errors import RigParameterError, SimulationInputError
from impactid.rigs.drop import MODEL, PA6_PAD_LAW, STEEL_ON_PA6, DropLaw, DropRig
from impactid.rigs.drop.parameters import (
    hertz_contact_time,
    hertz_max_penetration,
    hertz_stiffness,
    nominal_law,
    stiffness_from_contact_time,
)
from impactid.rigs.registry import MODELS, load_rig_toml, resolve_rig, rig_model, save_rig_toml


def test_preset_numbers():
    # k = 4/3 E* sqrt(R), steel (210 GPa, 0.3) on PA6 (2.8 GPa, 0.39), R = 8 mm, worked by hand
    e_star = 1.0 / ((1 - 0.3**2) / 210e9 + (1 - 0.39**2) / 2.8e9)
    assert STEEL_ON_PA6.k == pytest.approx(4.0 / 3.0 * e_star * math.sqrt(8e-3), rel=1e-12)
    assert STEEL_ON_PA6.k == pytest.approx(3.8826e8, rel=1e-4)
    assert (STEEL_ON_PA6.mass, STEEL_ON_PA6.p, STEEL_ON_PA6.gravity) == (1.0, 1.5, 9.81)
    assert PA6_PAD_LAW == nominal_law(STEEL_ON_PA6)
    assert PA6_PAD_LAW.beta == pytest.approx(0.3 * STEEL_ON_PA6.k) and PA6_PAD_LAW.n == 1.5


def test_hertz_closed_forms():
    # Hertz's impact of a sphere: T = 2.9432 delta_max / v for p = 1.5; a linear spring lasts pi sqrt(m/k)
    m, k, v = 1.0, 3.9e8, 0.99
    assert hertz_contact_time(m, k, 1.5, v) == pytest.approx(2.94328 * hertz_max_penetration(m, k, 1.5, v) / v,
                                                             rel=1e-5)
    assert hertz_contact_time(2.0, 1e6, 1.0, 3.0) == pytest.approx(math.pi * math.sqrt(2.0 / 1e6), rel=1e-12)
    assert hertz_max_penetration(2.0, 1e6, 1.0, 3.0) == pytest.approx(3.0 * math.sqrt(2.0 / 1e6), rel=1e-12)
    duration = hertz_contact_time(m, k, 1.5, v)
    assert stiffness_from_contact_time(m, 1.5, v, duration) == pytest.approx(k, rel=1e-12)
    assert hertz_stiffness(1.0, 1.0, 0.0, 1.0, 0.0) == pytest.approx(2.0 / 3.0)


def test_derived_quantities():
    rig = STEEL_ON_PA6
    assert rig.impact_speed(0.05) == pytest.approx(math.sqrt(2 * 9.81 * 0.05))
    assert rig.impact_speed(0.0, 2.0) == 2.0
    assert rig.k * rig.static_penetration() ** 1.5 == pytest.approx(rig.mass * rig.gravity)


@pytest.mark.parametrize(("field", "value", "match"), [
    ("mass", 0.0, "'mass' must be positive"),
    ("mass", -1.0, "'mass' must be positive"),
    ("k", 0.0, "'k' must be positive"),
    ("p", 0.5, "'p' .* must lie in \\[1, 3\\]"),
    ("p", 3.5, "'p' .* must lie in \\[1, 3\\]"),
    ("gravity", -9.81, "'gravity' must be >= 0"),
    ("mass", math.nan, "'mass' is not finite"),
    ("k", "3e8", "'k' must be a number"),
    ("p", True, "'p' must be a number"),
])
def test_bad_rig_parameters_name_the_field(field, value, match):
    with pytest.raises(RigParameterError, match=match):
        STEEL_ON_PA6.replace(**{field: value})


def test_zero_gravity_is_a_pendulum():
    assert STEEL_ON_PA6.replace(gravity=0.0).static_penetration() == 0.0


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"beta": -1.0}, "'beta' must be >= 0"),
    ({"beta": math.inf}, "'beta' must be finite"),
    ({"beta": 1.0, "n": -0.1}, "'n' .* must lie in"),
    ({"beta": 1.0, "n": 11.0}, "'n' .* must lie in"),
    ({"beta": "1"}, "'beta' must be a number"),
])
def test_bad_law(kwargs, match):
    with pytest.raises(SimulationInputError, match=match):
        DropLaw(**kwargs)


def test_toml_round_trip(tmp_path):
    rig = STEEL_ON_PA6.replace(mass=5.5, gravity=9.80665)
    path = save_rig_toml(rig, tmp_path / "drop.toml", {"drop_height_m": 0.3})
    back, operating = load_rig_toml(path)
    assert back == rig and operating == {"drop_height_m": 0.3}
    assert 'model = "drop-impact"' in path.read_text()


def test_rig_file_errors_name_file_and_parameter(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text('[rig]\nmodel = "drop-impact"\nmass = 1.0\nk = 3e8\np = 1.5\n')
    with pytest.raises(RigParameterError, match="bad.toml.*missing parameter.*gravity"):
        load_rig_toml(path)
    path.write_text('[rig]\nmodel = "drop-impact"\nmass = -1.0\nk = 3e8\np = 1.5\ngravity = 9.81\n')
    with pytest.raises(RigParameterError, match="bad.toml.*'mass' must be positive"):
        load_rig_toml(path)
    path.write_text('[rig]\nmodel = "drop-impact"\nmass = 1.0\nk = 3e8\np = 1.5\ngravity = 9.81\nbeta = 1.0\n')
    with pytest.raises(RigParameterError, match="unknown rig parameter.*beta"):
        load_rig_toml(path)


def test_registry_entry():
    assert rig_model("drop-impact") is MODEL and MODELS["drop-impact"] is MODEL
    assert MODEL.default is STEEL_ON_PA6 and MODEL.parameters is DropRig
    assert resolve_rig("drop-impact").rig is STEEL_ON_PA6
    assert resolve_rig("STEEL_ON_PA6").model is MODEL
    assert set(MODEL.channels) == {"impactor_acceleration", "contact_force"}
    assert isinstance(MODEL.kernel, str)  # reading a rig file does not load numba


def test_channels_are_interpreted_in_files():
    from impactid.io import channel_spec

    assert channel_spec("impactor_acceleration") == ("m/s^2", "acceleration")
    assert channel_spec("contact_force") == ("N", "force")


def test_import_loads_no_numba():
    import subprocess
    import sys

    code = "import sys; import impactid.rigs.drop; print('numba' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == "False"

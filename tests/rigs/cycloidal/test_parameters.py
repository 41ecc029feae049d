"""Rig parameters: presets, derived values (R-1..R-3 repaired, R-D1), validation, rig-file round trip."""

from __future__ import annotations

import math

import numpy as np
import pytest

from impactid.errors import RigParameterError
from impactid.rigs.cycloidal import (
    KUSHWAHA2000,
    KUSHWAHA2000_THICK_OIL,
    KUSHWAHA2000_ZEROS_EXACT,
    MODEL,
    PRESETS,
    CycloidalEHLRig,
)
from impactid.rigs.registry import MODELS, load_rig_toml, rig_model, save_rig_toml
from tests.rigs.cycloidal import reference_cycloidal_ehl as R


def test_assumed_set_and_derived_values_match_the_reference(rig, ref_p):
    for ours, theirs in (("m3", "m3"), ("k0", "k0"), ("f0", "f0"), ("f_p", "f_p"), ("c_spring", "c"), ("S", "S"),
                         ("beta", "beta"), ("R0", "R0"), ("L_c", "L_c"), ("eta0", "eta0"), ("alpha_pv", "alpha_pv"),
                         ("K_se", "K_se"), ("C_se", "C_se"), ("g_lash", "g_lash")):
        assert getattr(rig, ours) == ref_p[theirs], ours
    assert rig.m5 == pytest.approx(ref_p["m5"], rel=1e-15)
    assert rig.m5 == pytest.approx(9.289e-3, abs=0.5e-6)  # with the square on (pi f0)
    assert rig.k_s1 == pytest.approx(93333.33, abs=0.01) and rig.k_s2 == 140000.0
    assert rig.E_prime == pytest.approx(2.3077e11, rel=2e-5)  # E' = 2/Sigma (R-D1)
    assert rig.G_star == pytest.approx(5769.2, abs=0.05)
    # the shared surge model: f0 and 2 f0, 4 % and 6 % damping with one damper (R-D6 repaired)
    np.testing.assert_allclose(rig.surge.natural_frequencies(), [504.5, 1009.0], rtol=1e-12)
    z1, z2 = rig.surge_damping_ratios
    assert z1 == pytest.approx(0.040, abs=5e-4) and z2 == pytest.approx(1.5 * z1, rel=1e-12)


def test_presets(rig):
    assert MODEL.default is KUSHWAHA2000 and list(PRESETS)[0] == "kushwaha2000"
    assert KUSHWAHA2000_THICK_OIL.eta0 == 0.045
    z = R.reference_params("zeros_exact")
    assert KUSHWAHA2000_ZEROS_EXACT.beta == z["beta"] and KUSHWAHA2000_ZEROS_EXACT.R0 == pytest.approx(z["R0"])
    with pytest.raises(KeyError, match="presets: kushwaha2000"):
        MODEL.preset("kushwaha")


def test_registered_with_its_channels():
    assert rig_model("cycloidal-flat-follower-ehl") is MODEL and MODELS[MODEL.name] is MODEL
    assert set(MODEL.channels) == {"valve_displacement", "cam_angle", "valve_velocity", "contact_load"}
    from impactid.io import channel_spec

    assert channel_spec("valve_displacement") == ("m", "length")
    assert channel_spec("contact_load") == ("N", "force")


@pytest.mark.parametrize("change, match", [
    ({"m3": 0.0}, "m3"), ({"f0": -1.0}, "f0"), ({"nu1": 0.5}, "nu1"), ({"beta": 4.0}, "beta"),
    ({"steps_per_rev": 500.5}, "steps_per_rev"), ({"ws_clip": 0.5}, "ws_clip"), ({"g_lash": -1e-6}, "g_lash"),
    ({"eta0": math.nan}, "eta0"), ({"R0": 2e-3}, "not convex"),
])
def test_bad_parameters_are_refused(change, match):
    with pytest.raises(RigParameterError, match=match):
        KUSHWAHA2000.replace(**change)


def test_not_convex_message_names_the_radius():
    # R0 = 5 mm with S = 8 mm, beta = 90 deg: R = R0 + s + s'' < 0 near 3 beta/4 of the rise
    with pytest.raises(RigParameterError, match=r"radius of curvature .* at cam angle 15\d\.\d+ deg"):
        KUSHWAHA2000.replace(R0=5e-3)


def test_rig_file_round_trip(tmp_path):
    path = save_rig_toml(KUSHWAHA2000_ZEROS_EXACT, tmp_path / "rig.toml", {"cam_speed_hz": 50.0})
    rig, operating = load_rig_toml(path)
    assert isinstance(rig, CycloidalEHLRig) and rig == KUSHWAHA2000_ZEROS_EXACT and operating == {"cam_speed_hz": 50.0}
    text = path.read_text()
    for name in ("m3", "k0", "f0", "f_p", "c_spring", "S", "beta", "R0", "L_c", "E1", "E2", "nu1", "nu2", "eta0",
                 "alpha_pv", "steps_per_rev", "ws_clip", "K_se", "C_se", "g_lash"):
        assert f"\n{name} = " in text
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace("m3 = 0.225", "m_3 = 0.225"))
    with pytest.raises(RigParameterError, match="missing parameter"):
        load_rig_toml(bad)

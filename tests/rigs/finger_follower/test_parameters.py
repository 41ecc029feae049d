"""Parameters of the finger-follower rig: the paper's formulas (closed forms), presets, validation, files."""

from __future__ import annotations

import math

import pytest

from impactid.errors import RigParameterError
from impactid.rigs.finger_follower.parameters import (
    KIM1990,
    KIM1990_TABLE2,
    FingerFollowerRig,
    contact_damping,
    equivalent_mass,
    static_preloads,
    tappet_limits,
    tappet_weights,
)


def test_tappet_limits_reproduce_table1_values(rig):
    K_e, c_plus, c_minus = tappet_limits(rig.A_e, rig.E_oil, rig.H_e, rig.mu_oil, rig.L_p, rig.R_p, rig.h_clear)
    # K-4 and K-5 with Table 1 (the specification's derived values, 5 digits)
    assert K_e == pytest.approx(1.6432e7, rel=5e-5)
    assert c_plus == pytest.approx(2.6350e6, rel=5e-5)
    assert c_minus == pytest.approx(1.1281, rel=5e-5)
    # the Poiseuille term alone, as quoted (2.6320e6) and the shear term (2987)
    poiseuille = 6 * rig.mu_oil * math.pi * rig.L_p * rig.R_p**2 * (rig.R_p + rig.h_clear) / rig.h_clear**3
    assert poiseuille == pytest.approx(2.6320e6, rel=5e-5)
    assert c_plus - poiseuille == pytest.approx(2987, rel=5e-4)
    assert (K_e, c_plus, c_minus) == rig.tappet_limits


def test_time_constants_of_the_identified_tappets(rig):
    for hz, c_q, k_q, tau_q in ((15.0, 1.871e4, 4.601e6, 4.07e-3), (1600 / 60, 2.477e4, 4.930e6, 5.02e-3)):
        c_t, k_t = rig.tappet_drag(hz)
        assert c_t == pytest.approx(c_q, rel=5e-4) and k_t == pytest.approx(k_q, rel=5e-4)
        assert c_t / k_t == pytest.approx(tau_q, rel=2e-3)


def test_contact_damping_rule_reproduces_table2(rig):
    surge = rig.surge
    c_tf = contact_damping(rig.K_tf, rig.M_t, equivalent_mass(rig.L_tf, rig.M_f, rig.I_f))
    c_vf = contact_damping(rig.K_vf, rig.M_v + 2 * surge.mass, equivalent_mass(rig.L_vf, rig.M_f, rig.I_f))
    assert c_tf == pytest.approx(118.97, abs=0.01) and c_vf == pytest.approx(94.13, abs=0.01)
    # C_fc corresponds to a lever arm of 12.72 mm (rigid camshaft)
    assert contact_damping(rig.K_fc, equivalent_mass(12.72e-3, rig.M_f, rig.I_f)) == pytest.approx(197.97, rel=1e-3)
    assert equivalent_mass(0.0, 2.0, 1.0) == 2.0


def test_static_preloads_balance_the_follower(rig):
    F_vf0, F_fc0 = static_preloads(20.0, 1.47)
    assert F_vf0 == pytest.approx(42.553, abs=1e-3) and F_fc0 == pytest.approx(62.553, abs=1e-3)
    # moment balance about G with the base-circle lever arm
    assert rig.F_tf0 * rig.L_tf + rig.F_fc0 * rig.L_fc0 - rig.F_vf0 * rig.L_vf == pytest.approx(0.0, abs=1e-12)
    assert rig.d_c0 == pytest.approx(25.0e-3, rel=1e-12)
    assert rig.Y_v_star == pytest.approx((275.0 - F_vf0) / 1.31e7, rel=1e-12)


def test_speed_law_of_the_tappet_weights():
    args = (0.0071, 0.28, 15.0, 0.0094, 0.30, 1600 / 60)
    assert tappet_weights(10.0, *args) == (0.0071, 0.28)
    assert tappet_weights(50.0, *args) == (0.0094, 0.30)
    a, b = tappet_weights(0.5 * (15.0 + 1600 / 60), *args)
    assert a == pytest.approx(0.5 * (0.0071 + 0.0094)) and b == pytest.approx(0.29)


def test_surge_model_is_the_shared_one(rig):
    s = rig.surge
    assert s.mass == pytest.approx(9.290e-3, abs=5e-7)
    assert s.c_end == pytest.approx(2.3557, abs=1e-4) and s.c_middle == pytest.approx(3.5336, abs=1e-4)


def test_table2_preset_uses_the_printed_tappet_stiffness():
    assert KIM1990_TABLE2.K_e == pytest.approx(6.648e7, rel=1e-12)
    assert KIM1990_TABLE2.C_d_plus == KIM1990.C_d_plus


@pytest.mark.parametrize(("change", "message"), [
    ({"M_t": 0.0}, "'M_t' must be positive"),
    ({"cam_sense": 0.5}, "'cam_sense' must be -1 or \\+1"),
    ({"RR0": 0.9}, "'RR0' must exceed 1"),
    ({"F_tf0": 300.0}, "must exceed the follower/valve preload"),
    ({"R_ab": 0.2}, "do not form a triangle"),
    ({"h_clear": 0.01}, "smaller than the plunger radius"),
    ({"speed_2_hz": 10.0}, "must be below"),
    ({"M_f": math.nan}, "not finite"),
])
def test_invalid_parameters_are_named(change, message):
    with pytest.raises(RigParameterError, match=message):
        KIM1990.replace(**change)


def test_rig_file_round_trip(tmp_path):
    from impactid.rigs.registry import load_rig_toml, save_rig_toml

    path = save_rig_toml(KIM1990, tmp_path / "ff.toml", {"cam_speed_hz": 15.0})
    rig, operating = load_rig_toml(path)
    assert isinstance(rig, FingerFollowerRig) and rig == KIM1990 and operating == {"cam_speed_hz": 15.0}
    text = path.read_text().replace("M_t = ", "M_tt = ")
    (tmp_path / "bad.toml").write_text(text)
    with pytest.raises(RigParameterError, match="missing parameter"):
        load_rig_toml(tmp_path / "bad.toml")

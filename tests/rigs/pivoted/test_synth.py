"""Synthetic rig P recordings: force balance, exact sample instants, S3 impulses, determinism."""

from __future__ import annotations

import math

import numpy as np
import pytest

from impactid import SUNDAR2016, HuntCrossley, simulate
from impactid.rigs.pivoted import spring_force
from impactid.rigs.pivoted.synth import synth_pivoted
from impactid.synth import SensorModel

RIG = SUNDAR2016.with_eccentricity_ratio(0.2)


def force_balance(rig, rec, alpha):
    """(S-21): F = m_b l_g alpha_ddot + N_x sin a + (N_y + F_s - m_b g) cos a, from the written channels."""
    add = rec["accel_tangential"] / rig.l_a
    fs = spring_force(alpha, rig.k_s, rig.L_s_u, rig.d_y, rig.d_x, rig.w_b)
    return rig.m_b * rig.l_g * add + rec["force_x"] * np.sin(alpha) + (rec["force_y"] + fs - rig.m_b * rig.g) * np.cos(
        alpha)


def test_force_balance_s21_recovers_true_contact_force(s2_synthetic):
    rec, truth = s2_synthetic.recording, s2_synthetic.truth
    rebuilt = force_balance(RIG, rec, truth["alpha"])
    peak = np.max(np.abs(truth["contact_force"]))
    assert peak > 1000.0  # impacts are in the window
    assert np.max(np.abs(rebuilt - truth["contact_force"])) <= 1e-9 * peak


def test_force_balance_holds_without_friction_and_with_clipping():
    syn = synth_pivoted(RIG, 16.0, HuntCrossley(24.7e9, 1.5, clip=True), 0.1, settle_s=5.0, mu=0.0)
    rebuilt = force_balance(RIG, syn.recording, syn.truth["alpha"])
    assert np.max(np.abs(rebuilt - syn.truth["contact_force"])) <= 1e-9 * np.max(syn.truth["contact_force"])


def test_sample_instants_are_exact(s2_synthetic):
    rec, truth = s2_synthetic.recording, s2_synthetic.truth
    k = np.arange(rec.n_samples)
    assert np.array_equal(rec.time, 40.0 + k / 204_800.0)
    assert np.array_equal(truth["t"], rec.time)
    assert np.allclose(rec["cam_angle"], 2 * math.pi * 16.0 * rec.time, rtol=0, atol=1e-12)
    # the truth at sample instants equals an independent run evaluated at those instants only
    picks = np.sort(np.random.default_rng(0).choice(rec.n_samples, 40, replace=False))
    direct = simulate(RIG, 16.0, HuntCrossley(24.7e9, 1.5), float(rec.time[picks[-1]]) + 1e-3,
                      t_eval=rec.time[picks])
    assert np.allclose(direct.alpha, truth["alpha"][picks], rtol=0, atol=1e-12)
    assert np.allclose(direct.alpha_dot, truth["alpha_dot"][picks], rtol=1e-9, atol=1e-9)


def test_truth_lists_every_impact(s2_synthetic):
    truth = s2_synthetic.truth
    starts = truth["impacts"]["t_start"]
    assert starts.size == 16 and truth["impact_kinds"].split(",") == ["contact"] * 16
    assert np.allclose(np.diff(starts), 1 / 16.0, rtol=1e-6)  # period-1 after settling
    in_contact = truth["mode"] == 1
    for t0, t1 in zip(starts, truth["impacts"]["t_end"]):
        inside = (truth["t"] > t0) & (truth["t"] < t1)
        assert np.all(in_contact[inside])


def test_s3_impulses_carry_the_velocity_jump(s3_synthetic):
    rec, truth = s3_synthetic.recording, s3_synthetic.truth
    imp = truth["impacts"]
    kinds = truth["impact_kinds"].split(",")
    jumps = [(t, a1 - a0) for t, a0, a1, k in zip(imp["t_start"], imp["alpha_dot_start"], imp["alpha_dot_end"], kinds)
             if k == "impact"]
    assert len(jumps) >= 16
    dt = 1 / rec.sample_rate_hz
    accel = rec["accel_tangential"]
    free = truth["alpha_ddot"] * RIG.l_a  # the smooth part at each sample
    for t, jump in jumps:
        k = int((t - rec.start_time_s) / dt)
        area = (accel[k:k + 2] - free[k:k + 2]).sum() * dt
        assert area == pytest.approx(RIG.l_a * jump, rel=1e-9)
    # xi = 1 - gamma v_a per impact
    va = -imp["gap_rate_start"][np.array(kinds) == "impact"]
    xi = imp["xi"][np.array(kinds) == "impact"]
    assert np.allclose(xi, 1 - 0.8 * va, rtol=1e-9)


def test_same_seed_same_file_and_noise_changes_with_seed():
    sensors = SensorModel(noise=0.005, adc_bits=16, seed=3)
    a = synth_pivoted(RIG, 16.0, HuntCrossley(24.7e9, 1.5), 0.05, settle_s=1.0, sensors=sensors)
    b = synth_pivoted(RIG, 16.0, HuntCrossley(24.7e9, 1.5), 0.05, settle_s=1.0, sensors=sensors)
    c = synth_pivoted(RIG, 16.0, HuntCrossley(24.7e9, 1.5), 0.05, settle_s=1.0,
                      sensors=SensorModel(noise=0.005, adc_bits=16, seed=4))
    for name in a.recording.channels:
        assert np.array_equal(a.recording[name], b.recording[name])
    assert not np.array_equal(a.recording["force_x"], c.recording["force_x"])


def test_bad_arguments_are_rejected():
    from impactid.errors import SimulationInputError

    with pytest.raises(SimulationInputError, match="unknown channel"):
        synth_pivoted(RIG, 16.0, HuntCrossley(24.7e9, 1.5), 0.01, channels=("pressure",))
    with pytest.raises(SimulationInputError, match="duration must be positive"):
        synth_pivoted(RIG, 16.0, HuntCrossley(24.7e9, 1.5), -1.0)
    with pytest.raises(SimulationInputError, match="noise fractions"):
        SensorModel(noise=-0.1)

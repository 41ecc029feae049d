"""Compiled simulator: closed-form checks, conservation, the restitution reset, the batch entry
point and the errors it raises. (The comparison with solve_ivp is in test_against_solve_ivp.py.)"""

from __future__ import annotations

import dataclasses
import math
import pickle

import numpy as np
import pytest
from scipy import special

from impactid import (
    SUNDAR2016,
    HuntCrossley,
    Restitution,
    RigParameterError,
    SimulationError,
    SimulationInputError,
    Tolerances,
    simulate,
    simulate_event,
    simulate_events,
)
from impactid.rigs.pivoted import kernel as K
from impactid.rigs.pivoted.runs import EventResult, pack_law, pack_rig


def _point_mass_parameters(mass, stiffness, arm=1000.0, contact_radius=0.03):
    """Rig-P parameter vector that behaves as a point mass on a line.

    The follower pivots about P with I = m L^2 at a lever arm L = 1000 m, with no spring, no
    gravity, no eccentricity and no friction. The contact is at alpha ~ 1e-9 rad, where
    sin(alpha) = alpha to 1e-19 and chi = L to 1e-12 relative: the gap is L alpha, the effective
    mass I / chi^2 = m, so the contact is the textbook 1-DOF impact.
    """
    p = pack_rig(SUNDAR2016, mu=0.0).copy()
    p[K.PE_X], p[K.PE_Y], p[K.ECC], p[K.RSUM] = arm, contact_radius, 0.0, contact_radius
    p[K.K_S], p[K.GRAV] = 0.0, 0.0
    p[K.I_B], p[K.K_H] = mass * arm**2, stiffness
    return p


def _run(p, law, a0, ad0, t_end, rtol=1e-12, atol_alpha=1e-15, atol_rate=1e-13):
    contacts = np.empty((8, K.N_CCOL))
    empty = np.empty(0)
    # the argument types of the package's own call (a read-only rig vector, a writable law vector,
    # a run-time overflow_ok): the kernel is compiled once for them, not again for this test
    p, law = p.copy(), law.copy()
    p.setflags(write=False)
    res = K.integrate(0.0, a0, ad0, K.initial_mode(0.0, a0, ad0, p, law, 0.0, 1.0), t_end, p, law, 0.0, 1.0,
                      rtol, atol_alpha, atol_rate, 1e-3, 1_000_000, empty, empty, empty,
                      np.empty(0, np.int8), contacts, np.empty((0, 2)), False, K.NO_SENS, K.NO_SENS_MAX,
                      K.NO_GRID_SENS)
    assert res[0] == K.OK
    return res, contacts[: res[1]]


@pytest.mark.parametrize("zeta", [0.02, 0.1, 0.3])
def test_linear_spring_dashpot_impact_matches_closed_form(zeta):
    """Unclipped Kelvin–Voigt impact: e = exp(-zeta pi / sqrt(1 - zeta^2)), duration pi / omega_d."""
    m, k, v0, L = 1.0, 1e6, 1.0, 1000.0
    c = 2.0 * zeta * math.sqrt(k * m)
    p = _point_mass_parameters(m, k, arm=L)
    law = pack_law(HuntCrossley(beta=c, n=0.0, stiffness_exponent=1.0))
    x0 = 1e-4  # start 0.1 mm away, approaching at v0
    res, contacts = _run(p, law, math.asin(x0 / L), -v0 / L, 0.01)
    assert len(contacts) == 1
    row = contacts[0]
    omega_d = math.sqrt(k / m) * math.sqrt(1.0 - zeta**2)
    expected_e = math.exp(-zeta * math.pi / math.sqrt(1.0 - zeta**2))
    assert row[K.C_DPSI_START] == pytest.approx(-v0, rel=1e-10)
    assert row[K.C_XI] == pytest.approx(expected_e, rel=1e-8)
    assert row[K.C_T_START] == pytest.approx(x0 / v0, rel=1e-9)
    assert row[K.C_T_END] - row[K.C_T_START] == pytest.approx(math.pi / omega_d, rel=1e-8)
    # peak indentation of the damped half-sine
    t_pk = math.atan(math.sqrt(1 - zeta**2) / zeta) / omega_d
    x_pk = v0 / omega_d * math.exp(-zeta * math.sqrt(k / m) * t_pk) * math.sin(omega_d * t_pk)
    assert row[K.C_PEAK_DELTA] == pytest.approx(x_pk, rel=1e-8)


def test_hertz_impact_without_damping_is_elastic():
    """Undamped Hertz impact: separation speed equals approach speed (energy conserved)."""
    p = _point_mass_parameters(0.4, 8e9)
    law = pack_law(HuntCrossley(beta=0.0, n=1.5))
    # angles ~1e-8 rad and rates ~3e-4 rad/s at L = 1000 m: absolute tolerances scaled to match
    _, contacts = _run(p, law, math.asin(1e-5 / 1000.0), -0.3 / 1000.0, 1e-3, atol_alpha=1e-20, atol_rate=1e-16)
    assert contacts[0, K.C_XI] == pytest.approx(1.0, rel=1e-9)
    # Hertz's contact duration for F = k delta^1.5: T = 2 (delta_max / v) int_0^1 (1 - u^2.5)^-1/2 du,
    # delta_max = (5 m v^2 / 4 k)^(2/5), and the integral is B(0.4, 0.5) / 2.5
    m, k, v = 0.4, 8e9, 0.3
    delta_max = (5 * m * v**2 / (4 * k)) ** 0.4
    t_hertz = 2 * delta_max / v * special.beta(0.4, 0.5) / 2.5
    assert contacts[0, K.C_T_END] - contacts[0, K.C_T_START] == pytest.approx(t_hertz, rel=1e-8)
    assert contacts[0, K.C_PEAK_DELTA] == pytest.approx(delta_max, rel=1e-8)


def _free_energy(rig, alpha, alpha_dot):
    """0.5 I a'^2 + integral (F_s d_x - m g l_g cos a) da, in closed form (docs/estimation.md)."""
    ks, dx = rig.k_s, rig.d_x
    potential = ks * dx * ((rig.L_s_u - rig.d_y) * alpha - dx * np.log(np.cos(alpha))
                           + 0.5 * rig.w_b * np.log(1 / np.cos(alpha) + np.tan(alpha)))
    potential -= rig.m_b * rig.g * rig.l_g * np.sin(alpha)
    return 0.5 * rig.I_b * alpha_dot**2 + potential


def test_free_flight_conserves_energy():
    rig = SUNDAR2016
    p = pack_rig(rig).copy()
    p[K.PE_Y] = 1.0  # move the cam out of reach: pure free flight of the real follower dynamics
    law = pack_law(HuntCrossley(24.7e9, 1.5))
    a0, ad0 = 0.12, 0.0
    e0 = _free_energy(rig, a0, ad0)
    scale = abs(_free_energy(rig, a0, ad0) - _free_energy(rig, 0.0147, 0.0))  # energy exchanged in a swing
    for t_end in (0.05, 0.137, 0.4, 1.0):
        res, contacts = _run(p, law, a0, ad0, t_end)
        assert len(contacts) == 0
        drift = abs(_free_energy(rig, res[4], res[5]) - e0) / scale
        assert drift < 1e-10, (t_end, drift)


def test_restitution_reset_follows_the_law():
    rig = SUNDAR2016.with_eccentricity_ratio(0.25)
    law = Restitution(gamma=0.8)
    run = simulate(rig, 15.0, law, 3.0)
    impacts = run.contacts[run.contacts["kind"] == "impact"]
    assert len(impacts) >= 40
    v_a = -impacts["gap_rate_start"].to_numpy()
    xi = impacts["xi"].to_numpy()
    np.testing.assert_allclose(xi, 1.0 - 0.8 * v_a, rtol=0, atol=1e-12)
    sep = impacts["gap_rate_end"].to_numpy()
    big = v_a > 1e-3
    np.testing.assert_allclose(sep[big], xi[big] * v_a[big], rtol=1e-12)
    # alpha is continuous through an impact; only alpha_dot jumps
    np.testing.assert_array_equal(impacts["alpha_start"].to_numpy(), impacts["alpha_end"].to_numpy())
    # the run starts riding the cam (static equilibrium of the rigid contact) and sticks until it leaves
    assert run.contacts["kind"].iloc[0] == "stick"


def test_restitution_out_of_range_is_reported_not_clamped():
    rig = SUNDAR2016.with_eccentricity_ratio(0.25)
    with pytest.raises(SimulationError, match="xi < 0"):
        simulate(rig, 15.0, Restitution(gamma=5.0), 1.0)


def _period1_onset(rig, hz, law):
    """State at a contact onset of a settled period-1 run (for S1 events)."""
    run = simulate(rig, hz, law, 30.0)
    row = run.contacts.iloc[-2]
    theta = 2 * math.pi * hz * row["t_start"]
    return (row["alpha_start"], row["alpha_dot_start"], theta), run.contacts.iloc[-1]["t_start"] - row["t_start"], row


def test_s1_event_reproduces_the_s2_event_it_starts_from(seed_law):
    """An S1 event started at an S2 onset state reproduces that S2 contact and the next onset."""
    rig = SUNDAR2016.with_eccentricity_ratio(0.25)
    (a0, ad0, th0), t_e, row = _period1_onset(rig, 15.0, seed_law)
    ev = simulate_event(rig, 15.0, seed_law, a0, ad0, th0, t_e * 0.999, t_eval=np.linspace(0, 4e-4, 82))
    assert ev.contact_duration == pytest.approx(row["duration"], rel=1e-7)
    assert ev.peak_force == pytest.approx(row["peak_force"], rel=1e-7)
    assert ev.n_contacts == 1
    assert ev.alpha_m > a0
    assert ev.contact_force.max() <= ev.peak_force * (1 + 1e-12)
    assert ev.contact_force.max() > 0.95 * ev.peak_force  # the grid (5 us) samples near the peak
    assert np.all(ev.indentation[ev.t > ev.contact_duration + 1e-6] == 0)


def test_event_result_has_every_field_and_behaves_as_a_frozen_dataclass(seed_law):
    """simulate_event builds its record without the dataclass's __init__ (runs._frozen_record)."""
    rig = SUNDAR2016.with_eccentricity_ratio(0.25)
    (a0, ad0, th0), t_e, _ = _period1_onset(rig, 15.0, seed_law)
    ev = simulate_event(rig, 15.0, seed_law, a0, ad0, th0, t_e)
    assert set(vars(ev)) == {f.name for f in dataclasses.fields(EventResult)}
    assert ev == dataclasses.replace(ev)  # the same record through __init__ (the arrays compare by identity)
    with pytest.raises(dataclasses.FrozenInstanceError):
        ev.alpha_m = 0.0
    assert ev.contacts["t_start"].iloc[0] == ev.contact_table[0, K.C_T_START]
    assert pickle.loads(pickle.dumps(ev)).alpha_m == ev.alpha_m


def test_batch_equals_single_events(seed_law):
    rig = SUNDAR2016.with_eccentricity_ratio(0.25)
    (a0, ad0, th0), t_e, _ = _period1_onset(rig, 15.0, seed_law)
    states = np.array([[a0, ad0, th0], [a0, ad0 * 1.05, th0], [a0, ad0 * 0.9, th0 + 0.01]])
    t_end = np.full(3, t_e)
    trials = np.array([[24.7e9, 1.5], [12e9, 1.5], [1500.0, 0.0], [5e11, 2.0]])
    grids = [np.linspace(0, 3e-4, 61)] * 3
    batch = simulate_events(rig, 15.0, states, t_end, trials, grids=grids)
    for i, (beta, n) in enumerate(trials):
        for j, (a, ad, th) in enumerate(states):
            ev = simulate_event(rig, 15.0, HuntCrossley(beta, n), a, ad, th, t_e, t_eval=grids[j])
            assert batch.alpha_m[i, j] == ev.alpha_m
            assert batch.peak_force[i, j] == ev.peak_force
            assert batch.contact_duration[i, j] == ev.contact_duration
            sl = slice(batch.grid_offsets[j], batch.grid_offsets[j + 1])
            np.testing.assert_array_equal(batch.contact_force[i, sl], ev.contact_force)
    # more damping, lower rebound: alpha_m falls with beta at fixed n
    assert batch.alpha_m[0, 0] < batch.alpha_m[1, 0]


@pytest.mark.parametrize(
    ("call", "error", "message"),
    [
        (lambda: simulate(SUNDAR2016, 0.0, HuntCrossley(24.7e9), 1.0), SimulationInputError,
         "cam speed must be positive"),
        (lambda: simulate(SUNDAR2016, float("nan"), HuntCrossley(24.7e9), 1.0), SimulationInputError, "finite"),
        (lambda: simulate(SUNDAR2016, 16.0, HuntCrossley(24.7e9), 1.0, initial_state=(float("nan"), 0.0)),
         SimulationInputError, "initial alpha must be finite"),
        (lambda: simulate_event(SUNDAR2016, 16.0, HuntCrossley(24.7e9), 0.04, float("inf"), 0.0, 0.06),
         SimulationInputError, "alpha_dot0 must be finite"),
        (lambda: simulate(SUNDAR2016.replace(k_s=-3319.0), 16.0, HuntCrossley(24.7e9), 1.0),
         RigParameterError, "'k_s' must be positive"),
        (lambda: SUNDAR2016.with_eccentricity_ratio(1.0), RigParameterError, "smaller than the cam radius"),
        (lambda: simulate(SUNDAR2016, 16.0, HuntCrossley(24.7e9), -1.0), SimulationInputError, "duration"),
        (lambda: simulate_events(SUNDAR2016, 16.0, [[0.04, 0.0, 0.0]], [0.06], [[1e9, -1.0]]),
         SimulationInputError, "trial beta and n"),
        (lambda: simulate(SUNDAR2016, 16.0, HuntCrossley(24.7e9), 1.0, mu=-0.2), SimulationInputError, "mu"),
    ],
)
def test_non_physical_inputs_raise_clear_errors(call, error, message):
    with pytest.raises(error, match=message):
        call()


def test_packing_is_remembered_per_object_and_agrees_with_equal_objects():
    """pack_rig and pack_law answer a repeated rig or law from an identity check (runs._last_rig)."""
    rig = SUNDAR2016.with_eccentricity_ratio(0.25)
    p = pack_rig(rig)
    assert pack_rig(rig) is p
    assert np.array_equal(pack_rig(SUNDAR2016.with_eccentricity_ratio(0.25)), p)  # an equal rig: same vector
    assert pack_rig(rig, mu=0.3)[K.MU] == 0.3 and pack_rig(rig)[K.MU] == rig.mu
    assert pack_rig(SUNDAR2016)[K.ECC] == SUNDAR2016.e and pack_rig(rig) is p
    law = HuntCrossley(24.7e9, 1.5)
    assert pack_law(law) is pack_law(law)
    assert pack_law(HuntCrossley(1e9, 1.0))[K.BETA] == 1e9 and pack_law(law)[K.BETA] == 24.7e9
    with pytest.raises(SimulationInputError, match="expected a .* rig"):
        pack_rig(object())


def test_event_inputs_that_convert_to_numbers_are_accepted(seed_law):
    """simulate_event's fast finiteness check falls back to the converting one (runs._finite)."""
    rig = SUNDAR2016.with_eccentricity_ratio(0.25)
    (a0, ad0, th0), t_e, _ = _period1_onset(rig, 15.0, seed_law)
    ev = simulate_event(rig, 15.0, seed_law, a0, ad0, th0, t_e)
    assert simulate_event(rig, 15.0, seed_law, str(a0), ad0, np.float64(th0), t_e).alpha_m == ev.alpha_m


def test_solver_failure_raises():
    with pytest.raises(SimulationError, match="maximum number of integration steps"):
        simulate(SUNDAR2016, 16.0, HuntCrossley(24.7e9), 1.0, tolerances=Tolerances(max_steps=50))
    with pytest.raises(SimulationError, match="S1 batch: event 0"):
        simulate_events(SUNDAR2016, 16.0, [[0.04, -3.0, 0.0]], [0.06], [[24.7e9, 1.5]],
                        tolerances=Tolerances(max_steps=20))

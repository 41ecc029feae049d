"""Forward sensitivities of rig P's S1 runs (kernel.rhs_partials, kernel._sensitivity_step) against
central differences: of the right-hand side, of ``alpha_m`` and of the force and gap histories, and of
the residuals built from them (EventSet.residuals_and_jacobian)."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from impactid import SUNDAR2016, HuntCrossley
from impactid.rigs.pivoted import kernel as K
from impactid.rigs.pivoted.reconstruct import reconstruct
from impactid.rigs.pivoted.residuals import EventSet
from impactid.rigs.pivoted.runs import Tolerances, pack_law, pack_rig, simulate_events

#: Tight tolerances for the difference quotients: with rtol 1e-12 and a step of 1e-5 in ln beta and
#: n, a central difference carries about 1e-12 / 1e-5 = 1e-7 (relative) of round-off and integration
#: error and 1e-10 of truncation; the sensitivities are integrated on the same steps as the state.
TIGHT = Tolerances(rtol=1e-12, atol_alpha=1e-15, atol_rate=1e-13)
STEP = 1e-5


@pytest.mark.parametrize("law", [HuntCrossley(24.7e9, 1.5), HuntCrossley(3e11, 2.0), HuntCrossley(5e10, 1.2, clip=True),
                                 HuntCrossley(2e8, 1.0)])
@pytest.mark.parametrize("mu", [0.0, 0.2])
def test_partials_of_the_right_hand_side_are_its_derivatives(law, mu):
    """Every entry of rhs_partials against a central difference of the kernel's acceleration and force."""
    rig = SUNDAR2016.with_eccentricity_ratio(0.15)
    p = pack_rig(rig, mu)
    omega = 2 * math.pi * 17
    rng = np.random.default_rng(11)
    checked = 0
    for _ in range(200):
        t = rng.uniform(0, 0.05)
        th_ref = rng.uniform(0, 2 * math.pi)
        a = rig.contact_angle(th_ref + omega * t) - rng.uniform(1e-7, 4e-5) / 0.09
        ad = rng.uniform(-6, 6)
        for mode in (K.FREE, K.CONTACT):
            lv = pack_law(law)
            got = K.rhs_partials(mode, t, a, ad, p, lv, th_ref, omega)

            def f(a_, ad_, lnb=0.0, dn=0.0, lv=lv, mode=mode, t=t, th_ref=th_ref):
                lv_ = lv.copy()
                lv_[K.BETA] *= math.exp(lnb)
                lv_[K.N_EXP] += dn
                return (K.acceleration(mode, t, a_, ad_, p, lv_, th_ref, omega),
                        K.contact_force(mode, t, a_, ad_, p, lv_, th_ref, omega))

            ha, hd, hp = 1e-9, 1e-6, 1e-6
            diffs = [(np.subtract(f(a + ha, ad), f(a - ha, ad))) / (2 * ha),
                     (np.subtract(f(a, ad + hd), f(a, ad - hd))) / (2 * hd),
                     (np.subtract(f(a, ad, lnb=hp), f(a, ad, lnb=-hp))) / (2 * hp),
                     (np.subtract(f(a, ad, dn=hp), f(a, ad, dn=-hp))) / (2 * hp)]
            base_acc, base_force = f(a, ad)
            if mode == K.CONTACT and law.clip and base_force <= 1e-3:
                continue  # at the clip the force has a kink: differences straddle it
            for k, (acc_d, force_d) in enumerate(diffs):
                # the difference's own error: truncation (relative ~h^2) and the round-off of the values
                # (1e-15 of terms up to ~1e6, over the step h)
                h = (ha, hd, hp, hp)[k]
                assert got[k] == pytest.approx(acc_d, rel=1e-4, abs=1e-15 * (1e6 + abs(base_acc)) / h), (mode, k)
                force_tol = 1e-15 * (1e4 + abs(base_force)) / h
                assert got[4 + k] == pytest.approx(force_d, rel=1e-4, abs=force_tol), (mode, k)
            checked += 1
    assert checked > 200


@pytest.fixture(scope="module")
def events(s2_synthetic):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        es = EventSet.from_reconstruction(reconstruct(s2_synthetic.recording, anchor="cam-phase"))
    return es.subset(slice(0, 4))


def _differences(es, beta, n, grids):
    trials = [[beta * math.exp(STEP), n], [beta * math.exp(-STEP), n], [beta, n + STEP], [beta, n - STEP]]
    f = simulate_events(es.rig, es.cam_speed_hz, es.states, es.t_end, trials, tolerances=TIGHT, grids=grids)
    alpha_m = np.stack([f.alpha_m[0] - f.alpha_m[1], f.alpha_m[2] - f.alpha_m[3]], axis=1) / (2 * STEP)
    force = np.stack([f.contact_force[0] - f.contact_force[1], f.contact_force[2] - f.contact_force[3]]) / (2 * STEP)
    gap = np.stack([f.gap[0] - f.gap[1], f.gap[2] - f.gap[3]]) / (2 * STEP)
    return alpha_m, force, gap


@pytest.mark.parametrize("beta, n", [(24.7e9, 1.5), (5e9, 1.3), (1e11, 1.8), (2e8, 1.0)])
def test_sensitivities_of_alpha_m_and_the_histories_match_central_differences(events, beta, n):
    """Measured (rig with friction mu 0.2): alpha_m within 2.4e-7 of the largest derivative (1.5e-6 at
    n = 1), force and gap histories within 2e-7 (force by n at n = 1: 9e-5, at the samples next to
    the switches, where the force has a kink that the differences straddle)."""
    grids = list(events.t)
    run = simulate_events(events.rig, events.cam_speed_hz, events.states, events.t_end, [[beta, n]],
                          tolerances=TIGHT, grids=grids, sensitivities=True)
    alpha_m, force, gap = _differences(events, beta, n, grids)
    scale = np.max(np.abs(alpha_m), axis=0)
    assert np.all(scale > 0)
    assert np.max(np.abs(run.alpha_m_sensitivity[0] - alpha_m), axis=0) / scale == pytest.approx(0, abs=1e-5)
    for got, want, tol in ((run.contact_force_sensitivity[0], force, 5e-4), (run.gap_sensitivity[0], gap, 1e-5)):
        assert np.max(np.abs(got - want), axis=1) / np.max(np.abs(want), axis=1) == pytest.approx(0, abs=tol)


def test_sensitivities_leave_the_state_untouched(events):
    """Partial error control: the steps, and so every result, are those of a run without them."""
    trials = np.array([[24.7e9, 1.5], [3e10, 1.4]])
    grids = list(events.t)
    plain = simulate_events(events.rig, events.cam_speed_hz, events.states, events.t_end, trials, grids=grids)
    with_sens = simulate_events(events.rig, events.cam_speed_hz, events.states, events.t_end, trials, grids=grids,
                                sensitivities=True)
    for name in ("alpha_m", "t_alpha_m", "contact_start", "contact_end", "peak_force", "n_steps", "contact_force",
                 "gap"):
        np.testing.assert_array_equal(getattr(with_sens, name), getattr(plain, name), err_msg=name)
    assert plain.alpha_m_sensitivity is None and with_sens.alpha_m_sensitivity.shape == (2, len(events), 2)


@pytest.mark.parametrize("residual", ["lambda1", "lambda2", "lambda3"])
def test_residual_jacobian_matches_central_differences_of_the_residuals(events, residual):
    trial = np.array([[20e9, 1.45]])
    r, jac, failed = events.residuals_and_jacobian(trial, residual)
    assert not failed.any()
    np.testing.assert_array_equal(r, events.residuals(trial, residual))
    h = 1e-4
    for k, (db, dn) in enumerate(((math.exp(h), 0.0), (1.0, h))):
        up = events.residuals(np.array([[trial[0, 0] * db, trial[0, 1] + dn]]), residual)[0]
        down = events.residuals(np.array([[trial[0, 0] / db, trial[0, 1] - dn]]), residual)[0]
        want = (up - down) / (2 * h)
        # differences at the default tolerance (rtol 1e-10): error ~1e-10 / 1e-4 of the residual's scale
        assert jac[0, :, k] == pytest.approx(want, rel=1e-3, abs=1e-5 * np.max(np.abs(want)))


def test_a_friction_reversal_in_a_contact_leaves_the_run_without_sensitivities():
    """A slow cam (0.5 Hz) hit at 5 rad/s: the sliding velocity reverses during the contact, the
    friction force jumps there, and the kernel (which does not locate that instant) gives NaN
    sensitivities rather than ones missing the jump; the run's own results stay."""
    from impactid import simulate_event

    rig, law = SUNDAR2016.with_eccentricity_ratio(0.2), HuntCrossley(24.7e9, 1.5)
    th0 = 4.5
    a0, ad0 = rig.contact_angle(th0) + 1e-6, -5.0
    assert simulate_event(rig, 0.5, law, a0, ad0, th0, 0.01).contacts["friction_reversals"].sum() >= 1
    run = simulate_events(rig, 0.5, [[a0, ad0, th0]], [0.01], [[law.beta, law.n]], sensitivities=True)
    assert np.isnan(run.alpha_m_sensitivity).all()
    assert np.isfinite(run.alpha_m).all()
    frictionless = simulate_events(rig, 0.5, [[a0, ad0, th0]], [0.01], [[law.beta, law.n]], sensitivities=True, mu=0.0)
    assert np.isfinite(frictionless.alpha_m_sensitivity).all()

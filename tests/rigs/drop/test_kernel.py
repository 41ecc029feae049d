"""The compiled drop kernel against the independent ``solve_ivp`` reference (``reference_drop.py``), and
its forward sensitivities against central differences of the kernel itself."""

from __future__ import annotations

import math

import numpy as np
import pytest

from impactid.rigs.drop import STEEL_ON_PA6, DropLaw
from impactid.rigs.drop import kernel as K
from impactid.rigs.drop.simulate import Tolerances, pack, replay_impacts, simulate_drop
from tests.rigs.drop import reference_drop as R

#: The kernel at a tolerance like the reference's (rtol 1e-12), for the comparisons.
TIGHT = Tolerances(rtol=1e-12, atol_x=1e-15, atol_v=1e-11)
#: Contact laws of the sweep: (label, p, k, beta, n). The preset's Hertz contact with Hunt and
#: Crossley's n = p, separations by force (n < p) and at the surface (n >= p), viscous damping (the
#: force jumps at the onset), a linear spring.
K_H = STEEL_ON_PA6.k
LAWS = [
    ("hunt-crossley n=p", 1.5, K_H, 0.3 * K_H, 1.5),
    ("n=1", 1.5, K_H, 3e6, 1.0),
    ("n=0.5", 1.5, K_H, 3.5e5, 0.5),
    ("n=2.5", 1.5, K_H, 2e11, 2.5),
    ("viscous n=0", 1.5, K_H, 30.0, 0.0),
    ("linear p=1", 1.0, 2e6, 1e4, 1.0),
]
HEIGHTS = (0.01, 0.2, 1.0)
#: Agreement required. Measured over the sweep (41 impacts, docs/drop.md): times 6.8e-11 s, speeds
#: 3.7e-10 m/s, peaks 8.3e-9, positions 1.1e-10 m (drops of up to 1 m), forces 1.1e-7 of the peak.
TIME_TOL = 2e-9  # s, onset and separation times
SPEED_TOL = 5e-9  # m/s, approach and separation speeds
PEAK_REL_TOL = 1e-7  # peak force and largest penetration, relative
STATE_TOL = 1e-9  # m, positions on the output grid
FORCE_REL_TOL = 2e-6  # forces on the output grid, relative to the largest peak


def _case(p, k, beta, n, height):
    rig = STEEL_ON_PA6.replace(p=p, k=k)
    law = DropLaw(beta, n)
    fall = math.sqrt(2.0 * height / rig.gravity)
    t_end = fall + 0.3
    t_eval = np.linspace(0.0, t_end, 4001)
    run = simulate_drop(rig, law, height, duration=t_end, t_eval=t_eval, tol=TIGHT)
    ref = R.simulate(rig.mass, rig.gravity, rig.k, rig.p, beta, n, -height, 0.0, t_end, t_eval=t_eval)
    return run, ref


def _compare(run, ref):
    table = run.impacts
    ref_done = [imp for imp in ref["impacts"] if "t_end" in imp]
    done = table[table["end"].isin(["force", "surface"])]
    assert len(done) == len(ref_done) >= 1
    assert list(done["kind"]) == [imp.get("kind", "onset") for imp in ref_done]
    worst = {"time": 0.0, "speed": 0.0, "peak": 0.0}
    for (_, row), imp in zip(done.iterrows(), ref_done):
        worst["time"] = max(worst["time"], abs(row.onset_time_s - imp["t_onset"]), abs(row.separation_time_s
                                                                                        - imp["t_end"]))
        worst["speed"] = max(worst["speed"], abs(row.separation_speed_m_s + imp["v_end"]),
                             abs(row.approach_speed_m_s - imp["v_onset"]))
        worst["peak"] = max(worst["peak"], abs(row.peak_force_n / imp["peak_force"] - 1.0),
                            abs(row.max_penetration_m / imp["max_penetration"] - 1.0))
        assert row.end == imp["end"]
    worst["x"] = float(np.max(np.abs(run.x - ref["x"])))
    worst["force"] = float(np.max(np.abs(run.force - ref["force"])) / table["peak_force_n"].max())
    return worst


def _check(worst):
    assert worst["time"] < TIME_TOL
    assert worst["speed"] < SPEED_TOL
    assert worst["peak"] < PEAK_REL_TOL
    assert worst["x"] < STATE_TOL
    assert worst["force"] < FORCE_REL_TOL


@pytest.mark.parametrize("law", LAWS[:2] + LAWS[4:5], ids=lambda c: c[0])
def test_kernel_matches_reference(law):
    _, p, k, beta, n = law
    _check(_compare(*_case(p, k, beta, n, 0.05)))


@pytest.mark.slow
@pytest.mark.parametrize("height", HEIGHTS)
@pytest.mark.parametrize("law", LAWS, ids=lambda c: c[0])
def test_kernel_matches_reference_sweep(law, height):
    _, p, k, beta, n = law
    _check(_compare(*_case(p, k, beta, n, height)))


def test_comparison_can_fail():
    # the same comparison against a reference run with another damping finds the difference
    rig = STEEL_ON_PA6
    run, _ = _case(1.5, K_H, 0.3 * K_H, 1.5, 0.05)
    other = R.simulate(rig.mass, rig.gravity, rig.k, rig.p, 0.3 * K_H * 1.001, 1.5, -0.05, 0.0, run.t[-1],
                       t_eval=run.t)
    with pytest.raises(AssertionError):
        _check(_compare(run, other))


def test_free_flight_is_exact():
    rig = STEEL_ON_PA6
    law = DropLaw(0.3 * K_H, 1.5)
    t = np.linspace(0.0, 0.09, 50)
    run = simulate_drop(rig, law, 0.05, duration=0.09, t_eval=t)
    np.testing.assert_allclose(run.x, -0.05 + 0.5 * rig.gravity * t**2, rtol=0, atol=1e-17)
    np.testing.assert_allclose(run.v, rig.gravity * t, rtol=0, atol=1e-15)
    assert np.all(run.force == 0.0) and run.impacts.empty


def test_onset_time_and_speed_are_the_free_falls():
    rig = STEEL_ON_PA6
    run = simulate_drop(rig, DropLaw(0.3 * K_H, 1.5), 0.05, release_speed=0.2, duration=0.2)
    first = run.impacts.iloc[0]
    v = math.sqrt(0.2**2 + 2 * rig.gravity * 0.05)
    assert first.approach_speed_m_s == pytest.approx(v, rel=1e-14)
    assert first.onset_time_s == pytest.approx((v - 0.2) / rig.gravity, rel=1e-13)


def test_undamped_impact_is_hertz():
    # no damping, no gravity: Hertz's closed forms (T = 2.9432 delta_max / v, elastic rebound)
    from impactid.rigs.drop.parameters import hertz_contact_time, hertz_max_penetration

    rig = STEEL_ON_PA6.replace(gravity=0.0)
    run = simulate_drop(rig, DropLaw(0.0, 1.5), 0.0, release_speed=1.0, duration=0.01, tol=TIGHT)
    row = run.impacts.iloc[0]
    assert row.contact_duration_s == pytest.approx(hertz_contact_time(1.0, rig.k, 1.5, 1.0), rel=1e-10)
    assert row.max_penetration_m == pytest.approx(hertz_max_penetration(1.0, rig.k, 1.5, 1.0), rel=1e-10)
    assert row.separation_speed_m_s == pytest.approx(1.0, rel=1e-9)  # DP5 conserves energy to ~1e-10 here
    assert len(run.impacts) == 1  # no gravity: it never comes back


def test_drop_comes_to_rest():
    rig = STEEL_ON_PA6
    run = simulate_drop(rig, DropLaw(0.3 * K_H, 1.5), 0.01)
    assert math.isfinite(run.t_rest) and run.t_end == run.t_rest
    assert run.impacts["end"].iloc[-1] == "rest"
    assert (run.impacts["end"].iloc[:-1] != "rest").all()
    # restitution rises as the impacts slow down (Hunt and Crossley: e ~ 1 - (2/3)(beta/k) v)
    e = run.separated["restitution"].to_numpy()
    assert np.all(np.diff(e[:20]) > 0.0)


# ---- forward sensitivities -----------------------------------------------------------------------

SENS_TOL = Tolerances(rtol=1e-12, atol_x=1e-17, atol_v=1e-13)


def _forces(rig, law, speeds, times):
    return replay_impacts(rig, law, speeds, times, derivatives=False, tol=SENS_TOL).force


@pytest.mark.parametrize(("beta", "n"), [(0.3 * K_H, 1.5), (3e6, 1.0), (2e11, 2.5), (3.5e5, 0.7)])
def test_sensitivities_match_central_differences(beta, n):
    rig = STEEL_ON_PA6
    law = DropLaw(beta, n)
    speeds = np.array([0.99, 0.4])
    times = [np.arange(-3, 80) / 51_200.0, np.arange(-3, 100) / 51_200.0]
    rep = replay_impacts(rig, law, speeds, times, tol=SENS_TOL)
    eps = 1e-5
    fd = np.column_stack([
        (_forces(rig.replace(k=rig.k * math.exp(eps)), law, speeds, times)
         - _forces(rig.replace(k=rig.k * math.exp(-eps)), law, speeds, times)) / (2 * eps),
        (_forces(rig, DropLaw(beta * math.exp(eps), n), speeds, times)
         - _forces(rig, DropLaw(beta * math.exp(-eps), n), speeds, times)) / (2 * eps),
        (_forces(rig, DropLaw(beta, n + eps), speeds, times) - _forces(rig, DropLaw(beta, n - eps), speeds, times))
        / (2 * eps),
        (_forces(rig, law, speeds + 1e-6, times) - _forces(rig, law, speeds - 1e-6, times)) / 2e-6,
    ])
    error = np.max(np.abs(rep.force_derivatives - fd), axis=0) / np.max(np.abs(fd), axis=0)
    assert np.all(error < 1e-6), error
    # the force rate (the onset-time derivative) against differences in time, off the onset's kink
    dt = 1e-9
    rate = (_forces(rig, law, speeds, [t + dt for t in times]) - _forces(rig, law, speeds, [t - dt for t in times])) / (
        2 * dt)
    off_kink = np.abs(rep.tau) > 2 * dt
    assert np.max(np.abs(rep.force_rate - rate)[off_kink]) < 1e-5 * np.max(np.abs(rate))


@pytest.mark.parametrize(("beta", "n", "tolerance"), [(0.3 * K_H, 1.5, 5e-6), (3e6, 1.0, 5e-6), (30.0, 0.0, 5e-5)])
def test_sensitivities_through_flights(beta, n, tolerance):
    # d(force)/d(ln k, ln beta, n) on a grid through three impacts of a drop: the onsets after the first
    # depend on the parameters (and, for viscous damping, the force jumps there: the saltation). The
    # differences use a small step: an onset moves by dt0/dn * eps (0.6 s per unit n), and a sample a
    # few microseconds after it sees the t^1.5 rise of the force, not its derivative, for eps >~ 1e-6.
    rig = STEEL_ON_PA6
    par = pack(rig, DropLaw(beta, n))
    grid = np.linspace(0.095, 0.42, 20_000)

    def run(params, sens=True):
        g_out = np.empty((grid.size, K.N_GCOL))
        s = np.zeros((K.N_SENS, 2)) if sens else np.zeros((0, 2))
        g_sens = np.zeros((grid.size, K.N_SENS, 3)) if sens else np.zeros((0, K.N_SENS, 3))
        res = K.integrate(0.0, -0.05, 0.0, grid[-1], params, 1e-12, 1e-17, 1e-13, 1e-3, 10**6, False, grid, g_out,
                          np.empty((16, K.N_ICOL)), s, g_sens)
        assert res.status == K.OK and res.n_impacts >= 2
        return g_out[:, K.G_FORCE], g_sens[:, :, 2]

    _, dF = run(par)
    eps = 1e-8
    # (n = 0: d/dn of x^n is ln x, singular at every onset; the fit searches n in [0.5, 3])
    columns = ((K.P_K, True), (K.P_BETA, True)) + (((K.P_N, False),) if n > 0.0 else ())
    for q, (index, log) in enumerate(columns):
        up, down = par.copy(), par.copy()
        if log:
            up[index] *= math.exp(eps)
            down[index] *= math.exp(-eps)
        else:
            up[index] += eps
            down[index] -= eps
        fd = (run(up, False)[0] - run(down, False)[0]) / (2 * eps)
        assert np.max(np.abs(fd - dF[:, q])) < tolerance * np.max(np.abs(fd))


def test_drop_sensitivities_through_the_api():
    # simulate_drop(sensitivities=True): dF/d(release speed) against central differences, through two impacts
    rig = STEEL_ON_PA6
    law = DropLaw(0.3 * K_H, 1.5)
    t = np.linspace(0.1, 0.28, 5000)
    run = simulate_drop(rig, law, 0.05, release_speed=0.1, duration=0.3, t_eval=t, sensitivities=True, tol=SENS_TOL)
    eps = 1e-8
    up = simulate_drop(rig, law, 0.05, release_speed=0.1 + eps, duration=0.3, t_eval=t, tol=SENS_TOL).force
    down = simulate_drop(rig, law, 0.05, release_speed=0.1 - eps, duration=0.3, t_eval=t, tol=SENS_TOL).force
    fd = (up - down) / (2 * eps)
    assert run.force_derivatives.shape == (t.size, 4)
    assert np.max(np.abs(run.force_derivatives[:, 3] - fd)) < 5e-6 * np.max(np.abs(fd))
    assert simulate_drop(rig, law, 0.05, duration=0.3, t_eval=t).force_derivatives is None


def test_partials_match_differences():
    par = pack(STEEL_ON_PA6, DropLaw(3e6, 1.2))
    x, v = 2e-4, 0.4
    f_x, f_v, f_lnk, f_lnb, f_n = K.force_partials(x, v, par)

    def force(xx, vv, p=par):
        return K.contact_force(np.array([xx]), np.array([vv]), p)[0]

    h = 1e-10
    assert f_x == pytest.approx((force(x + h, v) - force(x - h, v)) / (2 * h), rel=1e-6)
    assert f_v == pytest.approx((force(x, v + 1e-7) - force(x, v - 1e-7)) / 2e-7, rel=1e-6)
    up, down = par.copy(), par.copy()
    up[K.P_N] += 1e-7
    down[K.P_N] -= 1e-7
    assert f_n == pytest.approx((force(x, v, up) - force(x, v, down)) / 2e-7, rel=1e-6)
    assert f_lnk + f_lnb == pytest.approx(force(x, v), rel=1e-12)

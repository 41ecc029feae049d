"""The compiled rig F simulator against the independent solve_ivp reference, and its behaviour.

Tolerances: the reference (DOP853, rtol 1e-12, atol 1e-14) reproduces itself at rtol 1e-13 to
about 1e-10 s in impact times and 1e-9 rad/s in rates (tests/rigs/flat/reference_flat.py); the
compiled kernel runs at rtol 1e-10. Impact times must agree to 1e-9 s, rates to 1e-7 rad/s
(relative to rates of ~1 rad/s) and states on an output grid to 1e-9 rad.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from impactid.errors import SimulationInputError
from impactid.rigs.flat import ALZATE2007 as RIG
from impactid.rigs.flat.simulate import SpeedRestitution, bifurcation, simulate_flat
from tests.rigs.flat import reference_flat as ref

TIME_TOL = 1e-9  # [s]
RATE_TOL = 1e-7  # [rad/s]


def _compare(rpm, r, revolutions, theta_c0=0.0, initial=None, n_events=None):
    omega = rpm * 2.0 * math.pi / 60.0
    t_end = revolutions * 60.0 / rpm
    kwargs = {} if initial is None else {"theta_f0": initial[0], "theta_f_dot0": initial[1]}
    reference = ref.run_flat_reference(RIG, omega, r, t_end, theta_c0=theta_c0, **kwargs)
    times = np.linspace(0.0, t_end, 997)
    ours = simulate_flat(RIG, rpm / 60.0, t_end, restitution=r, times=times, theta_c0=theta_c0, initial=initial)
    ref_table = reference.events_table()
    n = len(ref_table) if n_events is None else n_events
    assert len(ours.events) >= n and len(ref_table) >= n
    mine = ours.events.iloc[:n]
    theirs = ref_table.iloc[:n]
    assert list(mine["kind"]) == list(theirs["kind"])
    np.testing.assert_allclose(mine["t"].to_numpy(), theirs["time"].to_numpy(), rtol=0, atol=TIME_TOL)
    np.testing.assert_allclose(mine["rate_before"].to_numpy(), theirs["rate_before"].to_numpy(), rtol=0,
                               atol=RATE_TOL)
    np.testing.assert_allclose(mine["rate_after"].to_numpy(), theirs["rate_after"].to_numpy(), rtol=0,
                               atol=RATE_TOL)
    ref_states = np.array([np.ravel(reference.state(t)[0])[0] for t in times])
    np.testing.assert_allclose(ours.theta_f, ref_states, rtol=0, atol=1e-9)
    return ours, reference


def test_period1_chattering_run_matches_reference():
    """130 rpm, r = 0.8: release, 51 impacts accumulating into sticking, every revolution."""
    ours, reference = _compare(130.0, 0.8, 5)
    kinds = list(ours.events["kind"])
    assert kinds.count("release") == 5 and kinds.count("stick") == 5
    assert kinds.count("impact") == len(reference.impacts)


@pytest.mark.parametrize("rpm, r", [(140.0, 0.6), (150.0, 0.57), (128.0, 0.3)])
def test_impacting_runs_match_reference(rpm, r):
    _compare(rpm, r, 4)


def test_free_start_matches_reference():
    """From a free state above the cam, at a cam angle other than 0."""
    _compare(130.0, 0.8, 1.2, theta_c0=1.0, initial=(0.45, 0.5))


def test_speed_law_matches_constant():
    law = SpeedRestitution.from_rpm(0.65 + 130 * 0.004, -0.004)
    assert law(140.0 / 60.0) == pytest.approx(0.61, abs=1e-12)
    a = simulate_flat(RIG, 140.0 / 60.0, 2.0, restitution=law)
    b = simulate_flat(RIG, 140.0 / 60.0, 2.0, restitution=0.61)
    np.testing.assert_allclose(a.theta_f, b.theta_f, rtol=0, atol=1e-12)


def test_below_detachment_follower_rides_the_cam():
    run = simulate_flat(RIG, 110.0 / 60.0, 3.0, restitution=0.8)
    assert run.events.empty and run.riding.all()
    np.testing.assert_allclose(run.theta_f, RIG.contact_angle(run.cam_angle), rtol=0, atol=1e-15)


def test_chattering_accumulates_into_sticking_without_stalling():
    """r = 0.88 at 130 rpm: every revolution ends its bounces in a Zeno sequence (~85 impacts whose
    bounces shrink geometrically); each is accumulated into sticking, so 50 revolutions take a few
    thousand steps, not an unbounded number."""
    run = simulate_flat(RIG, 130.0 / 60.0, 50 * 60.0 / 130.0, restitution=0.88)
    kinds = run.events["kind"]
    sticks = run.events.index[kinds == "stick"]
    assert len(sticks) >= 45
    # the impact that ends a sequence separates slower than the chatter threshold
    ending = run.events.loc[sticks - 1]
    assert (ending["kind"] == "impact").all() and (ending["gap_rate_after"] < 1e-6).all()
    assert (kinds == "impact").sum() / len(sticks) > 60
    assert run.steps < 20_000
    assert RIG.gap(run.theta_f, run.cam_angle).min() > -1e-12  # no penetration on the output grid


def test_stroboscopic_sweep_regimes():
    result = bifurcation(RIG, np.array([110.0, 130.0, 140.0]) / 60.0, 0.6, revolutions=60, strobe_phase=0.0)
    regimes = list(result.table["regime"])
    assert regimes[0] == "contact"
    assert regimes[1] == "period-1" and regimes[2] == "period-1"
    # stroboscopic samples equal the long single run's state at theta_c = 2 pi k
    run = simulate_flat(RIG, 130.0 / 60.0, 60 * 60.0 / 130.0, restitution=0.6,
                        times=np.arange(31, 61) * 60.0 / 130.0)
    np.testing.assert_allclose(result.strobe_angle[1], run.theta_f, rtol=0, atol=1e-12)


@pytest.mark.parametrize("kwargs, match", [
    ({"cam_speed_hz": 0.0}, "cam speed"),
    ({"cam_speed_hz": float("nan")}, "cam speed"),
    ({"restitution": 1.2}, "restitution"),
    ({"initial": (0.0, 0.0)}, "inside the cam"),
    ({"duration": -1.0}, "duration"),
])
def test_bad_input(kwargs, match):
    args = {"cam_speed_hz": 2.0, "duration": 1.0} | kwargs
    rig_args = {k: args.pop(k) for k in ("cam_speed_hz", "duration")}
    with pytest.raises(SimulationInputError, match=match):
        simulate_flat(RIG, rig_args["cam_speed_hz"], rig_args["duration"], **args)


def test_speed_law_outside_unit_interval_is_rejected():
    law = SpeedRestitution.from_rpm(1.5, -0.001)
    with pytest.raises(SimulationInputError, match="outside"):
        law(60.0 / 60.0)

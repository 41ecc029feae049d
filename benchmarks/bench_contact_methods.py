"""Where an S1 event's time goes, and what other integration methods would need for it (issue 27).

Run: ``python benchmarks/bench_contact_methods.py [--page docs/performance_contact_methods.md]``.

The S1 target (at least 1000x the best equally accurate ``solve_ivp``, ``bench_simulator.py``) asks
for an event in about 14 us. This benchmark measures, on the event of ``bench_simulator.py``, whether
a change of method could reach that:

1. the compiled kernel's time and steps in the 0.33 ms contact and in the 62 ms of free flight
   (integrations stopped at the contact's end), and the whole event through ``simulate_event``;
2. right-hand-side evaluations that ``solve_ivp`` needs for the contact and for the free flight, on
   the independent reference model, at the kernel's default tolerance (rtol 1e-10, atol 1e-13):
   Dormand-Prince 5(4) (RK45, the kernel's method) and the 8th-order DOP853, each in time and in a
   Sundman variable ``s`` with ``dt/ds = sqrt(delta + delta0)`` that removes the contact's
   ``delta^1.5`` kink at its onset and end (``alpha(s)`` is smooth where ``alpha(t)`` has a
   ``t^3.5`` term); errors of the contact end time and of the exit rate against DOP853 at rtol 1e-13;
3. if the optional package ``heyoka`` (an LLVM-compiled Taylor integrator) is installed, its time for
   the contact and the free flight at tol 1e-10 (it cannot start at the onset itself: the Taylor
   coefficients of ``delta^1.5`` at ``delta = 0`` are infinite, so it starts 1e-3 of the contact in);
4. the budget: the evaluations and the cost per evaluation that 1000x would need.

The conclusions drawn from it are in docs/simulator.md ("Why S1 stays below 1000x").
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from scipy.integrate import solve_ivp  # noqa: E402

from benchmarks.bench_simulator import best_time, contact_interval, kernel_runner, s1_event  # noqa: E402
from benchmarks.pages import BenchmarkPage  # noqa: E402
from impactid import simulate_event  # noqa: E402
from impactid.simulate import DEFAULT_TOLERANCES  # noqa: E402
from tests.rigs.pivoted import reference_rigp as ref  # noqa: E402

PAGE_INTRO = """\
Where the time of one S1 event goes (the event of [the simulator's benchmark](performance_simulator.md):
a contact and one revolution of free flight at e/r_c 0.2, 16 Hz, beta 24.7 GN s m^-2.5, n 1.5), and
how many right-hand-side evaluations other methods need for its contact and its free flight at the
compiled kernel's default tolerance. docs/simulator.md ("Why S1 stays below 1000x") draws the
conclusions."""

#: Offsets delta0 [m] of the Sundman variable (the contact's peak indentation is about 2e-5 m).
SUNDMAN_OFFSETS = (1e-14, 1e-12, 1e-10)
#: Absolute tolerances [s] on the time, a state in the Sundman variable.
SUNDMAN_TIME_ATOLS = (1e-16, 1e-13, 1e-11)


def _kernels(p, th0, omega, law, mu):
    return ref._make_kernels(p, th0, omega, law.beta, law.n, mu, False)


def _exit_event(kernels, sundman: bool):
    if sundman:
        def event(s, y):  # y = (t, alpha, alpha_dot)
            return kernels["ev_gap"](y[0], y[1:])
    else:
        def event(t, y):
            return kernels["ev_gap"](t, y)
    event.terminal, event.direction = True, 1.0
    return event


def _sundman_rhs(kernels, offset):
    rhs, kin = kernels["rhs_contact"], kernels["kin"]

    def f(s, y):
        t, a, ad = y
        psi = kin(t, a, ad)[2]
        dt_ds = math.sqrt(max(-psi, 0.0) + offset)
        rate, acceleration = rhs(t, [a, ad])
        return [dt_ds, rate * dt_ds, acceleration * dt_ds]

    return f


def run(args) -> int:
    rig, law, hz, (a0, ad0, th0), t_end = s1_event()
    tol = DEFAULT_TOLERANCES
    omega = 2 * math.pi * hz
    repeat = 2 if args.quick else 7

    print("== 1. the compiled kernel, per phase ==")
    kernel, contacts = kernel_runner(rig, hz, law, a0, ad0, th0)
    whole = kernel(t_end)
    t_on, t_off = contact_interval(contacts)
    in_contact = kernel(t_off)
    contact_us = best_time(lambda: kernel(t_off), repeat=repeat) * 1e6
    whole_us = best_time(lambda: kernel(t_end), repeat=repeat) * 1e6
    event_us = best_time(lambda: simulate_event(rig, hz, law, a0, ad0, th0, t_end), repeat=repeat) * 1e6
    contact_steps = int(in_contact.n_steps) + int(in_contact.n_rejected)
    flight_steps = int(whole.n_steps) + int(whole.n_rejected) - contact_steps
    print(f"contact ({1e3 * (t_off - t_on):.3f} ms): {contact_us:6.1f} us, {in_contact.n_steps} accepted + "
          f"{in_contact.n_rejected} rejected steps = {6 * contact_steps} evaluations, "
          f"{1e3 * contact_us / (6 * contact_steps):.0f} ns each")
    print(f"free flight ({1e3 * (t_end - t_off):.1f} ms): {whole_us - contact_us:6.1f} us, {flight_steps} steps "
          f"= {6 * flight_steps} evaluations")
    unbounded, _ = kernel_runner(rig, hz, law, a0, ad0, th0, replace(tol, max_step_revolutions=1.0))
    loose = unbounded(t_end)
    print(f"with the step bound of 1/50 revolution lifted to a whole revolution: {loose.n_steps} accepted + "
          f"{loose.n_rejected} rejected steps (the bound does not bind; the tolerance sets the free flight's steps)")
    print(f"kernel, whole event: {whole_us:6.1f} us; simulate_event: {event_us:6.1f} us "
          f"(the Python around the kernel {event_us - whole_us:.1f} us)")

    print("\n== 2. solve_ivp on the reference model: evaluations at rtol 1e-10, atol 1e-13 ==")
    p = ref.reference_params(0.2)
    kernels = _kernels(p, th0, omega, law, rig.mu)
    truth = solve_ivp(kernels["rhs_contact"], (0.0, 0.01), [a0, ad0], method="DOP853", rtol=1e-13, atol=1e-17,
                      events=[_exit_event(kernels, False)])
    t_exit, y_exit = truth.t_events[0][0], truth.y_events[0][0]

    def report(label, sol, t_index, rate_index):
        y = sol.y_events[0][0]
        print(f"  {label:44s} steps {len(sol.t) - 1:4d}  evaluations {sol.nfev:5d}  "
              f"exit time error {y[t_index] - t_exit if t_index is not None else sol.t_events[0][0] - t_exit:8.1e} s"
              f"  exit rate error {(y[rate_index] - y_exit[1]) / y_exit[1]:8.1e}")

    rtol, atol = tol.rtol, tol.atol_alpha
    print(f"contact ({1e3 * t_exit:.4f} ms):")
    for method in ("RK45", "DOP853"):
        sol = solve_ivp(kernels["rhs_contact"], (0.0, 0.01), [a0, ad0], method=method, rtol=rtol, atol=atol,
                        events=[_exit_event(kernels, False)])
        report(f"{method} in time", sol, None, 1)
        if method == "RK45":
            starts, steps = sol.t[:-1] / t_exit, np.diff(sol.t) / t_exit
            print(f"    its steps as fractions of the contact: median {np.median(steps[starts < 0.4]):.4f} in its "
                  f"first 40 %, {np.median(steps[starts > 0.5]):.4f} in its second half; the first "
                  f"{steps[0]:.1e}, the last {steps[-1]:.1e} (the ends, where delta^1.5 has unbounded derivatives)")
    for method in ("RK45", "DOP853"):
        for time_atol in SUNDMAN_TIME_ATOLS:
            for offset in SUNDMAN_OFFSETS:
                sol = solve_ivp(_sundman_rhs(kernels, offset), (0.0, 10.0), [0.0, a0, ad0], method=method,
                                rtol=rtol, atol=np.array([time_atol, atol, atol]), events=[_exit_event(kernels, True)])
                report(f"{method} in s, delta0 {offset:.0e} m, t atol {time_atol:.0e} s", sol, 0, 2)
    print(f"free flight ({1e3 * (t_end - t_exit):.1f} ms, from the exact exit state):")
    for method in ("RK45", "DOP853"):
        sol = solve_ivp(kernels["rhs_free"], (t_exit, t_end), y_exit, method=method, rtol=rtol, atol=atol)
        print(f"  {method:44s} steps {len(sol.t) - 1:4d}  evaluations {sol.nfev:5d}")
    print(f"  (the kernel bounds a free-flight step by {tol.max_step_revolutions:g} of a revolution, so that a "
          "grazing contact cannot be stepped over: a method of fewer, longer steps needs another guard)")

    print("\n== 3. a Taylor method (heyoka) ==")
    taylor = _taylor(p, law, rig.mu, kernels, a0, ad0, th0, omega, t_exit, y_exit, t_end, repeat)
    print(taylor)

    print("\n== 4. the budget of 1000x ==")
    baseline = best_time(lambda: ref.run_hybrid(a0, ad0, th0, hz, t_end, p, law.beta, law.n, rig.mu, rtol=1e-10,
                                                atol=1e-13, method="DOP853"), repeat=max(1, repeat // 3),
                         min_time=0.05) * 1e6
    budget = baseline / 1000.0
    python_us = event_us - whole_us
    per_eval = 1e3 * (budget - python_us) / (6 * contact_steps)
    print(f"solve_ivp DOP853 rtol 1e-10 (the baseline of bench_simulator.py at the default tolerance): "
          f"{baseline / 1e3:.2f} ms per event; 1000x: {budget:.1f} us per event")
    print(f"with the Python around the kernel as it is ({python_us:.1f} us) and a free flight that cost nothing, "
          f"the contact's {6 * contact_steps} evaluations would have {per_eval:.0f} ns each "
          f"(now {1e3 * contact_us / (6 * contact_steps):.0f} ns)")
    return 0


def _taylor(p, law, mu, kernels, a0, ad0, th0, omega, t_exit, y_exit, t_end, repeat) -> str:
    """heyoka's contact (from 1e-3 of it in) and free flight at tol 1e-10, or why it was not run."""
    try:
        import heyoka as hy  # optional: not a dependency of impactid
    except ImportError:
        return "heyoka is not installed (pip install heyoka): not measured"
    PEx, PEy, e = p["PE_x"], p["PE_y"], p["e"]
    clearance, hp, rc = p["h_p"] + p["r_c"], p["h_p"], p["r_c"]
    a, ad = hy.make_vars("a", "ad")
    th = th0 + omega * hy.time
    sa, ca, sat, cat = hy.sin(a), hy.cos(a), hy.sin(a + th), hy.cos(a + th)
    psi = PEx * sa + PEy * ca - e * sat - clearance
    chi = PEx * ca - PEy * sa - e * cat
    delta = -psi
    force = p["k_H"] * delta * hy.sqrt(delta) - law.beta * delta ** law.n * (chi * ad - e * cat * omega)
    free = (p["m_b"] * p["g"] * p["l_g"] * ca
            - p["k_s"] * p["d_x"] * (p["L_s_u"] - p["d_y"] + p["d_x"] * sa / ca + 0.5 * p["w_b"] / ca))
    nG, _, _, _, s_at = kernels["kin"](0.0, a0, ad0)
    sliding = math.copysign(1.0, nG * ad0 - e * s_at * omega - (rc + e * s_at) * (ad0 + omega))  # never reverses
    leaves = hy.t_event(psi, direction=hy.event_direction.positive)
    contact = hy.taylor_adaptive([(a, ad), (ad, (free + force * chi - mu * force * sliding * hp) / p["I_b"])],
                                 [a0, ad0], tol=1e-10, t_events=[leaves])
    flight = hy.taylor_adaptive([(a, ad), (ad, free / p["I_b"])], [a0, ad0], tol=1e-10,
                                t_events=[hy.t_event(psi, direction=hy.event_direction.negative)])
    start = solve_ivp(kernels["rhs_contact"], (0.0, 1e-3 * t_exit), [a0, ad0], method="DOP853", rtol=1e-13,
                      atol=1e-17)
    t_in, y_in = start.t[-1], start.y[:, -1].copy()

    def run_contact():
        contact.time, contact.state[:] = t_in, y_in
        return contact.propagate_until(0.01)

    def run_flight():
        flight.time, flight.state[:] = t_exit, y_exit
        return flight.propagate_until(t_end)

    steps_c, steps_f = run_contact()[3], run_flight()[3]
    error = contact.time - t_exit
    contact_us = best_time(run_contact, repeat=repeat, min_time=0.1) * 1e6
    flight_us = best_time(run_flight, repeat=repeat, min_time=0.1) * 1e6
    return (f"heyoka {hy.__version__}, order {contact.order}: contact {contact_us:.1f} us ({steps_c} steps, exit time "
            f"error {error:.1e} s), free flight {flight_us:.1f} us ({steps_f} steps)")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats")
    parser.add_argument("--page", type=Path, help="also write the report as this Markdown page")
    args = parser.parse_args(argv)
    started = time.perf_counter()
    with BenchmarkPage(args.page, "Performance: where an S1 event's time goes", PAGE_INTRO):
        code = run(args)
    print(f"({time.perf_counter() - started:.0f} s)", file=sys.stderr)
    return code


if __name__ == "__main__":
    sys.exit(main())

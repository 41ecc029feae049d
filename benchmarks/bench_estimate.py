"""Benchmark of the contact-damping estimators. Run: ``python benchmarks/bench_estimate.py``.

Everything is measured in one run on this machine (ratios, so that the machine's load cancels):

1. **Cost.** Two 2 s recordings of rig P at the built-in example's operating points (e/r_c 0.05 at
   16 Hz and 0.25 at 15 Hz; beta 24.7 GN s m^-2.5, n 1.5; 0.2 % noise, 24-bit ADC), made by
   impactid's generator. For the least-squares method (the default) and the optimiser: the
   ``n``-fixed fit of the first recording and the joint fit of both, through
   :func:`impactid.rigs.pivoted.estimates.fit_contact_damping` on the reconstructed events (S1 simulations
   counted by the objective, wall time of the fit alone).
2. **Agreement** on validation cases: noise-free S2 at e/r_c 0.2, 16 Hz (``n`` fixed), the joint
   fit over 0.2/16 Hz + 0.25/15 Hz (noise-free), the two noisy recordings of part 1 (``n`` fixed
   and joint), and three 2 s recordings with 0.5 % noise on every channel (``n`` fixed; seeds 1-3).
   For each: both estimates, whether each lies inside the other method's interval, and whether
   each interval holds the truth.

Targets (printed, met or missed with the measured figure): a joint fit over two 2 s recordings
with at most 10,000 S1 simulations and at most 5x the wall time of the ``n``-fixed fit of one of
them; the least-squares estimates inside the optimiser's intervals on every validation case.

``--quick`` skips the optimiser's joint fits (they take minutes each). ``--page PATH`` also writes
the report as a documentation page (docs/performance_estimation.md is written by
``python benchmarks/bench_estimate.py --quick --page docs/performance_estimation.md``).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks.pages import BenchmarkPage  # noqa: E402
from impactid import SUNDAR2016, HuntCrossley  # noqa: E402
from impactid.rigs.pivoted.estimates import fit_contact_damping  # noqa: E402
from impactid.rigs.pivoted.reconstruct import reconstruct  # noqa: E402
from impactid.rigs.pivoted.residuals import EventSet  # noqa: E402
from impactid.synth import SensorModel, synth_pivoted  # noqa: E402

BETA, N = 24.7e9, 1.5
LAW = HuntCrossley(BETA, N)


def events(e_over_rc: float, hz: float, seconds: float, noise: float = 0.0, seed: int = 0,
           adc_bits: int | None = None) -> EventSet:
    sensors = SensorModel(noise=noise, adc_bits=adc_bits, seed=seed)
    rec = synth_pivoted(SUNDAR2016.with_eccentricity_ratio(e_over_rc), hz, LAW, seconds, sensors=sensors).recording
    return EventSet.from_reconstruction(reconstruct(rec), source=f"{e_over_rc}/{hz:g} Hz")


def fit(sets, method: str, fix_n=None, jacobian: str = "sensitivities"):
    t0 = time.perf_counter()
    est = fit_contact_damping(sets, method=method, fix_n=fix_n, jacobian=jacobian)
    return est, time.perf_counter() - t0


def run_cost(sets, sensitivities: bool, repeat: int = 5) -> float:
    """Best wall time [s] of one batched S1 call of every event of ``sets`` at the truth (one trial law)."""
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        for s in sets:
            s.simulate(np.array([[BETA, N]]), sensitivities=sensitivities)
        best = min(best, time.perf_counter() - t0)
    return best


def inside(value: float, interval) -> bool:
    return bool(interval[0] <= value <= interval[1])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="skip the optimiser's joint fits")
    parser.add_argument("--page", type=Path, help="also write the report as this Markdown page")
    args = parser.parse_args(argv)
    warnings.simplefilter("ignore")
    with BenchmarkPage(args.page, "Performance: estimation", PAGE_INTRO):
        return run(args)


PAGE_INTRO = """\
The cost of the contact-damping estimators (S1 simulations, wall time of the fit alone) and their
agreement. Recordings: two 2 s recordings of rig P at the built-in example's operating points
(e/r_c 0.05 at 16 Hz and 0.25 at 15 Hz; beta 24.7 GN s m^-2.5, n 1.5; 0.2 % noise, 24-bit ADC).
Agreement cases: noise-free 0.2/16 Hz, the two noisy recordings, and three 2 s recordings with
0.5 % noise (seeds 1-3); beta is printed as its error relative to the truth, then its interval,
whether the interval holds the truth, and whether the estimate lies in the other method's interval.
Targets (the least-squares estimator, issue of joint fits in seconds): a joint fit over two 2 s
recordings with at most 10,000 S1 simulations and at most 5x the wall time of the n-fixed fit of one
of them; the least-squares estimates inside the optimiser's intervals on every case."""


def run(args) -> int:
    a = events(0.05, 16.0, 2.0, noise=0.002, seed=1, adc_bits=24)
    b = events(0.25, 15.0, 2.0, noise=0.002, seed=2, adc_bits=24)
    fit([a.subset(slice(0, 3))], "least-squares", fix_n=N)  # compile and warm up
    print(f"recordings: 2 s each, {len(a)} + {len(b)} impacts (0.2 % noise)\n")

    plain = run_cost([a, b], sensitivities=False)
    augmented = run_cost([a, b], sensitivities=True)
    rollouts = augmented / plain
    print("0. Jacobian: one S1 run of every event with the forward sensitivities (ln beta, n) costs "
          f"{rollouts:.2f} runs without them\n   ({augmented * 1e3:.2f} ms against {plain * 1e3:.2f} ms for "
          f"{len(a) + len(b)} events): residuals and Jacobian together cost {rollouts:.2f} rollouts, against "
          "1 + 4 (joint) or 1 + 2 (n fixed) with central differences\n")

    print("1. cost                                         S1 simulations   wall [s]")
    cost = {}
    rows = [("least-squares", "sensitivities"), ("least-squares", "differences"), ("optimise", None)]
    for method, jac in rows:
        for label, sets, fix_n in (("n fixed, one recording", [a], N), ("joint, two recordings", [a, b], None)):
            if method == "optimise" and fix_n is None and args.quick:
                continue
            est, wall = fit(sets, method, fix_n, jac or "sensitivities")
            cost[method, jac, fix_n is None] = (est, wall)
            name = method if jac is None else f"{method} ({jac})"
            print(f"   {name:29s} {label:24s} {est.n_simulations:9d}   {wall:8.2f}")
    ls_fixed, ls_fixed_wall = cost["least-squares", "sensitivities", False]
    ls_joint, ls_joint_wall = cost["least-squares", "sensitivities", True]
    ratio = ls_joint_wall / ls_fixed_wall
    for joint in (False, True):
        (sens_est, sens_wall), (diff_est, diff_wall) = (cost["least-squares", j, joint]
                                                        for j in ("sensitivities", "differences"))
        what = "joint" if joint else "n fixed"
        n_part = f", n {abs(sens_est.n - diff_est.n):.1e}" if joint else ""
        print(f"   {what}: sensitivities / differences = {sens_wall / diff_wall:.2f} in wall time; estimates differ "
              f"by {abs(math.log(sens_est.beta / diff_est.beta)):.1e} in ln beta{n_part}")
    targets = [("joint fit: at most 10,000 S1 simulations", ls_joint.n_simulations <= 10_000,
                f"{ls_joint.n_simulations}"),
               ("joint fit: at most 5x the wall time of the n-fixed fit", ratio <= 5.0, f"{ratio:.2f}x")]
    if ("optimise", None, True) in cost:
        opt_joint, opt_wall = cost["optimise", None, True]
        print(f"   joint: least squares / optimiser = {ls_joint.n_simulations / opt_joint.n_simulations:.4f} in "
              f"simulations, {ls_joint_wall / opt_wall:.4f} in wall time")

    print("\n2. agreement (estimate; [interval]; truth inside?; inside the other method's interval?)")
    cases = [("noise-free 0.2/16 Hz, n fixed", [events(0.2, 16.0, 1.0)], N),
             ("noise-free 0.2/16 + 0.25/15 Hz, joint", [events(0.2, 16.0, 1.0), events(0.25, 15.0, 1.0)], None),
             ("0.2 % noise 0.05/16 Hz 2 s, n fixed", [a], N),
             ("0.2 % noise 0.05/16 + 0.25/15 Hz 2 s, joint", [a, b], None)]
    cases += [(f"0.5 % noise 0.2/16 Hz 2 s seed {s}, n fixed", [events(0.2, 16.0, 2.0, noise=0.005, seed=s)], N)
              for s in (1, 2, 3)]
    agree = []
    for label, sets, fix_n in cases:
        if fix_n is None and args.quick:
            continue
        ls, _ = fit(sets, "least-squares", fix_n)
        opt, _ = fit(sets, "optimise", fix_n)
        ok = inside(ls.beta, opt.beta_interval) and (fix_n is not None or inside(ls.n, opt.n_interval))
        agree.append(ok)
        print(f"   {label}")
        for name, e, other in (("least squares", ls, opt), ("optimiser", opt, ls)):
            n_part = "" if fix_n is not None else (
                f"  n {e.n:.4f} [{e.n_interval[0]:.4f}, {e.n_interval[1]:.4f}] {inside(N, e.n_interval)}")
            print(f"     {name:13s} beta {e.beta / BETA - 1:+.4f} [{e.beta_interval[0] / BETA - 1:+.4f}, "
                  f"{e.beta_interval[1] / BETA - 1:+.4f}] {inside(BETA, e.beta_interval)}{n_part}  "
                  f"in the other's: {inside(e.beta, other.beta_interval)}")
    targets.append(("least-squares estimates inside the optimiser's intervals", all(agree),
                    f"{sum(agree)}/{len(agree)} cases"))

    print("\ntargets")
    for text, met, figure in targets:
        print(f"   {'met ' if met else 'MISS'}  {text}: {figure}")
    return 0 if all(met for _, met, _ in targets) else 1


if __name__ == "__main__":
    sys.exit(main())

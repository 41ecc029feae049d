"""Benchmark of rig F's bifurcation diagram (issue 6). Run: ``python benchmarks/bench_bifurcation.py``.

Measures, in one run on this machine:

1. the full diagram the issue asks for: 200 cam speeds from 110 to 165 rpm, 100 revolutions each,
   with the compiled sweep on all cores and on one thread (target: under 60 s);
2. the baseline: the independent ``solve_ivp`` reference model (tests/rigs/flat/reference_flat.py,
   DOP853) for the same work at a few speeds, timed in the same run and scaled to 200 speeds; the
   ratio compiled/reference is printed;
3. that the two agree: stroboscopic angles of the compiled sweep against the reference at the
   timed speeds.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import numba  # noqa: E402

from impactid.rigs.flat import ALZATE2007  # noqa: E402
from impactid.rigs.flat.simulate import DEFAULT_RESTITUTION, bifurcation  # noqa: E402
from tests.rigs.flat import reference_flat as ref  # noqa: E402


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--speeds", type=int, default=200)
    parser.add_argument("--revolutions", type=int, default=100)
    parser.add_argument("--reference-speeds", type=int, default=3, help="speeds timed with solve_ivp")
    parser.add_argument("--reference-revolutions", type=int, default=10,
                        help="revolutions per reference speed (scaled to --revolutions)")
    args = parser.parse_args(argv)
    rig = ALZATE2007
    speeds = np.linspace(110.0, 165.0, args.speeds) / 60.0
    bifurcation(rig, speeds[:2], revolutions=2)  # compile (or load the cache) outside the timing

    t0 = time.perf_counter()
    result = bifurcation(rig, speeds, revolutions=args.revolutions)
    t_all = time.perf_counter() - t0
    threads = numba.get_num_threads()
    numba.set_num_threads(1)
    t0 = time.perf_counter()
    bifurcation(rig, speeds, revolutions=args.revolutions)
    t_one = time.perf_counter() - t0
    numba.set_num_threads(threads)

    picks = np.linspace(0, args.speeds - 1, args.reference_speeds + 2).astype(int)[1:-1]
    t_ref = 0.0
    worst = 0.0
    for i in picks:
        hz = float(speeds[i])
        omega = 2.0 * math.pi * hz
        n = args.reference_revolutions
        t0 = time.perf_counter()
        run = ref.run_flat_reference(rig, omega, DEFAULT_RESTITUTION(hz), n / hz)
        t_ref += time.perf_counter() - t0
        _, _, strobe = run.stroboscopic()
        short = bifurcation(rig, [hz], revolutions=n, kept=n)
        strobe = np.ravel(strobe)[1 : n + 1]
        worst = max(worst, float(np.max(np.abs(short.strobe_angle[0][: strobe.size] - strobe))))
    per_rev_ref = t_ref / (len(picks) * args.reference_revolutions)
    t_ref_full = per_rev_ref * args.revolutions * args.speeds

    counts = result.table["regime"].value_counts().to_dict()
    print(f"bifurcation diagram: {args.speeds} speeds x {args.revolutions} revolutions (110-165 rpm)")
    print(f"  compiled, {threads} threads: {t_all:8.2f} s   (target < 60 s)")
    print(f"  compiled, 1 thread : {t_one:8.2f} s   (scaling {t_one / t_all:.2f}x on {threads} threads)")
    print(f"  solve_ivp reference: {t_ref_full:8.1f} s   (measured {t_ref:.1f} s for {len(picks)} speeds x "
          f"{args.reference_revolutions} revolutions, scaled)")
    print(f"  ratio reference / compiled ({threads} threads): {t_ref_full / t_all:8.0f}x")
    print(f"  largest stroboscopic difference compiled vs reference: {worst:.2e} rad")
    print(f"  regimes: {counts}; transitions: {result.transitions()}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Interval coverage of the single-impact test rig's fit (``impactid.rigs.drop.fit_drop``) over noise
seeds: 95 % intervals of k, beta and n against the truth of drops made by the independent
``solve_ivp`` reference (``tests/rigs/drop/reference_drop.py``), 0.5 % noise on both channels.

Run: ``python benchmarks/validate_drop.py [--seeds 100]`` (about 20 s with single-threaded BLAS; up to
a few minutes when a multithreaded BLAS competes for a loaded machine's cores). A validation script,
not a test: it prints the measured coverage with its binomial 95 % interval and the spread of the
standardised errors, and exits 1 when a coverage is below 88 % or a spread outside 0.8-1.25.
Measured (100 seeds): coverage 95, 94, 94 % for k, beta, n; spreads 0.97, 1.02, 1.02.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from scipy import stats

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from impactid.rigs.drop import PA6_PAD_LAW, STEEL_ON_PA6, fit_drop  # noqa: E402
from tests.rigs.drop import reference_drop as R  # noqa: E402
from tests.rigs.drop.conftest import HEIGHTS  # noqa: E402

NAMES = ("k", "beta", "n")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=100)
    args = parser.parse_args(argv)
    rig, law = STEEL_ON_PA6, PA6_PAD_LAW
    truth = {"k": rig.k, "beta": law.beta, "n": law.n}
    z, covered = [], []
    for seed in range(args.seeds):
        recs = [R.reference_recording(rig, law.beta, law.n, h, noise=0.005, seed=1000 + 2 * seed + i)[0]
                for i, h in enumerate(HEIGHTS)]
        fit = fit_drop(recs)
        z.append([(fit.value(name) - truth[name]) / fit[name].stderr for name in NAMES])
        covered.append([fit[name].contains(truth[name]) for name in NAMES])
    coverage = np.mean(covered, axis=0)
    spread = np.std(z, axis=0)
    hits = np.sum(covered, axis=0)
    print(f"{args.seeds} noise seeds, drops from {', '.join(f'{h:g}' for h in HEIGHTS)} m, 0.5 % noise")
    print("parameter  coverage  binomial 95 %      spread of (estimate - truth) / stderr")
    for k, name in enumerate(NAMES):
        low, high = stats.binomtest(int(hits[k]), args.seeds).proportion_ci(0.95)
        print(f"{name:<9}  {coverage[k]:7.1%}   [{low:.3f}, {high:.3f}]     {spread[k]:.3f}")
    ok = bool(np.all(coverage >= 0.88) and np.all((spread > 0.8) & (spread < 1.25)))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())

"""The compiled simulator of this tree against another commit's, measured in one run.

    python benchmarks/bench_simulator_against.py [REV] [--rounds 5]

``REV`` (default ``HEAD~1``) is checked out into a temporary git worktree; both trees run the same
timing script in fresh processes (warm numba caches: each tree is compiled once before timing),
alternating A, B, A, B, ... so that a change of the machine's load falls on both. Timed, on rig P
at e/r_c = 0.2, 16 Hz with the Hunt–Crossley law of Sundar, Dreyer & Singh (2016):

* one S1 event (contact and one revolution of free flight) through ``simulate_event``;
* a batch of 256 S1 events through ``simulate_events`` on one thread (the estimator's workload);
* 2 s of settled motion through ``simulate``.

The ratio is this tree's time over REV's (below 1: faster), the best of the rounds for each.
The target of the one-integrator-core refactor: no ratio above 1.05.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: Runs inside each tree (old and new public names are both accepted).
TIMING = r"""
import json, math, time
import numba
numba.set_num_threads(1)
import numpy as np
import impactid as I
rig0 = getattr(I, "SUNDAR2016", None) or getattr(I, "SEED001_TABLE1")
rig = rig0.with_eccentricity_ratio(0.2)
law = I.HuntCrossley(24.7e9, 1.5)
hz = 16.0
settled = I.simulate(rig, hz, law, 40.0)
onset = settled.contacts.iloc[-2]
a0, ad0 = float(onset["alpha_start"]), float(onset["alpha_dot_start"])
th0 = 2.0 * math.pi * hz * float(onset["t_start"])
states = np.tile([[a0, ad0, th0]], (256, 1))
ends = np.full(256, 1.0 / hz)
laws = np.array([[law.beta, law.n]])

def best(fn, repeat=5, min_time=0.3):
    out = math.inf
    for _ in range(repeat):
        n, start = 0, time.perf_counter()
        while True:
            fn(); n += 1
            if time.perf_counter() - start >= min_time:
                break
        out = min(out, (time.perf_counter() - start) / n)
    return out

def one_event():
    I.simulate_event(rig, hz, law, a0, ad0, th0, 1.0 / hz)

def batch():
    I.simulate_events(rig, hz, states, ends, laws)

def settled_run():
    I.simulate(rig, hz, law, 2.0)

for fn in (one_event, batch, settled_run):
    fn()
print(json.dumps({"event_us": 1e6 * best(one_event), "batch_us_per_event": 1e6 * best(batch) / 256,
                  "simulate_2s_ms": 1e3 * best(settled_run, repeat=3)}))
"""


def _run(tree: Path) -> dict:
    env = dict(os.environ, PYTHONPATH=str(tree))
    out = subprocess.run([sys.executable, "-c", TIMING], cwd=tree, env=env, capture_output=True, text=True,
                         check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("rev", nargs="?", default="HEAD~1", help="the commit to compare with (default HEAD~1)")
    parser.add_argument("--rounds", type=int, default=5, help="alternating rounds (default 5)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="impactid-bench-") as tmp:
        other = Path(tmp) / "tree"
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(other), args.rev], check=True,
                       capture_output=True)
        try:
            described = subprocess.run(["git", "-C", str(other), "log", "--oneline", "-1"], capture_output=True,
                                       text=True).stdout.strip()
            print(f"this tree: {ROOT}\nagainst:   {described}")
            for tree in (ROOT, other):  # compile once in each tree (numba cache) before timing
                _run(tree)
            rows = {"this": [], "other": []}
            for k in range(args.rounds):
                rows["this"].append(_run(ROOT))
                rows["other"].append(_run(other))
                print(f"round {k + 1}/{args.rounds}: this {rows['this'][-1]}  other {rows['other'][-1]}", flush=True)
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(other)], capture_output=True)
    worst = 0.0
    print(f"\n{'quantity':<22} {'this':>12} {'other':>12} {'ratio':>8}")
    for key in rows["this"][0]:
        mine = min(r[key] for r in rows["this"])
        theirs = min(r[key] for r in rows["other"])
        worst = max(worst, mine / theirs)
        print(f"{key:<22} {mine:>12.4g} {theirs:>12.4g} {mine / theirs:>8.3f}")
    print(f"\nlargest ratio {worst:.3f} (target <= 1.05): {'met' if worst <= 1.05 else 'MISSED'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

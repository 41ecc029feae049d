"""Benchmark of ``impactid estimate`` (issue 5). Run: ``python benchmarks/bench_estimate.py``.

In one run on this machine, on a 2 s noise-free S2 recording at e/r_c 0.2, 16 Hz (~31 impacts):

1. the whole estimate (read from HDF5, events, reconstruction, fit, uncertainty, restitution) with
   n fixed, and jointly for (beta, n), wall time, through the same code as the command line;
2. the paper-style alternative: a grid search of the same final resolution, 0.1 % in beta
   (4.3e-4 decades over the 6 decades of the default bounds: 13 817 trial values) with n fixed,
   timed in full; for the joint fit the grid also needs n at 0.001 over [0.5, 2.5] (2001 values),
   whose time is extrapolated from the measured cost per trial (it would take hours);
3. the ratios grid / optimiser.

Targets: n fixed under 5 s, joint under 30 s.
"""

from __future__ import annotations

import math
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from impactid import SUNDAR2016, HuntCrossley  # noqa: E402
from impactid.estimates import C_BOUNDS, _Objective, estimate, reference_indentation  # noqa: E402
from impactid.synth import synth_pivoted  # noqa: E402


def main() -> int:
    warnings.simplefilter("ignore")
    s = synth_pivoted(SUNDAR2016.with_eccentricity_ratio(0.2), 16.0, HuntCrossley(24.7e9, 1.5), 2.0)
    with tempfile.TemporaryDirectory() as tmp:
        path = s.write(Path(tmp) / "s2_2s.h5")
        estimate(path, fix_n=1.5)  # warm the numba cache and imports
        t0 = time.perf_counter()
        fixed = estimate(path, fix_n=1.5)
        t_fixed = time.perf_counter() - t0
        t0 = time.perf_counter()
        joint = estimate(path)
        t_joint = time.perf_counter() - t0
    sets = list(fixed.event_sets)
    obj = _Objective(sets, "lambda1", reference_indentation(sets))
    step = math.log10(1.001)
    grid = np.arange(math.log10(C_BOUNDS[0]), math.log10(C_BOUNDS[1]) + step, step)
    t0 = time.perf_counter()
    values = np.concatenate([obj.mean(obj.per_event(chunk, 1.5)) for chunk in np.array_split(grid, 16)])
    t_grid = time.perf_counter() - t0
    beta_grid = float(obj.beta(grid[int(np.argmin(values))], 1.5))
    n_rows = 2001
    t_grid_joint = t_grid * n_rows
    impacts = len(fixed.damping.per_event)
    print(f"recording: 2 s, {impacts} impacts")
    print(f"estimate, n fixed : {t_fixed:7.2f} s wall (target < 5 s)   beta {fixed.damping.beta:.6g}")
    print(f"estimate, joint   : {t_joint:7.2f} s wall (target < 30 s)  beta {joint.damping.beta:.6g}, "
          f"n {joint.damping.n:.4f}")
    print(f"grid, n fixed     : {t_grid:7.2f} s wall ({grid.size} trials x {impacts} impacts; beta {beta_grid:.6g})")
    print(f"grid, joint       : {t_grid_joint:7.0f} s (extrapolated: {n_rows} x {grid.size} trials)")
    print(f"ratio grid/optimiser: n fixed {t_grid / t_fixed:.1f}x (grid alone vs whole estimate), "
          f"joint {t_grid_joint / t_joint:.0f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())

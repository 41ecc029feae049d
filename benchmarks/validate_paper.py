"""Rerun the error, sensitivity and restitution analyses of Sundar, Dreyer & Singh (2016) (Tables 2, 3, 4) on the
project's own S2/S3 recordings, print them beside the paper's, and write ``docs/validation.md``.

Run: ``python benchmarks/validate_paper.py [--out docs/validation.md] [--seeds 10]`` (about 3-5 min).

All recordings come from ``impactid.synth`` (1 s after 40 s of settling, 204.8 kHz, noise-free unless
stated); the pipeline is the one ``impactid estimate`` runs (events, rk integration, cam-phase
anchor unless stated, S1 replays). Nothing reads ``/truth`` except to score the result.
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

from impactid import SUNDAR2016, HuntCrossley, Restitution  # noqa: E402
from impactid.pipeline import estimate  # noqa: E402
from impactid.rigs.pivoted.estimates import fit_restitution  # noqa: E402
from impactid.rigs.pivoted.reconstruct import reconstruct  # noqa: E402
from impactid.rigs.pivoted.regimes import classify_regime  # noqa: E402
from impactid.rigs.pivoted.residuals import EventSet  # noqa: E402
from impactid.synth import SensorModel, synth_pivoted  # noqa: E402

BETA, N = 24.7e9, 1.5
LAW = HuntCrossley(BETA, N)
POINTS = [(0.05, 23.0), (0.10, 18.0), (0.15, 17.0), (0.20, 16.0), (0.25, 15.0)]
PAPER_L1 = {0.05: 0.0056, 0.10: 0.0361, 0.15: 4.75e-7, 0.20: 0.78e-7, 0.25: 1.65e-7}


def quiet(fn, *a, **k):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fn(*a, **k)


def rig_at(ratio):
    return SUNDAR2016.with_eccentricity_ratio(ratio)


def nearest_period1(ratio, hz, law=LAW):
    """Nearest cam speed (0.25 Hz steps, up to +-6 Hz) where the model is period-1."""
    for step in range(1, 25):
        for sign in (-1, 1):
            f = hz + sign * 0.25 * step
            res = quiet(classify_regime, rig_at(ratio), f, law)
            if res.regime == "period-1":
                return f
    return None


def table2(lines):
    lines += ["## Table 2: error analysis (residuals at the true beta, n on noise-free S2 data)", "",
              "Mean over the events of one 1 s recording (after 40 s of settling) of |L1|, L2, |L3| evaluated at "
              "the true parameters. Paper: mean L1 as listed, L2 about 0.07-0.10, L3 about 0.002-0.004.", "",
              "| e/r_c | cam speed [Hz] | regime (model) | events | mean L1 | paper L1 | mean L2 | mean L3 |",
              "|---|---|---|---|---|---|---|---|"]
    rows = []
    for ratio, hz in POINTS:
        regime = quiet(classify_regime, rig_at(ratio), hz, LAW).regime
        rows.append((ratio, hz, regime, PAPER_L1[ratio]))
        if regime != "period-1":
            alt = nearest_period1(ratio, hz)
            if alt is not None:
                rows.append((ratio, alt, "period-1 (nearest)", None))
    for ratio, hz, regime, paper in rows:
        s = synth_pivoted(rig_at(ratio), hz, LAW, 1.0)
        try:
            es = EventSet.from_reconstruction(quiet(reconstruct, s.recording, anchor="cam-phase"))
            vals = [float(np.nanmean(np.abs(es.residuals(np.array([[BETA, N]]), r)))) for r in
                    ("lambda1", "lambda2", "lambda3")]
            n_ev = len(es)
        except Exception as exc:  # non-period-1 data can defeat the period-1 pipeline: say so
            vals, n_ev = [math.nan] * 3, f"failed: {type(exc).__name__}"
        paper_s = f"{paper:.3g}" if paper is not None else "-"
        lines.append(f"| {ratio} | {hz:g} | {regime} | {n_ev} | {vals[0]:.3g} | {paper_s} | {vals[1]:.3g} | "
                     f"{vals[2]:.3g} |")
        print(lines[-1], flush=True)
    lines.append("")
    return rows


def table3(lines):
    lines += ["## Table 3: sensitivity at e/r_c = 0.2, 16 Hz (residual / its value at the truth)", "",
              "| perturbation | L1 ratio | paper L1 ratio | L2 ratio | L3 ratio |", "|---|---|---|---|---|"]
    s = synth_pivoted(rig_at(0.2), 16.0, LAW, 1.0)
    es = EventSet.from_reconstruction(quiet(reconstruct, s.recording, anchor="cam-phase"))
    cases = [("truth", 1, 1, "1"), ("beta +1 %", 1.01, 1, "0.58e5"), ("beta -1 %", 0.99, 1, "0.58e5"),
             ("beta +2 %", 1.02, 1, "-"), ("beta -2 %", 0.98, 1, "-"), ("n +1 %", 1, 1.01, "9e5"),
             ("n -1 %", 1, 0.99, "9e5"), ("n +2 %", 1, 1.02, "-"), ("n -2 %", 1, 0.98, "-")]
    trials = np.array([[BETA * b, N * n] for _, b, n, _ in cases])
    means = {r: np.nanmean(np.abs(es.residuals(trials, r)), axis=1) for r in ("lambda1", "lambda2", "lambda3")}
    for k, (name, _, _, paper) in enumerate(cases):
        ratio = {r: means[r][k] / means[r][0] for r in means}
        lines.append(f"| {name} | {ratio['lambda1']:.3g} | {paper} | {ratio['lambda2']:.3g} | "
                     f"{ratio['lambda3']:.3g} |")
        print(lines[-1], flush=True)
    lines += ["", f"Ideal values (at the truth): L1 {means['lambda1'][0]:.3g}, L2 {means['lambda2'][0]:.3g}, "
              f"L3 {means['lambda3'][0]:.3g}.", ""]


def table4(lines, rows):
    lines += ["## Table 4: restitution (S3, gamma = 0.8 s/m), gamma recovered", "",
              "Paper: gamma recovered within 0-5 %. Both anchors shown (return-time is the paper's).", "",
              "| e/r_c | cam speed [Hz] | regime (model, S3) | events | gamma return-time | error "
              "| gamma cam-phase | error |",
              "|---|---|---|---|---|---|---|---|"]
    law = Restitution(gamma=0.8)
    seen = set()
    for ratio, hz, _, _ in rows:
        for f in ([hz] if (ratio, hz) not in seen else []):
            seen.add((ratio, f))
            try:
                regime = quiet(classify_regime, rig_at(ratio), f, law).regime
            except Exception as exc:  # reported, not hidden (see the closing note of issue 5)
                regime = f"classification failed ({type(exc).__name__})"
            cells = []
            n_ev = "-"
            try:
                s = synth_pivoted(rig_at(ratio), f, law, 1.0)
            except Exception as exc:
                lines.append(f"| {ratio} | {f:g} | {regime} | - | S3 simulation failed: {str(exc)[:80]} | - | - | - |")
                print(lines[-1], flush=True)
                continue
            for anchor in ("return-time", "cam-phase"):
                try:
                    recon = quiet(reconstruct, s.recording, anchor=anchor)
                    fit = quiet(fit_restitution, recon.table, recon.rig.k_H)
                    cells += [f"{fit.gamma:.4g}", f"{100 * (fit.gamma / 0.8 - 1):+.2g} %"]
                    n_ev = len(recon.table)
                except Exception as exc:
                    cells += [f"failed ({type(exc).__name__})", "-"]
            lines.append(f"| {ratio} | {f:g} | {regime} | {n_ev} | " + " | ".join(cells) + " |")
            print(lines[-1], flush=True)
    lines.append("")


def estimates(lines, n_seeds):
    lines += ["## Estimates (impactid estimate defaults: lambda1, optimiser, cam-phase anchor)", ""]
    a = synth_pivoted(rig_at(0.2), 16.0, LAW, 1.0)
    b = synth_pivoted(rig_at(0.25), 15.0, LAW, 1.0)
    lines += ["| data | n | beta / truth - 1 | beta interval / truth - 1 | n estimate | n interval | separable "
              "| time |",
              "|---|---|---|---|---|---|---|---|"]
    for name, recs, fix in [("0.2/16 Hz, noise-free", [a.recording], N), ("0.2/16 Hz, noise-free", [a.recording], None),
                            ("0.2/16 + 0.25/15 Hz, noise-free", [a.recording, b.recording], None)]:
        t0 = time.perf_counter()
        d = quiet(estimate, recs, fix_n=fix).damping
        dt = time.perf_counter() - t0
        lines.append(f"| {name} | {'fixed' if fix is not None else 'free'} | {d.beta / BETA - 1:+.3g} | "
                     f"[{d.beta_interval[0] / BETA - 1:+.3g}, {d.beta_interval[1] / BETA - 1:+.3g}] | {d.n:.4f} | "
                     f"[{d.n_interval[0]:.4f}, {d.n_interval[1]:.4f}] | {d.separable} | {dt:.1f} s |")
        print(lines[-1], flush=True)
    lines += ["", f"### 0.5 % noise on every channel, n fixed at 1.5, 2 s recordings, {n_seeds} noise seeds", "",
              "| seed | impacts | beta / truth - 1 | interval / truth - 1 | covers truth | sd from cam phase |",
              "|---|---|---|---|---|---|"]
    errors, covered = [], 0
    for seed in range(1, n_seeds + 1):
        s = synth_pivoted(rig_at(0.2), 16.0, LAW, 2.0, sensors=SensorModel(noise=0.005, seed=seed))
        d = quiet(estimate, s.recording, fix_n=N).damping
        err = d.beta / BETA - 1
        cov = d.beta_interval[0] <= BETA <= d.beta_interval[1]
        errors.append(err)
        covered += cov
        lines.append(f"| {seed} | {len(d.per_event)} | {err:+.3g} | [{d.beta_interval[0] / BETA - 1:+.3g}, "
                     f"{d.beta_interval[1] / BETA - 1:+.3g}] | {cov} | {d.phase_beta_sd / BETA:.3g} |")
        print(lines[-1], flush=True)
    errors = np.array(errors)
    lines += ["", f"Mean error {errors.mean():+.3g}, standard deviation {errors.std(ddof=1):.3g}, largest "
              f"|error| {np.abs(errors).max():.3g}; the interval covers the truth in {covered} of {n_seeds}.", ""]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(ROOT / "docs" / "validation.md"))
    parser.add_argument("--seeds", type=int, default=10)
    args = parser.parse_args()
    t0 = time.perf_counter()
    lines = ["# Validation against Sundar, Dreyer & Singh (2016) (Tables 2, 3, 4) and the estimators", "",
             "Generated by `python benchmarks/validate_paper.py`; every number below was measured by that run.", ""]
    rows = table2(lines)
    table3(lines)
    table4(lines, rows)
    estimates(lines, args.seeds)
    lines.append(f"Total run time {time.perf_counter() - t0:.0f} s.")
    from impactid.rigs._toml import write_text_atomic

    write_text_atomic(args.out, "\n".join(lines) + "\n")
    print(f"written {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

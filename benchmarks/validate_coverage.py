"""Interval coverage of rig P's n-fixed estimate over many noise seeds; writes docs/validation_coverage.md.

    python benchmarks/validate_coverage.py [--seeds 100] [--noise 0.003] [--workers N | --scheduler ADDRESS]
        [--out docs/validation_coverage.md]

At each of three clean period-1 operating points of rig P (the paper's law, ``beta`` 24.7 GN s m^-2.5,
``n`` 1.5) one noise-free recording is made, then passed through the sensor chain with ``--seeds``
independent noise realisations (Gaussian noise of ``--noise`` of each channel's peak, 24-bit ADC), and
each realisation is estimated with n fixed through :func:`impactid.pipeline.estimate` with the default
options (what a user gets). One of the three points is recorded by the independent SciPy reference
model (``tests/rigs/pivoted/reference_recordings.py``), the others by impactid's simulator.

Per point the page reports the coverage of the 95 % interval of ``beta`` (the share of seeds whose
interval holds the truth) with its Clopper–Pearson 95 % interval, the mean and spread of the error,
the median half-width, refusals with their reasons, and the targets:

* the binomial 95 % interval of the measured coverage contains 0.95 at each point;
* no point's coverage is below 88 %;
* confident wrong answers (an estimate more than 5 % off with an interval excluding the truth) no more
  often than calibrated intervals give them: the count over all points at most the 95 % Poisson quantile of
  the count expected (:func:`expected_confident_wrong`). Calibrated 95 % intervals miss the truth in 5 %
  of the seeds by construction, and where a seed's standard error is near 2.5 % or more some of those
  misses exceed 5 %: "none at all" is not a property such intervals have over 300 noisy seeds.

With ``--workers N`` (a local dask cluster) or ``--scheduler ADDRESS`` the fits run on the cluster's
workers (:mod:`impactid.distributed`); the recordings are made once per point, here.
"""

from __future__ import annotations

import argparse
import math
import platform
import sys
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import stats

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from impactid.distributed import add_scheduler_arguments, iter_tasks, scheduler_client  # noqa: E402
from impactid.errors import ImpactidError  # noqa: E402
from impactid.synth.sensors import SensorModel  # noqa: E402
from tests import envelope as E  # noqa: E402

#: The law of every point (Sundar, Dreyer & Singh 2016, Table 2).
BETA, N = 24.7e9, 1.5
#: (name, e/r_c, cam speed [Hz], generator): three clean period-1 points, one from the reference model.
POINTS = (("P1", 0.20, 16.0, "reference"), ("P2", 0.25, 15.0, "impactid"), ("P3", 0.15, 17.0, "impactid"))
#: Seeds of the noise realisations: ``SEED0 + k``.
SEED0 = 1000
TARGET_COVERAGE = 0.95
MIN_COVERAGE = 0.88


@dataclass(frozen=True)
class Task:
    """One noise realisation of one point, to estimate."""

    point: str
    seed: int
    recording: object


def _noisy(clean, noise: float, seed: int):
    """``clean`` through the sensor chain: Gaussian noise of ``noise`` of each channel's peak, 24-bit ADC."""
    from benchmarks.envelope_case import with_sensors

    return with_sensors(clean, SensorModel(noise=noise, adc_bits=24, seed=seed))


def estimate_task(task: Task) -> dict:
    """The n-fixed estimate of one realisation (on a worker or here); never raises for a refusal."""
    from impactid.pipeline import estimate

    started = time.perf_counter()
    row = {"point": task.point, "seed": task.seed}
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            result = estimate([task.recording], fix_n=N)
    except ImpactidError as exc:
        return {**row, "status": "refusal", "reason": " ".join(str(exc).split()),
                "seconds": time.perf_counter() - started}
    d = result.damping
    return {**row, "status": "estimate", "reason": "", "beta": d.beta, "beta_lo": d.beta_interval[0],
            "beta_hi": d.beta_interval[1], "seconds": time.perf_counter() - started,
            "lack_of_fit": any("lack of fit" in w for w in result.warnings)}


def clopper_pearson(k: int, n: int, level: float = 0.95) -> tuple[float, float]:
    """The exact (Clopper–Pearson) ``level`` interval of a binomial proportion ``k / n``."""
    a = 1.0 - level
    lo = 0.0 if k == 0 else float(stats.beta.ppf(a / 2, k, n - k + 1))
    hi = 1.0 if k == n else float(stats.beta.ppf(1 - a / 2, k + 1, n - k))
    return lo, hi


def expected_confident_wrong(beta: np.ndarray, lo: np.ndarray, hi: np.ndarray, truth: float = BETA,
                             margin: float = 0.05, level: float = 0.95) -> np.ndarray:
    """Per seed, the probability of a confident wrong answer were its interval calibrated.

    With the seed's interval ``[lo, hi]`` a calibrated ``level`` interval, ``x = ln(beta_hat / truth)``
    is normal with mean 0 and the seed's own standard error ``sigma = ln(hi / lo) / (2 z)``, ``z`` the
    normal ``level`` quantile; the interval excludes the truth where ``x > h_lo = ln(beta_hat / lo)``
    (the truth below it) or ``x < -h_hi = -ln(hi / beta_hat)``. A confident wrong answer is that with
    ``|beta_hat / truth - 1| > margin``::

        P = 1 - Phi(max(ln(1 + margin), h_lo) / sigma) + Phi(min(ln(1 - margin), -h_hi) / sigma).

    Parameters
    ----------
    beta, lo, hi : the estimates and their interval's ends [N s m^-2.5].
    truth : the true beta [N s m^-2.5].
    margin : the relative error that counts as wrong [-].
    level : the intervals' nominal level [-].

    Returns
    -------
    numpy.ndarray
        per seed, the probability [-] (NaN where the interval is not finite and positive).
    """
    beta, lo, hi = (np.asarray(v, dtype=float) for v in (beta, lo, hi))
    z = stats.norm.ppf(0.5 + 0.5 * level)
    with np.errstate(all="ignore"):
        h_lo, h_hi = np.log(beta / lo), np.log(hi / beta)
        sigma = (h_lo + h_hi) / (2.0 * z)
        high = stats.norm.sf(np.maximum(math.log1p(margin), h_lo) / sigma)
        low = stats.norm.cdf(np.minimum(math.log1p(-margin), -h_hi) / sigma)
    return np.where(np.isfinite(sigma) & (sigma > 0), high + low, np.nan)


def summarise(frame: pd.DataFrame) -> tuple[pd.DataFrame, dict[str, bool]]:
    """Per point: coverage with its binomial interval, errors, half-widths, refusals; the targets."""
    rows = []
    for point, group in frame.groupby("point", sort=False):
        est = group[group["status"] == "estimate"]
        covered = (est["beta_lo"] <= BETA) & (BETA <= est["beta_hi"])
        error = est["beta"] / BETA - 1.0
        half = 0.5 * (est["beta_hi"] - est["beta_lo"]) / est["beta"]
        confident_wrong = int(((error.abs() > 0.05) & ~covered).sum())
        expected = float(np.nansum(expected_confident_wrong(est["beta"], est["beta_lo"], est["beta_hi"])))
        lo, hi = clopper_pearson(int(covered.sum()), len(est)) if len(est) else (math.nan, math.nan)
        rows.append({"point": point, "seeds": len(group), "estimates": len(est),
                     "refusals": int((group["status"] == "refusal").sum()),
                     "coverage": float(covered.mean()) if len(est) else math.nan, "coverage_lo": lo,
                     "coverage_hi": hi, "mean_error": float(error.mean()), "sd_error": float(error.std(ddof=1)),
                     "median_half_width": float(half.median()), "confident_wrong": confident_wrong,
                     "confident_wrong_expected": expected,
                     "lack_of_fit_notes": int(est.get("lack_of_fit", pd.Series(dtype=bool)).sum())})
    table = pd.DataFrame(rows)
    targets = {
        "the binomial 95 % interval of each point's coverage contains 0.95":
            bool(((table["coverage_lo"] <= TARGET_COVERAGE) & (TARGET_COVERAGE <= table["coverage_hi"])).all()),
        f"no point's coverage below {MIN_COVERAGE:.0%}": bool((table["coverage"] >= MIN_COVERAGE).all()),
        f"confident wrong answers (error > 5 % with an interval excluding the truth) over all points, "
        f"{int(table['confident_wrong'].sum())}, at most the 95 % Poisson quantile "
        f"{int(stats.poisson.ppf(0.95, table['confident_wrong_expected'].sum()))} of the "
        f"{table['confident_wrong_expected'].sum():.2f} calibrated intervals would give":
            bool(table["confident_wrong"].sum() <= stats.poisson.ppf(0.95, table["confident_wrong_expected"].sum())),
    }
    return table, targets


def page(table: pd.DataFrame, targets: dict[str, bool], frame: pd.DataFrame, args, seconds: float) -> str:
    """The Markdown page."""
    lines = ["# Validation: interval coverage over noise seeds (rig P, n fixed)", "",
             f"Made by `python benchmarks/validate_coverage.py --seeds {args.seeds} --noise {args.noise:g}` "
             f"in {seconds:.0f} s ({platform.python_version()}, {platform.machine()}). Law: beta "
             f"{BETA / 1e9:g} GN s m^-2.5, n {N:g} (fixed in the fits). Noise: {100 * args.noise:g} % of each "
             "channel's peak, Gaussian, 24-bit ADC. Each seed is one estimate with the default options "
             "(`impactid estimate REC.h5 --fix-n 1.5`).", "",
             "| point | e/r_c | cam speed [Hz] | recording | seeds | estimates | refusals | coverage | binomial 95 % "
             "| mean error | sd of error | median half-width | confident wrong | expected if calibrated |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    where = {name: (ratio, hz, gen) for name, ratio, hz, gen in POINTS}
    for r in table.itertuples():
        ratio, hz, gen = where[r.point]
        lines.append(f"| {r.point} | {ratio:g} | {hz:g} | {gen} | {r.seeds} | {r.estimates} | {r.refusals} | "
                     f"{100 * r.coverage:.1f} % | [{100 * r.coverage_lo:.1f}, {100 * r.coverage_hi:.1f}] % | "
                     f"{100 * r.mean_error:+.2f} % | {100 * r.sd_error:.2f} % | {100 * r.median_half_width:.2f} % | "
                     f"{r.confident_wrong} | {r.confident_wrong_expected:.2f} |")
    lines += ["", "## Targets", ""]
    lines += [f"- {'met' if ok else '**missed**'}: {text}" for text, ok in targets.items()]
    refusals = frame[frame["status"] == "refusal"]
    if len(refusals):
        lines += ["", "## Refusals", ""]
        lines += [f"- {r.point} seed {r.seed}: {r.reason}" for r in refusals.itertuples()]
    lines += ["", "The per-seed results are in `validation_coverage.csv` beside this page.", ""]
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=100, help="noise realisations per point (default 100)")
    parser.add_argument("--noise", type=float, default=0.003, help="noise, fraction of each channel's peak")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "validation_coverage.md")
    add_scheduler_arguments(parser)
    args = parser.parse_args(argv)
    started = time.perf_counter()
    tasks = []
    for name, ratio, hz, generator in POINTS:
        case = E.Case(id=name, klass="HC", e_over_rc=ratio, cam_speed_hz=hz, beta=BETA, n=N, noise=0.0,
                      adc_bits=None, generator=generator)
        clean, _ = E.make_recording(case)
        print(f"{name}: e/r_c {ratio:g}, {hz:g} Hz, {generator} recording made", flush=True)
        tasks += [Task(name, SEED0 + k, _noisy(clean, args.noise, SEED0 + k)) for k in range(args.seeds)]
    rows = []
    with scheduler_client(args, what="validate_coverage") as client:
        for k, (_, row) in enumerate(iter_tasks(estimate_task, tasks, client=client)):
            rows.append(row)
            if (k + 1) % 25 == 0:
                print(f"  {k + 1} of {len(tasks)} estimates", flush=True)
    frame = pd.DataFrame(rows).sort_values(["point", "seed"], kind="stable")
    table, targets = summarise(frame)
    print(table.to_string(index=False))
    for text, ok in targets.items():
        print(f"{'met' if ok else 'MISSED'}: {text}")
    args.out.write_text(page(table, targets, frame, args, time.perf_counter() - started))
    frame.to_csv(args.out.with_suffix(".csv"), index=False)
    print(f"written {args.out}")
    return 0 if all(targets.values()) else 1


if __name__ == "__main__":
    sys.exit(main())

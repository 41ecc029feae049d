"""Prediction of real planar impacts: impactid's fitted law against the six published contact models.

The data are the planar impacts of an ellipse tracked by motion capture (Fazeli, Donlon, Drumwright &
Rodriguez 2017, ICRA; the MIT MCube planar-impact dataset): one row per impact with the pre- and
post-impact states, the contact Jacobian, the authors' "true" impulse and the impulses six published
rigid-contact models predict (Drumwright-Shell; Anitescu-Potra with Poisson and with Newton
restitution; Mirtich; Wang-Mason; Whittaker). The file is not in the repository: give its folder with
``--data`` or the environment variable ``IMPACTID_REALDATA_PLANAR`` (the folder holding
``mcube_ellipse.csv``).

Protocol: 20 random half splits (``numpy.random.default_rng(seed).permutation``, seeds 0-19). On each,
``impactid.rigs.planar.fit_planar`` fits every law to the training half's measured impulses and
selects one by BIC; the selected law predicts the test half from the pre-impact states and contact
Jacobians alone (the test rows pass through ``PlanarImpacts.pre_impact()``, which drops the outcome);
the relative impulse error ``|p_pred - p_true| / |p_true|`` of each test impact is taken against the
true impulse, and its median is the split's score. The published models' impulses (read only here,
for the comparison) are scored on the same test halves. The statistic compared is the median over the
20 splits of the per-split medians.

A synthetic section measures the coverage of the reported 95 % intervals: at three settings
(:data:`SETTINGS`: laws and velocity noise), ``--seeds`` tables from ``synth_impacts`` (the generator
of ``impactid synth --rig planar-impact``) are fitted with their generating law and each interval is
checked against the value the table was made with (the binomial 95 % interval of the coverage, the
bias, the scatter against the standard error, the estimates more than 5 % off whose interval excludes
the truth).

Run: ``python benchmarks/validate_planar_impacts.py [--data FOLDER] [--splits 20] [--seeds 200] [--write]``
(a few minutes on one core); ``--write`` writes ``docs/validation_planar_impacts.md``. Exits 1 when
impactid's statistic is not below every published model's, or when a coverage interval misses 0.95.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from scipy import stats  # noqa: E402

from impactid.rigs.planar import MCUBE_ELLIPSE, fit_planar, fit_planar_law, predict_planar, read_impacts  # noqa: E402
from impactid.rigs.planar.synth import synth_impacts  # noqa: E402
from impactid.rigs.planar.table import PlanarImpacts  # noqa: E402

FILE = "mcube_ellipse.csv"
#: The published models of the file: column prefix -> name.
PUBLISHED = {"drumwright_shell": "Drumwright-Shell", "ap_poisson": "Anitescu-Potra (Poisson)",
             "ap_newton": "Anitescu-Potra (Newton)", "mirtich": "Mirtich", "wang_mason": "Wang-Mason",
             "whittaker": "Whittaker"}
PAGE = ROOT / "docs" / "validation_planar_impacts.md"
#: The synthetic settings of the coverage measurement: label -> (law, parameters, velocity noise [m/s]).
SETTINGS = {
    "A": ("newton-linear-et", {"e0": 0.8, "gamma": 0.08, "mu": 0.25, "e_t": 0.3}, 0.01),
    "B": ("newton-linear-et", {"e0": 0.8, "gamma": 0.08, "mu": 0.25, "e_t": 0.3}, 0.03),
    "C": ("chatterjee-ruina-constant-stick", {"e": 0.5, "mu": 0.12}, 0.02),
}
#: Impacts per synthetic table (``impactid synth --rig planar-impact``'s default).
SYNTH_IMPACTS = 200


def coverage(seeds: int) -> pd.DataFrame:
    """Interval coverage over noise seeds 0..seeds-1 at each of :data:`SETTINGS`.

    Each seed makes a table with ``synth_impacts`` (the generating law's parameters are kept here and
    used only to score), fits the generating law with ``fit_planar_law`` (no profiles) and records,
    per parameter, whether the reported 95 % interval (clustered by impact) holds the truth and
    whether the engine's model-based interval (``value +/- t * model-based standard error``, the
    intervals before the clustered covariance) did.
    """
    rows = []
    for label, (law, truth, noise) in SETTINGS.items():
        for seed in range(seeds):
            made = synth_impacts(law, truth, count=SYNTH_IMPACTS, noise=noise, seed=seed)
            n = len(made)
            table = PlanarImpacts("synthetic", np.arange(1, n + 1), made.q_pre, made.v_pre, made.jn, made.jt,
                                  made.v_post, made.impulse)
            fit = fit_planar_law(table, MCUBE_ELLIPSE, law, profiles=False)
            model_based = fit.statistics["model_based_stderr"]
            q_model = stats.t.ppf(0.975, fit.statistics["n_residuals"] - fit.statistics["n_params"])
            for name, value in truth.items():
                p = fit[name]
                lo, hi = p.interval
                rows.append({"setting": label, "law": law, "noise": noise, "seed": seed, "parameter": name,
                             "truth": value, "value": p.value, "stderr": p.stderr,
                             "covered": bool(lo <= value <= hi),
                             "covered_before": bool(abs(p.value - value) <= q_model * model_based[name]),
                             "confident_wrong": bool(abs(p.value - value) > 0.05 * abs(value)
                                                     and not lo <= value <= hi)})
        print(f"coverage setting {label}: {seeds} seeds done", flush=True)
    return pd.DataFrame(rows)


def _binomial(k: int, n: int) -> tuple[float, float]:
    """The Clopper-Pearson 95 % interval of a proportion ``k / n``."""
    ci = stats.binomtest(k, n).proportion_ci(0.95)
    return float(ci.low), float(ci.high)


def coverage_lines(cover: pd.DataFrame, seconds: float) -> tuple[list[str], bool]:
    """The page's synthetic section and whether every parameter's coverage interval holds 0.95 with no
    confident wrong answer."""
    seeds = int(cover["seed"].nunique())
    lines = ["## Synthetic impacts: interval coverage", "",
             f"Tables made by `impactid.rigs.planar.synth.synth_impacts` (the generator of `impactid synth --rig "
             f"planar-impact`; {SYNTH_IMPACTS} impacts of the MCube ellipse, approach speeds 1-3 m/s, Gaussian noise "
             "of the given standard deviation on v_x and v_y and over k_g on omega, before and after the impact, the "
             "impulses those of the noisy velocity change), noise seeds "
             f"0-{seeds - 1} at each setting; the generating law is fitted (`fit_planar_law`, no profiles) and the "
             "reported 95 % interval of each parameter is checked against the value the table was made with. "
             "*Before*: the engine's model-based interval (one residual variance for all impacts, the covariance "
             "scale (J^T J)^-1); *after*: the interval clustered by impact that fits report now "
             "([planar impacts](planar_impacts.md#uncertainty)). Coverage interval: Clopper-Pearson 95 %.", "",
             "| setting | law | noise [m/s] | parameter | coverage before | coverage after | 95 % interval of "
             "coverage | bias / scatter | scatter / mean std. error | >5 % off and not covered |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    met = True
    for (label, name), group in cover.groupby(["setting", "parameter"], sort=False):
        k, n = int(group["covered"].sum()), len(group)
        lo, hi = _binomial(k, n)
        wrong = int(group["confident_wrong"].sum())
        met &= lo <= 0.95 <= hi and wrong == 0
        scatter = float(group["value"].std(ddof=1))
        bias = float(group["value"].mean() - group["truth"].iloc[0])
        lines.append(f"| {label} | {group['law'].iloc[0]} | {group['noise'].iloc[0]:g} | {name} | "
                     f"{group['covered_before'].mean():.3f} | {k / n:.3f} | [{lo:.3f}, {hi:.3f}] | "
                     f"{bias / scatter:+.2f} | {scatter / float(group['stderr'].mean()):.2f} | {wrong} |")
    lines += ["", f"Target (issue 26): every coverage interval contains 0.95 and no estimate is more than 5 % off "
              f"with an interval that excludes the truth. **{'Met' if met else 'Not met'}.** Run time "
              f"{seconds:.0f} s for {seeds} seeds at {len(SETTINGS)} settings.", "",
              "The last column counts the seeds whose estimate is more than 5 % off and whose interval misses the "
              "truth; for a parameter whose scatter is itself a few per cent of its value (gamma = 0.08 s/m and "
              "e_t = 0.3 at 0.03 m/s) every missed interval is more than 5 % off, so the column there counts the "
              "ordinary misses of a 95 % interval, not estimates far outside theirs.", ""]
    return lines, met


def relative_error(predicted: np.ndarray, true: np.ndarray) -> np.ndarray:
    """``|p_pred - p_true| / |p_true|`` per impact; rows ``(p_t, p_n)``."""
    return np.linalg.norm(predicted - true, axis=1) / np.linalg.norm(true, axis=1)


def run(folder: Path, splits: int) -> dict:
    path = folder / FILE
    impacts = read_impacts(path, require="impulse")
    published = pd.read_csv(path, usecols=[f"{p}_impulse_{c}" for p in PUBLISHED for c in ("t", "n")])
    n = len(impacts)
    rows, fits = [], []
    started = time.perf_counter()
    for seed in range(splits):
        order = np.random.default_rng(seed).permutation(n)
        train, test = np.sort(order[: n // 2]), np.sort(order[n // 2:])
        fit = fit_planar(impacts.subset(train), MCUBE_ELLIPSE, profiles=False)
        held = impacts.subset(test)
        predicted = predict_planar(fit.law, fit.values, MCUBE_ELLIPSE, held.pre_impact())
        p = predicted[["predicted_impulse_t", "predicted_impulse_n"]].to_numpy()
        row = {"seed": seed, "law": fit.law.name, "impactid": float(np.median(relative_error(p, held.impulse)))}
        for prefix in PUBLISHED:
            q = published[[f"{prefix}_impulse_t", f"{prefix}_impulse_n"]].to_numpy()[test]
            row[prefix] = float(np.median(relative_error(q, held.impulse)))
        rows.append(row)
        fits.append({"seed": seed, "law": fit.law.name, **{name: (p.value, p.stderr, p.interval)
                                                           for name, p in fit.params.items()}})
        print(f"split {seed:2d}: {fit.law.name:<22} impactid {row['impactid']:.4f}   best published "
              f"{min(row[k] for k in PUBLISHED):.4f}", flush=True)
    table = pd.DataFrame(rows)
    whole = {prefix: float(np.median(relative_error(published[[f"{prefix}_impulse_t", f"{prefix}_impulse_n"]]
                                                     .to_numpy(), impacts.impulse))) for prefix in PUBLISHED}
    full = fit_planar(impacts, MCUBE_ELLIPSE)
    return {"table": table, "fits": fits, "whole": whole, "full": full, "n": n,
            "seconds": time.perf_counter() - started}


def _fmt(value: float, spec: str = ".4f") -> str:
    return format(value, spec) if np.isfinite(value) else "undetermined"


def page(result: dict, splits: int, synthetic: list[str] | None = None) -> str:
    table, fits, full = result["table"], result["fits"], result["full"]
    ours = float(table["impactid"].median())
    theirs = {prefix: float(table[prefix].median()) for prefix in PUBLISHED}
    best = min(theirs, key=theirs.get)
    met = all(ours < v for v in theirs.values())
    lines = ["# Validation: planar impacts of a rigid body (real motion-capture data)", "",
             "Written by `python benchmarks/validate_planar_impacts.py --write` (the data are read from the folder "
             "given by `--data` or `IMPACTID_REALDATA_PLANAR`; they are not in the repository). Method and laws: "
             "[planar impacts](planar_impacts.md).", "",
             f"**Data.** {result['n']} impacts of an ellipse (36.4 g, radius of gyration 19.2 mm) dropped on a flat "
             "surface and tracked by motion capture at 250 Hz (Fazeli, Donlon, Drumwright & Rodriguez 2017): "
             "pre- and post-impact states, contact Jacobian, the authors' \"true\" impulse, and the impulses of six "
             "published rigid-contact models fitted by the authors.", "",
             f"**Protocol.** {splits} random half splits (`numpy.random.default_rng(seed).permutation`, seeds "
             f"0-{splits - 1}). impactid fits its eight laws to the training half's measured impulses and selects "
             "one by BIC; the selected law predicts the test half from the pre-impact states and contact "
             "Jacobians alone. Score: the median over the test impacts of the relative impulse error "
             "|p_pred - p_true| / |p_true|; the published models' impulses are scored on the same test halves. "
             "The statistic is the median of the per-split medians.", "",
             "## Result", "",
             "| model | median over splits | min | max | median over all impacts (published, as fitted by the "
             "authors) |", "|---|---|---|---|---|",
             f"| **impactid** (fitted on the other half) | **{_fmt(ours)}** | {_fmt(table['impactid'].min())} | "
             f"{_fmt(table['impactid'].max())} | - |"]
    for prefix, name in PUBLISHED.items():
        lines.append(f"| {name} | {_fmt(theirs[prefix])} | {_fmt(table[prefix].min())} | {_fmt(table[prefix].max())} "
                     f"| {_fmt(result['whole'][prefix])} |")
    wins = int(np.sum(table["impactid"] < table[list(PUBLISHED)].min(axis=1)))
    lines += ["", f"Target (issue 29): impactid's median below every published model's. **{'Met' if met else 'Not met'}"
              f"**: {_fmt(ours)} against {_fmt(theirs[best])} for the best published model ({PUBLISHED[best]}); "
              f"impactid is below the best published model on {wins} of {splits} splits.", "",
              "## Per split", "", "| seed | selected law | impactid | " + " | ".join(PUBLISHED.values()) + " |",
              "|---|---|---|" + "---|" * len(PUBLISHED)]
    for _, row in table.iterrows():
        lines.append(f"| {int(row['seed'])} | {row['law']} | {_fmt(row['impactid'])} | "
                     + " | ".join(_fmt(row[p]) for p in PUBLISHED) + " |")
    lines += ["", "## Fitted parameters", "",
              "Per split, the selected law's parameters (value +/- standard error) on the training half:", "",
              "| seed | law | parameters |", "|---|---|---|"]
    for f in fits:
        text = "; ".join(f"{k} = {_fmt(v[0], '.4g')} +/- {_fmt(v[1], '.2g')}" for k, v in f.items()
                         if k not in ("seed", "law"))
        lines.append(f"| {f['seed']} | {f['law']} | {text} |")
    lines += ["", f"On all {result['n']} impacts (`impactid planar fit` with `--body mcube-ellipse`): law "
              f"`{full.law.name}` ({full.details.get('selection', '')}), model check "
              f"*{full.model_check.get('verdict')}*:", "",
              "| parameter | value | std. error | 95 % interval | note |", "|---|---|---|---|---|"]
    for p in full.params.values():
        lines.append(f"| {p.name} | {_fmt(p.value, '.4g')} | {_fmt(p.stderr, '.2g')} | "
                     f"[{_fmt(p.interval[0], '.4g')}, {_fmt(p.interval[1], '.4g')}] {p.unit} | {p.note} |")
    comparison = full.tables["laws"]
    lines += ["", "The eight laws on all impacts (RSS of the relative impulse residuals; AIC and BIC as "
              "`impactid.engine.compare_models` defines them):", "",
              "| law | fitted parameters | RSS | delta AIC | delta BIC | median error (fitted impacts) |",
              "|---|---|---|---|---|---|"]
    for _, row in comparison.iterrows():
        lines.append(f"| {row['law']} | {row['n_params']} | {row['rss']:.4g} | {row['delta_aic']:.1f} | "
                     f"{row['delta_bic']:.1f} | {_fmt(row['median_relative_impulse_error'])} |")
    lines += ["", "## Reading the result", "",
              "* Newton's restitution of the normal velocity with Coulomb friction and sticking predicts the "
              "impulses better than the impulse-space law of Chatterjee & Ruina (1998) on these data, and a "
              "restitution falling with the approach speed, e = e0 (1 - gamma u), is preferred by BIC and by the "
              "likelihood-ratio test over a constant one.",
              "* The tangential restitution e_t sits on its lower bound, -1 (the sticking impulse then leaves the "
              "contact's tangential velocity unchanged rather than stopping it). The file's \"true\" tangential "
              "impulse is positive for most impacts although the contact point slides in +x before every impact "
              "(v_t > 0 in all rows), and it has the opposite sign of the change of x-momentum it should explain "
              "(it agrees with the change of angular momentum instead): with the file's Jacobian and mass matrix the "
              "\"true\" impulses are not those of a rigid body with friction opposing sliding. A law that lets e_t "
              "go below -1 (a tangential velocity that grows, unphysical) fits them better still (a median of 0.061 "
              "over the same 20 splits in a development run with e_t searched in [-3, 1], not repeated by this "
              "script); impactid keeps the physical range and reports the bound.",
              "* The model check finds the residual structured: the mean relative residuals of the tangential and "
              "the normal component differ beyond their scatter (the tangential impulse is not fully explained). "
              "The intervals are clustered by impact (each impact's own residual scatter, "
              "[planar impacts](planar_impacts.md#uncertainty)); with e_t on a bound, the identifiability block does "
              "not report the parameters as determined.",
              "* The post-impact velocities predicted from the same impulses differ from the measured ones by a "
              "median of about 55 % in the kinetic-energy norm (mostly the spin), for the same reason: the file's "
              "impulses do not reproduce its velocity changes.", "",
              f"Run time: {result['seconds']:.0f} s for {splits} splits and the fit of all impacts.", ""]
    lines += synthetic or []
    return "\n".join(lines).rstrip() + "\n", met


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", default=os.environ.get("IMPACTID_REALDATA_PLANAR"),
                        help="folder holding mcube_ellipse.csv (default: $IMPACTID_REALDATA_PLANAR)")
    parser.add_argument("--splits", type=int, default=20)
    parser.add_argument("--seeds", type=int, default=200,
                        help="noise seeds of the synthetic coverage section per setting (0: skip it)")
    parser.add_argument("--write", action="store_true", help=f"write {PAGE.relative_to(ROOT)}")
    args = parser.parse_args(argv)
    if not args.data or not (Path(args.data) / FILE).is_file():
        parser.error(f"no {FILE}: give --data FOLDER or set IMPACTID_REALDATA_PLANAR")
    synthetic, covered = None, True
    if args.seeds > 0:
        started = time.perf_counter()
        cover = coverage(args.seeds)
        synthetic, covered = coverage_lines(cover, time.perf_counter() - started)
        print("\n".join(synthetic))
    result = run(Path(args.data), args.splits)
    text, met = page(result, args.splits, synthetic)
    table = result["table"]
    print(f"median over {args.splits} splits: impactid {table['impactid'].median():.4f}; "
          + ", ".join(f"{PUBLISHED[p]} {table[p].median():.4f}" for p in PUBLISHED))
    if args.write:
        PAGE.write_text(text, encoding="utf-8")
        print(f"written {PAGE}")
    return 0 if met and covered else 1


if __name__ == "__main__":
    sys.exit(main())

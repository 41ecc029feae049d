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

Run: ``python benchmarks/validate_planar_impacts.py [--data FOLDER] [--splits 20] [--write]``
(about a minute on one core); ``--write`` writes ``docs/validation_planar_impacts.md``. Exits 1 when
impactid's statistic is not below every published model's.
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

from impactid.rigs.planar import MCUBE_ELLIPSE, fit_planar, predict_planar, read_impacts  # noqa: E402

FILE = "mcube_ellipse.csv"
#: The published models of the file: column prefix -> name.
PUBLISHED = {"drumwright_shell": "Drumwright-Shell", "ap_poisson": "Anitescu-Potra (Poisson)",
             "ap_newton": "Anitescu-Potra (Newton)", "mirtich": "Mirtich", "wang_mason": "Wang-Mason",
             "whittaker": "Whittaker"}
PAGE = ROOT / "docs" / "validation_planar_impacts.md"


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


def page(result: dict, splits: int) -> str:
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
              "The intervals are those of the least-squares fit with the residual scatter as noise; with e_t on a "
              "bound, the identifiability block does not report the parameters as determined.",
              "* The post-impact velocities predicted from the same impulses differ from the measured ones by a "
              "median of about 55 % in the kinetic-energy norm (mostly the spin), for the same reason: the file's "
              "impulses do not reproduce its velocity changes.", "",
              f"Run time: {result['seconds']:.0f} s for {splits} splits and the fit of all impacts."]
    return "\n".join(lines) + "\n", met


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", default=os.environ.get("IMPACTID_REALDATA_PLANAR"),
                        help="folder holding mcube_ellipse.csv (default: $IMPACTID_REALDATA_PLANAR)")
    parser.add_argument("--splits", type=int, default=20)
    parser.add_argument("--write", action="store_true", help=f"write {PAGE.relative_to(ROOT)}")
    args = parser.parse_args(argv)
    if not args.data or not (Path(args.data) / FILE).is_file():
        parser.error(f"no {FILE}: give --data FOLDER or set IMPACTID_REALDATA_PLANAR")
    result = run(Path(args.data), args.splits)
    text, met = page(result, args.splits)
    table = result["table"]
    print(f"median over {args.splits} splits: impactid {table['impactid'].median():.4f}; "
          + ", ".join(f"{PUBLISHED[p]} {table[p].median():.4f}" for p in PUBLISHED))
    if args.write:
        PAGE.write_text(text, encoding="utf-8")
        print(f"written {PAGE}")
    return 0 if met else 1


if __name__ == "__main__":
    sys.exit(main())

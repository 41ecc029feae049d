"""Validate the estimators across rig P's envelope; writes docs/validation_envelope.md.

    python benchmarks/validate_envelope.py [--part period-1|general|misspecified|all] [--hc 60] [--s3 15]
        [--seed 2026] [--out docs/validation_envelope.md] [--cases PATH] [--only ID [ID ...]] [--limit K]
        [--fresh] [--redraw] [--no-joint] [--workers N | --scheduler ADDRESS]

Three parts (``--part``, default all of them):

*period-1*: cases drawn with a fixed seed across the region where impactid's own regime classification finds
period-1 motion for each case's law (e/r_c 0.05-0.30, beta 5e9-1e11 N s m^-(n+1) log-uniform, n 1.2-1.8;
friction mu 0 or 0.2; noise 0-1 %; 51.2/102.4/204.8 kHz; 16-24 bit ADC; accelerometer offset and drift), plus
restitution (S3) cases with gamma 0.3-1.2 s/m. A third of the recordings are made by the independent SciPy
reference model of ``tests/rigs/pivoted/reference_recordings.py``. For each case the n-fixed fit, a joint fit
with a second period-1 point whose approach speed differs by at least 30 %, and the restitution fit are run
through :func:`impactid.pipeline.estimate` (:func:`tests.envelope.run_case`).

*general*: the general-motion cases of ``benchmarks/envelope_case.py`` (``GENERAL_CASES``: near-plastic,
period-k, slow with noise, slow noise-free, riding, irregular; a third by the reference model), each with the
n-fixed fit at the true n (:func:`benchmarks.envelope_case.run_general_case`, as ``envelope_case.py --class``
runs it).

*misspecified*: recordings estimated with a model other than the one that made them
(``MISSPECIFIED_CASES`` of ``benchmarks/envelope_case.py``): restitution-law recordings fitted with
Hunt-Crossley (n fixed at 1.5, and a joint fit over two points), and recordings estimated with a rig whose one
constant is off by 20-50 % (:func:`benchmarks.envelope_case.run_misspecified_case`). They are scored by
whether the fit carries the model check's warning (a verdict other than consistent, or a refusal with its
reason) and whether it reports beta and n as separable.

The page reports, per class, how many fits ended in an estimate, a refusal (with its reason) or an error, the
error distribution, the coverage of the reported intervals, the confident wrong answers (more than 5 % off
with an interval that excludes the truth) and the targets met or missed; the targets are printed at the end.

The drawn period-1 cases are cached next to the output (``validation_envelope_cases.json``, or ``--cases``)
so that a rerun validates the same cases; ``--redraw`` draws them again. Every finished case is appended to
``validation_envelope_rows.jsonl`` next to the output, so an interrupted run resumes where it stopped (a row is
reused for the same case and options; after a change to the estimator, run with ``--fresh``, which for a whole
run, all parts and no selection, moves the earlier rows to ``validation_envelope_rows.jsonl.bak`` so that resuming
it without ``--fresh`` reuses only its own rows). Per-fit results
go to ``validation_envelope.csv``. ``--only`` and ``--limit`` select cases (smoke runs; the page then covers
the selection). With ``--workers N`` (a local dask cluster) or ``--scheduler ADDRESS`` (an existing one) the
cases run on the cluster's workers (:mod:`impactid.distributed`): the task
(:func:`benchmarks.envelope_case.run_task`) is pickled by reference, so the workers must import this
repository's ``tests`` and ``benchmarks`` packages (a local cluster inherits this process's ``sys.path``; the
workers of an existing one need the repository root on theirs). ``benchmarks/envelope_notes.md``
(hand-written: the analysis of the misses) is included in the page.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import platform
import subprocess
import sys
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks import envelope_case as G  # noqa: E402
from impactid.distributed import add_scheduler_arguments, iter_tasks, scheduler_client  # noqa: E402
from tests import envelope as E  # noqa: E402

TARGETS = {
    "errors": "0 tracebacks and 0 unexplained errors",
    "confident": "zero confident wrong answers: no estimate more than 5 % off with a 95 % interval that excludes "
                 "the truth, in any class",
    "n_fixed": "n fixed, noise-free: beta within 1 % in at least 95 % of cases (riding excluded)",
    "n_fixed_classes": "n fixed, noise-free, per class (riding, S3 and misspecified excluded, and irregular motion, "
                       "refused by design): beta within 1 % in "
                       "at least 95 % of the cases estimated, and no more than 10 % refused (a fit that reports its "
                       "parameters as not determined, its model check finding that the law does not describe the "
                       "data or beta's interval reaching more than ten times away from the estimate, counts as "
                       "refused: it gives no value it stands by)",
    "coverage": "noisy: interval coverage at least 90 %",
    "joint": "joint over two points, noise-free: beta within 5 % and n within 0.02 in at least 90 % of pairs (of two "
             "usable recordings); a pair with one unusable recording gives the other's fit, says so and is not "
             "reported separable",
    "gamma": "S3: gamma within 2 % in the period-1 cases",
    "misspecified": "every misspecified fit carries the model-check warning (or a refusal with its reason), and "
                    "none is reported as separable",
}
#: Parts whose targets each target is measured on (a target of a part not run is not printed).
TARGET_PARTS = {"errors": None, "confident": None, "n_fixed": "period-1", "n_fixed_classes": None,
                "coverage": "period-1", "joint": "period-1", "gamma": "period-1", "misspecified": "misspecified"}
#: The period-1 class each period-1 target is measured on.
TARGET_CLASS = {"n_fixed": "noise-free", "coverage": "noisy", "joint": "noise-free", "gamma": "S3"}
#: The noise-free classes of the per-class n-fixed target (riding and irregular: refusals by design, as the
#: cases of other classes whose follower rides the cam (:data:`RIDING`); S3: not Hunt-Crossley).
NOISE_FREE_CLASSES = ("noise-free", "friction", "low-rate", "near-plastic", "period-k", "slow-noise-free")
#: The refusal reason of a follower that rides the cam: such a case is a riding case whatever its class.
RIDING = "rides the cam"


def _flatten(rows: list[dict]) -> pd.DataFrame:
    flat = []
    for row in rows:
        base = {k: v for k, v in row.items() if k != "outcomes"}
        for o in row["outcomes"] or [{"fit": "generation", "status": "skipped", "reason": row["generation"],
                                      "values": {}, "seconds": 0.0}]:
            flat.append({**base, "fit": o["fit"], "status": o["status"], "reason": o["reason"].replace("\n", " "),
                         "seconds": o["seconds"], **o["values"]})
    return pd.DataFrame(flat)


def _share(mask: pd.Series) -> str:
    return f"{int(mask.sum())}/{len(mask)} ({100 * mask.mean():.0f} %)" if len(mask) else "-"


def _pct(values, q) -> str:
    values = np.abs(np.asarray(values, dtype=float))
    values = values[np.isfinite(values)]
    return f"{np.percentile(values, q):.2g}" if values.size else "-"


def summarise(frame: pd.DataFrame) -> tuple[list[str], dict[str, bool], dict[str, str]]:
    """The period-1 part of the page: the misses, refusals, errors and per-class tables; the targets met and
    their measured values."""
    lines: list[str] = []
    met: dict[str, bool] = {}
    lines += ["## Outcomes per class", "",
              "| class | fit | cases | estimate | refusal | error |", "|---|---|---|---|---|---|"]
    for klass in E.CLASSES:
        for fit in ("n-fixed", "joint", "restitution"):
            part = frame[(frame["klass"] == klass) & (frame["fit"] == fit)]
            if part.empty:
                continue
            counts = part["status"].value_counts()
            lines.append(f"| {klass} | {fit} | {len(part)} | {counts.get('estimate', 0)} | {counts.get('refusal', 0)} "
                         f"| {counts.get('error', 0)} |")
    errors = frame[frame["status"] == "error"]
    met["errors"] = errors.empty
    lines += ["", "## Error distribution and interval coverage", "",
              "Relative errors of beta and gamma, absolute errors of n; the 50th/90th percentile and maximum of "
              "|error| over the estimates of each class; coverage is the share of reported intervals that contain "
              "the truth.", "",
              "| class | fit | quantity | estimates | median abs err | 90th pct | max | coverage |",
              "|---|---|---|---|---|---|---|---|"]
    for klass in E.CLASSES:
        for fit, quantities in (("n-fixed", ("beta",)), ("joint", ("beta", "n")), ("restitution", ("gamma",))):
            part = frame[(frame["klass"] == klass) & (frame["fit"] == fit) & (frame["status"] == "estimate")]
            for q in quantities:
                err = f"{q}_error"
                if part.empty or err not in part or part[err].isna().all():
                    continue
                cov = part[f"{q}_covered"].dropna().astype(bool) if f"{q}_covered" in part else pd.Series([], bool)
                lines.append(f"| {klass} | {fit} | {q} | {part[err].notna().sum()} | {_pct(part[err], 50)} | "
                             f"{_pct(part[err], 90)} | {_pct(part[err], 100)} | {_share(cov)} |")
    # targets (a column no case filled, e.g. no S3 case finished yet, counts as not met)
    for column in ("beta_error", "n_error", "gamma_error", "beta_covered", "n_covered"):
        if column not in frame:
            frame[column] = math.nan
    nf = frame[(frame["klass"] == "noise-free") & (frame["fit"] == "n-fixed")]
    nf = nf[~((nf["status"] == "refusal") & nf["reason"].astype(str).str.contains(RIDING))]
    ok = (nf["status"] == "estimate") & (nf["beta_error"].abs() <= 0.01)
    met["n_fixed"] = bool(len(nf) and ok.mean() >= 0.95)
    noisy = frame[(frame["klass"] == "noisy") & (frame["status"] == "estimate") & frame["fit"].isin(["n-fixed",
                                                                                                      "joint"])]
    # the intervals reported: a withheld one (the model check rejects the law: NaN) excludes nothing and is
    # counted apart, as a refusal of an interval
    covered, withheld = [], 0
    for _, row in noisy.iterrows():
        for q in ("beta", "n") if row["fit"] == "joint" else ("beta",):
            if math.isfinite(row.get(f"{q}_lo", math.nan)) and math.isfinite(row.get(f"{q}_hi", math.nan)):
                covered.append(bool(row[f"{q}_covered"]))
            else:
                withheld += 1
    cov_share = float(np.mean(covered)) if covered else math.nan
    met["coverage"] = bool(covered and cov_share >= 0.90)
    jt = frame[(frame["klass"] == "noise-free") & (frame["fit"] == "joint")]
    # a pair one of whose recordings cannot be used (its follower rides the cam) is the other clause: the
    # fit of the usable recording, a note naming the one left out, and no claim that one point separates beta, n
    left = (jt["left_out"].astype("boolean").fillna(False).astype(bool) if "left_out" in jt
            else pd.Series(False, index=jt.index))
    both, partial = jt[~left], jt[left]
    jok_both = (both["status"] == "estimate") & (both["beta_error"].abs() <= 0.05) & (both["n_error"].abs() <= 0.02)
    jok_partial = (partial["status"] == "estimate") & ~partial["separable"].astype("boolean").fillna(False).astype(bool)
    jok = pd.concat([jok_both, jok_partial]).reindex(jt.index)
    jok_all = (jt["status"] == "estimate") & (jt["beta_error"].abs() <= 0.05) & (jt["n_error"].abs() <= 0.02)
    met["joint"] = bool(len(both) and jok_both.mean() >= 0.90 and jok_partial.all())
    s3 = frame[(frame["klass"] == "S3") & (frame["fit"] == "restitution")]
    gok = (s3["status"] == "estimate") & (s3["gamma_error"].abs() <= 0.02)
    met["gamma"] = bool(len(s3) and gok.all())
    measured = {
        "errors": f"{len(errors)} errors",
        "n_fixed": f"{_share(ok)} within 1 %",
        "coverage": f"{sum(covered)}/{len(covered)} reported intervals ({100 * cov_share:.0f} %) contain the truth "
                    f"({withheld} withheld by the model check)",
        "joint": f"{_share(jok_both)} of the pairs of two usable recordings within 5 % and 0.02; "
                 f"{len(partial)} pair(s) with one recording left out: {_share(jok_partial)} give the other's fit with "
                 f"the note and not separable (counting those as misses: {_share(jok_all)} of all pairs)",
        "gamma": f"{_share(gok)} within 2 %",
    }
    head: list[str] = []
    misses = []
    for label, part, good in (("n-fixed noise-free", nf, ok), ("joint noise-free", jt, jok), ("S3", s3, gok)):
        for _, row in part[~good].iterrows():
            detail = row["reason"][:160] if row["status"] != "estimate" else (
                f"beta error {row.get('beta_error', math.nan):+.3g}" + (
                    f", n error {row.get('n_error', math.nan):+.3g}" if label.startswith("joint") else "")
                if not label.startswith("S3") else f"gamma error {row.get('gamma_error', math.nan):+.3g}")
            misses.append(f"| {row['id']} | {label} | {row['generator']} | {row['e_over_rc']:.3g} | "
                          f"{row['cam_speed_hz']:.3g} | {row['status']} | {detail} |")
    if misses:
        head += ["", "Cases that miss an accuracy target (the analysis of each is in the notes below):", "",
                 "| case | target | generator | e/r_c | Hz | outcome | detail |", "|---|---|---|---|---|---|---|"]
        head += misses
    refusals = frame[frame["status"] == "refusal"]
    if not refusals.empty:
        head += ["", "Refusals (the tool declined to answer, with its reason):", "", "| case | class | fit | reason |",
                 "|---|---|---|---|"]
        head += [f"| {r['id']} | {r['klass']} | {r['fit']} | {r['reason'][:200]} |" for _, r in refusals.iterrows()]
    if not errors.empty:
        head += ["", "Errors (tracebacks; each is a bug):", ""]
        head += [f"- {r['id']} {r['fit']}: `{r['reason'][-300:]}`" for _, r in errors.iterrows()]
    return head + [""] + lines, met, measured


def confident_wrong(frame: pd.DataFrame) -> pd.Series:
    """Per fit of the flattened rows: an estimate more than 5 % off the truth (relative) whose 95 % interval
    excludes it; on ``beta`` (n-fixed and joint fits), ``n`` (joint) and ``gamma`` (restitution fits with a
    truth). The truth is recovered from the stored errors; a withheld (NaN) interval excludes nothing."""
    def col(name):
        return frame[name].astype(float) if name in frame else pd.Series(math.nan, index=frame.index)

    est = frame["status"] == "estimate"
    beta, err, lo, hi = col("beta"), col("beta_error"), col("beta_lo"), col("beta_hi")
    truth = beta / (1.0 + err)
    wrong = (err.abs() > G.CONFIDENT_WRONG) & ((lo > truth) | (hi < truth))
    n, n_err, n_lo, n_hi = col("n"), col("n_error"), col("n_lo"), col("n_hi")
    n_truth = n - n_err
    joint = frame["fit"] == "joint"
    wrong |= joint & ((n_err / n_truth).abs() > G.CONFIDENT_WRONG) & ((n_lo > n_truth) | (n_hi < n_truth))
    gamma, g_err, g_se = col("gamma"), col("gamma_error"), col("gamma_stderr")
    g_truth = gamma / (1.0 + g_err)
    wrong |= (frame["fit"] == "restitution") & (g_err.abs() > G.CONFIDENT_WRONG) & (
        (gamma - g_truth).abs() > 1.96 * g_se)
    return (est & wrong.fillna(False)).astype(bool)


def summarise_general(frame: pd.DataFrame) -> list[str]:
    """The page's section on the general-motion classes (n-fixed fits at the true n)."""
    lines = ["## General motion", "",
             "The n-fixed fit (at the true n) of each general-motion case; errors and coverage over the estimates; "
             "*confident wrong*: more than 5 % off with an interval that excludes the truth.", "",
             "*Settling*: impactid's simulator settles each case again from the static equilibrium and from ten "
             "starts 1e-13 to 1e-9 rad away from it; *sensitive*: some start (a difference of rounding, not of the "
             "experiment) settles to another motion in the recorded second (impacts per revolution, or median "
             "approach speed beyond 1 %: coexisting motions with a chaotic transient between them, or irregular "
             "motion), so that another machine, compiler or kernel build may record another motion for that case; "
             "the motions found, with how many starts gave each. *robust*: all starts agree (a sample, not a "
             "proof). On one machine every recording is the same in any process, worker or order "
             "(benchmarks/envelope_case.py, `settling_check`).", "",
             "| class | cases | estimate | refusal | error | not recorded | within 1 % | within 5 % | covered | "
             "median abs err | max abs err | confident wrong | sensitive settling |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for klass in G.GENERAL_CLASSES:
        part = frame[frame["klass"] == klass]
        if part.empty:
            continue
        fits = part[part["fit"] == "n-fixed"]
        est = fits[fits["status"] == "estimate"]
        err = est["beta_error"].astype(float) if "beta_error" in est else pd.Series([], dtype=float)
        cov = est["beta_covered"].astype(bool) if "beta_covered" in est else pd.Series([], dtype=bool)
        counts = fits["status"].value_counts()
        lines.append(f"| {klass} | {part['id'].nunique()} | {counts.get('estimate', 0)} | {counts.get('refusal', 0)} "
                     f"| {counts.get('error', 0)} | {int((part['fit'] == 'generation').sum())} | "
                     f"{_share(err.abs() <= 0.01)} | {_share(err.abs() <= 0.05)} | {_share(cov)} | {_pct(err, 50)} | "
                     f"{_pct(err, 100)} | {int(part['confident_wrong'].sum())} | {_sensitive(part)} |")
    lines += ["", "Per case (true motion from the recording's truth: impacts per revolution, median restitution, "
              "approach speed and contact time):", "",
              "| case | class | generator | e/r_c | Hz | n | impacts/rev | xi | v_a m/s | contact ms | settling | "
              "outcome | beta error | interval (rel.) | verdict | confident wrong |",
              "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for _, r in frame.iterrows():
        if r["status"] == "estimate":
            outcome, error, interval = "estimate", f"{100 * r['beta_error']:+.2f} %", _interval(r)
        else:
            outcome, error, interval = f"{r['status']}: {str(r['reason'])[:140]}", "-", "-"
        lines.append(f"| {r['id']} | {r['klass']} | {r['generator']} | {r['e_over_rc']:.3g} | {r['cam_speed_hz']:.3g} "
                     f"| {r['n']:.3g} | {_num(r, 'impacts_per_revolution')} | {_num(r, 'xi')} | {_num(r, 'v_a')} | "
                     f"{_num(r, 'contact_ms')} | {_settling(r)} | {outcome} | {error} | {interval} | "
                     f"{_text(r, 'verdict')} | "
                     f"{'**yes**' if r['confident_wrong'] else 'no'} |")
    return lines


def _sensitive(part: pd.DataFrame) -> str:
    """How many cases of a class settle to a motion that depends on round-off, ``-`` for rows without the check."""
    if "settling" not in part:
        return "-"
    settling = part.drop_duplicates("id")["settling"]
    checked = settling.isin(("robust", "sensitive"))
    return f"{int((settling == 'sensitive').sum())}/{int(checked.sum())}" if checked.any() else "-"


def _settling(row) -> str:
    """A case's settling (:func:`benchmarks.envelope_case.settling_check`): robust, or sensitive with the motion
    (impacts per revolution at the median approach speed) each start settled to."""
    value = _text(row, "settling")
    return f"**sensitive**: {_text(row, 'settled_motions')}" if value == "sensitive" else value


def _interval(row) -> str:
    """The interval of ``beta`` relative to the truth, or why there is none."""
    truth = row["beta"] / (1.0 + row["beta_error"])
    lo, hi = row["beta_lo"] / truth - 1.0, row["beta_hi"] / truth - 1.0
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return "withheld"
    return f"[{100 * lo:+.1f}, {100 * hi:+.1f}] %"


def _names_model(reason) -> bool:
    """Whether a refusal's reason names the model or the rig as the cause (its wording)."""
    text = str(reason).lower()
    return any(word in text for word in ("rig", "model", "constant"))


def _text(row, key: str) -> str:
    """A text column of a flattened row, ``-`` where it is missing."""
    value = row.get(key, None)
    return "-" if value is None or (isinstance(value, float) and math.isnan(value)) else str(value)


def _num(row, key: str, fmt: str = ".3g") -> str:
    value = row.get(key, math.nan)
    try:
        return format(float(value), fmt) if math.isfinite(float(value)) else "-"
    except (TypeError, ValueError):
        return "-"


def misspecified_warned(frame: pd.DataFrame) -> pd.DataFrame:
    """The damping fits (n-fixed, joint) of the misspecified rows with ``warned`` (the model check's warning, or
    a refusal with its reason) and ``separable_reported`` (a joint estimate reported separable)."""
    fits = frame[frame["fit"].isin(["n-fixed", "joint"])].copy()
    warned = fits["warned"] if "warned" in fits else pd.Series(False, index=fits.index)
    fits["warned_any"] = (fits["status"] == "refusal") | ((fits["status"] == "estimate") & warned.fillna(False)
                                                          .astype(bool))
    separable = fits["separable"] if "separable" in fits else pd.Series(None, index=fits.index)
    fits["separable_reported"] = (fits["status"] == "estimate") & (fits["fit"] == "joint") & (separable == True)  # noqa: E712
    return fits


def summarise_misspecified(frame: pd.DataFrame) -> list[str]:
    """The page's section on the misspecified cases."""
    fits = misspecified_warned(frame)
    lines = ["## Misspecified models", "",
             "Each damping fit of a recording estimated with a model other than the one that made it. *warned*: "
             "the model check's verdict is not consistent (or the fit is refused with its reason; whether the "
             "reason's wording names the model or the rig is noted); the beta of a "
             "restitution-law recording is scored against the law's Hunt-Crossley equivalent 1.5 gamma k_H at "
             "n = 1.5 (a reference, not a truth: the law is not Hunt-Crossley).", "",
             "| case | kind | generator | misspecification | e/r_c, Hz | fit | outcome | verdict (action) | warned | "
             "separable | beta error | interval (rel.) | confident wrong |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for idx, r in frame[frame["fit"] != "restitution"].iterrows():
        what = (f"{r['constant']} x {r['scale']:g}" if r["kind"] == "rig-constant"
                else f"restitution law, gamma {r['gamma']:.3g} s/m")
        point = f"{r['e_over_rc']:.3g}, {r['cam_speed_hz']:.3g}" + (
            f" + {r['pair_e_over_rc']:.3g}, {r['pair_cam_speed_hz']:.3g}" if r["fit"] == "joint" else "")
        if r["status"] == "estimate":
            outcome, error, interval = "estimate", f"{100 * r['beta_error']:+.2f} %", _interval(r)
            if r["fit"] == "joint":
                error += f", n {r['n']:.3g}"
            verdict = f"{_text(r, 'verdict')} ({_text(r, 'action')})"
        else:
            outcome, error, interval = f"{r['status']}: {str(r['reason'])[:160]}", "-", "-"
            verdict = "-" if r["status"] != "refusal" else ("- (the reason names the model or rig)" if _names_model(
                r["reason"]) else "- (the reason does not name the model or rig)")
        warned = "-" if idx not in fits.index else ("yes" if fits.loc[idx, "warned_any"] else "**no**")
        sep = "-" if r["fit"] != "joint" or r["status"] != "estimate" else str(r.get("separable"))
        lines.append(f"| {r['id']} | {r['kind']} | {r['generator']} | {what} | {point} | {r['fit']} | {outcome} | "
                     f"{verdict} | {warned} | {sep} | {error} | {interval} | "
                     f"{'**yes**' if r['confident_wrong'] else 'no'} |")
    rest = frame[(frame["fit"] == "restitution") & (frame["status"] == "estimate")]
    if not rest.empty and "gamma_error" in rest:
        lines += ["", "The restitution fit of the same recordings (the law that made them): gamma error "
                  + ", ".join(f"{r['id']} {100 * r['gamma_error']:+.2f} %" for _, r in rest.iterrows()) + "."]
    return lines


def targets_all(frames: dict[str, pd.DataFrame], met: dict[str, bool]) -> tuple[list[str], dict[str, str]]:
    """The targets over every part run: confident wrong answers, the per-class n-fixed target, the misspecified
    target and the errors; updates ``met`` and returns the per-class table and the measured values."""
    measured: dict[str, str] = {}
    everything = pd.concat([f for f in frames.values() if not f.empty], ignore_index=True) if frames else \
        pd.DataFrame()
    errors = everything[everything["status"] == "error"] if not everything.empty else everything
    met["errors"] = errors.empty
    measured["errors"] = f"{len(errors)} errors"
    wrong = everything[everything["confident_wrong"]] if not everything.empty else everything
    scored = int((everything["status"] == "estimate").sum()) if not everything.empty else 0
    met["confident"] = bool(scored) and wrong.empty
    measured["confident"] = (f"{len(wrong)} of {scored} estimates" + (
        ": " + ", ".join(f"{r['id']} {r['fit']}" for _, r in wrong.iterrows()) if len(wrong) else ""))
    lines = ["| class | cases | estimated | not determined | refused | error | within 1 % of the estimated | met |",
             "|---|---|---|---|---|---|---|---|"]
    results = []
    for klass in NOISE_FREE_CLASSES:
        part = everything[(everything["klass"] == klass) & (everything["fit"] == "n-fixed")] \
            if not everything.empty else everything
        if part.empty:
            continue
        part = part[~((part["status"] == "refusal") & part["reason"].astype(str).str.contains(RIDING))]
        if part.empty:
            continue
        fitted = part[part["status"] == "estimate"]
        # the tool's own word: a fit that does not report its parameters as determined gives no estimate
        # (a row without the field, from a run before it was recorded, counts as determined: the page says which)
        determined = (fitted["determined"].map(lambda v: not (isinstance(v, (bool, np.bool_)) and not v))
                      if "determined" in fitted else pd.Series(True, index=fitted.index))
        est, undetermined = fitted[determined], fitted[~determined]
        within = int((est["beta_error"].abs() <= 0.01).sum()) if len(est) else 0
        refused = int((part["status"] == "refusal").sum()) + len(undetermined)
        ok = bool(len(est) and within / len(est) >= 0.95 and refused / len(part) <= 0.10)
        results.append((klass, ok, within, len(est), refused, len(part)))
        lines.append(f"| {klass} | {len(part)} | {len(est)} | {len(undetermined)}"
                     + (f" ({', '.join(undetermined['id'].astype(str))})" if len(undetermined) else "")
                     + f" | {refused - len(undetermined)} | {int((part['status'] == 'error').sum())} | "
                     f"{within}/{len(est)} | {'yes' if ok else '**no**'} |")
    if results:  # (no noise-free class in the parts run: the target is not shown)
        met["n_fixed_classes"] = all(r[1] for r in results)
    measured["n_fixed_classes"] = (f"{sum(r[1] for r in results)}/{len(results)} classes; missed: "
                                   + (", ".join(f"{k} ({w}/{e} within 1 %, {rf}/{n} refused or not determined)"
                                                for k, ok, w, e, rf, n in results if not ok) or "none"))
    if "misspecified" in frames and not frames["misspecified"].empty:
        fits = misspecified_warned(frames["misspecified"])
        warned, separable = fits["warned_any"], fits["separable_reported"]
        met["misspecified"] = bool(len(fits)) and bool(warned.all()) and not bool(separable.any())
        measured["misspecified"] = (f"{int(warned.sum())}/{len(fits)} fits warned; {int(separable.sum())} reported "
                                    "separable" + ("; not warned: " + ", ".join(
                                        f"{r['id']} {r['fit']}" for _, r in fits[~warned].iterrows())
                                        if (~warned).any() else ""))
    return lines, measured


def _source_version() -> str:
    """The commit (and ``+dirty``) of the sources the rows were computed with, recorded with each row."""
    try:
        head = subprocess.run(["git", "-C", str(ROOT), "describe", "--always", "--dirty"], capture_output=True,
                              text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        head = "unknown"
    return head


def _plain(value):
    """JSON fallback for numpy scalars in the per-case rows."""
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


def _load_period1(args) -> list:
    """The drawn period-1 cases: from the cache (``--cases``, default next to the output), else drawn and cached."""
    cache = args.cases or args.out.with_name("validation_envelope_cases.json")
    if cache.exists() and not args.redraw:
        stored = json.loads(cache.read_text())
        cases = [E.Case(**{**c, "pair": tuple(c["pair"]) if c["pair"] else None}) for c in stored["cases"]]
        print(f"{len(cases)} period-1 cases from {cache}", flush=True)
        return cases
    cases = E.draw_cases(args.hc, args.s3, args.seed,
                         progress=lambda k, n: print(f"\rdrawing cases {k}/{n}", end="", flush=True))
    print(flush=True)
    cache.write_text(json.dumps({"seed": args.seed, "cases": [asdict(c) for c in cases]}, indent=1) + "\n")
    return cases


def _select(items: list[tuple[str, object]], only: list[str] | None, limit: int | None) -> list[tuple[str, object]]:
    """The ``(part, case)`` items named by ``--only``, or the first ``--limit`` of each part."""
    if only:
        known = {case.id for _, case in items}
        unknown = sorted(set(only) - known)
        if unknown:
            raise SystemExit(f"validate_envelope.py: no case {', '.join(unknown)} in the parts selected")
        items = [(p, c) for p, c in items if c.id in only]
    if limit is not None:
        kept, seen = [], {}
        for p, c in items:
            seen[p] = seen.get(p, 0) + 1
            if seen[p] <= limit:
                kept.append((p, c))
        items = kept
    return items


def _intro(parts: dict[str, list], args, versions: set[str], minutes: float | None) -> list[str]:
    cases = [c for cs in parts.values() for c in cs]
    n_ref = sum(c.generator == "reference" for c in cases)
    p1 = parts.get("period-1", [])
    general = parts.get("general", [])
    mis = parts.get("misspecified", [])
    counts = []
    if p1:
        counts.append(f"{len(p1)} period-1 cases (seed {args.seed}: {sum(c.klass != 'S3' for c in p1)} "
                      f"Hunt-Crossley cases in {len({c.klass for c in p1} - {'S3'})} classes and "
                      f"{sum(c.klass == 'S3' for c in p1)} restitution (S3) cases)")
    if general:
        counts.append(f"{len(general)} general-motion cases in {len({c.klass for c in general})} classes")
    if mis:
        counts.append(f"{len(mis)} misspecified cases")
    lines = [
        "# Validation across the envelope: period-1, general motion, misspecified models", "",
        "Generated by `python benchmarks/validate_envelope.py` "
        f"({time.strftime('%Y-%m-%d')}, {platform.machine()}, "
        + (f"{minutes:.0f} min for the cases computed in this run). " if minutes is not None else
           "written from the rows of the runs that computed them). ")
        + "; ".join(counts) + f"; {n_ref} of the {len(cases)} ({100 * n_ref / max(len(cases), 1):.0f} %) recorded by "
        "the independent SciPy reference model, the others by impactid's generator. Per-fit results: "
        f"`{args.out.with_suffix('.csv').name}`; computed at commit(s) {', '.join(sorted(versions)) or '-'}.", ""]
    if p1:
        lines += [
            "**Period-1.** How the cases are drawn: e/r_c uniform in [0.05, 0.30]; a cam speed from 6-24 Hz (0.5 Hz "
            "steps) where impactid's regime classification, for the case's own law and friction, finds period-1 "
            "motion with one impact per revolution; beta log-uniform in [5e9, 1e11] N s m^-(n+1), n uniform in "
            "[1.2, 1.8]; the joint fit's second point is another period-1 point of the same rig and law whose "
            "approach speed differs by at least 30 %. Classes (the other factors at their clean values): "
            "*noise-free* (16-24 bit ADC only), *noisy* (0.1-1 % Gaussian noise on every analogue channel, 16-24 "
            "bit ADC, accelerometer offset up to 2 m/s^2 and drift up to 0.5 m/s^2/s), *friction* (mu = 0.2, "
            "noise-free), *low-rate* (51.2 or 102.4 kHz after the anti-alias filter of the sensor chain), *S3* "
            "(restitution law, gamma uniform in [0.3, 1.2] s/m). Every recording is 1 s of the settled motion. The "
            "n-fixed fit uses the true n; nothing else of the truth reaches the estimator.", ""]
    if general:
        lines += ["**General motion** (`GENERAL_CASES` of `benchmarks/envelope_case.py`, recorded after "
                  f"{G.SETTLE_GENERAL_S:g} s of settling; the n-fixed fit at the true n): "
                  + "; ".join(f"*{k}* ({v})" for k, v in G.GENERAL_CLASSES.items()) + ".", ""]
    if mis:
        lines += ["**Misspecified models** (`MISSPECIFIED_CASES` of `benchmarks/envelope_case.py`): "
                  + "; ".join(f"*{k}* ({v})" for k, v in G.MISSPECIFIED_KINDS.items()) + ".", ""]
    return lines


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--part", choices=(*G.PARTS, "all"), default="all",
                        help="the part(s) to run: period-1, general, misspecified or all (default)")
    parser.add_argument("--hc", type=int, default=60, help="Hunt-Crossley period-1 cases when drawn (default 60)")
    parser.add_argument("--s3", type=int, default=15, help="restitution period-1 cases when drawn (default 15)")
    parser.add_argument("--seed", type=int, default=2026)
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "validation_envelope.md")
    parser.add_argument("--cases", type=Path, default=None,
                        help="the drawn period-1 cases (default validation_envelope_cases.json next to --out)")
    parser.add_argument("--only", nargs="+", metavar="ID", help="run only these cases (ids of any part)")
    parser.add_argument("--limit", type=int, metavar="K", help="run only the first K cases of each part")
    parser.add_argument("--redraw", action="store_true", help="draw the period-1 cases again (ignore the cache)")
    parser.add_argument("--fresh", action="store_true", help="recompute every case (ignore finished rows)")
    parser.add_argument("--no-joint", action="store_true", help="skip the joint fits (quick look)")
    add_scheduler_arguments(parser)  # --scheduler ADDRESS / --workers N: the cases on a dask cluster
    args = parser.parse_args(argv)
    started = time.perf_counter()
    chosen = G.PARTS if args.part == "all" else (args.part,)
    items: list[tuple[str, object]] = []
    for part in chosen:
        cases = _load_period1(args) if part == "period-1" else G.task_cases(part)
        items += [(part, c) for c in cases]
    items = _select(items, args.only, args.limit)
    # per-case rows are appended as they finish, so an interrupted run resumes where it stopped; a row
    # is reused for the same part, case and options (each row records the commit it was computed with; after a
    # change to the estimator, run with --fresh)
    done_path = args.out.with_name("validation_envelope_rows.jsonl")
    version = _source_version()
    done = {}
    whole = args.part == "all" and not (args.only or args.limit is not None)
    if done_path.exists() and (args.redraw or args.fresh) and whole:
        # a fresh full run starts a new rows file (the old one kept beside it), so that resuming it after an
        # interruption reuses only its own rows, never an earlier run's
        backup = done_path.with_suffix(".jsonl.bak")
        done_path.replace(backup)
        print(f"earlier rows moved to {backup}", flush=True)
    if done_path.exists() and not (args.redraw or args.fresh):
        for line in done_path.read_text().splitlines():
            with contextlib.suppress(ValueError, KeyError):
                entry = json.loads(line)
                if entry["joint"] == (not args.no_joint):
                    done[(entry.get("part", "period-1"), entry["case"]["id"])] = entry
    rows: list[dict | None] = [None] * len(items)
    versions = set()
    pending = []
    for k, (part, case) in enumerate(items):
        entry = done.get((part, case.id))
        if entry is not None and entry["case"] == json.loads(json.dumps(asdict(case))):
            rows[k] = entry["row"]
            versions.add(entry["source"])
            print(f"[{k + 1}/{len(items)}] {case.id}: done in an earlier run", flush=True)
        else:
            pending.append(k)
    # the cases left run here one after the other, or on the workers of --scheduler/--workers; each row
    # is appended to the rows file as soon as its case finishes, in whatever order they finish
    t0 = time.perf_counter()
    tasks = [(items[k][0], items[k][1], not args.no_joint) for k in pending]
    with scheduler_client(args, what="validate_envelope.py") as client:
        for finished, (j, row) in enumerate(iter_tasks(G.run_task, tasks, client=client), start=1):
            k = pending[j]
            part, case = items[k]
            rows[k] = row
            versions.add(version)
            with done_path.open("a") as handle:
                handle.write(json.dumps({"source": version, "part": part, "joint": not args.no_joint,
                                         "case": asdict(case), "row": row}, default=_plain) + "\n")
            brief = ", ".join(f"{o['fit']} {o['status']}" + (
                f" {100 * o['values']['beta_error']:+.2f} %" if "beta_error" in o["values"] else "") + (
                f" [{o['values']['verdict']}]" if "verdict" in o["values"] else "")
                for o in row["outcomes"]) or row["generation"]
            print(f"[{k + 1}/{len(items)}] {case.id} {case.klass} ({case.generator}): {brief} "
                  f"({finished}/{len(pending)} after {time.perf_counter() - t0:.0f} s)", flush=True)
    frames: dict[str, pd.DataFrame] = {}
    for part in chosen:
        selected = [r for (p, _), r in zip(items, rows) if p == part]
        if selected:
            frame = _flatten(selected)
            frame.insert(0, "part", part)
            frame["confident_wrong"] = confident_wrong(frame)
            frames[part] = frame
    if frames:
        pd.concat(frames.values(), ignore_index=True).to_csv(args.out.with_suffix(".csv"), index=False)
    met: dict[str, bool] = {}
    measured: dict[str, str] = {}
    body: list[str] = []
    if "period-1" in frames:
        lines, met_p1, measured_p1 = summarise(frames["period-1"])
        met.update(met_p1)
        measured.update(measured_p1)
        body += ["## Period-1 envelope"] + lines
    class_lines, measured_all = targets_all(frames, met)
    measured.update(measured_all)
    if "general" in frames:
        body += [""] + summarise_general(frames["general"])
    if "misspecified" in frames:
        body += [""] + summarise_misspecified(frames["misspecified"])
    # a target whose part or class was not run (a selection) is not shown
    p1_classes = set(frames["period-1"]["klass"]) if "period-1" in frames else set()
    shown = [k for k in TARGETS if k in met and (TARGET_PARTS[k] is None or TARGET_PARTS[k] in frames)
             and TARGET_CLASS.get(k, "") in p1_classes | {""}]
    head = ["## Targets", "", "| target | measured | met |", "|---|---|---|"]
    head += [f"| {TARGETS[k]} | {measured[k]} | {'yes' if met[k] else '**no**'} |" for k in shown]
    if "n_fixed_classes" in met:
        head += ["", "The per-class n-fixed target (noise-free classes, all parts run):", "", *class_lines]
    parts = {p: [c for q, c in items if q == p] for p in chosen}
    page = _intro(parts, args, versions, (time.perf_counter() - started) / 60 if pending else None) + head + body
    notes = ROOT / "benchmarks" / "envelope_notes.md"
    if notes.exists():
        page += ["", notes.read_text().strip(), ""]
    args.out.write_text("\n".join(page) + "\n")
    print(f"wrote {args.out}")
    for key in shown:
        print(f"  {'met ' if met[key] else 'MISS'}  {TARGETS[key]}: {measured[key]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

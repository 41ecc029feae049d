"""The identification engine on NIST's StRD nonlinear regression problems; writes docs/validation_engine.md.

    python benchmarks/validate_engine.py [--out docs/validation_engine.md]

Every one of the 27 problems (Misra1a ... Bennett5, of lower, average and higher difficulty) from
both of NIST's starting points, with the analytic Jacobian and with the engine's default central
differences, through :func:`impactid.engine.search` and :func:`impactid.engine.uncertainty` with their
defaults (the problems, models and scoring are those of ``tests/test_engine_nist.py``). A start is
*certified* when the parameters match NIST's certified values to 6 significant digits, the standard
deviations to 3 and the residual sum of squares; *flagged* when it does not and the engine itself says
so (not converged, a note, an undetermined standard error); *confident and wrong* otherwise (the
target is none).
"""

from __future__ import annotations

import argparse
import math
import platform
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import scipy

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests import test_engine_nist as T  # noqa: E402


def _digits(error: float) -> str:
    return "exact" if error == 0 else f"{-math.log10(error):.1f}"


def verdict(outcome) -> str:
    """``certified``, ``flagged`` or ``confident and wrong``."""
    return "certified" if outcome.certified else ("flagged" if outcome.flags else "**confident and wrong**")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "validation_engine.md")
    args = parser.parse_args(argv)
    started = time.perf_counter()
    warnings.simplefilter("ignore")
    lines = ["# Validation: the identification engine on NIST's StRD nonlinear regression problems", "",
             f"Made by `python benchmarks/validate_engine.py` (numpy {np.__version__}, scipy {scipy.__version__}, "
             f"Python {platform.python_version()}). NIST's Statistical Reference Datasets for nonlinear "
             "regression are 27 problems with certified parameter values and standard deviations, each with two "
             "starting points (public domain; the data files are in `tests/data/nist_strd/`). Every problem is "
             "solved here through the engine every rig's fit uses (`impactid.engine.search` and "
             "`impactid.engine.uncertainty`, default options, all parameters unbounded), once with the analytic "
             "Jacobian and once with the engine's central differences. The same runs are tests "
             "(`tests/test_engine_nist.py`).", "",
             "A start is **certified** when the parameters match the certificate to 6 significant digits, the "
             "standard deviations to 3 and the residual sum of squares to 1e-6 (plus double-precision round-off); "
             "**flagged** when it does not and the engine says so itself (not converged, a note, an undetermined "
             "standard error); **confident and wrong** otherwise.", ""]
    summary = []
    for jacobian in T.JACOBIANS:
        lines += [f"## {jacobian} Jacobian", "",
                  "| problem | difficulty | start | verdict | digits of parameters | digits of SDs | nfev "
                  "| engine's flag |",
                  "|---|---|---|---|---|---|---|---|"]
        outcomes = []
        for name in T.MODELS:
            for start in (1, 2):
                o = T.identify(name, start, jacobian)
                outcomes.append((name, start, o))
                flag = "; ".join(f[:80] for f in o.flags)
                lines.append(f"| {name} | {T.problem(name).difficulty} | {start} | {verdict(o)} | "
                             f"{_digits(o.parameter_error)} | {_digits(o.sd_error)} | {o.found.nfev} | {flag} |")
        certified = [o for *_, o in outcomes if o.certified]
        flagged = [f"{n} {s}" for n, s, o in outcomes if not o.certified and o.flags]
        wrong = [f"{n} {s}" for n, s, o in outcomes if not o.certified and not o.flags]
        problems = sum(any(o.certified for m, _, o in outcomes if m == n) for n in T.MODELS)
        worst_p = max(o.parameter_error for o in certified)
        worst_s = max(o.sd_error for o in certified)
        text = (f"{jacobian}: {len(certified)} of {len(outcomes)} starts certified, {len(flagged)} flagged "
                f"({', '.join(flagged) or 'none'}), {len(wrong)} confident and wrong ({', '.join(wrong) or 'none'}); "
                f"{problems} of {len(T.MODELS)} problems certified from at least one start; the worst certified "
                f"start has {_digits(worst_p)} digits of the parameters and {_digits(worst_s)} of the SDs")
        summary.append(text)
        lines += ["", text + ".", ""]
        # a flagged start: given ten times scipy's default budget, does it reach the certificate?
        for n, s, o in outcomes:
            if o.certified or o.found.success:
                continue
            budget = T.LARGER_BUDGET_PER_PARAMETER * T.problem(n).certified.size
            again = T.identify(n, s, jacobian, max_nfev=budget)
            lines.append(f"- {n} start {s} ran out of evaluations (the engine says so); with max_nfev {budget}: "
                         f"{verdict(again)}, {_digits(again.parameter_error)} digits.")
        lines.append("")
    lines.insert(lines.index("## analytic Jacobian"), "**Summary.** " + " ".join(s + "." for s in summary) + "\n")
    lines += [f"Run time {time.perf_counter() - started:.0f} s.", ""]
    args.out.write_text("\n".join(lines))
    print("\n".join(summary))
    print(f"written {args.out}")
    return 0 if all("0 confident and wrong" in s for s in summary) else 1


if __name__ == "__main__":
    sys.exit(main())

"""Validation of restitution from bounce timing: synthetic recovery and the real recordings.

    python benchmarks/validate_bounces.py --out docs/validation_bounces.md [--real-data DIR] [--seeds 30]

Synthetic part (always): known laws, table-tennis ball with drag, timing jitter of 0.3 ms rounded
to 1/48000 s, a bounce-to-bounce scatter of e of 0.002, and in every drop one missed bounce, one
echo, one spurious and one displaced trigger, a release click and a junk end. Reports true against
recovered parameters, the coverage of the 95 % intervals over the papers, the selected laws, and
how often the cleaning labels the injected faults exactly.

Real part (with ``--real-data``, the folder holding ``pingpong_parquet/`` and ``unknown_ball/``):
every file is read and analysed; per ball, e with its interval under each law, the selected law,
with and without drag, the rejected intervals with their reasons, the drag-coefficient
sensitivity, and figures (``docs/figures/bounces_*.png``).
"""

from __future__ import annotations

import argparse
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np

from impactid._files import StagedFiles
from impactid.rigs.ball import TABLE_TENNIS, analyse_bounces, clean_sequence
from impactid.rigs.ball.synth import synth_drop

LAWS = {"constant": {"e": 0.95}, "linear": {"e0": 0.97, "gamma": 0.02}, "viscoelastic": {"a": 0.05}}
HEIGHTS = (0.08, 0.12, 0.18, 0.24, 0.30, 0.40)
FAULTS = dict(missed=1, echoes=1, spurious=1, displaced=1, release=True, junk_end=1)


def synthetic(seeds: int) -> tuple[list[str], dict]:
    lines = ["## Synthetic drops: recovery of known laws", "",
             f"{seeds} experiments per law, each of {len(HEIGHTS)} drops of a table-tennis ball (heights "
             f"{', '.join(f'{h:g}' for h in HEIGHTS)} m; flight with drag, buoyancy and added mass), timing jitter "
             "0.3 ms rounded to 1/48000 s, bounce-to-bounce scatter of e 0.002, and in every drop one missed "
             "bounce, one echo, one spurious and one displaced trigger, a release click and a junk end event. "
             "Analysed with the ball known (drag corrected), law fitted = law simulated.", "",
             "| law | parameter | true | mean recovered | sd over seeds | mean stderr | coverage of 95 % interval |",
             "|---|---|---|---|---|---|---|"]
    selection = {}
    cleaning = Counter()
    for law, params in LAWS.items():
        values, hits, selected = {k: [] for k in params}, {k: 0 for k in params}, Counter()
        for seed in range(seeds):
            drops = []
            for j, h in enumerate(HEIGHTS):
                d = synth_drop(law, params, seed=10_000 * seed + 100 * j + len(law), ball=TABLE_TENNIS, height=h,
                               jitter=3e-4, scatter=0.002, min_flight=0.1, **FAULTS)
                drops.append(d)
                if law == "linear":
                    seq = clean_sequence(d.times, resolution=1 / 48000)
                    got = np.where(np.isin(seq.status, ["echo", "spurious"]), "extra", np.array(seq.status))
                    want = np.array([{"impact": "impact", "junk": "end", "echo": "extra", "spurious": "extra"}.get(
                        lab, lab) for lab in d.labels])
                    cleaning["drops"] += 1
                    cleaning["exact"] += bool(np.array_equal(got, want))
                    for lab in ("release", "echo", "spurious", "displaced", "junk"):
                        mask = np.array(d.labels) == lab
                        cleaning[f"{lab} found"] += int(np.sum(got[mask] == want[mask]))
                        cleaning[f"{lab} injected"] += int(np.sum(mask))
                    spans = seq.flights[seq.flights["flights"] == 2]
                    tau = d.true_times[d.missed[0]]
                    cleaning["missed found"] += int(bool(np.any((spans["start_s"] < tau) &
                                                                (tau < spans["start_s"] + spans["duration_s"]))))
                    cleaning["missed injected"] += 1
                    cleaning["genuine impacts rejected"] += int(np.sum((want == "impact") & (got != "impact")))
                    cleaning["genuine impacts"] += int(np.sum(want == "impact"))
            result = analyse_bounces([d.times for d in drops], ball=TABLE_TENNIS, chained=False,
                                     compare_no_drag=False)
            fit = result.law_fits[law]
            selected[result.selected] += 1
            for k, v in params.items():
                values[k].append((fit[k].value, fit[k].stderr))
                hits[k] += fit[k].contains(v)
        for k, v in params.items():
            arr = np.array(values[k])
            lines.append(f"| {law} | {k} | {v:g} | {arr[:, 0].mean():.5f} | {arr[:, 0].std(ddof=1):.2g} | "
                         f"{arr[:, 1].mean():.2g} | {hits[k]}/{seeds} = {100 * hits[k] / seeds:.0f} % |")
        selection[law] = selected
    lines += ["", "Selected law (BIC, a simpler law preferred within 2) per simulated law:", "",
              "| simulated | " + " | ".join(LAWS) + " |", "|---|" + "---|" * len(LAWS)]
    for law, sel in selection.items():
        lines.append(f"| {law} | " + " | ".join(str(sel.get(n, 0)) for n in LAWS) + " |")
    lines += ["", f"Cleaning of the {cleaning['drops']} drops of the linear law: {cleaning['exact']} labelled "
              "exactly as injected.", "", "| fault | injected | found |", "|---|---|---|"]
    for lab in ("release", "echo", "spurious", "displaced", "junk", "missed"):
        lines.append(f"| {lab} | {cleaning[f'{lab} injected']} | {cleaning[f'{lab} found']} |")
    lines.append(f"| genuine impacts rejected | {cleaning['genuine impacts']} | "
                 f"{cleaning['genuine impacts rejected']} |")
    lines += ["", "A missed bounce counts as found when the span between accepted impacts around its true time "
              "is labelled as two flights; the other faults when the injected event gets its label (echo and "
              "spurious triggers both count as extra triggers; a displaced trigger also leaves a two-flight "
              "span, around the impact it mistimed)."]
    return lines, {"selection": selection, "cleaning": dict(cleaning)}


def _law_rows(result, label):
    rows = []
    for name, fit in result.law_fits.items():
        text = "; ".join(f"{p.name} = {p.value:.5g} +/- {p.stderr:.2g} [{p.interval[0]:.5g}, {p.interval[1]:.5g}]"
                         f" {p.unit}".rstrip() for p in fit.params.values())
        mark = " (selected)" if name == result.selected else ""
        rows.append(f"| {label} | {name}{mark} | {text} | {fit.statistics['bic']:.1f} |")
    return rows


def real(folder: Path, figures: Path, staged) -> list[str]:
    lines = ["## Real recordings", "",
             "phyphox 'Acoustic stopwatch' exports of a student laboratory (48 kHz; event times on a 1/48000 s "
             "grid). Files read from the folder given on the command line; they are not in the repository.", ""]
    sets = [("table-tennis ball on parquet", sorted((folder / "pingpong_parquet").glob("*.xlsx")), TABLE_TENNIS),
            ("unknown rubber ball", sorted((folder / "unknown_ball").glob("*.xls")), None)]
    for title, files, ball in sets:
        if not files:
            lines += [f"### {title}", "", "no files found", ""]
            continue
        start = time.perf_counter()
        result = analyse_bounces(files, ball=ball)
        seconds = time.perf_counter() - start
        s = result.statistics
        lines += [f"### {title}: {len(files)} files", "",
                  f"{s['drops_analysed']} drops analysed, {s['drops_refused']} refused; {s['impacts_used']} "
                  f"coefficients used; {s['intervals_rejected']} of {s['intervals']} intervals rejected; impact "
                  f"speeds {s['speed_min_m_s']:.2f}-{s['speed_max_m_s']:.2f} m/s; bounce-to-bounce scatter of e "
                  f"{s['intrinsic_scatter']:.2g}, timing noise {1e3 * s['timing_sigma_s']:.2g} ms "
                  f"({seconds:.1f} s, chained fits included).", "",
                  "| flight model | law | parameters (value +/- stderr [95 % interval]) | BIC |", "|---|---|---|---|"]
        lines += _law_rows(result, result.statistics["flight_model"])
        if result.no_drag_fits:
            vac = analyse_bounces(files, ball=ball, drag=False, chained=False)
            lines += _law_rows(vac, "vacuum (no drag)")
        for name, fit in result.chained_fits.items():
            text = "; ".join(f"{p.name} = {p.value:.5g} +/- {p.stderr:.2g}" for p in fit.params.values())
            lines.append(f"| chained fit, {result.statistics['flight_model']} | {name} | {text} | "
                         f"{fit.statistics['bic']:.1f} |")
        lines += ["", f"Selected: **{result.selected}** ({result.details['selection']}).", ""]
        if ball is not None:
            lines += ["Sensitivity to the drag coefficient (linear law):", "",
                      "| Cd | e0 | gamma [s/m] |", "|---|---|---|"]
            for cd in (0.32, 0.42, 0.52):
                r = analyse_bounces(files, ball=ball.with_(drag_coefficient=cd), chained=False, compare_no_drag=False)
                f = r.law_fits["linear"]
                lines.append(f"| {cd:g} | {f['e0'].value:.5f} +/- {f['e0'].stderr:.2g} | "
                             f"{f['gamma'].value:.5f} +/- {f['gamma'].stderr:.2g} |")
            lines.append("")
        lines += ["Notes:", ""] + [f"- {n}" for n in result.notes] + [""]
        table = result.bounces
        flags = Counter(table["flag"])
        lines += ["Intervals by flag: " + ", ".join(f"{k} {v}" for k, v in sorted(flags.items())) + ".", "",
                  "| file | interval | duration [s] | flag | reason |", "|---|---|---|---|---|"]
        for r in table[~table["flag"].isin(["ok", "first"])].itertuples(index=False):
            lines.append(f"| {r.file} | {r.index} | {r.interval_s:.5f} | {r.flag} | {r.reason} |")
        key = "pingpong" if ball is not None else "unknown"
        for name, fig in ((f"bounces_{key}_restitution.png", result.plot()),
                          (f"bounces_{key}_intervals.png", result.plot_intervals())):
            staged.write_with(figures / name, lambda tmp, fig=fig: fig.savefig(tmp, format="png", dpi=110))
            lines += [f"![{name}](figures/{name})", ""]
    return lines


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--real-data", type=Path, default=None, help="folder with pingpong_parquet/ and unknown_ball/")
    parser.add_argument("--out", type=Path, required=True, help="markdown page to write")
    parser.add_argument("--seeds", type=int, default=30, help="synthetic experiments per law")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    lines = ["# Validation: restitution from bounce timing", "",
             "Written by `benchmarks/validate_bounces.py`; every number below was measured by that run.", ""]
    syn, _ = synthetic(args.seeds)
    lines += syn + [""]
    figures = args.out.parent / "figures"
    with StagedFiles() as staged:
        if args.real_data is not None:
            if not args.real_data.is_dir():
                print(f"validate_bounces: error: --real-data {args.real_data}: not a folder", file=sys.stderr)
                return 2
            lines += real(args.real_data, figures, staged)
        else:
            lines += ["## Real recordings", "", "not run (no --real-data given)", ""]
        lines.append(f"Run time {time.perf_counter() - start:.0f} s.")
        staged.write_text(args.out, "\n".join(lines) + "\n")
    print(f"written {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

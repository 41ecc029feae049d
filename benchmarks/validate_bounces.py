"""Validation of restitution from bounce timing: synthetic recovery, room audio, faulty drops, and
the real recordings.

    python benchmarks/validate_bounces.py --out docs/validation_bounces.md [--real-data DIR] [--seeds 30]
        [--room-seeds 10] [--stress-seeds 20]

Synthetic part (always): known laws, table-tennis ball with drag, timing jitter of 0.3 ms rounded
to 1/48000 s, a bounce-to-bounce scatter of e of 0.002, and in every drop one missed bounce, one
echo, one spurious and one displaced trigger, a release click and a junk end. Reports true against
recovered parameters, the coverage of the 95 % intervals over the papers, the selected laws, and
how often the cleaning labels the injected faults exactly.

Room audio (always): drops under a constant and a speed-dependent law rendered as a room records
them (:data:`impactid.rigs.ball.synth.ROOM_AUDIO`: two to four clicks per contact, echoes, ringing,
noise 20 dB below the loudest click, clipping); the restitution law fitted to the detected onsets
against the one fitted to the clean impact times (the issue's tolerance: 0.005), also through Ogg
Vorbis (lossy) when soundfile is installed.

Faulty drops (always): drops with up to six spurious and two missed triggers, cleaned one by one:
how many are discarded whole, how many of their good intervals are kept, how many faulty ones
pass, and the restitution of each drop against that of its clean impact times.

Real part (with ``--real-data`` or ``IMPACTID_REALDATA_BOUNCES``, the folder holding
``pingpong_parquet/`` and ``unknown_ball/``; the files are never copied): every file is read and
analysed; drops discarded whole and intervals by flag; per ball, e with its interval under each
law, the selected law, with and without drag, the rejected intervals with their reasons, the
drag-coefficient sensitivity, and figures (``docs/figures/bounces_*.png``).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

import numpy as np

from impactid._files import StagedFiles
from impactid.rigs.ball import TABLE_TENNIS, analyse_bounces, clean_sequence, detect_onsets, read_bounces, readers
from impactid.rigs.ball.onsets import REJECTION_WORDS
from impactid.rigs.ball.synth import ROOM_AUDIO, simulate_drop, synth_audio, synth_drop

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


ROOM_LAWS = {"constant": {"e": 0.92}, "linear": {"e0": 0.96, "gamma": 0.02}}
#: The issue's tolerance on the restitution from room audio against the clean sequence.
ROOM_TOLERANCE = 0.005


def _fit(times_or_recording, law):
    return analyse_bounces([times_or_recording], ball=TABLE_TENNIS, chained=False, law=law, compare_no_drag=False)


def _law_difference(heard, clean, law) -> tuple[float, float, float, float]:
    """Largest |e_heard(v) - e_clean(v)| over the impact speeds the heard fit used, its value at
    their median, and that speed range [m/s]."""
    used = heard.bounces[heard.bounces["used"]]
    v = np.linspace(used["impact_speed_m_s"].min(), used["impact_speed_m_s"].max(), 41)
    d = heard.law_fits[law].predict(v)[0] - clean.law_fits[law].predict(v)[0]
    mid = float(np.median(used["impact_speed_m_s"]))
    d_mid = float(heard.law_fits[law].predict([mid])[0][0] - clean.law_fits[law].predict([mid])[0][0])
    return float(np.max(np.abs(d))), d_mid, float(v[0]), float(v[-1])


def room_audio(seeds: int) -> list[str]:
    """Restitution from synthetic room audio against the clean impact times."""
    vorbis = readers.soundfile is not None
    lines = ["## Room audio: restitution from the sound against the clean sequence", "",
             f"{seeds} drops per law of a table-tennis ball (heights drawn from 0.2-0.6 m, flight with drag), rendered "
             "as a phone in a room records them (`impactid.rigs.ball.synth.ROOM_AUDIO`): two to four clicks per "
             "contact 0.4-2.5 ms apart, room echoes at 4.1 and 11.3 ms, the floor ringing at 2.3 kHz for 30 ms, "
             "white noise 20 dB below the loudest click, peaks clipped at full scale; 48 kHz for even seeds, "
             "44.1 kHz for odd ones. The onsets found by `detect_onsets` and the clean impact times are fitted "
             "with the simulated law (ball known, drag corrected); the table gives the largest difference of "
             "the two fitted e(v) over the impact speeds that the audio's fit used, and at their median. "
             f"Tolerance (issue 29): {ROOM_TOLERANCE}." + (
                 " The last column: the same audio, 16-bit, through Ogg Vorbis (lossy; written and read by "
                 "soundfile), against the clean sequence." if vorbis else ""), "",
             "| law | seed | rate [Hz] | impacts (heard / true) | clicks rejected (contact / echo / ringing) | "
             "onset error median / max [ms] | speeds [m/s] | max abs(de) | de at median speed |"
             + (" Vorbis: max abs(de) |" if vorbis else ""),
             "|---|---|---|---|---|---|---|---|---|" + ("---|" if vorbis else "")]
    worst = {}
    with tempfile.TemporaryDirectory() as tmp:
        for law, params in ROOM_LAWS.items():
            worst[law] = [0.0, 0.0]
            for seed in range(seeds):
                rng = np.random.default_rng(1000 + seed)
                height = rng.uniform(0.2, 0.6)
                rate = 48000 if seed % 2 == 0 else 44100
                sim = simulate_drop(law, params, ball=TABLE_TENNIS, height=height, first_impact=0.3, min_flight=0.06)
                speeds = np.r_[np.sqrt(2 * 9.81 * height), sim["v"][: sim["times"].size - 1]]
                x = synth_audio(sim["times"], speeds, sample_rate=rate, rng=rng, **ROOM_AUDIO)
                on = detect_onsets(x, rate)
                clean, heard = _fit(sim["times"], law), _fit(on.times, law)
                d_max, d_mid, v_lo, v_hi = _law_difference(heard, clean, law)
                worst[law][0] = max(worst[law][0], d_max)
                error = np.min(np.abs(on.times[:, None] - sim["times"][None, :]), axis=1)
                merged = Counter(on.rejected_reasons)
                row = (f"| {law} | {seed} | {rate} | {on.times.size} / {sim['times'].size} | "
                       f"{merged['contact']} / {merged['echo']} / {merged['ringing']} | "
                       f"{1e3 * np.median(error):.3f} / {1e3 * np.max(error):.2f} | {v_lo:.2f}-{v_hi:.2f} | "
                       f"{d_max:.2g} | {d_mid:+.2g} |")
                if vorbis:
                    path = Path(tmp) / f"{law}{seed}.ogg"
                    stored = np.clip(np.round(x * 32768), -32768, 32767).astype(np.int16)
                    readers.soundfile.write(path, stored, rate, format="OGG", subtype="VORBIS")
                    d_ogg = _law_difference(_fit(read_bounces(path), law), clean, law)[0]
                    worst[law][1] = max(worst[law][1], d_ogg)
                    row += f" {d_ogg:.2g} |"
                lines.append(row)
    lines += [""] + [f"Largest difference, {law} law: {w[0]:.2g}" + (f" (Ogg Vorbis {w[1]:.2g})" if vorbis else "")
                     + f" - {'within' if max(w) < ROOM_TOLERANCE else 'BEYOND'} the tolerance {ROOM_TOLERANCE}."
                     for law, w in worst.items()]
    lines += ["", "Onsets are timed on the rising edge of a contact's first click; the later clicks of a contact, "
              "the echoes and the ringing are rejected with their reason (the detector's reasons: "
              f"{', '.join(REJECTION_WORDS)}; an echo that arrives within a contact's clicks is merged into the "
              "contact). The quiet last bounces, below the "
              "noise, are not heard: the law is then fitted over the louder, faster impacts only (the speed "
              "column)."]
    return lines


STRESS_SPURIOUS = (0, 3, 6, 10)
STRESS_MISSED = (0, 1, 2)


def _flights_kept(drop, seq) -> tuple[int, int, int]:
    """True flights that could be kept (both impacts triggered on time), those kept as one flight
    between accepted impacts, and spans kept as one flight that are not a true flight."""
    on_time = {int(k) for k, lab in zip(drop.impact_index, drop.labels) if lab == "impact"}
    good = sum(1 for k in on_time if k + 1 in on_time)
    labels, k = np.array(drop.labels), drop.impact_index
    kept = faulty = 0
    for f in seq.flights.itertuples(index=False):
        if f.flights != 1 or f.anomalous:
            continue
        a, b = int(f.start_event), int(f.end_event)
        if labels[a] == "impact" and labels[b] == "impact" and k[b] == k[a] + 1:
            kept += 1
        else:
            faulty += 1
    return good, kept, faulty


def faulty_drops(seeds: int) -> list[str]:
    """Drops with spurious and missed triggers, cleaned one by one: discarded whole or kept."""
    lines = ["## Faulty drops: cleaned, not discarded", "",
             f"{seeds} drops per row of a table-tennis ball (e = 0.92, drop heights 0.15-0.5 m, flights down to "
             "60 ms, timing jitter 0.2 ms on the 1/48000 s grid), each with one echo, a release click, a junk end "
             "event, and the spurious triggers (between 30 % and 80 % of a flight) and missed bounces of the row. "
             "Each drop is cleaned and analysed alone (constant law, ball known). A good flight is one true flight "
             "between two impacts triggered on time; it is kept when the cleaning accepts both impacts and labels "
             "the span between them one flight. A faulty flight is a span accepted as one flight that is not a "
             "true one (a spurious trigger or an echo taken for an impact). de: the drop's e against that of its "
             "clean impact times.", "",
             "| spurious | missed | drops discarded whole | good flights kept (lowest per drop; all) | "
             "faulty flights kept | median abs(de) | largest abs(de) |", "|---|---|---|---|---|---|---|"]
    summary = {}
    for spurious in STRESS_SPURIOUS:
        for missed in STRESS_MISSED:
            discarded, fractions, faulty_all, good_all, kept_all, errors = 0, [], 0, 0, 0, []
            for seed in range(seeds):
                height = 0.15 + 0.35 * ((seed * 0.618) % 1.0)
                d = synth_drop("constant", {"e": 0.92}, seed=500 * seed + 10 * spurious + missed, ball=TABLE_TENNIS,
                               height=height, min_flight=0.06, jitter=2e-4, spurious=spurious, missed=missed,
                               echoes=1, release=True, junk_end=1)
                seq = clean_sequence(d.times, resolution=1 / 48000)
                if seq.refused:
                    discarded += 1
                    continue
                good, kept, faulty = _flights_kept(d, seq)
                fractions.append(kept / max(good, 1))
                good_all, kept_all, faulty_all = good_all + good, kept_all + kept, faulty_all + faulty
                try:
                    errors.append(abs(_fit(d.times, "constant")["constant.e"].value
                                      - _fit(d.true_times, "constant")["constant.e"].value))
                except Exception as exc:  # a drop the analysis refuses counts as discarded
                    discarded += 1
                    print(f"validate_bounces: faulty drop {spurious}/{missed}/{seed} refused: {exc}", file=sys.stderr)
            e = np.array(errors) if errors else np.array([np.nan])
            lowest = f"{100 * min(fractions):.0f} %" if fractions else "-"
            summary[spurious, missed] = (discarded, min(fractions) if fractions else 0.0, faulty_all, np.max(e))
            lines.append(f"| {spurious} | {missed} | {discarded} of {seeds} | {lowest}; {kept_all} of {good_all} | "
                         f"{faulty_all} | {np.median(e):.2g} | {np.max(e):.2g} |")
    for label, rows in (("up to six spurious triggers", [k for k in summary if k[0] <= 6]),
                        ("ten spurious triggers", [k for k in summary if k[0] > 6])):
        if rows:
            lines += ["", f"With {label} and up to {max(k[1] for k in rows)} missed bounces per drop: "
                      f"{sum(summary[k][0] for k in rows)} of {len(rows) * seeds} drops discarded whole, at least "
                      f"{100 * min(summary[k][1] for k in rows):.0f} % of the good flights kept in every drop "
                      "not discarded, "
                      f"{sum(summary[k][2] for k in rows)} faulty flights kept, the largest abs(de) "
                      f"{max(summary[k][3] for k in rows):.2g}."]
    lines += ["", "The flights next to a rejected trigger are kept: a spurious trigger or an echo is dropped and the "
              "flight across it measured between the impacts around it; a missed bounce leaves a span of two "
              "flights (flag `missed`), not counted as kept, whose impacts still bound their other flights."]
    return lines


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
             "grid). Files read from the folder given on the command line (or in IMPACTID_REALDATA_BOUNCES); they are "
             "not in the repository.", ""]
    summary = ["Drops discarded whole and intervals by flag (`ok`: a flight consistent with the rest of its drop, "
               "used for e; the other flags are the reasons an interval is not used; `first`: the first flight of "
               "a drop, which has no measured predecessor):", "",
               "| set | drops | discarded whole | fewest `ok` intervals in a drop | intervals | by flag |",
               "|---|---|---|---|---|---|"]
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
        withheld = []
        for name, fit in result.chained_fits.items():
            text = "; ".join(f"{p.name} = {p.value:.5g} +/- " + (f"{p.stderr:.2g}" if np.isfinite(p.stderr) else
                                                                 "withheld") for p in fit.params.values())
            if not all(np.isfinite(p.stderr) for p in fit.params.values()):
                withheld.append(f"{name} ({fit.statistics['residual_over_timing_noise']:.0f} x)")
            lines.append(f"| chained fit, {result.statistics['flight_model']} | {name} | {text} | "
                         f"{fit.statistics['bic']:.1f} |")
        if withheld:
            lines += ["", "Chained fits: the standard errors are withheld by the model check where the residual of the "
                      "event times is many times their noise and structured (" + ", ".join(withheld) + " the timing "
                      "noise): a bounce-to-bounce scatter of e accumulates along a drop, which the chained model "
                      "does not describe; the per-impact fits above carry the intervals."]
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
        per_drop = table.groupby("drop")["flag"].apply(lambda f: int(np.sum(f == "ok")))
        summary.append(f"| {title} | {s['drops_analysed'] + s['drops_refused']} | {s['drops_refused']} | "
                       f"{per_drop.min()} | {len(table)} | "
                       + ", ".join(f"{k} {v}" for k, v in sorted(flags.items())) + " |")
        lines += ["Intervals by flag: " + ", ".join(f"{k} {v}" for k, v in sorted(flags.items())) + ".", "",
                  "| file | interval | duration [s] | flag | reason |", "|---|---|---|---|---|"]
        for r in table[~table["flag"].isin(["ok", "first"])].itertuples(index=False):
            lines.append(f"| {r.file} | {r.index} | {r.interval_s:.5f} | {r.flag} | {r.reason} |")
        key = "pingpong" if ball is not None else "unknown"
        for name, fig in ((f"bounces_{key}_restitution.png", result.plot()),
                          (f"bounces_{key}_intervals.png", result.plot_intervals())):
            staged.write_with(figures / name, lambda tmp, fig=fig: fig.savefig(tmp, format="png", dpi=110))
            lines += [f"![{name}](figures/{name})", ""]
    return lines[:4] + summary + [""] + lines[4:]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--real-data", type=Path, default=os.environ.get("IMPACTID_REALDATA_BOUNCES") or None,
                        help="folder with pingpong_parquet/ and unknown_ball/ (default: $IMPACTID_REALDATA_BOUNCES)")
    parser.add_argument("--out", type=Path, required=True, help="markdown page to write")
    parser.add_argument("--seeds", type=int, default=30, help="synthetic experiments per law")
    parser.add_argument("--room-seeds", type=int, default=10, help="room-audio drops per law")
    parser.add_argument("--stress-seeds", type=int, default=20, help="faulty drops per row of the stress test")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    lines = ["# Validation: restitution from bounce timing", "",
             "Written by `benchmarks/validate_bounces.py`; every number below was measured by that run.", ""]
    syn, _ = synthetic(args.seeds)
    lines += syn + [""]
    lines += room_audio(args.room_seeds) + [""]
    lines += faulty_drops(args.stress_seeds) + [""]
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

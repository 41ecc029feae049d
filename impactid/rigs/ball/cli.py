"""``impactid bounces``: restitution from bounce timings (phyphox exports, CSV of times, WAV).

Thin: parses arguments, calls :func:`impactid.rigs.ball.analyse_bounces`, prints, writes. Follows
the conventions of :mod:`impactid.cli`: arguments that are not finite or not positive are
usage errors (``argument --x: ...``), the input files are checked before any is read (each must be
a regular file, never a named pipe or a device, and no recording may be given twice), output paths
are checked before any computation, outputs are written as transactions (the JSON first, then the
figures), and every failure is one line ``impactid: error: ...`` with exit status 2.
"""

from __future__ import annotations

import math
from pathlib import Path

from impactid._files import StagedFiles, check_output
from impactid.commandline import UsageError, check_report, figure_format, say_report, write_report
from impactid.commandline import json_text as _json_text
from impactid.commandline import print_json as _print_json
from impactid.rigs.ball.analysis import analyse_bounces
from impactid.rigs.ball.figures import figure_names, write_figures
from impactid.rigs.ball.flight import flight_constants
from impactid.rigs.ball.parameters import AIR_DENSITY, STANDARD_GRAVITY, Ball, BallParameterError, ball_preset
from impactid.rigs.ball.readers import check_files, read_drops

__all__ = ["run"]


def _ball(args):
    """The ball of the arguments (None when unknown); usage errors for inconsistent ones."""
    custom = args.mass is not None or args.diameter is not None
    if args.ball is not None and custom:
        raise UsageError("argument --ball: give either --ball or --mass with --diameter, not both")
    if custom and (args.mass is None or args.diameter is None):
        missing = "--diameter" if args.diameter is None else "--mass"
        given = "--mass" if args.diameter is None else "--diameter"
        raise UsageError(f"argument {given}: a custom ball needs {missing} too")
    extras = [name for name, value in (("--drag-coefficient", args.drag_coefficient),
                                        ("--air-density", args.air_density)) if value is not None]
    if args.ball is None and not custom:
        if extras:
            raise UsageError(f"argument {extras[0]}: needs a ball (--ball NAME, or --mass and --diameter)")
        return None
    changes = {}
    if args.drag_coefficient is not None:
        changes["drag_coefficient"] = args.drag_coefficient
    if args.air_density is not None:
        changes["air_density"] = args.air_density
    try:
        if args.ball is not None:
            return ball_preset(args.ball).with_(**changes)
        return Ball("custom", mass=args.mass, diameter=args.diameter,
                    drag_coefficient=changes.get("drag_coefficient", 0.42),
                    air_density=changes.get("air_density", AIR_DENSITY),
                    gravity=changes.get("gravity", STANDARD_GRAVITY))
    except BallParameterError as exc:
        raise UsageError(f"argument --mass: {exc}") from None


def _num(value, fmt=".5g") -> str:
    return "undetermined" if value is None or not math.isfinite(float(value)) else format(float(value), fmt)


def _document(result, args, ball: Ball | None) -> dict:
    """The command's JSON document (``docs/formats.md``, "Fit results"): the
    :class:`~impactid.rigs.ball.analysis.BounceAnalysis` in the :class:`~impactid.results.FitResult`
    schema (``FitResult.from_dict(data)`` rebuilds it; the law fits' parameters are ``constant.e``,
    ``linear.e0``, ``linear.gamma``, ..., the per-interval table ``tables.bounces``, the ball and the
    flight in ``details``, with ``details.drag``: whether the flights include the air) and the files
    read (``recordings_read``); ``--plots`` adds ``plots``."""
    data = result.to_dict()
    data["details"].setdefault("drag", flight_constants(ball, not args.no_drag, args.gravity).drag)
    data["recordings_read"] = [str(f) for f in args.files]
    return data


def run(args) -> int:
    """Run ``impactid bounces``; returns the exit code."""
    ball = _ball(args)
    inputs = list(args.files)
    check_files(inputs)  # before anything is opened: a named pipe would block the job forever
    if args.out:
        check_output(args.out, option="--out", inputs=inputs)
    if args.plots:
        check_output(args.plots, option="--plots", inputs=inputs, directory=True)
    check_report(args, inputs, others={"--out": args.out})
    channel = getattr(args, "audio_channel", "mix")
    onset_options = None if channel == "mix" else {"channel": channel}
    recordings = [r for f in args.files for r in read_drops(f, onset_options=onset_options)]
    result = analyse_bounces(recordings, ball=ball, drag=not args.no_drag, gravity=args.gravity, law=args.law,
                             criterion=args.criterion, chained=not args.no_chained)
    data = _document(result, args, ball)
    if args.plots:
        data["plots"] = [str(Path(args.plots) / n) for n in figure_names(result, recordings, figure_format(args))]
    if args.out:
        with StagedFiles(protect=inputs) as staged:
            staged.write_text(args.out, _json_text(data))
    if args.plots:
        with StagedFiles(protect=inputs) as staged:
            write_figures(result, args.plots, staged, recordings, fmt=figure_format(args))
    write_report(args, data, inputs, ((), lambda staged: write_figures(result, args.plots, staged, recordings,
                                                                         fmt=figure_format(args))))
    if args.json:
        _print_json(data)
        return 0
    _print_report(result, args, recordings)
    return 0


def _print_trials(result) -> None:
    """One line per drop (the trials of a table of several drops are drops of their own)."""
    table = result.bounces
    for name in dict.fromkeys(table["file"].tolist()):
        rows = table[table["file"] == name]
        used = rows[rows["used"].astype(bool)]
        flagged = rows[~rows["flag"].isin(["ok", "first"])]
        mean = float(used["e"].astype(float).mean()) if len(used) else math.nan
        print(f"  drop {name}: {len(used)} coefficients used, mean e {_num(mean, '.4f')}, "
              f"{len(flagged)} of {len(rows)} intervals flagged")


def _print_report(result, args, recordings=()) -> None:
    s = result.statistics
    fits = result.law_fits
    print(f"impactid bounces: {s['files']} file(s), {s['drops_analysed']} drop(s) analysed, "
          f"{s['impacts_used']} coefficients used, {s['intervals_rejected']} of {s['intervals']} intervals rejected "
          f"({s['flight_model']})")
    for name, fit in fits.items():
        mark = "*" if name == result.selected else " "
        text = ", ".join(f"{p.name} = {_num(p.value)} +/- {_num(p.stderr, '.2g')} {p.unit}".rstrip()
                         for p in fit.params.values())
        print(f" {mark} {name:<13} {text}   BIC {_num(fit.statistics['bic'], '.1f')}")
    print(f"  selected: {result.selected} ({result.details.get('selection', '')})")
    print(f"  impact speeds {_num(s['speed_min_m_s'], '.3g')}-{_num(s['speed_max_m_s'], '.3g')} m/s; "
          f"scatter of e {_num(s['intrinsic_scatter'], '.2g')}, "
          f"timing noise {_num(1e3 * s['timing_sigma_s'], '.2g')} ms")
    if any(getattr(r, "trial", "") for r in recordings):
        _print_trials(result)
    for note in result.notes:
        print(f"  note: {note}")
    if args.out:
        print(f"  result written to {args.out}")
    if args.plots:
        print(f"  figures written to {args.plots}")
    say_report(args)


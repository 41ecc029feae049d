"""``impactid tracks analyse``: thin; reads the tracks, calls :func:`~impactid.rigs.tracks.analysis.analyse_tracks`,
prints, writes. Inputs are checked before any is read, outputs before any computation; the JSON and
the figures are written as transactions; every failure is one line ``impactid: error: ...``.
"""

from __future__ import annotations

import math
from pathlib import Path

from impactid._files import check_distinct_inputs
from impactid.commandline import UsageError, check_outputs, deliver, figure_format
from impactid.rigs.tracks.analysis import air_model_share, analyse_tracks
from impactid.rigs.tracks.figures import figure_names, write_figures
from impactid.rigs.tracks.parameters import TABLE_TENNIS_BALL, TrackParameterError
from impactid.rigs.tracks.readers import LENGTH_UNITS, TIME_UNITS, is_spin_index, read_track

__all__ = ["run"]


def _ball(args):
    changes = {name: getattr(args, name) for name in ("mass", "diameter", "drag_coefficient", "lift_scale",
                                                       "air_density") if getattr(args, name) is not None}
    if changes.keys() & {"mass", "diameter"}:
        changes["name"] = "custom"
    try:
        return TABLE_TENNIS_BALL.with_(**changes)
    except TrackParameterError as exc:
        raise UsageError(f"argument --mass: {exc}") from None


def _num(value, fmt=".4g") -> str:
    return "undetermined" if value is None or not math.isfinite(float(value)) else format(float(value), fmt)


def run(args) -> int:
    """Run ``impactid tracks analyse``; returns the exit code."""
    ball = _ball(args)
    if args.units is not None and args.units.strip().lower() not in LENGTH_UNITS:
        raise UsageError(f"argument --units: unknown length unit {args.units!r} (m, cm, mm, um, in, ft)")
    if args.time_units is not None and args.time_units.strip().lower() not in TIME_UNITS:
        raise UsageError(f"argument --time-units: unknown time unit {args.time_units!r} (s, ms, us, min)")
    if args.surface_height is not None and not math.isfinite(args.surface_height):
        raise UsageError("argument --surface-height: must be finite")
    inputs = list(args.tracks)
    for path in inputs:
        p = Path(path)
        if not p.exists():
            raise UsageError(f"{path}: no such file")
        if not p.is_file():
            raise UsageError(f"{path}: not a regular file")
    if len(inputs) > 1:
        check_distinct_inputs(inputs, what="track")
    check_outputs(args, inputs)
    skipped = [p for p in inputs if is_spin_index(p)]
    paths = [p for p in inputs if p not in skipped]
    if not paths:
        raise UsageError(f"{inputs[0]}: a spin index, not a track; give the tracks")
    tracks = [read_track(p, time=args.time, x=args.x, y=args.y, z=args.z, up=args.up, length_unit=args.units,
                         time_unit=args.time_units, spin=args.spin) for p in paths]
    options = dict(surface_height=args.surface_height, surface=args.surface, spin=not args.no_magnus,
                   criterion=args.criterion, rule=not args.no_rule, spin_side="out" if args.spin_after else "in",
                   estimate_lift=not (args.no_air_share or args.no_magnus), air_share=not args.no_air_share)
    if args.window is not None:
        options["window"] = args.window
    if args.min_flight is not None:
        options["min_flight"] = args.min_flight
    if args.speed_band is not None:
        options["speed_band"] = args.speed_band
    result = analyse_tracks(tracks, ball, **options)
    data = result.to_dict()
    data["recordings_read"] = [str(p) for p in paths]
    if skipped:
        data["details"]["spin_indexes_skipped"] = [str(p) for p in skipped]
    share = None
    if not args.no_air_share:
        share = air_model_share(result)
        data["details"]["air_model_share"] = {"columns": list(share.columns),
                                              "data": share.to_numpy(dtype=object).tolist()}
    fmt = figure_format(args)
    deliver(args, data, inputs, figures=(figure_names(result, fmt),
                                         lambda staged: write_figures(result, args.plots, staged, fmt)))
    if not args.json:
        _print_report(result, args, share)
    return 0


def _print_report(result, args, share) -> None:
    s = result.statistics
    print(f"impactid tracks analyse: {s['tracks']} track(s), {s['bounces_found']} bounce(s) found, "
          f"{s['bounces_analysed']} analysed; surface at {_num(s['surface_height_m'])} m "
          f"({result.details['surface']})")
    for name, p in result.params.items():
        lo, hi = p.interval
        print(f"  {name:<24} {_num(p.value)} [{_num(lo)}, {_num(hi)}] {p.unit}".rstrip())
    sel = result.details["selected"]
    print(f"  selected by {s['criterion']}: normal {sel.get('normal')}, tangential {sel.get('tangential')}")
    rule = result.details.get("rule")
    if rule:
        line = (f"  table-tennis rule (30.5 cm -> 22-25 cm): e_n {_num(rule['e_low'])}-{_num(rule['e_high'])} at "
                f"{_num(rule['impact_speed_m_s'], '.3g')} m/s (vacuum {_num(rule['vacuum'][0])}-"
                f"{_num(rule['vacuum'][1])})")
        if "overlaps" in rule:
            line += f"; the tracks' interval {'overlaps' if rule['overlaps'] else 'does not overlap'} it"
        print(line)
        if "overlaps_with_air_model" in rule:
            air = result.details["air_model"]
            print(f"  with the air model's share (C_D {air['drag_range'][0]:g}-{air['drag_range'][1]:g}, lift scale "
                  f"{air['lift_range'][0]:.3g}-{air['lift_range'][1]:.3g}): tracks "
                  f"{_num(rule['tracks_interval_air'][0])}-{_num(rule['tracks_interval_air'][1])}, rule "
                  f"{_num(rule['band_over_drag_range'][0])}-{_num(rule['band_over_drag_range'][1])}: "
                  f"{'overlap' if rule['overlaps_with_air_model'] else 'no overlap'}")
    if share is not None:
        for row in share.itertuples():
            print(f"  air model C_D {row.drag_coefficient:g}, lift scale {row.lift_scale:.3g}: e_n {_num(row.e_n)} "
                  f"[{_num(row.e_n_low)}, {_num(row.e_n_high)}]; rule {_num(row.rule_low)}-{_num(row.rule_high)}")
    not_analysed = result.bounces[~result.bounces["analysed"]]
    for row in not_analysed.itertuples():
        print(f"  not analysed: {row.bounce}: {row.reason}")
    for note in result.notes:
        print(f"  note: {note}")
    if args.out:
        print(f"  result written to {args.out}")
    if args.plots:
        print(f"  figures written to {args.plots}")

"""``impactid tracks analyse``: thin; reads the tracks, calls :func:`~impactid.rigs.tracks.analysis.analyse_tracks`,
prints, writes (the JSON, the figures, the ``--report`` page). Inputs are checked before any is read,
outputs before any computation; the outputs are written as transactions; every failure is one line
``impactid: error: ...``. Also ``impactid synth --rig tracked-ball`` (:func:`run_synth`), which
writes a synthetic track (:mod:`impactid.rigs.tracks.synth`).
"""

from __future__ import annotations

import math
from pathlib import Path

from impactid._files import check_distinct_inputs
from impactid.commandline import (
    UsageError,
    check_out_suffix,
    check_outputs,
    deliver,
    figure_format,
    refuse_other_rigs_options,
    say_report,
)
from impactid.rigs.base import argument_dests
from impactid.rigs.tracks.analysis import air_model_share, analyse_tracks
from impactid.rigs.tracks.commands import SYNTH, SYNTH_SUFFIXES
from impactid.rigs.tracks.figures import figure_names, write_figures
from impactid.rigs.tracks.parameters import MODEL_NAME, TABLE_TENNIS_BALL, TrackParameterError
from impactid.rigs.tracks.readers import LENGTH_UNITS, TIME_UNITS, is_spin_index, read_track
from impactid.rigs.tracks.synth import (
    DEFAULT_FRAME_RATE,
    DEFAULT_HEIGHT,
    DEFAULT_NOISE,
    synth_track,
    write_track,
)

__all__ = ["run", "run_synth"]

#: Defaults of ``impactid synth --rig tracked-ball`` not in :mod:`~impactid.rigs.tracks.synth`'s constants.
SYNTH_DEFAULTS = {"bounce_law": (0.9, 0.0), "mu": 0.25, "horizontal_speed": 0.5, "bounces": 3}
#: The options of other rigs' ``synth`` that mean something close here, and what to give instead.
_SYNTH_HINTS = {"noise": " (the tracked positions' noise is --position-noise M)",
                "sample_rate": " (the track's sampling is --frame-rate FPS)",
                "restitution": " (the tracked ball's restitution law is --bounce-law E0,GAMMA)",
                "restitution_law": " (the tracked ball's restitution law is --bounce-law E0,GAMMA)",
                "jitter": " (the tracked positions' noise is --position-noise M)",
                "ball": " (the tracked ball is the table-tennis ball: --rig tracked-ball)"}


def _ball(args):
    changes = {name: getattr(args, name) for name in ("mass", "diameter", "drag_coefficient", "lift_scale",
                                                       "air_density") if getattr(args, name) is not None}
    if changes.keys() & {"mass", "diameter"}:
        changes["name"] = "custom"
    try:
        return TABLE_TENNIS_BALL.with_(**changes)
    except TrackParameterError as exc:
        raise UsageError(f"argument --mass: {exc}") from None


#: Most analysed bounces printed one per line.
_BOUNCES_PRINTED = 20


def _spin_text(row, side: str, planar: bool) -> str:
    """A bounce's spin before or after (``side`` ``in``/``out``) as ``(wx, wy, wz)`` with standard errors, or
    for a 2-D track (``planar``) the one value, counter-clockwise in its x-y plane as ``--spin`` takes it."""
    parts = []
    for axis in ("y" if planar else "xyz"):
        value = getattr(row, f"spin_{side}_{axis}_rad_s") * (-1.0 if planar else 1.0)
        se = getattr(row, f"spin_{side}_{axis}_rad_s_stderr", math.nan)
        parts.append(_num(value, ".3g") + (f" +- {_num(se, '.2g')}" if math.isfinite(se) and se > 0 else ""))
    return parts[0] if len(parts) == 1 else "(" + ", ".join(parts) + ")"


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
                                         lambda staged: write_figures(result, args.plots, staged,
                                                                        figure_format(args))))
    if not args.json:
        _print_report(result, args, share)
    return 0


def _synth_values(args) -> dict:
    """The values of ``impactid synth --rig tracked-ball``, defaults filled and checked (one-line errors)."""
    e0, gamma = args.bounce_law if args.bounce_law is not None else SYNTH_DEFAULTS["bounce_law"]
    height = DEFAULT_HEIGHT if args.height is None else args.height
    rate = DEFAULT_FRAME_RATE if args.frame_rate is None else args.frame_rate
    spin = args.spin if args.spin is not None else (0.0,)
    values = dict(height=height, horizontal_speed=SYNTH_DEFAULTS["horizontal_speed"] if args.horizontal_speed is None
                  else args.horizontal_speed, e0=e0, gamma=gamma,
                  mu=SYNTH_DEFAULTS["mu"] if args.mu is None else args.mu,
                  bounces=SYNTH_DEFAULTS["bounces"] if args.bounces is None else args.bounces, frame_rate=rate,
                  noise=DEFAULT_NOISE if args.position_noise is None else args.position_noise, seed=args.seed,
                  dimensions=2 if len(spin) == 1 else 3,
                  spin=(0.0, -spin[0], 0.0) if len(spin) == 1 else tuple(spin))  # 2-D: out of x-y is -y inside
    if not 0.005 <= height <= 20.0:
        raise UsageError(f"argument --height: the release height must lie in [0.005, 20] m, got {height:g}")
    speed = math.sqrt(2.0 * 9.80665 * height)
    if not (0.0 < e0 <= 1.0 and gamma >= 0.0 and e0 - gamma * speed >= 0.1):
        raise UsageError(f"argument --bounce-law: e = {e0:g} - {gamma:g} v needs 0 < E0 <= 1, GAMMA >= 0 and e at "
                         f"least 0.1 at the first impact ({speed:.3g} m/s from {height:g} m)")
    if abs(values["horizontal_speed"]) > 50.0:
        raise UsageError(f"argument --horizontal-speed: must lie in [-50, 50] m/s, got {values['horizontal_speed']:g}")
    if max(abs(w) for w in spin) > 2000.0:
        raise UsageError("argument --spin: at most 2000 rad/s (about 19 000 rpm) per component")
    if values["noise"] > 0.1:
        raise UsageError(f"argument --position-noise: at most 0.1 m, got {values['noise']:g}")
    if not 1.0 <= rate <= 100_000.0:
        raise UsageError(f"argument --frame-rate: must lie in [1, 100000] frames/s, got {rate:g}")
    return values


def run_synth(args) -> int:
    """``impactid synth --rig tracked-ball``: a synthetic track (positions against time) of a ball dropped onto
    a surface, as CSV, TSV or a Tracker export, for ``impactid tracks analyse``; returns the exit code."""
    refuse_other_rigs_options(args, argument_dests(SYNTH.arguments), command="synth", model_name=MODEL_NAME,
                              hints=_SYNTH_HINTS)
    check_out_suffix(args.out, SYNTH_SUFFIXES, "a track")
    values = _synth_values(args)
    check_outputs(args, [])
    try:
        track = synth_track(ball=args.resolved_rig.rig, **values)
    except ValueError as exc:
        raise UsageError(f"arguments --height/--bounce-law/--bounces/--frame-rate: {exc}") from None
    write_track(args.out, track, name=Path(args.out).stem)
    e = track.restitution
    sticks = int(track.sticking.sum())
    print(f"{args.out}: {track.dimensions}-D track of a {track.ball.name} ball from {values['height']:g} m, "
          f"{track.time.size} frames at {track.frame_rate:g} fps, {e.size} bounce(s) at "
          f"{track.impact_speeds.max():.3g} to {track.impact_speeds.min():.3g} m/s (e_n {e.max():.3f} to "
          f"{e.min():.3f}; {sticks} of {e.size} stick), position noise {1e3 * track.noise:g} mm")
    return 0


def _print_report(result, args, share) -> None:
    s = result.statistics
    print(f"impactid tracks analyse: {s['tracks']} track(s), {s['bounces_found']} bounce(s) found, "
          f"{s['bounces_analysed']} analysed; surface at {_num(s['surface_height_m'])} m "
          f"({result.details['surface']})")
    for name, p in result.params.items():
        lo, hi = p.interval
        high = "inf (bounded below only)" if hi == math.inf else _num(hi)
        print(f"  {name:<24} {_num(p.value)} [{_num(lo)}, {high}] {p.unit}".rstrip())
    sel = result.details["selected"]
    print(f"  selected by {s['criterion']}: normal {sel.get('normal')}, tangential {sel.get('tangential')}")
    surface_share = result.details.get("surface_share", {})
    if surface_share.get("carried"):
        print(f"  the surface plane's share (its slopes' errors through the normal, in the intervals above): "
              f"e_n_speed_band {_num(surface_share.get('e_n_speed_band', math.nan), '.2g')}, per bounce "
              f"{_num(surface_share['per_bounce_median'], '.2g')} (median)")
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
    analysed = result.bounces[result.bounces["analysed"]]
    planar = {f["details"]["bounce"] for f in result.details["bounce_fits"] if f["details"]["dimensions"] == 2}
    if len(analysed) <= _BOUNCES_PRINTED:
        for row in analysed.itertuples():
            print(f"  bounce {row.bounce}: e_n {_num(row.e_n)} [{_num(row.e_n_low)}, {_num(row.e_n_high)}], beta_t "
                  f"{_num(row.beta_t)} [{_num(row.beta_t_low)}, {_num(row.beta_t_high)}]; spin "
                  f"{_spin_text(row, 'in', row.bounce in planar)} -> {_spin_text(row, 'out', row.bounce in planar)} "
                  f"rad/s ({row.spin_source})")
    else:
        print(f"  {len(analysed)} bounces analysed: their values and spins are in the result's bounces table (--out)")
    not_analysed = result.bounces[~result.bounces["analysed"]]
    for row in not_analysed.itertuples():
        print(f"  not analysed: {row.bounce}: {row.reason}")
    for note in result.notes:
        print(f"  note: {note}")
    if args.out:
        print(f"  result written to {args.out}")
    if args.plots:
        print(f"  figures written to {args.plots}")
    say_report(args)

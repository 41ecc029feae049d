"""The ``impactid`` command line. Thin: parses arguments, calls the public API, prints results.

Units on the command line are SI like everywhere else (``--beta`` in N s m^-(n+1), e.g. 24.7e9 for
the seed's 24.7 GN s m^-2.5), except cam speeds, which are in Hz (``--cam-speed``) as in the papers.
Errors that come from the user's input print one line ``impactid: error: ...`` and exit with 2.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Sequence
from pathlib import Path

from impactid import __version__
from impactid.contact import HuntCrossley
from impactid.errors import ImpactidError
from impactid.rigs import SEED001_TABLE1, PivotedFollowerRig, load_rig_toml

EXIT_INPUT_ERROR = 2


def _rig(args) -> PivotedFollowerRig:
    if getattr(args, "rig", None):
        rig, _ = load_rig_toml(args.rig)
        if not isinstance(rig, PivotedFollowerRig):
            raise ImpactidError(f"{args.rig}: this command supports the 'pivoted-follower' rig only")
    else:
        rig = SEED001_TABLE1
    if getattr(args, "e_over_rc", None) is not None:
        rig = rig.with_eccentricity_ratio(args.e_over_rc)
    return rig


def _law(args) -> HuntCrossley:
    return HuntCrossley(beta=args.beta, n=args.n, clip=getattr(args, "clip", False))


def _json_default(value):
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if hasattr(value, "item"):
        return value.item()
    raise TypeError(type(value).__name__)


def _print_json(data) -> None:
    print(json.dumps(data, indent=2, default=_json_default, allow_nan=False))


def _write_json(path, data) -> None:
    """Write ``data`` as JSON to ``path`` atomically (NaN as null)."""
    from impactid.rigs._toml import write_text_atomic

    write_text_atomic(path, json.dumps(data, indent=2, default=_json_default, allow_nan=False) + "\n")


def _range(text: str) -> list[float]:
    """``a:b:n`` (n values from a to b) or a comma-separated list."""
    import numpy as np

    try:
        if ":" in text:
            a, b, n = text.split(":")
            return [float(x) for x in np.linspace(float(a), float(b), int(n))]
        return [float(x) for x in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected 'start:stop:count' or 'v1,v2,...', got {text!r}") from None


# ---- commands ---------------------------------------------------------------------------------


def cmd_regime(args) -> int:
    from impactid.simulate.regimes import classify_regime, detachment_speed

    rig = _rig(args)
    result = classify_regime(rig, args.cam_speed, _law(args), mu=args.mu, max_revolutions=args.max_revolutions)
    data = result.to_dict()
    data["detachment_hz"] = detachment_speed(rig, mu=args.mu).cam_speed_hz
    if args.json:
        _print_json(data)
    else:
        per = f", {result.period_revolutions} revolution(s)" if result.period_revolutions else ""
        print(f"e/r_c = {rig.e_over_rc:.4g}, cam speed {args.cam_speed:g} Hz: {result.regime}{per}")
        print(f"  impacts per revolution (last window): {result.impacts_per_revolution:.3g}")
        print(f"  simulated {result.simulated_s:.2f} s; detachment speed {data['detachment_hz']:.4g} Hz")
        if result.settling:
            print("  note: the motion was still settling when the run ended")
    return 0


def _named_or_file_rig(spec: str | None, default):
    """A rig from a model name ('pivoted-follower', 'flat-follower': the seeds' tables) or a file."""
    from impactid.rigs import SEED000_TABLE5

    if spec is None:
        return default
    named = {"pivoted-follower": SEED001_TABLE1, "flat-follower": SEED000_TABLE5}
    if spec in named:
        return named[spec]
    rig, _ = load_rig_toml(spec)
    return rig


def cmd_detachment(args) -> int:
    from impactid.rigs import FlatFollowerRig
    from impactid.simulate.regimes import detachment_speed

    rig = _named_or_file_rig(args.rig, SEED001_TABLE1)
    if isinstance(rig, FlatFollowerRig):
        if args.e_over_rc is not None or args.mu is not None:
            raise ImpactidError("--e-over-rc and --mu apply to the pivoted-follower rig only")
        hz = rig.detachment_speed_hz()
        data = {"rig": rig.model, "cam_speed_hz": hz, "cam_speed_rpm": hz * 60.0,
                "method": "inverse kinematics: contact torque (A-11) reaches 0"}
        if args.json:
            _print_json(data)
        else:
            print(f"detachment at {hz:.6g} Hz ({hz * 60:.6g} rpm)")
        return 0
    if args.e_over_rc is not None:
        rig = rig.with_eccentricity_ratio(args.e_over_rc)
    result = detachment_speed(rig, mu=args.mu)
    if args.json:
        _print_json(result.to_dict())
    else:
        print(f"detachment at {result.cam_speed_hz:.6g} Hz ({result.cam_speed_rpm:.6g} rpm), "
              f"cam angle {result.cam_angle:.4f} rad")
    return 0


def _restitution_law(args):
    from impactid.simulate.flat import DEFAULT_RESTITUTION, SpeedRestitution

    if args.restitution is not None:
        return SpeedRestitution(a=args.restitution)
    if args.restitution_law is not None:
        a, b = args.restitution_law
        return SpeedRestitution.from_rpm(a, b)
    return DEFAULT_RESTITUTION


def cmd_bifurcation(args) -> int:
    import numpy as np

    from impactid.rigs import SEED000_TABLE5, FlatFollowerRig
    from impactid.simulate.flat import bifurcation

    rig = _named_or_file_rig(args.rig, SEED000_TABLE5)
    if not isinstance(rig, FlatFollowerRig):
        raise ImpactidError(f"{args.rig}: the bifurcation diagram is implemented for the 'flat-follower' rig only "
                            "(use impactid regime-map for the pivoted follower)")
    scale = {"rpm": 1.0 / 60.0, "hz": 1.0}[args.unit]
    if not (0.0 < args.start < args.stop) or args.speeds < 2:
        raise ImpactidError(f"--from {args.start:g} --to {args.stop:g} --speeds {args.speeds}: need "
                            "0 < from < to and at least 2 speeds")
    speeds = np.linspace(args.start, args.stop, args.speeds) * scale
    law = _restitution_law(args)
    result = bifurcation(rig, speeds, law, revolutions=args.revolutions, kept=args.kept)
    from impactid.reports import write_bifurcation

    paths = write_bifurcation(result, args.out)
    transitions = result.transitions()
    data = {"transitions": transitions, "detachment_rpm_inverse_kinematics": rig.detachment_speed_hz() * 60.0,
            "restitution_law": law.to_dict(), "regime_counts": result.table["regime"].value_counts().to_dict(),
            "revolutions": result.revolutions, "kept": result.kept, "files": [str(x) for x in paths]}
    if args.json:
        _print_json(data)
    else:
        for path in paths:
            print(path)
        print(f"impacts from {transitions['detachment_rpm']:.2f} rpm (inverse kinematics "
              f"{data['detachment_rpm_inverse_kinematics']:.2f} rpm); period-1 until "
              f"{transitions['period1_end_rpm']:.2f} rpm; first irregular {transitions['irregular_rpm']:.2f} rpm")
    return 0


def cmd_restitution(args) -> int:
    import warnings

    from impactid.encoder_impacts import EncoderImpactWarning, fit_speed_law, restitution_at_speed
    from impactid.io import read_recording

    if not args.recordings:
        raise ImpactidError("give one impacting encoder recording per cam speed")
    profile = None
    if args.profile:
        from impactid.camprofile import load_profile_json

        profile = load_profile_json(args.profile)
    rig = None
    if args.rig:
        rig = _named_or_file_rig(args.rig, None)
    points = []
    notes = []
    for path in args.recordings:
        recording = read_recording(path)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", EncoderImpactWarning)
            points.append(restitution_at_speed(recording, profile, method=args.method, rig=rig))
        notes += [str(w.message) for w in caught]
    fit = fit_speed_law(points) if len(points) > 1 else None
    data = {"method": args.method, "profile": args.profile or "analytic A-17 of the recording's rig",
            "points": [p.to_dict() for p in points], "warnings": notes}
    if fit is not None:
        data["fit"] = fit.to_dict()["law"] | {"residual_rms": fit.residual_rms}
    if args.out:
        for path in args.recordings:
            if Path(path).resolve() == Path(args.out).resolve():
                raise ImpactidError(f"--out {args.out} is an input recording; refusing to overwrite it")
        _write_json(args.out, data)
    if args.json:
        _print_json(data)
    else:
        for p in points:
            print(f"{p.source}: {p.cam_speed_rpm:.2f} rpm, r = {p.restitution:.4f} +- {p.stderr:.4f} "
                  f"({p.n_impacts} first impacts, {args.method})")
        if fit is not None:
            law = fit.law.to_dict()
            print(f"r = {law['a']:.4f} + ({law['b_per_rpm']:.6f} +- {fit.stderr_b * 2 * math.pi / 60:.6f}) * rpm "
                  f"(residual RMS {fit.residual_rms:.2g})")
        for note in notes:
            print(f"warning: {note}", file=sys.stderr)
    return 0


def cmd_regime_map(args) -> int:
    from impactid.simulate.regimes import regime_map

    rig = _rig(args)
    out = Path(args.out)

    def progress(done, total):
        if not args.quiet:
            print(f"\r  {done}/{total} operating points", end="", file=sys.stderr, flush=True)

    frame = regime_map(rig, args.e_over_rc_values, args.cam_speeds, _law(args), mu=args.mu, progress=progress,
                       max_revolutions=args.max_revolutions)
    if not args.quiet:
        print(file=sys.stderr)
    from impactid.reports import write_regime_map

    paths = write_regime_map(frame, out)
    for path in paths:
        print(path)
    return 0


def cmd_simulate(args) -> int:
    from impactid.simulate import simulate

    rig = _rig(args)
    run = simulate(rig, args.cam_speed, _law(args), args.duration, mu=args.mu)
    table = run.contacts
    if args.out:
        from impactid.reports import write_csv_atomic

        write_csv_atomic(table, args.out)
    if args.json:
        _print_json({"contacts": len(table), "final_alpha": run.final_alpha, "final_alpha_dot": run.final_alpha_dot,
                     "n_steps": run.n_steps, "contact_table": table.to_dict(orient="list")})
    else:
        print(f"e/r_c = {rig.e_over_rc:.4g}, {args.cam_speed:g} Hz, beta = {args.beta:.4g}, n = {args.n:g}: "
              f"{len(table)} contacts in {args.duration:g} s ({run.n_steps} integrator steps)")
        cols = ["t_start", "duration", "gap_rate_start", "gap_rate_end", "peak_indentation", "peak_force", "xi"]
        with_units = table[cols].tail(args.show).rename(columns={
            "t_start": "t_start[s]", "duration": "duration[s]", "gap_rate_start": "v_approach[m/s]",
            "gap_rate_end": "v_separation[m/s]", "peak_indentation": "peak_indent[m]", "peak_force": "peak_force[N]"})
        print(with_units.to_string(index=False, float_format=lambda x: f"{x:.6g}"))
    return 0


def cmd_synth(args) -> int:
    from data_synth import SensorModel, synth_flat_encoders, synth_pivoted
    from impactid.contact import Restitution
    from impactid.rigs import SEED000_TABLE5, FlatFollowerRig

    if args.rig in (None, "pivoted-follower", "flat-follower"):
        rig = SEED000_TABLE5 if args.rig == "flat-follower" else SEED001_TABLE1
    else:
        rig, _ = load_rig_toml(args.rig)
    noise = {}
    for item in args.noise_channel or []:
        name, _, value = item.partition("=")
        try:
            noise[name] = float(value)
        except ValueError:
            raise ImpactidError(f"--noise-channel expects NAME=FRACTION, got {item!r}") from None
    cam_speed = args.cam_speed if args.rpm is None else args.rpm / 60.0
    if cam_speed is None:
        raise ImpactidError("give the cam speed with --cam-speed HZ or --rpm RPM")
    if isinstance(rig, FlatFollowerRig):
        sensors = SensorModel(noise=noise or 0.0, seed=args.seed)
        synthetic = synth_flat_encoders(rig, cam_speed, args.duration, sample_rate_hz=args.sample_rate or 20_000.0,
                                        cam_ppr=args.cam_ppr or 5000, follower_ppr=args.follower_ppr,
                                        cam_zero_offset=args.cam_zero_offset, sensors=sensors)
    else:
        if args.e_over_rc is not None:
            rig = rig.with_eccentricity_ratio(args.e_over_rc)
        law = (Restitution(gamma=args.gamma) if args.law == "restitution"
               else HuntCrossley(beta=args.beta, n=args.n, clip=args.clip))
        sensors = SensorModel(noise=noise or args.noise, adc_bits=args.adc_bits, accel_offset=args.accel_offset,
                              accel_drift=args.accel_drift, decimation=args.decimate, cam_encoder_ppr=args.cam_ppr,
                              seed=args.seed)
        synthetic = synth_pivoted(rig, cam_speed, law, args.duration, settle_s=args.settle,
                                  sample_rate_hz=args.sample_rate or 204_800.0, sensors=sensors, mu=args.mu)
    path = synthetic.write(args.out)
    rec = synthetic.recording
    print(f"{path}: {rec.rig.model}, {rec.n_samples} samples at {rec.sample_rate_hz:g} Hz "
          f"({', '.join(rec.channels)})")
    return 0


def _recording_path(args):
    if args.example:
        if args.recording:
            raise ImpactidError("give either a recording or --example, not both")
        from impactid.examples import example_recording_path

        return example_recording_path()
    if not args.recording:
        raise ImpactidError("no recording given (pass a file, or --example for the built-in example)")
    return args.recording


def cmd_info(args) -> int:
    from impactid.io import read_recording

    rec = read_recording(_recording_path(args), rig=args.rig)
    info = {
        "file": rec.source, "rig": rec.rig.model if rec.rig is not None else None,
        "sample_rate_hz": rec.sample_rate_hz, "start_time_s": rec.start_time_s, "n_samples": rec.n_samples,
        "duration_s": rec.duration, "operating": dict(rec.operating),
        "channels": {name: {"units": rec.units[name], "min": float(x.min()), "max": float(x.max())}
                     for name, x in rec.channels.items()},
        "provenance": list(rec.provenance),
    }
    if args.json:
        _print_json(info)
    else:
        print(f"{info['file']}: rig {info['rig']}, {rec.n_samples} samples at {rec.sample_rate_hz:g} Hz "
              f"({rec.duration:.6g} s from {rec.start_time_s:g} s)")
        for key, value in rec.operating.items():
            print(f"  {key} = {value:.6g}")
        for name, c in info["channels"].items():
            print(f"  {name} [{c['units']}]: {c['min']:.6g} .. {c['max']:.6g}")
    return 0


def cmd_events(args) -> int:
    from impactid.events import find_events
    from impactid.io import read_recording
    from impactid.reconstruct import reconstruct

    rec = read_recording(_recording_path(args), rig=args.rig)
    events = find_events(rec, threshold=args.threshold, onset_threshold=args.onset_threshold)
    result = reconstruct(rec, events, integration=args.integration, anchor=args.anchor)
    table = result.table
    if args.out:
        from impactid.reports import write_csv_atomic

        write_csv_atomic(table.reset_index(), args.out)
    if args.json:
        _print_json({"events_found": len(events), "events_used": len(table), "noise_sigma": events.noise_sigma,
                     "warnings": list(result.warnings), "provenance": list(result.provenance),
                     "table": table.reset_index().to_dict(orient="list")})
    else:
        print(f"{rec.source}: {len(events)} events found, {len(table)} reconstructed "
              f"(integration {result.integration!r}, anchor {result.anchor!r})")
        cols = ["t_onset", "contact_duration", "alpha_m", "approach_speed", "separation_speed", "xi", "peak_force"]
        print(table[cols].head(args.show).to_string(float_format=lambda x: f"{x:.6g}"))
    return 0


def _progress_bar(enabled: bool):
    """A one-line progress display on stderr (only when enabled, e.g. stderr is a terminal)."""
    if not enabled:
        return None

    def show(stage: str, fraction: float) -> None:
        width = 30
        filled = int(round(width * max(0.0, min(fraction, 1.0))))
        end = "\n" if fraction >= 1.0 else ""
        print(f"\r[{'#' * filled}{'.' * (width - filled)}] {100 * fraction:5.1f}% {stage:<12}", end=end,
              file=sys.stderr, flush=True)

    return show


def _grid_counts(text: str) -> tuple[int, int]:
    try:
        parts = [int(x) for x in text.replace("x", ",").split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected NB[,NN] grid counts, got {text!r}") from None
    if len(parts) == 1:
        parts.append(21)
    if len(parts) != 2 or min(parts) < 3:
        raise argparse.ArgumentTypeError(f"grid counts must be NB[,NN] with each >= 3, got {text!r}")
    return parts[0], parts[1]


def cmd_estimate(args) -> int:
    import warnings as _warnings

    from impactid.estimates import C_BOUNDS, EstimationWarning, estimate

    if args.example:
        from impactid.examples import example_recording_path

        paths = [example_recording_path()] + list(args.recordings)
    elif args.recordings:
        paths = list(args.recordings)
    else:
        raise ImpactidError("give one or more recordings, or --example")
    for p in paths if args.out else ():
        if Path(args.out).resolve() == Path(p).resolve():
            raise ImpactidError(f"{args.out}: refusing to overwrite an input recording")
    rig = None
    if args.rig:
        rig, _ = load_rig_toml(args.rig)
    progress = _progress_bar(args.progress if args.progress is not None else sys.stderr.isatty())
    with _warnings.catch_warnings():
        _warnings.simplefilter("ignore", EstimationWarning)  # collected in the result and printed below
        result = estimate(paths, residual=args.residual, fix_n=args.fix_n,
                          method="grid" if args.grid else "optimise", grid=args.grid or (41, 21), rig=rig,
                          integration=args.integration, anchor=args.anchor, c_bounds=C_BOUNDS,
                          n_bounds=tuple(args.n_range), progress=progress)
    data = result.to_dict()
    data["recordings_read"] = [str(p) for p in paths]
    if _deliver(args, data, "estimate_figures", result):
        return 0
    d, r = result.damping, result.restitution
    unc = data["uncertainty"]
    print(f"impactid estimate: {len(paths)} recording(s), {data['impacts_used']} impacts, residual {d.residual}, "
          f"method {d.method} ({d.n_simulations} S1 simulations, {d.seconds:.2f} s)")
    print(f"  beta  = {d.beta:.5g} N s m^-{d.n + 1:.3g}   interval [{unc['beta_interval'][0]:.5g}, "
          f"{unc['beta_interval'][1]:.5g}]")
    if d.fixed_n:
        print(f"  n     = {d.n:.4g} (fixed)")
    else:
        tag = "" if d.separable else "   NOT SEPARABLE from beta (see warnings)"
        print(f"  n     = {d.n:.4g}   interval [{unc['n_interval'][0]:.4g}, {unc['n_interval'][1]:.4g}]{tag}")
    print(f"  objective (mean {d.residual}) = {d.objective:.4g}")
    print(f"  gamma = {r.gamma:.5g} +- {r.gamma_stderr:.2g} s/m  (xi = 1 - gamma v_a; HC equivalent beta "
          f"{r.beta_equivalent:.4g} N s m^-2.5)")
    print(f"  xi_mean = {r.xi_mean:.5g}, va_mean = {r.va_mean:.5g} m/s, constant r = {r.r_constant:.5g}")
    for message in result.warnings:
        print(f"  warning: {message}")
    _say_written(args)
    return 0


def _deliver(args, data: dict, figures: str, result) -> bool:
    """The outputs shared by ``estimate`` and ``cam-fit``: the figures of ``result`` (by the name
    of their writer in :mod:`impactid.reports`, imported only when asked for) into ``--plots``
    with their paths recorded in ``data``, ``data`` as JSON into ``--out`` (atomically) and, with
    ``--json``, on stdout. Returns True when the JSON was printed (no text report then)."""
    if args.plots:
        from impactid import reports

        data["plots"] = [str(p) for p in getattr(reports, figures)(result, args.plots)]
    if args.out:
        _write_json(args.out, data)
    if args.json:
        _print_json(data)
        return True
    return False


def _say_written(args) -> None:
    if args.out:
        print(f"  result written to {args.out}")
    if args.plots:
        print(f"  figures written to {args.plots}")


def cmd_cam_fit(args) -> int:
    from impactid.camprofile import fit_cam_profile
    from impactid.io import read_recording

    path = _recording_path(args)
    if args.out and Path(args.out).resolve() == Path(path).resolve():
        raise ImpactidError(f"{args.out}: refusing to overwrite the input recording")
    terms = args.terms.strip().lower()
    if terms != "auto":
        try:
            terms = int(terms)
        except ValueError:
            raise ImpactidError(f"--terms expects a positive integer or 'auto', got {args.terms!r}") from None
    window = None
    if args.window:
        try:
            window = tuple(float(v) for v in args.window.split(","))
        except ValueError:
            window = ()
        if len(window) != 2:
            raise ImpactidError(f"--window expects T0,T1 in seconds, got {args.window!r}")
    rec = read_recording(path, rig=args.rig)
    fit = fit_cam_profile(rec, terms, criterion=args.criterion, max_terms=args.max_terms, window=window,
                          nonnegative=not args.signed, counter=args.counter)
    data = fit.to_dict(samples=3600)
    data["recording"] = str(path)
    if _deliver(args, data, "cam_fit_figures", fit):
        return 0
    print(fit.report())
    _say_written(args)
    return 0


# ---- parser -----------------------------------------------------------------------------------


def _add_rig_args(p: argparse.ArgumentParser, with_ratio: bool = True) -> None:
    p.add_argument("--rig", metavar="RIG.toml", help="rig file (FORMAT.md); default: seed 001 Table 1")
    if with_ratio:
        p.add_argument("--e-over-rc", type=float, default=None, help="eccentricity ratio e/r_c (default: rig's)")


def _add_recording_args(p: argparse.ArgumentParser, several: bool = False) -> None:
    if several:
        p.add_argument("recordings", metavar="REC", nargs="*", help="HDF5 or CSV recordings (several: joint fit)")
    else:
        p.add_argument("recording", metavar="REC", nargs="?", help="HDF5 or CSV recording")
    p.add_argument("--example", action="store_true", help="use the built-in example recording")
    p.add_argument("--rig", metavar="RIG.toml", help="rig file that supplies or overrides the recording's rig")


def _add_kinematics_args(p: argparse.ArgumentParser, anchor: str) -> None:
    from impactid.reconstruct import ANCHORS
    from impactid.signal import INTEGRATORS

    p.add_argument("--integration", default="rk", choices=list(INTEGRATORS),
                   help="integration method (default rk, as in the paper)")
    p.add_argument("--anchor", default=anchor, choices=list(ANCHORS),
                   help=f"integration-constant anchor (default {anchor}; return-time is the paper's)")


def _add_law_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--beta", type=float, default=24.7e9, help="damping coefficient [N s m^-(n+1)] (default 24.7e9)")
    p.add_argument("--n", type=float, default=1.5, help="damping index (default 1.5)")
    p.add_argument("--mu", type=float, default=None, help="friction coefficient (default: rig's)")
    p.add_argument("--clip", action="store_true", help="clip tensile contact force to 0")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="impactid", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"impactid {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("regime", help="classify the motion of rig P at one operating point")
    _add_rig_args(p)
    p.add_argument("--cam-speed", type=float, required=True, metavar="HZ", help="cam speed [Hz]")
    _add_law_args(p)
    p.add_argument("--max-revolutions", type=int, default=2000, help="longest run while settling")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=cmd_regime)

    p = sub.add_parser("detachment", help="cam speed at which the follower leaves the cam (inverse kinematics)")
    p.add_argument("--rig", metavar="RIG.toml|MODEL",
                   help="rig file or 'pivoted-follower' / 'flat-follower' (the seeds' tables); default pivoted")
    p.add_argument("--e-over-rc", type=float, default=None, help="eccentricity ratio e/r_c (rig P)")
    p.add_argument("--mu", type=float, default=None, help="friction coefficient (default: rig's)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=cmd_detachment)

    p = sub.add_parser("bifurcation", help="rig F bifurcation diagram over cam speed, CSV and PNG (seed 000 Fig. 16)")
    p.add_argument("--rig", metavar="RIG.toml|MODEL", help="flat-follower rig file; default seed 000 Table 5")
    p.add_argument("--from", dest="start", type=float, default=110.0, help="lowest cam speed (default 110)")
    p.add_argument("--to", dest="stop", type=float, default=165.0, help="highest cam speed (default 165)")
    p.add_argument("--unit", choices=["rpm", "hz"], default="rpm", help="unit of --from/--to (default rpm)")
    p.add_argument("--speeds", type=int, default=200, help="number of cam speeds (default 200)")
    p.add_argument("--revolutions", type=int, default=100, help="revolutions simulated per speed (default 100)")
    p.add_argument("--kept", type=int, default=None, help="last revolutions plotted and classified (default half)")
    group = p.add_mutually_exclusive_group()
    group.add_argument("--restitution", type=float, default=None, help="constant coefficient of restitution")
    group.add_argument("--restitution-law", type=lambda t: tuple(float(v) for v in t.split(",")), default=None,
                       metavar="A,B", help="r = A + B * rpm (default: our stand-in law, see README)")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=cmd_bifurcation)

    p = sub.add_parser("restitution", help="rig F: coefficient of restitution per cam speed from impacting "
                                           "encoder recordings, and r = a + b omega")
    p.add_argument("recordings", metavar="REC", nargs="*", help="impacting encoder recordings (one per cam speed)")
    p.add_argument("--profile", metavar="fit.json", help="cam profile from impactid cam-fit (default: analytic A-17)")
    p.add_argument("--method", choices=["impact-law", "first-bounce"], default="impact-law",
                   help="impact-law: fitted flight rates either side of each first impact; first-bounce: the "
                        "model's r that reproduces the first-bounce height (seed 000)")
    p.add_argument("--rig", metavar="RIG.toml|MODEL", help="rig for first-bounce (default: the recording's)")
    p.add_argument("--out", metavar="law.json", help="write the results as JSON (atomically)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=cmd_restitution)

    p = sub.add_parser("regime-map", help="regime map over (e/r_c, cam speed), CSV and PNG (Fig. 3 of seed 001)")
    _add_rig_args(p, with_ratio=False)
    p.add_argument("--e-over-rc-values", type=_range, default=_range("0.05:0.25:5"),
                   help="e/r_c values: 'start:stop:count' or a list (default 0.05:0.25:5)")
    p.add_argument("--cam-speeds", type=_range, default=_range("4:24:21"),
                   help="cam speeds [Hz]: 'start:stop:count' or a list (default 4:24:21)")
    _add_law_args(p)
    p.add_argument("--max-revolutions", type=int, default=2000, help="longest run per point while settling")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    p.add_argument("--quiet", action="store_true", help="no progress output")
    p.set_defaults(func=cmd_regime_map)

    p = sub.add_parser("simulate", help="long S2 run from static equilibrium; prints the contact table")
    _add_rig_args(p)
    p.add_argument("--cam-speed", type=float, required=True, metavar="HZ", help="cam speed [Hz]")
    p.add_argument("--duration", type=float, default=2.0, help="simulated time [s] (default 2)")
    _add_law_args(p)
    p.add_argument("--out", metavar="CONTACTS.csv", help="write the contact table as CSV")
    p.add_argument("--show", type=int, default=8, help="rows of the contact table to print (last ones)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=cmd_simulate)

    p = sub.add_parser("synth", help="write a synthetic recording (S2/S3 of rig P, encoders of rig F)")
    p.add_argument("--rig", default="pivoted-follower", metavar="MODEL|RIG.toml",
                   help="'pivoted-follower' (seed 001 Table 1), 'flat-follower' (seed 000 Table 5) or a rig file")
    p.add_argument("--e-over-rc", type=float, default=None, help="eccentricity ratio e/r_c (rig P)")
    p.add_argument("--cam-speed", type=float, default=None, metavar="HZ", help="cam speed [Hz]")
    p.add_argument("--rpm", type=float, default=None, help="cam speed [rpm] (instead of --cam-speed)")
    p.add_argument("--law", choices=["hunt-crossley", "restitution"], default="hunt-crossley",
                   help="contact law (S2) or restitution law (S3)")
    _add_law_args(p)
    p.add_argument("--gamma", type=float, default=0.8, help="restitution law xi = 1 - gamma v_a [s/m] (default 0.8)")
    p.add_argument("--duration", type=float, default=2.0, help="recorded time [s] (default 2)")
    p.add_argument("--settle", type=float, default=40.0, help="discarded settling time [s] (default 40)")
    p.add_argument("--sample-rate", type=float, default=None,
                   help="sample rate [Hz] (default 204800 for rig P, 20000 for rig F)")
    p.add_argument("--noise", type=float, default=0.0, help="Gaussian noise, fraction of peak, analogue channels")
    p.add_argument("--noise-channel", action="append", metavar="NAME=FRACTION", help="noise of one channel")
    p.add_argument("--adc-bits", type=int, default=None, help="ADC resolution [bits] (default: none)")
    p.add_argument("--accel-offset", type=float, default=0.0, help="accelerometer offset [m/s^2]")
    p.add_argument("--accel-drift", type=float, default=0.0, help="accelerometer drift [m/s^2 per s]")
    p.add_argument("--decimate", type=int, default=1, help="anti-alias filter and decimation factor (default 1)")
    p.add_argument("--cam-ppr", type=int, default=None, help="cam encoder pulses/rev (rig F default 5000)")
    p.add_argument("--follower-ppr", type=int, default=10_000, help="follower encoder pulses/rev (rig F)")
    p.add_argument("--cam-zero-offset", type=float, default=None, help="cam encoder zero [rad] (rig F; default random)")
    p.add_argument("--seed", type=int, default=0, help="random seed")
    p.add_argument("--out", required=True, metavar="FILE.h5", help="output HDF5 file")
    p.set_defaults(func=cmd_synth)

    p = sub.add_parser("info", help="read and validate a recording; print what it holds")
    _add_recording_args(p)
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=cmd_info)

    p = sub.add_parser("events", help="find impacts and reconstruct each one (alpha, v_a, xi, contact force)")
    _add_recording_args(p)
    _add_kinematics_args(p, anchor="return-time")
    p.add_argument("--threshold", type=float, default=None, help="pulse detection level [m/s^2] (default: from noise)")
    p.add_argument("--onset-threshold", type=float, default=None, help="contact onset level [m/s^2]")
    p.add_argument("--out", metavar="EVENTS.csv", help="write the per-event table as CSV")
    p.add_argument("--show", type=int, default=10, help="rows to print")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=cmd_events)

    p = sub.add_parser("estimate", help="estimate Hunt-Crossley beta, n and the restitution law from recordings")
    _add_recording_args(p, several=True)
    p.add_argument("--residual", default="lambda1", choices=["lambda1", "lambda2", "lambda3"],
                   help="residual minimised (default lambda1: accelerometer only)")
    p.add_argument("--fix-n", type=float, default=None, metavar="N", help="fix the exponent n (0: viscous)")
    p.add_argument("--grid", type=_grid_counts, default=None, metavar="NB[,NN]",
                   help="paper-style grid search with NB values of beta (log) and NN of n instead of the optimiser")
    p.add_argument("--n-range", type=float, nargs=2, default=[0.5, 2.5], metavar=("LO", "HI"),
                   help="search bounds of n (default 0.5 2.5)")
    _add_kinematics_args(p, anchor="cam-phase")
    p.add_argument("--out", metavar="RESULT.json", help="write the result as JSON (atomically)")
    p.add_argument("--plots", metavar="DIR", help="write figures (hysteresis, restitution, landscape, residuals)")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                   help="progress bar on stderr (default: when stderr is a terminal)")
    p.set_defaults(func=cmd_estimate)

    p = sub.add_parser("cam-fit", help="fit a Gaussian-sum cam profile (seed 000, eq. 1) to rig F encoder data")
    _add_recording_args(p)
    p.add_argument("--terms", default="7", metavar="N|auto",
                   help="number of Gaussian terms, or 'auto' to choose 1..--max-terms by --criterion (default 7)")
    p.add_argument("--max-terms", type=int, default=9, help="highest order tried by --terms auto (default 9)")
    p.add_argument("--criterion", choices=["bic", "aic"], default="bic", help="order-selection criterion (default bic)")
    p.add_argument("--window", metavar="T0,T1",
                   help="use only the samples with T0 <= t < T1 [s] (revolutions are still checked inside it)")
    p.add_argument("--counter", choices=["floor", "round", "none"], default="floor",
                   help="encoder counters floor (incremental counter, default) or round; 'none': no correction")
    p.add_argument("--signed", action="store_true", help="allow negative amplitudes (default a_i >= 0)")
    p.add_argument("--out", metavar="FIT.json",
                   help="write coefficients, statistics and the sampled profile as JSON (atomically)")
    p.add_argument("--plots", metavar="DIR",
                   help="write figures (data and fit, residuals, derivatives, order selection)")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.set_defaults(func=cmd_cam_fit)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``impactid`` command; returns the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except ImpactidError as exc:
        print(f"impactid: error: {exc}", file=sys.stderr)
        return EXIT_INPUT_ERROR


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

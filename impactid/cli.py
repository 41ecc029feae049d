"""The ``impactid`` command line. Thin: parses arguments, calls the public API, prints results.

Units on the command line are SI like everywhere else (``--beta`` in N s m^-(n+1), e.g. 24.7e9 for
the paper's 24.7 GN s m^-2.5), except cam speeds, which are in Hz (``--cam-speed``) or rpm
(``--rpm``) as in the papers.

Failure is a result too. Every problem a user can cause (a bad file, channel, argument or output
path, Ctrl-C, SIGTERM) ends in one line ``impactid: error: ...`` on stderr naming the file,
channel or argument, with exit status 2 (130 after Ctrl-C, 143 after SIGTERM); inputs are never
modified, output paths are checked before any computation starts, and outputs are written as one
transaction (:mod:`impactid._files`), so an interrupted or failed command leaves no partial file.
The result (JSON) is committed before the figures, so a failure while plotting keeps it. Warnings
print as ``impactid: warning: ...`` lines, each once.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import signal
import sys
import threading
import warnings
from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np

from impactid import __version__
from impactid._files import (
    StagedFiles,
    TerminationRequested,
    check_output,
    request_termination,
    termination_requested,
)
from impactid.commandline import (
    UsageError,
)
from impactid.commandline import (
    exponent as _exponent,
)
from impactid.commandline import (
    fraction as _fraction,
)
from impactid.commandline import (
    integer_in as _integer,
)
from impactid.commandline import (
    json_text as _json_text,
)
from impactid.commandline import (
    nonnegative as _nonnegative,
)
from impactid.commandline import (
    num as _num,
)
from impactid.commandline import (
    number as _number,
)
from impactid.commandline import (
    pair as _pair,
)
from impactid.commandline import (
    positive as _positive,
)
from impactid.commandline import (
    print_json as _print_json,
)
from impactid.contact import HuntCrossley
from impactid.distributed import add_scheduler_arguments
from impactid.errors import ImpactidError

__all__ = ["UsageError", "build_parser", "main", "resolve_rig"]

EXIT_INPUT_ERROR = 2
EXIT_INTERRUPTED = 130
EXIT_TERMINATED = 143
#: Largest grid of trial laws ``--grid NB,NN`` accepts (each costs one S1 run per impact).
MAX_GRID_POINTS = 100_000
#: Largest number of operating points of ``regime-map`` and speeds of ``bifurcation``.
MAX_SWEEP_POINTS = 10_000
#: Largest number of samples ``synth`` generates (times the decimation factor).
MAX_SYNTH_SAMPLES = 200_000_000


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors (``impactid: error: argument --x: ...``) raised, not printed."""

    def error(self, message: str):  # noqa: D401 - argparse API
        raise UsageError(message)


# ---- argument types ---------------------------------------------------------------------------


def _range(text: str) -> list[float]:
    """``a:b:n`` (n values from a to b) or a comma-separated list of positive numbers."""
    try:
        if ":" in text:
            a, b, n = text.split(":")
            count = int(n)
            if not 1 <= count <= MAX_SWEEP_POINTS:
                raise argparse.ArgumentTypeError(f"the count in {text!r} must lie in [1, {MAX_SWEEP_POINTS}]")
            values = [float(x) for x in np.linspace(_number(a), _number(b), count)]
        else:
            values = [_number(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected 'start:stop:count' or 'v1,v2,...', got {text!r}") from None
    if not values:
        raise argparse.ArgumentTypeError(f"no values in {text!r}")
    if min(values) <= 0.0:
        raise argparse.ArgumentTypeError(f"values must be positive, got {text!r}")
    return values


def _grid_counts(text: str) -> tuple[int, int]:
    try:
        parts = [int(x) for x in text.replace("x", ",").split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected NB[,NN] grid counts, got {text!r}") from None
    if len(parts) == 1:
        parts.append(21)
    if len(parts) != 2 or min(parts) < 3:
        raise argparse.ArgumentTypeError(f"grid counts must be NB[,NN] with each >= 3, got {text!r}")
    if parts[0] * parts[1] > MAX_GRID_POINTS:
        raise argparse.ArgumentTypeError(
            f"{text!r} asks for {parts[0] * parts[1]:,} trial laws (each simulated for every impact); at most "
            f"{MAX_GRID_POINTS:,}: use the optimiser (no --grid) for a precise estimate")
    return parts[0], parts[1]


# ---- shared plumbing --------------------------------------------------------------------------


def _rig_presets() -> dict:
    """The default parameter set of every registered rig that rig files describe, by model name."""
    from impactid.rigs.registry import MODELS, RIG_MODELS

    return {name: MODELS[name].default for name in RIG_MODELS}


def _is_rig_file(spec: str | None) -> bool:
    return spec is not None and spec not in _rig_presets()


def resolve_rig(spec: str | None, default=None) -> tuple[object, dict]:
    """The one rig resolver of every command: ``spec`` is a rig model name (its preset: the
    papers' parameter tables) or a TOML rig file; returns ``(rig, operating)`` where ``operating``
    is the file's ``[operating]`` table (empty for a preset)."""
    from impactid.rigs import load_rig_toml

    if spec is None:
        return default, {}
    presets = _rig_presets()
    if spec in presets:
        return presets[spec], {}
    return load_rig_toml(spec)


def _pivoted(args, command: str):
    """Rig P for a simulation command (``--rig``, then ``--e-over-rc``), and the rig file's operating point."""
    from impactid.rigs import SUNDAR2016, PivotedFollowerRig

    rig, operating = resolve_rig(getattr(args, "rig", None), SUNDAR2016)
    if not isinstance(rig, PivotedFollowerRig):
        raise UsageError(f"argument --rig: '{command}' simulates the 'pivoted-follower' rig only, "
                         f"got a {rig.model!r} rig")
    if getattr(args, "e_over_rc", None) is not None:
        rig = rig.with_eccentricity_ratio(args.e_over_rc)
    return rig, operating


def _cam_speed(args, operating: dict, required: bool = True) -> float | None:
    """``--cam-speed`` [Hz] or ``--rpm``, else the rig file's ``[operating] cam_speed_hz``."""
    if getattr(args, "rpm", None) is not None:
        return args.rpm / 60.0
    if getattr(args, "cam_speed", None) is not None:
        return args.cam_speed
    if "cam_speed_hz" in operating:
        return float(operating["cam_speed_hz"])
    if required:
        raise UsageError("no cam speed: give --cam-speed HZ (or --rpm RPM), or a rig file with "
                         "[operating] cam_speed_hz")
    return None


def _law(args) -> HuntCrossley:
    return HuntCrossley(beta=args.beta, n=args.n, clip=getattr(args, "clip", False))


def _recording_rig(args):
    """``--rig`` of a recording command: a TOML file path (it supplies the rig and operating point) or
    a preset rig by model name; None to use the recording's own."""
    spec = getattr(args, "rig", None)
    if spec is None:
        return None
    return _rig_presets().get(spec, spec)


def _sibling_tomls(paths) -> list[Path]:
    return [Path(p).with_suffix(".toml") for p in paths if str(p).lower().endswith((".csv", ".txt"))]


def _inputs(args, recordings: Sequence) -> list:
    """Every input file of a command (for the output checks): recordings, their sibling rig files,
    ``--rig`` and ``--profile`` files."""
    files = list(recordings) + _sibling_tomls(recordings)
    if _is_rig_file(getattr(args, "rig", None)):
        files.append(args.rig)
    if getattr(args, "profile", None):
        files.append(args.profile)
    return files


def _check_outputs(args, inputs: Sequence, *, out: str = "out", out_is_dir: bool = False) -> None:
    """Check ``--out`` and ``--plots`` before the computation starts."""
    if getattr(args, out, None):
        check_output(getattr(args, out), option="--out", inputs=inputs, directory=out_is_dir)
    if getattr(args, "plots", None):
        check_output(args.plots, option="--plots", inputs=inputs, directory=True)


def _example_paths(args, several: bool) -> list:
    from impactid.examples import example_recording_paths

    paths = example_recording_paths()
    return paths if several else paths[:1]


def _recording_paths(args, several: bool = False) -> list:
    given = list(args.recordings) if several else ([args.recording] if args.recording else [])
    if args.example:
        if given and not several:
            raise UsageError("give either a recording or --example, not both")
        return _example_paths(args, several) + given
    if not given:
        what = "give one or more recordings" if several else "no recording given (pass a file"
        raise UsageError(f"{what}, or --example for the built-in example" + ("" if several else ")"))
    return given


def _deliver(args, data: dict, figures: str | None, result, inputs: Sequence) -> None:
    """Write ``data`` as JSON to ``--out`` (committed first), then the figures of ``result`` (by
    the name of their writer in :mod:`impactid.reports`) into ``--plots``, as a second
    transaction; ``--json`` prints the JSON on stdout."""
    if args.plots and figures:
        data["plots"] = [str(Path(args.plots) / name) for name in _figure_names(figures, result)]
    if args.out:
        with StagedFiles(protect=inputs) as staged:
            staged.write_text(args.out, _json_text(data))
    if args.plots and figures:
        from impactid import reports

        with StagedFiles(protect=inputs) as staged:
            getattr(reports, figures)(result, args.plots, staged)
    if args.json:
        _print_json(data)


def _figure_names(figures: str, result) -> list[str]:
    if figures == "estimate_figures":
        names = ["hysteresis.png", "landscape.png", "residuals.png"]
        return names[:1] + (["restitution.png"] if result.restitution is not None else []) + names[1:]
    names = ["cam_fit.png"]
    return names + (["cam_fit_order.png"] if getattr(result, "order_table", None) is not None else [])


def _say_written(args) -> None:
    if args.out:
        print(f"  result written to {args.out}")
    if args.plots:
        print(f"  figures written to {args.plots}")


# ---- commands ---------------------------------------------------------------------------------


def cmd_regime(args) -> int:
    from impactid.simulate.regimes import classify_regime, detachment_speed

    rig, operating = _pivoted(args, "regime")
    cam_speed = _cam_speed(args, operating)
    result = classify_regime(rig, cam_speed, _law(args), mu=args.mu, max_revolutions=args.max_revolutions)
    data = result.to_dict()
    data["detachment_hz"] = detachment_speed(rig, mu=args.mu).cam_speed_hz
    if args.json:
        _print_json(data)
    else:
        per = f", {result.period_revolutions} revolution(s)" if result.period_revolutions else ""
        print(f"e/r_c = {rig.e_over_rc:.4g}, cam speed {cam_speed:g} Hz: {result.regime}{per}")
        print(f"  impacts per revolution (last window): {result.impacts_per_revolution:.3g}")
        print(f"  simulated {result.simulated_s:.2f} s; detachment speed {data['detachment_hz']:.4g} Hz")
        if result.settling:
            print("  note: the motion was still settling when the run ended")
    return 0


def cmd_detachment(args) -> int:
    from impactid.rigs import SUNDAR2016, FlatFollowerRig
    from impactid.simulate.regimes import detachment_speed

    rig, _ = resolve_rig(args.rig, SUNDAR2016)
    if isinstance(rig, FlatFollowerRig):
        if args.e_over_rc is not None or args.mu is not None:
            raise UsageError("arguments --e-over-rc and --mu apply to the pivoted-follower rig only")
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
    from impactid.rigs.flat.simulate import DEFAULT_RESTITUTION, SpeedRestitution

    if args.restitution is not None:
        return SpeedRestitution(a=args.restitution)
    if args.restitution_law is not None:
        a, b = args.restitution_law
        return SpeedRestitution.from_rpm(a, b)
    return DEFAULT_RESTITUTION


def cmd_bifurcation(args) -> int:
    from impactid.rigs import ALZATE2007, FlatFollowerRig
    from impactid.rigs.flat.simulate import bifurcation

    rig, _ = resolve_rig(args.rig, ALZATE2007)
    if not isinstance(rig, FlatFollowerRig):
        raise UsageError(f"argument --rig: the bifurcation diagram is implemented for the 'flat-follower' rig only, "
                         f"got {rig.model!r} (use impactid regime-map for the pivoted follower)")
    if not args.start < args.stop:
        raise UsageError(f"arguments --from/--to: need from < to, got {args.start:g} and {args.stop:g}")
    if args.kept is not None and args.kept > args.revolutions:
        raise UsageError(f"argument --kept: at most --revolutions ({args.revolutions}), got {args.kept}")
    scale = {"rpm": 1.0 / 60.0, "hz": 1.0}[args.unit]
    _check_outputs(args, _inputs(args, []), out_is_dir=True)
    speeds = np.linspace(args.start, args.stop, args.speeds) * scale
    law = _restitution_law(args)
    from impactid.distributed import progress_bar, scheduler_client

    with scheduler_client(args, what="impactid bifurcation") as client, \
            progress_bar(args.speeds, desc="bifurcation", unit="speed") as bar:
        result = bifurcation(rig, speeds, law, revolutions=args.revolutions, kept=args.kept, client=client,
                             progress=lambda done, total: bar.update(done - bar.n))
    from impactid.reports import write_bifurcation

    with StagedFiles(protect=_inputs(args, [])) as staged:
        paths = write_bifurcation(result, args.out, staged)
    transitions = result.transitions()
    data = {"transitions": transitions, "detachment_rpm_inverse_kinematics": rig.detachment_speed_hz() * 60.0,
            "restitution_law": law.to_dict(), "regime_counts": result.table["regime"].value_counts().to_dict(),
            "revolutions": result.revolutions, "kept": result.kept, "files": [str(x) for x in paths]}
    if args.json:
        _print_json(data)
    else:
        for path in paths:
            print(path)
        print(f"impacts from {_num(transitions['detachment_rpm'], '.2f')} rpm (inverse kinematics "
              f"{data['detachment_rpm_inverse_kinematics']:.2f} rpm); period-1 until "
              f"{_num(transitions['period1_end_rpm'], '.2f')} rpm; first irregular "
              f"{_num(transitions['irregular_rpm'], '.2f')} rpm")
    return 0


def cmd_restitution(args) -> int:
    from impactid.encoder_impacts import EncoderImpactWarning, fit_speed_law, restitution_at_speed
    from impactid.io import read_recording

    if not args.recordings:
        raise UsageError("give one impacting encoder recording per cam speed")
    inputs = _inputs(args, args.recordings)
    _check_outputs(args, inputs)
    profile = None
    if args.profile:
        from impactid.camprofile import load_profile_json

        profile = load_profile_json(args.profile)
    rig = None
    if args.rig:
        rig, _ = resolve_rig(args.rig)
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
        with StagedFiles(protect=inputs) as staged:
            staged.write_text(args.out, _json_text(data))
    if args.json:
        _print_json(data)
    else:
        for p in points:
            print(f"{p.source}: {p.cam_speed_rpm:.2f} rpm, r = {_num(p.restitution, '.4f')} +- {_num(p.stderr, '.4f')} "
                  f"({p.n_impacts} first impacts, {args.method})")
        if fit is not None:
            law = fit.law.to_dict()
            print(f"r = {law['a']:.4f} + ({law['b_per_rpm']:.6f} +- {_num(fit.stderr_b * 2 * math.pi / 60, '.6f')})"
                  f" * rpm (residual RMS {fit.residual_rms:.2g})")
        for note in notes:
            print(f"impactid: warning: {note}", file=sys.stderr)
    return 0


def cmd_regime_map(args) -> int:
    from impactid.simulate.regimes import regime_map

    rig, _ = _pivoted(args, "regime-map")
    points = len(args.e_over_rc_values) * len(args.cam_speeds)
    if points > MAX_SWEEP_POINTS:
        raise UsageError(f"arguments --e-over-rc-values/--cam-speeds: {points:,} operating points; at most "
                         f"{MAX_SWEEP_POINTS:,}")
    _check_outputs(args, _inputs(args, []), out_is_dir=True)
    for ratio in args.e_over_rc_values:  # every ratio checked before the long run
        rig.with_eccentricity_ratio(ratio)

    from impactid.distributed import progress_bar, scheduler_client

    with scheduler_client(args, what="impactid regime-map") as client, \
            progress_bar(points, enabled=not args.quiet, desc="regime map", unit="point") as bar:
        frame = regime_map(rig, args.e_over_rc_values, args.cam_speeds, _law(args), mu=args.mu,
                           progress=lambda done, total: bar.update(done - bar.n),
                           max_revolutions=args.max_revolutions, client=client)
    from impactid.reports import write_regime_map

    with StagedFiles(protect=_inputs(args, [])) as staged:
        paths = write_regime_map(frame, args.out, staged)
    for path in paths:
        print(path)
    return 0


def cmd_simulate(args) -> int:
    from impactid.simulate import simulate

    rig, operating = _pivoted(args, "simulate")
    cam_speed = _cam_speed(args, operating)
    _check_outputs(args, _inputs(args, []))
    run = simulate(rig, cam_speed, _law(args), args.duration, mu=args.mu)
    table = run.contacts
    if args.out:
        from impactid.reports import write_csv_atomic

        with StagedFiles(protect=_inputs(args, [])) as staged:
            write_csv_atomic(table, args.out, staged)
    if args.json:
        _print_json({"contacts": len(table), "final_alpha": run.final_alpha, "final_alpha_dot": run.final_alpha_dot,
                     "n_steps": run.n_steps, "contact_table": table.to_dict(orient="list")})
    else:
        print(f"e/r_c = {rig.e_over_rc:.4g}, {cam_speed:g} Hz, beta = {args.beta:.4g}, n = {args.n:g}: "
              f"{len(table)} contacts in {args.duration:g} s ({run.n_steps} integrator steps)")
        cols = ["t_start", "duration", "gap_rate_start", "gap_rate_end", "peak_indentation", "peak_force", "xi"]
        with_units = table[cols].tail(args.show).rename(columns={
            "t_start": "t_start[s]", "duration": "duration[s]", "gap_rate_start": "v_approach[m/s]",
            "gap_rate_end": "v_separation[m/s]", "peak_indentation": "peak_indent[m]", "peak_force": "peak_force[N]"})
        print(with_units.to_string(index=False, float_format=lambda x: f"{x:.6g}"))
    return 0


def cmd_synth(args) -> int:
    from impactid.contact import Restitution
    from impactid.rigs import SUNDAR2016, FlatFollowerRig
    from impactid.synth import SensorModel, synth_flat_encoders, synth_pivoted

    rig, operating = resolve_rig(args.rig, SUNDAR2016)
    noise = {}
    for item in args.noise_channel or []:
        name, _, value = item.partition("=")
        try:
            noise[name] = _fraction(value)
        except argparse.ArgumentTypeError as exc:
            raise UsageError(f"argument --noise-channel: expected NAME=FRACTION, got {item!r} ({exc})") from None
    cam_speed = _cam_speed(args, operating)
    flat = isinstance(rig, FlatFollowerRig)
    rate = args.sample_rate or (20_000.0 if flat else 204_800.0)
    samples = args.duration * rate * (1 if flat else args.decimate)
    if samples > MAX_SYNTH_SAMPLES:
        raise UsageError(f"arguments --duration/--sample-rate/--decimate: {samples:.3g} samples to generate; at most "
                         f"{MAX_SYNTH_SAMPLES:.3g} (split the recording)")
    _check_outputs(args, _inputs(args, []))
    if flat:
        sensors = SensorModel(noise=noise or 0.0, seed=args.seed)
        synthetic = synth_flat_encoders(rig, cam_speed, args.duration, sample_rate_hz=rate,
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
                                  sample_rate_hz=rate, sensors=sensors, mu=args.mu)
    from impactid.io import write_hdf5

    path = write_hdf5(synthetic.recording, args.out, truth=synthetic.truth)
    rec = synthetic.recording
    print(f"{path}: {rec.rig.model}, {rec.n_samples} samples at {rec.sample_rate_hz:g} Hz "
          f"({', '.join(rec.channels)})")
    return 0


def cmd_info(args) -> int:
    from impactid.io import read_recording

    rec = read_recording(_recording_paths(args)[0], rig=_recording_rig(args))
    info = {
        "file": rec.source, "rig": rec.rig.model if rec.rig is not None else None,
        "sample_rate_hz": rec.sample_rate_hz, "start_time_s": rec.start_time_s, "n_samples": rec.n_samples,
        "duration_s": rec.duration, "operating": dict(rec.operating),
        "channels": {name: {"units": rec.units[name], "min": rec.channel_range(name)[0],
                            "max": rec.channel_range(name)[1]} for name in rec.channels},
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

    path = _recording_paths(args)[0]
    inputs = _inputs(args, [path])
    _check_outputs(args, inputs)
    rec = read_recording(path, rig=_recording_rig(args))
    events = find_events(rec, threshold=args.threshold, onset_threshold=args.onset_threshold)
    result = reconstruct(rec, events, integration=args.integration, anchor=args.anchor)
    table = result.table
    if args.out:
        from impactid.reports import write_csv_atomic

        with StagedFiles(protect=inputs) as staged:
            write_csv_atomic(table.reset_index(), args.out, staged)
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


def cmd_estimate(args) -> int:
    from impactid.estimates import C_BOUNDS, EstimationWarning, estimate

    paths = _recording_paths(args, several=True)
    lo, hi = args.n_range
    if not lo < hi:
        raise UsageError(f"argument --n-range: need LO < HI, got {lo:g} {hi:g}")
    inputs = _inputs(args, paths)
    _check_outputs(args, inputs)
    progress = _progress_bar(args.progress if args.progress is not None else sys.stderr.isatty())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EstimationWarning)  # collected in the result and printed below
        result = estimate(paths, residual=args.residual, fix_n=args.fix_n,
                          method="grid" if args.grid else args.method, grid=args.grid or (41, 21),
                          rig=_recording_rig(args), integration=args.integration, anchor=args.anchor,
                          c_bounds=C_BOUNDS, n_bounds=(lo, hi), progress=progress)
    data = result.to_dict()
    data["recordings_read"] = [str(p) for p in paths]
    _deliver(args, data, "estimate_figures", result, inputs)
    if args.json:
        return 0
    d, r = result.damping, result.restitution
    unc = data["uncertainty"]
    print(f"impactid estimate: {len(paths)} recording(s), {data['impacts_used']} impacts, residual {d.residual}, "
          f"method {d.method} ({d.n_simulations} S1 simulations, {d.seconds:.2f} s)")
    print(f"  beta  = {_num(d.beta)} N s m^-{d.n + 1:.3g}   interval [{_num(unc['beta_interval'][0])}, "
          f"{_num(unc['beta_interval'][1])}]")
    if d.fixed_n:
        print(f"  n     = {d.n:.4g} (fixed)")
    else:
        tag = "" if d.separable else "   NOT SEPARABLE from beta (see warnings)"
        print(f"  n     = {_num(d.n, '.4g')}   interval [{_num(unc['n_interval'][0], '.4g')}, "
              f"{_num(unc['n_interval'][1], '.4g')}]{tag}")
    print(f"  objective (mean {d.residual}) = {_num(d.objective, '.4g')}")
    if r is None:
        print("  restitution law: undetermined (see warnings)")
    else:
        print(f"  gamma = {_num(r.gamma)} +- {_num(r.gamma_stderr, '.2g')} s/m  (xi = 1 - gamma v_a; HC equivalent "
              f"beta {_num(r.beta_equivalent, '.4g')} N s m^-2.5)")
        print(f"  xi_mean = {_num(r.xi_mean)}, va_mean = {_num(r.va_mean)} m/s, constant r = {_num(r.r_constant)}")
    for message in data.get("warnings", []):
        print(f"  warning: {message}")
    _say_written(args)
    return 0


def cmd_campaign(args) -> int:
    from impactid.campaign import load_campaign, run_campaign
    from impactid.distributed import cluster_from_args, require

    require("pyarrow", what="impactid campaign")
    spec = load_campaign(args.source)
    out = args.out or spec.out
    if out is None:
        raise UsageError("argument --out: no output folder: give --out DIR, or out = \"DIR\" in the [campaign] "
                         "table of the campaign file")
    check_output(out, option="--out", inputs=spec.inputs(), directory=True)
    if args.serial:
        if args.scheduler is not None or args.workers:
            raise UsageError("argument --serial: not allowed with --scheduler or --workers N")
        args.workers = 0
    cluster = cluster_from_args(args, local_default=True, what="impactid campaign")
    progress = args.progress if args.progress is not None else sys.stderr.isatty()
    result = run_campaign(spec, out, cluster=cluster, fresh=args.fresh, progress=progress,
                          log=lambda text: print(f"impactid campaign: {text}", file=sys.stderr, flush=True))
    fits = len(result.table)
    data = {"campaign": spec.name, "out": str(result.out), "fits": fits, "ran": result.ran,
            "skipped": result.skipped, "failed": result.failed, "prepared": result.prepared,
            "prepared_from_cache": result.cached, "seconds": result.seconds, "where": result.where,
            "files": [str(f) for f in result.files],
            "failures": [{"kind": k, "name": n, "reason": r} for k, n, r in result.failures()]}
    if args.json:
        _print_json(data)
    else:
        print(f"campaign {spec.name}: {len(spec.recordings)} recordings, {fits} fits: {result.ran} done, "
              f"{result.skipped} skipped (finished earlier), {result.failed} failed "
              f"({result.seconds:.1f} s, {result.where})")
        for kind, name, reason in result.failures():
            print(f"  failed: {kind} fit {name}: {reason}")
        print(f"  table written to {result.files[0]} and {result.files[1]}")
    return 0 if result.ok else 1


def cmd_cam_fit(args) -> int:
    from impactid.camprofile import fit_cam_profile
    from impactid.io import read_recording

    path = _recording_paths(args)[0]
    inputs = _inputs(args, [path])
    terms = args.terms.strip().lower()
    if terms != "auto":
        try:
            terms = int(terms)
        except ValueError:
            raise UsageError(f"argument --terms: expected a positive integer or 'auto', got {args.terms!r}") from None
        if not 1 <= terms <= 20:
            raise UsageError(f"argument --terms: must lie in [1, 20], got {terms}")
    window = None
    if args.window:
        try:
            window = _pair(args.window)
        except argparse.ArgumentTypeError:
            window = None
        if window is None or not window[0] < window[1]:
            raise UsageError(f"argument --window: expected T0,T1 in seconds with T0 < T1, got {args.window!r}")
    _check_outputs(args, inputs)
    rec = read_recording(path, rig=_recording_rig(args))
    fit = fit_cam_profile(rec, terms, criterion=args.criterion, max_terms=args.max_terms, window=window,
                          nonnegative=not args.signed, counter=args.counter)
    data = fit.to_dict(samples=3600)
    data["recording"] = str(path)
    _deliver(args, data, "cam_fit_figures", fit, inputs)
    if args.json:
        return 0
    print(fit.report())
    _say_written(args)
    return 0


# ---- parser -----------------------------------------------------------------------------------


def _add_sim_rig_args(p: argparse.ArgumentParser, with_ratio: bool = True) -> None:
    p.add_argument("--rig", metavar="MODEL|RIG.toml",
                   help="rig model name ('pivoted-follower': Sundar et al. 2016 Table 1) or a TOML rig file "
                        "(its [operating] table supplies defaults such as cam_speed_hz)")
    if with_ratio:
        p.add_argument("--e-over-rc", type=_positive, default=None, help="eccentricity ratio e/r_c (default: rig's)")


def _add_recording_args(p: argparse.ArgumentParser, several: bool = False) -> None:
    if several:
        p.add_argument("recordings", metavar="REC", nargs="*", help="HDF5 or CSV recordings (several: joint fit)")
    else:
        p.add_argument("recording", metavar="REC", nargs="?", help="HDF5 or CSV recording")
    p.add_argument("--example", action="store_true",
                   help="use the built-in example (two recordings of one rig; commands that read one use the first)")
    p.add_argument("--rig", metavar="RIG.toml|MODEL",
                   help="rig file (or model name) that supplies or overrides the recording's rig and operating point")


def _add_kinematics_args(p: argparse.ArgumentParser, anchor: str) -> None:
    from impactid.reconstruct import ANCHORS
    from impactid.signal import INTEGRATORS

    p.add_argument("--integration", default="rk", choices=list(INTEGRATORS),
                   help="integration method (default rk, as in the paper)")
    p.add_argument("--anchor", default=anchor, choices=list(ANCHORS),
                   help=f"integration-constant anchor (default {anchor}; return-time is the paper's)")


def _add_law_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--beta", type=_nonnegative, default=24.7e9,
                   help="damping coefficient [N s m^-(n+1)] (default 24.7e9)")
    p.add_argument("--n", type=_exponent, default=1.5, help="damping index (default 1.5)")
    p.add_argument("--mu", type=_nonnegative, default=None, help="friction coefficient (default: rig's)")
    p.add_argument("--clip", action="store_true", help="clip tensile contact force to 0")


def _add_speed_args(p: argparse.ArgumentParser, rpm: bool = False) -> None:
    p.add_argument("--cam-speed", type=_positive, default=None, metavar="HZ",
                   help="cam speed [Hz] (default: the rig file's [operating] cam_speed_hz)")
    if rpm:
        p.add_argument("--rpm", type=_positive, default=None, help="cam speed [rpm] (instead of --cam-speed)")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="impactid", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"impactid {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    p = sub.add_parser("regime", help="classify the motion of rig P at one operating point")
    _add_sim_rig_args(p)
    _add_speed_args(p)
    _add_law_args(p)
    p.add_argument("--max-revolutions", type=_integer(1, 1_000_000), default=2000, help="longest run while settling")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=cmd_regime)

    p = sub.add_parser("detachment", help="cam speed at which the follower leaves the cam (inverse kinematics)")
    p.add_argument("--rig", metavar="MODEL|RIG.toml",
                   help="rig model name ('pivoted-follower', 'flat-follower': the papers' tables) or a rig file")
    p.add_argument("--e-over-rc", type=_positive, default=None, help="eccentricity ratio e/r_c (rig P)")
    p.add_argument("--mu", type=_nonnegative, default=None, help="friction coefficient (default: rig's)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=cmd_detachment)

    p = sub.add_parser("bifurcation", help="rig F bifurcation diagram over cam speed, CSV and PNG "
                                           "(Alzate et al. 2007, Fig. 16)")
    p.add_argument("--rig", metavar="MODEL|RIG.toml", help="flat-follower rig file; default Alzate et al. 2007 Table 5")
    p.add_argument("--from", dest="start", type=_positive, default=110.0, help="lowest cam speed (default 110)")
    p.add_argument("--to", dest="stop", type=_positive, default=165.0, help="highest cam speed (default 165)")
    p.add_argument("--unit", choices=["rpm", "hz"], default="rpm", help="unit of --from/--to (default rpm)")
    p.add_argument("--speeds", type=_integer(2, MAX_SWEEP_POINTS), default=200,
                   help="number of cam speeds (default 200)")
    p.add_argument("--revolutions", type=_integer(2, 100_000), default=100,
                   help="revolutions simulated per speed (default 100)")
    p.add_argument("--kept", type=_integer(1, 100_000), default=None,
                   help="last revolutions plotted and classified (default half)")
    group = p.add_mutually_exclusive_group()
    group.add_argument("--restitution", type=_fraction, default=None, help="constant coefficient of restitution")
    group.add_argument("--restitution-law", type=_pair, default=None, metavar="A,B",
                       help="r = A + B * rpm (default: our stand-in law, see the docs)")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    p.add_argument("--json", action="store_true", help="print JSON")
    add_scheduler_arguments(p)
    p.set_defaults(func=cmd_bifurcation)

    p = sub.add_parser("restitution", help="rig F: coefficient of restitution per cam speed from impacting "
                                           "encoder recordings, and r = a + b omega")
    p.add_argument("recordings", metavar="REC", nargs="*", help="impacting encoder recordings (one per cam speed)")
    p.add_argument("--profile", metavar="fit.json", help="cam profile from impactid cam-fit (default: analytic A-17)")
    p.add_argument("--method", choices=["impact-law", "first-bounce"], default="impact-law",
                   help="impact-law: fitted flight rates either side of each first impact; first-bounce: the "
                        "model's r that reproduces the first-bounce height (Alzate et al. 2007)")
    p.add_argument("--rig", metavar="RIG.toml|MODEL", help="rig for first-bounce (default: the recording's)")
    p.add_argument("--out", metavar="law.json", help="write the results as JSON (atomically)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=cmd_restitution)

    p = sub.add_parser("regime-map", help="regime map over (e/r_c, cam speed), CSV and PNG "
                                          "(Sundar et al. 2016, Fig. 3)")
    _add_sim_rig_args(p, with_ratio=False)
    p.add_argument("--e-over-rc-values", type=_range, default=_range("0.05:0.25:5"),
                   help="e/r_c values: 'start:stop:count' or a list (default 0.05:0.25:5)")
    p.add_argument("--cam-speeds", type=_range, default=_range("4:24:21"),
                   help="cam speeds [Hz]: 'start:stop:count' or a list (default 4:24:21)")
    _add_law_args(p)
    p.add_argument("--max-revolutions", type=_integer(1, 1_000_000), default=2000,
                   help="longest run per point while settling")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    p.add_argument("--quiet", action="store_true", help="no progress output")
    add_scheduler_arguments(p)
    p.set_defaults(func=cmd_regime_map)

    p = sub.add_parser("simulate", help="long S2 run from static equilibrium; prints the contact table")
    _add_sim_rig_args(p)
    _add_speed_args(p)
    p.add_argument("--duration", type=_positive, default=2.0, help="simulated time [s] (default 2)")
    _add_law_args(p)
    p.add_argument("--out", metavar="CONTACTS.csv", help="write the contact table as CSV")
    p.add_argument("--show", type=_integer(0, 1_000_000), default=8, help="rows of the contact table to print")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=cmd_simulate)

    p = sub.add_parser("synth", help="write a synthetic recording (S2/S3 of rig P, encoders of rig F)")
    p.add_argument("--rig", default="pivoted-follower", metavar="MODEL|RIG.toml",
                   help="'pivoted-follower' (Sundar et al. 2016 Table 1), 'flat-follower' (Alzate et al. 2007 "
                        "Table 5) or a rig file")
    p.add_argument("--e-over-rc", type=_positive, default=None, help="eccentricity ratio e/r_c (rig P)")
    _add_speed_args(p, rpm=True)
    p.add_argument("--law", choices=["hunt-crossley", "restitution"], default="hunt-crossley",
                   help="contact law (S2) or restitution law (S3)")
    _add_law_args(p)
    p.add_argument("--gamma", type=_nonnegative, default=0.8,
                   help="restitution law xi = 1 - gamma v_a [s/m] (default 0.8)")
    p.add_argument("--duration", type=_positive, default=2.0, help="recorded time [s] (default 2)")
    p.add_argument("--settle", type=_nonnegative, default=40.0, help="discarded settling time [s] (default 40)")
    p.add_argument("--sample-rate", type=_positive, default=None,
                   help="sample rate [Hz] (default 204800 for rig P, 20000 for rig F)")
    p.add_argument("--noise", type=_fraction, default=0.0, help="Gaussian noise, fraction of peak, analogue channels")
    p.add_argument("--noise-channel", action="append", metavar="NAME=FRACTION", help="noise of one channel")
    p.add_argument("--adc-bits", type=_integer(2, 32), default=None, help="ADC resolution [bits] (default: none)")
    p.add_argument("--accel-offset", type=_number, default=0.0, help="accelerometer offset [m/s^2]")
    p.add_argument("--accel-drift", type=_number, default=0.0, help="accelerometer drift [m/s^2 per s]")
    p.add_argument("--decimate", type=_integer(1, 64), default=1,
                   help="anti-alias filter and decimation factor (default 1)")
    p.add_argument("--cam-ppr", type=_integer(1, 10_000_000), default=None,
                   help="cam encoder pulses/rev (rig F default 5000)")
    p.add_argument("--follower-ppr", type=_integer(1, 10_000_000), default=10_000,
                   help="follower encoder pulses/rev (rig F)")
    p.add_argument("--cam-zero-offset", type=_number, default=None,
                   help="cam encoder zero [rad] (rig F; default random)")
    p.add_argument("--seed", type=_integer(0, 2**63 - 1), default=0, help="random seed")
    p.add_argument("--out", required=True, metavar="FILE.h5", help="output HDF5 file")
    p.set_defaults(func=cmd_synth)

    p = sub.add_parser("info", help="read and validate a recording; print what it holds")
    _add_recording_args(p)
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=cmd_info)

    p = sub.add_parser("events", help="find impacts and reconstruct each one (alpha, v_a, xi, contact force)")
    _add_recording_args(p)
    _add_kinematics_args(p, anchor="return-time")
    p.add_argument("--threshold", type=_positive, default=None,
                   help="pulse detection level [m/s^2] (default: from noise)")
    p.add_argument("--onset-threshold", type=_positive, default=None, help="contact onset level [m/s^2]")
    p.add_argument("--out", metavar="EVENTS.csv", help="write the per-event table as CSV")
    p.add_argument("--show", type=_integer(0, 1_000_000), default=10, help="rows to print")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=cmd_events)

    p = sub.add_parser("estimate", help="estimate Hunt-Crossley beta, n and the restitution law from recordings")
    _add_recording_args(p, several=True)
    p.add_argument("--residual", default="lambda1", choices=["lambda1", "lambda2", "lambda3"],
                   help="residual minimised (default lambda1: accelerometer only)")
    p.add_argument("--fix-n", type=_exponent, default=None, metavar="N", help="fix the exponent n (0: viscous)")
    p.add_argument("--method", choices=["least-squares", "optimise"], default="least-squares",
                   help="least-squares (default: trust-region Gauss-Newton, profile intervals) or optimise "
                        "(nested Brent searches, lattice and bootstrap intervals; about 100x the simulations)")
    p.add_argument("--grid", type=_grid_counts, default=None, metavar="NB[,NN]",
                   help="paper-style grid search with NB values of beta (log) and NN of n instead of --method")
    p.add_argument("--n-range", type=_exponent, nargs=2, default=[0.5, 2.5], metavar=("LO", "HI"),
                   help="search bounds of n (default 0.5 2.5)")
    _add_kinematics_args(p, anchor="cam-phase")
    p.add_argument("--out", metavar="RESULT.json", help="write the result as JSON (atomically)")
    p.add_argument("--plots", metavar="DIR", help="write figures (hysteresis, restitution, landscape, residuals)")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                   help="progress bar on stderr (default: when stderr is a terminal)")
    p.set_defaults(func=cmd_estimate)

    from impactid.campaign import FORMAT_HELP

    p = sub.add_parser("campaign", help="fit every recording of a campaign alone and its groups jointly, on a dask "
                                        "cluster; a rerun skips finished fits",
                       formatter_class=argparse.RawDescriptionHelpFormatter,
                       description=FORMAT_HELP + "\nExit status: 0 when every fit ended in an estimate, 1 when some "
                                                 "failed (the table and the\nfailed: lines say why), 2 when the "
                                                 "campaign could not be run.")
    p.add_argument("source", metavar="CAMPAIGN.toml|DIR", help="campaign file, or a folder of recordings")
    p.add_argument("--out", metavar="DIR", help="output folder (default: [campaign] out of the campaign file)")
    add_scheduler_arguments(p, local_default=True)
    p.add_argument("--serial", action="store_true", help="run in this process, without dask (as --workers 0)")
    p.add_argument("--fresh", action="store_true", help="run every task again (ignore finished fits and caches)")
    p.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                   help="progress bar on stderr (default: when stderr is a terminal)")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.set_defaults(func=cmd_campaign)

    p = sub.add_parser("cam-fit", help="fit a Gaussian-sum cam profile (Alzate et al. 2007, eq. 1) to rig F "
                                       "encoder data")
    _add_recording_args(p)
    p.add_argument("--terms", default="7", metavar="N|auto",
                   help="number of Gaussian terms, or 'auto' to choose 1..--max-terms by --criterion (default 7)")
    p.add_argument("--max-terms", type=_integer(1, 20), default=9, help="highest order tried by --terms auto")
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
    _add_rig_commands(sub)
    return parser


def _add_rig_commands(sub) -> None:
    """The commands the registered rigs contribute (:class:`~impactid.rigs.base.CommandSpec`).

    A command several rigs contribute takes ``--rig MODEL`` and runs the chosen rig's
    implementation; its arguments are the union of theirs. Commands are grouped
    (``impactid valvetrain simulate``) or top-level (group ``""``)."""
    from impactid.rigs.registry import MODELS

    specs: dict[tuple[str, str], list] = {}
    for model in MODELS.values():
        for spec in model.commands:
            specs.setdefault((spec.group, spec.name), []).append((model, spec))
    groups: dict[str, argparse._SubParsersAction] = {}
    for (group, name), entries in specs.items():
        if group:
            if group not in groups:
                rigs = ", ".join(sorted({m.name for m, _ in entries}))
                holder = sub.add_parser(group, help=f"{group} commands ({rigs})")
                groups[group] = holder.add_subparsers(dest=f"{group}_command", required=True, parser_class=_Parser)
            target = groups[group]
        else:
            target = sub
        p = target.add_parser(name, help=entries[0][1].help, description=entries[0][1].description or None)
        names = [m.name for m, _ in entries]
        if group or len(names) > 1:  # a top-level command of one rig (``impactid bounces``) needs no --rig
            p.add_argument("--rig", choices=names, default=names[0] if len(names) == 1 else None,
                           required=len(names) > 1, help=f"rig model ({', '.join(names)})")
        for _, spec in entries:
            for argument in spec.arguments:
                argument.add_to(p)
        p.set_defaults(func=_run_rig_command, rig_commands={m.name: spec for m, spec in entries})


def _run_rig_command(args) -> int:
    from impactid.rigs.registry import rig_model

    name = getattr(args, "rig", None) or next(iter(args.rig_commands))
    spec = args.rig_commands[name]
    return int(spec.run(args, rig_model(name)) or 0)


# ---- entry point ------------------------------------------------------------------------------


def _error(message: str) -> None:
    text = " ".join(str(message).split())  # one line, whatever the message held
    print(f"impactid: error: {text}", file=sys.stderr, flush=True)


@contextlib.contextmanager
def _command_environment() -> Iterator[None]:
    """Warnings as ``impactid: warning: ...`` lines (each text once), SIGTERM raised as an
    exception (so that outputs are rolled back), both restored on exit."""
    shown: set[str] = set()

    def show(message, category, filename, lineno, file=None, line=None):
        text = " ".join(str(message).split())
        if text not in shown:
            shown.add(text)
            print(f"impactid: warning: {text}", file=sys.stderr, flush=True)

    def terminate(signum, frame):
        request_termination()  # raises; outputs are rolled back as on Ctrl-C

    def unraisable(info):
        # a stop raised inside a finalizer is swallowed by Python; the flag it set still stops the
        # job (at the next output commit, or below), so the traceback is not shown
        if not isinstance(info.exc_value, (TerminationRequested, KeyboardInterrupt)):
            previous_hook(info)

    previous_handler = None
    previous_hook = sys.unraisablehook
    in_main = threading.current_thread() is threading.main_thread()
    if in_main:
        previous_handler = signal.signal(signal.SIGTERM, terminate)
    sys.unraisablehook = unraisable
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("always")
            # numba's pedantic SSA check warns, on first compilation, about variables of the DP5 core's
            # inlined overloads (harmless, numba issue 7236): not a message for the user
            warnings.filterwarnings("ignore", message=r"variable '.*' is not in scope")
            warnings.showwarning = show
            yield
            if termination_requested():
                raise TerminationRequested()
    finally:
        sys.unraisablehook = previous_hook
        if in_main:
            signal.signal(signal.SIGTERM, previous_handler)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``impactid`` command; returns the exit code."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except UsageError as exc:
        _error(exc)
        return EXIT_INPUT_ERROR
    try:
        with _command_environment():
            return int(args.func(args) or 0)
    except ImpactidError as exc:
        _error(exc)
        return EXIT_INPUT_ERROR
    except KeyboardInterrupt:
        _error("interrupted (Ctrl-C); outputs not completed were not written")
        return EXIT_INTERRUPTED
    except TerminationRequested:
        _error("terminated (SIGTERM); outputs not completed were not written")
        return EXIT_TERMINATED
    except MemoryError:
        _error("out of memory: the input or the requested computation is too large for this machine")
        return EXIT_INPUT_ERROR
    except OSError as exc:  # a file system problem not caught where it happened (disk full, ...)
        where = f"{exc.filename}: " if exc.filename else ""
        _error(f"{where}{exc.strerror or exc}")
        return EXIT_INPUT_ERROR


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

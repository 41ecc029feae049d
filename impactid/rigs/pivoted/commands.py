"""The commands rig P contributes: ``impactid regime | regime-map | simulate | events``, and its
implementations of ``impactid detachment`` and ``impactid synth`` (shared with rig F; the rig
``--rig`` names runs them, rig P by default). ``impactid estimate`` is the application's, generic
over the rigs: rig P's part of it is :mod:`impactid.rigs.pivoted.estimation`.

Thin: parse arguments, call the public API, print results. Units on the command line are SI
(``--beta`` in N s m^-(n+1), e.g. 24.7e9 for the paper's 24.7 GN s m^-2.5), except cam speeds
(``--cam-speed`` in Hz, ``--rpm``). Output paths are checked before any computation and written as
transactions (:mod:`impactid.commandline`).

Light: the arguments are data, and each command imports the numerics when it runs, so that
``impactid --help`` and ``impactid COMMAND --help`` load neither numpy nor the rig's parameters.
"""

from __future__ import annotations

import argparse

from impactid.commandline import (
    CAM_PPR,
    FIGURE_FORMAT,
    JSON,
    MAX_SWEEP_POINTS,
    NOISE_CHANNEL,
    SAMPLE_RATE,
    SEED,
    SYNTH_DURATION,
    SYNTH_OUT,
    UsageError,
    cam_speed,
    check_outputs,
    check_synth_size,
    command_inputs,
    exponent,
    figure_format,
    fraction,
    integer_in,
    noise_channels,
    nonnegative,
    number,
    positive,
    print_json,
    recording_arguments,
    recording_paths,
    recording_rig,
    rig_help,
    speed_arguments,
    write_synthetic,
)
from impactid.distributed import scheduler_arguments
from impactid.rigs.base import Argument, CommandSpec
from impactid.rigs.pivoted.arguments import kinematics_arguments

#: The rig's model name (``impactid.rigs.pivoted.parameters.MODEL_NAME``; that module loads numpy and SciPy).
MODEL_NAME = "pivoted-follower"

__all__ = ["COMMANDS", "kinematics_arguments"]

# ---- argument types ---------------------------------------------------------------------------


def _linspace(start: float, stop: float, count: int) -> list[float]:
    """``numpy.linspace(start, stop, count)`` as floats, value for value (``start + i * step``, the last
    ``stop``), without numpy."""
    if count == 1:
        return [start]
    step = (stop - start) / (count - 1)
    return [start + i * step for i in range(count - 1)] + [stop]


def _range(text: str) -> list[float]:
    """``a:b:n`` (n values from a to b) or a comma-separated list of positive numbers."""
    try:
        if ":" in text:
            a, b, n = text.split(":")
            count = int(n)
            if not 1 <= count <= MAX_SWEEP_POINTS:
                raise argparse.ArgumentTypeError(f"the count in {text!r} must lie in [1, {MAX_SWEEP_POINTS}]")
            values = _linspace(number(a), number(b), count)
        else:
            values = [number(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected 'start:stop:count' or 'v1,v2,...', got {text!r}") from None
    if not values:
        raise argparse.ArgumentTypeError(f"no values in {text!r}")
    if min(values) <= 0.0:
        raise argparse.ArgumentTypeError(f"values must be positive, got {text!r}")
    return values


# ---- shared plumbing --------------------------------------------------------------------------


def _simulated_rig(args, command: str):
    """Rig P for a simulation command (``--rig``, then ``--e-over-rc``), and the rig file's operating point."""
    from impactid.rigs.registry import resolve_rig

    resolved = resolve_rig(getattr(args, "rig", None), default=MODEL_NAME)
    if resolved.model.name != MODEL_NAME:
        raise UsageError(f"argument --rig: '{command}' simulates the 'pivoted-follower' rig only, "
                         f"got a {resolved.model.name!r} rig")
    rig = resolved.rig
    if getattr(args, "e_over_rc", None) is not None:
        rig = rig.with_eccentricity_ratio(args.e_over_rc)
    return rig, resolved.operating


def _law(args):
    from impactid.contact import HuntCrossley

    return HuntCrossley(beta=args.beta, n=args.n, clip=getattr(args, "clip", False))


# ---- commands ---------------------------------------------------------------------------------


def run_regime(args, model) -> int:
    from impactid.rigs.pivoted.regimes import classify_regime, detachment_speed

    rig, operating = _simulated_rig(args, "regime")
    speed = cam_speed(args, operating)
    result = classify_regime(rig, speed, _law(args), mu=args.mu, max_revolutions=args.max_revolutions)
    data = result.to_dict()
    data["detachment_hz"] = detachment_speed(rig, mu=args.mu).cam_speed_hz
    if args.json:
        print_json(data)
    else:
        per = f", {result.period_revolutions} revolution(s)" if result.period_revolutions else ""
        print(f"e/r_c = {rig.e_over_rc:.4g}, cam speed {speed:g} Hz: {result.regime}{per}")
        print(f"  impacts per revolution (last window): {result.impacts_per_revolution:.3g}")
        print(f"  simulated {result.simulated_s:.2f} s; detachment speed {data['detachment_hz']:.4g} Hz")
        if result.settling:
            print("  note: the motion was still settling when the run ended")
    return 0


def run_detachment(args, model) -> int:
    from impactid.rigs.pivoted.regimes import detachment_speed

    rig = args.resolved_rig.rig
    if args.e_over_rc is not None:
        rig = rig.with_eccentricity_ratio(args.e_over_rc)
    result = detachment_speed(rig, mu=args.mu)
    if args.json:
        print_json(result.to_dict())
    else:
        print(f"detachment at {result.cam_speed_hz:.6g} Hz ({result.cam_speed_rpm:.6g} rpm), "
              f"cam angle {result.cam_angle:.4f} rad")
    return 0


def run_regime_map(args, model) -> int:
    from impactid._files import StagedFiles
    from impactid.rigs.pivoted.figures import write_regime_map
    from impactid.rigs.pivoted.regimes import regime_map

    rig, _ = _simulated_rig(args, "regime-map")
    points = len(args.e_over_rc_values) * len(args.cam_speeds)
    if points > MAX_SWEEP_POINTS:
        raise UsageError(f"arguments --e-over-rc-values/--cam-speeds: {points:,} operating points; at most "
                         f"{MAX_SWEEP_POINTS:,}")
    inputs = command_inputs(args, [])
    check_outputs(args, inputs, out_is_dir=True)
    for ratio in args.e_over_rc_values:  # every ratio checked before the long run
        rig.with_eccentricity_ratio(ratio)

    from impactid.commandline import progress_bar as task_bar
    from impactid.distributed import scheduler_client

    with scheduler_client(args, what="impactid regime-map") as client, \
            task_bar(points, enabled=not args.quiet, desc="regime map", unit="point") as bar:
        frame = regime_map(rig, args.e_over_rc_values, args.cam_speeds, _law(args), mu=args.mu,
                           progress=lambda done, total: bar.update(done - bar.n),
                           max_revolutions=args.max_revolutions, client=client)
    with StagedFiles(protect=inputs) as staged:
        paths = write_regime_map(frame, args.out, staged, figure_format(args))
    for path in paths:
        print(path)
    return 0


def run_simulate(args, model) -> int:
    from impactid._files import StagedFiles
    from impactid.rigs.pivoted.runs import simulate

    rig, operating = _simulated_rig(args, "simulate")
    speed = cam_speed(args, operating)
    inputs = command_inputs(args, [])
    check_outputs(args, inputs)
    run = simulate(rig, speed, _law(args), args.duration, mu=args.mu)
    table = run.contacts
    if args.out:
        from impactid.reports import write_csv_atomic

        with StagedFiles(protect=inputs) as staged:
            write_csv_atomic(table, args.out, staged)
    if args.json:
        print_json({"contacts": len(table), "final_alpha": run.final_alpha, "final_alpha_dot": run.final_alpha_dot,
                    "n_steps": run.n_steps, "contact_table": table.to_dict(orient="list")})
    else:
        print(f"e/r_c = {rig.e_over_rc:.4g}, {speed:g} Hz, beta = {args.beta:.4g}, n = {args.n:g}: "
              f"{len(table)} contacts in {args.duration:g} s ({run.n_steps} integrator steps)")
        cols = ["t_start", "duration", "gap_rate_start", "gap_rate_end", "peak_indentation", "peak_force", "xi"]
        with_units = table[cols].tail(args.show).rename(columns={
            "t_start": "t_start[s]", "duration": "duration[s]", "gap_rate_start": "v_approach[m/s]",
            "gap_rate_end": "v_separation[m/s]", "peak_indentation": "peak_indent[m]", "peak_force": "peak_force[N]"})
        print(with_units.to_string(index=False, float_format=lambda x: f"{x:.6g}"))
    return 0


def run_synth(args, model) -> int:
    from impactid.contact import HuntCrossley, Restitution
    from impactid.rigs.pivoted.synth import synth_pivoted
    from impactid.synth import SensorModel

    rig, operating = args.resolved_rig.rig, args.resolved_rig.operating
    noise = noise_channels(args.noise_channel)
    speed = cam_speed(args, operating)
    rate = args.sample_rate or 204_800.0
    samples = args.duration * rate * args.decimate
    check_synth_size(samples)
    check_outputs(args, command_inputs(args, []))
    if args.e_over_rc is not None:
        rig = rig.with_eccentricity_ratio(args.e_over_rc)
    law = (Restitution(gamma=args.gamma) if args.law == "restitution"
           else HuntCrossley(beta=args.beta, n=args.n, clip=args.clip))
    sensors = SensorModel(noise=noise or args.noise, adc_bits=args.adc_bits, accel_offset=args.accel_offset,
                          accel_drift=args.accel_drift, decimation=args.decimate, cam_encoder_ppr=args.cam_ppr,
                          seed=args.seed)
    synthetic = synth_pivoted(rig, speed, law, args.duration, settle_s=args.settle, sample_rate_hz=rate,
                              sensors=sensors, mu=args.mu)
    return write_synthetic(synthetic, args.out)


def run_events(args, model) -> int:
    from impactid._files import StagedFiles
    from impactid.events import find_events
    from impactid.io import check_memory, read_recording
    from impactid.rigs.pivoted.reconstruct import reconstruct

    path = recording_paths(args)[0]
    inputs = command_inputs(args, [path])
    check_outputs(args, inputs)
    check_memory([path], "events")  # before anything is allocated
    rec = read_recording(path, rig=recording_rig(args))
    events = find_events(rec, threshold=args.threshold, onset_threshold=args.onset_threshold)
    result = reconstruct(rec, events, integration=args.integration, anchor=args.anchor)
    table = result.table
    if args.out:
        from impactid.reports import write_csv_atomic

        with StagedFiles(protect=inputs) as staged:
            write_csv_atomic(table.reset_index(), args.out, staged)
    if args.json:
        print_json({"events_found": len(events), "events_used": len(table), "noise_sigma": events.noise_sigma,
                    "warnings": list(result.warnings), "provenance": list(result.provenance),
                    "table": table.reset_index().to_dict(orient="list")})
    else:
        print(f"{rec.source}: {len(events)} events found, {len(table)} reconstructed "
              f"(integration {result.integration!r}, anchor {result.anchor!r})")
        cols = ["t_onset", "contact_duration", "alpha_m", "approach_speed", "separation_speed", "xi", "peak_force"]
        print(table[cols].head(args.show).to_string(float_format=lambda x: f"{x:.6g}"))
    return 0


# ---- arguments --------------------------------------------------------------------------------


def _simulated_rig_arguments(with_ratio: bool = True) -> tuple[Argument, ...]:
    out = (Argument(("--rig",), {"metavar": "MODEL|PRESET|RIG.toml", "help": rig_help(
        "the pivoted-follower rig (default: Sundar et al. 2016 Table 1); a rig file's [operating] table "
        "supplies defaults such as cam_speed_hz")}),)
    if with_ratio:
        out += (Argument(("--e-over-rc",), {"type": positive, "default": None,
                                            "help": "eccentricity ratio e/r_c (default: rig's)"}),)
    return out


MU = Argument(("--mu",), {"type": nonnegative, "default": None, "help": "friction coefficient (default: rig's)"})
LAW = (
    Argument(("--beta",), {"type": nonnegative, "default": 24.7e9,
                           "help": "damping coefficient [N s m^-(n+1)] (default 24.7e9)"}),
    Argument(("--n",), {"type": exponent, "default": 1.5, "help": "damping index (default 1.5)"}),
    MU,
    Argument(("--clip",), {"action": "store_true", "help": "clip tensile contact force to 0"}),
)
E_OVER_RC_RIG_P = Argument(("--e-over-rc",), {"type": positive, "default": None,
                                              "help": "eccentricity ratio e/r_c (rig P)"})
MAX_REVOLUTIONS = {"type": integer_in(1, 1_000_000), "default": 2000}


COMMANDS = (
    CommandSpec("", "regime", "classify the motion of rig P at one operating point", (
        *_simulated_rig_arguments(), *speed_arguments(), *LAW,
        Argument(("--max-revolutions",), {**MAX_REVOLUTIONS, "help": "longest run while settling"}),
        JSON), run_regime),
    CommandSpec("", "detachment", "cam speed at which the follower leaves the cam (inverse kinematics)", (
        E_OVER_RC_RIG_P, MU, JSON), run_detachment, rig_argument="resolve", default_rig=True),
    CommandSpec("", "regime-map", "regime map over (e/r_c, cam speed), CSV and figure (Sundar et al. 2016, Fig. 3)", (
        *_simulated_rig_arguments(with_ratio=False),
        Argument(("--e-over-rc-values",), {"type": _range, "default": _range("0.05:0.25:5"),
                                           "help": "e/r_c values: 'start:stop:count' or a list (default 0.05:0.25:5)"}),
        Argument(("--cam-speeds",), {"type": _range, "default": _range("4:24:21"),
                                     "help": "cam speeds [Hz]: 'start:stop:count' or a list (default 4:24:21)"}),
        *LAW,
        Argument(("--max-revolutions",), {**MAX_REVOLUTIONS, "help": "longest run per point while settling"}),
        Argument(("--out",), {"required": True, "metavar": "DIR", "help": "output folder"}),
        FIGURE_FORMAT,
        Argument(("--quiet",), {"action": "store_true", "help": "no progress output"}),
        *scheduler_arguments()), run_regime_map),
    CommandSpec("", "simulate", "long S2 run from static equilibrium; prints the contact table", (
        *_simulated_rig_arguments(), *speed_arguments(),
        Argument(("--duration",), {"type": positive, "default": 2.0, "help": "simulated time [s] (default 2)"}),
        *LAW,
        Argument(("--out",), {"metavar": "CONTACTS.csv", "help": "write the contact table as CSV"}),
        Argument(("--show",), {"type": integer_in(0, 1_000_000), "default": 8,
                               "help": "rows of the contact table to print"}),
        JSON), run_simulate),
    CommandSpec("", "synth", "write a synthetic recording (S2/S3 of rig P, encoders of rig F)", (
        E_OVER_RC_RIG_P, *speed_arguments(rpm=True),
        Argument(("--law",), {"choices": ["hunt-crossley", "restitution"], "default": "hunt-crossley",
                              "help": "contact law (S2) or restitution law (S3)"}),
        *LAW,
        Argument(("--gamma",), {"type": nonnegative, "default": 0.8,
                                "help": "restitution law xi = 1 - gamma v_a [s/m] (default 0.8)"}),
        SYNTH_DURATION,
        Argument(("--settle",), {"type": nonnegative, "default": 40.0,
                                 "help": "discarded settling time [s] (default 40)"}),
        SAMPLE_RATE,
        Argument(("--noise",), {"type": fraction, "default": 0.0,
                                "help": "Gaussian noise, fraction of peak, analogue channels"}),
        NOISE_CHANNEL,
        Argument(("--adc-bits",), {"type": integer_in(2, 32), "default": None,
                                   "help": "ADC resolution [bits] (default: none)"}),
        Argument(("--accel-offset",), {"type": number, "default": 0.0, "help": "accelerometer offset [m/s^2]"}),
        Argument(("--accel-drift",), {"type": number, "default": 0.0,
                                      "help": "accelerometer drift [m/s^2 per s]"}),
        Argument(("--decimate",), {"type": integer_in(1, 64), "default": 1,
                                   "help": "anti-alias filter and decimation factor (default 1)"}),
        CAM_PPR, SEED, SYNTH_OUT), run_synth, rig_argument="resolve", default_rig=True),
    CommandSpec("", "events", "find impacts and reconstruct each one (alpha, v_a, xi, contact force)", (
        *recording_arguments(), *kinematics_arguments("return-time"),
        Argument(("--threshold",), {"type": positive, "default": None,
                                    "help": "pulse detection level [m/s^2] (default: from noise)"}),
        Argument(("--onset-threshold",), {"type": positive, "default": None,
                                          "help": "contact onset level [m/s^2]"}),
        Argument(("--out",), {"metavar": "EVENTS.csv", "help": "write the per-event table as CSV"}),
        Argument(("--show",), {"type": integer_in(0, 1_000_000), "default": 10, "help": "rows to print"}),
        JSON), run_events),
)

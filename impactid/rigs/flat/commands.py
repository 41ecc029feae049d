"""The commands rig F contributes: ``impactid bifurcation | restitution | cam-fit``, and its
implementations of ``impactid detachment`` and ``impactid synth`` (shared with rig P; ``--rig
flat-follower``, ``--rig ALZATE2007`` or a flat-follower rig file runs them).

``impactid synth --rig flat-follower`` writes encoder recordings at any cam speed: below the
detachment speed (122.45 rpm for Alzate et al.'s rig) the follower rides the cam
(:func:`~impactid.rigs.flat.synth.synth_flat_encoders`, exact); at or above it the rig's impact
simulator runs with a restitution law (:func:`~impactid.rigs.flat.synth_impacts.synth_flat_impacting`,
``--restitution R`` or ``--restitution-law A,B``; default the stand-in law
:data:`~impactid.rigs.flat.simulate.DEFAULT_RESTITUTION`): the runs ``impactid restitution`` reads.

Thin: parse arguments, call the public API, print results. Cam speeds in rpm or Hz as in the paper;
output paths are checked before any computation and written as transactions
(:mod:`impactid.commandline`).

Light: the arguments are data, and each command imports the numerics (numpy included) when it runs,
so that ``impactid --help`` and ``impactid COMMAND --help`` load neither numpy nor the rig's parameters.
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import replace

from impactid.commandline import (
    CAM_PPR,
    FIGURE_FORMAT,
    JSON,
    MAX_SWEEP_POINTS,
    NOISE_CHANNEL,
    REPORT,
    SAMPLE_RATE,
    SEED,
    SYNTH_DURATION,
    SYNTH_OUT,
    UsageError,
    cam_speed,
    check_outputs,
    check_synth_size,
    command_inputs,
    deliver,
    figure_format,
    fraction,
    integer_in,
    noise_channels,
    num,
    number,
    pair,
    positive,
    print_json,
    recording_arguments,
    recording_paths,
    recording_rig,
    refuse_other_rigs_options,
    rig_help,
    say_written,
    speed_arguments,
    write_synthetic,
)
from impactid.distributed import scheduler_arguments
from impactid.rigs.base import Argument, CommandSpec, argument_dests

#: The rig's model name (``impactid.rigs.flat.parameters.MODEL_NAME``; that module loads numpy).
MODEL_NAME = "flat-follower"

__all__ = ["COMMANDS"]


def run_detachment(args, model) -> int:
    if args.e_over_rc is not None or args.mu is not None:
        raise UsageError("arguments --e-over-rc and --mu apply to the pivoted-follower rig only")
    rig = args.resolved_rig.rig
    hz = rig.detachment_speed_hz()
    data = {"rig": rig.model, "cam_speed_hz": hz, "cam_speed_rpm": hz * 60.0,
            "method": "inverse kinematics: contact torque (A-11) reaches 0"}
    if args.json:
        print_json(data)
    else:
        print(f"detachment at {hz:.6g} Hz ({hz * 60:.6g} rpm)")
    return 0


def _restitution_law(args):
    from impactid.rigs.flat.simulate import DEFAULT_RESTITUTION, SpeedRestitution

    if args.restitution is not None:
        return SpeedRestitution(a=args.restitution)
    if args.restitution_law is not None:
        a, b = args.restitution_law
        return SpeedRestitution.from_rpm(a, b)
    return DEFAULT_RESTITUTION


def run_bifurcation(args, model) -> int:
    import numpy as np

    from impactid._files import StagedFiles
    from impactid.rigs.flat.figures import write_bifurcation
    from impactid.rigs.flat.simulate import bifurcation
    from impactid.rigs.registry import resolve_rig

    resolved = resolve_rig(args.rig, default=MODEL_NAME)
    if resolved.model.name != MODEL_NAME:
        raise UsageError(f"argument --rig: the bifurcation diagram is implemented for the 'flat-follower' rig only, "
                         f"got {resolved.model.name!r} (use impactid regime-map for the pivoted follower)")
    rig = resolved.rig
    if not args.start < args.stop:
        raise UsageError(f"arguments --from/--to: need from < to, got {args.start:g} and {args.stop:g}")
    if args.kept is not None and args.kept > args.revolutions:
        raise UsageError(f"argument --kept: at most --revolutions ({args.revolutions}), got {args.kept}")
    scale = {"rpm": 1.0 / 60.0, "hz": 1.0}[args.unit]
    inputs = command_inputs(args, [])
    check_outputs(args, inputs, out_is_dir=True)
    speeds = np.linspace(args.start, args.stop, args.speeds) * scale
    law = _restitution_law(args)
    from impactid.commandline import progress_bar as task_bar
    from impactid.distributed import scheduler_client

    with scheduler_client(args, what="impactid bifurcation") as client, \
            task_bar(args.speeds, desc="bifurcation", unit="speed") as bar:
        result = bifurcation(rig, speeds, law, revolutions=args.revolutions, kept=args.kept, client=client,
                             progress=lambda done, total: bar.update(done - bar.n))
    with StagedFiles(protect=inputs) as staged:
        paths = write_bifurcation(result, args.out, staged, figure_format(args))
    transitions = result.transitions()
    data = {"transitions": transitions, "detachment_rpm_inverse_kinematics": rig.detachment_speed_hz() * 60.0,
            "restitution_law": law.to_dict(), "regime_counts": result.table["regime"].value_counts().to_dict(),
            "revolutions": result.revolutions, "kept": result.kept, "files": [str(x) for x in paths]}
    if args.json:
        print_json(data)
    else:
        for path in paths:
            print(path)
        print(f"impacts from {num(transitions['detachment_rpm'], '.2f')} rpm (inverse kinematics "
              f"{data['detachment_rpm_inverse_kinematics']:.2f} rpm); period-1 until "
              f"{num(transitions['period1_end_rpm'], '.2f')} rpm; first irregular "
              f"{num(transitions['irregular_rpm'], '.2f')} rpm")
    return 0


def run_restitution(args, model) -> int:
    from impactid.io import read_recording
    from impactid.rigs.flat.encoder_impacts import fit_speed_law, restitution_at_speed
    from impactid.rigs.registry import resolve_rig

    if not args.recordings:
        raise UsageError("give one impacting encoder recording per cam speed")
    inputs = command_inputs(args, args.recordings, [args.profile])
    check_outputs(args, inputs)
    profile = None
    if args.profile:
        from impactid.rigs.flat.camprofile import load_profile_json

        profile = load_profile_json(args.profile)
    rig = resolve_rig(args.rig).rig if args.rig else None
    recordings = [read_recording(path) for path in args.recordings]
    points = [restitution_at_speed(recording, profile, method=args.method, rig=rig, warn=False)
              for recording in recordings]
    result = fit_speed_law(points)
    result = replace(result, details={**result.details,
                                      "profile": args.profile or "analytic A-17 of the recording's rig"})
    data = result.to_dict()
    data["recordings_read"] = [str(p) for p in args.recordings]
    overlays = ()
    if args.plots or args.report:
        overlays = _restitution_overlays(result, points, recordings, rig, profile)
    deliver(args, data, inputs, _restitution_figures(args, result, overlays))
    if args.json:
        return 0
    for p in points:
        print(f"{p.source}: {p.cam_speed_rpm:.2f} rpm, r = {num(p.restitution, '.4f')} +- {num(p.stderr, '.4f')} "
              f"({p.n_impacts} first impacts, {args.method})")
    law = result.details["law"]
    print(f"r = {law['a']:.4f} + ({law['b_per_rpm']:.6f} +- {num(result.details['stderr_b_per_rpm'], '.6f')})"
          f" * rpm (residual RMS {result.residual_rms:.2g})")
    for note in result.notes:
        print(f"impactid: note: {note}", file=sys.stderr)
    for overlay in overlays:
        if overlay.note:
            print(f"impactid: note: figure: {overlay.source}, first impact {overlay.number}: {overlay.note}",
                  file=sys.stderr)
    say_written(args)
    return 0


def _restitution_overlays(result, points, recordings, rig, profile):
    """The first impacts ``restitution --plots``/``--report`` shows, measured and simulated with the fitted law
    (:func:`impactid.rigs.flat.figures.impact_overlays`)."""
    from impactid.rigs.flat.figures import impact_overlays

    a, b = result.value("a"), result.value("b")
    law = result.law if math.isfinite(a) and math.isfinite(b) else None
    return impact_overlays(points, recordings, law, rig=rig, profile=profile)


def _restitution_figures(args, result, overlays):
    """The figures of ``restitution --plots``: their names and their writer."""
    from impactid.rigs.flat import figures

    names = (["restitution_impacts.png"] if overlays else []) + ["restitution_law.png"]
    return names, lambda staged: figures.restitution_figures(result, overlays, args.plots, staged,
                                                             figure_format(args))


def _cam_fit_figures(args, fit):
    """The figures of ``cam-fit --plots``: their names and their writer."""
    from impactid.rigs.flat import figures

    names = ["cam_fit.png"] + (["cam_fit_order.png"] if getattr(fit, "order_table", None) is not None else [])
    return names, lambda staged: figures.cam_fit_figures(fit, args.plots, staged, figure_format(args))


def run_cam_fit(args, model) -> int:
    from impactid.io import read_recording
    from impactid.rigs.flat.camprofile import fit_cam_profile

    path = recording_paths(args)[0]
    inputs = command_inputs(args, [path])
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
            window = pair(args.window)
        except argparse.ArgumentTypeError:
            window = None
        if window is None or not window[0] < window[1]:
            raise UsageError(f"argument --window: expected T0,T1 in seconds with T0 < T1, got {args.window!r}")
    check_outputs(args, inputs)
    rec = read_recording(path, rig=recording_rig(args))
    fit = fit_cam_profile(rec, terms, criterion=args.criterion, max_terms=args.max_terms, window=window,
                          nonnegative=not args.signed, counter=args.counter)
    data = fit.to_dict()
    data["recordings_read"] = [str(path)]
    deliver(args, data, inputs, _cam_fit_figures(args, fit))
    if args.json:
        return 0
    print(fit.report())
    say_written(args)
    return 0


def run_synth(args, model) -> int:
    """``impactid synth --rig flat-follower``: permanent contact below detachment, impacting at or above it."""
    from impactid.synth import SensorModel

    refuse_other_rigs_options(args, argument_dests(_SYNTH.arguments), command="synth", model_name=MODEL_NAME)
    rig, operating = args.resolved_rig.rig, args.resolved_rig.operating
    noise = noise_channels(args.noise_channel)
    speed = cam_speed(args, operating)
    rate = args.sample_rate or 20_000.0
    samples = args.duration * rate
    check_synth_size(samples)
    detachment = rig.detachment_speed_hz()
    impacting = speed >= detachment
    law_given = "--restitution" if args.restitution is not None else (
        "--restitution-law" if args.restitution_law is not None else None)
    if law_given and not impacting:
        raise UsageError(f"argument {law_given}: {speed * 60:.5g} rpm is below the detachment speed "
                         f"{detachment * 60:.5g} rpm: the follower rides the cam and never impacts")
    check_outputs(args, command_inputs(args, []))
    sensors = SensorModel(noise=noise or 0.0, seed=args.seed)
    encoders = dict(sample_rate_hz=rate, cam_ppr=args.cam_ppr or 5000, follower_ppr=args.follower_ppr,
                    cam_zero_offset=args.cam_zero_offset, sensors=sensors)
    if impacting:
        from impactid.rigs.flat.synth_impacts import synth_flat_impacting

        synthetic = synth_flat_impacting(rig, speed, args.duration, restitution=_restitution_law(args), **encoders)
    else:
        from impactid.rigs.flat.synth import synth_flat_encoders

        synthetic = synth_flat_encoders(rig, speed, args.duration, **encoders)
    return write_synthetic(synthetic, args.out)


OUT_JSON = Argument(("--out",), {"metavar": "law.json", "help": "write the results as JSON (atomically)"})

#: The restitution law of rig F's impacts (``bifurcation``; ``synth`` at or above detachment).
RESTITUTION_LAW = (
    Argument(("--restitution",), {"type": fraction, "default": None,
                                  "help": "constant coefficient of restitution (rig F impacts)"},
             exclusive="restitution"),
    Argument(("--restitution-law",), {"type": pair, "default": None, "metavar": "A,B",
                                      "help": "rig F: r = A + B * rpm (default: our stand-in law r = 1.17 - 0.004 "
                                              "rpm, see docs/rig_f.md)"},
             exclusive="restitution"),
)

_SYNTH = CommandSpec("", "synth", "write a synthetic encoder recording of rig F (impacting at or above detachment)", (
    *speed_arguments(rpm=True), SYNTH_DURATION, SAMPLE_RATE, NOISE_CHANNEL, CAM_PPR,
    Argument(("--follower-ppr",), {"type": integer_in(1, 10_000_000), "default": 10_000,
                                   "help": "follower encoder pulses/rev (rig F)"}),
    Argument(("--cam-zero-offset",), {"type": number, "default": None,
                                      "help": "cam encoder zero [rad] (rig F; default random)"}),
    *RESTITUTION_LAW, SEED, SYNTH_OUT), run_synth, rig_argument="resolve")

COMMANDS = (
    CommandSpec("", "bifurcation", "rig F bifurcation diagram over cam speed, CSV and figure (Alzate et al. 2007, "
                                   "Fig. 16)", (
        Argument(("--rig",), {"metavar": "MODEL|PRESET|RIG.toml", "help": rig_help(
            "the flat-follower rig (default: Alzate et al. 2007 Table 5)")}),
        Argument(("--from",), {"dest": "start", "type": positive, "default": 110.0,
                               "help": "lowest cam speed (default 110)"}),
        Argument(("--to",), {"dest": "stop", "type": positive, "default": 165.0,
                             "help": "highest cam speed (default 165)"}),
        Argument(("--unit",), {"choices": ["rpm", "hz"], "default": "rpm",
                               "help": "unit of --from/--to (default rpm)"}),
        Argument(("--speeds",), {"type": integer_in(2, MAX_SWEEP_POINTS), "default": 200,
                                 "help": "number of cam speeds (default 200)"}),
        Argument(("--revolutions",), {"type": integer_in(2, 100_000), "default": 100,
                                      "help": "revolutions simulated per speed (default 100)"}),
        Argument(("--kept",), {"type": integer_in(1, 100_000), "default": None,
                               "help": "last revolutions plotted and classified (default half)"}),
        *RESTITUTION_LAW,
        Argument(("--out",), {"required": True, "metavar": "DIR", "help": "output folder"}),
        FIGURE_FORMAT, JSON, *scheduler_arguments()), run_bifurcation),
    CommandSpec("", "restitution", "rig F: coefficient of restitution per cam speed from impacting encoder "
                                   "recordings, and r = a + b omega", (
        Argument(("recordings",), {"metavar": "REC", "nargs": "*",
                                   "help": "impacting encoder recordings (one per cam speed)"}),
        Argument(("--profile",), {"metavar": "fit.json",
                                  "help": "cam profile from impactid cam-fit (default: analytic A-17)"}),
        Argument(("--method",), {"choices": ["impact-law", "first-bounce"], "default": "impact-law",
                                 "help": "impact-law: fitted flight rates either side of each first impact; "
                                         "first-bounce: the model's r that reproduces the first-bounce height "
                                         "(Alzate et al. 2007)"}),
        Argument(("--rig",), {"metavar": "RIG.toml|MODEL|PRESET",
                              "help": rig_help("the rig for first-bounce and the figures' simulations (default: "
                                               "the recording's)")}),
        OUT_JSON,
        Argument(("--plots",), {"metavar": "DIR",
                                "help": "write figures (measured first impacts against their simulation with the "
                                        "fitted law; the law over cam speed)"}),
        FIGURE_FORMAT, REPORT, JSON), run_restitution),
    CommandSpec("", "cam-fit", "fit a Gaussian-sum cam profile (Alzate et al. 2007, eq. 1) to rig F encoder data", (
        *recording_arguments(),
        Argument(("--terms",), {"default": "7", "metavar": "N|auto",
                                "help": "number of Gaussian terms, or 'auto' to choose 1..--max-terms by --criterion "
                                        "(default 7)"}),
        Argument(("--max-terms",), {"type": integer_in(1, 20), "default": 9,
                                    "help": "highest order tried by --terms auto"}),
        Argument(("--criterion",), {"choices": ["bic", "aic"], "default": "bic",
                                    "help": "order-selection criterion (default bic)"}),
        Argument(("--window",), {"metavar": "T0,T1", "help": "use only the samples with T0 <= t < T1 [s] "
                                                           "(revolutions are still checked inside it)"}),
        Argument(("--counter",), {"choices": ["floor", "round", "none"], "default": "floor",
                                  "help": "encoder counters floor (incremental counter, default) or round; 'none': "
                                          "no correction"}),
        Argument(("--signed",), {"action": "store_true", "help": "allow negative amplitudes (default a_i >= 0)"}),
        Argument(("--out",), {"metavar": "FIT.json",
                              "help": "write the fit result (coefficients, statistics, the sampled profile) as JSON "
                                        "(atomically)"}),
        Argument(("--plots",), {"metavar": "DIR",
                                "help": "write figures (data and fit, residuals, derivatives, order selection)"}),
        FIGURE_FORMAT, REPORT,
        Argument(("--json",), {"action": "store_true", "help": "print the result as JSON"})), run_cam_fit),
    CommandSpec("", "detachment", "cam speed at which the follower leaves the cam (inverse kinematics)", (JSON,),
                run_detachment, rig_argument="resolve"),
    _SYNTH,
)

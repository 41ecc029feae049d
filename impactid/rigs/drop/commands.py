"""Commands of the single-impact test rig.

* ``impactid synth --rig drop-impact|STEEL_ON_PA6|RIG.toml --height H --out drop.h5``: a synthetic
  drop recording (the shared ``synth`` command; its rig P and rig F options are refused here);
* ``impactid drop simulate --height H``: the impact table of a simulated drop;
* ``impactid drop fit REC...``: ``k``, ``beta`` and ``n`` from drop recordings.

Each command checks its outputs before computing, writes them as one transaction, prints a short
report or, with ``--json``, the JSON document, and raises :class:`~impactid.errors.ImpactidError`
for what the user can fix. SI units on the command line (heights in m, speeds in m/s, ``beta`` in
N s m^-(n+1)). Importing this module loads no numerics (nor numpy: the figures' module is imported
when a figure is written); the fit's arguments are declared in :mod:`impactid.rigs.drop.arguments`.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

from impactid.commandline import (
    FIGURE_FORMAT,
    NOISE_CHANNEL,
    REPORT,
    SAMPLE_RATE,
    SEED,
    SYNTH_DURATION,
    SYNTH_OUT,
    UsageError,
    check_outputs,
    check_synth_size,
    command_inputs,
    deliver,
    exponent,
    fraction,
    integer_in,
    noise_channels,
    nonnegative,
    num,
    number,
    positive,
    refuse_other_rigs_options,
    say_written,
    write_synthetic,
)
from impactid.rigs.base import Argument, CommandSpec, argument_dests
from impactid.rigs.drop.arguments import fit_arguments

__all__ = ["COMMANDS", "fit_arguments", "fit_figures"]

MODEL_NAME = "drop-impact"

# ---- the shared ``synth`` options this rig uses, declared exactly as rig P declares them ----------
_NOISE = Argument(("--noise",), {"type": fraction, "default": 0.0,
                                 "help": "Gaussian noise, fraction of peak, analogue channels"})
_ADC_BITS = Argument(("--adc-bits",), {"type": integer_in(2, 32), "default": None,
                                       "help": "ADC resolution [bits] (default: none)"})
_ACCEL_OFFSET = Argument(("--accel-offset",), {"type": number, "default": 0.0, "help": "accelerometer offset [m/s^2]"})
_ACCEL_DRIFT = Argument(("--accel-drift",), {"type": number, "default": 0.0,
                                             "help": "accelerometer drift [m/s^2 per s]"})
_DECIMATE = Argument(("--decimate",), {"type": integer_in(1, 64), "default": 1,
                                       "help": "anti-alias filter and decimation factor (default 1)"})
# ---- this rig's own options --------------------------------------------------------------------
_HEIGHT = Argument(("--height",), {"type": nonnegative, "default": None, "metavar": "M",
                                   "help": "drop-impact: fall of the contact point to the contact surface [m] "
                                           "(default: the rig file's [operating] drop_height_m)"})
_RELEASE = Argument(("--release-speed",), {"type": nonnegative, "default": None, "metavar": "M/S",
                                           "help": "drop-impact: speed at release towards the contact [m/s] "
                                                   "(default: the rig file's release_speed_m_s, else 0)"})
_BETA = Argument(("--damping-beta",), {"type": nonnegative, "default": None, "metavar": "BETA",
                                       "help": "drop-impact: Hunt-Crossley damping beta [N s m^-(n+1)] (default: "
                                               "0.3 s/m times the rig's k, a restitution of about 0.8 at 1 m/s)"})
_N = Argument(("--damping-n",), {"type": exponent, "default": None, "metavar": "N",
                                 "help": "drop-impact: Hunt-Crossley damping index n (default: the rig's p)"})
_PRE_TRIGGER = Argument(("--pre-trigger",), {"type": nonnegative, "default": None, "metavar": "S",
                                             "help": "drop-impact: recorded time before the first impact [s] "
                                                     "(default 0.01)"})
_ACCEL_ONLY = Argument(("--accelerometer-only",), {"action": "store_true",
                                                   "help": "drop-impact: record no contact force"})
_RIG_FILE = Argument(("--rig-file",), {"metavar": "RIG.toml",
                                       "help": "TOML rig file of the drop rig (default: the STEEL_ON_PA6 preset; for "
                                               "fit: the recordings' own rigs)"})
_JSON = Argument(("--json",), {"action": "store_true", "help": "print the result as JSON"})
_PLOTS = Argument(("--plots",), {"metavar": "DIR", "help": "write figures into this folder"})


def _height(args, operating) -> tuple[float, float]:
    height = args.height if args.height is not None else operating.get("drop_height_m")
    if height is None:
        raise UsageError("argument --height: no drop height: give --height M, or a rig file with [operating] "
                         "drop_height_m")
    release = args.release_speed if args.release_speed is not None else operating.get("release_speed_m_s", 0.0)
    if not (math.isfinite(height) and height >= 0.0 and math.isfinite(release) and release >= 0.0):
        raise UsageError(f"drop height {height!r} m and release speed {release!r} m/s must be >= 0")
    if height == 0.0 and release == 0.0:
        raise UsageError("argument --height: the height and the release speed are both 0: nothing impacts")
    return float(height), float(release)


def _law(args, rig):
    from impactid.rigs.drop.parameters import DropLaw, nominal_law

    nominal = nominal_law(rig)
    return DropLaw(beta=nominal.beta if args.damping_beta is None else args.damping_beta,
                   n=nominal.n if args.damping_n is None else args.damping_n)


def _rig_file(args):
    """``--rig-file`` (a drop rig) or the default preset, with its operating table."""
    from impactid.errors import RigParameterError
    from impactid.rigs.drop.parameters import STEEL_ON_PA6
    from impactid.rigs.registry import load_rig_toml

    if not getattr(args, "rig_file", None):
        return STEEL_ON_PA6, {}
    rig, operating = load_rig_toml(args.rig_file)
    if rig.model != MODEL_NAME:
        raise RigParameterError(f"{args.rig_file}: a {rig.model!r} rig, expected {MODEL_NAME!r}")
    return rig, operating


# ---- impactid synth --rig drop-impact --------------------------------------------------------------


def run_synth(args, model) -> int:
    from impactid.rigs.drop.synth import DEFAULT_PRE_TRIGGER_S, DEFAULT_SAMPLE_RATE_HZ, synth_drop_impact
    from impactid.synth.sensors import SensorModel

    refuse_other_rigs_options(args, argument_dests(_SYNTH.arguments), command="synth", model_name=MODEL_NAME,
                              note=" (the drop's damping is --damping-beta/--damping-n)")
    rig, operating = args.resolved_rig.rig, args.resolved_rig.operating
    height, release = _height(args, operating)
    law = _law(args, rig)
    rate = args.sample_rate or DEFAULT_SAMPLE_RATE_HZ
    check_synth_size(args.duration * rate * args.decimate)
    check_outputs(args, command_inputs(args, []))
    noise = noise_channels(args.noise_channel)
    sensors = SensorModel(noise=noise or args.noise, adc_bits=args.adc_bits, accel_offset=args.accel_offset,
                          accel_drift=args.accel_drift, decimation=args.decimate, seed=args.seed)
    from impactid.rigs.drop.parameters import ACCELERATION_CHANNEL, FORCE_CHANNEL

    channels = (ACCELERATION_CHANNEL,) if args.accelerometer_only else (ACCELERATION_CHANNEL, FORCE_CHANNEL)
    synthetic = synth_drop_impact(rig, law, height, release_speed=release, duration=args.duration,
                                  pre_trigger=DEFAULT_PRE_TRIGGER_S if args.pre_trigger is None else args.pre_trigger,
                                  sample_rate_hz=rate, sensors=sensors, channels=channels)
    return write_synthetic(synthetic, args.out)


_SYNTH = CommandSpec(
    "", "synth", "write a synthetic recording (S2/S3 of rig P, encoders of rig F, drops of drop-impact)",
    (_HEIGHT, _RELEASE, _BETA, _N, _PRE_TRIGGER, _ACCEL_ONLY, SYNTH_DURATION, SAMPLE_RATE, _NOISE, NOISE_CHANNEL,
     _ADC_BITS, _ACCEL_OFFSET, _ACCEL_DRIFT, _DECIMATE, SEED, SYNTH_OUT),
    run_synth, rig_argument="resolve")


# ---- impactid drop simulate ----------------------------------------------------------------------


def run_simulate(args, model) -> int:
    from impactid.rigs.drop.simulate import simulate_drop

    rig, operating = _rig_file(args)
    height, release = _height(args, operating)
    law = _law(args, rig)
    inputs = command_inputs(args, [], extra=[getattr(args, "rig_file", None)])
    check_outputs(args, inputs)
    run = simulate_drop(rig, law, height, release_speed=release, duration=args.duration)
    table = run.impacts
    data = {"rig": {"model": MODEL_NAME, **rig.to_dict()}, "law": {"beta": law.beta, "n": law.n},
            "drop_height_m": height, "release_speed_m_s": release,
            "impact_speed_m_s": rig.impact_speed(height, release),
            "t_end_s": run.t_end, "rest_time_s": run.t_rest, "contact_steps": run.n_steps,
            "impacts": table.to_dict(orient="list")}

    def figures(staged):
        from impactid.rigs.drop.figures import drop_figure, save

        return [save(drop_figure(run), Path(args.plots) / "drop_force.png", staged)]

    deliver(args, data, inputs, (["drop_force.png"], figures) if args.plots else None)
    if args.json:
        return 0
    print(f"impactid drop simulate: {rig.mass:g} kg from {height:g} m at {release:g} m/s (impact speed "
          f"{rig.impact_speed(height, release):.4g} m/s), k = {rig.k:.4g} N/m^{rig.p:g}, beta = {law.beta:.4g} "
          f"N s/m^{law.n + 1:g}, n = {law.n:g}")
    rest = (f"at rest after {run.t_rest:.4g} s" if math.isfinite(run.t_rest) else
            f"not at rest by {run.t_end:.4g} s")
    print(f"  {len(table)} contact phase(s); {rest}")
    shown = table.head(args.show)
    for _, row in shown.iterrows():
        print(f"  t = {row.onset_time_s:.6f} s  v_in = {row.approach_speed_m_s:.4g} m/s  delta_max = "
              f"{1e3 * row.max_penetration_m:.4g} mm  F_max = {row.peak_force_n:.4g} N  T = "
              f"{1e3 * row.contact_duration_s:.4g} ms  v_out = {num(row.separation_speed_m_s, '.4g')} m/s  "
              f"e = {num(row.restitution, '.4g')}  ({row.end})")
    if len(table) > len(shown):
        print(f"  ... {len(table) - len(shown)} more (--show N, or --out)")
    say_written(args)
    return 0


# ---- impactid drop fit ---------------------------------------------------------------------------


def fit_figures(result, plots: str | os.PathLike[str] | None):
    """The figure of a drop fit's ``--plots``: its name and its writer (measured and simulated contact
    signals with the residuals; ``plots`` None: drawn for the ``--report`` page only)."""

    def write(staged):
        from impactid.rigs.drop.figures import save

        return [save(result.plot(), Path(plots or ".") / "drop_fit.png", staged)]

    return ["drop_fit.png"], write


def run_fit(args, model) -> int:
    from impactid._files import check_distinct_inputs
    from impactid.io import read_recording
    from impactid.rigs.drop.identify import fit_drop

    paths = list(args.recordings)
    if len(paths) > 1:
        check_distinct_inputs(paths, what="recording")
    inputs = command_inputs(args, paths, extra=[getattr(args, "rig_file", None)])
    check_outputs(args, inputs)
    recordings = [read_recording(p, rig=args.rig_file) for p in paths]
    result = fit_drop(recordings, fix_n=args.fix_n, channels=args.channels, max_impacts=args.max_impacts,
                      speeds=args.speeds, confidence=args.confidence)
    data = result.to_dict()
    data["recordings_read"] = [str(p) for p in paths]

    deliver(args, data, inputs, fit_figures(result, args.plots))  # --plots, and the --report page
    if args.json:
        return 0
    print(result.report())
    say_written(args)
    return 0


COMMANDS = (
    _SYNTH,
    CommandSpec("drop", "simulate", "simulate a drop: the impact table through the bounces to rest", (
        _RIG_FILE, _HEIGHT, _RELEASE, _BETA, _N,
        Argument(("--duration",), {"type": positive, "default": None, "metavar": "S",
                                   "help": "simulated time [s] (default: until the impactor rests on the contact)"}),
        Argument(("--show",), {"type": integer_in(0, 1_000_000), "default": 10, "help": "impacts to print"}),
        Argument(("--out",), {"metavar": "RESULT.json", "help": "write the result as JSON (atomically)"}),
        _PLOTS, FIGURE_FORMAT, _JSON), run_simulate),
    CommandSpec("drop", "fit", "fit the Hunt-Crossley contact (k, beta, n) to drop recordings", (
        Argument(("recordings",), {"metavar": "REC", "nargs": "+",
                                   "help": "HDF5 or CSV drop recordings (several: joint fit)"}),
        _RIG_FILE,
        *fit_arguments(),
        Argument(("--out",), {"metavar": "RESULT.json", "help": "write the result as JSON (atomically)"}),
        _PLOTS, FIGURE_FORMAT, REPORT, _JSON), run_fit),
)

"""The ``impactid valvetrain ...`` commands of the finger-follower rig (``--rig finger-follower-hla``).

Each command checks its outputs before computing, writes them as one transaction (nothing partial
on an error, Ctrl-C or SIGTERM), prints a short report or, with ``--json``, the JSON document, and
raises :class:`~impactid.errors.ImpactidError` for what the user can fix (the command line prints
it as one ``impactid: error: ...`` line). Units at the edge: rpm, mm, um and deg in text; JSON keys
carry their SI unit in their names.

Every camshaft speed a command takes (``--rpm``, ``--rpms``, ``--rpm-from``/``--rpm-to``, a
recording's operating point) must lie in the range the model describes,
:func:`~impactid.rigs.finger_follower.simulate.speed_range` (1/300 to 3 times the rigid train's
jump speed; the decision is documented in :class:`impactid.rigs.valvespring.CamSpeedRange`). The
commands are shared with the other valve train, so argparse accepts the union of both rigs' options:
the flags both declare are declared alike, with no choices or defaults that would reject or hide the
other's values; this rig checks its own and refuses an option of the other rig instead of ignoring
it. Light: the arguments are data and each command imports the numerics when it runs (``impactid
valvetrain COMMAND --help`` loads neither numpy nor pandas).
"""

from __future__ import annotations

import json
import math
import sys
import warnings
from pathlib import Path
from typing import Any

from impactid.commandline import (
    FIGURE_FORMAT,
    REPORT,
    check_report,
    integer_in,
    positive,
    refuse_foreign_options,
    say_report,
    write_report,
)
from impactid.errors import RigParameterError, SimulationError, SimulationInputError
from impactid.rigs.base import Argument, CommandSpec

__all__ = ["COMMANDS"]

MODEL_NAME = "finger-follower-hla"
#: The paper presets ``--preset`` names (validated here: the other valve train has its own).
PRESETS = ("kim1990", "kim1990-table2")
#: Finest ``--resolution-rpm`` of ``jump-speed``: far below any physical meaning, and the bisection
#: stops after about 20 halvings instead of looping at the floating-point resolution.
MIN_RESOLUTION_RPM = 1e-4
#: Most sweep speeds of ``jump-speed`` and of ``leakdown`` (each one a periodic steady state).
MAX_SWEEP_SPEEDS = 400
MAX_LEAKDOWN_SPEEDS = 200
#: Whole revolutions ``synth`` records.
MAX_SYNTH_REVOLUTIONS = 1000

# ---- shared flags, declared exactly as the other valve-train rig declares them -------------------
RPM = Argument(("--rpm",), {"type": float, "help": "camshaft speed [rpm]"})
JSON = Argument(("--json",), {"action": "store_true", "help": "print the result as JSON"})
OUT = Argument(("--out",), {"help": "write the JSON result to this file"})
PLOTS = Argument(("--plots",), {"help": "write figures into this folder"})
RIG_FILE = Argument(("--rig-file",), {"help": "TOML rig file (default: the rig's paper preset)"})
# ---- this rig's own flags ----------------------------------------------------------------------
LIFT = Argument(("--lift",), {"help": "finger-follower: cam lift file (CSV gamma_rad,lift_m or TOML [lift]); "
                                      "default the rig's cycloidal law or the rig file's [lift] table"})
PRESET = Argument(("--preset",), {"default": None, "metavar": "NAME",
                                  "help": "named parameter set when no rig file is given (finger-follower: kim1990 "
                                          "(default), kim1990-table2)"})
#: shared with the cycloidal rig's synth, declared exactly alike (each rig checks its own limits)
REVOLUTIONS = Argument(("--revolutions",), {"type": positive, "default": None,
                                            "help": "revolutions recorded (cycloidal: default 4, need not be whole; "
                                                    "finger-follower: whole, default 16)"})
SEED = Argument(("--seed",), {"type": integer_in(0, 2**31 - 1), "default": None, "help": "random seed (default 0)"})


def _positive(name: str, value) -> float:
    if value is None:
        raise SimulationInputError(f"argument {name}: required")
    value = float(value)
    if not (math.isfinite(value) and value > 0.0):
        raise SimulationInputError(f"argument {name}: must be positive, got {value!r}")
    return value


def _own_options(args, model) -> None:
    """Options of the other valve train's version of this command are refused."""
    refuse_foreign_options(args, model)


def _speed_check(train, value, what: str) -> float:
    """A camshaft speed [rpm] inside the rig's :func:`~impactid.rigs.finger_follower.simulate.speed_range`."""
    from impactid.rigs.finger_follower.simulate import speed_range

    return speed_range(train).check(value, what)


def _rig_and_lift(args, default_rig=None):
    """The rig (``--rig-file``, ``--preset`` or ``default_rig``, else the paper preset) and the lift law."""
    from impactid.rigs.finger_follower.cam import read_lift
    from impactid.rigs.finger_follower.parameters import KIM1990, KIM1990_TABLE2

    lift = None
    rig_file = getattr(args, "rig_file", None)
    preset = getattr(args, "preset", None)
    if preset is not None and preset not in PRESETS:
        raise SimulationInputError(f"argument --preset: unknown preset {preset!r} for the {MODEL_NAME!r} rig "
                                   f"(choose from {', '.join(PRESETS)})")
    if rig_file and preset:
        raise SimulationInputError("give either --rig-file or --preset, not both")
    if rig_file:
        from impactid.rigs._toml import read_toml
        from impactid.rigs.registry import load_rig_toml

        rig, _ = load_rig_toml(rig_file)
        if rig.model != MODEL_NAME:
            raise RigParameterError(f"{rig_file}: a {rig.model!r} rig, expected {MODEL_NAME!r}")
        if isinstance(read_toml(rig_file).get("lift"), dict):
            lift = read_lift(rig_file)
    elif preset == "kim1990-table2":
        rig = KIM1990_TABLE2
    else:
        rig = default_rig if default_rig is not None else KIM1990
    if getattr(args, "lift", None):
        lift = read_lift(args.lift)
    return rig, lift


def _inputs(args, extra=()) -> list:
    files = [f for f in (getattr(args, "rig_file", None), getattr(args, "lift", None)) if f] + list(extra)
    return files


def _check(args, inputs, out_option: str = "--out") -> None:
    from impactid._files import check_output

    if getattr(args, "out", None):
        check_output(args.out, option=out_option, inputs=inputs)
    if getattr(args, "plots", None):
        check_output(args.plots, option="--plots", inputs=inputs, directory=True)
    check_report(args, inputs, others={out_option: getattr(args, "out", None)})


def _json_text(data: dict) -> str:
    from impactid.results import json_ready

    return json.dumps(json_ready(data), indent=2, allow_nan=False) + "\n"


def _deliver(args, data: dict, inputs, figures=()) -> None:
    """``--out`` JSON and ``--plots`` figures in one transaction; ``--json`` to stdout."""
    from impactid._files import StagedFiles
    from impactid.commandline import figure_format

    fmt = figure_format(args)
    if args.plots and figures:
        from impactid.plotting import figure_name

        data["plots"] = [figure_name(Path(args.plots) / name, fmt) for name, _ in figures]
    with StagedFiles(protect=inputs) as staged:
        if args.out:
            staged.write_text(args.out, _json_text(data))
        if args.plots and figures:
            from impactid.rigs.finger_follower import figures as F

            for name, make in figures:
                F.save(make(), Path(args.plots) / name, staged, fmt)
    if getattr(args, "report", None) is not None:  # the fit commands' --report: the figures drawn again, for the page
        from impactid.rigs.finger_follower import figures as F

        write_report(args, data, inputs, ([name for name, _ in figures], lambda staged: [
            F.save(make(), Path(args.plots) / name, staged, figure_format(args)) for name, make in figures]))
    if args.json:
        sys.stdout.write(_json_text(data))


def _mm(x) -> str:
    return "undetermined" if x is None or not math.isfinite(x) else f"{1e3 * x:.4g} mm"


# ============================================================================================
# simulate
# ============================================================================================


def run_simulate(args, model) -> int:
    """``impactid valvetrain simulate --rig finger-follower-hla --rpm N``."""
    from impactid.rigs.finger_follower import analysis
    from impactid.rigs.finger_follower import figures as F
    from impactid.rigs.finger_follower.simulate import prepare, steady_state, summarize

    _own_options(args, model)
    _positive("--rpm", args.rpm)
    inputs = _inputs(args)
    _check(args, inputs)
    rig, lift = _rig_and_lift(args)
    train = prepare(rig, lift, clip_tension=bool(getattr(args, "clip_tension", False)),
                    moment_cos=bool(getattr(args, "moment_cos", False)))
    rpm = _speed_check(train, args.rpm, "argument --rpm")
    state = steady_state(train, rpm)
    s = summarize(state)
    seps = [{"contact": e["contact"], "criterion": e["criterion"], "start_cam_angle_deg": e["start_deg"],
             "end_cam_angle_deg": e["end_deg"], "revolution": e["revolution"]} for e in s["separations"]]
    data: dict[str, Any] = {"rig": MODEL_NAME, "rpm": rpm, "alpha": state.alpha, "beta": state.beta,
                            "converged": state.converged, "period_revolutions": state.period,
                            "revolutions_run": s["revolutions_run"],
                            "max_valve_lift_m": s["max_valve_lift_m"],
                            "max_tappet_leakdown_m": s["max_tappet_leakdown_m"],
                            "seating_speed_m_s": s["seating_speed_m_s"],
                            "peak_cam_force_opening_N": s["peak_cam_force_opening_N"],
                            "peak_cam_force_closing_N": s["peak_cam_force_closing_N"],
                            "peak_cam_force_nose_N": s["peak_cam_force_nose_N"],
                            "valve_opens_deg": s["valve_opens_deg"], "valve_closes_deg": s["valve_closes_deg"],
                            "jump": s["jump"], "bounce": s["bounce"], "tappet_separation": s["tappet_separation"],
                            "openings_per_revolution": s["openings_per_revolution"], "bounces": s["bounces"],
                            "separations": seps,
                            "min_force_N": {k: s[f"min_{k}_N"] for k in ("F_tf", "F_fc", "F_vf", "F_seat")},
                            "max_force_N": {k: s[f"max_{k}_N"] for k in ("F_tf", "F_fc", "F_vf", "F_seat")},
                            "notes": list(state.notes)}
    figures = []
    if args.plots:
        table = analysis.cycle_table(state)
        figures = [("cycle.png", lambda: F.plot_cycle(table, rpm=rpm)),
                   ("rocker_ratio.png", lambda: F.plot_rocker_ratio(train.kinematics))]
    _deliver(args, data, inputs, figures)
    if not args.json:
        print(f"finger-follower-hla at {rpm:.6g} rpm camshaft ({'periodic' if state.converged else 'NOT periodic'}, "
              f"{s['revolutions_run']} revolutions run): valve lift {_mm(s['max_valve_lift_m'])}, tappet leak-down "
              f"{1e6 * s['max_tappet_leakdown_m']:.4g} um, seating speed {s['seating_speed_m_s']:.4g} m/s")
        print(f"  cam force peaks: opening {s['peak_cam_force_opening_N']:.5g} N, closing "
              f"{s['peak_cam_force_closing_N']:.5g} N; jump {'yes' if s['jump'] else 'no'}, bounce "
              f"{'yes' if s['bounce'] else 'no'}, {len(seps)} separation interval(s)")
        for note in state.notes:
            print(f"  note: {note}")
    return 0


# ============================================================================================
# modes
# ============================================================================================


def run_modes(args, model) -> int:
    """``impactid valvetrain modes --rig finger-follower-hla``: linearised natural frequencies."""
    from impactid.rigs.finger_follower.simulate import natural_frequencies, prepare

    _own_options(args, model)
    inputs = _inputs(args)
    _check(args, inputs)
    rig, lift = _rig_and_lift(args)
    train = prepare(rig, lift)
    speed_hz = _speed_check(train, args.rpm, "argument --rpm") / 60.0 if args.rpm is not None else None
    seated = natural_frequencies(train, "seated", speed_hz=speed_hz)
    opened = natural_frequencies(train, "open", speed_hz=speed_hz)
    data = {"rig": MODEL_NAME, "beta": seated.beta,
            "frequencies_hz": {"seated": seated.frequencies_hz.tolist(), "open": opened.frequencies_hz.tolist()},
            "dominant": {"seated": list(seated.dominant), "open": list(opened.dominant)},
            "open_cam_angle_deg": math.degrees(opened.theta)}
    _deliver(args, data, inputs)
    if not args.json:
        for name, m in (("seated", seated), ("open (cam at the nose)", opened)):
            print(f"{name}: " + ", ".join(f"{f:.1f} Hz ({d})" for f, d in zip(m.frequencies_hz, m.dominant)))
    return 0


# ============================================================================================
# jump-speed
# ============================================================================================


def run_jump_speed(args, model) -> int:
    """``impactid valvetrain jump-speed --rig finger-follower-hla``: jump and bounce speeds."""
    from impactid.rigs.finger_follower.simulate import critical_speeds, prepare

    _own_options(args, model)
    inputs = _inputs(args)
    _check(args, inputs)
    lo = _positive("--rpm-from", 1000.0 if args.rpm_from is None else args.rpm_from)
    hi = _positive("--rpm-to", 6000.0 if args.rpm_to is None else args.rpm_to)
    step = _positive("--rpm-step", 250.0 if args.rpm_step is None else args.rpm_step)
    res = _positive("--resolution-rpm", 1.0 if args.resolution_rpm is None else args.resolution_rpm)
    if not lo < hi:
        raise SimulationInputError(f"argument --rpm-to: must exceed --rpm-from ({lo:g} rpm), got {hi:g}")
    rig, lift = _rig_and_lift(args)
    train = prepare(rig, lift)
    _speed_check(train, lo, "argument --rpm-from")
    _speed_check(train, hi, "argument --rpm-to")
    if step > hi - lo or (hi - lo) / step > MAX_SWEEP_SPEEDS:
        raise SimulationInputError(f"argument --rpm-step: {step:g} rpm gives {(hi - lo) / step:.3g} steps from "
                                   f"{lo:g} to {hi:g} rpm; give 1 to {MAX_SWEEP_SPEEDS}")
    if res < MIN_RESOLUTION_RPM:
        raise SimulationInputError(f"argument --resolution-rpm: at least {MIN_RESOLUTION_RPM:g} rpm, got {res:g}")
    speeds = critical_speeds(train, rpm_from=lo, rpm_to=hi, step_rpm=step, resolution_rpm=res)
    data = {"rig": MODEL_NAME, "jump_speed_rpm": speeds.jump_speed_rpm, "bounce_speed_rpm": speeds.bounce_speed_rpm,
            "resolution_rpm": res, "notes": list(speeds.notes),
            "sweep": speeds.sweep.to_dict(orient="records")}
    _deliver(args, data, inputs)
    if not args.json:
        def fmt(x):
            return "none in the range" if not math.isfinite(x) else f"{x:.1f} rpm"
        print(f"jump speed {fmt(speeds.jump_speed_rpm)}, bounce speed {fmt(speeds.bounce_speed_rpm)} "
              f"(sweep {lo:g}-{hi:g} rpm by {step:g}, bisection to {res:g} rpm)")
        for note in speeds.notes:
            print(f"  note: {note}")
    return 0


# ============================================================================================
# leakdown
# ============================================================================================


def run_leakdown(args, model) -> int:
    """``impactid valvetrain leakdown``: maximum tappet leak-down against camshaft speed (Fig. 8).

    A speed that cannot be simulated is reported (``failure`` in the JSON, an ``impactid: warning:``
    line) without taking the others with it; the command then exits with 1 (2 when none ran)."""
    from impactid.rigs.finger_follower import figures as F
    from impactid.rigs.finger_follower.simulate import leakdown_curve, prepare

    _own_options(args, model)
    inputs = _inputs(args)
    _check(args, inputs)
    text = DEFAULT_LEAKDOWN_RPMS if args.rpms is None else str(args.rpms)
    try:
        rpms = [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise SimulationInputError(f"argument --rpms: a comma-separated list of speeds, got {args.rpms!r}") from None
    if not rpms or len(rpms) > MAX_LEAKDOWN_SPEEDS:
        raise SimulationInputError(f"argument --rpms: give 1 to {MAX_LEAKDOWN_SPEEDS} speeds")
    for r in rpms:
        _positive("--rpms", r)
    rig, lift = _rig_and_lift(args)
    train = prepare(rig, lift)
    for r in rpms:
        _speed_check(train, r, "argument --rpms")
    frame = leakdown_curve(train, rpms)
    failed = frame[frame["failure"] != ""]
    if len(failed) == len(frame):
        raise SimulationError("no speed could be simulated: " + "; ".join(failed["failure"]))
    data = {"rig": MODEL_NAME, "leakdown": frame.to_dict(orient="records")}
    _deliver(args, data, inputs, [("leakdown.png", lambda: F.plot_leakdown(frame))])
    for row in failed.itertuples():
        warnings.warn(f"{row.rpm:g} rpm left out (the other speeds were computed): {row.failure}", stacklevel=2)
    if not args.json:
        for row in frame.itertuples():
            value = "could not be simulated" if row.failure else f"{1e6 * row.max_tappet_leakdown_m:7.3f} um"
            print(f"{row.rpm:8.6g} rpm: max leak-down {value}")
    return 1 if len(failed) else 0


# ============================================================================================
# synth
# ============================================================================================


def run_synth(args, model) -> int:
    """``impactid valvetrain synth --rig finger-follower-hla --rpm N --out REC.h5``."""
    from impactid._files import check_output
    from impactid.rigs.finger_follower.simulate import prepare
    from impactid.rigs.finger_follower.synth import Sensors, synth_recording

    _own_options(args, model)
    _positive("--rpm", args.rpm)
    if not args.out:
        raise SimulationInputError("argument --out: the recording file to write (.h5, or .csv with its .toml)")
    inputs = _inputs(args)
    check_output(args.out, option="--out", inputs=inputs)
    if str(args.out).lower().endswith(".csv"):  # the CSV's rig file is written next to it
        check_output(Path(args.out).with_suffix(".toml"), option="--out (its .toml rig file)", inputs=inputs)
    revolutions = 16.0 if args.revolutions is None else float(args.revolutions)
    if not (revolutions.is_integer() and 1 <= revolutions <= MAX_SYNTH_REVOLUTIONS):
        raise SimulationInputError(f"argument --revolutions: a whole number from 1 to {MAX_SYNTH_REVOLUTIONS} for "
                                   f"the {MODEL_NAME!r} rig, got {args.revolutions:g}")
    revolutions = int(revolutions)
    sampling = args.sampling or "angle"
    rig, lift = _rig_and_lift(args)
    rpm = _speed_check(prepare(rig, lift), args.rpm, "argument --rpm")
    sensors = Sensors.ideal() if args.noise_free else Sensors()
    synth = synth_recording(rig, rpm, revolutions=revolutions, sampling=sampling, lift=lift, sensors=sensors,
                            seed=0 if args.seed is None else int(args.seed))
    if str(args.out).lower().endswith(".csv"):
        from impactid.io import write_csv

        write_csv(synth.recording, args.out)
    else:
        synth.write(args.out)
    if args.json:
        sys.stdout.write(_json_text({"recording": str(args.out), "rpm": rpm, "revolutions": revolutions,
                                     "sampling": sampling, "samples": synth.recording.n_samples}))
    else:
        print(f"wrote {args.out}: {revolutions} revolutions at {rpm:.6g} rpm, {sampling}-domain sampling, "
              f"{synth.recording.n_samples} samples")
    return 0


# ============================================================================================
# fit-tappet, fit-lift
# ============================================================================================


def _read(paths, args):
    from impactid.io import read_recording

    rig_file = getattr(args, "rig_file", None)
    recs = [read_recording(p, rig=rig_file) if rig_file else read_recording(p) for p in paths]
    for rec in recs:
        rec.require_rig(MODEL_NAME)
    return recs


def _document(result, paths) -> dict:
    """The JSON document of a fit command: the result's (the FitResult schema, docs/formats.md) and the
    recordings read (``recordings_read``); ``--plots`` adds ``plots``."""
    return {**result.to_dict(), "recordings_read": [str(p) for p in paths]}


def run_fit_tappet(args, model) -> int:
    """``impactid valvetrain fit-tappet REC [REC ...]``: the tappet drag (alpha, beta; c_t, k_t).

    One fit of all recordings (``--joint``, or one recording: a ``TappetFit``) or one fit per
    recording (a :class:`TappetFitSet`). Without ``--joint`` a recording that cannot be fitted does
    not take the others with it: it is listed under ``details.failed`` (and in an ``impactid: warning:``
    line) and the command exits with 1; 2 when none could be fitted.
    """
    from impactid._files import check_distinct_inputs
    from impactid.errors import ImpactidError
    from impactid.rigs.finger_follower.cam import read_lift
    from impactid.rigs.finger_follower.identify import IdentificationError, TappetFitSet, fit_tappet_drag

    _own_options(args, model)
    paths = list(args.recordings)
    check_distinct_inputs(paths)
    inputs = _inputs(args, paths)
    _check(args, inputs)
    lift = read_lift(args.lift) if getattr(args, "lift", None) else None
    failed: list[dict] = []
    if args.joint or len(paths) == 1:
        fits = [fit_tappet_drag(_read(paths, args), lift=lift, joint=True)]
        result = fits[0]
    else:
        fits = []
        for path in paths:
            try:
                fits.append(fit_tappet_drag(_read([path], args)[0], lift=lift))
            except ImpactidError as exc:
                failed.append({"recording": str(path), "reason": str(exc)})
        if not fits:
            raise IdentificationError("no recording could be fitted: " + "; ".join(f["reason"] for f in failed))
        result = TappetFitSet.of(fits, failed)
    data = _document(result, paths)
    figures = [(f"tappet_fit_{k}.png", (lambda f=f: f.plot())) for k, f in enumerate(fits)]
    _deliver(args, data, inputs, figures)
    for f in fits:
        for note in f.notes:
            warnings.warn(note, stacklevel=2)
    for f in failed:
        warnings.warn(f"not fitted (the other recordings were): {f['reason']}", stacklevel=2)
    if not args.json:
        for f in fits:
            print(f.report())
        say_report(args)
    return 1 if failed else 0


def run_fit_lift(args, model) -> int:
    """``impactid valvetrain fit-lift REC``: cam lift law and nose phase from low-speed valve motion."""
    from impactid.rigs.finger_follower.identify import fit_cam_lift

    _own_options(args, model)
    inputs = _inputs(args, [args.recording])
    _check(args, inputs)
    rec = _read([args.recording], args)[0]
    fit = fit_cam_lift(rec)
    data = _document(fit, [args.recording])
    _deliver(args, data, inputs, [("lift_fit.png", fit.plot)])
    for note in fit.notes:
        warnings.warn(note, stacklevel=2)
    if not args.json:
        print(fit.report())
        say_report(args)
    return 0


def run_fit_damping(args, model) -> int:
    """``impactid valvetrain fit-damping REC``: the contact and valve-spring damping ratios from the
    valve's ringing at closure (the tappet drag is the rig's: fit it first and put it in the rig file)."""
    from impactid.results import FitResult
    from impactid.rigs.finger_follower.cam import read_lift
    from impactid.rigs.finger_follower.identify import fit_damping

    _own_options(args, model)
    inputs = _inputs(args, [args.recording])
    _check(args, inputs)
    lift = read_lift(args.lift) if getattr(args, "lift", None) else None
    rec = _read([args.recording], args)[0]
    fit = fit_damping(rec, lift=lift)
    data = _document(fit, [args.recording])
    figures = [("damping_fit.png", fit.plot)] if type(fit).plot is not FitResult.plot else []
    _deliver(args, data, inputs, figures)
    for note in fit.notes:
        warnings.warn(note, stacklevel=2)
    if not args.json:
        print(fit.report())
        say_report(args)
    return 0


#: Speeds of ``leakdown`` when ``--rpms`` is not given [rpm].
DEFAULT_LEAKDOWN_RPMS = "600,800,900,1200,1600,2000,2450,3000"
_CLIP = Argument(("--clip-tension",), {"action": "store_true",
                                       "help": "finger-follower: also drop a contact while its force would be "
                                               "tensile"})
_MCOS = Argument(("--moment-cos",), {"action": "store_true", "help": "finger-follower: moments with cos(theta_f) "
                                                                                  "(virtual work)"})

COMMANDS = (
    CommandSpec("valvetrain", "simulate", "simulate a valve train in its periodic steady state",
                (RPM, JSON, OUT, PLOTS, FIGURE_FORMAT, RIG_FILE, LIFT, PRESET, _CLIP, _MCOS), run_simulate),
    CommandSpec("valvetrain", "modes", "linearised natural frequencies with the cam held (seated, open)",
                (RPM, JSON, OUT, PLOTS, FIGURE_FORMAT, RIG_FILE, LIFT, PRESET), run_modes),
    CommandSpec("valvetrain", "jump-speed", "jump and bounce speeds by a speed sweep and bisection",
                (JSON, OUT, PLOTS, FIGURE_FORMAT, RIG_FILE, LIFT, PRESET,
                 Argument(("--rpm-from",), {"type": float, "default": None,
                                            "help": "finger-follower: sweep start [rpm] (default 1000)"}),
                 Argument(("--rpm-to",), {"type": float, "default": None,
                                          "help": "finger-follower: sweep end [rpm] (default 6000)"}),
                 Argument(("--rpm-step",), {"type": float, "default": None,
                                            "help": "finger-follower: sweep step [rpm] (default 250)"}),
                 Argument(("--resolution-rpm",), {"type": float, "default": None,
                                                  "help": "finger-follower: bisection resolution [rpm] (default 1)"})),
                run_jump_speed),
    CommandSpec("valvetrain", "leakdown", "maximum tappet leak-down against camshaft speed",
                (JSON, OUT, PLOTS, FIGURE_FORMAT, RIG_FILE, LIFT, PRESET,
                 Argument(("--rpms",), {"default": None,
                                        "help": f"camshaft speeds [rpm], comma-separated (default "
                                                f"{DEFAULT_LEAKDOWN_RPMS})"})),
                run_leakdown),
    CommandSpec("valvetrain", "synth", "write a synthetic recording of a valve-train test",
                (RPM, JSON, OUT, RIG_FILE, LIFT, PRESET, REVOLUTIONS,
                 Argument(("--sampling",), {"choices": ["angle", "time"], "default": None,
                                            "help": "finger-follower: angle-domain (encoder-clocked, default) or "
                                                    "time-domain sampling"}),
                 Argument(("--noise-free",), {"action": "store_true", "help": "finger-follower: ideal sensors"}),
                 SEED),
                run_synth),
    CommandSpec("valvetrain", "fit-tappet", "fit the hydraulic tappet's drag (alpha, beta) to tappet motion",
                (Argument(("recordings",), {"nargs": "+", "help": "recordings (HDF5, or CSV with a TOML rig file)"}),
                 JSON, OUT, PLOTS, FIGURE_FORMAT, REPORT, RIG_FILE, LIFT,
                 Argument(("--joint",), {"action": "store_true",
                                         "help": "one (alpha, beta) for all recordings (default: one per speed)"})),
                run_fit_tappet),
    CommandSpec("valvetrain", "fit-lift", "fit the cam lift law to low-speed valve displacement",
                (Argument(("recording",), {"help": "recording at low speed (HDF5, or CSV with a TOML rig file)"}),
                 JSON, OUT, PLOTS, FIGURE_FORMAT, REPORT, RIG_FILE),
                run_fit_lift),
    CommandSpec("valvetrain", "fit-damping", "fit the contact and valve-spring damping ratios to the valve's ringing",
                (Argument(("recording",), {"help": "recording at a speed where the valve rings at closure (HDF5, or "
                                                   "CSV with a TOML rig file)"}),
                 JSON, OUT, PLOTS, FIGURE_FORMAT, REPORT, RIG_FILE, LIFT),
                run_fit_damping),
)

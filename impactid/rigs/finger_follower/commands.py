"""The ``impactid valvetrain ...`` commands of the finger-follower rig (``--rig finger-follower-hla``).

Each command checks its outputs before computing, writes them as one transaction (nothing partial
on an error, Ctrl-C or SIGTERM), prints a short report or, with ``--json``, the JSON document, and
raises :class:`~impactid.errors.ImpactidError` for what the user can fix (the command line prints
it as one ``impactid: error: ...`` line). Units at the edge: rpm, mm, um and deg in text; JSON keys
carry their SI unit in their names.
"""

from __future__ import annotations

import json
import math
import sys
import warnings
from pathlib import Path
from typing import Any

from impactid.errors import RigParameterError, SimulationInputError
from impactid.rigs.base import Argument, CommandSpec

__all__ = ["COMMANDS"]

MODEL_NAME = "finger-follower-hla"

# ---- shared flags, declared exactly as the other valve-train rig declares them -------------------
RPM = Argument(("--rpm",), {"type": float, "help": "camshaft speed [rpm]"})
JSON = Argument(("--json",), {"action": "store_true", "help": "print the result as JSON"})
OUT = Argument(("--out",), {"help": "write the JSON result to this file"})
PLOTS = Argument(("--plots",), {"help": "write figures into this folder"})
RIG_FILE = Argument(("--rig-file",), {"help": "TOML rig file (default: the rig's paper preset)"})
# ---- this rig's own flags ----------------------------------------------------------------------
LIFT = Argument(("--lift",), {"help": "cam lift file (CSV gamma_rad,lift_m or TOML [lift]); default the rig's "
                                      "cycloidal law or the rig file's [lift] table"})
PRESET = Argument(("--preset",), {"choices": ["kim1990", "kim1990-table2"], "default": None,
                                  "help": "paper preset when no rig file is given (default kim1990)"})


def _positive(name: str, value) -> float:
    if value is None:
        raise SimulationInputError(f"argument {name}: required")
    value = float(value)
    if not (math.isfinite(value) and value > 0.0):
        raise SimulationInputError(f"argument {name}: must be positive, got {value!r}")
    return value


def _rig_and_lift(args, default_rig=None):
    """The rig (``--rig-file``, ``--preset`` or ``default_rig``, else the paper preset) and the lift law."""
    from impactid.rigs.finger_follower.cam import read_lift
    from impactid.rigs.finger_follower.parameters import KIM1990, KIM1990_TABLE2

    lift = None
    rig_file = getattr(args, "rig_file", None)
    if rig_file:
        from impactid.rigs._toml import read_toml
        from impactid.rigs.registry import load_rig_toml

        rig, _ = load_rig_toml(rig_file)
        if rig.model != MODEL_NAME:
            raise RigParameterError(f"{rig_file}: a {rig.model!r} rig, expected {MODEL_NAME!r}")
        if isinstance(read_toml(rig_file).get("lift"), dict):
            lift = read_lift(rig_file)
    elif getattr(args, "preset", None) == "kim1990-table2":
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


def _json_text(data: dict) -> str:
    from impactid.results import json_ready

    return json.dumps(json_ready(data), indent=2, allow_nan=False) + "\n"


def _deliver(args, data: dict, inputs, figures=()) -> None:
    """``--out`` JSON and ``--plots`` figures in one transaction; ``--json`` to stdout."""
    from impactid._files import StagedFiles
    from impactid.rigs.finger_follower import figures as F

    if args.plots and figures:
        data["plots"] = [str(Path(args.plots) / name) for name, _ in figures]
    with StagedFiles(protect=inputs) as staged:
        if args.out:
            staged.write_text(args.out, _json_text(data))
        if args.plots:
            for name, make in figures:
                F.save(make(), Path(args.plots) / name, staged)
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

    rpm = _positive("--rpm", args.rpm)
    inputs = _inputs(args)
    _check(args, inputs)
    rig, lift = _rig_and_lift(args)
    train = prepare(rig, lift, clip_tension=bool(getattr(args, "clip_tension", False)),
                    moment_cos=bool(getattr(args, "moment_cos", False)))
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

    inputs = _inputs(args)
    _check(args, inputs)
    rig, lift = _rig_and_lift(args)
    speed_hz = _positive("--rpm", args.rpm) / 60.0 if args.rpm is not None else None
    train = prepare(rig, lift)
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

    inputs = _inputs(args)
    _check(args, inputs)
    lo = _positive("--rpm-from", args.rpm_from)
    hi = _positive("--rpm-to", args.rpm_to)
    step = _positive("--rpm-step", args.rpm_step)
    res = _positive("--resolution-rpm", args.resolution_rpm)
    if not lo < hi:
        raise SimulationInputError(f"argument --rpm-to: must exceed --rpm-from ({lo:g} rpm), got {hi:g}")
    if (hi - lo) / step > 400:
        raise SimulationInputError(f"argument --rpm-step: {step:g} rpm gives more than 400 sweep speeds")
    rig, lift = _rig_and_lift(args)
    speeds = critical_speeds(prepare(rig, lift), rpm_from=lo, rpm_to=hi, step_rpm=step, resolution_rpm=res)
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
    """``impactid valvetrain leakdown``: maximum tappet leak-down against camshaft speed (Fig. 8)."""
    from impactid.rigs.finger_follower import figures as F
    from impactid.rigs.finger_follower.simulate import leakdown_curve, prepare

    inputs = _inputs(args)
    _check(args, inputs)
    try:
        rpms = [float(x) for x in str(args.rpms).split(",") if x.strip()]
    except ValueError:
        raise SimulationInputError(f"argument --rpms: a comma-separated list of speeds, got {args.rpms!r}") from None
    if not rpms or len(rpms) > 200:
        raise SimulationInputError("argument --rpms: give 1 to 200 speeds")
    for r in rpms:
        _positive("--rpms", r)
    rig, lift = _rig_and_lift(args)
    frame = leakdown_curve(prepare(rig, lift), rpms)
    data = {"rig": MODEL_NAME, "leakdown": frame.to_dict(orient="records")}
    _deliver(args, data, inputs, [("leakdown.png", lambda: F.plot_leakdown(frame))])
    if not args.json:
        for row in frame.itertuples():
            print(f"{row.rpm:8.6g} rpm: max leak-down {1e6 * row.max_tappet_leakdown_m:7.3f} um")
    return 0


# ============================================================================================
# synth
# ============================================================================================


def run_synth(args, model) -> int:
    """``impactid valvetrain synth --rig finger-follower-hla --rpm N --out REC.h5``."""
    from impactid._files import check_output
    from impactid.rigs.finger_follower.synth import Sensors, synth_recording

    rpm = _positive("--rpm", args.rpm)
    if not args.out:
        raise SimulationInputError("argument --out: the recording file to write (.h5, or .csv with its .toml)")
    inputs = _inputs(args)
    check_output(args.out, option="--out", inputs=inputs)
    revolutions = int(args.revolutions)
    if not 1 <= revolutions <= 1000:
        raise SimulationInputError(f"argument --revolutions: 1 to 1000, got {revolutions}")
    rig, lift = _rig_and_lift(args)
    sensors = Sensors.ideal() if args.noise_free else Sensors()
    synth = synth_recording(rig, rpm, revolutions=revolutions, sampling=args.sampling, lift=lift, sensors=sensors,
                            seed=int(args.seed))
    if str(args.out).lower().endswith(".csv"):
        from impactid.io import write_csv

        write_csv(synth.recording, args.out)
    else:
        synth.write(args.out)
    if args.json:
        sys.stdout.write(_json_text({"recording": str(args.out), "rpm": rpm, "revolutions": revolutions,
                                     "sampling": args.sampling, "samples": synth.recording.n_samples}))
    else:
        print(f"wrote {args.out}: {revolutions} revolutions at {rpm:.6g} rpm, {args.sampling}-domain sampling, "
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


def run_fit_tappet(args, model) -> int:
    """``impactid valvetrain fit-tappet REC [REC ...]``: the tappet drag (alpha, beta; c_t, k_t)."""
    from impactid.rigs.finger_follower.cam import read_lift
    from impactid.rigs.finger_follower.identify import fit_tappet_drag

    paths = list(args.recordings)
    inputs = _inputs(args, paths)
    _check(args, inputs)
    recs = _read(paths, args)
    lift = read_lift(args.lift) if getattr(args, "lift", None) else None
    fits = fit_tappet_drag(recs, lift=lift, joint=bool(args.joint))
    fits = fits if isinstance(fits, list) else [fits]
    data = {"rig": MODEL_NAME, "joint": bool(args.joint),
            "fits": [{"recordings": [c["source"] for c in f.details["cycles"]],
                      "rpm": [c["rpm"] for c in f.details["cycles"]], **f.to_dict()} for f in fits]}
    for entry in data["fits"]:
        entry.pop("tables", None)
    figures = [(f"tappet_fit_{k}.png", (lambda f=f: f.plot())) for k, f in enumerate(fits)]
    _deliver(args, data, inputs, figures)
    for f in fits:
        for note in f.notes:
            warnings.warn(note, stacklevel=2)
    if not args.json:
        for f in fits:
            print(f.report())
    return 0


def run_fit_lift(args, model) -> int:
    """``impactid valvetrain fit-lift REC``: cam lift law and nose phase from low-speed valve motion."""
    from impactid.rigs.finger_follower.identify import fit_cam_lift

    inputs = _inputs(args, [args.recording])
    _check(args, inputs)
    rec = _read([args.recording], args)[0]
    fit = fit_cam_lift(rec)
    data = {"rig": MODEL_NAME, "recording": str(args.recording), **fit.to_dict()}
    data.pop("tables", None)
    _deliver(args, data, inputs, [("lift_fit.png", fit.plot)])
    for note in fit.notes:
        warnings.warn(note, stacklevel=2)
    if not args.json:
        print(fit.report())
    return 0


_CLIP = Argument(("--clip-tension",), {"action": "store_true",
                                       "help": "also drop a contact while its force would be tensile"})
_MCOS = Argument(("--moment-cos",), {"action": "store_true", "help": "moments with cos(theta_f) (virtual work)"})

COMMANDS = (
    CommandSpec("valvetrain", "simulate", "simulate a valve train in its periodic steady state",
                (RPM, JSON, OUT, PLOTS, RIG_FILE, LIFT, PRESET, _CLIP, _MCOS), run_simulate),
    CommandSpec("valvetrain", "modes", "linearised natural frequencies with the cam held (seated, open)",
                (RPM, JSON, OUT, PLOTS, RIG_FILE, LIFT, PRESET), run_modes),
    CommandSpec("valvetrain", "jump-speed", "jump and bounce speeds by a speed sweep and bisection",
                (JSON, OUT, PLOTS, RIG_FILE, LIFT, PRESET,
                 Argument(("--rpm-from",), {"type": float, "default": 1000.0, "help": "sweep start [rpm]"}),
                 Argument(("--rpm-to",), {"type": float, "default": 6000.0, "help": "sweep end [rpm]"}),
                 Argument(("--rpm-step",), {"type": float, "default": 250.0, "help": "sweep step [rpm]"}),
                 Argument(("--resolution-rpm",), {"type": float, "default": 1.0,
                                                  "help": "bisection resolution [rpm]"})),
                run_jump_speed),
    CommandSpec("valvetrain", "leakdown", "maximum tappet leak-down against camshaft speed",
                (JSON, OUT, PLOTS, RIG_FILE, LIFT, PRESET,
                 Argument(("--rpms",), {"default": "600,800,900,1200,1600,2000,2450,3000",
                                        "help": "camshaft speeds [rpm], comma-separated"})),
                run_leakdown),
    CommandSpec("valvetrain", "synth", "write a synthetic recording of a valve-train test",
                (RPM, JSON, OUT, RIG_FILE, LIFT, PRESET,
                 Argument(("--revolutions",), {"type": int, "default": 16, "help": "revolutions recorded"}),
                 Argument(("--sampling",), {"choices": ["angle", "time"], "default": "angle",
                                            "help": "angle-domain (encoder-clocked) or time-domain sampling"}),
                 Argument(("--noise-free",), {"action": "store_true", "help": "ideal sensors"}),
                 Argument(("--seed",), {"type": int, "default": 0, "help": "noise seed"})),
                run_synth),
    CommandSpec("valvetrain", "fit-tappet", "fit the hydraulic tappet's drag (alpha, beta) to tappet motion",
                (Argument(("recordings",), {"nargs": "+", "help": "recordings (HDF5, or CSV with a TOML rig file)"}),
                 JSON, OUT, PLOTS, RIG_FILE, LIFT,
                 Argument(("--joint",), {"action": "store_true",
                                         "help": "one (alpha, beta) for all recordings (default: one per speed)"})),
                run_fit_tappet),
    CommandSpec("valvetrain", "fit-lift", "fit the cam lift law to low-speed valve displacement",
                (Argument(("recording",), {"help": "recording at low speed (HDF5, or CSV with a TOML rig file)"}),
                 JSON, OUT, PLOTS, RIG_FILE),
                run_fit_lift),
)

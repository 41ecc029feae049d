"""Command-line commands this rig contributes: ``impactid valvetrain simulate | jump-speed | fit-surge | synth``.

The commands are shared with other valve-train rigs (``--rig MODEL`` chooses, the CLI adds it); the
arguments common to several rigs (``--rig-file``, ``--rpm``, ``--out``, ``--json``, ``--plots``) keep
the project's meanings, and this rig's own choices (``--level``, ``--preset``, ...) are validated
here rather than by argparse ``choices`` so that another rig's definition of the same flag cannot
reject them. Units on the command line are SI except camshaft speeds (rpm); reports print um, deg
and rpm.

Every camshaft speed a command takes (``--rpm``, ``--speeds``, ``--rpm-range``, a rig file's
``[operating] cam_speed_hz``, a recording's operating point) must lie in the range the model
describes, :attr:`CycloidalEHLRig.speed_range <impactid.rigs.cycloidal.parameters.CycloidalEHLRig.speed_range>`
(1/300 to 3 times the rig's rigid-follower jump speed; the decision is documented in
:class:`impactid.rigs.valvespring.CamSpeedRange`). An option of the other valve train given to
one of this rig's commands is refused, not ignored.
"""

from __future__ import annotations

import argparse
import math
import warnings
from pathlib import Path

from impactid.commandline import (
    FIGURE_FORMAT,
    MAX_SYNTH_SAMPLES,
    REPORT,
    UsageError,
    check_report,
    figure_format,
    refuse_foreign_options,
    say_report,
    write_report,
)
from impactid.commandline import integer_in as _count
from impactid.commandline import nonnegative as _nonnegative
from impactid.commandline import number as _number
from impactid.commandline import positive as _positive
from impactid.errors import SimulationError
from impactid.rigs.base import Argument, CommandSpec

__all__ = ["COMMANDS"]


_UsageError = UsageError

#: Finest jump-speed tolerance ``--xtol`` [rpm]: far below any physical meaning, and a bisection
#: stops after about 20 halvings instead of looping at the floating-point resolution.
MIN_XTOL_RPM = 1e-4
#: Most scan speeds of ``jump-speed`` (each one a steady cycle).
MAX_SCAN_SPEEDS = 400
#: Most film steps per revolution a command computes (each sampled 20 times for the load): a rig
#: file may hold up to 1e7, which would need gigabytes.
MAX_STEPS_PER_REV = 100_000
#: Fewest samples per camshaft revolution of a synthetic recording (10 deg: the cam event of
#: 180 deg must be resolved).
MIN_SAMPLES_PER_REV = 36
#: Most revolutions of a synthetic recording.
MAX_SYNTH_REVOLUTIONS = 10_000


def _fraction(text: str) -> float:
    value = _number(text)
    if not 0.0 < value < 1.0:
        raise argparse.ArgumentTypeError(f"must lie in (0, 1), got {text!r}")
    return value


def _speed_list(text: str) -> list[float]:
    values = [_positive(x) for x in text.split(",") if x.strip()]
    if not values or len(values) > 20:
        raise argparse.ArgumentTypeError(f"expected 1 to 20 speeds separated by commas, got {text!r}")
    return values


def _range(text: str) -> tuple[float, float]:
    parts = text.split(",")
    if len(parts) != 2:
        raise argparse.ArgumentTypeError(f"expected LOW,HIGH in rpm, got {text!r}")
    lo, hi = _positive(parts[0]), _positive(parts[1])
    if not lo < hi:
        raise argparse.ArgumentTypeError(f"need LOW < HIGH, got {text!r}")
    return lo, hi


# ---- shared plumbing ----------------------------------------------------------------------------


def _rig(args):
    """The rig (``--rig-file`` or ``--preset``) and the rig file's ``[operating]`` table."""
    from impactid.rigs.cycloidal.parameters import MODEL_NAME, PRESETS, CycloidalEHLRig
    from impactid.rigs.registry import load_rig_toml

    rig_file = getattr(args, "rig_file", None)
    preset = getattr(args, "preset", None)
    if rig_file:
        if preset:
            raise _UsageError("give either --rig-file or --preset, not both")
        rig, operating = load_rig_toml(rig_file)
        if not isinstance(rig, CycloidalEHLRig):
            raise _UsageError(f"argument --rig-file: {rig_file} describes a {rig.model!r} rig, not {MODEL_NAME!r}")
        return rig, operating
    name = preset or next(iter(PRESETS))
    if name not in PRESETS:
        raise _UsageError(f"argument --preset: unknown preset {name!r} (choose from {', '.join(PRESETS)})")
    return PRESETS[name], {}


def _rpm(args, rig, operating) -> float:
    """``--rpm``, else the rig file's ``[operating] cam_speed_hz``, inside the rig's speed range."""
    if getattr(args, "rpm", None) is not None:
        return rig.speed_range.check(args.rpm, "argument --rpm", _UsageError)
    if "cam_speed_hz" in operating:
        hz = operating["cam_speed_hz"]
        return rig.speed_range.check(60.0 * float(hz), f"{args.rig_file}: [operating] cam_speed_hz = {hz!r} Hz",
                                     _UsageError)
    raise _UsageError("no camshaft speed: give --rpm N (or a rig file with [operating] cam_speed_hz)")


def _steps_per_rev(args, rig) -> int | None:
    """``--steps-per-rev``, or None for the rig's ``steps_per_rev`` (refused above :data:`MAX_STEPS_PER_REV`)."""
    steps = getattr(args, "steps_per_rev", None)
    if steps is None and rig.film_steps > MAX_STEPS_PER_REV:
        raise _UsageError(f"{args.rig_file}: rig parameter 'steps_per_rev' = {rig.film_steps} is more film steps "
                          f"per revolution than a command computes (at most {MAX_STEPS_PER_REV}); give "
                          "--steps-per-rev N")
    return steps


def _own_options(args, model) -> None:
    """Options of the other valve train's version of this command are refused."""
    refuse_foreign_options(args, model)


def _level(args, allowed, default="A") -> str:
    level = getattr(args, "level", None) or default
    if level not in allowed:
        raise _UsageError(f"argument --level: {level!r} is not one of {', '.join(allowed)} for this rig")
    return level


def _inputs(args, recordings=()) -> list:
    files = list(recordings)
    if getattr(args, "rig_file", None):
        files.append(args.rig_file)
    return files


def _check(args, inputs, out_is_dir=False) -> None:
    from impactid._files import check_output

    if getattr(args, "out", None):
        check_output(args.out, option="--out", inputs=inputs, directory=out_is_dir)
    if getattr(args, "plots", None):
        check_output(args.plots, option="--plots", inputs=inputs, directory=True)
    check_report(args, inputs, others={"--out": getattr(args, "out", None)})


def _write(args, data: dict, inputs, figures=None, printed: dict | None = None) -> None:
    """Figures into ``--plots`` and the JSON to ``--out``, staged together (all or nothing), so the JSON's
    ``plots`` lists the figures written (the key only with ``--plots``); ``--json`` prints ``printed``
    (default: the same data)."""
    from impactid._files import StagedFiles
    from impactid.commandline import json_text as _json_text
    from impactid.commandline import print_json as _print_json

    plots = bool(getattr(args, "plots", None)) and figures is not None
    if plots or getattr(args, "out", None):
        with StagedFiles(protect=inputs) as staged:
            if plots:
                data["plots"] = [str(p) for p in figures(staged)]
            if getattr(args, "out", None):
                staged.write_text(args.out, _json_text(data))
    if getattr(args, "json", False):
        shown = data if printed is None else printed
        if "plots" in data and printed is not None:
            shown["plots"] = data["plots"]
        _print_json(shown)


# ---- commands -----------------------------------------------------------------------------------


def run_simulate(args, model) -> int:
    """``impactid valvetrain simulate --rig cycloidal-flat-follower-ehl``: the steady cycle at ``--rpm``
    (and at ``--speeds`` for the figures; one of those that cannot be simulated is left out with a
    warning and exit status 1, the main result is kept)."""
    from impactid.rigs.cycloidal.contact import WS_MODES
    from impactid.rigs.cycloidal.figures import write_cycle_figures
    from impactid.rigs.cycloidal.simulate import LEVELS, cycle

    _own_options(args, model)
    rig, operating = _rig(args)
    rpm = _rpm(args, rig, operating)
    level = _level(args, LEVELS)
    ws_mode = getattr(args, "ws_mode", None)
    if ws_mode is not None and ws_mode not in WS_MODES:
        raise _UsageError(f"argument --ws-mode: {ws_mode!r} is not one of {', '.join(WS_MODES)}")
    speeds = [rig.speed_range.check(r, "argument --speeds", _UsageError) for r in getattr(args, "speeds", None) or []]
    steps = _steps_per_rev(args, rig)
    inputs = _inputs(args)
    _check(args, inputs)
    result = cycle(rig, rpm, level, steps_per_rev=steps, ws_mode=ws_mode,
                   h_floor=getattr(args, "film_floor", None) or 0.0)
    extra, failed = [], []
    for r in speeds:
        if r != rpm:
            try:
                extra.append(cycle(rig, r, level, steps_per_rev=steps, ws_mode=ws_mode,
                                   h_floor=getattr(args, "film_floor", None) or 0.0))
            except SimulationError as exc:  # a further speed does not take the main result with it
                failed.append({"rpm": r, "reason": str(exc)})
    data = result.summary()
    data["rig_parameters"] = rig.to_dict()
    data["rigid_jump_speed_rpm"] = rig.rigid_jump_rpm
    if extra:
        data["other_speeds"] = [{k: r.summary()[k] for k in ("rpm", "nose_film_thickness_m", "max_film_thickness_m",
                                                              "min_film_thickness_m", "min_contact_load_N",
                                                              "max_contact_load_N")} for r in extra]
    if failed:
        data["failed_speeds"] = failed
    if getattr(args, "out", None):
        data["per_step"] = {k: v.tolist() for k, v in result.to_pandas().items()}
    figures = None
    if getattr(args, "plots", None):
        from impactid.commandline import figure_format

        def figures(staged):
            return write_cycle_figures(result, args.plots, staged, extra, fmt=figure_format(args))
    printed = {k: v for k, v in data.items() if k != "per_step"}
    _write(args, data, inputs, figures, printed)
    for f in failed:
        warnings.warn(f"argument --speeds: {f['rpm']:g} rpm left out (the other speeds were computed): "
                      f"{f['reason']}", stacklevel=2)
    if not getattr(args, "json", False):
        print(result.report())
        if getattr(args, "out", None):
            print(f"  result written to {args.out}")
        if getattr(args, "plots", None):
            print(f"  figures written to {args.plots}")
    return 1 if failed else 0


def run_jump_speed(args, model) -> int:
    from impactid.rigs.cycloidal.figures import jump_figure
    from impactid.rigs.cycloidal.simulate import jump_speed, level_a_min_load

    _own_options(args, model)
    rig, _ = _rig(args)
    level = _level(args, ("A", "B", "rigid"))
    rpm_range = getattr(args, "rpm_range", None) or (2000.0, 4500.0)
    for end in rpm_range:
        rig.speed_range.check(end, "argument --rpm-range", _UsageError)
    scan_step = getattr(args, "scan_step", None) or 50.0
    width = rpm_range[1] - rpm_range[0]
    if scan_step > width or width / scan_step > MAX_SCAN_SPEEDS:
        raise _UsageError(f"argument --scan-step: {scan_step:g} rpm gives {width / scan_step:.3g} steps over the "
                          f"{width:g} rpm of --rpm-range; give 1 to {MAX_SCAN_SPEEDS}")
    xtol = getattr(args, "xtol", None)
    if xtol is not None and xtol < MIN_XTOL_RPM:
        raise _UsageError(f"argument --xtol: at least {MIN_XTOL_RPM:g} rpm, got {xtol:g}")
    inputs = _inputs(args)
    _check(args, inputs)
    result = jump_speed(rig, level, rpm_range=rpm_range, scan_step=scan_step, xtol=xtol)
    data = result.to_dict()
    data["rigid_jump_speed_rpm"] = rig.rigid_jump_rpm
    data["rig_parameters"] = rig.to_dict()
    figures = None
    if getattr(args, "plots", None):
        import numpy as np

        def figures(staged):
            from impactid.commandline import figure_format
            from impactid.plotting import save_figure, style

            lo, hi = rpm_range
            speeds = np.linspace(lo, hi, 26)
            W = [level_a_min_load(rig, r)[0] for r in speeds]
            fig = jump_figure(speeds, W, result.rpm, level)
            if level != "A":
                with style():
                    fig.axes[0].set_title(f"Smallest load of model level A; jump speed of level {level} marked")
            return [save_figure(fig, Path(args.plots) / "jump_speed.png", staged, figure_format(args))]

    json_flag = getattr(args, "json", False)
    _write(args, data, inputs, figures)
    if not json_flag:
        if math.isfinite(result.rpm):
            print(f"jump speed (level {level}): {result.rpm:.2f} rpm camshaft, first loss at "
                  f"{math.degrees(result.angle):.2f} deg cam angle")
        else:
            print(f"jump speed (level {level}): not found")
        print(f"  criterion: {result.criterion}")
        print(f"  rigid follower without surge: {data['rigid_jump_speed_rpm']:.2f} rpm")
        for note in result.notes:
            print(f"  note: {note}")
    return 0


def run_fit_surge(args, model) -> int:
    from impactid._files import check_distinct_inputs
    from impactid.io import read_recording
    from impactid.rigs.cycloidal.identify import fit_surge

    _own_options(args, model)
    recordings = list(getattr(args, "recordings", None) or [])
    if not recordings:
        raise _UsageError("give one or more recordings (HDF5, or CSV with its rig file)")
    channel = getattr(args, "channel", None)
    if channel is not None and channel not in ("contact_load", "valve_displacement"):
        raise _UsageError(f"argument --channel: {channel!r} is not one of contact_load, valve_displacement")
    check_distinct_inputs(recordings)
    inputs = _inputs(args, recordings)
    _check(args, inputs)
    rig_file = getattr(args, "rig_file", None)
    recs = [read_recording(path, rig=rig_file) for path in recordings]
    fit = fit_surge(recs, channel=channel, free_k0=bool(getattr(args, "free_k0", False)),
                    confidence=getattr(args, "confidence", None) or 0.95)
    # the FitResult document (docs/formats.md) and the recordings read; --plots adds "plots"
    data = {**fit.to_dict(), "recordings_read": [str(p) for p in recordings]}
    def figures(staged):
        from impactid.plotting import save_figure

        return [save_figure(fit.plot(), Path(args.plots) / "surge_fit.png", staged, figure_format(args))]

    if getattr(args, "plots", None):
        from impactid.plotting import figure_name

        data["plots"] = [figure_name(Path(args.plots) / "surge_fit.png", figure_format(args))]
    json_flag = getattr(args, "json", False)
    _write(args, data, inputs, figures if getattr(args, "plots", None) else None)
    write_report(args, data, inputs, (["surge_fit.png"], figures))
    if not json_flag:
        print(fit.report())
        say_report(args)
    return 0


def run_synth(args, model) -> int:
    from impactid.rigs.cycloidal.synth import synth_recording

    _own_options(args, model)
    rig, operating = _rig(args)
    rpm = _rpm(args, rig, operating)
    level = _level(args, ("A", "B"))
    if not getattr(args, "out", None):
        raise _UsageError("argument --out: give the HDF5 file to write")
    revolutions = getattr(args, "revolutions", None) or 4.0
    if not revolutions <= MAX_SYNTH_REVOLUTIONS:
        raise _UsageError(f"argument --revolutions: at most {MAX_SYNTH_REVOLUTIONS}, got {revolutions:g}")
    sample_rate = getattr(args, "sample_rate", None) or 50_000.0
    per_rev = sample_rate * 60.0 / rpm
    if per_rev < MIN_SAMPLES_PER_REV:
        raise _UsageError(f"argument --sample-rate: {sample_rate:g} Hz gives {per_rev:.3g} samples per camshaft "
                          f"revolution at {rpm:g} rpm; at least {MIN_SAMPLES_PER_REV} are needed to resolve the cam")
    if revolutions * per_rev > MAX_SYNTH_SAMPLES:
        raise _UsageError(f"arguments --revolutions/--sample-rate: {revolutions * per_rev:.3g} samples to generate; "
                          f"at most {MAX_SYNTH_SAMPLES:.3g}")
    if revolutions * per_rev < 2:
        raise _UsageError(f"argument --revolutions: {revolutions:g} revolutions at {sample_rate:g} Hz is fewer than "
                          "2 samples")
    inputs = _inputs(args)
    _check(args, inputs)
    noise = {}
    if getattr(args, "noise_load", None):
        noise["contact_load"] = args.noise_load
    if getattr(args, "noise_displacement", None):
        noise["valve_displacement"] = args.noise_displacement
    synthetic = synth_recording(rig, rpm, level=level, revolutions=revolutions, sample_rate_hz=sample_rate,
                                noise=noise, seed=getattr(args, "seed", None) or 0)
    synthetic.write(args.out)
    rec = synthetic.recording
    data = {"out": str(args.out), "level": level, "rpm": rpm, "samples": rec.n_samples,
            "sample_rate_hz": rec.sample_rate_hz, "channels": list(rec.channels), "noise": noise}
    if getattr(args, "json", False):
        from impactid.commandline import print_json as _print_json

        _print_json(data)
    else:
        print(f"wrote {args.out}: {rec.n_samples} samples at {rec.sample_rate_hz:g} Hz, level {level}, {rpm:g} rpm, "
              f"channels {', '.join(rec.channels)}")
    return 0


# ---- argument specs -------------------------------------------------------------------------------

_RIG_FILE = Argument(("--rig-file",), {"metavar": "RIG.toml", "default": None,
                                       "help": "rig file ([rig] with model and parameters, optional [operating])"})
_PRESET = Argument(("--preset",), {"default": None, "metavar": "NAME",
                                   "help": "named parameter set (cycloidal: kushwaha2000 (default), "
                                           "kushwaha2000-zeros-exact, kushwaha2000-thick-oil)"})
#: shared with the other valve-train rigs, declared exactly alike (type float; checked in :func:`_rpm`)
_RPM = Argument(("--rpm",), {"type": float, "default": None, "help": "camshaft speed [rpm]"})
_JSON = Argument(("--json",), {"action": "store_true", "help": "print the result as JSON"})
_OUT_JSON = Argument(("--out",), {"metavar": "RESULT.json", "default": None,
                                  "help": "write the result as JSON (atomically)"})
_PLOTS = Argument(("--plots",), {"metavar": "DIR", "default": None, "help": "write figures into DIR"})
#: shared with the finger follower's synth, declared exactly alike (each rig checks its own limits)
REVOLUTIONS = Argument(("--revolutions",), {"type": _positive, "default": None,
                                            "help": "revolutions recorded (cycloidal: default 4, need not be whole; "
                                                    "finger-follower: whole, default 16)"})
SEED = Argument(("--seed",), {"type": _count(0, 2**31 - 1), "default": None, "help": "random seed (default 0)"})
_LEVEL = Argument(("--level",), {"default": None, "metavar": "LEVEL",
                                 "help": "cycloidal: A (adherent, the paper's; default), B (valve released, seat), "
                                         "kinematic or rigid (simulate), rigid (jump-speed)"})

COMMANDS = (
    CommandSpec("valvetrain", "simulate", "steady cycle: film, velocities, load, Hertz pressure", (
        _RIG_FILE, _PRESET, _RPM, _LEVEL,
        Argument(("--steps-per-rev",), {"type": _count(8, MAX_STEPS_PER_REV), "default": None,
                                        "help": "cycloidal: film time steps per revolution (default: rig's, 500)"}),
        Argument(("--ws-mode",), {"default": None, "metavar": "MODE",
                                  "help": "cycloidal: squeeze ratio clip (default), none or symmetric"}),
        Argument(("--film-floor",), {"type": _nonnegative, "default": None, "metavar": "M",
                                     "help": "cycloidal: film floor [m] (default none)"}),
        Argument(("--speeds",), {"type": _speed_list, "default": None, "metavar": "RPM,RPM",
                                 "help": "cycloidal: further speeds drawn in the figures"}),
        _OUT_JSON, _PLOTS, FIGURE_FORMAT, _JSON), run_simulate),
    CommandSpec("valvetrain", "jump-speed", "lowest camshaft speed at which the follower loses the cam", (
        _RIG_FILE, _PRESET, _LEVEL,
        Argument(("--rpm-range",), {"type": _range, "default": None, "metavar": "LOW,HIGH",
                                    "help": "cycloidal: speeds searched [rpm] (default 2000,4500)"}),
        Argument(("--scan-step",), {"type": _positive, "default": None,
                                    "help": "cycloidal: scan step [rpm] (default 50)"}),
        Argument(("--xtol",), {"type": _positive, "default": None,
                               "help": "cycloidal: tolerance [rpm] (default 0.01 level A, 0.5 level B)"}),
        _OUT_JSON, _PLOTS, FIGURE_FORMAT, _JSON), run_jump_speed),
    CommandSpec("valvetrain", "fit-surge", "fit surge frequency and damping, preload and moving mass to recordings", (
        Argument(("recordings",), {"metavar": "REC", "nargs": "*", "help": "HDF5 or CSV recordings"}),
        _RIG_FILE,
        Argument(("--channel",), {"default": None, "metavar": "NAME",
                                  "help": "contact_load (level-A model) or valve_displacement (level-B model); "
                                          "default: the first the recording has"}),
        Argument(("--free-k0",), {"action": "store_true", "help": "also fit the spring rate k0"}),
        Argument(("--confidence",), {"type": _fraction, "default": None,
                                     "help": "coverage of the intervals (default 0.95)"}),
        _OUT_JSON, _PLOTS, FIGURE_FORMAT, REPORT, _JSON), run_fit_surge),
    CommandSpec("valvetrain", "synth", "write a synthetic recording with known parameters", (
        _RIG_FILE, _PRESET, _RPM, _LEVEL,
        REVOLUTIONS,
        Argument(("--sample-rate",), {"type": _positive, "default": None,
                                      "help": "sampling rate [Hz] (default 50 kHz)"}),
        Argument(("--noise-load",), {"type": _nonnegative, "default": None, "help": "contact-load noise SD [N]"}),
        Argument(("--noise-displacement",), {"type": _nonnegative, "default": None,
                                             "help": "valve-displacement noise SD [m]"}),
        SEED,
        Argument(("--out",), {"metavar": "FILE.h5", "default": None, "help": "output HDF5 recording"}),
        _JSON), run_synth),
)

"""Command-line commands this rig contributes: ``impactid valvetrain simulate | jump-speed | fit-surge | synth``.

The commands are shared with other valve-train rigs (``--rig MODEL`` chooses, the CLI adds it); the
arguments common to several rigs (``--rig-file``, ``--rpm``, ``--out``, ``--json``, ``--plots``) keep
the project's meanings, and this rig's own choices (``--level``, ``--preset``, ...) are validated
here rather than by argparse ``choices`` so that another rig's definition of the same flag cannot
reject them. Units on the command line are SI except camshaft speeds (rpm); reports print um, deg
and rpm.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from impactid.commandline import UsageError
from impactid.commandline import integer_in as _count
from impactid.commandline import nonnegative as _nonnegative
from impactid.commandline import number as _number
from impactid.commandline import positive as _positive
from impactid.rigs.base import Argument, CommandSpec

__all__ = ["COMMANDS"]


_UsageError = UsageError


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


def _rpm(args, operating) -> float:
    if getattr(args, "rpm", None) is not None:
        rpm = float(args.rpm)
        if not (math.isfinite(rpm) and rpm > 0.0):
            raise _UsageError(f"argument --rpm: must be a positive camshaft speed, got {args.rpm!r}")
        return rpm
    if "cam_speed_hz" in operating:
        return 60.0 * float(operating["cam_speed_hz"])
    raise _UsageError("no camshaft speed: give --rpm N (or a rig file with [operating] cam_speed_hz)")


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


def _write(args, data: dict, inputs, figures=None, printed: dict | None = None) -> None:
    """JSON to ``--out`` (committed first), then figures into ``--plots``; ``--json`` prints ``printed``
    (default: the same data)."""
    from impactid._files import StagedFiles
    from impactid.commandline import json_text as _json_text
    from impactid.commandline import print_json as _print_json

    if getattr(args, "plots", None) and figures is not None:
        data["plots"] = []
    if getattr(args, "out", None):
        with StagedFiles(protect=inputs) as staged:
            staged.write_text(args.out, _json_text(data))
    if getattr(args, "plots", None) and figures is not None:
        with StagedFiles(protect=inputs) as staged:
            data["plots"] = [str(p) for p in figures(staged)]
    if getattr(args, "json", False):
        shown = data if printed is None else printed
        if "plots" in data and printed is not None:
            shown["plots"] = data["plots"]
        _print_json(shown)


# ---- commands -----------------------------------------------------------------------------------


def run_simulate(args, model) -> int:
    from impactid.rigs.cycloidal.cam import rigid_jump_speed
    from impactid.rigs.cycloidal.contact import WS_MODES
    from impactid.rigs.cycloidal.figures import write_cycle_figures
    from impactid.rigs.cycloidal.simulate import LEVELS, cycle

    rig, operating = _rig(args)
    rpm = _rpm(args, operating)
    level = _level(args, LEVELS)
    ws_mode = getattr(args, "ws_mode", None)
    if ws_mode is not None and ws_mode not in WS_MODES:
        raise _UsageError(f"argument --ws-mode: {ws_mode!r} is not one of {', '.join(WS_MODES)}")
    inputs = _inputs(args)
    _check(args, inputs)
    result = cycle(rig, rpm, level, steps_per_rev=getattr(args, "steps_per_rev", None), ws_mode=ws_mode,
                   h_floor=getattr(args, "film_floor", None) or 0.0)
    extra = []
    for r in getattr(args, "speeds", None) or []:
        if r != rpm:
            extra.append(cycle(rig, r, level, steps_per_rev=getattr(args, "steps_per_rev", None), ws_mode=ws_mode,
                               h_floor=getattr(args, "film_floor", None) or 0.0))
    data = result.summary()
    data["rig_parameters"] = rig.to_dict()
    data["rigid_jump_speed_rpm"] = rigid_jump_speed(rig.m3, rig.k0, rig.f_p, rig.S, rig.beta)[0] * 60 / (2 * math.pi)
    if extra:
        data["other_speeds"] = [{k: r.summary()[k] for k in ("rpm", "nose_film_thickness_m", "max_film_thickness_m",
                                                              "min_film_thickness_m", "min_contact_load_N",
                                                              "max_contact_load_N")} for r in extra]
    if getattr(args, "out", None):
        data["per_step"] = {k: v.tolist() for k, v in result.to_pandas().items()}
    figures = (lambda staged: write_cycle_figures(result, args.plots, staged, extra)) if getattr(args, "plots",
                                                                                               None) else None
    printed = {k: v for k, v in data.items() if k != "per_step"}
    _write(args, data, inputs, figures, printed)
    if not getattr(args, "json", False):
        print(result.report())
        if getattr(args, "out", None):
            print(f"  result written to {args.out}")
        if getattr(args, "plots", None):
            print(f"  figures written to {args.plots}")
    return 0


def run_jump_speed(args, model) -> int:
    from impactid.rigs.cycloidal.cam import rigid_jump_speed
    from impactid.rigs.cycloidal.figures import jump_figure
    from impactid.rigs.cycloidal.simulate import jump_speed, level_a_min_load

    rig, _ = _rig(args)
    level = _level(args, ("A", "B", "rigid"))
    inputs = _inputs(args)
    _check(args, inputs)
    rpm_range = getattr(args, "rpm_range", None) or (2000.0, 4500.0)
    result = jump_speed(rig, level, rpm_range=rpm_range, scan_step=getattr(args, "scan_step", None) or 50.0,
                        xtol=getattr(args, "xtol", None))
    data = result.to_dict()
    data["rigid_jump_speed_rpm"] = rigid_jump_speed(rig.m3, rig.k0, rig.f_p, rig.S, rig.beta)[0] * 60 / (2 * math.pi)
    data["rig_parameters"] = rig.to_dict()
    figures = None
    if getattr(args, "plots", None):
        import numpy as np

        def figures(staged):
            lo, hi = rpm_range
            speeds = np.linspace(lo, hi, 26)
            W = [level_a_min_load(rig, r)[0] for r in speeds]
            fig = jump_figure(speeds, W, result.rpm, level)
            if level != "A":
                fig.axes[0].set_title(f"Level-A smallest load; jump speed of level {level} marked")
            path = Path(args.plots) / "jump_speed.png"
            return [staged.write_with(path, lambda tmp: fig.savefig(tmp, format="png", dpi=110))]

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
    from impactid.io import read_recording
    from impactid.rigs.cycloidal.identify import fit_surge

    recordings = list(getattr(args, "recordings", None) or [])
    if not recordings:
        raise _UsageError("give one or more recordings (HDF5, or CSV with its rig file)")
    inputs = _inputs(args, recordings)
    _check(args, inputs)
    rig_file = getattr(args, "rig_file", None)
    recs = [read_recording(path, rig=rig_file) for path in recordings]
    channel = getattr(args, "channel", None)
    if channel is not None and channel not in ("contact_load", "valve_displacement"):
        raise _UsageError(f"argument --channel: {channel!r} is not one of contact_load, valve_displacement")
    fit = fit_surge(recs, channel=channel, free_k0=bool(getattr(args, "free_k0", False)),
                    confidence=getattr(args, "confidence", None) or 0.95)
    data = fit.to_dict()
    data["values"] = {name: p.value for name, p in fit.params.items()}
    figures = None
    if getattr(args, "plots", None):
        def figures(staged):
            fig = fit.plot()
            path = Path(args.plots) / "surge_fit.png"
            return [staged.write_with(path, lambda tmp: fig.savefig(tmp, format="png", dpi=110))]

    json_flag = getattr(args, "json", False)
    _write(args, data, inputs, figures)
    if not json_flag:
        print(fit.report())
    return 0


def run_synth(args, model) -> int:
    from impactid.rigs.cycloidal.synth import synth_recording

    rig, operating = _rig(args)
    rpm = _rpm(args, operating)
    level = _level(args, ("A", "B"))
    if not getattr(args, "out", None):
        raise _UsageError("argument --out: give the HDF5 file to write")
    inputs = _inputs(args)
    _check(args, inputs)
    noise = {}
    if getattr(args, "noise_load", None):
        noise["contact_load"] = args.noise_load
    if getattr(args, "noise_displacement", None):
        noise["valve_displacement"] = args.noise_displacement
    synthetic = synth_recording(rig, rpm, level=level, revolutions=getattr(args, "revolutions", None) or 4.0,
                                sample_rate_hz=getattr(args, "sample_rate", None) or 50_000.0, noise=noise,
                                seed=getattr(args, "seed", None) or 0)
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
_PLOTS = Argument(("--plots",), {"metavar": "DIR", "default": None, "help": "write figures (PNG) into DIR"})
_LEVEL = Argument(("--level",), {"default": None, "metavar": "LEVEL",
                                 "help": "cycloidal: A (adherent, the paper's; default), B (valve released, seat), "
                                         "kinematic or rigid (simulate), rigid (jump-speed)"})

COMMANDS = (
    CommandSpec("valvetrain", "simulate", "steady cycle: film, velocities, load, Hertz pressure", (
        _RIG_FILE, _PRESET, _RPM, _LEVEL,
        Argument(("--steps-per-rev",), {"type": _count(8, 1_000_000), "default": None,
                                        "help": "cycloidal: film time steps per revolution (default: rig's, 500)"}),
        Argument(("--ws-mode",), {"default": None, "metavar": "MODE",
                                  "help": "cycloidal: squeeze ratio clip (default), none or symmetric"}),
        Argument(("--film-floor",), {"type": _nonnegative, "default": None, "metavar": "M",
                                     "help": "cycloidal: film floor [m] (default none)"}),
        Argument(("--speeds",), {"type": _speed_list, "default": None, "metavar": "RPM,RPM",
                                 "help": "cycloidal: further speeds drawn in the figures"}),
        _OUT_JSON, _PLOTS, _JSON), run_simulate),
    CommandSpec("valvetrain", "jump-speed", "lowest camshaft speed at which the follower loses the cam", (
        _RIG_FILE, _PRESET, _LEVEL,
        Argument(("--rpm-range",), {"type": _range, "default": None, "metavar": "LOW,HIGH",
                                    "help": "cycloidal: speeds searched [rpm] (default 2000,4500)"}),
        Argument(("--scan-step",), {"type": _positive, "default": None,
                                    "help": "cycloidal: scan step [rpm] (default 50)"}),
        Argument(("--xtol",), {"type": _positive, "default": None,
                               "help": "cycloidal: tolerance [rpm] (default 0.01 level A, 0.5 level B)"}),
        _OUT_JSON, _PLOTS, _JSON), run_jump_speed),
    CommandSpec("valvetrain", "fit-surge", "fit surge frequency and damping, preload and moving mass to recordings", (
        Argument(("recordings",), {"metavar": "REC", "nargs": "*", "help": "HDF5 or CSV recordings"}),
        _RIG_FILE,
        Argument(("--channel",), {"default": None, "metavar": "NAME",
                                  "help": "contact_load (level-A model) or valve_displacement (level-B model); "
                                          "default: the first the recording has"}),
        Argument(("--free-k0",), {"action": "store_true", "help": "also fit the spring rate k0"}),
        Argument(("--confidence",), {"type": _fraction, "default": None,
                                     "help": "coverage of the intervals (default 0.95)"}),
        _OUT_JSON, _PLOTS, _JSON), run_fit_surge),
    CommandSpec("valvetrain", "synth", "write a synthetic recording with known parameters", (
        _RIG_FILE, _PRESET, _RPM, _LEVEL,
        Argument(("--revolutions",), {"type": _positive, "default": None, "help": "revolutions (default 4)"}),
        Argument(("--sample-rate",), {"type": _positive, "default": None,
                                      "help": "sampling rate [Hz] (default 50 kHz)"}),
        Argument(("--noise-load",), {"type": _nonnegative, "default": None, "help": "contact-load noise SD [N]"}),
        Argument(("--noise-displacement",), {"type": _nonnegative, "default": None,
                                             "help": "valve-displacement noise SD [m]"}),
        Argument(("--seed",), {"type": _count(0, 2**31 - 1), "default": None, "help": "random seed"}),
        Argument(("--out",), {"metavar": "FILE.h5", "default": None, "help": "output HDF5 recording"}),
        _JSON), run_synth),
)

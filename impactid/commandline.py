"""Shared pieces of the ``impactid`` commands: usage errors, argument types, JSON output, and the
plumbing that several rigs' commands use (rig and recording arguments, output checks, delivery).

Every command (``impactid info`` in :mod:`impactid.cli` and those the rigs contribute through
:class:`~impactid.rigs.base.CommandSpec`) parses numbers with these types, so a bad argument ends in
the same one-line ``impactid: error: argument --x: ...`` whichever rig defines it, and writes JSON
with :func:`json_text` (non-finite numbers become ``null`` and are listed under ``warnings``).
Output paths are checked before any computation (:func:`check_outputs`) and written as
transactions (:func:`deliver`: the JSON first, then the figures).
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import math
import shlex
import sys
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path

from impactid._files import StagedFiles, check_distinct_inputs, check_output
from impactid.errors import ImpactidError
from impactid.rigs.base import Argument
from impactid.rigs.registry import DEFAULT_EXAMPLE_MODEL, RIG_MODELS, rig_by_name, rig_model

__all__ = ["CAM_PPR", "FIGURE_FORMAT", "JSON", "MAX_SWEEP_POINTS", "MAX_SYNTH_SAMPLES", "NAMESPACE_KEYS",
           "NOISE_CHANNEL", "PLOTS", "REPORT", "SAMPLE_RATE", "SEED", "SYNTH_DURATION", "SYNTH_OUT", "UsageError",
           "cam_speed", "check_outputs", "check_report", "check_synth_size", "command_inputs", "command_line",
           "deliver", "end_progress_line", "exponent", "figure_format", "fraction", "integer_in", "is_rig_file",
           "json_text", "noise_channels", "nonnegative", "num", "number", "number_up_to", "pair", "positive",
           "print_json", "progress_bar", "recording_arguments", "recording_paths", "recording_rig",
           "refuse_other_rigs_options", "rig_help", "say_report", "say_written", "speed_arguments",
           "stage_progress", "write_report", "write_synthetic"]

#: Largest number of operating points of ``regime-map`` and speeds of ``bifurcation``.
MAX_SWEEP_POINTS = 10_000
#: Largest number of samples ``synth`` generates (times the decimation factor).
MAX_SYNTH_SAMPLES = 200_000_000


class UsageError(ImpactidError, ValueError):
    """A command-line argument that cannot be used (parsed by argparse or checked by a command)."""


def number(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return value


def positive(text: str) -> float:
    value = number(text)
    if value <= 0.0:
        raise argparse.ArgumentTypeError(f"must be positive, got {text!r}")
    return value


def nonnegative(text: str) -> float:
    value = number(text)
    if value < 0.0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {text!r}")
    return value


def number_up_to(high: float, *, zero: bool = True, unit: str = ""):
    """An argparse type: a number in ``[0, high]`` (``(0, high]`` without ``zero``), ``unit`` named in
    the message."""
    low = "[" if zero else "("
    shown = f" {unit}" if unit else ""

    def parse(text: str) -> float:
        value = nonnegative(text) if zero else positive(text)
        if value > high:
            raise argparse.ArgumentTypeError(f"must lie in {low}0, {high:g}]{shown}, got {text!r}")
        return value

    return parse


#: A number in [0, 1].
fraction = number_up_to(1.0)
#: A number in [0, 10] (an exponent, a coefficient).
exponent = number_up_to(10.0)


def integer_in(lo: int, hi: int):
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
        if not lo <= value <= hi:
            raise argparse.ArgumentTypeError(f"must lie in [{lo}, {hi}], got {text!r}")
        return value

    return parse


def pair(text: str) -> tuple[float, float]:
    parts = text.split(",")
    if len(parts) != 2:
        raise argparse.ArgumentTypeError(f"expected A,B (two numbers separated by a comma), got {text!r}")
    return number(parts[0]), number(parts[1])


def json_text(data: dict) -> str:
    """JSON text of a result: non-finite numbers are written as null and listed in ``warnings``."""
    from impactid.results import json_ready  # results loads pandas: only when a result is written

    undetermined: list[str] = []
    clean = json_ready(data, undetermined)
    shown = [p for p in undetermined if not p.startswith("per_impact")]
    if shown and isinstance(clean, dict):
        note = (f"undetermined (not a finite number, written as null): {', '.join(shown[:20])}"
                f"{' ...' if len(shown) > 20 else ''}")
        clean.setdefault("warnings", []).append(note)
    return json.dumps(clean, indent=2, allow_nan=False) + "\n"


def print_json(data) -> None:
    sys.stdout.write(json_text(data))


def num(value, fmt: str = ".5g") -> str:
    """A number for the text report; ``undetermined`` when it is None or not finite."""
    if value is None or not math.isfinite(float(value)):
        return "undetermined"
    return format(float(value), fmt)



# ---- rigs and recordings ------------------------------------------------------------------------

#: How ``--rig`` is resolved (:func:`impactid.rigs.registry.resolve_rig`), for the commands' help.
RIG_RULES = ("a model name (the paper's parameter table), a preset name (SUNDAR2016, ALZATE2007, ...) or a TOML "
             "rig file (its [rig] model picks the rig)")


def rig_help(what: str) -> str:
    """Help text of a ``--rig`` argument: ``what`` it is for, then the resolver's rules."""
    return f"{what}: {RIG_RULES}"


def is_rig_file(spec: str | None) -> bool:
    """Whether a ``--rig`` value names a rig file (not a model or preset name)."""
    return spec is not None and rig_by_name(spec) is None


def recording_rig(args):
    """``--rig`` of a recording command, for :func:`impactid.io.read_recording`: the parameter set a
    model or preset name stands for, the rig file's path (read with the recording: it also supplies
    the operating point), or None to use the recording's own rig."""
    spec = getattr(args, "rig", None)
    if spec is None:
        return None
    named = rig_by_name(spec)
    if named is not None and named[0].name not in RIG_MODELS:
        raise UsageError(f"argument --rig: {spec!r} names the {named[0].name!r} rig, which has no recordings of "
                         f"this kind (give a model or preset name of {', '.join(RIG_MODELS)}, or a rig file)")
    return named[1] if named is not None else spec


def cam_speed(args, operating, required: bool = True) -> float | None:
    """``--cam-speed`` [Hz] or ``--rpm``, else the rig file's ``[operating] cam_speed_hz``, within the
    cam speeds a recording may have (:data:`impactid.io.MIN_CAM_SPEED_HZ` to ``MAX_CAM_SPEED_HZ``)."""
    from impactid.io import MAX_CAM_SPEED_HZ, MIN_CAM_SPEED_HZ  # io loads numba: only when a speed is needed

    given = None
    if getattr(args, "rpm", None) is not None:
        given, option = args.rpm / 60.0, "--rpm"
    elif getattr(args, "cam_speed", None) is not None:
        given, option = args.cam_speed, "--cam-speed"
    elif "cam_speed_hz" in operating:
        given, option = float(operating["cam_speed_hz"]), "the rig file's [operating] cam_speed_hz"
    if given is not None:
        if not MIN_CAM_SPEED_HZ <= given <= MAX_CAM_SPEED_HZ:
            raise UsageError(f"argument {option}: cam speed {given:.6g} Hz ({given * 60:.6g} rpm) is outside "
                             f"{MIN_CAM_SPEED_HZ:g} to {MAX_CAM_SPEED_HZ:g} Hz, the cam speeds impactid reads and "
                             "simulates")
        return given
    if required:
        raise UsageError("no cam speed: give --cam-speed HZ (or --rpm RPM), or a rig file with "
                         "[operating] cam_speed_hz")
    return None


def refuse_foreign_options(args, model, command_key: str = "valvetrain_command", group: str = "valvetrain") -> None:
    """Refuse an option of another rig's version of this command.

    Several rigs contribute a command of the same name (``valvetrain simulate``, ...); argparse
    accepts the union of their options, and the rig ``--rig`` chose would silently ignore another's.
    Any option given that ``model``'s own command does not declare is a usage error naming it.
    """
    name = getattr(args, command_key, None)
    spec = next((c for c in model.command_specs() if c.name == name), None)
    if spec is None:
        return
    own = {"command", command_key, "func", "rig", "resolved_rig", "option_defaults", "argv"}
    for argument in spec.arguments:
        flag = argument.flags[0]
        own.add(flag.lstrip("-").replace("-", "_") if flag.startswith("-") else flag)
    for dest, value in sorted(vars(args).items()):
        if dest not in own and value not in (None, False, [], ()):
            raise UsageError(f"argument --{dest.replace('_', '-')}: not an option of '{group} {name}' for the "
                             f"{model.name!r} rig (it belongs to another rig's version of the command)")


#: What the command line itself sets in a command's namespace (no rig's option).
NAMESPACE_KEYS = frozenset({"command", "func", "rig", "resolved_rig", "option_defaults", "argv"})


def refuse_other_rigs_options(args, own: Iterable[str], *, command: str, model_name: str, note: str = "",
                              hints: Mapping[str, str] | None = None) -> None:
    """Refuse an option of another rig's version of ``command`` (argparse takes the union of the rigs'
    options; this rig would silently ignore it): one whose value differs from its default
    (``args.option_defaults``, set by the command line) and that is not among ``own`` (this rig's
    ``dest`` names, :func:`impactid.rigs.base.argument_dests`). The message ends with ``note``, or with
    ``hints[dest]`` for that option."""
    defaults = getattr(args, "option_defaults", {})
    mine = NAMESPACE_KEYS | set(own)
    for dest, value in sorted(vars(args).items()):
        if dest not in mine and dest in defaults and value != defaults[dest]:
            raise UsageError(f"argument --{dest.replace('_', '-')}: not an option of '{command}' for the "
                             f"{model_name!r} rig (it belongs to another rig's version of the command)"
                             f"{(hints or {}).get(dest, '')}{note}")


def noise_channels(items) -> dict[str, float]:
    """``--noise-channel NAME=FRACTION`` (repeated) as a dict."""
    noise = {}
    for item in items or []:
        name, _, value = item.partition("=")
        try:
            noise[name] = fraction(value)
        except argparse.ArgumentTypeError as exc:
            raise UsageError(f"argument --noise-channel: expected NAME=FRACTION, got {item!r} ({exc})") from None
    return noise


def _sibling_tomls(paths) -> list[Path]:
    return [Path(p).with_suffix(".toml") for p in paths if str(p).lower().endswith((".csv", ".txt"))]


def command_inputs(args, recordings: Sequence, extra: Sequence = ()) -> list:
    """Every input file of a command (for the output checks): recordings, their sibling rig files,
    the ``--rig`` file and ``extra`` files (a ``--profile``, ...)."""
    files = list(recordings) + _sibling_tomls(recordings)
    if is_rig_file(getattr(args, "rig", None)):
        files.append(args.rig)
    return files + [f for f in extra if f]


def check_out_suffix(path: str, suffixes, what: str) -> None:
    """Refuse a ``--out`` whose suffix (any case) is not one of ``suffixes``: the formats a synthetic ``what``
    ("a drop", "a track") is written in, chosen by the file's suffix."""
    if Path(path).suffix.lower() not in suffixes:
        raise UsageError(f"argument --out: {what} is written as {', '.join(suffixes)} (by the file's suffix), "
                         f"got {path!r}")


def check_outputs(args, inputs: Sequence, *, out: str = "out", out_is_dir: bool = False) -> None:
    """Check ``--out``, ``--plots`` and ``--report`` before the computation starts."""
    if getattr(args, out, None) is not None:  # an empty path is refused, not taken for "no output"
        check_output(getattr(args, out), option="--out", inputs=inputs, directory=out_is_dir)
    if getattr(args, "plots", None) is not None:
        check_output(args.plots, option="--plots", inputs=inputs, directory=True)
    check_report(args, inputs, others={"--out": getattr(args, out, None)})


def check_report(args, inputs: Sequence, others: Mapping[str, object] | None = None) -> None:
    """Check ``--report`` (when the command has it and it is given) before the computation starts:
    writable, not an input, not the same file as another output (``others``: option to path)."""
    report = getattr(args, "report", None)
    if report is None:
        return
    check_output(report, option="--report", inputs=inputs)
    for option, path in (others or {}).items():
        if path is not None and Path(path).absolute() == Path(report).absolute():
            raise UsageError(f"argument --report: {report} is also the {option} file; give two different files")


def recording_paths(args, several: bool = False) -> list:
    """The recordings of a command: its positional ``recording`` (or ``recordings``) and ``--example``.

    Raises
    ------
    DuplicateInputError
        when one recording is given twice (by two names, or as two files with the same bytes): a
        joint fit would count its impacts twice (:func:`impactid._files.check_distinct_inputs`).
    UsageError
        when no recording is given, or a recording and ``--example`` to a command that reads one.
    """
    given = list(args.recordings) if several else ([args.recording] if args.recording else [])
    if args.example:
        if given and not several:
            raise UsageError("give either a recording or --example, not both")
        paths = list(rig_model(DEFAULT_EXAMPLE_MODEL).example())
        given = (paths if several else paths[:1]) + given
    elif not given:
        what = "give one or more recordings" if several else "no recording given (pass a file"
        raise UsageError(f"{what}, or --example for the built-in example" + ("" if several else ")"))
    if len(given) > 1:
        check_distinct_inputs(given, what="recording")
    return given


def deliver(args, data: dict, inputs: Sequence,
            figures: tuple[Sequence[str], Callable[[StagedFiles], object]] | None = None) -> None:
    """Write ``data`` as JSON to ``--out`` (committed first), then the figures into ``--plots``, as a
    second transaction, then the HTML page to ``--report`` (:func:`write_report`); ``--json`` prints
    the JSON on stdout.

    ``figures`` is ``(names, write)``: the file names the figures will have (listed in the JSON as
    ``plots``) and ``write(staged)``, which writes them into ``args.plots``. ``--figure-format``
    (:data:`FIGURE_FORMAT`) replaces the names' suffix and holds, while ``write`` runs, as the format
    :func:`impactid.plotting.save_figure` writes in (:func:`impactid.plotting.figure_format`). The
    page embeds the figures written for ``--plots`` (PNG or SVG), or draws them for itself."""
    fmt = figure_format(args)
    report = getattr(args, "report", None)
    if args.plots and figures:
        data["plots"] = [str(Path(args.plots) / _named(name, fmt)) for name in figures[0]]
    if args.out:
        with StagedFiles(protect=inputs) as staged:
            staged.write_text(args.out, json_text(data))
    drawn = None
    if args.plots and figures:
        from impactid.html_report import FigureCapture  # pandas and matplotlib only when figures are drawn
        from impactid.plotting import figure_format as saving_as

        with StagedFiles(protect=inputs) as staged, FigureCapture(staged) as capture, saving_as(fmt):
            figures[1](capture)
        drawn = capture.figures if fmt in (None, "png", "svg") else None
    if report is not None:
        write_report(args, data, inputs, figures, drawn=drawn)
    if args.json:
        print_json(data)


def write_report(args, data: Mapping, inputs: Sequence,
                 figures: tuple[Sequence[str], Callable[[StagedFiles], object]] | None = None, *,
                 drawn: Sequence | None = None) -> None:
    """Write ``--report``: the HTML page of the fit document ``data``
    (:func:`impactid.html_report.fit_page`), atomically; nothing without ``--report``.

    ``figures`` is the command's ``(names, write)`` of ``--plots`` (see :func:`deliver`); ``drawn``
    the figures already drawn (:class:`impactid.html_report.ReportFigure`), else ``write`` draws them
    now, as PNG into a private temporary folder (``args.plots`` and ``args.figure_format`` stand for
    that folder and PNG while it runs: a writer reads them when it runs)."""
    report = getattr(args, "report", None)
    if report is None:
        return
    from impactid.html_report import FigureCapture, fit_page  # pandas (and matplotlib) only when a page is written

    if drawn is None and figures:
        from impactid.plotting import figure_format as saving_as

        saved = {key: vars(args)[key] for key in ("plots", "figure_format") if key in vars(args)}
        with FigureCapture() as capture, saving_as("png"):
            try:
                args.plots, args.figure_format = capture.folder, "png"
                figures[1](capture)
            finally:
                for key in ("plots", "figure_format"):
                    if key in saved:
                        setattr(args, key, saved[key])
                    else:
                        delattr(args, key)
        drawn = capture.figures
    page = fit_page(data, command=command_line(args), inputs=[str(p) for p in inputs if p], figures=drawn or ())
    with StagedFiles(protect=inputs) as staged:
        staged.write_text(report, page)


def command_line(args) -> str:
    """The command line of ``args`` as typed (``impactid`` and the arguments :func:`impactid.cli.main`
    parsed, kept in ``args.argv``), for a report's provenance."""
    argv = getattr(args, "argv", None)
    return "impactid " + shlex.join(argv) if argv is not None else "impactid " + str(getattr(args, "command", ""))


def figure_format(args) -> str | None:
    """``--figure-format`` (``png``, ``svg`` or ``pdf``) of a command, or None when it has none."""
    return getattr(args, "figure_format", None)


def _named(name: str, fmt: str | None) -> str:
    """A figure's file name with the suffix of ``fmt`` (unchanged when None)."""
    return str(Path(name).with_suffix("." + fmt)) if fmt else name


def say_written(args) -> None:
    if args.out:
        print(f"  result written to {args.out}")
    if args.plots:
        print(f"  figures written to {args.plots}")
    say_report(args)


def say_report(args) -> None:
    """The line that says where ``--report`` was written (nothing without it)."""
    if getattr(args, "report", None) is not None:
        print(f"  report written to {args.report}")


def check_synth_size(samples: float) -> None:
    """Refuse a synthetic recording of more than :data:`MAX_SYNTH_SAMPLES` samples (before any work)."""
    if samples > MAX_SYNTH_SAMPLES:
        raise UsageError(f"arguments --duration/--sample-rate/--decimate: {samples:.3g} samples to generate; at most "
                         f"{MAX_SYNTH_SAMPLES:.3g} (split the recording)")


def write_synthetic(synthetic, out) -> int:
    """Write a synthetic recording and its truth to HDF5 ``out`` and print one line about it."""
    from impactid.io import write_hdf5

    path = write_hdf5(synthetic.recording, out, truth=synthetic.truth)
    rec = synthetic.recording
    print(f"{path}: {rec.rig.model}, {rec.n_samples} samples at {rec.sample_rate_hz:g} Hz "
          f"({', '.join(rec.channels)})")
    return 0


#: The progress bars shown now (closed before an error message is printed).
_open_bars: list = []


def progress_bar(total: int, *, enabled: bool | None = None, desc: str = "", unit: str = "task"):
    """A progress bar on stderr: a :class:`tqdm.tqdm` (a plain counter line without tqdm).

    Parameters
    ----------
    total : number of steps.
    enabled : show it (default: when stderr is a terminal).
    desc, unit : label and unit of the bar.

    Returns
    -------
    An object with ``update(n)``, ``set_postfix_str(text)``, ``clear()`` and ``refresh()`` (around a
    line printed while it is shown) and ``close()``, usable as a context manager; it shows nothing
    when disabled.
    """
    if enabled is None:
        enabled = sys.stderr.isatty()
    if enabled and importlib.util.find_spec("tqdm") is not None:
        from tqdm import tqdm

        bar = tqdm(total=total, desc=desc, unit=unit, file=sys.stderr, dynamic_ncols=True, leave=True)
    else:
        bar = _Counter(total, desc, enabled)
    if enabled:
        _open_bars.append(bar)
    return bar


class _Counter:
    """The progress bar without tqdm: one ``\\r``-rewritten line ``desc: done/total``."""

    def __init__(self, total: int, desc: str, enabled: bool):
        self.total, self.desc, self.enabled, self.n, self.note = total, desc, enabled, 0, ""

    def __enter__(self) -> _Counter:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _show(self, end: str = "") -> None:
        if self.enabled:
            print(f"\r{self.desc}: {self.n}/{self.total} {self.note}", end=end, file=sys.stderr, flush=True)

    def update(self, n: int = 1) -> None:
        self.n += n
        self._show()

    def clear(self) -> None:
        if self.enabled:
            print("\r\033[K", end="", file=sys.stderr, flush=True)

    def refresh(self) -> None:
        self._show()

    def set_postfix_str(self, text: str) -> None:
        self.note = text
        self._show()

    def close(self) -> None:
        self._show("\n")
        self.enabled = False


def stage_progress(enabled: bool) -> Callable[[str, float], None] | None:
    """The fits' progress callback ``(stage, fraction)`` on the one bar (:func:`progress_bar`): the
    job in percent, the stage as the bar's note; None when not ``enabled``."""
    if not enabled:
        return None
    bar = progress_bar(100, enabled=True, desc="progress", unit="%")

    def show(stage: str, fraction: float) -> None:
        done = int(round(100 * max(0.0, min(fraction, 1.0))))
        if done > bar.n:
            bar.update(done - bar.n)
        bar.set_postfix_str(stage)
        if fraction >= 1.0:
            _close(bar)

    return show


def _close(bar) -> None:
    if bar in _open_bars:
        _open_bars.remove(bar)
        bar.close()


def end_progress_line() -> None:
    """Close the progress bars still shown on stderr, so that a message printed next starts a line."""
    for bar in list(_open_bars):
        _close(bar)


# ---- arguments several rigs' commands declare alike ----------------------------------------------

JSON = Argument(("--json",), {"action": "store_true", "help": "print JSON"})
#: ``--plots DIR``: the folder of a command's figures (declare :data:`FIGURE_FORMAT` with it).
PLOTS = Argument(("--plots",), {"metavar": "DIR", "default": None, "help": "write the figures into DIR"})
#: ``--figure-format``: the file format of the ``--plots`` figures (:func:`figure_format`; the values
#: are :data:`impactid.plotting.FORMATS`, spelled out here so that building the parser loads no plotting).
#: ``--report REPORT.html``: a self-contained HTML page of a fit (:func:`write_report`,
#: :mod:`impactid.html_report`), written whether or not ``--plots`` is given.
REPORT = Argument(("--report",), {"metavar": "REPORT.html", "default": None,
                                  "help": "write a self-contained HTML report (parameters, model check, "
                                          "identifiability, figures, per-impact tables), atomically"})
FIGURE_FORMAT = Argument(("--figure-format",), {"choices": ("png", "svg", "pdf"), "default": "png",
                                                "help": "file format of the --plots figures: png (200 dpi, the "
                                                        "default), svg or pdf (vector)"})


def recording_arguments(several: bool = False) -> tuple[Argument, ...]:
    """The recording(s), ``--example`` and ``--rig`` of a command that reads recordings."""
    if several:
        files = Argument(("recordings",), {"metavar": "REC", "nargs": "*",
                                           "help": "HDF5 or CSV recordings (several: joint fit)"})
    else:
        files = Argument(("recording",), {"metavar": "REC", "nargs": "?", "help": "HDF5 or CSV recording"})
    return (
        files,
        Argument(("--example",), {"action": "store_true", "help": "use the built-in example (two recordings of "
                                                                  "one rig; commands that read one use the first)"}),
        Argument(("--rig",), {"metavar": "RIG.toml|MODEL|PRESET",
                              "help": rig_help("supplies or overrides the recording's rig (a rig file also its "
                                               "operating point)")}),
    )


def speed_arguments(rpm: bool = False) -> tuple[Argument, ...]:
    """``--cam-speed HZ`` (default: the rig file's ``[operating] cam_speed_hz``) and ``--rpm``."""
    out = (Argument(("--cam-speed",), {"type": positive, "default": None, "metavar": "HZ",
                                       "help": "cam speed [Hz] (default: the rig file's [operating] cam_speed_hz)"}),)
    if rpm:
        out += (Argument(("--rpm",), {"type": positive, "default": None,
                                      "help": "cam speed [rpm] (instead of --cam-speed)"}),)
    return out


# the arguments of ``impactid synth`` that rig P and rig F share
SYNTH_DURATION = Argument(("--duration",), {"type": positive, "default": 2.0,
                                            "help": "recorded time [s] (default 2)"})
SAMPLE_RATE = Argument(("--sample-rate",), {"type": positive, "default": None,
                                            "help": "sample rate [Hz] (default 204800 for rig P, 20000 for rig F)"})
NOISE_CHANNEL = Argument(("--noise-channel",), {"action": "append", "metavar": "NAME=FRACTION",
                                                "help": "noise of one channel"})
CAM_PPR = Argument(("--cam-ppr",), {"type": integer_in(1, 10_000_000), "default": None,
                                    "help": "cam encoder pulses/rev (rig F default 5000)"})
SEED = Argument(("--seed",), {"type": integer_in(0, 2**63 - 1), "default": 0, "help": "random seed"})
SYNTH_OUT = Argument(("--out",), {"required": True, "metavar": "FILE.h5", "help": "output HDF5 file"})

"""The ``impactid`` command line. Thin: parses arguments, calls the public API, prints results.

This module builds the parser from the rig registry and holds the environment every command runs
in (errors, warnings, Ctrl-C and SIGTERM), ``impactid info``, ``impactid estimate`` (generic: it
runs :class:`impactid.pipeline.Pipeline` with the estimator of the recordings' rig model, its
arguments the union of the rigs' :attr:`~impactid.rigs.base.Estimator.arguments`) and ``impactid
campaign`` (:mod:`impactid.campaign`). Each registered rig contributes
its commands (:class:`~impactid.rigs.base.CommandSpec`: rig P's ``events``,
``regime``, ... in :mod:`impactid.rigs.pivoted.commands`, rig F's in
:mod:`impactid.rigs.flat.commands`, ...); a command several rigs contribute runs the implementation
of the rig ``--rig`` names (:func:`impactid.rigs.registry.resolve_rig`: a model name, a preset name
or a TOML rig file). The plumbing the commands share is :mod:`impactid.commandline`. Units on the
command line are SI like everywhere else (``--beta`` in N s m^-(n+1), e.g. 24.7e9 for the paper's
24.7 GN s m^-2.5), except cam speeds, which are in Hz (``--cam-speed``) or rpm (``--rpm``) as in
the papers.

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
import functools
import os
import signal
import sys
import threading
import types
import warnings
from collections.abc import Iterator, Sequence

from impactid import _status
from impactid._files import TerminationRequested, request_termination, termination_requested
from impactid._signals import arrived_stop, forget_stops, in_import, in_native_machinery, stopping_handler
from impactid._version import __version__
from impactid.campaign_format import FORMAT_HELP
from impactid.commandline import (
    FIGURE_FORMAT,
    REPORT,
    UsageError,
    check_outputs,
    check_report,
    command_inputs,
    command_line,
    deliver,
    end_progress_line,
    print_json,
    recording_arguments,
    recording_paths,
    recording_rig,
    rig_help,
    say_written,
    stage_progress,
)
from impactid.distributed import add_scheduler_arguments
from impactid.errors import ImpactidError
from impactid.rigs.base import argument_dests
from impactid.rigs.registry import (
    PLUGINS,
    estimable_models,
    estimate_arguments,
    estimate_title,
    resolve_rig,
    rig_commands,
    rig_model,
)

__all__ = ["UsageError", "build_parser", "main"]

EXIT_INPUT_ERROR = 2
EXIT_INTERRUPTED = 130
EXIT_TERMINATED = 143
#: Exit status when stdout's reader closed the pipe (128 + SIGPIPE, as for the shell's own tools).
EXIT_BROKEN_PIPE = 141


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors (``impactid: error: argument --x: ...``) raised, not printed, and
    a description that may be a function, called when the help is printed (a text that lives in a
    heavy module: building the parser does not import it)."""

    def error(self, message: str):  # noqa: D401 - argparse API
        raise UsageError(message)

    def format_help(self) -> str:
        if callable(self.description):
            self.description = self.description()
        return super().format_help()


# ---- commands ---------------------------------------------------------------------------------


def cmd_info(args) -> int:
    from impactid.io import read_recording

    rec = read_recording(recording_paths(args)[0], rig=recording_rig(args))
    info = {
        "file": rec.source, "rig": rec.rig.model if rec.rig is not None else None,
        "sample_rate_hz": rec.sample_rate_hz, "start_time_s": rec.start_time_s, "n_samples": rec.n_samples,
        "duration_s": rec.duration, "operating": dict(rec.operating),
        "channels": {name: {"units": rec.units[name], "min": rec.channel_range(name)[0],
                            "max": rec.channel_range(name)[1]} for name in rec.channels},
        "provenance": list(rec.provenance),
    }
    if args.json:
        print_json(info)
    else:
        print(f"{info['file']}: rig {info['rig']}, {rec.n_samples} samples at {rec.sample_rate_hz:g} Hz "
              f"({rec.duration:.6g} s from {rec.start_time_s:g} s)")
        for key, value in rec.operating.items():
            print(f"  {key} = {value:.6g}")
        for name, c in info["channels"].items():
            print(f"  {name} [{c['units']}]: {c['min']:.6g} .. {c['max']:.6g}")
    return 0


def cmd_campaign(args) -> int:
    from impactid._files import check_output
    from impactid.campaign import load_campaign, run_campaign, write_campaign_report
    from impactid.distributed import cluster_from_args, missing

    spec = load_campaign(args.source)
    out = args.out or spec.out
    if out is None:
        raise UsageError("argument --out: no output folder: give --out DIR, or out = \"DIR\" in the [campaign] "
                         "table of the campaign file")
    check_output(out, option="--out", inputs=spec.inputs(), directory=True)
    check_report(args, spec.inputs())
    if args.serial:
        if args.scheduler is not None or args.workers:
            raise UsageError("argument --serial: not allowed with --scheduler or --workers N")
        args.workers = 0
    elif args.scheduler is None and args.workers is None and missing("distributed"):
        # the default local cluster needs dask (the 'campaign' extra): without it, serially, and say so
        warnings.warn("dask is not installed: the campaign runs serially in this process (pip install "
                      "'impactid[campaign]' for a cluster)", stacklevel=1)
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
    if args.report is not None:
        write_campaign_report(spec, result, args.report, command=command_line(args))
        data["report"] = str(args.report)
    if args.json:
        print_json(data)
    else:
        print(f"campaign {spec.name}: {len(spec.recordings)} recordings, {fits} fits: {result.ran} done, "
              f"{result.skipped} skipped (finished earlier), {result.failed} failed "
              f"({result.seconds:.1f} s, {result.where})")
        for kind, name, reason in result.failures():
            print(f"  failed: {kind} fit {name}: {reason}")
        print(f"  table written to {' and '.join(str(f) for f in result.files)}")
        if args.report is not None:
            print(f"  report written to {args.report}")
    return 0 if result.ok else 1


#: Arguments of ``impactid estimate`` that are no rig's estimate option.
_ESTIMATE_ARGUMENTS = frozenset({"recordings", "example", "rig", "out", "plots", "figure_format", "report", "json",
                                 "progress", "command", "func", "option_defaults", "argv"})


def cmd_estimate(args) -> int:
    """``impactid estimate``: the estimate of the recordings' rig (:class:`impactid.pipeline.Pipeline`)."""
    # the pipeline loads the recordings' reader (numba) and the estimators: when the command runs, not
    # when the parser is built (``impactid --help`` starts in a fraction of a second)
    from impactid.pipeline import Pipeline, read_recordings, recordings_model, rig_estimator

    paths = recording_paths(args, several=True)
    inputs = command_inputs(args, paths)
    check_outputs(args, inputs)
    recordings = read_recordings(paths, rig=recording_rig(args))  # sizes checked before anything is read
    model = recordings_model(recordings)
    est = rig_estimator(model, recordings[0].source)
    _refuse_foreign_estimate_options(args, model, est)
    pipeline = Pipeline(model=model, **est.options_from_arguments(args))
    progress = stage_progress(args.progress if args.progress is not None else sys.stderr.isatty())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", est.warning)  # the result's notes, printed below
        result = pipeline.run(recordings, progress=progress)
    data = est.to_dict(result)
    data["recordings_read"] = [str(p) for p in paths]
    deliver(args, data, inputs, est.figures(result, args) if est.figures is not None else None)
    if args.json:
        return 0
    for line in est.summary(result):
        print(line)
    say_written(args)
    return 0


def _refuse_foreign_estimate_options(args, model: str, est) -> None:
    """Refuse an option of another rig's estimate (argparse takes the union of the rigs' options; this
    rig's estimate would silently ignore it): a value that differs from its default."""
    own = set(est.argument_dests())
    defaults = getattr(args, "option_defaults", {})
    for dest, value in sorted(vars(args).items()):
        if dest in own or dest in _ESTIMATE_ARGUMENTS or dest not in defaults or value == defaults[dest]:
            continue
        owners = [name for name in estimable_models() if dest in argument_dests(estimate_arguments(name))]
        raise UsageError(f"argument --{dest.replace('_', '-')}: not an option of 'estimate' for the {model!r} rig "
                         f"(it is an option of the {' and '.join(repr(o) for o in owners)} rig's estimate)")


def _add_estimate_command(sub) -> None:
    """``impactid estimate``: the generic arguments and the union of the rigs' estimate arguments (read
    from each rig's light declaration of them: building the parser imports no estimation module)."""
    models = estimable_models()
    titles = "; ".join(title for title in map(estimate_title, models) if title)
    p = sub.add_parser("estimate", help=f"estimate a contact law from recordings of one rig ({titles})",
                       description="Estimate the contact law of the recordings' rig (their /rig model picks the "
                                   f"estimate: {', '.join(models)}); several recordings: a joint fit. Options of "
                                   "one rig's estimate are refused for another rig's recordings.")
    for argument in recording_arguments(several=True):
        argument.add_to(p)
    for name in models:
        for argument in estimate_arguments(name):
            argument.add_to(p)
    p.add_argument("--out", metavar="RESULT.json", help="write the result as JSON (atomically)")
    p.add_argument("--plots", metavar="DIR", help="write figures (rig P: hysteresis, restitution, landscape, "
                                                  "residuals)")
    FIGURE_FORMAT.add_to(p)
    REPORT.add_to(p)
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                   help="progress bar on stderr (default: when stderr is a terminal)")
    p.set_defaults(func=cmd_estimate, option_defaults=types.MappingProxyType({a.dest: a.default for a in p._actions}))


#: What ``impactid --help`` says first (for a user; the module's docstring is for a developer).
DESCRIPTION = ("impactid identifies contact and impact models from recordings of impact experiments: it "
               "finds each impact,\nreconstructs it and fits the rig's simulator to the data, with 95 % "
               "confidence intervals and a check\nthat the model describes the data.")
#: The end of ``impactid --help``: where to start.
EPILOG = ("Start with:  impactid estimate --example      (a built-in example: prints the estimate beside the "
          "values it was made with)\nEvery command has --help. Units are SI, cam speeds in Hz (--cam-speed) or "
          "rpm (--rpm). Documentation: docs/ in the\nsource tree (docs/commands.md lists every command).")


def _campaign_description() -> str:
    """``impactid campaign --help``'s text: the campaign file's format and the exit statuses
    (:data:`impactid.campaign_format.FORMAT_HELP`)."""
    return FORMAT_HELP + ("\nExit status: 0 when every fit ended in an estimate, 1 when some failed (the table and "
                          "the\nfailed: lines say why), 2 when the campaign could not be run.")


def _add_campaign_command(sub) -> None:
    p = sub.add_parser("campaign", help="fit every recording of a campaign alone and its groups jointly, on a dask "
                                        "cluster; a rerun skips finished fits",
                       formatter_class=argparse.RawDescriptionHelpFormatter, description=_campaign_description)
    p.add_argument("source", metavar="CAMPAIGN.toml|DIR", help="campaign file, or a folder of recordings")
    p.add_argument("--out", metavar="DIR", help="output folder (default: [campaign] out of the campaign file)")
    add_scheduler_arguments(p, local_default=True)
    p.add_argument("--serial", action="store_true", help="run in this process, without dask (as --workers 0)")
    p.add_argument("--fresh", action="store_true", help="run every task again (ignore finished fits and caches)")
    p.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                   help="progress bar on stderr (default: when stderr is a terminal)")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.add_argument("--report", metavar="REPORT.html", default=None,
                   help="write a self-contained HTML report: the per-recording estimates, the pooled (joint) "
                        "estimates and the spread of the single fits")
    p.set_defaults(func=cmd_campaign)


def cmd_warmup(args) -> int:
    """``impactid warmup``: compile (or load from numba's cache) the kernels the commands run
    (:mod:`impactid.warmup`), for every rig or ``--rig``'s, saying what and how long."""
    # the rigs' numerics (numba, the kernels) load when the command runs, not when the parser is built
    from impactid.warmup import all_models, warm_up

    models = [args.rig] if args.rig else all_models()
    warm_up(models, log=lambda text: print(f"impactid warmup: {text}", flush=True))
    return 0


def _add_warmup_command(sub) -> None:
    p = sub.add_parser("warmup", help="compile the simulators' kernels now (for container images and CI), so that "
                                      "the first command starts from numba's cache",
                       description="Compile (or load from numba's cache) every compiled kernel the commands use, "
                                   "for every rig or the one --rig names, and say what and how long. Run it as "
                                   "the user and on the CPU type that will run the commands (numba's cache is "
                                   "keyed on both); the cache is beside the package, or in $IMPACTID_CACHE_DIR/numba, "
                                   "or in the user's cache folder when the installation is read-only.")
    p.add_argument("--rig", choices=list(PLUGINS), default=None, help="only this rig (default: every rig)")
    p.set_defaults(func=cmd_warmup)


# ---- parser -----------------------------------------------------------------------------------


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="impactid", description=DESCRIPTION, epilog=EPILOG,
                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version=f"impactid {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    p = sub.add_parser("info", help="read and validate a recording; print what it holds")
    for argument in recording_arguments():
        argument.add_to(p)
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=cmd_info)
    _add_estimate_command(sub)
    _add_campaign_command(sub)
    _add_warmup_command(sub)
    _add_rig_commands(sub)
    return parser


def _add_rig_commands(sub) -> None:
    """The commands the registered rigs contribute (:class:`~impactid.rigs.base.CommandSpec`).

    A command several rigs contribute (or one of a group) takes ``--rig`` and runs the chosen rig's
    implementation; its arguments are the union of theirs. ``--rig`` is a model name among theirs
    (``rig_argument="model"``), or a model name, preset name or rig file resolved through the
    registry (``rig_argument="resolve"``; the spec with ``default_rig`` runs without ``--rig``).
    Commands are grouped (``impactid valvetrain simulate``) or top-level (group ``""``). The rigs'
    commands modules are read without building the rigs' models (:func:`~impactid.rigs.registry.rig_commands`):
    a command builds its rig's model when it runs."""
    specs: dict[tuple[str, str], list] = {}
    for model in list(PLUGINS):
        for spec in rig_commands(model):
            specs.setdefault((spec.group, spec.name), []).append((model, spec))
    groups: dict[str, argparse._SubParsersAction] = {}
    for (group, name), entries in specs.items():
        if group:
            if group not in groups:
                rigs = ", ".join(sorted({m for m, _ in entries}))
                holder = sub.add_parser(group, help=f"{group} commands ({rigs})")
                groups[group] = holder.add_subparsers(dest=f"{group}_command", required=True, parser_class=_Parser)
            target = groups[group]
        else:
            target = sub
        command = f"{group} {name}".strip()
        p = target.add_parser(name, help=entries[0][1].help, description=entries[0][1].description or None)
        names = [m for m, _ in entries]
        modes = {spec.rig_argument for _, spec in entries}
        defaults = [m for m, spec in entries if spec.default_rig]
        if len(modes) > 1 or len(defaults) > 1:
            raise ValueError(f"the rigs contributing '{command}' ({', '.join(names)}) disagree on its --rig")
        resolve = modes == {"resolve"}
        default = defaults[0] if defaults else None
        if resolve:
            p.add_argument("--rig", metavar="MODEL|PRESET|RIG.toml", default=None, required=default is None,
                           help=rig_help(f"the rig, whose model picks the implementation ({', '.join(names)}"
                                         + (f"; default {default}" if default else "") + ")"))
        elif group or len(names) > 1:  # a top-level command of one rig (``impactid bounces``) needs no --rig
            p.add_argument("--rig", choices=names, default=names[0] if len(names) == 1 else None,
                           required=len(names) > 1, help=f"rig model ({', '.join(names)})")
        for _, spec in entries:
            for argument in spec.arguments:
                argument.add_to(p)
        option_defaults = types.MappingProxyType({a.dest: a.default for a in p._actions})
        p.set_defaults(func=functools.partial(_run_rig_command, command=command,
                                              specs={m: spec for m, spec in entries},
                                              choose=resolve or bool(group) or len(names) > 1,
                                              resolve=resolve, default=default),
                       option_defaults=option_defaults)


def _run_rig_command(args, *, command: str, specs: dict, choose: bool, resolve: bool, default: str | None) -> int:
    """Run the implementation of the rig ``--rig`` names (``choose``), or the only rig's (a command of
    one rig, which may declare and resolve a ``--rig`` of its own). ``args.option_defaults`` holds
    the command's option defaults (a rig can tell an option of another rig's version of a shared
    command that was given from one that was not)."""
    if resolve:
        resolved = resolve_rig(args.rig, default=default)
        spec = specs.get(resolved.model.name)
        if spec is None:
            raise UsageError(f"argument --rig: '{command}' is not available for the {resolved.model.name!r} rig "
                             f"(it is for: {', '.join(specs)})")
        args.resolved_rig = resolved
        return int(spec.run(args, resolved.model) or 0)
    name = (args.rig or next(iter(specs))) if choose else next(iter(specs))
    return int(specs[name].run(args, rig_model(name)) or 0)


# ---- entry point ------------------------------------------------------------------------------


def _error(message: str) -> None:
    end_progress_line()
    text = " ".join(str(message).split())  # one line, whatever the message held
    print(f"impactid: error: {text}", file=sys.stderr, flush=True)


def _unsafe_to_stop(frame: types.FrameType | None) -> bool:
    """Whether a stop's exception must wait: inside numba or llvmlite, or inside an import."""
    return in_native_machinery(frame) or in_import(frame)


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

    def stop(signum):
        if signum == signal.SIGTERM:
            request_termination()  # raises; outputs are rolled back as on Ctrl-C
        raise KeyboardInterrupt()

    # raised only outside numba's and llvmlite's machinery (impactid._signals: an exception there
    # crashed the process) and outside a module's initialisation: a command imports its heavy
    # modules (NumPy, pandas, SciPy, numba, the rig's numerics) when it runs, and an exception raised
    # in the middle of a library's initialisation can leave its C state half-built (pyarrow's, under
    # pandas, was seen to kill the process at exit or hang it), so such a stop waits for the import
    handler = stopping_handler(stop, _last_words, defer_while=_unsafe_to_stop)

    def unraisable(info):
        # a stop raised inside a finalizer is swallowed by Python; the flag it set still stops the
        # job (at the next output commit, or below), so the traceback is not shown
        if not isinstance(info.exc_value, (TerminationRequested, KeyboardInterrupt)):
            previous_hook(info)

    previous_handler = previous_interrupt = None
    previous_hook = sys.unraisablehook
    in_main = threading.current_thread() is threading.main_thread()
    if in_main:
        previous_handler = signal.signal(signal.SIGTERM, handler)
        previous_interrupt = signal.signal(signal.SIGINT, handler)
    sys.unraisablehook = unraisable
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("always")
            # numba's pedantic SSA check warns, on first compilation, about variables of the DP5 core's
            # inlined overloads (harmless, numba issue 7236): not a message for the user
            warnings.filterwarnings("ignore", message=r"variable '.*' is not in scope")
            # a file a library left open when a stop interrupted it is closed by its finalizer: not news
            # for the user (it made a second line after "interrupted" when Ctrl-C landed in pandas' reader)
            warnings.filterwarnings("ignore", category=ResourceWarning)
            warnings.showwarning = show
            yield
            stop = signal.SIGTERM if termination_requested() else arrived_stop()
            if stop == signal.SIGTERM:  # a stop whose exception was lost (a finalizer, a retry not delivered)
                raise TerminationRequested()
            if stop is not None:
                raise KeyboardInterrupt()
    finally:
        handler.end()
        forget_stops()
        sys.unraisablehook = previous_hook
        if in_main:
            signal.signal(signal.SIGTERM, previous_handler)
            signal.signal(signal.SIGINT, previous_interrupt)


def _last_words(signum: int) -> str:
    """The one-line message of a command stopped by ``signum``."""
    if signum == signal.SIGTERM:
        return "terminated (SIGTERM); outputs not completed were not written"
    return "interrupted (Ctrl-C); outputs not completed were not written"


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``impactid`` command; returns the exit code."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except UsageError as exc:
        _error(exc)
        return EXIT_INPUT_ERROR
    args.argv = list(sys.argv[1:] if argv is None else argv)  # the command line, for a report's provenance
    try:
        with _command_environment(), _status.running(str(getattr(args, "command", None) or "working")):
            return int(args.func(args) or 0)
    except ImpactidError as exc:
        _error(exc)
        return EXIT_INPUT_ERROR
    except KeyboardInterrupt:
        _error(_last_words(signal.SIGINT))
        return EXIT_INTERRUPTED
    except TerminationRequested:
        _error(_last_words(signal.SIGTERM))
        return EXIT_TERMINATED
    except MemoryError:
        _error("out of memory: the input or the requested computation is too large for this machine")
        return EXIT_INPUT_ERROR
    except BrokenPipeError:  # the reader of stdout went away (`impactid ... | head`): not an error of the job
        with contextlib.suppress(OSError, ValueError):
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # the exit's flush fails quietly
        return EXIT_BROKEN_PIPE
    except OSError as exc:  # a file system problem not caught where it happened (disk full, ...)
        where = f"{exc.filename}: " if exc.filename else ""
        _error(f"{where}{exc.strerror or exc}")
        return EXIT_INPUT_ERROR


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

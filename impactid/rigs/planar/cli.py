"""``impactid planar fit`` and ``impactid planar predict``: what the commands run.

Thin: resolves the body, reads the table, calls :mod:`impactid.rigs.planar.identify`, prints and
writes. Also ``impactid synth --rig planar-impact`` (:func:`run_synth`), which writes a synthetic
table of impacts (:mod:`impactid.rigs.planar.synth`). Output paths are checked before anything is
computed, outputs are written atomically, and every failure the user can cause is one line
``impactid: error: ...`` (exit status 2).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from impactid._files import StagedFiles, check_output
from impactid.commandline import (
    UsageError,
    check_out_suffix,
    check_outputs,
    deliver,
    figure_format,
    print_json,
    refuse_other_rigs_options,
    say_written,
)
from impactid.errors import ImpactidError, RigParameterError
from impactid.results import FitResult
from impactid.rigs.base import argument_dests
from impactid.rigs.planar.commands import SYNTH, SYNTH_SUFFIXES
from impactid.rigs.planar.identify import PlanarFitError, PlanarLawFit, fit_planar, predict_planar, score_predictions
from impactid.rigs.planar.laws import PlanarLaw
from impactid.rigs.planar.parameters import MODEL_NAME, PRESETS, PlanarBody
from impactid.rigs.planar.synth import (
    DEFAULT_APPROACH_SPEEDS,
    DEFAULT_NOISE,
    DEFAULT_SEMI_AXES,
    synth_impacts,
    write_impacts,
)
from impactid.rigs.planar.table import read_impacts, read_pre_impact
from impactid.rigs.registry import resolve_rig

__all__ = ["body_from_arguments", "run_fit", "run_predict", "run_synth"]

#: Defaults of ``impactid synth --rig planar-impact`` not in :mod:`~impactid.rigs.planar.synth`'s constants.
SYNTH_DEFAULTS = {"restitution": 0.6, "mu": 0.3, "impact_rule": "newton", "impacts": 200}
#: The options of other rigs' ``synth`` that mean something close here, and what to give instead.
_SYNTH_HINTS = {"noise": " (the measured velocities' noise is --velocity-noise M/S)",
                "restitution_law": " (a speed-dependent restitution is --restitution E0 --restitution-slope GAMMA)",
                "bounce_law": " (a speed-dependent restitution is --restitution E0 --restitution-slope GAMMA)",
                "law": " (the impact law is --impact-rule, --restitution, --restitution-slope, --mu and "
                       "--tangential-restitution)"}


def body_from_arguments(args, default: PlanarBody | None = None) -> PlanarBody:
    """The body of ``--body``, ``--rig-file``, or ``--mass`` with ``--radius-of-gyration`` (else ``default``)."""
    given = [flag for flag, value in (("--body", args.body), ("--rig-file", args.rig_file),
                                      ("--mass", args.mass), ("--radius-of-gyration", args.radius_of_gyration))
             if value is not None]
    named = [flag for flag in given if flag in ("--body", "--rig-file")]
    if len(named) > 1 or (named and len(given) > 1):
        raise UsageError(f"argument {given[0]}: give one of --body, --rig-file, or --mass with "
                         f"--radius-of-gyration (got {', '.join(given)})")
    if args.body is not None:
        return PRESETS[args.body]
    if args.rig_file is not None:
        _check_input(args.rig_file, "--rig-file")
        try:
            resolved = resolve_rig(args.rig_file)
        except RigParameterError as exc:
            raise UsageError(f"argument --rig-file: {exc}") from None
        if resolved.model.name != MODEL_NAME:
            raise UsageError(f"argument --rig-file: {args.rig_file} describes a {resolved.model.name} rig, not a "
                             f"{MODEL_NAME} body")
        return resolved.rig
    if given:
        if args.mass is None or args.radius_of_gyration is None:
            missing, flag = (("--radius-of-gyration", "--mass") if args.radius_of_gyration is None
                             else ("--mass", "--radius-of-gyration"))
            raise UsageError(f"argument {flag}: a body needs {missing} too")
        return PlanarBody(mass=args.mass, radius_of_gyration=args.radius_of_gyration)
    if default is None:
        raise UsageError("argument --body: the body is needed: --body mcube-ellipse, --rig-file RIG.toml, or --mass "
                         "with --radius-of-gyration")
    return default


def _check_input(path: str, option: str) -> None:
    p = Path(path)
    if not p.exists():
        raise UsageError(f"argument {option}: {path}: no such file")
    if not p.is_file():
        raise UsageError(f"argument {option}: {path}: not a regular file")


def _num(value, fmt: str = ".4g") -> str:
    return "undetermined" if value is None or not math.isfinite(float(value)) else format(float(value), fmt)


def run_fit(args) -> int:
    """``impactid planar fit IMPACTS.csv``; returns the exit code."""
    body = body_from_arguments(args)
    _check_input(args.impacts, "IMPACTS.csv")
    inputs = [path for path in (args.impacts, args.rig_file) if path is not None]
    check_outputs(args, inputs)
    impacts = read_impacts(args.impacts, require=args.target or "any")
    try:
        result = fit_planar(impacts, body, laws=args.law, criterion=args.criterion, target=args.target,
                            confidence=args.confidence)
    except PlanarFitError as exc:
        raise ImpactidError(str(exc)) from None
    data = result.to_dict()
    data["recordings_read"] = [str(args.impacts)]
    deliver(args, data, inputs, _fit_figures(args, result, impacts))
    if args.json:
        return 0
    s = result.statistics
    print(f"impactid planar fit: {s['n_impacts']} impacts of {args.impacts}, law {result.law.name} "
          f"({result.details.get('selection', 'given')}), target {s['target']}")
    for p in result.params.values():
        lo, hi = p.interval
        if not math.isfinite(p.value) and math.isfinite(lo):  # a lower bound only (mu where every impact sticks)
            print(f"  {p.name:<6} >= {_num(lo)} (lower bound: not determined) {p.unit}".rstrip())
            continue
        print(f"  {p.name:<6} {_num(p.value, '.5g')} +/- {_num(p.stderr, '.2g')} [{_num(lo)}, {_num(hi)}] "
              f"{p.unit}".rstrip())
    if "median_relative_impulse_error" in s:
        print(f"  median relative impulse error of the fitted impacts {_num(s['median_relative_impulse_error'], '.3g')}"
              f"; {100 * s['sticking_fraction']:.0f} % stick")
    print(f"  model check: {result.model_check.get('verdict')}")
    for note in result.notes:
        print(f"  note: {note}")
    say_written(args)
    return 0


def _fit_figures(args, result, impacts):
    """The figures of ``planar fit --plots`` (:func:`impactid.rigs.planar.figures.planar_figures`): their names
    and their writer (matplotlib is imported when it runs)."""

    def write(staged):
        from impactid.rigs.planar.figures import planar_figures

        return planar_figures(result, impacts, args.plots, staged, figure_format(args))

    return ["planar_impacts.png", "planar_agreement.png"], write


def _read_law(path: str) -> PlanarLawFit:
    _check_input(path, "--law")
    try:
        result = FitResult.from_json(Path(path))
    except (json.JSONDecodeError, UnicodeDecodeError, KeyError, TypeError, ValueError, OSError) as exc:
        raise UsageError(f"argument --law: {path}: not a fit result ({str(exc).splitlines()[0]})") from None
    if not isinstance(result, PlanarLawFit):
        raise UsageError(f"argument --law: {path}: a {result.kind!r} result, not a planar impact law fit "
                         "(write one with impactid planar fit --out)")
    try:
        law = result.law
        result.body  # noqa: B018  (rebuilt here so that a bad body is refused before anything is read)
    except (KeyError, TypeError, ValueError) as exc:
        raise UsageError(f"argument --law: {path}: incomplete planar impact law fit ({exc})") from None
    missing = [n for n in law.names if n not in result.params or not math.isfinite(result.value(n))]
    if missing:
        raise UsageError(f"argument --law: {path}: parameter(s) {', '.join(missing)} missing or undetermined")
    return result


def run_predict(args) -> int:
    """``impactid planar predict IMPACTS.csv --law RESULT.json --out PREDICTIONS.csv``; returns the exit code."""
    _check_input(args.impacts, "IMPACTS.csv")
    fit = _read_law(args.law)
    body = body_from_arguments(args, default=fit.body)
    check_output(args.out, option="--out", inputs=[args.impacts, args.law])
    pre = read_pre_impact(args.impacts)  # the pre-impact state and the Jacobian: nothing else is read
    predictions = predict_planar(fit.law, fit.values, body, pre)
    scored = predictions
    summary = {"impacts": len(pre), "law": fit.law.name, "law_file": str(args.law), "source": str(args.impacts),
               "out": str(args.out), "parameters": dict(fit.values), "body": body.to_dict(),
               "sticking_fraction": float(np.mean(predictions["sticking"]))}
    if not args.no_score:
        try:  # the measured outcome, read only now and only to score
            truth = read_impacts(args.impacts)
        except ImpactidError:
            truth = None
        if truth is not None:
            scored = score_predictions(predictions, truth, body)
            for column in ("relative_impulse_error", "relative_velocity_error"):
                if column in scored:
                    summary[f"median_{column}"] = float(np.median(scored[column]))
    with StagedFiles(protect=[args.impacts, args.law]) as staged:
        staged.write_text(args.out, scored.to_csv(index=False, float_format="%.10g"))
    if args.json:
        print_json(summary)
        return 0
    print(f"impactid planar predict: {len(pre)} impacts of {args.impacts} with the {fit.law.name} law of {args.law}; "
          f"{100 * summary['sticking_fraction']:.0f} % stick")
    for key in ("median_relative_impulse_error", "median_relative_velocity_error"):
        if key in summary:
            print(f"  {key.replace('_', ' ')}: {summary[key]:.4g}")
    print(f"  predictions written to {args.out}")
    return 0


def _synth_law(args) -> tuple[PlanarLaw, dict]:
    """The law of ``impactid synth --rig planar-impact`` and its parameters, from the options."""
    e = SYNTH_DEFAULTS["restitution"] if args.restitution is None else args.restitution
    values = {"mu": SYNTH_DEFAULTS["mu"] if args.mu is None else args.mu}
    if args.restitution_slope is None:
        values["e"] = e
    else:
        values.update(e0=e, gamma=args.restitution_slope)
    if args.tangential_restitution is not None:
        values["e_t"] = args.tangential_restitution
    law = PlanarLaw(args.impact_rule or SYNTH_DEFAULTS["impact_rule"],
                    "constant" if args.restitution_slope is None else "linear", args.tangential_restitution is not None)
    return law, values


def run_synth(args) -> int:
    """``impactid synth --rig planar-impact``: a synthetic table of planar impacts made by a known law (its
    pre-impact states, contact Jacobians, post-impact states and impulses) for ``impactid planar fit``;
    returns the exit code."""
    refuse_other_rigs_options(args, argument_dests(SYNTH.arguments), command="synth", model_name=MODEL_NAME,
                              hints=_SYNTH_HINTS)
    check_out_suffix(args.out, SYNTH_SUFFIXES, "a table of impacts")
    body = args.resolved_rig.rig
    law, values = _synth_law(args)
    low, high = DEFAULT_APPROACH_SPEEDS if args.approach_speeds is None else args.approach_speeds
    if not 0.0 < low <= high <= 100.0:
        raise UsageError(f"argument --approach-speeds: needs 0 < LOW <= HIGH <= 100 m/s, got {low:g},{high:g}")
    a, b = DEFAULT_SEMI_AXES if args.semi_axes is None else args.semi_axes
    if not (0.0 < a <= 10.0 and 0.0 < b <= 10.0):
        raise UsageError(f"argument --semi-axes: two lengths in (0, 10] m, got {a:g},{b:g}")
    if law.restitution == "linear":
        ends = [values["e0"] * (1.0 - values["gamma"] * u) for u in (low, high)]
        if not all(0.0 <= e <= 1.0 for e in ends):
            raise UsageError(f"argument --restitution-slope: e0 (1 - GAMMA u) = {ends[0]:.3g} to {ends[1]:.3g} over "
                             f"the approach speeds {low:g}-{high:g} m/s; it must stay in [0, 1]")
    noise = DEFAULT_NOISE if args.velocity_noise is None else args.velocity_noise
    if noise > 10.0:
        raise UsageError(f"argument --velocity-noise: at most 10 m/s, got {noise:g}")
    check_outputs(args, [args.rig] if args.rig and Path(args.rig).suffix.lower() == ".toml" else [])
    count = SYNTH_DEFAULTS["impacts"] if args.impacts is None else args.impacts
    try:
        impacts = synth_impacts(law, values, body=body, count=count, semi_axes=(a, b), approach_speeds=(low, high),
                                noise=noise, seed=args.seed)
    except ValueError as exc:
        raise UsageError(f"arguments --mu/--restitution/--impact-rule: {exc}") from None
    write_impacts(args.out, impacts)
    described = ", ".join(f"{name} {value:g}" for name, value in impacts.values.items())
    print(f"{args.out}: {len(impacts)} impacts of a {body.mass:g} kg body (k_g {body.radius_of_gyration:g} m) made by "
          f"the {law.name} law ({described}), {100 * float(np.mean(impacts.exact.sticking)):.0f} % stick; velocity "
          f"noise {noise:g} m/s")
    return 0

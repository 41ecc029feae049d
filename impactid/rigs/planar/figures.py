"""The figures of ``impactid planar fit``, in the package's style (:mod:`impactid.plotting`).

Planar impacts are pairs of states, not time series: what a reader wants to see first is, for a few
impacts, the measured outcome (the velocity of the centre of mass after the impact and, where the table
has it, the impulse) beside the outcome the fitted law predicts from the pre-impact state and the contact
Jacobian alone (:func:`plot_planar_impacts`), then the same comparison over every impact
(:func:`plot_planar_agreement`). matplotlib is imported lazily.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from impactid._files import StagedFiles
from impactid.plotting import MEASURED, OKABE_ITO, SIMULATED, axis_label, styled
from impactid.reports import save_figure_atomic, staged_transaction
from impactid.rigs.planar.laws import ImpactOutcome, outcome
from impactid.rigs.planar.table import PlanarImpacts

__all__ = ["COMPONENTS", "IMPACTS_SHOWN", "PlanarPrediction", "planar_figures", "planar_prediction",
           "plot_planar_agreement", "plot_planar_impacts"]

#: Impacts shown by :func:`plot_planar_impacts` (spread over the approach speeds).
IMPACTS_SHOWN = 5

#: The outcome's components: (key, the quantity in words, its mathtext symbol, unit).
COMPONENTS = (
    ("vx", "horizontal velocity", "v_x", "m/s"),
    ("vy", "vertical velocity", "v_y", "m/s"),
    ("omega", "angular velocity", r"\omega", "rad/s"),
    ("pt", "tangential impulse", "p_t", "N s"),
    ("pn", "normal impulse", "p_n", "N s"),
)
_VELOCITIES = ("vx", "vy", "omega")


def _after(key: str, words: str, symbol: str) -> tuple[str, str]:
    """The words and symbol of a component after the impact (an impulse is only that)."""
    return (f"{words} after the impact", symbol + "^+") if key in _VELOCITIES else (words, symbol)


@dataclass(frozen=True)
class PlanarPrediction:
    """The measured and the predicted outcome of every impact of a planar fit (:func:`planar_prediction`).

    Attributes
    ----------
    impacts : the impacts (with their measured outcome where the table has it).
    approach_speed : ``u = -J_n v^-`` of each impact [m/s].
    predicted : the fitted law's :class:`~impactid.rigs.planar.laws.ImpactOutcome`, or None when the fit
        cannot predict (``note`` says why).
    values : the parameters predicted with (``mu`` at its lower bound where every impact sticks).
    law : the law's name.
    note : why there is no prediction, or what stands in for an undetermined parameter ("" otherwise).
    """

    impacts: PlanarImpacts
    approach_speed: np.ndarray
    predicted: ImpactOutcome | None
    values: dict
    law: str
    note: str = ""

    def measured(self, key: str) -> np.ndarray | None:
        """The measured component ``key`` of :data:`COMPONENTS` per impact, or None when not in the table."""
        imp = self.impacts
        if key in _VELOCITIES:
            return None if imp.v_post is None else imp.v_post[:, _VELOCITIES.index(key)]
        return None if imp.impulse is None else imp.impulse[:, ("pt", "pn").index(key)]

    def before(self, key: str) -> np.ndarray | None:
        """The pre-impact value of a velocity component, None for an impulse."""
        return self.impacts.v_pre[:, _VELOCITIES.index(key)] if key in _VELOCITIES else None

    def prediction(self, key: str) -> np.ndarray | None:
        """The predicted component ``key`` per impact, or None without a prediction."""
        out = self.predicted
        if out is None:
            return None
        if key in _VELOCITIES:
            return out.v_post[:, _VELOCITIES.index(key)]
        return out.p_t if key == "pt" else out.p_n

    def components(self) -> list[tuple[str, str, str, str]]:
        """The components with a measured or a predicted value."""
        return [c for c in COMPONENTS if self.measured(c[0]) is not None or self.prediction(c[0]) is not None]


def planar_prediction(result, impacts: PlanarImpacts) -> PlanarPrediction:
    """What the fitted law of ``result`` (a :class:`~impactid.rigs.planar.identify.PlanarLawFit`) predicts for
    each of ``impacts`` from its pre-impact state and contact Jacobian.

    A parameter the fit left undetermined stands at the lower end of its interval where that is known
    (``mu`` where every fitted impact sticks: any ``mu`` above the bound gives the same impulses);
    otherwise there is no prediction and ``note`` says why.
    """
    law = result.law
    values, stand_ins, missing = {}, [], []
    for name in law.names:
        p = result.params[name]
        if math.isfinite(p.value):
            values[name] = float(p.value)
        elif math.isfinite(p.interval[0]):
            values[name] = float(p.interval[0])
            stand_ins.append(f"{name} at its lower bound {p.interval[0]:.4g}")
        else:
            missing.append(name)
    speed = -np.sum(impacts.jn * impacts.v_pre, axis=1)
    if missing:
        return PlanarPrediction(impacts, speed, None, values, law.name,
                                f"no prediction: parameter(s) {', '.join(missing)} undetermined by the fit")
    predicted = outcome(law, values, impacts.v_pre, impacts.jt, impacts.jn, np.asarray(result.body.inverse_mass))
    note = ("predicted with " + ", ".join(stand_ins)) if stand_ins else ""
    return PlanarPrediction(impacts, speed, predicted, values, law.name, note)


def _picks(speed: np.ndarray, count: int, sticking: np.ndarray | None = None) -> np.ndarray:
    """Indices of at most ``count`` impacts spread over the approach speeds, slowest first; where some
    impacts stick and others slide (``sticking``, as predicted) and the spread shows only one kind, the
    middle one is replaced by the impact of the other kind nearest to it in speed."""
    order = np.argsort(speed, kind="stable")
    picks = order[np.unique(np.round(np.linspace(0, order.size - 1, min(count, order.size))).astype(int))]
    if sticking is not None and picks.size > 2 and np.unique(sticking[picks]).size == 1:
        other = np.flatnonzero(sticking != sticking[picks[0]])
        if other.size:
            middle = picks.size // 2
            picks[middle] = other[np.argmin(np.abs(speed[other] - speed[picks[middle]]))]
            picks = picks[np.argsort(speed[picks], kind="stable")]
    return picks


@styled
def plot_planar_impacts(prediction: PlanarPrediction, count: int = IMPACTS_SHOWN):
    """A few impacts (spread over the approach speeds, slowest at the bottom), one panel per component of
    the outcome: the velocity of the centre of mass before the impact (open circle), after it as measured
    (dot) and as the fitted law predicts it from the pre-impact state and the contact Jacobian (cross),
    and the measured and predicted impulse where the table has it."""
    from matplotlib.figure import Figure

    sticking = None if prediction.predicted is None else prediction.predicted.sticking
    rows = _picks(prediction.approach_speed, count, sticking)
    components = prediction.components()
    fig = Figure(figsize=(2.5 * len(components) + 1.4, 1.0 + 0.55 * len(rows)), layout="constrained")
    axes = fig.subplots(1, len(components), squeeze=False, sharey=True)[0]
    y = np.arange(rows.size)
    ticks = [f"impact {prediction.impacts.impact[i]}: $u$ = {prediction.approach_speed[i]:.3g} m/s"
             + ("" if sticking is None else (", sticks" if sticking[i] else ", slides")) for i in rows]
    for ax, (key, words, symbol, unit) in zip(axes, components):
        before, measured, predicted = prediction.before(key), prediction.measured(key), prediction.prediction(key)
        if before is not None:
            ax.plot(before[rows], y, "o", mfc="none", mec="0.55", ms=6, label="before the impact (measured)")
        if measured is not None:
            ax.plot(measured[rows], y, "o", color=MEASURED, ms=5, label="after: measured")
        if predicted is not None:
            ax.plot(predicted[rows], y, "x", color=SIMULATED, ms=8, mew=2.0, label="after: predicted by the fitted law")
        for k, i in enumerate(rows):  # the change each impact makes, measured and predicted
            ends = [v[i] for v in (measured, predicted) if v is not None]
            start = before[i] if before is not None else 0.0
            ax.plot([min(start, *ends), max(start, *ends)], [k, k], "-", color="0.8", lw=1.0, zorder=0)
        ax.axvline(0.0, color="0.3", lw=0.6)
        ax.set_xlabel(axis_label(words, unit, symbol))
        ax.set_ylabel(axis_label("impact (by approach speed)", None))
        missing = [w for w, v in (("measured", measured), ("predicted", predicted)) if v is None]
        ax.set_title("centre of mass" if key in _VELOCITIES else "impulse at the contact", fontsize=9)
        if missing:
            ax.text(0.02, 0.02, f"not {' or '.join(missing)}", transform=ax.transAxes, fontsize=7, color="0.4",
                    va="bottom", ha="left")
    axes[0].set_yticks(y, ticks)
    axes[0].set_ylim(-0.6, rows.size - 0.4)
    handles = {}
    for ax in axes:
        for handle, label in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(label, handle)
    fig.legend(list(handles.values()), list(handles), loc="outside lower center", ncols=min(3, len(handles)))
    title = f"{Path(prediction.impacts.source).name}: measured and predicted outcomes ({prediction.law} law)"
    if prediction.note:
        title += "\n" + prediction.note
    fig.suptitle(title, fontsize=10)
    return fig


@styled
def plot_planar_agreement(prediction: PlanarPrediction):
    """Predicted against measured outcome over every impact, one panel per measured component (the
    velocity of the centre of mass after the impact, the impulse), sticking and sliding impacts (as the
    law predicts them) told apart, with the line of equality and the RMS difference."""
    from matplotlib.figure import Figure

    components = [c for c in COMPONENTS if prediction.measured(c[0]) is not None]
    ncols = min(3, max(len(components), 1))
    nrows = max(1, math.ceil(len(components) / ncols))
    fig = Figure(figsize=(3.3 * ncols + 0.4, 3.1 * nrows + 0.7), layout="constrained")
    axes = fig.subplots(nrows, ncols, squeeze=False).ravel()
    for ax in axes[max(len(components), 1):]:
        ax.set_axis_off()
    predicted_any = prediction.predicted is not None
    sticking = prediction.predicted.sticking if predicted_any else None
    for ax, (key, words, symbol, unit) in zip(axes, components):
        measured = prediction.measured(key)
        predicted = prediction.prediction(key)
        if predicted is not None:
            for mask, label, colour, marker in ((sticking, "sticks (predicted)", OKABE_ITO["blue"], "o"),
                                                (~sticking, "slides (predicted)", OKABE_ITO["orange"], "s")):
                if np.any(mask):
                    ax.plot(measured[mask], predicted[mask], marker, ms=3.5, color=colour, alpha=0.8, label=label)
            finite = np.isfinite(predicted) & np.isfinite(measured)
            lo = float(min(measured[finite].min(), predicted[finite].min())) if finite.any() else 0.0
            hi = float(max(measured[finite].max(), predicted[finite].max())) if finite.any() else 1.0
            pad = 0.05 * (hi - lo or 1.0)
            ax.plot([lo - pad, hi + pad], [lo - pad, hi + pad], "-", color="0.4", lw=0.8, label="equality")
            rms = float(np.sqrt(np.mean((predicted[finite] - measured[finite]) ** 2))) if finite.any() else math.nan
            ax.set_title(f"RMS difference {rms:.3g} {unit}")
        else:
            ax.text(0.5, 0.5, prediction.note or "no prediction", transform=ax.transAxes, ha="center", va="center",
                    fontsize=7, color="0.4", wrap=True)
        words, symbol = _after(key, words, symbol)
        ax.set_title("\n".join(filter(None, (words, ax.get_title()))), fontsize=9)
        ax.set_xlabel(axis_label("measured", unit, symbol))
        ax.set_ylabel(axis_label("predicted", unit, symbol))
    if not components:
        axes[0].text(0.5, 0.5, "the table has no measured outcome", transform=axes[0].transAxes, ha="center")
        axes[0].set(xlabel=axis_label("measured outcome", "N s"), ylabel=axis_label("predicted outcome", "N s"))
    handles = {}
    for ax in axes:
        for handle, label in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(label, handle)
    if handles:
        fig.legend(list(handles.values()), list(handles), loc="outside lower center", ncols=len(handles))
    fig.suptitle(f"{Path(prediction.impacts.source).name}: predicted against measured, {len(prediction.impacts)} "
                 f"impacts ({prediction.law} law)", fontsize=10)
    return fig


def planar_figures(result, impacts: PlanarImpacts, out_dir: str | os.PathLike[str],
                   staged: StagedFiles | None = None, fmt: str | None = None) -> list[Path]:
    """Write the figures of ``impactid planar fit`` into ``out_dir``, atomically: ``planar_impacts.png``
    (:func:`plot_planar_impacts`) and ``planar_agreement.png`` (:func:`plot_planar_agreement`). ``fmt``: see
    :func:`impactid.plotting.save_figure`."""
    prediction = planar_prediction(result, impacts)
    out = Path(out_dir)
    with staged_transaction(staged) as st:
        return [save_figure_atomic(plot_planar_impacts(prediction), out / "planar_impacts.png", st, fmt),
                save_figure_atomic(plot_planar_agreement(prediction), out / "planar_agreement.png", st, fmt)]

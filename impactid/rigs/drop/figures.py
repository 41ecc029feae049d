"""Figures of the single-impact test rig, as matplotlib figures (never pyplot) in the package's style
(:mod:`impactid.plotting`); :func:`save` writes one atomically (or staged with other outputs). Units
at the edge: ms, mm."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from impactid.plotting import MEASURED, SIMULATED, UNITLESS, axis_label, number, styled

__all__ = ["drop_figure", "fit_figure", "save"]

#: The channels in words: (quantity, symbol, unit) of the axis labels.
_CHANNELS = {"impactor_acceleration": ("impactor acceleration", "a", "m/s$^2$"),
             "contact_force": ("contact force", "F", "N")}


def _channel_words(channel: str) -> str:
    return _CHANNELS.get(channel, (channel.replace("_", " "),))[0]


def _channel_label(channel: str) -> str:
    quantity, symbol, unit = _CHANNELS.get(channel, (channel.replace("_", " "), None, "recorded unit"))
    return axis_label(quantity, unit, symbol)


def _figure(nrows: int, ncols: int, **kwargs):
    """A :class:`matplotlib.figure.Figure` and its axes (a 2-D array), without pyplot."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=kwargs.pop("figsize", (4.0 * ncols, 2.8 * nrows)), layout="constrained")
    axes = fig.subplots(nrows, ncols, squeeze=False, **kwargs)
    return fig, axes


def _chosen(curves: list, count: int) -> list:
    """Up to ``count`` impacts, taking each recording's first impacts in turn."""
    by_source: dict[str, list] = {}
    for curve in curves:
        by_source.setdefault(curve["recording"], []).append(curve)
    chosen: list = []
    depth = 0
    while len(chosen) < count and any(depth < len(v) for v in by_source.values()):
        for items in by_source.values():
            if depth < len(items) and len(chosen) < count:
                chosen.append(items[depth])
        depth += 1
    return chosen


@styled
def fit_figure(fit, *, impacts: int = 4):
    """Measured (dots) and fitted (line) contact signals of up to ``impacts`` impacts of a
    :class:`~impactid.rigs.drop.identify.DropFit`, one column per impact, one row per channel, and the
    residuals in units of each channel's noise below."""
    curves = _chosen(list(fit.details.get("curves", [])), impacts)
    if not curves:
        raise ValueError("the fit has no impact curves to plot")
    channels = list(dict.fromkeys(c for curve in curves for c in curve["channels"]))
    fig, axes = _figure(len(channels) + 1, len(curves), sharex="col")
    for col, curve in enumerate(curves):
        t = np.asarray(curve["time_from_onset_ms"])
        for row, channel in enumerate(channels):
            ax = axes[row, col]
            data = curve["channels"].get(channel)
            if data is None:
                ax.set_axis_off()
                continue
            ax.plot(t, data["measured"], ".", ms=3, color=MEASURED, label="measured")
            ax.plot(t, data["model"], "-", lw=1.2, color=SIMULATED, label="simulation at the fitted law")
            ax.set_ylabel(_channel_label(channel))
            if row == 0:
                ax.set_title(f"{Path(str(curve['recording'])).name}, impact {curve['impact']}", fontsize=9)
            if row == 0 and col == 0:
                ax.legend(fontsize=7)
            res = (np.asarray(data["measured"]) - np.asarray(data["model"])) / data["noise_sd"]
            axes[-1, col].plot(t, res, ".-", ms=2, lw=0.6, label=_channel_words(channel))
        axes[-1, col].axhline(0.0, color="k", lw=0.5)
        axes[-1, col].set_xlabel(axis_label("time from the fitted onset", "ms", "t"))
        axes[-1, col].set_ylabel(f"residual / noise standard deviation {UNITLESS}")
        if col == 0:
            axes[-1, col].legend(fontsize=7)
    k, beta, n = fit.value("k"), fit.value("beta"), fit.value("n")
    fig.suptitle(f"Drop impacts: measured and simulated at the fitted law, $k$ = {number(k)} "
                 f"N/m$^{{{fit.value('p'):g}}}$, " rf"$\beta$ = {number(beta)} N s m$^{{-{n + 1:.3g}}}$, $n$ = {n:.4g}",
                 fontsize=10)
    return fig


@styled
def drop_figure(run, *, impacts: int = 6):
    """A simulated drop (:class:`~impactid.rigs.drop.simulate.DropRun`): the contact force of its first
    ``impacts`` impacts against the time from each onset, and the peak force and restitution against
    the approach speed for all of them."""
    from impactid.rigs.drop.simulate import simulate_drop

    table = run.separated
    fig, axes = _figure(1, 2, figsize=(10.0, 3.8))
    ax = axes[0, 0]
    for i, row in table.head(impacts).iterrows():
        t = np.linspace(0.0, 1.05 * row.contact_duration_s, 400)
        again = simulate_drop(run.rig, run.law, 0.0, release_speed=row.approach_speed_m_s, duration=float(t[-1]),
                              t_eval=t)
        ax.plot(1e3 * t, again.force, label=f"impact {i}: $v_a$ = {row.approach_speed_m_s:.3g} m/s")
    ax.set_xlabel(axis_label("time from the onset", "ms", "t"))
    ax.set_ylabel(axis_label("contact force", "N", "F"))
    ax.legend(fontsize=7, title="simulated impacts")
    ax = axes[0, 1]
    ax.plot(table.approach_speed_m_s, table.restitution, "o-", ms=3, color="C0", label="coefficient of restitution")
    ax.set_xlabel(axis_label("approach speed", "m/s", "v_a"))
    ax.set_ylabel(axis_label("coefficient of restitution", None, "e"), color="C0")
    twin = ax.twinx()
    twin.grid(False)
    twin.spines["right"].set_visible(True)
    twin.plot(table.approach_speed_m_s, table.peak_force_n, "s--", ms=3, color="C1", label="peak contact force")
    twin.set_ylabel(axis_label("peak contact force", "N"), color="C1")
    fig.suptitle(f"Drop of {run.rig.mass:g} kg from {run.height:g} m: {len(table)} bounces", fontsize=10)
    return fig


def save(fig, path: str | os.PathLike[str], staged=None, fmt: str | None = None) -> Path:
    """Write a figure atomically, or staged in ``staged``: PNG at 200 dpi, or SVG or PDF (``fmt``, else
    :func:`impactid.plotting.figure_format`'s; the suffix of ``path`` follows). Returns the path."""
    from impactid.reports import save_figure_atomic

    return save_figure_atomic(fig, path, staged, fmt)

"""Figures of the single-impact test rig, as matplotlib figures (never pyplot); :func:`save` writes one
atomically (or staged with other outputs). Units at the edge: ms, mm."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

__all__ = ["drop_figure", "fit_figure", "save"]

_LABELS = {"impactor_acceleration": "impactor acceleration [m/s^2]", "contact_force": "contact force [N]"}


def _figure(nrows: int, ncols: int, **kwargs):
    """A :class:`matplotlib.figure.Figure` and its axes (a 2-D array), without pyplot."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=kwargs.pop("figsize", (4.0 * ncols, 2.8 * nrows)), constrained_layout=True)
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
            ax.plot(t, data["measured"], ".", ms=3, color="0.3", label="measured")
            ax.plot(t, data["model"], "-", lw=1.2, color="C3", label="simulated (fitted contact)")
            ax.set_ylabel(_LABELS.get(channel, channel) if col == 0 else "")
            ax.grid(True, alpha=0.3)
            if row == 0:
                ax.set_title(f"{Path(str(curve['recording'])).name}, impact {curve['impact']}", fontsize=9)
            if row == 0 and col == 0:
                ax.legend(fontsize=7)
            res = (np.asarray(data["measured"]) - np.asarray(data["model"])) / data["noise_sd"]
            axes[-1, col].plot(t, res, ".-", ms=2, lw=0.6, label=channel.replace("_", " "))
        axes[-1, col].axhline(0.0, color="k", lw=0.5)
        axes[-1, col].set_xlabel("time from the fitted onset [ms]")
        axes[-1, col].grid(True, alpha=0.3)
        if col == 0:
            axes[-1, col].set_ylabel("residual / noise standard deviation [-]")
            axes[-1, col].legend(fontsize=7)
    k, beta, n = fit.value("k"), fit.value("beta"), fit.value("n")
    fig.suptitle(f"Drop impacts: measured and simulated with k = {k:.4g} N/m^{fit.value('p'):g}, "
                 f"beta = {beta:.4g} N s/m^(n+1), n = {n:.4g}", fontsize=10)
    return fig


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
        ax.plot(1e3 * t, again.force, label=f"impact {i}: {row.approach_speed_m_s:.3g} m/s")
    ax.set_xlabel("time from the onset [ms]")
    ax.set_ylabel("contact force [N]")
    ax.legend(fontsize=7)
    ax.grid(True, alpha=0.3)
    ax = axes[0, 1]
    ax.plot(table.approach_speed_m_s, table.restitution, "o-", ms=3, color="C0")
    ax.set_xlabel("approach speed [m/s]")
    ax.set_ylabel("coefficient of restitution [-]", color="C0")
    ax.grid(True, alpha=0.3)
    twin = ax.twinx()
    twin.plot(table.approach_speed_m_s, table.peak_force_n, "s--", ms=3, color="C1")
    twin.set_ylabel("peak contact force [N]", color="C1")
    fig.suptitle(f"Drop of {run.rig.mass:g} kg from {run.height:g} m: {len(table)} bounces", fontsize=10)
    return fig


def save(fig, path: str | os.PathLike[str], staged=None) -> Path:
    """Write a figure (PNG) atomically, or staged in ``staged``."""
    from impactid.reports import save_figure_atomic

    return save_figure_atomic(fig, path, staged, dpi=110)

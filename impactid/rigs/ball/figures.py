"""Figures of a bounce analysis (each a :class:`matplotlib.figure.Figure` built directly, never
through pyplot, so that nothing global is touched):

* :func:`plot_restitution`: e against impact speed, every fitted law with its confidence band;
* :func:`plot_intervals`: the intervals of every drop against their number, rejected ones marked
  by their flag;
* :func:`plot_onsets`: for audio, the envelope with the threshold and the detected onsets.

:func:`write_figures` saves them (PNG) through a :class:`~impactid._files.StagedFiles` transaction.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

__all__ = ["plot_intervals", "plot_onsets", "plot_restitution", "write_figures"]

_FLAG_STYLE = {
    "ok": dict(marker="o", color="#4c72b0", ms=4),
    "first": dict(marker="o", color="#4c72b0", ms=4, mfc="none"),
    "anomalous": dict(marker="D", color="#dd8452", ms=6),
    "missed": dict(marker="X", color="#c44e52", ms=8),
    "echo": dict(marker="v", color="#8172b3", ms=7),
    "spurious": dict(marker="^", color="#8172b3", ms=7),
    "displaced": dict(marker="P", color="#937860", ms=7),
    "release": dict(marker="s", color="#7f7f7f", ms=6),
    "end": dict(marker="s", color="#7f7f7f", ms=6, mfc="none"),
    "refused": dict(marker="x", color="#000000", ms=6),
}
_LAW_COLOURS = {"constant": "#55a868", "linear": "#c44e52", "viscoelastic": "#8172b3"}


def _new_figure(size=(7.0, 4.5)):
    from matplotlib.figure import Figure

    return Figure(figsize=size, constrained_layout=True)


def plot_restitution(result, ax=None, laws=None):
    """e against impact speed: the used coefficients (filled), the odd bounces (open), and each
    fitted law with its confidence band (the selected law drawn thicker)."""
    fig = None
    if ax is None:
        fig = _new_figure()
        ax = fig.add_subplot()
    table = result.bounces
    has_e = table[np.isfinite(table["e"].astype(float))]
    used = has_e[has_e["used"].astype(bool)]
    odd = has_e[~has_e["used"].astype(bool)]
    ax.plot(used["impact_speed_m_s"], used["e"], "o", ms=3.5, color="#4c72b0", alpha=0.7,
            label=f"per impact ({len(used)} used)")
    if len(odd):
        ax.plot(odd["impact_speed_m_s"], odd["e"], "D", ms=5, mfc="none", color="#dd8452",
                label=f"odd bounces, not used ({len(odd)})")
    fits = result.law_fits
    selected = result.selected
    for name, fit in fits.items():
        if laws is not None and name not in laws:
            continue
        lo, hi = fit.details["speed_range"]
        v = np.linspace(lo, hi, 200)
        mean, low, high = fit.predict(v)
        colour = _LAW_COLOURS.get(name, None)
        label = f"{name}: " + ", ".join(f"{p.name} = {p.value:.4g} +/- {p.stderr:.2g}" for p in fit.params.values())
        line = ax.plot(v, mean, color=colour, lw=2.5 if name == selected else 1.2,
                       label=label + (" (selected)" if name == selected else ""))[0]
        ax.fill_between(v, low, high, color=line.get_color(), alpha=0.18, lw=0)
    flight = result.details.get("flight", {}).get("label", "")
    ax.set_xlabel("impact speed v [m/s]")
    ax.set_ylabel("coefficient of restitution e [-]")
    ax.set_title(f"Restitution from bounce timing ({flight}; bands: "
                 f"{100 * next(iter(fits.values()))[next(iter(next(iter(fits.values())).params))].confidence:.0f} %)",
                 fontsize=9)
    if len(used):
        q = np.nanpercentile(used["e"], [1, 99])
        pad = 0.6 * (q[1] - q[0]) + 1e-3
        ax.set_ylim(q[0] - pad, q[1] + pad)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, loc="best")
    return fig if fig is not None else ax.figure


def plot_intervals(result, ax=None, max_drops: int = 40):
    """Intervals against their number in each drop (one line per drop), every interval marked by
    its flag (legend); the rejected ones stand out."""
    fig = None
    if ax is None:
        fig = _new_figure((7.5, 4.8))
        ax = fig.add_subplot()
    table = result.bounces
    drops = list(dict.fromkeys(table["drop"].tolist()))[:max_drops]
    seen = set()
    for d in drops:
        rows = table[table["drop"] == d]
        ax.plot(rows["index"], rows["interval_s"], "-", color="#bbbbbb", lw=0.8, zorder=1)
        for flag, style in _FLAG_STYLE.items():
            sel = rows[rows["flag"] == flag]
            if len(sel):
                ax.plot(sel["index"], sel["interval_s"], ls="none", zorder=2,
                        label=None if flag in seen else f"{flag} ({int((table['flag'] == flag).sum())})", **style)
                seen.add(flag)
    ax.set_xlabel("interval number in the file")
    ax.set_ylabel("interval between triggers [s]")
    ax.set_title(f"{len(drops)} drop(s): every interval and its flag", fontsize=9)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    return fig if fig is not None else ax.figure


def plot_onsets(recording, ax=None):
    """The envelope of an audio recording with the threshold, the onsets (coloured by confidence)
    and the suppressed triggers."""
    onsets = recording.onsets
    if onsets is None:
        raise ValueError(f"{recording.name}: not an audio recording (no onsets)")
    fig = None
    if ax is None:
        fig = _new_figure((8.0, 3.8))
        ax = fig.add_subplot()
    env = np.asarray(onsets.envelope)
    t = np.arange(env.size) / onsets.envelope_rate
    ax.semilogy(t, np.maximum(env, onsets.noise_floor * 1e-2), color="#4c72b0", lw=0.6,
                label="envelope (RMS, band-passed)")
    ax.axhline(onsets.threshold, color="#c44e52", ls="--", lw=1, label=f"threshold {onsets.threshold:.2g}")
    ax.axhline(max(onsets.noise_floor, 1e-12), color="#7f7f7f", ls=":", lw=1, label="noise floor (median)")
    for time, conf in zip(onsets.times, onsets.confidence):
        ax.axvline(time, color=(0.2, 0.6 * conf + 0.2, 0.2), lw=0.8, alpha=0.8)
    if onsets.suppressed.size:
        ax.plot(onsets.suppressed, np.full(onsets.suppressed.size, onsets.threshold), "v", color="#8172b3", ms=5,
                label=f"suppressed (ring-down/echo): {onsets.suppressed.size}")
    ax.plot([], [], color="#339933", lw=0.8, label=f"{onsets.times.size} onsets (shade: confidence)")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("envelope [full scale]")
    ax.set_title(f"{recording.name}: refractory {1e3 * onsets.refractory:.3g} ms", fontsize=9)
    ax.legend(fontsize=7, loc="upper right")
    return fig if fig is not None else ax.figure


def _safe(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]+", "_", Path(name).stem).strip("_") or "recording"


def figure_names(result, recordings=()) -> list[str]:
    """File names :func:`write_figures` writes."""
    names = ["restitution.png", "intervals.png"]
    names += [f"onsets_{_safe(r.name)}.png" for r in recordings if getattr(r, "onsets", None) is not None]
    return names


def write_figures(result, folder: str | os.PathLike[str], staged, recordings=()) -> list[Path]:
    """Save the figures of ``result`` (and the onset figures of audio ``recordings``) as PNG files
    in ``folder``, staged in the :class:`~impactid._files.StagedFiles` transaction ``staged``."""
    folder = Path(folder)
    out = []
    figures = [("restitution.png", plot_restitution(result)), ("intervals.png", plot_intervals(result))]
    figures += [(f"onsets_{_safe(r.name)}.png", plot_onsets(r)) for r in recordings
                if getattr(r, "onsets", None) is not None]
    for name, fig in figures:
        out.append(staged.write_with(folder / name, lambda tmp, fig=fig: fig.savefig(tmp, format="png", dpi=120)))
    return out

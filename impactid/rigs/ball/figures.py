"""Figures of a bounce analysis (each a :class:`matplotlib.figure.Figure` built directly, never
through pyplot, so that nothing global is touched), in the package's style
(:mod:`impactid.plotting`):

* :func:`plot_restitution`: e against impact speed, one colour and marker per drop, every fitted
  law with its confidence band;
* :func:`plot_intervals`: the intervals of every drop (one colour per drop) against their number,
  rejected ones marked by their flag;
* :func:`plot_onsets`: for audio, the waveform with the accepted onsets and the rejected clicks
  (by reason), and the envelope with the sliding threshold.

:func:`write_figures` saves them (PNG at 200 dpi, or SVG or PDF) through a
:class:`~impactid._files.StagedFiles` transaction.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

from impactid.plotting import CYCLE, OKABE_ITO, axis_label, figure_name, save_figure, styled

__all__ = ["plot_intervals", "plot_onsets", "plot_restitution", "write_figures"]

#: How each interval's flag is marked (shape; black edge, the drop's colour inside where filled).
_FLAG_STYLE = {
    "ok": dict(marker="o", ms=4),
    "first": dict(marker="o", ms=4, mfc="white"),
    "anomalous": dict(marker="D", ms=6, mec="black"),
    "missed": dict(marker="X", ms=8, mec="black"),
    "echo": dict(marker="v", ms=7, mec="black"),
    "spurious": dict(marker="^", ms=7, mec="black"),
    "displaced": dict(marker="P", ms=7, mec="black"),
    "release": dict(marker="s", ms=6, mec="black"),
    "end": dict(marker="s", ms=6, mfc="white", mec="black"),
    "refused": dict(marker="x", ms=6, mec="black"),
}
#: The flags in words (legend).
_FLAG_WORDS = {"ok": "used", "first": "first interval", "anomalous": "anomalous", "missed": "missed impact",
               "echo": "echo", "spurious": "spurious trigger", "displaced": "displaced trigger",
               "release": "release", "end": "end of the drop", "refused": "drop refused"}
_LAW_COLOURS = {"constant": OKABE_ITO["green"], "linear": OKABE_ITO["vermillion"],
                "viscoelastic": OKABE_ITO["reddish purple"]}
#: The laws in the words and symbols of docs/bounces.md.
_LAW_WORDS = {"constant": r"constant law $e = e_0$", "linear": r"linear law $e = e_0 - \gamma v$",
              "viscoelastic": r"viscoelastic law $e = 1 - a v^{1/5}$"}
#: The laws' parameters in mathtext, with their units.
_PARAM_WORDS = {"e": ("$e_0$", ""), "e0": ("$e_0$", ""), "gamma": (r"$\gamma$", " s/m"),
                "a": ("$a$", " (s/m)$^{1/5}$")}
#: Markers of the drops (with the colours of :data:`impactid.plotting.CYCLE`: 56 combinations).
_DROP_MARKERS = ("o", "s", "^", "D", "v", "P", "X")
#: Drops named in a legend (the others are drawn, not named).
LEGEND_DROPS = 10


def _drop_style(k: int) -> dict:
    """Colour and marker of the ``k``-th drop."""
    return {"color": CYCLE[k % len(CYCLE)], "marker": _DROP_MARKERS[k % len(_DROP_MARKERS)]}


def _drop_label(table, drop, k: int) -> str | None:
    """Legend label of a drop: its number and file (None beyond :data:`LEGEND_DROPS`)."""
    if k >= LEGEND_DROPS:
        return None
    files = table.loc[table["drop"] == drop, "file"] if "file" in table else []
    name = Path(str(files.iloc[0])).name if len(files) else ""
    return f"drop {drop}" + (f" ({name})" if name and name != f"drop {drop}" else "")


def _new_figure(size=(7.0, 4.5)):
    from matplotlib.figure import Figure

    return Figure(figsize=size, layout="constrained")


def _law_label(name: str, fit) -> str:
    parts = []
    for p in fit.params.values():
        symbol, unit = _PARAM_WORDS.get(p.name, (p.name.replace("_", " "), ""))
        parts.append(f"{symbol} = {p.value:.4g} ± {p.stderr:.2g}{unit}")
    return f"{_LAW_WORDS.get(name, name + ' law')}: " + ", ".join(parts)


@styled
def plot_restitution(result, ax=None, laws=None):
    """e against impact speed: the used coefficients (filled, one colour and marker per drop), the
    odd bounces (open grey), and each fitted law with its confidence band (the selected law drawn
    thicker)."""
    fig = None
    if ax is None:
        fig = _new_figure((7.5, 4.8))
        ax = fig.add_subplot()
    table = result.bounces
    has_e = table[np.isfinite(table["e"].astype(float))]
    used = has_e[has_e["used"].astype(bool)]
    odd = has_e[~has_e["used"].astype(bool)]
    drops = list(dict.fromkeys(table["drop"].tolist()))
    for k, d in enumerate(drops):
        sel = used[used["drop"] == d]
        if len(sel):
            ax.plot(sel["impact_speed_m_s"], sel["e"], ls="none", ms=4, alpha=0.8, label=_drop_label(table, d, k),
                    **_drop_style(k))
    if len(odd):
        ax.plot(odd["impact_speed_m_s"], odd["e"], "D", ms=5, mfc="none", color="0.45",
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
        label = _law_label(name, fit)
        line = ax.plot(v, mean, color=colour, lw=2.5 if name == selected else 1.2,
                       label=label + (" (selected)" if name == selected else ""))[0]
        ax.fill_between(v, low, high, color=line.get_color(), alpha=0.18, lw=0)
    flight = result.details.get("flight", {}).get("label", "")
    ax.set_xlabel(axis_label("impact speed", "m/s", "v"))
    ax.set_ylabel(axis_label("coefficient of restitution", None, "e"))
    ax.set_title(f"Restitution from bounce timing ({flight}; bands: "
                 f"{100 * next(iter(fits.values()))[next(iter(next(iter(fits.values())).params))].confidence:.0f} %"
                 f"; {len(used)} impacts used of {len(drops)} drop(s))")
    if len(used):
        q = np.nanpercentile(used["e"], [1, 99])
        pad = 0.6 * (q[1] - q[0]) + 1e-3
        ax.set_ylim(q[0] - pad, q[1] + pad)
    ax.legend(fontsize=7, loc="best", ncol=2 if len(drops) > 4 else 1)
    return fig if fig is not None else ax.figure


@styled
def plot_intervals(result, ax=None, max_drops: int = 40):
    """Intervals against their number in each drop: one colour per drop (a line through its
    intervals; legend), every interval marked by its flag (a second legend); the rejected ones stand
    out."""
    from matplotlib.lines import Line2D

    fig = None
    if ax is None:
        fig = _new_figure((7.5, 4.8))
        ax = fig.add_subplot()
    table = result.bounces
    drops = list(dict.fromkeys(table["drop"].tolist()))[:max_drops]
    seen: dict[str, dict] = {}
    for k, d in enumerate(drops):
        rows = table[table["drop"] == d]
        colour = _drop_style(k)["color"]
        ax.plot(rows["index"], rows["interval_s"], "-", color=colour, lw=0.9, zorder=1,
                label=_drop_label(table, d, k))
        for flag, style_ in _FLAG_STYLE.items():
            sel = rows[rows["flag"] == flag]
            if len(sel):
                ax.plot(sel["index"], sel["interval_s"], ls="none", zorder=2, color=colour,
                        **{"mec": colour, **style_})
                seen.setdefault(flag, style_)
    drop_legend = ax.legend(title="drop", fontsize=7, loc="upper right", ncol=2 if len(drops) > 5 else 1)
    handles = [Line2D([], [], ls="none", color="0.3", **{"mec": "0.3", **style_},
                      label=f"{_FLAG_WORDS.get(flag, flag)} ({int((table['flag'] == flag).sum())})")
               for flag, style_ in seen.items()]
    if handles:
        ax.legend(handles=handles, title="interval", fontsize=7, loc="lower left", ncol=2)
        ax.add_artist(drop_legend)
    ax.set_xlabel(axis_label("interval number in the file", None))
    ax.set_ylabel(axis_label("interval between triggers", "s"))
    ax.set_title(f"{len(drops)} drop(s): every interval and its flag")
    return fig if fig is not None else ax.figure


#: How the rejected clicks of audio are marked, by reason (marker, colour).
_REJECTED_STYLE = {"contact": ("v", OKABE_ITO["orange"]), "echo": ("^", OKABE_ITO["reddish purple"]),
                   "ringing": ("x", OKABE_ITO["sky blue"])}
#: The rejection reasons in words (legend).
_REJECTED_WORDS = {"contact": "further click of the same contact", "echo": "echo (recurring delay)",
                   "ringing": "ringing (much weaker, within the ringing time)"}


@styled
def plot_onsets(recording, ax=None):
    """The waveform of an audio recording with the accepted onsets and the rejected clicks (marked by
    the reason they were rejected), and below it the envelope with the sliding threshold. ``ax``:
    two axes (waveform, envelope), or None for a new figure."""
    onsets = recording.onsets
    if onsets is None:
        raise ValueError(f"{recording.name}: not an audio recording (no onsets)")
    fig = None
    if ax is None:
        fig = _new_figure((8.5, 5.5))
        ax = fig.subplots(2, 1, sharex=True, height_ratios=(3, 2))
    top, bottom = ax
    rate = onsets.envelope_rate
    wave = np.asarray(onsets.waveform)
    if wave.size:
        tw = np.arange(wave.shape[0]) / rate
        top.fill_between(tw, wave[:, 0], wave[:, 1], color=OKABE_ITO["blue"], lw=0, alpha=0.7,
                         label="waveform (lowest and highest sample per "
                               f"{1e3 / rate:.2g} ms{', channels averaged' if onsets.channel == 'mix' else ''})")
    height = float(np.max(np.abs(wave))) if wave.size else 1.0
    for k, time in enumerate(onsets.times):
        top.axvline(time, color=OKABE_ITO["green"], lw=0.9, label=f"{onsets.times.size} impacts (onsets)" if k == 0
                    else None)
    reasons = np.array(onsets.rejected_reasons, dtype=object)
    for reason, (marker, colour) in _REJECTED_STYLE.items():
        sel = reasons == reason
        if np.any(sel):
            top.plot(onsets.rejected[sel], np.full(int(sel.sum()), 1.05 * height), marker, color=colour, ms=5,
                     ls="none", label=f"rejected: {_REJECTED_WORDS[reason]} ({int(sel.sum())})")
    top.set_ylabel(axis_label("sound pressure", "full scale"))
    top.set_ylim(-1.15 * height, 1.2 * height)
    top.legend(fontsize=7, loc="lower right", ncol=2)
    env = np.asarray(onsets.envelope)
    t = np.arange(env.size) / rate
    bottom.semilogy(t, np.maximum(env, onsets.noise_floor * 1e-2), color=OKABE_ITO["blue"], lw=0.6,
                    label="envelope (RMS, band-passed)")
    curve = np.asarray(onsets.threshold_curve)
    if curve.size:
        bottom.plot(np.arange(curve.size) / rate, curve, color=OKABE_ITO["vermillion"], ls="--", lw=1,
                    label="threshold (sliding median + k MAD)")
    else:
        bottom.axhline(onsets.threshold, color=OKABE_ITO["vermillion"], ls="--", lw=1, label="threshold")
    bottom.plot(onsets.times, np.asarray(onsets.peak), "o", color=OKABE_ITO["green"], ms=3, label="impact peaks")
    bottom.set_xlabel(axis_label("time", "s", "t"))
    bottom.set_ylabel(axis_label("envelope", "full scale"))
    bottom.legend(fontsize=7, loc="upper right")
    echoes = ", ".join(f"{1e3 * d:.3g}" for d in onsets.echo_delays)
    top.set_title(f"{recording.name}: refractory time {1e3 * onsets.refractory:.3g} ms, ringing time "
                  f"{1e3 * onsets.ring_down:.3g} ms" + (f", echoes at {echoes} ms" if echoes else ""))
    return fig if fig is not None else top.figure


def _safe(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]+", "_", Path(name).stem).strip("_") or "recording"


def figure_names(result, recordings=(), fmt: str | None = None) -> list[str]:
    """File names :func:`write_figures` writes (the suffix of ``fmt``, else of the current
    :func:`impactid.plotting.figure_format`, else ``.png``)."""
    names = ["restitution.png", "intervals.png"]
    names += [f"onsets_{_safe(r.name)}.png" for r in recordings if getattr(r, "onsets", None) is not None]
    return [figure_name(name, fmt) for name in names]


def write_figures(result, folder: str | os.PathLike[str], staged, recordings=(), fmt: str | None = None) -> list[Path]:
    """Save the figures of ``result`` (and the onset figures of audio ``recordings``) in ``folder``,
    staged in the :class:`~impactid._files.StagedFiles` transaction ``staged``: PNG at 200 dpi, or
    SVG or PDF (``fmt``, else :func:`impactid.plotting.figure_format`'s; the names' suffix follows)."""
    folder = Path(folder)
    out = []
    figures = [("restitution.png", plot_restitution(result)), ("intervals.png", plot_intervals(result))]
    figures += [(f"onsets_{_safe(r.name)}.png", plot_onsets(r)) for r in recordings
                if getattr(r, "onsets", None) is not None]
    for name, fig in figures:
        out.append(save_figure(fig, folder / name, staged, fmt))
    return out

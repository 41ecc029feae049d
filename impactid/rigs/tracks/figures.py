"""Figures of a track analysis (:class:`matplotlib.figure.Figure` objects, never pyplot state), in the
package's style (:mod:`impactid.plotting`):

* :func:`restitution_figure`: per bounce, the normal restitution against the normal impact speed
  (with the fitted normal laws and the table-tennis rule's band) and against the incoming spin, and
  the tangential velocity ratio against the contact point's slip over the normal speed (with the
  fitted tangential laws' predictions);
* :func:`track_figure`: one track's height with the fitted flights of its analysed bounces.

:func:`write_figures` saves them through a :class:`~impactid._files.StagedFiles` transaction.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

from impactid.plotting import OKABE_ITO, axis_label, figure_name, new_figure, save_figure, styled
from impactid.rigs.tracks.flight import flight_positions
from impactid.rigs.tracks.parameters import TrackedBall

__all__ = ["figure_names", "restitution_figure", "track_figure", "write_figures"]


def _errorbars(ax, x, y, lo, hi, **style):
    ax.errorbar(x, y, yerr=[y - lo, hi - y], fmt="o", ms=3.5, lw=0.8, capsize=0, **style)


@styled
def restitution_figure(result, **_):
    """Three panels: ``e_n`` against ``v_n`` and against ``|omega_in|``, ``beta_t`` against ``|u_t,in| / v_n``."""
    fig, axes = new_figure(1, 3, size=(13.0, 4.2))
    ax1, ax2, ax3 = axes[0]
    table = result.tables["bounces"]
    used = table[table["analysed"]]
    v, e = used["vn_in_m_s"].to_numpy(float), used["e_n"].to_numpy(float)
    lo, hi = used["e_n_low"].to_numpy(float), used["e_n_high"].to_numpy(float)
    rule = result.details.get("rule")
    if rule:
        for ax in (ax1, ax2):
            ax.axhspan(rule["e_low"], rule["e_high"], color=OKABE_ITO["sky blue"], alpha=0.25, lw=0,
                       label=f"rule: {rule['rebound_heights_m'][0] * 100:g}-{rule['rebound_heights_m'][1] * 100:g} cm "
                             f"from {rule['drop_height_m'] * 100:g} cm")
    _errorbars(ax1, v, e, lo, hi, color=OKABE_ITO["blue"], label="bounces")
    grid = np.linspace(max(0.0, v.min() - 0.2), v.max() + 0.2, 50) if v.size else np.linspace(0, 1, 2)
    for name, colour in (("constant", OKABE_ITO["green"]), ("linear", OKABE_ITO["vermillion"])):
        if name == "constant" and "normal.constant.e" in result.params:
            ax1.plot(grid, np.full_like(grid, result.params["normal.constant.e"].value), color=colour,
                     label="constant law" + (" (selected)" if result.details["selected"].get("normal") == name else ""))
        if name == "linear" and "normal.linear.e0" in result.params:
            e0, g = result.params["normal.linear.e0"].value, result.params["normal.linear.gamma"].value
            ax1.plot(grid, e0 - g * grid, color=colour, ls="--",
                     label="linear law" + (" (selected)" if result.details["selected"].get("normal") == name else ""))
    band = result.details.get("speed_band")
    if band and "e_n_speed_band" in result.params:
        p = result.params["e_n_speed_band"]
        ax1.errorbar([0.5 * (band[0] + band[1])], [p.value], xerr=[[0.5 * (band[1] - band[0])]],
                     yerr=[[p.value - p.interval[0]], [p.interval[1] - p.value]], fmt="s", color="black", ms=6,
                     capsize=3, label=f"{band[0]:g}-{band[1]:g} m/s")
    ax1.set_xlabel(axis_label("normal impact speed", "m/s", "v_n"))
    ax1.set_ylabel(axis_label("normal restitution", None, "e_n"))
    ax1.legend(fontsize=7, loc="lower left")
    spin = used["spin_in_rad_s"].to_numpy(float)
    if np.any(np.isfinite(spin)):
        _errorbars(ax2, spin, e, lo, hi, color=OKABE_ITO["blue"])
        ax2.set_xlabel(axis_label("incoming spin", "rad/s", r"|\omega_{in}|"))
    else:
        ax2.text(0.5, 0.5, "spin not known", ha="center", va="center", transform=ax2.transAxes)
    ax2.set_ylabel(axis_label("normal restitution", None, "e_n"))
    slip = used["ut_in_m_s"].to_numpy(float) / v
    beta, blo, bhi = (used[k].to_numpy(float) for k in ("beta_t", "beta_t_low", "beta_t_high"))
    _errorbars(ax3, slip, beta, blo, bhi, color=OKABE_ITO["orange"], label="bounces")
    if "tangential.ratio.beta" in result.params:
        ax3.axhline(result.params["tangential.ratio.beta"].value, color=OKABE_ITO["green"], label="ratio law")
    ax3.set_xlabel(axis_label("slip of the contact point over the normal speed", None, r"|u_{t,in}| / v_n"))
    ax3.set_ylabel(axis_label("tangential velocity ratio", None, r"\beta_t"))
    ax3.legend(fontsize=7)
    return fig


@styled
def track_figure(track, fits=(), **_):
    """The height of ``track`` against time with the fitted flights of ``fits`` (:class:`BounceFit`)."""
    fig, axes = new_figure(1, 1, size=(7.0, 4.0))
    ax = axes[0, 0]
    ax.plot(track.time, track.height, ".", color=OKABE_ITO["blue"], ms=4, label="track")
    for fit in fits:
        d, v = fit.details, fit.values
        ball = TrackedBall.from_mapping(d["ball"])
        samples = np.asarray(d["samples"])
        tc = v["t_c"]
        pc = np.array([[v["x_c"], v["y_c"], v["z_c"]]])
        for side, vel, spin in (("before", d["v_in"], d["spin_in"]), ("after", d["v_out"], d["spin_out"])):
            ts = track.time[samples]
            ts = ts[ts < tc] if side == "before" else ts[ts >= tc]
            if ts.size == 0:
                continue
            grid = np.linspace(ts.min(), tc, 40)[::-1] if side == "before" else np.linspace(tc, ts.max(), 40)
            pos = flight_positions(pc, np.array([vel]), np.array([tc]), grid, ball,
                                   np.nan_to_num(np.array(spin, dtype=float)))[0]  # unknown: fitted without
            ax.plot(grid, pos[:, 2], color=OKABE_ITO["vermillion"], lw=1)
    ax.set_xlabel(axis_label("time", "s", "t"))
    ax.set_ylabel(axis_label("height of the ball's centre", "m", "z"))
    return fig


def _safe(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]+", "_", name).strip("_") or "track"


def figure_names(result, fmt: str | None = None) -> list[str]:
    """The file names :func:`write_figures` writes."""
    return [figure_name("tracks_restitution.png", fmt)]


def write_figures(result, folder: str | os.PathLike[str], staged, fmt: str | None = None) -> list[Path]:
    """Save the figures of ``result`` in ``folder``, staged in ``staged``."""
    return [save_figure(restitution_figure(result), Path(folder) / "tracks_restitution.png", staged, fmt)]

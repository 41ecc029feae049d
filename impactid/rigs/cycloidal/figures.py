"""Figures of the cycloidal-cam valve train (the paper's Figs. 2-7, jump speed, identification).

Every function returns a :class:`matplotlib.figure.Figure` made with ``Figure()`` (no pyplot, no
backend switching) in the package's style (:mod:`impactid.plotting`). Units at this edge: cam angle in
degrees, film in micrometres, pressure in GPa. Steps where the film formula is outside Table 3's
regression ranges are shaded.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from impactid.plotting import MEASURED, OKABE_ITO, SIMULATED, axis_label, save_figure, styled
from impactid.rigs.cycloidal import cam

__all__ = ["CYCLE_FIGURES", "cycle_figure", "entraining_figure", "film_figure", "hertz_figure", "jump_figure",
           "kinematics_figure", "load_figure", "squeeze_figure", "surge_fit_figure", "write_cycle_figures"]


def _figure(rows: int = 1, cols: int = 1, size=(7.5, 4.2), sharex=True):
    from matplotlib.figure import Figure

    fig = Figure(figsize=size, layout="constrained")  # called within impactid.plotting.style
    axes = fig.subplots(rows, cols, sharex=sharex, squeeze=False)
    return fig, axes


def _event_axis(ax, rig) -> None:
    ax.set_xlim(0.0, 360.0)
    ax.set_xticks(np.arange(0, 361, 45))
    for a in (math.degrees(rig.rise_start), 180.0, math.degrees(rig.return_end)):
        ax.axvline(a, color="0.85", lw=0.8, zorder=0)


_CAM_ANGLE = axis_label("cam angle", "deg", r"\psi")


def _shade_outside(ax, result) -> None:
    """Shade the steps where any group of (R-10) is outside Table 3."""
    out = ~result.inside
    deg = np.degrees(result.psi)
    step = 360.0 / result.psi.size
    start = None
    for i, flag in enumerate(np.append(out, False)):
        if flag and start is None:
            start = i
        elif not flag and start is not None:
            ax.axvspan(deg[start] - 0.5 * step, deg[i - 1] + 0.5 * step, color=OKABE_ITO["vermillion"], alpha=0.1,
                       lw=0)
            start = None


@styled
def kinematics_figure(rig):
    """Fig. 2: lift, velocity and acceleration of the cycloidal law (per radian of cam angle), and the
    jerk with its jump (the cusp of the acceleration) at the nose."""
    psi = np.linspace(0.0, 2.0 * math.pi, 3601)
    s, s1, s2, s3 = cam.lift(psi, rig.S, rig.beta)
    fig, axes = _figure(4, 1, size=(7.0, 7.5))
    deg = np.degrees(psi)
    for ax, y, label in zip(axes[:, 0], (s * 1e3, s1 * 1e3, s2 * 1e3, s3 * 1e3),
                            (axis_label("lift", "mm", "s"), axis_label("first derivative", "mm/rad", "s'"),
                             axis_label("second derivative", "mm/rad$^2$", "s''"),
                             axis_label("third derivative", "mm/rad$^3$", "s'''"))):
        ax.plot(deg, y, color="C0")
        ax.set_ylabel(label)
        _event_axis(ax, rig)
    axes[-1, 0].set_xlabel(axis_label("cam angle (nose at 180°)", "deg", r"\psi"))
    axes[0, 0].set_title("Cycloidal lift and its derivatives with respect to the cam angle")
    return fig


@styled
def entraining_figure(rig, rpms: Sequence[float] = (600.0, 1000.0, 3000.0)):
    """Fig. 3: entraining velocity ``u = (omega/2)(R0 + s + 2 s'')`` at several camshaft speeds, with
    the zero-entrainment angles."""
    psi = np.linspace(0.0, 2.0 * math.pi, 3601)
    fig, axes = _figure()
    ax = axes[0, 0]
    for rpm in rpms:
        ax.plot(np.degrees(psi), cam.entraining_velocity(psi, 2 * math.pi * rpm / 60, rig.S, rig.beta, rig.R0),
                label=f"{rpm:g} rpm")
    for z in np.degrees(cam.zero_entrainment_angles(rig.S, rig.beta, rig.R0)):
        ax.axvline(z, color="k", ls=":", lw=0.8)
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set_ylabel(axis_label("entraining velocity", "m/s", "u"))
    ax.set_xlabel(_CAM_ANGLE)
    ax.legend(title="camshaft speed")
    _event_axis(ax, rig)
    ax.set_title("Entraining velocity; dotted: zero entrainment")
    return fig


@styled
def film_figure(results: Sequence, log: bool = True):
    """Figs. 4 and 7: central film thickness around the cycle (one curve per result); steps outside
    the regression ranges of the first result shaded."""
    fig, axes = _figure()
    ax = axes[0, 0]
    for r in results:
        ax.plot(np.degrees(r.psi), r.h * 1e6, label=f"{r.rpm:g} rpm, level {r.level}")
    _shade_outside(ax, results[0])
    if log:
        ax.set_yscale("log")
    ax.set_ylabel(axis_label("central film thickness", "µm", "h_c"))
    ax.set_xlabel(_CAM_ANGLE)
    ax.legend(title="camshaft speed, model level")
    _event_axis(ax, results[0].rig)
    ax.set_title("Elastohydrodynamic film; shaded: film formula outside Table 3")
    return fig


@styled
def load_figure(results: Sequence):
    """Fig. 6: contact load around the cycle at several speeds (``W < 0`` = jump predicted, level A)."""
    fig, axes = _figure()
    ax = axes[0, 0]
    for r in results:
        ax.plot(np.degrees(r.fine_psi), r.fine_W, label=f"{r.rpm:g} rpm, level {r.level}", lw=1.0)
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set_ylabel(axis_label("contact load", "N", "W"))
    ax.set_xlabel(_CAM_ANGLE)
    ax.legend(title="camshaft speed, model level")
    _event_axis(ax, results[0].rig)
    ax.set_title("Contact load")
    return fig


@styled
def squeeze_figure(result):
    """Fig. 5: squeeze velocity ``dh/dt`` (positive = separation) and the squeeze ratio used."""
    fig, axes = _figure(2, 1, size=(7.5, 5.5))
    deg = np.degrees(result.psi)
    axes[0, 0].plot(deg, result.w * 1e3, color="C5")
    axes[0, 0].set_ylabel(axis_label("squeeze velocity", "mm/s", "w"))
    axes[1, 0].plot(deg, result.ws_raw, ".", ms=2, color="0.6", label="as computed")
    axes[1, 0].plot(deg, result.ws, color="C5", lw=1, label=f"used in the film formula (mode: {result.ws_mode})")
    axes[1, 0].axhspan(-0.005, 0.0, color=OKABE_ITO["green"], alpha=0.12, lw=0)
    lim = max(0.02, float(np.nanmax(np.abs(result.ws))) * 1.5)
    axes[1, 0].set_ylim(-lim, lim)
    axes[1, 0].set_ylabel(axis_label("squeeze ratio", None, "w_s^*"))
    axes[1, 0].legend(loc="upper right")
    axes[1, 0].set_xlabel(_CAM_ANGLE)
    for ax in axes[:, 0]:
        _event_axis(ax, result.rig)
    axes[0, 0].set_title(f"Squeeze film, {result.rpm:g} rpm (green band: regression range)")
    return fig


@styled
def hertz_figure(results: Sequence):
    """Maximum Hertz pressure and half-width around the cycle."""
    fig, axes = _figure(2, 1, size=(7.5, 5.5))
    for r in results:
        deg = np.degrees(r.psi)
        axes[0, 0].plot(deg, r.p0 / 1e9, label=f"{r.rpm:g} rpm")
        axes[1, 0].plot(deg, r.b0 * 1e6, label=f"{r.rpm:g} rpm")
    axes[0, 0].set_ylabel(axis_label("maximum Hertz pressure", "GPa", "p_0"))
    axes[1, 0].set_ylabel(axis_label("contact half-width", "µm", "b_0"))
    axes[1, 0].set_xlabel(_CAM_ANGLE)
    axes[0, 0].legend(title="camshaft speed")
    for ax in axes[:, 0]:
        _event_axis(ax, results[0].rig)
    axes[0, 0].set_title("Hertzian line contact")
    return fig


def cycle_figure(result, what: str = "film"):
    """One figure of a :class:`~impactid.rigs.cycloidal.simulate.CycleResult` by name."""
    if what not in CYCLE_FIGURES:
        raise ValueError(f"unknown figure {what!r}; valid: {', '.join(CYCLE_FIGURES)}")
    if what == "entraining":
        return entraining_figure(result.rig, (result.rpm,))
    if what == "squeeze":
        return squeeze_figure(result)
    return CYCLE_FIGURES[what]([result])


#: Figures of one cycle by name.
CYCLE_FIGURES = {"film": film_figure, "load": load_figure, "squeeze": squeeze_figure, "hertz": hertz_figure,
                 "entraining": entraining_figure}


@styled
def jump_figure(rpms, W_min, jump_rpm=None, level: str = "A"):
    """Smallest contact load of the steady cycle against camshaft speed, and the jump speed."""
    fig, axes = _figure()
    ax = axes[0, 0]
    ax.plot(rpms, W_min, "o-", ms=3)
    ax.axhline(0.0, color="k", lw=0.6)
    if jump_rpm is not None and math.isfinite(jump_rpm):
        ax.axvline(jump_rpm, color=OKABE_ITO["vermillion"], ls="--", label=f"jump speed {jump_rpm:.1f} rpm")
        ax.legend()
    ax.set_xlabel(axis_label("camshaft speed", "rpm"))
    ax.set_ylabel(axis_label("smallest contact load over the cycle", "N", r"W_{\min}"))
    ax.set_title(f"Jump speed, model level {level}")
    return fig


#: The channels a surge fit uses, in words (quantity, symbol).
_SURGE_CHANNELS = {"contact_load": ("contact load", "W"), "valve_displacement": ("valve displacement", "s_v")}


@styled
def surge_fit_figure(fit):
    """Measured channel and the simulation at the fitted surge model (means per degree of cam angle)
    of each recording, and the residual."""
    curves = fit.details.get("curves", [])
    unit = fit.details.get("unit", "")
    scale, label = (1e6, "µm") if unit == "m" else (1.0, unit or "SI unit")
    fig, axes = _figure(2, 1, size=(7.5, 5.5))
    for k, c in enumerate(curves):
        a = np.asarray(c["angle_deg"])
        m = np.asarray(c["measured"], dtype=float) * scale
        f = np.asarray(c["model"], dtype=float) * scale
        colour = f"C{k % 8}" if len(curves) > 1 else MEASURED
        axes[0, 0].plot(a, m, ".", ms=3, color=colour, label=f"measured, {c['rpm']:g} rpm")
        axes[0, 0].plot(a, f, lw=1.2, color=SIMULATED if len(curves) == 1 else colour,
                        label=f"simulation at the fitted model, {c['rpm']:g} rpm")
        axes[1, 0].plot(a, m - f, lw=1, color=colour)
    channel = str(fit.statistics.get("channel", ""))
    quantity, symbol = _SURGE_CHANNELS.get(channel, (channel.replace("_", " ") or "measured channel", None))
    axes[0, 0].set_ylabel(axis_label(quantity, label, symbol))
    axes[1, 0].set_ylabel(axis_label("residual (measured minus simulated)", label))
    axes[1, 0].set_xlabel(_CAM_ANGLE)
    axes[0, 0].legend(fontsize=8)
    axes[0, 0].set_title("Valve-spring surge, preload and mass fit (means per degree of cam angle)")
    return fig


def write_cycle_figures(result, folder, staged, extra: Sequence = (), fmt: str | None = None) -> list[Path]:
    """Write the figures of a cycle (and of ``extra`` cycles at other speeds) into ``folder`` through a
    :class:`~impactid._files.StagedFiles` transaction: PNG at 200 dpi, or SVG or PDF (``fmt``, else
    :func:`impactid.plotting.figure_format`'s; see :func:`impactid.plotting.save_figure`); returns
    the final paths."""
    folder = Path(folder)
    everything = [result, *extra]
    figures = {
        "kinematics.png": kinematics_figure(result.rig),
        "entraining.png": entraining_figure(result.rig, sorted({r.rpm for r in everything})),
        "film.png": film_figure(everything),
        "squeeze.png": squeeze_figure(result),
        "load.png": load_figure(everything),
        "hertz.png": hertz_figure(everything),
    }
    paths = []
    for name, fig in figures.items():
        paths.append(save_figure(fig, folder / name, staged, fmt))
    return paths

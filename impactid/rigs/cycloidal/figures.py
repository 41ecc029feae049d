"""Figures of the cycloidal-cam valve train (the paper's Figs. 2-7, jump speed, identification).

Every function returns a :class:`matplotlib.figure.Figure` made with ``Figure()`` (no pyplot, no
backend switching). Units at this edge: cam angle in degrees, film in micrometres, pressure in GPa.
Steps where the film formula is outside Table 3's regression ranges are shaded.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from impactid.rigs.cycloidal import cam

__all__ = ["CYCLE_FIGURES", "cycle_figure", "entraining_figure", "film_figure", "hertz_figure", "jump_figure",
           "kinematics_figure", "load_figure", "squeeze_figure", "surge_fit_figure", "write_cycle_figures"]


def _figure(rows: int = 1, cols: int = 1, size=(7.5, 4.2), sharex=True):
    from matplotlib.figure import Figure

    fig = Figure(figsize=size, layout="constrained")
    axes = fig.subplots(rows, cols, sharex=sharex, squeeze=False)
    return fig, axes


def _event_axis(ax, rig) -> None:
    ax.set_xlim(0.0, 360.0)
    ax.set_xticks(np.arange(0, 361, 45))
    for a in (math.degrees(rig.rise_start), 180.0, math.degrees(rig.return_end)):
        ax.axvline(a, color="0.85", lw=0.8, zorder=0)
    ax.grid(True, alpha=0.3)


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
            ax.axvspan(deg[start] - 0.5 * step, deg[i - 1] + 0.5 * step, color="tab:red", alpha=0.08, lw=0)
            start = None


def kinematics_figure(rig):
    """Fig. 2: lift, velocity and acceleration of the cycloidal law (per radian of cam angle), and the
    jerk with its jump (the cusp of the acceleration) at the nose."""
    psi = np.linspace(0.0, 2.0 * math.pi, 3601)
    s, s1, s2, s3 = cam.lift(psi, rig.S, rig.beta)
    fig, axes = _figure(4, 1, size=(7.0, 7.5))
    deg = np.degrees(psi)
    for ax, y, label in zip(axes[:, 0], (s * 1e3, s1 * 1e3, s2 * 1e3, s3 * 1e3),
                            ("lift s [mm]", "s' [mm/rad]", "s'' [mm/rad²]", "s''' [mm/rad³]")):
        ax.plot(deg, y, color="tab:blue")
        ax.set_ylabel(label)
        _event_axis(ax, rig)
    axes[-1, 0].set_xlabel("cam angle [deg] (nose at 180)")
    axes[0, 0].set_title("Cycloidal lift (R-31) and its derivatives")
    return fig


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
    ax.set_ylabel("entraining velocity u [m/s]")
    ax.set_xlabel("cam angle [deg]")
    ax.legend()
    _event_axis(ax, rig)
    ax.set_title("Entraining velocity; dotted: zero entrainment")
    return fig


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
    ax.set_ylabel("central film thickness h [µm]")
    ax.set_xlabel("cam angle [deg]")
    ax.legend()
    _event_axis(ax, results[0].rig)
    ax.set_title("EHL film (R-10); shaded: formula outside Table 3")
    return fig


def load_figure(results: Sequence):
    """Fig. 6: contact load around the cycle at several speeds (``W < 0`` = jump predicted, level A)."""
    fig, axes = _figure()
    ax = axes[0, 0]
    for r in results:
        ax.plot(np.degrees(r.fine_psi), r.fine_W, label=f"{r.rpm:g} rpm, level {r.level}", lw=1.0)
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set_ylabel("contact load W [N]")
    ax.set_xlabel("cam angle [deg]")
    ax.legend()
    _event_axis(ax, results[0].rig)
    ax.set_title("Contact load")
    return fig


def squeeze_figure(result):
    """Fig. 5: squeeze velocity ``dh/dt`` (positive = separation) and the squeeze ratio used."""
    fig, axes = _figure(2, 1, size=(7.5, 5.5))
    deg = np.degrees(result.psi)
    axes[0, 0].plot(deg, result.w * 1e3, color="tab:purple")
    axes[0, 0].set_ylabel("squeeze velocity w [mm/s]")
    axes[1, 0].plot(deg, result.ws_raw, ".", ms=2, color="0.6", label="w_s* raw")
    axes[1, 0].plot(deg, result.ws, color="tab:purple", lw=1, label=f"w_s* used ({result.ws_mode})")
    axes[1, 0].axhspan(-0.005, 0.0, color="tab:green", alpha=0.1, lw=0)
    lim = max(0.02, float(np.nanmax(np.abs(result.ws))) * 1.5)
    axes[1, 0].set_ylim(-lim, lim)
    axes[1, 0].set_ylabel("squeeze ratio w_s*")
    axes[1, 0].legend(loc="upper right")
    axes[1, 0].set_xlabel("cam angle [deg]")
    for ax in axes[:, 0]:
        _event_axis(ax, result.rig)
    axes[0, 0].set_title(f"Squeeze film, {result.rpm:g} rpm (green band: regression range)")
    return fig


def hertz_figure(results: Sequence):
    """Maximum Hertz pressure and half-width around the cycle."""
    fig, axes = _figure(2, 1, size=(7.5, 5.5))
    for r in results:
        deg = np.degrees(r.psi)
        axes[0, 0].plot(deg, r.p0 / 1e9, label=f"{r.rpm:g} rpm")
        axes[1, 0].plot(deg, r.b0 * 1e6, label=f"{r.rpm:g} rpm")
    axes[0, 0].set_ylabel("max pressure p0 [GPa]")
    axes[1, 0].set_ylabel("half-width b0 [µm]")
    axes[1, 0].set_xlabel("cam angle [deg]")
    axes[0, 0].legend()
    for ax in axes[:, 0]:
        _event_axis(ax, results[0].rig)
    axes[0, 0].set_title("Hertzian line contact (R-6, R-7)")
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


def jump_figure(rpms, W_min, jump_rpm=None, level: str = "A"):
    """Smallest contact load of the steady cycle against camshaft speed, and the jump speed."""
    fig, axes = _figure()
    ax = axes[0, 0]
    ax.plot(rpms, W_min, "o-", ms=3)
    ax.axhline(0.0, color="k", lw=0.6)
    if jump_rpm is not None and math.isfinite(jump_rpm):
        ax.axvline(jump_rpm, color="tab:red", ls="--", label=f"jump {jump_rpm:.1f} rpm")
        ax.legend()
    ax.set_xlabel("camshaft speed [rpm]")
    ax.set_ylabel("smallest contact load [N]")
    ax.grid(True, alpha=0.3)
    ax.set_title(f"Jump speed, level {level}")
    return fig


def surge_fit_figure(fit):
    """Measured channel and fitted model (binned per degree of cam angle) and the residual."""
    curves = fit.details.get("curves", [])
    unit = fit.details.get("unit", "")
    scale, label = (1e6, "µm") if unit == "m" else (1.0, unit)
    fig, axes = _figure(2, 1, size=(7.5, 5.5))
    for c in curves:
        a = np.asarray(c["angle_deg"])
        m = np.asarray(c["measured"], dtype=float) * scale
        f = np.asarray(c["model"], dtype=float) * scale
        axes[0, 0].plot(a, m, ".", ms=3, label=f"measured, {c['rpm']:g} rpm")
        axes[0, 0].plot(a, f, lw=1, label="fitted model")
        axes[1, 0].plot(a, m - f, lw=1)
    axes[0, 0].set_ylabel(f"{fit.statistics.get('channel', '')} [{label}]")
    axes[1, 0].set_ylabel(f"residual [{label}]")
    axes[1, 0].set_xlabel("cam angle [deg]")
    axes[0, 0].legend(fontsize=8)
    for ax in axes[:, 0]:
        ax.grid(True, alpha=0.3)
    axes[0, 0].set_title("Surge, preload and mass fit (per-degree means)")
    return fig


def write_cycle_figures(result, folder, staged, extra: Sequence = ()) -> list[Path]:
    """Write the figures of a cycle (and of ``extra`` cycles at other speeds) as PNG into ``folder``
    through a :class:`~impactid._files.StagedFiles` transaction; returns the final paths."""
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
        paths.append(staged.write_with(folder / name, lambda tmp, fig=fig: fig.savefig(tmp, format="png", dpi=110)))
    return paths

"""Figures of the finger-follower valve train (the paper's Figs. 5, 7, 8 and 9-12), as matplotlib
figures in the package's style (:mod:`impactid.plotting`); :func:`save` writes them atomically (or
staged with other outputs). Units at the edge: mm, µm, deg."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd

from impactid.plotting import OKABE_ITO, axis_label, styled

__all__ = ["plot_cycle", "plot_damping_fit", "plot_leakdown", "plot_lift_fit", "plot_rocker_ratio", "plot_tappet_fit",
           "save"]


def _figure(nrows: int = 1, ncols: int = 1, **kwargs):
    """A :class:`matplotlib.figure.Figure` and its axes, without pyplot (nothing global is touched)."""
    from matplotlib.figure import Figure

    kwargs.pop("constrained_layout", None)
    figure_keys = ("figsize", "dpi")
    fig = Figure(layout="constrained", **{k: v for k, v in kwargs.items() if k in figure_keys})
    return fig, fig.subplots(nrows, ncols, **{k: v for k, v in kwargs.items() if k not in figure_keys})


_BLUE, _GREEN, _VERMILLION = OKABE_ITO["blue"], OKABE_ITO["green"], OKABE_ITO["vermillion"]


@styled
def plot_cycle(table: pd.DataFrame, *, rpm: float, constant_ratio: pd.DataFrame | None = None):
    """Valve lift, velocity, acceleration and the contact forces against cam angle (Figs. 9-12).

    ``table`` is :func:`~impactid.rigs.finger_follower.analysis.cycle_table`; ``constant_ratio`` the
    same for the constant-rocker-ratio train (dashed cam force, Fig. 12's comparison).
    """
    fig, axes = _figure(4, 1, figsize=(7.5, 9.0), sharex=True, constrained_layout=True)
    th = table["cam_angle_deg"].to_numpy()
    order = np.argsort(th)
    th = th[order]

    def col(name, frame=table):
        return frame[name].to_numpy()[order] if frame is table else frame[name].to_numpy()

    axes[0].plot(th, 1e3 * col("Y_v"), color=_BLUE, label="valve lift $Y_v$")
    axes[0].plot(th, 1e3 * col("Y_t") * 10, color=_GREEN, label=r"tappet leak-down $Y_t$ $\times$10")
    axes[0].set_ylabel(axis_label("displacement", "mm"))
    axes[0].legend(fontsize=8)
    axes[1].plot(th, col("Y_v_dot"), color=_BLUE)
    axes[1].set_ylabel(axis_label("valve velocity", "m/s", r"\dot Y_v"))
    axes[2].plot(th, col("Y_v_ddot") / 1e3, color=_BLUE)
    axes[2].set_ylabel(axis_label("valve acceleration", "km/s$^2$", r"\ddot Y_v"))
    for name, colour, label in (("F_fc", _VERMILLION, "cam/follower"), ("F_vf", _BLUE, "follower/valve"),
                                ("F_tf", _GREEN, "tappet/follower")):
        axes[3].plot(th, col(name), color=colour, label=label)
    if constant_ratio is not None:
        o2 = np.argsort(constant_ratio["cam_angle_deg"].to_numpy())
        axes[3].plot(constant_ratio["cam_angle_deg"].to_numpy()[o2], constant_ratio["F_fc"].to_numpy()[o2], "--",
                     color=_VERMILLION, lw=1.0, label="cam/follower, constant rocker ratio")
    axes[3].set_ylabel(axis_label("contact force", "N"))
    axes[3].set_xlabel(axis_label("cam angle from the nose", "deg"))
    axes[3].legend(fontsize=8)
    axes[0].set_title(f"Finger follower with hydraulic lash adjuster, steady state at {rpm:.6g} rpm camshaft")
    axes[3].set_xlim(-120, 120)
    return fig


@styled
def plot_leakdown(frame: pd.DataFrame):
    """Maximum tappet leak-down against camshaft speed (Fig. 8)."""
    fig, ax = _figure(figsize=(6.5, 4.0), constrained_layout=True)
    ax.plot(frame["rpm"], 1e6 * frame["max_tappet_leakdown_m"], "o-")
    ax.set_xlabel(axis_label("camshaft speed", "rpm"))
    ax.set_ylabel(axis_label("maximum tappet leak-down", "µm"))
    ax.set_title("Tappet leak-down against speed (steady state)")
    return fig


@styled
def plot_tappet_fit(fit):
    """Measured (averaged) and fitted tappet motion against cam angle (Fig. 7)."""
    table = fit.tables["cycles"]
    fig, ax = _figure(figsize=(7.0, 4.2), constrained_layout=True)
    for (_, rpm), sel in table.groupby(["recording", "rpm"]):
        o = np.argsort(sel["cam_angle_deg"].to_numpy())
        th = sel["cam_angle_deg"].to_numpy()[o]
        line, = ax.plot(th, 1e6 * sel["measured_m"].to_numpy()[o], ".", ms=2,
                        label=f"measured (cycle average), {rpm:.6g} rpm")
        ax.plot(th, 1e6 * sel["fitted_m"].to_numpy()[o], "-", color=line.get_color(), lw=1.2,
                label=f"simulation at the fitted drag, {rpm:.6g} rpm")
    ax.set_xlabel(axis_label("cam angle from the nose", "deg"))
    ax.set_ylabel(axis_label("tappet leak-down", "µm", "Y_t"))
    a, b = fit.value("alpha"), fit.value("beta")
    ax.set_title(rf"Tappet drag fit: $\alpha$ = {a:.4g}, $\beta$ = {b:.4g}")
    ax.legend(fontsize=8)
    return fig


@styled
def plot_lift_fit(fit):
    """Measured (averaged) and fitted valve lift against cam angle."""
    table = fit.tables["cycle"]
    fig, ax = _figure(figsize=(7.0, 4.2), constrained_layout=True)
    th = table["cam_angle_deg"].to_numpy()
    ax.plot(th, 1e3 * table["measured_m"], ".", ms=2, color="#333333", label="measured (cycle average)")
    ax.plot(th, 1e3 * table["fitted_m"], "-", lw=1.2, color=_VERMILLION, label="fitted lift law")
    ax.set_xlabel(axis_label("cam angle (encoder, nose at 0)", "deg"))
    ax.set_ylabel(axis_label("valve lift", "mm", "Y_v"))
    ax.set_title(f"Cam lift fit: $S_K$ = {1e3 * fit.value('S_K'):.4g} mm")
    ax.legend(fontsize=8)
    return fig


@styled
def plot_rocker_ratio(kinematics):
    """Instantaneous rocker ratio and lever arm against cam angle (Fig. 5)."""
    fig, ax = _figure(figsize=(6.5, 4.0), constrained_layout=True)
    th = np.degrees(kinematics.theta)
    ax.plot(th, kinematics.values["RR"], color=_BLUE)
    ax.set_xlabel(axis_label("cam angle from the nose", "deg"))
    ax.set_ylabel(axis_label("rocker ratio", None))
    ax.set_xlim(-120, 120)
    ax.set_title("Instantaneous rocker ratio")
    return fig


def save(fig, path: str | os.PathLike[str], staged=None, fmt: str | None = None) -> Path:
    """Write a figure atomically, or staged in ``staged``: PNG at 200 dpi, or SVG or PDF (``fmt``, else
    :func:`impactid.plotting.figure_format`'s; the suffix of ``path`` follows). Returns the path."""
    from impactid.reports import save_figure_atomic

    return save_figure_atomic(fig, path, staged, fmt)


#: The valve channels of :func:`plot_damping_fit`: (quantity, symbol, scale to the shown unit, shown unit).
_VALVE_CHANNELS = {"valve_displacement": ("valve lift", "Y_v", 1e3, "mm"),
                   "valve_velocity": ("valve velocity", r"\dot Y_v", 1.0, "m/s"),
                   "contact_load": ("contact load", "F", 1.0, "N")}


@styled
def plot_damping_fit(fit):
    """Measured (cycle average) and simulated valve motion around closure, at the fitted contact and
    spring damping ratios: one panel per channel of a
    :class:`~impactid.rigs.finger_follower.identify.DampingFit` (its table ``cycle``)."""
    table = fit.tables["cycle"]
    channels = [c for c in _VALVE_CHANNELS if f"{c}_measured" in table] or sorted(
        {c.rsplit("_", 1)[0] for c in table.columns if c.endswith("_measured")})
    fig, axes = _figure(len(channels), 1, figsize=(7.0, 2.6 * len(channels) + 0.8), sharex=True, squeeze=False)
    th = table["cam_angle_deg"].to_numpy()
    for ax, c in zip(axes[:, 0], channels):
        quantity, symbol, scale, unit = _VALVE_CHANNELS.get(c, (c.replace("_", " "), None, 1.0, "SI unit"))
        ax.plot(th, scale * table[f"{c}_measured"].to_numpy(), ".", ms=2.5, color="#333333",
                label="measured (cycle average)")
        ax.plot(th, scale * table[f"{c}_fitted"].to_numpy(), "-", lw=1.2, color=_VERMILLION,
                label="simulation at the fitted damping")
        ax.set_ylabel(axis_label(quantity, unit, symbol))
    axes[0, 0].legend(fontsize=8)
    axes[-1, 0].set_xlabel(axis_label("cam angle from the nose", "deg"))
    zc, zs = fit.value("zeta_contact"), fit.value("zeta_spring")
    axes[0, 0].set_title(rf"Valve closure: contact damping ratio $\zeta_c$ = {zc:.3g}, spring $\zeta_s$ = {zs:.3g}")
    return fig

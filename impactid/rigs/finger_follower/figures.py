"""Figures of the finger-follower valve train (the paper's Figs. 5, 7, 8 and 9-12), as matplotlib
figures; :func:`save` writes them atomically (or staged with other outputs). Units at the edge:
mm, um, deg."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd

__all__ = ["plot_cycle", "plot_leakdown", "plot_lift_fit", "plot_rocker_ratio", "plot_tappet_fit", "save"]


def _figure(nrows: int = 1, ncols: int = 1, **kwargs):
    """A :class:`matplotlib.figure.Figure` and its axes, without pyplot (nothing global is touched)."""
    from matplotlib.figure import Figure

    figure_keys = ("figsize", "constrained_layout", "dpi")
    fig = Figure(**{k: v for k, v in kwargs.items() if k in figure_keys})
    return fig, fig.subplots(nrows, ncols, **{k: v for k, v in kwargs.items() if k not in figure_keys})


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

    axes[0].plot(th, 1e3 * col("Y_v"), "b", label="valve")
    axes[0].plot(th, 1e3 * col("Y_t") * 10, "g", label="tappet leak-down x10")
    axes[0].set_ylabel("displacement [mm]")
    axes[0].legend(fontsize=8)
    axes[1].plot(th, col("Y_v_dot"), "b")
    axes[1].set_ylabel("valve velocity [m/s]")
    axes[2].plot(th, col("Y_v_ddot") / 1e3, "b")
    axes[2].set_ylabel("valve accel. [km/s^2]")
    for name, colour, label in (("F_fc", "r", "cam/follower"), ("F_vf", "b", "follower/valve"),
                                ("F_tf", "g", "tappet/follower")):
        axes[3].plot(th, col(name), colour, label=label)
    if constant_ratio is not None:
        o2 = np.argsort(constant_ratio["cam_angle_deg"].to_numpy())
        axes[3].plot(constant_ratio["cam_angle_deg"].to_numpy()[o2], constant_ratio["F_fc"].to_numpy()[o2], "r--",
                     lw=1.0, label="cam/follower, constant rocker ratio")
    axes[3].set_ylabel("contact force [N]")
    axes[3].set_xlabel("cam angle from the nose [deg]")
    axes[3].legend(fontsize=8)
    axes[0].set_title(f"Finger follower with HLA, steady state at {rpm:.6g} rpm camshaft")
    for ax in axes:
        ax.grid(True, alpha=0.3)
    axes[3].set_xlim(-120, 120)
    return fig


def plot_leakdown(frame: pd.DataFrame):
    """Maximum tappet leak-down against camshaft speed (Fig. 8)."""
    fig, ax = _figure(figsize=(6.5, 4.0), constrained_layout=True)
    ax.plot(frame["rpm"], 1e6 * frame["max_tappet_leakdown_m"], "o-")
    ax.set_xlabel("camshaft speed [rpm]")
    ax.set_ylabel("maximum tappet leak-down [um]")
    ax.set_title("Tappet leak-down against speed (steady state)")
    ax.grid(True, alpha=0.3)
    return fig


def plot_tappet_fit(fit):
    """Measured (averaged) and fitted tappet motion against cam angle (Fig. 7)."""
    table = fit.tables["cycles"]
    fig, ax = _figure(figsize=(7.0, 4.2), constrained_layout=True)
    for (_, rpm), sel in table.groupby(["recording", "rpm"]):
        o = np.argsort(sel["cam_angle_deg"].to_numpy())
        th = sel["cam_angle_deg"].to_numpy()[o]
        line, = ax.plot(th, 1e6 * sel["measured_m"].to_numpy()[o], ".", ms=2, label=f"measured {rpm:.6g} rpm")
        ax.plot(th, 1e6 * sel["fitted_m"].to_numpy()[o], "-", color=line.get_color(), lw=1.2,
                label=f"fitted {rpm:.6g} rpm")
    ax.set_xlabel("cam angle from the nose [deg]")
    ax.set_ylabel("tappet leak-down [um]")
    a, b = fit.value("alpha"), fit.value("beta")
    ax.set_title(f"Tappet drag fit: alpha = {a:.4g}, beta = {b:.4g}")
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    return fig


def plot_lift_fit(fit):
    """Measured (averaged) and fitted valve lift against cam angle."""
    table = fit.tables["cycle"]
    fig, ax = _figure(figsize=(7.0, 4.2), constrained_layout=True)
    th = table["cam_angle_deg"].to_numpy()
    ax.plot(th, 1e3 * table["measured_m"], ".", ms=2, label="measured (averaged)")
    ax.plot(th, 1e3 * table["fitted_m"], "-", lw=1.2, label="fitted lift law")
    ax.set_xlabel("cam angle (encoder, nose at 0) [deg]")
    ax.set_ylabel("valve lift [mm]")
    ax.set_title(f"Cam lift fit: S_K = {1e3 * fit.value('S_K'):.4g} mm")
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    return fig


def plot_rocker_ratio(kinematics):
    """Instantaneous rocker ratio and lever arm against cam angle (Fig. 5)."""
    fig, ax = _figure(figsize=(6.5, 4.0), constrained_layout=True)
    th = np.degrees(kinematics.theta)
    ax.plot(th, kinematics.values["RR"], "b")
    ax.set_xlabel("cam angle from the nose [deg]")
    ax.set_ylabel("rocker ratio [-]")
    ax.set_xlim(-120, 120)
    ax.grid(True, alpha=0.3)
    ax.set_title("Instantaneous rocker ratio")
    return fig


def save(fig, path: str | os.PathLike[str], staged=None) -> Path:
    """Write a figure (PNG) atomically, or staged in ``staged``."""
    from impactid.reports import save_figure_atomic

    return save_figure_atomic(fig, path, staged, dpi=110)

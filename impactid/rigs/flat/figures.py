"""Rig F's figures: the bifurcation diagram and the cam profile fit, in the package's style
(:mod:`impactid.plotting`). matplotlib is imported lazily."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd

from impactid._files import StagedFiles
from impactid.plotting import MEASURED, SIMULATED, axis_label, styled
from impactid.reports import REGIME_COLOURS, save_figure_atomic, staged_transaction, write_csv_atomic

__all__ = ["cam_fit_figures", "plot_bifurcation", "plot_cam_fit", "plot_cam_fit_order", "write_bifurcation"]


#: The transition speeds of :meth:`~impactid.rigs.flat.simulate.BifurcationResult.transitions` in words.
TRANSITION_LABELS = {"detachment_rpm": "detachment", "period1_end_rpm": "end of period-1",
                     "irregular_rpm": "irregular motion"}


@styled
def plot_bifurcation(result, transitions: dict | None = None):
    """Stroboscopic follower angle against cam speed (Fig. 16 of Alzate et al. (2007)), coloured by regime."""
    from matplotlib.figure import Figure

    colours = REGIME_COLOURS
    table = result.table
    fig = Figure(figsize=(8, 4.5), layout="constrained")
    ax = fig.subplots()
    for regime, colour in colours.items():
        rows = np.flatnonzero(table["regime"].to_numpy() == regime)
        if rows.size == 0:
            continue
        rpm = np.repeat(table["cam_speed_rpm"].to_numpy()[rows], result.kept)
        ax.plot(rpm, result.strobe_angle[rows].ravel(), ".", ms=1.5, color=colour, alpha=0.8)
        ax.plot([], [], "o", color=colour, ms=4, label=regime)
    labels: dict[float, list[str]] = {}
    for key, value in (transitions or {}).items():
        if np.isfinite(value):
            labels.setdefault(float(value), []).append(TRANSITION_LABELS.get(key, key.replace("_rpm", "")
                                                                             .replace("_", " ")))
    for value, names in labels.items():
        ax.axvline(value, color="0.5", lw=0.6, ls="--")
        ax.text(value, 1.0, " " + ", ".join(names), rotation=90, va="top", ha="right", fontsize=7,
                transform=ax.get_xaxis_transform())
    ax.set_xlabel(axis_label("cam speed", "rpm", r"\Omega"))
    ax.set_ylabel(rf"follower angle $\theta_f$ at $\theta_c = 2\pi k + {result.strobe_phase:.3f}$ [rad]")
    ax.set_title(f"Bifurcation diagram of rig F (last {result.kept} of {result.revolutions} revolutions)")
    ax.legend(title="motion", loc="best", markerscale=1)
    return fig


def write_bifurcation(result, out_dir: str | os.PathLike[str], staged: StagedFiles | None = None,
                      fmt: str | None = None) -> list[Path]:
    """Write ``bifurcation.csv`` (one row per speed and kept revolution: ``cam_speed_rpm``,
    ``revolution``, ``theta_f`` [rad], ``theta_f_dot`` [rad/s], ``regime``), ``regimes.csv`` (one
    row per speed) and ``bifurcation.png`` (or ``.svg``, ``.pdf``: ``fmt``, see
    :func:`impactid.plotting.save_figure`) into ``out_dir``, atomically."""

    out_dir = Path(out_dir)
    table = result.table
    n_speeds, kept = result.strobe_angle.shape
    points = pd.DataFrame({
        "cam_speed_rpm": np.repeat(table["cam_speed_rpm"].to_numpy(), kept),
        "revolution": np.tile(np.arange(result.revolutions - kept + 1, result.revolutions + 1), n_speeds),
        "theta_f": result.strobe_angle.ravel(),
        "theta_f_dot": result.strobe_rate.ravel(),
        "regime": np.repeat(table["regime"].to_numpy(), kept),
    })
    with staged_transaction(staged) as st:
        paths = [write_csv_atomic(points, out_dir / "bifurcation.csv", st),
                 write_csv_atomic(table, out_dir / "regimes.csv", st)]
        fig = plot_bifurcation(result, result.transitions())
        paths.append(save_figure_atomic(fig, out_dir / "bifurcation.png", st, fmt))
    return paths


@styled
def plot_cam_fit(fit):
    """Figure of a :class:`impactid.rigs.flat.camprofile.CamProfileResult`: follower angle against cam angle with
    the fitted profile (top), residuals at the fitted points (middle), and the profile's analytic first
    and second derivatives with respect to the cam angle (bottom). Needs the fitted data (a result
    of :func:`~impactid.rigs.flat.camprofile.fit_cam_profile`, not one read from JSON)."""
    from matplotlib.figure import Figure

    data = fit.data
    if data is None:
        raise ValueError("the cam-profile figure needs the fitted data, which a result read from JSON does not keep")
    theta, value = fit.profile.sample(3600)
    _, first, second = fit.profile(theta, derivatives=2)
    fig = Figure(figsize=(8.0, 9.0), layout="constrained")
    axes = fig.subplots(3, 1, sharex=True)
    ax = axes[0]
    step = max(1, data.nsamples // 4000)  # a readable subsample of the (quantised) samples
    ax.plot(data.cam_angle[::step], data.follower_angle[::step], ".", ms=1.5, color="0.65",
            label=f"measured samples (1 in {step})")
    ax.plot(data.fit_cam_angle, data.fit_follower_angle, ".", ms=2.5, color=MEASURED,
            label=f"measured points fitted: {data.fit_points}")
    ax.plot(theta, value, "-", color=SIMULATED, lw=1.2, label=f"fitted profile ({fit.terms}-term Gaussian sum)")
    ax.set(ylabel=axis_label("follower angle", "rad", r"\theta_f"),
           title=f"{data.source or 'recording'}: cam profile, {len(data.used_revolutions)} revolution(s)")
    ax.legend(fontsize=8, loc="best")
    ax = axes[1]
    ax.plot(data.fit_cam_angle, 1e3 * fit.residuals(), ".", ms=2.5, color=MEASURED)
    ax.axhline(0.0, color="0.3", lw=0.8)
    ax.set(ylabel=axis_label("residual (measured minus fitted)", "mrad"),
           title=f"residual RMS {fit.rms_residual * 1e3:.3g} mrad, max {fit.max_residual * 1e3:.3g} mrad")
    ax = axes[2]
    ax.plot(theta, first, "-", color="C2", label=r"first, $d\theta_f/d\theta_c$ [rad/rad]")
    ax.plot(theta, second, "-", color="C0", label=r"second, $d^2\theta_f/d\theta_c^2$ [rad/rad$^2$]")
    ax.axhline(0.0, color="0.3", lw=0.8)
    ax.set(xlabel=axis_label("cam angle (the recording's convention)", "rad", r"\theta_c"),
           ylabel="derivative of the profile [rad/rad, rad/rad$^2$]", xlim=(0.0, 2.0 * np.pi))
    ax.legend(fontsize=8, loc="best")
    return fig


@styled
def plot_cam_fit_order(fit):
    """AIC and BIC against the number of Gaussian terms (``terms="auto"`` fits only)."""
    from matplotlib.figure import Figure

    table = fit.order_table
    fig = Figure(figsize=(6.0, 4.2), layout="constrained")
    ax = fig.subplots()
    ax.plot(table["terms"], table["aic"], "o-", label="AIC")
    ax.plot(table["terms"], table["bic"], "s-", label="BIC")
    chosen = table[table["chosen"]]
    ax.plot(chosen["terms"], chosen[fit.criterion], "*", color=SIMULATED, mec="black", ms=14,
            label=f"chosen by the {fit.criterion.upper()}")
    ax.set(xlabel=axis_label("Gaussian terms", None), ylabel=axis_label("information criterion", None),
           title="Cam-profile order selection")
    ax.legend()
    return fig


def cam_fit_figures(fit, out_dir: str | os.PathLike[str], staged: StagedFiles | None = None,
                    fmt: str | None = None) -> list[Path]:
    """Write ``cam_fit.png`` (:func:`plot_cam_fit`) and, for ``terms="auto"``, ``cam_fit_order.png``
    (:func:`plot_cam_fit_order`) into ``out_dir``, atomically (``fmt``: see
    :func:`impactid.plotting.save_figure`)."""

    out = Path(out_dir)
    written = []
    figures = [("cam_fit.png", plot_cam_fit)]
    if fit.order_table is not None:
        figures.append(("cam_fit_order.png", plot_cam_fit_order))
    with staged_transaction(staged) as st:
        for name, make in figures:
            fig = make(fit)
            written.append(save_figure_atomic(fig, out / name, st, fmt))
    return written

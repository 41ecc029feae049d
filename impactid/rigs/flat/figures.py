"""Rig F's figures: the bifurcation diagram, the cam profile fit and the restitution fit (measured and
simulated impacts, the law over cam speed), in the package's style (:mod:`impactid.plotting`).
matplotlib is imported lazily."""

from __future__ import annotations

import math
import os
import textwrap
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.integrate import solve_ivp

from impactid._files import StagedFiles
from impactid.errors import ImpactidError, SimulationError, SimulationInputError
from impactid.plotting import MEASURED, OKABE_ITO, SIMULATED, axis_label, styled
from impactid.reports import REGIME_COLOURS, save_figure_atomic, staged_transaction, write_csv_atomic
from impactid.rigs.flat import MODEL_NAME
from impactid.rigs.flat.encoder_impacts import FIT_WINDOW_S, EncoderImpactError, refine_offset, relative_motion
from impactid.rigs.flat.simulate import simulate_flat

__all__ = ["IMPACTS_SHOWN", "ImpactOverlay", "cam_fit_figures", "impact_overlays", "plot_bifurcation", "plot_cam_fit",
           "plot_cam_fit_order", "plot_restitution_impacts", "plot_restitution_law", "restitution_figures",
           "write_bifurcation"]

#: First impacts shown by :func:`plot_restitution_impacts` (spread over the cam speeds and the recordings).
IMPACTS_SHOWN = 4


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


# ---------------------------------------------------------------------------------------------
# The restitution fit: measured and simulated first impacts, and the law over cam speed
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ImpactOverlay:
    """One first impact of a restitution fit, as the encoders recorded it and as the rig's simulator
    reproduces it with the fitted law from the same pre-impact state (:func:`impact_overlays`).

    Attributes
    ----------
    source : the recording.
    cam_speed_rpm : its mean cam speed [rpm].
    number, count : the impact's number among the recording's measured first impacts (1 the earliest),
        and how many there are.
    t_impact : the impact time [s] (the recording's clock).
    time : the recorded sample times around the impact, from the impact [s].
    measured : the follower angle above the cam profile at ``time`` [rad] (encoder counts, half a count
        added).
    restitution_measured : this impact's ``-v+ / v-`` [-].
    restitution_law : the fitted law's ``r`` at the recording's cam speed [-] (NaN: not evaluated).
    sim_time, simulated : a fine time grid from the impact [s] and the simulated follower angle above the
        cam profile on it [rad]; None without a simulation.
    residual : the follower angle measured minus simulated at ``time`` [rad]; None without a simulation.
    follower_step : the follower encoder's count [rad] (0: not quantised).
    note : why the impact was not simulated ("" when it was).
    """

    source: str
    cam_speed_rpm: float
    number: int
    count: int
    t_impact: float
    time: np.ndarray
    measured: np.ndarray
    restitution_measured: float
    restitution_law: float
    sim_time: np.ndarray | None
    simulated: np.ndarray | None
    residual: np.ndarray | None
    follower_step: float
    note: str = ""


def _picks(points, count: int) -> list[tuple[int, int]]:
    """``(point, row)`` of the first impacts shown: at most ``count`` recordings spread over the cam
    speeds, and in each, impacts spread over the recording (the middle one when only one)."""
    order = sorted((i for i, p in enumerate(points) if len(p.impacts)), key=lambda i: points[i].cam_speed_hz)
    if len(order) > count:
        order = [order[k] for k in np.unique(np.round(np.linspace(0, len(order) - 1, count)).astype(int))]
    picks = []
    for k, i in enumerate(order):
        n = len(points[i].impacts)
        quota = min(n, count // len(order) + (1 if k < count % len(order) else 0)) if order else 0
        rows = [(n - 1) // 2] if quota == 1 else np.unique(np.round(np.linspace(0, n - 1, quota)).astype(int))
        picks += [(i, int(row)) for row in rows]
    return picks


def _backward_flight(rig, theta, rate, theta_c, omega: float, span: float) -> tuple[float, float, float]:
    """The free flight (A-10) followed back in time from the follower angle and rate ``theta, rate``
    [rad, rad/s] at the cam angle ``theta_c`` [rad], for ``span`` [s] or less: where the follower would
    be inside the cam earlier than that, the flight is followed back only to 80 % of the way there.
    Returns ``(time, angle, rate)`` at the start [s, rad, rad/s]."""
    flight = solve_ivp(lambda _, y: (y[1], -float(rig.spring_torque(y[0])) / rig.J), (0.0, -span), (theta, rate),
                       method="DOP853", rtol=1e-11, atol=1e-13, dense_output=True)
    if not flight.success:
        raise ImpactidError(f"the free flight before the impact could not be followed back ({flight.message})")
    grid = np.linspace(-span, 0.0, 801)[:-1]
    angle = flight.sol(grid)[0]
    inside = np.flatnonzero(rig.gap(angle, theta_c + omega * grid) < 0.0)
    start = -span if inside.size == 0 else 0.8 * float(grid[inside[-1]])
    if start > -1e-4:
        raise ImpactidError("the flight before the impact lasts less than 0.1 ms: no pre-impact state to start from")
    angle, velocity = flight.sol(start)
    return start, float(angle), float(velocity)


def _aligned_motion(point, recording, rig, profile) -> tuple:
    """``(motion, rig, reason)``: the recording's motion relative to the rig's own cam profile (A-17), aligned
    as :func:`~impactid.rigs.flat.encoder_impacts.restitution_at_speed` aligns it, and the rig to simulate; where
    the recording has no flat-follower rig, or the rig's profile does not fit it, the motion relative to the
    profile the point was measured with, no rig and the reason (or "")."""
    model = recording.rig if rig is None else rig
    model = model if getattr(model, "model", None) == MODEL_NAME else None
    reason = ""
    if model is not None:
        try:
            motion = relative_motion(recording, model.contact_angle)
            return relative_motion(recording, model.contact_angle, refine_offset(motion, point.impacts)), model, ""
        except EncoderImpactError as exc:
            model, reason = None, f"the rig's cam profile does not fit the recording ({str(exc).splitlines()[0]})"
    motion = relative_motion(recording, profile)
    return relative_motion(recording, profile, refine_offset(motion, point.impacts)), model, reason


def impact_overlays(points, recordings, law=None, rig=None, profile=None,
                    count: int = IMPACTS_SHOWN) -> tuple[ImpactOverlay, ...]:
    """A few first impacts of a restitution fit, measured and simulated with the fitted law.

    For each impact shown (at most ``count``: recordings spread over the cam speeds, impacts spread over
    each recording), the follower's recorded angle above the cam profile from 25 ms before the impact to
    a little after its first bounce, and the motion the rig's simulator
    (:func:`~impactid.rigs.flat.simulate.simulate_flat`) gives from the same pre-impact state with the
    law's ``r`` at the recording's cam speed: the state at the measured impact (the follower on the
    profile at the measured impact time, at the measured approach rate ``v-``) followed back along the
    free flight (A-10) to the window's start. The simulation then flies forward, finds the impact
    itself, bounces with the law's ``r`` and chatters or rides on as the model does; where the measured
    first bounce and the simulated one agree, the law describes the impact. The profile of the
    simulation (and of the relative angles) is the rig's own (A-17), aligned to the recording.

    Parameters
    ----------
    points : the per-speed measurements (:class:`~impactid.rigs.flat.encoder_impacts.RestitutionAtSpeed`).
    recordings : their recordings, in the same order.
    law : the fitted :class:`~impactid.rigs.flat.simulate.SpeedRestitution` (None: no simulation).
    rig : the rig to simulate (default each recording's; a recording without a flat-follower rig is
        shown measured only).
    profile : the cam profile the points were measured with, for the relative angle of a recording
        without a rig (default the rig's analytic profile).
    count : impacts shown.

    Returns
    -------
    One :class:`ImpactOverlay` per impact shown; an impact that could not be simulated has ``note``
    saying why.
    """
    out = []
    motions: dict[int, tuple] = {}
    for i, row_index in _picks(points, count):
        point, recording = points[i], recordings[i]
        row = point.impacts.iloc[row_index]
        if i not in motions:
            motions[i] = _aligned_motion(point, recording, rig, profile)
        motion, model, unaligned = motions[i]
        omega = 2.0 * math.pi * motion.cam_speed_hz
        t1 = float(row["t_impact"])
        theta_c1 = float(row["cam_angle"]) + motion.offset  # the profile's convention
        pre = FIT_WINDOW_S
        post = float(np.clip(2.5 * row["bounce_duration"], 0.4 * FIT_WINDOW_S, 4.0 * FIT_WINDOW_S))
        window = (motion.t >= t1 - pre) & (motion.t <= t1 + post)
        tau = motion.t[window] - t1
        measured_angle = motion.theta_f[window]
        measured = measured_angle - motion.profile(theta_c1 + omega * tau)
        r_law, sim_time, simulated, residual, note = math.nan, None, None, None, ""
        try:
            if unaligned:
                raise ImpactidError(unaligned)
            if model is None:
                raise ImpactidError(f"{point.source or 'the recording'} has no flat-follower rig description to "
                                    "simulate (give --rig)")
            if law is None:
                raise ImpactidError("the fitted law is undetermined")
            r_law = float(law.a + law.b * omega)
            if not 0.0 <= r_law <= 1.0:
                raise ImpactidError(f"the fitted law gives r = {r_law:.3g} at {60.0 * motion.cam_speed_hz:.1f} rpm, "
                                    "outside [0, 1]")
            theta1, slope = model.contact_angle(theta_c1, derivatives=1)
            start, theta0, rate0 = _backward_flight(model, float(theta1), float(row["rate_before"]) + omega * float(
                slope), theta_c1, omega, pre)
            sim_time = np.linspace(start, post, 1500)
            times = np.union1d(sim_time, tau[tau >= start]) - start
            run = simulate_flat(model, motion.cam_speed_hz, post - start, restitution=r_law, times=times,
                                theta_c0=float(np.mod(theta_c1 + omega * start, 2.0 * math.pi)),
                                initial=(theta0, rate0))
            angle = np.interp(sim_time - start, run.t, run.theta_f)
            simulated = angle - model.contact_angle(theta_c1 + omega * sim_time)
            inside = tau >= start
            residual = np.full(tau.size, np.nan)
            residual[inside] = measured_angle[inside] - np.interp(tau[inside] - start, run.t, run.theta_f)
        except (ImpactidError, ValueError, SimulationError, SimulationInputError) as exc:
            sim_time, simulated, residual = None, None, None
            note = f"not simulated: {str(exc).splitlines()[0]}"
        out.append(ImpactOverlay(source=point.source, cam_speed_rpm=60.0 * motion.cam_speed_hz,
                                 number=row_index + 1, count=len(point.impacts), t_impact=t1, time=tau,
                                 measured=measured, restitution_measured=float(row["restitution"]),
                                 restitution_law=r_law, sim_time=sim_time, simulated=simulated, residual=residual,
                                 follower_step=motion.follower_step, note=note))
    return tuple(out)


@styled
def plot_restitution_impacts(overlays):
    """Measured and simulated first impacts of a restitution fit (:func:`impact_overlays`): one column per
    impact, the follower angle above the cam profile against the time from the impact (top: the encoder's
    samples and the simulation with the fitted law from the same pre-impact state) and the follower angle
    measured minus simulated (bottom, with the band of half an encoder count)."""
    from matplotlib.figure import Figure

    if not overlays:
        raise ValueError("no first impact to show")
    fig = Figure(figsize=(3.2 * len(overlays) + 0.6, 5.6), layout="constrained")
    axes = fig.subplots(2, len(overlays), squeeze=False, sharex="col", height_ratios=(2.0, 1.0))
    for col, ov in enumerate(overlays):
        ax = axes[0, col]
        ax.plot(1e3 * ov.time, 1e3 * ov.measured, ".", ms=2.0, color=MEASURED, label="measured (follower encoder)")
        if ov.simulated is not None:
            ax.plot(1e3 * ov.sim_time, 1e3 * ov.simulated, "-", color=SIMULATED, lw=1.2,
                    label=f"simulated with the fitted law, $r$ = {ov.restitution_law:.3f}")
        ax.axvline(0.0, color="0.5", lw=0.6, ls="--")
        ax.set_ylabel(axis_label("follower above the cam", "mrad", r"\theta_f - \hat\theta_f"))
        ax.set_title(f"{Path(ov.source).name or 'recording'}, {ov.cam_speed_rpm:.1f} rpm\nfirst impact {ov.number} "
                     f"of {ov.count}: measured $r$ = {ov.restitution_measured:.3f}", fontsize=9)
        ax = axes[1, col]
        if ov.residual is not None:
            ax.plot(1e3 * ov.time, 1e3 * ov.residual, ".", ms=1.2, color=MEASURED)
            rms = float(np.sqrt(np.nanmean(ov.residual**2)))
            ax.set_title(f"RMS {1e3 * rms:.3g} mrad", fontsize=8)
        else:
            ax.text(0.5, 0.5, textwrap.fill(ov.note, 36, break_long_words=False), transform=ax.transAxes,
                    ha="center", va="center", fontsize=7, color=OKABE_ITO["vermillion"], zorder=5,
                    bbox={"facecolor": "white", "edgecolor": "none", "alpha": 0.9})
        if ov.follower_step > 0.0:
            ax.axhspan(-500 * ov.follower_step, 500 * ov.follower_step, color=OKABE_ITO["sky blue"], alpha=0.25,
                       lw=0, label="half an encoder count")
        ax.axhline(0.0, color="0.3", lw=0.8)
        ax.axvline(0.0, color="0.5", lw=0.6, ls="--")
        ax.set_xlabel(axis_label("time from the impact", "ms", "t - t_1"))
        ax.set_ylabel(axis_label("measured minus simulated", "mrad"))
    axes[0, 0].legend(loc="upper right", fontsize=7)
    if any(ov.follower_step > 0.0 for ov in overlays):
        axes[1, 0].legend(loc="lower right", fontsize=7)
    fig.suptitle("Rig F: measured first impacts and their simulation with the fitted restitution law")
    return fig


@styled
def plot_restitution_law(result):
    """The coefficient of restitution of each cam speed (with its whole standard error) and the fitted law
    ``r = a + b omega`` with its 95 % band, against the cam speed (Fig. 12 of Alzate et al. (2007))."""
    from matplotlib.figure import Figure

    points = [p for p in result.points if math.isfinite(p.restitution)]
    rpm = np.array([p.cam_speed_rpm for p in points])
    r = np.array([p.restitution for p in points])
    err = np.array([p.measurement_error for p in points])
    fig = Figure(figsize=(6.4, 4.2), layout="constrained")
    ax = fig.subplots()
    ax.errorbar(rpm, r, yerr=np.where(np.isfinite(err), 1.96 * err, 0.0), fmt="o", color=MEASURED, capsize=3,
                label="measured at each cam speed (95 % error bar)")
    a, b = result.value("a"), result.value("b")
    if rpm.size and math.isfinite(a) and math.isfinite(b):
        span = max(float(np.ptp(rpm)), 2.0)
        grid = np.linspace(rpm.min() - 0.1 * span, rpm.max() + 0.1 * span, 200)
        omega = grid * 2.0 * math.pi / 60.0
        per_rpm = b * 2.0 * math.pi / 60.0
        sign = "-" if per_rpm < 0 else "+"
        ax.plot(grid, a + b * omega, "-", color=SIMULATED,
                label=f"fitted law: $r$ = {a:.4f} {sign} {abs(per_rpm):.3g} $\\Omega$ / rpm")
        cov = np.asarray(result.details.get("correlation", {}).get("matrix", []), dtype=float)
        sa, sb = result.params["a"].stderr, result.params["b"].stderr
        if cov.shape == (2, 2) and math.isfinite(sa) and math.isfinite(sb) and not result.params["b"].fixed:
            var = sa**2 + 2.0 * cov[0, 1] * sa * sb * omega + (sb * omega) ** 2
            band = 1.96 * np.sqrt(np.clip(var, 0.0, None))
            ax.fill_between(grid, a + b * omega - band, a + b * omega + band, color=SIMULATED, alpha=0.15, lw=0,
                            label="95 % band of the law")
    ax.set(xlabel=axis_label("cam speed", "rpm", r"\Omega"),
           ylabel=axis_label("coefficient of restitution", None, "r"),
           title=f"Rig F: restitution against cam speed ({len(points)} cam speed{'s' if len(points) != 1 else ''})")
    ax.legend(loc="best")
    return fig


def restitution_figures(result, overlays, out_dir: str | os.PathLike[str], staged: StagedFiles | None = None,
                        fmt: str | None = None) -> list[Path]:
    """Write the figures of ``impactid restitution`` into ``out_dir``, atomically: ``restitution_impacts.png``
    (:func:`plot_restitution_impacts`, when there are ``overlays``) and ``restitution_law.png``
    (:func:`plot_restitution_law`). ``fmt``: see :func:`impactid.plotting.save_figure`."""
    out = Path(out_dir)
    written = []
    with staged_transaction(staged) as st:
        if overlays:
            written.append(save_figure_atomic(plot_restitution_impacts(overlays), out / "restitution_impacts.png",
                                              st, fmt))
        written.append(save_figure_atomic(plot_restitution_law(result), out / "restitution_law.png", st, fmt))
    return written

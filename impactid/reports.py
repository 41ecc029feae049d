"""Reports: tables and figures written to disk (atomically). matplotlib is imported lazily."""

from __future__ import annotations

import contextlib
import os
from pathlib import Path

import numpy as np
import pandas as pd

from impactid._files import StagedFiles, atomic_write

__all__ = ["REGIME_COLOURS", "cam_fit_figures", "estimate_figures", "period1_band", "plot_bifurcation", "plot_cam_fit",
           "plot_cam_fit_order", "plot_kinematics_spline_study", "plot_regime_map", "save_figure_atomic",
           "write_bifurcation", "write_csv_atomic", "write_regime_map"]

REGIME_COLOURS = {"contact": "#4c72b0", "period-1": "#55a868", "period-k": "#dd8452", "irregular": "#c44e52"}


@contextlib.contextmanager
def _transaction(staged: StagedFiles | None):
    """The caller's transaction, or a new one committed at the end of the block."""
    if staged is not None:
        yield staged
        return
    with StagedFiles() as own:
        yield own


def write_csv_atomic(frame: pd.DataFrame, path: str | os.PathLike[str], staged: StagedFiles | None = None) -> Path:
    """Write a DataFrame as CSV, atomically (or staged in ``staged``, committed with it)."""
    if staged is not None:
        return staged.write_with(path, lambda tmp: frame.to_csv(tmp, index=False))
    return atomic_write(path, lambda tmp: frame.to_csv(tmp, index=False))


def save_figure_atomic(fig, path: str | os.PathLike[str], staged: StagedFiles | None = None, **kwargs) -> Path:
    """Save a matplotlib figure, atomically (or staged in ``staged``, committed with it)."""
    fmt = Path(path).suffix.lstrip(".") or "png"

    def write(tmp: Path) -> None:
        fig.savefig(tmp, format=fmt, **kwargs)

    if staged is not None:
        return staged.write_with(path, write)
    return atomic_write(path, write)


def plot_regime_map(frame: pd.DataFrame):
    """Regime map figure (cam speed versus e/r_c, as Fig. 3 of Sundar, Dreyer & Singh (2016))."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8.0, 4.8), constrained_layout=True)
    ax = fig.subplots()
    for regime, colour in REGIME_COLOURS.items():
        sel = frame[frame["regime"] == regime]
        if len(sel):
            ax.scatter(sel["e_over_rc"], sel["cam_speed_hz"], s=36, marker="s", color=colour, label=regime)
    det = frame.groupby("e_over_rc")["detachment_hz"].first()
    ax.plot(det.index, det.to_numpy(), "k--", lw=1.2, label="detachment (inverse kinematics)")
    ax.set_xlabel("e / r_c [-]")
    ax.set_ylabel("cam speed Omega_c [Hz]")
    ax.set_title("Rig P motion regimes (S2, from static equilibrium)")
    ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8, framealpha=0.9)
    ax.grid(True, alpha=0.3)
    return fig


def write_regime_map(frame: pd.DataFrame, out_dir: str | os.PathLike[str],
                     staged: StagedFiles | None = None) -> list[Path]:
    """Write ``regime_map.csv`` and ``regime_map.png`` into ``out_dir`` (one transaction)."""

    out_dir = Path(out_dir)
    with _transaction(staged) as st:
        csv = write_csv_atomic(frame, out_dir / "regime_map.csv", st)
        fig = plot_regime_map(frame)
        png = save_figure_atomic(fig, out_dir / "regime_map.png", st, dpi=120)
    return [csv, png]


def plot_bifurcation(result, transitions: dict | None = None):
    """Stroboscopic follower angle against cam speed (Fig. 16 of Alzate et al. (2007)), coloured by regime."""
    from matplotlib.figure import Figure

    colours = {"contact": "tab:green", "period-1": "tab:blue", "period-k": "tab:orange", "irregular": "tab:red"}
    table = result.table
    fig = Figure(figsize=(8, 4.5), constrained_layout=True)
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
            labels.setdefault(float(value), []).append(key.replace("_rpm", ""))
    for value, names in labels.items():
        ax.axvline(value, color="0.5", lw=0.6, ls="--")
        ax.text(value, 1.0, " " + " = ".join(names), rotation=90, va="top", ha="right", fontsize=7,
                transform=ax.get_xaxis_transform())
    ax.set_xlabel("cam speed [rpm]")
    ax.set_ylabel(f"follower angle at theta_c = 2 pi k + {result.strobe_phase:.3f} [rad]")
    ax.set_title(f"rig F bifurcation diagram (last {result.kept} of {result.revolutions} revolutions)")
    ax.legend(loc="best", fontsize=8, markerscale=1)
    return fig


def write_bifurcation(result, out_dir: str | os.PathLike[str], staged: StagedFiles | None = None) -> list[Path]:
    """Write ``bifurcation.csv`` (one row per speed and kept revolution: ``cam_speed_rpm``,
    ``revolution``, ``theta_f`` [rad], ``theta_f_dot`` [rad/s], ``regime``), ``regimes.csv`` (one
    row per speed) and ``bifurcation.png`` into ``out_dir``, atomically."""

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
    with _transaction(staged) as st:
        paths = [write_csv_atomic(points, out_dir / "bifurcation.csv", st),
                 write_csv_atomic(table, out_dir / "regimes.csv", st)]
        fig = plot_bifurcation(result, result.transitions())
        paths.append(save_figure_atomic(fig, out_dir / "bifurcation.png", st, dpi=130))
    return paths


def period1_band(frame: pd.DataFrame) -> pd.DataFrame:
    """Per e/r_c, the cam speeds classified period-1 (min, max and count) in a regime-map frame."""
    rows = []
    for ratio, group in frame.groupby("e_over_rc"):
        p1 = group[group["regime"] == "period-1"]["cam_speed_hz"].to_numpy()
        rows.append({"e_over_rc": ratio, "period1_min_hz": float(np.min(p1)) if p1.size else np.nan,
                     "period1_max_hz": float(np.max(p1)) if p1.size else np.nan, "period1_points": int(p1.size)})
    return pd.DataFrame(rows)


# ---------------------------------------------------------------------------------------------
# estimation figures (impactid estimate --plots)
# ---------------------------------------------------------------------------------------------


def estimate_figures(result, out_dir: str | os.PathLike[str], staged: StagedFiles | None = None) -> list[Path]:
    """Write the figures of an :class:`impactid.estimates.Estimate` to ``out_dir`` (PNG), atomically.

    ``hysteresis.png``: contact force against indentation of the median-speed impact, measured
    (S-21, when the recording has pivot forces) and simulated at the estimate (Fig. 7 of Sundar, Dreyer & Singh (2016));
    ``restitution.png``: ``xi`` against ``v_a`` with the fitted laws (Fig. 10);
    ``landscape.png``: mean residual over (n, beta) with the valley and the estimate;
    ``residuals.png``: per-impact residual at the estimate.
    """

    from impactid.estimates import objective_landscape

    out = Path(out_dir)
    d, r = result.damping, result.restitution
    written = []
    with _transaction(staged) as st:
        _estimate_figures(result, d, r, out, st, written, objective_landscape)
    return written


def _estimate_figures(result, d, r, out, st, written, objective_landscape) -> None:
    from matplotlib.figure import Figure

    # hysteresis loop of the median-speed event of the first recording
    es = result.event_sets[0]
    i = int(np.argsort(es.approach_speed)[len(es) // 2])
    one = es.subset(i)
    batch = one.simulate(np.array([[d.beta, d.n]]), histories=True)
    fig = Figure(figsize=(6, 4.5))
    ax = fig.subplots()
    if es.force is not None:
        ax.plot(1e6 * es.indentation[i], es.force[i], "o-", ms=3, label="measured (S-21)")
    ax.plot(1e6 * np.maximum(-batch.gap[0], 0.0), batch.contact_force[0], "-", label="S1 at the estimate")
    ax.set(xlabel="indentation [um]", ylabel="contact force [N]",
           title=f"{es.source}: event {int(es.events[i])}, beta={d.beta:.4g}, n={d.n:.3g}")
    ax.legend()
    written.append(save_figure_atomic(fig, out / "hysteresis.png", st, dpi=120))
    # restitution (absent when no impact had a determined xi)
    if r is not None:
        frame = r.per_impact[r.per_impact["used"]]
        fig = Figure(figsize=(6, 4.5))
        ax = fig.subplots()
        ax.plot(frame["approach_speed"], frame["xi"], "o", ms=4, label="impacts")
        v = np.linspace(0.0, max(float(frame["approach_speed"].max()) * 1.2, 1e-3), 50)
        ax.plot(v, 1.0 - r.gamma * v, "-", label=f"xi = 1 - gamma v_a, gamma = {r.gamma:.4g} s/m")
        ax.axhline(r.r_constant, ls="--", color="0.5", label=f"constant r = {r.r_constant:.4g}")
        ax.set(xlabel="approach speed v_a [m/s]", ylabel="xi", ylim=(0, 1.05),
               title="restitution (Fig. 10 of Sundar, Dreyer & Singh (2016))")
        ax.legend()
        written.append(save_figure_atomic(fig, out / "restitution.png", st, dpi=120))
    # landscape with the valley
    # (the figure's own landscape: 31 x 31 about the estimate, +-0.5 in n and +-1.5 decades of c, where
    # the valley is; the full bounds cost twice the simulations, mostly of implausible laws)
    land = d.landscape or objective_landscape(
        list(result.event_sets), d.residual, delta_ref=d.delta_ref,
        n_values=np.linspace(max(d.n - 0.5, 0.0), d.n + 0.5, 31),
        c_values=d.damping_at_reference * np.logspace(-1.5, 1.5, 31))
    fig = Figure(figsize=(6.5, 4.8))
    ax = fig.subplots()
    nn = np.repeat(land.n[:, None], land.log10_c.size, axis=1)
    mesh = ax.pcolormesh(nn, np.log10(land.beta), np.log10(land.objective), shading="auto", cmap="viridis")
    fig.colorbar(mesh, ax=ax, label=f"log10 mean {d.residual}")
    ax.plot(d.valley["n"], np.log10(d.valley["beta"]), "w-", lw=1.5, label="valley beta(n)")
    ax.plot([d.n], [np.log10(d.beta)], "r*", ms=12, label="estimate")
    ax.set(xlabel="n", ylabel="log10 beta [N s m^-(n+1)]", title="objective landscape")
    ax.legend(loc="lower right")
    written.append(save_figure_atomic(fig, out / "landscape.png", st, dpi=120))
    # per-impact residuals
    fig = Figure(figsize=(6.5, 4))
    ax = fig.subplots()
    for source, part in d.per_event.groupby("source", sort=False):
        ax.plot(part["event"], part["residual"], "o", ms=4, label=str(source))
    ax.axhline(0.0, color="0.4", lw=0.8)
    ax.set(xlabel="event", ylabel=f"{d.residual} (signed)", title=f"per-impact residuals, mean |.| = {d.objective:.3g}")
    ax.legend(fontsize=8)
    written.append(save_figure_atomic(fig, out / "residuals.png", st, dpi=120))


# ---------------------------------------------------------------------------------------------
# contact-point kinematics: analytic derivatives against a differentiated spline (Lee 2005)
# ---------------------------------------------------------------------------------------------


def plot_kinematics_spline_study(studies: dict[str, pd.DataFrame]):
    """Relative error of the spline-differentiated follower acceleration and velocity against the
    number of nodes per revolution, log-log (as Figs. 5 and 7 of Lee (2005)).

    ``studies`` maps a profile label to a table of :func:`impactid.cam_kinematics.spline_error_study`.
    Solid lines: maximum relative error; dashed: RMS relative error; dotted grey: slopes N^-2
    (acceleration) and N^-3 (velocity), the orders of a periodic cubic spline on a smooth profile.
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=(10.0, 4.4), constrained_layout=True)
    axes = fig.subplots(1, 2)
    panels = (("acceleration", 2.0), ("velocity", 3.0))
    for ax, (quantity, order) in zip(axes, panels):
        for k, (label, frame) in enumerate(studies.items()):
            colour = f"C{k}"
            n = frame["nodes"].to_numpy(float)
            ax.loglog(n, frame[f"max_rel_error_{quantity}"], "o-", color=colour, ms=4, label=f"{label}: max")
            ax.loglog(n, frame[f"rms_rel_error_{quantity}"], "s--", color=colour, ms=3, lw=1.0,
                      label=f"{label}: RMS")
        if studies:
            first = next(iter(studies.values()))
            n = first["nodes"].to_numpy(float)
            mid = len(n) // 2
            anchor = 0.2 * float(first[f"rms_rel_error_{quantity}"].iloc[mid])  # below the data, visible
            ax.loglog(n, anchor * (n / n[mid]) ** -order, ":", color="0.4", lw=1.5, label=f"slope N^-{order:g}")
        ax.set(xlabel="nodes per revolution N", ylabel=f"relative {quantity} error [-]",
               title=f"follower angular {quantity}: spline vs analytic")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    return fig


# ---------------------------------------------------------------------------------------------
# cam-profile fit figures (impactid cam-fit --plots)
# ---------------------------------------------------------------------------------------------


def plot_cam_fit(fit):
    """Figure of a :class:`impactid.camprofile.CamProfileFit`: follower angle against cam angle with the
    fitted profile (top), residuals at the fitted points (middle), and the profile's analytic first
    and second derivatives with respect to the cam angle (bottom)."""
    from matplotlib.figure import Figure

    data = fit.data
    theta, value = fit.profile.sample(3600)
    _, first, second = fit.profile(theta, derivatives=2)
    fig = Figure(figsize=(8.0, 9.0), constrained_layout=True)
    axes = fig.subplots(3, 1, sharex=True)
    ax = axes[0]
    step = max(1, data.nsamples // 4000)  # a readable subsample of the (quantised) samples
    ax.plot(data.cam_angle[::step], data.follower_angle[::step], ".", ms=1.5, color="0.6",
            label=f"samples (1 in {step})")
    ax.plot(data.fit_cam_angle, data.fit_follower_angle, ".", ms=2.5, color="C0", label=f"fitted: {data.fit_points}")
    ax.plot(theta, value, "-", color="C3", lw=1.2, label=f"{fit.terms}-term Gaussian sum")
    ax.set(ylabel="follower angle [rad]",
           title=f"{data.source or 'recording'}: cam profile, {len(data.used_revolutions)} revolution(s)")
    ax.legend(fontsize=8, loc="best")
    ax = axes[1]
    ax.plot(data.fit_cam_angle, 1e3 * fit.residuals(), ".", ms=2.5, color="C0")
    ax.axhline(0.0, color="0.3", lw=0.8)
    ax.set(ylabel="residual [mrad]",
           title=f"residual RMS {fit.rms_residual * 1e3:.3g} mrad, max {fit.max_residual * 1e3:.3g} mrad")
    ax = axes[2]
    ax.plot(theta, first, "-", color="C2", label="d theta_f / d theta_c [rad/rad]")
    ax.plot(theta, second, "-", color="C4", label="d2 theta_f / d theta_c2 [rad/rad^2]")
    ax.axhline(0.0, color="0.3", lw=0.8)
    ax.set(xlabel="cam angle (recording's convention) [rad]", ylabel="derivative", xlim=(0.0, 2.0 * np.pi))
    ax.legend(fontsize=8, loc="best")
    for ax in axes:
        ax.grid(True, alpha=0.3)
    return fig


def plot_cam_fit_order(fit):
    """AIC and BIC against the number of Gaussian terms (``terms="auto"`` fits only)."""
    from matplotlib.figure import Figure

    table = fit.order_table
    fig = Figure(figsize=(6.0, 4.2), constrained_layout=True)
    ax = fig.subplots()
    ax.plot(table["terms"], table["aic"], "o-", label="AIC")
    ax.plot(table["terms"], table["bic"], "s-", label="BIC")
    chosen = table[table["chosen"]]
    ax.plot(chosen["terms"], chosen[fit.criterion], "r*", ms=14, label=f"chosen by {fit.criterion.upper()}")
    ax.set(xlabel="Gaussian terms", ylabel="information criterion", title="cam-profile order selection")
    ax.grid(True, alpha=0.3)
    ax.legend()
    return fig


def cam_fit_figures(fit, out_dir: str | os.PathLike[str], staged: StagedFiles | None = None) -> list[Path]:
    """Write ``cam_fit.png`` (:func:`plot_cam_fit`) and, for ``terms="auto"``, ``cam_fit_order.png``
    (:func:`plot_cam_fit_order`) into ``out_dir``, atomically."""

    out = Path(out_dir)
    written = []
    figures = [("cam_fit.png", plot_cam_fit)]
    if fit.order_table is not None:
        figures.append(("cam_fit_order.png", plot_cam_fit_order))
    with _transaction(staged) as st:
        for name, make in figures:
            fig = make(fit)
            written.append(save_figure_atomic(fig, out / name, st, dpi=120))
    return written

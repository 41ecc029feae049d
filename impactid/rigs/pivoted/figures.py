"""Rig P's figures: the regime map, the estimate's figures (``impactid estimate --plots``) and the
kinematics spline study. matplotlib is imported lazily."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd

from impactid._files import StagedFiles
from impactid.reports import REGIME_COLOURS, save_figure_atomic, staged_transaction, write_csv_atomic

__all__ = ["estimate_figures", "period1_band", "plot_kinematics_spline_study", "plot_regime_map", "write_regime_map"]


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
    with staged_transaction(staged) as st:
        csv = write_csv_atomic(frame, out_dir / "regime_map.csv", st)
        fig = plot_regime_map(frame)
        png = save_figure_atomic(fig, out_dir / "regime_map.png", st, dpi=120)
    return [csv, png]


def period1_band(frame: pd.DataFrame) -> pd.DataFrame:
    """Per e/r_c, the cam speeds classified period-1 (min, max and count) in a regime-map frame."""
    rows = []
    for ratio, group in frame.groupby("e_over_rc"):
        p1 = group[group["regime"] == "period-1"]["cam_speed_hz"].to_numpy()
        rows.append({"e_over_rc": ratio, "period1_min_hz": float(np.min(p1)) if p1.size else np.nan,
                     "period1_max_hz": float(np.max(p1)) if p1.size else np.nan, "period1_points": int(p1.size)})
    return pd.DataFrame(rows)


def estimate_figures(result, out_dir: str | os.PathLike[str], staged: StagedFiles | None = None) -> list[Path]:
    """Write the figures of an :class:`impactid.rigs.pivoted.estimates.Estimate` to ``out_dir`` (PNG), atomically.

    ``hysteresis.png``: contact force against indentation of the median-speed impact, measured
    (S-21, when the recording has pivot forces) and simulated at the estimate (Fig. 7 of Sundar, Dreyer & Singh (2016));
    ``restitution.png``: ``xi`` against ``v_a`` with the fitted laws (Fig. 10);
    ``landscape.png``: mean residual over (n, beta) with the valley and the estimate;
    ``residuals.png``: per-impact residual at the estimate.
    """

    from impactid.rigs.pivoted.estimates import objective_landscape

    out = Path(out_dir)
    d, r = result.damping, result.restitution
    written = []
    with staged_transaction(staged) as st:
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


def plot_kinematics_spline_study(studies: dict[str, pd.DataFrame]):
    """Relative error of the spline-differentiated follower acceleration and velocity against the
    number of nodes per revolution, log-log (as Figs. 5 and 7 of Lee (2005)).

    ``studies`` maps a profile label to a table of :func:`impactid.rigs.flat.cam_kinematics.spline_error_study`.
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

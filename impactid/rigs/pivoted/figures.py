"""Rig P's figures: the regime map, the estimate's figures (``impactid estimate --plots``) and the
kinematics spline study, in the package's style (:mod:`impactid.plotting`). matplotlib is imported
lazily."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd

from impactid._files import StagedFiles
from impactid.plotting import MEASURED, OKABE_ITO, SIMULATED, UNITLESS, axis_label, number, styled
from impactid.reports import REGIME_COLOURS, save_figure_atomic, staged_transaction, write_csv_atomic

__all__ = ["estimate_figures", "period1_band", "plot_contacts", "plot_kinematics_spline_study", "plot_regime_map",
           "write_regime_map"]

#: The residuals in the paper's words (Sundar, Dreyer & Singh (2016): Lambda_1 to Lambda_3).
RESIDUAL_LABELS = {
    "lambda1": r"relative error of the maximum follower angle $\Lambda_1$",
    "lambda2": r"relative force-history misfit $\Lambda_2$",
    "lambda3": r"relative hysteresis-area error $\Lambda_3$",
}
#: Short symbols of the residuals, for titles and colour bars.
RESIDUAL_SYMBOLS = {"lambda1": r"$\Lambda_1$", "lambda2": r"$\Lambda_2$", "lambda3": r"$\Lambda_3$"}
#: Impacts drawn in the measured-and-simulated figure (slowest, median and fastest approach).
CONTACTS_SHOWN = 3


@styled
def plot_regime_map(frame: pd.DataFrame):
    """Regime map figure (cam speed versus e/r_c, as Fig. 3 of Sundar, Dreyer & Singh (2016))."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8.0, 4.8), layout="constrained")
    ax = fig.subplots()
    for regime, colour in REGIME_COLOURS.items():
        sel = frame[frame["regime"] == regime]
        if len(sel):
            ax.scatter(sel["e_over_rc"], sel["cam_speed_hz"], s=36, marker="s", color=colour, label=regime)
    det = frame.groupby("e_over_rc")["detachment_hz"].first()
    ax.plot(det.index, det.to_numpy(), "k--", lw=1.2, label="detachment (inverse kinematics)")
    ax.set_xlabel(axis_label("eccentricity ratio", None, "e/r_c"))
    ax.set_ylabel(axis_label("cam speed", "Hz", r"\Omega_c"))
    ax.set_title("Motion regimes of rig P (long simulations from the static equilibrium)")
    ax.legend(title="motion", loc="upper left", bbox_to_anchor=(1.02, 1.0))
    return fig


def write_regime_map(frame: pd.DataFrame, out_dir: str | os.PathLike[str],
                     staged: StagedFiles | None = None, fmt: str | None = None) -> list[Path]:
    """Write ``regime_map.csv`` and ``regime_map.png`` (or ``.svg``, ``.pdf``: ``fmt``, see
    :func:`impactid.plotting.save_figure`) into ``out_dir`` (one transaction)."""

    out_dir = Path(out_dir)
    with staged_transaction(staged) as st:
        csv = write_csv_atomic(frame, out_dir / "regime_map.csv", st)
        fig = plot_regime_map(frame)
        png = save_figure_atomic(fig, out_dir / "regime_map.png", st, fmt)
    return [csv, png]


def period1_band(frame: pd.DataFrame) -> pd.DataFrame:
    """Per e/r_c, the cam speeds classified period-1 (min, max and count) in a regime-map frame."""
    rows = []
    for ratio, group in frame.groupby("e_over_rc"):
        p1 = group[group["regime"] == "period-1"]["cam_speed_hz"].to_numpy()
        rows.append({"e_over_rc": ratio, "period1_min_hz": float(np.min(p1)) if p1.size else np.nan,
                     "period1_max_hz": float(np.max(p1)) if p1.size else np.nan, "period1_points": int(p1.size)})
    return pd.DataFrame(rows)


def estimate_figures(result, out_dir: str | os.PathLike[str], staged: StagedFiles | None = None,
                     fmt: str | None = None) -> list[Path]:
    """Write the figures of an :class:`impactid.rigs.pivoted.estimates.Estimate` to ``out_dir``, atomically.

    ``hysteresis.png``: measured and simulated contacts of three impacts (the slowest, median and
    fastest approach; :func:`plot_contacts`): indentation against time and contact force against
    indentation (Fig. 7 of Sundar, Dreyer & Singh (2016)), the measurement against the simulation
    at the estimated law;
    ``restitution.png``: the coefficient of restitution against the approach speed with the fitted laws (Fig. 10);
    ``landscape.png``: mean residual over (n, beta) with the valley and the estimate;
    ``residuals.png``: per-impact residual at the estimate.
    PNG at 200 dpi, or SVG or PDF (``fmt``, else :func:`impactid.plotting.figure_format`'s).
    """

    from impactid.rigs.pivoted.estimates import objective_landscape

    out = Path(out_dir)
    d, r = result.damping, result.restitution
    written = []
    with staged_transaction(staged) as st:
        _estimate_figures(result, d, r, out, st, written, objective_landscape, fmt)
    return written


def _time_scale(t_max: float) -> tuple[float, str]:
    """Factor and unit to show times up to ``t_max`` [s] in (µs below 2 ms, else ms)."""
    return (1e6, "µs") if t_max < 2e-3 else (1e3, "ms")


@styled
def plot_contacts(event_set, beta: float, n: float, count: int = CONTACTS_SHOWN):
    """Measured and simulated contacts of a few impacts of one recording (an
    :class:`~impactid.rigs.pivoted.residuals.EventSet`): one column per impact (the slowest, median
    and fastest approach), the indentation against the time from the onset (top) and the contact
    force against the indentation (bottom: the hysteresis loop, Fig. 7 of Sundar, Dreyer & Singh
    (2016)); the measurement (dots: indentation reconstructed from the accelerometer, force from the
    pivot force sensors when the recording has them) against the simulation of the impact from its
    measured onset state at the law ``beta, n``."""
    from matplotlib.figure import Figure

    es = event_set
    order = np.argsort(es.approach_speed)
    picks = [int(order[k]) for k in sorted({0, len(order) // 2, len(order) - 1})][:max(count, 1)]
    batch = es.subset(np.array(picks)).simulate(np.array([[beta, n]]), histories=True)
    off = batch.grid_offsets
    scale, unit = _time_scale(max(float(np.max(es.t[i])) for i in picks))
    fig = Figure(figsize=(3.3 * len(picks) + 0.6, 6.0), layout="constrained")
    axes = fig.subplots(2, len(picks), squeeze=False)
    for col, i in enumerate(picks):
        t = np.asarray(es.t[i])
        cols = slice(off[col], off[col + 1])
        sim_delta = np.maximum(-np.asarray(batch.gap[0, cols]), 0.0)
        sim_force = np.asarray(batch.contact_force[0, cols])
        ax = axes[0, col]
        ax.plot(scale * t, 1e6 * np.asarray(es.indentation[i]), "o", ms=3, color=MEASURED,
                label="measured (accelerometer)")
        ax.plot(scale * t, 1e6 * sim_delta, "-", color=SIMULATED, label="simulation at the estimated law")
        ax.set_xlabel(axis_label("time from the contact onset", unit, "t"))
        ax.set_ylabel(axis_label("indentation", "µm", r"\delta"))
        ax.set_title(f"impact {int(es.events[i])}: $v_a$ = {es.approach_speed[i]:.3g} m/s")
        ax = axes[1, col]
        if es.force is not None:
            ax.plot(1e6 * np.asarray(es.indentation[i]), np.asarray(es.force[i]), "o", ms=3, color=MEASURED,
                    label="measured (pivot force sensors)")
        ax.plot(1e6 * sim_delta, sim_force, "-", color=SIMULATED, label="simulation at the estimated law")
        ax.set_xlabel(axis_label("indentation", "µm", r"\delta"))
        ax.set_ylabel(axis_label("contact force", "N", "F_c"))
    axes[0, 0].legend(loc="best")
    axes[1, 0].legend(loc="best")
    fig.suptitle(f"{Path(str(es.source)).name}: measured and simulated contacts, "
                 rf"$\beta$ = {number(beta)} N s m$^{{-{n + 1:.3g}}}$, $n$ = {n:.3g}")
    return fig


@styled
def plot_restitution(restitution):
    """The coefficient of restitution of each impact against its approach speed, with the fitted
    laws (Fig. 10 of Sundar, Dreyer & Singh (2016))."""
    from matplotlib.figure import Figure

    r = restitution
    frame = r.per_impact[r.per_impact["used"]]
    fig = Figure(figsize=(6.0, 4.5), layout="constrained")
    ax = fig.subplots()
    ax.plot(frame["approach_speed"], frame["xi"], "o", ms=4, color=MEASURED, label="impacts (measured)")
    v = np.linspace(0.0, max(float(frame["approach_speed"].max()) * 1.2, 1e-3), 50)
    ax.plot(v, 1.0 - r.gamma * v, "-", color=SIMULATED,
            label=rf"linear law $\xi = 1 - \gamma v_a$, $\gamma$ = {r.gamma:.4g} s/m")
    ax.axhline(r.r_constant, ls="--", color=OKABE_ITO["blue"], label=f"constant law, $r$ = {r.r_constant:.4g}")
    ax.set(xlabel=axis_label("approach speed", "m/s", "v_a"),
           ylabel=axis_label("coefficient of restitution", None, r"\xi"), ylim=(0, 1.05),
           title="Restitution of the impacts (Fig. 10 of Sundar, Dreyer & Singh (2016))")
    ax.legend(loc="lower left")
    return fig


@styled
def plot_landscape(damping, land):
    """The mean residual over ``(n, log10 beta)`` with the valley ``beta(n)`` and the estimate."""
    from matplotlib import patheffects
    from matplotlib.figure import Figure

    d = damping
    fig = Figure(figsize=(6.5, 4.8), layout="constrained")
    ax = fig.subplots()
    nn = np.repeat(land.n[:, None], land.log10_c.size, axis=1)
    mesh = ax.pcolormesh(nn, np.log10(land.beta), np.log10(land.objective), shading="auto", cmap="viridis")
    symbol = RESIDUAL_SYMBOLS.get(d.residual, "residual")
    fig.colorbar(mesh, ax=ax, label=rf"$\log_{{10}}$ of the mean residual {symbol} [-]")
    outline = [patheffects.Stroke(linewidth=3.2, foreground="black"), patheffects.Normal()]
    ax.plot(d.valley["n"], np.log10(d.valley["beta"]), "-", color="white", lw=1.6, path_effects=outline,
            label=r"valley $\beta(n)$ (least residual for each $n$)")
    ax.plot([d.n], [np.log10(d.beta)], "*", ms=15, color=OKABE_ITO["orange"], mec="black", mew=0.8,
            label="estimate")
    ax.set(xlabel=axis_label("force exponent", None, "n"),
           ylabel=r"damping coefficient $\log_{10}\beta$ [$\beta$ in N s m$^{-(n+1)}$]",
           title="Objective landscape")
    ax.grid(False)
    ax.legend(loc="lower right")
    return fig


@styled
def plot_residuals(damping):
    """The residual of each impact at the estimate (one colour per recording)."""
    from matplotlib.figure import Figure

    d = damping
    fig = Figure(figsize=(6.5, 4.0), layout="constrained")
    ax = fig.subplots()
    for source, part in d.per_event.groupby("source", sort=False):
        ax.plot(part["event"], part["residual"], "o", ms=4, label=Path(str(source)).name)
    ax.axhline(0.0, color="0.4", lw=0.8)
    label = RESIDUAL_LABELS.get(d.residual, "residual")
    ax.set(xlabel=axis_label("impact number in the recording", None),
           ylabel=f"{label}, signed {UNITLESS}",
           title=f"Residual of each impact at the estimate, mean absolute value {d.objective:.3g}")
    ax.legend(title="recording")
    return fig


def _estimate_figures(result, d, r, out, st, written, objective_landscape, fmt) -> None:
    es = result.event_sets[0]
    fig = plot_contacts(es, d.beta, d.n)
    written.append(save_figure_atomic(fig, out / "hysteresis.png", st, fmt))
    # restitution (absent when no impact had a determined xi)
    if r is not None:
        written.append(save_figure_atomic(plot_restitution(r), out / "restitution.png", st, fmt))
    # landscape with the valley
    # (the figure's own landscape: 31 x 31 about the estimate, +-0.5 in n and +-1.5 decades of c, where
    # the valley is; the full bounds cost twice the simulations, mostly of implausible laws)
    land = d.landscape or objective_landscape(
        list(result.event_sets), d.residual, delta_ref=d.delta_ref,
        n_values=np.linspace(max(d.n - 0.5, 0.0), d.n + 0.5, 31),
        c_values=d.damping_at_reference * np.logspace(-1.5, 1.5, 31))
    written.append(save_figure_atomic(plot_landscape(d, land), out / "landscape.png", st, fmt))
    written.append(save_figure_atomic(plot_residuals(d), out / "residuals.png", st, fmt))


@styled
def plot_kinematics_spline_study(studies: dict[str, pd.DataFrame]):
    """Relative error of the spline-differentiated follower acceleration and velocity against the
    number of nodes per revolution, log-log (as Figs. 5 and 7 of Lee (2005)).

    ``studies`` maps a profile label to a table of :func:`impactid.rigs.flat.cam_kinematics.spline_error_study`.
    Solid lines: maximum relative error; dashed: RMS relative error; dotted grey: slopes N^-2
    (acceleration) and N^-3 (velocity), the orders of a periodic cubic spline on a smooth profile.
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=(10.0, 4.4), layout="constrained")
    axes = fig.subplots(1, 2)
    panels = (("acceleration", 2.0), ("velocity", 3.0))
    for ax, (quantity, order) in zip(axes, panels):
        for k, (label, frame) in enumerate(studies.items()):
            colour = f"C{k}"
            n = frame["nodes"].to_numpy(float)
            ax.loglog(n, frame[f"max_rel_error_{quantity}"], "o-", color=colour, ms=4, label=f"{label}: maximum")
            ax.loglog(n, frame[f"rms_rel_error_{quantity}"], "s--", color=colour, ms=3, lw=1.0,
                      label=f"{label}: RMS")
        if studies:
            first = next(iter(studies.values()))
            n = first["nodes"].to_numpy(float)
            mid = len(n) // 2
            anchor = 0.2 * float(first[f"rms_rel_error_{quantity}"].iloc[mid])  # below the data, visible
            ax.loglog(n, anchor * (n / n[mid]) ** -order, ":", color="0.4", lw=1.5, label=f"slope $N^{{-{order:g}}}$")
        ax.set(xlabel=axis_label("nodes per revolution", None, "N"),
               ylabel=axis_label(f"relative {quantity} error", None),
               title=f"Follower angular {quantity}: spline against analytic")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
    return fig

"""Reports: tables and figures written to disk (atomically). matplotlib is imported lazily."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

REGIME_COLOURS = {"contact": "#4c72b0", "period-1": "#55a868", "period-k": "#dd8452", "irregular": "#c44e52"}


def _atomic_target(path: Path):
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    return Path(tmp)


def write_csv_atomic(frame: pd.DataFrame, path: str | os.PathLike[str]) -> Path:
    """Write a DataFrame as CSV through a temporary file and a rename."""
    path = Path(path)
    tmp = _atomic_target(path)
    try:
        frame.to_csv(tmp, index=False)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


def save_figure_atomic(fig, path: str | os.PathLike[str], **kwargs) -> Path:
    """Save a matplotlib figure through a temporary file and a rename."""
    path = Path(path)
    tmp = _atomic_target(path)
    try:
        fig.savefig(tmp, format=path.suffix.lstrip(".") or "png", **kwargs)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


def plot_regime_map(frame: pd.DataFrame):
    """Regime map figure (cam speed versus e/r_c, as Fig. 3 of seed 001)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8.0, 4.8), constrained_layout=True)
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


def write_regime_map(frame: pd.DataFrame, out_dir: str | os.PathLike[str]) -> list[Path]:
    """Write ``regime_map.csv`` and ``regime_map.png`` into ``out_dir``."""
    import matplotlib.pyplot as plt

    out_dir = Path(out_dir)
    csv = write_csv_atomic(frame, out_dir / "regime_map.csv")
    fig = plot_regime_map(frame)
    try:
        png = save_figure_atomic(fig, out_dir / "regime_map.png", dpi=120)
    finally:
        plt.close(fig)
    return [csv, png]


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


def estimate_figures(result, out_dir: str | os.PathLike[str]) -> list[Path]:
    """Write the figures of an :class:`impactid.estimates.Estimate` to ``out_dir`` (PNG), atomically.

    ``hysteresis.png``: contact force against indentation of the median-speed impact, measured
    (S-21, when the recording has pivot forces) and simulated at the estimate (Fig. 7 of seed 001);
    ``restitution.png``: ``xi`` against ``v_a`` with the fitted laws (Fig. 10);
    ``landscape.png``: mean residual over (n, beta) with the valley and the estimate;
    ``residuals.png``: per-impact residual at the estimate.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from impactid.estimates import objective_landscape

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    d, r = result.damping, result.restitution
    written = []
    # hysteresis loop of the median-speed event of the first recording
    es = result.event_sets[0]
    i = int(np.argsort(es.approach_speed)[len(es) // 2])
    one = es.subset(i)
    batch = one.simulate(np.array([[d.beta, d.n]]), histories=True)
    fig, ax = plt.subplots(figsize=(6, 4.5))
    if es.force is not None:
        ax.plot(1e6 * es.indentation[i], es.force[i], "o-", ms=3, label="measured (S-21)")
    ax.plot(1e6 * np.maximum(-batch.gap[0], 0.0), batch.contact_force[0], "-", label="S1 at the estimate")
    ax.set(xlabel="indentation [um]", ylabel="contact force [N]",
           title=f"{es.source}: event {int(es.events[i])}, beta={d.beta:.4g}, n={d.n:.3g}")
    ax.legend()
    written.append(save_figure_atomic(fig, out / "hysteresis.png", dpi=120))
    plt.close(fig)
    # restitution
    frame = r.per_impact[r.per_impact["used"]]
    fig, ax = plt.subplots(figsize=(6, 4.5))
    ax.plot(frame["approach_speed"], frame["xi"], "o", ms=4, label="impacts")
    v = np.linspace(0.0, max(float(frame["approach_speed"].max()) * 1.2, 1e-3), 50)
    ax.plot(v, 1.0 - r.gamma * v, "-", label=f"xi = 1 - gamma v_a, gamma = {r.gamma:.4g} s/m")
    ax.axhline(r.r_constant, ls="--", color="0.5", label=f"constant r = {r.r_constant:.4g}")
    ax.set(xlabel="approach speed v_a [m/s]", ylabel="xi", ylim=(0, 1.05), title="restitution (Fig. 10 of seed 001)")
    ax.legend()
    written.append(save_figure_atomic(fig, out / "restitution.png", dpi=120))
    plt.close(fig)
    # landscape with the valley
    land = d.landscape or objective_landscape(list(result.event_sets), d.residual, delta_ref=d.delta_ref)
    fig, ax = plt.subplots(figsize=(6.5, 4.8))
    nn = np.repeat(land.n[:, None], land.log10_c.size, axis=1)
    mesh = ax.pcolormesh(nn, np.log10(land.beta), np.log10(land.objective), shading="auto", cmap="viridis")
    fig.colorbar(mesh, ax=ax, label=f"log10 mean {d.residual}")
    ax.plot(d.valley["n"], np.log10(d.valley["beta"]), "w-", lw=1.5, label="valley beta(n)")
    ax.plot([d.n], [np.log10(d.beta)], "r*", ms=12, label="estimate")
    ax.set(xlabel="n", ylabel="log10 beta [N s m^-(n+1)]", title="objective landscape")
    ax.legend(loc="lower right")
    written.append(save_figure_atomic(fig, out / "landscape.png", dpi=120))
    plt.close(fig)
    # per-impact residuals
    fig, ax = plt.subplots(figsize=(6.5, 4))
    for source, part in d.per_event.groupby("source", sort=False):
        ax.plot(part["event"], part["residual"], "o", ms=4, label=str(source))
    ax.axhline(0.0, color="0.4", lw=0.8)
    ax.set(xlabel="event", ylabel=f"{d.residual} (signed)", title=f"per-impact residuals, mean |.| = {d.objective:.3g}")
    ax.legend(fontsize=8)
    written.append(save_figure_atomic(fig, out / "residuals.png", dpi=120))
    plt.close(fig)
    return written

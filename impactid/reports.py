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

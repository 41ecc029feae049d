"""The file writers every rig's reports use: tables and figures written to disk atomically, or staged
in a transaction of files committed together. Each rig draws its own figures (its ``figures`` module);
matplotlib is imported by them, lazily."""

from __future__ import annotations

import contextlib
import os
from pathlib import Path

import pandas as pd

from impactid._files import StagedFiles, atomic_write

__all__ = ["REGIME_COLOURS", "save_figure_atomic", "staged_transaction", "write_csv_atomic"]

REGIME_COLOURS = {"contact": "#4c72b0", "period-1": "#55a868", "period-k": "#dd8452", "irregular": "#c44e52"}


@contextlib.contextmanager
def staged_transaction(staged: StagedFiles | None):
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


# ---------------------------------------------------------------------------------------------
# contact-point kinematics: analytic derivatives against a differentiated spline (Lee 2005)
# ---------------------------------------------------------------------------------------------


# ---------------------------------------------------------------------------------------------
# cam-profile fit figures (impactid cam-fit --plots)
# ---------------------------------------------------------------------------------------------

"""The file writers every rig's reports use: tables and figures written to disk atomically, or staged
in a transaction of files committed together. Each rig draws its own figures (its ``figures`` module)
in the package's style (:mod:`impactid.plotting`); matplotlib is imported by them, lazily."""

from __future__ import annotations

import contextlib
import os
from pathlib import Path

import pandas as pd

from impactid._files import StagedFiles, atomic_write
from impactid.plotting import REGIME_COLOURS, save_figure

__all__ = ["REGIME_COLOURS", "save_figure_atomic", "staged_transaction", "write_csv_atomic"]


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


def save_figure_atomic(fig, path: str | os.PathLike[str], staged: StagedFiles | None = None, fmt: str | None = None,
                       **kwargs) -> Path:
    """Save a matplotlib figure, atomically (or staged in ``staged``, committed with it).

    PNG at 200 dpi, or SVG or PDF (:func:`impactid.plotting.save_figure`: the format is ``fmt``, else
    the one :func:`impactid.plotting.figure_format` set, else the suffix of ``path``, which is
    replaced by the format's). Returns the path written.
    """
    return save_figure(fig, path, staged, fmt, **kwargs)

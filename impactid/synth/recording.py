"""The synthetic recording every rig's synthesiser returns: the recording and what generated it."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from impactid.io import Recording, write_hdf5

__all__ = ["SyntheticRecording"]


@dataclass(frozen=True)
class SyntheticRecording:
    """A synthetic recording and what generated it.

    Attributes
    ----------
    recording : the :class:`~impactid.io.Recording` (SI units, the rig and operating point attached).
    truth : what generated it, written to the file's ``/truth`` group, which impactid's estimators
        never read.
    exact : the noise-free channels at the sample instants, where the synthesiser keeps them
        (empty otherwise).
    """

    recording: Recording
    truth: dict[str, Any] = field(default_factory=dict)
    exact: Mapping[str, np.ndarray] = field(default_factory=dict)

    def write(self, path) -> Path:
        """Write as HDF5 (docs/formats.md) with the ``/truth`` group, atomically; returns the path."""
        return write_hdf5(self.recording, path, truth=dict(self.truth))

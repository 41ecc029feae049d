import numpy as np
import pytest

from tests.rigs.tracks.reference_tracks import bouncing_track


@pytest.fixture(scope="session")
def spinning_bounce():
    """A 3-D table-tennis bounce at 240 Hz with 1 mm noise: topspin and sidespin, e_n 0.9, mu 0.25."""
    return bouncing_track(np.array([0.0, 0.9, 0.25]), np.array([0.3, -6.0, -1.2]), np.array([-150.0, 20.0, 40.0]),
                          e_n=0.9, mu=0.25, duration=0.3, rate=240.0, noise=1e-3, seed=3, bounces=1)


def write_track(path, times, pos, *, sep=";", header=None, scale=1.0):
    """A track file: ``header`` (None: none) then rows t, x, y, z."""
    lines = [] if header is None else [header]
    lines += [sep.join(f"{v:.6f}" for v in (t, *(p * scale))) for t, p in zip(times, pos)]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path

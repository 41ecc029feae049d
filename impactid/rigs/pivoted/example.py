"""The built-in example: two recordings of one rig, generated deterministically on first use and cached.

Two period-1 operating points of the rig P of Sundar, Dreyer & Singh (2016) with the same contact
law (beta = 24.7 GN s m^-2.5, n = 1.5): e/r_c = 0.05 at 16 Hz (approach speed 0.22 m/s) and
e/r_c = 0.25 at 15 Hz (0.69 m/s). With impacts at two approach speeds this far apart, beta and n
can be told apart at 0.2 % noise (one operating point alone gives a valley of equally good
(beta, n) pairs: notebook 01 shows that case; e/r_c 0.2 at 16 Hz with 0.25 at 15 Hz, approach
speeds 0.49 and 0.69 m/s, is still not enough: n from 1.23 to 1.63). Each recording is one
second at 204.8 kHz after 40 s of settling, with a realistic but mild acquisition chain: 0.2 %
Gaussian noise on the accelerometer and force channels and a 24-bit ADC. Generating them takes
about a second once the simulator is compiled; the files (about 6.5 MB each) are cached in
``$IMPACTID_CACHE_DIR`` (default ``$XDG_CACHE_HOME/impactid`` or ``~/.cache/impactid``) under
names that change whenever the recipe changes.
"""

from __future__ import annotations

import hashlib
import json
import tempfile
from pathlib import Path

from impactid._cachedir import user_cache_root
from impactid.contact import HuntCrossley
from impactid.io import Recording, read_recording
from impactid.rigs.pivoted import SUNDAR2016
from impactid.rigs.pivoted.synth import synth_pivoted
from impactid.synth.sensors import SensorModel

__all__ = ["EXAMPLE_POINTS", "EXAMPLE_RECIPE", "cache_dir", "example_recording", "example_recording_path",
           "example_recording_paths"]

#: What the two example recordings share; its hash and each point name the cached files.
EXAMPLE_RECIPE = {
    "beta": 24.7e9, "n": 1.5, "duration": 1.0, "settle_s": 40.0, "sample_rate_hz": 204_800.0, "noise": 0.002,
    "adc_bits": 24, "seed": 2016, "recipe_version": 2,
}
#: The operating points ``(e/r_c, cam speed [Hz])`` of the example recordings.
EXAMPLE_POINTS = ((0.05, 16.0), (0.25, 15.0))


def cache_dir() -> Path:
    """Folder of cached generated data: impactid's user cache (``$IMPACTID_CACHE_DIR`` when set; the
    compiled kernels' folder is beside it, :mod:`impactid._cachedir`), or a temporary folder without a
    home folder."""
    root = user_cache_root()
    return root if root is not None else Path(tempfile.gettempdir()) / "impactid"


def example_recording_paths(refresh: bool = False) -> list[Path]:
    """Paths of the two example recordings (HDF5 with ``/truth``), generating them if needed."""
    return [_example_path(k, refresh) for k in range(len(EXAMPLE_POINTS))]


def example_recording_path(refresh: bool = False) -> Path:
    """Path of the first example recording (e/r_c = 0.05, 16 Hz)."""
    return _example_path(0, refresh)


def example_recording() -> Recording:
    """The first example recording, read like any user file (its ``/truth`` is not loaded)."""
    return read_recording(example_recording_path())


def _example_path(k: int, refresh: bool) -> Path:
    e_over_rc, cam_speed_hz = EXAMPLE_POINTS[k]
    recipe = dict(EXAMPLE_RECIPE, e_over_rc=e_over_rc, cam_speed_hz=cam_speed_hz)
    key = hashlib.sha256(json.dumps(recipe, sort_keys=True).encode()).hexdigest()[:12]
    path = cache_dir() / f"example-rigP-{k + 1}-{key}.h5"
    if path.exists() and not refresh:
        return path
    r = recipe
    synthetic = synth_pivoted(
        SUNDAR2016.with_eccentricity_ratio(e_over_rc), cam_speed_hz, HuntCrossley(r["beta"], r["n"]),
        r["duration"], settle_s=r["settle_s"], sample_rate_hz=r["sample_rate_hz"],
        sensors=SensorModel(noise=r["noise"], adc_bits=r["adc_bits"], seed=r["seed"] + k))
    synthetic.truth["recipe"] = json.dumps(r)
    synthetic.write(path)  # atomic: a concurrent reader never sees a partial file
    return path

"""The built-in example recording: generated deterministically on first use and cached.

The example is the seed's Table 3 operating point (e/r_c = 0.2, 16 Hz, beta = 24.7 GN s m^-2.5,
n = 1.5, mu = 0.2), one second (16 impacts) at 204.8 kHz after 40 s of settling, with a realistic
but mild acquisition chain: 0.2 % Gaussian noise on the accelerometer and force channels and a
24-bit ADC. Generating it takes well under a second once the simulator is compiled; the file
(about 6.5 MB) is cached in ``$IMPACTID_CACHE_DIR`` (default ``$XDG_CACHE_HOME/impactid`` or
``~/.cache/impactid``) under a name that changes whenever the recipe changes.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

from data_synth.pivoted import synth_pivoted
from data_synth.sensors import SensorModel
from impactid.contact import HuntCrossley
from impactid.rigs.pivoted import SEED001_TABLE1

#: Everything that defines the example; its hash names the cached file.
EXAMPLE_RECIPE = {
    "e_over_rc": 0.2, "cam_speed_hz": 16.0, "beta": 24.7e9, "n": 1.5, "duration": 1.0, "settle_s": 40.0,
    "sample_rate_hz": 204_800.0, "noise": 0.002, "adc_bits": 24, "seed": 2016, "recipe_version": 1,
}


def cache_dir() -> Path:
    """Folder of cached generated data."""
    if os.environ.get("IMPACTID_CACHE_DIR"):
        return Path(os.environ["IMPACTID_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "impactid"


def example_recording_path(refresh: bool = False) -> Path:
    """Path of the example recording (HDF5 with ``/truth``), generating it if needed."""
    key = hashlib.sha256(json.dumps(EXAMPLE_RECIPE, sort_keys=True).encode()).hexdigest()[:12]
    path = cache_dir() / f"example-rigP-{key}.h5"
    if path.exists() and not refresh:
        return path
    r = EXAMPLE_RECIPE
    synthetic = synth_pivoted(
        SEED001_TABLE1.with_eccentricity_ratio(r["e_over_rc"]), r["cam_speed_hz"], HuntCrossley(r["beta"], r["n"]),
        r["duration"], settle_s=r["settle_s"], sample_rate_hz=r["sample_rate_hz"],
        sensors=SensorModel(noise=r["noise"], adc_bits=r["adc_bits"], seed=r["seed"]))
    synthetic.truth["recipe"] = json.dumps(r)
    synthetic.write(path)  # atomic: a concurrent reader never sees a partial file
    return path

"""The built-in example: two recordings of one rig, generated deterministically on first use and cached.

Two period-1 operating points of the rig P of Sundar, Dreyer & Singh (2016) with the same contact
law (beta = 24.7 GN s m^-2.5, n = 1.5, :data:`EXAMPLE_RECIPE`): e/r_c = 0.05 at 15 Hz (approach
speed 0.27 m/s) and e/r_c = 0.25 at 12 Hz (0.95 m/s). Impacts at approach speeds a factor 3.5 apart
tell beta and n apart (one operating point alone gives a valley of equally good (beta, n) pairs:
notebook 01 shows that case); both points keep their impacts away from the top of the cam's lift,
where the onset angles would fix the cam phase poorly (e/r_c 0.25 at 15 Hz, the example's second
point before recipe version 3, put n's 95 % interval at +-0.06 through the phase alone). Each
recording is three seconds at 204.8 kHz after 40 s of settling (44 and 35 impacts), with a good
laboratory acquisition chain: 0.05 % Gaussian noise (of each channel's peak) on the accelerometer
and force channels and a 24-bit ADC. That precision is what a joint fit needs to give n to about
+-0.005 and beta, whose value moves by a factor delta^-dn (delta ~ 25 um) with n, to within a factor
1.2 (95 %): at 0.2 % noise and one second per point the interval of beta spanned a factor 5.
``impactid estimate --example`` prints the recipe's values beside its estimates
(:func:`example_truth`, from this recipe, never from the files' ``/truth``). Generating the
recordings takes a few seconds once the simulator is compiled; the files (about 50 MB each) are
cached in ``$IMPACTID_CACHE_DIR`` (default ``$XDG_CACHE_HOME/impactid`` or ``~/.cache/impactid``)
under names that change whenever the recipe changes.
"""

from __future__ import annotations

import hashlib
import json
import tempfile
from collections.abc import Sequence
from pathlib import Path

from impactid._cachedir import user_cache_root
from impactid.contact import HuntCrossley
from impactid.io import Recording, read_recording
from impactid.rigs.pivoted import SUNDAR2016
from impactid.rigs.pivoted.synth import synth_pivoted
from impactid.synth.sensors import SensorModel

__all__ = ["EXAMPLE_POINTS", "EXAMPLE_RECIPE", "cache_dir", "example_recording", "example_recording_path",
           "example_recording_paths", "example_truth"]

#: What the two example recordings share; its hash and each point name the cached files.
EXAMPLE_RECIPE = {
    "beta": 24.7e9, "n": 1.5, "duration": 3.0, "settle_s": 40.0, "sample_rate_hz": 204_800.0, "noise": 0.0005,
    "adc_bits": 24, "seed": 2016, "recipe_version": 3,
}
#: The operating points ``(e/r_c, cam speed [Hz])`` of the example recordings.
EXAMPLE_POINTS = ((0.05, 15.0), (0.25, 12.0))


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
    """Path of the first example recording (e/r_c = 0.05, 15 Hz)."""
    return _example_path(0, refresh)


def example_recording() -> Recording:
    """The first example recording, read like any user file (its ``/truth`` is not loaded)."""
    return read_recording(example_recording_path())


def example_truth(sources: Sequence[str | Path]) -> dict | None:
    """The contact law the example was made with, when ``sources`` are the example's recordings.

    Read from :data:`EXAMPLE_RECIPE` (never from the files' ``/truth``), for the printed summary and the
    JSON of ``impactid estimate --example``: ``{"beta": [N s m^-(n+1)], "n": [-], "recipe": {...}}``
    when every recording of the example, and nothing else, is among ``sources`` (recognised by their
    file names, which hold the recipe's hash); None otherwise (any other recordings, or an example
    made with another recipe).
    """
    names = sorted(Path(s).name for s in sources)
    if names != sorted(_example_name(k) for k in range(len(EXAMPLE_POINTS))):
        return None
    recipe = dict(EXAMPLE_RECIPE, points=[list(p) for p in EXAMPLE_POINTS])
    return {"beta": float(EXAMPLE_RECIPE["beta"]), "n": float(EXAMPLE_RECIPE["n"]), "recipe": recipe}


def _recipe(k: int) -> dict:
    e_over_rc, cam_speed_hz = EXAMPLE_POINTS[k]
    return dict(EXAMPLE_RECIPE, e_over_rc=e_over_rc, cam_speed_hz=cam_speed_hz)


def _example_name(k: int) -> str:
    key = hashlib.sha256(json.dumps(_recipe(k), sort_keys=True).encode()).hexdigest()[:12]
    return f"example-rigP-{k + 1}-{key}.h5"


def _example_path(k: int, refresh: bool) -> Path:
    recipe = _recipe(k)
    e_over_rc, cam_speed_hz = EXAMPLE_POINTS[k]
    path = cache_dir() / _example_name(k)
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

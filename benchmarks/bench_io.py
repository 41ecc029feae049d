"""Reading a recording: impactid's reader against a bare h5py read of the same datasets.

Writes a 60 s, four-channel recording at 204.8 kHz (about 12.3 million samples per channel) to a
temporary folder, then times (best of ``--repeat``):

* baseline: ``h5py.File`` + ``dataset[()]`` of the four channels (no checks);
* impactid: ``read_recording`` (format checks, unit conversion, finite-sample check, rig
  validation, read-only arrays and the clipping/shortness check).

Target (issue 3): impactid at most 2x the baseline. Run: ``python benchmarks/bench_io.py``.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np

from impactid import SUNDAR2016
from impactid.io import Recording, read_recording, write_hdf5

CHANNELS = {"accel_tangential": "m/s^2", "force_x": "N", "force_y": "N", "cam_angle": "rad"}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    rate = 204_800.0
    n = int(args.seconds * rate)
    rng = np.random.default_rng(0)
    t = np.arange(n) / rate
    data = {"accel_tangential": rng.normal(0, 50, n), "force_x": rng.normal(0, 5, n),
            "force_y": rng.normal(0, 5, n), "cam_angle": 2 * np.pi * 16 * t}
    rec = Recording(channels=data, sample_rate_hz=rate, units=CHANNELS, rig=SUNDAR2016,
                    operating={"cam_speed_hz": 16.0})
    with tempfile.TemporaryDirectory() as tmp:
        path = write_hdf5(rec, Path(tmp) / "bench.h5")
        size = path.stat().st_size / 1e6

        def bare():
            with h5py.File(path, "r") as fh:
                return [fh["signals"][name][()] for name in CHANNELS]

        def ours():
            return read_recording(path)

        timings = {}
        for label, fn in (("h5py (baseline)", bare), ("impactid read_recording", ours)):
            fn()  # warm the page cache and imports
            best = min(_time(fn) for _ in range(args.repeat))
            timings[label] = best
        base = timings["h5py (baseline)"]
        print(f"recording: {args.seconds:g} s x 4 channels at 204.8 kHz = {4 * n / 1e6:.1f} M samples, {size:.0f} MB")
        for label, seconds in timings.items():
            print(f"  {label:26s} {seconds * 1e3:8.1f} ms  {4 * n / seconds / 1e6:7.1f} M samples/s  "
                  f"ratio {seconds / base:5.2f}")
        ratio = timings["impactid read_recording"] / base
        print(f"target: ratio <= 2.0 -> {'met' if ratio <= 2.0 else 'MISSED'} ({ratio:.2f})")


def _time(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


if __name__ == "__main__":
    main()

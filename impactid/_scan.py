"""Compiled single passes over long channels (reading and checking recordings).

Reading a 60 s recording at 204.8 kHz means 12 million samples per channel; numpy's separate
``min``/``max``/``isfinite`` passes cost more than the HDF5 read itself. These kernels do the
checks in one pass each, in parallel over chunks; ``tests/test_io.py`` compares them with numpy.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from impactid import compilation

__all__ = ["channel_scan", "count_equal", "extreme_stats"]

compilation.install()  # the first-use notice (impactid.compilation)

_CHUNKS = 16


@njit(parallel=True, nogil=True, cache=True)
def channel_scan(x):  # pragma: no cover - compiled
    """``(min, max, finite)`` of a 1-D float array; ``finite`` is False if any sample is NaN or Inf."""
    n = x.shape[0]
    los = np.empty(_CHUNKS)
    his = np.empty(_CHUNKS)
    acc = np.empty(_CHUNKS)
    for c in prange(_CHUNKS):
        a = c * n // _CHUNKS
        b = (c + 1) * n // _CHUNKS
        lo = np.inf
        hi = -np.inf
        s = 0.0
        for i in range(a, b):
            v = x[i]
            lo = min(lo, v)
            hi = max(hi, v)
            s += v - v  # 0 for finite samples, NaN for NaN and +-Inf
        los[c] = lo
        his[c] = hi
        acc[c] = s
    total = acc.sum()
    return los.min(), his.max(), total == 0.0


@njit(nogil=True, cache=True)
def extreme_stats(x, value, neighbour_below):  # pragma: no cover - compiled
    """Samples equal to ``value``, their longest consecutive run, and the count of the nearest value
    on the inner side (below ``value`` if ``neighbour_below``, else above): one pass."""
    count = 0
    run = 0
    longest = 0
    nearest = -np.inf if neighbour_below else np.inf
    nearest_count = 0
    for i in range(x.shape[0]):
        v = x[i]
        if v == value:
            count += 1
            run += 1
            if run > longest:
                longest = run
        else:
            run = 0
            if neighbour_below:
                if v > nearest:
                    nearest = v
                    nearest_count = 1
                elif v == nearest:
                    nearest_count += 1
            else:
                if v < nearest:
                    nearest = v
                    nearest_count = 1
                elif v == nearest:
                    nearest_count += 1
    return count, longest, nearest_count


@njit(parallel=True, nogil=True, cache=True)
def count_equal(x, value):  # pragma: no cover - compiled
    """Number of samples equal to ``value`` (parallel over chunks)."""
    n = x.shape[0]
    counts = np.zeros(_CHUNKS, dtype=np.int64)
    for c in prange(_CHUNKS):
        k = 0.0
        for i in range(c * n // _CHUNKS, (c + 1) * n // _CHUNKS):
            k += 1.0 if x[i] == value else 0.0  # float select: vectorises (an int add of a bool does not)
        counts[c] = np.int64(k)
    return counts.sum()

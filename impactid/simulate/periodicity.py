"""Periodicity of a stroboscopic sequence of states (the regime classification of every cam rig)."""

from __future__ import annotations

import numpy as np

__all__ = ["find_period"]


def find_period(alpha: np.ndarray, rate: np.ndarray, alpha_scale: float, tol: float, max_period: int) -> int:
    """Smallest k such that the stroboscopic states repeat after k samples.

    Two tests must pass: neighbours ``k`` apart agree, and samples a large multiple ``M`` of ``k``
    apart (at least half the record) agree too. The second test rejects slowly decaying
    transients, whose neighbours differ by only ``A r^j (r^k - 1)`` when the decay ratio per
    revolution ``r`` is close to 1.
    """
    rate_scale = max(float(np.max(np.abs(rate))), 1e-12)
    n = alpha.size
    for k in range(1, max_period + 1):
        if n < 4 * k:
            break
        big = (n // 2 // k) * k
        ok = True
        for lag in (k, big):
            da = np.max(np.abs(alpha[lag:] - alpha[:-lag])) / alpha_scale
            dr = np.max(np.abs(rate[lag:] - rate[:-lag])) / rate_scale
            if not (da < tol and dr < tol):
                ok = False
                break
        if ok:
            return k
    return 0

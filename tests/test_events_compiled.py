"""The compiled routines of the event detector and the reconstruction against the ones they replace
(issue 27), on real event windows: every sub-sample edge the detector solves on a noise-free and a noisy
S2 recording, and the integration of every event's window (the numbers must be the same to the last bit).
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from scipy import optimize

import impactid.events as events_module
from impactid.events import find_events
from impactid.signal import _cumulative_rk4_arrays, cumulative_rk4


def _subsample_start_scipy(r, k_first: int, direction: int) -> float:
    """The sub-sample start as it was before the compiled solver: SciPy's ``brentq`` on the exponents'
    mismatch (the reference)."""
    r1, r2, r3 = (abs(v) for v in r[:3])
    if not (0.0 < r1 < r2 < r3):
        return k_first - 0.5 * direction

    def mismatch(s):
        p12 = math.log(r2 / r1) / math.log((1.0 + s) / s)
        p23 = math.log(r3 / r2) / math.log((2.0 + s) / (1.0 + s))
        return p12 - p23

    try:
        lo, hi = 1e-6, 1.0 - 1e-9
        if mismatch(lo) * mismatch(hi) < 0.0:
            s = optimize.brentq(mismatch, lo, hi, xtol=1e-12)
            p = math.log(r2 / r1) / math.log((1.0 + s) / s)
            if 0.5 <= p <= 4.0:
                return k_first - s * direction
    except (ValueError, ZeroDivisionError):
        pass
    rho = (r2 / r1) ** (1.0 / 1.5)
    if rho > 1.0:
        s = 1.0 / (rho - 1.0)
        if 0.0 < s <= 1.0:
            return k_first - s * direction
    return k_first - 0.5 * direction


def _edges_of(recording) -> list[tuple[np.ndarray, int, int]]:
    """The arguments of every sub-sample edge the detector solves on ``recording``."""
    seen = []
    original = events_module._subsample_start

    def record(r, k_first, direction):
        seen.append((np.array(r, dtype=float), k_first, direction))
        return original(r, k_first, direction)

    events_module._subsample_start = record
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            find_events(recording, warn=False)
    finally:
        events_module._subsample_start = original
    return seen


@pytest.mark.parametrize("fixture", ["s2_synthetic", "s2_noisy"])
def test_compiled_subsample_start_is_scipys_brentq_on_real_edges(fixture, request):
    edges = _edges_of(request.getfixturevalue(fixture).recording)
    assert len(edges) >= 30
    solved = 0
    for r, k_first, direction in edges:
        new = events_module._subsample_start(r, k_first, direction)
        old = _subsample_start_scipy(r, k_first, direction)
        assert new == old, (r, k_first, direction)
        solved += abs(new - k_first) not in (0.0, 0.5)
    assert solved >= 10  # edges that take the power-law solution, not a fallback


def test_compiled_subsample_start_falls_back_like_the_reference():
    rng = np.random.default_rng(7)
    triples = np.sort(np.abs(rng.normal(size=(2000, 3))) * 10.0 ** rng.uniform(-6, 3, (2000, 1)), axis=1)
    # exact powers (root inside), flat and tiny ratios (fallbacks), and unordered ones
    triples = np.vstack([triples, [[1.0, 2.0 ** 1.5, 3.0 ** 1.5], [1.0, 1.0 + 1e-15, 1.0 + 2e-15],
                                   [1e-300, 1.0, 2.0], [3.0, 2.0, 1.0], [0.0, 1.0, 2.0]]])
    for r in triples:
        assert events_module._subsample_start(r, 100, +1) == _subsample_start_scipy(r, 100, +1)
        assert events_module._subsample_start(r, 100, -1) == _subsample_start_scipy(r, 100, -1)


def test_compiled_rk4_integral_is_the_array_expressions_on_event_windows(s2_synthetic, s2_noisy):
    for syn in (s2_synthetic, s2_noisy):
        rec = syn.recording
        x = rec["accel_tangential"] / rec.rig.l_a
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            onsets = find_events(rec, warn=False).table["onset_index"].to_numpy()
        dt = 1.0 / rec.sample_rate_hz
        for k0, k1 in zip(onsets[:-1], onsets[1:]):
            window = x[k0:k1]
            rate = cumulative_rk4(window, dt)
            assert np.array_equal(rate, _cumulative_rk4_arrays(window, dt))
            assert np.array_equal(cumulative_rk4(rate, dt), _cumulative_rk4_arrays(rate, dt))
    for n in range(4, 9):  # the shortest windows: the one-sided ends meet
        y = np.random.default_rng(n).normal(size=n)
        assert np.array_equal(cumulative_rk4(y, 1e-3), _cumulative_rk4_arrays(y, 1e-3))

"""Free flight of rig P and the return-time anchor of the per-impact pipeline (S-19).

``I_b alpha_ddot = m_b g l_g cos(alpha) - F_s(alpha) d_x`` (S-9) is smooth and slow (its natural
frequency is a few Hz) over one cam revolution, so a fixed-step classical RK4 with a few thousand
steps is accurate to about 1e-13 rad; ``tests/simulate/test_freeflight.py`` checks it against
``scipy.integrate.solve_ivp`` (DOP853, rtol 1e-12). The variational equation is integrated
alongside, so the anchor's Newton iteration has the exact derivative of the end angle with
respect to the start angle.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from impactid.simulate import _kernel as K

#: RK4 steps per free flight (one cam revolution or less).
FREE_FLIGHT_STEPS = 2000


@njit(cache=True)
def _free_accel(a, p):
    return K._torque(a, p) / p[K.I_B]


@njit(cache=True)
def _free_accel_slope(a, p):
    """d(alpha_ddot)/d(alpha) of free flight (central difference of the torque, h = 1e-7 rad)."""
    h = 1e-7
    return (K._torque(a + h, p) - K._torque(a - h, p)) / (2.0 * h * p[K.I_B])


@njit(cache=True)
def free_flight(alpha0, rate0, duration, p, steps):  # pragma: no cover - compiled
    """Free flight from ``(alpha0, rate0)`` for ``duration`` [s]: returns
    ``(alpha, rate, d alpha / d alpha0, d rate / d alpha0)`` at the end (RK4, ``steps`` steps)."""
    h = duration / steps
    a = alpha0
    v = rate0
    sa = 1.0  # sensitivities to alpha0
    sv = 0.0
    for _ in range(steps):
        k1a = v
        k1v = _free_accel(a, p)
        j1 = _free_accel_slope(a, p)
        k1sa = sv
        k1sv = j1 * sa
        a2 = a + 0.5 * h * k1a
        v2 = v + 0.5 * h * k1v
        sa2 = sa + 0.5 * h * k1sa
        sv2 = sv + 0.5 * h * k1sv
        k2a = v2
        k2v = _free_accel(a2, p)
        j2 = _free_accel_slope(a2, p)
        k2sa = sv2
        k2sv = j2 * sa2
        a3 = a + 0.5 * h * k2a
        v3 = v + 0.5 * h * k2v
        sa3 = sa + 0.5 * h * k2sa
        sv3 = sv + 0.5 * h * k2sv
        k3a = v3
        k3v = _free_accel(a3, p)
        j3 = _free_accel_slope(a3, p)
        k3sa = sv3
        k3sv = j3 * sa3
        a4 = a + h * k3a
        v4 = v + h * k3v
        sa4 = sa + h * k3sa
        sv4 = sv + h * k3sv
        k4a = v4
        k4v = _free_accel(a4, p)
        j4 = _free_accel_slope(a4, p)
        k4sa = sv4
        k4sv = j4 * sa4
        a += h / 6.0 * (k1a + 2.0 * k2a + 2.0 * k3a + k4a)
        v += h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v)
        sa += h / 6.0 * (k1sa + 2.0 * k2sa + 2.0 * k3sa + k4sa)
        sv += h / 6.0 * (k1sv + 2.0 * k2sv + 2.0 * k3sv + k4sv)
    return a, v, sa, sv


@njit(cache=True)
def return_time_anchors(start_angle, start_rate, duration, displacement, guess, p, steps, tol,
                        out):  # pragma: no cover - compiled
    """For each event, the start angle ``alpha_s`` of a free flight that, from rate
    ``start_rate``, moves by ``displacement`` in ``duration``: Newton on
    ``G(alpha_s) = alpha(duration; alpha_s) - alpha_s - displacement``.

    ``start_angle`` is unused except for shape; ``guess`` holds the initial iterates. Fills
    ``out[i] = (alpha_s, G'(alpha_s), iterations)``; ``iterations`` is -1 if Newton failed.
    """
    for i in range(guess.shape[0]):
        x = guess[i]
        it = 0
        slope = 0.0
        ok = False
        while it < 30:
            a_end, _, sa, _ = free_flight(x, start_rate[i], duration[i], p, steps)
            g = a_end - x - displacement[i]
            slope = sa - 1.0
            it += 1
            if slope == 0.0 or not np.isfinite(g):
                break
            step = g / slope
            x -= step
            if abs(step) < tol:
                ok = True
                break
        out[i, 0] = x
        out[i, 1] = slope
        out[i, 2] = it if ok else -1

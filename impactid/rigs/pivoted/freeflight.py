"""Free flight of rig P and the return-time anchor of the per-impact pipeline (S-19).

``I_b alpha_ddot = m_b g l_g cos(alpha) - F_s(alpha) d_x`` (S-9) is smooth and slow (its natural
frequency is a few Hz) over one cam revolution, so a fixed-step classical RK4 with a few thousand
steps is accurate to about 1e-13 rad; ``tests/rigs/pivoted/test_freeflight.py`` checks it against
``scipy.integrate.solve_ivp`` (DOP853, rtol 1e-12). The variational equation is integrated
alongside, so the anchor's Newton iteration has the exact derivative of the end angle with
respect to the start angle.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from impactid.rigs.pivoted import kernel as K

__all__ = ["FREE_FLIGHT_STEPS", "free_flight", "return_time_anchors"]

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
def _derivatives(a, v, sa, sv, p):
    """Right-hand side of the free flight and of its variational equation."""
    return v, _free_accel(a, p), sv, _free_accel_slope(a, p) * sa


@njit(cache=True)
def free_flight(alpha0, rate0, duration, p, steps):  # pragma: no cover - compiled
    """Free flight from ``(alpha0, rate0)`` for ``duration`` [s]: returns
    ``(alpha, rate, d alpha / d alpha0, d rate / d alpha0)`` at the end (RK4, ``steps`` steps)."""
    h = duration / steps
    a, v, sa, sv = alpha0, rate0, 1.0, 0.0  # state and its sensitivities to alpha0
    for _ in range(steps):
        k1 = _derivatives(a, v, sa, sv, p)
        k2 = _derivatives(a + 0.5 * h * k1[0], v + 0.5 * h * k1[1], sa + 0.5 * h * k1[2], sv + 0.5 * h * k1[3], p)
        k3 = _derivatives(a + 0.5 * h * k2[0], v + 0.5 * h * k2[1], sa + 0.5 * h * k2[2], sv + 0.5 * h * k2[3], p)
        k4 = _derivatives(a + h * k3[0], v + h * k3[1], sa + h * k3[2], sv + h * k3[3], p)
        a += h / 6.0 * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0])
        v += h / 6.0 * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1])
        sa += h / 6.0 * (k1[2] + 2.0 * k2[2] + 2.0 * k3[2] + k4[2])
        sv += h / 6.0 * (k1[3] + 2.0 * k2[3] + 2.0 * k3[3] + k4[3])
    return a, v, sa, sv


@njit(cache=True)
def return_time_anchors(start_rate, duration, displacement, guess, p, steps, tol, out):  # pragma: no cover - compiled
    """For each event, the start angle ``alpha_s`` of a free flight that, from rate
    ``start_rate``, moves by ``displacement`` in ``duration``: Newton on
    ``G(alpha_s) = alpha(duration; alpha_s) - alpha_s - displacement``.

    ``guess`` holds the initial iterates. Fills
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

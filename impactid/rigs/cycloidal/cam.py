"""Cycloidal lift law (R-31) and the kinematics of a flat-faced translating follower on it.

Cam angle ``psi`` [rad] (taken modulo ``2 pi``): the rise runs from ``pi - beta`` to the nose at
``pi``, the return is its mirror image from ``pi`` to ``pi + beta``, the base circle is elsewhere.
With ``x`` the angle since the start of the rise (``0 <= x <= beta``) and ``theta = 2 pi x / beta``::

    s    = S [x/beta - sin(theta)/(2 pi)]               (R-31)
    s'   = (S/beta) [1 - cos(theta)]
    s''  = (2 pi S/beta^2) sin(theta)
    s''' = (4 pi^2 S/beta^3) cos(theta)

(a prime is ``d/dpsi``). On the return ``s`` and ``s''`` are mirrored, ``s'`` and ``s'''`` change
sign. ``s, s', s''`` are continuous everywhere; ``s'''`` jumps at the ends of the event and at the
nose, where the value returned is the rise's (its left limit).

For the flat follower, at constant cam speed ``omega`` [rad/s] (standard results, the paper's
text prints the entraining velocity without ``omega``, decision R-D9)::

    R   = R0 + s + s''               radius of curvature at the contact = reduced radius  (R-E1)
    e   = s'                         offset of the contact from the follower axis         (R-E2)
    u   = (omega/2)(R0 + s + 2 s'')  entraining (mean rolling) velocity                   (R-E3)
    u_s = omega (R0 + s)             sliding velocity                                     (R-E4)

The scalar :func:`lift_scalar` is the one formula: it is compiled with numba and used by the
array function :func:`lift` and by the dynamic kernels.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from scipy import optimize

from impactid import compilation

compilation.install()  # before the kernels: the kernel cache's locators and the first-use notice

__all__ = ["contact_offset", "entraining_velocity", "lift", "lift_scalar", "max_radius_of_curvature",
           "min_radius_of_curvature", "radius_of_curvature", "rigid_jump_speed", "sliding_velocity",
           "valve_acceleration", "valve_jerk", "valve_velocity", "zero_entrainment_angles"]

TWO_PI = 2.0 * math.pi


@njit(cache=True)
def lift_scalar(psi, S, beta):
    """``(s, s', s'', s''')`` of the cycloidal law at cam angle ``psi`` [rad] (any real value).

    Units: ``s`` [m], ``s'`` [m/rad], ``s''`` [m/rad^2], ``s'''`` [m/rad^3]."""
    q = psi - TWO_PI * math.floor(psi / TWO_PI)
    a = math.pi - beta
    if q < a or q > math.pi + beta:
        return 0.0, 0.0, 0.0, 0.0
    if q <= math.pi:  # rise; the nose belongs to the rise
        x = q - a
        sign = 1.0
    else:  # return: mirror image about the nose
        x = math.pi + beta - q
        sign = -1.0
    theta = TWO_PI * x / beta
    sn = math.sin(theta)
    cs = math.cos(theta)
    s = S * (x / beta - sn / TWO_PI)
    s1 = sign * (S / beta) * (1.0 - cs)
    s2 = (TWO_PI * S / (beta * beta)) * sn
    s3 = sign * (4.0 * math.pi * math.pi * S / (beta * beta * beta)) * cs
    return s, s1, s2, s3


@njit(cache=True)
def _lift_array(psi, S, beta, out):
    for i in range(psi.shape[0]):
        s, s1, s2, s3 = lift_scalar(psi[i], S, beta)
        out[0, i] = s
        out[1, i] = s1
        out[2, i] = s2
        out[3, i] = s3


def lift(psi, S: float, beta: float):
    """The cycloidal lift (R-31) and its analytic derivatives at cam angles ``psi`` [rad].

    Parameters
    ----------
    psi : cam angle(s) [rad], any real values (taken modulo ``2 pi``).
    S : total lift [m].
    beta : rise (= return) angle [rad].

    Returns
    -------
    s, s1, s2, s3 : arrays of the shape of ``psi``: ``s`` [m], ``s'`` [m/rad], ``s''`` [m/rad^2],
        ``s'''`` [m/rad^3].
    """
    arr = np.asarray(psi, dtype=float)
    flat = np.ascontiguousarray(arr.ravel())
    out = np.empty((4, flat.size))
    _lift_array(flat, float(S), float(beta), out)
    return tuple(o.reshape(arr.shape) if arr.ndim else float(o[0]) for o in out)


def radius_of_curvature(psi, S: float, beta: float, R0: float):
    """Cam radius of curvature at the contact ``R = R0 + s + s''`` (R-E1) [m]."""
    s, _, s2, _ = lift(psi, S, beta)
    return R0 + s + s2


def contact_offset(psi, S: float, beta: float):
    """Offset of the contact from the follower axis ``e = s'`` (R-E2) [m]."""
    return lift(psi, S, beta)[1]


def entraining_velocity(psi, omega: float, S: float, beta: float, R0: float):
    """Entraining (mean rolling) velocity ``u = (omega/2)(R0 + s + 2 s'')`` (R-E3, R-D9) [m/s].

    The mean of the cam surface velocity relative to the moving contact, ``omega (R0 + s + s'')``,
    and the follower's, ``omega s''``. ``omega`` [rad/s]."""
    s, _, s2, _ = lift(psi, S, beta)
    return 0.5 * omega * (R0 + s + 2.0 * s2)


def sliding_velocity(psi, omega: float, S: float, beta: float, R0: float):
    """Sliding velocity ``u_s = omega (R0 + s)`` (R-E4) [m/s]: the difference of the two surface
    velocities relative to the contact (friction is omitted in the model)."""
    return omega * (R0 + lift(psi, S, beta)[0])


def valve_velocity(psi, omega: float, S: float, beta: float):
    """Kinematic valve velocity ``omega s'`` [m/s]."""
    return omega * lift(psi, S, beta)[1]


def valve_acceleration(psi, omega: float, S: float, beta: float):
    """Kinematic valve acceleration ``omega^2 s''`` [m/s^2]."""
    return omega**2 * lift(psi, S, beta)[2]


def valve_jerk(psi, omega: float, S: float, beta: float):
    """Kinematic valve jerk ``omega^3 s'''`` [m/s^3] (jumps at the nose: the cusp of Fig. 2)."""
    return omega**3 * lift(psi, S, beta)[3]


def _rise_extremum(fun, lo: float, hi: float, n: int = 2001, sign: float = 1.0) -> tuple[float, float]:
    """Minimum of ``sign * fun`` over ``[lo, hi]``: a grid, then a bounded refinement."""
    x = np.linspace(lo, hi, n)
    v = sign * fun(x)
    i = int(np.argmin(v))
    a, b = x[max(i - 1, 0)], x[min(i + 1, n - 1)]
    res = optimize.minimize_scalar(lambda q: sign * float(fun(np.array([q]))[0]), bounds=(a, b), method="bounded",
                                   options={"xatol": 1e-12})
    if res.fun < v[i]:
        return sign * float(res.fun), float(res.x)
    return sign * float(v[i]), float(x[i])


def min_radius_of_curvature(S: float, beta: float, R0: float) -> tuple[float, float]:
    """Smallest radius of curvature ``R0 + s + s''`` over the cam and its cam angle on the rise
    (the return mirrors it): ``(R_min [m], psi [rad])``. ``R_min > 0`` is the convexity condition."""
    r_min, psi = _rise_extremum(lambda q: radius_of_curvature(q, S, beta, R0), math.pi - beta, math.pi)
    return min(r_min, R0), (psi if r_min < R0 else 0.0)


def max_radius_of_curvature(S: float, beta: float, R0: float) -> tuple[float, float]:
    """Largest radius of curvature and its cam angle on the rise: ``(R_max [m], psi [rad])``."""
    r_max, psi = _rise_extremum(lambda q: radius_of_curvature(q, S, beta, R0), math.pi - beta, math.pi,
                                sign=-1.0)
    return max(r_max, R0), psi


def zero_entrainment_angles(S: float, beta: float, R0: float) -> np.ndarray:
    """Cam angles [rad, in ``[0, 2 pi)``, sorted] where the entraining velocity vanishes,
    ``R0 + s + 2 s'' = 0``.

    The roots lie in the deceleration part of each flank (where ``s'' < 0``); they are bracketed on a
    fine grid of the rise and refined with Brent's method to about 1e-15 rad; the return's are their
    mirror images about the nose. An empty array when the entrainment never reverses."""
    a = math.pi - beta

    def f(q):
        s, _, s2, _ = lift_scalar(q, S, beta)
        return R0 + s + 2.0 * s2

    grid = np.linspace(a, math.pi, 4001)
    s, _, s2, _ = lift(grid, S, beta)
    vals = R0 + s + 2.0 * s2
    roots = []
    for i in range(grid.size - 1):
        if vals[i] == 0.0:
            roots.append(grid[i])
        elif vals[i] * vals[i + 1] < 0.0:
            roots.append(optimize.brentq(f, grid[i], grid[i + 1], xtol=1e-15, rtol=1e-15))
    rise = np.array(roots)
    return np.sort(np.concatenate([rise, 2.0 * math.pi - rise]))


def rigid_jump_speed(m3: float, k0: float, f_p: float, S: float, beta: float) -> tuple[float, float]:
    """Camshaft speed at which a rigid follower on a massless spring first loses the cam.

    The load ``W = m3 omega^2 s'' + f_p + k0 s`` stays positive while ``omega^2 < (f_p + k0 s) /
    (m3 (-s''))`` wherever ``s'' < 0``. Returns ``(omega_jump [rad/s], psi [rad])``: the square root of
    the minimum of that ratio over the rise's deceleration part (the return mirrors it) and where it is.
    """
    def ratio(q):
        s, _, s2, _ = lift(q, S, beta)
        return (f_p + k0 * s) / (m3 * np.maximum(-s2, 1e-300))

    lo = math.pi - 0.5 * beta + 1e-9 * beta
    best, psi = _rise_extremum(ratio, lo, math.pi - 1e-9 * beta)
    return math.sqrt(best), psi

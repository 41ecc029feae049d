"""Independent synthetic tracks of a bouncing, spinning ball, written from the specification alone
with plain SciPy (nothing of impactid's physics is imported).

Flight: ``m_eff dv/dt = -(m - rho V) g e_z - 1/2 rho A C_D |v| v + 1/2 rho A C_L |v|^2 (omega x v) / |omega x v|``
(``m_eff = m + rho V / 2``; ``omega`` perpendicular to ``v`` in the tests' lift, which uses the whole
``|omega|``: the lift is ``1/2 rho A C_L |v| (omega x v) / |omega|``) with the bilinear lift coefficient
of Sawicki, Hubbard & Stronge (2003), ``C_L = 1.5 S`` up to ``S = 0.1`` and ``0.09 + 0.6 S`` above,
``S = R |omega| / |v|``, times a scale; spin constant in flight; each flight a ``solve_ivp`` (DOP853, rtol 1e-12)
ended by the ball's centre reaching ``surface + R``. Impact: a rigid thin shell (``I = 2/3 m R^2``) on a
surface of unit normal ``n`` (``e_z`` unless tilted: the surface through ``(0, 0, surface)`` rising
by ``slope = (dz/dx, dz/dy)``), normal restitution ``e_n``, Coulomb friction ``mu`` with sticking; the
angular impulse about the centre is ``r x P`` with ``r = -R n``.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

MASS, DIAMETER, RHO, G = 2.7e-3, 0.040, 1.204, 9.80665
RADIUS = DIAMETER / 2
AREA, VOLUME = np.pi * DIAMETER ** 2 / 4, np.pi * DIAMETER ** 3 / 6
INERTIA = 2.0 / 3.0 * MASS * RADIUS ** 2


def lift(s):
    """The bilinear lift coefficient of Sawicki, Hubbard & Stronge (2003) at spin parameter ``s``."""
    return 1.5 * s if s <= 0.1 else 0.09 + 0.6 * s


def _rhs(spin, cd, scale):
    m_eff = MASS + 0.5 * RHO * VOLUME
    w = float(np.linalg.norm(spin))

    def f(_t, y):
        v = y[3:]
        speed = np.linalg.norm(v)
        force = -0.5 * RHO * AREA * cd * speed * v
        if w > 0.0:
            force = force + 0.5 * RHO * AREA * scale * lift(RADIUS * w / speed) * speed * np.cross(spin, v) / w
        force[2] -= (MASS - RHO * VOLUME) * G
        return np.concatenate([v, force / m_eff])

    return f


def impact(v, spin, e_n, mu, n=(0.0, 0.0, 1.0)):
    """Velocity and spin after a rigid impact with friction on a plane of unit normal ``n`` (independent of
    impactid)."""
    n = np.asarray(n, dtype=float) / np.linalg.norm(n)
    r = -RADIUS * n
    vn = v @ n
    p_n = -(1.0 + e_n) * MASS * vn
    u = v + np.cross(spin, r)
    u_t = u - (u @ n) * n
    slip = np.linalg.norm(u_t)
    # impulse that stops the slip: u_t + P_t/m + (r x P_t) x r / I ... solved for a sphere: P = -u_t / (1/m + R^2/I)
    p_stick = -u_t / (1.0 / MASS + RADIUS ** 2 / INERTIA)
    p_t = p_stick if np.linalg.norm(p_stick) <= mu * p_n else -mu * p_n * u_t / slip
    impulse = p_n * n + p_t
    return v + impulse / MASS, spin + np.cross(r, impulse) / INERTIA


def bouncing_track(p0, v0, spin0, *, e_n=0.9, mu=0.25, surface=0.0, duration=0.5, rate=143.0, noise=0.0,
                   cd=0.45, lift_scale=1.0, seed=0, bounces=3, slope=(0.0, 0.0)):
    """Sampled positions (times, (n, 3)) of a ball from ``p0``, ``v0``, ``spin0`` bouncing on ``surface``
    (tilted by ``slope``); and the truth: a list of impacts (time, v_in, v_out, spin_in, spin_out)."""
    normal = np.array([-slope[0], -slope[1], 1.0]) / np.sqrt(1.0 + slope[0] ** 2 + slope[1] ** 2)
    y = np.concatenate([p0, v0]).astype(float)
    spin = np.asarray(spin0, dtype=float)
    t0, pieces, truth = 0.0, [], []

    def ground(_t, yy):  # the centre's distance from the plane, less the radius
        return (yy[2] - surface - slope[0] * yy[0] - slope[1] * yy[1]) * normal[2] - RADIUS
    ground.terminal, ground.direction = True, -1
    while t0 < duration:
        sol = solve_ivp(_rhs(spin, cd, lift_scale), (t0, duration), y, method="DOP853", rtol=1e-12, atol=1e-14,
                        events=ground, dense_output=True)
        t_end = sol.t[-1]
        pieces.append((t0, t_end, sol.sol))
        if sol.status != 1 or len(truth) >= bounces:
            break
        y = sol.y_events[0][0].copy()
        v_out, w_out = impact(y[3:], spin, e_n, mu, normal)
        truth.append((t_end, y[3:].copy(), v_out, spin.copy(), w_out))
        y[3:], spin, t0 = v_out, w_out, t_end
    times = np.arange(0.0, pieces[-1][1], 1.0 / rate)
    pos = np.empty((times.size, 3))
    for a, b, f in pieces:
        inside = (times >= a) & (times <= b)
        if np.any(inside):
            pos[inside] = f(times[inside])[:3].T
    rng = np.random.default_rng(seed)
    return times, pos + noise * rng.standard_normal(pos.shape), truth

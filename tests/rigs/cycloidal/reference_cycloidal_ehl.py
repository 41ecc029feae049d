"""Independent plain NumPy/SciPy reference of the cycloidal-cam / flat-follower valve train.

The system is the one of Kushwaha, Rahnejat & Jin (2000): a cam with a cycloidal lift law drives a
flat-faced translating follower (bucket) carrying the valve; the valve spring is a two-mass surge model
(the model and the spring of Kim, Jeon & Park (1990)); the cam/follower contact is an EHL line contact
whose central film thickness follows the extrapolated regression of Rahnejat (1984). The equations are
those of the project's valve-train specification, part R, with its repairs and decisions (R-D1..R-D17).
This module is written for cross-checking the compiled simulator: it favours clarity and accuracy over
speed, and it imports nothing from ``impactid``.

Conventions
-----------
* ``psi``: cam angle (rad), ``psi = omega t`` with ``t = 0`` at ``psi = 0``. The rise runs from
  ``pi - beta`` to ``pi`` (90 to 180 deg for the assumed ``beta = 90 deg``), the nose is at ``pi``, the
  return from ``pi`` to ``pi + beta``; base circle elsewhere. Angles are taken modulo ``2 pi``.
* On the lift ``s(psi)`` a prime is ``d/dpsi``; ``s1, s2, s3`` are ``s', s'', s'''``.
* ``y3`` valve/follower lift (+ = opening), ``y5``, ``y6`` the spring masses (5 next to the retainer),
  same sign, 0 at rest with the valve closed. ``W`` = cam contact load, + = compressive.
* Speeds are camshaft speeds in r/min (``rpm``); ``omega = 2 pi rpm / 60``.
* SI units everywhere.

Levels
------
* Level A (the paper's adherent model): ``y3 = s(psi)`` prescribed, (R-41), (R-42) integrated for the
  spring masses, the contact load is the constraint reaction (R-40'); ``W < 0`` is reported as "jump
  predicted". The kinematic load (R-43') and the rigid-follower load (no surge) are also given.
* Level B (extension): ``y3`` free; one-sided Hertz line contact ``W = delta^-1(g)`` for the penetration
  ``g = s(psi) - g_lash - y3 > 0`` and a one-sided valve seat ``max(0, -K_se y3 - C_se y3')`` for
  ``y3 < 0``; every switch is located with ``solve_ivp`` events and the integration is restarted there.

Numerics
--------
* All ODEs are integrated with ``solve_ivp(method="DOP853")`` at ``rtol = 1e-10`` and absolute
  tolerances of ``1e-14 m`` and ``1e-11 m/s`` (``RTOL``, ``ATOL_X``, ``ATOL_V``). Reason: the reference
  must be far more accurate than any cross-check tolerance, and the jump-speed bisections must be
  limited by their own tolerance, not by integration noise. Level A: the load error is ``k_s1`` times
  the spring-mass error; 100 times tighter tolerances change the 3000 r/min load by less than 1e-7 N.
  Level B is harder: the load depends on the micrometre difference ``s - y3`` of two quantities of
  millimetres through a contact stiffness of about 5e8 N/m, so ``rtol |y3|`` (8e-13 m) sets the floor;
  100 times tighter tolerances change the 3000 r/min load by about 1e-3 N (2e-6 relative) and the event
  angles by less than 3e-8 rad. Cross-check tolerances should stay above these.
* The integration is split at the kinematic break points ``pi - beta``, ``pi``, ``pi + beta`` (where
  ``s'''`` jumps) so that the right-hand side is smooth inside every ``solve_ivp`` call.
* Level A periodic steady state: exact shooting for the linear surge model,
  ``z(T) = Phi z(0) + z_p(T)`` with ``Phi = expm(A T)``; the result is verified by integrating one more
  revolution (``periodicity_error``).
* Level B periodic steady state: run-in from the level-A periodic state, with an explicit convergence
  test on the state at ``psi = 0 (mod 2 pi)`` from revolution to revolution.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import dblquad, quad, solve_ivp
from scipy.linalg import eigh, expm
from scipy.optimize import brentq, minimize_scalar
from scipy.special import lambertw

__all__ = [
    "TABLE3_RANGES",
    "reference_params",
    "derive",
    "omega_of",
    "surge_matrices",
    "surge_frequencies",
    "lift",
    "radius_of_curvature",
    "contact_offset",
    "entraining_velocity",
    "sliding_velocity",
    "zero_entrainment_angles",
    "valve_velocity",
    "valve_acceleration",
    "hertz_half_width",
    "hertz_max_pressure",
    "hertz_approach",
    "hertz_approach_numerical",
    "hertz_load_from_approach",
    "hertz_load_from_approach_lambertw",
    "ehl_groups",
    "ehl_film_formula",
    "ehl_validity",
    "ehl_film_scheme",
    "kinematic_load",
    "rigid_load",
    "level_a_periodic_state",
    "level_a_cycle",
    "level_a_load",
    "level_a_min_load",
    "level_b_static_state",
    "level_b_mode_from_state",
    "level_b_loads",
    "level_b_simulate",
    "level_b_steady_cycle",
    "cycle_outputs",
    "rigid_jump_speed",
    "jump_speed",
]

TWO_PI = 2.0 * math.pi

#: validity ranges of (R-10), Table 3 of Kushwaha, Rahnejat & Jin (2000): group -> (low, high)
TABLE3_RANGES = {
    "G": (5700.0, 9650.0),
    "ws": (-0.005, 0.0),
    "W": (0.34e-6, 0.56e-5),
    "U": (0.63e-11, 3.3e-11),
}

#: regression constants of (R-10) (Rahnejat 1984)
EHL_COEFF = 1.67
EHL_EXP_W = 0.059
EHL_EXP_U = 0.541
EHL_EXP_G = 0.421
EHL_SQUEEZE = 96.775

#: solve_ivp settings (see the module docstring for the reasons)
RTOL = 1e-10
ATOL_X = 1e-14
ATOL_V = 1e-11


# ---------------------------------------------------------------------------------------------
# Parameters
# ---------------------------------------------------------------------------------------------
def reference_params(preset: str = "assumed", **overrides) -> dict:
    """Parameter set of the cycloidal-cam / flat-follower train in SI units, with derived values.

    Parameters
    ----------
    preset : {"assumed", "zeros_exact", "thick_oil"}
        ``"assumed"``: the assumed set of the specification (R.3). ``"zeros_exact"``: the alternative
        that puts the zero-entrainment points exactly at 12 and 36 deg from the nose
        (``beta = 93.67 deg``, ``R0/S = 2.403``). ``"thick_oil"``: the assumed set with
        ``eta0 = 0.045 Pa s`` (R-D13).
    **overrides
        Primary parameters to replace (for example ``m3=0.25``); the derived values are recomputed.

    Returns
    -------
    dict
        Primary keys: ``m3, k0, f0, f_p, c, S, beta, R0, L_c, E1, E2, nu1, nu2, eta0, alpha_pv,
        steps_per_rev, ws_clip, K_se, C_se, g_lash``. Derived keys: ``m5, m6`` (R-1 repaired),
        ``k_s1, k_s3`` (R-3), ``k_s2`` (R-2), ``Sigma`` (compliance sum), ``E_prime = 2/Sigma`` (R-D1),
        ``G_star = alpha_pv E_prime``.
    """
    p = dict(
        m3=0.225,  # kg, middle of Table 1's 0.20-0.25 (R-D12)
        k0=35.0e3,  # N/m, valve spring rate
        f0=504.5,  # Hz, first surge frequency (ends clamped)
        f_p=275.0,  # N, spring preload
        c=2.355,  # N s/m, one damper constant for all three surge elements
        S=8.0e-3,  # m, total lift
        beta=0.5 * math.pi,  # rad, rise angle = return angle
        R0=20.0e-3,  # m, base-circle radius
        L_c=20.0e-3,  # m, contact length
        E1=210.0e9,
        E2=210.0e9,  # Pa, steel cam and steel follower
        nu1=0.3,
        nu2=0.3,
        eta0=0.015,  # Pa s, ambient viscosity
        alpha_pv=2.5e-8,  # 1/Pa, pressure-viscosity coefficient
        steps_per_rev=500,  # EHL time steps per camshaft revolution
        ws_clip=True,  # clip w_s* to Table 3's [-0.005, 0] (R-D2)
        K_se=1.31e7,  # N/m, valve seat stiffness (level B)
        C_se=634.77,  # N s/m, valve seat damping (level B)
        g_lash=0.0,  # m, valve lash (level B)
    )
    if preset == "assumed":
        pass
    elif preset == "zeros_exact":
        p["beta"] = math.radians(93.67)
        p["R0"] = 2.403 * p["S"]
    elif preset == "thick_oil":
        p["eta0"] = 0.045
    else:
        raise ValueError(f"unknown preset {preset!r}")
    for key, val in overrides.items():
        if key not in p:
            raise KeyError(f"unknown parameter {key!r}")
        p[key] = val
    return derive(p)


def derive(p: dict) -> dict:
    """(Re)compute the derived keys of ``p`` in place from its primary keys and return ``p``."""
    k0, f0 = p["k0"], p["f0"]
    p["m5"] = p["m6"] = (2.0 / 3.0) * k0 / (math.pi * f0) ** 2  # square on (pi f0)
    p["k_s1"] = p["k_s3"] = (8.0 / 3.0) * k0
    p["k_s2"] = 4.0 * k0
    p["Sigma"] = (1.0 - p["nu1"] ** 2) / p["E1"] + (1.0 - p["nu2"] ** 2) / p["E2"]
    p["E_prime"] = 2.0 / p["Sigma"]  # (R-D1)
    p["G_star"] = p["alpha_pv"] * p["E_prime"]
    return p


def omega_of(rpm: float) -> float:
    """Camshaft angular speed (rad/s) for a camshaft speed in r/min."""
    return TWO_PI * rpm / 60.0


def surge_matrices(p: dict):
    """Mass, damping and stiffness matrices of the two spring masses (y5, y6) with y3 clamped.

    Returns
    -------
    M, C, K : ndarray, shape (2, 2)
        From (R-41), (R-42): ``M z'' + C z' + K z = [k_s1 y3 + c y3', 0]``.
    """
    c = p["c"]
    M = np.diag([p["m5"], p["m6"]])
    K = np.array([[p["k_s1"] + p["k_s2"], -p["k_s2"]], [-p["k_s2"], p["k_s2"] + p["k_s3"]]])
    C = np.array([[2.0 * c, -c], [-c, 2.0 * c]])
    return M, C, K


def surge_frequencies(p: dict) -> np.ndarray:
    """Undamped natural frequencies (Hz) of the two-mass spring model with both ends clamped."""
    M, _, K = surge_matrices(p)
    lam = eigh(K, M, eigvals_only=True)
    return np.sqrt(lam) / TWO_PI


# ---------------------------------------------------------------------------------------------
# Cycloidal lift and flat-follower kinematics (R-E1..R-E5)
# ---------------------------------------------------------------------------------------------
def _lift_scalar(psi: float, S: float, beta: float):
    """Scalar ``(s, s', s'', s''')`` at cam angle ``psi``; used inside the ODE right-hand sides."""
    q = psi % TWO_PI
    a = math.pi - beta
    if q < a or q > math.pi + beta:
        return 0.0, 0.0, 0.0, 0.0
    if q <= math.pi:  # rise (the nose itself belongs to the rise: s''' is its left limit)
        x, sg = q - a, 1.0
    else:  # return: mirror image about the nose
        x, sg = math.pi + beta - q, -1.0
    th = TWO_PI * x / beta
    sn, cs = math.sin(th), math.cos(th)
    s = S * (x / beta - sn / TWO_PI)
    s1 = sg * (S / beta) * (1.0 - cs)
    s2 = (TWO_PI * S / beta**2) * sn
    s3 = sg * (4.0 * math.pi**2 * S / beta**3) * cs
    return s, s1, s2, s3


def lift(psi, p: dict):
    """Cycloidal lift (R-31) and its analytic derivatives over the whole revolution.

    Parameters
    ----------
    psi : array_like
        Cam angle (rad), any real value (taken modulo ``2 pi``).
    p : dict
        Parameters (``S``, ``beta``).

    Returns
    -------
    s, s1, s2, s3 : ndarray
        ``s`` (m) and ``s' = ds/dpsi``, ``s''``, ``s'''`` (m/rad^k). Rise from ``pi - beta`` to ``pi``,
        return its mirror image, zero on the base circle. At the nose ``s'''`` jumps from
        ``+4 pi^2 S/beta^3`` to ``-4 pi^2 S/beta^3``; the value returned at ``psi = pi`` is the rise's.
    """
    S, beta = p["S"], p["beta"]
    q = np.mod(np.asarray(psi, dtype=float), TWO_PI)
    a = math.pi - beta
    rise = (q >= a) & (q <= math.pi)
    ret = (q > math.pi) & (q <= math.pi + beta)
    x = np.where(rise, q - a, np.where(ret, math.pi + beta - q, 0.0))
    sg = np.where(ret, -1.0, 1.0)
    on = rise | ret
    th = TWO_PI * x / beta
    s = np.where(on, S * (x / beta - np.sin(th) / TWO_PI), 0.0)
    s1 = np.where(on, sg * (S / beta) * (1.0 - np.cos(th)), 0.0)
    s2 = np.where(on, (TWO_PI * S / beta**2) * np.sin(th), 0.0)
    s3 = np.where(on, sg * (4.0 * math.pi**2 * S / beta**3) * np.cos(th), 0.0)
    return s, s1, s2, s3


def radius_of_curvature(psi, p: dict):
    """Cam radius of curvature at the contact, ``R = R0 + s + s''`` (R-E1); the reduced radius (m)."""
    s, _, s2, _ = lift(psi, p)
    return p["R0"] + s + s2


def contact_offset(psi, p: dict):
    """Offset of the contact point from the follower axis, ``e = s'`` (R-E2), in m."""
    return lift(psi, p)[1]


def entraining_velocity(psi, rpm: float, p: dict):
    """Mean entraining (rolling) velocity ``u = (omega/2)(R0 + s + 2 s'')`` (R-E3, R-D9), m/s."""
    s, _, s2, _ = lift(psi, p)
    return 0.5 * omega_of(rpm) * (p["R0"] + s + 2.0 * s2)


def sliding_velocity(psi, rpm: float, p: dict):
    """Sliding velocity ``u_s = omega (R0 + s)`` (R-E4), m/s."""
    s = lift(psi, p)[0]
    return omega_of(rpm) * (p["R0"] + s)


def valve_velocity(psi, rpm: float, p: dict):
    """Kinematic valve velocity ``omega s'`` (m/s)."""
    return omega_of(rpm) * lift(psi, p)[1]


def valve_acceleration(psi, rpm: float, p: dict):
    """Kinematic valve acceleration ``omega^2 s''`` (m/s^2)."""
    return omega_of(rpm) ** 2 * lift(psi, p)[2]


def zero_entrainment_angles(p: dict) -> np.ndarray:
    """Cam angles (rad, in ``[0, 2 pi)``, sorted) where ``R0 + s + 2 s'' = 0``.

    Found by scanning for sign changes on a fine grid over the cam event and refining each with
    ``brentq`` (to about 1e-15 rad). For the assumed set there are four: two on each flank, in the
    deceleration part, symmetric about the nose.
    """
    a, b = math.pi - p["beta"], math.pi + p["beta"]

    def f(q):
        s, _, s2, _ = _lift_scalar(q, p["S"], p["beta"])
        return p["R0"] + s + 2.0 * s2

    grid = np.linspace(a, b, 4001)
    vals = np.array([f(q) for q in grid])
    roots = []
    for i in range(len(grid) - 1):
        if vals[i] == 0.0:
            roots.append(grid[i])
        elif vals[i] * vals[i + 1] < 0.0:
            roots.append(brentq(f, grid[i], grid[i + 1], xtol=1e-15, rtol=1e-15))
    return np.array(sorted(roots))


# ---------------------------------------------------------------------------------------------
# Hertzian line contact (R-4..R-9)
# ---------------------------------------------------------------------------------------------
def hertz_half_width(W, R, p: dict):
    """Hertz half-width ``b0 = sqrt((2/pi) Sigma W D / L_c)``, ``D = 2R`` (R-6); 0 for ``W <= 0``."""
    W = np.maximum(np.asarray(W, dtype=float), 0.0)
    return np.sqrt((2.0 / math.pi) * p["Sigma"] * W * 2.0 * np.asarray(R, dtype=float) / p["L_c"])


def hertz_max_pressure(W, R, p: dict):
    """Maximum Hertz pressure ``p0 = 2 W / (pi b0 L_c)`` (R-7), Pa; 0 for ``W <= 0``.

    Computed as ``p0 = b0 / (Sigma D)`` (the repaired (R-5)), which equals (R-7) and stays finite at
    ``W = 0``.
    """
    b0 = hertz_half_width(W, R, p)
    return b0 / (p["Sigma"] * 2.0 * np.asarray(R, dtype=float))


def hertz_approach(W, R, p: dict):
    """Central approach ``delta0 = (2 W Sigma/(pi L_c)) [ln(2 L_c/b0) + 0.5]`` (R-9 repaired), m.

    Equal to ``b0 p0 Sigma [ln(4a/b0) + 0.5]`` with ``a = L_c/2``. Returns 0 for ``W <= 0``.
    """
    W = np.asarray(W, dtype=float)
    Wp = np.maximum(W, 0.0)
    b0 = hertz_half_width(np.where(Wp > 0, Wp, 1.0), R, p)
    d = 2.0 * Wp * p["Sigma"] / (math.pi * p["L_c"]) * (np.log(2.0 * p["L_c"] / b0) + 0.5)
    return np.where(Wp > 0, d, 0.0)


def hertz_approach_numerical(W: float, R: float, p: dict, method: str = "quad") -> float:
    """Central approach by integrating (R-4) with the elliptical profile (R-8), independently of (R-9).

    ``delta(0,0) = (Sigma/pi) int_{-a}^{a} int_{-b0}^{b0} p0 sqrt(1 - x1^2/b0^2) / sqrt(x1^2 + y1^2)
    dx1 dy1`` over the rectangular footprint of half-length ``a = L_c/2`` (uniform pressure along the
    length). By symmetry it is four times the integral over the first quadrant.

    Parameters
    ----------
    method : {"quad", "dblquad"}
        ``"quad"``: the inner integral over the length ``y1`` is done with ``quad`` too (nested),
        the outer one over ``t = x1/b0`` in ``[0, 1]`` with the logarithmic end singularity left to
        QUADPACK's extrapolation. ``"dblquad"``: ``scipy.integrate.dblquad`` on the same quadrant.
        The closed form is used nowhere.
    """
    if W <= 0.0:
        return 0.0
    b0 = float(hertz_half_width(W, R, p))
    p0 = float(hertz_max_pressure(W, R, p))
    a = 0.5 * p["L_c"]
    if method == "quad":

        def inner(t):
            # int_0^{a/b0} dv / sqrt(t^2 + v^2) in the scaled variables t = x1/b0, v = y1/b0; the break
            # point v = t marks where the integrand turns from flat to 1/v
            val, _ = quad(lambda v: 1.0 / math.hypot(t, v), 0.0, a / b0, points=[max(t, 1e-300)],
                          limit=200, epsabs=0.0, epsrel=1e-12)
            return val

        outer, _ = quad(lambda t: math.sqrt(1.0 - t * t) * inner(t), 0.0, 1.0, limit=200,
                        epsabs=0.0, epsrel=1e-11)
        integral = 4.0 * b0 * outer  # dx1 dy1 = b0^2 dt dv and 1/r = 1/(b0 hypot(t, v))
    elif method == "dblquad":
        val, _ = dblquad(lambda v, t: math.sqrt(1.0 - t * t) / math.hypot(t, v), 0.0, 1.0,
                         0.0, a / b0, epsabs=0.0, epsrel=1e-10)
        integral = 4.0 * b0 * val
    else:
        raise ValueError(method)
    return p["Sigma"] / math.pi * p0 * integral


def hertz_load_from_approach(delta, R, p: dict):
    """Inverse ``W = delta^-1(delta)`` of (R-9) by monotone root finding (``brentq``), N.

    ``delta(W)`` increases monotonically with ``W`` while ``b0 < 2 L_c`` (its slope is
    ``(2 Sigma/(pi L_c)) ln(2 L_c/b0)``), which holds for any realistic load. Returns 0 for
    ``delta <= 0``. Vectorised over ``delta`` and ``R`` by a Python loop (reference, not speed).
    """
    delta = np.asarray(delta, dtype=float)
    R = np.broadcast_to(np.asarray(R, dtype=float), delta.shape)
    out = np.zeros(delta.shape)
    for idx in np.ndindex(delta.shape):
        d, r = float(delta[idx]), float(R[idx])
        if d <= 0.0:
            continue
        # W_max: where b0 = 2 L_c, the end of the monotone branch (b0^2 = 4 Sigma W R/(pi L_c));
        # about 5e8 N here, far beyond any load
        w_max = math.pi * p["L_c"] ** 3 / (p["Sigma"] * r)
        hi = 1.0
        while float(hertz_approach(hi, r, p)) < d:
            hi *= 2.0
            if hi > w_max:
                raise ValueError("approach beyond the monotone branch of (R-9)")
        out[idx] = brentq(lambda w, r=r, d=d: float(hertz_approach(w, r, p)) - d, 0.0, hi, xtol=1e-14, rtol=1e-14)
    return out if out.ndim else float(out)


def _lambertw_load(d: float, R: float, Sigma: float, L_c: float) -> float:
    """Scalar closed-form inverse of (R-9) through the lower branch of Lambert's W function.

    With ``C = 2 Sigma/(pi L_c)``, ``b0^2 = kb W``, ``kb = 4 Sigma R/(pi L_c)`` and
    ``L = ln(2 L_c) - 0.5 ln(kb) + 0.5``: ``delta = C W (L - 0.5 ln W)``. Writing ``v = L - 0.5 ln W``,
    ``-2 v e^{-2v} = -2 (delta/C) e^{-2L}``, so ``v = -W_{-1}(-2 (delta/C) e^{-2L}) / 2`` (branch -1:
    ``v > 1/2``, i.e. ``b0 < 2 L_c``, the monotone branch), and ``W = exp(2 (L - v))``.
    """
    if d <= 0.0:
        return 0.0
    C = 2.0 * Sigma / (math.pi * L_c)
    kb = 4.0 * Sigma * R / (math.pi * L_c)
    L = math.log(2.0 * L_c) - 0.5 * math.log(kb) + 0.5
    z = -2.0 * (d / C) * math.exp(-2.0 * L)
    if z < -1.0 / math.e:
        raise ValueError("approach beyond the monotone branch of (R-9)")
    v = -0.5 * lambertw(z, -1).real
    return math.exp(2.0 * (L - v))


def hertz_load_from_approach_lambertw(delta, R, p: dict):
    """Inverse of (R-9) in closed form (Lambert W, lower branch); same result as the root finder.

    Used inside the level-B right-hand side because it is exact and much faster than ``brentq``.
    """
    delta = np.asarray(delta, dtype=float)
    R = np.broadcast_to(np.asarray(R, dtype=float), delta.shape)
    out = np.array([_lambertw_load(float(d), float(r), p["Sigma"], p["L_c"])
                    for d, r in zip(delta.ravel(), R.ravel())]).reshape(delta.shape)
    return out if out.ndim else float(out)


# ---------------------------------------------------------------------------------------------
# EHL central film thickness (R-10, R-37..R-39)
# ---------------------------------------------------------------------------------------------
def ehl_groups(W, R, u, p: dict, w_floor: float = 1.0):
    """Dimensionless groups of (R-10) as decided in R-D1.

    Parameters
    ----------
    W, R, u : array_like
        Contact load (N), reduced radius = cam radius of curvature (m), entraining velocity (m/s).
    w_floor : float
        Floor on ``W`` inside the load group (1 N by default, R-D2); set 0 to see the raw group.

    Returns
    -------
    W_star, U_star, G_star : ndarray, ndarray, float
        ``W* = max(W, w_floor)/(E' R L_c)``, ``U* = eta0 |u|/(E' R)``, ``G* = alpha E'``.
    """
    Ep = p["E_prime"]
    R = np.asarray(R, dtype=float)
    W_star = np.maximum(np.asarray(W, dtype=float), w_floor) / (Ep * R * p["L_c"])
    U_star = p["eta0"] * np.abs(np.asarray(u, dtype=float)) / (Ep * R)
    return W_star, U_star, p["G_star"]


def ehl_film_formula(W, R, u, ws, p: dict):
    """Central film ``h = R * 1.67 W*^0.059 U*^0.541 G*^0.421 exp(-96.775 w_s*)`` (R-10, R-38), m.

    ``W`` is floored at 1 N inside the power law; ``ws`` is used as given (no clipping here), so an
    unclipped ``w_s*`` near a zero of ``u`` can give an infinite film (returned as ``inf``, no warning).
    """
    W_star, U_star, G_star = ehl_groups(W, R, u, p)
    with np.errstate(over="ignore"):
        squeeze = np.exp(-EHL_SQUEEZE * np.asarray(ws, dtype=float))
    h0 = EHL_COEFF * W_star**EHL_EXP_W * U_star**EHL_EXP_U * G_star**EHL_EXP_G * squeeze
    return np.asarray(R, dtype=float) * h0


def ehl_validity(W, R, u, ws, p: dict) -> dict:
    """Per-sample flags: is each group inside the regression range of Table 3 (``TABLE3_RANGES``)?

    ``W*`` is evaluated from the raw load (no floor), so that ``W <= 1 N`` is reported out of range.

    Returns
    -------
    dict
        ``{"W": bool array, "U": ..., "G": ..., "ws": ...}`` (True = inside, bounds included).
    """
    W_star, U_star, G_star = ehl_groups(W, R, u, p, w_floor=-np.inf)
    ws = np.asarray(ws, dtype=float)
    out = {}
    for key, val in (("W", W_star), ("U", U_star), ("G", np.full(np.shape(W_star), G_star)), ("ws", ws)):
        lo, hi = TABLE3_RANGES[key]
        out[key] = (val >= lo) & (val <= hi)
    return out


def ehl_film_scheme(W, R, u, dt: float, p: dict, ws_clip=None, n_rev: int = 1, ws_mode: str | None = None) -> dict:
    """Explicit squeeze-film time stepping (R-37..R-39, sign repaired) over periodic samples.

    Steps ``n = 0..N-1`` of one revolution; ``h_{n+1} = R_{n+1} h0*(W*_{n+1}, U*_{n+1}, G*,
    w_s* = w_n/|u_{n+1}|)`` with ``w_n = (h_n - h_{n-1})/dt`` (positive = separation). Start (R-39):
    ``h_{-1} = h_r = R_0 h0*(w_s* = 0)``, ``h_0 = 1.05 h_r``. The inputs are treated as periodic and
    the scheme is run over ``n_rev`` revolutions; the last one is returned.

    Parameters
    ----------
    W, R, u : array_like, shape (N,)
        Load (N), reduced radius (m), entraining velocity (m/s) at the steps of one revolution.
    dt : float
        Time step (s).
    ws_clip : bool, optional
        Clip ``w_s*`` to ``[-0.005, 0]`` (default: ``p["ws_clip"]``); ignored if ``ws_mode`` is given.
    ws_mode : {"clip", "none", "symmetric"}, optional
        ``"clip"`` (R-D2 default), ``"none"`` (raw ``w_s*``), ``"symmetric"`` (clip to
        ``[-0.005, 0.005]``, the symmetric extrapolation option).

    Returns
    -------
    dict
        ``h`` (m), ``w`` (squeeze velocity ``(h_n - h_{n-1})/dt``, m/s), ``ws_raw`` (the ``w_s*``
        that entered ``h_n``), ``ws`` (after clipping), ``clipped`` (bool per step), ``valid``
        (``ehl_validity`` of the groups with ``ws_raw``), ``h_r0`` (the start value).
    """
    W = np.asarray(W, dtype=float)
    R = np.asarray(R, dtype=float)
    u = np.asarray(u, dtype=float)
    N = len(W)
    if ws_mode is None:
        clip = p["ws_clip"] if ws_clip is None else ws_clip
        ws_mode = "clip" if clip else "none"
    lo, hi = TABLE3_RANGES["ws"]
    if ws_mode == "symmetric":
        hi = -lo

    def film(n, ws):
        return float(ehl_film_formula(W[n], R[n], u[n], ws, p))

    h_r = film(0, 0.0)
    h_prev, h_cur = h_r, 1.05 * h_r
    total = n_rev * N
    h = np.empty(total)
    w = np.empty(total)
    ws_raw = np.empty(total)
    ws_used = np.empty(total)
    h[0] = h_cur
    w[0] = (h_cur - h_prev) / dt
    ws_raw[0] = 0.0  # h_0 is set by, not by the formula
    ws_used[0] = 0.0
    for k in range(1, total):
        n = k % N
        w_prev = (h[k - 1] - (h[k - 2] if k >= 2 else h_prev)) / dt
        au = abs(u[n])
        raw = w_prev / au if au > 0.0 else (-np.inf if w_prev < 0 else (np.inf if w_prev > 0 else 0.0))
        used = raw if ws_mode == "none" else min(max(raw, lo), hi)
        h[k] = film(n, used)
        w[k] = (h[k] - h[k - 1]) / dt
        ws_raw[k] = raw
        ws_used[k] = used
    sl = slice(total - N, total)
    out = dict(h=h[sl], w=w[sl], ws_raw=ws_raw[sl], ws=ws_used[sl], h_r0=h_r)
    out["clipped"] = out["ws"] != out["ws_raw"]
    out["valid"] = ehl_validity(W, R, u, out["ws_raw"], p)
    return out


# ---------------------------------------------------------------------------------------------
# Loads without dynamics
# ---------------------------------------------------------------------------------------------
def kinematic_load(psi, p: dict):
    """Kinematic load ``W_kin = f_p + k0 s(psi)`` (R-43', R-D14), N."""
    return p["f_p"] + p["k0"] * lift(psi, p)[0]


def rigid_load(psi, rpm: float, p: dict):
    """Rigid follower without surge (massless spring): ``W = m3 omega^2 s'' + f_p + k0 s``, N."""
    s, _, s2, _ = lift(psi, p)
    return p["m3"] * omega_of(rpm) ** 2 * s2 + p["f_p"] + p["k0"] * s


def rigid_jump_speed(p: dict) -> float:
    """Lowest camshaft speed (r/min) at which ``rigid_load`` first reaches 0 somewhere.

    ``omega_j^2 = min over the deceleration part of (f_p + k0 s)/(m3 |s''|)``, found with a fine
    grid and ``minimize_scalar`` (bounded) on each flank.
    """
    def ratio(q):
        s, _, s2, _ = _lift_scalar(q, p["S"], p["beta"])
        return (p["f_p"] + p["k0"] * s) / (p["m3"] * (-s2))

    best = np.inf
    a = math.pi - p["beta"]
    for lo, hi in ((a + 0.5 * p["beta"], math.pi), (math.pi, math.pi + 0.5 * p["beta"])):
        eps = 1e-9
        grid = np.linspace(lo + eps, hi - eps, 2001)
        vals = np.array([ratio(q) for q in grid])
        i = int(np.argmin(vals))
        res = minimize_scalar(ratio, bounds=(grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)]),
                              method="bounded", options=dict(xatol=1e-12))
        best = min(best, res.fun, vals[i])
    return math.sqrt(best) * 60.0 / TWO_PI


# ---------------------------------------------------------------------------------------------
# Piecewise integration helper
# ---------------------------------------------------------------------------------------------
def _break_times(rpm: float, p: dict, t0: float, t1: float) -> np.ndarray:
    """Times in ``(t0, t1)`` where ``psi = omega t`` hits a kinematic break point (mod 2 pi)."""
    w = omega_of(rpm)
    beta = p["beta"]
    base = np.array([math.pi - beta, math.pi, math.pi + beta])
    k0 = math.floor(w * t0 / TWO_PI) - 1
    k1 = math.ceil(w * t1 / TWO_PI) + 1
    ts = np.concatenate([(base + TWO_PI * k) / w for k in range(k0, k1 + 1)])
    ts = ts[(ts > t0 + 1e-15 * max(1.0, abs(t0))) & (ts < t1 - 1e-15 * max(1.0, abs(t1)))]
    return np.sort(ts)


class _Piecewise:
    """Dense output made of several ``solve_ivp`` pieces, evaluated at any time in their union."""

    def __init__(self):
        self.t0 = []
        self.t1 = []
        self.sols = []

    def add(self, t0, t1, sol):
        if t1 > t0:
            self.t0.append(t0)
            self.t1.append(t1)
            self.sols.append(sol)

    def __call__(self, t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        starts = np.array(self.t0)
        idx = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(starts) - 1)
        out = np.empty((self.sols[0](self.t0[0]).shape[0], t.size))
        for j in np.unique(idx):
            m = idx == j
            out[:, m] = self.sols[j](t[m])
        return out


# ---------------------------------------------------------------------------------------------
# Level A: prescribed follower lift, surge masses integrated (R-40'..R-42)
# ---------------------------------------------------------------------------------------------
def _level_a_system(rpm: float, p: dict):
    w = omega_of(rpm)
    m5, m6, k1, k2, k3, c = p["m5"], p["m6"], p["k_s1"], p["k_s2"], p["k_s3"], p["c"]
    A = np.array([
        [0.0, 1.0, 0.0, 0.0],
        [-(k1 + k2) / m5, -2.0 * c / m5, k2 / m5, c / m5],
        [0.0, 0.0, 0.0, 1.0],
        [k2 / m6, c / m6, -(k2 + k3) / m6, -2.0 * c / m6],
    ])
    S, beta = p["S"], p["beta"]

    def rhs(t, z):
        s, s1, _, _ = _lift_scalar(w * t, S, beta)
        y5, v5, y6, v6 = z
        a5 = (k1 * (s - y5) + c * (w * s1 - v5) - k2 * (y5 - y6) - c * (v5 - v6)) / m5
        a6 = (k2 * (y5 - y6) + c * (v5 - v6) - k3 * y6 - c * v6) / m6
        return [v5, a5, v6, a6]

    return A, rhs


def _integrate_piecewise(rhs, z0, t0, t1, rpm, p, atol):
    """Integrate ``rhs`` from ``t0`` to ``t1`` restarting at the kinematic break points."""
    dense = _Piecewise()
    z = np.asarray(z0, dtype=float)
    edges = np.concatenate([[t0], _break_times(rpm, p, t0, t1), [t1]])
    for a, b in zip(edges[:-1], edges[1:]):
        sol = solve_ivp(rhs, (a, b), z, method="DOP853", rtol=RTOL, atol=atol, dense_output=True)
        if not sol.success:
            raise RuntimeError(sol.message)
        dense.add(a, b, sol.sol)
        z = sol.y[:, -1]
    return z, dense


def level_a_periodic_state(rpm: float, p: dict):
    """Periodic steady state of the surge masses at ``psi = 0`` by exact shooting.

    The surge model is linear with ``T``-periodic forcing, so ``z(T) = Phi z(0) + z_p(T)`` with
    ``Phi = expm(A T)`` and ``z_p`` the response from rest; ``z0 = (I - Phi)^-1 z_p(T)``.

    Returns
    -------
    z0 : ndarray, shape (4,)
        ``[y5, y5', y6, y6']`` at ``psi = 0`` (m, m/s).
    periodicity_error : float
        ``max |z(T) - z0|`` scaled by ``S`` (displacements) and ``omega S`` (velocities), from one
        more revolution integrated from ``z0`` (an explicit check of the shooting).
    """
    A, rhs = _level_a_system(rpm, p)
    T = TWO_PI / omega_of(rpm)
    atol = np.array([ATOL_X, ATOL_V, ATOL_X, ATOL_V])
    zp, _ = _integrate_piecewise(rhs, np.zeros(4), 0.0, T, rpm, p, atol)
    Phi = expm(A * T)
    z0 = np.linalg.solve(np.eye(4) - Phi, zp)
    zT, _ = _integrate_piecewise(rhs, z0, 0.0, T, rpm, p, atol)
    scale = np.array([p["S"], omega_of(rpm) * p["S"]] * 2)
    return z0, float(np.max(np.abs(zT - z0) / scale))


def level_a_load(t, z, rpm: float, p: dict):
    """Contact load (R-40') ``W = m3 omega^2 s'' + f_p + k_s1 (s - y5) + c (omega s' - y5')``, N.

    ``t`` (s, ``psi = omega t``) and ``z`` of shape (4, n) (``[y5, y5', y6, y6']``).
    """
    w = omega_of(rpm)
    s, s1, s2, _ = lift(w * np.asarray(t, dtype=float), p)
    return p["m3"] * w**2 * s2 + p["f_p"] + p["k_s1"] * (s - z[0]) + p["c"] * (w * s1 - z[1])


def level_a_cycle(rpm: float, p: dict, n: int | None = None) -> dict:
    """Level-A periodic steady cycle sampled at ``n`` equal steps from ``psi = 0``.

    Parameters
    ----------
    n : int, optional
        Samples per revolution (default ``p["steps_per_rev"]``).

    Returns
    -------
    dict
        ``psi`` (rad), ``t`` (s), ``z`` (4, n), ``W`` (N, R-40'), ``W_kin`` (R-43'), ``dense``
        (callable ``t -> z``, valid on ``[0, T]``), ``periodicity_error``, ``T`` (s).
    """
    n = p["steps_per_rev"] if n is None else n
    z0, err = level_a_periodic_state(rpm, p)
    _, rhs = _level_a_system(rpm, p)
    T = TWO_PI / omega_of(rpm)
    atol = np.array([ATOL_X, ATOL_V, ATOL_X, ATOL_V])
    _, dense = _integrate_piecewise(rhs, z0, 0.0, T, rpm, p, atol)
    t = np.arange(n) * (T / n)
    z = dense(t)
    psi = omega_of(rpm) * t
    return dict(psi=psi, t=t, z=z, W=level_a_load(t, z, rpm, p), W_kin=kinematic_load(psi, p),
                dense=dense, periodicity_error=err, T=T)


def level_a_min_load(rpm: float, p: dict, cycle: dict | None = None, n_grid: int = 7200):
    """Smallest level-A contact load over the steady cycle (continuous in ``psi``).

    The load is sampled on ``n_grid`` points from the dense output and the smallest sample is refined
    with ``minimize_scalar`` (bounded, ``xatol`` 1e-13 s).

    Returns
    -------
    W_min : float
        N.
    psi_min : float
        Cam angle of the minimum (rad).
    """
    cyc = level_a_cycle(rpm, p, n=8) if cycle is None else cycle
    T, dense = cyc["T"], cyc["dense"]
    t = np.linspace(0.0, T, n_grid, endpoint=False)
    W = level_a_load(t, dense(t), rpm, p)
    i = int(np.argmin(W))
    dtg = T / n_grid

    def f(tt):
        return float(level_a_load(tt, dense(tt), rpm, p)[0])

    res = minimize_scalar(f, bounds=(max(t[i] - dtg, 0.0), min(t[i] + dtg, T)), method="bounded",
                          options=dict(xatol=1e-13))
    if res.fun < W[i]:
        return float(res.fun), float(omega_of(rpm) * res.x)
    return float(W[i]), float(omega_of(rpm) * t[i])


# ---------------------------------------------------------------------------------------------
# Level B (extension): free follower, one-sided Hertz cam contact, one-sided valve seat
# ---------------------------------------------------------------------------------------------
#: level-B seat modes: "off" (y3 >= 0), "on" (y3 < 0 and the seat force -K_se y3 - C_se y3' > 0),
#: "slack" (y3 < 0 but that force <= 0, so the reaction max(0, ...) is 0)
SEAT_MODES = ("off", "on", "slack")

#: level-B event kinds, in the event log
EVENT_KINDS = ("contact_loss", "contact_regain", "seat_closing", "seat_liftoff", "seat_slack", "seat_reengage")


def _level_b_functions(rpm: float, p: dict):
    """Right-hand side and event functions of level B for a fixed mode (contact, seat).

    Inside a mode the force laws are extended smoothly past their switching surfaces (the contact load
    as an odd function of the penetration, the seat force linearly), so that trial stages of the step
    that ends on an event see no jump; the events themselves switch the mode.
    """
    w = omega_of(rpm)
    S, beta, R0 = p["S"], p["beta"], p["R0"]
    Sigma, L_c, g_lash = p["Sigma"], p["L_c"], p["g_lash"]
    m3, m5, m6 = p["m3"], p["m5"], p["m6"]
    k1, k2, k3, c, f_p = p["k_s1"], p["k_s2"], p["k_s3"], p["c"], p["f_p"]
    K_se, C_se = p["K_se"], p["C_se"]

    def cam_load(t, y3):
        s, _, s2, _ = _lift_scalar(w * t, S, beta)
        g = s - g_lash - y3
        Rc = R0 + s + s2
        return math.copysign(_lambertw_load(abs(g), Rc, Sigma, L_c), g)

    def rhs(t, x, contact, seat):
        y3, v3, y5, v5, y6, v6 = x
        W = cam_load(t, y3) if contact else 0.0
        F = (-K_se * y3 - C_se * v3) if seat == "on" else 0.0
        a3 = (W + F - f_p - k1 * (y3 - y5) - c * (v3 - v5)) / m3  # y3 free
        a5 = (k1 * (y3 - y5) + c * (v3 - v5) - k2 * (y5 - y6) - c * (v5 - v6)) / m5
        a6 = (k2 * (y5 - y6) + c * (v5 - v6) - k3 * y6 - c * v6) / m6
        return [v3, a3, v5, a5, v6, a6]

    def gap(t, x):  # penetration g = s - g_lash - y3 (> 0 in contact)
        return _lift_scalar(w * t, S, beta)[0] - g_lash - x[0]

    def lift_y(t, x):
        return x[0]

    def seat_force(t, x):
        return -K_se * x[0] - C_se * x[1]

    return rhs, gap, lift_y, seat_force, cam_load


def _mode_events(contact: bool, seat: str, gap, lift_y, seat_force, t_start: float):
    """Terminal event functions watched in a mode, each tagged with the event kind it reports.

    At the restart time ``t_start`` each function returns its value moved strictly to the side
    *before* the crossing it watches (``-max(|f|, 1e-300)`` for an upward crossing, ``+max(...)`` for a
    downward one). After an event the state lies on the switching surface and ``f(t_start)`` is 0 or
    +-1e-18 with either sign. With the wrong sign ``solve_ivp`` (which needs a sign change over a step)
    would miss a crossing inside the first step, for example a contact regained a fraction of a degree
    after a loss; with exactly 0 its root finder would return ``t_start`` itself and the mode would
    chatter. Elsewhere the functions are the plain ones.
    """
    evs = []

    def make(fun, direction, kind):
        def ev(t, x, *args):  # solve_ivp passes the mode arguments of the rhs to the events as well
            f = fun(t, x)
            if t == t_start:
                return -direction * max(abs(f), 1e-300)
            return f

        ev.terminal = True
        ev.direction = direction
        ev.kind = kind
        return ev

    evs.append(make(gap, -1.0, "contact_loss") if contact else make(gap, 1.0, "contact_regain"))
    if seat == "off":
        evs.append(make(lift_y, -1.0, "seat_closing"))
    elif seat == "on":
        evs.append(make(seat_force, -1.0, "seat_slack"))
        evs.append(make(lift_y, 1.0, "seat_liftoff"))
    else:  # slack
        evs.append(make(seat_force, 1.0, "seat_reengage"))
        evs.append(make(lift_y, 1.0, "seat_liftoff"))
    return evs


def _new_mode(kind: str, contact: bool, seat: str, x, p: dict):
    if kind == "contact_loss":
        return False, seat
    if kind == "contact_regain":
        return True, seat
    if kind == "seat_closing":
        return contact, ("on" if -p["C_se"] * x[1] > 0.0 else "slack")
    if kind == "seat_liftoff":
        return contact, "off"
    if kind == "seat_slack":
        return contact, "slack"
    if kind == "seat_reengage":
        return contact, "on"
    raise ValueError(kind)


def level_b_mode_from_state(t: float, x, rpm: float, p: dict):
    """Mode ``(contact, seat)`` implied by a state away from any switching surface."""
    s = _lift_scalar(omega_of(rpm) * t, p["S"], p["beta"])[0]
    contact = s - p["g_lash"] - x[0] > 0.0
    if x[0] >= 0.0:
        seat = "off"
    else:
        seat = "on" if -p["K_se"] * x[0] - p["C_se"] * x[1] > 0.0 else "slack"
    return bool(contact), seat


def level_b_static_state(p: dict) -> np.ndarray:
    """Static equilibrium on the base circle, ``[y3, 0, y5, 0, y6, 0]``.

    With ``y3 = -d`` the spring chain carries ``f_p - k0 d`` (series stiffness ``k0``; ``y5 = 5/8 y3``,
    ``y6 = 3/8 y3``), and the seat (``K_se d`` if ``d > 0``) and the cam (``delta^-1(d - g_lash)``)
    share it: ``W_cam + F_seat = f_p + k0 y3``. Solved with ``brentq``.
    """
    def resid(y3):
        g = -p["g_lash"] - y3
        W = float(hertz_load_from_approach_lambertw(g, p["R0"], p)) if g > 0 else 0.0
        F = -p["K_se"] * y3 if y3 < 0 else 0.0
        return W + F - p["f_p"] - p["k0"] * y3

    lo = -p["f_p"] / p["K_se"] * 1.01  # the seat alone would hold the preload there
    y3 = brentq(resid, lo, 0.0, xtol=1e-18, rtol=1e-15)
    return np.array([y3, 0.0, 0.625 * y3, 0.0, 0.375 * y3, 0.0])


def level_b_simulate(rpm: float, p: dict, x0, t0: float, t1: float, mode=None, max_events: int = 10000):
    """Integrate level B from ``t0`` to ``t1`` with event-located switching.

    Parameters
    ----------
    x0 : array_like, shape (6,)
        ``[y3, y3', y5, y5', y6, y6']`` at ``t0`` (m, m/s).
    mode : (bool, str), optional
        ``(contact, seat)`` at ``t0``; by default from the state (``level_b_mode_from_state``).
    max_events : int
        Safety limit against chattering.

    Returns
    -------
    dict
        ``x`` (state at ``t1``), ``mode`` (at ``t1``), ``dense`` (callable ``t -> x``), ``events``
        (list of dicts ``kind, t, psi`` (rad, mod 2 pi), ``x``), ``mode_of`` (callable ``t -> (contact,
        seat)`` for the dense output), ``n_rhs`` (right-hand-side evaluations).
    """
    rhs, gap, lift_y, seat_force, _ = _level_b_functions(rpm, p)
    w = omega_of(rpm)
    x = np.asarray(x0, dtype=float).copy()
    contact, seat = level_b_mode_from_state(t0, x, rpm, p) if mode is None else mode
    atol = np.array([ATOL_X, ATOL_V] * 3)
    dense = _Piecewise()
    mode_t0, mode_list = [], []
    events = []
    edges = np.concatenate([_break_times(rpm, p, t0, t1), [t1]])
    # a crossing pair inside one step would be invisible to the sign test; in free flight the step
    # could otherwise grow to several degrees of cam angle, so cap it at 0.5 deg
    max_step = math.radians(0.5) / w
    t = t0
    n_rhs = 0
    for t_end in edges:
        while t < t_end:
            evs = _mode_events(contact, seat, gap, lift_y, seat_force, t)
            sol = solve_ivp(rhs, (t, t_end), x, method="DOP853", rtol=RTOL, atol=atol, dense_output=True,
                            events=evs, args=(contact, seat), max_step=max_step)
            if not sol.success:
                raise RuntimeError(sol.message)
            n_rhs += sol.nfev
            t_stop = sol.t[-1]
            dense.add(t, t_stop, sol.sol)
            mode_t0.append(t)
            mode_list.append((contact, seat))
            x = sol.y[:, -1].copy()
            fired = [(j, te[0]) for j, te in enumerate(sol.t_events) if len(te)]
            if sol.status == 1 and fired:
                j, te = min(fired, key=lambda a: a[1])
                kind = evs[j].kind
                x = sol.y_events[j][0].copy()
                events.append(dict(kind=kind, t=float(te), psi=float((w * te) % TWO_PI), x=x.copy()))
                contact, seat = _new_mode(kind, contact, seat, x, p)
                t = float(te)
                if len(events) > max_events:
                    raise RuntimeError("too many level-B events (chattering?): last "
                                       + ", ".join(f"{e['kind']} at t={e['t']:.12g} g={gap(e['t'], e['x']):.3g}"
                                                   f" y3={e['x'][0]:.3g} v3={e['x'][1]:.3g}" for e in events[-6:]))
            else:
                t = t_end
    starts = np.array(mode_t0)

    def mode_of(tt):
        idx = np.clip(np.searchsorted(starts, np.atleast_1d(tt), side="right") - 1, 0, len(starts) - 1)
        return [mode_list[i] for i in idx]

    return dict(x=x, mode=(contact, seat), dense=dense, events=events, mode_of=mode_of, n_rhs=n_rhs)


def level_b_loads(t, X, rpm: float, p: dict):
    """Cam load ``W`` and seat reaction at times ``t`` for level-B states ``X`` of shape (6, n).

    The cam load is ``delta^-1(g)`` for ``g = s - g_lash - y3 > 0`` (0 otherwise); the seat reaction is
    ``max(0, -K_se y3 - C_se y3')`` for ``y3 < 0`` (0 otherwise).
    """
    w = omega_of(rpm)
    t = np.atleast_1d(t)
    s, _, s2, _ = lift(w * t, p)
    g = s - p["g_lash"] - X[0]
    Rc = p["R0"] + s + s2
    W = np.array([_lambertw_load(gi, ri, p["Sigma"], p["L_c"]) if gi > 0 else 0.0 for gi, ri in zip(g, Rc)])
    F = np.where(X[0] < 0.0, np.maximum(0.0, -p["K_se"] * X[0] - p["C_se"] * X[1]), 0.0)
    return W, F


def level_b_steady_cycle(rpm: float, p: dict, n: int | None = None, tol: float = 1e-8, max_rev: int = 60,
                         x0=None) -> dict:
    """Level-B periodic steady cycle by run-in with an explicit convergence test.

    Starts (by default) from the level-A periodic state of the spring masses plus the static level-B
    offsets on the base circle, and integrates whole revolutions from ``psi = 0`` until the state at
    ``psi = 0 (mod 2 pi)`` repeats: ``max(|dy|/S, |dv|/(omega S)) < tol`` between consecutive
    revolutions. The last revolution is the steady cycle.

    Parameters
    ----------
    n : int, optional
        Samples per revolution for the returned arrays (default ``p["steps_per_rev"]``).
    tol : float
        Convergence tolerance on the scaled state (``1e-8`` of ``S`` is 8e-11 m, about 0.04 N of
        contact load).
    max_rev : int
        Give up (``converged = False``) after this many revolutions.

    Returns
    -------
    dict
        ``psi, t`` (from the start of the cycle), ``x`` (6, n), ``W`` (cam load), ``F_seat``, ``events``
        (of the steady cycle, with ``t`` from its start and ``psi`` in rad), ``converged``, ``n_rev``,
        ``history`` (scaled state change per revolution), ``dense`` (``t -> x`` on ``[0, T]`` of the
        cycle), ``mode_of``, ``T``, ``jump`` (cam contact lost during the cam event, ``pi - beta`` to
        ``pi + beta``), ``bounce`` (more than one seat lift-off per revolution, i.e. a second seat
        separation after closing), ``n_rhs`` (right-hand-side evaluations of the last revolution).
    """
    n = p["steps_per_rev"] if n is None else n
    w = omega_of(rpm)
    T = TWO_PI / w
    if x0 is None:
        zA, _ = level_a_periodic_state(rpm, p)
        x0 = level_b_static_state(p)
        x0[2:] += zA
    x = np.asarray(x0, dtype=float)
    scale = np.array([p["S"], w * p["S"]] * 3)
    history = []
    mode = None
    res = None
    converged = False
    while len(history) < max_rev:
        res = level_b_simulate(rpm, p, x, 0.0, T, mode=mode)
        err = float(np.max(np.abs(res["x"] - x) / scale))
        history.append(err)
        x, mode = res["x"], res["mode"]
        if err < tol:
            converged = True
            break
    t = np.arange(n) * (T / n)
    X = res["dense"](t)
    W, F = level_b_loads(t, X, rpm, p)
    events = res["events"]
    rise0, rise1 = math.pi - p["beta"], math.pi + p["beta"]
    jump = any(e["kind"] == "contact_loss" and rise0 < e["psi"] < rise1 for e in events)
    # periodic cycle: the cam opens the valve once, so any further seat lift-off is a bounce after closing
    bounce = sum(e["kind"] == "seat_liftoff" for e in events) > 1
    return dict(psi=w * t, t=t, x=X, W=W, F_seat=F, events=events, converged=converged, n_rev=len(history),
                history=history, dense=res["dense"], mode_of=res["mode_of"], T=T, jump=jump, bounce=bounce,
                n_rhs=res["n_rhs"])


# ---------------------------------------------------------------------------------------------
# Cycle outputs
# ---------------------------------------------------------------------------------------------
def cycle_outputs(rpm: float, p: dict, level: str = "A", n: int | None = None, film_revs: int = 2,
                  ws_mode: str | None = None, level_b_tol: float = 1e-8) -> dict:
    """Film thickness, velocities, load and Hertz quantities over a steady cycle, plus summaries.

    Parameters
    ----------
    rpm : float
        Camshaft speed (r/min).
    level : {"A", "B", "kinematic", "rigid"}
        Load model: level A (R-40'), level B (free follower), the kinematic load (R-43'), or the rigid
        follower without surge.
    n : int, optional
        Steps per revolution (default ``p["steps_per_rev"]``); the steps start at ``psi = 0`` and include
        the nose (``psi = pi``) when ``n`` is even.
    film_revs : int
        Revolutions of the film scheme (periodic inputs); the last is reported, so that the arbitrary
        start (R-39) does not show (its effect is gone well before the cam event anyway).
    ws_mode : str, optional
        Squeeze-ratio handling of ``ehl_film_scheme`` (default from ``p["ws_clip"]``).

    Returns
    -------
    dict
        Arrays over the steps: ``psi`` (rad), ``psi_deg``, ``t``, ``u`` (entraining), ``u_s``
        (sliding), ``R`` (radius of curvature), ``e`` (offset), ``W`` (load), ``b0``, ``p0`` (Hertz),
        ``h`` (film), ``w`` (squeeze velocity), ``ws_raw``, ``ws``, ``clipped``, ``valid`` (dict per
        group), ``jump_predicted`` (``W < 0``, level A). Summaries: ``dt``, ``dpsi``, ``nose_film``,
        ``nose_u``, ``h_max``, ``psi_h_max``, ``h_min``, ``psi_h_min``, ``fraction_outside`` (dict per
        group), ``W_min``, ``W_max``, ``psi_W_min`` (sampled), ``base_load_min``, ``base_load_max``
        (load on the base circle, sampled on a fine grid for levels A and B), ``surge_ripple``
        (half the peak-to-peak base-circle load). Level A adds ``W_min_continuous`` and
        ``psi_W_min_continuous``; level B adds ``events``, ``jump``, ``bounce``, ``converged``, ``n_rev``,
        ``F_seat``, ``y3`` and ``level_b`` (the full ``level_b_steady_cycle`` result).
    """
    n = p["steps_per_rev"] if n is None else n
    w = omega_of(rpm)
    T = TWO_PI / w
    dt = T / n
    t = np.arange(n) * dt
    psi = w * t
    out = dict(psi=psi, psi_deg=np.degrees(psi), t=t, dt=dt, dpsi=TWO_PI / n, rpm=rpm, level=level)
    extra = {}
    base = (np.mod(psi, TWO_PI) < math.pi - p["beta"]) | (np.mod(psi, TWO_PI) > math.pi + p["beta"])
    tb = np.linspace(0.0, T, 20 * n, endpoint=False)
    psib = w * tb
    base_fine = (psib < math.pi - p["beta"]) | (psib > math.pi + p["beta"])
    if level == "A":
        cyc = level_a_cycle(rpm, p, n=n)
        W = cyc["W"]
        Wmin, psimin = level_a_min_load(rpm, p, cycle=cyc)
        extra.update(W_min_continuous=Wmin, psi_W_min_continuous=psimin,
                     periodicity_error=cyc["periodicity_error"])
        Wb = level_a_load(tb[base_fine], cyc["dense"](tb[base_fine]), rpm, p)
    elif level == "B":
        cyc = level_b_steady_cycle(rpm, p, n=n, tol=level_b_tol)
        W = cyc["W"]
        extra.update(events=cyc["events"], jump=cyc["jump"], bounce=cyc["bounce"], converged=cyc["converged"],
                     n_rev=cyc["n_rev"], F_seat=cyc["F_seat"], y3=cyc["x"][0], level_b=cyc)
        tt = tb[base_fine]
        Wb, _ = level_b_loads(tt, cyc["dense"](tt), rpm, p)
    elif level == "kinematic":
        W = kinematic_load(psi, p)
        Wb = W[base]
    elif level == "rigid":
        W = rigid_load(psi, rpm, p)
        Wb = W[base]
    else:
        raise ValueError(level)
    s, s1, s2, _ = lift(psi, p)
    Rc = p["R0"] + s + s2
    u = 0.5 * w * (p["R0"] + s + 2.0 * s2)
    film = ehl_film_scheme(W, Rc, u, dt, p, n_rev=film_revs, ws_mode=ws_mode)
    h = film["h"]
    i_nose = int(np.argmin(np.abs(psi - math.pi)))
    imax, imin = int(np.argmax(h)), int(np.argmin(h))
    out.update(u=u, u_s=w * (p["R0"] + s), R=Rc, e=s1, W=W, b0=hertz_half_width(W, Rc, p),
               p0=hertz_max_pressure(W, Rc, p), h=h, w=film["w"], ws_raw=film["ws_raw"], ws=film["ws"],
               clipped=film["clipped"], valid=film["valid"], jump_predicted=W < 0.0,
               nose_index=i_nose, nose_film=float(h[i_nose]), nose_u=float(u[i_nose]),
               h_max=float(h[imax]), psi_h_max=float(psi[imax]), h_min=float(h[imin]), psi_h_min=float(psi[imin]),
               fraction_outside={k: float(np.mean(~v)) for k, v in film["valid"].items()},
               fraction_clipped=float(np.mean(film["clipped"])),
               W_min=float(W.min()), W_max=float(W.max()), psi_W_min=float(psi[int(np.argmin(W))]),
               base_load_min=float(np.min(Wb)), base_load_max=float(np.max(Wb)),
               surge_ripple=0.5 * float(np.max(Wb) - np.min(Wb)))
    out.update(extra)
    return out


# ---------------------------------------------------------------------------------------------
# Jump speeds
# ---------------------------------------------------------------------------------------------
def jump_speed(p: dict, level: str = "A", rpm_lo: float = 2500.0, rpm_hi: float = 4000.0, xtol: float = 1.0,
               level_b_tol: float = 1e-7) -> float:
    """Camshaft speed (r/min) of the first jump, by bisection on ``[rpm_lo, rpm_hi]``.

    Level ``"A"``: the steady-cycle minimum of the adherent load (R-40') reaches 0 (first ``W < 0``).
    Level ``"B"``: the free follower first loses cam contact during the cam event in the steady cycle.
    Level ``"rigid"``: as ``rigid_jump_speed``. The predicate must be False at ``rpm_lo`` and True at
    ``rpm_hi``; if it switches more than once in between, bisection returns one of the switches.
    Each level-B evaluation runs a steady cycle, so ``xtol`` sets the cost.
    """
    if level == "rigid":
        return rigid_jump_speed(p)
    if level == "A":
        def pred(r):
            return level_a_min_load(r, p)[0] < 0.0
    elif level == "B":
        def pred(r):
            return level_b_steady_cycle(r, p, n=8, tol=level_b_tol)["jump"]
    else:
        raise ValueError(level)
    lo, hi = float(rpm_lo), float(rpm_hi)
    if pred(lo) or not pred(hi):
        raise ValueError("the jump predicate must be False at rpm_lo and True at rpm_hi")
    while hi - lo > xtol:
        mid = 0.5 * (lo + hi)
        if pred(mid):
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)

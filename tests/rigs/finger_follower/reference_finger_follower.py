"""Independent reference model of the OHC finger-follower valve train with a hydraulic lash adjuster.

The system is the overhead-cam finger-follower valve train with a hydraulic tappet (hydraulic lash
adjuster, HLA) of Kim, Jeon & Park (1990), as repaired by the project's valve-train specification
(part K). The module uses NumPy and SciPy only (``solve_ivp``, ``CubicSpline``) and imports nothing
from ``impactid``: it exists to cross-check the compiled simulator. It favours clarity and accuracy
over speed.

Conventions
-----------
* SI units everywhere (m, kg, s, N, rad). Camshaft speeds are in rpm where a function says so.
* Degrees of freedom, state vector ``y`` (12 entries)::

      y = [Y_t, Y_f, theta_f, Y_s1, Y_s2, Y_v,  dY_t, dY_f, dtheta_f, dY_s1, dY_s2, dY_v]

  ``Y_t`` tappet plunger (+ down = compressed, "leak-down"), ``Y_f`` follower centre of gravity G
  (+ down), ``theta_f`` follower rotation about G (+ when the valve end goes down), ``Y_s1``, ``Y_s2``
  the two valve-spring masses, ``Y_v`` valve (+ down = opening). Every coordinate is measured from the
  static equilibrium on the base circle (all zero at rest; the contact forces are then the preloads).
* Cam angle ``theta = theta0 + omega t``; ``theta = 0`` at the nose of the reference cam, negative on
  the opening flank. The default cam sense is clockwise in the pivot frame of the geometry
  (``cam_sense = -1``): the cam surface at the contact moves towards the pivot and the opening flank has
  the low rocker ratio.
* Geometry frame for the kinematics: origin at the pivot B (tappet/follower contact), x horizontal
  towards the valve tip, y up towards the cam.

Model (Kim, Jeon & Park 1990, with the repairs of the specification)
--------------------------------------------------------------------
Contact deflections (compression positive) and total contact forces, preloads included::

    d_tf = Y_f - L_tf sin(theta_f) - Y_t
    d_fc = Y_c(theta) - Y_f - L_fc(theta) sin(theta_f)
    d_vf = Y_f - Y_v + L_vf sin(theta_f)
    F_i  = F_i0 + K_i d_i + C_i dd_i/dt     (0 while d_i < -F_i0/K_i: the paper's separation criteria)

Equations of motion (Kim et al. eq. 8, tappet row with the drag force of eq. 6)::

    M_t Y_t''     = F_tf - F_tf0 - K_s Y_t - (alpha C_d(sign Y_t') Y_t' + beta K_e Y_t)
    M_f Y_f''     = F_fc - F_tf - F_vf
    I_f theta_f'' = F_tf L_tf + F_fc L_fc(theta) - F_vf L_vf     (times cos(theta_f) if moment_cos)
    m1 Y_s1''     = K_s1 (Y_v - Y_s1) + C_s1 (Y_v' - Y_s1') - K_s2 (Y_s1 - Y_s2) - C_s2 (Y_s1' - Y_s2')
    m2 Y_s2''     = K_s2 (Y_s1 - Y_s2) + C_s2 (Y_s1' - Y_s2') - K_s3 Y_s2 - C_s3 Y_s2'
    M_v Y_v''     = F_vf - F_o + R_seat - K_s1 (Y_v - Y_s1) - C_s1 (Y_v' - Y_s1')
    R_seat        = F_o - F_vf0 - K_se Y_v - C_se Y_v'   while seated (Y_v < Y_v*), else 0
    Y_v*          = (F_o - F_vf0) / K_se

The cam input ``Y_c`` and the lever arm ``L_fc`` come from the kinematic inversion (the paper's section
3.1, repaired: the contact lies on the common normal through the pad centre), tabulated over one
revolution and interpolated with periodic cubic splines.

Numerics (hybrid, event-driven)
-------------------------------
Inside one integration phase the right-hand side is smooth: the discrete mode (which contacts carry
force, seated or open valve, compression or refill branch of the tappet damping) is frozen. Every
switching surface is a terminal ``solve_ivp`` event: the three contact criteria ``g_i = d_i + F_i0/K_i``,
the seat threshold ``Y_v - Y_v*``, the sign of ``Y_t'`` and, with ``clip_tension``, the zero crossings
of the raw contact forces and of the seat reaction. At each event the integration restarts from the
event state with the switched mode. The sign of ``Y_t'`` uses a hysteresis of ``VT_EPS`` = 1e-10 m/s
(the damping force ambiguity is below ``alpha C_d+ VT_EPS`` = 2e-6 N); without it round-off chatter of
``Y_t'`` around exactly 0 on the base circle would trigger endless zero-length events.
``solve_ivp`` sees an event only when the function has opposite signs at the two ends of a step, so
a contact that opens and closes within one step would go unseen (this happens in free flight, where
the steps grow). Each ``solve_ivp`` call (at most 5 deg of cam angle) is therefore audited: its dense
output is probed every ``PROBE_DT`` = 2 us (1/44 of the period of the fastest linearised mode) and a
crossing found there ends the phase at its root (see :func:`simulate`).

Default integrator: RK45 (Dormand-Prince 5(4)) with ``rtol = 1e-10``, the absolute tolerances
``DEFAULT_ATOL`` (1e-12 m on the displacements, 5e-11 rad on ``theta_f`` = 1e-12 m at the lever arms,
1e-9 m/s and 5e-8 rad/s on the rates) and ``max_step = T/1000``. Justification: the contact
stiffnesses are 4e7 to 8e7 N/m, so 1e-12 m of deflection is 1e-4 N of contact force (the forces are
50 to 1100 N); the largest linearised mode is about 11 kHz, where a 1e-9 m/s rate error matches a
1e-14 m displacement error and gives under 1e-6 N through the contact dampers. The compression branch
of the tappet damper is stiff (``alpha C_d+ / M_t`` = 4e5 1/s, a 2.4 us time constant), so the step
is mostly set by the stability of the explicit method. That is why RK45 is used rather than DOP853:
against a DOP853 run at ``rtol = 1e-12``, ``max_step = T/20000`` (one revolution from rest at 600, 900
and 2450 rpm), RK45 at the defaults is within 1e-12 m in the displacements and 1e-4 N in all forces
(checked in the tests), whereas DOP853 at ``rtol = 1e-10`` (same cost) was off by up to 2e-10 m and
0.07 N (tappet drag): its error estimate is unreliable near its stability boundary.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicSpline
from scipy.optimize import brentq

__all__ = [
    "STATE_NAMES",
    "DEFAULT_ATOL",
    "VT_EPS",
    "ALPHA_BETA_POINTS",
    "tappet_limits",
    "surge_model",
    "contact_damping",
    "equivalent_follower_mass",
    "preloads",
    "alpha_beta",
    "reference_params",
    "cam_lift",
    "cam_radius_of_curvature",
    "base_geometry",
    "contact_kinematics",
    "kinematics_table",
    "Kinematics",
    "build_kinematics",
    "contact_forces",
    "rhs",
    "mechanical_energy",
    "simulate",
    "run_steady_state",
    "summarize_revolution",
    "static_equilibrium",
    "linearised_modes",
]

DEG = math.pi / 180.0
TWO_PI = 2.0 * math.pi

#: names of the six coordinates, in state order (the rates follow in the same order)
STATE_NAMES = ("Y_t", "Y_f", "theta_f", "Y_s1", "Y_s2", "Y_v")

#: absolute tolerances per state component (see the module docstring for the justification)
DEFAULT_ATOL = np.array([1e-12, 1e-12, 5e-11, 1e-12, 1e-12, 1e-12,
                         1e-9, 1e-9, 5e-8, 1e-9, 1e-9, 1e-9])

#: hysteresis of the tappet-damping switch on the sign of Y_t' [m/s]
VT_EPS = 1e-10

#: (rpm, alpha, beta) identified by Kim, Jeon & Park (1990) at 900 and 1600 rpm camshaft speed
ALPHA_BETA_POINTS = ((900.0, 0.0071, 0.28), (1600.0, 0.0094, 0.30))


# =============================================================================================
# Parameters
# =============================================================================================
def tappet_limits(A_e, E, H_e, mu, L, R_p, h):
    """Limiting stiffness and damping of the hydraulic tappet (Kim et al. eqs. 4 and 5).

    Parameters
    ----------
    A_e, E, H_e : float
        Equivalent chamber area [m^2], oil bulk modulus [Pa], compressed oil column length [m].
    mu, L, R_p, h : float
        Oil viscosity [Pa s], plunger length [m], plunger radius [m], radial clearance [m].

    Returns
    -------
    dict
        ``K_e = A_e E / H_e`` [N/m]; ``C_d_plus`` (compression, check valve closed: Poiseuille leakage
        through the annulus plus shear) and its two terms ``C_d_plus_terms``; ``C_d_minus`` (refill:
        shear of the clearance film only) [N s/m].
    """
    K_e = A_e * E / H_e
    c1 = 6.0 * mu * math.pi * L * R_p ** 2 * (R_p + h) / h ** 3
    c2 = 2.0 * mu * math.pi * R_p * L * (3.0 * R_p + 4.0 * h) / h ** 2
    c_minus = 2.0 * mu * math.pi * L * R_p / h
    return {"K_e": K_e, "C_d_plus": c1 + c2, "C_d_plus_terms": (c1, c2), "C_d_minus": c_minus}


def surge_model(K0, f0, zeta):
    """Two-mass valve-spring surge model (Kim et al. eq. 3) with stiffness-proportional damping.

    The spring (rate ``K0``, first clamped-clamped surge frequency ``f0``) becomes two equal masses and
    three springs, symmetric, with the same static rate and first frequency and the second at ``2 f0``.

    Parameters
    ----------
    K0 : float
        Spring rate [N/m].
    f0 : float
        First surge frequency [Hz].
    zeta : float
        Modal damping ratio of the first mode (0.04 in the paper); damping ``C_si = a K_si`` with
        ``a = 2 zeta / (2 pi f0)``, which gives ``2 zeta`` in the second mode.

    Returns
    -------
    dict
        ``m``, ``K_s1`` (= ``K_s3``), ``K_s2``, ``a``, ``C_s1`` (= ``C_s3``), ``C_s2``.
    """
    m = (2.0 / 3.0) * K0 / (math.pi * f0) ** 2
    K1 = 8.0 / 3.0 * K0
    K2 = 4.0 * K0
    a = 2.0 * zeta / (TWO_PI * f0)
    return {"m": m, "K_s1": K1, "K_s2": K2, "a": a, "C_s1": a * K1, "C_s2": a * K2}


def contact_damping(K, M1, M2=None, zeta=0.06):
    """Contact damping ``zeta * C_cr`` of Kim et al. eq. 1, ``C_cr = 2 sqrt(K M1 M2/(M1+M2))``.

    ``M2=None`` means an infinite second mass (rigid camshaft): ``C_cr = 2 sqrt(K M1)``.
    """
    if M2 is None:
        return zeta * 2.0 * math.sqrt(K * M1)
    return zeta * 2.0 * math.sqrt(K * M1 * M2 / (M1 + M2))


def equivalent_follower_mass(l, M_f, I_f):
    """Equivalent follower mass at distance ``l`` from G (Kim et al. eq. 2): ``M_f/(1 + M_f l^2/I_f)``."""
    return M_f / (1.0 + M_f * l * l / I_f)


def preloads(F_tf0, RR0):
    """Static contact preloads on the base circle (moment and force balance of the follower).

    ``F_vf0 = F_tf0/(RR0 - 1)``, ``F_fc0 = F_tf0 + F_vf0``. Returns ``(F_vf0, F_fc0)`` [N].
    """
    F_vf0 = F_tf0 / (RR0 - 1.0)
    return F_vf0, F_tf0 + F_vf0


def alpha_beta(rpm, p=None, law=None):
    """Tappet drag weights (alpha, beta) at a camshaft speed.

    Parameters
    ----------
    rpm : float
        Camshaft speed [1/min].
    p : dict, optional
        Parameters; ``p["alpha_beta_points"]`` and ``p["ab_law"]`` are used if given.
    law : {"linear", "step"}, optional
        ``"linear"`` (the specification's decision): linear in rpm between the 900 and 1600 rpm pairs,
        held constant outside. ``"step"``: the 900 rpm pair below 1600 rpm and the 1600 rpm pair from
        1600 rpm (what the specification's reference runs used). Both agree outside (900, 1600).

    Returns
    -------
    (float, float)
        ``alpha``, ``beta``.
    """
    pts = ALPHA_BETA_POINTS if p is None else p.get("alpha_beta_points", ALPHA_BETA_POINTS)
    if law is None:
        law = "linear" if p is None else p.get("ab_law", "linear")
    (n1, a1, b1), (n2, a2, b2) = pts
    if law == "step":
        return (a1, b1) if rpm < n2 else (a2, b2)
    if law != "linear":
        raise ValueError(f"unknown alpha/beta law {law!r}")
    if rpm <= n1:
        return a1, b1
    if rpm >= n2:
        return a2, b2
    w = (rpm - n1) / (n2 - n1)
    return a1 + w * (a2 - a1), b1 + w * (b2 - b1)


def reference_params(preset="paper", *, F_tf0=20.0, clip_tension=False, moment_cos=False, cam_sense=-1,
                     S_K=6.0e-3, beta_K=0.5 * math.pi, ab_law="linear"):
    """All parameters of the model in SI units (Tables 1 to 3 of Kim, Jeon & Park 1990, repaired).

    Parameters
    ----------
    preset : {"paper", "table2"}
        ``"paper"``: tappet stiffness ``K_e = A_e E/H_e = 1.6432e7 N/m`` from eq. 4 and Table 1.
        ``"table2"``: Table 2's printed ``K_tp = 6.648e7 N/m`` used in place of ``K_e`` (the drag
        stiffness is then ``beta K_tp``). Both use ``C_d+ = 2.6350e6``, ``C_d- = 1.1281 N s/m`` (eq. 5).
    F_tf0 : float
        Static HLA force = tappet/follower preload [N] (assumed; 20 N default, plausible 10 to 80 N).
    clip_tension : bool
        If True, every contact force and the seat reaction are also clipped at zero (``max(F, 0)``).
        Default False follows the paper: a force is zero only while its elastic separation criterion
        holds, so damping can make it slightly tensile.
    moment_cos : bool
        If True the moments in the follower's rotation equation carry ``cos(theta_f)`` (virtual-work
        consistent). Default False follows the paper (``F L``).
    cam_sense : {-1, +1}
        Cam rotation sense in the pivot frame; -1 = clockwise (the contact surface moves towards the
        pivot; the opening flank has the low rocker ratio).
    S_K, beta_K : float
        Total lift [m] and rise (= return) angle [rad] of the reference cycloidal flat-follower lift.
    ab_law : {"linear", "step"}
        Speed law of (alpha, beta); see :func:`alpha_beta`.

    Returns
    -------
    dict
        Primary and derived parameters (keys as in the specification's proposed rig file, plus the
        surge model, contact damping, tappet limits, preloads and ``Y_v_star``).
    """
    if preset not in ("paper", "table2"):
        raise ValueError(f"unknown preset {preset!r}")
    if cam_sense not in (-1, 1):
        raise ValueError("cam_sense must be -1 or +1")
    p = dict(
        preset=preset,
        # Table 2: masses and inertia
        M_t=0.04567, M_f=0.05981, I_f=1.1527e-5, M_v=0.08544,
        # valve spring (text)
        K0=35000.0, f0=504.46, F_o=275.0, zeta_spring=0.04, zeta_contact=0.06,
        # Table 2: contact and seat stiffness / damping
        K_tf=5.52e7, K_fc=8.37e7, K_vf=4.33e7, K_se=1.31e7,
        C_tf=118.97, C_fc=197.97, C_vf=94.13, C_se=634.77,
        K_s=5.92e3, K_tp=6.648e7,
        # Table 1: tappet
        A_e=1.213e-4, H_e=1.015e-2, E_oil=1.375e9, mu_oil=0.015, R_p=7.9325e-3, h_clear=9.0e-6,
        L_p=1.358e-2,
        # Table 3: kinematic dimensions
        R_ab=36.40e-3, R_1=31.67e-3, R_c=13.00e-3, R_f=34.00e-3, L_tf=14.22e-3, L_vf=22.53e-3,
        RR0=1.47,
        # assumptions
        F_tf0=float(F_tf0), cam_sense=int(cam_sense), S_K=float(S_K), beta_K=float(beta_K),
        alpha_beta_points=ALPHA_BETA_POINTS, ab_law=ab_law,
        clip_tension=bool(clip_tension), moment_cos=bool(moment_cos),
    )
    tl = tappet_limits(p["A_e"], p["E_oil"], p["H_e"], p["mu_oil"], p["L_p"], p["R_p"], p["h_clear"])
    p["K_e_formula"] = tl["K_e"]
    p["K_e"] = tl["K_e"] if preset == "paper" else p["K_tp"]
    p["C_d_plus"] = tl["C_d_plus"]
    p["C_d_minus"] = tl["C_d_minus"]
    sm = surge_model(p["K0"], p["f0"], p["zeta_spring"])
    p.update(m1=sm["m"], m2=sm["m"], K_s1=sm["K_s1"], K_s2=sm["K_s2"], K_s3=sm["K_s1"],
             C_s1=sm["C_s1"], C_s2=sm["C_s2"], C_s3=sm["C_s1"], a_spring=sm["a"])
    p["L_sum"] = p["L_tf"] + p["L_vf"]               # follower length (assumed L_tf + L_vf)
    p["d_c0"] = p["L_sum"] / p["RR0"]                # horizontal pivot-to-contact distance, base circle
    p["L_fc0"] = p["d_c0"] - p["L_tf"]
    p["F_vf0"], p["F_fc0"] = preloads(p["F_tf0"], p["RR0"])
    p["Y_v_star"] = (p["F_o"] - p["F_vf0"]) / p["K_se"]
    return p


# =============================================================================================
# Cam lift and kinematics
# =============================================================================================
def cam_lift(gamma, p):
    """Flat-follower design lift ``S(gamma)`` and its analytic derivatives.

    The reference cam is cycloidal and symmetric about the nose (``gamma = 0``)::

        S = S_K [x/beta_K - sin(2 pi x/beta_K)/(2 pi)],  x = beta_K - |gamma|  for |gamma| < beta_K, else 0

    ``p["lift_fn"]`` (a callable ``gamma -> (S, S', S'')``) replaces the law if present.

    Parameters
    ----------
    gamma : float or array_like
        Cam-fixed generation angle [rad], 0 at the nose.
    p : dict
        Parameters (``S_K``, ``beta_K``).

    Returns
    -------
    (S, dS/dgamma, d2S/dgamma2)
        Floats for a float input, arrays otherwise [m, m/rad, m/rad^2].
    """
    if p.get("lift_fn") is not None:
        return p["lift_fn"](gamma)
    SK, bK = p["S_K"], p["beta_K"]
    if np.ndim(gamma) == 0:
        g = float(gamma)
        a = abs(g)
        if a >= bK:
            return 0.0, 0.0, 0.0
        x = bK - a
        u = TWO_PI * x / bK
        S = SK * (x / bK - math.sin(u) / TWO_PI)
        dSdx = SK / bK * (1.0 - math.cos(u))
        d2Sdx2 = SK * TWO_PI / bK ** 2 * math.sin(u)
        sgn = (g > 0) - (g < 0)
        return S, -sgn * dSdx, d2Sdx2
    g = np.asarray(gamma, dtype=float)
    a = np.abs(g)
    inside = a < bK
    x = np.where(inside, bK - a, 0.0)
    u = TWO_PI * x / bK
    S = np.where(inside, SK * (x / bK - np.sin(u) / TWO_PI), 0.0)
    S1 = np.where(inside, -np.sign(g) * SK / bK * (1.0 - np.cos(u)), 0.0)
    S2 = np.where(inside, SK * TWO_PI / bK ** 2 * np.sin(u), 0.0)
    return S, S1, S2


def cam_radius_of_curvature(gamma, p):
    """Cam radius of curvature ``rho = R_c + S + S''`` of the flat-follower cam (must stay > 0)."""
    S, _, S2 = cam_lift(gamma, p)
    return p["R_c"] + np.asarray(S) + np.asarray(S2)


def base_geometry(p):
    """Base-circle configuration in the pivot frame (origin at the pivot B).

    Triangle A B C0 has ``|AB| = R_ab``, ``|BC0| = R_1``, ``|AC0| = R_c + R_f``. The base contact
    ``P0 = A + R_c/(R_c + R_f) (C0 - A)`` is placed at the horizontal distance
    ``d_c0 = (L_tf + L_vf)/RR0`` from the pivot, with the cam above the follower (the mirror solution,
    cam below, is rejected).

    Returns
    -------
    dict
        ``A``, ``C0``, ``P0`` (arrays [m]); ``g0`` = direction of ``C0 - A`` [rad]; ``angle_B`` = angle
        ABC0 [rad]; ``BP0`` = |BP0| [m]; ``normal_deg`` = direction of the base contact normal (from C0
        to A) [deg].
    """
    Rab, R1, Rc, Rf = p["R_ab"], p["R_1"], p["R_c"], p["R_f"]
    cosB = (Rab ** 2 + R1 ** 2 - (Rc + Rf) ** 2) / (2.0 * Rab * R1)
    angB = math.acos(cosB)
    lam = Rc / (Rc + Rf)
    # with A on the +x axis, C0 at angle -angB (A above C0 after rotation)
    A_ = np.array([Rab, 0.0])
    C_ = R1 * np.array([math.cos(-angB), math.sin(-angB)])
    P_ = A_ + lam * (C_ - A_)
    r = math.hypot(P_[0], P_[1])
    delta = math.atan2(P_[1], P_[0])
    d_c0 = p["d_c0"]
    if d_c0 > r:
        raise ValueError("base contact cannot reach the horizontal distance d_c0")
    a = math.acos(d_c0 / r) - delta          # rotation putting P0 at x = d_c0, y > 0 (cam above)
    rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    A = rot @ A_
    C0 = rot @ C_
    P0 = rot @ P_
    g0 = math.atan2(C0[1] - A[1], C0[0] - A[0])
    normal = math.atan2(A[1] - C0[1], A[0] - C0[0])
    return {"A": A, "C0": C0, "P0": P0, "g0": g0, "angle_B": angB, "BP0": r,
            "normal_deg": normal / DEG}


def _contact_newton(theta, gamma, p, geo):
    """Newton solve of |A + Rot(sigma theta) Q(gamma) - B| = R_1 for gamma; returns (gamma, parts)."""
    sig = p["cam_sense"]
    Ax, Ay = geo["A"]
    g0 = geo["g0"]
    Rc, Rf, R1 = p["R_c"], p["R_f"], p["R_1"]
    for _ in range(60):
        S, S1, S2 = cam_lift(gamma, p)
        psi = g0 + sig * (theta - gamma)
        cp, sp = math.cos(psi), math.sin(psi)
        nx, ny = cp, sp
        tx, ty = sig * sp, -sig * cp            # t = dn/dgamma (rotated frame)
        Cx = Ax + (Rc + S + Rf) * nx + S1 * tx
        Cy = Ay + (Rc + S + Rf) * ny + S1 * ty
        f = Cx * Cx + Cy * Cy - R1 * R1
        rho_p = Rc + S + S2 + Rf                 # dC/dgamma = rho_p t
        df = 2.0 * rho_p * (Cx * tx + Cy * ty)
        step = -f / df
        gamma += step
        if abs(step) < 1e-15:
            break
    else:  # pragma: no cover - Newton always converges for this geometry
        raise RuntimeError(f"contact Newton did not converge at theta={theta}")
    S, S1, S2 = cam_lift(gamma, p)
    psi = g0 + sig * (theta - gamma)
    cp, sp = math.cos(psi), math.sin(psi)
    n = np.array([cp, sp])
    t = np.array([sig * sp, -sig * cp])
    C = geo["A"] + (Rc + S + Rf) * n + S1 * t
    P = geo["A"] + (Rc + S) * n + S1 * t
    return gamma, dict(S=S, S1=S1, S2=S2, n=n, t=t, C=C, P=P)


def contact_kinematics(theta, p, gamma_guess=None, geo=None):
    """Exact contact point and kinematic outputs at one cam angle (the paper's section 3.1, repaired).

    The cam profile in cam-fixed coordinates is the flat-follower envelope of Kim et al. eq. 7,
    ``P_cam(gamma) = (R_c + S) n(gamma) + S'(gamma) t(gamma)``, with the pitch curve
    ``Q = P_cam + R_f n`` (pad centre). The pad centre ``C`` satisfies ``|C - B| = R_1``; the contact
    lies on the common normal through ``C``. The root is continued from the base configuration
    (``gamma = theta`` on the base circle); ``gamma_guess`` should be the root at a nearby angle.

    Parameters
    ----------
    theta : float
        Cam angle [rad] (0 at the nose).
    p : dict
        Parameters.
    gamma_guess : float, optional
        Starting value of the generation angle (default ``theta``).
    geo : dict, optional
        :func:`base_geometry` output (computed if omitted).

    Returns
    -------
    dict
        ``gamma``; ``C``, ``P`` [m]; ``phi`` follower rotation [rad] (+ = valve end down);
        ``d_c`` = x of P; ``RR = (L_tf + L_vf)/d_c``; ``L_fc = d_c - L_tf``; ``Y_c = d_c sin(phi)``;
        ``Y_v_kin = (L_tf + L_vf) sin(phi)``; and the exact derivatives ``dphi``, ``dd_c``, ``dL_fc``,
        ``dY_c``, ``dgamma`` with respect to theta (implicit differentiation).
    """
    if geo is None:
        geo = base_geometry(p)
    if gamma_guess is None:
        gamma_guess = theta
    gamma, q = _contact_newton(float(theta), float(gamma_guess), p, geo)
    C, P, n, t = q["C"], q["P"], q["n"], q["t"]
    Rc, Rf = p["R_c"], p["R_f"]
    rho_p = Rc + q["S"] + q["S2"] + Rf
    # partial derivatives of C: dC/dgamma = rho_p t ; dC/dtheta|gamma = sigma-rotation of the vector A->C
    dn_dth = -t                                 # d n / d theta at fixed gamma (= -t for both senses)
    dt_dth = n
    dC_dth = (Rc + q["S"] + Rf) * dn_dth + q["S1"] * dt_dth
    dC_dg = rho_p * t
    dgamma = -float(C @ dC_dth) / float(C @ dC_dg)
    dC = dC_dth + dC_dg * dgamma
    dn = dn_dth + t * dgamma
    dP = dC - Rf * dn
    ang0 = math.atan2(geo["C0"][1], geo["C0"][0])
    ang = math.atan2(C[1], C[0])
    phi = ang0 - ang
    phi = (phi + math.pi) % TWO_PI - math.pi
    dphi = -(C[0] * dC[1] - C[1] * dC[0]) / float(C @ C)
    d_c = float(P[0])
    dd_c = float(dP[0])
    L = p["L_sum"]
    out = dict(gamma=gamma, C=C, P=P, phi=phi, d_c=d_c, RR=L / d_c, L_fc=d_c - p["L_tf"],
               Y_c=d_c * math.sin(phi), Y_v_kin=L * math.sin(phi),
               dgamma=dgamma, dphi=dphi, dd_c=dd_c, dL_fc=dd_c,
               dY_c=dd_c * math.sin(phi) + d_c * math.cos(phi) * dphi)
    out["dRR"] = -L * dd_c / d_c ** 2
    return out


def kinematics_table(p, step_deg=0.1):
    """Tabulate the exact kinematics over one revolution, theta from -180 deg (step ``step_deg``).

    The root is continued step by step from the base circle at -180 deg. On the base circle
    (``|gamma| >= beta_K`` for the reference cam) the contact is exactly the base configuration; the
    round-off there is removed so that the table is exactly constant (``phi = 0``, ``Y_c = 0``).

    Returns
    -------
    dict of arrays
        ``theta`` (N points, -pi <= theta < pi), ``gamma``, ``phi``, ``d_c``, ``RR``, ``L_fc``,
        ``Y_c``, ``Y_v_kin``, ``dY_c``, ``dL_fc`` (exact derivatives), ``P`` (N x 2), ``C`` (N x 2).
    """
    n = int(round(360.0 / step_deg))
    if abs(n * step_deg - 360.0) > 1e-9:
        raise ValueError("step_deg must divide 360")
    theta = -math.pi + TWO_PI * np.arange(n) / n
    geo = base_geometry(p)
    keys = ("gamma", "phi", "d_c", "RR", "L_fc", "Y_c", "Y_v_kin", "dY_c", "dL_fc")
    tab = {k: np.empty(n) for k in keys}
    tab["P"] = np.empty((n, 2))
    tab["C"] = np.empty((n, 2))
    g = theta[0]
    for i, th in enumerate(theta):
        k = contact_kinematics(th, p, gamma_guess=g, geo=geo)
        g = k["gamma"]
        S, S1, _ = cam_lift(g, p)
        if S == 0.0 and S1 == 0.0 and p.get("lift_fn") is None:
            # base circle: exact base configuration
            k.update(phi=0.0, d_c=p["d_c0"], RR=p["RR0"], L_fc=p["L_fc0"], Y_c=0.0, Y_v_kin=0.0,
                     dY_c=0.0, dL_fc=0.0, P=geo["P0"], C=geo["C0"])
        for key in keys:
            tab[key][i] = k[key]
        tab["P"][i] = k["P"]
        tab["C"][i] = k["C"]
    tab["theta"] = theta
    tab["step"] = TWO_PI / n
    return tab


class Kinematics:
    """Periodic cubic-spline interpolation of the kinematic table over one revolution.

    Attributes
    ----------
    table : dict
        The table it was built from (:func:`kinematics_table`).
    variant : str
        ``"variable"`` (the finger follower) or ``"constant_ratio"`` (see :func:`build_kinematics`).
    splines : dict of CubicSpline
        ``phi``, ``d_c``, ``RR``, ``L_fc``, ``Y_c``, ``Y_v_kin`` as periodic splines of theta.

    Notes
    -----
    :meth:`eval` is a fast scalar evaluation of ``Y_c``, ``dY_c/dtheta``, ``L_fc``, ``dL_fc/dtheta``
    from the same spline coefficients (Horner form), used by the equations of motion; the derivatives
    are those of the interpolant, so the damping terms use the exact time derivative of the
    interpolated cam input.
    """

    NAMES = ("phi", "d_c", "RR", "L_fc", "Y_c", "Y_v_kin")

    def __init__(self, table, variant="variable"):
        self.table = table
        self.variant = variant
        th = table["theta"]
        self.n = th.size
        self.h = TWO_PI / self.n
        self.theta_start = float(th[0])
        th_ext = np.append(th, th[0] + TWO_PI)
        self.splines = {}
        for name in self.NAMES:
            v = np.append(table[name], table[name][0])
            self.splines[name] = CubicSpline(th_ext, v, bc_type="periodic")
        cy = self.splines["Y_c"].c
        cl = self.splines["L_fc"].c
        self._coef = [tuple(float(v) for v in (cy[0, i], cy[1, i], cy[2, i], cy[3, i],
                                               cl[0, i], cl[1, i], cl[2, i], cl[3, i]))
                      for i in range(self.n)]

    def eval(self, theta):
        """Return ``(Y_c, dY_c/dtheta, L_fc, dL_fc/dtheta)`` at a scalar cam angle (any real value)."""
        u = (float(theta) - self.theta_start) % TWO_PI
        i = int(u / self.h)
        if i >= self.n:
            i = self.n - 1
        s = u - i * self.h
        a3, a2, a1, a0, b3, b2, b1, b0 = self._coef[i]
        return (((a3 * s + a2) * s + a1) * s + a0, (3.0 * a3 * s + 2.0 * a2) * s + a1,
                ((b3 * s + b2) * s + b1) * s + b0, (3.0 * b3 * s + 2.0 * b2) * s + b1)

    def __call__(self, name, theta, nu=0):
        """Vectorised spline value (``nu=0``) or derivative (``nu=1, 2``) of a named quantity."""
        u = (np.asarray(theta, dtype=float) - self.theta_start) % TWO_PI + self.theta_start
        return self.splines[name](u, nu)


def build_kinematics(p, step_deg=0.1, variant="variable", table=None):
    """Kinematic splines for the equations of motion.

    Parameters
    ----------
    p : dict
        Parameters.
    step_deg : float
        Table step [deg] (default 0.1; the grid contains -90, 0 and +90 deg, the ends of the cycloidal
        cam event, so the jump of S''' falls on a knot).
    variant : {"variable", "constant_ratio"}
        ``"variable"``: the finger follower (``L_fc(theta)``, ``Y_c = d_c sin(phi)``).
        ``"constant_ratio"``: the comparison system of the paper's Fig. 12 as defined here: the same
        kinematic valve lift ``Y_v,kin(theta)`` with a constant rocker ratio ``RR0`` and lever arm
        ``L_fc0``: ``L_fc = L_fc0``, ``d_c = d_c0``, ``Y_c = Y_v,kin/RR0``,
        ``phi = asin(Y_v,kin/(L_tf + L_vf))``, so that the rigid train still has zero deflections.
    table : dict, optional
        A precomputed :func:`kinematics_table` (of the variable system).

    Returns
    -------
    Kinematics
    """
    if table is None:
        table = kinematics_table(p, step_deg)
    if variant == "variable":
        return Kinematics(table, "variable")
    if variant != "constant_ratio":
        raise ValueError(f"unknown variant {variant!r}")
    t = dict(table)
    n = t["theta"].size
    yv = table["Y_v_kin"]
    t["phi"] = np.arcsin(yv / p["L_sum"])
    t["d_c"] = np.full(n, p["d_c0"])
    t["RR"] = np.full(n, p["RR0"])
    t["L_fc"] = np.full(n, p["L_fc0"])
    t["Y_c"] = yv / p["RR0"]
    return Kinematics(t, "constant_ratio")


# =============================================================================================
# Forces and equations of motion
# =============================================================================================
_SWITCHES = ("g_tf", "g_fc", "g_vf", "g_seat", "vt", "h_tf", "h_fc", "h_vf", "h_seat")


def _ab_values(p, rpm=None, alpha=None, beta=None):
    """Resolve (alpha, beta): explicit values win, else the speed law at ``rpm``."""
    if alpha is None or beta is None:
        if rpm is None:
            raise ValueError("give rpm or both alpha and beta")
        a, b = alpha_beta(rpm, p)
        alpha = a if alpha is None else alpha
        beta = b if beta is None else beta
    return float(alpha), float(beta)


def _raw(theta, y, omega, p, kin):
    """Deflections, switching values and raw (unswitched) contact forces and seat reaction."""
    Yt, Yf, th, Ys1, Ys2, Yv, vt, vf, w, vs1, vs2, vv = y
    Yc, dYc, Lfc, dLfc = kin.eval(theta)
    s, c = math.sin(th), math.cos(th)
    L_tf, L_vf = p["L_tf"], p["L_vf"]
    d_tf = Yf - L_tf * s - Yt
    d_fc = Yc - Yf - Lfc * s
    d_vf = Yf - Yv + L_vf * s
    r_tf = vf - L_tf * w * c - vt
    r_fc = dYc * omega - vf - Lfc * w * c - dLfc * omega * s
    r_vf = vf - vv + L_vf * w * c
    return dict(
        Lfc=Lfc, s=s, c=c, d_tf=d_tf, d_fc=d_fc, d_vf=d_vf, r_tf=r_tf, r_fc=r_fc, r_vf=r_vf,
        g_tf=d_tf + p["F_tf0"] / p["K_tf"], g_fc=d_fc + p["F_fc0"] / p["K_fc"],
        g_vf=d_vf + p["F_vf0"] / p["K_vf"], g_seat=Yv - p["Y_v_star"], vt=vt,
        h_tf=p["F_tf0"] + p["K_tf"] * d_tf + p["C_tf"] * r_tf,
        h_fc=p["F_fc0"] + p["K_fc"] * d_fc + p["C_fc"] * r_fc,
        h_vf=p["F_vf0"] + p["K_vf"] * d_vf + p["C_vf"] * r_vf,
        h_seat=p["F_o"] - p["F_vf0"] - p["K_se"] * Yv - p["C_se"] * vv,
    )


def _mode_from_state(raw, p):
    """Mode (tf, fc, vf, seated, tap_pos) determined by the state itself (the paper's rules)."""
    clip = p["clip_tension"]
    on = []
    for k in ("tf", "fc", "vf"):
        on.append(raw["g_" + k] >= 0.0 and (not clip or raw["h_" + k] >= 0.0))
    seated = raw["g_seat"] < 0.0 and (not clip or raw["h_seat"] >= 0.0)
    return (on[0], on[1], on[2], seated, raw["vt"] >= 0.0)


def _mode_from_signs(sg, clip):
    """Mode tuple from the sign bookkeeping of the switching functions."""
    on = [sg["g_" + k] > 0 and (not clip or sg["h_" + k] > 0) for k in ("tf", "fc", "vf")]
    seated = sg["g_seat"] < 0 and (not clip or sg["h_seat"] > 0)
    return (on[0], on[1], on[2], seated, sg["vt"] > 0)


_CONST_KEYS = ("M_t", "M_f", "I_f", "m1", "m2", "M_v", "L_tf", "L_vf", "K_tf", "K_fc", "K_vf", "K_se",
               "C_tf", "C_fc", "C_vf", "C_se", "F_tf0", "F_fc0", "F_vf0", "F_o", "K_s", "K_e", "C_d_plus",
               "C_d_minus", "K_s1", "K_s2", "K_s3", "C_s1", "C_s2", "C_s3", "moment_cos")


def _consts(p):
    """The parameters used by :func:`_accel`, as a tuple in ``_CONST_KEYS`` order."""
    return tuple(p[k] for k in _CONST_KEYS)


def _accel(theta, y, omega, c, kin, alpha, beta, mode):
    """Accelerations and forces for a frozen mode (Kim et al. eqs. 6, 8, 9).

    ``y`` is a sequence of 12 floats, ``c = _consts(p)``, ``mode = (tf_on, fc_on, vf_on, seated,
    tappet_compressing)``. Returns ``(accelerations (6), (F_tf, F_fc, F_vf, R_seat, F_drag))``.
    """
    (M_t, M_f, I_f, m1, m2, M_v, L_tf, L_vf, K_tf, K_fc, K_vf, K_se, C_tf, C_fc, C_vf, C_se, F_tf0, F_fc0,
     F_vf0, F_o, K_s, K_e, C_dp, C_dm, K_s1, K_s2, K_s3, C_s1, C_s2, C_s3, moment_cos) = c
    tf_on, fc_on, vf_on, seated, tap_pos = mode
    Yt, Yf, th, Ys1, Ys2, Yv, vt, vf, w, vs1, vs2, vv = y
    Yc, dYc, Lfc, dLfc = kin.eval(theta)
    s, co = math.sin(th), math.cos(th)
    # contact forces, totals including the preloads (eq. 9); zero while the criterion (eq. 10) holds
    F_tf = F_tf0 + K_tf * (Yf - L_tf * s - Yt) + C_tf * (vf - L_tf * w * co - vt) if tf_on else 0.0
    F_fc = (F_fc0 + K_fc * (Yc - Yf - Lfc * s)
            + C_fc * (dYc * omega - vf - Lfc * w * co - dLfc * omega * s)) if fc_on else 0.0
    F_vf = F_vf0 + K_vf * (Yf - Yv + L_vf * s) + C_vf * (vf - vv + L_vf * w * co) if vf_on else 0.0
    # seat reaction while seated (eq. 8f written as F_vf - F_o + R_seat; eq. 8g has R_seat = 0)
    R_seat = (F_o - F_vf0 - K_se * Yv - C_se * vv) if seated else 0.0
    # tappet drag (eq. 6), C_d by the sign of Y_t'
    F_drag = alpha * (C_dp if tap_pos else C_dm) * vt + beta * K_e * Yt
    a_t = (F_tf - F_tf0 - K_s * Yt - F_drag) / M_t
    a_f = (F_fc - F_tf - F_vf) / M_f
    mom = F_tf * L_tf + F_fc * Lfc - F_vf * L_vf
    if moment_cos:
        mom *= co
    a_th = mom / I_f
    sp1 = K_s1 * (Yv - Ys1) + C_s1 * (vv - vs1)
    sp2 = K_s2 * (Ys1 - Ys2) + C_s2 * (vs1 - vs2)
    sp3 = K_s3 * Ys2 + C_s3 * vs2
    a_s1 = (sp1 - sp2) / m1
    a_s2 = (sp2 - sp3) / m2
    a_v = (F_vf - F_o + R_seat - sp1) / M_v
    return (a_t, a_f, a_th, a_s1, a_s2, a_v), (F_tf, F_fc, F_vf, R_seat, F_drag)


def contact_forces(theta, y, omega, p, kin, rpm=None, alpha=None, beta=None, mode=None):
    """Contact forces, seat reaction and tappet drag at one state (Kim et al. eqs. 9 and 10).

    Parameters
    ----------
    theta : float
        Cam angle [rad].
    y : array_like
        State (12 entries).
    omega : float
        Cam speed [rad/s].
    p : dict
        Parameters.
    kin : Kinematics
        Kinematic splines.
    rpm, alpha, beta : float, optional
        Speed for the (alpha, beta) law, or explicit values (needed only for the drag force).
    mode : tuple, optional
        ``(tf_on, fc_on, vf_on, seated, tappet_compressing)``; default: from the state (the paper's
        criteria; with ``clip_tension`` a negative raw force also switches the contact off).

    Returns
    -------
    dict
        ``F_tf``, ``F_fc``, ``F_vf`` (totals incl. preloads), ``F_seat`` (seat reaction, 0 when open),
        ``F_drag`` (tappet drag of eq. 6), deflections ``d_tf``, ``d_fc``, ``d_vf``, the switching values
        and ``mode``.
    """
    y = [float(v) for v in y]
    raw = _raw(theta, y, omega, p, kin)
    if mode is None:
        mode = _mode_from_state(raw, p)
    if alpha is None and beta is None and rpm is None:
        alpha, beta = 0.0, 0.0
    else:
        alpha, beta = _ab_values(p, rpm, alpha, beta)
    _, (F_tf, F_fc, F_vf, R, Fd) = _accel(theta, y, omega, _consts(p), kin, alpha, beta, mode)
    out = dict(F_tf=F_tf, F_fc=F_fc, F_vf=F_vf, F_seat=R, F_drag=Fd, mode=mode)
    out.update({k: raw[k] for k in ("d_tf", "d_fc", "d_vf") + _SWITCHES})
    return out


def rhs(t, y, omega, theta0, p, kin, rpm=None, alpha=None, beta=None, mode=None):
    """Right-hand side ``dy/dt`` of the 6-DOF model (Kim et al. eq. 8, repaired).

    Parameters
    ----------
    t : float
        Time [s]; the cam angle is ``theta0 + omega t``.
    y : array_like
        State (12 entries, see the module docstring).
    omega, theta0 : float
        Cam speed [rad/s] and cam angle at ``t = 0`` [rad].
    p, kin : dict, Kinematics
        Parameters and kinematic splines.
    rpm, alpha, beta : float, optional
        Camshaft speed for the (alpha, beta) law or explicit values. If all are omitted, the speed is
        taken from ``omega``.
    mode : tuple, optional
        Frozen mode (see :func:`contact_forces`); default from the state.

    Returns
    -------
    numpy.ndarray
        ``dy/dt`` (12 entries).
    """
    if rpm is None and (alpha is None or beta is None):
        rpm = omega * 60.0 / TWO_PI
    alpha, beta = _ab_values(p, rpm, alpha, beta)
    theta = theta0 + omega * t
    y = [float(v) for v in y]
    if mode is None:
        mode = _mode_from_state(_raw(theta, y, omega, p, kin), p)
    acc, _ = _accel(theta, y, omega, _consts(p), kin, alpha, beta, mode)
    return np.array(y[6:] + list(acc))


def mechanical_energy(theta, y, p, kin, beta):
    """Kinetic plus potential energy of the train with the cam held at ``theta`` [J].

    Contact potentials ``V_i = K_i g_i^2/2 - F_i0^2/(2 K_i)`` for ``g_i = d_i + F_i0/K_i >= 0`` and
    ``-F_i0^2/(2 K_i)`` when separated (the elastic force ``F_i0 + K_i d_i`` vanishes at the
    separation threshold, so it is continuous); tappet ``(K_s + beta K_e) Y_t^2/2 + F_tf0 Y_t``;
    surge springs; valve ``F_vf0 Y_v + K_se Y_v^2/2`` seated, ``F_o Y_v - K_se Y_v*^2/2`` open.
    With ``moment_cos=True`` and all damping set to zero it is conserved by the equations of motion
    (used as a consistency check of signs and lever arms). Clipping of tensile forces is not included.
    """
    Yt, Yf, th, Ys1, Ys2, Yv, vt, vf, w, vs1, vs2, vv = [float(v) for v in y]
    raw = _raw(theta, [Yt, Yf, th, Ys1, Ys2, Yv, vt, vf, w, vs1, vs2, vv], 0.0, p, kin)
    T = 0.5 * (p["M_t"] * vt ** 2 + p["M_f"] * vf ** 2 + p["I_f"] * w ** 2 + p["m1"] * vs1 ** 2
               + p["m2"] * vs2 ** 2 + p["M_v"] * vv ** 2)
    V = 0.0
    for k in ("tf", "fc", "vf"):
        K, F0, g = p["K_" + k], p["F_" + k + "0"], raw["g_" + k]
        V += (0.5 * K * g * g if g >= 0.0 else 0.0) - 0.5 * F0 * F0 / K
    V += 0.5 * (p["K_s"] + beta * p["K_e"]) * Yt ** 2 + p["F_tf0"] * Yt
    V += 0.5 * (p["K_s1"] * (Yv - Ys1) ** 2 + p["K_s2"] * (Ys1 - Ys2) ** 2 + p["K_s3"] * Ys2 ** 2)
    if Yv < p["Y_v_star"]:
        V += p["F_vf0"] * Yv + 0.5 * p["K_se"] * Yv ** 2
    else:
        V += p["F_o"] * Yv - 0.5 * p["K_se"] * p["Y_v_star"] ** 2
    return T + V


# =============================================================================================
# Hybrid integration
# =============================================================================================
@dataclass
class _Ctx:
    p: dict
    kin: Kinematics
    omega: float
    theta0: float
    alpha: float
    beta: float


def _switch_value(name, t, y, ctx):
    raw = _raw(ctx.theta0 + ctx.omega * t, [float(v) for v in y], ctx.omega, ctx.p, ctx.kin)
    return raw[name]


def _monitored(sg, clip):
    names = ["g_tf", "g_fc", "g_vf", "g_seat", "vt"]
    if clip:
        for k in ("tf", "fc", "vf"):
            if sg["g_" + k] > 0:
                names.append("h_" + k)
        if sg["g_seat"] < 0:
            names.append("h_seat")
    return names


def _make_event(name, sign, ctx):
    """Terminal event leaving the current sign ``sign`` of switching function ``name``."""
    p, kin, omega, theta0 = ctx.p, ctx.kin, ctx.omega, ctx.theta0
    if name == "vt":
        off = VT_EPS * sign                   # hysteresis: switch when Y_t' passes -sign * VT_EPS

        def ev(t, y):
            return y[6] + off
    elif name == "g_seat":
        ys = p["Y_v_star"]

        def ev(t, y):
            return y[5] - ys
    elif name == "g_tf":
        L, g0 = p["L_tf"], p["F_tf0"] / p["K_tf"]

        def ev(t, y):
            return y[1] - L * math.sin(y[2]) - y[0] + g0
    elif name == "g_vf":
        L, g0 = p["L_vf"], p["F_vf0"] / p["K_vf"]

        def ev(t, y):
            return y[1] - y[5] + L * math.sin(y[2]) + g0
    elif name == "g_fc":
        g0 = p["F_fc0"] / p["K_fc"]

        def ev(t, y):
            Yc, _, Lfc, _ = kin.eval(theta0 + omega * t)
            return Yc - y[1] - Lfc * math.sin(y[2]) + g0
    else:
        def ev(t, y):
            return _switch_value(name, t, y, ctx)
    ev.terminal = True
    ev.direction = -float(sign)
    return ev


def _initial_signs(theta, y, ctx):
    """Signs (+1 for values >= 0, else -1) of all switching functions at a state."""
    raw = _raw(theta, [float(v) for v in y], ctx.omega, ctx.p, ctx.kin)
    return {k: (1 if raw[k] >= 0.0 else -1) for k in _SWITCHES}


def _update_signs(sg, fired, monitored, theta, y, ctx):
    """Signs after an event.

    The fired switches flip. A monitored switch found clearly on the wrong side (a double crossing
    inside one step, or two crossings at the same instant) is corrected and reported; the signs of
    unmonitored switches (raw forces of separated contacts) are set from their values.
    """
    raw = _raw(theta, [float(v) for v in y], ctx.omega, ctx.p, ctx.kin)
    new = dict(sg)
    corrections = []
    for k in _SWITCHES:
        if k in fired:
            new[k] = -sg[k]
            continue
        v = raw[k]
        if k not in monitored:
            new[k] = 1 if v >= 0.0 else -1
            continue
        if k == "vt":
            if sg[k] > 0 and v < -VT_EPS:
                new[k] = -1
                corrections.append(k)
            elif sg[k] < 0 and v > VT_EPS:
                new[k] = 1
                corrections.append(k)
            continue
        if k.startswith("h_"):
            tol = 1e-9          # N
        else:
            tol = 1e-15         # m
        if sg[k] > 0 and v < -tol:
            new[k] = -1
            corrections.append(k)
        elif sg[k] < 0 and v > tol:
            new[k] = 1
            corrections.append(k)
    return new, corrections


#: largest spacing of the probes with which each phase's dense output is audited for switching
#: functions that crossed and crossed back inside one step [s]
PROBE_DT = 2e-6


def _switch_array(name, theta, Y, ctx):
    """Switching function ``name`` at many points (``theta`` array, ``Y`` 12 x n)."""
    p, kin, omega = ctx.p, ctx.kin, ctx.omega
    Yt, Yf, th, Ys1, Ys2, Yv, vt, vf, w, vs1, vs2, vv = Y
    if name == "vt":
        return vt
    if name == "g_seat":
        return Yv - p["Y_v_star"]
    if name == "h_seat":
        return p["F_o"] - p["F_vf0"] - p["K_se"] * Yv - p["C_se"] * vv
    s = np.sin(th)
    c = np.cos(th)
    if name == "g_tf":
        return Yf - p["L_tf"] * s - Yt + p["F_tf0"] / p["K_tf"]
    if name == "g_vf":
        return Yf - Yv + p["L_vf"] * s + p["F_vf0"] / p["K_vf"]
    if name == "h_tf":
        return (p["F_tf0"] + p["K_tf"] * (Yf - p["L_tf"] * s - Yt)
                + p["C_tf"] * (vf - p["L_tf"] * w * c - vt))
    if name == "h_vf":
        return (p["F_vf0"] + p["K_vf"] * (Yf - Yv + p["L_vf"] * s)
                + p["C_vf"] * (vf - vv + p["L_vf"] * w * c))
    Yc, Lfc = kin("Y_c", theta), kin("L_fc", theta)
    if name == "g_fc":
        return Yc - Yf - Lfc * s + p["F_fc0"] / p["K_fc"]
    if name == "h_fc":
        dYc, dLfc = kin("Y_c", theta, 1), kin("L_fc", theta, 1)
        return (p["F_fc0"] + p["K_fc"] * (Yc - Yf - Lfc * s)
                + p["C_fc"] * (dYc * omega - vf - Lfc * w * c - dLfc * omega * s))
    raise KeyError(name)


def _leave_value(name, sign, theta, Y, ctx):
    """``sign * f + offset``: negative once switching function ``f`` has left its current sign."""
    v = sign * _switch_array(name, theta, Y, ctx)
    return v + VT_EPS if name == "vt" else v


def _audit_phase(dense, t0, t1, names, sg, ctx):
    """Earliest crossing inside (t0, t1) that the end-of-step sign test of ``solve_ivp`` missed.

    ``solve_ivp`` compares the event functions at the ends of each step only, so a contact that opens
    and closes again within one step (or a seat touch-and-go) goes unseen. The dense output of the
    phase is probed at spacing ``PROBE_DT`` (1/44 of the period of the fastest linearised mode,
    11.3 kHz); a switching function found on the wrong side at an interior probe is root-found on the
    dense output. Returns ``(t_event, name)`` or None.
    """
    n = int(math.ceil((t1 - t0) / PROBE_DT))
    if n < 2:
        return None
    ts = t0 + (t1 - t0) * np.arange(1, n) / n
    Y = dense(ts)
    theta = ctx.theta0 + ctx.omega * ts
    best = None
    for name in names:
        h = _leave_value(name, sg[name], theta, Y, ctx)
        bad = np.nonzero(h < 0.0)[0]
        if bad.size == 0:
            continue
        k = int(bad[0])
        ta = t0 if k == 0 else ts[k - 1]
        tb = ts[k]
        if best is not None and ta >= best[0]:
            continue

        def hf(tt, name=name):
            return float(_leave_value(name, sg[name], np.array([ctx.theta0 + ctx.omega * tt]),
                                      dense(np.array([tt])), ctx)[0])

        if hf(ta) <= 0.0:
            te = ta
        else:
            te = brentq(hf, ta, tb, xtol=1e-16, rtol=8.9e-16)
            # the restart must not be before the crossing: step to the far side if brentq stopped short
            if hf(te) > 0.0:
                te = np.nextafter(te, tb)
        if best is None or te < best[0]:
            best = (float(te), name)
    return best


def simulate(p, kin, y0, theta0, omega, t_end, *, rpm=None, alpha=None, beta=None, t_eval=None,
             signs=None, rtol=1e-10, atol=None, method="RK45", max_step=None, max_phases=100000):
    """Hybrid event-driven integration of the model from ``t = 0`` to ``t_end``.

    Parameters
    ----------
    p, kin : dict, Kinematics
        Parameters and kinematic splines.
    y0 : array_like
        Initial state (12 entries).
    theta0, omega : float
        Cam angle at ``t = 0`` [rad] and cam speed [rad/s] (``omega = 0`` holds the cam fixed).
    t_end : float
        End time [s].
    rpm, alpha, beta : float, optional
        Speed for the (alpha, beta) law, or explicit values; default speed from ``omega``.
    t_eval : array_like, optional
        Output times in [0, t_end] (sorted). Default: only the end point.
    signs : dict, optional
        Sign bookkeeping of the switching functions at ``t = 0`` (returned by a previous call to
        continue a run); default from the initial state.
    rtol, atol, method, max_step : optional
        ``solve_ivp`` settings; ``atol`` defaults to ``DEFAULT_ATOL``, ``max_step`` to 1/1000 of a
        revolution (``inf`` for a fixed cam).
    max_phases : int
        Safety limit on the number of integration phases.

    Returns
    -------
    dict
        ``t``, ``theta`` (unwrapped), ``y`` (12 x n), forces ``F_tf``, ``F_fc``, ``F_vf``,
        ``F_seat``, ``F_drag`` at the output times (computed with the phase's mode); ``events``
        (list of dicts: ``name``, ``direction`` (+1 rising, -1 falling), ``t``, ``theta``, ``y``);
        ``corrections`` (switches found on the wrong side at a restart: missed double crossings);
        ``y_end``, ``signs_end``, ``n_phases`` (number of ``solve_ivp`` calls), ``n_audit``
        (crossings found by the dense-output audit, see below), ``nfev``, ``alpha``, ``beta``.

    Notes
    -----
    Each phase is integrated by ``solve_ivp`` calls (at most 5 deg of cam angle each) with terminal
    events on all monitored switching functions (dense output on). ``solve_ivp`` detects an event
    only if the function has opposite signs at the two ends of a step, so a contact that separates
    and recloses within one step is not seen. Every call is therefore audited: its dense output is
    probed at spacing ``PROBE_DT`` for the contact and seat functions, and a crossing found there ends
    the phase instead (root-found on the dense output). The tappet-damping switch is not audited: the
    drag force is continuous there (its damping term vanishes at ``Y_t' = 0``), and the dense output's
    rate noise on the quiet base circle is of the order of ``VT_EPS``.
    """
    if rpm is None and (alpha is None or beta is None):
        rpm = abs(omega) * 60.0 / TWO_PI
    alpha, beta = _ab_values(p, rpm, alpha, beta)
    ctx = _Ctx(p, kin, float(omega), float(theta0), alpha, beta)
    atol = DEFAULT_ATOL if atol is None else atol
    if max_step is None:
        max_step = TWO_PI / abs(omega) / 1000.0 if omega != 0.0 else np.inf
    # length of one solve_ivp call at most (an audit finding discards the rest of the call)
    chunk = TWO_PI / abs(omega) / 72.0 if omega != 0.0 else t_end / 50.0
    clip = p["clip_tension"]
    cst = _consts(p)
    y = np.asarray(y0, dtype=float).copy()
    sg = _initial_signs(theta0, y, ctx) if signs is None else dict(signs)
    t_eval = np.array([t_end]) if t_eval is None else np.asarray(t_eval, dtype=float)
    out_t, out_y, out_F = [], [], []
    events, corrections = [], []
    t = 0.0
    i_eval = 0              # next output point not yet produced
    n_phases = 0
    n_audit = 0
    nfev = 0
    n_zero = 0
    while t < t_end:
        mode = _mode_from_signs(sg, clip)
        names = _monitored(sg, clip)
        evs = [_make_event(k, sg[k], ctx) for k in names]

        def fun(tt, yy, mode=mode):
            yl = yy.tolist()
            acc, _ = _accel(theta0 + omega * float(tt), yl, omega, cst, kin, alpha, beta, mode)
            return np.array(yl[6:] + list(acc))

        t_chunk = min(t + chunk, t_end)
        if t_end - t_chunk < 1e-3 * chunk:
            t_chunk = t_end
        sol = solve_ivp(fun, (t, t_chunk), y, method=method, events=evs, dense_output=True, rtol=rtol,
                        atol=atol, max_step=max_step)
        n_phases += 1
        nfev += sol.nfev
        if sol.status < 0:
            raise RuntimeError(f"solve_ivp failed: {sol.message}")
        t_stop = float(sol.t[-1])
        # located events (solve_ivp tests the event signs at the step ends only)
        fired = [k for k, te_k in zip(names, sol.t_events) if len(te_k)]
        t_new = min(float(te_k[0]) for te_k in sol.t_events if len(te_k)) if fired else t_chunk
        # audit of the dense output for crossings that began and ended inside one step
        miss = _audit_phase(sol.sol, t, t_stop, [k for k in names if k != "vt"], sg, ctx)
        if miss is not None and miss[0] < t_new:
            t_new, fired = miss
            fired = [fired]
            n_audit += 1
        y_new = sol.y[:, -1].copy() if not fired else sol.sol(t_new)
        # output points in [t, t_new] (the phase start only for the first phase)
        j = i_eval
        while j < t_eval.size and t_eval[j] <= t_new:
            j += 1
        if j > i_eval:
            te = t_eval[i_eval:j]
            Y = sol.sol(te)
            for tk, yk in zip(te, Y.T):
                out_t.append(tk)
                out_y.append(yk)
                _, F = _accel(theta0 + omega * float(tk), yk.tolist(), omega, cst, kin, alpha, beta, mode)
                out_F.append(F)
            i_eval = j
        if not fired:
            t, y = t_chunk, y_new
            continue
        for k in fired:
            events.append(dict(name=k, direction=-sg[k], t=t_new, theta=theta0 + omega * t_new,
                               y=y_new.copy()))
        n_zero = n_zero + 1 if t_new - t <= 1e-15 * max(1.0, abs(t)) else 0
        if n_zero > 20:
            raise RuntimeError(f"Zeno-like switching at t={t_new}: {fired}")
        sg, corr = _update_signs(sg, fired, names, theta0 + omega * t_new, y_new, ctx)
        if corr:
            corrections.append(dict(t=t_new, names=corr))
        t, y = t_new, y_new
        if n_phases > max_phases:
            raise RuntimeError("too many integration phases")
    out_y = np.array(out_y).T if out_y else np.zeros((12, 0))
    out_F = np.array(out_F).T if out_F else np.zeros((5, 0))
    out_t = np.array(out_t)
    return dict(t=out_t, theta=theta0 + omega * out_t, y=out_y, F_tf=out_F[0], F_fc=out_F[1],
                F_vf=out_F[2], F_seat=out_F[3], F_drag=out_F[4], events=events, corrections=corrections,
                y_end=y, signs_end=sg, n_phases=n_phases, n_audit=n_audit, nfev=nfev, alpha=alpha, beta=beta)


#: scales of the run-in convergence test (per state component): 1 um, 1 um at the valve lever arm,
#: 1 mm/s, and the corresponding follower-rotation rate
CONVERGENCE_SCALE = np.array([1e-6, 1e-6, 1e-6 / 22.53e-3, 1e-6, 1e-6, 1e-6,
                              1e-3, 1e-3, 1e-3 / 22.53e-3, 1e-3, 1e-3, 1e-3])


def run_steady_state(rpm, p=None, kin=None, *, variant="variable", alpha=None, beta=None, tol=1e-4,
                     min_rev=2, max_rev=40, grid_step_deg=0.02, rtol=1e-10, atol=None, method="RK45",
                     max_step_fraction=1e-3):
    """Run the model from rest on the base circle into its periodic steady state.

    The run starts at cam angle -180 deg (base circle, opposite the nose) from the static equilibrium
    (all coordinates and rates zero). Revolutions are integrated one after another; after each the
    state at -180 deg is compared with the state one revolution earlier (a Poincare section: if it
    repeats, the whole orbit repeats). Convergence: ``max_i |dy_i| / CONVERGENCE_SCALE_i < tol``,
    i.e. with the default ``tol = 1e-4`` all displacements repeat within 0.1 nm and all rates within
    0.1 um/s, about 100 times the integration error. The last revolution is the steady one.

    Parameters
    ----------
    rpm : float
        Camshaft speed [1/min].
    p : dict, optional
        Parameters (default ``reference_params()``).
    kin : Kinematics, optional
        Kinematic splines (default built from ``p`` with ``variant``).
    variant : {"variable", "constant_ratio"}
        Used only when ``kin`` is omitted.
    alpha, beta : float, optional
        Tappet drag weights; default from the speed law.
    tol : float
        Convergence tolerance (see above).
    min_rev, max_rev : int
        At least ``min_rev`` revolutions; ``RuntimeError`` if not converged after ``max_rev``.
    grid_step_deg : float
        Output grid step in cam angle [deg] (must divide 360).
    rtol, atol, method : optional
        Integrator settings (module docstring).
    max_step_fraction : float
        Largest step as a fraction of one revolution (keeps event detection from stepping over
        a short excursion on the quiet base circle).

    Returns
    -------
    dict
        ``rpm``, ``omega``, ``T``, ``alpha``, ``beta``, ``n_rev`` (revolutions run), ``converged``,
        ``history`` (per revolution: ``diff`` of the Poincare test, ``max_Y_t``, ``max_Y_v``,
        ``n_phases``, ``nfev``), ``steady`` (the output dict of :func:`simulate` for the last revolution,
        with ``theta`` mapped to [-pi, pi) and ``theta_deg``), and ``summary``
        (:func:`summarize_revolution`).
    """
    if p is None:
        p = reference_params()
    if kin is None:
        kin = build_kinematics(p, variant=variant)
    alpha, beta = _ab_values(p, rpm, alpha, beta)
    omega = TWO_PI * rpm / 60.0
    T = TWO_PI / omega
    n = int(round(360.0 / grid_step_deg))
    if abs(n * grid_step_deg - 360.0) > 1e-9:
        raise ValueError("grid_step_deg must divide 360")
    t_eval = T * np.arange(n) / n
    y = np.zeros(12)
    signs = None
    history = []
    converged = False
    res = None
    for k in range(max_rev):
        res = simulate(p, kin, y, -math.pi, omega, T, alpha=alpha, beta=beta, t_eval=t_eval, signs=signs,
                       rtol=rtol, atol=atol, method=method, max_step=max_step_fraction * T)
        diff = float(np.max(np.abs(res["y_end"] - y) / CONVERGENCE_SCALE))
        history.append(dict(rev=k + 1, diff=diff, max_Y_t=float(res["y"][0].max()),
                            max_Y_v=float(res["y"][5].max()), n_phases=res["n_phases"], nfev=res["nfev"],
                            n_corrections=len(res["corrections"])))
        y = res["y_end"]
        signs = res["signs_end"]
        if k + 1 >= min_rev and diff < tol:
            converged = True
            break
    if not converged:
        raise RuntimeError(f"no periodic steady state after {max_rev} revolutions (last diff {diff:.3g})")
    res["theta_deg"] = (res["theta"] + math.pi) % TWO_PI / DEG - 180.0
    res["theta"] = res["theta_deg"] * DEG
    summary = summarize_revolution(res, p)
    return dict(rpm=rpm, omega=omega, T=T, alpha=alpha, beta=beta, n_rev=len(history), converged=converged,
                history=history, steady=res, summary=summary, variant=kin.variant)


def _wrap_deg(theta):
    return (theta / DEG + 180.0) % 360.0 - 180.0


def summarize_revolution(res, p, flank_deg=None):
    """Summary of one (steady) revolution produced by :func:`simulate` starting at -180 deg.

    Parameters
    ----------
    res : dict
        Output of :func:`simulate` over one revolution (``theta_deg`` in [-180, 180) if present).
    p : dict
        Parameters.
    flank_deg : (float, float), optional
        ``(a, b)``: the opening flank is theta in [-b, -a] deg and the closing flank [a, b] deg.
        Default ``(beta_K/3, beta_K)`` = (30, 90) deg for the reference cam: the cam event without its
        middle third, so that the nose hump of the cam force is not taken for a flank peak. (Any ``a``
        from about 20 to 42 deg gives the same flank peaks at 2450 rpm for the variable and the
        constant-ratio system. At low speed the cam force has no separate flank hump and the flank
        maximum sits at the inner window edge.)

    Returns
    -------
    dict
        ``max_valve_lift`` [m] (max ``Y_v``), ``max_tappet_leakdown`` [m] (max ``Y_t``) and their angles;
        ``peak_cam_force_opening`` / ``_closing`` [N] (max ``F_fc`` on the opening / closing flank, the
        paper's "first" and "second" peak) with their angles; ``peak_cam_force_nose`` (max over the
        middle third); ``min_``/``max_`` of each contact force; ``openings`` (number of upward
        crossings of ``Y_v*`` = valve openings per revolution; ``bounce`` if more than one);
        ``closings`` (list of (theta_deg, Y_v') at the downward crossings); ``seating_velocity`` [m/s]
        (``Y_v'`` at the first closing after the maximum lift, negative = towards the seat);
        ``separations``: list of (contact, theta_start_deg, theta_end_deg) for the intervals in which a
        contact criterion (eq. 10) holds (``theta_end < theta_start`` means the interval wraps through
        -180 deg; ``None`` marks an end not reached in this revolution); ``tension_intervals`` (the
        same for the zero crossings of the raw force and of the seat reaction with ``clip_tension``).
    """
    th = res["theta_deg"] if "theta_deg" in res else _wrap_deg(res["theta"])
    y = res["y"]
    Ffc = res["F_fc"]
    if flank_deg is None:
        bK = p["beta_K"] / DEG
        flank_deg = (bK / 3.0, bK)
    a, b = flank_deg
    out = {}
    out["max_valve_lift"] = float(y[5].max())
    i_lift = int(np.argmax(y[5]))
    out["theta_max_lift_deg"] = float(th[i_lift])
    out["max_tappet_leakdown"] = float(y[0].max())
    out["theta_max_leakdown_deg"] = float(th[int(np.argmax(y[0]))])
    windows = {"opening": (th >= -b) & (th <= -a), "closing": (th >= a) & (th <= b),
               "nose": (th > -a) & (th < a)}
    for name, m in windows.items():
        i = int(np.argmax(np.where(m, Ffc, -np.inf)))
        out["peak_cam_force_" + name] = float(Ffc[i])
        out["theta_peak_" + name + "_deg"] = float(th[i])
    for k in ("F_tf", "F_fc", "F_vf", "F_seat"):
        out["min_" + k] = float(res[k].min())
        out["max_" + k] = float(res[k].max())
    evs = res["events"]
    openings = [e for e in evs if e["name"] == "g_seat" and e["direction"] > 0]
    closings = [e for e in evs if e["name"] == "g_seat" and e["direction"] < 0]
    out["openings"] = len(openings)
    out["opening_angles_deg"] = [float(_wrap_deg(e["theta"])) for e in openings]
    out["closings"] = [(float(_wrap_deg(e["theta"])), float(e["y"][11])) for e in closings]
    th_lift = out["theta_max_lift_deg"]
    after = [c for c in out["closings"] if c[0] > th_lift]
    out["seating_velocity"] = after[0][1] if after else (out["closings"][0][1] if out["closings"] else None)
    out["bounce"] = len(openings) > 1
    out["separations"] = _intervals(evs, ("g_tf", "g_fc", "g_vf"))
    out["tension_intervals"] = _intervals(evs, ("h_tf", "h_fc", "h_vf", "h_seat"))
    return out


def _intervals(evs, names):
    """Pair falling (start) and rising (end) crossings per switching function, by cam angle."""
    label = {"g_tf": "tappet/follower", "g_fc": "cam/follower", "g_vf": "valve/follower",
             "h_tf": "tappet/follower", "h_fc": "cam/follower", "h_vf": "valve/follower",
             "h_seat": "seat"}
    out = []
    for name in names:
        seq = [(e["direction"], float(_wrap_deg(e["theta"]))) for e in evs if e["name"] == name]
        lead_end = None
        start = None
        for d, a in seq:
            if d < 0:
                start = a
            elif start is None:
                lead_end = a          # the revolution began inside an interval
            else:
                out.append((label[name], start, a))
                start = None
        if start is not None:
            out.append((label[name], start, lead_end))
        elif lead_end is not None:
            out.append((label[name], None, lead_end))
    return out


# =============================================================================================
# Statics and linearised modes
# =============================================================================================
def static_equilibrium(theta, p, kin, beta, seated=None):
    """Static equilibrium with the cam held at ``theta`` (all contacts active).

    The tappet's static stiffness is ``K_s + beta K_e`` (the elastic part of the drag force).

    Parameters
    ----------
    theta : float
        Cam angle [rad].
    p, kin : dict, Kinematics
    beta : float
        Tappet drag stiffness weight.
    seated : bool, optional
        Force the valve branch; default: the one consistent with the solution.

    Returns
    -------
    numpy.ndarray
        Six equilibrium coordinates.
    """
    Yc, _, Lfc, _ = kin.eval(theta)
    phi = float(kin("phi", theta))
    Yv0 = p["L_sum"] * math.sin(phi)
    guess = np.array([0.0, p["L_tf"] * math.sin(phi), phi, 0.6 * Yv0, 0.3 * Yv0, Yv0])
    branches = [seated] if seated is not None else [True, False]
    steps = np.array([1e-9, 1e-9, 1e-7, 1e-9, 1e-9, 1e-9])
    Mdiag = np.array([p["M_t"], p["M_f"], p["I_f"], p["m1"], p["m2"], p["M_v"]])
    for b in branches:
        mode = (True, True, True, b, True)

        def f(q, mode=mode):
            acc, _ = _accel(theta, list(q) + [0.0] * 6, 0.0, _consts(p), kin, 0.0, beta, mode)
            return np.array(acc) * Mdiag          # generalised forces [N, N m]

        q = guess.copy()
        for _ in range(50):                       # Newton with a central-difference Jacobian
            J = np.empty((6, 6))
            for j in range(6):
                dq = np.zeros(6)
                dq[j] = steps[j]
                J[:, j] = (f(q + dq) - f(q - dq)) / (2.0 * steps[j])
            dq = np.linalg.solve(J, -f(q))
            q = q + dq
            if np.all(np.abs(dq) < 1e-15 * (1.0 + np.abs(q))):
                break
        res = np.abs(f(q))
        ok = (q[5] < p["Y_v_star"]) == b
        if res.max() < 1e-8 and (ok or seated is not None):
            return q
    raise RuntimeError("static equilibrium not found")


def linearised_modes(p, kin, config="seated", rpm=900.0, beta=None):
    """Undamped natural frequencies of the train linearised with the cam held fixed.

    Parameters
    ----------
    p, kin : dict, Kinematics
    config : {"seated", "nose"}
        ``"seated"``: cam on the base circle, valve seated (seat spring ``K_se`` active), about the
        rest state. ``"nose"``: cam held at the nose (theta = 0), valve open, about the static
        equilibrium there (computed by :func:`static_equilibrium`).
    rpm : float
        Speed that selects ``beta`` through the speed law (default 900 rpm).
    beta : float, optional
        Explicit tappet weight.

    Returns
    -------
    dict
        ``freq_hz`` (six frequencies, ascending), ``q_eq`` (equilibrium), ``M`` (diagonal mass matrix),
        ``K`` (stiffness matrix ``-dF/dq``, not symmetric in general with the paper's moments),
        ``active`` (description of the active elements).

    Notes
    -----
    All three contacts are active and linear (``K_tf``, ``K_fc``, ``K_vf``); the tappet plunger is
    tied to ground by ``K_s + beta K_e`` (the elastic part of the drag force of eq. 6; the dashpot
    ``alpha C_d`` is left out, as all damping is); the valve spring chain by ``K_s1``, ``K_s2``,
    ``K_s3``; the valve by ``K_se`` when seated, by nothing else when open (the preload ``F_o`` is a
    constant force). The lever arm is ``L_fc(theta)`` at the held angle.
    """
    if beta is None:
        _, beta = alpha_beta(rpm, p)
    if config == "seated":
        theta = -math.pi
        seated = True
        q0 = np.zeros(6)
    elif config == "nose":
        theta = 0.0
        seated = False
        q0 = static_equilibrium(theta, p, kin, beta, seated=False)
    else:
        raise ValueError(f"unknown config {config!r}")
    mode = (True, True, True, seated, True)
    Mdiag = np.array([p["M_t"], p["M_f"], p["I_f"], p["m1"], p["m2"], p["M_v"]])

    def F(q):
        acc, _ = _accel(theta, list(q) + [0.0] * 6, 0.0, _consts(p), kin, 0.0, beta, mode)
        return np.array(acc) * Mdiag

    K = np.empty((6, 6))
    steps = np.array([1e-9, 1e-9, 1e-7, 1e-9, 1e-9, 1e-9])
    for j in range(6):
        dq = np.zeros(6)
        dq[j] = steps[j]
        K[:, j] = -(F(q0 + dq) - F(q0 - dq)) / (2.0 * steps[j])
    lam = np.linalg.eigvals(K / Mdiag[:, None])
    f = np.sqrt(np.abs(lam.real)) / TWO_PI
    active = dict(contacts=("tappet/follower", "cam/follower", "valve/follower"), seat=seated,
                  tappet_ground_stiffness=p["K_s"] + beta * p["K_e"], theta=theta)
    return dict(freq_hz=np.sort(f), q_eq=q0, M=np.diag(Mdiag), K=K, active=active, beta=beta)

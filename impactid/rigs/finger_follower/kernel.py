"""Compiled (numba) event-driven integrator of the finger-follower valve train (Kim et al. 1990, K-8).

State (vector layout of :mod:`impactid.simulate.dp5`, 12 entries)::

    y = [Y_t, Y_f, theta_f, Y_s1, Y_s2, Y_v,  Y_t', Y_f', theta_f', Y_s1', Y_s2', Y_v']

coordinates from the static equilibrium on the base circle, positive down (valve opening); the cam
angle is ``theta = theta0 + omega t``.

Model
-----
Contact deflections and total forces (preloads included, K-9)::

    d_tf = Y_f - L_tf sin(theta_f) - Y_t             F_tf = F_tf0 + K_tf d_tf + C_tf d_tf'
    d_fc = Y_c(theta) - Y_f - L_fc(theta) sin(theta_f)   F_fc = F_fc0 + K_fc d_fc + C_fc d_fc'
    d_vf = Y_f - Y_v + L_vf sin(theta_f)             F_vf = F_vf0 + K_vf d_vf + C_vf d_vf'

each zero while its separation criterion ``g = d + F_0/K < 0`` holds (K-10; with ``clip_tension``
also while the force itself would be negative). Equations of motion (K-8, tappet row with the
drag force K-6 and the HLA's static force, decision K-D3)::

    M_t Y_t''     = F_tf - F_tf0 - K_s Y_t - (c_t(sign Y_t') Y_t' + k_t Y_t)
    M_f Y_f''     = F_fc - F_tf - F_vf
    I_f theta_f'' = F_tf L_tf + F_fc L_fc - F_vf L_vf           (times cos(theta_f) with moment_cos)
    surge masses  : the shared two-mass model (impactid.rigs.valvespring)
    M_v Y_v''     = F_vf - F_o + R_seat + F_spring,   R_seat = F_o - F_vf0 - K_se Y_v - C_se Y_v' while seated

with ``c_t(+) = alpha C_d+``, ``c_t(-) = alpha C_d-``, ``k_t = beta K_e``. ``Y_c``, ``L_fc`` come
from the periodic cubic splines of the kinematic table (Horner form, with their derivatives).

Modes and switching functions
-----------------------------
The mode is a bit mask: tappet, cam and valve contacts carrying force, valve seated, tappet
compressing (``Y_t' > 0``: the check valve closed). Nine switching functions decide it: the
three criteria ``g_tf, g_fc, g_vf``, the seat function ``Y_v - Y_v*``, ``Y_t'`` (with a
hysteresis of ``VT_EPS``: the damping force is continuous there, and without a hysteresis round-off
noise on the quiet base circle would switch endlessly) and, with ``clip_tension``, the raw forces
and the seat reaction. Each has a sign in the bookkeeping ``signs``; the mode is a function of the
signs.

Method
------
* Dormand–Prince 5(4) steps of the one core (:func:`impactid.simulate.dp5.step`, vector layout;
  the rig's stage inlined), its error norm, controller and dense output.
* After each accepted step every watched switching function is tested for leaving its sign: at
  the step end, and, when its rate changes from moving towards zero to moving away inside the step
  (a minimum of the "leave value"), at the minimum of the cubic Hermite interpolant of its values
  and rates at the two ends, evaluated on the dense output. So a contact that opens and closes
  within one step is found (``solve_ivp`` misses those). A crossing is located by Brent's method
  on the dense output (:func:`impactid.simulate.dp5.brent`); the earliest wins. The step is then
  re-integrated from its start to the crossing and, if the function has not quite crossed (dense
  output against the step's 5th-order solution), a Newton correction on the step length follows.
  Other functions found on the wrong side at that state switch at the same instant.
* A new mode restarts the method (the derivative is re-evaluated; FSAL does not carry over).
* The compression branch of the tappet damper is stiff (``alpha C_d+ / M_t`` = 4e5 1/s): the
  step size is then set by the stability of the explicit method, which the error control finds.

Status codes are the core's (:data:`impactid.simulate.dp5.STATUS_MESSAGES`) plus ``ZENO`` (more
than ``MAX_ZERO_LENGTH`` switches without time advancing).
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import njit

from impactid import compilation
from impactid.rigs import valvespring as _spring
from impactid.simulate import dp5
from impactid.simulate.dp5 import (
    BAD_INPUT,
    EVENTS_FULL,
    MAX_STEPS,
    NONFINITE,
    OK,
    SAMPLES_FULL,
    STEP_UNDERFLOW,
)

compilation.install()  # before the kernels: the kernel cache's locators and the first-use notice

__all__ = ["BAD_INPUT", "EVENTS_FULL", "MAX_STEPS", "NONFINITE", "N_ECOL", "N_PAR", "OK", "SAMPLES_FULL",
           "STATUS_MESSAGES", "STEP_UNDERFLOW", "SWITCH_NAMES", "ZENO", "evaluate", "initial_signs", "integrate",
           "mode_from_signs", "observe", "switch_values"]

_jit = njit(cache=True, inline="always")
#: The core's stage functions: compiled once and inlined by LLVM (``forceinline``), with the flags of
#: the function that calls ``dp5.step`` (numba's ``inline="always"`` re-typed them at every stage:
#: :mod:`impactid.simulate.dp5`, "Compiling a rig's step").
_STAGE_FLAGS = {"cache": True, "forceinline": True}
_surge = _jit(_spring.surge_accelerations)
TWO_PI = 2.0 * math.pi

# ---- parameter vector layout (built by simulate.pack) -------------------------------------
(P_MT, P_MF, P_IF, P_MV, P_MS, P_LTF, P_LVF, P_KTF, P_KFC, P_KVF, P_KSE, P_CTF, P_CFC, P_CVF, P_CSE,
 P_FTF0, P_FFC0, P_FVF0, P_FO, P_KS, P_KS1, P_KS2, P_CS1, P_CS2, P_YVS, P_CLIP, P_MCOS, P_VTEPS) = range(28)
N_PAR = 28
# ---- the run tuple: (coef, n, dth, omega, theta0, c_plus, c_minus, k_t) -----------------------
# ---- mode bits --------------------------------------------------------------------------------
M_TF, M_FC, M_VF, M_SEAT, M_TPOS = 1, 2, 4, 8, 16
# ---- switching functions ----------------------------------------------------------------------
G_TF, G_FC, G_VF, G_SEAT, VT, H_TF, H_FC, H_VF, H_SEAT = range(9)
N_SW = 9
SWITCH_NAMES = ("g_tf", "g_fc", "g_vf", "g_seat", "vt", "h_tf", "h_fc", "h_vf", "h_seat")
# monitor layout: values [0, 9), rates [9, 18), forces F_tf, F_fc, F_vf, R_seat, F_drag [18, 23)
N_MON = 23
# ---- event table -------------------------------------------------------------------------------
E_KIND, E_DIR, E_T, E_THETA = range(4)
E_Y = 4                      # 12 state entries follow
E_F = 16                     # F_tf, F_fc, F_vf, R_seat (in the mode before the switch)
N_ECOL = 20
# ---- status --------------------------------------------------------------------------------------
ZENO = 8
STATUS_MESSAGES = {**dp5.STATUS_MESSAGES,
                   ZENO: "Zeno-like switching: many switches without time advancing"}
#: Consecutive switches at one instant allowed before the run stops with ``ZENO``.
MAX_ZERO_LENGTH = 50
#: Tolerance below which a switching function found on the wrong side after a switch is taken as
#: round-off, per function: [m] for the criteria and the seat, [N] for the raw forces.
_TOL = np.array([1e-14, 1e-14, 1e-14, 1e-14, 0.0, 1e-8, 1e-8, 1e-8, 1e-8])
#: Probes of the dense output that look for the return of a function that starts a step at
#: round-off on the wrong side of its switch (right after switching) and leaves again later.
_N_PROBE = 8

RunEnd = namedtuple("RunEnd", ["status", "n_events", "t", "n_steps", "n_rejected", "h"])


# ============================================================================================
# Right-hand side
# ============================================================================================


@_jit
def _kin(theta, coef, n, dth):
    """``Y_c, Y_c', Y_c'', L_fc, L_fc', L_fc''`` (d/dtheta) from the periodic splines."""
    u = theta + math.pi
    u -= TWO_PI * math.floor(u / TWO_PI)
    i = int(u / dth)
    if i >= n:
        i = n - 1
    s = u - i * dth
    a3, a2, a1, a0 = coef[i, 0], coef[i, 1], coef[i, 2], coef[i, 3]
    b3, b2, b1, b0 = coef[i, 4], coef[i, 5], coef[i, 6], coef[i, 7]
    return (((a3 * s + a2) * s + a1) * s + a0, (3.0 * a3 * s + 2.0 * a2) * s + a1, 6.0 * a3 * s + 2.0 * a2,
            ((b3 * s + b2) * s + b1) * s + b0, (3.0 * b3 * s + 2.0 * b2) * s + b1, 6.0 * b3 * s + 2.0 * b2)


@_jit
def _rhs(mode, theta, Yt, Yf, th, Ys1, Ys2, Yv, vt, vf, w, vs1, vs2, vv, p, run, K, s, mon, want):
    """Derivative at one state, written into ``K[s, :]``; with ``want`` also the switching values,
    their rates and the forces into ``mon`` (same evaluation)."""
    coef, n, dth, omega, theta0, c_plus, c_minus, k_t = run
    Yc, dYc, d2Yc, Lfc, dLfc, d2Lfc = _kin(theta, coef, n, dth)
    sn = math.sin(th)
    cs = math.cos(th)
    L_tf = p[P_LTF]
    L_vf = p[P_LVF]
    d_tf = Yf - L_tf * sn - Yt
    r_tf = vf - L_tf * w * cs - vt
    d_fc = Yc - Yf - Lfc * sn
    r_fc = dYc * omega - vf - Lfc * w * cs - dLfc * omega * sn
    d_vf = Yf - Yv + L_vf * sn
    r_vf = vf - vv + L_vf * w * cs
    h_tf = p[P_FTF0] + p[P_KTF] * d_tf + p[P_CTF] * r_tf
    h_fc = p[P_FFC0] + p[P_KFC] * d_fc + p[P_CFC] * r_fc
    h_vf = p[P_FVF0] + p[P_KVF] * d_vf + p[P_CVF] * r_vf
    h_seat = p[P_FO] - p[P_FVF0] - p[P_KSE] * Yv - p[P_CSE] * vv
    F_tf = h_tf if mode & M_TF else 0.0
    F_fc = h_fc if mode & M_FC else 0.0
    F_vf = h_vf if mode & M_VF else 0.0
    R_seat = h_seat if mode & M_SEAT else 0.0
    F_drag = (c_plus if mode & M_TPOS else c_minus) * vt + k_t * Yt
    a_t = (F_tf - p[P_FTF0] - p[P_KS] * Yt - F_drag) / p[P_MT]
    a_f = (F_fc - F_tf - F_vf) / p[P_MF]
    mom = F_tf * L_tf + F_fc * Lfc - F_vf * L_vf
    if p[P_MCOS] != 0.0:
        mom *= cs
    a_th = mom / p[P_IF]
    a_1, a_2, f_spring = _surge(Yv, vv, Ys1, vs1, Ys2, vs2, p[P_MS], p[P_KS1], p[P_KS2], p[P_CS1], p[P_CS2])
    a_v = (F_vf - p[P_FO] + R_seat + f_spring) / p[P_MV]
    K[s, 0] = vt
    K[s, 1] = vf
    K[s, 2] = w
    K[s, 3] = vs1
    K[s, 4] = vs2
    K[s, 5] = vv
    K[s, 6] = a_t
    K[s, 7] = a_f
    K[s, 8] = a_th
    K[s, 9] = a_1
    K[s, 10] = a_2
    K[s, 11] = a_v
    if want:
        rot = a_th * cs - w * w * sn          # d/dt (w cos theta_f)
        mon[0] = d_tf + p[P_FTF0] / p[P_KTF]
        mon[1] = d_fc + p[P_FFC0] / p[P_KFC]
        mon[2] = d_vf + p[P_FVF0] / p[P_KVF]
        mon[3] = Yv - p[P_YVS]
        mon[4] = vt
        mon[5] = h_tf
        mon[6] = h_fc
        mon[7] = h_vf
        mon[8] = h_seat
        mon[9] = r_tf
        mon[10] = r_fc
        mon[11] = r_vf
        mon[12] = vv
        mon[13] = a_t
        mon[14] = p[P_KTF] * r_tf + p[P_CTF] * (a_f - L_tf * rot - a_t)
        mon[15] = p[P_KFC] * r_fc + p[P_CFC] * (d2Yc * omega * omega - a_f - 2.0 * dLfc * omega * w * cs
                                                 - Lfc * rot - d2Lfc * omega * omega * sn)
        mon[16] = p[P_KVF] * r_vf + p[P_CVF] * (a_f - a_v + L_vf * rot)
        mon[17] = -p[P_KSE] * vv - p[P_CSE] * a_v
        mon[18] = F_tf
        mon[19] = F_fc
        mon[20] = F_vf
        mon[21] = R_seat
        mon[22] = F_drag


@njit(**_STAGE_FLAGS)
def _begin(mode, t, y, p, run):
    return (0.0,)


@njit(**_STAGE_FLAGS)
def _stage(mode, cache, t, y, d, ch, p, run, K, s, mon):
    """The core's stage: the derivative at ``y + d``, ``t + ch``; the last stage also fills ``mon``."""
    omega, theta0 = run[3], run[4]
    _rhs(mode, theta0 + omega * (t + ch), y[0] + d[0], y[1] + d[1], y[2] + d[2], y[3] + d[3], y[4] + d[4],
         y[5] + d[5], y[6] + d[6], y[7] + d[7], y[8] + d[8], y[9] + d[9], y[10] + d[10], y[11] + d[11],
         p, run, K, s, mon, s == 6)


@njit(cache=True)
def _step(mode, t, y, h, p, run, K, work, ynew, mon):
    """One step of the core (compiled once; the integrator calls it for steps and re-integrations)."""
    return dp5.step(_stage, _begin, mode, t, y, h, p, run, K, work, ynew, mon)


@njit(cache=True)
def _initial_step(mode, t, y, p, run, K, work, mon, rtol, atol, h_max):
    return dp5.initial_step(_stage, _begin, mode, t, y, p, run, K, work, mon, rtol, atol, h_max)


@njit(cache=True)
def evaluate(mode, t, y, p, run, K, s, mon):
    """Derivative at ``(t, y)`` in ``mode`` into ``K[s]``, switching values, rates and forces into ``mon``."""
    omega, theta0 = run[3], run[4]
    _rhs(mode, theta0 + omega * t, y[0], y[1], y[2], y[3], y[4], y[5], y[6], y[7], y[8], y[9], y[10], y[11],
         p, run, K, s, mon, True)


@njit(cache=True)
def switch_values(t, y, p, run, out):
    """The nine switching functions at ``(t, y)`` (mode-independent) into ``out``."""
    K = np.empty((1, 12))
    mon = np.empty(N_MON)
    evaluate(0, t, y, p, run, K, 0, mon)
    for k in range(N_SW):
        out[k] = mon[k]


@_jit
def _switch_at(k, theta, z, p, run):
    """Value of switching function ``k`` at state ``z`` (no derivative needed)."""
    if k == G_TF:
        return z[1] - p[P_LTF] * math.sin(z[2]) - z[0] + p[P_FTF0] / p[P_KTF]
    if k == G_VF:
        return z[1] - z[5] + p[P_LVF] * math.sin(z[2]) + p[P_FVF0] / p[P_KVF]
    if k == G_SEAT:
        return z[5] - p[P_YVS]
    if k == VT:
        return z[6]
    if k == H_SEAT:
        return p[P_FO] - p[P_FVF0] - p[P_KSE] * z[5] - p[P_CSE] * z[11]
    sn = math.sin(z[2])
    cs = math.cos(z[2])
    if k == H_TF:
        return (p[P_FTF0] + p[P_KTF] * (z[1] - p[P_LTF] * sn - z[0])
                + p[P_CTF] * (z[7] - p[P_LTF] * z[8] * cs - z[6]))
    if k == H_VF:
        return (p[P_FVF0] + p[P_KVF] * (z[1] - z[5] + p[P_LVF] * sn)
                + p[P_CVF] * (z[7] - z[11] + p[P_LVF] * z[8] * cs))
    coef, n, dth, omega = run[0], run[1], run[2], run[3]
    Yc, dYc, _, Lfc, dLfc, _ = _kin(theta, coef, n, dth)
    if k == G_FC:
        return Yc - z[1] - Lfc * sn + p[P_FFC0] / p[P_KFC]
    return (p[P_FFC0] + p[P_KFC] * (Yc - z[1] - Lfc * sn)
            + p[P_CFC] * (dYc * omega - z[7] - Lfc * z[8] * cs - dLfc * omega * sn))


# ============================================================================================
# Modes and sign bookkeeping
# ============================================================================================


@njit(cache=True)
def mode_from_signs(sg, clip):
    """Mode bit mask from the signs of the switching functions (the paper's rules)."""
    mode = 0
    if sg[G_TF] > 0.0 and (not clip or sg[H_TF] > 0.0):
        mode |= M_TF
    if sg[G_FC] > 0.0 and (not clip or sg[H_FC] > 0.0):
        mode |= M_FC
    if sg[G_VF] > 0.0 and (not clip or sg[H_VF] > 0.0):
        mode |= M_VF
    if sg[G_SEAT] < 0.0 and (not clip or sg[H_SEAT] > 0.0):
        mode |= M_SEAT
    if sg[VT] > 0.0:
        mode |= M_TPOS
    return mode


@_jit
def _watched(k, sg, clip):
    """Whether switching function ``k`` can change the mode with the current signs."""
    if k <= VT:
        return True
    if not clip:
        return False
    if k == H_SEAT:
        return sg[G_SEAT] < 0.0
    return sg[k - H_TF] > 0.0


@njit(cache=True)
def initial_signs(t, y, p, run, sg):
    """Signs from the state: +1 where a switching function is >= 0, else -1."""
    v = np.empty(N_SW)
    switch_values(t, y, p, run, v)
    for k in range(N_SW):
        sg[k] = 1.0 if v[k] >= 0.0 else -1.0


# ============================================================================================
# Event location
# ============================================================================================


@_jit
def _offset(k, p):
    return p[P_VTEPS] if k == VT else 0.0


@njit(cache=True)
def _leave_at(x, args):
    """``sign * f_k + offset`` on the dense output at fraction ``x`` of the step."""
    k, sign, off, t0, h, y0, Q, p, run, z = args
    dp5.dense(x, h, y0, Q, z)
    return sign * _switch_at(k, run[4] + run[3] * (t0 + x * h), z, p, run) + off


@_jit
def _hermite_min(f0, f1, d0, d1):
    """Location in (0, 1) of the minimum of the cubic Hermite interpolant of values ``f0, f1`` and
    slopes ``d0 < 0 < d1`` (per unit of x); -1 if none."""
    # p(x) = f0 + d0 x + c2 x^2 + c3 x^3
    c2 = 3.0 * (f1 - f0) - 2.0 * d0 - d1
    c3 = 2.0 * (f0 - f1) + d0 + d1
    a = 3.0 * c3
    b = 2.0 * c2
    c = d0
    # "<=": with rates of round-off size (subnormal) the right side underflows to 0 while a may be 0
    if abs(a) <= 1e-14 * (abs(b) + abs(c)):
        if b <= 0.0:
            return -1.0
        x = -c / b
    else:
        disc = b * b - 4.0 * a * c
        if disc < 0.0:
            return -1.0
        r = math.sqrt(disc)
        # the root where p' goes from negative to positive: p'' = 2 a x + b > 0
        x1 = (-b + r) / (2.0 * a)
        x2 = (-b - r) / (2.0 * a)
        x = x1 if 2.0 * a * x1 + b > 0.0 else x2
    if 0.0 < x < 1.0:
        return x
    return -1.0


@njit(cache=True)
def _find_event(t, h, y, Q, p, run, sg, clip, mon0, mon1, z):
    """Earliest switching function leaving its sign inside the step; ``(x, k)`` with ``k = -1`` if none."""
    best_x = 2.0
    best_k = -1
    for k in range(N_SW):
        if not _watched(k, sg, clip):
            continue
        sign = sg[k]
        off = _offset(k, p)
        L0 = sign * mon0[k] + off
        L1 = sign * mon1[k] + off
        D0 = sign * mon0[9 + k] * h
        D1 = sign * mon1[9 + k] * h
        if L0 < 0.0:
            L0 = 0.0  # round-off after a switch (a real re-crossing shows at the end or the minimum)
        x = 2.0
        args = (k, sign, off, t, h, y, Q, p, run, z)
        if L1 < -_TOL[k] or (L1 < 0.0 and L0 > 0.0):
            if L0 > 0.0:
                x = dp5.brent(_leave_at, args, 0.0, 1.0, L0, L1, max(4e-16, 1e-16 / max(h, 1e-300)), -1)
            elif D0 <= 0.0:
                x = 0.0  # at round-off on the wrong side and moving further: it has left
            else:
                # it starts at round-off, moves to its own side, and comes back within the step:
                # bracket the crossing after the largest of a few probes of the dense output
                xa = 0.0
                La = 0.0
                for j in range(1, _N_PROBE):
                    xj = j / _N_PROBE
                    Lj = _leave_at(xj, args)
                    if Lj > La:
                        xa = xj
                        La = Lj
                if La > 0.0:
                    x = dp5.brent(_leave_at, args, xa, 1.0, La, L1, max(4e-16, 1e-16 / max(h, 1e-300)), -1)
                else:
                    x = 0.0
        elif D0 < 0.0 and D1 > 0.0:
            xm = _hermite_min(L0, L1, D0, D1)
            if xm > 0.0:
                Lm = _leave_at(xm, args)
                if Lm < 0.0:
                    if L0 == 0.0:
                        x = 0.0
                    else:
                        x = dp5.brent(_leave_at, args, 0.0, xm, L0, Lm, max(4e-16, 1e-16 / max(h, 1e-300)), -1)
        if x < best_x:
            best_x = x
            best_k = k
    return best_x, best_k


@njit(cache=True)
def _record(events, n_ev, k, direction, t, theta, y, mon):
    if n_ev < events.shape[0]:
        events[n_ev, E_KIND] = k
        events[n_ev, E_DIR] = direction
        events[n_ev, E_T] = t
        events[n_ev, E_THETA] = theta
        for i in range(12):
            events[n_ev, E_Y + i] = y[i]
        for i in range(4):
            events[n_ev, E_F + i] = mon[18 + i]
    return n_ev + 1


@njit(cache=True)
def _emit(grid, gi, t_stop, t, h, y, Q, mode, out_y, out_mode, z):
    """Dense output of the step ``[t, t + h]`` at the grid times up to ``t_stop``."""
    while gi < grid.shape[0] and grid[gi] <= t_stop:
        dp5.dense((grid[gi] - t) / h, h, y, Q, z)
        for i in range(12):
            out_y[gi, i] = z[i]
        out_mode[gi] = mode
        gi += 1
    return gi


# ============================================================================================
# The hybrid integrator
# ============================================================================================


@njit(cache=True)
def integrate(p, run, t0, y, sg, t_end, rtol, atol, h_max, h0, max_steps, grid, out_y, out_mode, events):
    """Integrate from ``t0`` to ``t_end``; ``y`` (12) and ``sg`` (9 signs) are updated in place.

    Parameters
    ----------
    p : packed parameters (layout above).
    run : ``(coef, n, dth, omega, theta0, c_plus, c_minus, k_t)``: kinematic spline coefficients
        (n x 8) and their step [rad], cam speed [rad/s], cam angle at ``t = 0`` [rad], tappet
        damping while compressing and refilling [N s/m], tappet stiffness [N/m].
    t0, t_end : start and end time [s].
    y, sg : state and sign bookkeeping at ``t0``, overwritten with those at the end.
    rtol, atol : relative tolerance and absolute tolerances (12) of the error norm.
    h_max, h0 : largest step and the first step [s] (``h0 <= 0``: the core's starting step).
    max_steps : limit on the number of steps (accepted and rejected).
    grid : sorted output times in ``[t0, t_end]``; ``out_y[i]`` the state and ``out_mode[i]``
        the mode at ``grid[i]``.
    events : (capacity, N_ECOL) table of switches, in order (beyond the capacity they are counted).

    Returns
    -------
    :data:`RunEnd`.
    """
    clip = p[P_CLIP] != 0.0
    K = np.empty((7, 12))
    Q = np.empty((12, 4))
    work = np.empty(12)
    ynew = np.empty(12)
    z = np.empty(12)
    mon0 = np.empty(N_MON)
    mon1 = np.empty(N_MON)
    vals = np.empty(N_SW)
    t = t0
    n_ev = 0
    n_steps = 0
    n_rej = 0
    gi = 0
    n_zero = 0
    for i in range(12):
        if not math.isfinite(y[i]):
            return RunEnd(BAD_INPUT, 0, t, 0, 0, 0.0)
    if not (math.isfinite(t0) and math.isfinite(t_end) and t_end >= t0):
        return RunEnd(BAD_INPUT, 0, t, 0, 0, 0.0)
    mode = mode_from_signs(sg, clip)
    evaluate(mode, t, y, p, run, K, 0, mon0)
    h = h0 if h0 > 0.0 else _initial_step(mode, t, y, p, run, K, work, mon1, rtol, atol, h_max)
    rejected = False
    while t < t_end:
        if n_steps >= max_steps:
            return RunEnd(MAX_STEPS, n_ev, t, n_steps, n_rej, h)
        h = min(h, h_max)
        last = False
        if t + h >= t_end:
            h = t_end - t
            last = True
        if h <= 4e-16 * max(1.0, abs(t)):
            if t_end - t <= 4e-16 * max(1.0, abs(t)):
                t = t_end
                break
            return RunEnd(STEP_UNDERFLOW, n_ev, t, n_steps, n_rej, h)
        y1, err = _step(mode, t, y, h, p, run, K, work, ynew, mon1)
        n_steps += 1
        finite = True
        for i in range(12):
            if not math.isfinite(y1[i]):
                finite = False
        enorm = dp5.error_norm(y, y1, err, rtol, atol) if finite else 1e300
        if not (enorm <= 1.0):
            n_rej += 1
            if not finite and h < 1e-14 * max(1.0, abs(t)):
                return RunEnd(NONFINITE, n_ev, t, n_steps, n_rej, h)
            h *= dp5.shrink_factor(enorm, 0.2, 0.2) if finite else 0.2
            rejected = True
            continue
        dp5.dense_coefficients(K, Q)
        x_ev, k_ev = _find_event(t, h, y, Q, p, run, sg, clip, mon0, mon1, z)
        if k_ev < 0:
            gi = _emit(grid, gi, t + h, t, h, y, Q, mode, out_y, out_mode, z)
            t = t_end if last else t + h
            for i in range(12):
                y[i] = y1[i]
                K[0, i] = K[6, i]
            for i in range(N_MON):
                mon0[i] = mon1[i]
            h *= dp5.step_factor(enorm, rejected)
            rejected = False
            n_zero = 0
            continue
        # ---- a switch inside the step: outputs up to it, then re-integrate to it ----
        hr = x_ev * h
        gi = _emit(grid, gi, t + hr, t, h, y, Q, mode, out_y, out_mode, z)
        sign = sg[k_ev]
        off = _offset(k_ev, p)
        if hr > 0.0:
            y1, err = _step(mode, t, y, hr, p, run, K, work, ynew, mon1)
            for _ in range(3):
                leave = sign * mon1[k_ev] + off
                rate = sign * mon1[9 + k_ev]
                if leave <= 0.0 or rate >= 0.0:
                    break
                hr -= leave / rate * (1.0 + 1e-12)
                hr = min(hr, h)
                y1, err = _step(mode, t, y, hr, p, run, K, work, ynew, mon1)
            n_zero = 0
            for i in range(12):
                y[i] = y1[i]
        else:
            n_zero += 1
            if n_zero > MAX_ZERO_LENGTH:
                return RunEnd(ZENO, n_ev, t, n_steps, n_rej, h)
            for i in range(N_MON):
                mon1[i] = mon0[i]
        t = t + hr
        theta = run[4] + run[3] * t
        n_ev = _record(events, n_ev, k_ev, -sign, t, theta, y, mon1)
        # new signs: the fired function flips; others found clearly on the wrong side flip too
        # (simultaneous switches); unwatched ones follow their values
        switch_values(t, y, p, run, vals)
        flipped = np.zeros(N_SW, dtype=np.bool_)
        flipped[k_ev] = True
        for k in range(N_SW):
            if k == k_ev:
                continue
            if not _watched(k, sg, clip):
                sg[k] = 1.0 if vals[k] >= 0.0 else -1.0
                continue
            if sg[k] * vals[k] + _offset(k, p) < -_TOL[k]:
                flipped[k] = True
                n_ev = _record(events, n_ev, k, -sg[k], t, theta, y, mon1)
        for k in range(N_SW):
            if flipped[k]:
                sg[k] = -sg[k]
        mode = mode_from_signs(sg, clip)
        evaluate(mode, t, y, p, run, K, 0, mon0)
        rejected = False
    gi = _emit_end(grid, gi, t, y, mode, out_y, out_mode)
    return RunEnd(OK, n_ev, t, n_steps, n_rej, h)


@njit(cache=True)
def _emit_end(grid, gi, t, y, mode, out_y, out_mode):
    """Grid times at the end of the run (equal to ``t_end`` up to round-off)."""
    while gi < grid.shape[0] and grid[gi] <= t * (1.0 + 1e-15) + 1e-300:
        for i in range(12):
            out_y[gi, i] = y[i]
        out_mode[gi] = mode
        gi += 1
    return gi


@njit(cache=True)
def observe(t, y, mode, p, run, out):
    """Forces and switching values along a sampled run: ``out[i] = (F_tf, F_fc, F_vf, R_seat, F_drag,
    a_t, a_f, a_theta, a_1, a_2, a_v)`` at time ``t[i]``, state ``y[i]`` in mode ``mode[i]``."""
    K = np.empty((1, 12))
    mon = np.empty(N_MON)
    for i in range(t.shape[0]):
        evaluate(mode[i], t[i], y[i], p, run, K, 0, mon)
        for j in range(5):
            out[i, j] = mon[18 + j]
        for j in range(6):
            out[i, 5 + j] = K[0, 6 + j]

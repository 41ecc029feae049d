"""Compiled (numba) event-driven integrator of the single-impact test rig, on :mod:`impactid.simulate.dp5`.

Model (:mod:`impactid.rigs.drop.parameters`): one degree of freedom ``x`` [m], positive into the
contact, ``v = dx/dt``; ``m x'' = m g - F`` with the Hunt–Crossley force
``F = max(k x^p + beta x^n v, 0)`` for ``x > 0`` and ``F = 0`` otherwise.

Modes and events
----------------
``FREE`` (``F = 0``: flight, or inside the contact region with the force clipped) and ``CONTACT``
(``F > 0``). Their switching functions are ``x`` and the *reduced force*
``phi = k x^(p-m) + beta x^(n-m) v`` with ``m = min(p, n)``, which has the sign of ``F`` for
``x > 0`` and, unlike ``F``, does not vanish identically at the surface:

=================  ============================  =========================================
event              switching function            from -> to
=================  ============================  =========================================
onset              ``x`` rises through 0         FREE -> CONTACT (opens an impact row)
force separation   ``phi`` falls through 0       CONTACT -> FREE (``x > 0``: force clipped)
surface exit       ``x`` falls through 0         CONTACT -> FREE
re-contact         ``phi`` rises through 0       FREE (``x > 0``) -> CONTACT (opens a row)
=================  ============================  =========================================

* **Contact** is integrated with the core's Dormand–Prince 5(4) step (pair layout), error norm,
  step-size controller, starting step and continuous extension. Inside CONTACT the stages see the
  force continued smoothly past the switching surfaces (not clipped; ``x^p`` continued as an odd
  function), so a trial step that overshoots an event sees no kink. After every accepted step both
  switching functions are checked at three interior points of the continuous extension and at the
  step's end; the earliest crossing is located with the core's Brent root finder, the step is
  re-integrated from its start to the root, and one Newton correction ``h -= g / g'`` (another
  re-integration) puts the switch where the switching function is at round-off level. The first
  step of a contact, whose force grows like ``t^p``, is shrunk with the exponent ``1/(p + 1)`` of its
  local error (:func:`impactid.simulate.dp5.shrink_factor`).
* **Free flight** under gravity alone is a parabola and is advanced in closed form (exactly):
  the DP5 steps would reproduce it to rounding, but a step's end-point check cannot see the
  impactor dip below the surface and come back within one step; the closed form gives the onset
  time as a root of a quadratic (in its cancellation-free form). Inside the contact region with the
  force clipped, re-contact (``phi`` rising through 0) is bracketed on 32 points of the parabola and
  located with Brent's method.
* Non-terminal events in contact, located on the continuous extension with Brent's method: the
  largest penetration (``v`` falls through 0) and the peak force (``dF/dt`` falls through 0).
* **Rest.** The mechanical energy ``E = m v^2/2 - m g x + k x^(p+1)/(p+1)`` (0 at the surface at
  rest) never increases; once it is negative in contact the impactor can no longer reach the
  surface: it rests on the contact, and the run records no further impacts (the open row ends as
  ``END_REST``). With ``stop_at_rest`` the run stops there once the output grid is written.

Forward sensitivities
---------------------
``d(x, v)/d(ln k, ln beta, n, v0)`` (``v0``: the speed at the start) are integrated with the state
on the same steps: the variational equations ``s' = (s_v, -(F_x s_x + F_v s_v + F_theta)/m)`` in
contact (``(s_v, 0)`` in flight, exactly) with the same tableau at the same stage states, the
error control on the state alone (CVODES's "partial error control"); the runs' steps, events and
results are therefore those of a run without sensitivities. At an event the right-hand side is
continuous (the force is 0 on both sides) except at the onset of viscous damping (``n = 0``: the
force jumps to ``beta v``), where the saltation ``s_v += (F+/m) (-s_x / v)`` is applied. At an
onset the coefficient ``F_x = p k x^(p-1)`` of the variational equations is singular in time
(``~ t^(p-1)``); a non-zero ``s_x`` there would be integrated through it with an error the state's
error control does not see (1e-4 relative at a drop's second impact). Since the system is
autonomous, ``dy/dt`` solves the homogeneous variational equations, so the onset-time part of the
sensitivities, ``(s_x / v) dy/dt``, is carried exactly and only the remainder (whose ``x`` component
starts at 0) is integrated; the two are added back wherever the sensitivities are read. On an
output grid the derivatives of the force follow, ``dF/dtheta = F_x s_x + F_v s_v + F_theta``.

Status codes are the core's (:data:`impactid.simulate.dp5.STATUS_MESSAGES`); the Python layer
(:mod:`impactid.rigs.drop.simulate`) turns them into :class:`~impactid.errors.SimulationError`.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import njit

from impactid import compilation
from impactid.simulate import dp5
from impactid.simulate.dp5 import BAD_INPUT, EVENTS_FULL, MAX_STEPS, NONFINITE, OK, STATUS_MESSAGES, STEP_UNDERFLOW

compilation.install()  # before the kernels: the kernel cache's locators and the first-use notice

__all__ = ["BAD_INPUT", "CONTACT", "END_FORCE", "END_OPEN", "END_REST", "END_SURFACE", "EVENTS_FULL", "FREE",
           "KIND_ONSET", "KIND_RECONTACT", "MAX_STEPS", "NONFINITE", "N_GCOL", "N_ICOL", "N_PAR", "N_SENS", "OK",
           "STATUS_MESSAGES", "STEP_UNDERFLOW", "RunEnd", "acceleration", "contact_force", "force_partials",
           "force_rate", "initial_mode", "integrate", "replay"]

_jit = njit(cache=True, inline="always")
#: The core's stage functions: compiled once and inlined by LLVM (``forceinline``), with the flags of
#: the function that calls ``dp5.step`` (numba's ``inline="always"`` re-typed them at every stage:
#: :mod:`impactid.simulate.dp5`, "Compiling a rig's step").
_STAGE_FLAGS = {"cache": True, "error_model": "numpy", "forceinline": True}
#: Stage numbers as run-time ``int64`` (a literal would compile ``_sensitivity_stage`` once per stage).
_S = dp5.STAGE

# ---- parameter vector layout (built by simulate.pack) --------------------------------------
P_MASS, P_GRAV, P_K, P_P, P_BETA, P_N = range(6)
N_PAR = 6
# ---- modes ---------------------------------------------------------------------------------
FREE, CONTACT = 0, 1
# ---- forward sensitivities: d(x, v)/d(ln k, ln beta, n, v0) ----------------------------------
S_LNK, S_LNB, S_N, S_V0 = range(4)
N_SENS = 4
# ---- impact table columns ------------------------------------------------------------------
(I_T_ONSET, I_V_ONSET, I_X_MAX, I_T_X_MAX, I_F_PEAK, I_T_F_PEAK, I_T_END, I_X_END, I_V_END, I_KIND,
 I_END_KIND) = range(11)
N_ICOL = 11
KIND_ONSET, KIND_RECONTACT = 1.0, 2.0
END_OPEN, END_FORCE, END_SURFACE, END_REST = 0.0, 1.0, 2.0, 3.0
# ---- output grid columns -------------------------------------------------------------------
G_X, G_V, G_MODE, G_FORCE, G_FORCE_RATE = range(5)
N_GCOL = 5
# ---- switching functions -------------------------------------------------------------------
SW_X, SW_PHI, SW_V, SW_FDOT = range(4)
#: What :func:`integrate` returns: the status, the impacts in the table, the final time, state and
#: mode, the time the impactor came to rest (NaN if it did not), and the step counts.
RunEnd = namedtuple("RunEnd", ["status", "n_impacts", "t", "x", "v", "mode", "t_rest", "n_steps", "n_rejected"])

_CHECKS = (0.25, 0.5, 0.75, 1.0)
_SCAN_POINTS = 32
_NO_WORK = np.empty(0)


# ============================================================================================
# The force and its derivatives (scalars; ``pt`` is the parameter tuple)
# ============================================================================================


@_jit
def _power(d, e):
    """``d**e`` for ``d >= 0`` with the common exponents as cheap special cases (``0**0 = 1``)."""
    if e == 1.5:
        return d * math.sqrt(d)
    if e == 1.0:
        return d
    if e == 0.0:
        return 1.0
    if e == 2.0:
        return d * d
    if e == 0.5:
        return math.sqrt(d)
    return d**e


@_jit
def _dpower(d, e):
    """``d/dd d**e = e d**(e-1)`` for ``d >= 0``; 0 at ``d = 0`` for ``e > 1`` and (where it is
    infinite, ``0 < e < 1``) by convention: only the first stage of a contact sits exactly there."""
    if e == 0.0:
        return 0.0
    if e == 1.0:
        return 1.0
    if d <= 0.0:
        return 0.0
    if e == 1.5:
        return 1.5 * math.sqrt(d)
    if e == 2.0:
        return 2.0 * d
    return e * d ** (e - 1.0)


@_jit
def _force_continued(x, v, pt):
    """The contact force as the stages of CONTACT see it: ``k sgn(x)|x|^p + beta |x|^n v`` (not clipped)."""
    ax = abs(x)
    elastic = pt[P_K] * _power(ax, pt[P_P])
    if x < 0.0:
        elastic = -elastic
    return elastic + pt[P_BETA] * _power(ax, pt[P_N]) * v


@_jit
def _force(x, v, pt):
    """The physical contact force [N]: ``max(k x^p + beta x^n v, 0)`` for ``x > 0``, else 0."""
    if x <= 0.0:
        return 0.0
    f = pt[P_K] * _power(x, pt[P_P]) + pt[P_BETA] * _power(x, pt[P_N]) * v
    return f if f > 0.0 else 0.0


@_jit
def _reduced_force(x, v, pt):
    """``phi = k x^(p-m) + beta x^(n-m) v``, ``m = min(p, n)``: the sign of the force for ``x > 0``."""
    ax = abs(x)
    m = min(pt[P_P], pt[P_N])
    return pt[P_K] * _power(ax, pt[P_P] - m) + pt[P_BETA] * _power(ax, pt[P_N] - m) * v


@_jit
def _reduced_force_rate(x, v, a, pt):
    """``d phi / dt`` for ``x > 0`` with acceleration ``a``."""
    ax = abs(x)
    m = min(pt[P_P], pt[P_N])
    return (pt[P_K] * _dpower(ax, pt[P_P] - m) * v
            + pt[P_BETA] * (_dpower(ax, pt[P_N] - m) * v * v + _power(ax, pt[P_N] - m) * a))


@_jit
def _force_rate_continued(x, v, pt):
    """``dF/dt`` of the continued force in contact [N/s] (``a = g - F/m``)."""
    ax = abs(x)
    f = _force_continued(x, v, pt)
    a = pt[P_GRAV] - f / pt[P_MASS]
    sg = 1.0 if x >= 0.0 else -1.0
    return (pt[P_K] * _dpower(ax, pt[P_P]) * v
            + pt[P_BETA] * (sg * _dpower(ax, pt[P_N]) * v * v + _power(ax, pt[P_N]) * a))


@_jit
def _partials(x, v, pt):
    """Partial derivatives of the continued force: ``(F_x, F_v, F_lnk, F_lnbeta, F_n)``."""
    ax = abs(x)
    sg = 1.0 if x >= 0.0 else -1.0
    k = pt[P_K]
    beta = pt[P_BETA]
    xn = _power(ax, pt[P_N])
    f_x = k * _dpower(ax, pt[P_P]) + beta * sg * _dpower(ax, pt[P_N]) * v
    f_v = beta * xn
    f_lnk = k * sg * _power(ax, pt[P_P])
    f_lnb = beta * xn * v
    f_n = f_lnb * math.log(ax) if ax > 0.0 else 0.0
    return f_x, f_v, f_lnk, f_lnb, f_n


@_jit
def _tuple(par):
    """The parameters as a tuple of floats (kept in registers by the stages; dp5, "Compiling a rig's step")."""
    return (par[0], par[1], par[2], par[3], par[4], par[5])


assert N_PAR == 6, "_tuple spells out the layout's length"


# ---- public scalar and array forms (for tests and the Python layer) -------------------------


@njit(cache=True)
def contact_force(x, v, par):
    """The physical contact force [N] at penetration ``x`` [m] and rate ``v`` [m/s] (arrays)."""
    pt = _tuple(par)
    out = np.empty(x.shape[0])
    for i in range(x.shape[0]):
        out[i] = _force(x[i], v[i], pt)
    return out


@njit(cache=True)
def force_rate(x, v, par):
    """``dF/dt`` [N/s] of the physical force (0 where it is 0) at the states ``(x, v)`` (arrays)."""
    pt = _tuple(par)
    out = np.empty(x.shape[0])
    for i in range(x.shape[0]):
        out[i] = _force_rate_continued(x[i], v[i], pt) if _force(x[i], v[i], pt) > 0.0 else 0.0
    return out


@njit(cache=True)
def acceleration(x, v, par):
    """``x'' = g - F/m`` [m/s^2] at the states ``(x, v)`` (arrays)."""
    pt = _tuple(par)
    out = np.empty(x.shape[0])
    for i in range(x.shape[0]):
        out[i] = pt[P_GRAV] - _force(x[i], v[i], pt) / pt[P_MASS]
    return out


@njit(cache=True)
def force_partials(x, v, par):
    """``(F_x, F_v, F_lnk, F_lnbeta, F_n)`` of the continued force at one state (for tests)."""
    return _partials(x, v, _tuple(par))


# ============================================================================================
# Dormand–Prince pieces (pair layout; CONTACT only)
# ============================================================================================


@njit(**_STAGE_FLAGS)
def _begin(mode, t, y, pt, law):
    return (0.0,)


@njit(**_STAGE_FLAGS)
def _stage(mode, cache, t, y, d, ch, pt, law, K, s, monitor):
    """Rate and acceleration at ``y + d`` in contact (the continued force)."""
    x = y[0] + d[0]
    v = y[1] + d[1]
    K[s, 0] = v
    K[s, 1] = pt[P_GRAV] - _force_continued(x, v, pt) * (1.0 / pt[P_MASS])


@njit(cache=True, error_model="numpy")
def _dp5_step(t, x, v, h, f0, par, K):
    """One contact step of the core from ``(t, x, v)`` with ``f0 = x''(t)``; fills ``K`` (7x2).
    Returns ``(x1, v1, err_x, err_v)``."""
    K[0, 0] = v
    K[0, 1] = f0
    pt = _tuple(par)
    y1, err = dp5.step(_stage, _begin, CONTACT, t, (x, v), h, pt, pt, K, _NO_WORK, _NO_WORK, _NO_WORK)
    return y1[0], y1[1], err[0], err[1]


@njit(cache=True, error_model="numpy")
def _initial_step(t, x, v, f0, par, rtol, atol_x, atol_v, h_max, K):
    K[0, 0] = v
    K[0, 1] = f0
    pt = _tuple(par)
    return dp5.initial_step(_stage, _begin, CONTACT, t, (x, v), pt, pt, K, _NO_WORK, _NO_WORK, rtol,
                            (atol_x, atol_v), h_max)


@njit(cache=True, inline="always")
def _dense(frac, h, x0, v0, Q):
    return dp5.dense(frac, h, (x0, v0), Q, _NO_WORK)


@njit(cache=True)
def _switch_value(kind, x, v, pt):
    if kind == SW_X:
        return x
    if kind == SW_PHI:
        return _reduced_force(x, v, pt)
    if kind == SW_V:
        return v
    return _force_rate_continued(x, v, pt)


@njit(cache=True)
def _switch_at(frac, args):
    kind, h, x0, v0, Q, pt = args
    x, v = _dense(frac, h, x0, v0, Q)
    return _switch_value(kind, x, v, pt)


@njit(cache=True)
def _root_dense(kind, h, x0, v0, Q, pt, xa, xb, fa, fb):
    """Root of a switching function on the continuous extension, as a fraction of the step."""
    args = (kind, h, x0, v0, Q, pt)
    frac = dp5.brent(_switch_at, args, xa, xb, fa, fb, max(4e-16, 1e-17 / max(h, 1e-300)), 0)
    return min(max(frac, 0.0), 1.0)


# ============================================================================================
# Forward sensitivities in contact
# ============================================================================================


@njit(**_STAGE_FLAGS)
def _sensitivity_stage(s, x, v, d, dS, sens0, KS, pt):
    """Row ``s`` of the sensitivities' stages at the stage state ``(x, v) + d``, for the sensitivities
    ``sens0 + dS`` (``dS`` flat, 2 per parameter)."""
    f_x, f_v, f_lnk, f_lnb, f_n = _partials(x + d[0], v + d[1], pt)
    inv_m = 1.0 / pt[P_MASS]
    for q in range(sens0.shape[0]):
        s_x = sens0[q, 0] + dS[2 * q]
        s_v = sens0[q, 1] + dS[2 * q + 1]
        direct = f_lnk if q == S_LNK else (f_lnb if q == S_LNB else (f_n if q == S_N else 0.0))
        KS[s, 2 * q] = s_v
        KS[s, 2 * q + 1] = -(f_x * s_x + f_v * s_v + direct) * inv_m


@njit(cache=True, error_model="numpy")
def _sensitivity_step(x, v, h, K, sens0, sens1, KS, work, par):
    """Advance the sensitivities over the contact step just taken (stages ``K`` of the step from
    ``(x, v)`` of length ``h``): ``sens0`` (N_SENS x 2) at its start, ``sens1`` at its end, ``KS``
    (7 x 2 N_SENS) their stages (for dense output); ``work`` (2 N_SENS) scratch."""
    pt = _tuple(par)
    y = (x, v)
    for i in range(work.shape[0]):
        work[i] = 0.0
    _sensitivity_stage(_S[0], x, v, (0.0, 0.0), work, sens0, KS, pt)
    _sensitivity_stage(_S[1], x, v, dp5.tableau_combine(y, K, 1, h, _NO_WORK),
                       dp5.tableau_combine(work, KS, 1, h, work), sens0, KS, pt)
    _sensitivity_stage(_S[2], x, v, dp5.tableau_combine(y, K, 2, h, _NO_WORK),
                       dp5.tableau_combine(work, KS, 2, h, work), sens0, KS, pt)
    _sensitivity_stage(_S[3], x, v, dp5.tableau_combine(y, K, 3, h, _NO_WORK),
                       dp5.tableau_combine(work, KS, 3, h, work), sens0, KS, pt)
    _sensitivity_stage(_S[4], x, v, dp5.tableau_combine(y, K, 4, h, _NO_WORK),
                       dp5.tableau_combine(work, KS, 4, h, work), sens0, KS, pt)
    _sensitivity_stage(_S[5], x, v, dp5.tableau_combine(y, K, 5, h, _NO_WORK),
                       dp5.tableau_combine(work, KS, 5, h, work), sens0, KS, pt)
    dS = dp5.tableau_combine(work, KS, 6, h, work)
    for q in range(sens0.shape[0]):
        sens1[q, 0] = sens0[q, 0] + dS[2 * q]
        sens1[q, 1] = sens0[q, 1] + dS[2 * q + 1]
    _sensitivity_stage(_S[6], x, v, dp5.tableau_combine(y, K, 6, h, _NO_WORK), dS, sens0, KS, pt)


@njit(cache=True, inline="always")
def _dense_sensitivity(frac, h, sens0, QS, q, component):
    c = 2 * q + component
    return sens0[q, component] + h * frac * (QS[c, 0] + frac * (QS[c, 1] + frac * (QS[c, 2] + frac * QS[c, 3])))


# ============================================================================================
# Free flight in closed form
# ============================================================================================


@njit(cache=True)
def _phi_on_parabola(tau, args):
    x0, v0, g, pt = args
    return _reduced_force(x0 + v0 * tau + 0.5 * g * tau * tau, v0 + g * tau, pt)


@njit(cache=True)
def _flight_event(x, v, pt, horizon):
    """The next event of free flight from ``(x, v)`` within ``horizon`` [s].

    Returns ``(tau, kind)``: kind 0 none (``tau = horizon``), 1 onset (``x`` reaches 0 moving into
    the contact), 2 re-contact (``phi`` rises through 0 while ``x > 0``), 3 surface exit (``x``
    reaches 0 moving out, the force having stayed clipped).
    """
    g = pt[P_GRAV]
    if x < 0.0 or (x == 0.0 and v <= 0.0):
        tau = math.inf
        if g > 0.0:
            root = math.sqrt(v * v - 2.0 * g * x)
            tau = -2.0 * x / (root + v) if v > 0.0 else (root - v) / g
        elif v > 0.0:
            tau = -x / v
        if tau <= horizon:
            return tau, 1
        return horizon, 0
    if x == 0.0:
        return 0.0, 1
    phi0 = _reduced_force(x, v, pt)
    if phi0 > 0.0 and _reduced_force_rate(x, v, g, pt) >= 0.0:
        return 0.0, 2  # pressing and not (as just after a separation, at round-off level) falling
    # inside the contact region, force clipped (v < 0 here, as phi <= 0 needs it)
    tau_exit = math.inf
    if v < 0.0:
        disc = v * v - 2.0 * g * x
        if disc >= 0.0:
            tau_exit = 2.0 * x / (-v + math.sqrt(disc))
    tau_stop = tau_exit
    if g > 0.0 and v < 0.0:
        tau_stop = min(tau_stop, -v / g)  # where v = 0 (and phi > 0), if the surface is not reached first
    tau_stop = min(tau_stop, horizon)
    args = (x, v, g, pt)
    prev_tau = 0.0
    prev = min(phi0, 0.0)
    for i in range(1, _SCAN_POINTS + 1):
        tau = tau_stop * i / _SCAN_POINTS
        val = _phi_on_parabola(tau, args)
        if prev <= 0.0 < val:
            root = dp5.brent(_phi_on_parabola, args, prev_tau, tau, prev, val,
                             max(4e-16 * tau, 1e-300), 1)
            return root, 2
        prev_tau = tau
        prev = val
    if tau_exit <= horizon:
        return tau_exit, 3
    return horizon, 0


# ============================================================================================
# The hybrid integrator
# ============================================================================================


@njit(cache=True)
def initial_mode(x, v, par):
    """The mode of a state: CONTACT if ``x > 0`` and the force is positive (``phi > 0``), or ``x = 0``
    and moving into the contact (``v > 0``); else FREE."""
    pt = _tuple(par)
    if x > 0.0:
        return CONTACT if _reduced_force(x, v, pt) > 0.0 else FREE
    if x == 0.0 and v > 0.0:
        return CONTACT
    return FREE


@njit(cache=True)
def _open_row(impacts, row, kind, t, x, v, pt):
    for c in range(N_ICOL):
        impacts[row, c] = np.nan
    impacts[row, I_T_ONSET] = t
    impacts[row, I_V_ONSET] = v
    impacts[row, I_X_MAX] = x
    impacts[row, I_T_X_MAX] = t
    impacts[row, I_F_PEAK] = _force(x, v, pt)
    impacts[row, I_T_F_PEAK] = t
    impacts[row, I_KIND] = kind
    impacts[row, I_END_KIND] = END_OPEN


@njit(cache=True)
def _write_free(grid, gi, t_stop, inclusive, t, x, v, g, g_out, sens, g_sens):
    """Write the grid points in ``[t, t_stop)`` (``]`` with ``inclusive``) of the parabola from ``(t, x, v)``."""
    n_sens = sens.shape[0]
    while gi < grid.shape[0] and (grid[gi] < t_stop or (inclusive and grid[gi] <= t_stop)):
        tau = grid[gi] - t
        g_out[gi, G_X] = x + v * tau + 0.5 * g * tau * tau
        g_out[gi, G_V] = v + g * tau
        g_out[gi, G_MODE] = FREE
        g_out[gi, G_FORCE] = 0.0
        g_out[gi, G_FORCE_RATE] = 0.0
        for q in range(n_sens):
            g_sens[gi, q, 0] = sens[q, 0] + sens[q, 1] * tau
            g_sens[gi, q, 1] = sens[q, 1]
            g_sens[gi, q, 2] = 0.0
        gi += 1
    return gi


@njit(cache=True)
def _write_contact_point(gi, x, v, pt, g_out, n_sens, sx, sv, g_sens, q):
    """Grid row ``gi`` from a contact state (the physical, clipped force); ``q == -1``: the state part."""
    if q < 0:
        g_out[gi, G_X] = x
        g_out[gi, G_V] = v
        g_out[gi, G_MODE] = CONTACT
        f = _force(x, v, pt)
        g_out[gi, G_FORCE] = f
        g_out[gi, G_FORCE_RATE] = _force_rate_continued(x, v, pt) if f > 0.0 else 0.0
        return
    g_sens[gi, q, 0] = sx
    g_sens[gi, q, 1] = sv
    if g_out[gi, G_FORCE] > 0.0:
        f_x, f_v, f_lnk, f_lnb, f_n = _partials(x, v, pt)
        direct = f_lnk if q == S_LNK else (f_lnb if q == S_LNB else (f_n if q == S_N else 0.0))
        g_sens[gi, q, 2] = f_x * sx + f_v * sv + direct
    else:
        g_sens[gi, q, 2] = 0.0


@njit(cache=True)
def _energy(x, v, pt):
    """Mechanical energy [J], 0 at rest at the surface: ``m v^2/2 - m g x + k x^(p+1)/(p+1)`` (``x > 0``)."""
    m = pt[P_MASS]
    e = 0.5 * m * v * v - m * pt[P_GRAV] * x
    if x > 0.0:
        e += pt[P_K] * _power(x, pt[P_P] + 1.0) / (pt[P_P] + 1.0)
    return e


@njit(cache=True)
def integrate(t0, x0, v0, t_end, par, rtol, atol_x, atol_v, h_max, max_steps, stop_at_rest,
              grid, g_out, impacts, sens, g_sens):
    """Integrate the drop from ``(t0, x0, v0)`` to ``t_end`` (or to rest).

    Parameters
    ----------
    t0, x0, v0 : initial time [s], position [m] (positive into the contact; ``-h`` for a drop from
        height ``h``) and velocity [m/s] (positive towards the contact).
    t_end : final time [s].
    par : packed parameters ``(m, g, k, p, beta, n)`` (layout ``P_*``).
    rtol, atol_x, atol_v : error tolerances (relative; absolute for x [m] and v [m/s]).
    h_max : largest contact step [s]; max_steps : budget of contact steps (accepted and rejected).
    stop_at_rest : stop once the impactor rests on the contact and the grid is written.
    grid : sorted output times in ``[t0, t_end]``; g_out : (len(grid), N_GCOL) receives x, v, mode,
        force and force rate.
    impacts : (capacity, N_ICOL) table of contact phases, filled in order (``EVENTS_FULL`` when full).
    sens : (N_SENS, 2) sensitivities ``d(x, v)/d(ln k, ln beta, n, v0)`` at ``t0`` (the caller sets
        them: zeros for a measured state, ``(0, 1)`` in the ``v0`` row), advanced in place to the
        end; shape (0, 2) for none. g_sens : (len(grid), N_SENS, 3) receives ``d(x, v, F)`` on the
        grid (shape (0, N_SENS, 3) without sensitivities).

    Returns
    -------
    :data:`RunEnd`.
    """
    pt = _tuple(par)
    g = pt[P_GRAV]
    inv_m = 1.0 / pt[P_MASS]
    n_grid = grid.shape[0]
    n_sens = sens.shape[0]
    cap = impacts.shape[0]
    K = np.empty((7, 2))
    Q = np.empty((2, 4))
    KS = np.empty((7, 2 * n_sens))
    QS = np.empty((2 * n_sens, 4))
    sens_new = np.empty((n_sens, 2))
    sens_work = np.empty(2 * n_sens)
    shift = np.zeros(n_sens)
    t = t0
    x = x0
    v = v0
    n_imp = 0
    n_steps = 0
    n_rej = 0
    t_rest = np.nan
    resting = False
    status = OK
    gi = 0
    if not (math.isfinite(t0) and math.isfinite(x0) and math.isfinite(v0) and math.isfinite(t_end)):
        return RunEnd(BAD_INPUT, 0, t, x, v, FREE, t_rest, 0, 0)
    for i in range(N_PAR):
        if not math.isfinite(par[i]):
            return RunEnd(BAD_INPUT, 0, t, x, v, FREE, t_rest, 0, 0)
    mode = initial_mode(x, v, par)
    open_row = -1
    if mode == CONTACT:
        if cap == 0:
            return RunEnd(EVENTS_FULL, 0, t, x, v, mode, t_rest, 0, 0)
        _open_row(impacts, 0, KIND_ONSET if x == 0.0 else KIND_RECONTACT, t, x, v, pt)
        open_row = 0
        n_imp = 1
    while t < t_end:
        if mode == FREE:
            # ---------------- free flight, in closed form ----------------
            tau, kind = _flight_event(x, v, pt, t_end - t)
            t_next = t + tau if kind != 0 else t_end
            gi = _write_free(grid, gi, t_next, kind == 0, t, x, v, g, g_out, sens, g_sens)
            for q in range(n_sens):
                sens[q, 0] += sens[q, 1] * tau
            x_new = x + v * tau + 0.5 * g * tau * tau
            v = v + g * tau
            x = x_new
            t = t_next
            if kind == 0:
                break
            if kind == 3:  # left the contact region through the surface, no force: stay free
                x = 0.0
                continue
            if kind == 1:
                x = 0.0
                # saltation at the onset (only the viscous law's force jumps there)
                f_plus = _force_continued(0.0, v, pt)
                if f_plus != 0.0 and v > 0.0:
                    for q in range(n_sens):
                        sens[q, 1] += f_plus * inv_m * (-sens[q, 0] / v)
            mode = CONTACT
            if not resting:
                if n_imp >= cap:
                    status = EVENTS_FULL
                    break
                _open_row(impacts, n_imp, KIND_ONSET if kind == 1 else KIND_RECONTACT, t, x, v, pt)
                open_row = n_imp
                n_imp += 1
            continue
        # ---------------- contact, DP5 ----------------
        f0 = g - _force_continued(x, v, pt) * inv_m
        # at an onset (x = 0) the sensitivities' component along the flow, (s_x / v) dy/dt (a shift of the
        # onset time), is carried exactly and only the rest is integrated (module docstring)
        for q in range(n_sens):
            shift[q] = sens[q, 0] / v if (x == 0.0 and v != 0.0) else 0.0
            sens[q, 0] -= shift[q] * v
            sens[q, 1] -= shift[q] * f0
        h = _initial_step(t, x, v, f0, par, rtol, atol_x, atol_v, h_max, K)
        onset = True
        rejected = False
        r_prev = _force_rate_continued(x, v, pt)
        switched = False
        event_kind = -1
        while t < t_end:
            if n_steps + n_rej >= max_steps:
                status = MAX_STEPS
                break
            h = min(h, h_max)
            hit = False
            if t + h >= t_end or t_end - (t + h) < 1e-12 * (t_end - t0):
                h = t_end - t
                hit = True
            if h <= 16.0 * 2.2e-16 * max(abs(t), 1e-300):
                status = STEP_UNDERFLOW
                break
            x1, v1, ex, ev = _dp5_step(t, x, v, h, f0, par, K)
            if not (math.isfinite(x1) and math.isfinite(v1)):
                h *= 0.1
                n_rej += 1
                rejected = True
                continue
            err = dp5.error_norm((x, v), (x1, v1), (ex, ev), rtol, (atol_x, atol_v))
            if err > 1.0:
                if onset:
                    h *= dp5.shrink_factor(err, 1.0 / (pt[P_P] + 1.0), 0.01)
                else:
                    h *= dp5.shrink_factor(err, 1.0 / dp5.ORDER, 0.2)
                n_rej += 1
                rejected = True
                continue
            # ---- accepted: the earliest crossing of x or phi through 0, downwards ----
            dp5.dense_coefficients(K, Q)
            prev_x = x
            prev_phi = _reduced_force(x, v, pt)
            prev_frac = 0.0
            start_x_zero = x <= 0.0
            start_phi_zero = prev_phi <= 0.0
            event_kind = -1
            event_frac = 2.0
            bracket_fail = False
            for c in range(4):
                frac = _CHECKS[c]
                if frac < 1.0:
                    xc, vc = _dense(frac, h, x, v, Q)
                else:
                    xc, vc = x1, v1
                cur_x = xc
                cur_phi = _reduced_force(xc, vc, pt)
                if c == 0:
                    # a function that starts at 0 (x at an onset, phi at a re-contact) must be positive
                    # at the first check; its crossings are looked for from there
                    if (start_x_zero and cur_x <= 0.0) or (start_phi_zero and cur_phi <= 0.0):
                        bracket_fail = True  # left at once: the step is too long to see the contact
                        break
                    if start_x_zero:
                        prev_x = cur_x
                    if start_phi_zero:
                        prev_phi = cur_phi
                found = False
                if prev_x > 0.0 and cur_x <= 0.0:
                    r = _root_dense(SW_X, h, x, v, Q, pt, prev_frac, frac, prev_x, cur_x)
                    if r < event_frac:
                        event_frac = r
                        event_kind = SW_X
                    found = True
                if prev_phi > 0.0 and cur_phi <= 0.0:
                    r = _root_dense(SW_PHI, h, x, v, Q, pt, prev_frac, frac, prev_phi, cur_phi)
                    if r < event_frac:
                        event_frac = r
                        event_kind = SW_PHI
                    found = True
                if found:
                    break
                prev_x = cur_x
                prev_phi = cur_phi
                prev_frac = frac
            if bracket_fail:
                h *= 0.25
                n_rej += 1
                rejected = True
                continue
            onset = False
            factor = dp5.step_factor(err, rejected)
            rejected = False
            if event_kind >= 0:
                h_ev = event_frac * h
                if h_ev <= 0.0:
                    h_ev = 1e-3 * h
                x1, v1, ex, ev = _dp5_step(t, x, v, h_ev, f0, par, K)
                # one Newton correction on the switching function
                a1 = K[6, 1]
                if event_kind == SW_X:
                    g_val, g_rate = x1, v1
                else:
                    g_val, g_rate = _reduced_force(x1, v1, pt), _reduced_force_rate(x1, v1, a1, pt)
                if g_val != 0.0 and g_rate != 0.0:
                    h_new = h_ev - g_val / g_rate
                    if 0.0 < h_new <= h:
                        x1, v1, ex, ev = _dp5_step(t, x, v, h_new, f0, par, K)
                        h_ev = h_new
                h = h_ev
                hit = False
                dp5.dense_coefficients(K, Q)
                switched = True
            t1 = t_end if hit else t + h
            n_steps += 1
            if n_sens > 0:
                _sensitivity_step(x, v, h, K, sens, sens_new, KS, sens_work, par)
                dp5.dense_coefficients(KS, QS)
            # ---- non-terminal events: largest penetration, peak force ----
            r1 = _force_rate_continued(x1, v1, pt)
            if open_row >= 0 and not resting:
                if x1 > impacts[open_row, I_X_MAX]:
                    impacts[open_row, I_X_MAX] = x1
                    impacts[open_row, I_T_X_MAX] = t1
                if v > 0.0 and v1 <= 0.0:
                    r = _root_dense(SW_V, h, x, v, Q, pt, 0.0, 1.0, v, v1)
                    xr, vr = _dense(r, h, x, v, Q)
                    if xr > impacts[open_row, I_X_MAX]:
                        impacts[open_row, I_X_MAX] = xr
                        impacts[open_row, I_T_X_MAX] = t + r * h
                f1 = _force(x1, v1, pt)
                if f1 > impacts[open_row, I_F_PEAK]:
                    impacts[open_row, I_F_PEAK] = f1
                    impacts[open_row, I_T_F_PEAK] = t1
                if r_prev > 0.0 and r1 <= 0.0:
                    r = _root_dense(SW_FDOT, h, x, v, Q, pt, 0.0, 1.0, r_prev, r1)
                    xr, vr = _dense(r, h, x, v, Q)
                    fr = _force(xr, vr, pt)
                    if fr > impacts[open_row, I_F_PEAK]:
                        impacts[open_row, I_F_PEAK] = fr
                        impacts[open_row, I_T_F_PEAK] = t + r * h
            # ---- the grid points of this step ----
            while gi < n_grid and grid[gi] <= t1:
                frac = (grid[gi] - t) / h
                xg, vg = _dense(frac, h, x, v, Q)
                _write_contact_point(gi, xg, vg, pt, g_out, n_sens, 0.0, 0.0, g_sens, -1)
                ag = g - _force_continued(xg, vg, pt) * inv_m
                for q in range(n_sens):
                    _write_contact_point(gi, xg, vg, pt, g_out, n_sens,
                                         _dense_sensitivity(frac, h, sens, QS, q, 0) + shift[q] * vg,
                                         _dense_sensitivity(frac, h, sens, QS, q, 1) + shift[q] * ag, g_sens, q)
                gi += 1
            for q in range(n_sens):
                sens[q, 0] = sens_new[q, 0]
                sens[q, 1] = sens_new[q, 1]
            t = t1
            x = x1
            v = v1
            f0 = K[6, 1]
            r_prev = r1
            if not resting and _energy(x, v, pt) < 0.0:
                resting = True
                t_rest = t
                if open_row >= 0:
                    impacts[open_row, I_END_KIND] = END_REST
                    open_row = -1
            if resting and stop_at_rest and gi >= n_grid:
                break
            if switched:
                break
            h *= factor
        a_end = g - _force_continued(x, v, pt) * inv_m
        for q in range(n_sens):  # back to the full sensitivities
            sens[q, 0] += shift[q] * v
            sens[q, 1] += shift[q] * a_end
            shift[q] = 0.0
        if status != OK or not switched:
            break
        # ---- the contact phase ended at (t, x, v) ----
        if event_kind == SW_X:
            x = 0.0
        if open_row >= 0:
            impacts[open_row, I_T_END] = t
            impacts[open_row, I_X_END] = x
            impacts[open_row, I_V_END] = v
            impacts[open_row, I_END_KIND] = END_SURFACE if event_kind == SW_X else END_FORCE
            open_row = -1
        mode = FREE
    return RunEnd(status, n_imp, t, x, v, mode, t_rest, n_steps, n_rej)


# ============================================================================================
# Replays of measured impacts (the fit's model)
# ============================================================================================


@njit(cache=True)
def replay(speeds, offsets, taus, par, rtol, atol_x, atol_v, h_max, max_steps, out, out_sens, status):
    """Replay impacts from their onset states ``(x, v) = (0, speeds[i])`` at time 0.

    Impact ``i`` is sampled at the times ``taus[offsets[i]:offsets[i+1]]`` (sorted, >= 0, from its
    onset): ``out`` (len(taus), N_GCOL) receives the state, force and force rate there, ``out_sens``
    (len(taus), N_SENS, 3) ``d(x, v, F)/d(ln k, ln beta, n, v0)``; ``status`` (n_impacts,) the run's
    status. Each replay ends at its last sample time.
    """
    impacts = np.empty((16, N_ICOL))
    sens = np.zeros((N_SENS, 2))
    for i in range(speeds.shape[0]):
        lo = offsets[i]
        hi = offsets[i + 1]
        for q in range(N_SENS):
            sens[q, 0] = 0.0
            sens[q, 1] = 0.0
        sens[S_V0, 1] = 1.0
        if hi <= lo:
            status[i] = OK
            continue
        res = integrate(0.0, 0.0, speeds[i], taus[hi - 1], par, rtol, atol_x, atol_v, h_max, max_steps, False,
                        taus[lo:hi], out[lo:hi], impacts, sens, out_sens[lo:hi])
        status[i] = res.status

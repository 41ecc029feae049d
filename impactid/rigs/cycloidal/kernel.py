"""Compiled (numba) integrators of the cycloidal-cam valve train, built on :mod:`impactid.simulate.dp5`.

Both levels use the core's Dormand–Prince 5(4) step, error norm, step-size controller, starting
step, continuous extension and Brent root finder in its **vector** layout (the state is a 1-D
array; the stage function writes ``K[s, :]``). Steps are cut so that they end exactly on the
kinematic break points of the cycloid (start of the rise, nose, end of the return, where ``s'''``
jumps), so that every step sees a smooth right-hand side.

Level A (the paper's adherent model)
    State ``z = [y5, y5', y6, y6']`` (the spring masses); the valve lift is prescribed,
    ``y3 = s(omega t)``, ``y3' = omega s'``; (R-41), (R-42) through
    :func:`impactid.rigs.valvespring.surge_accelerations` (one damper ``c`` on all three elements).

Level B (extension: the valve released)
    State ``x = [y3, y3', y5, y5', y6, y6']``. Mode = ``contact + 2 * seat`` with ``contact`` in
    {0, 1} and ``seat`` in {OFF, ON, SLACK}:

    * cam contact: load ``W = delta^-1(g)`` for the penetration ``g = s - g_lash - y3 > 0``
      (Hertz line contact (R-9) inverted, radius ``R0 + s + s''``), 0 when separated;
    * valve seat: reaction ``-K_se y3 - C_se y3'`` while ``y3 < 0`` and that is positive (ON),
      0 when the valve is off the seat (OFF, ``y3 >= 0``) or on it but the damper would pull (SLACK);
    * ``m3 y3'' = W + F_seat - f_p - k_s1 (y3 - y5) - c (y3' - y5')`` (R-40 with ``y3`` free).

    Inside a mode the force laws are continued smoothly past their switching surfaces (the cam load
    as an odd function of ``g``, the seat reaction linearly), so the trial stages of a step that
    ends on an event see no jump. Six switching functions (``phi`` below, each crossing upwards at
    its event) are checked after every accepted step at the step's end and at three interior points
    of its continuous extension; the earliest crossing is located with Brent's method on the
    continuous extension, the step is re-integrated from its start to the root, the mode switches
    and the event is logged. The new mode is the flip the event implies (its direction of crossing
    fixes it); the switching function that just fired is deflated at the restart,
    ``phi(t)/(t - t_event)``, whose value at the event is its rate (negative: before the next
    crossing), so an event a fraction of a step later is still seen, and the mode cannot chatter
    at the event itself.

    ============  ===================  ==========================
    event kind    phi crossing up      new mode
    ============  ===================  ==========================
    CONTACT_LOSS  ``-g``               contact 0
    CONTACT_GAIN  ``g``                contact 1
    SEAT_CLOSING  ``-y3``              seat ON (SLACK if y3' = 0)
    SEAT_LIFTOFF  ``y3``               seat OFF
    SEAT_SLACK    ``-F``               seat SLACK
    SEAT_REENGAGE ``F``                seat ON
    ============  ===================  ==========================

    Chattering (a Zeno sequence of events, e.g. with valve lash) is stopped by ``max_events``:
    the run returns ``EVENTS_FULL``.

Status codes are the core's (:data:`impactid.simulate.dp5.STATUS_MESSAGES`); the Python layer
(:mod:`impactid.rigs.cycloidal.simulate`) turns them into :class:`~impactid.errors.SimulationError`.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import njit

from impactid import compilation
from impactid.rigs.cycloidal.cam import lift_scalar
from impactid.rigs.cycloidal.contact import hertz_load_scalar
from impactid.rigs.valvespring import surge_accelerations as _surge_py
from impactid.simulate import dp5
from impactid.simulate.dp5 import BAD_INPUT, EVENTS_FULL, MAX_STEPS, NONFINITE, OK, STATUS_MESSAGES, STEP_UNDERFLOW

compilation.install()  # before the kernels: the kernel cache's locators and the first-use notice

__all__ = ["BAD_INPUT", "CONTACT_GAIN", "CONTACT_LOSS", "EVENTS_FULL", "EVENT_NAMES", "MAX_STEPS", "NONFINITE", "OK",
           "SEAT_CLOSING", "SEAT_LIFTOFF", "SEAT_REENGAGE", "SEAT_SLACK", "SEAT_NAMES", "STATUS_MESSAGES",
           "STEP_UNDERFLOW", "RunEnd", "integrate_a", "integrate_b", "loads_b", "rhs_a", "rhs_b"]

_jit = njit(cache=True, inline="always")
#: The core's stage functions: compiled once and inlined by LLVM (``forceinline``), with the flags of
#: the function that calls ``dp5.step`` (numba's ``inline="always"`` re-typed them at every stage:
#: :mod:`impactid.simulate.dp5`, "Compiling a rig's step").
_STAGE_FLAGS = {"cache": True, "forceinline": True}
_surge = _jit(_surge_py)

# ---- parameter vector layout (built by simulate.pack) --------------------------------------
(P_M3, P_M5, P_KS1, P_KS2, P_C, P_FP, P_S, P_BETA, P_R0, P_SIGMA, P_LC, P_KSE, P_CSE, P_LASH,
 P_OMEGA) = range(15)
N_PAR = 15
# ---- level-B seat modes and event kinds ------------------------------------------------------
SEAT_OFF, SEAT_ON, SEAT_SLACK_MODE = 0, 1, 2
SEAT_NAMES = ("off", "on", "slack")
CONTACT_LOSS, CONTACT_GAIN, SEAT_CLOSING, SEAT_LIFTOFF, SEAT_SLACK, SEAT_REENGAGE = 1, 2, 3, 4, 5, 6
EVENT_NAMES = {CONTACT_LOSS: "contact_loss", CONTACT_GAIN: "contact_regain", SEAT_CLOSING: "seat_closing",
               SEAT_LIFTOFF: "seat_liftoff", SEAT_SLACK: "seat_slack", SEAT_REENGAGE: "seat_reengage"}
# ---- event table columns -----------------------------------------------------------------------
E_KIND, E_T, E_Y3, E_V3, E_RATE = range(5)  # E_RATE: g' (contact), y3' (seat), dF/dt (seat force)
N_ECOL = 5
#: What the integrators return: status, events logged, final time and mode, accepted and rejected steps.
RunEnd = namedtuple("RunEnd", ["status", "n_events", "t", "mode", "n_steps", "n_rejected"])

_SLOT_CONTACT, _SLOT_LIFT, _SLOT_FORCE = 0, 1, 2
_CHECKS = np.array([0.25, 0.5, 0.75, 1.0])


# ============================================================================================
# Level A: prescribed valve lift, the spring masses integrated
# ============================================================================================


@_jit
def _accel_a(t, y5, v5, y6, v6, p):
    om = p[P_OMEGA]
    s, s1, _, _ = lift_scalar(om * t, p[P_S], p[P_BETA])
    a5, a6, _ = _surge(s, om * s1, y5, v5, y6, v6, p[P_M5], p[P_KS1], p[P_KS2], p[P_C], p[P_C])
    return a5, a6


@njit(**_STAGE_FLAGS)
def _begin_a(mode, t, y, p, law):
    return (0.0,)


@njit(**_STAGE_FLAGS)
def _stage_a(mode, cache, t, y, d, ch, p, law, K, s, monitor):
    y5 = y[0] + d[0]
    v5 = y[1] + d[1]
    y6 = y[2] + d[2]
    v6 = y[3] + d[3]
    a5, a6 = _accel_a(t + ch, y5, v5, y6, v6, p)
    K[s, 0] = v5
    K[s, 1] = a5
    K[s, 2] = v6
    K[s, 3] = a6


@njit(cache=True)
def rhs_a(t, z, p, out):
    """Level-A right-hand side ``dz/dt`` at time ``t`` [s] (for tests against a reference)."""
    a5, a6 = _accel_a(t, z[0], z[1], z[2], z[3], p)
    out[0] = z[1]
    out[1] = a5
    out[2] = z[3]
    out[3] = a6


@njit(cache=True)
def _emit(grid, gi, t_stop, t, h, y, Q, out, mode, scratch):
    """Write the continuous extension of the step ``[t, t + h]`` at the grid times ``<= t_stop``."""
    n = y.shape[0]
    while gi < grid.shape[0] and grid[gi] <= t_stop:
        x = (grid[gi] - t) / h if h > 0.0 else 0.0
        dp5.dense(x, h, y, Q, scratch)
        for i in range(n):
            out[gi, i] = scratch[i]
        out[gi, n] = mode
        gi += 1
    return gi


@njit(cache=True)
def integrate_a(p, t0, z, t_end, rtol, atol, h_max, max_steps, stops, grid, out):
    """Integrate level A from ``t0`` to ``t_end``; ``z`` (4,) is the initial state, overwritten with the
    final one.

    Parameters
    ----------
    p : packed parameters (layout ``P_*``); rtol, atol (4,) : tolerances; h_max : largest step [s];
    max_steps : step budget; stops : sorted times [s] where a step must end (kinematic break points);
    grid : sorted output times in ``[t0, t_end]``; out : (len(grid), 5) states and the mode (0).
    """
    n = 4
    K = np.empty((7, n))
    Q = np.empty((n, 4))
    work = np.empty(n)
    ynew = np.empty(n)
    scratch = np.empty(n)
    monitor = np.empty(1)
    y = z.copy()
    for i in range(n):
        if not math.isfinite(y[i]):
            return RunEnd(BAD_INPUT, 0, t0, 0, 0, 0)
    t = t0
    rhs_a(t, y, p, work)
    for i in range(n):
        K[0, i] = work[i]
    h = dp5.initial_step(_stage_a, _begin_a, 0, t, y, p, p, K, work, monitor, rtol, atol, h_max)
    si = 0
    while si < stops.shape[0] and stops[si] <= t:
        si += 1
    gi = 0
    while gi < grid.shape[0] and grid[gi] < t:
        gi += 1
    n_steps = 0
    n_rej = 0
    rejected = False
    while t < t_end:
        if n_steps + n_rej >= max_steps:
            z[:] = y
            return RunEnd(MAX_STEPS, 0, t, 0, n_steps, n_rej)
        t_lim = t_end
        if si < stops.shape[0] and stops[si] < t_lim:
            t_lim = stops[si]
        h = min(h, h_max)
        hit = False
        if t + h >= t_lim - 1e-14 * max(1.0, abs(t_lim)):
            h = t_lim - t
            hit = True
        if h <= 4e-16 * max(1.0, abs(t)):
            z[:] = y
            return RunEnd(STEP_UNDERFLOW, 0, t, 0, n_steps, n_rej)
        y1, e = dp5.step(_stage_a, _begin_a, 0, t, y, h, p, p, K, work, ynew, monitor)
        err = dp5.error_norm(y, y1, e, rtol, atol)
        if not math.isfinite(err):
            n_rej += 1
            h *= 0.2
            rejected = True
            continue
        if err > 1.0:
            n_rej += 1
            h *= dp5.shrink_factor(err, 0.2, 0.2)
            rejected = True
            continue
        n_steps += 1
        dp5.dense_coefficients(K, Q)
        t_new = t_lim if hit else t + h
        gi = _emit(grid, gi, t_new, t, h, y, Q, out, 0, scratch)
        for i in range(n):
            y[i] = y1[i]
            K[0, i] = K[6, i]
        t = t_new
        if hit and si < stops.shape[0] and t >= stops[si]:
            si += 1
        h *= dp5.step_factor(err, rejected)
        rejected = False
    while gi < grid.shape[0]:
        for i in range(n):
            out[gi, i] = y[i]
        out[gi, n] = 0
        gi += 1
    z[:] = y
    return RunEnd(OK, 0, t, 0, n_steps, n_rej)


# ============================================================================================
# Level B: the valve released; unilateral Hertz cam contact and valve seat
# ============================================================================================


@_jit
def _forces_b(mode, t, y3, v3, p):
    """Cam load (continued as an odd function of the penetration) and seat reaction in ``mode``."""
    W = 0.0
    if mode % 2 == 1:
        s, _, s2, _ = lift_scalar(p[P_OMEGA] * t, p[P_S], p[P_BETA])
        g = s - p[P_LASH] - y3
        load = hertz_load_scalar(abs(g), p[P_R0] + s + s2, p[P_SIGMA], p[P_LC])
        W = load if g >= 0.0 else -load
    F = 0.0
    if mode // 2 == SEAT_ON:
        F = -p[P_KSE] * y3 - p[P_CSE] * v3
    return W, F


@_jit
def _accel_b(mode, t, y3, v3, y5, v5, y6, v6, p):
    W, F = _forces_b(mode, t, y3, v3, p)
    a5, a6, spring = _surge(y3, v3, y5, v5, y6, v6, p[P_M5], p[P_KS1], p[P_KS2], p[P_C], p[P_C])
    a3 = (W + F - p[P_FP] + spring) / p[P_M3]
    return a3, a5, a6


@njit(**_STAGE_FLAGS)
def _begin_b(mode, t, y, p, law):
    return (0.0,)


@njit(**_STAGE_FLAGS)
def _stage_b(mode, cache, t, y, d, ch, p, law, K, s, monitor):
    y3 = y[0] + d[0]
    v3 = y[1] + d[1]
    y5 = y[2] + d[2]
    v5 = y[3] + d[3]
    y6 = y[4] + d[4]
    v6 = y[5] + d[5]
    a3, a5, a6 = _accel_b(mode, t + ch, y3, v3, y5, v5, y6, v6, p)
    K[s, 0] = v3
    K[s, 1] = a3
    K[s, 2] = v5
    K[s, 3] = a5
    K[s, 4] = v6
    K[s, 5] = a6


@njit(cache=True)
def rhs_b(mode, t, x, p, out):
    """Level-B right-hand side ``dx/dt`` in ``mode`` at time ``t`` [s] (for tests against a reference)."""
    a3, a5, a6 = _accel_b(mode, t, x[0], x[1], x[2], x[3], x[4], x[5], p)
    out[0] = x[1]
    out[1] = a3
    out[2] = x[3]
    out[3] = a5
    out[4] = x[5]
    out[5] = a6


@njit(cache=True)
def loads_b(t, X, p, W, F):
    """Cam load ``W`` and seat reaction ``F`` [N] of level-B states ``X`` (n, >= 2) at times ``t``:
    the physical one-sided laws (``W = delta^-1(g)`` for ``g > 0``, ``F = max(0, -K_se y3 - C_se y3')``
    for ``y3 < 0``), whatever the mode."""
    for i in range(t.shape[0]):
        s, _, s2, _ = lift_scalar(p[P_OMEGA] * t[i], p[P_S], p[P_BETA])
        g = s - p[P_LASH] - X[i, 0]
        W[i] = hertz_load_scalar(g, p[P_R0] + s + s2, p[P_SIGMA], p[P_LC]) if g > 0.0 else 0.0
        F[i] = max(0.0, -p[P_KSE] * X[i, 0] - p[P_CSE] * X[i, 1]) if X[i, 0] < 0.0 else 0.0


@_jit
def _phi(slot, mode, t, y3, v3, p):
    """Switching function of ``slot`` in ``mode``; its upward crossing is the slot's event.
    Returns NaN for a slot the mode does not watch."""
    if slot == _SLOT_CONTACT:
        s, _, _, _ = lift_scalar(p[P_OMEGA] * t, p[P_S], p[P_BETA])
        g = s - p[P_LASH] - y3
        return -g if mode % 2 == 1 else g
    seat = mode // 2
    if slot == _SLOT_LIFT:
        return -y3 if seat == SEAT_OFF else y3
    if seat == SEAT_OFF:
        return math.nan
    F = -p[P_KSE] * y3 - p[P_CSE] * v3
    return -F if seat == SEAT_ON else F


@_jit
def _phi_rate(slot, mode, t, v3, a3, p):
    """Time derivative of :func:`_phi` (for the deflation at a restart)."""
    if slot == _SLOT_CONTACT:
        _, s1, _, _ = lift_scalar(p[P_OMEGA] * t, p[P_S], p[P_BETA])
        gr = p[P_OMEGA] * s1 - v3
        return -gr if mode % 2 == 1 else gr
    seat = mode // 2
    if slot == _SLOT_LIFT:
        return -v3 if seat == SEAT_OFF else v3
    Fr = -p[P_KSE] * v3 - p[P_CSE] * a3
    return -Fr if seat == SEAT_ON else Fr


@njit(cache=True)
def _phi_dense(x, args):
    slot, mode, t, h, y, Q, p, deflate, slope0, scratch = args
    if deflate and x <= 0.0:
        return slope0
    dp5.dense(x, h, y, Q, scratch)
    f = _phi(slot, mode, t + x * h, scratch[0], scratch[1], p)
    if deflate:
        return f / x
    return f


@njit(cache=True)
def _root(slot, mode, t, h, y, Q, p, deflate, slope0, scratch, xa, xb, fa, fb):
    args = (slot, mode, t, h, y, Q, p, deflate, slope0, scratch)
    return dp5.brent(_phi_dense, args, xa, xb, fa, fb, max(4e-16, 1e-17 / max(h, 1e-300)), 1)


@njit(cache=True)
def _new_mode(kind, mode, v3):
    contact = mode % 2
    seat = mode // 2
    if kind == CONTACT_LOSS:
        contact = 0
    elif kind == CONTACT_GAIN:
        contact = 1
    elif kind == SEAT_CLOSING:
        seat = SEAT_ON if v3 < 0.0 else SEAT_SLACK_MODE
    elif kind == SEAT_LIFTOFF:
        seat = SEAT_OFF
    elif kind == SEAT_SLACK:
        seat = SEAT_SLACK_MODE
    else:
        seat = SEAT_ON
    return contact + 2 * seat


@njit(cache=True)
def _event_kind(slot, mode):
    if slot == _SLOT_CONTACT:
        return CONTACT_LOSS if mode % 2 == 1 else CONTACT_GAIN
    seat = mode // 2
    if slot == _SLOT_LIFT:
        return SEAT_CLOSING if seat == SEAT_OFF else SEAT_LIFTOFF
    return SEAT_SLACK if seat == SEAT_ON else SEAT_REENGAGE


@njit(cache=True)
def integrate_b(p, t0, x, mode0, t_end, rtol, atol, h_max, max_steps, stops, grid, out, events, max_events):
    """Integrate level B from ``t0`` to ``t_end``; ``x`` (6,) is the initial state, overwritten with the
    final one.

    Parameters
    ----------
    p : packed parameters (layout ``P_*``); mode0 : initial mode ``contact + 2 seat``;
    rtol, atol (6,) : tolerances; h_max : largest step [s]; max_steps : step budget (accepted and
    rejected); stops : sorted times [s] where a step must end; grid : sorted output times;
    out : (len(grid), 7) states and mode; events : (capacity, N_ECOL) event log (events beyond its
    capacity are counted, not stored); max_events : a run with more events stops with EVENTS_FULL
    (chattering).

    Returns
    -------
    :data:`RunEnd`.
    """
    n = 6
    K = np.empty((7, n))
    Q = np.empty((n, 4))
    work = np.empty(n)
    ynew = np.empty(n)
    scratch = np.empty(n)
    scratch2 = np.empty(n)
    monitor = np.empty(1)
    y = x.copy()
    for i in range(n):
        if not math.isfinite(y[i]):
            return RunEnd(BAD_INPUT, 0, t0, mode0, 0, 0)
    mode = mode0
    t = t0
    rhs_b(mode, t, y, p, work)
    for i in range(n):
        K[0, i] = work[i]
    h = dp5.initial_step(_stage_b, _begin_b, mode, t, y, p, p, K, work, monitor, rtol, atol, h_max)
    si = 0
    while si < stops.shape[0] and stops[si] <= t:
        si += 1
    gi = 0
    while gi < grid.shape[0] and grid[gi] < t:
        gi += 1
    n_steps = 0
    n_rej = 0
    n_ev = 0
    rejected = False
    fresh = -1  # slot of the switching function that fired at the step start (deflated)
    fresh_rate = 0.0
    f_end = np.empty(3)
    f_prev = np.empty(3)
    while t < t_end:
        if n_steps + n_rej >= max_steps:
            x[:] = y
            return RunEnd(MAX_STEPS, n_ev, t, mode, n_steps, n_rej)
        t_lim = t_end
        if si < stops.shape[0] and stops[si] < t_lim:
            t_lim = stops[si]
        h = min(h, h_max)
        hit = False
        if t + h >= t_lim - 1e-14 * max(1.0, abs(t_lim)):
            h = t_lim - t
            hit = True
        if h <= 4e-16 * max(1.0, abs(t)):
            x[:] = y
            return RunEnd(STEP_UNDERFLOW, n_ev, t, mode, n_steps, n_rej)
        y1, e = dp5.step(_stage_b, _begin_b, mode, t, y, h, p, p, K, work, ynew, monitor)
        err = dp5.error_norm(y, y1, e, rtol, atol)
        if not math.isfinite(err):
            n_rej += 1
            h *= 0.2
            rejected = True
            continue
        if err > 1.0:
            n_rej += 1
            h *= dp5.shrink_factor(err, 0.2, 0.2)
            rejected = True
            continue
        dp5.dense_coefficients(K, Q)
        # ---- switching functions: start, three interior points, end --------------------------
        for slot in range(3):
            if slot == fresh:
                f_prev[slot] = min(fresh_rate * h, -1e-300)
            else:
                f_prev[slot] = _phi(slot, mode, t, y[0], y[1], p)
        best_x = 2.0
        best_slot = -1
        x_prev = 0.0
        for c in range(_CHECKS.shape[0]):
            xc = _CHECKS[c]
            if xc < 1.0:
                dp5.dense(xc, h, y, Q, scratch)
                y3c = scratch[0]
                v3c = scratch[1]
            else:
                y3c = y1[0]
                v3c = y1[1]
            tc = t_lim if (hit and xc == 1.0) else t + xc * h
            for slot in range(3):
                f = _phi(slot, mode, tc, y3c, v3c, p)
                if slot == fresh:
                    f = f / xc
                f_end[slot] = f
            for slot in range(3):
                fa = f_prev[slot]
                fb = f_end[slot]
                if math.isnan(fa) or math.isnan(fb):
                    continue
                if fa <= 0.0 and fb > 0.0:
                    xr = _root(slot, mode, t, h, y, Q, p, slot == fresh, f_prev[slot] if slot == fresh else 0.0,
                               scratch2, x_prev, xc, fa, fb)
                    if xr < best_x:
                        best_x = xr
                        best_slot = slot
            if best_slot >= 0:
                break
            for slot in range(3):
                f_prev[slot] = f_end[slot]
            x_prev = xc
        if best_slot < 0:
            # ---- no event: accept the step ----
            n_steps += 1
            t_new = t_lim if hit else t + h
            gi = _emit(grid, gi, t_new, t, h, y, Q, out, mode, scratch)
            for i in range(n):
                y[i] = y1[i]
                K[0, i] = K[6, i]
            t = t_new
            if hit and si < stops.shape[0] and t >= stops[si]:
                si += 1
            h *= dp5.step_factor(err, rejected)
            rejected = False
            fresh = -1
            continue
        # ---- an event inside the step: re-integrate to it, switch the mode ----
        h_ev = best_x * h
        if h_ev <= 0.0:
            h_ev = 1e-16 * max(1.0, abs(t))
        y1, e = dp5.step(_stage_b, _begin_b, mode, t, y, h_ev, p, p, K, work, ynew, monitor)
        n_steps += 1
        dp5.dense_coefficients(K, Q)
        t_ev = t + h_ev
        gi = _emit(grid, gi, t_ev, t, h_ev, y, Q, out, mode, scratch)
        for i in range(n):
            y[i] = y1[i]
        t = t_ev
        kind = _event_kind(best_slot, mode)
        a3_before = K[6, 1]
        mode = _new_mode(kind, mode, y[1])
        rhs_b(mode, t, y, p, work)
        for i in range(n):
            K[0, i] = work[i]
        if best_slot == _SLOT_CONTACT:
            rate = p[P_OMEGA] * lift_scalar(p[P_OMEGA] * t, p[P_S], p[P_BETA])[1] - y[1]
        elif best_slot == _SLOT_LIFT:
            rate = y[1]
        else:
            rate = -p[P_KSE] * y[1] - p[P_CSE] * a3_before
        if n_ev < events.shape[0]:
            events[n_ev, E_KIND] = kind
            events[n_ev, E_T] = t
            events[n_ev, E_Y3] = y[0]
            events[n_ev, E_V3] = y[1]
            events[n_ev, E_RATE] = rate
        n_ev += 1
        if n_ev >= max_events:
            x[:] = y
            return RunEnd(EVENTS_FULL, n_ev, t, mode, n_steps, n_rej)
        fresh = best_slot
        fresh_rate = _phi_rate(best_slot, mode, t, y[1], K[0, 1], p)
        if hit and si < stops.shape[0] and t >= stops[si]:
            si += 1
        rejected = False
    while gi < grid.shape[0]:
        for i in range(n):
            out[gi, i] = y[i]
        out[gi, n] = mode
        gi += 1
    x[:] = y
    return RunEnd(OK, n_ev, t, mode, n_steps, n_rej)

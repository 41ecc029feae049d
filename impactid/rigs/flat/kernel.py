"""Compiled (numba) event-driven integrator for rig F (Alzate et al. 2007, docs/rig_f.md).

The follower is either in free flight (A-10, ``J theta_ddot = -M_s(theta)``) or riding the cam
(``theta = theta_hat(theta_c)`` exactly, A-11/A-17). Impacts are instantaneous velocity resets with
the restitution law on the gap rate (A-12..A-16): ``h_dot+ = -r h_dot-``, i.e.
``theta_dot+ = theta_dot- - (1 + r) h_dot- / L`` with ``L = dh/dtheta_f``. (Written with the cam
centre, this is the paper's A-14: at contact the lever arm and the normal velocity of the contact
point ``p_C`` equal those of the cam centre.)

Method
------
* Free flight: the Dormand–Prince 5(4) core of :mod:`impactid.simulate.dp5` (pair layout: the
  follower angle and rate), standard step-size control, 4th-order dense output. After each
  accepted step the gap is checked at the step end and its midpoint; a sign change is located
  with Brent's method (:func:`~impactid.simulate.dp5.brent`) on the dense output, the step is
  re-integrated from its start to the root and one Newton correction ``dt = -h / h_dot`` (another
  re-integration) puts the impact where ``|h|`` is at round-off level.
* The step that starts at an impact has a root at its own start (``h = 0``, ``h_dot+ > 0``); the
  gap is deflated there, ``h(t) / (t - t_i)``, whose value at ``t_i`` is ``h_dot+``, so the next
  impact is found however short the bounce.
* Chattering: a bounce whose separation speed ``h_dot+`` is below ``v_stick`` would last about
  ``2 h_dot+ / h_ddot`` and the impacts that follow accumulate (a Zeno sequence) in a time of the
  same order. Such an impact, when the cam can hold the follower (contact torque ``tau >= 0``),
  ends the sequence: the follower sticks. This is what keeps the integrator from stalling.
* Sticking: the state is the exact contact motion, no integration. The contact torque
  ``tau(theta_c) = J omega^2 theta_hat'' + M_s(theta_hat)`` is scanned at ``STICK_SCAN`` points per
  revolution and its downward zero is located by Brent's method; the follower is then
  released into free flight with the contact state.

Status codes are returned instead of raising; :mod:`impactid.rigs.flat.simulate` turns them into
:class:`~impactid.errors.SimulationError`.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import njit, prange

from impactid import compilation
from impactid.rigs.flat import parameters as _geo
from impactid.simulate import dp5
from impactid.simulate.dp5 import BAD_INPUT, MAX_STEPS, NONFINITE, OK, STATUS_MESSAGES, STEP_UNDERFLOW

compilation.install()  # before the kernels: the kernel cache's locators and the first-use notice

_jit = njit(cache=True, inline="always")
#: The core's stage functions: compiled once and inlined by LLVM (``forceinline``), with the flags of
#: the function that calls ``dp5.step`` (numba's ``inline="always"`` re-typed them at every stage:
#: :mod:`impactid.simulate.dp5`, "Compiling a rig's step").
_STAGE_FLAGS = {"cache": True, "forceinline": True}
_gap = _jit(_geo.flat_gap)
_gap_rate = _jit(_geo.flat_gap_rate)
_lever = _jit(_geo.flat_lever)
_spring_torque = _jit(_geo.flat_spring_torque)
_contact_angle = _jit(_geo.contact_angle_derivatives)

# ---- parameter vector layout (built by flat.pack_flat_rig) --------------------------------
P_R, P_E, P_X0, P_Y0, P_D, P_J, P_K, P_XA, P_L = range(9)
N_PAR = 9
# ---- modes ---------------------------------------------------------------------------------
FREE, STICK = 0, 1
# ---- event table -----------------------------------------------------------------------------
EV_IMPACT, EV_STICK, EV_RELEASE = 1.0, 2.0, 3.0
E_KIND, E_T, E_THETA_C, E_THETA_F, E_RATE_BEFORE, E_RATE_AFTER, E_GAPRATE_BEFORE, E_GAPRATE_AFTER = range(8)
N_ECOL = 8
# ---- status codes: the core's (dp5.STATUS_MESSAGES) ----------------------------------------
__all__ = ["BAD_INPUT", "MAX_STEPS", "NONFINITE", "OK", "STATUS_MESSAGES", "STEP_UNDERFLOW", "integrate", "sweep"]
#: What :func:`integrate` returns: the status, the number of events, the final time, state and
#: mode, and the number of steps.
RunEnd = namedtuple("RunEnd", ["status", "n_events", "t", "theta", "rate", "mode", "n_steps"])
#: Points per cam revolution at which the contact torque is checked while sticking.
STICK_SCAN = 2048


@njit(cache=True)
def free_acceleration(theta, p):
    """Follower acceleration in free flight (A-10) [rad/s^2]."""
    return -_spring_torque(theta, p[P_K], p[P_XA], p[P_D], p[P_L]) / p[P_J]


@njit(cache=True)
def gap(theta, theta_c, p):
    return _gap(theta, theta_c, p[P_R], p[P_E], p[P_X0], p[P_Y0], p[P_D])


@njit(cache=True)
def contact_state(theta_c, omega, p):
    """Follower angle, rate and contact torque when riding the cam at cam angle ``theta_c``."""
    th, d1, d2 = _contact_angle(theta_c, p[P_R], p[P_E], p[P_X0], p[P_Y0], p[P_D])
    tau = p[P_J] * omega * omega * d2 + _spring_torque(th, p[P_K], p[P_XA], p[P_D], p[P_L])
    return th, omega * d1, tau


@njit(**_STAGE_FLAGS)
def _begin(mode, t, y, p, law):
    return (0.0,)


@njit(**_STAGE_FLAGS)
def _stage(mode, cache, t, y, d, ch, p, law, K, s, monitor):
    """Free flight (A-10): the rate and acceleration at ``y + d`` (the flight is autonomous)."""
    K[s, 0] = y[1] + d[1]
    K[s, 1] = free_acceleration(y[0] + d[0], p)


_NO_WORK = np.empty(0)


@njit(cache=True)
def _dp5_step(theta, rate, h, f0, p, K, Q):
    """One DP5 step of the free flight from the core; fills the continuous extension ``Q``;
    returns the new state and its error estimate."""
    K[0, 0] = rate
    K[0, 1] = f0
    y1, err = dp5.step(_stage, _begin, FREE, 0.0, (theta, rate), h, p, p, K, _NO_WORK, _NO_WORK, _NO_WORK)
    dp5.dense_coefficients(K, Q)
    return y1[0], y1[1], err[0], err[1]


@njit(cache=True)
def _dense(x, h, th0, r0, Q):
    """State at fraction ``x`` of the step from the continuous extension ``Q``."""
    return dp5.dense(x, h, (th0, r0), Q, _NO_WORK)


@njit(cache=True)
def _gap_dense(x, t0, h, th0, r0, Q, p, omega, theta_c0, x_deflate, slope0):
    """Gap on the dense output at fraction ``x``; with ``x_deflate >= 0`` the gap divided by
    ``(x - x_deflate)`` (its limit at ``x_deflate`` is ``slope0``, the gap rate times ``h``)."""
    if x_deflate >= 0.0 and x - x_deflate <= 0.0:
        return slope0
    th, _ = _dense(x, h, th0, r0, Q)
    g = gap(th, theta_c0 + omega * (t0 + x * h), p)
    if x_deflate >= 0.0:
        return g / (x - x_deflate)
    return g


@njit(cache=True)
def _gap_at(x, args):
    t0, h, th0, r0, Q, p, omega, theta_c0, x_deflate, slope0 = args
    return _gap_dense(x, t0, h, th0, r0, Q, p, omega, theta_c0, x_deflate, slope0)


@njit(cache=True)
def _root_gap(xa, xb, fa, fb, t0, h, th0, r0, Q, p, omega, theta_c0, x_deflate, slope0):
    """Root of the (deflated) gap in [xa, xb] (fa > 0 > fb) to about 1e-16 of a step."""
    args = (t0, h, th0, r0, Q, p, omega, theta_c0, x_deflate, slope0)
    return dp5.brent(_gap_at, args, xa, xb, fa, fb, max(4e-16, 1e-16 / max(h, 1e-300)), -1)


@njit(cache=True)
def _torque_at(tm, args):
    omega, theta_c0, p = args
    return contact_state(theta_c0 + omega * tm, omega, p)[2]


@njit(cache=True)
def _root_torque(ta, tb, fa, fb, omega, theta_c0, p):
    """Downward zero of the contact torque in [ta, tb] (fa >= 0 > fb) to about 1e-15 s: the last
    time at which the cam still holds the follower."""
    return dp5.brent(_torque_at, (omega, theta_c0, p), ta, tb, fa, fb, 4e-16 * max(1.0, abs(tb)), 1)


@njit(cache=True)
def _emit_dense(grid, gi, t_stop, t, h, th, r, Q, out):
    """Write the free-flight dense output of the step ``[t, t + h]`` at the grid times up to
    ``t_stop`` into ``out``; returns the next grid index."""
    while gi < grid.shape[0] and grid[gi] <= t_stop:
        gth, grt = _dense((grid[gi] - t) / h, h, th, r, Q)
        out[gi, 0] = gth
        out[gi, 1] = grt
        out[gi, 2] = FREE
        gi += 1
    return gi


@njit(cache=True)
def _record(events, n_ev, kind, t, theta_c, th, r_before, r_after, g_before, g_after, counts, t0, period):
    if n_ev < events.shape[0]:
        events[n_ev, E_KIND] = kind
        events[n_ev, E_T] = t
        events[n_ev, E_THETA_C] = theta_c
        events[n_ev, E_THETA_F] = th
        events[n_ev, E_RATE_BEFORE] = r_before
        events[n_ev, E_RATE_AFTER] = r_after
        events[n_ev, E_GAPRATE_BEFORE] = g_before
        events[n_ev, E_GAPRATE_AFTER] = g_after
    if counts.shape[0] > 0:
        k = int((t - t0) / period)
        if 0 <= k < counts.shape[0]:
            counts[k, int(kind) - 1] += 1
    return n_ev + 1


@njit(cache=True)
def integrate(p, omega, theta_c0, restitution, v_stick, t0, theta0, rate0, mode0, t_end,
              rtol, atol_a, atol_d, h_max, max_steps, grid, out, events, counts):
    """Integrate rig F from ``t0`` to ``t_end``.

    Parameters
    ----------
    p : packed rig parameters (layout above).
    omega, theta_c0 : cam speed [rad/s] and cam angle at ``t = 0`` [rad].
    restitution : coefficient ``r`` of this run [-]; ``v_stick`` : chatter threshold [m/s].
    theta0, rate0, mode0 : initial state [rad, rad/s] and mode (FREE or STICK; a STICK start
        takes the contact state at ``t0`` and ignores theta0/rate0).
    rtol, atol_a, atol_d, h_max, max_steps : integrator settings.
    grid : sorted output times; ``out[i] = (theta_f, rate, mode)`` at ``grid[i]``.
    events : (capacity, N_ECOL) event table, filled in order (events beyond capacity are counted).
    counts : (revolutions, 3) counts of impacts/sticks/releases per cam revolution from ``t0``
        (shape (0, 3) to skip).

    Returns
    -------
    :data:`RunEnd` (a named record).
    """
    period = 2.0 * math.pi / omega
    t = t0
    th = theta0
    r = rate0
    mode = mode0
    n_ev = 0
    n_steps = 0
    gi = 0
    n_grid = grid.shape[0]
    K = np.empty((7, 2))
    Q = np.empty((2, 4))
    if not (math.isfinite(t0) and math.isfinite(t_end) and math.isfinite(theta0) and math.isfinite(rate0)):
        return RunEnd(BAD_INPUT, 0, t, th, r, mode, 0)
    if mode == STICK:
        th, r, tau = contact_state(theta_c0 + omega * t, omega, p)
        if tau < 0.0:
            mode = FREE
    deflate = mode0 == STICK  # the current free flight starts on the surface (impact or release)
    g_start_rate = 0.0  # h_dot at that start
    h = min(h_max, 1e-4 * period)
    dt_scan = period / STICK_SCAN
    while t < t_end:
        if mode == STICK:
            # exact contact motion until the torque turns negative or the run ends
            _, _, tau_a = contact_state(theta_c0 + omega * t, omega, p)
            released = False
            while t < t_end:
                tb = min(t + dt_scan, t_end)
                _, _, tau_b = contact_state(theta_c0 + omega * tb, omega, p)
                if tau_b < 0.0:
                    tb = _root_torque(t, tb, max(tau_a, 0.0), tau_b, omega, theta_c0, p)
                    released = True
                while gi < n_grid and grid[gi] <= tb:
                    gth, grt, _ = contact_state(theta_c0 + omega * grid[gi], omega, p)
                    out[gi, 0] = gth
                    out[gi, 1] = grt
                    out[gi, 2] = STICK
                    gi += 1
                t = tb
                tau_a = tau_b
                if released:
                    break
            th, r, _ = contact_state(theta_c0 + omega * t, omega, p)
            if released:
                n_ev = _record(events, n_ev, EV_RELEASE, t, theta_c0 + omega * t, th, r, r, 0.0, 0.0,
                               counts, t0, period)
                mode = FREE
                deflate = True
                g_start_rate = 0.0
                h = min(h_max, 1e-4 * period)
            continue
        # ---- free flight: one adaptive DP5 step ----
        if n_steps >= max_steps:
            return RunEnd(MAX_STEPS, n_ev, t, th, r, mode, n_steps)
        f0 = free_acceleration(th, p)
        h = min(h, h_max, t_end - t)
        if h <= 4e-16 * max(1.0, abs(t)):
            if t_end - t <= 4e-16 * max(1.0, abs(t)):
                t = t_end
                break
            return RunEnd(STEP_UNDERFLOW, n_ev, t, th, r, mode, n_steps)
        th1, r1, ea, ed = _dp5_step(th, r, h, f0, p, K, Q)
        n_steps += 1
        err = dp5.error_norm((th, r), (th1, r1), (ea, ed), rtol, (atol_a, atol_d))
        if not (math.isfinite(th1) and math.isfinite(r1)):
            if h < 1e-12 * period:
                return RunEnd(NONFINITE, n_ev, t, th, r, mode, n_steps)
            h *= 0.2
            continue
        if err > 1.0:
            h *= max(0.2, 0.9 * err ** -0.2)
            continue
        # accepted: look for an impact inside the step
        t1 = t + h
        g1 = gap(th1, theta_c0 + omega * t1, p)
        gm = _gap_dense(0.5, t, h, th, r, Q, p, omega, theta_c0, -1.0, 0.0)
        x_root = -1.0
        if deflate:
            # the flight starts on the surface: work with the gap deflated at the step start
            slope0 = g_start_rate * h
            if slope0 > 0.0:
                if gm < 0.0:
                    x_root = _root_gap(0.0, 0.5, slope0, gm / 0.5, t, h, th, r, Q, p, omega, theta_c0,
                                           0.0, slope0)
                elif g1 < 0.0:
                    x_root = _root_gap(0.5, 1.0, gm / 0.5, g1, t, h, th, r, Q, p, omega, theta_c0, 0.0, slope0)
            elif gm < 0.0 and g1 < 0.0:
                # left the surface with zero gap rate and was pushed straight back: ride the cam again
                mode = STICK
                continue
        else:
            g0 = gap(th, theta_c0 + omega * t, p)
            if gm < 0.0:
                x_root = _root_gap(0.0, 0.5, g0, gm, t, h, th, r, Q, p, omega, theta_c0, -1.0, 0.0)
            elif g1 < 0.0:
                x_root = _root_gap(0.5, 1.0, gm, g1, t, h, th, r, Q, p, omega, theta_c0, -1.0, 0.0)
        if x_root < 0.0:
            # no impact: emit outputs, advance
            gi = _emit_dense(grid, gi, t1, t, h, th, r, Q, out)
            t = t1
            th = th1
            r = r1
            deflate = False
            h *= min(10.0, 0.9 * max(err, 1e-10) ** -0.2)
            continue
        # impact inside the step: re-integrate to the root, one Newton correction
        hr = x_root * h
        for _ in range(2):
            thr, rr, _, _ = _dp5_step(th, r, hr, f0, p, K, Q)
            tc = theta_c0 + omega * (t + hr)
            g = gap(thr, tc, p)
            gr = _gap_rate(thr, rr, tc, omega, p[P_E], p[P_X0], p[P_Y0])
            if gr < 0.0:
                hr -= g / gr
        thr, rr, _, _ = _dp5_step(th, r, hr, f0, p, K, Q)
        # outputs before the impact (on the re-integrated step's dense output)
        gi = _emit_dense(grid, gi, t + hr, t, hr, th, r, Q, out)
        t = t + hr
        th = thr
        tc = theta_c0 + omega * t
        g_before = _gap_rate(th, rr, tc, omega, p[P_E], p[P_X0], p[P_Y0])
        if g_before > 0.0:
            g_before = 0.0
        lever = _lever(th, tc, p[P_E], p[P_X0], p[P_Y0])
        r_after = rr - (1.0 + restitution) * g_before / lever
        g_after = -restitution * g_before
        n_ev = _record(events, n_ev, EV_IMPACT, t, tc, th, rr, r_after, g_before, g_after, counts, t0, period)
        r = r_after
        if g_after < v_stick:
            ths, rs, tau = contact_state(tc, omega, p)
            if tau >= 0.0:
                n_ev = _record(events, n_ev, EV_STICK, t, tc, ths, r_after, rs, g_after, 0.0, counts, t0, period)
                th = ths
                r = rs
                mode = STICK
                continue
        deflate = True
        g_start_rate = g_after
        h = min(h, max(hr, 1e-9 * period))
    while gi < n_grid:
        # only times equal to t_end can remain
        if mode == STICK:
            gth, grt, _ = contact_state(theta_c0 + omega * grid[gi], omega, p)
            out[gi, 0] = gth
            out[gi, 1] = grt
        else:
            out[gi, 0] = th
            out[gi, 1] = r
        out[gi, 2] = mode
        gi += 1
    return RunEnd(OK, n_ev, t, th, r, mode, n_steps)


@njit(cache=True, parallel=True)
def sweep(p, omegas, restitutions, v_stick, revolutions, strobe_phase, rtol, atol_a, atol_d, h_max_rev, max_steps,
          strobe, counts, status, steps):  # pragma: no cover - compiled
    """Runs from permanent contact at ``theta_c = 0`` for each cam speed (in parallel).

    ``strobe[i, k] = (theta_f, rate, mode)`` at ``theta_c = 2 pi k + strobe_phase`` (``k = 1..``,
    ``0 <= strobe_phase < 2 pi``, the last sample inside the run); ``counts[i]`` holds the
    impacts/sticks/releases per revolution; ``status[i]`` and ``steps[i]`` the run's outcome.
    """
    for i in prange(omegas.shape[0]):
        omega = omegas[i]
        period = 2.0 * math.pi / omega
        grid = period * (np.arange(revolutions).astype(np.float64) + strobe_phase / (2.0 * math.pi))
        if strobe_phase == 0.0:
            grid += period
        events = np.empty((0, N_ECOL))
        res = integrate(p, omega, 0.0, restitutions[i], v_stick, 0.0, 0.0, 0.0, STICK,
                        revolutions * period, rtol, atol_a, atol_d, h_max_rev * period, max_steps,
                        grid, strobe[i], events, counts[i])
        status[i] = res.status
        steps[i] = res.n_steps

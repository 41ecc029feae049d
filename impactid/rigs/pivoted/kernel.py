"""Compiled (numba) event-driven hybrid integrator for rig P.

This module is the only hot loop of impactid's simulations. Everything here works on scalars and
preallocated arrays; there is no Python in the inner loop and no allocation per step.

Method
------
* Dormand–Prince 5(4) (the tableau of ``scipy.integrate.RK45``, taken from SciPy so that it is not
  retyped), local extrapolation, FSAL, the standard step-size controller (safety 0.9, factor
  limits 0.2 and 10; a rejected first step of a compliant contact shrinks with the exponent
  1/(p+1) of the onset's ``t^(p+1)`` local error instead of 1/5) and the 4th-order continuous
  extension for dense output.
* Cost: the right-hand side is inlined into the step; the last stage also returns the monitored
  quantities (gap, gap rate, force, force rate, sliding velocity) from the same trigonometry; the
  stages' sines and cosines come from those at the step start by angle addition
  (``_sincos_shifted``, with as many terms of the series as the increment needs); the library
  sines and cosines at the step's end, which the next step starts from, are computed by the last
  stage, beside the error estimate rather than after the step-size controller; the controller
  works on the squared error norm (no square root); the step functions are compiled with FMA
  contraction (``_STEP_FLAGS``). docs/simulator.md ("Speed") says what each saves.
* The state is ``(alpha, alpha_dot)``; the cam angle is ``Theta(t) = theta_ref + omega t``.
* Modes: ``FREE`` (S-9), ``CONTACT`` (S-16 with the generalised Hunt–Crossley force
  ``k delta^p - beta delta^n dpsi/dt``, S-11..S-18),
  ``STICK`` (rigid contact constraint ``psi_i = 0``, used only by the restitution model when an
  approach speed falls below ``v_stick``; its normal force ``lambda`` follows from the constraint).
* Exact switching: after each accepted step the switching function of the current mode (the gap
  ``psi_i``, or ``lambda`` when sticking) is checked for a sign change in the direction that ends
  the mode. The root is found with Brent's method on the dense output, the step is then
  re-integrated from its start to the root, and for gap events one Newton correction
  ``h -= psi/dpsi`` (another re-integration) puts the switch where ``|psi_i|`` is at round-off
  level. The new mode starts from that state; no smoothing, no fixed step through the contact.
* Non-terminal events located on the dense output in the same way: maxima of ``alpha``
  (``alpha_dot`` crossing 0 downwards), peak indentation (``dpsi_i/dt`` crossing 0 upwards in
  contact), peak contact force (``dF/dt`` crossing 0 downwards), reversals of the sliding
  velocity (friction direction) during a contact.

Status codes are returned instead of raising (numba cannot raise rich errors from parallel
loops); :mod:`impactid.rigs.pivoted.runs` turns them into :class:`~impactid.errors.SimulationError`.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import njit, prange

from impactid import compilation
from impactid.rigs.pivoted import parameters as _geo
from impactid.simulate import dp5

compilation.install()  # before the kernels: the kernel cache's locators and the first-use notice

__all__ = ["KIND_COMPLIANT", "KIND_RESTITUTION", "NO_GRID_SENS", "NO_SENS", "NO_SENS_MAX", "N_CCOL", "N_LAW", "N_RIG",
           "N_SENS", "N_SUM", "STATUS_MESSAGES", "RunEnd", "acceleration", "batch_events", "contact_force",
           "initial_mode", "integrate", "observe", "rhs_partials", "stick_force"]

_jit = njit(cache=True, inline="always")

#: Compilation flags of the step functions (``_dp5_step``, ``_initial_step``, ``_sensitivity_step``):
#: numpy's error model, as the core asks (:mod:`impactid.simulate.dp5`, "Compiling a rig's step"),
#: and FMA contraction, the one fast-math flag that cannot change a result beyond round-off: it
#: fuses a multiplication and the addition that consumes it into one operation rounded once
#: instead of twice (each such result within an ulp of the separately rounded one). No
#: reassociation, no reciprocal approximations, no approximate library functions, and NaN and
#: infinity keep their meaning (the integrator rejects a non-finite trial step). With it a step
#: takes about 7 % less (docs/simulator.md, "Speed").
#:
#: And LLVM's ``alwaysinline`` (``forceinline``), so that the same inputs give the same bits whether the
#: kernels were just compiled or loaded from the cache. Where contraction is allowed, which products fuse
#: depends on the optimisation the code went through, and numba keeps two compilations of a called
#: kernel: its own, and the copy linked into each caller and optimised again there. A caller that calls
#: the step by symbol runs whichever copy the JIT resolved first: the step's own where the step was
#: compiled or loaded as a kernel in the process (a fresh compilation compiles it while typing
#: ``integrate``), the caller's where ``integrate`` came from the cache alone. The two differ at
#: round-off, and a run of 150 s through a chaotic transient then ends on another attractor (the
#: envelope validation's pk00: 0.7 impacts per revolution after a fresh compilation, 1 from the cache;
#: benchmarks/envelope_notes.md). Inlined into its caller, a step has one compilation per caller, the one
#: cached with it. Every function compiled with contraction must therefore be inlined
#: (tests/rigs/pivoted/test_kernel_determinism.py checks it).
_STEP_FLAGS = {"cache": True, "error_model": "numpy", "fastmath": {"contract": True}, "forceinline": True}
#: Compilation flags of the functions the step functions call once per stage (``_begin``, ``_stage``,
#: ``_sensitivity_stage``): the step's own flags, so that their arithmetic is the step's, with its
#: ``alwaysinline`` instead of numba's IR inlining (``inline="always"``): each is typed and lowered once
#: and LLVM inlines the compiled body at every stage, where numba would re-type the whole body at each of
#: the seven call sites (that made ``_dp5_step`` 25 s and ``_sensitivity_step`` 20 s of a cold start; now
#: about 3 s each: docs/simulator.md, "Compile time").
_STAGE_FLAGS = _STEP_FLAGS
#: Flags of the small helpers the integrator and the observables call at several places (``acceleration``,
#: ``_trig_at``, ``_dense``, ``_dense_sensitivity``, ``_row_for``): their callers' (default) flags, inlined
#: by LLVM rather than re-typed by numba at each call (a quarter of ``integrate``'s own compile time).
_HELPER_FLAGS = {"cache": True, "forceinline": True}
#: Stage numbers as run-time ``int64`` (a literal would compile ``_sensitivity_stage`` once per stage).
_S = dp5.STAGE

# Shared physics, compiled from the very functions the public API uses.
_gap = _jit(_geo.gap)
_lever_arm = _jit(_geo.lever_arm)
_tangential_gap_rate = _jit(_geo.tangential_gap_rate)
_sliding_velocity_from = _jit(_geo.sliding_velocity)
_spring_force = _jit(_geo.spring_force)
_free_torque = _jit(_geo.free_torque)

# ---- parameter vector layout (built by runs.pack_rig) --------------------------------------
PE_X, PE_Y, ECC, RSUM, R_C, H_P, M_B, GRAV, L_G, K_S, L_SU, D_Y, D_X, W_B, I_B, K_H, MU = range(17)
N_RIG = 17
# ---- law vector layout ---------------------------------------------------------------------
LAW_KIND, BETA, N_EXP, CLIP, XI0, GAMMA, V_STICK, P_EXP = range(8)
N_LAW = 8
KIND_COMPLIANT = 0.0
KIND_RESTITUTION = 1.0
# ---- modes ---------------------------------------------------------------------------------
FREE, CONTACT, STICK = 0, 1, 2
# ---- event functions -----------------------------------------------------------------------
EV_GAP, EV_RATE, EV_GAPRATE, EV_DFORCE, EV_VR, EV_LAMBDA = range(6)
#: The event kinds and modes the integrator passes to its own functions, as run-time ``int64``: a
#: global integer is a literal to numba, and a literal argument compiles the callee once per value
#: (``_event_value`` had seven compiled versions, ``_root_dense`` four, ``contact_force`` three).
_EV_GAP, _EV_RATE, _EV_GAPRATE, _EV_DFORCE, _EV_LAMBDA = (np.int64(k) for k in (EV_GAP, EV_RATE, EV_GAPRATE,
                                                                          EV_DFORCE, EV_LAMBDA))
_FREE, _CONTACT = np.int64(FREE), np.int64(CONTACT)
# ---- contact table columns -----------------------------------------------------------------
(C_T_START, C_T_END, C_DPSI_START, C_DPSI_END, C_PEAK_DELTA, C_PEAK_FORCE, C_ALPHA_START,
 C_RATE_START, C_ALPHA_END, C_RATE_END, C_KIND, C_FRICTION_REVERSALS, C_T_PEAK_FORCE,
 C_T_PEAK_DELTA, C_XI) = range(15)
N_CCOL = 15
ROW_COMPLIANT, ROW_IMPACT, ROW_STICK = 1.0, 2.0, 3.0
# ---- status codes: the core's, with this kernel's names for its tables --------------------
OK, MAX_STEPS, STEP_UNDERFLOW, NONFINITE, BAD_INPUT = (dp5.OK, dp5.MAX_STEPS, dp5.STEP_UNDERFLOW, dp5.NONFINITE,
                                                       dp5.BAD_INPUT)
CONTACTS_FULL, APEX_FULL, XI_NEGATIVE = dp5.EVENTS_FULL, dp5.SAMPLES_FULL, dp5.LAW_RANGE
STATUS_MESSAGES = {**dp5.STATUS_MESSAGES, CONTACTS_FULL: "contact table full", APEX_FULL: "apex table full",
                   XI_NEGATIVE: "restitution law gave xi < 0 (approach speed beyond 1/gamma: outside the law's range)"}
#: What :func:`integrate` returns: the status, the table counts, the final state and mode, the
#: largest follower angle and its time, and the step statistics.
RunEnd = namedtuple("RunEnd", ["status", "n_contacts", "n_apexes", "t", "alpha", "alpha_dot", "mode", "alpha_max",
                               "t_alpha_max", "n_steps", "n_rejected"])
# ---- summary columns of the batch entry point ----------------------------------------------
(S_ALPHA_M, S_T_ALPHA_M, S_N_CONTACTS, S_T_START, S_T_END, S_DPSI_START, S_DPSI_END,
 S_PEAK_FORCE, S_PEAK_DELTA, S_ALPHA_END, S_RATE_END, S_STATUS, S_N_STEPS) = range(13)
N_SUM = 13


# ============================================================================================
# Right-hand side and observables
# ============================================================================================


@_jit
def _torque(a, p):
    spring = _spring_force(a, p[K_S], p[L_SU], p[D_Y], p[D_X], p[W_B])
    return _free_torque(a, spring, p[M_B], p[GRAV], p[L_G], p[D_X])


@_jit
def _sliding_velocity(a, ad, th, omega, psi, rsum, ecc, r_c):
    dpsi_j = _tangential_gap_rate(a, ad, th, omega, psi, rsum, ecc)
    return _sliding_velocity_from(a, ad, th, omega, dpsi_j, ecc, r_c)


@_jit
def _free_torque_of(sa, ca, p):
    """Spring and gravity torque about the pivot [N m] from sin/cos of alpha (S-9)."""
    return p[M_B] * p[GRAV] * p[L_G] * ca - p[K_S] * (
        p[L_SU] - p[D_Y] + (p[D_X] * sa + 0.5 * p[W_B]) / ca) * p[D_X]


@_jit
def _evaluate(mode, t, a, ad, add, p, law, theta_ref, omega, want_acceleration):
    """The right-hand side and the monitored quantities at one state, sharing the trigonometry.

    Returns ``(alpha_ddot, g, dpsi, force, dforce, v_r)``. With ``want_acceleration`` false,
    ``add`` is taken as the known ``alpha_ddot`` (FSAL) instead of being computed. ``g`` is the
    function whose zero ends the mode (the gap, or the constraint force when sticking), then the
    gap rate [m/s], the contact force [N], its rate [N/s] (contact only) and the sliding velocity
    [m/s] (contact and stick only).
    """
    th = theta_ref + omega * t
    return _evaluate_trig(mode, a, ad, add, math.sin(a), math.cos(a), math.sin(th), math.cos(th), p, law, omega,
                          want_acceleration)


# reciprocals of the Taylor series' divisors (compile-time constants of ``_sincos_shifted``)
_INV6, _INV12, _INV20, _INV30, _INV42, _INV56, _INV72 = (1.0 / k for k in (6, 12, 20, 30, 42, 56, 72))


@_jit
def _sincos_shifted(x0, s0, c0, d):
    """``sin(x0 + d), cos(x0 + d)`` from ``s0 = sin(x0), c0 = cos(x0)``.

    For the small in-step increments (``|d| < 0.03``) by the angle-addition formulas with the
    Taylor series of ``sin d`` and ``cos d - 1``, which is about 4x cheaper than two library calls;
    otherwise directly. The series' divisions are multiplications by the reciprocals (constants): a
    division's latency, taken seven times in a chain at every stage, was most of a free-flight
    step's time. The series stop at the first term that no longer matters: the first term left
    out is below 1e-20 (absolute; a thousandth of an ulp of a sine or cosine above 0.1) in every
    branch (``|d| < 2.6e-4``: ``d^5/120``, ``d^6/720``; ``|d| < 4.3e-3``: ``d^7/5040``,
    ``d^8/40320``; ``|d| < 0.03``: ``d^11/11!``, ``d^10/10!``). A contact step moves alpha by
    about 1e-5 rad, a free-flight step by about 1e-3: the shorter series take 2 and 4 fewer
    multiply-adds off each stage's chain of dependent operations.
    """
    ad = abs(d)
    d2 = d * d
    if ad < 2.6e-4:
        sd = d * (1.0 - d2 * _INV6)
        cm1 = -0.5 * d2 * (1.0 - d2 * _INV12)
    elif ad < 4.3e-3:
        sd = d * (1.0 - d2 * _INV6 * (1.0 - d2 * _INV20))
        cm1 = -0.5 * d2 * (1.0 - d2 * _INV12 * (1.0 - d2 * _INV30))
    elif ad < 0.03:
        sd = d * (1.0 - d2 * _INV6 * (1.0 - d2 * _INV20 * (1.0 - d2 * _INV42 * (1.0 - d2 * _INV72))))
        cm1 = -0.5 * d2 * (1.0 - d2 * _INV12 * (1.0 - d2 * _INV30 * (1.0 - d2 * _INV56)))
    else:
        return math.sin(x0 + d), math.cos(x0 + d)
    return s0 + (s0 * cm1 + c0 * sd), c0 + (c0 * cm1 - s0 * sd)


@_jit
def _contact_geometry(ad, sa, ca, st, ct, p, omega):
    """Gap ``psi`` [m], lever arm ``chi`` [m], ``sin`` and ``cos`` of ``alpha + Theta`` and the gap
    rate [m/s] from the sines and cosines of alpha and Theta (S-11..S-14)."""
    gx = p[PE_X] - p[ECC] * ct
    gy = p[PE_Y] - p[ECC] * st
    psi = sa * gx + ca * gy - p[RSUM]
    chi = ca * gx - sa * gy
    s = sa * ct + ca * st  # sin(alpha + Theta)
    c = ca * ct - sa * st  # cos(alpha + Theta)
    return psi, chi, s, c, chi * ad - p[ECC] * c * omega


@_jit
def _evaluate_trig(mode, a, ad, add, sa, ca, st, ct, p, law, omega, want_acceleration):
    """``_evaluate`` with the sines and cosines of alpha (``sa, ca``) and Theta (``st, ct``) given."""
    psi, chi, s, c, dpsi = _contact_geometry(ad, sa, ca, st, ct, p, omega)
    torque = _free_torque_of(sa, ca, p)
    if mode == FREE:
        if want_acceleration:
            add = torque * (1.0 / p[I_B])
        return add, psi, dpsi, 0.0, 0.0, 0.0
    chi_dot = -ad * (psi + p[RSUM]) + p[ECC] * omega * s
    vr = -chi_dot - (p[R_C] + p[ECC] * s) * (ad + omega)
    if mode == STICK:
        if want_acceleration:
            add = -(chi_dot * ad + p[ECC] * s * (ad + omega) * omega) / chi
        lam = (p[I_B] * add - torque) / (chi - p[MU] * np.sign(vr) * p[H_P])
        return add, lam, dpsi, lam, 0.0, vr
    d = -psi if psi < 0.0 else 0.0
    pe = law[P_EXP]
    n = law[N_EXP]
    stiff = _power(d, pe)
    damp = stiff if n == pe else _power(d, n)
    beta = law[BETA]
    force = p[K_H] * stiff - beta * damp * dpsi
    clipped = law[CLIP] != 0.0 and force < 0.0
    if clipped:
        force = 0.0
    if want_acceleration:
        add = (torque + force * chi - p[MU] * force * np.sign(vr) * p[H_P]) * (1.0 / p[I_B])
    dforce = 0.0
    if d > 0.0 and not (law[CLIP] != 0.0 and force <= 0.0):
        ddpsi = chi_dot * ad + chi * add + p[ECC] * s * (ad + omega) * omega
        dforce = -pe * p[K_H] * _power(d, pe - 1.0) * dpsi - beta * damp * ddpsi
        if n != 0.0:
            dforce += beta * n * _power(d, n - 1.0) * dpsi * dpsi
    return add, psi, dpsi, force, dforce, vr


@njit(cache=True)
def stick_force(t, a, ad, p, theta_ref, omega):
    """Normal force ``lambda`` [N] that the rigid constraint needs (negative = would pull)."""
    return _evaluate(STICK, t, a, ad, 0.0, p, np.zeros(N_LAW), theta_ref, omega, True)[3]


@_jit
def _power(d, exponent):
    """``d**exponent`` with the exponents of the papers (0, 1, 1.5) as cheap special cases."""
    if exponent == 1.5:
        return d * math.sqrt(d)
    if exponent == 1.0:
        return d
    if exponent == 0.0:
        return 1.0
    if exponent == 0.5:
        return math.sqrt(d)
    return d**exponent


@njit(cache=True)
def rhs_partials(mode, t, a, ad, p, law, theta_ref, omega):
    """Partial derivatives of ``alpha_ddot`` and of the contact force with respect to the state and the law.

    Returns ``(f_a, f_ad, f_lnb, f_n, F_a, F_ad, F_lnb, F_n)``: ``f = alpha_ddot`` [rad/s^2] and ``F``
    the Hunt–Crossley force [N], differentiated by ``alpha`` [rad], ``alpha_dot`` [rad/s],
    ``ln beta`` and ``n`` (``beta`` held). The coefficients of the forward-sensitivity equations
    (:func:`_sensitivity_step`). For FREE and CONTACT; a clipped force (``F = 0`` where it would pull)
    has zero partials, as has the damping term at ``delta = 0``. With friction the direction
    ``sigma = sgn(v_r)`` of the sliding velocity is held (it is piecewise constant: the friction force
    jumps where it reverses, which :func:`integrate` handles).

    With ``psi`` the gap, ``chi = d psi / d alpha`` the lever arm, ``delta = -psi``,
    ``dpsi = chi alpha_dot - e omega cos(alpha + Theta)``::

        d chi / d alpha = -(psi + R),   d dpsi / d alpha = -(psi + R) alpha_dot + e omega sin(alpha + Theta)
        F_a  = -chi (p k delta^(p-1) - n beta delta^(n-1) dpsi) - beta delta^n d dpsi / d alpha
        F_ad = -beta delta^n chi,  F_lnb = -beta delta^n dpsi,  F_n = F_lnb ln delta
        f_a  = (T'(alpha) + F_a arm - F (psi + R)) / I_b,  f_ad = F_ad arm / I_b,  f_x = F_x arm / I_b

    with ``arm = chi - mu sigma h_p``, the moment arm of the normal force with its friction (S-16).

    with ``T'`` the derivative of the spring and gravity torque (S-9). ``tests/rigs/pivoted/test_sensitivity.py``
    checks every entry against central differences of :func:`acceleration` and :func:`contact_force`.
    """
    th = theta_ref + omega * t
    return _partials_trig(mode, ad, math.sin(a), math.cos(a), math.sin(th), math.cos(th), p, law, omega)


@_jit
def _partials_trig(mode, ad, sa, ca, st, ct, p, law, omega):
    """:func:`rhs_partials` from the sines and cosines of alpha (``sa, ca``) and Theta (``st, ct``;
    not read in FREE)."""
    torque_a = -p[M_B] * p[GRAV] * p[L_G] * sa - p[K_S] * p[D_X] * (p[D_X] + 0.5 * p[W_B] * sa) / (ca * ca)
    inv_i = 1.0 / p[I_B]
    if mode != CONTACT:
        return torque_a * inv_i, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    psi, chi, s, c, dpsi = _contact_geometry(ad, sa, ca, st, ct, p, omega)
    dpsi_a = -ad * (psi + p[RSUM]) + p[ECC] * omega * s
    d = -psi if psi < 0.0 else 0.0
    pe = law[P_EXP]
    n = law[N_EXP]
    beta = law[BETA]
    force = p[K_H] * _power(d, pe) - beta * _power(d, n) * dpsi
    if d <= 0.0 or (law[CLIP] != 0.0 and force < 0.0):
        return torque_a * inv_i, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    damp = beta * _power(d, n)
    force_a = -chi * (pe * p[K_H] * _power(d, pe - 1.0) - n * beta * _power(d, n - 1.0) * dpsi) - damp * dpsi_a
    force_ad = -damp * chi
    force_lnb = -damp * dpsi
    force_n = force_lnb * math.log(d)
    arm = chi
    if p[MU] != 0.0:
        vr = -dpsi_a - (p[R_C] + p[ECC] * s) * (ad + omega)  # dpsi_a is also d chi / dt
        arm = chi - p[MU] * np.sign(vr) * p[H_P]
    return ((torque_a + force_a * arm - force * (psi + p[RSUM])) * inv_i, force_ad * arm * inv_i,
            force_lnb * arm * inv_i, force_n * arm * inv_i, force_a, force_ad, force_lnb, force_n)


@njit(**_HELPER_FLAGS)
def acceleration(mode, t, a, ad, p, law, theta_ref, omega):
    """``alpha_ddot`` [rad/s^2] in the given mode.

    The hot path of the integrator: the formulas of ``rigs.pivoted`` (gap, lever arm, gap rate,
    sliding velocity, spring torque) and ``contact.hunt_crossley_force`` fused in ``_evaluate`` so
    that the trigonometric functions of alpha and Theta are computed once (free flight needs only
    those of alpha). ``tests/rigs/pivoted/test_kernel_rhs.py`` checks it against those public
    functions to round-off.
    """
    if mode == FREE:
        return _free_torque_of(math.sin(a), math.cos(a), p) / p[I_B]
    return _evaluate(mode, t, a, ad, 0.0, p, law, theta_ref, omega, True)[0]


@njit(cache=True)
def contact_force(mode, t, a, ad, p, law, theta_ref, omega):
    """Normal contact force [N]: Hunt–Crossley in CONTACT, ``lambda`` in STICK, 0 in FREE."""
    if mode == FREE:
        return 0.0
    return _evaluate(mode, t, a, ad, 0.0, p, law, theta_ref, omega, True)[3]


@njit(cache=True)
def _force_rate(t, a, ad, p, law, theta_ref, omega):
    """``dF/dt`` of the Hunt–Crossley force in contact [N/s]."""
    return _evaluate(CONTACT, t, a, ad, 0.0, p, law, theta_ref, omega, True)[4]


@njit(cache=True)
def _snapshot(mode, t, a, ad, add, p, law, theta_ref, omega):
    """Switching and monitoring quantities at a state whose ``alpha_ddot`` is known (FSAL).

    Returns ``(g, dpsi, force, dforce, v_r)`` (see ``_evaluate``).
    """
    r = _evaluate(mode, t, a, ad, add, p, law, theta_ref, omega, False)
    return r[1], r[2], r[3], r[4], r[5]


@njit(cache=True)
def _event_value(kind, mode, t, a, ad, p, law, theta_ref, omega):
    th = theta_ref + omega * t
    if kind == EV_RATE:
        return ad
    if kind == EV_GAP:
        return _gap(a, th, p[PE_X], p[PE_Y], p[ECC], p[RSUM])
    if kind == EV_GAPRATE:
        chi = _lever_arm(a, th, p[PE_X], p[PE_Y], p[ECC])
        return chi * ad - p[ECC] * math.cos(a + th) * omega
    if kind == EV_DFORCE:
        return _force_rate(t, a, ad, p, law, theta_ref, omega)
    if kind == EV_VR:
        psi = _gap(a, th, p[PE_X], p[PE_Y], p[ECC], p[RSUM])
        return _sliding_velocity(a, ad, th, omega, psi, p[RSUM], p[ECC], p[R_C])
    # EV_LAMBDA
    return stick_force(t, a, ad, p, theta_ref, omega)


@njit(cache=True)
def observe(t, a, ad, mode, p, law, theta_ref, omega, out):
    """Observables on arrays: fills ``out[:, k]`` with psi, dpsi, chi, force, alpha_ddot, v_r.

    ``out`` has shape (len(t), 6). Used for histories on sample grids.
    """
    for i in range(t.shape[0]):
        th = theta_ref + omega * t[i]
        psi = _gap(a[i], th, p[PE_X], p[PE_Y], p[ECC], p[RSUM])
        chi = _lever_arm(a[i], th, p[PE_X], p[PE_Y], p[ECC])
        out[i, 0] = psi
        out[i, 1] = chi * ad[i] - p[ECC] * math.cos(a[i] + th) * omega
        out[i, 2] = chi
        m = np.int64(mode[i])  # the integrator's mode type: one compiled contact_force
        out[i, 3] = contact_force(m, t[i], a[i], ad[i], p, law, theta_ref, omega)
        out[i, 4] = acceleration(m, t[i], a[i], ad[i], p, law, theta_ref, omega)
        out[i, 5] = _sliding_velocity(a[i], ad[i], th, omega, psi, p[RSUM], p[ECC], p[R_C])


# ============================================================================================
# Dormand–Prince step, dense output, root finding
# ============================================================================================


@njit(**_STAGE_FLAGS)
def _begin(mode, t, y, run, law):
    """Step start: the sines and cosines of alpha and Theta, reused by the stages (angle addition).

    They arrive in ``run`` (``trig``: ``sin alpha, cos alpha, sin Theta, cos Theta, Theta`` at the
    step start, :func:`_trig_at`; Theta's sine and cosine are 0, 1 in FREE, where the stages do not
    read them): the previous step's last stage computed them (``S[5:10]``) with the library, as this
    function used to. Computed there, the library calls run beside that step's error estimate
    instead of after the step-size controller, on the chain of dependent operations from one step
    to the next. Theta travels with its sine and cosine, so that the stages shift the very angle
    whose sine and cosine they have."""
    p, theta_ref, omega, trig = run
    return trig[0], trig[1], trig[4], trig[2], trig[3]


@njit(**_STAGE_FLAGS)
def _stage(mode, cache, t, y, d, ch, run, law, K, s, S):
    """Rate and acceleration at ``y + d``, ``t + ch`` (the core's stage); the last stage (``s = 6``)
    also writes the step end's monitored quantities ``(g, dpsi, force, dforce, v_r)`` into
    ``S[0:5]``, sharing its trigonometry, and into ``S[5:10]`` the library sines and cosines of alpha
    and (not in FREE) Theta at the step's end, and Theta, from which the next step starts
    (:func:`_begin`).
    The stages' sines and cosines come from those at the step start by angle addition
    (``_sincos_shifted``): alpha and Theta move by small amounts within a step."""
    p, theta_ref, omega, _ = run
    sa0, ca0, th0, st0, ct0 = cache
    a = y[0] + d[0]
    ad = y[1] + d[1]
    K[s, 0] = ad
    ss, cs = _sincos_shifted(y[0], sa0, ca0, d[0])
    if s < 6:
        if mode == FREE:
            K[s, 1] = _free_torque_of(ss, cs, p) * (1.0 / p[I_B])
        else:
            st, ct = _sincos_shifted(th0, st0, ct0, omega * ch)
            K[s, 1] = _evaluate_trig(mode, a, ad, 0.0, ss, cs, st, ct, p, law, omega, True)[0]
        return
    if mode == FREE:
        st = math.sin(th0 + omega * ch)
        ct = math.cos(th0 + omega * ch)
    else:
        st, ct = _sincos_shifted(th0, st0, ct0, omega * ch)
    K[6, 1], S[0], S[1], S[2], S[3], S[4] = _evaluate_trig(mode, a, ad, 0.0, ss, cs, st, ct, p, law, omega, True)
    # the step end's library sines and cosines (_trig_at) at the state the integrator takes on:
    # alpha_1 = y + d (dp5.advance; the same number as a), Theta from the absolute time t + h
    # (t1 = t + h in integrate), never accumulated step by step
    S[5] = math.sin(a)
    S[6] = math.cos(a)
    th1 = theta_ref + omega * (t + ch)
    S[9] = th1
    if mode != FREE:
        S[7] = math.sin(th1)
        S[8] = math.cos(th1)


@njit(**_HELPER_FLAGS)
def _trig_at(mode, t, a, theta_ref, omega):
    """``(sin alpha, cos alpha, sin Theta, cos Theta, Theta)`` at ``(t, alpha)``, Theta's sine and
    cosine as 0, 1 in FREE (the ``trig`` a step starts from: :func:`_begin`)."""
    th = theta_ref + omega * t
    if mode == FREE:
        return math.sin(a), math.cos(a), 0.0, 1.0, th
    return math.sin(a), math.cos(a), math.sin(th), math.cos(th), th


#: Length of the step's monitor array ``S``: ``g, dpsi, force, dforce, v_r`` at the step's end,
#: then ``sin alpha, cos alpha, sin Theta, cos Theta, Theta`` there (:func:`_stage`).
N_MONITOR = 10
_NO_WORK = np.empty(0)


@_jit
def _run_constants(p, law, theta_ref, omega, trig):
    """The rig's and the law's parameters as tuples of floats, with the cam's ``theta_ref`` and
    ``omega`` and the step start's ``trig`` (:func:`_trig_at`): what the core's stages read
    (``run`` and ``law`` of ``_begin`` and ``_stage``).

    Tuples stay in registers; arrays passed to the stages would be reference-counted at every stage
    (see :mod:`impactid.simulate.dp5`, "Compiling a rig's step"). Indexed with the same layout
    constants as the arrays."""
    run = ((p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], p[8], p[9], p[10], p[11], p[12], p[13], p[14],
            p[15], p[16]), theta_ref, omega, trig)
    return run, (law[0], law[1], law[2], law[3], law[4], law[5], law[6], law[7])


assert N_RIG == 17 and N_LAW == 8, "_run_constants spells out the layouts' lengths"


@njit(**_STEP_FLAGS)
def _dp5_step(mode, t, a, ad, h, f0, p, law, theta_ref, omega, K, S, trig):
    """One step of the core from (t, a, ad) with ``f0 = alpha_ddot(t)`` and ``trig`` the sines and
    cosines there (:func:`_trig_at`). Fills K (7x2) and S (N_MONITOR): the monitored quantities
    ``(g, dpsi, force, dforce, v_r)`` at the step's end, then its ``trig`` (:func:`_stage`).

    Compiled with ``_STEP_FLAGS``; the stages read the parameters as tuples (``_run_constants``).

    Returns (a_new, ad_new, err_a, err_ad)."""
    K[0, 0] = ad
    K[0, 1] = f0
    run, law_t = _run_constants(p, law, theta_ref, omega, trig)
    y1, err = dp5.step(_stage, _begin, mode, t, (a, ad), h, run, law_t, K, _NO_WORK, _NO_WORK, S)
    return y1[0], y1[1], err[0], err[1]


@njit(**_HELPER_FLAGS)
def _dense(x, h, a0, ad0, Q):
    return dp5.dense(x, h, (a0, ad0), Q, _NO_WORK)


@njit(cache=True)
def _event_at(x, args):
    kind, mode, t0, h, a0, ad0, Q, p, law, theta_ref, omega = args
    a, ad = _dense(x, h, a0, ad0, Q)
    return _event_value(kind, mode, t0 + x * h, a, ad, p, law, theta_ref, omega)


@njit(cache=True)
def _root_dense(kind, mode, t0, h, a0, ad0, Q, p, law, theta_ref, omega, g0, g1):
    """Root of an event function on the dense output, as a fraction of the step in [0, 1]."""
    args = (kind, mode, t0, h, a0, ad0, Q, p, law, theta_ref, omega)
    x = dp5.brent(_event_at, args, 0.0, 1.0, g0, g1, max(4e-16, 1e-16 / h), 0)
    return min(max(x, 0.0), 1.0)


@njit(**_STEP_FLAGS)
def _initial_step(mode, t, a, ad, f0, p, law, theta_ref, omega, rtol, atol_a, atol_d, h_max, K, S, trig):
    """The core's starting step (Hairer–Nørsett–Wanner, as scipy's ``select_initial_step``) from
    ``(t, a, ad)``, ``trig`` the sines and cosines there (:func:`_trig_at`).

    ``K`` (7x2) and ``S`` (N_MONITOR) are the caller's scratch arrays: ``K[0]`` and ``K[1]`` are
    overwritten."""
    K[0, 0] = ad
    K[0, 1] = f0
    run, law_t = _run_constants(p, law, theta_ref, omega, trig)
    return dp5.initial_step(_stage, _begin, mode, t, (a, ad), run, law_t, K, _NO_WORK, S, rtol, (atol_a, atol_d),
                            h_max)


# ============================================================================================
# Forward sensitivities
# ============================================================================================

#: Parameters of the forward sensitivities: ``ln beta`` and ``n`` (``beta`` held).
N_SENS = 2
#: The sensitivity arguments of :func:`integrate` for a run without sensitivities.
NO_SENS, NO_SENS_MAX, NO_GRID_SENS = np.zeros((0, 2)), np.zeros(0), np.zeros((0, N_SENS, 2))
_C = dp5.C


@njit(**_STEP_FLAGS)
def _sensitivity_step(mode, t, a, ad, h, K, sens0, sens1, KS, work, p, law, theta_ref, omega, trig):
    """Advance the forward sensitivities over the step just accepted (stages ``K``, 7x2, of the step
    from ``(t, a, ad)`` of length ``h``).

    ``sens0`` (N_SENS x 2): ``d(alpha, alpha_dot)/d(ln beta, n)`` at ``t``; ``sens1`` receives them at
    ``t + h``; ``KS`` (7 x 2 N_SENS) receives their stages (for dense output); ``work`` (2 N_SENS) is scratch;
    ``trig``: the sines and cosines at ``(t, a)`` (:func:`_trig_at`).

    The variational equations ``s' = (s_ad, f_a s_a + f_ad s_ad + f_x)`` (:func:`rhs_partials`) are
    integrated with the same Dormand–Prince tableau, at the same stage states and on the same steps
    as the state: the Runge–Kutta method applied to the augmented system, with the error control on
    the state alone (CVODES's "partial error control"). The state's steps, events and results are
    therefore exactly those of a run without sensitivities, and the sensitivities are the exact
    derivatives of the discrete solution up to the truncation error of the variational equations.

    At a switch between FREE and CONTACT the Hunt–Crossley force is zero on both sides, so the
    right-hand side is continuous and the sensitivities need no jump (saltation) there. Where the
    sliding velocity reverses in a contact with friction the right-hand side does jump, and the
    kernel does not locate that instant as an event: :func:`integrate` then makes the sensitivities
    NaN from there on, and the caller differentiates that run otherwise (finite differences).
    """
    # the stages written out with literal stage numbers, so that the core's ``tableau_combine`` has
    # the tableau's numbers in the code (as in ``dp5.step``); the parameters as tuples of floats
    run, law_t = _run_constants(p, law, theta_ref, omega, trig)
    pt = run[0]
    contact = mode == CONTACT
    trig0 = (trig[0], trig[1], trig[4], trig[2] if contact else 0.0, trig[3] if contact else 1.0)
    y = (a, ad)
    for i in range(work.shape[0]):
        work[i] = 0.0
    _sensitivity_stage(mode, _S[0], a, ad, (0.0, 0.0), work, 0.0, sens0, KS, trig0, pt, law_t, omega)
    _sensitivity_stage(mode, _S[1], a, ad, dp5.tableau_combine(y, K, 1, h, _NO_WORK),
                       dp5.tableau_combine(work, KS, 1, h, work), _C[1] * h, sens0, KS, trig0, pt, law_t, omega)
    _sensitivity_stage(mode, _S[2], a, ad, dp5.tableau_combine(y, K, 2, h, _NO_WORK),
                       dp5.tableau_combine(work, KS, 2, h, work), _C[2] * h, sens0, KS, trig0, pt, law_t, omega)
    _sensitivity_stage(mode, _S[3], a, ad, dp5.tableau_combine(y, K, 3, h, _NO_WORK),
                       dp5.tableau_combine(work, KS, 3, h, work), _C[3] * h, sens0, KS, trig0, pt, law_t, omega)
    _sensitivity_stage(mode, _S[4], a, ad, dp5.tableau_combine(y, K, 4, h, _NO_WORK),
                       dp5.tableau_combine(work, KS, 4, h, work), _C[4] * h, sens0, KS, trig0, pt, law_t, omega)
    _sensitivity_stage(mode, _S[5], a, ad, dp5.tableau_combine(y, K, 5, h, _NO_WORK),
                       dp5.tableau_combine(work, KS, 5, h, work), _C[5] * h, sens0, KS, trig0, pt, law_t, omega)
    dS = dp5.tableau_combine(work, KS, 6, h, work)
    for q in range(sens0.shape[0]):
        sens1[q, 0] = sens0[q, 0] + dS[2 * q]
        sens1[q, 1] = sens0[q, 1] + dS[2 * q + 1]
    _sensitivity_stage(mode, _S[6], a, ad, dp5.tableau_combine(y, K, 6, h, _NO_WORK), dS, h, sens0, KS, trig0, pt,
                       law_t, omega)


@njit(**_STAGE_FLAGS)
def _sensitivity_stage(mode, s, a, ad, d, dS, ch, sens0, KS, trig0, p, law, omega):
    """Row ``s`` of the sensitivities' stages: the variational right-hand side at the stage state
    ``(a, ad) + d`` and time ``t + ch``, for the sensitivities ``sens0 + dS`` (``dS`` flat, 2 per
    parameter)."""
    sa0, ca0, th0, st0, ct0 = trig0
    sa, ca = _sincos_shifted(a, sa0, ca0, d[0])
    if mode == CONTACT:
        st, ct = _sincos_shifted(th0, st0, ct0, omega * ch)
    else:
        st, ct = 0.0, 1.0
    f_a, f_ad, f_lnb, f_n, _, _, _, _ = _partials_trig(mode, ad + d[1], sa, ca, st, ct, p, law, omega)
    for q in range(sens0.shape[0]):
        s_a = sens0[q, 0] + dS[2 * q]
        s_d = sens0[q, 1] + dS[2 * q + 1]
        KS[s, 2 * q] = s_d
        KS[s, 2 * q + 1] = f_a * s_a + f_ad * s_d + (f_lnb if q == 0 else f_n)


@njit(**_HELPER_FLAGS)
def _dense_sensitivity(x, h, sens0, QS, q, component):
    """Sensitivity ``component`` (0: alpha, 1: alpha_dot) of parameter ``q`` at fraction ``x`` of a step."""
    c = 2 * q + component
    return sens0[q, component] + h * x * (QS[c, 0] + x * (QS[c, 1] + x * (QS[c, 2] + x * QS[c, 3])))


# ============================================================================================
# The hybrid integrator
# ============================================================================================


@njit(cache=True)
def initial_mode(t, a, ad, p, law, theta_ref, omega):
    """Mode of a state: in contact if ``psi_i < 0``, or ``psi_i ~ 0`` and approaching."""
    psi = _event_value(_EV_GAP, _FREE, t, a, ad, p, law, theta_ref, omega)
    dpsi = _event_value(_EV_GAPRATE, _FREE, t, a, ad, p, law, theta_ref, omega)
    touching = psi < 0.0 or (abs(psi) <= 1e-15 and dpsi < 0.0)
    if not touching:
        return FREE
    if law[LAW_KIND] == KIND_COMPLIANT:
        return CONTACT
    return STICK  # restitution model: a state inside the cam is projected onto the constraint


@njit(**_HELPER_FLAGS)
def _row_for(n_contacts, capacity, overflow_ok):
    """Row of the contact table for contact number ``n_contacts``; -1 when the table is full
    (with ``overflow_ok`` the last row is reused instead, if the table has at least two)."""
    if n_contacts < capacity:
        return n_contacts
    if overflow_ok and capacity >= 2:
        return capacity - 1
    return -1


@njit(cache=True)
def _open_row(contacts, n_contacts, kind, t, a, ad, dpsi):
    r = n_contacts
    for c in range(N_CCOL):
        contacts[r, c] = np.nan
    contacts[r, C_KIND] = kind
    contacts[r, C_T_START] = t
    contacts[r, C_ALPHA_START] = a
    contacts[r, C_RATE_START] = ad
    contacts[r, C_DPSI_START] = dpsi
    contacts[r, C_PEAK_DELTA] = 0.0
    contacts[r, C_PEAK_FORCE] = -np.inf
    contacts[r, C_FRICTION_REVERSALS] = 0.0


@njit(cache=True)
def _close_row(contacts, r, t, a, ad, dpsi):
    contacts[r, C_T_END] = t
    contacts[r, C_ALPHA_END] = a
    contacts[r, C_RATE_END] = ad
    contacts[r, C_DPSI_END] = dpsi
    if contacts[r, C_DPSI_START] < 0.0:
        contacts[r, C_XI] = -dpsi / contacts[r, C_DPSI_START]


@njit(cache=True)
def integrate(t0, a0, ad0, mode0, t_end, p, law, theta_ref, omega,
              rtol, atol_a, atol_d, h_max, max_steps,
              grid, g_a, g_d, g_mode, contacts, apexes, overflow_ok, sens, sens_max, g_sens):
    """Integrate the hybrid model from ``t0`` to ``t_end``.

    Parameters
    ----------
    t0, a0, ad0, mode0 : initial time [s], state [rad, rad/s] and mode (FREE/CONTACT/STICK;
        -1 to derive it from the state with :func:`initial_mode`).
    t_end : final time [s].
    p, law : packed rig parameters and contact/restitution law (layouts above).
    theta_ref, omega : cam angle ``Theta(t) = theta_ref + omega t`` [rad, rad/s].
    rtol, atol_a, atol_d : error tolerances (relative; absolute for alpha [rad], alpha_dot [rad/s]).
    h_max : largest step [s] (guards against stepping over grazing contacts).
    max_steps : step budget.
    grid : sorted times in [t0, t_end] at which the state is written to g_a, g_d, g_mode.
    contacts : (capacity, N_CCOL) table of contact phases/impacts, filled in order.
    apexes : (capacity, 2) table of local maxima (t, alpha); capacity 0 disables it.
    overflow_ok : when the contact table is full, keep integrating and let the last row take
        each further contact in turn (the first rows and the count stay right); otherwise stop
        with ``CONTACTS_FULL`` so that the caller can grow the table. S1 events use it: a
        chattering trial law still has an ``alpha_m``.
    sens : (N_SENS, 2) forward sensitivities ``d(alpha, alpha_dot)/d(ln beta, n)`` at ``t0`` (zeros for a
        measured initial state), advanced in place to ``t_end`` (:func:`_sensitivity_step`); shape
        (0, 2) for none. Only for the Hunt–Crossley law without friction (the caller checks).
    sens_max : (N_SENS,) receives ``d alpha_max / d(ln beta, n)`` (at an apex ``alpha_dot = 0``, so it
        is the sensitivity of ``alpha`` there); g_sens : (len(grid), N_SENS, 2) receives the
        sensitivities on the grid (shape (0, N_SENS, 2) with no sensitivities).

    Returns
    -------
    :data:`RunEnd` (a named record).
    """
    t = t0
    a = a0
    ad = ad0
    mode = mode0 if mode0 >= 0 else initial_mode(t0, a0, ad0, p, law, theta_ref, omega)
    mode0 = mode
    n_contacts = 0
    n_apexes = 0
    n_steps = 0
    n_rej = 0
    alpha_max = a0
    t_alpha_max = t0
    status = OK
    K = np.empty((7, 2))
    Q = np.empty((2, 4))
    S = np.empty(N_MONITOR)
    restitution = law[LAW_KIND] == KIND_RESTITUTION
    want_sens = sens.shape[0] > 0
    n_sens = sens.shape[0]
    KS = np.empty((7, 2 * n_sens))
    QS = np.empty((2 * n_sens, 4))
    sens_new = np.empty((n_sens, 2))
    sens_work = np.empty(2 * n_sens)
    for q in range(n_sens):
        sens_max[q] = 0.0  # alpha_max starts as alpha(t0), a measured value
    n_grid = grid.shape[0]
    cap_c = contacts.shape[0]
    cap_a = apexes.shape[0]
    gi = 0
    if not (math.isfinite(a0) and math.isfinite(ad0) and math.isfinite(t0) and math.isfinite(t_end)):
        return RunEnd(BAD_INPUT, 0, 0, t, a, ad, mode, alpha_max, t_alpha_max, 0, 0)
    while gi < n_grid and grid[gi] <= t0:
        g_a[gi] = a0
        g_d[gi] = ad0
        g_mode[gi] = mode0
        for q in range(n_sens):
            g_sens[gi, q, 0] = sens[q, 0]
            g_sens[gi, q, 1] = sens[q, 1]
        gi += 1
    open_row = -1
    if mode == CONTACT or mode == STICK:
        if n_contacts >= cap_c:
            return RunEnd(CONTACTS_FULL, n_contacts, n_apexes, t, a, ad, mode, alpha_max, t_alpha_max, 0, 0)
        dpsi0 = _event_value(_EV_GAPRATE, mode, t, a, ad, p, law, theta_ref, omega)
        _open_row(contacts, n_contacts, ROW_COMPLIANT if mode == CONTACT else ROW_STICK, t, a, ad, dpsi0)
        f_start = contact_force(mode, t, a, ad, p, law, theta_ref, omega)
        contacts[n_contacts, C_PEAK_FORCE] = f_start
        contacts[n_contacts, C_T_PEAK_FORCE] = t
        open_row = n_contacts
        n_contacts += 1
    f0 = acceleration(mode, t, a, ad, p, law, theta_ref, omega)
    g0, q0, _, r0, v0 = _snapshot(mode, t, a, ad, f0, p, law, theta_ref, omega)
    trig = _trig_at(mode, t, a, theta_ref, omega)  # then carried from each step's last stage
    h = _initial_step(mode, t, a, ad, f0, p, law, theta_ref, omega, rtol, atol_a, atol_d, h_max, K, S, trig)
    step_rejected = False
    onset = mode == CONTACT  # True until the first accepted step of a compliant contact
    span = t_end - t0
    while t < t_end:
        if n_steps >= max_steps:
            status = MAX_STEPS
            break
        h = min(h, h_max)
        if t + h >= t_end or t_end - (t + h) < 1e-12 * span:
            h = t_end - t
        if h <= 16.0 * 2.2e-16 * max(abs(t), 1e-300):
            status = STEP_UNDERFLOW
            break
        a1, ad1, ea, ed = _dp5_step(mode, t, a, ad, h, f0, p, law, theta_ref, omega, K, S, trig)
        if not (math.isfinite(a1) and math.isfinite(ad1)):
            # treat like a failed step: shrink hard
            h *= 0.1
            n_rej += 1
            step_rejected = True
            if h < 1e-300:
                status = NONFINITE
                break
            continue
        # the squared error norm (dp5.error_norm_squared): error_norm's square and its err <= 1 to an
        # ulp, factors equal to an ulp, and no square root on the chain from one step to the next
        err2 = dp5.error_norm_squared((a, ad), (a1, ad1), (ea, ed), rtol, (atol_a, atol_d))
        if not dp5.accepted_squared(err2):
            if onset:
                # first step of a compliant contact: the force grows like delta^p ~ t^p, so the
                # local error of a step from the onset scales like h^(p+1), not h^5; shrinking with
                # the true exponent lands on an acceptable step at once instead of after ~6 tries
                h *= dp5.shrink_factor_squared(err2, 1.0 / (law[P_EXP] + 1.0), 0.01)
            else:
                h *= dp5.shrink_factor_squared(err2, 1.0 / dp5.ORDER, 0.2)
            n_rej += 1
            step_rejected = True
            continue
        onset = False
        # ---- accepted: look for the event that ends the current mode ------------------------
        factor = dp5.step_factor_squared(err2, step_rejected)
        step_rejected = False
        switch = False
        switch_now = False
        g1, q1, f1, r1, v1 = S[0], S[1], S[2], S[3], S[4]
        # At the surface (g0 on the boundary) the gap rate decides: leaving means no event, and a
        # step that nevertheless ends on the wrong side hides a whole flight (or contact) inside
        # it, so it is rejected and shortened until the crossing can be bracketed properly.
        bracket_fail = False
        if mode == FREE:
            if g0 > 0.0:
                switch = g1 <= 0.0
            elif q0 < 0.0 or (q0 == 0.0 and g1 < 0.0):
                switch_now = True  # touching and approaching
            elif g1 <= 0.0:
                bracket_fail = True
        elif mode == CONTACT:
            if g0 < 0.0:
                switch = g1 >= 0.0
            elif q0 > 0.0 or (q0 == 0.0 and g1 > 0.0):
                switch_now = True  # at the surface and leaving
            elif g1 >= 0.0:
                bracket_fail = True
        else:  # STICK ends when lambda reaches 0 from above
            if g0 > 0.0:
                switch = g1 <= 0.0
            else:
                switch_now = True
        if bracket_fail:
            h *= 0.25
            n_rej += 1
            step_rejected = True
            continue
        if switch_now:
            # no step taken; mode changes at the current state (counted as a step so that a
            # pathological sequence of switches still meets the step budget)
            a1 = a
            ad1 = ad
            h = 0.0
            switch = True
            n_steps += 1
        elif switch:
            term_kind = _EV_LAMBDA if mode == STICK else _EV_GAP
            dp5.dense_coefficients(K, Q)
            x = _root_dense(term_kind, mode, t, h, a, ad, Q, p, law, theta_ref, omega, g0, g1)
            h_ev = x * h
            if h_ev <= 0.0:
                a1 = a
                ad1 = ad
                h = 0.0
            else:
                a1, ad1, ea, ed = _dp5_step(mode, t, a, ad, h_ev, f0, p, law, theta_ref, omega, K, S, trig)
                if term_kind == EV_GAP:
                    g_new, rate = S[0], S[1]  # the gap and its rate (S[0] is the gap in FREE/CONTACT)
                    if g_new != 0.0 and rate != 0.0:
                        h_new = h_ev - g_new / rate
                        if h_new > 0.0 and h_new <= h:
                            a1, ad1, ea, ed = _dp5_step(mode, t, a, ad, h_new, f0, p, law, theta_ref, omega, K, S, trig)
                            h_ev = h_new
                h = h_ev
                g1, q1, f1, r1, v1 = S[0], S[1], S[2], S[3], S[4]
        t1 = t + h if h > 0.0 else t
        if h > 0.0:
            n_steps += 1
            if want_sens:  # K now holds the stages of the step taken (re-integrated to an event)
                _sensitivity_step(mode, t, a, ad, h, K, sens, sens_new, KS, sens_work, p, law, theta_ref, omega,
                                  trig)
            # dense-output coefficients only when this step needs them (events, grid points)
            if (ad > 0.0 and ad1 <= 0.0) or (q0 < 0.0 and q1 >= 0.0) or (r0 > 0.0 and r1 <= 0.0) or (
                    gi < n_grid and grid[gi] <= t1):
                dp5.dense_coefficients(K, Q)
                if want_sens:
                    dp5.dense_coefficients(KS, QS)
            # ---- non-terminal events inside [t, t1] -------------------------------------------
            if ad > 0.0 and ad1 <= 0.0:
                x = _root_dense(_EV_RATE, mode, t, h, a, ad, Q, p, law, theta_ref, omega, ad, ad1)
                ax, adx = _dense(x, h, a, ad, Q)
                if cap_a > 0:
                    if n_apexes >= cap_a:
                        status = APEX_FULL
                        break
                    apexes[n_apexes, 0] = t + x * h
                    apexes[n_apexes, 1] = ax
                    n_apexes += 1
                if ax > alpha_max:
                    alpha_max = ax
                    t_alpha_max = t + x * h
                    for q in range(n_sens):
                        sens_max[q] = _dense_sensitivity(x, h, sens, QS, q, 0)
            if a1 > alpha_max:
                alpha_max = a1
                t_alpha_max = t1
                for q in range(n_sens):
                    sens_max[q] = sens_new[q, 0]
            if mode == CONTACT and open_row >= 0:
                # peak indentation: dpsi crosses 0 upwards
                if -g1 > contacts[open_row, C_PEAK_DELTA]:
                    contacts[open_row, C_PEAK_DELTA] = -g1
                    contacts[open_row, C_T_PEAK_DELTA] = t1
                if q0 < 0.0 and q1 >= 0.0:
                    x = _root_dense(_EV_GAPRATE, mode, t, h, a, ad, Q, p, law, theta_ref, omega, q0, q1)
                    ax, adx = _dense(x, h, a, ad, Q)
                    dx = -_event_value(_EV_GAP, mode, t + x * h, ax, adx, p, law, theta_ref, omega)
                    if dx > contacts[open_row, C_PEAK_DELTA]:
                        contacts[open_row, C_PEAK_DELTA] = dx
                        contacts[open_row, C_T_PEAK_DELTA] = t + x * h
                # peak force: dF/dt crosses 0 downwards
                if f1 > contacts[open_row, C_PEAK_FORCE]:
                    contacts[open_row, C_PEAK_FORCE] = f1
                    contacts[open_row, C_T_PEAK_FORCE] = t1
                if r0 > 0.0 and r1 <= 0.0:
                    x = _root_dense(_EV_DFORCE, mode, t, h, a, ad, Q, p, law, theta_ref, omega, r0, r1)
                    ax, adx = _dense(x, h, a, ad, Q)
                    fx = contact_force(mode, t + x * h, ax, adx, p, law, theta_ref, omega)
                    if fx > contacts[open_row, C_PEAK_FORCE]:
                        contacts[open_row, C_PEAK_FORCE] = fx
                        contacts[open_row, C_T_PEAK_FORCE] = t + x * h
                if p[MU] != 0.0 and (v0 > 0.0) != (v1 > 0.0):
                    contacts[open_row, C_FRICTION_REVERSALS] += 1.0
                    if want_sens:  # the friction force jumped inside this step: see _sensitivity_step
                        sens_new[:, :] = np.nan
                        QS[:, :] = np.nan  # (grid points of this step too)
            elif mode == STICK and open_row >= 0:
                if f1 > contacts[open_row, C_PEAK_FORCE]:
                    contacts[open_row, C_PEAK_FORCE] = f1
                    contacts[open_row, C_T_PEAK_FORCE] = t1
            # ---- dense output on the grid -------------------------------------------------------
            while gi < n_grid and grid[gi] <= t1:
                x = (grid[gi] - t) / h
                ga, gd = _dense(x, h, a, ad, Q)
                g_a[gi] = ga
                g_d[gi] = gd
                g_mode[gi] = mode
                for q in range(n_sens):
                    g_sens[gi, q, 0] = _dense_sensitivity(x, h, sens, QS, q, 0)
                    g_sens[gi, q, 1] = _dense_sensitivity(x, h, sens, QS, q, 1)
                gi += 1
            for q in range(n_sens):
                sens[q, 0] = sens_new[q, 0]
                sens[q, 1] = sens_new[q, 1]
        if h > 0.0:  # the sines and cosines at the new state: the last stage of the step taken computed them
            trig = (S[5], S[6], S[7], S[8], S[9]) if mode != FREE else (S[5], S[6], 0.0, 1.0, S[9])
        t = t1
        a = a1
        ad = ad1
        if not switch:
            f0 = K[6, 1]
            g0, q0, _, r0, v0 = g1, q1, f1, r1, v1
            h = h * factor
            continue
        # ---- mode switch at (t, a, ad) --------------------------------------------------------
        dpsi = _event_value(_EV_GAPRATE, mode, t, a, ad, p, law, theta_ref, omega)
        if mode == FREE:
            row = _row_for(n_contacts, cap_c, overflow_ok)
            if row < 0:
                status = CONTACTS_FULL
                break
            if not restitution:
                _open_row(contacts, row, ROW_COMPLIANT, t, a, ad, dpsi)
                f_start = contact_force(_CONTACT, t, a, ad, p, law, theta_ref, omega)
                contacts[row, C_PEAK_FORCE] = f_start
                contacts[row, C_T_PEAK_FORCE] = t
                open_row = row
                n_contacts += 1
                mode = CONTACT
            else:
                # instantaneous impact (S-27): alpha, Theta keep their values, dpsi -> -xi dpsi
                th = theta_ref + omega * t
                chi = _lever_arm(a, th, p[PE_X], p[PE_Y], p[ECC])
                cam_term = p[ECC] * math.cos(a + th) * omega
                v_a = -dpsi if dpsi < 0.0 else 0.0
                xi = law[XI0] - law[GAMMA] * v_a
                if xi < 0.0:
                    status = XI_NEGATIVE
                    break
                dpsi_after = xi * v_a
                ad_before = ad
                _open_row(contacts, row, ROW_IMPACT, t, a, ad_before, dpsi)
                # a slow enough impact ends in sticking if the constraint force is compressive
                stick = False
                ad_stick = 0.0
                lam = 0.0
                if dpsi_after < law[V_STICK]:
                    ad_stick = cam_term / chi
                    lam = stick_force(t, a, ad_stick, p, theta_ref, omega)
                    stick = lam > 0.0
                ad = ad_stick if stick else (dpsi_after + cam_term) / chi
                _close_row(contacts, row, t, a, ad, 0.0 if stick else dpsi_after)
                contacts[row, C_XI] = xi
                n_contacts += 1
                open_row = -1
                if stick:
                    row = _row_for(n_contacts, cap_c, overflow_ok)
                    if row < 0:
                        status = CONTACTS_FULL
                        break
                    _open_row(contacts, row, ROW_STICK, t, a, ad, 0.0)
                    contacts[row, C_PEAK_FORCE] = lam
                    contacts[row, C_T_PEAK_FORCE] = t
                    open_row = row
                    n_contacts += 1
                    mode = STICK
        else:
            if open_row >= 0:
                _close_row(contacts, open_row, t, a, ad, dpsi)
            open_row = -1
            mode = FREE
        f0 = acceleration(mode, t, a, ad, p, law, theta_ref, omega)
        g0, q0, _, r0, v0 = _snapshot(mode, t, a, ad, f0, p, law, theta_ref, omega)
        h_prev = h
        trig = _trig_at(mode, t, a, theta_ref, omega)  # alpha is unchanged; Theta's are needed out of FREE
        h = _initial_step(mode, t, a, ad, f0, p, law, theta_ref, omega, rtol, atol_a, atol_d, h_max, K, S, trig)
        onset = mode == CONTACT
        if h_prev > 0.0 and mode == FREE:
            h = max(h, min(h_prev, h_max))
    return RunEnd(status, n_contacts, n_apexes, t, a, ad, mode, alpha_max, t_alpha_max, n_steps, n_rej)


# ============================================================================================
# Batch of S1 events x trial laws, in parallel
# ============================================================================================


@njit(cache=True, parallel=True)
def batch_events(states, t_ends, trials, p, law_base, omega, rtol, atol_a, atol_d, h_max,
                 max_steps, grid, grid_offsets, summary, hist_force, hist_gap, contact_capacity, overflow_ok,
                 sens_summary, hist_dforce, hist_dgap):
    """Run every event (rows of ``states`` = alpha, alpha_dot, Theta at t = 0) for every trial
    law (rows of ``trials`` = beta, n), in parallel over the flattened (trial, event) pairs.

    ``summary`` (n_trials, n_events, N_SUM) receives the per-run summary; when ``grid`` is not
    empty, ``hist_force`` / ``hist_gap`` (n_trials, len(grid)) receive the contact force and gap
    on each event's slice ``grid[grid_offsets[i]:grid_offsets[i+1]]`` (times from the event start).
    ``overflow_ok`` is passed to :func:`integrate` (true: a chattering trial fills its table and
    goes on); a run-time flag, not a constant, so that ``integrate`` has one compiled signature.

    Forward sensitivities (Hunt–Crossley without friction): when ``sens_summary`` (n_trials, n_events,
    N_SENS) is not empty in its last axis it receives ``d alpha_m / d(ln beta, n)``, and with a grid
    ``hist_dforce`` / ``hist_dgap`` (n_trials, N_SENS, len(grid)) the derivatives of the histories
    (otherwise pass shapes (n_trials, n_events, 0) and (n_trials, 0, 0)).
    """
    n_ev = states.shape[0]
    n_tr = trials.shape[0]
    want_hist = grid.shape[0] > 0
    n_jobs = n_ev * n_tr
    # Jobs are dealt out round-robin to 64 chunks so that every thread gets a mix of cheap and
    # expensive trial laws (prange splits its range into contiguous blocks); buffers are reused
    # within a chunk.
    n_chunks = min(64, n_jobs)
    for chunk in prange(n_chunks):
        contacts = np.empty((contact_capacity, N_CCOL))
        apexes = np.empty((0, 2))
        law = law_base.copy()
        sens = np.zeros((sens_summary.shape[2], 2))
        for job in range(chunk, n_jobs, n_chunks):
            _batch_job(job, n_ev, states, t_ends, trials, p, law, omega, rtol, atol_a, atol_d, h_max, max_steps,
                       grid, grid_offsets, summary, hist_force, hist_gap, contacts, apexes, want_hist, overflow_ok,
                       sens, sens_summary, hist_dforce, hist_dgap)


@njit(cache=True)
def _batch_job(job, n_ev, states, t_ends, trials, p, law, omega, rtol, atol_a, atol_d, h_max, max_steps,
               grid, grid_offsets, summary, hist_force, hist_gap, contacts, apexes, want_hist, overflow_ok,
               sens, sens_summary, hist_dforce, hist_dgap):
    tr = job // n_ev
    ev = job % n_ev
    law[BETA] = trials[tr, 0]
    law[N_EXP] = trials[tr, 1]
    a0 = states[ev, 0]
    ad0 = states[ev, 1]
    th0 = states[ev, 2]
    if want_hist:
        lo = grid_offsets[ev]
        hi = grid_offsets[ev + 1]
    else:
        lo = 0
        hi = 0
    gt = grid[lo:hi]
    ga = np.empty(hi - lo)
    gd = np.empty(hi - lo)
    gm = np.empty(hi - lo, dtype=np.int8)
    n_sens = sens.shape[0]
    sens[:, :] = 0.0  # the onset state is measured: independent of the law
    sens_max = sens_summary[tr, ev]
    g_sens = np.empty((hi - lo if n_sens > 0 else 0, n_sens, 2))
    mode0 = initial_mode(0.0, a0, ad0, p, law, th0, omega)
    res = integrate(0.0, a0, ad0, mode0, t_ends[ev], p, law, th0, omega, rtol, atol_a, atol_d,
                    h_max, max_steps, gt, ga, gd, gm, contacts, apexes, overflow_ok, sens, sens_max, g_sens)
    st = res.status
    nc = res.n_contacts
    out = summary[tr, ev]
    out[S_ALPHA_M] = res.alpha_max
    out[S_T_ALPHA_M] = res.t_alpha_max
    out[S_N_CONTACTS] = nc
    out[S_ALPHA_END] = res.alpha
    out[S_RATE_END] = res.alpha_dot
    out[S_STATUS] = st
    out[S_N_STEPS] = res.n_steps
    if nc > 0:
        out[S_T_START] = contacts[0, C_T_START]
        out[S_T_END] = contacts[0, C_T_END]
        out[S_DPSI_START] = contacts[0, C_DPSI_START]
        out[S_DPSI_END] = contacts[0, C_DPSI_END]
        out[S_PEAK_FORCE] = contacts[0, C_PEAK_FORCE]
        out[S_PEAK_DELTA] = contacts[0, C_PEAK_DELTA]
    else:
        for c in (S_T_START, S_T_END, S_DPSI_START, S_DPSI_END, S_PEAK_FORCE, S_PEAK_DELTA):
            out[c] = np.nan
    if want_hist and hi > lo:
        obs = np.empty((hi - lo, 6))
        observe(gt, ga, gd, gm, p, law, th0, omega, obs)
        for k in range(hi - lo):
            hist_force[tr, lo + k] = obs[k, 3]
            hist_gap[tr, lo + k] = obs[k, 0]
        for k in range(hi - lo if n_sens > 0 else 0):
            _, _, _, _, force_a, force_ad, force_lnb, force_n = rhs_partials(gm[k], gt[k], ga[k], gd[k], p, law, th0,
                                                                             omega)
            chi = obs[k, 2]
            for q in range(n_sens):
                s_a = g_sens[k, q, 0]
                hist_dforce[tr, q, lo + k] = force_a * s_a + force_ad * g_sens[k, q, 1] + (
                    force_lnb if q == 0 else force_n)
                hist_dgap[tr, q, lo + k] = chi * s_a

"""Validation recordings of rig P made by an independent simulator (plain SciPy, not impactid's).

Why this exists
---------------
impactid identifies the Hunt–Crossley damping (beta, n) and the restitution law of rig P
(Sundar, Dreyer & Singh (2016), an eccentric cam on a pivoted follower) from impact recordings.
If the recordings used to validate it were made by impactid's own compiled simulator, a bias that
the estimator and the data generator share (a sign, a lever arm, a friction convention, an event
or step-size artefact of the compiled kernel) would cancel out and the validation would pass
anyway. The recordings made here come from a separate implementation of the physics,
``tests/rigs/pivoted/reference_rigp.py`` (the model of docs/rig_p.md and docs/estimation.md written out again
with SciPy's
``solve_ivp``, DOP853, event-driven, rtol 1e-12), so such a shared bias shows up as a
disagreement.

What is shared with impactid, and what is not
---------------------------------------------
* Shared: only the container and the acquisition chain: :class:`impactid.io.Recording`,
  :func:`impactid.io.write_hdf5` (with the ``/truth`` group), the rig dataclass that describes the
  rig in the file (``impactid.rigs.SUNDAR2016``; its parameters are checked to equal
  ``reference_params``), and the sensor chain of ``impactid.synth.sensors`` (noise, ADC, accelerometer
  offset/drift, anti-alias decimation, encoder counts), which is not physics.
* Not shared: the equations of motion, the contact and restitution laws, the event handling, the
  integrator, the steady-state search and the formulas of the channels. The accelerometer signal
  ``l_a * alpha_ddot`` uses ``reference_rigp.angular_acceleration``, and the pivot reaction (docs/rig_p.md
  1.4 with the friction term of 1.9) is written out in this module. Nothing here imports
  ``impactid.simulate``, the geometry functions of ``impactid.rigs`` or ``impactid.rigs.pivoted.synth``.

Steady state by shooting, not by settling
-----------------------------------------
impactid's generator runs from static equilibrium and discards a settling time (about 40 s of
simulated time at e/r_c = 0.2, 16 Hz). Here the period-1 steady state is found directly
(:func:`periodic_orbit`). The Poincaré map P takes the follower state ``(alpha, alpha_dot)`` at a
fixed cam phase in free flight to the state one cam revolution ``T = 1 / f`` later. Newton's method
finds its fixed point, with a central-difference Jacobian. The eigenvalues of that Jacobian (the
Floquet multipliers) say whether the orbit is stable. An orbit is refused (:class:`OrbitRefused`,
a ``ValueError``) when it is unstable, when it does not have exactly one contact (impact) per
revolution, or when it chatters or rides on the cam.

Time convention (the same as impactid's synthetic recordings)
-------------------------------------------------------------
The recording's clock gives the cam angle ``Theta(t) = theta_ref + 2 pi f t``, and the
``cam_angle`` channel is exactly that. The first sample is at ``start_time_s``. The integration
starts on the periodic orbit at the last time ``t <= start_time_s`` (less the decimation margin)
at which the cam is at the section phase. The impact times in the truth dict are on this clock.
The steady motion is periodic, so the same ``theta_ref`` and ``start_time_s`` as a settled
impactid recording give the same impact times.

SI units throughout (m, s, kg, N, rad).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from impactid.io import CHANNEL_UNITS, Recording, write_hdf5
from impactid.rigs import SUNDAR2016
from impactid.synth.sensors import SensorModel, antialias_decimate, apply_sensors, encoder_counts
from tests.rigs.pivoted import reference_rigp as R

__all__ = [
    "GENERATOR",
    "ALL_CHANNELS",
    "OrbitRefused",
    "PeriodicOrbit",
    "periodic_orbit",
    "pivot_reaction",
    "reference_recording",
    "write_reference_recording",
]

GENERATOR = "reference solve_ivp (tests/rigs/pivoted/reference_recordings.py)"
ALL_CHANNELS = ("accel_tangential", "force_x", "force_y", "cam_angle")
TWO_PI = 2.0 * math.pi
#: Samples simulated beyond each end when decimating (the FIR filter's edge zone), output samples.
DECIMATION_MARGIN = 64
#: A contact that lasts longer than this fraction of a revolution is not an impact: the follower
#: rides on the cam (the compliant model's form of sticking).
MAX_CONTACT_FRACTION = 0.05
#: Rig parameters whose values must be identical in the impactid rig and ``reference_params``.
_RIG_KEYS = ("m_b", "I_b", "l_g", "l_a", "w_b", "r_d", "r_c", "e", "k_s", "L_s_u", "d_x", "d_y", "PE_x",
             "PE_y", "Y_c", "Y_b", "nu_c", "nu_b", "g")


class OrbitRefused(ValueError):
    """No usable period-1 orbit: ``reason`` says why; ``orbit`` holds what was found (or None)."""

    def __init__(self, reason: str, orbit: PeriodicOrbit | None = None):
        super().__init__(reason)
        self.reason = reason
        self.orbit = orbit


# ---------------------------------------------------------------------------------------------
# Laws
# ---------------------------------------------------------------------------------------------
def _law(law: dict) -> dict:
    """Normalise a law dict: ``{"kind": "hunt-crossley", "beta", "n"[, "clip"]}`` or
    ``{"kind": "restitution", "gamma"[, "xi0"]}``."""
    if not isinstance(law, dict) or "kind" not in law:
        raise ValueError(f"law must be a dict with a 'kind', got {law!r}")
    kind = str(law["kind"]).lower()
    if kind in ("hunt-crossley", "hunt_crossley", "hc"):
        out = {"kind": "hunt-crossley", "beta": float(law["beta"]), "n": float(law["n"]),
               "clip": bool(law.get("clip", False))}
        if not (out["beta"] >= 0.0 and math.isfinite(out["beta"]) and out["n"] >= 0.0):
            raise ValueError(f"Hunt-Crossley law needs beta >= 0 and n >= 0, got {law!r}")
        return out
    if kind == "restitution":
        out = {"kind": "restitution", "gamma": float(law["gamma"]), "xi0": float(law.get("xi0", 1.0))}
        if not (math.isfinite(out["gamma"]) and out["gamma"] >= 0.0 and 0.0 < out["xi0"] <= 1.0):
            raise ValueError(f"restitution law needs gamma >= 0 and 0 < xi0 <= 1, got {law!r}")
        return out
    raise ValueError(f"unknown law kind {law['kind']!r} (expected 'hunt-crossley' or 'restitution')")


def _run(p, law, mu, state, theta0, cam_speed_hz, duration, rtol, atol):
    """Run the reference model for ``duration`` from ``state`` with the cam at ``theta0``.

    Returns (final state, list of contact/impact dicts with times relative to the start, raw run).
    Errors of the reference model (restitution chatter, xi < 0, no progress) become OrbitRefused.
    """
    a0, ad0 = float(state[0]), float(state[1])
    try:
        if law["kind"] == "hunt-crossley":
            run = R.run_hybrid(a0, ad0, theta0, cam_speed_hz, duration, p, law["beta"], law["n"], mu,
                               clip=law["clip"], rtol=rtol, atol=atol)
            events = run["contacts"]
        else:
            run = R.run_restitution(a0, ad0, theta0, cam_speed_hz, duration, p, law["xi0"], law["gamma"],
                                    rtol=rtol, atol=atol)
            events = run["impacts"]
    except (RuntimeError, ValueError) as exc:
        raise OrbitRefused(f"the reference model failed ({exc}); the motion chatters or leaves the law's "
                           "range") from exc
    return np.array(run["final"], dtype=float), events, run


# ---------------------------------------------------------------------------------------------
# Period-1 orbit by shooting
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class PeriodicOrbit:
    """A period-1 orbit of rig P found by shooting (see :func:`periodic_orbit`).

    Attributes
    ----------
    state : fixed point ``(alpha [rad], alpha_dot [rad/s])`` of the Poincaré map.
    section_phase : cam angle ``Theta`` of the Poincaré section [rad], in [0, 2 pi); the follower
        is in free flight there.
    cam_speed_hz, period : cam speed [Hz] and revolution time ``T = 1 / f`` [s].
    law, mu : the contact law (normalised dict) and friction coefficient.
    multipliers : Floquet multipliers (eigenvalues of the map Jacobian), complex, by modulus.
    jacobian : the 2x2 map Jacobian at the fixed point (central differences).
    residual : ``P(state) - state`` (rad, rad/s), the fixed point's tolerance.
    contacts_per_revolution : contact phases (Hunt–Crossley) or impacts (restitution) in one revolution.
    contacts : those contacts/impacts as the reference model reports them, times relative to the section.
    newton_iterations, map_evaluations : effort spent.
    """

    state: np.ndarray
    section_phase: float
    cam_speed_hz: float
    period: float
    law: dict
    mu: float
    multipliers: np.ndarray
    jacobian: np.ndarray
    residual: np.ndarray
    contacts_per_revolution: int
    contacts: list = field(repr=False)
    newton_iterations: int = 0
    map_evaluations: int = 0
    rtol: float = 1e-12
    atol: float = 1e-15

    @property
    def spectral_radius(self) -> float:
        """Largest Floquet multiplier modulus (below 1: stable)."""
        return float(np.max(np.abs(self.multipliers)))

    @property
    def stable(self) -> bool:
        return self.spectral_radius < 1.0

    def residual_norm(self) -> float:
        """Map residual in angle units: ``max(|d alpha|, |d alpha_dot| T / 2 pi)`` [rad]."""
        return _scaled_norm(self.residual, self.period)

    def summary(self) -> str:
        m = ", ".join(f"{z.real:.6g}{z.imag:+.3g}j" if abs(z.imag) > 0 else f"{z.real:.6g}"
                      for z in self.multipliers)
        return (f"period-1 orbit at {self.cam_speed_hz:g} Hz: alpha = {self.state[0]:.12g} rad, "
                f"alpha_dot = {self.state[1]:.12g} rad/s at Theta = {self.section_phase:.6g} rad; "
                f"multipliers [{m}] (|max| {self.spectral_radius:.6g}); "
                f"{self.contacts_per_revolution} contact(s) per revolution; map residual "
                f"{self.residual_norm():.3g} rad")


def _scaled_norm(dx, period):
    """max(|d alpha|, |d alpha_dot| * T / 2 pi): a rate error in rad per radian of cam angle."""
    return float(max(abs(dx[0]), abs(dx[1]) * period / TWO_PI))


def _section_phase_from(events, law, cam_speed_hz, theta0, t_from):
    """Middle of the longest contact-free arc of cam angle among ``events`` after ``t_from``."""
    W = TWO_PI * cam_speed_hz
    arcs = []
    for c in events:
        if law["kind"] == "hunt-crossley":
            t0, t1 = c["t_start"], c["t_end"]
            if not math.isfinite(t1):
                continue
        else:
            t0 = t1 = c["t"]
        if t0 >= t_from:
            arcs.append(((theta0 + W * t0) % TWO_PI, (theta0 + W * t1) % TWO_PI))
    if not arcs:
        raise OrbitRefused("no contact in the last warm-up revolution: the follower does not reach the cam")
    starts = sorted(a for a, _ in arcs)
    # the free arcs lie between consecutive contact starts (contacts are short); take the longest
    gaps = [(starts[(k + 1) % len(starts)] - starts[k]) % TWO_PI or TWO_PI for k in range(len(starts))]
    k = int(np.argmax(gaps))
    ends = {a: b for a, b in arcs}
    lo = ends[starts[k]]
    hi = starts[(k + 1) % len(starts)]
    arc = (hi - lo) % TWO_PI or TWO_PI
    return (lo + 0.5 * arc) % TWO_PI


def periodic_orbit(p: dict, cam_speed_hz: float, law: dict, mu: float = 0.2, *, guess=None,
                   section_phase: float | None = None, warmup_revolutions: int = 10, max_newton: int = 25,
                   tol: float = 1e-13, accept_tol: float = 1e-10, fd_step=(1e-6, 1e-4), rtol: float = 1e-12,
                   atol: float = 1e-15, max_contact_fraction: float = MAX_CONTACT_FRACTION) -> PeriodicOrbit:
    """Period-1 steady state of rig P by shooting on the one-revolution Poincaré map.

    The map takes the follower state ``(alpha, alpha_dot)`` at cam angle ``Theta = section_phase``
    (in free flight) to the state one revolution ``T = 1 / cam_speed_hz`` later, integrated by
    ``reference_rigp.run_hybrid`` (Hunt–Crossley) or ``reference_rigp.run_restitution`` at
    ``rtol`` (default 1e-12, like the reference) and ``atol`` 1e-15. Newton's method on
    ``P(x) - x = 0`` uses a central-difference Jacobian (steps ``fd_step`` = (d alpha [rad],
    d alpha_dot [rad/s])) and halves a step that does not reduce the residual.

    Start: ``guess`` (a state at ``section_phase``), or else ``warmup_revolutions`` revolutions
    run from static equilibrium with the cam at Theta = 0 (docs/estimation.md; for the restitution law
    the follower starts on the cam surface at rest, there being no indentation). Without a
    ``section_phase``, the section is the middle of the longest contact-free arc of the last
    warm-up revolution.

    Tolerance of the fixed point: Newton stops when the map residual
    ``max(|d alpha|, |d alpha_dot| T / 2 pi)`` is below ``tol`` (1e-13 rad) or stops decreasing,
    and the orbit is refused if the residual is still ``accept_tol`` (1e-10 rad) or more. That
    floor is set by the integration error of one revolution at rtol 1e-12. Measured at e/r_c
    0.25, 15 Hz and 0.2, 16 Hz (beta 24.7e9, n 1.5, mu 0.2), the residual ``P(x*) - x*`` is about
    1e-14 rad in alpha and 1e-13 rad/s in alpha_dot (3-6 Newton iterations, 3-5 s). The result
    carries the residual (``PeriodicOrbit.residual``). The computed map is not smooth below its
    integration error, so the fixed point itself is determined to about 1e-12 rad and 2e-11
    rad/s (Newton runs from different starts close that far apart). The multipliers come from
    the central-difference Jacobian at the fixed point and are good to about 1e-5.

    Raises :class:`OrbitRefused` (a ``ValueError``) with the reason when Newton does not
    converge, the orbit is unstable (a multiplier of modulus >= 1; one below -1 means a
    period-doubling: the steady motion is period-2 or longer), the revolution has no contact or
    more than one (chatter), a contact lasts longer than ``max_contact_fraction`` of a revolution
    (riding on the cam), or the reference model fails (restitution chatter, xi < 0).
    The refused orbit, when there is one, is in the exception's ``orbit``.
    """
    law = _law(law)
    f = float(cam_speed_hz)
    if not (math.isfinite(f) and f > 0.0):
        raise ValueError(f"cam speed must be positive, got {cam_speed_hz!r} Hz")
    mu = float(mu)
    T = 1.0 / f
    W = TWO_PI * f
    n_eval = 0

    # ---- start ------------------------------------------------------------------------------
    if guess is None or section_phase is None:
        if guess is not None:
            raise ValueError("a guess needs its section_phase")
        if law["kind"] == "hunt-crossley":
            start = (R.static_equilibrium(0.0, p), 0.0)
        else:
            start = (R.contact_angle(0.0, p), 0.0)
        n_warm = max(int(warmup_revolutions), 2)
        x_end, events, _ = _run(p, law, mu, start, 0.0, f, n_warm * T, rtol, atol)
        if section_phase is None:
            section_phase = _section_phase_from(events, law, f, 0.0, (n_warm - 1) * T)
        section_phase = float(section_phase) % TWO_PI
        # from Theta = 2 pi n_warm (= 0) on to the section phase
        x, _, _ = _run(p, law, mu, x_end, 0.0, f, section_phase / W, rtol, atol)
    else:
        section_phase = float(section_phase) % TWO_PI
        x = np.array(guess, dtype=float)

    def pmap(y):
        nonlocal n_eval
        n_eval += 1
        y_end, ev, _ = _run(p, law, mu, y, section_phase, f, T, rtol, atol)
        return y_end, ev

    h = np.array(fd_step, dtype=float)

    def jacobian(y):
        J = np.empty((2, 2))
        for j in range(2):
            d = np.zeros(2)
            d[j] = h[j]
            J[:, j] = (pmap(y + d)[0] - pmap(y - d)[0]) / (2.0 * h[j])
        return J

    # ---- Newton -----------------------------------------------------------------------------
    px, _ = pmap(x)
    r = px - x
    rn = _scaled_norm(r, T)
    it = 0
    while rn >= tol and it < max_newton:
        it += 1
        J = jacobian(x)
        try:
            dx = -np.linalg.solve(J - np.eye(2), r)
        except np.linalg.LinAlgError:
            raise OrbitRefused(f"Newton failed: P' - I is singular at iteration {it} "
                               "(a multiplier equals 1)") from None
        lam = 1.0
        for _ in range(8):
            x_try = x + lam * dx
            px_try, _ = pmap(x_try)
            r_try = px_try - x_try
            rn_try = _scaled_norm(r_try, T)
            if rn_try < rn:
                break
            lam *= 0.5
        else:
            break  # no decrease along the Newton direction: at the integration noise floor (or lost)
        x, r, rn = x_try, r_try, rn_try
    if rn >= accept_tol:
        raise OrbitRefused(f"Newton did not converge to a period-1 orbit at {f:g} Hz after {it} iterations "
                           f"(map residual {rn:.3g} rad); the steady motion may not be period-1")

    # ---- the orbit: multipliers, contacts per revolution --------------------------------------
    J = jacobian(x)
    mult = np.linalg.eigvals(J)
    mult = mult[np.argsort(-np.abs(mult))]
    _, events = pmap(x)
    orbit = PeriodicOrbit(state=x.copy(), section_phase=section_phase, cam_speed_hz=f, period=T, law=law,
                          mu=mu, multipliers=mult, jacobian=J, residual=r.copy(),
                          contacts_per_revolution=len(events), contacts=events, newton_iterations=it,
                          map_evaluations=n_eval, rtol=rtol, atol=atol)
    psi_s = float(R.gap(x[0], section_phase, p))
    where = f"e/r_c = {p['e_over_rc']:g}, {f:g} Hz"
    if psi_s <= 0.0:
        raise OrbitRefused(f"{where}: the orbit is in contact at the section phase (psi_i = {psi_s:.3g} m): "
                           "the follower rides on the cam", orbit)
    if len(events) == 0:
        raise OrbitRefused(f"{where}: no contact in a revolution of the orbit", orbit)
    if len(events) > 1:
        raise OrbitRefused(f"{where}: {len(events)} contacts per revolution (chatter or multiple impacts), "
                           "not a period-1 single-impact orbit", orbit)
    if law["kind"] == "hunt-crossley":
        dur = events[0]["t_end"] - events[0]["t_start"]
        if not math.isfinite(dur) or dur > max_contact_fraction * T:
            raise OrbitRefused(f"{where}: the contact lasts {dur:.3g} s, more than {max_contact_fraction:g} of a "
                               "revolution: the follower rides on (sticks to) the cam, not an impact", orbit)
    if not orbit.stable:
        kinds = []
        if np.any((np.abs(mult.imag) < 1e-12) & (mult.real <= -1.0)):
            kinds.append("a multiplier below -1: period-doubling, the steady motion is period-2 or longer")
        if np.any((np.abs(mult.imag) < 1e-12) & (mult.real >= 1.0)):
            kinds.append("a multiplier above +1")
        if np.any((np.abs(mult.imag) >= 1e-12) & (np.abs(mult) >= 1.0)):
            kinds.append("a complex pair outside the unit circle: quasi-periodic or longer-period motion")
        raise OrbitRefused(f"{where}: the period-1 orbit is unstable, Floquet multipliers "
                           f"{np.array2string(mult, precision=6)} (|max| = {orbit.spectral_radius:.6g} >= 1; "
                           f"{'; '.join(kinds)})", orbit)
    return orbit


# ---------------------------------------------------------------------------------------------
# Channels (docs/formats.md)
# ---------------------------------------------------------------------------------------------
def pivot_reaction(p, alpha, alpha_dot, alpha_ddot, contact_force, friction):
    """Pivot reaction on the follower ``(N_x, N_y)`` [N], docs/rig_p.md with the friction of 1.9.

    Newton's law for the bar (CG at ``r_G = l_g u(alpha)``)::

        N = m_b r_G_ddot - F_s e_y + m_b g e_y + F_lam n(alpha) + F_f u(alpha)
        r_G_ddot = -l_g alpha_ddot n(alpha) - l_g alpha_dot^2 u(alpha)

    with ``u = (cos a, -sin a)``, ``n = (sin a, cos a)``. ``friction`` is the signed magnitude
    ``F_f = mu F_lam sgn(v_r)``: the friction force on the follower is ``-F_f u``, so the pivot
    supplies ``+F_f u``.
    """
    sa, ca = np.sin(alpha), np.cos(alpha)
    ux, uy = ca, -sa
    nx, ny = sa, ca
    m, lg = p["m_b"], p["l_g"]
    Fs = R.spring_force(alpha, p)
    rgx = -lg * alpha_ddot * nx - lg * alpha_dot ** 2 * ux
    rgy = -lg * alpha_ddot * ny - lg * alpha_dot ** 2 * uy
    fx = m * rgx + contact_force * nx + friction * ux
    fy = m * rgy - Fs + m * p["g"] + contact_force * ny + friction * uy
    return fx, fy


def _physics(p, law, mu, W, theta, alpha, alpha_dot, in_contact):
    """alpha_ddot, contact force, friction, gap at the given states (vectorised)."""
    beta, n = (law["beta"], law["n"]) if law["kind"] == "hunt-crossley" else (0.0, 1.0)
    clip = law.get("clip", False)
    add = np.asarray(R.angular_acceleration(alpha, alpha_dot, theta, W, p, beta, n, mu, False), dtype=float)
    force = np.zeros_like(add)
    friction = np.zeros_like(add)
    c = np.asarray(in_contact, dtype=bool)
    if law["kind"] == "hunt-crossley" and np.any(c):
        a, ad, th = alpha[c], alpha_dot[c], theta[c]
        add[c] = R.angular_acceleration(a, ad, th, W, p, beta, n, mu, True, clip=clip)
        force[c] = R.contact_force(a, ad, th, W, p, beta, n, clip=clip)
        friction[c] = mu * force[c] * np.sign(R.relative_sliding_velocity(a, ad, th, W, p))
    return add, force, friction, np.asarray(R.gap(alpha, theta, p), dtype=float)


# ---------------------------------------------------------------------------------------------
# Dense trajectories over a recording
# ---------------------------------------------------------------------------------------------
def _restitution_dense(p, law, state, theta0, cam_speed_hz, t_end, rtol, atol):
    """run_restitution for the impacts, then each free flight between them again with dense output.

    The free flights use the reference's own right-hand side (``reference_rigp._make_kernels``)
    from each post-impact state; the state reached at the next impact is checked against
    run_restitution's.
    """
    _, impacts, run = _run(p, law, 0.0, state, theta0, cam_speed_hz, t_end, rtol, atol)
    W = TWO_PI * cam_speed_hz
    rhs = R._make_kernels(p, theta0, W, 0.0, 1.0, 0.0, False)["rhs_free"]
    bounds = [0.0] + [imp["t"] for imp in impacts] + [t_end]
    starts = [np.array(state, dtype=float)] + [np.array([imp["alpha"], imp["alpha_dot_after"]]) for imp in impacts]
    segments = []
    for k in range(len(bounds) - 1):
        t0, t1 = bounds[k], bounds[k + 1]
        if t1 <= t0:
            continue
        sol = solve_ivp(rhs, (t0, t1), starts[k], method="DOP853", rtol=rtol, atol=atol, dense_output=True)
        if sol.status != 0:
            raise RuntimeError("solve_ivp failed: " + str(sol.message))
        if k < len(impacts):
            y1 = sol.y[:, -1]
            imp = impacts[k]
            ref = np.array([imp["alpha"], imp["alpha_dot_before"]])
            if np.any(np.abs(y1 - ref) > 1e-8 * (1.0 + np.abs(ref))):
                raise AssertionError(f"free flight re-integration disagrees with run_restitution at t = {t1}: "
                                     f"{y1} vs {ref}")
        segments.append((t0, t1, sol.sol))

    def evaluate(t_array):
        tt = np.atleast_1d(np.asarray(t_array, dtype=float))
        A = np.full(tt.shape, np.nan)
        AD = np.full(tt.shape, np.nan)
        # an impact instant belongs to the flight before it (state before the jump)
        idx = np.searchsorted([s[0] for s in segments], tt, side="left") - 1
        idx = np.clip(idx, 0, len(segments) - 1)
        for k in np.unique(idx):
            m = idx == k
            yy = segments[k][2](tt[m])
            A[m], AD[m] = yy[0], yy[1]
        return A, AD, np.zeros(tt.shape, dtype=bool)

    return impacts, evaluate, run


def _apexes(evaluate, tau, alpha_dot):
    """Local maxima of alpha: alpha_dot crossing zero downwards, refined with brentq."""
    k = np.flatnonzero((alpha_dot[:-1] > 0.0) & (alpha_dot[1:] <= 0.0))
    t_out, a_out = [], []
    for i in k:
        def rate(t):
            return float(evaluate(t)[1][0])
        lo, hi = tau[i], tau[i + 1]
        t_m = brentq(rate, lo, hi, xtol=1e-15, rtol=4 * np.finfo(float).eps) if rate(hi) < 0.0 else hi
        t_out.append(t_m)
        a_out.append(float(evaluate(t_m)[0][0]))
    return np.array(t_out), np.array(a_out)


def _check_rig(rig, p):
    rd = rig.to_dict()
    bad = [k for k in _RIG_KEYS if rd[k] != p[k]]
    derived = {"k_H": rig.k_H, "h_p": rig.h_p}
    bad += [k for k, v in derived.items() if not math.isclose(v, p[k], rel_tol=1e-14)]
    if bad:
        raise AssertionError("impactid's SUNDAR2016 and reference_params disagree on "
                             + ", ".join(f"{k} ({rd.get(k, derived.get(k))!r} vs {p[k]!r})" for k in bad))


def reference_recording(e_over_rc: float, cam_speed_hz: float, law: dict, *, mu: float = 0.2,
                        duration: float = 1.0, sample_rate_hz: float = 204800.0,
                        sensors: SensorModel | None = None, theta_ref: float = 0.0, start_time_s: float = 0.0,
                        channels: tuple[str, ...] = ALL_CHANNELS, orbit: PeriodicOrbit | None = None,
                        rtol: float = 1e-12, atol: float = 1e-15) -> tuple[Recording, dict[str, Any]]:
    """A recording of rig P on its stable period-1 orbit, made by the independent reference model.

    Parameters
    ----------
    e_over_rc, cam_speed_hz : operating point (eccentricity ratio, cam speed [Hz]).
    law : ``{"kind": "hunt-crossley", "beta": ..., "n": ...}`` (S2) or
        ``{"kind": "restitution", "gamma": ..., "xi0": 1.0}`` (S3).
    mu : Coulomb friction coefficient at the contact (also written into the recording's rig).
    duration, sample_rate_hz : recorded time [s] and sample rate [Hz]; ``round(duration * rate)`` samples.
    sensors : :class:`impactid.synth.sensors.SensorModel` (default: none, exact signals at the sample instants).
    theta_ref, start_time_s : the recording's clock: ``Theta(t) = theta_ref + 2 pi f t``; the first
        sample is at ``start_time_s``.
    channels : which of ``accel_tangential``, ``force_x``, ``force_y``, ``cam_angle`` to write.
    orbit : a :class:`PeriodicOrbit` found before (skips the search); else :func:`periodic_orbit`.

    Returns ``(recording, truth)``. ``truth`` has the layout of ``impactid.synth.synth_pivoted``'s
    (law, beta/n or gamma/xi0, mu, e_over_rc, cam_speed_hz, theta_ref, sample_rate_hz, sensors, applied,
    exact ``t, alpha, alpha_dot, mode, contact_force, gap, alpha_ddot`` at the samples, ``impacts``
    with ``t_start, t_end, gap_rate_start, gap_rate_end, peak_force, peak_indentation, alpha_*,
    alpha_dot_*, xi``, apexes) plus ``generator``, ``orbit`` (fixed point, multipliers, map residual)
    and the clock (``start_time_s``, ``integration_start_s``). For the restitution law
    ``t_end = t_start`` and the peak force and indentation are NaN (instantaneous impacts).

    Raises :class:`OrbitRefused` where the operating point has no stable period-1 orbit.
    """
    sensors = SensorModel() if sensors is None else sensors
    law = _law(law)
    unknown = sorted(set(channels) - set(ALL_CHANNELS))
    if unknown:
        raise ValueError(f"unknown channel(s) {', '.join(unknown)}; rig P records {', '.join(ALL_CHANNELS)}")
    if not (math.isfinite(duration) and duration > 0.0):
        raise ValueError(f"duration must be positive, got {duration!r} s")
    if not (math.isfinite(sample_rate_hz) and sample_rate_hz > 0.0):
        raise ValueError(f"sample_rate_hz must be positive, got {sample_rate_hz!r}")
    f = float(cam_speed_hz)
    W = TWO_PI * f
    mu = float(mu)
    p = R.reference_params(e_over_rc)
    p["mu"] = mu
    rig = SUNDAR2016.with_eccentricity_ratio(e_over_rc)
    if rig.mu != mu:
        rig = rig.replace(mu=mu)
    _check_rig(rig, p)

    if orbit is None:
        orbit = periodic_orbit(p, f, law, mu, rtol=rtol, atol=atol)
    elif orbit.cam_speed_hz != f or orbit.law != law or orbit.mu != mu:
        raise ValueError("the supplied orbit was found for another cam speed, law or mu")

    # ---- time grid (recording clock) and integration start on the orbit ----------------------
    q = int(sensors.decimation)
    n = int(round(duration * sample_rate_hz))
    margin = DECIMATION_MARGIN if q > 1 else 0
    fine_rate = q * sample_rate_hz
    j = np.arange(-margin * q, (n + margin) * q)
    t_fine = start_time_s + j / fine_rate
    lead = margin * q  # fine samples before the first output sample
    # last time <= t_fine[0] at which Theta = section phase (mod 2 pi)
    lag = math.fmod(theta_ref + W * t_fine[0] - orbit.section_phase, TWO_PI) % TWO_PI
    t_int0 = float(t_fine[0]) - lag / W
    tau = t_fine - t_int0  # time since the integration start
    t_run = float(tau[-1]) + 1.0 / fine_rate

    if law["kind"] == "hunt-crossley":
        _, contacts, run = _run(p, law, mu, orbit.state, orbit.section_phase, f, t_run, rtol, atol)
        evaluate = run["evaluate"]
    else:
        contacts, evaluate, run = _restitution_dense(p, law, orbit.state, orbit.section_phase, f, t_run, rtol,
                                                     atol)

    alpha, alpha_dot, in_contact = evaluate(tau)
    if not (np.all(np.isfinite(alpha)) and np.all(np.isfinite(alpha_dot))):
        raise RuntimeError("dense output does not cover the sample instants")
    theta_phys = orbit.section_phase + W * tau  # the integration's cam angle (= the clock's, mod 2 pi)
    add, force, friction, psi = _physics(p, law, mu, W, theta_phys, alpha, alpha_dot, in_contact)
    fx, fy = pivot_reaction(p, alpha, alpha_dot, add, force, friction)
    exact = {"accel_tangential": p["l_a"] * add, "force_x": fx, "force_y": fy,
             "cam_angle": theta_ref + W * t_fine}

    if law["kind"] == "restitution":  # impulses over the two fine samples around each impact (docs/estimation.md)
        for imp in contacts:
            x = (imp["t"] - tau[0]) * fine_rate  # fine-sample position of the impact
            k = int(math.floor(x))
            w = x - k
            jump = imp["alpha_dot_after"] - imp["alpha_dot_before"]
            chi = float(R.lever_arm(imp["alpha"], orbit.section_phase + W * imp["t"], p))
            impulse = (-p["m_b"] * p["l_g"] + p["I_b"] / chi) * jump
            areas = {"accel_tangential": p["l_a"] * jump, "force_x": impulse * math.sin(imp["alpha"]),
                     "force_y": impulse * math.cos(imp["alpha"])}
            for name, area in areas.items():
                if 0 <= k < t_fine.size:
                    exact[name][k] += (1.0 - w) * area * fine_rate
                if 0 <= k + 1 < t_fine.size:
                    exact[name][k + 1] += w * area * fine_rate

    # ---- sensor chain (shared with impactid's generator: not physics) ------------------------
    sample_index = slice(lead, lead + n * q, q)
    clean: dict[str, np.ndarray] = {}
    for name in channels:
        x = exact[name]
        if q == 1 or name == "cam_angle":
            clean[name] = x[sample_index].copy()
        else:
            clean[name] = antialias_decimate(x, q)[margin:margin + n]
    rng = np.random.default_rng(sensors.seed)
    measured, applied = apply_sensors({k: v for k, v in clean.items() if k != "cam_angle"}, sample_rate_hz,
                                      sensors, rng)
    if "cam_angle" in channels:
        cam = clean["cam_angle"]
        if sensors.cam_encoder_ppr is not None:
            cam = encoder_counts(cam, int(sensors.cam_encoder_ppr))
            applied["cam_angle"] = {"encoder_ppr": int(sensors.cam_encoder_ppr)}
        measured["cam_angle"] = cam
    measured = {name: measured[name] for name in channels}

    t_samples = t_fine[sample_index]
    law_text = (f"hunt-crossley beta = {law['beta']:.6g}, n = {law['n']:g}" if law["kind"] == "hunt-crossley"
                else f"restitution gamma = {law['gamma']:g}, xi0 = {law['xi0']:g}")
    recording = Recording(
        channels=measured, sample_rate_hz=sample_rate_hz, units={k: CHANNEL_UNITS[k] for k in measured},
        rig=rig, operating={"cam_speed_hz": f, "eccentricity_m": rig.e}, start_time_s=float(start_time_s),
        provenance=(f"{GENERATOR}: {law_text}, mu = {mu:g}, {f:g} Hz, e/r_c = {float(e_over_rc):g}, "
                    f"period-1 orbit (multipliers |max| {orbit.spectral_radius:.4g})",))

    # ---- truth -------------------------------------------------------------------------------
    t_lo, t_hi = float(start_time_s), float(start_time_s) + n / sample_rate_hz
    rows = []
    if law["kind"] == "hunt-crossley":
        for c in contacts:
            ts = c["t_start"] + t_int0
            if not (t_lo <= ts < t_hi):
                continue
            a_s, ad_s, _ = evaluate([c["t_start"]])
            a_e, ad_e, _ = evaluate([c["t_end"]])
            rows.append(dict(t_start=ts, t_end=c["t_end"] + t_int0, gap_rate_start=c["dpsi_start"],
                             gap_rate_end=c["dpsi_end"], peak_force=c["peak_force"],
                             peak_indentation=c["peak_indentation"], t_peak_force=c["t_peak_force"] + t_int0,
                             alpha_start=a_s[0], alpha_dot_start=ad_s[0], alpha_end=a_e[0], alpha_dot_end=ad_e[0],
                             xi=-c["dpsi_end"] / c["dpsi_start"]))
    else:
        for imp in contacts:
            ts = imp["t"] + t_int0
            if not (t_lo <= ts < t_hi):
                continue
            rows.append(dict(t_start=ts, t_end=ts, gap_rate_start=-imp["v_a"], gap_rate_end=imp["xi"] * imp["v_a"],
                             peak_force=math.nan, peak_indentation=math.nan, t_peak_force=math.nan,
                             alpha_start=imp["alpha"], alpha_dot_start=imp["alpha_dot_before"],
                             alpha_end=imp["alpha"], alpha_dot_end=imp["alpha_dot_after"], xi=imp["xi"]))
    cols = ("t_start", "t_end", "gap_rate_start", "gap_rate_end", "peak_force", "peak_indentation", "t_peak_force",
            "alpha_start", "alpha_dot_start", "alpha_end", "alpha_dot_end", "xi")
    impacts = {col: np.array([r_[col] for r_ in rows], dtype=float) for col in cols}
    t_apex, a_apex = _apexes(evaluate, tau, alpha_dot)
    t_apex = t_apex + t_int0
    keep = (t_apex >= t_lo) & (t_apex < t_hi)
    si = sample_index
    truth: dict[str, Any] = {
        "generator": GENERATOR,
        "model": "S2" if law["kind"] == "hunt-crossley" else "S3",
        "cam_speed_hz": f,
        "e_over_rc": float(e_over_rc),
        "mu": mu,
        "theta_ref": float(theta_ref),
        "start_time_s": float(start_time_s),
        "integration_start_s": t_int0,
        "sample_rate_hz": float(sample_rate_hz),
        "tolerance_rtol": float(rtol),
        "tolerance_atol": float(atol),
        "sensors": {k: v for k, v in sensors.to_dict().items() if v is not None and v != {}},
        "applied": applied,
        "t": t_samples,
        "alpha": alpha[si].copy(),
        "alpha_dot": alpha_dot[si].copy(),
        "mode": in_contact[si].astype(np.int8),
        "contact_force": force[si].copy(),
        "gap": psi[si].copy(),
        "alpha_ddot": add[si].copy(),
        "impacts": impacts,
        "impact_kinds": ",".join(["contact" if law["kind"] == "hunt-crossley" else "impact"] * len(rows)),
        "apexes": {"t": t_apex[keep], "alpha": a_apex[keep]},
        "orbit": {
            "section_phase": orbit.section_phase,
            "alpha": float(orbit.state[0]),
            "alpha_dot": float(orbit.state[1]),
            "multipliers_real": orbit.multipliers.real.copy(),
            "multipliers_imag": orbit.multipliers.imag.copy(),
            "spectral_radius": orbit.spectral_radius,
            "map_residual": orbit.residual.copy(),
            "contacts_per_revolution": int(orbit.contacts_per_revolution),
            "newton_iterations": int(orbit.newton_iterations),
        },
    }
    if law["kind"] == "hunt-crossley":
        truth.update(law="hunt-crossley", beta=law["beta"], n=law["n"], clip=law["clip"],
                     stiffness_exponent=1.5, k_H=p["k_H"])
    else:
        truth.update(law="restitution", gamma=law["gamma"], xi0=law["xi0"])
    return recording, _plain(truth)


def write_reference_recording(path, *args, **kwargs):
    """:func:`reference_recording` written to HDF5 with its ``/truth`` group; returns the path."""
    recording, truth = reference_recording(*args, **kwargs)
    return write_hdf5(recording, path, truth=truth)


def _plain(value: Any) -> Any:
    """Mappings to dicts and numpy scalars to Python scalars (HDF5-ready)."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, np.generic):
        return value.item()
    return value

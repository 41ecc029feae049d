"""Independent plain-Python/SciPy reference implementation of "Rig P".

Rig P is the eccentric cylindrical cam on a pivoted follower with point contact,
from Sundar, Dreyer & Singh (2016) (Sundar, Dreyer & Singh 2016). This module follows
``shared/spec/docs/rig_p.md`` section 1 (1.1-1.3, 1.7, 1.9). It is meant for cross-checking
the compiled simulator, so it favours clarity and accuracy over speed.

Conventions (docs/rig_p.md)
--------------------------
* Fixed frame: origin at the follower pivot P, e_x horizontal towards the cam, e_y up.
* ``alpha``: follower angle from e_x, clockwise positive (tip moving down).
  u(alpha) = (cos a, -sin a) along the bar; n(alpha) = (sin a, cos a), the normal towards the cam.
* ``theta`` (Theta): cam angle, counter-clockwise. The cam centre is
  G_c = PE - e (cos Theta, sin Theta).
* psi_i = n . G_c - (h_p + r_c)  (> 0 separated, < 0 indentation), chi = u . G_c,
  dpsi_i/dt = chi*alpha_dot - e*cos(alpha+Theta)*Theta_dot.
* Cam speed ``omega_hz`` is in Hz: Theta(t) = theta0 + 2*pi*omega_hz*t.

SI units everywhere, angles in rad.

Notes on the numerics
---------------------
* Each regime is integrated by its own ``solve_ivp`` call with a terminal event on psi_i, and the
  next regime starts from the event state (``sol.y_events``). The event direction (-1 for entering
  contact, +1 for leaving it) stops the new phase from firing again at its own start, where
  psi_i is 0 to within round-off.
* Inside the *contact-phase ODE right-hand side* only, the contact force is extended past psi_i = 0
  as an odd function of the indentation, k_H*sgn(delta)*|delta|^1.5 - beta*|delta|^n*dpsi. So the
  extension is continuous at psi_i = 0 (for n = 0 as well), and the trial stages of the last step,
  which may overshoot the exit, do not see a jump. This changes nothing for psi_i <= 0, where the
  trajectory is defined. The public ``contact_force`` / ``angular_acceleration`` follow the spec
  and return F = 0 for psi_i >= 0.
* sgn(0) = 0 in the friction law (numpy convention).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import quad, solve_ivp
from scipy.optimize import brentq, minimize_scalar

__all__ = [
    "reference_params",
    "gap",
    "lever_arm",
    "gap_rate",
    "psi_j",
    "psi_j_rate",
    "relative_sliding_velocity",
    "zero_state",
    "gap_paper_S5",
    "gap_rate_paper_S7",
    "spring_force",
    "contact_force",
    "angular_acceleration",
    "free_flight_energy",
    "static_equilibrium",
    "run_hybrid",
    "run_restitution",
]

TWO_PI = 2.0 * math.pi


# ---------------------------------------------------------------------------------------------
# Parameters
# ---------------------------------------------------------------------------------------------
def reference_params(e_over_rc: float) -> dict:
    """Table 1 of Sundar, Dreyer & Singh (2016) with labels repaired (docs/rig_p.md), SI units, plus derived keys."""
    p = dict(
        m_b=0.257,
        I_b=3.3e-3,
        l_g=0.086,
        l_b=0.173,  # follower length, not used by the equations
        l_a=0.063,
        w_b=0.0127,
        r_d=0.0032,
        r_c=0.0175,
        e_over_rc=float(e_over_rc),
        k_s=3319.0,
        L_s_u=0.053,
        d_x=0.035,
        d_y=0.058,
        PE_x=0.089,
        PE_y=0.027,
        Y_c=210e9,
        Y_b=210e9,
        nu_c=0.3,
        nu_b=0.3,
        mu=0.2,
        g=9.81,
    )
    p["e"] = float(e_over_rc) * p["r_c"]
    _derive(p)
    return p


def _derive(p: dict) -> dict:
    """(Re)compute the derived keys from the primary ones (use after editing a parameter)."""
    p["Y_e"] = 1.0 / ((1.0 - p["nu_c"] ** 2) / p["Y_c"] + (1.0 - p["nu_b"] ** 2) / p["Y_b"])  # (S-12)
    p["rho_e"] = 1.0 / (1.0 / p["r_c"] + 1.0 / p["r_d"])  # (S-13)
    p["k_H"] = 4.0 / 3.0 * p["Y_e"] * math.sqrt(p["rho_e"])  # (S-11): k_lambda |psi| = k_H |psi|^1.5
    p["h_p"] = 0.5 * p["w_b"] + 2.0 * p["r_d"]
    return p


# ---------------------------------------------------------------------------------------------
# Geometry and kinematics (docs/rig_p.md)
# ---------------------------------------------------------------------------------------------
def gap(alpha, theta, p):
    """psi_i = n(alpha) . G_c(Theta) - (h_p + r_c)."""
    e = p["e"]
    return (p["PE_x"] * np.sin(alpha) + p["PE_y"] * np.cos(alpha) - e * np.sin(alpha + theta)
            - (p["h_p"] + p["r_c"]))


def lever_arm(alpha, theta, p):
    """chi = u(alpha) . G_c(Theta)."""
    e = p["e"]
    return p["PE_x"] * np.cos(alpha) - p["PE_y"] * np.sin(alpha) - e * np.cos(alpha + theta)


def gap_rate(alpha, alpha_dot, theta, theta_dot, p):
    """dpsi_i/dt = chi*alpha_dot - e*cos(alpha+Theta)*Theta_dot."""
    return lever_arm(alpha, theta, p) * alpha_dot - p["e"] * np.cos(alpha + theta) * theta_dot


def zero_state(p):
    """0-state (alpha0, Theta0) of (S-3, S-4) as corrected in docs/rig_p.md."""
    D = p["h_p"] + p["r_c"] + p["e"]
    X, Y = p["PE_x"], p["PE_y"]
    c = (Y * D + math.sqrt(X ** 4 + X ** 2 * Y ** 2 - X ** 2 * D ** 2)) / (X ** 2 + Y ** 2)
    a0 = math.acos(c)
    return a0, 0.5 * math.pi - a0


def _chi0(p):
    a0, _ = zero_state(p)
    return p["PE_x"] * math.cos(a0) - p["PE_y"] * math.sin(a0)


def psi_j(alpha, theta, p):
    """psi_j = chi0 - chi (docs/rig_p.md; equals (S-6))."""
    return _chi0(p) - lever_arm(alpha, theta, p)


def psi_j_rate(alpha, alpha_dot, theta, theta_dot, p):
    """dpsi_j/dt, closed form of (S-8): (n . G_c) alpha_dot - e sin(alpha+Theta) Theta_dot."""
    nG = gap(alpha, theta, p) + p["h_p"] + p["r_c"]
    return nG * alpha_dot - p["e"] * np.sin(alpha + theta) * theta_dot


def relative_sliding_velocity(alpha, alpha_dot, theta, theta_dot, p):
    """v_r of (S-18): dpsi_j/dt - [r_c + e sin(alpha+Theta)] (alpha_dot + Theta_dot)."""
    return (psi_j_rate(alpha, alpha_dot, theta, theta_dot, p)
            - (p["r_c"] + p["e"] * np.sin(alpha + theta)) * (alpha_dot + theta_dot))


def gap_paper_S5(alpha, theta, p):
    """psi_i written as in (S-5), for cross-checking the closed form."""
    a0, th0 = zero_state(p)
    chi0 = _chi0(p)
    H = p["h_p"] + p["r_c"]
    e = p["e"]
    return (chi0 * np.sin(alpha - a0) + H * (np.cos(alpha - a0) - 1.0)
            + e * (np.sin(alpha + th0) - np.sin(alpha + theta)))


def gap_rate_paper_S7(alpha, alpha_dot, theta, theta_dot, p):
    """dpsi_i/dt written as in (S-7), for cross-checking the closed form."""
    a0, th0 = zero_state(p)
    chi0 = _chi0(p)
    H = p["h_p"] + p["r_c"]
    e = p["e"]
    return (chi0 * np.cos(alpha - a0) * alpha_dot - H * np.sin(alpha - a0) * alpha_dot
            + e * (np.cos(alpha + th0) * alpha_dot - np.cos(alpha + theta) * (alpha_dot + theta_dot)))


# ---------------------------------------------------------------------------------------------
# Forces and equations of motion (docs/rig_p.md)
# ---------------------------------------------------------------------------------------------
def spring_force(alpha, p):
    """(S-10): F_s = k_s [L_s^u - d_y + d_x tan(alpha) + 0.5 w_b sec(alpha)]."""
    return p["k_s"] * (p["L_s_u"] - p["d_y"] + p["d_x"] * np.tan(alpha) + 0.5 * p["w_b"] / np.cos(alpha))


def contact_force(alpha, alpha_dot, theta, theta_dot, p, beta, n, clip=False):
    """Generalised Hunt-Crossley force F = k_H delta^1.5 - beta delta^n dpsi_i/dt, delta = -psi_i.

    Returns 0 where psi_i >= 0. Unclipped (may be tensile) unless clip=True.
    n = 0 gives delta**0 = 1 (viscous damping) even for tiny delta.
    """
    psi = gap(alpha, theta, p)
    dpsi = gap_rate(alpha, alpha_dot, theta, theta_dot, p)
    delta = np.asarray(-psi, dtype=float)
    in_c = delta > 0.0
    dpos = np.where(in_c, delta, 0.0)
    F = p["k_H"] * dpos ** 1.5 - beta * dpos ** n * dpsi
    if clip:
        F = np.maximum(F, 0.0)
    F = np.where(in_c, F, 0.0)
    return F[()] if np.ndim(F) == 0 else F


def angular_acceleration(alpha, alpha_dot, theta, theta_dot, p, beta, n, mu, in_contact: bool,
                         clip=False):
    """alpha_ddot from (S-9) (free flight) or (S-16) (contact, with friction (S-17, S-18))."""
    torque = p["m_b"] * p["g"] * p["l_g"] * np.cos(alpha) - spring_force(alpha, p) * p["d_x"]
    if in_contact:
        F = contact_force(alpha, alpha_dot, theta, theta_dot, p, beta, n, clip=clip)
        chi = lever_arm(alpha, theta, p)
        vr = relative_sliding_velocity(alpha, alpha_dot, theta, theta_dot, p)
        Ff = mu * F * np.sign(vr)
        torque = torque + F * chi - Ff * p["h_p"]
    return torque / p["I_b"]


def free_flight_energy(alpha, alpha_dot, p, alpha_ref=0.0):
    """E = 0.5 I_b alpha_dot^2 + int_{alpha_ref}^{alpha} (F_s d_x - m_b g l_g cos a) da (docs/estimation.md)."""
    def integrand(a):
        return float(spring_force(a, p)) * p["d_x"] - p["m_b"] * p["g"] * p["l_g"] * math.cos(a)

    def one(a, ad):
        V, _ = quad(integrand, alpha_ref, float(a), epsabs=0.0, epsrel=1e-13, limit=200)
        return 0.5 * p["I_b"] * float(ad) ** 2 + V

    if np.ndim(alpha) == 0:
        return one(alpha, alpha_dot)
    return np.array([one(a, ad) for a, ad in zip(np.ravel(alpha), np.ravel(alpha_dot))])


def contact_angle(theta, p):
    """The alpha with psi_i(alpha, Theta) = 0 on the branch with chi > 0 (closed form).

    psi_i = R sin(alpha + phi) - (h_p + r_c), with R = |G_c|, phi = atan2(G_cy, G_cx), and
    chi = R cos(alpha + phi).
    """
    Gx = p["PE_x"] - p["e"] * math.cos(theta)
    Gy = p["PE_y"] - p["e"] * math.sin(theta)
    R = math.hypot(Gx, Gy)
    return math.asin((p["h_p"] + p["r_c"]) / R) - math.atan2(Gy, Gx)


def static_equilibrium(theta, p):
    """alpha* (alpha_dot = 0) where k_H delta^1.5 chi balances gravity + spring (friction ignored)."""
    theta = float(theta)
    kH = p["k_H"]
    mgl = p["m_b"] * p["g"] * p["l_g"]

    def torque(a):
        delta = -float(gap(a, theta, p))
        Fk = kH * delta ** 1.5 if delta > 0.0 else 0.0
        return (mgl * math.cos(a) - float(spring_force(a, p)) * p["d_x"]
                + Fk * float(lever_arm(a, theta, p)))

    a_c = contact_angle(theta, p)
    if torque(a_c) >= 0.0:
        raise ValueError("free-flight torque at first touch pushes the follower away from the cam: "
                         "no static contact equilibrium")
    a_lo = a_c - 1e-2
    if torque(a_lo) <= 0.0:
        raise ValueError("could not bracket the static equilibrium")
    return brentq(torque, a_lo, a_c, xtol=1e-17, rtol=4.0 * np.finfo(float).eps, maxiter=500)


# ---------------------------------------------------------------------------------------------
# Fast scalar right-hand sides used inside the integrators
# ---------------------------------------------------------------------------------------------
def _make_kernels(p, theta0, W, beta, n, mu, clip):
    PEx, PEy, e = p["PE_x"], p["PE_y"], p["e"]
    H = p["h_p"] + p["r_c"]
    hp, rc = p["h_p"], p["r_c"]
    ks, Lsu, dy, dx, wb = p["k_s"], p["L_s_u"], p["d_y"], p["d_x"], p["w_b"]
    mgl = p["m_b"] * p["g"] * p["l_g"]
    invI = 1.0 / p["I_b"]
    kH = p["k_H"]
    sin, cos, tan = math.sin, math.cos, math.tan

    def free_torque(a):
        ca = cos(a)
        Fs = ks * (Lsu - dy + dx * tan(a) + 0.5 * wb / ca)
        return mgl * ca - Fs * dx

    def rhs_free(t, y):
        a = y[0]
        return [y[1], free_torque(a) * invI]

    def kin(t, a, ad):
        th = theta0 + W * t
        sa, ca = sin(a), cos(a)
        s_at, c_at = sin(a + th), cos(a + th)
        nG = PEx * sa + PEy * ca - e * s_at
        chi = PEx * ca - PEy * sa - e * c_at
        psi = nG - H
        dpsi = chi * ad - e * c_at * W
        return nG, chi, psi, dpsi, s_at

    def force_ext(psi, dpsi):
        delta = -psi
        if delta >= 0.0:
            F = kH * delta * math.sqrt(delta) - beta * delta ** n * dpsi
        else:  # smooth continuation past the exit, only ever seen by trial stages
            ad_ = -delta
            F = -kH * ad_ * math.sqrt(ad_) - beta * ad_ ** n * dpsi
        if clip and F < 0.0:
            F = 0.0
        return F

    def rhs_contact(t, y):
        a, ad = y[0], y[1]
        nG, chi, psi, dpsi, s_at = kin(t, a, ad)
        F = force_ext(psi, dpsi)
        if mu != 0.0 and F != 0.0:
            vr = nG * ad - e * s_at * W - (rc + e * s_at) * (ad + W)
            sg = 1.0 if vr > 0.0 else (-1.0 if vr < 0.0 else 0.0)
            fr = mu * F * sg * hp
        else:
            fr = 0.0
        return [ad, (free_torque(a) + F * chi - fr) * invI]

    def ev_gap(t, y):
        a = y[0]
        th = theta0 + W * t
        return PEx * sin(a) + PEy * cos(a) - e * sin(a + th) - H

    def ev_alpha_dot(t, y):
        return y[1]

    return dict(rhs_free=rhs_free, rhs_contact=rhs_contact, kin=kin, ev_gap=ev_gap,
                ev_alpha_dot=ev_alpha_dot)


def _event(fun, terminal, direction):
    def ev(t, y):
        return fun(t, y)
    ev.terminal = terminal
    ev.direction = direction
    return ev


def _continuous_max(f, t_steps, t_lo, t_hi, nsub=8):
    """Maximum of a smooth scalar function f(t) on [t_lo, t_hi].

    The grid is the solver steps, each split into nsub parts. The best grid point is then refined
    with a bounded Brent search on its two neighbouring grid cells. The search variable is shifted
    to the grid point, so that the tolerance is not limited by |t|.
    Returns (f_max, t_max).
    """
    ts = np.asarray(t_steps, dtype=float)
    ts = ts[(ts >= t_lo) & (ts <= t_hi)]
    ts = np.unique(np.concatenate([[t_lo, t_hi], ts]))
    if ts.size < 2 or t_hi <= t_lo:
        return f(t_lo), t_lo
    frac = np.linspace(0.0, 1.0, nsub + 1)[:-1]
    grid = np.concatenate([(ts[:-1, None] + frac[None, :] * np.diff(ts)[:, None]).ravel(), [ts[-1]]])
    vals = np.array([f(t) for t in grid])
    i = int(np.argmax(vals))
    best_v, best_t = float(vals[i]), float(grid[i])
    lo = grid[max(i - 1, 0)]
    hi = grid[min(i + 1, grid.size - 1)]
    tc = grid[i]
    if hi > lo:
        res = minimize_scalar(lambda s: -f(tc + s), bounds=(lo - tc, hi - tc), method="bounded",
                              options=dict(xatol=1e-15 * max(hi - lo, 1e-300) + 1e-300, maxiter=500))
        if -res.fun > best_v:
            best_v, best_t = float(-res.fun), float(tc + res.x)
    return best_v, best_t


# ---------------------------------------------------------------------------------------------
# Hybrid (compliant contact) simulation
# ---------------------------------------------------------------------------------------------
def run_hybrid(alpha0, alpha_dot0, theta0, omega_hz, t_end, p, beta, n, mu, clip=False,
               rtol=1e-12, atol=1e-15, method="DOP853", max_phases=1_000_000) -> dict:
    """Event-driven simulation of the contact / free-flight model (docs/rig_p.md).

    Returns a dict with 'contacts', 'alpha_m', 't_alpha_m', 'final', 'evaluate', 'nfev' and also
    'phases' (a list of (t_start, t_end, in_contact)). Each contact record also carries
    't_peak_force' and 't_peak_indentation'. 'evaluate' gives a time that is exactly on a phase
    boundary to the earlier phase.
    """
    alpha0, alpha_dot0 = float(alpha0), float(alpha_dot0)
    theta0, t_end = float(theta0), float(t_end)
    beta, n, mu = float(beta), float(n), float(mu)
    W = TWO_PI * float(omega_hz)
    K = _make_kernels(p, theta0, W, beta, n, mu, clip)
    ev_enter = _event(K["ev_gap"], True, -1.0)
    ev_exit = _event(K["ev_gap"], True, +1.0)
    ev_amax = _event(K["ev_alpha_dot"], False, -1.0)

    def F_of(t, a, ad):
        return float(contact_force(a, ad, theta0 + W * t, W, p, beta, n, clip=clip))

    psi0 = float(gap(alpha0, theta0, p))
    dpsi0 = float(gap_rate(alpha0, alpha_dot0, theta0, W, p))
    if abs(psi0) < 1e-15:
        contact = dpsi0 < 0.0
    else:
        contact = psi0 < 0.0

    t = 0.0
    y = np.array([alpha0, alpha_dot0])
    phases = []  # (t0, t1, OdeSolution, in_contact)
    contacts = []
    amax_cand = [(alpha0, 0.0)]
    nfev = 0
    while t < t_end:
        if len(phases) >= max_phases:
            raise RuntimeError("too many phases")
        if contact:
            rhs, ev_sw = K["rhs_contact"], ev_exit
        else:
            rhs, ev_sw = K["rhs_free"], ev_enter
        sol = solve_ivp(rhs, (t, t_end), y, method=method, rtol=rtol, atol=atol,
                        dense_output=True, events=[ev_sw, ev_amax])
        nfev += sol.nfev
        if sol.status < 0:
            raise RuntimeError("solve_ivp failed: " + str(sol.message))
        for te, ye in zip(sol.t_events[1], sol.y_events[1]):
            amax_cand.append((float(ye[0]), float(te)))
        switched = sol.status == 1 and len(sol.t_events[0]) > 0
        if switched:
            t1 = float(sol.t_events[0][-1])
            y1 = np.array(sol.y_events[0][-1], dtype=float)
            if t1 <= t:
                raise RuntimeError(f"no progress in phase starting at t={t}")
        else:
            t1 = float(sol.t[-1])
            y1 = np.array(sol.y[:, -1], dtype=float)
        phases.append((t, t1, sol.sol, contact))
        amax_cand.append((float(y1[0]), t1))

        if contact:
            dsol = sol.sol
            t_steps = sol.t

            def Ft(tt, dsol=dsol):
                yy = dsol(tt)
                return F_of(tt, yy[0], yy[1])

            def dlt(tt, dsol=dsol):
                yy = dsol(tt)
                return -float(gap(yy[0], theta0 + W * tt, p))

            pf, tpf = _continuous_max(Ft, t_steps, t, t1)
            pi_, tpi = _continuous_max(dlt, t_steps, t, t1)
            ys = sol.y[:, 0]
            contacts.append(dict(
                t_start=t,
                t_end=t1 if switched else float("nan"),
                dpsi_start=float(gap_rate(ys[0], ys[1], theta0 + W * t, W, p)),
                dpsi_end=float(gap_rate(y1[0], y1[1], theta0 + W * t1, W, p)) if switched else float("nan"),
                peak_force=pf, t_peak_force=tpf,
                peak_indentation=pi_, t_peak_indentation=tpi,
            ))
        t, y = t1, y1
        if switched:
            contact = not contact
        else:
            break

    a_m, t_m = max(amax_cand, key=lambda c: c[0])

    def evaluate(t_array):
        tt = np.atleast_1d(np.asarray(t_array, dtype=float))
        A = np.full(tt.shape, np.nan)
        AD = np.full(tt.shape, np.nan)
        C = np.zeros(tt.shape, dtype=bool)
        done = np.zeros(tt.shape, dtype=bool)
        for (t0_, t1_, s_, c_) in phases:
            m = (~done) & (tt >= t0_) & (tt <= t1_)
            if np.any(m):
                yy = s_(tt[m])
                A[m], AD[m], C[m] = yy[0], yy[1], c_
                done |= m
        return A, AD, C

    return dict(contacts=contacts, alpha_m=float(a_m), t_alpha_m=float(t_m),
                final=(float(y[0]), float(y[1])), evaluate=evaluate, nfev=int(nfev),
                phases=[(a, b, c) for (a, b, _, c) in phases])


# ---------------------------------------------------------------------------------------------
# Restitution model S3 (docs/estimation.md)
# ---------------------------------------------------------------------------------------------
def run_restitution(alpha0, alpha_dot0, theta0, omega_hz, t_end, p, xi0, gamma, rtol=1e-12,
                    atol=1e-15, method="DOP853", max_impacts=1000) -> dict:
    """Free flight with instantaneous impacts: dpsi_after = -xi dpsi_before, xi = xi0 - gamma v_a.

    alpha and Theta keep their values at an impact; alpha_dot is reset from the closed-form gap rate.
    Raises ValueError if xi < 0 or if the initial state is inside the cam (psi_i < -1e-15), and
    RuntimeError after more than max_impacts impacts. A start exactly at psi_i = 0 (|psi_i| < 1e-15)
    with dpsi_i/dt < 0 gives an impact at t = 0.
    """
    alpha0, alpha_dot0 = float(alpha0), float(alpha_dot0)
    theta0, t_end = float(theta0), float(t_end)
    W = TWO_PI * float(omega_hz)
    K = _make_kernels(p, theta0, W, 0.0, 1.0, 0.0, False)
    ev_enter = _event(K["ev_gap"], True, -1.0)
    ev_amax = _event(K["ev_alpha_dot"], False, -1.0)
    e = p["e"]

    impacts = []

    def do_impact(t, a, ad):
        th = theta0 + W * t
        dpsi_b = float(gap_rate(a, ad, th, W, p))
        v_a = abs(dpsi_b)
        xi = xi0 - gamma * v_a
        if xi < 0.0:
            raise ValueError(f"restitution coefficient xi = {xi} < 0 at v_a = {v_a} m/s "
                             "(outside the law's range)")
        dpsi_a = xi * v_a
        chi = float(lever_arm(a, th, p))
        ad_after = (dpsi_a + e * math.cos(a + th) * W) / chi
        impacts.append(dict(t=t, v_a=v_a, xi=xi, alpha=a, alpha_dot_before=ad, alpha_dot_after=ad_after))
        if len(impacts) > max_impacts:
            raise RuntimeError(f"more than {max_impacts} impacts")
        return ad_after

    psi0 = float(gap(alpha0, theta0, p))
    dpsi0 = float(gap_rate(alpha0, alpha_dot0, theta0, W, p))
    if psi0 < -1e-15:
        raise ValueError("initial state is inside the cam (psi_i < 0)")
    y = np.array([alpha0, alpha_dot0])
    if abs(psi0) < 1e-15 and dpsi0 < 0.0:
        y[1] = do_impact(0.0, alpha0, alpha_dot0)

    t = 0.0
    amax_cand = [(alpha0, 0.0)]
    nfev = 0
    while t < t_end:
        sol = solve_ivp(K["rhs_free"], (t, t_end), y, method=method, rtol=rtol, atol=atol,
                        dense_output=True, events=[ev_enter, ev_amax])
        nfev += sol.nfev
        if sol.status < 0:
            raise RuntimeError("solve_ivp failed: " + str(sol.message))
        for te, ye in zip(sol.t_events[1], sol.y_events[1]):
            amax_cand.append((float(ye[0]), float(te)))
        if sol.status == 1 and len(sol.t_events[0]) > 0:
            t1 = float(sol.t_events[0][-1])
            y1 = np.array(sol.y_events[0][-1], dtype=float)
            if t1 <= t:
                raise RuntimeError(f"no progress after impact at t={t}")
            amax_cand.append((float(y1[0]), t1))
            y1[1] = do_impact(t1, float(y1[0]), float(y1[1]))
            t, y = t1, y1
        else:
            y = np.array(sol.y[:, -1], dtype=float)
            t = float(sol.t[-1])
            amax_cand.append((float(y[0]), t))
            break
    a_m, t_m = max(amax_cand, key=lambda c: c[0])
    return dict(impacts=impacts, alpha_m=float(a_m), t_alpha_m=float(t_m),
                final=(float(y[0]), float(y[1])), nfev=int(nfev))

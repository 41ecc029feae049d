"""Periodic steady states, cycle analyses and jump speeds of the cycloidal-cam valve train.

* Level A (the paper's model): the valve adheres to the cam, the spring masses are integrated with the
  lift as input and the contact load is the constraint reaction (R-40'); ``W < 0`` means "jump
  predicted (the adherent model is not valid there)". Its periodic steady state is found directly:
  the surge model is linear, so the state after one revolution is ``z(T) = Phi z(0) + z_p(T)`` with
  ``Phi = expm(A T)`` and ``z_p`` the compiled response from rest; ``z(0) = (I - Phi)^-1 z_p(T)``,
  verified by integrating one more revolution (``periodicity_error``).
* Level B (extension): the valve released, unilateral Hertz cam contact and valve seat, switches as
  located events. Its periodic steady state is found by run-in from the level-A periodic state plus
  the static base-circle offsets, with an explicit convergence test on the state at ``psi = 0``
  from revolution to revolution; a speed without a periodic steady state (irregular bouncing) is
  reported as not converged, never as a cycle.
* Kinematic load (R-43'): ``W = f_p + k0 s`` (no inertia, no surge); rigid follower without surge:
  ``W = m3 omega^2 s'' + f_p + k0 s``.

:func:`cycle` samples a steady cycle at the film scheme's steps (``steps_per_rev``, from ``psi = 0``)
and returns the film, velocities, load and Hertz quantities with their validity flags
(:class:`CycleResult`); :func:`jump_speed` finds the first jump speed by a scan and bisection.
All speeds are camshaft speeds in r/min at this interface (R-D3); SI inside.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from scipy import linalg, optimize

from impactid.errors import SimulationError, SimulationInputError
from impactid.rigs.cycloidal import cam
from impactid.rigs.cycloidal import kernel as K
from impactid.rigs.cycloidal.contact import (
    RangeFlags,
    film_scheme,
    hertz_approach,
    hertz_half_width,
    hertz_load,
    hertz_max_pressure,
)
from impactid.rigs.cycloidal.parameters import KUSHWAHA2000, CycloidalEHLRig

__all__ = ["LEVELS", "CycleResult", "JumpSpeedResult", "LevelBCycle", "Tolerances", "cycle", "jump_speed",
           "level_a_min_load", "level_a_periodic_state", "level_a_run", "level_b_run", "level_b_static_state",
           "level_b_steady_cycle", "omega_of", "pack", "sweep", "warm_up"]

TWO_PI = 2.0 * math.pi
#: Load models of :func:`cycle`: level A (the paper's adherent model), level B (valve released),
#: the kinematic load of (R-43') and the rigid follower without surge.
LEVELS = ("A", "B", "kinematic", "rigid")


@dataclass(frozen=True)
class Tolerances:
    """Integrator settings of both levels.

    Attributes
    ----------
    rtol : relative tolerance; atol_x [m], atol_v [m/s] : absolute tolerances of displacements and
        velocities. The defaults keep the level-B load (which depends on the micrometre difference
        ``s - y3`` through a contact stiffness of about 5e8 N/m) accurate to about 1e-3 N.
    h_max_deg : largest step, in degrees of cam angle (so that a pair of crossings inside one step
        of a free flight cannot be missed).
    max_steps : step budget of one call [-].
    max_events : a level-B run with more events per revolution stops (chattering).
    """

    rtol: float = 1e-10
    atol_x: float = 1e-14
    atol_v: float = 1e-11
    h_max_deg: float = 0.5
    max_steps: int = 20_000_000
    max_events: int = 2000


DEFAULT_TOLERANCES = Tolerances()


def omega_of(rpm: float) -> float:
    """Camshaft angular speed [rad/s] of a camshaft speed [r/min]."""
    return TWO_PI * float(rpm) / 60.0


def _check_rpm(rpm: float) -> float:
    rpm = float(rpm)
    if not (math.isfinite(rpm) and rpm > 0.0):
        raise SimulationInputError(f"camshaft speed must be positive and finite, got {rpm!r} rpm")
    return rpm


def pack(rig: CycloidalEHLRig, rpm: float) -> np.ndarray:
    """The rig's parameters and the cam speed in the kernels' layout (:mod:`.kernel`, ``P_*``)."""
    p = np.empty(K.N_PAR)
    p[K.P_M3], p[K.P_M5], p[K.P_KS1], p[K.P_KS2] = rig.m3, rig.m5, rig.k_s1, rig.k_s2
    p[K.P_C], p[K.P_FP], p[K.P_S], p[K.P_BETA], p[K.P_R0] = rig.c_spring, rig.f_p, rig.S, rig.beta, rig.R0
    p[K.P_SIGMA], p[K.P_LC], p[K.P_KSE], p[K.P_CSE] = rig.sigma, rig.L_c, rig.K_se, rig.C_se
    p[K.P_LASH], p[K.P_OMEGA] = rig.g_lash, omega_of(rpm)
    return p


def _break_times(rig: CycloidalEHLRig, omega: float, t0: float, t1: float) -> np.ndarray:
    """Times in ``(t0, t1]`` where ``psi = omega t`` reaches a kinematic break point (mod 2 pi)."""
    base = np.array([math.pi - rig.beta, math.pi, math.pi + rig.beta])
    k0 = math.floor(omega * t0 / TWO_PI) - 1
    k1 = math.ceil(omega * t1 / TWO_PI) + 1
    ts = np.concatenate([(base + TWO_PI * k) / omega for k in range(k0, k1 + 1)])
    return np.sort(ts[(ts > t0) & (ts < t1)])


def _raise(status: int, what: str, t: float) -> None:
    if status != K.OK:
        raise SimulationError(f"{what}: {K.STATUS_MESSAGES.get(status, 'unknown status')} at t = {t:.9g} s")


# ============================================================================================
# Level A
# ============================================================================================


def level_a_run(rig: CycloidalEHLRig, rpm: float, z0, t0: float, t1: float, grid=None,
                tol: Tolerances = DEFAULT_TOLERANCES):
    """Integrate level A (spring masses, prescribed lift) from ``t0`` to ``t1`` [s].

    Returns ``(z1, Z)``: the state ``[y5, y5', y6, y6']`` at ``t1`` and the states at the ``grid`` times
    (shape (len(grid), 4))."""
    rpm = _check_rpm(rpm)
    p = pack(rig, rpm)
    omega = p[K.P_OMEGA]
    grid = np.zeros(0) if grid is None else np.ascontiguousarray(grid, dtype=float)
    out = np.empty((grid.size, 5))
    z = np.array(z0, dtype=float)
    atol = np.array([tol.atol_x, tol.atol_v] * 2)
    res = K.integrate_a(p, float(t0), z, float(t1), tol.rtol, atol, math.radians(tol.h_max_deg) / omega,
                        tol.max_steps, _break_times(rig, omega, t0, t1), grid, out)
    _raise(res.status, f"level A at {rpm:g} rpm", res.t)
    return z, out[:, :4]


def _surge_system_matrix(rig: CycloidalEHLRig) -> np.ndarray:
    M, C, Kmat = rig.surge.matrices()
    Minv = np.linalg.inv(M)
    A = np.zeros((4, 4))
    A[0, 1] = A[2, 3] = 1.0
    A[np.ix_([1, 3], [0, 2])] = -Minv @ Kmat
    A[np.ix_([1, 3], [1, 3])] = -Minv @ C
    return A


def level_a_periodic_state(rig: CycloidalEHLRig, rpm: float, tol: Tolerances = DEFAULT_TOLERANCES):
    """Periodic steady state of the spring masses at ``psi = 0`` (exact shooting of the linear model).

    Returns ``(z0, periodicity_error)``: ``[y5, y5', y6, y6']`` [m, m/s] and the largest change over one
    more revolution, scaled by ``S`` (displacements) and ``omega S`` (velocities)."""
    rpm = _check_rpm(rpm)
    T = TWO_PI / omega_of(rpm)
    zp, _ = level_a_run(rig, rpm, np.zeros(4), 0.0, T, tol=tol)
    Phi = linalg.expm(_surge_system_matrix(rig) * T)
    z0 = np.linalg.solve(np.eye(4) - Phi, zp)
    zT, _ = level_a_run(rig, rpm, z0, 0.0, T, tol=tol)
    scale = np.array([rig.S, omega_of(rpm) * rig.S] * 2)
    return z0, float(np.max(np.abs(zT - z0) / scale))


def level_a_load(rig: CycloidalEHLRig, rpm: float, t, Z) -> np.ndarray:
    """Contact load (R-40') ``W = m3 omega^2 s'' + f_p + k_s1 (s - y5) + c (omega s' - y5')`` [N]
    at times ``t`` [s] for spring-mass states ``Z`` (n, 4)."""
    w = omega_of(rpm)
    s, s1, s2, _ = cam.lift(w * np.asarray(t, dtype=float), rig.S, rig.beta)
    Z = np.asarray(Z, dtype=float)
    return rig.m3 * w**2 * s2 + rig.f_p + rig.k_s1 * (s - Z[:, 0]) + rig.c_spring * (w * s1 - Z[:, 1])


def level_a_min_load(rig: CycloidalEHLRig, rpm: float, tol: Tolerances = DEFAULT_TOLERANCES, n_grid: int = 7200,
                     z0=None) -> tuple[float, float]:
    """Smallest level-A contact load over the steady cycle, continuous in the cam angle.

    The load is sampled at ``n_grid`` points of the steady revolution; around the smallest sample the
    integration is repeated on a grid 1000 times finer, twice (the minimum is then located to
    ``1e-6`` of the first spacing, where the load's curvature makes the sampling error negligible).
    Returns ``(W_min [N], psi [rad])``."""
    rpm = _check_rpm(rpm)
    w = omega_of(rpm)
    T = TWO_PI / w
    if z0 is None:
        z0, _ = level_a_periodic_state(rig, rpm, tol)
    t = np.arange(n_grid) * (T / n_grid)
    _, Z = level_a_run(rig, rpm, z0, 0.0, T, grid=t, tol=tol)
    W = level_a_load(rig, rpm, t, Z)
    i = int(np.argmin(W))
    W_best, t_best = float(W[i]), float(t[i])
    # zoom twice around the smallest sample: [t_i - dt, t_i + dt] on 2001 points (periodic wrap at psi = 0)
    ta, za, dt = (t[i - 1], Z[i - 1], T / n_grid) if i > 0 else (-T / n_grid, Z[-1], T / n_grid)
    for _ in range(2):
        fine = ta + np.linspace(0.0, 2.0 * dt, 2001)
        _, Zf = level_a_run(rig, rpm, za, ta, fine[-1], grid=fine, tol=tol)
        Wf = level_a_load(rig, rpm, fine, Zf)
        k = int(np.argmin(Wf))
        if Wf[k] < W_best:
            W_best, t_best = float(Wf[k]), float(fine[k])
        dt = fine[1] - fine[0]
        ta, za = (fine[k - 1], Zf[k - 1]) if k > 0 else (fine[0], Zf[0])
    return W_best, (w * t_best) % TWO_PI


# ============================================================================================
# Level B
# ============================================================================================


def level_b_static_state(rig: CycloidalEHLRig) -> tuple[np.ndarray, int]:
    """Static equilibrium on the base circle, ``([y3, 0, y5, 0, y6, 0], mode)``.

    The spring chain (series rate ``k0``; ``y5 = 5/8 y3``, ``y6 = 3/8 y3``) carries ``f_p + k0 y3``;
    the seat (``-K_se y3`` for ``y3 < 0``) and the cam (``delta^-1(-g_lash - y3)`` on the base-circle
    radius) share it. With lash the cam does not touch and the seat takes everything."""
    def resid(y3):
        g = -rig.g_lash - y3
        W = float(hertz_load(g, rig.R0, rig.sigma, rig.L_c)) if g > 0.0 else 0.0
        F = -rig.K_se * y3 if y3 < 0.0 else 0.0
        return W + F - rig.f_p - rig.k0 * y3

    if rig.f_p == 0.0:
        y3 = 0.0
    else:
        lo = -rig.f_p / (rig.K_se + rig.k0) * 1.01 if rig.K_se > 0 else -1e-3
        y3 = optimize.brentq(resid, lo, 0.0, xtol=1e-18, rtol=1e-15)
    x = np.array([y3, 0.0, 0.625 * y3, 0.0, 0.375 * y3, 0.0])
    contact = 1 if -rig.g_lash - y3 > 0.0 else 0
    seat = K.SEAT_ON if (y3 < 0.0 and rig.K_se > 0.0) else K.SEAT_OFF
    return x, contact + 2 * seat


def _mode_from_state(rig: CycloidalEHLRig, psi: float, x) -> int:
    s = cam.lift_scalar(psi, rig.S, rig.beta)[0]
    contact = 1 if s - rig.g_lash - x[0] > 0.0 else 0
    if x[0] >= 0.0:
        seat = K.SEAT_OFF
    else:
        seat = K.SEAT_ON if -rig.K_se * x[0] - rig.C_se * x[1] > 0.0 else K.SEAT_SLACK_MODE
    return contact + 2 * seat


def _event_records(events: np.ndarray, n: int, omega: float, t_origin: float = 0.0) -> list[dict]:
    rows = []
    for k in range(min(n, events.shape[0])):
        e = events[k]
        t = float(e[K.E_T])
        rows.append({"kind": K.EVENT_NAMES[int(e[K.E_KIND])], "t": t - t_origin,
                     "psi": float((omega * t) % TWO_PI), "y3": float(e[K.E_Y3]), "v3": float(e[K.E_V3]),
                     "rate": float(e[K.E_RATE])})
    return rows


def level_b_run(rig: CycloidalEHLRig, rpm: float, x0, t0: float, t1: float, mode0: int | None = None, grid=None,
                tol: Tolerances = DEFAULT_TOLERANCES, raise_on_chatter: bool = True):
    """Integrate level B from ``t0`` to ``t1`` [s].

    Returns ``(x1, mode1, X, modes, events, status)``: the state and mode at ``t1``, the states
    (len(grid), 6) and modes at the ``grid`` times, the event log (dicts: ``kind``, ``t``, ``psi``
    [rad, mod 2 pi], ``y3``, ``v3``, ``rate``) and the kernel status. Chattering (more than
    ``tol.max_events`` events) raises :class:`SimulationError` unless ``raise_on_chatter`` is False."""
    rpm = _check_rpm(rpm)
    p = pack(rig, rpm)
    omega = p[K.P_OMEGA]
    x = np.array(x0, dtype=float)
    if mode0 is None:
        mode0 = _mode_from_state(rig, omega * t0, x)
    grid = np.zeros(0) if grid is None else np.ascontiguousarray(grid, dtype=float)
    out = np.empty((grid.size, 7))
    events = np.empty((tol.max_events, K.N_ECOL))
    atol = np.array([tol.atol_x, tol.atol_v] * 3)
    res = K.integrate_b(p, float(t0), x, int(mode0), float(t1), tol.rtol, atol, math.radians(tol.h_max_deg) / omega,
                        tol.max_steps, _break_times(rig, omega, t0, t1), grid, out, events, tol.max_events)
    if res.status == K.EVENTS_FULL:
        if raise_on_chatter:
            raise SimulationError(
                f"level B at {rpm:g} rpm: more than {tol.max_events} contact/seat events between t = {t0:.6g} s "
                f"and {res.t:.6g} s (chattering); the model has no contact damping, so a follower that hits the "
                "cam or the seat repeatedly (valve lash, speeds far above the jump speed) can bounce without end")
    else:
        _raise(res.status, f"level B at {rpm:g} rpm", res.t)
    return (x, int(res.mode), out[:, :6], out[:, 6].astype(int), _event_records(events, res.n_events, omega),
            res.status)


def level_b_loads(rig: CycloidalEHLRig, rpm: float, t, X) -> tuple[np.ndarray, np.ndarray]:
    """Cam load ``W`` and seat reaction ``F`` [N] of level-B states ``X`` (n, 6) at times ``t`` [s]."""
    t = np.ascontiguousarray(t, dtype=float)
    X = np.ascontiguousarray(X, dtype=float)
    W = np.empty(t.size)
    F = np.empty(t.size)
    K.loads_b(t, X, pack(rig, rpm), W, F)
    return W, F


@dataclass(frozen=True)
class LevelBCycle:
    """The level-B steady cycle (or the last revolution tried, when none was found).

    Attributes
    ----------
    rpm : camshaft speed [r/min]; T : revolution [s].
    x0, mode0 : state ``[y3, y3', y5, y5', y6, y6']`` and mode at ``psi = 0`` of the cycle.
    converged : whether the state at ``psi = 0`` repeated to ``tol`` (scaled by ``S``, ``omega S``).
    history : the scaled change of that state per revolution of the run-in.
    events : events of the cycle (times from its start).
    chattering : the last revolution stopped on the event budget (no cycle).
    """

    rpm: float
    T: float
    x0: np.ndarray
    mode0: int
    converged: bool
    history: tuple[float, ...]
    events: tuple[dict, ...]
    chattering: bool = False

    @property
    def n_rev(self) -> int:
        return len(self.history)

    def jump(self, rig: CycloidalEHLRig) -> bool:
        """Whether the follower loses the cam during the cam event (``pi - beta`` to ``pi + beta``)."""
        return any(e["kind"] == "contact_loss" and rig.rise_start < e["psi"] < rig.return_end for e in self.events)

    @property
    def bounce(self) -> bool:
        """More than one seat lift-off per revolution: the valve leaves the seat again after closing."""
        return sum(e["kind"] == "seat_liftoff" for e in self.events) > 1


def level_b_steady_cycle(rig: CycloidalEHLRig, rpm: float, tol: Tolerances = DEFAULT_TOLERANCES,
                         conv_tol: float = 1e-8, max_rev: int = 60, x0=None) -> LevelBCycle:
    """Level-B periodic steady cycle by run-in with an explicit convergence test.

    Starts (by default) from the level-A periodic state of the spring masses plus the static
    base-circle offsets of level B and integrates whole revolutions from ``psi = 0`` until
    ``max(|dy|/S, |dv|/(omega S)) < conv_tol`` between consecutive revolutions at ``psi = 0``
    (``1e-8`` of ``S`` is 8e-11 m, about 0.04 N of contact load). The first surge mode decays by
    ``exp(-2 pi zeta1 f0 T)`` per revolution (0.08 at 3000 rpm), and the seat damping kills the
    contact ringing on every closing, so a speed with a stable period-1 motion converges in about
    ten revolutions; one without (irregular bouncing) is returned with ``converged=False``."""
    rpm = _check_rpm(rpm)
    w = omega_of(rpm)
    T = TWO_PI / w
    if x0 is None:
        zA, _ = level_a_periodic_state(rig, rpm, tol)
        xs, _ = level_b_static_state(rig)
        x0 = xs.copy()
        x0[2:] += zA
    x = np.asarray(x0, dtype=float)
    mode = _mode_from_state(rig, 0.0, x)
    scale = np.array([rig.S, w * rig.S] * 3)
    history = []
    events: list[dict] = []
    x_start, mode_start = x, mode
    chattering = False
    converged = False
    while len(history) < max_rev:
        x_start, mode_start = x, mode
        x1, mode1, _, _, events, status = level_b_run(rig, rpm, x, 0.0, T, mode0=mode, tol=tol,
                                                      raise_on_chatter=False)
        if status == K.EVENTS_FULL:
            chattering = True
            history.append(math.inf)
            break
        err = float(np.max(np.abs(x1 - x) / scale))
        history.append(err)
        x, mode = x1, mode1
        if err < conv_tol:
            converged = True
            x_start, mode_start = x, mode
            break
    return LevelBCycle(rpm=rpm, T=T, x0=np.array(x_start), mode0=int(mode_start), converged=converged,
                       history=tuple(history), events=tuple(events), chattering=chattering)


# ============================================================================================
# Cycle analyses
# ============================================================================================


@dataclass(frozen=True)
class CycleResult(RangeFlags):
    """Film thickness, velocities, load and Hertz quantities over one steady camshaft revolution.

    Arrays are over the ``N = steps_per_rev`` steps of the film scheme, ``psi = 2 pi n/N`` from 0
    (the nose ``psi = pi`` is a step when ``N`` is even). SI units; angles in rad.

    Attributes
    ----------
    rig, rpm, level : what was simulated; ws_mode : squeeze-ratio handling; dt : step [s].
    psi, t : cam angle [rad] and time [s] of the steps.
    s, s1, s2 : lift [m] and its derivatives [m/rad, m/rad^2].
    u, u_s : entraining and sliding velocities [m/s]; R : radius of curvature [m]; e : offset [m].
    W : contact load [N] (level B: the cam load only); F_seat : seat reaction [N] (level B, else 0).
    b0, p0, delta : Hertz half-width [m], maximum pressure [Pa], approach [m] (0 where W <= 0).
    h, w, ws_raw, ws, clipped, floored, valid : the film scheme (:class:`~.contact.FilmScheme`).
    jump_predicted : ``W < 0`` (level A: the adherent model is not valid there).
    fine_psi, fine_W : the load on a grid ``fine`` times finer (for extrema and the surge ripple).
    W_min, psi_W_min : smallest load, continuous in ``psi`` for level A (zoomed), else on the fine grid.
    events : level-B events of the cycle; converged : level B found a periodic cycle;
    periodicity_error : level A's check of the shooting; y3 : level-B valve lift at the steps [m].
    notes : what qualifies the result (extrapolated film, jump predicted, no steady cycle, ...).
    """

    rig: CycloidalEHLRig
    rpm: float
    level: str
    ws_mode: str
    dt: float
    psi: np.ndarray
    t: np.ndarray
    s: np.ndarray
    s1: np.ndarray
    s2: np.ndarray
    u: np.ndarray
    u_s: np.ndarray
    R: np.ndarray
    e: np.ndarray
    W: np.ndarray
    F_seat: np.ndarray
    b0: np.ndarray
    p0: np.ndarray
    delta: np.ndarray
    h: np.ndarray
    w: np.ndarray
    ws_raw: np.ndarray
    ws: np.ndarray
    clipped: np.ndarray
    floored: np.ndarray
    valid: dict
    jump_predicted: np.ndarray
    fine_psi: np.ndarray
    fine_W: np.ndarray
    W_min: float
    psi_W_min: float
    y3: np.ndarray | None = None
    events: tuple[dict, ...] = ()
    converged: bool = True
    periodicity_error: float = 0.0
    h_floor: float = 0.0
    notes: tuple[str, ...] = ()
    details: dict = field(default_factory=dict)

    # ---- summaries ---------------------------------------------------------------------------
    @property
    def steps_per_rev(self) -> int:
        return int(self.psi.size)

    @property
    def nose_index(self) -> int:
        return int(np.argmin(np.abs(self.psi - math.pi)))


    @property
    def zero_entrainment_angles(self) -> np.ndarray:
        """Cam angles [rad] where ``u = 0`` (independent of speed)."""
        return cam.zero_entrainment_angles(self.rig.S, self.rig.beta, self.rig.R0)

    def _base(self, psi) -> np.ndarray:
        return (psi < self.rig.rise_start) | (psi > self.rig.return_end)

    @property
    def base_circle_load(self) -> tuple[float, float]:
        """Smallest and largest load on the base circle [N] (fine grid; level B: cam plus seat)."""
        base = self._base(self.fine_psi)
        return float(self.fine_W[base].min()), float(self.fine_W[base].max())

    @property
    def surge_ripple(self) -> float:
        """Half the peak-to-peak base-circle load [N] (the first surge mode after closing)."""
        lo, hi = self.base_circle_load
        return 0.5 * (hi - lo)

    def summary(self) -> dict[str, Any]:
        """The cycle's numbers as a JSON-ready dict (SI units in the key names; angles in deg)."""
        i_nose = self.nose_index
        imax, imin = int(np.argmax(self.h)), int(np.argmin(self.h))
        zeros = self.zero_entrainment_angles
        frac = self.fraction_outside()
        lo, hi = self.base_circle_load
        jump_deg = np.degrees(self.psi[self.jump_predicted])
        out = {
            "rig": self.rig.model, "level": self.level, "rpm": self.rpm, "steps_per_rev": self.steps_per_rev,
            "dt_s": self.dt, "ws_mode": self.ws_mode, "film_floor_m": self.h_floor,
            "nose_film_thickness_m": float(self.h[i_nose]), "nose_entraining_velocity_m_s": float(self.u[i_nose]),
            "nose_angle_deg": float(np.degrees(self.psi[i_nose])),
            "max_film_thickness_m": float(self.h[imax]), "max_film_angle_deg": float(np.degrees(self.psi[imax])),
            "min_film_thickness_m": float(self.h[imin]), "min_film_angle_deg": float(np.degrees(self.psi[imin])),
            "min_film_note": (f"the formula gives h -> 0 as u -> 0; the minimum depends on how close a step "
                              f"falls to a zero of u (step {360.0 / self.steps_per_rev:.3g} deg, decision R-D5)"),
            "zero_entrainment_angles_deg": [float(v) for v in np.degrees(zeros)],
            "zero_entrainment_from_nose_deg": [float(v) for v in np.degrees(zeros) - 180.0],
            "min_contact_load_N": float(self.W_min), "min_contact_load_angle_deg": float(np.degrees(self.psi_W_min)),
            "max_contact_load_N": float(self.fine_W.max()),
            "max_contact_load_angle_deg": float(np.degrees(self.fine_psi[int(np.argmax(self.fine_W))])),
            "max_hertz_pressure_Pa": float(self.p0.max()),
            "max_hertz_half_width_m": float(self.b0.max()),
            "max_entraining_velocity_m_s": float(self.u.max()), "min_entraining_velocity_m_s": float(self.u.min()),
            "max_squeeze_velocity_m_s": float(self.w.max()), "min_squeeze_velocity_m_s": float(self.w.min()),
            "fraction_outside_range": {"W_star": frac["W"], "U_star": frac["U"], "G_star": frac["G"],
                                       "ws_star": frac["ws"], "any": frac["any"]},
            "fraction_ws_clipped": float(np.mean(self.clipped)),
            "base_circle_load_min_N": lo, "base_circle_load_max_N": hi, "surge_ripple_N": self.surge_ripple,
            "jump_predicted": bool(self.jump_predicted.any() or self.W_min < 0.0),
            "jump_predicted_angles_deg": [float(jump_deg.min()), float(jump_deg.max())] if jump_deg.size else [],
            "notes": list(self.notes),
        }
        if self.level == "A":
            out["periodicity_error"] = self.periodicity_error
        if self.level == "B":
            out["converged"] = self.converged
            out["events"] = [{"kind": e["kind"], "angle_deg": math.degrees(e["psi"])} for e in self.events]
            out["jump"] = any(e["kind"] == "contact_loss" and self.rig.rise_start < e["psi"] < self.rig.return_end
                              for e in self.events)
            out["bounce"] = sum(e["kind"] == "seat_liftoff" for e in self.events) > 1
        return out

    def to_pandas(self) -> pd.DataFrame:
        """Per-step table (SI units, angle in deg)."""
        frame = pd.DataFrame({
            "psi_deg": np.degrees(self.psi), "t_s": self.t, "lift_m": self.s, "u_m_s": self.u, "u_s_m_s": self.u_s,
            "R_m": self.R, "e_m": self.e, "W_N": self.W, "F_seat_N": self.F_seat, "b0_m": self.b0, "p0_Pa": self.p0,
            "delta_m": self.delta, "h_m": self.h, "w_m_s": self.w, "ws_raw": self.ws_raw, "ws": self.ws,
            "ws_clipped": self.clipped, "W_star_inside": self.valid["W"], "U_star_inside": self.valid["U"],
            "G_star_inside": self.valid["G"], "ws_star_inside": self.valid["ws"],
            "jump_predicted": self.jump_predicted})
        if self.y3 is not None:
            frame["y3_m"] = self.y3
        return frame

    def report(self) -> str:
        """A short text report (um, deg, rpm at this edge)."""
        d = self.summary()
        f = d["fraction_outside_range"]
        lines = [
            f"{self.rig.model}, level {self.level}, {self.rpm:g} rpm, {self.steps_per_rev} steps/rev "
            f"(ws {self.ws_mode})",
            f"  nose: film {d['nose_film_thickness_m'] * 1e6:.4g} um, entraining velocity "
            f"{d['nose_entraining_velocity_m_s']:.4g} m/s",
            f"  film: max {d['max_film_thickness_m'] * 1e6:.4g} um at {d['max_film_angle_deg']:.1f} deg, "
            f"min {d['min_film_thickness_m'] * 1e6:.4g} um at {d['min_film_angle_deg']:.1f} deg",
            "  zero entrainment at " + ", ".join(f"{a:.2f}" for a in d["zero_entrainment_angles_deg"]) + " deg",
            f"  load: min {d['min_contact_load_N']:.4g} N at {d['min_contact_load_angle_deg']:.1f} deg, "
            f"max {d['max_contact_load_N']:.4g} N; surge ripple on the base circle +-{d['surge_ripple_N']:.3g} N",
            f"  max Hertz pressure {d['max_hertz_pressure_Pa'] / 1e9:.4g} GPa, half-width "
            f"{d['max_hertz_half_width_m'] * 1e6:.4g} um",
            f"  outside Table 3: W* {100 * f['W_star']:.1f} %, U* {100 * f['U_star']:.1f} %, "
            f"G* {100 * f['G_star']:.1f} %, ws* {100 * f['ws_star']:.1f} % of the cycle",
        ]
        if d["jump_predicted"]:
            lines.append("  JUMP PREDICTED: W < 0 " + (
                f"from {d['jump_predicted_angles_deg'][0]:.1f} to {d['jump_predicted_angles_deg'][1]:.1f} deg"
                if d["jump_predicted_angles_deg"] else "between steps"))
        lines += [f"  note: {n}" for n in self.notes]
        return "\n".join(lines)

    def plot(self, what: str = "film"):
        """A figure of the cycle (``film``, ``load``, ``squeeze``, ``hertz``, ``entraining``); see
        :mod:`impactid.rigs.cycloidal.figures`."""
        from impactid.rigs.cycloidal import figures

        return figures.cycle_figure(self, what)


def _loads_for_level(rig, rpm, level, tol, t, fine_t, conv_tol, max_rev):
    """Loads at the steps ``t`` and on the fine grid, with what the level adds."""
    w = omega_of(rpm)
    extra: dict[str, Any] = {}
    notes: list[str] = []
    if level == "A":
        z0, perr = level_a_periodic_state(rig, rpm, tol)
        T = TWO_PI / w
        _, Z = level_a_run(rig, rpm, z0, 0.0, T, grid=fine_t, tol=tol)
        W_fine = level_a_load(rig, rpm, fine_t, Z)
        W_min, psi_min = level_a_min_load(rig, rpm, tol, z0=z0)
        extra.update(periodicity_error=perr, W_min=W_min, psi_W_min=psi_min)
        fine_total = W_fine
    elif level == "B":
        cyc = level_b_steady_cycle(rig, rpm, tol, conv_tol=conv_tol, max_rev=max_rev)
        if cyc.chattering:
            raise SimulationError(
                f"level B at {rpm:g} rpm: chattering (more than {tol.max_events} events in one revolution); "
                "no cycle to analyse")
        _, _, X, _, _, _ = level_b_run(rig, rpm, cyc.x0, 0.0, cyc.T, mode0=cyc.mode0, grid=fine_t, tol=tol)
        W_fine, F_fine = level_b_loads(rig, rpm, fine_t, X)
        fine_total = W_fine + F_fine
        k = int(np.argmin(W_fine))
        extra.update(W_min=float(W_fine[k]), psi_W_min=float(w * fine_t[k]), events=cyc.events,
                     converged=cyc.converged, X_fine=X, F_fine=F_fine, level_b=cyc)
        if not cyc.converged:
            notes.append(f"level B found no periodic steady state within {cyc.n_rev} revolutions (last change "
                         f"{cyc.history[-1]:.2g} of S); the revolution shown is the last one run, not a cycle")
        if cyc.jump(rig):
            notes.append("level B: the follower loses the cam during the cam event (jump)")
        if cyc.bounce:
            notes.append("level B: the valve bounces on its seat after closing")
    elif level == "kinematic":
        s = cam.lift(w * fine_t, rig.S, rig.beta)[0]
        W_fine = rig.f_p + rig.k0 * s
        fine_total = W_fine
    elif level == "rigid":
        s, _, s2, _ = cam.lift(w * fine_t, rig.S, rig.beta)
        W_fine = rig.m3 * w**2 * s2 + rig.f_p + rig.k0 * s
        fine_total = W_fine
    else:
        raise ValueError(f"unknown level {level!r}; valid: {', '.join(LEVELS)}")
    if "W_min" not in extra:
        k = int(np.argmin(W_fine))
        extra.update(W_min=float(W_fine[k]), psi_W_min=float(w * fine_t[k]))
    return W_fine, fine_total, extra, notes


def cycle(rig: CycloidalEHLRig, rpm: float, level: str = "A", *, steps_per_rev: int | None = None,
          ws_mode: str | None = None, film_revs: int = 2, h_floor: float = 0.0, fine: int = 20,
          tol: Tolerances = DEFAULT_TOLERANCES, conv_tol: float = 1e-8, max_rev: int = 60) -> CycleResult:
    """Film thickness, velocities, load and Hertz quantities over a steady cycle (the paper's Figs. 3-7).

    Parameters
    ----------
    rig : the rig; rpm : camshaft speed [r/min].
    level : ``"A"`` (the paper's adherent model, default), ``"B"`` (valve released), ``"kinematic"``
        (the load of Figs. 4 and 5, R-43') or ``"rigid"`` (no surge).
    steps_per_rev : steps of the film scheme (default ``rig.steps_per_rev``, the paper's 500).
    ws_mode : squeeze-ratio handling, ``"clip"``, ``"none"`` or ``"symmetric"`` (default from ``rig.ws_clip``).
    film_revs : revolutions of the film scheme (the last is reported).
    h_floor : optional film floor [m] (decision R-D5; 0 = none).
    fine : the load is also sampled ``fine`` times per step for its extrema and the surge ripple.
    tol, conv_tol, max_rev : integrator settings; level-B convergence tolerance and revolution budget.
    """
    rpm = _check_rpm(rpm)
    if level not in LEVELS:
        raise ValueError(f"unknown level {level!r}; valid: {', '.join(LEVELS)}")
    n = rig.film_steps if steps_per_rev is None else int(steps_per_rev)
    if n < 8:
        raise ValueError(f"steps_per_rev must be >= 8, got {steps_per_rev!r}")
    ws_mode = ("clip" if rig.ws_clip else "none") if ws_mode is None else ws_mode
    w = omega_of(rpm)
    T = TWO_PI / w
    dt = T / n
    t = np.arange(n) * dt
    psi = w * t
    fine_t = np.arange(n * fine) * (dt / fine)
    W_fine, total_fine, extra, notes = _loads_for_level(rig, rpm, level, tol, t, fine_t, conv_tol, max_rev)
    W = W_fine[::fine].copy()
    F = (extra["F_fine"][::fine].copy() if "F_fine" in extra else np.zeros(n))
    s, s1, s2, _ = cam.lift(psi, rig.S, rig.beta)
    Rc = rig.R0 + s + s2
    u = 0.5 * w * (rig.R0 + s + 2.0 * s2)
    film = film_scheme(W, Rc, u, dt, rig.E_prime, rig.L_c, rig.eta0, rig.alpha_pv, ws_mode=ws_mode, n_rev=film_revs,
                       h_floor=h_floor)
    jump = W < 0.0
    frac = film.fraction_outside()
    for key, label in (("U", "U*"), ("W", "W*"), ("G", "G*"), ("ws", "w_s*")):
        if frac[key] > 0.0:
            notes.append(f"{label} outside the regression range of Table 3 on {100 * frac[key]:.1f} % of the cycle: "
                         "the film formula is extrapolated there (flags per step in 'valid')")
    if level == "A" and (jump.any() or extra["W_min"] < 0.0):
        notes.append(f"jump predicted: the adherent load reaches {extra['W_min']:.4g} N at "
                     f"{math.degrees(extra['psi_W_min']):.2f} deg; the adherent model (and its film) is not valid "
                     "there")
    if h_floor > 0.0 and film.floored.any():
        notes.append(f"film floor {h_floor:.3g} m applied on {int(film.floored.sum())} steps")
    y3 = extra["X_fine"][::fine, 0].copy() if "X_fine" in extra else None
    return CycleResult(
        rig=rig, rpm=rpm, level=level, ws_mode=ws_mode, dt=dt, psi=psi, t=t, s=s, s1=s1, s2=s2, u=u,
        u_s=w * (rig.R0 + s), R=Rc, e=s1, W=W, F_seat=F,
        b0=hertz_half_width(W, Rc, rig.sigma, rig.L_c), p0=hertz_max_pressure(W, Rc, rig.sigma, rig.L_c),
        delta=hertz_approach(W, Rc, rig.sigma, rig.L_c), h=film.h, w=film.w, ws_raw=film.ws_raw, ws=film.ws,
        clipped=film.clipped, floored=film.floored, valid=film.valid, jump_predicted=jump,
        fine_psi=w * fine_t, fine_W=total_fine, W_min=float(extra["W_min"]), psi_W_min=float(extra["psi_W_min"]),
        y3=y3, events=tuple(extra.get("events", ())), converged=bool(extra.get("converged", True)),
        periodicity_error=float(extra.get("periodicity_error", 0.0)), h_floor=float(h_floor), notes=tuple(notes),
        details={"film_revs": film_revs, "fine": fine, "tolerances": tol})


def sweep(rig: CycloidalEHLRig, rpms: Sequence[float], level: str = "A", **options) -> list[CycleResult]:
    """:func:`cycle` at several camshaft speeds (the paper's Figs. 3, 6 and 7)."""
    return [cycle(rig, rpm, level, **options) for rpm in rpms]


# ============================================================================================
# Jump speeds
# ============================================================================================


@dataclass(frozen=True)
class JumpSpeedResult:
    """The lowest camshaft speed at which the follower first loses the cam.

    Attributes
    ----------
    level : ``"rigid"``, ``"A"`` or ``"B"``.
    rpm : the jump speed [r/min] (NaN when none was found in the searched range).
    bracket : ``(below, above)`` [r/min]: the last speed without and the first with a jump.
    angle : cam angle [rad] of the first loss (of ``W < 0`` for level A) just above the jump speed.
    criterion : what "jump" means at this level.
    evaluations : speeds simulated; notes : qualifications.
    """

    level: str
    rpm: float
    bracket: tuple[float, float]
    angle: float
    criterion: str
    evaluations: int
    notes: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        return {"level": self.level, "jump_speed_rpm": self.rpm, "bracket_rpm": list(self.bracket),
                "angle_deg": math.degrees(self.angle) if math.isfinite(self.angle) else math.nan,
                "criterion": self.criterion, "evaluations": self.evaluations, "notes": list(self.notes)}


def _level_b_jump(rig, rpm, tol, conv_tol, max_rev):
    cyc = level_b_steady_cycle(rig, rpm, tol, conv_tol=conv_tol, max_rev=max_rev)
    if cyc.chattering:
        return True, math.nan, cyc
    losses = [e["psi"] for e in cyc.events
              if e["kind"] == "contact_loss" and rig.rise_start < e["psi"] < rig.return_end]
    return bool(losses), (min(losses) if losses else math.nan), cyc


def jump_speed(rig: CycloidalEHLRig, level: str = "A", rpm_range: tuple[float, float] = (2000.0, 4500.0),
               scan_step: float = 50.0, xtol: float | None = None, tol: Tolerances = DEFAULT_TOLERANCES,
               conv_tol: float = 1e-7, max_rev: int = 60) -> JumpSpeedResult:
    """Lowest camshaft speed [r/min] at which the follower first loses the cam.

    * ``"rigid"``: rigid follower on a massless spring, ``W = m3 omega^2 s'' + f_p + k0 s`` (closed form
      up to a one-dimensional minimisation; ``rpm_range`` unused).
    * ``"A"``: the steady-cycle minimum of the adherent load (R-40'), continuous in the cam angle,
      reaches 0. The speeds of ``rpm_range`` are scanned upwards every ``scan_step`` r/min for the first
      sign change of that minimum, then Brent's method (a safeguarded bisection) refines it to
      ``xtol`` (default 0.01 r/min).
    * ``"B"``: the released follower first loses cam contact during the cam event in the level-B steady
      cycle (or the motion chatters). Scan, then bisection of that yes/no predicate to ``xtol``
      (default 0.5 r/min).

    A jump that appears and disappears between two scan speeds is not seen (the note says so). The
    lower end of ``rpm_range`` must be free of jump: otherwise the result is a refusal (NaN, with the
    reason), not a guess.
    """
    notes = []
    if level == "rigid":
        wj, psi = cam.rigid_jump_speed(rig.m3, rig.k0, rig.f_p, rig.S, rig.beta)
        rpm = wj * 60.0 / TWO_PI
        return JumpSpeedResult("rigid", rpm, (rpm, rpm), psi, "rigid follower without surge: first W < 0", 0)
    lo, hi = float(rpm_range[0]), float(rpm_range[1])
    if not (math.isfinite(lo) and math.isfinite(hi) and 0.0 < lo < hi):
        raise SimulationInputError(f"rpm_range must be 0 < low < high, got {rpm_range!r}")
    if not (math.isfinite(scan_step) and scan_step > 0.0):
        raise SimulationInputError(f"scan_step must be positive, got {scan_step!r}")
    evaluations = 0
    if level == "A":
        xtol = 0.01 if xtol is None else xtol

        def f(r):
            nonlocal evaluations
            evaluations += 1
            return level_a_min_load(rig, r, tol)[0]

        criterion = "level A (adherent): steady-cycle minimum of the contact load (R-40') reaches 0"
        speeds = np.arange(lo, hi + 0.5 * scan_step, scan_step)
        speeds[-1] = min(speeds[-1], hi)
        prev, fprev = None, None
        for r in speeds:
            fr = f(r)
            if fr < 0.0:
                if prev is None:
                    return JumpSpeedResult("A", math.nan, (math.nan, r), math.nan, criterion, evaluations,
                                           (f"the adherent load is already negative ({fr:.4g} N) at the lowest speed "
                                            f"{r:g} rpm; lower the range",))
                root = optimize.brentq(f, prev, r, xtol=xtol)
                _, psi = level_a_min_load(rig, root + xtol, tol)
                evaluations += 1
                notes.append(f"scanned every {scan_step:g} rpm from {lo:g} rpm; a jump band narrower than that "
                             "between two scan speeds would not be seen")
                return JumpSpeedResult("A", float(root), (float(root - xtol), float(root + xtol)), psi, criterion,
                                       evaluations, tuple(notes))
            prev, fprev = r, fr
        return JumpSpeedResult("A", math.nan, (hi, math.nan), math.nan, criterion, evaluations,
                               (f"no W < 0 up to {hi:g} rpm (smallest load there {fprev:.4g} N)",))
    if level == "B":
        xtol = 0.5 if xtol is None else xtol
        criterion = ("level B (valve released): first loss of cam contact during the cam event in the steady cycle, "
                     "or chattering")

        def pred(r):
            nonlocal evaluations
            evaluations += 1
            return _level_b_jump(rig, r, tol, conv_tol, max_rev)

        speeds = np.arange(lo, hi + 0.5 * scan_step, scan_step)
        speeds[-1] = min(speeds[-1], hi)
        prev = None
        for r in speeds:
            jumped, psi, cyc = pred(r)
            if jumped:
                if prev is None:
                    return JumpSpeedResult("B", math.nan, (math.nan, r), psi, criterion, evaluations,
                                           (f"the follower already loses the cam at the lowest speed {r:g} rpm; "
                                            "lower the range",))
                a, b, psi_b = prev, r, psi
                while b - a > xtol:
                    mid = 0.5 * (a + b)
                    jm, pm, _ = pred(mid)
                    if jm:
                        b, psi_b = mid, pm
                    else:
                        a = mid
                notes.append(f"scanned every {scan_step:g} rpm from {lo:g} rpm, then bisection to {xtol:g} rpm")
                return JumpSpeedResult("B", float(0.5 * (a + b)), (float(a), float(b)), psi_b, criterion,
                                       evaluations, tuple(notes))
            if not cyc.converged:
                notes.append(f"no periodic steady state at {r:g} rpm (taken as no jump: no contact loss in the "
                             "last revolution)")
            prev = r
        return JumpSpeedResult("B", math.nan, (hi, math.nan), math.nan, criterion, evaluations,
                               (f"no contact loss up to {hi:g} rpm", *notes))
    raise ValueError(f"unknown level {level!r}; valid: rigid, A, B")


def warm_up() -> None:
    """The cycloidal valve train's level-B simulator, briefly (``impactid warmup``)."""
    x, mode = level_b_static_state(KUSHWAHA2000)
    level_b_run(KUSHWAHA2000, 3000.0, x, 0.0, 60.0 / 3000.0 * 0.05, mode)

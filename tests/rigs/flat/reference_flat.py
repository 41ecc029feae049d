"""Independent SciPy reference of the rig F impacting model (Alzate et al. 2007, docs/rig_f.md).

A plain ``solve_ivp`` implementation, written for cross-checking the compiled simulator: it favours
clarity and accuracy over speed. From the rig it uses only the contact angle ``theta_hat`` (A-17)
with its analytic derivatives and the spring moment ``M_s`` (A-10); everything else is written out
here. SI units, angles counter-clockwise [rad].

Model
-----
* Cam angle ``theta_c(t) = theta_c0 + omega t`` at constant ``omega`` [rad/s]; state
  ``(theta_f, theta_f_dot)`` of the follower.
* Cam centre ``X = e cos theta_c + x0``, ``Y = e sin theta_c + y0``; gap
  ``h = X sin theta_f - Y cos theta_f - d - R`` (>= 0 apart); lever arm ``L = X cos theta_f + Y sin theta_f``;
  gap rate ``h_dot = X_dot sin theta_f - Y_dot cos theta_f + L theta_f_dot`` with
  ``X_dot = -e omega sin theta_c``, ``Y_dot = e omega cos theta_c``.
* Free flight (A-10): ``J theta_f_ddot = -M_s(theta_f)``; DOP853, ``rtol = 1e-12``, ``atol = 1e-14``,
  terminal event ``h = 0`` with ``h`` decreasing (direction -1).
* Impact: ``h_dot+ = -r h_dot-``, i.e. ``theta_f_dot+ = theta_f_dot- - (1 + r) h_dot- / L``;
  ``theta_f`` and ``theta_c`` keep their values. ``r`` is a constant or a callable of ``omega``.
* Sticking (the follower rides on the cam): ``theta_f = theta_hat(theta_c)``,
  ``theta_f_dot = omega theta_hat'(theta_c)``, exactly, with contact torque
  ``tau(theta_c) = J omega^2 theta_hat''(theta_c) + M_s(theta_hat(theta_c)) >= 0``. Contact is lost
  where ``tau`` crosses zero going negative (cam angle by ``brentq`` to ``1e-13`` rad, bracketed on a
  scan of ``SCAN_STEP``); free flight then starts from the contact state.
* Entering sticking: after an impact with ``h_dot+ < v_stick`` and ``tau >= 0`` at that instant.
  A run started without an initial follower state starts in contact: sticking if ``tau >= 0`` at
  ``t = 0``, else free flight from the contact state. Initial states are not recorded as events.

Numerics of leaving the surface
-------------------------------
A free segment that starts on the cam (after an impact or a release) starts at ``h = 0`` to within
rounding, and the event ``h = 0`` must not fire there, nor miss a short bounce. After an impact
(``h_dot+ > 0``) the first step is limited to a twentieth of the estimated flight time
``2 h_dot+ / |h_ddot|`` so that the first step ends with a clearly positive gap. After a release
(``h_dot = h_ddot = 0``, the gap grows like ``t^3``), or an impact that leaves no separation speed
with ``tau < 0``, the first ``ARMING_ANGLE / omega`` seconds are integrated without the event and
the gap must then be positive (else ``RuntimeError``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

__all__ = [
    "ARMING_ANGLE",
    "FlatEvent",
    "FlatReferenceRun",
    "SCAN_STEP",
    "contact_torque",
    "free_flight_energy",
    "gap",
    "gap_acceleration",
    "gap_rate",
    "lever_arm",
    "run_flat_reference",
    "spring_potential",
]

TWO_PI = 2.0 * math.pi
RTOL = 1e-12
ATOL = 1e-14
#: Cam-angle step [rad] of the scan that brackets the loss of contact (tau crossing zero downwards).
SCAN_STEP = TWO_PI / 20_000
#: Cam angle [rad] integrated without the impact event after a release.
ARMING_ANGLE = 1e-3
#: Cam-angle tolerance of the loss-of-contact root [rad].
RELEASE_XTOL = 1e-13


# ---------------------------------------------------------------------------------------------
# Geometry and forces
# ---------------------------------------------------------------------------------------------
def _cam_centre(rig, theta_c, omega):
    ct, st = np.cos(theta_c), np.sin(theta_c)
    return (rig.e * ct + rig.x0, rig.e * st + rig.y0, -rig.e * omega * st, rig.e * omega * ct,
            -rig.e * omega**2 * ct, -rig.e * omega**2 * st)


def gap(rig, theta_f, theta_c):
    """Gap ``h = X sin theta_f - Y cos theta_f - d - R`` [m]."""
    X, Y, *_ = _cam_centre(rig, theta_c, 0.0)
    return X * np.sin(theta_f) - Y * np.cos(theta_f) - rig.d - rig.R


def lever_arm(rig, theta_f, theta_c):
    """``L = X cos theta_f + Y sin theta_f`` [m] (= dh/dtheta_f)."""
    X, Y, *_ = _cam_centre(rig, theta_c, 0.0)
    return X * np.cos(theta_f) + Y * np.sin(theta_f)


def gap_rate(rig, theta_f, theta_f_dot, theta_c, omega):
    """``h_dot = X_dot sin theta_f - Y_dot cos theta_f + L theta_f_dot`` [m/s]."""
    X, Y, Xd, Yd, _, _ = _cam_centre(rig, theta_c, omega)
    s, c = np.sin(theta_f), np.cos(theta_f)
    return Xd * s - Yd * c + (X * c + Y * s) * theta_f_dot


def gap_acceleration(rig, theta_f, theta_f_dot, theta_c, omega):
    """``h_ddot`` [m/s^2] in free flight (``J theta_f_ddot = -M_s``)."""
    X, Y, Xd, Yd, Xdd, Ydd = _cam_centre(rig, theta_c, omega)
    s, c = np.sin(theta_f), np.cos(theta_f)
    thdd = -rig.spring_torque(theta_f) / rig.J
    return (Xdd * s - Ydd * c + 2.0 * theta_f_dot * (Xd * c + Yd * s) - theta_f_dot**2 * (X * s - Y * c)
            + (X * c + Y * s) * thdd)


def contact_torque(rig, theta_c, omega):
    """Torque the cam exerts in sticking contact, ``J omega^2 theta_hat'' + M_s(theta_hat)`` [N m]."""
    th, _, dd = rig.contact_angle(theta_c, derivatives=2)
    return rig.J * omega**2 * dd + rig.spring_torque(th)


def spring_potential(rig, theta_f):
    """Potential of the spring moment [J]: ``M_s = K u u'`` with ``u = x_A tan th + d / cos th - L_s``,
    so ``V = K u^2 / 2`` and ``dV/dtheta_f = M_s``."""
    u = rig.x_A * np.tan(theta_f) + rig.d / np.cos(theta_f) - rig.spring_length
    return 0.5 * rig.K * u * u


def free_flight_energy(rig, theta_f, theta_f_dot):
    """``J theta_f_dot^2 / 2 + V(theta_f)`` [J], conserved in free flight."""
    return 0.5 * rig.J * np.asarray(theta_f_dot) ** 2 + spring_potential(rig, theta_f)


# ---------------------------------------------------------------------------------------------
# Results
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class FlatEvent:
    """One switching event.

    kind : ``"impact"``, ``"stick"`` or ``"release"``.
    time [s], theta_c [rad] (unwrapped), theta_f [rad].
    rate_before, rate_after : follower rate just before and after [rad/s] (for ``stick``, the
        post-impact rate and ``omega theta_hat'``; for ``release``, both ``omega theta_hat'``).
    gap_rate_before, gap_rate_after : ``h_dot`` before and after [m/s] (impacts; nan otherwise).
    """

    kind: str
    time: float
    theta_c: float
    theta_f: float
    rate_before: float
    rate_after: float
    gap_rate_before: float = math.nan
    gap_rate_after: float = math.nan


@dataclass(frozen=True)
class _Segment:
    kind: str  # "free" | "stick"
    t0: float
    t1: float
    sol: object = None  # OdeSolution of a free segment


@dataclass(frozen=True)
class FlatReferenceRun:
    """A reference run: events and piecewise dense output.

    Attributes
    ----------
    rig, omega [rad/s], r (the value used) [-], theta_c0 [rad], t_end [s], v_stick [m/s].
    events : tuple of :class:`FlatEvent` in time order.
    """

    rig: object
    omega: float
    r: float
    theta_c0: float
    t_end: float
    v_stick: float
    events: tuple[FlatEvent, ...]
    segments: tuple[_Segment, ...] = field(repr=False)

    @property
    def impacts(self) -> list[FlatEvent]:
        return [e for e in self.events if e.kind == "impact"]

    def cam_angle(self, t):
        """``theta_c(t)`` [rad]."""
        return self.theta_c0 + self.omega * np.asarray(t, dtype=float)

    def state(self, t):
        """Follower angle [rad] and rate [rad/s] at time(s) ``t`` in ``[0, t_end]`` (after any event at ``t``)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        starts = np.array([s.t0 for s in self.segments])
        idx = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(self.segments) - 1)
        th = np.empty_like(t)
        thd = np.empty_like(t)
        for i in np.unique(idx):
            seg, sel = self.segments[i], idx == i
            if seg.kind == "stick":
                a, a1 = self.rig.contact_angle(self.cam_angle(t[sel]), derivatives=1)
                th[sel], thd[sel] = a, self.omega * a1
            else:
                y = seg.sol(t[sel])
                th[sel], thd[sel] = y[0], y[1]
        return th, thd

    def stroboscopic(self):
        """Times [s], cam angles [rad] and follower angles [rad] at ``theta_c = theta_c0 + 2 pi k``."""
        k = np.arange(int(math.floor(self.omega * self.t_end / TWO_PI * (1.0 + 1e-14))) + 1)
        t = TWO_PI * k / self.omega
        return t, self.cam_angle(t), self.state(t)[0]

    def events_table(self):
        """Events as a pandas DataFrame."""
        import pandas as pd

        return pd.DataFrame([e.__dict__ for e in self.events],
                            columns=list(FlatEvent.__dataclass_fields__))


# ---------------------------------------------------------------------------------------------
# The hybrid run
# ---------------------------------------------------------------------------------------------
def _release_angle(rig, omega, tc_start, tc_end):
    """First cam angle in ``(tc_start, tc_end]`` where tau crosses zero going negative, or None."""
    n = max(int(math.ceil((tc_end - tc_start) / SCAN_STEP)), 1)
    grid = np.linspace(tc_start, tc_end, n + 1)
    tau = contact_torque(rig, grid, omega)
    down = np.flatnonzero((tau[:-1] >= 0.0) & (tau[1:] < 0.0))
    if down.size == 0:
        return None
    i = int(down[0])
    return brentq(lambda tc: float(contact_torque(rig, tc, omega)), grid[i], grid[i + 1], xtol=RELEASE_XTOL,
                  rtol=4.0 * np.finfo(float).eps, maxiter=200)


def run_flat_reference(rig, omega: float, r: float | Callable[[float], float], t_end: float, theta_c0: float = 0.0,
                       theta_f0: float | None = None, theta_f_dot0: float | None = None, v_stick: float = 1e-6,
                       max_events: int = 100_000) -> FlatReferenceRun:
    """Simulate rig F with instantaneous impacts (restitution) and sticking, from ``t = 0`` to ``t_end``.

    Parameters
    ----------
    rig : :class:`impactid.rigs.flat.FlatFollowerRig` (uses ``contact_angle``, ``spring_torque``, geometry).
    omega : constant cam speed [rad/s] (> 0).
    r : coefficient of restitution [-] in [0, 1], or a callable ``r(omega)``.
    t_end : end time [s].
    theta_c0 : cam angle at ``t = 0`` [rad].
    theta_f0, theta_f_dot0 : initial follower state [rad, rad/s]; ``None`` starts in contact.
    v_stick : post-impact separation speed below which the follower sticks (if ``tau >= 0``) [m/s].
    max_events : guard against an unending impact sequence (``RuntimeError``).
    """
    if not omega > 0.0:
        raise ValueError(f"omega must be positive, got {omega!r} rad/s")
    r_value = float(r(omega)) if callable(r) else float(r)
    if not 0.0 <= r_value <= 1.0:
        raise ValueError(f"restitution coefficient must lie in [0, 1], got {r_value!r}")
    J = rig.J

    def tc_of(t):
        return theta_c0 + omega * t

    def rhs(t, y):
        return [y[1], -float(rig.spring_torque(y[0])) / J]

    def impact_event(t, y):
        return float(gap(rig, y[0], tc_of(t)))

    impact_event.terminal = True
    impact_event.direction = -1.0

    events: list[FlatEvent] = []
    segments: list[_Segment] = []
    t = 0.0
    if theta_f0 is None:
        th0, th1 = rig.contact_angle(theta_c0, derivatives=1)
        y = np.array([float(th0), omega * float(th1)])
        mode = "stick" if contact_torque(rig, theta_c0, omega) >= 0.0 else "arm"
    else:
        y = np.array([float(theta_f0), float(theta_f_dot0 or 0.0)])
        if gap(rig, y[0], theta_c0) < -1e-12:
            raise ValueError(f"initial state penetrates the cam: gap {float(gap(rig, y[0], theta_c0))!r} m")
        mode = "free"
    first_step = None

    while t < t_end:
        if len(events) > max_events:
            raise RuntimeError(f"more than {max_events} events before t = {t!r} s (Zeno sequence without sticking?)")
        if mode == "stick":
            tc_rel = _release_angle(rig, omega, tc_of(t), tc_of(t_end))
            if tc_rel is None:
                segments.append(_Segment("stick", t, t_end))
                t = t_end
                break
            t_rel = (tc_rel - theta_c0) / omega
            segments.append(_Segment("stick", t, t_rel))
            a, a1 = rig.contact_angle(tc_rel, derivatives=1)
            rate = omega * float(a1)
            events.append(FlatEvent("release", t_rel, tc_rel, float(a), rate, rate))
            t, y, mode = t_rel, np.array([float(a), rate]), "arm"
            continue
        if mode == "arm":
            t_arm = min(t + ARMING_ANGLE / omega, t_end)
            sol = solve_ivp(rhs, (t, t_arm), y, method="DOP853", rtol=RTOL, atol=ATOL, dense_output=True)
            if not sol.success:
                raise RuntimeError(f"solve_ivp failed after leaving the cam at t = {t!r} s: {sol.message}")
            segments.append(_Segment("free", t, t_arm, sol.sol))
            t, y = t_arm, sol.y[:, -1].copy()
            h = float(gap(rig, y[0], tc_of(t)))
            if t < t_end and not h > 0.0:
                raise RuntimeError(f"the follower did not leave the cam within {ARMING_ANGLE} rad of cam angle "
                                   f"(gap {h!r} m at t = {t!r} s)")
            mode, first_step = "free", None
            continue
        # free flight until the next impact
        kwargs = {"first_step": min(first_step, t_end - t)} if first_step else {}
        sol = solve_ivp(rhs, (t, t_end), y, method="DOP853", rtol=RTOL, atol=ATOL, dense_output=True,
                        events=impact_event, **kwargs)
        if not sol.success:
            raise RuntimeError(f"solve_ivp failed in free flight from t = {t!r} s: {sol.message}")
        if sol.status != 1:  # reached t_end
            segments.append(_Segment("free", t, t_end, sol.sol))
            t = t_end
            break
        t_imp = float(sol.t_events[0][0])
        th, rate_minus = (float(v) for v in sol.y_events[0][0])
        segments.append(_Segment("free", t, t_imp, sol.sol))
        tc = tc_of(t_imp)
        hd_minus = float(gap_rate(rig, th, rate_minus, tc, omega))
        L = float(lever_arm(rig, th, tc))
        rate_plus = rate_minus - (1.0 + r_value) * hd_minus / L
        hd_plus = float(gap_rate(rig, th, rate_plus, tc, omega))
        events.append(FlatEvent("impact", t_imp, tc, th, rate_minus, rate_plus, hd_minus, hd_plus))
        t = t_imp
        tau = float(contact_torque(rig, tc, omega))
        if hd_plus < v_stick and tau >= 0.0:
            a, a1 = rig.contact_angle(tc, derivatives=1)
            rate = omega * float(a1)
            events.append(FlatEvent("stick", t_imp, tc, float(a), rate_plus, rate))
            y, mode = np.array([float(a), rate]), "stick"
            continue
        y = np.array([th, rate_plus])
        hdd = float(gap_acceleration(rig, th, rate_plus, tc, omega))
        if hd_plus > 0.0 and hdd < 0.0:
            mode, first_step = "free", 0.05 * 2.0 * hd_plus / -hdd
        elif hd_plus > 0.0:
            mode, first_step = "free", None  # separating for good: the gap grows at once
        else:
            mode = "arm"
    return FlatReferenceRun(rig=rig, omega=float(omega), r=r_value, theta_c0=float(theta_c0), t_end=float(t_end),
                            v_stick=float(v_stick), events=tuple(events), segments=tuple(segments))


def _print_reference_run(rpm: float = 130.0, r: float = 0.8, revolutions: int = 5) -> None:
    """Print the events of a run started in contact at theta_c0 = 0 (``python -m tests.rigs.flat.reference_flat``)."""
    from impactid.rigs.flat import ALZATE2007

    omega = rpm * TWO_PI / 60.0
    period = TWO_PI / omega
    run = run_flat_reference(ALZATE2007, omega, r, revolutions * period)
    print(f"rig F (ALZATE2007), {rpm:g} rpm (omega = {omega:.15g} rad/s), r = {r:g}, "
          f"v_stick = {run.v_stick:g} m/s, start in contact at theta_c0 = 0, {revolutions} revolutions "
          f"(T = {period:.15g} s)")
    print(f"{'#':>4s} {'kind':8s} {'rev':>3s} {'time [s]':>19s} {'theta_c [rad]':>19s} {'theta_f [rad]':>19s} "
          f"{'rate- [rad/s]':>19s} {'rate+ [rad/s]':>19s} {'h_dot- [m/s]':>13s}")
    for i, e in enumerate(run.events):
        print(f"{i:4d} {e.kind:8s} {int(e.time // period):3d} {e.time:19.15f} {e.theta_c:19.15f} {e.theta_f:19.15f} "
              f"{e.rate_before:19.15f} {e.rate_after:19.15f} {e.gap_rate_before:13.6e}")
    t, _, th = run.stroboscopic()
    print("stroboscopic theta_f at theta_c = 2 pi k:", " ".join(f"{v:.15f}" for v in th))


if __name__ == "__main__":
    _print_reference_run()

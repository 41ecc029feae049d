"""Simulation of the finger-follower valve train: runs, periodic steady state, events, modes, critical speeds.

* :func:`prepare` turns a rig (and optionally a lift law) into a :class:`ValveTrain`: the packed
  parameters and the kinematic splines the compiled kernel (:mod:`.kernel`) needs.
* :func:`simulate` integrates a number of revolutions and returns a :class:`Run` (states, forces,
  switching events with their cam angles).
* :func:`steady_state` finds the periodic steady state directly: revolutions are integrated one
  after another from rest on the base circle and the state at -180 deg (a Poincare section) is
  compared with the one a revolution (or ``k`` revolutions) earlier until it repeats within a
  tolerance; a run that does not settle says so (:attr:`SteadyState.converged`).
* :func:`summarize` reports the quantities engine engineers ask for (valve lift, leak-down,
  seating speed, flank peaks of the cam force, jump, bounce, separations).
* :func:`natural_frequencies` linearises the train with the cam held (valve seated or open).
* :func:`critical_speeds` sweeps the camshaft speed and bisects the jump and bounce speeds.
* :func:`leakdown_curve` gives the maximum tappet leak-down against speed (the paper's Fig. 8).
* :func:`rigid_jump_rpm` is the closed-form jump speed of the rigid train, and :func:`speed_range`
  the camshaft speeds the model is used at (1/300 to 3 times it, the decision of
  :class:`~impactid.rigs.valvespring.CamSpeedRange`).

Speeds are camshaft speeds; functions take them in Hz (``speed_hz``) or rpm (``rpm``) as named.
Cam angles are in rad in the model's convention: 0 at the nose, negative while opening.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import pandas as pd

from impactid.errors import SimulationError, SimulationInputError
from impactid.rigs.finger_follower import kernel as KN
from impactid.rigs.finger_follower.cam import TABLE_STEP_DEG, Kinematics, build_kinematics
from impactid.rigs.finger_follower.parameters import KIM1990
from impactid.rigs.valvespring import CamSpeedRange

__all__ = ["DEFAULT_TOLERANCES", "STATE_NAMES", "CriticalSpeeds", "Modes", "Run", "SteadyState", "Tolerances",
           "ValveTrain", "critical_speeds", "leakdown_curve", "natural_frequencies", "pack", "prepare",
           "rigid_jump_rpm", "simulate", "speed_range", "static_equilibrium", "steady_state", "summarize", "warm_up"]

TWO_PI = 2.0 * math.pi
DEG = math.pi / 180.0
#: Names of the six coordinates in state order (their rates follow in the same order).
STATE_NAMES = ("Y_t", "Y_f", "theta_f", "Y_s1", "Y_s2", "Y_v")
#: Hysteresis of the tappet-damping switch on the sign of ``Y_t'`` [m/s]: the drag force is
#: ambiguous by at most ``alpha C_d+ VT_EPS`` = 2e-6 N inside it.
VT_EPS = 1e-10
CONTACTS = {KN.G_TF: "tappet/follower", KN.G_FC: "cam/follower", KN.G_VF: "valve/follower",
            KN.H_TF: "tappet/follower", KN.H_FC: "cam/follower", KN.H_VF: "valve/follower", KN.H_SEAT: "seat"}
_WHAT = {(KN.G_TF, -1): "tappet/follower separates", (KN.G_TF, 1): "tappet/follower closes",
         (KN.G_FC, -1): "cam/follower separates", (KN.G_FC, 1): "cam/follower closes",
         (KN.G_VF, -1): "valve/follower separates", (KN.G_VF, 1): "valve/follower closes",
         (KN.G_SEAT, 1): "valve opens", (KN.G_SEAT, -1): "valve closes",
         (KN.VT, 1): "tappet starts compressing", (KN.VT, -1): "tappet starts refilling",
         (KN.H_TF, -1): "tappet/follower force reaches 0", (KN.H_TF, 1): "tappet/follower force positive",
         (KN.H_FC, -1): "cam/follower force reaches 0", (KN.H_FC, 1): "cam/follower force positive",
         (KN.H_VF, -1): "valve/follower force reaches 0", (KN.H_VF, 1): "valve/follower force positive",
         (KN.H_SEAT, -1): "seat reaction reaches 0", (KN.H_SEAT, 1): "seat reaction positive"}
#: Scales of the steady-state test per state component: 1 um, 1 um at the valve lever arm, 1 mm/s.
_SCALE_DISPLACEMENT = 1e-6
_SCALE_RATE = 1e-3


# --------------------------------------------------------------------------------------------
# Settings and the prepared model
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Tolerances:
    """Integrator settings.

    Attributes
    ----------
    rtol : relative tolerance of the embedded error estimate [-].
    atol_displacement : absolute tolerance of the displacements [m] (the rotation's is this over
        ``L_vf``).
    atol_rate : absolute tolerance of the rates [m/s].
    max_step_revolutions : largest step as a fraction of a revolution.
    max_steps_per_revolution : step budget (a run that needs more raises SimulationError).
    max_events_per_revolution : capacity of the event table.

    The defaults keep the displacements within 1e-12 m and the contact forces within 1e-3 N of
    a tight solution (rtol 1e-12): measured against the independent ``solve_ivp`` reference in
    ``tests/rigs/finger_follower/test_simulate.py``. The contact stiffnesses are 4e7 to 8e7 N/m,
    so 1e-12 m is 1e-4 N of force; the forces are 20 to 1100 N.
    """

    rtol: float = 1e-9
    atol_displacement: float = 3e-12
    atol_rate: float = 3e-9
    max_step_revolutions: float = 1e-3
    max_steps_per_revolution: int = 2_000_000
    max_events_per_revolution: int = 20_000

    def __post_init__(self) -> None:
        for name in ("rtol", "atol_displacement", "atol_rate", "max_step_revolutions"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise SimulationInputError(f"tolerance {name} must be positive and finite, got {value!r}")
        if self.rtol < 1e-14:
            raise SimulationInputError(f"rtol {self.rtol!r} is below what double precision supports (1e-14)")

    def atol(self, rig) -> np.ndarray:
        """Absolute tolerances per state component."""
        d, v = self.atol_displacement, self.atol_rate
        return np.array([d, d, d / rig.L_vf, d, d, d, v, v, v / rig.L_vf, v, v, v])


DEFAULT_TOLERANCES = Tolerances()


def pack(rig, *, clip_tension: bool = False, moment_cos: bool = False) -> np.ndarray:
    """The parameter vector of the compiled kernel (layout ``kernel.P_*``)."""
    surge = rig.surge
    p = np.zeros(KN.N_PAR)
    values = {KN.P_MT: rig.M_t, KN.P_MF: rig.M_f, KN.P_IF: rig.I_f, KN.P_MV: rig.M_v, KN.P_MS: surge.mass,
              KN.P_LTF: rig.L_tf, KN.P_LVF: rig.L_vf, KN.P_KTF: rig.K_tf, KN.P_KFC: rig.K_fc, KN.P_KVF: rig.K_vf,
              KN.P_KSE: rig.K_se, KN.P_CTF: rig.C_tf, KN.P_CFC: rig.C_fc, KN.P_CVF: rig.C_vf, KN.P_CSE: rig.C_se,
              KN.P_FTF0: rig.F_tf0, KN.P_FFC0: rig.F_fc0, KN.P_FVF0: rig.F_vf0, KN.P_FO: rig.F_o, KN.P_KS: rig.K_s,
              KN.P_KS1: surge.k_end, KN.P_KS2: surge.k_middle, KN.P_CS1: surge.c_end, KN.P_CS2: surge.c_middle,
              KN.P_YVS: rig.Y_v_star, KN.P_CLIP: float(clip_tension), KN.P_MCOS: float(moment_cos),
              KN.P_VTEPS: VT_EPS}
    for index, value in values.items():
        p[index] = value
    return p


@dataclass(frozen=True, eq=False)
class ValveTrain:
    """A rig prepared for simulation.

    Attributes
    ----------
    rig : the parameters (:class:`~impactid.rigs.finger_follower.FingerFollowerRig`).
    kinematics : the tabulated kinematics (:class:`~impactid.rigs.finger_follower.cam.Kinematics`),
        with the lift law they were built from.
    clip_tension : also switch a contact off while its force would be tensile (decision K-D11).
    moment_cos : moments with ``cos(theta_f)`` (virtual-work consistent, decision K-D12).
    p : packed parameters of the kernel.
    """

    rig: Any
    kinematics: Kinematics
    clip_tension: bool = False
    moment_cos: bool = False
    p: np.ndarray = field(default=None, repr=False)

    def __post_init__(self) -> None:
        if self.p is None:
            object.__setattr__(self, "p", pack(self.rig, clip_tension=self.clip_tension, moment_cos=self.moment_cos))

    @property
    def lift(self):
        """The cam lift law."""
        return self.kinematics.lift

    @property
    def variant(self) -> str:
        """``"variable"`` or ``"constant_ratio"``."""
        return self.kinematics.variant

    def with_rig(self, rig) -> ValveTrain:
        """The same kinematics and options with other dynamic parameters (the geometry and lift
        must be the same: the kinematics are not rebuilt)."""
        return replace(self, rig=rig, p=None)

    def tappet(self, speed_hz: float, alpha: float | None = None, beta: float | None = None) -> tuple[float, ...]:
        """``(alpha, beta, c_plus, c_minus, k_t)`` at a speed: the rig's speed law unless given."""
        a, b = self.rig.tappet_weights(speed_hz)
        a = a if alpha is None else float(alpha)
        b = b if beta is None else float(beta)
        if not (math.isfinite(a) and a >= 0.0 and math.isfinite(b) and b >= 0.0):
            raise SimulationInputError(f"tappet weights must be finite and >= 0, got alpha={a!r}, beta={b!r}")
        return a, b, a * self.rig.C_d_plus, a * self.rig.C_d_minus, b * self.rig.K_e

    def run_tuple(self, omega: float, theta0: float, c_plus: float, c_minus: float, k_t: float) -> tuple:
        """The kernel's ``run`` argument."""
        coef = self.kinematics.coef
        n = coef.shape[0]
        return (coef, n, TWO_PI / n, float(omega), float(theta0), float(c_plus), float(c_minus), float(k_t))


def prepare(rig, lift=None, *, variant: str = "variable", clip_tension: bool = False, moment_cos: bool = False,
            table_step_deg: float = TABLE_STEP_DEG) -> ValveTrain:
    """A rig ready to simulate: the kinematics tabulated with ``lift`` (default the rig's cycloidal
    law) and the model options (see :class:`ValveTrain`)."""
    kin = build_kinematics(rig, lift, variant=variant, step_deg=table_step_deg)
    return ValveTrain(rig=rig, kinematics=kin, clip_tension=bool(clip_tension), moment_cos=bool(moment_cos))


def _train(model) -> ValveTrain:
    if isinstance(model, ValveTrain):
        return model
    if hasattr(model, "model") and getattr(model, "model", "") == "finger-follower-hla":
        return prepare(model)
    raise SimulationInputError(f"expected a FingerFollowerRig or a ValveTrain, got {type(model).__name__}")


def rigid_jump_rpm(model) -> float:
    """Camshaft speed [rpm] at which the rigid train on a massless valve spring first loses the cam.

    The rigid follower turns about the tappet contact, so the moving parts reduced to the valve are
    ``m = M_v + (I_f + M_f L_tf^2) / (L_tf + L_vf)^2``. The cam force vanishes where their inertia on
    the closing flank, ``m omega^2 (-Y_v'')``, reaches the valve spring's force ``F_o + K0 Y_v``
    (``Y_v`` the kinematic valve lift (K-7f), a prime ``d/dtheta``), so ``omega_jump^2`` is the
    minimum of ``(F_o + K0 Y_v) / (m (-Y_v''))`` where ``Y_v'' < 0`` (the analogue of the cycloidal
    rig's :func:`~impactid.rigs.cycloidal.cam.rigid_jump_speed`; the small HLA preload, the spring
    masses and the contact compliances are left out). For :data:`KIM1990` it is 3303 rpm, 6 % above
    the simulated jump speed (3130 rpm). Infinite for a lift without deceleration.
    """
    train = _train(model)
    rig, kin = train.rig, train.kinematics
    lift = np.asarray(kin.values["Y_v_kin"])
    curvature = np.asarray(kin("Y_v_kin", kin.theta, 2))
    mass = rig.M_v + (rig.I_f + rig.M_f * rig.L_tf**2) / rig.L_sum**2
    closing = curvature < -1e-9 * float(np.max(np.abs(curvature)))  # not the spline's round-off on the base circle
    if not closing.any():
        return math.inf
    omega2 = float(np.min((rig.F_o + rig.K0 * lift[closing]) / (mass * -curvature[closing])))
    return math.sqrt(omega2) * 60.0 / TWO_PI


def speed_range(model) -> CamSpeedRange:
    """The camshaft speeds the model is used at: 1/300 to 3 times :func:`rigid_jump_rpm` (the decision
    is documented in :class:`~impactid.rigs.valvespring.CamSpeedRange`)."""
    return CamSpeedRange(rigid_jump_rpm(model))


def _speed(rpm: float) -> float:
    value = float(rpm)
    if not (math.isfinite(value) and value > 0.0):
        raise SimulationInputError(f"camshaft speed must be positive and finite, got {rpm!r} rpm")
    return value / 60.0


# --------------------------------------------------------------------------------------------
# Runs
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Run:
    """A simulated run, sampled on a grid of cam angles.

    Attributes
    ----------
    rpm : camshaft speed [rpm]; ``alpha``, ``beta`` the tappet weights used.
    t : sample times [s] from the run's start; ``theta`` the cam angles [rad] (unwrapped,
        0 at the nose).
    y : states (n x 12) [m, rad, m/s, rad/s] (see :data:`STATE_NAMES`).
    mode : the kernel's mode bit mask at each sample.
    forces : contact forces and accelerations (n x 11): ``F_tf, F_fc, F_vf, R_seat, F_drag`` [N]
        then the six accelerations [m/s^2, rad/s^2].
    events : table of switches, with columns switch, what, contact, direction, t_s,
        cam_angle_rad, cam_angle_deg (wrapped to [-180, 180)), revolution (from 0), Y_v, Y_v_dot,
        Y_t [m, m/s, m] and the forces before the switch.
    y_end, signs_end, t_end : state, sign bookkeeping and time at the end (to continue a run).
    theta_start : cam angle at ``t = 0`` [rad].
    steps, rejected : integrator statistics.
    """

    rpm: float
    alpha: float
    beta: float
    t: np.ndarray
    theta: np.ndarray
    y: np.ndarray
    mode: np.ndarray
    forces: np.ndarray
    events: pd.DataFrame
    y_end: np.ndarray
    signs_end: np.ndarray
    t_end: float
    theta_start: float
    steps: int
    rejected: int

    @property
    def theta_deg(self) -> np.ndarray:
        """Cam angle wrapped to [-180, 180) deg."""
        return (self.theta / DEG + 180.0) % 360.0 - 180.0

    def channel(self, name: str) -> np.ndarray:
        """A coordinate (``Y_t``, ``Y_v``, ...), a rate (``Y_v_dot``, ...), a force (``F_fc``, ...) or
        an acceleration (``Y_v_ddot``, ...) along the run."""
        names = {n: i for i, n in enumerate(STATE_NAMES)}
        if name in names:
            return self.y[:, names[name]]
        if name.endswith("_dot") and not name.endswith("_ddot") and name[:-4] in names:
            return self.y[:, 6 + names[name[:-4]]]
        if name.endswith("_ddot") and name[:-5] in names:
            return self.forces[:, 5 + names[name[:-5]]]
        forces = {"F_tf": 0, "F_fc": 1, "F_vf": 2, "F_seat": 3, "F_drag": 4}
        if name in forces:
            return self.forces[:, forces[name]]
        raise KeyError(f"no channel {name!r} (coordinates {', '.join(STATE_NAMES)}, their _dot and _ddot, "
                       f"forces {', '.join(forces)})")


def simulate(model, rpm: float, *, revolutions: float = 1.0, start: tuple | None = None, theta_start: float = -math.pi,
             grid_step_deg: float = 0.05, grid: np.ndarray | None = None, alpha: float | None = None,
             beta: float | None = None, tolerances: Tolerances = DEFAULT_TOLERANCES) -> Run:
    """Integrate the valve train at a constant camshaft speed.

    Parameters
    ----------
    model : a :class:`ValveTrain` (or a rig, prepared with its default lift).
    rpm : camshaft speed [rpm].
    revolutions : length of the run [revolutions].
    start : ``(y, signs)`` to continue from (a previous run's ``y_end, signs_end``); default the
        static equilibrium on the base circle at rest.
    theta_start : cam angle at the start [rad] (default -pi, on the base circle opposite the nose).
    grid_step_deg : output every this many degrees of cam angle from the start (ignored with ``grid``).
    grid : output times [s] from the start (sorted, within the run).
    alpha, beta : tappet weights; default the rig's speed law.
    tolerances : :class:`Tolerances`.

    Raises
    ------
    SimulationError
        when the integrator fails (with the kernel's reason).
    """
    train = _train(model)
    speed_hz = _speed(rpm)
    if not (math.isfinite(revolutions) and revolutions > 0.0):
        raise SimulationInputError(f"revolutions must be positive, got {revolutions!r}")
    a, b, c_plus, c_minus, k_t = train.tappet(speed_hz, alpha, beta)
    omega = TWO_PI * speed_hz
    period = 1.0 / speed_hz
    t_end = revolutions * period
    if grid is None:
        n = int(math.floor(revolutions * 360.0 / grid_step_deg + 1e-9)) + 1
        grid = np.arange(n) * (grid_step_deg * DEG / omega)
        grid = grid[grid <= t_end * (1 + 1e-12)]
    grid = np.ascontiguousarray(grid, dtype=float)
    if grid.size and (np.any(np.diff(grid) < 0.0) or grid[0] < 0.0 or grid[-1] > t_end * (1 + 1e-12)):
        raise SimulationInputError("output grid must be sorted and lie within the run")
    run = train.run_tuple(omega, theta_start, c_plus, c_minus, k_t)
    if start is None:
        y = np.zeros(12)
        signs = np.zeros(KN.N_SW)
        KN.initial_signs(0.0, y, train.p, run, signs)
    else:
        y = np.array(start[0], dtype=float).copy()
        signs = np.array(start[1], dtype=float).copy()
        if y.shape != (12,) or signs.shape != (KN.N_SW,):
            raise SimulationInputError("start must be (state of 12, signs of 9)")
    out_y = np.zeros((grid.size, 12))
    out_mode = np.zeros(grid.size, dtype=np.int64)
    capacity = int(tolerances.max_events_per_revolution * max(1.0, revolutions)) + 16
    events = np.zeros((capacity, KN.N_ECOL))
    max_steps = int(tolerances.max_steps_per_revolution * max(1.0, revolutions))
    end = KN.integrate(train.p, run, 0.0, y, signs, t_end, tolerances.rtol, tolerances.atol(train.rig),
                       tolerances.max_step_revolutions * period, 0.0, max_steps, grid, out_y, out_mode, events)
    if end.status != KN.OK:
        recent = events[max(0, min(end.n_events, capacity) - 4):min(end.n_events, capacity)]
        last = ", ".join(f"{KN.SWITCH_NAMES[int(e[KN.E_KIND])]} {'rising' if e[KN.E_DIR] > 0 else 'falling'} at "
                         f"{math.degrees(e[KN.E_THETA]):.4f} deg" for e in recent)
        raise SimulationError(f"finger-follower simulation at {rpm:.6g} rpm failed at t = {end.t:.6g} s "
                              f"(cam angle {math.degrees(theta_start + omega * end.t):.3f} deg): "
                              f"{KN.STATUS_MESSAGES.get(end.status, end.status)}"
                              + (f"; last switches: {last}" if last else ""))
    if end.n_events > capacity:
        raise SimulationError(f"finger-follower simulation at {rpm:.6g} rpm: {end.n_events} switching events, more "
                              f"than the table holds ({capacity}); the contacts chatter")
    forces = np.zeros((grid.size, 11))
    if grid.size:
        KN.observe(grid, out_y, out_mode, train.p, run, forces)
    table = _event_table(events[:end.n_events], theta_start, period)
    return Run(rpm=float(rpm), alpha=a, beta=b, t=grid, theta=theta_start + omega * grid, y=out_y, mode=out_mode,
               forces=forces, events=table, y_end=y, signs_end=signs, t_end=float(end.t), theta_start=theta_start,
               steps=int(end.n_steps), rejected=int(end.n_rejected))


def _event_table(ev: np.ndarray, theta_start: float, period: float) -> pd.DataFrame:
    kinds = ev[:, KN.E_KIND].astype(int)
    dirs = ev[:, KN.E_DIR].astype(int)
    theta = ev[:, KN.E_THETA]
    return pd.DataFrame({
        "switch": [KN.SWITCH_NAMES[k] for k in kinds],
        "what": [_WHAT.get((k, d), f"{KN.SWITCH_NAMES[k]} {d:+d}") for k, d in zip(kinds, dirs)],
        "contact": [CONTACTS.get(k, "seat" if k == KN.G_SEAT else "tappet damping") for k in kinds],
        "direction": dirs,
        "t_s": ev[:, KN.E_T],
        "cam_angle_rad": theta,
        "cam_angle_deg": (theta / DEG + 180.0) % 360.0 - 180.0,
        "revolution": np.floor((ev[:, KN.E_T] + 1e-12 * period) / period).astype(int),
        "Y_v": ev[:, KN.E_Y + 5], "Y_v_dot": ev[:, KN.E_Y + 11], "Y_t": ev[:, KN.E_Y + 0],
        "F_tf": ev[:, KN.E_F], "F_fc": ev[:, KN.E_F + 1], "F_vf": ev[:, KN.E_F + 2], "F_seat": ev[:, KN.E_F + 3],
    })


# --------------------------------------------------------------------------------------------
# Periodic steady state
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class SteadyState:
    """The periodic steady state at one speed (or the last revolutions of a run that did not settle).

    Attributes
    ----------
    rpm, alpha, beta : speed [rpm] and tappet weights.
    revolutions : the last ``period`` revolutions (``Run`` objects from -180 deg each); when the run
        did not settle, the last ``keep`` revolutions.
    converged : whether the Poincare section repeated within ``tol``.
    period : the period in revolutions (1 for the usual period-1 orbit; 0 when not periodic).
    history : per revolution of the run-in: ``revolution, difference`` (largest state change at
        -180 deg against one revolution earlier, in units of 1 um and 1 mm/s), ``max_Y_t``,
        ``max_Y_v``, ``openings``, ``steps``.
    tol : the convergence tolerance used.
    event_deg : cam angles of the start and end of the lift event [deg] (from the lift law).
    notes : what qualifies the result.
    """

    rpm: float
    alpha: float
    beta: float
    revolutions: tuple
    converged: bool
    period: int
    history: pd.DataFrame
    tol: float
    event_deg: tuple = (-90.0, 90.0)
    notes: tuple = ()

    @property
    def revolution(self) -> Run:
        """The last revolution."""
        return self.revolutions[-1]

    @property
    def start(self) -> tuple[np.ndarray, np.ndarray]:
        """State and signs at the end (to start another speed or another parameter set from)."""
        last = self.revolutions[-1]
        return last.y_end, last.signs_end

    @property
    def events(self) -> pd.DataFrame:
        """Switching events of the kept revolutions (``revolution`` numbered from 0)."""
        frames = []
        for k, rev in enumerate(self.revolutions):
            e = rev.events.copy()
            e["revolution"] = k
            frames.append(e)
        return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()

    def interpolate(self, name: str, theta) -> np.ndarray:
        """A channel of the last revolution (see :meth:`Run.channel`) at cam angles [rad] (periodic
        cubic interpolation of the output grid)."""
        from scipy.interpolate import CubicSpline

        rev = self.revolution
        x = rev.theta
        values = rev.channel(name)
        if abs((x[-1] - x[0]) - TWO_PI) < 1e-9:
            x, values = x[:-1], values[:-1]
        spline = CubicSpline(np.append(x, x[0] + TWO_PI), np.append(values, values[0]), bc_type="periodic")
        u = (np.asarray(theta, dtype=float) - x[0]) % TWO_PI + x[0]
        return spline(u)

    def summary(self) -> dict[str, Any]:
        """:func:`summarize` of the kept revolutions."""
        return summarize(self)


def _section_difference(a: np.ndarray, b: np.ndarray, L_vf: float) -> float:
    scale = np.array([_SCALE_DISPLACEMENT] * 6 + [_SCALE_RATE] * 6)
    scale[2] /= L_vf
    scale[8] /= L_vf
    return float(np.max(np.abs(a - b) / scale))


def steady_state(model, rpm: float, *, alpha: float | None = None, beta: float | None = None, tol: float = 1e-4,
                 min_revolutions: int = 2, max_revolutions: int = 60, max_period: int = 4, keep: int = 4,
                 start: tuple | None = None, grid_step_deg: float = 0.05, grid_deg: np.ndarray | None = None,
                 tolerances: Tolerances = DEFAULT_TOLERANCES) -> SteadyState:
    """The periodic steady state at a camshaft speed, found by a run-in with a convergence test.

    Revolutions are integrated one after another from ``start`` (default: rest on the base circle
    at -180 deg). After each, the state at -180 deg is compared with the states 1 to
    ``max_period`` revolutions earlier; the orbit is periodic when the largest difference is below
    ``tol`` in units of 1 um (displacements, the rotation at the valve lever arm) and 1 mm/s
    (rates): with ``tol = 1e-4``, 0.1 nm and 0.1 um/s, about 100 times the integration error.

    Parameters
    ----------
    model : :class:`ValveTrain` or rig.
    rpm : camshaft speed [rpm].
    alpha, beta : tappet weights (default the rig's speed law).
    tol, min_revolutions, max_revolutions, max_period : the convergence test and its limits.
    keep : revolutions kept when the run does not settle.
    start : ``(y, signs)`` at -180 deg, e.g. the :attr:`SteadyState.start` of a nearby speed or
        tappet (a warm start; it does not change the result, only the time to reach it).
    grid_step_deg, grid_deg : output grid of each revolution: every ``grid_step_deg`` from -180
        deg, or the cam angles ``grid_deg`` [deg] in [-180, 180) (sorted).
    """
    train = _train(model)
    speed_hz = _speed(rpm)
    a, b, *_ = train.tappet(speed_hz, alpha, beta)
    period_s = 1.0 / speed_hz
    omega = TWO_PI * speed_hz
    if grid_deg is None:
        n = int(round(360.0 / grid_step_deg))
        grid_deg = -180.0 + np.arange(n + 1) * (360.0 / n)
    grid = (np.asarray(grid_deg, dtype=float) + 180.0) * DEG / omega
    grid = np.clip(grid, 0.0, period_s)
    sections = []
    current = start
    if current is None:
        y0 = np.zeros(12)
        s0 = np.zeros(KN.N_SW)
        KN.initial_signs(0.0, y0, train.p, train.run_tuple(omega, -math.pi, 0.0, 0.0, 0.0), s0)
        current = (y0, s0)
    sections.append(np.array(current[0], dtype=float))
    runs: list[Run] = []
    rows = []
    converged = False
    period = 0
    for k in range(1, max_revolutions + 1):
        rev = simulate(train, rpm, revolutions=1.0, start=current, grid=grid, alpha=a, beta=b, tolerances=tolerances)
        runs.append(rev)
        runs = runs[-max(keep, max_period):]
        sections.append(rev.y_end.copy())
        diffs = [(_section_difference(sections[-1], sections[-1 - q], train.rig.L_vf) if len(sections) > q
                  else math.inf)
                 for q in range(1, max_period + 1)]
        opens = int(((rev.events["switch"] == "g_seat") & (rev.events["direction"] > 0)).sum())
        rows.append({"revolution": k, "difference": diffs[0], "max_Y_t": float(rev.y[:, 0].max()),
                     "max_Y_v": float(rev.y[:, 5].max()), "openings": opens, "steps": rev.steps})
        current = (rev.y_end, rev.signs_end)
        if k >= min_revolutions:
            for q, d in enumerate(diffs, start=1):
                if d < tol and k >= q + min_revolutions - 1:
                    converged = True
                    period = q
                    break
        if converged:
            break
    notes = []
    if converged:
        kept = tuple(runs[-period:])
        if period > 1:
            notes.append(f"period-{period} orbit: the motion repeats every {period} revolutions")
    else:
        kept = tuple(runs[-keep:])
        notes.append(f"no periodic steady state within {max_revolutions} revolutions (last section difference "
                     f"{rows[-1]['difference']:.3g} against the tolerance {tol:g}); the last {len(kept)} revolutions "
                     "are reported")
    event = tuple(math.degrees(x) for x in train.lift.event)
    return SteadyState(rpm=float(rpm), alpha=a, beta=b, revolutions=kept, converged=converged, period=period,
                       history=pd.DataFrame(rows), tol=tol, event_deg=event, notes=tuple(notes))


# --------------------------------------------------------------------------------------------
# Summary of a steady state
# --------------------------------------------------------------------------------------------


def _intervals(events: pd.DataFrame, switch: str) -> list[tuple[float | None, float | None]]:
    """Pairs (falling, rising) of one switching function within a revolution, by cam angle [deg];
    ``None`` for an end outside the revolution (it began in the previous one or ends in the next)."""
    out = []
    start = None
    lead = None
    for _, e in events[events["switch"] == switch].iterrows():
        if e["direction"] < 0:
            start = float(e["cam_angle_deg"])
        elif start is None:
            lead = float(e["cam_angle_deg"])
        else:
            out.append((start, float(e["cam_angle_deg"])))
            start = None
    if start is not None:
        out.append((start, lead))
    elif lead is not None:
        out.append((None, lead))
    return out


def summarize(state: SteadyState, flank_fraction: float = 1.0 / 3.0) -> dict[str, Any]:
    """What a steady state means for the engine (SI units, cam angles in degrees from the nose).

    Keys
    ----
    ``max_valve_lift_m``, ``cam_angle_max_lift_deg``; ``max_tappet_leakdown_m``,
    ``cam_angle_max_leakdown_deg``; ``seating_velocity_m_s`` (``Y_v'`` at the valve's closing after
    its maximum lift, negative = towards the seat) and ``seating_speed_m_s`` (its magnitude);
    ``peak_cam_force_opening_N`` and ``peak_cam_force_closing_N`` (largest cam/follower force on
    the opening and closing flank: the cam event without its middle ``flank_fraction``, so that the
    nose hump is not taken for a flank peak; the paper's "first" and "second" peak) with their
    angles, ``peak_cam_force_nose_N``; ``min_``/``max_`` of every contact force; ``valve_opens_deg``,
    ``valve_closes_deg`` (the main opening); ``openings_per_revolution`` (largest over the kept
    revolutions), ``bounce`` (more than one), ``bounces`` (each reopening: angles and height above
    the lift-off point); ``jump`` (the cam/follower criterion holds during the cam event) and
    ``jumps``; ``separations`` (every interval in which a contact criterion holds: ``contact,
    start_deg, end_deg, revolution``); ``converged``, ``period``, ``revolutions_run``.
    """
    revs = state.revolutions
    last = revs[-1]
    th = last.theta_deg
    out: dict[str, Any] = {"rpm": state.rpm, "alpha": state.alpha, "beta": state.beta,
                           "converged": state.converged, "period": state.period,
                           "revolutions_run": int(len(state.history))}
    yv = last.y[:, 5]
    yt = last.y[:, 0]
    i = int(np.argmax(yv))
    out["max_valve_lift_m"] = float(yv[i])
    out["cam_angle_max_lift_deg"] = float(th[i])
    j = int(np.argmax(yt))
    out["max_tappet_leakdown_m"] = float(yt[j])
    out["cam_angle_max_leakdown_deg"] = float(th[j])
    ev0, ev1 = state.event_deg
    F = last.channel("F_fc")
    windows = {"opening": (th >= ev0) & (th <= ev0 * flank_fraction),
               "closing": (th >= ev1 * flank_fraction) & (th <= ev1),
               "nose": (th > ev0 * flank_fraction) & (th < ev1 * flank_fraction)}
    for name, mask in windows.items():
        if mask.any():
            k = int(np.argmax(np.where(mask, F, -np.inf)))
            out[f"peak_cam_force_{name}_N"] = float(F[k])
            out[f"cam_angle_peak_{name}_deg"] = float(th[k])
        else:
            out[f"peak_cam_force_{name}_N"] = math.nan
            out[f"cam_angle_peak_{name}_deg"] = math.nan
    for name in ("F_tf", "F_fc", "F_vf", "F_seat"):
        values = np.concatenate([r.channel(name) for r in revs])
        out[f"min_{name}_N"] = float(values.min())
        out[f"max_{name}_N"] = float(values.max())
    events = state.events
    seat = events[events["switch"] == "g_seat"]
    opens = seat[seat["direction"] > 0]
    per_rev = [int((opens["revolution"] == k).sum()) for k in range(len(revs))]
    out["openings_per_revolution"] = max(per_rev) if per_rev else 0
    out["bounce"] = out["openings_per_revolution"] > 1
    last_events = events[events["revolution"] == len(revs) - 1]
    lo = last_events[(last_events["switch"] == "g_seat") & (last_events["direction"] > 0)]
    lc = last_events[(last_events["switch"] == "g_seat") & (last_events["direction"] < 0)]
    main_open = lo[lo["cam_angle_deg"] < out["cam_angle_max_lift_deg"]]
    main_close = lc[lc["cam_angle_deg"] > out["cam_angle_max_lift_deg"]]
    out["valve_opens_deg"] = float(main_open["cam_angle_deg"].iloc[-1]) if len(main_open) else math.nan
    out["valve_closes_deg"] = float(main_close["cam_angle_deg"].iloc[0]) if len(main_close) else math.nan
    if len(main_close):
        v = float(main_close["Y_v_dot"].iloc[0])
        out["seating_velocity_m_s"] = v
        out["seating_speed_m_s"] = abs(v)
    else:
        out["seating_velocity_m_s"] = math.nan
        out["seating_speed_m_s"] = math.nan
    bounces = []
    for k, rev in enumerate(revs):
        e = rev.events
        ro = e[(e["switch"] == "g_seat") & (e["direction"] > 0)]
        rc = e[(e["switch"] == "g_seat") & (e["direction"] < 0)]
        if len(ro) <= 1:
            continue
        thr = rev.theta_deg
        imain = int(np.argmax(rev.y[:, 5]))
        for _, o in ro.iterrows():
            a = float(o["cam_angle_deg"])
            if a < thr[imain]:
                continue  # the main opening
            later = rc[rc["cam_angle_deg"] > a]
            b = float(later["cam_angle_deg"].iloc[0]) if len(later) else None
            mask = (thr >= a) & (thr <= (b if b is not None else 180.0))
            height = float(rev.y[mask, 5].max()) if mask.any() else math.nan
            bounces.append({"revolution": k, "opens_deg": a, "closes_deg": b, "max_lift_m": height})
    out["bounces"] = bounces
    seps = []
    for k, rev in enumerate(revs):
        for switch, contact in (("g_tf", "tappet/follower"), ("g_fc", "cam/follower"), ("g_vf", "valve/follower"),
                                ("h_tf", "tappet/follower"), ("h_fc", "cam/follower"), ("h_vf", "valve/follower")):
            for a, b in _intervals(rev.events, switch):
                seps.append({"contact": contact, "criterion": "deflection" if switch[0] == "g" else "force",
                             "start_deg": a, "end_deg": b, "revolution": k})
    out["separations"] = seps
    jumps = [s for s in seps if s["contact"] == "cam/follower"
             and any(x is not None and ev0 <= x <= ev1 for x in (s["start_deg"], s["end_deg"]))]
    out["jump"] = bool(jumps)
    out["jumps"] = jumps
    out["tappet_separation"] = any(s["contact"] == "tappet/follower" for s in seps)
    out["notes"] = list(state.notes)
    return out


# --------------------------------------------------------------------------------------------
# Statics and linearised modes
# --------------------------------------------------------------------------------------------

_ALL_CONTACTS = KN.M_TF | KN.M_FC | KN.M_VF | KN.M_TPOS


def _generalised_forces(train: ValveTrain, theta: float, q: np.ndarray, mode: int, k_t: float) -> np.ndarray:
    run = train.run_tuple(0.0, theta, 0.0, 0.0, k_t)
    y = np.concatenate([q, np.zeros(6)])
    K = np.empty((1, 12))
    mon = np.empty(KN.N_MON)
    KN.evaluate(mode, 0.0, y, train.p, run, K, 0, mon)
    return K[0, 6:] * _mass_diagonal(train.rig)


def _mass_diagonal(rig) -> np.ndarray:
    m = rig.surge.mass
    return np.array([rig.M_t, rig.M_f, rig.I_f, m, m, rig.M_v])


def static_equilibrium(model, theta: float, *, beta: float | None = None, speed_hz: float | None = None,
                       seated: bool | None = None) -> np.ndarray:
    """Static equilibrium with the cam held at ``theta`` [rad], all three contacts carrying load.

    The tappet's static stiffness is ``K_s + beta K_e`` (the elastic part of the drag force);
    ``beta`` from the rig's speed law at ``speed_hz`` unless given. ``seated`` forces the valve
    branch (default: the one consistent with the solution). Returns the six coordinates.
    """
    train = _train(model)
    rig = train.rig
    if beta is None:
        beta = rig.tappet_weights(speed_hz if speed_hz is not None else rig.speed_1_hz)[1]
    k_t = beta * rig.K_e
    phi = float(train.kinematics("phi", theta))
    yv = rig.L_sum * math.sin(phi)
    guess = np.array([0.0, rig.L_tf * math.sin(phi), phi, 0.6 * yv, 0.3 * yv, yv])
    steps = np.array([1e-9, 1e-9, 1e-7, 1e-9, 1e-9, 1e-9])
    branches = [seated] if seated is not None else [True, False]
    for branch in branches:
        mode = _ALL_CONTACTS | (KN.M_SEAT if branch else 0)
        q = guess.copy()
        for _ in range(60):
            f = _generalised_forces(train, theta, q, mode, k_t)
            J = np.empty((6, 6))
            for j in range(6):
                dq = np.zeros(6)
                dq[j] = steps[j]
                J[:, j] = (_generalised_forces(train, theta, q + dq, mode, k_t)
                           - _generalised_forces(train, theta, q - dq, mode, k_t)) / (2.0 * steps[j])
            dq = np.linalg.solve(J, -f)
            q = q + dq
            if np.all(np.abs(dq) < 1e-15 * (1.0 + np.abs(q))):
                break
        residual = np.abs(_generalised_forces(train, theta, q, mode, k_t)).max()
        consistent = (q[5] < rig.Y_v_star) == branch
        if residual < 1e-8 and (consistent or seated is not None):
            return q
    raise SimulationError(f"no static equilibrium found with the cam held at {math.degrees(theta):.3f} deg")


@dataclass(frozen=True)
class Modes:
    """Linearised undamped modes of the train with the cam held.

    Attributes
    ----------
    frequencies_hz : natural frequencies, ascending [Hz].
    shapes : mode shapes (6 x n, columns), each scaled to unit largest physical displacement
        (the rotation taken at the valve lever arm).
    dominant : for each mode, the coordinate with the largest share of kinetic energy.
    equilibrium : the coordinates about which the train was linearised.
    stiffness, mass : the matrices ``-dF/dq`` and ``diag(M)`` (SI).
    theta : the cam angle held [rad]; ``seated`` the valve branch; ``beta`` the tappet weight.
    """

    frequencies_hz: np.ndarray
    shapes: np.ndarray
    dominant: tuple
    equilibrium: np.ndarray
    stiffness: np.ndarray
    mass: np.ndarray
    theta: float
    seated: bool
    beta: float

    def to_dict(self) -> dict[str, Any]:
        return {"frequencies_hz": self.frequencies_hz.tolist(), "dominant": list(self.dominant),
                "cam_angle_deg": math.degrees(self.theta), "valve": "seated" if self.seated else "open",
                "beta": self.beta, "equilibrium": dict(zip(STATE_NAMES, self.equilibrium.tolist()))}


def natural_frequencies(model, valve: str = "seated", *, theta: float | None = None, beta: float | None = None,
                        speed_hz: float | None = None) -> Modes:
    """Natural frequencies of the train linearised with the cam held.

    Parameters
    ----------
    valve : ``"seated"`` (cam on the base circle at -180 deg, about the rest state, seat spring
        ``K_se`` active) or ``"open"`` (cam held at ``theta``, default the nose, valve open, about the
        static equilibrium there).
    theta : cam angle held [rad] (only for ``"open"``; a seated valve is on the base circle).
    beta, speed_hz : tappet weight (default the rig's law at ``speed_hz``, itself defaulting to
        the first identified speed).

    All three contacts are linear springs; the tappet plunger is tied to ground by ``K_s + beta
    K_e`` (the elastic part of the drag force; the dashpot ``alpha C_d`` is left out as all damping
    is); the spring masses by the surge springs; the valve by ``K_se`` when seated.
    """
    train = _train(model)
    rig = train.rig
    if beta is None:
        beta = rig.tappet_weights(speed_hz if speed_hz is not None else rig.speed_1_hz)[1]
    if valve == "seated":
        th = -math.pi
        q0 = np.zeros(6)
        seated = True
    elif valve == "open":
        th = 0.0 if theta is None else float(theta)
        q0 = static_equilibrium(train, th, beta=beta, seated=False)
        if q0[5] < rig.Y_v_star:
            raise SimulationInputError(f"the valve is not open with the cam held at {math.degrees(th):.2f} deg")
        seated = False
    else:
        raise ValueError(f"valve must be 'seated' or 'open', got {valve!r}")
    mode = _ALL_CONTACTS | (KN.M_SEAT if seated else 0)
    k_t = beta * rig.K_e
    steps = np.array([1e-9, 1e-9, 1e-7, 1e-9, 1e-9, 1e-9])
    K = np.empty((6, 6))
    for j in range(6):
        dq = np.zeros(6)
        dq[j] = steps[j]
        K[:, j] = -(_generalised_forces(train, th, q0 + dq, mode, k_t)
                    - _generalised_forces(train, th, q0 - dq, mode, k_t)) / (2.0 * steps[j])
    M = _mass_diagonal(rig)
    values, vectors = np.linalg.eig(K / M[:, None])
    order = np.argsort(values.real)
    freqs = np.sqrt(np.abs(values.real[order])) / TWO_PI
    shapes = vectors[:, order].real.copy()
    physical = shapes.copy()
    physical[2] *= rig.L_vf
    dominant = []
    for c in range(6):
        energy = M * shapes[:, c] ** 2
        dominant.append(STATE_NAMES[int(np.argmax(energy))])
        scale = physical[:, c][int(np.argmax(np.abs(physical[:, c])))]
        shapes[:, c] /= scale
    return Modes(frequencies_hz=freqs, shapes=shapes, dominant=tuple(dominant), equilibrium=q0, stiffness=K,
                 mass=np.diag(M), theta=th, seated=seated, beta=float(beta))


# --------------------------------------------------------------------------------------------
# Speed sweeps: leak-down, jump and bounce speeds
# --------------------------------------------------------------------------------------------


def leakdown_curve(model, rpms: Sequence[float], **options) -> pd.DataFrame:
    """Maximum tappet leak-down in the steady state against camshaft speed (the paper's Fig. 8).

    Returns a table ``rpm, alpha, beta, max_tappet_leakdown_m, cam_angle_max_leakdown_deg,
    max_valve_lift_m, converged, failure``. A speed the integrator cannot follow (chatter, step
    budget) does not take the others with it: its row holds NaN and ``failure`` says why (empty for
    the speeds that ran).
    """
    train = _train(model)
    rows = []
    start = None
    for rpm in rpms:
        try:
            st = steady_state(train, rpm, start=start, **options)
        except SimulationError as exc:
            rows.append({"rpm": float(rpm), "alpha": math.nan, "beta": math.nan, "max_tappet_leakdown_m": math.nan,
                         "cam_angle_max_leakdown_deg": math.nan, "max_valve_lift_m": math.nan, "converged": False,
                         "failure": str(exc)})
            continue
        start = st.start
        s = summarize(st)
        rows.append({"rpm": float(rpm), "alpha": st.alpha, "beta": st.beta,
                     "max_tappet_leakdown_m": s["max_tappet_leakdown_m"],
                     "cam_angle_max_leakdown_deg": s["cam_angle_max_leakdown_deg"],
                     "max_valve_lift_m": s["max_valve_lift_m"], "converged": st.converged, "failure": ""})
    return pd.DataFrame(rows)


@dataclass(frozen=True)
class CriticalSpeeds:
    """Jump and bounce speeds from a speed sweep refined by bisection.

    Attributes
    ----------
    jump_speed_rpm : lowest camshaft speed [rpm] at which the follower leaves the cam during the
        cam event in the steady state (NaN if none in the range); ``bounce_speed_rpm`` the same for
        the valve reopening after closing (more than one opening per revolution).
    resolution_rpm : bisection resolution (the speeds are within this of the transition).
    sweep : table of the sweep and bisection runs, with columns rpm, jump, bounce,
        tappet_separation, converged, period, max_valve_lift_m, seating_speed_m_s,
        peak_cam_force_closing_N, min_F_fc_N, failure and stage (``sweep`` or ``bisection``;
        ``failure`` says why a speed could not be simulated, empty otherwise).
    notes : what qualifies the result (a transition that is not monotone in speed, runs that did
        not settle, no transition in the range).
    """

    jump_speed_rpm: float
    bounce_speed_rpm: float
    resolution_rpm: float
    sweep: pd.DataFrame
    notes: tuple = ()

    def to_dict(self) -> dict[str, Any]:
        return {"jump_speed_rpm": self.jump_speed_rpm, "bounce_speed_rpm": self.bounce_speed_rpm,
                "resolution_rpm": self.resolution_rpm, "notes": list(self.notes),
                "sweep": self.sweep.to_dict(orient="records")}


def _flags(train: ValveTrain, rpm: float, start, options) -> tuple[dict, Any]:
    """The flags of one speed; a speed the integrator cannot follow gives a row with ``failure`` set
    (and no flags) and the warm start it was given."""
    try:
        st = steady_state(train, rpm, start=start, **options)
    except SimulationError as exc:
        return {"rpm": float(rpm), "jump": None, "bounce": None, "tappet_separation": None, "converged": False,
                "period": 0, "max_valve_lift_m": math.nan, "seating_speed_m_s": math.nan,
                "peak_cam_force_closing_N": math.nan, "min_F_fc_N": math.nan, "failure": str(exc)}, start
    s = summarize(st)
    row = {"rpm": float(rpm), "jump": s["jump"], "bounce": s["bounce"], "tappet_separation": s["tappet_separation"],
           "converged": st.converged, "period": st.period, "max_valve_lift_m": s["max_valve_lift_m"],
           "seating_speed_m_s": s["seating_speed_m_s"], "peak_cam_force_closing_N": s["peak_cam_force_closing_N"],
           "min_F_fc_N": s["min_F_fc_N"], "failure": ""}
    return row, st.start


def critical_speeds(model, *, rpm_from: float = 1000.0, rpm_to: float = 6000.0, step_rpm: float = 250.0,
                    resolution_rpm: float = 1.0, **options) -> CriticalSpeeds:
    """Jump and bounce speeds: a sweep from ``rpm_from`` to ``rpm_to`` in steps of ``step_rpm``, then
    bisection of the first speed interval in which each flag turns on, to ``resolution_rpm``.

    A speed "jumps" when the cam/follower criterion (K-10) holds somewhere in the cam event in the
    steady state (or in the last revolutions of a run that does not settle); it "bounces" when the
    valve opens more than once per revolution. The reported speed is the upper end of the final
    bracket (the lowest speed found with the flag on). A flag that turns off again at a higher
    sweep speed is noted: bisection then finds the first transition only.

    A speed the integrator cannot follow (chatter, step budget) is listed in the table with its
    ``failure`` and left out of the decision, with a note; a bisection step that fails stops the
    bisection, and the note gives the bracket reached.
    """
    train = _train(model)
    if not (0.0 < rpm_from < rpm_to and step_rpm > 0.0 and resolution_rpm > 0.0):
        raise SimulationInputError("critical_speeds needs 0 < rpm_from < rpm_to, step_rpm > 0, resolution_rpm > 0")
    speeds = np.arange(rpm_from, rpm_to + 0.5 * step_rpm, step_rpm)
    rows = []
    start = None
    for rpm in speeds:
        row, start = _flags(train, float(rpm), start, options)
        row["stage"] = "sweep"
        rows.append(row)
    notes = []
    result = {}
    # the sweep alone (bisection runs of one flag must not count for the other), without failed speeds
    swept = [r for r in rows if not r["failure"]]
    failures = [r for r in rows if r["failure"]]
    if failures:
        listed = ", ".join(f"{r['rpm']:g}" for r in failures)
        notes.append(f"{len(failures)} sweep speed(s) could not be simulated and are left out ({listed} rpm; "
                     f"the first: {failures[0]['failure']})")
    for flag in ("jump", "bounce"):
        on = [r for r in swept if r[flag]]
        if not on:
            result[flag] = math.nan
            notes.append(f"no {flag} between {rpm_from:g} and {rpm_to:g} rpm")
            continue
        first = next(i for i, r in enumerate(swept) if r[flag])
        if first == 0:
            result[flag] = math.nan
            notes.append(f"{flag} already at the lowest speed of the sweep ({swept[0]['rpm']:g} rpm): lower rpm_from")
            continue
        if any(not r[flag] for r in swept[first:]):
            back = [r["rpm"] for r in swept[first:] if not r[flag]]
            notes.append(f"{flag} is not monotone in speed: off again at {', '.join(f'{x:g}' for x in back)} rpm "
                         "(the first transition is reported)")
        lo, hi = swept[first - 1]["rpm"], swept[first]["rpm"]
        while hi - lo > resolution_rpm:
            mid = 0.5 * (lo + hi)
            row, _ = _flags(train, mid, None, options)
            row["stage"] = "bisection"
            rows.append(row)
            if row["failure"]:
                notes.append(f"the {flag} bisection stopped at {mid:g} rpm, which could not be simulated "
                             f"({row['failure']}): the {flag} speed lies in ({lo:g}, {hi:g}] rpm")
                break
            if row[flag]:
                hi = mid
            else:
                lo = mid
        result[flag] = hi
    unsettled = [r["rpm"] for r in rows if not r["converged"] and not r["failure"]]
    if unsettled:
        notes.append(f"{len(unsettled)} run(s) did not reach a periodic steady state (from {min(unsettled):g} rpm); "
                     "their flags come from the last revolutions run")
    table = pd.DataFrame(rows).sort_values("rpm", kind="stable").reset_index(drop=True)
    return CriticalSpeeds(jump_speed_rpm=result["jump"], bounce_speed_rpm=result["bounce"],
                          resolution_rpm=float(resolution_rpm), sweep=table, notes=tuple(notes))


def warm_up() -> None:
    """The finger-follower simulator, a fifth of a revolution (``impactid warmup``)."""
    simulate(prepare(KIM1990), 1200.0, revolutions=0.2)

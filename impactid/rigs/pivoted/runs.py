"""Simulation runs of rig P built on the compiled hybrid integrator.

* :func:`simulate` — a long run (the papers' S2 with a :class:`~impactid.contact.HuntCrossley`
  law, S3 with a :class:`~impactid.contact.Restitution` law), from static equilibrium by default.
* :func:`simulate_event` — S1: one impact event from a measured state through the contact and
  the free flight to a given end time.
* :func:`simulate_events` — the batch entry point: many S1 events for many trial ``(beta, n)``
  in one call, in parallel on all cores, with no Python in the inner loop.

All inputs and outputs are SI: cam speed in Hz (``Theta_dot = 2 pi cam_speed_hz``), angles in rad.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from impactid.contact import HuntCrossley, Restitution
from impactid.errors import SimulationError, SimulationInputError
from impactid.rigs.pivoted import kernel as K
from impactid.rigs.pivoted.parameters import MODEL_NAME, SUNDAR2016, PivotedFollowerRig
from impactid.simulate.tolerances import DEFAULT_TOLERANCES, Tolerances

__all__ = ["BATCH_CHUNK_JOBS", "DEFAULT_TOLERANCES", "MODE_NAMES", "S1_CONTACT_ROWS", "S1_MAX_STEPS", "BatchResult",
           "EventResult", "Law", "SimulationResult", "Tolerances", "observables", "pack_law", "pack_rig",
           "simulate", "simulate_event", "simulate_events", "warm_up"]

Law = HuntCrossley | Restitution

MODE_NAMES = {K.FREE: "free", K.CONTACT: "contact", K.STICK: "stick"}

#: Step budget of one S1 event: a period-1 event takes about 150 steps, a chattering one a few
#: thousand; a trial law that needs more than this is reported as failed, not waited for.
S1_MAX_STEPS = 200_000
#: Contact-table rows kept per S1 run (only the first contact's summary is used; further contacts
#: are counted, see ``integrate(overflow_ok=True)``).
S1_CONTACT_ROWS = 64
#: Largest number of (trial, event) runs per compiled batch call (about 0.2 s on two cores).
BATCH_CHUNK_JOBS = 8192
_ROW_KINDS = {K.ROW_COMPLIANT: "contact", K.ROW_IMPACT: "impact", K.ROW_STICK: "stick"}




# ---------------------------------------------------------------------------------------------
# packing and validation
# ---------------------------------------------------------------------------------------------


#: The last rig (with its own ``mu``) and the last law packed, with their vectors: S1 events are
#: simulated by the thousand with one rig and law, and the identity check costs a tenth of the
#: ``lru_cache`` lookup, which hashes every field of the frozen dataclass (about 1 us for a rig).
_last_rig: tuple = (None, None)
_last_law: tuple = (None, None)


def pack_rig(rig: PivotedFollowerRig, mu: float | None = None) -> np.ndarray:
    """Rig parameters as the kernel's parameter vector (optionally overriding ``mu``).

    Cached per (rig, mu): rigs are frozen, and S1 events are simulated by the thousand."""
    global _last_rig
    last = _last_rig  # one read: another thread may replace it
    if mu is None and rig is last[0]:
        return last[1]
    if getattr(rig, "model", None) != MODEL_NAME:
        raise SimulationInputError(f"expected a {MODEL_NAME!r} rig, got {type(rig).__name__}")
    p = _pack_rig_cached(rig, None if mu is None else _finite("mu", mu))
    if mu is None:
        _last_rig = (rig, p)
    return p


@functools.lru_cache(maxsize=256)
def _pack_rig_cached(rig: PivotedFollowerRig, mu: float | None) -> np.ndarray:
    p = np.empty(K.N_RIG)
    p[K.PE_X], p[K.PE_Y], p[K.ECC] = rig.PE_x, rig.PE_y, rig.e
    p[K.RSUM], p[K.R_C], p[K.H_P] = rig.contact_radius, rig.r_c, rig.h_p
    p[K.M_B], p[K.GRAV], p[K.L_G] = rig.m_b, rig.g, rig.l_g
    p[K.K_S], p[K.L_SU], p[K.D_Y], p[K.D_X], p[K.W_B] = rig.k_s, rig.L_s_u, rig.d_y, rig.d_x, rig.w_b
    p[K.I_B], p[K.K_H] = rig.I_b, rig.k_H
    if mu is None:
        mu = rig.mu
    mu = _finite("mu", mu)
    if mu < 0.0:
        raise SimulationInputError(f"friction coefficient mu must be >= 0, got {mu!r}")
    p[K.MU] = mu
    p.setflags(write=False)
    return p


def pack_law(law: Law) -> np.ndarray:
    """Contact or restitution law as the kernel's law vector (cached; read-only)."""
    global _last_law
    last = _last_law
    if law is last[0]:
        return last[1]
    v = _pack_law_cached(law)
    _last_law = (law, v)
    return v


@functools.lru_cache(maxsize=256)
def _pack_law_cached(law: Law) -> np.ndarray:
    v = np.zeros(K.N_LAW)
    if isinstance(law, HuntCrossley):
        v[K.LAW_KIND] = K.KIND_COMPLIANT
        v[K.BETA], v[K.N_EXP], v[K.CLIP] = law.beta, law.n, float(law.clip)
        v[K.P_EXP] = law.stiffness_exponent
    elif isinstance(law, Restitution):
        v[K.LAW_KIND] = K.KIND_RESTITUTION
        v[K.XI0], v[K.GAMMA], v[K.V_STICK] = law.xi0, law.gamma, law.v_stick
        v[K.P_EXP] = 1.5
    else:
        raise SimulationInputError(f"law must be HuntCrossley or Restitution, got {type(law).__name__}")
    v.setflags(write=False)
    return v


def _finite(name: str, value) -> float:
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise SimulationInputError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(value):
        raise SimulationInputError(f"{name} must be finite, got {value!r}")
    return value


def _all_finite(a, b, c, d) -> bool:
    """True if the four values are finite numbers (the fast check of valid input; False also for
    values that :func:`_finite` accepts after converting them, such as numeric strings)."""
    try:
        return math.isfinite(a) and math.isfinite(b) and math.isfinite(c) and math.isfinite(d)
    except TypeError:
        return False


def _cam_speed(cam_speed_hz) -> float:
    cam_speed_hz = _finite("cam_speed_hz", cam_speed_hz)
    if cam_speed_hz <= 0.0:
        raise SimulationInputError(f"cam speed must be positive, got {cam_speed_hz!r} Hz")
    return cam_speed_hz


def _raise_status(status: int, what: str, t: float) -> None:
    if status != K.OK:
        raise SimulationError(f"{what}: {K.STATUS_MESSAGES.get(status, status)} (at t = {t:.9g} s)")


#: Columns of the contact frame after ``kind``, ``t_start``, ``t_end`` and ``duration``, and the
#: kernel's table columns they come from (``friction_reversals`` follows, as an integer column).
_CONTACT_COLUMNS = {
    "gap_rate_start": K.C_DPSI_START, "gap_rate_end": K.C_DPSI_END, "peak_indentation": K.C_PEAK_DELTA,
    "peak_force": K.C_PEAK_FORCE, "t_peak_force": K.C_T_PEAK_FORCE, "t_peak_indentation": K.C_T_PEAK_DELTA,
    "alpha_start": K.C_ALPHA_START, "alpha_dot_start": K.C_RATE_START, "alpha_end": K.C_ALPHA_END,
    "alpha_dot_end": K.C_RATE_END, "xi": K.C_XI,
}


def _contact_frame(table: np.ndarray) -> pd.DataFrame:
    """The kernel's contact table as the public DataFrame (one row per contact phase or impact).

    Built in one constructor call with every column in its place: inserting and replacing columns
    afterwards cost pandas about four times as much, as much as half of a 2 s run's simulation."""
    start, end = table[:, K.C_T_START], table[:, K.C_T_END]
    reversals = table[:, K.C_FRICTION_REVERSALS]
    columns = {"kind": [_ROW_KINDS.get(k, "?") for k in table[:, K.C_KIND]], "t_start": start, "t_end": end,
               "duration": end - start}
    columns.update((name, table[:, c]) for name, c in _CONTACT_COLUMNS.items())
    columns["friction_reversals"] = np.where(np.isnan(reversals), 0.0, reversals).astype(int)
    return pd.DataFrame(columns)


#: The apex table of a run that keeps none (capacity 0: the kernel never writes it).
_NO_APEXES = np.empty((0, 2))


def _run_kernel(t0, alpha0, rate0, t_end, p, law_vec, theta_ref, omega, tol, grid, capacity, apex_capacity):
    """Call the kernel, growing the tables until they are large enough."""
    mode0 = -1  # the kernel derives the initial mode from the state (saves a dispatch)
    h_max = tol.max_step_revolutions * 2.0 * math.pi / omega
    if grid.shape[0]:
        g_a = np.empty(grid.shape[0])
        g_d = np.empty(grid.shape[0])
    else:  # nothing is written: the empty grid serves (S1 events are simulated by the thousand)
        g_a = g_d = grid
    g_m = np.empty(grid.shape[0], dtype=np.int8)
    # grow the tables (x8) when they fill, but never beyond about 400 MB: a run with that many
    # contacts is chattering and is reported rather than allowed to exhaust memory
    limit = 4_000_000
    while True:
        contacts = np.empty((capacity, K.N_CCOL))
        apexes = np.empty((apex_capacity, 2)) if apex_capacity else _NO_APEXES
        # a writable copy of the law vector and a run-time overflow_ok, as the batch passes them:
        # ``integrate``, the largest function numba compiles here (about a minute and a half cold),
        # then has one compiled signature, whichever entry point comes first. (A compiled wrapper
        # returning a plain tuple would save the 1 us numba takes to hand the named record over,
        # but LLVM then compiles the whole integrator again inside it: 75 s more on a cold start.)
        res = K.integrate(t0, alpha0, rate0, mode0, t_end, p, law_vec.copy(), theta_ref, omega,
                          tol.rtol, tol.atol_alpha, tol.atol_rate, h_max, tol.max_steps,
                          grid, g_a, g_d, g_m, contacts, apexes, False, K.NO_SENS, K.NO_SENS_MAX,
                          K.NO_GRID_SENS)
        status = res.status
        if status == K.CONTACTS_FULL and capacity < limit:
            capacity = min(capacity * 8, limit)
        elif status == K.APEX_FULL and apex_capacity < limit:
            apex_capacity = min(apex_capacity * 8, limit)
        else:
            break
    return res, contacts, apexes, g_a, g_d, g_m


def _time_grid(t_eval, t0: float, t_end: float) -> np.ndarray:
    if t_eval is None:
        return np.empty(0)
    grid = np.ascontiguousarray(np.asarray(t_eval, dtype=float).ravel())
    if grid.size and not np.all(np.isfinite(grid)):
        raise SimulationInputError("t_eval contains non-finite times")
    if grid.size and (np.any(np.diff(grid) < 0.0) or grid[0] < t0 or grid[-1] > t_end * (1 + 1e-15) + 1e-300):
        raise SimulationInputError(f"t_eval must be sorted and lie within [{t0}, {t_end}] s")
    return grid


# ---------------------------------------------------------------------------------------------
# results
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SimulationResult:
    """A long run (S2 or S3).

    Attributes
    ----------
    t : sample times [s] (the requested ``t_eval``; empty if none was requested).
    alpha, alpha_dot : follower angle [rad] and rate [rad/s] at ``t``.
    mode : int8 mode at ``t`` (0 free, 1 compliant contact, 2 sticking).
    contacts : one row per contact phase (S2), impact or sticking phase (S3): start and end
        times [s], gap rates at start (approach, negative) and end (separation) [m/s], peak
        indentation [m] and force [N], states at start and end, ``xi`` = -rate_end/rate_start.
    apexes : local maxima of alpha: columns ``t`` [s], ``alpha`` [rad].
    final_time, final_alpha, final_alpha_dot : state at the end of the run.
    rig, law, cam_speed_hz, theta_ref : what was simulated; ``Theta(t) = theta_ref + 2 pi f t``.
    n_steps, n_rejected : integrator statistics.
    """

    t: np.ndarray
    alpha: np.ndarray
    alpha_dot: np.ndarray
    mode: np.ndarray
    contacts: pd.DataFrame
    apexes: pd.DataFrame
    final_time: float
    final_alpha: float
    final_alpha_dot: float
    rig: PivotedFollowerRig
    law: Law
    cam_speed_hz: float
    theta_ref: float
    mu: float
    n_steps: int
    n_rejected: int

    @property
    def theta(self) -> np.ndarray:
        """Cam angle at ``t`` [rad]."""
        return self.theta_ref + 2.0 * math.pi * self.cam_speed_hz * self.t

    def observables(self) -> pd.DataFrame:
        """Gap, gap rate, lever arm, contact force, angular acceleration and sliding velocity at ``t``."""
        return observables(self.rig, self.law, self.cam_speed_hz, self.t, self.alpha, self.alpha_dot,
                           self.mode, theta_ref=self.theta_ref, mu=self.mu)


@dataclass(frozen=True)
class EventResult:
    """One S1 event.

    Attributes
    ----------
    alpha_m : maximum follower angle over the event [rad] (S-22), ``t_alpha_m`` its time [s].
    contact_duration : duration of the first contact [s] (``t_a``); NaN if no contact occurred.
    exit_alpha, exit_alpha_dot : state at the end of the first contact [rad, rad/s].
    approach_gap_rate, separation_gap_rate : ``dpsi_i/dt`` at the first contact's start and end [m/s].
    peak_force [N], peak_indentation [m] : maxima during the first contact.
    n_contacts : number of contacts during the event (more than 1 means re-contact/chatter).
    contacts : the full contact table (a pandas DataFrame, built on first access from
        ``contact_table``, the kernel's raw array, so that simulating events stays cheap).
    t, contact_force, indentation, alpha, alpha_dot : histories on the requested grid
        (``indentation = -psi_i``, positive in contact).
    final_alpha, final_alpha_dot : state at the end time.
    """

    alpha_m: float
    t_alpha_m: float
    contact_duration: float
    exit_alpha: float
    exit_alpha_dot: float
    approach_gap_rate: float
    separation_gap_rate: float
    peak_force: float
    peak_indentation: float
    n_contacts: int
    contact_table: np.ndarray
    t: np.ndarray
    contact_force: np.ndarray
    indentation: np.ndarray
    alpha: np.ndarray
    alpha_dot: np.ndarray
    final_alpha: float
    final_alpha_dot: float
    n_steps: int = field(default=0)

    @functools.cached_property
    def contacts(self) -> pd.DataFrame:
        return _contact_frame(self.contact_table)


def _frozen_record(cls, values: dict):
    """An instance of the frozen dataclass ``cls`` whose ``__dict__`` is ``values`` (every field,
    by name), made without its generated ``__init__``.

    That ``__init__`` sets each field through ``object.__setattr__`` (the price of being frozen):
    for the 19 fields of :class:`EventResult` it took three times as long as a dict display handed
    over as the instance's ``__dict__``, about 5 us, some 5 % of a simulated S1 event. The class
    must not need ``__post_init__``.
    """
    record = object.__new__(cls)
    object.__setattr__(record, "__dict__", values)
    return record


@dataclass(frozen=True)
class BatchResult:
    """Many S1 events for many trial laws. Arrays have shape (n_trials, n_events)."""

    trials: np.ndarray
    alpha_m: np.ndarray
    t_alpha_m: np.ndarray
    n_contacts: np.ndarray
    contact_start: np.ndarray
    contact_end: np.ndarray
    approach_gap_rate: np.ndarray
    separation_gap_rate: np.ndarray
    peak_force: np.ndarray
    peak_indentation: np.ndarray
    final_alpha: np.ndarray
    final_alpha_dot: np.ndarray
    n_steps: np.ndarray
    grid: np.ndarray
    grid_offsets: np.ndarray
    contact_force: np.ndarray | None
    gap: np.ndarray | None
    status: np.ndarray | None = None
    #: (n_trials, n_events, 2): forward sensitivities ``d alpha_m / d(ln beta, n)`` [rad] (``beta`` held
    #: for ``n``), when asked for (``sensitivities=True``), else None.
    alpha_m_sensitivity: np.ndarray | None = None
    #: (n_trials, 2, total grid length): ``d F / d(ln beta, n)`` [N] and ``d psi / d(ln beta, n)`` [m]
    #: on the grids, when asked for with grids, else None.
    contact_force_sensitivity: np.ndarray | None = None
    gap_sensitivity: np.ndarray | None = None

    @property
    def failed(self) -> np.ndarray:
        """(n_trials, n_events) bool: runs that could not be simulated (``on_failure="flag"``)."""
        if self.status is None:
            return np.zeros(self.alpha_m.shape, dtype=bool)
        return self.status != K.OK

    @property
    def contact_duration(self) -> np.ndarray:
        """Duration of the first contact of each run [s]."""
        return self.contact_end - self.contact_start


# ---------------------------------------------------------------------------------------------
# public runs
# ---------------------------------------------------------------------------------------------


def simulate(rig: PivotedFollowerRig, cam_speed_hz: float, law: Law, duration: float, *,
             t_eval: Sequence[float] | np.ndarray | None = None, initial_state: tuple[float, float] | None = None,
             t_start: float = 0.0, theta_ref: float = 0.0, mu: float | None = None,
             tolerances: Tolerances = DEFAULT_TOLERANCES) -> SimulationResult:
    """Long run of rig P (S2 for a Hunt–Crossley law, S3 for a restitution law).

    Parameters
    ----------
    rig : rig parameters.
    cam_speed_hz : constant cam speed ``Omega_c`` [Hz].
    law : :class:`HuntCrossley` (compliant contact) or :class:`Restitution` (instantaneous impacts).
    duration : simulated time [s] after ``t_start``.
    t_eval : times [s] at which to return the state (dense output); none by default.
    initial_state : ``(alpha, alpha_dot)`` at ``t_start``; default: static equilibrium with the cam at
        ``theta_ref`` and ``alpha_dot = 0`` (docs/estimation.md).
    theta_ref : cam angle at ``t = 0`` [rad]; ``Theta(t) = theta_ref + 2 pi cam_speed_hz t``.
    mu : friction coefficient; default ``rig.mu``.
    tolerances : integrator settings.

    Raises
    ------
    SimulationInputError : non-physical input (zero cam speed, NaN state, ...).
    SimulationError : the integrator failed.
    """
    cam_speed_hz = _cam_speed(cam_speed_hz)
    duration = _finite("duration", duration)
    if duration <= 0.0:
        raise SimulationInputError(f"duration must be positive, got {duration!r} s")
    t_start = _finite("t_start", t_start)
    theta_ref = _finite("theta_ref", theta_ref)
    p = pack_rig(rig, mu)
    law_vec = pack_law(law)
    omega = 2.0 * math.pi * cam_speed_hz
    if initial_state is None:
        alpha0 = rig.static_equilibrium(theta_ref + omega * t_start)
        if isinstance(law, Restitution):
            alpha0 = float(rig.contact_angle(theta_ref + omega * t_start))
        rate0 = 0.0
    else:
        alpha0, rate0 = (_finite("initial alpha", initial_state[0]), _finite("initial alpha_dot", initial_state[1]))
    t_end = t_start + duration
    grid = _time_grid(t_eval, t_start, t_end)
    revolutions = duration * cam_speed_hz
    res, contacts, apexes, g_a, g_d, g_m = _run_kernel(
        t_start, alpha0, rate0, t_end, p, law_vec, theta_ref, omega, tolerances, grid,
        capacity=int(8 * revolutions) + 64, apex_capacity=int(8 * revolutions) + 64)
    status, n_c, n_ap, t_fin, a_fin, ad_fin = res.status, res.n_contacts, res.n_apexes, res.t, res.alpha, res.alpha_dot
    _raise_status(status, f"simulation at {cam_speed_hz} Hz", t_fin)
    return SimulationResult(
        t=grid, alpha=g_a, alpha_dot=g_d, mode=g_m, contacts=_contact_frame(contacts[:n_c]),
        apexes=pd.DataFrame(apexes[:n_ap], columns=["t", "alpha"]),
        final_time=t_fin, final_alpha=a_fin, final_alpha_dot=ad_fin, rig=rig, law=law,
        cam_speed_hz=cam_speed_hz, theta_ref=theta_ref, mu=float(p[K.MU]), n_steps=int(res.n_steps),
        n_rejected=int(res.n_rejected))


def simulate_event(rig: PivotedFollowerRig, cam_speed_hz: float, law: Law, alpha0: float, alpha_dot0: float,
                   theta0: float, t_end: float, *, t_eval: Sequence[float] | np.ndarray | None = None,
                   mu: float | None = None, tolerances: Tolerances = DEFAULT_TOLERANCES) -> EventResult:
    """S1: one impact event from ``(alpha0, alpha_dot0, Theta0)`` at ``t = 0`` to ``t_end``.

    The run starts in contact if the gap is negative (or zero and closing), otherwise in free
    flight; it follows every contact and free-flight phase until ``t_end`` [s].
    """
    cam_speed_hz = _cam_speed(cam_speed_hz)
    if not _all_finite(alpha0, alpha_dot0, theta0, t_end):  # else the slow check names the culprit
        for name, v in (("alpha0", alpha0), ("alpha_dot0", alpha_dot0), ("theta0", theta0), ("t_end", t_end)):
            _finite(name, v)
    if t_end <= 0.0:
        raise SimulationInputError(f"t_end must be positive, got {t_end!r} s")
    p = pack_rig(rig, mu)
    law_vec = pack_law(law)
    omega = 2.0 * math.pi * cam_speed_hz
    grid = _time_grid(t_eval, 0.0, float(t_end))
    res, contacts, _, g_a, g_d, g_m = _run_kernel(
        0.0, float(alpha0), float(alpha_dot0), float(t_end), p, law_vec, float(theta0), omega, tolerances,
        grid, capacity=16, apex_capacity=0)
    _raise_status(res.status, "S1 event", res.t)
    n_contacts = int(res.n_contacts)
    table = contacts[:n_contacts]
    if grid.shape[0]:
        obs = np.empty((grid.shape[0], 6))
        # a writable copy: the same compiled signature as the batch's (pack_law's array is read-only)
        K.observe(grid, g_a, g_d, g_m, p, law_vec.copy(), float(theta0), omega, obs)
        force, indentation = obs[:, 3], np.where(g_m != K.FREE, -obs[:, 0], 0.0)
    else:  # no histories requested: skip the observation pass (S1 events are run by the thousand)
        force, indentation = g_a, g_d
    if n_contacts:
        first = table[0].tolist()
        duration = first[K.C_T_END] - first[K.C_T_START]
        exit_a, exit_ad = first[K.C_ALPHA_END], first[K.C_RATE_END]
        approach, separation = first[K.C_DPSI_START], first[K.C_DPSI_END]
        peak_f, peak_d = first[K.C_PEAK_FORCE], first[K.C_PEAK_DELTA]
    else:
        duration = exit_a = exit_ad = approach = separation = peak_f = peak_d = math.nan
    return _frozen_record(EventResult, {
        "alpha_m": res.alpha_max, "t_alpha_m": res.t_alpha_max, "contact_duration": duration, "exit_alpha": exit_a,
        "exit_alpha_dot": exit_ad, "approach_gap_rate": approach, "separation_gap_rate": separation,
        "peak_force": peak_f, "peak_indentation": peak_d, "n_contacts": n_contacts, "contact_table": table,
        "t": grid, "contact_force": force, "indentation": indentation, "alpha": g_a, "alpha_dot": g_d,
        "final_alpha": res.alpha, "final_alpha_dot": res.alpha_dot, "n_steps": int(res.n_steps)})


@functools.lru_cache(maxsize=4)
def _batch_law(clip: bool) -> np.ndarray:
    """The law vector of a batch: Hunt–Crossley, ``beta`` and ``n`` set per trial by the kernel."""
    return pack_law(HuntCrossley(beta=1.0, n=1.5, clip=clip))


def simulate_events(rig: PivotedFollowerRig, cam_speed_hz: float, states: np.ndarray, t_end: np.ndarray,
                    trials: np.ndarray, *, clip: bool = False, mu: float | None = None,
                    grids: Sequence[np.ndarray] | None = None,
                    tolerances: Tolerances = DEFAULT_TOLERANCES, on_failure: str = "raise",
                    max_steps: int = S1_MAX_STEPS, sensitivities: bool = False) -> BatchResult:
    """Batch S1: every event for every trial ``(beta, n)``, in parallel (numba ``prange``).

    Parameters
    ----------
    states : (n_events, 3) array of ``alpha [rad], alpha_dot [rad/s], Theta [rad]`` at each event start.
    t_end : (n_events,) end time of each event [s] (e.g. the measured next onset ``t_e``).
    trials : (n_trials, 2) array of ``beta [N s m^-(n+1)], n [-]``.
    grids : optional per-event time grids [s] (from the event start) on which the contact force
        and gap histories are returned (``contact_force``, ``gap``: (n_trials, total grid length),
        event i in columns ``grid_offsets[i]:grid_offsets[i+1]``).
    on_failure : ``"raise"`` (default): a run that fails raises :class:`SimulationError` naming the
        event and trial; ``"flag"``: failed runs get NaN results and their status code in
        ``BatchResult.status`` (an estimator asks questions with trial laws, and a trial may be
        impossible to simulate without that being an error of the job).
    max_steps : step budget of one event (default :data:`S1_MAX_STEPS`, about 1000 times what a
        period-1 event takes); a run that needs more fails with ``MAX_STEPS``.
    sensitivities : also integrate the forward sensitivities of each run with respect to ``ln beta``
        and ``n`` (the variational equations, in the kernel, on the same steps: see
        ``kernel._sensitivity_step``), returned as ``alpha_m_sensitivity`` and, with grids,
        ``contact_force_sensitivity`` and ``gap_sensitivity``. With friction, a run in which the
        sliding velocity reverses during a contact (the friction force jumps there, and the kernel
        does not locate the instant as an event) has NaN sensitivities from that step on; the
        period-1 impacts measured have none (``friction_reversals`` of the contact table).

    A chattering trial law (any number of contacts in one event) is simulated to the end: the
    first contact's summary and ``alpha_m`` stay exact, only the count is reported for the rest.
    The work is done in chunks of at most :data:`BATCH_CHUNK_JOBS` runs, so that Ctrl-C
    interrupts a long batch within a fraction of a second.
    """
    if on_failure not in ("raise", "flag"):
        raise ValueError(f"on_failure must be 'raise' or 'flag', got {on_failure!r}")
    cam_speed_hz = _cam_speed(cam_speed_hz)
    states = np.ascontiguousarray(np.atleast_2d(np.asarray(states, dtype=float)))
    t_end = np.ascontiguousarray(np.atleast_1d(np.asarray(t_end, dtype=float)))
    trials = np.ascontiguousarray(np.atleast_2d(np.asarray(trials, dtype=float)))
    if states.shape[1] != 3:
        raise SimulationInputError(f"states must have shape (n_events, 3), got {states.shape}")
    if t_end.shape != (states.shape[0],):
        raise SimulationInputError(f"t_end must have one entry per event ({states.shape[0]}), got {t_end.shape}")
    if trials.shape[1] != 2:
        raise SimulationInputError(f"trials must have shape (n_trials, 2) of (beta, n), got {trials.shape}")
    # (the arrays' own methods: numpy's functions add a dispatch that cost as much as the checks)
    for name, arr in (("states", states), ("t_end", t_end), ("trials", trials)):
        if not np.isfinite(arr).all():
            raise SimulationInputError(f"{name} contains non-finite values")
    if (t_end <= 0.0).any():
        raise SimulationInputError("every t_end must be positive")
    if (trials < 0.0).any():
        raise SimulationInputError("trial beta and n must be >= 0")
    p = pack_rig(rig, mu)
    law_vec = _batch_law(clip)
    omega = 2.0 * math.pi * cam_speed_hz
    n_ev, n_tr = states.shape[0], trials.shape[0]
    if grids is not None:
        if len(grids) != n_ev:
            raise SimulationInputError("grids must have one array per event")
        parts = [_time_grid(g, 0.0, float(te)) for g, te in zip(grids, t_end)]
        offsets = np.zeros(n_ev + 1, dtype=np.int64)
        offsets[1:] = np.cumsum([len(g) for g in parts])
        grid = np.ascontiguousarray(np.concatenate(parts)) if parts else np.empty(0)
    else:
        grid = np.empty(0)
        offsets = np.zeros(n_ev + 1, dtype=np.int64)
    hist_force = np.empty((n_tr, grid.shape[0]))
    hist_gap = np.empty((n_tr, grid.shape[0]))
    summary = np.empty((n_tr, n_ev, K.N_SUM))
    n_sens = K.N_SENS if sensitivities else 0
    sens_summary = np.empty((n_tr, n_ev, n_sens))
    hist_dforce = np.empty((n_tr, n_sens, grid.shape[0] if n_sens else 0))
    hist_dgap = np.empty_like(hist_dforce)
    h_max = tolerances.max_step_revolutions * 2.0 * math.pi / omega
    budget = int(min(max_steps, tolerances.max_steps))
    per_call = max(1, BATCH_CHUNK_JOBS // max(n_ev, 1))
    for lo in range(0, n_tr, per_call):  # chunks: Python sees Ctrl-C between them
        hi = min(lo + per_call, n_tr)
        K.batch_events(states, t_end, trials[lo:hi], p, law_vec, omega, tolerances.rtol, tolerances.atol_alpha,
                       tolerances.atol_rate, h_max, budget, grid, offsets, summary[lo:hi],
                       hist_force[lo:hi], hist_gap[lo:hi], S1_CONTACT_ROWS, True, sens_summary[lo:hi],
                       hist_dforce[lo:hi], hist_dgap[lo:hi])
    status = summary[:, :, K.S_STATUS].astype(int)
    failed = status != K.OK
    if failed.any():
        if on_failure == "raise":
            tr, ev = np.argwhere(failed)[0]
            raise SimulationError(
                f"S1 batch: event {ev} with beta={trials[tr, 0]:.6g}, n={trials[tr, 1]:.6g} failed: "
                f"{K.STATUS_MESSAGES.get(int(status[tr, ev]), status[tr, ev])}")
        keep = [K.S_STATUS, K.S_N_STEPS, K.S_N_CONTACTS]
        cols = [c for c in range(K.N_SUM) if c not in keep]
        summary[:, :, cols] = np.where(failed[:, :, None], np.nan, summary[:, :, cols])
        if grid.size:
            for i in range(n_ev):
                bad = failed[:, i]
                if bad.any():
                    hist_force[bad, offsets[i]:offsets[i + 1]] = np.nan
                    hist_gap[bad, offsets[i]:offsets[i + 1]] = np.nan
                    hist_dforce[bad, :, offsets[i]:offsets[i + 1]] = np.nan
                    hist_dgap[bad, :, offsets[i]:offsets[i + 1]] = np.nan
        sens_summary[failed] = np.nan
    s = summary
    return BatchResult(
        trials=trials, alpha_m=s[:, :, K.S_ALPHA_M], t_alpha_m=s[:, :, K.S_T_ALPHA_M],
        n_contacts=s[:, :, K.S_N_CONTACTS].astype(int), contact_start=s[:, :, K.S_T_START],
        contact_end=s[:, :, K.S_T_END], approach_gap_rate=s[:, :, K.S_DPSI_START],
        separation_gap_rate=s[:, :, K.S_DPSI_END], peak_force=s[:, :, K.S_PEAK_FORCE],
        peak_indentation=s[:, :, K.S_PEAK_DELTA], final_alpha=s[:, :, K.S_ALPHA_END],
        final_alpha_dot=s[:, :, K.S_RATE_END], n_steps=s[:, :, K.S_N_STEPS].astype(int),
        grid=grid, grid_offsets=offsets,
        contact_force=hist_force if grid.size else None, gap=hist_gap if grid.size else None,
        status=status, alpha_m_sensitivity=sens_summary if sensitivities else None,
        contact_force_sensitivity=hist_dforce if sensitivities and grid.size else None,
        gap_sensitivity=hist_dgap if sensitivities and grid.size else None)


def observables(rig: PivotedFollowerRig, law: Law, cam_speed_hz: float, t, alpha, alpha_dot, mode, *,
                theta_ref: float = 0.0, mu: float | None = None) -> pd.DataFrame:
    """Gap ``psi_i`` [m], gap rate [m/s], lever arm [m], contact force [N], ``alpha_ddot``
    [rad/s^2] and sliding velocity [m/s] for states sampled at times ``t`` in the given modes."""
    p = pack_rig(rig, mu)
    law_vec = pack_law(law)
    t = np.ascontiguousarray(t, dtype=float)
    out = np.empty((t.shape[0], 6))
    K.observe(t, np.ascontiguousarray(alpha, dtype=float), np.ascontiguousarray(alpha_dot, dtype=float),
              np.ascontiguousarray(mode, dtype=np.int8), p, law_vec.copy(), theta_ref, 2.0 * math.pi * cam_speed_hz,
              out)  # a writable law vector: one compiled signature of observe (pack_law's is read-only)
    return pd.DataFrame(out, columns=["gap", "gap_rate", "lever_arm", "contact_force", "alpha_ddot",
                                      "sliding_velocity"], index=pd.Index(t, name="t"))


def warm_up() -> None:
    """Rig P's simulator: a short run with a sample grid (``simulate``, ``synth``) and a batch of S1 events
    with forward sensitivities and histories (the estimate's fits), with the argument types the commands
    use, so that each kernel compiles (or loads from numba's cache) the signature they run
    (``impactid warmup``, :attr:`impactid.rigs.base.RigModel.warmup`)."""
    rig = SUNDAR2016.with_eccentricity_ratio(0.2)
    law = HuntCrossley(24.7e9, 1.5)
    simulate(rig, 16.0, law, 0.05, t_eval=np.linspace(0.0, 0.05, 11))
    states = np.array([[0.07, -4.0, 0.3]])
    simulate_events(rig, 16.0, states, np.array([0.0625]), np.array([[24.7e9, 1.5]]),
                    grids=[np.linspace(0.0, 1e-3, 5)], sensitivities=True)

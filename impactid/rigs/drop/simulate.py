"""Simulations of the single-impact test rig: Python wrappers of :mod:`impactid.rigs.drop.kernel`.

* :func:`simulate_drop` - a drop (or swing) from a height, through its impacts, to rest or for a
  duration, with the per-impact table and optional histories on a time grid;
* :func:`replay_impacts` - impacts replayed from given onset speeds, sampled at given times from
  their onsets, with the derivatives of the force with respect to ``ln k``, ``ln beta``, ``n`` and
  the onset speed (the model of :func:`~impactid.rigs.drop.identify.fit_drop`).

Inputs are checked here (:class:`~impactid.errors.SimulationInputError` naming the argument); a
failed integration raises :class:`~impactid.errors.SimulationError`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from impactid.errors import SimulationError, SimulationInputError
from impactid.rigs.drop import kernel
from impactid.rigs.drop.parameters import PA6_PAD_LAW, STEEL_ON_PA6, DropLaw, DropRig

__all__ = ["DEFAULT_TOLERANCES", "IMPACT_COLUMNS", "MAX_DURATION_S", "DropRun", "Replay", "Tolerances",
           "impact_table", "pack", "replay_impacts", "simulate_drop", "warm_up"]

#: Longest run [s] of :func:`simulate_drop` without a duration (it stops at rest first).
MAX_DURATION_S = 600.0
#: The columns of the per-impact table (SI units; speeds are magnitudes, the approach towards the
#: contact and the separation away from it).
IMPACT_COLUMNS = ("onset_time_s", "approach_speed_m_s", "max_penetration_m", "max_penetration_time_s",
                  "peak_force_n", "peak_force_time_s", "separation_time_s", "contact_duration_s",
                  "separation_speed_m_s", "separation_penetration_m", "restitution", "kind", "end")
_KINDS = {kernel.KIND_ONSET: "onset", kernel.KIND_RECONTACT: "re-contact"}
_ENDS = {kernel.END_OPEN: "open", kernel.END_FORCE: "force", kernel.END_SURFACE: "surface", kernel.END_REST: "rest"}
_MAX_TABLE = 1 << 16


@dataclass(frozen=True)
class Tolerances:
    """Integration settings of the contact phases (free flight is exact).

    Attributes
    ----------
    rtol : relative tolerance [-].
    atol_x : absolute tolerance of the position [m].
    atol_v : absolute tolerance of the velocity [m/s].
    h_max : largest contact step [s].
    max_steps : budget of contact steps (accepted and rejected) of one run.
    """

    rtol: float = 1e-10
    atol_x: float = 1e-15
    atol_v: float = 1e-11
    h_max: float = 1e-3
    max_steps: int = 5_000_000

    def __post_init__(self) -> None:
        for name in ("rtol", "atol_x", "atol_v", "h_max"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0.0):
                raise SimulationInputError(f"tolerance {name!r} must be a positive number, got {value!r}")
        if not (isinstance(self.max_steps, (int, np.integer)) and self.max_steps > 0):
            raise SimulationInputError(f"tolerance 'max_steps' must be a positive integer, got {self.max_steps!r}")


DEFAULT_TOLERANCES = Tolerances()


def pack(rig: DropRig, law: DropLaw) -> np.ndarray:
    """The kernel's parameter vector ``(m, g, k, p, beta, n)`` (layout ``kernel.P_*``)."""
    if not isinstance(rig, DropRig):
        raise SimulationInputError(f"rig must be a DropRig, got {type(rig).__name__}")
    if not isinstance(law, DropLaw):
        raise SimulationInputError(f"law must be a DropLaw (beta, n), got {type(law).__name__}")
    return np.array([rig.mass, rig.gravity, rig.k, rig.p, law.beta, law.n], dtype=float)


def _check_number(name: str, value, *, minimum: float | None = None, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        raise SimulationInputError(f"{name} must be a number, got {value!r}")
    value = float(value)
    if not math.isfinite(value):
        raise SimulationInputError(f"{name} must be finite, got {value!r}")
    if positive and value <= 0.0:
        raise SimulationInputError(f"{name} must be positive, got {value!r}")
    if minimum is not None and value < minimum:
        raise SimulationInputError(f"{name} must be >= {minimum:g}, got {value!r}")
    return value


def _raise_status(status: int, what: str) -> None:
    if status != kernel.OK:
        raise SimulationError(f"{what}: {kernel.STATUS_MESSAGES.get(int(status), f'status {status}')}")


def impact_table(rows: np.ndarray) -> pd.DataFrame:
    """The kernel's impact rows as a table (:data:`IMPACT_COLUMNS`)."""
    r = np.asarray(rows, dtype=float).reshape(-1, kernel.N_ICOL)
    approach = r[:, kernel.I_V_ONSET]
    separation = -r[:, kernel.I_V_END]
    with np.errstate(invalid="ignore", divide="ignore"):
        restitution = np.where(approach > 0.0, separation / approach, np.nan)
    return pd.DataFrame({
        "onset_time_s": r[:, kernel.I_T_ONSET], "approach_speed_m_s": approach,
        "max_penetration_m": r[:, kernel.I_X_MAX], "max_penetration_time_s": r[:, kernel.I_T_X_MAX],
        "peak_force_n": r[:, kernel.I_F_PEAK], "peak_force_time_s": r[:, kernel.I_T_F_PEAK],
        "separation_time_s": r[:, kernel.I_T_END], "contact_duration_s": r[:, kernel.I_T_END] - r[:, kernel.I_T_ONSET],
        "separation_speed_m_s": separation, "separation_penetration_m": r[:, kernel.I_X_END],
        "restitution": restitution,
        "kind": [_KINDS.get(k, "?") for k in r[:, kernel.I_KIND]],
        "end": [_ENDS.get(k, "?") for k in r[:, kernel.I_END_KIND]],
    }, columns=list(IMPACT_COLUMNS))


@dataclass(frozen=True)
class DropRun:
    """A simulated drop.

    Attributes
    ----------
    rig, law : what was simulated.
    height : fall of the contact point to the surface [m]; release_speed : speed at release [m/s].
    impacts : per-impact table (:data:`IMPACT_COLUMNS`), in time order.
    t : the output times [s] (time 0 at release); empty without ``t_eval``.
    x, v : position [m] (positive into the contact) and velocity [m/s] at ``t``.
    force : contact force [N] at ``t``; acceleration : what an accelerometer on the impactor reads,
        ``F/m`` [m/s^2] (the specific force along the line of impact, away from the contact: 0 in
        flight, ``g`` at rest on the contact); mode : 0 free, 1 contact.
    t_end : time the run ended [s]; t_rest : time the impactor came to rest on the contact [s]
        (NaN if it did not within the run).
    n_steps, n_rejected : contact steps taken and rejected.
    force_derivatives : with ``sensitivities=True``, (len(t), 4) ``dF/d(ln k, ln beta, n, v0)`` at ``t``
        [N, N, N, N s/m] (``v0``: the release speed); the accelerometer's are these divided by the
        mass. None otherwise.
    """

    rig: DropRig
    law: DropLaw
    height: float
    release_speed: float
    impacts: pd.DataFrame
    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    force: np.ndarray
    acceleration: np.ndarray
    mode: np.ndarray
    t_end: float
    t_rest: float
    n_steps: int
    n_rejected: int
    force_derivatives: np.ndarray | None = None

    @property
    def separated(self) -> pd.DataFrame:
        """The impacts that ended in a separation (the bounces)."""
        return self.impacts[self.impacts["end"].isin(["force", "surface"])].reset_index(drop=True)

    def history(self) -> pd.DataFrame:
        """The histories on the output grid as a table."""
        return pd.DataFrame({"t_s": self.t, "x_m": self.x, "v_m_s": self.v, "force_n": self.force,
                             "acceleration_m_s2": self.acceleration, "mode": self.mode})


def simulate_drop(rig: DropRig, law: DropLaw, height: float, *, release_speed: float = 0.0,
                  duration: float | None = None, t_eval: Sequence[float] | np.ndarray | None = None,
                  sensitivities: bool = False, tol: Tolerances = DEFAULT_TOLERANCES) -> DropRun:
    """Simulate a drop from ``height`` through its impacts.

    Parameters
    ----------
    rig, law : the rig (mass, ``k``, ``p``, gravity) and the contact's damping (``beta``, ``n``).
    height : fall of the contact point to the contact surface [m], >= 0 (time 0 is the release).
    release_speed : speed at release towards the contact [m/s], >= 0.
    duration : simulated time [s]; None runs until the impactor rests on the contact (at most
        :data:`MAX_DURATION_S`).
    t_eval : sorted output times in ``[0, duration]`` [s] (histories), or None.
    sensitivities : also integrate the forward sensitivities and return the derivatives of the force
        on ``t_eval`` with respect to ``ln k``, ``ln beta``, ``n`` and the release speed.
    tol : integration settings.

    Returns
    -------
    :class:`DropRun`
    """
    params = pack(rig, law)
    height = _check_number("height", height, minimum=0.0)
    release_speed = _check_number("release_speed", release_speed, minimum=0.0)
    if height == 0.0 and release_speed == 0.0:
        raise SimulationInputError("height and release_speed are both 0: the impactor starts at rest on the surface "
                                   "and nothing impacts")
    if rig.gravity == 0.0 and release_speed == 0.0:
        raise SimulationInputError("without gravity (a pendulum swung horizontally) the impactor needs a "
                                   "release_speed > 0 to reach the contact")
    stop_at_rest = duration is None
    t_end = MAX_DURATION_S if duration is None else _check_number("duration", duration, positive=True)
    grid = np.zeros(0) if t_eval is None else np.asarray(t_eval, dtype=float).ravel()
    if grid.size:
        if not np.all(np.isfinite(grid)):
            raise SimulationInputError("t_eval has non-finite times")
        if np.any(np.diff(grid) < 0.0):
            raise SimulationInputError("t_eval must be sorted")
        if grid[0] < 0.0 or grid[-1] > t_end:
            raise SimulationInputError(f"t_eval must lie in [0, {t_end:g}] s (the run), got [{grid[0]:g}, "
                                       f"{grid[-1]:g}]")
    capacity = 64
    while True:
        g_out = np.empty((grid.size, kernel.N_GCOL))
        rows = np.empty((capacity, kernel.N_ICOL))
        sens = np.zeros((kernel.N_SENS if sensitivities else 0, 2))
        if sensitivities:
            sens[kernel.S_V0, 1] = 1.0  # d(x, v)/d v0 at the release
        g_sens = np.zeros((grid.size if sensitivities else 0, kernel.N_SENS, 3))
        res = kernel.integrate(0.0, -height, release_speed, t_end, params, tol.rtol, tol.atol_x, tol.atol_v, tol.h_max,
                               int(tol.max_steps), stop_at_rest, grid, g_out, rows, sens, g_sens)
        if res.status == kernel.EVENTS_FULL and capacity < _MAX_TABLE:
            capacity *= 4
            continue
        break
    _raise_status(res.status, f"drop from {height:g} m at {release_speed:g} m/s")
    force = g_out[:, kernel.G_FORCE].copy()
    return DropRun(rig=rig, law=law, height=height, release_speed=release_speed,
                   impacts=impact_table(rows[:res.n_impacts]), t=grid.copy(), x=g_out[:, kernel.G_X].copy(),
                   v=g_out[:, kernel.G_V].copy(), force=force, acceleration=force / rig.mass,
                   mode=g_out[:, kernel.G_MODE].astype(np.int8), t_end=float(res.t), t_rest=float(res.t_rest),
                   n_steps=int(res.n_steps), n_rejected=int(res.n_rejected),
                   force_derivatives=g_sens[:, :, 2].copy() if sensitivities else None)


@dataclass(frozen=True)
class Replay:
    """Impacts replayed from their onsets (:func:`replay_impacts`), on the concatenated sample times.

    Attributes
    ----------
    offsets : (n_impacts + 1,) where each impact's samples start and end in the arrays below.
    tau : times from each impact's onset [s].
    force : contact force [N]; force_rate : its time derivative [N/s].
    x, v : position [m] and velocity [m/s].
    force_derivatives : (n_samples, 4) ``dF/d(ln k, ln beta, n, v0)`` [N, N, N, N s/m] (``v0``: the
        impact's onset speed), or None when not asked for.
    """

    offsets: np.ndarray
    tau: np.ndarray
    force: np.ndarray
    force_rate: np.ndarray
    x: np.ndarray
    v: np.ndarray
    force_derivatives: np.ndarray | None


def replay_impacts(rig: DropRig, law: DropLaw, speeds: Sequence[float] | np.ndarray,
                   times: Sequence[np.ndarray], *, derivatives: bool = True,
                   tol: Tolerances = DEFAULT_TOLERANCES) -> Replay:
    """Impacts replayed from the onset states ``(x, v) = (0, speeds[i])``, sampled at ``times[i]``.

    Parameters
    ----------
    rig, law : rig and damping.
    speeds : onset (approach) speed of each impact [m/s], > 0.
    times : for each impact, sorted sample times from its onset [s]; times before the onset (< 0)
        are in flight before it (zero force, zero derivatives).
    derivatives : also integrate the forward sensitivities (``Replay.force_derivatives``).

    Returns
    -------
    :class:`Replay`
    """
    params = pack(rig, law)
    speeds = np.asarray(speeds, dtype=float).ravel()
    if len(times) != speeds.size:
        raise SimulationInputError(f"{speeds.size} speeds but {len(times)} sample-time arrays")
    if not np.all(np.isfinite(speeds) & (speeds > 0.0)):
        raise SimulationInputError("onset speeds must be positive and finite")
    pieces = [np.asarray(t, dtype=float).ravel() for t in times]
    for i, piece in enumerate(pieces):
        if not np.all(np.isfinite(piece)) or np.any(np.diff(piece) < 0.0):
            raise SimulationInputError(f"sample times of impact {i} must be finite and sorted")
    counts = np.array([p.size for p in pieces], dtype=np.int64)
    offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    tau = np.concatenate(pieces) if pieces else np.zeros(0)
    after = tau >= 0.0
    # the kernel sees each impact's times from its onset on; earlier samples are flight before it
    kept = [p[p >= 0.0] for p in pieces]
    k_offsets = np.concatenate([[0], np.cumsum([p.size for p in kept])]).astype(np.int64)
    k_tau = np.concatenate(kept) if kept else np.zeros(0)
    out = np.empty((k_tau.size, kernel.N_GCOL))
    out_sens = np.zeros((k_tau.size, kernel.N_SENS, 3))
    status = np.zeros(speeds.size, dtype=np.int64)
    kernel.replay(speeds, k_offsets, k_tau, params, tol.rtol, tol.atol_x, tol.atol_v, tol.h_max, int(tol.max_steps),
                  out, out_sens, status)
    bad = np.flatnonzero(status != kernel.OK)
    if bad.size:
        _raise_status(int(status[bad[0]]), f"replay of impact {int(bad[0])} at {speeds[bad[0]]:g} m/s")
    n = tau.size
    force = np.zeros(n)
    rate = np.zeros(n)
    x = np.zeros(n)
    v = np.zeros(n)
    force[after] = out[:, kernel.G_FORCE]
    rate[after] = out[:, kernel.G_FORCE_RATE]
    x[after] = out[:, kernel.G_X]
    v[after] = out[:, kernel.G_V]
    # before the onset: free flight towards the surface
    before = ~after
    if before.any():
        impact_of = np.repeat(np.arange(speeds.size), counts)
        s0 = speeds[impact_of[before]]
        tb = tau[before]
        x[before] = s0 * tb + 0.5 * rig.gravity * tb * tb
        v[before] = s0 + rig.gravity * tb
    dF = None
    if derivatives:
        dF = np.zeros((n, kernel.N_SENS))
        dF[after] = out_sens[:, :, 2]
    return Replay(offsets=offsets, tau=tau, force=force, force_rate=rate, x=x, v=v, force_derivatives=dF)


def warm_up() -> None:
    """The drop rig's simulator (with and without sensitivities) and its impact replay, briefly
    (``impactid warmup``)."""
    simulate_drop(STEEL_ON_PA6, PA6_PAD_LAW, 0.05, sensitivities=True)
    simulate_drop(STEEL_ON_PA6, PA6_PAD_LAW, 0.05)
    replay_impacts(STEEL_ON_PA6, PA6_PAD_LAW, [1.0], [np.linspace(0.0, 1e-4, 5)])

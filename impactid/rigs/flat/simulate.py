"""Rig F (Alzate et al. 2007): impacting motion with a restitution law, and the bifurcation diagram.

:func:`simulate_flat` runs the compiled event-driven model of :mod:`impactid.rigs.flat.kernel`
(free flight A-10, riding the cam A-11/A-17, impacts A-12..A-16, chattering accumulated into
sticking) at a constant cam speed. :func:`bifurcation` runs it from permanent contact at many cam
speeds in parallel, samples the follower stroboscopically once per cam revolution (Fig. 16 of the
seed) and classifies each speed as permanent contact, periodic impacting (period k revolutions) or
irregular.

The coefficient of restitution depends on the cam speed as in the paper:
:class:`SpeedRestitution` ``r(omega) = a + b omega`` (``b = 0`` for a constant ``r``).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from impactid.errors import SimulationError, SimulationInputError
from impactid.rigs.flat import FlatFollowerRig
from impactid.rigs.flat import kernel as FK
from impactid.rigs.flat.parameters import ALZATE2007
from impactid.simulate.periodicity import find_period
from impactid.simulate.tolerances import DEFAULT_TOLERANCES, Tolerances

__all__ = ["DEFAULT_RESTITUTION", "EVENT_KINDS", "RPM", "TWO_PI", "V_STICK", "BifurcationResult", "FlatRun",
           "SpeedRestitution", "bifurcation", "pack_flat_rig", "simulate_flat", "strobe_phase_default", "warm_up"]

TWO_PI = 2.0 * math.pi
RPM = TWO_PI / 60.0  # rad/s per rpm

#: Separation speed below which an impact ends a chattering sequence in sticking [m/s]. The bounce
#: it would start lasts about ``2 v / h_ddot`` (~1e-6 s for rig F, whose relative acceleration at
#: contact is a few m/s^2) and rises about ``v^2 / (2 h_ddot)`` (~1e-13 m): far below any encoder.
V_STICK = 1e-6


@dataclass(frozen=True)
class SpeedRestitution:
    """Coefficient of restitution linear in the cam speed: ``r = a + b * omega``.

    Attributes
    ----------
    a : intercept [-]
    b : slope [s/rad] per rad/s of cam speed (0 for a constant coefficient)
    """

    a: float
    b: float = 0.0

    def __post_init__(self) -> None:
        for name in ("a", "b"):
            if not math.isfinite(getattr(self, name)):
                raise SimulationInputError(f"restitution law: {name} is not finite ({getattr(self, name)!r})")

    @classmethod
    def from_rpm(cls, a: float, b_per_rpm: float = 0.0) -> SpeedRestitution:
        """Law given with its slope per rpm of cam speed (the paper's Fig. 12 axis)."""
        return cls(a=a, b=b_per_rpm / RPM)

    def __call__(self, cam_speed_hz: float) -> float:
        """``r`` at a cam speed [Hz]; must lie in [0, 1]."""
        r = self.a + self.b * TWO_PI * cam_speed_hz
        if not 0.0 <= r <= 1.0:
            raise SimulationInputError(
                f"restitution law r = {self.a:.6g} + {self.b:.6g} omega gives r = {r:.6g} at "
                f"{cam_speed_hz * 60:.6g} rpm, outside [0, 1]")
        return r

    def to_dict(self) -> dict:
        """The law with its slope per rad/s and per rpm."""
        return {"a": self.a, "b_per_rad_s": self.b, "b_per_rpm": self.b * RPM}


#: Default law of the bifurcation tools: r falls from 0.67 at 125 rpm to 0.55 at 155 rpm. The
#: seed fits r linearly in cam speed over 130-155 rpm (Fig. 12) but does not print its values;
#: this law is our stand-in and is documented as such wherever it is used.
DEFAULT_RESTITUTION = SpeedRestitution.from_rpm(0.67 + 125 * 0.004, -0.004)


def pack_flat_rig(rig: FlatFollowerRig) -> np.ndarray:
    """Rig parameters in the kernel's layout."""
    p = np.empty(FK.N_PAR)
    p[FK.P_R], p[FK.P_E], p[FK.P_X0], p[FK.P_Y0], p[FK.P_D] = rig.R, rig.e, rig.x0, rig.y0, rig.d
    p[FK.P_J], p[FK.P_K], p[FK.P_XA], p[FK.P_L] = rig.J, rig.K, rig.x_A, rig.spring_length
    return p


def _restitution_value(restitution, cam_speed_hz: float) -> float:
    if isinstance(restitution, SpeedRestitution):
        return restitution(cam_speed_hz)
    r = float(restitution)
    if not 0.0 <= r <= 1.0:
        raise SimulationInputError(f"coefficient of restitution must lie in [0, 1], got {r!r}")
    return r


def _check_speed(cam_speed_hz: float) -> float:
    speed = float(cam_speed_hz)
    if not (math.isfinite(speed) and speed > 0.0):
        raise SimulationInputError(f"cam speed must be positive and finite, got {cam_speed_hz!r} Hz")
    return speed


EVENT_KINDS = {FK.EV_IMPACT: "impact", FK.EV_STICK: "stick", FK.EV_RELEASE: "release"}


@dataclass(frozen=True)
class FlatRun:
    """A run of rig F.

    Attributes
    ----------
    t : output times [s]
    theta_f, rate : follower angle [rad] and rate [rad/s] at ``t``
    riding : True where the follower rides the cam (sticking) at ``t``
    events : pandas DataFrame
        impacts, sticks and releases: ``kind, t, theta_c, theta_f,
        rate_before, rate_after, gap_rate_before, gap_rate_after`` [s, rad, rad/s, m/s]
    cam_speed_hz, theta_c0 : cam speed [Hz] and cam angle at t = 0 [rad]
    restitution : coefficient of restitution of the run [-]
    steps : accepted+rejected integrator steps
    """

    t: np.ndarray
    theta_f: np.ndarray
    rate: np.ndarray
    riding: np.ndarray
    events: object
    cam_speed_hz: float
    theta_c0: float
    restitution: float
    steps: int

    @property
    def cam_angle(self) -> np.ndarray:
        """Cam angle at ``t`` [rad]."""
        return self.theta_c0 + TWO_PI * self.cam_speed_hz * self.t

    def impacts(self):
        """The impact rows of :attr:`events`."""
        return self.events[self.events["kind"] == "impact"]


def simulate_flat(rig: FlatFollowerRig, cam_speed_hz: float, duration: float, *, restitution=None,
                  times=None, theta_c0: float = 0.0, initial: tuple[float, float] | None = None,
                  v_stick: float = V_STICK, tolerances: Tolerances = DEFAULT_TOLERANCES,
                  max_events: int = 1_000_000) -> FlatRun:
    """Simulate rig F at a constant cam speed.

    Parameters
    ----------
    rig : rig F parameters.
    cam_speed_hz : cam speed [Hz].
    duration : simulated time [s].
    restitution : a number in [0, 1] or a :class:`SpeedRestitution`; default
        :data:`DEFAULT_RESTITUTION`.
    times : output times in [0, duration] (sorted); default 100 per cam revolution.
    theta_c0 : cam angle at t = 0 [rad].
    initial : follower ``(angle, rate)`` at t = 0 [rad, rad/s]; default: riding the cam. A state
        inside the cam (negative gap) is rejected.
    v_stick : chatter threshold [m/s] (see :data:`V_STICK`).

    Raises
    ------
    SimulationInputError : non-physical input. SimulationError : the integrator failed.
    """
    speed = _check_speed(cam_speed_hz)
    r = _restitution_value(DEFAULT_RESTITUTION if restitution is None else restitution, speed)
    if not (math.isfinite(duration) and duration > 0.0):
        raise SimulationInputError(f"duration must be positive, got {duration!r} s")
    omega = TWO_PI * speed
    if times is None:
        times = np.linspace(0.0, duration, int(math.ceil(100 * duration * speed)) + 1)
    times = np.ascontiguousarray(times, dtype=float)
    if times.size and (np.any(np.diff(times) < 0) or times[0] < 0 or times[-1] > duration):
        raise SimulationInputError("output times must be sorted and lie in [0, duration]")
    if initial is None:
        th0, rate0, mode0 = 0.0, 0.0, FK.STICK
    else:
        th0, rate0 = (float(v) for v in initial)
        if not (math.isfinite(th0) and math.isfinite(rate0)):
            raise SimulationInputError(f"initial state must be finite, got {initial!r}")
        if rig.gap(th0, theta_c0) < 0.0:
            raise SimulationInputError(f"initial follower angle {th0!r} rad lies inside the cam")
        mode0 = FK.FREE
    p = pack_flat_rig(rig)
    out = np.empty((times.size, 3))
    events = np.empty((max_events, FK.N_ECOL))
    tol = tolerances
    end = FK.integrate(
        p, omega, float(theta_c0), r, float(v_stick), 0.0, th0, rate0, mode0, float(duration),
        tol.rtol, tol.atol_alpha, tol.atol_rate, tol.max_step_revolutions / speed, tol.max_steps,
        times, out, events, np.zeros((0, 3), dtype=np.int64))
    status, n_ev, t_stop, steps = end.status, end.n_events, end.t, end.n_steps
    if status != FK.OK:
        raise SimulationError(f"rig F at {speed * 60:.6g} rpm: {FK.STATUS_MESSAGES[status]} (at t = {t_stop:.9g} s)")
    if n_ev > max_events:
        raise SimulationError(f"rig F at {speed * 60:.6g} rpm: {n_ev} events exceed max_events = {max_events}")
    import pandas as pd

    table = pd.DataFrame(events[:n_ev], columns=["kind", "t", "theta_c", "theta_f", "rate_before", "rate_after",
                                                  "gap_rate_before", "gap_rate_after"])
    table["kind"] = table["kind"].map(EVENT_KINDS)
    return FlatRun(t=times, theta_f=out[:, 0].copy(), rate=out[:, 1].copy(), riding=out[:, 2] == FK.STICK,
                   events=table, cam_speed_hz=speed, theta_c0=float(theta_c0), restitution=r, steps=int(steps))


# ---------------------------------------------------------------------------------------------
# Bifurcation diagram
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class BifurcationResult:
    """Stroboscopic samples and regimes over a range of cam speeds.

    Attributes
    ----------
    table : pandas DataFrame
        one row per speed: ``cam_speed_hz, cam_speed_rpm, restitution, regime
        ("contact" | "period-1" | "period-k" | "irregular"), period_revolutions,
        impacts_per_revolution, releases_per_revolution, strobe_spread`` (spread of the kept
        stroboscopic angles [rad])
    strobe_angle, strobe_rate : (speeds, kept revolutions) follower angle [rad] and rate [rad/s] at
        ``theta_c = 2 pi k + strobe_phase`` over the kept (last) revolutions
    revolutions, kept : simulated and kept revolutions per speed
    restitution : the law used
    strobe_phase : cam angle of the stroboscopic section [rad]
    """

    table: object
    strobe_angle: np.ndarray
    strobe_rate: np.ndarray
    revolutions: int
    kept: int
    restitution: SpeedRestitution
    strobe_phase: float = 0.0

    def transitions(self) -> dict:
        """Transition speeds [rpm] scanning up (NaN when none): the first speed with impacts
        (``detachment_rpm``), the first impacting speed that is not period-1
        (``period1_end_rpm``) and the first irregular one (``irregular_rpm``)."""
        tab = self.table
        impacting = tab["regime"] != "contact"
        masks = {"detachment_rpm": impacting,
                 "period1_end_rpm": impacting & (tab["regime"] != "period-1"),
                 "irregular_rpm": tab["regime"] == "irregular"}
        out = {}
        for key, mask in masks.items():
            hit = tab["cam_speed_rpm"][mask]
            out[key] = float(hit.iloc[0]) if len(hit) else math.nan
        return out


def strobe_phase_default(rig: FlatFollowerRig) -> float:
    """Cam angle [rad] of the default stroboscopic section: 1 rad after the cam angle where contact
    is first lost (the minimum of the required contact torque), i.e. inside the flight of the
    impacting motion. At ``theta_c = 0`` the follower rides the cam at every speed below about
    150 rpm, which would hide the impacting branch of the diagram."""
    theta = np.linspace(0.0, TWO_PI, 3600, endpoint=False)
    torque = rig.contact_torque(theta, rig.detachment_speed_hz())
    return float(np.mod(theta[int(np.argmin(torque))] + 1.0, TWO_PI))


def _sweep(packed: np.ndarray, part: tuple[np.ndarray, np.ndarray], *, v_stick: float, revolutions: int,
           phase: float, tolerances: Tolerances) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The runs of :func:`bifurcation` at the cam speeds [Hz] and restitution coefficients of ``part``
    (a module-level function: parts of a sweep are sent to workers)."""
    speeds, rs = part
    strobe = np.empty((speeds.size, revolutions, 3))
    counts = np.zeros((speeds.size, revolutions, 3), dtype=np.int64)
    status = np.zeros(speeds.size, dtype=np.int64)
    steps = np.zeros(speeds.size, dtype=np.int64)
    tol = tolerances
    FK.sweep(packed, TWO_PI * np.ascontiguousarray(speeds), np.ascontiguousarray(rs), v_stick, revolutions, phase,
             tol.rtol, tol.atol_alpha, tol.atol_rate, tol.max_step_revolutions, tol.max_steps, strobe, counts, status,
             steps)
    return strobe, counts, status, steps


def bifurcation(rig: FlatFollowerRig, cam_speeds_hz, restitution=None, *, revolutions: int = 100,
                kept: int | None = None, strobe_phase: float | None = None, v_stick: float = V_STICK,
                periodicity_tol: float = 1e-4,
                max_period: int = 12, tolerances: Tolerances = DEFAULT_TOLERANCES,
                client=None, progress=None) -> BifurcationResult:
    """Bifurcation diagram of rig F (Fig. 16 of Alzate et al. (2007)).

    Each speed is run from permanent contact at ``theta_c = 0`` for ``revolutions`` cam revolutions
    (the speeds in parallel on all cores); the follower is sampled once per revolution at the cam angle
    ``strobe_phase`` [rad] (default :func:`strobe_phase_default`); the last ``kept`` (default half)
    samples are kept and classified: ``"contact"`` when the follower never left the cam in them, periodic with
    period k when the stroboscopic states repeat after k samples to ``periodicity_tol`` (angle
    relative to the cam's stroke, rate relative to the largest rate; the test of
    :func:`impactid.simulate.periodicity.find_period`, which also rejects slowly decaying transients),
    ``"irregular"`` otherwise. ``periodicity_tol`` sits far above the integrator's error (rtol
    1e-10) and below the differences between distinct periodic branches.

    With a ``client`` (a :class:`distributed.Client`, :mod:`impactid.distributed`), the speeds are
    split into parts run on its workers (each part in parallel on its worker's threads); the
    diagram is the same. ``progress(done, total)`` is called as cam speeds are done (serially: once,
    at the end of the one parallel run).
    """
    law = DEFAULT_RESTITUTION if restitution is None else restitution
    if not isinstance(law, SpeedRestitution):
        law = SpeedRestitution(a=_restitution_value(law, 1.0))
    speeds = np.atleast_1d(np.asarray(cam_speeds_hz, dtype=float))
    for s in speeds:
        _check_speed(s)
    revolutions = int(revolutions)
    kept = revolutions // 2 if kept is None else int(kept)
    if not 1 <= kept <= revolutions:
        raise SimulationInputError(f"kept revolutions must lie in [1, {revolutions}], got {kept}")
    phase = strobe_phase_default(rig) if strobe_phase is None else float(np.mod(strobe_phase, TWO_PI))
    rs = np.array([law(s) for s in speeds])
    run = functools.partial(_sweep, pack_flat_rig(rig), v_stick=float(v_stick), revolutions=revolutions,
                            phase=phase, tolerances=tolerances)
    if client is None:
        strobe, counts, status, steps = run((speeds, rs))
        if progress is not None:
            progress(speeds.size, speeds.size)
    else:
        from impactid.distributed import map_tasks

        workers = max(1, len(client.scheduler_info().get("workers", {})))
        parts = [(a, b) for a, b in zip(np.array_split(speeds, min(speeds.size, 4 * workers)),
                                        np.array_split(rs, min(speeds.size, 4 * workers)))]
        sizes = [a.size for a, _ in parts]
        step = None if progress is None else (lambda done, _: progress(sum(sizes[:done]), speeds.size))
        pieces = map_tasks(run, parts, client=client, progress=step)
        strobe, counts, status, steps = (np.concatenate([piece[k] for piece in pieces]) for k in range(4))
    bad = np.flatnonzero(status != FK.OK)
    if bad.size:
        i = int(bad[0])
        raise SimulationError(f"rig F at {speeds[i] * 60:.6g} rpm: {FK.STATUS_MESSAGES[int(status[i])]}")
    profile = rig.contact_angle(np.linspace(0.0, TWO_PI, 3600, endpoint=False))
    stroke = float(profile.max() - profile.min())
    import pandas as pd

    rows = []
    angle = strobe[:, -kept:, 0]
    rate = strobe[:, -kept:, 1]
    for i, speed in enumerate(speeds):
        window = counts[i, -kept:]
        impacts = float(window[:, 0].sum()) / kept
        releases = float(window[:, 2].sum()) / kept
        if releases == 0.0 and impacts == 0.0:
            regime, period = "contact", 1
        else:
            period = find_period(angle[i], rate[i], stroke, periodicity_tol, max_period)
            regime = "irregular" if period == 0 else ("period-1" if period == 1 else "period-k")
        rows.append({"cam_speed_hz": float(speed), "cam_speed_rpm": float(speed) * 60.0, "restitution": float(rs[i]),
                     "regime": regime, "period_revolutions": int(period), "impacts_per_revolution": impacts,
                     "releases_per_revolution": releases, "strobe_spread": float(np.ptp(angle[i])),
                     "steps": int(steps[i])})
    return BifurcationResult(table=pd.DataFrame(rows), strobe_angle=angle.copy(), strobe_rate=rate.copy(),
                             revolutions=revolutions, kept=kept, restitution=law, strobe_phase=phase)


def warm_up() -> None:
    """Rig F's simulator and bifurcation sweep, briefly (``impactid warmup``)."""
    simulate_flat(ALZATE2007, 130.0 / 60.0, 0.5)
    bifurcation(ALZATE2007, [130.0 / 60.0], revolutions=4)

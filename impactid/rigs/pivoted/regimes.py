"""Motion regimes of rig P: classification of long runs, detachment speed, regime maps.

Classification (:func:`classify_regime`)
    A long run from static equilibrium is sampled stroboscopically once per cam revolution
    (``Theta = theta_ref + 2 pi k``). After a settling time, the run is examined in windows of
    ``window`` revolutions: the motion is

    * ``"contact"`` when no contact was lost in the window (permanent contact);
    * periodic with period ``k`` revolutions when the stroboscopic states repeat after ``k``
      samples (``k <= max_period``) to within ``periodicity_tol`` of their scale (alpha relative
      to the cam's angular stroke, alpha_dot relative to the largest rate in the window);
      ``"period-1"`` means one revolution and exactly one impact per revolution (the paper's
      working condition), any other periodic impacting motion is ``"period-k"`` (with
      ``period_revolutions`` and ``impacts_per_period`` reported);
    * ``"irregular"`` otherwise.

    Because transients of this model can decay slowly (tens of seconds of simulated time), the
    run is extended window by window (up to ``max_revolutions``) until two consecutive windows
    agree on a periodic classification; a motion still not periodic then is ``"irregular"`` and
    the result says whether the stroboscopic spread was still shrinking (``"settling": true``:
    possibly a very slow transient rather than chaos).

Detachment (:func:`detachment_speed`)
    Inverse kinematics: with the follower riding the cam (``psi_i = 0``), ``alpha_c(Theta)`` and its
    derivatives follow from the closed-form gap; the contact force needed is
    ``lambda = (I_b Omega^2 alpha_c'' - Q(alpha_c)) / (chi - mu sgn(v_r) h_p)``. Contact is lost at
    the lowest cam speed for which ``min over Theta of lambda`` reaches 0.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from scipy import optimize

from impactid.contact import HuntCrossley, Restitution
from impactid.errors import SimulationInputError
from impactid.rigs.pivoted import PivotedFollowerRig
from impactid.rigs.pivoted.runs import DEFAULT_TOLERANCES, Tolerances, simulate
from impactid.simulate.periodicity import find_period

__all__ = ["SEED_S2_LAW", "DetachmentResult", "Law", "RegimeResult", "classify_regime", "detachment_speed",
           "follower_kinematics", "regime_map", "required_contact_force"]

Law = HuntCrossley | Restitution

#: the paper's S2 contact law (Table 2 of Sundar, Dreyer & Singh (2016)), the default of every regime computation
SEED_S2_LAW = HuntCrossley(beta=24.7e9, n=1.5)


@dataclass(frozen=True)
class RegimeResult:
    """Classification of a long run.

    Attributes
    ----------
    regime : "contact", "period-1", "period-k" or "irregular".
    period_revolutions : period in cam revolutions (0 if not periodic, 1 for contact).
    impacts_per_period : number of contacts that start in one period (NaN if not periodic).
    impacts_per_revolution : mean number of contacts per revolution in the last window.
    settled_after_s : simulated time at which the classification became stable [s].
    simulated_s : total simulated time [s].
    stroboscopic_spread : spread of the stroboscopic alpha in the last window relative to the
        cam stroke (0 for a perfectly period-1 motion).
    settling : True when an irregular motion's spread was still shrinking (maybe a slow transient).
    e_over_rc, cam_speed_hz, beta, n, mu : the operating point.
    """

    regime: str
    period_revolutions: int
    impacts_per_period: float
    impacts_per_revolution: float
    settled_after_s: float
    simulated_s: float
    stroboscopic_spread: float
    settling: bool
    e_over_rc: float
    cam_speed_hz: float
    beta: float
    n: float
    mu: float

    def to_dict(self) -> dict:
        """Plain dict (JSON-ready)."""
        d = asdict(self)
        for key, value in d.items():
            if isinstance(value, float) and not math.isfinite(value):
                d[key] = None
        return d


def classify_regime(rig: PivotedFollowerRig, cam_speed_hz: float, law: Law | None = None, *,
                    mu: float | None = None, settle_revolutions: int = 200, window: int = 48,
                    max_revolutions: int = 2000, max_period: int = 12, periodicity_tol: float = 1e-4,
                    tolerances: Tolerances = DEFAULT_TOLERANCES) -> RegimeResult:
    """Classify the motion of rig P at a cam speed [Hz] (see the module docstring).

    Parameters
    ----------
    law : contact law; default the paper's S2 law ``beta = 24.7e9 N s m^-2.5, n = 1.5``.
    settle_revolutions : revolutions discarded before the first window.
    window : revolutions per examined window.
    max_revolutions : longest run before giving up on settling.
    periodicity_tol : relative tolerance of the stroboscopic repetition test. It is far above the
        integrator's error (rtol 1e-10) and below the differences between distinct periodic
        branches; a transient decaying slower than this is reported as not yet settled.
    """
    if law is None:
        law = SEED_S2_LAW
    if cam_speed_hz is None or not math.isfinite(cam_speed_hz) or cam_speed_hz <= 0.0:
        raise SimulationInputError(f"cam speed must be positive, got {cam_speed_hz!r} Hz")
    period = 1.0 / cam_speed_hz
    stroke = max(float(np.ptp(rig.contact_angle(np.linspace(0.0, 2.0 * math.pi, 64)))), 1e-9)
    state = None
    t = 0.0
    revs_done = 0
    first = True
    previous_k = None
    previous_spread = math.inf
    previous_a = np.empty(0)
    previous_lag1 = math.inf
    previous_r = np.empty(0)
    while True:
        n_revs = settle_revolutions + window if first else window
        grid = t + period * np.arange(1, n_revs + 1)
        run = simulate(rig, cam_speed_hz, law, n_revs * period, t_eval=grid, initial_state=state, t_start=t,
                       mu=mu, tolerances=tolerances)
        state = (run.final_alpha, run.final_alpha_dot)
        t = run.final_time
        revs_done += n_revs
        first = False
        strobe_a = run.alpha[-window:]
        strobe_r = run.alpha_dot[-window:]
        # the periodicity test looks at the last two windows together
        pair_a = np.concatenate([previous_a, strobe_a])
        pair_r = np.concatenate([previous_r, strobe_r])
        previous_a, previous_r = strobe_a, strobe_r
        t_window0 = t - window * period
        starts = run.contacts["t_start"].to_numpy()
        lost_contact = bool(np.any(run.mode[-window:] == 0)) or np.any(
            (starts > t_window0) & (run.contacts["kind"].to_numpy() != "stick"))
        in_window = starts[(starts > t_window0)]
        per_rev = in_window.size / window
        spread = float(np.ptp(strobe_a)) / stroke
        if not lost_contact and run.contacts.shape[0] <= 1:
            k = 1
            regime = "contact"
        else:
            k = find_period(pair_a, pair_r, stroke, periodicity_tol, max_period)
            regime = "irregular" if k == 0 else ("period-1" if (k == 1 and in_window.size == window) else "period-k")
        # a decaying transient can look periodic with a multiple of its true period: accept k > 1
        # only when the lag-1 differences have stopped shrinking between the two windows
        lag1 = float(np.max(np.abs(np.diff(strobe_a)))) / stroke
        converging = k > 1 and lag1 < 0.9 * previous_lag1
        previous_lag1 = lag1
        stable = k > 0 and previous_k == k and not converging
        if stable or revs_done >= max_revolutions:
            settling = (regime == "irregular" and spread < 0.5 * previous_spread) or converging
            impacts_per_period = (in_window.size / window) * k if k > 0 else math.nan
            if regime == "contact":
                impacts_per_period = 0.0
            beta = law.beta if isinstance(law, HuntCrossley) else math.nan
            n = law.n if isinstance(law, HuntCrossley) else math.nan
            return RegimeResult(
                regime=regime, period_revolutions=int(k), impacts_per_period=float(impacts_per_period),
                impacts_per_revolution=float(per_rev),
                settled_after_s=float(t - 2 * window * period) if stable else math.nan,
                simulated_s=float(t), stroboscopic_spread=spread, settling=bool(settling),
                e_over_rc=rig.e_over_rc, cam_speed_hz=float(cam_speed_hz), beta=float(beta), n=float(n),
                mu=float(run.mu))
        previous_k = k
        previous_spread = spread


# ---------------------------------------------------------------------------------------------
# Detachment by inverse kinematics
# ---------------------------------------------------------------------------------------------


def follower_kinematics(rig: PivotedFollowerRig, theta):
    """Follower angle riding the cam and its derivatives with respect to the cam angle.

    Returns ``alpha_c``, ``d alpha_c / d Theta``, ``d2 alpha_c / d Theta2`` (implicit differentiation of
    ``psi_i(alpha, Theta) = 0``: ``psi_alpha = chi``, ``psi_Theta = -e cos(alpha + Theta)``,
    ``psi_alpha_alpha = -(h_p + r_c)``, ``psi_alpha_Theta = psi_Theta_Theta = e sin(alpha + Theta)``).
    """
    theta = np.asarray(theta, dtype=float)
    alpha = rig.contact_angle(theta)
    chi = rig.lever_arm(alpha, theta)
    s = rig.e * np.sin(alpha + theta)
    c = rig.e * np.cos(alpha + theta)
    d1 = c / chi
    d2 = -(-rig.contact_radius * d1**2 + 2.0 * s * d1 + s) / chi
    return alpha, d1, d2


def required_contact_force(rig: PivotedFollowerRig, cam_speed_hz: float, theta, mu: float | None = None):
    """Contact force [N] needed to keep the follower on the cam at ``theta`` (rigid contact)."""
    mu = rig.mu if mu is None else mu
    omega = 2.0 * math.pi * cam_speed_hz
    alpha, d1, d2 = follower_kinematics(rig, theta)
    rate = omega * d1
    accel = omega**2 * d2
    v_r = rig.sliding_velocity(alpha, rate, theta, omega)
    chi = rig.lever_arm(alpha, theta)
    return (rig.I_b * accel - rig.free_torque(alpha)) / (chi - mu * np.sign(v_r) * rig.h_p)


@dataclass(frozen=True)
class DetachmentResult:
    """Lowest cam speed at which the follower loses contact (inverse kinematics)."""

    cam_speed_hz: float
    cam_angle: float
    e_over_rc: float

    @property
    def cam_speed_rpm(self) -> float:
        return 60.0 * self.cam_speed_hz

    def to_dict(self) -> dict:
        return {"cam_speed_hz": self.cam_speed_hz, "cam_speed_rpm": self.cam_speed_rpm,
                "cam_angle_rad": self.cam_angle, "e_over_rc": self.e_over_rc}


def detachment_speed(rig: PivotedFollowerRig, mu: float | None = None, n_angles: int = 3600) -> DetachmentResult:
    """Lowest cam speed [Hz] at which the required contact force reaches zero somewhere.

    Without friction ``lambda = (I_b Omega^2 alpha'' - Q) / chi`` is linear in ``Omega^2`` at each cam
    angle, so the speed is ``min over Theta`` of ``sqrt(Q / (I_b alpha''))`` where ``alpha'' < 0``
    (refined with a bounded scalar minimisation). Friction changes the sign of the denominator's
    small correction only, and is included by bisection on ``min lambda``.
    """
    if rig.e <= 0.0:
        raise SimulationInputError("a cam with zero eccentricity never detaches the follower")
    theta = np.linspace(0.0, 2.0 * math.pi, n_angles, endpoint=False)

    def omega_sq(th):
        alpha, _, d2 = follower_kinematics(rig, th)
        q = rig.free_torque(alpha)
        with np.errstate(divide="ignore", invalid="ignore"):
            w2 = np.where(d2 < 0.0, q / (rig.I_b * d2), np.inf)
        return np.where(w2 > 0.0, w2, np.inf)

    w2 = omega_sq(theta)
    i = int(np.argmin(w2))
    if not np.isfinite(w2[i]):
        raise SimulationInputError("the follower never needs a pulling force: no detachment speed")
    step = 2.0 * math.pi / n_angles
    res = optimize.minimize_scalar(lambda th: float(omega_sq(np.array([th]))[0]),
                                   bounds=(theta[i] - step, theta[i] + step), method="bounded",
                                   options={"xatol": 1e-12})
    th_star = float(res.x) % (2.0 * math.pi)
    f_hz = math.sqrt(float(res.fun)) / (2.0 * math.pi)
    mu_eff = rig.mu if mu is None else mu
    if mu_eff != 0.0:
        def min_force(hz):
            return float(np.min(required_contact_force(rig, hz, theta, mu=mu_eff)))
        lo, hi = 0.8 * f_hz, 1.25 * f_hz
        if min_force(lo) > 0.0 > min_force(hi):
            f_hz = optimize.brentq(min_force, lo, hi, xtol=1e-10)
            th_star = float(theta[np.argmin(required_contact_force(rig, f_hz, theta, mu=mu_eff))])
    return DetachmentResult(cam_speed_hz=f_hz, cam_angle=th_star, e_over_rc=rig.e_over_rc)


# ---------------------------------------------------------------------------------------------
# Regime map
# ---------------------------------------------------------------------------------------------


def _classify_point(point: tuple[PivotedFollowerRig, float], law: Law, mu: float | None, options: dict) -> dict:
    """One simulated point of :func:`regime_map` (a module-level function: it is sent to workers)."""
    rig, hz = point
    return classify_regime(rig, hz, law, mu=mu, **options).to_dict()


def regime_map(rig: PivotedFollowerRig, e_over_rc, cam_speeds_hz, law: Law | None = None, *,
               mu: float | None = None, progress=None, client=None, **classify_kwargs):
    """Classify the motion over a grid of (e/r_c, cam speed) — Fig. 3 of Sundar, Dreyer & Singh (2016).

    Parameters
    ----------
    rig : rig P; its eccentricity is set to each ratio of ``e_over_rc``.
    e_over_rc : eccentricity ratios ``e / r_c`` [-].
    cam_speeds_hz : cam speeds [Hz].
    law : contact law (default :data:`SEED_S2_LAW`).
    mu : friction coefficient (default: the rig's).
    progress : optional callable ``progress(done, total)`` over the grid points.
    client : a :class:`distributed.Client`: the simulated points are classified on its cluster
        (:mod:`impactid.distributed`); None (default): one after the other here. The table is the same.
    classify_kwargs : passed to :func:`classify_regime`.

    Returns
    -------
    pandas.DataFrame
        one row per grid point (ratios outer, speeds inner): the :class:`RegimeResult` fields plus
        ``detachment_hz`` (inverse kinematics) for that eccentricity and ``simulated`` (False below
        the detachment speed, where the follower stays on the cam without simulating).
    """
    import functools

    import pandas as pd

    from impactid.distributed import map_tasks

    law = SEED_S2_LAW if law is None else law
    e_values = [float(x) for x in np.atleast_1d(e_over_rc)]
    speeds = [float(x) for x in np.atleast_1d(cam_speeds_hz)]
    total = len(e_values) * len(speeds)
    rows: list[dict | None] = []
    simulate_at: list[tuple[int, tuple[PivotedFollowerRig, float]]] = []
    details: list[float] = []
    for ratio in e_values:
        r = rig.with_eccentricity_ratio(ratio)
        det = detachment_speed(r, mu=mu).cam_speed_hz
        for hz in speeds:
            details.append(det)
            if hz < det:
                # below detachment the follower stays on the cam: no need to simulate
                row = RegimeResult("contact", 1, 0.0, 0.0, 0.0, 0.0, 0.0, False, ratio, hz,
                                   getattr(law, "beta", math.nan), getattr(law, "n", math.nan),
                                   r.mu if mu is None else mu).to_dict()
                row["simulated"] = False
                rows.append(row)
            else:
                simulate_at.append((len(rows), (r, hz)))
                rows.append(None)
    skipped = total - len(simulate_at)
    if progress is not None and skipped:
        progress(skipped, total)
    step = None if progress is None else (lambda done, _: progress(skipped + done, total))
    classified = map_tasks(functools.partial(_classify_point, law=law, mu=mu, options=classify_kwargs),
                           [point for _, point in simulate_at], client=client, progress=step)
    for (k, _), row in zip(simulate_at, classified):
        row["simulated"] = True
        rows[k] = row
    for row, det in zip(rows, details):
        row["detachment_hz"] = det
    return pd.DataFrame(rows)

"""The two-mass valve-spring surge model shared by the valve-train rigs.

A helical valve spring of static rate ``K0`` [N/m] whose first surge (standing-wave) frequency with
both ends clamped is ``f0`` [Hz] is replaced by two equal masses joined by three springs (end, middle,
end), chosen so that the model has the spring's static rate, its first natural frequency ``f0``
and, as a clamped-clamped continuous spring does, its second at ``2 f0`` (Kim, Jeon & Park 1990;
the same model in Kushwaha, Rahnejat & Jin 2000):

    m1 = m2 = (2/3) K0 / (pi f0)^2,    K_s1 = K_s3 = (8/3) K0,    K_s2 = 4 K0

Check: the three springs in series give ``1 / (3/8 + 1/4 + 3/8) K0 = K0``; the in-phase mode (middle
spring unstretched) has ``omega^2 = K_s1 / m = (2 pi f0)^2``, the anti-phase mode
``(K_s1 + 2 K_s2) / m = (4 pi f0)^2``.

Damping, the two papers' conventions:

* stiffness-proportional (Kim et al.: "4 % proportional viscous damping"): ``C_si = a K_si`` with
  ``a = 2 zeta / (2 pi f0)``, giving the damping ratio ``zeta`` in the first mode and ``2 zeta`` in
  the second;
* one damper ``c`` on all three elements (Kushwaha et al.).

The first-mode damping ratio of either convention is computed by one function,
:meth:`SurgeModel.damping_ratios` (:func:`damper_damping_ratio` for one damper ``c``); the rigs and
the fits report it from there, never from a second formula.

Sign convention: the valve (or retainer) end moves by ``y_v``, the masses by ``y_1`` (next to the
valve) and ``y_2`` (next to the head), all positive in the valve-opening direction; the head end
is fixed. The functions are plain arithmetic, so rig kernels compile them with numba.

Besides the spring, the module holds what the two valve-train rigs' commands check alike: the
camshaft speeds their models describe (:class:`CamSpeedRange`) and whether a recorded channel
can inform a fit (:func:`check_fit_channel` before it, :func:`check_model_explains` after it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from impactid.errors import RigParameterError, SimulationInputError

__all__ = ["MAX_SPEED_FACTOR", "MIN_SPEED_FRACTION", "CamSpeedRange", "SurgeModel", "check_fit_channel",
           "check_model_explains", "damper_damping_ratio", "surge_accelerations", "surge_model"]


@dataclass(frozen=True)
class SurgeModel:
    """Two-mass surge model of a valve spring (SI units).

    Attributes
    ----------
    mass : each of the two equal masses ``m1 = m2`` [kg].
    k_end, k_middle : end springs ``K_s1 = K_s3`` and middle spring ``K_s2`` [N/m].
    c_end, c_middle : their dampers [N s/m].
    """

    mass: float
    k_end: float
    k_middle: float
    c_end: float
    c_middle: float

    def matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Mass, damping and stiffness matrices of the two masses with both ends clamped."""
        m, k1, k2, c1, c2 = self.mass, self.k_end, self.k_middle, self.c_end, self.c_middle
        mass = np.diag([m, m])
        stiffness = np.array([[k1 + k2, -k2], [-k2, k2 + k1]])
        damping = np.array([[c1 + c2, -c2], [-c2, c2 + c1]])
        return mass, damping, stiffness

    def natural_frequencies(self) -> np.ndarray:
        """Undamped natural frequencies [Hz] with both ends clamped (ascending)."""
        mass, _, stiffness = self.matrices()
        return np.sqrt(np.sort(np.linalg.eigvals(np.linalg.solve(mass, stiffness)).real)) / (2.0 * math.pi)

    def damping_ratios(self) -> np.ndarray:
        """Modal damping ratios of the two modes (the damping is proportional, so the modes decouple)."""
        mass, damping, stiffness = self.matrices()
        values, vectors = np.linalg.eig(np.linalg.solve(mass, stiffness))
        order = np.argsort(values.real)
        out = []
        for k in order:
            v = vectors[:, k].real
            m_k, c_k, k_k = v @ mass @ v, v @ damping @ v, v @ stiffness @ v
            out.append(c_k / (2.0 * math.sqrt(k_k * m_k)))
        return np.array(out)

    @property
    def static_rate(self) -> float:
        """Rate of the three springs in series [N/m] (equals ``K0``)."""
        return 1.0 / (2.0 / self.k_end + 1.0 / self.k_middle)


def surge_model(K0: float, f0: float, *, damping_ratio: float | None = None,
                damper: float | None = None) -> SurgeModel:
    """The two-mass model of a spring of rate ``K0`` [N/m] and first surge frequency ``f0`` [Hz].

    Give exactly one of ``damping_ratio`` (stiffness-proportional damping with that ratio in the
    first mode, Kim et al.) or ``damper`` [N s/m] (one damper on all three elements, Kushwaha et al.).
    """
    if not (math.isfinite(K0) and K0 > 0.0 and math.isfinite(f0) and f0 > 0.0):
        raise RigParameterError(f"K0 and f0 must be positive and finite, got {K0!r}, {f0!r}")
    if (damping_ratio is None) == (damper is None):
        raise ValueError("give exactly one of damping_ratio and damper")
    mass = (2.0 / 3.0) * K0 / (math.pi * f0) ** 2
    k_end, k_middle = (8.0 / 3.0) * K0, 4.0 * K0
    if damping_ratio is not None:
        if not (math.isfinite(damping_ratio) and damping_ratio >= 0.0):
            raise RigParameterError(f"damping_ratio must be >= 0, got {damping_ratio!r}")
        a = 2.0 * damping_ratio / (2.0 * math.pi * f0)
        return SurgeModel(mass, k_end, k_middle, a * k_end, a * k_middle)
    if not (math.isfinite(damper) and damper >= 0.0):
        raise RigParameterError(f"damper must be >= 0, got {damper!r}")
    return SurgeModel(mass, k_end, k_middle, float(damper), float(damper))


def damper_damping_ratio(K0: float, f0: float, damper: float) -> float:
    """First-mode damping ratio [-] of a spring of rate ``K0`` [N/m] and surge frequency ``f0`` [Hz]
    with one damper ``damper`` [N s/m] on all three elements (Kushwaha et al.'s convention).

    It is :meth:`SurgeModel.damping_ratios` of :func:`surge_model` (the one place the ratio is
    computed); for the record, it equals ``3 pi c f0 / (8 K0)`` (``c / (2 sqrt(K_s1 m))``), so 2.355 N s/m
    on the papers' spring (35 kN/m, 504.5 Hz) is 4.0 %.
    """
    return float(surge_model(K0, f0, damper=damper).damping_ratios()[0])


def surge_accelerations(y_v, v_v, y_1, v_1, y_2, v_2, mass, k_end, k_middle, c_end, c_middle):
    """Accelerations of the two spring masses and the spring force on the valve end.

    Returns ``(a_1, a_2, force_on_valve)``: ``m a_1 = K_s1 (y_v - y_1) + C_s1 (v_v - v_1) - K_s2 (y_1 - y_2)
    - C_s2 (v_1 - v_2)``, ``m a_2 = K_s2 (y_1 - y_2) + C_s2 (v_1 - v_2) - K_s3 y_2 - C_s3 v_2``, and the force
    of the first spring on the valve end, ``-(K_s1 (y_v - y_1) + C_s1 (v_v - v_1))`` [N] (it resists opening;
    the static preload is added by the rig). Plain arithmetic, compiled by the rigs' kernels.
    """
    end = k_end * (y_v - y_1) + c_end * (v_v - v_1)
    middle = k_middle * (y_1 - y_2) + c_middle * (v_1 - v_2)
    head = k_end * y_2 + c_end * v_2
    return (end - middle) / mass, (middle - head) / mass, -end


# ---- what the valve-train commands check alike ------------------------------------------------

#: Highest camshaft speed the valve-train models are used at, as a multiple of the rig's
#: rigid-follower jump speed (see :class:`CamSpeedRange`).
MAX_SPEED_FACTOR = 3.0
#: Lowest camshaft speed, as a fraction of the rigid-follower jump speed.
MIN_SPEED_FRACTION = 1.0 / 300.0


@dataclass(frozen=True)
class CamSpeedRange:
    """The camshaft speeds a valve-train model describes, from its rigid-follower jump speed.

    The decision (the same for both valve trains). The range scales with the rig's rigid-follower
    jump speed ``n_j``, the speed at which the inertia of the moving parts on the closing flank,
    ``m omega^2 |s''|``, first exceeds the spring force ``F_preload + k s`` that holds them on the
    cam (a closed form for each rig, within 6 % of the simulated jump speed of both papers' rigs):

    * at most ``MAX_SPEED_FACTOR n_j = 3 n_j``: the inertia forces are then 9 times what the spring
      can hold; the follower leaves the cam for most of the event and the valve lands on its seat at
      speeds far outside the force range over which the contact stiffnesses were linearised and the
      seat model was taken from the literature (the adherent model of the cycloidal rig already
      fails at ``n_j``, the tappet drag was identified at 900 and 1600 rpm). Beyond it a simulation
      returns numbers of no engine (10^9 rpm gave contact loads of 5e13 N).
    * at least ``MIN_SPEED_FRACTION n_j = n_j / 300``: the inertia forces are below 1.1e-5 of the
      spring force, so the motion is the quasi-static one to that accuracy (nothing dynamic is left
      to simulate or identify), while the cost of following the surge ringing, ``f0 / n`` spring
      periods per revolution (about 2700 at the limit), grows without bound as the speed falls
      (1 rpm exhausts the integrator's step budget).

    For the papers' rigs: about 11 to 9700 rpm (cycloidal, ``n_j`` = 3240 rpm) and 11 to 9900 rpm
    (finger follower, ``n_j`` = 3300 rpm).

    Attributes
    ----------
    rigid_jump_rpm : the rig's rigid-follower jump speed [rpm] (camshaft).
    """

    rigid_jump_rpm: float

    def __post_init__(self) -> None:
        if not (self.rigid_jump_rpm > 0.0):  # inf (a lift without deceleration) is allowed
            raise SimulationInputError(f"rigid-follower jump speed must be positive, got {self.rigid_jump_rpm!r} rpm")

    @property
    def lowest_rpm(self) -> float:
        """Lowest camshaft speed [rpm] the model is used at."""
        return MIN_SPEED_FRACTION * self.rigid_jump_rpm if math.isfinite(self.rigid_jump_rpm) else 0.0

    @property
    def highest_rpm(self) -> float:
        """Highest camshaft speed [rpm] the model is used at."""
        return MAX_SPEED_FACTOR * self.rigid_jump_rpm

    def describe(self) -> str:
        """The range and where it comes from, for messages."""
        return (f"{self.lowest_rpm:.4g} to {self.highest_rpm:.4g} rpm camshaft (1/{1 / MIN_SPEED_FRACTION:g} to "
                f"{MAX_SPEED_FACTOR:g} times this rig's rigid-follower jump speed, {self.rigid_jump_rpm:.5g} rpm)")

    def check(self, rpm: float, what: str, error: type[Exception] = SimulationInputError) -> float:
        """``rpm`` [rpm] as a float, or ``error`` naming ``what`` (an argument, or a file and attribute)
        when it is not a finite speed inside the range."""
        try:
            value = float(rpm)
        except (TypeError, ValueError):
            raise error(f"{what}: expected a camshaft speed in rpm, got {rpm!r}") from None
        if not (math.isfinite(value) and value > 0.0):
            raise error(f"{what}: the camshaft speed must be positive and finite, got {rpm!r} rpm")
        if not self.lowest_rpm <= value <= self.highest_rpm:
            side = "above" if value > self.highest_rpm else "below"
            raise error(f"{what}: {value:.6g} rpm is {side} the speeds this rig's model describes, "
                        f"{self.describe()}")
        return value


#: Fewest samples a fitted channel must hold.
MIN_FIT_SAMPLES = 144
#: Significance of :func:`check_model_explains`: a fit whose model explains no more of the channel
#: than noise alone would, at this level, is refused.
INFORMATION_SIGNIFICANCE = 1e-3


def check_fit_channel(values, cam_angle, *, where: str, channel: str, unit: str = "",
                      error: type[Exception] = ValueError, min_revolutions: float = 0.999) -> None:
    """Refuse, before a fit starts, a channel that cannot inform it.

    A valve-train fit compares a model periodic in the cam angle with a channel; a channel with
    non-finite samples, fewer than :data:`MIN_FIT_SAMPLES` samples, less than ``min_revolutions``
    camshaft revolutions, or one value in every sample (a zero or constant channel: a dead or
    disconnected sensor) can only return the start values. Whether a varying channel carries more
    than noise is decided after the fit, by :func:`check_model_explains` (a test against the
    fitted model is far more sensitive than any test of the channel alone).

    Parameters
    ----------
    values : the channel's samples [SI].
    cam_angle : the cam angle of each sample [rad], unwrapped (any zero).
    where, channel, unit : the file, the channel's name and its SI unit, for the message.
    error : the exception class raised (the fit's own, an :class:`~impactid.errors.ImpactidError`).
    min_revolutions : the camshaft revolutions the channel must cover.

    Raises
    ------
    error
        naming the file and the channel, and why the channel cannot inform the fit.
    """
    y = np.asarray(values, dtype=float).ravel()
    angle = np.asarray(cam_angle, dtype=float).ravel()
    what = f"{where}: channel {channel!r}"
    if y.size != angle.size:
        raise error(f"{what} has {y.size} samples but the cam angle {angle.size}")
    bad = ~np.isfinite(y)
    if bad.any():
        raise error(f"{what} has {int(bad.sum())} NaN or Inf sample(s), the first at index {int(np.argmax(bad))}")
    if (~np.isfinite(angle)).any():
        raise error(f"{where}: the cam angle has NaN or Inf samples")
    if y.size < MIN_FIT_SAMPLES:
        raise error(f"{what} is too short: {y.size} samples; a fit needs at least {MIN_FIT_SAMPLES}")
    revolutions = (float(np.max(angle)) - float(np.min(angle))) / (2.0 * math.pi)
    if not revolutions >= min_revolutions:
        raise error(f"{what} is too short: it covers {revolutions:.3g} camshaft revolutions (channel 'cam_angle'); "
                    f"at least {min_revolutions:.3g} are needed to see the whole cam event")
    lo, hi = float(np.min(y)), float(np.max(y))
    if lo == hi:
        suffix = f" {unit}" if unit else ""
        state = "zero in every sample" if lo == 0.0 else f"constant ({lo:.6g}{suffix} in every sample)"
        raise error(f"{what} is {state}: it carries no information for this fit (a dead or disconnected sensor?)")


def check_model_explains(null_ss: float, residual_ss: float, n: int, model_params: int, *, null_params: int = 1,
                         where: str, channel: str, error: type[Exception] = ValueError) -> None:
    """Refuse a fit whose model explains no more of the channel than noise alone would.

    The F test of the fitted model against the null model (the offsets or the constant the fit
    carries anyway): ``F = ((SS0 - SS1) / p) / (SS1 / (n - p0 - p))`` with ``SS0`` and ``SS1`` the
    residual sums of squares of the null model and of the fit, ``p`` the model's further parameters
    and ``p0`` the null model's. On a channel of noise alone ``F`` is about 1; the fit is refused
    when the probability of an ``F`` as large from noise alone is above
    :data:`INFORMATION_SIGNIFICANCE`. (Noise alone is told from a weak but real signal by the model:
    a tappet record with noise twice its amplitude, one revolution, still passes, with the fit's
    wide intervals to say how little it determines.)

    Parameters
    ----------
    null_ss, residual_ss : ``SS0`` and ``SS1`` [squared channel units].
    n : data points; model_params : ``p``; null_params : ``p0``.
    where, channel : the file(s) and the channel, for the message.
    error : the exception class raised.
    """
    dof = n - null_params - model_params
    if dof < 1:
        raise error(f"{where}: channel {channel!r} is too short: {n} values for {null_params + model_params} "
                    "parameters")
    if not (math.isfinite(null_ss) and math.isfinite(residual_ss)):
        raise error(f"{where}: channel {channel!r}: the fit ended with a non-finite residual")
    if residual_ss <= 0.0:
        return  # the model reproduces the channel exactly
    ratio = ((null_ss - residual_ss) / model_params) / (residual_ss / dof)
    from scipy import stats

    if ratio <= 0.0:
        raise error(f"{where}: channel {channel!r} carries no information for this fit: the fitted model explains "
                    "none of it (it leaves more scatter than the channel has about its mean); is it noise only, or "
                    "the wrong channel?")
    p_value = float(stats.f.sf(ratio, model_params, dof))
    if not p_value < INFORMATION_SIGNIFICANCE:
        raise error(f"{where}: channel {channel!r} carries no information for this fit: the fitted model explains "
                    f"no more of it than noise alone would (F = {ratio:.3g} on {model_params} and {dof} degrees of "
                    f"freedom, p = {p_value:.2g}); is it noise only, or the wrong channel?")

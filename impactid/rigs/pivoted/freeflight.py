"""Free flight of rig P and the return-time anchor of the per-impact pipeline (S-19).

``I_b alpha_ddot = m_b g l_g cos(alpha) - F_s(alpha) d_x`` (S-9) is smooth and slow (its natural
frequency is a few Hz) over one cam revolution, so a fixed-step classical RK4 with a few thousand
steps is accurate to about 1e-13 rad; ``tests/rigs/pivoted/test_freeflight.py`` checks it against
``scipy.integrate.solve_ivp`` (DOP853, rtol 1e-12). The variational equation is integrated
alongside, so the anchor's Newton iteration has the exact derivative of the end angle with
respect to the start angle.

:func:`free_flight_fit` checks the rig file against a recording: the measured angular acceleration
between impacts against the free-flight model's at the reconstructed angles. A wrong inertia ``I_b``
scales the model's acceleration, a wrong spring stiffness ``k_s`` (or preload) adds a term linear in the
angle; a refit of the model with a free scale and a free linear term (and each flight's accelerometer
offset) then removes what the rig file's model leaves, and measures how far the rig file is off.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from numba import njit, prange

from impactid import compilation
from impactid.engine.distributions import chi2_sf
from impactid.rigs.pivoted import kernel as K

compilation.install()  # before the kernels: the kernel cache's locators and the first-use notice

__all__ = ["FREE_FLIGHT_CLEAN", "FREE_FLIGHT_CLEAN_SWING", "FREE_FLIGHT_MISFIT", "FREE_FLIGHT_SIGNIFICANCE",
           "FREE_FLIGHT_STEPS", "FreeFlightFit", "free_accelerations", "free_flight", "free_flight_fit",
           "return_time_anchors"]

#: A recording's free flight counts as clean when the refitted model (:func:`free_flight_fit`) leaves a
#: residual RMS at most this many times the accelerometer's noise, or at most :data:`FREE_FLIGHT_CLEAN_SWING`
#: of the acceleration's swing (what is left is noise and the double integration's own error: no contact,
#: no riding, no other force between impacts). Measured (envelope cases): right and wrong rigs (I_b, k_s
#: off by 20-30 %) leave 0.5-1.3 x the noise, or up to 1e-3 of the swing where the detector's separations
#: were moved; followers riding the cam leave 0.3-0.5 of the swing (800-13000 x the noise).
FREE_FLIGHT_CLEAN = 2.0
FREE_FLIGHT_CLEAN_SWING = 0.02
#: The rig file's free-flight model disagrees with a clean recording when what the refit removes is more
#: than this share of the free-flight acceleration's swing (RMS over standard deviation) and significant.
#: Measured: 0.19-0.31 with I_b x 1.3 or x 0.75 and k_s x 1.25 or x 0.7; at most 2e-4 on noise-free
#: recordings of the right rig (and up to 0.3 on noisy ones, where it is not significant).
FREE_FLIGHT_MISFIT = 0.05
#: Significance of the refit's two extra parameters (chi-square with 2 degrees of freedom; 3 sigma).
FREE_FLIGHT_SIGNIFICANCE = 0.0027

#: RK4 steps per free flight (one cam revolution or less).
FREE_FLIGHT_STEPS = 2000


@njit(cache=True)
def _free_accel(a, p):
    return K._torque(a, p) / p[K.I_B]


@njit(cache=True)
def _free_accel_slope(a, p):
    """d(alpha_ddot)/d(alpha) of free flight (central difference of the torque, h = 1e-7 rad)."""
    h = 1e-7
    return (K._torque(a + h, p) - K._torque(a - h, p)) / (2.0 * h * p[K.I_B])


@njit(cache=True)
def _derivatives(a, v, sa, sv, p):
    """Right-hand side of the free flight and of its variational equation."""
    return v, _free_accel(a, p), sv, _free_accel_slope(a, p) * sa


@njit(cache=True)
def free_flight(alpha0, rate0, duration, p, steps):  # pragma: no cover - compiled
    """Free flight from ``(alpha0, rate0)`` for ``duration`` [s]: returns
    ``(alpha, rate, d alpha / d alpha0, d rate / d alpha0)`` at the end (RK4, ``steps`` steps)."""
    h = duration / steps
    a, v, sa, sv = alpha0, rate0, 1.0, 0.0  # state and its sensitivities to alpha0
    for _ in range(steps):
        k1 = _derivatives(a, v, sa, sv, p)
        k2 = _derivatives(a + 0.5 * h * k1[0], v + 0.5 * h * k1[1], sa + 0.5 * h * k1[2], sv + 0.5 * h * k1[3], p)
        k3 = _derivatives(a + 0.5 * h * k2[0], v + 0.5 * h * k2[1], sa + 0.5 * h * k2[2], sv + 0.5 * h * k2[3], p)
        k4 = _derivatives(a + h * k3[0], v + h * k3[1], sa + h * k3[2], sv + h * k3[3], p)
        a += h / 6.0 * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0])
        v += h / 6.0 * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1])
        sa += h / 6.0 * (k1[2] + 2.0 * k2[2] + 2.0 * k3[2] + k4[2])
        sv += h / 6.0 * (k1[3] + 2.0 * k2[3] + 2.0 * k3[3] + k4[3])
    return a, v, sa, sv


@njit(cache=True, parallel=True)
def return_time_anchors(start_rate, duration, displacement, guess, p, steps, tol, out):  # pragma: no cover - compiled
    """For each event, the start angle ``alpha_s`` of a free flight that, from rate
    ``start_rate``, moves by ``displacement`` in ``duration``: Newton on
    ``G(alpha_s) = alpha(duration; alpha_s) - alpha_s - displacement``.

    ``guess`` holds the initial iterates. Fills
    ``out[i] = (alpha_s, G'(alpha_s), iterations)``; ``iterations`` is -1 if Newton failed. The events are
    independent: they are shared out among numba's threads (the same numbers as one by one).
    """
    for i in prange(guess.shape[0]):
        x = guess[i]
        it = 0
        slope = 0.0
        ok = False
        while it < 30:
            a_end, _, sa, _ = free_flight(x, start_rate[i], duration[i], p, steps)
            g = a_end - x - displacement[i]
            slope = sa - 1.0
            it += 1
            if slope == 0.0 or not np.isfinite(g):
                break
            step = g / slope
            x -= step
            if abs(step) < tol:
                ok = True
                break
        out[i, 0] = x
        out[i, 1] = slope
        out[i, 2] = it if ok else -1


@njit(cache=True)
def free_accelerations(alpha, p):  # pragma: no cover - compiled
    """The free flight's angular acceleration [rad/s^2] at each angle of ``alpha`` [rad] (S-9)."""
    out = np.empty(alpha.shape[0])
    for k in range(alpha.shape[0]):
        out[k] = _free_accel(alpha[k], p)
    return out


@dataclass(frozen=True)
class FreeFlightFit:
    """The rig file's free-flight model against a recording's free flights (:func:`free_flight_fit`).

    Attributes
    ----------
    events, samples : free flights and samples compared.
    noise : the angular acceleration's noise [rad/s^2] (the accelerometer's noise floor over its radius).
    swing : standard deviation of the model's acceleration within the flights [rad/s^2].
    model_rms : RMS of the measured minus the model's acceleration, each flight's offset removed [rad/s^2].
    refit_rms : the same after the refit (a scale of the model and a term linear in the angle) [rad/s^2].
    scale : the refit's scale of the model's acceleration (1 for the right inertia: ``I_b`` of the rig
        file over the recording's).
    linear : the refit's linear term over the model's slope ``d alpha_ddot / d alpha`` (0 for the right
        spring: a wrong ``k_s`` or preload makes it non-zero).
    misfit : RMS of what the refit removes over the swing [-].
    chi_square, p_value : ``(SS_model - SS_refit) / noise^2`` and its probability under ``chi^2(2)``.
    clean : the refit leaves noise (:data:`FREE_FLIGHT_CLEAN`, :data:`FREE_FLIGHT_CLEAN_SWING`).
    disagrees : clean, and the rig file's model misses by more than :data:`FREE_FLIGHT_MISFIT` of the
        swing, significantly (:data:`FREE_FLIGHT_SIGNIFICANCE`).
    """

    events: int
    samples: int
    noise: float
    swing: float
    model_rms: float
    refit_rms: float
    scale: float
    linear: float
    misfit: float
    chi_square: float
    p_value: float
    clean: bool
    disagrees: bool

    def to_dict(self) -> dict:
        return {k: getattr(self, k) for k in self.__dataclass_fields__}

    def reason(self) -> str:
        """Why the recorded motion is not the rig file's, in words ("" when it agrees)."""
        if not self.disagrees:
            return ""
        return (f"the recorded motion is not the motion of the rig described by the rig file: the rig file's "
                f"free-flight model misses the measured angular acceleration between impacts by "
                f"{100 * self.misfit:.3g} % of its swing over {self.events} flights, while the same model with its "
                f"acceleration scaled ({self.scale:.3g}) and a term linear in the angle added fits them to the noise "
                f"({self.refit_rms / self.noise:.2g} x the noise): the rig file's constants that govern the "
                "reconstruction look wrong: the follower's moment of inertia I_b, the return spring's stiffness k_s "
                "or its preload (or the accelerometer's scale); check the rig file")


def free_flight_fit(alpha: Iterable[np.ndarray], acceleration: Iterable[np.ndarray], p: np.ndarray,
                    noise: float) -> FreeFlightFit | None:
    """The rig file's free-flight model against measured free flights.

    Parameters
    ----------
    alpha : per flight, the reconstructed angles [rad] of its free samples.
    acceleration : per flight, the measured angular acceleration on them [rad/s^2] (any constant offset).
    p : the packed rig (:func:`~impactid.rigs.pivoted.runs.pack_rig`) of the rig file.
    noise : the angular acceleration's noise [rad/s^2].

    Returns
    -------
    :class:`FreeFlightFit`, or None with fewer than two flights of at least 16 samples (or no noise scale).

    The measured acceleration is fitted as ``b_i + s m(alpha) + c (alpha - mean)`` (``m`` the model's free
    acceleration, ``b_i`` each flight's offset); the rig file's model is ``s = 1, c = 0``.
    """
    # flight by flight (a recording's free samples are most of it: 12 M at 60 s and 204.8 kHz, whose
    # concatenated copies held 1 GB): the sums of the fit, and the triangular factor of the design
    # [m, x | y - m] stacked over the flights (a QR of the stacked factors is the QR of the whole design)
    events = n = 0
    ss_model = sum_m = sum_mm = sum_xm = sum_xx = 0.0
    factor = np.zeros((0, 3))
    for a, y in zip(alpha, acceleration):
        a, y = np.asarray(a, dtype=float), np.asarray(y, dtype=float)
        if a.size < 16 or not (np.all(np.isfinite(a)) and np.all(np.isfinite(y))):
            continue
        m = free_accelerations(np.ascontiguousarray(a), p)
        m -= m.mean()
        x = a - a.mean()
        r = y - y.mean()
        r -= m  # the measured acceleration's departure from the rig file's model
        events, n = events + 1, n + a.size
        # products summed pairwise (np.dot of short vectors costs ten times more in OpenBLAS's threads)
        ss_model += float(np.sum(r * r))
        sum_m += float(np.sum(m))
        sum_mm += float(np.sum(m * m))
        sum_xm += float(np.sum(x * m))
        sum_xx += float(np.sum(x * x))
        factor = np.linalg.qr(np.vstack([factor, np.column_stack([m, x, r])]), mode="r")
    if events < 2 or not (math.isfinite(noise) and noise > 0.0):
        return None
    # the refit y = s m + c x: s - 1 and c are the least-squares coefficients of y - m on [m, x]
    coef = np.linalg.lstsq(factor[:2, :2], factor[:2, 2], rcond=None)[0] + np.array([1.0, 0.0])
    ss_refit = float(factor[2, 2] ** 2)
    swing = math.sqrt(max(sum_mm / n - (sum_m / n) ** 2, 0.0))
    slope = sum_xm / sum_xx if sum_xx > 0.0 else math.nan
    removed = max(ss_model - ss_refit, 0.0)
    chi_square = removed / noise ** 2
    p_value = chi2_sf(chi_square, 2)
    refit_rms = math.sqrt(ss_refit / n)
    misfit = math.sqrt(removed / n) / swing if swing > 0.0 else math.nan
    clean = refit_rms <= max(FREE_FLIGHT_CLEAN * noise, FREE_FLIGHT_CLEAN_SWING * swing)
    disagrees = bool(clean and misfit > FREE_FLIGHT_MISFIT and p_value < FREE_FLIGHT_SIGNIFICANCE)
    return FreeFlightFit(events=events, samples=int(n), noise=float(noise), swing=swing,
                         model_rms=math.sqrt(ss_model / n), refit_rms=refit_rms, scale=float(coef[0]),
                         linear=float(coef[1] / slope) if slope and math.isfinite(slope) else math.nan,
                         misfit=float(misfit), chi_square=float(chi_square), p_value=p_value, clean=bool(clean),
                         disagrees=disagrees)

"""Identification on recordings of the finger-follower valve train (Kim, Jeon & Park 1990, and more).

* :func:`synchronous_average` averages a recording over camshaft revolutions with its encoder
  (angle-domain or time-domain sampling), as the paper's rig did.
* :func:`fit_tappet_drag` is the paper's identification: the tappet drag of (K-6) from the
  measured plunger motion ``Y_t(theta)``, by least squares of the simulated periodic steady state
  against the averaged cycle. The free parameters are the better-conditioned products
  ``c_t = alpha C_d+`` [N s/m] and ``k_t = beta K_e`` [N/m] (searched in logarithms); ``alpha``
  and ``beta`` are reported as well, with the same relative intervals, and mean something only
  with the rig's ``C_d+`` and ``K_e``. The zero offset of the gap sensor is a nuisance parameter
  eliminated in closed form (variable projection). One fit per speed, or one pair for several
  speeds (``joint=True``).
* :func:`fit_damping` fits the contact damping ratio and the valve spring's damping ratio to the
  valve's motion around closure (displacement, and velocity when recorded).
* :func:`fit_cam_lift` is the analogue of rig F's cam-profile fit: the lift law (a cycloidal rise
  and return of unknown height and angles) and the encoder's phase against the nose, from the
  valve displacement at a low speed, where the train is nearly quasi-static.

Refusals
--------
Every fit refuses, with an :class:`IdentificationError` naming the file and the channel or
attribute, a recording whose cam speed (operating point, else encoder) lies outside the model's
:func:`~impactid.rigs.finger_follower.simulate.speed_range`, absurd operating attributes
(``samples_per_revolution``, ``encoder_ppr``, ``nose_angle_rad``), a channel that is non-finite,
constant or zero or shorter than a revolution, and, after the fit, a channel the fitted model
explains no better than noise alone (:func:`impactid.rigs.valvespring.check_model_explains`).

Search, intervals, model check
------------------------------
Every fit runs on the identification engine (:mod:`impactid.engine`): the search
(:func:`~impactid.engine.search`, trust-region reflective, central differences, in logarithms of the
positive parameters), linearised (Gauss-Newton) intervals at the optimum
(:func:`~impactid.engine.uncertainty`: covariance ``s^2 (J^T J)^-1`` by the shared rule of
:func:`impactid.engine.covariance.covariance_from_jacobian`, with the residual variance
``s^2 = SSR / (n - p)`` where ``p`` counts the eliminated offsets, Student-t quantiles for the chosen
confidence, mapped back from the logarithms), and the model check
(:func:`~impactid.engine.residual_against_noise`): the residual against the recording's own noise,
the scatter of the synchronous average over the revolutions (the pooled standard error of the bins;
a recording of one revolution has none, and is not checked). The averaged samples are independent
when the sensor noise is white, which is the assumption these intervals rest on; they say nothing
about model error (a wrong cam or wrong masses), which the model check reports instead. When the
two tappet parameters are correlated beyond ``|rho| > 0.995`` or one is determined to worse than
50 %, the result says they are not separable.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any, ClassVar

import numpy as np
import pandas as pd
from scipy import stats

from impactid.engine import (
    Free,
    ModelCheck,
    Search,
    Uncertainty,
    check_model,
    combine_checks,
    governing_check,
    identifiability,
    residual_against_noise,
    search,
    uncertainty,
)
from impactid.errors import ImpactidError, SimulationError
from impactid.results import FitResult, Parameter
from impactid.rigs.finger_follower.cam import CycloidalLift
from impactid.rigs.finger_follower.simulate import DEFAULT_TOLERANCES, prepare, speed_range, steady_state
from impactid.rigs.valvespring import check_fit_channel, check_model_explains

__all__ = ["AveragedCycle", "DampingFit", "IdentificationError", "LiftFit", "TappetFit", "TappetFitSet", "fit_cam_lift",
           "fit_damping", "fit_tappet_drag", "synchronous_average"]

TWO_PI = 2.0 * math.pi
DEG = math.pi / 180.0
#: Correlation beyond which two parameters are reported as not separable.
SEPARABILITY_CORRELATION = 0.995
#: Relative standard error beyond which a parameter is reported as not determined.
SEPARABILITY_RELATIVE_ERROR = 0.5
#: Steady-state tolerance inside the fits (units of 1 um and 1 mm/s, see ``steady_state``): 1 pm,
#: far below the finite-difference steps' effect (1e-4 relative, about 10 nm of leak-down).
FIT_STEADY_TOL = 1e-6
#: Points per revolution at which a model is evaluated for time-domain data (0.02 deg; the
#: periodic cubic spline through them interpolates the leak-down to about 1e-10 m).
MODEL_GRID_POINTS = 18_000
#: Step tolerance of the lift fit (relative, on log S_K, log beta and the phase in rad): 1e-9 of
#: the angles is 1e-7 deg, far inside the intervals noisy data give (1e-5 relative).
LIFT_XTOL = 1e-9
#: Largest operating ``nose_angle_rad`` [rad] in magnitude (a million revolutions): float64 still
#: resolves it to about 1e-9 rad; beyond it the value cannot locate the nose at all.
MAX_NOSE_ANGLE = 2.0 * math.pi * 1e6
#: Fewest bins per revolution of a synchronous average (10 deg).
MIN_BINS = 36
#: SI units of the channels the fits read (for messages).
_UNITS = {"tappet_displacement": "m", "valve_displacement": "m", "valve_velocity": "m/s", "contact_load": "N"}


class IdentificationError(ImpactidError, ValueError):
    """A recording that cannot be used for the identification asked (missing channel, no speed, ...)."""


# --------------------------------------------------------------------------------------------
# Synchronous averaging
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class AveragedCycle:
    """One camshaft revolution averaged over the revolutions of a recording.

    Attributes
    ----------
    theta : cam angles of the bins [rad], model convention (0 at the nose), sorted in [-pi, pi).
    mean, stderr : averaged channels and their standard errors by name [SI] (NaN stderr for a
        bin with one sample).
    counts : samples per bin.
    rpm : camshaft speed [rpm]; ``revolutions`` the number of revolutions averaged.
    sampling : ``"angle"`` or ``"time"``; ``source`` the recording's file.
    notes : what qualifies the average.
    """

    theta: np.ndarray
    mean: dict
    stderr: dict
    counts: np.ndarray
    rpm: float
    revolutions: float
    sampling: str
    source: str = ""
    notes: tuple = ()
    sample_theta: np.ndarray | None = None
    sample_bin: np.ndarray | None = None

    @property
    def theta_deg(self) -> np.ndarray:
        """Bin angles [deg]."""
        return self.theta / DEG

    @property
    def exact_bins(self) -> bool:
        """Whether every sample sits at its bin's angle (angle-domain sampling): a model is then
        compared at the bin angles; otherwise it is averaged over the samples as the data were."""
        return self.sample_theta is None

    def model_grid_deg(self) -> np.ndarray:
        """Cam angles [deg] at which to evaluate a model for :meth:`average_model`."""
        if self.exact_bins:
            return self.theta_deg
        return -180.0 + np.arange(MODEL_GRID_POINTS + 1) * (360.0 / MODEL_GRID_POINTS)

    def average_model(self, values: np.ndarray) -> np.ndarray:
        """A model's values at :meth:`model_grid_deg`, averaged into the bins as the data were
        (time-domain sampling: interpolated at every sample's angle with a periodic cubic spline,
        then bin-averaged, so the binning's own smoothing is applied to both)."""
        if self.exact_bins:
            return np.asarray(values, dtype=float)
        from scipy.interpolate import CubicSpline

        grid = np.radians(self.model_grid_deg())
        v = np.asarray(values, dtype=float).copy()
        v[-1] = v[0]
        spline = CubicSpline(grid, v, bc_type="periodic")
        at = spline(self.sample_theta)
        n = self.theta.size
        return np.bincount(self.sample_bin, weights=at, minlength=n) / self.counts

    def to_frame(self) -> pd.DataFrame:
        """Table ``cam_angle_deg, count`` and, per channel, its mean and standard error."""
        data: dict[str, Any] = {"cam_angle_deg": self.theta_deg, "count": self.counts}
        for name in self.mean:
            data[name] = self.mean[name]
            data[f"{name}_stderr"] = self.stderr[name]
        return pd.DataFrame(data)


def _model_angles(recording) -> tuple[np.ndarray, str, list[str]]:
    """Cam angle of every sample in the model convention (0 at the nose), unwrapped [rad]."""
    notes: list[str] = []
    where = recording.source or "recording"
    if "cam_angle" not in recording:
        raise IdentificationError(f"{where}: no 'cam_angle' channel (the encoder)")
    nose = float(recording.operating.get("nose_angle_rad", 0.0))
    if not abs(nose) <= MAX_NOSE_ANGLE:
        raise IdentificationError(f"{where}: operating nose_angle_rad = {nose!r} is not an angle of the encoder's "
                                  f"reading (at most {MAX_NOSE_ANGLE:.3g} rad, a million revolutions, in magnitude)")
    # the nose's angle modulo a revolution (exact), so that a large value costs the angles no precision
    nose = math.remainder(nose, TWO_PI)
    if "nose_angle_rad" not in recording.operating:
        notes.append("no operating nose_angle_rad: the encoder zero is taken as the cam nose")
    angle = np.unwrap(np.asarray(recording["cam_angle"], dtype=float))
    if angle.size < 2 or not angle[-1] > angle[0]:
        raise IdentificationError(f"{where}: the cam angle (channel 'cam_angle') does not increase (the encoder "
                                  "stands still or counts backwards; reverse its sign)")
    if "samples_per_revolution" in recording.operating:
        per_rev = recording.operating["samples_per_revolution"]
        if not (per_rev == round(per_rev) and MIN_BINS <= per_rev <= 1e8):
            raise IdentificationError(
                f"{where}: operating samples_per_revolution = {per_rev!r} must be a whole number of samples per "
                f"camshaft revolution, from {MIN_BINS} to 1e8")
        if per_rev > angle.size:
            raise IdentificationError(f"{where}: too short: {angle.size} samples, less than one camshaft revolution "
                                      f"(operating samples_per_revolution = {per_rev:g})")
        step = float(np.median(np.diff(angle)))
        if not math.isclose(step, TWO_PI / per_rev, rel_tol=0.01):
            raise IdentificationError(
                f"{where}: operating samples_per_revolution = {per_rev:g} disagrees with channel 'cam_angle', whose "
                f"step is {math.degrees(step):.6g} deg ({TWO_PI / step:.6g} samples per revolution)")
        return angle - nose, "angle", notes
    ppr = recording.operating.get("encoder_ppr")
    if ppr is not None and not (ppr == round(ppr) and ppr >= 1):
        raise IdentificationError(f"{where}: operating encoder_ppr = {ppr!r} must be a whole number of encoder "
                                  "steps per revolution (at least 1)")
    # time-domain sampling: the camshaft turns at a constant speed (the paper's DC drive), so a
    # straight line through the encoder readings removes their quantisation; a counter reads the
    # step below the true angle, so half a step is added back
    t = np.arange(angle.size) / recording.sample_rate_hz
    slope, intercept = np.polyfit(t, angle, 1)
    line = intercept + slope * t
    ppr = recording.operating.get("encoder_ppr")
    step = TWO_PI / ppr if ppr else 0.0
    spread = float(np.sqrt(np.mean((angle - line) ** 2)))
    if spread > max(3.0 * step, 0.5 * DEG):
        notes.append(f"the cam angle departs from a constant speed by {spread / DEG:.3g} deg RMS: the encoder "
                     "readings are used as they are")
        return angle + 0.5 * step - nose, "time", notes
    return line + 0.5 * step - nose, "time", notes


def synchronous_average(recording, *, channels: Sequence[str] = ("tappet_displacement", "valve_displacement"),
                        bins: int | None = None) -> AveragedCycle:
    """Average a recording over camshaft revolutions by cam angle.

    Parameters
    ----------
    recording : :class:`impactid.io.Recording` with ``cam_angle`` [rad] and the channels asked
        (those missing are skipped; at least one must be there); ``/operating`` gives
        ``cam_speed_hz`` (else the encoder's rate), ``nose_angle_rad`` (encoder angle of the nose)
        and, for angle-domain sampling, ``samples_per_revolution``.
    channels : channels to average.
    bins : bins per revolution (angle-domain default: the samples per revolution, one bin per
        encoder step; time-domain default: 720, half a degree).

    Angle-domain recordings are binned on their own encoder angles; time-domain recordings by the
    cam angle of a constant-speed line through the encoder readings, each bin at the mean angle of
    its samples.
    """
    where = recording.source or "recording"
    present = [c for c in channels if c in recording]
    if not present:
        raise IdentificationError(f"{where}: none of the channels {', '.join(channels)}")
    theta, sampling, notes = _model_angles(recording)
    speed = recording.operating.get("cam_speed_hz")
    if speed is None:
        speed = (theta[-1] - theta[0]) / TWO_PI * recording.sample_rate_hz / max(theta.size - 1, 1)
        notes.append("no operating cam_speed_hz: the speed is the encoder's mean rate")
    revolutions = (theta[-1] - theta[0]) / TWO_PI
    if revolutions < 0.999:
        raise IdentificationError(f"{where}: less than one camshaft revolution recorded ({revolutions:.3g})")
    if sampling == "angle":
        n = int(bins or round(recording.operating["samples_per_revolution"]))
        step = TWO_PI / n
        index = np.round((theta - theta[0]) / step).astype(np.int64) % n
    else:
        n = int(bins or 720)
        step = TWO_PI / n
        index = np.floor(((theta + math.pi) % TWO_PI) / step).astype(np.int64) % n
    if n < MIN_BINS:
        raise IdentificationError(f"{where}: {n} bins per revolution are too few (at least {MIN_BINS})")
    counts = np.bincount(index, minlength=n)
    keep = counts > 0
    wrapped = (theta + math.pi) % TWO_PI - math.pi
    # mean angle per bin (circular, relative to the bin's first sample, so a bin at +-pi stays whole)
    first = np.full(n, np.nan)
    first[index[::-1]] = wrapped[::-1]
    rel = (wrapped - first[index] + math.pi) % TWO_PI - math.pi
    angle = first + np.bincount(index, weights=rel, minlength=n) / np.maximum(counts, 1)
    angle = (angle + math.pi) % TWO_PI - math.pi
    mean, err = {}, {}
    for c in present:
        x = np.asarray(recording[c], dtype=float)
        s1 = np.bincount(index, weights=x, minlength=n)
        m = s1 / np.maximum(counts, 1)
        dev = x - m[index]
        var = np.bincount(index, weights=dev * dev, minlength=n) / np.maximum(counts - 1, 1)
        se = np.where(counts > 1, np.sqrt(var / np.maximum(counts, 1)), np.nan)
        mean[c], err[c] = m[keep], se[keep]
    angle, counts = angle[keep], counts[keep]
    order = np.argsort(angle)
    if (~keep).any():
        notes.append(f"{int((~keep).sum())} of {n} bins hold no sample")
    sample_theta = sample_bin = None
    if sampling == "time":
        # bin numbers after dropping the empty bins and sorting by angle
        renumber = np.full(n, -1, dtype=np.int64)
        renumber[np.flatnonzero(keep)[order]] = np.arange(order.size)
        sample_bin = renumber[index]
        sample_theta = wrapped
    return AveragedCycle(theta=angle[order], mean={c: v[order] for c, v in mean.items()},
                         stderr={c: v[order] for c, v in err.items()}, counts=counts[order], rpm=60.0 * float(speed),
                         revolutions=float(revolutions), sampling=sampling, source=recording.source, notes=tuple(notes),
                         sample_theta=sample_theta, sample_bin=sample_bin)


def _fit_cycle(recording, channels: Sequence[str], train, bins: int | None) -> AveragedCycle:
    """The synchronous average a fit reads, after the checks that the recording can inform it.

    Each channel must be able to inform a fit (:func:`~impactid.rigs.valvespring.check_fit_channel`:
    finite, at least one revolution, not constant or zero; whether it holds more than noise is
    tested after the fit, :func:`~impactid.rigs.valvespring.check_model_explains`), and the cam
    speed (the operating point's, else the encoder's) must lie in the model's
    :func:`~impactid.rigs.finger_follower.simulate.speed_range`. Raises :class:`IdentificationError`
    naming the file and the channel or attribute.
    """
    where = recording.source or "recording"
    theta, _, _ = _model_angles(recording)
    for channel in channels:
        check_fit_channel(recording[channel], theta, where=where, channel=channel, unit=_UNITS.get(channel, ""),
                          error=IdentificationError)
    cycle = synchronous_average(recording, channels=channels, bins=bins)
    hz = recording.operating.get("cam_speed_hz")
    what = (f"{where}: operating cam_speed_hz = {hz:.6g} Hz" if hz is not None
            else f"{where}: the cam speed of the encoder (channel 'cam_angle'; no operating cam_speed_hz)")
    speed_range(train).check(cycle.rpm, what, IdentificationError)
    return cycle


# --------------------------------------------------------------------------------------------
# Least squares with linearised intervals
# --------------------------------------------------------------------------------------------


#: Search settings of the profile refits: the fits' own step and tolerances, fewer evaluations (a
#: profile point needs the rise of the cost to a few percent, not the optimum to 1e-12).
_PROFILE_SEARCH = {"x_scale": 1.0, "diff_step": 1e-5, "xtol": 1e-8, "ftol": 1e-8, "gtol": 1e-8, "max_nfev": 40}


def _engine_fit(residual, free: Sequence[Free], n_linear: int, confidence: float, **options
                ) -> tuple[Search, Uncertainty, int]:
    """The engine's search and uncertainty, the residual variance counting the ``n_linear`` offsets
    eliminated in closed form (``s^2 = SSR / (n - p - n_linear)``). Returns the search, the
    uncertainty and the degrees of freedom."""
    found = search(residual, free, **options)
    dof = found.residual.size - len(found.varying) - n_linear
    if dof <= 0:
        raise IdentificationError(f"{found.residual.size} averaged samples cannot determine "
                                  f"{len(found.varying) + n_linear} parameters")
    return found, uncertainty(found, confidence=confidence, dof=dof), dof


def _derived_log_parameter(name: str, log_value: float, log_se: float, fit: Uncertainty, unit: str,
                           note: str = "") -> Parameter:
    """A parameter derived from the searched logarithms (``tau = c_t / k_t``): Student-t interval
    with the fit's degrees of freedom, mapped back from the logarithm."""
    value = math.exp(log_value)
    if not math.isfinite(log_se):
        return Parameter(name, value, confidence=fit.confidence, unit=unit, note=note or "undetermined", min=0.0)
    q = float(stats.t.ppf(0.5 + 0.5 * fit.confidence, fit.dof))
    return Parameter(name, value, value * log_se, (math.exp(log_value - q * log_se), math.exp(log_value + q * log_se)),
                     fit.confidence, unit=unit, note=note, min=0.0)


def _noise_check(residual: np.ndarray, stderr: np.ndarray, *, what: str, unit: str):
    """The residual against the recording's own noise: the pooled standard error of the synchronous
    average's bins (:func:`impactid.engine.residual_against_noise`). A cycle without repeated
    revolutions has no noise estimate: then the statistics are NaN and there is no note."""
    se = np.asarray(stderr, dtype=float)
    se = se[np.isfinite(se)]
    noise = float(np.sqrt(np.mean(se**2))) if se.size >= max(1, residual.size // 2) else math.nan
    if not noise > 0.0:
        rms = float(np.sqrt(np.mean(np.asarray(residual) ** 2)))
        return {"residual_rms": rms, "noise_sd": math.nan, "residual_over_noise": math.nan}, ()
    return residual_against_noise(residual, noise, what=what, unit=unit)


#: The noise reference of a synchronous average, in words (for the model check).
AVERAGE_NOISE = "the scatter of the synchronous average over the revolutions (pooled standard error of the bins)"


def _pooled_noise(residual: np.ndarray, stderr: np.ndarray) -> float | None:
    """The pooled standard error of the bins :func:`_noise_check` compares with (None without one)."""
    se = np.asarray(stderr, dtype=float)
    se = se[np.isfinite(se)]
    noise = float(np.sqrt(np.mean(se**2))) if se.size >= max(1, np.asarray(residual).size // 2) else math.nan
    return noise if noise > 0.0 else None


#: Without a noise reference (one revolution), structure in a residual below this fraction of the
#: channel's range is the model's own accuracy (the steady state's tolerance, the spline through the
#: model grid: 1e-10 m on a lift of millimetres), not evidence against it.
MODEL_ACCURACY = 1e-6


def _model_check(residual: np.ndarray, stderr: np.ndarray, *, what: str, unit: str, n_params: int,
                 assumed_sd: float, data_range: float, groups: np.ndarray | None = None) -> ModelCheck:
    """The engine's model check (:func:`impactid.engine.check_model`) of a fit to synchronous averages:
    the residual in cam-angle order (each recording a group) against the pooled standard error of
    the bins (the revolutions' scatter; none for one revolution: the residual variance itself, and
    structure counts only above :data:`MODEL_ACCURACY` of ``data_range`` [unit]), the persistence of
    the residual along the cycle (a smooth misfit, ``n_eff``), no per-event covariate (one averaged
    cycle per speed). ``assumed_sd``: the residual standard deviation the covariance assumed
    (``sqrt(SSR / dof)`` [unit])."""
    return check_model(residual, _pooled_noise(residual, stderr), noise_reference=AVERAGE_NOISE, what=what,
                       unit=unit, n_params=n_params, groups=groups, assumed_sd=assumed_sd,
                       structure_floor=MODEL_ACCURACY * data_range)


def _project(r: np.ndarray, groups: list[np.ndarray]) -> np.ndarray:
    """Remove the mean of each group (the offsets, eliminated in closed form)."""
    out = r.copy()
    for g in groups:
        out[g] -= out[g].mean()
    return out


# --------------------------------------------------------------------------------------------
# Tappet drag
# --------------------------------------------------------------------------------------------


class TappetFit(FitResult):
    """The tappet drag of (K-6) fitted to measured plunger motion.

    Parameters ``c_t`` [N s/m] and ``k_t`` [N/m] (fitted), ``alpha`` and ``beta`` (the same
    divided by the rig's ``C_d+`` and ``K_e``), ``tau`` [s] (``c_t / k_t``, the compression time
    constant) and the sensor offsets. Table ``cycles``: per recording and bin, the averaged and the
    fitted ``Y_t``.
    """

    kind: ClassVar[str] = "finger_follower_tappet"
    title: ClassVar[str] = "tappet drag fit (Kim, Jeon & Park 1990, K-6)"

    def plot(self, **kwargs):
        from impactid.rigs.finger_follower.figures import plot_tappet_fit

        return plot_tappet_fit(self, **kwargs)


def _tappet_residual_factory(train, cycles, tolerances):
    starts: dict[int, Any] = {}

    def model(x, k, cycle):
        c_t, k_t = math.exp(x[0]), math.exp(x[1])
        rig = train.rig
        st = steady_state(train, cycle.rpm, alpha=c_t / rig.C_d_plus, beta=k_t / rig.K_e, tol=FIT_STEADY_TOL,
                          start=starts.get(k), grid_deg=cycle.model_grid_deg(), tolerances=tolerances,
                          max_revolutions=200)
        starts[k] = st.start
        if not st.converged:
            raise SimulationError(f"no periodic steady state at {cycle.rpm:.6g} rpm with c_t = {c_t:.4g} N s/m, "
                                  f"k_t = {k_t:.4g} N/m")
        return cycle.average_model(st.revolution.channel("Y_t"))

    return model


def fit_tappet_drag(recordings, rig=None, *, lift=None, joint: bool = False, start: tuple[float, float] | None = None,
                    confidence: float = 0.95, bins: int | None = None, tolerances=DEFAULT_TOLERANCES,
                    clip_tension: bool = False, moment_cos: bool = False):
    """Fit the tappet drag to the measured plunger motion (the paper's identification).

    Parameters
    ----------
    recordings : one recording or a sequence (``tappet_displacement`` [m] and ``cam_angle`` [rad],
        any speeds).
    rig : the rig (default: the first recording's).
    lift : the cam lift law (default the rig's cycloidal law).
    joint : one ``(c_t, k_t)`` for all recordings (default: one per recording, as the paper did;
        the tappet "stiffens" with speed, so joint fits of several speeds mix two states).
    start : ``(c_t, k_t)`` to start from [N s/m, N/m]; default ``(0.5 % C_d+, 50 % K_e)``, a
        neutral point that knows nothing of the truth.
    confidence : coverage of the intervals.
    bins : bins of the synchronous average (see :func:`synchronous_average`).

    Returns
    -------
    :class:`TappetFit` (one recording or ``joint``), else a list of them, one per recording.
    """
    from impactid.io import Recording

    if isinstance(recordings, Recording):
        recordings = [recordings]
    recordings = list(recordings)
    if not recordings:
        raise IdentificationError("no recording given")
    if not joint and len(recordings) > 1:
        return [fit_tappet_drag(r, rig, lift=lift, start=start, confidence=confidence, bins=bins,
                                tolerances=tolerances, clip_tension=clip_tension, moment_cos=moment_cos)
                for r in recordings]
    rig = rig if rig is not None else recordings[0].require_rig("finger-follower-hla")
    train = prepare(rig, lift, clip_tension=clip_tension, moment_cos=moment_cos)
    cycles = []
    for rec in recordings:
        if "tappet_displacement" not in rec:
            raise IdentificationError(f"{rec.source or 'recording'}: no 'tappet_displacement' channel")
        cycles.append(_fit_cycle(rec, ("tappet_displacement",), train, bins))
    model = _tappet_residual_factory(train, cycles, tolerances)
    data = np.concatenate([c.mean["tappet_displacement"] for c in cycles])
    sizes = np.cumsum([0] + [c.theta.size for c in cycles])
    groups = [np.arange(sizes[i], sizes[i + 1]) for i in range(len(cycles))]
    scale = max(float(np.ptp(data)), 1e-9)
    n_eval = [0]

    failed = [0]

    def residual(x):
        n_eval[0] += 1
        try:
            sim = np.concatenate([model(x, k, c) for k, c in enumerate(cycles)])
        except SimulationError:
            # a trial tappet the integrator cannot follow (chatter, no steady state): a penalty the
            # optimiser's step control backs away from, counted and reported
            failed[0] += 1
            return np.full(data.size, 10.0)
        return _project(data - sim, groups) / scale

    c0, k0 = start if start is not None else (0.005 * rig.C_d_plus, 0.5 * rig.K_e)
    if not (c0 > 0.0 and k0 > 0.0):
        raise IdentificationError(f"start values must be positive, got c_t = {c0!r}, k_t = {k0!r}")
    free = (Free("c_t", c0, 0.0, math.inf, unit="N s/m", log=True),
            Free("k_t", k0, 0.0, math.inf, unit="N/m", log=True))
    found, fit, dof = _engine_fit(residual, free, len(cycles), confidence, x_scale=1.0, diff_step=1e-5, xtol=1e-12,
                                  ftol=1e-12, gtol=1e-12, max_nfev=200)
    x = found.x
    r = found.residual * scale
    sources = ", ".join(dict.fromkeys(c.source or "recording" for c in cycles))
    check_model_explains(float(np.sum(_project(data, groups) ** 2)), float(r @ r), r.size, 2,
                         null_params=len(groups), where=sources, channel="tappet_displacement",
                         error=IdentificationError)
    cov, se = fit.covariance.matrix, fit.covariance.stderr  # of ln c_t and ln k_t
    rho = float(fit.correlation[0, 1])
    notes = [n for c in cycles for n in c.notes] + list(fit.notes)
    separable = True
    if not math.isfinite(rho) or abs(rho) > SEPARABILITY_CORRELATION:
        separable = False
        notes.append(f"c_t and k_t are not separable from these data (correlation {rho:.4f}); fit several "
                     "speeds or fix one of them")
    for name, err in (("c_t", se[0]), ("k_t", se[1])):
        if not err <= SEPARABILITY_RELATIVE_ERROR:
            separable = False
            notes.append(f"{name} is not determined by these data (relative standard error {100 * err:.3g} %): "
                         "c_t and k_t are not separable here; average more revolutions, fit several speeds or "
                         "fix one of them")
    if not found.success:
        notes.append(f"the optimiser stopped without converging: {found.message}")
    if failed[0]:
        notes.append(f"{failed[0]} trial parameter set(s) could not be simulated and were penalised")
    # the model check: the residual against the scatter of the averages over the revolutions
    bin_stderr = np.concatenate([c.stderr["tappet_displacement"] for c in cycles])
    check, _ = _noise_check(r, bin_stderr, what="tappet_displacement", unit="m")
    checked = _model_check(r, bin_stderr, what="tappet_displacement", unit="m", n_params=2 + len(cycles),
                         assumed_sd=math.sqrt(fit.scale) * scale, data_range=float(np.ptp(data)),
                         groups=np.concatenate([np.full(g.size, k) for k, g in enumerate(groups)]))
    notes.extend(checked.notes)
    if checked.describes_data is False:
        separable = False
        notes.append("the model does not describe the recording: c_t and k_t are not reported as separable "
                     "(check the rig's constants: preloads, masses, the lift)")
    bound_note = "" if separable else "not separable"
    c_t, k_t = (replace(p, note=bound_note or p.note) for p in fit.parameters)
    alpha = Parameter("alpha", c_t.value / rig.C_d_plus, c_t.stderr / rig.C_d_plus,
                      tuple(v / rig.C_d_plus for v in c_t.interval), confidence, unit="", note=bound_note,
                      min=0.0)
    beta = Parameter("beta", k_t.value / rig.K_e, k_t.stderr / rig.K_e, tuple(v / rig.K_e for v in k_t.interval),
                     confidence, unit="", note=bound_note, min=0.0)
    tau_log_se = math.sqrt(max(cov[0, 0] + cov[1, 1] - 2 * cov[0, 1], 0.0)) if np.all(np.isfinite(cov)) else math.nan
    tau = _derived_log_parameter("tau", x[0] - x[1], tau_log_se, fit, "s")
    params = list(checked.widen([c_t, k_t, alpha, beta, tau]))
    rows = []
    sims = []
    for k, (cycle, g) in enumerate(zip(cycles, groups)):
        sim = model(x, k, cycle)
        offset = float(np.mean(data[g] - sim))
        sims.append(sim + offset)
        name = "offset" if len(cycles) == 1 else f"offset_{k}"
        params.append(Parameter(name, offset, fixed=False, unit="m",
                                note="gap-sensor zero, eliminated in closed form (no interval)"))
        for th, y, s in zip(cycle.theta_deg, data[g], sim + offset):
            rows.append({"recording": k, "rpm": cycle.rpm, "cam_angle_deg": th, "measured_m": y, "fitted_m": s})
    rms = float(np.sqrt(np.mean(r * r)))
    statistics = {"n_data": int(r.size), "dof": int(dof), "residual_rms_m": rms, "correlation_c_t_k_t": float(rho),
                  "separable": separable, "evaluations": int(n_eval[0]), "failed_evaluations": int(failed[0]),
                  "cost": float(0.5 * r @ r), "noise_sd_m": check["noise_sd"],
                  "residual_over_noise": check["residual_over_noise"],
                  "condition_number": fit.statistics["condition_number"], "success": found.success,
                  "speeds_rpm": ", ".join(f"{c.rpm:.6g}" for c in cycles)}
    details = {"cycles": [{"rpm": c.rpm, "revolutions": c.revolutions, "sampling": c.sampling, "source": c.source,
                           "bins": int(c.theta.size)} for c in cycles],
               "C_d_plus": rig.C_d_plus, "K_e": rig.K_e, "start": [c0, k0], "confidence": confidence,
               "joint": bool(joint)}
    # the profiles of c_t and k_t by refit (each point a one-parameter search of the steady state)
    described = identifiability(found, fit, residual=residual, search_options=_PROFILE_SEARCH,
                                describes_data=checked.describes_data)
    return TappetFit(params=params, statistics=statistics, notes=tuple(dict.fromkeys(notes)),
                     tables={"cycles": pd.DataFrame(rows)}, details=details,
                     provenance=tuple(f"fit_tappet_drag({c.source or 'recording'}, {c.rpm:.6g} rpm)" for c in cycles),
                     model_check=combine_checks([checked]), identifiability=described)


# --------------------------------------------------------------------------------------------
# Cam lift from low-speed valve motion
# --------------------------------------------------------------------------------------------


class LiftFit(FitResult):
    """A cycloidal cam lift fitted to the valve displacement at a low speed.

    Parameters ``S_K`` [m], ``beta_open``, ``beta_close`` [rad], ``phase`` [rad] (the nose's
    position against the recording's ``nose_angle_rad``: the true nose is at model angle
    ``phase``) and the valve sensor ``offset`` [m]. Table ``cycle``: averaged and fitted ``Y_v``.
    """

    kind: ClassVar[str] = "finger_follower_lift"
    title: ClassVar[str] = "cam lift fit (cycloidal law, low-speed valve motion)"

    @property
    def lift(self) -> CycloidalLift:
        """The fitted lift law."""
        return CycloidalLift(self.value("S_K"), self.value("beta_open"), self.value("beta_close"))

    def plot(self, **kwargs):
        from impactid.rigs.finger_follower.figures import plot_lift_fit

        return plot_lift_fit(self, **kwargs)


def _narrowest_convex_rise(S_K: float, R_c: float) -> float:
    """Smallest rise angle [rad] of a cycloidal lift of height ``S_K`` that keeps the cam convex."""
    from impactid.errors import RigParameterError
    from impactid.rigs.finger_follower.cam import check_convex

    def convex(b):
        try:
            check_convex(CycloidalLift(S_K, b, b), R_c, samples=4000)
            return True
        except RigParameterError:
            return False

    lo, hi = 0.05, 0.45 * TWO_PI
    if not convex(hi):
        return hi
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if convex(mid) else (mid, hi)
    return hi


def fit_cam_lift(recording, rig=None, *, start: CycloidalLift | None = None, confidence: float = 0.95,
                 bins: int | None = None, tolerances=DEFAULT_TOLERANCES, max_rpm: float = 1200.0) -> LiftFit:
    """Fit a cycloidal lift (height, rise and return angles) and the nose phase to the valve lift.

    The valve displacement is simulated with the full model in its steady state (the tappet with
    the rig's drag at the recording's speed), so the train's compliance is accounted for; at low
    speed the result depends little on the dynamic parameters. Only recordings up to ``max_rpm``
    are accepted (beyond it the spring surge and the tappet dynamics would be fitted as cam shape).

    ``start`` defaults to a cycloidal law read off the data: the valve's largest lift over the
    rig's base-circle rocker ratio, and the rise and return angles from the width of the open
    interval; nothing of the truth.
    """
    rig = rig if rig is not None else recording.require_rig("finger-follower-hla")
    where = recording.source or "recording"
    if "valve_displacement" not in recording:
        raise IdentificationError(f"{where}: no 'valve_displacement' channel")
    cycle = _fit_cycle(recording, ("valve_displacement",), prepare(rig), bins)
    if cycle.rpm > max_rpm:
        raise IdentificationError(f"{where}: the lift is fitted at low speed (at most {max_rpm:g} rpm); this "
                                  f"recording is at {cycle.rpm:.6g} rpm")
    y = cycle.mean["valve_displacement"]
    lift_m = float(np.max(y) - np.median(y))
    if start is None:
        base = np.median(y)
        open_ = cycle.theta[y - base > 0.5 * lift_m]
        half = 0.5 * float(np.ptp(open_)) if open_.size else 0.5 * math.pi / 2
        centre = float(np.mean(open_)) if open_.size else 0.0
        # a cycloidal rise reaches half its height half-way through the rise: the half-lift
        # half-width is about half the rise angle
        # half-way through the rise; the finger follower's kinematics narrow it further, so start
        # wider, and at least 15 % above the narrowest rise that keeps the cam convex
        S_K0 = lift_m / rig.RR0
        b0 = min(max(2.2 * half, 1.15 * _narrowest_convex_rise(S_K0, rig.R_c)), 0.45 * TWO_PI)
        start = CycloidalLift(S_K0, b0, b0)
        phase0 = centre
    else:
        phase0 = 0.0
    scale = max(lift_m, 1e-6)
    theta_deg = cycle.theta_deg
    state = {"start": None, "n": 0}

    def simulate_lift(x):
        S_K, b_open, b_close, phase = math.exp(x[0]), math.exp(x[1]), math.exp(x[2]), x[3]
        train = prepare(rig, CycloidalLift(S_K, b_open, b_close))
        # the model at data angle theta is the lift law's at theta - phase
        shifted = (cycle.model_grid_deg() - math.degrees(phase) + 180.0) % 360.0 - 180.0
        order = np.argsort(shifted, kind="stable")
        st = steady_state(train, cycle.rpm, tol=FIT_STEADY_TOL, start=state["start"], grid_deg=shifted[order],
                          tolerances=tolerances)
        state["start"] = st.start
        values = np.empty(shifted.size)
        values[order] = st.revolution.channel("Y_v")
        return cycle.average_model(values)

    def residual(x):
        state["n"] += 1
        try:
            sim = simulate_lift(x)
        except ImpactidError:
            return np.full(y.size, 10.0)  # a trial cam the train cannot follow (not convex, no contact)
        return _project(y - sim, [np.arange(y.size)]) / scale

    free = (Free("S_K", start.S_K, 0.0, math.inf, unit="m", log=True),
            Free("beta_open", start.beta_open, 0.0, math.inf, unit="rad", log=True),
            Free("beta_close", start.beta_close, 0.0, math.inf, unit="rad", log=True),
            Free("phase", phase0, unit="rad"))
    found, fit, dof = _engine_fit(residual, free, 1, confidence, diff_step=1e-6, xtol=LIFT_XTOL, ftol=1e-10,
                                  gtol=1e-10, max_nfev=300)
    x = found.x
    r = found.residual * scale
    check_model_explains(float(np.sum((y - y.mean()) ** 2)), float(r @ r), r.size, 4, where=where,
                         channel="valve_displacement", error=IdentificationError)
    params = list(fit.parameters)
    sim = simulate_lift(x)
    offset = float(np.mean(y - sim))
    params.append(Parameter("offset", offset, unit="m", note="valve-sensor zero, eliminated in closed form"))
    notes = list(cycle.notes) + list(fit.notes)
    if not found.success:
        notes.append(f"the optimiser stopped without converging: {found.message}")
    check, _ = _noise_check(r, cycle.stderr["valve_displacement"], what="valve_displacement", unit="m")
    checked = _model_check(r, cycle.stderr["valve_displacement"], what="valve_displacement", unit="m", n_params=5,
                         assumed_sd=math.sqrt(fit.scale) * scale, data_range=float(np.ptp(y)))
    notes.extend(checked.notes)
    params = list(checked.widen(params[:4])) + params[4:]
    corr = fit.correlation
    statistics = {"n_data": int(r.size), "dof": int(dof), "residual_rms_m": float(np.sqrt(np.mean(r * r))),
                  "rpm": cycle.rpm, "evaluations": int(state["n"]), "cost": float(0.5 * r @ r),
                  "noise_sd_m": check["noise_sd"], "residual_over_noise": check["residual_over_noise"],
                  "condition_number": fit.statistics["condition_number"], "success": found.success}
    table = pd.DataFrame({"cam_angle_deg": theta_deg, "measured_m": y, "fitted_m": sim + offset})
    described = identifiability(found, fit, quadratic_reason="a refit of the four lift parameters costs about 100 "
                                "steady states per point", describes_data=checked.describes_data)
    return LiftFit(params=params, statistics=statistics, notes=tuple(notes), tables={"cycle": table},
                   details={"correlation": corr.tolist(), "start": start.to_dict() | {"phase": phase0},
                            "confidence": confidence, "source": cycle.source},
                   provenance=(f"fit_cam_lift({where}, {cycle.rpm:.6g} rpm)",),
                   model_check=combine_checks([checked]), identifiability=described)


# --------------------------------------------------------------------------------------------
# Contact and spring damping from the ringing after valve closure
# --------------------------------------------------------------------------------------------

#: The contact damping ratio behind the rig's tabulated contact dampers (Kim et al.'s rule, K-1).
TABLE_CONTACT_ZETA = 0.06


class DampingFit(FitResult):
    """Contact and valve-spring damping ratios fitted to the valve motion around closure.

    Parameters ``zeta_contact`` (the three contact dampers scaled together from the rig's values,
    which correspond to 0.06 by Kim et al.'s rule) and ``zeta_spring`` (first surge mode). Table
    ``cycle``: the averaged and fitted channels in the window.
    """

    kind: ClassVar[str] = "finger_follower_damping"
    title: ClassVar[str] = "contact and spring damping from the ringing after valve closure"

    def plot(self, **kwargs):
        from impactid.rigs.finger_follower.figures import plot_damping_fit

        return plot_damping_fit(self, **kwargs)


def _closing_angle(theta: np.ndarray, lift: np.ndarray) -> float:
    """Cam angle [rad] where the averaged valve lift last falls through a tenth of its maximum."""
    base = float(np.median(lift))
    level = base + 0.1 * (float(np.max(lift)) - base)
    above = np.flatnonzero(lift > level)
    return float(theta[above[-1]]) if above.size else math.nan


def fit_damping(recording, rig=None, *, lift=None, window_deg: tuple[float, float] = (-20.0, 60.0),
                confidence: float = 0.95, bins: int | None = None, tolerances=DEFAULT_TOLERANCES) -> DampingFit:
    """Fit the contact damping ratio and the valve-spring damping ratio to the valve's ringing.

    Parameters
    ----------
    recording : a recording at a speed where the valve closes hard enough to ring (``valve_displacement``
        and, if present, ``valve_velocity`` are used; each channel is weighted by the scatter of its
        synchronous average).
    rig, lift : the rig (default the recording's) and its cam lift.
    window_deg : cam-angle window [deg] relative to where the averaged valve lift last falls through a
        tenth of its maximum (the end of the closing flank, found in the data).
    confidence : coverage of the intervals.

    The tappet drag is the rig's at the recording's speed (fit it first with :func:`fit_tappet_drag`
    and put it in the rig). When a ratio is determined to worse than 50 %, the result says the data
    do not carry it.
    """
    rig = rig if rig is not None else recording.require_rig("finger-follower-hla")
    where = recording.source or "recording"
    if "valve_displacement" not in recording:
        raise IdentificationError(f"{where}: no 'valve_displacement' channel")
    names = [c for c in ("valve_displacement", "valve_velocity") if c in recording]
    base_train = prepare(rig, lift)
    cycle = _fit_cycle(recording, names, base_train, bins)
    closing = _closing_angle(cycle.theta, cycle.mean["valve_displacement"])
    if not math.isfinite(closing):
        raise IdentificationError(f"{where}: the valve does not open in this recording")
    lo, hi = closing + math.radians(window_deg[0]), closing + math.radians(window_deg[1])
    mask = (cycle.theta >= lo) & (cycle.theta <= hi)
    if mask.sum() < 10:
        raise IdentificationError(f"{where}: fewer than 10 averaged samples in the closing window")
    weights = {}
    for c in names:
        se = cycle.stderr[c][mask]
        se = se[np.isfinite(se) & (se > 0)]
        weights[c] = 1.0 / float(np.median(se)) if se.size else 1.0 / max(float(np.ptp(cycle.mean[c])) * 1e-3, 1e-12)
    data = np.concatenate([cycle.mean[c][mask] * weights[c] for c in names])
    groups = [np.arange(k * int(mask.sum()), (k + 1) * int(mask.sum())) for k in range(len(names))]
    state = {"start": None, "n": 0, "failed": 0}
    channel_of = {"valve_displacement": "Y_v", "valve_velocity": "Y_v_dot"}

    def model(x):
        zc, zs = math.exp(x[0]), math.exp(x[1])
        scale = zc / TABLE_CONTACT_ZETA
        trial = rig.replace(C_tf=rig.C_tf * scale, C_fc=rig.C_fc * scale, C_vf=rig.C_vf * scale, zeta_spring=zs)
        st = steady_state(base_train.with_rig(trial), cycle.rpm, tol=FIT_STEADY_TOL, start=state["start"],
                          grid_deg=cycle.model_grid_deg(), tolerances=tolerances, max_revolutions=200)
        state["start"] = st.start
        if not st.converged:
            raise SimulationError(f"no periodic steady state with zeta_contact {zc:.4g}, zeta_spring {zs:.4g}")
        return np.concatenate([cycle.average_model(st.revolution.channel(channel_of[c]))[mask] * weights[c]
                               for c in names])

    def residual(x):
        state["n"] += 1
        try:
            return _project(data - model(x), [groups[0]])  # the displacement sensor's zero
        except SimulationError:
            state["failed"] += 1
            return np.full(data.size, 1e3)

    free = (Free("zeta_contact", 0.03, 0.0, math.inf, log=True), Free("zeta_spring", 0.08, 0.0, math.inf, log=True))
    found, fit, dof = _engine_fit(residual, free, 1, confidence, diff_step=1e-5, xtol=1e-10, ftol=1e-12, gtol=1e-12,
                                  max_nfev=100)
    x, r = found.x, found.residual
    check_model_explains(float(np.sum(_project(data, [groups[0]]) ** 2)), float(r @ r), r.size, 2,
                         where=where, channel=", ".join(names), error=IdentificationError)
    se = fit.covariance.stderr  # of the logarithms: relative errors
    notes = list(cycle.notes) + list(fit.notes)
    params = []
    for k, p in enumerate(fit.parameters):
        note = p.note
        if not se[k] <= SEPARABILITY_RELATIVE_ERROR:
            note = "not determined"
            notes.append(f"{p.name} is not determined by these data (relative standard error {100 * se[k]:.3g} %): "
                         "the ringing after closure does not carry it")
        params.append(replace(p, note=note))
    if state["failed"]:
        notes.append(f"{state['failed']} trial parameter set(s) could not be simulated and were penalised")
    if not found.success:
        notes.append(f"the optimiser stopped without converging: {found.message}")
    # the model check, per channel: the residual against the scatter of the averages over the revolutions
    checks, models = {}, []
    for k, c in enumerate(names):
        checks[c], _ = _noise_check(r[groups[k]] / weights[c], cycle.stderr[c][mask], what=c, unit=_UNITS[c])
        models.append(_model_check(r[groups[k]] / weights[c], cycle.stderr[c][mask], what=c, unit=_UNITS[c],
                                   n_params=3, assumed_sd=math.sqrt(fit.scale) / weights[c],
                                   data_range=float(np.ptp(cycle.mean[c][mask]))))
        notes.extend(models[-1].notes)
    params = list(governing_check(models).widen(params))
    rho = float(fit.correlation[0, 1])
    fitted = model(x)
    table = {"cam_angle_deg": cycle.theta_deg[mask]}
    for k, c in enumerate(names):
        g = groups[k]
        table[f"{c}_measured"] = data[g] / weights[c]
        offset = float(np.mean(data[g] - fitted[g])) if k == 0 else 0.0
        table[f"{c}_fitted"] = (fitted[g] + offset) / weights[c]
    statistics = {"n_data": int(data.size), "dof": int(dof), "rpm": cycle.rpm, "channels": ", ".join(names),
                  "closing_deg": math.degrees(closing), "correlation": float(rho), "evaluations": state["n"],
                  "failed_evaluations": state["failed"], "weighted_rms": float(np.sqrt(np.mean(r**2))),
                  "condition_number": fit.statistics["condition_number"], "success": found.success}
    for c in names:
        statistics[f"residual_over_noise_{c}"] = checks[c]["residual_over_noise"]
    described = identifiability(found, fit, residual=residual, search_options={**_PROFILE_SEARCH, "max_nfev": 25},
                                describes_data=all(m.describes_data is not False for m in models))
    return DampingFit(params=params, statistics=statistics, notes=tuple(notes), tables={"cycle": pd.DataFrame(table)},
                      details={"window_deg": list(window_deg), "confidence": confidence,
                               "weights": {c: w for c, w in weights.items()}},
                      provenance=(f"fit_damping({where}, {cycle.rpm:.6g} rpm)",),
                      model_check=combine_checks(models), identifiability=described)


class TappetFitSet(FitResult):
    """``impactid valvetrain fit-tappet`` with several recordings, one fit per recording (not ``--joint``).

    Parameters: each fit's, named ``fit<k>.<name>`` (``fit0.alpha``, ``fit0.beta``, ``fit1.alpha``, ...;
    ``k`` numbers the fits in the order of the recordings, failures left out). Statistics: ``fits`` and
    ``failed`` (numbers). Tables: ``fits`` (one row per fit: ``fit``, ``recordings``, ``rpm`` and its
    statistics). Details: ``fits`` (each fit's whole document: :attr:`fits` rebuilds the
    :class:`~impactid.rigs.finger_follower.identify.TappetFit` objects) and ``failed`` (``recording``,
    ``reason`` of each recording that could not be fitted). Notes: each fit's, prefixed with ``fit<k>``.
    """

    kind = "finger_follower_tappet_set"
    title = "tappet drag, one fit per recording"

    @classmethod
    def of(cls, fits, failed) -> TappetFitSet:
        """The set of ``fits`` (:class:`TappetFit`) and the recordings that ``failed`` (``recording``, ``reason``)."""
        params, rows, notes, provenance = [], [], [], []
        for k, fit in enumerate(fits):
            params += [replace(p, name=f"fit{k}.{p.name}") for p in fit.params.values()]
            recordings, rpm = _fit_recordings(fit)
            rows.append({"fit": f"fit{k}", "recordings": ";".join(recordings), "rpm": ";".join(f"{r:g}" for r in rpm),
                         **{key: value for key, value in fit.statistics.items()
                            if isinstance(value, (int, float, str, bool)) or value is None}})
            notes += [f"fit{k} ({', '.join(recordings)}): {note}" for note in fit.notes]
            provenance += list(fit.provenance)
        notes += [f"not fitted (the other recordings were): {f['reason']}" for f in failed]
        return cls(params=params, statistics={"fits": len(fits), "failed": len(failed)}, notes=notes,
                   tables={"fits": pd.DataFrame(rows)},
                   details={"fits": [fit.to_dict() for fit in fits], "failed": [dict(f) for f in failed]},
                   provenance=provenance + ["impactid valvetrain fit-tappet: one fit per recording"],
                   model_check=_set_model_check(fits),
                   identifiability={"determined": bool(fits) and all(f.identifiability.get("determined") for f in fits),
                                    "parts": {f"fit{k}": dict(f.identifiability) for k, f in enumerate(fits)}})

    @property
    def fits(self) -> tuple:
        """The per-recording fits (:class:`~impactid.rigs.finger_follower.identify.TappetFit`)."""
        return tuple(FitResult.from_dict(d) for d in self.details.get("fits", ()))


def _set_model_check(fits) -> dict:
    """The ``model_check`` block of a set of fits: the worst verdict, the strongest action, every check
    (each named ``fit<k>: <what>``)."""
    from impactid.engine.checks import VERDICTS

    blocks = [dict(f.model_check) for f in fits if f.model_check]
    if not blocks:
        return combine_checks([])
    worst = max(blocks, key=lambda b: VERDICTS.index(b.get("verdict", "not checked")))
    actions = {b.get("action", "none") for b in blocks}
    checks = [{**c, "what": f"fit{k}: {c.get('what')}"} for k, b in enumerate(blocks) for c in b.get("checks", ())]
    return {"verdict": worst["verdict"], "describes_data": worst.get("describes_data"),
            "action": "withheld" if "withheld" in actions else ("widened" if "widened" in actions else "none"),
            "inflation": max(float(b.get("inflation") or 1.0) for b in blocks), "checks": checks,
            "rule": blocks[0].get("rule", "")}


def _fit_recordings(fit) -> tuple[list[str], list[float]]:
    """The recordings and speeds [rpm] of a tappet fit."""
    cycles = fit.details.get("cycles", ())
    return [str(c["source"]) for c in cycles], [float(c["rpm"]) for c in cycles]

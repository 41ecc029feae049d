"""Cam profiles as sums of Gaussians of the cam angle (Alzate et al. 2007, eq. 1 / A-1), and their fit.

``theta_hat(theta_c) = sum_i a_i exp(-((theta_c - b_i) / c_i)^2)`` gives the follower angle in
permanent contact [rad] as a function of the cam angle [rad]. A cam profile is periodic in the cam
angle, so by default each Gaussian is *wrapped*: ``theta_c - b_i`` is first reduced to
``[-pi, pi)`` and the Gaussian is summed over the images ``+ 2 pi k``, ``|k| <= WRAP_IMAGES``.
A Gaussian centred near 0 or 2 pi then continues smoothly across the seam instead of being cut
there, and the profile can be evaluated on unwrapped cam angles of any revolution. With
``c_i <= C_MAX`` (pi) the first omitted image is at least ``(2 WRAP_IMAGES + 1) pi = 5 pi`` away and
contributes less than ``a_i exp(-25)``, i.e. below 1e-11 a_i, so the wrapped sum and its
derivatives are periodic to rounding. The seed's own Table 3 model is *not* wrapped (the paper
evaluates eq. 1 directly on one revolution); ``periodic=False`` reproduces it.

Derivatives with respect to the cam angle are analytic: with ``u = (theta_c - b) / c``,
``d/dtheta_c = -2 u / c * g`` and ``d2/dtheta_c2 = (4 u^2 - 2) / c^2 * g``, ``g = exp(-u^2)``.

Fitting a profile to encoder data (:func:`fit_cam_profile`)
------------------------------------------------------------
1. *Data selection* (:func:`select_cam_profile_data`): the recording (or an explicit time window of
   it) is cut into complete cam revolutions counted from its first sample
   (:func:`~impactid.rigs.flat.encoders.complete_revolutions`). A revolution is used when its cam
   speed is steady (sector speeds within ``speed_tolerance`` of each other and its mean speed
   within ``speed_tolerance`` of the median revolution), below the detachment speed of the
   recording's rig (when it has a flat-follower rig), and when its follower angle against the cam
   angle stays within ``departure_tolerance`` of the common curve (the per-bin median over the
   steady revolutions): a revolution in which the follower leaves the cam departs from that curve.
   Every revolution is reported with the reason it was rejected. A period-1 impacting recording
   repeats the same departure every revolution; without a rig to say it runs above detachment,
   the data alone cannot tell it from a cam profile.
2. *Encoder quantisation* (read with :mod:`impactid.rigs.flat.encoders`): the step of each angle
   channel is detected from the data (its values lie on a grid of its smallest non-zero change:
   :func:`~impactid.rigs.flat.encoders.encoder_step`). An incremental counter (``counter="floor"``)
   reports ``floor(angle / step) * step``: a reading is on average half a count *below* the
   angle, a bias of ``pi / ppr`` (0.31 mrad at 10 000 ppr) that no profile shape can absorb, and
   near the profile's extremes the reading stays on one count over a wide cam range (a plateau
   whose error is up to a whole count, not half). Both are avoided by fitting the *edges* of the
   follower encoder instead of its samples (:func:`~impactid.rigs.flat.encoders.encoder_edges`):
   when the reading changes, the follower angle has just crossed a count boundary whose value is
   known exactly; the crossing time is known to half a sample interval, and the cam angle at that
   time comes from a local line through the cam encoder's own edges
   (:func:`~impactid.rigs.flat.encoders.local_linear`, which averages their timing errors away).
   The fit error then comes from the follower edges' timing only (a uniform error of half a sample
   of cam motion times the profile slope: about 0.01 mrad RMS at 20 kHz and 110 rpm) instead of
   the quantisation (0.18 mrad RMS). When the follower channel is not quantised (noisy or exact),
   the samples are averaged per cam count (or per 1/4096 revolution), after adding the counter's
   half count to a quantised cam. Whether a counter floors or rounds cannot be told from the data
   (the difference is a constant follower offset plus half a cam count); ``counter="round"`` and
   ``"none"`` (no correction) exist for encoders that round and for comparison.
3. *Cam-angle convention*: the recording's cam angle has an arbitrary zero. The profile is fitted
   directly as a function of the recording's cam angle (read through the counter convention, i.e.
   the continuous angle whose floor is the reading), so the centres ``b_i`` are reported in that
   convention, reduced to ``[0, 2 pi)``; no offset parameter is needed because the model is
   periodic. :func:`compare_profiles` finds the offset (and direction) to another convention, e.g.
   the analytic contact angle (A-17) of the rig.
4. *Least squares* by variable projection on the identification engine (:mod:`impactid.engine`):
   for fixed centres and widths the amplitudes are linear, so the search (the engine's, trust-region
   reflective with native bounds, from the seeds of step 5, with the LSMR subproblem solver in the
   parameters' own coordinates: :func:`_search_lsmr`) varies only ``b_i`` and ``c_i`` while
   each trial's amplitudes are the (non-negative) linear least-squares solution, with Kaufman's
   analytic Jacobian. Eliminating the amplitudes removes the long, flat valleys of the full
   3N-parameter problem (broad Gaussians trade amplitude for width), which cost thousands of
   evaluations there. Chi-square, AIC and BIC are computed for all 3N coefficients, and the
   engine's uncertainty (standard errors, intervals, bound hits, correlations, the shared covariance
   rule) from the full analytic Jacobian at the optimum. Bounds: ``c_min <= c_i <= C_MAX``
   (``C_MIN`` = 0.05 rad by default; ``C_MAX`` keeps the wrapping exact) and ``a_i >= 0``
   (``nonnegative``: a positive follower angle as a sum of bumps, without large cancelling terms;
   ``nonnegative=False`` for signed amplitudes). Centres are free (the model is periodic in them).
   The residual is then checked against the recording's own noise (the edges' timing error times
   the profile's slope, or the follower channel's noise floor for means): a profile that misses
   the data by more than their noise is noted as a lack of fit. The engine's whole check
   (:func:`impactid.engine.check_model`: the residual in cam-angle order, its persistence along the
   cam, ``n_eff``) widens or withholds the coefficients' intervals by its rule where it finds the
   profile wanting; the identifiability block (:func:`impactid.engine.identifiability`, quadratic
   profiles) states the condition number and correlations, and with ``terms="auto"`` compares the
   orders (AIC, BIC, likelihood-ratio tests of each order against the next).
5. *Seeding*: candidates are ``N`` equally spaced centres at several phases with common widths of
   0.5 to 1.4 times the spacing (translation-invariant, so they work for any cam zero offset; seven
   such terms span the harmonics 0..3 of a profile), and in ``terms="auto"`` also the previous
   order's fit plus one term at the largest residual bump. Each gets its best amplitudes by the
   linear solve; the ``starts`` best are refined and the lowest chi-square wins.
6. *Order selection* (``terms="auto"``): orders 1..``max_terms`` are fitted and the one with the
   lowest AIC or BIC (lmfit's definitions) is chosen; the table is reported. The residuals are
   timing (or quantisation) errors, not independent Gaussian noise, so read the table, not only the
   choice.
"""

from __future__ import annotations

import json
import math
import os
import time
from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd
from scipy.optimize import minimize_scalar, nnls

from impactid.engine import (
    Free,
    Search,
    check_model,
    combine_checks,
    compare_models,
    identifiability,
    residual_against_noise,
    search,
    uncertainty,
)
from impactid.errors import ImpactidError
from impactid.io import Recording, read_recording
from impactid.results import FitResult
from impactid.rigs.flat.encoders import (
    COUNTERS,
    TWO_PI,
    CounterReading,
    complete_revolutions,
    encoder_edges,
    local_linear,
    pulses_per_revolution,
    read_counter,
)
from impactid.rigs.flat.figures import plot_cam_fit
from impactid.signal import noise_floor

__all__ = ["ALZATE2007_CAM", "CAM_EDGE_WINDOW", "CRITERIA", "C_MAX", "C_MIN", "DEFAULT_STARTS",
           "DEFAULT_TERMS", "DEPARTURE_BINS", "DEPARTURE_FLOOR", "FIT_BINS", "FIT_TOLERANCE",
           "MAX_NFEV_PER_PARAMETER", "MAX_TERMS", "NEGLIGIBLE_U", "SPEED_SECTORS", "SPEED_TOLERANCE",
           "WRAP_IMAGES", "CamProfileData", "CamProfileError", "CamProfileResult",
           "GaussianSumProfile", "ProfileComparison", "compare_profiles", "fit_cam_profile", "gaussian_sum",
           "load_profile_json", "select_cam_profile_data"]

#: Images ``b_i + 2 pi k``, ``|k| <= WRAP_IMAGES``, summed for a periodic profile.
WRAP_IMAGES = 2
#: Widest Gaussian a periodic profile may hold [rad] (keeps the wrapped sum exact, see module doc).
C_MAX = math.pi
#: Narrowest Gaussian a fit may use by default [rad] (about 3 degrees: finer features are not what
#: a cam profile is made of; fitted to samples instead of edges, such terms chase count plateaus).
C_MIN = 0.05
#: Default number of Gaussian terms (Alzate et al. (2007) uses seven).
DEFAULT_TERMS = 7
#: Highest order tried by ``terms="auto"``.
MAX_TERMS = 9
#: Nonlinear refinements started from the best seeds.
DEFAULT_STARTS = 3
#: Default tolerance on the relative cam-speed variation, within and between revolutions.
SPEED_TOLERANCE = 0.05
#: Smallest default tolerance on the departure of a revolution from the common curve [rad]: 1 mrad,
#: 1.6 follower counts at 10 000 ppr; bin means of clean revolutions agree to a few hundredths of it.
DEPARTURE_FLOOR = 1e-3
#: Cam-angle bins of the departure test (per revolution) and of the fit when the cam is not quantised.
DEPARTURE_BINS = 360
FIT_BINS = 4096
#: Cam-encoder edges on each side of a follower edge in the local line giving its cam angle.
CAM_EDGE_WINDOW = 16
#: Sectors per revolution over which the cam speed must be steady.
SPEED_SECTORS = 8
#: Relative tolerances of the trust-region refinement (cost, step and gradient): 1e-8 of the cost is
#: 5e-9 of the RMS residual, far below anything the data can tell apart.
FIT_TOLERANCE = 1e-8
#: Function evaluations allowed per free parameter and start.
MAX_NFEV_PER_PARAMETER = 100
#: Order-selection criteria.
CRITERIA = ("bic", "aic")

#: ``|u|`` beyond which ``exp(-u^2)`` (< 1e-16) is left out of the fit's basis.
NEGLIGIBLE_U = 6.1


class CamProfileError(ImpactidError, ValueError):
    """A recording cannot give a cam profile (missing channel, too short, no permanent-contact
    revolution, ...) or a fit was asked for with invalid settings. The message names the file."""


# --------------------------------------------------------------------------------------------
# The model
# --------------------------------------------------------------------------------------------


def _images(periodic: bool) -> np.ndarray:
    return TWO_PI * np.arange(-WRAP_IMAGES, WRAP_IMAGES + 1) if periodic else np.zeros(1)


def _offset(theta: np.ndarray, b: float, periodic: bool) -> np.ndarray:
    """``theta - b``, reduced to ``[-pi, pi)`` for a periodic profile."""
    d = theta - b
    return np.mod(d + math.pi, TWO_PI) - math.pi if periodic else d


def gaussian_sum(theta_c, a, b, c, derivatives: int = 0, periodic: bool = True):
    """Sum of Gaussians and optionally its first and second derivatives.

    Parameters
    ----------
    theta_c : cam angle(s) [rad] (any revolution when ``periodic``).
    a, b, c : amplitudes [rad], centres [rad] and widths [rad] (1-D, same length).
    derivatives : 0 returns the value; 1 or 2 return a tuple ``(value, d/dtheta_c[, d2/dtheta_c2])``.
    periodic : sum each Gaussian over its ``2 pi`` images (see module doc).

    Returns
    -------
    ndarray or tuple of ndarray with the shape of ``theta_c`` [rad, rad/rad, rad/rad^2].
    """
    theta = np.asarray(theta_c, dtype=float)
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    c = np.asarray(c, dtype=float)
    shifts = _images(periodic)
    flat = theta.reshape(-1)
    value = np.zeros_like(flat)
    first = np.zeros_like(flat) if derivatives >= 1 else None
    second = np.zeros_like(flat) if derivatives >= 2 else None
    # Loop over terms and images (at most 7 x 5): each pass is vectorised over all angles.
    for ai, bi, ci in zip(a, b, c, strict=True):
        d = _offset(flat, bi, periodic)
        for shift in shifts:
            u = (d - shift) / ci
            g = ai * np.exp(-u * u)
            value += g
            if first is not None:
                first += (-2.0 * u / ci) * g
            if second is not None:
                second += ((4.0 * u * u - 2.0) / (ci * ci)) * g
    shape = theta.shape
    if derivatives == 0:
        return value.reshape(shape)
    if derivatives == 1:
        return value.reshape(shape), first.reshape(shape)
    return value.reshape(shape), first.reshape(shape), second.reshape(shape)


def _basis(theta: np.ndarray, b, c, jacobian: bool = False):
    """Wrapped unit Gaussians ``E[:, i] = sum_k exp(-u^2)`` (shape ``(n, N)``) and, with
    ``jacobian``, ``E_b = sum 2 u / c exp(-u^2)`` and ``E_c = sum 2 u^2 / c exp(-u^2)``, so that the
    model ``E @ a`` has ``d/da_i = E[:, i]``, ``d/db_i = a_i E_b[:, i]``, ``d/dc_i = a_i E_c[:, i]``."""
    n, m = theta.size, len(b)
    E = np.zeros((n, m))
    Eb = np.zeros((n, m)) if jacobian else None
    Ec = np.zeros((n, m)) if jacobian else None
    images = _images(True)
    for i, (bi, ci) in enumerate(zip(b, c, strict=True)):
        d = _offset(theta, bi, True)
        # an image at least (2|k| - 1) pi away adds < exp(-NEGLIGIBLE_U^2) ~ 1e-16 when that is
        # more than NEGLIGIBLE_U widths: skip it (the narrow terms of a fit need one image only)
        for shift in images[np.abs(images) - math.pi <= NEGLIGIBLE_U * ci]:
            u = (d - shift) / ci
            g = np.exp(-u * u)
            E[:, i] += g
            if jacobian:
                Eb[:, i] += (2.0 * u / ci) * g
                Ec[:, i] += (2.0 * u * u / ci) * g
    return (E, Eb, Ec) if jacobian else E


@dataclass(frozen=True)
class GaussianSumProfile:
    """A cam profile ``theta_hat(theta_c)`` as a sum of Gaussians (eq. 1 of Alzate et al. (2007)).

    Attributes
    ----------
    a : amplitudes [rad]
    b : centres [rad], in the cam-angle convention the profile was fitted in
    c : widths [rad] (> 0)
    periodic : whether the Gaussians are wrapped over the revolution (see module doc)
    """

    a: tuple[float, ...]
    b: tuple[float, ...]
    c: tuple[float, ...]
    periodic: bool = True

    def __post_init__(self) -> None:
        for name in ("a", "b", "c"):
            values = tuple(float(v) for v in getattr(self, name))
            if not all(math.isfinite(v) for v in values):
                raise ValueError(f"Gaussian-sum profile: {name} has non-finite values {values}")
            object.__setattr__(self, name, values)
        if not len(self.a) == len(self.b) == len(self.c) or not self.a:
            raise ValueError("Gaussian-sum profile: a, b and c must be non-empty and of equal length, "
                             f"got {len(self.a)}, {len(self.b)}, {len(self.c)}")
        if min(self.c) <= 0.0:
            raise ValueError(f"Gaussian-sum profile: widths c must be positive, got {self.c}")

    @property
    def terms(self) -> int:
        """Number of Gaussian terms."""
        return len(self.a)

    def __call__(self, theta_c, derivatives: int = 0):
        """Follower angle [rad] at cam angle(s) ``theta_c`` [rad] (and derivatives, see
        :func:`gaussian_sum`)."""
        return gaussian_sum(theta_c, self.a, self.b, self.c, derivatives, self.periodic)

    def shifted(self, offset: float) -> GaussianSumProfile:
        """The same profile in a cam-angle convention whose zero lies ``offset`` [rad] further on:
        ``shifted(offset)(theta) == self(theta + offset)``."""
        return GaussianSumProfile(self.a, tuple(bi - offset for bi in self.b), self.c, self.periodic)

    def to_dict(self) -> dict:
        """Coefficients as lists (radians)."""
        return {"a": list(self.a), "b": list(self.b), "c": list(self.c), "periodic": self.periodic}

    def sample(self, samples: int = 3600) -> tuple[np.ndarray, np.ndarray]:
        """The profile on ``samples`` uniform cam angles ``2 pi k / samples`` over one revolution:
        ``(cam_angle, follower_angle)`` [rad]."""
        theta = TWO_PI * np.arange(int(samples)) / int(samples)
        return theta, self(theta)


def load_profile_json(path: str | os.PathLike[str]) -> GaussianSumProfile:
    """Read the profile of an ``impactid cam-fit`` result (``fit.json``): a
    :class:`CamProfileResult` in the fit-result schema (``kind`` ``"cam-profile"``, parameters
    ``a1..aN``, ``b1..bN``, ``c1..cN`` in radians, ``details.periodic``), or a plain object with
    coefficient lists ``a``, ``b``, ``c`` (radians) and optionally ``periodic`` (default True).

    Raises
    ------
    CamProfileError : the file is missing, is not JSON, or lacks valid coefficients (the message
        names the file and the key).
    """
    path = os.fspath(path)
    if os.path.exists(path) and not os.path.isfile(path):
        raise CamProfileError(f"{path}: not a regular file (a folder, named pipe or device)")
    try:
        with open(path, encoding="utf-8") as handle:
            data = json.load(handle)
    except FileNotFoundError:
        raise CamProfileError(f"{path}: cam-profile file not found") from None
    except (OSError, ValueError) as exc:
        raise CamProfileError(f"{path}: not a readable JSON cam-profile file ({exc})") from None
    if not isinstance(data, dict):
        raise CamProfileError(f"{path}: expected a JSON object (the output of impactid cam-fit --out)")
    if "params" in data or "kind" in data:
        if data.get("kind") != CamProfileResult.kind or not isinstance(data.get("params"), dict):
            raise CamProfileError(f"{path}: a fit result of kind {data.get('kind')!r}, not a cam profile "
                                  f"({CamProfileResult.kind!r}, the output of impactid cam-fit --out)")
        params = data["params"]
        coefficients = {}
        for kind in "abc":
            values, k = [], 1
            while f"{kind}{k}" in params:
                entry = params[f"{kind}{k}"]
                values.append(entry.get("value") if isinstance(entry, dict) else None)
                k += 1
            coefficients[kind] = values
        missing = [f"{k}1" for k in "abc" if not coefficients[k]]
        if missing:
            raise CamProfileError(f"{path}: no parameter(s) {', '.join(missing)} in params")
        details = data.get("details") if isinstance(data.get("details"), dict) else {}
        a, b, c, periodic = coefficients["a"], coefficients["b"], coefficients["c"], details.get("periodic", True)
    else:
        missing = [k for k in ("a", "b", "c") if not isinstance(data.get(k), list)]
        if missing:
            raise CamProfileError(f"{path}: no coefficient list(s) {', '.join(missing)} (expected the output of "
                                  "impactid cam-fit --out)")
        a, b, c, periodic = data["a"], data["b"], data["c"], data.get("periodic", True)
    try:
        return GaussianSumProfile(tuple(a), tuple(b), tuple(c), bool(periodic))
    except (TypeError, ValueError) as exc:
        raise CamProfileError(f"{path}: invalid cam-profile coefficients: {exc}") from None


#: The seed's Table 3 model (7 terms, three decimals as printed, evaluated un-wrapped as in eq. 1).
ALZATE2007_CAM = GaussianSumProfile(
    a=(0.307, 0.0, 0.304, 0.013, 0.0, 0.095, 0.036),
    b=(6.311, -0.19, -0.753, 5.208, 4.339, 1.932, 4.418),
    c=(2.777, 0.349, 2.613, 1.268, 0.067, 2.251, 1.743),
    periodic=False,
)


# --------------------------------------------------------------------------------------------
# Data selection
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class CamProfileData:
    """Permanent-contact data selected from a recording for a cam-profile fit.

    Attributes
    ----------
    cam_angle : cam angle of each used sample [rad], in the recording's convention (plus the
        counter's mean offset, half a count for a floor counter), reduced to ``[0, 2 pi)``;
        shape ``(nsamples,)``.
    follower_angle : follower angle of each used sample [rad] (plus the counter's mean offset).
    fit_cam_angle, fit_follower_angle : the points the profile is fitted to [rad], ascending cam
        angle, shape ``(npoints,)``: the follower-encoder edges when the follower channel is
        quantised (``fit_points == "follower edges"``), else the samples averaged per cam count
        (``"cam-count means"``) or per 1/``FIT_BINS`` revolution (``"cam-angle bin means"``).
    fit_weight : least-squares weight of each point (1 for edges; ``sqrt(samples / mean)`` for
        means, so that fitting the means equals fitting the samples up to a constant).
    fit_points : which points, see above.
    revolutions : one row per complete revolution: ``revolution``, ``t_start`` and ``t_end`` [s],
        ``speed_hz`` (mean cam speed) [Hz], ``speed_spread`` (relative spread of the sector speeds),
        ``speed_min_hz``, ``speed_max_hz`` [Hz], ``speed_deviation`` (relative to the median
        revolution), ``departure`` (largest distance of the revolution's binned follower angle from
        the common curve) [rad], ``departure_angle`` (cam angle where it occurs) [rad], ``used`` and
        ``reason`` (empty when used).
    cam_step, follower_step : detected encoder count steps [rad] (None: not quantised).
    counter : the counter convention assumed (a key of ``COUNTERS``).
    speed_tolerance : relative cam-speed tolerance used.
    departure_tolerance : departure tolerance used [rad].
    detachment_speed_hz : cam speed at or above which revolutions were rejected [Hz] (None: no check).
    source : file the recording came from.
    window : ``(t0, t1)`` [s] when the selection was limited to a time window.
    notes : what was done, one line per step.
    edge_timing_sd : for follower edges, the standard deviation of the cam angle assigned to an edge
        from its timing alone (uniform over one sample interval: ``omega dt / sqrt(12)``) [rad of cam
        angle]; None for means.
    fit_noise : for means, the standard deviation of each mean from the follower channel's own noise
        (:func:`impactid.signal.noise_floor` over the samples of the mean) [rad]; None for edges.
    """

    cam_angle: np.ndarray
    follower_angle: np.ndarray
    fit_cam_angle: np.ndarray
    fit_follower_angle: np.ndarray
    fit_weight: np.ndarray
    fit_points: str
    revolutions: pd.DataFrame
    cam_step: float | None
    follower_step: float | None
    counter: str
    speed_tolerance: float
    departure_tolerance: float
    detachment_speed_hz: float | None
    source: str = ""
    window: tuple[float, float] | None = None
    notes: tuple[str, ...] = ()
    edge_timing_sd: float | None = None
    fit_noise: np.ndarray | None = field(default=None, repr=False)

    @property
    def nsamples(self) -> int:
        """Number of samples used."""
        return int(self.cam_angle.size)

    @property
    def npoints(self) -> int:
        """Number of points fitted."""
        return int(self.fit_cam_angle.size)

    @property
    def used_revolutions(self) -> tuple[int, ...]:
        """Indices of the revolutions used (counted from the first sample of the window)."""
        return tuple(int(k) for k in self.revolutions.loc[self.revolutions["used"], "revolution"])

    @property
    def rejected_revolutions(self) -> dict[int, str]:
        """Rejected revolutions and why."""
        rows = self.revolutions[~self.revolutions["used"]]
        return {int(k): str(r) for k, r in zip(rows["revolution"], rows["reason"], strict=True)}


def _check_selection_settings(counter: str, speed_tolerance: float, departure_tolerance: float | None) -> None:
    """Raise :class:`CamProfileError` for an unknown counter or a tolerance that is not positive."""
    if counter not in COUNTERS:
        raise CamProfileError(f"unknown encoder counter {counter!r}; choose one of {', '.join(COUNTERS)}")
    if not (math.isfinite(speed_tolerance) and speed_tolerance > 0.0):
        raise CamProfileError(f"speed_tolerance must be positive, got {speed_tolerance!r}")
    if departure_tolerance is not None and not (math.isfinite(departure_tolerance) and departure_tolerance > 0.0):
        raise CamProfileError(f"departure_tolerance must be positive, got {departure_tolerance!r}")


@dataclass(frozen=True)
class _TimeWindow:
    """A recording limited to a time window: the samples, the window [s] (None: all) and a note."""

    recording: Recording
    window: tuple[float, float] | None
    note: str | None

    @property
    def span(self) -> str:
        """`` in the window [t0, t1) s`` for messages (empty without a window)."""
        return f" in the window [{self.window[0]:g}, {self.window[1]:g}) s" if self.window else ""


def _time_window(recording: Recording, window: tuple[float, float] | None, where: str) -> _TimeWindow:
    """The samples with ``t0 <= t < t1`` (all of them when ``window`` is None)."""
    if window is None:
        return _TimeWindow(recording, None, None)
    t0, t1 = (float(v) for v in window)
    if not (math.isfinite(t0) and math.isfinite(t1) and t1 > t0):
        raise CamProfileError(f"{where}: the time window must be two finite times t0 < t1, got {window!r}")
    sliced = recording.slice_time(t0, t1)
    return _TimeWindow(sliced, (t0, t1), f"time window [{t0:g}, {t1:g}) s: {sliced.n_samples} samples")


def _rig_detachment_speed(recording: Recording) -> float | None:
    """Detachment speed [Hz] of the recording's rig when it is a flat-follower rig, else None."""
    if getattr(recording.rig, "model", None) == "flat-follower":
        return float(recording.rig.detachment_speed_hz())
    return None


def _revolution_speeds(members, t, travel) -> pd.DataFrame:
    """One row per revolution: its times and cam speeds over ``SPEED_SECTORS`` sectors, and the
    deviation of its mean speed from the median revolution (columns of :class:`CamProfileData`)."""
    rows = []
    for k, idx in enumerate(members):
        row = dict(revolution=k, t_start=float(t[idx[0]]) if idx.size else math.nan,
                   t_end=float(t[idx[-1]]) if idx.size else math.nan, speed_hz=math.nan, speed_spread=math.inf,
                   speed_min_hz=math.nan, speed_max_hz=math.nan)
        if idx.size >= 2 * SPEED_SECTORS:
            tk, xk = t[idx], travel[idx]
            tc = tk - tk.mean()  # least-squares slope, closed form
            mean = float(np.sum(tc * (xk - xk.mean())) / np.sum(tc * tc)) / TWO_PI
            edges = np.linspace(0, idx.size - 1, SPEED_SECTORS + 1).round().astype(int)
            sector = (xk[edges[1:]] - xk[edges[:-1]]) / (tk[edges[1:]] - tk[edges[:-1]]) / TWO_PI
            row.update(speed_hz=mean, speed_min_hz=float(sector.min()), speed_max_hz=float(sector.max()),
                       speed_spread=float((sector.max() - sector.min()) / mean) if mean > 0.0 else math.inf)
        rows.append(row)
    table = pd.DataFrame(rows)
    table["speed_deviation"] = table["speed_hz"] / _median_speed(table) - 1.0
    return table


def _median_speed(table: pd.DataFrame) -> float:
    """Median of the revolutions' mean cam speeds [Hz] (NaN when none has one)."""
    finite = table["speed_hz"].notna()
    return float(np.median(table.loc[finite, "speed_hz"])) if finite.any() else math.nan


def _speed_rejections(table: pd.DataFrame, speed_tolerance: float, detachment_speed_hz: float | None) -> list[str]:
    """Why each revolution of a :func:`_revolution_speeds` table is not steady below detachment
    (empty string: it is)."""
    median_speed = _median_speed(table)
    reasons = []
    for row in table.itertuples():
        if not math.isfinite(row.speed_hz) or row.speed_hz <= 0.0:
            reasons.append("too few samples, or the cam does not turn steadily forward")
        elif row.speed_spread > speed_tolerance:
            reasons.append(f"cam speed varies by {row.speed_spread:.1%} within the revolution "
                           f"({row.speed_min_hz * 60:.4g} to {row.speed_max_hz * 60:.4g} rpm; tolerance "
                           f"{speed_tolerance:.1%})")
        elif abs(row.speed_deviation) > speed_tolerance:
            reasons.append(f"mean cam speed {row.speed_hz * 60:.4g} rpm differs by {row.speed_deviation:+.1%} from "
                           f"the median revolution ({median_speed * 60:.4g} rpm; tolerance {speed_tolerance:.1%})")
        elif detachment_speed_hz is not None and row.speed_max_hz >= detachment_speed_hz:
            reasons.append(f"cam speed {row.speed_max_hz * 60:.4g} rpm reaches the detachment speed "
                           f"{detachment_speed_hz * 60:.4g} rpm: contact cannot be permanent")
        else:
            reasons.append("")
    return reasons


@dataclass(frozen=True)
class _Departures:
    """How far each revolution's binned follower angle lies from the common curve.

    Attributes
    ----------
    distance : largest distance per revolution [rad] (NaN: no steady revolution, or no sample).
    angle : cam angle of the bin where it occurs [rad].
    tolerance : the departure tolerance [rad] (given, or the default of :func:`_departures`).
    bins : cam-angle bins per revolution.
    """

    distance: np.ndarray
    angle: np.ndarray
    tolerance: float
    bins: int

    def reason(self, k: int) -> str:
        """Why revolution ``k`` departs from the common curve (empty string: it does not)."""
        if self.distance[k] <= self.tolerance:
            return ""
        return (f"follower angle departs from the common curve of the steady revolutions by "
                f"{self.distance[k] * 1e3:.3g} mrad at cam angle {self.angle[k]:.3f} rad (tolerance "
                f"{self.tolerance * 1e3:.3g} mrad): the follower left the cam?")


def _departures(members, phase: np.ndarray, follower: np.ndarray, steady: np.ndarray, follower_step: float | None,
                tolerance: float | None) -> _Departures:
    """Distance of each revolution's follower angle (averaged in cam-angle bins, at most
    ``DEPARTURE_BINS``) from the per-bin median over the ``steady`` revolutions.

    The default tolerance is the largest of ``DEPARTURE_FLOOR``, 1.5 follower counts and 8 times
    the noise level of a bin mean (the follower channel's :func:`impactid.signal.noise_floor`).
    """
    n_rev = len(members)
    per_rev = max(int(np.median([m.size for m in members])), 1)
    nbins = int(min(DEPARTURE_BINS, max(8, per_rev // 8)))
    bin_of = np.minimum((phase * (nbins / TWO_PI)).astype(np.int64), nbins - 1)
    curves = np.full((n_rev, nbins), np.nan)
    for k, idx in enumerate(members):
        counts = np.bincount(bin_of[idx], minlength=nbins)
        sums = np.bincount(bin_of[idx], weights=follower[idx], minlength=nbins)
        curves[k] = np.where(counts > 0, sums / np.maximum(counts, 1), np.nan)
    if tolerance is None:
        sigma = noise_floor(follower, subtract_curvature=True, include_quantisation=False)
        tolerance = max(DEPARTURE_FLOOR, 1.5 * (follower_step or 0.0),
                        8.0 * sigma / math.sqrt(max(per_rev / nbins, 1.0)))
    distance = np.full(n_rev, np.nan)
    angle = np.full(n_rev, np.nan)
    if steady.any():
        common = np.nanmedian(curves[steady], axis=0)
        dist = np.abs(curves - common)
        valid = np.isfinite(dist)
        j = np.argmax(np.where(valid, dist, -1.0), axis=1)
        distance = np.where(valid.any(axis=1), dist[np.arange(n_rev), j], np.nan)
        angle = (j + 0.5) * (TWO_PI / nbins)
    return _Departures(distance=distance, angle=angle, tolerance=float(tolerance), bins=nbins)


def _no_usable_revolution(where: str, reasons: list[str], span: str) -> CamProfileError:
    """The error for a recording whose every revolution was rejected, with the reasons counted."""
    kinds: dict[str, int] = {}
    for r in reasons:
        key = r.split(" (")[0].split(":")[0].split(" by ")[0].split(" varies")[0]
        kinds[key] = kinds.get(key, 0) + 1
    summary = "; ".join(f"{n} x {k}" for k, n in kinds.items())
    return CamProfileError(
        f"{where}: no revolution usable for a cam-profile fit: {len(reasons)} complete revolution(s){span}, all "
        f"rejected ({summary}). The fit needs revolutions at steady cam speed in permanent contact")


@dataclass(frozen=True)
class _FitPoints:
    """The points a profile is fitted to: cam angle [rad] (ascending), follower angle [rad], weight,
    which points (``CamProfileData.fit_points``), a note on how they were made and, for means, the
    samples in each."""

    cam_angle: np.ndarray
    follower_angle: np.ndarray
    weight: np.ndarray
    kind: str
    note: str
    count: np.ndarray | None = None

    def ordered(self) -> _FitPoints:
        """The points by ascending cam angle."""
        order = np.argsort(self.cam_angle, kind="stable")
        return _FitPoints(self.cam_angle[order], self.follower_angle[order], self.weight[order], self.kind,
                          self.note, None if self.count is None else self.count[order])


def _follower_edge_points(cam: CounterReading, follower: CounterReading, raw_cam: np.ndarray,
                          raw_follower: np.ndarray, t: np.ndarray, in_use: np.ndarray) -> _FitPoints | None:
    """The follower encoder's edges inside the used samples, at the cam angle of their times (module
    doc, step 2); None when the follower is not quantised or too few edges are left."""
    if follower.step is None:
        return None
    tf, vf, kf = encoder_edges(raw_follower, t, follower.step, follower.counter)
    keep = in_use[kf] & in_use[kf - 1]
    if cam.step is not None:
        tc, vc, _ = encoder_edges(raw_cam, t, cam.step, cam.counter)
        if tc.size < 2 * CAM_EDGE_WINDOW + 1:
            return None
        keep &= (tf >= tc[0]) & (tf <= tc[-1])
        cam_at = local_linear(tf, tc, vc, CAM_EDGE_WINDOW)
        how = f"a line through the nearest {2 * CAM_EDGE_WINDOW + 1} cam-encoder edges"
    else:
        cam_at = np.interp(tf, t, raw_cam)
        how = "interpolated in the cam samples"
    if int(keep.sum()) < 2 * (3 * MAX_TERMS + 1):
        return None
    x, y = np.mod(cam_at[keep], TWO_PI), vf[keep]
    return _FitPoints(x, y, np.ones_like(x), "follower edges",
                      f"{x.size} follower-encoder edges fitted (exact count boundaries; cam angle from {how})")


def _sample_mean_points(cam: CounterReading, raw_cam: np.ndarray, phase: np.ndarray, follower: np.ndarray,
                        idx: np.ndarray) -> _FitPoints:
    """The used samples averaged per cam count (a quantised cam of whole pulses per revolution) or
    per 1/``FIT_BINS`` revolution, weighted by the square root of their relative sample counts."""
    x, y = phase[idx], follower[idx]
    ppr = pulses_per_revolution(cam.step)
    if ppr is not None:
        ref = raw_cam[0] + cam.shift
        level = np.mod(np.rint(np.mod(raw_cam[idx] + cam.shift - ref, TWO_PI) / cam.step).astype(np.int64), ppr)
        counts = np.bincount(level, minlength=ppr)
        sums = np.bincount(level, weights=y, minlength=ppr)
        keep = counts > 0
        fx = np.mod(ref + np.arange(ppr) * cam.step, TWO_PI)[keep]
        kind = "cam-count means"
    else:
        level = np.minimum((x * (FIT_BINS / TWO_PI)).astype(np.int64), FIT_BINS - 1)
        counts = np.bincount(level, minlength=FIT_BINS)
        sums = np.bincount(level, weights=y, minlength=FIT_BINS)
        keep = counts > 0
        fx = np.bincount(level, weights=x, minlength=FIT_BINS)[keep] / counts[keep]
        kind = "cam-angle bin means"
    fy = sums[keep] / counts[keep]
    fw = np.sqrt(counts[keep] / np.mean(counts[keep]))
    return _FitPoints(fx, fy, fw, kind, f"{idx.size} samples averaged into {fx.size} {kind}", counts[keep])


def select_cam_profile_data(recording: Recording, *, window: tuple[float, float] | None = None,
                            speed_tolerance: float = SPEED_TOLERANCE, departure_tolerance: float | None = None,
                            detachment_speed_hz: float | None = None, counter: str = "floor") -> CamProfileData:
    """Select the permanent-contact, steady-speed revolutions of a recording (module doc, steps 1-2).

    Parameters
    ----------
    recording : :class:`~impactid.io.Recording` with channels ``cam_angle`` and ``follower_angle``.
    window : ``(t0, t1)`` [s]: use only the samples with ``t0 <= t < t1`` (revolutions are counted
        from the window's first sample).
    speed_tolerance : largest relative spread of the cam speed over the ``SPEED_SECTORS`` sectors of
        a revolution, and largest relative deviation of its mean speed from the median revolution.
    departure_tolerance : largest distance [rad] of a revolution's follower angle (averaged in
        ``DEPARTURE_BINS`` cam-angle bins) from the per-bin median over the steady revolutions.
        Default: the largest of ``DEPARTURE_FLOOR``, 1.5 follower counts and 8 times the noise
        level of a bin mean.
    detachment_speed_hz : revolutions whose sector speed reaches this cam speed [Hz] are rejected
        (contact cannot be permanent). Default: the detachment speed of the recording's rig when it
        is a flat-follower rig, else no check; ``math.inf`` disables the check.
    counter : how the encoders quantise, a key of ``COUNTERS`` (module doc, step 2).

    Raises
    ------
    RecordingError : a channel is missing or the window holds no samples.
    CamProfileError : fewer than one complete cam revolution, no usable revolution (the message
        names the file and why the revolutions were rejected), or invalid settings.
    """
    where = recording.source or "recording"
    _check_selection_settings(counter, speed_tolerance, departure_tolerance)
    recording.require("cam_angle", "follower_angle", method="the cam-profile fit")
    windowed = _time_window(recording, window, where)
    notes = [windowed.note] if windowed.note else []
    rec = windowed.recording
    raw_cam = np.asarray(rec["cam_angle"], dtype=float)
    raw_follower = np.asarray(rec["follower_angle"], dtype=float)
    t = rec.time
    revolutions = complete_revolutions(raw_cam)
    if len(revolutions) < 1:
        raise CamProfileError(
            f"{where}: channel 'cam_angle' covers only {revolutions.turns:.3g} cam revolution(s){windowed.span}; a "
            "cam-profile fit needs at least one complete revolution in permanent contact")
    cam, follower = read_counter(raw_cam, counter), read_counter(raw_follower, counter)
    notes += [cam.describe("cam_angle"), follower.describe("follower_angle")]
    phase = np.mod(cam.angle, TWO_PI)

    # ---- revolutions at a steady speed below detachment ----
    if detachment_speed_hz is None:
        detachment_speed_hz = _rig_detachment_speed(rec)
        if detachment_speed_hz is not None:
            notes.append(f"detachment speed of the recording's rig: {detachment_speed_hz * 60:.5g} rpm")
    table = _revolution_speeds(revolutions.members, t, revolutions.travel)
    reasons = _speed_rejections(table, speed_tolerance, detachment_speed_hz)
    steady = np.array([r == "" for r in reasons])

    # ---- consistency of the follower angle with the common curve ----
    departures = _departures(revolutions.members, phase, follower.angle, steady, follower.step, departure_tolerance)
    for k in np.flatnonzero(steady):
        reasons[k] = departures.reason(k)
    table["departure"] = departures.distance
    table["departure_angle"] = departures.angle
    table["used"] = np.array([r == "" for r in reasons], dtype=bool)
    table["reason"] = reasons
    used = table["used"].to_numpy()
    notes.append(f"{len(revolutions)} complete revolution(s){windowed.span}, {int(used.sum())} used (speed tolerance "
                 f"{speed_tolerance:.1%}, departure tolerance {departures.tolerance * 1e3:.3g} mrad over "
                 f"{departures.bins} cam-angle bins)")
    if not used.any():
        raise _no_usable_revolution(where, reasons, windowed.span)

    # ---- the used samples and the points to fit ----
    idx = np.sort(np.concatenate([revolutions.members[k] for k in np.flatnonzero(used)]))
    in_use = np.zeros(raw_cam.size, dtype=bool)
    in_use[idx] = True
    points = _follower_edge_points(cam, follower, raw_cam, raw_follower, t, in_use)
    if points is None:
        points = _sample_mean_points(cam, raw_cam, phase, follower.angle, idx)
    notes.append(points.note)
    points = points.ordered()
    edge_timing_sd, fit_noise = None, None
    if points.count is None:  # edges: timing uniform over one sample interval, at the used cam speed
        speed = float(np.median(table.loc[table["used"], "speed_hz"]))
        edge_timing_sd = TWO_PI * speed / rec.sample_rate_hz / math.sqrt(12.0)
    else:  # means: the follower channel's own noise over the samples of each
        sigma = noise_floor(follower.angle[idx], subtract_curvature=True)
        fit_noise = sigma / np.sqrt(points.count)
    return CamProfileData(
        cam_angle=phase[idx], follower_angle=follower.angle[idx], fit_cam_angle=points.cam_angle,
        fit_follower_angle=points.follower_angle, fit_weight=points.weight, fit_points=points.kind,
        revolutions=table, cam_step=cam.step, follower_step=follower.step, counter=counter,
        speed_tolerance=float(speed_tolerance), departure_tolerance=departures.tolerance,
        detachment_speed_hz=detachment_speed_hz, source=recording.source, window=windowed.window, notes=tuple(notes),
        edge_timing_sd=edge_timing_sd, fit_noise=fit_noise)


# --------------------------------------------------------------------------------------------
# The fit
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class CamProfileResult(FitResult):
    """A Gaussian-sum cam profile fitted to encoder data (:func:`fit_cam_profile`).

    ``params``: ``a1..aN``, ``b1..bN``, ``c1..cN`` [rad] (amplitudes, centres, widths), terms sorted
    by centre; the centres are in the recording's cam-angle convention (see :class:`CamProfileData`),
    in ``[0, 2 pi)``. Their standard errors come from the full Jacobian at the optimum (the engine's
    :func:`impactid.engine.uncertainty`, scaled by the reduced chi-square as lmfit does); they are
    undetermined (NaN, ``null``) for the centre and width of a zero-amplitude term, and for every
    coefficient when the condition number of ``J^T J`` exceeds
    :data:`impactid.engine.covariance.CONDITION_LIMIT` (overlapping terms: only the profile they add up to
    is determined; the notes say which and why). They treat the residuals as independent: read
    them as indicative.

    ``statistics``: the engine's (``ndata``, ``nvarys``, ``dof``, ``reduced_chi_square``,
    ``variance_scale``, ``condition_number``, ``cost``, ``nfev``: evaluations of the chosen order's
    refinements, ``success``), ``terms``, ``nsamples``, ``chisqr`` [rad^2] (sum of squared weighted
    residuals), ``aic``, ``bic`` (lmfit's definitions, ``nvarys = 3 terms``), ``rms_residual``,
    ``max_residual`` [rad] (weighted, over the fitted points), ``rms_sample_residual``,
    ``max_sample_residual`` [rad] (over all used samples: for quantised data this includes the
    quantisation error), ``nfev_total`` (all orders), ``starts``, and the model check against the
    recording's own noise (``noise_sd`` [rad], ``residual_over_noise``).

    ``tables``: ``revolutions`` (the selection, :attr:`CamProfileData.revolutions`) and, with
    ``terms="auto"``, ``orders`` (``terms``, ``nvarys``, ``chisqr``, ``rms``, ``aic``, ``bic``,
    ``success``, ``chosen``). ``details``: ``model``, ``source``, ``window``, ``periodic``,
    ``criterion``, ``fit_points``, ``cam_angle_convention``, ``message`` (the optimiser's),
    ``quantisation``, ``selection``, ``revolutions_used``, ``revolutions_rejected``, ``units``,
    ``seconds`` (wall time of the fit) and ``profile`` (the profile sampled on 3600 uniform cam
    angles over one revolution: ``cam_angle``, ``follower_angle`` [rad]).

    Attributes
    ----------
    data : the selected data the profile was fitted to (not part of the JSON form: None after
        :meth:`~impactid.results.FitResult.from_json`).
    """

    kind = "cam-profile"
    title = "Gaussian-sum cam profile"

    data: CamProfileData | None = field(default=None, repr=False, compare=False)

    # ---- the profile ---------------------------------------------------------------------------
    @property
    def terms(self) -> int:
        """Number of Gaussian terms."""
        return int(self.statistics["terms"])

    def _coefficients(self, kind: str) -> tuple[float, ...]:
        return tuple(self.params[f"{kind}{k + 1}"].value for k in range(self.terms))

    def _errors(self, kind: str) -> tuple[float, ...]:
        return tuple(self.params[f"{kind}{k + 1}"].stderr for k in range(self.terms))

    @property
    def profile(self) -> GaussianSumProfile:
        """The fitted (periodic) profile."""
        return GaussianSumProfile(self._coefficients("a"), self._coefficients("b"), self._coefficients("c"),
                                  bool(self.details.get("periodic", True)))

    @property
    def stderr_a(self) -> tuple[float, ...]:
        """Standard errors of the amplitudes [rad] (NaN: undetermined)."""
        return self._errors("a")

    @property
    def stderr_b(self) -> tuple[float, ...]:
        """Standard errors of the centres [rad] (NaN: undetermined)."""
        return self._errors("b")

    @property
    def stderr_c(self) -> tuple[float, ...]:
        """Standard errors of the widths [rad] (NaN: undetermined)."""
        return self._errors("c")

    # ---- statistics ------------------------------------------------------------------------------
    def _stat(self, name: str) -> float:
        value = self.statistics.get(name)
        return math.nan if value is None else float(value)

    @property
    def rms_residual(self) -> float:
        return self._stat("rms_residual")

    @property
    def max_residual(self) -> float:
        return self._stat("max_residual")

    @property
    def rms_sample_residual(self) -> float:
        return self._stat("rms_sample_residual")

    @property
    def max_sample_residual(self) -> float:
        return self._stat("max_sample_residual")

    @property
    def chisqr(self) -> float:
        return self._stat("chisqr")

    @property
    def redchi(self) -> float:
        return self._stat("reduced_chi_square")

    @property
    def aic(self) -> float:
        return self._stat("aic")

    @property
    def bic(self) -> float:
        return self._stat("bic")

    @property
    def ndata(self) -> int:
        return int(self.statistics["ndata"])

    @property
    def nsamples(self) -> int:
        return int(self.statistics["nsamples"])

    @property
    def nvarys(self) -> int:
        return int(self.statistics["nvarys"])

    @property
    def nfev(self) -> int:
        return int(self.statistics["nfev"])

    @property
    def success(self) -> bool:
        return bool(self.statistics["success"])

    @property
    def covariance_condition(self) -> float:
        """Condition number of the column-scaled ``J^T J`` [-]."""
        return self._stat("condition_number")

    @property
    def criterion(self) -> str | None:
        """``"aic"`` or ``"bic"`` when the order was selected automatically, else None."""
        return self.details.get("criterion")

    @property
    def order_table(self) -> pd.DataFrame | None:
        """With ``terms="auto"``: one row per order tried; else None."""
        return self.tables.get("orders")

    @property
    def stderr_note(self) -> str:
        """Why some standard errors are undetermined (empty when every one is a number)."""
        return "; ".join(n for n in self.notes if "undetermined" in n or "condition number" in n)

    def residuals(self) -> np.ndarray:
        """``data - profile`` at the fitted points [rad] (unweighted)."""
        if self.data is None:
            raise CamProfileError("the fitted points are not kept in a result read from JSON")
        return self.data.fit_follower_angle - self.profile(self.data.fit_cam_angle)

    # ---- text and figures --------------------------------------------------------------------------
    def summary(self) -> str:
        """A short text summary (the lmfit-style report is :meth:`report`)."""
        d = self.details
        used, total = len(d.get("revolutions_used", ())), len(self.tables.get("revolutions", ()))
        lines = [
            f"{d.get('source') or 'recording'}: {self.terms}-term Gaussian-sum cam profile"
            + (f" (order chosen by {self.criterion.upper()})" if self.criterion else ""),
            f"  revolutions used {used} of {total}; {self.ndata} {d.get('fit_points', 'points')} fitted "
            f"({self.nsamples} samples)",
            f"  residual RMS {self.rms_residual * 1e3:.4g} mrad, max {self.max_residual * 1e3:.4g} mrad; over the "
            f"samples RMS {self.rms_sample_residual * 1e3:.4g} mrad, max {self.max_sample_residual * 1e3:.4g} mrad",
            f"  chi-square {self.chisqr:.4g} rad^2, AIC {self.aic:.6g}, BIC {self.bic:.6g}",
            f"  {'converged' if self.success else 'NOT converged'}: {d.get('message', '')} ({self.nfev} evaluations, "
            f"{self.statistics.get('starts')} start(s), {float(d.get('seconds') or 0.0):.2f} s)",
        ]
        if self.order_table is not None:
            lines.append("  order selection:")
            lines.extend("    " + line for line in self.order_table.to_string(
                index=False, float_format=lambda v: f"{v:.6g}").splitlines())
        return "\n".join(lines)

    def report(self) -> str:
        """The summary, then the lmfit-style report (statistics, coefficients, notes)."""
        return self.summary() + "\n" + super().report()

    def plot(self, **kwargs):
        """Data and fit, residuals, derivatives (:func:`impactid.rigs.flat.figures.plot_cam_fit`)."""
        return plot_cam_fit(self)


def _solve_amplitudes(E: np.ndarray, y: np.ndarray, w: np.ndarray, nonnegative: bool) -> tuple[np.ndarray, float]:
    """Best amplitudes for a fixed basis (weighted, optionally non-negative) and the cost.

    Solved through the normal equations (``N x N``): tall LAPACK factorisations are avoided, as they
    can be very slow with a multi-threaded BLAS on a busy machine.
    """
    A = E * w[:, None]
    rhs = y * w
    G, g = A.T @ A, A.T @ rhs
    if nonnegative:
        # the non-negative solution of the normal equations through a Cholesky factor
        try:
            L = np.linalg.cholesky(G)
            a, _ = nnls(L.T, np.linalg.solve(L, g), maxiter=50 * A.shape[1])
        except np.linalg.LinAlgError:
            a, _ = nnls(A, rhs, maxiter=50 * A.shape[1])
    else:
        a = np.linalg.lstsq(G, g, rcond=None)[0]
    r = A @ a - rhs
    return a, float(r @ r)


def _even_seeds(terms: int, c_lo: float, c_hi: float) -> list[tuple[np.ndarray, np.ndarray]]:
    """Equally spaced centres at several phases, common widths (module doc, step 5)."""
    spacing = TWO_PI / terms
    phases = 16 if terms <= 2 else 4
    widths = {min(max(k * spacing, c_lo), c_hi) for k in (0.5, 0.7, 1.0, 1.4)}
    if terms <= 2:
        widths |= {min(max(w, c_lo), c_hi) for w in (0.5, 1.0, 1.5, 2.0, 2.5)}
    seeds = []
    for j in range(phases):
        b = spacing * (j / phases + np.arange(terms))
        for width in sorted(widths):
            seeds.append((b, np.full(terms, width)))
    return seeds


def _greedy_seed(previous: GaussianSumProfile, x: np.ndarray, y: np.ndarray, c_lo: float, c_hi: float,
                 nonnegative: bool) -> tuple[np.ndarray, np.ndarray]:
    """The previous order's terms plus one at the largest (smoothed) residual bump."""
    r = y - previous(x)
    m = max(len(r) // 100, 1)
    smooth = np.convolve(np.concatenate((r[-m:], r, r[:m])), np.ones(2 * m + 1) / (2 * m + 1), mode="same")[m:-m]
    j = int(np.argmax(smooth if nonnegative else np.abs(smooth)))
    width = min(max(0.3, c_lo), c_hi)
    return np.append(previous.b, x[j]), np.append(previous.c, width)


class _Projection:
    """Variable projection of one order (module doc, step 4): for centres and widths ``u = (b1, c1,
    b2, c2, ...)`` the amplitudes are the (non-negative) linear least-squares solution, the residual
    is ``P(b, c) y`` with ``P`` the projection off the active columns, and its Jacobian is Kaufman's
    ``P dA/d(b, c) a``. The last point's basis and amplitudes are kept (the search asks for the
    residual and the Jacobian at the same point)."""

    def __init__(self, x, y, w, terms, nonnegative):
        self.x, self.y, self.w, self.terms, self.nonnegative = x, y, w, terms, nonnegative
        self.key = None

    def at(self, u: np.ndarray):
        key = np.asarray(u, dtype=float).tobytes()
        if key != self.key:
            b, c = np.asarray(u[0::2], dtype=float), np.asarray(u[1::2], dtype=float)
            self.E, self.Eb, self.Ec = _basis(self.x, b, c, jacobian=True)
            self.a, _ = _solve_amplitudes(self.E, self.y, self.w, self.nonnegative)
            self.key = key
        return self

    def residual(self, u):
        p = self.at(u)
        return self.w * (p.E @ p.a - self.y)

    def jacobian(self, u):
        p = self.at(u)
        w = self.w[:, None]
        J = np.empty((self.x.size, 2 * self.terms))
        J[:, 0::2] = p.Eb * p.a * w
        J[:, 1::2] = p.Ec * p.a * w
        active = p.a != 0.0
        if active.any():  # project off the active columns (normal equations: k x k solves only)
            A = p.E[:, active] * w
            J -= A @ np.linalg.lstsq(A.T @ A, A.T @ J, rcond=None)[0]
        return J


def _search_lsmr(residual, jacobian, free: list[Free], starts: list[dict], *, max_nfev: int) -> Search:
    """The engine's search with the LSMR trust-region solver in the parameters' own coordinates.

    On the 7-term problem (condition ~1e31) the stop along the model's flat valleys depends on
    both: the exact solver in normalised coordinates stops 1.4e-3 lower in chi-square, with the
    profile moved by 7.8e-7 rad and the coefficients by up to 70 %, beyond this fit's stated
    tolerances (tests/golden/cam_fit.tolerances.toml), and 14 times slower."""
    return search(residual, free, jacobian=jacobian, starts=starts, tr_solver="lsmr", normalise=False,
                  xtol=FIT_TOLERANCE, ftol=FIT_TOLERANCE, gtol=FIT_TOLERANCE, max_nfev=max_nfev)


def _fit_order(x, y, w, terms, c_lo, c_hi, nonnegative, starts, extra_seeds=()):
    """Seed and refine one order (module doc, steps 4-5): the seeds are the rig's, each refinement
    the engine's search (:func:`_search_lsmr`, trust-region reflective within the width bounds) over
    the centres and widths of the variable projection (:class:`_Projection`). Returns
    ``(search, a, b, c, starts run)`` of the best refinement."""
    candidates = []
    for b, c in list(extra_seeds) + _even_seeds(terms, c_lo, c_hi):
        _, cost = _solve_amplitudes(_basis(x, b, c), y, w, nonnegative)
        candidates.append((cost, b, c))
    candidates.sort(key=lambda s: s[0])
    chosen = []
    for cand in candidates:  # distinct starts only (equal costs come from symmetric seeds)
        if all(not math.isclose(cand[0], other[0], rel_tol=1e-9) for other in chosen):
            chosen.append(cand)
        if len(chosen) == starts:
            break
    free, seeds = [], []
    for _, b0, c0 in chosen:
        seed = {}
        for i in range(terms):
            seed[f"b{i + 1}"] = float(b0[i])
            seed[f"c{i + 1}"] = float(min(max(c0[i], c_lo), c_hi))
        seeds.append(seed)
    for i in range(terms):
        free.append(Free(f"b{i + 1}", seeds[0][f"b{i + 1}"], unit="rad"))
        free.append(Free(f"c{i + 1}", seeds[0][f"c{i + 1}"], c_lo, c_hi, unit="rad"))
    projection = _Projection(x, y, w, terms, nonnegative)
    found = _search_lsmr(projection.residual, projection.jacobian, free, seeds,
                         max_nfev=MAX_NFEV_PER_PARAMETER * (2 * terms + 1))
    values = found.values()
    b = np.array([values[f"b{i + 1}"] for i in range(terms)])
    c = np.array([values[f"c{i + 1}"] for i in range(terms)])
    a, _ = _solve_amplitudes(_basis(x, b, c), y, w, nonnegative)
    return found, a, b, c, len(chosen)


@dataclass(frozen=True)
class _Criteria:
    """Goodness of one order's fit: chi-square (sum of squared weighted residuals) [rad^2], AIC and
    BIC (lmfit's definitions, ``nvarys = 3 terms``), weighted RMS and largest absolute residual
    [rad]."""

    chisqr: float
    aic: float
    bic: float
    rms: float
    max: float
    nvarys: int


def _criteria(x, y, w, a, b, c) -> _Criteria:
    r = w * (_basis(x, b, c) @ a - y)
    ndata, nvarys = x.size, 3 * len(a)
    chisqr = float(r @ r)
    neg2_log_likel = ndata * math.log(max(chisqr, 1e-300) / ndata)
    return _Criteria(chisqr=chisqr, aic=neg2_log_likel + 2.0 * nvarys, bic=neg2_log_likel + math.log(ndata) * nvarys,
                     rms=math.sqrt(chisqr / float(np.sum(w * w))), max=float(np.max(np.abs(r / w))), nvarys=nvarys)


def _coefficients_search(found: Search, x, y, w, a, b, c, c_lo: float, c_hi: float, nonnegative: bool) -> Search:
    """The chosen order's optimum as a search over all ``3 N`` coefficients (``a1..aN, b1..bN,
    c1..cN``, terms sorted by centre), with the full analytic Jacobian, for the engine's
    uncertainty: the variable projection searched the centres and widths only, and the
    amplitudes' errors (and their correlations with the rest) need the full Jacobian."""
    b = np.mod(np.asarray(b, dtype=float), TWO_PI)
    order = np.argsort(b, kind="stable")
    a, b, c = np.asarray(a, dtype=float)[order], b[order], np.asarray(c, dtype=float)[order]
    E, Eb, Ec = _basis(x, b, c, jacobian=True)
    r = w * (E @ a - y)
    J = np.hstack((E, Eb * a, Ec * a)) * w[:, None]
    n = len(a)
    free = tuple([Free(f"a{k + 1}", float(a[k]), 0.0 if nonnegative else -math.inf, math.inf, unit="rad")
                  for k in range(n)]
                 + [Free(f"b{k + 1}", float(b[k]), unit="rad") for k in range(n)]
                 + [Free(f"c{k + 1}", float(min(max(c[k], c_lo), c_hi)), c_lo, c_hi, unit="rad") for k in range(n)])
    return Search(free=free, x=np.concatenate((a, b, c)), residual=r, jacobian=J, cost=0.5 * float(r @ r),
                  nfev=found.nfev, success=found.success, message=found.message, starts=found.starts)


def _fit_noise(data: CamProfileData, profile: GaussianSumProfile) -> np.ndarray:
    """The noise of each fitted point [rad] (:func:`_noise_check`'s; NaN where the data show none)."""
    if data.fit_noise is not None:
        return np.asarray(data.fit_noise, dtype=float)
    if data.edge_timing_sd is not None and math.isfinite(data.edge_timing_sd):
        _, slope = profile(data.fit_cam_angle, derivatives=1)
        return np.array(data.edge_timing_sd * math.sqrt(float(np.mean(slope * slope))))
    return np.array(math.nan)


#: The noise reference of the cam-profile fit, in words (for the model check).
PROFILE_NOISE = ("the follower edges' timing error (uniform over a sample) times the profile's slope, or the "
                 "follower channel's noise over the samples of each mean")


def _model_check(data: CamProfileData, profile: GaussianSumProfile, n_params: int, variance_scale: float):
    """The engine's model check (:func:`impactid.engine.check_model`) of the profile at its fitted
    points, in cam-angle order; ``variance_scale`` is the reduced chi-square the covariance was scaled by."""
    residual = data.fit_follower_angle - profile(data.fit_cam_angle)
    noise = np.broadcast_to(_fit_noise(data, profile), residual.shape)
    known = bool(np.all(np.isfinite(noise)) and np.all(noise > 0.0))
    order = np.argsort(np.mod(data.fit_cam_angle, TWO_PI), kind="stable")
    assumed = None
    if known:
        scale = float(np.median(np.asarray(data.fit_weight, dtype=float) * noise))
        assumed = math.sqrt(variance_scale) / scale if scale > 0 and math.isfinite(variance_scale) else None
    checked = check_model(residual[order], noise[order] if known else None, noise_reference=PROFILE_NOISE,
                          what="follower_angle", unit="rad", n_params=n_params, assumed_over_noise=assumed,
                          order=known)
    if not known:  # noise-free data: the residual is rounding and interpolation, whatever its shape
        checked = replace(checked, verdict="not checked", inflation=1.0, action="none",
                          notes=("the recording shows no noise to check the profile against (noise-free data)",))
    return checked


def _noise_check(data: CamProfileData, profile: GaussianSumProfile) -> tuple[dict, tuple[str, ...]]:
    """The residual at the fitted points against the recording's own noise
    (:func:`impactid.engine.residual_against_noise`): for follower edges the timing error of an edge
    (uniform over a sample: cam-angle SD ``omega dt / sqrt(12)``) times the profile's slope there, as
    an RMS over the edges (an edge where the profile is flat has no timing error to speak of); for
    means, the follower channel's noise floor over the samples of each mean."""
    residual = data.fit_follower_angle - profile(data.fit_cam_angle)
    if data.fit_noise is not None:
        noise = np.asarray(data.fit_noise, dtype=float)
    elif data.edge_timing_sd is not None and math.isfinite(data.edge_timing_sd):
        _, slope = profile(data.fit_cam_angle, derivatives=1)
        noise = np.array(data.edge_timing_sd * math.sqrt(float(np.mean(slope * slope))))
    else:
        noise = np.array(math.nan)
    if not (np.all(np.isfinite(noise)) and np.all(noise > 0.0)):
        return {}, ("the recording shows no noise to check the profile against (noise-free data): the model "
                    "check is not made",)
    return residual_against_noise(residual, noise, what="follower_angle", unit="rad")


def fit_cam_profile(data, terms: int | str = DEFAULT_TERMS, *, criterion: str = "bic", max_terms: int = MAX_TERMS,
                    c_bounds: tuple[float, float] = (C_MIN, C_MAX), nonnegative: bool = True,
                    starts: int = DEFAULT_STARTS, window: tuple[float, float] | None = None,
                    speed_tolerance: float = SPEED_TOLERANCE, departure_tolerance: float | None = None,
                    detachment_speed_hz: float | None = None, counter: str = "floor") -> CamProfileResult:
    """Fit a periodic Gaussian-sum cam profile (Alzate et al. 2007, eq. 1) to encoder data by least squares.

    Parameters
    ----------
    data : a :class:`~impactid.io.Recording`, a recording file (HDF5 or CSV), or
        :class:`CamProfileData` already selected.
    terms : number of Gaussian terms, or ``"auto"`` to choose 1..``max_terms`` by ``criterion``.
    criterion : ``"bic"`` or ``"aic"`` (used with ``terms="auto"``).
    max_terms : highest order tried by ``terms="auto"``.
    c_bounds : ``(c_min, c_max)`` bounds of the widths [rad], ``0 < c_min < c_max <= C_MAX``.
    nonnegative : constrain the amplitudes to ``a_i >= 0`` (needs a positive follower angle).
    starts : refinements run from the best seeds (module doc, step 5).
    window, speed_tolerance, departure_tolerance, detachment_speed_hz, counter : data selection,
        see :func:`select_cam_profile_data` (ignored when ``data`` is already selected).

    Returns
    -------
    CamProfileResult

    Raises
    ------
    CamProfileError : invalid settings, no usable data, or (with ``nonnegative``) a follower angle
        that is not positive.
    RecordingError : unreadable file or missing channel.
    """
    if not isinstance(data, CamProfileData):
        if isinstance(data, (str, os.PathLike)):
            data = read_recording(data)
        data = select_cam_profile_data(data, window=window, speed_tolerance=speed_tolerance,
                                       departure_tolerance=departure_tolerance,
                                       detachment_speed_hz=detachment_speed_hz, counter=counter)
    where = data.source or "recording"
    auto = isinstance(terms, str)
    if auto:
        if terms != "auto":
            raise CamProfileError(f"terms must be a positive integer or 'auto', got {terms!r}")
        if criterion not in CRITERIA:
            raise CamProfileError(f"unknown criterion {criterion!r}; choose one of {', '.join(CRITERIA)}")
        if isinstance(max_terms, bool) or int(max_terms) != max_terms or max_terms < 1:
            raise CamProfileError(f"max_terms must be a positive integer, got {max_terms!r}")
        orders = list(range(1, int(max_terms) + 1))
    else:
        if isinstance(terms, bool) or int(terms) != terms or terms < 1:
            raise CamProfileError(f"terms must be a positive integer or 'auto', got {terms!r}")
        orders = [int(terms)]
    c_lo, c_hi = (float(v) for v in c_bounds)
    if not 0.0 < c_lo < c_hi <= C_MAX:
        raise CamProfileError(f"c_bounds must satisfy 0 < c_min < c_max <= pi, got {c_bounds!r}")
    if isinstance(starts, bool) or int(starts) != starts or starts < 1:
        raise CamProfileError(f"starts must be a positive integer, got {starts!r}")
    x, y, w = data.fit_cam_angle, data.fit_follower_angle, data.fit_weight
    if x.size <= 3 * orders[-1] + 1:
        raise CamProfileError(f"{where}: {x.size} {data.fit_points} are too few for a {orders[-1]}-term fit "
                              f"({3 * orders[-1]} coefficients)")
    if nonnegative and float(np.min(y)) <= 0.0:
        raise CamProfileError(
            f"{where}: channel 'follower_angle' reaches {float(np.min(y)):.6g} rad <= 0: a sum of non-negative "
            "Gaussians cannot follow it; fit with signed amplitudes (nonnegative=False, CLI --signed)")

    start = time.perf_counter()
    results, rows, previous = {}, [], None
    for order in orders:
        extra = [_greedy_seed(previous, x, y, c_lo, c_hi, nonnegative)] if previous is not None else []
        found, a, b, c, runs = _fit_order(x, y, w, order, c_lo, c_hi, nonnegative, int(starts), extra)
        crit = _criteria(x, y, w, a, b, c)
        results[order] = (found, a, b, c, runs, crit)
        previous = GaussianSumProfile(a, b, c)
        rows.append({"terms": order, "nvarys": crit.nvarys, "chisqr": crit.chisqr, "rms": crit.rms,
                     "aic": crit.aic, "bic": crit.bic, "success": bool(found.success)})
    if auto:
        table = pd.DataFrame(rows)
        pick = int(table.loc[table[criterion].idxmin(), "terms"])
        table["chosen"] = table["terms"] == pick
    else:
        table, pick = None, orders[0]
    found, a, b, c, runs, crit = results[pick]
    full = _coefficients_search(found, x, y, w, a, b, c, c_lo, c_hi, nonnegative)
    fit = uncertainty(full)
    seconds = time.perf_counter() - start
    values = full.values()
    profile = GaussianSumProfile(tuple(values[f"a{k + 1}"] for k in range(pick)),
                                 tuple(values[f"b{k + 1}"] for k in range(pick)),
                                 tuple(values[f"c{k + 1}"] for k in range(pick)))
    res = data.follower_angle - profile(data.cam_angle)
    check, check_notes = _noise_check(data, profile)
    checked = _model_check(data, profile, 3 * pick, float(fit.scale))
    parameters = checked.widen(fit.parameters)
    comparison = None
    if table is not None and len(table) > 1:
        comparison = compare_models([{"name": f"{int(row.terms)} terms", "n_params": int(row.nvarys),
                                      "n_data": int(x.size), "rss": float(row.chisqr)} for row in table.itertuples()],
                                    nested=[(f"{a} terms", f"{b} terms") for a, b in zip(table["terms"][:-1],
                                                                                        table["terms"][1:])],
                                    choice=f"the number of Gaussian terms (chosen by {criterion.upper()})")
        comparison = _chosen_order(comparison, pick, criterion)
    described = identifiability(full, fit, comparison=comparison, describes_data=checked.describes_data,
                                quadratic_reason=f"a refit of {3 * pick} coefficients per point costs a whole fit")
    statistics = {**fit.statistics, "terms": pick, "nsamples": data.nsamples, "chisqr": crit.chisqr, "aic": crit.aic,
                  "bic": crit.bic, "rms_residual": crit.rms, "max_residual": crit.max,
                  "rms_sample_residual": float(np.sqrt(np.mean(res * res))),
                  "max_sample_residual": float(np.max(np.abs(res))),
                  "nfev_total": int(sum(r[0].nfev for r in results.values())), "starts": runs,
                  **{k: v for k, v in check.items() if k != "residual_rms"}}
    notes = list(fit.notes)
    zero = [k + 1 for k in range(pick) if profile.a[k] == 0.0]
    if zero:
        notes.append(f"centre and width undetermined for the zero-amplitude term(s) {', '.join(map(str, zero))}")
    notes += list(check_notes) + list(checked.further_notes)
    if comparison is not None and comparison.get("preferred_by_likelihood_ratio"):
        notes.append(f"{pick} terms by {criterion.upper()}; the likelihood-ratio tests of each order against the next "
                     f"would take {comparison['preferred_by_likelihood_ratio']}: they count every sample as an "
                     "independent residual, but the residuals are timing and quantisation errors correlated along the "
                     "cam, which overstates the evidence for more terms (read the table of orders)")
    notes += [f"revolution {k} rejected: {reason}" for k, reason in data.rejected_revolutions.items()]
    theta, value = profile.sample(3600)
    details = {
        "model": "gaussian-sum cam profile (Alzate et al. (2007) eq. 1), periodic",
        "source": data.source,
        "window": list(data.window) if data.window else None,
        "periodic": profile.periodic,
        "criterion": criterion if auto else None,
        "fit_points": data.fit_points,
        "cam_angle_convention": "the recording's cam_angle, mod 2 pi" + (
            f", read as a {data.counter} counter (angle = reading + {COUNTERS[data.counter]:g} count on average)"
            if data.cam_step is not None else ""),
        "message": found.message,
        "seconds": seconds,
        "quantisation": {"counter": data.counter, "cam_step": data.cam_step,
                         "cam_ppr": pulses_per_revolution(data.cam_step), "follower_step": data.follower_step,
                         "follower_ppr": pulses_per_revolution(data.follower_step)},
        "selection": {"speed_tolerance": data.speed_tolerance, "departure_tolerance": data.departure_tolerance,
                      "detachment_speed_hz": data.detachment_speed_hz, "notes": list(data.notes)},
        "revolutions_used": list(data.used_revolutions),
        "revolutions_rejected": {str(k): v for k, v in data.rejected_revolutions.items()},
        "units": {"a": "rad", "b": "rad", "c": "rad", "residuals": "rad", "chisqr": "rad^2", "profile": "rad",
                  "noise_sd": "rad", "revolutions.t_start": "s", "revolutions.speed_hz": "Hz"},
        "profile": {"cam_angle": theta, "follower_angle": value},
    }
    tables = {"revolutions": data.revolutions}
    if table is not None:
        tables["orders"] = table
    provenance = (*data.notes, f"impactid.rigs.flat.camprofile.fit_cam_profile: {pick} terms"
                  + (f" (chosen by {criterion.upper()} among 1..{orders[-1]})" if auto else "")
                  + f", {runs} start(s), {found.nfev} evaluations")
    return CamProfileResult(params=parameters, statistics=statistics, notes=tuple(notes), tables=tables,
                            details=details, provenance=provenance, data=data, model_check=combine_checks([checked]),
                            identifiability=described)


def _chosen_order(comparison: dict, pick: int, criterion: str) -> dict:
    """The comparison of the orders with the order the fit took (``pick``, by ``criterion``) as its
    ``preferred``; where the likelihood-ratio tests' own preference differs, it is kept as
    ``preferred_by_likelihood_ratio`` and the rule says why the criterion decides."""
    chosen = f"{pick} terms"
    if comparison.get("preferred") == chosen:
        return comparison
    return {**comparison, "preferred": chosen, "preferred_by_likelihood_ratio": comparison.get("preferred"),
            "rule": (f"the order with the lowest {criterion.upper()} (the likelihood-ratio tests, which count every "
                     "sample as an independent residual, are shown but do not decide: the residuals are timing and "
                     "quantisation errors correlated along the cam)")}


# --------------------------------------------------------------------------------------------
# Validation against a reference profile
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ProfileComparison:
    """How well a profile matches a reference under the best change of cam-angle convention.

    ``error(theta) = profile(theta) - reference(direction * theta + offset) - level`` on
    ``samples`` uniform cam angles ``theta`` over one revolution ``[0, 2 pi)``.

    Attributes
    ----------
    rms, max_abs : RMS and largest absolute error [rad].
    offset : cam-angle offset [rad] in ``[0, 2 pi)``.
    direction : +1 (same sense of rotation) or -1 (reversed).
    level : constant follower-angle offset removed [rad] (0 unless ``fit_level``).
    cam_angle, error : the evaluation grid and the error there [rad], shape ``(samples,)``.
    """

    rms: float
    max_abs: float
    offset: float
    direction: int
    level: float
    cam_angle: np.ndarray = field(repr=False)
    error: np.ndarray = field(repr=False)

    def to_dict(self) -> dict[str, float]:
        """Scalars as plain data (radians)."""
        return {"rms": self.rms, "max_abs": self.max_abs, "offset": self.offset, "direction": self.direction,
                "level": self.level}


def compare_profiles(profile, reference, *, directions=(1, -1), samples: int = 3600,
                     fit_level: bool = False) -> ProfileComparison:
    """Compare a profile with a reference function under the best cam-angle offset (and direction).

    Parameters
    ----------
    profile : callable ``theta [rad] -> follower angle [rad]`` evaluated on one revolution
        ``[0, 2 pi)`` (a :class:`GaussianSumProfile`, periodic or not).
    reference : callable ``theta [rad] -> follower angle [rad]``, ``2 pi``-periodic (e.g.
        ``rig.contact_angle`` of a :class:`~impactid.rigs.FlatFollowerRig`, eq. A-17).
    directions : senses of rotation tried: ``(1,)``, ``(-1,)`` or ``(1, -1)``.
    samples : uniform cam angles over the revolution.
    fit_level : also remove the best constant follower-angle offset.

    Returns
    -------
    ProfileComparison minimising the RMS error: the offset is found on the sample grid by circular
    cross-correlation (FFT) and refined by a bounded scalar minimisation (to about 1e-12 rad).
    """
    samples = int(samples)
    theta = TWO_PI * np.arange(samples) / samples
    p = np.asarray(profile(theta), dtype=float)
    r = np.asarray(reference(theta), dtype=float)
    step = TWO_PI / samples
    P, R = np.fft.rfft(p), np.fft.rfft(r)
    best = None
    for direction in directions:
        if direction not in (1, -1):
            raise ValueError(f"directions must be +1 or -1, got {direction!r}")
        # sum_j p_j r_{(s j + m) mod M}: correlation for s = +1, convolution for s = -1
        corr = np.fft.irfft((np.conj(P) if direction == 1 else P) * R, n=samples)
        m = int(np.argmax(corr))

        def mean_square(delta, direction=direction, grid=m * step):
            e = p - np.asarray(reference(direction * theta + grid + delta), dtype=float)
            if fit_level:
                e = e - e.mean()
            return float(np.mean(e * e))

        # refine the small correction to the grid offset (Brent's tolerance is relative to |x|)
        res = minimize_scalar(mean_square, bounds=(-step, step), method="bounded", options={"xatol": 1e-13})
        delta = float(res.x) if res.fun <= mean_square(0.0) else 0.0
        value = mean_square(delta)
        if best is None or value < best[0]:
            best = (value, m * step + delta, direction)
    value, offset, direction = best
    error = p - np.asarray(reference(direction * theta + offset), dtype=float)
    level = float(error.mean()) if fit_level else 0.0
    error = error - level
    return ProfileComparison(rms=float(np.sqrt(np.mean(error * error))), max_abs=float(np.max(np.abs(error))),
                             offset=float(np.mod(offset, TWO_PI)), direction=int(direction), level=level,
                             cam_angle=theta, error=error)

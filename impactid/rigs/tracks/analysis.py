"""The whole job on ball tracks: every bounce found, fitted and judged, the laws across bounces, and
the table-tennis rule's band beside the restitution at the rule's impact speeds
(:func:`analyse_tracks` -> :class:`TrackAnalysis`).

1. Each track's bounces (:func:`~impactid.rigs.tracks.bounces.find_bounces`) and tracking noise
   (:func:`~impactid.rigs.tracks.bounces.tracking_noise`); each bounce with enough flight fitted
   (:func:`~impactid.rigs.tracks.bounces.fit_bounce`), the contact height free, in the order of time:
   the track's given spin is its first bounce's incoming spin, each later bounce's is the previous
   bounce's outgoing spin (propagated), and a spin nothing gives is estimated from the flights
   (unknown without the Magnus force; such bounces are left out of the tangential laws).
2. The surface: given (``surface_height``, horizontal), or estimated from the fitted contact points
   (tracks analysed together share their frame): a plane ``z_c = a + b x + c y`` through the contact
   points within :data:`SURFACE_BAND` of their median height (``b`` only for 2-D tracks), kept when
   it beats the horizontal plane by BIC (``surface="auto"``; ``"plane"`` or ``"flat"`` force one).
   A tilted plane's normal is the direction of the normal restitution: the bounces are refitted with
   it (:func:`~impactid.rigs.tracks.bounces.fit_bounce`, ``normal``). Read against the plane's
   gradient, ``e_n`` does not change under an affine distortion of the frame
   (:func:`restitution_against`); the slopes' covariance is carried into every ``e_n`` and into the
   normal laws (the surface plane's share, in quadrature; common to all bounces, so that pooling does
   not average it down; ``details.surface_share``). A bounce counts when its lowest
   sample lies within :data:`SURFACE_BAND` of the contact plane (the ball's bottom within 5 cm of the
   surface, above or below); with a given surface the bounces are refitted with the contact on it.
3. A bounce is analysed unless it lacks flight, its fit fails, its flights' model check withholds
   its intervals, or it is not on the surface: each other candidate is in the table with its reason.
4. The laws across the analysed bounces (:mod:`~impactid.rigs.tracks.laws`, the velocities turned
   into the surface's frame), chosen by AIC or BIC; the restitution over the normal impact speeds
   ``speed_band`` (the constant law on those bounces); the rule's band through the same air model
   (:func:`~impactid.rigs.tracks.rule.rule_band`).
5. With ``estimate_lift``: the lift scale of the ball's lift model fitted per bounce with a known
   spin (an eleventh parameter of each bounce's fit) and pooled across them by the constant law
   (random effects, DerSimonian & Laird 1986): ``params["lift_scale"]``.
6. With ``air_share``: the air model's share of the uncertainty. Every bounce is refitted with the
   drag coefficient at the ends of :data:`~impactid.rigs.tracks.parameters.DRAG_RANGE` and the lift
   scale at the ends of its range (``lift_range``; by default the estimated interval joined with the
   nominal scale; without an estimate 0 to the nominal), one at a time. Each quantity's shifts
   ``Delta`` are added as a systematic term, ``[sum of min(0, Delta), sum of max(0, Delta)]`` over the
   two coefficients, to its statistical interval: ``e_n_air_low``, ``e_n_air_high`` per bounce (the
   ``e_n_air`` parameter of each bounce fit) and ``e_n_speed_band_air`` (the pooled value on the same
   bounces in each variant). The rule's band likewise over the drag range.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
import pandas as pd
from scipy import stats

from impactid.engine import combine_checks
from impactid.errors import ImpactidError
from impactid.results import FitResult, Parameter
from impactid.rigs.tracks.bounces import (
    MIN_FLIGHT,
    WINDOW,
    BounceFit,
    Candidate,
    find_bounces,
    fit_bounce,
    tracking_noise,
)
from impactid.rigs.tracks.laws import (
    NORMAL_LAWS,
    TANGENTIAL_LAWS,
    LawFit,
    fit_normal_law,
    fit_tangential_law,
    select,
)
from impactid.rigs.tracks.parameters import DRAG_RANGE, LIFT_MODEL, TABLE_TENNIS_BALL, TrackedBall
from impactid.rigs.tracks.readers import Track
from impactid.rigs.tracks.rule import rule_band

__all__ = ["SPEED_BAND", "SURFACE_BAND", "SURFACE_MODES", "SurfacePlane", "TrackAnalysis", "TrackAnalysisError",
           "air_model_share", "analyse_tracks", "restitution_against", "restitution_slope_gradient", "surface_plane"]

#: How far above the surface the ball's bottom may be at a bounce's lowest sample [m].
SURFACE_BAND = 0.05
#: The normal impact speeds compared with the table-tennis rule [m/s].
SPEED_BAND = (2.0, 3.0)
#: How the surface is estimated: ``auto`` (a plane when BIC prefers it to a horizontal one), ``plane``, ``flat``.
SURFACE_MODES = ("auto", "plane", "flat")


class TrackAnalysisError(ImpactidError, ValueError):
    """Tracks that cannot be analysed (no bounce at all, inconsistent options); the message says why."""


class TrackAnalysis(FitResult):
    """Bounces of tracked balls: per-bounce restitution and the laws across bounces.

    Parameters: ``normal.constant.e``, ``normal.linear.e0``, ``normal.linear.gamma`` [s/m],
    ``tangential.ratio.beta``, ``tangential.coulomb.mu``, and ``e_n_speed_band`` (the constant law on
    the bounces whose normal impact speed lies in ``details.speed_band``). Tables: ``bounces`` (one row
    per bounce found, analysed or with the reason it is not). Details: the ball, the surface, the
    selected laws and their comparisons, the rule's band and its comparison, the per-bounce fits
    (``bounce_fits``, each a :class:`~impactid.rigs.tracks.bounces.BounceFit` as a dict).
    """

    kind = "tracked-ball-bounces"
    title = "bounces of tracked balls"

    @property
    def bounces(self) -> pd.DataFrame:
        """The per-bounce table."""
        return self.tables["bounces"]

    def plot(self, **kwargs):
        from impactid.rigs.tracks.figures import restitution_figure

        return restitution_figure(self, **kwargs)


@dataclass(frozen=True)
class _Bounce:
    track: Track
    cand: Candidate
    label: str
    fit: BounceFit | None
    reason: str


def _label(track: Track, cand: Candidate) -> str:
    return f"{track.name}@{track.time[cand.index]:.4f}s"


def _usable_spin(fit: BounceFit | None) -> bool:
    """Whether a bounce's outgoing spin can be carried to the next bounce: fitted, its spin known, its
    intervals not withheld, its covariance finite."""
    if fit is None or fit.details.get("spin_source", "unknown") == "unknown":
        return False
    if fit.model_check.get("action") == "withheld":
        return False
    return bool(np.all(np.isfinite(fit.details["spin_out"]))
                and np.all(np.isfinite(fit.details["spin_out_covariance"])))


def _fit_all(tracks: Sequence[Track], ball: TrackedBall, *, contact_height, spin, confidence, min_flight,
             window, spin_side, normal=None, fit_lift=False, only=None, breaks=frozenset()) -> list[_Bounce]:
    """Every bounce of the tracks fitted in the order of time, each with its incoming spin (step 1 of the
    module doc): the track's given spin for its first bounce, the previous bounce's outgoing spin
    (propagated) when that bounce was fitted with a usable spin and is not in ``breaks`` (labels of
    bounces that are not on the surface), else estimated from the flights (unknown without the Magnus
    force). ``only``: the labels to return (the bounces before them in their tracks are fitted too,
    for their spins)."""
    out = []
    for track in tracks:
        cands = find_bounces(track, min_flight=min_flight, window=window)
        labels = [_label(track, c) for c in cands]
        last = max((k for k, lab in enumerate(labels) if only is None or lab in only), default=-1)
        noise = tracking_noise(track, cands)
        previous: _Bounce | None = None
        for k, (cand, label) in enumerate(zip(cands, labels)):
            if k > last:
                break
            keep = only is None or label in only
            if cand.reason:
                previous = _Bounce(track, cand, label, None, cand.reason)
                if keep:
                    out.append(previous)
                continue
            options = {}
            if previous is None and track.spin is not None:
                options = dict(spin_source="given")
            elif (previous is not None and previous.label not in breaks and _usable_spin(previous.fit)):
                options = dict(spin_source="propagated", spin_in=np.array(previous.fit.details["spin_out"]),
                               spin_in_covariance=np.array(previous.fit.details["spin_out_covariance"]))
            else:
                options = dict(spin_source="estimated" if spin else "unknown")
            try:
                fit = fit_bounce(track, cand, ball, contact_height=contact_height, spin=spin, confidence=confidence,
                                 bounce_id=label, noise=noise, spin_side=spin_side, normal=normal,
                                 fit_lift=fit_lift, **options)
            except ValueError as exc:
                previous = _Bounce(track, cand, label, None, f"fit failed: {exc}")
                if keep:
                    out.append(previous)
                continue
            previous = _Bounce(track, cand, label, fit, "")
            if keep:
                out.append(previous)
    return out


@dataclass(frozen=True)
class SurfacePlane:
    """The plane of the contact points ``z_c = height + slope_x (x - x0) + slope_y (y - y0)``.

    Attributes
    ----------
    height : of the ball's centre at contact at the centroid ``(x0, y0)`` [m].
    centroid : ``(x0, y0)`` [m].
    slopes : ``(slope_x, slope_y)`` [m/m] (zeros for a horizontal plane).
    stderr : the standard errors of ``(height, slope_x, slope_y)`` (from the points' scatter about the plane).
    rms : the points' scatter about the plane [m].
    points : how many contact points.
    tilted : whether the plane is tilted (chosen, or forced).
    bic : ``{"flat": ..., "plane": ...}`` of the two fits.
    slope_covariance : the covariance of ``(slope_x, slope_y)`` [(m/m)^2] (zeros for a horizontal plane).
    """

    height: float
    centroid: tuple[float, float]
    slopes: tuple[float, float]
    stderr: tuple[float, float, float]
    rms: float
    points: int
    tilted: bool
    bic: dict
    slope_covariance: tuple[tuple[float, float], tuple[float, float]] = ((0.0, 0.0), (0.0, 0.0))

    @property
    def normal(self) -> np.ndarray:
        """The plane's unit normal (up)."""
        n = np.array([-self.slopes[0], -self.slopes[1], 1.0])
        return n / np.linalg.norm(n)

    @property
    def tilt(self) -> float:
        """The angle between the normal and ``e_z`` [rad]."""
        return math.atan(math.hypot(*self.slopes))

    def contact_height(self, x, y):
        """The ball centre's height at contact at ``(x, y)`` [m]."""
        return self.height + self.slopes[0] * (x - self.centroid[0]) + self.slopes[1] * (y - self.centroid[1])

    def to_dict(self) -> dict:
        return {"contact_height_m": self.height, "centroid_m": list(self.centroid), "slopes": list(self.slopes),
                "stderr": list(self.stderr), "rms_m": self.rms, "points": self.points, "tilted": self.tilted,
                "tilt_rad": self.tilt, "normal": self.normal.tolist(), "bic": self.bic,
                "slope_covariance": [list(row) for row in self.slope_covariance]}


def surface_plane(points: np.ndarray, *, slopes: int = 2, mode: str = "auto") -> SurfacePlane:
    """The plane through contact points (``(n, 3)``: ``x_c, y_c, z_c`` [m]) by least squares, with
    ``slopes`` (2: along x and y; 1: along x) or none; ``mode`` ``auto`` keeps the tilt when its BIC,
    ``n ln(RSS / n) + k ln n``, is lower than the horizontal plane's, ``plane`` always, ``flat`` never.
    The standard errors are from the points' scatter about the plane (their own errors are smaller)."""
    if mode not in SURFACE_MODES:
        raise TrackAnalysisError(f"unknown surface mode {mode!r}; valid: {', '.join(SURFACE_MODES)}")
    pts = np.asarray(points, dtype=float)
    n = pts.shape[0]
    centroid = (float(np.mean(pts[:, 0])), float(np.mean(pts[:, 1])))
    columns = [np.ones(n), pts[:, 0] - centroid[0], pts[:, 1] - centroid[1]][:1 + slopes]
    fits = {}
    for name, k in (("flat", 1), ("plane", 1 + slopes)):
        if n <= k + 1:
            continue
        design = np.column_stack(columns[:k])
        coef, *_ = np.linalg.lstsq(design, pts[:, 2], rcond=None)
        rss = float(np.sum((pts[:, 2] - design @ coef) ** 2))
        sigma2 = rss / (n - k)
        cov = sigma2 * np.linalg.pinv(design.T @ design)
        bic = n * math.log(max(rss, 1e-300) / n) + k * math.log(n)
        fits[name] = (coef, np.sqrt(np.diag(cov)), math.sqrt(rss / n), bic, cov)
    if "flat" not in fits:
        z = float(np.mean(pts[:, 2]))
        return SurfacePlane(z, centroid, (0.0, 0.0), (math.nan, 0.0, 0.0), 0.0, n, False, {})
    bic = {name: f[3] for name, f in fits.items()}
    tilted = "plane" in fits and slopes > 0 and (mode == "plane" or (mode == "auto" and bic["plane"] < bic["flat"]))
    coef, se, rms, _, cov = fits["plane" if tilted else "flat"]
    slope = (float(coef[1]), float(coef[2]) if slopes > 1 else 0.0) if tilted else (0.0, 0.0)
    stderr = (float(se[0]), float(se[1]) if tilted else 0.0, float(se[2]) if tilted and slopes > 1 else 0.0)
    slope_cov = np.zeros((2, 2))
    if tilted:
        slope_cov[:slopes, :slopes] = cov[1:, 1:]
    return SurfacePlane(float(coef[0]), centroid, slope, stderr, rms, n, tilted, bic,
                        tuple(tuple(float(v) for v in row) for row in slope_cov))


def _surface_frame(normal: np.ndarray) -> np.ndarray:
    """The rotation (3, 3) whose rows are the surface's frame: two tangents (the first in the x-z plane)
    and the normal; ``e_z`` gives the identity."""
    n = np.asarray(normal, dtype=float)
    t1 = np.array([1.0, 0.0, 0.0]) - n[0] * n
    t1 /= np.linalg.norm(t1)
    return np.vstack([t1, np.cross(n, t1), n])


def restitution_against(v_in: np.ndarray, v_out: np.ndarray, slopes) -> np.ndarray:
    """The normal restitution ``-(v_out . m) / (v_in . m)`` (B,) of velocities ``v_in``, ``v_out`` (B, 3)
    [m/s] against a plane rising by ``slopes = (slope_x, slope_y)`` [m/m]: ``m = (-slope_x, -slope_y, 1)``
    is the gradient of ``z - slope_x x - slope_y y`` (the plane's normal up to its length, which cancels).
    Read with that gradient, ``e_n`` does not change under an affine distortion of the tracks' frame
    (a rotation, a shear, a scale error of one axis): the velocities and the plane of the contact
    points are distorted together."""
    m = np.array([-float(slopes[0]), -float(slopes[1]), 1.0])
    return -(np.atleast_2d(v_out) @ m) / (np.atleast_2d(v_in) @ m)


def restitution_slope_gradient(v_in: np.ndarray, v_out: np.ndarray, slopes) -> np.ndarray:
    """``d e_n / d (slope_x, slope_y)`` (B, 2) of :func:`restitution_against` [per m/m]."""
    v_in, v_out = np.atleast_2d(v_in), np.atleast_2d(v_out)
    m = np.array([-float(slopes[0]), -float(slopes[1]), 1.0])
    a, b = v_in @ m, v_out @ m
    return np.column_stack([(v_out[:, k] * a - b * v_in[:, k]) / a ** 2 for k in (0, 1)])


def _law_surface_share(law: LawFit, speeds: np.ndarray, v_in: np.ndarray, v_out: np.ndarray, se: np.ndarray,
                       slopes, slope_cov: np.ndarray, confidence: float) -> dict[str, float]:
    """The standard deviation that the surface plane's slopes give each parameter of a normal law: the
    law refitted (its scatter ``tau`` kept) with every bounce's ``e_n`` read against the plane moved by
    one standard error of each slope, the derivatives combined with the slopes' covariance. The error
    of the slopes is common to all bounces: pooling does not average it down."""
    gradients = np.zeros((len(law.params), 2))
    for k in (0, 1):
        step = math.sqrt(max(float(slope_cov[k, k]), 0.0))
        if step == 0.0:
            continue
        shift = np.zeros(2)
        shift[k] = step
        moved = [fit_normal_law(law.name, speeds, restitution_against(v_in, v_out, np.asarray(slopes) + sign * shift),
                                se, confidence=confidence, tau=law.extra["tau"]) for sign in (1.0, -1.0)]
        for j, p in enumerate(law.params):
            gradients[j, k] = (moved[0][p.name].value - moved[1][p.name].value) / (2.0 * step)
    return {p.name: math.sqrt(max(float(g @ slope_cov @ g), 0.0)) for p, g in zip(law.params, gradients)}


#: The note of a restitution whose interval carries the surface plane's uncertainty.
_SURFACE_SHARE_NOTE = "with the surface plane's share {:.2g} (the slopes' covariance through the normal)"


def _with_share(p: Parameter, share: float) -> Parameter:
    """``p`` with the standard deviation ``share`` added in quadrature to its standard error and its
    interval's two sides widened in the same ratio (``p`` unchanged when ``share`` is 0 or ``p`` has no
    finite standard error)."""
    if not (share > 0.0 and math.isfinite(share) and math.isfinite(p.stderr) and p.stderr > 0.0):
        return p
    stderr = math.hypot(p.stderr, share)
    ratio = stderr / p.stderr
    low, high = p.interval
    note = "; ".join(x for x in (p.note, _SURFACE_SHARE_NOTE.format(share)) if x)
    return replace(p, stderr=stderr, interval=(p.value - (p.value - low) * ratio, p.value + (high - p.value) * ratio),
                   note=note)


def _row(b: _Bounce, status: str, reason: str) -> dict:
    row = {"bounce": b.label, "track": b.track.source, "sample": int(b.cand.index),
           "t_min_s": float(b.track.time[b.cand.index]), "z_min_m": float(b.track.height[b.cand.index]),
           "analysed": status == "analysed", "reason": reason}
    if b.fit is None:
        row["spin_source"] = ""
        return row
    f = b.fit
    row["spin_source"] = f.details["spin_source"]
    for side in ("in", "out"):
        spin = np.asarray(f.details[f"spin_{side}"], dtype=float)
        row[f"spin_{side}_rad_s"] = float(np.linalg.norm(spin))
        for axis, k in zip("xyz", range(3)):
            row[f"spin_{side}_{axis}_rad_s"] = float(spin[k])
            name = f"spin_{side}_{axis}"
            if name in f.params:
                row[f"spin_{side}_{axis}_rad_s_stderr"] = f.params[name].stderr
    for name in ("t_c", "z_c", "vn_in", "speed_in", "vt_in", "e_n", "beta_t", "ut_in", "ut_out", "dspin_x",
                 "dspin_y"):
        if name not in f.params:
            continue
        p = f.params[name]
        unit = {"t_c": "s", "z_c": "m"}.get(name, p.unit.replace("/", "_"))
        key = f"{name}_{unit}" if unit else name
        row[key] = p.value
        if name in ("e_n", "beta_t", "vn_in", "dspin_x", "dspin_y", "z_c"):
            row[f"{key}_stderr"] = p.stderr
        if name in ("e_n", "beta_t"):
            row[f"{name}_low"], row[f"{name}_high"] = p.interval
    row["residual_rms_m"] = f.statistics["residual_rms_m"]
    row["samples_before"] = f.statistics["samples_before"]
    row["samples_after"] = f.statistics["samples_after"]
    row["model_check"] = f.model_check.get("verdict", "")
    return row


def _band_fit(speeds, e, se, band, confidence):
    inside = (speeds >= band[0]) & (speeds <= band[1])
    if np.sum(inside) < 2:
        return None, int(np.sum(inside))
    return fit_normal_law("constant", speeds[inside], e[inside], se[inside], confidence=confidence), int(np.sum(inside))


def _pooled(fits: dict, labels: list[str], confidence) -> tuple[float, float, float] | None:
    """The constant law on the bounces ``labels`` of ``fits`` (label -> BounceFit): (value, low, high), None
    with fewer than two."""
    use = [fits[k] for k in labels if k in fits and fits[k] is not None and math.isfinite(fits[k]["e_n"].stderr)]
    if len(use) < 2:
        return None
    law = fit_normal_law("constant", np.array([f["vn_in"].value for f in use]),
                         np.array([f["e_n"].value for f in use]), np.array([f["e_n"].stderr for f in use]),
                         confidence=confidence)
    p = law["e"]
    return p.value, p.interval[0], p.interval[1]


def _systematic(shifts: dict[str, list[float]]) -> tuple[float, float]:
    """The systematic term ``[sum of min(0, Delta), sum of max(0, Delta)]`` over the factors' shifts."""
    low = sum(min([0.0, *d]) for d in shifts.values())
    high = sum(max([0.0, *d]) for d in shifts.values())
    return low, high


def analyse_tracks(tracks: Sequence[Track], ball: TrackedBall = TABLE_TENNIS_BALL, *,
                   surface_height: float | None = None, surface: str = "auto", spin: bool = True,
                   criterion: str = "bic", confidence: float = 0.95, min_flight: int = MIN_FLIGHT,
                   window: float = WINDOW, speed_band: tuple[float, float] = SPEED_BAND, rule: bool = True,
                   spin_side: str = "in", estimate_lift: bool = False, air_share: bool = False,
                   lift_range: tuple[float, float] | None = None) -> TrackAnalysis:
    """Analyse the bounces of one or several tracks (module doc).

    Parameters
    ----------
    tracks : the tracks (:func:`~impactid.rigs.tracks.readers.read_track`), in one frame.
    ball : the ball and its air model.
    surface_height : the surface's height in the tracks' frame [m] (horizontal); None: estimated.
    surface : how an estimated surface is modelled (:data:`SURFACE_MODES`).
    spin : whether the flights feel the Magnus force of their spin.
    criterion : ``"bic"`` or ``"aic"``: how the laws are chosen.
    confidence : coverage of the intervals.
    min_flight, window : samples of flight each side needs, and the flight fitted each side [s].
    speed_band : the normal impact speeds [m/s] of ``e_n_speed_band``.
    rule : whether to compute the table-tennis rule's band (a table-tennis ball on a table).
    spin_side : ``"in"``: the tracks' spins were measured before their bounces; ``"out"``: after.
    estimate_lift : whether to estimate the lift scale from the tracks (step 5 of the module doc).
    air_share : whether to state the air model's share of the uncertainty (step 6).
    lift_range : the lift scales of the air model's share (None: from the estimate, module doc).

    Raises
    ------
    TrackAnalysisError
        when no bounce can be analysed (the message gives the reasons).
    """
    if criterion not in ("aic", "bic"):
        raise TrackAnalysisError(f"unknown criterion {criterion!r}; valid: aic, bic")
    if surface not in SURFACE_MODES:
        raise TrackAnalysisError(f"unknown surface mode {surface!r}; valid: {', '.join(SURFACE_MODES)}")
    tracks = list(tracks)
    if not tracks:
        raise TrackAnalysisError("no track given")
    contact = None if surface_height is None else surface_height + ball.radius
    if spin_side not in ("in", "out"):
        raise TrackAnalysisError(f"spin_side must be 'in' or 'out', got {spin_side!r}")
    common = dict(contact_height=contact, spin=spin, confidence=confidence, min_flight=min_flight, window=window,
                  spin_side=spin_side)
    fitted = _fit_all(tracks, ball, **common)
    heights = np.array([b.fit["z_c"].value for b in fitted if b.fit is not None])
    notes: list[str] = []
    lift, lift_details = None, None
    if estimate_lift and spin:
        level = contact if contact is not None else float(np.median(heights)) if heights.size else 0.0
        near = {b.label for b in fitted if b.fit is not None
                and abs(float(b.track.height[b.cand.index]) - level) <= SURFACE_BAND}
        lifted = [b.fit for b in _fit_all(tracks, ball, fit_lift=True, only=near, **common) if b.fit is not None]
        use = [f for f in lifted if "lift_scale" in f.params and math.isfinite(f["lift_scale"].stderr)
               and f["lift_scale"].stderr > 0]
        if len(use) >= 2:
            law = fit_normal_law("constant", np.zeros(len(use)), np.array([f["lift_scale"].value for f in use]),
                                 np.array([f["lift_scale"].stderr for f in use]), confidence=confidence)
            lp = law["e"]
            lift = Parameter("lift_scale", lp.value, lp.stderr, lp.interval, lp.confidence, False, "",
                             f"the factor on the lift coefficient of {LIFT_MODEL}, estimated from the {len(use)} "
                             f"bounces with a known spin (each fitted with its own scale; pooled with their scatter, "
                             f"DerSimonian & Laird); the published fit is 1; the bounces use {lp.value:.4g}")
            lift_details = {"bounces": len(use), "published_scale": ball.lift_scale, "per_bounce": {
                f.details["bounce"]: [f["lift_scale"].value, f["lift_scale"].stderr] for f in use}}
            ball = ball.with_(lift_scale=lp.value)
            fitted = _fit_all(tracks, ball, **common)
            heights = np.array([b.fit["z_c"].value for b in fitted if b.fit is not None])
            notes.append(f"lift scale estimated from the tracks: {lp.value:.3g} [{lp.interval[0]:.3g}, "
                         f"{lp.interval[1]:.3g}] times the published lift coefficient; the bounces are fitted with it")
        else:
            notes.append("the lift scale could not be estimated (fewer than two bounces with a known spin): the "
                         "published lift coefficient is used")
    plane = None
    normal = np.array([0.0, 0.0, 1.0])
    if contact is None:
        if heights.size == 0:
            reasons = sorted({b.reason for b in fitted})
            raise TrackAnalysisError("no bounce could be analysed" + (": " + "; ".join(reasons[:3]) if reasons else
                                                                      ": no minimum of the height with flight "
                                                                      "falling into it and rising out of it"))
        median = float(np.median(heights))
        points = np.array([[b.fit[k].value for k in ("x_c", "y_c", "z_c")] for b in fitted
                           if b.fit is not None and abs(b.fit["z_c"].value - median) <= SURFACE_BAND
                           and b.fit.model_check.get("action") != "withheld"]
                          or [[b.fit[k].value for k in ("x_c", "y_c", "z_c")] for b in fitted if b.fit is not None])
        slopes = 2 if all(t.dimensions == 3 for t in tracks) else 1
        plane = surface_plane(points, slopes=slopes, mode=surface)
        if plane.tilted:
            normal = plane.normal
            fitted = _fit_all(tracks, ball, normal=normal, **common)
        contact_est = plane.height
        spread = plane.rms
        surface_z = plane.height - ball.radius / normal[2]
        what = (f"a plane tilted by {1e3 * plane.tilt:.2g} mrad (slopes {1e3 * plane.slopes[0]:.2g} +- "
                f"{1e3 * plane.stderr[1]:.1g} mm/m along x, {1e3 * plane.slopes[1]:.2g} +- {1e3 * plane.stderr[2]:.1g} "
                "mm/m along y; its normal is the normal of e_n)" if plane.tilted else "horizontal")
        notes.append(f"surface estimated from {plane.points} fitted contact points: {what}; at the points' centroid "
                     f"{surface_z:.4g} m; the points scatter by {plane.rms * 1e3:.2g} mm about it")
    else:
        contact_est, surface_z, spread = contact, float(surface_height), math.nan
    # a bounce that is not on the surface (a hit elsewhere) breaks the chain of spins: the bounce after it
    # has its spin estimated, not carried through an impact of unknown geometry
    breaks = set()
    for b in fitted:
        if b.fit is None:
            continue
        i = b.cand.index
        here = contact_est if plane is None else plane.contact_height(b.track.position[i, 0], b.track.position[i, 1])
        if abs(float(b.track.height[i]) - here) > SURFACE_BAND:
            breaks.add(b.label)
    if any(b.label in breaks and any(o.track is b.track and o.cand.index > b.cand.index for o in fitted)
           for b in fitted):
        common["breaks"] = frozenset(breaks)
        fitted = _fit_all(tracks, ball, normal=normal, **common)
    frame = _surface_frame(normal)
    rows, analysed = [], []
    for b in fitted:
        if b.fit is None:
            rows.append(_row(b, "not analysed", b.reason))
            continue
        i = b.cand.index
        here = contact_est if plane is None else plane.contact_height(b.track.position[i, 0], b.track.position[i, 1])
        above = float(b.track.height[i]) - here
        reason = ""
        if abs(above) > SURFACE_BAND:
            reason = (f"its lowest sample is {abs(above):.3g} m {'above' if above > 0 else 'below'} the surface (more "
                      f"than {SURFACE_BAND:g} m): not a bounce on it")
        elif b.fit.model_check.get("action") == "withheld":
            findings = [f for c in b.fit.model_check.get("checks", ()) for f in c.get("findings", ())]
            reason = "the flights do not describe the track (model check: " + "; ".join(findings[:2]) + ")"
        elif not math.isfinite(b.fit["e_n"].stderr):
            reason = "the restitution is not determined by the fit"
        rows.append(_row(b, "analysed" if not reason else "not analysed", reason))
        if not reason:
            analysed.append(b)
    table = pd.DataFrame(rows)
    statistics = {"tracks": len(tracks), "bounces_found": len(fitted), "bounces_analysed": len(analysed),
                  "bounces_not_analysed": len(fitted) - len(analysed), "surface_height_m": surface_z,
                  "contact_height_scatter_m": spread, "criterion": criterion,
                  "surface_tilt_rad": plane.tilt if plane is not None else 0.0}
    if not analysed:
        reasons = sorted({r["reason"] for r in rows})
        raise TrackAnalysisError("no bounce could be analysed: " + "; ".join(reasons[:3]))
    params: list[Parameter] = []
    if plane is not None and plane.tilted:
        q = float(stats.t.ppf(0.5 + 0.5 * confidence, max(plane.points - 3, 1)))
        for k, axis in ((1, "x"), (2, "y")):
            if plane.stderr[k] > 0:
                v, se_k = plane.slopes[k - 1], plane.stderr[k]
                params.append(Parameter(f"surface.slope_{axis}", v, se_k, (v - q * se_k, v + q * se_k), confidence,
                                        False, "m/m", "rise of the fitted contact points' plane along " + axis))
    fits = [b.fit for b in analysed]
    labels = [b.label for b in analysed]
    speeds = np.array([f["vn_in"].value for f in fits])
    e = np.array([f["e_n"].value for f in fits])
    se = np.array([f["e_n"].stderr for f in fits])
    # the surface plane's share: a tilted plane's slopes are estimates, and e_n is read against their normal
    slopes_now = np.array(plane.slopes if plane is not None else (0.0, 0.0), dtype=float)
    tilted = plane is not None and plane.tilted
    slope_cov = np.array(plane.slope_covariance, dtype=float) if tilted else np.zeros((2, 2))
    carry = bool(np.any(slope_cov != 0.0))
    v_in_xyz = np.array([f.details["v_in"] for f in fits])
    v_out_xyz = np.array([f.details["v_out"] for f in fits])
    share = np.zeros(len(fits))
    if carry:
        grad = restitution_slope_gradient(v_in_xyz, v_out_xyz, slopes_now)
        share = np.sqrt(np.maximum(np.einsum("bi,ij,bj->b", grad, slope_cov, grad), 0.0))
    surface_e = {k: _with_share(f["e_n"], float(d)) for k, f, d in zip(labels, fits, share)}
    for k, d in zip(labels, share):
        row = table.index[table["bounce"] == k][0]
        p = surface_e[k]
        table.loc[row, "e_n_fit_stderr"] = table.loc[row, "e_n_stderr"]
        table.loc[row, "e_n_surface_stderr"] = float(d)
        table.loc[row, "e_n_stderr"], (table.loc[row, "e_n_low"], table.loc[row, "e_n_high"]) = p.stderr, p.interval
    surface_share: dict = {"carried": carry, "slope_covariance": slope_cov.tolist(),
                           "per_bounce_median": float(np.median(share)) if share.size else 0.0, "laws": {}}

    def with_surface(law: LawFit, inside: np.ndarray) -> LawFit:
        if not carry:
            return law
        shares = _law_surface_share(law, speeds[inside], v_in_xyz[inside], v_out_xyz[inside], se[inside], slopes_now,
                                    slope_cov, confidence)
        return replace(law, params=tuple(_with_share(p, shares[p.name]) for p in law.params),
                       extra={**law.extra, "surface_share": shares})

    everyone = np.ones(len(fits), dtype=bool)
    laws: dict[str, dict[str, LawFit]] = {"normal": {}, "tangential": {}}
    comparisons, selected, checks = {}, {}, []
    for name in NORMAL_LAWS:
        try:
            laws["normal"][name] = with_surface(fit_normal_law(name, speeds, e, se, confidence=confidence), everyone)
        except ValueError as exc:
            notes.append(f"normal law {name}: {exc}")
        else:
            surface_share["laws"][name] = laws["normal"][name].extra.get("surface_share", {})
    v_in = np.array([f.details["v_in"] for f in fits]) @ frame.T
    v_out = np.array([f.details["v_out"] for f in fits]) @ frame.T
    w_in = np.array([f.details["spin_in"] for f in fits]) @ frame.T
    dims = np.array([f.details["dimensions"] for f in fits])
    # the friction laws need the incoming spin: the bounces whose spin is unknown are left out of all the
    # tangential laws (so that they are compared on the same bounces), unless none is known
    spun = np.all(np.isfinite(w_in), axis=1)
    tangential_laws = dict(TANGENTIAL_LAWS)
    if not np.any(spun):
        spun = np.ones(len(fits), dtype=bool)
        tangential_laws = {"ratio": TANGENTIAL_LAWS["ratio"]}
        notes.append("no bounce has a known incoming spin: only the tangential ratio law is fitted (the Coulomb "
                     "and rolling laws need the spin)")
    elif not np.all(spun):
        notes.append(f"{int(np.sum(~spun))} of {len(fits)} bounces have an unknown incoming spin: they are left out "
                     "of the tangential laws (their beta_t is still reported)")
    statistics["bounces_in_tangential_laws"] = int(np.sum(spun))
    for name in tangential_laws:
        try:
            laws["tangential"][name] = fit_tangential_law(name, v_in[spun], v_out[spun], w_in[spun], ball.radius,
                                                          ball.inertia, dimensions=dims[spun], confidence=confidence)
        except ValueError as exc:
            notes.append(f"tangential law {name}: {exc}")
    for kind, fitted_laws in laws.items():
        if not fitted_laws:
            continue
        nested = [("constant", "linear")] if kind == "normal" and len(fitted_laws) == 2 else []
        chosen, block = select(list(fitted_laws.values()), criterion, nested=nested)
        comparisons[kind], selected[kind] = block, chosen
        checks.append(fitted_laws[chosen].check)
        for law in fitted_laws.values():
            params += [Parameter(f"{kind}.{law.name}.{p.name}", p.value, p.stderr, p.interval, p.confidence, p.fixed,
                                 p.unit, p.note, p.min, p.max) for p in law.params]
    band_fit, n_band = _band_fit(speeds, e, se, speed_band, confidence)
    in_band = [lab for lab, v in zip(labels, speeds) if speed_band[0] <= v <= speed_band[1]]
    band_param = None
    if band_fit is not None:
        band_fit = with_surface(band_fit, (speeds >= speed_band[0]) & (speeds <= speed_band[1]))
        band_share = band_fit.extra.get("surface_share", {}).get("e", 0.0)
        surface_share["e_n_speed_band"] = band_share
        p = band_fit["e"]
        band_param = Parameter("e_n_speed_band", p.value, p.stderr, p.interval, p.confidence, False, "",
                               f"constant law on the {n_band} bounces at {speed_band[0]:g}-{speed_band[1]:g} m/s; "
                               "statistical interval" + (f" with the surface plane's share {band_share:.2g}"
                                                         if band_share > 0 else "")
                               + " (the air model's share in e_n_speed_band_air)")
        params.append(band_param)
    else:
        notes.append(f"fewer than two bounces at {speed_band[0]:g}-{speed_band[1]:g} m/s: no restitution there")
    statistics["bounces_in_speed_band"] = n_band
    details = {"ball": ball.to_dict(), "lift_model": LIFT_MODEL, "spin": spin, "spin_side": spin_side,
               "surface_height_m": surface_z, "surface": "given" if surface_height is not None else "estimated",
               "surface_plane": plane.to_dict() if plane is not None else None, "normal": normal.tolist(),
               "speed_band": list(speed_band), "selected": selected, "law_comparison": comparisons,
               "laws": {kind: {name: {"params": [p.to_dict() for p in law.params], "rss": law.rss,
                                      "n_data": law.n_data, "extra": law.extra,
                                      "model_check": law.check.to_dict()} for name, law in fl.items()}
                        for kind, fl in laws.items()}}
    common_fixed = {**common, "normal": normal, "only": set(labels)}
    if lift is not None:
        params.append(lift)
        details["lift_estimate"] = lift_details
    if air_share:
        lift_from = ("given" if lift_range is not None else "the estimated lift scale's interval" if lift is not None
                     else "no lift to the nominal scale")
        if lift_range is None:
            lift_range = tuple(lift.interval) if lift is not None else (0.0, ball.lift_scale)
        lift_range = (max(float(lift_range[0]), 0.0), max(float(lift_range[1]), 0.0))
        variants = [("drag_coefficient", cd) for cd in DRAG_RANGE if cd != ball.drag_coefficient]
        variants += [("lift_scale", lam) for lam in lift_range if lam != ball.lift_scale]
        by_label = dict(zip(labels, fits))
        nominal_pool = _pooled(by_label, in_band, confidence)
        shifts: dict[str, dict[str, list[float]]] = {k: {"drag_coefficient": [], "lift_scale": []} for k in labels}
        pool_shifts: dict[str, list[float]] = {"drag_coefficient": [], "lift_scale": []}
        variant_rows = [{"drag_coefficient": ball.drag_coefficient, "lift_scale": ball.lift_scale,
                         "e_n": nominal_pool[0] if nominal_pool else math.nan,
                         "e_n_low": nominal_pool[1] if nominal_pool else math.nan,
                         "e_n_high": nominal_pool[2] if nominal_pool else math.nan, "bounces": n_band,
                         "residual_rms_m": float(np.median([f.statistics["residual_rms_m"] for f in fits]))}]
        for factor, value in variants:
            other = {b.label: b.fit for b in _fit_all(tracks, ball.with_(**{factor: value}), **common_fixed)}
            for k in labels:
                if other.get(k) is not None:
                    shifts[k][factor].append(other[k]["e_n"].value - by_label[k]["e_n"].value)
            common_band = [k for k in in_band if other.get(k) is not None]
            a = _pooled(by_label, common_band, confidence)
            b_ = _pooled(other, common_band, confidence)
            if a is not None and b_ is not None:
                pool_shifts[factor].append(b_[0] - a[0])
            v_ = b_ if b_ is not None else (math.nan, math.nan, math.nan)
            variant_rows.append({"drag_coefficient": ball.drag_coefficient, "lift_scale": ball.lift_scale,
                                 factor: value, "e_n": v_[0], "e_n_low": v_[1], "e_n_high": v_[2],
                                 "bounces": len(common_band),
                                 "residual_rms_m": float(np.median([f.statistics["residual_rms_m"]
                                                                    for f in other.values() if f is not None]))})
        new_fits = []
        for k, f in zip(labels, fits):
            lo_s, hi_s = _systematic(shifts[k])
            p = surface_e[k]
            air = Parameter("e_n_air", p.value, p.stderr, (p.interval[0] + lo_s, p.interval[1] + hi_s), p.confidence,
                            False, "", f"the statistical interval widened by the air model's share {lo_s:+.4f}/"
                                       f"{hi_s:+.4f} (C_D {DRAG_RANGE[0]:g}-{DRAG_RANGE[1]:g}, lift scale "
                                       f"{lift_range[0]:.3g}-{lift_range[1]:.3g})")
            new_fits.append(replace(f, params=tuple(f.params.values()) + (air,)))
            row = table.index[table["bounce"] == k][0]
            table.loc[row, "e_n_air_low"], table.loc[row, "e_n_air_high"] = air.interval
        fits = new_fits
        sys_lo, sys_hi = _systematic(pool_shifts)
        details["air_model"] = {"drag_range": list(DRAG_RANGE), "lift_range": list(lift_range),
                                "lift_range_from": lift_from,
                                "pooled_shifts": pool_shifts, "systematic": [sys_lo, sys_hi],
                                "variants": variant_rows}
        if band_param is not None:
            params.append(Parameter("e_n_speed_band_air", band_param.value, band_param.stderr,
                                    (band_param.interval[0] + sys_lo, band_param.interval[1] + sys_hi), confidence,
                                    False, "", f"e_n_speed_band's interval widened by the air model's share "
                                               f"{sys_lo:+.4f}/{sys_hi:+.4f} (C_D {DRAG_RANGE[0]:g}-{DRAG_RANGE[1]:g}"
                                               f", lift scale {lift_range[0]:.3g}-{lift_range[1]:.3g})"))
    fits = [replace(f, params=tuple(surface_e[k] if q.name == "e_n" else q for q in f.params.values()))
            for k, f in zip(labels, fits)]
    details["surface_share"] = surface_share
    details["bounce_fits"] = [f.to_dict() for f in fits]
    if rule:
        band = rule_band(ball)
        block = band.to_dict()
        if band_fit is not None:
            lo, hi = band_fit["e"].interval
            block["tracks_interval"] = [lo, hi]
            block["overlaps"] = bool(lo <= band.high and hi >= band.low)
            per = table[table["analysed"] & (table["vn_in_m_s"] >= speed_band[0]) &
                        (table["vn_in_m_s"] <= speed_band[1])]
            block["bounces_overlapping"] = int(np.sum((per["e_n_low"] <= band.high) & (per["e_n_high"] >= band.low)))
            block["bounces_in_band"] = int(len(per))
            if air_share:
                alo, ahi = (p for p in params if p.name == "e_n_speed_band_air").__next__().interval
                rlo, rhi = band.drag_range
                block["tracks_interval_air"] = [alo, ahi]
                block["overlaps_with_air_model"] = bool(alo <= rhi and ahi >= rlo)
                block["bounces_overlapping_air"] = int(np.sum((per["e_n_air_low"] <= rhi) &
                                                              (per["e_n_air_high"] >= rlo)))
        details["rule"] = block
    parts = {kind: {**laws[kind][selected[kind]].identifiability, "model_comparison": comparisons[kind]}
             for kind in selected if laws[kind][selected[kind]].identifiability}
    identifiability = {"parts": parts, "determined": bool(parts) and all(p.get("determined") for p in parts.values())}
    return TrackAnalysis(params=params, statistics=statistics, notes=tuple(notes), tables={"bounces": table},
                         details=details, model_check=combine_checks(checks), identifiability=identifiability,
                         provenance=tuple(f"read {t.source}" for t in tracks) + ("analyse_tracks",))


def air_model_share(result: TrackAnalysis) -> pd.DataFrame:
    """The air model's share of an analysis made with ``air_share=True``: one row per air model (the
    nominal first, then each coefficient at an end of its range): ``drag_coefficient``, ``lift_scale``,
    ``e_n``, ``e_n_low``, ``e_n_high`` (the constant law on the speed band's bounces), ``bounces``,
    ``residual_rms_m`` (median over the bounces), ``rule_low``, ``rule_high`` (the rule's band)."""
    block = result.details.get("air_model")
    if block is None:
        raise TrackAnalysisError("the analysis has no air model's share (analyse with air_share=True)")
    frame = pd.DataFrame(block["variants"])
    ball = result.details["ball"]
    rule = result.details.get("rule")
    lows, highs = [], []
    for cd in frame["drag_coefficient"]:
        if rule is None:
            lows.append(math.nan)
            highs.append(math.nan)
            continue
        band = rule_band(TrackedBall.from_mapping({**ball, "drag_coefficient": float(cd)}))
        lows.append(band.low)
        highs.append(band.high)
    return frame.assign(rule_low=lows, rule_high=highs)

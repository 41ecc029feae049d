"""Bounces in a ball track: where they are (:func:`find_bounces`) and what each one did
(:func:`fit_bounce`, a :class:`BounceFit`).

**Finding.** A bounce is an interior minimum of the height (the lowest sample within two on either
side) where the height falls before it and rises after it (the vertical speed over three samples
above :data:`MIN_VERTICAL_SPEED` on both sides: the noise of a flight's apex makes minima too, with
no such turn), with at least ``min_flight`` samples of flight on each side within ``window``
seconds (and before the next minimum). Whether it is on the surface is decided once the surface is
known (:func:`impactid.rigs.tracks.analysis.analyse_tracks`).

**Fitting.** The incoming and the outgoing flights are one least-squares fit through the
identification engine: both start at the contact, at the time ``t_c`` and the ball-centre position
``(x_c, y_c, z_c)``, the incoming flight with the velocity ``v_in`` (integrated backwards to the
samples before it), the outgoing with ``v_out`` (forwards); the contact lasts about a millisecond, a
seventh of a sample, and is taken as instantaneous. The flights follow
:mod:`~impactid.rigs.tracks.flight` (gravity, drag, Magnus); the incoming spin is given (the track's
measured spin), propagated (the previous bounce's outgoing spin, its covariance carried), estimated
(three more parameters, one in 2-D: the Magnus curvature of the flights) or unknown
(:data:`SPIN_SOURCES`), the outgoing spin follows from the tangential impulse by the balance of angular
momentum about the contact point, ``Delta omega = -(n x Delta v_t) / (k R)`` (``k = I / (m R^2)``,
``n`` the surface's unit normal, ``e_z`` unless a tilted surface is given), so that the change of
spin is seen through the change of the tangential velocity. ``z_c`` is free (the height where the
two flights meet) unless the surface is given. With ``fit_lift`` the lift scale of the ball's lift
model is an eleventh parameter (its interval from the same fit). The derived quantities, each with
an interval by the delta method on the fit's covariance: the normal restitution
``e_n = -(v_out . n) / (v_in . n)``, the tangential velocity ratio
``beta_t = (v_t,out . v_t,in) / |v_t,in|^2`` (``v_t = v - (v . n) n``), the contact point's tangential
velocity before and after (``u_t = v_t - R omega x n``) and the change of spin.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy import stats

from impactid.engine import (
    NO_NOISE_REFERENCE,
    Free,
    check_model,
    combine_checks,
    identifiability,
    search,
    uncertainty,
)
from impactid.results import FitResult, Parameter
from impactid.rigs.tracks.flight import MAX_STEP, flight_positions
from impactid.rigs.tracks.parameters import TrackedBall
from impactid.rigs.tracks.readers import Track

__all__ = ["MAX_SPIN", "MIN_FLIGHT", "MIN_VERTICAL_SPEED", "NOISE_REFERENCE", "OUTLIER_SIGMAS", "SPIN_SOURCES",
           "WINDOW", "BounceFit", "Candidate", "find_bounces", "fit_bounce", "spin_change", "tracking_noise"]

#: Fewest samples of flight on each side of a bounce.
MIN_FLIGHT = 5
#: The vertical speed that must fall in and rise out of a minimum for it to be a bounce [m/s].
MIN_VERTICAL_SPEED = 0.3
#: The flight fitted on each side of a bounce [s] (at most).
WINDOW = 0.12
#: A sample whose misfit exceeds this many robust standard deviations is dropped (once, at most two a side).
OUTLIER_SIGMAS = 5.0

#: Where the model check's noise comes from (:func:`tracking_noise`).
NOISE_REFERENCE = "the track's scatter about cubics through 15 samples of flight"

#: Where the incoming spin of a bounce comes from: ``given`` (the track's measured spin, for its first
#: bounce), ``propagated`` (the previous bounce's outgoing spin: its incoming spin changed by the angular
#: impulse of its friction, :func:`spin_change`), ``estimated`` (fitted from the curvature that the Magnus
#: force gives the flights) or ``unknown`` (none of these: the flights are fitted without Magnus force and
#: every quantity that needs the spin is left undetermined).
SPIN_SOURCES = ("given", "propagated", "estimated", "unknown")
#: Largest spin component an estimate may reach [rad/s].
MAX_SPIN = 2000.0

_NAMES = ("t_c", "x_c", "y_c", "z_c", "vin_x", "vin_y", "vin_z", "vout_x", "vout_y", "vout_z", "lift_scale",
          "win_x", "win_y", "win_z")
_STEPS = np.array([1e-6, 1e-6, 1e-6, 1e-6, 1e-5, 1e-5, 1e-5, 1e-5, 1e-5, 1e-5, 1e-4, 1e-2, 1e-2, 1e-2])
_UP = np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True)
class Candidate:
    """A bounce found in a track.

    Attributes
    ----------
    index : the sample of the minimum height.
    before, after : the samples of the incoming and outgoing flight within the window (the minimum
        not included).
    reason : why it cannot be analysed ("" when it can).
    """

    index: int
    before: np.ndarray
    after: np.ndarray
    reason: str = ""


def find_bounces(track: Track, *, min_flight: int = MIN_FLIGHT, window: float = WINDOW) -> list[Candidate]:
    """The bounces of a track (module doc); those without enough flight carry their ``reason``."""
    t, z = track.time, track.height
    n = t.size
    minima = []
    for i in range(1, n - 1):
        lo, hi = max(0, i - 2), min(n, i + 3)
        if z[i] > np.min(z[lo:hi]) or (i > 0 and z[i] == z[i - 1]):
            continue
        j0, j1 = max(0, i - 3), min(n - 1, i + 3)
        falling = (z[i] - z[j0]) / (t[i] - t[j0]) if j0 < i else 0.0
        rising = (z[j1] - z[i]) / (t[j1] - t[i]) if j1 > i else 0.0
        if falling < -MIN_VERTICAL_SPEED and rising > MIN_VERTICAL_SPEED:
            minima.append(i)
    out = []
    for k, i in enumerate(minima):
        first = minima[k - 1] + 1 if k > 0 else 0
        last = minima[k + 1] - 1 if k + 1 < len(minima) else n - 1
        before = np.arange(first, i)
        before = before[t[i] - t[before] <= window]
        after = np.arange(i + 1, last + 1)
        after = after[t[after] - t[i] <= window]
        reason = ""
        if before.size < min_flight or after.size < min_flight:
            side, count = ("before", before.size) if before.size < min_flight else ("after", after.size)
            reason = (f"only {count} samples of flight {side} the minimum at {t[i]:.4g} s "
                      f"(at least {min_flight} needed)")
        out.append(Candidate(index=i, before=before, after=after, reason=reason))
    return out


def tracking_noise(track: Track, candidates: list[Candidate] = (), span: int = 15) -> np.ndarray:
    """The tracking noise of a track in each axis [m], (3,): the median over windows of ``span`` samples
    of flight (none within three samples of a bounce) of the scatter about a cubic,
    ``sqrt(SS / (span - 4))``. A cubic follows a flight of 0.1 s to a few micrometres (drag and Magnus
    bend a parabola by the third power of time, the fourth-order term is below 1e-5 m); what is left
    is the noise, including the error of the time stamps times the speed (which is why the axis of
    the fast horizontal flight is noisier). NaN where the track has no such window (and for the
    ``y`` of a 2-D track)."""
    t, p = track.time, track.position
    axes = [0, 1, 2] if track.dimensions == 3 else [0, 2]
    near = np.zeros(t.size, dtype=bool)
    for c in candidates:
        near[max(0, c.index - 3):c.index + 4] = True
    values: dict[int, list[float]] = {a: [] for a in axes}
    for k in range(0, t.size - span + 1, max(1, span // 3)):
        if near[k:k + span].any():
            continue
        tt = t[k:k + span] - t[k + span // 2]
        for a in axes:
            coef = np.polyfit(tt, p[k:k + span, a], 3)
            r = p[k:k + span, a] - np.polyval(coef, tt)
            values[a].append(math.sqrt(float(r @ r) / (span - 4)))
    out = np.full(3, math.nan)
    for a in axes:
        if values[a]:
            out[a] = float(np.median(values[a]))
    return out


def spin_change(dv_t: np.ndarray, ball: TrackedBall, normal: np.ndarray = _UP) -> np.ndarray:
    """The change of spin [rad/s] (..., 3) that a tangential velocity change ``dv_t`` (..., 3) [m/s] of a
    rigid ball on a surface of unit ``normal`` (default ``e_z``) implies: ``-(n x dv_t) / (k R)``."""
    dv_t = np.asarray(dv_t, dtype=float)
    n = np.broadcast_to(np.asarray(normal, dtype=float), dv_t.shape)
    return -np.cross(n, dv_t) / (ball.inertia * ball.radius)


class BounceFit(FitResult):
    """One bounce: the contact, the velocities before and after, and what they imply.

    Parameters ``t_c`` [s], ``x_c``, ``y_c``, ``z_c`` [m], ``vin_x`` ... ``vout_z`` [m/s] (fitted);
    ``e_n``, ``beta_t``, ``speed_in`` [m/s], ``vn_in`` [m/s], ``ut_in``, ``ut_out`` [m/s] (the contact
    point's tangential speed), ``dspin_x``, ``dspin_y`` [rad/s] (derived, delta-method intervals).
    ``details``: the track, the sample of the minimum, the samples used, the incoming spin, the
    vectors ``v_in``, ``v_out``, ``spin_in``, ``spin_out`` and the covariance of ``v_in, v_out``.
    """

    kind = "tracked-ball-bounce"
    title = "bounce of a tracked ball"

    @property
    def e_n(self) -> Parameter:
        return self.params["e_n"]


def _start(track: Track, cand: Candidate, dims: int):
    """Start values from a parabola on each side: contact time, position, velocities; and which side
    the minimum's sample falls on."""
    t, p = track.time, track.position
    sides = []
    for idx in (cand.before[-6:], cand.after[:6]):
        tt = t[idx]
        ref = tt.mean()
        coef = [np.polyfit(tt - ref, p[idx, a], 2 if a == 2 else 1) for a in range(3)]
        sides.append((ref, coef))
    (r1, c1), (r2, c2) = sides
    # the time where the two height parabolas cross, between the last sample before and the first after
    grid = np.linspace(t[cand.before[-1]], t[cand.after[0]], 201)
    gap = np.polyval(c1[2], grid - r1) - np.polyval(c2[2], grid - r2)
    tc = float(grid[np.argmin(np.abs(gap))])
    pos = [0.5 * (np.polyval(c1[a], tc - r1) + np.polyval(c2[a], tc - r2)) for a in range(3)]
    vin = [np.polyval(np.polyder(c1[a]), tc - r1) for a in range(3)]
    vout = [np.polyval(np.polyder(c2[a]), tc - r2) for a in range(3)]
    if dims == 2:
        pos[1] = vin[1] = vout[1] = 0.0
    return tc, pos, vin, vout


def fit_bounce(track: Track, cand: Candidate, ball: TrackedBall, *, contact_height: float | None = None,
               spin: bool = True, confidence: float = 0.95, bounce_id: str = "",
               noise: np.ndarray | None = None, spin_side: str = "in", normal: np.ndarray | None = None,
               fit_lift: bool = False, spin_source: str | None = None, spin_in: np.ndarray | None = None,
               spin_in_covariance: np.ndarray | None = None) -> BounceFit:
    """Fit the two flights of one bounce (module doc).

    Parameters
    ----------
    track, cand : the track and the bounce (:func:`find_bounces`).
    ball : the ball and its air model.
    contact_height : the height of the ball's centre at contact [m] (the surface plus the radius);
        None: fitted (where the flights meet).
    spin : whether the Magnus force of the spin acts on the flights.
    confidence : coverage of the intervals.
    spin_side : which flight a ``given`` spin belongs to: ``"in"`` (measured before the bounce; the
        outgoing spin follows from the impulse) or ``"out"`` (measured after it; the incoming spin
        follows from the impulse). Other sources are always the incoming spin.
    bounce_id : a label for the tables.
    noise : the track's tracking noise in each axis [m] (:func:`tracking_noise`): the weights of the
        positions and the model check's reference; None (or NaN): equal weights, no reference.
    normal : the surface's normal (3,) (normalised here; None: ``e_z``): the direction of ``e_n``.
    fit_lift : whether the lift scale is fitted (from ``ball.lift_scale``; needs a given spin).
    spin_source : where the incoming spin comes from (:data:`SPIN_SOURCES`); None: ``given`` when the
        track has a spin, else ``estimated`` when the Magnus force acts, else ``unknown``.
    spin_in : the spin [rad/s] (3,) of a ``given`` (None: the track's) or ``propagated`` source, or the
        start of an ``estimated`` one (None: 0).
    spin_in_covariance : (3, 3) the covariance of a ``propagated`` ``spin_in`` [rad^2/s^2] (None: 0);
        it is added to the intervals of every quantity that depends on the incoming spin.

    Returns
    -------
    BounceFit

    Raises
    ------
    ValueError
        when the flights do not meet as a bounce (the fitted vertical velocities do not reverse).
    """
    dims = track.dimensions
    axes = [0, 1, 2] if dims == 3 else [0, 2]
    t, p = track.time, track.position
    tc0, pos0, vin0, vout0 = _start(track, cand, dims)
    i = cand.index
    before = list(cand.before) + ([i] if t[i] < tc0 else [])
    after = ([i] if t[i] >= tc0 else []) + list(cand.after)
    if spin_side not in ("in", "out"):
        raise ValueError(f"spin_side must be 'in' or 'out', got {spin_side!r}")
    if spin_source is None:
        spin_source = "given" if track.spin is not None else "estimated" if spin else "unknown"
    if spin_source not in SPIN_SOURCES:
        raise ValueError(f"spin_source must be one of {', '.join(SPIN_SOURCES)}, got {spin_source!r}")
    if spin_source == "given" and spin_in is None and track.spin is None:
        raise ValueError("a given spin needs the track's spin or spin_in")
    if spin_source == "propagated" and spin_in is None:
        raise ValueError("a propagated spin needs spin_in")
    if spin_source == "estimated" and not spin:
        spin_source = "unknown"  # without the Magnus force the flights carry no trace of the spin
    side = spin_side if spin_source == "given" else "in"
    known = np.asarray(spin_in if spin_in is not None else track.spin if spin_source == "given" else (0.0, 0.0, 0.0),
                       dtype=float)
    w_given = known if spin_source in ("given", "propagated") else np.zeros(3)
    w_prior_cov = (np.zeros((3, 3)) if spin_in_covariance is None or spin_source != "propagated"
                   else np.asarray(spin_in_covariance, dtype=float))
    estimate = spin_source == "estimated"
    flight_ball = ball if spin else ball.with_(lift_scale=0.0)
    n_hat = _UP if normal is None else np.asarray(normal, dtype=float) / float(np.linalg.norm(normal))
    if dims == 2 and abs(n_hat[1]) > 0.0:
        raise ValueError("the surface normal of a 2-D track must lie in its x-z plane")
    fit_lift = bool(fit_lift and spin and spin_source == "given")
    notes = []
    if spin_source == "unknown":
        notes.append("the incoming spin is unknown (not given, not propagated from a previous bounce"
                     + (", and the flights have no Magnus force to estimate it from" if not spin else "")
                     + "): the flights are fitted without it, and the contact point's slip and the spins are "
                       "left undetermined")
    elif spin_source == "estimated":
        notes.append("the incoming spin is estimated from the flights (the curvature of the Magnus force, "
                     f"lift scale {flight_ball.lift_scale:.3g}); its error scales with the lift model's")
    elif spin_source == "propagated":
        notes.append("the incoming spin is the previous bounce's outgoing spin (its incoming spin changed by "
                     "the angular impulse of its friction), constant in flight")
    n_base = 11 if fit_lift else 10
    spin_axes = ([1] if dims == 2 else [0, 1, 2]) if estimate else []

    def model(u: np.ndarray, b_idx: np.ndarray, a_idx: np.ndarray) -> np.ndarray:
        u = np.atleast_2d(u)
        tc, pc, vin, vout = u[:, 0], u[:, 1:4], u[:, 4:7], u[:, 7:10]
        lam = u[:, 10] if fit_lift else None
        dv = vout - vin
        dv = dv - (dv @ n_hat)[:, None] * n_hat[None, :]
        change = spin_change(dv, ball, n_hat)
        if estimate:
            w0 = u[:, n_base:n_base + 3]
        else:
            w0 = np.broadcast_to(w_given[None, :], change.shape)
        w_before = w0 + (0.0 if side == "in" else -change)
        w_after = w0 + (change if side == "in" else 0.0)
        if spin_source == "unknown":
            w_before = w_after = np.zeros_like(change)
        tb = t[b_idx][::-1]
        pb = flight_positions(pc, vin, tc, tb, flight_ball, w_before, MAX_STEP, lam)[:, ::-1, :]
        pa = flight_positions(pc, vout, tc, t[a_idx], flight_ball, w_after, MAX_STEP, lam)
        pred = np.concatenate([pb, pa], axis=1)[:, :, axes]
        return pred.reshape(u.shape[0], -1)

    sigma = np.ones(len(axes))
    has_noise = noise is not None and bool(np.all(np.isfinite(np.asarray(noise)[axes]) & (np.asarray(noise)[axes] > 0)))
    if has_noise:
        sigma = np.asarray(noise, dtype=float)[axes]
    steps_all = np.r_[_STEPS[:10], _STEPS[10:11] if fit_lift else [], _STEPS[11:14] if estimate else []]

    def run(b_idx, a_idx, start):
        data = p[np.r_[b_idx, a_idx]][:, axes].ravel()
        weight = np.tile(1.0 / sigma, b_idx.size + a_idx.size)
        free = [Free("t_c", start[0], start[0] - 0.05, start[0] + 0.05, unit="s"),
                Free("x_c", start[1], unit="m"), Free("y_c", start[2], unit="m", vary=dims == 3),
                Free("z_c", start[3] if contact_height is None else contact_height, unit="m",
                     vary=contact_height is None)]
        free += [Free(n, v, -60.0, 60.0, unit="m/s", vary=dims == 3 or not n.endswith("_y"))
                 for n, v in zip(_NAMES[4:10], start[4:10])]
        if fit_lift:
            free.append(Free("lift_scale", start[10], -5.0, 10.0))
        if estimate:
            free += [Free(n, start[n_base + k] if k in spin_axes else 0.0, -MAX_SPIN, MAX_SPIN, unit="rad/s",
                          vary=k in spin_axes) for k, n in enumerate(_NAMES[11:14])]
        jfree = np.array([f.vary for f in free])

        def residual(u):
            return (model(u, b_idx, a_idx)[0] - data) * weight

        def jacobian(u):
            steps = np.where(jfree, steps_all, 0.0)
            batch = np.vstack([u[None, :], u[None, :] + np.diag(steps)[jfree], u[None, :] - np.diag(steps)[jfree]])
            out = model(batch, b_idx, a_idx)
            k = int(jfree.sum())
            jac = np.zeros((out.shape[1], len(free)))
            jac[:, jfree] = ((out[1:1 + k] - out[1 + k:]) / (2.0 * steps[jfree][:, None])).T
            return jac * weight[:, None]

        found = search(residual, free, jacobian=jacobian, max_nfev=200, normalise=False, x_scale=1.0)
        return found, free, data

    start = ([tc0, *pos0, *vin0, *vout0] + ([ball.lift_scale] if fit_lift else [])
             + (list(known) if estimate else []))
    b_idx, a_idx = np.asarray(before, dtype=int), np.asarray(after, dtype=int)
    found, free, data = run(b_idx, a_idx, start)
    # outliers: samples far from the fit, by the residual's robust scatter (at most two a side, once)
    r = found.residual.reshape(-1, len(axes))
    size = np.sqrt(np.sum(r * r, axis=1))
    spread = 1.4826 * np.median(np.abs(r)) + 1e-12
    far = np.flatnonzero(size > OUTLIER_SIGMAS * spread * math.sqrt(len(axes)))
    nb = b_idx.size
    drop_b = [k for k in far if k < nb][:2]
    drop_a = [k - nb for k in far if k >= nb][:2]
    if (drop_b or drop_a) and nb - len(drop_b) >= MIN_FLIGHT and a_idx.size - len(drop_a) >= MIN_FLIGHT:
        dropped = [float(t[b_idx[k]]) for k in drop_b] + [float(t[a_idx[k]]) for k in drop_a]
        b_idx, a_idx = np.delete(b_idx, drop_b), np.delete(a_idx, drop_a)
        found, free, data = run(b_idx, a_idx, list(found.values().values()))
        notes.append(f"{len(dropped)} sample(s) more than {OUTLIER_SIGMAS:g} robust standard deviations off the "
                     f"flights dropped (at {', '.join(f'{x:.4g}' for x in dropped)} s)")
    values = found.values()
    if not (values["vin_x"] * n_hat[0] + values["vin_y"] * n_hat[1] + values["vin_z"] * n_hat[2] < 0.0
            < values["vout_x"] * n_hat[0] + values["vout_y"] * n_hat[1] + values["vout_z"] * n_hat[2]):
        raise ValueError(f"the fitted flights do not meet as a bounce (vertical velocity {values['vin_z']:.3g} "
                         f"m/s in, {values['vout_z']:.3g} m/s out)")
    dof = max(found.residual.size - int(sum(f.vary for f in free)), 1)
    # with the noise known, the covariance is scaled by the reduced chi-square only where it exceeds 1
    fit = uncertainty(found, confidence=confidence,
                      scale=max(1.0, 2.0 * found.cost / dof) if has_noise else None)
    groups = np.repeat([0] * b_idx.size + [1] * a_idx.size, len(axes))
    sd = np.tile(sigma, b_idx.size + a_idx.size)
    check = check_model(found.residual * sd, sd if has_noise else None,
                        noise_reference=NOISE_REFERENCE if has_noise else NO_NOISE_REFERENCE, what="track positions",
                        unit="m", n_params=len(fit.names), groups=groups, order=True,
                        **({"assumed_over_noise": math.sqrt(fit.scale)} if has_noise else {}))
    params = check.widen(fit.parameters)
    # derived quantities by the delta method on the covariance (widened as the parameters were), with
    # the covariance of a propagated incoming spin added for those that depend on it
    names = list(fit.names)
    cov = np.array(fit.covariance.matrix, dtype=float) * (check.inflation ** 2 if check.action == "widened" else 1.0)
    if check.action == "withheld":
        cov = np.full_like(cov, np.nan)
    x = np.array([values[n] for n in names])
    q = float(stats.t.ppf(0.5 + 0.5 * confidence, max(fit.dof, 1)))

    def vec(xx, ww):
        d = dict(values)
        d.update(zip(names, xx))
        d["w_prior"] = ww
        return d

    def jacobian_of(fun) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The value of ``fun`` (a vector) and its derivatives by the fitted values and the prior spin."""
        v0 = np.atleast_1d(np.asarray(fun(vec(x, w_given)), dtype=float))
        gx = np.zeros((v0.size, x.size))
        gw = np.zeros((v0.size, 3))
        for k in range(x.size):
            h = 1e-6 * max(1.0, abs(x[k]))
            e = np.zeros(x.size)
            e[k] = h
            gx[:, k] = (np.atleast_1d(fun(vec(x + e, w_given))) - np.atleast_1d(fun(vec(x - e, w_given)))) / (2 * h)
        if spin_source == "propagated":
            for k in range(3):
                e = np.zeros(3)
                e[k] = 1e-3
                gw[:, k] = (np.atleast_1d(fun(vec(x, w_given + e))) - np.atleast_1d(fun(vec(x, w_given - e)))) / 2e-3
        return v0, gx, gw

    def derived_covariance(fun) -> tuple[np.ndarray, np.ndarray]:
        v0, gx, gw = jacobian_of(fun)
        return v0, gx @ cov @ gx.T + gw @ w_prior_cov @ gw.T

    def derived(fun) -> tuple[float, float]:
        v0, c = derived_covariance(fun)
        var = float(c[0, 0])
        return float(v0[0]), math.sqrt(var) if math.isfinite(var) and var >= 0 else math.nan

    def along(v):
        return float(v @ n_hat)

    def vin(d):
        return np.array([d["vin_x"], d["vin_y"], d["vin_z"]])

    def vout(d):
        return np.array([d["vout_x"], d["vout_y"], d["vout_z"]])

    def tangential(v):
        return v - along(v) * n_hat

    def u_t(v, w):  # contact point's tangential velocity v_t - R (w x n)
        return tangential(v) - ball.radius * np.cross(w, n_hat)

    def change(d):
        return spin_change((tangential(vout(d)) - tangential(vin(d)))[None, :], ball, n_hat)[0]

    def w_in_of(d):
        if spin_source == "unknown":
            return np.full(3, math.nan)
        if estimate:
            return np.array([d["win_x"], d["win_y"], d["win_z"]])
        return d["w_prior"] if side == "in" else d["w_prior"] - change(d)

    def w_out(d):
        if spin_source == "unknown":
            return np.full(3, math.nan)
        if estimate:
            return w_in_of(d) + change(d)
        return d["w_prior"] + change(d) if side == "in" else d["w_prior"]

    def beta(d):
        a, b = tangential(vin(d)), tangential(vout(d))
        return float(a @ b / (a @ a)) if a @ a > 0 else math.nan

    quantities = {
        "e_n": (lambda d: -along(vout(d)) / along(vin(d)), ""),
        "beta_t": (beta, ""),
        "speed_in": (lambda d: float(np.linalg.norm(vin(d))), "m/s"),
        "vn_in": (lambda d: -along(vin(d)), "m/s"),
        "vt_in": (lambda d: float(np.linalg.norm(tangential(vin(d)))), "m/s"),
        "ut_in": (lambda d: float(np.linalg.norm(u_t(vin(d), w_in_of(d)))), "m/s"),
        "ut_out": (lambda d: float(np.linalg.norm(u_t(vout(d), w_out(d)))), "m/s"),
        "dspin_x": (lambda d: float(change(d)[0]), "rad/s"),
        "dspin_y": (lambda d: float(change(d)[1]), "rad/s"),
    }
    for k, axis in enumerate("xyz"):
        quantities[f"spin_in_{axis}"] = (lambda d, k=k: float(w_in_of(d)[k]), "rad/s")
        quantities[f"spin_out_{axis}"] = (lambda d, k=k: float(w_out(d)[k]), "rad/s")
    if dims == 2:
        for name in ("dspin_x", "spin_in_x", "spin_in_z", "spin_out_x", "spin_out_z"):
            quantities.pop(name)
    spin_dependent = {"ut_in", "ut_out"} | {n for n in quantities if n.startswith("spin_")}
    for name, (fun, unit) in quantities.items():
        value, se = derived(fun)
        if name in spin_dependent and spin_source == "unknown":
            note = "the incoming spin is unknown"
        elif math.isfinite(se):
            note = (f"spin {spin_source}" if name.startswith("spin_") else "")
        else:
            note = "withheld by the model check" if check.action == "withheld" else "undetermined"
        params += (Parameter(name, value, se, (value - q * se, value + q * se), confidence, False, unit, note),)
    ids = [names.index(n) for n in ("vin_x", "vin_y", "vin_z", "vout_x", "vout_y", "vout_z") if n in names]
    block = identifiability(found, fit, names=[n for n in names], describes_data=check.describes_data)
    residual_rms = float(np.sqrt(np.mean((found.residual * sd) ** 2)))
    stats_ = {**fit.statistics, "samples_before": int(b_idx.size), "samples_after": int(a_idx.size),
              "residual_rms_m": residual_rms, "tracking_noise_m": [float(v) for v in noise] if has_noise else None}
    w_in_value, w_in_cov = derived_covariance(w_in_of)
    w_out_value, w_out_cov = derived_covariance(w_out)
    details = {"track": track.source, "bounce": bounce_id, "index": int(cand.index),
               "samples": [int(k) for k in np.r_[b_idx, a_idx]], "spin_known": spin_source != "unknown",
               "spin_source": spin_source, "spin_side": side, "spin_in": w_in_value.tolist(),
               "spin_out": w_out_value.tolist(), "spin_in_covariance": w_in_cov.tolist(),
               "spin_out_covariance": w_out_cov.tolist(), "v_in": vin(values).tolist(),
               "v_out": vout(values).tolist(), "dimensions": dims,
               "velocity_names": [names[k] for k in ids],
               "velocity_covariance": cov[np.ix_(ids, ids)].tolist(),
               "ball": flight_ball.to_dict(), "normal": n_hat.tolist(),
               "air_model": {"drag_coefficient": ball.drag_coefficient,
                             "lift_scale": values["lift_scale"] if fit_lift else flight_ball.lift_scale,
                             "lift_scale_fitted": fit_lift, "air_density": ball.air_density}}
    return BounceFit(params=params, statistics=stats_, notes=tuple(notes) + fit.notes + check.further_notes,
                     details=details, model_check=combine_checks([check]), identifiability=block,
                     provenance=(f"fit_bounce({track.source}, sample {cand.index})",))


def with_label(fit: BounceFit, label: str) -> BounceFit:
    """The fit with its ``details.bounce`` label set."""
    return replace(fit, details={**fit.details, "bounce": label})

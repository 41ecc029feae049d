"""Identification of the valve spring's surge, the preload and the moving mass from recordings.

Kushwaha, Rahnejat & Jin (2000) identify nothing; these fits are impactid's extension for users with
measurements. Given one or more recordings of the cycloidal-cam valve train at known camshaft speeds
(each with a ``cam_angle`` channel for the phase), :func:`fit_surge` fits

* ``f0`` [Hz], the first surge frequency of the valve spring (both ends clamped), and ``c_spring``
  [N s/m], the damper of the two-mass surge model (reported also as the first-mode damping ratio
  ``zeta1``, computed by :func:`impactid.rigs.valvespring.damper_damping_ratio`, the one function that
  computes it: ``3 pi c f0 / (8 k0)``);
* ``f_p`` [N], the preload, and ``m3`` [kg], the moving mass (valve, follower, retainer);
* optionally ``k0`` [N/m], the spring rate (fixed at the rig file's value by default: a static
  measurement of the spring gives it far better than a dynamic fit).

Two measurement models, chosen by the channel:

``contact_load`` -> level A (the paper's adherent model)
    ``W = m3 omega^2 s'' + f_p + k_s1 (s - y5) + c (omega s' - y5')`` (R-40'). The load is linear in
    ``m3`` and ``f_p``; these are solved by linear least squares inside the nonlinear fit of ``f0``,
    ``c_spring`` (and ``k0``) (variable projection). The surge frequency shows as the ripple on the
    base circle after closing; ``m3`` multiplies the kinematic acceleration, ``f_p`` is the offset.
    Samples where the measured load is not positive (the valve left the cam) are excluded: the adherent
    model does not describe them.

``valve_displacement`` -> level B (valve released)
    Below the jump speed the valve follows the lift less the Hertz approach (about 1 um), so the
    displacement's deviation from the nominal lift is a load measurement in micrometres: this fit
    needs a sensor resolving a few nanometres and a lift known to that accuracy (a cam profile error
    biases it). Above the jump speed the separation and the seat bounce add information. All
    parameters enter nonlinearly; each evaluation is a level-B steady cycle. The fit is refused when
    the displacement's noise hides the whole load-dependent part of the motion.

Refusals: a recording whose cam speed lies outside the rig's
:attr:`~impactid.rigs.cycloidal.parameters.CycloidalEHLRig.speed_range`, a channel that is
non-finite, constant or zero, shorter than a revolution, or (after the fit) explained no better by
the model than by noise alone (:func:`impactid.rigs.valvespring.check_model_explains`) is refused
with an :class:`IdentificationError` naming the file and the channel or attribute.

Search, uncertainty and model check come from the identification engine (:mod:`impactid.engine`):
the search is :func:`~impactid.engine.search` (within bounds; for level A over ``f0``, ``c_spring``
(``k0``) with ``f_p`` and ``m3`` projected out, for level B over every parameter); the uncertainty is
:func:`~impactid.engine.uncertainty` of the full parameter vector at the optimum (``J`` by central
differences of the model, ``s^2`` the residual variance, the shared covariance rule, Student-t
intervals at ``confidence``, bound hits), each interval cut at the parameter's physical lower bound.
It assumes white noise and a correct model; a parameter whose interval is wider than its value is
reported as not determined. The model check is :func:`~impactid.engine.residual_against_noise`:
each recording's residual against its own noise, measured from the first differences of the
residual (the noise is white, the misfit of a model smooth; at least :data:`NOISE_FLOOR` of the
channel's range, the simulator's accuracy). The engine's whole check
(:func:`impactid.engine.check_model`) adds the residual's persistence along each recording (a smooth
misfit, ``n_eff``) and widens or withholds every fitted interval (``zeta1``'s with them) by its rule
where it finds the model wanting. The identifiability block (:func:`impactid.engine.identifiability`)
has quadratic profiles: a refit point costs a whole fit of periodic steady states. The EHL regression
constants (1.67, 0.059, 0.541, 0.421, 96.775) are not identifiable from dynamic signals (the film does
not enter the dynamics) and stay fixed.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import ClassVar

import numpy as np
import pandas as pd
from scipy import stats

from impactid.engine import (
    Free,
    Search,
    check_model,
    combine_checks,
    identifiability,
    residual_against_noise,
    search,
    uncertainty,
)
from impactid.errors import ImpactidError
from impactid.results import FitResult, Parameter
from impactid.rigs.cycloidal import cam
from impactid.rigs.cycloidal.contact import hertz_load
from impactid.rigs.cycloidal.parameters import CycloidalEHLRig
from impactid.rigs.cycloidal.simulate import (
    DEFAULT_TOLERANCES,
    Tolerances,
    level_a_periodic_state,
    level_a_run,
    level_b_run,
    level_b_steady_cycle,
    omega_of,
)
from impactid.rigs.valvespring import check_fit_channel, check_model_explains, damper_damping_ratio

__all__ = ["CHANNEL_MODELS", "NOISE_FLOOR", "IdentificationError", "SurgeFit", "fit_surge"]

TWO_PI = 2.0 * math.pi
#: Which level models which channel.
CHANNEL_MODELS = {"contact_load": "A", "valve_displacement": "B"}
_UNITS = {"f0": "Hz", "c_spring": "N s/m", "f_p": "N", "m3": "kg", "k0": "N/m", "zeta1": ""}
_BOUNDS = {"f0": (20.0, 20_000.0), "c_spring": (0.0, 1e3), "f_p": (0.0, 1e5), "m3": (1e-4, 1e2), "k0": (10.0, 1e8)}
#: The noise of the model check is at least this fraction of the channel's range: the simulator's
#: accuracy (a noise-free recording is compared with it).
NOISE_FLOOR = 1e-9


class IdentificationError(ImpactidError, ValueError):
    """A recording cannot identify the surge parameters (wrong rig, no phase, no information)."""


@dataclass(frozen=True)
class SurgeFit(FitResult):
    """Result of :func:`fit_surge`: ``f0``, ``c_spring``, ``zeta1``, ``f_p``, ``m3`` (and ``k0``)."""

    kind: ClassVar[str] = "valvetrain-surge-fit"
    title: ClassVar[str] = "valve-spring surge, preload and moving mass (cycloidal-flat-follower-ehl)"

    def plot(self, **kwargs):
        """Measured channel and fitted model against cam angle, per recording, with the residuals."""
        from impactid.rigs.cycloidal.figures import surge_fit_figure

        return surge_fit_figure(self, **kwargs)


@dataclass
class _Data:
    source: str
    rig: CycloidalEHLRig
    rpm: float
    psi: np.ndarray  # cam angle of each sample [rad]
    y: np.ndarray  # measured channel
    grid: np.ndarray  # sorted phase times [s] in [0, T)
    order: np.ndarray  # sample index of each grid point
    x0: np.ndarray | None = None  # level-B warm start


def _prepare(recordings, channel: str | None, rig: CycloidalEHLRig | None) -> tuple[list[_Data], str, list[str]]:
    notes = []
    if not recordings:
        raise IdentificationError("no recording given")
    chosen = channel
    data = []
    for rec in recordings:
        where = rec.source or "recording"
        the_rig = rig if rig is not None else rec.rig
        if not isinstance(the_rig, CycloidalEHLRig):
            got = getattr(the_rig, "model", None)
            raise IdentificationError(f"{where}: needs a 'cycloidal-flat-follower-ehl' rig (the recording's rig is "
                                      f"{got!r}; pass a rig file)")
        if chosen is None:
            chosen = next((c for c in CHANNEL_MODELS if c in rec.channels), None)
            if chosen is None:
                raise IdentificationError(f"{where}: has neither a contact_load nor a valve_displacement channel "
                                          f"(it has {', '.join(rec.channels)})")
        if chosen not in CHANNEL_MODELS:
            raise IdentificationError(f"unknown channel {chosen!r}; the surge fit reads {', '.join(CHANNEL_MODELS)}")
        if chosen not in rec.channels:
            raise IdentificationError(f"{where}: no channel {chosen!r} (it has {', '.join(rec.channels)})")
        if "cam_angle" not in rec.channels:
            raise IdentificationError(f"{where}: the surge fit needs a cam_angle channel to know the cam's phase")
        psi = np.asarray(rec.channel("cam_angle"), dtype=float)
        hz = rec.cam_speed_hz
        if hz is None:
            hz = rec.encoder_speed_hz("cam_angle")
            rpm = the_rig.speed_range.check(60.0 * hz, f"{where}: the cam speed of the encoder (channel 'cam_angle'; "
                                                       "no operating cam_speed_hz)", IdentificationError)
            notes.append(f"{where}: no operating cam_speed_hz; the cam speed {rpm:.6g} rpm is the encoder's")
        else:
            rpm = the_rig.speed_range.check(60.0 * hz, f"{where}: operating cam_speed_hz = {hz:.6g} Hz",
                                            IdentificationError)
        y = np.asarray(rec.channel(chosen), dtype=float)
        unit = "N" if chosen == "contact_load" else "m"
        check_fit_channel(y, psi, where=where, channel=chosen, unit=unit, error=IdentificationError)
        keep = np.ones(y.size, dtype=bool)
        if chosen == "contact_load":
            keep = y > 0.0
            if not keep.any():
                raise IdentificationError(f"{where}: channel 'contact_load' has no positive sample (the largest is "
                                          f"{float(y.max()):.6g} N): the follower never presses on the cam, and the "
                                          "adherent model (level A) describes nothing of it")
            if not keep.all():
                notes.append(f"{where}: {int((~keep).sum())} samples with a load <= 0 (the valve left the cam) are "
                             "excluded: the adherent model (level A) does not describe them")
                check_fit_channel(y[keep], psi[keep], where=where, channel=chosen, unit=unit,
                                  error=IdentificationError, min_revolutions=0.0)
        psi, y = psi[keep], y[keep]
        data.append(_Data(where, the_rig, rpm, psi, y, *_phase(psi, rpm)))
    return data, chosen, notes


def _rig_with(rig: CycloidalEHLRig, theta: dict) -> CycloidalEHLRig:
    return rig.replace(**{k: float(v) for k, v in theta.items() if k in ("f0", "c_spring", "k0", "f_p", "m3")})


def _level_a_parts(d: _Data, theta: dict, tol: Tolerances):
    """Surge part ``k_s1 (s - y5) + c (omega s' - y5')`` and inertia regressor ``omega^2 s''`` at the samples."""
    rig = _rig_with(d.rig, theta)
    w = omega_of(d.rpm)
    z0, _ = level_a_periodic_state(rig, d.rpm, tol)
    _, Z = level_a_run(rig, d.rpm, z0, 0.0, TWO_PI / w, grid=d.grid, tol=tol)
    y5 = np.empty(d.psi.size)
    v5 = np.empty(d.psi.size)
    y5[d.order], v5[d.order] = Z[:, 0], Z[:, 1]
    s, s1, s2, _ = cam.lift(d.psi, rig.S, rig.beta)
    return rig.k_s1 * (s - y5) + rig.c_spring * (w * s1 - v5), w**2 * s2


def _level_b_model(d: _Data, theta: dict, tol: Tolerances, conv_tol: float):
    rig = _rig_with(d.rig, theta)
    cyc = level_b_steady_cycle(rig, d.rpm, tol, conv_tol=conv_tol, max_rev=200, x0=d.x0)
    if not cyc.converged:
        raise IdentificationError(f"{d.source}: the level-B model has no periodic steady state at {d.rpm:g} rpm with "
                                  f"{theta}; record at a speed with a periodic motion")
    d.x0 = cyc.x0
    _, _, X, _, _, _ = level_b_run(rig, d.rpm, cyc.x0, 0.0, cyc.T, mode0=cyc.mode0, grid=d.grid, tol=tol)
    out = np.empty(d.psi.size)
    out[d.order] = X[:, 0]
    return out


def _interval(value, se, q, lo_bound):
    if not (math.isfinite(se) and math.isfinite(value)):
        return (math.nan, math.nan)
    return (max(value - q * se, lo_bound), value + q * se)


def _phase(psi, rpm):
    phase = np.mod(psi, TWO_PI) / omega_of(rpm)
    order = np.argsort(phase, kind="stable")
    return phase[order], order


def _fit_level_a(data, nonlinear, base, tol, scan_f0, full=False):
    """Variable-projection fit of the level-A load model: ``f0``, ``c_spring`` (``k0``) nonlinear,
    ``f_p`` and ``m3`` by linear least squares. Returns the values (and the residual and solution)."""

    def project(theta_vec):
        theta = dict(zip(nonlinear, theta_vec))
        cols, rhs = [], []
        for d in data:
            G, a = _level_a_parts(d, theta, tol)
            cols.append(np.column_stack([np.ones(d.y.size), a]))
            rhs.append(d.y - G)
        A = np.vstack(cols)
        b = np.concatenate(rhs)
        beta, *_ = np.linalg.lstsq(A, b, rcond=None)
        return b - A @ beta, beta

    def residual(theta_vec):
        return project(theta_vec)[0]

    x0 = np.array([getattr(base, k) for k in nonlinear], dtype=float)
    if scan_f0:
        f_grid = base.f0 * np.geomspace(0.5, 2.0, 41)
        costs = []
        for f in f_grid:
            trial = x0.copy()
            trial[0] = f
            costs.append(float(np.sum(residual(trial) ** 2)))
        x0[0] = f_grid[int(np.argmin(costs))]
    lo = np.array([_BOUNDS[k][0] for k in nonlinear])
    hi = np.array([_BOUNDS[k][1] for k in nonlinear])
    x0 = np.clip(x0, lo * (1 + 1e-9) + 1e-12, hi * (1 - 1e-9))
    free = [Free(k, float(v), *_BOUNDS[k], unit=_UNITS[k]) for k, v in zip(nonlinear, x0)]
    found = search(residual, free, diff_step=1e-6, max_nfev=400)
    r, beta = project(found.x)
    values = dict(zip(nonlinear, (float(v) for v in found.x)))
    values.update(f_p=float(beta[0]), m3=float(beta[1]))
    return (values, r, found) if full else values


def _zeta_parameter(values: dict, k0_fixed: float, cov: np.ndarray, names: list, q: float,
                    confidence: float) -> Parameter:
    """The first surge mode's damping ratio ``zeta1`` of the fitted damper, by
    :func:`~impactid.rigs.valvespring.damper_damping_ratio` (the one function that computes it), with
    its standard error by the delta method (the gradient by central differences of that function)."""
    point = {"c_spring": values["c_spring"], "f0": values["f0"], "k0": values.get("k0", k0_fixed)}

    def zeta_of(p: dict) -> float:
        return damper_damping_ratio(p["k0"], p["f0"], p["c_spring"])

    zeta = zeta_of(point)
    grad = np.zeros(len(names))
    for name in ("c_spring", "f0", "k0"):
        if name not in names:
            continue
        step = 1e-6 * max(abs(point[name]), 1e-9)
        up, down = dict(point), dict(point)
        up[name] += step
        down[name] = max(point[name] - step, 0.0)  # the damper may sit at its bound 0
        grad[names.index(name)] = (zeta_of(up) - zeta_of(down)) / (up[name] - down[name])
    se = float(math.sqrt(max(grad @ cov @ grad, 0.0))) if np.all(np.isfinite(cov)) else math.nan
    return Parameter("zeta1", zeta, se, _interval(zeta, se, q, 0.0), confidence, False, "",
                     "first surge mode's damping ratio, derived from c_spring, f0 and k0")


def fit_surge(recordings, *, channel: str | None = None, rig: CycloidalEHLRig | None = None, free_k0: bool = False,
              confidence: float = 0.95, tol: Tolerances = DEFAULT_TOLERANCES, scan_f0: bool = True,
              conv_tol: float = 1e-12) -> SurgeFit:
    """Fit the surge frequency and damping, the preload and the moving mass to recordings.

    Parameters
    ----------
    recordings : a :class:`~impactid.io.Recording` or a sequence of them (a joint fit), each with a
        ``cam_angle`` channel, the measured channel and a cam speed (operating point or encoder).
    channel : ``"contact_load"`` (level-A model) or ``"valve_displacement"`` (level-B model); by
        default the first of these the first recording has.
    rig : the rig whose other parameters are held fixed (default: each recording's own); its ``f0``,
        ``c_spring``, ``f_p``, ``m3`` are the starting values.
    free_k0 : also fit the spring rate ``k0``.
    confidence : coverage of the reported intervals.
    scan_f0 : start the contact-load fit from the best ``f0`` of a scan over 0.5 to 2 times the rig's
        (an oscillatory model has a local minimum at every wrong alias of the ripple).
    conv_tol : level-B steady-state tolerance inside the displacement fit (tight, so that finite
        differences see the parameters, not the run-in).

    Returns
    -------
    :class:`SurgeFit`
    """
    if not isinstance(recordings, Sequence):
        recordings = [recordings]
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must lie in (0, 1), got {confidence!r}")
    data, chosen, notes = _prepare(list(recordings), channel, rig)
    level = CHANNEL_MODELS[chosen]
    base = data[0].rig
    nonlinear = ["f0", "c_spring"] + (["k0"] if free_k0 else [])
    n_total = sum(d.y.size for d in data)
    if level == "A":
        names = nonlinear + ["f_p", "m3"]
        values, r, found = _fit_level_a(data, nonlinear, base, tol, scan_f0, full=True)

        def model_all(vals):
            theta = {k: vals[k] for k in nonlinear}
            out = []
            for d in data:
                G, a = _level_a_parts(d, theta, tol)
                out.append(G + vals["f_p"] + vals["m3"] * a)
            return np.concatenate(out)

    else:
        names = nonlinear + ["f_p", "m3"]
        # information check: the load-dependent part of the displacement (the Hertz approach and any
        # separation) against the noise left after removing the model at the starting values
        start = {k: getattr(base, k) for k in names}
        pred0 = np.concatenate([_level_b_model(d, start, tol, conv_tol) for d in data])
        y_all = np.concatenate([d.y for d in data])
        lift_all = np.concatenate([cam.lift(d.psi, d.rig.S, d.rig.beta)[0] for d in data])
        load_part = float(np.ptp(pred0 - lift_all))
        # noise from first differences of the residual (the model removes the signal)
        noise = float(np.std(np.diff(y_all - pred0)) / math.sqrt(2.0))
        if noise > 0.5 * load_part:
            raise IdentificationError(
                f"the valve displacement's noise ({noise * 1e9:.3g} nm) is comparable with the whole load-dependent "
                f"part of the valve motion ({load_part * 1e9:.3g} nm: the Hertz approach, and any jump or bounce): "
                "the surge, the preload and the mass cannot be identified from it. Record the contact load, use a "
                "displacement sensor resolving a few nm, or record above the jump speed")
        # starting values: the load the displacement implies (Hertz approach inverted, plus the seat's
        # static reaction), fitted with the fast level-A model (variable projection, f0 scan); the
        # level-B model has a local minimum at every wrong phase of the contact ringing
        derived = []
        for d in data:
            s = cam.lift(d.psi, d.rig.S, d.rig.beta)[0]
            Rc = d.rig.R0 + s + cam.lift(d.psi, d.rig.S, d.rig.beta)[2]
            W = hertz_load(np.maximum(s - d.rig.g_lash - d.y, 0.0), Rc, d.rig.sigma, d.rig.L_c)
            W = W + np.where(d.y < 0.0, -d.rig.K_se * d.y, 0.0)
            derived.append(_Data(d.source, d.rig, d.rpm, d.psi, W, d.grid, d.order))
        keep_all = [dd.y > 0.0 for dd in derived]
        derived = [_Data(dd.source, dd.rig, dd.rpm, dd.psi[k], dd.y[k], *_phase(dd.psi[k], dd.rpm))
                   for dd, k in zip(derived, keep_all)]
        first = _fit_level_a(derived, nonlinear, base, tol, scan_f0)
        start = {k: first[k] for k in names}
        notes.append("starting values from a level-A fit of the load implied by the displacement: "
                     + ", ".join(f"{k} = {start[k]:.5g}" for k in names))
        res0 = y_all - np.concatenate([_level_b_model(d, start, tol, conv_tol) for d in data])
        r_scale = max(float(np.sqrt(np.mean(res0**2))), 1e-15)  # residuals of order 1 for the solver's tolerances

        def residual(u):
            theta = dict(zip(names, u))
            return np.concatenate([d.y - _level_b_model(d, theta, tol, conv_tol) for d in data]) / r_scale

        # the engine searches in coordinates divided by the start values (as this fit always did),
        # with unit steps in them (x_scale 1)
        u0 = {k: min(max(start[k], _BOUNDS[k][0] * (1 + 1e-9)), _BOUNDS[k][1] * (1 - 1e-9)) for k in names}
        free = [Free(k, float(u0[k]), *_BOUNDS[k], unit=_UNITS[k]) for k in names]
        found = search(residual, free, x_scale=1.0, xtol=1e-10, ftol=1e-10, gtol=1e-10, diff_step=1e-4,
                       max_nfev=200)
        values = found.values()
        r = found.residual * r_scale

        def model_all(vals):
            return np.concatenate([_level_b_model(d, vals, tol, conv_tol) for d in data])
    # ---- does the model explain more of the channel than noise would? (a constant is the null model) ----
    y_fitted = np.concatenate([d.y for d in data])
    check_model_explains(float(np.sum((y_fitted - y_fitted.mean()) ** 2)), float(np.sum(r**2)), n_total,
                         len(names) - 1, where=", ".join(dict.fromkeys(d.source for d in data)), channel=chosen,
                         error=IdentificationError)
    # ---- the engine's uncertainty of the full parameter vector (J by central differences) ----
    p = len(names)
    J = np.empty((n_total, p))
    rel = 1e-5 if level == "A" else 1e-3
    for j, k in enumerate(names):
        step = rel * max(abs(values[k]), 1e-12)
        plus = dict(values)
        minus = dict(values)
        plus[k] += step
        minus[k] -= step
        J[:, j] = (model_all(plus) - model_all(minus)) / (2.0 * step)
    # level A's f_p and m3 are solved by linear least squares, unbounded
    bounds = {k: (_BOUNDS[k] if level == "B" or k in nonlinear else (-math.inf, math.inf)) for k in names}
    full = Search(free=tuple(Free(k, float(values[k]), *bounds[k], unit=_UNITS[k]) for k in names),
                  x=np.array([values[k] for k in names], dtype=float), residual=r, jacobian=-J,
                  cost=float(0.5 * r @ r), nfev=found.nfev, success=found.success, message=found.message)
    if n_total <= p:
        raise IdentificationError(f"{n_total} samples cannot determine {p} parameters")
    fit = uncertainty(full, confidence=confidence)
    notes.extend(fit.notes)
    cov, cond, s2 = fit.covariance.matrix, fit.statistics["condition_number"], fit.scale
    params = []
    for par in fit.parameters:
        lo, hi = par.interval
        note = par.note
        if not math.isfinite(par.stderr) or par.stderr > abs(par.value):
            note = "not determined by these data (interval wider than the value)"
        # cut at the physical lower bound (a damper, a preload and a mass are not negative)
        params.append(replace(par, interval=(max(lo, _BOUNDS[par.name][0]), hi) if math.isfinite(lo) else (lo, hi),
                              note=note))
    # ---- the model check: each recording's residual against its own noise ----
    noise = []
    offset = 0
    for d in data:
        res = r[offset:offset + d.y.size]
        offset += d.y.size
        floor = NOISE_FLOOR * float(np.ptp(d.y))
        noise.append(np.full(d.y.size, max(float(np.std(np.diff(res))) / math.sqrt(2.0), floor)))
    check, check_notes = residual_against_noise(r, np.concatenate(noise), what=chosen,
                                                unit="N" if chosen == "contact_load" else "m")
    notes.extend(check_notes)
    checked = check_model(r, np.concatenate(noise), noise_reference=f"the residual's first differences over sqrt 2 "
                          f"(white noise; a smooth misfit cancels), at least {NOISE_FLOOR:g} of the channel's range",
                          what=chosen, unit="N" if chosen == "contact_load" else "m", n_params=p,
                          groups=np.concatenate([np.full(d.y.size, k) for k, d in enumerate(data)]),
                          assumed_sd=math.sqrt(s2) if math.isfinite(s2) else None)
    notes.extend(checked.further_notes)
    if not free_k0:
        params.append(Parameter("k0", float(base.k0), 0.0, (base.k0, base.k0), confidence, True, "N/m",
                                "fixed at the rig file's spring rate"))
    q = float(stats.t.ppf(0.5 + 0.5 * confidence, fit.dof))
    params.append(_zeta_parameter(values, base.k0, cov, names, q, confidence))
    params = list(checked.widen(params))
    notes.append("the EHL regression constants are not identified: the film does not enter the dynamics")
    if level == "B":
        notes.append("level-B fit of the valve displacement: it assumes the nominal lift exactly; a cam profile error "
                     "of the order of the Hertz approach (1 um) biases every parameter")
    rows = []
    start = 0
    fitted = model_all(values)
    curves = []
    for d in data:
        n = d.y.size
        res = r[start:start + n]
        rows.append({"source": d.source, "rpm": d.rpm, "samples": n, "rms_residual": float(np.sqrt(np.mean(res**2)))})
        # a per-degree binned curve for the figure
        deg = np.degrees(np.mod(d.psi, TWO_PI))
        bins = np.clip(deg.astype(int), 0, 359)
        meas = np.bincount(bins, d.y, 360) / np.maximum(np.bincount(bins, minlength=360), 1)
        mod = np.bincount(bins, fitted[start:start + n], 360) / np.maximum(np.bincount(bins, minlength=360), 1)
        curves.append({"source": d.source, "rpm": d.rpm, "angle_deg": (np.arange(360) + 0.5).tolist(),
                       "measured": meas.tolist(), "model": mod.tolist()})
        start += n
    stats_ = {"channel": chosen, "model": f"level {level}", "ndata": n_total, "nvarys": p, "nfev": int(found.nfev),
              "residual_rms": float(np.sqrt(np.mean(r**2))), "residual_sd": math.sqrt(s2) if math.isfinite(s2) else s2,
              "condition_number": cond, "success": bool(found.success), "dof": fit.dof,
              "noise_sd": check["noise_sd"], "residual_over_noise": check["residual_over_noise"]}
    return SurgeFit(params=params, statistics=stats_, notes=tuple(notes),
                    tables={"recordings": pd.DataFrame(rows)},
                    details={"curves": curves, "unit": "N" if chosen == "contact_load" else "m",
                             "free_k0": free_k0, "covariance": cov.tolist(), "names": names},
                    provenance=tuple(f"fit_surge: {d.source} at {d.rpm:g} rpm ({d.y.size} samples of {chosen})"
                                     for d in data),
                    model_check=combine_checks([checked]),
                    identifiability=identifiability(full, fit, describes_data=checked.describes_data,
                                                    quadratic_reason="a refit point costs a whole fit of periodic "
                                                    "steady states"))

"""Identification of the Hunt–Crossley contact (``k``, ``beta``, ``n``) from drop recordings.

:func:`fit_drop` fits the measured contact signals, the accelerometer (``F/m``) and/or the load cell
(``F``), sample by sample in a window around each impact (:mod:`impactid.rigs.drop.measure`), to
the same impacts replayed by the compiled simulator from their onset states
(:func:`~impactid.rigs.drop.simulate.replay_impacts`), by nonlinear least squares
(the identification engine's :func:`impactid.engine.search`: trust-region reflective within bounds,
coordinates scaled by their start magnitudes, several starts) over

* ``ln k``, ``ln beta`` and ``n`` (``n`` optionally fixed), shared by every impact;
* per impact, its onset time (the measured onset is only known to a fraction of a sample, and a
  pulse shifted by a tenth of a sample already leaves a residual of a few percent of its peak) and,
  by default, its onset speed (the measured one is a starting value: the drop height's speed for
  the first impact, the flight time's for the others); ``speeds="measured"`` holds the speeds.

The Jacobian is analytic: the kernel integrates the forward sensitivities ``d(x, v)/d(ln k, ln beta,
n, v0)`` with the state, which give ``dF/dtheta`` at every sample; the derivative with respect to
an onset time is ``-dF/dt``. Residuals are weighted by each channel's noise standard deviation
measured between impacts (at least :data:`~impactid.rigs.drop.measure.NOISE_FLOOR` of its peak),
so that the two channels combine and the reduced chi-square compares the residual with the noise.

The rig's mass, gravity and stiffness exponent ``p`` are taken as known; its ``k`` is **never**
read: the starting stiffness comes from the measured contact durations through Hertz's closed form
(:func:`~impactid.rigs.drop.parameters.stiffness_from_contact_time`), the starting damping from the
measured restitution, and the fit starts from several damping indices (:data:`N_STARTS`) and keeps
the best.

Uncertainty (:func:`impactid.engine.uncertainty`): the covariance of every fitted parameter (the
nuisances included) from the weighted residuals' Jacobian at the optimum by the shared rule of
:func:`impactid.engine.covariance.covariance_from_jacobian`, scaled by the residual variance (the reduced
chi-square): a residual larger than the noise (a lack of fit) widens the intervals by the same
factor. Intervals are Student-t intervals on ``ln k``, ``ln beta`` and ``n`` (mapped to ``k`` and
``beta``, hence asymmetric); a parameter on a bound of the search is reported. Model check
(:func:`impactid.engine.residual_against_noise`): the residual of each channel against its noise
between impacts (each recording's residual divided by its own noise); above
:data:`LACK_OF_FIT_FACTOR` times the noise the notes report a lack of fit, and a smaller but
statistically significant excess (a mean square above ``1 + max(3 sqrt(2/m), 0.02)`` times the
noise's for ``m`` samples) is reported as a systematic misfit below the noise level. Beyond that
the engine's whole check (:func:`impactid.engine.check_model`) looks at the residual's structure: its
persistence within each impact's window (a smooth misfit: the effective number of independent
samples ``n_eff``) and, with :data:`~impactid.engine.checks.MIN_STRUCTURE_DATA` impacts or more, a
trend of each impact's amplitude misfit (``sum r m / sum m^2``) with its approach speed. When the
model does not describe the data the intervals of ``k``, ``beta`` and ``n`` are widened by the
engine's rule (``x sqrt(n / n_eff)`` beyond the misfit's variance already in the covariance) or,
for a structured residual more than :data:`~impactid.engine.GROSS_LACK_OF_FIT` times the noise,
withheld: a wrong model can give intervals that miss the truth however they are widened
(``docs/drop.md`` shows one).

Identifiability (:func:`impactid.engine.identifiability`): condition number, correlations of ``k``,
``beta``, ``n``, bounds, quadratic profiles (a refit replays every impact about 30 times per point),
and with ``n`` fitted the law with ``n`` held at :data:`N_COMPARED` (Hunt and Crossley's) compared
with it by AIC, BIC and the likelihood-ratio test (one refit).
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import pandas as pd

from impactid.engine import (
    LACK_OF_FIT_FACTOR,
    SIGNIFICANT_EXCESS_FLOOR,
    SIGNIFICANT_EXCESS_SIGMAS,
    Free,
    check_model,
    combine_checks,
    compare_models,
    governing_check,
    identifiability,
    residual_against_noise,
    search,
    uncertainty,
)
from impactid.errors import ImpactidError
from impactid.results import FitResult, Parameter
from impactid.rigs.drop.measure import NOISE_FLOOR, ImpactObservations, measure_impacts
from impactid.rigs.drop.parameters import (
    ACCELERATION_CHANNEL,
    FORCE_CHANNEL,
    N_BOUNDS,
    N_MAX,
    DropLaw,
    DropRig,
    hertz_max_penetration,
    stiffness_from_contact_time,
)
from impactid.rigs.drop.simulate import Tolerances, replay_impacts

__all__ = ["DROP_NOISE", "FIT_TOLERANCES", "LACK_OF_FIT_FACTOR", "N_BOUNDS", "N_COMPARED", "N_STARTS",
           "SIGNIFICANT_EXCESS_FLOOR",
           "SIGNIFICANT_EXCESS_SIGMAS", "DropFit", "IdentificationError", "fit_drop"]

# LACK_OF_FIT_FACTOR, SIGNIFICANT_EXCESS_SIGMAS and SIGNIFICANT_EXCESS_FLOOR are the engine's
# (impactid.engine), re-exported: the model check is impactid.engine.residual_against_noise.
#: Damping indices the fit starts from (the best end point is kept).
N_STARTS = (1.0, 1.5, 2.0)
#: The damping index the fitted one is compared with (Hunt and Crossley's ``n = p`` for Hertz's ``p = 1.5``).
N_COMPARED = 1.5
#: The noise reference of the model check.
DROP_NOISE = ("each channel between impacts (each recording's own, at least "
              "impactid.rigs.drop.measure.NOISE_FLOOR of its peak)")
#: The stiffness is searched within this factor of its Hertz starting value, the damping within
#: this factor of its starting values at the ends of :data:`N_BOUNDS`.
K_RANGE = 100.0
BETA_RANGE = 1e3
#: Onset times are searched within this many samples of the measured ones; onset speeds within
#: this factor of the measured ones.
ONSET_SHIFT_SAMPLES = 5.0
SPEED_RANGE = (0.7, 1.3)
#: Integration settings of the fit's replays.
FIT_TOLERANCES = Tolerances(rtol=1e-10, atol_x=1e-15, atol_v=1e-11)
_SCALES = {ACCELERATION_CHANNEL: "mass", FORCE_CHANNEL: "one"}
_UNITS = {ACCELERATION_CHANNEL: "m/s^2", FORCE_CHANNEL: "N"}


class IdentificationError(ImpactidError, ValueError):
    """Drop recordings that cannot identify the contact (wrong rig, no impact, bad option)."""


@dataclass(frozen=True)
class DropFit(FitResult):
    """Result of :func:`fit_drop`: ``k`` [N/m^p], ``beta`` [N s/m^(n+1)], ``n`` [-] (and the fixed ``p``)."""

    kind: ClassVar[str] = "drop-impact-fit"
    title: ClassVar[str] = "Hunt-Crossley contact (k, beta, n) from drop impacts (drop-impact)"

    @property
    def law(self) -> DropLaw:
        """The fitted damping as a :class:`~impactid.rigs.drop.parameters.DropLaw`."""
        return DropLaw(beta=self.value("beta"), n=self.value("n"))

    def plot(self, **kwargs):
        """Measured and simulated contact signals of a few impacts, with the residuals."""
        from impactid.rigs.drop.figures import fit_figure

        return fit_figure(self, **kwargs)


@dataclass
class _Impact:
    """One impact's data in the fit."""

    source: str
    index: int
    rig: DropRig
    t: np.ndarray  # sample times [s]
    y: dict  # channel -> measured samples
    sigma: dict  # channel -> noise weight (standard deviation) [SI]
    noise: dict  # channel -> measured noise standard deviation [SI]
    onset: float
    speed: float
    speed_from: str
    row: dict


def _observations(recordings, rig, max_impacts, snr_min) -> list[ImpactObservations]:
    from impactid.io import read_recording

    if isinstance(recordings, (str, os.PathLike, ImpactObservations)) or hasattr(recordings, "channels"):
        recordings = [recordings]
    recordings = list(recordings)
    if not recordings:
        raise IdentificationError("no recording given")
    out = []
    for rec in recordings:
        if isinstance(rec, ImpactObservations):
            out.append(rec)
            continue
        if isinstance(rec, (str, os.PathLike)):
            rec = read_recording(rec, rig=rig)
        out.append(measure_impacts(rec, rig=rig, max_impacts=max_impacts, snr_min=snr_min))
    return out


def fit_drop(recordings, *, fix_n: float | None = None, channels: Sequence[str] | None = None,
             max_impacts: int | None = 4, speeds: str = "fit", confidence: float = 0.95, rig: DropRig | None = None,
             n_starts: Sequence[float] = N_STARTS, snr_min: float = 20.0,
             tol: Tolerances = FIT_TOLERANCES) -> DropFit:
    """Fit ``k``, ``beta`` and ``n`` of the Hunt–Crossley contact to drop recordings.

    Parameters
    ----------
    recordings : a :class:`~impactid.io.Recording`, a recording's path, an
        :class:`~impactid.rigs.drop.measure.ImpactObservations`, or a sequence of them (a joint fit:
        the same contact, drops from several heights, possibly different impactors).
    fix_n : fix the damping index ``n`` (e.g. 1.5) instead of fitting it.
    channels : the signals fitted (``impactor_acceleration``, ``contact_force``); default every one
        of them that each recording has.
    max_impacts : impacts used per recording, the first ones (None: all that are measured).
    speeds : ``"fit"`` (default): the onset speeds are fitted with the contact; ``"measured"``: held
        at the measured values (the drop height's and the flight times').
    confidence : coverage of the intervals.
    rig : the drop rig (default: each recording's); its mass, gravity and ``p`` are used, never its ``k``.
    n_starts : damping indices the fit starts from (ignored with ``fix_n``).
    snr_min : impacts whose peak is below this many noise standard deviations are left out.
    tol : integration settings of the replays.

    Returns
    -------
    :class:`DropFit`

    Raises
    ------
    IdentificationError
        for a bad option, recordings of different stiffness exponents, a channel a recording lacks;
        :class:`~impactid.rigs.drop.measure.MeasurementError` when a recording has no usable impact.
    """
    if speeds not in ("fit", "measured"):
        raise IdentificationError(f"speeds must be 'fit' or 'measured', got {speeds!r}")
    if not (isinstance(confidence, (int, float)) and 0.0 < confidence < 1.0):
        raise IdentificationError(f"confidence must lie in (0, 1), got {confidence!r}")
    if fix_n is not None and not (isinstance(fix_n, (int, float)) and 0.0 <= fix_n <= N_MAX):
        raise IdentificationError(f"fix_n must be a damping index in [0, {N_MAX:g}], got {fix_n!r}")
    if max_impacts is not None and (int(max_impacts) != max_impacts or max_impacts < 1):
        raise IdentificationError(f"max_impacts must be a positive integer or None, got {max_impacts!r}")
    starts = [float(fix_n)] if fix_n is not None else [float(s) for s in n_starts]
    if not starts or any(not N_BOUNDS[0] <= s <= N_BOUNDS[1] for s in starts if fix_n is None):
        raise IdentificationError(f"n_starts must lie in {N_BOUNDS}, got {list(n_starts)!r}")
    observations = _observations(recordings, rig, max_impacts, snr_min)
    notes: list[str] = []
    impacts: list[_Impact] = []
    p_values = {o.rig.p for o in observations}
    if len(p_values) > 1:
        raise IdentificationError(f"the recordings' rigs have different stiffness exponents p ({sorted(p_values)}): "
                                  "one contact law cannot describe them")
    p = p_values.pop()
    for obs in observations:
        notes.extend(obs.notes)
        used = list(obs.channels) if channels is None else list(channels)
        missing = [c for c in used if c not in obs.signals]
        if missing or not used:
            raise IdentificationError(f"{obs.source}: no channel {', '.join(missing) or '(none asked)'} to fit (it has "
                                      f"{', '.join(obs.channels)})")
        for _, row in obs.impacts.iterrows():
            a, b = int(row["window_start"]), int(row["window_stop"])
            impacts.append(_Impact(
                source=obs.source, index=int(row["impact"]), rig=obs.rig, t=obs.time(a, b),
                y={c: obs.signals[c][a:b] for c in used}, sigma={c: obs.noise_weight(c) for c in used},
                noise={c: obs.noise[c] for c in used}, onset=float(row["onset_time_s"]),
                speed=float(row["approach_speed_m_s"]), speed_from=str(row["approach_speed_from"]),
                row=row.to_dict()))
    all_channels = list(dict.fromkeys(c for imp in impacts for c in imp.y))
    n_imp = len(impacts)
    fit_n = fix_n is None
    free_speeds = speeds == "fit"
    # every parameter in the engine's order (the index n and the speeds are held when not fitted)
    n_law = 3
    names = ["k", "beta", "n"] + [f"t0_{j}" for j in range(n_imp)] + [f"v0_{j}" for j in range(n_imp)]
    # ---- starting values from the measured durations and restitution (Hertz; never the rig's k) ----
    masses = np.array([imp.rig.mass for imp in impacts])
    v_meas = np.array([imp.speed for imp in impacts])
    t0_meas = np.array([imp.onset for imp in impacts])
    durations = np.array([imp.row["contact_duration_s"] for imp in impacts])
    restitution = np.array([imp.row["restitution"] for imp in impacts])
    k_each = stiffness_from_contact_time(masses, p, v_meas, durations)
    k0 = float(np.median(k_each[np.isfinite(k_each) & (k_each > 0)])) if np.any(np.isfinite(k_each)) else math.nan
    if not (math.isfinite(k0) and k0 > 0.0):
        raise IdentificationError("the measured contact durations give no starting stiffness (are the impacts "
                                  "resolved by the sample rate?)")
    e_med = float(np.clip(np.nanmedian(restitution), 0.05, 0.99)) if np.any(np.isfinite(restitution)) else 0.8
    v_med = float(np.median(v_meas))
    m_med = float(np.median(masses))
    slope = 1.5 * (1.0 - e_med) / v_med  # Hunt & Crossley: e ~ 1 - (2/3) (beta/k) v for n = p
    delta_max = hertz_max_penetration(m_med, k0, p, v_med)

    def beta_start(n_value: float) -> float:
        return k0 * slope * delta_max ** (p - n_value)

    ln_beta_lo = min(math.log(beta_start(N_BOUNDS[0])), math.log(beta_start(N_BOUNDS[1])), math.log(beta_start(
        starts[0]))) - math.log(BETA_RANGE)
    ln_beta_hi = max(math.log(beta_start(N_BOUNDS[0])), math.log(beta_start(N_BOUNDS[1])), math.log(beta_start(
        starts[0]))) + math.log(BETA_RANGE)
    dt = np.array([1.0 / _rate(imp) for imp in impacts])
    free = [Free("k", k0, k0 / K_RANGE, k0 * K_RANGE, unit=f"N/m^{p:g}", log=True),
            Free("beta", beta_start(starts[0]), math.exp(ln_beta_lo), math.exp(ln_beta_hi), unit="N s/m^(n+1)",
                 log=True),
            Free("n", starts[0], *(N_BOUNDS if fit_n else (0.0, N_MAX)), vary=fit_n)]
    free += [Free(f"t0_{j}", float(t0_meas[j]), float(t0_meas[j] - ONSET_SHIFT_SAMPLES * dt[j]),
                  float(t0_meas[j] + ONSET_SHIFT_SAMPLES * dt[j]), unit="s", report=False) for j in range(n_imp)]
    free += [Free(f"v0_{j}", float(v_meas[j]), float(SPEED_RANGE[0] * v_meas[j]), float(SPEED_RANGE[1] * v_meas[j]),
                  vary=free_speeds, unit="m/s", report=False) for j in range(n_imp)]
    n_varying = sum(f.vary for f in free)
    # ---- the model: replays grouped by impactor (mass, gravity) ----
    groups: dict[tuple[float, float], list[int]] = {}
    for j, imp in enumerate(impacts):
        groups.setdefault((imp.rig.mass, imp.rig.gravity), []).append(j)
    blocks = []  # (impact j, channel, start, stop) of the residual vector
    start = 0
    for j, imp in enumerate(impacts):
        for c in imp.y:
            blocks.append((j, c, start, start + imp.t.size))
            start += imp.t.size
    n_data = start
    y_all = np.concatenate([impacts[j].y[c] for j, c, _, _ in blocks])
    w_all = np.concatenate([np.full(impacts[j].t.size, 1.0 / impacts[j].sigma[c]) for j, c, _, _ in blocks])
    if n_data <= n_varying:
        raise IdentificationError(f"{n_data} samples for {n_varying} parameters: too few to fit")

    def unpack(u):
        """k, beta, n, onset times and speeds from the engine's coordinates (ln k, ln beta, n, t0, v0)."""
        return (math.exp(u[0]), math.exp(u[1]), float(u[2]), u[n_law:n_law + n_imp],
                u[n_law + n_imp:n_law + 2 * n_imp])

    def model(u, jacobian: bool):
        k, beta, n_value, t0, v0 = unpack(u)
        law = DropLaw(beta=beta, n=n_value)
        force = [None] * n_imp
        rate = [None] * n_imp
        dforce = [None] * n_imp
        for (mass, gravity), members in groups.items():
            rig_g = DropRig(mass=mass, k=k, p=p, gravity=gravity)
            rep = replay_impacts(rig_g, law, v0[members], [impacts[j].t - t0[j] for j in members],
                                 derivatives=jacobian, tol=tol)
            for i, j in enumerate(members):
                lo, hi = rep.offsets[i], rep.offsets[i + 1]
                force[j] = rep.force[lo:hi]
                rate[j] = rep.force_rate[lo:hi]
                if jacobian:
                    dforce[j] = rep.force_derivatives[lo:hi]
        out = np.empty(n_data)
        jac = np.zeros((n_data, len(names))) if jacobian else None
        for j, c, lo, hi in blocks:
            scale = 1.0 / impacts[j].rig.mass if c == ACCELERATION_CHANNEL else 1.0
            out[lo:hi] = scale * force[j]
            if jacobian:
                jac[lo:hi, 0] = scale * dforce[j][:, 0]
                jac[lo:hi, 1] = scale * dforce[j][:, 1]
                jac[lo:hi, 2] = scale * dforce[j][:, 2]
                jac[lo:hi, n_law + j] = -scale * rate[j]
                jac[lo:hi, n_law + n_imp + j] = scale * dforce[j][:, 3]
        return out, jac

    cache: dict = {}

    def evaluate(u):
        key = u.tobytes()
        if cache.get("key") != key:
            out, jac = model(u, True)
            cache.update(key=key, r=w_all * (y_all - out), J=-w_all[:, None] * jac)
        return cache["r"], cache["J"]

    # ---- the engine: search from every damping index, covariance, intervals, bound hits ----
    begin = [{"n": s, "beta": beta_start(s)} for s in starts] if fit_n else [{}]
    found = search(lambda u: evaluate(u)[0], free, jacobian=lambda u: evaluate(u)[1], starts=begin, max_nfev=300)
    fit = uncertainty(found, confidence=confidence)
    notes.extend(fit.notes)
    values = found.values()
    u = np.array([f.coordinate(values[f.name]) for f in free])
    fitted, _ = model(u, False)
    k, beta, n_value, t0, v0 = unpack(u)
    se = {name: fit.stderr(name) if name in fit.names else 0.0 for name in names}
    tried = [{"n_start": float(t.get("n", starts[0])), "cost": t["cost"], "nfev": t["nfev"], "success": t["success"]}
             for t in found.starts]
    n_won = tried[int(np.argmin([t["cost"] for t in tried]))]["n_start"]
    s2 = fit.scale
    params = list(fit.parameters)
    params.append(Parameter("p", p, 0.0, (p, p), confidence, True, "", "the rig's stiffness exponent"))
    # ---- model check: residual against the noise between impacts ----
    stats_: dict = {"ndata": n_data, "nvarys": n_varying, "nfev": found.nfev,
                    "n_recordings": len(observations), "n_impacts": n_imp, "channels": ",".join(all_channels),
                    "speeds": speeds}
    residual = y_all - fitted
    checks = []
    for c in all_channels:
        sel = np.concatenate([np.arange(lo, hi) for j, cc, lo, hi in blocks if cc == c])
        # each recording's residual against its own noise (noise levels differ between recordings)
        check, check_notes = residual_against_noise(residual[sel], 1.0 / w_all[sel], what=c, unit=_UNITS[c])
        floored = [imp for imp in impacts if c in imp.noise and imp.noise[c] < imp.sigma[c]]
        stats_[f"residual_rms_{c}"] = check["residual_rms"]
        stats_[f"noise_sd_{c}"] = float(np.median([imp.noise[c] for imp in impacts if c in imp.noise]))
        stats_[f"residual_over_noise_{c}"] = check["residual_over_noise"]
        if floored:
            notes.append(f"channel {c!r} is noise-free between impacts in {len({i.source for i in floored})} "
                         f"recording(s) (noise below {NOISE_FLOOR:g} of its peak, the floor of the simulator's "
                         "accuracy): its residual there is compared with that floor")
        for note in check_notes:
            notes.append(f"{note} (in the contact signals: sensor dynamics or filtering, a second contact, another "
                         f"force law?); the intervals are widened by the misfit (x {math.sqrt(max(s2, 1.0)):.3g})")
        # the engine's whole check: structure within each impact, a trend of the amplitude misfit with speed
        chunks = [(j, lo, hi) for j, cc, lo, hi in blocks if cc == c]
        amplitude = np.array([float(residual[lo:hi] @ fitted[lo:hi]) / max(float(fitted[lo:hi] @ fitted[lo:hi]),
                                                                            1e-300) for _, lo, hi in chunks])
        checks.append(check_model(residual[sel], 1.0 / w_all[sel], noise_reference=DROP_NOISE, what=c, unit=_UNITS[c],
                                  n_params=n_varying,
                                  groups=np.concatenate([np.full(hi - lo, j) for j, lo, hi in chunks]),
                                  covariate=np.array([v0[j] for j, _, _ in chunks]),
                                  covariate_name="approach speed [m/s]", event_residual=amplitude,
                                  assumed_over_noise=math.sqrt(max(s2, 0.0))))
        notes.extend(checks[-1].further_notes)
    governing = governing_check(checks)
    params = list(governing.widen(params, names=("k", "beta", "n")))
    stats_.update(reduced_chi_square=s2, interval_inflation=math.sqrt(max(s2, 0.0)), dof=fit.dof,
                  condition_number=fit.statistics["condition_number"], success=found.success, cost=found.cost,
                  n_start=float(n_won))
    # ---- speeds: the first impact's fitted speed against the drop height's ----
    if free_speeds:
        for j, imp in enumerate(impacts):
            if imp.speed_from != "drop height":
                continue
            se_v = se[f"v0_{j}"]
            off = v0[j] / imp.speed - 1.0
            if abs(off) > 0.01 and (not math.isfinite(se_v) or abs(v0[j] - imp.speed) > 3.0 * se_v):
                notes.append(f"{imp.source}: the first impact's fitted speed {v0[j]:.5g} m/s differs from the drop "
                             f"height's {imp.speed:.5g} m/s by {100 * off:+.2g} %: check the drop height, the gravity, "
                             "the mass and the accelerometer's or load cell's calibration")
    # ---- tables and curves ----
    rows = []
    curves = []
    for j, imp in enumerate(impacts):
        row = {"recording": imp.source, "impact": imp.index, "onset_time_measured_s": imp.onset,
               "onset_time_fitted_s": float(t0[j]), "onset_time_stderr_s": se[f"t0_{j}"],
               "approach_speed_measured_m_s": imp.speed, "approach_speed_from": imp.speed_from,
               "approach_speed_fitted_m_s": float(v0[j]),
               "approach_speed_stderr_m_s": se[f"v0_{j}"],
               "contact_duration_s": float(imp.row["contact_duration_s"]),
               "separation_speed_m_s": float(imp.row["separation_speed_m_s"]),
               "peak_force_measured_n": float(imp.row["peak_force_n"]), "samples": int(imp.t.size)}
        curve = {"recording": imp.source, "impact": imp.index, "time_from_onset_ms": (1e3 * (imp.t - t0[j])).tolist(),
                 "channels": {}}
        for jj, c, lo, hi in blocks:
            if jj != j:
                continue
            res = residual[lo:hi]
            row[f"rms_residual_{c}"] = float(np.sqrt(np.mean(res**2)))
            if c == FORCE_CHANNEL:
                row["peak_force_model_n"] = float(np.max(fitted[lo:hi]))
            elif "peak_force_model_n" not in row:
                row["peak_force_model_n"] = float(np.max(fitted[lo:hi]) * imp.rig.mass)
            curve["channels"][c] = {"measured": y_all[lo:hi].tolist(), "model": fitted[lo:hi].tolist(),
                                    "noise_sd": imp.sigma[c], "unit": _UNITS[c]}
        rows.append(row)
        curves.append(curve)
    n_law_varying = 3 if fit_n else 2
    cov_law = fit.covariance.matrix[:n_law_varying, :n_law_varying]
    comparison = None
    if fit_n and N_BOUNDS[0] <= N_COMPARED <= N_BOUNDS[1]:
        # the law with n held at N_COMPARED: one refit from the optimum, every other parameter free
        held = [Free(f.name, N_COMPARED, f.min, f.max, vary=False, unit=f.unit) if f.name == "n"
                else Free(f.name, min(max(values[f.name], f.min), f.max), f.min, f.max, vary=f.vary, unit=f.unit,
                          log=f.log, report=f.report) for f in free]
        again = search(lambda u: evaluate(u)[0], held, jacobian=lambda u: evaluate(u)[1], max_nfev=300)
        comparison = compare_models([{"name": f"n = {N_COMPARED:g}", "n_params": n_varying - 1, "n_data": n_data,
                                      "rss": 2.0 * again.cost},
                                     {"name": "n fitted", "n_params": n_varying, "n_data": n_data,
                                      "rss": 2.0 * found.cost}],
                                    nested=[(f"n = {N_COMPARED:g}", "n fitted")],
                                    choice=f"n fitted or held at {N_COMPARED:g}")
    described = identifiability(found, fit, comparison=comparison, describes_data=governing.describes_data,
                                quadratic_reason="a refit replays every impact about 30 times per point")
    return DropFit(params=params, statistics=stats_, notes=tuple(dict.fromkeys(notes)),
                   tables={"impacts": pd.DataFrame(rows), "starts": pd.DataFrame(tried)},
                   details={"curves": curves, "covariance_ln_k_ln_beta_n": cov_law.tolist(),
                            "names": ["ln_k", "ln_beta", "n"][:n_law_varying], "k_start": k0, "confidence": confidence},
                   provenance=tuple(f"fit_drop: {o.source}: {len(o.impacts)} impact(s) of {', '.join(o.channels)}"
                                    for o in observations),
                   model_check=combine_checks(checks), identifiability=described)


def _rate(imp: _Impact) -> float:
    return 1.0 / float(imp.t[1] - imp.t[0]) if imp.t.size > 1 else 1.0

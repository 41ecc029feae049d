"""Synthetic recordings of rig P: the S2 (Hunt–Crossley) and S3 (restitution) simulations of
Sundar, Dreyer & Singh (2016) sampled as an acquisition system would (docs/rig_p.md and 1.9).

The simulator runs from static equilibrium (cam at ``theta_ref``), the first ``settle_s`` seconds
are discarded, and the exact dense output is sampled at the sample instants
``t_k = settle_s + k / sample_rate_hz`` (with ``decimation`` > 1, on a finer grid whose every
``decimation``-th point is a sample instant). The recording keeps the simulation clock:
``start_time_s = settle_s``, so the impact times of ``/truth`` are on the recording's time axis.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from impactid._version import __version__
from impactid.contact import HuntCrossley, Restitution
from impactid.errors import SimulationInputError
from impactid.io import CHANNEL_UNITS, Recording
from impactid.rigs.pivoted import PivotedFollowerRig, spring_force
from impactid.rigs.pivoted.runs import DEFAULT_TOLERANCES, observables, simulate
from impactid.synth.recording import SyntheticRecording
from impactid.synth.sensors import NO_SENSOR_ERRORS, SensorModel, antialias_decimate, apply_sensors, encoder_counts

__all__ = ["ALL_CHANNELS", "DEFAULT_SAMPLE_RATE_HZ", "DEFAULT_SETTLE_S", "SyntheticRecording", "pivot_reaction",
           "synth_pivoted"]

DEFAULT_SAMPLE_RATE_HZ = 204_800.0
#: Default settling time [s]: the slowest Table 2 transient (e/r_c = 0.2, 16 Hz) needs about 35 s
#: to reach period-1 motion (README, "Findings").
DEFAULT_SETTLE_S = 40.0
#: Longest settling time [s]: 90 times the default, which outlasts the slowest period-1 transient of
#: rig P; more only costs time (and a contact table sized by it, which a huge value cannot allocate).
MAX_SETTLE_S = 3600.0
#: Output samples simulated beyond each end when decimating (the FIR filter's edge zone).
_DECIMATION_MARGIN = 64

ALL_CHANNELS = ("accel_tangential", "force_x", "force_y", "cam_angle")


def pivot_reaction(rig: PivotedFollowerRig, alpha, alpha_dot, alpha_ddot, contact_force, friction_force):
    """Pivot reaction on the follower ``(N_x, N_y)`` [N] (docs/rig_p.md and 1.9).

    ``N = m_b r_G_ddot - F_s e_y + m_b g e_y + F_lam n(alpha) + F_f u(alpha)`` with
    ``r_G_ddot = -l_g alpha_ddot n - l_g alpha_dot^2 u``; ``F_f`` is the signed friction magnitude
    ``mu F_lam sgn(v_r)`` (the friction force on the follower is ``-F_f u``).
    """
    sa, ca = np.sin(alpha), np.cos(alpha)
    ux, uy = ca, -sa
    nx, ny = sa, ca
    spring = spring_force(alpha, rig.k_s, rig.L_s_u, rig.d_y, rig.d_x, rig.w_b)
    m, lg = rig.m_b, rig.l_g
    rgx = -lg * alpha_ddot * nx - lg * alpha_dot**2 * ux
    rgy = -lg * alpha_ddot * ny - lg * alpha_dot**2 * uy
    force_x = m * rgx + contact_force * nx + friction_force * ux
    force_y = m * rgy - spring + m * rig.g + contact_force * ny + friction_force * uy
    return force_x, force_y


def _exact_channels(rig, law, cam_speed_hz, t, alpha, alpha_dot, mode, theta_ref, mu):
    obs = observables(rig, law, cam_speed_hz, t, alpha, alpha_dot, mode, theta_ref=theta_ref, mu=mu)
    force = obs["contact_force"].to_numpy()
    add = obs["alpha_ddot"].to_numpy()
    friction = np.where(mode != 0, mu * force * np.sign(obs["sliding_velocity"].to_numpy()), 0.0)
    fx, fy = pivot_reaction(rig, alpha, alpha_dot, add, force, friction)
    return {
        "accel_tangential": rig.l_a * add,
        "force_x": fx,
        "force_y": fy,
        "cam_angle": theta_ref + 2.0 * math.pi * cam_speed_hz * t,
    }, obs


def _add_impulses(channels, impacts, rig, t0, rate, n):
    """S3: each impact as an impulse spread over the two samples around it (docs/estimation.md)."""
    for t_i, a_i, before, after, chi in impacts:
        x = (t_i - t0) * rate
        k = int(math.floor(x))
        w = x - k
        jump = after - before
        accel_area = rig.l_a * jump
        impulse = (-rig.m_b * rig.l_g + rig.I_b / chi) * jump
        parts = {"accel_tangential": accel_area, "force_x": impulse * math.sin(a_i),
                 "force_y": impulse * math.cos(a_i)}
        for name, area in parts.items():
            if 0 <= k < n:
                channels[name][k] += (1.0 - w) * area * rate
            if 0 <= k + 1 < n:
                channels[name][k + 1] += w * area * rate


def synth_pivoted(rig: PivotedFollowerRig, cam_speed_hz: float, law: HuntCrossley | Restitution,
                  duration: float, *, settle_s: float = DEFAULT_SETTLE_S,
                  sample_rate_hz: float = DEFAULT_SAMPLE_RATE_HZ, sensors: SensorModel = NO_SENSOR_ERRORS,
                  channels: tuple[str, ...] = ALL_CHANNELS, theta_ref: float = 0.0,
                  mu: float | None = None) -> SyntheticRecording:
    """Synthesise an S2 (``law`` a :class:`HuntCrossley`) or S3 (a :class:`Restitution`) recording.

    Parameters
    ----------
    rig : rig P parameters (``e`` sets e/r_c).
    cam_speed_hz : cam speed ``Omega_c`` [Hz].
    duration : recorded time [s] after the settling time.
    settle_s : simulated time discarded before recording [s].
    sample_rate_hz : output sample rate [Hz].
    sensors : sensor imperfections (none by default: the exact signals at the sample instants).
    channels : which docs/formats.md channels to write.
    theta_ref : cam angle at simulation time 0 [rad].
    mu : friction coefficient (default ``rig.mu``).
    """
    unknown = sorted(set(channels) - set(ALL_CHANNELS))
    if unknown:
        raise SimulationInputError(f"unknown channel(s) {', '.join(unknown)}; rig P records {', '.join(ALL_CHANNELS)}")
    if not (math.isfinite(duration) and duration > 0.0):
        raise SimulationInputError(f"duration must be positive, got {duration!r} s")
    if not (math.isfinite(settle_s) and 0.0 <= settle_s <= MAX_SETTLE_S):
        raise SimulationInputError(f"settling time settle_s (--settle) must be between 0 and {MAX_SETTLE_S:g} s, got "
                                   f"{settle_s!r} s")
    if not (math.isfinite(sample_rate_hz) and sample_rate_hz > 0.0):
        raise SimulationInputError(f"sample_rate_hz must be positive, got {sample_rate_hz!r}")
    mu = rig.mu if mu is None else float(mu)
    q = int(sensors.decimation)
    n = int(round(duration * sample_rate_hz))
    margin = _DECIMATION_MARGIN if q > 1 else 0
    fine_rate = q * sample_rate_hz
    j = np.arange(-margin * q, (n + margin) * q)
    t_fine = settle_s + j / fine_rate
    t_fine = t_fine[t_fine >= 0.0] if margin else t_fine
    lead = int(np.count_nonzero(j < 0)) - (j.size - t_fine.size)  # fine samples before the first output
    run = simulate(rig, cam_speed_hz, law, duration=float(t_fine[-1]) + 1.0 / fine_rate, t_eval=t_fine,
                   theta_ref=theta_ref, mu=mu)
    exact, obs = _exact_channels(rig, law, cam_speed_hz, t_fine, run.alpha, run.alpha_dot, run.mode, theta_ref, mu)
    contacts = run.contacts
    if isinstance(law, Restitution):
        impacts_rows = contacts[contacts["kind"] == "impact"]
        a_i = impacts_rows["alpha_start"].to_numpy()
        t_i = impacts_rows["t_start"].to_numpy()
        theta_i = theta_ref + 2.0 * math.pi * cam_speed_hz * t_i
        chi_i = rig.lever_arm(a_i, theta_i)
        impacts = zip(t_i, a_i, impacts_rows["alpha_dot_start"].to_numpy(), impacts_rows["alpha_dot_end"].to_numpy(),
                      chi_i)
        _add_impulses(exact, impacts, rig, float(t_fine[0]), fine_rate, t_fine.size)
    sample_index = slice(lead, lead + n * q, q)  # the fine samples that are sample instants
    measured_clean: dict[str, np.ndarray] = {}
    for name in channels:
        x = exact[name]
        if q == 1 or name == "cam_angle":
            measured_clean[name] = x[sample_index].copy()
        else:
            y = antialias_decimate(x[lead % q:], q)
            first = lead // q
            measured_clean[name] = y[first:first + n]
    rng = np.random.default_rng(sensors.seed)
    measured, applied = apply_sensors({k: v for k, v in measured_clean.items() if k != "cam_angle"},
                                      sample_rate_hz, sensors, rng)
    if "cam_angle" in channels:
        cam = measured_clean["cam_angle"]
        if sensors.cam_encoder_ppr is not None:
            cam = encoder_counts(cam, int(sensors.cam_encoder_ppr))
            applied["cam_angle"] = {"encoder_ppr": int(sensors.cam_encoder_ppr)}
        measured["cam_angle"] = cam
    measured = {name: measured[name] for name in channels}
    t_samples = settle_s + np.arange(n) / sample_rate_hz
    recording = Recording(
        channels=measured, sample_rate_hz=sample_rate_hz, units={k: CHANNEL_UNITS[k] for k in measured},
        rig=rig if mu == rig.mu else rig.replace(mu=mu),  # the file describes the rig that was simulated
        operating={"cam_speed_hz": float(cam_speed_hz), "eccentricity_m": rig.e},
        start_time_s=settle_s,
        provenance=(f"impactid.rigs.pivoted.synth.synth_pivoted: {type(law).__name__} at {cam_speed_hz} Hz, e/r_c = "
                    f"{rig.e / rig.r_c:.6g}, settle {settle_s} s",))
    in_window = (contacts["t_start"] >= t_samples[0]) & (contacts["t_start"] < t_samples[0] + duration)
    window = contacts[in_window]
    apexes = run.apexes[(run.apexes["t"] >= t_samples[0]) & (run.apexes["t"] < t_samples[0] + duration)]
    truth: dict[str, Any] = {
        "generator": "impactid.rigs.pivoted.synth.synth_pivoted",
        "impactid_version": __version__,
        "model": "S2" if isinstance(law, HuntCrossley) else "S3",
        "cam_speed_hz": float(cam_speed_hz),
        "e_over_rc": rig.e / rig.r_c,
        "mu": mu,
        "theta_ref": float(theta_ref),
        "settle_s": float(settle_s),
        "sample_rate_hz": float(sample_rate_hz),
        "tolerance_rtol": DEFAULT_TOLERANCES.rtol,
        "sensors": {k: v for k, v in sensors.to_dict().items() if v is not None and v != {}},
        "applied": applied,
        "t": t_samples,
        "alpha": run.alpha[sample_index].copy(),
        "alpha_dot": run.alpha_dot[sample_index].copy(),
        "mode": run.mode[sample_index].astype(np.int8),
        "contact_force": obs["contact_force"].to_numpy()[sample_index].copy(),
        "gap": obs["gap"].to_numpy()[sample_index].copy(),
        "alpha_ddot": obs["alpha_ddot"].to_numpy()[sample_index].copy(),
        "impacts": {col: window[col].to_numpy(dtype=float) for col in (
            "t_start", "t_end", "gap_rate_start", "gap_rate_end", "peak_force", "peak_indentation",
            "alpha_start", "alpha_dot_start", "alpha_end", "alpha_dot_end", "xi")},
        "impact_kinds": ",".join(window["kind"].tolist()),
        "apexes": {"t": apexes["t"].to_numpy(), "alpha": apexes["alpha"].to_numpy()},
    }
    if isinstance(law, HuntCrossley):
        truth.update(law="hunt-crossley", beta=law.beta, n=law.n, clip=bool(law.clip),
                     stiffness_exponent=law.stiffness_exponent, k_H=rig.k_H)
    else:
        truth.update(law="restitution", gamma=law.gamma, xi0=law.xi0, v_stick=law.v_stick)
    return SyntheticRecording(recording=recording, truth=_plain(truth))


def _plain(value: Any) -> Any:
    """Mappings to dicts and numpy scalars to Python scalars (HDF5-ready)."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if hasattr(value, "items"):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, np.generic):
        return value.item()
    return value

"""Synthetic recordings of the cycloidal-cam valve train with known parameters.

A recording is the steady cycle of level A (the valve adheres to the cam: the valve displacement is
the lift, the contact load the constraint reaction) or level B (the valve released: its displacement
deviates from the lift by the Hertz approach, the seat and any jump) sampled at a constant rate over
whole revolutions, with optional white Gaussian noise per channel. Channels (SI, docs/formats.md):
``cam_angle`` [rad, unwrapped], ``valve_displacement`` [m, positive opening], ``valve_velocity``
[m/s], ``contact_load`` [N, synthetic only]. The truth (parameters, level, speed, noise, seed) goes to
the file's ``/truth`` group, which the estimators never read.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from impactid.errors import SimulationInputError
from impactid.rigs.cycloidal import cam
from impactid.rigs.cycloidal.parameters import CycloidalEHLRig
from impactid.rigs.cycloidal.simulate import (
    DEFAULT_TOLERANCES,
    Tolerances,
    level_a_load,
    level_a_periodic_state,
    level_a_run,
    level_b_loads,
    level_b_run,
    level_b_steady_cycle,
    omega_of,
)
from impactid.synth.recording import SyntheticRecording

__all__ = ["CHANNELS", "SyntheticRecording", "synth_recording"]

TWO_PI = 2.0 * math.pi
#: Channels a synthetic recording can hold, and their SI units.
CHANNELS = {"cam_angle": "rad", "valve_displacement": "m", "valve_velocity": "m/s", "contact_load": "N"}


def synth_recording(rig: CycloidalEHLRig, rpm: float, *, level: str = "A", revolutions: float = 4.0,
                    sample_rate_hz: float = 50_000.0, channels: Sequence[str] = tuple(CHANNELS),
                    noise: Mapping[str, float] | None = None, cam_angle_offset: float = 0.0, seed: int = 0,
                    tol: Tolerances = DEFAULT_TOLERANCES) -> SyntheticRecording:
    """Steady-cycle recording of the valve train at a camshaft speed.

    Parameters
    ----------
    rig : the rig (its parameters are the truth).
    rpm : camshaft speed [r/min].
    level : ``"A"`` (adherent, the paper's model) or ``"B"`` (valve released, seat and Hertz contact).
    revolutions : recorded camshaft revolutions (need not be whole).
    sample_rate_hz : sampling rate [Hz].
    channels : which of :data:`CHANNELS` to record.
    noise : white Gaussian noise per channel, standard deviation in SI units (e.g.
        ``{"contact_load": 2.0}`` for 2 N); the cam angle stays exact unless given.
    cam_angle_offset : cam angle at the first sample [rad].
    seed : seed of the random generator.
    """
    unknown = sorted(set(channels) - set(CHANNELS))
    if unknown:
        raise SimulationInputError(f"unknown channel(s) {', '.join(unknown)}; valid: {', '.join(CHANNELS)}")
    noise = dict(noise or {})
    bad = sorted(set(noise) - set(channels))
    if bad:
        raise SimulationInputError(f"noise given for channel(s) not recorded: {', '.join(bad)}")
    for name, sd in noise.items():
        if not (math.isfinite(sd) and sd >= 0.0):
            raise SimulationInputError(f"noise of {name!r} must be >= 0, got {sd!r}")
    if not (math.isfinite(revolutions) and revolutions > 0.0):
        raise SimulationInputError(f"revolutions must be positive, got {revolutions!r}")
    if not (math.isfinite(sample_rate_hz) and sample_rate_hz > 0.0):
        raise SimulationInputError(f"sample_rate_hz must be positive, got {sample_rate_hz!r}")
    w = omega_of(rpm)
    T = TWO_PI / w
    n = int(round(revolutions * T * sample_rate_hz))
    if n < 2:
        raise SimulationInputError("the recording would have fewer than 2 samples")
    t = np.arange(n) / sample_rate_hz
    psi = cam_angle_offset + w * t
    # the steady cycle is periodic: integrate one revolution at the samples' phases
    phase_t = np.mod(psi, TWO_PI) / w
    order = np.argsort(phase_t, kind="stable")
    grid = phase_t[order]
    exact: dict[str, np.ndarray] = {}
    truth: dict[str, Any] = {"level": level, "rpm": float(rpm), "parameters": rig.to_dict(), "seed": int(seed),
                             "noise": {k: float(v) for k, v in noise.items()},
                             "cam_angle_offset_rad": float(cam_angle_offset)}
    if level == "A":
        z0, _ = level_a_periodic_state(rig, rpm, tol)
        _, Z = level_a_run(rig, rpm, z0, 0.0, T, grid=grid, tol=tol)
        W = np.empty(n)
        W[order] = level_a_load(rig, rpm, grid, Z)
        s, s1, _, _ = cam.lift(psi, rig.S, rig.beta)
        y3, v3 = s, w * s1
    elif level == "B":
        cyc = level_b_steady_cycle(rig, rpm, tol)
        if not cyc.converged:
            truth["note"] = f"level B found no periodic steady state in {cyc.n_rev} revolutions; last one repeated"
        _, _, X, _, _, _ = level_b_run(rig, rpm, cyc.x0, 0.0, T, mode0=cyc.mode0, grid=grid, tol=tol)
        Wc, _ = level_b_loads(rig, rpm, grid, X)
        W = np.empty(n)
        y3 = np.empty(n)
        v3 = np.empty(n)
        W[order], y3[order], v3[order] = Wc, X[:, 0], X[:, 1]
        truth["converged"] = bool(cyc.converged)
    else:
        raise SimulationInputError(f"unknown level {level!r}; valid: A, B")
    exact = {"cam_angle": psi, "valve_displacement": y3, "valve_velocity": v3, "contact_load": W}
    rng = np.random.default_rng(seed)
    data = {}
    for name in channels:
        values = exact[name].copy()
        if noise.get(name, 0.0) > 0.0:
            values = values + rng.normal(0.0, noise[name], size=n)
        data[name] = values
    from impactid.io import Recording

    recording = Recording(channels=data, sample_rate_hz=float(sample_rate_hz),
                          units={name: CHANNELS[name] for name in data}, rig=rig,
                          operating={"cam_speed_hz": float(rpm) / 60.0},
                          provenance=(f"synth_recording(level {level}, {rpm:g} rpm, {revolutions:g} rev, "
                                      f"{sample_rate_hz:g} Hz, noise {noise}, seed {seed})",))
    return SyntheticRecording(recording=recording, exact={k: exact[k] for k in channels}, truth=truth)

"""Synthetic recordings of the finger-follower valve train (the paper's test rig, simulated).

The rig of Kim, Jeon & Park (1990) measured the valve displacement with a non-contact optical
follower, the tappet (plunger) motion with a gap sensor and the cam angle with an encoder on the
camshaft, and averaged the signals over revolutions with the encoder. The paper gives no sample
rate, resolution or noise level; the defaults of :class:`Sensors` are assumptions (documented in
``docs/finger_follower.md``), each a parameter.

Two samplings are offered:

* ``"angle"``: one sample per encoder step (``encoder_ppr`` samples per revolution), as an encoder-
  clocked acquisition records; the ``cam_angle`` channel is the encoder angle, exact at each
  sample. The recording's ``sample_rate_hz`` is the nominal ``encoder_ppr * cam_speed_hz`` and its
  ``/operating`` table carries ``samples_per_revolution``: this is how an angle-domain recording is
  recognised (docs/formats.md addition).
* ``"time"``: uniform time samples at ``sample_rate_hz`` with the encoder angle quantised to its
  step (floor, as a counter reads it).

The recording starts in the periodic steady state (found by
:func:`~impactid.rigs.finger_follower.simulate.steady_state`) and runs continuously for
``revolutions`` revolutions, so a motion that is not periodic is recorded as it is. The cam
angle's zero is the nose plus ``nose_angle`` (``/operating nose_angle_rad`` says where the nose is,
as the rig file of a real test would).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from impactid.errors import SimulationInputError
from impactid.rigs.finger_follower.simulate import DEFAULT_TOLERANCES, prepare, simulate, steady_state

__all__ = ["Sensors", "SynthRecording", "synth_recording"]

TWO_PI = 2.0 * math.pi
#: Default time-domain sample rate [Hz]: a data-acquisition clock independent of the camshaft, so
#: that the samples fall at every phase of the encoder's steps (a rate commensurate with the
#: encoder, such as 20 samples per degree, leaves the encoder's quantisation unaveraged: up to a
#: tenth of a step of angle error, which biases the tappet damping by 5e-4 at 1600 rpm).
DEFAULT_SAMPLE_RATE_HZ = 50_000.0


@dataclass(frozen=True)
class Sensors:
    """Sensor models (assumed; the paper gives none). Noise is white and Gaussian (RMS values);
    each displacement is then quantised to its resolution (rounded, as an ADC).

    Attributes
    ----------
    valve_noise_m, valve_resolution_m : optical valve-displacement follower [m].
    tappet_noise_m, tappet_resolution_m : gap sensor on the plunger [m].
    velocity_noise_m_s : valve-velocity channel (a laser vibrometer, say) [m/s].
    load_noise_N : the cam/follower load channel (synthetic data only) [N].
    valve_offset_m, tappet_offset_m : sensor zero offsets [m] (the fits estimate them).
    """

    valve_noise_m: float = 2e-6
    valve_resolution_m: float = 1e-6
    tappet_noise_m: float = 0.3e-6
    tappet_resolution_m: float = 0.1e-6
    velocity_noise_m_s: float = 5e-3
    load_noise_N: float = 1.0
    valve_offset_m: float = 0.0
    tappet_offset_m: float = 0.0

    def __post_init__(self) -> None:
        for name, value in asdict(self).items():
            if not math.isfinite(value) or (not name.endswith("offset_m") and value < 0.0):
                raise SimulationInputError(f"sensor setting {name} must be finite and >= 0, got {value!r}")

    @classmethod
    def ideal(cls) -> Sensors:
        """No noise, no quantisation, no offsets."""
        return cls(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


@dataclass(frozen=True)
class SynthRecording:
    """A synthetic recording and what generated it.

    ``recording`` is an :class:`impactid.io.Recording`; ``truth`` the values it was made with (the
    ``/truth`` group of the HDF5 file: estimators never read it).
    """

    recording: Any
    truth: dict = field(default_factory=dict)

    def write(self, path) -> Path:
        """Write as HDF5 (with ``/truth``), or as CSV plus its TOML rig file (without truth)."""
        from impactid.io import write_csv, write_hdf5

        path = Path(path)
        if path.suffix.lower() == ".csv":
            return write_csv(self.recording, path)[0]
        return write_hdf5(self.recording, path, truth=self.truth)


def _measure(values: np.ndarray, noise: float, resolution: float, offset: float, rng) -> np.ndarray:
    out = values + offset
    if noise > 0.0:
        out = out + rng.normal(0.0, noise, values.size)
    if resolution > 0.0:
        out = np.round(out / resolution) * resolution
    return out


def synth_recording(rig, rpm: float, *, revolutions: int = 16, sampling: str = "angle", encoder_ppr: int = 1440,
                    sample_rate_hz: float | None = None, lift=None, sensors: Sensors = Sensors(),
                    nose_angle: float = 0.7, start_angle: float = -2.5, alpha: float | None = None,
                    beta: float | None = None, velocity: bool = False, load: bool = False, seed: int = 0,
                    clip_tension: bool = False, moment_cos: bool = False,
                    tolerances=DEFAULT_TOLERANCES) -> SynthRecording:
    """Simulate a test of the valve train and record it as the paper's rig would.

    Parameters
    ----------
    rig : :class:`~impactid.rigs.finger_follower.FingerFollowerRig`.
    rpm : camshaft speed [rpm].
    revolutions : whole revolutions recorded (for synchronous averaging).
    sampling : ``"angle"`` (one sample per encoder step) or ``"time"`` (``sample_rate_hz``).
    encoder_ppr : encoder steps per revolution.
    sample_rate_hz : time-domain sample rate [Hz] (default :data:`DEFAULT_SAMPLE_RATE_HZ`).
    lift : a lift law (default the rig's cycloidal law).
    sensors : :class:`Sensors`.
    nose_angle : encoder angle of the nose [rad] (written to ``/operating nose_angle_rad``).
    start_angle : cam angle of the first sample [rad] (0 at the nose).
    alpha, beta : tappet weights (default the rig's speed law).
    velocity, load : add the ``valve_velocity`` and ``contact_load`` (cam/follower force) channels.
    seed : seed of the noise generator.
    clip_tension, moment_cos : model options (:func:`~impactid.rigs.finger_follower.simulate.prepare`).
    """
    from impactid.io import Recording

    if sampling not in ("angle", "time"):
        raise SimulationInputError(f"sampling must be 'angle' or 'time', got {sampling!r}")
    if int(revolutions) < 1 or int(encoder_ppr) < 36:
        raise SimulationInputError("revolutions must be >= 1 and encoder_ppr >= 36")
    revolutions, encoder_ppr = int(revolutions), int(encoder_ppr)
    speed_hz = float(rpm) / 60.0
    omega = TWO_PI * speed_hz
    train = prepare(rig, lift, clip_tension=clip_tension, moment_cos=moment_cos)
    steady = steady_state(train, rpm, alpha=alpha, beta=beta, tolerances=tolerances, grid_step_deg=1.0)
    step = TWO_PI / encoder_ppr
    t0 = ((start_angle + math.pi) % TWO_PI) / omega
    if sampling == "angle":
        n = revolutions * encoder_ppr
        t = t0 + np.arange(n) * (step / omega)
        rate = encoder_ppr * speed_hz
    else:
        rate = float(sample_rate_hz) if sample_rate_hz is not None else DEFAULT_SAMPLE_RATE_HZ
        if not (math.isfinite(rate) and rate > 0.0):
            raise SimulationInputError(f"sample_rate_hz must be positive, got {sample_rate_hz!r}")
        n = int(math.floor(revolutions * rate / speed_hz))
        t = t0 + np.arange(n) / rate
    run = simulate(train, rpm, revolutions=revolutions + 1, start=steady.start, grid=t, alpha=steady.alpha,
                   beta=steady.beta, tolerances=tolerances)
    theta = run.theta  # model convention, unwrapped from -pi
    encoder = theta + nose_angle
    if sampling == "time":
        encoder = step * np.floor(encoder / step)
    rng = np.random.default_rng(seed)
    channels = {
        "valve_displacement": _measure(run.channel("Y_v"), sensors.valve_noise_m, sensors.valve_resolution_m,
                                       sensors.valve_offset_m, rng),
        "tappet_displacement": _measure(run.channel("Y_t"), sensors.tappet_noise_m, sensors.tappet_resolution_m,
                                        sensors.tappet_offset_m, rng),
        "cam_angle": encoder,
    }
    if velocity:
        channels["valve_velocity"] = _measure(run.channel("Y_v_dot"), sensors.velocity_noise_m_s, 0.0, 0.0, rng)
    if load:
        channels["contact_load"] = _measure(run.channel("F_fc"), sensors.load_noise_N, 0.0, 0.0, rng)
    units = {"valve_displacement": "m", "tappet_displacement": "m", "cam_angle": "rad", "valve_velocity": "m/s",
             "contact_load": "N"}
    operating = {"cam_speed_hz": speed_hz, "nose_angle_rad": float(nose_angle)}
    if sampling == "angle":
        operating["samples_per_revolution"] = float(encoder_ppr)
    else:
        operating["encoder_ppr"] = float(encoder_ppr)
    a, b = steady.alpha, steady.beta
    truth = {
        "rpm": float(rpm), "alpha": a, "beta": b, "c_t": a * rig.C_d_plus, "k_t": b * rig.K_e,
        "nose_angle_rad": float(nose_angle), "sampling": sampling, "encoder_ppr": encoder_ppr,
        "revolutions": revolutions, "seed": int(seed), "periodic": bool(steady.converged),
        "period_revolutions": int(steady.period), "clip_tension": bool(clip_tension), "moment_cos": bool(moment_cos),
        "sensors": asdict(sensors), "lift": train.lift.to_dict(),
    }
    recording = Recording(channels=channels, sample_rate_hz=rate, units={k: units[k] for k in channels}, rig=rig,
                          operating=operating,
                          provenance=(f"synth_recording(finger-follower-hla, {rpm:g} rpm, {revolutions} revolutions, "
                                      f"{sampling} sampling, {encoder_ppr} ppr, seed {seed})",))
    return SynthRecording(recording=recording, truth=truth)

"""Synthetic ball tracks: a spinning ball dropped onto a horizontal surface, its bounces made by a known
restitution law and Coulomb friction, sampled like a video (``impactid synth --rig tracked-ball``).

The flights follow the rig's own flight model (:mod:`~impactid.rigs.tracks.flight`: gravity less
buoyancy, quadratic drag and the Magnus force of the spin, the spin constant in flight), integrated
with the classical fourth-order Runge-Kutta method; each flight ends where the ball's centre reaches
``R`` above the surface (the time found by bisection on the last step, to 1e-12 s). Each bounce is a
rigid impact: the normal restitution ``e_n = e0 - gamma v_n`` of the normal impact speed ``v_n``
(clipped to [0, 1]) and the tangential outcome of a rigid ball with Coulomb friction ``mu`` and
sticking (:func:`~impactid.rigs.tracks.laws.tangential_prediction`, Nakashima et al. 2010); the spin
changes by the angular impulse about the centre, ``Delta omega = -(n x Delta v) / (k R)``. These
are the laws ``impactid tracks analyse`` fits (normal ``constant`` or ``linear``, tangential
``coulomb``), so a synthetic track tests the analysis against known values. The tests' reference
tracks (``tests/rigs/tracks/reference_tracks.py``) are written independently of this module.

The samples are the ball centre's positions at ``k / frame_rate`` from the release, with Gaussian
noise of ``noise`` [m] on every written coordinate, up to the touchdown after the last bounce.
:func:`write_track` writes them as a CSV or TSV table with a header (``t (s)``, ``x (m)``, ``y (m)``
[, ``z (m)``]) or as a Tracker export (``.txt``), in a frame with the vertical axis ``y`` (2-D) or
``z`` (3-D) and the surface at height 0. The truth (the bounces' times, velocities, spins and
restitutions) stays in the :class:`SyntheticTrack` and is never written into the file.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from impactid._files import atomic_write
from impactid.rigs.tracks.flight import MAX_STEP, acceleration, flight_positions
from impactid.rigs.tracks.laws import tangential_prediction
from impactid.rigs.tracks.parameters import TABLE_TENNIS_BALL, TrackedBall

__all__ = ["DEFAULT_FRAME_RATE", "DEFAULT_HEIGHT", "DEFAULT_NOISE", "MAX_SAMPLES", "TRACK_FORMATS", "SyntheticTrack",
           "synth_track", "track_text", "write_track"]

#: A phone's slow-motion video [frames/s].
DEFAULT_FRAME_RATE = 240.0
#: Release height of the ball's bottom above the surface [m] (the table-tennis rule's 30.5 cm).
DEFAULT_HEIGHT = 0.305
#: Standard deviation of the tracked positions [m] (a ball of a few pixels in a phone video).
DEFAULT_NOISE = 1e-3
#: Most samples a synthetic track may have.
MAX_SAMPLES = 10_000_000
#: Slowest impact a bounce may have [m/s]: below it the ball has come to rest.
MIN_IMPACT_SPEED = 1e-3
#: Longest track [s] (a ball still bouncing after a minute has stopped being one).
MAX_DURATION = 600.0
#: The suffixes :func:`write_track` writes, and what.
TRACK_FORMATS = {".csv": "comma-separated table with a header of names and units",
                 ".tsv": "tab-separated table with a header of names and units",
                 ".txt": "Tracker export: the track's name, then t, x, y[, z] (metres, seconds), tab-separated"}


@dataclass(frozen=True)
class SyntheticTrack:
    """A synthetic track and its truth.

    Attributes
    ----------
    time : (n,) sample times from the release [s].
    position : (n, 3) the ball centre with noise [m], ``z`` up, the surface at ``z = 0``.
    exact : (n, 3) the same without noise [m].
    dimensions : 2 (the plane ``y = 0``: written as ``t, x, y`` with ``y`` up) or 3.
    ball : the ball and its air model.
    spin : the spin at release ``(wx, wy, wz)`` [rad/s] (internal frame).
    impact_times : (B,) the bounces' times [s].
    velocity_in, velocity_out : (B, 3) the velocities before and after each bounce [m/s].
    spin_in, spin_out : (B, 3) the spins before and after [rad/s].
    restitution : (B,) the normal restitution of each bounce [-].
    sticking : (B,) whether the contact point stopped slipping.
    law : the restitution law ``{"e0", "gamma"}`` and the friction ``mu``.
    noise : standard deviation of the positions [m]; frame_rate [frames/s]; seed.
    """

    time: np.ndarray
    position: np.ndarray
    exact: np.ndarray
    dimensions: int
    ball: TrackedBall
    spin: tuple[float, float, float]
    impact_times: np.ndarray
    velocity_in: np.ndarray
    velocity_out: np.ndarray
    spin_in: np.ndarray
    spin_out: np.ndarray
    restitution: np.ndarray
    sticking: np.ndarray
    law: dict
    noise: float
    frame_rate: float
    seed: int

    @property
    def impact_speeds(self) -> np.ndarray:
        """(B,) the normal impact speeds [m/s]."""
        return -self.velocity_in[:, 2]


def _step(p: np.ndarray, v: np.ndarray, spin: np.ndarray, ball: TrackedBall, h: float):
    """One classical Runge-Kutta step of length ``h`` [s] of the flight (the same scheme as
    :func:`~impactid.rigs.tracks.flight.flight_positions`), returning the new position and velocity."""
    w = spin[None, :]
    k1 = acceleration(v[None, :], w, ball)[0]
    v2 = v + 0.5 * h * k1
    k2 = acceleration(v2[None, :], w, ball)[0]
    v3 = v + 0.5 * h * k2
    k3 = acceleration(v3[None, :], w, ball)[0]
    v4 = v + h * k3
    k4 = acceleration(v4[None, :], w, ball)[0]
    return p + h / 6.0 * (v + 2.0 * v2 + 2.0 * v3 + v4), v + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


def _touchdown(p: np.ndarray, v: np.ndarray, spin: np.ndarray, ball: TrackedBall, t_end: float):
    """The flight from ``(p, v)`` at time 0 until the centre falls to ``R`` above the surface: the time,
    position and velocity there (None when it does not land before ``t_end`` [s])."""
    h = MAX_STEP / 2.0
    t = 0.0
    while t < t_end:
        p_next, v_next = _step(p, v, spin, ball, h)
        if p_next[2] <= ball.radius and v_next[2] < 0.0:
            lo, hi = 0.0, h
            while hi - lo > 1e-13:
                mid = 0.5 * (lo + hi)
                if _step(p, v, spin, ball, mid)[0][2] <= ball.radius:
                    hi = mid
                else:
                    lo = mid
            p_hit, v_hit = _step(p, v, spin, ball, hi)
            return t + hi, p_hit, v_hit
        p, v, t = p_next, v_next, t + h
    return None


def _bounce(v_in: np.ndarray, spin: np.ndarray, ball: TrackedBall, e0: float, gamma: float, mu: float):
    """The velocity and spin after a bounce on the horizontal surface, its restitution and whether it sticks."""
    speed = -v_in[2]
    e_n = min(max(e0 - gamma * speed, 0.0), 1.0)
    v_out_z = e_n * speed
    v_t, sticks = tangential_prediction(mu, v_in[None, :], np.array([v_out_z]), spin[None, :], ball.radius,
                                        ball.inertia)
    v_out = np.array([v_t[0, 0], v_t[0, 1], v_out_z])
    dv = v_out - v_in
    n = np.array([0.0, 0.0, 1.0])
    spin_out = spin - np.cross(n, dv) / (ball.inertia * ball.radius)
    return v_out, spin_out, e_n, bool(sticks[0])


def synth_track(*, ball: TrackedBall = TABLE_TENNIS_BALL, height: float = DEFAULT_HEIGHT,
                horizontal_speed: float = 0.0, spin=(0.0, 0.0, 0.0), dimensions: int = 2, e0: float = 0.9,
                gamma: float = 0.0, mu: float = 0.25, bounces: int = 3, frame_rate: float = DEFAULT_FRAME_RATE,
                noise: float = DEFAULT_NOISE, seed: int = 0) -> SyntheticTrack:
    """A ball released at ``height`` with a horizontal speed and a spin, bouncing ``bounces`` times.

    Parameters
    ----------
    ball : the ball and its air model (the preset table-tennis ball by default).
    height : release height of the ball's bottom above the surface [m], > 0.
    horizontal_speed : speed along ``x`` at the release [m/s].
    spin : the spin at the release ``(wx, wy, wz)`` [rad/s] (``z`` up; a 2-D track spins about ``y``
        only: ``wy = -w`` for a counter-clockwise ``w`` in the written ``x``-``y`` plane).
    dimensions : 2 or 3: the track written (the motion is computed in 3-D either way).
    e0, gamma : the normal restitution ``e_n = e0 - gamma v_n`` [-], [s/m].
    mu : Coulomb friction coefficient [-] (``inf``: the contact point always stops slipping).
    bounces : number of bounces, >= 1; the track ends at the touchdown after the last.
    frame_rate : samples per second [Hz].
    noise : standard deviation of each written coordinate [m].
    seed : seed of the noise.

    Raises
    ------
    ValueError
        a value out of range, or a ball that does not land (a rebound too short to leave the surface).
    """
    spin = np.asarray(spin, dtype=float)
    if spin.shape != (3,) or not np.all(np.isfinite(spin)):
        raise ValueError(f"the spin must be three finite components [rad/s], got {spin!r}")
    if dimensions not in (2, 3):
        raise ValueError(f"dimensions must be 2 or 3, got {dimensions!r}")
    if dimensions == 2 and (spin[0] != 0.0 or spin[2] != 0.0):
        raise ValueError("a 2-D track spins about the axis out of its plane only (wx = wz = 0)")
    checks = ((height > 0.0, "height must be positive"), (frame_rate > 0.0, "frame_rate must be positive"),
              (noise >= 0.0, "noise must be >= 0"), (mu >= 0.0, "mu must be >= 0"),
              (bounces >= 1, "bounces must be at least 1"), (0.0 < e0 <= 1.0, "e0 must lie in (0, 1]"),
              (gamma >= 0.0, "gamma must be >= 0"),
              (all(math.isfinite(x) for x in (height, frame_rate, noise, e0, gamma, horizontal_speed)),
               "the values must be finite"))
    for ok, message in checks:
        if not ok:
            raise ValueError(message)
    p = np.array([0.0, 0.0, height + ball.radius])
    v = np.array([float(horizontal_speed), 0.0, 0.0])
    w = spin.copy()
    flights = []  # (start time, start position, start velocity, spin, end time)
    t0 = 0.0
    records = []
    for k in range(bounces + 1):
        landing = _touchdown(p, v, w, ball, MAX_DURATION - t0)
        if landing is None:
            raise ValueError(f"the ball does not land within {MAX_DURATION:g} s after bounce {k}")
        dt, p_hit, v_hit = landing
        flights.append((t0, p.copy(), v.copy(), w.copy(), t0 + dt))
        t0 += dt
        if k == bounces:
            break
        if -v_hit[2] < MIN_IMPACT_SPEED:
            raise ValueError(f"the ball comes to rest: bounce {k + 1} would be slower than {1e3 * MIN_IMPACT_SPEED:g} "
                             f"mm/s; ask for at most {k} bounces")
        v_out, w_out, e_n, sticks = _bounce(v_hit, w, ball, e0, gamma, mu)
        records.append((t0, v_hit, v_out, w.copy(), w_out, e_n, sticks))
        p, v, w = np.array([p_hit[0], p_hit[1], ball.radius]), v_out, w_out
    samples = math.floor(t0 * frame_rate) + 1
    if samples > MAX_SAMPLES:
        raise ValueError(f"{samples} samples to write; at most {MAX_SAMPLES} (fewer bounces or a lower frame rate)")
    time = np.arange(samples) / frame_rate
    exact = np.empty((samples, 3))
    for start, p0, v0, w0, end in flights:
        inside = (time >= start) & (time <= end)
        if np.any(inside):
            exact[inside] = flight_positions(p0[None, :], v0[None, :], np.array([start]), time[inside], ball,
                                             w0[None, :])[0]
    rng = np.random.default_rng(seed)
    position = exact + noise * rng.standard_normal(exact.shape)
    if dimensions == 2:
        position[:, 1] = 0.0
    return SyntheticTrack(
        time=time, position=position, exact=exact, dimensions=dimensions, ball=ball,
        spin=(float(spin[0]), float(spin[1]), float(spin[2])),
        impact_times=np.array([r[0] for r in records]), velocity_in=np.array([r[1] for r in records]),
        velocity_out=np.array([r[2] for r in records]), spin_in=np.array([r[3] for r in records]),
        spin_out=np.array([r[4] for r in records]), restitution=np.array([r[5] for r in records]),
        sticking=np.array([r[6] for r in records], dtype=bool), law={"e0": e0, "gamma": gamma, "mu": mu},
        noise=float(noise), frame_rate=float(frame_rate), seed=int(seed))


def track_text(track: SyntheticTrack, suffix: str = ".csv", name: str = "ball") -> str:
    """The text of a track file (:data:`TRACK_FORMATS` by ``suffix``): ``t, x, y`` (2-D, ``y`` up) or
    ``t, x, y, z`` (3-D, ``z`` up), in seconds and metres."""
    suffix = suffix.lower()
    if suffix not in TRACK_FORMATS:
        raise ValueError(f"unknown suffix {suffix or '(none)'!r}; a track is written as {', '.join(TRACK_FORMATS)}")
    if track.dimensions == 2:
        columns = np.column_stack([track.time, track.position[:, 0], track.position[:, 2]])
        names = ("t", "x", "y")
    else:
        columns = np.column_stack([track.time, track.position])
        names = ("t", "x", "y", "z")
    sep = "," if suffix == ".csv" else "\t"
    if suffix == ".txt":
        lines = [name, sep.join(names)]
    else:
        lines = [sep.join(f"{n} ({'s' if n == 't' else 'm'})" for n in names)]
    lines += [sep.join([f"{row[0]:.9f}", *(f"{x:.7f}" for x in row[1:])]) for row in columns]
    return "\n".join(lines) + "\n"


def write_track(path: str | os.PathLike[str], track: SyntheticTrack, *, name: str = "ball") -> Path:
    """Write ``track`` as the file its suffix names (:data:`TRACK_FORMATS`), atomically.

    Raises
    ------
    ValueError : an unknown suffix.
    """
    return atomic_write(path, track_text(track, Path(path).suffix, name=name))

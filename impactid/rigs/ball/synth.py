"""Synthetic drops: impact times from a known restitution law and flight model, the trigger faults
of real acoustic stopwatches, and the files real tools write (phyphox ``.xlsx`` and CSV exports, a
plain CSV of times, WAV audio).

A drop (:func:`simulate_drop`) starts from rest at a height, falls (with air if asked), and bounces
with ``e(v)`` from :mod:`impactid.rigs.ball.laws` until the flights are shorter than
``min_flight``. :func:`inject_faults` turns the true impact times into what a phyphox
"Acoustic stopwatch" might record: Gaussian timing jitter rounded to the audio sample period,
missed bounces, echo and spurious triggers inside a flight, a displaced trigger, a release click
before the first impact, and junk events after the last bounce. Every injected fault is labelled,
so tests can check that the cleaning finds exactly them.

:func:`synth_audio` renders impacts as clicks: a sum of damped resonances (the ball's shell at a
few kHz, the floor lower and longer), amplitude proportional to the impact speed, a 50 microsecond
rise, room echoes (delayed attenuated copies), background noise (white plus mains hum), optional
clipping, mono or stereo; :func:`write_wav` writes 16-, 24- or 32-bit integer or 32-bit float WAV.

All writers go through :func:`impactid._files.atomic_write`. Nothing here is read by the
estimators: the truth travels in the returned objects only.
"""

from __future__ import annotations

import math
import os
import struct
import zipfile
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from impactid._files import atomic_write
from impactid.rigs.ball.flight import FlightConstants, flight_constants, flight_time, landing_speed
from impactid.rigs.ball.laws import get_law
from impactid.rigs.ball.parameters import Ball

__all__ = ["DEFAULT_BOUNCE_LAW", "DEFAULT_HEIGHT", "DROP_FORMATS", "STOPWATCH_FAULTS", "SynthDrop", "inject_faults",
           "java_scientific", "simulate_drop", "synth_audio", "synth_drop", "write_drop", "write_event_csv",
           "write_phyphox_csv", "write_phyphox_xlsx", "write_wav", "ROOM_AUDIO"]

#: Labels of events in a synthetic drop.
EVENT_LABELS = ("impact", "release", "echo", "spurious", "displaced", "junk")

#: The restitution law of ``impactid synth --rig bouncing-ball`` unless ``--bounce-law`` is given:
#: ``e = e0 - gamma v`` [-, s/m], a stand-in for a table-tennis ball on a hard floor (e about 0.9
#: at the 2.4 m/s of a 0.3 m drop).
DEFAULT_BOUNCE_LAW = ("linear", {"e0": 0.96, "gamma": 0.02})

#: Release height of ``impactid synth --rig bouncing-ball`` unless ``--height`` is given [m].
DEFAULT_HEIGHT = 0.3

#: The faults of a phone's acoustic stopwatch that ``impactid synth --rig bouncing-ball --faults``
#: adds (arguments of :func:`inject_faults`): the release click, one missed bounce, one echo, one
#: spurious trigger and two junk events after the last bounce.
STOPWATCH_FAULTS = {"release": True, "missed": 1, "echoes": 1, "spurious": 1, "junk_end": 2}

#: What :func:`write_drop` writes, by the output file's suffix.
DROP_FORMATS = {".csv": "a plain CSV of event times [s]",
                ".xlsx": "a phyphox 'Acoustic stopwatch' Excel export",
                ".wav": "16-bit 48 kHz audio of the impact clicks (with room echoes and background noise)"}


@dataclass(frozen=True)
class SynthDrop:
    """A synthetic drop.

    Attributes
    ----------
    times : observed event times [s] (after faults), increasing.
    labels : per observed event, one of ``impact``, ``release``, ``echo``, ``spurious``,
        ``displaced`` (an impact triggered late or early), ``junk``.
    impact_index : per observed event, the index of the true impact it records (-1 if none).
    true_times : the true impact times [s].
    impact_speeds : true impact speeds [m/s] (one per true impact).
    launch_speeds : true launch speeds [m/s] after each impact.
    restitution : true e at each impact.
    missed : indices of the true impacts that were not recorded.
    truth : what generated it (law, parameters, ball, flight constants, height, jitter, seed).
    """

    times: np.ndarray
    labels: tuple[str, ...]
    impact_index: np.ndarray
    true_times: np.ndarray
    impact_speeds: np.ndarray
    launch_speeds: np.ndarray
    restitution: np.ndarray
    missed: tuple[int, ...] = ()
    truth: Mapping = field(default_factory=dict)

    def fault_counts(self) -> dict[str, int]:
        """How many events of each kind, and how many impacts were missed."""
        counts = {label: int(sum(lab == label for lab in self.labels)) for label in EVENT_LABELS}
        counts["missed"] = len(self.missed)
        return counts


def _law_function(law: str | Callable, params: Mapping[str, float] | None) -> Callable[[np.ndarray], np.ndarray]:
    if callable(law):
        return law
    spec = get_law(law)
    values = np.array([float(params[name]) for name in spec.names]) if params else None
    if values is None:
        raise ValueError(f"law {law!r} needs params {spec.names}")
    return lambda v: spec.evaluate(values, v)


def simulate_drop(law: str | Callable = "linear", params: Mapping[str, float] | None = None, *,
                  ball: Ball | None = None, drag: bool = True, height: float = 0.3, first_impact: float = 0.5,
                  min_flight: float = 0.1, max_impacts: int = 60, scatter: float = 0.0,
                  rng: np.random.Generator | None = None,
                  constants: FlightConstants | None = None) -> dict[str, np.ndarray]:
    """True impact times of a ball released from rest at ``height`` [m].

    Parameters
    ----------
    law, params : restitution law by name (see :mod:`~impactid.rigs.ball.laws`) and its parameters,
        or a callable ``e(v)``.
    ball, drag : the flight (see :func:`~impactid.rigs.ball.flight.flight_constants`), or ``constants``.
    height : release height of the ball's bottom above the floor [m].
    first_impact : time of the first impact [s].
    min_flight : the drop ends when a flight would be shorter [s].
    max_impacts : at most this many impacts.
    scatter : standard deviation of a bounce-to-bounce scatter added to ``e(v)`` (needs ``rng``).
    rng : random generator for ``scatter``.

    Returns
    -------
    dict with ``times`` (impact times [s]), ``v`` (impact speeds), ``u`` (launch speeds),
    ``e`` (restitution at each impact), ``flights`` (durations [s]), ``fall_time`` [s].
    """
    c = constants if constants is not None else flight_constants(ball, drag)
    e_of = _law_function(law, params)
    g, vt = c.gravity, c.terminal_speed
    if math.isfinite(vt):
        x = math.exp(g * height / vt ** 2)
        fall = vt / g * math.acosh(x)
        w = vt * math.sqrt(1.0 - 1.0 / x ** 2)
    else:
        fall = math.sqrt(2.0 * height / g)
        w = math.sqrt(2.0 * g * height)
    times, vs, us, es, flights = [first_impact], [], [], [], []
    for _ in range(max_impacts - 1):
        e = float(e_of(np.asarray(w)))
        if scatter > 0.0:
            e += scatter * float((rng if rng is not None else np.random.default_rng()).standard_normal())
        u = e * w
        T = float(flight_time(u, c))
        vs.append(w)
        us.append(u)
        es.append(e)
        if T < min_flight:
            break
        flights.append(T)
        times.append(times[-1] + T)
        w = float(landing_speed(u, c))
    n = len(times)
    return {"times": np.array(times), "v": np.array(vs[:n]), "u": np.array(us[:n]), "e": np.array(es[:n]),
            "flights": np.array(flights), "fall_time": fall}


def inject_faults(true_times: np.ndarray, rng: np.random.Generator, *, jitter: float = 0.0,
                  resolution: float = 1.0 / 48000, missed: int = 0, echoes: int = 0, spurious: int = 0,
                  displaced: int = 0, displacement: float = 0.01, release: bool = False, fall_time: float = 0.2,
                  junk_end: int = 0) -> tuple[np.ndarray, tuple[str, ...], np.ndarray, tuple[int, ...]]:
    """Observed events from true impact times, with labelled faults.

    Parameters
    ----------
    true_times : impact times [s].
    rng : random generator.
    jitter : standard deviation of the trigger timing [s] (Gaussian, per event).
    resolution : the times are rounded to multiples of this [s] (phyphox: 1/48000 s); 0 for none.
    missed : number of inner impacts not recorded (never the first three or the last two, never
        two within three impacts).
    echoes : number of echo triggers, 2 to 20 ms (at most a fifth of the flight) after an impact.
    spurious : number of spurious triggers, anywhere between 20 % and 80 % of a flight.
    displaced : number of impacts (from the fifth on) triggered ``displacement`` [s] late or early.
    release : add a release click ``fall_time`` before the first impact.
    junk_end : number of junk events after the last impact (0.1 to 0.8 s apart).

    Returns
    -------
    times, labels, impact index per event (-1 for non-impacts), indices of missed impacts.
    """
    n = true_times.size
    inner = np.arange(3, n - 2)
    chosen: list[int] = []
    for k in rng.permutation(inner):
        if len(chosen) >= missed:
            break
        if all(abs(int(k) - c) > 2 for c in chosen):
            chosen.append(int(k))
    missed_set = set(chosen)
    events: list[tuple[float, str, int]] = []
    shift_candidates = [k for k in range(4, n - 2) if k not in missed_set and k - 1 not in missed_set
                        and k + 1 not in missed_set]
    shifted = set(int(k) for k in rng.choice(shift_candidates, size=min(displaced, len(shift_candidates)),
                                             replace=False)) if displaced and shift_candidates else set()
    for k, t in enumerate(true_times):
        if k in missed_set:
            continue
        if k in shifted:
            events.append((t + displacement * rng.choice([-1.0, 1.0]), "displaced", k))
        else:
            events.append((t, "impact", k))
    flights = np.diff(true_times)
    spots = [k for k in range(1, n - 1) if k not in missed_set and k not in shifted and k + 1 not in shifted]
    for _ in range(echoes):
        k = int(rng.choice(spots))
        events.append((true_times[k] + rng.uniform(0.002, min(0.020, 0.2 * flights[k])), "echo", -1))
    for _ in range(spurious):
        k = int(rng.choice(spots))
        events.append((true_times[k] + rng.uniform(0.3, 0.8) * flights[k], "spurious", -1))
    if release:
        events.append((true_times[0] - fall_time, "release", -1))
    t_last = true_times[-1]
    for _ in range(junk_end):
        t_last += rng.uniform(0.1, 0.8)
        events.append((t_last, "junk", -1))
    events.sort(key=lambda e: e[0])
    times = np.array([e[0] for e in events])
    if jitter > 0:
        times = times + rng.normal(0.0, jitter, times.size)
    if resolution > 0:
        times = np.round(times / resolution) * resolution
    order = np.argsort(times, kind="stable")
    times = times[order]
    labels = tuple(events[i][1] for i in order)
    index = np.array([events[i][2] for i in order], dtype=int)
    keep = np.concatenate([[True], np.diff(times) > 0])  # a trigger cannot repeat at the same sample
    return times[keep], tuple(lab for lab, k in zip(labels, keep) if k), index[keep], tuple(sorted(missed_set))


def synth_drop(law: str | Callable = "linear", params: Mapping[str, float] | None = None, *, seed: int = 0,
               ball: Ball | None = None, drag: bool = True, height: float = 0.3, min_flight: float = 0.1,
               jitter: float = 0.0, resolution: float = 1.0 / 48000, missed: int = 0, echoes: int = 0,
               spurious: int = 0, displaced: int = 0, displacement: float = 0.01, release: bool = False,
               junk_end: int = 0, first_impact: float | None = None, scatter: float = 0.0) -> SynthDrop:
    """A synthetic drop with faults: :func:`simulate_drop` then :func:`inject_faults` (same arguments)."""
    rng = np.random.default_rng(seed)
    start = float(first_impact) if first_impact is not None else float(rng.uniform(0.4, 1.2))
    sim = simulate_drop(law, params, ball=ball, drag=drag, height=height, first_impact=start, min_flight=min_flight,
                        scatter=scatter, rng=rng)
    times, labels, index, missed_idx = inject_faults(
        sim["times"], rng, jitter=jitter, resolution=resolution, missed=missed, echoes=echoes, spurious=spurious,
        displaced=displaced, displacement=displacement, release=release, fall_time=sim["fall_time"],
        junk_end=junk_end)
    c = flight_constants(ball, drag)
    truth = {"law": law if isinstance(law, str) else "callable", "params": dict(params or {}),
             "ball": ball.to_dict() if ball is not None else None, "drag": bool(drag and ball is not None),
             "constants": c.to_dict(), "height_m": height, "jitter_s": jitter, "resolution_s": resolution,
             "scatter": scatter,
             "seed": seed}
    return SynthDrop(times=times, labels=labels, impact_index=index, true_times=sim["times"],
                     impact_speeds=sim["v"], launch_speeds=sim["u"], restitution=sim["e"], missed=missed_idx,
                     truth=truth)


# ---- files ---------------------------------------------------------------------------------------


def _phyphox_intervals(times: np.ndarray) -> np.ndarray:
    """phyphox's ``Interval (s)`` column: the time to the next event, 0 after the last."""
    return np.append(np.diff(times), 0.0)


def write_phyphox_xlsx(path: str | os.PathLike[str], times: Sequence[float]) -> Path:
    """Write ``times`` [s] as a phyphox "Acoustic stopwatch" Excel export (sheets ``All`` and
    ``Metadata Device``)."""
    times = np.asarray(times, dtype=float)
    frame = pd.DataFrame({"Event time (s)": times, "Interval (s)": _phyphox_intervals(times)})
    meta = pd.DataFrame({"property": ["version", "model"], "value": ["synthetic", "impactid.rigs.ball.synth"]})

    def write(tmp: Path) -> None:
        with pd.ExcelWriter(tmp, engine="openpyxl") as writer:
            frame.to_excel(writer, sheet_name="All", index=False)
            meta.to_excel(writer, sheet_name="Metadata Device", index=False)

    return atomic_write(path, write)


def java_scientific(value: float, decimal: str = ".") -> str:
    """``value`` as Java's ``DecimalFormat("0.000000000E0")`` writes it (phyphox's CSV numbers),
    e.g. ``6.943541667E-1``."""
    if not math.isfinite(value):
        return "NaN"
    if value == 0.0:
        text = "0.000000000E0"
    else:
        exponent = int(math.floor(math.log10(abs(value))))
        mantissa = round(value / 10.0 ** exponent, 9)
        if abs(mantissa) >= 10.0:
            mantissa /= 10.0
            exponent += 1
        text = f"{mantissa:.9f}E{exponent}"
    return text.replace(".", decimal)


def write_phyphox_csv(path: str | os.PathLike[str], times: Sequence[float], *, separator: str = ",",
                      decimal: str = ".", zipped: bool = False) -> Path:
    """Write ``times`` [s] as phyphox writes its CSV export of the ``All`` set: quoted header,
    ``separator`` (``,``, ``\\t`` or ``;``), ``decimal`` (``.`` or ``,``; phyphox pairs a decimal comma
    only with tab or semicolon); ``zipped`` writes phyphox's ZIP archive (``All.csv`` plus
    ``meta/device.csv``)."""
    if separator == "," and decimal == ",":
        raise ValueError("phyphox never writes a decimal comma with a comma separator")
    times = np.asarray(times, dtype=float)
    rows = [f'"Event time (s)"{separator}"Interval (s)"']
    rows += [f"{java_scientific(t, decimal)}{separator}{java_scientific(d, decimal)}"
             for t, d in zip(times, _phyphox_intervals(times))]
    text = "\n".join(rows) + "\n"
    if not zipped:
        return atomic_write(path, text)

    def write(tmp: Path) -> None:
        with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as archive:
            archive.writestr("All.csv", text)
            archive.writestr("meta/device.csv", f'"property"{separator}"value"\n"model"{separator}"synthetic"\n')

    return atomic_write(path, write)


def write_event_csv(path: str | os.PathLike[str], times: Sequence[float], *, header: str | None = "time (s)") -> Path:
    """Write a plain CSV of event times [s], one per line, with an optional header."""
    lines = ([header] if header else []) + [repr(float(t)) for t in times]
    return atomic_write(path, "\n".join(lines) + "\n")


def write_drop(path: str | os.PathLike[str], drop: SynthDrop, *, seed: int = 0) -> Path:
    """Write a synthetic drop as the file its suffix names (:data:`DROP_FORMATS`), atomically.

    Parameters
    ----------
    path : ``.csv`` (the observed event times [s], one per line, under a ``time (s)`` header),
        ``.xlsx`` (the observed event times as a phyphox "Acoustic stopwatch" export) or ``.wav``
        (the true impacts as clicks, amplitude proportional to the impact speed, 48 kHz 16-bit:
        :func:`synth_audio`; the trigger faults of the drop are not rendered, the reader's onset
        detector has its own).
    drop : from :func:`synth_drop`.
    seed : seed of the audio's phases and background noise (``.wav`` only).

    Raises
    ------
    ValueError : an unknown suffix.
    """
    suffix = Path(path).suffix.lower()
    if suffix == ".csv":
        return write_event_csv(path, drop.times)
    if suffix == ".xlsx":
        return write_phyphox_xlsx(path, drop.times)
    if suffix == ".wav":
        rate = 48000.0
        count = min(drop.true_times.size, drop.impact_speeds.size)
        audio = synth_audio(drop.true_times[:count], drop.impact_speeds[:count], sample_rate=rate,
                            rng=np.random.default_rng(seed))
        return write_wav(path, audio, rate)
    raise ValueError(f"{os.fspath(path)}: unknown suffix {suffix or '(none)'!r}; a drop is written as "
                     f"{', '.join(DROP_FORMATS)}")


# ---- audio ---------------------------------------------------------------------------------------

#: Default click resonances: (frequency [Hz], decay time [s], relative amplitude).
CLICK_MODES = ((3900.0, 1.2e-3, 1.0), (6100.0, 0.6e-3, 0.6), (1500.0, 4.0e-3, 0.35))


def synth_audio(impact_times: Sequence[float], impact_speeds: Sequence[float], *, sample_rate: float = 48000.0,
                duration: float | None = None, rng: np.random.Generator | None = None,
                modes: Sequence[tuple[float, float, float]] = CLICK_MODES, rise: float = 50e-6,
                level: float = 0.3, echoes: Sequence[tuple[float, float]] = ((0.0041, 0.35), (0.0113, 0.2)),
                noise_db: float = -40.0, hum: float = 0.0, clip: float | None = None, channels: int = 1,
                extra_clicks: Sequence[tuple[float, float]] = (), clicks_per_contact: tuple[int, int] = (1, 1),
                click_spacing: tuple[float, float] = (0.4e-3, 2.5e-3),
                click_amplitudes: tuple[float, float] = (0.25, 0.7),
                ringing: tuple[float, float, float] | None = None) -> np.ndarray:
    """Audio of a drop: one contact per impact (and per ``extra_clicks`` entry ``(time, speed)``).

    Parameters
    ----------
    impact_times, impact_speeds : [s], [m/s]; click amplitude is proportional to the speed.
    sample_rate : [Hz].
    duration : [s]; default 0.5 s after the last click.
    modes : the click's damped resonances (frequency [Hz], decay time [s], amplitude).
    rise : rise time of the click's envelope [s].
    level : peak amplitude of a click at the fastest impact [full scale], before clipping.
    echoes : room echoes (delay [s], relative amplitude): delayed attenuated copies of every contact.
    noise_db : white background noise RMS relative to ``level`` [dB] (-20: a signal-to-noise ratio of
        20 dB at the loudest click).
    hum : amplitude of a 50 Hz hum and its harmonics [full scale].
    clip : clip the signal at this amplitude (e.g. 1.0 after raising ``level``), None for no clipping.
    channels : 1 or 2; the second channel has 0.8 x the gain, a 0.1 ms delay and its own noise.
    clicks_per_contact : (fewest, most) clicks of one contact (drawn uniformly per contact): the
        first at the impact, the others ``click_spacing`` [s] apart (the ball rattling on the floor,
        the shell's rebound), each weaker than the first by a factor drawn from ``click_amplitudes``.
    click_spacing : (shortest, longest) time between two clicks of one contact [s].
    click_amplitudes : (smallest, largest) amplitude of a later click relative to the first.
    ringing : ``(frequency [Hz], decay time [s], amplitude relative to the click)``: the surface
        ringing after every contact (a long decaying tone), None for none.

    Returns
    -------
    (n,) for one channel, (n, channels) otherwise, full scale 1.
    """
    rng = rng if rng is not None else np.random.default_rng(0)
    times = np.asarray(list(impact_times) + [t for t, _ in extra_clicks], dtype=float)
    speeds = np.asarray(list(impact_speeds) + [v for _, v in extra_clicks], dtype=float)
    fs = float(sample_rate)
    total = float(duration) if duration is not None else float(times.max() + 0.5)
    n = int(round(total * fs))
    t = np.arange(n) / fs
    vmax = float(np.max(impact_speeds)) if len(impact_speeds) else 1.0
    # the clicks of every contact: (time, amplitude relative to the contact's first click, its phases)
    clicks: list[tuple[float, float, np.ndarray, float]] = []
    lo, hi = int(clicks_per_contact[0]), int(clicks_per_contact[1])
    if not 1 <= lo <= hi:
        raise ValueError(f"clicks_per_contact must be (fewest, most), 1 <= fewest <= most: {clicks_per_contact}")
    for t0, v in zip(times, speeds):
        count = int(rng.integers(lo, hi + 1))
        offset = 0.0
        for c in range(count):
            if c:
                offset += float(rng.uniform(*click_spacing))
            weight = 1.0 if c == 0 else float(rng.uniform(*click_amplitudes))
            clicks.append((t0 + offset, weight * v / vmax, rng.uniform(0, 2 * np.pi, size=len(modes)), t0))
    tones = [] if ringing is None else [(float(ringing[0]), float(ringing[1]), float(ringing[2]))]
    longest = max([tau for _, tau, _ in modes] + [tau for _, tau, _ in tones])
    span = int(10 * longest * fs) + 1
    ring_phase = rng.uniform(0, 2 * np.pi, size=times.size)
    out = np.zeros((n, channels))
    for ch in range(channels):
        gain = 1.0 if ch == 0 else 0.8
        delay = 0.0 if ch == 0 else 1e-4
        for tc, a_click, phases, _ in clicks:
            for d, a in ((0.0, 1.0),) + tuple(echoes):
                _add_burst(out[:, ch], t, fs, tc + delay + d, gain * a * level * a_click, modes, phases, rise, span)
        for k, (t0, v) in enumerate(zip(times, speeds)):
            for f, dec, w in tones:
                _add_burst(out[:, ch], t, fs, t0 + delay, gain * level * v / vmax, ((f, dec, w),),
                           ring_phase[k:k + 1], 4 * rise, span)
        out[:, ch] += level * 10 ** (noise_db / 20.0) * rng.standard_normal(n)
        if hum:
            out[:, ch] += hum * (np.sin(2 * np.pi * 50 * t) + 0.3 * np.sin(2 * np.pi * 150 * t + 1.0))
    if clip is not None:
        out = np.clip(out, -clip, clip)
    return out[:, 0] if channels == 1 else out


def _add_burst(out: np.ndarray, t: np.ndarray, fs: float, start: float, amplitude: float,
               modes: Sequence[tuple[float, float, float]], phases: np.ndarray, rise: float, span: int) -> None:
    """Add to ``out`` (samples at times ``t`` [s]) one burst of decaying sinusoids (``modes``:
    frequency [Hz], decay time [s], weight) starting at ``start`` [s] with a rise time ``rise`` [s]."""
    i0 = int(math.ceil(start * fs))
    if i0 >= out.size:
        return
    seg = slice(max(i0, 0), min(i0 + span, out.size))
    tau = t[seg] - start
    shape = (1.0 - np.exp(-tau / rise)) * sum(
        w * np.exp(-tau / dec) * np.sin(2 * np.pi * f * tau + phases[m]) for m, (f, dec, w) in enumerate(modes))
    out[seg] += amplitude * shape


#: A phone on a hard floor in a room (arguments of :func:`synth_audio`): two to four clicks per
#: contact, two room echoes, the floor ringing at 2.3 kHz for tens of milliseconds, background noise
#: 20 dB below the loudest click and its peaks clipped at full scale.
ROOM_AUDIO = {"clicks_per_contact": (2, 4), "echoes": ((0.0041, 0.35), (0.0113, 0.2)),
              "ringing": (2300.0, 0.03, 0.2), "noise_db": -20.0, "level": 1.1, "clip": 1.0}


def write_wav(path: str | os.PathLike[str], samples: np.ndarray, sample_rate: float, encoding: str = "int16") -> Path:
    """Write audio (full scale 1) as a WAV file: ``encoding`` ``int16``, ``int24``, ``int32`` or
    ``float32``. Integer encodings are clipped to full scale."""
    x = np.asarray(samples, dtype=float)
    x2 = x[:, None] if x.ndim == 1 else x
    rate = int(round(sample_rate))
    if encoding == "float32":
        data = x2.astype("<f4")
        return _write_riff(path, data.tobytes(), rate, x2.shape[1], 32, 3)
    bits = {"int16": 16, "int24": 24, "int32": 32}.get(encoding)
    if bits is None:
        raise ValueError(f"unknown encoding {encoding!r}; valid: int16, int24, int32, float32")
    full = 2 ** (bits - 1)
    q = np.clip(np.round(x2 * full), -full, full - 1).astype(np.int64)
    if bits == 24:
        raw = q.astype("<i4").view(np.uint8).reshape(-1, 4)[:, :3].tobytes()
    else:
        raw = q.astype("<i2" if bits == 16 else "<i4").tobytes()
    return _write_riff(path, raw, rate, x2.shape[1], bits, 1)


def _write_riff(path, raw: bytes, rate: int, channels: int, bits: int, tag: int) -> Path:
    block = channels * bits // 8
    fmt = struct.pack("<HHIIHH", tag, channels, rate, rate * block, block, bits)
    body = b"WAVE" + b"fmt " + struct.pack("<I", len(fmt)) + fmt + b"data" + struct.pack("<I", len(raw)) + raw
    if len(raw) % 2:
        body += b"\x00"
    return atomic_write(path, b"RIFF" + struct.pack("<I", len(body)) + body)

"""The click detector on synthetic audio with known impact times.

Measured here (and quoted in docs/bounces.md): with clicks of random phase in three damped
resonances, two room echoes, white noise 40 dB below the loudest click and mains hum, the onsets
carry a constant offset of a few tens of microseconds and a scatter of about 40 us (2 samples);
intervals are good to about 0.1 ms, ten times better than an acoustic stopwatch's triggers.
"""

import numpy as np
import pytest

from impactid.rigs.ball import TABLE_TENNIS, detect_onsets, read_bounces
from impactid.rigs.ball.sequence import clean_sequence
from impactid.rigs.ball.synth import simulate_drop, synth_audio, write_wav


@pytest.fixture(scope="module")
def drop():
    sim = simulate_drop("linear", {"e0": 0.96, "gamma": 0.01}, ball=TABLE_TENNIS, height=0.3, first_impact=0.3,
                        min_flight=0.08)
    speeds = np.r_[np.sqrt(2 * 9.81 * 0.3), sim["v"][: sim["times"].size - 1]]
    return sim["times"], speeds


def _errors(found, true):
    assert found.size == true.size, (found.size, true.size)
    err = found - true
    return err, np.diff(found) - np.diff(true)


#: the combinations the fast loop (``pytest -m "not slow"``) keeps: every channel count, encoding and rate once
FAST_WAV = {(1, "int16", 44100), (2, "int24", 48000), (1, "float32", 48000)}


@pytest.mark.parametrize(("channels", "encoding", "rate"), [
    pytest.param(c, e, r, marks=() if (c, e, r) in FAST_WAV else pytest.mark.slow)
    for c in (1, 2) for e in ("int16", "int24", "float32") for r in (44100, 48000)])
def test_onsets_from_wav_after_cleaning(tmp_path, drop, rate, encoding, channels):
    true, speeds = drop
    x = synth_audio(true, speeds, sample_rate=rate, rng=np.random.default_rng(rate + channels), channels=channels,
                    hum=0.01)
    rec = read_bounces(write_wav(tmp_path / "d.wav", x, rate, encoding))
    seq = clean_sequence(rec.times, name=rec.name)
    found = rec.times[seq.accepted]
    err, derr = _errors(found, true)
    assert abs(np.mean(err)) < 1e-4                 # constant offset below 0.1 ms
    assert np.std(err) < 1e-4                       # scatter below 0.1 ms (measured: ~40 us)
    assert np.sqrt(np.mean(derr ** 2)) < 1.5e-4     # interval error
    assert np.all(rec.onsets.confidence[np.isin(rec.times, found)] > 0.0)


def test_clean_recording_without_echo_needs_no_cleaning(drop):
    true, speeds = drop
    x = synth_audio(true, speeds, sample_rate=48000, rng=np.random.default_rng(3), echoes=(), noise_db=-50)
    on = detect_onsets(x, 48000)
    err, derr = _errors(on.times, true)
    assert np.std(err) < 6e-5 and np.max(np.abs(derr)) < 2.5e-4
    assert on.refractory > on.ring_down * 0.99 and np.isfinite(on.shortest_flight)


def test_clipping_does_not_move_the_onsets(drop):
    true, speeds = drop
    rng = np.random.default_rng(5)
    clipped = synth_audio(true, speeds, sample_rate=48000, rng=rng, level=1.5, clip=1.0, echoes=())
    on = detect_onsets(clipped, 48000)
    err, _ = _errors(on.times, true)
    assert np.std(err) < 1e-4


@pytest.mark.parametrize("delay", [0.006, 0.02])
def test_echoes_do_not_make_onsets(drop, delay):
    """An early echo is part of its click's ring-down (hysteresis); a later one is suppressed as too
    loud for so short a flight, except after the last, short flights, where the cleaning (which
    knows the flights) rejects it."""
    true, speeds = drop
    x = synth_audio(true, speeds, sample_rate=48000, rng=np.random.default_rng(7), echoes=((delay, 0.4),),
                    noise_db=-50)
    on = detect_onsets(x, 48000)
    seq = clean_sequence(on.times)
    err, _ = _errors(on.times[seq.accepted], true)
    assert np.std(err) < 1e-4
    if delay > 0.01:
        assert on.suppressed.size >= true.size // 2
        assert set(seq.status) <= {"impact", "echo", "end"}  # an echo after the last impact is "end"


def test_threshold_follows_the_noise_not_the_amplitude(drop):
    true, speeds = drop
    quiet = synth_audio(true, speeds, sample_rate=48000, rng=np.random.default_rng(1), level=0.01, echoes=())
    loud = synth_audio(true, speeds, sample_rate=48000, rng=np.random.default_rng(1), level=0.5, echoes=())
    a, b = detect_onsets(quiet, 48000), detect_onsets(loud, 48000)
    assert b.threshold / a.threshold == pytest.approx(50.0, rel=0.05)  # scales with the noise floor
    assert a.times.size == b.times.size == true.size


def test_bad_arguments():
    x = np.zeros(4800)
    with pytest.raises(ValueError, match="band"):
        detect_onsets(x, 8000, band=(100, 5000))
    with pytest.raises(ValueError, match="fraction"):
        detect_onsets(x, 8000, fraction=1.5)

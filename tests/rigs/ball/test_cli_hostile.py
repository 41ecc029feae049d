"""``impactid bounces`` on hostile input: every failure is one line ``impactid: error: ...`` naming
the file (exit 2), nothing hangs, nothing is counted twice, memory follows the input's size.

One test (or a few) per class of failure a hostile probe found: absurd times that once sent
LAPACK into an endless loop deaf to SIGTERM and Ctrl-C; a named pipe that blocked the reader; event
counts and WAV files whose memory grew without bound; one recording given twice; a WAV sampled too
slowly for the click detector; milliseconds read as seconds.
"""

from __future__ import annotations

import os
import resource
import shutil
import signal
import struct
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from impactid._files import DuplicateInputError
from impactid.cli import main
from impactid.errors import ImpactidError
from impactid.rigs.ball import (
    TABLE_TENNIS,
    BounceAnalysisError,
    BounceFileError,
    BounceRecording,
    analyse_bounces,
    readers,
)
from impactid.rigs.ball.onsets import BLOCK_FRAMES, envelope, memory_needed, min_sample_rate
from impactid.rigs.ball.readers import MAX_EVENTS, MAX_MEMORY, check_file, read_bounces
from impactid.rigs.ball.sequence import _fit_ratio, clean_sequence
from impactid.rigs.ball.synth import simulate_drop, synth_audio, synth_drop, write_phyphox_xlsx, write_wav

#: The event times [s] of a table-tennis drop (15 impacts from 0.69 s, on phyphox's 1/48000 s grid).
DROP = np.round(simulate_drop("linear", {"e0": 0.96, "gamma": 0.02}, ball=TABLE_TENNIS, height=0.12,
                              first_impact=0.69, min_flight=0.12)["times"] * 48000) / 48000


def _run(argv, capsys) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


@pytest.fixture(params=["soundfile", "scipy"])
def audio_reader(request, monkeypatch):
    """Each audio test twice: samples read by soundfile (libsndfile), and by scipy.io.wavfile as
    where soundfile cannot be imported."""
    if request.param == "soundfile":
        if readers.soundfile is None:
            pytest.skip("soundfile cannot be imported here")
    else:
        monkeypatch.setattr(readers, "soundfile", None)
    return request.param


def _one_error_line(err: str) -> str:
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("impactid: error: ") and "Traceback" not in err, err
    return lines[0]


def _csv(path: Path, times, header: str | None = "time") -> Path:
    body = "\n".join(repr(float(t)) for t in np.asarray(times, dtype=float))
    path.write_text((f"{header}\n" if header is not None else "") + body + "\n")
    return path


def _default_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_DFL)  # a child of a background job may inherit SIGINT ignored


def _impactid(*argv) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "impactid.cli", *map(str, argv)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, preexec_fn=_default_sigint)


def _finish(proc: subprocess.Popen, timeout: float = 120.0) -> tuple[str, str]:
    """Output of a process that must end by itself within ``timeout`` [s] (a hang guard, generous for
    a loaded machine: these end in the time of the imports); killed and failed otherwise."""
    try:
        return proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate()
        pytest.fail(f"impactid did not end within {timeout:g} s (killed)")


def test_ball_errors_are_impactid_errors():
    for kind in (BounceFileError, BounceAnalysisError, DuplicateInputError):
        assert issubclass(kind, ImpactidError)


# ---- 1. absurd times: refused before any numerics; nothing loops forever; signals are heard ------


@pytest.mark.parametrize("times,token", [
    (DROP * 1e300, "beyond +/-1e+10 s"),                           # overflows when squared: LAPACK once hung
    (DROP * 1e12, "beyond +/-1e+10 s"),
    (np.r_[DROP, DROP[-1] + 4000.0], "span"),                      # a drop does not last an hour
    (np.r_[DROP[:5], np.inf, DROP[6:]], "NaN or empty"),
])
def test_absurd_times_are_refused_naming_the_file(tmp_path, capsys, times, token):
    path = _csv(tmp_path / "drop.csv", times)
    code, out, err = _run(["bounces", path], capsys)
    line = _one_error_line(err)
    assert code == 2 and str(path) in line and token in line, line
    assert out == ""


def test_times_of_1e300_end_at_once_in_a_subprocess(tmp_path):
    """The probe's file: no overflow warnings, no LAPACK message on stdout, no endless loop."""
    path = _csv(tmp_path / "big.csv", DROP * 1e300)
    proc = _impactid("bounces", path)
    out, err = _finish(proc)
    assert proc.returncode == 2
    assert out == "", (out, err)  # LAPACK wrote "DLASCL parameter number 4 had an illegal value" there
    line = _one_error_line(err)
    assert str(path) in line and "warning" not in err


def test_the_cleaning_never_hands_non_finite_numbers_to_lapack(monkeypatch):
    """Direct callers of the library: huge intervals are refused; a design that overflows drops to
    a lower degree, one that cannot be made finite gives no model, and LAPACK never sees either."""
    real = np.linalg.lstsq
    seen = []

    def checked(a, b, *args, **kwargs):
        seen.append(bool(np.all(np.isfinite(a)) and np.all(np.isfinite(b))))
        assert seen[-1], "non-finite numbers reached LAPACK"
        return real(a, b, *args, **kwargs)

    monkeypatch.setattr(np.linalg, "lstsq", checked)
    with pytest.raises(ValueError, match="beyond any flight"):
        clean_sequence(DROP * 1e200)
    prev = np.geomspace(1e120, 2e120, 12)  # finite, but its cube overflows: a line is fitted instead
    coef, _ = _fit_ratio(prev, prev * 0.9)
    assert np.all(np.isfinite(coef)) and abs(np.polyval(coef, prev[0]) - 0.9) < 1e-9
    prev[3] = np.inf
    coef, scale = _fit_ratio(prev, prev * 0.9)
    assert np.isnan(coef).all() and np.isnan(scale)
    assert seen and all(seen)


def _sigcgt(pid: int) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("SigCgt:"):
            return int(line.split()[1], 16)
    return 0


def _cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="needs /proc")
@pytest.mark.parametrize("signum,code,word", [(signal.SIGTERM, 143, "terminated"), (signal.SIGINT, 130,
                                                                                     "interrupted")])
def test_signals_stop_the_longest_cleaning(tmp_path, signum, code, word):
    """The costliest input one drop may be (MAX_EVENTS random triggers: the cleaning tries every
    start for its full rounds) is still stopped by SIGTERM and Ctrl-C, promptly."""
    rng = np.random.default_rng(7)
    path = _csv(tmp_path / "noise.csv", np.sort(rng.uniform(0.0, 100.0, MAX_EVENTS)))
    out = tmp_path / "r.json"
    proc = _impactid("bounces", path, "--out", out)
    try:
        # signal once the command's handlers are in place (SIGTERM caught: SigCgt bit 15), however
        # long the imports take on a loaded machine; then let it compute for a moment
        deadline = time.time() + 180
        while proc.poll() is None and time.time() < deadline and not _sigcgt(proc.pid) >> (signal.SIGTERM - 1) & 1:
            time.sleep(0.05)
        time.sleep(1.0)
        assert proc.poll() is None, proc.communicate()
        cpu_at_signal = _cpu_seconds(proc.pid)
        children_before = resource.getrusage(resource.RUSAGE_CHILDREN)
        proc.send_signal(signum)
        _, err = proc.communicate(timeout=120)  # a hang guard, not the measure
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    children_after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu_total = (children_after.ru_utime - children_before.ru_utime) + (children_after.ru_stime
                                                                        - children_before.ru_stime)
    assert proc.returncode == code, err
    assert _one_error_line(err).startswith(f"impactid: error: {word}")
    assert cpu_total - cpu_at_signal < 5.0, (cpu_total, cpu_at_signal)
    assert not out.exists() and not list(tmp_path.glob("*.tmp"))


# ---- 2. special files are refused before they are opened ----------------------------------------


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="named pipes are POSIX")
def test_named_pipe_is_refused_without_blocking(tmp_path):
    fifo = tmp_path / "drop.csv"
    os.mkfifo(fifo)
    link = tmp_path / "link.csv"
    link.symlink_to(fifo)
    with pytest.raises(BounceFileError, match="named pipe"):
        check_file(fifo)  # never opens it
    for target in (fifo, link):
        proc = _impactid("bounces", target)
        out, err = _finish(proc)  # a reader of the pipe would wait for a writer forever
        line = _one_error_line(err)
        assert proc.returncode == 2 and str(target) in line and "named pipe" in line, err


@pytest.mark.parametrize("special,token", [("/dev/null", "character device"), ("DIR", "is a directory")])
def test_devices_and_folders_are_refused(tmp_path, capsys, special, token):
    target = tmp_path if special == "DIR" else Path(special)
    if not target.exists():
        pytest.skip(f"no {special}")
    good = _csv(tmp_path / "drop.csv", DROP)
    code, _, err = _run(["bounces", good, target], capsys)
    line = _one_error_line(err)
    assert code == 2 and str(target) in line and token in line
    with pytest.raises(BounceFileError, match=token):
        read_bounces(target)


# ---- 3. memory: bounded by the input's size, refused with the number beyond the budget ------------


def test_more_events_than_a_drop_are_refused_before_parsing(tmp_path, capsys):
    path = tmp_path / "million.csv"
    path.write_text("time\n" + "\n".join(f"{k * 1e-3:.3f}" for k in range(1, 100_001)) + "\n")
    code, _, err = _run(["bounces", path], capsys)
    line = _one_error_line(err)
    assert code == 2 and str(path) in line and f"at most {MAX_EVENTS}" in line
    with pytest.raises(BounceFileError, match="more than one drop"):
        BounceRecording.from_times(np.arange(1, MAX_EVENTS + 2) * 0.01)
    with pytest.raises(ValueError, match="more than one drop"):
        clean_sequence(np.arange(1, MAX_EVENTS + 2) * 0.01)


def _wav_header(channels: int, rate: int, bits: int, data_bytes: int) -> bytes:
    block = channels * bits // 8
    fmt = struct.pack("<HHIIHH", 1, channels, rate, rate * block, block, bits)
    return (b"RIFF" + struct.pack("<I", 4 + 8 + len(fmt) + 8 + data_bytes) + b"WAVE" + b"fmt "
            + struct.pack("<I", len(fmt)) + fmt + b"data" + struct.pack("<I", data_bytes))


def test_wav_beyond_the_memory_budget_is_refused_from_its_header(tmp_path, capsys, audio_reader):
    """A (sparse) WAV of 4 GB of stereo audio, about 6 hours: refused with the memory it needs and
    the limit, before a sample is read (soundfile holds the samples in memory, scipy maps them)."""
    path = tmp_path / "long.wav"
    data_bytes = 0xFFFF_0000
    with open(path, "wb") as fh:
        fh.write(_wav_header(2, 48000, 16, data_bytes))
        fh.truncate(44 + data_bytes)  # a hole: no disk space is used
    need = memory_needed(data_bytes // 4, 2, 2) + (data_bytes if audio_reader == "soundfile" else 0)
    assert need > MAX_MEMORY
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    code, _, err = _run(["bounces", path], capsys)
    line = _one_error_line(err)
    assert code == 2 and str(path) in line and "MiB of memory" in line and f"{need / 2 ** 20:,.0f} MiB" in line
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 100_000  # kB: nothing read


def test_blockwise_envelope_is_the_single_pass_one():
    """The envelope computed a block at a time (from the stored integers) is the one a single pass
    over the whole recording gives, to single precision."""
    sim = simulate_drop("constant", {"e": 0.9}, ball=TABLE_TENNIS, height=0.2, first_impact=0.2, min_flight=0.06)
    speeds = np.r_[2.0, sim["v"][: sim["times"].size - 1]]
    x = synth_audio(sim["times"], speeds, rng=np.random.default_rng(5), channels=2, hum=0.01)
    stored = np.round(x * 32768).clip(-32768, 32767).astype(np.int16)
    whole = envelope(stored / 32768.0, 48000.0, (800.0, 12000.0), 0.25e-3, block_frames=stored.shape[0])
    blocks = envelope(stored, 48000.0, (800.0, 12000.0), 0.25e-3, scale=2.0 ** -15, block_frames=4099)
    assert whole.dtype == np.float32 and blocks.shape == whole.shape
    assert np.max(np.abs(blocks - whole)) <= 1e-6 * np.max(whole)


_MEMORY_PROBE = textwrap.dedent("""
    import resource, sys
    from impactid.rigs.ball.readers import read_bounces
    read_bounces(sys.argv[1])  # imports and warms everything on a short file
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    rec = read_bounces(sys.argv[2])
    print(rec.times.size, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before)
""")


def test_long_stereo_wav_is_read_in_memory_proportional_to_the_file(tmp_path):
    """Two minutes of stereo audio (23 MB): the peak memory grows by a few times the file, not the
    21 times of reading it whole into double precision."""
    rate, minutes = 48000, 2.0
    sim = simulate_drop("constant", {"e": 0.9}, ball=TABLE_TENNIS, height=0.2, first_impact=0.2, min_flight=0.06)
    speeds = np.r_[2.0, sim["v"][: sim["times"].size - 1]]
    short = write_wav(tmp_path / "short.wav", synth_audio(sim["times"], speeds, rng=np.random.default_rng(1),
                                                          channels=2), rate)
    drop = np.round(synth_audio(sim["times"], speeds, rng=np.random.default_rng(2), channels=2, duration=5.0)
                    * 32768).clip(-32768, 32767).astype("<i2")
    frames = int(minutes * 60 * rate)
    rng = np.random.default_rng(3)
    path = tmp_path / "long.wav"
    with open(path, "wb") as fh:
        fh.write(_wav_header(2, rate, 16, frames * 4))
        fh.write(drop.tobytes())
        for start in range(drop.shape[0], frames, 1 << 20):
            m = min(1 << 20, frames - start)
            fh.write(np.round(rng.normal(0.0, 0.003, (m, 2)) * 32768).astype("<i2").tobytes())
    size_kb = path.stat().st_size / 1024
    proc = subprocess.run([sys.executable, "-c", _MEMORY_PROBE, str(short), str(path)], capture_output=True,
                          text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    clicks, grown_kb = (int(v) for v in proc.stdout.split())
    assert clicks >= sim["times"].size
    assert grown_kb < 6 * size_kb, (grown_kb, size_kb)


def test_memory_estimate_grows_with_the_frames_only():
    assert memory_needed(10 * BLOCK_FRAMES, 2, 2) - memory_needed(5 * BLOCK_FRAMES, 2, 2) == 8 * 5 * BLOCK_FRAMES


# ---- 4. one recording given twice ----------------------------------------------------------------


def test_the_same_recording_twice_is_refused(tmp_path, capsys):
    first = _csv(tmp_path / "a.csv", DROP)
    copy = tmp_path / "copy.csv"
    shutil.copyfile(first, copy)
    link = tmp_path / "link.csv"
    link.symlink_to(first)
    xlsx = write_phyphox_xlsx(tmp_path / "a.xlsx", DROP)  # the same data in another format
    for pair in ((first, first), (first, copy), (first, link), (first, xlsx)):
        code, _, err = _run(["bounces", *pair, "--no-chained"], capsys)
        line = _one_error_line(err)
        assert code == 2 and str(pair[1]) in line and "twice" in line, line
    with pytest.raises(DuplicateInputError):
        analyse_bounces([DROP, DROP.copy()], chained=False)


# ---- 5. a WAV sampled too slowly for the click detector -------------------------------------------


@pytest.mark.parametrize("rate", [1000, 1777])
def test_wav_below_the_detector_rate_is_refused(tmp_path, capsys, rate, audio_reader):
    rng = np.random.default_rng(rate)
    x = rng.normal(0.0, 0.01, 2 * rate)
    x[:: rate // 3] += 0.5
    path = write_wav(tmp_path / "slow.wav", x, rate)
    code, _, err = _run(["bounces", path], capsys)
    line = _one_error_line(err)
    assert code == 2 and str(path) in line and f"{rate} Hz" in line and "at least 1778 Hz" in line, line
    assert 1777 < min_sample_rate() < 1778


# ---- 6. times in another unit than the one read ----------------------------------------------------


@pytest.mark.parametrize("times,header,hint", [
    (DROP * 1e3, "time", "'time (ms)'"),              # milliseconds under a plain header
    (DROP * 1e3, None, "a header line, e.g. 'time (ms)'"),
    (DROP * 1e6, "t", "'t (us)'"),                    # microseconds
    (DROP, "time (ms)", "'time (s)'"),                # seconds under a millisecond header
])
def test_times_in_another_unit_are_refused_naming_the_column(tmp_path, capsys, times, header, hint):
    path = _csv(tmp_path / "drop.csv", times, header)
    code, _, err = _run(["bounces", path], capsys)
    line = _one_error_line(err)
    assert code == 2 and str(path) in line and hint in line, line
    assert "column" in line and "not in" in line


def test_the_unit_in_the_header_is_honoured(tmp_path, capsys):
    drops = [synth_drop("linear", {"e0": 0.96, "gamma": 0.02}, seed=s, ball=TABLE_TENNIS, height=h, min_flight=0.1)
             for s, h in ((1, 0.15), (2, 0.25))]
    paths = [_csv(tmp_path / f"drop{j}.csv", d.times * 1e3, "time (ms)") for j, d in enumerate(drops)]
    code, out, err = _run(["bounces", *paths, "--no-chained", "--json"], capsys)
    assert code == 0, err
    assert '"drops_analysed": 2' in out


def test_a_line_of_millions_of_fields_is_refused_before_it_is_split(tmp_path, capsys):
    """A 6 MB CSV whose one line holds 3 million fields: refused from a count of its separators
    (splitting it into Python lists would take gigabytes)."""
    path = tmp_path / "wide.csv"
    path.write_text("time\n" + ",".join(["0"] * 3_000_000) + "\n")
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    code, out, err = _run(["bounces", path], capsys)
    line = _one_error_line(err)
    assert code == 2 and "wide.csv" in line and "3,000,000 fields" in line and out == ""
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 500_000  # kB: far below the gigabytes


@pytest.mark.parametrize("encoding", ["int16", "int24", "float32"])
def test_a_truncated_wav_is_refused_naming_the_file_and_what_is_missing(tmp_path, capsys, audio_reader, encoding):
    times = np.cumsum(0.5 * 0.9 ** np.arange(12))
    full = write_wav(tmp_path / "full.wav", synth_audio(times, 3.0 * 0.9 ** np.arange(12), sample_rate=44100), 44100,
                     encoding)
    cut = tmp_path / "cut.wav"
    size = full.stat().st_size
    cut.write_bytes(full.read_bytes()[: size // 3])
    code, out, err = _run(["bounces", cut], capsys)
    line = _one_error_line(err)
    assert code == 2 and "cut.wav" in line and "truncated" in line and f"announces {size:,} bytes" in line, line
    assert out == ""
    assert read_bounces(full).times.size >= 10  # the whole file is read

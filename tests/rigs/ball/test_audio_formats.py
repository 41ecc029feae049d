"""Audio files other than WAV, and the two ways WAV is read.

soundfile (libsndfile) reads WAV, FLAC and OGG; where it cannot be imported, WAV is read by
scipy.io.wavfile and FLAC and OGG are refused with one line naming the file and the package. Both
WAV readers must hand the click detector the same samples.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from impactid.cli import main
from impactid.rigs.ball import TABLE_TENNIS, analyse_bounces, read_bounces, readers
from impactid.rigs.ball.readers import BounceFileError, read_audio, read_drops
from impactid.rigs.ball.synth import ROOM_AUDIO, simulate_drop, synth_audio, write_wav

soundfile = readers.soundfile
needs_soundfile = pytest.mark.skipif(soundfile is None, reason="soundfile (libsndfile) cannot be imported here")
RATE = 44100


def _room_drop(seed: int = 0, channels: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Room audio of a table-tennis drop (several clicks per contact, echoes, ringing, noise, clipping)
    at 44.1 kHz, quantised to 16 bits, and its impact times."""
    rng = np.random.default_rng(seed)
    sim = simulate_drop("constant", {"e": 0.9}, ball=TABLE_TENNIS, height=0.3, first_impact=0.3, min_flight=0.08)
    speeds = np.r_[np.sqrt(2 * 9.81 * 0.3), sim["v"][: sim["times"].size - 1]]
    x = synth_audio(sim["times"], speeds, sample_rate=RATE, rng=rng, channels=channels, **ROOM_AUDIO)
    return np.clip(np.round(x * 32768), -32768, 32767).astype(np.int16), sim["times"]


def _restitution(recording) -> float:
    res = analyse_bounces([recording], ball=TABLE_TENNIS, chained=False, law="constant", compare_no_drag=False)
    return res["constant.e"].value


def _run(argv, capsys) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


@needs_soundfile
def test_flac_gives_the_clicks_of_the_same_samples_in_a_wav(tmp_path, capsys):
    """FLAC is lossless: the same 16-bit samples as a WAV give the same onsets to the sample, and
    ``impactid bounces drop.flac`` analyses it."""
    samples, times = _room_drop(0, channels=2)
    wav = write_wav(tmp_path / "drop.wav", samples / 32768.0, RATE)
    flac = tmp_path / "drop.flac"
    soundfile.write(flac, samples, RATE, format="FLAC", subtype="PCM_16")
    from_wav, from_flac = read_bounces(wav), read_bounces(flac)
    assert from_flac.format == "flac" and "FLAC" in from_flac.provenance[0] and "soundfile" in from_flac.provenance[0]
    np.testing.assert_array_equal(from_flac.times, from_wav.times)
    error = np.min(np.abs(from_flac.times[:, None] - times[None, :]), axis=1)
    assert np.median(error) < 1e-4
    assert read_drops(flac)[0].times.size == from_flac.times.size
    code, out, err = _run(["bounces", flac, "--ball", "pingpong", "--audio-channel", "1", "--json", "--no-chained"],
                          capsys)
    assert code == 0, err
    assert '"drops_analysed": 1' in out
    e = json.loads(out)["params"]["constant.e"]
    assert abs(e["value"] - 0.9) < 3 * e["stderr"] + 2e-3, e


@needs_soundfile
def test_ogg_vorbis_gives_the_restitution_of_the_wav(tmp_path):
    """Ogg Vorbis is lossy (a click is smeared over a transform block): the restitution of its onsets
    is that of the WAV's within the Done-when tolerance."""
    samples, _ = _room_drop(1)
    wav = write_wav(tmp_path / "drop.wav", samples / 32768.0, RATE)
    ogg = tmp_path / "drop.ogg"
    soundfile.write(ogg, samples, RATE, format="OGG", subtype="VORBIS")
    from_ogg = read_bounces(ogg)
    assert from_ogg.format == "ogg" and "vorbis" in from_ogg.provenance[0]
    assert abs(_restitution(from_ogg) - _restitution(read_bounces(wav))) < 0.005


@needs_soundfile
@pytest.mark.parametrize("encoding", ["int16", "int24", "int32", "float32"])
def test_soundfile_and_scipy_read_the_same_wav_samples(tmp_path, monkeypatch, encoding):
    samples, _ = _room_drop(2, channels=2)
    path = write_wav(tmp_path / f"{encoding}.wav", samples[: RATE] / 32768.0 * 0.9, RATE, encoding)
    by_soundfile = read_audio(path)
    monkeypatch.setattr(readers, "soundfile", None)
    by_scipy = read_audio(path)
    assert "soundfile" in by_soundfile.reader and "scipy" in by_scipy.reader
    assert (by_soundfile.encoding, by_soundfile.quantum, by_soundfile.sample_rate) == (
        by_scipy.encoding, by_scipy.quantum, by_scipy.sample_rate)
    np.testing.assert_array_equal(by_soundfile.block(), by_scipy.block())


def test_wav_is_read_without_soundfile(tmp_path, monkeypatch):
    samples, times = _room_drop(3)
    path = write_wav(tmp_path / "drop.wav", samples / 32768.0, RATE)
    monkeypatch.setattr(readers, "soundfile", None)
    recording = read_bounces(path)
    assert "scipy.io.wavfile" in recording.provenance[0]
    error = np.min(np.abs(recording.times[:, None] - times[None, :]), axis=1)
    assert recording.times.size >= 10 and np.median(error) < 1e-4


@pytest.mark.parametrize("name,head,kind", [("drop.flac", b"fLaC", "FLAC"), ("drop.ogg", b"OggS", "OGG")])
def test_without_soundfile_flac_and_ogg_are_refused_naming_the_package(tmp_path, monkeypatch, capsys, name, head,
                                                                      kind):
    path = tmp_path / name
    path.write_bytes(head + bytes(range(256)) * 8)
    monkeypatch.setattr(readers, "soundfile", None)
    code, out, err = _run(["bounces", path], capsys)
    lines = err.strip().splitlines()
    assert code == 2 and out == "" and len(lines) == 1, err
    assert lines[0].startswith("impactid: error: ") and str(path) in lines[0]
    assert f"reading {kind} audio needs the soundfile package" in lines[0] and "pip install soundfile" in lines[0]


@needs_soundfile
def test_damaged_and_cut_flac_are_refused(tmp_path, capsys):
    junk = tmp_path / "junk.flac"
    junk.write_bytes(b"fLaC" + bytes(range(256)) * 8)
    samples, _ = _room_drop(4)
    full = tmp_path / "full.flac"
    soundfile.write(full, samples, RATE, format="FLAC", subtype="PCM_16")
    cut = tmp_path / "cut.flac"
    cut.write_bytes(full.read_bytes()[: full.stat().st_size // 3])
    for path, token in ((junk, "not a readable FLAC file"), (cut, "FLAC file")):
        code, out, err = _run(["bounces", path], capsys)
        lines = err.strip().splitlines()
        assert code == 2 and out == "" and len(lines) == 1 and str(path) in lines[0] and token in lines[0], err
    with pytest.raises(BounceFileError, match="cut short|truncated"):
        read_bounces(cut)


@needs_soundfile
def test_cut_ogg_is_refused_inside_a_page_and_at_a_page_boundary(tmp_path, capsys):
    # libsndfile decodes the pages of a cut Ogg stream without a word (no announced length): the reader checks
    # that the file ends with a complete page flagged end-of-stream
    samples, _ = _room_drop(5)
    full = tmp_path / "full.ogg"
    soundfile.write(full, samples, RATE, format="OGG", subtype="VORBIS")
    data = full.read_bytes()
    assert read_bounces(full).times.size >= 5
    inside = tmp_path / "inside.ogg"
    inside.write_bytes(data[: 2 * len(data) // 3])
    boundary = tmp_path / "boundary.ogg"
    boundary.write_bytes(data[: data.rfind(b"OggS")])  # the last page dropped whole: every page left is complete
    tagged = tmp_path / "tagged.ogg"  # a complete stream with a tag appended after it: not called cut
    tagged.write_bytes(data + b"TAG" + bytes(125))
    try:  # today's libsndfile reads the stream and ignores the tag; older ones (1.0.x) cannot tell its length
        assert read_bounces(tagged).times.size == read_bounces(full).times.size
    except BounceFileError as refused:
        assert "truncated" not in str(refused), refused
    header_cut = tmp_path / "header_cut.ogg"  # cut inside the last page's header: the page before is mid-stream
    header_cut.write_bytes(data[: data.rfind(b"OggS") + 10])
    for path, token in ((inside, "ends inside a page"), (boundary, "no end-of-stream flag"),
                        (header_cut, "no end-of-stream flag")):
        code, out, err = _run(["bounces", path], capsys)
        lines = err.strip().splitlines()
        assert code == 2 and out == "" and len(lines) == 1, err
        assert str(path) in lines[0] and "truncated OGG file" in lines[0] and token in lines[0], lines[0]


@pytest.mark.parametrize("name,token", [("text.flac", "not a FLAC file"), ("text.ogg", "not a OGG file"),
                                        ("text.wav", "not a WAV file")])
def test_a_name_that_promises_audio_without_its_content(tmp_path, name, token):
    path = tmp_path / name
    path.write_text("hello\n")
    with pytest.raises(BounceFileError, match=token):
        read_bounces(path)


@pytest.mark.parametrize("samples,token", [
    (np.zeros(RATE), "silent"),
    (np.sign(np.sin(np.arange(RATE) * 0.01)) * 1.5, "clipped"),
    (np.random.default_rng(0).normal(0, 0.1, 500), "too short"),
], ids=["silent", "clipped", "short"])
def test_unusable_wav_is_refused_by_the_scipy_reader_too(tmp_path, monkeypatch, samples, token):
    path = write_wav(tmp_path / "bad.wav", samples, RATE)
    monkeypatch.setattr(readers, "soundfile", None)
    with pytest.raises(BounceFileError, match=token):
        read_bounces(path)

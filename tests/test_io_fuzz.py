"""Property-based fuzzing of the readers: a corrupted or random file is either read or rejected with
impactid's own error type (never another exception)."""

from __future__ import annotations

import tempfile
import warnings
from pathlib import Path

import h5py
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from impactid import SUNDAR2016, save_rig_toml
from impactid.errors import ImpactidError
from impactid.io import Recording, read_recording, write_hdf5

# derandomize: CI runs the same examples every time (a failure is reproducible, never flaky)
SETTINGS = settings(max_examples=150, deadline=None, derandomize=True,
                    suppress_health_check=[HealthCheck.function_scoped_fixture])


def _valid_bytes() -> bytes:
    n = 300
    rec = Recording(channels={"accel_tangential": np.sin(np.arange(n) * 0.1), "force_x": np.cos(np.arange(n) * 0.1)},
                    sample_rate_hz=1000.0, units={"accel_tangential": "m/s^2", "force_x": "N"}, rig=SUNDAR2016,
                    operating={"cam_speed_hz": 16.0})
    with tempfile.TemporaryDirectory() as tmp:
        path = write_hdf5(rec, Path(tmp) / "v.h5")
        return path.read_bytes()


VALID = _valid_bytes()


def _read(path: Path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            rec = read_recording(path)
        except ImpactidError:
            return None
    assert isinstance(rec, Recording)
    for x in rec.channels.values():
        assert np.all(np.isfinite(x))
    return rec


@pytest.fixture(scope="module")
def folder():
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        save_rig_toml(SUNDAR2016, tmp / "f.toml", operating={"cam_speed_hz": 16.0})
        yield tmp


@SETTINGS
@given(flips=st.lists(st.tuples(st.integers(0, len(VALID) - 1), st.integers(0, 255)), min_size=1, max_size=40),
       cut=st.one_of(st.none(), st.integers(0, len(VALID))))
@pytest.mark.slow
def test_corrupted_hdf5(folder, flips, cut):
    data = bytearray(VALID)
    for pos, value in flips:
        data[pos] = value
    if cut is not None:
        data = data[:cut]
    path = folder / "f.h5"
    path.write_bytes(bytes(data))
    _read(path)


@SETTINGS
@given(blob=st.binary(max_size=2000), suffix=st.sampled_from([".h5", ".csv", ".hdf5"]),
       signature=st.booleans())
def test_random_bytes(folder, blob, suffix, signature):
    path = folder / f"f{suffix}"
    path.write_bytes((b"\x89HDF\r\n\x1a\n" if signature else b"") + blob)
    _read(path)


CSV_ALPHABET = st.sampled_from(list("0123456789,.-+e\n ") + ["nan", "inf", "time_s", "force_x", "accel_tangential",
                                                             "x", '"', "#", "\t", "\r\n", "1e-5", "1e400"])


@SETTINGS
@given(parts=st.lists(CSV_ALPHABET, max_size=200), header=st.booleans())
def test_random_csv(folder, parts, header):
    text = ("time_s,force_x\n" if header else "") + "".join(parts)
    path = folder / "f.csv"
    path.write_text(text)
    _read(path)


TEXT = st.text(alphabet=st.characters(blacklist_characters="\x00"), max_size=5)  # HDF5 strings cannot hold NUL
ATTR_VALUES = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-10, 10), TEXT,
                        st.lists(st.floats(allow_nan=False), max_size=3).map(np.array))


@SETTINGS
@given(rate=ATTR_VALUES, start=ATTR_VALUES, units=st.one_of(ATTR_VALUES, st.sampled_from(["N", "m/s^2", "g", "kN"])),
       rig_value=ATTR_VALUES, rig_key=st.sampled_from(["k_s", "m_b", "e", "mu", "model", "bogus"]),
       op_value=ATTR_VALUES, length=st.integers(0, 50),
       dtype=st.sampled_from(["f8", "f4", "i4", "u1", "S3", "c16", "?"]), ndim=st.integers(0, 2))
@pytest.mark.slow
def test_random_structure(folder, rate, start, units, rig_value, rig_key, op_value, length, dtype, ndim):
    path = folder / "s.h5"
    with h5py.File(path, "w") as fh:
        sig = fh.create_group("signals")
        sig.attrs["sample_rate_hz"] = rate
        sig.attrs["start_time_s"] = start
        shape = () if ndim == 0 else (length,) * ndim
        ds = sig.create_dataset("force_x", data=np.ones(shape).astype(dtype))
        ds.attrs["units"] = units
        good = sig.create_dataset("accel_tangential", data=np.zeros(max(length, 1)))
        good.attrs["units"] = "m/s^2"
        rig = fh.create_group("rig")
        rig.attrs["model"] = "pivoted-follower"
        for key, value in SUNDAR2016.to_dict().items():
            rig.attrs[key] = value
        rig.attrs[rig_key] = rig_value
        fh.create_group("operating").attrs["cam_speed_hz"] = op_value
    _read(path)


# unit strings: pint evaluates them as arithmetic, so its parser raises whatever Python's tokenizer and
# arithmetic raise (or computes for ever: 2^2^2^2^30); every string must end in a factor or a UnitError
UNIT_PIECES = st.sampled_from(["m", "s", "N", "g", "k", "mm", "kN", "deg", "rad", "turn", "rev", "/", "*", "^", "**",
                               "(", ")", " ", "-", "+", ".", "0", "1", "2", "9", "e", "1e308", "99999999", "²", "³",
                               "⁻", "·", "per", "squared", "°", ",", "_", "[", "]", "'", '"', "\\", "%", "\t", "pi",
                               "nan", "inf", "degC", "delta_degC", "lambda", "import", "__", "#", ":", ";", "=",
                               "m/s^2", "standard_gravity", "ms^-2", "1/0"])
UNIT_TEXT = st.one_of(st.lists(UNIT_PIECES, max_size=16).map("".join), st.text(max_size=24))


@settings(max_examples=400, deadline=None, derandomize=True)
@given(unit=UNIT_TEXT, quantity=st.sampled_from(["acceleration", "force", "angle"]))
def test_unit_strings_parse_or_raise_unit_error(unit, quantity):
    from impactid.units import UnitError, si_factor

    try:
        factor = si_factor(unit, quantity)
    except UnitError as exc:
        assert exc.reason and "\n" not in str(exc)
        return
    assert np.isfinite(factor) and factor > 0.0

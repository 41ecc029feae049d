"""Reading only the channels a job needs (issue 27): the readers' ``channels`` selection."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

import impactid.io as io_module
from impactid.io import RecordingError, read_csv, read_hdf5, read_recording, write_csv, write_hdf5
from tests.test_io import small_recording


def _written(rec, tmp_path, kind: str):
    """``rec`` written as HDF5 or as CSV (with its rig file) in ``tmp_path``; the path read back."""
    if kind == "h5":
        path = tmp_path / "r.h5"
        write_hdf5(rec, path)
        return path
    return write_csv(rec, tmp_path / "r.csv")[0]


@pytest.mark.parametrize("kind", ["h5", "csv"])
def test_only_the_channels_asked_for_are_read_and_they_are_unchanged(tmp_path, kind):
    """The channels asked for (those the file has) come back sample for sample; the others are not read."""
    path = _written(small_recording(), tmp_path, kind)
    whole = read_recording(path, check=False)
    part = read_recording(path, channels=("accel_tangential", "cam_angle", "not_in_the_file"), check=False)
    assert list(part.channels) == ["accel_tangential", "cam_angle"]
    for name in part.channels:
        assert np.array_equal(part[name], whole[name])
        assert part.channel_range(name) == whole.channel_range(name)
    assert (part.sample_rate_hz, part.start_time_s, part.rig, dict(part.operating)) == (
        whole.sample_rate_hz, whole.start_time_s, whole.rig, dict(whole.operating))
    reader = read_hdf5 if kind == "h5" else read_csv
    assert list(reader(path, channels=["force_x"]).channels) == ["force_x"]


@pytest.mark.parametrize("kind", ["h5", "csv"])
def test_none_of_the_channels_in_the_file_is_an_error_naming_both(tmp_path, kind):
    path = _written(small_recording(), tmp_path, kind)
    with pytest.raises(RecordingError, match=r"none of the channels follower_angle is in the recording \(it has "
                                             r"accel_tangential"):
        read_recording(path, channels=("follower_angle",))


def test_large_channels_are_mapped_from_the_file_and_read_alike(tmp_path, monkeypatch):
    """Channels of at least MAP_BYTES are mapped, not copied: the same samples and ranges, read-only; their
    pages given back (release_pages) leave them readable; a calibrated channel is still read and scaled."""
    rec = small_recording()
    path = tmp_path / "r.h5"
    write_hdf5(rec, path)
    copied = read_hdf5(path)
    monkeypatch.setattr(io_module, "MAP_BYTES", 1)
    mapped = read_hdf5(path)
    assert all(isinstance(mapped[n].base, memoryview) for n in mapped.channels)
    assert not any(isinstance(copied[n].base, memoryview) for n in copied.channels)
    for name in copied.channels:
        assert np.array_equal(mapped[name], copied[name])
        assert mapped.channel_range(name) == copied.channel_range(name)
        assert not mapped[name].flags.writeable
    io_module.release_pages(mapped)
    io_module.release_pages(copied)
    for name in copied.channels:
        assert np.array_equal(mapped[name], copied[name])
    with h5py.File(path, "a") as fh:
        fh["signals"]["force_x"].attrs["scale"] = 2.0
    scaled = read_hdf5(path)
    assert not isinstance(scaled["force_x"].base, memoryview)
    assert np.array_equal(scaled["force_x"], 2.0 * copied["force_x"])

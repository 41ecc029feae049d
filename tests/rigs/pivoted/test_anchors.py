"""The anchors of rig P's reconstruction as typed objects (issue 25, "functions that do one job").

Each anchor is a frozen dataclass with a name and the channels it needs; ``ANCHORS`` maps the names
to them, and ``reconstruct`` runs the one named. The anchored constants are checked against the
truth in tests/rigs/pivoted/test_reconstruct.py; here: the types, what each anchor returns, and that running an
anchor by hand on the integrated windows gives what ``reconstruct`` reports.
"""

from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np
import pytest

from impactid.io import RecordingError
from impactid.rigs.pivoted import MODEL_NAME
from impactid.rigs.pivoted import reconstruct as reconstruct_module
from impactid.rigs.pivoted.anchors import (
    ANCHORS,
    AnchoredOnsets,
    CamGeometryAnchor,
    CamPhaseAnchor,
    EventWindows,
    ReturnTimeAnchor,
)
from impactid.rigs.pivoted.reconstruct import reconstruct


@pytest.fixture(scope="module")
def windows(s2_synthetic) -> EventWindows:
    rec = s2_synthetic.recording
    rig = rec.require_rig(MODEL_NAME)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        events = reconstruct_module._events_to_reconstruct(rec, None, warn=False)
    return reconstruct_module._integrate_events(rec, rig, events, "rk", rec.require_cam_speed())


def test_anchors_are_typed_objects_by_name():
    assert list(ANCHORS) == ["return-time", "cam-geometry", "cam-phase"]
    for name, anchor in ANCHORS.items():
        assert dataclasses.is_dataclass(anchor) and anchor.name == name
        with pytest.raises(dataclasses.FrozenInstanceError):
            anchor.name_of_nothing = 1  # frozen
    assert CamGeometryAnchor.channels == ("cam_angle",)
    assert ReturnTimeAnchor.channels == () and CamPhaseAnchor.channels == ()
    assert reconstruct_module.ANCHORS is ANCHORS  # still importable from reconstruct


def test_each_anchor_returns_its_constants_and_what_it_found(windows):
    n = len(windows)
    rt = ReturnTimeAnchor().anchor(windows)
    assert isinstance(rt, AnchoredOnsets) and rt.constants.shape == (n,)
    assert np.all(rt.iterations > 0) and rt.theta_onset is None and math.isnan(rt.cam_phase)
    np.testing.assert_array_equal(rt.return_time_onset, windows.angle_onset + rt.constants)

    geometry = CamGeometryAnchor().anchor(windows)
    assert np.all(geometry.iterations == 0) and geometry.theta_onset.shape == (n,)
    assert geometry.return_time_onset is None and math.isnan(geometry.cam_phase)

    phase = CamPhaseAnchor().anchor(windows)
    assert phase.theta_onset.shape == (n,) and math.isfinite(phase.cam_phase) and phase.cam_phase_stderr > 0
    np.testing.assert_array_equal(phase.iterations, rt.iterations)  # it starts from the return-time anchor
    np.testing.assert_array_equal(phase.theta_onset, phase.cam_phase + windows.omega * windows.t_onset)
    # noise-free, the three agree on the onset angles to well below the indentation's angle (~1e-4 rad)
    for other in (rt, geometry):
        assert np.max(np.abs(other.constants - phase.constants)) < 2e-5


@pytest.mark.parametrize("name", list(ANCHORS))
def test_reconstruct_reports_what_its_anchor_found(s2_synthetic, windows, name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        recon = reconstruct(s2_synthetic.recording, anchor=name)
    anchored = ANCHORS[name].anchor(windows)
    np.testing.assert_array_equal(recon.table["anchor_constant"].to_numpy(), anchored.constants)
    np.testing.assert_array_equal(recon.table["anchor_iterations"].to_numpy(), anchored.iterations)
    if anchored.theta_onset is not None:
        np.testing.assert_array_equal(recon.table["theta_onset"].to_numpy(), anchored.theta_onset)
    assert recon.cam_phase == anchored.cam_phase or (math.isnan(recon.cam_phase) and math.isnan(anchored.cam_phase))


def test_an_anchor_with_parameters_is_an_ordinary_value(windows):
    loose = ReturnTimeAnchor(tolerance=1e-6)
    assert loose != ReturnTimeAnchor() and loose.name == "return-time"
    strict, coarse = ReturnTimeAnchor().anchor(windows), loose.anchor(windows)
    assert np.all(coarse.iterations <= strict.iterations)
    assert np.max(np.abs(coarse.constants - strict.constants)) < 1e-5
    assert CamPhaseAnchor(first=loose).first is loose


def test_the_cam_geometry_anchor_names_the_channel_it_needs(s2_synthetic):
    rec = s2_synthetic.recording
    bare = rec.with_step("drop the encoder", channels={k: v for k, v in rec.channels.items() if k != "cam_angle"})
    with pytest.raises(RecordingError, match="cam-geometry.*cam_angle"):
        reconstruct(bare, anchor="cam-geometry")
    with pytest.raises(ValueError, match="valid: return-time, cam-geometry, cam-phase"):
        reconstruct(rec, anchor="encoder")


def test_contact_windows_apply_the_constants(windows):
    constants = np.full(len(windows), 0.5)
    constants[0] = math.nan
    out = windows.contact_windows(constants)
    assert out[0] is None
    t, alpha, acceleration = out[1]
    np.testing.assert_array_equal(alpha, windows.angles[1][:alpha.size] + 0.5)
    assert t[0] == pytest.approx(windows.onset_offset[1] * windows.dt)
    assert acceleration.size == alpha.size == min(int(windows.contact_end[1]) + 1, windows.angles[1].size)


def test_the_hertz_phase_root_is_nan_where_the_ratios_vanish_inside_the_bracket():
    """The Hertz-ratio phase's root finder meets NaN where a trial phase leaves no indentation or force
    (a rig constant 40 % off did: a traceback from brentq); it gives NaN there, and the root elsewhere."""
    import math

    from impactid.rigs.pivoted.anchors import bracketed_root

    assert bracketed_root(lambda q: q - 0.1, -0.5, 0.5, xtol=1e-9) == pytest.approx(0.1, abs=1e-8)
    assert math.isnan(bracketed_root(lambda q: q - 0.1 if abs(q) > 0.2 else math.nan, -0.5, 0.5, xtol=1e-9))

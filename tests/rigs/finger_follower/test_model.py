"""The rig goes in through the rig-model protocol: one folder, one registry line."""

from __future__ import annotations

import numpy as np
import pytest

from impactid.rigs.base import RigModel
from impactid.rigs.registry import MODELS, RIG_MODELS, rig_from_mapping, rig_model


def test_registered_with_its_presets_channels_and_commands(rig):
    model = rig_model("finger-follower-hla")
    assert isinstance(model, RigModel) and MODELS["finger-follower-hla"] is model
    assert RIG_MODELS["finger-follower-hla"] is model.parameters
    assert model.default is rig and model.preset("kim1990-table2").K_e == pytest.approx(6.648e7)
    with pytest.raises(KeyError, match="presets: kim1990"):
        model.preset("nope")
    assert {c for c, s in model.channels.items() if s.required} == {"valve_displacement", "cam_angle"}
    assert model.channels["tappet_displacement"].unit == "m"
    assert {c.name for c in model.command_specs()} >= {"simulate", "modes", "jump-speed", "fit-tappet", "fit-lift"}
    assert all(c.group == "valvetrain" for c in model.command_specs())
    assert rig_from_mapping({"model": "finger-follower-hla", **rig.to_dict()}) == rig


def test_recordings_know_the_rig_channels():
    from impactid.io import channel_spec

    assert channel_spec("tappet_displacement") == ("m", "length")
    assert channel_spec("contact_load") == ("N", "force")


def test_gap_and_kernel_entries(rig):
    model = rig_model("finger-follower-hla")
    rest = np.zeros(12)
    # at rest the cam/follower contact is closed by its preload: gap = -F_fc0/K_fc
    assert model.gap(rig, rest, -np.pi) == pytest.approx(-rig.F_fc0 / rig.K_fc, rel=1e-12)
    assert model.gap_rate(rig, rest, -np.pi, 100.0) == pytest.approx(0.0, abs=1e-15)
    p = model.pack(rig)
    assert p.shape == (model.kernel.N_PAR,) and p[model.kernel.P_FTF0] == rig.F_tf0
    assert model.laws[0].pack(model.laws[0].law_type(alpha=0.01, beta=0.3)).tolist() == [0.01, 0.3]

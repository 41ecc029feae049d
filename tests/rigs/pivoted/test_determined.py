"""When rig P's damping fit reports beta as determined (impactid/rigs/pivoted/damping_diagnostics.py): not where its
interval reaches more than a decade from the estimate, and the residual's trend with the approach speed is tested
only within recordings whose approach speeds differ."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

from impactid.rigs.pivoted.damping_diagnostics import (
    ALIKE_SPREAD,
    DETERMINED_REACH,
    _speeds_differ,
    interval_reach,
    mark_reach,
)


def test_interval_reach():
    assert interval_reach(1.0, (0.5, 3.0)) == 3.0
    assert interval_reach(2.0, (0.01, 2.5)) == 200.0
    assert math.isnan(interval_reach(1.0, (math.nan, math.nan)))  # withheld: nothing to judge


def test_an_interval_that_reaches_beyond_a_decade_is_not_determined():
    """The envelope's low-rate hc07: +101 %, its interval 3.5e7 to 4.1e11 around 1.55e10."""
    block, notes = {"determined": True, "notes": ["an earlier note"]}, []
    mark_reach(block, 1.551e10, (3.496e7, 4.134e11), notes)
    assert block["determined"] is False and len(notes) == 1
    assert block["notes"][0] == notes[0] and "not determined" in notes[0] and "444 times" in notes[0]
    assert block["notes"][1] == "an earlier note"
    kept, notes = {"determined": True, "notes": []}, []
    mark_reach(kept, 1.0, (1.0 / (0.99 * DETERMINED_REACH), 0.99 * DETERMINED_REACH), notes)
    assert kept["determined"] is True and not notes


def test_the_trend_is_tested_only_where_the_approach_speeds_differ():
    alike = SimpleNamespace(approach_speed=np.full(12, 0.5) * (1.0 + 1e-4 * np.arange(12)))  # period-1: one speed
    alternating = SimpleNamespace(approach_speed=np.tile([0.3, 0.5], 6))  # period-2 impacts
    assert not _speeds_differ(alike)
    assert _speeds_differ(alternating)
    just = SimpleNamespace(approach_speed=np.array([1.0 - 1.01 * ALIKE_SPREAD, 1.0 + 1.01 * ALIKE_SPREAD]))
    assert _speeds_differ(just)

"""The least-squares search's start scan on a part of the events (issue 27): the scan only picks where the
Gauss–Newton search starts, so a representative part of the events gives the same estimate for a
fraction of the simulations (a 60 s recording: 959 impacts, 41 scan points, four fifths of the fit)."""

from __future__ import annotations

import warnings

import pytest

from impactid.rigs.pivoted import damping_objective
from impactid.rigs.pivoted.estimates import fit_contact_damping
from impactid.rigs.pivoted.reconstruct import reconstruct
from impactid.rigs.pivoted.residuals import EventSet


@pytest.fixture(scope="module")
def noisy_events(s2_noisy):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return EventSet.from_reconstruction(reconstruct(s2_noisy.recording, anchor="cam-phase"))


def test_a_part_of_the_events_is_every_sets_events_at_one_stride(noisy_events):
    obj = damping_objective.DampingObjective([noisy_events, noisy_events.subset(slice(0, 7))], "lambda1", 3e-5)
    part = obj.scan_part(10)
    assert part is not None and part.n_events <= 10
    stride = -(-obj.n_events // 10)
    assert [len(s) for s in part.sets] == [len(range(0, len(noisy_events), stride)), len(range(0, 7, stride))]
    assert obj.scan_part(obj.n_events) is None  # all events within the limit: the scan takes them all


@pytest.mark.parametrize("fix_n", [1.5, None])
def test_the_scan_on_a_part_starts_the_search_where_the_whole_scan_does(noisy_events, monkeypatch, fix_n):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        whole = fit_contact_damping(noisy_events, fix_n=fix_n)
        monkeypatch.setattr(damping_objective, "SCAN_EVENTS", 8)
        part = fit_contact_damping(noisy_events, fix_n=fix_n)
    assert len(noisy_events) > 8
    assert part.beta == whole.beta and part.n == whole.n
    assert part.beta_interval == whole.beta_interval
    assert part.n_simulations < whole.n_simulations - 30 * (len(noisy_events) - 8)

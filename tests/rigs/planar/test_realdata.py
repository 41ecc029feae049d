"""The real planar impacts (not in the repository): a fit on one half predicts the other half.

Set ``IMPACTID_REALDATA_PLANAR`` to the folder that holds ``mcube_ellipse.csv`` (Fazeli, Donlon,
Drumwright & Rodriguez 2017); without it these tests are skipped.
"""

import os
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from impactid.rigs.planar import MCUBE_ELLIPSE, fit_planar, predict_planar, read_impacts, read_pre_impact

ROOT = os.environ.get("IMPACTID_REALDATA_PLANAR")
FILE = Path(ROOT or ".") / "mcube_ellipse.csv"
pytestmark = pytest.mark.skipif(not ROOT or not FILE.is_file(),
                                reason="set IMPACTID_REALDATA_PLANAR to the real planar impacts")


def test_a_half_predicts_the_other_half_better_than_the_published_models():
    impacts = read_impacts(FILE)
    assert len(impacts) == 859 and impacts.impulse is not None
    order = np.random.default_rng(0).permutation(len(impacts))
    train, test = np.sort(order[:429]), np.sort(order[429:])
    fit = fit_planar(impacts.subset(train), MCUBE_ELLIPSE, profiles=False)
    pre = read_pre_impact(FILE).subset(test)
    predicted = predict_planar(fit.law, fit.values, MCUBE_ELLIPSE, pre)
    p = predicted[["predicted_impulse_t", "predicted_impulse_n"]].to_numpy()
    truth = impacts.impulse[test]
    ours = np.median(np.linalg.norm(p - truth, axis=1) / np.linalg.norm(truth, axis=1))
    published = pd.read_csv(FILE, usecols=["ap_newton_impulse_t", "ap_newton_impulse_n"]).to_numpy()[test]
    theirs = np.median(np.linalg.norm(published - truth, axis=1) / np.linalg.norm(truth, axis=1))
    assert ours < theirs and ours < 0.08, (ours, theirs)
    assert 0.0 < fit.value("mu") < 0.5

"""Identification on recordings made by the independent ``solve_ivp`` reference (not by impactid).

The recordings are sampled from the reference's periodic steady cycles
(``tests/rigs/cycloidal/reference_cycloidal_ehl.py``,
DOP853 at ``rtol = 1e-10``), built into :class:`~impactid.io.Recording` objects that carry the preset rig
(:data:`KUSHWAHA2000`) as the "nominal" rig the user believes in; the truth (below) differs from it in
every identified value and is never passed to the estimator.

Tolerances: noise-free, the compiled model and the reference agree to integration accuracy, so the
level-A fit recovers the truth to 1e-6 relative (measured: about 1e-9); level B, whose displacement
carries the load through a micrometre Hertz approach, to 1e-4 (measured: about 1e-5 for ``c_spring``,
2e-7 for the others). With noise the statement is the interval's: it must contain the truth.
"""

from __future__ import annotations

import numpy as np
import pytest

from impactid.io import Recording
from impactid.rigs.cycloidal import KUSHWAHA2000, fit_surge
from tests.rigs.cycloidal import reference_cycloidal_ehl as R

TRUE = {"f0": 480.0, "c_spring": 3.0, "f_p": 260.0, "m3": 0.235}
NAMES = tuple(TRUE)


@pytest.fixture(scope="module")
def ref_truth():
    return R.reference_params(f0=TRUE["f0"], c=TRUE["c_spring"], f_p=TRUE["f_p"], m3=TRUE["m3"])


def _record(rpm, dense, T, channel, values_of, fs=20_000.0, revolutions=3.0, noise=0.0, seed=0):
    n = int(round(revolutions * T * fs))
    t = np.arange(n) / fs
    values = values_of(np.mod(t, T), dense)
    if noise:
        values = values + np.random.default_rng(seed).normal(0.0, noise, n)
    return Recording(channels={"cam_angle": R.omega_of(rpm) * t, channel: values}, sample_rate_hz=fs,
                     units={"cam_angle": "rad", channel: "N" if channel == "contact_load" else "m"},
                     rig=KUSHWAHA2000, operating={"cam_speed_hz": rpm / 60.0},
                     provenance=(f"tests/rigs/cycloidal/reference_cycloidal_ehl.py steady cycle at {rpm:g} rpm",))


def reference_load_recording(p, rpm, **kw):
    """Level-A contact load (R-40') of the reference's periodic steady cycle."""
    cyc = R.level_a_cycle(rpm, p, n=8)
    return _record(rpm, cyc["dense"], cyc["T"], "contact_load",
                   lambda ph, dense: R.level_a_load(ph, dense(ph), rpm, p), **kw)


def reference_displacement_recording(p, rpm, **kw):
    """Level-B valve displacement of the reference's periodic steady cycle."""
    cyc = R.level_b_steady_cycle(rpm, p, n=8)
    assert cyc["converged"]
    return _record(rpm, cyc["dense"], cyc["T"], "valve_displacement", lambda ph, dense: dense(ph)[0], **kw)


def test_contact_load_from_the_reference_noise_free(ref_truth):
    """The fast loop's share of the next test: one noise-free reference cycle (no joint noisy fit)."""
    fit = fit_surge(reference_load_recording(ref_truth, 3000.0))
    assert fit.statistics["model"] == "level A"
    for k in NAMES:
        assert fit.value(k) == pytest.approx(TRUE[k], rel=1e-6), k


@pytest.mark.slow
def test_contact_load_from_the_reference(ref_truth):
    fit = fit_surge(reference_load_recording(ref_truth, 3000.0))
    for k in NAMES:
        assert fit.value(k) == pytest.approx(TRUE[k], rel=1e-6), k
    # 3 N of noise, two speeds jointly: the 95 % intervals contain the truth and are narrow
    recs = [reference_load_recording(ref_truth, rpm, noise=3.0, seed=seed) for rpm, seed in ((2500.0, 11),
                                                                                              (3000.0, 12))]
    fit = fit_surge(recs)
    for k in NAMES:
        assert fit[k].contains(TRUE[k]), (k, fit[k])
        assert fit[k].stderr < 0.05 * abs(TRUE[k]), k
    assert fit.statistics["residual_sd"] == pytest.approx(3.0, rel=0.1)


@pytest.mark.slow
def test_valve_displacement_from_the_reference(ref_truth):
    # the truth rig loses the cam at 3000 rpm (lower preload, heavier valve): the separation adds information
    clean = reference_displacement_recording(ref_truth, 3000.0, revolutions=2.0)
    fit = fit_surge(clean)
    assert fit.statistics["model"] == "level B"
    for k in NAMES:
        assert fit.value(k) == pytest.approx(TRUE[k], rel=1e-4), k
    y = clean.channel("valve_displacement") + np.random.default_rng(2).normal(0.0, 5e-9, clean.n_samples)
    noisy = Recording(channels={"cam_angle": clean.channel("cam_angle"), "valve_displacement": y},
                      sample_rate_hz=clean.sample_rate_hz, units=clean.units, rig=KUSHWAHA2000,
                      operating=clean.operating)
    fit = fit_surge(noisy)
    for k in NAMES:
        assert fit[k].contains(TRUE[k]), (k, fit[k])

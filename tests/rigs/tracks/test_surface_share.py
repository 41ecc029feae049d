"""The surface plane's share of the restitution's uncertainty: e_n read against the contact points'
plane, its derivative by the plane's slopes, and the slopes' covariance carried into the pooled laws."""

import numpy as np
import pytest

from impactid.rigs.tracks import TABLE_TENNIS_BALL, Track, analyse_tracks
from impactid.rigs.tracks.analysis import restitution_against, restitution_slope_gradient, surface_plane
from tests.rigs.tracks.reference_tracks import bouncing_track


def _bounces(count=30, seed=3):
    rng = np.random.default_rng(seed)
    v_in = np.column_stack([rng.uniform(-0.5, 0.5, count), rng.uniform(-9, -4, count), rng.uniform(-3, -2, count)])
    v_out = np.column_stack([v_in[:, 0] * 0.8, v_in[:, 1] * 0.8, -0.9 * v_in[:, 2]])
    return v_in, v_out


def test_restitution_is_unchanged_by_an_affine_distortion():
    """A rotation, a shear and a scale of one axis applied to the velocities and to the plane of the contact
    points together leave e_n read against the plane unchanged; read against e_z it changes."""
    v_in, v_out = _bounces()
    truth = restitution_against(v_in, v_out, (0.0, 0.0))
    c, s = np.cos(0.01), np.sin(0.01)
    for matrix in (np.array([[1, 0, 0], [0, c, -s], [0, s, c]]), np.array([[1, 0, 0], [0, 1, 0], [0.004, 0.008, 1]]),
                   np.diag([1.0, 1.03, 0.97])):
        # the plane z = 0 becomes the plane whose gradient is the row (0, 0, 1) A^-1
        m = np.array([0.0, 0.0, 1.0]) @ np.linalg.inv(matrix)
        slopes = (-m[0] / m[2], -m[1] / m[2])
        assert restitution_against(v_in @ matrix.T, v_out @ matrix.T, slopes) == pytest.approx(truth, abs=1e-12)
    sheared = np.array([[1, 0, 0], [0, 1, 0], [0, 0.008, 1]])
    assert np.max(np.abs(restitution_against(v_in @ sheared.T, v_out @ sheared.T, (0.0, 0.0)) - truth)) > 0.02


def test_slope_gradient_matches_finite_differences():
    v_in, v_out = _bounces()
    slopes = np.array([0.002, 0.008])
    grad = restitution_slope_gradient(v_in, v_out, slopes)
    for k in (0, 1):
        h = np.zeros(2)
        h[k] = 1e-6
        numeric = (restitution_against(v_in, v_out, slopes + h) - restitution_against(v_in, v_out, slopes - h)) / 2e-6
        assert grad[:, k] == pytest.approx(numeric, rel=1e-5, abs=1e-8)


def test_plane_slope_covariance_is_the_least_squares_one():
    rng = np.random.default_rng(2)
    xy = rng.uniform(-1, 1, (40, 2))
    z = 0.02 + 0.003 * xy[:, 0] + 0.008 * xy[:, 1] + 2e-3 * rng.standard_normal(40)
    plane = surface_plane(np.column_stack([xy, z]), mode="plane")
    design = np.column_stack([np.ones(40), xy - xy.mean(axis=0)])
    coef, rss, *_ = np.linalg.lstsq(design, z, rcond=None)
    cov = float(rss[0]) / (40 - 3) * np.linalg.inv(design.T @ design)
    assert plane.slopes == pytest.approx(coef[1:], rel=1e-9)
    assert np.array(plane.slope_covariance) == pytest.approx(cov[1:, 1:], rel=1e-9)
    assert surface_plane(np.column_stack([xy, z]), mode="flat").slope_covariance == ((0.0, 0.0), (0.0, 0.0))


def test_the_plane_share_in_the_pooled_restitution():
    """Twelve bounces on a plane rising 8 mm/m along y: the pooled e_n's standard error holds the common
    share of the slopes, the weighted mean of the bounces' gradients through the slopes' covariance (not
    averaged down by the number of bounces), and each bounce's holds its own."""
    rng = np.random.default_rng(8)
    tracks = []
    for k in range(12):
        spin = rng.uniform(-150, 150, 3)
        p0 = np.array([rng.uniform(-0.6, 0.6), rng.uniform(0.4, 1.9), 0.35])
        v0 = np.array([rng.uniform(-0.5, 0.5), rng.uniform(-8, -4), rng.uniform(-1.5, -0.5)])
        times, pos, _ = bouncing_track(p0, v0, spin, e_n=0.9, mu=0.2, surface=0.0, slope=(0.0, 0.008), duration=0.4,
                                       rate=240.0, noise=1e-3, seed=k, bounces=1)
        tracks.append(Track(source=f"t{k}", time=times, position=pos, dimensions=3, spin=tuple(spin), name=f"t{k}"))
    res = analyse_tracks(tracks, TABLE_TENNIS_BALL, rule=False, surface="plane")
    plane = res.details["surface_plane"]
    cov = np.array(plane["slope_covariance"])
    assert np.sqrt(np.diag(cov)) == pytest.approx(plane["stderr"][1:], rel=1e-9)
    fits = res.details["bounce_fits"]
    table = res.bounces[res.bounces["analysed"]]
    v_in = np.array([f["details"]["v_in"] for f in fits])
    v_out = np.array([f["details"]["v_out"] for f in fits])
    grad = restitution_slope_gradient(v_in, v_out, plane["slopes"])
    tau = res.details["laws"]["normal"]["constant"]["extra"]["tau"]
    weight = 1.0 / (table["e_n_fit_stderr"].to_numpy() ** 2 + tau ** 2)
    mean_grad = weight @ grad / weight.sum()
    share = float(np.sqrt(mean_grad @ cov @ mean_grad))
    assert res.details["surface_share"]["laws"]["constant"]["e"] == pytest.approx(share, rel=0.02)
    assert share > 0.5 * float(np.median(table["e_n_surface_stderr"]))  # common: not divided by sqrt(12)
    per_bounce = np.sqrt(table["e_n_fit_stderr"] ** 2 + table["e_n_surface_stderr"] ** 2)
    assert table["e_n_stderr"].to_numpy() == pytest.approx(per_bounce.to_numpy(), rel=1e-9)
    assert res["normal.constant.e"].contains(0.9)

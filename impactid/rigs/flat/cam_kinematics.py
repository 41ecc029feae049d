"""Follower kinematics in permanent contact: analytic derivatives against a differentiated spline (Lee 2005).

In permanent contact the follower angle is a function of the cam angle, ``theta_f = theta_hat(theta_c)``
[rad]. At constant cam speed ``omega`` [rad/s] the chain rule gives the follower's angular velocity
and acceleration exactly from the profile's derivatives with respect to the cam angle:

    theta_f_dot  = omega   theta_hat'(theta_c)          [rad/s]
    theta_f_ddot = omega^2 theta_hat''(theta_c)         [rad/s^2]

Lee (2005) argues for computing the contact-point acceleration from the local geometry
in this way rather than, as is common in cam design, by differentiating a cubic spline fitted
through the displacement at ``N`` nodes per revolution: the spline needs the whole revolution, and
its second derivative is much less accurate than the displacement (his Figs. 5 and 7; 0.05 % maximum
relative error of the acceleration with 10 000 nodes, and a much larger one for a cam whose profile
changes more sharply). This module measures that claim on rig F.

Profiles are callables with the protocol ``profile(theta_c, derivatives=k)`` (``k = 0`` returns the
angle, ``k = 1, 2`` a tuple up to that derivative), e.g. ``FlatFollowerRig.contact_angle`` (the
eccentric cam, A-17) and :class:`impactid.rigs.flat.camprofile.GaussianSumProfile`; they must be
``2 pi``-periodic.

Errors are relative, as Lee (2005) defines them: the error divided by the largest magnitude of the
analytic quantity over a revolution. Because both methods scale the same way with ``omega``
(velocity ``~ omega``, acceleration ``~ omega^2``), the relative errors do not depend on the cam speed.

A periodic cubic spline through ``N`` uniform nodes of a smooth displacement converges at
``h^4`` in the displacement, ``h^3`` in the velocity and ``h^2`` in the acceleration (``h = 2 pi / N``)
once ``h`` is small against the length over which the profile changes; a profile with a feature of
width ``c`` [rad] needs ``h << c``, so the node count for a given error grows like ``1 / c``.

The "sharper profile" of the study, :func:`revised_nose_profile`, is rig F's eccentric cam with a
narrow Gaussian depression at its nose (see its docstring for why it is a fair analogue of Lee's
(2005) revised cam).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy import optimize
from scipy.interpolate import CubicSpline

from impactid.rigs.flat import ALZATE2007, FlatFollowerRig
from impactid.rigs.flat.camprofile import GaussianSumProfile

__all__ = [
    "DEFAULT_NODES",
    "Profile",
    "ProfileSum",
    "analytic_follower_kinematics",
    "convergence_order",
    "displacement_spline",
    "flat_follower_cam_curvature_radius",
    "revised_nose_profile",
    "spline_error_study",
    "spline_follower_kinematics",
]

TWO_PI = 2.0 * math.pi

#: A cam profile: ``profile(theta_c [rad], derivatives=k)`` -> angle [rad] or tuple up to the k-th
#: derivative with respect to the cam angle [rad, rad/rad, rad/rad^2].
Profile = Callable[..., object]

#: Node counts per revolution of the error study (1-2-5 steps from 25 to 10 000, log spaced).
DEFAULT_NODES: tuple[int, ...] = (25, 50, 100, 200, 500, 1000, 2000, 5000, 10_000)


# --------------------------------------------------------------------------------------------
# Profiles
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ProfileSum:
    """Sum of profiles, itself a profile: ``ProfileSum((f, g))(theta_c, derivatives=k)`` adds the
    values (and the derivatives) of ``f`` and ``g``.

    Attributes
    ----------
    terms : profiles with the ``derivatives=`` protocol [rad].
    """

    terms: tuple[Profile, ...]

    def __post_init__(self) -> None:
        if not self.terms:
            raise ValueError("ProfileSum needs at least one term")
        object.__setattr__(self, "terms", tuple(self.terms))

    def __call__(self, theta_c, derivatives: int = 0):
        """Follower angle [rad] (and its derivatives) at cam angle(s) ``theta_c`` [rad]."""
        parts = [_as_tuple(term(theta_c, derivatives=derivatives)) for term in self.terms]
        total = tuple(np.sum(np.stack([np.asarray(p[k], dtype=float) for p in parts]), axis=0)
                      for k in range(derivatives + 1))
        return total[0] if derivatives == 0 else total


def revised_nose_profile(rig: FlatFollowerRig = ALZATE2007, depth: float = 4e-4,
                         width: float = 0.05) -> ProfileSum:
    """Rig F's eccentric cam (A-17) with its nose locally pulled in: the study's sharper profile.

    ``theta_hat(theta_c) + GaussianSumProfile(a=-depth, b=theta_nose, c=width)``, where
    ``theta_nose`` is the cam angle of largest follower lift.

    Why it is a fair analogue of Lee's (2005) revised cam: Lee revises one node of his nine-node
    spline cam contour, moving the extreme point of the nose inwards (5 cm to 4.2 cm), and his
    acceleration then peaks higher and its interpolation error concentrates in a window about five
    degrees wide (his Figs. 6 and 7). Here, too, the nose is pulled in locally: with the defaults
    (a depression of 0.4 mrad of follower angle, about 0.1 mm at the face; ``width`` 0.05 rad, a
    full width at half depth of 4.8 degrees) the peak follower acceleration is four times the
    eccentric cam's, over a few degrees, and the cam stays convex (smallest radius of curvature
    11 mm against the eccentric cam's 45 mm, see :func:`flat_follower_cam_curvature_radius`), so
    a flat-faced follower can follow it. Unlike Lee's spline contour (only twice differentiable),
    this profile is smooth, so the spline converges at the same asymptotic order for both profiles
    and only the constant and the onset of the asymptotic regime (``h << width``) differ; the
    study therefore isolates the effect of the length scale, which is what "changes more sharply"
    means.

    Parameters
    ----------
    rig : rig F parameters (the eccentric cam).
    depth : depth of the depression in follower angle [rad] (> 0 pulls the nose in).
    width : Gaussian width ``c`` [rad] (> 0).
    """
    if not width > 0.0:
        raise ValueError(f"width must be positive, got {width!r} rad")
    res = optimize.minimize_scalar(lambda tc: -float(rig.contact_angle(tc)), bounds=(0.0, TWO_PI),
                                   method="bounded", options={"xatol": 1e-12})
    lobe = GaussianSumProfile(a=(-depth,), b=(float(res.x),), c=(width,))
    return ProfileSum((rig.contact_angle, lobe))


def flat_follower_cam_curvature_radius(profile: Profile, theta_c, x0: float, y0: float, d: float):
    """Radius of curvature [m] of the cam contour that gives ``profile`` with rig F's flat-faced follower.

    The follower face is the line ``p . m = d`` with ``m = (sin theta_f, -cos theta_f)`` (pivot at
    the origin). Seen from the cam, the contour's support function about the cam's centre of
    rotation ``C = (x0, y0)`` is ``p(phi) = C . m - d`` in the normal direction
    ``phi = theta_f + pi/2 - theta_c``, and the contour's radius of curvature is
    ``p + d2p/dphi2``; the cam is convex (a flat face can follow it) where it is positive.
    For the eccentric cam of radius ``R`` it equals ``R`` at every angle.

    Parameters
    ----------
    profile : follower angle in contact ``theta_hat(theta_c)`` [rad] with the ``derivatives=`` protocol.
    theta_c : cam angle(s) [rad].
    x0, y0 : cam centre of rotation from the follower pivot [m].
    d : pivot to follower face [m].
    """
    th, t1, t2 = profile(theta_c, derivatives=2)
    a = x0 * np.cos(th) + y0 * np.sin(th)
    b = x0 * np.sin(th) - y0 * np.cos(th)
    p = b - d
    p_t = a * t1
    p_tt = a * t2 - b * t1 * t1
    phi_t = t1 - 1.0
    return p + (p_tt * phi_t - p_t * t2) / phi_t**3


# --------------------------------------------------------------------------------------------
# Kinematics
# --------------------------------------------------------------------------------------------


def analytic_follower_kinematics(profile: Profile, theta_c, omega: float):
    """Follower angle, angular velocity and acceleration in permanent contact at constant cam speed,
    from the profile's analytic derivatives (the chain rule of the module doc).

    ``theta_f = theta_hat(theta_c)``, ``theta_f_dot = omega theta_hat'(theta_c)`` and
    ``theta_f_ddot = omega^2 theta_hat''(theta_c)``: derivatives with respect to *time*, the
    reference :func:`spline_follower_kinematics` is compared with. (Rig P's
    :func:`impactid.rigs.pivoted.regimes.follower_kinematics` gives derivatives with respect to the
    cam angle instead.)

    Parameters
    ----------
    profile : follower angle in contact ``theta_hat(theta_c)`` [rad] with the ``derivatives=`` protocol.
    theta_c : cam angle(s) [rad].
    omega : constant cam speed [rad/s].

    Returns
    -------
    theta_f, theta_f_dot, theta_f_ddot : arrays shaped like ``theta_c`` [rad, rad/s, rad/s^2].
    """
    th, t1, t2 = profile(theta_c, derivatives=2)
    return np.asarray(th, dtype=float), omega * np.asarray(t1, dtype=float), omega**2 * np.asarray(t2, dtype=float)


def displacement_spline(profile: Profile, nodes: int, theta_start: float = 0.0) -> CubicSpline:
    """Periodic cubic spline through the displacement at ``nodes`` uniform cam angles per revolution.

    Nodes at ``theta_start + 2 pi k / nodes`` [rad], ``k = 0 .. nodes``, the last repeating the
    first (``bc_type="periodic"``, periodic extrapolation, so any cam angle may be evaluated).

    Parameters
    ----------
    profile : follower angle in contact [rad] (``profile(theta_c)`` is all that is used).
    nodes : nodes per revolution ``N`` (>= 4).
    theta_start : cam angle of the first node [rad].
    """
    nodes = int(nodes)
    if nodes < 4:
        raise ValueError(f"a periodic cubic spline needs at least 4 nodes per revolution, got {nodes}")
    knots = theta_start + TWO_PI * np.arange(nodes + 1) / nodes
    values = np.asarray(profile(knots[:-1]), dtype=float)
    return CubicSpline(knots, np.append(values, values[0]), bc_type="periodic")


def spline_follower_kinematics(profile: Profile, theta_c, omega: float, nodes: int, theta_start: float = 0.0):
    """Follower angle, angular velocity and acceleration from a differentiated periodic cubic spline.

    The displacement is interpolated by :func:`displacement_spline` through ``nodes`` uniform nodes
    per revolution and differentiated once and twice (the practice Lee (2005) compares against).

    Parameters
    ----------
    profile : follower angle in contact [rad].
    theta_c : cam angle(s) [rad].
    omega : constant cam speed [rad/s].
    nodes : nodes per revolution ``N`` (>= 4).
    theta_start : cam angle of the first node [rad].

    Returns
    -------
    theta_f, theta_f_dot, theta_f_ddot : arrays shaped like ``theta_c`` [rad, rad/s, rad/s^2].
    """
    spline = displacement_spline(profile, nodes, theta_start)
    tc = np.asarray(theta_c, dtype=float)
    return spline(tc), omega * spline(tc, 1), omega**2 * spline(tc, 2)


# --------------------------------------------------------------------------------------------
# Error study
# --------------------------------------------------------------------------------------------


def spline_error_study(profile: Profile, nodes: Sequence[int] = DEFAULT_NODES, points_per_interval: int = 8,
                       scale_samples: int = 2**18, theta_start: float = 0.0) -> pd.DataFrame:
    """Relative error of the spline velocity and acceleration against the analytic ones, per node count.

    For each ``N`` in ``nodes`` the spline of :func:`displacement_spline` is differentiated and
    compared with the analytic derivatives on a dense grid of ``points_per_interval`` uniformly
    spaced cam angles in each node interval (nodes included). Errors are divided by the largest
    magnitude of the analytic quantity over the revolution (Lee's (2005) definition), taken on a fixed
    grid of ``scale_samples`` angles so that the scale does not change with ``N``. The cam speed
    cancels out of these ratios.

    Parameters
    ----------
    profile : follower angle in contact [rad] with the ``derivatives=`` protocol.
    nodes : node counts per revolution (each >= 4).
    points_per_interval : evaluation points per node interval (>= 1).
    scale_samples : grid size for the largest analytic magnitudes.
    theta_start : cam angle of the first node [rad].

    Returns
    -------
    DataFrame, one row per ``N``: ``nodes``; ``node_spacing_deg`` [deg]; ``max_rel_error_velocity``,
    ``rms_rel_error_velocity``, ``max_rel_error_acceleration``, ``rms_rel_error_acceleration`` [-];
    ``theta_c_max_error_acceleration`` (cam angle of the largest acceleration error, [rad] in
    ``[0, 2 pi)``). ``attrs`` holds the scales (``velocity_scale`` [rad/rad],
    ``acceleration_scale`` [rad/rad^2]) and the study settings.
    """
    if int(points_per_interval) < 1:
        raise ValueError(f"points_per_interval must be >= 1, got {points_per_interval!r}")
    m = int(points_per_interval)
    fine = theta_start + TWO_PI * np.arange(int(scale_samples)) / int(scale_samples)
    _, fine_1, fine_2 = profile(fine, derivatives=2)
    v_scale = float(np.max(np.abs(fine_1)))
    a_scale = float(np.max(np.abs(fine_2)))
    if not (v_scale > 0.0 and a_scale > 0.0):
        raise ValueError("the profile is constant: relative errors are undefined")
    rows = []
    for n in nodes:
        spline = displacement_spline(profile, n, theta_start)
        grid = theta_start + TWO_PI * np.arange(int(n) * m) / (int(n) * m)
        _, ref_1, ref_2 = profile(grid, derivatives=2)
        err_v = np.abs(spline(grid, 1) - ref_1) / v_scale
        err_a = np.abs(spline(grid, 2) - ref_2) / a_scale
        k = int(np.argmax(err_a))
        rows.append({
            "nodes": int(n),
            "node_spacing_deg": 360.0 / int(n),
            "max_rel_error_velocity": float(err_v.max()),
            "rms_rel_error_velocity": float(np.sqrt(np.mean(err_v**2))),
            "max_rel_error_acceleration": float(err_a.max()),
            "rms_rel_error_acceleration": float(np.sqrt(np.mean(err_a**2))),
            "theta_c_max_error_acceleration": float(np.mod(grid[k], TWO_PI)),
        })
    frame = pd.DataFrame(rows)
    frame.attrs.update({"velocity_scale": v_scale, "acceleration_scale": a_scale,
                        "points_per_interval": m, "scale_samples": int(scale_samples),
                        "theta_start": float(theta_start), "profile": repr(profile)})
    return frame


def convergence_order(frame: pd.DataFrame, column: str, nodes_min: int | None = None,
                      nodes_max: int | None = None) -> float:
    """Observed convergence order ``p`` of ``column ~ N^-p``: least-squares slope of
    ``log(column)`` against ``log(nodes)``, negated, over ``nodes_min <= N <= nodes_max``.

    Parameters
    ----------
    frame : a table of :func:`spline_error_study`.
    column : error column, e.g. ``"max_rel_error_acceleration"``.
    nodes_min, nodes_max : range of node counts fitted (default: all rows).
    """
    sel = frame
    if nodes_min is not None:
        sel = sel[sel["nodes"] >= nodes_min]
    if nodes_max is not None:
        sel = sel[sel["nodes"] <= nodes_max]
    if len(sel) < 2:
        raise ValueError(f"need at least two rows to fit an order, got {len(sel)}")
    slope = np.polyfit(np.log(sel["nodes"].to_numpy(float)), np.log(sel[column].to_numpy(float)), 1)[0]
    return float(-slope)


def _as_tuple(value) -> tuple:
    return value if isinstance(value, tuple) else (value,)

r"""Synthetic tables of planar impacts made by a known law (``impactid synth --rig planar-impact``).

An elliptical body (semi-axes ``a``, ``b``; the mass and the radius of gyration of a
:class:`~impactid.rigs.planar.parameters.PlanarBody`) falls onto a horizontal floor (``y`` up) at a
random orientation ``theta``; it touches at its lowest point, at ``r = (r_x, r_y)`` from the centre
of mass,

.. math:: r_y = -\sqrt{a^2 \sin^2\theta + b^2 \cos^2\theta}, \qquad
          r_x = -(a^2 - b^2) \sin\theta \cos\theta / |r_y|,

so that the contact Jacobian's rows are ``J_n = (0, 1, r_x)`` and ``J_t = (1, 0, -r_y)`` (the
contact point's velocity ``v + omega x r``). The contact point approaches at a speed drawn uniformly
from ``approach_speeds``; the centre slides at up to ``sliding_speed`` either way and spins at up to
``spin`` either way. The outcome (the impulse and the post-impact velocity) is the law's
(:func:`~impactid.rigs.planar.laws.outcome`: Newton or Chatterjee-Ruina restitution, constant or
``e0 (1 - gamma u)``, Coulomb friction with sticking, tangential restitution ``e_t``); impacts the
law cannot resolve (Painleve's paradox of sliding with friction) are drawn again.

Measurement noise: Gaussian with standard deviation ``noise`` [m/s] on ``v_x`` and ``v_y`` and
``noise / k_g`` [rad/s] on ``omega``, before and after the impact (as a motion-capture system sees
both); the written impulses are the ones the noisy velocity change implies, the least-squares
solution of ``M (v^+ - v^-) = J_t^T p_t + J_n^T p_n``. The table has the columns of
:mod:`~impactid.rigs.planar.table` (docs/formats.md); the law's parameters stay in the
:class:`SyntheticImpacts` and are never written into it.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from impactid._files import atomic_write
from impactid.rigs.planar.laws import ImpactOutcome, PlanarLaw, get_law, outcome
from impactid.rigs.planar.parameters import MCUBE_ELLIPSE, PlanarBody
from impactid.rigs.planar.table import (
    ID_COLUMN,
    IMPULSE_COLUMNS,
    JACOBIAN_COLUMNS,
    POST_COLUMNS,
    PRE_COLUMNS,
)

__all__ = ["DEFAULT_APPROACH_SPEEDS", "DEFAULT_NOISE", "DEFAULT_SEMI_AXES", "MAX_IMPACTS", "TABLE_FORMATS",
           "SyntheticImpacts", "impacts_frame", "synth_impacts", "write_impacts"]

#: The semi-axes of the MCube ellipse (Fazeli, Donlon, Drumwright & Rodriguez 2017) [m].
DEFAULT_SEMI_AXES = (0.035, 0.025)
#: Range of the contact point's approach speed [m/s].
DEFAULT_APPROACH_SPEEDS = (1.0, 3.0)
#: Largest sliding speed of the centre before the impact [m/s], either way.
DEFAULT_SLIDING_SPEED = 1.0
#: Largest spin before the impact [rad/s], either way.
DEFAULT_SPIN = 15.0
#: Standard deviation of the measured velocities [m/s] (motion capture at a few hundred Hz).
DEFAULT_NOISE = 0.01
#: Most impacts of one table.
MAX_IMPACTS = 1_000_000
#: The suffixes :func:`write_impacts` writes (a separator each).
TABLE_FORMATS = {".csv": ",", ".tsv": "\t"}


@dataclass(frozen=True)
class SyntheticImpacts:
    """A synthetic table of planar impacts and its truth.

    Attributes
    ----------
    q_pre : (n, 3) configuration ``(x, y, theta)`` [m, m, rad].
    v_pre, v_post : (n, 3) measured velocities before and after [m/s, m/s, rad/s] (with noise).
    impulse : (n, 2) ``(p_t, p_n)`` the noisy velocity change implies [N s].
    jn, jt : (n, 3) the contact Jacobian's rows [-, -, m].
    exact : the law's outcome on the exact pre-impact velocities (:class:`~impactid.rigs.planar.laws.ImpactOutcome`).
    v_exact : (n, 3) the exact pre-impact velocities.
    law : the law; values : its parameters by name; body : the body; noise : [m/s]; seed.
    """

    q_pre: np.ndarray
    v_pre: np.ndarray
    v_post: np.ndarray
    impulse: np.ndarray
    jn: np.ndarray
    jt: np.ndarray
    exact: ImpactOutcome
    v_exact: np.ndarray
    law: PlanarLaw
    values: dict
    body: PlanarBody
    noise: float
    seed: int

    def __len__(self) -> int:
        return int(self.v_pre.shape[0])


def _contact(theta: np.ndarray, a: float, b: float) -> tuple[np.ndarray, np.ndarray]:
    """The lowest point of the ellipse at orientation ``theta`` from its centre: ``(r_x, r_y)`` [m]."""
    s, c = np.sin(theta), np.cos(theta)
    depth = np.sqrt(a * a * s * s + b * b * c * c)
    return -(a * a - b * b) * s * c / depth, -depth


def synth_impacts(law: str | PlanarLaw, values: dict, *, body: PlanarBody = MCUBE_ELLIPSE, count: int = 200,
                  semi_axes: tuple[float, float] = DEFAULT_SEMI_AXES,
                  approach_speeds: tuple[float, float] = DEFAULT_APPROACH_SPEEDS,
                  sliding_speed: float = DEFAULT_SLIDING_SPEED, spin: float = DEFAULT_SPIN,
                  noise: float = DEFAULT_NOISE, seed: int = 0) -> SyntheticImpacts:
    """``count`` impacts of ``body`` on a floor made by ``law`` with the parameters ``values``.

    Parameters
    ----------
    law : a law of :data:`~impactid.rigs.planar.laws.LAWS` (its name or itself).
    values : its parameters by name (``e`` or ``e0`` and ``gamma`` [s/m]; ``mu``; ``e_t`` for a ``-et`` law).
    body : mass and radius of gyration.
    count : number of impacts, >= 1.
    semi_axes : the ellipse's semi-axes ``(a, b)`` [m], positive.
    approach_speeds : ``(low, high)`` the contact point's approach speed [m/s], 0 < low <= high.
    sliding_speed : largest ``|v_x|`` before the impact [m/s]; spin : largest ``|omega|`` [rad/s].
    noise : standard deviation of the measured velocities [m/s] (``noise / k_g`` on ``omega``), >= 0.
    seed : seed of the impacts and the noise.

    Raises
    ------
    ValueError
        a value out of range, a missing parameter, or a law that leaves too many impacts unresolved.
    """
    law = get_law(law)
    missing = [n for n in law.names if n not in values]
    if missing:
        raise ValueError(f"law {law.name!r} needs parameter(s) {', '.join(missing)}")
    values = {n: float(values[n]) for n in law.names}
    a, b = (float(x) for x in semi_axes)
    low, high = (float(x) for x in approach_speeds)
    checks = ((1 <= count <= MAX_IMPACTS, f"count must lie in [1, {MAX_IMPACTS}]"),
              (a > 0.0 and b > 0.0, "the semi-axes must be positive"),
              (0.0 < low <= high, "the approach speeds must satisfy 0 < low <= high"),
              (sliding_speed >= 0.0 and spin >= 0.0 and noise >= 0.0,
               "the sliding speed, the spin and the noise must be >= 0"),
              (all(math.isfinite(x) for x in (a, b, low, high, sliding_speed, spin, noise, *values.values())),
               "the values must be finite"),
              (values["mu"] >= 0.0, "mu must be >= 0"))
    for ok, message in checks:
        if not ok:
            raise ValueError(message)
    rng = np.random.default_rng(seed)
    minv = np.asarray(body.inverse_mass)
    theta = np.empty(count)
    v = np.empty((count, 3))
    todo = np.arange(count)
    for _ in range(20):
        k = todo.size
        theta[todo] = rng.uniform(0.0, 2.0 * math.pi, k)
        r_x, _ = _contact(theta[todo], a, b)
        omega = rng.uniform(-spin, spin, k)
        v[todo] = np.column_stack([rng.uniform(-sliding_speed, sliding_speed, k),
                                   -rng.uniform(low, high, k) - r_x * omega, omega])
        r_x, r_y = _contact(theta, a, b)
        jn = np.column_stack([np.zeros(count), np.ones(count), r_x])
        jt = np.column_stack([np.ones(count), np.zeros(count), -r_y])
        exact = outcome(law, values, v, jt, jn, minv)
        todo = np.flatnonzero(~(np.isfinite(exact.p_n) & np.isfinite(exact.p_t)))
        if todo.size == 0:
            break
    else:
        raise ValueError(f"the {law.name} law with mu = {values['mu']:g} leaves impacts unresolved (Painleve's "
                         "paradox: sliding with that friction has no solution); give a smaller mu")
    k_g = body.radius_of_gyration
    scale = np.array([noise, noise, noise / k_g])
    v_pre = v + scale * rng.standard_normal(v.shape)
    v_post = exact.v_post + scale * rng.standard_normal(v.shape)
    # the impulse the measured velocity change implies: least squares of M dv = J^T p
    mass = np.asarray(body.diagonal_mass)
    moment = mass * (v_post - v_pre)
    impulse = np.empty((count, 2))
    for i in range(count):
        basis = np.column_stack([jt[i], jn[i]])
        impulse[i] = np.linalg.lstsq(basis, moment[i], rcond=None)[0]
    q_pre = np.column_stack([rng.uniform(-0.1, 0.1, count), -r_y, theta])
    return SyntheticImpacts(q_pre=q_pre, v_pre=v_pre, v_post=v_post, impulse=impulse, jn=jn, jt=jt, exact=exact,
                            v_exact=v, law=law, values=values, body=body, noise=float(noise), seed=int(seed))


def impacts_frame(impacts: SyntheticImpacts) -> pd.DataFrame:
    """The table (docs/formats.md): ``impact``, the pre-impact state, the Jacobian, the post-impact
    state (the configuration unchanged by an instantaneous impact) and the impulses."""
    n = len(impacts)
    columns = {ID_COLUMN: np.arange(1, n + 1)}
    pre = np.column_stack([impacts.q_pre, impacts.v_pre])
    post = np.column_stack([impacts.q_pre, impacts.v_post])
    columns.update({name: pre[:, k] for k, name in enumerate(PRE_COLUMNS)})
    columns.update({name: np.column_stack([impacts.jn, impacts.jt])[:, k] for k, name in enumerate(JACOBIAN_COLUMNS)})
    columns.update({name: post[:, k] for k, name in enumerate(POST_COLUMNS)})
    columns.update({name: impacts.impulse[:, k] for k, name in enumerate(IMPULSE_COLUMNS)})
    return pd.DataFrame(columns)


def write_impacts(path: str | os.PathLike[str], impacts: SyntheticImpacts) -> Path:
    """Write the table as CSV (``.csv``) or TSV (``.tsv``), atomically.

    Raises
    ------
    ValueError : another suffix.
    """
    suffix = Path(path).suffix.lower()
    if suffix not in TABLE_FORMATS:
        raise ValueError(f"unknown suffix {suffix or '(none)'!r}; a table of impacts is written as "
                         f"{', '.join(TABLE_FORMATS)}")
    text = impacts_frame(impacts).to_csv(index=False, sep=TABLE_FORMATS[suffix], float_format="%.10g")
    return atomic_write(path, text)

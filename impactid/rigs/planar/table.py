"""Tables of planar impacts: one row per impact, read column by column (docs/formats.md).

The layout is that of the planar impact dataset of Fazeli, Donlon, Drumwright & Rodriguez (2017),
SI units and radians, ``y`` up:

====================================================== ==================================================
columns                                                meaning
====================================================== ==================================================
``impact`` (optional)                                  the impact's number (default: the row, from 1)
``x_pre, y_pre, theta_pre``                            configuration of the centre of mass before the impact
``vx_pre, vy_pre, omega_pre``                          its velocity just before the impact [m/s, m/s, rad/s]
``jn_x, jn_y, jn_theta``                               normal row of the contact Jacobian [-, -, m]
``jt_x, jt_y, jt_theta``                               tangential row [-, -, m]
``x_post, ..., omega_post`` (optional)                 the same just after the impact
``impulse_t, impulse_n`` (optional)                    the measured tangential and normal impulse [N s]
====================================================== ==================================================

The rows of the Jacobian map the generalised velocity ``v`` to the contact point's normal and
tangential velocity, ``v_n = J_n v`` (positive apart) and ``v_t = J_t v``; the impulse acts on the
body as ``J_n^T p_n + J_t^T p_t``. Other columns (a published model's ``<model>_impulse_t``, ...) are
never read.

Two readers, which select their columns explicitly (pandas ``usecols``: no other column is parsed):

* :func:`read_pre_impact`: what a prediction may use, the pre-impact state and the Jacobian only;
* :func:`read_impacts`: the same and the measured outcome (post-impact velocities and/or impulses),
  what a fit and the scoring of a prediction use.

Errors are one line naming the file and the column (:class:`PlanarTableError`).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from impactid.errors import ImpactidError

__all__ = ["ID_COLUMN", "IMPULSE_COLUMNS", "JACOBIAN_COLUMNS", "POST_COLUMNS", "POST_VELOCITY_COLUMNS",
           "PRE_COLUMNS", "PlanarImpacts", "PlanarTableError", "read_impacts", "read_pre_impact"]

#: The impact's number (optional).
ID_COLUMN = "impact"
#: The pre-impact configuration and velocity of the centre of mass.
PRE_COLUMNS = ("x_pre", "y_pre", "theta_pre", "vx_pre", "vy_pre", "omega_pre")
#: The normal and the tangential row of the contact Jacobian.
JACOBIAN_COLUMNS = ("jn_x", "jn_y", "jn_theta", "jt_x", "jt_y", "jt_theta")
#: The post-impact configuration and velocity (optional).
POST_COLUMNS = ("x_post", "y_post", "theta_post", "vx_post", "vy_post", "omega_post")
#: The post-impact velocity (what a velocity fit and the scoring use).
POST_VELOCITY_COLUMNS = ("vx_post", "vy_post", "omega_post")
#: The measured tangential and normal impulse (optional).
IMPULSE_COLUMNS = ("impulse_t", "impulse_n")


class PlanarTableError(ImpactidError, ValueError):
    """A table of planar impacts that cannot be used (the message names the file and the column)."""


@dataclass(frozen=True)
class PlanarImpacts:
    """Impacts of a rigid body in the plane, one row each (SI units, radians).

    Attributes
    ----------
    source : where they were read (a file name, for messages and results).
    impact : (n,) the impacts' numbers.
    q_pre : (n, 3) configuration ``(x, y, theta)`` before the impact [m, m, rad].
    v_pre : (n, 3) velocity ``(v_x, v_y, omega)`` before the impact [m/s, m/s, rad/s].
    jn, jt : (n, 3) the normal and tangential rows of the contact Jacobian [-, -, m].
    v_post : (n, 3) velocity after the impact, or None (not read, or not in the file).
    impulse : (n, 2) measured impulse ``(p_t, p_n)`` [N s], or None.
    """

    source: str
    impact: np.ndarray
    q_pre: np.ndarray
    v_pre: np.ndarray
    jn: np.ndarray
    jt: np.ndarray
    v_post: np.ndarray | None = None
    impulse: np.ndarray | None = None

    def __len__(self) -> int:
        return int(self.impact.size)

    def subset(self, rows) -> PlanarImpacts:
        """The impacts of ``rows`` (indices or a boolean mask), as a new table."""
        rows = np.asarray(rows)
        return PlanarImpacts(self.source, self.impact[rows], self.q_pre[rows], self.v_pre[rows], self.jn[rows],
                             self.jt[rows], None if self.v_post is None else self.v_post[rows],
                             None if self.impulse is None else self.impulse[rows])

    def pre_impact(self) -> PlanarImpacts:
        """The same impacts without their outcome (what a prediction may see)."""
        return PlanarImpacts(self.source, self.impact, self.q_pre, self.v_pre, self.jn, self.jt)


def _header(path: Path, sep: str) -> list[str]:
    try:
        return [str(c).strip() for c in pd.read_csv(path, sep=sep, nrows=0).columns]
    except (pd.errors.EmptyDataError, pd.errors.ParserError, UnicodeDecodeError) as exc:
        raise PlanarTableError(f"{path}: not a table of impacts ({str(exc).splitlines()[0]})") from None


def _open(path: str | os.PathLike[str]) -> tuple[Path, str]:
    path = Path(path)
    if not path.exists():
        raise PlanarTableError(f"{path}: no such file")
    if not path.is_file():
        raise PlanarTableError(f"{path}: not a regular file")
    return path, ("\t" if path.suffix.lower() in (".tsv", ".tab") else ",")


def _read(path: Path, sep: str, wanted: list[str]) -> pd.DataFrame:
    """The ``wanted`` columns of the file (no other is parsed), as floats; one line per problem."""
    try:
        frame = pd.read_csv(path, sep=sep, usecols=lambda c: str(c).strip() in wanted, dtype=str)
    except (pd.errors.ParserError, UnicodeDecodeError, ValueError) as exc:
        raise PlanarTableError(f"{path}: not a table of impacts ({str(exc).splitlines()[0]})") from None
    frame.columns = [str(c).strip() for c in frame.columns]
    if len(frame) == 0:
        raise PlanarTableError(f"{path}: no impact (the table has a header and no row)")
    out = {}
    for name in wanted:
        values = pd.to_numeric(frame[name].str.strip(), errors="coerce").to_numpy(dtype=float)
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            raise PlanarTableError(f"{path}: column {name!r} has {bad.size} value(s) that are not finite numbers "
                                   f"(first at data row {bad[0] + 1}: {frame[name].iloc[bad[0]]!r})")
        out[name] = values
    return pd.DataFrame(out)


def _missing(path: Path, header: list[str], names) -> None:
    missing = [n for n in names if n not in header]
    if missing:
        raise PlanarTableError(f"{path}: missing column(s) {', '.join(repr(n) for n in missing)} (a table of planar "
                               "impacts needs the pre-impact state and the contact Jacobian; docs/formats.md)")


def _build(path: Path, frame: pd.DataFrame, has_id: bool, v_post, impulse) -> PlanarImpacts:
    impact = (frame[ID_COLUMN].to_numpy().astype(int) if has_id else np.arange(1, len(frame) + 1))
    block = frame[list(PRE_COLUMNS)].to_numpy()
    jac = frame[list(JACOBIAN_COLUMNS)].to_numpy()
    impacts = PlanarImpacts(str(path), impact, block[:, :3], block[:, 3:], jac[:, :3], jac[:, 3:], v_post, impulse)
    jn_norm = np.hypot(impacts.jn[:, 0], impacts.jn[:, 1])
    jt_norm = np.hypot(impacts.jt[:, 0], impacts.jt[:, 1])
    for name, norm in (("jn_x, jn_y", jn_norm), ("jt_x, jt_y", jt_norm)):
        bad = np.flatnonzero(norm <= 1e-9)
        if bad.size:
            raise PlanarTableError(f"{path}: columns {name} are zero at impact {impact[bad[0]]}: a contact Jacobian "
                                   "row needs a direction")
    return impacts


def read_pre_impact(path: str | os.PathLike[str]) -> PlanarImpacts:
    """The pre-impact states and contact Jacobians of a table of planar impacts, nothing else.

    Only ``impact``, :data:`PRE_COLUMNS` and :data:`JACOBIAN_COLUMNS` are parsed (pandas ``usecols``):
    the post-impact, impulse and published-model columns are not read, whatever they hold.

    Raises
    ------
    PlanarTableError
        naming the file and the column: no such file, a missing column, a value that is not a
        finite number, a Jacobian row without direction, an empty table.
    """
    path, sep = _open(path)
    header = _header(path, sep)
    _missing(path, header, PRE_COLUMNS + JACOBIAN_COLUMNS)
    has_id = ID_COLUMN in header
    frame = _read(path, sep, ([ID_COLUMN] if has_id else []) + list(PRE_COLUMNS + JACOBIAN_COLUMNS))
    return _build(path, frame, has_id, None, None)


def read_impacts(path: str | os.PathLike[str], *, require: str = "any") -> PlanarImpacts:
    """A table of planar impacts with the measured outcome (for a fit, or to score a prediction).

    Parameters
    ----------
    path : CSV (``.tsv``/``.tab``: tab-separated) with the columns of the module's table.
    require : ``"impulse"`` (the columns :data:`IMPULSE_COLUMNS` must be there), ``"velocity"``
        (:data:`POST_VELOCITY_COLUMNS`) or ``"any"`` (at least one of the two groups).

    Returns
    -------
    PlanarImpacts
        with ``impulse`` and ``v_post`` where the file has them (a group with a missing column is
        not read: None).

    Raises
    ------
    PlanarTableError
        as :func:`read_pre_impact`, and naming the missing outcome columns.
    """
    if require not in ("any", "impulse", "velocity"):
        raise ValueError(f"require must be 'any', 'impulse' or 'velocity', got {require!r}")
    path, sep = _open(path)
    header = _header(path, sep)
    _missing(path, header, PRE_COLUMNS + JACOBIAN_COLUMNS)
    has_impulse = all(c in header for c in IMPULSE_COLUMNS)
    has_post = all(c in header for c in POST_VELOCITY_COLUMNS)
    needed = {"impulse": IMPULSE_COLUMNS, "velocity": POST_VELOCITY_COLUMNS}.get(require)
    if needed is not None and not all(c in header for c in needed):
        _missing(path, header, needed)
    if require == "any" and not (has_impulse or has_post):
        missing = [c for c in IMPULSE_COLUMNS + POST_VELOCITY_COLUMNS if c not in header]
        raise PlanarTableError(f"{path}: missing column(s) {', '.join(repr(n) for n in missing)}: no measured outcome "
                               f"(the impulses {', '.join(IMPULSE_COLUMNS)} or the post-impact velocities "
                               f"{', '.join(POST_VELOCITY_COLUMNS)})")
    has_id = ID_COLUMN in header
    wanted = (([ID_COLUMN] if has_id else []) + list(PRE_COLUMNS + JACOBIAN_COLUMNS)
              + (list(IMPULSE_COLUMNS) if has_impulse else []) + (list(POST_VELOCITY_COLUMNS) if has_post else []))
    frame = _read(path, sep, wanted)
    v_post = frame[list(POST_VELOCITY_COLUMNS)].to_numpy() if has_post else None
    impulse = frame[list(IMPULSE_COLUMNS)].to_numpy() if has_impulse else None
    return _build(path, frame, has_id, v_post, impulse)

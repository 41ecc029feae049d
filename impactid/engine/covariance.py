"""Parameter covariance from a least-squares Jacobian, with its condition and an honest "undetermined".

Every fit in impactid that reports standard errors from ``(J^T J)^-1`` goes through
:func:`covariance_from_jacobian`, so that they share one rule for when a standard error is a number:

* The columns of ``J`` are scaled to unit norm first (the condition then does not depend on the
  parameters' units), and the covariance is formed from the singular value decomposition of the
  scaled ``J`` (``V diag(1/s^2) V^T``), never by inverting ``J^T J`` explicitly, whose rounding
  errors can make diagonal entries negative.
* ``condition`` is the condition number of the scaled ``J^T J``, ``(s_max / s_min)^2``. Inverting a
  matrix of condition ``kappa`` in double precision loses about ``kappa * eps`` of relative accuracy;
  above :data:`CONDITION_LIMIT` (``0.01 / eps``, about 4.5e13) the covariance would not be known to
  1 %, and, more to the point, the data do not determine the parameters separately: two library
  releases, or two starting points, stop at different places along the flat directions. Then every
  standard error is reported as undetermined (NaN, ``null`` in JSON) and ``reason`` says why. Below
  the limit every standard error is a number: a standard error never flips between a number and
  "undetermined" with the release of a linear-algebra library.

A column of zeros (a parameter the model does not depend on at the optimum) is a different case: that
parameter alone is undetermined (``reason`` names it) and the others keep their numbers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["CONDITION_LIMIT", "Covariance", "covariance_from_jacobian"]

#: Largest condition number of the column-scaled ``J^T J`` at which standard errors are reported:
#: ``0.01 / eps`` (the covariance is then known to about 1 %). Above it they are undetermined.
CONDITION_LIMIT: float = 0.01 / float(np.finfo(float).eps)


@dataclass(frozen=True)
class Covariance:
    """The covariance of fitted parameters and how well it is determined.

    Attributes
    ----------
    matrix : (p, p) covariance [parameter units squared]; NaN rows/columns where undetermined.
    stderr : (p,) standard errors ``sqrt(diag(matrix))`` [parameter units]; NaN where undetermined.
    condition : condition number of the column-scaled ``J^T J`` over the parameters the model
        depends on [-] (inf when a combination of them is not determined at all).
    reason : empty when every standard error is a number; else why some or all are undetermined.
    """

    matrix: np.ndarray
    stderr: np.ndarray
    condition: float
    reason: str = ""

    @property
    def determined(self) -> bool:
        """Whether every standard error is a number."""
        return bool(np.all(np.isfinite(self.stderr)))

    @property
    def correlation(self) -> np.ndarray:
        """The correlation matrix (NaN where undetermined)."""
        with np.errstate(invalid="ignore", divide="ignore"):
            return self.matrix / np.outer(self.stderr, self.stderr)


def covariance_from_jacobian(jacobian: np.ndarray, scale: float = 1.0, *, names: tuple[str, ...] | None = None,
                             condition_limit: float = CONDITION_LIMIT) -> Covariance:
    """Covariance ``scale * (J^T J)^-1`` of least-squares parameters, with its condition.

    Parameters
    ----------
    jacobian : (m, p) Jacobian of the (weighted) residuals with respect to the parameters at the
        optimum [residual units per parameter unit].
    scale : the variance of one residual, usually the reduced chi-square ``chisqr / (m - p)``
        [residual units squared]; 1 for residuals already divided by their standard deviations.
    names : the parameters' names, for ``reason`` (default ``p0, p1, ...``).
    condition_limit : the largest condition number of the scaled ``J^T J`` with standard errors
        reported (default :data:`CONDITION_LIMIT`).

    Returns
    -------
    Covariance
        the matrix, standard errors, condition and, when some are undetermined, the reason.
    """
    J = np.asarray(jacobian, dtype=float)
    if J.ndim != 2:
        raise ValueError(f"expected a 2-D Jacobian, got shape {J.shape}")
    m, p = J.shape
    names = tuple(names) if names is not None else tuple(f"p{k}" for k in range(p))
    matrix = np.full((p, p), math.nan)
    stderr = np.full(p, math.nan)
    if p == 0:
        return Covariance(matrix, stderr, 1.0)
    if not (np.all(np.isfinite(J)) and math.isfinite(scale) and scale >= 0.0):
        return Covariance(matrix, stderr, math.inf, "the Jacobian or the residual variance is not finite")
    norms = np.sqrt(np.sum(J * J, axis=0))
    live = norms > 0.0
    dead = [names[k] for k in range(p) if not live[k]]
    if not live.any():
        return Covariance(matrix, stderr, math.inf, "the residuals do not depend on any parameter")
    scaled = J[:, live] / norms[live]
    _, s, vt = np.linalg.svd(scaled, full_matrices=False)
    if s.size < int(live.sum()) or s[-1] <= 0.0:
        condition = math.inf
    else:
        condition = float((s[0] / s[-1]) ** 2)
    if not condition <= condition_limit:
        reason = (f"the data do not determine the parameters separately: the condition number of J^T J is "
                  f"{condition:.3g}, above {condition_limit:.3g} (standard errors would not be known to 1 %)")
        if m < p:
            reason += f"; {m} data for {p} parameters"
        return Covariance(matrix, stderr, condition, reason)
    inner = (vt.T / s**2) @ vt  # (scaled J^T scaled J)^-1 from the SVD
    cov_live = scale * inner / np.outer(norms[live], norms[live])
    idx = np.flatnonzero(live)
    matrix[np.ix_(idx, idx)] = cov_live
    stderr[idx] = np.sqrt(np.clip(np.diag(cov_live), 0.0, None))
    reason = ""
    if dead:
        reason = f"the residuals do not depend on {', '.join(dead)} at the optimum (undetermined)"
    return Covariance(matrix, stderr, condition, reason)

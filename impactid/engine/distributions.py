"""The few distribution functions the engine's intervals and checks need, from :mod:`scipy.special`.

``scipy.stats`` takes 0.3-0.6 s to import (its hundred distributions, with their docstrings built at
import), which every estimate paid for five functions; these are the special functions that
``scipy.stats``' own methods evaluate (``t.ppf`` is ``stdtrit``, ``chi2.sf`` is ``chdtrc``, ...), so the
values are the same (tests/test_engine_distributions.py compares them with ``scipy.stats``).
"""

from __future__ import annotations

from scipy import special

__all__ = ["chi2_quantile", "chi2_sf", "normal_quantile", "normal_sf", "student_t_quantile", "student_t_sf",
           "two_sided_quantile"]


def student_t_quantile(p: float, dof: float) -> float:
    """Quantile of Student's t with ``dof`` degrees of freedom at probability ``p`` (``scipy.stats.t.ppf``)."""
    return float(special.stdtrit(dof, p))


def student_t_sf(x: float, dof: float) -> float:
    """Upper tail probability of Student's t beyond ``x`` (``scipy.stats.t.sf``)."""
    return float(special.stdtr(dof, -x))


def chi2_quantile(p: float, dof: float) -> float:
    """Quantile of the chi-square law with ``dof`` degrees of freedom at ``p`` (``scipy.stats.chi2.ppf``)."""
    return float(2.0 * special.gammaincinv(0.5 * dof, p))


def chi2_sf(x: float, dof: float) -> float:
    """Upper tail probability of the chi-square law beyond ``x`` (``scipy.stats.chi2.sf``)."""
    return float(special.chdtrc(dof, x))


def normal_quantile(p: float) -> float:
    """Quantile of the standard normal law at ``p`` (``scipy.stats.norm.ppf``)."""
    return float(special.ndtri(p))


def normal_sf(x: float) -> float:
    """Upper tail probability of the standard normal law beyond ``x`` (``scipy.stats.norm.sf``)."""
    return float(special.ndtr(-x))


def two_sided_quantile(level: float, dof: float) -> float:
    """The two-sided ``level`` quantile of Student's t with ``dof`` degrees of freedom (the normal law's without
    any): the half-width of a ``level`` interval in standard errors."""
    p = 0.5 + 0.5 * level
    return student_t_quantile(p, dof) if dof > 0 else normal_quantile(p)

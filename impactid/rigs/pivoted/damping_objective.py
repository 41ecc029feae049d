"""The contact-damping fit's objective and problem: what every search method of
:func:`~impactid.rigs.pivoted.damping.fit_contact_damping` minimises, and over what.

The objective is the mean residual over the pooled events of one or several event sets
(:mod:`impactid.rigs.pivoted.residuals`), as a function of the search coordinates ``(log10 c, n)``
with ``c = beta delta_ref^n`` [N s/m], the damping coefficient at the reference indentation
``delta_ref`` [m] (the median measured peak indentation). Its per-event residuals (and their
Jacobian, from the simulator's forward sensitivities) are what the least-squares method works on.

:class:`DampingProblem` holds a validated fit's inputs: the event sets, the residual, the search box,
and the levels and settings its intervals use.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from impactid.rigs.pivoted.estimate_results import Landscape
from impactid.rigs.pivoted.residuals import EventSet, residual_name

__all__ = ["C_BOUNDS", "N_BOUNDS", "SCAN_EVENTS", "DampingObjective", "DampingProblem", "objective_landscape",
           "reference_indentation"]

#: Default search bounds: damping at the reference indentation ``c`` [N s/m] and exponent ``n``.
C_BOUNDS = (1.0, 1.0e6)
N_BOUNDS = (0.5, 2.5)
#: Most events the least-squares search's start scan simulates (:meth:`DampingObjective.scan_cost`): the scan
#: only picks the starting points, and its 41 points over six decades of ``c`` cost four fifths of a 60 s
#: recording's fit when every one of its 959 impacts is simulated at each.
SCAN_EVENTS = 128


class DampingObjective:
    """Mean residual over the pooled events of several event sets, in ``(log10 c, n)``.

    Parameters
    ----------
    sets : event sets of one or several recordings (pooled).
    residual : the residual's name (``"lambda1"``, ``"lambda2"``, ``"lambda3"``).
    delta_ref : reference indentation [m]; ``beta = c / delta_ref^n``.

    Attributes
    ----------
    n_simulations : S1 runs made so far (trial law x event).
    n_failed : S1 runs that could not be simulated (penalised, see :mod:`~impactid.rigs.pivoted.residuals`).
    n_events : events pooled over the sets.
    """

    def __init__(self, sets: Sequence[EventSet], residual: str, delta_ref: float):
        self.sets = list(sets)
        self.residual = residual
        self.delta_ref = delta_ref
        self.n_simulations = 0
        self.n_failed = 0
        self.n_events = sum(len(s) for s in self.sets)

    def beta(self, logc, n):
        """``beta = 10^logc / delta_ref^n`` [N s m^-(n+1)] (arrays broadcast)."""
        return np.power(10.0, logc) / np.power(self.delta_ref, n)

    def per_event(self, logc, n) -> np.ndarray:
        """Per-event residuals, shape ``(m, n_events)``, for ``m`` points ``(log10 c, n)`` (arrays broadcast)."""
        logc, n = np.broadcast_arrays(np.atleast_1d(np.asarray(logc, dtype=float)),
                                      np.atleast_1d(np.asarray(n, dtype=float)))
        trials = np.column_stack([self.beta(logc, n), n])
        self.n_simulations += trials.shape[0] * self.n_events
        parts = [s.residuals_and_failures(trials, self.residual) for s in self.sets]
        self.n_failed += int(sum(int(f.sum()) for _, f in parts))
        return np.concatenate([r for r, _ in parts], axis=1)

    def per_event_and_jacobian(self, logc, n) -> tuple[np.ndarray, np.ndarray]:
        """Per-event residuals ``(k, n_events)`` and their derivatives ``(k, n_events, 2)`` by
        ``(log10 c, n)``, from the simulator's forward sensitivities (one run per trial and event).

        The kernel differentiates by ``(ln beta, n)`` with ``beta`` held; with
        ``ln beta = ln(10) log10 c - n ln(delta_ref)``::

            dr/dlog10 c = ln(10) dr/dln beta,    dr/dn (c held) = dr/dn (beta held) - ln(delta_ref) dr/dln beta
        """
        logc, n = np.broadcast_arrays(np.atleast_1d(np.asarray(logc, dtype=float)),
                                      np.atleast_1d(np.asarray(n, dtype=float)))
        trials = np.column_stack([self.beta(logc, n), n])
        self.n_simulations += trials.shape[0] * self.n_events
        parts = [s.residuals_and_jacobian(trials, self.residual) for s in self.sets]
        self.n_failed += int(sum(int(f.sum()) for _, _, f in parts))
        r = np.concatenate([p[0] for p in parts], axis=1)
        by_law = np.concatenate([p[1] for p in parts], axis=1)
        jac = np.empty_like(by_law)
        jac[..., 0] = math.log(10.0) * by_law[..., 0]
        jac[..., 1] = by_law[..., 1] - math.log(self.delta_ref) * by_law[..., 0]
        return r, jac

    def scan_part(self, limit: int | None = None) -> DampingObjective | None:
        """The objective over a representative part of at most ``limit`` events (default
        :data:`SCAN_EVENTS`; every set's events at an even stride, each set keeping its first), or None when
        all events are within ``limit``."""
        limit = SCAN_EVENTS if limit is None else int(limit)
        if self.n_events <= limit:
            return None
        stride = math.ceil(self.n_events / limit)
        sets = [s.subset(slice(None, None, stride)) for s in self.sets if len(s)]
        return DampingObjective(sets, self.residual, self.delta_ref)

    def scan_cost(self, logc, n) -> np.ndarray:
        """The sum of squares of the per-event residuals at ``m`` points (over the events with a residual at
        every point), shape ``(m,)``; the simulations count in this objective."""
        values = self.per_event(logc, n)
        used = np.all(np.isfinite(values), axis=0)
        return np.sum(values[:, used] ** 2, axis=1) if used.any() else np.full(values.shape[0], np.inf)

    @staticmethod
    def mean(per_event: np.ndarray) -> np.ndarray:
        """Mean absolute residual over events (the last axis); ``inf`` where no event has one."""
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            out = np.nanmean(np.abs(per_event), axis=-1)
        return np.where(np.isfinite(out), out, np.inf)

    def __call__(self, logc: float, n: float) -> float:
        """The mean residual at one point ``(log10 c, n)``."""
        return float(self.mean(self.per_event(logc, n))[0])


@dataclass(frozen=True)
class DampingProblem:
    """A validated contact-damping fit: its events, residual, search box and interval settings.

    Attributes
    ----------
    sets : the event sets (pooled: a joint fit over operating points).
    residual : the residual's canonical name (``"lambda1"``, ...).
    fix_n : the fixed exponent, or None when ``n`` is estimated.
    log10_c_bounds : search bounds of ``log10 c``, ``c`` [N s/m].
    n_bounds : search bounds of ``n`` (used when ``n`` is estimated).
    delta_ref : reference indentation [m] (:func:`reference_indentation`).
    residual_floor : the residual's noise floor; the intervals' indifference level is at least this.
    systematic : a known systematic uncertainty of the residual; likewise a lower limit of that level.
    separability_width : widest interval of ``n`` with which ``beta, n`` count as separable.
    bootstrap_resamples, bootstrap_seed : resamples of the events and the seed of the bootstrap.
    landscape : whether the result carries the 41 x 41 objective landscape over the default bounds.
    """

    sets: tuple[EventSet, ...]
    residual: str
    fix_n: float | None
    log10_c_bounds: tuple[float, float]
    n_bounds: tuple[float, float]
    delta_ref: float
    residual_floor: float
    systematic: float
    separability_width: float
    bootstrap_resamples: int
    bootstrap_seed: int
    landscape: bool

    @property
    def indifference(self) -> float:
        """The residual's error per event below which fits count as equally good: the larger of
        :attr:`residual_floor` and :attr:`systematic` [residual units]."""
        return max(self.residual_floor, self.systematic)

    def objective(self, sets: Sequence[EventSet] | None = None) -> DampingObjective:
        """A fresh objective (simulation counters at zero) over ``sets`` (default: the problem's own)."""
        return DampingObjective(self.sets if sets is None else sets, self.residual, self.delta_ref)

    def landscape_if_asked(self) -> Landscape | None:
        """The objective landscape when :attr:`landscape` asks for it, else None."""
        return objective_landscape(self.sets, self.residual, delta_ref=self.delta_ref) if self.landscape else None


def reference_indentation(sets: Sequence[EventSet]) -> float:
    """Median measured peak indentation over all events [m] (1e-5 m if none is positive)."""
    values = np.concatenate([s.peak_indentation for s in sets]) if sets else np.empty(0)
    values = values[np.isfinite(values) & (values > 0)]
    return float(np.median(values)) if values.size else 1e-5


def objective_landscape(sets: Sequence[EventSet], residual: str = "lambda1", *, n_values=None, c_values=None,
                        delta_ref: float | None = None) -> Landscape:
    """Mean residual over a (n, c) grid (one batch simulation). Defaults: 41 x 41 over the default bounds.

    Parameters
    ----------
    sets : event sets (pooled).
    residual : the residual's name.
    n_values : exponents of the grid (default 41 over :data:`N_BOUNDS`).
    c_values : damping at the reference indentation [N s/m] (default 41 log-spaced over :data:`C_BOUNDS`).
    delta_ref : reference indentation [m] (default :func:`reference_indentation` of ``sets``).
    """
    residual = residual_name(residual)
    delta_ref = reference_indentation(sets) if delta_ref is None else float(delta_ref)
    obj = DampingObjective(sets, residual, delta_ref)
    n_values = np.linspace(*N_BOUNDS, 41) if n_values is None else np.atleast_1d(np.asarray(n_values, float))
    logc = np.log10(np.geomspace(*C_BOUNDS, 41) if c_values is None else np.asarray(c_values, float))
    nn, cc = np.meshgrid(n_values, logc, indexing="ij")
    values = obj.mean(obj.per_event(cc.ravel(), nn.ravel())).reshape(nn.shape)
    return Landscape(n=n_values, log10_c=logc, beta=obj.beta(cc, nn), objective=values, residual=residual)

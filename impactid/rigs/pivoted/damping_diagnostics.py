"""What both search methods of the contact-damping fit report alike: identifiability, notes, tables.

* :func:`approach_speed_spread`: how much the impacts' approach speeds differ;
* :func:`separability`: whether the data separate ``beta`` from ``n`` (the ``n`` interval no wider than
  the separability width and off the search bounds), with the note that says why not;
* :func:`bound_notes`: an estimate on a search bound;
* :func:`failure_note`: S1 runs with trial laws that could not be simulated;
* :func:`per_event_table`: the per-event residuals at the estimate;
* :func:`widen_interval`: an interval widened by an independent error, in quadrature.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from impactid.rigs.pivoted.damping_objective import DampingObjective, DampingProblem
from impactid.rigs.pivoted.residuals import FAILED_SIMULATION_RESIDUAL

__all__ = ["ALIKE_SPREAD", "SEPARABILITY_WIDTH", "approach_speed_spread", "bound_notes", "failure_note",
           "per_event_table", "separability", "widen_interval"]

#: Widest ``n`` interval for which ``beta`` and ``n`` count as separable.
SEPARABILITY_WIDTH = 0.25
#: Relative spread (std/mean) of approach speeds below which impacts count as "all alike".
ALIKE_SPREAD = 0.02


def approach_speed_spread(problem: DampingProblem) -> float:
    """Relative spread (std/mean) of the finite approach speeds over all events (0 with fewer than two)."""
    va = np.concatenate([s.approach_speed for s in problem.sets])
    va = va[np.isfinite(va)]
    return float(np.std(va) / np.mean(va)) if va.size > 1 and np.mean(va) > 0 else 0.0


def separability(problem: DampingProblem, n_interval: tuple[float, float], beta_interval: tuple[float, float],
                 region: str, notes: list[str]) -> bool | None:
    """Whether ``beta, n`` are separable (None with ``n`` fixed); a note says why not.

    Parameters
    ----------
    problem : the fit.
    n_interval : the interval of ``n``; beta_interval : that of ``beta`` [N s m^-(n+1)].
    region : what the ``n`` interval is, for the note (the indifference region, the profile interval).
    notes : the fit's notes, appended to.
    """
    if problem.fix_n is not None:
        return None
    n_lo, n_hi = problem.n_bounds
    touches = n_interval[0] <= n_lo + 1e-9 or n_interval[1] >= n_hi - 1e-9
    separable = bool((n_interval[1] - n_interval[0]) <= problem.separability_width and not touches)
    if not separable:
        spread = approach_speed_spread(problem)
        why = (f"all impacts have nearly the same approach speed (spread {100 * spread:.2g} %)"
               if spread < ALIKE_SPREAD else f"the approach speeds spread only {100 * spread:.2g} %")
        notes.append(
            f"beta and n are not separable from these data ({why}): along the valley beta(n) {region} "
            f"for n from {n_interval[0]:.3g} to {n_interval[1]:.3g} "
            f"(beta {beta_interval[0]:.4g} to {beta_interval[1]:.4g}); the joint point estimate is not precise. Fix n "
            + ("(--fix-n) or fit recordings at several operating points together." if len(problem.sets) == 1 else
               "(--fix-n), add operating points whose approach speeds differ more (lower e/r_c or cam speed), "
               "or record with less noise."))
    return separable


def bound_notes(problem: DampingProblem, logc_hat: float, n_hat: float, notes: list[str]) -> None:
    """Notes on an estimate ``(log10 c, n)`` that lies on a search bound."""
    (lc_lo, lc_hi), (n_lo, n_hi) = problem.log10_c_bounds, problem.n_bounds
    if logc_hat <= lc_lo + 1e-6 or logc_hat >= lc_hi - 1e-6:
        notes.append(f"the estimate lies on the search bound of c = beta delta_ref^n ({10 ** logc_hat:.3g} N s/m): "
                     "widen the bounds or check the data")
    if problem.fix_n is None and (n_hat <= n_lo + 1e-6 or n_hat >= n_hi - 1e-6):
        notes.append(f"the estimate of n lies on its search bound ({n_hat:.3g})")


def failure_note(obj: DampingObjective, notes: list[str]) -> None:
    """Say how many S1 runs with trial laws could not be simulated (penalised, not fatal)."""
    if obj.n_failed:
        notes.append(f"{obj.n_failed} of {obj.n_simulations} S1 runs with trial laws could not be simulated "
                     f"(step budget or step-size underflow); each counted as a residual of "
                     f"{FAILED_SIMULATION_RESIDUAL:g} for its event, so the search avoided those laws")


def per_event_table(problem: DampingProblem, residuals: np.ndarray) -> pd.DataFrame:
    """The table ``source, event, approach_speed`` [m/s] ``, residual`` of the pooled events."""
    sets = problem.sets
    return pd.DataFrame({"source": np.concatenate([[s.source] * len(s) for s in sets]),
                         "event": np.concatenate([s.events for s in sets]),
                         "approach_speed": np.concatenate([s.approach_speed for s in sets]),
                         "residual": residuals})


def widen_interval(interval: tuple[float, float], centre: float, extra: float) -> tuple[float, float]:
    """Widen ``(lo, hi)`` about ``centre`` by ``extra`` in quadrature on each side."""
    lo, hi = interval
    return (centre - math.hypot(centre - lo, extra), centre + math.hypot(hi - centre, extra))

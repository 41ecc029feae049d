"""Rig P's estimates under one name: a module that only re-exports (issue 25, "functions that do one job").

The estimates are three subjects, each in its own module of :mod:`impactid.rigs.pivoted`:

* the **contact damping** ``beta, n`` (Sundar, Dreyer & Singh 2016, sections 5.2, 6-7):
  :mod:`~impactid.rigs.pivoted.damping` (:func:`fit_contact_damping`, the method's description),
  on :mod:`~impactid.rigs.pivoted.damping_objective` (the objective, the search box,
  :func:`objective_landscape`), :mod:`~impactid.rigs.pivoted.damping_least_squares` (the
  ``"least-squares"`` method), :mod:`~impactid.rigs.pivoted.damping_search` (``"optimise"`` and
  ``"grid"``) and :mod:`~impactid.rigs.pivoted.damping_diagnostics` (identifiability and notes);
* the **restitution** law ``xi = 1 - gamma v_a`` (section 8): :mod:`~impactid.rigs.pivoted.restitution`
  (:func:`fit_restitution`);
* the **result types**, with the whole job's :class:`Estimate`: :mod:`~impactid.rigs.pivoted.estimate_results`.

Every name this module held before the split is importable from it still (other code, the tests and
the benchmarks import from here); new code may import from the subject modules directly.
``_Objective`` is :class:`~impactid.rigs.pivoted.damping_objective.DampingObjective` under its old name.
"""

from __future__ import annotations

from impactid.rigs.pivoted.damping import (
    BOOTSTRAP_RESAMPLES,
    BOOTSTRAP_SEED,
    CALIBRATION_THRESHOLD,
    JACOBIANS,
    METHODS,
    RESIDUAL_FLOOR,
    fit_contact_damping,
)
from impactid.rigs.pivoted.damping_diagnostics import ALIKE_SPREAD, SEPARABILITY_WIDTH
from impactid.rigs.pivoted.damping_objective import (
    C_BOUNDS,
    N_BOUNDS,
    DampingObjective,
    objective_landscape,
    reference_indentation,
)
from impactid.rigs.pivoted.estimate_results import (
    ContactDampingResult,
    DampingEstimate,
    Estimate,
    EstimationWarning,
    Landscape,
    Progress,
    RestitutionEstimate,
    RestitutionResult,
)
from impactid.rigs.pivoted.restitution import fit_restitution

__all__ = ["ALIKE_SPREAD", "BOOTSTRAP_RESAMPLES", "BOOTSTRAP_SEED", "CALIBRATION_THRESHOLD", "C_BOUNDS", "JACOBIANS",
           "METHODS", "N_BOUNDS", "RESIDUAL_FLOOR", "SEPARABILITY_WIDTH", "ContactDampingResult", "DampingEstimate",
           "Estimate", "EstimationWarning", "Landscape", "Progress", "RestitutionEstimate", "RestitutionResult",
           "fit_contact_damping", "fit_restitution", "objective_landscape", "reference_indentation"]

#: The objective under its name before the split (``benchmarks/envelope_case.py``, ``tests/test_engine_valley.py``).
_Objective = DampingObjective

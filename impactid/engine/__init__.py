"""The identification engine every rig's fit uses: the search, the uncertainty and the model check.

A rig gives the engine its residual (and, where its kernel integrates sensitivities, the Jacobian)
as functions of the searched parameters, described like lmfit's parameters (:class:`Free`: name,
value, min, max, vary). The engine then

1. **searches** (:func:`search`): scipy's trust-region reflective least squares within the bounds,
   with the analytic Jacobian or finite differences, from one or several starts (the best cost
   wins; every start is recorded);
2. **states the uncertainty** (:func:`uncertainty`): the covariance from the Jacobian at the optimum
   by the shared rule of :func:`impactid.engine.covariance.covariance_from_jacobian` (undetermined
   directions are reported, never inverted), scaled by the reduced chi-square (lmfit's
   ``scale_covar``) or by a known noise, Student-t intervals mapped back through a logarithmic
   coordinate where a parameter is searched in one, bound hits, and the correlation matrix;
3. **checks the model** (:func:`check_model`, a :class:`ModelCheck`): the residual against the noise
   reference of the data kind (:func:`residual_against_noise`), a chi-square lack-of-fit test, and
   the residual's structure across events (a trend with the rig's per-event covariate, alternation
   or persistence between consecutive residuals); when the model does not describe the data the
   result says so, and the intervals are widened or withheld (:meth:`ModelCheck.widen`);
4. **describes the identifiability** (:func:`identifiability`): the condition number, the correlation
   matrix, the parameters on or near a bound, the shape of each parameter's profile, and where a fit
   offers a choice between laws, AIC, BIC and the likelihood-ratio test (:func:`compare_models`).

The rig keeps what is its own: its residual, the noise it measures, its tables and its result
type (a :class:`~impactid.results.FitResult` built from :attr:`Uncertainty.parameters`).

The modules: :mod:`~impactid.engine.least_squares` (the search), :mod:`~impactid.engine.intervals`
(covariance, intervals, the linearised bootstrap), :mod:`~impactid.engine.covariance` (the one rule
for an undetermined standard error), :mod:`~impactid.engine.checks` (the model check),
:mod:`~impactid.engine.identifiability` (the identifiability block) and
:mod:`~impactid.engine.valley` (the trust-region Gauss–Newton search along a ``(log10 c, n)`` valley
with its profile, for contact laws ``beta delta^n``, used by rig P's contact-damping fit).
"""

from __future__ import annotations

from impactid.engine.checks import (
    GROSS_LACK_OF_FIT,
    LACK_OF_FIT_FACTOR,
    NO_NOISE_REFERENCE,
    SIGNIFICANT_EXCESS_FLOOR,
    SIGNIFICANT_EXCESS_SIGMAS,
    STRUCTURE_SIGNIFICANCE,
    ModelCheck,
    check_model,
    combine_checks,
    governing_check,
    residual_against_noise,
)
from impactid.engine.covariance import CONDITION_LIMIT, Covariance, covariance_from_jacobian
from impactid.engine.identifiability import (
    PROFILE_THRESHOLD,
    compare_models,
    identifiability,
    profile_interval,
    profile_shape,
)
from impactid.engine.intervals import BOUND_TOLERANCE, Uncertainty, linearised_bootstrap, uncertainty
from impactid.engine.least_squares import Free, Search, search

__all__ = ["BOUND_TOLERANCE", "CONDITION_LIMIT", "GROSS_LACK_OF_FIT", "LACK_OF_FIT_FACTOR", "NO_NOISE_REFERENCE",
           "PROFILE_THRESHOLD", "SIGNIFICANT_EXCESS_FLOOR", "SIGNIFICANT_EXCESS_SIGMAS", "STRUCTURE_SIGNIFICANCE",
           "Covariance", "Free", "ModelCheck", "Search", "Uncertainty", "check_model", "combine_checks",
           "compare_models", "covariance_from_jacobian", "governing_check", "identifiability", "linearised_bootstrap",
           "profile_interval", "profile_shape", "residual_against_noise", "search", "uncertainty"]

"""The engine's model check: whether a model describes the data, from its residual against the
recording's own noise (:func:`residual_against_noise`)."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["LACK_OF_FIT_FACTOR", "SIGNIFICANT_EXCESS_FLOOR", "SIGNIFICANT_EXCESS_SIGMAS", "residual_against_noise"]

#: A residual RMS more than this many times the noise's is a lack of fit [-].
LACK_OF_FIT_FACTOR = 1.5
#: Sigmas of the chi-square spread by which the residual's mean square may exceed the noise's before
#: the excess is reported as systematic.
SIGNIFICANT_EXCESS_SIGMAS = 3.0
#: Smallest reported excess of the residual's mean square over the noise's [-].
SIGNIFICANT_EXCESS_FLOOR = 0.02


def residual_against_noise(residual: np.ndarray, noise_sd: float | np.ndarray, *, what: str,
                           unit: str = "") -> tuple[dict[str, float], tuple[str, ...]]:
    """Whether a model describes the data: its residual against the recording's own noise.

    Parameters
    ----------
    residual : measured minus model [unit].
    noise_sd : the noise standard deviation the recording shows where the model has nothing to
        explain (between impacts, before a trigger, ...) [unit]; one value or one per sample.
    what : what the residual is of (a channel's name), for the notes.
    unit : its unit, for the notes.

    Returns
    -------
    statistics : ``residual_rms`` [unit], ``noise_sd`` [unit] (the median), and
        ``residual_over_noise`` (RMS of the residual in units of the noise).
    notes : a lack of fit (the ratio above :data:`LACK_OF_FIT_FACTOR`), or a significant systematic
        excess (the mean square above ``1 + max(3 sqrt(2 / N), 0.02)`` times the noise's, the
        chi-square spread of N samples).
    """
    residual = np.asarray(residual, dtype=float)
    noise = np.broadcast_to(np.asarray(noise_sd, dtype=float), residual.shape)
    rms = float(np.sqrt(np.mean(residual**2)))
    ratio = float(np.sqrt(np.mean((residual / noise) ** 2)))
    statistics = {"residual_rms": rms, "noise_sd": float(np.median(noise)), "residual_over_noise": ratio}
    excess = max(SIGNIFICANT_EXCESS_SIGMAS * math.sqrt(2.0 / max(residual.size, 1)), SIGNIFICANT_EXCESS_FLOOR)
    unit_text = f" {unit}" if unit else ""
    if ratio > LACK_OF_FIT_FACTOR:
        return statistics, (f"lack of fit: the residual RMS of {what!r} ({rms:.4g}{unit_text}) is {ratio:.3g} times "
                            f"its noise (more than {LACK_OF_FIT_FACTOR:g}): the model does not describe everything "
                            "in the data; the intervals assume the model",)
    if ratio**2 > 1.0 + excess:
        return statistics, (f"the residual of {what!r} exceeds its noise significantly (mean square {ratio**2:.3g} "
                            f"times the noise's, more than 1 + {excess:.2g} for {residual.size} samples): a "
                            "systematic misfit below the noise level",)
    return statistics, ()

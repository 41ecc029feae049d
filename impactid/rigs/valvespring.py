"""The two-mass valve-spring surge model shared by the valve-train rigs.

A helical valve spring of static rate ``K0`` [N/m] whose first surge (standing-wave) frequency with
both ends clamped is ``f0`` [Hz] is replaced by two equal masses joined by three springs (end, middle,
end), chosen so that the model has the spring's static rate, its first natural frequency ``f0``
and, as a clamped-clamped continuous spring does, its second at ``2 f0`` (Kim, Jeon & Park 1990;
the same model in Kushwaha, Rahnejat & Jin 2000):

    m1 = m2 = (2/3) K0 / (pi f0)^2,    K_s1 = K_s3 = (8/3) K0,    K_s2 = 4 K0

Check: the three springs in series give ``1 / (3/8 + 1/4 + 3/8) K0 = K0``; the in-phase mode (middle
spring unstretched) has ``omega^2 = K_s1 / m = (2 pi f0)^2``, the anti-phase mode
``(K_s1 + 2 K_s2) / m = (4 pi f0)^2``.

Damping, the two papers' conventions:

* stiffness-proportional (Kim et al.: "4 % proportional viscous damping"): ``C_si = a K_si`` with
  ``a = 2 zeta / (2 pi f0)``, giving the damping ratio ``zeta`` in the first mode and ``2 zeta`` in
  the second;
* one damper ``c`` on all three elements (Kushwaha et al.).

Sign convention: the valve (or retainer) end moves by ``y_v``, the masses by ``y_1`` (next to the
valve) and ``y_2`` (next to the head), all positive in the valve-opening direction; the head end
is fixed. The functions are plain arithmetic, so rig kernels compile them with numba.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["SurgeModel", "surge_accelerations", "surge_model"]


@dataclass(frozen=True)
class SurgeModel:
    """Two-mass surge model of a valve spring (SI units).

    Attributes
    ----------
    mass : each of the two equal masses ``m1 = m2`` [kg].
    k_end, k_middle : end springs ``K_s1 = K_s3`` and middle spring ``K_s2`` [N/m].
    c_end, c_middle : their dampers [N s/m].
    """

    mass: float
    k_end: float
    k_middle: float
    c_end: float
    c_middle: float

    def matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Mass, damping and stiffness matrices of the two masses with both ends clamped."""
        m, k1, k2, c1, c2 = self.mass, self.k_end, self.k_middle, self.c_end, self.c_middle
        mass = np.diag([m, m])
        stiffness = np.array([[k1 + k2, -k2], [-k2, k2 + k1]])
        damping = np.array([[c1 + c2, -c2], [-c2, c2 + c1]])
        return mass, damping, stiffness

    def natural_frequencies(self) -> np.ndarray:
        """Undamped natural frequencies [Hz] with both ends clamped (ascending)."""
        mass, _, stiffness = self.matrices()
        return np.sqrt(np.sort(np.linalg.eigvals(np.linalg.solve(mass, stiffness)).real)) / (2.0 * math.pi)

    def damping_ratios(self) -> np.ndarray:
        """Modal damping ratios of the two modes (the damping is proportional, so the modes decouple)."""
        mass, damping, stiffness = self.matrices()
        values, vectors = np.linalg.eig(np.linalg.solve(mass, stiffness))
        order = np.argsort(values.real)
        out = []
        for k in order:
            v = vectors[:, k].real
            m_k, c_k, k_k = v @ mass @ v, v @ damping @ v, v @ stiffness @ v
            out.append(c_k / (2.0 * math.sqrt(k_k * m_k)))
        return np.array(out)

    @property
    def static_rate(self) -> float:
        """Rate of the three springs in series [N/m] (equals ``K0``)."""
        return 1.0 / (2.0 / self.k_end + 1.0 / self.k_middle)


def surge_model(K0: float, f0: float, *, damping_ratio: float | None = None,
                damper: float | None = None) -> SurgeModel:
    """The two-mass model of a spring of rate ``K0`` [N/m] and first surge frequency ``f0`` [Hz].

    Give exactly one of ``damping_ratio`` (stiffness-proportional damping with that ratio in the
    first mode, Kim et al.) or ``damper`` [N s/m] (one damper on all three elements, Kushwaha et al.).
    """
    if not (math.isfinite(K0) and K0 > 0.0 and math.isfinite(f0) and f0 > 0.0):
        raise ValueError(f"K0 and f0 must be positive and finite, got {K0!r}, {f0!r}")
    if (damping_ratio is None) == (damper is None):
        raise ValueError("give exactly one of damping_ratio and damper")
    mass = (2.0 / 3.0) * K0 / (math.pi * f0) ** 2
    k_end, k_middle = (8.0 / 3.0) * K0, 4.0 * K0
    if damping_ratio is not None:
        if not (math.isfinite(damping_ratio) and damping_ratio >= 0.0):
            raise ValueError(f"damping_ratio must be >= 0, got {damping_ratio!r}")
        a = 2.0 * damping_ratio / (2.0 * math.pi * f0)
        return SurgeModel(mass, k_end, k_middle, a * k_end, a * k_middle)
    if not (math.isfinite(damper) and damper >= 0.0):
        raise ValueError(f"damper must be >= 0, got {damper!r}")
    return SurgeModel(mass, k_end, k_middle, float(damper), float(damper))


def surge_accelerations(y_v, v_v, y_1, v_1, y_2, v_2, mass, k_end, k_middle, c_end, c_middle):
    """Accelerations of the two spring masses and the spring force on the valve end.

    Returns ``(a_1, a_2, force_on_valve)``: ``m a_1 = K_s1 (y_v - y_1) + C_s1 (v_v - v_1) - K_s2 (y_1 - y_2)
    - C_s2 (v_1 - v_2)``, ``m a_2 = K_s2 (y_1 - y_2) + C_s2 (v_1 - v_2) - K_s3 y_2 - C_s3 v_2``, and the force
    of the first spring on the valve end, ``-(K_s1 (y_v - y_1) + C_s1 (v_v - v_1))`` [N] (it resists opening;
    the static preload is added by the rig). Plain arithmetic, compiled by the rigs' kernels.
    """
    end = k_end * (y_v - y_1) + c_end * (v_v - v_1)
    middle = k_middle * (y_1 - y_2) + c_middle * (v_1 - v_2)
    head = k_end * y_2 + c_end * v_2
    return (end - middle) / mass, (middle - head) / mass, -end

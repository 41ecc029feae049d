"""Parameters of the finger-follower valve train with a hydraulic lash adjuster (Kim, Jeon & Park 1990).

:class:`FingerFollowerRig` is a frozen dataclass of flat floats in SI units (one attribute per
parameter, the names of the rig file); the derived quantities of the paper (the tappet's limiting
stiffness and damping, the surge model, the static preloads, the seat lift-off threshold) are
properties computed from them, so that a rig file cannot hold an inconsistent copy.

The paper's tables are the preset :data:`KIM1990` (with the repairs and assumptions of the
project's reading of the paper, see ``docs/finger_follower.md``); :data:`KIM1990_TABLE2`
replaces the tappet's limiting stiffness by Table 2's printed ``K_tp = 6.648e7 N/m``.

Pure functions (:func:`tappet_limits`, :func:`contact_damping`, :func:`equivalent_mass`,
:func:`static_preloads`, :func:`tappet_weights`) hold the formulas; the class only organises calls.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

from impactid.errors import RigParameterError
from impactid.rigs._params import RigParameters
from impactid.rigs.valvespring import SurgeModel, surge_model

__all__ = ["KIM1990", "KIM1990_TABLE2", "MODEL_NAME", "PARAMETER_UNITS", "FingerFollowerRig", "contact_damping",
           "equivalent_mass", "static_preloads", "tappet_limits", "tappet_weights"]

MODEL_NAME = "finger-follower-hla"
RPM = 2.0 * math.pi / 60.0  # rad/s per rpm


# --------------------------------------------------------------------------------------------
# Pure formulas of the paper
# --------------------------------------------------------------------------------------------


def tappet_limits(A_e, E_oil, H_e, mu_oil, L_p, R_p, h_clear):
    """Limiting stiffness and damping of the hydraulic tappet (K-4, K-5).

    Parameters
    ----------
    A_e : equivalent chamber area [m^2].
    E_oil : oil bulk modulus [Pa].
    H_e : length of the compressed oil column [m].
    mu_oil : oil viscosity [Pa s].
    L_p, R_p, h_clear : plunger length, plunger radius and radial clearance [m].

    Returns
    -------
    (K_e, C_d_plus, C_d_minus) : ``K_e = A_e E / H_e`` [N/m] (oil compressible, no leakage); the
    damping with the check valve closed, ``Y_t' > 0`` (Poiseuille leakage through the annulus
    plus shear of the film) and open, ``Y_t' < 0`` (shear only) [N s/m].
    """
    K_e = A_e * E_oil / H_e
    poiseuille = 6.0 * mu_oil * math.pi * L_p * R_p**2 * (R_p + h_clear) / h_clear**3
    shear_plus = 2.0 * mu_oil * math.pi * R_p * L_p * (3.0 * R_p + 4.0 * h_clear) / h_clear**2
    C_d_minus = 2.0 * mu_oil * math.pi * L_p * R_p / h_clear
    return K_e, poiseuille + shear_plus, C_d_minus


def equivalent_mass(l, M_f, I_f):
    """Equivalent mass of the follower at distance ``l`` [m] from its centre of gravity (K-2) [kg]:
    ``M_f / (1 + M_f l^2 / I_f)``."""
    return M_f / (1.0 + M_f * l * l / I_f)


def contact_damping(K, M1, M2=math.inf, zeta=0.06):
    """Contact damping ``zeta C_cr`` with ``C_cr = 2 sqrt(K M1 M2 / (M1 + M2))`` (K-1) [N s/m].

    ``M2 = inf`` is a rigid camshaft (``C_cr = 2 sqrt(K M1)``). Kim et al.'s Table 2 values follow
    from ``zeta = 0.06`` with ``M1 = M_t, M2 = M_e(L_tf)`` (C_tf) and ``M1 = M_v + m1 + m2,
    M2 = M_e(L_vf)`` (C_vf); C_fc corresponds to a lever arm of 12.72 mm. Use this rule when you
    change a mass or a stiffness.
    """
    reduced = M1 if math.isinf(M2) else M1 * M2 / (M1 + M2)
    return zeta * 2.0 * math.sqrt(K * reduced)


def static_preloads(F_tf0, RR0):
    """Static contact forces on the base circle (K-11): ``(F_vf0, F_fc0)`` [N] from the HLA force
    ``F_tf0`` [N] and the base-circle rocker ratio ``RR0``: ``F_vf0 = F_tf0 / (RR0 - 1)``,
    ``F_fc0 = F_tf0 + F_vf0`` (force and moment balance of the follower)."""
    F_vf0 = F_tf0 / (RR0 - 1.0)
    return F_vf0, F_tf0 + F_vf0


def tappet_weights(speed_hz, alpha_1, beta_1, speed_1_hz, alpha_2, beta_2, speed_2_hz):
    """Tappet drag weights ``(alpha, beta)`` of (K-6) at a camshaft speed [Hz] (decision K-D7).

    Linear in the speed between the two identified points ``(speed_1_hz, alpha_1, beta_1)`` and
    ``(speed_2_hz, alpha_2, beta_2)``, held constant outside them.
    """
    if speed_hz <= speed_1_hz:
        return alpha_1, beta_1
    if speed_hz >= speed_2_hz:
        return alpha_2, beta_2
    w = (speed_hz - speed_1_hz) / (speed_2_hz - speed_1_hz)
    return alpha_1 + w * (alpha_2 - alpha_1), beta_1 + w * (beta_2 - beta_1)


# --------------------------------------------------------------------------------------------
# The parameter dataclass
# --------------------------------------------------------------------------------------------

#: SI unit of every rig-file parameter.
PARAMETER_UNITS = {
    "M_t": "kg", "M_f": "kg", "I_f": "kg m^2", "M_v": "kg",
    "K0": "N/m", "f0": "Hz", "F_o": "N", "zeta_spring": "",
    "K_tf": "N/m", "K_fc": "N/m", "K_vf": "N/m", "K_se": "N/m",
    "C_tf": "N s/m", "C_fc": "N s/m", "C_vf": "N s/m", "C_se": "N s/m",
    "K_s": "N/m", "A_e": "m^2", "H_e": "m", "E_oil": "Pa", "mu_oil": "Pa s", "R_p": "m", "h_clear": "m",
    "L_p": "m", "alpha_1": "", "beta_1": "", "speed_1_hz": "Hz", "alpha_2": "", "beta_2": "", "speed_2_hz": "Hz",
    "F_tf0": "N",
    "R_ab": "m", "R_1": "m", "R_c": "m", "R_f": "m", "L_tf": "m", "L_vf": "m", "RR0": "", "cam_sense": "",
    "S_K": "m", "beta_K": "rad",
}

_POSITIVE = ("M_t", "M_f", "I_f", "M_v", "K0", "f0", "F_o", "K_tf", "K_fc", "K_vf", "K_se", "A_e", "H_e", "E_oil",
             "mu_oil", "R_p", "h_clear", "L_p", "alpha_1", "beta_1", "speed_1_hz", "alpha_2", "beta_2", "speed_2_hz",
             "F_tf0", "R_ab", "R_1", "R_c", "R_f", "L_tf", "L_vf", "beta_K")
_NONNEGATIVE = ("zeta_spring", "C_tf", "C_fc", "C_vf", "C_se", "K_s", "S_K")


@dataclass(frozen=True)
class FingerFollowerRig(RigParameters):
    """Parameters of the OHC finger-follower valve train with a hydraulic tappet (SI units).

    Attributes
    ----------
    M_t, M_f, M_v : equivalent tappet-plunger mass, follower mass, equivalent valve mass [kg].
    I_f : follower moment of inertia about its centre of gravity G [kg m^2].
    K0, f0, F_o : valve-spring rate [N/m], first surge frequency (both ends clamped) [Hz], preload [N].
    zeta_spring : damping ratio of the first surge mode (stiffness-proportional damping) [-].
    K_tf, K_fc, K_vf, K_se : stiffness of the tappet/follower, cam/follower and follower/valve
        contacts and of the valve seat [N/m].
    C_tf, C_fc, C_vf, C_se : their damping [N s/m].
    K_s : plunger-spring stiffness [N/m].
    A_e, H_e, E_oil, mu_oil, R_p, h_clear, L_p : tappet chamber area [m^2], oil-column length [m],
        oil bulk modulus [Pa], oil viscosity [Pa s], plunger radius, radial clearance and plunger
        length [m] (Table 1; they give ``K_e``, ``C_d+``, ``C_d-`` by K-4, K-5).
    alpha_1, beta_1, speed_1_hz, alpha_2, beta_2, speed_2_hz : the tappet drag weights of (K-6)
        identified at two camshaft speeds [-, -, Hz]; linear in speed between them, constant
        outside (decision K-D7). Give equal pairs for a speed-independent tappet.
    F_tf0 : static HLA force, the tappet/follower preload [N] (assumed, decision K-D6).
    R_ab, R_1, R_c, R_f : cam centre to pivot, pivot to pad centre, cam base radius, pad radius [m].
    L_tf, L_vf : centre of gravity G to the tappet contact and to the valve contact [m].
    RR0 : rocker ratio on the base circle [-].
    cam_sense : -1 when the cam turns clockwise in the pivot frame (x towards the valve, y up):
        the contact moves towards the pivot and the opening flank has the low rocker ratio
        (decision K-D5); +1 the other way.
    S_K, beta_K : total lift [m] and rise (= return) angle [rad] of the cycloidal flat-follower
        lift law (the reference cam, decision K-D4); a lift table replaces them when given.
    """

    model: ClassVar[str] = MODEL_NAME

    M_t: float
    M_f: float
    I_f: float
    M_v: float
    K0: float
    f0: float
    F_o: float
    zeta_spring: float
    K_tf: float
    K_fc: float
    K_vf: float
    K_se: float
    C_tf: float
    C_fc: float
    C_vf: float
    C_se: float
    K_s: float
    A_e: float
    H_e: float
    E_oil: float
    mu_oil: float
    R_p: float
    h_clear: float
    L_p: float
    alpha_1: float
    beta_1: float
    speed_1_hz: float
    alpha_2: float
    beta_2: float
    speed_2_hz: float
    F_tf0: float
    R_ab: float
    R_1: float
    R_c: float
    R_f: float
    L_tf: float
    L_vf: float
    RR0: float
    cam_sense: float
    S_K: float
    beta_K: float

    def __post_init__(self) -> None:
        self._check_numbers()
        for name in _POSITIVE:
            if getattr(self, name) <= 0.0:
                raise RigParameterError(f"rig parameter {name!r} must be positive, got {getattr(self, name)!r} "
                                        f"[{PARAMETER_UNITS[name]}]".replace(" []", ""))
        for name in _NONNEGATIVE:
            if getattr(self, name) < 0.0:
                raise RigParameterError(f"rig parameter {name!r} must be >= 0, got {getattr(self, name)!r}")
        if self.cam_sense not in (-1.0, 1.0):
            raise RigParameterError(f"rig parameter 'cam_sense' must be -1 or +1, got {self.cam_sense!r}")
        if not self.speed_1_hz < self.speed_2_hz:
            raise RigParameterError(f"rig parameters 'speed_1_hz' = {self.speed_1_hz!r} Hz must be below "
                                    f"'speed_2_hz' = {self.speed_2_hz!r} Hz")
        if self.h_clear >= self.R_p:
            raise RigParameterError(f"rig parameter 'h_clear' = {self.h_clear!r} m must be smaller than the plunger "
                                    f"radius R_p = {self.R_p!r} m")
        if not self.RR0 > 1.0:
            raise RigParameterError(f"rig parameter 'RR0' must exceed 1 (valve lift larger than the cam input), "
                                    f"got {self.RR0!r}")
        if self.beta_K > math.pi:
            raise RigParameterError(f"rig parameter 'beta_K' = {self.beta_K!r} rad: a rise of more than pi leaves "
                                    "no base circle")
        sides = (self.R_ab, self.R_1, self.R_c + self.R_f)
        if 2.0 * max(sides) >= sum(sides):
            raise RigParameterError(
                "rig parameters R_ab, R_1, R_c + R_f do not form a triangle (cam centre, pivot, pad centre): "
                f"{self.R_ab!r}, {self.R_1!r}, {self.R_c + self.R_f!r} m")
        if self.Y_v_star <= 0.0:
            raise RigParameterError(
                f"the valve-spring preload F_o = {self.F_o!r} N must exceed the follower/valve preload "
                f"F_vf0 = {self.F_vf0!r} N (else the valve is pushed off its seat at rest)")

    # ---- derived values ----------------------------------------------------------------------
    @property
    def tappet_limits(self) -> tuple[float, float, float]:
        """``(K_e, C_d+, C_d-)`` [N/m, N s/m, N s/m] from Table 1 (K-4, K-5)."""
        return tappet_limits(self.A_e, self.E_oil, self.H_e, self.mu_oil, self.L_p, self.R_p, self.h_clear)

    @property
    def K_e(self) -> float:
        """Limiting tappet stiffness ``A_e E / H_e`` [N/m] (K-4)."""
        return self.tappet_limits[0]

    @property
    def C_d_plus(self) -> float:
        """Limiting tappet damping while compressing (check valve closed) [N s/m] (K-5a)."""
        return self.tappet_limits[1]

    @property
    def C_d_minus(self) -> float:
        """Limiting tappet damping while refilling (check valve open) [N s/m] (K-5b)."""
        return self.tappet_limits[2]

    @property
    def surge(self) -> SurgeModel:
        """The two-mass valve-spring surge model (K-3) with stiffness-proportional damping."""
        return surge_model(self.K0, self.f0, damping_ratio=self.zeta_spring)

    @property
    def L_sum(self) -> float:
        """Follower length ``L_tf + L_vf`` [m] (decision K-D8)."""
        return self.L_tf + self.L_vf

    @property
    def d_c0(self) -> float:
        """Horizontal pivot-to-contact distance on the base circle ``L_sum / RR0`` [m]."""
        return self.L_sum / self.RR0

    @property
    def L_fc0(self) -> float:
        """Lever arm of the cam contact about G on the base circle [m]."""
        return self.d_c0 - self.L_tf

    @property
    def F_vf0(self) -> float:
        """Static follower/valve contact force [N] (K-11)."""
        return static_preloads(self.F_tf0, self.RR0)[0]

    @property
    def F_fc0(self) -> float:
        """Static cam/follower contact force [N] (K-11)."""
        return static_preloads(self.F_tf0, self.RR0)[1]

    @property
    def Y_v_star(self) -> float:
        """Valve lift-off threshold ``(F_o - F_vf0) / K_se`` [m] (coordinates from the static equilibrium)."""
        return (self.F_o - self.F_vf0) / self.K_se

    def tappet_weights(self, speed_hz: float) -> tuple[float, float]:
        """``(alpha, beta)`` at a camshaft speed [Hz] (linear between the two identified points)."""
        return tappet_weights(speed_hz, self.alpha_1, self.beta_1, self.speed_1_hz, self.alpha_2, self.beta_2,
                              self.speed_2_hz)

    def tappet_drag(self, speed_hz: float) -> tuple[float, float]:
        """``(c_t, k_t) = (alpha C_d+, beta K_e)`` at a camshaft speed [Hz]: the compression damping
        [N s/m] and the stiffness [N/m] that enter the dynamics."""
        alpha, beta = self.tappet_weights(speed_hz)
        return alpha * self.C_d_plus, beta * self.K_e


#: Kim, Jeon & Park (1990) Tables 1-3 and the values quoted in their text, in SI units, with the
#: repairs and assumptions of the project's reading (K_e and C_d+ from K-4/K-5 with Table 1;
#: F_tf0 = 20 N; clockwise cam; the reference cycloidal cam, 6 mm lift, 90 deg rise and return;
#: alpha, beta identified at 900 and 1600 rpm camshaft speed).
KIM1990 = FingerFollowerRig(
    M_t=0.04567, M_f=0.05981, I_f=1.1527e-5, M_v=0.08544,
    K0=35_000.0, f0=504.46, F_o=275.0, zeta_spring=0.04,
    K_tf=5.52e7, K_fc=8.37e7, K_vf=4.33e7, K_se=1.31e7,
    C_tf=118.97, C_fc=197.97, C_vf=94.13, C_se=634.77,
    K_s=5.92e3, A_e=1.213e-4, H_e=1.015e-2, E_oil=1.375e9, mu_oil=0.015, R_p=7.9325e-3, h_clear=9.0e-6,
    L_p=1.358e-2,
    alpha_1=0.0071, beta_1=0.28, speed_1_hz=900.0 / 60.0, alpha_2=0.0094, beta_2=0.30, speed_2_hz=1600.0 / 60.0,
    F_tf0=20.0,
    R_ab=36.40e-3, R_1=31.67e-3, R_c=13.00e-3, R_f=34.00e-3, L_tf=14.22e-3, L_vf=22.53e-3, RR0=1.47,
    cam_sense=-1.0, S_K=6.0e-3, beta_K=0.5 * math.pi,
)

#: Table 2's printed tappet stiffness ``K_tp = 6.648e7 N/m`` in place of ``K_e`` from (K-4): the
#: oil bulk modulus that gives it with Table 1's A_e and H_e (5.563 GPa; decision K-D1 keeps this
#: as the alternative, not the default).
KIM1990_TABLE2 = KIM1990.replace(E_oil=6.648e7 * KIM1990.H_e / KIM1990.A_e)

"""Parameters of the cycloidal-cam / flat-follower valve train with an EHL line contact.

The rig of Kushwaha, Rahnejat & Jin (2000): a cycloidal cam drives a flat-faced translating
follower (bucket) that carries the valve; the valve spring is the two-mass surge model of
Kim, Jeon & Park (1990) (:mod:`impactid.rigs.valvespring`, one damper on all three elements);
the cam/follower contact is a Hertzian line contact lubricated by an elastohydrodynamic film
whose central thickness follows the extrapolated regression of Rahnejat (1984).

The paper gives almost no geometry or lubricant data. :data:`KUSHWAHA2000` is the assumed set of
the project's specification (each value chosen to satisfy a statement the paper makes); the
variants are named after what they change. Every parameter is one float in SI units (the rig
file's names, docs/formats.md); ``ws_clip`` and ``steps_per_rev`` are floats holding a flag (0/1) and a
count, so that a rig file stays a flat table of numbers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

from impactid.errors import RigParameterError
from impactid.rigs._params import RigParameters
from impactid.rigs.valvespring import CamSpeedRange, SurgeModel, surge_model

__all__ = ["KUSHWAHA2000", "KUSHWAHA2000_THICK_OIL", "KUSHWAHA2000_ZEROS_EXACT", "MODEL_NAME", "PRESETS",
           "TABLE1_RANGES", "UNITS", "CycloidalEHLRig"]

MODEL_NAME = "cycloidal-flat-follower-ehl"

#: SI unit of every rig parameter (the rig file's names).
UNITS = {
    "m3": "kg", "k0": "N/m", "f0": "Hz", "f_p": "N", "c_spring": "N s/m", "S": "m", "beta": "rad", "R0": "m",
    "L_c": "m", "E1": "Pa", "E2": "Pa", "nu1": "", "nu2": "", "eta0": "Pa s", "alpha_pv": "1/Pa",
    "steps_per_rev": "", "ws_clip": "", "K_se": "N/m", "C_se": "N s/m", "g_lash": "m",
}

#: Table 1 of Kushwaha, Rahnejat & Jin (2000): mass ranges [kg] of the parts the planar model keeps.
TABLE1_RANGES = {"m3": (0.20, 0.25), "m5": (0.005, 0.010)}


@dataclass(frozen=True)
class CycloidalEHLRig(RigParameters):
    """Parameters of the cycloidal-cam / flat-follower / EHL valve train (SI units).

    Attributes
    ----------
    m3 : valve/follower mass, including the spring retainer [kg]
    k0 : valve-spring rate [N/m]
    f0 : first surge frequency of the valve spring, both ends clamped [Hz]
    f_p : spring preload on the base circle [N]
    c_spring : one damper constant for the three elements of the surge model [N s/m]
    S : total lift of the cycloidal law [m]
    beta : rise angle = return angle [rad]; the rise runs from ``pi - beta`` to the nose at ``pi``
    R0 : base-circle radius [m]
    L_c : contact length (a little less than the cam width) [m]
    E1, E2 : Young's moduli of cam and follower [Pa]
    nu1, nu2 : their Poisson ratios [-]
    eta0 : lubricant viscosity at atmospheric pressure and inlet temperature [Pa s]
    alpha_pv : pressure-viscosity coefficient [1/Pa]
    steps_per_rev : time steps per camshaft revolution of the explicit film scheme (an integer)
    ws_clip : 1 to clip the squeeze ratio ``w_s*`` to the regression range [-0.005, 0] (default,
        decision R-D2), 0 to use it unclipped (the analyses also take the choice as an option)
    K_se, C_se : valve-seat stiffness [N/m] and damping [N s/m] (level B only)
    g_lash : valve lash [m] (level B only)
    """

    model: ClassVar[str] = MODEL_NAME

    m3: float
    k0: float
    f0: float
    f_p: float
    c_spring: float
    S: float
    beta: float
    R0: float
    L_c: float
    E1: float
    E2: float
    nu1: float
    nu2: float
    eta0: float
    alpha_pv: float
    steps_per_rev: float
    ws_clip: float
    K_se: float
    C_se: float
    g_lash: float

    def __post_init__(self) -> None:
        self._check_numbers()
        for name in ("m3", "k0", "f0", "S", "beta", "R0", "L_c", "E1", "E2", "eta0", "alpha_pv"):
            if getattr(self, name) <= 0.0:
                raise RigParameterError(
                    f"rig parameter {name!r} must be positive, got {getattr(self, name)!r} [{UNITS[name]}]")
        for name in ("f_p", "c_spring", "K_se", "C_se", "g_lash"):
            if getattr(self, name) < 0.0:
                raise RigParameterError(
                    f"rig parameter {name!r} must be >= 0, got {getattr(self, name)!r} [{UNITS[name]}]")
        for name in ("nu1", "nu2"):
            if not 0.0 <= getattr(self, name) < 0.5:
                raise RigParameterError(f"rig parameter {name!r} must lie in [0, 0.5), got {getattr(self, name)!r}")
        if self.beta > math.pi:
            raise RigParameterError(
                f"rig parameter 'beta' = {self.beta!r} rad: rise and return must fit in one revolution (beta <= pi)")
        if self.steps_per_rev != round(self.steps_per_rev) or not 8 <= self.steps_per_rev <= 10_000_000:
            raise RigParameterError(
                f"rig parameter 'steps_per_rev' must be an integer in [8, 1e7], got {self.steps_per_rev!r}")
        if self.ws_clip not in (0.0, 1.0):
            raise RigParameterError(f"rig parameter 'ws_clip' must be 0 or 1, got {self.ws_clip!r}")
        from impactid.rigs.cycloidal.cam import min_radius_of_curvature

        r_min, psi_min = min_radius_of_curvature(self.S, self.beta, self.R0)
        if r_min <= 0.0:
            raise RigParameterError(
                f"rig parameters give a cam that is not convex: radius of curvature R0 + s + s'' = {r_min:.4g} m "
                f"at cam angle {math.degrees(psi_min):.2f} deg (a flat follower needs R > 0 everywhere; "
                "raise R0 or beta, or lower S)")

    # ---- derived quantities ---------------------------------------------------------------
    @property
    def surge(self) -> SurgeModel:
        """The two-mass surge model of the valve spring (R-1..R-3, one damper ``c_spring``)."""
        return surge_model(self.k0, self.f0, damper=self.c_spring)

    @property
    def m5(self) -> float:
        """Each spring mass ``m5 = m6 = (2/3) k0 / (pi f0)^2`` (R-1 repaired) [kg]."""
        return (2.0 / 3.0) * self.k0 / (math.pi * self.f0) ** 2

    @property
    def k_s1(self) -> float:
        """End springs ``k_s1 = k_s3 = (8/3) k0`` (R-3) [N/m]."""
        return (8.0 / 3.0) * self.k0

    @property
    def k_s2(self) -> float:
        """Middle spring ``k_s2 = 4 k0`` (R-2) [N/m]."""
        return 4.0 * self.k0

    @property
    def sigma(self) -> float:
        """Compliance sum ``Sigma = (1 - nu1^2)/E1 + (1 - nu2^2)/E2`` [1/Pa]."""
        return (1.0 - self.nu1**2) / self.E1 + (1.0 - self.nu2**2) / self.E2

    @property
    def E_prime(self) -> float:
        """Reduced modulus ``E' = 2 / Sigma`` (decision R-D1) [Pa]."""
        return 2.0 / self.sigma

    @property
    def G_star(self) -> float:
        """Materials group ``G* = alpha_pv E'`` of (R-10) [-]."""
        return self.alpha_pv * self.E_prime

    @property
    def surge_damping_ratios(self) -> tuple[float, float]:
        """Modal damping ratios of the two surge modes (single damper: ``zeta2 = 1.5 zeta1``)."""
        z = self.surge.damping_ratios()
        return float(z[0]), float(z[1])

    @property
    def rigid_jump_rpm(self) -> float:
        """Camshaft speed [rpm] at which a rigid follower on a massless spring first loses the cam
        (:func:`~impactid.rigs.cycloidal.cam.rigid_jump_speed`)."""
        from impactid.rigs.cycloidal.cam import rigid_jump_speed

        return rigid_jump_speed(self.m3, self.k0, self.f_p, self.S, self.beta)[0] * 60.0 / (2.0 * math.pi)

    @property
    def speed_range(self) -> CamSpeedRange:
        """The camshaft speeds the model is used at: 1/300 to 3 times :attr:`rigid_jump_rpm`
        (the decision is :class:`~impactid.rigs.valvespring.CamSpeedRange`'s)."""
        return CamSpeedRange(self.rigid_jump_rpm)

    @property
    def rise_start(self) -> float:
        """Cam angle where the rise starts, ``pi - beta`` [rad]."""
        return math.pi - self.beta

    @property
    def return_end(self) -> float:
        """Cam angle where the return ends (valve closed), ``pi + beta`` [rad]."""
        return math.pi + self.beta

    @property
    def film_steps(self) -> int:
        """``steps_per_rev`` as an int."""
        return int(self.steps_per_rev)


def _assumed(**changes) -> CycloidalEHLRig:
    values = dict(
        m3=0.225,            # kg, middle of Table 1's 0.20-0.25 (R-D12)
        k0=35.0e3,           # N/m, the spring of Kim, Jeon & Park (1990)
        f0=504.5,            # Hz, its first surge frequency
        f_p=275.0,           # N, its preload (assumed: not given by the paper)
        c_spring=2.355,      # N s/m, 4 % in the first surge mode (6 % in the second)
        S=8.0e-3,            # m, total lift (assumed)
        beta=0.5 * math.pi,  # rad, "flank and nose action 90 to 270 deg"
        R0=20.0e-3,          # m, base circle: R0/S = 2.5 puts the zero-entrainment points at 10.8/35.2 deg
        L_c=20.0e-3,         # m, contact length (keeps the nose W* inside Table 3)
        E1=210.0e9, E2=210.0e9, nu1=0.3, nu2=0.3,  # steel on steel: E' = 230.8 GPa
        eta0=0.015,          # Pa s, engine oil near 80 C: nose film 0.978 um at 3000 rpm
        alpha_pv=2.5e-8,     # 1/Pa, smallest round value with G* inside Table 3
        steps_per_rev=500.0,  # the paper's "about 500 time steps per revolution"
        ws_clip=1.0,         # clip w_s* to Table 3's range (R-D2)
        K_se=1.31e7, C_se=634.77,  # valve seat of Kim, Jeon & Park (1990), level B only
        g_lash=0.0,          # m, no lash
    )
    values.update(changes)
    return CycloidalEHLRig(**values)


#: The specification's assumed parameter set for Kushwaha, Rahnejat & Jin (2000) (its section R.3).
KUSHWAHA2000 = _assumed()
#: Variant that puts the zero-entrainment points exactly at 12 and 36 deg from the nose (the
#: paper's statement): ``beta = 93.67 deg``, ``R0 = 2.403 S``.
KUSHWAHA2000_ZEROS_EXACT = _assumed(beta=math.radians(93.67), R0=2.403 * 8.0e-3)
#: Variant with ``eta0 = 0.045 Pa s`` (decision R-D13): U* inside Table 3 at 1000 rpm, nose film
#: 0.98 um at 1000 rpm, but a nose entraining velocity of only 1.47 m/s there.
KUSHWAHA2000_THICK_OIL = _assumed(eta0=0.045)

#: Named parameter sets, the default first.
PRESETS = {
    "kushwaha2000": KUSHWAHA2000,
    "kushwaha2000-zeros-exact": KUSHWAHA2000_ZEROS_EXACT,
    "kushwaha2000-thick-oil": KUSHWAHA2000_THICK_OIL,
}

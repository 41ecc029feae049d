"""Hertzian line contact (R-4..R-9) and the extrapolated EHL central film thickness (R-10, R-37..R-39).

Hertz (a cylinder of radius ``R`` on a plane, contact length ``L_c``, compliance sum
``Sigma = (1 - nu1^2)/E1 + (1 - nu2^2)/E2``, ``D = 2 R``)::

    b0^2  = (2/pi) Sigma W D / L_c              half-width                    (R-6)
    p0    = 2 W / (pi b0 L_c) = b0 / (Sigma D)  maximum pressure              (R-7), (R-5) repaired
    delta = (2 W Sigma/(pi L_c)) [ln(2 L_c/b0) + 1/2]   central approach      (R-9) repaired

(R-9) is the approach at the centre of a rectangular footprint of half-length ``L_c/2`` under the
elliptical pressure (R-8), integrated from (R-4) with ``asinh(a/|x|)`` replaced by ``ln(2a/|x|)``
(relative error of order ``(b0/L_c)^2``). It increases monotonically with ``W`` while
``b0 < 2 L_c``; :func:`hertz_load` inverts it by Newton's method in the variable
``v = ln(2 L_c/b0) + 1/2``.

EHL film (Rahnejat 1984, the regression the paper extrapolates), with the dimensionless groups of
decision R-D1 (``E' = 2/Sigma``, ``R`` the cam radius of curvature at the contact, ``u`` the mean
entraining velocity, ``eta0`` the ambient viscosity)::

    h  = R * 1.67 W*^0.059 U*^0.541 G*^0.421 exp(-96.775 w_s*)     (R-10), (R-38)
    W* = W/(E' R L_c),  U* = eta0 |u|/(E' R),  G* = alpha E',  w_s* = (dh/dt)/|u|

The regression covered only Table 3's ranges (:data:`TABLE3_RANGES`); every evaluation carries a
flag per group saying whether it was inside. Nothing is extrapolated silently: the film functions
return the flags with the film, and the analyses report the fraction of the cycle outside each range.
Inside the power law the load is floored at ``w_floor`` (1 N, decision R-D2) so that a vanishing or
negative load gives a finite film; the flag still sees the raw load.

The squeeze term is stepped explicitly (R-37..R-39, the printed sign of (R-37) repaired)::

    w_n = (h_n - h_{n-1}) / dt                       (positive = the surfaces separate)
    h_{n+1} = R_{n+1} h0*(W*_{n+1}, U*_{n+1}, G*, w_s* = w_n / |u_{n+1}|)
    start: h_{-1} = h_r = R_0 h0*(w_s* = 0),  h_0 = 1.05 h_r

with ``w_s*`` clipped to the regression range by default (``ws_mode="clip"``, every clipped step
flagged), or unclipped (``"none"``), or clipped symmetrically to ``[-0.005, 0.005]``
(``"symmetric"``, the symmetric extrapolation option). The scheme is a compiled loop.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np
from numba import njit

from impactid import compilation

compilation.install()  # before the kernels: the kernel cache's locators and the first-use notice

__all__ = ["EHL_CONSTANTS", "TABLE3_RANGES", "WS_MODES", "FilmEvaluation", "FilmScheme", "RangeFlags", "ehl_film",
           "ehl_groups", "ehl_validity", "film_scheme", "hertz_approach", "hertz_half_width", "hertz_load",
           "hertz_max_pressure", "hertz_load_scalar"]

#: Validity ranges of (R-10): Table 3 of Kushwaha, Rahnejat & Jin (2000); group -> (low, high).
TABLE3_RANGES = MappingProxyType({"W": (0.34e-6, 0.56e-5), "U": (0.63e-11, 3.3e-11), "G": (5700.0, 9650.0),
                                  "ws": (-0.005, 0.0)})
#: Regression constants of (R-10) (Rahnejat 1984): coefficient, exponents of W*, U*, G*, squeeze factor.
EHL_CONSTANTS = MappingProxyType({"coefficient": 1.67, "exp_W": 0.059, "exp_U": 0.541, "exp_G": 0.421,
                                  "squeeze": 96.775})
_C0, _EW, _EU, _EG, _ES = 1.67, 0.059, 0.541, 0.421, 96.775
#: Squeeze-ratio handling of the film scheme, by name (decision R-D2 is "clip").
WS_MODES = MappingProxyType({"clip": 0, "none": 1, "symmetric": 2})
#: Load floor inside the power law [N] (decision R-D2).
W_FLOOR = 1.0


# ============================================================================================
# Hertz line contact
# ============================================================================================


def hertz_half_width(W, R, sigma: float, L_c: float):
    """Hertz half-width ``b0 = sqrt(4 Sigma W R/(pi L_c))`` (R-6) [m]; 0 for ``W <= 0``.

    ``W`` [N], ``R`` [m] reduced radius, ``sigma`` [1/Pa] compliance sum, ``L_c`` [m]."""
    W = np.maximum(np.asarray(W, dtype=float), 0.0)
    return np.sqrt(4.0 * sigma * W * np.asarray(R, dtype=float) / (math.pi * L_c))


def hertz_max_pressure(W, R, sigma: float, L_c: float):
    """Maximum Hertz pressure ``p0 = 2 W/(pi b0 L_c) = b0/(Sigma D)`` (R-7, R-5) [Pa]; 0 for ``W <= 0``."""
    return hertz_half_width(W, R, sigma, L_c) / (2.0 * sigma * np.asarray(R, dtype=float))


def hertz_approach(W, R, sigma: float, L_c: float):
    """Central approach ``delta = (2 W Sigma/(pi L_c)) [ln(2 L_c/b0) + 1/2]`` (R-9 repaired) [m];
    0 for ``W <= 0``."""
    W = np.asarray(W, dtype=float)
    Wp = np.maximum(W, 0.0)
    b0 = hertz_half_width(np.where(Wp > 0.0, Wp, 1.0), R, sigma, L_c)
    return np.where(Wp > 0.0, 2.0 * Wp * sigma / (math.pi * L_c) * (np.log(2.0 * L_c / b0) + 0.5), 0.0)


@njit(cache=True)
def hertz_load_scalar(delta, R, sigma, L_c):
    """Load [N] whose central approach (R-9) is ``delta`` [m] on radius ``R`` [m]; 0 for ``delta <= 0``,
    NaN beyond the monotone branch (``b0 >= 2 L_c``, loads of order 1e8 N).

    With ``C = 2 Sigma/(pi L_c)``, ``b0^2 = kb W``, ``kb = 4 Sigma R/(pi L_c)`` and
    ``v = ln(2 L_c/b0) + 1/2``: ``W = (4 L_c^2 e/kb) e^(-2v)`` and ``delta = C W v``, so ``v`` solves
    ``ln v - 2 v = ln(delta kb/(4 C L_c^2 e))`` with ``v > 1/2``; Newton's method from
    ``v = -ln(...)/2`` converges in a few iterations (the map is a contraction by ``1/(2v)``)."""
    if delta <= 0.0:
        return 0.0
    C = 2.0 * sigma / (math.pi * L_c)
    kb = 4.0 * sigma * R / (math.pi * L_c)
    A = 4.0 * L_c * L_c * math.e / kb  # W = A exp(-2 v)
    rhs = math.log(delta / (C * A))  # ln v - 2 v = rhs
    if rhs > math.log(0.5) - 1.0:  # beyond the maximum of ln v - 2 v (at v = 1/2)
        return math.nan
    v = max(0.5000001, -0.5 * rhs)
    for _ in range(60):
        g = math.log(v) - 2.0 * v - rhs
        dv = g / (1.0 / v - 2.0)
        v_new = v - dv
        if v_new <= 0.5:
            v_new = 0.5 * (v + 0.5)
        if abs(v_new - v) <= 1e-15 * v:
            v = v_new
            break
        v = v_new
    return A * math.exp(-2.0 * v)


@njit(cache=True)
def _hertz_load_array(delta, R, sigma, L_c, out):
    for i in range(delta.shape[0]):
        out[i] = hertz_load_scalar(delta[i], R[i], sigma, L_c)


def hertz_load(delta, R, sigma: float, L_c: float):
    """Inverse of (R-9): the load [N] at central approach ``delta`` [m] on radius ``R`` [m]
    (0 where ``delta <= 0``; NaN beyond the monotone branch)."""
    d = np.asarray(delta, dtype=float)
    Rb = np.broadcast_to(np.asarray(R, dtype=float), d.shape)
    out = np.empty(d.size)
    _hertz_load_array(np.ascontiguousarray(d.ravel()), np.ascontiguousarray(Rb.ravel()), float(sigma),
                      float(L_c), out)
    return out.reshape(d.shape) if d.ndim else float(out[0])


# ============================================================================================
# EHL film
# ============================================================================================


def ehl_groups(W, R, u, E_prime: float, L_c: float, eta0: float, alpha_pv: float, w_floor: float = W_FLOOR):
    """Dimensionless groups of (R-10) as decided in R-D1.

    Parameters
    ----------
    W : contact load [N]; R : reduced radius = cam radius of curvature [m]; u : entraining velocity
        [m/s]; E_prime : ``2/Sigma`` [Pa]; L_c : contact length [m]; eta0 : ambient viscosity
        [Pa s]; alpha_pv : pressure-viscosity coefficient [1/Pa].
    w_floor : floor on ``W`` [N] inside the load group (``-inf`` for the raw group).

    Returns
    -------
    W_star, U_star : arrays; G_star : float.
    """
    R = np.asarray(R, dtype=float)
    W_star = np.maximum(np.asarray(W, dtype=float), w_floor) / (E_prime * R * L_c)
    U_star = eta0 * np.abs(np.asarray(u, dtype=float)) / (E_prime * R)
    return W_star, U_star, alpha_pv * E_prime


def ehl_validity(W, R, u, ws, E_prime: float, L_c: float, eta0: float, alpha_pv: float) -> dict:
    """Per-evaluation flags: is each group inside Table 3's range (bounds included)?

    ``W*`` is formed from the raw load (no floor), so a load below 1 N (or negative: the adherent
    model's "jump predicted") is reported out of range. Returns ``{"W", "U", "G", "ws"}`` -> bool
    arrays (True = inside)."""
    W_star, U_star, G_star = ehl_groups(W, R, u, E_prime, L_c, eta0, alpha_pv, w_floor=-np.inf)
    ws = np.asarray(ws, dtype=float)
    shape = np.broadcast(W_star, U_star, ws).shape
    out = {}
    for key, val in (("W", W_star), ("U", U_star), ("G", np.full(shape, G_star)), ("ws", ws)):
        lo, hi = TABLE3_RANGES[key]
        out[key] = np.broadcast_to((val >= lo) & (val <= hi), shape).copy()
    return out


@dataclass(frozen=True)
class FilmEvaluation:
    """One or more evaluations of (R-10), with their validity flags.

    Attributes
    ----------
    h : central film thickness [m].
    W_star, U_star, G_star, ws_star : the groups (``W_star`` with the load floor applied).
    valid : ``{"W", "U", "G", "ws"}`` -> bool arrays, True where the group is inside Table 3.
    """

    h: np.ndarray
    W_star: np.ndarray
    U_star: np.ndarray
    G_star: float
    ws_star: np.ndarray
    valid: dict

    @property
    def inside(self) -> np.ndarray:
        """True where every group is inside its regression range."""
        return self.valid["W"] & self.valid["U"] & self.valid["G"] & self.valid["ws"]

    @property
    def extrapolated(self) -> bool:
        """Whether any evaluation lies outside the regression ranges."""
        return not bool(np.all(self.inside))


def ehl_film(W, R, u, ws, E_prime: float, L_c: float, eta0: float, alpha_pv: float,
             w_floor: float = W_FLOOR) -> FilmEvaluation:
    """Central film thickness (R-10, R-38) for given load, radius, entraining velocity and squeeze
    ratio, with a validity flag per group and evaluation (see :class:`FilmEvaluation`).

    ``ws`` is used as given (clipping is the film scheme's business). Units as in :func:`ehl_groups`."""
    W_star, U_star, G_star = ehl_groups(W, R, u, E_prime, L_c, eta0, alpha_pv, w_floor)
    ws = np.asarray(ws, dtype=float)
    with np.errstate(over="ignore", invalid="ignore"):
        h = np.asarray(R, dtype=float) * _C0 * W_star**_EW * U_star**_EU * G_star**_EG * np.exp(-_ES * ws)
    valid = ehl_validity(W, R, u, ws, E_prime, L_c, eta0, alpha_pv)
    return FilmEvaluation(h=h, W_star=W_star, U_star=U_star, G_star=float(G_star), ws_star=ws, valid=valid)


@njit(cache=True)
def _film_formula(W, R, u, ws, E_prime, L_c, eta0, G_star, w_floor):
    W_star = max(W, w_floor) / (E_prime * R * L_c)
    U_star = eta0 * abs(u) / (E_prime * R)
    if U_star == 0.0:
        return 0.0
    return R * _C0 * W_star**_EW * U_star**_EU * G_star**_EG * math.exp(-_ES * ws)


@njit(cache=True)
def _film_scheme(W, R, u, dt, E_prime, L_c, eta0, G_star, w_floor, mode, n_rev, h_floor,
                 h, w, ws_raw, ws_used, floored):
    N = W.shape[0]
    lo, hi = -0.005, 0.0
    if mode == 2:
        hi = 0.005
    h_r = _film_formula(W[0], R[0], u[0], 0.0, E_prime, L_c, eta0, G_star, w_floor)
    h_prev2 = h_r
    h_prev = 1.05 * h_r
    total = n_rev * N
    start = total - N
    if start == 0:
        h[0] = h_prev
        w[0] = (h_prev - h_prev2) / dt
        ws_raw[0] = 0.0
        ws_used[0] = 0.0
        floored[0] = False
    for k in range(1, total):
        n = k % N
        w_prev = (h_prev - h_prev2) / dt
        au = abs(u[n])
        if au > 0.0:
            raw = w_prev / au
        elif w_prev < 0.0:
            raw = -math.inf
        elif w_prev > 0.0:
            raw = math.inf
        else:
            raw = 0.0
        used = raw if mode == 1 else min(max(raw, lo), hi)
        hk = _film_formula(W[n], R[n], u[n], used, E_prime, L_c, eta0, G_star, w_floor)
        fl = False
        if hk < h_floor:
            hk = h_floor
            fl = True
        if k >= start:
            j = k - start
            h[j] = hk
            w[j] = (hk - h_prev) / dt
            ws_raw[j] = raw
            ws_used[j] = used
            floored[j] = fl
        h_prev2 = h_prev
        h_prev = hk


class RangeFlags:
    """What a result with per-step validity flags ``valid`` (one boolean array per dimensionless
    group of the film formula) says about the regression ranges of the paper's Table 3."""

    valid: dict

    @property
    def inside(self) -> np.ndarray:
        """True where every group is inside its regression range."""
        return self.valid["W"] & self.valid["U"] & self.valid["G"] & self.valid["ws"]

    def fraction_outside(self) -> dict:
        """Fraction of the steps outside each regression range, and outside any (``"any"``)."""
        out = {k: float(np.mean(~v)) for k, v in self.valid.items()}
        out["any"] = float(np.mean(~self.inside))
        return out


@dataclass(frozen=True)
class FilmScheme(RangeFlags):
    """The film over one revolution from the explicit squeeze scheme (R-37..R-39).

    The arrays are over the steps of the revolution.

    Attributes
    ----------
    h : central film thickness [m].
    w : squeeze velocity ``(h_n - h_{n-1})/dt`` [m/s], positive = separation.
    ws_raw : squeeze ratio ``w_{n-1}/|u_n|`` that entered ``h_n``, before clipping [-].
    ws : the ratio used (after clipping) [-].
    clipped : where ``ws != ws_raw``.
    floored : where the optional film floor replaced the formula's value.
    valid : ``{"W", "U", "G", "ws"}`` -> True where the group (raw ``W``, raw ``ws``) is inside Table 3.
    mode : ``"clip"``, ``"none"`` or ``"symmetric"``; n_rev : revolutions run (the last is kept).
    """

    h: np.ndarray
    w: np.ndarray
    ws_raw: np.ndarray
    ws: np.ndarray
    clipped: np.ndarray
    floored: np.ndarray
    valid: dict
    mode: str
    n_rev: int



def film_scheme(W, R, u, dt: float, E_prime: float, L_c: float, eta0: float, alpha_pv: float, *,
                ws_mode: str = "clip", n_rev: int = 2, h_floor: float = 0.0,
                w_floor: float = W_FLOOR) -> FilmScheme:
    """Explicit squeeze-film time stepping over periodic samples of one revolution (R-37..R-39).

    Parameters
    ----------
    W, R, u : load [N], reduced radius [m] and entraining velocity [m/s] at the ``N`` equally spaced
        steps of one revolution (``dt`` apart); treated as periodic.
    dt : time step [s].
    E_prime, L_c, eta0, alpha_pv : as in :func:`ehl_groups`.
    ws_mode : ``"clip"`` (default, R-D2), ``"none"`` or ``"symmetric"``; a callable is not accepted.
    n_rev : revolutions to run; the last is returned, so the arbitrary start (R-39) does not show.
    h_floor : optional film floor [m] (0: none), applied inside the scheme and flagged (R-D5).
    w_floor : load floor inside the power law [N].
    """
    if ws_mode not in WS_MODES:
        raise ValueError(f"unknown ws_mode {ws_mode!r}; valid: {', '.join(WS_MODES)}")
    if int(n_rev) < 1:
        raise ValueError(f"n_rev must be >= 1, got {n_rev!r}")
    if not (math.isfinite(dt) and dt > 0.0):
        raise ValueError(f"dt must be positive, got {dt!r}")
    if not (math.isfinite(h_floor) and h_floor >= 0.0):
        raise ValueError(f"h_floor must be >= 0, got {h_floor!r}")
    W = np.ascontiguousarray(W, dtype=float)
    R = np.ascontiguousarray(R, dtype=float)
    u = np.ascontiguousarray(u, dtype=float)
    N = W.size
    if not (R.size == N and u.size == N and N >= 2):
        raise ValueError("W, R and u must have the same length (at least 2)")
    h, w, ws_raw, ws_used = (np.empty(N) for _ in range(4))
    floored = np.zeros(N, dtype=np.bool_)
    _film_scheme(W, R, u, float(dt), float(E_prime), float(L_c), float(eta0), float(alpha_pv * E_prime),
                 float(w_floor), WS_MODES[ws_mode], int(n_rev), float(h_floor), h, w, ws_raw, ws_used, floored)
    valid = ehl_validity(W, R, u, ws_raw, E_prime, L_c, eta0, alpha_pv)
    return FilmScheme(h=h, w=w, ws_raw=ws_raw, ws=ws_used, clipped=ws_used != ws_raw, floored=floored,
                      valid=valid, mode=ws_mode, n_rev=int(n_rev))

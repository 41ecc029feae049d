"""Cam lift, contact point, rocker ratio and lever arm of the finger follower (Kim et al. 1990, K.2.5-K.2.6).

The cam is given by the lift ``S(gamma)`` of a translating flat-faced follower (the "desired cam
lift" of the paper) over the cam-fixed angle ``gamma`` (0 at the nose, negative on the opening
side). Its profile is the envelope of the follower face (K-7): with ``n(gamma)`` the outward normal
and ``t = dn/dgamma``,

    P_cam(gamma) = A + (R_c + S) n + S' t,        radius of curvature  rho = R_c + S + S''.

The finger follower's pad is a circle of radius ``R_f`` whose centre C stays at ``|BC| = R_1``
from the pivot B (the tappet, held fixed for the kinematics). The contact lies on the common
normal through C (decision K-D15), so ``C = P_cam + R_f n`` and the contact angle ``gamma`` solves
``|C(gamma; theta)| = R_1`` at cam angle ``theta``. In the pivot frame (origin B, x towards the
valve tip, y towards the cam) the cam-fixed direction ``gamma`` points along
``psi = g0 + sigma (theta - gamma)``; on the base circle ``gamma = theta``. From the contact
(K-7a..f):

    phi  = angle(C0) - angle(C)            follower rotation (+ = valve end down)
    d_c  = x_P                            horizontal pivot-to-contact distance
    RR   = (L_tf + L_vf) / d_c            instantaneous rocker ratio
    L_fc = d_c - L_tf                     lever arm of the cam force about G
    Y_c  = d_c sin(phi)                   cam input of the lumped model (K-D13)
    Y_v,kin = (L_tf + L_vf) sin(phi)      valve lift of the rigid train

The contact is found by Newton's method, continued from the base circle in cam-angle steps, with
the exact derivatives by implicit differentiation; both are compiled (numba) because the lift fit
rebuilds the table at every trial. :func:`build_kinematics` tabulates one revolution and
interpolates ``Y_c`` and ``L_fc`` (and the others) with periodic cubic splines: the compiled
simulator evaluates those splines.

Lift laws (:class:`CycloidalLift`, :class:`LiftTable`) evaluate ``(S, S', S'')``; a lift table
travels in a CSV file (columns ``gamma_rad,lift_m``) or a TOML ``[lift]`` table
(:func:`read_lift`, :func:`write_lift`).
"""

from __future__ import annotations

import csv
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numba import njit
from scipy.interpolate import CubicSpline

from impactid import compilation
from impactid.errors import RigParameterError

compilation.install()  # before the kernels: the kernel cache's locators and the first-use notice

__all__ = ["BaseGeometry", "CycloidalLift", "Kinematics", "LiftTable", "base_geometry", "build_kinematics",
           "contact_kinematics", "cycloidal_lift", "lift_from_rig", "read_lift", "write_lift"]

TWO_PI = 2.0 * math.pi
DEG = math.pi / 180.0
#: Default step of the kinematic table [deg]: the splines' interpolation error is below 2e-11 m
#: in Y_c and L_fc where the lift is smooth, and below 5e-9 m within a degree of the points where
#: the cycloidal lift's third derivative jumps (the nose and the event ends) (tests).
TABLE_STEP_DEG = 0.1

LIFT_CYCLOIDAL, LIFT_TABLE = 0, 1


# --------------------------------------------------------------------------------------------
# Lift laws
# --------------------------------------------------------------------------------------------


@njit(cache=True)
def cycloidal_lift(gamma, S_K, beta_open, beta_close):
    """Cycloidal flat-follower lift and its derivatives ``(S, dS/dgamma, d2S/dgamma2)``
    [m, m/rad, m/rad^2] at the cam-fixed angle ``gamma`` [rad] in [-pi, pi] (0 at the nose).

    ``S = S_K (x/b - sin(2 pi x/b) / (2 pi))`` with ``x = b - |gamma|`` for ``|gamma| < b`` (0
    outside), ``b = beta_open`` for ``gamma < 0`` and ``beta_close`` for ``gamma >= 0``. Both halves
    have ``S' = S'' = 0`` at the nose and at the ends, so the lift is twice continuously
    differentiable even when the two angles differ.
    """
    b = beta_open if gamma < 0.0 else beta_close
    a = abs(gamma)
    if a >= b:
        return 0.0, 0.0, 0.0
    x = b - a
    u = TWO_PI * x / b
    S = S_K * (x / b - math.sin(u) / TWO_PI)
    dS_dx = S_K / b * (1.0 - math.cos(u))
    d2S = S_K * TWO_PI / (b * b) * math.sin(u)
    if gamma > 0.0:
        return S, -dS_dx, d2S
    if gamma < 0.0:
        return S, dS_dx, d2S
    return S, 0.0, d2S


@njit(cache=True)
def _wrap(gamma):
    """``gamma`` wrapped to [-pi, pi)."""
    return (gamma + math.pi) % TWO_PI - math.pi


@njit(cache=True)
def _table_lift(gamma, knots, coef):
    """Clamped cubic spline through a lift table (0 outside its first and last knot)."""
    n = knots.shape[0]
    if gamma <= knots[0] or gamma >= knots[n - 1]:
        return 0.0, 0.0, 0.0
    i = np.searchsorted(knots, gamma) - 1
    if i < 0:
        i = 0
    elif i > n - 2:
        i = n - 2
    s = gamma - knots[i]
    c3, c2, c1, c0 = coef[0, i], coef[1, i], coef[2, i], coef[3, i]
    return ((c3 * s + c2) * s + c1) * s + c0, (3.0 * c3 * s + 2.0 * c2) * s + c1, 6.0 * c3 * s + 2.0 * c2


@njit(cache=True)
def lift_eval(gamma, kind, lp, knots, coef):
    """``(S, S', S'')`` of a lift law in the compiled layout (``kind``: 0 cycloidal with
    ``lp = (S_K, beta_open, beta_close)``, 1 table with spline ``knots, coef``)."""
    g = _wrap(gamma)
    if kind == LIFT_CYCLOIDAL:
        return cycloidal_lift(g, lp[0], lp[1], lp[2])
    return _table_lift(g, knots, coef)


_EMPTY_1 = np.zeros(1)
_EMPTY_2 = np.zeros((4, 1))


@dataclass(frozen=True)
class CycloidalLift:
    """Cycloidal flat-follower lift (the reference cam of decision K-D4 when symmetric).

    Attributes
    ----------
    S_K : total lift [m].
    beta_open, beta_close : rise and return angles [rad] (equal for a symmetric cam).
    """

    S_K: float
    beta_open: float
    beta_close: float

    kind = LIFT_CYCLOIDAL

    def __post_init__(self) -> None:
        for name in ("S_K", "beta_open", "beta_close"):
            value = float(getattr(self, name))
            if not math.isfinite(value) or value <= 0.0:
                raise RigParameterError(f"cycloidal lift: {name} must be positive and finite, got {value!r}")
            object.__setattr__(self, name, value)
        if self.beta_open + self.beta_close >= TWO_PI:
            raise RigParameterError("cycloidal lift: rise and return angles leave no base circle")

    def compiled(self) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
        """``(kind, lp, knots, coef)`` for :func:`lift_eval`."""
        return self.kind, np.array([self.S_K, self.beta_open, self.beta_close]), _EMPTY_1, _EMPTY_2

    def __call__(self, gamma):
        """``(S, S', S'')`` at ``gamma`` [rad] (scalar or array)."""
        return _evaluate_lift(self, gamma)

    @property
    def event(self) -> tuple[float, float]:
        """Cam-fixed angles where the lift starts and ends [rad]."""
        return -self.beta_open, self.beta_close

    def to_dict(self) -> dict[str, Any]:
        return {"law": "cycloidal", "S_K": self.S_K, "beta_open": self.beta_open, "beta_close": self.beta_close}


@dataclass(frozen=True, eq=False)
class LiftTable:
    """A lift table ``S(gamma)`` interpolated by a clamped cubic spline.

    ``gamma`` [rad] increasing inside (-pi, pi), 0 at the nose, negative on the opening side;
    ``lift`` [m], non-negative, zero at the first and last point (the base circle); the spline
    has zero slope there and the lift is zero outside. The lift's second derivative jumps at the
    two ends unless the table makes it vanish there.
    """

    gamma: np.ndarray
    lift: np.ndarray
    source: str = ""
    _coef: np.ndarray = field(init=False, repr=False)

    kind = LIFT_TABLE

    def __post_init__(self) -> None:
        where = f"{self.source}: " if self.source else ""
        gamma = np.array(self.gamma, dtype=float).ravel()
        lift = np.array(self.lift, dtype=float).ravel()
        if gamma.size != lift.size:
            raise RigParameterError(f"{where}lift table: {gamma.size} angles but {lift.size} lifts")
        if gamma.size < 5:
            raise RigParameterError(f"{where}lift table: at least 5 points needed, got {gamma.size}")
        if not (np.all(np.isfinite(gamma)) and np.all(np.isfinite(lift))):
            raise RigParameterError(f"{where}lift table: non-finite values")
        if not np.all(np.diff(gamma) > 0.0):
            raise RigParameterError(f"{where}lift table: gamma_rad must increase strictly")
        if gamma[0] <= -math.pi or gamma[-1] >= math.pi:
            raise RigParameterError(f"{where}lift table: gamma_rad must lie inside (-pi, pi) (0 at the nose)")
        if np.any(lift < 0.0):
            raise RigParameterError(f"{where}lift table: negative lift at gamma = {gamma[np.argmax(lift < 0)]!r} rad")
        scale = max(float(lift.max()), 1e-300)
        if abs(lift[0]) > 1e-9 * scale or abs(lift[-1]) > 1e-9 * scale:
            raise RigParameterError(f"{where}lift table: the lift must be 0 at the first and last point "
                                    f"(the base circle), got {lift[0]!r} and {lift[-1]!r} m")
        lift[0] = lift[-1] = 0.0
        for name, value in (("gamma", gamma), ("lift", lift)):
            value.flags.writeable = False
            object.__setattr__(self, name, value)
        spline = CubicSpline(gamma, lift, bc_type="clamped")
        object.__setattr__(self, "_coef", np.ascontiguousarray(spline.c))

    def compiled(self) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
        """``(kind, lp, knots, coef)`` for :func:`lift_eval`."""
        return self.kind, _EMPTY_1, np.ascontiguousarray(self.gamma), self._coef

    def __call__(self, gamma):
        """``(S, S', S'')`` at ``gamma`` [rad] (scalar or array)."""
        return _evaluate_lift(self, gamma)

    @property
    def S_K(self) -> float:
        """Largest lift of the table [m]."""
        return float(self.lift.max())

    @property
    def event(self) -> tuple[float, float]:
        """Cam-fixed angles of the first and last point [rad]."""
        return float(self.gamma[0]), float(self.gamma[-1])

    def to_dict(self) -> dict[str, Any]:
        return {"law": "table", "gamma_rad": self.gamma.tolist(), "lift_m": self.lift.tolist()}


@njit(cache=True)
def _lift_array(gamma, kind, lp, knots, coef, out):
    for i in range(gamma.shape[0]):
        out[0, i], out[1, i], out[2, i] = lift_eval(gamma[i], kind, lp, knots, coef)


def _evaluate_lift(lift, gamma):
    g = np.asarray(gamma, dtype=float)
    out = np.empty((3, g.size))
    _lift_array(np.ascontiguousarray(g.ravel()), *lift.compiled(), out)
    if g.ndim == 0:
        return float(out[0, 0]), float(out[1, 0]), float(out[2, 0])
    return out[0].reshape(g.shape), out[1].reshape(g.shape), out[2].reshape(g.shape)


def lift_from_rig(rig) -> CycloidalLift:
    """The rig's cycloidal lift law (``S_K``, ``beta_K`` for both rise and return)."""
    return CycloidalLift(rig.S_K, rig.beta_K, rig.beta_K)


def radius_of_curvature(lift, R_c: float, gamma):
    """Cam radius of curvature ``rho = R_c + S + S''`` [m] (must stay positive: a convex cam)."""
    S, _, S2 = lift(gamma)
    return R_c + np.asarray(S) + np.asarray(S2)


def check_convex(lift, R_c: float, samples: int = 20_000) -> float:
    """The smallest radius of curvature over the cam [m]; :class:`RigParameterError` if it is not
    positive (the flat-follower envelope would have a cusp and the contact would not be unique)."""
    g = np.linspace(-math.pi, math.pi, samples, endpoint=False)
    rho = radius_of_curvature(lift, R_c, g)
    k = int(np.argmin(rho))
    if not rho[k] > 0.0:
        raise RigParameterError(f"the cam is not convex: radius of curvature {rho[k]:.4g} m at gamma = "
                                f"{g[k] / DEG:.2f} deg (R_c + S + S'' must stay positive)")
    return float(rho[k])


# ---- lift files ------------------------------------------------------------------------------


def read_lift(path: str | os.PathLike[str]):
    """Read a cam lift from a file.

    * CSV: columns ``gamma_rad`` and ``lift_m`` (SI; ``#`` comments allowed) -> :class:`LiftTable`;
    * TOML: a ``[lift]`` table (it may sit in a rig file next to ``[rig]``) with either arrays
      ``gamma_rad`` and ``lift_m`` (a table) or ``law = "cycloidal"`` with ``S_K`` [m] and
      ``beta_open``, ``beta_close`` [rad] -> :class:`CycloidalLift`.

    Raises :class:`~impactid.errors.RigParameterError` naming the file.
    """
    path = Path(path)
    if not path.is_file():
        raise RigParameterError(f"{path}: lift file not found" if not path.exists() else f"{path}: not a file")
    if path.suffix.lower() == ".toml":
        from impactid.rigs._toml import read_toml

        data = read_toml(path)
        table = data.get("lift")
        if not isinstance(table, dict):
            raise RigParameterError(f"{path}: no [lift] table")
        return lift_from_mapping(table, source=str(path))
    try:
        with path.open(encoding="utf-8", newline="") as fh:
            rows = [r for r in csv.reader(line for line in fh if line.strip() and not line.lstrip().startswith("#"))]
    except (OSError, UnicodeDecodeError) as exc:
        raise RigParameterError(f"{path}: cannot read lift file ({exc})") from None
    if not rows:
        raise RigParameterError(f"{path}: empty lift file")
    header = [c.strip() for c in rows[0]]
    if "gamma_rad" not in header or "lift_m" not in header:
        raise RigParameterError(f"{path}: a lift CSV needs columns gamma_rad and lift_m (got {', '.join(header)})")
    ig, il = header.index("gamma_rad"), header.index("lift_m")
    try:
        gamma = [float(r[ig]) for r in rows[1:]]
        lift = [float(r[il]) for r in rows[1:]]
    except (ValueError, IndexError):
        raise RigParameterError(f"{path}: malformed lift CSV (every row needs numbers in gamma_rad and "
                                "lift_m)") from None
    return LiftTable(np.array(gamma), np.array(lift), source=str(path))


def lift_from_mapping(table: dict, source: str = ""):
    """A lift from a mapping (the ``[lift]`` table of a TOML file, or :meth:`to_dict` output)."""
    where = f"{source}: " if source else ""
    law = table.get("law", "table")
    if law == "cycloidal":
        try:
            return CycloidalLift(float(table["S_K"]), float(table["beta_open"]), float(table["beta_close"]))
        except KeyError as exc:
            raise RigParameterError(f"{where}[lift] law 'cycloidal' needs {exc.args[0]}") from None
        except (TypeError, ValueError):
            raise RigParameterError(f"{where}[lift] S_K, beta_open, beta_close must be numbers") from None
    if law != "table":
        raise RigParameterError(f"{where}[lift] unknown law {law!r} (known: cycloidal, table)")
    if "gamma_rad" not in table or "lift_m" not in table:
        raise RigParameterError(f"{where}[lift] table needs arrays gamma_rad and lift_m")
    try:
        gamma = np.array(table["gamma_rad"], dtype=float)
        lift = np.array(table["lift_m"], dtype=float)
    except (TypeError, ValueError):
        raise RigParameterError(f"{where}[lift] gamma_rad and lift_m must be arrays of numbers") from None
    return LiftTable(gamma, lift, source=source)


def write_lift(lift, path: str | os.PathLike[str]) -> Path:
    """Write a lift as CSV (``gamma_rad,lift_m``; a cycloidal law is tabulated every 0.25 deg over
    its event) or as a TOML ``[lift]`` table (by the suffix), atomically."""
    from impactid._files import atomic_write
    from impactid.rigs._toml import format_toml

    path = Path(path)
    if isinstance(lift, CycloidalLift):
        g = np.arange(-lift.beta_open, lift.beta_close + 1e-12, 0.25 * DEG)
        g[-1] = lift.beta_close
        table = LiftTable(g, lift(g)[0])
    else:
        table = lift
    if path.suffix.lower() == ".toml":
        if isinstance(lift, CycloidalLift):
            text = format_toml({"lift": lift.to_dict()}, header="impactid cam lift (SI units)")
        else:
            text = "# impactid cam lift table (SI units; gamma 0 at the nose, negative opening)\n[lift]\n"
            text += "law = \"table\"\n"
            text += "gamma_rad = [" + ", ".join(repr(float(v)) for v in table.gamma) + "]\n"
            text += "lift_m = [" + ", ".join(repr(float(v)) for v in table.lift) + "]\n"
        return atomic_write(path, text)
    lines = ["# impactid cam lift table: flat-follower lift S(gamma), gamma 0 at the nose, negative opening",
             "gamma_rad,lift_m"] + [f"{g!r},{s!r}" for g, s in zip(table.gamma.tolist(), table.lift.tolist())]
    return atomic_write(path, "\n".join(lines) + "\n")


# --------------------------------------------------------------------------------------------
# Geometry of the base-circle configuration
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class BaseGeometry:
    """Base-circle configuration in the pivot frame (origin at the pivot B) [m, rad].

    ``A`` cam centre, ``C0`` pad centre, ``P0`` contact; ``g0`` direction of ``C0 - A`` (the
    base-circle contact normal points the other way, at ``normal`` from +x); ``angle_B`` the angle
    A-B-C0 of the triangle.
    """

    A: tuple[float, float]
    C0: tuple[float, float]
    P0: tuple[float, float]
    g0: float
    normal: float
    angle_B: float


def base_geometry(rig) -> BaseGeometry:
    """The base-circle configuration from Table 3 and the rocker ratio (K.2.6 step 1).

    Triangle A B C0 has ``|AB| = R_ab``, ``|BC0| = R_1``, ``|AC0| = R_c + R_f``; the contact
    ``P0 = A + R_c/(R_c + R_f) (C0 - A)`` lies at the horizontal distance ``d_c0 = L_sum / RR0``
    from the pivot, with the cam above the follower (the mirror solution, cam below, is rejected).
    """
    R_ab, R_1, rc, rf = rig.R_ab, rig.R_1, rig.R_c, rig.R_f
    cos_b = (R_ab**2 + R_1**2 - (rc + rf) ** 2) / (2.0 * R_ab * R_1)
    angle_B = math.acos(cos_b)
    lam = rc / (rc + rf)
    # A on the +x axis, C0 clockwise from it by angle_B; then rotate the triangle about B
    ax, ay = R_ab, 0.0
    cx, cy = R_1 * math.cos(-angle_B), R_1 * math.sin(-angle_B)
    px, py = ax + lam * (cx - ax), ay + lam * (cy - ay)
    r = math.hypot(px, py)
    if rig.d_c0 >= r:
        raise RigParameterError(f"rig geometry: the base-circle contact is {r * 1e3:.4g} mm from the pivot, less than "
                                f"the horizontal distance d_c0 = (L_tf + L_vf)/RR0 = {rig.d_c0 * 1e3:.4g} mm")
    rot = math.acos(rig.d_c0 / r) - math.atan2(py, px)
    c, s = math.cos(rot), math.sin(rot)

    def turn(x, y):
        return (c * x - s * y, s * x + c * y)

    A, C0, P0 = turn(ax, ay), turn(cx, cy), turn(px, py)
    g0 = math.atan2(C0[1] - A[1], C0[0] - A[0])
    normal = math.atan2(A[1] - C0[1], A[0] - C0[0])
    return BaseGeometry(A=A, C0=C0, P0=P0, g0=g0, normal=normal, angle_B=angle_B)


# --------------------------------------------------------------------------------------------
# The contact (compiled)
# --------------------------------------------------------------------------------------------


@njit(cache=True)
def _contact(theta, gamma, sig, Ax, Ay, g0, rc, rf, r1, kind, lp, knots, coef):
    """Newton solve of ``|C(gamma; theta)| = R_1`` from ``gamma``; returns ``(gamma, ok, S, S1, S2,
    nx, ny, tx, ty, Cx, Cy)`` with ``n``, ``t`` the normal and tangent at the solution."""
    ok = False
    for _ in range(60):
        S, S1, S2 = lift_eval(gamma, kind, lp, knots, coef)
        psi = g0 + sig * (theta - gamma)
        nx, ny = math.cos(psi), math.sin(psi)
        tx, ty = sig * ny, -sig * nx
        Cx = Ax + (rc + S + rf) * nx + S1 * tx
        Cy = Ay + (rc + S + rf) * ny + S1 * ty
        f = Cx * Cx + Cy * Cy - r1 * r1
        df = 2.0 * (rc + S + S2 + rf) * (Cx * tx + Cy * ty)
        step = -f / df
        if abs(step) > 0.2:
            step = 0.2 if step > 0.0 else -0.2
        gamma += step
        if abs(step) < 1e-15:
            ok = True
            break
    S, S1, S2 = lift_eval(gamma, kind, lp, knots, coef)
    psi = g0 + sig * (theta - gamma)
    nx, ny = math.cos(psi), math.sin(psi)
    tx, ty = sig * ny, -sig * nx
    Cx = Ax + (rc + S + rf) * nx + S1 * tx
    Cy = Ay + (rc + S + rf) * ny + S1 * ty
    return gamma, ok, S, S1, S2, nx, ny, tx, ty, Cx, Cy


@njit(cache=True)
def contact_table(thetas, gamma0, sig, Ax, Ay, g0, angle_c0, rc, rf, r1, l_tf, l_sum, kind, lp, knots, coef, out):
    """The contact and its kinematic outputs at increasing cam angles ``thetas``, continued from
    ``gamma0`` at the first one. Fills ``out[:, k]`` with ``gamma, phi, d_c, Y_c, L_fc, Y_v_kin,
    dphi, dd_c, dY_c, Px, Py, Cx, Cy, dgamma`` (derivatives with respect to theta, exact by
    implicit differentiation). Returns the index of the first angle where Newton failed, or -1.

    On the base circle (``S = S' = 0`` at the solution) the exact base configuration is written,
    so that the table is exactly constant there.
    """
    gamma = gamma0
    dg = 1.0
    for k in range(thetas.shape[0]):
        th = thetas[k]
        guess = gamma if k == 0 else gamma + dg * (th - thetas[k - 1])
        gamma, ok, S, S1, S2, nx, ny, tx, ty, Cx, Cy = _contact(th, guess, sig, Ax, Ay, g0, rc, rf, r1,
                                                               kind, lp, knots, coef)
        if not ok:
            return k
        rho_p = rc + S + S2 + rf
        # dC/dtheta at fixed gamma (n' = -t, t' = n) and dC/dgamma = rho_p t
        dCx_th = -(rc + S + rf) * tx + S1 * nx
        dCy_th = -(rc + S + rf) * ty + S1 * ny
        dg = -(Cx * dCx_th + Cy * dCy_th) / (rho_p * (Cx * tx + Cy * ty))
        dCx = dCx_th + rho_p * tx * dg
        dCy = dCy_th + rho_p * ty * dg
        dnx = -tx + tx * dg
        Px, Py = Cx - rf * nx, Cy - rf * ny
        dPx = dCx - rf * dnx
        base = S == 0.0 and S1 == 0.0
        if base:
            phi, dphi, dPx = 0.0, 0.0, 0.0
        else:
            phi = angle_c0 - math.atan2(Cy, Cx)
            phi = (phi + math.pi) % TWO_PI - math.pi
            dphi = -(Cx * dCy - Cy * dCx) / (Cx * Cx + Cy * Cy)
        sp, cp = math.sin(phi), math.cos(phi)
        out[0, k] = gamma
        out[1, k] = phi
        out[2, k] = Px
        out[3, k] = Px * sp
        out[4, k] = Px - l_tf
        out[5, k] = l_sum * sp
        out[6, k] = dphi
        out[7, k] = dPx
        out[8, k] = dPx * sp + Px * cp * dphi
        out[9, k] = Px
        out[10, k] = Py
        out[11, k] = Cx
        out[12, k] = Cy
        out[13, k] = dg
    return -1


_ROWS = ("gamma", "phi", "d_c", "Y_c", "L_fc", "Y_v_kin", "dphi", "dd_c", "dY_c", "Px", "Py", "Cx", "Cy", "dgamma")


def _table(rig, lift, thetas: np.ndarray, geo: BaseGeometry, gamma0: float) -> dict[str, np.ndarray]:
    out = np.empty((len(_ROWS), thetas.size))
    angle_c0 = math.atan2(geo.C0[1], geo.C0[0])
    fail = contact_table(np.ascontiguousarray(thetas, dtype=float), float(gamma0), float(rig.cam_sense),
                         geo.A[0], geo.A[1], geo.g0, angle_c0, rig.R_c, rig.R_f, rig.R_1, rig.L_tf, rig.L_sum,
                         *lift.compiled(), out)
    if fail >= 0:
        raise RigParameterError(f"no cam/follower contact found at cam angle {thetas[fail] / DEG:.3f} deg: the pad "
                                "circle cannot reach the cam there (check R_1, R_f, R_ab and the lift)")
    table = dict(zip(_ROWS, out))
    if np.any(table["d_c"] <= 0.0):
        k = int(np.argmax(table["d_c"] <= 0.0))
        raise RigParameterError(f"the contact passes behind the pivot at cam angle {thetas[k] / DEG:.3f} deg")
    return table


def contact_kinematics(rig, theta, lift=None) -> dict[str, np.ndarray]:
    """The exact contact and kinematic outputs at cam angles ``theta`` [rad] (scalar or array).

    The contact is continued from the base circle at -180 deg through every angle asked (sorted
    internally), so any angle is valid. Returns a dict of arrays shaped like ``theta``: ``gamma``
    (contact angle on the cam), ``phi`` (follower rotation), ``d_c``, ``RR``, ``L_fc``, ``Y_c``,
    ``Y_v_kin`` and their exact derivatives ``dphi``, ``dd_c`` (= ``dL_fc``), ``dY_c``,
    ``dgamma`` [rad, m, -, ... per rad], the contact ``P`` and pad centre ``C`` (``(..., 2)`` [m]).
    """
    lift = lift_from_rig(rig) if lift is None else lift
    geo = base_geometry(rig)
    th = np.asarray(theta, dtype=float)
    flat = th.ravel()
    wrapped = (flat + math.pi) % TWO_PI - math.pi
    order = np.argsort(wrapped)
    # continue from -180 deg through a 1 deg grid plus the requested angles
    grid = np.arange(-180.0, 180.0, 1.0) * DEG
    allth = np.concatenate([grid, wrapped[order]])
    idx = np.argsort(allth, kind="stable")
    table = _table(rig, lift, allth[idx], geo, -math.pi)
    pos = np.empty(allth.size, dtype=int)
    pos[idx] = np.arange(allth.size)
    pick = np.empty(flat.size, dtype=int)
    pick[order] = pos[grid.size:]
    result = {k: table[k][pick].reshape(th.shape) for k in _ROWS}
    result["RR"] = rig.L_sum / result["d_c"]
    result["dL_fc"] = result["dd_c"]
    result["P"] = np.stack([result.pop("Px"), result.pop("Py")], axis=-1)
    result["C"] = np.stack([result.pop("Cx"), result.pop("Cy")], axis=-1)
    return result


# --------------------------------------------------------------------------------------------
# The tabulated kinematics used by the simulator
# --------------------------------------------------------------------------------------------

VARIANTS = ("variable", "constant_ratio")


@dataclass(frozen=True, eq=False)
class Kinematics:
    """One revolution of kinematics, tabulated from -180 deg and interpolated by periodic cubic splines.

    Attributes
    ----------
    theta : table angles [rad], ``-pi + k step``.
    values : the tabulated quantities by name: ``phi``, ``d_c``, ``RR``, ``L_fc``, ``Y_c``,
        ``Y_v_kin``, ``gamma`` and the exact derivatives ``dY_c``, ``dL_fc``, ``dphi`` [rad, m, -].
    contact, pad_centre : contact point P and pad centre C at the table angles [m] (n x 2).
    variant : ``"variable"`` (the finger follower) or ``"constant_ratio"`` (the comparison system
        of the paper's Fig. 12: the same kinematic valve lift with the rocker ratio held at RR0).
    lift : the lift law it was built from.
    coef : (n, 8) spline coefficients of ``Y_c`` and ``L_fc`` per interval (cubic, highest power
        first), the layout of the compiled simulator.
    """

    theta: np.ndarray
    values: dict
    contact: np.ndarray
    pad_centre: np.ndarray
    variant: str
    lift: Any
    coef: np.ndarray
    splines: dict = field(repr=False)

    @property
    def step(self) -> float:
        """Table step [rad]."""
        return TWO_PI / self.theta.size

    def __call__(self, name: str, theta, nu: int = 0):
        """Spline value (``nu = 0``) or derivative (``nu = 1, 2``) of a tabulated quantity at any
        cam angle [rad] (periodic)."""
        if name not in self.splines:
            raise KeyError(f"no kinematic quantity {name!r}; known: {', '.join(self.splines)}")
        u = (np.asarray(theta, dtype=float) + math.pi) % TWO_PI - math.pi
        return self.splines[name](u, nu)

    def rocker_ratio(self, theta):
        """Instantaneous rocker ratio ``RR = (L_tf + L_vf) / d_c`` (K-7c) [-]."""
        return self("RR", theta)

    def lever_arm(self, theta):
        """Lever arm of the cam force about G, ``L_fc = d_c - L_tf`` (K-7d) [m]."""
        return self("L_fc", theta)

    def cam_input(self, theta):
        """Cam input at the contact ``Y_c = d_c sin(phi)`` (K-7e) [m]."""
        return self("Y_c", theta)

    def valve_lift(self, theta):
        """Valve lift of the rigid train ``(L_tf + L_vf) sin(phi)`` (K-7f) [m]."""
        return self("Y_v_kin", theta)

    def open_interval(self, threshold: float = 1e-4) -> tuple[float, float]:
        """Cam angles [rad] where the kinematic valve lift first rises above and last falls below
        ``threshold`` [m] (0.1 mm by default)."""
        from scipy.optimize import brentq

        y = self.values["Y_v_kin"] - threshold
        above = np.flatnonzero(y > 0.0)
        if above.size == 0:
            return math.nan, math.nan
        i, j = int(above[0]), int(above[-1])
        f = lambda t: float(self.valve_lift(t)) - threshold  # noqa: E731
        a = brentq(f, self.theta[i - 1], self.theta[i], xtol=1e-13)
        b = brentq(f, self.theta[j], self.theta[j] + self.step, xtol=1e-13)
        return a, b


def build_kinematics(rig, lift=None, *, variant: str = "variable", step_deg: float = TABLE_STEP_DEG) -> Kinematics:
    """Tabulate the kinematics of one revolution and build its splines.

    Parameters
    ----------
    rig : :class:`~impactid.rigs.finger_follower.FingerFollowerRig`.
    lift : a lift law (:class:`CycloidalLift`, :class:`LiftTable`); default the rig's cycloidal law.
    variant : ``"variable"`` or ``"constant_ratio"`` (``L_fc = L_fc0``, ``Y_c = Y_v,kin / RR0``,
        ``phi = asin(Y_v,kin / L_sum)``: the rigid train still has zero deflections).
    step_deg : table step [deg]; must divide 360.

    Raises
    ------
    RigParameterError
        if the cam is not convex, or the pad cannot reach it.
    """
    if variant not in VARIANTS:
        raise ValueError(f"unknown kinematics variant {variant!r}; known: {', '.join(VARIANTS)}")
    n = int(round(360.0 / step_deg))
    if n < 360 or abs(n * step_deg - 360.0) > 1e-9:
        raise ValueError(f"step_deg must divide 360 and be at most 1 deg, got {step_deg!r}")
    lift = lift_from_rig(rig) if lift is None else lift
    check_convex(lift, rig.R_c)
    geo = base_geometry(rig)
    theta = -math.pi + TWO_PI * np.arange(n) / n
    t = _table(rig, lift, theta, geo, -math.pi)
    values = {"gamma": t["gamma"], "phi": t["phi"], "d_c": t["d_c"], "Y_c": t["Y_c"], "L_fc": t["L_fc"],
              "Y_v_kin": t["Y_v_kin"], "dY_c": t["dY_c"], "dL_fc": t["dd_c"], "dphi": t["dphi"]}
    values["RR"] = rig.L_sum / values["d_c"]
    if variant == "constant_ratio":
        yv = values["Y_v_kin"]
        values["phi"] = np.arcsin(yv / rig.L_sum)
        values["d_c"] = np.full(n, rig.d_c0)
        values["RR"] = np.full(n, rig.RR0)
        values["L_fc"] = np.full(n, rig.L_fc0)
        values["Y_c"] = yv / rig.RR0
        values["dY_c"] = rig.L_sum * np.cos(t["phi"]) * t["dphi"] / rig.RR0
        values["dL_fc"] = np.zeros(n)
        values["dphi"] = rig.L_sum * np.cos(t["phi"]) * t["dphi"] / np.sqrt(rig.L_sum**2 - yv**2)
    th_ext = np.append(theta, math.pi)
    splines = {}
    for name in ("phi", "d_c", "RR", "L_fc", "Y_c", "Y_v_kin"):
        splines[name] = CubicSpline(th_ext, np.append(values[name], values[name][0]), bc_type="periodic")
    coef = np.ascontiguousarray(np.vstack([splines["Y_c"].c, splines["L_fc"].c]).T)
    for v in values.values():
        v.flags.writeable = False
    contact = np.stack([t["Px"], t["Py"]], axis=1)
    pad = np.stack([t["Cx"], t["Cy"]], axis=1)
    return Kinematics(theta=theta, values=values, contact=contact, pad_centre=pad, variant=variant, lift=lift,
                      coef=coef, splines=splines)

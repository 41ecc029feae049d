r"""Algebraic impact laws with friction for one contact of a rigid body in the plane.

Notation (SI units): ``v`` the generalised velocity ``(v_x, v_y, omega)`` of the centre of mass
before the impact, ``M = m diag(1, 1, k_g^2)`` the mass matrix, ``J_n`` and ``J_t`` the normal and
tangential rows of the contact Jacobian, ``v_n = J_n v < 0`` (approaching) and ``v_t = J_t v`` the
contact point's velocity. An impulse ``p = (p_t, p_n)`` changes the velocity by
``M^-1 (J_t^T p_t + J_n^T p_n)`` and the contact velocity by ``W p``, with the Delassus matrix
(the inverse inertia seen at the contact)

.. math:: W = J M^{-1} J^T = \begin{pmatrix} w_{tt} & w_{tn} \\ w_{tn} & w_{nn} \end{pmatrix},
          \qquad J = \begin{pmatrix} J_t \\ J_n \end{pmatrix}.

Two rules turn the restitution ``e``, the Coulomb friction coefficient ``mu`` and the tangential
restitution ``e_t`` into the impulse (both are algebraic laws in the sense of Brach 1989 and
Chatterjee & Ruina 1998: no integration through the contact):

* ``newton`` (:func:`newton_coulomb_impulse`): Newton's kinematic restitution of the normal
  velocity, ``v_n^+ = -e v_n``; the impulse that also gives ``v_t^+ = -e_t v_t`` (with ``e_t = 0``:
  the contact point stops sliding) is used when it lies in the friction cone ``|p_t| <= mu p_n``
  (*sticking*); otherwise the contact slides, ``p_t = -s mu p_n`` against the tangential impulse
  sticking would need (``s`` its sign), and ``p_n`` still gives ``v_n^+ = -e v_n``:
  ``p_n = -(1 + e) v_n / (w_nn + s mu w_tn)`` (undefined, NaN, where the denominator is not
  positive: Painleve's paradox of rigid-body friction).
* ``chatterjee-ruina`` (:func:`chatterjee_ruina_impulse`): the impulse-space law of Chatterjee &
  Ruina (1998): the plastic sticking impulse ``P_I = -W^-1 (v_t, v_n)`` (the one that ends every
  relative motion) is scaled, ``P = ((1 + e_t) P_{I,t}, (1 + e) P_{I,n})``, and its tangential part
  is cut to the friction cone, ``|P_t| <= mu P_n``.

The restitution may depend on the approach speed ``u = -v_n`` (:data:`RESTITUTION`):
``constant`` ``e(u) = e`` or ``linear`` ``e(u) = e_0 (1 - gamma u)`` [gamma in s/m] (negative values
are clipped to 0). A law (:class:`PlanarLaw`) is a rule, a restitution and whether ``e_t`` is fitted
(``-et``) or held at 0 (``-stick``: sliding stops when friction suffices): :data:`LAWS` lists the
eight, named ``<rule>-<restitution>-<tangential>``.

Every function is vectorised over impacts (NumPy arrays of one value per impact) and pure.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

__all__ = ["LAWS", "RESTITUTION", "RULES", "ImpactOutcome", "PlanarLaw", "chatterjee_ruina_impulse",
           "contact_velocity", "delassus", "get_law", "linear_restitution", "newton_coulomb_impulse", "outcome",
           "post_velocity"]


def delassus(jt: np.ndarray, jn: np.ndarray, inverse_mass) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The Delassus matrix ``W = J M^-1 J^T`` of each impact: ``(w_tt, w_tn, w_nn)``.

    Parameters
    ----------
    jt, jn : (n, 3) tangential and normal rows of the contact Jacobian [-, -, m].
    inverse_mass : (3,) or (n, 3) the diagonal of ``M^-1`` [1/kg, 1/kg, 1/(kg m^2)].

    Returns
    -------
    w_tt, w_tn, w_nn : (n,) [1/kg].
    """
    jt, jn, minv = np.asarray(jt, float), np.asarray(jn, float), np.asarray(inverse_mass, float)
    return (np.sum(jt * jt * minv, axis=-1), np.sum(jt * jn * minv, axis=-1), np.sum(jn * jn * minv, axis=-1))


def contact_velocity(row: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The contact point's velocity along a Jacobian row: ``J v`` per impact [m/s]."""
    return np.sum(np.asarray(row, float) * np.asarray(v, float), axis=-1)


def linear_restitution(speed, e0, gamma):
    """``e(u) = e_0 (1 - gamma u)`` [-] at the approach speed ``u`` [m/s] (``gamma`` [s/m])."""
    return e0 * (1.0 - gamma * np.asarray(speed, float))


#: Restitution laws by name: parameter names, units and the function ``e(u, *parameters)``.
RESTITUTION = {
    "constant": (("e",), ("",), lambda speed, e: np.full(np.shape(speed), float(e))),
    "linear": (("e0", "gamma"), ("", "s/m"), linear_restitution),
}


def newton_coulomb_impulse(vt, vn, w_tt, w_tn, w_nn, e, mu, e_t=0.0):
    """Newton's restitution with Coulomb friction and sticking (module doc, rule ``newton``).

    Parameters
    ----------
    vt, vn : (n,) tangential and normal contact velocity before the impact [m/s] (``vn < 0``).
    w_tt, w_tn, w_nn : (n,) the Delassus matrix [1/kg] (:func:`delassus`).
    e : restitution [-] (a number or one per impact), ``v_n^+ = -e v_n``.
    mu : Coulomb friction coefficient [-], >= 0.
    e_t : tangential restitution [-] in [-1, 1]: sticking ends at ``v_t^+ = -e_t v_t``.

    Returns
    -------
    p_t, p_n : (n,) the impulse [N s] (0 where the contact does not approach, ``vn >= 0``; NaN where
        sliding has no solution, Painleve's paradox).
    sticking : (n,) bool, whether the impulse lies inside the friction cone.
    """
    vt, vn = np.asarray(vt, float), np.asarray(vn, float)
    e = np.clip(np.broadcast_to(np.asarray(e, float), vn.shape), 0.0, None)
    dvt, dvn = -(1.0 + e_t) * vt, -(1.0 + e) * vn
    det = w_tt * w_nn - w_tn * w_tn
    pt_stick = (w_nn * dvt - w_tn * dvn) / det
    pn_stick = (w_tt * dvn - w_tn * dvt) / det
    sticking = (pn_stick >= 0.0) & (np.abs(pt_stick) <= mu * pn_stick)
    direction = np.where(pt_stick >= 0.0, 1.0, -1.0)
    denominator = w_nn + direction * mu * w_tn
    with np.errstate(divide="ignore", invalid="ignore"):
        pn_slide = np.where(denominator > 0.0, dvn / denominator, np.nan)
    pt = np.where(sticking, pt_stick, direction * mu * pn_slide)
    pn = np.where(sticking, pn_stick, pn_slide)
    approach = vn < 0.0
    return np.where(approach, pt, 0.0), np.where(approach, pn, 0.0), sticking & approach


def chatterjee_ruina_impulse(vt, vn, w_tt, w_tn, w_nn, e, mu, e_t=0.0):
    """The impulse-space law of Chatterjee & Ruina (1998) (module doc, rule ``chatterjee-ruina``).

    Parameters and returns as :func:`newton_coulomb_impulse`; ``e`` scales the normal part of the
    plastic sticking impulse, ``1 + e_t`` its tangential part.
    """
    vt, vn = np.asarray(vt, float), np.asarray(vn, float)
    e = np.clip(np.broadcast_to(np.asarray(e, float), vn.shape), 0.0, None)
    det = w_tt * w_nn - w_tn * w_tn
    pi_t = -(w_nn * vt - w_tn * vn) / det
    pi_n = -(w_tt * vn - w_tn * vt) / det
    pn = np.clip((1.0 + e) * pi_n, 0.0, None)
    pt_hat = (1.0 + e_t) * pi_t
    limit = mu * pn
    sticking = np.abs(pt_hat) <= limit
    pt = np.clip(pt_hat, -limit, limit)
    approach = vn < 0.0
    return np.where(approach, pt, 0.0), np.where(approach, pn, 0.0), sticking & approach


#: The impulse rules by name.
RULES = {"newton": newton_coulomb_impulse, "chatterjee-ruina": chatterjee_ruina_impulse}


def post_velocity(v_pre, jt, jn, inverse_mass, p_t, p_n) -> np.ndarray:
    """The velocity after the impulse: ``v + M^-1 (J_t^T p_t + J_n^T p_n)`` (n, 3) [m/s, m/s, rad/s]."""
    return (np.asarray(v_pre, float) + np.asarray(inverse_mass, float)
            * (np.asarray(jt, float) * np.asarray(p_t, float)[:, None]
               + np.asarray(jn, float) * np.asarray(p_n, float)[:, None]))


@dataclass(frozen=True)
class ImpactOutcome:
    """What a law predicts for each impact (arrays of one value per impact).

    Attributes
    ----------
    vt, vn : contact velocity before the impact [m/s].
    restitution : ``e`` at each impact's approach speed [-].
    p_t, p_n : the impulse [N s].
    v_post : (n, 3) velocity after the impact [m/s, m/s, rad/s].
    sticking : whether the impulse lies inside the friction cone.
    """

    vt: np.ndarray
    vn: np.ndarray
    restitution: np.ndarray
    p_t: np.ndarray
    p_n: np.ndarray
    v_post: np.ndarray
    sticking: np.ndarray


@dataclass(frozen=True)
class PlanarLaw:
    """An impact law: a rule (:data:`RULES`), a restitution (:data:`RESTITUTION`) and whether the
    tangential restitution ``e_t`` is a parameter (True) or 0.

    ``names`` are its parameters: the restitution's, then ``mu``, then ``e_t`` when fitted.
    """

    rule: str
    restitution: str
    tangential: bool

    def __post_init__(self) -> None:
        if self.rule not in RULES:
            raise ValueError(f"unknown impact rule {self.rule!r}; rules: {', '.join(RULES)}")
        if self.restitution not in RESTITUTION:
            raise ValueError(f"unknown restitution {self.restitution!r}; laws: {', '.join(RESTITUTION)}")

    @property
    def name(self) -> str:
        return f"{self.rule}-{self.restitution}-{'et' if self.tangential else 'stick'}"

    @property
    def names(self) -> tuple[str, ...]:
        return RESTITUTION[self.restitution][0] + ("mu",) + (("e_t",) if self.tangential else ())

    @property
    def units(self) -> tuple[str, ...]:
        return RESTITUTION[self.restitution][1] + ("",) + (("",) if self.tangential else ())

    @property
    def formula(self) -> str:
        e = "e" if self.restitution == "constant" else "e0 (1 - gamma u)"
        tangential = "-e_t v_t" if self.tangential else "0"
        if self.rule == "newton":
            return (f"v_n+ = -({e}) v_n; v_t+ = {tangential} if |p_t| <= mu p_n, else p_t = -s mu p_n "
                    "(Newton restitution, Coulomb friction with sticking)")
        return (f"p = ((1 + e_t) P_I,t, (1 + {e}) P_I,n), P_I = -W^-1 (v_t, v_n), |p_t| cut to mu p_n "
                f"(Chatterjee & Ruina 1998{'' if self.tangential else ', e_t = 0'})")

    def outcome(self, values: Mapping[str, float], v_pre, jt, jn, inverse_mass) -> ImpactOutcome:
        """The impulse and the post-impact velocity of each impact for the parameters ``values``."""
        return outcome(self, values, v_pre, jt, jn, inverse_mass)


def outcome(law: PlanarLaw, values: Mapping[str, float], v_pre, jt, jn, inverse_mass) -> ImpactOutcome:
    """What ``law`` with the parameters ``values`` (by name) predicts for each impact.

    Parameters
    ----------
    law : the law.
    values : its parameters by name (``e`` or ``e0``, ``gamma``; ``mu``; ``e_t``).
    v_pre : (n, 3) velocity before the impact [m/s, m/s, rad/s].
    jt, jn : (n, 3) the contact Jacobian's rows.
    inverse_mass : (3,) the diagonal of ``M^-1``.
    """
    missing = [n for n in law.names if n not in values]
    if missing:
        raise ValueError(f"law {law.name!r} needs parameter(s) {', '.join(missing)}")
    vt, vn = contact_velocity(jt, v_pre), contact_velocity(jn, v_pre)
    names, _, function = RESTITUTION[law.restitution]
    e = np.clip(function(-vn, *(values[n] for n in names)), 0.0, None)
    w_tt, w_tn, w_nn = delassus(jt, jn, inverse_mass)
    e_t = float(values.get("e_t", 0.0)) if law.tangential else 0.0
    p_t, p_n, sticking = RULES[law.rule](vt, vn, w_tt, w_tn, w_nn, e, float(values["mu"]), e_t)
    return ImpactOutcome(vt, vn, e, p_t, p_n, post_velocity(v_pre, jt, jn, inverse_mass, p_t, p_n), sticking)


#: The laws by name, ``<rule>-<restitution>-<tangential>``.
LAWS = {law.name: law for law in (PlanarLaw(rule, restitution, tangential) for rule, restitution, tangential
                                  in itertools.product(RULES, RESTITUTION, (False, True)))}


def get_law(law: str | PlanarLaw) -> PlanarLaw:
    """A law by name (:data:`LAWS`), or the law itself; an unknown name raises ValueError listing them."""
    if isinstance(law, PlanarLaw):
        return law
    try:
        return LAWS[law]
    except KeyError:
        raise ValueError(f"unknown planar impact law {law!r}; laws: {', '.join(LAWS)}") from None



"""The table-tennis rule as a check on measured restitution: a ball dropped from 30.5 cm onto the
table must rebound 22 to 25 cm (heights of the ball's bottom above the table, so of its centre's
fall and rise). Through an air model the rule becomes a band of normal restitution at the impact
speed of that drop (about 2.4 m/s): the ball falls with drag (and buoyancy, added mass) to its
impact speed ``v_i``; a restitution ``e`` launches it at ``e v_i``, and it rises with drag to an apex;
the band is the ``e`` whose apexes are 22 and 25 cm. In vacuum ``e = sqrt(h / H)``: 0.849-0.905.
Each flight is a :func:`scipy.integrate.solve_ivp` (DOP853, rtol 1e-12) ended by an event; the
band's ends by Brent's method.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from scipy import integrate, optimize

from impactid.rigs.tracks.parameters import DRAG_RANGE, TrackedBall

__all__ = ["DROP_HEIGHT", "REBOUND_HEIGHTS", "RuleBand", "apex_height", "impact_speed", "rule_band"]

#: The rule's drop height [m] and rebound heights [m].
DROP_HEIGHT = 0.305
REBOUND_HEIGHTS = (0.22, 0.25)


@dataclass(frozen=True)
class RuleBand:
    """The normal restitution the rule allows through one air model.

    Attributes
    ----------
    impact_speed : of the drop [m/s].
    low, high : the restitution of a 22 cm and of a 25 cm rebound [-].
    vacuum : the band without air ``sqrt(h / H)`` [-].
    drag_coefficient : of the air model.
    drag_range : the band's ends over :data:`~impactid.rigs.tracks.parameters.DRAG_RANGE`
        (``(low at the lowest C_D, high at the highest)``).
    """

    impact_speed: float
    low: float
    high: float
    vacuum: tuple[float, float]
    drag_coefficient: float
    drag_range: tuple[float, float]

    def to_dict(self) -> dict:
        return {"drop_height_m": DROP_HEIGHT, "rebound_heights_m": list(REBOUND_HEIGHTS),
                "impact_speed_m_s": self.impact_speed, "e_low": self.low, "e_high": self.high,
                "vacuum": list(self.vacuum), "drag_coefficient": self.drag_coefficient,
                "drag_range": list(DRAG_RANGE), "band_over_drag_range": list(self.drag_range)}


def _rhs(ball: TrackedBall):
    def rhs(_t, y):
        return [y[1], -ball.net_gravity - ball.drag_rate * abs(y[1]) * y[1]]
    return rhs


def impact_speed(ball: TrackedBall, height: float = DROP_HEIGHT) -> float:
    """The speed [m/s] of a ball released at rest whose centre falls ``height`` [m]."""
    def ground(_t, y):
        return y[0]
    ground.terminal, ground.direction = True, -1
    sol = integrate.solve_ivp(_rhs(ball), (0.0, 10.0), [height, 0.0], method="DOP853", rtol=1e-12, atol=1e-14,
                              events=ground)
    return float(-sol.y_events[0][0][1])


def apex_height(ball: TrackedBall, speed: float) -> float:
    """The rise [m] of a ball launched straight up at ``speed`` [m/s]."""
    if speed <= 0.0:
        return 0.0

    def top(_t, y):
        return y[1]
    top.terminal, top.direction = True, -1
    sol = integrate.solve_ivp(_rhs(ball), (0.0, 10.0), [0.0, speed], method="DOP853", rtol=1e-12, atol=1e-14,
                              events=top)
    return float(sol.y_events[0][0][0])


def _band(ball: TrackedBall) -> tuple[float, float, float]:
    v = impact_speed(ball)
    ends = [optimize.brentq(lambda e, h=h: apex_height(ball, e * v) - h, 0.3, 1.5, xtol=1e-12)
            for h in REBOUND_HEIGHTS]
    return v, ends[0], ends[1]


def rule_band(ball: TrackedBall) -> RuleBand:
    """The rule's band of normal restitution through ``ball``'s air model (module doc)."""
    v, low, high = _band(ball)
    lo_cd = _band(ball.with_(drag_coefficient=DRAG_RANGE[0]))[1]
    hi_cd = _band(ball.with_(drag_coefficient=DRAG_RANGE[1]))[2]
    vacuum = tuple(math.sqrt(h / DROP_HEIGHT) for h in REBOUND_HEIGHTS)
    return RuleBand(impact_speed=v, low=low, high=high, vacuum=vacuum, drag_coefficient=ball.drag_coefficient,
                    drag_range=(min(lo_cd, low), max(hi_cd, high)))

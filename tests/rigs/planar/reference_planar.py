"""An independent reference of the Newton-Coulomb impact law, written from the complementarity
conditions alone with plain SciPy (no impactid physics).

For each impact the impulse ``(p_t, p_n)`` solves

    minimise   (v_t^+ + e_t v_t)^2
    subject to v_n^+ = -e v_n               (Newton's restitution)
               -mu p_n <= p_t <= mu p_n     (Coulomb's friction cone)

with ``v^+ = v + M^-1 (J_t^T p_t + J_n^T p_n)``: sticking (``v_t^+ = -e_t v_t``) where the cone
allows it, else the sliding impulse on the cone's edge closest to it. Solved by SLSQP.
"""

from __future__ import annotations

import numpy as np
from scipy import optimize


def reference_impulse(v, jt, jn, inverse_mass, e, mu, e_t):
    """``(p_t, p_n)`` of one impact (``v``, ``jt``, ``jn``, ``inverse_mass``: 3-vectors)."""
    v, jt, jn, minv = (np.asarray(a, float) for a in (v, jt, jn, inverse_mass))

    def post(p):
        return v + minv * (jt * p[0] + jn * p[1])

    vt, vn = jt @ v, jn @ v
    scale = abs(vn) / (jn @ (minv * jn))  # impulse scale [N s]

    def objective(x):
        return ((jt @ post(x * scale) + e_t * vt) / abs(vn)) ** 2

    constraints = [{"type": "eq", "fun": lambda x: (jn @ post(x * scale) + e * vn) / abs(vn)},
                   {"type": "ineq", "fun": lambda x: mu * x[1] - x[0]},
                   {"type": "ineq", "fun": lambda x: mu * x[1] + x[0]}]
    best = None
    for start in ([0.0, 1.0 + e], [mu * (1.0 + e), 1.0 + e], [-mu * (1.0 + e), 1.0 + e]):
        sol = optimize.minimize(objective, start, method="SLSQP", constraints=constraints,
                                options={"ftol": 1e-16, "maxiter": 500})
        if best is None or sol.fun < best.fun:
            best = sol
    return best.x * scale


def reference_impulses(v, jt, jn, inverse_mass, e, mu, e_t):
    """Impulses ``(n, 2)`` of ``n`` impacts; ``e`` one per impact."""
    e = np.broadcast_to(np.asarray(e, float), (len(v),))
    return np.array([reference_impulse(v[i], jt[i], jn[i], inverse_mass, e[i], mu, e_t) for i in range(len(v))])


def random_impacts(n, seed, *, lever=0.03):
    """Pre-impact velocities and Jacobians of a body like an ellipse dropped on a floor: ``jn = (0, 1, r_x)``,
    ``jt = (1, 0, d)`` with a lever ``r_x`` of a few mm and a depth ``d`` of 25-35 mm, approach speeds of
    1.5-3.5 m/s and a sliding speed of either sign."""
    rng = np.random.default_rng(seed)
    jn = np.stack([np.zeros(n), np.ones(n), rng.uniform(-0.3, 0.3, n) * lever], axis=1)
    jt = np.stack([np.ones(n), np.zeros(n), rng.uniform(0.8, 1.2, n) * lever], axis=1)
    v = np.stack([rng.uniform(-1.0, 1.0, n), -rng.uniform(1.5, 3.5, n), rng.uniform(-15.0, 15.0, n)], axis=1)
    return v, jt, jn


def write_table(path, v, jt, jn, impulse=None, v_post=None, extra=None):
    """A table of impacts in the layout of docs/formats.md (``extra``: more columns by name)."""
    import pandas as pd

    n = len(v)
    data = {"impact": np.arange(1, n + 1), "x_pre": np.zeros(n), "y_pre": np.full(n, 0.03), "theta_pre": np.zeros(n),
            "vx_pre": v[:, 0], "vy_pre": v[:, 1], "omega_pre": v[:, 2],
            **{f"jn_{c}": jn[:, i] for i, c in enumerate(("x", "y", "theta"))},
            **{f"jt_{c}": jt[:, i] for i, c in enumerate(("x", "y", "theta"))}}
    if v_post is not None:
        data.update({"x_post": np.zeros(n), "y_post": np.full(n, 0.03), "theta_post": np.zeros(n),
                     "vx_post": v_post[:, 0], "vy_post": v_post[:, 1], "omega_post": v_post[:, 2]})
    if impulse is not None:
        data.update({"impulse_t": impulse[:, 0], "impulse_n": impulse[:, 1]})
    data.update(extra or {})
    pd.DataFrame(data).to_csv(path, index=False, float_format="%.12g")
    return path

"""Independent reference of the single-impact test rig: plain NumPy/SciPy (``solve_ivp``), written from
the specification, importing nothing of impactid's physics.

Specification: one degree of freedom ``x`` [m], positive into the contact (0 at first touch),
``v = dx/dt``; ``m x'' = m g - F`` with ``F = max(k x^p + beta x^n v, 0)`` for ``x > 0`` and 0 for
``x <= 0``. An accelerometer on the impactor reads ``F/m`` (the specific force away from the
contact), a load cell under the contact reads ``F``.

The run alternates flight and contact phases, each a ``solve_ivp`` (DOP853) call ended by terminal
events: flight ends when ``x`` rises through 0 (onset), or, inside the contact region with the force
clipped, when the unclipped force ``k x^p + beta x^n v`` rises through 0 (re-contact); contact ends
when the unclipped force falls through 0 or ``x`` falls through 0. During contact the force law is
continued past ``x = 0`` as ``k sgn(x)|x|^p + beta |x|^n v`` so that the integrator's trial steps
past an event see a smooth function. Peak force and largest penetration are found on the dense
output with a bounded scalar minimisation.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import minimize_scalar


def force_unclipped(x, v, k, p, beta, n):
    """``k sgn(x)|x|^p + beta |x|^n v`` [N]."""
    ax = abs(x)
    return math.copysign(k * ax**p, x) + beta * ax**n * v


def force(x, v, k, p, beta, n):
    """The physical force [N] (arrays allowed)."""
    x = np.asarray(x, dtype=float)
    v = np.asarray(v, dtype=float)
    xp = np.where(x > 0.0, x, 0.0)
    f = k * xp**p + beta * xp**n * v
    return np.where((x > 0.0) & (f > 0.0), f, 0.0)


def simulate(m, g, k, p, beta, n, x0, v0, t_end, t_eval=None, rtol=1e-12, atol=(1e-16, 1e-12), max_phases=200):
    """Reference run from ``(x0, v0)`` at t = 0 to ``t_end``.

    Returns a dict: ``impacts`` (list of dicts: t_onset, v_onset, t_end, v_end, x_end, peak_force,
    t_peak_force, max_penetration), and, with ``t_eval``, ``x``, ``v``, ``force`` there.
    """
    t_eval = np.zeros(0) if t_eval is None else np.asarray(t_eval, dtype=float)
    out_x = np.full(t_eval.size, np.nan)
    out_v = np.full(t_eval.size, np.nan)

    def rhs_free(t, y):
        return [y[1], g]

    def rhs_contact(t, y):
        return [y[1], g - force_unclipped(y[0], y[1], k, p, beta, n) / m]

    def ev_onset(t, y):
        return y[0]
    ev_onset.terminal, ev_onset.direction = True, 1.0

    def ev_recontact(t, y):
        return force_unclipped(y[0], y[1], k, p, beta, n)
    ev_recontact.terminal, ev_recontact.direction = True, 1.0

    def ev_force(t, y):
        return force_unclipped(y[0], y[1], k, p, beta, n)
    ev_force.terminal, ev_force.direction = True, -1.0

    def ev_exit(t, y):
        return y[0]
    ev_exit.terminal, ev_exit.direction = True, -1.0

    t, x, v = 0.0, float(x0), float(v0)
    contact = x > 0.0 and force_unclipped(x, v, k, p, beta, n) > 0.0 or (x == 0.0 and v > 0.0)
    impacts = []
    current = None
    if contact:
        current = {"t_onset": t, "v_onset": v}
    for _ in range(max_phases):
        if t >= t_end:
            break
        if contact:
            sol = solve_ivp(rhs_contact, (t, t_end), [x, v], method="DOP853", rtol=rtol, atol=atol,
                            events=[ev_force, ev_exit], dense_output=True, max_step=2e-5)
        else:
            inside_contact = x > 0.0  # the force clipped after a separation: re-contact, or exit
            events = [ev_recontact, ev_exit] if inside_contact else [ev_onset]
            sol = solve_ivp(rhs_free, (t, t_end), [x, v], method="DOP853", rtol=rtol, atol=atol,
                            events=events, dense_output=True, max_step=2e-5 if inside_contact else np.inf)
        hits = [(te[0], i) for i, te in enumerate(sol.t_events) if te.size]
        t_stop = min(hits)[0] if hits else sol.t[-1]
        inside = (t_eval >= t) & (t_eval <= t_stop)
        if inside.any():
            y = sol.sol(t_eval[inside])
            out_x[inside] = y[0]
            out_v[inside] = y[1]
        if contact:
            # peak force and largest penetration of this phase on the dense output
            grid = np.linspace(t, t_stop, 2001)
            y = sol.sol(grid)
            f = force(y[0], y[1], k, p, beta, n)
            j = int(np.argmax(f))
            lo, hi = grid[max(j - 1, 0)], grid[min(j + 1, grid.size - 1)]
            dense = sol.sol
            res = minimize_scalar(lambda s, dense=dense: -float(force(*dense(s), k, p, beta, n)), bounds=(lo, hi),
                                  method="bounded", options={"xatol": 1e-15})
            current["peak_force"] = -res.fun
            current["t_peak_force"] = res.x
            j = int(np.argmax(y[0]))
            lo, hi = grid[max(j - 1, 0)], grid[min(j + 1, grid.size - 1)]
            res = minimize_scalar(lambda s, dense=dense: -float(dense(s)[0]), bounds=(lo, hi), method="bounded",
                                  options={"xatol": 1e-15})
            current["max_penetration"] = -res.fun
        if not hits:
            if contact:
                impacts.append(current)
            break
        t_stop, which = min(hits)
        y_stop = sol.y_events[which][0]
        t, x, v = float(t_stop), float(y_stop[0]), float(y_stop[1])
        if contact:
            # where it separates: inside the contact region (the force reached 0 first) or at the surface
            # (for n >= p both switching functions vanish together there)
            current.update(t_end=t, v_end=v, x_end=max(x, 0.0), end="force" if x > 1e-12 else "surface")
            impacts.append(current)
            current = None
            contact = False
            if which == 1:
                x = 0.0
        elif inside_contact and which == 1:
            x = 0.0  # left the contact region without force: a flight follows
        else:
            contact = True
            if not inside_contact:
                x = 0.0
            current = {"t_onset": t, "v_onset": v, "kind": "re-contact" if inside_contact else "onset"}
    result = {"impacts": impacts}
    if t_eval.size:
        result.update(x=out_x, v=out_v, force=force(out_x, out_v, k, p, beta, n))
    return result


def drop_signals(m, g, k, p, beta, n, height, sample_rate_hz, duration, pre_trigger, release_speed=0.0):
    """Exact accelerometer (``F/m``) and force samples of a drop from ``height``, recorded from
    ``pre_trigger`` seconds before the first onset for ``duration`` seconds (time 0 at release).

    Returns ``(t0, acceleration, force, impacts)``: the first sample's time and the signals."""
    v1 = math.sqrt(release_speed**2 + 2.0 * g * height)
    t_onset = (v1 - release_speed) / g
    t0 = max(t_onset - pre_trigger, 0.0)
    t0 = math.floor(t0 * sample_rate_hz) / sample_rate_hz
    samples = int(round(duration * sample_rate_hz))
    t = t0 + np.arange(samples) / sample_rate_hz
    run = simulate(m, g, k, p, beta, n, -height, release_speed, t[-1] + 1.0 / sample_rate_hz, t_eval=t)
    return t0, run["force"] / m, run["force"], run["impacts"]


def reference_recording(rig, beta, n, height, *, sample_rate_hz=51_200.0, duration=0.5, pre_trigger=0.01,
                        noise=0.0, seed=0, channels=("impactor_acceleration", "contact_force")):
    """A drop recording made by this reference (not by impactid's kernel): the exact signals sampled,
    then impactid's generic sensor chain (Gaussian noise, ``noise`` of each channel's peak), as an
    impactid Recording with the rig and the drop height in its operating point. Only the container,
    the rig dataclass and the sensor chain are impactid's."""
    from impactid.io import Recording
    from impactid.synth.sensors import SensorModel, apply_sensors

    t0, accel, force_, impacts = drop_signals(rig.mass, rig.gravity, rig.k, rig.p, beta, n, height, sample_rate_hz,
                                              duration, pre_trigger)
    clean = {"impactor_acceleration": accel, "contact_force": force_}
    clean = {c: clean[c] for c in channels}
    measured, _ = apply_sensors(clean, sample_rate_hz, SensorModel(noise=noise, seed=seed))
    units = {"impactor_acceleration": "m/s^2", "contact_force": "N"}
    recording = Recording(channels=measured, sample_rate_hz=sample_rate_hz, units={c: units[c] for c in channels},
                          rig=rig, operating={"drop_height_m": height, "release_speed_m_s": 0.0}, start_time_s=t0,
                          source=f"reference drop from {height:g} m")
    return recording, impacts

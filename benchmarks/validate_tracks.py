"""Validation of bounces from ball tracks: synthetic coverage and the real table-tennis trajectories.

    python benchmarks/validate_tracks.py --out docs/validation_tracks.md [--real-data DIR] [--seeds 60]

Synthetic part (always): single bounces of a spinning table-tennis ball made by the independent
reference of the tests (``tests/rigs/tracks/reference_tracks.py``: ``solve_ivp`` flights with drag and
Magnus, a rigid impact with Coulomb friction and sticking), sampled at 143 or 240 Hz with 2 mm of
position noise; the coverage of the 95 % intervals of ``e_n`` and ``beta_t`` over ``--seeds`` bounces.

Real part (with ``--real-data``, the folder holding ``spindoe/``: the trajectories of Gossard et al.
2023, one bounce of a table-tennis ball in most, the spin measured by the authors): every track is
read and analysed (``impactid tracks analyse``: the lift scale estimated, the table's plane estimated,
the air model's share stated); the page gives how many bounces were analysed and why the others were
not, checks that every interior minimum of the height within 5 cm of the table with five samples of
flight on each side was found, tabulates each bounce's values with their statistical interval and the
interval with the air model's share, the laws and their comparison, the table-tennis rule's band
through the same air model, what the tilt of the surface, the published lift and the side of the
measured spin do, and draws ``docs/figures/tracks_*.png``.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from impactid._files import StagedFiles  # noqa: E402
from impactid.results import FitResult  # noqa: E402
from impactid.rigs.tracks import TABLE_TENNIS_BALL, Track, air_model_share, analyse_tracks, find_bounces  # noqa: E402
from impactid.rigs.tracks.bounces import fit_bounce, tracking_noise  # noqa: E402
from impactid.rigs.tracks.figures import track_figure  # noqa: E402
from impactid.rigs.tracks.laws import fit_normal_law  # noqa: E402
from impactid.rigs.tracks.parameters import DRAG_RANGE, LIFT_MODEL, lift_over_spin  # noqa: E402
from impactid.rigs.tracks.readers import is_spin_index, read_track  # noqa: E402
from impactid.rigs.tracks.synth import synth_track  # noqa: E402
from tests.rigs.tracks.reference_tracks import bouncing_track  # noqa: E402

#: The lean of the synthetic frames and tables of the tilt checks [m/m] (the SpinDOE contact plane's slope along y).
LEAN = 0.0078


def _f(value, fmt=".3f") -> str:
    return "–" if value is None or not math.isfinite(float(value)) else format(float(value), fmt)


def synthetic(seeds: int) -> list[str]:
    rng = np.random.default_rng(0)
    hits_e = hits_b = n = 0
    se = []
    for seed in range(seeds):
        spin = rng.uniform(-250, 250, 3)
        v0 = np.array([rng.uniform(-0.5, 0.5), rng.uniform(-8, -4), rng.uniform(-2, -0.5)])
        times, pos, truth = bouncing_track(np.array([0.0, 0.9, 0.25]), v0, spin, e_n=0.9, mu=0.25, duration=0.3,
                                           rate=(143.0, 240.0)[seed % 2], noise=2e-3, seed=seed, bounces=1)
        track = Track("synthetic", times, pos, 3, tuple(spin))
        cands = [c for c in find_bounces(track) if not c.reason]
        if len(cands) != 1:
            continue
        fit = fit_bounce(track, cands[0], TABLE_TENNIS_BALL, noise=tracking_noise(track, cands))
        _, v_in, v_out, _, _ = truth[0]
        beta = (v_out[:2] @ v_in[:2]) / (v_in[:2] @ v_in[:2])
        n += 1
        hits_e += fit["e_n"].contains(-v_out[2] / v_in[2])
        hits_b += fit["beta_t"].contains(beta)
        se.append(fit["e_n"].stderr)
    return ["## Synthetic bounces: coverage", "",
            f"{n} single bounces from the independent reference (`tests/rigs/tracks/reference_tracks.py`: "
            "`solve_ivp` flights with drag C_D 0.45 and the published lift of Sawicki, Hubbard & Stronge (2003), "
            "spins of up to 250 rad/s in each axis, a "
            "rigid impact with e_n 0.9 and Coulomb friction 0.25 with sticking), sampled at 143 or 240 Hz with "
            "2 mm of position noise, each fitted alone.", "",
            "| quantity | coverage of the 95 % interval | median standard error |", "|---|---|---|",
            f"| e_n | {hits_e}/{n} ({100 * hits_e / max(n, 1):.0f} %) | {np.median(se):.4f} |",
            f"| beta_t | {hits_b}/{n} ({100 * hits_b / max(n, 1):.0f} %) | |", ""]


#: The multi-bounce scenarios: (label, dimensions, release spin [rad/s], horizontal speed [m/s], mu, spin given).
SCENARIOS = (
    ("2-D, no spin, estimated; slides then sticks", 2, (0.0, 0.0, 0.0), 4.0, 0.25, False),
    ("2-D, backspin 150 rad/s given; slides", 2, (0.0, -150.0, 0.0), 3.0, 0.15, True),
    ("2-D, topspin 100 rad/s given; sticks", 2, (0.0, 100.0, 0.0), 3.0, 0.4, True),
    ("3-D, spin (50, -100, 30) given; slides then sticks", 3, (50.0, -100.0, 30.0), 4.0, 0.25, True),
    ("3-D, spin (80, -120, 0) estimated; slides", 3, (80.0, -120.0, 0.0), 5.0, 0.15, False),
    ("3-D, no spin, estimated; sticks", 3, (0.0, 0.0, 0.0), 2.0, 0.4, False),
)


def multi_bounce(seeds: int) -> list[str]:
    """Coverage of mu, beta_t, e_n and the incoming spins on synthetic tracks of three bounces (the rig's own
    synthesiser, 240 fps, 1 mm of noise), each track analysed alone with the spins of its later bounces
    propagated."""
    rows = []
    for label, dims, spin, speed, mu, given in SCENARIOS:
        hit_mu = det_mu = 0
        hits = {"e_n": 0, "beta_t": 0, "spin": 0}
        bounces = spin_n = slides = 0
        widths = []
        for seed in range(seeds):
            s = synth_track(horizontal_speed=speed, spin=spin, dimensions=dims, mu=mu, bounces=3, seed=seed,
                            frame_rate=240.0, noise=1e-3)
            track = Track("synthetic", s.time, s.position, dims, tuple(spin) if given else None)
            result = analyse_tracks([track], rule=False, air_share=False)
            p = result["tangential.coulomb.mu"]
            hit_mu += p.contains(mu)
            if math.isfinite(p.interval[1]):
                det_mu += 1
                widths.append(p.interval[1] / p.interval[0])
            table = result.bounces[result.bounces["analysed"]]
            for row in table.itertuples():
                k = int(np.argmin(np.abs(s.impact_times - row.t_c_s)))
                v_in, v_out = s.velocity_in[k], s.velocity_out[k]
                beta = (v_out[:2] @ v_in[:2]) / (v_in[:2] @ v_in[:2])
                bounces += 1
                slides += not s.sticking[k]
                hits["e_n"] += row.e_n_low <= s.restitution[k] <= row.e_n_high
                hits["beta_t"] += row.beta_t_low <= beta <= row.beta_t_high
                if row.spin_source != "given":
                    spin_n += 1
                    axes = "y" if dims == 2 else "xyz"
                    ok = True
                    for axis in axes:
                        j = "xyz".index(axis)
                        se = getattr(row, f"spin_in_{axis}_rad_s_stderr")
                        ok &= abs(getattr(row, f"spin_in_{axis}_rad_s") - s.spin_in[k, j]) <= 1.96 * se
                    hits["spin"] += ok
        rows.append(f"| {label} | {mu:g} | {bounces} ({slides} slide) | {hit_mu}/{seeds}"
                    + (f" ({seeds - det_mu} bounded below only)" if det_mu < seeds else "")
                    + f" | {_f(np.median(widths) if widths else math.nan, '.2f')} | {hits['beta_t']}/{bounces} | "
                    f"{hits['e_n']}/{bounces} | {hits['spin']}/{spin_n} |")
    return ["## Synthetic tracks of several bounces: the spin carried from bounce to bounce", "",
            f"Tracks of three bounces from the rig's synthesiser (`impactid synth --rig tracked-ball`: 240 fps, 1 mm "
            f"of position noise, e_n 0.9, Coulomb friction mu with sticking), {seeds} seeds per scenario, each track "
            "analysed alone (`analyse_tracks`, no air model's share). The first bounce's incoming spin is given (the "
            "release spin, the track's measured spin) or estimated from the flights' Magnus curvature; the later "
            "bounces' spins are propagated (the previous bounce's incoming spin plus R P_t / I). The mu interval joins "
            "the delta method's with the profile likelihood's; it is open above ('bounded below only') when every "
            "bounce may stick within the scatter. The median upper/lower ratio is over the closed intervals. "
            "The spin column counts the "
            "propagated and estimated incoming spins whose every component lies within 1.96 standard errors.", "",
            "| scenario | mu | bounces | mu covered | median upper/lower of mu | beta_t covered | e_n covered | "
            "spin_in covered |", "|---|---|---|---|---|---|---|---|", *rows, ""]


def _lean_tracks(case: str, count: int, lift_scale: float) -> list[Track]:
    """SpinDOE-like tracks (143 Hz, 1 mm of noise, the balls along -y at 4-9 m/s, spins of 50-350 rad/s, e_n 0.9)
    bouncing on a level table seen from a level frame (``level``), on a table rising by LEAN along y
    (``table``), on a level table seen from a frame rotated by atan(LEAN) about x (``rotated``: gravity leans
    in the frame) or through a shear of the heights by LEAN along y (``shear``: a tracking error)."""
    rng = np.random.default_rng(100)
    c, s = math.cos(math.atan(LEAN)), math.sin(math.atan(LEAN))
    turn = np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
    tracks = []
    for k in range(count):
        spin = rng.normal(0.0, 1.0, 3)
        spin *= rng.uniform(50.0, 350.0) / np.linalg.norm(spin)
        p0 = np.array([rng.uniform(-0.4, 0.4), rng.uniform(0.8, 2.2), rng.uniform(0.15, 0.35)])
        v0 = np.array([rng.uniform(-0.6, 0.6), rng.uniform(-9.0, -4.0), rng.uniform(-1.5, 0.5)])
        times, pos, _ = bouncing_track(p0, v0, spin, e_n=0.9, mu=0.25, surface=-0.027, duration=0.5, rate=143.0,
                                       lift_scale=lift_scale, seed=k, bounces=1,
                                       slope=(0.0, LEAN) if case == "table" else (0.0, 0.0))
        if case == "rotated":
            pos = pos @ turn.T
        elif case == "shear":
            pos[:, 2] += LEAN * pos[:, 1]
        tracks.append(Track(f"{case}{k}", times, pos + 1e-3 * rng.standard_normal(pos.shape), 3, tuple(spin)))
    return tracks


def _flight_windows(tracks, spins, span: int = 15, gap: int = 3) -> list[tuple]:
    """Cubics through ``span`` samples of free flight (none within ``gap`` samples of a minimum of the height):
    the velocity, the acceleration and its standard error at each window's middle, and the flight's spin
    (``spins[(track source, segment)]``; windows of a segment without a spin are left out)."""
    out = []
    for track in tracks:
        minima = [c.index for c in find_bounces(track)]
        edges = [-gap - 1, *minima, track.time.size + gap]
        for seg in range(len(edges) - 1):
            spin = spins.get((track.source, seg))
            if spin is None or not np.all(np.isfinite(spin)):
                continue
            for k in range(edges[seg] + gap + 1, edges[seg + 1] - gap - span + 1, span):
                tt = track.time[k:k + span] - np.mean(track.time[k:k + span])
                design = np.vander(tt, 4)
                coef, *_ = np.linalg.lstsq(design, track.position[k:k + span], rcond=None)
                res = track.position[k:k + span] - design @ coef
                var = np.sum(res ** 2, axis=0) / (span - 4) * np.linalg.inv(design.T @ design)[1, 1]
                out.append((coef[2], 2.0 * coef[1], 2.0 * np.sqrt(var), np.asarray(spin, dtype=float)))
    return out


def _gravity_from_flights(windows, ball, drag=None, lift=None) -> dict:
    """Gravity's vector in the tracks' frame from the flights alone (no table): every window's acceleration
    ``a = g + C_D d(v) + lambda l(v, omega)`` (``d`` the drag per unit C_D, ``l`` the published Magnus
    acceleration), the three components of ``g`` with C_D and the lift scale ``lambda`` (each fitted, or
    fixed at ``drag``, ``lift``) by weighted least squares; the covariance scaled by the reduced chi-square.
    Returns ``{name: (value, stderr)}`` and ``chi2`` (the reduced chi-square) and ``windows``."""
    v = np.array([w[0] for w in windows])
    acc = np.array([w[1] for w in windows])
    err = np.array([w[2] for w in windows])
    spin = np.array([w[3] for w in windows])
    speed = np.linalg.norm(v, axis=1)
    per_drag = -ball.drag_rate / ball.drag_coefficient * speed[:, None] * v
    per_lift = ball.lift_rate * lift_over_spin(ball.radius * np.linalg.norm(spin, axis=1) / speed)[:, None] * np.cross(
        spin, v)
    n = v.shape[0]
    design = np.zeros((3 * n, 5))
    for axis in range(3):
        design[axis * n:(axis + 1) * n, axis] = 1.0
        design[axis * n:(axis + 1) * n, 3] = per_drag[:, axis]
        design[axis * n:(axis + 1) * n, 4] = per_lift[:, axis]
    target = acc.T.ravel().copy()
    weight = 1.0 / err.T.ravel()
    names = ["g_x", "g_y", "g_z", "C_D", "lift_scale"]
    free = [0, 1, 2]
    for col, fixed in ((3, drag), (4, lift)):
        if fixed is None:
            free.append(col)
        else:
            target -= design[:, col] * fixed
    a = design[:, free] * weight[:, None]
    coef, *_ = np.linalg.lstsq(a, target * weight, rcond=None)
    res = target * weight - a @ coef
    chi2 = float(res @ res) / (res.size - len(free))
    cov = np.linalg.inv(a.T @ a) * max(chi2, 1.0)
    out = {names[j]: (float(c), float(math.sqrt(cov[i, i]))) for i, (j, c) in enumerate(zip(free, coef))}
    return {**out, "chi2": chi2, "windows": n}


def _regular_times(track: Track) -> Track:
    """The track with its time stamps put on a regular grid: each sample's frame number from its time over the
    frame interval (dropped frames kept as gaps), the grid a straight-line fit of the times to the frame
    numbers (five rounds, from the median interval over ten samples); the track unchanged when two samples
    would fall on one frame."""
    t = track.time
    span = min(10, t.size - 1)
    period, offset = float(np.median((t[span:] - t[:-span]) / span)), float(t[0])
    for _ in range(5):
        frame = np.round((t - offset) / period)
        frame -= frame[0]
        if not np.all(np.diff(frame) > 0):
            return track
        period, offset = (float(c) for c in np.polyfit(frame, t, 1))
    return Track(track.source, offset + period * frame, track.position, track.dimensions, track.spin,
                 name=track.name)


def _pooled_constant(rows, column="e_n") -> str:
    law = fit_normal_law("constant", rows["vn_in_m_s"].to_numpy(float), rows[column].to_numpy(float),
                         rows["e_n_fit_stderr"].to_numpy(float))
    p = law["e"]
    return f"{p.value:.4f} {_interval(p)}"


def tilt_checks(tracks, result, flat, ball, lift: float) -> list[str]:
    """Whether the contact points' plane is the table's, what reads e_n right, and what else could move it."""
    plane = result.details["surface_plane"]
    slope_y, se_y = plane["slopes"][1], plane["stderr"][2]
    lines = ["### Is the tilt real, and what does it do to e_n?", "",
             "e_n is read against the gradient of the contact points' plane, m = (-slope_x, -slope_y, 1): with the "
             "velocities it transforms like them under any affine distortion of the tracks' frame (a rotation, a "
             "shear, a scale error of one axis), so that e_n against the plane does not change whether the table "
             "leans, the frame leans (gravity then leans with it) or the tracking shears the heights; e_n against "
             "e_z changes in all three. What would make the horizontal reading right is a rise of the contact "
             "points that is not in the velocities (a bias of the contact heights that grows along y).", ""]
    # synthetic: does the estimator recover a lean and not invent one; which reading is right
    count = 24
    rows, grav, found, covered, missed = [], [], [], [], []
    for case, what in (("level", "level table, level frame"), ("table", f"table rising {1e3 * LEAN:g} mm/m along y"),
                       ("rotated", f"level table, frame rotated by {1e3 * math.atan(LEAN):.2f} mrad (gravity leans)"),
                       ("shear", f"level table, heights sheared by {1e3 * LEAN:g} mm/m along y")):
        synth = _lean_tracks(case, count, lift)
        auto = analyse_tracks(synth, ball, rule=False)
        level = analyse_tracks(synth, ball, rule=False, surface="flat")
        sp = auto.details["surface_plane"]
        ea, el = auto["normal.constant.e"], level["normal.constant.e"]
        slope = (f"{1e3 * sp['slopes'][1]:.2f} +- {1e3 * sp['stderr'][2]:.2f}" if sp["tilted"] else "– (horizontal)")
        rows.append(f"| {what} | {slope} | {ea.value:.4f} {_interval(ea)} | {el.value:.4f} {_interval(el)} |")
        found.append(sp["tilted"] == (case != "level"))
        covered.append(ea.contains(0.9))
        missed.append(case == "level" or not el.contains(0.9))
        if case in ("level", "rotated"):
            spins = {(t.source, 0): t.spin for t in synth}
            g = _gravity_from_flights(_flight_windows(synth, spins), ball, drag=ball.drag_coefficient,
                                      lift=ball.lift_scale)
            grav.append((what, g))
    lines += [f"{count} synthetic tracks per row (the tests' independent reference: 143 Hz, 1 mm of noise, the balls "
              f"along -y at 4-9 m/s, spins of 50-350 rad/s, lift scale {lift:.2f}, one bounce with e_n 0.9 and "
              "Coulomb friction 0.25), analysed like the SpinDOE tracks (the surface `auto`: a plane when BIC "
              "prefers it):", "",
              "| truth | slope along y found [mm/m] | e_n against the plane found (95 %) | e_n against e_z (95 %) |",
              "|---|---|---|---|", *rows, "",
              f"A tilt found where there is one and none where there is none: {sum(found)} of {len(found)} rows; e_n "
              f"against the plane covers 0.9 in {sum(covered)} of {len(covered)}; against e_z it misses 0.9 in "
              f"{sum(missed) - 1} of the {len(missed) - 1} leaning rows. The SpinDOE tracks' two readings differ by "
              f"{result['e_n_speed_band'].value - flat['e_n_speed_band'].value:+.4f}. The flights are fitted with "
              "gravity along -z in every row; in the rotated frame it is not.", ""]
    # the real contact points: the plane's determination
    fits = result.details["bounce_fits"]
    pts = np.array([[f["params"][k]["value"] for k in ("x_c", "y_c", "z_c")] for f in fits])
    owner = np.array([f["details"]["track"] for f in fits])
    rng = np.random.default_rng(1)
    names = np.unique(owner)
    boot = []
    for _ in range(2000):
        pick = np.concatenate([np.flatnonzero(owner == nm) for nm in rng.choice(names, names.size)])
        design = np.column_stack([np.ones(pick.size), pts[pick, 0], pts[pick, 1]])
        boot.append(np.linalg.lstsq(design, pts[pick, 2], rcond=None)[0][2])
    boot = np.array(boot)
    table, ftable = result.bounces[result.bounces["analysed"]], flat.bounces[flat.bounces["analysed"]]
    both = table.merge(ftable[["bounce", "e_n"]], on="bounce", suffixes=("", "_flat"))
    ratio = both["vt_in_m_s"] / both["vn_in_m_s"]
    low = both[ratio < 1.5]
    share = result.details["surface_share"]
    lines += ["On the SpinDOE tracks:", "",
              f"* the plane's slope along y, {1e3 * slope_y:.2f} +- {1e3 * se_y:.2f} mm/m (least squares on the "
              f"contact points), is {1e3 * boot.std():.2f} mm/m by a bootstrap over the tracks (2000 resamples; 95 % "
              f"{1e3 * np.percentile(boot, 2.5):.2f} to {1e3 * np.percentile(boot, 97.5):.2f} mm/m): "
              f"{slope_y / se_y:.0f} standard errors from level, over the {np.ptp(pts[:, 1]):.1f} m of y that the "
              "contact points span;",
              f"* its standard error is now carried into e_n: {share.get('e_n_speed_band', 0.0):.4f} on the pooled "
              f"e_n at 2-3 m/s, {share['per_bounce_median']:.4f} (median) on each bounce's, added in quadrature (the "
              "error of the slopes is common to all bounces, so that pooling does not average it down);",
              f"* against e_z, e_n falls with the tangential speed (correlation of e_n with v_t / v_n "
              f"{np.corrcoef(both['e_n_flat'], ratio)[0, 1]:+.2f}; against the plane "
              f"{np.corrcoef(both['e_n'], ratio)[0, 1]:+.2f}), as the lean of the normal makes it. The "
              f"{len(low)} bounces with v_t / v_n below 1.5, which the lean moves least, give e_n = "
              f"{_pooled_constant(low, 'e_n_flat')} against e_z and {_pooled_constant(low)} against the plane "
              "(constant law, the flights' statistical errors): above the rule's band in either reading.", ""]
    # gravity from the flights alone
    spins = {}
    for track in tracks:
        if track.spin is not None:
            spins[(track.source, 0)] = track.spin
        own = sorted((f for f in fits if f["details"]["track"] == track.source), key=lambda f: f["details"]["index"])
        minima = [c.index for c in find_bounces(track)]
        for f in own:
            if f["details"]["index"] in minima:
                spins[(track.source, minima.index(f["details"]["index"]) + 1)] = f["details"]["spin_out"]
    windows = _flight_windows(tracks, spins)
    free = _gravity_from_flights(windows, ball)
    fixed = _gravity_from_flights(windows, ball, drag=ball.drag_coefficient, lift=ball.lift_scale)

    def g_row(label, g):
        cells = " | ".join(f"{g[k][0]:+.3f} +- {g[k][1]:.3f}" if k in g else "fixed" for k in
                           ("g_x", "g_y", "g_z", "C_D", "lift_scale"))
        return f"| {label} | {g['windows']} | {cells} | {g['chi2']:.1f} |"

    lines += ["Gravity's vector from the free flights alone (no table): cubics through 15 samples of flight (none "
              "within three samples of a bounce) give each window's velocity and acceleration; the accelerations "
              "are fitted as g + drag + Magnus (the measured or propagated spin), g's three components with the drag "
              "coefficient and the lift scale free or fixed; the errors scaled by the reduced chi-square. A frame "
              f"leaning by {1e3 * LEAN:g} mrad about x would show g_y = {ball.net_gravity * LEAN:+.3f} m/s^2.", "",
              "| flights | windows | g_x [m/s^2] | g_y [m/s^2] | g_z [m/s^2] | C_D | lift scale | chi^2 / dof |",
              "|---|---|---|---|---|---|---|---|",
              g_row("SpinDOE, C_D and lift free", free), g_row("SpinDOE, C_D and lift fixed", fixed),
              *[g_row(f"synthetic: {what}, fixed", g) for what, g in grav], "",
              f"The model's net gravity is {ball.net_gravity:.3f} m/s^2 (its lean in the synthetic rotated frame "
              f"{ball.net_gravity * LEAN:+.3f} m/s^2 along y). On the SpinDOE flights g_y is "
              f"{free['g_y'][0]:+.2f} +- {free['g_y'][1]:.2f} m/s^2 with the drag free and "
              f"{fixed['g_y'][0]:+.2f} +- {fixed['g_y'][1]:.2f} m/s^2 with it fixed, "
              f"{free['g_y'][0] / (ball.net_gravity * LEAN):.1f} times what a lean of the frame by the contact "
              "plane's slope would give. Along y, g is degenerate with the drag of balls that all fly along -y, "
              "and the flights are not described to their noise (reduced chi-square "
              f"{free['chi2']:.0f} against {grav[0][1]['chi2']:.1f} on the synthetic flights): a drag or a lift the "
              f"model lacks; |g_z| is {abs(free['g_z'][0]) / ball.net_gravity:.3f} times the net gravity. "
              "Gravity's direction is therefore not determined by these flights to the few mrad that matter; e_n "
              "against the plane does not need it (the rotated-frame row above).", ""]
    # what else could move e_n: time stamps, gravity's size, the window
    given = np.nanmedian([tracking_noise(t, find_bounces(t)) for t in tracks], axis=0)
    regular = [_regular_times(t) for t in tracks]
    on_grid = np.nanmedian([tracking_noise(t, find_bounces(t)) for t in regular], axis=0)
    g_up = abs(free["g_z"][0]) / ball.net_gravity
    variants = [("nominal (lift scale fixed at the estimate)", tracks, ball, {}),
                ("time stamps on a regular grid", regular, ball, {}),
                (f"gravity x {g_up:.3f} (the flights' vertical acceleration)", tracks,
                 ball.with_(gravity=ball.gravity * g_up), {}),
                ("flight windows of 0.08 s (not 0.12 s)", tracks, ball, {"window": 0.08})]
    rows = []
    for label, tr, b, options in variants:
        r = analyse_tracks(tr, b, **options)
        pl = r.details["surface_plane"]
        rows.append(f"| {label} | {1e3 * pl['slopes'][1]:.2f} | {r['e_n_speed_band'].value:.4f} "
                    f"{_interval(r['e_n_speed_band'])} | {r.statistics['bounces_in_speed_band']} |")
    lines += [f"The time stamps are rounded to 1 ms and jitter (intervals of 6, 7 and 8 ms): the scatter about "
              f"cubics through 15 samples is {1e3 * given[1]:.2f} mm along y and {1e3 * given[2]:.2f} mm along z with "
              f"the stamps, {1e3 * on_grid[1]:.2f} mm and {1e3 * on_grid[2]:.2f} mm on a regular grid of frames "
              f"({sum(r is not t for r, t in zip(regular, tracks))} of {len(tracks)} tracks put on a grid; the others "
              "have stamps that stray by half a frame or more and are kept): the samples are regular, their stamps "
              "are not. What that, the size of gravity and the flights' length do "
              "(each row a whole analysis, the surface estimated):", "",
              "| variant | slope along y [mm/m] | e_n at 2-3 m/s (95 %, with the plane's share) | bounces |",
              "|---|---|---|---|", *rows, ""]
    return lines


def _minima_check(tracks, result) -> tuple[int, int, list[str]]:
    """Every interior minimum of the height within 5 cm of the table with >= 5 samples on each side
    (counted up to the neighbouring such minima), and whether the analysis found it."""
    plane = result.details["surface_plane"]
    table = result.bounces
    total = found = 0
    missed = []
    for track in tracks:
        z = track.height
        contact = (plane["contact_height_m"] + plane["slopes"][0] * (track.position[:, 0] - plane["centroid_m"][0])
                   + plane["slopes"][1] * (track.position[:, 1] - plane["centroid_m"][1]))
        lows = [i for i in range(1, z.size - 1) if z[i] < z[i - 1] and z[i] <= z[i + 1]
                and abs(z[i] - contact[i]) <= 0.05]
        for k, i in enumerate(lows):
            before = i - (lows[k - 1] if k else -1) - 1
            after = (lows[k + 1] if k + 1 < len(lows) else z.size) - i - 1
            if before < 5 or after < 5:
                continue
            total += 1
            rows = table[(table["track"] == track.source) & ((table["sample"] - i).abs() <= 2)]
            if len(rows):
                found += 1
            else:
                missed.append(f"{Path(track.source).name} sample {i}")
    return total, found, missed


def _sources(table) -> str:
    """How many analysed bounces had their incoming spin given, propagated, estimated or unknown."""
    used = table[table["analysed"]]
    counts = used["spin_source"].value_counts()
    return ", ".join(f"{int(counts[k])} {k}" for k in ("given", "propagated", "estimated", "unknown") if k in counts)


def _interval(p) -> str:
    return f"[{p.interval[0]:.4f}, {p.interval[1]:.4f}]"


def real(folder: Path, figures: Path, staged: StagedFiles) -> list[str]:
    files = [p for p in sorted((folder / "spindoe").glob("*.csv")) if not is_spin_index(p)]
    tracks = [read_track(p) for p in files]
    t0 = time.perf_counter()
    result = analyse_tracks(tracks, estimate_lift=True, air_share=True)
    elapsed = time.perf_counter() - t0
    s = result.statistics
    table = result.bounces
    lift = result["lift_scale"]
    ball = TABLE_TENNIS_BALL.with_(lift_scale=lift.value)
    plane = result.details["surface_plane"]
    air = result.details["air_model"]
    used = list(result.details["bounce_fits"])
    stderr_zc = float(np.median([f["params"]["z_c"]["stderr"] for f in used]))
    lines = ["## The SpinDOE table-tennis trajectories", "",
             f"{len(files)} trajectories of Gossard et al. (2023, SpinDOE; about 143 samples per second, positions "
             "of the ball's centre in the table's frame, the spin of each measured by the authors from a dot "
             "pattern), analysed together with the defaults of `impactid tracks analyse spindoe/*.csv` (table-tennis "
             f"ball 2.7 g, 40 mm, C_D 0.45, the lift coefficient of {LIFT_MODEL} times a scale estimated from the "
             "tracks, the measured spin taken as the incoming spin of each trajectory's first bounce and the later "
             "bounces' spins propagated from it, the surface's plane estimated, the air model's share "
             f"stated) in {elapsed:.0f} s.", "",
             f"* spins: {_sources(table)};",
             f"* bounces found: **{s['bounces_found']}**, analysed: **{s['bounces_analysed']}**, not analysed: "
             f"{s['bounces_not_analysed']} (reasons below);",
             f"* the lift scale, estimated from the {result.details['lift_estimate']['bounces']} bounces near the "
             "table (each bounce's fit with its own scale as an eleventh parameter, pooled with the bounces' scatter): "
             f"**{lift.value:.3f} {_interval(lift)}** (95 %): the published lift fit (scale 1), made for baseballs, "
             f"is {1 / lift.interval[1]:.1f} to {1 / lift.interval[0]:.1f} times stronger than what these table-tennis "
             "flights show. The bounces are fitted "
             "with the estimated scale and its interval is the lift's share of the air model;",
             f"* the surface: a plane through the {plane['points']} fitted contact points rises by "
             f"**{1e3 * plane['slopes'][0]:.1f} +- {1e3 * plane['stderr'][1]:.1f} mm/m along x and "
             f"{1e3 * plane['slopes'][1]:.1f} +- {1e3 * plane['stderr'][2]:.1f} mm/m along y** (a tilt of "
             f"{1e3 * plane['tilt_rad']:.1f} mrad; BIC {plane['bic']['plane']:.0f} against {plane['bic']['flat']:.0f} "
             f"for a horizontal plane) and leaves {1e3 * plane['rms_m']:.1f} mm (the contact heights' own standard "
             f"errors: median {1e3 * stderr_zc:.2f} mm). Its normal is the direction of e_n. Whether the table is "
             "tilted or the tracks' frame is (its origin is already 27 mm off the table: the contact centres lie "
             f"at {1e3 * plane['contact_height_m']:.1f} mm, not +20 mm), the plane's normal is the table's normal "
             "in the tracks' frame, and the slopes' standard errors are carried into every e_n (below); gravity is "
             "kept along -z;"]
    total, found, missed = _minima_check(tracks, result)
    lines.append(f"* every interior minimum of the height within 5 cm of the table with at least five samples of "
                 f"flight on each side: {total}, found by the analysis: {found}"
                 + (f" (missed: {', '.join(missed)})" if missed else "") + ".")
    lines += ["", "### Bounces not analysed", "", "| bounce | reason |", "|---|---|"]
    for row in table[~table["analysed"]].itertuples():
        lines.append(f"| {row.bounce} | {row.reason} |")
    rule = result.details["rule"]
    e, ea = result["e_n_speed_band"], result["e_n_speed_band_air"]
    sys_lo, sys_hi = air["systematic"]
    shifts = air["pooled_shifts"]
    lines += ["", "### The table-tennis rule, and the air model's share", "",
              "A ball dropped from 30.5 cm must rebound 22-25 cm. Through the same air model as the tracks' flights "
              f"(C_D {rule['drag_coefficient']:g}), the drop reaches {rule['impact_speed_m_s']:.3f} m/s and the rule "
              f"allows **e_n = {rule['e_low']:.4f} to {rule['e_high']:.4f}** (without air {rule['vacuum'][0]:.4f} to "
              f"{rule['vacuum'][1]:.4f}; over C_D {DRAG_RANGE[0]:g}-{DRAG_RANGE[1]:g}: "
              f"**{rule['band_over_drag_range'][0]:.4f} to {rule['band_over_drag_range'][1]:.4f}**; the dropped ball "
              "does not spin, so the lift does not enter).", "",
              f"The tracks' bounces at normal impact speeds of 2-3 m/s ({s['bounces_in_speed_band']} bounces; the "
              "constant law on them, each weighted by its standard error and the bounces' scatter):", "",
              f"* statistical: **e_n = {e.value:.4f} {_interval(e)}** (95 %; the flights' fits and the surface "
              f"plane's slopes, whose share is {result.details['surface_share'].get('e_n_speed_band', 0.0):.4f});",
              f"* with the air model's share: **{_interval(ea)}**. Every bounce refitted with C_D at "
              f"{DRAG_RANGE[0]:g} and {DRAG_RANGE[1]:g} moves the pooled e_n by "
              f"{', '.join(f'{d:+.4f}' for d in shifts['drag_coefficient'])}, with the lift scale at the ends of its "
              f"interval ({air['lift_range'][0]:.3f}, {air['lift_range'][1]:.3f}) by "
              f"{', '.join(f'{d:+.4f}' for d in shifts['lift_scale'])}; the shifts of the two coefficients are added "
              f"({sys_lo:+.4f}/{sys_hi:+.4f}) to the statistical interval's ends.", "",
              f"Through the same air model the tracks' interval "
              f"**{'overlaps' if rule['overlaps'] else 'does not overlap'}** the rule's band; with the air model's "
              f"share on both sides ({_interval(ea)} against {rule['band_over_drag_range'][0]:.4f}-"
              f"{rule['band_over_drag_range'][1]:.4f}) it "
              f"**{'overlaps' if rule['overlaps_with_air_model'] else 'does not overlap'}**. Of the "
              f"{rule['bounces_in_band']} bounces' own intervals, {rule['bounces_overlapping']} overlap the band, "
              f"{rule['bounces_overlapping_air']} with the air model's share.", ""]
    share = air_model_share(result)
    lines += ["Each air model's pooled e_n on the same bounces (its interval from the flights' fits alone, without the "
              "surface plane's share, as the shifts above are taken):", "",
              "| C_D | lift scale | e_n at 2-3 m/s | 95 % interval | bounces | rule band | median residual RMS [mm] |",
              "|---|---|---|---|---|---|---|"]
    for row in share.itertuples():
        lines.append(f"| {row.drag_coefficient:g} | {row.lift_scale:.3f} | {_f(row.e_n, '.4f')} | "
                     f"[{_f(row.e_n_low, '.4f')}, {_f(row.e_n_high, '.4f')}] | {row.bounces} | "
                     f"{_f(row.rule_low, '.4f')}-{_f(row.rule_high, '.4f')} | {1e3 * row.residual_rms_m:.2f} |")
    # what the surface's tilt, the published lift and the side of the measured spin do
    flat = analyse_tracks(tracks, ball, surface="flat", air_share=True, lift_range=tuple(lift.interval))
    published = analyse_tracks(tracks, TABLE_TENNIS_BALL)
    after = analyse_tracks(tracks, ball, spin_side="out")
    ef, efa, ep, eo = (flat["e_n_speed_band"], flat["e_n_speed_band_air"], published["e_n_speed_band"],
                       after["e_n_speed_band"])
    fr = flat.details["rule"]
    lines += ["", "### The surface's tilt, the published lift, the measured spin's side", "",
              "| analysis | e_n at 2-3 m/s (95 %) | with the air model's share | bounces | overlaps the rule |",
              "|---|---|---|---|---|",
              f"| default (tilted plane, estimated lift) | {e.value:.4f} {_interval(e)} | {_interval(ea)} | "
              f"{s['bounces_in_speed_band']} | {'yes' if rule['overlaps'] else 'no'} / "
              f"{'yes' if rule['overlaps_with_air_model'] else 'no'} |",
              f"| horizontal surface (`--surface flat`) | {ef.value:.4f} {_interval(ef)} | {_interval(efa)} | "
              f"{flat.statistics['bounces_in_speed_band']} | {'yes' if fr['overlaps'] else 'no'} / "
              f"{'yes' if fr['overlaps_with_air_model'] else 'no'} |",
              f"| published lift, scale 1 (`--no-air-share`, nothing estimated) | {ep.value:.4f} {_interval(ep)} | – | "
              f"{published.statistics['bounces_in_speed_band']} | "
              f"{'yes' if published.details['rule']['overlaps'] else 'no'} / – |",
              f"| spin measured after the bounce (`--spin-after`) | {eo.value:.4f} {_interval(eo)} | – | "
              f"{after.statistics['bounces_in_speed_band']} | {'yes' if after.details['rule']['overlaps'] else 'no'} "
              "/ – |", "",
              f"The tilt of {1e3 * plane['tilt_rad']:.1f} mrad moves e_n by {e.value - ef.value:+.4f}: the balls "
              "travel along -y at 4-9 m/s, and against a normal leaning towards -y by the slope c the incoming normal "
              "speed is smaller by c |v_y,in| and the outgoing one larger by c |v_y,out| (about 0.05 m/s each at "
              "2.4 m/s). This is larger than the air model's share and decides whether the tracks meet the rule. "
              "Whether the table leans in the tracks' frame, the frame leans (gravity with it) or the tracking shears "
              "the heights along y, e_n against the plane's normal is the one to read (next section); the horizontal "
              "row would be right only if the contact points' rise were not in the velocities.", ""]
    lines += tilt_checks(tracks, result, flat, ball, lift.value)
    lines += ["### Laws across bounces", "",
              "| law | parameters | AIC | BIC |", "|---|---|---|---|"]
    for kind, block in result.details["law_comparison"].items():
        for row in block["models"]:
            params = ", ".join(f"{p.name.split('.')[-1]} = {p.value:.4g} [{p.interval[0]:.4g}, {p.interval[1]:.4g}]"
                               for p in result.params.values() if p.name.startswith(f"{kind}.{row['name']}."))
            mark = " (selected)" if block["selected"] == row["name"] else ""
            lines.append(f"| {kind} {row['name']}{mark} | {params or '–'} | {row['aic']:.1f} | {row['bic']:.1f} |")
    coulomb = result.details["laws"]["tangential"].get("coulomb", {})
    lines += ["", f"Coulomb law: {coulomb.get('extra', {}).get('sticking', '–')} of {s['bounces_analysed']} bounces "
              "leave rolling at the fitted friction.", ""]
    name = "tracks_restitution.png"
    fig = result.plot()
    staged.write_with(figures / name, lambda tmp, fig=fig: fig.savefig(tmp, format="png", dpi=110))
    lines += ["### Per-bounce values against impact speed and spin", "", f"![{name}](figures/{name})", "",
              "Left: e_n against the normal impact speed with the fitted laws, the rule's band (shaded) and the "
              "2-3 m/s estimate; middle: against the measured spin; right: the tangential velocity ratio against "
              "the contact point's slip over the normal speed.", ""]
    example = next((t for t in tracks if Path(t.source).stem == "053"), tracks[0])
    fits = [f for f in (result.details["bounce_fits"]) if f["details"]["track"] == example.source]
    fig2 = track_figure(example, [FitResult.from_dict(f) for f in fits])
    staged.write_with(figures / "tracks_example.png", lambda tmp, fig=fig2: fig.savefig(tmp, format="png", dpi=110))
    lines += ["![tracks_example.png](figures/tracks_example.png)", "",
              f"Trajectory {Path(example.source).name}: the height and the fitted flights of its bounces.", "",
              "### Every bounce", "",
              "e_n against the tilted plane's normal; \"95 %\" its statistical interval (the flight's fit and the "
              "plane's slopes), \"with air\" that interval "
              "widened by the bounce's own shifts under the air model's range.", "",
              "| bounce | v_n [m/s] | e_n | 95 % | with air | beta_t | 95 % | |spin_in| [rad/s] | spin | "
              "|u_t,in| [m/s] | dspin_x, dspin_y [rad/s] | RMS [mm] | check |",
              "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for row in table[table["analysed"]].itertuples():
        lines.append(f"| {row.bounce} | {row.vn_in_m_s:.3f} | {row.e_n:.4f} | [{row.e_n_low:.3f}, "
                     f"{row.e_n_high:.3f}] | [{row.e_n_air_low:.3f}, {row.e_n_air_high:.3f}] | {row.beta_t:.3f} | "
                     f"[{row.beta_t_low:.3f}, {row.beta_t_high:.3f}] | {_f(row.spin_in_rad_s, '.0f')} | "
                     f"{row.spin_source} | {_f(row.ut_in_m_s, '.2f')} | "
                     f"{row.dspin_x_rad_s:.0f}, {row.dspin_y_rad_s:.0f} | "
                     f"{1e3 * row.residual_rms_m:.2f} | {row.model_check} |")
    return lines + [""]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--real-data", type=Path, default=None, help="folder with spindoe/")
    parser.add_argument("--out", type=Path, required=True, help="markdown page to write")
    parser.add_argument("--seeds", type=int, default=60, help="synthetic bounces")
    parser.add_argument("--multi-seeds", type=int, default=8, help="synthetic tracks of three bounces per scenario")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    lines = ["# Validation: bounces from ball tracks", "",
             "Written by `benchmarks/validate_tracks.py` ([the method](tracks.md)); every number below was measured "
             "by that run:", "", "```", "python benchmarks/validate_tracks.py --out docs/validation_tracks.md "
             "--real-data DIR", "```", ""]
    lines += synthetic(args.seeds)
    lines += multi_bounce(args.multi_seeds)
    figures = args.out.parent / "figures"
    with StagedFiles() as staged:
        if args.real_data is not None:
            if not (args.real_data / "spindoe").is_dir():
                print(f"validate_tracks: error: --real-data {args.real_data}: no spindoe/ folder", file=sys.stderr)
                return 2
            lines += real(args.real_data, figures, staged)
        else:
            lines += ["## Real trajectories", "", "not run (no --real-data given)", ""]
        lines.append(f"Run time {time.perf_counter() - start:.0f} s.")
        staged.write_text(args.out, "\n".join(lines) + "\n")
    print(f"written {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

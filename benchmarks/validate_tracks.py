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
from impactid.rigs.tracks.parameters import DRAG_RANGE, LIFT_MODEL  # noqa: E402
from impactid.rigs.tracks.readers import is_spin_index, read_track  # noqa: E402
from impactid.rigs.tracks.synth import synth_track  # noqa: E402
from tests.rigs.tracks.reference_tracks import bouncing_track  # noqa: E402


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
             "in the tracks' frame; gravity is kept along -z;"]
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
              f"* statistical: **e_n = {e.value:.4f} {_interval(e)}** (95 %);",
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
    lines += ["| C_D | lift scale | e_n at 2-3 m/s | 95 % interval | bounces | rule band | median residual RMS [mm] |",
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
              "2.4 m/s). This is larger than the air model's share and decides whether the tracks meet the rule. The "
              "plane is estimated from the contact points: if their rise along y were an error of the tracking (a "
              "depth error growing along y) rather than a tilt of the table in the tracks' frame, "
              "the horizontal row would be the right one.", ""]
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
              "e_n against the tilted plane's normal; \"95 %\" its statistical interval, \"with air\" that interval "
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

"""Figures of the model check and the identifiability block, from real runs of impactid's public API.

    NUMBA_NUM_THREADS=1 python benchmarks/figures_identification.py [--out-dir docs/figures]
        [--only model_check|identifiability]

Writes two figures (PNG, 200 dpi; the second in the package's style, :func:`impactid.plotting.style`),
shown in docs/identifiability.md and docs/estimation.md (``--only`` writes one of them):

* ``model_check.png``: a finger-follower tappet fit (``fit_tappet_drag``) to one synthetic
  recording (900 rpm, 16 revolutions, the default sensors, seed 2: the case of
  ``tests/rigs/finger_follower/test_identify.py``) made with the rig's lash-adjuster preload of
  20 N, fitted once with the right preload and once with 30 N. Per bin of the synchronous
  average: the residual (measured minus fitted) in units of the fit's noise reference, with the
  band of that noise, and each fit's ``model_check`` (verdict, RMS over noise, chi-square,
  lag-1 autocorrelation, effective samples, inflation, action) and its ``alpha``, ``beta``.
* ``identifiability.png``: rig P's ``estimate`` of ``(beta, n)`` (least squares) from the first
  built-in example recording alone (one operating point, e/r_c 0.05 at 15 Hz) and from both
  (with e/r_c 0.25 at 12 Hz; ``EXAMPLE_POINTS``): the profile of ``n`` from each result's
  ``identifiability`` block (the rise of the sum of squares along the valley, in units of the
  residual variance) against the 95 % threshold, with the reported interval of ``n``.

Everything plotted is read from the results. The synthetic truth is used only to mark the true
value: the tappet recording's ``truth`` (alpha, beta) and the example recordings' recipe
(``EXAMPLE_RECIPE``: n = 1.5). Run time about 40 s after the simulators are compiled (the example
recordings are generated on first use and cached, see ``impactid.rigs.pivoted.example``).
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from impactid import estimate, read_recording  # noqa: E402
from impactid._files import StagedFiles  # noqa: E402
from impactid.plotting import OKABE_ITO, PNG_DPI, styled  # noqa: E402
from impactid.rigs.finger_follower import KIM1990  # noqa: E402
from impactid.rigs.finger_follower.identify import fit_tappet_drag  # noqa: E402
from impactid.rigs.finger_follower.synth import synth_recording  # noqa: E402
from impactid.rigs.pivoted.example import EXAMPLE_POINTS, EXAMPLE_RECIPE, example_recording_paths  # noqa: E402

DPI = PNG_DPI
PRELOAD_TRUE, PRELOAD_WRONG = 20.0, 30.0


def _interval(p, digits: int = 5) -> str:
    lo, hi = p.interval
    if not (np.isfinite(lo) and np.isfinite(hi)):
        return "interval withheld"
    return f"95 % [{lo:.{digits}g}, {hi:.{digits}g}]"


def model_check_figure() -> tuple[Figure, list[str]]:
    """The tappet fit with the right and with a wrong lash-adjuster preload."""
    s = synth_recording(KIM1990.replace(F_tf0=PRELOAD_TRUE), 900.0, revolutions=16, seed=2)
    fits = [(f"fitted with the rig's preload, {PRELOAD_TRUE:g} N",
             fit_tappet_drag(s.recording, KIM1990.replace(F_tf0=PRELOAD_TRUE))),
            (f"fitted with a wrong preload, {PRELOAD_WRONG:g} N (the rig has {PRELOAD_TRUE:g} N)",
             fit_tappet_drag(s.recording, KIM1990.replace(F_tf0=PRELOAD_WRONG)))]
    fig = Figure(figsize=(11, 6.0))
    grid = fig.add_gridspec(2, 2, height_ratios=(3, 1.1), hspace=0.3, wspace=0.16, left=0.07, right=0.98,
                            top=0.89, bottom=0.01)
    log = []
    for col, (label, fit) in enumerate(fits):
        check = fit.model_check
        part = check["checks"][0]
        noise = part["noise_sd"]
        table = fit.tables["cycles"]
        residual = (table["measured_m"] - table["fitted_m"]).to_numpy()
        z = residual / noise
        ax = fig.add_subplot(grid[0, col])
        angle = table["cam_angle_deg"].to_numpy()
        ax.axhspan(-2, 2, color="tab:green", alpha=0.12, lw=0, label="noise reference, +-2 sd")
        ax.axhspan(-1, 1, color="tab:green", alpha=0.25, lw=0, label="noise reference, +-1 sd")
        ax.plot(angle, z, ".", ms=2.2, color="tab:blue" if col == 0 else "tab:red",
                label="residual per bin (measured - fitted)")
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set(xlim=(-180, 180), xlabel="cam angle [deg]", title=label)
        ax.set_xticks(range(-180, 181, 60))
        if col == 0:
            ax.set_ylabel(f"residual / noise sd ({noise * 1e9:.0f} nm)")
        ax.legend(loc="lower left", fontsize=7.5, markerscale=3, framealpha=0.85)
        ax.text(0.99, 0.03, f"verdict: {check['verdict']}", transform=ax.transAxes, ha="right", va="bottom",
                fontsize=11, fontweight="bold", color="tab:green" if check["describes_data"] else "tab:red",
                bbox=dict(facecolor="white", edgecolor="none", alpha=0.85))
        widening = {"none": "intervals as computed", "widened": "intervals widened",
                    "withheld": "intervals withheld"}.get(check["action"], check["action"])
        reason = ""
        if check["action"] == "withheld":
            reason = "\n  (structured and RMS > 3 x noise: no widening suffices)"
        elif check["action"] == "widened":
            reason = f" (x {check['inflation']:.3g})"
        truth = {name: s.truth[name] for name in ("alpha", "beta")}
        lines = [f"RMS {part['residual_over_noise']:.2f} x noise;  chi2 {part['chi_square']:.5g} for "
                 f"{part['dof']} dof, p = {part['chi_square_p_value']:.2g}",
                 f"lag-1 autocorrelation {part['lag1_autocorrelation']:+.2f};  effective samples "
                 f"{part['effective_samples']:.4g} of {part['n']}",
                 f"inflation {check['inflation']:.3g}: {widening}{reason}"]
        for name, value in truth.items():
            p = fit[name]
            lines.append(f"{name} = {p.value:.5g} ({100 * (p.value / value - 1):+.2f} % off the true {value:g}), "
                         f"{_interval(p)}")
        tx = fig.add_subplot(grid[1, col])
        tx.axis("off")
        tx.text(0.0, 1.0, "\n".join(lines), transform=tx.transAxes, va="top", ha="left", fontsize=8.2,
                family="monospace", linespacing=1.45)
        log.append(f"model_check {label}: verdict {check['verdict']}, action {check['action']}, inflation "
                   f"{check['inflation']:.4g}, RMS/noise {part['residual_over_noise']:.4g}, n_eff "
                   f"{part['effective_samples']:.4g}, " + ", ".join(
                       f"{n} {fit[n].value:.6g} {fit[n].interval}" for n in truth))
    fig.suptitle("Model check: one recording of a finger-follower tappet (900 rpm, 16 revolutions, lash-adjuster "
                 f"preload {PRELOAD_TRUE:g} N), tappet drag fitted twice", fontsize=11, y=0.99)
    return fig, log


@styled
def identifiability_figure() -> tuple[Figure, list[str]]:
    """Rig P: the profile of n from one operating point and from two."""
    recordings = [read_recording(p) for p in example_recording_paths()]
    n_true = EXAMPLE_RECIPE["n"]
    runs = []
    for label, selection in ((f"one operating point (e/r_c {EXAMPLE_POINTS[0][0]:g}, {EXAMPLE_POINTS[0][1]:g} Hz)",
                              recordings[:1]),
                             ("two operating points (+ e/r_c "
                              f"{EXAMPLE_POINTS[1][0]:g}, {EXAMPLE_POINTS[1][1]:g} Hz), joint fit", recordings)):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the not-separable warning is in the result, read below
            runs.append((label, estimate(selection).damping))
    fig = Figure(figsize=(11, 6.2))  # constrained layout (the package's style)
    grid = fig.add_gridspec(2, 2, height_ratios=(3, 1.0))
    log = []
    first = None
    for col, (label, d) in enumerate(runs):
        block = d.identifiability
        profile = block["profiles"]["n"]
        points = np.asarray(profile["points"], dtype=float)
        order = np.argsort(points[:, 0])
        ax = fig.add_subplot(grid[0, col], sharey=first)
        first = first or ax
        lo, hi = d.n_interval
        ax.axvspan(lo, hi, color=OKABE_ITO["orange"], alpha=0.25, lw=0, label="reported 95 % interval of $n$")
        ax.plot(points[order, 0], points[order, 1], "o-", ms=3.5, color=OKABE_ITO["blue"],
                label=r"profile of $n$ ($\log_{10} c$ refitted at each $n$)")
        ax.axhline(block["profile_threshold"], color="k", ls="--", lw=1,
                   label=f"95 % threshold ({block['profile_threshold']:.2f})")
        ax.axvline(n_true, color=OKABE_ITO["green"], lw=1.2, label=f"true $n$ = {n_true:g} (the example's recipe)")
        ax.plot([d.n], [0.0], "D", color=OKABE_ITO["vermillion"], ms=6, label=f"estimate $n$ = {d.n:.4g}",
                zorder=5)
        if col == 0:
            ax.set_xlim(0.45, 2.6)
            for bound in (0.5, 2.5):
                ax.axvline(bound, color="0.4", lw=0.8, ls=":")
            ax.text(2.49, 6.9, "search\nbound", ha="right", va="top", fontsize=7.5, color="0.3",
                    bbox=dict(facecolor="white", edgecolor="none", alpha=0.85))
            ax.set_ylabel("rise of the sum of squares / residual variance [-]")
        else:
            ax.set_xlim(lo - 0.2 * (hi - lo), hi + 0.2 * (hi - lo))
        ax.set_ylim(0, 7.2)
        ax.set(xlabel="exponent $n$ [-]", title=label)
        ax.title.set_fontsize(10)
        ax.legend(loc="upper left", fontsize=7.5, framealpha=0.9)
        determined = block["determined"]
        ax.text(0.99, 0.02 if col == 0 else 0.97, f"profile: {profile['shape']}",
                transform=ax.transAxes, ha="right", va="bottom" if col == 0 else "top",
                fontsize=11, fontweight="bold", color=OKABE_ITO["green"] if determined else OKABE_ITO["vermillion"],
                bbox=dict(facecolor="white", edgecolor="none", alpha=0.85))
        corr = block["largest_correlation"]["value"]
        comparison = block.get("model_comparison") or {}
        wald = comparison.get("wald", {})
        ratio = comparison.get("likelihood_ratio") or []
        lrt = f"LR p = {ratio[0]['p_value']:.2g}, " if ratio else "LR n/a, "
        lines = [f"impacts {int(np.isfinite(d.per_event['residual']).sum())}, approach speeds "
                 f"{d.per_event['approach_speed'].min():.3g} to {d.per_event['approach_speed'].max():.3g} m/s",
                 f"correlation (log10 c, n) {corr:.6f}; condition number {block['condition_number']:.3g}",
                 f"n = {d.n:.4g}, 95 % [{lo:.4g}, {hi:.4g}]" + ("  (on the search bound)" if any(
                     b["on_bound"] for b in block["near_bounds"]) else ""),
                 f"beta = {d.beta:.3g}, 95 % [{d.beta_interval[0]:.3g}, {d.beta_interval[1]:.3g}] N s m^-(n+1)",
                 f"separable: {d.separable};  determined: {determined};  model check: "
                 f"{d.model_check['verdict']}",
                 f"n = 1.5 or fitted: {lrt}Wald p = {wald.get('p_value', float('nan')):.2g}; "
                 f"preferred: {comparison.get('preferred', 'n/a')}"]
        tx = fig.add_subplot(grid[1, col])
        tx.axis("off")
        tx.text(0.0, 1.0, "\n".join(lines), transform=tx.transAxes, va="top", ha="left", fontsize=8.2,
                family="monospace", linespacing=1.45)
        log.append(f"identifiability {label}: shape {profile['shape']}, n {d.n:.5g} {d.n_interval}, beta {d.beta:.4g} "
                   f"{d.beta_interval}, corr {corr:.7f}, determined {determined}, separable {d.separable}, "
                   f"preferred {comparison.get('preferred')}")
    fig.suptitle("Identifiability: rig P's contact-law exponent $n$ from one operating point and from two "
                 "(least squares, built-in example recordings)")
    return fig, log


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out-dir", type=Path, default=Path(__file__).resolve().parent.parent / "docs" / "figures",
                        help="folder of the figures (default docs/figures)")
    parser.add_argument("--only", choices=("model_check", "identifiability"), default=None,
                        help="write only this figure (default: both)")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    log = []
    figures = [(name, make) for name, make in (("model_check", model_check_figure),
                                               ("identifiability", identifiability_figure))
               if args.only in (None, name)]
    with StagedFiles() as staged:
        for name, make in figures:
            t = time.perf_counter()
            fig, lines = make()
            staged.write_with(args.out_dir / f"{name}.png",
                              lambda tmp, fig=fig: fig.savefig(tmp, format="png", dpi=DPI))
            log += lines + [f"{name}.png: {time.perf_counter() - t:.1f} s"]
    print("\n".join(log))
    print(f"written {', '.join(str(args.out_dir / f'{name}.png') for name, _ in figures)} "
          f"in {time.perf_counter() - start:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())

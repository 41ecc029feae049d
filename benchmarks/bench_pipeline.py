"""Per-impact pipeline (issues 4 and 27): the 60 s estimate's time and memory, and every method's accuracy.

1. The 60 s estimate (issue 27): a 60 s S2 recording at 204.8 kHz (e/r_c 0.2, 16 Hz, the default law:
   959 usable impacts; made once and kept in ``~/.cache/impactid/bench_pipeline_S60.h5``, or
   ``--recording``). ``impactid estimate REC --fix-n 1.5`` runs as a subprocess ``--repeat`` times (wall,
   CPU = user + system of the child, peak memory = its maximum resident set size); then each stage runs
   in process as the estimate runs it (read, events, reconstruct, the calibration's sampling, fit,
   calibration; wall, CPU, share of the stages' CPU, peak resident set after the stage). Targets: at
   most 5 s wall and 1 GB peak memory; the estimate inside the interval the command gave before the
   issue's first change (measured the same day on this recording, :data:`BEFORE`) with an interval no
   narrower than half of that one.
2. Accuracy against the synthetic truth, 1 s recordings (15 usable events), noise-free and with
   0.5 % Gaussian noise on every analogue channel: onset error [samples], alpha error [fraction of
   peak-to-peak, worst sample of all events], alpha_m [relative], xi [absolute], v_a [relative],
   contact force [fraction of peak] for each integration method and anchor.

Run: ``python benchmarks/bench_pipeline.py`` (writes ``docs/performance_pipeline.md``; ``--quick`` skips
the 60 s part, ``--no-page`` prints only, ``--repeat N`` the subprocess runs).
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

from impactid import SUNDAR2016, HuntCrossley
from impactid.events import find_events
from impactid.io import read_recording, write_hdf5
from impactid.pipeline import Pipeline
from impactid.rigs.pivoted import calibration, estimation
from impactid.rigs.pivoted import reconstruct as reconstruct_module
from impactid.rigs.pivoted.reconstruct import ANCHORS, reconstruct
from impactid.rigs.pivoted.synth import synth_pivoted
from impactid.signal import INTEGRATORS
from impactid.synth import SensorModel

sys.path.insert(0, str(Path(__file__).resolve().parent))

from pages import BenchmarkPage, impactid_command  # noqa: E402

PAGE = Path(__file__).resolve().parents[1] / "docs" / "performance_pipeline.md"
LAW = HuntCrossley(24.7e9, 1.5)
#: The 60 s recording (made when missing).
RECORDING = Path.home() / ".cache" / "impactid" / "bench_pipeline_S60.h5"
#: Targets of issue 27: wall [s] and peak resident memory [bytes] of the 60 s estimate.
TARGET_WALL_S = 5.0
TARGET_PEAK_B = 1e9
#: ``impactid estimate`` on the 60 s recording before the issue's first change (the commit before it
#: was not at hand: the same command at 5411c77 + the working tree of 2026-11-26, before any of this
#: issue's pipeline changes): beta [N s m^-2.5] and its interval; 37.6-38.1 s wall, 18.4 s CPU
#: (12.8 user + 5.6 system) and 3.34 GB peak at a load average of 5.
BEFORE = {"beta": 24703043627.81368, "interval": (24696386150.307674, 24709702899.99543),
          "wall_s": 38.1, "cpu_s": 18.4, "peak_b": 3.343e9}
#: The channels rig P's default estimate (lambda1) needs: the accelerometer, and the cam encoder
#: for the recording's check of its cam speed.
NEEDED = ("accel_tangential", "cam_angle")


def _recording(path: Path) -> Path:
    """The 60 s recording at ``path``, synthesised first when missing (about 25 s, 1 GB)."""
    if not path.exists():
        path.parent.mkdir(parents=True, exist_ok=True)
        print(f"making {path} (60 s at 204.8 kHz, e/r_c 0.2, 16 Hz)")
        syn = synth_pivoted(SUNDAR2016.with_eccentricity_ratio(0.2), 16.0, LAW, 60.0)
        write_hdf5(syn.recording, path, truth=syn.truth)
    return path


#: The command's environment: this one, with Python's bytecode cache allowed. An installation holds the package's
#: bytecode (pip compiles it); a development checkout under ``PYTHONDONTWRITEBYTECODE`` (which some workplaces set)
#: would compile every module's source in every run instead (0.17 s of the estimate, measured with cProfile).
_WITH_BYTECODE = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}


def _run_estimate(path: Path, out: Path) -> tuple[float, float, float]:
    """``impactid estimate PATH --fix-n 1.5``: (wall [s], CPU [s], peak resident memory [bytes])."""
    start = time.perf_counter()
    child = subprocess.Popen([*impactid_command(), "estimate", str(path), "--fix-n", "1.5", "--out", str(out)],
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=_WITH_BYTECODE)
    _, status, usage = os.wait4(child.pid, 0)
    wall = time.perf_counter() - start
    child.returncode = os.waitstatus_to_exitcode(status)
    if child.returncode != 0:
        raise RuntimeError(f"impactid estimate exited with {child.returncode}")
    return wall, usage.ru_utime + usage.ru_stime, usage.ru_maxrss * 1024.0


def _verdict(ok: bool) -> str:
    return "PASS" if ok else "MISS"


def command(path: Path, repeat: int) -> None:
    """The subprocess runs of ``impactid estimate`` against the targets."""
    print(f"impactid estimate {path.name} --fix-n 1.5: {repeat} runs (after one warm-up run: numba's cache, "
          "the file in the page cache)")
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "estimate.json"
        _run_estimate(path, out)
        runs = [_run_estimate(path, out) for _ in range(repeat)]
        result = json.loads(out.read_text())
    walls, cpus, peaks = zip(*runs)
    print(f"  {'run':>4s} {'wall [s]':>9s} {'CPU [s]':>8s} {'peak [GB]':>10s}")
    for k, (w, c, m) in enumerate(runs, start=1):
        print(f"  {k:4d} {w:9.2f} {c:8.2f} {m / 1e9:10.3f}")
    wall, cpu, peak = statistics.median(walls), statistics.median(cpus), max(peaks)
    print(f"  median wall {wall:.2f} s (min {min(walls):.2f}), median CPU {cpu:.2f} s, largest peak "
          f"{peak / 1e9:.3f} GB")
    print(f"  before: {BEFORE['wall_s']:.1f} s wall, {BEFORE['cpu_s']:.1f} s CPU, {BEFORE['peak_b'] / 1e9:.2f} GB")
    print(f"  target wall <= {TARGET_WALL_S:g} s: {_verdict(wall <= TARGET_WALL_S)} (median {wall:.2f} s; CPU "
          f"{cpu:.2f} s is the wall an idle 2-core machine would approach)")
    print(f"  target peak <= {TARGET_PEAK_B / 1e9:g} GB: {_verdict(peak <= TARGET_PEAK_B)} ({peak / 1e9:.3f} GB)")
    beta = result["params"]["beta"]
    lo, hi = BEFORE["interval"]
    inside = lo <= beta["value"] <= hi
    width = beta["interval"][1] - beta["interval"][0]
    wide = width >= 0.5 * (hi - lo)
    print(f"  beta {beta['value']:.10g} [{beta['interval'][0]:.10g}, {beta['interval'][1]:.10g}]; before "
          f"{BEFORE['beta']:.10g} [{lo:.10g}, {hi:.10g}]")
    print(f"  target estimate inside the interval before: {_verdict(inside)}; interval no narrower than half: "
          f"{_verdict(wide)} (width ratio {width / (hi - lo):.3f})")
    rows = result.get("tables", {}).get("calibration", {}).get("data", [])
    for row in rows:
        print(f"  calibration: bias of alpha_m {row[1]:+.3e} +- {row[2]:.1e} over {row[3]} events")


class _Timed:
    """Wraps a module's function: the wall and CPU time of its calls (not counting nested timed calls)."""

    def __init__(self, module, name: str, label: str, clock: list) -> None:
        self.module, self.name, self.label, self.clock = module, name, label, clock
        self.original = getattr(module, name)
        self.wall = self.cpu = 0.0
        self.peak = 0.0

    def __call__(self, *args, **kwargs):
        wall, cpu = time.perf_counter(), time.process_time()
        self.clock.append(0)  # nested timed calls add their time here, which is not ours
        try:
            return self.original(*args, **kwargs)
        finally:
            dw, dc = time.perf_counter() - wall, time.process_time() - cpu
            nested = self.clock.pop()
            self.wall += dw - nested[0] if nested else dw
            self.cpu += dc - nested[1] if nested else dc
            if self.clock:
                outer = self.clock[-1] or (0.0, 0.0)
                self.clock[-1] = (outer[0] + dw, outer[1] + dc)
            self.peak = max(self.peak, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024.0)

    def __enter__(self):
        setattr(self.module, self.name, self)
        return self

    def __exit__(self, *exc) -> None:
        setattr(self.module, self.name, self.original)


def stages(path: Path) -> None:
    """The estimate's stages in this process, as ``impactid estimate`` runs them (the pipeline's own calls
    timed where it makes them; numba's functions compiled by a warm-up on 1 s first)."""
    pipeline = Pipeline(model="pivoted-follower", fix_n=1.5)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        warm = read_recording(path, channels=NEEDED)
        pipeline.fit([pipeline.prepare(warm.slice_time(warm.start_time_s, warm.start_time_s + 1.0))], warn=False)
        del warm
        calibration._cached_bias.cache_clear()
        base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024.0
        clock: list = []
        rows = []
        for channels, label in ((None, "all channels"), (NEEDED, ", ".join(NEEDED))):
            wall, cpu = time.perf_counter(), time.process_time()
            rec = read_recording(path, channels=channels)
            rows.append((f"read ({label})", time.perf_counter() - wall, time.process_time() - cpu,
                         resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024.0))
            if channels is None:
                del rec
        timers = [_Timed(reconstruct_module, "find_events", "events (find_events)", clock),
                  _Timed(estimation, "reconstruct", "reconstruct (rk, cam-phase)", clock),
                  _Timed(estimation, "start_contact_damping", "fit: the first search (least squares)", clock),
                  _Timed(estimation, "finish_contact_damping", "fit: the first fit's intervals, checks", clock),
                  _Timed(estimation, "fit_contact_damping", "fit: the refit, phase corrected", clock),
                  _Timed(estimation, "pipeline_bias", "calibration (65 revolutions)", clock),
                  _Timed(estimation, "fit_restitution", "restitution law", clock)]
        for timer in timers:
            timer.__enter__()
        try:
            wall, cpu = time.perf_counter(), time.process_time()
            prepared = pipeline.prepare(rec)
            result = pipeline.fit([prepared], warn=False)
            total_wall, total_cpu = time.perf_counter() - wall, time.process_time() - cpu
        finally:
            for timer in timers:
                timer.__exit__()
    rows += [(t.label, t.wall, t.cpu, t.peak) for t in timers]
    rest_wall = total_wall - sum(t.wall for t in timers)
    rest_cpu = total_cpu - sum(t.cpu for t in timers)
    rows.append(("the rest (tables, event set, checks)", rest_wall, rest_cpu,
                 resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024.0))
    measured = rows[1:]  # the estimate reads once: the shares count the needed channels' read
    total = sum(r[2] for r in measured)
    print(f"\nstages in process (after a 1 s warm-up, {base / 1e9:.3f} GB resident: the interpreter, the libraries "
          "and the warm-up's arrays; the reads: all four channels as the command line reads them, and the two the "
          "estimate needs, which the stages then use)")
    print(f"  {'stage':38s} {'wall [s]':>9s} {'CPU [s]':>8s} {'share':>6s} {'peak RSS [GB]':>14s}")
    for k, (name, wall, cpu, peak) in enumerate(rows):
        share = f"{cpu / total:6.1%}" if k else f"{'-':>6s}"
        print(f"  {name:38s} {wall:9.2f} {cpu:8.2f} {share} {peak / 1e9:14.3f}")
    print(f"  {'all stages (needed channels)':38s} {sum(r[1] for r in measured):9.2f} {total:8.2f}")
    d = result.damping
    print(f"  {len(result.reconstructions[0])} impacts reconstructed; fit: {d.n_simulations} S1 simulations; "
          f"beta {d.beta:.10g}")
    for row in result.calibration:
        print(f"  calibration: {row['alpha_m']:+.3e} +- {row['stderr']:.1e} over {row['events']} events")


def accuracy(noise: float) -> None:
    syn = synth_pivoted(SUNDAR2016, 16.0, LAW, 1.0, sensors=SensorModel(noise=noise, seed=1))
    rec, truth = syn.recording, syn.truth
    dt = 1 / rec.sample_rate_hz
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        events = find_events(rec)
    starts = truth["impacts"]["t_start"]
    onset = np.max(np.abs(events.table["t_onset"].to_numpy() - starts)) / dt
    pp = truth["alpha"].max() - truth["alpha"].min()
    print(f"\naccuracy, noise {noise:.1%} of peak: onset error {onset:.3f} samples (max of {len(events)} events)")
    print(f"  {'integration':10s} {'anchor':13s} {'alpha/pp':>9s} {'alpha_m':>9s} {'xi':>9s} {'v_a':>9s} "
          f"{'force':>9s} {'xi n/a':>6s}")
    for integ, anchor in itertools.product(INTEGRATORS, ANCHORS):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = reconstruct(rec, events, integration=integ, anchor=anchor)
        ea, em, ex, ev, ef = [], [], [], [], []
        for e in r.table.index:
            kin = r.event_kinematics(e)
            k0 = events.table.loc[e, "onset_index"]
            ea.append(np.max(np.abs(kin.alpha - truth["alpha"][k0:k0 + kin.alpha.size])) / pp)
            j = int(np.argmin(np.abs(starts - r.table.loc[e, "t_onset"])))
            ap = truth["apexes"]
            sel = (ap["t"] > starts[j]) & (ap["t"] < starts[j] + 1 / 16)
            em.append(abs(r.table.loc[e, "alpha_m"] / ap["alpha"][sel].max() - 1))
            ex.append(abs(r.table.loc[e, "xi"] - truth["impacts"]["xi"][j]))
            ev.append(abs(r.table.loc[e, "approach_speed"] / -truth["impacts"]["gap_rate_start"][j] - 1))
            hist = r.contact[e]
            true_f = truth["contact_force"][k0:k0 + hist.t.size]
            ef.append(np.max(np.abs(hist.contact_force - true_f)) / true_f.max())
        n_nan = int(np.sum(~np.isfinite(ex)))
        worst_xi = np.nanmax(ex) if n_nan < len(ex) else np.nan
        print(f"  {integ:10s} {anchor:13s} {max(ea):9.2e} {max(em):9.2e} {worst_xi:9.2e} "
              f"{max(ev):9.2e} {max(ef):9.2e} {n_nan:6d}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="skip the 60 s estimate")
    parser.add_argument("--recording", type=Path, default=RECORDING, help="the 60 s recording (made when missing)")
    parser.add_argument("--repeat", type=int, default=3, help="subprocess runs of the estimate (default 3)")
    parser.add_argument("--no-page", action="store_true", help="print only: do not write the page")
    args = parser.parse_args()
    intro = ("Issue 27 (the 60 s estimate): the calibration replays 65 cam revolutions (4.1 s at 16 Hz) instead "
             "of a copy of the recording, cached per rig, operating point, law and sampling; noisy onsets are "
             "fitted in one batch (impactid.events.ONSET_FIT); the return-time anchor starts from the median "
             "of a few solutions and solves the events on numba's threads; the calibration's sampling reuses the "
             "events' noise floor; reconstruction results no longer keep whole windows alive; the readers take "
             "the channels a job needs. Memory: channels of 32 MB or more stored contiguous as float64 are mapped "
             "from the file, not copied (impactid.io.MAP_BYTES): the pivot forces, which rig P reads only around "
             "the impacts, then occupy memory only there (their pages given back every 64 events); the angular "
             "acceleration is divided by the accelerometer's radius where it is read, not copied whole; the noise "
             "floor forms the second difference in chunks and takes its median in place; the rig file's "
             "free-flight check sums flight by flight (it concatenated 12 M samples several times: 1 GB and 3 s). "
             "Every change keeps the estimate's numbers (the noise floor, the events and the fit to the last bit; "
             "the free-flight check's refit to 1e-10). Then: the least-squares search's 41-point start scan, "
             "which only picks where the Gauss-Newton search starts, simulates a part of the events (at most 128, "
             "every recording's at one stride: impactid.rigs.pivoted.damping_objective.SCAN_EVENTS); on this "
             "recording it was four fifths of the fit's 49,868 S1 runs (now 16,428); the event detector solves "
             "each sub-sample edge with a compiled Brent iteration (SciPy's brentq's steps, the same numbers) and "
             "evaluates its baselines without numpy.polyval's array of zeros; the RK4 double integration of "
             "each event window is one compiled pass; a channel stored in SI units is taken without loading the "
             "unit parser (pint: 0.4 s). These keep the estimate's numbers to the last bit (tests/"
             "test_events_compiled.py, tests/rigs/pivoted/test_scan_part.py); only the count of simulations "
             "changes. Then (issue 26's noise-free cam phase): the calibration measures this noise-free "
             "recording's cam-phase bias (-4.3e-5 rad; the recording's own error is -4.5e-5) on one model "
             "recording sampled with its first contact where the measurement's first onset falls, and the fit is "
             "repeated with the phase corrected (the estimate moves by -0.015 %, inside the interval before); the "
             "contact-duration check that pays for that refit replays 128 of the 959 events "
             "(impactid.rigs.pivoted.damping_diagnostics.DURATION_CHECK_EVENTS: 0.6 s per fit), and the "
             "distribution functions come from scipy.special instead of scipy.stats, whose import (with "
             "scipy.signal's) took 0.4 s of every estimate. Then (2026-11-27) a new machine, an AMD EPYC, slower than "
             "the one before (the S1 event 36.6 us instead of 31.5): the command runs with Python's bytecode cache "
             "allowed, as an installation has its bytecode (this workplace sets PYTHONDONTWRITEBYTECODE, under which a "
             "development checkout compiled every module's source in every run: 5.16 s instead of 4.92 s here; "
             "medians of 5.01 s and, of nine runs, 5.00 s in two more runs); and the calibrated estimate finishes "
             "its first fit (intervals, model check, diagnostics) only where no correction refits it "
             "(impactid.rigs.pivoted.damping.start_contact_damping): this noise-free recording's phase correction "
             "refits, and the first fit's discarded intervals and checks took 0.4 s (the estimate and its interval "
             "as before; the count of S1 simulations falls). "
             "CPU seconds are the child's user + system time; on a "
             "loaded machine the wall time exceeds them by the load's share.")
    with BenchmarkPage(None if args.no_page or args.quick else PAGE, "Performance: the 60 s estimate", intro):
        print(f"load average (1 min) at the start {os.getloadavg()[0]:.2f}; {os.cpu_count()} cores; "
              f"NUMBA_NUM_THREADS {os.environ.get('NUMBA_NUM_THREADS', 'default')}")
        if not args.quick:
            path = _recording(args.recording)
            command(path, args.repeat)
            stages(path)
        for noise in (0.0, 0.005):
            accuracy(noise)
        print(f"\nload average (1 min) at the end {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()

"""Scaling of ``impactid campaign``: 1 against 2 workers on this machine, and the capacity of a real cluster.

    python benchmarks/bench_campaign.py [--seconds 2] [--out docs/performance.md] [--keep DIR]

1. **Recordings.** 8 recordings of rig P (Sundar, Dreyer & Singh 2016, beta 24.7 GN s m^-2.5, n 1.5):
   4 period-1 operating points (e/r_c, Hz) = (0.05, 16), (0.1, 14), (0.2, 16), (0.25, 15), 2 repeats
   each (different noise), ``--seconds`` each (default 2) at 204.8 kHz after 40 s of settling, 0.2 %
   Gaussian noise on the accelerometer and force channels, 24-bit ADC; written by impactid's
   generator into a temporary folder (``--keep DIR``: into DIR, with the campaign file, for running
   ``impactid campaign DIR/campaign.toml`` yourself).
2. **The campaign.** Every recording prepared (events, reconstruction) and fitted alone (n fixed at
   1.5), and each repeat's 4 recordings fitted jointly (beta and n): 8 prepare tasks, 8 single fits
   and 2 joint fits, with impactid's default pipeline (least squares, calibrated).
3. **Scaling.** The campaign on a local dask cluster of 1 worker, then of 2 workers (each a fresh
   cluster and a fresh output folder; numba's caches warm: each cluster first runs a warm-up
   campaign of one short recording). Wall time of the campaign alone (the cluster's start is
   reported apart), the ratio, recordings per hour per core, and the peak resident memory of each
   worker process (psutil, sampled every 0.2 s).
4. **Duration.** One recording of the first point at 2 s and at 8 s, prepared and fitted alone on
   the 1-worker cluster: wall time and the worker's peak memory against the recorded time, a straight
   line through the two, extrapolated to a 60 s recording at 204.8 kHz (the laboratory's); the
   capacity of a real cluster follows from it.

Writes ``--out`` (default ``docs/performance.md``) with the measured figures, the capacity estimate
and the method.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import platform
import shutil
import sys
import tempfile
import threading
import time
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402
import psutil  # noqa: E402

from impactid import SUNDAR2016, HuntCrossley, __version__  # noqa: E402
from impactid.campaign import load_campaign, run_campaign  # noqa: E402
from impactid.distributed import connect  # noqa: E402
from impactid.synth import SensorModel, synth_pivoted  # noqa: E402

LAW = HuntCrossley(24.7e9, 1.5)
POINTS = ((0.05, 16.0), (0.1, 14.0), (0.2, 16.0), (0.25, 15.0))
REPEATS = 2
#: The laboratory's recording: 60 s at 204.8 kHz.
TARGET_SECONDS = 60.0
#: Durations [s] of the single-recording runs the extrapolation to TARGET_SECONDS is drawn through.
DURATIONS = (2.0, 16.0)


def make_recording(folder: Path, name: str, ratio: float, hz: float, seconds: float, seed: int) -> Path:
    """One recording of rig P at (e/r_c, cam speed [Hz]), ``seconds`` long, 0.2 % noise, 24-bit ADC."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        synthetic = synth_pivoted(SUNDAR2016.with_eccentricity_ratio(ratio), hz, LAW, seconds,
                                  sensors=SensorModel(noise=0.002, adc_bits=24, seed=seed))
    return synthetic.write(folder / f"{name}.h5")


def write_campaign(folder: Path, entries: list[tuple[str, str | None]], name: str) -> Path:
    """A campaign file in ``folder``: ``entries`` are (recording name, group or None)."""
    lines = ["[campaign]", f'name = "{name}"', 'out = "results"', ""]
    for rec, group in entries:
        lines += ["[[recording]]", f'path = "{rec}.h5"'] + ([f'group = "{group}"'] if group else []) + [""]
    path = folder / "campaign.toml"
    path.write_text("\n".join(lines))
    return path


def make_campaign(folder: Path, seconds: float) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    entries = []
    for repeat in range(1, REPEATS + 1):
        for k, (ratio, hz) in enumerate(POINTS):
            name = f"op{k + 1}_e{ratio:g}_{hz:g}Hz_r{repeat}"
            make_recording(folder, name, ratio, hz, seconds, seed=10 * repeat + k)
            entries.append((name, f"repeat{repeat}"))
    return write_campaign(folder, entries, f"bench {len(entries)} recordings x {seconds:g} s")


def single_campaign(folder: Path, seconds: float, seed: int = 99) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    ratio, hz = POINTS[0]
    make_recording(folder, "one", ratio, hz, seconds, seed)
    return write_campaign(folder, [("one", None)], f"one recording x {seconds:g} s")


class PeakMemory(threading.Thread):
    """Peak resident memory [bytes] of each of the processes ``pids``, sampled every ``every`` seconds."""

    def __init__(self, pids, every: float = 0.2):
        super().__init__(daemon=True)
        self.procs = {pid: psutil.Process(pid) for pid in pids}
        self.peak = dict.fromkeys(pids, 0)
        self.every = every
        self.stop = threading.Event()

    def run(self) -> None:
        while not self.stop.is_set():
            for pid, proc in self.procs.items():
                try:
                    self.peak[pid] = max(self.peak[pid], proc.memory_info().rss)
                except psutil.Error:
                    pass
            self.stop.wait(self.every)

    def __enter__(self) -> PeakMemory:
        self.start()
        return self

    def __exit__(self, *exc) -> None:
        self.stop.set()
        self.join()


def cpu_seconds(pids) -> float:
    """User + system CPU time [s] the processes ``pids`` have used so far."""
    total = 0.0
    for pid in pids:
        times = psutil.Process(pid).cpu_times()
        total += times.user + times.system
    return total


def run_measured(client, campaign: Path, out: Path) -> dict:
    """The campaign on ``client`` into a fresh ``out``: wall time [s], CPU time of the workers and of
    this process [s], peak memory per worker [bytes]."""
    shutil.rmtree(out, ignore_errors=True)
    spec = load_campaign(campaign)
    pids = list(client.run(os.getpid).values())
    cpu0, here0 = cpu_seconds(pids), cpu_seconds([os.getpid()])
    with PeakMemory(pids) as memory:
        t0 = time.perf_counter()
        result = run_campaign(spec, out, client=client)
        wall = time.perf_counter() - t0
    assert result.skipped == 0, "a fresh output folder"
    return {"wall": wall, "cpu": cpu_seconds(pids) - cpu0, "cpu_driver": cpu_seconds([os.getpid()]) - here0,
            "peak_rss": max(memory.peak.values()), "peaks": sorted(memory.peak.values()), "result": result,
            "load": os.getloadavg()}


def line(x0: float, y0: float, x1: float, y1: float, x: float) -> float:
    """The straight line through (x0, y0) and (x1, y1), at x."""
    return y0 + (y1 - y0) * (x - x0) / (x1 - x0)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=2.0, help="length of each campaign recording [s] (default 2)")
    parser.add_argument("--repeats", type=int, default=3,
                        help="campaign runs per configuration, alternating 1 and 2 workers (default 3)")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "performance.md", help="page written")
    parser.add_argument("--keep", type=Path, default=None, help="write the recordings and campaign file here")
    parser.add_argument("--durations", default=",".join(f"{d:g}" for d in DURATIONS), metavar="D0,D1",
                        help="recorded times [s] of the single-recording runs (default 2,16)")
    args = parser.parse_args(argv)
    durations = tuple(float(x) for x in args.durations.split(","))
    started = time.perf_counter()
    load_before = os.getloadavg()
    work = Path(tempfile.mkdtemp(prefix="bench_campaign_"))
    try:
        folder = args.keep or work / "recordings"
        print(f"writing {len(POINTS) * REPEATS} recordings of {args.seconds:g} s to {folder}", flush=True)
        campaign = make_campaign(folder, args.seconds)
        warm = single_campaign(work / "warm", 0.3)
        by_duration = {d: single_campaign(work / f"d{d:g}", d) for d in durations}
        runs: dict[int, list[dict]] = {1: [], 2: []}
        starts: dict[int, float] = {}
        scaling = {}
        with contextlib.ExitStack() as stack:
            clients = {}
            for workers in (1, 2):
                t0 = time.perf_counter()
                clients[workers] = stack.enter_context(connect(workers=workers))
                starts[workers] = time.perf_counter() - t0
                run_campaign(load_campaign(warm), work / f"warm_out{workers}", client=clients[workers])  # numba warm
                print(f"{workers} worker(s): cluster started in {starts[workers]:.1f} s, warm-up done", flush=True)
            # the two clusters stay up and the runs alternate, so that the other jobs' load falls on both alike
            for repeat in range(args.repeats):
                for workers in (1, 2):
                    r = run_measured(clients[workers], campaign, work / f"out{workers}")
                    runs[workers].append(r)
                    print(f"  run {repeat + 1}, {workers} worker(s): {r['wall']:.1f} s, CPU {r['cpu']:.0f} s, "
                          f"{r['result'].ran} fits ({r['result'].failed} failed), peak memory per worker "
                          f"{r['peak_rss'] / 1e6:.0f} MB, load {r['load'][0]:.1f}", flush=True)
            for d, path in by_duration.items():
                scaling[d] = run_measured(clients[1], path, work / f"d{d:g}_out")
                print(f"  one recording of {d:g} s: {scaling[d]['wall']:.1f} s, CPU {scaling[d]['cpu']:.1f} s, peak "
                      f"{scaling[d]['peak_rss'] / 1e6:.0f} MB", flush=True)
        load_after = os.getloadavg()
        page = report(args, runs, starts, scaling, load_before, load_after, time.perf_counter() - started)
        args.out.write_text(page)
        print(f"wrote {args.out}")
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return 0


def _duration(hours: float) -> str:
    return f"{hours:.1f} h" if hours >= 1.0 else f"{60 * hours:.0f} min"


def report(args, runs: dict, starts: dict, scaling: dict, load_before, load_after, total: float) -> str:
    n_rec = len(POINTS) * REPEATS
    median = {w: float(np.median([r["wall"] for r in rs])) for w, rs in runs.items()}
    ratio = median[1] / median[2]
    pairs = [a["wall"] / b["wall"] for a, b in zip(runs[1], runs[2])]
    cpu = {w: float(np.median([r["cpu"] + r["cpu_driver"] for r in rs])) for w, rs in runs.items()}
    share = {w: float(np.median([r["cpu"] / r["wall"] for r in rs])) for w, rs in runs.items()}
    shared = share[1] < 0.9  # a single-threaded worker alone on a core gets nearly all of it
    cpu_rate = n_rec / (float(np.median([r["cpu"] + r["cpu_driver"] for rs in runs.values() for r in rs])) / 3600.0)
    (d0, s0), (d1, s1) = sorted(scaling.items())
    cpu_of = {d: v["cpu"] + v["cpu_driver"] for d, v in scaling.items()}
    cpu_target = line(d0, cpu_of[d0], d1, cpu_of[d1], TARGET_SECONDS)
    cpu_campaign_rec = line(d0, cpu_of[d0], d1, cpu_of[d1], args.seconds)
    # the campaign's cost per recording (its share of the joint fits included) scales as one recording's
    scale = cpu_target / cpu_campaign_rec
    per_core_target = cpu_rate / scale
    mem_target = line(d0, s0["peak_rss"], d1, s1["peak_rss"], TARGET_SECONDS)
    mem_campaign = max(r["peak_rss"] for rs in runs.values() for r in rs)
    first = runs[1][0]
    res1 = first["result"].table
    single = res1[(res1["kind"] == "single") & (res1["status"] == "ok")]
    joint = res1[(res1["kind"] == "joint") & (res1["status"] == "ok")]
    # a joint fit's share of the 1-worker campaign (its tasks ran one after the other), per recording it holds
    joint_fraction = float(res1.loc[res1["kind"] == "joint", "seconds"].sum()) / first["wall"]
    joint_cpu_per_rec = joint_fraction * (first["cpu"] + first["cpu_driver"]) / n_rec
    group = 40
    longest = group * joint_cpu_per_rec * scale / 3600.0
    cores = os.cpu_count()
    ok = all(r["result"].failed == 0 for rs in runs.values() for r in rs)
    same = all(np.array_equal(r["result"].table["beta"].to_numpy(), res1["beta"].to_numpy(), equal_nan=True)
               for rs in runs.values() for r in rs)
    gb = 1e9
    fits = first["result"].fits
    limit = 1.5 * mem_target
    node_workers = max(1, int(64 * gb // limit))
    example = 120
    hours = {c: max(example / (per_core_target * c), longest) for c in (32, 128)}
    loads = [r["load"][0] for rs in runs.values() for r in rs]
    rows = [
        "# Performance: campaigns on a cluster", "",
        f"Generated by `python benchmarks/bench_campaign.py` ({time.strftime('%Y-%m-%d')}, impactid {__version__}, "
        f"{platform.machine()}, {cores} cores, {psutil.virtual_memory().total / gb:.0f} GB, Python "
        f"{platform.python_version()}; {total / 60:.0f} min). Every figure below was measured by that run.", "",
        (f"**The machine was shared with other jobs while it ran** (the 1-worker campaign's worker obtained "
         f"{share[1]:.2f} of a core): its load average (processes wanting a core, for "
         f"{cores} cores) was {load_before[0]:.1f} when the run started, {min(loads):.1f} to {max(loads):.1f} after "
         f"each campaign and {load_after[0]:.1f} at the end. The wall times are therefore longer than on an idle "
         "machine, and the 2-worker speed-up is limited by the cores the other jobs took, not by impactid. The "
         "capacity estimate is computed from the CPU time the campaign's processes used (what a dedicated core would "
         "give them), which the other jobs change much less." if shared else
         f"The machine ran nothing else of note: the 1-worker campaign's worker obtained {share[1]:.2f} of a core "
         f"(its CPU time over the wall time); the load average (processes wanting a core, for {cores} cores, the "
         f"campaign's own included) was {load_before[0]:.1f} when the run started, {min(loads):.1f} to "
         f"{max(loads):.1f} after each campaign and {load_after[0]:.1f} at the end."), "",
        "## The campaign", "",
        f"{n_rec} recordings of rig P (beta 24.7 GN s m^-2.5, n 1.5) at 4 period-1 operating points (e/r_c, Hz) = "
        + ", ".join(f"({r:g}, {h:g})" for r, h in POINTS)
        + f", 2 repeats each, {args.seconds:g} s at 204.8 kHz, 0.2 % noise, 24-bit ADC. The campaign prepares each "
        "recording once (events, reconstruction), fits each alone with n fixed at 1.5, and fits each repeat's 4 "
        f"recordings jointly (beta and n free): {n_rec} prepare tasks and {fits} fits, impactid's default pipeline "
        "(least squares, calibrated). Two local clusters (`impactid.distributed.connect(workers=N)`: N "
        "single-threaded worker processes, `NUMBA_NUM_THREADS=1`), of 1 and of 2 workers, were started and warmed "
        "up (a campaign of one short recording each: numba's on-disk caches loaded); then the campaign ran "
        f"{args.repeats} times on each, alternating, each time into a fresh output folder (so that the other jobs' "
        f"load, which drifts, falls on both alike). Cluster start: {starts[1]:.1f} s (1 worker), {starts[2]:.1f} s "
        "(2 workers), not included below.", "",
        "CPU time is that of the worker processes plus that of the command's process (which holds the local "
        "cluster's scheduler and nannies).", "",
        "| run | workers | campaign wall time [s] | CPU time, workers + command [s] | fits (failed) | load after | "
        "peak memory per worker [MB] |",
        "|---|---|---|---|---|---|---|",
    ]
    for k in range(len(runs[1])):
        for w in (1, 2):
            r = runs[w][k]
            rows.append(f"| {k + 1} | {w} | {r['wall']:.1f} | {r['cpu']:.0f} + {r['cpu_driver']:.0f} | "
                        f"{r['result'].ran} ({r['result'].failed}) | {r['load'][0]:.1f} | "
                        f"{', '.join(f'{p / 1e6:.0f}' for p in r['peaks'])} |")
    rows += [
        "",
        f"**Ratio** of the median wall times, 1 worker over 2 workers: **{ratio:.2f}** ({median[1]:.1f} s against "
        f"{median[2]:.1f} s; run by run {', '.join(f'{p:.2f}' for p in pairs)}; ideal 2). Recordings per hour per "
        f"core, from the median wall times: {n_rec / (median[1] / 3600):.0f} (1 worker), "
        f"{n_rec / (median[2] / 3600) / 2:.0f} (2 workers); from the CPU time (median {cpu[1]:.0f} s and "
        f"{cpu[2]:.0f} s): {cpu_rate:.0f} recordings of {args.seconds:g} s per CPU-hour. The worker processes "
        f"obtained on average {share[1]:.2f} cores (1 worker) and {share[2]:.2f} cores (2 workers) (their CPU time "
        "over the wall time)"
        + (": the ratio measures how much more of the machine two processes obtained from the other jobs as much as "
           "the campaign's parallelism. " if shared else
           "; the 2 workers fall short of 2 cores by the time one of them waits for the other's results (the joint "
           "fits need their recordings prepared) and by the command's own process, which shares the cores. ")
        + "A campaign's own parallelism is its independent tasks: "
        f"{n_rec} prepare tasks and {n_rec} single fits, then "
        f"{fits - n_rec} joint fits that wait for their recordings; the last joint fit to start bounds the wall "
        "time from below whatever the number of workers.", "",
        "Estimates of the first 1-worker run: single fits beta "
        f"{single['beta'].min() / 1e9:.2f} to {single['beta'].max() / 1e9:.2f} GN s m^-2.5 (truth 24.7); joint fits "
        + "; ".join(f"beta {r.beta / 1e9:.1f} GN s m^-(n+1), n {r.n:.3f} [{r.n_lo:.3f}, {r.n_hi:.3f}]"
                    for r in joint.itertuples())
        + f" (truth n 1.5). Every fit {'ended in an estimate' if ok else 'did not end in an estimate (see the table)'}"
        + ("; every other run gave the same numbers." if same else "; other runs' numbers differ (a bug).")
        + "", "",
        "## Recorded time, and a 60 s recording", "",
        "One recording of the first point, prepared and fitted alone (n fixed) on the warm 1-worker cluster:", "",
        "| recorded time [s] | wall time [s] | CPU time [s] | peak worker memory [MB] |", "|---|---|---|---|",
    ]
    for d, v in sorted(scaling.items()):
        rows.append(f"| {d:g} | {v['wall']:.1f} | {cpu_of[d]:.1f} | {v['peak_rss'] / 1e6:.0f} |")
    rows += [
        f"| {TARGET_SECONDS:g} (the straight line through the two) | | {cpu_target:.0f} | {mem_target / 1e6:.0f} |",
        "",
        "Assumptions: the work of a recording grows linearly with its recorded time (impacts per second are set by "
        "the cam speed; every impact is reconstructed and replayed in each objective evaluation; the calibration "
        "simulates the recording's own length after a fixed 40 s of settling: the constant part), so CPU time and "
        "memory are straight lines in the recorded time; a joint fit costs about what its recordings' single fits "
        "cost together (it replays the same impacts), so the whole campaign's cost per recording scales like one "
        "recording's. The memory line holds the samples of the recording (4 channels of 8-byte samples: 393 MB per "
        "minute at 204.8 kHz), the calibration's simulated recording and the per-sample work arrays of the event "
        "detection and reconstruction, over the worker's fixed part (Python, numpy, numba, pandas, dask).", "",
        "## Capacity of a real cluster", "",
        f"From the campaign's CPU time ({cpu_rate:.0f} recordings of {args.seconds:g} s per CPU-hour, the median of "
        f"the {2 * args.repeats} runs) and the duration line (a {TARGET_SECONDS:g} s recording costs {scale:.1f} "
        f"times the CPU time of a {args.seconds:g} s one):", "",
        f"* **{per_core_target:.1f} recordings of {TARGET_SECONDS:g} s at 204.8 kHz per hour per core** (each fitted "
        f"alone and in its group's joint fit), i.e. {60 / per_core_target:.1f} core-minutes per recording;",
        f"* **about {mem_target / gb:.1f} GB per worker** (peak resident memory of a worker preparing and fitting a "
        f"{TARGET_SECONDS:g} s recording; {mem_campaign / 1e6:.0f} MB in the {args.seconds:g} s campaign above); "
        f"with a limit of 1.5 times that per worker (`dask worker --memory-limit {limit / gb:.1f}GB`), "
        f"{node_workers} workers fit a node with 64 GB;",
        f"* a campaign of {example} such recordings (40 operating points x 3 repeats, "
        f"{example * TARGET_SECONDS * 204800 * 4 * 8 / gb:.0f} GB of samples; each repeat's {group} recordings one "
        f"joint group) needs {example / per_core_target:.1f} core-hours: about {_duration(hours[32])} on 32 cores "
        f"and {_duration(hours[128])} on 128. A joint fit is one task, so the wall time is at least the longest: "
        f"the joint fits took {100 * joint_fraction:.0f} % of the 1-worker campaign, "
        f"{joint_cpu_per_rec:.2f} CPU-seconds per {args.seconds:g} s recording they hold, so a group of {group} "
        f"recordings of {TARGET_SECONDS:g} s is a task of about {_duration(longest)}"
        + (" (the figures above include that bound)" if longest >= min(hours.values()) - 1e-9 else "")
        + "; smaller groups (e.g. one per range of operating points) let more cores help.", "",
        "Reading the recordings from a shared file system adds its transfer time (393 MB per minute of recording, "
        "read once by the prepare task); the command's process writes only the results (tens of kB per fit).", "",
        "## Running a campaign", "",
        "```bash",
        "impactid campaign campaign.toml                       # local cluster, one worker per core",
        "impactid campaign campaign.toml --workers 4           # local cluster of 4 workers",
        "impactid campaign DIR --out results/ --serial         # in this process, without dask",
        "# a real cluster: a scheduler, and single-threaded workers on each node",
        "dask scheduler --scheduler-file /shared/sched.json &",
        "NUMBA_NUM_THREADS=1 dask worker --scheduler-file /shared/sched.json --nworkers 32 --nthreads 1 \\",
        f"    --memory-limit {limit / gb:.1f}GB &",
        "impactid campaign campaign.toml --scheduler /shared/sched.json",
        "```", "",
        "The workers read the recordings by their paths and must import the same impactid: put the recordings, "
        "the campaign file and the output folder on a file system every node sees under the same path, and install "
        "the same impactid on every node. The command's process writes every output (the fit JSON files as each fit "
        "finishes, the table at the end). Regime maps (`impactid regime-map --workers N | --scheduler ADDRESS`), "
        "bifurcation diagrams (`impactid bifurcation`, the same options) and the envelope validation "
        "(`python benchmarks/validate_envelope.py --workers N`) map their independent points over the same kinds "
        "of cluster; they run serially by default.", "",
        "## Dependencies", "",
        "The cluster needs `dask[distributed]`, the table `pyarrow` (Parquet) and the progress bar `tqdm`: the "
        "`campaign` extra (`pip install 'impactid[campaign]'`), which the `test` extra includes. They are an extra, "
        "not dependencies, because the main job (`impactid estimate`) needs none of them and they are large (pyarrow "
        "alone installs about 170 MB, as much as scipy and numpy together); `impactid campaign` names what is "
        "missing (`impactid: error: impactid campaign needs distributed, not installed here: install the 'campaign' "
        "extra (pip install 'impactid[campaign]')`), and `--serial` runs without dask.", "",
    ]
    return "\n".join(rows)


if __name__ == "__main__":
    sys.exit(main())

"""Per-impact pipeline (issue 4): speed on a 60 s recording and accuracy of every method.

1. Speed: a 60 s S2 recording at 204.8 kHz (e/r_c 0.2, 16 Hz: 960 impacts) through
   ``find_events`` + ``reconstruct`` (rk, return-time); prints seconds and samples per second.
   Target: under 10 s.
2. Accuracy against the synthetic truth, 1 s recordings (15 usable events), noise-free and with
   0.5 % Gaussian noise on every analogue channel: onset error [samples], alpha error [fraction of
   peak-to-peak, worst sample of all events], alpha_m [relative], xi [absolute], v_a [relative],
   contact force [fraction of peak] for each integration method and anchor.

Run: ``python benchmarks/bench_pipeline.py`` (``--quick`` skips the 60 s run).
"""

from __future__ import annotations

import argparse
import itertools
import time
import warnings

import numpy as np

from impactid import SUNDAR2016, HuntCrossley
from impactid.events import find_events
from impactid.rigs.pivoted.reconstruct import ANCHORS, reconstruct
from impactid.rigs.pivoted.synth import synth_pivoted
from impactid.signal import INTEGRATORS
from impactid.synth import SensorModel

LAW = HuntCrossley(24.7e9, 1.5)


def speed() -> None:
    syn = synth_pivoted(SUNDAR2016, 16.0, LAW, 60.0)
    rec = syn.recording
    t0 = time.perf_counter()
    events = find_events(rec)
    t1 = time.perf_counter()
    result = reconstruct(rec, events)
    t2 = time.perf_counter()
    print(f"speed: {rec.duration:g} s at {rec.sample_rate_hz:g} Hz ({rec.n_samples / 1e6:.1f} M samples), "
          f"{len(events)} events, {len(result)} reconstructed")
    print(f"  find_events {t1 - t0:.2f} s, reconstruct {t2 - t1:.2f} s, total {t2 - t0:.2f} s "
          f"-> {rec.n_samples / (t2 - t0) / 1e6:.2f} M samples/s (target: total < 10 s)")


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
    parser.add_argument("--quick", action="store_true", help="skip the 60 s speed run")
    args = parser.parse_args()
    if not args.quick:
        speed()
    for noise in (0.0, 0.005):
        accuracy(noise)


if __name__ == "__main__":
    main()

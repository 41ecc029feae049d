"""The campaign file's format, as ``impactid campaign --help`` shows it.

A module of text only: the command line's help reads it without loading pandas, numba or the
pipeline (:mod:`impactid.campaign` re-exports it).
"""

from __future__ import annotations

__all__ = ["FORMAT_HELP"]

#: The campaign file, as ``impactid campaign --help`` shows it.
FORMAT_HELP = """\
Every recording of a campaign is fitted alone (Hunt-Crossley beta with n fixed at 1.5 unless the
campaign says otherwise) and the recordings of each group jointly (beta and n), on a dask cluster.
Each recording is read, segmented and reconstructed once; its product feeds its own fit and its
group's. Each fit is written to OUT/fits/<key>.json as soon as it finishes, the summary table to
OUT/campaign.parquet and OUT/campaign.csv at the end (all files written atomically). The key of a
fit is a SHA-256 of its recordings' content, the options and the impactid version: a rerun skips
the finished fits and runs the failed ones again. A fit that cannot be done (a corrupt file, rigs
that differ in a group, a worker that died) is a failed row with its reason; the others go on.

The campaign file (TOML; paths relative to its folder):

    [campaign]
    name = "rig P, March 2026"
    out = "results"          # output folder (--out overrides)
    single_fits = true       # fit every recording alone (default true)
    model = "pivoted-follower"   # the rig model whose estimate the fits run (the
                             # default; e.g. "drop-impact": its options below)

    [options]                # options of every fit: the rig's estimate options
    residual = "lambda1"     # (impactid.Pipeline; rig P: residual, method, integration,
    method = "least-squares" # anchor, n_bounds, calibrate, ...)

    [single]                 # the per-recording fits, over [options] (default fix_n = 1.5)
    fix_n = 1.5

    [joint]                  # the joint fits, over [options] (default: n estimated)
    fix_n = "free"

    [[recording]]
    path = "op01_a.h5"
    group = "rigP"           # recordings of one group are fitted jointly
    [[recording]]
    path = "op02_a.csv"
    rig = "rigP.toml"        # optional rig file ([rig] and [operating])
    cam_speed_hz = 15.0      # optional overrides of the operating point [Hz]
    e_over_rc = 0.25         # and of the eccentricity ratio e/r_c
    group = "rigP"
    name = "op02-a"          # optional (default: the file name without suffix)

A folder instead of a campaign file: every recording in it (*.h5, *.hdf5, *.csv; not in
sub-folders) is fitted alone, and the recordings of each rig jointly: those whose files name the
same rig model and parameters (but the eccentricity e), two or more to a group (group "all" when
that is every recording, else the model's name, e.g. "pivoted-follower"); the fits run the
estimate of its recordings' rig model. A group that names one recording twice (one file, or two
files of identical content), or recordings of different rigs, is a failed joint fit with the
reason, as is a recording whose rig cannot be fitted or is not the campaign's model; the others
stand, and these failures cost no preparation.
"""

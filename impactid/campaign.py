"""Campaigns: many recordings of a rig, their per-recording and joint fits, as one resumable task graph.

A laboratory records a campaign (tens of operating points, several repeats each) and wants every
recording fitted alone and the recordings of one rig fitted jointly. :func:`run_campaign` runs that
job on a ``dask.distributed`` cluster (or serially in this process) and keeps every finished part:

* **The task graph.** Per recording, one *prepare* task reads the file, finds the impacts and
  measures them (:meth:`impactid.pipeline.Pipeline.prepare`; rig P: the event set and reconstruction);
  its product (without the samples: a few kB per impact, picklable) feeds the recording's own fit
  and every joint fit of a group that holds the recording, so that no reconstruction is computed
  twice. Per recording one *single* fit (n fixed at 1.5 unless the campaign says otherwise), per
  group one *joint* fit of its recordings.
* **Keys.** Every task is keyed by a SHA-256 of what decides its result: the content of the
  recording (and of its rig files), the operating-point overrides, the pipeline options and the
  impactid version. File digests are cached in the output folder by (path, size, modification time),
  so that a rerun does not read large files again.
* **Outputs**, all written atomically (a temporary file renamed into place, permissions from the
  umask): ``fits/<key>.json`` per fit as soon as it finishes (status, reason, the estimate as the
  rig's :attr:`~impactid.rigs.base.Estimator.to_dict` writes it); ``prepared/<key>.pkl`` per prepared recording (the
  cache of the joint fits; delete it freely); at the end the summary table ``campaign.parquet`` and
  ``campaign.csv`` (one row per fit; rebuilt from the JSON files by :func:`summary_table`).
* **Reruns.** A fit whose ``fits/<key>.json`` holds a finished estimate is not run again (reported
  as skipped); a prepare task whose product is cached loads it. Failed fits are run again.
* **Failures.** A part that cannot be done (a corrupt or missing file, a rig mismatch in a group, a
  worker that died three times on the same task) is recorded as a failed row with a one-line reason
  and takes no other part with it; a joint fit whose recording could not be prepared fails naming
  it. A worker that dies loses only its running task: dask runs it again on another worker, and the
  finished results are already on disk. What the files' digests and headers tell before anything
  is prepared fails at once, without a task: a recording that cannot be read or whose rig impactid
  cannot fit (:func:`read_rig_header`), a group that names one recording twice (one file, or two
  files of identical content: its impacts would count twice) or recordings of different rigs.
* **Folders.** A folder's recordings are grouped by rig (:func:`rig_groups`): the recordings whose
  headers name the same rig model and parameters (but the eccentricity) are fitted jointly.
* **Rigs.** A campaign runs the estimate of one rig model (:attr:`CampaignSpec.model`: the campaign
  file's ``[campaign] model``, a folder's recordings' model, else the registry's default): its
  options are checked against that rig's estimate (:attr:`impactid.rigs.base.Estimator.options`),
  and a recording of another rig is a failed part known without a task.

The campaign file and the folder form: :data:`FORMAT_HELP` (docs/formats.md).
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib.util
import json
import math
import os
import pickle
import socket
import time
import tomllib
import traceback
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import pandas as pd

from impactid._files import StagedFiles, atomic_write, same_file
from impactid._version import __version__
from impactid.campaign_format import FORMAT_HELP  # re-exported: the text lives in a light module
from impactid.commandline import json_text
from impactid.errors import ImpactidError
from impactid.html_report import campaign_page
from impactid.pipeline import Pipeline, PreparedRecording, _estimable, rig_estimator
from impactid.rigs.base import OptionError
from impactid.rigs.registry import DEFAULT_EXAMPLE_MODEL, PLUGINS, estimable_models

__all__ = ["FORMAT_HELP", "OPERATING_RIG_PARAMETERS", "CampaignError", "CampaignResult", "CampaignSpec", "FitJob",
           "FitOutcome", "PrepareJob", "PrepareOutcome", "RecordingSpec", "RigHeader", "fit_task", "load_campaign",
           "plan", "prepare_task", "read_fits", "read_recording_spec", "read_rig_header", "rig_groups",
           "parquet_available", "run_campaign", "summary_table", "write_campaign_report"]

#: Recording files a campaign folder is scanned for.
RECORDING_SUFFIXES = (".h5", ".hdf5", ".csv")
#: Version of the keys and of the files of the output folder (a change makes every task run again).
FORMAT_VERSION = 2
#: The per-recording fits fix the Hunt–Crossley exponent at the Hertz value unless told otherwise:
#: one operating point cannot tell beta and n apart (docs/estimation.md).
SINGLE_DEFAULTS = {"fix_n": 1.5}
#: Bytes read at a time when hashing a recording.
HASH_CHUNK = 1 << 22
HASH_CACHE = ".impactid-hashes.json"
TABLE_NAME = "campaign"
#: The rig model whose estimate a campaign runs when neither its file nor its folder's recordings say.
DEFAULT_MODEL = DEFAULT_EXAMPLE_MODEL

_RECORDING_KEYS = {"path", "name", "group", "rig", "cam_speed_hz", "e_over_rc"}
_TOP_KEYS = {"campaign", "options", "single", "joint", "recording"}
_CAMPAIGN_KEYS = {"name", "out", "single_fits", "model"}




class CampaignError(ImpactidError, ValueError):
    """A campaign file or folder that cannot be used (named in the message)."""


# ---- the campaign -----------------------------------------------------------------------------------


@dataclass(frozen=True)
class RecordingSpec:
    """One recording of a campaign.

    Attributes
    ----------
    name : its name in the campaign (unique; the file name without suffix by default).
    path : the recording file (HDF5 or CSV).
    rig : a TOML rig file that supplies or overrides the recording's rig and operating point, or None.
    cam_speed_hz : override of the operating point's cam speed [Hz], or None.
    e_over_rc : override of the rig's eccentricity ratio ``e / r_c`` [-], or None.
    group : the group of recordings fitted jointly with this one, or None.
    """

    name: str
    path: Path
    rig: Path | None = None
    cam_speed_hz: float | None = None
    e_over_rc: float | None = None
    group: str | None = None

    def overrides(self) -> dict:
        """The operating-point overrides (JSON-ready; part of the key)."""
        return {"cam_speed_hz": self.cam_speed_hz, "e_over_rc": self.e_over_rc}

    def inputs(self) -> list[Path]:
        """Every file the recording is made of: the recording, its CSV rig file, ``rig``."""
        files = [self.path]
        if self.path.suffix.lower() == ".csv" and self.rig is None:
            files.append(self.path.with_suffix(".toml"))
        if self.rig is not None:
            files.append(self.rig)
        return files


@dataclass(frozen=True)
class CampaignSpec:
    """A campaign: its recordings, their groups and the options of the fits.

    Attributes
    ----------
    name : the campaign's name (in the table and the JSON files).
    recordings : the recordings, in the order of the file (or of their names in a folder).
    single : the pipeline of the per-recording fits (None: no per-recording fits).
    joint : the pipeline of the joint fits.
    source : the campaign file or folder it was read from (None when built in code).
    out : the output folder the campaign file names, or None.
    model : the rig model whose estimate the fits run; the pipelines hold every option of it
        (:meth:`impactid.pipeline.Pipeline.bind`).
    """

    name: str
    recordings: tuple[RecordingSpec, ...]
    single: Pipeline | None = field(default_factory=lambda: Pipeline(**SINGLE_DEFAULTS))
    joint: Pipeline = field(default_factory=Pipeline)
    source: Path | None = None
    out: Path | None = None
    model: str = DEFAULT_MODEL

    def __post_init__(self) -> None:
        _check_model(self._where(), self.model)
        for name in ("single", "joint"):
            pipeline = getattr(self, name)
            if pipeline is not None:
                try:
                    object.__setattr__(self, name, pipeline.bind(self.model))
                except OptionError as exc:
                    raise CampaignError(f"{self._where()}: [{name}]: {exc}") from None
        names = [r.name for r in self.recordings]
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise CampaignError(f"{self._where()}: recording names must be unique; {', '.join(twice)} appear more "
                                "than once (give each a name = \"...\")")
        if not self.recordings:
            raise CampaignError(f"{self._where()}: no recording in the campaign")
        for group, members in self.groups().items():
            if len(members) < 2:
                raise CampaignError(f"{self._where()}: group {group!r} has one recording ({members[0].name}); a joint "
                                    "fit needs two or more (add recordings or remove the group)")

    def _where(self) -> str:
        return str(self.source) if self.source is not None else "campaign"

    def groups(self) -> dict[str, tuple[RecordingSpec, ...]]:
        """The groups of jointly fitted recordings, by name (in the order they first appear)."""
        out: dict[str, list[RecordingSpec]] = {}
        for r in self.recordings:
            if r.group is not None:
                out.setdefault(r.group, []).append(r)
        return {k: tuple(v) for k, v in out.items()}

    def inputs(self) -> list[Path]:
        """Every input file of the campaign (for the output checks)."""
        files = [p for r in self.recordings for p in r.inputs()]
        if self.source is not None and self.source.is_file():
            files.append(self.source)
        return files


def _check_model(where: str, model: Any) -> None:
    """Refuse a campaign model that is no registered rig model with an estimate."""
    if not isinstance(model, str) or model not in PLUGINS:
        raise CampaignError(f"{where}: [campaign]: model must be a rig model name (one of {', '.join(PLUGINS)}), "
                            f"got {model!r}")
    able = estimable_models()
    if model not in able:
        raise CampaignError(f"{where}: [campaign]: impactid estimates no contact law from {model!r} recordings (model "
                            f"must be one of {', '.join(able)})")


def _pipeline(where: str, table: str, options: dict, model: str) -> Pipeline:
    """The pipeline of a table of the campaign file: every option of ``model``'s estimate, the table's
    given (an unknown option or a refused value names the table)."""
    values = dict(options)
    if isinstance(values.get("fix_n"), str):
        if values["fix_n"].strip().lower() != "free":
            raise CampaignError(f"{where}: [{table}]: fix_n must be a number or \"free\", got {values['fix_n']!r}")
        values["fix_n"] = None
    for key in ("grid", "c_bounds", "n_bounds"):
        if isinstance(values.get(key), list):
            values[key] = tuple(values[key])
    try:
        pipeline = Pipeline(model=model, **values)
    except (TypeError, ValueError) as exc:
        raise CampaignError(f"{where}: [{table}]: {exc}") from None
    if pipeline.fix_n is not None and isinstance(pipeline.fix_n, bool):
        raise CampaignError(f"{where}: [{table}]: fix_n must be a number or \"free\", got {pipeline.fix_n!r}")
    return pipeline


def _number(where: str, key: str, value: Any) -> float | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
        raise CampaignError(f"{where}: {key} must be a positive number, got {value!r}")
    return float(value)


def load_campaign(path: str | os.PathLike[str]) -> CampaignSpec:
    """Read a campaign file (TOML) or a folder of recordings (module docstring).

    Parameters
    ----------
    path : the campaign file, or a folder whose recordings make the campaign.

    Returns
    -------
    CampaignSpec
        with the paths resolved against the campaign file's folder.

    Raises
    ------
    CampaignError
        naming the file and the table or key at fault (unknown keys are refused, so that a typo
        never passes silently).
    """
    path = Path(path)
    if path.is_dir():
        return _from_folder(path)
    if not path.exists():
        raise CampaignError(f"{path}: campaign file or folder not found")
    try:
        with path.open("rb") as fh:
            data = tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise CampaignError(f"{path}: not a valid TOML file ({exc})") from None
    except OSError as exc:
        raise CampaignError(f"{path}: cannot read ({exc.strerror or exc})") from None
    where = str(path)
    unknown = sorted(set(data) - _TOP_KEYS)
    if unknown:
        raise CampaignError(f"{where}: unknown table(s) {', '.join(unknown)} (expected {', '.join(sorted(_TOP_KEYS))})")
    for table in ("campaign", "options", "single", "joint"):
        if not isinstance(data.get(table, {}), dict):
            raise CampaignError(f"{where}: [{table}] must be a table")
    head = data.get("campaign", {})
    unknown = sorted(set(head) - _CAMPAIGN_KEYS)
    if unknown:
        raise CampaignError(f"{where}: [campaign]: unknown key(s) {', '.join(unknown)} (known: "
                            f"{', '.join(sorted(_CAMPAIGN_KEYS))})")
    base = path.parent
    model = head.get("model", DEFAULT_MODEL)
    _check_model(where, model)
    options = data.get("options", {})
    single_fits = head.get("single_fits", True)
    if not isinstance(single_fits, bool):
        raise CampaignError(f"{where}: [campaign]: single_fits must be true or false, got {single_fits!r}")
    single = _pipeline(where, "single", {**SINGLE_DEFAULTS, **options, **data.get("single", {})}, model) \
        if single_fits else None
    joint = _pipeline(where, "joint", {**options, **data.get("joint", {})}, model)
    entries = data.get("recording", [])
    if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
        raise CampaignError(f"{where}: recordings are given as [[recording]] tables")
    recordings = []
    for k, entry in enumerate(entries, start=1):
        at = f"{where}: recording {k}"
        unknown = sorted(set(entry) - _RECORDING_KEYS)
        if unknown:
            raise CampaignError(f"{at}: unknown key(s) {', '.join(unknown)} (known: "
                                f"{', '.join(sorted(_RECORDING_KEYS))})")
        if not isinstance(entry.get("path"), str) or not entry["path"].strip():
            raise CampaignError(f"{at}: needs path = \"FILE\"")
        for key in ("name", "group", "rig"):
            if key in entry and (not isinstance(entry[key], str) or not entry[key].strip()):
                raise CampaignError(f"{at}: {key} must be a non-empty string, got {entry[key]!r}")
        file = base / entry["path"]
        recordings.append(RecordingSpec(
            name=entry.get("name") or file.stem, path=file, rig=(base / entry["rig"]) if "rig" in entry else None,
            cam_speed_hz=_number(at, "cam_speed_hz", entry.get("cam_speed_hz")),
            e_over_rc=_number(at, "e_over_rc", entry.get("e_over_rc")), group=entry.get("group")))
    name = head.get("name", path.stem)
    if not isinstance(name, str):
        raise CampaignError(f"{where}: [campaign]: name must be a string, got {name!r}")
    out = head.get("out")
    if out is not None and (not isinstance(out, str) or not out.strip()):
        raise CampaignError(f"{where}: [campaign]: out must be a folder name, got {out!r}")
    return CampaignSpec(name=name, recordings=tuple(recordings), single=single, joint=joint, source=path,
                        out=(base / out) if out else None, model=model)


def _from_folder(folder: Path) -> CampaignSpec:
    files = sorted(p for p in folder.iterdir() if p.suffix.lower() in RECORDING_SUFFIXES and p.is_file())
    if not files:
        raise CampaignError(f"{folder}: no recording (*.h5, *.hdf5, *.csv) in this folder")
    recordings = [RecordingSpec(name=p.stem, path=p) for p in files]
    groups = rig_groups(recordings)
    member_of = {name: group for group, names in groups.items() for name in names}
    # the estimate of the folder's rig model (of the one model among its recordings that impactid fits)
    models = {h.model for h in (read_rig_header(r) for r in recordings) if h is not None and h.estimable}
    model = next(iter(models)) if len(models) == 1 else DEFAULT_MODEL
    return CampaignSpec(name=folder.name, recordings=tuple(replace(r, group=member_of.get(r.name))
                                                           for r in recordings), source=folder, model=model)


def rig_groups(recordings: Sequence[RecordingSpec]) -> dict[str, tuple[str, ...]]:
    """The joint groups of a folder's recordings: those of one rig, two or more to a group.

    Recordings are of one rig when their files' headers (:func:`read_rig_header`) name the same
    model and the same parameters but the operating point's (:data:`OPERATING_RIG_PARAMETERS`), the
    condition of a joint fit. A recording whose header cannot be read, or whose rig impactid cannot
    fit, is in no group (its own fit says why), nor is the only recording of its rig.

    Returns
    -------
    dict
        recording names by group name, in the order of ``recordings``: ``"all"`` when every
        recording is in the one group, else the rig model's name (``"pivoted-follower"``, with
        ``-1``, ``-2``, ... when recordings of one model differ in their parameters).
    """
    by_rig: dict[RigHeader, list[str]] = {}
    for r in recordings:
        header = read_rig_header(r)
        if header is not None and header.estimable:
            by_rig.setdefault(header, []).append(r.name)
    joint = {header: names for header, names in by_rig.items() if len(names) > 1}
    if len(joint) == 1 and len(next(iter(joint.values()))) == len(recordings):
        return {"all": tuple(next(iter(joint.values())))}
    per_model: dict[str, int] = {}
    for header in joint:
        per_model[header.model] = per_model.get(header.model, 0) + 1
    groups: dict[str, tuple[str, ...]] = {}
    seen: dict[str, int] = {}
    for header, names in joint.items():
        seen[header.model] = seen.get(header.model, 0) + 1
        name = header.model if per_model[header.model] == 1 else f"{header.model}-{seen[header.model]}"
        groups[name] = tuple(names)
    return groups


# ---- the rig of a recording, from its header -----------------------------------------------------

#: Rig parameters that may differ between the recordings of one joint fit: the operating point's
#: eccentricity ``e`` (rig P). Every other parameter (the contact pair, the follower) must be equal,
#: as :meth:`impactid.pipeline.Pipeline.fit` requires
#: (:attr:`impactid.rigs.pivoted.reconstruct.Reconstruction.fixed_parameters`).
OPERATING_RIG_PARAMETERS = ("e",)


@dataclass(frozen=True)
class RigHeader:
    """The rig of a recording as its file's header states it (no sample is read).

    Attributes
    ----------
    model : the rig model's name (docs/formats.md), e.g. ``"pivoted-follower"``.
    fixed : ``(name, value)`` of every rig parameter but :data:`OPERATING_RIG_PARAMETERS`, sorted by
        name [SI units]: recordings of one joint fit share them.
    estimable : whether impactid estimates a contact law from recordings of this rig model.
    """

    model: str
    fixed: tuple[tuple[str, float], ...]
    estimable: bool

    def differences(self, other: RigHeader) -> str:
        """How ``other`` differs from this rig, in a few words ("" when it does not)."""
        if self.model != other.model:
            return f"model {self.model} against {other.model}"
        mine, theirs = dict(self.fixed), dict(other.fixed)
        names = [k for k in sorted(set(mine) | set(theirs)) if mine.get(k) != theirs.get(k)]
        return f"rig parameter(s) {', '.join(names)}" if names else ""


def read_rig_header(spec: RecordingSpec) -> RigHeader | None:
    """The rig of a campaign's recording, from the header of its file (HDF5: the ``/rig`` group's
    attributes) or from its rig file (``spec.rig``; a CSV's sibling TOML file), reading no sample.

    The rig is the one the recording's reader (:func:`impactid.io.read_recording`) would give it; the
    overrides of the operating point change only :data:`OPERATING_RIG_PARAMETERS`.

    Returns
    -------
    RigHeader or None
        None when the header cannot be read (a missing or damaged file, no rig): the recording's own
        tasks then say why.
    """
    from impactid.rigs import load_rig_toml, rig_from_mapping
    from impactid.rigs.registry import rig_model

    try:
        if spec.rig is not None:
            rig, _ = load_rig_toml(spec.rig)
        else:
            with spec.path.open("rb") as fh:
                signature = fh.read(len(_HDF5_SIGNATURE))
            if signature == _HDF5_SIGNATURE or spec.path.suffix.lower() in (".h5", ".hdf5", ".hdf"):
                rig = rig_from_mapping(_hdf5_rig_attributes(spec.path), source=f"{spec.path} /rig")
            elif spec.path.suffix.lower() in (".csv", ".txt"):
                rig, _ = load_rig_toml(spec.path.with_suffix(".toml"))
            else:
                return None
        parameters = rig.to_dict()
        model = rig_model(rig.model)
    except Exception:  # noqa: BLE001 - no header, no judgement: the reader names the problem
        return None
    fixed = tuple(sorted((k, float(v)) for k, v in parameters.items() if k not in OPERATING_RIG_PARAMETERS))
    return RigHeader(model=model.name, fixed=fixed, estimable=_estimable(model))


_HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"


def _hdf5_rig_attributes(path: Path) -> dict[str, Any]:
    """The attributes of an HDF5 recording's ``/rig`` group (``model`` a string, the others numbers)."""
    import h5py
    import numpy as np

    with h5py.File(path, "r") as fh:
        group = fh.get("rig")
        if not isinstance(group, h5py.Group):
            raise CampaignError(f"{path}: no /rig group")
        values: dict[str, Any] = {}
        for key, value in group.attrs.items():
            if key == "model":
                text = value[()] if isinstance(value, np.ndarray) else value
                values[key] = text.decode("utf-8", errors="replace") if isinstance(text, bytes) else str(text)
            else:
                values[key] = float(np.asarray(value).reshape(()))
    return values


def _not_estimable(spec: RecordingSpec, header: RigHeader) -> str:
    """Why a recording of this rig cannot be fitted (the reason :mod:`impactid.pipeline` gives)."""
    able = " or ".join(repr(m) for m in estimable_models()) or "no"
    return (f"{spec.path}: needs a {able} rig (impactid estimates no contact law from the recordings of this model), "
            f"the recording's rig is {header.model!r}")


def _other_model(spec: RecordingSpec, header: RigHeader, model: str) -> str:
    """Why a recording of another rig than the campaign's is not fitted."""
    return (f"{spec.path}: a {header.model!r} recording in a campaign of the {model!r} rig's estimate (its options "
            f"are that rig's; set [campaign] model, or run each rig's recordings as a campaign of their own)")


# ---- content hashes ---------------------------------------------------------------------------------


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as fh:
        while chunk := fh.read(HASH_CHUNK):
            digest.update(chunk)
    return digest.hexdigest()


class _Digests:
    """SHA-256 of input files, cached in the output folder by (resolved path, size, mtime_ns)."""

    def __init__(self, out: Path):
        self.path = out / HASH_CACHE
        self.entries: dict[str, dict] = {}
        self.changed = False
        with contextlib.suppress(OSError, ValueError, TypeError):
            entries = json.loads(self.path.read_text())
            if isinstance(entries, dict):
                self.entries = entries

    def __call__(self, path: Path) -> str:
        """The file's digest; raises :class:`CampaignError` if it cannot be read."""
        try:
            resolved = str(path.resolve())
            st = path.stat()
        except OSError as exc:
            raise CampaignError(f"{path}: {exc.strerror or exc}") from None
        if not path.is_file():
            raise CampaignError(f"{path}: not a regular file")
        entry = self.entries.get(resolved)
        if entry and entry.get("size") == st.st_size and entry.get("mtime_ns") == st.st_mtime_ns:
            return entry["sha256"]
        try:
            digest = _sha256(path)
        except OSError as exc:
            raise CampaignError(f"{path}: cannot read ({exc.strerror or exc})") from None
        self.entries[resolved] = {"size": st.st_size, "mtime_ns": st.st_mtime_ns, "sha256": digest}
        self.changed = True
        return digest

    def uncached(self, paths: Sequence[Path]) -> list[Path]:
        """The existing files of ``paths`` whose digest is not cached (they will be read)."""
        out = []
        for path in paths:
            with contextlib.suppress(OSError):
                st = path.stat()
                entry = self.entries.get(str(path.resolve()))
                if not (entry and entry.get("size") == st.st_size and entry.get("mtime_ns") == st.st_mtime_ns):
                    out.append(path)
        return out

    def save(self) -> None:
        if self.changed:
            atomic_write(self.path, json.dumps(self.entries, indent=1, sort_keys=True) + "\n")
            self.changed = False


def _key(data: dict) -> str:
    text = json.dumps({"format": FORMAT_VERSION, "impactid": __version__, **data}, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()


# ---- tasks ------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class PrepareJob:
    """A prepare task: read, segment and reconstruct one recording.

    Attributes
    ----------
    key : the task's key (content hash).
    recording : the recording.
    model : the rig model whose estimator prepares it.
    options : ``(name, value)`` of the options that change the product (the estimator's
        :attr:`~impactid.rigs.base.Estimator.prepare_options`; rig P: the reconstruction's
        ``integration`` and ``anchor``); the others are the estimate's defaults.
    cache : the cached product's file (loaded when it holds this key), or None.
    """

    key: str
    recording: RecordingSpec
    model: str
    options: tuple[tuple[str, Any], ...] = ()
    cache: Path | None = None


@dataclass(frozen=True)
class PrepareOutcome:
    """What a prepare task returns: the product, or the reason it could not be made.

    Attributes
    ----------
    key, name : the task's key and the recording's name.
    prepared : the :class:`~impactid.pipeline.PreparedRecording` (None when it failed).
    error : the one-line reason of a failure ("" when it succeeded).
    seconds : time taken [s].
    cached : the product was loaded from the cache.
    """

    key: str
    name: str
    prepared: PreparedRecording | None
    error: str = ""
    seconds: float = 0.0
    cached: bool = False


@dataclass(frozen=True)
class FitJob:
    """A fit task: one recording alone (``kind="single"``) or a group jointly (``"joint"``).

    Attributes
    ----------
    key : the task's key (content hash).
    kind : ``"single"`` or ``"joint"``.
    name : the recording's or the group's name.
    recordings : the recordings fitted.
    pipeline : the options of the fit.
    campaign : the campaign's name.
    digests : per recording, the SHA-256 of its files (recorded in the result).
    refused : why the fit cannot be done, known before any task runs (a group that names one
        recording twice, recordings of different rigs), or "".
    """

    key: str
    kind: str
    name: str
    recordings: tuple[RecordingSpec, ...]
    pipeline: Pipeline
    campaign: str = ""
    digests: tuple[tuple[str, ...], ...] = ()
    refused: str = ""


@dataclass(frozen=True)
class FitOutcome:
    """What a fit task returns: the JSON-ready record written to ``fits/<key>.json``.

    Attributes
    ----------
    key : the task's key.
    record : the record (``status`` ``"ok"`` with ``result``, or ``"failed"`` with ``reason``).
    """

    key: str
    record: dict

    @property
    def ok(self) -> bool:
        """Whether the fit ended in an estimate."""
        return self.record.get("status") == "ok"


def _reason(exc: BaseException) -> str:
    """One line: the message of an impactid error, ``Type: message`` of anything else."""
    if isinstance(exc, ImpactidError):
        text = str(exc)
    elif isinstance(exc, MemoryError):
        text = "out of memory"
    else:
        text = f"{type(exc).__name__}: {exc}"
    return " ".join(text.split()) or type(exc).__name__


def read_recording_spec(spec: RecordingSpec):
    """The :class:`~impactid.io.Recording` of a campaign entry, with its rig file and overrides applied."""
    from impactid.io import read_recording

    rec = read_recording(spec.path, rig=spec.rig)
    if spec.e_over_rc is not None:
        if rec.rig is None or not hasattr(rec.rig, "with_eccentricity_ratio"):
            raise CampaignError(f"{spec.path}: e_over_rc given, but the recording's rig has no eccentricity")
        rec = rec.with_rig(rec.rig.with_eccentricity_ratio(spec.e_over_rc))
    if spec.cam_speed_hz is not None:
        rec = rec.with_step(f"campaign: cam_speed_hz = {spec.cam_speed_hz!r} Hz",
                            operating={**dict(rec.operating), "cam_speed_hz": spec.cam_speed_hz})
    return rec


def prepare_task(job: PrepareJob) -> PrepareOutcome:
    """Run a prepare task (on a worker or here): load the cached product, or make it.

    Never raises for a bad recording: the outcome carries the reason.
    """
    t0 = time.perf_counter()
    if job.cache is not None and job.cache.is_file():
        with contextlib.suppress(Exception):
            with job.cache.open("rb") as fh:
                stored = pickle.load(fh)
            product = stored.get("prepared") if isinstance(stored, dict) else None
            # (a product of an older format is made again)
            if isinstance(product, PreparedRecording) and stored.get("key") == job.key and \
                    getattr(product, "model", None) == job.model:
                return PrepareOutcome(job.key, job.recording.name, product,
                                      seconds=time.perf_counter() - t0, cached=True)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            rec = read_recording_spec(job.recording)
            pipeline = Pipeline(model=job.model, **dict(job.options))
            prepared = pipeline.prepare(rec, name=job.recording.name, keep_samples=False)
        # the reader's notes on the data (a clipped channel, ...) go with the product into its fits' results
        notes = tuple(dict.fromkeys(" ".join(str(w.message).split()) for w in caught
                                    if w.category.__module__.startswith("impactid")))
        prepared = replace(prepared, notes=notes + tuple(m for m in prepared.notes if m not in notes))
        return PrepareOutcome(job.key, job.recording.name, prepared, seconds=time.perf_counter() - t0)
    except Exception as exc:  # noqa: BLE001 - a part that cannot be done does not take the others with it
        return PrepareOutcome(job.key, job.recording.name, None, error=_reason(exc),
                              seconds=time.perf_counter() - t0)


def _record(job: FitJob, status: str, reason: str, seconds: float, result: dict | None) -> dict:
    return {
        "format": FORMAT_VERSION, "impactid": __version__, "campaign": job.campaign, "key": job.key,
        "kind": job.kind, "name": job.name, "status": status, "reason": reason,
        "recordings": [{"name": r.name, "path": str(r.path), "rig": str(r.rig) if r.rig else None,
                        "sha256": list(d), **r.overrides()}
                       for r, d in zip(job.recordings, job.digests or [()] * len(job.recordings))],
        "options": job.pipeline.to_dict(), "seconds": seconds, "host": socket.gethostname(),
        "finished": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "result": result,
    }


def fit_task(job: FitJob, *prepared: PrepareOutcome) -> FitOutcome:
    """Run a fit task (on a worker or here) on the outcomes of its recordings' prepare tasks.

    Never raises for a fit that cannot be done: the outcome's record carries the reason.
    """
    t0 = time.perf_counter()
    if job.refused:
        return FitOutcome(job.key, _record(job, "failed", job.refused, 0.0, None))
    bad = [p for p in prepared if p.prepared is None]
    reason = "; ".join(f"recording {p.name} could not be prepared: {p.error}" for p in bad)
    if len(bad) == len(prepared):
        return FitOutcome(job.key, _record(job, "failed", reason, 0.0, None))
    # a recording that cannot be prepared does not take a joint fit with it: the others are fitted,
    # and the record's reason and the result's notes say which was left out and why
    good = [p.prepared for p in prepared if p.prepared is not None]
    if bad:
        left_out = tuple(f"{p.name} left out of the joint fit: {p.error}" for p in bad)
        good[0] = replace(good[0], notes=left_out + tuple(good[0].notes))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the estimate's notes are in its result
            estimate = job.pipeline.fit(good, warn=False)
            result = rig_estimator(job.pipeline.model or prepared[0].prepared.model).to_dict(estimate)
    except Exception as exc:  # noqa: BLE001 - a part that cannot be done does not take the others with it
        reason = _reason(exc)
        if not isinstance(exc, (ImpactidError, MemoryError)):
            reason += " (" + " <- ".join(f"{f.name}:{f.lineno}" for f in traceback.extract_tb(exc.__traceback__)[-3:]) \
                + ")"
        return FitOutcome(job.key, _record(job, "failed", reason, time.perf_counter() - t0, None))
    return FitOutcome(job.key, _record(job, "ok", reason, time.perf_counter() - t0, result))


# ---- the run ----------------------------------------------------------------------------------------


@dataclass(frozen=True)
class CampaignResult:
    """What :func:`run_campaign` did.

    Attributes
    ----------
    out : the output folder.
    table : the summary (one row per fit; :func:`summary_table`).
    ran : fits run now that ended in an estimate.
    skipped : fits finished in an earlier run (not run again).
    failed : fits without an estimate: run now and failed, or refused without a task. Each fit is
        counted once: ``ran + skipped + failed`` is the number of fits (:attr:`fits`).
    prepared : recordings prepared now (read, segmented, reconstructed); ``cached``: loaded from the cache.
    cached : prepared products loaded from the cache.
    seconds : wall time [s].
    files : the summary files written (``campaign.parquet`` where pyarrow is installed, ``campaign.csv``).
    where : where the tasks ran (``"serial"``, or the cluster).
    """

    out: Path
    table: pd.DataFrame
    ran: int
    skipped: int
    failed: int
    prepared: int
    cached: int
    seconds: float
    files: tuple[Path, ...]
    where: str

    @property
    def ok(self) -> bool:
        """Whether every fit ended in an estimate."""
        return self.failed == 0

    @property
    def fits(self) -> int:
        """The number of fits of the campaign (rows of the table)."""
        return len(self.table)

    def failures(self) -> list[tuple[str, str, str]]:
        """``(kind, name, reason)`` of every failed fit."""
        bad = self.table[self.table["status"] != "ok"]
        return [(str(r.kind), str(r["name"]), str(r.reason)) for _, r in bad.iterrows()]


def plan(spec: CampaignSpec, out: Path, digests: Callable[[Path], str]) -> tuple[
        dict[str, PrepareJob], dict[str, PrepareOutcome], list[tuple[FitJob, list[str]]]]:
    """The campaign's tasks.

    What can be known of a recording without preparing it is decided here, from its files' digests
    and headers (:func:`read_rig_header`): a recording whose files cannot be read, or whose rig
    impactid cannot fit, has a failed outcome and no task; a group that names one recording twice
    (one file, or two files of identical content) or recordings of different rigs is a refused fit
    (:attr:`FitJob.refused`) that needs no task.

    Returns
    -------
    prepares : the prepare jobs by key.
    unpreparable : by key, the failed outcome of each recording that cannot be prepared, known
        without a task (files missing or unreadable, a rig impactid cannot fit).
    fits : the fit jobs, each with the keys of the prepare jobs it needs (none for a refused fit).
    """
    prepares: dict[str, PrepareJob] = {}
    unpreparable: dict[str, PrepareOutcome] = {}
    file_digests: dict[str, tuple[str, ...]] = {}
    reasons: dict[str, str] = {}
    headers: dict[str, RigHeader | None] = {}
    for r in spec.recordings:
        try:
            file_digests[r.name] = tuple(digests(p) for p in r.inputs())
        except CampaignError as exc:
            reasons[r.name] = _reason(exc)
            continue
        headers[r.name] = header = read_rig_header(r)
        if header is not None and not header.estimable:
            reasons[r.name] = _not_estimable(r, header)
        elif header is not None and header.model != spec.model:
            reasons[r.name] = _other_model(r, header, spec.model)
    prepare_options = rig_estimator(spec.model).prepare_options

    def prepare_key(r: RecordingSpec, pipeline: Pipeline) -> str:
        opts = {k: getattr(pipeline, k) for k in prepare_options}
        if r.name not in file_digests:
            key = _key({"task": "prepare", "unreadable": str(r.path), **opts})
        else:
            key = _key({"task": "prepare", "files": file_digests[r.name], "overrides": r.overrides(), **opts})
        if r.name in reasons:
            unpreparable[key] = PrepareOutcome(key, r.name, None, error=reasons[r.name])
        else:
            prepares.setdefault(key, PrepareJob(key, r, spec.model, tuple(opts.items()),
                                                cache=out / "prepared" / f"{key}.pkl"))
        return key

    fits: list[tuple[FitJob, list[str]]] = []

    def add(kind: str, name: str, members: Sequence[RecordingSpec], pipeline: Pipeline, refused: str = "") -> None:
        keys = [prepare_key(r, pipeline) for r in members]
        # the names are part of a fit's key (two recordings of equal content are still two rows); the
        # paths are not (a campaign folder that moves keeps its finished fits)
        key = _key({"task": kind, "name": name, "recordings": [r.name for r in members], "prepared": keys,
                    "options": pipeline.to_dict()})
        job = FitJob(key, kind, name, tuple(members), pipeline, spec.name,
                     tuple(file_digests.get(r.name, ()) for r in members), refused=refused)
        fits.append((job, [] if refused else keys))

    if spec.single is not None:
        for r in spec.recordings:
            add("single", r.name, [r], spec.single)
    for group, members in spec.groups().items():
        add("joint", group, members, spec.joint, refused=_refused_group(group, members, file_digests, headers))
    return prepares, unpreparable, fits


def _refused_group(group: str, members: Sequence[RecordingSpec], file_digests: dict[str, tuple[str, ...]],
                   headers: dict[str, RigHeader | None]) -> str:
    """Why a group cannot be fitted jointly, known before anything is prepared ("" when it may be).

    * one recording named twice: the same file (resolved path or inode) or two files of identical
      content (their SHA-256, cached: the rule of :func:`impactid._files.check_distinct_inputs`
      without reading the files again) would count its impacts twice;
    * recordings of different rigs (their headers differ in the model or in a parameter other
      than :data:`OPERATING_RIG_PARAMETERS`).
    """
    for k, second in enumerate(members):
        for first in members[:k]:
            digest = file_digests.get(first.name, ("",))[0]
            if same_file(first.path, second.path):
                how = "one file"
            elif digest and digest == file_digests.get(second.name, ("",))[0]:
                how = f"identical contents, SHA-256 {digest[:12]}"
            else:
                continue
            return (f"group {group!r} names one recording twice: {first.name} ({first.path}) and {second.name} "
                    f"({second.path}) are the same ({how}); each recording may be in a group once, or its "
                    "impacts would count twice")
    known = [(r, headers[r.name]) for r in members if headers.get(r.name) is not None]
    for r, header in known[1:]:
        first, first_header = known[0]
        differ = first_header.differences(header)
        if differ:
            return (f"group {group!r}: a joint fit needs recordings of one rig (the same model, and the same "
                    f"parameters but the eccentricity e); {first.name} and {r.name} differ ({differ})")
    return ""


def _finished(path: Path, key: str) -> dict | None:
    """The record of ``fits/<key>.json`` when it holds a finished estimate of this key."""
    with contextlib.suppress(OSError, ValueError):
        record = json.loads(path.read_text())
        if isinstance(record, dict) and record.get("key") == key and record.get("status") == "ok":
            return record
    return None


def run_campaign(spec: CampaignSpec, out: str | os.PathLike[str], *, client: Any = None,
                 cluster: Callable[[], contextlib.AbstractContextManager] | None = None, fresh: bool = False,
                 progress: bool | None = False, log: Callable[[str], None] | None = None) -> CampaignResult:
    """Run a campaign: prepare the recordings, fit each alone and each group jointly (module docstring).

    Parameters
    ----------
    spec : the campaign (:func:`load_campaign`).
    out : the output folder (created if needed).
    client : a :class:`distributed.Client` to run the tasks on; None: ``cluster``, else serially here.
    cluster : without ``client``: a callable returning a context manager that yields a client
        (e.g. ``lambda: impactid.distributed.connect(workers=2)``), entered only when there is work
        to do (a rerun with every fit finished, or failing for a reason known without a task,
        starts no cluster).
    fresh : ignore the finished fits and cached products (run everything again).
    progress : show a progress bar on stderr (None: when stderr is a terminal).
    log : receives one line per notable step (where the tasks run, failures as they happen).

    Returns
    -------
    CampaignResult
        counts, the summary table and the files written. Failed fits are rows with their reason;
        they never raise.

    Raises
    ------
    ImpactidError
        the output folder cannot be written.
    """
    from impactid.commandline import progress_bar

    t0 = time.perf_counter()
    out = Path(out)
    say = log or (lambda text: None)
    (out / "fits").mkdir(parents=True, exist_ok=True)
    digests = _Digests(out)
    unhashed = digests.uncached([p for r in spec.recordings for p in r.inputs()])
    if unhashed:
        size = sum(p.stat().st_size for p in unhashed)
        say(f"hashing {len(unhashed)} input file(s), {size / 1e9:.3g} GB (once: the digests are cached in {out})")
    prepares, unpreparable, fits = plan(spec, out, digests)
    digests.save()
    rows: dict[str, dict] = {}  # the summary row of every fit (the results stay on disk)
    todo: list[tuple[FitJob, list[str]]] = []  # the fits that need tasks
    known: list[FitOutcome] = []  # the fits that fail without a task (their reason known now)
    for job, keys in fits:
        bad = [unpreparable[k] for k in keys if k in unpreparable]
        if job.refused or bad:
            known.append(fit_task(job, *bad))  # at once: a refused fit, or one naming its unpreparable recordings
            continue
        done = None if fresh else _finished(out / "fits" / f"{job.key}.json", job.key)
        if done is not None:
            rows[job.key] = _row(done)
        else:
            todo.append((job, keys))
    skipped = len(rows)
    for outcome in known:
        atomic_write(out / "fits" / f"{outcome.key}.json", json_text(outcome.record))
        rows[outcome.key] = _row(outcome.record)
        say(f"{outcome.record['kind']} fit {outcome.record['name']} failed: {outcome.record['reason']}")
    needed = {k for _, keys in todo for k in keys}
    jobs = [replace(prepares[k], cache=None) if fresh else prepares[k] for k in prepares if k in needed]
    counts = {"prepared": 0, "cached": 0, "ran": 0}
    where = "nothing to run"
    if todo:
        bar = progress_bar(len(jobs) + len(todo), enabled=progress, desc=f"campaign {spec.name}", unit="task")
        plain = say

        def say(text: str) -> None:  # a line above the progress bar, which is drawn again below it
            bar.clear()
            plain(text)
            bar.refresh()

        def on_prepare(outcome: PrepareOutcome) -> None:
            bar.update(1)
            if outcome.prepared is None:
                return  # the fits that need it fail, naming it
            counts["cached" if outcome.cached else "prepared"] += 1
            if not outcome.cached:
                with contextlib.suppress(ImpactidError, OSError, pickle.PicklingError):
                    atomic_write(out / "prepared" / f"{outcome.key}.pkl",
                                 pickle.dumps({"key": outcome.key, "prepared": outcome.prepared},
                                              protocol=pickle.HIGHEST_PROTOCOL))

        def on_fit(outcome: FitOutcome) -> None:
            atomic_write(out / "fits" / f"{outcome.key}.json", json_text(outcome.record))
            rows[outcome.key] = _row(outcome.record)
            counts["ran"] += outcome.ok
            bar.update(1)
            if not outcome.ok:
                say(f"{outcome.record['kind']} fit {outcome.record['name']} failed: {outcome.record['reason']}")
            failed = sum(1 for r in rows.values() if r["status"] != "ok")
            if failed:
                bar.set_postfix_str(f"{failed} failed")

        with bar:
            if client is not None:
                where = _describe(client)
                say(f"running {len(jobs)} prepare and {len(todo)} fit tasks on {where}")
                _run_on(client, jobs, todo, on_prepare, on_fit)
            elif cluster is not None:
                with cluster() as started:
                    where = _describe(started)
                    say(f"running {len(jobs)} prepare and {len(todo)} fit tasks on {where}")
                    _run_on(started, jobs, todo, on_prepare, on_fit)
            else:
                where = "serial"
                say(f"running {len(jobs)} prepare and {len(todo)} fit tasks serially in this process")
                _run_serial(jobs, todo, on_prepare, on_fit)
    table = _frame([rows[job.key] for job, _ in fits if job.key in rows])
    with StagedFiles(protect=spec.inputs()) as staged:
        # the CSV always; the Parquet copy where pyarrow is installed (the 'campaign' extra): a campaign
        # runs serially without the extra, as after `pip install impactid`
        written = []
        if parquet_available():
            written.append(staged.write_with(out / f"{TABLE_NAME}.parquet",
                                             lambda tmp: table.to_parquet(tmp, index=False)))
        written.append(staged.write_with(out / f"{TABLE_NAME}.csv", lambda tmp: table.to_csv(tmp, index=False)))
    failed = int((table["status"] != "ok").sum()) if len(table) else 0
    return CampaignResult(out=out, table=table, ran=counts["ran"], skipped=skipped, failed=failed,
                          prepared=counts["prepared"], cached=counts["cached"], seconds=time.perf_counter() - t0,
                          files=tuple(written), where=where)


def write_campaign_report(spec: CampaignSpec, result: CampaignResult, path: str | os.PathLike[str], *,
                          command: str = "") -> Path:
    """Write the HTML page of a campaign (``impactid campaign --report``) atomically: the per-recording
    estimates, the pooled (joint) estimates and the spread of the single fits
    (:func:`impactid.html_report.campaign_page`). Returns the path."""
    counts = {"recordings": len(spec.recordings), "fits": result.fits, "done now": result.ran,
              "skipped (finished earlier)": result.skipped, "failed": result.failed,
              "seconds": round(result.seconds, 1), "where": result.where}
    page = campaign_page(spec.name, result.table, command=command, inputs=[str(p) for p in spec.inputs()],
                         files=[str(f) for f in result.files], counts=counts)
    return atomic_write(path, page, protect=spec.inputs())


def parquet_available() -> bool:
    """Whether pyarrow (the 'campaign' extra) is installed: the summary's Parquet copy needs it."""
    return importlib.util.find_spec("pyarrow") is not None


def _describe(client: Any) -> str:
    try:
        workers = client.scheduler_info().get("workers", {})
        threads = sum(w.get("nthreads", 1) for w in workers.values())
        address = client.scheduler.address
        kind = "a local cluster" if str(address).startswith(("tcp://127.0.0.1", "inproc://")) else "the cluster"
        return f"{kind} at {address} ({len(workers)} workers, {threads} threads)"
    except Exception:  # noqa: BLE001 - a description only
        return "a dask cluster"


def _run_serial(jobs: list[PrepareJob], todo: list[tuple[FitJob, list[str]]], on_prepare, on_fit) -> None:
    """Serially: each recording's preparation, then the fits as soon as their recordings are prepared."""
    outcomes: dict[str, PrepareOutcome] = {}
    pending = list(todo)
    for job in jobs:
        outcome = prepare_task(job)
        outcomes[job.key] = outcome
        on_prepare(outcome)
        ready = [(f, keys) for f, keys in pending if all(k in outcomes for k in keys)]
        for fit, keys in ready:
            on_fit(fit_task(fit, *[outcomes[k] for k in keys]))
        pending = [p for p in pending if p not in ready]
    for fit, keys in pending:  # a fit that needs no preparation
        on_fit(fit_task(fit, *[outcomes[k] for k in keys]))


def _run_on(client: Any, jobs: list[PrepareJob], todo: list[tuple[FitJob, list[str]]], on_prepare, on_fit) -> None:
    """On a dask cluster: the prepare futures feed the fit futures; results are handled as they arrive."""
    from distributed import Future, as_completed

    futures: dict[str, Any] = {}
    kinds: dict[str, tuple[str, Any]] = {}
    for job in jobs:
        future = client.submit(prepare_task, job, key=f"prepare-{job.recording.name}-{job.key[:16]}", pure=False)
        futures[job.key] = future
        kinds[future.key] = ("prepare", job)
    fit_futures = []
    for fit, keys in todo:
        future = client.submit(fit_task, fit, *[futures[k] for k in keys],
                               key=f"fit-{fit.kind}-{fit.name}-{fit.key[:16]}", pure=False)
        fit_futures.append(future)
        kinds[future.key] = ("fit", fit)
    try:
        for future in as_completed([f for f in futures.values() if isinstance(f, Future)] + fit_futures):
            kind, job = kinds[future.key]
            try:
                value = future.result()
            except Exception as exc:  # noqa: BLE001 - a task dask gave up on (its worker died, ...)
                reason = f"the task did not finish: {_reason(exc)}"
                if kind == "prepare":
                    on_prepare(PrepareOutcome(job.key, job.recording.name, None, error=reason))
                else:
                    on_fit(FitOutcome(job.key, _record(job, "failed", reason, 0.0, None)))
                continue
            (on_prepare if kind == "prepare" else on_fit)(value)
    finally:
        client.cancel([f for f in list(futures.values()) + fit_futures if isinstance(f, Future) and not f.done()])


# ---- the summary table ------------------------------------------------------------------------------

#: Columns of the summary table, in order (units in docs/formats.md).
COLUMNS = ("campaign", "kind", "name", "status", "reason", "recordings", "n_recordings", "e_over_rc",
           "cam_speed_hz", "operating_points", "beta", "beta_lo", "beta_hi", "n", "n_lo", "n_hi", "n_fixed",
           "separable", "gamma", "gamma_stderr", "xi_mean", "va_mean", "impacts_used", "residual", "objective",
           "method", "simulations", "warnings", "seconds", "key", "json")


def _fit_result_fields(res: dict) -> dict:
    """The summary's fields of a result in the :class:`~impactid.results.FitResult` schema (rig P's
    ``pivoted-estimate``, the drop rig's ``drop-impact-fit``, ...): in the keys of the summary's row."""
    params, stats = res.get("params") or {}, res.get("statistics") or {}
    details = res.get("details") or {}

    def param(name: str, key: str = "value"):
        return (params.get(name) or {}).get(key)

    def interval(name: str) -> list:
        return list(param(name, "interval") or [None, None])

    table = (res.get("tables") or {}).get("recordings") or {}
    columns = list(table.get("columns") or [])
    recordings = [dict(zip(columns, row)) for row in table.get("data") or []]
    impacts = stats.get("impacts_used", stats.get("n_impacts"))
    return {
        "beta": param("beta"), "n": param("n"), "gamma": param("gamma"), "xi_mean": stats.get("xi_mean"),
        "va_mean": stats.get("va_mean"), "impacts_used": impacts, "residual": stats.get("residual", ""),
        "objective": stats.get("objective"), "recordings": recordings, "warnings": res.get("notes"),
        "uncertainty": {"beta_interval": interval("beta"), "n_interval": interval("n"),
                        "n_fixed": bool(param("n", "fixed") or False), "separable": stats.get("separable"),
                        "gamma_stderr": param("gamma", "stderr")},
        "contact_damping": {"method": (details.get("contact_damping") or {}).get("method", ""),
                            "simulations": stats.get("simulations")},
    }


def _row(record: dict) -> dict:
    res = record.get("result") or {}
    if isinstance(res.get("params"), dict):  # a FitResult document (every estimate since issue 25)
        res = _fit_result_fields(res)
    # else: a fit file of an earlier impactid (rig P's own document), read as it was written
    unc = res.get("uncertainty") or {}
    recs = res.get("recordings") or []
    nan = math.nan

    def num(value) -> float:
        return float(value) if isinstance(value, (int, float)) and not isinstance(value, bool) else nan

    def bound(name: str, k: int) -> float:
        pair = unc.get(name) or [None, None]
        return num(pair[k]) if len(pair) > k else nan

    single = record.get("kind") == "single" and len(recs) == 1
    json_path = Path("fits") / f"{record.get('key', '')}.json"
    return {
        "campaign": record.get("campaign", ""), "kind": record.get("kind", ""), "name": record.get("name", ""),
        "status": record.get("status", ""), "reason": record.get("reason", ""),
        "recordings": ";".join(r.get("name", "") for r in record.get("recordings", [])),
        "n_recordings": len(record.get("recordings", [])),
        "e_over_rc": num(recs[0].get("e_over_rc")) if single else nan,
        "cam_speed_hz": num(recs[0].get("cam_speed_hz")) if single else nan,
        "operating_points": ";".join(f"{num(r.get('e_over_rc')):.4g}/{num(r.get('cam_speed_hz')):.4g}" for r in recs),
        "beta": num(res.get("beta")), "beta_lo": bound("beta_interval", 0), "beta_hi": bound("beta_interval", 1),
        "n": num(res.get("n")), "n_lo": bound("n_interval", 0), "n_hi": bound("n_interval", 1),
        "n_fixed": bool(unc.get("n_fixed", False)), "separable": unc.get("separable"),
        "gamma": num(res.get("gamma")), "gamma_stderr": num(unc.get("gamma_stderr")),
        "xi_mean": num(res.get("xi_mean")), "va_mean": num(res.get("va_mean")),
        "impacts_used": int(res["impacts_used"]) if isinstance(res.get("impacts_used"), int) else 0,
        "residual": res.get("residual", ""), "objective": num(res.get("objective")),
        "method": (res.get("contact_damping") or {}).get("method", ""),
        "simulations": int((res.get("contact_damping") or {}).get("simulations") or 0),
        "warnings": len(res.get("warnings") or []), "seconds": num(record.get("seconds")),
        "key": record.get("key", ""), "json": str(json_path),
    }


def summary_table(records: Sequence[dict]) -> pd.DataFrame:
    """The summary table of fit records (one row per fit, the columns of :data:`COLUMNS`).

    Units: ``beta*`` N s m^-(n+1), ``gamma*`` s/m, ``va_mean`` m/s, ``cam_speed_hz`` Hz,
    ``seconds`` s of the fit task; ``e_over_rc`` and ``cam_speed_hz`` are those of a single fit's
    recording (NaN for joint fits, whose points are listed in ``operating_points`` as ``e/r_c/Hz``).
    """
    return _frame([_row(r) for r in records])


def _frame(rows: Sequence[dict]) -> pd.DataFrame:
    frame = pd.DataFrame(list(rows), columns=list(COLUMNS))
    frame["separable"] = frame["separable"].astype("boolean")
    return frame


def read_fits(out: str | os.PathLike[str], keys: Sequence[str] | None = None) -> list[dict]:
    """The fit records of an output folder (``fits/*.json``; only ``keys``, in their order, if given).

    ``summary_table(read_fits(out))`` rebuilds the table of every fit the folder holds.
    """
    folder = Path(out) / "fits"
    paths = [folder / f"{k}.json" for k in keys] if keys is not None else sorted(folder.glob("*.json"))
    records = []
    for path in paths:
        with contextlib.suppress(OSError, ValueError):
            record = json.loads(path.read_text())
            if isinstance(record, dict) and "key" in record:
                records.append(record)
    return records

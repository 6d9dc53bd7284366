"""Dataset manifests: a study's recordings as they come, each with its own reading, range and role.

A manifest (TOML) lists recordings; each is read with its own mapping spec (or as a file in pinid's
dataset format), cut to a time or row range, and given a role — training, validation or payload (drive
gains).  So one file can give a training and a validation range without a converter::

    description = "UR-like arm, run 3"      # optional
    drives = "drives.toml"                  # optional: replaces the URDF's transmissions
    payload = "payload.toml"                # with role = "payload" recordings: drive gains from currents
    delay = 0.04                            # optional: torque delay [s], "auto", "auto-per-joint" or { tau = 0.04 }
    fit_joints = ["shoulder", "elbow"]      # optional: joints whose torque rows enter the fit
    offsets = "per-recording"               # optional: one torque offset per joint per training recording
    calibrate_offsets = 0.1                 # optional: validation offsets fitted on each one's first 10 %
    allow_overlap = false                   # optional: true turns overlapping ranges into a warning

    [[recording]]
    file = "run3.csv"
    mapping = "rig.toml"                    # optional; without it, pinid's dataset format
    role = "train"                          # train | validate | payload
    time = [0.0, 60.0]                      # optional: start ≤ t < stop [s]; or rows = [0, 6000]

    [[recording]]
    file = "run3.csv"
    mapping = "rig.toml"
    role = "validate"
    time = [60.0, 90.0]

Paths (``file``, ``mapping``, ``drives``, ``payload``) are relative to the manifest's folder, else (when no
such file is there) to the working folder.  ``rows`` are
0-based data rows, ``[first, stop)`` as a Python slice (``stop`` may be left out: ``rows = [6000]``);
``time`` selects the samples with ``start ≤ t < stop`` on the recording's own time column.  Two ranges
that share a sample are refused (a validation range inside the training range measures a
training error; two training ranges count rows twice) unless ``allow_overlap = true`` (then a warning): of
one file by row index, of two files (a copy, a hard link, the same rows cut to a file of their own) by the
samples themselves (t, q and tau, bit for bit).  A ``rows`` stop past the end of the file is refused.
Unknown keys, missing files, an empty range and a manifest without a training recording are one-line
errors.  The range is cut from the recording as read, before any filtering, so a range gives exactly what
the same rows written to a file of their own give.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from pinid.data.dataset import Dataset
from pinid.data.formats import read_recording, warn
from pinid.errors import DataError, SpecError

ROLES: tuple[str, ...] = ("train", "validate", "payload")
_TOP = {
    "description",
    "drives",
    "payload",
    "delay",
    "fit_joints",
    "offsets",
    "calibrate_offsets",
    "allow_overlap",
    "recording",
}
_ENTRY = {"file", "mapping", "role", "time", "rows", "label"}


@dataclass(frozen=True)
class Entry:
    """One recording of a manifest: its file, mapping spec (None: dataset format), role and range."""

    file: Path
    mapping: Path | None
    role: str
    time: tuple[float, float] | None = None
    rows: tuple[int, int | None] | None = None
    label: str | None = None

    @property
    def name(self) -> str:
        """How the recording is shown: the file and its range."""
        if self.label:
            return self.label
        if self.time is not None:
            return f"{self.file.name}[t {self.time[0]:g}–{self.time[1]:g} s]"
        if self.rows is not None:
            return f"{self.file.name}[rows {self.rows[0]}:{'' if self.rows[1] is None else self.rows[1]}]"
        return self.file.name


@dataclass
class Manifest:
    """A parsed, checked manifest (see the module text); :meth:`read` gives the recordings."""

    path: Path
    entries: list[Entry]
    drives: Path | None = None
    payload: Path | None = None
    delay: Any = None
    fit_joints: list[str] | None = None
    offsets: str | None = None
    calibrate_offsets: float | None = None
    allow_overlap: bool = False
    description: str = ""

    @classmethod
    def load(cls, path: str | os.PathLike) -> "Manifest":
        """Read and check a manifest TOML file (files must exist; the recordings are not read yet)."""
        from pinid.io import read_toml

        p = Path(path)
        if not p.is_file():
            raise SpecError(f"{p}: manifest not found, expected a TOML file with [[recording]] tables")
        return cls.from_dict(read_toml(p, "manifest with [[recording]] tables"), p)

    @classmethod
    def from_dict(cls, d: dict, path: Path) -> "Manifest":
        """Check the dict form of a manifest read from ``path`` (relative paths from its folder)."""
        origin = str(path)
        _unknown(d, _TOP, origin, "the manifest")
        recs = d.get("recording")
        if not isinstance(recs, list) or not recs or not all(isinstance(r, dict) for r in recs):
            raise SpecError(f"{origin}: no [[recording]] tables; expected at least one with file and role")
        folder = path.parent
        entries = [_entry(r, k, folder, origin) for k, r in enumerate(recs)]
        if not any(e.role == "train" for e in entries):
            raise SpecError(f'{origin}: no recording with role = "train"; expected at least one training recording')
        payload = _file(d["payload"], folder, origin, "payload") if "payload" in d else None
        if (payload is None) != (not any(e.role == "payload" for e in entries)):
            raise SpecError(
                f'{origin}: payload = "FILE" and recordings with role = "payload" go together (drive gains)'
            )
        fit = d.get("fit_joints")
        if fit is not None and (not isinstance(fit, list) or not all(isinstance(j, str) for j in fit)):
            raise SpecError(f"{origin}: fit_joints = {fit!r}, expected a list of joint names")
        overlap = d.get("allow_overlap", False)
        if not isinstance(overlap, bool):
            raise SpecError(f"{origin}: allow_overlap = {overlap!r}, expected true or false")
        desc = d.get("description", "")
        if not isinstance(desc, str):
            raise SpecError(f"{origin}: description = {desc!r}, expected text")
        return cls(
            path,
            entries,
            drives=_file(d["drives"], folder, origin, "drives") if "drives" in d else None,
            payload=payload,
            delay=d.get("delay"),
            fit_joints=fit,
            offsets=d.get("offsets"),
            calibrate_offsets=d.get("calibrate_offsets"),
            allow_overlap=overlap,
            description=desc,
        )

    def read(self, model=None) -> "ManifestRecordings":
        """Read every recording (with ``model``: in its joint order, checked against it), cut to its range;
        DataError for an empty range or overlapping ranges of one file (see the module text)."""
        spans: list[tuple[str, int, int, Entry, np.ndarray]] = []
        study = ManifestRecordings(self)
        for e in self.entries:
            ds = read_recording(e.file, mapping=e.mapping, model=model)
            first, stop = _span(ds, e, self.path)
            path, keys = os.path.realpath(e.file), _row_keys(ds, first, stop)
            for p, a, b, other, other_keys in spans:
                if p == path:
                    shared = (
                        f"rows {max(a, first)}–{min(b, stop) - 1} of {e.file.name}" if first < b and a < stop else ""
                    )
                else:  # another file: a copy (or hard link) shares samples, not a path
                    n = np.intersect1d(keys, other_keys).size
                    shared = f"{n} samples (the same t, q and tau in {e.file.name} and {other.file.name})" if n else ""
                if shared:
                    msg = f"{self.path}: {e.name} ({e.role}) and {other.name} ({other.role}) share {shared}"
                    if not self.allow_overlap:
                        raise DataError(msg + "; expected ranges that do not overlap (allow_overlap = true allows it)")
                    warn(None, msg + " (allow_overlap = true)")
            spans.append((path, first, stop, e, keys))
            part = ds.select(slice(first, stop))
            part.source = str(e.file) if e.time is None and e.rows is None else f"{e.file}[{_range_text(e)}]"
            if e.label:
                part.source = e.label
            study.by_role[e.role].append(part)
        return study


@dataclass
class ManifestRecordings:
    """The recordings of a manifest by role (``train``, ``validate``, ``payload``) and its settings."""

    manifest: Manifest
    by_role: dict[str, list[Dataset]] = field(default_factory=lambda: {r: [] for r in ROLES})

    @property
    def train(self) -> list[Dataset]:
        """The training recordings."""
        return self.by_role["train"]

    @property
    def validate(self) -> list[Dataset] | None:
        """The validation recordings (None when there is none)."""
        return self.by_role["validate"] or None

    @property
    def payload_data(self) -> list[Dataset] | None:
        """The recordings with the payload (None when there is none)."""
        return self.by_role["payload"] or None


def _range_text(e: Entry) -> str:
    if e.time is not None:
        return f"t {e.time[0]:g}–{e.time[1]:g} s"
    return f"rows {e.rows[0]}:{'' if e.rows[1] is None else e.rows[1]}"


def _span(ds: Dataset, e: Entry, origin: Path) -> tuple[int, int]:
    """``[first, stop)`` sample indices of the entry's range in the recording; DataError when empty."""
    if e.time is not None:
        inside = np.flatnonzero((ds.t >= e.time[0]) & (ds.t < e.time[1]))
        if inside.size == 0:
            raise DataError(
                f"{origin}: {e.name}: no sample with {e.time[0]:g} ≤ t < {e.time[1]:g} s "
                f"(the recording spans {ds.t[0]:g}–{ds.t[-1]:g} s); expected a range inside it"
            )
        return int(inside[0]), int(inside[-1]) + 1
    if e.rows is not None:
        first, stop = e.rows[0], ds.n if e.rows[1] is None else e.rows[1]
        if stop > ds.n:
            raise DataError(
                f"{origin}: {e.name}: rows {e.rows[0]}:{e.rows[1]} go past the end of {e.file.name}, which has "
                f"{ds.n} rows; expected a stop ≤ {ds.n} (or [first] for every row from first)"
            )
        if first >= stop:
            raise DataError(
                f"{origin}: {e.name}: rows {e.rows[0]}:{'' if e.rows[1] is None else e.rows[1]} select no row "
                f"of {ds.n}; expected a range inside the recording"
            )
        return first, stop
    return 0, ds.n


def _row_keys(ds: Dataset, first: int, stop: int) -> np.ndarray:
    """Sorted 64-bit keys of the samples ``[first, stop)`` (time, positions, torque, bit for bit): two
    recordings share a sample when they share a key (a copy of a file shares all of them)."""
    cols = [ds.t[first:stop, None], ds.q[first:stop]] + ([] if ds.tau is None else [ds.tau[first:stop]])
    bits = np.ascontiguousarray(np.hstack(cols), dtype=np.float64).view(np.uint64)
    mult = np.random.default_rng(0).integers(1, 2**63, size=bits.shape[1], dtype=np.uint64) | np.uint64(1)
    with np.errstate(over="ignore"):
        keys = (bits ^ (bits >> np.uint64(29))) * mult
        return np.unique(np.bitwise_xor.reduce(keys * np.uint64(0x9E3779B97F4A7C15), axis=1))


def _unknown(d: dict, allowed: set[str], origin: str, where: str) -> None:
    bad = sorted(str(k) for k in d if k not in allowed)
    if bad:
        raise SpecError(
            f"{origin}: unknown key(s) {', '.join(bad)} in {where}; expected some of {', '.join(sorted(allowed))}"
        )


def _file(v: Any, folder: Path, origin: str, key: str) -> Path:
    if not isinstance(v, str) or not v:
        raise SpecError(f"{origin}: {key} = {v!r}, expected a file name (relative to the manifest's folder)")
    p = folder / v
    if not p.exists():
        here = Path(v)  # else relative to the working folder (a manifest in a clone naming ../shared/… beside it)
        if not here.is_absolute() and here.exists():
            return here
        also = "" if Path(v).is_absolute() else f" nor {Path.cwd() / v}"
        raise SpecError(f"{origin}: {key} = {v!r}: {p} not found{also}")
    return p


def _entry(r: dict, k: int, folder: Path, origin: str) -> Entry:
    where = f"[[recording]] {k + 1}"
    _unknown(r, _ENTRY, origin, where)
    if "file" not in r:
        raise SpecError(f'{origin}: {where} has no file; expected file = "recording.csv"')
    role = r.get("role")
    if role not in ROLES:
        raise SpecError(f"{origin}: {where} role = {role!r}, expected one of {', '.join(ROLES)}")
    if "time" in r and "rows" in r:
        raise SpecError(f"{origin}: {where} has both time and rows; expected one range")
    time = rows = None
    if "time" in r:
        v = r["time"]
        ok = isinstance(v, list) and len(v) == 2 and all(_real(x) for x in v)
        if not ok or not np.all(np.isfinite(v)) or v[0] >= v[1]:
            raise SpecError(f"{origin}: {where} time = {v!r}, expected [start, stop] in seconds with start < stop")
        time = (float(v[0]), float(v[1]))
    if "rows" in r:
        v = r["rows"]
        ok = isinstance(v, list) and len(v) in (1, 2) and all(isinstance(x, int) and not isinstance(x, bool) for x in v)
        if not ok or v[0] < 0 or (len(v) == 2 and v[1] <= v[0]):
            raise SpecError(
                f"{origin}: {where} rows = {v!r}, expected [first, stop] with 0 ≤ first < stop (or [first])"
            )
        rows = (int(v[0]), int(v[1]) if len(v) == 2 else None)
    label = r.get("label")
    if label is not None and not isinstance(label, str):
        raise SpecError(f"{origin}: {where} label = {label!r}, expected text")
    return Entry(
        _file(r["file"], folder, origin, f"{where} file"),
        _file(r["mapping"], folder, origin, f"{where} mapping") if "mapping" in r else None,
        role,
        time,
        rows,
        label,
    )


def _real(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)

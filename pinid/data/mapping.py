"""Mapping specs: how to read a recording that is not in pinid's dataset format.

A mapping spec is a small TOML file (or the same structure as a dict) that says where each joint's
position, velocity, acceleration and torque are, in which unit, and where the time is.  The full
reference with worked examples is ``docs/data.md``; in short::

    # top-level keys describe the main file (the one given to read_recording / --data)
    header = true                 # false: columns by 0-based index (or name them with `names`)
    delimiter = ","               # default: guessed from the first data line (, ; tab or spaces)
    rows = [0, -1]                # rows to keep, Python slice [start, stop) (default: all)
    time = { column = "time", scale = 1.0 }     # or time = { rate = 1000.0 } when there is no time column

    [joints.hip]
    q = { column = "pos_meas1" }                # a column name, a 0-based index, or a table
    tau = { column = "cur1", scale = 0.107 }    # current [A] × torque constant [N·m/A]

    [joints.knee]
    q = { column = 3, scale = "deg", sign = -1 }
    tau = { source = "torques", column = "knee", scale = 2.5 }

    [sources.torques]             # another file, relative to the main file's folder and inside it
    path = "{stem}_torque.csv"    # {stem}: the main file's name without suffix; {name}: with it; {suffix}
    time = { column = "t_ms", scale = "ms" }   # own time stamps: interpolated onto the main time

Motor-side measurements through a transmission (possibly coupled, as on wrists)::

    [transmission]
    joints = ["wrist_2", "wrist_3"]
    motors = ["m2", "m3"]
    matrix = [[50, 0], [-50, 50]]   # q_motor = matrix · q_joint  (rows: motors, columns: joints)
    [motors.m2]
    q = { column = "enc2", scale = 9.587e-5 }
    tau = { column = "cur2", scale = 0.05 }

Positions, velocities and accelerations of the joints are ``matrix⁻¹ · motor``; joint torques are
``matrixᵀ · motor torque`` (power balance, losses ignored).  A value is ``sign · scale · raw + offset``,
``offset`` in SI units after scaling.
"""

from __future__ import annotations

import difflib
import os
import re
import warnings
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from pinid.data.registry import READERS, Table, reader_for
from pinid.errors import DataError, DataWarning, SpecError
from pinid.io import read_toml
from pinid.model.drives import Transmission, transmission_from_table
from pinid.data.dataset import Dataset, FloatingChannels
from pinid.io import as_path

QUANTITIES: tuple[str, ...] = ("q", "dq", "ddq", "tau")

#: Unit words accepted as ``scale`` of joint quantities (factor to SI).
SCALE_WORDS: dict[str, float] = {
    "rad": 1.0,
    "deg": np.pi / 180.0,
    "mrad": 1e-3,
    "m": 1.0,
    "mm": 1e-3,
    "N·m": 1.0,
    "Nm": 1.0,
    "mNm": 1e-3,
}
#: Unit words of a ``scale`` in the ``[floating]`` table (factor to SI), beside the joints' words.
FLOATING_SCALE_WORDS: dict[str, float] = {
    "m": 1.0,
    "cm": 1e-2,
    "mm": 1e-3,
    "rad/s": 1.0,
    "deg/s": np.pi / 180.0,
    "m/s²": 1.0,
    "m/s^2": 1.0,
    "g": 9.80665,
    "N": 1.0,
    "kN": 1e3,
    "N·m": 1.0,
    "Nm": 1.0,
    "N·mm": 1e-3,
    "Nmm": 1e-3,
}
_FLOATING_WORDS = {**SCALE_WORDS, **FLOATING_SCALE_WORDS}
#: Unit words accepted as ``scale`` of the time column (factor to seconds).
TIME_WORDS: dict[str, float] = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6, "ns": 1e-9}

_SOURCE_KEYS = {"path", "format", "delimiter", "header", "skip_rows", "comment", "names", "rows", "time", "ros"}
_TOP_KEYS = (_SOURCE_KEYS - {"path"}) | {
    "joints",
    "motors",
    "sources",
    "transmission",
    "checks",
    "description",
    "floating",
}
_COLUMN_KEYS = {"column", "source", "index", "scale", "sign", "offset"}
_TIME_KEYS = {"column", "index", "scale", "offset", "rate", "rebase"}
_CHECK_VALUES = ("error", "warn", "off")
_CHECK_KEYS = {"limits", "degrees"}
MAIN = "main"
#: The placeholders of a ``[sources.x] path``, substituted literally (nothing else in braces is allowed).
PLACEHOLDERS: tuple[str, ...] = ("stem", "name", "suffix")
_BRACES = re.compile(r"\{([^{}]*)\}")


# ---------------------------------------------------------------------------------------------- spec objects
@dataclass(frozen=True)
class ColumnRef:
    """Where one signal is: a source, a column (name or 0-based index), and the conversion to SI."""

    source: str
    column: str | int
    index: int | None = None  # column of a 2-D array in an NPZ file
    scale: float = 1.0
    sign: float = 1.0
    offset: float = 0.0
    where: str = ""  # the spec's table, for messages: "[joints.hip.tau]"


@dataclass(frozen=True)
class TimeSpec:
    """The time of a source: a column (scaled to seconds) or a constant sample rate [Hz]."""

    column: str | int | None = None
    index: int | None = None
    scale: float = 1.0
    offset: float = 0.0
    rate: float | None = None
    rebase: bool = False  # True: time from the file's first sample (t - t[0]), e.g. Unix time stamps


@dataclass
class SourceSpec:
    """How to read one file."""

    name: str
    path: str | None = None  # None for the main file
    format: str = "auto"
    delimiter: str | None = None
    header: bool = True
    skip_rows: int = 0
    comment: str = "#"
    names: list[str] | None = None
    rows: tuple[int | None, int | None] = (None, None)
    time: TimeSpec | None = None
    ros: dict | None = None  # [ros] of a ROS 2 bag: topic, effort_topic, time (pinid.data.rosbag)


@dataclass
class MappingSpec:
    """A parsed, validated mapping spec; :meth:`read` turns a file into a :class:`~pinid.data.dataset.Dataset`.

    ``floating``: the ``[floating]`` table of a floating base's recording, each floating column's
    dataset-format name (``base_x``, ``imu_<frame>_wx``, ``wrench_<link>_fz``, ``plate_<link>_copx``,
    ``contact_<link>`` …, docs/floating-base.md) → where it is, as a joint signal is (a column name, an index,
    or ``{ column, source, index, scale, sign, offset }``; ``scale`` a number or a word of
    :data:`FLOATING_SCALE_WORDS` or :data:`SCALE_WORDS`); :meth:`read_all` reads them with the joints, on the
    samples inside every source of either.  Empty for a fixed base."""

    main: SourceSpec
    sources: dict[str, SourceSpec] = field(default_factory=dict)
    joints: dict[str, dict[str, ColumnRef]] = field(default_factory=dict)
    motors: dict[str, dict[str, ColumnRef]] = field(default_factory=dict)
    transmission: Transmission | None = None
    checks: dict[str, str] = field(default_factory=dict)
    origin: str = "<mapping>"
    allow_outside_paths: bool = False  # True: [sources.*] paths may leave the main file's folder
    floating: dict[str, ColumnRef] = field(default_factory=dict)

    # ------------------------------------------------------------------ construction
    @classmethod
    def load(
        cls, spec: "str | os.PathLike | dict | MappingSpec", *, allow_outside_paths: bool = False
    ) -> "MappingSpec":
        """A spec from a TOML file, a dict of the same structure, or an existing spec.

        ``allow_outside_paths``: let ``[sources.*]`` paths leave the main file's folder (refused by default:
        a spec from elsewhere must not read, or show in a message, files such as ``/etc/shadow``).
        """
        if isinstance(spec, MappingSpec):
            return replace(spec, allow_outside_paths=True) if allow_outside_paths else spec
        if isinstance(spec, dict):
            return replace(cls.from_dict(spec, origin="mapping spec"), allow_outside_paths=allow_outside_paths)
        p = Path(spec)
        if not p.is_file():
            raise SpecError(f"{p}: mapping spec not found, expected a TOML file")
        d = read_toml(p, "TOML mapping spec")
        return replace(cls.from_dict(d, origin=str(p)), allow_outside_paths=allow_outside_paths)

    @classmethod
    def from_dict(cls, d: dict, *, origin: str = "mapping spec") -> "MappingSpec":
        """Validate the dict form; unknown keys are errors (they are usually typos)."""
        if not isinstance(d, dict):
            raise SpecError(f"{origin}: expected a table of keys, got {type(d).__name__}")
        _unknown(d, _TOP_KEYS, origin, "the top level")
        main = _source(MAIN, {k: v for k, v in d.items() if k in _SOURCE_KEYS}, origin, main=True)
        if main.time is None and main.ros is not None:
            main.time = TimeSpec(column="t")  # a ROS 2 bag's own clock
        if main.time is None:
            raise SpecError(
                f'{origin}: no time: give time = {{ column = "..." }} (a time column) or '
                "time = { rate = ... } (a constant sample rate in Hz)"
            )
        sources = {}
        raw_sources = d.get("sources", {})
        if not isinstance(raw_sources, dict):
            raise SpecError(f"{origin}: [sources] must be a table of named files")
        for name, sd in raw_sources.items():
            if name == MAIN:
                raise SpecError(f"{origin}: [sources.{MAIN}] is reserved for the main file; choose another name")
            if not isinstance(sd, dict):
                raise SpecError(f'{origin}: [sources.{name}] must be a table with at least path = "..."')
            _unknown(sd, _SOURCE_KEYS, origin, f"[sources.{name}]")
            if "path" not in sd:
                raise SpecError(f'{origin}: [sources.{name}] has no path, expected path = "file.csv"')
            sources[name] = _source(name, sd, origin)
        known_sources = {MAIN, *sources}
        joints = _signal_tables(d.get("joints", {}), "joints", origin, known_sources)
        motors = _signal_tables(d.get("motors", {}), "motors", origin, known_sources)
        transmission = None
        if "transmission" in d:
            transmission = _transmission(d["transmission"], origin, motors, joints)
        elif motors:
            raise SpecError(f"{origin}: [motors] given without a [transmission] saying how motors drive joints")
        if not joints and transmission is None:
            raise SpecError(f"{origin}: no joints, expected [joints.<name>] tables (or a [transmission])")
        checks = d.get("checks", {})
        if not isinstance(checks, dict):
            raise SpecError(f'{origin}: [checks] must be a table, e.g. limits = "warn"')
        _unknown(checks, _CHECK_KEYS, origin, "[checks]")
        for k, v in checks.items():
            if v not in _CHECK_VALUES:
                raise SpecError(f"{origin}: [checks] {k} = {v!r}, expected one of {', '.join(_CHECK_VALUES)}")
        floating = _floating_table(d.get("floating", {}), origin, known_sources)
        return cls(main, sources, joints, motors, transmission, dict(checks), origin, floating=floating)

    @property
    def joint_names(self) -> list[str]:
        """Joints the spec produces: the direct ones, then those behind the transmission."""
        out = list(self.joints)
        if self.transmission is not None:
            out += [j for j in self.transmission.joints if j not in out]
        return out

    # ------------------------------------------------------------------ reading
    def _load(self, path: Path) -> tuple[np.ndarray, np.ndarray, dict, Any]:
        """The main file's time [s], the mask of its samples inside every timed source, the values of every
        column reference (sources interpolated onto the main time) and the main file's table."""
        refs_by_source: dict[str, list[ColumnRef]] = {}
        for table in (self.joints, self.motors, {"": self.floating}):
            for sig in table.values():
                for ref in sig.values():
                    refs_by_source.setdefault(ref.source, []).append(ref)
        # main file
        main_tab = _open_source(self.main, path, path, refs_by_source.get(MAIN, []), self.origin)
        t = _time_of(main_tab, self.main, self.origin)
        values: dict[ColumnRef, np.ndarray] = {}
        for ref in refs_by_source.get(MAIN, []):
            values[ref] = main_tab.values(ref, self.origin)
        keep = np.ones(len(t), dtype=bool)
        for name, src in self.sources.items():
            refs = refs_by_source.get(name, [])
            if not refs:
                continue
            file = _source_file(src, path, self.origin, self.allow_outside_paths)
            tab = _open_source(src, file, path, refs, self.origin)
            if src.time is None:
                if tab.nrows != len(t):
                    raise DataError(
                        f"{file}: {tab.nrows} rows, but {path.name} has {len(t)} (columns of different lengths); "
                        f"expected the same number of rows, or a time for [sources.{name}] to align them"
                    )
                for ref in refs:
                    values[ref] = tab.values(ref, self.origin)
            else:
                ts = _time_of(tab, src, self.origin)
                inside = (t >= ts[0]) & (t <= ts[-1])
                if not inside.any():
                    raise DataError(
                        f"{file}: its time [{ts[0]:g}, {ts[-1]:g}] s does not overlap "
                        f"{path.name}'s [{t[0]:g}, {t[-1]:g}] s, expected recordings of the same run"
                    )
                keep &= inside
                for ref in refs:
                    values[ref] = np.interp(t, ts, tab.values(ref, self.origin))
        return t, keep, values, main_tab

    def time_span(self, path: str | os.PathLike) -> tuple[float, float]:
        """The (first, last) time [s] of the main file ``path`` inside every timed source this spec reads."""
        path = Path(path)
        t, keep = self._load(path)[:2]
        if not keep.any():
            raise DataError(f"{path}: no sample lies inside every source's time span ({self.origin})")
        return float(t[keep][0]), float(t[keep][-1])

    def read(self, path: str | os.PathLike) -> Dataset:
        """Read the main file ``path`` (and the other sources) into a Dataset (not yet checked against a model)."""
        return self.read_all(path)[0]

    def read_all(self, path: str | os.PathLike) -> tuple[Dataset, dict[str, np.ndarray]]:
        """:meth:`read`, and the ``[floating]`` columns by name [SI units] on the Dataset's samples (``{}``
        without a ``[floating]`` table): the joints and the floating columns keep one common time span, the
        samples inside every source of either."""
        path = Path(path)
        t, keep, values, main_tab = self._load(path)
        if self.floating and not keep.any():
            raise DataError(
                f"{path}: the joint and [floating] sources have no common time span (no sample lies inside every "
                "source's time span); expected recordings of the same run"
            )
        floating = _orientations({name: _convert(values[ref], ref) for name, ref in self.floating.items()})
        columns_desc: dict[str, str] = {}
        for ref in values:
            columns_desc.setdefault(ref.where, f"{ref.source}:{ref.column!r}")
        n = len(t)
        # assemble joint signals
        signals: dict[str, dict[str, np.ndarray]] = {}
        for joint, sig in self.joints.items():
            signals[joint] = {qty: _convert(values[ref], ref) for qty, ref in sig.items()}
        if self.transmission is not None:
            tr = self.transmission
            for qty in QUANTITIES:
                have = [m for m in tr.motors if qty in self.motors.get(m, {})]
                if not have:
                    continue
                if len(have) != len(tr.motors):
                    missing = [m for m in tr.motors if m not in have]
                    raise SpecError(
                        f"{self.origin}: {qty} given for motors {have} but not {missing}; "
                        "a transmission needs every motor's value to compute the joints'"
                    )
                motor = np.column_stack([_convert(values[self.motors[m][qty]], self.motors[m][qty]) for m in tr.motors])
                joint_vals = motor @ tr.matrix if qty == "tau" else np.linalg.solve(tr.matrix, motor.T).T
                for i, j in enumerate(tr.joints):
                    signals.setdefault(j, {})[qty] = joint_vals[:, i]
        values.clear()  # the columns live on in ``signals`` only: each is let go once stacked (below)
        main_tab.data = {}
        joint_names = self.joint_names
        for j in joint_names:
            if "q" not in signals.get(j, {}):
                raise SpecError(f"{self.origin}: joint '{j}' has no position q, expected q = {{ column = ... }}")
        arrays: dict[str, np.ndarray | None] = {}
        for qty in QUANTITIES:
            have = [j for j in joint_names if qty in signals[j]]
            if have and len(have) != len(joint_names):
                missing = [j for j in joint_names if j not in have]
                raise SpecError(
                    f"{self.origin}: {qty} given for joints {have} but not for {missing}; "
                    f"expected {qty} for every joint or for none"
                )
            # one (N, nv) array per quantity; its columns let go as soon as it is stacked (one copy of the recording)
            arrays[qty] = np.column_stack([signals[j].pop(qty) for j in joint_names]) if have else None
        idx = np.flatnonzero(keep)
        if idx.size < n:
            warnings.warn(
                f"{path}: kept {idx.size} of {n} samples, those inside every source's time span",
                DataWarning,
                stacklevel=3,
            )
            t = t[idx]
            arrays = {k: (None if v is None else v[idx]) for k, v in arrays.items()}
            floating = {k: v[idx] for k, v in floating.items()}
        meta = {"mapping": self.origin, "columns": columns_desc, "checks": dict(self.checks)}
        if main_tab.line0 is not None and idx.size == n:
            meta["line0"] = main_tab.line0 + main_tab.row0  # file line of sample 0, for messages
        ds = Dataset(
            t=t,
            q=arrays["q"],
            joints=joint_names,
            dq=arrays["dq"],
            ddq=arrays["ddq"],
            tau=arrays["tau"],
            source=str(path),
            meta=meta,
        )
        return ds, floating


# ---------------------------------------------------------------------------------------------- parsing
def _unknown(d: dict, allowed: set[str], origin: str, where: str) -> None:
    for k in d:
        if k not in allowed:
            close = difflib.get_close_matches(str(k), sorted(allowed), n=1)
            hint = f" (did you mean '{close[0]}'?)" if close else ""
            raise SpecError(
                f"{origin}: unknown key '{k}' in {where}{hint}; expected some of {', '.join(sorted(allowed))}"
            )


def _source_path(v: Any, origin: str, where: str) -> str:
    """A ``[sources.x] path`` checked: text whose braces hold only :data:`PLACEHOLDERS`."""
    if not isinstance(v, str) or not v:
        raise SpecError(f'{origin}: path = {v!r} in {where}, expected a file name such as "{{stem}}_torque.csv"')
    if "\x00" in v:
        raise SpecError(f"{origin}: path = {v!r} in {where} holds a NUL character, expected a file name")
    for m in _BRACES.finditer(v):
        if m.group(1) not in PLACEHOLDERS:
            raise SpecError(
                f"{origin}: path = {v!r} in {where}: unknown placeholder {{{m.group(1)}}}, expected "
                f"{', '.join('{' + p + '}' for p in PLACEHOLDERS)} (a brace is not allowed otherwise)"
            )
    if "{" in _BRACES.sub("", v) or "}" in _BRACES.sub("", v):
        raise SpecError(
            f"{origin}: path = {v!r} in {where} has an unmatched brace, expected "
            f"{', '.join('{' + p + '}' for p in PLACEHOLDERS)} as the only text in braces"
        )
    return v


def _source_file(src: SourceSpec, main: Path, origin: str, allow_outside: bool) -> Path:
    """The file of source ``src`` for the main file ``main``: placeholders substituted literally, and
    (unless ``allow_outside``) inside ``main``'s folder once symbolic links are resolved."""
    values = {"stem": main.stem, "name": main.name, "suffix": main.suffix}
    file = main.parent / _BRACES.sub(lambda m: values[m.group(1)], src.path)
    if not allow_outside and not file.resolve().is_relative_to(main.parent.resolve()):
        raise SpecError(
            f"{origin}: [sources.{src.name}] path = {src.path!r} leads outside {main.parent.resolve()} "
            "(the recording's folder); expected a file in that folder or below it "
            "(--allow-outside-paths, or allow_outside_paths=True from Python, allows it)"
        )
    return file


def _number(v: Any, origin: str, where: str, *, words: dict[str, float] | None = None) -> float:
    if isinstance(v, str) and words is not None and v in words:
        return words[v]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v):
        extra = f" or one of {', '.join(words)}" if words else ""
        raise SpecError(f"{origin}: {where} = {v!r}, expected a finite number{extra}")
    return float(v)


def _rows(v: Any, origin: str, where: str) -> tuple[int | None, int | None]:
    if isinstance(v, dict):
        _unknown(v, {"start", "stop"}, origin, where)
        v = [v.get("start"), v.get("stop")]
    if (
        not isinstance(v, list)
        or len(v) != 2
        or not all(x is None or (isinstance(x, int) and not isinstance(x, bool)) for x in v)
    ):
        raise SpecError(
            f"{origin}: {where} = {v!r}, expected [start, stop] (0-based, stop excluded, negative from the end)"
        )
    return v[0], v[1]


def _column_key(col: Any, origin: str, where: str) -> str | int:
    """A column name or a 0-based index >= 0: one rule for the shorthand (``q = 3``) and the table form."""
    if isinstance(col, bool) or not isinstance(col, (str, int)) or (isinstance(col, int) and col < 0):
        raise SpecError(
            f"{origin}: {where} = {col!r}, expected a column name or a 0-based index >= 0 "
            "(negative indices are not accepted)"
        )
    return col


def _time(v: Any, origin: str, where: str) -> TimeSpec:
    if isinstance(v, (str, int)) and not isinstance(v, bool):
        return TimeSpec(column=_column_key(v, origin, where))
    if not isinstance(v, dict):
        raise SpecError(f"{origin}: {where} = {v!r}, expected a column name or index, or a table with column or rate")
    _unknown(v, _TIME_KEYS, origin, where)
    if ("column" in v) == ("rate" in v):
        raise SpecError(f"{origin}: {where} needs exactly one of column (time stamps) or rate (constant rate in Hz)")
    if "rate" in v:
        if "rebase" in v:
            raise SpecError(f"{origin}: {where}.rebase is for a time column; a rate's time starts at 0")
        rate = _number(v["rate"], origin, f"{where}.rate")
        if rate <= 0:
            raise SpecError(f"{origin}: {where}.rate = {rate:g}, expected a sample rate > 0 [Hz]")
        return TimeSpec(rate=rate)
    col = _column_key(v["column"], origin, f"{where}.column")
    index = v.get("index")
    rebase = v.get("rebase", False)
    if not isinstance(rebase, bool):
        raise SpecError(f"{origin}: {where}.rebase = {rebase!r}, expected true (time from the first sample) or false")
    return TimeSpec(
        column=col,
        index=index,
        scale=_number(v.get("scale", 1.0), origin, f"{where}.scale", words=TIME_WORDS),
        offset=_number(v.get("offset", 0.0), origin, f"{where}.offset"),
        rebase=rebase,
    )


def _source(name: str, d: dict, origin: str, *, main: bool = False) -> SourceSpec:
    where = "the top level" if main else f"[sources.{name}]"
    s = SourceSpec(name=name, path=None if main else _source_path(d["path"], origin, where))
    fmt = d.get("format", "auto")
    if fmt != "auto" and fmt not in READERS:
        raise SpecError(
            f"{origin}: format = {fmt!r} in {where}, expected {', '.join(repr(r) for r in READERS)} "
            "or 'auto' (by suffix)"
        )
    s.format = fmt
    if "delimiter" in d:
        delim = d["delimiter"]
        if not isinstance(delim, str) or len(delim) != 1 and delim not in ("whitespace", "\\t"):
            raise SpecError(f"{origin}: delimiter = {delim!r} in {where}, expected one character or 'whitespace'")
        s.delimiter = "\t" if delim == "\\t" else delim
    if "header" in d:
        if not isinstance(d["header"], bool):
            raise SpecError(f"{origin}: header = {d['header']!r} in {where}, expected true or false")
        s.header = d["header"]
    if "skip_rows" in d:
        if isinstance(d["skip_rows"], bool) or not isinstance(d["skip_rows"], int) or d["skip_rows"] < 0:
            raise SpecError(f"{origin}: skip_rows = {d['skip_rows']!r} in {where}, expected a count of lines >= 0")
        s.skip_rows = d["skip_rows"]
    if "comment" in d:
        if not isinstance(d["comment"], str) or not d["comment"]:
            raise SpecError(f"{origin}: comment = {d['comment']!r} in {where}, expected a non-empty string such as '#'")
        s.comment = d["comment"]
    if "names" in d:
        names = d["names"]
        if not isinstance(names, list) or not all(isinstance(x, str) for x in names):
            raise SpecError(f"{origin}: names in {where} must be a list of column names")
        s.names = list(names)
    if "rows" in d:
        s.rows = _rows(d["rows"], origin, f"rows in {where}")
    if "time" in d:
        s.time = _time(d["time"], origin, f"time in {where}")
    if "ros" in d:
        if not isinstance(d["ros"], dict):
            raise SpecError(f'{origin}: ros in {where} must be a table, e.g. [ros] topic = "/joint_states"')
        s.ros = dict(d["ros"])  # its keys are checked by the ROS 2 bag reader (pinid.data.rosbag.options)
    return s


def _column(v: Any, origin: str, where: str, sources: set[str], words: dict[str, float] = SCALE_WORDS) -> ColumnRef:
    if isinstance(v, (str, int)) and not isinstance(v, bool):
        return ColumnRef(MAIN, _column_key(v, origin, where), where=where)
    if not isinstance(v, dict):
        raise SpecError(
            f"{origin}: {where} = {v!r}, expected a column name, a 0-based index or a table with column = ..."
        )
    _unknown(v, _COLUMN_KEYS, origin, where)
    if "column" not in v:
        raise SpecError(f'{origin}: {where} has no column, expected column = "name" or a 0-based index')
    col = _column_key(v["column"], origin, f"{where}.column")
    source = v.get("source", MAIN)
    if source not in sources:
        raise SpecError(
            f"{origin}: {where}.source = {source!r} is not defined; expected '{MAIN}' or one of "
            f"[sources.*] ({', '.join(sorted(sources - {MAIN})) or 'none defined'})"
        )
    index = v.get("index")
    if index is not None and (isinstance(index, bool) or not isinstance(index, int) or index < 0):
        raise SpecError(f"{origin}: {where}.index = {index!r}, expected a 0-based column of a 2-D array")
    sign = _number(v.get("sign", 1.0), origin, f"{where}.sign")
    if sign not in (1.0, -1.0):
        raise SpecError(f"{origin}: {where}.sign = {sign:g}, expected 1 or -1")
    scale = _number(v.get("scale", 1.0), origin, f"{where}.scale", words=words)
    if scale == 0:
        raise SpecError(f"{origin}: {where}.scale = 0, expected a non-zero factor to SI units")
    return ColumnRef(source, col, index, scale, sign, _number(v.get("offset", 0.0), origin, f"{where}.offset"), where)


def _signal_tables(d: Any, kind: str, origin: str, sources: set[str]) -> dict[str, dict[str, ColumnRef]]:
    if not isinstance(d, dict):
        raise SpecError(f"{origin}: [{kind}] must be a table of [{kind}.<name>] tables")
    out = {}
    for name, sig in d.items():
        if not isinstance(sig, dict):
            raise SpecError(f"{origin}: [{kind}.{name}] must be a table with q = ..., and optionally dq, ddq, tau")
        _unknown(sig, set(QUANTITIES), origin, f"[{kind}.{name}]")
        out[name] = {qty: _column(v, origin, f"[{kind}.{name}.{qty}]", sources) for qty, v in sig.items()}
    return out


def _floating_table(d: Any, origin: str, sources: set[str]) -> dict[str, ColumnRef]:
    """The ``[floating]`` table: each key a floating column's dataset-format name, each value where it is."""
    if not isinstance(d, dict):
        raise SpecError(f'{origin}: [floating] must be a table of floating columns, e.g. base_x = "mocap_x"')
    out = {}
    for name, ref in d.items():
        if not any(FloatingChannels.groups([name]).values()) and not _RPY.fullmatch(name):
            raise SpecError(
                f"{origin}: [floating] {name}: not a floating column; expected base_x … base_qw, imu_<frame>_qx … _az, "
                "wrench_<link>_fx … _tz, plate_<link>_fx … _tz or contact_<link> (docs/floating-base.md), or an "
                "orientation as roll, pitch, yaw: base_roll, base_pitch, base_yaw (imu_<frame>_roll …)"
            )
        out[name] = _column(ref, origin, f"[floating.{name}]", sources, words=_FLOATING_WORDS)
    for prefix in sorted({m.group(1) for m in map(_RPY.fullmatch, out) if m}):
        have = [a for a in RPY if f"{prefix}_{a}" in out]
        if len(have) != 3:
            missing = [f"{prefix}_{a}" for a in RPY if a not in have]
            raise SpecError(
                f"{origin}: [floating] {', '.join(f'{prefix}_{a}' for a in have)} without {', '.join(missing)}; "
                "expected roll, pitch and yaw together (R = Rz(yaw)·Ry(pitch)·Rx(roll))"
            )
        quat = [f"{prefix}_{k}" for k in ("qx", "qy", "qz", "qw") if f"{prefix}_{k}" in out]
        if quat:
            raise SpecError(
                f"{origin}: [floating] {prefix}_roll, _pitch, _yaw and {', '.join(quat)} both give the orientation; "
                "expected one of the two (roll-pitch-yaw or a quaternion)"
            )
    return out


#: The axes of an orientation given as roll, pitch, yaw in a ``[floating]`` table (``base_roll`` …).
RPY: tuple[str, ...] = ("roll", "pitch", "yaw")
_RPY = re.compile(r"(base|imu_.+)_(roll|pitch|yaw)")


def rpy_to_quaternion(roll: np.ndarray, pitch: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """(N, 4) unit quaternions ``x, y, z, w`` of ``R = Rz(yaw)·Ry(pitch)·Rx(roll)`` (roll-pitch-yaw, ZYX) [rad],
    with a continuous sign (a yaw that wraps at ±π gives the same rotation, not a jump of the quaternion)."""
    from pinid.checks import as_floats

    roll, pitch, yaw = (as_floats(a, name).reshape(-1) for a, name in ((roll, "roll"), (pitch, "pitch"), (yaw, "yaw")))
    if not len(roll) == len(pitch) == len(yaw):
        raise DataError(f"roll, pitch, yaw: {len(roll)}, {len(pitch)}, {len(yaw)} samples, expected as many of each")
    cr, sr = np.cos(0.5 * roll), np.sin(0.5 * roll)
    cp, sp = np.cos(0.5 * pitch), np.sin(0.5 * pitch)
    cy, sy = np.cos(0.5 * yaw), np.sin(0.5 * yaw)
    q = np.column_stack(
        [
            sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy,
            cr * cp * cy + sr * sp * sy,
        ]
    )
    if len(q) > 1:  # as pinid.data.contacts.continuous_quat (which imports this module): q and −q are one rotation
        dots = np.einsum("ij,ij->i", q[1:], q[:-1])
        q *= np.concatenate([[1.0], np.cumprod(np.where(dots < 0, -1.0, 1.0))])[:, None]
    return q


def _orientations(floating: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The ``[floating]`` columns with each roll-pitch-yaw triple replaced by its quaternion's 4 columns."""
    prefixes = sorted({m.group(1) for m in map(_RPY.fullmatch, floating) if m})
    if not prefixes:
        return floating
    out = {k: v for k, v in floating.items() if not _RPY.fullmatch(k)}
    for prefix in prefixes:
        q = rpy_to_quaternion(*(floating[f"{prefix}_{a}"] for a in RPY))
        out.update({f"{prefix}_{k}": q[:, i] for i, k in enumerate(("qx", "qy", "qz", "qw"))})
    return out


def _transmission(d: Any, origin: str, motors: dict, joints: dict) -> Transmission:
    t = transmission_from_table(d, origin)  # the same type and checks as a robot's drives
    tj, tm = t.joints, t.motors
    for m in tm:
        if m not in motors:
            raise SpecError(f"{origin}: motor '{m}' of [transmission] has no [motors.{m}] table")
    for m in motors:
        if m not in tm:
            raise SpecError(f"{origin}: [motors.{m}] is not listed in [transmission] motors {tm}")
    for j in tj:
        if j in joints:
            raise SpecError(
                f"{origin}: joint '{j}' has data both in [joints.{j}] and through [transmission]; "
                "expected one or the other"
            )
    return t


def _convert(raw: np.ndarray, ref: ColumnRef) -> np.ndarray:
    if ref.scale == 1.0 and ref.sign == 1.0 and ref.offset == 0.0:
        return raw
    return (ref.sign * ref.scale) * raw + ref.offset


# ---------------------------------------------------------------------------------------------- tables
def _open_source(src: SourceSpec, file: Path, main_path: Path, refs: list[ColumnRef], origin: str) -> Table:
    reader = reader_for(file, src.format)
    if not reader.folder:
        _check_file(file)
    wanted: list[tuple[str | int, int | None, str]] = [(r.column, r.index, r.where) for r in refs]
    if src.time is not None and src.time.column is not None:
        wanted.append(
            (
                src.time.column,
                src.time.index,
                f"time of {'the main file' if src.name == MAIN else f'[sources.{src.name}]'}",
            )
        )
    tab = reader.read(file, src, wanted, origin)
    tab.time0 = 0.0
    if src.time is not None and src.time.rebase and tab.nrows:  # the file's first time stamp, before rows = [...]
        tab.time0 = float(tab.data[(src.time.column, src.time.index)][0])
    start, stop = src.rows
    if start is not None or stop is not None:
        sl = slice(start, stop)
        kept = range(tab.nrows)[sl]
        if len(kept) == 0:
            raise SpecError(f"{origin}: rows [{start}, {stop}] keep no row of {file.name}, which has {tab.nrows} rows")
        tab.data = {k: v[sl] for k, v in tab.data.items()}
        tab.nrows = len(kept)
        tab.row0 = kept.start
    else:
        tab.row0 = 0
    for col, index, where in wanted:
        a = tab.data[(col, index)]
        bad = np.flatnonzero(~np.isfinite(a))
        if bad.size:
            i = int(bad[0])
            kind = "NaN" if np.isnan(a[i]) else "an infinite value"
            at = f"line {tab.line0 + tab.row0 + i}" if tab.line0 is not None else f"index {tab.row0 + i}"
            name = f"{col}" + ("" if index is None else f"[:, {index}]")
            raise DataError(
                f"{file}: column '{name}' ({where.strip('[]')}) has {kind} at {at} "
                f"({bad.size} non-finite value{'s' if bad.size > 1 else ''} in all); expected finite numbers "
                "(drop those rows with rows = [start, stop] in a mapping spec)"
            )
    return tab


def _check_file(file: Path) -> None:
    if not file.exists():
        raise DataError(f"{file}: file not found, expected a recording")
    if file.is_dir():
        raise DataError(f"{file}: is a folder, expected a recording file")
    if not file.is_file():  # a FIFO would block the reader forever, a device never ends
        from pinid.io import check_input_file

        check_input_file(file, "recording", error=DataError)
    if file.stat().st_size == 0:
        raise DataError(f"{file}: file is empty, expected a recording")


def _time_of(tab: Table, src: SourceSpec, origin: str) -> np.ndarray:
    ts = src.time
    where = "the main file" if src.name == MAIN else f"[sources.{src.name}]"
    if ts.rate is not None:
        return (tab.row0 + np.arange(tab.nrows)) / ts.rate
    key = (ts.column, ts.index)
    if key not in tab.data:  # pragma: no cover - always requested
        raise SpecError(f"{origin}: time column {ts.column!r} of {where} was not read")
    raw = tab.data[key]
    if ts.rebase:
        raw = raw - getattr(tab, "time0", 0.0)
    t = raw * ts.scale + ts.offset
    return t


def peek_columns(path: str | os.PathLike) -> tuple[str, list[str]]:
    """``(format, names)`` of a file in pinid's dataset format: the CSV header or the NPZ array names
    (any registered reader with a ``columns`` function, :mod:`pinid.data.registry`)."""
    path = as_path(path, error=DataError)
    file = Path(path)
    reader = None
    if file.suffix or file.is_dir():
        try:
            reader = reader_for(file)
        except DataError:
            pass
    if reader is None or not reader.folder:
        _check_file(file)
    if reader is None or reader.columns is None:
        known = " or ".join(r.suffixes[0] for r in READERS.values() if r.columns and r.suffixes)
        raise DataError(
            f"{file}: unknown file type '{file.suffix}', expected {known} in pinid's dataset "
            "format, or a mapping spec (--mapping) that says how to read it"
        )
    return reader.name, reader.columns(file)

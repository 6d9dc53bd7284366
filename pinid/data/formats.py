"""Recordings on disk: read (pinid's dataset format, or any file through a mapping spec), check, write.

Dataset format (``docs/data.md``): a CSV file with a header, or an NPZ archive of 1-D arrays, with the
columns

=================  ==========================================  =========
name               what                                        unit
=================  ==========================================  =========
``t``              time, strictly increasing                   s
``q_<joint>``      joint position (one per joint, required)    rad or m
``dq_<joint>``     joint velocity (optional)                   rad/s
``ddq_<joint>``    joint acceleration (optional)               rad/s²
``tau_<joint>``    joint torque (optional for reading)         N·m or N
=================  ==========================================  =========

Other columns are ignored (listed in ``Dataset.meta["ignored_columns"]``).  A quantity is given for
every joint or for none.  Anything else is read with a mapping spec (:mod:`pinid.data.mapping`).

Checks (:func:`check_recording`, run by :func:`read_recording`): time stamps finite and strictly
increasing (no duplicates), no NaN or infinite values, columns of equal length; with a model: every
joint of the model present and no joint unknown to it, revolute positions that look like degrees,
positions outside the URDF limits.  Failures raise :class:`~pinid.errors.DataError` with a one-line
message naming the file, the column or joint, and what was expected; softer findings are
:class:`DataWarning` and are also listed in ``Dataset.meta["warnings"]``.
"""

from __future__ import annotations

import os
import warnings
import zipfile
from collections import Counter
from pathlib import Path

import numpy as np

from pinid.data.dataset import Dataset
from pinid.errors import DataError, DataWarning, SpecError
from pinid.io import atomic_path
from pinid.data.csv_reader import FLOAT_RE
from pinid.data.mapping import QUANTITIES, MappingSpec, peek_columns
from pinid.data.registry import Writer, register_writer, writer_for
from pinid.data.dataset import as_dataset
from pinid.checks import as_floats, count

PREFIXES: dict[str, str] = {"q": "q_", "dq": "dq_", "ddq": "ddq_", "tau": "tau_"}
CHECK_MODES = ("error", "warn", "off")


def warn(ds: Dataset | None, message: str) -> None:
    """Issue a :class:`DataWarning` and remember it in ``ds.meta["warnings"]``."""
    if not isinstance(message, str):
        raise DataError(f"message: got {type(message).__name__}, expected the warning's text")
    if ds is not None:
        ds.meta.setdefault("warnings", []).append(message)
    warnings.warn(message, DataWarning, stacklevel=3)


# ---------------------------------------------------------------------------------------------- reading
def format_spec(names: list[str], source: str = "recording") -> tuple[dict, list[str]]:
    """The mapping spec (dict form) of a file in the dataset format with columns ``names``.

    Returns ``(spec, ignored_columns)``.
    """
    if not isinstance(names, (list, tuple)) or not all(isinstance(n, str) for n in names):
        raise DataError(f"{source}: names: got {names!r:.60}, expected a list of column names")
    if names and all(FLOAT_RE.match(n) for n in names):
        raise DataError(
            f"{source}: the first line is numbers, not column names; pinid's dataset format needs a header "
            "(t, q_<joint>, ...), and a file without one needs a mapping spec with header = false"
        )
    counts = Counter(names)  # linear: names.count per name was quadratic (40 000 columns took a minute)
    dup = sorted(n for n, c in counts.items() if c > 1)
    if dup:
        raise DataError(
            f"{source}: column {dup[0]!r} appears {counts[dup[0]]} times in the header; expected each column once"
        )
    if "t" not in names:
        hint = " (it has 'time': use a mapping spec with time = \"time\")" if "time" in names else ""
        raise DataError(
            f"{source}: no column 't'{hint}; expected pinid's dataset format (t, q_<joint>, "
            "dq_<joint>, ddq_<joint>, tau_<joint>) or a mapping spec (--mapping) that says how to read it"
        )
    joints: dict[str, dict] = {}
    order: list[str] = []
    ignored: list[str] = []
    by_qty: dict[str, list[str]] = {q: [] for q in QUANTITIES}
    for n in names:
        for qty, pre in PREFIXES.items():
            if n.startswith(pre) and len(n) > len(pre):
                by_qty[qty].append(n[len(pre) :])
                break
        else:
            if n != "t":
                ignored.append(n)
    order = list(by_qty["q"])
    if not order:
        raise DataError(
            f"{source}: no position column q_<joint>; expected one q_<joint> per joint "
            f"(columns: {', '.join(names[:20])})"
        )
    for qty in ("dq", "ddq", "tau"):
        extra = [j for j in by_qty[qty] if j not in order]
        if extra:
            raise DataError(
                f"{source}: column '{PREFIXES[qty]}{extra[0]}' has no position column 'q_{extra[0]}'; "
                "expected every joint to have q_<joint>"
            )
    for qty in ("dq", "ddq", "tau"):
        have = by_qty[qty]
        if have and len(have) != len(order):
            missing = [j for j in order if j not in have]
            raise DataError(
                f"{source}: {qty} given for joints {have} but not for {missing}; expected a "
                f"{PREFIXES[qty]}<joint> column for every joint or for none"
            )
    for j in order:
        joints[j] = {qty: f"{PREFIXES[qty]}{j}" for qty in QUANTITIES if j in by_qty[qty]}
    return {"time": "t", "joints": joints}, ignored


def read_recording(
    path: str | os.PathLike,
    *,
    mapping: str | os.PathLike | dict | MappingSpec | None = None,
    model=None,
    limits: str | None = None,
    degrees: str | None = None,
    allow_outside_paths: bool = False,
    swing_rows: bool = False,
) -> Dataset:
    """Read a recording into a :class:`~pinid.data.dataset.Dataset` and check it.

    ``path``: a CSV or NPZ file in pinid's dataset format, or any file described by ``mapping`` (a TOML
    mapping spec path, a dict of the same structure, or a :class:`~pinid.data.mapping.MappingSpec`).
    ``model``: a :class:`~pinid.model.robot.RobotModel` (or a URDF path or robot name); when given, the columns are put in the order of
    ``model.joint_names`` and checked against the URDF (missing or unknown joints, degrees, limits).
    ``limits`` / ``degrees``: "error" (default), "warn" or "off" for those two checks; a mapping spec's
    ``[checks]`` table sets them too (the keyword wins).  ``allow_outside_paths``: let the mapping spec's
    ``[sources.*]`` paths leave the recording's folder (refused by default, ``docs/checks.md``).
    Raises DataError (bad data) or SpecError (bad mapping spec), one-line messages.

    With a floating ``model`` (:class:`~pinid.model.floating.FloatingRobotModel`) the base motion, IMU, contact
    wrenches, force plates and contact phases are read too, into ``floating``
    (:class:`~pinid.data.dataset.FloatingChannels`; the columns of docs/floating-base.md, or a mapping spec's
    ``[floating]`` table) and checked against the model (:func:`pinid.data.contacts.read_floating_channels`;
    ``swing_rows``: contact phases without a wrench are legs without force sensing).
    """
    if not isinstance(path, (str, os.PathLike)) or "\x00" in os.fspath(path):
        raise DataError(f"path: got {path!r:.60}, expected the path of a recording (a file name without NUL)")
    model = _robot_or_none(model)
    path = Path(path)
    floating = model is not None and _is_floating(model)
    if swing_rows and not floating:
        raise SpecError("swing_rows: only for a floating model (contact phases of legs without force sensing)")
    if mapping is None:
        _, names = peek_columns(path)
        spec_dict, ignored = format_spec(names, str(path))
        spec = MappingSpec.from_dict(spec_dict, origin=f"{path} (dataset format)")
    else:
        spec = MappingSpec.load(mapping, allow_outside_paths=allow_outside_paths)
        ignored = []
        if spec.floating and not floating:
            raise SpecError(
                f"{spec.origin}: a [floating] table ({', '.join(spec.floating)}) for "
                f"{'no model' if model is None else model.name + ', a fixed-base robot'}; expected a floating "
                "model (RobotModel.from_urdf(..., base='floating'), --base floating) or no [floating] table"
            )
    ds, columns = spec.read_all(path)
    if ignored:
        ds.meta["ignored_columns"] = ignored
    checks = dict(ds.meta.get("checks", {}))
    if limits is not None:
        checks["limits"] = limits
    if degrees is not None:
        checks["degrees"] = degrees
    ds = check_recording(ds, model, limits=checks.get("limits", "error"), degrees=checks.get("degrees", "error"))
    if not floating:
        return ds
    # deferred: the floating channels' reader is needed for a floating model only
    from pinid.data.contacts import read_floating_channels

    return read_floating_channels(path, ds, model, None if mapping is None else columns, swing_rows=swing_rows)


def _at(ds: Dataset, k: int) -> str:
    line0 = ds.meta.get("line0")
    return f"line {line0 + k}" if line0 is not None else f"sample {k}"


#: Largest magnitude accepted for q, dq, ddq and tau: beyond it squares overflow and the value is a
#: unit, scale or parsing error, not a measurement.
MAX_ABS_VALUE = 1e9


def check_recording(ds: Dataset, model=None, *, limits: str = "error", degrees: str = "error") -> Dataset:
    """Check a dataset (and, with a model, reorder it to ``model.joint_names``); return the checked dataset.

    Raises DataError on: fewer than 2 samples, non-finite or non-increasing (or duplicate) time stamps,
    NaN/inf values, and, with a model, joints missing from the recording or unknown to the URDF, revolute
    positions beyond a full turn (degrees?), positions outside the URDF limits by more than 1 % of the
    range.  ``limits`` / ``degrees`` = "warn" or "off" soften those two.
    """
    ds = as_dataset(ds)
    for name, mode in (("limits", limits), ("degrees", degrees)):
        if mode not in CHECK_MODES:
            raise SpecError(f"check {name} = {mode!r}, expected one of {', '.join(CHECK_MODES)}")
    src = ds.source
    if ds.n < 2:
        raise DataError(f"{src}: {ds.n} sample{'s' if ds.n != 1 else ''}, expected a recording of at least 2 samples")
    t = ds.t
    if not np.all(np.isfinite(t)):
        k = int(np.flatnonzero(~np.isfinite(t))[0])
        raise DataError(f"{src}: time stamp at {_at(ds, k)} is not finite, expected finite times [s]")
    d = np.diff(t)
    bad = np.flatnonzero(d <= 0)
    if bad.size:
        k = int(bad[0])
        if d[k] == 0:
            raise DataError(
                f"{src}: duplicate time stamp t = {t[k]:.9g} s at {_at(ds, k)} and {_at(ds, k + 1)} "
                f"({bad.size} non-increasing step{'s' if bad.size > 1 else ''}); expected strictly increasing time"
            )
        raise DataError(
            f"{src}: time goes backwards at {_at(ds, k + 1)} (t = {t[k]:.9g} s then {t[k + 1]:.9g} s); "
            "expected strictly increasing time stamps"
        )
    for qty in QUANTITIES:
        a = getattr(ds, qty)
        if a is None:
            continue
        finite = np.isfinite(a)
        if not finite.all():
            k, j = (int(x[0]) for x in np.nonzero(~finite))
            raise DataError(
                f"{src}: {qty} of joint '{ds.joints[j]}' is not finite at {_at(ds, k)}; expected finite numbers"
            )
        huge = np.abs(a) > MAX_ABS_VALUE
        if huge.any():
            k, j = (int(x[0]) for x in np.nonzero(huge))
            raise DataError(
                f"{src}: {qty} of joint '{ds.joints[j]}' is {a[k, j]:.3g} at {_at(ds, k)}; expected "
                f"|value| below {MAX_ABS_VALUE:.0e} (a unit or scale error?)"
            )
    if model is None:
        return ds
    return _check_against_model(ds, model, limits, degrees)


def _is_floating(model) -> bool:
    """Whether the RobotModel ``model`` is a floating one (its module is loaded then: no import otherwise)."""
    from pinid.model.floating import FloatingRobotModel  # deferred, as the model itself (pinocchio)

    return isinstance(model, FloatingRobotModel)


def _robot_or_none(model):
    """None, or ``model`` as a RobotModel (a URDF path or robot name is loaded); ModelError otherwise."""
    from pinid.model.robot import RobotModel, as_robot

    if model is None:
        return None
    if isinstance(model, (str, os.PathLike)):
        return RobotModel.from_urdf(model)
    return as_robot(model)


def _check_against_model(ds: Dataset, model, limits: str, degrees: str) -> Dataset:
    model = _robot_or_none(model)
    src = ds.source
    names = model.joint_names
    unknown = [j for j in ds.joints if j not in names and j not in model.locked]
    if unknown:
        raise DataError(
            f"{src}: joint '{unknown[0]}' of the recording is not a joint of {model.name} "
            f"(its active joints: {', '.join(names)}); expected the URDF's joint names"
        )
    missing = [j for j in names if j not in ds.joints]
    if missing:
        recorded = [j for j in names if j in ds.joints]  # in the model's order
        hint = (
            f"; to identify with the recorded joints alone, give --joints {','.join(recorded)} (the others held at "
            f"0, or mid-range when 0 is outside their limits; Python: joints=[...]), or say where they were held: "
            f"{' '.join(f'--lock {j}=0' for j in missing)}"
            if recorded
            else ""
        )
        raise DataError(
            f"{src}: no data for joint '{missing[0]}' of {model.name}"
            f"{f' (nor {missing[1:]})' if len(missing) > 1 else ''}; the recording has {', '.join(ds.joints)}{hint}"
        )
    for j in ds.joints:
        if j in model.locked:
            q = ds.q[:, ds.joints.index(j)]
            moved = float(np.max(np.abs(q - model.locked[j])))
            if moved > 0.01:
                warn(
                    ds,
                    f"{src}: joint '{j}' is locked at {model.locked[j]:g} in the model but moves by up to "
                    f"{moved:.3g} in the recording; its data are dropped",
                )
    out = ds.reorder(names)
    out.meta.setdefault("warnings", list(ds.meta.get("warnings", [])))
    for i, info in enumerate(model.joints):
        q = out.q[:, i]
        qmin, qmax = float(q.min()), float(q.max())
        if info.kind == "revolute" and degrees != "off":
            peak = max(abs(qmin), abs(qmax))
            if peak > 2 * np.pi * 1.05:
                msg = (
                    f"{src}: positions of joint '{info.name}' reach {peak:.4g}, more than a full turn for a revolute "
                    'joint: they look like degrees; expected radians (a mapping spec converts with scale = "deg"; '
                    'a joint that really turns that far needs degrees = "off" in its [checks])'
                )
                if degrees == "error":
                    raise DataError(msg)
                warn(out, msg)
        if limits == "off" or not (np.isfinite(info.lower) or np.isfinite(info.upper)):
            continue
        span = info.upper - info.lower if np.isfinite(info.upper - info.lower) else 1.0
        tol = max(1e-6, 0.01 * span)
        low, high = qmin < info.lower - tol, qmax > info.upper + tol
        if low or high:
            k = int(np.argmin(q) if low else np.argmax(q))
            value = qmin if low else qmax
            fixes = _range_fixes(out, model)  # a hint only when it fits every joint outside its limits
            hint = f"; the recording's joint ranges do not fit {model.name}'s: is it the robot recorded (--urdf)?"
            if all(f["degrees"] for f in fixes):
                hint = '; in degrees they would fit (a mapping spec converts with scale = "deg")'
            elif all(f["sign"] for f in fixes):
                hint = "; with the opposite sign they would fit (sign = -1 in a mapping spec)"
            urdf = Path(model.urdf_path).name if model.urdf_path is not None else model.name
            msg = (
                f"{src}: joint '{info.name}' reaches {value:.4g} at {_at(out, k)}, outside its URDF limits "
                f"[{info.lower:.4g}, {info.upper:.4g}] (URDF {urdf}){hint}"
            )
            if limits == "error":
                raise DataError(msg)
            warn(out, msg)
    return out


def _range_fixes(ds: Dataset, model) -> list[dict]:
    """For each joint whose positions leave its URDF limits (by more than 1 % of the range): whether they fit
    in degrees (only when the motion spans more than the joint's range, impossible in radians: a recording in
    radians of another robot would fit in degrees too, as nearly anything does) and with the opposite sign."""
    fixes = []
    for i, info in enumerate(model.joints):
        q = ds.q[:, i]
        qmin, qmax = float(q.min()), float(q.max())
        span = info.upper - info.lower if np.isfinite(info.upper - info.lower) else 1.0
        tol = max(1e-6, 0.01 * span)
        if info.lower - tol <= qmin and qmax <= info.upper + tol:
            continue
        r = np.pi / 180
        degrees = info.kind != "prismatic" and qmax - qmin > span + tol
        degrees = degrees and info.lower - tol <= qmin * r and qmax * r <= info.upper + tol
        fixes.append({"degrees": degrees, "sign": info.lower - tol <= -qmax and -qmin <= info.upper + tol})
    return fixes


# ---------------------------------------------------------------------------------------------- writing
def _columns(ds: Dataset) -> tuple[list[str], np.ndarray]:
    names = ["t"]
    blocks = [ds.t[:, None]]
    for qty in QUANTITIES:
        a = getattr(ds, qty)
        if a is None:
            continue
        names += [f"{PREFIXES[qty]}{j}" for j in ds.joints]
        blocks.append(a)
    extra = {} if ds.floating is None else ds.floating.columns()  # base motion, IMU, wrenches, plates, contacts
    names += list(extra)
    blocks += [np.column_stack(list(extra.values()))] if extra else []
    return names, np.hstack(blocks)


def write_recording(path: str | os.PathLike, ds: Dataset, *, digits: int = 12) -> Path:
    """Write ``ds`` in the dataset format, atomically, with the writer of ``path``'s suffix (CSV or NPZ;
    :mod:`pinid.data.registry`); a floating recording's channels (``ds.floating``) as the columns of
    docs/floating-base.md (``base_x``, ``imu_<frame>_wx``, ``wrench_<link>_fz``, ``contact_<link>`` …).

    CSV values carry ``digits`` significant digits, the time as many as its steps need
    (:func:`time_digits`: epoch time stamps keep their milliseconds); NPZ keeps full precision.  The output depends only on
    the data (no time stamp inside), so the same dataset always gives the same bytes.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise DataError(f"path: got {type(path).__name__}, expected the path of the recording to write")
    if not isinstance(ds, Dataset):
        raise DataError(f"ds: got {type(ds).__name__}, expected a pinid Dataset")
    if isinstance(digits, bool) or not isinstance(digits, int) or not 1 <= digits <= 17:
        raise SpecError(f"digits={digits!r}, expected an integer from 1 to 17 (significant digits of the CSV values)")
    path = Path(path)
    writer = writer_for(path)
    for j in ds.joints:
        if not j or any(c in j for c in ',;\t\n"') or j != j.strip():
            raise DataError(
                f"{path}: joint name {j!r} cannot be a column name, expected no commas, quotes or spaces at the ends"
            )
    names, data = _columns(ds)
    if not np.all(np.isfinite(data)):
        raise DataError(f"{path}: the dataset holds NaN or infinite values, refusing to write them")
    with atomic_path(path) as tmp:
        writer.write(tmp, names, data, digits)
    return path


def _write_npz(tmp: Path, names: list[str], data: np.ndarray, digits: int) -> None:
    """NPZ, one array per column, full precision, no time stamp inside (same data, same bytes)."""
    with zipfile.ZipFile(tmp, "w", compression=zipfile.ZIP_STORED, allowZip64=True) as zf:
        for i, n in enumerate(names):
            info = zipfile.ZipInfo(f"{n}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            with zf.open(info, "w", force_zip64=True) as f:
                np.lib.format.write_array(f, np.ascontiguousarray(data[:, i]), allow_pickle=False)


def time_digits(t: np.ndarray, digits: int) -> int:
    """Significant digits the time column ``t`` [s] needs: at least ``digits``, and enough that every
    time step keeps 7 digits of its own (epoch seconds, t = 1.7e9 in 1 ms steps, need 20: all 17 of a
    float64, which read back exactly); never more than 17."""
    t, digits = as_floats(t, "t").reshape(-1), count(digits, "digits", low=1)
    steps = np.diff(t)
    steps = steps[steps > 0]
    if not steps.size:
        return digits
    span = float(np.abs(t).max())
    need = int(np.ceil(np.log10(max(span / float(steps.min()), 1.0)))) + 7
    return min(17, max(digits, need))


def _write_csv(tmp: Path, names: list[str], data: np.ndarray, digits: int) -> None:
    """CSV with a header line, ``digits`` significant digits (the time column: :func:`time_digits`)."""
    first = time_digits(data[:, 0], digits) if names and names[0] == "t" else digits
    fmt = ",".join([f"%.{first}g"] + [f"%.{digits}g"] * (data.shape[1] - 1))
    with open(tmp, "w", encoding="utf-8", newline="\n") as f:
        f.write(",".join(names) + "\n")
        chunk = 20000
        for s in range(0, len(data), chunk):
            rows = data[s : s + chunk].tolist()
            f.write("\n".join(fmt % tuple(r) for r in rows))
            f.write("\n")


register_writer(Writer("csv", _write_csv, suffixes=(".csv",)))
register_writer(Writer("npz", _write_npz, suffixes=(".npz",)))

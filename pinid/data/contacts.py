"""The floating channels of a recording: base motion (motion capture or an IMU), external wrenches, contacts.

:func:`~pinid.data.formats.read_recording` of a floating model calls :func:`read_floating_channels`, which reads
them into the recording's ``floating`` field (:class:`~pinid.data.dataset.FloatingChannels`);
:func:`~pinid.data.formats.write_recording` writes them back; :func:`~pinid.data.preprocess.prepare` turns them
into :class:`FloatingSamples`, the prepared state.

A floating recording is a file in pinid's dataset format (``t``, ``q_<joint>``, optional ``dq_``, ``ddq_``,
``tau_`` per joint; ``docs/data.md``) with more columns (``docs/floating-base.md``):

====================================================  ==============================================  ========
columns                                               what                                            unit
====================================================  ==============================================  ========
``base_x, base_y, base_z``                            base-link origin in the world (motion capture)  m
``base_qx, base_qy, base_qz, base_qw``                base-link orientation, unit quaternion           –
                                                      (base → world)
``imu_<frame>_qx … _qw``                              IMU orientation (IMU frame → world)              –
``imu_<frame>_wx, _wy, _wz``                          gyro: angular velocity, IMU frame                rad/s
``imu_<frame>_ax, _ay, _az``                          accelerometer: specific force (acceleration      m/s²
                                                      minus gravity), IMU frame
``wrench_<link>_fx, _fy, _fz, _tx, _ty, _tz``         wrench on ``link`` in its frame, moment about   N, N·m
                                                      its origin (foot F/T sensor, insole)
``plate_<link>_fx, _fy, _fz``                         force-plate force on ``link``, world frame       N
``plate_<link>_copx, _copy`` (``_copz``, ``_tz``)     centre of pressure (world; copz default 0) and  m, N·m
                                                      free moment about the vertical (default 0)
``contact_<link>``                                    contact phase: 1 in contact, 0 not (the         –
                                                      link's wrench is zeroed where 0)
====================================================  ==============================================  ========

The base motion comes from one source: motion capture (``base_*``, differentiated like the joints) or one
IMU on the base link or a frame fixed to it (its placement is the URDF frame's: add a fixed link for an IMU
the URDF does not have).  Force plates need the base position (motion capture), since their centre of
pressure is in the world.  Every check raises :class:`~pinid.errors.DataError` naming the column.
"""

from __future__ import annotations

import re

import os
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from pinid.data.dataset import ACC, GYRO, PLATE, POSE, QUAT, WRENCH, Dataset, FloatingChannels
from pinid.data.mapping import MappingSpec, peek_columns
from pinid.errors import DataError
from pinid.model.floating import FloatingRobotModel, Wrench, as_floating

PLATE_OPTIONAL = ("copz", "tz")
#: Tolerance on the norm of a recorded quaternion (1 ± this).
QUATERNION_TOL = 1e-3


def _need(have: dict, wanted, what: str, source: str, optional=()) -> None:
    missing = [c for c in wanted if c not in have and c not in optional]
    if missing:
        raise DataError(
            f"{source}: {what} has columns {', '.join(sorted(have.values()))} but not {', '.join(missing)}; "
            f"expected all of {', '.join(c for c in wanted if c not in optional)}"
        )


def read_floating_channels(
    path: str | os.PathLike,
    data: Dataset,
    model: FloatingRobotModel,
    columns: dict[str, np.ndarray] | None = None,
    *,
    swing_rows: bool = False,
) -> Dataset:
    """``data`` (the joints of ``path``, read and checked by :func:`~pinid.data.formats.read_recording`, which
    calls this for a floating ``model``) with its floating channels (:class:`~pinid.data.dataset.FloatingChannels`):
    read from the dataset format's columns (the table in the module text) or given as ``columns`` (the floating
    columns by dataset-format name [SI] on the samples of ``data``, read through a mapping spec's ``[floating]``
    table: :meth:`~pinid.data.mapping.MappingSpec.read_all`), and checked against ``model``: every
    link and frame named exists, the IMU is fixed to the base link, quaternions are unit, contact phases have a
    wrench (unless ``swing_rows``: then a link with contact phases and no wrench is a leg without force sensing,
    whose contact rows are left out, see :func:`pinid.problem.floating.floating_problem`), force plates have the
    base position."""
    model = as_floating(model)
    path = Path(path)
    source = str(path)
    if columns is not None:
        g, values = FloatingChannels.groups(columns), columns
        short = [c for c, v in columns.items() if np.shape(v) != (data.n,)]
        if short:
            raise DataError(
                f"{source}: floating column {short[0]} is not one value per sample ({data.n}); expected equal lengths"
            )
    else:
        _, names = peek_columns(path)
        g = FloatingChannels.groups(names)
        extra = [c for grp in ("base",) for c in g[grp].values()]
        extra += [c for d in (*g["imu"].values(), *g["wrench"].values(), *g["plate"].values()) for c in d.values()]
        extra += list(g["contact"].values())
        values = _read_columns(path, extra, data.n) if extra else {}
        if "ignored_columns" in data.meta:  # read here, not ignored
            data.meta["ignored_columns"] = [c for c in data.meta["ignored_columns"] if c not in extra]
    rec = FloatingChannels(model=model)
    if g["base"]:
        _need(g["base"], POSE, "the base pose", source)
        rec.base_pose = np.column_stack([values[g["base"][c]] for c in POSE])
        _check_unit(rec.base_pose[:, 3:], "base_qx..base_qw", source)
        rec.base_pose[:, 3:] = continuous_quat(rec.base_pose[:, 3:])
    if len(g["imu"]) > 1:
        raise DataError(f"{source}: IMUs on {', '.join(g['imu'])}; expected one IMU (imu_<frame>_...)")
    for frame, cols in g["imu"].items():
        fid = model.frame_id(frame, f"{source}: IMU frame (column {next(iter(cols.values()))})")
        if model.ff_model.frames[fid].parentJoint != 1:
            raise DataError(
                f"{source}: IMU frame '{frame}' is not fixed to the base link '{model.base_link}'; expected the "
                "base link or a frame fixed to it"
            )
        _need(cols, GYRO + ACC, f"the IMU on '{frame}'", source)
        rec.imu_frame = frame
        rec.imu = {
            "w": np.column_stack([values[cols[c]] for c in GYRO]),
            "a": np.column_stack([values[cols[c]] for c in ACC]),
        }
        if any(c in cols for c in QUAT):
            _need(cols, QUAT, f"the IMU orientation on '{frame}'", source)
            rec.imu["q"] = np.column_stack([values[cols[c]] for c in QUAT])
            _check_unit(rec.imu["q"], f"imu_{frame}_qx..qw", source)
            rec.imu["q"] = continuous_quat(rec.imu["q"])
    if rec.base_pose is None and rec.imu_frame is None:
        raise DataError(f"{source}: no base motion; expected base_x..base_qw (motion capture) or imu_<frame>_* columns")
    if rec.base_pose is not None and rec.imu_frame is not None:
        raise DataError(f"{source}: both base_* and imu_* columns; expected one source of base motion")
    if rec.imu_frame is not None and "q" not in rec.imu:
        raise DataError(f"{source}: the IMU on '{rec.imu_frame}' has no orientation columns imu_{rec.imu_frame}_qx..qw")
    for link, cols in g["wrench"].items():
        model.frame_id(link, f"{source}: wrench frame (column {next(iter(cols.values()))})")
        _need(cols, WRENCH, f"the wrench on '{link}'", source)
        rec.wrenches[link] = np.column_stack([values[cols[c]] for c in WRENCH])
    for link, cols in g["plate"].items():
        model.frame_id(link, f"{source}: force-plate link (column {next(iter(cols.values()))})")
        _need(cols, PLATE, f"the force plate under '{link}'", source, PLATE_OPTIONAL)
        rec.plates[link] = np.column_stack([values[cols[c]] if c in cols else np.zeros(data.n) for c in PLATE])
        if link in rec.wrenches:
            raise DataError(f"{source}: link '{link}' has both wrench_ and plate_ columns; expected one")
    if rec.plates and rec.base_pose is None:
        raise DataError(
            f"{source}: force plates ({', '.join(rec.plates)}) need the base position in the world "
            "(base_x..base_qw columns, motion capture); an IMU alone does not give it"
        )
    for link, col in g["contact"].items():
        model.frame_id(link, f"{source}: contact link (column {col})")
        if link not in rec.wrenches and link not in rec.plates and not swing_rows:
            raise DataError(
                f"{source}: column {col} gives contact phases of '{link}' but there is no wrench_{link}_* or "
                f"plate_{link}_* column; expected the contact wrench of a link in contact (or --swing-rows: use only "
                "the rows that wrench does not enter)"
            )
        c = values[col]
        if not np.all((c == 0) | (c == 1)):
            raise DataError(f"{source}: column {col} has values other than 0 and 1; expected contact phases")
        rec.contacts[link] = c.astype(bool)
    return replace(data, floating=rec)


def _check_unit(quat: np.ndarray, what: str, source: str) -> None:
    norms = np.linalg.norm(quat, axis=1)
    bad = np.flatnonzero(np.abs(norms - 1.0) > QUATERNION_TOL)
    if bad.size:
        k = int(bad[0])
        raise DataError(
            f"{source}: quaternion {what} at sample {k} has norm {norms[k]:.6g}; expected a unit quaternion "
            f"(x, y, z, w; norm 1 ± {QUATERNION_TOL:g})"
        )


def _read_columns(path: Path, columns: list[str], n: int) -> dict[str, np.ndarray]:
    """Raw values of ``columns`` of a dataset-format file (through a mapping spec of pseudo-joints)."""
    spec = MappingSpec.from_dict(
        {"time": "t", "joints": {f"c{i}": {"q": c} for i, c in enumerate(columns)}}, origin=f"{path} (floating columns)"
    )
    try:
        ds = spec.read(path)
    except DataError as e:  # name the column as the file does, not the pseudo-joint it was read through
        raise DataError(
            re.sub(r" \(joints\.c\d+\.q\)", " (a base, IMU, wrench, plate or contact column)", str(e))
        ) from None
    if ds.n != n:
        raise DataError(f"{path}: {ds.n} rows of base and wrench columns for {n} samples; expected equal lengths")
    bad = ~np.isfinite(ds.q)
    if bad.any():
        k, j = (int(x) for x in np.argwhere(bad)[0])
        raise DataError(f"{path}: column {columns[j]} has NaN or infinite values (first at sample {k})")
    return {c: ds.q[:, i] for i, c in enumerate(columns)}


# ---------------------------------------------------------------------------------------------- prepared
@dataclass
class FloatingSamples:
    """A floating recording ready for the regressor: joints (``data`` with q, dq, ddq; tau or None), the base
    state (Pinocchio's free-flyer ``base_q`` (N, 7), ``base_v``, ``base_a`` (N, 6), base frame, linear part of
    ``base_v`` zero and of ``base_a`` the classical acceleration of the base origin: see
    :mod:`pinid.model.floating`), and the external wrenches."""

    data: Dataset
    base_q: np.ndarray
    base_v: np.ndarray
    base_a: np.ndarray
    wrenches: list[Wrench]
    unsensed: dict[str, np.ndarray] = field(default_factory=dict)  # link -> (N,) in contact, wrench unknown
    uncertain: dict[str, np.ndarray] = field(default_factory=dict)  # link -> (N,) phase neither 0 nor 1

    @property
    def n(self) -> int:
        return self.data.n

    @property
    def source(self) -> str:
        return self.data.source


def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton products of (N, 4) quaternions ``x, y, z, w``."""
    ax, ay, az, aw = a.T
    bx, by, bz, bw = b.T
    return np.column_stack(
        [
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz,
        ]
    )


def continuous_quat(q: np.ndarray) -> np.ndarray:
    """(N, 4) quaternions with a continuous sign: each sample is negated (the same rotation) when it lies in the
    other hemisphere than the previous one (dot product < 0), as angles are unwrapped before filtering.
    Motion-capture software and ROS tf often keep w ≥ 0, which flips q → −q whenever the rotation angle
    passes 180°; filtered and differentiated component-wise, such a flip is a spike in ω and ω̇."""
    q = np.array(q, dtype=float)
    if len(q) < 2:
        return q
    dots = np.einsum("ij,ij->i", q[1:], q[:-1])
    sign = np.concatenate([[1.0], np.cumprod(np.where(dots < 0, -1.0, 1.0))])
    return q * sign[:, None]


def quat_matrix(q: np.ndarray) -> np.ndarray:
    """(N, 3, 3) rotation matrices of (N, 4) unit quaternions ``x, y, z, w``."""
    x, y, z, w = (q / np.linalg.norm(q, axis=1, keepdims=True)).T
    return np.stack(
        [
            np.column_stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)]),
            np.column_stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)]),
            np.column_stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]),
        ],
        axis=1,
    )


def matrix_quat(R: np.ndarray) -> np.ndarray:
    """(N, 4) quaternions ``x, y, z, w`` (w ≥ 0) of (N, 3, 3) rotation matrices."""
    import pinocchio as pin  # the model layer loads it anyway

    out = np.array([pin.Quaternion(r).coeffs() for r in R])
    return out * np.where(out[:, 3:] < 0, -1.0, 1.0)

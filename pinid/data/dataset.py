"""A recording in memory: time, joint positions, optional velocities and accelerations, torques, and for a
floating base its optional channels (base motion, IMU, contact wrenches, force plates, contact phases).

This is the one object the data path hands to identification.  Arrays are ``(N, nv)`` in the order of
``joints``; units are SI: t [s], q [rad or m], dq [rad/s], ddq [rad/s²], tau [N·m].  Reading files,
checking them and preprocessing live in :mod:`pinid.data.formats` (:func:`~pinid.data.formats.read_recording`
reads the floating channels too when its model is floating, :mod:`pinid.data.contacts`) and
:mod:`pinid.data.preprocess`.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from pinid.checks import as_floats
from pinid.errors import DataError


POSE = ("x", "y", "z", "qx", "qy", "qz", "qw")
QUAT = ("qx", "qy", "qz", "qw")
GYRO = ("wx", "wy", "wz")
ACC = ("ax", "ay", "az")
WRENCH = ("fx", "fy", "fz", "tx", "ty", "tz")
PLATE = ("fx", "fy", "fz", "copx", "copy", "copz", "tz")


@dataclass
class FloatingChannels:
    """The channels of a floating-base recording beside its joints, ``(N, ·)`` arrays on the recording's time
    stamps (the column names of docs/floating-base.md): ``base_pose`` (N, 7) ``x y z qx qy qz qw`` (motion
    capture) or an IMU on ``imu_frame`` (``imu``: "q" (N, 4), "w" (N, 3) gyro, "a" (N, 3) accelerometer),
    ``wrenches`` link → (N, 6) in the link frame, ``plates`` link → (N, 7) ``fx fy fz copx copy copz tz``,
    ``contacts`` link → (N,) booleans, and ``model``: the floating robot model it was read or simulated for."""

    base_pose: np.ndarray | None = None
    imu_frame: str | None = None
    imu: dict[str, np.ndarray] = field(default_factory=dict)
    wrenches: dict[str, np.ndarray] = field(default_factory=dict)
    plates: dict[str, np.ndarray] = field(default_factory=dict)
    contacts: dict[str, np.ndarray] = field(default_factory=dict)
    model: Any = None

    def columns(self) -> dict[str, np.ndarray]:
        """The channels by column name (the dataset format's names: ``base_x``, ``imu_<frame>_wx``,
        ``wrench_<link>_fz``, ``plate_<link>_copx``, ``contact_<link>`` …)."""
        out: dict[str, np.ndarray] = {}
        if self.base_pose is not None:
            out.update({f"base_{c}": self.base_pose[:, i] for i, c in enumerate(POSE)})
        if self.imu_frame is not None:
            for key, names in (("q", QUAT), ("w", GYRO), ("a", ACC)):
                if key in self.imu:
                    out.update({f"imu_{self.imu_frame}_{c}": self.imu[key][:, i] for i, c in enumerate(names)})
        for link, w in self.wrenches.items():
            out.update({f"wrench_{link}_{c}": w[:, i] for i, c in enumerate(WRENCH)})
        for link, w in self.plates.items():
            out.update({f"plate_{link}_{c}": w[:, i] for i, c in enumerate(PLATE)})
        for link, c in self.contacts.items():
            out[f"contact_{link}"] = c.astype(float)
        return out

    @staticmethod
    def groups(names: Iterable[str]) -> dict:
        """The floating columns among ``names`` (dataset-format names), grouped: ``{"base": {pose key: name},
        "imu": {frame: {key: name}}, "wrench"/"plate": {link: {key: name}}, "contact": {link: name}}``; a name
        that is no floating column is in none."""
        out: dict = {"base": {}, "imu": {}, "wrench": {}, "plate": {}, "contact": {}}
        for n in names:
            if n.startswith("base_") and n[5:] in POSE:
                out["base"][n[5:]] = n
                continue
            m = re.fullmatch(r"imu_(.+)_(qx|qy|qz|qw|wx|wy|wz|ax|ay|az)", n)
            if m:
                out["imu"].setdefault(m.group(1), {})[m.group(2)] = n
                continue
            m = re.fullmatch(r"wrench_(.+)_(fx|fy|fz|tx|ty|tz)", n)
            if m:
                out["wrench"].setdefault(m.group(1), {})[m.group(2)] = n
                continue
            m = re.fullmatch(r"plate_(.+)_(fx|fy|fz|copx|copy|copz|tz)", n)
            if m:
                out["plate"].setdefault(m.group(1), {})[m.group(2)] = n
                continue
            if n.startswith("contact_") and len(n) > 8:
                out["contact"][n[8:]] = n
        return out

    def select(self, index) -> "FloatingChannels":
        """The channels at the samples ``index`` (slice, boolean mask or indices)."""
        return replace(
            self,
            base_pose=None if self.base_pose is None else self.base_pose[index],
            imu={k: v[index] for k, v in self.imu.items()},
            wrenches={k: v[index] for k, v in self.wrenches.items()},
            plates={k: v[index] for k, v in self.plates.items()},
            contacts={k: v[index] for k, v in self.contacts.items()},
        )


@dataclass
class Dataset:
    """One recording; ``dq``, ``ddq`` and ``tau`` may be None when not measured; ``floating`` the channels of a
    floating base (:class:`FloatingChannels`), None for a fixed base."""

    t: np.ndarray
    q: np.ndarray
    joints: list[str]
    dq: np.ndarray | None = None
    ddq: np.ndarray | None = None
    tau: np.ndarray | None = None
    source: str = "<memory>"
    meta: dict = field(default_factory=dict)
    floating: FloatingChannels | None = None

    def __post_init__(self) -> None:
        self.t = as_floats(self.t, f"{self.source}: t", finite=False).reshape(-1)
        if (
            isinstance(self.joints, str)
            or not isinstance(self.joints, Iterable)
            or not all(isinstance(j, str) for j in self.joints)
        ):
            raise DataError(f"{self.source}: joints {self.joints!r}, expected a list of joint names")
        self.joints = list(self.joints)
        twice = sorted({j for j in self.joints if self.joints.count(j) > 1})
        if twice:
            raise DataError(
                f"{self.source}: joints {self.joints}: '{twice[0]}' appears twice, expected each joint once"
            )
        self.q = _as2d(self.q, "q", self)
        for name in ("dq", "ddq", "tau"):
            value = getattr(self, name)
            if value is not None:
                setattr(self, name, _as2d(value, name, self))
        n, nv = len(self.t), len(self.joints)
        for name in ("q", "dq", "ddq", "tau"):
            a = getattr(self, name)
            if a is not None and a.shape != (n, nv):
                raise DataError(
                    f"{self.source}: {name} has shape {a.shape}, expected ({n}, {nv}) for {n} time stamps "
                    f"and joints {self.joints}"
                )
        if self.floating is not None:
            if not isinstance(self.floating, FloatingChannels):
                raise DataError(
                    f"{self.source}: floating: got {type(self.floating).__name__}, expected FloatingChannels or None"
                )
            for name, a in self.floating.columns().items():
                if len(a) != n:
                    raise DataError(f"{self.source}: column {name} has {len(a)} samples, expected {n} (one per t)")

    @property
    def n(self) -> int:
        """Number of samples."""
        return len(self.t)

    @property
    def nv(self) -> int:
        """Number of joints."""
        return len(self.joints)

    @property
    def duration(self) -> float:
        """Time span [s]."""
        return float(self.t[-1] - self.t[0]) if self.n > 1 else 0.0

    @property
    def sample_rate(self) -> float:
        """Median sample rate [Hz]."""
        if self.n < 2:
            return float("nan")
        return float(1.0 / np.median(np.diff(self.t)))

    def select(self, index) -> "Dataset":
        """A dataset of the samples ``index`` (slice, boolean mask or indices)."""
        pick = lambda a: None if a is None else a[index]
        return replace(
            self,
            t=self.t[index],
            q=self.q[index],
            dq=pick(self.dq),
            ddq=pick(self.ddq),
            tau=pick(self.tau),
            meta=dict(self.meta),
            floating=None if self.floating is None else self.floating.select(index),
        )

    def reorder(self, joints: list[str]) -> "Dataset":
        """The same data with columns in the order of ``joints`` (a model's joint names); the arrays are
        shared (not copied) when the columns are already in that order."""
        missing = [j for j in joints if j not in self.joints]
        if missing:
            raise DataError(f"{self.source}: no data for joint(s) {missing}; the recording has {self.joints}")
        idx = [self.joints.index(j) for j in joints]
        if idx == list(range(self.nv)):  # already in that order: the same arrays, no copy of the recording
            pick = lambda a: a
        else:
            pick = lambda a: None if a is None else a[:, idx]
        return replace(
            self,
            q=pick(self.q),
            dq=pick(self.dq),
            ddq=pick(self.ddq),
            tau=pick(self.tau),
            joints=list(joints),
            meta=dict(self.meta),
        )


def _as2d(a, name: str, ds: Dataset) -> np.ndarray:
    a = as_floats(a, f"{ds.source}: {name}", finite=False)
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2:
        raise DataError(f"{ds.source}: {name} has {a.ndim} dimensions, expected a (samples, joints) table")
    return a


def as_dataset(ds, name: str = "ds") -> Dataset:
    """``ds`` if it is a :class:`Dataset`; DataError naming the argument ``name`` otherwise."""
    if not isinstance(ds, Dataset):
        raise DataError(
            f"{name}: got {type(ds).__name__}, expected a pinid Dataset (pinid.data.formats.read_recording)"
        )
    return ds

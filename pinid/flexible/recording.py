"""Flexible-joint recordings and the input signals of twin experiments (seed 003, Section 3).

* :class:`InputSignal` — the excitation of a twin (bias + Schroeder multisine + square wave per joint).
* :class:`FlexRecording` — a recording: time, input (motor torque ``T_<joint>`` [N·m] or voltage
  ``V_<joint>`` [V]), link angles ``q_<joint>``, optional motor angles ``qm_<joint>`` [rad]; CSV or NPZ on disk
  through :mod:`pinid.data.registry`.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field, replace
from pathlib import Path
from collections.abc import Sequence

import numpy as np

from pinid.errors import DataError
from pinid.data.mapping import SourceSpec, peek_columns
from pinid.data.registry import reader_for, writer_for
from pinid.io import atomic_path, jsonable, write_json


# ====================================================================== input signals
@dataclass
class InputSignal:
    """The input of a twin experiment: per joint ``bias + multisine + square`` after ``rest`` seconds of ``bias``.

    ``kind``: ``"torque"`` [N·m at the motor] or ``"voltage"`` [V]; ``duration`` [s]; ``rate`` [Hz];
    ``joints[name]``: ``bias``; ``multisine = {amplitude, f_min, f_max, lines}`` (Schroeder phases,
    scaled so that its peak is ``amplitude``); ``square = {amplitude, period, delay}``.  Joints not listed
    get zero.
    """

    kind: str = "torque"
    duration: float = 2.0
    rate: float = 500.0
    rest: float = 0.1
    joints: dict = field(default_factory=dict)

    def generate(self, joint_names: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
        """``(t, u)``: ``N = round(duration·rate) + 1`` samples, ``u`` ``(N, nv)``."""
        n = int(round(self.duration * self.rate)) + 1
        t = np.arange(n) / self.rate
        u = np.zeros((n, len(joint_names)))
        moving = t >= self.rest
        tm = t - self.rest
        for j, name in enumerate(joint_names):
            spec = self.joints.get(name, {})
            u[:, j] = float(spec.get("bias", 0.0))
            ms = spec.get("multisine")
            if ms:
                k = int(ms.get("lines", 8))
                f = np.linspace(float(ms["f_min"]), float(ms["f_max"]), k)
                phase = -np.pi * np.arange(1, k + 1) * np.arange(k) / k  # Schroeder
                s = np.sin(2 * np.pi * f[None, :] * tm[:, None] + phase[None, :]).sum(axis=1)
                peak = np.abs(s[moving]).max() if moving.any() else 1.0
                u[moving, j] += float(ms["amplitude"]) * s[moving] / max(peak, 1e-12)
            sq = spec.get("square")
            if sq:
                period, delay = float(sq["period"]), float(sq.get("delay", 0.0))
                on = moving & (tm >= delay)
                phase = ((tm - delay) / period) % 1.0
                u[on, j] += float(sq["amplitude"]) * np.where(phase[on] < 0.5, 1.0, -1.0)
        return t, u


# ====================================================================== recordings
@dataclass
class FlexRecording:
    """Input and measured angles of one run, sampled uniformly.

    ``t`` (N,) [s]; ``u`` (N, nv) motor torque [N·m] (``input = "torque"``) or voltage [V]; ``q`` (N, nv)
    link angles [rad]; ``qm`` (N, nv) motor angles on the motor side [rad] or None.
    """

    t: np.ndarray
    u: np.ndarray
    q: np.ndarray
    joints: list[str]
    qm: np.ndarray | None = None
    input: str = "torque"
    source: str = "<memory>"
    meta: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.t = np.asarray(self.t, dtype=float).reshape(-1)
        n, nv = len(self.t), len(self.joints)
        for name in ("u", "q", "qm"):
            a = getattr(self, name)
            if a is None:
                continue
            a = np.asarray(a, dtype=float)
            if a.ndim == 1 and nv == 1:
                a = a[:, None]
            if a.shape != (n, nv):
                raise DataError(
                    f"{self.source}: {name} has shape {a.shape}, expected ({n}, {nv}) for joints {self.joints}"
                )
            if not np.all(np.isfinite(a)):
                raise DataError(f"{self.source}: {name} holds NaN or infinite values")
            setattr(self, name, a)
        if self.input not in ("torque", "voltage"):
            raise DataError(f"{self.source}: input {self.input!r}, expected torque or voltage")
        if n < 3:
            raise DataError(f"{self.source}: {n} samples, expected at least 3")
        if not np.all(np.isfinite(self.t)):
            raise DataError(f"{self.source}: time holds NaN or infinite values")
        d = np.diff(self.t)
        if np.any(d <= 0):
            k = int(np.argmax(d <= 0)) + 1
            raise DataError(f"{self.source}: time is not strictly increasing at sample {k} (t = {self.t[k]:g} s)")
        dt = float(np.median(d))
        if np.max(np.abs(d - dt)) > 1e-3 * dt:
            k = int(np.argmax(np.abs(d - dt))) + 1
            raise DataError(
                f"{self.source}: time step {d[k - 1]:g} s at sample {k} differs from {dt:g} s; output-error "
                "fitting needs uniform sampling (resample first)"
            )

    @property
    def dt(self) -> float:
        """Sample period [s]."""
        return float(np.median(np.diff(self.t)))

    @property
    def n(self) -> int:
        """Number of samples."""
        return len(self.t)

    @property
    def input_prefix(self) -> str:
        """Column prefix of the input: ``T_`` (motor torque) or ``u_`` (voltage)."""
        return "T_" if self.input == "torque" else "V_"

    def reorder(self, joints: Sequence[str]) -> "FlexRecording":
        """The same recording with columns in the order of ``joints`` (a model's joint names)."""
        missing = [j for j in joints if j not in self.joints]
        if missing:
            raise DataError(
                f"{self.source}: no data for joint(s) {', '.join(missing)}; the recording has {', '.join(self.joints)}"
            )
        extra = [j for j in self.joints if j not in joints]
        if extra:
            raise DataError(
                f"{self.source}: joint(s) {', '.join(extra)} are not active joints of the model ({', '.join(joints)})"
            )
        idx = [self.joints.index(j) for j in joints]
        return replace(
            self,
            u=self.u[:, idx],
            q=self.q[:, idx],
            qm=None if self.qm is None else self.qm[:, idx],
            joints=list(joints),
            meta=dict(self.meta),
        )

    def save(self, path: str | os.PathLike, *, digits: int = 12) -> Path:
        """Write ``t, T_<j>|V_<j>, q_<j>, [qm_<j>]`` atomically with the recording writers of
        :mod:`pinid.data.registry` (CSV or NPZ by suffix); ``meta`` goes to ``<path>.json`` if any."""
        path = Path(path)
        writer = writer_for(path)
        names = ["t"] + [f"{self.input_prefix}{j}" for j in self.joints] + [f"q_{j}" for j in self.joints]
        blocks = [self.t[:, None], self.u, self.q]
        if self.qm is not None:
            names += [f"qm_{j}" for j in self.joints]
            blocks.append(self.qm)
        data = np.hstack(blocks)
        with atomic_path(path) as tmp:
            writer.write(tmp, names, data, digits)
        if self.meta:
            write_json(path.with_suffix(path.suffix + ".json"), jsonable(self.meta))
        return path

    @classmethod
    def load(cls, path: str | os.PathLike) -> "FlexRecording":
        """Read a file written by :meth:`save` (or by hand: the same columns) with the recording readers of
        :mod:`pinid.data.registry` (CSV or NPZ); DataError on bad content."""
        p = Path(path)
        if not p.is_file():
            raise DataError(f"{p}: file not found, expected a flexible-joint recording (CSV: t, T_<joint>, q_<joint>)")
        _, names = peek_columns(p)
        if len(set(names)) != len(names):
            raise DataError(f"{p}: duplicate column names in the header")
        if not names or names[0] != "t":
            raise DataError(f"{p}: first column is {names[0]!r}, expected 't' (time [s])")
        table = reader_for(p).read(p, SourceSpec(name="main"), [(n, None, f"column {n}") for n in names], str(p))
        col = {n: table.data[(n, None)] for n in names}
        joints = [n[2:] for n in names if n.startswith("q_")]
        if not joints:
            raise DataError(f"{p}: no link-angle column q_<joint>")
        kinds = {"torque" if n.startswith("T_") else "voltage" for n in names if n[:2] in ("T_", "V_")}
        if len(kinds) != 1:
            raise DataError(
                f"{p}: expected input columns T_<joint> (motor torque, N·m) or V_<joint> (voltage, V), "
                f"one kind for every joint"
            )
        kind = kinds.pop()
        pre = "T_" if kind == "torque" else "V_"
        for j in joints:
            if f"{pre}{j}" not in col:
                raise DataError(f"{p}: no input column '{pre}{j}' for joint '{j}'")
        has_qm = [f"qm_{j}" in col for j in joints]
        if any(has_qm) and not all(has_qm):
            raise DataError(f"{p}: motor angles qm_<joint> for some joints only, expected all or none")
        known = {"t"} | {f"{x}{j}" for j in joints for x in (pre, "q_", "qm_")}
        unknown = [n for n in names if n not in known]
        if unknown:
            raise DataError(
                f"{p}: unknown column(s) {', '.join(unknown)} (expected t, {pre}<joint>, q_<joint>, qm_<joint>)"
            )
        meta = {}
        side = p.with_suffix(p.suffix + ".json")
        if side.is_file():
            try:
                meta = json.loads(side.read_text(encoding="utf-8"))
            except (ValueError, UnicodeDecodeError):
                meta = {}
        return cls(
            col["t"],
            np.column_stack([col[f"{pre}{j}"] for j in joints]),
            np.column_stack([col[f"q_{j}"] for j in joints]),
            joints,
            np.column_stack([col[f"qm_{j}"] for j in joints]) if all(has_qm) else None,
            kind,
            str(p),
            meta,
        )

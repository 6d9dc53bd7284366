"""Output-error identification of flexible-joint robots (seed 003, Section 3).

The drive parameters of :mod:`pinid.flexible.model` enter the dynamics nonlinearly, so they are not fitted
on a regressor: the model is *simulated* under the measured input and the parameters that make the
simulated angles match the measured ones are searched for.  Costs, over the samples ``i`` and the
measured angles ``j`` (link angles, and motor angles when measured and asked for)::

    "abs":  J = Σ_i Σ_j |e_ij|          seed 003 Eq. (15) [rad]
    "sq":   J = Σ_i Σ_j e_ij²           [rad²]

with ``e = simulated − measured``.  Every metaheuristic of :data:`pinid.optimizers.OPTIMIZERS` (pso,
woa, ewoa, de) minimises it through the same interface: the whole population is simulated at once
(:meth:`~pinid.flexible.model.FlexibleModel.simulate`).  ``"least_squares"`` is scipy's trust-region
reflective least squares, a gradient-based comparison: it minimises the squared error (``"sq"``), or for
``"abs"`` its ``soft_l1`` loss with ``f_scale`` [rad] (≈ |e| for |e| ≫ f_scale), in coordinates scaled
to the box; its finite-difference Jacobian is one batch simulation of ``d + 1`` parameter sets.

What is here
------------
* :class:`InputSignal` — the excitation of a twin (bias + Schroeder multisine + square wave per joint).
* :class:`FlexRecording` — a recording: time, input (motor torque ``T_<joint>`` [N·m] or voltage
  ``V_<joint>`` [V]), link angles ``q_<joint>``, optional motor angles ``qm_<joint>`` [rad]; CSV on disk.
* :class:`FlexSpec`, :func:`load_flex_spec` — the TOML spec: URDF, drives, fixed values, bounds of the
  free parameters, the truth of the twin, its input and the fit settings
  (``excitation/tracker_flex_spec.toml`` documents every key).
* :func:`make_twin` — a recording simulated with known parameters, with seeded Gaussian noise.
* :class:`OutputErrorProblem` — simulated-vs-measured angles as a batch cost, residuals, Jacobian.
* :func:`fit_output_error` → :class:`OutputErrorResult` (fitted values, error against the truth, cost
  curve, time); :func:`sensitivity` — which parameters the excitation makes observable;
  :func:`compare_rigid_flexible` — seed 003 Figs. 6-7.
"""

from __future__ import annotations

import json
import math
import os
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from collections.abc import Mapping, Sequence

import numpy as np

from pinid.errors import DataError, JointError, PinidError, SolverError, SpecError
from pinid.data.mapping import SourceSpec, peek_columns
from pinid.data.registry import reader_for, writer_for
from pinid.io import atomic_path, jsonable, read_bounded_file, write_json
from pinid.flexible.model import FLEX_PARAMS, RIGID_PARAMS, Drive, FlexibleModel, FlexSimulation, check_parameter
from pinid.model.robot import INERTIAL_NAMES, RobotModel
from pinid.optimizers import OPTIMIZERS, get_optimizer
from pinid.io import as_path

#: Costs of :class:`OutputErrorProblem`.
COSTS: tuple[str, ...] = ("abs", "sq")
#: Angles that can be compared: link angles, motor angles (motor side).
OUTPUTS: tuple[str, ...] = ("link", "motor")
#: The gradient-based method (the others come from :data:`pinid.optimizers.OPTIMIZERS`).
LEAST_SQUARES = "least_squares"


def methods() -> list[str]:
    """Every method :func:`fit_output_error` accepts."""
    return list(OPTIMIZERS) + [LEAST_SQUARES]


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


# ====================================================================== spec
@dataclass
class FitSettings:
    """``[fit]`` of a spec: cost, compared angles, initial-angle window, method and its settings, twin noise."""

    cost: str = "abs"
    outputs: tuple[str, ...] = ("link",)
    rest_time: float = 0.0
    method: str = "pso"
    population: int = 60
    iterations: int = 100
    seed: int = 0
    noise: float = 0.0
    f_scale: float = 1e-3


@dataclass
class FlexSpec:
    """A flexible-joint identification spec (see ``excitation/tracker_flex_spec.toml``).

    ``fixed``: values of fixed parameters; ``free``/``lower``/``upper``: the fitted parameters and their
    box; ``truth``: known values (of the twin), free and fixed; ``nominal``: a value for every free
    parameter (its truth, else the middle of its box).
    """

    source: str
    robot: RobotModel
    drives: list[Drive]
    fixed: dict[str, float]
    free: list[str]
    lower: np.ndarray
    upper: np.ndarray
    truth: dict[str, float] | None
    input: InputSignal
    fit: FitSettings
    coulomb_speed: float = 0.05
    max_step: float = 2e-3
    backend: str = "auto"
    description: str = ""

    @property
    def nominal(self) -> dict[str, float]:
        """Starting values [SI]: the truth where the spec gives it, else the middle of each bound."""
        t = self.truth or {}
        return {n: t.get(n, 0.5 * (lo + hi)) for n, lo, hi in zip(self.free, self.lower, self.upper)}

    def model(self) -> FlexibleModel:
        """The model with the fixed values and the nominal values of the free parameters (the truth of a twin)."""
        return FlexibleModel(
            self.robot,
            self.drives,
            {**self.fixed, **(self.truth or {}), **self.nominal},
            coulomb_speed=self.coulomb_speed,
            max_step=self.max_step,
            backend=self.backend,
        )

    def rigid(self) -> "FlexSpec":
        """The same spec with every drive rigid: K1, K2, C dropped (seed 003's rigid model)."""
        keep = [i for i, n in enumerate(self.free) if n.rsplit(".", 1)[-1] not in ("K1", "K2", "C")]
        drop = lambda d: {n: v for n, v in d.items() if n.rsplit(".", 1)[-1] not in ("K1", "K2", "C")}  # noqa: E731
        return replace(
            self,
            drives=[Drive(d.joint, d.ratio, flexible=False) for d in self.drives],
            fixed=drop(self.fixed),
            free=[self.free[i] for i in keep],
            lower=self.lower[keep],
            upper=self.upper[keep],
            truth=None if self.truth is None else drop(self.truth),
        )

    def to_dict(self) -> dict:
        """Plain-JSON form of the spec."""
        return {
            "source": self.source,
            "urdf": str(self.robot.urdf_path),
            "description": self.description,
            "drives": [{"joint": d.joint, "ratio": d.ratio, "flexible": d.flexible} for d in self.drives],
            "fixed": self.fixed,
            "free": {n: [float(lo), float(hi)] for n, lo, hi in zip(self.free, self.lower, self.upper)},
            "truth": self.truth,
            "fit": {**self.fit.__dict__, "outputs": list(self.fit.outputs)},
            "coulomb_speed": self.coulomb_speed,
            "max_step": self.max_step,
            "backend": self.backend,
        }


_TOP_KEYS = {"description", "urdf", "coulomb_speed", "max_step", "backend", "joints", "truth", "input", "fit"}
_FIT_KEYS = set(FitSettings.__dataclass_fields__)
_INPUT_KEYS = {"kind", "duration", "rate", "rest"}
_SIGNAL_KEYS = {"bias", "multisine", "square"}


def _number(
    value, what: str, source: str, *, integer: bool = False, positive: bool = False, nonneg: bool = False
) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise SpecError(f"{source}: {what} = {value!r}, expected a finite number")
    if integer and int(value) != value:
        raise SpecError(f"{source}: {what} = {value!r}, expected an integer")
    if positive and value <= 0:
        raise SpecError(f"{source}: {what} = {value!r}, expected a positive number")
    if nonneg and value < 0:
        raise SpecError(f"{source}: {what} = {value!r}, expected ≥ 0")
    return int(value) if integer else float(value)


def _check_bounds(name: str, lo: float, hi: float, *, flexible: bool, source: str) -> None:
    """Bounds that allow impossible values are spec errors (a negative stiffness, inertia or friction)."""
    par = name.rsplit(".", 1)[-1]
    pre = f"{source}: {name} bounds [{lo:g}, {hi:g}]"
    if not lo < hi:
        raise SpecError(f"{pre}: expected lower < upper (give a single number to fix a parameter)")
    if par == "K1" and lo <= 0:
        raise SpecError(f"{pre}: negative or zero stiffness allowed, expected a lower bound > 0 N·m/rad")
    if par == "Jm" and flexible and lo <= 0:
        raise SpecError(f"{pre}: expected a lower bound > 0 kg·m² for the motor inertia of a flexible joint")
    if par in ("C", "Jm", "Bm", "fv", "fc", "b", "fcl") and lo < 0:
        raise SpecError(f"{pre}: negative values allowed, expected a lower bound ≥ 0")
    if par == "kv" and lo <= 0 <= hi:
        raise SpecError(f"{pre}: contains 0, expected a motor constant of one sign")
    if par == "m" and lo <= 0:
        raise SpecError(f"{pre}: expected a lower bound > 0 kg for a mass")
    if par in ("Ixx", "Iyy", "Izz") and lo < 0:
        raise SpecError(f"{pre}: expected a lower bound ≥ 0 kg·m² for a moment of inertia")


def _resolve_urdf(value: str, spec_path: Path | None) -> str:
    if spec_path is not None:
        cand = spec_path.parent / value
        if cand.is_file():
            return str(cand)
    return value


def load_flex_spec(path: str | os.PathLike, *, robot: RobotModel | None = None) -> FlexSpec:
    """Read a TOML spec: a file, or the name of one that ships with pinid (``tracker_flex_spec``,
    :func:`pinid.resources.bundled_flex_specs`); SpecError (naming the file, the table and the key) if it is
    missing, malformed or impossible."""
    from pinid.resources import EXCITATION_DIR, bundled_flex_specs

    path = as_path(path)
    p = Path(path)
    name = p.name.removesuffix(".toml")
    if not p.is_file() and name == str(path).removesuffix(".toml") and name in bundled_flex_specs():
        p = EXCITATION_DIR / f"{name}.toml"
    if not p.is_file():
        raise SpecError(
            f"{p}: file not found, expected a flexible-joint spec (.toml) or a bundled one "
            f"({', '.join(bundled_flex_specs())})"
        )
    from pinid.io import read_toml

    data = read_toml(p, "flexible-joint spec (TOML)")
    return spec_from_dict(data, source=str(p), robot=robot, spec_path=p)


def spec_from_dict(
    data: Mapping, *, source: str = "<spec>", robot: RobotModel | None = None, spec_path: Path | None = None
) -> FlexSpec:
    """Build a :class:`FlexSpec` from the plain-dict form of a spec file."""
    if not isinstance(data, Mapping):
        raise SpecError(f"data: got {type(data).__name__}, expected a flexible-joint spec table")
    unknown = sorted(set(data) - _TOP_KEYS)
    if unknown:
        raise SpecError(f"{source}: unknown setting(s) {', '.join(unknown)} (known: {', '.join(sorted(_TOP_KEYS))})")
    if robot is None:
        if "urdf" not in data:
            raise SpecError(f"{source}: no 'urdf' setting, expected the robot's URDF (path or bundled name)")
        if not isinstance(data["urdf"], str):
            raise SpecError(f"{source}: urdf = {data['urdf']!r}, expected a path or a robot name")
        try:
            robot = RobotModel.from_urdf(_resolve_urdf(data["urdf"], spec_path))
        except PinidError as exc:
            raise SpecError(f"{source}: urdf: {exc}") from None
    coulomb_speed = _number(data.get("coulomb_speed", 0.05), "coulomb_speed", source, positive=True)
    max_step = _number(data.get("max_step", 2e-3), "max_step", source, positive=True)
    backend = data.get("backend", "auto")
    if backend not in ("auto", "trig", "pinocchio"):
        raise SpecError(f"{source}: backend = {backend!r}, expected auto, trig or pinocchio")
    joints = data.get("joints", {})
    if not isinstance(joints, dict) or not joints:
        raise SpecError(f"{source}: no [joints.<name>] table, expected at least one driven joint")
    drives: list[Drive] = []
    fixed: dict[str, float] = {}
    free: list[str] = []
    lower: list[float] = []
    upper: list[float] = []
    for jname, table in joints.items():
        where = f"{source}: [joints.{jname}]"
        if jname not in robot.joint_names:
            raise SpecError(
                f"{where}: unknown joint '{jname}', expected an active joint of {robot.name} "
                f"({', '.join(robot.joint_names)})"
            )
        if not isinstance(table, dict):
            raise SpecError(f"{where}: expected a table of settings")
        flexible = table.get("flexible", True)
        if not isinstance(flexible, bool):
            raise SpecError(f"{where}: flexible = {flexible!r}, expected true or false")
        if "ratio" not in table:
            raise SpecError(f"{where}: no ratio, expected the reduction ratio r = motor angle / link angle (> 0)")
        ratio = table["ratio"]
        if isinstance(ratio, bool) or not isinstance(ratio, (int, float)) or not math.isfinite(ratio) or ratio <= 0:
            raise SpecError(f"{where}: ratio = {ratio!r}, expected a positive number (motor angle / link angle)")
        drives.append(Drive(jname, float(ratio), flexible))
        allowed = FLEX_PARAMS if flexible else RIGID_PARAMS
        for key, value in table.items():
            if key in ("ratio", "flexible"):
                continue
            if key not in allowed and key not in INERTIAL_NAMES:
                raise SpecError(
                    f"{where}: unknown parameter '{key}' of a {'flexible' if flexible else 'rigid'} joint "
                    f"(expected {', '.join(allowed)}, or an inertial parameter {', '.join(INERTIAL_NAMES)})"
                )
            name = f"{jname}.{key}"
            if isinstance(value, list):
                if len(value) != 2:
                    raise SpecError(f"{where}: {key} = {value!r}, expected [lower, upper] or a number")
                lo = _number(value[0], f"{key} lower bound", where)
                hi = _number(value[1], f"{key} upper bound", where)
                _check_bounds(name, lo, hi, flexible=flexible, source=source)
                free.append(name)
                lower.append(lo)
                upper.append(hi)
            else:
                v = _number(value, key, where)
                if key in FLEX_PARAMS:
                    check_parameter(name, v, flexible=flexible, where=f"{source}: ")
                fixed[name] = v
    if len(free) == 0:
        raise SpecError(f"{source}: no free parameter, expected at least one [lower, upper] bound in [joints.<name>]")
    truth = _read_truth(data.get("truth"), robot, drives, fixed, free, lower, upper, source)
    inp = _read_input(data.get("input", {}), robot, source)
    fit = _read_fit(data.get("fit", {}), source)
    spec = FlexSpec(
        source,
        robot,
        drives,
        fixed,
        free,
        np.array(lower),
        np.array(upper),
        truth,
        inp,
        fit,
        coulomb_speed,
        max_step,
        backend,
        str(data.get("description", "")),
    )
    try:  # every name and value the model will see, checked once here
        spec.model()
    except SpecError as exc:
        raise SpecError(f"{source}: {exc}") from None
    except JointError as exc:
        raise SpecError(f"{source}: {exc}") from None
    return spec


def _read_truth(table, robot, drives, fixed, free, lower, upper, source) -> dict | None:
    if table is None:
        return None
    if not isinstance(table, dict):
        raise SpecError(f"{source}: [truth] must be a table of [truth.<joint>] tables")
    by_joint = {d.joint: d for d in drives}
    truth: dict[str, float] = {}
    for jname, t in table.items():
        where = f"{source}: [truth.{jname}]"
        if jname not in robot.joint_names:
            raise SpecError(
                f"{where}: unknown joint '{jname}', expected an active joint of {robot.name} "
                f"({', '.join(robot.joint_names)})"
            )
        if not isinstance(t, dict):
            raise SpecError(f"{where}: expected a table of parameter values")
        d = by_joint.get(jname)
        allowed = (d.param_names if d else ()) + INERTIAL_NAMES
        for key, value in t.items():
            if key not in allowed:
                raise SpecError(f"{where}: unknown parameter '{key}' (expected one of {', '.join(allowed)})")
            name = f"{jname}.{key}"
            if name in fixed:
                raise SpecError(f"{where}: {key} is fixed in [joints.{jname}]; give its value there only")
            v = _number(value, key, where)
            if key in FLEX_PARAMS:
                check_parameter(name, v, flexible=d.flexible if d else False, where=f"{source}: ")
            if name in free:
                i = free.index(name)
                if not lower[i] <= v <= upper[i]:
                    raise SpecError(f"{where}: {key} = {v:g} is outside its bounds [{lower[i]:g}, {upper[i]:g}]")
            truth[name] = v
    return truth


def _read_input(table, robot, source) -> InputSignal:
    where = f"{source}: [input]"
    if not isinstance(table, dict):
        raise SpecError(f"{where}: expected a table")
    out = InputSignal()
    for key, value in table.items():
        if key in _INPUT_KEYS:
            if key == "kind":
                if value not in ("torque", "voltage"):
                    raise SpecError(f"{where}: kind = {value!r}, expected torque or voltage")
                out.kind = value
            else:
                setattr(out, key, _number(value, key, where, positive=key != "rest", nonneg=key == "rest"))
        elif key in robot.joint_names:
            if not isinstance(value, dict):
                raise SpecError(f"{where}.{key}: expected a table (bias, multisine, square)")
            bad = sorted(set(value) - _SIGNAL_KEYS)
            if bad:
                raise SpecError(f"{where}.{key}: unknown setting(s) {', '.join(bad)} (known: bias, multisine, square)")
            if "bias" in value:
                _number(value["bias"], "bias", f"{where}.{key}")
            ms = value.get("multisine")
            if ms is not None:
                w = f"{where}.{key}.multisine"
                if not isinstance(ms, dict) or not {"amplitude", "f_min", "f_max"} <= set(ms):
                    raise SpecError(f"{w}: expected {{amplitude, f_min, f_max, lines}}")
                _number(ms["amplitude"], "amplitude", w, nonneg=True)
                lo = _number(ms["f_min"], "f_min", w, positive=True)
                hi = _number(ms["f_max"], "f_max", w, positive=True)
                if hi < lo:
                    raise SpecError(f"{w}: f_max {hi:g} < f_min {lo:g}")
                _number(ms.get("lines", 8), "lines", w, integer=True, positive=True)
            sq = value.get("square")
            if sq is not None:
                w = f"{where}.{key}.square"
                if not isinstance(sq, dict) or not {"amplitude", "period"} <= set(sq):
                    raise SpecError(f"{w}: expected {{amplitude, period, delay}}")
                _number(sq["amplitude"], "amplitude", w, nonneg=True)
                _number(sq["period"], "period", w, positive=True)
                _number(sq.get("delay", 0.0), "delay", w, nonneg=True)
            out.joints[key] = value
        else:
            raise SpecError(
                f"{where}: unknown setting or joint '{key}' (settings: {', '.join(sorted(_INPUT_KEYS))}; "
                f"joints: {', '.join(robot.joint_names)})"
            )
    if out.rest >= out.duration:
        raise SpecError(f"{where}: rest {out.rest:g} s ≥ duration {out.duration:g} s")
    for key, value in out.joints.items():  # after the loop: rate may come after the joints' tables
        ms = value.get("multisine")
        if ms is not None and float(ms["f_max"]) >= out.rate / 2:
            raise SpecError(
                f"{where}.{key}.multisine: f_max {float(ms['f_max']):g} Hz is at or above the Nyquist "
                f"frequency of the input rate {out.rate:g} Hz, expected f_max < {out.rate / 2:g} Hz"
            )
    return out


def _read_fit(table, source) -> FitSettings:
    where = f"{source}: [fit]"
    if not isinstance(table, dict):
        raise SpecError(f"{where}: expected a table")
    bad = sorted(set(table) - _FIT_KEYS)
    if bad:
        raise SpecError(f"{where}: unknown setting(s) {', '.join(bad)} (known: {', '.join(sorted(_FIT_KEYS))})")
    fit = FitSettings()
    for key, value in table.items():
        if key == "cost":
            if value not in COSTS:
                raise SpecError(f"{where}: cost = {value!r}, expected one of {', '.join(COSTS)}")
            fit.cost = value
        elif key == "outputs":
            if not isinstance(value, list) or not value or any(v not in OUTPUTS for v in value):
                raise SpecError(f"{where}: outputs = {value!r}, expected a non-empty list of {', '.join(OUTPUTS)}")
            fit.outputs = tuple(value)
        elif key == "method":
            if value not in methods():
                raise SpecError(f"{where}: method = {value!r}, expected one of {', '.join(methods())}")
            fit.method = value
        elif key in ("population", "iterations"):
            setattr(fit, key, _number(value, key, where, integer=True, positive=True))
        elif key == "seed":
            fit.seed = _number(value, key, where, integer=True, nonneg=True)
        elif key == "f_scale":
            fit.f_scale = _number(value, key, where, positive=True)
        else:  # noise, rest_time
            setattr(fit, key, _number(value, key, where, nonneg=True))
    return fit


# ====================================================================== twin
def make_twin(
    model: FlexibleModel,
    signal: InputSignal | tuple[np.ndarray, np.ndarray],
    *,
    noise: float = 0.0,
    rng: np.random.Generator | int | None = 0,
    q0: np.ndarray | None = None,
    refine: int = 4,
    motor: bool = True,
) -> FlexRecording:
    """Simulate ``model`` (its values are the truth) and return a recording with seeded noise.

    ``signal``: an :class:`InputSignal` or ``(t, u)``; ``noise``: standard deviation [rad] of the Gaussian
    noise added to every measured angle (link and motor); ``refine``: the twin integrates with a step
    ``refine`` times smaller than a fit would (so that fitting does not reuse the exact same discretisation);
    ``motor``: also record the motor angles.  ``meta["truth"]`` holds every parameter value.
    """
    if not isinstance(model, FlexibleModel):
        raise SpecError(f"model: got {type(model).__name__}, expected a FlexibleModel")
    if isinstance(signal, InputSignal):
        t, u = signal.generate(model.joint_names)
        kind = signal.kind
    else:
        t, u = (np.asarray(a, dtype=float) for a in signal)
        kind = "torque"
    if not isinstance(rng, np.random.Generator):
        rng = np.random.default_rng(0 if rng is None else rng)
    dt = float(t[1] - t[0])
    q0 = np.zeros(model.nv) if q0 is None else np.asarray(q0, dtype=float)
    h, _ = model.choose_step(dt, model.values[None, :], q0)
    sim = model.simulate(u, dt, q0=q0, input=kind, step=h / max(1, int(refine)))
    if sim.diverged[0]:
        raise SolverError("twin simulation diverged: the truth values give a non-finite state")
    q = sim.q[0] + (noise * rng.standard_normal(sim.q[0].shape) if noise > 0 else 0.0)
    qm = None
    if motor:
        qm = sim.qm[0] + (noise * rng.standard_normal(sim.qm[0].shape) if noise > 0 else 0.0)
    meta = {
        "twin": True,
        "noise": float(noise),
        "step": float(sim.step),
        "truth": dict(zip(model.names, map(float, model.values))),
        "drives": [{"joint": d.joint, "ratio": d.ratio, "flexible": d.flexible} for d in model.drives],
    }
    return FlexRecording(t, u, q, list(model.joint_names), qm, kind, "<twin>", meta)


# ====================================================================== the problem
class OutputErrorProblem:
    """Simulated against measured angles, as a function of the free parameters.

    ``model``: gives the fixed values and the structure; ``recording``: input and measured angles;
    ``free``: names of the fitted parameters, with box ``lower``/``upper``; ``cost``: ``"abs"`` or ``"sq"``;
    ``outputs``: ``("link",)`` (seed 003) and/or ``"motor"``; ``rest_time`` [s]: the initial link angles
    are the mean of the measured ones over ``[t0, t0 + rest_time]`` (at least the first sample).
    The RK4 step is fixed for the problem, from the worst corner of the box (:meth:`_choose_step`), so that
    every candidate is integrated stably with the same step.
    """

    def __init__(
        self,
        model: FlexibleModel,
        recording: FlexRecording,
        free: Sequence[str],
        lower,
        upper,
        *,
        cost: str = "abs",
        outputs: Sequence[str] = ("link",),
        rest_time: float = 0.0,
        step: float | None = None,
        truth: Mapping[str, float] | None = None,
        label: str = "",
    ) -> None:
        if cost not in COSTS:
            raise SpecError(f"cost {cost!r}, expected one of {', '.join(COSTS)}")
        outputs = tuple(outputs)
        if not outputs or any(o not in OUTPUTS for o in outputs):
            raise SpecError(f"outputs {outputs!r}, expected some of {', '.join(OUTPUTS)}")
        self.model = model
        self.recording = recording.reorder(model.joint_names)
        if "motor" in outputs and self.recording.qm is None:
            raise DataError(
                f"{recording.source}: no motor angles qm_<joint>, but the fit compares motor angles "
                "(outputs = ['link', 'motor']); use outputs = ['link']"
            )
        self.free = list(free)
        self.idx = np.array([model.index(n) for n in self.free], dtype=int)
        self.lower = np.asarray(lower, dtype=float).reshape(-1)
        self.upper = np.asarray(upper, dtype=float).reshape(-1)
        if self.lower.shape != (len(self.free),) or self.upper.shape != (len(self.free),):
            raise SpecError(f"bounds of shapes {self.lower.shape}, {self.upper.shape}, expected ({len(self.free)},)")
        if np.any(self.lower >= self.upper):
            i = int(np.argmax(self.lower >= self.upper))
            raise SpecError(f"{self.free[i]}: bounds [{self.lower[i]:g}, {self.upper[i]:g}], expected lower < upper")
        self.cost_kind = cost
        self.outputs = outputs
        self.truth = dict(truth) if truth else None
        self.label = label
        rec = self.recording
        self.dt = rec.dt
        k = max(1, int(np.searchsorted(rec.t, rec.t[0] + rest_time, side="right")))
        self.q0 = rec.q[:k].mean(axis=0)
        meas = [rec.q]
        if "motor" in outputs:
            meas.append(rec.qm)
        self.measured = np.concatenate(meas, axis=1)  # (N, k·nv)
        self.step = float(step) if step else self._choose_step()
        self.nsim = 0
        self.seconds = 0.0

    @property
    def d(self) -> int:
        """Number of fitted parameters."""
        return len(self.free)

    def full(self, X: np.ndarray) -> np.ndarray:
        """Full parameter vectors ``(P, D)`` from free ones ``(P, d)``."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        out = np.repeat(self.model.values[None, :], len(X), axis=0)
        out[:, self.idx] = X
        return out

    def _choose_step(self) -> float:
        """Stable for the worst corner of the box (the fastest rates come with high stiffness, damping and
        friction and low inertias; free inertial parameters are tried at both bounds and at 64 random points),
        accurate for the model's values (the truth of a twin, else the middle of the box)."""
        lo, hi = self.lower, self.upper
        worst = np.empty(self.d)
        for i, n in enumerate(self.free):
            par = n.rsplit(".", 1)[-1]
            if par in ("Jm",):
                worst[i] = lo[i]
            elif par in ("K2", "kv"):
                worst[i] = lo[i] if abs(lo[i]) > abs(hi[i]) else hi[i]
            elif par in FLEX_PARAMS:
                worst[i] = hi[i]
            else:
                worst[i] = np.nan
        inert = np.isnan(worst)
        rng = np.random.default_rng(12345)
        probes = [
            np.where(inert, lo, worst),
            np.where(inert, hi, worst),
            np.where(inert, self.model.values[self.idx], worst),
        ]
        rnd = lo + rng.random((64, self.d)) * (hi - lo)
        rnd[:, ~inert] = worst[~inert]
        X = np.vstack(probes + [rnd])
        h, _ = self.model.choose_step(self.dt, self.full(X), self.q0, accuracy=self.model.values[None, :])
        return h

    # ------------------------------------------------------------------ evaluation
    def simulate(self, X) -> FlexSimulation:
        """Simulate free parameter vectors ``(P, d)`` (or one ``(d,)``) under the recording's input."""
        start = time.perf_counter()
        sim = self.model.simulate(
            self.recording.u, self.dt, self.full(X), q0=self.q0, input=self.recording.input, step=self.step
        )
        self.nsim += sim.q.shape[0]
        self.seconds += time.perf_counter() - start
        return sim

    def errors(self, X) -> np.ndarray:
        """Simulated minus measured angles ``(P, N, k·nv)`` [rad] (link angles, then motor angles)."""
        sim = self.simulate(X)
        parts = [sim.q]
        if "motor" in self.outputs:
            parts.append(sim.qm)
        return np.concatenate(parts, axis=2) - self.measured[None]

    def cost_of_errors(self, e: np.ndarray) -> np.ndarray:
        """The cost of angle errors ``e`` (P, samples, channels) [rad]: Σ|e| (seed 003 Eq. (15)) or Σe²; inf where not finite."""
        with np.errstate(all="ignore"):
            c = np.abs(e).sum(axis=(1, 2)) if self.cost_kind == "abs" else (e * e).sum(axis=(1, 2))
        return np.where(np.isfinite(c), c, np.inf)

    def cost_batch(self, X: np.ndarray) -> np.ndarray:
        """The cost of every row of ``X`` ``(P, d)``: one batch simulation."""
        return self.cost_of_errors(self.errors(X))

    def cost(self, x) -> float:
        """The cost of one parameter vector ``x``."""
        return float(self.cost_batch(np.atleast_2d(x))[0])

    def integrator_error(self, x, refine: int = 4) -> float:
        """Largest difference [rad] of the link angles at ``x`` between the problem's step and a ``refine`` times
        smaller one: the integrator's tolerance at that point."""
        full = self.full(np.atleast_2d(x))
        a = self.model.simulate(self.recording.u, self.dt, full, q0=self.q0, input=self.recording.input, step=self.step)
        b = self.model.simulate(
            self.recording.u, self.dt, full, q0=self.q0, input=self.recording.input, step=self.step / refine
        )
        return float(np.max(np.abs(a.q - b.q)))

    def metrics(self, x) -> dict:
        """Per joint (and output) RMS, mean and max absolute angle error [rad] at ``x``."""
        e = self.errors(np.atleast_2d(x))[0]
        names = [f"{j}" for j in self.model.joint_names]
        if "motor" in self.outputs:
            names += [f"{j}.motor" for j in self.model.joint_names]
        out = {}
        for k, n in enumerate(names):
            ek = e[:, k]
            out[n] = {
                "rms": float(np.sqrt(np.mean(ek**2))),
                "mean_abs": float(np.mean(np.abs(ek))),
                "max_abs": float(np.max(np.abs(ek))),
            }
        return out


# ====================================================================== results
@dataclass
class OutputErrorResult:
    """One fit: fitted values, cost and its curve, time, and the error against the truth when it is known.

    ``history``: ``[[simulations, best cost], ...]``; ``nfev``: parameter sets simulated; ``seconds``: wall
    time of the fit; ``metrics``: angle errors per joint at the fit [rad]; ``rel_error``: (fitted − truth)/|truth|.
    """

    method: str
    model_kind: str
    cost_kind: str
    names: list[str]
    x: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    cost: float
    history: list
    nfev: int
    seconds: float
    message: str
    step: float
    metrics: dict
    truth: dict | None = None
    extra: dict = field(default_factory=dict)

    @property
    def values(self) -> dict[str, float]:
        """Fitted values by name [SI]."""
        return {n: float(v) for n, v in zip(self.names, self.x)}

    @property
    def rel_error(self) -> dict[str, float] | None:
        """Relative error against the truth [%] per parameter, None without a truth."""
        if not self.truth:
            return None
        out = {}
        for n, v in zip(self.names, self.x):
            if n in self.truth:
                t = self.truth[n]
                out[n] = float((v - t) / abs(t)) if t != 0 else float("inf") if v != 0 else 0.0
        return out

    @property
    def rms(self) -> float:
        """RMS angle error over every compared angle [rad]."""
        return float(np.sqrt(np.mean([m["rms"] ** 2 for m in self.metrics.values()])))

    def to_dict(self) -> dict:
        """Plain-JSON form (the file ``pinid flex fit`` writes)."""
        return jsonable(
            {
                "method": self.method,
                "model": self.model_kind,
                "cost_kind": self.cost_kind,
                "cost": self.cost,
                "values": self.values,
                "bounds": {n: [float(a), float(b)] for n, a, b in zip(self.names, self.lower, self.upper)},
                "truth": self.truth,
                "rel_error": self.rel_error,
                "metrics": self.metrics,
                "rms": self.rms,
                "history": self.history,
                "nfev": self.nfev,
                "seconds": self.seconds,
                "message": self.message,
                "step": self.step,
                **self.extra,
            }
        )

    def save(self, path: str | os.PathLike) -> Path:
        """Write :meth:`to_dict` as JSON (atomically)."""
        return write_json(path, self.to_dict())

    @classmethod
    def from_dict(cls, d: dict) -> "OutputErrorResult":
        """Rebuild from :meth:`to_dict`'s output."""
        names = list(d["values"])
        known = {
            "method",
            "model",
            "cost_kind",
            "cost",
            "values",
            "bounds",
            "truth",
            "rel_error",
            "metrics",
            "rms",
            "history",
            "nfev",
            "seconds",
            "message",
            "step",
        }
        return cls(
            d["method"],
            d["model"],
            d["cost_kind"],
            names,
            np.array([d["values"][n] for n in names]),
            np.array([d["bounds"][n][0] for n in names]),
            np.array([d["bounds"][n][1] for n in names]),
            float(d["cost"]),
            d["history"],
            int(d["nfev"]),
            float(d["seconds"]),
            d["message"],
            float(d["step"]),
            d["metrics"],
            d.get("truth"),
            {k: v for k, v in d.items() if k not in known},
        )

    @classmethod
    def load(cls, path: str | os.PathLike) -> "OutputErrorResult":
        """Read a file written by :meth:`save`."""
        p = Path(path)
        try:
            return cls.from_dict(json.loads(read_bounded_file(p, "output-error result (JSON)", error=DataError)))
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise DataError(f"{p}: not an output-error result ({exc})") from None

    def table(self) -> list[list[str]]:
        """Rows ``[name, fitted, truth, error %, lower, upper]`` as text."""
        rel = self.rel_error or {}
        rows = []
        for n, v, lo, hi in zip(self.names, self.x, self.lower, self.upper):
            t = (self.truth or {}).get(n)
            rows.append(
                [
                    n,
                    f"{v:.6g}",
                    "-" if t is None else f"{t:.6g}",
                    "-" if n not in rel else f"{100 * rel[n]:+.3f}",
                    f"{lo:.4g}",
                    f"{hi:.4g}",
                ]
            )
        return rows


# ====================================================================== fitting
def fit_output_error(
    problem: OutputErrorProblem,
    method: str = "pso",
    *,
    rng: np.random.Generator | int | None = 0,
    x0=None,
    options: Mapping | None = None,
    progress: bool | None = None,
    f_scale: float = 1e-3,
    max_nfev: int = 60,
) -> OutputErrorResult:
    """Fit the free parameters of ``problem`` with ``method`` (a registry optimiser or ``"least_squares"``).

    ``options``: settings of the optimiser (``population``, ``iterations``, …); ``x0``: a start (free values)
    put in the initial population, or least squares' start (default: the middle of the box);
    ``f_scale`` [rad]: least squares' soft-L1 scale when the cost is ``"abs"``; ``max_nfev``: least squares'
    budget of residual evaluations (each Jacobian costs one more batch of ``d`` simulations).
    """
    if not isinstance(problem, OutputErrorProblem):
        raise SpecError(f"problem: got {type(problem).__name__}, expected an OutputErrorProblem (problem_from_spec)")
    if method not in methods():
        raise SpecError(f"unknown method {method!r}, expected one of {', '.join(methods())}")
    start = time.perf_counter()
    nsim0 = problem.nsim
    history: list[list[float]] = []
    if method == LEAST_SQUARES:
        x, message, extra = _least_squares(problem, x0, history, f_scale, max_nfev, options or {}, progress)
    else:
        opt = get_optimizer(method, **dict(options or {}))

        def fun(X):
            return problem.cost_batch(X)

        def callback(it, xb, fb):
            history.append([problem.nsim - nsim0, float(fb)])
            return None

        res = opt.minimize(fun, problem.lower, problem.upper, rng=rng, x0=x0, callback=callback, progress=progress)
        if not history or history[0][0] != 0:
            history.insert(0, [0, float(res.history[0])])
        x, message = res.x, res.message
        extra = {"iterations": int(res.nit), "options": {k: v for k, v in vars(opt.options).items()}}
    seconds = time.perf_counter() - start
    nfev = problem.nsim - nsim0
    cost = problem.cost(x)
    metrics = problem.metrics(x)
    extra["integrator_error"] = problem.integrator_error(x)
    kind = "flexible" if problem.model.flexible_joints else "rigid"
    truth = None
    if problem.truth:
        truth = {n: float(problem.truth[n]) for n in problem.free if n in problem.truth}
    return OutputErrorResult(
        method,
        kind,
        problem.cost_kind,
        list(problem.free),
        np.asarray(x, float),
        problem.lower.copy(),
        problem.upper.copy(),
        cost,
        history,
        nfev,
        seconds,
        message,
        problem.step,
        metrics,
        truth,
        extra,
    )


def _least_squares(problem: OutputErrorProblem, x0, history, f_scale, max_nfev, options, progress=None):
    from scipy.optimize import least_squares

    from pinid.progress import progress as progress_bar

    lo, hi = problem.lower, problem.upper
    width = hi - lo
    z0 = 0.5 * np.ones(problem.d) if x0 is None else np.clip((np.asarray(x0, float).reshape(-1) - lo) / width, 0, 1)
    if z0.shape != (problem.d,):
        raise SpecError(f"least_squares: x0 has {z0.size} values, expected {problem.d}")
    best = {"cost": np.inf}
    nsim0 = problem.nsim
    diff = float(options.get("diff_step", 1e-6))

    def residuals(z):
        e = problem.errors((lo + z * width)[None, :])
        c = float(problem.cost_of_errors(e)[0])
        best["cost"] = min(best["cost"], c)
        history.append([problem.nsim - nsim0, best["cost"]])
        bar.update(1)
        bar.set_postfix_str(f"best {best['cost']:.6g}", refresh=False)
        r = e[0].reshape(-1)
        if not np.all(np.isfinite(r)):
            return np.full(r.shape, 1e3)  # diverged: a large, finite residual
        return r

    def jacobian(z):
        steps = np.where(z + diff <= 1.0, diff, -diff)
        Z = np.vstack([z] + [z + np.eye(problem.d)[i] * steps[i] for i in range(problem.d)])
        e = problem.errors(lo + Z * width).reshape(len(Z), -1)
        J = (e[1:] - e[:1]) / steps[:, None]
        J[~np.isfinite(J)] = 0.0
        return J.T

    kw = dict(
        method="trf",
        jac=jacobian,
        bounds=(np.zeros(problem.d), np.ones(problem.d)),
        x_scale=1.0,
        ftol=float(options.get("ftol", 1e-12)),
        xtol=float(options.get("xtol", 1e-12)),
        gtol=float(options.get("gtol", 1e-12)),
        max_nfev=int(options.get("max_nfev", max_nfev)),
    )
    if problem.cost_kind == "abs":
        kw.update(loss="soft_l1", f_scale=float(f_scale))
    bar = progress_bar(kw["max_nfev"], "least_squares", enabled=progress)
    try:
        res = least_squares(residuals, z0, **kw)
    finally:
        bar.close()
    return (
        lo + res.x * width,
        str(res.message),
        {
            "njev": int(res.njev or 0),
            "status": int(res.status),
            "f_scale": float(f_scale) if problem.cost_kind == "abs" else None,
        },
    )


# ====================================================================== observability
def sensitivity(problem: OutputErrorProblem, x=None, *, noise: float = 1e-3, rel_step: float = 1e-5) -> dict:
    """Which free parameters the recording's excitation makes observable, at ``x`` (default: the truth).

    ``S[k, i] = ∂e_k/∂ln|x_i|`` (finite differences, one batch simulation) — the change of every compared
    angle for a 1 % change of a parameter, ×100.  Returns the singular values of ``S`` (a value near 0: a
    combination of parameters the angles do not see), each parameter's relative standard deviation
    ``σ·√((SᵀS)⁻¹)_ii`` for Gaussian angle noise ``noise`` [rad] (Cramér-Rao bound of least squares), and the
    weakest direction (the right singular vector of the smallest singular value).
    """
    if not isinstance(problem, OutputErrorProblem):
        raise SpecError(f"problem: got {type(problem).__name__}, expected an OutputErrorProblem (problem_from_spec)")
    if x is None:
        if not problem.truth or any(n not in problem.truth for n in problem.free):
            x = problem.model.values[problem.idx]
        else:
            x = np.array([problem.truth[n] for n in problem.free])
    x = np.asarray(x, dtype=float)
    scale = np.where(x != 0, np.abs(x), problem.upper - problem.lower)
    h = rel_step * scale
    X = np.vstack([x] + [x + np.eye(problem.d)[i] * h[i] for i in range(problem.d)])
    e = problem.errors(X).reshape(len(X), -1)
    S = ((e[1:] - e[:1]) / h[:, None] * scale[:, None]).T  # (rows, d): per unit relative change
    U, s, Vt = np.linalg.svd(S, full_matrices=False)
    tiny = s < s[0] * 1e-12
    inv = np.where(tiny, np.inf, 1.0 / np.where(tiny, 1.0, s) ** 2)
    with np.errstate(invalid="ignore"):
        var = (Vt.T**2 * inv[None, :]).sum(axis=1)
    rel_std = noise * np.sqrt(var)
    return {
        "names": list(problem.free),
        "x": x.tolist(),
        "singular_values": s.tolist(),
        "condition": float(s[0] / s[-1]) if s[-1] > 0 else float("inf"),
        "rel_std": dict(zip(problem.free, map(float, rel_std))),
        "noise": float(noise),
        "weakest": dict(zip(problem.free, map(float, Vt[-1]))),
        "samples": int(e.shape[1]),
    }


#: Relative standard deviations [-] that :func:`classify` calls well determined and weak.
WELL_DETERMINED = 0.01
WEAK = 0.1


def classify(rel_std: float) -> str:
    """``"observable"`` (±2σ within ±2 %), ``"weak"`` (σ ≤ 10 %) or ``"unobservable"`` at the noise of the bound."""
    if isinstance(rel_std, bool) or not isinstance(rel_std, (int, float, np.floating, np.integer)):
        raise SpecError(f"rel_std: got {type(rel_std).__name__}, expected a relative standard deviation (a number)")
    if rel_std <= WELL_DETERMINED:
        return "observable"
    return "weak" if rel_std <= WEAK else "unobservable"


# ====================================================================== spec-level helpers
def problem_from_spec(
    spec: FlexSpec,
    recording: FlexRecording,
    *,
    rigid: bool = False,
    cost: str | None = None,
    outputs: Sequence[str] | None = None,
) -> OutputErrorProblem:
    """The problem a spec describes for ``recording`` (``rigid``: the rigid-joint model of the same spec)."""
    if not isinstance(spec, FlexSpec):
        raise SpecError(f"spec: got {type(spec).__name__}, expected a FlexSpec (load_flex_spec)")
    s = spec.rigid() if rigid else spec
    model = s.model()
    truth = None  # the rigid model has no truth: the twin is flexible
    if not rigid and (s.truth is not None or recording.meta.get("truth")):
        truth = {**(s.truth or {}), **(recording.meta.get("truth") or {})}  # what made the recording wins
    return OutputErrorProblem(
        model,
        recording,
        s.free,
        s.lower,
        s.upper,
        cost=cost or s.fit.cost,
        outputs=outputs or s.fit.outputs,
        rest_time=s.fit.rest_time,
        truth=truth,
        label="rigid" if rigid else "flexible",
    )


def compare_rigid_flexible(
    spec: FlexSpec,
    recording: FlexRecording,
    *,
    method: str | None = None,
    options: Mapping | None = None,
    rng: int = 0,
    polish: bool = True,
    progress: bool | None = None,
) -> dict:
    """Seed 003 Figs. 6-7: fit the flexible and the rigid model of ``spec`` to the same recording.

    Each model is fitted with ``method`` (default the spec's), then, if ``polish``, refined by least squares
    from that result.  Returns ``{"flexible": result, "rigid": result, "simulated": {label: (N, nv)},
    "measured": (N, nv), "t": (N,)}``.
    """
    if not isinstance(spec, FlexSpec):
        raise SpecError(f"spec: got {type(spec).__name__}, expected a FlexSpec (load_flex_spec)")
    method = method or spec.fit.method
    opts = dict(options or {"population": spec.fit.population, "iterations": spec.fit.iterations})
    out: dict = {"t": recording.t, "measured": recording.reorder(spec.robot.joint_names).q, "simulated": {}}
    for label, rigid in (("flexible", False), ("rigid", True)):
        prob = problem_from_spec(spec, recording, rigid=rigid)
        res = fit_output_error(
            prob,
            method,
            rng=rng,
            options=None if method == LEAST_SQUARES else opts,
            progress=progress,
            f_scale=spec.fit.f_scale,
        )
        if polish and method != LEAST_SQUARES:
            ls = fit_output_error(prob, LEAST_SQUARES, x0=res.x, f_scale=spec.fit.f_scale, progress=progress)
            if ls.cost <= res.cost:
                ls.history = res.history + [[res.nfev + h[0], min(h[1], res.cost)] for h in ls.history]
                ls.extra["global"] = {"method": method, "cost": res.cost, "nfev": res.nfev, "seconds": res.seconds}
                ls.method = f"{method}+least_squares"
                ls.nfev += res.nfev
                ls.seconds += res.seconds
                res = ls
        out[label] = res
        out["simulated"][label] = prob.simulate(res.x).q[0]
    return out

"""The TOML spec of a flexible-joint study (seed 003): URDF, drives, fixed values, bounds of the free
parameters, the truth of the twin, its input and the fit settings (``excitation/tracker_flex_spec.toml``
documents every key); :class:`FlexSpec`, :func:`load_flex_spec`, and the fit settings' vocabulary
(:data:`COSTS`, :data:`OUTPUTS`, :func:`methods`).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, replace
from pathlib import Path
from collections.abc import Mapping

import numpy as np

from pinid.errors import JointError, PinidError, SpecError
from pinid.flexible.model import FLEX_PARAMS, RIGID_PARAMS, Drive, FlexibleModel, check_parameter
from pinid.model.robot import INERTIAL_NAMES, RobotModel
from pinid.optimizers import OPTIMIZERS
from pinid.flexible.recording import InputSignal


#: Costs of :class:`OutputErrorProblem`.
COSTS: tuple[str, ...] = ("abs", "sq")
#: Angles that can be compared: link angles, motor angles (motor side).
OUTPUTS: tuple[str, ...] = ("link", "motor")
#: The gradient-based method (the others come from :data:`pinid.optimizers.OPTIMIZERS`).
LEAST_SQUARES = "least_squares"


def methods() -> list[str]:
    """Every method :func:`fit_output_error` accepts."""
    return list(OPTIMIZERS) + [LEAST_SQUARES]


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
    from pinid.io import as_path
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
    return _spec_from_dict(data, source=str(p), robot=robot, spec_path=p)


def _spec_from_dict(
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

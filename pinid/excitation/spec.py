"""The excitation spec: the limits and settings of a design, where they come from, and their checks.

Limits
------
An :class:`ExcitationSpec` holds them.  Position and velocity limits come from the URDF; a spec file
(TOML or JSON, see ``excitation/exo_leg_table2.toml``) adds what a URDF cannot hold — acceleration
limits, margins, the offsets q0, the number of harmonics, the base frequency — and may tighten (never
widen) the URDF's limits.  Without a spec file: URDF limits, ``DEFAULT_ACCELERATION`` for the
acceleration, ``DEFAULT_VELOCITY`` where the URDF gives no velocity, ``q0 ± DEFAULT_HALF_RANGE`` where
it gives no position limits, offsets at the centres of the ranges.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from pinid.model.base import BaseParameters, base_parameters
from pinid.errors import SpecError
from pinid.io import as_path, display_path, parse_spec_text, read_bounded_file
from pinid.resources import EXCITATION_DIR
from pinid.model.robot import RobotModel, as_robot
from pinid.model.terms import TermSelection
from pinid.model.bundled import BUNDLED_URDF_DIR

#: Acceleration limit [rad/s² or m/s²] when neither the spec nor the URDF gives one.
DEFAULT_ACCELERATION = 5.0
#: Velocity limit [rad/s or m/s] when the URDF gives none.
DEFAULT_VELOCITY = 2.0
#: Half position range [rad or m] around q0 when the URDF gives no position limits.
DEFAULT_HALF_RANGE = math.pi
DEFAULT_HARMONICS = 4
#: Seed 001's base frequency ωf = 0.2π rad/s (period 10 s).
DEFAULT_BASE_FREQUENCY = 0.2 * math.pi
#: Samples per period of the regressor whose condition number is minimised.
DEFAULT_SAMPLES = 200
#: Smallest motion [rad or m] a joint's limits must allow at the base frequency.
MIN_AMPLITUDE = 1e-3
#: Criteria: name -> description.
CRITERIA = {
    "cond": "condition number of the base regressor (seed 001 Eq. (20))",
    "logdet": "D-optimal: −log det(W_bᵀ W_b)",
}
#: Spec files used by default for bundled robots (in the repository's ``excitation/`` folder).
DEFAULT_SPECS = {"exo_leg": "exo_leg_table2.toml"}

_SPEC_KEYS = {
    "description",
    "urdf",
    "harmonics",
    "base_frequency",
    "samples",
    "rest_start",
    "optimize_offsets",
    "margin",
    "criterion",
    "terms",
    "q0",
    "joints",
    "torque_limits",
}
_JOINT_KEYS = {"q_min", "q_max", "dq_max", "ddq_max", "tau_max", "q0"}


# ====================================================================================== specification
@dataclass
class ExcitationSpec:
    """Limits and settings of an excitation design; arrays are per active joint, in model order.

    ``q_min``, ``q_max`` [rad], ``dq_max`` [rad/s], ``ddq_max`` [rad/s²], ``tau_max`` [N·m] (inf: none),
    ``q0`` [rad] the offsets (fixed unless ``optimize_offsets``).  ``margin`` is a fraction of every limit
    kept in reserve: the position range shrinks by ``margin·(q_max − q_min)`` at each end, the velocity
    and acceleration limits by the factor ``1 − margin``.
    """

    joints: list[str]
    q_min: np.ndarray
    q_max: np.ndarray
    dq_max: np.ndarray
    ddq_max: np.ndarray
    q0: np.ndarray
    tau_max: np.ndarray | None = None
    harmonics: int = DEFAULT_HARMONICS
    base_frequency: float = DEFAULT_BASE_FREQUENCY
    samples: int = DEFAULT_SAMPLES
    rest_start: bool = True
    optimize_offsets: bool = False
    margin: float = 0.0
    criterion: str = "cond"
    terms: TermSelection = field(default_factory=TermSelection)
    source: str = "defaults"

    def __post_init__(self) -> None:
        nv = len(self.joints)
        for name in ("q_min", "q_max", "dq_max", "ddq_max", "q0", "tau_max"):
            value = getattr(self, name)
            if value is None:
                value = np.full(nv, np.inf)
            value = np.asarray(value, dtype=float).reshape(-1)
            if value.shape != (nv,):
                raise SpecError(f"{self.source}: {name} has {value.size} values, expected {nv} (joints {self.joints})")
            setattr(self, name, value)

    # ------------------------------------------------------------------ derived limits
    @property
    def period(self) -> float:
        """Period 2π/ω [s]."""
        return 2 * math.pi / self.base_frequency

    @property
    def lower(self) -> np.ndarray:
        """Lower position limits after the margin [rad]."""
        return self.q_min + self.margin * (self.q_max - self.q_min)

    @property
    def upper(self) -> np.ndarray:
        """Upper position limits after the margin [rad]."""
        return self.q_max - self.margin * (self.q_max - self.q_min)

    @property
    def velocity(self) -> np.ndarray:
        """Velocity limits after the margin [rad/s]."""
        return self.dq_max * (1 - self.margin)

    @property
    def acceleration(self) -> np.ndarray:
        """Acceleration limits after the margin [rad/s²]."""
        return self.ddq_max * (1 - self.margin)

    @property
    def torque(self) -> np.ndarray:
        """Torque limits after the margin [N·m] (inf: none)."""
        return self.tau_max * (1 - self.margin)

    @property
    def has_torque_limits(self) -> bool:
        """True when any joint has a torque limit (then the design computes torques with the nominal URDF)."""
        return bool(np.any(np.isfinite(self.tau_max)))

    def replace(self, **changes) -> "ExcitationSpec":
        """A copy with some settings changed (``spec.replace(harmonics=6)``)."""
        return replace(self, **changes)

    def limits_dict(self) -> dict:
        """Per joint ``{q_min, q_max, dq_max, ddq_max, tau_max}`` as given (before the margin); None = no limit."""

        def num(x):
            return float(x) if np.isfinite(x) else None

        return {
            j: {
                "q_min": num(self.q_min[i]),
                "q_max": num(self.q_max[i]),
                "dq_max": num(self.dq_max[i]),
                "ddq_max": num(self.ddq_max[i]),
                "tau_max": num(self.tau_max[i]),
            }
            for i, j in enumerate(self.joints)
        }

    def to_dict(self) -> dict:
        """Plain-dict form of the settings and limits."""
        return {
            "source": self.source,
            "harmonics": int(self.harmonics),
            "base_frequency": float(self.base_frequency),
            "samples": int(self.samples),
            "rest_start": bool(self.rest_start),
            "optimize_offsets": bool(self.optimize_offsets),
            "margin": float(self.margin),
            "criterion": self.criterion,
            "terms": self.terms.names,
            "q0": self.q0.tolist(),
            "limits": self.limits_dict(),
        }

    # ------------------------------------------------------------------ checks
    def validate(self, model: RobotModel | None = None, base: BaseParameters | None = None) -> None:
        """Raise SpecError, with a one-line message naming the joint and the limit, if no useful
        trajectory can meet these settings."""
        src = self.source
        if int(self.harmonics) != self.harmonics or self.harmonics < 1:
            raise SpecError(f"{src}: harmonics {self.harmonics!r}, expected an integer >= 1")
        if self.rest_start and self.harmonics < 2:
            raise SpecError(
                f"{src}: rest_start needs at least 2 harmonics (it uses up the first), got {self.harmonics}"
            )
        if not (np.isfinite(self.base_frequency) and self.base_frequency > 0):
            raise SpecError(f"{src}: base_frequency {self.base_frequency!r}, expected > 0 [rad/s]")
        if int(self.samples) != self.samples or self.samples <= 2 * self.harmonics:
            raise SpecError(
                f"{src}: samples {self.samples!r}, expected an integer > 2·harmonics = {2 * self.harmonics} "
                "(the samples must resolve the highest harmonic)"
            )
        if not (0 <= self.margin < 0.5):
            raise SpecError(f"{src}: margin {self.margin!r}, expected a fraction in [0, 0.5)")
        if self.criterion not in CRITERIA:
            raise SpecError(f"{src}: criterion {self.criterion!r}, expected one of {', '.join(CRITERIA)}")
        w = self.base_frequency
        for i, j in enumerate(self.joints):
            lo, hi, q0 = self.q_min[i], self.q_max[i], self.q0[i]
            if not (np.isfinite(lo) and np.isfinite(hi)):
                raise SpecError(f"{src}: joint '{j}': position range [{lo:g}, {hi:g}] is not finite")
            if not lo < hi:
                raise SpecError(
                    f"{src}: joint '{j}': position range [{lo:g}, {hi:g}] has no width, expected q_min < q_max"
                )
            for name, value, unit in (("dq_max", self.dq_max[i], "rad/s"), ("ddq_max", self.ddq_max[i], "rad/s²")):
                if not (np.isfinite(value) and value > 0):
                    raise SpecError(f"{src}: joint '{j}': {name} {value:g}, expected a finite limit > 0 [{unit}]")
            if not np.isnan(self.tau_max[i]) and self.tau_max[i] <= 0:
                raise SpecError(f"{src}: joint '{j}': tau_max {self.tau_max[i]:g}, expected > 0 [N·m] (or no limit)")
            if not np.isfinite(q0) or not (self.lower[i] < q0 < self.upper[i]):
                extra = f" (after the margin {self.margin:g})" if self.margin else ""
                raise SpecError(
                    f"{src}: joint '{j}': offset q0 = {q0:g} is outside its range "
                    f"[{self.lower[i]:.6g}, {self.upper[i]:.6g}]{extra}; expected strictly inside"
                )
            room = {
                "position": min(q0 - self.lower[i], self.upper[i] - q0),
                "dq_max": self.velocity[i] / w,
                "ddq_max": self.acceleration[i] / w**2,
            }
            which = min(room, key=room.get)
            if room[which] < MIN_AMPLITUDE:
                if which == "position":
                    why = f"offset q0 = {q0:g} is only {room[which]:.3g} rad from a position limit"
                else:
                    value = self.velocity[i] if which == "dq_max" else self.acceleration[i]
                    why = (
                        f"{which} {value:g} allows at most {room[which]:.3g} rad of motion at base frequency "
                        f"{w:g} rad/s"
                    )
                raise SpecError(
                    f"{src}: joint '{j}': {why}; expected room for at least {MIN_AMPLITUDE:g} rad "
                    "(widen the limit or lower base_frequency)"
                )
        if model is not None:
            if model.joint_names != list(self.joints):
                raise SpecError(f"{src}: joints {self.joints} do not match the model's {model.joint_names}")
            nb = (base or base_parameters(model, self.terms)).count
            if self.samples * model.nv < nb:
                raise SpecError(
                    f"{src}: samples {self.samples} × {model.nv} joints = {self.samples * model.nv} rows "
                    f"< {nb} base parameters; expected more samples"
                )


def default_spec(model: RobotModel, **settings) -> ExcitationSpec:
    """Limits from the URDF plus pinid's defaults (see the module documentation); ``settings`` override
    any field of :class:`ExcitationSpec` (``harmonics=6``, ``rest_start=False``...)."""
    model = as_robot(model)
    lo, hi = model.lower.copy(), model.upper.copy()
    both = np.isfinite(lo) & np.isfinite(hi)
    q0 = np.zeros(model.nv)
    q0[both] = 0.5 * (lo[both] + hi[both])
    only_lo, only_hi = np.isfinite(lo) & ~np.isfinite(hi), ~np.isfinite(lo) & np.isfinite(hi)
    q0 = np.where(only_lo, lo + DEFAULT_HALF_RANGE, q0)
    q0 = np.where(only_hi, hi - DEFAULT_HALF_RANGE, q0)
    lo = np.where(np.isfinite(lo), lo, q0 - DEFAULT_HALF_RANGE)
    hi = np.where(np.isfinite(hi), hi, q0 + DEFAULT_HALF_RANGE)
    vel = np.where(np.isfinite(model.velocity_limit), model.velocity_limit, DEFAULT_VELOCITY)
    fields_ = dict(
        joints=model.joint_names,
        q_min=lo,
        q_max=hi,
        dq_max=vel,
        ddq_max=np.full(model.nv, DEFAULT_ACCELERATION),
        q0=q0,
        tau_max=np.full(model.nv, np.inf),
        source=f"{model.urdf_path.name if model.urdf_path else model.name} (URDF limits, pinid defaults)",
    )
    fields_.update(settings)
    return ExcitationSpec(**fields_)


def bundled_spec_path(model: RobotModel) -> Path | None:
    """The spec file pinid uses by default for a bundled robot (``exo_leg`` → ``excitation/exo_leg_table2.toml``)."""
    model = as_robot(model)
    if model.urdf_path is None:
        return None
    path = Path(model.urdf_path)
    name = DEFAULT_SPECS.get(path.stem)
    if name is None:
        return None
    try:  # the bundled file itself (any path to it) or an unchanged copy; an edited copy gets its own limits
        bundled = BUNDLED_URDF_DIR / f"{path.stem}.urdf"
        if not (bundled.exists() and (os.path.samefile(bundled, path) or bundled.read_bytes() == path.read_bytes())):
            return None
    except OSError:
        return None
    spec = EXCITATION_DIR / name
    return spec if spec.is_file() else None


def load_spec(path: str | os.PathLike, model: RobotModel) -> ExcitationSpec:
    """Read a spec file (``.toml`` or ``.json``) for ``model``: URDF limits, overridden (tightened) by the file."""
    path = as_path(path)
    p = Path(path)
    text = read_bounded_file(p, "excitation spec (.toml or .json)")
    kind = "JSON" if p.suffix.lower() == ".json" else "TOML"
    data = parse_spec_text(text, str(p), "excitation spec", kind=kind)
    if not isinstance(data, dict):
        raise SpecError(f"{p}: expected a table of settings at the top level")
    return _spec_from_dict(data, model, source=display_path(p))


def _spec_from_dict(data: dict, model: RobotModel, *, source: str = "<spec>") -> ExcitationSpec:
    """Build a spec from the plain-dict form of a spec file (see ``excitation/exo_leg_table2.toml``)."""
    if not isinstance(data, dict):
        raise SpecError(f"{source}: data: got {type(data).__name__}, expected a table of settings")
    unknown = sorted(set(data) - _SPEC_KEYS)
    if unknown:
        raise SpecError(f"{source}: unknown setting(s) {', '.join(unknown)} (known: {', '.join(sorted(_SPEC_KEYS))})")
    spec = default_spec(model)
    changes: dict = {"source": source}

    def number(value, what, integer=False):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise SpecError(f"{source}: {what} = {value!r}, expected a number")
        if integer and int(value) != value:
            raise SpecError(f"{source}: {what} = {value!r}, expected an integer")
        return int(value) if integer else float(value)

    def flag(value, what):
        if not isinstance(value, bool):
            raise SpecError(f"{source}: {what} = {value!r}, expected true or false")
        return value

    if "harmonics" in data:
        changes["harmonics"] = number(data["harmonics"], "harmonics", integer=True)
    if "samples" in data:
        changes["samples"] = number(data["samples"], "samples", integer=True)
    if "base_frequency" in data:
        changes["base_frequency"] = number(data["base_frequency"], "base_frequency")
        if not (np.isfinite(changes["base_frequency"]) and changes["base_frequency"] > 0):  # the period divides by it
            raise SpecError(f"{source}: base_frequency = {data['base_frequency']!r}, expected a number > 0 [rad/s]")
    if "margin" in data:
        changes["margin"] = number(data["margin"], "margin")
    for key in ("rest_start", "optimize_offsets"):
        if key in data:
            changes[key] = flag(data[key], key)
    if "criterion" in data:
        changes["criterion"] = str(data["criterion"])
    if "terms" in data:
        terms = data["terms"]
        try:
            changes["terms"] = TermSelection.from_names(terms if isinstance(terms, (str, list)) else str(terms))
        except ValueError as exc:
            raise SpecError(f"{source}: terms: {exc}") from None
    arrays = {k: getattr(spec, k).copy() for k in ("q_min", "q_max", "dq_max", "ddq_max", "tau_max", "q0")}
    urdf_limits = {"q_min": model.lower, "q_max": model.upper, "dq_max": model.velocity_limit}
    if data.get("torque_limits") is not None:
        if flag(data["torque_limits"], "torque_limits"):
            arrays["tau_max"] = model.effort_limit.copy()
    q0 = data.get("q0", {})
    if not isinstance(q0, dict):
        raise SpecError(f"{source}: q0 must be a table joint = value [rad], e.g. q0 = {{hip = 0.61}}")
    joints = data.get("joints", {})
    if not isinstance(joints, dict):
        raise SpecError(f"{source}: joints must be a table of tables, e.g. [joints.hip] q_min = -0.1")
    q0_given = set()
    for jname, value in q0.items():
        i = _joint(model, jname, source)
        arrays["q0"][i] = number(value, f"q0.{jname}")
        q0_given.add(i)
    for jname, table in joints.items():
        i = _joint(model, jname, source)
        if not isinstance(table, dict):
            raise SpecError(f"{source}: joints.{jname} must be a table of limits ({', '.join(sorted(_JOINT_KEYS))})")
        bad = sorted(set(table) - _JOINT_KEYS)
        if bad:
            raise SpecError(
                f"{source}: joints.{jname}: unknown key(s) {', '.join(bad)} (known: {', '.join(sorted(_JOINT_KEYS))})"
            )
        for key, value in table.items():
            value = number(value, f"joints.{jname}.{key}")
            if key in urdf_limits:  # a spec may tighten the URDF's limits, never widen them
                urdf = urdf_limits[key][i]
                wider = value < urdf - 1e-9 if key == "q_min" else value > urdf + 1e-9
                if np.isfinite(urdf) and wider:
                    raise SpecError(
                        f"{source}: joints.{jname}.{key} = {value:g} is outside the URDF's limit {urdf:g}; "
                        "a spec may tighten the URDF's limits, not widen them"
                    )
            if key == "q0":
                q0_given.add(i)
            arrays[key][i] = value
    # offsets not given: the centre of the (possibly new) range
    for i in range(model.nv):
        if i not in q0_given:
            arrays["q0"][i] = 0.5 * (arrays["q_min"][i] + arrays["q_max"][i])
    changes.update(arrays)
    return spec.replace(**changes)


def _joint(model: RobotModel, name: str, source: str) -> int:
    if name not in model.joint_names:
        raise SpecError(
            f"{source}: joint '{name}' is not an active joint of {model.name} "
            f"(active joints: {', '.join(model.joint_names)})"
        )
    return model.joint_names.index(name)


def spec_for(model: RobotModel, path: str | os.PathLike | None = None, **settings) -> ExcitationSpec:
    """The spec to use: ``path`` if given, else the bundled one for ``exo_leg``, else :func:`default_spec`;
    ``settings`` (not None) override its fields."""
    model = as_robot(model)
    path = path if path is not None else bundled_spec_path(model)
    spec = load_spec(path, model) if path is not None else default_spec(model)
    settings = {k: v for k, v in settings.items() if v is not None}
    return spec.replace(**settings) if settings else spec

"""Drives: the motors of a robot and the transmissions between motors and joints.

A transmission couples some motors to as many joints: ``q_motor = matrix · q_joint`` (rows motors,
columns joints; square and invertible).  A plain reduction is a 1×1 matrix ``[[n]]``; a wrist
differential a 2×2 block; a cable that couples hip and knee a triangular block.  Then
``dq_motor = G·dq``, ``ddq_motor = G·ddq`` and the joint torques are ``τ_joint = Gᵀ·τ_motor`` (power
balance, losses ignored).  The robot's ``G`` (motors × joints, in the robot's joint order) stacks its
transmissions; a joint without a transmission has no motor (a motor term cannot act on it).

The motor-side terms of :mod:`pinid.model.terms` (``motor_fc``, ``motor_fv``, ``motor_armature``,
``motor_offset``; parameters ``<motor>.fc`` …) enter joint ``j``'s row as ``G[m, j]·c_m(G·q, G·dq, G·ddq)``.

Two sources, with the same meaning of ``matrix`` as a mapping spec's ``[transmission]``
(:mod:`pinid.data.mapping`; one :class:`Transmission` type and one parser for both):

1. the URDF's own ``<transmission>`` elements (ros_control / transmission_interface convention):
   ``SimpleTransmission`` with the actuator's ``mechanicalReduction`` ``n`` gives ``[[n]]``;
   ``DifferentialTransmission`` with actuator roles ``actuator1/2`` (reductions ``a1, a2``) and joint
   roles ``joint1/2`` (reductions ``j1, j2``, default 1) gives ``[[a1·j1, a1·j2], [a2·j1, −a2·j2]]``.
   Other transmission types and transmissions of inactive (locked or fixed) joints are left out.  A
   joint named by several ``SimpleTransmission`` elements with the same reduction (vendor URDFs such as
   Kinova's describe each drive twice: once for ros_control, once with its motor inertia) keeps the first;
   the others are left out with one warning.  Different reductions for one joint are an error.
2. a drives TOML (``--drives FILE``), replacing the URDF's::

       [transmission]                 # or [[transmission]] for several
       joints = ["wrist_2", "wrist_3"]
       motors = ["m5", "m6"]
       matrix = [[1, 0], [1, 1]]      # q_motor = matrix · q_joint
       [motors.m6]                    # optional nominal motor terms (SI units): the twin's plant uses
       fc = 0.3                       # them, identification starts from them, export writes them
       fv = 0.02
       armature = 1e-4
       offset = 0.0
"""

from __future__ import annotations

import os
import re
import warnings
from dataclasses import dataclass, field
from typing import Any
from collections.abc import Mapping, Sequence

import numpy as np

from pinid.errors import ModelError, ModelWarning, SpecError
from pinid.model.urdf import Element, UrdfDocument

#: Keys of a ``[motors.<name>]`` table of a drives file: the motor terms' parameter suffixes.
MOTOR_VALUE_KEYS: tuple[str, ...] = ("fc", "fv", "armature", "offset", "fc_pos", "fc_neg", "fs")


@dataclass(frozen=True)
class Transmission:
    """``q_motor = matrix · q_joint`` for ``motors`` × ``joints`` (square, invertible); ``τ_joint = matrixᵀ·τ_motor``."""

    joints: list[str]
    motors: list[str]
    matrix: np.ndarray


def transmission_from_table(d: Any, origin: str, error: type = SpecError) -> Transmission:
    """Parse and check a ``[transmission]`` table (``joints``, ``motors``, ``matrix``); one-line ``error``."""
    where = "[transmission]"
    if not isinstance(origin, str):
        raise SpecError(f"origin: got {type(origin).__name__}, expected text naming the file")
    if not isinstance(d, dict):
        raise error(f"{origin}: {where} must be a table with joints, motors, matrix, got {type(d).__name__}")
    extra = sorted(set(d) - {"joints", "motors", "matrix"})
    if extra:
        raise error(f"{origin}: {where} has unknown key(s) {extra}; expected joints, motors, matrix")
    for k in ("joints", "motors", "matrix"):
        if k not in d:
            raise error(f"{origin}: {where} has no {k}; expected joints, motors and matrix")
    tj, tm = d["joints"], d["motors"]
    if not (isinstance(tj, list) and isinstance(tm, list) and all(isinstance(x, str) for x in tj + tm)):
        raise error(f"{origin}: {where} joints and motors must be lists of names")
    if len(set(tj)) != len(tj) or len(set(tm)) != len(tm):
        raise error(f"{origin}: {where} joints and motors must not repeat names")
    try:
        R = np.array(d["matrix"], dtype=float)
    except (TypeError, ValueError):
        raise error(f"{origin}: {where} matrix must be a list of rows of numbers") from None
    return _checked(Transmission(list(tj), list(tm), R), origin, error)


def _names(x, name: str, error: type = SpecError) -> None:
    """``error`` naming ``name`` unless ``x`` is a list, tuple or array of names."""
    if not isinstance(x, (list, tuple, np.ndarray)) or not all(isinstance(n, str) for n in x):
        raise error(f"{name}: got {type(x).__name__}, expected a list of names")


#: What a motor name may hold: letters, digits and ``_ - . / :`` (it becomes parameter names ``<motor>.fc``
#: and a TOML key; a space, quote, newline or other control character would make both ambiguous).
MOTOR_NAME = re.compile(r"[A-Za-z0-9_./:-]+")


def check_motor_names(motors: Sequence[str], joints: Sequence[str], origin: str) -> None:
    """SpecError (one line, naming the motor) unless every motor name is valid (:data:`MOTOR_NAME`) and no
    joint's: with motor terms, ``knee.fc`` of a motor named ``knee`` would clash with the joint's.  Checked
    when motor terms are used (:func:`pinid.model.terms.layout`), so a URDF whose actuators carry the joints'
    names still loads and serves every joint-side model."""
    _names(motors, "motors")
    _names(joints, "joints")
    if not isinstance(origin, str):
        raise SpecError(f"origin: got {type(origin).__name__}, expected text naming the file")
    for m in motors:
        if not isinstance(m, str) or not MOTOR_NAME.fullmatch(m):
            raise SpecError(
                f"{origin}: motor name {m!r} is not allowed with motor terms, expected letters, digits and "
                "_ - . / : only (it becomes parameter names like '<motor>.fc' and a TOML key)"
            )
        if m in joints:
            raise SpecError(
                f"{origin}: motor '{m}' has the name of a joint, so with motor terms the parameters '{m}.fc' "
                f"of the joint and of the motor would clash; expected distinct names: rename the motor "
                f"(URDF <actuator> or drives file), e.g. '{m}_motor'"
            )


#: Largest magnitude of a transmission ratio accepted (motor rad per joint rad, or rad per m): real gears
#: and screws stay below 1e5; 1e200 overflows the regressor's motor columns.
MAX_GEAR_RATIO = 1e6


def _checked(t: Transmission, origin: str, error: type = SpecError) -> Transmission:
    """``t`` if its matrix is square (motors × joints), invertible and of plausible ratios (each entry
    ≤ :data:`MAX_GEAR_RATIO` in magnitude), else a one-line ``error``."""
    R = t.matrix
    if R.ndim == 2 and np.all(np.isfinite(R)) and np.abs(R).max(initial=0.0) > MAX_GEAR_RATIO:
        raise error(
            f"{origin}: transmission of {t.joints}: ratio {np.abs(R).max():g} in its matrix, expected entries "
            f"of magnitude at most {MAX_GEAR_RATIO:g} (q_motor = matrix · q_joint)"
        )
    if R.shape != (len(t.motors), len(t.joints)) or len(t.motors) != len(t.joints) or not t.joints:
        raise error(
            f"{origin}: transmission of {t.joints}: matrix has shape {R.shape}, expected a square "
            f"({len(t.motors)} motors × {len(t.joints)} joints) matrix with q_motor = matrix · q_joint"
        )
    if not np.all(np.isfinite(R)) or abs(np.linalg.det(R)) < 1e-12 * max(1.0, np.abs(R).max()) ** len(t.joints):
        raise error(
            f"{origin}: transmission of {t.joints}: matrix is singular or not finite ({R.tolist()}), "
            "expected an invertible matrix"
        )
    return t


@dataclass
class Drives:
    """The motors of a robot: ``matrix`` G (motors × the robot's joints) and nominal motor-term values."""

    joints: list[str]  # the robot's active joints, in model order (the columns of matrix)
    transmissions: list[Transmission]
    values: dict[str, dict[str, float]] = field(default_factory=dict)  # motor → {suffix: value}
    origin: str = "drives"

    def __post_init__(self) -> None:
        seen_j: dict[str, str] = {}
        seen_m: set[str] = set()
        for t in self.transmissions:
            for j in t.joints:
                if j not in self.joints:
                    raise SpecError(
                        f"{self.origin}: transmission names joint '{j}', which is not an active joint "
                        f"(active joints: {', '.join(self.joints)})"
                    )
                if j in seen_j:
                    raise SpecError(f"{self.origin}: joint '{j}' is in two transmissions, expected one")
                seen_j[j] = t.motors[0]
            for m in t.motors:
                if m in seen_m:
                    raise SpecError(f"{self.origin}: motor '{m}' is in two transmissions, expected one")
                seen_m.add(m)
        for m, vals in self.values.items():
            if m not in seen_m:
                raise SpecError(
                    f"{self.origin}: [motors.{m}] is not a motor of any transmission "
                    f"(motors: {', '.join(self.motor_names)})"
                )
            for k, v in vals.items():
                if k not in MOTOR_VALUE_KEYS:
                    raise SpecError(
                        f"{self.origin}: [motors.{m}] has unknown key '{k}', expected some of {list(MOTOR_VALUE_KEYS)}"
                    )
                if not isinstance(v, (int, float)) or isinstance(v, bool) or not np.isfinite(v):
                    raise SpecError(f"{self.origin}: [motors.{m}] {k} = {v!r}, expected a finite number")
                if k != "offset" and v < 0:
                    raise SpecError(f"{self.origin}: [motors.{m}] {k} = {v!r}, expected >= 0")
        G = np.zeros((len(seen_m), len(self.joints)))
        r = 0
        for t in self.transmissions:
            cols = [self.joints.index(j) for j in t.joints]
            G[r : r + len(t.motors), cols] = t.matrix
            r += len(t.motors)
        self.matrix = G

    @property
    def motor_names(self) -> list[str]:
        """Motor names, in the order of G's rows."""
        return [m for t in self.transmissions for m in t.motors]

    def nominal(self, suffix: str) -> np.ndarray:
        """Per motor, the nominal value of a motor term (``fc``, ``fv``, ``armature``, ``offset``; 0 if not given)."""
        return np.array([float(self.values.get(m, {}).get(suffix, 0.0)) for m in self.motor_names])

    def to_dict(self) -> dict:
        """The drives TOML as a dict (``[[transmission]]`` tables and ``[motors.<m>]`` values)."""
        out: dict = {
            "transmission": [
                {
                    "joints": list(t.joints),
                    "motors": list(t.motors),
                    "matrix": np.asarray(t.matrix, dtype=float).tolist(),
                }
                for t in self.transmissions
            ]
        }
        if self.values:
            out["motors"] = {m: dict(v) for m, v in self.values.items()}
        return out

    @classmethod
    def from_dict(cls, d: Mapping, joints: Sequence[str], origin: str = "drives") -> "Drives":
        """Parse a drives TOML's dict for a robot with active ``joints`` (see the module text)."""
        if not isinstance(d, Mapping):
            raise SpecError(f"{origin}: expected a table with [transmission] and optional [motors.<name>]")
        extra = sorted(set(d) - {"transmission", "motors", "description"})
        if extra:
            raise SpecError(f"{origin}: unknown table(s) {extra}; expected [transmission] and [motors.<name>]")
        if "transmission" not in d:
            raise SpecError(f"{origin}: no [transmission] table; expected joints, motors and matrix")
        tables = d["transmission"] if isinstance(d["transmission"], list) else [d["transmission"]]
        if not tables:
            raise SpecError(
                f"{origin}: transmission = [] lists no transmission; expected at least one [[transmission]] "
                "table with joints, motors and matrix (or leave out --drives for a robot without motors)"
            )
        transmissions = [transmission_from_table(t, origin) for t in tables]
        motors = d.get("motors", {})
        if not isinstance(motors, Mapping) or not all(isinstance(v, Mapping) for v in motors.values()):
            raise SpecError(f"{origin}: [motors] must hold [motors.<name>] tables of numbers")
        return cls(list(joints), transmissions, {m: dict(v) for m, v in motors.items()}, origin)


def load_drives(path: str | os.PathLike, joints: Sequence[str]) -> Drives:
    """Read a drives TOML file for a robot with active ``joints``; SpecError (one line) when it is wrong."""
    from pinid.io import as_path, read_toml

    p = as_path(path, "path")
    _names(joints, "joints")
    if not p.is_file():
        raise SpecError(f"{p}: drives file not found, expected a TOML file with a [transmission] table")
    d = read_toml(p, "drives file with a [transmission] table")
    return Drives.from_dict(d, joints, str(p))


def _number(el: Element | None, tag: str, origin: str, default: float | None = None) -> float:
    sub = el.find(tag) if el is not None else None
    if sub is None or not (sub.text or "").strip():
        if default is None:
            raise ModelError(f"{origin}: <{tag}> missing, expected a number")
        return default
    try:
        v = float(sub.text)
    except ValueError:
        raise ModelError(f"{origin}: <{tag}> is {sub.text.strip()!r}, expected a number") from None
    if not np.isfinite(v):
        raise ModelError(f"{origin}: <{tag}> is {v}, expected a finite number")
    return v


def urdf_transmissions(
    urdf_text: str | UrdfDocument, joints: Sequence[str], origin: str = "URDF"
) -> list[Transmission]:
    """The transmissions of a URDF's ``<transmission>`` elements among the active ``joints`` (module text);
    ``urdf_text``: the URDF's text or its :class:`~pinid.model.urdf.UrdfDocument` (a model's, read once)."""
    if not isinstance(urdf_text, (str, UrdfDocument)):
        raise ModelError(f"urdf_text: got {type(urdf_text).__name__}, expected the URDF's text")
    _names(joints, "joints", ModelError)
    document = urdf_text if isinstance(urdf_text, UrdfDocument) else UrdfDocument.from_text(urdf_text, origin)
    known = document.joint_names()
    out = []
    simple: dict[str, tuple[str, float]] = {}  # joint → (its first SimpleTransmission, reduction)
    repeated: list[str] = []  # transmissions that describe a drive already read
    for tr in document.transmissions():
        name = tr.get("name", "?")
        where = f"{origin}: <transmission name={name!r}>"
        kind = (tr.findtext("type") or tr.get("type") or "").strip().split("/")[-1]
        jels, aels = tr.findall("joint"), tr.findall("actuator")
        for el in jels + aels:
            if not (el.get("name") or "").strip():
                raise ModelError(f'{where}: a <{el.tag}> without a name, expected <{el.tag} name="...">')
        jnames = [j.get("name") for j in jels]
        unknown = [j for j in jnames if j not in known]
        if unknown:
            raise ModelError(f"{where} names joint(s) {unknown} that the URDF does not have")
        if kind not in ("SimpleTransmission", "DifferentialTransmission"):
            continue
        active = [j for j in jnames if j in joints]
        if not active:
            continue
        if len(active) != len(jnames):
            raise ModelError(
                f"{where} couples active joint(s) {active} with inactive ones "
                f"{[j for j in jnames if j not in joints]}; expected all of them active"
            )
        if kind == "SimpleTransmission":
            if len(jels) != 1 or len(aels) != 1:
                raise ModelError(f"{where}: SimpleTransmission needs one joint and one actuator")
            n = _number(aels[0], "mechanicalReduction", where, 1.0)
            if jnames[0] in simple:  # the same drive described again (ros_control and motor descriptions)
                first, reduction = simple[jnames[0]]
                if reduction != n:
                    raise ModelError(
                        f"{where}: joint {jnames[0]!r} is also in <transmission name={first!r}> with another "
                        f"reduction ({reduction:g}, here {n:g}); expected one transmission per joint"
                    )
                repeated.append(name)
                continue
            simple[jnames[0]] = (name, n)
            out.append(_checked(Transmission(jnames, [aels[0].get("name")], np.array([[n]])), where, ModelError))
            continue
        if len(jels) != 2 or len(aels) != 2:
            raise ModelError(f"{where}: DifferentialTransmission needs two joints and two actuators")
        a = _by_role(aels, ("actuator1", "actuator2"), where)
        j = _by_role(jels, ("joint1", "joint2"), where)
        a1, a2 = (_number(e, "mechanicalReduction", where, 1.0) for e in a)
        j1, j2 = (_number(e, "mechanicalReduction", where, 1.0) for e in j)
        G = np.array([[a1 * j1, a1 * j2], [a2 * j1, -a2 * j2]])
        out.append(_checked(Transmission([e.get("name") for e in j], [e.get("name") for e in a], G), where, ModelError))
    if repeated:
        warnings.warn(
            f"{origin}: <transmission> {', '.join(repeated)} describe drives already read (same joint, same "
            "reduction): left out, the first transmission of each joint is used",
            ModelWarning,
            stacklevel=2,
        )
    return out


def _by_role(els: list[Element], roles: tuple[str, str], where: str) -> list[Element]:
    by = {(e.findtext("role") or "").strip(): e for e in els}
    if set(by) != set(roles):
        raise ModelError(f"{where}: roles {sorted(by)}, expected {list(roles)}")
    return [by[r] for r in roles]


def as_drives(drives: Drives | str | os.PathLike | None, joints: Sequence[str] | None) -> Drives | None:
    """The drives of a robot with active ``joints``: a :class:`Drives` (re-ordered to ``joints``), a drives
    TOML path (read), or None for none; SpecError for anything else.  ``joints`` None: only the type is
    checked (``drives`` is returned as given).  A model gets its drives at construction
    (``RobotModel.from_urdf(..., drives=)``) or as a new model (``RobotModel.with_drives``)."""
    if drives is not None and not isinstance(drives, (Drives, str, os.PathLike)):
        raise SpecError(f"drives: got {type(drives).__name__}, expected a Drives, a drives TOML path or None")
    if drives is None or joints is None:
        return drives
    _names(joints, "joints")
    if not isinstance(drives, Drives):
        drives = load_drives(drives, joints)
    if list(drives.joints) != list(joints):
        drives = Drives(list(joints), drives.transmissions, drives.values, drives.origin)
    return drives

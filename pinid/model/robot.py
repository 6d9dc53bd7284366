"""Load a fixed-base URDF into a Pinocchio model: active joints, locked joints, limits, parameter names.

Conventions: SI units and radians.  Joint coordinates ``q`` are one number per active joint (the angle
for revolute and continuous joints, the displacement for prismatic ones), whatever Pinocchio's own
configuration layout is.  Standard inertial parameters per body are Pinocchio's
``[m, mx, my, mz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz]`` about the joint frame, named ``<joint>.<name>``.
"""

from __future__ import annotations

import contextlib
import copy
import importlib
import io
import numbers
import os
import sys
import tempfile
import warnings
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from collections.abc import Callable, Iterator, Mapping, Sequence

import numpy as np
import pinocchio as pin

from pinid.checks import as_floats, as_state, as_states, as_vector, count, number, same_length
from pinid.errors import JointError, ModelError, ModelWarning
from pinid.model.bundled import resolve_robot
from pinid.model.terms import Stribeck
from pinid.model.urdf import UrdfDocument

#: Names of the 10 standard inertial parameters of a body, in Pinocchio's order.
INERTIAL_NAMES: tuple[str, ...] = ("m", "mx", "my", "mz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz")

#: Tolerance of the inertia checks, relative to the body's trace of inertia [kg·m²] (CAD rounding).
INERTIA_TOL = 1e-6
_UNBOUNDED = 1e10  # |limit| above this is treated as no limit
#: Builders of the bases other than "fixed", by name: ``(fixed model, URDF text, path) -> model``; each
#: module of :data:`BASE_MODULES` registers its own when it loads.
BASE_BUILDERS: dict[str, Callable] = {}
#: The module that builds each base other than "fixed", loaded on first use (a plug-in: the module imports
#: this one, so this one names it instead of importing it).
BASE_MODULES: dict[str, str] = {"floating": "pinid.model.floating"}


def _check_mimics(document: UrdfDocument, active: Sequence[str], path: Path) -> None:
    """Refuse an active joint that mimics another (Pinocchio would treat it as independent); a locked one is fine."""
    for name, mimicked in document.mimic_joints().items():
        if name in active:
            raise ModelError(
                f"{path}: mimic joints are not supported: joint '{name}' mimics "
                f"'{mimicked}'; expected independent joints (lock it with --lock)"
            )


@contextlib.contextmanager
def _captured_stderr() -> Iterator[io.StringIO]:
    """Capture what C++ code (urdfdom) prints on file descriptor 2, so errors stay one line."""
    out = io.StringIO()
    try:
        fd = sys.stderr.fileno()
    except (AttributeError, ValueError, io.UnsupportedOperation):
        yield out
        return
    sys.stderr.flush()
    saved = os.dup(fd)
    with tempfile.TemporaryFile(mode="w+b") as tmp:
        os.dup2(tmp.fileno(), fd)
        try:
            yield out
        finally:
            os.dup2(saved, fd)
            os.close(saved)
            tmp.seek(0)
            out.write(tmp.read().decode("utf-8", "replace"))


@dataclass(frozen=True)
class JointInfo:
    """One active joint: name, kind and limits [rad, rad/s, N·m] (or [m, m/s, N] for prismatic)."""

    name: str
    kind: str  # "revolute", "continuous" or "prismatic"
    lower: float
    upper: float
    velocity: float
    effort: float


#: A joint velocity limit above this [rad/s or m/s] is a URDF's placeholder (the iCub's: 50000), not a limit:
#: random states (base parameters) then draw speeds as for a joint without one.
VELOCITY_PLACEHOLDER = 100.0


class RobotModel:
    """A fixed-base serial (or tree) robot with one degree of freedom per active joint.

    Build it with :meth:`from_urdf`.  ``pin_model`` is the (reduced) Pinocchio model; its armature,
    damping and friction are zero so that ``rnea`` is the rigid-body torque only; the joint friction
    read from the URDF ``<dynamics>`` tags is kept in ``coulomb`` [N·m] and ``viscous`` [N·m·s/rad].
    ``base`` is "fixed" (a floating base is :class:`pinid.model.floating.FloatingRobotModel`).

    A model is built once with everything it needs: its ``drives`` (:class:`pinid.model.drives.Drives` or
    None) and the per-run settings of its terms (``settings``, ``{setting name: value}``, e.g. ``stribeck``
    shapes ``{term: pinid.model.terms.Stribeck}`` and the wearer's ``passive_exponents``; a term names the
    setting it reads, :attr:`pinid.model.terms.Term.setting`) are given at construction and read-only
    afterwards (:meth:`setting`); :meth:`with_drives`, :meth:`with_setting`, :meth:`with_stribeck` and
    :meth:`with_passive_exponents` return a new model.
    ``continuous``: the indices of the continuous joints (Pinocchio's cos/sin coordinates).
    """

    base = "fixed"

    #: True when the model was loaded with ``repair_inertia`` (saved with it, so a saved model loads back).
    repair_inertia: bool = False

    def __init__(
        self,
        pin_model: pin.Model,
        joints: Sequence[JointInfo],
        *,
        coulomb: np.ndarray,
        viscous: np.ndarray,
        urdf_path: Path | None = None,
        urdf_text: str | None = None,
        locked: Mapping[str, float] | None = None,
        drives=None,
        urdf_document: UrdfDocument | None = None,
        settings: Mapping[str, object] | None = None,
    ) -> None:
        self.pin_model = pin_model
        self.joints: tuple[JointInfo, ...] = tuple(joints)
        self.coulomb = np.asarray(coulomb, dtype=float)
        self.viscous = np.asarray(viscous, dtype=float)
        self.urdf_path = urdf_path
        self.urdf_text = urdf_document.text if urdf_document is not None else urdf_text
        self._urdf_document = urdf_document
        self.locked = dict(locked or {})
        self._drives = drives  # the robot's transmissions (pinid.model.drives.Drives) when it has any
        # setting name → value, a private copy (read through .setting): "stribeck" {term: Stribeck},
        # "passive_exponents" {anatomical joint: (terms, 4) exponent coefficients} (pinid.wearer.passive), …
        self._settings: dict[str, object] = {}
        for name, value in (settings or {}).items():
            self._settings = _with_setting(self._settings, name, value)
        self._data = pin_model.createData()
        self._continuous = tuple(i for i, j in enumerate(self.joints) if j.kind == "continuous")
        self._idx_q = [pin_model.joints[i + 1].idx_q for i in range(len(self.joints))]

    def __getstate__(self) -> dict:
        """Pickled without Pinocchio's work data (rebuilt on loading; pin 4.0's ``Data`` cannot be unpickled)."""
        state = dict(self.__dict__)
        state.pop("_data", None)
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._data = self.pin_model.createData()

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_urdf(
        cls,
        urdf: str | os.PathLike,
        *,
        joints: Sequence[str] | None = None,
        locked: Mapping[str, float] | None = None,
        repair_inertia: bool = False,
        base: str = "fixed",
        drives=None,
    ) -> "RobotModel":
        """Load a URDF file, a bundled robot name (``exo_leg``) or an example-robot-data name (``panda``).

        ``joints``: names of the active joints (default: every movable joint not in ``locked`` and not a
        mimic joint — a ``<mimic>`` joint, e.g. a gripper's second finger, is locked like an inactive joint
        unless listed in ``joints``, where it is refused).
        ``repair_inertia``: a body whose rotational inertia is not physical (a negative principal moment, or
        one larger than the sum of the other two) is refused by default; with True it is replaced by the
        nearest physical one (:func:`nearest_physical_inertia`) with a :class:`~pinid.errors.ModelWarning`
        naming the body, and the repaired values are the model's (nominal, prior) parameters.
        ``locked``: joints held fixed at a value [rad or m]; other inactive joints are held at 0 (or at
        the middle of their range when 0 is outside it).  The URDF's ``<transmission>`` elements become
        ``drives`` (:mod:`pinid.model.drives`) unless ``drives`` (a :class:`~pinid.model.drives.Drives` or a
        drives TOML path) replaces them.  ``base``: "fixed" (the root link bolted to the world) or
        "floating" (on a free flyer: :class:`pinid.model.floating.FloatingRobotModel`, docs/floating-base.md).
        """
        if base != "fixed" and base not in BASE_BUILDERS:
            if not isinstance(base, str) or base not in BASE_MODULES:
                raise ModelError(f"base={base!r}, expected one of: fixed, {', '.join(BASE_MODULES)}")
            importlib.import_module(BASE_MODULES[base])  # registers its builder
        if not isinstance(urdf, (str, os.PathLike)):
            raise ModelError(f"urdf: got {type(urdf).__name__}, expected a URDF path or a robot name")
        if joints is not None and (isinstance(joints, str) or not all(isinstance(j, str) for j in joints)):
            raise JointError(f"joints {joints!r}: expected a list of joint names")
        if locked is not None and (
            not isinstance(locked, Mapping)
            or not all(isinstance(v, numbers.Real) and not isinstance(v, bool) for v in locked.values())
        ):
            raise JointError(f"locked {locked!r}: expected {{joint name: value [rad or m]}}")
        from pinid.model.drives import Drives, as_drives, urdf_transmissions

        as_drives(drives, None)  # a wrong type fails before the URDF is read
        path, preset_locked = resolve_robot(urdf)
        document = UrdfDocument.read(path)
        text = document.text
        with _captured_stderr() as printed:
            try:
                full = pin.buildModelFromXML(text)
                failure = None
            except Exception as exc:  # noqa: BLE001 - Pinocchio raises plain RuntimeError/ValueError
                failure = exc
        said = [ln.strip() for ln in printed.getvalue().splitlines() if ln.strip().startswith("Error:")]
        if failure is None and said:  # urdfdom drops what it cannot parse (e.g. a NaN mass) and says so
            raise ModelError(f"{path}: not a valid URDF ({said[0][len('Error:') :].strip()})")
        if failure is not None:
            msg = said[0][len("Error:") :].strip() if said else (str(failure).strip().splitlines() or [""])[0]
            raise ModelError(f"{path}: not a valid URDF ({msg or type(failure).__name__})") from None
        lock = {k: v for k, v in preset_locked.items() if k not in (joints or ())}
        lock.update(locked or {})
        names = [full.names[i] for i in range(1, full.njoints)]
        for jid in range(1, full.njoints):
            j = full.joints[jid]
            if j.nv != 1:
                raise ModelError(
                    f"{path}: joint '{full.names[jid]}' has {j.nv} degrees of freedom "
                    "(floating or planar); pinid supports fixed-base robots with 1-DOF joints"
                )
        if not names:
            raise ModelError(f"{path}: no movable joint, expected at least one revolute, continuous or prismatic joint")
        for n in list(lock) + list(joints or []):
            if n not in names:
                raise JointError(f"joint '{n}' is not in {path.name} (its joints: {', '.join(names)})")
        mimics = set(document.mimic_joints()) if joints is None else set()
        chosen = set(lock)  # locked by the user or the robot's preset (panda's fingers), before pinid adds its own
        active = list(joints) if joints is not None else [n for n in names if n not in lock and n not in mimics]
        if not active:
            raise ModelError(f"{path}: every movable joint is locked, expected at least one active joint")
        for n in active:
            if n in lock:
                raise ModelError(f"joint '{n}' is both active and locked, expected one or the other")
        _check_mimics(document, active, path)
        infos_full = {n: _joint_info(full, full.getJointId(n)) for n in names}
        q_ref = pin.neutral(full)
        to_lock = []
        for n in names:
            if n in active:
                continue
            info = infos_full[n]
            value = lock.get(n)
            if value is None:
                value = 0.0 if info.lower <= 0.0 <= info.upper else 0.5 * (info.lower + info.upper)
            elif not (info.lower - 1e-12 <= value <= info.upper + 1e-12):
                raise ModelError(
                    f"joint '{n}': locked value {value:g} is outside its limits [{info.lower:g}, {info.upper:g}]"
                )
            lock[n] = float(value)
            jid = full.getJointId(n)
            _set_coordinate(q_ref, full.joints[jid], info.kind, value)
            to_lock.append(jid)
        silent = sorted(n for n in mimics if n in lock and n not in chosen)  # locked by pinid, not the user or a preset
        if silent:
            followed = document.mimic_joints()
            warnings.warn(
                f"{path.name}: mimic joint(s) locked: "
                + ", ".join(f"'{n}' (mimics '{followed[n]}') at {lock[n]:g}" for n in silent)
                + "; pinid identifies independent joints only, so their motion and torque are not in the model "
                f"(lock them yourself, --lock {silent[0]}=VALUE, to choose the value and silence this)",
                ModelWarning,
                stacklevel=2,
            )
        # keep the URDF friction of the active joints before reducing
        coul = np.array([full.friction[full.joints[full.getJointId(n)].idx_v] for n in active])
        visc = np.array([full.damping[full.joints[full.getJointId(n)].idx_v] for n in active])
        _check_inertias(full, path, repair=repair_inertia)
        model = pin.buildReducedModel(full, to_lock, q_ref) if to_lock else full
        # order of the reduced model's joints follows the URDF tree, not the user's list
        order = [model.names[i] for i in range(1, model.njoints)]
        if order != active:
            perm = [active.index(n) for n in order]
            coul, visc, active = coul[perm], visc[perm], order
        model.armature[:] = 0.0
        model.damping[:] = 0.0
        model.friction[:] = 0.0
        infos = [_joint_info(model, model.getJointId(n)) for n in active]
        if drives is not None:
            drives = as_drives(drives, active)
        else:
            transmissions = urdf_transmissions(document, active, path.name)
            drives = Drives(list(active), transmissions, {}, f"{path.name} <transmission>") if transmissions else None
        robot = cls(
            model,
            infos,
            coulomb=coul,
            viscous=visc,
            urdf_path=path,
            locked={k: v for k, v in lock.items() if k not in active},
            drives=drives,
            urdf_document=document,
        )
        if base != "fixed":
            robot = BASE_BUILDERS[base](robot, text, path)
        if repair_inertia:
            robot.repair_inertia = True
        return robot

    # ------------------------------------------------------------------ settings (read-only: built once)
    @property
    def drives(self):
        """The robot's transmissions (:class:`pinid.model.drives.Drives`), None when it has none."""
        return self._drives

    @property
    def settings(self) -> Mapping[str, object]:
        """``{setting name: value}``: every per-run setting of the model's terms (read-only, as :meth:`setting`
        gives each one; a setting the model does not set is absent)."""
        return MappingProxyType({name: self.setting(name) for name in self._settings})

    def setting(self, name: str, default: object = None) -> object:
        """The value of the term setting ``name`` (a :attr:`pinid.model.terms.Term.setting`), ``default`` when
        the model does not set it; a mapping is given as a read-only view."""
        if not isinstance(name, str):
            raise ModelError(f"name: got {type(name).__name__}, expected a setting name (str)")
        value = self._settings.get(name, default)
        return MappingProxyType(value) if isinstance(value, dict) else value

    @property
    def stribeck(self) -> Mapping:
        """``{term: pinid.model.terms.Stribeck}``: the Stribeck shapes the model sets (read-only; a term
        absent here has the default shape, :func:`pinid.model.terms.stribeck`)."""
        return self.setting("stribeck", MappingProxyType({}))

    @property
    def passive_exponents(self) -> Mapping:
        """``{anatomical joint: (terms, 4) exponent coefficients}`` of the wearer's passive moments
        (:mod:`pinid.wearer.passive`; read-only, empty for the published ones)."""
        return self.setting("passive_exponents", MappingProxyType({}))

    @property
    def continuous(self) -> tuple[int, ...]:
        """Indices of the continuous joints (their Pinocchio coordinates are cos, sin); empty when none."""
        return self._continuous

    def _copy_with(self, **attributes) -> "RobotModel":
        """A shallow copy of this model with some attributes replaced (the construction of with_*)."""
        out = copy.copy(self)
        for key, value in attributes.items():
            setattr(out, key, value)
        return out

    def with_urdf_path(self, path: str | os.PathLike | None) -> "RobotModel":
        """A copy of this model that names ``path`` as the URDF it came from (a saved model rebuilt from the
        URDF text it kept names the original file; this model is left as it is)."""
        if path is not None and not isinstance(path, (str, os.PathLike)):
            raise ModelError(f"path: got {type(path).__name__}, expected a URDF path or None")
        return self._copy_with(urdf_path=None if path is None else Path(path))

    def with_drives(self, drives) -> "RobotModel":
        """A copy of this model with other drives: a :class:`~pinid.model.drives.Drives`, a drives TOML path,
        or None for none (this model is left as it is)."""
        from pinid.model.drives import as_drives

        return self._copy_with(_drives=as_drives(drives, self.joint_names))

    def with_setting(self, name: str, value: object) -> "RobotModel":
        """A copy of this model whose term setting ``name`` is ``value`` (replacing its own; None or an empty
        mapping removes it; this model is left as it is).  The terms that declare the setting
        (:attr:`pinid.model.terms.Term.setting`) read it through ``Motion.robot`` and save it with the model."""
        if not isinstance(name, str) or not name:
            raise ModelError(f"name: got {name!r}, expected a setting name (str)")
        return self._copy_with(_settings=_with_setting(self._settings, name, value))

    def with_stribeck(self, settings: Mapping) -> "RobotModel":
        """A copy of this model with these Stribeck shapes ``{term: Stribeck}`` on top of its own (this model
        is left as it is)."""
        shapes = settings.values() if isinstance(settings, Mapping) else ()
        if not isinstance(settings, Mapping) or not all(isinstance(v, Stribeck) for v in shapes):
            raise ModelError(f"settings: got {type(settings).__name__}, expected {{term: pinid.model.terms.Stribeck}}")
        return self.with_setting("stribeck", {**self.stribeck, **settings})

    def with_passive_exponents(self, exponents: Mapping) -> "RobotModel":
        """A copy of this model whose wearer passive-moment exponents are ``exponents`` (replacing its own;
        ``{}`` for the published ones; checked by :func:`pinid.wearer.passive.check_exponents`)."""
        if not isinstance(exponents, Mapping):
            raise ModelError(
                f"exponents: got {type(exponents).__name__}, expected {{anatomical joint: (terms, 4) array}}"
            )
        return self.with_setting("passive_exponents", exponents)

    # ------------------------------------------------------------------ description
    @property
    def urdf_document(self) -> UrdfDocument | None:
        """The URDF this model was built from, read once (:mod:`pinid.model.urdf`); None without URDF text."""
        if self._urdf_document is None and self.urdf_text:
            self._urdf_document = UrdfDocument.from_text(self.urdf_text, str(self.urdf_path or self.name))
        return self._urdf_document

    @property
    def name(self) -> str:
        """The robot's name from the URDF."""
        return self.pin_model.name

    @property
    def nv(self) -> int:
        """Number of active joints."""
        return len(self.joints)

    @property
    def joint_names(self) -> list[str]:
        """Names of the active joints, in model order."""
        return [j.name for j in self.joints]

    @property
    def lower(self) -> np.ndarray:
        """Lower position limits [rad or m] (−inf where none)."""
        return np.array([j.lower for j in self.joints])

    @property
    def upper(self) -> np.ndarray:
        """Upper position limits [rad or m] (+inf where none)."""
        return np.array([j.upper for j in self.joints])

    @property
    def velocity_limit(self) -> np.ndarray:
        """Velocity limits [rad/s or m/s] (inf where none)."""
        return np.array([j.velocity for j in self.joints])

    @property
    def effort_limit(self) -> np.ndarray:
        """Effort limits [N·m or N] (inf where none)."""
        return np.array([j.effort for j in self.joints])

    @property
    def motor_names(self) -> list[str]:
        """Names of the motors of the robot's drives (empty without drives)."""
        return list(self.drives.motor_names) if self.drives is not None else []

    def joint_index(self, name: str) -> int:
        """Index of an active joint by name; JointError if unknown."""
        try:
            return self.joint_names.index(name)
        except ValueError:
            raise JointError(
                f"joint '{name}' is not an active joint (active joints: {', '.join(self.joint_names)})"
            ) from None

    @property
    def inertial_names(self) -> list[str]:
        """Names ``<joint>.<param>`` of the 10·nv standard inertial parameters."""
        return [f"{j}.{p}" for j in self.joint_names for p in INERTIAL_NAMES]

    def inertial_parameters(self) -> np.ndarray:
        """Standard inertial parameters of the model (10 per body, about the joint frame)."""
        return np.concatenate(
            [self.pin_model.inertias[i].toDynamicParameters() for i in range(1, self.pin_model.njoints)]
        )

    def with_inertial_parameters(self, theta: np.ndarray, *, coulomb=None, viscous=None) -> "RobotModel":
        """A copy of this model with other inertial parameters (and optionally friction)."""
        theta = as_vector(theta, "theta", 10 * self.nv, f"inertial parameters (10 per joint of {self.joint_names})")
        coulomb, viscous = (
            None if v is None else as_state(v, name, self.joint_names)
            for name, v in (("coulomb", coulomb), ("viscous", viscous))
        )
        model = pin.Model(self.pin_model)
        for i in range(self.nv):
            model.inertias[i + 1] = pin.Inertia.FromDynamicParameters(theta[10 * i : 10 * i + 10])
        out = RobotModel(
            model,
            self.joints,
            coulomb=self.coulomb if coulomb is None else coulomb,
            viscous=self.viscous if viscous is None else viscous,
            urdf_path=self.urdf_path,
            urdf_text=self.urdf_text,
            locked=self.locked,
            drives=self.drives,
            urdf_document=self._urdf_document,
            settings=self.settings,
        )
        out.repair_inertia = self.repair_inertia  # its URDF text still needs the repair to load
        return out

    # ------------------------------------------------------------------ kinematics helpers
    def configuration(self, q: np.ndarray) -> np.ndarray:
        """Pinocchio configuration vector for joint coordinates ``q`` (nv,) [rad or m]."""
        return self._pin_configuration(as_state(q, "q", self.joint_names))

    def _pin_configuration(self, q: np.ndarray) -> np.ndarray:
        """:meth:`configuration` of a checked ``q`` (nv,) floats (no check: for loops over checked samples)."""
        if not self._continuous:
            return q
        out = np.empty(self.pin_model.nq)
        for i, j in enumerate(self.joints):
            _set_coordinate(out, self.pin_model.joints[i + 1], j.kind, q[i])
        return out

    def rnea(self, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> np.ndarray:
        """Rigid-body inverse dynamics [N·m] for one sample (nv,) or many (N, nv); no friction."""
        one = np.ndim(q) == 1
        q, dq, ddq = (as_states(x, n, self.joint_names) for n, x in (("q", q), ("dq", dq), ("ddq", ddq)))
        same_length(q=q, dq=dq, ddq=ddq)
        if one:
            return pin.rnea(self.pin_model, self._data, self.configuration(q[0]), dq[0], ddq[0]).copy()
        conf = self._pin_configuration  # the samples are checked above (a check per sample tripled the time)
        return np.array([pin.rnea(self.pin_model, self._data, conf(a), b, c).copy() for a, b, c in zip(q, dq, ddq)])

    def random_states(
        self, n: int, rng: np.random.Generator, *, acceleration: float = 5.0
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``n`` random (q, dq, ddq) inside the position and velocity limits; |ddq| ≤ ``acceleration``.  A velocity
        limit that is missing, or above :data:`VELOCITY_PLACEHOLDER` (a URDF's placeholder), draws |dq| ≤ 2 rad/s."""
        n = count(n, "n", low=1)
        acceleration = number(acceleration, "acceleration", low=0)
        lo = np.where(np.isfinite(self.lower), self.lower, -np.pi)
        hi = np.where(np.isfinite(self.upper), self.upper, np.pi)
        v = self.velocity_limit
        # a placeholder limit (the iCub's URDF says 50000 rad/s) counts as none: random speeds of that size make
        # the centripetal columns 1e10 × the gravity ones, and base_parameters drops the masses as zero columns
        vmax = np.where(np.isfinite(v) & (v > 0) & (v <= VELOCITY_PLACEHOLDER), v, 2.0)
        q = rng.uniform(lo, hi, size=(n, self.nv))
        dq = rng.uniform(-vmax, vmax, size=(n, self.nv))
        ddq = rng.uniform(-acceleration, acceleration, size=(n, self.nv))
        return q, dq, ddq

    def __repr__(self) -> str:
        return f"RobotModel({self.name!r}, joints={self.joint_names})"


def _with_setting(settings: dict[str, object], name: str, value: object) -> dict[str, object]:
    """A copy of ``settings`` whose ``name`` is ``value`` (a mapping copied into a dict); None or an empty
    mapping removes it (a setting that is not set)."""
    out = dict(settings)
    if isinstance(value, Mapping):
        value = dict(value)
    if value is None or (isinstance(value, dict) and not value):
        out.pop(name, None)
    else:
        out[name] = value
    return out


def as_robot(model) -> RobotModel:
    """``model`` if it is a RobotModel; ModelError naming what was expected otherwise."""
    if not isinstance(model, RobotModel):
        raise ModelError(
            f"model: got {type(model).__name__}, expected a pinid RobotModel "
            "(pinid.RobotModel.from_urdf(path or robot name))"
        )
    return model


#: Largest body mass [kg] accepted from a URDF; anything heavier is a unit or typing error.
MAX_BODY_MASS = 1e6


def nearest_physical_inertia(inertia: np.ndarray, iterations: int = 200) -> np.ndarray:
    """The physical rotational inertia [kg·m²] nearest to ``inertia`` (3×3, about the centre of mass) in the
    Frobenius norm: the same principal axes, the principal moments projected (Euclidean) onto the cone of
    the triangle inequalities ``e_i ≤ e_j + e_k`` (which imply ``e_i ≥ 0``) by Dykstra's alternating
    projections onto its three half-spaces.  (For a set of symmetric matrices defined by their eigenvalues
    only, the nearest matrix keeps the eigenvectors, so this is the nearest physical inertia.)"""
    inertia = as_floats(inertia, "inertia")
    if inertia.shape != (3, 3):
        raise ModelError(f"inertia: shape {inertia.shape}, expected a 3×3 rotational inertia [kg·m²]")
    e, V = np.linalg.eigh(0.5 * (inertia + inertia.T))
    normals = [np.array(n, dtype=float) / np.sqrt(3.0) for n in ((1, -1, -1), (-1, 1, -1), (-1, -1, 1))]
    x, corr = e.copy(), [np.zeros(3) for _ in normals]
    for _ in range(iterations):
        for k, n in enumerate(normals):  # half-space n·x ≤ 0
            y = x + corr[k]
            x = y - max(float(n @ y), 0.0) * n
            corr[k] = y - x
    x = np.maximum(x, 0.0)
    return (V * x) @ V.T


def _check_inertias(model: pin.Model, path: Path, *, repair: bool = False) -> None:
    """Refuse inertial values that are not numbers, negative masses, absurdly large ones, and rotational
    inertias that no body has: principal moments (about the centre of mass) below zero, or one larger than
    the sum of the other two (triangle inequality), both beyond :data:`INERTIA_TOL` × trace.  ``repair``:
    replace such a rotational inertia by :func:`nearest_physical_inertia` (in ``model``) with a
    :class:`~pinid.errors.ModelWarning` instead."""
    for jid in range(1, model.njoints):
        p = model.inertias[jid].toDynamicParameters()
        name = model.names[jid]
        if not np.all(np.isfinite(p)):
            raise ModelError(f"{path}: the body moved by joint '{name}' has a NaN or infinite <inertial> value")
        if p[0] < 0 or p[0] > MAX_BODY_MASS:
            raise ModelError(
                f"{path}: the body moved by joint '{name}' has mass {p[0]:.3g} kg; expected 0 to {MAX_BODY_MASS:.0e} kg"
            )
        e = np.linalg.eigvalsh(model.inertias[jid].inertia)
        tol = INERTIA_TOL * abs(e).sum() + 1e-12
        if e[0] < -tol or e[0] + e[1] < e[2] - tol:
            why = "a negative principal moment" if e[0] < -tol else "one moment larger than the sum of the other two"
            if repair:
                body = model.inertias[jid]
                fixed = nearest_physical_inertia(body.inertia)
                model.inertias[jid] = pin.Inertia(body.mass, body.lever, fixed)
                f = np.linalg.eigvalsh(fixed)
                warnings.warn(
                    f"{path.name}: the body moved by joint '{name}' has principal moments {e[0]:.4g}, {e[1]:.4g}, "
                    f"{e[2]:.4g} kg·m² ({why}); repaired to the nearest physical inertia {f[0]:.4g}, {f[1]:.4g}, "
                    f"{f[2]:.4g} kg·m² (same mass, centre of mass and axes; --repair-inertia)",
                    ModelWarning,
                    stacklevel=4,
                )
                continue
            raise ModelError(
                f"{path}: the body moved by joint '{name}' has principal moments of inertia "
                f"{e[0]:.3g}, {e[1]:.3g}, {e[2]:.3g} kg·m² ({why}); expected a physical inertia "
                "(moments >= 0, each at most the sum of the other two; --repair-inertia loads the nearest one)"
            )


def _joint_info(model: pin.Model, jid: int) -> JointInfo:
    j = model.joints[jid]
    short = j.shortname()
    if j.nq == 2:
        kind, lo, hi = "continuous", -np.inf, np.inf
    else:
        kind = "prismatic" if "P" in short.replace("JointModel", "")[:1] else "revolute"
        lo, hi = float(model.lowerPositionLimit[j.idx_q]), float(model.upperPositionLimit[j.idx_q])
        lo = -np.inf if lo < -_UNBOUNDED else lo
        hi = np.inf if hi > _UNBOUNDED else hi
        if lo == hi:  # CAD exporters write <limit lower="0" upper="0"/> for "not given"
            lo, hi = -np.inf, np.inf
    vel = float(model.velocityLimit[j.idx_v])
    eff = float(model.effortLimit[j.idx_v])
    return JointInfo(  # a zero velocity or effort limit is read as "not given" too
        name=model.names[jid],
        kind=kind,
        lower=lo,
        upper=hi,
        velocity=np.inf if (vel > _UNBOUNDED or vel <= 0) else vel,
        effort=np.inf if (eff > _UNBOUNDED or eff <= 0) else eff,
    )


def _set_coordinate(q_pin: np.ndarray, joint, kind: str, value: float) -> None:
    if kind == "continuous":
        q_pin[joint.idx_q] = np.cos(value)
        q_pin[joint.idx_q + 1] = np.sin(value)
    else:
        q_pin[joint.idx_q] = value

"""The identified model for controller code: inverse dynamics, mass matrix, Coriolis, gravity, friction.

A Pinocchio model carries the identified inertial parameters; the terms (:mod:`pinid.model.terms`:
Coulomb and viscous friction, armature, constant offset, joint side and, through the drives' ``G``,
motor side) are added on top.  With the classic joint terms the equation of motion is::

    τ = (M(q) + diag(armature))·ddq + C(q, dq)·dq + g(q) + friction(dq) + offset
    friction(dq) = fc·sign(dq) + fv·dq

and a motor term adds ``Gᵀ·τ_motor(G·q, G·dq, G·ddq)`` (rotor inertia ``Gᵀ·diag(Im)·G`` in ``M``).

All methods take one sample (``(nv,)`` arrays) or, for ``inverse_dynamics``, ``gravity`` and
``friction``, also ``(N, nv)`` batches.  Units: q [rad or m], dq [rad/s], ddq [rad/s²], τ [N·m].
Terms not in the identified model are zero.

Any standard parameter set with the identified base parameters gives exactly the same τ, M, C and g;
``physically_consistent`` says whether this one is consistent (then M(q) is positive definite).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pinocchio as pin

from pinid.checks import as_floats, as_state, as_states, same_length
from pinid.errors import ModelError, SpecError
from pinid.io import read_json, write_json
from pinid.model import terms as _terms
from pinid.model.export import identified_urdf
from pinid.model.physical import check_consistency
from pinid.model.regressor import JointTerms, parameter_names
from pinid.model.robot import RobotModel, as_robot
from pinid.model.terms import as_terms
from pinid.model.serialize import robot_from_dict, robot_to_dict

_FORMAT = "pinid.identified_model"


class IdentifiedModel:
    """A robot model with identified parameters (see the module text).

    Build it from an identification result (``pinid.identify(...).model``), from a standard parameter
    vector (``IdentifiedModel(robot, terms, theta)``), or load a saved one (:meth:`load`).
    """

    def __init__(self, robot: RobotModel, terms: JointTerms | None, theta: np.ndarray, *,
                 physically_consistent: bool | None = None, meta: dict | None = None) -> None:
        robot, terms = as_robot(robot), as_terms(terms)
        theta = as_floats(theta, "theta", finite=False).reshape(-1)
        nv, nt = robot.nv, _terms.count(robot, terms)
        _terms.robot_layout(robot, terms)  # motor terms need drives
        if theta.shape != (10 * nv + nt,):
            raise ModelError(f"expected {10 * nv + nt} standard parameters for {robot.name} with terms "
                             f"{terms.names}, got {theta.size}")
        if not np.all(np.isfinite(theta)):
            raise ModelError("identified parameters contain NaN or infinite values")
        self._values = _terms.values(robot, terms, theta[10 * nv:])
        self.fc = self._values["fc"]
        self.fv = self._values["fv"]
        self.offset = self._values["offset"]
        self.armature = self._values["armature"]
        self.terms = terms
        self.theta = theta.copy()
        self.nominal_robot = robot
        self.robot = robot.with_inertial_parameters(theta[: 10 * nv], coulomb=self.fc, viscous=self.fv)
        self.pin_model: pin.Model = self.robot.pin_model
        self.pin_data = self.pin_model.createData()
        if physically_consistent is None:
            physically_consistent = check_consistency(theta, robot.joint_names, terms.names, robot.motor_names).consistent
        self.physically_consistent = bool(physically_consistent)
        self.meta = dict(meta or {})
        self._plain = not robot._continuous

    # ---------------------------------------------------------------- description
    @property
    def nv(self) -> int:
        """Number of joints."""
        return self.robot.nv

    @property
    def joint_names(self) -> list[str]:
        """Joint names, in the order of q."""
        return self.robot.joint_names

    @property
    def standard_parameters(self) -> dict[str, float]:
        """``{name: value}`` of the standard parameters."""
        return dict(zip(parameter_names(self.robot, self.terms), map(float, self.theta)))

    def _q(self, q):
        q = as_state(q, "q", self.joint_names)
        return q if self._plain else self.robot.configuration(q)

    # ---------------------------------------------------------------- dynamics
    def _term_torque(self, q, dq, ddq, keep) -> np.ndarray:
        """Torque (N, nv) of the selected terms for which ``keep(term)`` holds."""
        sel = JointTerms(names=[t.name for t in self.terms.joint + self.terms.motor if keep(t)])
        theta = np.array([self._values[p.term.name][p.index] for p in _terms.robot_layout(self.robot, sel)])
        return _terms.torque(self.robot, sel, theta, q, dq, ddq)

    def friction(self, dq: np.ndarray) -> np.ndarray:
        """Friction torque [N·m] at joint velocities ``dq`` (one sample or a batch): the velocity-dependent
        terms, joint side (fc·sign(dq) + fv·dq) plus ``Gᵀ·`` motor side."""
        dq = as_floats(dq, "dq")
        one, dq = dq.ndim == 1, as_states(dq, "dq", self.joint_names)
        zero = np.zeros_like(dq)
        tau = self._term_torque(zero, dq, zero, lambda t: not t.inertia and t.suffix != "offset")
        return tau[0] if one else tau

    def gravity(self, q: np.ndarray) -> np.ndarray:
        """Gravity torque g(q) [N·m] (one sample or a batch)."""
        q = as_floats(q, "q")
        if q.ndim == 2:
            return np.array([self.gravity(x) for x in as_states(q, "q", self.joint_names)])
        return pin.computeGeneralizedGravity(self.pin_model, self.pin_data, self._q(q)).copy()

    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        """Joint-space mass matrix M(q) + diag(armature) [kg·m²], symmetric (nv, nv)."""
        M = pin.crba(self.pin_model, self.pin_data, self._q(q)).copy()
        M = np.triu(M) + np.triu(M, 1).T
        M += self.term_inertia
        return M

    @property
    def term_inertia(self) -> np.ndarray:
        """Constant inertia of the terms (nv, nv) [kg·m²]: diag(armature) + Gᵀ·diag(motor armature)·G."""
        out = np.zeros((self.nv, self.nv))
        for t in self.terms.joint + self.terms.motor:
            if t.inertia:
                v = self._values[t.name]
                G = np.eye(self.nv) if t.space == "joint" else self.robot.drives.matrix
                out += G.T @ (v[:, None] * G)
        return out

    def coriolis(self, q: np.ndarray, dq: np.ndarray) -> np.ndarray:
        """Coriolis/centrifugal matrix C(q, dq) (nv, nv), with Ṁ − 2C skew-symmetric; C·dq is the torque."""
        dq = as_state(dq, "dq", self.joint_names)
        return pin.computeCoriolisMatrix(self.pin_model, self.pin_data, self._q(q), dq).copy()

    def inverse_dynamics(self, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> np.ndarray:
        """Joint torque τ [N·m] for the motion (q, dq, ddq): rigid body + armature + friction + offset."""
        q, dq, ddq = (as_floats(x, n) for n, x in (("q", q), ("dq", dq), ("ddq", ddq)))
        if q.ndim == 2:
            same_length(q=q, dq=dq, ddq=ddq)
            return np.array([self.inverse_dynamics(a, b, c) for a, b, c in zip(q, dq, ddq)])
        dq, ddq = as_state(dq, "dq", self.joint_names), as_state(ddq, "ddq", self.joint_names)
        tau = pin.rnea(self.pin_model, self.pin_data, self._q(q), dq, ddq).copy()
        return tau + _terms.torque(self.robot, self.terms, self.theta[10 * self.nv:], q[None], dq[None], ddq[None])[0]

    def forward_dynamics(self, q: np.ndarray, dq: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """Joint acceleration ddq [rad/s²] under torque ``tau`` (solves the equation of motion)."""
        q, dq, tau = (as_state(x, n, self.joint_names) for n, x in (("q", q), ("dq", dq), ("tau", tau)))
        h = self.inverse_dynamics(q, dq, np.zeros(self.nv))
        return np.linalg.solve(self.mass_matrix(q), tau - h)

    # ---------------------------------------------------------------- files
    def to_dict(self) -> dict:
        """Plain-dict form with the URDF text, so that :meth:`from_dict` needs no other file."""
        from pinid import __version__  # the package's own attribute: set after its submodules load

        r = self.nominal_robot
        return {
            "format": _FORMAT, "version": 1, "pinid_version": __version__,
            "robot": robot_to_dict(r, self.terms),
            "standard_parameters": self.standard_parameters,
            "physically_consistent": self.physically_consistent,
            "meta": self.meta,
        }

    @classmethod
    def from_dict(cls, d: dict) -> "IdentifiedModel":
        """Inverse of :meth:`to_dict`."""
        if not isinstance(d, dict):
            raise SpecError(f"identified model: a {type(d).__name__}, expected a JSON object")
        if d.get("format") != _FORMAT:
            hint = (" — this is an identification (pinid identify's identification.json): read it with "
                    "pinid.Identification.load(path), its .model is the best method's IdentifiedModel"
                    if "methods" in d and "robot" in d else "")
            raise SpecError(f"not an identified model (format {d.get('format')!r}, expected {_FORMAT!r}){hint}")
        for key, kind in (("robot", dict), ("standard_parameters", dict), ("meta", (dict, type(None)))):
            if not isinstance(d.get(key), kind):
                raise SpecError(f"identified model: '{key}' is {type(d.get(key)).__name__}, expected "
                                f"{'a JSON object' if key != 'meta' else 'a JSON object or null'}")
        flag = d.get("physically_consistent")
        if flag is not None and not isinstance(flag, bool):
            raise SpecError(f"identified model: 'physically_consistent' is {flag!r}, expected true or false")
        robot, terms = robot_from_dict(d["robot"])
        names = parameter_names(robot, terms)
        values = d["standard_parameters"]
        missing = [n for n in names if n not in values]
        if missing:
            raise SpecError(f"identified model: missing parameter(s) {missing[:5]}")
        bad = [n for n in names if isinstance(values[n], bool) or not isinstance(values[n], (int, float))
               or not np.isfinite(values[n])]
        if bad:
            raise SpecError(f"identified model: parameter {bad[0]} is {values[bad[0]]!r}, expected a finite number")
        theta = np.array([float(values[n]) for n in names])
        # the stored flag is never trusted: consistency is checked again on the parameters themselves (a
        # stored false stays false: the run may have found the standard set off its base parameters)
        consistent = flag is not False and check_consistency(theta, robot.joint_names, terms.names,
                                                             robot.motor_names).consistent
        return cls(robot, terms, theta, physically_consistent=consistent, meta=d.get("meta"))

    def save(self, path: str | os.PathLike) -> Path:
        """Write as JSON (atomically)."""
        return write_json(path, self.to_dict())

    @classmethod
    def load(cls, path: str | os.PathLike) -> "IdentifiedModel":
        """Read a JSON file written by :meth:`save` (or by ``pinid identify``: ``model_<method>.json``)."""
        return cls.from_dict(read_json(path, "identified model"))

    def export_urdf(self, path: str | os.PathLike | None = None, *, force: bool = False) -> str:
        """The identified URDF text (see :func:`pinid.model.export.identified_urdf`); written to ``path`` when given."""
        return identified_urdf(self.nominal_robot, self.theta, self.terms, path, force=force,
                               comment=f"method {self.meta.get('method', '?')}")

    def export_drives(self, path: str | os.PathLike | None = None) -> str | None:
        """The drives TOML with the identified motor terms (:func:`pinid.model.export.identified_drives`), None
        without motor terms; written to ``path`` when given (read it back with ``--drives``)."""
        from pinid.model.export import identified_drives

        return identified_drives(self.nominal_robot, self.theta, self.terms, path,
                                 comment=f"method {self.meta.get('method', '?')}")

    def __repr__(self) -> str:
        return (f"IdentifiedModel({self.robot.name!r}, joints={self.joint_names}, terms={self.terms.names}, "
                f"physically_consistent={self.physically_consistent})")

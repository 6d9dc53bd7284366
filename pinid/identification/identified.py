"""The identified model for controller code: inverse dynamics, mass matrix, Coriolis, gravity, friction.

A Pinocchio model carries the identified inertial parameters; the terms (:mod:`pinid.model.terms`:
Coulomb and viscous friction, armature, constant offset, joint side and, through the drives' ``G``,
motor side) are added on top.  With the classic joint terms the equation of motion is::

    τ = (M(q) + diag(armature))·ddq + C(q, dq)·dq + g(q) + friction(dq) + offset
    friction(dq) = fc·sign(dq) + fv·dq

and a motor term adds ``Gᵀ·τ_motor(G·q, G·dq, G·ddq)`` (rotor inertia ``Gᵀ·diag(Im)·G`` in ``M``).

Every dynamics method takes one sample (``(nv,)`` arrays, returning (nv,) or (nv, nv)) or a batch
(``(N, nv)`` arrays, returning (N, nv) or (N, nv, nv)).  Units: q [rad or m], dq [rad/s], ddq [rad/s²],
τ [N·m].  Terms not in the identified model are zero.  :meth:`IdentifiedModel.derivatives` gives ∂τ/∂q and
∂τ/∂dq (RNEA derivatives plus the terms), :meth:`IdentifiedModel.forward_derivatives` those of ddq for
MPC; ``pin_model`` / ``pin_data`` reach the rest of Pinocchio (with the identified inertias; the terms
are pinid's own).

Any standard parameter set with the identified base parameters gives exactly the same τ, M, C and g;
``physically_consistent`` says whether this one is consistent (then M(q) is positive definite).
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pinocchio as pin

from pinid.checks import as_floats
from pinid.errors import DataError, ModelError, PinidError, SpecError
from pinid.io import read_json, write_json
from pinid.model import terms as _terms
from pinid.model.export import floating_urdf, identified_urdf
from pinid.model.physical import check_consistency
from pinid.model.regressor import parameter_names
from pinid.model.terms import TermSelection
from pinid.model.robot import RobotModel, as_robot
from pinid.model.terms import as_terms
from pinid.model.serialize import robot_from_dict, robot_to_dict

_FORMAT = "pinid.identified_model"


def _floating(robot: RobotModel) -> bool:
    return getattr(robot, "base", "fixed") == "floating"


def _bodies(robot: RobotModel) -> list[str]:
    """The moving bodies whose inertial parameters lead the standard vector: a floating robot's base first."""
    return robot.body_names if _floating(robot) else robot.joint_names


def _names(robot: RobotModel, terms: TermSelection) -> list[str]:
    """The standard parameters' names: :func:`~pinid.model.regressor.parameter_names` (with ``base.*`` first on a
    floating base)."""
    return parameter_names(robot, terms)


class IdentifiedModel:
    """A robot model with identified parameters (see the module text).

    Build it from an identification result (``pinid.identify(...).model``), from a standard parameter
    vector (``IdentifiedModel(robot, terms, theta)``), or load a saved one (:meth:`load`).
    """

    def __init__(
        self,
        robot: RobotModel,
        terms: TermSelection | None,
        theta: np.ndarray,
        *,
        physically_consistent: bool | None = None,
        meta: dict | None = None,
    ) -> None:
        robot, terms = as_robot(robot), as_terms(terms)
        theta = as_floats(theta, "theta", finite=False).reshape(-1)
        nv, floating = robot.nv, _floating(robot)
        layout = robot.bodies if floating else robot  # a floating robot's base body comes first, in terms too
        nt = _terms.term_count(layout, terms)
        _terms.robot_layout(robot, terms)  # motor terms need drives
        nb = 10 * (nv + floating)
        if theta.shape != (nb + nt,):
            raise ModelError(
                f"expected {nb + nt} standard parameters for {robot.name} with terms {terms.names}, got {theta.size}"
            )
        if not np.all(np.isfinite(theta)):
            raise ModelError("identified parameters contain NaN or infinite values")
        self._values = _terms.values(layout, terms, theta[nb:])
        if floating:  # the base's own terms (always 0: the free flyer has no friction) left out
            self._values = {k: np.asarray(v)[1:] for k, v in self._values.items()}
        self.fc = self._values["fc"]
        self.fv = self._values["fv"]
        self.offset = self._values["offset"]
        self.armature = self._values["armature"]
        self.terms = terms
        self.theta = theta.copy()
        self.nominal_robot = robot
        if floating:  # the free flyer's inertias too (exports, pin_model of the joints with the base held)
            robot = robot.with_floating_parameters(theta[:nb])
        self.robot = robot.with_inertial_parameters(theta[nb - 10 * nv : nb], coulomb=self.fc, viscous=self.fv)
        self.pin_model: pin.Model = self.robot.pin_model
        self.pin_data = self.pin_model.createData()
        if physically_consistent is None:
            physically_consistent = check_consistency(theta, _bodies(robot), terms.names, robot.motor_names).consistent
        self.physically_consistent = bool(physically_consistent)
        self.meta = dict(meta or {})
        self._plain = not robot.continuous
        self._nv = robot.nv
        self._upper = np.triu_indices(robot.nv, 1)
        self._term_inertia = self._inertia_of_terms()
        self._static = any(t.static for t in terms.joint)  # gravity(q) adds terms that depend on q only
        friction = [t for t in terms.joint + terms.motor if self._is_friction(t)]
        # friction(dq)'s terms with their values, for one sample's short path (None: a motor term among them)
        self._friction_terms = (
            None if any(t.space != "joint" for t in friction) else [(t, self._values[t.name]) for t in friction]
        )

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
        return dict(zip(_names(self.nominal_robot, self.terms), map(float, self.theta), strict=True))

    def _states(self, *arrays: tuple[str, object]) -> tuple[list[np.ndarray], bool]:
        """The named arrays as (N, nv) float batches, and whether they were one sample each (nv,).

        DataError when a shape is not (nv,) or (N, nv), the arrays disagree in N, or a value is not finite.
        """
        out, nv = [], self._nv
        for name, x in arrays:
            a = as_floats(x, name)
            if a.ndim not in (1, 2) or a.shape[-1] != nv:
                raise DataError(
                    f"{name} has shape {a.shape}, expected ({nv},) or (N, {nv}) for joints {self.joint_names}"
                )
            if a.size == 0:
                raise DataError(f"{name} is empty, expected at least one sample of {nv} joint values")
            if out and a.shape != out[0].shape:
                raise DataError(f"{name} has shape {a.shape}, expected {out[0].shape} like {arrays[0][0]}")
            out.append(a)
        single = out[0].ndim == 1
        return [a.reshape(-1, nv) for a in out], single

    def _config(self, q: np.ndarray) -> np.ndarray:
        return q if self._plain else self.robot.configuration(q)

    def _one(self, x: object) -> bool:
        """Whether ``x`` is one finite float sample (nv,) — a controller's call at every step, answered
        without the batch machinery of :meth:`_states` (the same numbers; anything else takes that path)."""
        # a finite sum has no NaN and no infinity (an overflowing one takes the checked path, which decides)
        return type(x) is np.ndarray and x.shape == (self._nv,) and x.dtype == np.float64 and math.isfinite(x.sum())

    @staticmethod
    def _is_friction(t) -> bool:
        return not (t.inertia or t.static or t.load) and t.suffix != "offset"

    # ---------------------------------------------------------------- dynamics
    def _term_torque(self, q, dq, ddq, keep=lambda t: True) -> np.ndarray:
        """Torque (N, nv) of the selected terms for which ``keep(term)`` holds, with their values of
        ``_values`` (the selection made once per set of names: a controller calls this at every step)."""
        names = tuple(t.name for t in self.terms.joint + self.terms.motor if keep(t))
        selections = self.__dict__.setdefault("_selections", {})
        if names not in selections:
            selections[names] = TermSelection(names=list(names))
        # the nominal robot: the columns of the identification (fl reads the nominal rigid-body torque)
        return _terms.torque(self.nominal_robot, selections[names], self._values, q, dq, ddq)

    def friction(self, dq: np.ndarray) -> np.ndarray:
        """Friction torque [N·m] at joint velocities ``dq`` (nv,) or (N, nv): the velocity-dependent
        terms, joint side (fc·sign(dq) + fv·dq) plus ``Gᵀ·`` motor side; not the load-dependent ``fl``
        (it needs q and ddq: :meth:`inverse_dynamics` has it)."""
        if self._friction_terms is not None and self._one(dq):  # terms.torque's joint sum, for one sample
            d = dq[None]
            zero = np.zeros((1, self._nv))
            motion = _terms.Motion(zero, d, zero, self.nominal_robot.joint_names, self.nominal_robot)
            tau = np.zeros((1, self._nv))
            for t, values in self._friction_terms:
                tau += t.torque(values, motion)
            return tau[0]
        (dq,), single = self._states(("dq", dq))
        zero = np.zeros_like(dq)
        tau = self._term_torque(zero, dq, zero, self._is_friction)
        return tau[0] if single else tau

    def gravity(self, q: np.ndarray) -> np.ndarray:
        """Static torque g(q) [N·m], (nv,) or (N, nv): gravity, plus the terms that depend on q only (the
        wearer's passive moments)."""
        static = self._static
        if not static and self._one(q):
            return np.array(pin.computeGeneralizedGravity(self.pin_model, self.pin_data, self._config(q)))
        (q,), single = self._states(("q", q))
        g = np.array([pin.computeGeneralizedGravity(self.pin_model, self.pin_data, self._config(x)) for x in q])
        if static:
            zero = np.zeros_like(q)
            g += self._term_torque(q, zero, zero, lambda t: t.static)
        return g[0] if single else g

    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        """Joint-space mass matrix M(q) + the terms' inertia [kg·m²]: symmetric (nv, nv), or (N, nv, nv)."""
        if self._one(q):
            M = np.array(pin.crba(self.pin_model, self.pin_data, self._config(q)))
            i, j = self._upper
            M[j, i] = M[i, j]  # crba fills the upper triangle
            M += self._term_inertia
            return M
        (q,), single = self._states(("q", q))
        M = np.empty((len(q), self.nv, self.nv))
        for i, x in enumerate(q):
            M[i] = pin.crba(self.pin_model, self.pin_data, self._config(x))
        i, j = self._upper
        M[:, j, i] = M[:, i, j]  # crba fills the upper triangle
        M += self._term_inertia
        return M[0] if single else M

    def _inertia_of_terms(self) -> np.ndarray:
        out = np.zeros((self.nv, self.nv))
        for t in self.terms.joint + self.terms.motor:
            if t.inertia:
                v = self._values[t.name]
                G = np.eye(self.nv) if t.space == "joint" else self.robot.drives.matrix
                out += G.T @ (v[:, None] * G)
        return out

    def coriolis(self, q: np.ndarray, dq: np.ndarray) -> np.ndarray:
        """Coriolis/centrifugal matrix C(q, dq) (nv, nv) or (N, nv, nv), with Ṁ − 2C skew-symmetric; C·dq
        is the torque [N·m]."""
        if self._one(q) and self._one(dq):
            return np.array(pin.computeCoriolisMatrix(self.pin_model, self.pin_data, self._config(q), dq))
        (q, dq), single = self._states(("q", q), ("dq", dq))
        C = np.array(
            [pin.computeCoriolisMatrix(self.pin_model, self.pin_data, self._config(a), b) for a, b in zip(q, dq)]
        )
        return C[0] if single else C

    def inverse_dynamics(self, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> np.ndarray:
        """Joint torque τ [N·m] for the motion (q, dq, ddq), (nv,) or (N, nv): rigid body + every term
        (friction, armature, offset, passive moments, motor side)."""
        (q, dq, ddq), single = self._states(("q", q), ("dq", dq), ("ddq", ddq))
        tau = np.array([pin.rnea(self.pin_model, self.pin_data, self._config(a), b, c) for a, b, c in zip(q, dq, ddq)])
        if len(self.terms):
            tau += _terms.torque(self.nominal_robot, self.terms, self._values, q, dq, ddq)
        return tau[0] if single else tau

    def forward_dynamics(self, q: np.ndarray, dq: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """Joint acceleration ddq [rad/s²] under torque ``tau`` [N·m] (solves the equation of motion with
        :meth:`mass_matrix`), (nv,) or (N, nv)."""
        (q, dq, tau), single = self._states(("q", q), ("dq", dq), ("tau", tau))
        h = self.inverse_dynamics(q, dq, np.zeros_like(q))
        try:
            ddq = np.linalg.solve(self.mass_matrix(q), (tau - h)[..., None])[..., 0]
        except np.linalg.LinAlgError:
            raise ModelError(
                "forward dynamics: the mass matrix is singular (a physically inconsistent model?), "
                "expected a consistent model"
            ) from None
        return ddq[0] if single else ddq

    def derivatives(self, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Partial derivatives of :meth:`inverse_dynamics`: ``(∂τ/∂q [N·m/rad], ∂τ/∂dq [N·m·s/rad])``, each
        (nv, nv) or (N, nv, nv), row = torque, column = joint; ``∂τ/∂ddq`` is :meth:`mass_matrix`.

        Rigid body from Pinocchio's RNEA derivatives (exact); the terms by central differences (step
        1e-6, exact for linear columns); Coulomb-type terms (``velocity_step``) add 0 to ∂τ/∂dq, their
        derivative away from dq = 0.
        """
        (q, dq, ddq), single = self._states(("q", q), ("dq", dq), ("ddq", ddq))
        n, nv = q.shape
        dtau_dq, dtau_dv = np.empty((n, nv, nv)), np.empty((n, nv, nv))
        for i in range(n):
            pin.computeRNEADerivatives(self.pin_model, self.pin_data, self._config(q[i]), dq[i], ddq[i])
            dtau_dq[i], dtau_dv[i] = self.pin_data.dtau_dq, self.pin_data.dtau_dv
        if len(self.terms):
            dtau_dq += self._term_jacobian(q, dq, ddq, "q", lambda t: True)
            dtau_dv += self._term_jacobian(q, dq, ddq, "dq", lambda t: not t.velocity_step)
        return (dtau_dq[0], dtau_dv[0]) if single else (dtau_dq, dtau_dv)

    def forward_derivatives(self, q: np.ndarray, dq: np.ndarray, tau: np.ndarray) -> tuple[np.ndarray, ...]:
        """Partial derivatives of :meth:`forward_dynamics` for MPC: ``(∂ddq/∂q, ∂ddq/∂dq, ∂ddq/∂τ)``, each
        (nv, nv) or (N, nv, nv): ``−M⁻¹·∂τ/∂q``, ``−M⁻¹·∂τ/∂dq`` at ``ddq = forward_dynamics(q, dq, τ)``, and
        ``M⁻¹`` [1/(kg·m²)]."""
        ddq = self.forward_dynamics(q, dq, tau)
        Minv = np.linalg.inv(self.mass_matrix(q))
        dq_, dv_ = self.derivatives(q, dq, ddq)
        return -Minv @ dq_, -Minv @ dv_, Minv

    def _term_jacobian(self, q, dq, ddq, wrt: str, keep) -> np.ndarray:
        """∂(term torque)/∂``wrt`` (N, nv, nv) by central differences, all joints in one vectorised call."""
        n, nv = q.shape
        h = 1e-6
        step = np.concatenate([np.eye(nv), -np.eye(nv)]) * h  # (2nv, nv)
        args = {"q": q, "dq": dq, "ddq": ddq}
        stacked = {k: np.repeat(v[None], 2 * nv, axis=0) for k, v in args.items()}  # (2nv, N, nv)
        stacked[wrt] = stacked[wrt] + step[:, None, :]
        tau = self._term_torque(*(stacked[k].reshape(-1, nv) for k in ("q", "dq", "ddq")), keep).reshape(2 * nv, n, nv)
        return np.moveaxis((tau[:nv] - tau[nv:]) / (2 * h), 0, 2)  # (N, torque row, joint column)

    # ---------------------------------------------------------------- files
    def to_dict(self) -> dict:
        """Plain-dict form with the URDF text, so that :meth:`from_dict` needs no other file."""
        from pinid import __version__  # the package's own attribute: set after its submodules load

        r = self.nominal_robot
        return {
            "format": _FORMAT,
            "version": 1,
            "pinid_version": __version__,
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
            hint = (
                " — this is pinid identify's identification.json: pass one of the model_<method>.json files "
                f"written beside it ({', '.join(f'model_{m}.json' for m in d['methods'])}), or in Python "
                "pinid.Identification.load(path).model"
                if isinstance(d.get("methods"), dict) and "robot" in d
                else ""
            )
            raise SpecError(f"not an identified model (format {d.get('format')!r}, expected {_FORMAT!r}){hint}")
        for key, kind in (("robot", dict), ("standard_parameters", dict), ("meta", (dict, type(None)))):
            if not isinstance(d.get(key), kind):
                raise SpecError(
                    f"identified model: '{key}' is {type(d.get(key)).__name__}, expected "
                    f"{'a JSON object' if key != 'meta' else 'a JSON object or null'}"
                )
        flag = d.get("physically_consistent")
        if flag is not None and not isinstance(flag, bool):
            raise SpecError(f"identified model: 'physically_consistent' is {flag!r}, expected true or false")
        robot, terms = robot_from_dict(d["robot"])
        names = _names(robot, terms)
        values = d["standard_parameters"]
        missing = [n for n in names if n not in values]
        if missing:
            raise SpecError(f"identified model: missing parameter(s) {missing[:5]}")
        bad = [
            n
            for n in names
            if isinstance(values[n], bool) or not isinstance(values[n], (int, float)) or not np.isfinite(values[n])
        ]
        if bad:
            raise SpecError(f"identified model: parameter {bad[0]} is {values[bad[0]]!r}, expected a finite number")
        theta = np.array([float(values[n]) for n in names])
        # the stored flag is never trusted: consistency is checked again on the parameters themselves (a
        # stored false stays false: the run may have found the standard set off its base parameters)
        consistent = (
            flag is not False and check_consistency(theta, _bodies(robot), terms.names, robot.motor_names).consistent
        )
        return cls(robot, terms, theta, physically_consistent=consistent, meta=d.get("meta"))

    def save(self, path: str | os.PathLike) -> Path:
        """Write as JSON (atomically)."""
        return write_json(path, self.to_dict())

    @classmethod
    def load(cls, path: str | os.PathLike) -> "IdentifiedModel":
        """Read a JSON file written by :meth:`save` (or by ``pinid identify``: ``model_<method>.json``); a pinid
        error naming the file if it is not such a file."""
        d = read_json(path, "identified model")  # its errors name the file already
        try:
            return cls.from_dict(d)
        except PinidError as exc:
            if str(path) in str(exc):
                raise
            error = type(exc)(f"{path}: {exc}")
            raise error.with_traceback(exc.__traceback__) from None

    @property
    def marks(self) -> dict[str, str] | None:
        """``{standard name: "identified" | "partly" | "not identified"}`` from the identification (``meta``'s
        ``standard_marks``; :meth:`pinid.model.base.BaseParameters.marks`), None when not known."""
        marks = self.meta.get("standard_marks")
        return dict(marks) if isinstance(marks, dict) else None

    def export_urdf(self, path: str | os.PathLike | None = None, *, force: bool = False) -> str:
        """The identified URDF text (see :func:`pinid.model.export.identified_urdf`; a floating robot's with its base
        link's inertial too, :func:`pinid.model.export.floating_urdf`); written to ``path`` when given."""
        if _floating(self.nominal_robot):
            method = f"method {self.meta.get('method', '?')}"
            return floating_urdf(
                self.nominal_robot, self.theta, self.terms, path, force=force, comment=method, marks=self.marks
            )
        return identified_urdf(
            self.nominal_robot,
            self.theta,
            self.terms,
            path,
            force=force,
            comment=f"method {self.meta.get('method', '?')}",
            marks=self.marks,
        )

    def export_mjcf(self, path: str | os.PathLike | None = None, *, floating: bool | None = None) -> str:
        """The identified model as MuJoCo MJCF (:func:`pinid.model.mjcf.identified_mjcf`); written to ``path`` when
        given.  ``floating``: a free joint on the root link (None: the robot's own base, fixed unless it has a
        floating one).  ModelError for a set MuJoCo cannot take (physically inconsistent, a massless body)."""
        from pinid.model.mjcf import identified_mjcf

        if floating is None:
            floating = getattr(self.nominal_robot, "base", "fixed") == "floating"
        return identified_mjcf(
            self.nominal_robot,
            self.theta,
            self.terms,
            path,
            floating=floating,
            comment=f"method {self.meta.get('method', '?')}",
            marks=self.marks,
        )

    def export_drives(self, path: str | os.PathLike | None = None) -> str | None:
        """The drives TOML with the identified motor terms (:func:`pinid.model.export.identified_drives`), None
        without motor terms; written to ``path`` when given (read it back with ``--drives``)."""
        from pinid.model.export import identified_drives

        return identified_drives(
            self.nominal_robot, self.theta, self.terms, path, comment=f"method {self.meta.get('method', '?')}"
        )

    def __repr__(self) -> str:
        return (
            f"IdentifiedModel({self.robot.name!r}, joints={self.joint_names}, terms={self.terms.names}, "
            f"physically_consistent={self.physically_consistent})"
        )

"""The joint-torque regressor: τ = W(q, dq, ddq) · θ, stacked over samples.

Columns: Pinocchio's 10 inertial columns per body (``<joint>.m`` … ``<joint>.Izz``), then per joint the
joint terms that are switched on, in the order of :data:`JOINT_TERM_NAMES`:

==========  =====================  ============  ==================
name        torque                 column        unit of the value
==========  =====================  ============  ==================
``fc``      Coulomb friction       sign(dq)      N·m
``fv``      viscous friction       dq            N·m·s/rad
``offset``  constant torque        1             N·m
``armature`` rotor inertia         ddq           kg·m²
==========  =====================  ============  ==================

Rows are sample-major: row ``k·nv + j`` is joint ``j`` at sample ``k``, so ``tau.reshape(-1)`` of an
``(N, nv)`` torque array matches.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np
import pinocchio as pin

from pinid.errors import DataError
from pinid.model.robot import RobotModel

#: Joint-term names in column order.
JOINT_TERM_NAMES: tuple[str, ...] = ("fc", "fv", "offset", "armature")


@dataclass(frozen=True)
class JointTerms:
    """Which per-joint terms enter the model (default: Coulomb and viscous friction)."""

    coulomb: bool = True
    viscous: bool = True
    offset: bool = False
    armature: bool = False

    @property
    def names(self) -> list[str]:
        """Names of the enabled terms, in column order."""
        return [n for n, f in zip(JOINT_TERM_NAMES, fields(self)) if getattr(self, f.name)]

    @classmethod
    def from_names(cls, names: str | list[str]) -> "JointTerms":
        """Build from ``"fc,fv,offset"`` or a list of term names; ``""`` or ``"none"`` for no term."""
        if isinstance(names, str):
            names = [n.strip() for n in names.split(",") if n.strip() and n.strip() != "none"]
        unknown = [n for n in names if n not in JOINT_TERM_NAMES]
        if unknown:
            raise ValueError(f"unknown joint term(s) {unknown}, expected some of {list(JOINT_TERM_NAMES)}")
        return cls(*(n in names for n in JOINT_TERM_NAMES))

    def __len__(self) -> int:
        return len(self.names)


def parameter_names(model: RobotModel, terms: JointTerms = JointTerms()) -> list[str]:
    """Names of all standard parameters: inertial block, then joint terms per joint."""
    return model.inertial_names + [f"{j}.{t}" for j in model.joint_names for t in terms.names]


def standard_parameters(model: RobotModel, terms: JointTerms = JointTerms()) -> np.ndarray:
    """The model's nominal standard parameters (URDF inertias and ``<dynamics>`` friction)."""
    values = {"fc": model.coulomb, "fv": model.viscous,
              "offset": np.zeros(model.nv), "armature": np.zeros(model.nv)}
    joint = np.array([[values[t][j] for t in terms.names] for j in range(model.nv)]).reshape(-1)
    return np.concatenate([model.inertial_parameters(), joint])


def _as_samples(model: RobotModel, name: str, x: np.ndarray) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    if x.ndim == 1:
        x = x[None, :]
    if x.ndim != 2 or x.shape[1] != model.nv:
        raise DataError(f"{name}: shape {x.shape}, expected (N, {model.nv}) for joints {model.joint_names}")
    return x


def regressor(
    model: RobotModel,
    q: np.ndarray,
    dq: np.ndarray,
    ddq: np.ndarray,
    terms: JointTerms = JointTerms(),
) -> np.ndarray:
    """Stacked regressor ``W`` of shape ``(N·nv, 10·nv + nv·len(terms))`` for N samples.

    ``q`` [rad], ``dq`` [rad/s], ``ddq`` [rad/s²] are ``(N, nv)`` arrays (or one ``(nv,)`` sample).
    ``W @ standard_parameters(model, terms)`` is the joint torque [N·m], rigid body plus joint terms.
    """
    q, dq, ddq = (_as_samples(model, n, x) for n, x in (("q", q), ("dq", dq), ("ddq", ddq)))
    if not (len(q) == len(dq) == len(ddq)):
        raise DataError(f"q, dq, ddq have {len(q)}, {len(dq)}, {len(ddq)} samples, expected the same number")
    n, nv = q.shape
    ni, nt = 10 * nv, len(terms)
    out = np.zeros((n, nv, ni + nv * nt))
    inertial = out[:, :, :ni]
    m, d = model.pin_model, model.pin_model.createData()
    compute = pin.computeJointTorqueRegressor
    if model._continuous:
        for k in range(n):
            inertial[k] = compute(m, d, model.configuration(q[k]), dq[k], ddq[k])
    else:
        for k in range(n):
            inertial[k] = compute(m, d, q[k], dq[k], ddq[k])
    columns = {"fc": np.sign(dq), "fv": dq, "offset": np.ones_like(dq), "armature": ddq}
    for t, name in enumerate(terms.names):
        for j in range(nv):
            out[:, j, ni + j * nt + t] = columns[name][:, j]
    return out.reshape(n * nv, ni + nv * nt)


def joint_torque(model: RobotModel, q, dq, ddq, theta: np.ndarray, terms: JointTerms = JointTerms()) -> np.ndarray:
    """Torque ``(N, nv)`` [N·m] of the standard parameters ``theta`` (regressor times parameters)."""
    q = _as_samples(model, "q", q)
    return (regressor(model, q, dq, ddq, terms) @ theta).reshape(len(q), model.nv)

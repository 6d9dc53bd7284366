"""The joint-torque regressor: τ = W(q, dq, ddq) · θ, stacked over samples.

Columns: Pinocchio's 10 inertial columns per body (``<joint>.m`` … ``<joint>.Izz``), then the selected
terms (:mod:`pinid.model.terms`): per joint, then per motor of the robot's drives.  The classic ones:

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

import numpy as np
import pinocchio as pin

from pinid.checks import as_states, as_vector, same_length
from pinid.model import terms as _terms
from pinid.model.robot import RobotModel, as_robot
from pinid.model.terms import TermSelection, as_terms

__all__ = ["parameter_names", "standard_parameters", "regressor", "joint_torque"]


def parameter_names(model: RobotModel, terms: TermSelection = TermSelection()) -> list[str]:
    """Names of all standard parameters: inertial block, then the term parameters (``hip.fc``, ``m6.fc``)."""
    model, terms = as_robot(model), as_terms(terms)
    return model.inertial_names + _terms.term_parameter_names(model, terms)


def standard_parameters(model: RobotModel, terms: TermSelection = TermSelection()) -> np.ndarray:
    """The model's nominal standard parameters (URDF inertias, ``<dynamics>`` friction, drives' values)."""
    model, terms = as_robot(model), as_terms(terms)
    return np.concatenate([model.inertial_parameters(), _terms.nominal(model, terms)])


def regressor(
    model: RobotModel,
    q: np.ndarray,
    dq: np.ndarray,
    ddq: np.ndarray,
    terms: TermSelection = TermSelection(),
) -> np.ndarray:
    """Stacked regressor ``W`` of shape ``(N·nv, 10·nv + number of term parameters)`` for N samples.

    ``q`` [rad], ``dq`` [rad/s], ``ddq`` [rad/s²] are ``(N, nv)`` arrays (or one ``(nv,)`` sample).
    ``W @ standard_parameters(model, terms)`` is the joint torque [N·m], rigid body plus terms (joint terms + Gᵀ·motor terms).
    """
    model, terms = as_robot(model), as_terms(terms)
    q, dq, ddq = (as_states(x, n, model.joint_names) for n, x in (("q", q), ("dq", dq), ("ddq", ddq)))
    same_length(q=q, dq=dq, ddq=ddq)
    n, nv = q.shape
    ni = 10 * nv
    nt = _terms.term_count(model, terms)
    out = np.empty((n, nv, ni + nt))
    inertial = out[:, :, :ni]
    m, d = model.pin_model, model.pin_model.createData()
    compute = pin.computeJointTorqueRegressor
    if model.continuous:
        for k in range(n):
            inertial[k] = compute(m, d, model.configuration(q[k]), dq[k], ddq[k])
    else:
        for k in range(n):
            inertial[k] = compute(m, d, q[k], dq[k], ddq[k])
    out[:, :, ni:] = 0.0
    _terms.columns(model, terms, q, dq, ddq, out=out[:, :, ni:])
    return out.reshape(n * nv, ni + nt)


def joint_torque(
    model: RobotModel, q, dq, ddq, theta: np.ndarray, terms: TermSelection = TermSelection()
) -> np.ndarray:
    """Torque ``(N, nv)`` [N·m] of the standard parameters ``theta`` (regressor times parameters)."""
    model, terms = as_robot(model), as_terms(terms)
    q = as_states(q, "q", model.joint_names)
    theta = as_vector(theta, "theta", len(parameter_names(model, terms)), f"standard parameters (terms {terms.names})")
    return (regressor(model, q, dq, ddq, terms) @ theta).reshape(len(q), model.nv)


def __getattr__(name: str):
    if name == "JointTerms":  # the old name of TermSelection, for one release (pinid.model.terms warns)
        from pinid.model import terms

        return getattr(terms, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

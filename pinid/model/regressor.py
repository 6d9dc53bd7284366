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

A floating-base model (:class:`~pinid.model.floating.FloatingRobotModel`: a free flyer is a root joint, as in
Pinocchio) is dispatched on: its parameters are those of every moving body, the base link's first (``base.m`` …),
and its regressor takes Pinocchio's free-flyer state (``FloatingRobotModel.full_state`` builds it) and has
``6 + n`` rows per sample, the base link's 6 (force, then moment, base frame) before the ``n`` joint rows.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from pinid.checks import as_floats, as_states, as_vector, same_length
from pinid.errors import DataError
from pinid.model import terms as _terms
from pinid.model.floating import BASE_NQ, BASE_NV, FloatingRobotModel, free_flyer_terms
from pinid.model.robot import RobotModel, as_robot
from pinid.model.terms import TermSelection, as_terms

__all__ = ["parameter_names", "standard_parameters", "regressor", "joint_torque"]


def parameter_names(model: RobotModel, terms: TermSelection = TermSelection()) -> list[str]:
    """Names of all standard parameters: inertial block, then the term parameters (``hip.fc``, ``m6.fc``); a
    floating model's with the base body first.

    A floating model's: ``base.m`` … ``base.Izz`` (the base link, about its frame), then per joint's body, then the
    terms per body (the base's first: a free flyer has no friction, they are zero columns)."""
    if isinstance(model, FloatingRobotModel):
        terms = free_flyer_terms(model, terms)
        view = model.bodies
        return view.inertial_names + _terms.term_parameter_names(view, terms)
    model, terms = as_robot(model), as_terms(terms)
    return model.inertial_names + _terms.term_parameter_names(model, terms)


def standard_parameters(model: RobotModel, terms: TermSelection = TermSelection()) -> np.ndarray:
    """The model's nominal standard parameters (URDF inertias, ``<dynamics>`` friction, drives' values); a floating
    model's with the base link's inertia first (:func:`parameter_names`)."""
    if isinstance(model, FloatingRobotModel):
        terms = free_flyer_terms(model, terms)
        return np.concatenate([model.floating_parameters(), _terms.nominal(model.bodies, terms)])
    model, terms = as_robot(model), as_terms(terms)
    return np.concatenate([model.inertial_parameters(), _terms.nominal(model, terms)])


def regressor(
    model: RobotModel,
    q: np.ndarray,
    dq: np.ndarray,
    ddq: np.ndarray,
    terms: TermSelection = TermSelection(),
) -> np.ndarray:
    """Stacked regressor ``W`` of shape ``(N·nv, 10·nv + number of term parameters)`` for N samples; a floating
    model's ``(N·(6 + n), 10·(n + 1) + …)`` on its free-flyer state (below).

    ``q`` [rad], ``dq`` [rad/s], ``ddq`` [rad/s²] are ``(N, nv)`` arrays (or one ``(nv,)`` sample).
    ``W @ standard_parameters(model, terms)`` is the joint torque [N·m], rigid body plus terms (joint terms + Gᵀ·motor terms).

    A floating model (:class:`~pinid.model.floating.FloatingRobotModel`) takes Pinocchio's free-flyer state:
    ``q`` ``(N, 7 + nq)`` (base position [m], unit quaternion x y z w, then the joints' configuration), ``dq`` and
    ``ddq`` ``(N, 6 + n)`` (the base's spatial velocity and its derivative in the base frame, linear first, then
    the joints'), as ``model.full_state(base_q, base_v, base_a, q, dq, ddq)`` builds them; ``W`` then has
    ``N·(6 + n)`` rows, per sample the 6 base rows first, and ``W @ standard_parameters(model, terms)`` is the
    generalised force of Pinocchio's RNEA on the free flyer (``[base wrench; joint torques]``, no external force)
    plus the joint terms in the joint rows.
    """
    if isinstance(model, FloatingRobotModel):
        return _free_flyer_regressor(model, q, dq, ddq, free_flyer_terms(model, terms))
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
    """Torque ``(N, nv)`` [N·m] of the standard parameters ``theta`` (regressor times parameters); a floating
    model's ``(N, 6 + n)`` (base wrench [N, N·m], then joint torques) from its free-flyer state (:func:`regressor`)."""
    if not isinstance(model, FloatingRobotModel):
        model, terms = as_robot(model), as_terms(terms)
        q = as_states(q, "q", model.joint_names)
    W = regressor(model, q, dq, ddq, terms)
    theta = as_vector(theta, "theta", W.shape[1], f"standard parameters (terms {as_terms(terms).names})")
    rows = model.nv + (BASE_NV if isinstance(model, FloatingRobotModel) else 0)
    return (W @ theta).reshape(-1, rows)


def _free_flyer_states(model: FloatingRobotModel, q, dq, ddq) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(Q, V, A)`` of a floating model checked: ``(N, 7 + nq)``, ``(N, 6 + n)`` twice; one sample as ``(1, …)``."""
    nq, nv = model.ff_model.nq, BASE_NV + model.nv
    out = []
    for name, x, width, what in (
        ("q", q, nq, f"base position, quaternion x y z w, then {model.pin_model.nq} joint coordinates"),
        ("dq", dq, nv, "base velocity (linear, angular; base frame), then the joints'"),
        ("ddq", ddq, nv, "base acceleration (linear, angular; base frame), then the joints'"),
    ):
        a = as_floats(x, name)
        a = a.reshape(1, -1) if a.ndim == 1 else a
        if a.ndim != 2 or a.shape[1] != width or a.shape[0] == 0:
            raise DataError(
                f"{name}: shape {np.shape(x)}, expected (N, {width}) for the floating {model.name} ({what}: "
                "model.full_state(base_q, base_v, base_a, q, dq, ddq) builds it)"
            )
        out.append(a)
    same_length(q=out[0], dq=out[1], ddq=out[2])
    norms = np.linalg.norm(out[0][:, 3:BASE_NQ], axis=1)
    bad = np.flatnonzero(np.abs(norms - 1.0) > 1e-6)
    if bad.size:
        k = int(bad[0])
        raise DataError(f"q: base quaternion of sample {k} has norm {norms[k]:.6g}, expected a unit quaternion")
    return out[0], out[1], out[2]


def _free_flyer_regressor(model: FloatingRobotModel, q, dq, ddq, terms: TermSelection) -> np.ndarray:
    """:func:`regressor` of a floating model (``terms`` checked): ``(N·(6 + n), p)``."""
    Q, V, A = _free_flyer_states(model, q, dq, ddq)
    n, nv = len(Q), model.nv
    names = parameter_names(model, terms)
    ni = 10 * (nv + 1)
    out = np.zeros((n, BASE_NV + nv, len(names)))
    m, d = model.ff_model, model.ff_data
    compute = pin.computeJointTorqueRegressor
    inertial = out[:, :, :ni]
    for k in range(n):
        inertial[k] = compute(m, d, Q[k], V[k], A[k])
    if terms.joint:  # joint-major term columns: the base's (zero) first, then the joints' in the fixed order
        qj = Q[:, BASE_NQ:]
        if model.continuous:  # Pinocchio's cos, sin of a continuous joint back to its angle [rad]
            qj = np.empty((n, nv))
            for i in range(nv):
                joint = m.joints[i + 2]
                c = Q[:, joint.idx_q]
                qj[:, i] = np.arctan2(Q[:, joint.idx_q + 1], c) if joint.nq == 2 else c
        _terms.columns(model, terms, qj, V[:, BASE_NV:], A[:, BASE_NV:], out=out[:, BASE_NV:, ni + len(terms.joint) :])
    return out.reshape(n * (BASE_NV + nv), len(names))


def __getattr__(name: str):
    if name == "JointTerms":  # the old name of TermSelection, for one release (pinid.model.terms warns)
        from pinid.model import terms

        return getattr(terms, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

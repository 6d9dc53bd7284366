"""Load-dependent Coulomb friction (harmonic drives: Coulomb friction that grows with the transmitted torque).

    τ_fl,j = fl_j · |τ_load,j(q, dq, ddq)| · sign(dq_j)      [N·m],  fl_j ≥ 0 (dimensionless)

``τ_load`` is the rigid-body torque (RNEA) of the model's **nominal** inertial parameters — those of the URDF
the model was built from (the CAD values), not the identified ones — so the column stays linear in the one
identified parameter ``fl`` per joint (``--terms fc,fv,fl``, parameter ``<joint>.fl``).  With the identified
inertia in ``τ_load`` the torque would be bilinear in the parameters; the nominal load is close enough to
scale a friction that is a few percent of it.  :class:`pinid.identification.identified.IdentifiedModel`
evaluates the term with its nominal robot for that reason.

The twin's plant applies ``fl·|τ_load|·tanh(dq/v_s)`` (Coulomb's smoothing) with the twin's own model's
rigid-body torque; as that depends on the acceleration being solved for, the plant finds it by fixed-point
iteration (:attr:`pinid.model.terms.Term.load`).  ``IdentifiedModel.friction(dq)``, a function of the velocity
alone, leaves the term out; :meth:`~pinid.identification.identified.IdentifiedModel.inverse_dynamics` has it.

Registered in :data:`pinid.model.terms.TERMS` when ``fl`` is first asked for
(its entry point of the group ``pinid.terms``, pyproject.toml; :mod:`pinid.plugins`).
"""

from __future__ import annotations

import weakref

import numpy as np
import pinocchio as pin

from pinid.errors import ModelError
from pinid.model.terms import Motion, Term, register


#: Pinocchio data per robot, for the twin's one-sample calls (a checked ``robot.rnea`` costs 25 times more).
_DATA: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _load_torque(m: Motion) -> np.ndarray:
    """Rigid-body torque (N, nv) [N·m] of ``m.robot``'s inertial parameters at the motion ``m`` (no friction)."""
    robot = m.robot if isinstance(m, Motion) else None
    if not hasattr(robot, "rnea"):
        raise ModelError(f"m: got {type(m).__name__}, expected a pinid.model.terms.Motion with its RobotModel")
    if np.shape(m.q)[0] != 1 or robot.continuous:
        return np.atleast_2d(robot.rnea(m.q, m.dq, m.ddq))
    data = _DATA.get(robot)
    if data is None:
        data = _DATA[robot] = robot.pin_model.createData()
    return pin.rnea(robot.pin_model, data, *(np.asarray(x[0], dtype=float) for x in (m.q, m.dq, m.ddq)))[None].copy()


def _column(m: Motion) -> np.ndarray:
    return np.abs(_load_torque(m)) * np.sign(m.dq)


def _plant(values: np.ndarray, m: Motion, vs: float) -> np.ndarray:
    return values * np.abs(_load_torque(m)) * np.tanh(m.dq / vs)


register(
    Term(
        "fl",
        "fl",
        "load-dependent Coulomb friction",
        "1",
        _column,
        nonnegative=True,
        plant=_plant,
        load=True,
        note="fl·|τ_load|·sign(dq), τ_load the URDF's rigid-body torque",
    )
)

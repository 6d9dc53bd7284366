"""Checks that the twin's plant can be simulated (a regular mass matrix) and that a run tracked its
trajectory (inside the joint limits, no lost trajectory): a model with absurd numbers fails with what is
wrong with it, not with "diverged"."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from pinid.errors import DataError, ModelError
from pinid.checks import as_floats, as_states
from pinid.model.robot import RobotModel, as_robot

#: How far [rad or m] beyond a joint limit, as a fraction of the limits' range, the plant may go before the
#: twin calls the run failed (a tracking loop overshoots a little where the trajectory touches a limit).
LIMIT_OVERSHOOT = 0.25
#: Largest tracking error [rad, or m for a prismatic joint] of a run the twin accepts (on joints without
#: limits; half a turn: the controller has lost the trajectory).
TRACKING_ERROR_MAX = np.pi


def check_tracking(model, q: np.ndarray, q_desired: np.ndarray) -> None:
    """DataError (one line) when the plant's positions ``q`` (N, nv) left a joint's limits by more than
    :data:`LIMIT_OVERSHOOT` × their range, or left ``q_desired`` by more than :data:`TRACKING_ERROR_MAX`:
    the recording would not show the trajectory asked for (the model cannot be held by its controller:
    a link kilometres long, a mass or inertia off by orders of magnitude, effort limits too low)."""
    model = as_robot(model)
    q, q_desired = as_states(q, "q", model.joint_names), as_states(q_desired, "q_desired", model.joint_names)
    if q.shape != q_desired.shape:
        raise DataError(f"q has {len(q)} samples and q_desired {len(q_desired)}, expected the same number")
    lo, hi = model.lower, model.upper
    bounded = np.isfinite(lo) & np.isfinite(hi) & (hi > lo)
    margin = np.where(bounded, LIMIT_OVERSHOOT * np.where(bounded, hi - lo, 0.0), np.inf)
    beyond = np.maximum(lo - q, q - hi)
    err = np.abs(q - q_desired).max(axis=0)
    bad = np.flatnonzero(np.any(beyond > margin, axis=0) | (err > TRACKING_ERROR_MAX))
    if not bad.size:
        return
    j = int(bad[np.argmax(err[bad])])
    name = model.joint_names[j]
    where = (
        f"reached {q[np.argmax(beyond[:, j]), j]:.4g}, outside its limits [{lo[j]:.4g}, {hi[j]:.4g}]"
        if bounded[j] and beyond[:, j].max() > margin[j]
        else f"is {err[j]:.4g} off the trajectory"
    )
    pm = model.pin_model
    offsets = [float(np.linalg.norm(pm.jointPlacements[i].translation)) for i in range(1, pm.njoints)]
    k = int(np.argmax(offsets))
    hint = (
        f"; joint '{model.joint_names[k]}' sits {offsets[k]:.3g} m from its parent joint" if offsets[k] > 10.0 else ""
    )
    raise DataError(
        f"simulation failed to track the trajectory: joint '{name}' {where} (tracking error up to "
        f"{err[j]:.3g}){hint}; expected a model its controller can hold: check the URDF's joint origins, "
        "masses, inertias and effort limits"
    )


def check_mass_matrix(model: RobotModel, q: np.ndarray, armature=None) -> None:
    """ModelError naming the link when the plant's mass matrix is singular at the positions ``q`` (N, nv):
    a joint that moves no mass or inertia (a massless last link) cannot be simulated, its acceleration
    is undetermined.  Armature and reflected rotor inertia count."""
    model = as_robot(model)
    q = as_states(q, "q", model.joint_names)
    if armature is not None:
        armature = as_floats(armature, "armature")
    pm, data = model.pin_model, model.pin_model.createData()
    extra = np.zeros(model.nv) if armature is None else np.asarray(armature, dtype=float)
    d = model.drives
    if d is not None and np.any(d.nominal("armature") != 0):
        extra = extra + np.einsum("mj,m,mj->j", d.matrix, d.nominal("armature"), d.matrix)
    for qk in np.atleast_2d(q):
        M = pin.crba(pm, data, model.configuration(qk))
        M = np.triu(M) + np.triu(M, 1).T
        M[np.diag_indices(model.nv)] += extra
        diag = np.diag(M)
        # A joint moving nothing has a zero diagonal entry (1e-12 kg·m² or kg: far below any real link).
        # Otherwise singularity is judged on M scaled to a unit diagonal, so that links of very different
        # sizes (a knee 1e6 m below the hip: M's entries 1e12 apart) are not mistaken for a massless one.
        weak = np.flatnonzero(~(diag > 1e-12))
        if weak.size:
            j = int(weak[0])
        else:
            lowest, vectors = np.linalg.eigh(M / np.sqrt(np.outer(diag, diag)))
            if lowest[0] > 1e-10:
                continue
            j = int(np.argmax(np.abs(vectors[:, 0])))  # the joint the singular direction moves most
        name = model.joint_names[j]
        jid = pm.getJointId(name)
        links = [f.name for f in pm.frames if f.parentJoint == jid and f.type == pin.FrameType.BODY]
        raise ModelError(
            f"{model.name}: joint '{name}' moves no mass or inertia about its axis (link "
            f"'{links[0] if links else name}' and the links after it are massless or their inertia is "
            "zero), so the mass matrix is singular and the plant cannot be simulated; expected a "
            "mass and inertia on every moving link (or an armature)"
        )

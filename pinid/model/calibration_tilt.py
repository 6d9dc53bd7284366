"""Calibration term ``tilt``: gravity's direction in the motion-capture world (2 angles), fitted with the inertia.

A motion-capture system's vertical is where its calibration put it; gravity is not obliged to agree.  The base
pose ``R_MB`` is read in the motion capture's world M; gravity's world G is M turned by ``R_GM = Rx(α)·Ry(β)``,
so ``R_GB = R_GM·R_MB`` and gravity in the base frame is ``g_B = R_MBᵀ·R_GMᵀ·g``.  Only ``g_B`` changes: the base
velocity and acceleration in the base frame, and a sensor's wrench in its own frame, do not depend on which
world the pose is read in; force plates (world wrenches) are turned with the pose.  The rows are bilinear in
(α, β) and the inertial parameters (gravity's moment is ``h × g_B``): :mod:`pinid.identification.calibration`
fits them together by Gauss-Newton.  Reported in degrees: α about the motion capture's x axis, β about its y.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from pinid.model.calibration import CalibrationTerm, rotation_xy
from pinid.model.floating import Wrench


def _rotate_quat(R: np.ndarray, quat: np.ndarray) -> np.ndarray:
    """(N, 4) quaternions x, y, z, w of ``R·R(quat)``."""
    from scipy.spatial.transform import Rotation

    return (Rotation.from_matrix(R) * Rotation.from_quat(quat)).as_quat()


def _apply(s, estimate):
    R = rotation_xy(estimate.values)
    bq = np.array(s.base_q, dtype=float, copy=True)
    bq[:, :3] = bq[:, :3] @ R.T
    bq[:, 3:] = _rotate_quat(R, bq[:, 3:])
    wrenches = [
        w if w.frame == "local" else Wrench(w.link, np.hstack([w.values[:, :3] @ R.T, w.values[:, 3:] @ R.T]), w.frame)
        for w in s.wrenches
    ]
    return replace(s, base_q=bq, wrenches=wrenches)


def _world(values: np.ndarray, g: np.ndarray) -> np.ndarray:
    """(3,) gravity in the motion capture's world [m/s²]: ``R(φ)ᵀ·g``."""
    return rotation_xy(values).T @ np.asarray(g, dtype=float)


def _gravity(values: np.ndarray, base_q: np.ndarray, g: np.ndarray) -> np.ndarray:
    """(N, 3) gravity in the base frame [m/s²] for base poses ``base_q`` read in the motion capture's world."""
    from scipy.spatial.transform import Rotation

    return Rotation.from_quat(base_q[:, 3:]).inv().apply(_world(values, g))


TERM = CalibrationTerm(
    "tilt",
    "gravity's direction in the motion-capture world",
    held=False,
    applies=lambda samples: bool(samples),
    apply=_apply,
    names=lambda samples: ["gravity.tilt_x", "gravity.tilt_y"],
    units=lambda samples: ["rad", "rad"],
    start=lambda samples: np.zeros(2),
    gravity=_gravity,
    shown=np.degrees,
    shown_units=lambda samples: ["deg", "deg"],
    negligible=1e-3,
    world=_world,
)

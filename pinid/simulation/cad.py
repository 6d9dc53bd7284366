"""A "CAD" model for the twin's feed-forward: the truth with its inertial parameters perturbed by a few
percent, physically consistent (:func:`perturb`).
"""

from __future__ import annotations

import math

import numpy as np

from pinid.errors import SpecError
from pinid.model.robot import RobotModel, as_robot


# ---------------------------------------------------------------------------------------------- perturbation
def perturb(model: RobotModel, percent: float, rng: np.random.Generator) -> RobotModel:
    """A copy of ``model`` whose inertial parameters differ by about ``percent`` % — a "CAD" model.

    Each body's mass distribution is transformed, which keeps it physically consistent: the mass is
    scaled by ``1 + ε·u`` (|u| ≤ 1, ε = percent/100) and the mass distribution mapped by ``x → S·x + t``
    with ``S = 1 + (ε/2)·U`` (entries of U uniform in [−1, 1]) and ``t`` up to ``(ε/2)·r`` per axis, r
    the body's radius of gyration about its joint.  In pseudo-inertia form ``J' = (1 + ε·u)·A J Aᵀ``
    with ``A = [[S, t], [0, 1]]``, so ``J' ⪰ 0`` whenever ``J ⪰ 0``.  Mass changes by at most ``percent``
    %, first moments and inertias by about as much.  Friction is unchanged.
    """
    model = as_robot(model)
    if not np.isfinite(percent) or percent < 0 or percent >= 100:
        raise SpecError(f"perturbation {percent!r} %, expected a percentage from 0 to below 100")
    eps = percent / 100.0
    theta = model.inertial_parameters().copy()
    for b in range(model.nv):
        p = theta[10 * b : 10 * b + 10]
        m, h = p[0], p[1:4]
        Ixx, Ixy, Iyy, Ixz, Iyz, Izz = p[4:10]
        inertia = np.array([[Ixx, Ixy, Ixz], [Ixy, Iyy, Iyz], [Ixz, Iyz, Izz]])
        sigma = 0.5 * np.trace(inertia) * np.eye(3) - inertia
        J = np.zeros((4, 4))
        J[:3, :3], J[:3, 3], J[3, :3], J[3, 3] = sigma, h, h, m
        S = np.eye(3) + 0.5 * eps * rng.uniform(-1, 1, (3, 3))
        radius = math.sqrt(max(np.trace(sigma), 0.0) / m) if m > 0 else 0.0
        A = np.eye(4)
        A[:3, :3] = S
        A[:3, 3] = 0.5 * eps * radius * rng.uniform(-1, 1, 3)
        Jp = (1.0 + eps * rng.uniform(-1, 1)) * (A @ J @ A.T)
        sig = 0.5 * (Jp[:3, :3] + Jp[:3, :3].T)
        I2 = np.trace(sig) * np.eye(3) - sig
        theta[10 * b : 10 * b + 10] = [Jp[3, 3], *Jp[:3, 3], I2[0, 0], I2[0, 1], I2[1, 1], I2[0, 2], I2[1, 2], I2[2, 2]]
    return model.with_inertial_parameters(theta)

"""The link side of a flexible-joint model (seed 003 Eqs. (11), (13)): ``M(q)``, ``c(q, dq)``, ``g(q)`` of the
URDF for a whole population of inertial parameter sets, by two backends (see :mod:`pinid.flexible.model`):

* :class:`TrigDynamics` — chains of ≤ 3 revolute joints, exact trigonometric polynomials in the angles,
  vectorised over the population;
* :class:`PinocchioBatch` — any URDF, Pinocchio per parameter set.
"""

from __future__ import annotations

import itertools

import numpy as np
import pinocchio as pin

from pinid.errors import SpecError
from pinid.model.robot import RobotModel


# ---------------------------------------------------------------------------------------------- link dynamics
def _harmonics(x: np.ndarray, degree: int) -> np.ndarray:
    """[1, cos x, sin x, cos 2x, sin 2x][: 2·degree+1] along a new last axis."""
    cols = [np.ones_like(x)]
    for k in range(1, degree + 1):
        cols += [np.cos(k * x), np.sin(k * x)]
    return np.stack(cols, axis=-1)


class TrigDynamics:
    """Exact batch ``M(q)``, ``c(q, dq)``, ``g(q)`` of a fixed-base chain of ≤ 3 revolute joints.

    ``M`` is a trigonometric polynomial of degree ≤ 2 in each of ``q[1:]`` (not in ``q[0]``: kinetic energy
    does not change when the whole chain turns about the first axis), ``g`` of degree ≤ 1 in each angle; both
    are linear in the standard inertial parameters.  The coefficients (``Mcoef[k, basis, i, j]``,
    ``Gcoef[k, basis, i]``) are solved exactly from Pinocchio's joint-torque regressor on a grid of 5 (resp.
    3) angles per joint.
    """

    MAX_JOINTS = 3

    def __init__(self, robot: RobotModel) -> None:
        nv = robot.nv
        if any(j.kind == "prismatic" for j in robot.joints):
            raise SpecError("trig backend: prismatic joints are not supported, use backend 'pinocchio'")
        if nv > self.MAX_JOINTS:
            raise SpecError(f"trig backend: {nv} joints, supports at most {self.MAX_JOINTS}; use backend 'pinocchio'")
        self.nv = nv
        model = pin.Model(robot.pin_model)
        model0 = pin.Model(robot.pin_model)
        model0.gravity = pin.Motion.Zero()
        data, data0 = model.createData(), model0.createData()
        p = 10 * nv
        # mass matrix: variables q[1:], 5 harmonics each
        grid5 = 2 * np.pi * np.arange(5) / 5
        inv5 = np.linalg.inv(_harmonics(grid5, 2))
        nb = 5 ** (nv - 1)
        vals = np.empty((nb, nv, nv, p))  # [point, i, j, k]
        zeros = np.zeros(nv)
        for n, angles in enumerate(itertools.product(grid5, repeat=nv - 1)):
            q = robot.configuration(np.array((0.0,) + angles))
            for j in range(nv):
                e = np.zeros(nv)
                e[j] = 1.0
                Y = pin.computeJointTorqueRegressor(model0, data0, q, zeros, e)
                vals[n, :, j, :] = Y
        kinv = np.ones((1, 1))
        for _ in range(nv - 1):
            kinv = np.kron(kinv, inv5)
        self.Mcoef = np.einsum("bn,nijk->kbij", kinv, vals)  # (p, nb, nv, nv)
        # gravity: all variables, 3 harmonics each
        grid3 = 2 * np.pi * np.arange(3) / 3
        inv3 = np.linalg.inv(_harmonics(grid3, 1))
        ng = 3**nv
        gvals = np.empty((ng, nv, p))
        for n, angles in enumerate(itertools.product(grid3, repeat=nv)):
            q = robot.configuration(np.array(angles))
            gvals[n] = pin.computeJointTorqueRegressor(model, data, q, zeros, zeros)
        kinv = np.ones((1, 1))
        for _ in range(nv):
            kinv = np.kron(kinv, inv3)
        self.Gcoef = np.einsum("bn,nik->kbi", kinv, gvals)  # (p, ng, nv)
        self.Mcoef[np.abs(self.Mcoef) < 1e-13] = 0.0
        self.Gcoef[np.abs(self.Gcoef) < 1e-13] = 0.0
        # gravity basis index b = 3·(harmonic of q1) + (harmonic of q2) for two joints: when the first
        # axis is vertical (the tracker), only rows 0..2 (q1 harmonic 0) are non-zero
        self._g_q2_rows = np.arange(3)
        self._g_q2_only = nv == 2 and not np.any(self.Gcoef[:, 3:, :])

    def coefficients(self, theta: np.ndarray, armature: np.ndarray | None = None):
        """Coefficients for inertial parameters ``theta`` ``(p,)`` or ``(P, p)``; ``armature`` ``(nv,)`` or ``(P, nv)``
        is added to the diagonal of M.  Returns ``(Mc, Gc)``: ``(…, nb, nv²)`` and ``(…, ng, nv)``."""
        nv = self.nv
        Mc = np.tensordot(theta, self.Mcoef, axes=(-1, 0))  # (..., nb, nv, nv)
        Gc = np.tensordot(theta, self.Gcoef, axes=(-1, 0))
        if armature is not None:
            arm = np.asarray(armature, dtype=float)
            Mc = Mc.copy()
            idx = np.arange(nv)
            Mc[..., 0, idx, idx] = Mc[..., 0, idx, idx] + arm
        return Mc.reshape(Mc.shape[:-2] + (nv * nv,)), Gc

    def _bases(self, q: np.ndarray):
        """Mass-matrix basis (P, nb), its derivatives w.r.t. q[1:] [(P, nb)…], gravity basis (P, ng)."""
        nv = self.nv
        per, dper, g1 = [], [], []
        for j in range(nv):
            c, s = np.cos(q[:, j]), np.sin(q[:, j])
            one = np.ones_like(c)
            g1.append(np.stack([one, c, s], axis=1))
            if j == 0:
                continue
            c2, s2 = c * c - s * s, 2.0 * s * c
            per.append(np.stack([one, c, s, c2, s2], axis=1))
            dper.append(np.stack([np.zeros_like(c), -s, c, -2.0 * s2, 2.0 * c2], axis=1))
        P = q.shape[0]

        def kron_rows(mats):
            out = np.ones((P, 1))
            for m in mats:
                out = (out[:, :, None] * m[:, None, :]).reshape(P, -1)
            return out

        phi = kron_rows(per)
        dphi = [kron_rows(per[:l] + [dper[l]] + per[l + 1 :]) for l in range(nv - 1)]
        psi = kron_rows(g1)
        return phi, dphi, psi

    @staticmethod
    def _apply(basis: np.ndarray, coef: np.ndarray) -> np.ndarray:
        """Σ_b basis[p, b]·coef[(p,) b, k] -> (P, k)."""
        if coef.ndim == 2:
            return basis @ coef
        return np.einsum("pb,pbk->pk", basis, coef)

    def terms(self, Mc, Gc, q: np.ndarray, dq: np.ndarray):
        """``M (P, nv, nv)``, ``c + g (P, nv)`` at states ``q, dq`` ``(P, nv)``."""
        nv, P = self.nv, q.shape[0]
        phi, dphi, psi = self._bases(q)
        M = self._apply(phi, Mc).reshape(P, nv, nv)
        h = self._apply(psi, Gc)
        for l, dp in enumerate(dphi):
            j = l + 1
            dM = self._apply(dp, Mc).reshape(P, nv, nv)
            dMdq = np.einsum("pik,pk->pi", dM, dq)
            h = h + dMdq * dq[:, j : j + 1]
            h[:, j] -= 0.5 * np.einsum("pi,pi->p", dq, dMdq)
        return M, h

    def forward(self, Mc, Gc, q: np.ndarray, dq: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """Joint accelerations ``M⁻¹(τ − c − g)`` ``(P, nv)``."""
        if self.nv == 2:
            return self._forward2(Mc, Gc, q, dq, tau)
        M, h = self.terms(Mc, Gc, q, dq)
        rhs = tau - h
        if self.nv == 1:
            return rhs / M[:, :, 0]
        if self.nv == 2:
            a, b, c, d = M[:, 0, 0], M[:, 0, 1], M[:, 1, 0], M[:, 1, 1]
            det = a * d - b * c
            return np.stack([(d * rhs[:, 0] - b * rhs[:, 1]) / det, (a * rhs[:, 1] - c * rhs[:, 0]) / det], axis=1)
        return np.linalg.solve(M, rhs[:, :, None])[:, :, 0]

    def _forward2(self, Mc, Gc, q, dq, tau):
        """Two joints, written out: one batched matmul gives M and ∂M/∂q2, then a 2×2 solve."""
        P = q.shape[0]
        c, s = np.cos(q[:, 1]), np.sin(q[:, 1])
        c2, s2 = c * c - s * s, 2.0 * s * c
        feat = np.empty((P, 2, 5))
        feat[:, 0, 0] = 1.0
        feat[:, 0, 1] = c
        feat[:, 0, 2] = s
        feat[:, 0, 3] = c2
        feat[:, 0, 4] = s2
        feat[:, 1, 0] = 0.0
        feat[:, 1, 1] = -s
        feat[:, 1, 2] = c
        feat[:, 1, 3] = -2.0 * s2
        feat[:, 1, 4] = 2.0 * c2
        MM = feat @ Mc  # (P, 2, 4): row 0 M, row 1 ∂M/∂q2
        if self._g_q2_only:
            G = Gc[..., self._g_q2_rows, :]
            g = (feat[:, 0, None, :3] @ G)[:, 0, :]
        else:
            c1, s1 = np.cos(q[:, 0]), np.sin(q[:, 0])
            h1 = np.stack([np.ones_like(c1), c1, s1], axis=1)
            psi = (h1[:, :, None] * feat[:, 0, None, :3]).reshape(P, 9)
            g = (psi[:, None, :] @ Gc)[:, 0, :]
        a, b, d = MM[:, 0, 0], MM[:, 0, 1], MM[:, 0, 3]
        da, db, dd = MM[:, 1, 0], MM[:, 1, 1], MM[:, 1, 3]
        v0, v1 = dq[:, 0], dq[:, 1]
        w0 = da * v0 + db * v1
        w1 = db * v0 + dd * v1
        r0 = tau[:, 0] - g[:, 0] - w0 * v1
        r1 = tau[:, 1] - g[:, 1] - w1 * v1 + 0.5 * (v0 * w0 + v1 * w1)
        det = a * d - b * b
        out = np.empty((P, 2))
        out[:, 0] = (d * r0 - b * r1) / det
        out[:, 1] = (a * r1 - b * r0) / det
        return out


class PinocchioBatch:
    """``pinocchio.aba`` per parameter set: the fallback for any URDF."""

    def __init__(self, robot: RobotModel, theta: np.ndarray, armature: np.ndarray) -> None:
        self.robot = robot
        P = theta.shape[0]
        self.models, self.datas = [], []
        for i in range(P):
            m = pin.Model(robot.pin_model)
            for j in range(robot.nv):
                m.inertias[j + 1] = pin.Inertia.FromDynamicParameters(theta[i, 10 * j : 10 * j + 10])
            for j, jn in enumerate(robot.joint_names):
                m.armature[m.joints[m.getJointId(jn)].idx_v] = armature[i, j]
            self.models.append(m)
            self.datas.append(m.createData())
        self.simple = not robot.continuous

    def forward(self, q, dq, tau) -> np.ndarray:
        out = np.empty_like(q)
        conf = self.robot.configuration
        for i, (m, d) in enumerate(zip(self.models, self.datas)):
            if not np.all(np.isfinite(q[i])) or not np.all(np.isfinite(dq[i])):
                out[i] = np.nan
                continue
            out[i] = pin.aba(m, d, q[i] if self.simple else conf(q[i]), dq[i], tau[i])
        return out

    def gravity(self, q0: np.ndarray) -> np.ndarray:
        conf = q0 if self.simple else self.robot.configuration(q0)
        return np.array([pin.computeGeneralizedGravity(m, d, conf) for m, d in zip(self.models, self.datas)])

    def mass_matrix(self, q0: np.ndarray) -> np.ndarray:
        conf = q0 if self.simple else self.robot.configuration(q0)
        out = []
        for m, d in zip(self.models, self.datas):
            M = pin.crba(m, d, conf)
            out.append(np.triu(M) + np.triu(M, 1).T)
        return np.array(out)

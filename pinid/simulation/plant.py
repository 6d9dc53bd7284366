"""The twin's plant: the equations of motion with joint friction and more joint terms, and one integration
step (:class:`Plant`), shared by the twin's recording runs (:func:`pinid.simulation.twin.simulate`) and the
closed loops of :func:`pinid.control.controllers.track`."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from pinid.model import terms as _terms
from pinid.model.robot import RobotModel


class Plant:
    """The twin's equations of motion, M(q)·ddq + h(q, dq) + fc·tanh(dq/v_s) + fv·dq + Σ terms = τ, and one
    integration step (see :mod:`pinid.simulation.twin`'s text: implicit friction when stiff, velocity first, trapezoidal
    position).  ``coulomb`` [N·m], ``viscous`` [N·m·s/rad] per joint, ``coulomb_velocity`` v_s [rad/s].

    With drives (``model.drives`` with nominal motor values) the motors add, through ``G``:
    rotor inertia ``Gᵀ·diag(Im)·G`` to M, and ``Gᵀ·(fc_m·tanh(G·dq/v_s) + fv_m·G·dq + offset_m)``.

    ``terms``: more joint terms of the registry (:mod:`pinid.model.terms`) with their true per-joint
    values, e.g. ``{"passive": [1, 1], "fc_pos": [...]}``; each acts through its own plant law
    (``Term.torque`` with ``smoothing = v_s``), an inertia term adds its values to M's diagonal, and a
    term with a smoothed law (Coulomb-like, stiff near zero velocity) joins the implicit friction with
    its velocity derivative (central difference); a term that reads the acceleration (``Term.load``: ``fl``,
    through the rigid-body torque) is solved with it by fixed-point iteration, started at the last step's."""

    def __init__(
        self,
        model: RobotModel,
        coulomb: np.ndarray,
        viscous: np.ndarray,
        coulomb_velocity: float,
        terms: dict[str, np.ndarray] | None = None,
    ) -> None:
        self.model = model
        self.fc = np.asarray(coulomb, dtype=float)
        self.fv = np.asarray(viscous, dtype=float)
        self._vs = coulomb_velocity
        self._ivs = 1.0 / coulomb_velocity
        self._data = model.pin_model.createData()
        self._eye = np.eye(model.nv)
        self._conf = model.configuration if model.continuous else None  # q is Pinocchio's configuration
        extra = [(_terms.TERMS[n], np.asarray(v, dtype=float)) for n, v in (terms or {}).items()]
        self.extra = [(t, v) for t, v in extra if not t.inertia]
        self._load = any(t.load for t, _ in self.extra)  # a term reads the acceleration (fl): solved by iteration
        self._a = np.zeros(model.nv)  # the last step's acceleration: the iteration's start
        added = sum((v for t, v in extra if t.inertia), np.zeros(model.nv))
        d = model.drives
        self.motor = None
        self.rotor = np.diag(added) if np.any(added) else None
        if d is not None and any(np.any(d.nominal(k) != 0) for k in ("fc", "fv", "armature", "offset")):
            G = d.matrix
            self.motor = {k: d.nominal(k) for k in ("fc", "fv", "armature", "offset")}
            self.G = G
            rotor = G.T @ (self.motor["armature"][:, None] * G)  # Gᵀ·diag(Im)·G [kg·m²]
            self.rotor = rotor if self.rotor is None else rotor + self.rotor
        self._fc_ivs = self.fc * self._ivs  # fc/v_s: the slope of the smoothed Coulomb law at zero velocity

    def _extra(self, q: np.ndarray, v: np.ndarray, a: np.ndarray, slope: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """Torque [N·m] of the extra terms at (q, v, a), and its velocity derivative (diagonal) [N·m·s/rad]."""

        def f(terms, vel):
            m = _terms.Motion(q[None], vel[None], a[None], self.model.joint_names, self.model)
            return sum((t.torque(x, m, self._vs)[0] for t, x in terms), np.zeros(q.size))

        stiff = [(t, x) for t, x in self.extra if t.plant is not None]
        D = np.zeros(q.size)
        if stiff and slope:
            dv = 1e-3 * self._vs
            D = (f(stiff, v + dv) - f(stiff, v - dv)) / (2 * dv)
        return f(self.extra, v), D

    def step(
        self, q: np.ndarray, v: np.ndarray, tau: np.ndarray, h: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(ddq, q_next, v_next)``: the acceleration at (q, v) under ``tau`` and the state ``h`` [s] later."""
        pm, pdata = self.model.pin_model, self._data
        qc = q if self._conf is None else self._conf(q)
        nle = pin.nonLinearEffects(pm, pdata, qc, v)
        th = np.tanh(v * self._ivs)
        Dx = 0.0
        if self.extra:
            fx, Dx = self._extra(q, v, self._a if self._load else np.zeros_like(v))
            tau = tau - fx
        if self.rotor is None:
            Minv = pin.computeMinverse(pm, pdata, qc)
            a = Minv @ (tau - nle - self.fc * th - self.fv * v)
            D = self._fc_ivs * (1.0 - th * th) + self.fv
            if self.extra:
                D = D + Dx
            stiff = h * float((Minv.diagonal() * D).max()) > 0.1
            D = np.diag(D) if stiff else D
        else:
            M = pin.crba(pm, pdata, qc)
            M = np.triu(M) + np.triu(M, 1).T + self.rotor
            Minv = np.linalg.inv(M)
            f = self.fc * th + self.fv * v
            D = np.diag(self._fc_ivs * (1.0 - th * th) + self.fv + Dx)
            if self.motor is not None:
                m, G = self.motor, self.G
                vm = G @ v
                thm = np.tanh(vm * self._ivs)
                f = f + G.T @ (m["fc"] * thm + m["fv"] * vm + m["offset"])
                Dm = m["fc"] * self._ivs * (1.0 - thm * thm) + m["fv"]
                D = D + G.T @ (Dm[:, None] * G)
            a = Minv @ (tau - nle - f)
            stiff = h * float(np.abs(Minv @ D).max()) > 0.1
        if self._load:  # solve a = M⁻¹·(τ − nle − f − f_x(q, v, a)) =: base − M⁻¹·f_x(q, v, a) by Newton
            base, K = a + Minv @ fx, None
            for _ in range(50):
                fa = self._extra(q, v, a, slope=False)[0]
                g = a - base + Minv @ fa
                if np.abs(g).max() <= 1e-13 * (1.0 + np.abs(a).max()):
                    break
                if K is None:  # ∂f_x/∂a by differences: exact for fl, affine in a between sign changes
                    e = 1e-6 * (1.0 + np.abs(a).max())
                    J = np.stack([(self._extra(q, v, a + e * u, slope=False)[0] - fa) / e for u in self._eye], axis=1)
                    K = np.linalg.inv(self._eye + Minv @ J)
                a = a - K @ g
            self._a = a
        if stiff:  # near zero velocity: implicit friction
            dv = np.linalg.solve(self._eye + (h * Minv) @ D, h * a)
        else:
            dv = h * a
        v_new = v + dv
        return a, q + (0.5 * h) * (v + v_new), v_new

"""Instrumental variables (IDIM-IV, Gautier & Janot): instruments from a simulation of the previous estimate.

Least squares on ``τ = W(q, dq, ddq)·β`` is biased when the regressor itself is noisy (errors in
variables: ``dq`` and ``ddq`` come from differentiating noisy positions).  IDIM-IV replaces the noisy
regressor by an *instrument* ``Z`` — a regressor correlated with ``W`` but not with its noise — and solves
``Zᵀ·diag(w)·W·β = Zᵀ·diag(w)·τ``.  Janot, Vandanjon & Gautier build ``Z = W(q_s, dq_s, ddq_s)`` from a
simulation of the robot model with the previous estimate, iterate until the parameters settle, start
from OLS.  When the OLS estimate cannot be simulated (a mass matrix that is not positive definite along
the motion makes the simulation diverge; it happens with noisy positions) pinid starts from the
physically consistent ``sdp`` estimate instead (``info_["start"]`` says which).  An iteration whose
estimate cannot be simulated ends the iterations, and the previous estimate (the last one simulated) is
returned; ``status_`` says so.

**The simulation (what pinid can do without the controller).**  The paper simulates the closed loop
with the rig's controller and reference trajectory.  A pinid problem carries neither (recordings have
q, dq, ddq, τ; no reference, no gains), so the model with base parameters ``β`` is simulated under the
*measured* torque, kept on the measured trajectory by a PD on the measured (preprocessed) positions::

    M_β(q_s)·ddq_s + n_β(q_s, dq_s) = τ_m + K_p·(q_m − q_s) + K_d·(dq_m − dq_s)

with ``K_p = M_jj·ω²``, ``K_d = 2·M_jj·ω`` (both poles at −ω, ``ω = 2π·bandwidth``, ``M_jj`` the diagonal of
the simulated model's mass matrix at the first sample; the URDF's where that is not positive).  ``M_β`` and ``n_β`` come from the base regressor itself
(every joint term, drives included), so any base parameters can be simulated.  Integration: classic
Runge–Kutta 4 on every sample interval (``substeps`` steps each), τ_m, q_m, dq_m interpolated by cubic
splines; the instrument row of sample k is ``W(q_s, dq_s, ddq_s)`` with the instantaneous simulated
acceleration.  Recordings faster than ``sim_rate`` (default 250 Hz) are integrated on every
⌊rate/sim_rate⌋-th sample only, the samples between filled by cubic Hermite interpolation of q (slopes
dq) and dq (slopes ddq): a 2 Hz closed loop needs no 1 kHz grid, and a minute of 1 kHz data then costs
seconds, not minutes (``sim_rate=None``: every sample).
This is the reconstruction BIRDy's IV uses when only measured signals are available.  The instruments
are not entirely free of the measurement noise: the PD passes the position noise through a low-pass
of bandwidth ω and the measured torque's noise enters ``ddq_s`` — their correlation with the regressor's
errors is second order in the noise, like the bias IV removes (docs/identification.md, "Real-data
estimators", measures what it gives).

On noise-free data ``W·β_true = τ`` exactly, so any instruments with ``ZᵀW`` invertible return the truth:
IV is consistent there whatever the simulation's accuracy.

The simulation needs the recordings (``problem.regressor_rows``, which every
:meth:`~pinid.problem.problem.IdentificationProblem.from_datasets` problem has); a problem made
from a bare ``W`` or a segmental stage is a :class:`~pinid.errors.SpecError`.

``physical=True``: every iteration solves the IV equations as two-stage least squares
(``min ‖P_Z·(W·β − τ)‖`` with ``P_Z`` the projection onto the instruments — the same solution as IV when
``ZᵀW`` is invertible) under the LMI constraints of :class:`~pinid.estimators.sdp.SDP`, so the
result is physically consistent.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pinocchio as pin

from pinid.data.dataset import Dataset
from pinid.errors import SolverError, SpecError
from pinid.estimators.base import Estimator, Setting
from pinid.estimators.sdp import SDP
from pinid.problem.problem import IdentificationProblem, Problem, RegressorRows, base_regressor
from pinid.linalg import solve_r
from pinid.model import terms as _terms


#: Largest ω·h [-] of one Runge–Kutta step (ω = 2π·bandwidth, h the step): RK4 on the PD's poles at −ω is
#: stable to ω·h ≈ 2.8; a lower ``sim_rate`` makes every simulation diverge.
RK4_STEP_LIMIT = 2.5


class ModelSimulation:
    """The model with base parameters ``β`` simulated on each recording of ``problem`` under the measured
    torque and a PD on the measured positions (see the module text); :meth:`instruments` returns the base
    regressor ``W(q_s, dq_s, ddq_s)`` on the problem's rows."""

    def __init__(
        self, problem: IdentificationProblem, bandwidth: float = 2.0, substeps: int = 1, rate: float | None = 250.0
    ) -> None:
        rows = getattr(problem, "regressor_rows", None)
        if not isinstance(rows, RegressorRows):  # a floating problem's rows have recordings too, not fixed-base ones
            raise SpecError(
                "iv/didim simulate the model on the recordings: expected a problem made from recordings of a "
                "fixed-base robot (IdentificationProblem.from_datasets), not a bare regressor, a segmental "
                "stage or a floating base"
            )
        low = 2 * math.pi * float(bandwidth) / (RK4_STEP_LIMIT * max(int(substeps), 1))
        if rate is not None and float(rate) < low:
            raise SpecError(
                f"sim_rate={rate:g} Hz is too low for the PD bandwidth {bandwidth:g} Hz: expected sim_rate ≥ "
                f"{low:.3g} Hz (ω·h ≤ {RK4_STEP_LIMIT:g} per Runge–Kutta step; default 250 Hz), or none for every sample"
            )
        self.problem = problem
        self.rows = rows
        self.bandwidth = float(bandwidth)
        self.substeps = int(substeps)
        self.rate = None if rate is None else float(rate)
        model = problem.model
        self.nv = model.nv
        self._pm = model.pin_model
        self._data = self._pm.createData()
        self._conf = model.configuration if model.continuous else (lambda x: x)
        self._omega = 2 * math.pi * self.bandwidth
        self._nominal = problem.nominal_base

    def _gains(self, q0: np.ndarray, split) -> tuple[np.ndarray, np.ndarray]:
        """PD gains ``(K_p, K_d)`` [N·m/rad, N·m·s/rad] putting both poles of each joint at −ω: ``M_jj`` of the
        simulated model at ``q0`` (so a light estimate is not driven by stiff gains), the URDF's where that
        diagonal is not positive."""
        mjj = np.diag(self._mass_bias(q0, np.zeros(self.nv), None, split)[0]).copy()
        bad = ~(np.isfinite(mjj) & (mjj > 0))
        if np.any(bad):
            nominal = np.diag(self._mass_bias(q0, np.zeros(self.nv), self._nominal)[0])
            mjj[bad] = np.where(nominal[bad] > 0, nominal[bad], 1.0)
        w = self._omega
        return mjj * w * w, 2 * mjj * w

    # ------------------------------------------------------------------ dynamics of base parameters
    def _split(self, base: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        theta = np.zeros(len(self.problem.base.standard_names))
        theta[self.problem.base.independent] = base
        ni = 10 * self.nv
        return theta[:ni], theta[ni:]

    def _mass_bias(self, q: np.ndarray, v: np.ndarray, base: np.ndarray, split=None) -> tuple[np.ndarray, np.ndarray]:
        """``(M(q), n(q, v))`` of the model ``τ = W_b·base`` [kg·m², N·m]: n = W(q, v, 0)·β, M's columns
        W(q, 0, e_i)·β − W(q, 0, 0)·β (Pinocchio's regressor and the terms' columns)."""
        th_in, th_t = split if split is not None else self._split(base)
        nv, pm, d = self.nv, self._pm, self._data
        qc = self._conf(q)
        zero = np.zeros(nv)
        compute = pin.computeJointTorqueRegressor
        n = compute(pm, d, qc, v, zero) @ th_in
        g = compute(pm, d, qc, zero, zero) @ th_in
        M = np.empty((nv, nv))
        e = np.zeros(nv)
        for i in range(nv):
            e[i] = 1.0
            M[:, i] = compute(pm, d, qc, zero, e) @ th_in - g
            e[i] = 0.0
        if th_t.size and np.any(th_t):
            Q = np.repeat(q[None], nv + 2, axis=0)
            V = np.zeros((nv + 2, nv))
            V[0] = v
            A = np.zeros((nv + 2, nv))
            A[2:] = np.eye(nv)
            tt = _terms.columns(self.problem.model, self.problem.terms, Q, V, A) @ th_t  # (nv+2, nv)
            n = n + tt[0]
            M = M + (tt[2:] - tt[1]).T
        return M, n

    def simulate(self, base: np.ndarray) -> list[Dataset]:
        """The simulated recordings (q_s, dq_s, ddq_s, the measured τ) for base parameters ``base``;
        SolverError when the simulation diverges or the mass matrix is singular."""
        split = self._split(np.asarray(base, dtype=float))
        return [self._one(ds, self._gains(ds.q[0], split), base, split) for ds in self.rows.datasets]

    def _one(self, ds: Dataset, gains, base, split) -> Dataset:
        Kp, Kd = gains
        t, qm, vm, tm = ds.t, ds.q, ds.dq, ds.tau
        n, nv, s = ds.n, self.nv, self.substeps
        span = np.maximum(np.ptp(qm, axis=0), 1e-3)

        def accel(q, v, tau, qr, vr):
            M, bias = self._mass_bias(q, v, base, split)
            try:
                return np.linalg.solve(M, tau + Kp * (qr - q) + Kd * (vr - v) - bias)
            except np.linalg.LinAlgError as exc:
                raise SolverError(f"{ds.source}: simulating the estimate, its mass matrix is singular") from exc

        # inputs between samples: not-a-knot cubic splines of τ_m, q_m, dq_m (4th order, as Runge–Kutta)
        from scipy.interpolate import CubicHermiteSpline, CubicSpline  # heavy import, only when simulating

        signals = np.stack([tm, qm, vm], axis=1)  # (n, 3, nv)
        spline = CubicSpline(t, signals, axis=0) if n >= 4 else None
        # the grid integrated: every `stride`-th sample (at most `rate` Hz) and the last one
        fs = (n - 1) / (t[-1] - t[0]) if n > 1 and t[-1] > t[0] else 1.0
        stride = max(1, int(fs // self.rate)) if self.rate else 1
        nodes = np.unique(np.r_[np.arange(0, n, stride), n - 1])
        t0, t1 = t[nodes[:-1]], t[nodes[1:]]
        fractions = sorted({j / s for j in range(s)} | {(j + 0.5) / s for j in range(s)} | {1.0})
        if spline is not None:
            at = {f: spline(t0 + f * (t1 - t0)) for f in fractions}
        else:
            at = {f: signals[nodes[:-1]] + f * (signals[nodes[1:]] - signals[nodes[:-1]]) for f in fractions}
        m = len(nodes)
        q_s, v_s, a_s = np.empty((m, nv)), np.empty((m, nv)), np.empty((m, nv))
        q, v = qm[0].copy(), vm[0].copy()
        for i, k in enumerate(nodes):
            a = accel(q, v, tm[k], qm[k], vm[k])
            q_s[i], v_s[i], a_s[i] = q, v, a
            if not (np.all(np.isfinite(a)) and np.all(np.abs(q - qm[k]) <= 10 * span + 1.0)):
                raise SolverError(
                    f"{ds.source}: the simulation of the estimate diverged at t = {t[k]:.4g} s "
                    "(an estimate far from physical, or a PD too weak: raise bandwidth)"
                )
            if i == m - 1:
                break
            h = (t1[i] - t0[i]) / s
            for j in range(s):
                u0, um, u1 = (at[f][i] for f in (j / s, (j + 0.5) / s, (j + 1) / s))
                k1v, k1a = v, (a if j == 0 else accel(q, v, *u0))
                k2v = v + 0.5 * h * k1a
                k2a = accel(q + 0.5 * h * k1v, k2v, *um)
                k3v = v + 0.5 * h * k2a
                k3a = accel(q + 0.5 * h * k2v, k3v, *um)
                k4v = v + h * k3a
                k4a = accel(q + h * k3v, k4v, *u1)
                q = q + (h / 6) * (k1v + 2 * k2v + 2 * k3v + k4v)
                v = v + (h / 6) * (k1a + 2 * k2a + 2 * k3a + k4a)
        if m < n:  # the samples between nodes: cubic Hermite of q (slopes dq) and dq (slopes ddq)
            vel = CubicHermiteSpline(t[nodes], v_s, a_s, axis=0)
            q_s = CubicHermiteSpline(t[nodes], q_s, v_s, axis=0)(t)
            v_s, a_s = vel(t), vel.derivative()(t)
        return Dataset(t, q_s, ds.joints, dq=v_s, ddq=a_s, tau=tm, source=f"{ds.source} (simulated)")

    def instruments(self, base: np.ndarray) -> np.ndarray:
        """``Z = W_b(q_s, dq_s, ddq_s)`` on the problem's rows (rows × nb) for base parameters ``base``."""
        p, rows = self.problem, self.rows
        sims = self.simulate(base)
        return np.concatenate(
            [base_regressor(p.model, p.terms, p.base, sim, keep=keep) for sim, keep in zip(sims, rows.keeps)]
        )


def _iv_solve(Z: np.ndarray, W: np.ndarray, tau: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """``β`` of ``Zᵀ·diag(w)·W·β = Zᵀ·diag(w)·τ`` (columns scaled to unit norm; SolverError when singular)."""
    sw = np.linalg.norm(W * np.sqrt(weights)[:, None], axis=0)
    sz = np.linalg.norm(Z * np.sqrt(weights)[:, None], axis=0)
    sw[sw == 0] = 1.0
    sz[sz == 0] = 1.0
    Zw = (Z / sz) * weights[:, None]
    A = Zw.T @ (W / sw)
    if not np.all(np.isfinite(A)) or np.linalg.cond(A) > 1e12:
        raise SolverError("iv: the instruments are (nearly) uncorrelated with the regressor (ZᵀW singular)")
    return np.linalg.solve(A, Zw.T @ tau) / sw


def physical_fit(
    problem: IdentificationProblem, W: np.ndarray, weights: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Base parameters of :class:`~pinid.estimators.sdp.SDP` (LMI-constrained least squares) on the
    problem with regressor ``W`` (and row ``weights``) in place of its own; returns ``(base, standard)``."""
    sub = replace(problem, W=W, weights=problem.weights if weights is None else weights, regressor_rows=None)
    est = SDP().fit(sub)
    return est.base_, est.standard_


def simulated_start(
    problem: IdentificationProblem, sim: ModelSimulation, what: str
) -> tuple[np.ndarray, np.ndarray, str]:
    """``(β₀, Z₀, start)``: the OLS estimate and its simulated regressor; when the OLS estimate cannot be
    simulated (its mass matrix is not positive definite along the motion: the simulation diverges), the
    physically consistent least-squares estimate (``sdp``, positive definite by construction) instead.
    SolverError when neither can be simulated."""
    R, c, _, scale = problem.compressed()
    x = solve_r(R, c, scale)
    try:
        return x, sim.instruments(x), "ols"
    except SolverError as first:
        try:
            x = SDP().fit(problem).base_
            return x, sim.instruments(x), "sdp (the OLS estimate could not be simulated)"
        except SolverError as exc:
            raise SolverError(f"{what}: simulating the OLS estimate failed ({first}), and the sdp one ({exc})") from exc


class SimulatingEstimator(Estimator):
    """What the estimators that simulate the model on the recordings (iv, didim) share: their settings
    and construction, and :attr:`~pinid.estimators.base.Estimator.simulates` (left out of the every-method
    defaults)."""

    simulates = True
    cost = 1000.0  # a simulation of the robot per pass: seconds to tens of seconds
    history = "passes"
    settings = {
        "iterations": Setting("int", low=1, help="iterations at most"),
        "tol": Setting("float", low=0.0, help="stop when the parameters change less than this, relatively"),
        "bandwidth": Setting("float", low=0.0, low_open=True, help="PD bandwidth [Hz] of the simulation"),
        "substeps": Setting("int", low=1, high=100, help="Runge–Kutta steps per integrated interval"),
        "sim_rate": Setting("float", low=0.0, low_open=True, optional=True, help="integrate at most at this rate [Hz]"),
        "physical": Setting("bool", help="physically consistent (LMI) least squares at every iteration"),
    }

    def __init__(
        self,
        iterations: int = 10,
        tol: float = 1e-6,
        bandwidth: float = 2.0,
        substeps: int = 1,
        sim_rate: float | None = 250.0,
        physical: bool = False,
    ) -> None:
        self.iterations = iterations
        self.tol = tol
        self.bandwidth = bandwidth
        self.substeps = substeps
        self.sim_rate = sim_rate
        self.physical = physical


class InstrumentalVariables(SimulatingEstimator):
    """IDIM-IV: instruments from a simulation of the previous estimate, iterated from OLS (module text).

    Settings: ``iterations`` (at most, default 10), ``tol`` (stop when the base parameters change less
    than this, relatively; default 1e-6), ``bandwidth`` [Hz] of the PD that keeps the simulation on the
    measured positions (default 2), ``substeps`` (Runge–Kutta steps per integrated interval, default 1),
    ``sim_rate`` (integrate at most at this rate [Hz], default 250; None: every sample),
    ``physical`` (each iteration as LMI-constrained two-stage least squares; default False).
    """

    name = "iv"
    summary = (
        "IDIM-IV (Janot, Vandanjon & Gautier): `Zᵀ W β = Zᵀ τ` with instruments `Z = W(q_s, dq_s, ddq_s)` "
        "from a simulation of the previous estimate, iterated from OLS"
    )
    assumptions = (
        "the simulated motion is correlated with the true one and not with the regressor's noise (see below: "
        "only approximately, without the rig's controller)"
    )
    settings_summary = "`iterations` (10), `tol` (1e-6), `bandwidth` (2 Hz), `substeps` (1), `physical` (False)"
    description = "instrumental variables (IDIM-IV): instruments from a simulation of the previous estimate"
    colour = "#800000"

    def lazy_imports(self) -> tuple[str, ...]:
        """The splines of its simulation (scipy.interpolate)."""
        return ("scipy.interpolate",)

    def fit(self, problem: Problem) -> "InstrumentalVariables":
        """OLS, then IV with instruments simulated from the previous estimate until it settles; sets ``base_``."""
        sim = ModelSimulation(problem, self.bandwidth, self.substeps, self.sim_rate)
        x, Z, start = simulated_start(problem, sim, "iv")
        W, tau, w = problem.W, problem.tau, problem.weights
        history, standard, status = [], None, "ok"
        change = float("inf")
        previous = (x, None)  # the last estimate whose simulation succeeded
        for k in range(int(self.iterations)):
            if k > 0:
                try:
                    Z = sim.instruments(x)
                except SolverError as exc:
                    x, standard = previous  # an estimate that cannot be simulated is not returned
                    status = (
                        f"stopped at iteration {k + 1} (its estimate cannot be simulated: {exc}); previous one returned"
                    )
                    break
                previous = (x, standard)
            if self.physical:
                Zs = Z * np.sqrt(w)[:, None]
                coef, *_ = np.linalg.lstsq(Zs, W * np.sqrt(w)[:, None], rcond=None)
                x_new, standard = physical_fit(problem, Z @ coef)
            else:
                x_new = _iv_solve(Z, W, tau, w)
            change = float(np.linalg.norm(x_new - x) / max(np.linalg.norm(x_new), 1e-300))
            history.append(change)
            x = x_new
            if change < self.tol:
                break
        self.base_ = x
        self.standard_ = standard
        self.weights_ = None
        self.history_ = history
        self.status_ = status if status != "ok" or change < self.tol else f"not settled after {len(history)} iterations"
        self.info_ = {
            "iterations": len(history),
            "last_change": change,
            "bandwidth_hz": float(self.bandwidth),
            "start": start,
        }
        return self

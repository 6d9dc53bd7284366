"""Physically consistent least squares: a semidefinite program (cvxpy + Clarabel).

Decision variable: the full standard parameter vector θ (10 per body + joint terms), so that physical
consistency can be imposed on every body.  Problem::

    minimise    ‖R·C·P·θ − c‖ / ‖y‖  +  λ·‖N·S⁻¹(θ − θ_nominal)‖
    subject to  J_i(θ) ⪰ ε·M_i·diag(L_i², L_i², L_i², 1)     every body i (pseudo-inertia LMI)
                fc ≥ 0, fv ≥ 0, armature ≥ 0                 every joint (when in the model)
                m_lo ≤ m_i ≤ m_hi                              optional mass bounds

* The data term is ‖W_b·P·θ − τ‖ (rows weighted), compressed by one pass over the column-scaled
  ``[W_b | τ]`` (:func:`~pinid.estimators.base.augmented_r`): ``‖W_b x − τ‖² = ‖R·C·x − c‖² + ρ²`` with
  ``R`` only nb × nb, so cvxpy never sees the tall regressor (``../shared/design.md``).  It is the *norm* of the excess
  residual, not its square: the minimiser is the same, but the cost has a kink where the excess is
  zero, so when the least-squares solution is physically realisable it is returned exactly (an exact
  penalty) whatever the small regulariser does; on noise-free data of a consistent robot the base
  parameters come back to solver precision.
* The regulariser pulls θ toward the URDF's nominal parameters only in the directions the data cannot
  see: ``N`` projects (in the scaled coordinates ``S⁻¹θ``) onto the null space of the base map ``P``,
  so it never competes with the data on a base parameter; it only decides how a base parameter is
  shared out among the standard ones.  ``S`` is :func:`pinid.model.physical.parameter_scale` (mass, mass ×
  length, mass × length² per body).  Default weight ``regularization = 1e-3``; 0 switches it off (the
  split among standard parameters is then whatever the solver lands on).
* ε = ``margin`` (default 1e-8) keeps every pseudo-inertia strictly positive definite, so that the
  mass matrix of the result is positive definite at every configuration.
* ``weighting="joint"`` weights each joint's rows by 1/σ_j² from an ordinary least-squares pass, as
  :class:`~pinid.estimators.wls.WLS` does; the default ``"none"`` weights rows by ``problem.weights``.

The result is checked afterwards (:func:`pinid.model.physical.check_consistency`): a solver status other
than ``optimal`` (``optimal_inaccurate`` included) is accepted only when that check passes and the
base parameters follow from θ; anything else raises :class:`~pinid.errors.SolverError`.
"""

from __future__ import annotations

import warnings

import numpy as np

from pinid.errors import SolverError
from pinid.model import terms as _terms
from pinid.model.physical import PSEUDO_INERTIA_BASIS, check_consistency, parameter_scale
from pinid.estimators.base import Estimator, augmented_r, joint_weights, solve_r


class PhysicalLS(Estimator):
    """Physically consistent least squares (LMI on every body's pseudo-inertia; see the module text).

    Settings: ``weighting`` ("none" or "joint"), ``regularization`` (weight λ of the pull toward the
    nominal parameters in unidentifiable directions, default 1e-3), ``mass_bounds`` (``(lo, hi)`` [kg]
    for every body, or ``{joint: (lo, hi)}``; None for none), ``margin`` (ε, default 1e-8), ``solver``
    (a cvxpy solver name, default "CLARABEL"), ``solver_options`` (dict passed to the solver).
    """

    name = "sdp"
    description = "physically consistent least squares (pseudo-inertia LMI, cvxpy + Clarabel)"
    consistent_by_construction = True

    def __init__(self, weighting: str = "none", regularization: float = 1e-3, mass_bounds=None,
                 margin: float = 1e-8, solver: str = "CLARABEL", solver_options: dict | None = None) -> None:
        self.weighting = weighting
        self.regularization = regularization
        self.mass_bounds = mass_bounds
        self.margin = margin
        self.solver = solver
        self.solver_options = solver_options

    def fit(self, problem) -> "PhysicalLS":
        """Solve the LMI-constrained least squares; sets ``base_``, ``standard_`` and the solver's ``status_``; SolverError if it fails."""
        import cvxpy as cp

        if self.weighting not in ("none", "joint"):
            raise ValueError(f"sdp: weighting={self.weighting!r}, expected 'none' or 'joint'")
        if not self.regularization >= 0:
            raise ValueError(f"sdp: regularization={self.regularization}, expected ≥ 0")
        w = problem.weights
        if self.weighting == "joint":
            x = solve_r(*_take(problem.compressed(), 0, 1, 3))
            jw, _ = joint_weights(problem, problem.tau - problem.W @ x)
            w = w * jw
            R, c, rho, colscale = augmented_r(problem.W, problem.tau, w)
        else:
            R, c, rho, colscale = problem.compressed()
        norm_y = float(np.sqrt(c @ c + rho * rho)) or 1.0
        P = problem.base.P
        nv, nt = problem.nv, len(problem.terms)
        S = parameter_scale(problem.nominal, nv, nt)
        G = (R * colscale) @ P * S / norm_y  # z = θ/S  ->  excess residual (relative)
        g = c / norm_y
        p = P.shape[1]
        z = cp.Variable(p)
        cost = cp.norm(G @ z - g)
        reg = None
        if self.regularization > 0:
            N = _null_projector(P * S)
            if N is not None:
                z0 = problem.nominal / S
                reg = cp.norm(N @ (z - z0))
                cost = cost + float(self.regularization) * reg
        constraints = consistency_constraints(z, problem, S, self.margin, self.mass_bounds)
        prob = cp.Problem(cp.Minimize(cost), constraints)
        status = _solve(prob, self.solver, self.solver_options, "sdp")
        if z.value is None:
            raise SolverError(f"sdp: solver {self.solver} returned status '{status}' without a solution")
        theta = np.asarray(z.value, dtype=float) * S
        # clip tiny negative joint terms the interior-point solver leaves at −1e-12
        theta = _clip_terms(theta, problem)
        report = check_consistency(theta, problem.model.joint_names, problem.terms.names, problem.model.motor_names)
        if not report.consistent:
            raise SolverError(f"sdp: solver {self.solver} status '{status}', but the result is not physically "
                              f"consistent ({'; '.join(report.problems)}); not returned")
        self.standard_ = theta
        self.base_ = P @ theta
        self.weights_ = w
        self.history_ = None
        self.status_ = status
        excess = float(np.linalg.norm(G @ (theta / S) - g))
        self.info_ = {
            "solver": self.solver, "status": status,
            "solve_seconds": _solve_time(prob),
            "excess_residual_relative": excess,
            "regularizer": None if reg is None else float(reg.value),
        }
        return self


def _take(seq, *idx):
    return [seq[i] for i in idx]


def _null_projector(A: np.ndarray, tol: float = 1e-10) -> np.ndarray | None:
    """Orthogonal projector onto the null space of ``A`` (None when it is trivial)."""
    _, s, Vt = np.linalg.svd(A, full_matrices=True)
    rank = int(np.sum(s > tol * (s[0] if s.size else 1.0)))
    V0 = Vt[rank:].T
    if V0.shape[1] == 0:
        return None
    return V0 @ V0.T


def consistency_constraints(z, problem, S: np.ndarray, margin: float, mass_bounds=None) -> list:
    """cvxpy constraints making θ = S·z physically consistent (LMI per body, non-negative joint terms)."""
    import cvxpy as cp

    nv = problem.nv
    p = 10 * nv + _terms.count(problem.model, problem.terms)
    joints = problem.model.joint_names
    cons = []
    for i in range(nv):
        M = S[10 * i]
        L = np.sqrt(S[10 * i + 4] / M)
        T = np.diag([1.0 / (np.sqrt(M) * L)] * 3 + [1.0 / np.sqrt(M)])
        B = np.zeros((16, p))
        for k in range(10):
            B[:, 10 * i + k] = (T @ PSEUDO_INERTIA_BASIS[k] @ T).reshape(-1, order="F") * S[10 * i + k]
        J = cp.reshape(B @ z, (4, 4), order="F")
        cons.append(0.5 * (J + J.T) >> float(margin) * np.eye(4))
    idx = 10 * nv + np.flatnonzero(_terms.nonnegative(problem.model, problem.terms))
    if idx.size:
        cons.append(z[idx] >= 0)
    if mass_bounds is not None:
        bounds = mass_bounds if isinstance(mass_bounds, dict) else {j: mass_bounds for j in joints}
        for j, (lo, hi) in bounds.items():
            i = problem.model.joint_index(j)
            if lo is not None:
                cons.append(z[10 * i] >= float(lo) / S[10 * i])
            if hi is not None:
                cons.append(z[10 * i] <= float(hi) / S[10 * i])
    return cons


#: Clarabel's tolerances used by default (its own defaults are 1e-8): the data term is a norm with a
#: kink at the least-squares solution, and 1e-10 brings noise-free base parameters back to ≤ 1e-6.
CLARABEL_OPTIONS = {"tol_gap_abs": 1e-10, "tol_gap_rel": 1e-10, "tol_feas": 1e-10, "tol_ktratio": 1e-8}


def _solve(prob, solver: str, options: dict | None, what: str) -> str:
    """Solve a cvxpy problem; return its status, raise SolverError when it failed outright."""
    import cvxpy as cp

    opts = dict(CLARABEL_OPTIONS) if solver.upper() == "CLARABEL" else {}
    opts.update(options or {})
    try:
        with warnings.catch_warnings():  # the status says it; the result is checked by the caller
            warnings.simplefilter("ignore")
            prob.solve(solver=solver, **opts)
    except cp.error.SolverError as exc:
        raise SolverError(f"{what}: solver {solver} failed ({str(exc).strip().splitlines()[0]})") from None
    status = prob.status
    if status in (cp.INFEASIBLE, cp.INFEASIBLE_INACCURATE):
        raise SolverError(f"{what}: solver {solver} says the constraints are infeasible (status '{status}'); "
                          "check the mass bounds")
    if status in (cp.UNBOUNDED, cp.UNBOUNDED_INACCURATE):
        raise SolverError(f"{what}: solver {solver} says the problem is unbounded (status '{status}')")
    if status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE):
        raise SolverError(f"{what}: solver {solver} stopped with status '{status}'")
    return status


def _solve_time(prob) -> float | None:
    try:
        return float(prob.solver_stats.solve_time)
    except (AttributeError, TypeError):
        return None


def _clip_terms(theta: np.ndarray, problem) -> np.ndarray:
    out = theta.copy()
    params = _terms.robot_layout(problem.model, problem.terms)
    for name in {p.term.name for p in params if p.term.nonnegative}:
        idx = [10 * problem.nv + k for k, p in enumerate(params) if p.term.name == name]
        if idx:
            out[idx] = np.where((out[idx] < 0) & (out[idx] > -1e-9 * max(1.0, np.abs(out[idx]).max())), 0.0,
                                out[idx])
    return out


def consistent_completion(problem, base: np.ndarray, *, solver: str = "CLARABEL") -> tuple[np.ndarray | None, str]:
    """A physically consistent standard vector θ with ``P·θ = base``, as close to the nominal one as possible.

    Minimises ``‖S⁻¹(θ − θ_nominal)‖`` subject to ``P·θ = base``, every pseudo-inertia ⪰ 0 and
    non-negative fc, fv, armature.  Returns ``(θ, status)``, or ``(None, reason)`` when no consistent θ
    reproduces these base parameters (the base parameters are not physically realisable).  θ is checked:
    consistent, and ``P·θ`` equal to ``base`` within 1e-6 relatively.
    """
    import cvxpy as cp

    P = problem.base.P
    nv, nt = problem.nv, len(problem.terms)
    S = parameter_scale(problem.nominal, nv, nt)
    A = P * S
    bscale = np.maximum(np.abs(A).sum(axis=1), 1e-300)
    base = np.asarray(base, dtype=float)
    z = cp.Variable(P.shape[1])
    z0 = problem.nominal / S
    cons = [(A / bscale[:, None]) @ z == base / bscale]
    cons += consistency_constraints(z, problem, S, 0.0)
    prob = cp.Problem(cp.Minimize(cp.norm(z - z0)), cons)
    try:
        status = _solve(prob, solver, None, "consistent completion")
    except SolverError as exc:
        return None, str(exc)
    if z.value is None:
        return None, f"solver status '{status}' without a solution"
    theta = _clip_terms(np.asarray(z.value) * S, problem)
    mismatch = np.abs(P @ theta - base) / bscale
    if mismatch.max() > 1e-6:
        return None, f"solver status '{status}', base parameters reproduced only to {mismatch.max():.1e}"
    report = check_consistency(theta, problem.model.joint_names, problem.terms.names, problem.model.motor_names)
    if not report.consistent:
        return None, "; ".join(report.problems)
    return theta, status

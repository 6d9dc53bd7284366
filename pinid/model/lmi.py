"""Physical consistency as cvxpy constraints (pseudo-inertia LMI per body), solving, and consistent completion.

Used by the LMI estimator (:class:`pinid.estimators.sdp.PhysicalLS`), its segmental stages and the
completion of base-only results (:func:`consistent_completion`).  cvxpy is imported inside the
functions that build a problem, so importing this module (or wrapping a least-squares result without
completion) does not load it.
"""

from __future__ import annotations

import warnings

import numpy as np

from pinid.errors import SolverError
from pinid.linalg import RANK_TOL
from pinid.model import terms as _terms
from pinid.model.physical import PSEUDO_INERTIA_BASIS, check_consistency, parameter_scale


def null_projector(A: np.ndarray, tol: float = RANK_TOL) -> np.ndarray | None:
    """Orthogonal projector onto the null space of ``A`` (None when it is trivial)."""
    _, s, Vt = np.linalg.svd(A, full_matrices=True)
    rank = int(np.sum(s > tol * (s[0] if s.size else 1.0)))
    V0 = Vt[rank:].T
    if V0.shape[1] == 0:
        return None
    return V0 @ V0.T


def consistency_constraints(z, problem, S: np.ndarray, margin: float, mass_bounds=None) -> list:
    """cvxpy constraints making θ = S·z physically consistent (LMI per body, non-negative joint terms)."""
    import cvxpy as cp  # heavy optional dependency: imported only when an LMI problem is built

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


def solve(prob, solver: str, options: dict | None, what: str) -> str:
    """Solve a cvxpy problem; return its status, raise SolverError when it failed outright."""
    import cvxpy as cp  # heavy optional dependency: imported only when an LMI problem is built

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
        raise SolverError(
            f"{what}: solver {solver} says the constraints are infeasible (status '{status}'); check the mass bounds"
        )
    if status in (cp.UNBOUNDED, cp.UNBOUNDED_INACCURATE):
        raise SolverError(f"{what}: solver {solver} says the problem is unbounded (status '{status}')")
    if status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE):
        raise SolverError(f"{what}: solver {solver} stopped with status '{status}'")
    return status


def solve_time(prob) -> float | None:
    """The solver's own time [s] of a solved cvxpy problem (None when it does not say)."""
    try:
        return float(prob.solver_stats.solve_time)
    except (AttributeError, TypeError):
        return None


def clip_terms(theta: np.ndarray, problem) -> np.ndarray:
    """θ with tiny negative joint terms (fc, fv, armature above −1e-9 relatively) set to 0: what an interior-point solver leaves."""
    out = theta.copy()
    params = _terms.robot_layout(problem.model, problem.terms)
    for name in {p.term.name for p in params if p.term.nonnegative}:
        idx = [10 * problem.nv + k for k, p in enumerate(params) if p.term.name == name]
        if idx:
            out[idx] = np.where((out[idx] < 0) & (out[idx] > -1e-9 * max(1.0, np.abs(out[idx]).max())), 0.0, out[idx])
    return out


def consistent_completion(problem, base: np.ndarray, *, solver: str = "CLARABEL") -> tuple[np.ndarray | None, str]:
    """A physically consistent standard vector θ with ``P·θ = base``, as close to the nominal one as possible.

    Minimises ``‖S⁻¹(θ − θ_nominal)‖`` subject to ``P·θ = base``, every pseudo-inertia ⪰ 0 and
    non-negative fc, fv, armature.  Returns ``(θ, status)``, or ``(None, reason)`` when no consistent θ
    reproduces these base parameters (the base parameters are not physically realisable).  θ is checked:
    consistent, and ``P·θ`` equal to ``base`` within 1e-6 relatively.
    """
    import cvxpy as cp  # heavy optional dependency: imported only when an LMI problem is built

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
        status = solve(prob, solver, None, "consistent completion")
    except SolverError as exc:
        return None, str(exc)
    if z.value is None:
        return None, f"solver status '{status}' without a solution"
    theta = clip_terms(np.asarray(z.value) * S, problem)
    mismatch = np.abs(P @ theta - base) / bscale
    if mismatch.max() > 1e-6:
        return None, f"solver status '{status}', base parameters reproduced only to {mismatch.max():.1e}"
    report = check_consistency(theta, problem.model.joint_names, problem.terms.names, problem.model.motor_names)
    if not report.consistent:
        return None, "; ".join(report.problems)
    return theta, status

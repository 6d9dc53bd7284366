"""Physical consistency as conic constraints (pseudo-inertia LMI per body) and consistent completion.

Used by the LMI estimator (:class:`pinid.estimators.sdp.SDP`), its segmental stages and the
completion of base-only results (:func:`consistent_completion`).  The problems are stated with
:class:`pinid.model.conic.ConicProblem`: Clarabel solves them directly, cvxpy is loaded only for another
solver.
"""

from __future__ import annotations

import numpy as np

from pinid.errors import SolverError
from pinid.linalg import RANK_TOL
from pinid.model.conic import ConicProblem
from pinid.model import terms as _terms
from pinid.model.physical import PSEUDO_INERTIA_BASIS, check_consistency, parameter_scale
from pinid.checks import array_like, as_floats, count
from pinid.errors import SpecError


def null_projector(A: np.ndarray, tol: float = RANK_TOL) -> np.ndarray | None:
    """Orthogonal projector onto the null space of ``A`` (None when it is trivial)."""
    array_like(A, "A")
    _, s, Vt = np.linalg.svd(A, full_matrices=True)
    rank = int(np.sum(s > tol * (s[0] if s.size else 1.0)))
    V0 = Vt[rank:].T
    if V0.shape[1] == 0:
        return None
    return V0 @ V0.T


def add_consistency_constraints(conic: ConicProblem, problem, S: np.ndarray, margin: float, mass_bounds=None) -> None:
    """Constrain θ = S·z of ``conic`` to be physically consistent: every pseudo-inertia ⪰ ``margin``·M·diag(L², L², L², 1),
    non-negative joint terms, masses within ``mass_bounds`` ((lo, hi) [kg] for every body, or {joint: (lo, hi)})."""
    if not hasattr(problem, "nv"):
        raise SpecError(
            f"problem: got {type(problem).__name__}, expected an identification problem (IdentificationProblem)"
        )
    nv = problem.nv
    p = conic.n
    joints = problem.model.joint_names
    for i in range(nv):
        conic.add_psd(pseudo_inertia_map(S, i, p), -float(margin) * np.eye(4).reshape(-1))
    idx = 10 * nv + np.flatnonzero(_terms.nonnegative(problem.model, problem.terms))
    if idx.size:
        conic.add_inequality(np.eye(p)[idx], 0.0)
    if mass_bounds is not None:
        bounds = mass_bounds if isinstance(mass_bounds, dict) else {j: mass_bounds for j in joints}
        for j, (lo, hi) in bounds.items():
            k = 10 * problem.model.joint_index(j)  # the body's mass m = S_k·z_k
            if lo is not None:
                conic.add_inequality(np.eye(p)[k], float(lo) / S[k])
            if hi is not None:
                conic.add_inequality(-np.eye(p)[k], -float(hi) / S[k])


def clip_terms(theta: np.ndarray, problem) -> np.ndarray:
    """θ with tiny negative joint terms (fc, fv, armature above −1e-9 relatively) set to 0: what an interior-point solver leaves."""
    array_like(theta, "theta")
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
    if not hasattr(problem, "base"):
        raise SpecError(
            f"problem: got {type(problem).__name__}, expected an identification problem (IdentificationProblem)"
        )
    P = problem.base.P
    nv, nt = problem.nv, len(problem.terms)
    S = parameter_scale(problem.nominal, nv, nt)
    A = P * S
    bscale = np.maximum(np.abs(A).sum(axis=1), 1e-300)
    base = np.asarray(base, dtype=float)
    conic = ConicProblem(P.shape[1])
    conic.add_norm(np.eye(P.shape[1]), problem.nominal / S)
    conic.add_equality(A / bscale[:, None], base / bscale)
    add_consistency_constraints(conic, problem, S, 0.0)
    try:
        solution = conic.solve(solver, None, "consistent completion")
    except SolverError as exc:
        return None, str(exc)
    status = solution.status
    theta = clip_terms(solution.z * S, problem)
    mismatch = np.abs(P @ theta - base) / bscale
    if mismatch.max() > 1e-6:
        return None, f"solver status '{status}', base parameters reproduced only to {mismatch.max():.1e}"
    report = check_consistency(theta, problem.model.joint_names, problem.terms.names, problem.model.motor_names)
    if not report.consistent:
        return None, "; ".join(report.problems)
    return theta, status


def pseudo_inertia_map(S: np.ndarray, i: int, p: int) -> np.ndarray:
    """(16, p) map from z = θ/S (``S`` the column scale) to the column-major vec of body ``i``'s pseudo-inertia
    in its own scale (mass and length of ``S``): what :func:`add_consistency_constraints` keeps PSD."""
    S = as_floats(S, "S")
    i, p = count(i, "i"), count(p, "p", low=1)
    if S.ndim != 1 or len(S) < 10 * (i + 1):
        raise SpecError(f"S: shape {S.shape}, expected a column scale of at least {10 * (i + 1)} values")
    M = S[10 * i]
    L = np.sqrt(S[10 * i + 4] / M)
    T = np.diag([1.0 / (np.sqrt(M) * L)] * 3 + [1.0 / np.sqrt(M)])
    B = np.zeros((16, p))
    for k in range(10):
        B[:, 10 * i + k] = (T @ PSEUDO_INERTIA_BASIS[k] @ T).reshape(-1, order="F") * S[10 * i + k]
    return B

"""Physically consistent least squares: a semidefinite program (Clarabel, stated with :mod:`pinid.model.conic`).

Decision variable: the full standard parameter vector θ (10 per body + joint terms), so that physical
consistency can be imposed on every body.  Problem::

    minimise    ‖R·C·P·θ − c‖ / ‖y‖  +  λ·‖N·S⁻¹(θ − θ_nominal)‖
    subject to  J_i(θ) ⪰ ε·M_i·diag(L_i², L_i², L_i², 1)     every body i (pseudo-inertia LMI)
                fc ≥ 0, fv ≥ 0, armature ≥ 0                 every joint (when in the model)
                m_lo ≤ m_i ≤ m_hi                              optional mass bounds

* The data term is ‖W_b·P·θ − τ‖ (rows weighted), compressed by one pass over the column-scaled
  ``[W_b | τ]`` (:func:`~pinid.linalg.augmented_r`): ``‖W_b x − τ‖² = ‖R·C·x − c‖² + ρ²`` with
  ``R`` only nb × nb, so the solver never sees the tall regressor (docs/benchmarks.md, memory).  It is the *norm* of the excess
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

import numpy as np

from pinid.errors import SolverError, SpecError
from pinid.estimators.base import Estimator, Setting, joint_weights
from pinid.problem.problem import IdentificationProblem, Problem
from pinid.linalg import augmented_r, solve_r
from pinid.model.conic import ConicProblem
from pinid.model.lmi import add_consistency_constraints, clip_terms, null_projector
from pinid.model.physical import check_consistency, parameter_scale


class SDP(Estimator):
    """Physically consistent least squares (LMI on every body's pseudo-inertia; see the module text).

    Settings: ``weighting`` ("none" or "joint"), ``regularization`` (weight λ of the pull toward the
    nominal parameters in unidentifiable directions, default 1e-3), ``mass_bounds`` (``(lo, hi)`` [kg]
    for every body, or ``{joint: (lo, hi)}``; None for none), ``margin`` (ε, default 1e-8), ``solver``
    ("CLARABEL", the default, is called directly; any other name is a cvxpy solver, cvxpy then loaded), ``solver_options`` (dict passed to the solver).

    Named after its registry name ``"sdp"`` (how it is solved: a semidefinite program), as the other
    estimators are (OLS, WLS, RLS, ...): the name users type (``--methods ols,sdp``), find in saved
    results and in the seed papers' tables.
    """

    name = "sdp"
    summary = (
        "physically consistent least squares: semidefinite program in the full standard vector θ, Clarabel "
        "(`pinid.model.conic`; another `solver` through cvxpy)"
    )
    assumptions = "as OLS, plus: the robot is made of rigid bodies with non-negative mass, friction and armature"
    settings_summary = (
        '`weighting` ("none"; "joint" weights as WLS), `regularization` (1e-3), `mass_bounds` (None; `(lo, '
        'hi)` kg for every body or `{joint: (lo, hi)}`), `margin` (1e-8), `solver` ("CLARABEL"), '
        "`solver_options`"
    )
    description = "physically consistent least squares (pseudo-inertia LMI, Clarabel)"
    consistent_by_construction = True
    fits_standard = True
    colour = "#2ca02c"
    settings = {
        "weighting": Setting("str", choices=("none", "joint"), help="row weighting: none (as OLS) or joint (as WLS)"),
        "regularization": Setting(
            "float", low=0.0, help="weight of the pull toward the URDF in unidentifiable directions"
        ),
        "mass_bounds": Setting("any", optional=True, help="(lo, hi) [kg] for every body, or {joint: (lo, hi)}"),
        "margin": Setting("float", low=0.0, help="ε of the strict pseudo-inertia LMI"),
        "solver": Setting("str", help="CLARABEL (called directly) or another cvxpy solver name"),
        "solver_options": Setting("dict", optional=True, help="passed to the solver"),
    }

    def __init__(
        self,
        weighting: str = "none",
        regularization: float = 1e-3,
        mass_bounds=None,
        margin: float = 1e-8,
        solver: str = "CLARABEL",
        solver_options: dict | None = None,
    ) -> None:
        self.weighting = weighting
        self.regularization = regularization
        self.mass_bounds = mass_bounds
        self.margin = margin
        self.solver = solver
        self.solver_options = solver_options

    def fit(self, problem: IdentificationProblem) -> "SDP":
        """Solve the LMI-constrained least squares; sets ``base_``, ``standard_`` and the solver's ``status_``; SolverError if it fails."""
        if self.weighting not in ("none", "joint"):
            raise ValueError(f"sdp: weighting={self.weighting!r}, expected 'none' or 'joint'")
        if not self.regularization >= 0:
            raise ValueError(f"sdp: regularization={self.regularization}, expected ≥ 0")
        w = problem.weights
        if self.weighting == "joint":
            R0, c0, _, s0 = problem.compressed()
            x = solve_r(R0, c0, s0)
            blocked = getattr(problem, "blocked", False)  # then W is never built whole (issue 35)
            if blocked:
                problem.as_whole = True  # its sums as over the whole W, which it built before issue 35
            jw, _ = joint_weights(problem, problem.residual(x) if blocked else problem.tau - problem.W @ x)
            w = w * jw
            if blocked:
                R, c, rho, colscale = problem.weighted_compressed(w)
            else:
                R, c, rho, colscale = augmented_r(problem.W, problem.tau, w)
        else:
            R, c, rho, colscale = problem.compressed()
        norm_y = float(np.sqrt(c @ c + rho * rho)) or 1.0
        P = problem.base.P
        nv, nt = problem.nv, len(problem.terms)
        S = parameter_scale(problem.nominal, nv, nt)
        G = (R * colscale) @ P * S / norm_y  # z = θ/S  ->  excess residual (relative)
        g = c / norm_y
        conic = ConicProblem(P.shape[1])
        conic.add_norm(G, g)
        reg = None
        if self.regularization > 0:
            N = null_projector(P * S)
            if N is not None:
                reg = conic.add_norm(N, N @ (problem.nominal / S), float(self.regularization))
        add_consistency_constraints(conic, problem, S, self.margin, self.mass_bounds)
        solution = conic.solve(self.solver, self.solver_options, "sdp")
        status = solution.status
        theta = solution.z * S
        # clip tiny negative joint terms the interior-point solver leaves at −1e-12
        theta = clip_terms(theta, problem)
        report = check_consistency(theta, problem.model.joint_names, problem.terms.names, problem.model.motor_names)
        if not report.consistent:
            raise SolverError(
                f"sdp: solver {self.solver} status '{status}', but the result is not physically "
                f"consistent ({'; '.join(report.problems)}); not returned"
            )
        self.standard_ = theta
        self.base_ = P @ theta
        self.weights_ = w
        self.history_ = None
        self.status_ = status
        excess = float(np.linalg.norm(G @ (theta / S) - g))
        self.info_ = {
            "solver": self.solver,
            "status": status,
            "solve_seconds": solution.solve_seconds,
            "excess_residual_relative": excess,
            "regularizer": None if reg is None else solution.norms[reg],
        }
        return self

    def fit_stage(
        self,
        problem: IdentificationProblem,
        sub: Problem,
        cols: np.ndarray,
        *,
        fixed: tuple[np.ndarray, np.ndarray] | None = None,
        what: str = "sdp stage",
    ) -> tuple[np.ndarray, dict]:
        """One stage of a staged fit (seed 000's segmental strategy): a physically consistent θ of ``problem``
        whose base parameters ``cols`` fit ``sub``'s rows (``sub.W``'s columns are those base parameters),
        and whose base parameters ``fixed[0]`` equal ``fixed[1]``.  Returns ``(θ, {"status", "rows"})``."""
        if self.weighting != "none":
            raise SpecError("segmental sdp: only weighting='none'")
        regularization = self.regularization
        P = problem.base.P
        nv, nt = problem.nv, len(problem.terms)
        S = parameter_scale(problem.nominal, nv, nt)
        R, c, rho, colscale = sub.compressed()
        norm_y = float(np.sqrt(c @ c + rho * rho)) or 1.0
        G = (R * colscale) @ P[cols] * S / norm_y
        g = c / norm_y
        conic = ConicProblem(P.shape[1])
        conic.add_norm(G, g)
        seen = P[cols] if fixed is None else P
        N = null_projector(seen * S) if regularization > 0 else None
        if N is not None:
            conic.add_norm(N, N @ (problem.nominal / S), float(regularization))
        add_consistency_constraints(conic, problem, S, self.margin, self.mass_bounds)
        if fixed is not None:
            A = P[fixed[0]] * S
            rs = np.maximum(np.abs(A).sum(axis=1), 1e-300)
            conic.add_equality(A / rs[:, None], np.asarray(fixed[1], float) / rs)
        solution = conic.solve(self.solver, self.solver_options, what)
        status = solution.status
        theta = clip_terms(solution.z * S, problem)
        report = check_consistency(theta, problem.model.joint_names, problem.terms.names, problem.model.motor_names)
        if not report.consistent:
            raise SolverError(
                f"{what}: status '{status}' but the result is not physically consistent ({'; '.join(report.problems)})"
            )
        return theta, {"status": status, "rows": sub.rows}


__all__ = ["SDP"]

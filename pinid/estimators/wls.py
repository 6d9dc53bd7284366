"""Weighted least squares: each joint's rows weighted by the inverse of its residual variance."""

from __future__ import annotations

import numpy as np

from pinid.estimators.base import Estimator, Setting, joint_weights
from pinid.problem.problem import Problem
from pinid.linalg import solve_r, weighted_lstsq


class WLS(Estimator):
    """Weighted least squares (Gautier's weighting).

    A first least-squares pass gives the residual of every row; each joint's rows are weighted by
    1/σ_j², σ_j² the residual variance of that joint; the weighted problem is solved again.  With
    ``iterations > 1`` the weights are re-estimated from the weighted fit's residuals that many times
    (stopping early when the base parameters change by less than ``tol`` relatively).

    Assumes independent torque errors whose variance differs between joints (different sensors,
    gear ratios, torque ranges) but not in time.  On data where one joint's torques are much larger,
    OLS lets that joint dominate; WLS gives each joint an equal say per unit of its own noise.
    """

    name = "wls"
    description = "least squares, each joint weighted by 1/(its residual variance)"
    colour = "grey"
    history = "passes"
    settings = {
        "iterations": Setting("int", low=1, help="reweighting passes"),
        "tol": Setting("float", low=0.0, help="stop when the parameters change less than this, relatively"),
    }

    def __init__(self, iterations: int = 1, tol: float = 1e-10) -> None:
        self.iterations = iterations
        self.tol = tol

    def fit(self, problem: Problem) -> "WLS":
        """OLS, then least squares with each joint's rows weighted by 1/σ_j²; sets ``base_`` and ``sigma_`` [N·m]."""
        if int(self.iterations) < 1:
            raise ValueError(f"WLS: iterations={self.iterations}, expected ≥ 1")
        R, c, _, scale = problem.compressed()
        x = solve_r(R, c, scale)
        history = []
        sigma = None
        for _ in range(int(self.iterations)):
            r = problem.tau - problem.W @ x
            w, sigma = joint_weights(problem, r)
            w = w * problem.weights
            x_new = weighted_lstsq(problem.W, problem.tau, w)
            r_new = problem.tau - problem.W @ x_new
            history.append(float(np.sum(w * r_new**2)))
            change = np.linalg.norm(x_new - x) / max(np.linalg.norm(x_new), 1e-300)
            x = x_new
            if change < self.tol:
                break
        self.base_ = x
        self.standard_ = None
        self.weights_ = w
        self.history_ = history
        self.status_ = "ok"
        self.info_ = {"joint_sigma": {n: float(s) for n, s in zip(problem.model.joint_names, sigma)}}
        return self

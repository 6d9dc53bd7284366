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
    summary = "each joint's rows weighted by 1/σ_j², σ_j² that joint's residual variance from an OLS pass"
    assumptions = "errors independent, variance differs between joints (sensors, torque ranges), constant in time"
    settings_summary = "`iterations` (1: one reweighting; more re-estimate σ_j from the weighted fit), `tol` (1e-10)"
    description = "least squares, each joint weighted by 1/(its residual variance)"
    colour = "#ff7f0e"
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
        blocked = getattr(problem, "blocked", False)  # then W is never built whole (issue 35)
        if blocked:
            problem.as_whole = True  # its sums as over the whole W, which wls built before issue 35
        for _ in range(int(self.iterations)):
            r = problem.residual(x) if blocked else problem.tau - problem.W @ x
            w, sigma = joint_weights(problem, r)
            del r
            np.multiply(w, problem.weights, out=w)
            if blocked:
                x_new = solve_r(*_compressed_weighted(problem, w))
            else:
                x_new = weighted_lstsq(problem.W, problem.tau, w)
            e = problem.residual(x_new) if blocked else problem.tau - problem.W @ x_new
            np.square(e, out=e)
            history.append(float(np.sum(np.multiply(w, e, out=e))))  # Σ w·r², in one array of rows
            del e
            change = np.linalg.norm(x_new - x) / max(np.linalg.norm(x_new), 1e-300)
            x = x_new
            if change < self.tol:
                break
        self.base_ = x
        self.standard_ = None
        del w  # weights_ forms it again when read (below): a fitted WLS holds no array of rows
        self.__dict__["_weight_rows_"] = (problem.joint, problem.weights, sigma)
        self.history_ = history
        self.status_ = "ok"
        self.info_ = {"joint_sigma": {n: float(s) for n, s in zip(problem.model.joint_names, sigma)}}
        return self


def _weights(self: WLS) -> np.ndarray | None:
    rows = self.__dict__.get("_weight_rows_")
    if rows is None:
        return self.__dict__.get("_given_weights_")
    joint, weights, sigma = rows
    w = (1.0 / sigma**2)[joint]
    return np.multiply(w, weights, out=w)  # the fit's weights, the same operations


def _set_weights(self: WLS, value: np.ndarray | None) -> None:
    self.__dict__["_given_weights_"], self.__dict__["_weight_rows_"] = value, None


WLS.weights_ = property(
    _weights,
    _set_weights,
    doc="(rows,) the row weights of the fit: 1/σ_j² of each row's joint times ``problem.weights``, formed when "
    "read from σ (issue 35: not held, 8 bytes per row).",
)


def _compressed_weighted(problem: Problem, w: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(R, c, scale)`` of the weighted problem, without the tall ``W`` (the problem's blocks)."""
    R, c, _, scale = problem.weighted_compressed(w)
    return R, c, scale

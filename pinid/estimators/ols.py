"""Ordinary least squares on the base regressor."""

from __future__ import annotations

from pinid.estimators.base import Estimator
from pinid.problem.problem import Problem
from pinid.linalg import solve_r


class OLS(Estimator):
    """Ordinary least squares: ``argmin ‖W_b·x − τ‖²`` (rows weighted by ``problem.weights``, ones by default).

    Assumes independent torque errors of equal variance on every row (all joints alike) and regressor
    columns measured without error.  The solution is the global minimiser of the squared torque error
    on the training data.  Computed by a column-scaled QR factorisation (numerically safer than the
    normal equations).  No settings.
    """

    name = "ols"
    summary = (
        "least squares on the base regressor (column-scaled Cholesky of the Gram matrix; Householder QR when "
        "its condition number exceeds 1e10)"
    )
    assumptions = "independent torque errors of equal variance on every row, regressor without error"
    settings_summary = "none"
    description = "ordinary least squares on the base regressor"
    colour = "#1f77b4"

    def __init__(self) -> None:
        pass

    def fit(self, problem: Problem) -> "OLS":
        """Least squares on the base regressor; sets ``base_``."""
        R, c, rho, scale = problem.compressed()
        self.base_ = solve_r(R, c, scale)
        self.standard_ = None
        self.weights_ = None
        self.history_ = None
        self.status_ = "ok"
        self.info_ = {"residual_norm": rho}
        return self

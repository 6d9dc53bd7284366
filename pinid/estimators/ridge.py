"""Ridge-regularised least squares: least squares pulled toward a prior (the URDF's base parameters).

The worked example of docs/architecture.md ("adding an estimator"): this file and one line in the
registry are all it took.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from pinid.estimators.base import Estimator, Setting
from pinid.problem.problem import Problem


class Ridge(Estimator):
    """Least squares with a Tikhonov term toward a prior, in column-scaled coordinates.

    Minimises ``‖diag(√w)(W x − τ)‖² + alpha·‖D (x − x_prior)‖²`` with ``D`` the column norms of
    ``diag(√w)·W`` (so ``alpha`` is dimensionless: the penalty weighs every parameter by how strongly
    the data see it), ``x_prior`` the URDF's base parameters (``prior="nominal"``) or zero
    (``prior="zero"``).  ``alpha = 0`` is ordinary least squares.  Useful when the excitation leaves
    some base parameters poorly determined: those stay near the prior instead of wandering off.
    """

    name = "ridge"
    assumptions = "as OLS, plus: the URDF's base parameters are a useful prior where the data say little"
    description = "ridge-regularised least squares toward the URDF's base parameters"
    colour = "#000080"
    settings = {
        "alpha": Setting("float", low=0.0, help="weight of the pull toward the prior (dimensionless)"),
        "prior": Setting("str", choices=("nominal", "zero"), help="the prior: the URDF's values or zero"),
    }

    def __init__(self, alpha: float = 1e-4, prior: str = "nominal") -> None:
        self.alpha = alpha
        self.prior = prior

    def fit(self, problem: Problem) -> "Ridge":
        """Solve the regularised normal equations on the compressed problem; sets ``base_``."""
        R, c, _, scale = problem.compressed()  # ‖A z − y‖² = ‖R z − c‖² + ρ², z = scale·x
        z0 = scale * (problem.nominal_base if self.prior == "nominal" else np.zeros(problem.nb))
        G = R.T @ R + float(self.alpha) * np.eye(problem.nb)
        z = scipy.linalg.solve(G, R.T @ c + float(self.alpha) * z0, assume_a="pos")
        self.base_ = z / scale
        self.standard_ = None
        self.weights_ = None
        self.history_ = None
        self.status_ = "ok"
        self.info_ = {"alpha": float(self.alpha), "prior": self.prior}
        return self

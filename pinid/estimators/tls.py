"""Total least squares (errors in variables) on ``[W | τ]`` by the SVD, with column scaling.

Least squares treats the regressor as exact and puts every error on the torque.  Total least squares
lets both be wrong: it finds the smallest perturbation ``[ΔW | Δτ]`` (Frobenius norm) that makes
``(W + ΔW)·β = τ + Δτ`` solvable — the right singular vector ``v`` of ``[W | τ]`` for its smallest singular
value gives ``β = −v[:nb] / v[nb]`` (Golub & Van Loan).

**Column scaling.**  TLS is consistent only when the errors of all columns are independent with equal
variance, which a regressor's columns (masses, inertias, friction; N·m per unit of very different
quantities) never are.  pinid scales every column of ``diag(√w)·W`` to unit norm and the torque column to
unit norm too (``scaling="norm"``, the default, the usual choice when the error variances are unknown), or
leaves them as they are (``scaling="none"``); the result is unscaled afterwards.  The scaling changes the
estimate under noise (not on noise-free data, where ``[W | τ]`` has an exact null vector and TLS returns
the truth).  The tall matrix is never decomposed: with the compressed form ``(R, c, ρ)`` of
:meth:`~pinid.problem.problem.IdentificationProblem.compressed`, ``[[R, c], [0, ρ]]`` has the
same right singular vectors as the (column-scaled) ``[W | τ]``, so the SVD is (nb+1) × (nb+1).

TLS has no physically consistent variant here (its cost is not a norm of a linear residual, so the
LMI problem of ``sdp`` does not apply); results are checked for consistency afterwards as for OLS.
"""

from __future__ import annotations

import numpy as np

from pinid.errors import SolverError
from pinid.estimators.base import Estimator, Setting
from pinid.problem.problem import Problem


class TLS(Estimator):
    """Total least squares on ``[W | τ]`` by the SVD of its compressed form (module text).

    Settings: ``scaling`` ("norm": every column of ``W`` and ``τ`` to unit norm, the default; "none").
    """

    name = "tls"
    summary = "total least squares on `[W | τ]` (smallest right singular vector of its compressed form)"
    assumptions = (
        "errors in every column, independent and of equal variance after the column scaling (`scaling`: "
        '"norm", unit-norm columns of W and τ; or "none")'
    )
    settings_summary = '`scaling` ("norm")'
    description = "total least squares (errors in variables) on [W | τ], columns scaled to unit norm"
    colour = "#008080"
    settings = {
        "scaling": Setting("str", choices=("norm", "none"), help="column scaling of [W | τ] before the SVD"),
    }

    def __init__(self, scaling: str = "norm") -> None:
        self.scaling = scaling

    def fit(self, problem: Problem) -> "TLS":
        """The smallest right singular vector of the scaled ``[W | τ]``; sets ``base_`` and ``info_["sigma_min"]``."""
        R, c, rho, scale = problem.compressed()
        nb = len(c)
        T = np.zeros((nb + 1, nb + 1))
        T[:nb, :nb], T[:nb, nb], T[nb, nb] = R, c, rho  # columns: W/scale (unit norm), then τ
        norm_tau = float(np.sqrt(c @ c + rho * rho)) or 1.0
        col = np.ones(nb + 1)
        if self.scaling == "norm":
            col[nb] = 1.0 / norm_tau
        else:
            col[:nb] = scale  # back to W's own columns
        _, s, Vt = np.linalg.svd(T * col)
        v = Vt[-1]
        if abs(v[nb]) <= 1e-14 * np.abs(v).max():
            raise SolverError("tls: the smallest singular vector has no torque component (τ is not explained by W)")
        y = -v[:nb] / v[nb]  # in the scaled coordinates: (W/… col)·y ≈ τ·col[nb]
        x = y * col[:nb] / col[nb]
        self.base_ = x / scale
        self.standard_ = None
        self.weights_ = None
        self.history_ = None
        self.status_ = "ok"
        self.info_ = {"sigma_min": float(s[-1]), "sigma_ratio": float(s[-1] / s[-2]) if s[-2] > 0 else None}
        return self

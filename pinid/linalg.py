"""Least-squares kernels shared by the problem and the estimators, and the rank tolerance.

A tall weighted least-squares problem ``min ‖diag(√w)(W x − τ)‖`` is compressed once into an
``nb × nb`` triangle (:func:`augmented_r`) that every estimator and statistic reuses.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from pinid.errors import SolverError

#: Relative tolerance on singular values (or pivots, or Gram eigenvalues) below which a matrix counts as
#: rank deficient: used for the regressor's rank check, the choice Cholesky vs QR, and null spaces.
RANK_TOL = 1e-10
#: Relative pivot below which a triangular solve refuses (stricter than :data:`RANK_TOL`: the rank was
#: already checked on the problem; this only guards against a numerically singular triangle).
SOLVE_TOL = 1e-13


def augmented_r(
    W: np.ndarray, tau: np.ndarray, weights: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, float, np.ndarray]:
    """Compress a weighted least-squares problem: ``(R, c, rho, scale)``.

    With ``A = diag(√w)·W·diag(1/scale)`` (columns scaled to unit norm) and ``y = √w·τ``,
    ``‖A x − y‖² = ‖R x − c‖² + rho²`` for every ``x``: ``R`` is ``(nb, nb)`` upper triangular, ``rho``
    the least-squares residual norm.  One pass over the tall matrix: the Cholesky factor of the
    column-scaled Gram matrix ``AᵀA`` when its condition number is below 1e10 (then the normal
    equations lose at most ~1e-6 relative accuracy, far below any noise), else — and for rank
    deficiency — Householder QR of ``[A | y]``.
    """
    W = np.asarray(W, dtype=float)
    y = np.asarray(tau, dtype=float)
    nb = W.shape[1]
    if weights is not None and not np.all(weights == 1.0):
        w = np.asarray(weights, dtype=float)
        Ww = W * w[:, None]
        G = Ww.T @ W
        b = Ww.T @ y
        yy = float(np.dot(w * y, y))
        del Ww
    else:
        w = None
        G = W.T @ W
        b = W.T @ y
        yy = float(np.dot(y, y))
    scale = np.sqrt(np.maximum(np.diag(G), 0.0))
    scale[scale == 0] = 1.0
    Gs = G / np.outer(scale, scale)
    ev = np.linalg.eigvalsh(Gs) if nb else np.ones(1)
    if nb and ev[0] > RANK_TOL * ev[-1] and np.all(np.isfinite(Gs)):
        try:
            R = scipy.linalg.cholesky(Gs, lower=False)
            c = scipy.linalg.solve_triangular(R, b / scale, trans="T")
            rho = float(np.sqrt(max(yy - float(c @ c), 0.0)))
            return R, c, rho, scale
        except (np.linalg.LinAlgError, ValueError):
            pass
    # ill-conditioned or rank-deficient: Householder QR of the scaled, weighted [A | y]
    aug = np.empty((W.shape[0], nb + 1))
    if w is not None:
        sw = np.sqrt(w)
        np.multiply(W, (sw[:, None] / scale), out=aug[:, :nb])
        aug[:, nb] = y * sw
    else:
        np.divide(W, scale, out=aug[:, :nb])
        aug[:, nb] = y
    R_aug = np.linalg.qr(aug, mode="r")
    k = min(R_aug.shape[0], nb + 1)
    R_full = np.zeros((nb + 1, nb + 1))
    R_full[:k] = R_aug[:k]
    return R_full[:nb, :nb], R_full[:nb, nb], float(abs(R_full[nb, nb])), scale


def solve_r(R: np.ndarray, c: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """The least-squares solution ``x`` of the compressed problem of :func:`augmented_r`."""
    d = np.abs(np.diag(R))
    if d.size and (not np.all(np.isfinite(R)) or d.min() <= SOLVE_TOL * d.max()):
        raise SolverError("least squares: the (weighted) base regressor is rank deficient")
    return scipy.linalg.solve_triangular(R, c) / scale


def weighted_lstsq(W: np.ndarray, tau: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """``argmin ‖diag(√w)(W x − τ)‖²`` through a column-scaled QR factorisation."""
    R, c, _, scale = augmented_r(W, tau, weights)
    return solve_r(R, c, scale)
